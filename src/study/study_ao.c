/* study_ao.c: the AO study (study_ao.h): options, frames, the ground truth and its cache, one
 * point, the sweep. The report is study_ao_report.c. docs/study.md. */
#include "study_ao_internal.h"
#include "../io/io.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef OBS_STUDY_DATA_DIR
#define OBS_STUDY_DATA_DIR "build/data"
#endif

/* ================================================================================================
 * Options
 * ============================================================================================== */

study_ao_options study_ao_options_default(void)
{
    study_ao_options o;
    memset(&o, 0, sizeof o);
    o.out_dir = "out/study-ao";
    o.report_dir = NULL;
    o.data_dir = OBS_STUDY_DATA_DIR;
    o.scenes = STUDY_AO_DEFAULT_SCENES;
    o.views = STUDY_AO_DEFAULT_VIEWS;
    o.methods = NULL; /* every registered technique */
    o.resolutions = STUDY_AO_DEFAULT_RESOLUTIONS;
    o.samples = STUDY_AO_DEFAULT_SAMPLES;
    o.radii = STUDY_AO_DEFAULT_RADII;
    o.blurs = STUDY_AO_DEFAULT_BLURS;
    o.budgets = STUDY_AO_DEFAULT_BUDGETS;
    o.runs = STUDY_AO_DEFAULT_RUNS;
    o.gt_max_samples = STUDY_AO_DEFAULT_GT_MAX_SAMPLES;
    o.quick = 0;
    o.log = NULL;
    o.shard = 1;
    o.shards = 1;
    o.gt_dir = NULL;
    return o;
}

study_ao_options study_ao_options_quick(void)
{
    study_ao_options o = study_ao_options_default();
    o.scenes = STUDY_AO_QUICK_SCENES;
    o.views = STUDY_AO_QUICK_VIEWS;
    o.resolutions = STUDY_AO_QUICK_RESOLUTIONS;
    o.samples = STUDY_AO_QUICK_SAMPLES;
    o.radii = STUDY_AO_QUICK_RADII;
    o.runs = STUDY_AO_QUICK_RUNS;
    o.gt_max_samples = STUDY_AO_QUICK_GT_MAX_SAMPLES;
    o.quick = 1;
    return o;
}

/* The ground truth's sampling settings: the one place they are decided (study_ao.h). */
truth_ao_params study_ao_truth_params(const study_ao_options *o, int width, int height, unsigned seed)
{
    truth_ao_params tp = truth_ao_params_default();
    tp.batch = 16;
    tp.replicates = 8;
    tp.error_bar = TRUTH_AO_BAR_REPLICATES;
    /* The per-pixel sample cap: gt_max_samples at 1280x720 or less; larger images get it scaled
     * down by their pixel count (a multiple of the batch of 16, at least 32), so that every
     * resolution's ground truth costs about the same rays. The larger noise per pixel averages out
     * in the error statistics, and the noise-corrected RMSE removes its contribution
     * (study_noise_corrected); SSIM is not corrected (docs/study.md). */
    const double px = (double)width * (double)height, ref = 1280.0 * 720.0;
    long long cap = o->gt_max_samples;
    if (px > ref) {
        long long n = (long long)(o->gt_max_samples * ref / px / 16.0 + 0.5) * 16;
        n = n < 32 ? 32 : n;
        cap = n < o->gt_max_samples ? n : o->gt_max_samples;
    }
    tp.min_samples = tp.max_samples = cap; /* a fixed count: unbiased (docs/truth.md, "Limits") */
    tp.seed = seed;
    return tp;
}

/* The study set (issue 5) and each scene's unit, in metres: the radius axis is in these units.
 * Our choice, about a quarter of the scene's typical feature: the bunny and the dragon are
 * normalised to a 1 m bounding sphere (docs/data.md), the room's furniture is about 0.5-2 m, the
 * village's houses are 6 m wide. */
double study_ao_scene_unit(const char *name)
{
    static const struct {
        const char *name;
        double unit;
    } scenes[] = {
        {"dragon_plane", 0.25}, {"village", 1.5}, {"room", 0.5}, {"bunny", 0.25}, {"sphere_on_plane", 0.5},
    };
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++)
        if (!strcmp(scenes[i].name, name))
            return scenes[i].unit;
    return 1.0;
}

/* ---- parsing the axes' values ------------------------------------------------------------------ */

int study_ao_i_parse_size(const char *s, int *w, int *h) { return obs_parse_size(s, RAST_MAX_DIM, w, h); }

/* ---- the results table ------------------------------------------------------------------------ */

const char *const study_ao_i_columns[] = {
    /* key */
    "scene", "view", "width", "height", "method", "samples", "radius_units", "blur",
    /* what was run */
    "radius_m", "params", "truth_estimator", "status",
    /* time, ms: median, min, max over the runs */
    "raster_ms", "raster_ms_min", "raster_ms_max", "prepare_ms", "kernel_ms", "kernel_ms_min", "kernel_ms_max",
    "blur_ms", "blur_ms_min", "blur_ms_max", "blend_ms", "total_ms", "total_ms_min", "total_ms_max", "runs",
    "threads",
    /* error against the matched ground truth, raw and calibrated */
    "rmse", "ssim", "bias", "mae", "cal_rmse", "cal_ssim", "cal_bias", "cal_gain", "cal_power",
    "gt_mean_std_error", "surface_pixels",
    /* the ground truth's own noise taken out (study_noise_corrected) */
    "gt_rms_std_error", "rmse_nc", "cal_rmse_nc",
    /* the ground truth's noise from a second, independent ground truth (appended: tables written
     * before it are read with it empty, and completed, see complete_row) */
    "gt_noise_rms",
    /* is the calibrated score informative (appended, issue 12; study_score): the flat baseline
     * (the ground truth's standard deviation), the calibrated skill 1 - MSE / Var [Murphy88], both
     * as measured and noise-corrected, and whether the fitted power is at its bound */
    "baseline_rmse", "baseline_rmse_nc", "cal_skill", "cal_skill_nc", "fit_at_bound",
};
const int study_ao_i_column_count = (int)(sizeof study_ao_i_columns / sizeof study_ao_i_columns[0]);
#define NCOL ((int)(sizeof study_ao_i_columns / sizeof study_ao_i_columns[0]))
#define KEY_COLUMNS STUDY_AO_KEY_COLUMNS

/* ================================================================================================
 * Open and close
 * ============================================================================================== */

static obs_status check_options(obs_context *ctx, study_ao *s)
{
    const study_ao_options *o = &s->o;
    if (!o->out_dir || !*o->out_dir || !o->data_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: no output or data directory");
    if (o->shards < 1 || o->shard < 1 || o->shard > o->shards)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: shard %d of %d (need 1 <= K <= N)", o->shard,
                         o->shards);
    if (o->runs < 1 || o->runs > 64)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: runs %d outside [1, 64]", o->runs);
    if (o->gt_max_samples < 32 || o->gt_max_samples > (1 << 20) || o->gt_max_samples % 16 != 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "study ao: ground truth max samples must be a multiple of 16 in [32, 1048576]");
    for (int i = 0; i < s->methods.n; i++)
        if (!ao_method_find(s->methods.v[i]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "study ao: unknown method '%s' (see 'obscura ao --list')", s->methods.v[i]);
    for (int i = 0; i < s->resolutions.n; i++) {
        int w, h;
        if (!study_ao_i_parse_size(s->resolutions.v[i], &w, &h))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: bad resolution '%s' (WxH)",
                             s->resolutions.v[i]);
    }
    for (int i = 0; i < s->samples.n; i++) {
        long long ll;
        if (!obs_parse_int(s->samples.v[i], 1, 1024, &ll))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: bad sample count '%s' (1..1024)",
                             s->samples.v[i]);
    }
    for (int i = 0; i < s->radii.n; i++) {
        double d;
        if (!obs_parse_double(s->radii.v[i], &d) || !(d > 0.0) || !isfinite(d))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: bad radius '%s' (> 0, in scene units)",
                             s->radii.v[i]);
    }
    for (int i = 0; i < s->blurs.n; i++)
        if (strcmp(s->blurs.v[i], "0") != 0 && strcmp(s->blurs.v[i], "1") != 0)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: --blur takes 0 and/or 1");
    for (int i = 0; i < s->budgets.n; i++) {
        double d;
        if (!obs_parse_double(s->budgets.v[i], &d) || !(d > 0.0) || !isfinite(d))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: bad budget '%s' (ms > 0)", s->budgets.v[i]);
    }
    return OBS_STATUS_OK;
}

obs_status study_ao_open(obs_context *ctx, const study_ao_options *o, study_ao **out)
{
    *out = NULL;
    study_ao *s = (study_ao *)calloc(1, sizeof *s);
    if (!s)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study ao: out of memory");
    s->o = *o;
    const char *methods = o->methods;
    if (!methods) { /* every registered technique */
        size_t off = 0;
        for (const ao_method *const *m = ao_methods(); *m && off < sizeof s->all_methods; m++)
            off += (size_t)snprintf(s->all_methods + off, sizeof s->all_methods - off, "%s%s", off ? "," : "",
                                    (*m)->name);
        methods = s->all_methods;
    }
    obs_status st = study_axis_parse(ctx, "scenes", o->scenes, &s->scenes);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "views", o->views, &s->views);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "methods", methods, &s->methods);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "resolutions", o->resolutions, &s->resolutions);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "samples", o->samples, &s->samples);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "radii", o->radii, &s->radii);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "blur", o->blurs, &s->blurs);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "budgets", o->budgets, &s->budgets);
    if (st == OBS_STATUS_OK)
        st = check_options(ctx, s);
    if (st == OBS_STATUS_OK) {
        snprintf(s->csv, sizeof s->csv, "%s/results.csv", o->out_dir);
        snprintf(s->json, sizeof s->json, "%s/results.json", o->out_dir);
        st = study_table_init(ctx, &s->table, study_ao_i_columns, NCOL, KEY_COLUMNS);
    }
    int64_t resumed = 0;
    if (st == OBS_STATUS_OK)
        st = study_table_read_csv(ctx, &s->table, s->csv, &resumed);
    if (st != OBS_STATUS_OK) {
        study_ao_close(s);
        return st;
    }
    if (resumed && o->log)
        fprintf(o->log, "obscura: study ao: resuming: %lld points already measured in %s\n", (long long)resumed,
                s->csv);
    *out = s;
    return OBS_STATUS_OK;
}

void study_ao_close(study_ao *s)
{
    if (!s)
        return;
    study_axis_free(&s->scenes);
    study_axis_free(&s->views);
    study_axis_free(&s->methods);
    study_axis_free(&s->resolutions);
    study_axis_free(&s->samples);
    study_axis_free(&s->radii);
    study_axis_free(&s->blurs);
    study_axis_free(&s->budgets);
    study_table_free(&s->table);
    free(s);
}

const study_table *study_ao_table(const study_ao *s) { return &s->table; }

study_ao_plan study_ao_plan_of(const study_ao *s)
{
    study_ao_plan p;
    memset(&p, 0, sizeof p);
    p.scenes = s->scenes.n;
    p.views = s->views.n;
    p.resolutions = s->resolutions.n;
    p.methods = s->methods.n;
    p.samples = s->samples.n;
    p.radii = s->radii.n;
    p.blurs = s->blurs.n;
    p.runs = s->o.runs;
    p.points = (int64_t)p.scenes * p.views * p.resolutions * p.methods * p.samples * p.radii * p.blurs;
    /* Expected duration, from the full study's own rates on the 2-core development machine
     * (2026-12-01; docs/study.md): a point with 5 runs costs about 0.5 us per pixel (1 s at 1080p
     * averaged over techniques and samples: the runs, the error and the calibration fit); the
     * ground truth of a frame about 4-10 s per ray set (one per radius for VOL, one for each of the
     * two hemisphere families) at any resolution, its sample cap scaling with the pixels. */
    double px = 0.0;
    for (int r = 0; r < s->resolutions.n; r++) {
        int W, H;
        if (study_ao_i_parse_size(s->resolutions.v[r], &W, &H))
            px += (double)W * H;
    }
    const double pts = (double)p.scenes * p.views * p.methods * p.samples * p.radii * p.blurs;
    const double mid = pts * px * 0.5e-6 * (p.runs + 1) / 6.0;
    const double sets = (double)p.scenes * p.views * p.resolutions * (p.radii + 2);
    p.sweep_min_lo = 0.6 * mid / 60;
    p.sweep_min_hi = 1.5 * mid / 60;
    p.truth_min_lo = sets * 4.0 / 60;
    p.truth_min_hi = sets * 10.0 / 60;
    return p;
}

/* ================================================================================================
 * Frames: per scene, view and resolution, the G-buffer and the masks
 * ============================================================================================== */

static obs_status load_scene(obs_context *ctx, const char *path, obs_scene *scene)
{
    io_gltf_options opt = io_gltf_options_default();
    return io_gltf_load(ctx, path, &opt, scene);
}

/* The camera named `view`; NOT_FOUND when the scene has none of that name. */
static obs_status pick_camera(obs_context *ctx, const obs_scene *s, const char *view, obs_camera *out)
{
    for (uint32_t c = 0; c < s->camera_count; c++)
        if (!strcmp(s->cameras[c].name, view)) {
            *out = s->cameras[c];
            return OBS_STATUS_OK;
        }
    long long idx;
    if (s->camera_count > 0 && obs_parse_int(view, 0, (long long)s->camera_count - 1, &idx)) {
        *out = s->cameras[idx];
        return OBS_STATUS_OK;
    }
    return obs_error(ctx, OBS_STATUS_NOT_FOUND, "%s: no camera named or numbered '%s' (the scene has %u)", s->source,
                     view, s->camera_count);
}

void study_ao_i_frame_free(study_ao_i_frame *f)
{
    rast_gbuffer_free(&f->gb);
    obs_image_f32_free(&f->mask);
    obs_image_f32_free(&f->fit_mask);
    truth_scene_destroy(f->ts);
    obs_scene_free(&f->scene);
    memset(f, 0, sizeof *f);
}

obs_status study_ao_i_frame_render(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                                   const char *view, int W, int H, int need_truth, study_ao_i_frame *f)
{
    memset(f, 0, sizeof *f);
    obs_scene_init(&f->scene);
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.glb", s->o.data_dir, scene_name);
    obs_status st = load_scene(ctx, path, &f->scene);
    if (st == OBS_STATUS_OK)
        st = pick_camera(ctx, &f->scene, view, &f->cam);
    if (st != OBS_STATUS_OK)
        return st;
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    st = rast_gbuffer_alloc(ctx, &rp, &f->gb);
    rast_view rv = {f->cam};
    double t[16];
    const int runs = s->o.runs < 16 ? s->o.runs : 16;
    for (int r = -1; r < runs && st == OBS_STATUS_OK; r++) { /* one warm-up run */
        double t0 = obs_time_now();
        st = rast_render(ctx, pool, &f->scene, &rv, 1, &rp, &f->gb, NULL);
        if (r >= 0)
            t[r] = 1e3 * (obs_time_now() - t0);
    }
    if (st != OBS_STATUS_OK)
        return st;
    f->raster = study_stats_of(t, runs);
    st = ao_input_from_gbuffer(ctx, &f->gb, 1, &f->in);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, W, H, &f->mask);
    if (st == OBS_STATUS_OK)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float d = obs_image_f32_row(f->in.depth, y)[x];
                obs_image_f32_row(&f->mask, y)[x] = d > 0.0f && d < INFINITY ? 1.0f : 0.0f;
            }
    /* The calibration fit (two parameters, ~50 passes over its pixels) on about 250k pixels: every
     * s-th pixel of every s-th row, s = ceil(sqrt(W H / 250k)) (1 up to 500x500, 3 at 1080p, 6 at
     * 4K). The fitted curve is then applied to, and scored on, every surface pixel. */
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, W, H, &f->fit_mask);
    if (st == OBS_STATUS_OK) {
        const int step = (int)ceil(sqrt((double)W * (double)H / 250000.0));
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                obs_image_f32_row(&f->fit_mask, y)[x] =
                    (x % step == step / 2 && y % step == step / 2) ? obs_image_f32_row(&f->mask, y)[x] : 0.0f;
    }
    if (st == OBS_STATUS_OK && need_truth)
        st = truth_scene_create(ctx, &f->scene, TRUTH_BUILD_MEDIUM, &f->ts);
    return st;
}


/* ================================================================================================
 * The ground truth and its cache
 * ============================================================================================== */

/* The cache file of a ground truth (seed 0; another seed gets a suffix). The name records the
 * settings of study_ao_truth_params that decide its accuracy (the fixed count and the
 * replicates), so that a cached file is only reused for the same settings. */
/* The ground-truth cache directory: o.gt_dir, shared by the shards of a study, or OUT/gt. */
static void gt_dir(const study_ao *s, char *dir, size_t size)
{
    if (s->o.gt_dir)
        snprintf(dir, size, "%s", s->o.gt_dir);
    else
        snprintf(dir, size, "%s/gt", s->o.out_dir);
}

/* The content hash of a cache file's inputs beyond its name's settings: the scene file's bytes and
 * obscura's version (docs/scale.md, "The shared cache"). Hashed once per scene file and kept
 * (a study opens a handful of scenes; the study runs on one thread). 0 when unreadable: the frame
 * itself then fails to load. */
static uint64_t scene_hash(const study_ao *s, const char *scene_name)
{
    static struct { char path[4096]; uint64_t h; } memo[16];
    static int nmemo = 0;
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.glb", s->o.data_dir, scene_name);
    for (int i = 0; i < nmemo; i++)
        if (!strcmp(memo[i].path, path))
            return memo[i].h;
    uint64_t h = 0;
    if (study_hash_file(NULL, study_hash_string(STUDY_HASH_INIT, OBS_VERSION_STRING), path, &h) != OBS_STATUS_OK)
        return 0;
    if (nmemo < 16) {
        snprintf(memo[nmemo].path, sizeof memo[nmemo].path, "%s", path);
        memo[nmemo++].h = h;
    }
    return h;
}

static void gt_path(const study_ao *s, const char *scene_name, const char *view, const study_ao_i_frame *f,
                    const char *estimator, float radius, unsigned seed, char *path, size_t size)
{
    const truth_ao_params tp = study_ao_truth_params(&s->o, f->in.w, f->in.h, seed);
    char rep[16] = "", dir[2048];
    if (seed)
        snprintf(rep, sizeof rep, "_s%u", seed);
    gt_dir(s, dir, sizeof dir);
    snprintf(path, size, "%s/%s_%s_%dx%d_%s_r%.6g_n%lld_R%d%s_%016llx.exr", dir, scene_name, view, f->in.w, f->in.h,
             estimator, (double)radius, (long long)tp.max_samples, tp.replicates, rep,
             (unsigned long long)scene_hash(s, scene_name));
}

/* Mean and root-mean-square of the ground truth's standard error over the surface pixels. */
static void gt_noise(const study_ao_i_frame *f, const obs_image_f32 *se, double *mean_se, double *rms_se)
{
    double s = 0.0, s2 = 0.0;
    int64_t n = 0;
    for (int y = 0; y < f->in.h; y++)
        for (int x = 0; x < f->in.w; x++)
            if (obs_image_f32_row(&f->mask, y)[x] != 0.0f) {
                double e = obs_image_f32_row(se, y)[x];
                s += e;
                s2 += e * e;
                n++;
            }
    *mean_se = n ? s / (double)n : 0.0;
    if (rms_se)
        *rms_se = n ? sqrt(s2 / (double)n) : 0.0;
}

/* Write one ground truth to its cache file (channels V, SE, N; atomically, io_exr_write). */
static obs_status gt_write(obs_context *ctx, const study_ao *s, const char *path, const char *estimator,
                           truth_ao_result *r)
{
    io_channel ch[3] = {{"V", IO_PIXEL_FLOAT, &r->mean, NULL},
                        {"SE", IO_PIXEL_FLOAT, &r->std_error, NULL},
                        {"N", IO_PIXEL_FLOAT, &r->count, NULL}};
    io_attr at[1];
    memset(at, 0, sizeof at);
    strcpy(at[0].name, "obscura:truth_estimator");
    at[0].type = IO_ATTR_STRING;
    at[0].s = (char *)estimator;
    char gtdir[4200];
    gt_dir(s, gtdir, sizeof gtdir);
    obs_status st = io_make_dirs(ctx, gtdir);
    if (st == OBS_STATUS_OK)
        st = io_exr_write(ctx, path, ch, 3, at, 1);
    return st;
}

obs_status study_ao_i_ground_truth(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                                   const char *view, study_ao_i_frame *f, const char *estimator, float radius,
                                   unsigned seed, obs_image_f32 *mean, double *mean_se, double *rms_se)
{
    char path[4096];
    gt_path(s, scene_name, view, f, estimator, radius, seed, path, sizeof path);
    io_image im;
    memset(&im, 0, sizeof im);
    if (access(path, R_OK) == 0 && io_image_read(ctx, path, &im) == OBS_STATUS_OK) {
        int cv = io_image_find_channel(&im, "V"), cs = io_image_find_channel(&im, "SE");
        if (cv >= 0 && cs >= 0 && im.width == f->in.w && im.height == f->in.h && im.f32[cv].data) {
            obs_status st = obs_image_f32_alloc(ctx, im.width, im.height, mean);
            for (int y = 0; st == OBS_STATUS_OK && y < im.height; y++)
                memcpy(obs_image_f32_row(mean, y), obs_image_f32_row(&im.f32[cv], y), sizeof(float) * (size_t)im.width);
            gt_noise(f, &im.f32[cs], mean_se, rms_se);
            io_image_free(&im);
            return st;
        }
        io_image_free(&im);
    }
    truth_ao_params tp = study_ao_truth_params(&s->o, f->in.w, f->in.h, seed);
    if (!truth_ao_estimator_from_name(estimator, &tp.estimator))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study: unknown estimator %s", estimator);
    tp.radius = radius;
    truth_ao_result r;
    obs_status st = truth_ao_render(ctx, pool, f->ts, &f->scene, &f->cam, &f->gb, &tp, &r);
    if (st != OBS_STATUS_OK)
        return st;
    st = gt_write(ctx, s, path, estimator, &r);
    gt_noise(f, &r.std_error, mean_se, rms_se);
    *mean = r.mean;
    memset(&r.mean, 0, sizeof r.mean);
    truth_ao_result_free(&r);
    return st;
}

/* ---- the ground truths a frame needs, computed together ----------------------------------------- */

/* The estimators whose rays can be shared (truth_ao_render_multi): 0 cosine-weighted hemisphere,
 * 1 uniform hemisphere, -1 for VOL (alone). */
static int gt_family(truth_ao_estimator e)
{
    switch (e) {
    case TRUTH_AO_COS:
    case TRUTH_AO_OBS_SAO_B:
    case TRUTH_AO_OBS_SAO_LINEAR:
    case TRUTH_AO_OBS_MSSAO:
        return 0;
    case TRUTH_AO_UNIF:
    case TRUTH_AO_OBS_HBAO:
        return 1;
    default:
        return -1;
    }
}

typedef struct gt_need {
    truth_ao_estimator est;
    float radius;
} gt_need;

/* Compute, for frame f, every (estimator, radius) in need[0..n-1] whose cache file for `seed` is
 * missing: the hemisphere estimators of one family in one ray set per up to TRUTH_AO_MAX_OUTPUTS
 * outputs, VOL one radius at a time; each output goes to its own cache file, as
 * study_ao_i_ground_truth would write it. The values are those of the single runs for the same
 * rays; a pixel of a shared set stops when all its outputs are within the target (so it takes at
 * least the samples each alone would). */
static obs_status gt_prepare_seed(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                                  const char *view, study_ao_i_frame *f, const gt_need *need, int n, unsigned seed)
{
    obs_status st = OBS_STATUS_OK;
    int done[256] = {0};
    for (int i = 0; i < n; i++) {
        char path[4096];
        gt_path(s, scene_name, view, f, truth_ao_estimator_name(need[i].est), need[i].radius, seed, path, sizeof path);
        done[i] = access(path, R_OK) == 0;
    }
    for (int i = 0; i < n && st == OBS_STATUS_OK; i++) {
        if (done[i])
            continue;
        truth_ao_output outs[TRUTH_AO_MAX_OUTPUTS];
        int idx[TRUTH_AO_MAX_OUTPUTS], k = 0;
        const int fam = gt_family(need[i].est);
        for (int j = i; j < n && k < TRUTH_AO_MAX_OUTPUTS; j++)
            if (!done[j] && (j == i || (fam >= 0 && gt_family(need[j].est) == fam))) {
                outs[k] = (truth_ao_output){need[j].est, need[j].radius};
                idx[k++] = j;
                if (fam < 0)
                    break;
            }
        const truth_ao_params tp = study_ao_truth_params(&s->o, f->in.w, f->in.h, seed);
        truth_ao_result r[TRUTH_AO_MAX_OUTPUTS];
        double t0 = obs_time_now();
        st = truth_ao_render_multi(ctx, pool, f->ts, &f->scene, &f->cam, &f->gb, &tp, outs, k, r);
        if (st != OBS_STATUS_OK)
            break;
        if (s->o.log)
            fprintf(s->o.log,
                    "\rground truth %s/%s %dx%d%s: %d output%s (%s%s) in %.1f s, %.0f Mrays, %.2f samples/px mean\n",
                    scene_name, view, f->in.w, f->in.h, seed ? " (replicate)" : "", k, k > 1 ? "s" : "",
                    truth_ao_estimator_name(outs[0].estimator), k > 1 ? ", ..." : "", obs_time_now() - t0,
                    r[0].stats.rays / 1e6,
                    r[0].stats.pixels_surface ? (double)r[0].stats.rays / (double)r[0].stats.pixels_surface : 0.0);
        for (int j = 0; j < k; j++) {
            char path[4096];
            gt_path(s, scene_name, view, f, truth_ao_estimator_name(outs[j].estimator), outs[j].radius, seed, path,
                    sizeof path);
            if (st == OBS_STATUS_OK)
                st = gt_write(ctx, s, path, truth_ao_estimator_name(outs[j].estimator), &r[j]);
            truth_ao_result_free(&r[j]);
            done[idx[j]] = 1;
        }
    }
    return st;
}

static obs_status gt_prepare(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                             const char *view, study_ao_i_frame *f, const gt_need *need, int n)
{
    if (n > 256)
        n = 256;
    /* Shards share the cache (docs/scale.md): the frame's missing ground truths are computed under
     * one lock per frame, so two shards never compute the same one at once; a shard that waited
     * finds the other's files (written to a temporary name and renamed) and computes only what is
     * still missing. */
    char dir[4096], lock_path[4400];
    gt_dir(s, dir, sizeof dir);
    obs_status st = io_make_dirs(ctx, dir);
    if (st != OBS_STATUS_OK)
        return st;
    snprintf(lock_path, sizeof lock_path, "%s/%s_%s_%dx%d_%016llx.lock", dir, scene_name, view, f->in.w, f->in.h,
             (unsigned long long)scene_hash(s, scene_name));
    study_lock lock;
    int waited = 0;
    st = study_lock_acquire(ctx, lock_path, 7.0 * 24 * 3600, &lock, &waited);
    if (st != OBS_STATUS_OK)
        return st;
    if (waited && s->o.log)
        fprintf(s->o.log, "\rground truth %s/%s %dx%d: waited for another shard's lock\n", scene_name, view, f->in.w,
                f->in.h);
    /* one seed: the noise estimate comes from the replicates inside each pixel (gt_cache_get) */
    st = gt_prepare_seed(ctx, pool, s, scene_name, view, f, need, n, 0);
    study_lock_release(&lock);
    return st;
}

/* The frame's ground truths in memory, loaded once each (a 4K EXR takes a while to decode). */
typedef struct gt_slot {
    char est[32];
    float radius;
    obs_image_f32 mean;
    double mean_se, rms_se;
    double noise_rms; /* sqrt(mean over the scored pixels of s_R^2): the reference's noise */
    double ref_var;   /* g0's variance over the surface pixels (met_result.ref_var): the flat baseline's MSE */
} gt_slot;

typedef struct gt_cache {
    gt_slot slot[32];
    int n;
} gt_cache;

static void gt_cache_clear(gt_cache *c)
{
    for (int i = 0; i < c->n; i++)
        obs_image_f32_free(&c->slot[i].mean);
    c->n = 0;
}

static obs_status gt_cache_get(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                               const char *view, study_ao_i_frame *f, gt_cache *c, const char *est, float radius,
                               const gt_slot **out)
{
    for (int i = 0; i < c->n; i++)
        if (!strcmp(c->slot[i].est, est) && c->slot[i].radius == radius) {
            *out = &c->slot[i];
            return OBS_STATUS_OK;
        }
    if (c->n == (int)(sizeof c->slot / sizeof c->slot[0]))
        gt_cache_clear(c);
    gt_slot *g = &c->slot[c->n];
    memset(g, 0, sizeof *g);
    snprintf(g->est, sizeof g->est, "%s", est);
    g->radius = radius;
    obs_status st =
        study_ao_i_ground_truth(ctx, pool, s, scene_name, view, f, est, radius, 0, &g->mean, &g->mean_se, &g->rms_se);
    /* the flat baseline: the variance of g0 over the pixels every point is scored on, by the
     * metrics' own rule (so it is the ref_var of met_compare(g0, ao, mask)) */
    met_result self;
    met_params mp = met_params_default();
    mp.compute_ssim = 0;
    if (st == OBS_STATUS_OK)
        st = met_compare(ctx, pool, &g->mean, &g->mean, &f->mask, &mp, &self);
    if (st != OBS_STATUS_OK) {
        obs_image_f32_free(&g->mean);
        return st;
    }
    g->ref_var = self.ref_var;
    /* The reference's noise: each pixel's s_R^2 estimates the variance of its mean without bias
     * (randomised QMC with 8 independent replicates at a fixed count [L'Ecuyer & Lemieux 2002];
     * calibrated in tests/test_truth_ao.c), so their mean over the scored pixels estimates the
     * noise's share of the mean squared error. (Until issue 12: the difference of two whole ground
     * truths from seeds 0 and 1, which cost twice the rays for the same estimate.) */
    g->noise_rms = g->rms_se;
    c->n++;
    *out = g;
    return OBS_STATUS_OK;
}

/* The error against a noisy reference (study_noise_corrected, study_score_of): E[(a - g_hat)^2] =
 * (a - g)^2 + Var(g_hat) (a is independent of the reference's noise), so the mean squared error
 * less the reference's mean noise variance estimates the mean squared error against the exact g;
 * clamped at 0. The variance comes from an independent replicate (gt_cache_get), not from the
 * per-pixel i.i.d. standard error: that formula over-estimates the spread of these low-discrepancy
 * estimates by a factor that varies per pixel (on an open plane VOL's estimate is exact after every
 * even sample count while its i.i.d. SE is 0.5/sqrt(n)), so subtracting it would over-correct. */


/* ================================================================================================
 * One point
 * ============================================================================================== */

/* The run function (one point's time and output) and the error function (its scores against the
 * ground truth), study_ao_internal.h. */
obs_status study_ao_i_run_point(obs_context *ctx, obs_pool *pool, const ao_method *m, const void *p,
                                study_ao_i_frame *f, int runs, const obs_image_f32 *gt, obs_image_f32 *ao,
                                study_ao_i_point *res)
{
    obs_image_f32 raw = {0}, blend = {0}, cal = {0};
    obs_status st = obs_image_f32_alloc(ctx, f->in.w, f->in.h, ao);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, f->in.w, f->in.h, &raw);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, f->in.w, f->in.h, &blend);
    double tp[64], tk[64], tb[64], tl[64], tt[64];
    if (runs > 64)
        runs = 64;
    const obs_image_f32 *np[3] = {f->in.normal[0], f->in.normal[1], f->in.normal[2]};
    for (int r = -1; r < runs && st == OBS_STATUS_OK; r++) {
        ao_stats as;
        memset(&as, 0, sizeof as);
        double t0 = obs_time_now();
        st = m->compute(ctx, pool, &f->in, p, ao, &raw, &as);
        double t1 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = ao_blend_lambert(ctx, pool, &f->in, ao, np, &blend);
        double t2 = obs_time_now();
        if (r >= 0) {
            tp[r] = 1e3 * as.seconds_prepare;
            tk[r] = 1e3 * as.seconds_kernel;
            tb[r] = 1e3 * as.seconds_blur;
            tl[r] = 1e3 * (t2 - t1);
            tt[r] = 1e3 * (t2 - t0);
        }
    }
    if (st == OBS_STATUS_OK) {
        res->prepare = study_stats_of(tp, runs);
        res->kernel = study_stats_of(tk, runs);
        res->blur = study_stats_of(tb, runs);
        res->blend = study_stats_of(tl, runs);
        res->total = study_stats_of(tt, runs);
    }
    if (st == OBS_STATUS_OK && gt) {
        met_params mp = met_params_default();
        st = met_compare(ctx, pool, gt, ao, &f->mask, &mp, &res->raw);
        if (st == OBS_STATUS_OK)
            st = met_fit_gain_power(ctx, pool, gt, ao, &f->fit_mask, &mp, &res->fit);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, f->in.w, f->in.h, &cal);
        if (st == OBS_STATUS_OK)
            st = met_apply_gain_power(ctx, ao, res->fit.gain, res->fit.power, &cal);
        if (st == OBS_STATUS_OK)
            st = met_compare(ctx, pool, gt, &cal, &f->mask, &mp, &res->cal);
    }
    obs_image_f32_free(&raw);
    obs_image_f32_free(&blend);
    obs_image_f32_free(&cal);
    return st;
}


/* ================================================================================================
 * The sweep
 * ============================================================================================== */

static void fmt(char *buf, double v) { snprintf(buf, 32, "%.9g", v); }

/* The manifest (study.h): the canonical text of every option that decides a row's values. */
static void study_ao_i_manifest(const study_ao *s, study_manifest *m)
{
    memset(m, 0, sizeof *m);
    snprintf(m->study, sizeof m->study, "ao");
    snprintf(m->version, sizeof m->version, "%s", OBS_VERSION_STRING);
    char methods[1200] = "";
    size_t off = 0;
    for (int i = 0; i < s->methods.n && off < sizeof methods; i++)
        off += (size_t)snprintf(methods + off, sizeof methods - off, "%s%s", i ? "," : "", s->methods.v[i]);
    snprintf(m->config, sizeof m->config,
             "scenes=%s;views=%s;methods=%s;resolutions=%s;samples=%s;radii=%s;blurs=%s;runs=%d;gt_max_samples=%lld;"
             "quick=%d",
             s->o.scenes, s->o.views, methods, s->o.resolutions, s->o.samples, s->o.radii, s->o.blurs, s->o.runs,
             s->o.gt_max_samples, s->o.quick);
    snprintf(m->config_hash, sizeof m->config_hash, "%016llx",
             (unsigned long long)study_hash_string(STUDY_HASH_INIT, m->config));
    m->shard = s->o.shard;
    m->shards = s->o.shards;
}

static obs_status save_table(obs_context *ctx, study_ao *s)
{
    s->last_save = obs_time_now();
    s->dirty = 0;
    obs_status st = io_make_dirs(ctx, s->o.out_dir);
    if (st == OBS_STATUS_OK)
        st = study_table_write_csv(ctx, &s->table, s->csv);
    if (st == OBS_STATUS_OK)
        st = study_table_write_json(ctx, &s->table, s->json);
    if (st == OBS_STATUS_OK) {
        study_manifest m;
        study_ao_i_manifest(s, &m);
        st = study_manifest_write(ctx, s->o.out_dir, &m);
    }
    return st;
}

/* A point's parameters from its key cells: the technique's defaults, then the swept axes. Returns
 * the radius in metres as set. */
static float point_params(const ao_method *m, const char *samples, const char *radius_units, const char *blur,
                          double unit, void *p)
{
    const float radius_m = (float)(atof(radius_units) * unit);
    m->params_default(p);
    m->set_samples(p, atoi(samples));
    m->set_radius(p, radius_m);
    m->set_blur(p, atoi(blur));
    return radius_m;
}

/* Does a point still need work: not measured (row < 0), or measured ("ok") before a column that
 * needs its ground truth existed (the replicate-based noise, the flat baseline)? */
static int row_pending(const study_table *t, int64_t row)
{
    if (row < 0)
        return 1;
    return !strcmp(study_table_get(t, row, study_table_column(t, "status")), "ok") &&
           (!study_table_get(t, row, study_table_column(t, "gt_noise_rms"))[0] ||
            !study_table_get(t, row, study_table_column(t, "fit_at_bound"))[0]);
}

/* Complete a measured row written before the trailing columns existed, from its raw and calibrated
 * RMSE, its fitted power and its ground truth (noise, variance); cells already there are kept. */
static obs_status complete_row(obs_context *ctx, study_table *t, int64_t row, double noise_rms, double ref_var)
{
    const double rmse = study_table_num(t, row, study_table_column(t, "rmse"));
    const double cal = study_table_num(t, row, study_table_column(t, "cal_rmse"));
    const double power = study_table_num(t, row, study_table_column(t, "cal_power"));
    const study_score sc = study_score_of(rmse * rmse, cal * cal, ref_var, noise_rms, met_fit_power_at_bound(power));
    obs_status st = OBS_STATUS_OK;
    if (!study_table_get(t, row, study_table_column(t, "gt_noise_rms"))[0]) {
        const char *names[] = {"gt_noise_rms", "rmse_nc", "cal_rmse_nc"};
        const double v[] = {noise_rms, sc.rmse_nc, sc.cal_rmse_nc};
        for (int k = 0; k < 3 && st == OBS_STATUS_OK; k++) {
            char b[32];
            fmt(b, v[k]);
            st = study_table_set(ctx, t, row, study_table_column(t, names[k]), b);
        }
    }
    if (!study_table_get(t, row, study_table_column(t, "fit_at_bound"))[0]) {
        const char *names[] = {"baseline_rmse", "baseline_rmse_nc", "cal_skill", "cal_skill_nc", "fit_at_bound"};
        const double v[] = {sc.baseline_rmse, sc.baseline_rmse_nc, sc.cal_skill, sc.cal_skill_nc, sc.fit_at_bound};
        for (int k = 0; k < 5 && st == OBS_STATUS_OK; k++) {
            char b[32];
            fmt(b, v[k]);
            st = study_table_set(ctx, t, row, study_table_column(t, names[k]), b);
        }
    }
    return st;
}

/* Every ground truth the pending points of a frame need, computed together (gt_prepare). */
/* The index of a point in the study's enumeration (frames in scene, view, resolution order; in a
 * frame, method, samples, radius, blur): what shards split (study_shard_has). */
static int64_t point_index(const study_ao *s, int64_t frame, int mi, int ni, int qi, int bi)
{
    const int64_t per_frame = (int64_t)s->methods.n * s->samples.n * s->radii.n * s->blurs.n;
    return frame * per_frame + (((int64_t)mi * s->samples.n + ni) * s->radii.n + qi) * s->blurs.n + bi;
}

static int in_shard(const study_ao *s, int64_t frame, int mi, int ni, int qi, int bi)
{
    return study_shard_has(s->o.shard, s->o.shards, point_index(s, frame, mi, ni, qi, bi));
}

static obs_status frame_truths(obs_context *ctx, obs_pool *pool, study_ao *s, const char *scene, const char *view,
                               const char *ws, const char *hs, study_ao_i_frame *f, int64_t frame)
{
    const double unit = study_ao_scene_unit(scene);
    gt_need need[256];
    int nn = 0;
    for (int qi = 0; qi < s->radii.n; qi++)
        for (int mi = 0; mi < s->methods.n; mi++)
            for (int ni = 0; ni < s->samples.n; ni++)
                for (int bi = 0; bi < s->blurs.n; bi++) {
                    const char *key[KEY_COLUMNS] = {scene, view, ws, hs, s->methods.v[mi], s->samples.v[ni],
                                                    s->radii.v[qi], s->blurs.v[bi]};
                    if (!in_shard(s, frame, mi, ni, qi, bi) ||
                        !row_pending(&s->table, study_table_find(&s->table, key)))
                        continue;
                    const ao_method *m = ao_method_find(s->methods.v[mi]);
                    unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
                    point_params(m, s->samples.v[ni], s->radii.v[qi], s->blurs.v[bi], unit, p);
                    truth_ao_estimator e;
                    if (m->params_validate(ctx, p) != OBS_STATUS_OK ||
                        !truth_ao_estimator_from_name(m->truth_estimator(p), &e)) {
                        obs_context_clear_error(ctx);
                        continue;
                    }
                    const float r = m->get_radius(p);
                    int dup = 0;
                    for (int k = 0; k < nn; k++)
                        dup |= need[k].est == e && need[k].radius == r;
                    if (!dup && nn < 256)
                        need[nn++] = (gt_need){e, r};
                }
    return gt_prepare(ctx, pool, s, scene, view, f, need, nn);
}

/* Rows measured before the trailing columns existed: complete them (no timing). */
static obs_status frame_complete_rows(obs_context *ctx, obs_pool *pool, study_ao *s, const char *scene,
                                      const char *view, const char *ws, const char *hs, study_ao_i_frame *f,
                                      gt_cache *gtc)
{
    const double unit = study_ao_scene_unit(scene);
    obs_status st = OBS_STATUS_OK;
    for (int qi = 0; qi < s->radii.n && st == OBS_STATUS_OK; qi++)
        for (int mi = 0; mi < s->methods.n && st == OBS_STATUS_OK; mi++)
            for (int ni = 0; ni < s->samples.n && st == OBS_STATUS_OK; ni++)
                for (int bi = 0; bi < s->blurs.n && st == OBS_STATUS_OK; bi++) {
                    const char *key[KEY_COLUMNS] = {scene, view, ws, hs, s->methods.v[mi], s->samples.v[ni],
                                                    s->radii.v[qi], s->blurs.v[bi]};
                    const int64_t row = study_table_find(&s->table, key);
                    if (row < 0 || !row_pending(&s->table, row))
                        continue;
                    const ao_method *m = ao_method_find(s->methods.v[mi]);
                    unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
                    point_params(m, s->samples.v[ni], s->radii.v[qi], s->blurs.v[bi], unit, p);
                    const gt_slot *gts = NULL;
                    st = gt_cache_get(ctx, pool, s, scene, view, f, gtc, m->truth_estimator(p), m->get_radius(p),
                                      &gts);
                    if (st == OBS_STATUS_OK)
                        st = complete_row(ctx, &s->table, row, gts->noise_rms, gts->ref_var);
                    s->dirty = 1;
                }
    return st;
}

/* Measure one point not in the table yet and append its row. Returns OK (a refused point is
 * recorded as failed), or an out-of-memory or I/O error, which stops the sweep. */
static obs_status measure_point(obs_context *ctx, obs_pool *pool, study_ao *s, const char *const *key,
                                study_ao_i_frame *f, gt_cache *gtc)
{
    const ao_method *m = ao_method_find(key[4]);
    unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
    const float radius_m = point_params(m, key[5], key[6], key[7], study_ao_scene_unit(key[0]), p);
    study_ao_i_point res;
    memset(&res, 0, sizeof res);
    char params[1024], status[256];
    m->params_to_string(p, params, sizeof params);
    const char *est = m->truth_estimator(p);
    char cells[NCOL][32];
    const char *row[NCOL];
    for (int c = 0; c < NCOL; c++) {
        cells[c][0] = '\0';
        row[c] = cells[c];
    }
    for (int c = 0; c < KEY_COLUMNS; c++)
        row[c] = key[c];
    fmt(cells[8], radius_m);
    row[9] = params;
    row[10] = est;
    obs_image_f32 ao = {0};
    const gt_slot *gts = NULL;
    obs_status st = OBS_STATUS_OK;
    obs_status ps = m->params_validate(ctx, p);
    if (ps == OBS_STATUS_OK)
        ps = gt_cache_get(ctx, pool, s, key[0], key[1], f, gtc, est, m->get_radius(p), &gts);
    if (ps == OBS_STATUS_OK)
        ps = study_ao_i_run_point(ctx, pool, m, p, f, s->o.runs, &gts->mean, &ao, &res);
    if (ps == OBS_STATUS_OUT_OF_MEMORY || ps == OBS_STATUS_IO_ERROR) {
        st = ps; /* a study that cannot allocate or write stops */
    } else if (ps != OBS_STATUS_OK) {
        snprintf(status, sizeof status, "failed: %s", obs_context_last_error(ctx));
        row[11] = status;
        obs_context_clear_error(ctx);
    } else {
        row[11] = "ok";
        const study_score sc =
            study_score_of(res.raw.mse, res.cal.mse, res.cal.ref_var, gts->noise_rms, res.fit.power_at_bound);
        const double v[] = {f->raster.median, f->raster.min, f->raster.max, res.prepare.median, res.kernel.median,
                            res.kernel.min, res.kernel.max, res.blur.median, res.blur.min, res.blur.max,
                            res.blend.median, res.total.median, res.total.min, res.total.max, s->o.runs,
                            obs_pool_threads(pool), res.raw.rmse, res.raw.ssim, res.raw.bias, res.raw.mae,
                            res.cal.rmse, res.cal.ssim, res.cal.bias, res.fit.gain, res.fit.power, gts->mean_se,
                            (double)res.raw.valid, gts->rms_se, sc.rmse_nc, sc.cal_rmse_nc, gts->noise_rms,
                            sc.baseline_rmse, sc.baseline_rmse_nc, sc.cal_skill, sc.cal_skill_nc, sc.fit_at_bound};
        _Static_assert(sizeof v / sizeof v[0] == NCOL - 12, "one value per measured column");
        for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
            fmt(cells[12 + k], v[k]);
    }
    obs_image_f32_free(&ao);
    if (st == OBS_STATUS_OK)
        st = study_table_append(ctx, &s->table, row);
    s->dirty = 1;
    return st;
}

static obs_status sweep(obs_context *ctx, obs_pool *pool, study_ao *s, int truth_only)
{
    const study_ao_plan plan = study_ao_plan_of(s);
    study_progress pr;
    study_progress_begin(&pr, s->o.log, plan.points);
    const int64_t per_frame = (int64_t)s->methods.n * s->samples.n * s->radii.n * s->blurs.n;
    obs_status st = OBS_STATUS_OK;
    for (int si = 0; si < s->scenes.n && st == OBS_STATUS_OK; si++)
        for (int vi = 0; vi < s->views.n && st == OBS_STATUS_OK; vi++)
            for (int ri = 0; ri < s->resolutions.n && st == OBS_STATUS_OK; ri++) {
                const char *scene = s->scenes.v[si], *view = s->views.v[vi];
                const int64_t frame = ((int64_t)si * s->views.n + vi) * s->resolutions.n + ri;
                int W = 0, H = 0;
                study_ao_i_parse_size(s->resolutions.v[ri], &W, &H);
                char ws[32], hs[32];
                snprintf(ws, sizeof ws, "%d", W);
                snprintf(hs, sizeof hs, "%d", H);
                /* Which points are still to do here? */
                int64_t remaining = 0;
                for (int mi = 0; mi < s->methods.n; mi++)
                    for (int ni = 0; ni < s->samples.n; ni++)
                        for (int qi = 0; qi < s->radii.n; qi++)
                            for (int bi = 0; bi < s->blurs.n; bi++) {
                                const char *key[KEY_COLUMNS] = {scene, view, ws, hs, s->methods.v[mi], s->samples.v[ni],
                                                                s->radii.v[qi], s->blurs.v[bi]};
                                remaining += in_shard(s, frame, mi, ni, qi, bi) &&
                                             row_pending(&s->table, study_table_find(&s->table, key));
                            }
                if (!remaining) {
                    for (int64_t k = 0; k < per_frame; k++)
                        study_progress_step(&pr, 0, "resumed");
                    continue;
                }
                study_ao_i_frame f;
                st = study_ao_i_frame_render(ctx, pool, s, scene, view, W, H, 1, &f);
                if (st != OBS_STATUS_OK) {
                    study_ao_i_frame_free(&f);
                    break;
                }
                st = frame_truths(ctx, pool, s, scene, view, ws, hs, &f, frame);
                gt_cache gtc;
                memset(&gtc, 0, sizeof gtc);
                if (st == OBS_STATUS_OK)
                    st = frame_complete_rows(ctx, pool, s, scene, view, ws, hs, &f, &gtc);
                if (truth_only) {
                    for (int64_t k = 0; k < per_frame; k++)
                        study_progress_step(&pr, 0, "ground truth");
                    gt_cache_clear(&gtc);
                    study_ao_i_frame_free(&f);
                    if (st == OBS_STATUS_OK && s->dirty)
                        st = save_table(ctx, s);
                    continue;
                }
                for (int qi = 0; qi < s->radii.n && st == OBS_STATUS_OK; qi++)
                    for (int mi = 0; mi < s->methods.n && st == OBS_STATUS_OK; mi++)
                        for (int ni = 0; ni < s->samples.n && st == OBS_STATUS_OK; ni++)
                            for (int bi = 0; bi < s->blurs.n && st == OBS_STATUS_OK; bi++) {
                                const char *key[KEY_COLUMNS] = {scene, view, ws, hs, s->methods.v[mi], s->samples.v[ni],
                                                                s->radii.v[qi], s->blurs.v[bi]};
                                char label[128];
                                snprintf(label, sizeof label, "%s/%s %dx%d %s n=%s r=%s b=%s", scene, view, W, H,
                                         s->methods.v[mi], s->samples.v[ni], s->radii.v[qi], s->blurs.v[bi]);
                                if (!in_shard(s, frame, mi, ni, qi, bi) || study_table_find(&s->table, key) >= 0) {
                                    study_progress_step(&pr, 0, label);
                                    continue;
                                }
                                st = measure_point(ctx, pool, s, key, &f, &gtc);
                                /* every few seconds (the table is rewritten whole, so not after every
                                 * point of a 10,000-point study): a killed study loses at most the
                                 * last seconds of points and resumes */
                                if (st == OBS_STATUS_OK && obs_time_now() - s->last_save > 5.0)
                                    st = save_table(ctx, s);
                                study_progress_step(&pr, 1, label);
                            }
                gt_cache_clear(&gtc);
                study_ao_i_frame_free(&f);
                if (st == OBS_STATUS_OK && s->dirty)
                    st = save_table(ctx, s);
            }
    study_progress_end(&pr);
    /* what was measured is kept, even on an error */
    if (st == OBS_STATUS_OK || s->dirty) {
        obs_status ss = save_table(ctx, s);
        st = st == OBS_STATUS_OK ? ss : st;
    }
    return st;
}

static void log_plan(const study_ao *s, obs_pool *pool)
{
    if (!s->o.log)
        return;
    const study_ao_plan p = study_ao_plan_of(s);
    fprintf(s->o.log,
            "obscura: study ao: %lld points (%d scenes x %d views x %d resolutions x %d methods x %d samples x "
            "%d radii x %d blur), %d timed runs each, %d threads\n",
            (long long)p.points, p.scenes, p.views, p.resolutions, p.methods, p.samples, p.radii, p.blurs, p.runs,
            obs_pool_threads(pool));
}

obs_status study_ao_truth(obs_context *ctx, obs_pool *pool, study_ao *s)
{
    log_plan(s, pool);
    return sweep(ctx, pool, s, 1);
}

obs_status study_ao_sweep(obs_context *ctx, obs_pool *pool, study_ao *s)
{
    log_plan(s, pool);
    return sweep(ctx, pool, s, 0);
}

/* ================================================================================================
 * Merging shards (docs/scale.md)
 * ============================================================================================== */

/* The value of key in a manifest's config text ("k=v;k=v"), copied into out; NULL when absent. */
static const char *config_value(const char *config, const char *key, char *out, size_t size)
{
    const size_t kl = strlen(key);
    for (const char *p = config; p && *p;) {
        const char *e = strchr(p, ';');
        const size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len > kl && !strncmp(p, key, kl) && p[kl] == '=') {
            const size_t vl = len - kl - 1 < size - 1 ? len - kl - 1 : size - 1;
            memcpy(out, p + kl + 1, vl);
            out[vl] = 0;
            return out;
        }
        p = e ? e + 1 : NULL;
    }
    return NULL;
}

obs_status study_ao_merge(obs_context *ctx, obs_pool *pool, const char *const *dirs, int count, const char *out_dir,
                          const char *report_dir, const char *data_dir, FILE *log)
{
    if (!dirs || count < 1 || !out_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study merge: no shard directories or no output directory");
    study_manifest *m = (study_manifest *)calloc((size_t)count, sizeof *m);
    study_table *tables = (study_table *)calloc((size_t)count, sizeof *tables);
    if (!m || !tables) {
        free(m);
        free(tables);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study merge: out of memory");
    }
    obs_status st = OBS_STATUS_OK;
    /* The manifests: one study, one configuration, one version, one shard count, each shard once. */
    for (int i = 0; i < count && st == OBS_STATUS_OK; i++) {
        st = study_manifest_read(ctx, dirs[i], &m[i]);
        if (st != OBS_STATUS_OK)
            break;
        if (strcmp(m[i].study, "ao") != 0)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study merge: %s holds a '%s' study, not 'ao'", dirs[i],
                           m[i].study);
        else if (i > 0 && strcmp(m[i].version, m[0].version) != 0)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                           "study merge: %s was written by obscura %s, %s by %s: refusing to merge versions", dirs[i],
                           m[i].version, dirs[0], m[0].version);
        else if (i > 0 && strcmp(m[i].config_hash, m[0].config_hash) != 0)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                           "study merge: %s has another configuration than %s (config hash %s, not %s): %s", dirs[i],
                           dirs[0], m[i].config_hash, m[0].config_hash, m[i].config);
        else if (i > 0 && m[i].shards != m[0].shards)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study merge: %s is a shard of %d, %s of %d", dirs[i],
                           m[i].shards, dirs[0], m[0].shards);
        for (int j = 0; j < i && st == OBS_STATUS_OK; j++)
            if (m[j].shard == m[i].shard)
                st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study merge: %s and %s are both shard %d of %d", dirs[j],
                               dirs[i], m[i].shard, m[i].shards);
    }
    /* The study the shards ran, from the first manifest's configuration. */
    char scenes[1024], views[1024], methods[1200], resolutions[1024], samples[512], radii[512], blurs[64], num[64];
    study_ao_options o = study_ao_options_default();
    if (st == OBS_STATUS_OK) {
        const char *c = m[0].config;
        if (!config_value(c, "scenes", scenes, sizeof scenes) || !config_value(c, "views", views, sizeof views) ||
            !config_value(c, "methods", methods, sizeof methods) ||
            !config_value(c, "resolutions", resolutions, sizeof resolutions) ||
            !config_value(c, "samples", samples, sizeof samples) || !config_value(c, "radii", radii, sizeof radii) ||
            !config_value(c, "blurs", blurs, sizeof blurs))
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "study merge: %s/manifest.json: incomplete configuration", dirs[0]);
        o.scenes = scenes, o.views = views, o.methods = methods, o.resolutions = resolutions;
        o.samples = samples, o.radii = radii, o.blurs = blurs;
        if (config_value(c, "runs", num, sizeof num))
            o.runs = atoi(num);
        if (config_value(c, "gt_max_samples", num, sizeof num))
            o.gt_max_samples = atoll(num);
        if (config_value(c, "quick", num, sizeof num))
            o.quick = atoi(num);
    }
    o.out_dir = out_dir;
    o.report_dir = report_dir;
    if (data_dir)
        o.data_dir = data_dir;
    o.log = log;
    study_ao *s = NULL;
    if (st == OBS_STATUS_OK)
        st = study_ao_open(ctx, &o, &s);
    if (st == OBS_STATUS_OK && s->table.rows > 0)
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study merge: %s already holds a results table", out_dir);
    /* Each shard's table (the merge does not trust a shard's rows to be its own: it takes a point
     * from whichever table has it, and refuses a point two tables hold). */
    for (int i = 0; i < count && st == OBS_STATUS_OK; i++) {
        char csv[4200];
        snprintf(csv, sizeof csv, "%s/results.csv", dirs[i]);
        int64_t rows = 0;
        st = study_table_init(ctx, &tables[i], study_ao_i_columns, NCOL, KEY_COLUMNS);
        if (st == OBS_STATUS_OK)
            st = study_table_read_csv(ctx, &tables[i], csv, &rows);
    }
    /* The rows in a single run's order: frames (scene, view, resolution), then radius, method,
     * samples, blur (sweep). */
    int64_t merged = 0, missing = 0;
    for (int si = 0; st == OBS_STATUS_OK && si < s->scenes.n; si++)
        for (int vi = 0; st == OBS_STATUS_OK && vi < s->views.n; vi++)
            for (int ri = 0; st == OBS_STATUS_OK && ri < s->resolutions.n; ri++) {
                int W = 0, H = 0;
                study_ao_i_parse_size(s->resolutions.v[ri], &W, &H);
                char ws[32], hs[32];
                snprintf(ws, sizeof ws, "%d", W);
                snprintf(hs, sizeof hs, "%d", H);
                for (int qi = 0; qi < s->radii.n && st == OBS_STATUS_OK; qi++)
                    for (int mi = 0; mi < s->methods.n && st == OBS_STATUS_OK; mi++)
                        for (int ni = 0; ni < s->samples.n && st == OBS_STATUS_OK; ni++)
                            for (int bi = 0; bi < s->blurs.n && st == OBS_STATUS_OK; bi++) {
                                const char *key[KEY_COLUMNS] = {s->scenes.v[si], s->views.v[vi], ws, hs,
                                                                s->methods.v[mi], s->samples.v[ni], s->radii.v[qi],
                                                                s->blurs.v[bi]};
                                int from = -1;
                                int64_t row = -1;
                                for (int i = 0; i < count && st == OBS_STATUS_OK; i++) {
                                    const int64_t r = study_table_find(&tables[i], key);
                                    if (r < 0)
                                        continue;
                                    if (from >= 0)
                                        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                                       "study merge: %s and %s both hold the point %s/%s %sx%s %s n=%s "
                                                       "r=%s b=%s",
                                                       dirs[from], dirs[i], key[0], key[1], key[2], key[3], key[4],
                                                       key[5], key[6], key[7]);
                                    from = i;
                                    row = r;
                                }
                                if (st != OBS_STATUS_OK)
                                    break;
                                if (from < 0) {
                                    missing++;
                                    continue;
                                }
                                const char *cells[STUDY_MAX_COLUMNS];
                                for (int c = 0; c < NCOL; c++)
                                    cells[c] = study_table_get(&tables[from], row, c);
                                st = study_table_append(ctx, &s->table, cells);
                                merged++;
                            }
            }
    if (st == OBS_STATUS_OK) {
        s->o.shard = 1, s->o.shards = 1; /* the merged table is the whole study's */
        st = save_table(ctx, s);
    }
    if (st == OBS_STATUS_OK && log)
        fprintf(log, "obscura: study merge: %d shard%s of %d, %lld points into %s/results.csv%s\n", count,
                count > 1 ? "s" : "", m[0].shards, (long long)merged, out_dir,
                missing ? " (some points were measured by no shard: see below)" : "");
    if (st == OBS_STATUS_OK && log && missing)
        fprintf(log, "obscura: study merge: %lld points missing (%d of %d shards given)\n", (long long)missing, count,
                m[0].shards);
    if (st == OBS_STATUS_OK && report_dir)
        st = study_ao_report(ctx, pool, s);
    for (int i = 0; i < count; i++)
        study_table_free(&tables[i]);
    free(tables);
    free(m);
    study_ao_close(s);
    return st;
}
