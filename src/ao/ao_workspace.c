/* ao_workspace.c: scratch planes and buffers kept between calls (ao_internal.h, ao_i_ws_*). */
#include "ao_internal.h"

#include <stdlib.h>
#include <string.h>

/* One slot: its memory and how much it holds (planes: floats; buffers: bytes) */
typedef struct ws_slot {
    void *data;
    size_t cap;
} ws_slot;

/* The slot lists grow as a call asks (MSSAO asks for the most: up to ~10 planes per level, 16
 * levels, plus a packed buffer per level). */
struct ao_i_ws {
    ws_slot *plane, *buf;
    int plane_slots, buf_slots; /* allocated */
    int nplanes, nbufs;         /* used by the current call */
};

/* Slot i of *list (n slots allocated), growing the list (new slots empty). NULL: out of memory. */
static ws_slot *ws_slot_at(ws_slot **list, int *n, int i)
{
    if (i >= *n) {
        const int m = *n ? 2 * *n : 16;
        ws_slot *l = (ws_slot *)realloc(*list, sizeof **list * (size_t)m);
        if (!l)
            return NULL;
        memset(l + *n, 0, sizeof *l * (size_t)(m - *n));
        *list = l;
        *n = m;
    }
    return &(*list)[i];
}

static void ws_destroy(void *p)
{
    ao_i_ws *ws = (ao_i_ws *)p;
    if (!ws)
        return;
    for (int i = 0; i < ws->plane_slots; i++)
        obs_aligned_free(ws->plane[i].data);
    for (int i = 0; i < ws->buf_slots; i++)
        obs_aligned_free(ws->buf[i].data);
    free(ws->plane);
    free(ws->buf);
    free(ws);
}

ao_i_ws *ao_i_ws_take(obs_context *ctx, const void *key)
{
    ao_i_ws *ws = (ao_i_ws *)obs_context_scratch_take(ctx, key);
    if (!ws)
        ws = (ao_i_ws *)calloc(1, sizeof *ws);
    if (ws)
        ws->nplanes = ws->nbufs = 0;
    return ws;
}

void ao_i_ws_put(obs_context *ctx, const void *key, ao_i_ws *ws)
{
    if (ws)
        obs_context_scratch_put(ctx, key, ws, ws_destroy);
}

static obs_status ws_plane(obs_context *ctx, ao_i_ws *ws, int width, int height, obs_image_f32 *out, int zero)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao workspace: out is NULL");
    memset(out, 0, sizeof *out);
    /* obs_image_f32_alloc's checks and errors (src/core/image.c, plane_alloc) */
    if (width < 1 || height < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "image size %dx%d: both sides must be >= 1", width,
                         height);
    const obs_limits *lim = obs_context_limits(ctx);
    const size_t row = ((size_t)width + 15) & ~(size_t)15;
    size_t elems, bytes;
    if (!obs_mul_size(row, (size_t)height, &elems) || !obs_mul_size(elems, 4, &bytes))
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "image size %dx%d overflows size_t", width, height);
    if ((int64_t)width * (int64_t)height > lim->max_image_pixels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d has %lld pixels, over the limit of %lld (raise it with --max-pixels)", width,
                         height, (long long)width * height, (long long)lim->max_image_pixels);
    if ((int64_t)bytes > lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d needs %lld bytes, over the limit of %lld (raise it with --max-memory)", width,
                         height, (long long)bytes, (long long)lim->max_memory_bytes);
    ws_slot *sl = ws ? ws_slot_at(&ws->plane, &ws->plane_slots, ws->nplanes) : NULL;
    if (!sl)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ao workspace: out of memory");
    /* The slot's memory, grown when needed; zeroed as obs_image_f32_alloc's */
    if (!sl->data || elems > sl->cap) {
        obs_aligned_free(sl->data);
        sl->data = obs_aligned_alloc(bytes);
        sl->cap = sl->data ? elems : 0;
        if (!sl->data)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes for a %dx%d image", bytes,
                             width, height);
    }
    if (zero)
        memset(sl->data, 0, bytes);
    ws->nplanes++;
    out->data = (float *)sl->data;
    out->width = width;
    out->height = height;
    out->stride = (ptrdiff_t)row;
    return OBS_STATUS_OK;
}

obs_status ao_i_ws_plane(obs_context *ctx, ao_i_ws *ws, int width, int height, obs_image_f32 *out)
{
    return ws_plane(ctx, ws, width, height, out, 1);
}

obs_status ao_i_ws_plane_unzeroed(obs_context *ctx, ao_i_ws *ws, int width, int height, obs_image_f32 *out)
{
    return ws_plane(ctx, ws, width, height, out, 0);
}

void *ao_i_ws_buf(ao_i_ws *ws, size_t bytes, int zero)
{
    ws_slot *sl = ws ? ws_slot_at(&ws->buf, &ws->buf_slots, ws->nbufs) : NULL;
    if (!sl)
        return NULL;
    if (bytes == 0)
        bytes = 1;
    if (!sl->data || bytes > sl->cap) {
        obs_aligned_free(sl->data);
        sl->data = obs_aligned_alloc(bytes);
        sl->cap = sl->data ? bytes : 0;
        if (!sl->data)
            return NULL;
    }
    if (zero)
        memset(sl->data, 0, bytes);
    ws->nbufs++;
    return sl->data;
}
