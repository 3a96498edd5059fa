/* common.c: scene loading and camera choice shared by the subcommands. */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

obs_status cli_load_scene(obs_context *ctx, const char *path, obs_scene *scene)
{
    io_gltf_options opt = io_gltf_options_default();
    return io_gltf_load(ctx, path, &opt, scene);
}

obs_status cli_require_triangles(obs_context *ctx, const obs_scene *s)
{
    uint64_t drawn = 0;
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (s->instances[i].mesh < s->mesh_count)
            drawn += s->meshes[s->instances[i].mesh].triangle_count;
    if (drawn > 0)
        return OBS_STATUS_OK;
    return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                     "%s: the scene has no triangles to render (%u meshes, %u instances in the scene's node tree); "
                     "an empty G-buffer would look like a result",
                     s->source, s->mesh_count, s->instance_count);
}

obs_status cli_scene_and_camera(obs_context *ctx, const char *path, const char *which, obs_scene *scene,
                                obs_camera *cam)
{
    obs_status st = cli_load_scene(ctx, path, scene);
    if (st == OBS_STATUS_OK)
        st = cli_require_triangles(ctx, scene);
    if (st == OBS_STATUS_OK)
        st = cli_pick_camera(ctx, scene, which, cam);
    return st;
}

obs_status cli_pick_camera(obs_context *ctx, const obs_scene *s, const char *which, obs_camera *out)
{
    if (which && which[0]) {
        for (uint32_t c = 0; c < s->camera_count; c++)
            if (!strcmp(s->cameras[c].name, which)) {
                *out = s->cameras[c];
                return OBS_STATUS_OK;
            }
        long long idx;
        if (cli_parse_int(which, 0, (long long)s->camera_count - 1, &idx) && s->camera_count > 0) {
            *out = s->cameras[idx];
            return OBS_STATUS_OK;
        }
        return obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no camera named or numbered '%s' (the scene has %u)",
                         s->source, which, s->camera_count);
    }
    for (uint32_t c = 0; c < s->camera_count; c++)
        if (!strcmp(s->cameras[c].name, "default")) {
            *out = s->cameras[c];
            return OBS_STATUS_OK;
        }
    if (s->camera_count > 0) {
        *out = s->cameras[0];
        return OBS_STATUS_OK;
    }
    *out = obs_camera_frame_bounds(s->bounds, (float)(45.0 * OBS_PI / 180.0));
    return OBS_STATUS_OK;
}

/* mkdir -p for the directory part of path. */
obs_status cli_make_parent_dirs(obs_context *ctx, const char *path)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n >= sizeof buf)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "output path too long: %s", path);
    memcpy(buf, path, n + 1);
    char *slash = strrchr(buf, '/');
    if (!slash)
        return OBS_STATUS_OK;
    *slash = '\0';
    return io_make_dirs(ctx, buf);
}

const char *cli_output_prefix(const char *arg, char *buf, size_t size, char exr_ext[5])
{
    memcpy(exr_ext, ".exr", 5);
    size_t n = strlen(arg);
    if (n + 1 > size)
        return NULL;
    memcpy(buf, arg, n + 1);
    /* "out.exr" names the EXR itself (as oiiotool, pbrt and Blender users type it): the stem is
     * the prefix, so the PNG and JSON go beside it. A bare ".exr" (no stem) stays a prefix. */
    if (n > 4 && strcasecmp(buf + n - 4, ".exr") == 0 && buf[n - 5] != '/') {
        memcpy(exr_ext, buf + n - 4, 5);   /* keep the case the user typed: "out.EXR" is the path */
        buf[n - 4] = '\0';
    }
    return buf;
}

void cli_json_camera(io_json *j, const obs_camera *c)
{
    io_json_begin_object(j, "camera");
    io_json_string(j, "name", c->name);
    io_json_string(j, "projection", c->projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic");
    if (c->projection == OBS_PROJECTION_PERSPECTIVE) {
        io_json_number(j, "yfov_rad", c->yfov);
        io_json_number(j, "aspect", c->aspect);
    } else {
        io_json_number(j, "xmag", c->xmag);
        io_json_number(j, "ymag", c->ymag);
    }
    io_json_number(j, "znear", c->znear);
    if (isinf(c->zfar))
        io_json_string(j, "zfar", "infinity");
    else
        io_json_number(j, "zfar", c->zfar);
    io_json_floats(j, "view_matrix_column_major", c->view.m, 16);
    io_json_floats(j, "world_matrix_column_major", c->world.m, 16);
    io_json_end_object(j);
}

/* ---- progress bar ---------------------------------------------------------------------------- */

void cli_progress_draw(void *user, int64_t done, int64_t total, uint64_t rays)
{
    cli_progress *pr = (cli_progress *)user;
    double now = obs_time_now();
    if (done < total && now - pr->last < 0.2)
        return;
    pr->last = now;
    double el = now - pr->t0, f = total > 0 ? (double)done / (double)total : 1.0;
    int width = 30, fill = (int)(f * width);
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < fill ? '=' : i == fill ? '>' : ' ';
    bar[width] = '\0';
    double eta = done > 0 ? el * (double)(total - done) / (double)done : 0.0;
    int es = (int)(eta + 0.5);
    fprintf(stderr, "\robscura: %s [%s] %5.1f%%  %6.2f Mrays/s  ETA %d:%02d:%02d ", pr->label, bar, 100.0 * f,
            el > 0 ? (double)rays / el * 1e-6 : 0.0, es / 3600, es / 60 % 60, es % 60);
    fflush(stderr);
    pr->drawn = 1;
}

int cli_view_flag(const cli_view_flags *f, int argc, char **argv, int *i)
{
    const char *a = argv[*i], *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    if (f->prefix && (!strcmp(a, "-o") || !strcmp(a, "--output"))) {
        if (!v)
            return cli_usage_error("%s needs %s", a, f->output_needs), -1;
        *f->prefix = cli_output_prefix(v, f->prefix_buf, f->prefix_size, f->exr_ext);
        if (!*f->prefix)
            return cli_usage_error("%s: path too long", a), -1;
    } else if (f->camera && !strcmp(a, "--camera")) {
        if (!v)
            return cli_usage_error("--camera needs a name or index"), -1;
        *f->camera = v;
    } else if (f->W && !strcmp(a, "--size")) {
        if (!cli_parse_size(v, f->W, f->H))
            return cli_usage_error("--size needs WxH with each side in [1, %d]", RAST_MAX_DIM), -1;
        *f->size_given = 1;
    } else {
        return 0;
    }
    ++*i;
    return 1;
}

int cli_write_sidecar(obs_context *ctx, const io_json *j, const char *prefix)
{
    char path[4200];
    snprintf(path, sizeof path, "%s.json", prefix);
    if (io_json_write(ctx, j, path) == OBS_STATUS_OK)
        return CLI_EXIT_OK;
    fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
    return CLI_EXIT_OUTPUT;
}

int cli_parse_triple(const char *v, double out[3])
{
    if (!v)
        return 0;
    char *end;
    const char *s = v;
    for (int c = 0; c < 3; c++) {
        out[c] = strtod(s, &end);
        if (end == s || !isfinite(out[c]))
            return 0;
        s = end;
        if (c < 2) {
            if (*s != ',')
                return 0;
            s++;
        }
    }
    return *s == '\0';
}

int cli_size_from_camera(const obs_camera *cam, int size_given, int *W, int *H)
{
    if (!size_given && cam->projection == OBS_PROJECTION_PERSPECTIVE && cam->aspect > 0.0f) {
        const int h = (int)lround(1920.0 / cam->aspect);
        if (h < 1 || h > RAST_MAX_DIM)
            return cli_usage_error("camera aspect %g gives an unusable height; pass --size", (double)cam->aspect);
        *W = 1920;
        *H = h;
    }
    return CLI_EXIT_OK;
}

/* ---- the study commands ------------------------------------------------------------------------ */

int cli_has_flag(int argc, char **argv, int from, const char *flag)
{
    int found = 0;
    for (int i = from; i < argc; i++)
        found |= !strcmp(argv[i], flag);
    return found;
}

int cli_string_flags(const cli_string_flag *t, int argc, char **argv, int *i)
{
    if (*i + 1 >= argc)
        return 0;
    for (; t->name; t++)
        if (!strcmp(argv[*i], t->name)) {
            *t->dst = argv[++*i];
            return 1;
        }
    return 0;
}

static int study_flag(cli_study_run *run, int has_truth, int *runs, int argc, char **argv, int *i)
{
    const char *a = argv[*i], *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    long long ll;
    if (!strcmp(a, "--quick")) {
        return 1;
    } else if (!strcmp(a, "--dry-run")) {
        run->dry_run = 1;
    } else if (has_truth && !strcmp(a, "--truth-only")) {
        run->truth_only = 1;
    } else if (!strcmp(a, "--report-only")) {
        run->report_only = 1;
    } else if (!strcmp(a, "--runs")) {
        if (!cli_parse_int(v, 1, 64, &ll))
            return cli_usage_error("--runs needs an integer in [1, 64]"), -1;
        *runs = (int)ll, ++*i;
    } else {
        return 0;
    }
    return 1;
}

int cli_study_flags(cli_globals *g, const char *name, cli_study_run *run, int has_truth, int *runs,
                    const cli_string_flag *strings, int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    int r = study_flag(run, has_truth, runs, argc, argv, i);
    if (r == 0)
        r = cli_string_flags(strings, argc, argv, i);
    if (r == 0)
        r = cli_limit_flag(g, argc, argv, i);
    if (r > 0)
        return CLI_EXIT_OK;
    return r < 0 ? CLI_EXIT_USAGE : cli_usage_error("%s: unknown option '%s' (or a missing value)", name, a);
}

int cli_study_check(const char *name, int has_truth, const cli_study_run *run, const char *report_dir)
{
    if (run->report_only && !report_dir)
        return cli_usage_error("%s: --report-only needs --report DIR", name);
    if (run->report_only + run->truth_only + run->dry_run > 1)
        return cli_usage_error(has_truth ? "%s: --report-only, --truth-only and --dry-run exclude each other"
                                         : "%s: --report-only and --dry-run exclude each other",
                               name);
    return CLI_EXIT_OK;
}

obs_context *cli_context(const cli_globals *g)
{
    obs_context *ctx = obs_context_create();
    if (!ctx)
        return NULL;
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    return ctx;
}

int cli_mpi_start(obs_context *ctx, int *argc, char ***argv, scale_comm **comm)
{
    *comm = NULL;
    if (!scale_mpi_launched())
        return CLI_EXIT_OK;
    obs_status sm = scale_mpi_init(ctx, argc, argv, comm);
    if (sm == OBS_STATUS_OK)
        return CLI_EXIT_OK;
    fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
    obs_context_destroy(ctx);
    return sm == OBS_STATUS_UNSUPPORTED ? CLI_EXIT_USAGE : CLI_EXIT_INTERNAL;
}

int cli_study_main(cli_globals *g, const cli_study_steps *steps, const void *options, const cli_study_run *run,
                   const char *out_dir, const char *report_dir)
{
    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    int code = CLI_EXIT_OK;
    void *s = NULL;
    obs_status st = steps->open(ctx, options, &s);
    if (st == OBS_STATUS_INVALID_ARGUMENT) { /* a bad list, technique, size, ...: a usage error */
        code = cli_usage_error("%s", obs_context_last_error(ctx));
        obs_context_destroy(ctx);
        return code;
    }
    obs_pool *pool = st == OBS_STATUS_OK ? obs_pool_create(g->threads) : NULL;
    if (st == OBS_STATUS_OK && !pool)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot create the thread pool", steps->name);
    if (st == OBS_STATUS_OK && run->dry_run) {
        steps->plan(s, options, g, pool);
    } else if (st == OBS_STATUS_OK) {
        if (run->truth_only)
            st = steps->truth(ctx, pool, s);
        else if (!run->report_only)
            st = steps->sweep(ctx, pool, s);
        if (st == OBS_STATUS_OK && report_dir && !run->truth_only)
            st = steps->report(ctx, pool, s);
        if (st == OBS_STATUS_OK && !g->quiet)
            fprintf(stderr, "obscura: %s: %lld points in %s/results.csv%s%s\n", steps->name, steps->rows(s), out_dir,
                    report_dir ? ", report in " : "", report_dir ? report_dir : "");
    }
    if (st != OBS_STATUS_OK)
        code = cli_fail(ctx, st);
    steps->close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    return code;
}
