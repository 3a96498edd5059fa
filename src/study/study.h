/* study.h: the generic parts of an accuracy-versus-time study (prefix study_): a sweep over
 * parameter axes with resume, a results table written as CSV and JSON, timing statistics, the
 * score a point records against a noisy ground truth (raw and calibrated RMSE with the truth's
 * noise taken out, the flat baseline, the skill, whether the fit is at its bound), Pareto fronts, a
 * progress bar and SVG scatter plots. A study (`obscura study ao`: study_ao.h; later sss and
 * volume) is a list of axes, a run function that measures one point, an error function that
 * scores it against a ground truth with a replicate, and a report; docs/study.md, "The shape of
 * a study", says what each provides. */
#ifndef STUDY_H
#define STUDY_H

#include "../core/obs.h"
#include "../metrics/metrics.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- The results table ------------------------------------------------------------------------
 * Rows of named columns, every value kept as text (numbers formatted with %.9g, so a CSV read back
 * gives the same doubles). The first key_columns columns identify a point: a row whose key is
 * already present is a point already measured (resume). */

#define STUDY_MAX_COLUMNS 64
#define STUDY_MAX_ROWS 1000000      /* a table refuses rows beyond this (LIMIT_EXCEEDED) */

typedef struct study_table {
    int columns;
    int key_columns;
    char *names[STUDY_MAX_COLUMNS];
    int64_t rows, capacity;
    char **cells;                   /* rows * columns strings, row-major (owned) */
} study_table;

/* Create an empty table with the given column names (copied); the first key_columns are the key.
 * Returns OK, INVALID_ARGUMENT (no columns, too many, duplicate or empty names, names with
 * commas, quotes or newlines, key_columns outside [1, columns]) or OUT_OF_MEMORY. */
obs_status study_table_init(obs_context *ctx, study_table *t, const char *const *names, int columns, int key_columns);
void study_table_free(study_table *t);                 /* NULL-safe */

/* The column index of name, or -1. */
int study_table_column(const study_table *t, const char *name);

/* The row whose key cells equal key[0..key_columns-1], or -1. */
int64_t study_table_find(const study_table *t, const char *const *key);

/* Append a row of `columns` values (copied; NULL = empty). Returns OK, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status study_table_append(obs_context *ctx, study_table *t, const char *const *values);

/* Replace a cell (value copied; NULL = empty). Returns OK, INVALID_ARGUMENT (out of range), OUT_OF_MEMORY. */
obs_status study_table_set(obs_context *ctx, study_table *t, int64_t row, int column, const char *value);

/* A cell (never NULL: "" for empty), and the cell as a double (NaN for empty or non-numeric). */
const char *study_table_get(const study_table *t, int64_t row, int column);
double study_table_num(const study_table *t, int64_t row, int column);

/* Write the table as CSV (RFC 4180: a header line, then one line per row; cells with commas,
 * quotes or newlines are quoted) atomically to path. Returns OK or IO_ERROR. */
obs_status study_table_write_csv(obs_context *ctx, const study_table *t, const char *path);

/* Read a CSV written by study_table_write_csv into t, which must be initialised with the same
 * columns, or with more: a file whose header is a prefix of t's columns (at least the key) was
 * written before columns were appended, and its rows get those trailing cells empty. Rows are
 * appended. A missing file is not an error (*rows_read = 0). Returns OK,
 * PARSE_ERROR (other columns, a malformed line: the message names the file and line),
 * IO_ERROR, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status study_table_read_csv(obs_context *ctx, study_table *t, const char *path, int64_t *rows_read);

/* Write the table as JSON: {"columns": [...], "rows": [{name: value, ...}, ...]}, numbers as
 * numbers where the whole cell parses as a finite double, else strings. Atomic. OK or IO_ERROR. */
obs_status study_table_write_json(obs_context *ctx, const study_table *t, const char *path);

/* ---- Timing statistics ------------------------------------------------------------------------ */

typedef struct study_stats {
    double median, min, max;        /* of the samples; NaN when n = 0 */
    int n;
} study_stats;

/* The median (the mean of the two middle values for even n), min and max of v[0..n-1] (v is
 * reordered). */
study_stats study_stats_of(double *v, int n);

/* ---- Axes ---------------------------------------------------------------------------------------
 * An axis is a list of values given as one comma-separated string ("4,8,16,32"); empty items are
 * skipped. The values are text: each study parses and checks its own. */

#define STUDY_AXIS_MAX 32

typedef struct study_axis {
    int n;
    char *v[STUDY_AXIS_MAX];        /* pointers into buf */
    char *buf;                      /* owned */
} study_axis;

/* Split list into out (which is overwritten, not freed: start from a zeroed axis or free it first).
 * Returns OK, INVALID_ARGUMENT (NULL or empty list, more than STUDY_AXIS_MAX values: the message
 * names the axis), OUT_OF_MEMORY. */
obs_status study_axis_parse(obs_context *ctx, const char *name, const char *list, study_axis *out);
void study_axis_free(study_axis *a);                   /* NULL-safe; leaves it empty */

/* ---- Scores against a noisy ground truth --------------------------------------------------------
 * Every study scores a point against a ground truth that is itself an estimate. The truth's noise
 * variance s^2 (mean over the scored pixels) comes from independent randomisations of the same
 * estimator -- the replicate variance estimate of randomised quasi-Monte Carlo [L'Ecuyer &
 * Lemieux 2002, "Recent advances in randomized quasi-Monte Carlo methods"]: either inside each
 * pixel (the AO ground truth's s_R, truth_ao_params.error_bar = TRUTH_AO_BAR_REPLICATES: s^2 is
 * the mean of s_R^2), or, for a reference without its own replicates, from two whole runs g0, g1,
 * E[(g0 - g1)^2] = 2 Var(g0) per pixel (study_replicate_noise_rms). A noisy reference inflates a
 * mean squared error by s^2 (the point's error is independent of the reference's noise), so s^2
 * is subtracted (clamped at 0). */

/* sqrt(mean over the pixels mask allows (m != 0) of (g0 - g1)^2 / 2): g0's noise, for references
 * that carry no replicates of their own. 0 when no pixel. */
double study_replicate_noise_rms(const obs_image_f32 *g0, const obs_image_f32 *g1, const obs_image_f32 *mask);

/* sqrt(max(0, rmse^2 - noise_rms^2)). */
double study_noise_corrected(double rmse, double noise_rms);

/* What a point records against its ground truth, from mean squared errors: raw (the effect's
 * output) and calibrated (after the effect's artistic knobs are fitted, met_fit_gain_power for AO),
 * each as measured and with the truth's noise taken out (_nc); the flat baseline (the RMSE of the
 * best constant image, the truth's standard deviation) and the calibrated skill
 * 1 - MSE_cal / Var(truth) [Murphy88] (met_skill_of; _nc: both with s^2 taken out); and whether the
 * fit ended at a bound of its range. */
typedef struct study_score {
    double rmse, rmse_nc;
    double cal_rmse, cal_rmse_nc;
    double baseline_rmse, baseline_rmse_nc;
    double cal_skill, cal_skill_nc;
    int fit_at_bound;
} study_score;

/* raw_mse, cal_mse: the point's; ref_var: the truth's variance over the same pixels; noise_rms: s
 * (0: an exact truth); fit_at_bound: the calibration's flag. */
study_score study_score_of(double raw_mse, double cal_mse, double ref_var, double noise_rms, int fit_at_bound);

/* A skill at or below this is "about as good as a flat image": the calibrated image explains at
 * most 5% of the truth's variance (a constant test image scores about -1e-14, an inverted one
 * -0.13). Our choice (issue 12: a near-constant image must not rank on its calibrated RMSE). */
#define STUDY_SKILL_MIN 0.05

/* 1 when a calibrated score says something about the effect: its skill is above STUDY_SKILL_MIN
 * (a NaN skill is not). A fit at its power bound is flagged (fit_at_bound), not excluded: its
 * skill already says how much of the truth the re-shaped image explains. Reports rank only
 * informative configurations (docs/study.md). */
int study_score_informative(double cal_skill);

/* ---- Pareto front ------------------------------------------------------------------------------
 * on_front[i] = 1 when no other point j has cost[j] <= cost[i] and err[j] <= err[i] with one of
 * them strictly smaller (both minimised). Points with a NaN coordinate are never on the front.
 * Returns the number of points on the front. O(n log n). */
int study_pareto_front(const double *cost, const double *err, int n, unsigned char *on_front);

/* ---- Progress ---------------------------------------------------------------------------------- */

typedef struct study_progress {
    FILE *out;                      /* NULL = silent */
    int64_t total, done, skipped;   /* points; skipped = already measured (resume) */
    double t0;                      /* obs_time_now() at the start */
    double last_print;
    int is_tty;
} study_progress;

void study_progress_begin(study_progress *p, FILE *out, int64_t total);
/* One point finished (measured = 0 when it was skipped); label says which. Redraws the bar at most
 * every 0.2 s (always on a terminal's last point; one line per 5% when out is not a terminal). */
void study_progress_step(study_progress *p, int measured, const char *label);
void study_progress_end(study_progress *p);

/* ---- SVG scatter plots --------------------------------------------------------------------------
 * A scatter of error against cost with one series per name, its Pareto front drawn as a step line,
 * axes with ticks, the axis labels the caller gives (with units), and a legend. */

typedef struct study_series {
    const char *name;               /* legend entry */
    const double *x, *y;            /* n points */
    int n;
} study_series;

typedef struct study_plot {
    const char *title;
    const char *x_label, *y_label;  /* with units: "time per frame (ms)" */
    int log_x, log_y;               /* logarithmic axes */
    int pareto;                     /* 1: mark the front of all series together */
    int width, height;              /* pixels; 0 = 900 x 560 */
} study_plot;

/* Write the plot atomically to path. Points with NaN or (on a log axis) non-positive coordinates
 * are left out and counted in the caption. Returns OK, INVALID_ARGUMENT (no series, more than 16),
 * IO_ERROR. */
obs_status study_svg_scatter(obs_context *ctx, const char *path, const study_plot *plot, const study_series *series,
                             int series_count);

/* ---- Shards and a shared cache (docs/scale.md) ------------------------------------------------
 * A study's points are numbered in its fixed enumeration order; shard K of N (1 <= K <= N) takes
 * the points whose index i has i mod N = K - 1 (interleaved: every shard gets a share of every
 * frame and technique). The shards of one study share its ground-truth cache directory; a file in
 * it is named by a hash of what determines its content, written to a temporary name and renamed
 * (io_exr_write), and computed under a lock file so that two shards never compute it at once. */

/* "K/N" -> 1 and *k, *n (1 <= K <= N <= 1000000); 0 when malformed. */
int study_shard_parse(const char *s, int *k, int *n);
/* Slurm array jobs: K = SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1 (MIN 0 when unset),
 * N = SLURM_ARRAY_TASK_COUNT, when both ID and COUNT are set and give 1 <= K <= N (an array with a
 * step other than 1 is not supported): returns 1. Else 0 (no shard). */
int study_shard_from_env(int *k, int *n);
/* 1 when point `index` belongs to shard k of n (always for n <= 1). */
static inline int study_shard_has(int k, int n, int64_t index) { return n <= 1 || index % n == (int64_t)(k - 1); }

/* FNV-1a, 64-bit [FNV]: h = (h ^ byte) * 0x100000001b3, from the offset basis 0xcbf29ce484222325
 * (STUDY_HASH_INIT). Not cryptographic: it names cache files and checks configurations. */
#define STUDY_HASH_INIT 0xcbf29ce484222325ull
uint64_t study_hash_bytes(uint64_t h, const void *data, size_t len);
uint64_t study_hash_string(uint64_t h, const char *s);      /* the bytes and a terminating 0 */
/* The hash of a file's bytes, continuing from h. Returns OK or IO_ERROR. */
obs_status study_hash_file(obs_context *ctx, uint64_t h, const char *path, uint64_t *out);

/* A lock file: created with O_CREAT | O_EXCL (atomic on local and NFSv3+ file systems), holding
 * "host pid". study_lock_acquire waits (polling every 50-100 ms) while another process holds it,
 * up to timeout_s seconds (then LIMIT_EXCEEDED, naming the file); a lock held by a
 * process of this host that no longer exists is stale and removed. *waited = 1 when it had to
 * wait (another process held it). Returns OK, LIMIT_EXCEEDED, IO_ERROR. */
typedef struct study_lock {
    char path[4096];
    int held;
} study_lock;
obs_status study_lock_acquire(obs_context *ctx, const char *path, double timeout_s, study_lock *lock, int *waited);
void study_lock_release(study_lock *lock);                 /* NULL-safe; removes the file */

/* The manifest of a study's output directory, DIR/manifest.json: which study, obscura's version,
 * the configuration (its canonical text and hash) and the shard. Written beside results.csv;
 * `obscura study merge` reads it to refuse tables from other configurations or versions. */
typedef struct study_manifest {
    char study[32];               /* "ao" */
    char version[32];             /* OBS_VERSION_STRING */
    char config_hash[17];         /* 16 hex digits of study_hash_string(STUDY_HASH_INIT, config) */
    char config[4096];            /* canonical "key=value;" text of every option that decides a row */
    int shard, shards;            /* K of N; 1 of 1 for an unsharded run */
} study_manifest;
obs_status study_manifest_write(obs_context *ctx, const char *dir, const study_manifest *m);
/* Returns OK, IO_ERROR (missing), PARSE_ERROR (not a manifest). */
obs_status study_manifest_read(obs_context *ctx, const char *dir, study_manifest *m);

#ifdef __cplusplus
}
#endif

#endif
