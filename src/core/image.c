/* image.c: float32 / uint32 planes with explicit strides and overflow-checked allocation. */
#define _DEFAULT_SOURCE /* madvise(MADV_HUGEPAGE) */
#include "obs.h"

#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

void *obs_aligned_alloc(size_t bytes)
{
    /* Blocks of 4 MiB and more (a 1080p float plane is 8.3 MB) are aligned to 2 MiB and advised to
     * use transparent huge pages: on the development VM a 4 KiB page fault costs about 13 us, so
     * first-touching a 1080p plane cost ~26 ms with 4 KiB pages (docs/performance.md). */
    const size_t huge = (size_t)2 << 20;
    size_t rounded;
    if (bytes >= 2 * huge) {
        if (!obs_add_size(bytes, huge - 1, &rounded))
            return NULL;
        rounded &= ~(huge - 1);
        void *p = aligned_alloc(huge, rounded);
#ifdef MADV_HUGEPAGE
        if (p)
            (void)madvise(p, rounded, MADV_HUGEPAGE); /* advice only: failure changes nothing */
#endif
        return p;
    }
    if (!obs_add_size(bytes, 63, &rounded))
        return NULL;
    rounded &= ~(size_t)63;
    if (rounded == 0)
        rounded = 64;
    return aligned_alloc(64, rounded);
}

void obs_aligned_free(void *p) { free(p); }

/* The fill of OBS_POISON_UNINIT=1 (read once): a quiet-bit-clear NaN (signalling) for float planes,
 * the same bits for uint32 planes, so a pixel the producer missed shows up in any byte compare. */
#define OBS_POISON_BITS 0x7FA5A5A5u

static int poison_uninit(void)
{
    /* read at every allocation (a plane allocation dwarfs a getenv), so a test can switch it */
    const char *e = getenv("OBS_POISON_UNINIT");
    return e && e[0] == '1';
}

/* Shared by both element types (4 bytes each): checks sizes and limits. zero: return zeroed
 * memory; otherwise only the row padding (elements width..stride-1) is zeroed, so that a routine
 * reading or hashing whole rows stays deterministic, and the width x height elements are left to
 * the caller (filled with OBS_POISON_BITS when OBS_POISON_UNINIT=1). */
static obs_status plane_alloc(obs_context *ctx, int width, int height, int zero, void **data, ptrdiff_t *stride)
{
    if (width < 1 || height < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "image size %dx%d: both sides must be >= 1",
                         width, height);
    const obs_limits *lim = obs_context_limits(ctx);
    /* Round the row up to 16 elements (64 bytes) so every row starts aligned. */
    size_t row = ((size_t)width + 15) & ~(size_t)15;
    size_t elems, bytes;
    if (!obs_mul_size(row, (size_t)height, &elems) || !obs_mul_size(elems, 4, &bytes))
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "image size %dx%d overflows size_t", width, height);
    if ((int64_t)width * (int64_t)height > lim->max_image_pixels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d has %lld pixels, over the limit of %lld (raise it with --max-pixels)",
                         width, height, (long long)width * height, (long long)lim->max_image_pixels);
    if ((int64_t)bytes > lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d needs %lld bytes, over the limit of %lld (raise it with --max-memory)",
                         width, height, (long long)bytes, (long long)lim->max_memory_bytes);
    void *p = obs_aligned_alloc(bytes);
    if (!p)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes for a %dx%d image", bytes,
                         width, height);
    if (zero) {
        memset(p, 0, bytes);
    } else {
        const int poison = poison_uninit();
        for (int y = 0; y < height; y++) {
            uint32_t *r = (uint32_t *)p + (size_t)y * row;
            if (poison)
                for (int x = 0; x < width; x++)
                    r[x] = OBS_POISON_BITS;
            memset(r + width, 0, (row - (size_t)width) * 4);
        }
    }
    *data = p;
    *stride = (ptrdiff_t)row;
    return OBS_STATUS_OK;
}

static obs_status image_f32_alloc(obs_context *ctx, int width, int height, int zero, obs_image_f32 *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "obs_image_f32_alloc: out is NULL");
    memset(out, 0, sizeof *out);
    void *p = NULL;
    ptrdiff_t stride = 0;
    obs_status st = plane_alloc(ctx, width, height, zero, &p, &stride);
    if (st != OBS_STATUS_OK)
        return st;
    out->data = (float *)p;
    out->width = width;
    out->height = height;
    out->stride = stride;
    return OBS_STATUS_OK;
}

obs_status obs_image_f32_alloc(obs_context *ctx, int width, int height, obs_image_f32 *out)
{
    return image_f32_alloc(ctx, width, height, 1, out);
}

obs_status obs_image_f32_alloc_uninit(obs_context *ctx, int width, int height, obs_image_f32 *out)
{
    return image_f32_alloc(ctx, width, height, 0, out);
}

static obs_status image_u32_alloc(obs_context *ctx, int width, int height, int zero, obs_image_u32 *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "obs_image_u32_alloc: out is NULL");
    memset(out, 0, sizeof *out);
    void *p = NULL;
    ptrdiff_t stride = 0;
    obs_status st = plane_alloc(ctx, width, height, zero, &p, &stride);
    if (st != OBS_STATUS_OK)
        return st;
    out->data = (uint32_t *)p;
    out->width = width;
    out->height = height;
    out->stride = stride;
    return OBS_STATUS_OK;
}

obs_status obs_image_u32_alloc(obs_context *ctx, int width, int height, obs_image_u32 *out)
{
    return image_u32_alloc(ctx, width, height, 1, out);
}

obs_status obs_image_u32_alloc_uninit(obs_context *ctx, int width, int height, obs_image_u32 *out)
{
    return image_u32_alloc(ctx, width, height, 0, out);
}

void obs_image_f32_free(obs_image_f32 *im)
{
    if (!im)
        return;
    obs_aligned_free(im->data);
    memset(im, 0, sizeof *im);
}

void obs_image_u32_free(obs_image_u32 *im)
{
    if (!im)
        return;
    obs_aligned_free(im->data);
    memset(im, 0, sizeof *im);
}

void obs_image_f32_fill(obs_image_f32 *im, float v)
{
    for (int y = 0; y < im->height; y++) {
        float *r = obs_image_f32_row(im, y);
        for (int x = 0; x < im->width; x++)
            r[x] = v;
    }
}

void obs_image_u32_fill(obs_image_u32 *im, uint32_t v)
{
    for (int y = 0; y < im->height; y++) {
        uint32_t *r = obs_image_u32_row(im, y);
        for (int x = 0; x < im->width; x++)
            r[x] = v;
    }
}

obs_image_f32 obs_image_f32_window(const obs_image_f32 *im, int x0, int y0, int w, int h)
{
    obs_image_f32 v = {0};
    if (!im || !im->data || x0 < 0 || y0 < 0 || w < 1 || h < 1 || x0 + w > im->width || y0 + h > im->height)
        return v;
    v.data = im->data + (ptrdiff_t)y0 * im->stride + x0;
    v.width = w;
    v.height = h;
    v.stride = im->stride;
    return v;
}

obs_image_u32 obs_image_u32_window(const obs_image_u32 *im, int x0, int y0, int w, int h)
{
    obs_image_u32 v = {0};
    if (!im || !im->data || x0 < 0 || y0 < 0 || w < 1 || h < 1 || x0 + w > im->width || y0 + h > im->height)
        return v;
    v.data = im->data + (ptrdiff_t)y0 * im->stride + x0;
    v.width = w;
    v.height = h;
    v.stride = im->stride;
    return v;
}
