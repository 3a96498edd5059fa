/* study_ao_report.c: the AO study's report (study_ao_report): error-versus-time plots, the best
 * configuration per frame budget, the seed's table layouts, each technique's hard case, image grids,
 * MSSAO per level, and a closing summary, from the results table. docs/study.md, "The report". */
#include "study_ao_internal.h"
#include "../io/io.h"
#include "../core/obs_font.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A configuration (technique, samples, radius, blur) averaged over the rows of a resolution (and
 * of one scene or all). The error is the noise-corrected calibrated RMSE; beside it the flat
 * baseline and the calibrated skill (noise-corrected too), and how many of its points have their
 * fit at a bound. */
typedef struct agg {
    char method[32];
    int samples, blur;
    double radius_units;
    double time_sum, err_sum, raw_sum, base_sum, skill_sum;
    int n, nskill, nbound;
} agg;

static int col(const study_table *t, const char *name) { return study_table_column(t, name); }

static double mean_time(const agg *a) { return a->time_sum / a->n; }
static double mean_err(const agg *a) { return a->err_sum / a->n; }
static double mean_base(const agg *a) { return a->nskill ? a->base_sum / a->nskill : NAN; }
static double mean_skill(const agg *a) { return a->nskill ? a->skill_sum / a->nskill : NAN; }

/* Is a configuration's calibrated score informative (study_score_informative)? Not when its mean
 * skill is not above STUDY_SKILL_MIN. A table from before the skill columns (report-only on an old
 * table) has no skill: a fit at its bound in any point stands in for it then. */
static int informative(const agg *a)
{
    if (a->nskill == 0)
        return a->nbound == 0;
    return study_score_informative(mean_skill(a));
}

/* "†" after a configuration that is not informative (not ranked); "°" after one whose fit is at
 * its power bound in some point (ranked, flagged). */
static const char *mark(const agg *a) { return !informative(a) ? "†" : a->nbound > 0 ? "°" : ""; }

/* The aggregated configuration (of `method`, or of any when NULL) with the lowest mean error among
 * those whose mean time is within budget ms, and (informative_only) whose score is informative;
 * -1 if none. */
static int best_within(const agg *ag, int na, double budget, const char *method, int informative_only)
{
    int best = -1;
    for (int k = 0; k < na; k++)
        if ((!method || !strcmp(ag[k].method, method)) && mean_time(&ag[k]) <= budget &&
            (!informative_only || informative(&ag[k])) && (best < 0 || mean_err(&ag[k]) < mean_err(&ag[best])))
            best = k;
    return best;
}

/* Is the fit of row r at its bound: its fit_at_bound cell, or (a table from before that column)
 * the rule applied to its fitted power. */
static int row_at_bound(const study_table *t, int64_t r)
{
    const double b = study_table_num(t, r, col(t, "fit_at_bound"));
    return b == b ? b != 0.0 : met_fit_power_at_bound(study_table_num(t, r, col(t, "cal_power")));
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
              cx = col(t, "rmse_nc"), cst = col(t, "status"), csc = col(t, "scene"), csk = col(t, "cal_skill_nc"),
              cbl = col(t, "baseline_rmse_nc");
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
        const double skill = study_table_num(t, r, csk), base = study_table_num(t, r, cbl);
        if (skill == skill && base == base) {
            out[k].skill_sum += skill;
            out[k].base_sum += base;
            out[k].nskill++;
        }
        out[k].nbound += row_at_bound(t, r);
    }
    return n;
}

/* ---- image grids: layout and labels (study_ao_internal.h) ---- */

/* The column titles; the error column continues with the colour bar and its scale. */
static const char *const grid_titles[3] = {"AO (technique)", "ground truth (matched)", "|AO-GT| 0 "};
#define GRID_BAR_CELLS 6   /* the error colour bar's width, in glyph cells */
#define GRID_BAR_END " 0.5" /* its top label: STUDY_AO_GRID_ERROR_MAX */

/* Band and text colours (linear, written as-is): black on light grey, distinct from the white gaps. */
static const float grid_band[3] = {0.85f, 0.85f, 0.85f};
static const float grid_ink[3] = {0.0f, 0.0f, 0.0f};

/* An sRGB-encoded colour-map value decoded to linear (io_png_write with IO_PNG_LINEAR writes values
 * as-is, and met_colormap_inferno gives sRGB): IEC 61966-2-1's decoding. */
static float grid_srgb_decode(float v) { return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f); }

/* Row labels may have several lines, separated by '\n': the number of lines of `text`, and the
 * width of its widest line at scale 1. */
static int grid_text_lines(const char *text, int *widest)
{
    int lines = 1, w = 0, cur = 0;
    for (const char *c = text; *c; c++) {
        if (*c == '\n') {
            lines++;
            cur = 0;
        } else
            cur += OBS_FONT_GLYPH_W;
        w = cur > w ? cur : w;
    }
    *widest = w;
    return lines;
}

/* Draw the lines of `text` from (x, y) down, a blank of `scale` pixels between lines. */
static void grid_draw_lines(obs_image_f32 rgb[3], int x, int y, int scale, const char *text)
{
    char line[256];
    while (*text) {
        size_t n = strcspn(text, "\n");
        snprintf(line, sizeof line, "%.*s", (int)(n < sizeof line ? n : sizeof line - 1), text);
        obs_font_draw(rgb, 3, x, y, scale, grid_ink, line);
        y += (OBS_FONT_GLYPH_H + 1) * scale;
        text += n + (text[n] == '\n');
    }
}

void study_ao_i_grid_layout(study_ao_i_grid *g, int cell_w, int cell_h, int rows, const char *const *labels)
{
    memset(g, 0, sizeof *g);
    g->cell_w = cell_w;
    g->cell_h = cell_h;
    g->rows = rows;
    g->gap = 4;
    /* the font grows with the cell: 8 px glyphs per 320 px of cell width, rounded (192: 1, 480: 2,
     * 1920: 6, 3840: 12; our choice, about 3% of the width), then lowered until every line fits */
    int s = (cell_w + 160) / 320;
    s = s < 1 ? 1 : s;
    const int width = 3 * cell_w + 2 * g->gap;
    int lines = 1;
    for (int i = 0; i < rows; i++) {
        int w1;
        const int n = grid_text_lines(labels[i], &w1);
        lines = n > lines ? n : lines;
        while (s > 1 && w1 * s > width - 4 * s)
            s--;
    }
    for (int c = 0; c < 3; c++) {
        const int w1 = obs_font_text_width(grid_titles[c], 1) +
                       (c == 2 ? (GRID_BAR_CELLS * OBS_FONT_GLYPH_W + obs_font_text_width(GRID_BAR_END, 1)) : 0);
        while (s > 1 && w1 * s > cell_w - 4 * s)
            s--;
    }
    g->scale = s;
    /* text plus 2s above and below; s between lines */
    g->title_h = OBS_FONT_GLYPH_H * s + 4 * s;
    g->label_h = lines * OBS_FONT_GLYPH_H * s + (lines - 1) * s + 4 * s;
    g->width = width;
    g->height = g->title_h + rows * (g->label_h + cell_h) + (rows > 0 ? rows - 1 : 0) * g->gap;
}

void study_ao_i_grid_cell_origin(const study_ao_i_grid *g, int row, int col, int *x, int *y)
{
    *x = col * (g->cell_w + g->gap);
    *y = g->title_h + row * (g->label_h + g->cell_h + g->gap) + g->label_h;
}

void study_ao_i_grid_draw_labels(const study_ao_i_grid *g, obs_image_f32 rgb[3], const char *const *labels)
{
    const int s = g->scale, pad = 2 * s;
    /* the title band: one title per column, the error column's colour bar and its scale */
    obs_font_fill_rect(rgb, 3, 0, 0, g->width, g->title_h, grid_band);
    for (int c = 0; c < 3; c++) {
        int x = c * (g->cell_w + g->gap) + pad;
        x = obs_font_draw(rgb, 3, x, pad, s, grid_ink, grid_titles[c]);
        if (c != 2)
            continue;
        const int bw = GRID_BAR_CELLS * OBS_FONT_GLYPH_W * s, bh = OBS_FONT_GLYPH_H * s;
        for (int i = 0; i < bw; i++) {
            float heat[3], lin[3];
            met_colormap_inferno((i + 0.5) / bw, heat);
            for (int k = 0; k < 3; k++)
                lin[k] = grid_srgb_decode(heat[k]);
            obs_font_fill_rect(rgb, 3, x + i, pad, 1, bh, lin);
        }
        obs_font_draw(rgb, 3, x + bw, pad, s, grid_ink, GRID_BAR_END);
    }
    /* each row's label band, directly above its cells */
    for (int i = 0; i < g->rows; i++) {
        int x, y;
        study_ao_i_grid_cell_origin(g, i, 0, &x, &y);
        obs_font_fill_rect(rgb, 3, 0, y - g->label_h, g->width, g->label_h, grid_band);
        grid_draw_lines(rgb, pad, y - g->label_h + pad, s, labels[i]);
    }
}

/* An image grid: one row per technique (its AO, the ground truth, the error heat map |AO - GT| on
 * [0, STUDY_AO_GRID_ERROR_MAX]), for the chosen point of each, each row labelled with the
 * technique, its parameters, and its time and error from the table at MW x MH. */
typedef struct grid_row {
    const ao_method *m;
    int samples, blur;
    double radius_units;
} grid_row;

/* The label of a grid row: the technique, its parameters, and the time and error of its point in
 * this scene and view at MW x MH from the table (or "not measured"). */
static void grid_row_label(const study_ao *s, const char *scene, const char *view, int MW, int MH,
                           const grid_row *r, char *out, size_t size)
{
    const study_table *t = &s->table;
    int64_t found = -1;
    for (int64_t k = 0; k < t->rows && found < 0; k++)
        if (!strcmp(study_table_get(t, k, col(t, "scene")), scene) &&
            !strcmp(study_table_get(t, k, col(t, "view")), view) &&
            !strcmp(study_table_get(t, k, col(t, "method")), r->m->name) &&
            !strcmp(study_table_get(t, k, col(t, "status")), "ok") && study_table_num(t, k, col(t, "width")) == MW &&
            study_table_num(t, k, col(t, "height")) == MH && study_table_num(t, k, col(t, "samples")) == r->samples &&
            study_table_num(t, k, col(t, "radius_units")) == r->radius_units &&
            study_table_num(t, k, col(t, "blur")) == r->blur)
            found = k;
    int n = snprintf(out, size, "%s: %d samples, radius %g m, blur %s\n", r->m->name, r->samples,
                     r->radius_units * study_ao_scene_unit(scene), r->blur ? "on" : "off");
    if (n < 0 || (size_t)n >= size)
        return;
    if (found < 0) {
        snprintf(out + n, size - (size_t)n, "not measured at %dx%d", MW, MH);
        return;
    }
    const double skill = study_table_num(t, found, col(t, "cal_skill_nc"));
    n += snprintf(out + n, size - (size_t)n, "%.2f ms at %dx%d, calibrated RMSE %.3f",
                  study_table_num(t, found, col(t, "total_ms")), MW, MH,
                  study_table_num(t, found, col(t, "cal_rmse_nc")));
    if (skill == skill && n > 0 && (size_t)n < size)
        snprintf(out + n, size - (size_t)n, ", skill %.2f", skill);
}

static obs_status write_grid(obs_context *ctx, obs_pool *pool, const study_ao *s, const char *scene,
                             const char *view, int W, int H, int MW, int MH, const grid_row *rows, int nrows,
                             const char *path)
{
    char text[16][160];
    const char *labels[16];
    nrows = nrows > 16 ? 16 : nrows;
    for (int i = 0; i < nrows; i++) {
        grid_row_label(s, scene, view, MW, MH, &rows[i], text[i], sizeof text[i]);
        labels[i] = text[i];
    }
    study_ao_i_grid g;
    study_ao_i_grid_layout(&g, W, H, nrows, labels);
    study_ao_i_frame f;
    obs_status st = study_ao_i_frame_render(ctx, pool, s, scene, view, W, H, 1, &f);
    obs_image_f32 rgb[3] = {{0}, {0}, {0}};
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
        st = obs_image_f32_alloc(ctx, g.width, g.height, &rgb[c]);
        if (st == OBS_STATUS_OK)
            obs_image_f32_fill(&rgb[c], 1.0f);
    }
    if (st == OBS_STATUS_OK)
        study_ao_i_grid_draw_labels(&g, rgb, labels);
    for (int i = 0; i < nrows && st == OBS_STATUS_OK; i++) {
        const ao_method *m = rows[i].m;
        unsigned char p[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
        m->params_default(p);
        m->set_samples(p, rows[i].samples);
        m->set_radius(p, (float)(rows[i].radius_units * study_ao_scene_unit(scene)));
        m->set_blur(p, rows[i].blur);
        obs_image_f32 ao = {0}, gt = {0};
        double se;
        study_ao_i_point res;
        memset(&res, 0, sizeof res);
        st = study_ao_i_ground_truth(ctx, pool, s, scene, view, &f, m->truth_estimator(p), m->get_radius(p), 0, &gt, &se, NULL);
        if (st == OBS_STATUS_OK)
            st = study_ao_i_run_point(ctx, pool, m, p, &f, 1, NULL, &ao, &res);
        int x0, y0;
        study_ao_i_grid_cell_origin(&g, i, 0, &x0, &y0);
        for (int y = 0; st == OBS_STATUS_OK && y < H; y++)
            for (int x = 0; x < W; x++) {
                const int yy = y0 + y;
                const int surf = obs_image_f32_row(&f.mask, y)[x] != 0.0f;
                const float a = surf ? obs_image_f32_row(&ao, y)[x] : 0.0f;
                const float gv = surf ? obs_image_f32_row(&gt, y)[x] : 0.0f;
                float heat[3];
                met_colormap_inferno(surf ? fabs((double)a - gv) / STUDY_AO_GRID_ERROR_MAX : 0.0, heat);
                for (int c = 0; c < 3; c++) {
                    obs_image_f32_row(&rgb[c], yy)[x0 + x] = a;
                    obs_image_f32_row(&rgb[c], yy)[x0 + W + g.gap + x] = gv;
                    /* the colour map is sRGB-encoded: decode (the PNG is written linear) */
                    obs_image_f32_row(&rgb[c], yy)[x0 + 2 * (W + g.gap) + x] = grid_srgb_decode(heat[c]);
                }
            }
        obs_image_f32_free(&ao);
        obs_image_f32_free(&gt);
    }
    if (st == OBS_STATUS_OK)
        st = io_png_write(ctx, path, rgb, 3, IO_PNG_LINEAR);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&rgb[c]);
    study_ao_i_frame_free(&f);
    return st;
}

/* The seed's Table 24 with error: MSSAO's cost per level and the accuracy of stopping at each level,
 * for each scene (first view) at W x H, with the middle swept radius and sample count. The time of a
 * level is its downsample + AO pass + level blur (ao_mssao_stats.seconds_level, median of `runs`);
 * the error of level l is the RMSE against the matched ground truth of levels coarsest..l combined
 * as the finest level's combine would combine them (AO_MSSAO_LEVEL_COMBINED), upsampled to W x H by
 * nearest texel. Writes the rows to md; a scene that fails is reported in its row. */
static obs_status mssao_levels_table(obs_context *ctx, obs_pool *pool, const study_ao *s, int W, int H, FILE *md)
{
    const ao_method *m = ao_method_find("mssao");
    if (!m)
        return OBS_STATUS_OK;
    const double units = atof(s->radii.v[s->radii.n > 1 ? 1 : 0]);
    const int samples = atoi(s->samples.v[s->samples.n > 1 ? 1 : 0]);
    fprintf(md, "\n## MSSAO per level (the seed's Table 24, with error)\n\nAt %dx%d, radius %g units, %d samples, "
                "first view. Time: the level's downsample, AO pass and level blur (median of %d runs). Error: RMSE "
                "against the matched ground truth of the levels from the coarsest down to this one, combined as the "
                "finest level combines them and upsampled by nearest texel (level 0 is the method's output).\n\n"
                "| scene | level | size | ms | RMSE |\n|---|---|---|---|---|\n",
            W, H, units, samples, s->o.runs);
    obs_status st = OBS_STATUS_OK;
    for (int sc = 0; sc < s->scenes.n && st == OBS_STATUS_OK; sc++) {
        const char *scene = s->scenes.v[sc], *view = s->views.v[0];
        study_ao_i_frame f;
        st = study_ao_i_frame_render(ctx, pool, s, scene, view, W, H, 1, &f);
        ao_mssao_params p;
        m->params_default(&p);
        m->set_radius(&p, (float)(units * study_ao_scene_unit(scene)));
        m->set_samples(&p, samples);
        m->set_blur(&p, 0);
        obs_image_f32 gt = {0}, out = {0}, up = {0}, lvimg = {0};
        double gt_se = 0.0;
        if (st == OBS_STATUS_OK)
            st = study_ao_i_ground_truth(ctx, pool, s, scene, view, &f, m->truth_estimator(&p), m->get_radius(&p), 0, &gt, &gt_se, NULL);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &out);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &up);
        double t[AO_MSSAO_MAX_LEVELS][16];
        const int runs = s->o.runs < 16 ? s->o.runs : 16;
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
        study_ao_i_frame_free(&f);
    }
    return st;
}

obs_status study_ao_report(obs_context *ctx, obs_pool *pool, study_ao *s)
{
    if (!s->o.report_dir || !*s->o.report_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study ao: no report directory");
    const study_table *t = &s->table;
    obs_status dst = io_make_dirs(ctx, s->o.report_dir);
    if (dst != OBS_STATUS_OK)
        return dst;
    char path[4096];
    char mdpath[4096];
    snprintf(mdpath, sizeof mdpath, "%s/README.md", s->o.report_dir);
    /* The page is built in memory and written atomically at the end. */
    char *mdtext = NULL;
    size_t mdlen = 0;
    FILE *md = open_memstream(&mdtext, &mdlen);
    if (!md)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", mdpath);
    /* The main resolution: 1920x1080 when swept, else the first. */
    int MW = 0, MH = 0;
    for (int r = 0; r < s->resolutions.n; r++) {
        int w, h;
        study_ao_i_parse_size(s->resolutions.v[r], &w, &h);
        if (r == 0 || (w == 1920 && h == 1080)) {
            MW = w;
            MH = h;
        }
    }
    fprintf(md, "# What AO accuracy costs in time\n\n");
    fprintf(md, "Generated by `obscura study ao%s --report %s` (obscura %s). Reproduce: docs/study.md.\n\n",
            s->o.quick ? " --quick" : "", s->o.report_dir, OBS_VERSION_STRING);
    /* the table itself beside the page: the numbers behind every figure */
    snprintf(path, sizeof path, "%s/results.csv", s->o.report_dir);
    dst = study_table_write_csv(ctx, t, path);
    if (dst != OBS_STATUS_OK) {
        fclose(md);
        free(mdtext);
        return dst;
    }
    fprintf(md, "- Points: %lld rows in [`results.csv`](results.csv) (a copy of `%s/results.csv`; columns: "
                "docs/study.md).", (long long)t->rows, s->o.out_dir);
    {
        /* what was measured at each resolution: a study may sweep some resolutions more fully */
        const int cw = col(t, "width"), chh = col(t, "height"), cn = col(t, "samples"), cq = col(t, "radius_units");
        for (int r = 0; r < s->resolutions.n; r++) {
            int w, h;
            study_ao_i_parse_size(s->resolutions.v[r], &w, &h);
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
            fprintf(md, " %s: %lld (samples %s; radii %s)%s", s->resolutions.v[r], (long long)n, n ? sam + 1 : "-",
                    n ? rad + 1 : "-", r + 1 < s->resolutions.n ? ";" : ".\n");
        }
    }
    fprintf(md, "- Scenes:");
    for (int i = 0; i < s->scenes.n; i++)
        fprintf(md, " %s (unit %.3g m)%s", s->scenes.v[i], study_ao_scene_unit(s->scenes.v[i]), i + 1 < s->scenes.n ? "," : ".");
    /* the scanned meshes' credit, which the Stanford repository asks of published images (data/README.md) */
    fprintf(md, " The bunny is the Stanford bunny (Stanford Computer Graphics Laboratory), the dragon CGAL's "
                "\"Chinese dragon\"; where each mesh comes from and its terms: data/README.md.\n");
    fprintf(md, "- Time: the median of %d runs after one warm-up, on %d threads; `total` is the AO pass with its "
                "preparation, blur and the final blend (the G-buffer is timed separately).\n",
            s->o.runs, obs_pool_threads(pool));
    fprintf(md, "- Error: against each technique's matched ground truth (`obscura ao --list` names it; "
                "docs/truth.md), over surface pixels. *Calibrated* fits `1 - g (1 - v^p)` to the ground truth "
                "first (docs/compare.md), so it measures shape, not the technique's overall darkness. Every RMSE "
                "here has the ground truth's own noise taken out: sqrt(max(0, RMSE^2 - s^2)), s^2 the reference's mean "
                "noise variance over the surface pixels, estimated from a second ground truth with another seed "
                "(an independent randomisation): s^2 = mean((g0 - g1)^2) / 2 (`gt_noise_rms`; `rmse_nc`, "
                "`cal_rmse_nc`; the uncorrected values are in the CSV).\n");
    fprintf(md, "- Is a calibrated score informative? The fit can turn an image that says nothing about the ground "
                "truth into about its mean, whose RMSE is the ground truth's standard deviation. So the tables give, "
                "beside the calibrated RMSE, the *flat baseline* (the RMSE of the best constant image: the ground "
                "truth's standard deviation over the surface pixels) and the *skill* 1 - MSE / Var(ground truth) "
                "(Murphy 1988, the MSE skill score against the sample mean; 1 perfect, 0 no better than a flat "
                "image), both with the noise s^2 taken out of the MSE and of the variance (`baseline_rmse_nc`, "
                "`cal_skill_nc`). A configuration is **not ranked** (marked †) when its mean skill is not above %g "
                "(the calibrated image explains at most 5%% of the ground truth's variance): the budget table, each "
                "technique's best, the summary's budgets and Pareto front consider only the others. A fit whose "
                "power sits at the bound of its range in some point (`fit_at_bound`) is flagged ° and still ranked: "
                "its skill says how much the re-shaped image explains. The plots show every point.\n",
            STUDY_SKILL_MIN);
    fprintf(md, "- Ground truth: a fixed %lld samples per pixel at 1280x720 and below (no adaptive stopping: "
                "unbiased, rare occlusion included), scaled by the pixel count above (1920x1080: %lld, 3840x2160: "
                "%lld), so each resolution's ground truth costs about the same rays; 8 Owen-scrambled replicates "
                "per pixel give its noise, which the `_nc` columns take out; the estimators that share a direction "
                "distribution are computed from one ray set (`truth_ao_render_multi`).\n\n",
            s->o.gt_max_samples, (long long)study_ao_truth_params(&s->o, 1920, 1080, 0).max_samples,
            (long long)study_ao_truth_params(&s->o, 3840, 2160, 0).max_samples);

    /* ---- plots: calibrated RMSE against total time, all scenes together, and per scene ---- */
    for (int sc = -1; sc < s->scenes.n; sc++) {
        study_series ser[16];
        double *xs[16] = {0}, *ys[16] = {0};
        int ns = 0;
        for (int mi = 0; mi < s->methods.n && ns < 16; mi++) {
            xs[ns] = (double *)malloc(sizeof(double) * (size_t)(t->rows + 1));
            ys[ns] = (double *)malloc(sizeof(double) * (size_t)(t->rows + 1));
            if (!xs[ns] || !ys[ns])
                break;
            int n = 0;
            for (int64_t r = 0; r < t->rows; r++) {
                if (strcmp(study_table_get(t, r, col(t, "method")), s->methods.v[mi]) != 0 ||
                    strcmp(study_table_get(t, r, col(t, "status")), "ok") != 0 ||
                    study_table_num(t, r, col(t, "width")) != MW || study_table_num(t, r, col(t, "height")) != MH)
                    continue;
                if (sc >= 0 && strcmp(study_table_get(t, r, col(t, "scene")), s->scenes.v[sc]) != 0)
                    continue;
                xs[ns][n] = study_table_num(t, r, col(t, "total_ms"));
                ys[ns][n] = study_table_num(t, r, col(t, "cal_rmse_nc"));
                n++;
            }
            ser[ns] = (study_series){s->methods.v[mi], xs[ns], ys[ns], n};
            ns++;
        }
        char title[256], file[256];
        snprintf(title, sizeof title, "Calibrated RMSE vs time, %dx%d, %s", MW, MH, sc < 0 ? "all scenes" : s->scenes.v[sc]);
        snprintf(file, sizeof file, "pareto_%s.svg", sc < 0 ? "all" : s->scenes.v[sc]);
        snprintf(path, sizeof path, "%s/%s", s->o.report_dir, file);
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
        int fastest = -1, unranked = 0;
        for (int k = 0; k < na; k++) {
            if (fastest < 0 || mean_time(&ag[k]) < mean_time(&ag[fastest]))
                fastest = k;
            unranked += !informative(&ag[k]);
        }
        fprintf(sum, "- **Per frame budget at %dx%d** (time and error averaged over the scenes and views, %d threads; "
                     "informative configurations only):",
                MW, MH, obs_pool_threads(pool));
        for (int b = 0; b < s->budgets.n; b++) {
            double budget = atof(s->budgets.v[b]);
            const int best = best_within(ag, na, budget, NULL, 1);
            if (best >= 0)
                fprintf(sum, " %g ms: %s (%d samples, radius %g, blur %s), %.2f ms, calibrated RMSE %.3f, skill %.2f;",
                        budget, ag[best].method, ag[best].samples, ag[best].radius_units, ag[best].blur ? "on" : "off",
                        mean_time(&ag[best]), mean_err(&ag[best]), mean_skill(&ag[best]));
            else if (best_within(ag, na, budget, NULL, 0) >= 0)
                fprintf(sum, " %g ms: nothing informative fits;", budget);
            else
                fprintf(sum, " %g ms: nothing fits;", budget);
        }
        if (fastest >= 0)
            fprintf(sum, " the fastest configuration of all is %s with %d samples at %.2f ms (calibrated RMSE %.3f, "
                         "skill %.2f%s).\n",
                    ag[fastest].method, ag[fastest].samples, mean_time(&ag[fastest]), mean_err(&ag[fastest]),
                    mean_skill(&ag[fastest]), informative(&ag[fastest]) ? "" : ", not informative");
        /* which configurations are left out of the ranking, by technique */
        if (unranked > 0) {
            fprintf(sum, "- **Not ranked** (mean skill not above %g): %d of %d configurations:", STUDY_SKILL_MIN,
                    unranked, na);
            int first = 1;
            for (int mi = 0; mi < s->methods.n; mi++) {
                int n = 0, nb = 0, of = 0;
                for (int k = 0; k < na; k++)
                    if (!strcmp(ag[k].method, s->methods.v[mi])) {
                        of++;
                            n += !informative(&ag[k]);
                        nb += !informative(&ag[k]) && ag[k].nbound > 0;
                    }
                if (n)
                    fprintf(sum, "%s %s %d of %d (%d at the bound)", first ? "" : ",", s->methods.v[mi], n, of, nb);
                first &= !n;
            }
            fprintf(sum, ".\n");
        }
        /* per scene, for the budgets nothing fits on average: scenes differ in covered pixels */
        agg *as = (agg *)calloc(4096, sizeof(agg));
        for (int b = 0; as && b < s->budgets.n; b++) {
            const double budget = atof(s->budgets.v[b]);
            if (best_within(ag, na, budget, NULL, 1) >= 0)
                continue;
            fprintf(sum, "- **%g ms, scene by scene** (mean over views):", budget);
            for (int sc = 0; sc < s->scenes.n; sc++) {
                const int ns = aggregate(t, MW, MH, s->scenes.v[sc], as, 4096);
                const int k = best_within(as, ns, budget, NULL, 1);
                if (k >= 0)
                    fprintf(sum, " %s: %s (%d samples, radius %g, blur %s), %.2f ms, calibrated RMSE %.3f, skill %.2f;",
                            s->scenes.v[sc], as[k].method, as[k].samples, as[k].radius_units, as[k].blur ? "on" : "off",
                            mean_time(&as[k]), mean_err(&as[k]), mean_skill(&as[k]));
                else
                    fprintf(sum, " %s: nothing %sfits;", s->scenes.v[sc],
                            best_within(as, ns, budget, NULL, 0) >= 0 ? "informative " : "");
            }
            fprintf(sum, "\n");
        }
        free(as);
        /* which techniques are on the Pareto front of the informative averaged configurations (an
         * uninformative one has NaN coordinates, which are never on the front) */
        double *cx = (double *)malloc(sizeof(double) * (size_t)(na ? na : 1));
        double *cy = (double *)malloc(sizeof(double) * (size_t)(na ? na : 1));
        unsigned char *on = (unsigned char *)calloc((size_t)(na ? na : 1), 1);
        if (cx && cy && on && na) {
            for (int k = 0; k < na; k++) {
                cx[k] = informative(&ag[k]) ? mean_time(&ag[k]) : NAN;
                cy[k] = informative(&ag[k]) ? mean_err(&ag[k]) : NAN;
            }
            study_pareto_front(cx, cy, na, on);
            fprintf(sum, "- **On the Pareto front** (informative averaged configurations at %dx%d, by time):", MW, MH);
            int first = 1;
            for (int pass = 0; pass < na; pass++) { /* print in order of time */
                int k = -1;
                for (int j = 0; j < na; j++)
                    if (on[j] == 1 && (k < 0 || cx[j] < cx[k]))
                        k = j;
                if (k < 0)
                    break;
                on[k] = 2;
                fprintf(sum, "%s %s %d/%g/%s (%.1f ms, %.3f, %.2f)", first ? "" : ",", ag[k].method, ag[k].samples,
                        ag[k].radius_units, ag[k].blur ? "blur" : "raw", cx[k], cy[k], mean_skill(&ag[k]));
                first = 0;
            }
            fprintf(sum, " (technique samples/radius/blur, ms, calibrated RMSE, skill).\n");
        }
        free(cx);
        free(cy);
        free(on);
    }
    fprintf(md, "## Best technique per frame budget (%dx%d, mean over scenes and views)\n\n"
                "Informative configurations only (see above); skill and flat baseline are means over the same points.\n\n",
            MW, MH);
    fprintf(md, "| budget | technique | samples | radius (units) | blur | time (ms) | calibrated RMSE | flat baseline "
                "| skill | raw RMSE |\n|---|---|---|---|---|---|---|---|---|---|\n");
    grid_row best_rows[16];
    int nbest = 0;
    for (int b = 0; b < s->budgets.n; b++) {
        double budget = atof(s->budgets.v[b]);
        const int best = best_within(ag, na, budget, NULL, 1);
        if (best < 0) {
            fprintf(md, "| %g ms | %s | | | | | | | | |\n", budget,
                    best_within(ag, na, budget, NULL, 0) >= 0 ? "none informative fits" : "none fits");
            continue;
        }
        const agg *a = &ag[best];
        fprintf(md, "| %g ms | %s | %d | %g | %s | %.2f | %.4f | %.4f | %.3f | %.4f |\n", budget, a->method, a->samples,
                a->radius_units, a->blur ? "yes" : "no", mean_time(a), mean_err(a), mean_base(a), mean_skill(a),
                a->raw_sum / a->n);
    }
    /* the best point of each technique within the largest budget, for the grid: its best
     * informative configuration, else (marked) its best of all */
    double big = 0.0;
    for (int b = 0; b < s->budgets.n; b++)
        big = atof(s->budgets.v[b]) > big ? atof(s->budgets.v[b]) : big;
    fprintf(md, "\n## Each technique at its best within %g ms\n\nIts best informative configuration; † when it has "
                "none, then its best of all (not ranked).\n\n| technique | samples | radius (units) | blur | time (ms) "
                "| calibrated RMSE | flat baseline | skill | raw RMSE |\n|---|---|---|---|---|---|---|---|---|\n", big);
    for (int mi = 0; mi < s->methods.n && nbest < 16; mi++) {
        int best = best_within(ag, na, big, s->methods.v[mi], 1);
        if (best < 0)
            best = best_within(ag, na, big, s->methods.v[mi], 0);
        if (best < 0) {
            fprintf(md, "| %s | — | — | — | over budget | | | | |\n", s->methods.v[mi]);
            continue;
        }
        const agg *a = &ag[best];
        fprintf(md, "| %s%s | %d | %g | %s | %.2f | %.4f | %.4f | %.3f | %.4f |\n", a->method, mark(a), a->samples,
                a->radius_units, a->blur ? "yes" : "no", mean_time(a), mean_err(a), mean_base(a), mean_skill(a),
                a->raw_sum / a->n);
        best_rows[nbest++] = (grid_row){ao_method_find(a->method), a->samples, a->blur, a->radius_units};
    }

    /* ---- tables in the seed's layout: time (and error) for samples x radius per technique ---- */
    fprintf(md, "\n## Time and error for samples × radius (the seed's Tables 15, 18, 22, 23), %dx%d, no blur\n\n"
                "Each cell: median total ms / calibrated RMSE (skill), mean over scenes and views; † not informative "
                "(skill not above %g), ° fit at its power bound in some point.\n", MW, MH, STUDY_SKILL_MIN);
    for (int mi = 0; mi < s->methods.n; mi++) {
        fprintf(md, "\n**%s**\n\n| samples \\ radius |", s->methods.v[mi]);
        for (int q = 0; q < s->radii.n; q++)
            fprintf(md, " %s |", s->radii.v[q]);
        fprintf(md, "\n|---|");
        for (int q = 0; q < s->radii.n; q++)
            fprintf(md, "---|");
        fprintf(md, "\n");
        for (int n = 0; n < s->samples.n; n++) {
            fprintf(md, "| %s |", s->samples.v[n]);
            for (int q = 0; q < s->radii.n; q++) {
                int k = 0;
                while (k < na && !(!strcmp(ag[k].method, s->methods.v[mi]) && ag[k].samples == atoi(s->samples.v[n]) &&
                                   ag[k].radius_units == atof(s->radii.v[q]) && ag[k].blur == 0))
                    k++;
                if (k < na)
                    fprintf(md, " %.2f / %.4f (%.2f)%s |", mean_time(&ag[k]), mean_err(&ag[k]), mean_skill(&ag[k]),
                            mark(&ag[k]));
                else
                    fprintf(md, " — |");
            }
            fprintf(md, "\n");
        }
    }
    /* ---- time at each resolution (the seed's Table 26) ---- */
    fprintf(md, "\n## Time at each resolution (the seed's Table 26)\n\nMedian total ms / calibrated RMSE (skill) at "
                "samples %s, radius %s, no blur, mean over scenes and views; † not informative.\n\n| technique |",
            s->samples.v[s->samples.n > 1 ? 1 : 0],
            s->radii.v[s->radii.n > 1 ? 1 : 0]);
    for (int r = 0; r < s->resolutions.n; r++)
        fprintf(md, " %s |", s->resolutions.v[r]);
    fprintf(md, "\n|---|");
    for (int r = 0; r < s->resolutions.n; r++)
        fprintf(md, "---|");
    fprintf(md, "\n");
    for (int mi = 0; mi < s->methods.n; mi++) {
        fprintf(md, "| %s |", s->methods.v[mi]);
        for (int r = 0; r < s->resolutions.n; r++) {
            int w, h;
            study_ao_i_parse_size(s->resolutions.v[r], &w, &h);
            agg *ar = (agg *)calloc(4096, sizeof(agg));
            int nr = ar ? aggregate(t, w, h, NULL, ar, 4096) : 0;
            int k = 0;
            while (k < nr && !(!strcmp(ar[k].method, s->methods.v[mi]) &&
                               ar[k].samples == atoi(s->samples.v[s->samples.n > 1 ? 1 : 0]) &&
                               ar[k].radius_units == atof(s->radii.v[s->radii.n > 1 ? 1 : 0]) && ar[k].blur == 0))
                k++;
            if (k < nr)
                fprintf(md, " %.2f / %.4f (%.2f)%s |", mean_time(&ar[k]), mean_err(&ar[k]), mean_skill(&ar[k]),
                        mark(&ar[k]));
            else
                fprintf(md, " — |");
            free(ar);
        }
        fprintf(md, "\n");
    }
    /* ---- where each technique fails: its worst scene and view ---- */
    fprintf(md, "\n## Where each technique is worst\n\nThe scene and view with the largest calibrated RMSE at %dx%d "
                "(over all its points there), with the flat baseline and the skill of that point († not informative) "
                "and its raw bias there (negative: darker than the ground truth).\n\n"
                "| technique | worst scene / view | calibrated RMSE | flat baseline | skill | raw bias |\n"
                "|---|---|---|---|---|---|\n", MW, MH);
    int nhard = 0;
    for (int mi = 0; mi < s->methods.n; mi++) {
        double worst = -1.0, wb = NAN, wbase = NAN, wskill = NAN;
        int wbound = 0;
        const char *wsn = "—", *wvn = "";
        for (int64_t r = 0; r < t->rows; r++) {
            if (strcmp(study_table_get(t, r, col(t, "method")), s->methods.v[mi]) != 0 ||
                strcmp(study_table_get(t, r, col(t, "status")), "ok") != 0 ||
                study_table_num(t, r, col(t, "width")) != MW)
                continue;
            double e = study_table_num(t, r, col(t, "cal_rmse_nc"));
            if (e > worst) {
                worst = e;
                wb = study_table_num(t, r, col(t, "bias"));
                wbase = study_table_num(t, r, col(t, "baseline_rmse_nc"));
                wskill = study_table_num(t, r, col(t, "cal_skill_nc"));
                wbound = row_at_bound(t, r);
                wsn = study_table_get(t, r, col(t, "scene"));
                wvn = study_table_get(t, r, col(t, "view"));
            }
        }
        /* the skill rule where the table has the skill, else the bound as its stand-in */
        const int uninformative = wskill == wskill ? !study_score_informative(wskill) : wbound;
        fprintf(md, "| %s | %s / %s | %.4f | %.4f | %.3f%s | %.4f |\n", s->methods.v[mi], wsn, wvn, worst, wbase, wskill,
                uninformative ? "†" : wbound ? "°" : "", wb);
        if (worst >= 0.0)
            fprintf(sum, "%s %s on %s/%s (calibrated RMSE %.3f, skill %.2f%s, %s by %.3f)", nhard++ ? ";" : "- **Hard "
                    "cases** (each technique's worst scene and view at the main resolution, over all its points):",
                    s->methods.v[mi], wsn, wvn, worst, wskill, uninformative ? ", not informative" : "",
                    wb < 0.0 ? "too dark" : "too light", fabs(wb));
    }
    if (nhard)
        fprintf(sum, ".\n");
    free(ag);
    /* ---- image grids ---- */
    obs_status st = OBS_STATUS_OK;
    if (nbest > 0) {
        fprintf(md, "\n## Image grids\n\nEach row: the technique at its best point within %g ms (table above), the "
                    "matched ground truth, and |AO − ground truth| as a heat map from 0 (black) to 0.5 (yellow), "
                    "inferno colour map. The images label themselves: the column titles and the heat map's scale "
                    "across the top, and above each row the technique, its samples, radius (metres) and blur, "
                    "with that point's time, calibrated RMSE and skill in the scene's first view at %dx%d "
                    "(from the table).\n\n", big, MW, MH);
        for (int sc = 0; sc < s->scenes.n && st == OBS_STATUS_OK; sc++) {
            char file[256];
            snprintf(file, sizeof file, "grid_%s.png", s->scenes.v[sc]);
            snprintf(path, sizeof path, "%s/%s", s->o.report_dir, file);
            /* grids at a reduced size (480 wide) so the page stays light */
            int GW = MW > 480 ? 480 : MW, GH = (int)lround((double)MH * GW / MW);
            st = write_grid(ctx, pool, s, s->scenes.v[sc], s->views.v[0], GW, GH, MW, MH, best_rows, nbest, path);
            fprintf(md, "**%s** (%s view, %dx%d; rows:", s->scenes.v[sc], s->views.v[0], GW, GH);
            for (int i = 0; i < nbest; i++)
                fprintf(md, " %s%s", best_rows[i].m->name, i + 1 < nbest ? "," : ")");
            fprintf(md, "\n\n![grid %s](%s)\n\n", s->scenes.v[sc], file);
        }
    }
    int has_mssao = 0;
    for (int mi = 0; mi < s->methods.n; mi++)
        has_mssao |= !strcmp(s->methods.v[mi], "mssao");
    if (st == OBS_STATUS_OK && has_mssao)
        st = mssao_levels_table(ctx, pool, s, MW, MH, md);
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

