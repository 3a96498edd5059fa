/* cli_sss.h: what `obscura sss` and `obscura truth sss` share (sss_flags.c). Not a library header. */
#ifndef OBS_CLI_SSS_H
#define OBS_CLI_SSS_H

#include "cli.h"
#include "sss/sss.h"

typedef struct cli_sss_options {
    const char *material_name;       /* --material */
    int from_scene;                  /* --from-scene */
    double sigma_s_prime[3], sigma_a[3], eta;   /* a user material */
    int sigma_s_prime_given, sigma_a_given, eta_given;
    double mm_per_unit;              /* --scale-mm */
    double light_dir[3];             /* --light-dir */
    int light_dir_given;
    double light_intensity;          /* --light-intensity */
} cli_sss_options;

extern const char *cli_sss_help_material_light;
void cli_sss_options_init(cli_sss_options *o);
/* Consume one of the shared flags at argv[*i]: 1 consumed, 0 not one of them, -1 usage error (printed). */
int cli_sss_flag(cli_sss_options *o, int argc, char **argv, int *i);
/* Usage checks across flags: 0, or CLI_EXIT_USAGE after printing. */
int cli_sss_options_check(const cli_sss_options *o, const char *command);
/* Resolve the materials (setup) and replace scene->lights by the effective lights: --light-dir, else
 * the scene's directional and point lights (a spot light is UNSUPPORTED), else one from the
 * camera's upper right. NOT_FOUND when nothing is translucent (the message names the file). */
obs_status cli_sss_prepare(obs_context *ctx, const cli_sss_options *o, const char *scene_path, obs_scene *scene,
                           const obs_camera *cam, sss_scene_setup *setup);
/* The exit code for a failure of the above (an unknown preset is a usage error). */
int cli_sss_exit_for(obs_context *ctx, obs_status st);
/* The sidecar's "mm_per_unit", "materials" (the translucent slots) and "lights" (the effective ones). */
void cli_sss_json_setup(io_json *j, const cli_sss_options *o, const sss_scene_setup *setup, const obs_scene *scene);

#endif
