/* study_ao_internal.h: what study_ao.c (options, frames, ground truth, the sweep) shares with
 * study_ao_report.c. Not a public header. */
#ifndef STUDY_AO_INTERNAL_H
#define STUDY_AO_INTERNAL_H

#include "study_ao.h"
#include "../ao/ao.h"
#include "../metrics/metrics.h"
#include "../raster/raster.h"

struct study_ao {
    study_ao_options o;             /* as given (strings borrowed) */
    char all_methods[1024];         /* o.methods when NULL was given: every registered technique */
    study_axis scenes, views, methods, resolutions, samples, radii, blurs, budgets;
    study_table table;
    char csv[4096], json[4096];
    double last_save;
    int dirty;
};

/* The results table's columns: the key, what was run, time, error (docs/study.md). */
enum { STUDY_AO_KEY_COLUMNS = 8 };
extern const char *const study_ao_i_columns[];
extern const int study_ao_i_column_count;

/* "WxH" -> 1 and *w, *h; 0 when malformed. */
int study_ao_i_parse_size(const char *s, int *w, int *h);

/* Per scene, view and resolution: the G-buffer, the AO input and the masks. */
typedef struct study_ao_i_frame {
    obs_scene scene;
    truth_scene *ts;
    obs_camera cam;
    rast_gbuffer gb;
    ao_input in;
    obs_image_f32 mask;             /* 1 on surface pixels (w x h) */
    obs_image_f32 fit_mask;         /* the surface pixels of a regular s x s lattice: the calibration fit's */
    study_stats raster;
} study_ao_i_frame;

obs_status study_ao_i_frame_render(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                                   const char *view, int W, int H, int need_truth, study_ao_i_frame *f);
void study_ao_i_frame_free(study_ao_i_frame *f);

/* The ground truth (seed 0: the reference; 1: its replicate) for (estimator, radius) on frame f,
 * from the cache OUT/gt/ or computed and cached. mean is allocated; mean_se and rms_se (may be
 * NULL) receive the mean and RMS of its per-pixel standard error over the surface pixels. */
obs_status study_ao_i_ground_truth(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene_name,
                                   const char *view, study_ao_i_frame *f, const char *estimator, float radius,
                                   unsigned seed, obs_image_f32 *mean, double *mean_se, double *rms_se);

/* One point: its times and its scores (run_point). */
typedef struct study_ao_i_point {
    study_stats prepare, kernel, blur, blend, total;
    met_result raw, cal;
    met_fit fit;
} study_ao_i_point;

/* Run method m with params p on frame f `runs` times (after one warm-up), time it, and (gt not
 * NULL) compare with the ground truth gt, raw and after the calibrated fit. ao receives the last
 * run's AO (w x h, allocated). */
obs_status study_ao_i_run_point(obs_context *ctx, obs_pool *pool, const ao_method *m, const void *p,
                                study_ao_i_frame *f, int runs, const obs_image_f32 *gt, obs_image_f32 *ao,
                                study_ao_i_point *res);

/* ---- image grids (study_ao_report.c; docs/study.md, "The report") ----
 * A grid is a band of column titles at the top, then for each row a label band and the row's three
 * cells side by side: the technique's AO, the matched ground truth, and |AO - GT| as an inferno
 * heat map on [0, STUDY_AO_GRID_ERROR_MAX]. Bands are light grey with black text (obs_font.h), so
 * they read on any image; the cells hold the images untouched. */
#define STUDY_AO_GRID_ERROR_MAX 0.5 /* |AO - GT| at the top of the heat map; ours (issue 5's grids) */
typedef struct study_ao_i_grid {
    int cell_w, cell_h, rows;
    int gap;           /* pixels between cells and between rows (background) */
    int scale;         /* the font's integer scale: 1 at 192 wide, 2 at 480, 12 at 3840 */
    int title_h;       /* height of the column-title band at the top */
    int label_h;       /* height of each row's label band, directly above its cells */
    int width, height; /* of the whole grid */
} study_ao_i_grid;

/* Lay out a grid of `rows` rows of cell_w x cell_h cells whose row labels are labels[0..rows-1]
 * (one line each): the font scale grows with the cell width, and is lowered until the longest
 * label and the column titles fit. */
void study_ao_i_grid_layout(study_ao_i_grid *g, int cell_w, int cell_h, int rows, const char *const *labels);
/* The top-left pixel of cell (row, col), col 0..2. */
void study_ao_i_grid_cell_origin(const study_ao_i_grid *g, int row, int col, int *x, int *y);
/* Draw the title band (column titles, the error colour bar and its scale) and each row's label
 * band into rgb (3 linear planes of g->width x g->height, written by io_png_write as
 * IO_PNG_LINEAR). Only band pixels are written; cells and gaps are left as they are. */
void study_ao_i_grid_draw_labels(const study_ao_i_grid *g, obs_image_f32 rgb[3], const char *const *labels);

#endif
