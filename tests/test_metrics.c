/* test_metrics.c: the comparison measures of src/metrics (RMSE ... SSIM, masks, non-finite
 * inputs, the calibrated gain/power fit, determinism). */
#include "core/obs.h"
#include "metrics/metrics.h"
#include "test.h"

#include <stdlib.h>
#include <string.h>

/* ---- helpers ------------------------------------------------------------------------------ */

static float px(const obs_image_f32 *im, int x, int y) { return obs_image_f32_row(im, y)[x]; }
static void set_px(obs_image_f32 *im, int x, int y, float v) { obs_image_f32_row(im, y)[x] = v; }

static void fill_values(obs_image_f32 *im, const float *v)
{
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x < im->width; x++)
            set_px(im, x, y, v[y * im->width + x]);
}

/* Deterministic pseudo-random values in [lo, hi). */
static void fill_random(obs_image_f32 *im, uint64_t seed, float lo, float hi)
{
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x < im->width; x++)
            set_px(im, x, y, lo + (hi - lo) * obs_rng_float((uint64_t)y * (uint64_t)im->width + (uint64_t)x, 0, 0, seed));
}

/* A smooth-plus-noise image, so that SSIM windows see structure. */
static void fill_structured(obs_image_f32 *im, uint64_t seed)
{
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x < im->width; x++) {
            double s = 0.5 + 0.3 * sin(0.21 * x) * cos(0.17 * y);
            double n = obs_rng_float((uint64_t)y * (uint64_t)im->width + (uint64_t)x, 0, 1, seed) - 0.5;
            set_px(im, x, y, (float)(s + 0.2 * n));
        }
}

/* SSIM computed directly: for every pixel, the clipped 11x11 window, weights g_i g_j renormalised
 * over the valid in-image pixels; counted when the centre is valid and the valid weight is at
 * least half the in-image weight. mask may be NULL. O(N * 121), written independently of the
 * separable implementation. */
static double ssim_direct(const obs_image_f32 *a, const obs_image_f32 *b, const obs_image_f32 *mask, double L,
                          int64_t *count)
{
    double g[11], gs = 0.0;
    for (int k = 0; k < 11; k++) {
        g[k] = exp(-(double)((k - 5) * (k - 5)) / (2.0 * 1.5 * 1.5));
        gs += g[k];
    }
    for (int k = 0; k < 11; k++)
        g[k] /= gs;
    double c1 = (0.01 * L) * (0.01 * L), c2 = (0.03 * L) * (0.03 * L);
    double sum = 0.0;
    int64_t n = 0;
    int w = a->width, h = a->height;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (mask && px(mask, x, y) == 0.0f)
                continue;
            double wv = 0, wi = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
            for (int j = -5; j <= 5; j++)
                for (int i = -5; i <= 5; i++) {
                    int xx = x + i, yy = y + j;
                    if (xx < 0 || yy < 0 || xx >= w || yy >= h)
                        continue;
                    double wt = g[i + 5] * g[j + 5];
                    wi += wt;
                    if (mask && px(mask, xx, yy) == 0.0f)
                        continue;
                    double va = px(a, xx, yy), vb = px(b, xx, yy);
                    wv += wt;
                    sa += wt * va;
                    sb += wt * vb;
                    saa += wt * va * va;
                    sbb += wt * vb * vb;
                    sab += wt * va * vb;
                }
            if (wv < 0.5 * wi)
                continue;
            double ma = sa / wv, mb = sb / wv;
            double va = saa / wv - ma * ma, vb = sbb / wv - mb * mb, cab = sab / wv - ma * mb;
            sum += ((2 * ma * mb + c1) * (2 * cab + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            n++;
        }
    *count = n;
    return n ? sum / (double)n : NAN;
}

/* ---- pointwise measures ------------------------------------------------------------------- */

TEST(metrics_match_hand_computed_values)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 2, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 2, &b), ctx);
    CHECK(a.stride > a.width); /* exercises strides */
    /* errors e = B - A = {0, 1/8, -1/8 ; -1/8, 1/4, 0} */
    const float ra[6] = {0.5f, 0.25f, 0.75f, 1.0f, 0.0f, 0.5f};
    const float rb[6] = {0.5f, 0.375f, 0.625f, 0.875f, 0.25f, 0.5f};
    fill_values(&a, ra);
    fill_values(&b, rb);
    met_params p = met_params_default();
    met_result r;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r), ctx);
    CHECK_EQ_INT(r.pixels, 6);
    CHECK_EQ_INT(r.valid, 6);
    CHECK_EQ_INT(r.masked, 0);
    CHECK_EQ_INT(r.nonfinite, 0);
    /* MSE = (3/64 + 1/16) / 6 = 7/384; MAE = (3/8 + 1/4) / 6 = 5/48; bias = (1/8) / 6 = 1/48 */
    CHECK_NEAR(r.mse, 7.0 / 384.0, 1e-15);
    CHECK_NEAR(r.rmse, sqrt(7.0 / 384.0), 1e-15);
    CHECK_NEAR(r.mae, 5.0 / 48.0, 1e-15);
    CHECK_NEAR(r.bias, 1.0 / 48.0, 1e-15);
    CHECK_NEAR(r.max_abs, 0.25, 0.0);
    CHECK_EQ_INT(r.max_x, 1);
    CHECK_EQ_INT(r.max_y, 1);
    CHECK_NEAR(r.psnr, 10.0 * log10(384.0 / 7.0), 1e-12); /* 17.392... dB */
    CHECK_NEAR(r.psnr, 17.392332, 1e-5);
    CHECK_EQ_INT(r.over_count, 4); /* |e| > 0.05 */
    CHECK_NEAR(r.over_fraction, 4.0 / 6.0, 1e-15);
    CHECK_NEAR(r.ref_mean, 3.0 / 6.0, 1e-15);
    CHECK_NEAR(r.test_mean, 3.125 / 6.0, 1e-15);

    /* The threshold is strict (|e| > t), and the peak scales PSNR by 20 log10(peak). */
    p.threshold = 0.125;
    p.peak = 10.0;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r), ctx);
    CHECK_EQ_INT(r.over_count, 1);
    CHECK_NEAR(r.psnr, 10.0 * log10(100.0 * 384.0 / 7.0), 1e-12);

    /* Ties for the maximum: the first pixel in row-major order. */
    set_px(&b, 1, 0, 0.5f); /* e = 1/4 at (1, 0) too */
    CHECK_OK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r), ctx);
    CHECK_EQ_INT(r.max_x, 1);
    CHECK_EQ_INT(r.max_y, 0);

    /* Identical images: zero errors, PSNR +inf. */
    CHECK_OK(met_compare(ctx, NULL, &a, &a, NULL, NULL, &r), ctx);
    CHECK(r.mse == 0.0 && r.max_abs == 0.0 && r.bias == 0.0);
    CHECK(isinf(r.psnr) && r.psnr > 0);

    /* Parameter and size checks. */
    p = met_params_default();
    p.peak = 0.0;
    CHECK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32 c = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 2, 3, &c), ctx);
    CHECK(met_compare(ctx, NULL, &a, &c, NULL, NULL, &r) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&c);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

/* ---- SSIM --------------------------------------------------------------------------------- */

TEST(ssim_of_identical_images_is_one)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, m = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 70, 45, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 70, 45, &m), ctx);
    fill_structured(&a, 7);
    double s;
    int64_t n;
    CHECK_OK(met_ssim(ctx, NULL, &a, &a, NULL, NULL, &s, &n, NULL), ctx);
    CHECK_EQ_INT(n, 70 * 45);
    CHECK(s == 1.0);
    /* With a mask, and for a constant image. */
    fill_random(&m, 3, 0.0f, 1.0f);
    for (int y = 0; y < m.height; y++)
        for (int x = 0; x < m.width; x++)
            set_px(&m, x, y, px(&m, x, y) < 0.3f ? 0.0f : 1.0f);
    CHECK_OK(met_ssim(ctx, NULL, &a, &a, &m, NULL, &s, &n, NULL), ctx);
    CHECK(n > 0);
    CHECK(s == 1.0);
    obs_image_f32_fill(&a, 0.25f);
    CHECK_OK(met_ssim(ctx, NULL, &a, &a, NULL, NULL, &s, &n, NULL), ctx);
    CHECK(s == 1.0);
    met_result r;
    CHECK_OK(met_compare(ctx, NULL, &a, &a, NULL, NULL, &r), ctx);
    CHECK(r.ssim == 1.0);
    obs_image_f32_free(&a);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}

TEST(ssim_matches_reference_value)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0}, m = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 29, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 29, &b), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 29, &m), ctx);

    /* Constants a and b: sigma = 0, so SSIM = (2ab + C1) / (a^2 + b^2 + C1) everywhere. */
    const double va = 0.3, vb = 0.7, c1 = 0.01 * 0.01;
    obs_image_f32_fill(&a, (float)va);
    obs_image_f32_fill(&b, (float)vb);
    double fa = (float)va, fb = (float)vb;
    double expect = (2 * fa * fb + c1) / (fa * fa + fb * fb + c1);
    double s;
    int64_t n;
    CHECK_OK(met_ssim(ctx, NULL, &a, &b, NULL, NULL, &s, &n, NULL), ctx);
    CHECK_NEAR(s, expect, 1e-12);
    CHECK_NEAR(expect, 0.7241855, 1e-6); /* (0.42 + 1e-4) / (0.58 + 1e-4) = 0.4201 / 0.5801 */
    /* With L = 2: C1 = (0.02)^2. */
    met_params p = met_params_default();
    p.dynamic_range = 2.0;
    CHECK_OK(met_ssim(ctx, NULL, &a, &b, NULL, &p, &s, &n, NULL), ctx);
    CHECK_NEAR(s, (2 * fa * fb + 4e-4) / (fa * fa + fb * fb + 4e-4), 1e-12);

    /* Noisy structured images against the direct O(N * 121) implementation, with and without a
     * mask (a hole and a ragged region, so that some windows fall under half valid). */
    fill_structured(&a, 11);
    fill_structured(&b, 12);
    int64_t nd;
    double sd = ssim_direct(&a, &b, NULL, 1.0, &nd);
    CHECK_OK(met_ssim(ctx, NULL, &a, &b, NULL, NULL, &s, &n, NULL), ctx);
    CHECK_EQ_INT(n, nd);
    CHECK_NEAR(s, sd, 1e-12);
    CHECK(s > 0.05 && s < 0.99);
    for (int y = 0; y < m.height; y++)
        for (int x = 0; x < m.width; x++) {
            int hole = (x - 18) * (x - 18) + (y - 14) * (y - 14) < 40;
            int ragged = x > 25 && ((x + y) % 3 != 0);
            set_px(&m, x, y, hole || ragged ? 0.0f : 1.0f);
        }
    sd = ssim_direct(&a, &b, &m, 1.0, &nd);
    CHECK_OK(met_ssim(ctx, NULL, &a, &b, &m, NULL, &s, &n, NULL), ctx);
    CHECK_EQ_INT(n, nd);
    CHECK(n < 37 * 29 - 150); /* the mask and the half-weight rule removed pixels */
    CHECK_NEAR(s, sd, 1e-12);

    /* An image taller than one strip, to cross strip borders. */
    obs_image_f32 big_a = {0}, big_b = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 23, 150, &big_a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 23, 150, &big_b), ctx);
    fill_structured(&big_a, 21);
    fill_structured(&big_b, 22);
    sd = ssim_direct(&big_a, &big_b, NULL, 1.0, &nd);
    CHECK_OK(met_ssim(ctx, NULL, &big_a, &big_b, NULL, NULL, &s, &n, NULL), ctx);
    CHECK_EQ_INT(n, nd);
    CHECK_NEAR(s, sd, 1e-12);
    obs_image_f32_free(&big_a);
    obs_image_f32_free(&big_b);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}

TEST(ssim_is_symmetric_and_at_most_one)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0}, map = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 50, 40, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 50, 40, &b), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 50, 40, &map), ctx);
    for (uint64_t seed = 1; seed <= 4; seed++) {
        fill_structured(&a, seed);
        if (seed == 4)
            fill_random(&b, 99, 0.0f, 1.0f);
        else
            fill_structured(&b, seed + 100);
        double sab, sba;
        int64_t n1, n2;
        CHECK_OK(met_ssim(ctx, NULL, &a, &b, NULL, NULL, &sab, &n1, &map), ctx);
        CHECK_OK(met_ssim(ctx, NULL, &b, &a, NULL, NULL, &sba, &n2, NULL), ctx);
        CHECK(sab == sba);
        CHECK_EQ_INT(n1, n2);
        CHECK(sab <= 1.0 && sab >= -1.0);
        for (int y = 0; y < map.height; y++)
            for (int x = 0; x < map.width; x++)
                CHECK(px(&map, x, y) <= 1.0f + 1e-6f && px(&map, x, y) >= -1.0f - 1e-6f);
    }
    /* A negated-contrast image gives SSIM well below zero locally; still >= -1. */
    for (int y = 0; y < a.height; y++)
        for (int x = 0; x < a.width; x++)
            set_px(&b, x, y, 1.0f - px(&a, x, y));
    double s;
    CHECK_OK(met_ssim(ctx, NULL, &a, &b, NULL, NULL, &s, NULL, NULL), ctx);
    CHECK(s < 0.0 && s >= -1.0);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_image_f32_free(&map);
    obs_context_destroy(ctx);
}

/* ---- masks and non-finite values ---------------------------------------------------------- */

TEST(mask_excludes_pixels)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0}, m = {0};
    const int W = 40, H = 30;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &b), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &m), ctx);
    fill_structured(&a, 5);
    fill_structured(&b, 5);
    obs_image_f32_fill(&m, 1.0f);
    /* Wreck the test image where the mask is 0 (or NaN): huge errors, NaN, infinity. */
    int64_t masked = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if ((x * 7 + y * 3) % 5 == 0) {
                set_px(&m, x, y, (x % 2) ? 0.0f : NAN);
                set_px(&b, x, y, (y % 3 == 0) ? NAN : (y % 3 == 1) ? INFINITY : 100.0f);
                masked++;
            }
    met_result r;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, &m, NULL, &r), ctx);
    CHECK_EQ_INT(r.masked, masked);
    CHECK_EQ_INT(r.valid, W * H - masked);
    CHECK_EQ_INT(r.nonfinite, 0);
    CHECK(r.mse == 0.0 && r.max_abs == 0.0);
    CHECK(r.ssim == 1.0);
    /* The fit uses the same valid pixels: on the masked identity it recovers g = 1, p = 1. */
    met_fit f;
    CHECK_OK(met_fit_gain_power(ctx, NULL, &a, &b, &m, NULL, &f), ctx);
    CHECK_EQ_INT(f.count, W * H - masked);
    CHECK_NEAR(f.gain, 1.0, 1e-6);
    CHECK_NEAR(f.power, 1.0, 1e-6);
    /* Mask values other than 0 and NaN count as valid (2, -1, inf): these pixels hold 100. */
    CHECK(px(&b, 2, 2) == 100.0f && px(&b, 7, 2) == 100.0f && px(&b, 12, 2) == 100.0f);
    set_px(&m, 2, 2, 2.0f);
    set_px(&m, 7, 2, -1.0f);
    set_px(&m, 12, 2, INFINITY);
    CHECK_OK(met_compare(ctx, NULL, &a, &b, &m, NULL, &r), ctx);
    CHECK_EQ_INT(r.valid, W * H - masked + 3);
    CHECK(r.max_abs > 99.0);
    CHECK_EQ_INT(r.max_x, 2);
    CHECK_EQ_INT(r.max_y, 2);
    /* Without the mask the wrecked pixels are an error (non-finite); with ignore_nonfinite the
     * non-finite ones are skipped and counted. */
    CHECK(met_compare(ctx, NULL, &a, &b, NULL, NULL, &r) == OBS_STATUS_INVALID_ARGUMENT);
    met_params p = met_params_default();
    p.ignore_nonfinite = 1;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r), ctx);
    CHECK(r.max_abs > 99.0);
    CHECK(r.nonfinite > 0);
    CHECK_EQ_INT(r.valid + r.nonfinite, W * H);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}

TEST(nonfinite_inputs_are_reported)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 6, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 6, &b), ctx);
    obs_image_f32_fill(&a, 0.5f);
    obs_image_f32_fill(&b, 0.5f);
    set_px(&b, 3, 2, NAN);
    met_result r;
    obs_context_clear_error(ctx);
    CHECK(met_compare(ctx, NULL, &a, &b, NULL, NULL, &r) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(r.first_nonfinite_x, 3);
    CHECK_EQ_INT(r.first_nonfinite_y, 2);
    CHECK_EQ_INT(r.first_nonfinite_input, MET_INPUT_TEST);
    CHECK(isnan(r.first_nonfinite_value));
    CHECK(isnan(r.rmse));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "(3, 2)") && strstr(obs_context_last_error(ctx), "test"),
              "message: %s", obs_context_last_error(ctx));
    /* An earlier infinity in the reference is named first. */
    set_px(&a, 6, 1, -INFINITY);
    obs_context_clear_error(ctx);
    CHECK(met_compare(ctx, NULL, &a, &b, NULL, NULL, &r) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(r.first_nonfinite_x, 6);
    CHECK_EQ_INT(r.first_nonfinite_y, 1);
    CHECK_EQ_INT(r.first_nonfinite_input, MET_INPUT_REFERENCE);
    CHECK_EQ_INT(r.nonfinite, 2);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "reference") && strstr(obs_context_last_error(ctx), "-inf"),
              "message: %s", obs_context_last_error(ctx));
    /* The other entry points apply the same rule. */
    double s;
    met_fit f;
    CHECK(met_ssim(ctx, NULL, &a, &b, NULL, NULL, &s, NULL, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(met_fit_gain_power(ctx, NULL, &a, &b, NULL, NULL, &f) == OBS_STATUS_INVALID_ARGUMENT);
    /* ignore_nonfinite: skipped and counted. */
    met_params p = met_params_default();
    p.ignore_nonfinite = 1;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, NULL, &p, &r), ctx);
    CHECK_EQ_INT(r.nonfinite, 2);
    CHECK_EQ_INT(r.valid, 48 - 2);
    CHECK(r.mse == 0.0);
    CHECK(r.ssim == 1.0);
    CHECK_EQ_INT(r.first_nonfinite_input, MET_INPUT_REFERENCE);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

/* ---- calibrated fit ----------------------------------------------------------------------- */

static void synthesize_inverse(const obs_image_f32 *ref, double g, double p, obs_image_f32 *test)
{
    /* ref = 1 - g (1 - v^p)  <=>  v = (1 - (1 - ref) / g)^(1/p) */
    for (int y = 0; y < ref->height; y++)
        for (int x = 0; x < ref->width; x++) {
            double r = px(ref, x, y);
            set_px(test, x, y, (float)pow(1.0 - (1.0 - r) / g, 1.0 / p));
        }
}

TEST(calibrated_fit_recovers_known_gain_and_power)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 r = {0}, t = {0}, c = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &r), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &t), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &c), ctx);
    const double cases[4][2] = {{1.3, 1.7}, {0.6, 0.5}, {1.0, 1.0}, {2.0, 3.5}};
    for (int k = 0; k < 4; k++) {
        double g = cases[k][0], p = cases[k][1];
        /* reference visibility in [1 - 0.9 g, 1] keeps (1 - r)/g <= 0.9 */
        double lo = 1.0 - 0.9 * g;
        fill_random(&r, 40 + (uint64_t)k, (float)(lo > 0.0 ? lo : 0.0), 1.0f);
        synthesize_inverse(&r, g, p, &t);
        met_fit f;
        CHECK_OK(met_fit_gain_power(ctx, NULL, &r, &t, NULL, NULL, &f), ctx);
        CHECK_MSG(fabs(f.gain - g) <= 1e-3 && fabs(f.power - p) <= 1e-3,
                  "case %d: fitted g %.9g p %.9g, expected %g %g (%d evaluations)", k, f.gain, f.power, g, p,
                  f.evaluations);
        CHECK_EQ_INT(f.count, 64 * 48);
        CHECK(f.fit_rmse < 1e-5);
        CHECK(!f.power_at_bound);
        /* Applying the fit brings the test onto the reference. */
        CHECK_OK(met_apply_gain_power(ctx, &t, f.gain, f.power, &c), ctx);
        met_result m;
        CHECK_OK(met_compare(ctx, NULL, &r, &c, NULL, NULL, &m), ctx);
        CHECK(m.rmse < 1e-5);
        CHECK(m.ssim > 0.9999);
    }
    /* A test without any occlusion: g = p = 1 by definition. */
    obs_image_f32_fill(&t, 1.0f);
    met_fit f;
    CHECK_OK(met_fit_gain_power(ctx, NULL, &r, &t, NULL, NULL, &f), ctx);
    CHECK(f.gain == 1.0 && f.power == 1.0);
    /* Values outside [0, 1] are clamped before the power (no NaN from pow of a negative). */
    fill_random(&t, 77, -0.2f, 1.2f);
    CHECK_OK(met_fit_gain_power(ctx, NULL, &r, &t, NULL, NULL, &f), ctx);
    CHECK(isfinite(f.gain) && isfinite(f.power) && f.gain >= 0.0);
    CHECK_OK(met_apply_gain_power(ctx, &t, f.gain, f.power, &c), ctx);
    for (int y = 0; y < c.height; y++)
        for (int x = 0; x < c.width; x++)
            CHECK(px(&c, x, y) >= 0.0f && px(&c, x, y) <= 1.0f);
    obs_image_f32_free(&r);
    obs_image_f32_free(&t);
    obs_image_f32_free(&c);
    obs_context_destroy(ctx);
}

/* ---- determinism -------------------------------------------------------------------------- */

TEST(metrics_are_independent_of_thread_count)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0}, m = {0};
    const int W = 301, H = 203; /* several strips, odd sizes */
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &b), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &m), ctx);
    fill_structured(&a, 1);
    fill_structured(&b, 2);
    fill_random(&m, 3, 0.0f, 1.0f);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            set_px(&m, x, y, px(&m, x, y) < 0.1f ? 0.0f : 1.0f);
    met_result ref;
    met_fit fref;
    CHECK_OK(met_compare(ctx, NULL, &a, &b, &m, NULL, &ref), ctx);
    CHECK_OK(met_fit_gain_power(ctx, NULL, &a, &b, &m, NULL, &fref), ctx);
    const int threads[4] = {1, 2, 3, 8};
    for (int k = 0; k < 4; k++) {
        obs_pool *pool = obs_pool_create(threads[k]);
        CHECK(pool != NULL);
        for (int rep = 0; rep < 2; rep++) {
            met_result r;
            met_fit f;
            CHECK_OK(met_compare(ctx, pool, &a, &b, &m, NULL, &r), ctx);
            CHECK_OK(met_fit_gain_power(ctx, pool, &a, &b, &m, NULL, &f), ctx);
            CHECK_MSG(!memcmp(&r.mse, &ref.mse, sizeof r.mse) && !memcmp(&r.mae, &ref.mae, sizeof r.mae) &&
                          !memcmp(&r.bias, &ref.bias, sizeof r.bias) && !memcmp(&r.ssim, &ref.ssim, sizeof r.ssim) &&
                          r.max_x == ref.max_x && r.max_y == ref.max_y && r.over_count == ref.over_count &&
                          r.ssim_pixels == ref.ssim_pixels,
                      "%d threads: rmse %.17g vs %.17g, ssim %.17g vs %.17g", threads[k], r.rmse, ref.rmse, r.ssim,
                      ref.ssim);
            CHECK_MSG(!memcmp(&f.gain, &fref.gain, sizeof f.gain) && !memcmp(&f.power, &fref.power, sizeof f.power) &&
                          !memcmp(&f.sse, &fref.sse, sizeof f.sse),
                      "%d threads: fit %.17g %.17g vs %.17g %.17g", threads[k], f.gain, f.power, fref.gain, fref.power);
        }
        obs_pool_destroy(pool);
    }
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}

TEST(metrics_colormap_endpoints_match_inferno)
{
    float c[3];
    met_colormap_inferno(0.0, c);
    CHECK_NEAR(c[0], 0.001462, 1e-6);
    CHECK_NEAR(c[2], 0.013866, 1e-6);
    met_colormap_inferno(1.0, c);
    CHECK_NEAR(c[0], 0.988362, 1e-6);
    CHECK_NEAR(c[1], 0.998364, 1e-6);
    CHECK_NEAR(c[2], 0.644924, 1e-6);
    met_colormap_inferno(5.0, c); /* clamped */
    CHECK_NEAR(c[1], 0.998364, 1e-6);
    met_colormap_inferno(NAN, c);
    CHECK_NEAR(c[0], 0.001462, 1e-6);
    /* matplotlib's entry 128 (t = 128/255) is (0.735683, 0.215906, 0.330245). */
    met_colormap_inferno(128.0 / 255.0, c);
    CHECK_NEAR(c[0], 0.735683, 6e-3);
    CHECK_NEAR(c[1], 0.215906, 6e-3);
    CHECK_NEAR(c[2], 0.330245, 6e-3);
    /* Monotone luminance-ish: the red channel never falls much along the ramp. */
    float prev = -1.0f;
    for (int i = 0; i <= 100; i++) {
        met_colormap_inferno(i / 100.0, c);
        float lum = 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
        CHECK(lum >= prev - 1e-6f);
        prev = lum;
    }
}

/* ---- the flat baseline and the skill score [Murphy88] ------------------------------------- */

/* Fit test to ref, apply the fit, score the calibrated image: its skill against the flat baseline. */
static met_skill calibrated_skill(obs_context *ctx, const obs_image_f32 *ref, const obs_image_f32 *test, met_fit *f)
{
    obs_image_f32 c = {0};
    met_skill s = {NAN, NAN, NAN};
    met_result m;
    if (obs_image_f32_alloc(ctx, ref->width, ref->height, &c) == OBS_STATUS_OK &&
        met_fit_gain_power(ctx, NULL, ref, test, NULL, NULL, f) == OBS_STATUS_OK &&
        met_apply_gain_power(ctx, test, f->gain, f->power, &c) == OBS_STATUS_OK &&
        met_compare(ctx, NULL, ref, &c, NULL, NULL, &m) == OBS_STATUS_OK)
        s = met_skill_of(m.mse, m.ref_var, 0.0);
    obs_image_f32_free(&c);
    return s;
}

TEST(metrics_skill_and_baseline_match_hand_values)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 r = {0}, t = {0}, m = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 2, 2, &r), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 2, 2, &t), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 2, 2, &m), ctx);
    /* reference 0.25, 0.5, 0.75, 1 (exact in float): mean 0.625, variance (0.140625 + 0.015625 +
     * 0.015625 + 0.140625) / 4 = 0.078125; test off by 0.25 at one pixel: mse 0.015625 */
    const float rv[4] = {0.25f, 0.5f, 0.75f, 1.0f}, tv[4] = {0.25f, 0.5f, 0.75f, 0.75f};
    fill_values(&r, rv);
    fill_values(&t, tv);
    met_result res;
    CHECK_OK(met_compare(ctx, NULL, &r, &t, NULL, NULL, &res), ctx);
    CHECK_NEAR(res.ref_var, 0.078125, 1e-15);
    met_skill s = met_skill_of(res.mse, res.ref_var, 0.0);
    CHECK_NEAR(s.baseline_rmse, sqrt(0.078125), 1e-15);
    CHECK_NEAR(s.rmse, 0.125, 1e-15);
    CHECK_NEAR(s.skill, 1.0 - 0.015625 / 0.078125, 1e-14); /* 0.8 */
    /* the same noise variance taken out of both: (0.015625 - 0.0078125) / (0.078125 - 0.0078125) */
    s = met_skill_of(res.mse, res.ref_var, 0.0078125);
    CHECK_NEAR(s.baseline_rmse, sqrt(0.0703125), 1e-15);
    CHECK_NEAR(s.skill, 1.0 - 0.0078125 / 0.0703125, 1e-14);
    /* a noise larger than the error: the corrected error is 0, the skill 1 */
    s = met_skill_of(res.mse, res.ref_var, 0.02);
    CHECK(s.rmse == 0.0 && s.skill == 1.0);
    /* a flat reference: nothing beats a flat image, the skill is undefined */
    s = met_skill_of(0.01, 0.0, 0.0);
    CHECK(s.baseline_rmse == 0.0 && isnan(s.skill));
    s = met_skill_of(NAN, 0.1, 0.0);
    CHECK(isnan(s.skill) && isnan(s.baseline_rmse));
    /* the variance is over the valid pixels only: without the pixel at 1, (0.25, 0.5, 0.75) has
     * variance 0.125 / 3 */
    const float mv[4] = {1, 1, 1, 0};
    fill_values(&m, mv);
    CHECK_OK(met_compare(ctx, NULL, &r, &t, &m, NULL, &res), ctx);
    CHECK_NEAR(res.ref_var, 0.125 / 3.0, 1e-15);
    CHECK_EQ_INT(res.valid, 3);
    obs_image_f32_free(&r);
    obs_image_f32_free(&t);
    obs_image_f32_free(&m);
    /* over many strips and a large offset (where sum(a^2) - n mean^2 cancels), the merged variance
     * matches a two-pass one over the image and does not depend on the thread count */
    CHECK_OK(obs_image_f32_alloc(ctx, 97, 301, &r), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 97, 301, &t), ctx);
    fill_random(&r, 5, 1000.0f, 1000.25f);
    fill_random(&t, 6, 1000.0f, 1000.25f);
    double mean = 0.0, v2 = 0.0;
    for (int y = 0; y < r.height; y++)
        for (int x = 0; x < r.width; x++)
            mean += px(&r, x, y);
    mean /= 97.0 * 301.0;
    for (int y = 0; y < r.height; y++)
        for (int x = 0; x < r.width; x++)
            v2 += (px(&r, x, y) - mean) * (px(&r, x, y) - mean);
    v2 /= 97.0 * 301.0;
    met_params mp = met_params_default();
    mp.compute_ssim = 0;
    CHECK_OK(met_compare(ctx, NULL, &r, &t, NULL, &mp, &res), ctx);
    CHECK_MSG(fabs(res.ref_var - v2) <= 1e-9 * v2, "variance %.17g, two-pass %.17g", res.ref_var, v2);
    obs_pool *pool = obs_pool_create(3);
    met_result res3;
    CHECK_OK(met_compare(ctx, pool, &r, &t, NULL, &mp, &res3), ctx);
    CHECK(res3.ref_var == res.ref_var);
    obs_pool_destroy(pool);
    obs_image_f32_free(&r);
    obs_image_f32_free(&t);
    obs_context_destroy(ctx);
}

/* The calibrated fit turns an uninformative test into about the reference's mean: its calibrated
 * RMSE is then the flat baseline, and the skill says so (about 0, or below); an inverted image
 * gains nothing either; a perfect image has skill 1; a noisy but informative one lies between. */
TEST(metrics_skill_separates_informative_from_flat_tests)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 r = {0}, t = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 96, 80, &r), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 96, 80, &t), ctx);
    fill_structured(&r, 11);
    for (int y = 0; y < r.height; y++) /* keep the reference a visibility in [0, 1] */
        for (int x = 0; x < r.width; x++)
            set_px(&r, x, y, fminf(1.0f, fmaxf(0.0f, px(&r, x, y))));
    met_fit f;
    /* constant */
    obs_image_f32_fill(&t, 0.7f);
    met_skill s = calibrated_skill(ctx, &r, &t, &f);
    CHECK_MSG(fabs(s.skill) <= 1e-4 && (f.power_at_bound || s.skill <= 1e-9), "constant: skill %.3g, p %g", s.skill,
              f.power);
    /* its calibrated RMSE is the flat baseline */
    CHECK_MSG(fabs(s.rmse - s.baseline_rmse) <= 1e-4, "constant: rmse %g, baseline %g", s.rmse, s.baseline_rmse);
    /* inverted */
    for (int y = 0; y < r.height; y++)
        for (int x = 0; x < r.width; x++)
            set_px(&t, x, y, 1.0f - px(&r, x, y));
    s = calibrated_skill(ctx, &r, &t, &f);
    CHECK_MSG(s.skill <= 1e-9, "inverted: skill %.3g (p %g, at bound %d)", s.skill, f.power, f.power_at_bound);
    /* perfect */
    met_result res;
    CHECK_OK(met_compare(ctx, NULL, &r, &r, NULL, NULL, &res), ctx);
    s = met_skill_of(res.mse, res.ref_var, 0.0);
    CHECK(s.skill == 1.0 && s.rmse == 0.0);
    s = calibrated_skill(ctx, &r, &r, &f);
    CHECK_MSG(s.skill > 1.0 - 1e-6 && !f.power_at_bound, "perfect, calibrated: skill %.9g", s.skill);
    /* noisy but informative: the reference plus uniform noise of variance 0.1^2 / 12 */
    for (int y = 0; y < r.height; y++)
        for (int x = 0; x < r.width; x++)
            set_px(&t, x, y, px(&r, x, y) + 0.1f * (obs_rng_float((uint64_t)(y * 96 + x), 0, 3, 21) - 0.5f));
    CHECK_OK(met_compare(ctx, NULL, &r, &t, NULL, NULL, &res), ctx);
    s = met_skill_of(res.mse, res.ref_var, 0.0);
    const double want = 1.0 - (0.01 / 12.0) / res.ref_var;
    CHECK_MSG(s.skill > 0.0 && s.skill < 1.0 && fabs(s.skill - want) < 0.05, "noisy: skill %g, about %g", s.skill, want);
    double raw_skill = s.skill;
    s = calibrated_skill(ctx, &r, &t, &f);
    CHECK_MSG(s.skill > 0.0 && s.skill < 1.0 && s.skill >= raw_skill - 0.05 && !f.power_at_bound,
              "noisy, calibrated: skill %g (raw %g)", s.skill, raw_skill);
    obs_image_f32_free(&r);
    obs_image_f32_free(&t);
    obs_context_destroy(ctx);
}
