/* metrics.c: error measures, SSIM and the calibrated gain/power fit (metrics.h, docs/compare.md). */
#include "metrics.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

met_params met_params_default(void)
{
    met_params p;
    memset(&p, 0, sizeof p);
    p.peak = 1.0;
    p.threshold = 0.05;
    p.dynamic_range = 1.0;
    p.ignore_nonfinite = 0;
    p.compute_ssim = 1;
    return p;
}

/* ------------------------------------------------------------------------------------------------
 * Helpers
 * ---------------------------------------------------------------------------------------------- */

/* malloc with an overflow check and ctx's max_memory_bytes. */
static void *met_alloc(obs_context *ctx, size_t count, size_t size, const char *what, obs_status *st)
{
    size_t bytes;
    if (!obs_mul_size(count, size, &bytes)) {
        *st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "metrics: the size of %s overflows", what);
        return NULL;
    }
    obs_limits lim = ctx ? *obs_context_limits(ctx) : obs_limits_default();
    if ((uint64_t)bytes > (uint64_t)lim.max_memory_bytes) {
        *st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                        "metrics: %s needs %zu bytes, over the memory limit of %lld bytes (raise it with --max-memory)",
                        what, bytes, (long long)lim.max_memory_bytes);
        return NULL;
    }
    void *p = malloc(bytes ? bytes : 1);
    if (!p)
        *st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "metrics: out of memory allocating %s (%zu bytes)", what, bytes);
    return p;
}

static obs_status check_plane(obs_context *ctx, const obs_image_f32 *im, const char *what)
{
    if (!im || !im->data || im->width < 1 || im->height < 1 || im->stride < im->width)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "metrics: the %s plane is NULL, empty or has a bad stride",
                         what);
    return OBS_STATUS_OK;
}

static obs_status check_same_size(obs_context *ctx, const obs_image_f32 *a, const obs_image_f32 *b, const char *what)
{
    if (a->width != b->width || a->height != b->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "metrics: the %s plane is %dx%d, the reference is %dx%d", what,
                         b->width, b->height, a->width, a->height);
    return OBS_STATUS_OK;
}

static obs_status check_inputs(obs_context *ctx, const obs_image_f32 *ref, const obs_image_f32 *test,
                               const obs_image_f32 *mask, const met_params *p)
{
    obs_status st = check_plane(ctx, ref, "reference");
    if (st == OBS_STATUS_OK)
        st = check_plane(ctx, test, "test");
    if (st == OBS_STATUS_OK)
        st = check_same_size(ctx, ref, test, "test");
    if (st == OBS_STATUS_OK && mask) {
        st = check_plane(ctx, mask, "mask");
        if (st == OBS_STATUS_OK)
            st = check_same_size(ctx, ref, mask, "mask");
    }
    if (st != OBS_STATUS_OK)
        return st;
    if (!(p->peak > 0.0) || !isfinite(p->peak))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "metrics: peak must be finite and > 0 (got %g)", p->peak);
    if (!(p->threshold >= 0.0) || !isfinite(p->threshold))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "metrics: threshold must be finite and >= 0 (got %g)",
                         p->threshold);
    if (!(p->dynamic_range > 0.0) || !isfinite(p->dynamic_range))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "metrics: dynamic range must be finite and > 0 (got %g)",
                         p->dynamic_range);
    return OBS_STATUS_OK;
}

static int strip_count(int height) { return (height + MET_STRIP_ROWS - 1) / MET_STRIP_ROWS; }

/* The validity map: 1 where the mask allows the pixel and both values are finite. */
typedef struct valid_info {
    int64_t masked, nonfinite, valid;
    int first_x, first_y, first_input;
    float first_value;
} valid_info;

static obs_status build_valid(obs_context *ctx, const obs_image_f32 *ref, const obs_image_f32 *test,
                              const obs_image_f32 *mask, const met_params *p, uint8_t **out, valid_info *vi)
{
    int w = ref->width, h = ref->height;
    memset(vi, 0, sizeof *vi);
    vi->first_x = vi->first_y = -1;
    vi->first_input = MET_INPUT_NONE;
    vi->first_value = 0.0f;
    obs_status st = OBS_STATUS_OK;
    uint8_t *v = met_alloc(ctx, (size_t)w * (size_t)h, 1, "the validity map", &st);
    if (!v)
        return st;
    for (int y = 0; y < h; y++) {
        const float *ra = obs_image_f32_row(ref, y), *rb = obs_image_f32_row(test, y);
        const float *rm = mask ? obs_image_f32_row(mask, y) : NULL;
        uint8_t *vr = v + (size_t)y * (size_t)w;
        for (int x = 0; x < w; x++) {
            if (rm && !met_mask_valid(rm[x])) {
                vr[x] = 0;
                vi->masked++;
                continue;
            }
            int fa = isfinite(ra[x]) != 0, fb = isfinite(rb[x]) != 0;
            if (!fa || !fb) {
                if (vi->first_input == MET_INPUT_NONE) {
                    vi->first_x = x;
                    vi->first_y = y;
                    vi->first_input = !fa ? MET_INPUT_REFERENCE : MET_INPUT_TEST;
                    vi->first_value = !fa ? ra[x] : rb[x];
                }
                vi->nonfinite++;
                vr[x] = 0;
                continue;
            }
            vr[x] = 1;
            vi->valid++;
        }
    }
    if (vi->nonfinite > 0 && !p->ignore_nonfinite) {
        free(v);
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "non-finite value %g in the %s image at pixel (%d, %d) (%lld such pixels in all)",
                         (double)vi->first_value, vi->first_input == MET_INPUT_REFERENCE ? "reference" : "test",
                         vi->first_x, vi->first_y, (long long)vi->nonfinite);
    }
    *out = v;
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Pointwise measures
 * ---------------------------------------------------------------------------------------------- */

typedef struct point_sums {
    double se, ae, e, ra, ta, max_abs;
    double ra_k, ra_d, ra_d2; /* the reference's shift (its strip's first valid value), sum and sum of squares of a - k */
    int64_t n, over;
    int max_x, max_y;
} point_sums;

typedef struct point_job {
    const obs_image_f32 *ref, *test;
    const uint8_t *valid;
    double threshold;
    point_sums *strips;
} point_job;

static void point_task(void *user, int64_t task, int thread)
{
    (void)thread;
    point_job *j = user;
    int w = j->ref->width, h = j->ref->height;
    int y0 = (int)task * MET_STRIP_ROWS, y1 = y0 + MET_STRIP_ROWS < h ? y0 + MET_STRIP_ROWS : h;
    point_sums s;
    memset(&s, 0, sizeof s);
    s.max_abs = -1.0;
    s.max_x = s.max_y = -1;
    for (int y = y0; y < y1; y++) {
        const float *ra = obs_image_f32_row(j->ref, y), *rb = obs_image_f32_row(j->test, y);
        const uint8_t *vr = j->valid + (size_t)y * (size_t)w;
        for (int x = 0; x < w; x++) {
            if (!vr[x])
                continue;
            double a = ra[x], b = rb[x];
            double e = b - a, ae = fabs(e);
            if (s.n == 0)
                s.ra_k = a;
            const double d = a - s.ra_k;
            s.ra_d += d;
            s.ra_d2 += d * d;
            s.se += e * e;
            s.ae += ae;
            s.e += e;
            s.ra += a;
            s.ta += b;
            s.n++;
            if (ae > j->threshold)
                s.over++;
            if (ae > s.max_abs) {
                s.max_abs = ae;
                s.max_x = x;
                s.max_y = y;
            }
        }
    }
    j->strips[task] = s;
}

/* ------------------------------------------------------------------------------------------------
 * SSIM (Wang, Bovik, Sheikh, Simoncelli, IEEE TIP 13(4) 600-612, 2004), eq. 13, Gaussian window
 * ---------------------------------------------------------------------------------------------- */

void met_ssim_weights(double w[MET_SSIM_WINDOW])
{
    double sum = 0.0;
    for (int k = 0; k < MET_SSIM_WINDOW; k++) {
        double d = (double)(k - MET_SSIM_RADIUS);
        w[k] = exp(-d * d / (2.0 * MET_SSIM_SIGMA * MET_SSIM_SIGMA));
        sum += w[k];
    }
    for (int k = 0; k < MET_SSIM_WINDOW; k++)
        w[k] /= sum;
}

#define SSIM_Q 6 /* filtered quantities: m, m a, m b, m a a, m b b, m a b */

typedef struct ssim_job {
    const obs_image_f32 *a, *b;
    const uint8_t *valid;
    obs_image_f32 *map;
    int w, h;
    double g[MET_SSIM_WINDOW];
    double c1, c2;
    const double *hw, *vw;      /* in-image 1-D window weight per column / row */
    double **scratch;           /* per worker thread */
    double *sums;               /* per strip */
    int64_t *counts;            /* per strip */
} ssim_job;

/* Scratch per thread: horizontally filtered rows H[q][row][x] for MET_STRIP_ROWS + 2R rows, the
 * row inputs in[q][x], and the vertical accumulators acc[q][x]. */
static size_t ssim_scratch_doubles(int w)
{
    return (size_t)SSIM_Q * (size_t)w * (size_t)(MET_STRIP_ROWS + 2 * MET_SSIM_RADIUS + 2);
}

static void ssim_task(void *user, int64_t task, int thread)
{
    ssim_job *j = user;
    const int w = j->w, h = j->h, R = MET_SSIM_RADIUS;
    const int y0 = (int)task * MET_STRIP_ROWS, y1 = y0 + MET_STRIP_ROWS < h ? y0 + MET_STRIP_ROWS : h;
    const int ybeg = y0 - R > 0 ? y0 - R : 0, yend = y1 + R < h ? y1 + R : h;
    const int rows = yend - ybeg;
    double *H = j->scratch[thread];                       /* [q][row][x] */
    double *in = H + (size_t)SSIM_Q * (size_t)rows * (size_t)w;   /* [q][x] */
    double *acc = in + (size_t)SSIM_Q * (size_t)w;        /* [q][x] */
    const double *g = j->g;

    /* Horizontal pass, windows clipped at the left and right borders. */
    for (int yy = ybeg; yy < yend; yy++) {
        const float *ra = obs_image_f32_row(j->a, yy), *rb = obs_image_f32_row(j->b, yy);
        const uint8_t *vr = j->valid + (size_t)yy * (size_t)w;
        for (int x = 0; x < w; x++) {
            double m = vr[x] ? 1.0 : 0.0;
            double a = vr[x] ? (double)ra[x] : 0.0, b = vr[x] ? (double)rb[x] : 0.0;
            double ma = m * a, mb = m * b;
            in[0 * (size_t)w + x] = m;
            in[1 * (size_t)w + x] = ma;
            in[2 * (size_t)w + x] = mb;
            in[3 * (size_t)w + x] = ma * a;
            in[4 * (size_t)w + x] = mb * b;
            in[5 * (size_t)w + x] = ma * b;
        }
        for (int q = 0; q < SSIM_Q; q++) {
            const double *src = in + (size_t)q * (size_t)w;
            double *dst = H + ((size_t)q * (size_t)rows + (size_t)(yy - ybeg)) * (size_t)w;
            for (int x = 0; x < w; x++) {
                int lo = x - R > 0 ? x - R : 0, hi = x + R < w - 1 ? x + R : w - 1;
                double s = 0.0;
                for (int xx = lo; xx <= hi; xx++)
                    s += g[xx - x + R] * src[xx];
                dst[x] = s;
            }
        }
    }

    /* Vertical pass and the SSIM of each counted pixel, row-major. */
    double sum = 0.0;
    int64_t count = 0;
    for (int y = y0; y < y1; y++) {
        memset(acc, 0, sizeof(double) * (size_t)SSIM_Q * (size_t)w);
        int lo = y - R > 0 ? y - R : 0, hi = y + R < h - 1 ? y + R : h - 1;
        for (int yy = lo; yy <= hi; yy++) {
            double gy = g[yy - y + R];
            for (int q = 0; q < SSIM_Q; q++) {
                const double *src = H + ((size_t)q * (size_t)rows + (size_t)(yy - ybeg)) * (size_t)w;
                double *dst = acc + (size_t)q * (size_t)w;
                for (int x = 0; x < w; x++)
                    dst[x] += gy * src[x];
            }
        }
        const uint8_t *vr = j->valid + (size_t)y * (size_t)w;
        float *mr = j->map ? obs_image_f32_row(j->map, y) : NULL;
        for (int x = 0; x < w; x++) {
            double sw = acc[x];
            double wimg = j->hw[x] * j->vw[y];
            if (!vr[x] || !(sw > 0.0) || sw < 0.5 * wimg) {
                if (mr)
                    mr[x] = NAN;
                continue;
            }
            double mu_a = acc[1 * (size_t)w + x] / sw, mu_b = acc[2 * (size_t)w + x] / sw;
            double var_a = acc[3 * (size_t)w + x] / sw - mu_a * mu_a;
            double var_b = acc[4 * (size_t)w + x] / sw - mu_b * mu_b;
            double cov = acc[5 * (size_t)w + x] / sw - mu_a * mu_b;
            double num = (2.0 * mu_a * mu_b + j->c1) * (2.0 * cov + j->c2);
            double den = (mu_a * mu_a + mu_b * mu_b + j->c1) * (var_a + var_b + j->c2);
            double s = num / den;
            sum += s;
            count++;
            if (mr)
                mr[x] = (float)s;
        }
    }
    j->sums[task] = sum;
    j->counts[task] = count;
}

static obs_status ssim_with_valid(obs_context *ctx, obs_pool *pool, const obs_image_f32 *a, const obs_image_f32 *b,
                                  const uint8_t *valid, const met_params *p, double *out_ssim, int64_t *out_count,
                                  obs_image_f32 *map)
{
    ssim_job j;
    memset(&j, 0, sizeof j);
    j.a = a;
    j.b = b;
    j.valid = valid;
    j.map = map;
    j.w = a->width;
    j.h = a->height;
    met_ssim_weights(j.g);
    j.c1 = (MET_SSIM_K1 * p->dynamic_range) * (MET_SSIM_K1 * p->dynamic_range);
    j.c2 = (MET_SSIM_K2 * p->dynamic_range) * (MET_SSIM_K2 * p->dynamic_range);
    int threads = pool ? obs_pool_threads(pool) : 1;
    if (threads < 1)
        threads = 1;
    int strips = strip_count(j.h);
    obs_status st = OBS_STATUS_OK;
    double *hw = NULL, *vw = NULL, *sums = NULL;
    int64_t *counts = NULL;
    double **scratch = calloc((size_t)threads, sizeof *scratch);
    if (!scratch)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "metrics: out of memory");
    hw = met_alloc(ctx, (size_t)j.w, sizeof(double), "SSIM window weights", &st);
    if (hw)
        vw = met_alloc(ctx, (size_t)j.h, sizeof(double), "SSIM window weights", &st);
    if (vw)
        sums = met_alloc(ctx, (size_t)strips, sizeof(double), "SSIM strip sums", &st);
    if (sums)
        counts = met_alloc(ctx, (size_t)strips, sizeof(int64_t), "SSIM strip counts", &st);
    for (int t = 0; counts && t < threads && st == OBS_STATUS_OK; t++) {
        scratch[t] = met_alloc(ctx, ssim_scratch_doubles(j.w), sizeof(double), "SSIM scratch", &st);
        if (!scratch[t])
            break;
    }
    if (st == OBS_STATUS_OK) {
        const int R = MET_SSIM_RADIUS;
        for (int x = 0; x < j.w; x++) {
            double s = 0.0;
            for (int k = -R; k <= R; k++)
                if (x + k >= 0 && x + k < j.w)
                    s += j.g[k + R];
            hw[x] = s;
        }
        for (int y = 0; y < j.h; y++) {
            double s = 0.0;
            for (int k = -R; k <= R; k++)
                if (y + k >= 0 && y + k < j.h)
                    s += j.g[k + R];
            vw[y] = s;
        }
        j.hw = hw;
        j.vw = vw;
        j.scratch = scratch;
        j.sums = sums;
        j.counts = counts;
        obs_pool_run(pool, strips, ssim_task, &j);
        double sum = 0.0;
        int64_t n = 0;
        for (int s = 0; s < strips; s++) {
            sum += sums[s];
            n += counts[s];
        }
        *out_ssim = n > 0 ? sum / (double)n : NAN;
        if (out_count)
            *out_count = n;
    }
    for (int t = 0; t < threads; t++)
        free(scratch[t]);
    free(scratch);
    free(hw);
    free(vw);
    free(sums);
    free(counts);
    return st;
}

obs_status met_ssim(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref, const obs_image_f32 *test,
                    const obs_image_f32 *mask, const met_params *p, double *out_ssim, int64_t *out_count,
                    obs_image_f32 *map)
{
    met_params def = met_params_default();
    if (!p)
        p = &def;
    if (!out_ssim)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "met_ssim: NULL output");
    *out_ssim = NAN;
    if (out_count)
        *out_count = 0;
    obs_status st = check_inputs(ctx, ref, test, mask, p);
    if (st == OBS_STATUS_OK && map) {
        st = check_plane(ctx, map, "SSIM map");
        if (st == OBS_STATUS_OK)
            st = check_same_size(ctx, ref, map, "SSIM map");
    }
    if (st != OBS_STATUS_OK)
        return st;
    uint8_t *valid = NULL;
    valid_info vi;
    st = build_valid(ctx, ref, test, mask, p, &valid, &vi);
    if (st != OBS_STATUS_OK)
        return st;
    st = ssim_with_valid(ctx, pool, ref, test, valid, p, out_ssim, out_count, map);
    free(valid);
    return st;
}

/* ------------------------------------------------------------------------------------------------
 * met_compare
 * ---------------------------------------------------------------------------------------------- */

static void result_init(met_result *r, const obs_image_f32 *ref)
{
    memset(r, 0, sizeof *r);
    r->pixels = ref ? (int64_t)ref->width * ref->height : 0;
    r->first_nonfinite_x = r->first_nonfinite_y = -1;
    r->first_nonfinite_input = MET_INPUT_NONE;
    r->mse = r->rmse = r->mae = r->bias = r->max_abs = r->psnr = NAN;
    r->over_fraction = r->ref_mean = r->test_mean = r->ref_var = r->ssim = NAN;
    r->max_x = r->max_y = -1;
}

obs_status met_compare(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref, const obs_image_f32 *test,
                       const obs_image_f32 *mask, const met_params *p, met_result *out)
{
    met_params def = met_params_default();
    if (!p)
        p = &def;
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "met_compare: NULL output");
    result_init(out, (ref && ref->data) ? ref : NULL);
    obs_status st = check_inputs(ctx, ref, test, mask, p);
    if (st != OBS_STATUS_OK)
        return st;
    uint8_t *valid = NULL;
    valid_info vi;
    st = build_valid(ctx, ref, test, mask, p, &valid, &vi);
    out->masked = vi.masked;
    out->nonfinite = vi.nonfinite;
    out->first_nonfinite_x = vi.first_x;
    out->first_nonfinite_y = vi.first_y;
    out->first_nonfinite_input = vi.first_input;
    out->first_nonfinite_value = vi.first_value;
    if (st != OBS_STATUS_OK)
        return st;

    int strips = strip_count(ref->height);
    point_sums *ps = met_alloc(ctx, (size_t)strips, sizeof *ps, "metric strip sums", &st);
    if (!ps) {
        free(valid);
        return st;
    }
    point_job pj = {ref, test, valid, p->threshold, ps};
    obs_pool_run(pool, strips, point_task, &pj);
    point_sums t;
    memset(&t, 0, sizeof t);
    t.max_abs = -1.0;
    t.max_x = t.max_y = -1;
    /* The reference's variance: each strip's sum of squared deviations from its own mean, from
     * sums shifted by its first value, then the strips merged in order by the pairwise update of
     * [Chan83] (M2 = M2a + M2b + d^2 na nb / n, d the difference of the means), which avoids the
     * cancellation of sum(a^2) - n mean^2. */
    double var_mean = 0.0, var_m2 = 0.0;
    for (int s = 0; s < strips; s++) {
        if (ps[s].n > 0) {
            const double nb = (double)ps[s].n, na = (double)t.n, mb = ps[s].ra_k + ps[s].ra_d / nb;
            const double m2b = ps[s].ra_d2 - ps[s].ra_d * ps[s].ra_d / nb, d = mb - var_mean;
            var_m2 += (m2b > 0.0 ? m2b : 0.0) + d * d * na * nb / (na + nb);
            var_mean += d * nb / (na + nb);
        }
        t.se += ps[s].se;
        t.ae += ps[s].ae;
        t.e += ps[s].e;
        t.ra += ps[s].ra;
        t.ta += ps[s].ta;
        t.n += ps[s].n;
        t.over += ps[s].over;
        if (ps[s].n > 0 && ps[s].max_abs > t.max_abs) {
            t.max_abs = ps[s].max_abs;
            t.max_x = ps[s].max_x;
            t.max_y = ps[s].max_y;
        }
    }
    free(ps);
    out->valid = t.n;
    out->over_count = t.over;
    if (t.n > 0) {
        double n = (double)t.n;
        out->mse = t.se / n;
        out->rmse = sqrt(out->mse);
        out->mae = t.ae / n;
        out->bias = t.e / n;
        out->ref_mean = t.ra / n;
        out->test_mean = t.ta / n;
        out->ref_var = var_m2 / n;
        out->max_abs = t.max_abs;
        out->max_x = t.max_x;
        out->max_y = t.max_y;
        out->over_fraction = (double)t.over / n;
        out->psnr = out->mse > 0.0 ? 10.0 * log10(p->peak * p->peak / out->mse) : INFINITY;
    }
    if (p->compute_ssim)
        st = ssim_with_valid(ctx, pool, ref, test, valid, p, &out->ssim, &out->ssim_pixels, NULL);
    free(valid);
    return st;
}

/* ------------------------------------------------------------------------------------------------
 * Calibrated fit: calibrated(v) = clamp01(1 - g (1 - clamp01(v)^p))
 * ---------------------------------------------------------------------------------------------- */

#define FIT_CHUNK 65536
#define FIT_GRID 21

static double clamp01(double v) { return v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v; }

typedef struct fit_job {
    const double *lv;    /* ln clamp01(v) (-inf for v <= 0), compacted valid pixels, row-major */
    const double *rp;    /* 1 - r */
    int64_t n;
    double power, gain;  /* gain used by the SSE pass */
    double *s_ro, *s_oo, *s_sse;   /* per chunk */
} fit_job;

static void fit_sums_task(void *user, int64_t task, int thread)
{
    (void)thread;
    fit_job *j = user;
    int64_t i0 = task * FIT_CHUNK, i1 = i0 + FIT_CHUNK < j->n ? i0 + FIT_CHUNK : j->n;
    double ro = 0.0, oo = 0.0;
    for (int64_t i = i0; i < i1; i++) {
        double o = 1.0 - exp(j->power * j->lv[i]);
        ro += j->rp[i] * o;
        oo += o * o;
    }
    j->s_ro[task] = ro;
    j->s_oo[task] = oo;
}

static void fit_sse_task(void *user, int64_t task, int thread)
{
    (void)thread;
    fit_job *j = user;
    int64_t i0 = task * FIT_CHUNK, i1 = i0 + FIT_CHUNK < j->n ? i0 + FIT_CHUNK : j->n;
    double s = 0.0;
    for (int64_t i = i0; i < i1; i++) {
        double d = j->rp[i] - j->gain * (1.0 - exp(j->power * j->lv[i]));
        s += d * d;
    }
    j->s_sse[task] = s;
}

typedef struct fit_state {
    obs_pool *pool;
    fit_job *job;
    int64_t chunks;
    double s_rr;
    int evaluations;
} fit_state;

/* The profile objective: SSE at the optimal g for p = exp(u). */
static double fit_objective(fit_state *f, double u, double *gain_out)
{
    fit_job *j = f->job;
    j->power = exp(u);
    obs_pool_run(f->pool, f->chunks, fit_sums_task, j);
    double ro = 0.0, oo = 0.0;
    for (int64_t c = 0; c < f->chunks; c++) {
        ro += j->s_ro[c];
        oo += j->s_oo[c];
    }
    f->evaluations++;
    double g = (oo > 0.0 && ro > 0.0) ? ro / oo : 0.0;
    if (gain_out)
        *gain_out = g;
    return f->s_rr - 2.0 * g * ro + g * g * oo;
}

/* Brent's minimiser without derivatives (R. P. Brent, "Algorithms for Minimization without
 * Derivatives", 1973, ch. 5; the netlib fmin), on [a, b] to absolute tolerance tol. */
static double brent_min(fit_state *f, double a, double b, double tol, double *fmin_out)
{
    const double c = 0.5 * (3.0 - sqrt(5.0));
    const double eps = sqrt(DBL_EPSILON);
    double v = a + c * (b - a), w = v, x = v;
    double d = 0.0, e = 0.0;
    double fx = fit_objective(f, x, NULL), fv = fx, fw = fx;
    for (int iter = 0; iter < 200; iter++) {
        double xm = 0.5 * (a + b);
        double tol1 = eps * fabs(x) + tol / 3.0, tol2 = 2.0 * tol1;
        if (fabs(x - xm) <= tol2 - 0.5 * (b - a))
            break;
        int golden = 1;
        if (fabs(e) > tol1) {
            double r = (x - w) * (fx - fv);
            double q = (x - v) * (fx - fw);
            double pp = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if (q > 0.0)
                pp = -pp;
            else
                q = -q;
            double etemp = e;
            e = d;
            if (!(fabs(pp) >= fabs(0.5 * q * etemp) || pp <= q * (a - x) || pp >= q * (b - x))) {
                d = pp / q;
                double u = x + d;
                if (u - a < tol2 || b - u < tol2)
                    d = xm - x >= 0.0 ? tol1 : -tol1;
                golden = 0;
            }
        }
        if (golden) {
            e = x >= xm ? a - x : b - x;
            d = c * e;
        }
        double u = fabs(d) >= tol1 ? x + d : x + (d >= 0.0 ? tol1 : -tol1);
        double fu = fit_objective(f, u, NULL);
        if (fu <= fx) {
            if (u < x)
                b = x;
            else
                a = x;
            v = w; fv = fw;
            w = x; fw = fx;
            x = u; fx = fu;
        } else {
            if (u < x)
                a = u;
            else
                b = u;
            if (fu <= fw || w == x) {
                v = w; fv = fw;
                w = u; fw = fu;
            } else if (fu <= fv || v == x || v == w) {
                v = u; fv = fu;
            }
        }
    }
    *fmin_out = fx;
    return x;
}

obs_status met_fit_gain_power(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ref,
                              const obs_image_f32 *test, const obs_image_f32 *mask, const met_params *p,
                              met_fit *out)
{
    met_params def = met_params_default();
    if (!p)
        p = &def;
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "met_fit_gain_power: NULL output");
    memset(out, 0, sizeof *out);
    out->gain = out->power = 1.0;
    out->fit_rmse = NAN;
    obs_status st = check_inputs(ctx, ref, test, mask, p);
    if (st != OBS_STATUS_OK)
        return st;
    uint8_t *valid = NULL;
    valid_info vi;
    st = build_valid(ctx, ref, test, mask, p, &valid, &vi);
    if (st != OBS_STATUS_OK)
        return st;
    int64_t n = vi.valid;
    out->count = n;
    if (n == 0) {
        free(valid);
        return OBS_STATUS_OK;
    }
    int64_t chunks = (n + FIT_CHUNK - 1) / FIT_CHUNK;
    double *lv = met_alloc(ctx, (size_t)n, sizeof(double), "the fit's pixel arrays", &st);
    double *rp = lv ? met_alloc(ctx, (size_t)n, sizeof(double), "the fit's pixel arrays", &st) : NULL;
    double *sums = rp ? met_alloc(ctx, (size_t)chunks * 3, sizeof(double), "the fit's chunk sums", &st) : NULL;
    if (!sums) {
        free(lv);
        free(rp);
        free(valid);
        return st;
    }
    /* Compact the valid pixels, row-major. */
    int64_t k = 0;
    double s_rr = 0.0;
    int any_occlusion = 0;
    for (int y = 0; y < ref->height; y++) {
        const float *ra = obs_image_f32_row(ref, y), *rb = obs_image_f32_row(test, y);
        const uint8_t *vr = valid + (size_t)y * (size_t)ref->width;
        for (int x = 0; x < ref->width; x++) {
            if (!vr[x])
                continue;
            double v = clamp01((double)rb[x]);
            lv[k] = v > 0.0 ? log(v) : -INFINITY;
            rp[k] = 1.0 - (double)ra[x];
            if (lv[k] != 0.0)
                any_occlusion = 1;
            k++;
        }
    }
    free(valid);
    /* S_rr in the same chunked order as the other sums. */
    for (int64_t c = 0; c < chunks; c++) {
        int64_t i0 = c * FIT_CHUNK, i1 = i0 + FIT_CHUNK < n ? i0 + FIT_CHUNK : n;
        double s = 0.0;
        for (int64_t i = i0; i < i1; i++)
            s += rp[i] * rp[i];
        s_rr += s;
    }
    fit_job job;
    memset(&job, 0, sizeof job);
    job.lv = lv;
    job.rp = rp;
    job.n = n;
    job.s_ro = sums;
    job.s_oo = sums + chunks;
    job.s_sse = sums + 2 * chunks;
    fit_state f = {pool, &job, chunks, s_rr, 0};

    double best_u = 0.0, best_g = 1.0;
    if (any_occlusion) {
        const double ulo = log(MET_FIT_POWER_MIN), uhi = log(MET_FIT_POWER_MAX);
        double grid_f[FIT_GRID];
        int kbest = 0;
        for (int i = 0; i < FIT_GRID; i++) {
            double u = ulo + (uhi - ulo) * (double)i / (double)(FIT_GRID - 1);
            grid_f[i] = fit_objective(&f, u, NULL);
            if (grid_f[i] < grid_f[kbest])
                kbest = i;
        }
        int ka = kbest > 0 ? kbest - 1 : 0, kb = kbest < FIT_GRID - 1 ? kbest + 1 : FIT_GRID - 1;
        double a = ulo + (uhi - ulo) * (double)ka / (double)(FIT_GRID - 1);
        double b = ulo + (uhi - ulo) * (double)kb / (double)(FIT_GRID - 1);
        double ub = ulo + (uhi - ulo) * (double)kbest / (double)(FIT_GRID - 1);
        double fb;
        double ux = brent_min(&f, a, b, 1e-9, &fb);
        best_u = fb <= grid_f[kbest] ? ux : ub;
        if (best_u < ulo)
            best_u = ulo;
        if (best_u > uhi)
            best_u = uhi;
        fit_objective(&f, best_u, &best_g);
        out->power = exp(best_u);
        out->gain = best_g;
        out->power_at_bound = met_fit_power_at_bound(out->power);
    }
    /* The objective at the result, summed directly (no cancellation). */
    job.power = exp(best_u);
    job.gain = out->gain;
    obs_pool_run(pool, chunks, fit_sse_task, &job);
    double sse = 0.0;
    for (int64_t c = 0; c < chunks; c++)
        sse += job.s_sse[c];
    out->sse = sse;
    out->fit_rmse = sqrt(sse / (double)n);
    out->evaluations = f.evaluations;
    free(lv);
    free(rp);
    free(sums);
    return OBS_STATUS_OK;
}

obs_status met_apply_gain_power(obs_context *ctx, const obs_image_f32 *test, double gain, double power,
                                obs_image_f32 *out)
{
    obs_status st = check_plane(ctx, test, "test");
    if (st == OBS_STATUS_OK)
        st = check_plane(ctx, out, "output");
    if (st == OBS_STATUS_OK)
        st = check_same_size(ctx, test, out, "output");
    if (st != OBS_STATUS_OK)
        return st;
    if (!(gain >= 0.0) || !isfinite(gain) || !(power > 0.0) || !isfinite(power))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "met_apply_gain_power: gain %g must be >= 0 and power %g > 0",
                         gain, power);
    for (int y = 0; y < test->height; y++) {
        const float *src = obs_image_f32_row(test, y);
        float *dst = obs_image_f32_row(out, y);
        for (int x = 0; x < test->width; x++) {
            double v = src[x];
            if (v != v) {
                dst[x] = src[x];
                continue;
            }
            dst[x] = (float)clamp01(1.0 - gain * (1.0 - pow(clamp01(v), power)));
        }
    }
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Skill against the flat baseline [Murphy88]
 * ---------------------------------------------------------------------------------------------- */

int met_fit_power_at_bound(double power)
{
    return fabs(power - MET_FIT_POWER_MIN) <= 1e-6 * MET_FIT_POWER_MIN ||
           fabs(power - MET_FIT_POWER_MAX) <= 1e-6 * MET_FIT_POWER_MAX;
}

met_skill met_skill_of(double mse, double ref_var, double noise_var)
{
    met_skill s;
    /* Noise correction: with r_hat = r + n, n independent of r and of the test, zero mean and mean
     * variance noise_var, E[mse] = mse(r) + noise_var and E[Var(r_hat)] = Var(r) + noise_var; the
     * same subtraction as the studies' noise-corrected RMSE, clamped at 0. */
    const double nv = noise_var > 0.0 ? noise_var : 0.0;
    const double m = mse - nv > 0.0 ? mse - nv : 0.0, v = ref_var - nv > 0.0 ? ref_var - nv : 0.0;
    s.rmse = sqrt(m);
    /* The best constant image is the reference's mean; its MSE is Var(r): the flat baseline. */
    s.baseline_rmse = sqrt(v);
    /* [Murphy88] the MSE skill score against the sample climatology: SS = 1 - MSE / MSE(mean) =
     * 1 - MSE / Var(r) (= r^2 - (r - s_t/s_r)^2 - ((mean t - mean r)/s_r)^2 in his decomposition). */
    s.skill = v > 0.0 ? 1.0 - m / v : NAN;
    if (!(mse >= 0.0) || !(ref_var >= 0.0) || !isfinite(mse) || !isfinite(ref_var))
        s.rmse = s.baseline_rmse = s.skill = NAN;
    return s;
}

/* ------------------------------------------------------------------------------------------------
 * Colour map
 * ---------------------------------------------------------------------------------------------- */

/* matplotlib's "inferno" (_cm_listed.py, _inferno_data; Nathaniel J. Smith and Stefan van der Walt,
 * 2015, CC0): entries round(k * 255 / 32), k = 0..32, of the 256-entry table, sRGB-encoded.
 * Linear interpolation over k reproduces the full table within 1.5/255. */
static const float inferno33[33][3] = {
    {0.001462f, 0.000466f, 0.013866f}, {0.013995f, 0.011225f, 0.071862f}, {0.042253f, 0.028139f, 0.141141f},
    {0.081962f, 0.043328f, 0.215289f}, {0.129285f, 0.047293f, 0.290788f}, {0.183429f, 0.040329f, 0.354971f},
    {0.238273f, 0.036621f, 0.396353f}, {0.290763f, 0.045644f, 0.418637f}, {0.341500f, 0.062325f, 0.429425f},
    {0.391453f, 0.080927f, 0.433109f}, {0.441207f, 0.099338f, 0.431594f}, {0.491022f, 0.117179f, 0.425552f},
    {0.540920f, 0.134729f, 0.415123f}, {0.590734f, 0.152563f, 0.400290f}, {0.640135f, 0.171438f, 0.381065f},
    {0.688653f, 0.192239f, 0.357603f}, {0.735683f, 0.215906f, 0.330245f}, {0.775059f, 0.239667f, 0.303526f},
    {0.817341f, 0.270954f, 0.270390f}, {0.855992f, 0.307038f, 0.235133f}, {0.890341f, 0.347957f, 0.198286f},
    {0.919879f, 0.393389f, 0.160070f}, {0.944285f, 0.442772f, 0.120354f}, {0.963387f, 0.495462f, 0.079073f},
    {0.977092f, 0.550850f, 0.039050f}, {0.985315f, 0.608422f, 0.024202f}, {0.987945f, 0.667748f, 0.058329f},
    {0.984865f, 0.728427f, 0.120785f}, {0.976108f, 0.789974f, 0.196018f}, {0.962517f, 0.851476f, 0.285546f},
    {0.948683f, 0.910473f, 0.395289f}, {0.951740f, 0.960587f, 0.524203f}, {0.988362f, 0.998364f, 0.644924f},
};

void met_colormap_inferno(double t, float srgb[3])
{
    if (!(t > 0.0))
        t = 0.0;
    if (t > 1.0)
        t = 1.0;
    double s = t * 32.0;
    int k = (int)s;
    if (k > 31)
        k = 31;
    double f = s - (double)k;
    for (int c = 0; c < 3; c++)
        srgb[c] = (float)((double)inferno33[k][c] + ((double)inferno33[k + 1][c] - (double)inferno33[k][c]) * f);
}
