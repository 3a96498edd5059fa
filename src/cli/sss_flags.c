/* sss_flags.c: the material, scale and light flags that `obscura sss` and `obscura truth sss`
 * share, and the scene preparation both do (docs/sss.md, docs/cli.md). */
#include "cli_sss.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *cli_sss_help_material_light =
    "material (one of; default --from-scene):\n"
    "  --material NAME       every mesh is translucent with a Jensen 2001 preset (apple, chicken1,\n"
    "                        chicken2, cream, ketchup, marble, potato, skimmilk, skin1, skin2,\n"
    "                        spectralon, wholemilk)\n"
    "  --from-scene          materials whose glTF extras carry \"obscura_sss\" (docs/sss.md) are\n"
    "                        translucent; the others are opaque (black here, they still cast shadows)\n"
    "  --sigma-s-prime R,G,B --sigma-a R,G,B --eta E   a user material (per mm; all three needed)\n"
    "  --scale-mm S          millimetres per scene unit (default 1000: glTF units are metres)\n"
    "light (default: the scene's directional and point lights; none: one from the camera's upper right):\n"
    "  --light-dir X,Y,Z     replace the scene's lights by a directional light travelling along X,Y,Z (world)\n"
    "  --light-intensity I   its irradiance (default 1)\n";

void cli_sss_options_init(cli_sss_options *o)
{
    memset(o, 0, sizeof *o);
    o->mm_per_unit = SSS_DEFAULT_MM_PER_UNIT;
    o->light_intensity = 1.0;
}

int cli_sss_flag(cli_sss_options *o, int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    const char *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    if (!strcmp(a, "--material")) {
        if (!v) return cli_usage_error("--material needs a preset name"), -1;
        o->material_name = v;
    } else if (!strcmp(a, "--from-scene")) {
        o->from_scene = 1;
        return 1;
    } else if (!strcmp(a, "--sigma-s-prime") || !strcmp(a, "--sigma-a")) {
        const int sp = !strcmp(a, "--sigma-s-prime");
        if (!cli_parse_triple(v, sp ? o->sigma_s_prime : o->sigma_a))
            return cli_usage_error("%s needs R,G,B (three finite numbers, per mm)", a), -1;
        if (sp) o->sigma_s_prime_given = 1; else o->sigma_a_given = 1;
    } else if (!strcmp(a, "--eta")) {
        if (!cli_parse_float(v, &o->eta)) return cli_usage_error("--eta needs a number"), -1;
        o->eta_given = 1;
    } else if (!strcmp(a, "--scale-mm")) {
        if (!cli_parse_float(v, &o->mm_per_unit) || !(o->mm_per_unit > 0) || !isfinite(o->mm_per_unit))
            return cli_usage_error("--scale-mm needs a number > 0 (millimetres per scene unit)"), -1;
    } else if (!strcmp(a, "--light-dir")) {
        if (!cli_parse_triple(v, o->light_dir) || (o->light_dir[0] == 0 && o->light_dir[1] == 0 && o->light_dir[2] == 0))
            return cli_usage_error("--light-dir needs X,Y,Z, not all zero"), -1;
        o->light_dir_given = 1;
    } else if (!strcmp(a, "--light-intensity")) {
        if (!cli_parse_float(v, &o->light_intensity) || !(o->light_intensity >= 0) || !isfinite(o->light_intensity))
            return cli_usage_error("--light-intensity needs a number >= 0"), -1;
    } else {
        return 0;
    }
    (*i)++;
    return 1;
}

int cli_sss_options_check(const cli_sss_options *o, const char *command)
{
    const int user = o->sigma_s_prime_given || o->sigma_a_given || o->eta_given;
    if (user && !(o->sigma_s_prime_given && o->sigma_a_given && o->eta_given))
        return cli_usage_error("%s: a user material needs all of --sigma-s-prime, --sigma-a and --eta", command);
    if ((o->material_name != NULL) + user + o->from_scene > 1)
        return cli_usage_error("%s: give one of --material, the user material flags and --from-scene", command);
    return 0;
}

/* The default light when the scene has none: directional, from the camera's upper right and behind
 * the viewer (view-space direction towards the light normalize(0.35, 0.6, 0.72), as `obscura ao`'s
 * blend), white. */
static obs_light default_light(const obs_camera *cam, double intensity)
{
    obs_light L;
    memset(&L, 0, sizeof L);
    snprintf(L.name, sizeof L.name, "default (camera upper right)");
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.color = (obs_vec3){1.0f, 1.0f, 1.0f};
    L.intensity = (float)intensity;
    const double lv[3] = {0.35, 0.6, 0.72};
    const double n = sqrt(lv[0] * lv[0] + lv[1] * lv[1] + lv[2] * lv[2]);
    const float *m = cam->world.m; /* column-major camera -> world */
    double d[3];
    for (int r = 0; r < 3; r++)
        d[r] = -(m[r] * lv[0] + m[4 + r] * lv[1] + m[8 + r] * lv[2]) / n;
    const double dn = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    L.direction = (obs_vec3){(float)(d[0] / dn), (float)(d[1] / dn), (float)(d[2] / dn)};
    return L;
}

obs_status cli_sss_prepare(obs_context *ctx, const cli_sss_options *o, const char *scene_path, obs_scene *scene,
                           const obs_camera *cam, sss_scene_setup *setup)
{
    sss_material mat;
    memset(&mat, 0, sizeof mat);
    const int user = o->sigma_s_prime_given && o->sigma_a_given && o->eta_given;
    obs_status st = OBS_STATUS_OK;
    if (o->material_name) {
        st = sss_material_find(ctx, o->material_name, &mat);
    } else if (user) {
        snprintf(mat.name, sizeof mat.name, "user");
        for (int c = 0; c < 3; c++) {
            mat.sigma_s[c] = o->sigma_s_prime[c];
            mat.sigma_a[c] = o->sigma_a[c];
        }
        mat.eta = o->eta;
        st = sss_material_validate(ctx, &mat, "command line");
    }
    if (st == OBS_STATUS_OK)
        st = sss_scene_setup_make(ctx, scene, (o->material_name || user) ? &mat : NULL, o->mm_per_unit, setup);
    if (st == OBS_STATUS_OK && !sss_scene_setup_any_translucent(setup, scene))
        st = obs_error(ctx, OBS_STATUS_NOT_FOUND,
                       "%s: no translucent material: no material carries \"obscura_sss\" in its extras "
                       "(docs/sss.md); give --material NAME to make every mesh translucent", scene_path);
    if (st != OBS_STATUS_OK)
        return st;
    /* The effective lights replace the scene's (the passes and the references read scene->lights). */
    obs_light *lights = (obs_light *)calloc(scene->light_count + 1, sizeof *lights);
    if (!lights)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    uint32_t n = 0;
    if (o->light_dir_given) {
        const double *d = o->light_dir;
        const double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        obs_light *L = &lights[n++];
        snprintf(L->name, sizeof L->name, "--light-dir");
        L->type = OBS_LIGHT_DIRECTIONAL;
        L->color = (obs_vec3){1.0f, 1.0f, 1.0f};
        L->intensity = (float)o->light_intensity;
        L->direction = (obs_vec3){(float)(d[0] / len), (float)(d[1] / len), (float)(d[2] / len)};
    } else {
        for (uint32_t l = 0; l < scene->light_count; l++) {
            if (scene->lights[l].type == OBS_LIGHT_SPOT) {
                free(lights);
                return obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                                 "%s: light %u (%s) is a spot light; subsurface scattering supports directional and "
                                 "point lights (docs/sss.md); pass --light-dir to use a directional light instead",
                                 scene_path, l, scene->lights[l].name);
            }
            lights[n++] = scene->lights[l];
        }
        if (n == 0)
            lights[n++] = default_light(cam, o->light_intensity);
    }
    free(scene->lights);
    scene->lights = lights;
    scene->light_count = n;
    return OBS_STATUS_OK;
}

int cli_sss_exit_for(obs_context *ctx, obs_status st)
{
    /* An unknown preset is a command-line mistake: a usage error with the list of names. */
    if (st == OBS_STATUS_NOT_FOUND && strstr(obs_context_last_error(ctx), "preset")) {
        fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
        return CLI_EXIT_USAGE;
    }
    return cli_fail(ctx, st);
}

void cli_sss_json_setup(io_json *j, const cli_sss_options *o, const sss_scene_setup *setup, const obs_scene *scene)
{
    io_json_number(j, "mm_per_unit", o->mm_per_unit);
    io_json_begin_array(j, "materials");
    for (uint32_t m = 0; m < setup->mats.count; m++) {
        if (!setup->mats.translucent[m])
            continue;
        const sss_material *sm = &setup->mats.constants[m].material;
        io_json_begin_object(j, NULL);
        io_json_int(j, "slot", m);
        io_json_string(j, "name", sm->name);
        float v3[3];
        for (int c = 0; c < 3; c++) v3[c] = (float)sm->sigma_s[c];
        io_json_floats(j, "sigma_s_per_mm", v3, 3);
        for (int c = 0; c < 3; c++) v3[c] = (float)sm->sigma_a[c];
        io_json_floats(j, "sigma_a_per_mm", v3, 3);
        io_json_number(j, "g", sm->g);
        io_json_number(j, "eta", sm->eta);
        io_json_end_object(j);
    }
    io_json_end_array(j);
    if (setup->uses_override)
        io_json_string(j, "material_override", setup->none_constants.material.name);
    io_json_begin_array(j, "lights");
    for (uint32_t l = 0; l < scene->light_count; l++) {
        const obs_light *L = &scene->lights[l];
        io_json_begin_object(j, NULL);
        io_json_string(j, "name", L->name);
        io_json_string(j, "type", L->type == OBS_LIGHT_DIRECTIONAL ? "directional" : "point");
        io_json_number(j, "intensity", L->intensity);
        float v3[3] = {L->color.x, L->color.y, L->color.z};
        io_json_floats(j, "color", v3, 3);
        float d3[3] = {L->direction.x, L->direction.y, L->direction.z};
        float p3[3] = {L->position.x, L->position.y, L->position.z};
        io_json_floats(j, L->type == OBS_LIGHT_DIRECTIONAL ? "direction" : "position",
                       L->type == OBS_LIGHT_DIRECTIONAL ? d3 : p3, 3);
        io_json_end_object(j);
    }
    io_json_end_array(j);
}
