/* study.h: the generic parts of an accuracy-versus-time study (prefix study_): a sweep over
 * parameter axes with resume, a results table written as CSV and JSON, timing statistics, Pareto
 * fronts, a progress bar and SVG scatter plots. A study (`obscura study ao`, later sss and volume)
 * is a list of axes, a run function that measures one point, and the error it records; everything
 * else is here. docs/study.md. */
#ifndef STUDY_H
#define STUDY_H

#include "../core/obs.h"

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

#ifdef __cplusplus
}
#endif

#endif
