/* test_ao_blur.c: the shared post-process blurs (src/ao/ao_blur.c): the seed's 21-tap Gaussian
 * against an independent double-precision convolution, its kernel against the Gaussian it encodes,
 * the shader's accumulation order, clamp-to-edge, thread counts, bad input; ao_blur_reach. */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static float lcg01(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (float)(*s >> 8) * (1.0f / 16777216.0f);
}

TEST(ao_gauss21_kernel_is_the_normalised_sigma_2sqrt2_gaussian)
{
    double sum = 0.0;
    for (int i = -AO_GAUSS21_RADIUS; i <= AO_GAUSS21_RADIUS; i++)
        sum += exp(-(double)(i * i) / 16.0);
    for (int i = -AO_GAUSS21_RADIUS; i <= AO_GAUSS21_RADIUS; i++) {
        const double w = exp(-(double)(i * i) / 16.0) / sum;
        /* printed with 9 decimals in the shader */
        CHECK_MSG(fabs((double)ao_gauss21_kernel[i + AO_GAUSS21_RADIUS] - w) < 6e-10 + 1e-7 * w,
                  "kernel[%d] = %.9g, Gaussian %.9g", i + AO_GAUSS21_RADIUS,
                  (double)ao_gauss21_kernel[i + AO_GAUSS21_RADIUS], w);
        CHECK(ao_gauss21_kernel[i + AO_GAUSS21_RADIUS] == ao_gauss21_kernel[AO_GAUSS21_RADIUS - i]);
    }
}

/* Independent reference: the same separable sum in double with clamp-to-edge. */
static double ref_blur(const obs_image_f32 *a, int x, int y)
{
    double acc = 0.0;
    for (int j = -AO_GAUSS21_RADIUS; j <= AO_GAUSS21_RADIUS; j++) {
        int yy = y + j < 0 ? 0 : y + j >= a->height ? a->height - 1 : y + j;
        double row = 0.0;
        for (int i = -AO_GAUSS21_RADIUS; i <= AO_GAUSS21_RADIUS; i++) {
            int xx = x + i < 0 ? 0 : x + i >= a->width ? a->width - 1 : x + i;
            row += (double)ao_gauss21_kernel[i + AO_GAUSS21_RADIUS] * obs_image_f32_row(a, yy)[xx];
        }
        acc += (double)ao_gauss21_kernel[j + AO_GAUSS21_RADIUS] * row;
    }
    return acc;
}

TEST(ao_gauss21_matches_double_convolution_with_clamp_to_edge)
{
    obs_context *ctx = obs_context_create();
    const int sizes[4][2] = {{1, 1}, {7, 3}, {37, 23}, {64, 41}};
    for (int s = 0; s < 4; s++) {
        obs_image_f32 a = {0}, b = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, sizes[s][0], sizes[s][1], &a), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, sizes[s][0], sizes[s][1], &b), ctx);
        uint32_t seed = 12345u + (uint32_t)s;
        for (int y = 0; y < a.height; y++)
            for (int x = 0; x < a.width; x++)
                obs_image_f32_row(&a, y)[x] = lcg01(&seed);
        CHECK_OK(ao_blur_gaussian21(ctx, NULL, &a, &b), ctx);
        double maxerr = 0.0;
        for (int y = 0; y < a.height; y++)
            for (int x = 0; x < a.width; x++) {
                double e = fabs(obs_image_f32_row(&b, y)[x] - ref_blur(&a, x, y));
                maxerr = e > maxerr ? e : maxerr;
            }
        /* 42 float additions of values <= 1: a few ulps of 1 */
        CHECK_MSG(maxerr < 2e-6, "%dx%d: max error %.3g against the double convolution", a.width, a.height, maxerr);
        obs_image_f32_free(&a);
        obs_image_f32_free(&b);
    }
    obs_context_destroy(ctx);
}

TEST(ao_gauss21_accumulates_in_the_shader_order)
{
    /* An impulse at (x, y) of a tall image: the vertical pass at row y - i picks up
     * kernel[10 - i] * h, where h is the horizontal pass's value; every output is one product, so
     * the result is exact, and any left/right or up/down mix-up of the asymmetric test image below
     * would show. The order of additions is checked on a ramp: in float the sum
     * sum_{i=-10..10} k[10-i] * v(y - i) in that order is one specific rounding. */
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0};
    const int W = 3, H = 41;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &b), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&a, y)[x] = 1.0f / (float)(1 + y * y); /* strongly asymmetric in y */
    CHECK_OK(ao_blur_gaussian21(ctx, NULL, &a, &b), ctx);
    const int y = 20;
    /* horizontal pass: a constant row v sums to v * (the float sum of the kernel in order) */
    float h[41];
    for (int r = 0; r < H; r++) {
        float c = 0.0f;
        for (int i = -10; i <= 10; i++)
            c += ao_gauss21_kernel[10 - i] * obs_image_f32_row(&a, r)[1];
        h[r] = c;
    }
    float v = 0.0f;
    for (int i = -10; i <= 10; i++)
        v += ao_gauss21_kernel[10 - i] * h[y - i];
    float v_rev = 0.0f;
    for (int i = 10; i >= -10; i--)
        v_rev += ao_gauss21_kernel[10 - i] * h[y - i];
    CHECK_MSG(obs_image_f32_row(&b, y)[1] == v, "got %.9g, shader order gives %.9g (reverse order %.9g)",
              (double)obs_image_f32_row(&b, y)[1], (double)v, (double)v_rev);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

TEST(ao_gauss21_keeps_constants_and_is_thread_count_independent)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, ref = {0}, b = {0};
    const int W = 97, H = 61;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ref), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &b), ctx);
    obs_image_f32_fill(&a, 1.0f);
    CHECK_OK(ao_blur_gaussian21(ctx, NULL, &a, &ref), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            CHECK_MSG(fabsf(obs_image_f32_row(&ref, y)[x] - 1.0f) < 3e-7f, "constant 1 -> %.9g at (%d,%d)",
                      (double)obs_image_f32_row(&ref, y)[x], x, y);
    uint32_t seed = 7u;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&a, y)[x] = lcg01(&seed);
    CHECK_OK(ao_blur_gaussian21(ctx, NULL, &a, &ref), ctx);
    const int threads[2] = {2, 8};
    for (int t = 0; t < 2; t++) {
        obs_pool *pool = obs_pool_create(threads[t]);
        CHECK(pool != NULL);
        CHECK_OK(ao_blur_gaussian21(ctx, pool, &a, &b), ctx);
        CHECK_MSG(tu_same_plane(&ref, &b), "%d threads differ from 1", threads[t]);
        obs_pool_destroy(pool);
    }
    obs_image_f32_free(&a);
    obs_image_f32_free(&ref);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

TEST(ao_gauss21_rejects_bad_planes)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 a = {0}, b = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 8, &a), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 7, &b), ctx);
    CHECK(ao_blur_gaussian21(ctx, NULL, NULL, &b) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_blur_gaussian21(ctx, NULL, &a, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_clear_error(ctx);
    CHECK(ao_blur_gaussian21(ctx, NULL, &a, &b) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "same non-zero size") != NULL);
    obs_context_clear_error(ctx);
    CHECK(ao_blur_gaussian21(ctx, NULL, &a, &a) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "alias") != NULL);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_context_destroy(ctx);
}

TEST(ao_blur_reach_grows_the_window_and_clips_to_the_buffer)
{
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = 100;
    in.height = 50;
    in.x0 = 4;
    in.y0 = 20;
    in.w = 90;
    in.h = 10;
    int r[4];
    ao_blur_reach(&in, 10, r);
    CHECK_EQ_INT(r[0], 0);
    CHECK_EQ_INT(r[1], 10);
    CHECK_EQ_INT(r[2], 100);
    CHECK_EQ_INT(r[3], 30);
    ao_blur_reach(&in, 0, r);
    CHECK(r[0] == 4 && r[1] == 20 && r[2] == 90 && r[3] == 10);
    ao_blur_reach(&in, -3, r);
    CHECK(r[0] == 4 && r[1] == 20 && r[2] == 90 && r[3] == 10);
}

/* The blur's loops run over whole rows (vectorised across x); every pixel must still get exactly the
 * shader's per-pixel sum, bit for bit: computed here pixel by pixel, in the shader's order. */
TEST(ao_gauss21_equals_the_per_pixel_shader_sum_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    const int sizes[3][2] = {{1, 1}, {23, 5}, {131, 77}};
    for (int s = 0; s < 3; s++) {
        const int W = sizes[s][0], H = sizes[s][1];
        obs_image_f32 a = {0}, b = {0}, h = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &a), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &b), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &h), ctx);
        uint32_t seed = 99u + (uint32_t)s;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                obs_image_f32_row(&a, y)[x] = lcg01(&seed) * (x % 3 ? 1.0f : 1e-3f);
        obs_pool *pool = obs_pool_create(2);
        CHECK_OK(ao_blur_gaussian21(ctx, pool, &a, &b), ctx);
        obs_pool_destroy(pool);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float c = 0.0f;
                for (int i = -10; i <= 10; i++) {
                    int xx = x + i < 0 ? 0 : x + i >= W ? W - 1 : x + i;
                    c += ao_gauss21_kernel[10 - i] * obs_image_f32_row(&a, y)[xx];
                }
                obs_image_f32_row(&h, y)[x] = c;
            }
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float c = 0.0f;
                for (int i = -10; i <= 10; i++) {
                    int yy = y - i < 0 ? 0 : y - i >= H ? H - 1 : y - i;
                    c += ao_gauss21_kernel[10 - i] * obs_image_f32_row(&h, yy)[x];
                }
                CHECK_MSG(c == obs_image_f32_row(&b, y)[x], "%dx%d: (%d,%d) = %.9g, per-pixel sum %.9g", W, H, x, y,
                          (double)obs_image_f32_row(&b, y)[x], (double)c);
            }
        obs_image_f32_free(&a);
        obs_image_f32_free(&b);
        obs_image_f32_free(&h);
    }
    obs_context_destroy(ctx);
}
