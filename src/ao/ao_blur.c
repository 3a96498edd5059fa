/* ao_blur.c: the shared post-process blurs (ao.h, "Shared post-process blurs").
 *
 * The seed thesis' 21-tap separable Gaussian (ssao-thesis-2017 §4.2.3, Figura 31), whose kernel is
 * the one of Movania's OpenGL Development Cookbook SSAO recipe (the same `kernel[index--]` loop
 * over i = -10..10): w_i = exp(-i^2/16) / sum_{j=-10..10} exp(-j^2/16), a Gaussian with
 * sigma = 2*sqrt(2) px normalised over the 21 taps, written with 9 decimals. docs/ao/blur.md. */
#include "ao.h"

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

/* One output row. The sum runs i = -10..10 in the shader's order, color += kernel[10 - i] * tap,
 * starting from 0 (Figura 31). Horizontal taps are at x + i. Vertical taps are at GL row
 * y_gl + i, which is our row y - i (ao.h: rows run downwards here, upwards in GL), so the same
 * float additions happen in the same order as on the GPU. Taps outside clamp to the edge
 * (GL_CLAMP_TO_EDGE). Offsets land on texel centres, where GL_LINEAR and GL_NEAREST agree. */
static void gauss_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const gauss_job *j = (const gauss_job *)user;
    const int y = (int)task, W = j->src->width, H = j->src->height, R = AO_GAUSS21_RADIUS;
    float *o = obs_image_f32_row(j->dst, y);
    if (!j->vertical) {
        const float *s = obs_image_f32_row(j->src, y);
        for (int x = 0; x < W; x++) {
            float c = 0.0f;
            if (x >= R && x + R < W) {
                for (int i = -R; i <= R; i++)
                    c += ao_gauss21_kernel[R - i] * s[x + i];
            } else {
                for (int i = -R; i <= R; i++)
                    c += ao_gauss21_kernel[R - i] * s[clampi(x + i, 0, W - 1)];
            }
            o[x] = c;
        }
        return;
    }
    const float *rows[2 * AO_GAUSS21_RADIUS + 1];
    for (int i = -R; i <= R; i++)
        rows[i + R] = obs_image_f32_row(j->src, clampi(y - i, 0, H - 1));
    for (int x = 0; x < W; x++) {
        float c = 0.0f;
        for (int i = -R; i <= R; i++)
            c += ao_gauss21_kernel[R - i] * rows[i + R][x];
        o[x] = c;
    }
}

obs_status ao_blur_gaussian21(obs_context *ctx, obs_pool *pool, const obs_image_f32 *in, obs_image_f32 *out)
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
    obs_status st = obs_image_f32_alloc(ctx, in->width, in->height, &tmp);
    if (st != OBS_STATUS_OK)
        return st;
    gauss_job h = {in, &tmp, 0}, v = {&tmp, out, 1};
    obs_pool_run(pool, in->height, gauss_row, &h);
    obs_pool_run(pool, in->height, gauss_row, &v);
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
