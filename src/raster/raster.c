/* raster.c: the software rasterizer's driver: view constants, vertex transform, triangle setup
 * with exact clipping, binning into screen tiles, per-tile visibility, and the resolve step that
 * computes every attribute from the exact pixel ray. The conventions are in raster.h and
 * docs/conventions.md; the design is in docs/raster.md.
 *
 * Pipeline (one view at a time; every stage is a set of tasks whose output depends only on the
 * task index, so the result is identical for any number of threads):
 *   1. Transform: each instance's vertices to view space, in double.
 *   2. Setup: fixed chunks of RAST_CHUNK triangles. Each triangle is culled, clipped against the
 *      near/far planes and the guard band (Sutherland-Hodgman in view space, exact planes),
 *      projected, snapped to 1/256 px, and its edge functions and key plane are set up. The
 *      records of a chunk are binned into the screen tiles their bounding boxes touch.
 *   3. Tiles: each tile rasterizes the bins of all chunks in chunk order (so triangle order is
 *      kept: ties go to the earlier triangle), then resolves its pixels: the pixel's exact ray
 *      meets the visible triangle's plane at t = (n.v0 - n.o)/(n.d) (in double), which is the
 *      linear depth; the barycentrics of the hit come from the plane's dual basis
 *      (see resolve_tri); outputs are written once per pixel.
 */
#include "raster_internal.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* Triangles per setup chunk. Fixed (not derived from the thread count) so that binning order,
 * and therefore tie-breaking, never depends on the pool. 4096 triangles keep a chunk's records
 * (~90 bytes each) within L2. */
#define RAST_CHUNK 4096
/* Vertices per transform task. */
#define RAST_VERTEX_BLOCK 16384

rast_params rast_params_default(void)
{
    rast_params p;
    memset(&p, 0, sizeof p);
    p.width = 1920;  /* the seed study's main resolution (ssao-thesis-2017, Table 26) */
    p.height = 1080;
    p.guard = 0;
    p.outputs = RAST_OUT_ALL;
    p.depth_convention = RAST_DEPTH_GL_STANDARD;
    p.cull = RAST_CULL_NONE;
    p.face_forward = 1;
    p.isa = RAST_ISA_AUTO;
    p.tile_size = 64; /* 32, 64 and 128 cost the same instructions on the bunny (bench --tile);
                         64x64 keeps a tile's key/id buffers (48 KB) in L2 */
    return p;
}

const char *rast_isa_name(rast_isa isa)
{
    switch (isa) {
    case RAST_ISA_AUTO: return "auto";
    case RAST_ISA_SCALAR: return "scalar";
    case RAST_ISA_AVX2: return "avx2";
    default: return "unknown";
    }
}

const char *rast_depth_convention_name(rast_depth_convention c)
{
    switch (c) {
    case RAST_DEPTH_GL_STANDARD: return "gl_standard";
    case RAST_DEPTH_ZERO_TO_ONE: return "zero_to_one";
    case RAST_DEPTH_REVERSED_Z: return "reversed_z";
    default: return "unknown";
    }
}

int rast_isa_available(rast_isa isa)
{
    switch (isa) {
    case RAST_ISA_AUTO:
    case RAST_ISA_SCALAR: return 1;
    case RAST_ISA_AVX2:
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
        return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
        return 0;
#endif
    default: return 0;
    }
}

/* ------------------------------------------------------------------------------------------------
 * View constants
 * ---------------------------------------------------------------------------------------------- */

static void set_proj(obs_mat4 *m, double p00, double p11, double p22, double p23, int ortho)
{
    memset(m, 0, sizeof *m);
    m->m[0] = (float)p00;
    m->m[5] = (float)p11;
    m->m[10] = (float)p22;
    m->m[14] = (float)p23;
    if (ortho)
        m->m[15] = 1.0f;
    else
        m->m[11] = -1.0f;
}

/* Standard (GL, clip z in [-w,w]) and reversed-Z zero-to-one depth rows, glTF 2.0 spec appendix
 * "Projection Matrices" for the standard form; the reversed form maps near -> 1, far -> 0
 * (infinite far: P22 = 0, P23 = near, as in [Reed15] "Depth Precision Visualized"). */
static void depth_rows(const rast_view_constants *vc, double *s22, double *s23, double *r22, double *r23)
{
    double n = vc->znear, f = vc->zfar;
    if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE) {
        if (isinf(f)) {
            *s22 = -1.0; *s23 = -2.0 * n;
            *r22 = 0.0; *r23 = n;
        } else {
            *s22 = (f + n) / (n - f); *s23 = 2.0 * f * n / (n - f);
            *r22 = n / (f - n); *r23 = n * f / (f - n);
        }
    } else {
        *s22 = 2.0 / (n - f); *s23 = (f + n) / (n - f);
        *r22 = 1.0 / (f - n); *r23 = f / (f - n);
    }
}

obs_status rast_view_constants_make(obs_context *ctx, const rast_params *p, const obs_camera *cam,
                                    rast_view_constants *out)
{
    if (!p || !cam || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_view_constants_make: NULL argument");
    memset(out, 0, sizeof *out);
    if (p->width < 1 || p->height < 1 || p->width > RAST_MAX_DIM || p->height > RAST_MAX_DIM)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "image size %dx%d: each side must be in [1, %d]",
                         p->width, p->height, RAST_MAX_DIM);
    if (p->guard < 0 || p->width + 2 * (int64_t)p->guard > RAST_MAX_DIM ||
        p->height + 2 * (int64_t)p->guard > RAST_MAX_DIM)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "guard band %d: must be >= 0 and keep the full image within %d px", p->guard, RAST_MAX_DIM);
    double n = cam->znear, f = cam->zfar;
    int ortho = cam->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    if (cam->projection != OBS_PROJECTION_PERSPECTIVE && !ortho)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "camera '%s': unknown projection %d", cam->name,
                         (int)cam->projection);
    if (!isfinite(n) || (ortho ? n < 0.0 : n <= 0.0) || isnan(f) || !(f > n) || (ortho && isinf(f)))
        return obs_error(ctx, OBS_STATUS_INVALID_DEPTH_RANGE,
                         "camera '%s': znear %g, zfar %g: need %s, zfar > znear%s", cam->name, n, f,
                         ortho ? "znear >= 0" : "znear > 0", ortho ? " and finite" : " (or infinite)");
    if (!obs_mat4_is_finite(cam->view))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "camera '%s': non-finite view matrix", cam->name);
    const int W = p->width, H = p->height, g = p->guard;
    const int Wf = W + 2 * g, Hf = H + 2 * g;
    double p00, p11;
    if (!ortho) {
        if (!(cam->yfov > 0.0f && cam->yfov < OBS_PI_F) || !isfinite(cam->aspect) || cam->aspect < 0.0f)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "camera '%s': yfov %g must be in (0, pi) and aspect %g >= 0", cam->name,
                             (double)cam->yfov, (double)cam->aspect);
        double aspect = cam->aspect > 0.0f ? (double)cam->aspect : (double)W / (double)H;
        p11 = 1.0 / tan(0.5 * (double)cam->yfov);
        p00 = p11 / aspect;
    } else {
        if (!(cam->xmag > 0.0f) || !(cam->ymag > 0.0f) || !isfinite(cam->xmag) || !isfinite(cam->ymag))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "camera '%s': xmag %g and ymag %g must be > 0",
                             cam->name, (double)cam->xmag, (double)cam->ymag);
        p00 = 1.0 / (double)cam->xmag;
        p11 = 1.0 / (double)cam->ymag;
    }
    out->full_width = Wf;
    out->full_height = Hf;
    out->inner_x0 = g;
    out->inner_y0 = g;
    out->view = cam->view;
    out->znear = n;
    out->zfar = f;
    out->projection_type = cam->projection;
    double s22, s23, r22, r23;
    depth_rows(out, &s22, &s23, &r22, &r23);
    /* The guard band widens the frustum so that inner pixel (x, y) is full pixel (x+g, y+g):
     * NDC scales by W/(W+2g) and H/(H+2g). */
    double p00f = p00 * (double)W / (double)Wf, p11f = p11 * (double)H / (double)Hf;
    set_proj(&out->projection_inner, p00, p11, s22, s23, ortho);
    set_proj(&out->projection, p00f, p11f, s22, s23, ortho);
    set_proj(&out->projection_reversed, p00f, p11f, r22, r23, ortho);
    /* Pixel ray model: NDC x = 2 px / Wf - 1 and y = 1 - 2 py / Hf (row 0 at the top). */
    out->fx = 0.5 * (double)Wf * p00f;
    out->fy = 0.5 * (double)Hf * p11f;
    out->cx = 0.5 * (double)Wf;
    out->cy = 0.5 * (double)Hf;
    return OBS_STATUS_OK;
}

void rast_pixel_ray(const rast_view_constants *vc, const obs_camera *cam, double px, double py, obs_dvec3 *origin,
                    obs_dvec3 *dir)
{
    obs_dvec3 o, d;
    double ax = (px - vc->cx) * (1.0 / vc->fx), ay = -(py - vc->cy) * (1.0 / vc->fy);
    if (vc->projection_type == OBS_PROJECTION_PERSPECTIVE) {
        o = obs_dv3(0.0, 0.0, 0.0);
        d = obs_dv3(ax, ay, -1.0);
    } else {
        o = obs_dv3(ax, ay, 0.0);
        d = obs_dv3(0.0, 0.0, -1.0);
    }
    const float *w = cam->world.m;
    origin->x = w[0] * o.x + w[4] * o.y + w[8] * o.z + w[12];
    origin->y = w[1] * o.x + w[5] * o.y + w[9] * o.z + w[13];
    origin->z = w[2] * o.x + w[6] * o.y + w[10] * o.z + w[14];
    dir->x = w[0] * d.x + w[4] * d.y + w[8] * d.z;
    dir->y = w[1] * d.x + w[5] * d.y + w[9] * d.z;
    dir->z = w[2] * d.x + w[6] * d.y + w[10] * d.z;
}

/* Depth-buffer values, in double. With d = linear depth (-z_view) > 0:
 *   GL standard    window depth = 0.5 * z_ndc + 0.5,  z_ndc = -P22 + P23 / d      (perspective)
 *                                                     z_ndc = -P22 d + P23        (orthographic)
 *   zero-to-one    d01 = f (d - n) / (d (f - n)); infinite far: 1 - n / d; ortho (d - n) / (f - n)
 *   reversed-Z     drev = n (f - d) / (d (f - n)); infinite far: n / d;   ortho (f - d) / (f - n) */
double rast_ndc_depth_from_linear(const rast_view_constants *vc, rast_depth_convention conv, double d)
{
    double n = vc->znear, f = vc->zfar;
    int persp = vc->projection_type == OBS_PROJECTION_PERSPECTIVE;
    if (!(d < INFINITY))
        return conv == RAST_DEPTH_REVERSED_Z ? 0.0 : 1.0;
    switch (conv) {
    case RAST_DEPTH_GL_STANDARD: {
        double s22, s23, r22, r23;
        depth_rows(vc, &s22, &s23, &r22, &r23);
        double zndc = persp ? -s22 + s23 / d : -s22 * d + s23;
        return 0.5 * zndc + 0.5;
    }
    case RAST_DEPTH_ZERO_TO_ONE:
        if (!persp)
            return (d - n) / (f - n);
        return isinf(f) ? 1.0 - n / d : f * (d - n) / (d * (f - n));
    case RAST_DEPTH_REVERSED_Z:
        if (!persp)
            return (f - d) / (f - n);
        return isinf(f) ? n / d : n * (f - d) / (d * (f - n));
    default:
        return NAN;
    }
}

double rast_linear_from_ndc_depth(const rast_view_constants *vc, rast_depth_convention conv, double v)
{
    double n = vc->znear, f = vc->zfar;
    int persp = vc->projection_type == OBS_PROJECTION_PERSPECTIVE;
    switch (conv) {
    case RAST_DEPTH_GL_STANDARD: {
        if (v >= 1.0)
            return INFINITY;
        double s22, s23, r22, r23;
        depth_rows(vc, &s22, &s23, &r22, &r23);
        double zndc = 2.0 * v - 1.0;
        return persp ? s23 / (zndc + s22) : (s23 - zndc) / s22;
    }
    case RAST_DEPTH_ZERO_TO_ONE:
        if (v >= 1.0)
            return INFINITY;
        if (!persp)
            return n + v * (f - n);
        return isinf(f) ? n / (1.0 - v) : f * n / (f - v * (f - n));
    case RAST_DEPTH_REVERSED_Z:
        if (v <= 0.0)
            return INFINITY;
        if (!persp)
            return f - v * (f - n);
        return isinf(f) ? n / v : n * f / (n + v * (f - n));
    default:
        return NAN;
    }
}

/* ------------------------------------------------------------------------------------------------
 * G-buffer allocation
 * ---------------------------------------------------------------------------------------------- */

/* zero: zeroed planes (rast_gbuffer_alloc); otherwise uninitialised ones (rast_gbuffer_alloc_uninit):
 * rast_render writes every element of every requested plane of a layer it renders (tile_task
 * visits every tile of the full (W+2g) x (H+2g) image, and each tile row goes either to
 * background_row, which fills the row, or to resolve_row, which writes every output of every
 * pixel: background pixels in its first branch, covered ones by the scalar resolve or by
 * resolve4, which writes all outputs but the NDC depth, written after it). */
static obs_status gbuffer_alloc(obs_context *ctx, const rast_params *p, rast_gbuffer *out, int zero)
{
    if (!p || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_gbuffer_alloc: NULL argument");
    obs_status (*alloc_f)(obs_context *, int, int, obs_image_f32 *) =
        zero ? obs_image_f32_alloc : obs_image_f32_alloc_uninit;
    obs_status (*alloc_u)(obs_context *, int, int, obs_image_u32 *) =
        zero ? obs_image_u32_alloc : obs_image_u32_alloc_uninit;
    memset(out, 0, sizeof *out);
    if (p->width < 1 || p->height < 1 || p->guard < 0 || p->width + 2 * (int64_t)p->guard > RAST_MAX_DIM ||
        p->height + 2 * (int64_t)p->guard > RAST_MAX_DIM)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "G-buffer %dx%d with guard %d: each side plus 2*guard must be in [1, %d]", p->width,
                         p->height, p->guard, RAST_MAX_DIM);
    int W = p->width + 2 * p->guard, H = p->height + 2 * p->guard;
    /* Check the whole group against the memory limit before allocating anything. */
    int planes = 0;
    for (uint32_t b = p->outputs, k = 0; k < 7; k++)
        if (b & (1u << k))
            planes += (k == 2 || k == 3) ? 3 : 1;
    const obs_limits *lim = obs_context_limits(ctx);
    double bytes = (double)planes * 4.0 * (double)((W + 15) & ~15) * (double)H;
    if (bytes > (double)lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "G-buffer %dx%d with %d planes needs %.0f bytes, over the limit of %lld (raise it with "
                         "--max-memory)", W, H, planes, bytes, (long long)lim->max_memory_bytes);
    out->width = W;
    out->height = H;
    out->guard = p->guard;
    out->outputs = p->outputs;
    out->depth_convention = p->depth_convention;
    obs_status st = OBS_STATUS_OK;
#define ALLOC_F(bit, plane) \
    if (st == OBS_STATUS_OK && (p->outputs & (bit))) st = alloc_f(ctx, W, H, &(plane))
#define ALLOC_U(bit, plane) \
    if (st == OBS_STATUS_OK && (p->outputs & (bit))) st = alloc_u(ctx, W, H, &(plane))
    ALLOC_F(RAST_OUT_DEPTH, out->depth);
    ALLOC_F(RAST_OUT_NDC_DEPTH, out->ndc_depth);
    for (int c = 0; c < 3; c++) {
        ALLOC_F(RAST_OUT_NORMAL, out->normal[c]);
        ALLOC_F(RAST_OUT_FACE_NORMAL, out->face_normal[c]);
    }
    ALLOC_U(RAST_OUT_PRIM_ID, out->prim_id);
    ALLOC_U(RAST_OUT_INSTANCE_ID, out->instance_id);
    ALLOC_U(RAST_OUT_MATERIAL_ID, out->material_id);
#undef ALLOC_F
#undef ALLOC_U
    if (st != OBS_STATUS_OK)
        rast_gbuffer_free(out);
    return st;
}

obs_status rast_gbuffer_alloc(obs_context *ctx, const rast_params *p, rast_gbuffer *out)
{
    return gbuffer_alloc(ctx, p, out, 1);
}

obs_status rast_gbuffer_alloc_uninit(obs_context *ctx, const rast_params *p, rast_gbuffer *out)
{
    return gbuffer_alloc(ctx, p, out, 0);
}

void rast_gbuffer_free(rast_gbuffer *gb)
{
    if (!gb)
        return;
    obs_image_f32_free(&gb->depth);
    obs_image_f32_free(&gb->ndc_depth);
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&gb->normal[c]);
        obs_image_f32_free(&gb->face_normal[c]);
    }
    obs_image_u32_free(&gb->prim_id);
    obs_image_u32_free(&gb->instance_id);
    obs_image_u32_free(&gb->material_id);
    memset(gb, 0, sizeof *gb);
}


/* ------------------------------------------------------------------------------------------------
 * Workspace: grow-only buffers kept between renders (no page faults, no allocator traffic in
 * the steady state).
 * ---------------------------------------------------------------------------------------------- */

/* One setup chunk. Aligned to a cache line so that threads working on neighbouring chunks never
 * share one (false sharing made 2 threads slower than 1 in the first version). */
typedef struct chunk_data {
    _Alignas(64) rast_i_tri *tris;
    uint32_t count, cap;
    uint32_t *bin_start;   /* tile_count + 1 */
    uint32_t *bin_list;
    uint32_t *fill;        /* tile_count */
    size_t bin_start_cap, bin_list_cap, fill_cap;
    uint64_t nonfinite, degenerate, culled, clipped;
    int oom;
} chunk_data;

/* One transformed vertex, one cache line: everything setup and resolve read of it. Vertices are
 * projected once here instead of once per triangle corner (about 6 times), and a triangle's
 * data is three cache lines instead of a dozen scattered ones. */
typedef struct rast_vtx {
    double x, y, z;      /* view space */
    double key;          /* visibility key (1/w or z); valid when code == 0 */
    int32_t X, Y;        /* snapped screen position, sub-pixel units; valid when code == 0 */
    uint32_t code;       /* frustum outcode; RAST_VTX_NONFINITE for a NaN/Inf position */
    float nx, ny, nz;    /* unit view-space normal; 0 when the mesh has none or it is bad */
    uint32_t pad[2];
} rast_vtx;
#define RAST_VTX_NONFINITE 0x80u

struct rast_workspace {
    rast_vtx *vtx; size_t vtx_cap;          /* transformed vertices, all instances */
    uint64_t *voff; size_t voff_cap;        /* per instance: its first vertex in vtx */
    uint64_t *tri_start; size_t tri_start_cap;
    uint32_t *vt_inst, *vt_block; size_t vt_cap, vt_block_cap;
    chunk_data *chunks; size_t chunks_cap;
    float *tkey; uint32_t *tinst, *tprim; size_t tkey_cap, tinst_cap, tprim_cap;  /* threads * T*T */
    uint64_t *tile_covered; size_t covered_cap;
};

/* Make *p hold at least `need` elements of `elem` bytes. Returns 0 when out of memory. */
static int grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap && *p)
        return 1;
    size_t n = need < 16 ? 16 : need + need / 2, bytes;
    if (!obs_mul_size(n, elem, &bytes))
        return 0;
    void *q = obs_aligned_alloc(bytes);
    if (!q)
        return 0;
    obs_aligned_free(*p); /* contents need not survive a grow */
    *p = q;
    *cap = n;
    return 1;
}

rast_workspace *rast_workspace_create(void)
{
    return (rast_workspace *)calloc(1, sizeof(rast_workspace));
}

void rast_workspace_destroy(rast_workspace *ws)
{
    if (!ws)
        return;
    obs_aligned_free(ws->vtx);
    obs_aligned_free(ws->voff);
    obs_aligned_free(ws->tri_start);
    obs_aligned_free(ws->vt_inst);
    obs_aligned_free(ws->vt_block);
    for (size_t c = 0; c < ws->chunks_cap; c++) {
        obs_aligned_free(ws->chunks[c].tris);
        obs_aligned_free(ws->chunks[c].bin_start);
        obs_aligned_free(ws->chunks[c].bin_list);
        obs_aligned_free(ws->chunks[c].fill);
    }
    obs_aligned_free(ws->chunks);
    obs_aligned_free(ws->tkey);
    obs_aligned_free(ws->tinst);
    obs_aligned_free(ws->tprim);
    obs_aligned_free(ws->tile_covered);
    free(ws);
}

/* ------------------------------------------------------------------------------------------------
 * Render state of one view
 * ---------------------------------------------------------------------------------------------- */

typedef struct render_state {
    const obs_scene *scene;
    const rast_params *p;
    const rast_view_constants *vc;
    rast_gbuffer *gb;
    rast_workspace *ws;
    int W, H, ortho;
    double fx, fy, cx, cy, znear, zfar;
    int64_t chunk_count;
    obs_tiling tiling;
    rast_i_tile_fn tile_fn;
    rast_i_resolve4_fn resolve4;
    float bg_ndc;
} render_state;

/* ---- helpers of the transform and setup stages ------------------------------------------------- */

/* Cofactor matrix of the upper 3x3 of view*world, row-major: proportional to the inverse-
 * transpose, which is how normals transform (the scale is removed by normalising). */
static void normal_matrix(const obs_mat4 *view, const obs_mat4 *world, double out[9])
{
    obs_dmat4 mv = obs_dmat4_mul(obs_mat4_to_double(*view), obs_mat4_to_double(*world));
    double a00 = mv.m[0], a01 = mv.m[4], a02 = mv.m[8];
    double a10 = mv.m[1], a11 = mv.m[5], a12 = mv.m[9];
    double a20 = mv.m[2], a21 = mv.m[6], a22 = mv.m[10];
    out[0] = a11 * a22 - a12 * a21; out[1] = a12 * a20 - a10 * a22; out[2] = a10 * a21 - a11 * a20;
    out[3] = a02 * a21 - a01 * a22; out[4] = a00 * a22 - a02 * a20; out[5] = a01 * a20 - a00 * a21;
    out[6] = a01 * a12 - a02 * a11; out[7] = a02 * a10 - a00 * a12; out[8] = a00 * a11 - a01 * a10;
    double det = a00 * out[0] + a01 * out[1] + a02 * out[2];
    if (det < 0.0) /* a mirroring transform: the inverse-transpose is cofactor / det */
        for (int k = 0; k < 9; k++)
            out[k] = -out[k];
}

typedef struct vtx { double x, y, z; } vtx;

enum { PL_NEAR, PL_FAR, PL_LEFT, PL_RIGHT, PL_TOP, PL_BOTTOM, PL_COUNT };

/* Clip planes as linear functions of view-space position (clipping in view space is clipping in
 * clip space, since clip coordinates are linear in view coordinates). The guard-band planes keep
 * the projected sx = cx + fx x / w within [-G, W + G] and sy = cy - fy y / w within [-G, H + G],
 * G = RAST_GUARD_BAND_PX:
 *   left (cx + G) w + fx x >= 0, right (W + G - cx) w - fx x >= 0,
 *   top  (cy + G) w - fy y >= 0, bottom (H + G - cy) w + fy y >= 0 (row 0 at the top). */
static double guard_eval(const render_state *rs, int plane, const vtx *v)
{
    double w = rs->ortho ? 1.0 : -v->z;
    const double G = RAST_GUARD_BAND_PX;
    switch (plane) {
    case PL_NEAR: return -v->z - rs->znear;
    case PL_FAR: return v->z + rs->zfar;
    case PL_LEFT: return (rs->cx + G) * w + rs->fx * v->x;
    case PL_RIGHT: return ((double)rs->W + G - rs->cx) * w - rs->fx * v->x;
    case PL_TOP: return (rs->cy + G) * w - rs->fy * v->y;
    case PL_BOTTOM: return ((double)rs->H + G - rs->cy) * w + rs->fy * v->y;
    default: return 0.0;
    }
}

/* Frustum outcode (near, far, left, right, top, bottom of the image itself). A triangle whose
 * vertices all have outcode 0 needs no clipping: it is inside the guard band too. */
static unsigned frustum_outcode(const render_state *rs, const vtx *v)
{
    double w = rs->ortho ? 1.0 : -v->z;
    double sx = rs->fx * v->x, sy = rs->fy * v->y; /* screen offsets from the centre, times w */
    unsigned c = 0;
    c |= (-v->z < rs->znear) ? 1u : 0u;
    c |= (-v->z > rs->zfar) ? 2u : 0u;      /* never for an infinite far plane */
    c |= (sx < -rs->cx * w) ? 4u : 0u;
    c |= (sx > ((double)rs->W - rs->cx) * w) ? 8u : 0u;
    c |= (sy > rs->cy * w) ? 16u : 0u;
    c |= (sy < -((double)rs->H - rs->cy) * w) ? 32u : 0u;
    return c;
}

/* Round half away from zero (as llround), without the libm call; |x| < 2^23 here. */
static inline int64_t round_away(double x) { return (int64_t)(x < 0.0 ? x - 0.5 : x + 0.5); }

/* floor(a / 256) and ceil(a / 256) for signed a (GCC and Clang shift signed values
 * arithmetically, which is floor division by a power of two). */
static inline int64_t floor256(int64_t a) { return a >> 8; }
static inline int64_t ceil256(int64_t a) { return -floor256(-a); }

/* Snap a screen position (pixels) to 1/256 px. */
static inline void snap(double sx, double sy, int64_t *X, int64_t *Y)
{
    const double lim = 8388607.0; /* 2^23 - 1 sub-pixel units; the guard band keeps us inside */
    double xs = sx * 256.0, ys = sy * 256.0;
    xs = xs < -lim ? -lim : (xs > lim ? lim : xs);
    ys = ys < -lim ? -lim : (ys > lim ? lim : ys);
    *X = round_away(xs);
    *Y = round_away(ys);
}

/* Set up one snapped triangle (sub-pixel integer positions, keys) and append it.
 * Returns 1 if appended, 0 if zero area or no pixel centre in its box, -1 when out of room. */
static int setup_piece(const render_state *rs, chunk_data *cd, const int64_t X[3], const int64_t Y[3],
                       const double key[3], uint32_t instance, uint32_t prim)
{
    int64_t area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
    if (area == 0)
        return 0;
    int64_t minX = X[0], maxX = X[0], minY = Y[0], maxY = Y[0];
    for (int i = 1; i < 3; i++) {
        minX = X[i] < minX ? X[i] : minX; maxX = X[i] > maxX ? X[i] : maxX;
        minY = Y[i] < minY ? Y[i] : minY; maxY = Y[i] > maxY ? Y[i] : maxY;
    }
    /* Pixel x is a candidate when its centre 256x + 128 lies in [minX, maxX]. */
    int64_t px0 = ceil256(minX - 128), px1 = floor256(maxX - 128);
    int64_t py0 = ceil256(minY - 128), py1 = floor256(maxY - 128);
    if (px0 < 0) px0 = 0;
    if (py0 < 0) py0 = 0;
    if (px1 > rs->W - 1) px1 = rs->W - 1;
    if (py1 > rs->H - 1) py1 = rs->H - 1;
    if (px0 > px1 || py0 > py1)
        return 0;
    if (cd->count == cd->cap)
        return -1; /* capacity is reserved per chunk; see render_view */
    rast_i_tri *t = &cd->tris[cd->count++];
    int o1 = area > 0 ? 1 : 2, o2 = area > 0 ? 2 : 1; /* positive orientation: inside has E_i >= 0 */
    int o[3] = {0, o1, o2};
    t->small = (maxX - minX) <= (1 << 14) && (maxY - minY) <= (1 << 14);
    t->minx = (int32_t)px0; t->maxx = (int32_t)px1;
    t->miny = (int32_t)py0; t->maxy = (int32_t)py1;
    for (int i = 0; i < 3; i++) {
        int a = o[i], b = o[(i + 1) % 3];
        int64_t A = Y[a] - Y[b], B = X[b] - X[a];
        t->A[i] = (int32_t)A;
        t->B[i] = (int32_t)B;
        t->C[i] = -(A * X[a] + B * Y[a]);
        /* top-left rule (y down): a left edge has A > 0; a top edge has A == 0 and B > 0 */
        t->bias[i] = (A > 0 || (A == 0 && B > 0)) ? 0 : 1;
    }
    /* Key plane through the snapped vertices, referenced at the first candidate pixel centre. */
    double x0 = (double)X[0] / 256.0, y0 = (double)Y[0] / 256.0;
    double dx1 = (double)(X[1] - X[0]) / 256.0, dy1 = (double)(Y[1] - Y[0]) / 256.0;
    double dx2 = (double)(X[2] - X[0]) / 256.0, dy2 = (double)(Y[2] - Y[0]) / 256.0;
    double inv_det = 65536.0 / (double)area;
    double kx = ((key[1] - key[0]) * dy2 - (key[2] - key[0]) * dy1) * inv_det;
    double ky = ((key[2] - key[0]) * dx1 - (key[1] - key[0]) * dx2) * inv_det;
    double ox = (double)px0 + 0.5, oy = (double)py0 + 0.5;
    t->k0 = (float)(key[0] + kx * (ox - x0) + ky * (oy - y0));
    t->kx = (float)kx;
    t->ky = (float)ky;
    t->ox = (float)ox;
    t->oy = (float)oy;
    t->instance = instance;
    t->prim = prim;
    return 1;
}

static inline void project(const render_state *rs, const vtx *v, double *sx, double *sy, double *key)
{
    if (rs->ortho) {
        *sx = rs->cx + rs->fx * v->x;
        *sy = rs->cy - rs->fy * v->y;
        *key = v->z; /* closer = larger z (less negative) */
    } else {
        double iw = 1.0 / -v->z;
        *sx = rs->cx + rs->fx * v->x * iw;
        *sy = rs->cy - rs->fy * v->y * iw;
        *key = iw;
    }
}

/* Sutherland-Hodgman against the active planes; at most 3 + 6 vertices. */
static int clip_polygon(const render_state *rs, vtx *poly, int n, unsigned planes)
{
    vtx tmp[12];
    for (int pl = 0; pl < PL_COUNT && n > 0; pl++) {
        if (!(planes & (1u << pl)))
            continue;
        int m = 0;
        for (int i = 0; i < n; i++) {
            const vtx *a = &poly[i], *b = &poly[(i + 1) % n];
            double da = guard_eval(rs, pl, a), db = guard_eval(rs, pl, b);
            if (da >= 0.0)
                tmp[m++] = *a;
            if ((da >= 0.0) != (db >= 0.0)) {
                /* Interpolate from the endpoint nearer the plane. From a, t = da / (da - db)
                 * rounds to 1 when |da| >> |db| and a + t (b - a) cancels: a vertex at depth
                 * 1.5e29 and one at 10.8 gave an intersection at z = 0, hence w = 0 and a NaN
                 * screen position (found by fuzz_gltf; docs/hard-cases.md). This way a shared
                 * edge is also cut at the same point whichever triangle clips it. */
                const vtx *p = a, *q = b;
                double dp = da, dq = db;
                if (fabs(da) > fabs(db)) {
                    p = b, q = a;
                    dp = db, dq = da;
                }
                double t = dp / (dp - dq);
                vtx c = {p->x + t * (q->x - p->x), p->y + t * (q->y - p->y), p->z + t * (q->z - p->z)};
                if (pl == PL_NEAR) /* land exactly on the plane */
                    c.z = -rs->znear;
                else if (pl == PL_FAR)
                    c.z = -rs->zfar;
                tmp[m++] = c;
            }
        }
        n = m;
        memcpy(poly, tmp, (size_t)n * sizeof(vtx));
    }
    return n;
}

/* ---- 1. vertex transform ---------------------------------------------------------------------- */

static void transform_task(void *user, int64_t task, int thread)
{
    (void)thread;
    render_state *rs = (render_state *)user;
    rast_workspace *ws = rs->ws;
    uint32_t i = ws->vt_inst[task];
    const obs_instance *in = &rs->scene->instances[i];
    const obs_mesh *m = &rs->scene->meshes[in->mesh];
    obs_dmat4 mv = obs_dmat4_mul(obs_mat4_to_double(rs->vc->view), obs_mat4_to_double(in->world));
    uint32_t v0 = ws->vt_block[task] * RAST_VERTEX_BLOCK;
    uint32_t v1 = v0 + RAST_VERTEX_BLOCK < m->vertex_count ? v0 + RAST_VERTEX_BLOCK : m->vertex_count;
    rast_vtx *out = ws->vtx + ws->voff[i];
    const double *a = mv.m;
    const int want_normals = m->normals && (rs->p->outputs & RAST_OUT_NORMAL);
    double N[9];
    if (want_normals)
        normal_matrix(&rs->vc->view, &in->world, N);
    for (uint32_t v = v0; v < v1; v++) {
        double x = m->positions[3 * v], y = m->positions[3 * v + 1], z = m->positions[3 * v + 2];
        rast_vtx *o = &out[v];
        vtx p = {a[0] * x + a[4] * y + a[8] * z + a[12], a[1] * x + a[5] * y + a[9] * z + a[13],
                 a[2] * x + a[6] * y + a[10] * z + a[14]};
        o->x = p.x;
        o->y = p.y;
        o->z = p.z;
        o->nx = o->ny = o->nz = 0.0f;
        if (!isfinite(p.x + p.y + p.z)) {
            o->code = RAST_VTX_NONFINITE;
            continue;
        }
        o->code = frustum_outcode(rs, &p);
        if (!o->code) { /* inside the image: its projection is what every triangle corner uses */
            double sx, sy;
            int64_t X, Y;
            project(rs, &p, &sx, &sy, &o->key);
            snap(sx, sy, &X, &Y);
            o->X = (int32_t)X;
            o->Y = (int32_t)Y;
        }
        if (want_normals) {
            const float *n = &m->normals[3 * (size_t)v];
            double nx = N[0] * n[0] + N[1] * n[1] + N[2] * n[2];
            double ny = N[3] * n[0] + N[4] * n[1] + N[5] * n[2];
            double nz = N[6] * n[0] + N[7] * n[1] + N[8] * n[2];
            double l = sqrt(nx * nx + ny * ny + nz * nz);
            if (l > 0.0 && isfinite(l)) { /* a bad normal stays 0 and contributes nothing */
                o->nx = (float)(nx / l);
                o->ny = (float)(ny / l);
                o->nz = (float)(nz / l);
            }
        }
    }
}

/* ---- 2. setup -------------------------------------------------------------------------------- */

static void setup_task(void *user, int64_t task, int thread)
{
    (void)thread;
    render_state *rs = (render_state *)user;
    rast_workspace *ws = rs->ws;
    chunk_data *cd = &ws->chunks[task];
    const obs_scene *sc = rs->scene;
    uint64_t g0 = (uint64_t)task * RAST_CHUNK;
    uint64_t g1 = g0 + RAST_CHUNK;
    uint64_t total = ws->tri_start[sc->instance_count];
    if (g1 > total)
        g1 = total;
    uint64_t nonfinite = 0, degenerate = 0, culled = 0, clipped = 0;
    cd->count = 0;
    /* find the instance holding g0 (binary search over the prefix sums) */
    uint32_t lo = 0, hi = sc->instance_count;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (ws->tri_start[mid] <= g0) lo = mid; else hi = mid;
    }
    uint32_t inst = lo;
    const int finite_far = isfinite(rs->zfar);
    const rast_cull cull = rs->p->cull;
    for (uint64_t g = g0; g < g1; g++) {
        while (g >= ws->tri_start[inst + 1])
            inst++;
        const obs_mesh *m = &sc->meshes[sc->instances[inst].mesh];
        uint32_t prim = (uint32_t)(g - ws->tri_start[inst]);
        const uint32_t *ix = &m->indices[3 * (size_t)prim];
        const rast_vtx *V = ws->vtx + ws->voff[inst];
        if (g + 8 < g1 && g + 8 < ws->tri_start[inst + 1]) { /* prefetch: a hint only */
            const uint32_t *nx = ix + 24;
            __builtin_prefetch(&V[nx[0]]);
            __builtin_prefetch(&V[nx[1]]);
            __builtin_prefetch(&V[nx[2]]);
        }
        const rast_vtx *a = &V[ix[0]], *b = &V[ix[1]], *c = &V[ix[2]];
        unsigned oc0 = a->code, oc1 = b->code, oc2 = c->code;
        if ((oc0 | oc1 | oc2) & RAST_VTX_NONFINITE) {
            nonfinite++;
            continue;
        }
        if (ix[0] == ix[1] || ix[1] == ix[2] || ix[0] == ix[2]) {
            degenerate++;
            continue;
        }
        vtx v[3] = {{a->x, a->y, a->z}, {b->x, b->y, b->z}, {c->x, c->y, c->z}};
        vtx e1 = {v[1].x - v[0].x, v[1].y - v[0].y, v[1].z - v[0].z};
        vtx e2 = {v[2].x - v[0].x, v[2].y - v[0].y, v[2].z - v[0].z};
        vtx ng = {e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
        if (ng.x == 0.0 && ng.y == 0.0 && ng.z == 0.0) {
            degenerate++;
            continue;
        }
        if (cull != RAST_CULL_NONE) {
            /* front = counter-clockwise seen from the eye: the normal points at the eye */
            double facing = rs->ortho ? ng.z : -(ng.x * v[0].x + ng.y * v[0].y + ng.z * v[0].z);
            int front = facing > 0.0;
            if ((cull == RAST_CULL_BACK && !front) || (cull == RAST_CULL_FRONT && front)) {
                culled++;
                continue;
            }
        }
        if (oc0 & oc1 & oc2) {
            culled++;
            continue;
        }
        int r = 0;
        if (!(oc0 | oc1 | oc2)) {
            /* Inside the image: the per-vertex projections apply. Pieces with zero area after
             * snapping, or no pixel centre in their box, are dropped silently: that is
             * sub-pixel geometry, not an error. */
            int64_t X[3] = {a->X, b->X, c->X}, Y[3] = {a->Y, b->Y, c->Y};
            double key[3] = {a->key, b->key, c->key};
            r = setup_piece(rs, cd, X, Y, key, inst, prim);
        } else {
            /* Partly outside the image: which clip planes does it cross? */
            unsigned planes = 0;
            for (int pl = 0; pl < PL_COUNT; pl++) {
                if (pl == PL_FAR && !finite_far)
                    continue;
                if (guard_eval(rs, pl, &v[0]) < 0.0 || guard_eval(rs, pl, &v[1]) < 0.0 || guard_eval(rs, pl, &v[2]) < 0.0)
                    planes |= 1u << pl;
            }
            if (planes)
                clipped++;
            vtx poly[12] = {v[0], v[1], v[2]};
            int n = planes ? clip_polygon(rs, poly, 3, planes) : 3;
            if (n < 3) {
                culled++;
                continue;
            }
            int64_t X[12], Y[12];
            double key[12];
            for (int k = 0; k < n; k++) {
                double sx, sy;
                project(rs, &poly[k], &sx, &sy, &key[k]);
                snap(sx, sy, &X[k], &Y[k]);
            }
            for (int k = 1; k + 1 < n && r >= 0; k++) {
                int64_t X3[3] = {X[0], X[k], X[k + 1]}, Y3[3] = {Y[0], Y[k], Y[k + 1]};
                double K3[3] = {key[0], key[k], key[k + 1]};
                r = setup_piece(rs, cd, X3, Y3, K3, inst, prim);
            }
        }
        if (r < 0) {
            cd->oom = 2; /* out of reserved records: the driver grows and retries */
            return;
        }
    }
    cd->nonfinite = nonfinite;
    cd->degenerate = degenerate;
    cd->culled = culled;
    cd->clipped = clipped;

    /* Bin the chunk's records into tiles (a counting sort keeps record order within a tile). */
    const obs_tiling *tl = &rs->tiling;
    size_t ntiles = (size_t)obs_tiling_count(tl);
    if (!grow((void **)&cd->bin_start, &cd->bin_start_cap, ntiles + 1, sizeof(uint32_t)) ||
        !grow((void **)&cd->fill, &cd->fill_cap, ntiles, sizeof(uint32_t))) {
        cd->oom = 1;
        return;
    }
    memset(cd->bin_start, 0, (ntiles + 1) * sizeof(uint32_t));
    const int shift = __builtin_ctz((unsigned)tl->tile);
    uint64_t refs = 0;
    for (uint32_t i = 0; i < cd->count; i++) {
        const rast_i_tri *t = &cd->tris[i];
        int tx0 = t->minx >> shift, tx1 = t->maxx >> shift, ty0 = t->miny >> shift, ty1 = t->maxy >> shift;
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++)
                cd->bin_start[(size_t)ty * tl->tiles_x + tx + 1]++;
        refs += (uint64_t)(tx1 - tx0 + 1) * (uint64_t)(ty1 - ty0 + 1);
    }
    if (refs > UINT32_MAX || !grow((void **)&cd->bin_list, &cd->bin_list_cap, (size_t)refs, sizeof(uint32_t))) {
        cd->oom = 1;
        return;
    }
    for (size_t k = 0; k < ntiles; k++)
        cd->bin_start[k + 1] += cd->bin_start[k];
    memcpy(cd->fill, cd->bin_start, ntiles * sizeof(uint32_t));
    for (uint32_t i = 0; i < cd->count; i++) {
        const rast_i_tri *t = &cd->tris[i];
        int tx0 = t->minx >> shift, tx1 = t->maxx >> shift, ty0 = t->miny >> shift, ty1 = t->maxy >> shift;
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++)
                cd->bin_list[cd->fill[(size_t)ty * tl->tiles_x + tx]++] = i;
    }
}

/* ---- 3. tiles: visibility, then resolve ------------------------------------------------------ */

static void resolve_tri_setup(const render_state *rs, uint32_t inst, uint32_t prim, resolve_tri *r)
{
    const obs_scene *sc = rs->scene;
    const obs_mesh *m = &sc->meshes[sc->instances[inst].mesh];
    const uint32_t *ix = &m->indices[3 * (size_t)prim];
    const rast_vtx *V = rs->ws->vtx + rs->ws->voff[inst];
    const rast_vtx *a = &V[ix[0]], *b = &V[ix[1]], *c = &V[ix[2]];
    obs_dvec3 v0 = obs_dv3(a->x, a->y, a->z), v1 = obs_dv3(b->x, b->y, b->z), v2 = obs_dv3(c->x, c->y, c->z);
    obs_dvec3 e1 = obs_dv3_sub(v1, v0), e2 = obs_dv3_sub(v2, v0);
    obs_dvec3 n = obs_dv3_cross(e1, e2);
    double nn = obs_dv3_dot(n, n); /* > 0: setup skipped zero-area triangles */
    double inn = 1.0 / nn, il = 1.0 / sqrt(nn);
    obs_dvec3 d1 = obs_dv3_cross(e2, n), d2 = obs_dv3_cross(n, e1);
    r->inst = inst;
    r->prim = prim;
    r->v0 = v0;
    r->n = n;
    r->n_v0 = obs_dv3_dot(n, v0);
    r->m1 = obs_dv3(d1.x * inn, d1.y * inn, d1.z * inn);
    r->m2 = obs_dv3(d2.x * inn, d2.y * inn, d2.z * inn);
    r->c1 = obs_dv3_dot(v0, r->m1);
    r->c2 = obs_dv3_dot(v0, r->m2);
    r->nunit = obs_dv3(n.x * il, n.y * il, n.z * il);
    r->has_vn = m->normals && (rs->p->outputs & RAST_OUT_NORMAL);
    if (r->has_vn) {
        const rast_vtx *abc[3] = {a, b, c};
        for (int k = 0; k < 3; k++) {
            r->vn[k][0] = abc[k]->nx;
            r->vn[k][1] = abc[k]->ny;
            r->vn[k][2] = abc[k]->nz;
        }
    }
    r->material = m->material >= 0 ? (uint32_t)m->material : RAST_ID_NONE;
    /* The depth range of the visible piece (F8): the vertices' linear depths (-z: view space
     * looks down -z, for both projections), within the clip range the piece was cut to. */
    double zmin = -v0.z, zmax = -v0.z;
    zmin = -v1.z < zmin ? -v1.z : zmin;
    zmax = -v1.z > zmax ? -v1.z : zmax;
    zmin = -v2.z < zmin ? -v2.z : zmin;
    zmax = -v2.z > zmax ? -v2.z : zmax;
    r->z_lo = zmin > rs->znear ? zmin : rs->znear;
    r->z_hi = zmax < rs->zfar ? zmax : rs->zfar;
    r->t_lo = r->z_lo - RAST_I_DEPTH_RANGE_SLACK * fabs(r->z_lo);
    r->t_hi = r->z_hi + RAST_I_DEPTH_RANGE_SLACK * fabs(r->z_hi);
}


/* A small direct-mapped cache of resolve_tri per tile: a triangle spans several rows of a tile,
 * and fetching its indices and vertices again for every row was the resolve's main cost
 * (cache misses on the index buffer). */
#define RESOLVE_CACHE 64

static inline resolve_tri *resolve_lookup(const render_state *rs, resolve_tri *cache, uint32_t inst, uint32_t prim)
{
    resolve_tri *r = &cache[(prim * 2654435761u + inst) >> 26 & (RESOLVE_CACHE - 1)];
    if (r->inst != inst || r->prim != prim)
        resolve_tri_setup(rs, inst, prim, r);
    return r;
}

static void resolve_row(const render_state *rs, int y, int x0, int n, const uint32_t *inst, const uint32_t *prim,
                        const float *key, resolve_tri *cache)
{
    rast_gbuffer *gb = rs->gb;
    const uint32_t out = gb->outputs;
    out_rows o;
    memset(&o, 0, sizeof o);
#define ROWF(bit, plane, dst) if (out & (bit)) dst = obs_image_f32_row(&(plane), y) + x0
#define ROWU(bit, plane, dst) if (out & (bit)) dst = obs_image_u32_row(&(plane), y) + x0
    ROWF(RAST_OUT_DEPTH, gb->depth, o.depth);
    ROWF(RAST_OUT_NDC_DEPTH, gb->ndc_depth, o.ndc);
    for (int c = 0; c < 3; c++) {
        ROWF(RAST_OUT_NORMAL, gb->normal[c], o.n[c]);
        ROWF(RAST_OUT_FACE_NORMAL, gb->face_normal[c], o.ng[c]);
    }
    ROWU(RAST_OUT_PRIM_ID, gb->prim_id, o.prim);
    ROWU(RAST_OUT_INSTANCE_ID, gb->instance_id, o.inst);
    ROWU(RAST_OUT_MATERIAL_ID, gb->material_id, o.mat);
#undef ROWF
#undef ROWU
    const double py = y + 0.5, ay = -(py - rs->cy) * (1.0 / rs->fy), inv_fx = 1.0 / rs->fx;
    const rast_depth_convention conv = rs->p->depth_convention;
    const int face_forward = rs->p->face_forward;
    for (int i = 0; i < n; i++) {
        uint32_t id = inst[i];
        if (id == RAST_ID_NONE) {
            if (o.depth) o.depth[i] = INFINITY;
            if (o.ndc) o.ndc[i] = rs->bg_ndc;
            if (o.n[0]) o.n[0][i] = o.n[1][i] = o.n[2][i] = 0.0f;
            if (o.ng[0]) o.ng[0][i] = o.ng[1][i] = o.ng[2][i] = 0.0f;
            if (o.prim) o.prim[i] = RAST_ID_NONE;
            if (o.inst) o.inst[i] = RAST_ID_NONE;
            if (o.mat) o.mat[i] = RAST_ID_NONE;
            continue;
        }
        if (i + 6 < n && inst[i + 6] != RAST_ID_NONE) { /* prefetch a later triangle's indices */
            const obs_mesh *pm = &rs->scene->meshes[rs->scene->instances[inst[i + 6]].mesh];
            __builtin_prefetch(&pm->indices[3 * (size_t)prim[i + 6]]);
        }
        const resolve_tri *r = resolve_lookup(rs, cache, id, prim[i]);
        /* Four neighbours showing the same triangle: the SIMD path, when there is one, does
         * exactly this arithmetic lane by lane (it returns 0 to leave a group to us). */
        if (rs->resolve4 && i + 3 < n && inst[i + 3] == id && prim[i + 3] == prim[i] && inst[i + 1] == id &&
            prim[i + 1] == prim[i] && inst[i + 2] == id && prim[i + 2] == prim[i] &&
            rs->resolve4(r, &o, i, x0 + i, ay, rs->cx, inv_fx, rs->ortho, face_forward)) {
            if (o.ndc)
                for (int k = 0; k < 4; k++)
                    o.ndc[i + k] = (float)rast_ndc_depth_from_linear(rs->vc, conv, (double)o.depth_exact[k]);
            i += 3;
            continue;
        }
        /* The exact ray through the pixel centre (view space; see rast_pixel_ray), with slopes
         * (ax, ay): perspective o = 0, d = (ax, ay, -1); orthographic o = (ax, ay, 0),
         * d = (0, 0, -1). Its hit with the plane n.p = n.v0 and the barycentrics
         * b_k = (P - v0).m_k are linear forms in (ax, ay) and t: */
        double ax = ((x0 + i) + 0.5 - rs->cx) * inv_fx;
        double t, b1, b2, nd;
        if (!rs->ortho) {
            nd = r->n.x * ax + r->n.y * ay - r->n.z;
            t = r->n_v0 / nd; /* the linear depth: d.z = -1 */
            b1 = t * (r->m1.x * ax + r->m1.y * ay - r->m1.z) - r->c1;
            b2 = t * (r->m2.x * ax + r->m2.y * ay - r->m2.z) - r->c2;
        } else {
            nd = -r->n.z;
            t = (r->n_v0 - r->n.x * ax - r->n.y * ay) / nd;
            b1 = r->m1.x * ax + r->m1.y * ay - r->m1.z * t - r->c1;
            b2 = r->m2.x * ax + r->m2.y * ay - r->m2.z * t - r->c2;
        }
        if (!(t > 0.0 && t >= r->t_lo && t <= r->t_hi)) {
            /* Edge-on under snapping (F8): the plane (nearly) holds the eye, and the exact depth
             * is <= 0, not finite, or outside the piece's own depth range (beyond the slack).
             * Fall back to the raster key, clamped into that range. */
            t = rs->ortho ? -(double)key[i] : 1.0 / (double)key[i];
            if (!(t >= r->z_lo)) /* NaN too */
                t = r->z_lo;
            if (t > r->z_hi)
                t = r->z_hi;
        }
        const float flip = (face_forward && nd > 0.0) ? -1.0f : 1.0f;
        if (o.depth) o.depth[i] = (float)t;
        if (o.ndc) o.ndc[i] = (float)rast_ndc_depth_from_linear(rs->vc, conv, t);
        if (o.ng[0]) {
            o.ng[0][i] = flip * (float)r->nunit.x;
            o.ng[1][i] = flip * (float)r->nunit.y;
            o.ng[2][i] = flip * (float)r->nunit.z;
        }
        if (o.n[0]) {
            float nsx = (float)r->nunit.x, nsy = (float)r->nunit.y, nsz = (float)r->nunit.z;
            if (r->has_vn) {
                /* clamp to the triangle: snapping can put a centre just outside it */
                b1 = b1 < 0.0 ? 0.0 : (b1 > 1.0 ? 1.0 : b1);
                b2 = b2 < 0.0 ? 0.0 : (b2 > 1.0 ? 1.0 : b2);
                if (b1 + b2 > 1.0) {
                    double sc = 1.0 / (b1 + b2);
                    b1 *= sc;
                    b2 *= sc;
                }
                /* The blend of unit vertex normals runs in float: the shading normal is an
                 * interpolated quantity with no exact reference, and float keeps it within
                 * 1e-6 of the double result. */
                float fb1 = (float)b1, fb2 = (float)b2, fb0 = 1.0f - fb1 - fb2;
                float sx = fb0 * r->vn[0][0] + fb1 * r->vn[1][0] + fb2 * r->vn[2][0];
                float sy = fb0 * r->vn[0][1] + fb1 * r->vn[1][1] + fb2 * r->vn[2][1];
                float sz = fb0 * r->vn[0][2] + fb1 * r->vn[1][2] + fb2 * r->vn[2][2];
                float l2 = sx * sx + sy * sy + sz * sz;
                if (l2 > 1e-12f) {
                    float il = 1.0f / sqrtf(l2);
                    nsx = sx * il;
                    nsy = sy * il;
                    nsz = sz * il;
                }
            }
            o.n[0][i] = flip * nsx;
            o.n[1][i] = flip * nsy;
            o.n[2][i] = flip * nsz;
        }
        if (o.prim) o.prim[i] = r->prim;
        if (o.inst) o.inst[i] = r->inst;
        if (o.mat) o.mat[i] = r->material;
    }
}

/* A row segment with no surface: plain fills, one plane at a time. */
static void background_row(const render_state *rs, int y, int x0, int n)
{
    rast_gbuffer *gb = rs->gb;
    const uint32_t out = gb->outputs;
#define FILLF(bit, plane, v) if (out & (bit)) { float *r_ = obs_image_f32_row(&(plane), y) + x0; for (int i = 0; i < n; i++) r_[i] = (v); }
#define FILLU(bit, plane) if (out & (bit)) { uint32_t *r_ = obs_image_u32_row(&(plane), y) + x0; for (int i = 0; i < n; i++) r_[i] = RAST_ID_NONE; }
    FILLF(RAST_OUT_DEPTH, gb->depth, INFINITY);
    FILLF(RAST_OUT_NDC_DEPTH, gb->ndc_depth, rs->bg_ndc);
    for (int c = 0; c < 3; c++) {
        FILLF(RAST_OUT_NORMAL, gb->normal[c], 0.0f);
        FILLF(RAST_OUT_FACE_NORMAL, gb->face_normal[c], 0.0f);
    }
    FILLU(RAST_OUT_PRIM_ID, gb->prim_id);
    FILLU(RAST_OUT_INSTANCE_ID, gb->instance_id);
    FILLU(RAST_OUT_MATERIAL_ID, gb->material_id);
#undef FILLF
#undef FILLU
}

static void tile_task(void *user, int64_t task, int thread)
{
    render_state *rs = (render_state *)user;
    rast_workspace *ws = rs->ws;
    int x0, y0, x1, y1;
    obs_tiling_rect(&rs->tiling, task, &x0, &y0, &x1, &y1);
    const int T = rs->tiling.tile, tw = x1 - x0, th = y1 - y0;
    const size_t TT = (size_t)T * T;
    float *key = ws->tkey + (size_t)thread * TT;
    uint32_t *inst = ws->tinst + (size_t)thread * TT, *prim = ws->tprim + (size_t)thread * TT;
    for (int y = 0; y < th; y++) { /* two plain loops: both vectorise */
        float *kr = key + (size_t)y * T;
        uint32_t *ir = inst + (size_t)y * T;
        for (int x = 0; x < tw; x++)
            kr[x] = -INFINITY;
        for (int x = 0; x < tw; x++)
            ir[x] = RAST_ID_NONE;
    }
    for (int64_t c = 0; c < rs->chunk_count; c++) {
        const chunk_data *cd = &ws->chunks[c];
        uint32_t b0 = cd->bin_start[task], b1 = cd->bin_start[task + 1];
        if (b1 > b0)
            rs->tile_fn(cd->tris, cd->bin_list + b0, b1 - b0, x0, y0, tw, th, T, key, inst, prim);
    }
    uint64_t covered = 0;
    resolve_tri cache[RESOLVE_CACHE]; /* only the keys need resetting (zeroing it all cost 15%) */
    for (int k = 0; k < RESOLVE_CACHE; k++)
        cache[k].inst = RAST_ID_NONE;
    for (int y = 0; y < th; y++) {
        const uint32_t *ir = inst + (size_t)y * T;
        int row_covered = 0;
        for (int x = 0; x < tw; x++)
            row_covered += ir[x] != RAST_ID_NONE;
        covered += (uint64_t)row_covered;
        if (row_covered)
            resolve_row(rs, y0 + y, x0, tw, ir, prim + (size_t)y * T, key + (size_t)y * T, cache);
        else
            background_row(rs, y0 + y, x0, tw);
    }
    ws->tile_covered[task] = covered;
}

/* ------------------------------------------------------------------------------------------------
 * rast_render
 * ---------------------------------------------------------------------------------------------- */

static rast_isa choose_isa(rast_isa want)
{
    if (want == RAST_ISA_AUTO) {
        const char *env = getenv("OBS_ISA");
        if (env && !strcmp(env, "scalar"))
            return RAST_ISA_SCALAR;
        return rast_isa_available(RAST_ISA_AVX2) ? RAST_ISA_AVX2 : RAST_ISA_SCALAR;
    }
    return want;
}

static obs_status render_view(obs_context *ctx, obs_pool *pool, rast_workspace *ws, const obs_scene *sc,
                              const obs_camera *cam, const rast_params *p, rast_gbuffer *gb, rast_i_tile_fn tile_fn,
                              rast_stats *st)
{
    rast_view_constants vc;
    obs_status s = rast_view_constants_make(ctx, p, cam, &vc);
    if (s != OBS_STATUS_OK)
        return s;
    gb->constants = vc;
    const int threads = obs_pool_threads(pool);
    render_state rs;
    memset(&rs, 0, sizeof rs);
    rs.scene = sc;
    rs.p = p;
    rs.vc = &gb->constants;
    rs.gb = gb;
    rs.ws = ws;
    rs.W = vc.full_width;
    rs.H = vc.full_height;
    rs.ortho = vc.projection_type == OBS_PROJECTION_ORTHOGRAPHIC;
    rs.fx = vc.fx; rs.fy = vc.fy; rs.cx = vc.cx; rs.cy = vc.cy;
    rs.znear = vc.znear; rs.zfar = vc.zfar;
    rs.tile_fn = tile_fn;
#if defined(OBS_HAVE_AVX2)
    rs.resolve4 = tile_fn == rast_i_tile_avx2 ? rast_i_resolve4_avx2 : NULL;
#endif
    rs.tiling = obs_tiling_make(rs.W, rs.H, p->tile_size);
    rs.bg_ndc = p->depth_convention == RAST_DEPTH_REVERSED_Z ? 0.0f : 1.0f;
    double t0 = obs_time_now();

    /* 1. transform */
    const uint32_t ni = sc->instance_count;
    if (!grow((void **)&ws->voff, &ws->voff_cap, (size_t)ni + 1, sizeof(uint64_t)) ||
        !grow((void **)&ws->tri_start, &ws->tri_start_cap, (size_t)ni + 1, sizeof(uint64_t)))
        goto oom;
    uint64_t ntasks = 0;
    ws->voff[0] = 0;
    ws->tri_start[0] = 0;
    for (uint32_t i = 0; i < ni; i++) {
        const obs_mesh *m = &sc->meshes[sc->instances[i].mesh];
        ws->voff[i + 1] = ws->voff[i] + m->vertex_count;
        ws->tri_start[i + 1] = ws->tri_start[i] + m->triangle_count;
        ntasks += (m->vertex_count + RAST_VERTEX_BLOCK - 1) / RAST_VERTEX_BLOCK;
    }
    size_t nverts = (size_t)ws->voff[ni];
    if (!grow((void **)&ws->vtx, &ws->vtx_cap, nverts + 1, sizeof(rast_vtx)) ||
        !grow((void **)&ws->vt_inst, &ws->vt_cap, (size_t)ntasks + 1, sizeof(uint32_t)) ||
        !grow((void **)&ws->vt_block, &ws->vt_block_cap, (size_t)ntasks + 1, sizeof(uint32_t)))
        goto oom;
    ntasks = 0;
    for (uint32_t i = 0; i < ni; i++) {
        const obs_mesh *m = &sc->meshes[sc->instances[i].mesh];
        for (uint32_t b = 0; (uint64_t)b * RAST_VERTEX_BLOCK < m->vertex_count; b++) {
            ws->vt_inst[ntasks] = i;
            ws->vt_block[ntasks] = b;
            ntasks++;
        }
    }
    obs_pool_run(pool, (int64_t)ntasks, transform_task, &rs);

    /* 2. setup and binning. A chunk first reserves one record per triangle plus some slack;
     * clipping can make up to 7 pieces of one triangle (a polygon of up to 9 vertices), so a
     * chunk that runs out is given room for 7 per triangle and set up again. */
    uint64_t total = ws->tri_start[ni];
    rs.chunk_count = (int64_t)((total + RAST_CHUNK - 1) / RAST_CHUNK);
    if (rs.chunk_count > 0 && (size_t)rs.chunk_count > ws->chunks_cap) {
        size_t ncap = (size_t)rs.chunk_count;
        chunk_data *nc = (chunk_data *)obs_aligned_alloc(ncap * sizeof(chunk_data));
        if (!nc)
            goto oom;
        memset(nc, 0, ncap * sizeof(chunk_data));
        if (ws->chunks)
            memcpy(nc, ws->chunks, ws->chunks_cap * sizeof(chunk_data));
        obs_aligned_free(ws->chunks);
        ws->chunks = nc;
        ws->chunks_cap = ncap;
    }
    for (int64_t c = 0; c < rs.chunk_count; c++) {
        chunk_data *cd = &ws->chunks[c];
        uint64_t n = total - (uint64_t)c * RAST_CHUNK < RAST_CHUNK ? total - (uint64_t)c * RAST_CHUNK : RAST_CHUNK;
        size_t cap = cd->cap;
        if (!grow((void **)&cd->tris, &cap, (size_t)n + 256, sizeof(rast_i_tri)))
            goto oom;
        cd->cap = (uint32_t)(cap > UINT32_MAX ? UINT32_MAX : cap);
        cd->oom = 0;
        cd->count = 0;
    }
    if (rs.chunk_count > 0)
        obs_pool_run(pool, rs.chunk_count, setup_task, &rs);
    for (int64_t c = 0; c < rs.chunk_count; c++) {
        chunk_data *cd = &ws->chunks[c];
        if (cd->oom == 2) { /* ran out of records: reserve the worst case and redo this chunk */
            size_t cap = cd->cap;
            if (!grow((void **)&cd->tris, &cap, (size_t)RAST_CHUNK * 7, sizeof(rast_i_tri)))
                goto oom;
            cd->cap = (uint32_t)cap;
            cd->oom = 0;
            setup_task(&rs, c, 0);
        }
        if (cd->oom)
            goto oom;
        st->triangles_nonfinite += cd->nonfinite;
        st->triangles_degenerate += cd->degenerate;
        st->triangles_culled += cd->culled;
        st->triangles_clipped += cd->clipped;
        st->triangles_rasterized += cd->count;
    }
    st->triangles_in += total;
    double t1 = obs_time_now();

    /* 3. tiles */
    size_t ntiles = (size_t)obs_tiling_count(&rs.tiling);
    size_t tt = (size_t)p->tile_size * (size_t)p->tile_size * (size_t)threads;
    if (!grow((void **)&ws->tkey, &ws->tkey_cap, tt, sizeof(float)) ||
        !grow((void **)&ws->tinst, &ws->tinst_cap, tt, sizeof(uint32_t)) ||
        !grow((void **)&ws->tprim, &ws->tprim_cap, tt, sizeof(uint32_t)) ||
        !grow((void **)&ws->tile_covered, &ws->covered_cap, ntiles, sizeof(uint64_t)))
        goto oom;
    /* With no triangles there are no chunks, and every tile resolves to background. */
    obs_pool_run(pool, (int64_t)ntiles, tile_task, &rs);
    for (size_t k = 0; k < ntiles; k++)
        st->pixels_covered += ws->tile_covered[k];
    double t2 = obs_time_now();
    st->seconds_setup += t1 - t0;
    st->seconds_raster += t2 - t1; /* visibility and resolve run fused per tile */
    return OBS_STATUS_OK;
oom:
    return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "rasterizer: out of memory while rendering %llu triangles",
                     (unsigned long long)obs_scene_triangle_count(sc));
}

obs_status rast_render_ws(obs_context *ctx, obs_pool *pool, rast_workspace *ws, const obs_scene *scene,
                          const rast_view *views, int view_count, const rast_params *params, rast_gbuffer *layers,
                          rast_stats *stats)
{
    rast_stats local;
    rast_stats *st = stats ? stats : &local;
    memset(st, 0, sizeof *st);
    if (!ws || !scene || !views || !params || !layers || view_count < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_render: NULL argument or view_count %d < 1",
                         view_count);
    if (params->tile_size < 16 || params->tile_size > 256 || (params->tile_size & (params->tile_size - 1)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "rast_render: tile_size %d must be a power of two in [16, 256]", params->tile_size);
    if ((unsigned)params->depth_convention >= RAST_DEPTH_COUNT || (unsigned)params->cull >= RAST_CULL_COUNT ||
        (unsigned)params->isa >= RAST_ISA_COUNT || (params->outputs & ~RAST_OUT_ALL))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_render: an enum parameter is out of range");
    rast_isa isa = choose_isa(params->isa);
    if (!rast_isa_available(isa))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "rast_render: the %s path is not available (%s)",
                         rast_isa_name(isa),
#if defined(OBS_HAVE_AVX2)
                         "this CPU lacks it"
#else
                         "this build has OBS_ENABLE_SIMD=OFF"
#endif
        );
    rast_i_tile_fn fn = rast_i_tile_scalar;
#if defined(OBS_HAVE_AVX2)
    if (isa == RAST_ISA_AVX2)
        fn = rast_i_tile_avx2;
#endif
    st->isa_used = isa;
    for (int k = 0; k < view_count; k++) {
        rast_gbuffer *gb = &layers[k];
        if (gb->width != params->width + 2 * params->guard || gb->height != params->height + 2 * params->guard ||
            gb->outputs != params->outputs || gb->guard != params->guard)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "rast_render: layer %d was allocated for other params (%dx%d, guard %d, outputs 0x%x)", k,
                             gb->width, gb->height, gb->guard, gb->outputs);
        gb->depth_convention = params->depth_convention;
        obs_status s = render_view(ctx, pool, ws, scene, &views[k].camera, params, gb, fn, st);
        if (s != OBS_STATUS_OK)
            return s;
    }
    return OBS_STATUS_OK;
}

static const char rast_workspace_scratch_key = 0; /* its address keys the context's scratch slot */
static void workspace_destroy_cb(void *ws) { rast_workspace_destroy((rast_workspace *)ws); }

obs_status rast_render(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const rast_view *views,
                       int view_count, const rast_params *params, rast_gbuffer *layers, rast_stats *stats)
{
    /* The workspace is parked in the context between calls (obs_context_scratch_*), so that the
     * renders of one context (the SSS light maps, the K map views and the camera G-buffer of one
     * build; repeated builds) reuse its buffers instead of page-faulting fresh ones: in the SSS
     * bench a fresh workspace per call cost ~10k page faults of ~56k (docs/raster.md). */
    rast_workspace *ws = (rast_workspace *)obs_context_scratch_take(ctx, &rast_workspace_scratch_key);
    if (!ws)
        ws = rast_workspace_create();
    if (!ws)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "rast_render: out of memory");
    obs_status s = rast_render_ws(ctx, pool, ws, scene, views, view_count, params, layers, stats);
    obs_context_scratch_put(ctx, &rast_workspace_scratch_key, ws, workspace_destroy_cb);
    return s;
}
