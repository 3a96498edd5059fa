/* cli.h: shared pieces of the obscura command (not a library header). */
#ifndef OBS_CLI_H
#define OBS_CLI_H

#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "scale/scale.h"

/* Exit codes (docs/cli.md). */
enum {
    CLI_EXIT_OK = 0,
    CLI_EXIT_THRESHOLD = 1,   /* a comparison is outside its thresholds (compare) */
    CLI_EXIT_USAGE = 2,       /* bad command line */
    CLI_EXIT_INPUT = 3,       /* an input file is missing, unreadable, malformed or unsupported */
    CLI_EXIT_LIMIT = 4,       /* a resource limit refused the work (raise it with the named flag) */
    CLI_EXIT_OUTPUT = 5,      /* an output could not be written */
    CLI_EXIT_INTERNAL = 6     /* out of memory or an internal error */
};

typedef struct cli_globals {
    int threads;              /* --threads, 0 = all CPUs */
    int quiet, verbose;
    obs_limits limits;        /* --max-pixels etc. */
} cli_globals;

/* Map a status to an exit code. */
int cli_exit_for(obs_status st);
/* Print "obscura: <msg>" for the context's error and return its exit code. */
int cli_fail(obs_context *ctx, obs_status st);
/* A new context with the global limits and the log level of -q / -v; NULL when out of memory. */
obs_context *cli_context(const cli_globals *g);
/* Under an MPI launcher (scale_mpi_launched), start MPI into *comm (NULL without a launcher):
 * truth ao, truth sss and truth volume (docs/scale.md). Returns CLI_EXIT_OK, or when MPI cannot
 * start, prints the error, destroys ctx and returns the exit code (usage when the MPI library lacks
 * MPI_THREAD_FUNNELED or MPI is not built, else internal). */
int cli_mpi_start(obs_context *ctx, int *argc, char ***argv, scale_comm **comm);
/* Print a usage error and return CLI_EXIT_USAGE. */
int cli_usage_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Option parsing helpers: return 1 and set *out on success, 0 on a malformed value. */
int cli_parse_int(const char *s, long long lo, long long hi, long long *out);
int cli_parse_float(const char *s, double *out);
int cli_parse_size(const char *s, int *w, int *h);   /* "1920x1080" */
int cli_parse_triple(const char *s, double out[3]);   /* "x,y,z": three finite numbers */

/* The output and view flags of the scene commands (ao, gbuffer, sss, truth ao, truth sss, volume);
 * a NULL pointer leaves its flag out of the command. */
typedef struct cli_view_flags {
    const char **prefix;        /* -o, --output PREFIX: cli_output_prefix into prefix_buf and exr_ext */
    char *prefix_buf;
    size_t prefix_size;
    char *exr_ext;
    const char *output_needs;   /* what the -o error says it needs: "a path prefix or an .exr path" */
    const char **camera;        /* --camera NAME|INDEX */
    int *W, *H, *size_given;    /* --size WxH */
} cli_view_flags;
/* Consume argv[*i] when it is one of f's flags. Returns 1 when consumed (its value too), 0 when it is
 * not one, -1 on a missing or bad value (after printing the error). */
int cli_view_flag(const cli_view_flags *f, int argc, char **argv, int *i);

/* Try to consume a global limit flag at argv[*i]; returns 1 if consumed, 0 if not a limit
 * flag, -1 on a malformed value (after printing the error). */
int cli_limit_flag(cli_globals *g, int argc, char **argv, int *i);

/* Load a scene, choosing a camera by name or index ("" = "default" if present, else the
 * first camera, else a framing camera). */
obs_status cli_load_scene(obs_context *ctx, const char *path, obs_scene *scene);
obs_status cli_pick_camera(obs_context *ctx, const obs_scene *scene, const char *which, obs_camera *out);

/* cli_load_scene, cli_require_triangles and cli_pick_camera in turn (the scene commands' start). */
obs_status cli_scene_and_camera(obs_context *ctx, const char *path, const char *which, obs_scene *scene,
                                obs_camera *cam);

/* The default image size for a camera when --size was not given: 1920 wide at a perspective
 * camera's aspect (when it has one). Returns CLI_EXIT_OK, or CLI_EXIT_USAGE after printing when the
 * aspect gives an unusable height. */
int cli_size_from_camera(const obs_camera *cam, int size_given, int *W, int *H);

/* NOT_FOUND (exit 3) naming the file when no instance draws a triangle: gbuffer, ao --scene and
 * truth refuse an empty scene rather than write an empty image with exit 0 (docs/cli.md). */
obs_status cli_require_triangles(obs_context *ctx, const obs_scene *scene);

/* mkdir -p for the directory part of path (outputs may name new directories). */
obs_status cli_make_parent_dirs(obs_context *ctx, const char *path);

/* The output prefix from -o: an argument ending in ".exr" (any case) is the EXR's own path, and
 * the prefix is its stem ("out.exr" -> "out": out.exr, out.png, out.json); any other argument is
 * the prefix itself. Copies into buf and the EXR's extension as typed (".exr" or e.g. ".EXR") into
 * exr_ext; returns buf, or NULL when arg does not fit in size bytes. */
const char *cli_output_prefix(const char *arg, char *buf, size_t size, char exr_ext[5]);

/* The camera as a sidecar object "camera" (name, projection, its parameters, both matrices). */
void cli_json_camera(io_json *j, const obs_camera *c);

/* A progress bar with an ETA on stderr (truth_progress_fn's signature): label names the command. */
typedef struct cli_progress {
    double t0, last;
    int drawn;
    const char *label;
} cli_progress;
void cli_progress_draw(void *user, int64_t done, int64_t total, uint64_t rays);

/* Write the sidecar PREFIX.json. Returns CLI_EXIT_OK, or CLI_EXIT_OUTPUT after printing the error. */
int cli_write_sidecar(obs_context *ctx, const io_json *j, const char *prefix);

/* Write the common sidecar fields (version, revision, command line). */
void cli_json_header(io_json *j, const char *command, int argc, char **argv);

/* The whole command (main.c): main() calls it; the fuzz target fuzz_cli_args calls it in-process.
 * Returns the exit code. */
int cli_main(int argc, char **argv);

int cmd_gbuffer(cli_globals *g, int argc, char **argv);
int cmd_info(cli_globals *g, int argc, char **argv);
int cmd_truth(cli_globals *g, int argc, char **argv);
int cmd_compare(cli_globals *g, int argc, char **argv);
int cmd_ao(cli_globals *g, int argc, char **argv);
int cmd_study(cli_globals *g, int argc, char **argv);
int cmd_sss(cli_globals *g, int argc, char **argv);
int cmd_render(cli_globals *g, int argc, char **argv);   /* `obscura render` (cmd_render.c) */
int cmd_truth_sss(cli_globals *g, int argc, char **argv);   /* argv[1] == "sss" */
/* `obscura volume` (truth 0: argv[0] is "volume") and `obscura truth volume` (truth 1: argv[1] is "volume"). */
int cmd_volume(cli_globals *g, int argc, char **argv, int truth);

/* ---- the study commands (cmd_study.c, cmd_study_volume.c) ------------------------------------ */

/* 1 when flag stands anywhere in argv[from..argc) (--quick chooses the starting options; the flags
 * given explicitly override them wherever they stand). */
int cli_has_flag(int argc, char **argv, int from, const char *flag);

/* A flag whose value is kept as given ("--scenes LIST" into *dst); a table ends at a NULL name. */
typedef struct cli_string_flag {
    const char *name;
    const char **dst;
} cli_string_flag;
/* When argv[*i] names an entry and has a value: store the value, advance *i and return 1; else 0
 * (a flag given without its value falls through to the caller's "unknown option" error). */
int cli_string_flags(const cli_string_flag *table, int argc, char **argv, int *i);

/* What a study measures (--dry-run, --truth-only, --report-only). */
typedef struct cli_study_run {
    int dry_run, truth_only, report_only;
} cli_study_run;
/* A study's flags after its own: the ones every study takes (--quick, read with cli_has_flag;
 * --dry-run; --truth-only when has_truth; --report-only; --runs N into *runs), the strings of the
 * table, the limit flags; anything else is "<name>: unknown option". Returns 0 when argv[*i] was
 * consumed (its value too), CLI_EXIT_USAGE after printing the error. */
int cli_study_flags(cli_globals *g, const char *name, cli_study_run *run, int has_truth, int *runs,
                    const cli_string_flag *strings, int argc, char **argv, int *i);
/* After the flags: --report-only needs report_dir, and the three exclude each other. Returns
 * CLI_EXIT_OK, or CLI_EXIT_USAGE after printing ("<name>: ..."). */
int cli_study_check(const char *name, int has_truth, const cli_study_run *run, const char *report_dir);

/* A study library's steps, each an adapter of its study_*_ function (the study as void *). */
typedef struct cli_study_steps {
    const char *name;   /* "study ao": the messages' prefix */
    obs_status (*open)(obs_context *ctx, const void *options, void **study);
    void (*plan)(const void *study, const void *options, const cli_globals *g, obs_pool *pool); /* --dry-run */
    obs_status (*truth)(obs_context *ctx, obs_pool *pool, void *study);   /* NULL: no --truth-only */
    obs_status (*sweep)(obs_context *ctx, obs_pool *pool, void *study);
    obs_status (*report)(obs_context *ctx, obs_pool *pool, void *study);
    long long (*rows)(const void *study);   /* the table's rows */
    void (*close)(void *study);
} cli_study_steps;
/* Open the study (an INVALID_ARGUMENT, a bad list or size, is a usage error), then the dry run, the
 * references only, or the sweep and the report; prints the closing line unless -q. Returns the exit
 * code. out_dir and report_dir are the options' (for the closing line). */
int cli_study_main(cli_globals *g, const cli_study_steps *steps, const void *options, const cli_study_run *run,
                   const char *out_dir, const char *report_dir);

#endif
