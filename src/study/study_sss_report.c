/* study_sss_report.c: the SSS study's report (study_sss_report; docs/study.md, "Subsurface
 * scattering"): error-versus-time plots with the Pareto front, the seed's table layouts with the
 * theses' GPU timings beside ours, the Pareto points, the missing references with their reasons,
 * labelled image grids, and the estimated cost of the full study. From the table alone, except the
 * grids, which run their point once more (and read the cached references). */
#include "study_sss_internal.h"
#include "../core/obs_font.h"
#include "../io/io.h"
#include "../metrics/metrics.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- the table's rows ----------------------------------------------------------------------------- */

typedef struct prow {
    const char *scene, *light, *sampler;
    int W, H, K, N, S;
    double rebuilt, fixed, maps, lightmaps, combine, gbuffer, evals;
    double err[2], ratio[2], ref_seconds[2], ref_pixels[2], ref_mean[2], ref_noise[2];
    int ok;
} prow;

static double num(const study_table *t, int64_t r, const char *c) { return study_table_num(t, r, study_table_column(t, c)); }
static const char *str(const study_table *t, int64_t r, const char *c) { return study_table_get(t, r, study_table_column(t, c)); }

static prow *read_rows(const study_table *t, int *n)
{
    prow *p = (prow *)calloc((size_t)(t->rows ? t->rows : 1), sizeof *p);
    if (!p)
        return NULL;
    for (int64_t r = 0; r < t->rows; r++) {
        prow *q = &p[r];
        q->scene = str(t, r, "scene");
        q->light = str(t, r, "light");
        q->sampler = str(t, r, "sampler");
        q->W = (int)num(t, r, "width");
        q->H = (int)num(t, r, "height");
        q->K = (int)num(t, r, "K");
        q->N = (int)num(t, r, "N");
        q->S = (int)num(t, r, "map_size");
        q->ok = !strcmp(str(t, r, "status"), "ok");
        q->rebuilt = num(t, r, "rebuilt_ms");
        q->fixed = num(t, r, "fixed_ms");
        q->maps = num(t, r, "maps_ms");
        q->lightmaps = num(t, r, "lightmaps_ms");
        q->combine = num(t, r, "combine_ms");
        q->gbuffer = num(t, r, "camera_gbuffer_ms");
        q->evals = num(t, r, "disk_candidates");
        q->err[0] = num(t, r, "bf_rel_rmse_nc");
        q->err[1] = num(t, r, "rw_rel_rmse_nc");
        q->ratio[0] = num(t, r, "bf_mean_ratio");
        q->ratio[1] = num(t, r, "rw_mean_ratio");
        q->ref_seconds[0] = num(t, r, "bf_seconds");
        q->ref_seconds[1] = num(t, r, "rw_seconds");
        q->ref_pixels[0] = num(t, r, "bf_pixels");
        q->ref_pixels[1] = num(t, r, "rw_pixels");
        q->ref_mean[0] = num(t, r, "bf_mean");
        q->ref_mean[1] = num(t, r, "rw_mean");
        q->ref_noise[0] = num(t, r, "bf_noise_rms");
        q->ref_noise[1] = num(t, r, "rw_noise_rms");
    }
    *n = (int)t->rows;
    return p;
}

/* The tables and grids show the first sampler of the axis. */
static const char *main_sampler = "";

static const prow *find(const prow *p, int n, const char *scene, const char *light, int W, int H, int K, int N, int S)
{
    for (int i = 0; i < n; i++)
        if (p[i].ok && !strcmp(p[i].sampler, main_sampler) && !strcmp(p[i].scene, scene) && !strcmp(p[i].light, light) && p[i].W == W && p[i].H == H &&
            p[i].K == K && p[i].N == N && p[i].S == S)
            return &p[i];
    return NULL;
}

/* The value of an axis the tables and grids hold fixed: the one with the most measured points at
 * W x H (which: 0 K, 1 N, 2 map size), ties going to the one nearest the preferred value (the
 * thesis' K 16, N 48 ~ 50, maps 512). On the full grid every value has as many points, so the
 * preferred one is chosen; on a reduced study, the best-measured one. */
static int pick(const study_axis *a, int preferred, const prow *rows, int n, int W, int H, int which)
{
    int best = atoi(a->v[0]), best_count = -1;
    for (int i = 0; i < a->n; i++) {
        const int v = atoi(a->v[i]);
        int count = 0;
        for (int r = 0; r < n; r++)
            count += rows[r].ok && rows[r].W == W && rows[r].H == H &&
                     (which == 0 ? rows[r].K : which == 1 ? rows[r].N : rows[r].S) == v;
        if (count > best_count || (count == best_count && abs(v - preferred) < abs(best - preferred))) {
            best = v;
            best_count = count;
        }
    }
    return best;
}

static void cell(char *buf, size_t size, const prow *q)
{
    if (!q) {
        snprintf(buf, size, "—");
        return;
    }
    char e0[32] = "–", e1[32] = "–";
    if (!isnan(q->err[0]))
        snprintf(e0, sizeof e0, "%.3g", q->err[0]);
    if (!isnan(q->err[1]))
        snprintf(e1, sizeof e1, "%.3g", q->err[1]);
    snprintf(buf, size, "%.0f ms (%s / %s)", q->rebuilt, e0, e1);
}

/* ---- the theses' timings (docs/study.md, "SSS: the seed's tables") ------------------------------- */

/* [DalCorso14] (the precursor thesis, GTX 780 Ti, OpenGL 4.3, potato, 1 light, W_s = W_l = 512,
 * M = 1000; ../shared/reference/sss.md 3.8): per frame, ms. */
static const struct {
    const char *model, *ours;
    double ms[4];                   /* N = 1, 10, 50, 100 at K = 16 */
} thesis_n[] = {
    {"Bunny (21,474 triangles)", "bunny_cream", {2.1, 5.3, 19.8, 38.2}},
    {"Dragon (300k)", "dragon_skin", {12.5, 35.2, 140.6, 275.3}},
    {"Buddha (3.26M)", NULL, {96.7, 97.7, 128.0, 216.0}},
};
static const double thesis_k[4] = {6.6, 10.0, 20.1, 42.1};     /* Bunny, N = 50, K = 4, 8, 16, 32 */
static const double thesis_s[3] = {75.4, 142.1, 299.4};        /* Dragon, K = 16, N = 50, W_s = 256, 512, 1024 */
/* The seed's Table 5.3 (GTX 660, cream, g = 0, r = 0.025, samples 12 / 24 / 48 for 4 / 8 / 16
 * cameras): scene changed (maps rebuilt) and fixed scene (maps reused), ms. */
static const struct {
    const char *model, *ours;
    double rebuilt[3], fixed[3];
} seed_53[] = {
    {"Stanford Bunny", "bunny_cream", {117.80, 246.60, 543.48}, {0.90, 1.36, 2.39}},
    {"Stanford Dragon", "dragon_skin", {135.69, 266.66, 584.79}, {1.03, 1.98, 3.28}},
    {"Hebe statue", NULL, {157.23, 320.51, 729.92}, {1.44, 1.59, 2.41}},
    {"Stanford Buddha", NULL, {102.77, 206.61, 444.44}, {1.44, 1.64, 2.14}},
    {"standard sphere", "sphere_potato", {24.81, 50.13, 102.04}, {0.89, 0.97, 1.07}},
};

/* ---- image grids ----------------------------------------------------------------------------------- */

#define GRID_COLS 5
#define GRID_ERR_MAX 1.0 /* |Y_ours - Y_ref| / mean(Y_ref) at the top of the heat map (ours) */
static const char *const grid_titles[GRID_COLS] = {"ours (maps)", "brute force", "random walk", "|ours-BF|/mean",
                                                   "|ours-RW|/mean"};
static const float band[3] = {0.85f, 0.85f, 0.85f}, ink[3] = {0.0f, 0.0f, 0.0f}, grey[3] = {0.3f, 0.3f, 0.3f},
                   white[3] = {1.0f, 1.0f, 1.0f};

static float srgb_decode(float v) { return v <= 0.04045f ? v / 12.92f : powf((v + 0.055f) / 1.055f, 2.4f); }
static double lum3(const obs_image_f32 *p, int x, int y)
{
    return 0.2126 * obs_image_f32_row(&p[0], y)[x] + 0.7152 * obs_image_f32_row(&p[1], y)[x] +
           0.0722 * obs_image_f32_row(&p[2], y)[x];
}
static int cmpd(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

typedef struct grid_row {
    char label[256];
    obs_image_f32 ours[3];
    study_sss_i_ref ref[2];
} grid_row;

/* Draw row i's cells: radiance cells scaled by `expo` (linear), heat cells |Y - Y_ref| / mean. */
static void draw_row(obs_image_f32 *rgb, const grid_row *r, int x0, int y0, int cw, int ch, int d, int gap)
{
    const obs_image_f32 *mask = !r->ref[0].missing ? &r->ref[0].count : &r->ref[1].count;
    const int W = r->ours[0].width, H = r->ours[0].height;
    /* the exposure: the 99th percentile of the reference's luminance maps to 0.8 */
    double *v = (double *)malloc(sizeof(double) * (size_t)W * H);
    int n = 0;
    const obs_image_f32 *base = !r->ref[0].missing ? r->ref[0].rgb : !r->ref[1].missing ? r->ref[1].rgb : r->ours;
    double mean[2] = {0, 0};
    int mn[2] = {0, 0};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (obs_image_f32_row(mask, y)[x] > 0.0f) {
                if (v)
                    v[n++] = lum3(base, x, y);
                for (int e = 0; e < 2; e++)
                    if (!r->ref[e].missing) {
                        mean[e] += lum3(r->ref[e].rgb, x, y);
                        mn[e]++;
                    }
            }
    double p99 = 1.0;
    if (v && n) {
        qsort(v, (size_t)n, sizeof *v, cmpd);
        p99 = v[(int)(0.99 * (n - 1))];
    }
    free(v);
    const double expo = p99 > 0.0 ? 0.8 / p99 : 1.0;
    for (int e = 0; e < 2; e++)
        mean[e] = mn[e] ? mean[e] / mn[e] : 0.0;
    for (int c = 0; c < GRID_COLS; c++) {
        const int cx = x0 + c * (cw + gap);
        const int e = c == 1 || c == 3 ? 0 : 1;
        if (c > 0 && r->ref[e].missing) {
            obs_font_fill_rect(rgb, 3, cx, y0, cw, ch, grey);
            char text[600];
            snprintf(text, sizeof text, "missing: %s", r->ref[e].reason);
            const int per = cw / OBS_FONT_GLYPH_W - 1;
            const size_t len = strlen(text);
            for (int line = 0; line * per < (int)len && line < ch / 10 - 1; line++) {
                char part[128];
                snprintf(part, sizeof part, "%.*s", per < 127 ? per : 127, text + line * per);
                obs_font_draw(rgb, 3, cx + 4, y0 + 4 + 10 * line, 1, white, part);
            }
            continue;
        }
        for (int y = 0; y < ch; y++)
            for (int x = 0; x < cw; x++) {
                double acc[3] = {0, 0, 0};
                for (int j = 0; j < d; j++)
                    for (int i = 0; i < d; i++) {
                        const int sx = x * d + i, sy = y * d + j;
                        if (sx >= W || sy >= H)
                            continue;
                        if (c < 3) {
                            const obs_image_f32 *im = c == 0 ? r->ours : r->ref[c - 1].rgb;
                            for (int k = 0; k < 3; k++)
                                acc[k] += expo * obs_image_f32_row(&im[k], sy)[sx];
                        } else {
                            float heat[3];
                            double t = 0.0;
                            if (obs_image_f32_row(mask, sy)[sx] > 0.0f && mean[e] > 0.0)
                                t = fabs(lum3(r->ours, sx, sy) - lum3(r->ref[e].rgb, sx, sy)) / mean[e] / GRID_ERR_MAX;
                            met_colormap_inferno(t, heat);
                            for (int k = 0; k < 3; k++)
                                acc[k] += srgb_decode(heat[k]);
                        }
                    }
                for (int k = 0; k < 3; k++)
                    obs_image_f32_row(&rgb[k], y0 + y)[cx + x] = (float)(acc[k] / (d * d));
            }
    }
}

static obs_status write_grid(obs_context *ctx, obs_pool *pool, const study_sss *s, const prow *rows, int nrows,
                             const char *scene, int W, int H, FILE *md)
{
    grid_row gr[2];
    memset(gr, 0, sizeof gr);
    int ng = 0;
    obs_status st = OBS_STATUS_OK;
    const int Kp = pick(&s->Ks, 16, rows, nrows, W, H, 0), Np = pick(&s->Ns, 48, rows, nrows, W, H, 1),
              Sp = pick(&s->map_sizes, 512, rows, nrows, W, H, 2);
    for (int li = 0; li < s->lights.n && ng < 2 && st == OBS_STATUS_OK; li++) {
        const char *light = s->lights.v[li];
        const prow *q = find(rows, nrows, scene, light, W, H, Kp, Np, Sp);
        for (int i = 0; !q && i < nrows; i++) /* else its first measured point */
            if (rows[i].ok && !strcmp(rows[i].sampler, main_sampler) && !strcmp(rows[i].scene, scene) &&
                !strcmp(rows[i].light, light) && rows[i].W == W && rows[i].H == H)
                q = &rows[i];
        if (!q)
            continue;
        study_sss_i_frame f;
        st = study_sss_i_frame_render(ctx, pool, s, scene, light, W, H, &f);
        for (int e = 0; e < 2 && st == OBS_STATUS_OK; e++)
            st = study_sss_i_ref_get(ctx, pool, s, scene, light, &f, (truth_sss_estimator)e, &gr[ng].ref[e]);
        study_sss_i_times t;
        sss_sampler smp = SSS_SAMPLER_RUSSIAN_ROULETTE;
        sss_sampler_from_name(q->sampler, &smp);
        const sss_params p = study_sss_map_params(smp, q->K, q->N, q->S);
        if (st == OBS_STATUS_OK)
            st = study_sss_i_run_point(ctx, pool, &f, &p, 1, gr[ng].ours, &t);
        study_sss_i_frame_free(&f);
        char e0[32] = "-", e1[32] = "-";
        if (!isnan(q->err[0]))
            snprintf(e0, sizeof e0, "%.2f", q->err[0]);
        if (!isnan(q->err[1]))
            snprintf(e1, sizeof e1, "%.2f", q->err[1]);
        snprintf(gr[ng].label, sizeof gr[ng].label, "%s %s K%d N%d S%d: %.0f ms, rel.RMSE BF %s RW %s", scene,
                 light, q->K, q->N, q->S, q->rebuilt, e0, e1);
        ng++;
    }
    const int d = (W + 239) / 240, cw = (W + d - 1) / d, chh = (H + d - 1) / d, gap = 4, title_h = 34, label_h = 14;
    const int GW = GRID_COLS * cw + (GRID_COLS - 1) * gap, GH = title_h + ng * (label_h + chh + gap);
    obs_image_f32 rgb[3] = {{0}};
    for (int k = 0; k < 3 && st == OBS_STATUS_OK && ng; k++)
        st = obs_image_f32_alloc(ctx, GW, GH, &rgb[k]);
    if (st == OBS_STATUS_OK && ng) {
        obs_font_fill_rect(rgb, 3, 0, 0, GW, GH, white);
        obs_font_fill_rect(rgb, 3, 0, 0, GW, title_h, band);
        for (int c = 0; c < GRID_COLS; c++) {
            const int x = c * (cw + gap) + 2;
            obs_font_draw(rgb, 3, x, 2, 1, ink, grid_titles[c]);
            if (c < 3)
                continue;
            const int bw = cw - 24;
            for (int i = 0; i < bw; i++) {
                float heat[3], lin[3];
                met_colormap_inferno((i + 0.5) / bw, heat);
                for (int k = 0; k < 3; k++)
                    lin[k] = srgb_decode(heat[k]);
                obs_font_fill_rect(rgb, 3, x + 8 + i, 13, 1, 8, lin);
            }
            obs_font_draw(rgb, 3, x, 13, 1, ink, "0");
            obs_font_draw(rgb, 3, x + 8 + bw, 13, 1, ink, "1");
            obs_font_draw(rgb, 3, x, 23, 1, ink, "x mean lum.");
        }
        for (int i = 0; i < ng; i++) {
            const int y = title_h + i * (label_h + chh + gap);
            obs_font_fill_rect(rgb, 3, 0, y, GW, label_h, band);
            obs_font_draw(rgb, 3, 2, y + 3, 1, ink, gr[i].label);
            draw_row(rgb, &gr[i], 0, y + label_h, cw, chh, d, gap);
        }
        char path[4400];
        snprintf(path, sizeof path, "%s/grid_%s.png", s->o.report_dir, scene);
        st = io_png_write(ctx, path, rgb, 3, IO_PNG_SRGB);
        if (st == OBS_STATUS_OK)
            fprintf(md, "![%s](grid_%s.png)\n\n", scene, scene);
    }
    for (int k = 0; k < 3; k++)
        obs_image_f32_free(&rgb[k]);
    for (int i = 0; i < 2; i++) {
        for (int k = 0; k < 3; k++)
            obs_image_f32_free(&gr[i].ours[k]);
        study_sss_i_ref_free(&gr[i].ref[0]);
        study_sss_i_ref_free(&gr[i].ref[1]);
    }
    return st;
}

/* ---- plots ----------------------------------------------------------------------------------------- */

static obs_status write_plot(obs_context *ctx, const study_sss *s, const prow *rows, int n, int e, int fixed_time,
                             const char *only_scene, const char *file, const char *title)
{
    enum { MAXS = 16 };
    double *x = (double *)calloc((size_t)(n ? n : 1), sizeof(double) * 2 * MAXS);
    if (!x)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    study_series ser[MAXS];
    char names[MAXS][96];
    int ns = 0;
    for (int si = 0; si < s->scenes.n; si++)
        for (int li = 0; li < s->lights.n; li++)
        for (int ai = 0; ai < s->samplers.n && ns < MAXS; ai++) {
            if (only_scene && strcmp(only_scene, s->scenes.v[si]))
                continue;
            double *xs = x + (size_t)ns * 2 * n, *ys = xs + n;
            int m = 0;
            for (int i = 0; i < n; i++)
                if (rows[i].ok && !strcmp(rows[i].scene, s->scenes.v[si]) && !strcmp(rows[i].light, s->lights.v[li]) &&
                    !strcmp(rows[i].sampler, s->samplers.v[ai])) {
                    xs[m] = fixed_time ? rows[i].fixed : rows[i].rebuilt;
                    ys[m] = rows[i].err[e];
                    m++;
                }
            if (!m)
                continue;
            if (s->samplers.n > 1)
                snprintf(names[ns], sizeof names[ns], "%.40s, %.8s, %.30s", s->scenes.v[si], s->lights.v[li],
                         s->samplers.v[ai]);
            else
                snprintf(names[ns], sizeof names[ns], "%.40s, %.8s", s->scenes.v[si], s->lights.v[li]);
            ser[ns] = (study_series){names[ns], xs, ys, m};
            ns++;
        }
    obs_status st = OBS_STATUS_OK;
    if (ns) {
        study_plot p;
        memset(&p, 0, sizeof p);
        p.title = title;
        p.x_label = "time per frame, maps rebuilt: light G-buffers + maps + camera G-buffer + combination (ms)";
        p.y_label = e == 0 ? "relative RMSE of luminance vs brute force (noise-corrected)"
                           : "relative RMSE of luminance vs random walk (noise-corrected)";
        p.log_x = 1;
        p.log_y = 1;
        p.pareto = 1;
        char path[4400];
        snprintf(path, sizeof path, "%s/%s", s->o.report_dir, file);
        st = study_svg_scatter(ctx, path, &p, ser, ns);
    }
    free(x);
    return st;
}

/* ---- the report ------------------------------------------------------------------------------------ */

/* The full study's cost from this table's measured costs: per disk candidate (maps_ms over the
 * candidates drawn), the covered share of a map (candidates over K N S^2), the other passes'
 * means, and the references' time per pixel and candidate. */
static void full_cost(const study_sss *s, const prow *rows, int n, double *sweep_min, double *ref_min)
{
    double ms_per_eval = 0, cover = 0, other = 0, ref_ns[2] = {0, 0};
    int ne = 0, nr[2] = {0, 0};
    for (int i = 0; i < n; i++) {
        if (!rows[i].ok || !(rows[i].evals > 0))
            continue;
        ms_per_eval += rows[i].maps / rows[i].evals;
        cover += rows[i].evals / ((double)rows[i].K * rows[i].N * rows[i].S * rows[i].S);
        other += rows[i].lightmaps + rows[i].gbuffer + rows[i].combine;
        ne++;
        for (int e = 0; e < 2; e++)
            if (rows[i].ref_seconds[e] > 0 && rows[i].ref_pixels[e] > 0) {
                ref_ns[e] += 1e9 * rows[i].ref_seconds[e] / (rows[i].ref_pixels[e] * (double)s->o.ref_samples);
                nr[e]++;
            }
    }
    *sweep_min = *ref_min = NAN;
    if (!ne)
        return;
    ms_per_eval /= ne;
    cover /= ne;
    other /= ne;
    const study_sss_options d = study_sss_options_default();
    static const int Ks[4] = {4, 8, 16, 32}, Ns[3] = {16, 48, 128}, Ss[3] = {256, 512, 1024};
    double ms = 0;
    for (int k = 0; k < 4; k++)
        for (int nn = 0; nn < 3; nn++)
            for (int q = 0; q < 3; q++)
                ms += ms_per_eval * Ks[k] * Ns[nn] * cover * Ss[q] * Ss[q] + other;
    for (int i = 0; i < 2; i++) /* the seed's points outside the grid (K 16, N 48, 512 is in it) */
        ms += ms_per_eval * (4 << i) * (12 << i) * cover * 512.0 * 512.0 + other;
    *sweep_min = 8.0 * ms * d.runs / 60000.0; /* 4 scenes x 2 lights */
    /* references: a quarter of 320x240 translucent (the models fill about that), both estimators */
    double ref = 0;
    for (int e = 0; e < 2; e++)
        if (nr[e])
            ref += ref_ns[e] / nr[e] * 1e-9 * 0.25 * 320 * 240 * (double)d.ref_samples;
    *ref_min = 8.0 * ref / 60.0;
}

obs_status study_sss_report(obs_context *ctx, obs_pool *pool, study_sss *s)
{
    if (!s->o.report_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study sss: no report directory");
    obs_status st = io_make_dirs(ctx, s->o.report_dir);
    if (st != OBS_STATUS_OK)
        return st;
    int n = 0;
    prow *rows = read_rows(&s->table, &n);
    if (!rows)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
    char path[4400];
    snprintf(path, sizeof path, "%s/results.csv", s->o.report_dir);
    st = study_table_write_csv(ctx, &s->table, path);
    snprintf(path, sizeof path, "%s/README.md", s->o.report_dir);
    char tmp[4500];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *md = st == OBS_STATUS_OK ? fopen(tmp, "w") : NULL;
    if (st == OBS_STATUS_OK && !md)
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write %s", tmp);
    if (st != OBS_STATUS_OK) {
        free(rows);
        return st;
    }
    int W = 0, H = 0;
    obs_parse_size(s->resolutions.v[0], RAST_MAX_DIM, &W, &H);
    main_sampler = s->samplers.v[0];
    const char *front = s->lights.v[0];
    int nok = 0;
    for (int i = 0; i < n; i++)
        nok += rows[i].ok;
    double full_sweep, full_ref;
    full_cost(s, rows, n, &full_sweep, &full_ref);
    char date[32] = "";
    time_t now = time(NULL);
    strftime(date, sizeof date, "%Y-%m-%d", gmtime(&now));

    fprintf(md, "# Subsurface scattering study: scattering maps, time against error\n\n");
    fprintf(md, "Generated by `obscura study sss` (src/study/study_sss_report.c; docs/study.md, \"Subsurface "
                "scattering\") on %s from %d points (%d measured) in [`results.csv`](results.csv)%s.\n\n",
            date, n, nok, s->o.quick ? ", with the --quick options" : "");
    fprintf(md, "> **Timings are noisy.** They were measured on a shared 2-core development machine while other "
                "jobs ran (builds, tests), with %d run(s) per point; read them as an order of magnitude, and "
                "compare within this report only. Regenerate the full study on an idle machine with:\n>\n"
                "> ```sh\n> build/obscura study sss -o out/study-sss --report docs/results/sss\n> ```\n>\n",
            s->o.runs);
    if (!isnan(full_sweep))
        fprintf(md, "> Estimated from this table's measured per-point costs: the sweep about %.0f min (%d points, "
                    "3 runs each), the references about %.0f min more (first run; cached after).\n\n",
                full_sweep, 8 * 38, full_ref);
    else
        fprintf(md, "\n");
    fprintf(md, "docs/study.md (\"Subsurface scattering\") gives the commands that made this table, what each column "
                "means, and how the references are cached.\n\n");
    fprintf(md, "The axes asked for: scenes %s; lights %s; resolutions %s; samplers %s (the tables and images show the "
                "first); K %s; N %s; map sizes %s; %lld reference candidates per pixel%s (— marks a point not "
                "measured). Time is per frame in ms (median of the runs); errors are the relative "
                "RMSE of the luminance on the translucent pixels (RMSE over the reference's mean luminance) with "
                "the reference's own noise taken out, against the brute-force BSSRDF integral (**BF**: the "
                "method's error, the same directional dipole) and the volumetric random walk (**RW**: the model's "
                "error). Cells read `time (BF error / RW error)`; – is a missing reference.\n\n",
            s->o.scenes, s->o.lights, s->o.resolutions, s->o.samplers, s->o.Ks, s->o.Ns, s->o.map_sizes, s->o.ref_samples,
            s->o.seed_points ? ", plus the seed's Table 5.3 points" : "");

    /* plots */
    if (st == OBS_STATUS_OK)
        st = write_plot(ctx, s, rows, n, 0, 0, NULL, "error_bf.svg",
                        "SSS: error against the brute-force BSSRDF (the method's)");
    if (st == OBS_STATUS_OK)
        st = write_plot(ctx, s, rows, n, 1, 0, NULL, "error_rw.svg", "SSS: error against the random walk (the model's)");
    fprintf(md, "## Error against time\n\nThe dashed staircase is the Pareto front of the plot's points. All "
                "scenes:\n\n![error against the brute force](error_bf.svg)\n\n![error against the random walk]"
                "(error_rw.svg)\n\nPer scene (brute force, random walk):\n\n");
    for (int si = 0; si < s->scenes.n && st == OBS_STATUS_OK; si++) {
        char f0[256], f1[256], t0[256], t1[256];
        snprintf(f0, sizeof f0, "error_bf_%.200s.svg", s->scenes.v[si]);
        snprintf(f1, sizeof f1, "error_rw_%.200s.svg", s->scenes.v[si]);
        snprintf(t0, sizeof t0, "%.200s: error against the brute force", s->scenes.v[si]);
        snprintf(t1, sizeof t1, "%.200s: error against the random walk", s->scenes.v[si]);
        st = write_plot(ctx, s, rows, n, 0, 0, s->scenes.v[si], f0, t0);
        if (st == OBS_STATUS_OK)
            st = write_plot(ctx, s, rows, n, 1, 0, s->scenes.v[si], f1, t1);
        fprintf(md, "![%s](%s) ![%s](%s)\n\n", t0, f0, t1, f1);
    }

    /* the Pareto front against each reference */
    for (int e = 0; e < 2 && st == OBS_STATUS_OK; e++) {
        double *c = (double *)malloc(sizeof(double) * (size_t)(n ? n : 1) * 2);
        unsigned char *on = (unsigned char *)calloc((size_t)(n ? n : 1), 1);
        if (!c || !on) {
            free(c);
            free(on);
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
            break;
        }
        for (int i = 0; i < n; i++) {
            c[i] = rows[i].ok ? rows[i].rebuilt : NAN;
            c[n + i] = rows[i].ok ? rows[i].err[e] : NAN;
        }
        const int nf = study_pareto_front(c, c + n, n, on);
        fprintf(md, "### Pareto front against the %s (%d points)\n\n| scene | light | sampler | K | N | map | time (ms) | "
                    "rel. RMSE | mean ratio |\n|---|---|---|---|---|---|---|---|---|\n",
                e ? "random walk" : "brute force", nf);
        for (int done = 0; done < nf; done++) { /* by increasing time */
            int i = -1;
            for (int j = 0; j < n; j++)
                if (on[j] == 1 && (i < 0 || c[j] < c[i]))
                    i = j;
            if (i < 0)
                break;
            on[i] = 2;
            fprintf(md, "| %s | %s | %s | %d | %d | %d | %.0f | %.3f | %.3f |\n", rows[i].scene, rows[i].light,
                    rows[i].sampler, rows[i].K, rows[i].N, rows[i].S, rows[i].rebuilt, rows[i].err[e], rows[i].ratio[e]);
        }
        fprintf(md, "\n");
        free(c);
        free(on);
    }

    /* missing references */
    fprintf(md, "## Missing references\n\n");
    int nmiss = 0;
    for (int64_t r = 0; r < s->table.rows; r++)
        for (int e = 0; e < 2; e++) {
            const char *stt = study_table_get(&s->table, r, study_table_column(&s->table, e ? "rw_status" : "bf_status"));
            if (strncmp(stt, "missing", 7))
                continue;
            int seen = 0;
            for (int64_t q = 0; q < r && !seen; q++)
                seen = !strcmp(study_table_get(&s->table, q, 0), study_table_get(&s->table, r, 0)) &&
                       !strcmp(study_table_get(&s->table, q, 1), study_table_get(&s->table, r, 1)) &&
                       !strcmp(study_table_get(&s->table, q, study_table_column(&s->table, e ? "rw_status" : "bf_status")),
                               stt);
            if (seen)
                continue;
            fprintf(md, "- %s, light %s, %s: %s\n", study_table_get(&s->table, r, 0), study_table_get(&s->table, r, 1),
                    e ? "random walk" : "brute force", stt);
            nmiss++;
        }
    fprintf(md, "%s\n", nmiss ? "" : "None: every point has both references.\n");

    /* the references themselves: their noise, and the model against the method */
    fprintf(md, "## The references\n\nPer scene and light (%dx%d): each reference's mean luminance on the "
                "translucent pixels, its per-pixel noise relative to that mean (s / mean, s the RMS of the "
                "replicate standard error of Y), the seconds it took, and mean(RW) / mean(BF): how much the "
                "directional dipole's light differs from radiative transfer in the mesh on average (the model's "
                "bias, independent of the maps).\n\n| scene | light | BF mean | BF s / mean | BF time (s) | RW mean | "
                "RW s / mean | RW time (s) | mean(RW) / mean(BF) |\n|---|---|---|---|---|---|---|---|---|\n",
            W, H);
    double worst_noise = 0.0;
    for (int si = 0; si < s->scenes.n; si++)
        for (int li = 0; li < s->lights.n; li++) {
            const prow *q = NULL;
            for (int i = 0; i < n && !q; i++)
                if (rows[i].ok && !strcmp(rows[i].scene, s->scenes.v[si]) && !strcmp(rows[i].light, s->lights.v[li]) &&
                    rows[i].W == W && rows[i].H == H)
                    q = &rows[i];
            if (!q)
                continue;
            char c[2][3][32];
            for (int e = 0; e < 2; e++) {
                snprintf(c[e][0], 32, "%.4g", q->ref_mean[e]);
                snprintf(c[e][1], 32, "%.2f", q->ref_noise[e] / q->ref_mean[e]);
                double sec = NAN;
                for (int i = 0; i < n; i++) /* the row that computed it */
                    if (!strcmp(rows[i].scene, q->scene) && !strcmp(rows[i].light, q->light) && rows[i].W == W &&
                        rows[i].H == H && rows[i].ref_seconds[e] > 0)
                        sec = rows[i].ref_seconds[e];
                snprintf(c[e][2], 32, isnan(sec) ? "–" : "%.0f", sec);
                if (isnan(q->ref_mean[e]))
                    snprintf(c[e][0], 32, "–"), snprintf(c[e][1], 32, "–");
                else if (q->ref_noise[e] / q->ref_mean[e] > worst_noise)
                    worst_noise = q->ref_noise[e] / q->ref_mean[e];
            }
            char ratio[32] = "–";
            if (!isnan(q->ref_mean[0]) && !isnan(q->ref_mean[1]))
                snprintf(ratio, sizeof ratio, "%.3f", q->ref_mean[1] / q->ref_mean[0]);
            fprintf(md, "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", q->scene, q->light, c[0][0], c[0][1],
                    c[0][2], c[1][0], c[1][1], c[1][2], ratio);
        }
    if (worst_noise > 0.5)
        fprintf(md, "\n**Read the errors with care.** A reference's per-pixel noise here is up to %.1f times its mean "
                    "luminance (%lld candidates per pixel): area sampling of the whole mesh with a roulette is "
                    "heavy-tailed when the mean free path is millimetres on a 30 cm object. The noise-corrected "
                    "RMSE takes the reference's noise out in expectation, but one run's value still varies by "
                    "large factors, and the maps' own Russian roulette is heavy-tailed too (rare accepted far "
                    "samples with weight 1/p). The ratio of means, averaged over thousands of pixels, is the "
                    "stabler number; the references need far more candidates (the noise falls as "
                    "1/sqrt(candidates)) for the per-pixel errors to mean much.\n",
                worst_noise, s->o.ref_samples);
    fprintf(md, "\n");

    /* the seed's table layouts */
    const int Kp = pick(&s->Ks, 16, rows, n, W, H, 0), Np = pick(&s->Ns, 48, rows, n, W, H, 1),
              Sp = pick(&s->map_sizes, 512, rows, n, W, H, 2);
    char b[128];
    fprintf(md, "## Time against N per model ([DalCorso14]'s layout)\n\nOurs: K = %d, maps %d, light %s, %dx%d, "
                "CPU (%d threads). Cells: `time (BF / RW)`.\n\n| model |",
            Kp, Sp, front, W, H, obs_pool_threads(pool));
    for (int i = 0; i < s->Ns.n; i++)
        fprintf(md, " N = %s |", s->Ns.v[i]);
    fprintf(md, "\n|---|");
    for (int i = 0; i < s->Ns.n; i++)
        fprintf(md, "---|");
    fprintf(md, "\n");
    for (int si = 0; si < s->scenes.n; si++) {
        fprintf(md, "| %s |", s->scenes.v[si]);
        for (int i = 0; i < s->Ns.n; i++) {
            cell(b, sizeof b, find(rows, n, s->scenes.v[si], front, W, H, Kp, atoi(s->Ns.v[i]), Sp));
            fprintf(md, " %s |", b);
        }
        fprintf(md, "\n");
    }
    fprintf(md, "\n[DalCorso14] (GTX 780 Ti, OpenGL 4.3, potato, K = 16, W_s = W_l = 512, M = 1000; "
                "../shared/reference/sss.md 3.8), ms:\n\n| model | ours | N = 1 | N = 10 | N = 50 | N = 100 |\n"
                "|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < sizeof thesis_n / sizeof thesis_n[0]; i++)
        fprintf(md, "| %s | %s | %.1f | %.1f | %.1f | %.1f |\n", thesis_n[i].model,
                thesis_n[i].ours ? thesis_n[i].ours : "—", thesis_n[i].ms[0], thesis_n[i].ms[1], thesis_n[i].ms[2],
                thesis_n[i].ms[3]);

    const char *kscene = s->scenes.v[0];
    for (int i = 0; i < s->scenes.n; i++)
        if (!strcmp(s->scenes.v[i], "bunny_cream"))
            kscene = s->scenes.v[i];
    fprintf(md, "\n## Time against K\n\nOurs: %s, N = %d, maps %d, light %s; [DalCorso14]: Bunny, N = 50, 512, "
                "GTX 780 Ti.\n\n| K | ours | [DalCorso14] (ms) |\n|---|---|---|\n",
            kscene, Np, Sp, front);
    for (int i = 0; i < s->Ks.n; i++) {
        const int K = atoi(s->Ks.v[i]);
        cell(b, sizeof b, find(rows, n, kscene, front, W, H, K, Np, Sp));
        const int ti = K == 4 ? 0 : K == 8 ? 1 : K == 16 ? 2 : K == 32 ? 3 : -1;
        char tv[32] = "—";
        if (ti >= 0)
            snprintf(tv, sizeof tv, "%.1f", thesis_k[ti]);
        fprintf(md, "| %d | %s | %s |\n", K, b, tv);
    }
    const char *sscene = s->scenes.v[0];
    for (int i = 0; i < s->scenes.n; i++)
        if (!strcmp(s->scenes.v[i], "dragon_skin"))
            sscene = s->scenes.v[i];
    fprintf(md, "\n## Time against map size\n\nOurs: %s, K = %d, N = %d, light %s; [DalCorso14]: Dragon, K = 16, "
                "N = 50, GTX 780 Ti.\n\n| map size | ours | maps pass only (ms) | [DalCorso14] (ms) |\n|---|---|---|---|\n",
            sscene, Kp, Np, front);
    for (int i = 0; i < s->map_sizes.n; i++) {
        const int S = atoi(s->map_sizes.v[i]);
        const prow *q = find(rows, n, sscene, front, W, H, Kp, Np, S);
        cell(b, sizeof b, q);
        const int ti = S == 256 ? 0 : S == 512 ? 1 : S == 1024 ? 2 : -1;
        char tv[32] = "—";
        if (ti >= 0)
            snprintf(tv, sizeof tv, "%.1f", thesis_s[ti]);
        char mv[32] = "—";
        if (q)
            snprintf(mv, sizeof mv, "%.0f", q->maps);
        fprintf(md, "| %d | %s | %s | %s |\n", S, b, mv, tv);
    }
    fprintf(md, "\n## The seed's Table 5.3 [Alvarez18]: scene changed against fixed scene\n\n"
                "Ours: K = 4, 8, 16 directions (\"cameras\") with N = 12, 24, 48 samples, maps 512, light %s, %dx%d, "
                "each scene with its own material (the seed used cream for all). *Rebuilt*: light G-buffers + maps + "
                "camera G-buffer + combination; *fixed*: camera G-buffer + combination (maps reused). The seed: GTX "
                "660, cream, g = 0, r = 0.025, \"M\" = 12 / 24 / 48 samples (our reading of the extracted text).\n\n"
                "| model | K | ours rebuilt (ms) | ours fixed (ms) | seed rebuilt (ms) | seed fixed (ms) |\n"
                "|---|---|---|---|---|---|\n",
            front, W, H);
    for (size_t m = 0; m < sizeof seed_53 / sizeof seed_53[0]; m++)
        for (int i = 0; i < 3; i++) {
            const prow *q = NULL;
            for (int si = 0; si < s->scenes.n && seed_53[m].ours; si++)
                if (!strcmp(s->scenes.v[si], seed_53[m].ours))
                    q = find(rows, n, seed_53[m].ours, front, W, H, 4 << i, 12 << i, 512);
            char r0[32] = "—", r1[32] = "—";
            if (q) {
                snprintf(r0, sizeof r0, "%.0f", q->rebuilt);
                snprintf(r1, sizeof r1, "%.1f", q->fixed);
            }
            fprintf(md, "| %s%s%s | %d | %s | %s | %.2f | %.2f |\n", seed_53[m].model, seed_53[m].ours ? " / " : "",
                    seed_53[m].ours ? seed_53[m].ours : "", 4 << i, r0, r1, seed_53[m].rebuilt[i], seed_53[m].fixed[i]);
        }

    /* the passes of the seed-like point */
    fprintf(md, "\n## Where the time goes\n\nPer pass at K = %d, N = %d, maps %d, light %s (median ms):\n\n"
                "| scene | light G-buffer | maps | camera G-buffer | combination | rebuilt | fixed |\n"
                "|---|---|---|---|---|---|---|\n",
            Kp, Np, Sp, front);
    for (int si = 0; si < s->scenes.n; si++) {
        const prow *q = find(rows, n, s->scenes.v[si], front, W, H, Kp, Np, Sp);
        if (q)
            fprintf(md, "| %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", s->scenes.v[si], q->lightmaps, q->maps,
                    q->gbuffer, q->combine, q->rebuilt, q->fixed);
    }

    /* grids */
    fprintf(md, "\n## Images\n\nPer scene and light: ours at K = %d, N = %d, maps %d (else the most expensive point "
                "measured), both references, and |Y_ours - Y_ref| / mean(Y_ref) as an inferno heat map on [0, %g]. "
                "The radiance cells share one exposure per row (the reference's 99th percentile luminance at 0.8), "
                "sRGB; cells downsampled to at most 240 pixels wide.\n\n",
            Kp, Np, Sp, GRID_ERR_MAX);
    for (int si = 0; si < s->scenes.n && st == OBS_STATUS_OK; si++)
        st = write_grid(ctx, pool, s, rows, n, s->scenes.v[si], W, H, md);
    fprintf(md, "## Columns\n\n`results.csv`: the key (scene, light, width, height, sampler, K, N, map_size), the maps' "
                "settings (`params`), per-pass times (median, min, max), `rebuilt_ms`, `fixed_ms`, then per reference "
                "(`bf_`, `rw_`): status (`ok` or `missing: reason`), RMSE and relative RMSE of luminance raw and "
                "noise-corrected, the ratio of means (ours over the reference), the reference's noise, mean "
                "luminance and pixel count, the fitted gain with its calibrated RMSE and skill, and the seconds the "
                "reference took when computed (empty when cached). docs/study.md has the definitions.\n");
    free(rows);
    if (fclose(md) != 0 && st == OBS_STATUS_OK)
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write %s", tmp);
    if (st == OBS_STATUS_OK && rename(tmp, path) != 0)
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot rename %s", tmp);
    return st;
}
