/* ao_blur.c: the shared post-process blurs (ao.h, "Shared post-process blurs").
 *
 * The seed thesis' 21-tap separable Gaussian (ssao-thesis-2017 §4.2.3, Figura 31), whose kernel is
 * the one of Movania's OpenGL Development Cookbook SSAO recipe (the same `kernel[index--]` loop
 * over i = -10..10): w_i = exp(-i^2/16) / sum_{j=-10..10} exp(-j^2/16), a Gaussian with
 * sigma = 2*sqrt(2) px normalised over the 21 taps, written with 9 decimals. docs/ao/blur.md. */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <string.h>

/* The shader's constant array, kernel[0..20], as printed (float literals). kernel[index--] with
 * index = 20 at i = -10 reads kernel[10 - i]; the array is symmetric. */
const float ao_gauss21_kernel[2 * AO_GAUSS21_RADIUS + 1] = {
    0.000272337f, 0.00089296f,  0.002583865f, 0.00659813f,  0.014869116f, 0.029570767f, 0.051898313f,
    0.080381679f, 0.109868729f, 0.132526984f, 0.14107424f,  0.132526984f, 0.109868729f, 0.080381679f,
    0.051898313f, 0.029570767f, 0.014869116f, 0.00659813f,  0.002583865f, 0.00089296f,  0.000272337f,
};

typedef struct gauss_job {
    const obs_image_f32 *src;
    obs_image_f32 *dst;
    int vertical;
} gauss_job;

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Rows per task: enough work per task for the pool, few enough tasks for two threads to balance. */
#define GAUSS_ROWS_PER_TASK 8

/* One band of output rows. Every output value is the shader's sum
 *     c = 0; for i = -10..10: c += kernel[10 - i] * tap(i)
 * (Figura 31), accumulated in float in exactly that order. Horizontal taps are at x + i; vertical
 * taps at GL row y_gl + i, which is our row y - i (ao.h: rows run downwards here, upwards in GL), so
 * the same float additions happen in the same order as on the GPU. Taps outside clamp to the edge
 * (GL_CLAMP_TO_EDGE). Offsets land on texel centres, where GL_LINEAR and GL_NEAREST agree.
 *
 * The loops run i outside and x inside, over a whole row at once (a row padded with its clamped
 * edge texels for the horizontal pass): each pixel's sum still takes its 21 terms in the order
 * above, so the compiler's vectorisation across x (plain IEEE lanes, no FMA: -ffp-contract=off)
 * cannot change a bit; test ao_gauss21_accumulates_in_the_shader_order checks it. */
static void gauss_band(void *user, int64_t task, int thread)
{
    (void)thread;
    const gauss_job *j = (const gauss_job *)user;
    const int W = j->src->width, H = j->src->height, R = AO_GAUSS21_RADIUS;
    const int y0 = (int)task * GAUSS_ROWS_PER_TASK;
    const int y1 = y0 + GAUSS_ROWS_PER_TASK < H ? y0 + GAUSS_ROWS_PER_TASK : H;
    float *pad = NULL;
    if (!j->vertical) {
        pad = (float *)obs_aligned_alloc(sizeof(float) * (size_t)(W + 2 * R));
        if (!pad) { /* cannot happen for sizes the caller allocated; fall back to clamped taps */
            for (int y = y0; y < y1; y++) {
                const float *s = obs_image_f32_row(j->src, y);
                float *o = obs_image_f32_row(j->dst, y);
                for (int x = 0; x < W; x++) {
                    float c = 0.0f;
                    for (int i = -R; i <= R; i++)
                        c += ao_gauss21_kernel[R - i] * s[clampi(x + i, 0, W - 1)];
                    o[x] = c;
                }
            }
            return;
        }
    }
    for (int y = y0; y < y1; y++) {
        float *restrict o = obs_image_f32_row(j->dst, y);
        for (int x = 0; x < W; x++)
            o[x] = 0.0f;
        if (!j->vertical) {
            const float *s = obs_image_f32_row(j->src, y);
            for (int k = 0; k < R; k++) {
                pad[k] = s[0];
                pad[W + R + k] = s[W - 1];
            }
            memcpy(pad + R, s, sizeof(float) * (size_t)W);
            for (int i = -R; i <= R; i++) {
                const float w = ao_gauss21_kernel[R - i];
                const float *restrict t = pad + R + i;
                for (int x = 0; x < W; x++)
                    o[x] += w * t[x];
            }
        } else {
            for (int i = -R; i <= R; i++) {
                const float w = ao_gauss21_kernel[R - i];
                const float *restrict t = obs_image_f32_row(j->src, clampi(y - i, 0, H - 1));
                for (int x = 0; x < W; x++)
                    o[x] += w * t[x];
            }
        }
    }
    obs_aligned_free(pad);
}

obs_status ao_blur_gaussian21(obs_context *ctx, obs_pool *pool, const obs_image_f32 *in, obs_image_f32 *out)
{
    return ao_i_blur_gaussian21_ws(ctx, pool, NULL, in, out);
}

obs_status ao_i_blur_gaussian21_ws(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const obs_image_f32 *in,
                                   obs_image_f32 *out)
{
    if (!in || !out || !in->data || !out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_blur_gaussian21: NULL plane");
    if (in->data == out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_blur_gaussian21: input and output may not alias");
    if (in->width < 1 || in->height < 1 || out->width != in->width || out->height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao_blur_gaussian21: planes must have the same non-zero size (in %dx%d, out %dx%d)",
                         in->width, in->height, out->width, out->height);
    obs_image_f32 tmp = {0};
    obs_status st = ws ? ao_i_ws_plane(ctx, ws, in->width, in->height, &tmp)
                       : obs_image_f32_alloc(ctx, in->width, in->height, &tmp);
    if (st != OBS_STATUS_OK)
        return st;
    gauss_job h = {in, &tmp, 0}, v = {&tmp, out, 1};
    const int64_t bands = (in->height + GAUSS_ROWS_PER_TASK - 1) / GAUSS_ROWS_PER_TASK;
    obs_pool_run(pool, bands, gauss_band, &h);
    obs_pool_run(pool, bands, gauss_band, &v);
    if (!ws)
        obs_image_f32_free(&tmp);
    return OBS_STATUS_OK;
}

void ao_blur_reach(const ao_input *in, int reach, int rect[4])
{
    if (reach < 0)
        reach = 0;
    int x0 = in->x0 - reach, y0 = in->y0 - reach;
    int x1 = in->x0 + in->w + reach, y1 = in->y0 + in->h + reach;
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > in->width ? in->width : x1;
    y1 = y1 > in->height ? in->height : y1;
    rect[0] = x0;
    rect[1] = y0;
    rect[2] = x1 - x0;
    rect[3] = y1 - y0;
}

void ao_i_background_to_one(const ao_input *in, int y, float *row)
{
    const float *d = obs_image_f32_row(in->depth, in->y0 + y) + in->x0;
    for (int x = 0; x < in->w; x++) /* a select, not a branch: the loop vectorises */
        row[x] = d[x] > 0.0f && d[x] < INFINITY ? row[x] : 1.0f;
}
