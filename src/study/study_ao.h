/* study_ao.h: the AO study (prefix study_ao_): what screen-space AO accuracy costs in time (issue 5).
 *
 * A sweep over scenes, views, resolutions, techniques, samples, radii and blur; for each point the
 * time per pass (median, min and max of several runs) and the error against the technique's
 * matched ground truth (raw and calibrated RMSE with the truth's noise taken out, the flat baseline,
 * the calibrated skill, whether the fit is at its bound: study_score); then plots, image grids,
 * tables and a Markdown report. It is the first study built on study.h and follows the shape
 * docs/study.md describes ("The shape of a study"): axes (study_ao_options), a run function (one
 * point: time and output), an error function (study_score against the matched ground truth and
 * its noise), the ground truth with its cache and noise (study_ao_truth_params), and the
 * report. `obscura study ao` only parses flags into study_ao_options and calls these.
 *
 * Typical use:
 *     study_ao_options o = study_ao_options_quick();
 *     o.out_dir = "out/study"; o.report_dir = "out/study/report";
 *     study_ao *s;
 *     if (study_ao_open(ctx, &o, &s) == OBS_STATUS_OK) {
 *         st = study_ao_sweep(ctx, pool, s);                  // measures what results.csv lacks
 *         if (st == OBS_STATUS_OK) st = study_ao_report(ctx, pool, s);
 *         study_ao_close(s);
 *     }
 *
 * Outputs: OUT/results.csv and OUT/results.json (one row per point; columns in docs/study.md), the
 * ground truth cache OUT/gt/, and with a report directory REPORT/README.md, SVG plots, PNG grids
 * and a copy of results.csv. Threads: functions take an optional obs_pool (NULL = the caller's
 * thread); times and the `threads` column depend on it, the errors do not. */
#ifndef STUDY_AO_H
#define STUDY_AO_H

#include "study.h"
#include "../truth/truth.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Defaults (docs/study.md, "What a point is"): the full study of issue 5. */
#define STUDY_AO_DEFAULT_SCENES "dragon_plane,village,room,bunny"
#define STUDY_AO_DEFAULT_VIEWS "default,view2"
#define STUDY_AO_DEFAULT_RESOLUTIONS "3840x2160,1920x1080,1280x720"
#define STUDY_AO_DEFAULT_SAMPLES "4,8,16,32"
#define STUDY_AO_DEFAULT_RADII "0.5,1,1.5,2"      /* scene units (study_ao_scene_unit) */
#define STUDY_AO_DEFAULT_BLURS "0,1"
#define STUDY_AO_DEFAULT_BUDGETS "1,2,4,8"        /* ms */
#define STUDY_AO_DEFAULT_RUNS 5                   /* timed runs per point after one warm-up */
#define STUDY_AO_DEFAULT_GT_MAX_SAMPLES 256       /* per pixel at 1280x720 or less (study_ao_truth_params) */
/* --quick (CI, a few seconds per technique): the bunny, its default view, 192x108, 8 samples,
 * radius 1 unit, both blur settings, 3 runs, a coarser ground truth */
#define STUDY_AO_QUICK_SCENES "bunny"
#define STUDY_AO_QUICK_VIEWS "default"
#define STUDY_AO_QUICK_RESOLUTIONS "192x108"
#define STUDY_AO_QUICK_SAMPLES "8"
#define STUDY_AO_QUICK_RADII "1"
#define STUDY_AO_QUICK_RUNS 3
#define STUDY_AO_QUICK_GT_MAX_SAMPLES 128

/* The study's axes and settings. Start from study_ao_options_default() (or _quick()) and change
 * what you need. The strings are borrowed: they must outlive the study_ao opened with them. */
typedef struct study_ao_options {
    const char *out_dir;            /* results.csv, results.json, the ground truth cache gt/ */
    const char *report_dir;         /* where study_ao_report writes; NULL: no report */
    const char *data_dir;           /* the scenes, <name>.glb (default: the build's data directory) */
    /* the axes, comma-separated (study_axis) */
    const char *scenes;             /* names from the study set (study_ao_scene_unit) */
    const char *views;              /* camera names */
    const char *methods;            /* techniques (ao_method_find); NULL: every registered one */
    const char *resolutions;        /* "WxH" */
    const char *samples;            /* per pixel, 1..1024 (the technique's set_samples) */
    const char *radii;              /* in scene units, > 0 */
    const char *blurs;              /* "0" and/or "1" */
    const char *budgets;            /* frame budgets in ms for the report, > 0 */
    int runs;                       /* timed runs per point, [1, 64] */
    long long gt_max_samples;       /* multiple of 16 in [32, 2^20]; see study_ao_truth_params */
    int quick;                      /* 1: the options came from study_ao_options_quick (the report says so) */
    FILE *log;                      /* the progress bar and one line per ground truth computed; NULL: silent */
    /* scale-out (docs/scale.md) */
    int shard, shards;              /* run shard K of N of the points (study_shard_has); default 1 of 1 */
    const char *gt_dir;             /* the ground-truth cache, shared by shards; NULL: OUT/gt */
} study_ao_options;

study_ao_options study_ao_options_default(void);
study_ao_options study_ao_options_quick(void);

/* The ground truth's sampling settings for a W x H frame and a seed: the ONE place that decides
 * how the study's ground truths are sampled (the estimator and radius are then set per output).
 *   a FIXED count per pixel (min_samples = max_samples; no adaptive stopping, so the estimate is
 *     exactly unbiased, rare occlusion included: docs/truth.md, "Limits"): o->gt_max_samples at
 *     1280x720 or less; above, scaled by 921600 / (W H) (a multiple of 16, at least 32, never above
 *     o->gt_max_samples), so that every resolution's ground truth costs about the same rays
 *     (1920x1080: 112, 3840x2160: 32 from 256); batch 16, 8 replicates;
 *   error_bar = TRUTH_AO_BAR_REPLICATES: the SE plane is the replicates' standard error s_R, whose
 *     square is an unbiased estimate of each pixel's variance: the study's noise estimate;
 *   seed 0 (the caller's choice).
 * The cache file name records the count and the replicates (docs/study.md); a retune of the other
 * fields must change the name too, or clear OUT/gt/. */
truth_ao_params study_ao_truth_params(const study_ao_options *o, int width, int height, unsigned seed);

/* A scene's unit in metres, the unit of the radius axis (docs/study.md); 1 for a scene outside the
 * study set. */
double study_ao_scene_unit(const char *scene);

/* An open study: its options (validated, the axes split) and its results table. */
typedef struct study_ao study_ao;

/* Validate o, split its axes and read OUT/results.csv if there is one (a table written before
 * columns were appended is read with them empty; such rows are completed by the next sweep or
 * truth step over their frames, without timing them again). Logs "resuming: N points" to o->log.
 * Returns OK (*out set; study_ao_close it); INVALID_ARGUMENT (a bad option: an empty or too long
 * list, an unknown technique, a malformed resolution, sample count, radius, blur or budget, runs or
 * ground truth settings out of range -- the message names it); PARSE_ERROR (results.csv is not
 * this study's table); IO_ERROR; OUT_OF_MEMORY. */
obs_status study_ao_open(obs_context *ctx, const study_ao_options *o, study_ao **out);
void study_ao_close(study_ao *s);                      /* NULL-safe */

/* The results table (rows as measured so far; read-only). */
const study_table *study_ao_table(const study_ao *s);

/* The dry run: how many points and about how long, from the full study's rates on the 2-core
 * development machine (docs/study.md, "Cost"); coarse, stated as ranges. Measures nothing. */
typedef struct study_ao_plan {
    int64_t points;                 /* scenes x views x resolutions x methods x samples x radii x blurs */
    int scenes, views, resolutions, methods, samples, radii, blurs, runs;
    double sweep_min_lo, sweep_min_hi;      /* minutes */
    double truth_min_lo, truth_min_hi;      /* minutes, first run (cached after) */
} study_ao_plan;

study_ao_plan study_ao_plan_of(const study_ao *s);

/* Compute and cache every ground truth the grid's pending points need, and
 * complete rows measured before a column existed; measure nothing. Writes the table when it
 * changed. Returns OK, or the first error of loading a scene (NOT_FOUND, IO_ERROR, PARSE_ERROR...),
 * of the truth module, or of writing (IO_ERROR); OUT_OF_MEMORY; LIMIT_EXCEEDED. */
obs_status study_ao_truth(obs_context *ctx, obs_pool *pool, study_ao *s);

/* The sweep: study_ao_truth's work, then every point not in the table yet is run (one warm-up,
 * then o->runs timed runs) and scored; rows are appended and the table rewritten atomically at
 * most every 5 s and after each frame, and always at the end, even after an error (what was
 * measured is kept). A point the technique refuses is recorded with status "failed: <message>".
 * Returns as study_ao_truth; an out-of-memory or I/O error stops the sweep, a refused point
 * does not. */
obs_status study_ao_sweep(obs_context *ctx, obs_pool *pool, study_ao *s);

/* Write the report to o->report_dir (README.md, plots, grids, a copy of results.csv) from the
 * table as it is; the grids and the MSSAO per-level table run their few points again (and load or
 * compute their ground truths). Returns OK, INVALID_ARGUMENT (no report_dir), IO_ERROR,
 * OUT_OF_MEMORY, or a scene's or the truth module's error. */
obs_status study_ao_report(obs_context *ctx, obs_pool *pool, study_ao *s);

/* Merge the output directories of shards of one study (each with manifest.json and results.csv)
 * into out_dir: the rows in the order a single run writes them (so that the merged table equals a
 * single run's, timings aside), then results.csv, results.json and a manifest of shard 1 of 1; with
 * report_dir, the report from the merged table (study_ao_report). Refuses (INVALID_ARGUMENT, naming
 * the directory) manifests of another study, another configuration (config_hash), another version
 * or another shard count, the same shard twice, and an out_dir that already holds a table. Points
 * no shard has measured are left out and counted in the log. Returns OK, INVALID_ARGUMENT,
 * IO_ERROR, PARSE_ERROR, OUT_OF_MEMORY, or the report's errors. */
obs_status study_ao_merge(obs_context *ctx, obs_pool *pool, const char *const *dirs, int count, const char *out_dir,
                          const char *report_dir, const char *data_dir, FILE *log);

#ifdef __cplusplus
}
#endif

#endif
