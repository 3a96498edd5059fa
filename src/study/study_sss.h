/* study_sss.h: the subsurface-scattering study (prefix study_sss_): what the scattering maps of
 * Dal Corso et al. [DalCorso17] cost in time and how far they are from two references (issue 14,
 * part 7). The same shape as the AO study (docs/study.md, "The shape of a study"):
 *
 *   1. axes: scene (a translucent model with its material), light (front/behind), resolution, the
 *      maps' sampler (the technique), K (scattering-map directions), N (samples per texel), map size;
 *   2. the run function: light G-buffers, scattering maps, camera G-buffer, combination, each
 *      timed (median, min, max of `runs` runs); the times a frame costs when the scene changes
 *      (maps rebuilt) and when it does not (maps reused: camera G-buffer + combination);
 *   3. the error function: the luminance on the translucent pixels against each reference: RMSE,
 *      relative RMSE (over the reference's mean luminance), both with the reference's own noise
 *      taken out (study_noise_corrected), the ratio of means (bias), and the study_score after
 *      fitting one gain (the albedo scale an artist would set) with its skill [Murphy88];
 *   4. the references (truth.h, truth_sss_render): the brute-force BSSRDF integral (the METHOD's
 *      error: same BSSRDF, same constants) and the volumetric random walk (the MODEL's error),
 *      at a fixed candidate count with replicates (study_sss_truth_params), cached under OUT/ref/
 *      by content (a hash of the scene file, material, light, camera, size and reference
 *      parameters). A reference that cannot be computed (the random walk refuses an open mesh) is
 *      recorded as missing with its reason in the row's `rw_status`/`bf_status`, never hidden;
 *   5. the report (study_sss_report): error-versus-time plots with the Pareto front, the seed's
 *      table layouts with the GPU timings of the thesis beside ours, labelled image grids.
 *
 * Typical use:
 *     study_sss_options o = study_sss_options_quick();
 *     o.out_dir = "out/s"; o.report_dir = "out/s/report";
 *     study_sss *s;
 *     if (study_sss_open(ctx, &o, &s) == OBS_STATUS_OK) {
 *         st = study_sss_sweep(ctx, pool, s);
 *         if (st == OBS_STATUS_OK) st = study_sss_report(ctx, pool, s);
 *         study_sss_close(s);
 *     }
 * Threads: an optional obs_pool (NULL = the caller's thread); times depend on it, errors do not. */
#ifndef STUDY_SSS_H
#define STUDY_SSS_H

#include "study.h"
#include "../truth/truth.h"
#include "../sss/sss.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Defaults: issue 14 part 7 (the scenes are build/data's, src/tools/mkdata.c). */
#define STUDY_SSS_DEFAULT_SCENES "bunny_cream,dragon_skin,armadillo_marble,sphere_potato"
#define STUDY_SSS_DEFAULT_LIGHTS "front,behind"
#define STUDY_SSS_DEFAULT_RESOLUTIONS "320x240"   /* ours: the references' cost grows with pixels */
#define STUDY_SSS_DEFAULT_SAMPLERS "russian-roulette"   /* the thesis' final shader (sss.md 3.4) */
#define STUDY_SSS_DEFAULT_KS "4,8,16,32"
#define STUDY_SSS_DEFAULT_NS "16,48,128"
#define STUDY_SSS_DEFAULT_MAP_SIZES "256,512,1024"
#define STUDY_SSS_DEFAULT_RUNS 3
#define STUDY_SSS_DEFAULT_REF_SAMPLES 16384       /* candidates per pixel (truth_sss_params' min_samples default) */
/* --quick (CI, seconds): the sphere at 64x48, K 4, N 16, maps 64, a few thousand candidates */
#define STUDY_SSS_QUICK_SCENES "sphere_potato"
#define STUDY_SSS_QUICK_LIGHTS "front"
#define STUDY_SSS_QUICK_RESOLUTIONS "64x48"
#define STUDY_SSS_QUICK_KS "4"
#define STUDY_SSS_QUICK_NS "16"
#define STUDY_SSS_QUICK_MAP_SIZES "64"
#define STUDY_SSS_QUICK_RUNS 1
#define STUDY_SSS_QUICK_REF_SAMPLES 1024

typedef struct study_sss_options {
    const char *out_dir;            /* results.csv, results.json, the reference cache ref/ */
    const char *report_dir;         /* NULL: no report */
    const char *data_dir;           /* <scene>.glb */
    const char *scenes;             /* glb names whose materials carry "obscura_sss" */
    const char *lights;             /* "front" (the scene's first directional light) and/or "behind" (its opposite) */
    const char *resolutions;        /* "WxH" */
    const char *samplers;           /* the maps' disk samplers (sss_sampler_from_name): the technique axis */
    const char *Ks;                 /* 1..256 */
    const char *Ns;                 /* 1..65536 */
    const char *map_sizes;          /* 16..4096 (the light G-buffer is SSS_DEFAULT_LIGHT_MAP_SIZE) */
    int runs;                       /* timed runs per point, [1, 64] */
    long long ref_samples;          /* candidates per pixel of both references, a multiple of 64 in [64, 2^20] */
    int seed_points;                /* 1: add the seed's Table 5.3 points (K 4, 8, 16 with N 12, 24, 48 at 512
                                       maps) to every frame; default 1, quick 0 */
    int quick;                      /* the options came from _quick (the report says so) */
    FILE *log;                      /* progress; NULL = silent */
} study_sss_options;

study_sss_options study_sss_options_default(void);
study_sss_options study_sss_options_quick(void);

/* The references' settings: the ONE place that decides how they are sampled. A fixed count
 * (min = max = o->ref_samples: no adaptive stop), batch 64, 8 replicates (the error bars), the
 * directional dipole (the maps' model), seed 0; the random walk's patch radius is set per scene
 * (half the smallest reduced mean free path, as `obscura truth sss`). The cache key hashes these. */
truth_sss_params study_sss_truth_params(const study_sss_options *o, truth_sss_estimator e);

/* The maps' settings of a point: sss_params_default() with the sampler, K, N and map size set
 * explicitly (so that a change of the library's defaults does not change the study silently),
 * the directional dipole, the 5-tap visibility, 512 light G-buffers, one frame, seed 0. */
sss_params study_sss_map_params(sss_sampler sampler, int K, int N, int map_size);

typedef struct study_sss study_sss;

/* Validate o, split its axes, read OUT/results.csv. INVALID_ARGUMENT names a bad option;
 * PARSE_ERROR (not this study's table), IO_ERROR, OUT_OF_MEMORY. */
obs_status study_sss_open(obs_context *ctx, const study_sss_options *o, study_sss **out);
void study_sss_close(study_sss *s);
const study_table *study_sss_table(const study_sss *s);

typedef struct study_sss_plan {
    int64_t points;
    int scenes, lights, resolutions, Ks, Ns, map_sizes, runs;
    double sweep_min;               /* from the cost model (docs/study.md, "SSS: cost"), minutes */
    double ref_min;                 /* references, first run */
} study_sss_plan;
study_sss_plan study_sss_plan_of(const study_sss *s);

/* Compute and cache every reference the grid needs; measure nothing. */
obs_status study_sss_truth(obs_context *ctx, obs_pool *pool, study_sss *s);
/* The references, then every point not yet in the table; the table is rewritten every 5 s, after
 * each frame and at the end (even after an error). A point the library refuses is recorded as
 * "failed: <message>". */
obs_status study_sss_sweep(obs_context *ctx, obs_pool *pool, study_sss *s);
/* REPORT/README.md, SVG plots, PNG grids (their points are run again at the grid size), a copy of
 * results.csv. INVALID_ARGUMENT without report_dir. */
obs_status study_sss_report(obs_context *ctx, obs_pool *pool, study_sss *s);

/* The columns (docs/study.md, "SSS: what a point records"). */
extern const char *const study_sss_columns[];
extern const int study_sss_column_count;
#define STUDY_SSS_KEY_COLUMNS 8     /* scene, light, width, height, sampler, K, N, map_size */

#ifdef __cplusplus
}
#endif

#endif
