/* render_cache.c: content hashes, the in-memory cache of view-independent products, and the
 * optional disk cache (docs/render.md, "The cache").
 *
 * The hash (ours): the input is cut into little-endian 8-byte words (the tail zero-padded) and
 * fed to two independent 64-bit lanes:
 *   lane 0: h = (h ^ w) * 0x100000001b3              (FNV-1a's prime [FNV], a word at a time)
 *   lane 1: h = rotl(h + w * P2, 31) * P1            (xxHash64's round; P1, P2 its primes [xxHash])
 * and each lane is finished with SplitMix64's finaliser [Steele14] of (lane ^ length * golden
 * ratio). Two
 * unrelated lanes make an accidental 128-bit collision as unlikely as a random one for the
 * inputs we hash (no adversary). Every key begins with a domain string (the product kind) and
 * RENDER_CACHE_VERSION.
 *
 * Disk format (one file per key, DIR/<kind>-<32 hex>.bin), little-endian:
 *   magic "OBSRCACH" (8 bytes), u32 format version (2), u32 blob count n,
 *   u64 key[2], u64 payload hash (lane 0 of the hash of the blobs), n x u64 blob byte counts,
 *   then the blobs' bytes, each padded with zeros to a multiple of 8 bytes (so that every blob
 *   starts 8-byte aligned in the buffer the file is read into; the counts are the unpadded sizes).
 * Written to a temporary name beside it, then renamed (io_temp_path / io_commit_temp). A file that
 * is short, long, of another version or key, or whose payload hash differs is a miss (a warning). */
#include "render_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/io.h"

#define FNV_PRIME 0x100000001b3ull
#define XX_P1 0x9E3779B185EBCA87ull
#define XX_P2 0xC2B2AE3D27D4EB4Full

static uint64_t rotl64(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
static uint64_t splitmix_final(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
static void hash_word(render_hash *h, uint64_t w)
{
    h->h[0] = (h->h[0] ^ w) * FNV_PRIME;
    h->h[1] = rotl64(h->h[1] + w * XX_P2, 31) * XX_P1;
}
static uint64_t load_le64(const unsigned char *p)
{
    uint64_t w = 0;
    for (int i = 7; i >= 0; i--)
        w = (w << 8) | p[i];
    return w;
}

void render_hash_init(render_hash *h, const char *domain)
{
    memset(h, 0, sizeof *h);
    h->h[0] = 0xcbf29ce484222325ull; /* FNV-1a's offset basis */
    h->h[1] = 0x27D4EB2F165667C5ull; /* xxHash64's P5 as a seed */
    render_hash_str(h, RENDER_CACHE_VERSION);
    render_hash_str(h, domain);
}

void render_hash_bytes(render_hash *h, const void *data, size_t n)
{
    const unsigned char *p = (const unsigned char *)data;
    h->len += n;
    while (n > 0 && h->ntail > 0 && h->ntail < 8) {
        h->tail[h->ntail++] = *p++;
        n--;
        if (h->ntail == 8) {
            hash_word(h, load_le64(h->tail));
            h->ntail = 0;
        }
    }
    while (n >= 8) {
        hash_word(h, load_le64(p));
        p += 8;
        n -= 8;
    }
    while (n > 0) {
        h->tail[h->ntail++] = *p++;
        n--;
    }
}

void render_hash_u64(render_hash *h, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++)
        b[i] = (unsigned char)(v >> (8 * i));
    render_hash_bytes(h, b, 8);
}
void render_hash_i(render_hash *h, int64_t v) { render_hash_u64(h, (uint64_t)v); }
void render_hash_d(render_hash *h, double v)
{
    uint64_t u;
    if (v == 0.0)
        v = 0.0;
    if (v != v)
        u = 0x7ff8000000000000ull;
    else
        memcpy(&u, &v, 8);
    render_hash_u64(h, u);
}
void render_hash_str(render_hash *h, const char *s)
{
    size_t n = s ? strlen(s) : 0;
    render_hash_u64(h, n);
    render_hash_bytes(h, s ? s : "", n);
}
void render_hash_key(render_hash *h, render_key k)
{
    render_hash_u64(h, k.k[0]);
    render_hash_u64(h, k.k[1]);
}

render_key render_hash_final(const render_hash *h)
{
    render_hash t = *h;
    if (t.ntail > 0) {
        memset(t.tail + t.ntail, 0, (size_t)(8 - t.ntail));
        hash_word(&t, load_le64(t.tail));
    }
    render_key k;
    k.k[0] = splitmix_final(t.h[0] ^ (t.len * 0x9E3779B97F4A7C15ull));
    k.k[1] = splitmix_final(t.h[1] ^ (t.len * 0x9E3779B97F4A7C15ull) ^ 0x5555555555555555ull);
    return k;
}

void render_key_hex(render_key k, char out[33])
{
    snprintf(out, 33, "%016llx%016llx", (unsigned long long)k.k[0], (unsigned long long)k.k[1]);
}
int render_key_eq(render_key a, render_key b) { return a.k[0] == b.k[0] && a.k[1] == b.k[1]; }

/* ------------------------------------------------------------------------------------------------
 * Blobs
 * ---------------------------------------------------------------------------------------------- */

int render_blobs_add_copy(render_blobs *bl, const void *data, uint64_t bytes)
{
    if (bl->n == bl->cap) {
        int cap = bl->cap ? 2 * bl->cap : 16;
        render_blob *nb = (render_blob *)realloc(bl->b, (size_t)cap * sizeof *nb);
        if (!nb)
            return 0;
        bl->b = nb;
        bl->cap = cap;
    }
    void *copy = malloc(bytes ? (size_t)bytes : 1);
    if (!copy)
        return 0;
    if (bytes)
        memcpy(copy, data, (size_t)bytes);
    bl->b[bl->n].data = copy;
    bl->b[bl->n].bytes = bytes;
    bl->n++;
    return 1;
}

void render_blobs_free(render_blobs *bl)
{
    for (int i = 0; i < bl->n; i++)
        free(bl->b[i].data);
    free(bl->b);
    memset(bl, 0, sizeof *bl);
}

const void *render_reader_take(render_reader *r, uint64_t bytes)
{
    if (r->bad || r->i >= r->n || r->b[r->i].bytes != bytes) {
        r->bad = 1;
        return NULL;
    }
    return r->b[r->i++].data;
}

int render_blobs_add_plane(render_blobs *bl, const obs_image_f32 *im)
{
    int32_t wh[2] = {im->data ? im->width : 0, im->data ? im->height : 0};
    if (!render_blobs_add_copy(bl, wh, sizeof wh))
        return 0;
    if (!im->data)
        return 1;
    uint64_t row = (uint64_t)im->width * sizeof(float);
    if (!render_blobs_add_copy(bl, NULL, 0))
        return 0;
    render_blob *b = &bl->b[bl->n - 1];
    free(b->data);
    b->data = malloc((size_t)(row * (uint64_t)im->height));
    if (!b->data)
        return 0;
    b->bytes = row * (uint64_t)im->height;
    for (int y = 0; y < im->height; y++)
        memcpy((char *)b->data + (size_t)y * row, obs_image_f32_row(im, y), (size_t)row);
    return 1;
}

int render_blobs_add_plane_u32(render_blobs *bl, const obs_image_u32 *im)
{
    obs_image_f32 v = {(float *)im->data, im->width, im->height, im->stride};
    return render_blobs_add_plane(bl, &v); /* same bytes: 4 per element */
}

obs_status render_reader_plane(obs_context *ctx, render_reader *r, int w, int h, obs_image_f32 *out)
{
    memset(out, 0, sizeof *out);
    const int32_t *wh = (const int32_t *)render_reader_take(r, 8);
    if (!wh)
        return OBS_STATUS_PARSE_ERROR;
    if (wh[0] == 0 && wh[1] == 0)
        return OBS_STATUS_OK; /* an absent plane */
    if ((w > 0 && (wh[0] != w || wh[1] != h)) || wh[0] < 1 || wh[1] < 1) {
        r->bad = 1;
        return OBS_STATUS_PARSE_ERROR;
    }
    uint64_t row = (uint64_t)wh[0] * sizeof(float);
    const char *src = (const char *)render_reader_take(r, row * (uint64_t)wh[1]);
    if (!src)
        return OBS_STATUS_PARSE_ERROR;
    obs_status st = obs_image_f32_alloc(ctx, wh[0], wh[1], out);
    if (st != OBS_STATUS_OK)
        return st;
    for (int y = 0; y < wh[1]; y++)
        memcpy(obs_image_f32_row(out, y), src + (size_t)y * row, (size_t)row);
    return OBS_STATUS_OK;
}

obs_status render_reader_plane_u32(obs_context *ctx, render_reader *r, int w, int h, obs_image_u32 *out)
{
    memset(out, 0, sizeof *out);
    const int32_t *wh = (const int32_t *)render_reader_take(r, 8);
    if (!wh)
        return OBS_STATUS_PARSE_ERROR;
    if (wh[0] == 0 && wh[1] == 0)
        return OBS_STATUS_OK;
    if ((w > 0 && (wh[0] != w || wh[1] != h)) || wh[0] < 1 || wh[1] < 1) {
        r->bad = 1;
        return OBS_STATUS_PARSE_ERROR;
    }
    uint64_t row = (uint64_t)wh[0] * 4;
    const char *src = (const char *)render_reader_take(r, row * (uint64_t)wh[1]);
    if (!src)
        return OBS_STATUS_PARSE_ERROR;
    obs_status st = obs_image_u32_alloc(ctx, wh[0], wh[1], out);
    if (st != OBS_STATUS_OK)
        return st;
    for (int y = 0; y < wh[1]; y++)
        memcpy(obs_image_u32_row(out, y), src + (size_t)y * row, (size_t)row);
    return OBS_STATUS_OK;
}

/* A G-buffer: its header fields and constants as one blob, then every plane (absent ones empty). */
typedef struct gb_header {
    int32_t width, height, guard, depth_convention;
    uint32_t outputs, pad;
    rast_view_constants constants;
} gb_header;

int render_blobs_add_gbuffer(render_blobs *bl, const rast_gbuffer *gb)
{
    gb_header hd;
    memset(&hd, 0, sizeof hd);
    hd.width = gb->width, hd.height = gb->height, hd.guard = gb->guard;
    hd.depth_convention = (int32_t)gb->depth_convention;
    hd.outputs = gb->outputs;
    hd.constants = gb->constants;
    int ok = render_blobs_add_copy(bl, &hd, sizeof hd);
    ok = ok && render_blobs_add_plane(bl, &gb->depth) && render_blobs_add_plane(bl, &gb->ndc_depth);
    for (int c = 0; c < 3; c++)
        ok = ok && render_blobs_add_plane(bl, &gb->normal[c]) && render_blobs_add_plane(bl, &gb->face_normal[c]);
    ok = ok && render_blobs_add_plane_u32(bl, &gb->prim_id) && render_blobs_add_plane_u32(bl, &gb->instance_id) &&
         render_blobs_add_plane_u32(bl, &gb->material_id);
    return ok;
}

obs_status render_reader_gbuffer(obs_context *ctx, render_reader *r, rast_gbuffer *gb)
{
    memset(gb, 0, sizeof *gb);
    const gb_header *hd = (const gb_header *)render_reader_take(r, sizeof(gb_header));
    if (!hd)
        return OBS_STATUS_PARSE_ERROR;
    gb->width = hd->width, gb->height = hd->height, gb->guard = hd->guard;
    gb->depth_convention = (rast_depth_convention)hd->depth_convention;
    gb->outputs = hd->outputs;
    gb->constants = hd->constants;
    const int w = gb->width, h = gb->height;
    obs_status st = render_reader_plane(ctx, r, w, h, &gb->depth);
    if (st == OBS_STATUS_OK) st = render_reader_plane(ctx, r, w, h, &gb->ndc_depth);
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
        st = render_reader_plane(ctx, r, w, h, &gb->normal[c]);
        if (st == OBS_STATUS_OK) st = render_reader_plane(ctx, r, w, h, &gb->face_normal[c]);
    }
    if (st == OBS_STATUS_OK) st = render_reader_plane_u32(ctx, r, w, h, &gb->prim_id);
    if (st == OBS_STATUS_OK) st = render_reader_plane_u32(ctx, r, w, h, &gb->instance_id);
    if (st == OBS_STATUS_OK) st = render_reader_plane_u32(ctx, r, w, h, &gb->material_id);
    if (st != OBS_STATUS_OK)
        rast_gbuffer_free(gb);
    return st;
}

/* ------------------------------------------------------------------------------------------------
 * The cache
 * ---------------------------------------------------------------------------------------------- */

typedef struct cache_entry {
    render_key key;
    const render_product_ops *ops;
    void *p;
    uint64_t bytes;
    uint64_t used;     /* the frame that last used it (render_cache_begin_frame's counter) */
} cache_entry;

/* The memory budget (docs/render.md, "The cache"): after an insertion, entries are dropped from the
 * memory cache, least recently used first, while it holds more than `budget` bytes. An entry used
 * by the current frame is never dropped (the frame holds pointers to it), so one frame may exceed
 * the budget; the next frame's insertions make room. Dropped products stay on disk when the cache
 * has a directory. */
struct render_cache {
    cache_entry *e;
    int n, cap;
    uint64_t frame, budget;
    char dir[1024];
    render_cache_stats stats;
};

render_cache *render_cache_create(const char *dir, uint64_t budget)
{
    render_cache *c = (render_cache *)calloc(1, sizeof *c);
    if (c && dir)
        snprintf(c->dir, sizeof c->dir, "%s", dir);
    if (c) {
        c->budget = budget;
        c->frame = 1;
    }
    return c;
}

static void cache_trim(render_cache *c, obs_context *ctx);

void render_cache_begin_frame(render_cache *c, obs_context *ctx)
{
    c->frame++;
    cache_trim(c, ctx); /* between frames nothing is in use: back within the budget */
}

/* Drop least-recently-used entries not used by this frame while over the budget. */
static void cache_trim(render_cache *c, obs_context *ctx)
{
    while (c->stats.bytes > c->budget) {
        int victim = -1;
        for (int i = 0; i < c->n; i++)
            if (c->e[i].used < c->frame && (victim < 0 || c->e[i].used < c->e[victim].used))
                victim = i;
        if (victim < 0)
            return; /* everything left is in use by this frame */
        cache_entry *v = &c->e[victim];
        if (ctx) {
            char hex[33];
            render_key_hex(v->key, hex);
            obs_log(ctx, OBS_LOG_INFO, "render cache: dropped %s %s (%.1f MB) from memory to stay within %.1f MB",
                    v->ops->kind, hex, (double)v->bytes / 1e6, (double)c->budget / 1e6);
        }
        c->stats.bytes -= v->bytes;
        c->stats.evictions++;
        v->ops->free_fn(v->p);
        free(v->p);
        c->e[victim] = c->e[c->n - 1];
        c->n--;
        c->stats.entries = c->n;
    }
}

void render_cache_destroy(render_cache *c)
{
    if (!c)
        return;
    for (int i = 0; i < c->n; i++) {
        c->e[i].ops->free_fn(c->e[i].p);
        free(c->e[i].p);
    }
    free(c->e);
    free(c);
}

void *render_cache_find(render_cache *c, render_key k, const render_product_ops *ops)
{
    for (int i = 0; i < c->n; i++)
        if (c->e[i].ops == ops && render_key_eq(c->e[i].key, k)) {
            c->e[i].used = c->frame;
            return c->e[i].p;
        }
    return NULL;
}

static void cache_path(const render_cache *c, render_key k, const render_product_ops *ops, char *out, size_t n)
{
    char hex[33];
    render_key_hex(k, hex);
    snprintf(out, n, "%s/%s-%s.bin", c->dir, ops->kind, hex);
}

#define CACHE_MAGIC "OBSRCACH"
#define CACHE_FORMAT 2u

static uint64_t payload_hash(const render_blob *b, int n)
{
    render_hash h;
    render_hash_init(&h, "payload");
    for (int i = 0; i < n; i++)
        render_hash_bytes(&h, b[i].data, (size_t)b[i].bytes);
    return render_hash_final(&h).k[0];
}

static void put_u32(unsigned char *p, uint32_t v) { for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i)); }
static void put_u64(unsigned char *p, uint64_t v) { for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i)); }
static uint32_t get_u32(const unsigned char *p) { uint32_t v = 0; for (int i = 3; i >= 0; i--) v = (v << 8) | p[i]; return v; }

static obs_status cache_write(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops,
                              const render_blobs *bl)
{
    char path[1200], tmp[1300];
    obs_status st = io_make_dirs(ctx, c->dir);
    if (st != OBS_STATUS_OK)
        return st;
    cache_path(c, k, ops, path, sizeof path);
    st = io_temp_path(ctx, path, tmp, sizeof tmp);
    if (st != OBS_STATUS_OK)
        return st;
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "render cache: cannot write %s: %s", tmp, strerror(errno));
    const size_t head = 8 + 4 + 4 + 16 + 8 + 8 * (size_t)bl->n;
    unsigned char *hd = (unsigned char *)malloc(head);
    int ok = hd != NULL;
    if (ok) {
        memcpy(hd, CACHE_MAGIC, 8);
        put_u32(hd + 8, CACHE_FORMAT);
        put_u32(hd + 12, (uint32_t)bl->n);
        put_u64(hd + 16, k.k[0]);
        put_u64(hd + 24, k.k[1]);
        put_u64(hd + 32, payload_hash(bl->b, bl->n));
        for (int i = 0; i < bl->n; i++)
            put_u64(hd + 40 + 8 * (size_t)i, bl->b[i].bytes);
        ok = fwrite(hd, 1, head, f) == head;
    }
    static const unsigned char zeros[8] = {0};
    for (int i = 0; ok && i < bl->n; i++) {
        const size_t pad = (size_t)((8 - bl->b[i].bytes % 8) % 8);
        ok = bl->b[i].bytes == 0 || fwrite(bl->b[i].data, 1, (size_t)bl->b[i].bytes, f) == bl->b[i].bytes;
        ok = ok && (pad == 0 || fwrite(zeros, 1, pad, f) == pad);
    }
    free(hd);
    ok = (fclose(f) == 0) && ok;
    if (!ok) {
        remove(tmp);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "render cache: cannot write %s", tmp);
    }
    return io_commit_temp(ctx, tmp, path);
}

static void *cache_insert(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops, void *p,
                          uint64_t bytes)
{
    if (c->n == c->cap) {
        int cap = c->cap ? 2 * c->cap : 16;
        cache_entry *ne = (cache_entry *)realloc(c->e, (size_t)cap * sizeof *ne);
        if (!ne) {
            ops->free_fn(p);
            free(p);
            return NULL;
        }
        c->e = ne;
        c->cap = cap;
    }
    c->e[c->n].key = k;
    c->e[c->n].ops = ops;
    c->e[c->n].p = p;
    c->e[c->n].bytes = bytes;
    c->e[c->n].used = c->frame;
    c->n++;
    c->stats.entries = c->n;
    c->stats.bytes += bytes;
    cache_trim(c, ctx);
    return p;
}

void *render_cache_put(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops, void *p,
                       uint64_t bytes)
{
    if (!cache_insert(c, ctx, k, ops, p, bytes))
        return NULL;
    if (c->dir[0] && ops->save) {
        render_blobs bl;
        memset(&bl, 0, sizeof bl);
        obs_status st = ops->save(ctx, p, &bl);
        if (st == OBS_STATUS_OK)
            st = cache_write(c, ctx, k, ops, &bl);
        if (st != OBS_STATUS_OK) {
            obs_log(ctx, OBS_LOG_WARN, "render cache: %s not written to %s: %s", ops->kind, c->dir,
                    obs_context_last_error(ctx));
            obs_context_clear_error(ctx);
        }
        render_blobs_free(&bl);
    }
    return p;
}

void *render_cache_load(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops)
{
    if (!c->dir[0] || !ops->load)
        return NULL;
    char path[1200];
    cache_path(c, k, ops, path, sizeof path);
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL; /* the ordinary miss */
    fclose(f);
    char *data = NULL;
    size_t len = 0;
    const char *why = NULL;
    void *p = NULL;
    render_blob *b = NULL;
    if (io_read_file(ctx, path, (size_t)1 << 40, &data, &len) != OBS_STATUS_OK) {
        why = obs_context_last_error(ctx);
        goto miss;
    }
    const unsigned char *u = (const unsigned char *)data;
    if (len < 40 || memcmp(u, CACHE_MAGIC, 8) != 0) { why = "not a cache file (short, or no magic)"; goto miss; }
    if (get_u32(u + 8) != CACHE_FORMAT) { why = "another format version"; goto miss; }
    uint32_t n = get_u32(u + 12);
    if (n > (1u << 20) || len < 40 + 8 * (size_t)n) { why = "truncated header"; goto miss; }
    render_key fk;
    memcpy(&fk, u + 16, 16); /* little-endian hosts only (x86-64, aarch64) */
    if (!render_key_eq(fk, k)) { why = "the key inside differs from its name"; goto miss; }
    uint64_t want_hash;
    memcpy(&want_hash, u + 32, 8);
    b = (render_blob *)calloc(n ? n : 1, sizeof *b);
    if (!b) { why = "out of memory"; goto miss; }
    size_t off = 40 + 8 * (size_t)n;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t bytes;
        memcpy(&bytes, u + 40 + 8 * (size_t)i, 8);
        const uint64_t padded = bytes + (8 - bytes % 8) % 8;
        if (bytes > ((uint64_t)1 << 40) || padded > len - off) { why = "truncated data"; goto miss; }
        b[i].data = (void *)(u + off);
        b[i].bytes = bytes;
        off += (size_t)padded;
    }
    if (off != len) { why = "trailing bytes"; goto miss; }
    if (payload_hash(b, (int)n) != want_hash) { why = "the payload's hash differs (corrupt)"; goto miss; }
    p = calloc(1, ops->size);
    if (!p) { why = "out of memory"; goto miss; }
    render_reader r = {b, (int)n, 0, 0};
    obs_status st = ops->load(ctx, &r, p);
    if (st != OBS_STATUS_OK || r.bad || r.i != r.n) {
        ops->free_fn(p);
        free(p);
        p = NULL;
        why = "its blobs do not match the product";
        obs_context_clear_error(ctx);
        goto miss;
    }
    free(b);
    free(data);
    return cache_insert(c, ctx, k, ops, p, ops->bytes(p));
miss:
    obs_log(ctx, OBS_LOG_WARN, "render cache: ignoring %s: %s (rebuilding it)", path, why ? why : "?");
    obs_context_clear_error(ctx);
    free(b);
    free(data);
    return NULL;
}

void render_cache_count(render_cache *c, int hit_memory, int hit_disk, int miss)
{
    c->stats.hits_memory += hit_memory;
    c->stats.hits_disk += hit_disk;
    c->stats.misses += miss;
}

void render_cache_get_stats(const render_cache *c, render_cache_stats *out) { *out = c->stats; }
