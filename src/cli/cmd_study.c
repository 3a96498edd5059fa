/* cmd_study.c: `obscura study ao`: what AO accuracy costs in time (issue 5). A sweep over scenes,
 * views, resolutions, techniques, samples, radii and blur; for each point the time per pass (median,
 * min and max of several runs) and the error against the technique's matched ground truth, raw and
 * calibrated; then plots, image grids, tables and a Markdown report. The generic parts (table,
 * resume, statistics, Pareto fronts, progress, SVG) are src/study/study.h. docs/study.md. */
#include "cli.h"
#include "io/io.h"
#include "ao/ao.h"
#include "metrics/metrics.h"
#include "study/study.h"
#include "truth/truth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *study_help =
    "usage: obscura study ao [--quick] [-o DIR] [--report DIR] [options]\n"
    "Sweeps every AO technique and measures time per pass and error against its matched ground truth.\n"
    "  --quick                a small sweep for CI (the bunny, 192x108, 8 samples, radius 1 unit)\n"
    "  -o, --out DIR          results: DIR/results.csv, DIR/results.json, ground truth cache DIR/gt/\n"
    "                         (default out/study-ao); points already in results.csv are not redone\n"
    "  --report DIR           also write DIR/README.md with plots (SVG), image grids (PNG) and tables\n"
    "  --scenes LIST          comma-separated names from the study set (default: dragon_plane,village,room,bunny)\n"
    "  --views LIST           cameras (default: default,view2)\n"
    "  --methods LIST         techniques (default: every registered one, see 'obscura ao --list')\n"
    "  --resolutions LIST     e.g. 3840x2160,1920x1080,1280x720 (the default)\n"
    "  --samples LIST         samples per pixel (GTAO: slices x steps), default 4,8,16,32\n"
    "  --radii LIST           radius in scene units, default 0.5,1,1.5,2\n"
    "  --blur LIST            0,1 (default both)\n"
    "  --runs N               timed runs per point (default 5; the median is reported)\n"
    "  --gt-target-error E    ground truth: stop a pixel at this standard error (default 0.01)\n"
    "  --gt-max-samples N     ground truth: samples per pixel at most at 1280x720 or less (default 256);\n"
    "                         larger images get it scaled by 921600 / pixels (1080p 112, 4K 32)\n"
    "  --budgets LIST         frame budgets in ms for the summary and the grids (default 1,2,4,8)\n"
    "  --data DIR             where the scenes are (default: the build's data directory)\n"
    "  --dry-run              print the points and the expected duration, measure nothing\n"
    "  --truth-only           compute (and cache) the ground truths the points need, measure nothing\n"
    "  --report-only          write the --report from DIR/results.csv as it is, measure nothing (the\n"
    "                         axes given still choose the tables' rows and columns)\n";

#ifndef OBS_STUDY_DATA_DIR
#define OBS_STUDY_DATA_DIR "build/data"
#endif

/* The study set (issue 5) and each scene's unit, in metres: the radius axis is in these units.
 * Our choice, about a quarter of the scene's typical feature: the bunny and the dragon are
 * normalised to a 1 m bounding sphere (docs/data.md), the room's furniture is about 0.5-2 m, the
 * village's houses are 6 m wide. */
typedef struct scene_def {
    const char *name;
    double unit;
} scene_def;
static const scene_def study_scenes[] = {
    {"dragon_plane", 0.25}, {"village", 1.5}, {"room", 0.5}, {"bunny", 0.25}, {"sphere_on_plane", 0.5},
};

static double scene_unit(const char *name)
{
    for (size_t i = 0; i < sizeof study_scenes / sizeof study_scenes[0]; i++)
        if (!strcmp(study_scenes[i].name, name))
            return study_scenes[i].unit;
    return 1.0;
}

/* ---- lists ---------------------------------------------------------------------------------- */

#define MAX_LIST 32

typedef struct str_list {
    int n;
    char *v[MAX_LIST];
    char *buf;
} str_list;

static int split(const char *s, str_list *l)
{
    free(l->buf);
    memset(l, 0, sizeof *l);
    if (!s || !*s)
        return 0;
    l->buf = strdup(s);
    if (!l->buf)
        return 0;
    for (char *tok = strtok(l->buf, ","); tok; tok = strtok(NULL, ",")) {
        if (l->n == MAX_LIST)
            return 0;
        l->v[l->n++] = tok;
    }
    return l->n > 0;
}

/* ---- the results table ------------------------------------------------------------------------ */

static const char *const columns[] = {
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
    /* the ground truth's own noise taken out (see noise_corrected) */
    "gt_rms_std_error", "rmse_nc", "cal_rmse_nc",
    /* the ground truth's noise from a second, independent ground truth (appended last: tables
     * written before it are read with it empty, and refreshed, see refresh_noise) */
    "gt_noise_rms",
};
enum { KEY_COLUMNS = 8, NCOL = (int)(sizeof columns / sizeof columns[0]) };

/* ---- options ---------------------------------------------------------------------------------- */

typedef struct study_opts {
    int quick, dry_run, runs, truth_only, report_only;
    const char *out_dir, *report_dir, *data_dir;
    str_list scenes, views, methods, resolutions, samples, radii, blurs, budgets;
    double gt_target_error;
    long long gt_max_samples;
} study_opts;

/* mkdir -p dir (cli_make_parent_dirs creates the directories of a path's directory part). */
static obs_status ensure_dir(obs_context *ctx, const char *dir)
{
    char buf[4200];
    if (strlen(dir) + 3 > sizeof buf)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "directory name too long: %.64s...", dir);
    memcpy(buf, dir, strlen(dir));
    memcpy(buf + strlen(dir), "/x", 3);
    return cli_make_parent_dirs(ctx, buf);
}

/* ---- per scene, view and resolution: the G-buffer and the ground truth cache --------------------- */

typedef struct frame {
    obs_scene scene;
    truth_scene *ts;
    obs_camera cam;
    rast_gbuffer gb;
    ao_input in;
    obs_image_f32 nrm[3];           /* normals for the blend (the G-buffer's) */
    obs_image_f32 mask;             /* 1 on surface pixels (w x h) */
    obs_image_f32 fit_mask;         /* the surface pixels of a regular s x s lattice: the calibration fit's */
    study_stats raster;
} frame;

static void frame_free(frame *f)
{
    rast_gbuffer_free(&f->gb);
    obs_image_f32_free(&f->mask);
    obs_image_f32_free(&f->fit_mask);
    truth_scene_destroy(f->ts);
    obs_scene_free(&f->scene);
    memset(f, 0, sizeof *f);
}

static obs_status frame_render(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene_name,
                               const char *view, int W, int H, int need_truth, frame *f)
{
    memset(f, 0, sizeof *f);
    obs_scene_init(&f->scene);
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.glb", o->data_dir, scene_name);
    obs_status st = cli_load_scene(ctx, path, &f->scene);
    if (st == OBS_STATUS_OK)
        st = cli_pick_camera(ctx, &f->scene, view, &f->cam);
    if (st != OBS_STATUS_OK)
        return st;
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    st = rast_gbuffer_alloc(ctx, &rp, &f->gb);
    rast_view rv = {f->cam};
    double t[16];
    const int runs = o->runs < 16 ? o->runs : 16;
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

/* The ground truth for (scene, view, size, estimator, radius), from the cache DIR/gt/ or computed
 * and cached. mean and se are allocated here. */
/* The ground truth's per-pixel sample cap at W x H: gt_max_samples is the cap at 1280x720 or
 * less; larger images get it scaled down by their pixel count (a multiple of the batch of 16, at
 * least 32), so that every resolution's ground truth costs about the same rays. The larger noise
 * per pixel averages out in the error statistics, and the noise-corrected RMSE removes its
 * contribution (noise_corrected); SSIM is not corrected (docs/study.md). */
static long long gt_cap(const study_opts *o, int W, int H)
{
    const double px = (double)W * (double)H, ref = 1280.0 * 720.0;
    if (px <= ref)
        return o->gt_max_samples;
    long long n = (long long)(o->gt_max_samples * ref / px / 16.0 + 0.5) * 16;
    n = n < 32 ? 32 : n;
    return n < o->gt_max_samples ? n : o->gt_max_samples;
}

/* The cache file of a ground truth; seed 0 is the reference, seed 1 its independent replicate. */
static void gt_path(const study_opts *o, const char *scene_name, const char *view, const frame *f,
                    const char *estimator, float radius, unsigned seed, char *path, size_t size)
{
    char rep[16] = "";
    if (seed)
        snprintf(rep, sizeof rep, "_s%u", seed);
    snprintf(path, size, "%s/gt/%s_%s_%dx%d_%s_r%.6g_e%.3g_m%lld%s.exr", o->out_dir, scene_name, view, f->in.w,
             f->in.h, estimator, (double)radius, o->gt_target_error, gt_cap(o, f->in.w, f->in.h), rep);
}

/* Mean and root-mean-square of the ground truth's standard error over the surface pixels. */
static void gt_noise(const frame *f, const obs_image_f32 *se, double *mean_se, double *rms_se)
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
static obs_status gt_write(obs_context *ctx, const study_opts *o, const char *path, const char *estimator,
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
    snprintf(gtdir, sizeof gtdir, "%s/gt", o->out_dir);
    obs_status st = ensure_dir(ctx, gtdir);
    if (st == OBS_STATUS_OK)
        st = io_exr_write(ctx, path, ch, 3, at, 1);
    return st;
}

static obs_status ground_truth(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene_name,
                               const char *view, frame *f, const char *estimator, float radius, unsigned seed,
                               obs_image_f32 *mean, double *mean_se, double *rms_se)
{
    char path[4096];
    gt_path(o, scene_name, view, f, estimator, radius, seed, path, sizeof path);
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
    truth_ao_params tp = truth_ao_params_default();
    if (!truth_ao_estimator_from_name(estimator, &tp.estimator))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study: unknown estimator %s", estimator);
    tp.radius = radius;
    tp.target_error = o->gt_target_error;
    tp.min_samples = 32;
    tp.batch = 16;
    tp.max_samples = gt_cap(o, f->in.w, f->in.h);
    tp.seed = seed;
    truth_ao_result r;
    obs_status st = truth_ao_render(ctx, pool, f->ts, &f->scene, &f->cam, &f->gb, &tp, &r);
    if (st != OBS_STATUS_OK)
        return st;
    st = gt_write(ctx, o, path, estimator, &r);
    gt_noise(f, &r.std_error, mean_se, rms_se);
    *mean = r.mean;
    memset(&r.mean, 0, sizeof r.mean);
    truth_ao_result_free(&r);
    return st;
}

/* ---- the ground truths a frame needs, computed together ----------------------------------------- */

/* The estimators whose rays can be shared (truth_ao_render_multi): 0 cosine-weighted hemisphere,
 * 1 uniform hemisphere, 2 + k for VOL (alone). */
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

/* Compute, for frame f, every (estimator, radius) in need[0..n-1] that is not cached yet: the
 * hemisphere estimators of one family in one ray set per up to TRUTH_AO_MAX_OUTPUTS outputs, VOL
 * one radius at a time; each output goes to its own cache file, as ground_truth() would write it.
 * The values are those of the single runs for the same rays; a pixel of a shared set stops when
 * all its outputs are within the target (so it takes at least the samples each alone would). */
/* One seed's pass of gt_prepare: the need[] entries whose cache file for that seed is missing. */
static obs_status gt_prepare_seed(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene_name,
                                  const char *view, frame *f, const gt_need *need, int n, unsigned seed, int quiet)
{
    obs_status st = OBS_STATUS_OK;
    int done[256] = {0};
    for (int i = 0; i < n; i++) {
        char path[4096];
        gt_path(o, scene_name, view, f, truth_ao_estimator_name(need[i].est), need[i].radius, seed, path, sizeof path);
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
        truth_ao_params tp = truth_ao_params_default();
        tp.target_error = o->gt_target_error;
        tp.min_samples = 32;
        tp.batch = 16;
        tp.max_samples = gt_cap(o, f->in.w, f->in.h);
        tp.seed = seed;
        truth_ao_result r[TRUTH_AO_MAX_OUTPUTS];
        double t0 = obs_time_now();
        st = truth_ao_render_multi(ctx, pool, f->ts, &f->scene, &f->cam, &f->gb, &tp, outs, k, r);
        if (st != OBS_STATUS_OK)
            break;
        if (!quiet)
            fprintf(stderr,
                    "\rground truth %s/%s %dx%d%s: %d output%s (%s%s) in %.1f s, %.0f Mrays, %.2f samples/px mean\n",
                    scene_name, view, f->in.w, f->in.h, seed ? " (replicate)" : "", k, k > 1 ? "s" : "",
                    truth_ao_estimator_name(outs[0].estimator), k > 1 ? ", ..." : "", obs_time_now() - t0, r[0].stats.rays / 1e6,
                    r[0].stats.pixels_surface ? (double)r[0].stats.rays / (double)r[0].stats.pixels_surface : 0.0);
        for (int j = 0; j < k; j++) {
            char path[4096];
            gt_path(o, scene_name, view, f, truth_ao_estimator_name(outs[j].estimator), outs[j].radius, seed, path,
                    sizeof path);
            if (st == OBS_STATUS_OK)
                st = gt_write(ctx, o, path, truth_ao_estimator_name(outs[j].estimator), &r[j]);
            truth_ao_result_free(&r[j]);
            done[idx[j]] = 1;
        }
    }
    return st;
}

static obs_status gt_prepare(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene_name,
                             const char *view, frame *f, const gt_need *need, int n, int quiet)
{
    if (n > 256)
        n = 256;
    /* seed 0: the reference; seed 1: its independent replicate, for the noise estimate */
    obs_status st = gt_prepare_seed(ctx, pool, o, scene_name, view, f, need, n, 0, quiet);
    if (st == OBS_STATUS_OK)
        st = gt_prepare_seed(ctx, pool, o, scene_name, view, f, need, n, 1, quiet);
    return st;
}

/* The frame's ground truths in memory, loaded once each (a 4K EXR takes a while to decode). */
typedef struct gt_slot {
    char est[32];
    float radius;
    obs_image_f32 mean;
    double mean_se, rms_se;
    double noise_rms; /* sqrt(mean over surface pixels of (g0 - g1)^2 / 2): g0's noise, from its replicate */
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

static obs_status gt_cache_get(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene_name,
                               const char *view, frame *f, gt_cache *c, const char *est, float radius,
                               const gt_slot **out)
{
    for (int i = 0; i < c->n; i++)
        if (!strcmp(c->slot[i].est, est) && c->slot[i].radius == radius) {
            *out = &c->slot[i];
            return OBS_STATUS_OK;
        }
    if (c->n == (int)(sizeof c->slot / sizeof c->slot[0]))
        gt_cache_clear(c);
    gt_slot *s = &c->slot[c->n];
    memset(s, 0, sizeof *s);
    snprintf(s->est, sizeof s->est, "%s", est);
    s->radius = radius;
    obs_status st = ground_truth(ctx, pool, o, scene_name, view, f, est, radius, 0, &s->mean, &s->mean_se, &s->rms_se);
    obs_image_f32 g1 = {0};
    double se1;
    if (st == OBS_STATUS_OK)
        st = ground_truth(ctx, pool, o, scene_name, view, f, est, radius, 1, &g1, &se1, NULL);
    if (st != OBS_STATUS_OK) {
        obs_image_f32_free(&s->mean);
        obs_image_f32_free(&g1);
        return st;
    }
    /* Two independent randomisations of the same estimator (Cranley-Patterson shifts from seeds 0
     * and 1): E[(g0 - g1)^2] = 2 Var(g0), per pixel, whatever the sequence's convergence rate: the
     * replicate variance estimate of randomised QMC [L'Ecuyer & Lemieux 2002, "Recent advances in
     * randomized quasi-Monte Carlo methods", section 3; Owen 1997]. */
    double s2 = 0.0;
    int64_t n = 0;
    for (int y = 0; y < f->in.h; y++)
        for (int x = 0; x < f->in.w; x++)
            if (obs_image_f32_row(&f->mask, y)[x] != 0.0f) {
                double d = (double)obs_image_f32_row(&s->mean, y)[x] - obs_image_f32_row(&g1, y)[x];
                s2 += d * d;
                n++;
            }
    s->noise_rms = n ? sqrt(s2 / (2.0 * (double)n)) : 0.0;
    obs_image_f32_free(&g1);
    c->n++;
    *out = s;
    return OBS_STATUS_OK;
}

/* Error against a noisy reference: E[(a - g_hat)^2] = (a - g)^2 + Var(g_hat) (a is independent of
 * the reference's noise), so the mean squared error less the reference's mean noise variance
 * estimates the mean squared error against the exact g; clamped at 0. The variance comes from an
 * independent replicate (gt_cache_get), not from the per-pixel i.i.d. standard error: that
 * formula over-estimates the spread of these low-discrepancy estimates by a factor that varies
 * per pixel (on an open plane VOL's estimate is exact after every even sample count while its
 * i.i.d. SE is 0.5/sqrt(n)), so subtracting it would over-correct. */
static double noise_corrected(double rmse, double noise_rms)
{
    double d = rmse * rmse - noise_rms * noise_rms;
    return d > 0.0 ? sqrt(d) : 0.0;
}

/* ---- one point -------------------------------------------------------------------------------- */

typedef struct point_result {
    study_stats prepare, kernel, blur, blend, total;
    met_result raw, cal;
    met_fit fit;
    double gt_se, gt_rms, gt_noise;
    char params[1024];
    char status[256];
} point_result;

/* Run method m with params p on frame f `runs` times (after one warm-up), time it, and compare
 * with the ground truth gt (may be NULL). ao receives the last run's AO (w x h, allocated). */
static obs_status run_point(obs_context *ctx, obs_pool *pool, const ao_method *m, const void *p, frame *f, int runs,
                            const obs_image_f32 *gt, obs_image_f32 *ao, point_result *res)
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
        ao_stats s;
        memset(&s, 0, sizeof s);
        double t0 = obs_time_now();
        st = m->compute(ctx, pool, &f->in, p, ao, &raw, &s);
        double t1 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = ao_blend_lambert(ctx, pool, &f->in, ao, np, &blend);
        double t2 = obs_time_now();
        if (r >= 0) {
            tp[r] = 1e3 * s.seconds_prepare;
            tk[r] = 1e3 * s.seconds_kernel;
            tb[r] = 1e3 * s.seconds_blur;
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

/* ---- formatting helpers ------------------------------------------------------------------------ */

static void fmt(char *buf, double v) { snprintf(buf, 32, "%.9g", v); }

/* ---- the sweep ---------------------------------------------------------------------------------- */

typedef struct sweep_ctx {
    cli_globals *g;
    study_opts *o;
    study_table table;
    char csv[4096], json[4096];
    double last_save;
    int dirty;
} sweep_ctx;

static obs_status save_table(obs_context *ctx, sweep_ctx *s)
{
    s->last_save = obs_time_now();
    s->dirty = 0;
    obs_status st = ensure_dir(ctx, s->o->out_dir);
    if (st == OBS_STATUS_OK)
        st = study_table_write_csv(ctx, &s->table, s->csv);
    if (st == OBS_STATUS_OK)
        st = study_table_write_json(ctx, &s->table, s->json);
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

/* Does a point still need work: not measured (row < 0), or measured ("ok") before its ground
 * truth's replicate-based noise was recorded? */
static int row_pending(const study_table *t, int64_t row)
{
    if (row < 0)
        return 1;
    return !strcmp(study_table_get(t, row, study_table_column(t, "status")), "ok") &&
           !study_table_get(t, row, study_table_column(t, "gt_noise_rms"))[0];
}

/* Record a measured row's ground-truth noise and its noise-corrected RMSEs from its raw ones. */
static obs_status refresh_noise(obs_context *ctx, study_table *t, int64_t row, double noise_rms)
{
    char a[32], b[32], c[32];
    fmt(a, noise_rms);
    fmt(b, noise_corrected(study_table_num(t, row, study_table_column(t, "rmse")), noise_rms));
    fmt(c, noise_corrected(study_table_num(t, row, study_table_column(t, "cal_rmse")), noise_rms));
    obs_status st = study_table_set(ctx, t, row, study_table_column(t, "gt_noise_rms"), a);
    if (st == OBS_STATUS_OK)
        st = study_table_set(ctx, t, row, study_table_column(t, "rmse_nc"), b);
    if (st == OBS_STATUS_OK)
        st = study_table_set(ctx, t, row, study_table_column(t, "cal_rmse_nc"), c);
    return st;
}

static obs_status sweep(obs_context *ctx, obs_pool *pool, sweep_ctx *s)
{
    study_opts *o = s->o;
    const int nres = o->resolutions.n;
    int64_t total = (int64_t)o->scenes.n * o->views.n * nres * o->methods.n * o->samples.n * o->radii.n * o->blurs.n;
    if (!s->g->quiet)
        fprintf(stderr,
                "obscura: study ao: %lld points (%d scenes x %d views x %d resolutions x %d methods x %d samples x "
                "%d radii x %d blur), %d timed runs each, %d threads\n",
                (long long)total, o->scenes.n, o->views.n, nres, o->methods.n, o->samples.n, o->radii.n, o->blurs.n,
                o->runs, obs_pool_threads(pool));
    if (o->dry_run) {
        /* Expected duration, from the full study's own rates on the 2-core development machine
         * (2026-12-01; docs/study.md): a point with 5 runs costs about 0.5 us per pixel (1 s at
         * 1080p averaged over techniques and samples: the runs, the error and the calibration fit);
         * the ground truth of a frame about 4-10 s per ray set (one per radius for VOL, one for each
         * of the two hemisphere families) at any resolution, its sample cap scaling with the pixels.
         * Coarse, stated as a range; the bar's ETA comes from the points measured. */
        double px = 0.0;
        for (int r = 0; r < nres; r++) {
            int W, H;
            if (cli_parse_size(o->resolutions.v[r], &W, &H))
                px += (double)W * H;
        }
        double pts = (double)o->scenes.n * o->views.n * o->methods.n * o->samples.n * o->radii.n * o->blurs.n;
        double mid = pts * px * 0.5e-6 * (o->runs + 1) / 6.0, lo = 0.6 * mid, hi = 1.5 * mid;
        double sets = (double)o->scenes.n * o->views.n * nres * (o->radii.n + 2);
        printf("expected duration: sweep %.0f-%.0f min, ground truth %.0f-%.0f min (first run; cached after)\n",
               lo / 60, hi / 60, sets * 4.0 / 60, sets * 10.0 / 60);
        return OBS_STATUS_OK;
    }
    study_progress pr;
    study_progress_begin(&pr, s->g->quiet ? NULL : stderr, total);
    obs_status st = OBS_STATUS_OK;
    for (int si = 0; si < o->scenes.n && st == OBS_STATUS_OK; si++)
        for (int vi = 0; vi < o->views.n && st == OBS_STATUS_OK; vi++)
            for (int ri = 0; ri < nres && st == OBS_STATUS_OK; ri++) {
                const char *scene = o->scenes.v[si], *view = o->views.v[vi];
                int W = 0, H = 0;
                cli_parse_size(o->resolutions.v[ri], &W, &H);
                char ws[32], hs[32];
                snprintf(ws, sizeof ws, "%d", W);
                snprintf(hs, sizeof hs, "%d", H);
                /* Which points are still to do here? */
                int64_t remaining = 0;
                for (int mi = 0; mi < o->methods.n; mi++)
                    for (int ni = 0; ni < o->samples.n; ni++)
                        for (int qi = 0; qi < o->radii.n; qi++)
                            for (int bi = 0; bi < o->blurs.n; bi++) {
                                const char *key[KEY_COLUMNS] = {scene, view, ws, hs, o->methods.v[mi], o->samples.v[ni],
                                                                o->radii.v[qi], o->blurs.v[bi]};
                                remaining += row_pending(&s->table, study_table_find(&s->table, key));
                            }
                if (!remaining) {
                    for (int64_t k = 0; k < (int64_t)o->methods.n * o->samples.n * o->radii.n * o->blurs.n; k++)
                        study_progress_step(&pr, 0, "resumed");
                    continue;
                }
                frame f;
                st = frame_render(ctx, pool, o, scene, view, W, H, 1, &f);
                if (st != OBS_STATUS_OK) {
                    frame_free(&f);
                    break;
                }
                const double unit = scene_unit(scene);
                {
                    /* every ground truth this frame's remaining points need, computed together */
                    gt_need need[256];
                    int nn = 0;
                    for (int qi = 0; qi < o->radii.n; qi++)
                        for (int mi = 0; mi < o->methods.n; mi++)
                            for (int ni = 0; ni < o->samples.n; ni++)
                                for (int bi = 0; bi < o->blurs.n; bi++) {
                                    const char *key[KEY_COLUMNS] = {scene, view, ws, hs, o->methods.v[mi],
                                                                    o->samples.v[ni], o->radii.v[qi], o->blurs.v[bi]};
                                    if (!row_pending(&s->table, study_table_find(&s->table, key)))
                                        continue;
                                    const ao_method *m = ao_method_find(o->methods.v[mi]);
                                    unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
                                    point_params(m, o->samples.v[ni], o->radii.v[qi], o->blurs.v[bi], unit, p);
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
                    st = gt_prepare(ctx, pool, o, scene, view, &f, need, nn, s->g->quiet);
                }
                gt_cache gtc;
                memset(&gtc, 0, sizeof gtc);
                /* rows measured before the replicate-based noise existed: fill it in (no timing) */
                for (int qi = 0; qi < o->radii.n && st == OBS_STATUS_OK; qi++)
                    for (int mi = 0; mi < o->methods.n && st == OBS_STATUS_OK; mi++)
                        for (int ni = 0; ni < o->samples.n && st == OBS_STATUS_OK; ni++)
                            for (int bi = 0; bi < o->blurs.n && st == OBS_STATUS_OK; bi++) {
                                const char *key[KEY_COLUMNS] = {scene, view, ws, hs, o->methods.v[mi], o->samples.v[ni],
                                                                o->radii.v[qi], o->blurs.v[bi]};
                                const int64_t row = study_table_find(&s->table, key);
                                if (row < 0 || !row_pending(&s->table, row))
                                    continue;
                                const ao_method *m = ao_method_find(o->methods.v[mi]);
                                unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
                                point_params(m, o->samples.v[ni], o->radii.v[qi], o->blurs.v[bi], unit, p);
                                const gt_slot *gts = NULL;
                                st = gt_cache_get(ctx, pool, o, scene, view, &f, &gtc, m->truth_estimator(p),
                                                  m->get_radius(p), &gts);
                                if (st == OBS_STATUS_OK)
                                    st = refresh_noise(ctx, &s->table, row, gts->noise_rms);
                                s->dirty = 1;
                            }
                if (o->truth_only) {
                    for (int64_t k = 0; k < (int64_t)o->methods.n * o->samples.n * o->radii.n * o->blurs.n; k++)
                        study_progress_step(&pr, 0, "ground truth");
                    gt_cache_clear(&gtc);
                    frame_free(&f);
                    if (st == OBS_STATUS_OK && s->dirty)
                        st = save_table(ctx, s);
                    continue;
                }
                for (int qi = 0; qi < o->radii.n && st == OBS_STATUS_OK; qi++)
                    for (int mi = 0; mi < o->methods.n && st == OBS_STATUS_OK; mi++)
                        for (int ni = 0; ni < o->samples.n && st == OBS_STATUS_OK; ni++)
                            for (int bi = 0; bi < o->blurs.n && st == OBS_STATUS_OK; bi++) {
                                const ao_method *m = ao_method_find(o->methods.v[mi]);
                                const char *key[KEY_COLUMNS] = {scene, view, ws, hs, o->methods.v[mi], o->samples.v[ni],
                                                                o->radii.v[qi], o->blurs.v[bi]};
                                char label[128];
                                snprintf(label, sizeof label, "%s/%s %dx%d %s n=%s r=%s b=%s", scene, view, W, H,
                                         m->name, o->samples.v[ni], o->radii.v[qi], o->blurs.v[bi]);
                                if (study_table_find(&s->table, key) >= 0) {
                                    study_progress_step(&pr, 0, label);
                                    continue;
                                }
                                unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
                                const float radius_m = point_params(m, o->samples.v[ni], o->radii.v[qi], o->blurs.v[bi],
                                                                    unit, p);
                                point_result res;
                                memset(&res, 0, sizeof res);
                                m->params_to_string(p, res.params, sizeof res.params);
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
                                row[9] = res.params;
                                row[10] = est;
                                obs_image_f32 ao = {0};
                                const gt_slot *gts = NULL;
                                obs_status ps = m->params_validate(ctx, p);
                                if (ps == OBS_STATUS_OK)
                                    ps = gt_cache_get(ctx, pool, o, scene, view, &f, &gtc, est, m->get_radius(p), &gts);
                                if (ps == OBS_STATUS_OK) {
                                    res.gt_se = gts->mean_se;
                                    res.gt_rms = gts->rms_se;
                                    res.gt_noise = gts->noise_rms;
                                    ps = run_point(ctx, pool, m, p, &f, o->runs, &gts->mean, &ao, &res);
                                }
                                if (ps == OBS_STATUS_OUT_OF_MEMORY || ps == OBS_STATUS_IO_ERROR) {
                                    st = ps; /* a study that cannot allocate or write stops */
                                } else if (ps != OBS_STATUS_OK) {
                                    snprintf(res.status, sizeof res.status, "failed: %s", obs_context_last_error(ctx));
                                    row[11] = res.status;
                                    obs_context_clear_error(ctx);
                                } else {
                                    row[11] = "ok";
                                    double v[] = {f.raster.median, f.raster.min, f.raster.max, res.prepare.median,
                                                  res.kernel.median, res.kernel.min, res.kernel.max, res.blur.median,
                                                  res.blur.min, res.blur.max, res.blend.median, res.total.median,
                                                  res.total.min, res.total.max, o->runs, obs_pool_threads(pool),
                                                  res.raw.rmse, res.raw.ssim, res.raw.bias, res.raw.mae, res.cal.rmse,
                                                  res.cal.ssim, res.cal.bias, res.fit.gain, res.fit.power, res.gt_se,
                                                  (double)res.raw.valid, res.gt_rms,
                                                  noise_corrected(res.raw.rmse, res.gt_noise),
                                                  noise_corrected(res.cal.rmse, res.gt_noise), res.gt_noise};
                                    for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
                                        fmt(cells[12 + k], v[k]);
                                }
                                obs_image_f32_free(&ao);
                                if (st == OBS_STATUS_OK)
                                    st = study_table_append(ctx, &s->table, row);
                                s->dirty = 1;
                                /* every few seconds (the table is rewritten whole, so not after every
                                 * point of a 10,000-point study): a killed study loses at most the
                                 * last seconds of points and resumes */
                                if (st == OBS_STATUS_OK && obs_time_now() - s->last_save > 5.0)
                                    st = save_table(ctx, s);
                                study_progress_step(&pr, 1, label);
                            }
                gt_cache_clear(&gtc);
                frame_free(&f);
                if (st == OBS_STATUS_OK && s->dirty)
                    st = save_table(ctx, s);
            }
    study_progress_end(&pr);
    return st;
}

/* ================================================================================================
 * The report
 * ============================================================================================== */

typedef struct agg {
    char method[32];
    int samples, blur;
    double radius_units;
    double time_sum, err_sum, raw_sum;
    int n;
} agg;

static int col(const study_table *t, const char *name) { return study_table_column(t, name); }

/* The aggregated configuration (of `method`, or of any when NULL) with the lowest mean error among
 * those whose mean time is within budget ms; -1 if none. */
static int best_within(const agg *ag, int na, double budget, const char *method)
{
    int best = -1;
    for (int k = 0; k < na; k++)
        if ((!method || !strcmp(ag[k].method, method)) && ag[k].time_sum / ag[k].n <= budget &&
            (best < 0 || ag[k].err_sum / ag[k].n < ag[best].err_sum / ag[best].n))
            best = k;
    return best;
}

/* Add v to the list l (",a,b," form, at least ","), unless it is there or does not fit. */
static void list_add(char *l, size_t size, const char *v)
{
    char tok[64];
    snprintf(tok, sizeof tok, ",%s,", v);
    if (!strstr(l, tok) && strlen(l) + strlen(tok) < size)
        strcat(l, tok + 1);
}

/* Rows at W x H with status ok, averaged over scenes and views per (method, samples, radius, blur). */
/* The rows at W x H (of one scene, or of all when scene is NULL), averaged per configuration. */
static int aggregate(const study_table *t, int W, int H, const char *scene, agg *out, int max)
{
    int n = 0;
    const int cw = col(t, "width"), ch = col(t, "height"), cm = col(t, "method"), cs = col(t, "samples"),
              cr = col(t, "radius_units"), cb = col(t, "blur"), ct = col(t, "total_ms"), ce = col(t, "cal_rmse_nc"),
              cx = col(t, "rmse_nc"), cst = col(t, "status"), csc = col(t, "scene");
    for (int64_t r = 0; r < t->rows; r++) {
        if (strcmp(study_table_get(t, r, cst), "ok") != 0 || study_table_num(t, r, cw) != W ||
            study_table_num(t, r, ch) != H || (scene && strcmp(study_table_get(t, r, csc), scene) != 0))
            continue;
        const char *m = study_table_get(t, r, cm);
        int smp = (int)study_table_num(t, r, cs), bl = (int)study_table_num(t, r, cb);
        double rad = study_table_num(t, r, cr);
        int k = 0;
        while (k < n && !(strcmp(out[k].method, m) == 0 && out[k].samples == smp && out[k].blur == bl &&
                          out[k].radius_units == rad))
            k++;
        if (k == n) {
            if (n == max)
                continue;
            memset(&out[n], 0, sizeof out[n]);
            snprintf(out[n].method, sizeof out[n].method, "%s", m);
            out[n].samples = smp;
            out[n].blur = bl;
            out[n].radius_units = rad;
            n++;
        }
        out[k].time_sum += study_table_num(t, r, ct);
        out[k].err_sum += study_table_num(t, r, ce);
        out[k].raw_sum += study_table_num(t, r, cx);
        out[k].n++;
    }
    return n;
}

/* An image grid: one row per technique (its AO, the ground truth, the error heat map |AO - GT| on
 * [0, 0.5]), for the chosen point of each. */
typedef struct grid_row {
    const ao_method *m;
    int samples, blur;
    double radius_units;
} grid_row;

static obs_status write_grid(obs_context *ctx, obs_pool *pool, const study_opts *o, const char *scene,
                             const char *view, int W, int H, const grid_row *rows, int nrows, const char *path)
{
    frame f;
    obs_status st = frame_render(ctx, pool, o, scene, view, W, H, 1, &f);
    const int gap = 4, GW = 3 * W + 2 * gap, GH = nrows * H + (nrows - 1) * gap;
    obs_image_f32 rgb[3] = {{0}, {0}, {0}};
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
        st = obs_image_f32_alloc(ctx, GW, GH, &rgb[c]);
        for (int y = 0; st == OBS_STATUS_OK && y < GH; y++)
            for (int x = 0; x < GW; x++)
                obs_image_f32_row(&rgb[c], y)[x] = 1.0f;
    }
    for (int i = 0; i < nrows && st == OBS_STATUS_OK; i++) {
        const ao_method *m = rows[i].m;
        unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
        m->params_default(p);
        m->set_samples(p, rows[i].samples);
        m->set_radius(p, (float)(rows[i].radius_units * scene_unit(scene)));
        m->set_blur(p, rows[i].blur);
        obs_image_f32 ao = {0}, gt = {0};
        double se;
        point_result res;
        memset(&res, 0, sizeof res);
        st = ground_truth(ctx, pool, o, scene, view, &f, m->truth_estimator(p), m->get_radius(p), 0, &gt, &se, NULL);
        if (st == OBS_STATUS_OK)
            st = run_point(ctx, pool, m, p, &f, 1, NULL, &ao, &res);
        for (int y = 0; st == OBS_STATUS_OK && y < H; y++)
            for (int x = 0; x < W; x++) {
                const int yy = i * (H + gap) + y;
                const int surf = obs_image_f32_row(&f.mask, y)[x] != 0.0f;
                const float a = surf ? obs_image_f32_row(&ao, y)[x] : 0.0f;
                const float g = surf ? obs_image_f32_row(&gt, y)[x] : 0.0f;
                float heat[3];
                met_colormap_inferno(surf ? fabs((double)a - g) / 0.5 : 0.0, heat);
                for (int c = 0; c < 3; c++) {
                    obs_image_f32_row(&rgb[c], yy)[x] = a;
                    obs_image_f32_row(&rgb[c], yy)[W + gap + x] = g;
                    /* the colour map is sRGB-encoded: decode (io_png_write encodes) */
                    float v = heat[c];
                    obs_image_f32_row(&rgb[c], yy)[2 * (W + gap) + x] =
                        v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f);
                }
            }
        obs_image_f32_free(&ao);
        obs_image_f32_free(&gt);
    }
    if (st == OBS_STATUS_OK)
        st = io_png_write(ctx, path, rgb, 3, IO_PNG_LINEAR);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&rgb[c]);
    frame_free(&f);
    return st;
}

/* The seed's Table 24 with error: MSSAO's cost per level and the accuracy of stopping at each level,
 * for each scene (first view) at W x H, with the middle swept radius and sample count. The time of a
 * level is its downsample + AO pass + level blur (ao_mssao_stats.seconds_level, median of `runs`);
 * the error of level l is the RMSE against the matched ground truth of levels coarsest..l combined
 * as the finest level's combine would combine them (AO_MSSAO_LEVEL_COMBINED), upsampled to W x H by
 * nearest texel. Writes the rows to md; a scene that fails is reported in its row. */
static obs_status mssao_levels_table(obs_context *ctx, obs_pool *pool, const study_opts *o, int W, int H, FILE *md)
{
    const ao_method *m = ao_method_find("mssao");
    if (!m)
        return OBS_STATUS_OK;
    const double units = atof(o->radii.v[o->radii.n > 1 ? 1 : 0]);
    const int samples = atoi(o->samples.v[o->samples.n > 1 ? 1 : 0]);
    fprintf(md, "\n## MSSAO per level (the seed's Table 24, with error)\n\nAt %dx%d, radius %g units, %d samples, "
                "first view. Time: the level's downsample, AO pass and level blur (median of %d runs). Error: RMSE "
                "against the matched ground truth of the levels from the coarsest down to this one, combined as the "
                "finest level combines them and upsampled by nearest texel (level 0 is the method's output).\n\n"
                "| scene | level | size | ms | RMSE |\n|---|---|---|---|---|\n",
            W, H, units, samples, o->runs);
    obs_status st = OBS_STATUS_OK;
    for (int sc = 0; sc < o->scenes.n && st == OBS_STATUS_OK; sc++) {
        const char *scene = o->scenes.v[sc], *view = o->views.v[0];
        frame f;
        st = frame_render(ctx, pool, o, scene, view, W, H, 1, &f);
        ao_mssao_params p;
        m->params_default(&p);
        m->set_radius(&p, (float)(units * scene_unit(scene)));
        m->set_samples(&p, samples);
        m->set_blur(&p, 0);
        obs_image_f32 gt = {0}, out = {0}, up = {0}, lvimg = {0};
        double gt_se = 0.0;
        if (st == OBS_STATUS_OK)
            st = ground_truth(ctx, pool, o, scene, view, &f, m->truth_estimator(&p), m->get_radius(&p), 0, &gt, &gt_se, NULL);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &out);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &up);
        double t[AO_MSSAO_MAX_LEVELS][16];
        const int runs = o->runs < 16 ? o->runs : 16;
        for (int r = -1; r < runs && st == OBS_STATUS_OK; r++) {
            ao_mssao_stats ms;
            memset(&ms, 0, sizeof ms);
            st = ao_mssao_compute(ctx, pool, &f.in, &p, &out, NULL, &ms);
            for (int l = 0; r >= 0 && l < AO_MSSAO_MAX_LEVELS; l++)
                t[l][r] = 1e3 * ms.seconds_level[l];
        }
        ao_mssao_levels lv;
        memset(&lv, 0, sizeof lv);
        if (st == OBS_STATUS_OK)
            st = ao_mssao_compute_levels(ctx, pool, &f.in, &p, &lv);
        for (int l = 0; st == OBS_STATUS_OK && l < lv.count; l++) {
            const int lw = lv.level[l].width, lh = lv.level[l].height;
            st = obs_image_f32_alloc(ctx, lw, lh, &lvimg);
            if (st == OBS_STATUS_OK)
                st = ao_mssao_level_visibility(ctx, &lv, l, AO_MSSAO_LEVEL_COMBINED, &lvimg);
            met_result mr;
            memset(&mr, 0, sizeof mr);
            if (st == OBS_STATUS_OK) {
                /* level texel of full-buffer pixel (x, y): GL rows halve from the bottom, so map
                 * through GL coordinates; our row order for both images */
                for (int y = 0; y < H; y++) {
                    const int ygl = (H - 1 - y) >> l, ly = lh - 1 - (ygl < lh ? ygl : lh - 1);
                    for (int x = 0; x < W; x++) {
                        const int lx = (x >> l) < lw ? x >> l : lw - 1;
                        obs_image_f32_row(&up, y)[x] = obs_image_f32_row(&lvimg, ly)[lx];
                    }
                }
                met_params mp = met_params_default();
                st = met_compare(ctx, pool, &gt, &up, &f.mask, &mp, &mr);
            }
            if (st == OBS_STATUS_OK) {
                study_stats ts = study_stats_of(t[l], runs);
                fprintf(md, "| %s | %d | %dx%d | %.2f | %.4f |\n", scene, l, lw, lh, ts.median, mr.rmse);
            }
            obs_image_f32_free(&lvimg);
        }
        ao_mssao_levels_free(&lv);
        obs_image_f32_free(&gt);
        obs_image_f32_free(&out);
        obs_image_f32_free(&up);
        frame_free(&f);
    }
    return st;
}

static obs_status report(obs_context *ctx, obs_pool *pool, sweep_ctx *s)
{
    study_opts *o = s->o;
    const study_table *t = &s->table;
    obs_status dst = ensure_dir(ctx, o->report_dir);
    if (dst != OBS_STATUS_OK)
        return dst;
    char path[4096];
    char mdpath[4096];
    snprintf(mdpath, sizeof mdpath, "%s/README.md", o->report_dir);
    /* The page is built in memory and written atomically at the end. */
    char *mdtext = NULL;
    size_t mdlen = 0;
    FILE *md = open_memstream(&mdtext, &mdlen);
    if (!md)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", mdpath);
    /* The main resolution: 1920x1080 when swept, else the first. */
    int MW = 0, MH = 0;
    for (int r = 0; r < o->resolutions.n; r++) {
        int w, h;
        cli_parse_size(o->resolutions.v[r], &w, &h);
        if (r == 0 || (w == 1920 && h == 1080)) {
            MW = w;
            MH = h;
        }
    }
    fprintf(md, "# What AO accuracy costs in time\n\n");
    fprintf(md, "Generated by `obscura study ao%s --report %s` (obscura %s). Reproduce: docs/study.md.\n\n",
            o->quick ? " --quick" : "", o->report_dir, OBS_VERSION_STRING);
    /* the table itself beside the page: the numbers behind every figure */
    snprintf(path, sizeof path, "%s/results.csv", o->report_dir);
    dst = study_table_write_csv(ctx, t, path);
    if (dst != OBS_STATUS_OK) {
        fclose(md);
        free(mdtext);
        return dst;
    }
    fprintf(md, "- Points: %lld rows in [`results.csv`](results.csv) (a copy of `%s/results.csv`; columns: "
                "docs/study.md).", (long long)t->rows, o->out_dir);
    {
        /* what was measured at each resolution: a study may sweep some resolutions more fully */
        const int cw = col(t, "width"), chh = col(t, "height"), cn = col(t, "samples"), cq = col(t, "radius_units");
        for (int r = 0; r < o->resolutions.n; r++) {
            int w, h;
            cli_parse_size(o->resolutions.v[r], &w, &h);
            int64_t n = 0;
            char sam[256] = ",", rad[256] = ","; /* ",a,b," lists of the values seen */
            for (int64_t i = 0; i < t->rows; i++) {
                if (study_table_num(t, i, cw) != w || study_table_num(t, i, chh) != h)
                    continue;
                n++;
                list_add(sam, sizeof sam, study_table_get(t, i, cn));
                list_add(rad, sizeof rad, study_table_get(t, i, cq));
            }
            sam[strlen(sam) - 1] = rad[strlen(rad) - 1] = '\0';
            fprintf(md, " %s: %lld (samples %s; radii %s)%s", o->resolutions.v[r], (long long)n, n ? sam + 1 : "-",
                    n ? rad + 1 : "-", r + 1 < o->resolutions.n ? ";" : ".\n");
        }
    }
    fprintf(md, "- Scenes:");
    for (int i = 0; i < o->scenes.n; i++)
        fprintf(md, " %s (unit %.3g m)%s", o->scenes.v[i], scene_unit(o->scenes.v[i]), i + 1 < o->scenes.n ? "," : ".\n");
    fprintf(md, "- Time: the median of %d runs after one warm-up, on %d threads; `total` is the AO pass with its "
                "preparation, blur and the final blend (the G-buffer is timed separately).\n",
            o->runs, obs_pool_threads(pool));
    fprintf(md, "- Error: against each technique's matched ground truth (`obscura ao --list` names it; "
                "docs/truth.md), over surface pixels. *Calibrated* fits `1 - g (1 - v^p)` to the ground truth "
                "first (docs/compare.md), so it measures shape, not the technique's overall darkness. Every RMSE "
                "here has the ground truth's own noise taken out: sqrt(max(0, RMSE^2 - s^2)), s^2 the reference's mean "
                "noise variance over the surface pixels, estimated from a second ground truth with another seed "
                "(an independent randomisation): s^2 = mean((g0 - g1)^2) / 2 (`gt_noise_rms`; `rmse_nc`, "
                "`cal_rmse_nc`; the uncorrected values are in the CSV).\n");
    fprintf(md, "- Ground truth: target standard error %.3g per pixel, at most %lld samples per pixel at 1280x720 "
                "and below, scaled by the pixel count above (1920x1080: %lld, 3840x2160: %lld), so each resolution's "
                "ground truth costs about the same rays; the estimators that share a direction distribution are "
                "computed from one ray set (`truth_ao_render_multi`).\n\n",
            o->gt_target_error, o->gt_max_samples, gt_cap(o, 1920, 1080), gt_cap(o, 3840, 2160));

    /* ---- plots: calibrated RMSE against total time, all scenes together, and per scene ---- */
    for (int sc = -1; sc < o->scenes.n; sc++) {
        study_series ser[16];
        double *xs[16] = {0}, *ys[16] = {0};
        int ns = 0;
        for (int mi = 0; mi < o->methods.n && ns < 16; mi++) {
            xs[ns] = (double *)malloc(sizeof(double) * (size_t)(t->rows + 1));
            ys[ns] = (double *)malloc(sizeof(double) * (size_t)(t->rows + 1));
            if (!xs[ns] || !ys[ns])
                break;
            int n = 0;
            for (int64_t r = 0; r < t->rows; r++) {
                if (strcmp(study_table_get(t, r, col(t, "method")), o->methods.v[mi]) != 0 ||
                    strcmp(study_table_get(t, r, col(t, "status")), "ok") != 0 ||
                    study_table_num(t, r, col(t, "width")) != MW || study_table_num(t, r, col(t, "height")) != MH)
                    continue;
                if (sc >= 0 && strcmp(study_table_get(t, r, col(t, "scene")), o->scenes.v[sc]) != 0)
                    continue;
                xs[ns][n] = study_table_num(t, r, col(t, "total_ms"));
                ys[ns][n] = study_table_num(t, r, col(t, "cal_rmse_nc"));
                n++;
            }
            ser[ns] = (study_series){o->methods.v[mi], xs[ns], ys[ns], n};
            ns++;
        }
        char title[256], file[256];
        snprintf(title, sizeof title, "Calibrated RMSE vs time, %dx%d, %s", MW, MH, sc < 0 ? "all scenes" : o->scenes.v[sc]);
        snprintf(file, sizeof file, "pareto_%s.svg", sc < 0 ? "all" : o->scenes.v[sc]);
        snprintf(path, sizeof path, "%s/%s", o->report_dir, file);
        study_plot pl = {title, "time per frame: AO + blur + blend (ms, log scale)",
                         "RMSE against matched ground truth, calibrated (visibility)", 1, 0, 1, 0, 0};
        obs_status st = ns ? study_svg_scatter(ctx, path, &pl, ser, ns) : OBS_STATUS_OK;
        for (int k = 0; k < ns; k++) {
            free(xs[k]);
            free(ys[k]);
        }
        if (st != OBS_STATUS_OK) {
            fclose(md);
            free(mdtext);
            return st;
        }
        fprintf(md, "%s![%s](%s)\n\n", sc < 0 ? "## Error against time\n\nEach point is one (technique, samples, "
                                                "radius, blur) on one scene and view; the dashed line is the Pareto "
                                                "front (no other point is both faster and more accurate).\n\n" : "",
                title, file);
    }

    /* ---- the summary: best configuration per frame budget ---- */
    agg *ag = (agg *)calloc(4096, sizeof(agg));
    int na = ag ? aggregate(t, MW, MH, NULL, ag, 4096) : 0;
    /* the closing summary, written as the sections below find its facts, appended at the end */
    char *sumtext = NULL;
    size_t sumlen = 0;
    FILE *sum = open_memstream(&sumtext, &sumlen);
    if (!sum) {
        free(ag);
        fclose(md);
        free(mdtext);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", mdpath);
    }
    {
        int fastest = -1;
        for (int k = 0; k < na; k++)
            if (fastest < 0 || ag[k].time_sum / ag[k].n < ag[fastest].time_sum / ag[fastest].n)
                fastest = k;
        fprintf(sum, "- **Per frame budget at %dx%d** (time and error averaged over the scenes and views, %d threads):",
                MW, MH, obs_pool_threads(pool));
        for (int b = 0; b < o->budgets.n; b++) {
            double budget = atof(o->budgets.v[b]);
            const int best = best_within(ag, na, budget, NULL);
            if (best >= 0)
                fprintf(sum, " %g ms: %s (%d samples, radius %g, blur %s), %.2f ms, calibrated RMSE %.3f;", budget,
                        ag[best].method, ag[best].samples, ag[best].radius_units, ag[best].blur ? "on" : "off",
                        ag[best].time_sum / ag[best].n, ag[best].err_sum / ag[best].n);
            else
                fprintf(sum, " %g ms: nothing fits;", budget);
        }
        if (fastest >= 0)
            fprintf(sum, " the fastest configuration of all is %s with %d samples at %.2f ms (calibrated RMSE %.3f).\n",
                    ag[fastest].method, ag[fastest].samples, ag[fastest].time_sum / ag[fastest].n,
                    ag[fastest].err_sum / ag[fastest].n);
        /* per scene, for the budgets nothing fits on average: scenes differ in covered pixels */
        agg *as = (agg *)calloc(4096, sizeof(agg));
        for (int b = 0; as && b < o->budgets.n; b++) {
            const double budget = atof(o->budgets.v[b]);
            if (best_within(ag, na, budget, NULL) >= 0)
                continue;
            fprintf(sum, "- **%g ms, scene by scene** (mean over views):", budget);
            for (int sc = 0; sc < o->scenes.n; sc++) {
                const int ns = aggregate(t, MW, MH, o->scenes.v[sc], as, 4096);
                const int k = best_within(as, ns, budget, NULL);
                if (k >= 0)
                    fprintf(sum, " %s: %s (%d samples, radius %g, blur %s), %.2f ms, calibrated RMSE %.3f;",
                            o->scenes.v[sc], as[k].method, as[k].samples, as[k].radius_units, as[k].blur ? "on" : "off",
                            as[k].time_sum / as[k].n, as[k].err_sum / as[k].n);
                else
                    fprintf(sum, " %s: nothing fits;", o->scenes.v[sc]);
            }
            fprintf(sum, "\n");
        }
        free(as);
        /* which techniques are on the Pareto front of the averaged configurations */
        double *cx = (double *)malloc(sizeof(double) * (size_t)(na ? na : 1));
        double *cy = (double *)malloc(sizeof(double) * (size_t)(na ? na : 1));
        unsigned char *on = (unsigned char *)calloc((size_t)(na ? na : 1), 1);
        if (cx && cy && on && na) {
            for (int k = 0; k < na; k++) {
                cx[k] = ag[k].time_sum / ag[k].n;
                cy[k] = ag[k].err_sum / ag[k].n;
            }
            study_pareto_front(cx, cy, na, on);
            fprintf(sum, "- **On the Pareto front** (averaged configurations at %dx%d, by time):", MW, MH);
            int first = 1;
            for (int pass = 0; pass < na; pass++) { /* print in order of time */
                int k = -1;
                for (int j = 0; j < na; j++)
                    if (on[j] == 1 && (k < 0 || cx[j] < cx[k]))
                        k = j;
                if (k < 0)
                    break;
                on[k] = 2;
                fprintf(sum, "%s %s %d/%g/%s (%.1f ms, %.3f)", first ? "" : ",", ag[k].method, ag[k].samples,
                        ag[k].radius_units, ag[k].blur ? "blur" : "raw", cx[k], cy[k]);
                first = 0;
            }
            fprintf(sum, " (technique samples/radius/blur, ms, calibrated RMSE).\n");
        }
        free(cx);
        free(cy);
        free(on);
    }
    fprintf(md, "## Best technique per frame budget (%dx%d, mean over scenes and views)\n\n", MW, MH);
    fprintf(md, "| budget | technique | samples | radius (units) | blur | time (ms) | calibrated RMSE | raw RMSE |\n"
                "|---|---|---|---|---|---|---|---|\n");
    grid_row best_rows[16];
    int nbest = 0;
    for (int b = 0; b < o->budgets.n; b++) {
        double budget = atof(o->budgets.v[b]);
        const int best = best_within(ag, na, budget, NULL);
        if (best < 0) {
            fprintf(md, "| %g ms | none fits | | | | | | |\n", budget);
            continue;
        }
        const agg *a = &ag[best];
        fprintf(md, "| %g ms | %s | %d | %g | %s | %.2f | %.4f | %.4f |\n", budget, a->method, a->samples,
                a->radius_units, a->blur ? "yes" : "no", a->time_sum / a->n, a->err_sum / a->n, a->raw_sum / a->n);
    }
    /* the best point of each technique within the largest budget, for the grid */
    double big = 0.0;
    for (int b = 0; b < o->budgets.n; b++)
        big = atof(o->budgets.v[b]) > big ? atof(o->budgets.v[b]) : big;
    fprintf(md, "\n## Each technique at its best within %g ms\n\n| technique | samples | radius (units) | blur | time (ms) "
                "| calibrated RMSE | raw RMSE |\n|---|---|---|---|---|---|---|\n", big);
    for (int mi = 0; mi < o->methods.n && nbest < 16; mi++) {
        const int best = best_within(ag, na, big, o->methods.v[mi]);
        if (best < 0) {
            fprintf(md, "| %s | — | — | — | over budget | | |\n", o->methods.v[mi]);
            continue;
        }
        const agg *a = &ag[best];
        fprintf(md, "| %s | %d | %g | %s | %.2f | %.4f | %.4f |\n", a->method, a->samples, a->radius_units,
                a->blur ? "yes" : "no", a->time_sum / a->n, a->err_sum / a->n, a->raw_sum / a->n);
        best_rows[nbest++] = (grid_row){ao_method_find(a->method), a->samples, a->blur, a->radius_units};
    }

    /* ---- tables in the seed's layout: time (and error) for samples x radius per technique ---- */
    fprintf(md, "\n## Time and error for samples × radius (the seed's Tables 15, 18, 22, 23), %dx%d, no blur\n\n"
                "Each cell: median total ms / calibrated RMSE, mean over scenes and views.\n", MW, MH);
    for (int mi = 0; mi < o->methods.n; mi++) {
        fprintf(md, "\n**%s**\n\n| samples \\ radius |", o->methods.v[mi]);
        for (int q = 0; q < o->radii.n; q++)
            fprintf(md, " %s |", o->radii.v[q]);
        fprintf(md, "\n|---|");
        for (int q = 0; q < o->radii.n; q++)
            fprintf(md, "---|");
        fprintf(md, "\n");
        for (int n = 0; n < o->samples.n; n++) {
            fprintf(md, "| %s |", o->samples.v[n]);
            for (int q = 0; q < o->radii.n; q++) {
                int k = 0;
                while (k < na && !(!strcmp(ag[k].method, o->methods.v[mi]) && ag[k].samples == atoi(o->samples.v[n]) &&
                                   ag[k].radius_units == atof(o->radii.v[q]) && ag[k].blur == 0))
                    k++;
                if (k < na)
                    fprintf(md, " %.2f / %.4f |", ag[k].time_sum / ag[k].n, ag[k].err_sum / ag[k].n);
                else
                    fprintf(md, " — |");
            }
            fprintf(md, "\n");
        }
    }
    /* ---- time at each resolution (the seed's Table 26) ---- */
    fprintf(md, "\n## Time at each resolution (the seed's Table 26)\n\nMedian total ms / calibrated RMSE at samples %s, "
                "radius %s, no blur, mean over scenes and views.\n\n| technique |", o->samples.v[o->samples.n > 1 ? 1 : 0],
            o->radii.v[o->radii.n > 1 ? 1 : 0]);
    for (int r = 0; r < o->resolutions.n; r++)
        fprintf(md, " %s |", o->resolutions.v[r]);
    fprintf(md, "\n|---|");
    for (int r = 0; r < o->resolutions.n; r++)
        fprintf(md, "---|");
    fprintf(md, "\n");
    for (int mi = 0; mi < o->methods.n; mi++) {
        fprintf(md, "| %s |", o->methods.v[mi]);
        for (int r = 0; r < o->resolutions.n; r++) {
            int w, h;
            cli_parse_size(o->resolutions.v[r], &w, &h);
            agg *ar = (agg *)calloc(4096, sizeof(agg));
            int nr = ar ? aggregate(t, w, h, NULL, ar, 4096) : 0;
            int k = 0;
            while (k < nr && !(!strcmp(ar[k].method, o->methods.v[mi]) &&
                               ar[k].samples == atoi(o->samples.v[o->samples.n > 1 ? 1 : 0]) &&
                               ar[k].radius_units == atof(o->radii.v[o->radii.n > 1 ? 1 : 0]) && ar[k].blur == 0))
                k++;
            if (k < nr)
                fprintf(md, " %.2f / %.4f |", ar[k].time_sum / ar[k].n, ar[k].err_sum / ar[k].n);
            else
                fprintf(md, " — |");
            free(ar);
        }
        fprintf(md, "\n");
    }
    /* ---- where each technique fails: its worst scene and view ---- */
    fprintf(md, "\n## Where each technique is worst\n\nThe scene and view with the largest calibrated RMSE at %dx%d "
                "(over all its points there), and its raw bias there (negative: darker than the ground truth).\n\n"
                "| technique | worst scene / view | calibrated RMSE | raw bias |\n|---|---|---|---|\n", MW, MH);
    int nhard = 0;
    for (int mi = 0; mi < o->methods.n; mi++) {
        double worst = -1.0, wb = NAN;
        const char *wsn = "—", *wvn = "";
        for (int64_t r = 0; r < t->rows; r++) {
            if (strcmp(study_table_get(t, r, col(t, "method")), o->methods.v[mi]) != 0 ||
                strcmp(study_table_get(t, r, col(t, "status")), "ok") != 0 ||
                study_table_num(t, r, col(t, "width")) != MW)
                continue;
            double e = study_table_num(t, r, col(t, "cal_rmse_nc"));
            if (e > worst) {
                worst = e;
                wb = study_table_num(t, r, col(t, "bias"));
                wsn = study_table_get(t, r, col(t, "scene"));
                wvn = study_table_get(t, r, col(t, "view"));
            }
        }
        fprintf(md, "| %s | %s / %s | %.4f | %.4f |\n", o->methods.v[mi], wsn, wvn, worst, wb);
        if (worst >= 0.0)
            fprintf(sum, "%s %s on %s/%s (calibrated RMSE %.3f, %s by %.3f)", nhard++ ? ";" : "- **Hard cases** (each "
                    "technique's worst scene and view at the main resolution, over all its points):", o->methods.v[mi],
                    wsn, wvn, worst, wb < 0.0 ? "too dark" : "too light", fabs(wb));
    }
    if (nhard)
        fprintf(sum, ".\n");
    free(ag);
    /* ---- image grids ---- */
    obs_status st = OBS_STATUS_OK;
    if (nbest > 0) {
        fprintf(md, "\n## Image grids\n\nEach row: the technique at its best point within %g ms (table above), the "
                    "matched ground truth, and |AO − ground truth| as a heat map from 0 (black) to 0.5 (yellow), "
                    "inferno colour map.\n\n", big);
        for (int sc = 0; sc < o->scenes.n && st == OBS_STATUS_OK; sc++) {
            char file[256];
            snprintf(file, sizeof file, "grid_%s.png", o->scenes.v[sc]);
            snprintf(path, sizeof path, "%s/%s", o->report_dir, file);
            /* grids at a reduced size (480 wide) so the page stays light */
            int GW = MW > 480 ? 480 : MW, GH = (int)lround((double)MH * GW / MW);
            st = write_grid(ctx, pool, o, o->scenes.v[sc], o->views.v[0], GW, GH, best_rows, nbest, path);
            fprintf(md, "**%s** (%s view, %dx%d; rows:", o->scenes.v[sc], o->views.v[0], GW, GH);
            for (int i = 0; i < nbest; i++)
                fprintf(md, " %s%s", best_rows[i].m->name, i + 1 < nbest ? "," : ")");
            fprintf(md, "\n\n![grid %s](%s)\n\n", o->scenes.v[sc], file);
        }
    }
    int has_mssao = 0;
    for (int mi = 0; mi < o->methods.n; mi++)
        has_mssao |= !strcmp(o->methods.v[mi], "mssao");
    if (st == OBS_STATUS_OK && has_mssao)
        st = mssao_levels_table(ctx, pool, o, MW, MH, md);
    if (fclose(sum) == 0 && sumtext)
        fprintf(md, "\n## Summary\n\nGenerated from the table above, on this machine.\n\n%s", sumtext);
    free(sumtext);
    if (fclose(md) != 0 && st == OBS_STATUS_OK)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", mdpath);
    if (st == OBS_STATUS_OK)
        st = io_write_file_atomic(ctx, mdpath, mdtext, mdlen);
    free(mdtext);
    return st;
}

/* ================================================================================================
 * The command
 * ============================================================================================== */

int cmd_study(cli_globals *g, int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "ao") != 0) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            fputs(study_help, stdout);
            return CLI_EXIT_OK;
        }
        fputs(study_help, stderr);
        return argc < 2 ? CLI_EXIT_USAGE : cli_usage_error("study: unknown study '%s' (only 'ao' exists)", argv[1]);
    }
    study_opts o;
    memset(&o, 0, sizeof o);
    o.runs = 5;
    o.out_dir = "out/study-ao";
    o.data_dir = OBS_STUDY_DATA_DIR;
    o.gt_target_error = 0.01;
    o.gt_max_samples = 256;
    const char *scenes = "dragon_plane,village,room,bunny", *views = "default,view2", *methods = NULL,
               *res = "3840x2160,1920x1080,1280x720", *samples = "4,8,16,32", *radii = "0.5,1,1.5,2", *blurs = "0,1",
               *budgets = "1,2,4,8";
    int given_runs = 0, given_gt = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double d;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--quick")) {
            o.quick = 1;
        } else if (!strcmp(a, "--dry-run")) {
            o.dry_run = 1;
        } else if (!strcmp(a, "--truth-only")) {
            o.truth_only = 1;
        } else if (!strcmp(a, "--report-only")) {
            o.report_only = 1;
        } else if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && v) {
            o.out_dir = v, i++;
        } else if (!strcmp(a, "--report") && v) {
            o.report_dir = v, i++;
        } else if (!strcmp(a, "--data") && v) {
            o.data_dir = v, i++;
        } else if (!strcmp(a, "--scenes") && v) {
            scenes = v, i++;
        } else if (!strcmp(a, "--views") && v) {
            views = v, i++;
        } else if (!strcmp(a, "--methods") && v) {
            methods = v, i++;
        } else if (!strcmp(a, "--resolutions") && v) {
            res = v, i++;
        } else if (!strcmp(a, "--samples") && v) {
            samples = v, i++;
        } else if (!strcmp(a, "--radii") && v) {
            radii = v, i++;
        } else if (!strcmp(a, "--blur") && v) {
            blurs = v, i++;
        } else if (!strcmp(a, "--budgets") && v) {
            budgets = v, i++;
        } else if (!strcmp(a, "--runs")) {
            if (!cli_parse_int(v, 1, 64, &ll))
                return cli_usage_error("--runs needs an integer in [1, 64]");
            o.runs = (int)ll, i++, given_runs = 1;
        } else if (!strcmp(a, "--gt-target-error")) {
            if (!cli_parse_float(v, &d) || !(d >= 0.0) || !isfinite(d))
                return cli_usage_error("--gt-target-error needs a number >= 0");
            o.gt_target_error = d, i++, given_gt = 1;
        } else if (!strcmp(a, "--gt-max-samples")) {
            if (!cli_parse_int(v, 32, 1 << 20, &ll) || ll % 16 != 0)
                return cli_usage_error("--gt-max-samples needs a multiple of 16 in [32, 1048576]");
            o.gt_max_samples = ll, i++, given_gt = 1;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r > 0)
                continue;
            return cli_usage_error("study ao: unknown option '%s' (or a missing value)", a);
        }
    }
    if (o.report_only && !o.report_dir)
        return cli_usage_error("study ao: --report-only needs --report DIR");
    if (o.report_only + o.truth_only + o.dry_run > 1)
        return cli_usage_error("study ao: --report-only, --truth-only and --dry-run exclude each other");
    if (o.quick) {
        /* CI: one scene and view at a small size, the default sample count and radius, both blur
         * settings, 3 runs, a coarse ground truth. Explicit flags still win. */
        if (!strcmp(scenes, "dragon_plane,village,room,bunny"))
            scenes = "bunny";
        if (!strcmp(views, "default,view2"))
            views = "default";
        if (!strcmp(res, "3840x2160,1920x1080,1280x720"))
            res = "192x108";
        if (!strcmp(samples, "4,8,16,32"))
            samples = "8";
        if (!strcmp(radii, "0.5,1,1.5,2"))
            radii = "1";
        if (!given_runs)
            o.runs = 3;
        if (!given_gt) {
            o.gt_target_error = 0.02;
            o.gt_max_samples = 128;
        }
    }
    /* every registered method by default */
    char all_methods[1024] = "";
    if (!methods) {
        size_t off = 0;
        for (const ao_method *const *m = ao_methods(); *m; m++)
            off += (size_t)snprintf(all_methods + off, sizeof all_methods - off, "%s%s", off ? "," : "", (*m)->name);
        methods = all_methods;
    }
    int code = CLI_EXIT_OK;
    if (!split(scenes, &o.scenes) || !split(views, &o.views) || !split(methods, &o.methods) ||
        !split(res, &o.resolutions) || !split(samples, &o.samples) || !split(radii, &o.radii) ||
        !split(blurs, &o.blurs) || !split(budgets, &o.budgets)) {
        code = cli_usage_error("study ao: an empty or too long list (at most %d items)", MAX_LIST);
        goto free_lists;
    }
    for (int i = 0; i < o.methods.n; i++)
        if (!ao_method_find(o.methods.v[i])) {
            code = cli_usage_error("study ao: unknown method '%s' (see 'obscura ao --list')", o.methods.v[i]);
            goto free_lists;
        }
    for (int i = 0; i < o.resolutions.n; i++) {
        int w, h;
        if (!cli_parse_size(o.resolutions.v[i], &w, &h)) {
            code = cli_usage_error("study ao: bad resolution '%s' (WxH)", o.resolutions.v[i]);
            goto free_lists;
        }
    }
    for (int i = 0; i < o.samples.n; i++) {
        long long ll;
        if (!cli_parse_int(o.samples.v[i], 1, 1024, &ll)) {
            code = cli_usage_error("study ao: bad sample count '%s' (1..1024)", o.samples.v[i]);
            goto free_lists;
        }
    }
    for (int i = 0; i < o.radii.n; i++) {
        double d;
        if (!cli_parse_float(o.radii.v[i], &d) || !(d > 0.0) || !isfinite(d)) {
            code = cli_usage_error("study ao: bad radius '%s' (> 0, in scene units)", o.radii.v[i]);
            goto free_lists;
        }
    }
    for (int i = 0; i < o.blurs.n; i++)
        if (strcmp(o.blurs.v[i], "0") != 0 && strcmp(o.blurs.v[i], "1") != 0) {
            code = cli_usage_error("study ao: --blur takes 0 and/or 1");
            goto free_lists;
        }
    for (int i = 0; i < o.budgets.n; i++) {
        double d;
        if (!cli_parse_float(o.budgets.v[i], &d) || !(d > 0.0) || !isfinite(d)) {
            code = cli_usage_error("study ao: bad budget '%s' (ms > 0)", o.budgets.v[i]);
            goto free_lists;
        }
    }

    {
        obs_context *ctx = obs_context_create();
        if (!ctx) {
            code = CLI_EXIT_INTERNAL;
            goto free_lists;
        }
        obs_context_set_limits(ctx, &g->limits);
        obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
        obs_pool *pool = obs_pool_create(g->threads);
        sweep_ctx s;
        memset(&s, 0, sizeof s);
        s.g = g;
        s.o = &o;
        snprintf(s.csv, sizeof s.csv, "%s/results.csv", o.out_dir);
        snprintf(s.json, sizeof s.json, "%s/results.json", o.out_dir);
        obs_status st = pool ? study_table_init(ctx, &s.table, columns, NCOL, KEY_COLUMNS) : OBS_STATUS_OUT_OF_MEMORY;
        int64_t resumed = 0;
        if (st == OBS_STATUS_OK)
            st = study_table_read_csv(ctx, &s.table, s.csv, &resumed);
        if (st == OBS_STATUS_OK && resumed && !g->quiet)
            fprintf(stderr, "obscura: study ao: resuming: %lld points already measured in %s\n", (long long)resumed,
                    s.csv);
        if (st == OBS_STATUS_OK && !o.report_only)
            st = sweep(ctx, pool, &s);
        if (!o.dry_run && !o.report_only && (st == OBS_STATUS_OK || s.dirty)) { /* what was measured is kept, even on an error */
            obs_status ss = save_table(ctx, &s);
            st = st == OBS_STATUS_OK ? ss : st;
        }
        if (st == OBS_STATUS_OK && o.report_dir && !o.dry_run && !o.truth_only)
            st = report(ctx, pool, &s);
        if (st != OBS_STATUS_OK)
            code = cli_fail(ctx, st);
        else if (!g->quiet && !o.dry_run)
            fprintf(stderr, "obscura: study ao: %lld points in %s%s%s\n", (long long)s.table.rows, s.csv,
                    o.report_dir ? ", report in " : "", o.report_dir ? o.report_dir : "");
        study_table_free(&s.table);
        obs_pool_destroy(pool);
        obs_context_destroy(ctx);
    }
free_lists:
    split(NULL, &o.scenes);
    split(NULL, &o.views);
    split(NULL, &o.methods);
    split(NULL, &o.resolutions);
    split(NULL, &o.samples);
    split(NULL, &o.radii);
    split(NULL, &o.blurs);
    split(NULL, &o.budgets);
    return code;
}
