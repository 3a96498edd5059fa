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
 *      kept: ties go to the earlier triangle), then resolves its pixels: the visible triangle is
 *      intersected with the pixel's exact ray in double (Moller-Trumbore [Moller97]), giving the
 *      depth, barycentrics and normals; outputs are written once per pixel.
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
    p.width = 1920;  /* the seed study's main resolution */
    p.height = 1080;
    p.guard = 0;
    p.outputs = RAST_OUT_ALL;
    p.depth_convention = RAST_DEPTH_GL_STANDARD;
    p.cull = RAST_CULL_NONE;
    p.face_forward = 1;
    p.isa = RAST_ISA_AUTO;
    p.tile_size = 64;
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
    double ax = (px - vc->cx) / vc->fx, ay = -(py - vc->cy) / vc->fy;
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

obs_status rast_gbuffer_alloc(obs_context *ctx, const rast_params *p, rast_gbuffer *out)
{
    if (!p || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_gbuffer_alloc: NULL argument");
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
    if (st == OBS_STATUS_OK && (p->outputs & (bit))) st = obs_image_f32_alloc(ctx, W, H, &(plane))
#define ALLOC_U(bit, plane) \
    if (st == OBS_STATUS_OK && (p->outputs & (bit))) st = obs_image_u32_alloc(ctx, W, H, &(plane))
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
 * Render state
 * ---------------------------------------------------------------------------------------------- */

typedef struct chunk_data {
    rast_i_tri *tris;
    uint32_t count, cap;
    uint32_t *bin_start;   /* tile_count + 1 */
    uint32_t *bin_list;
    uint64_t nonfinite, degenerate, culled, clipped;
    int oom;
} chunk_data;

typedef struct render_state {
    const obs_scene *scene;
    const rast_params *p;
    const rast_view_constants *vc;
    rast_gbuffer *gb;
    int W, H, ortho;
    double fx, fy, cx, cy, znear, zfar;
    double gx, gy;               /* guard band in NDC units: |x_ndc| <= gx */
    /* per instance */
    double **vpos;               /* view-space positions, 3 per vertex */
    double (*nmat)[9];           /* view-space normal matrix, row-major 3x3 */
    uint64_t *tri_start;         /* prefix sum of triangle counts over instances (count+1) */
    /* vertex transform tasks */
    uint32_t *vt_inst;
    uint32_t *vt_block;
    /* setup */
    int64_t chunk_count;
    chunk_data *chunks;
    obs_tiling tiling;
    /* tiles */
    rast_i_tile_fn tile_fn;
    float **tkey;
    uint32_t **tinst, **tprim;
    uint64_t *tile_covered;
    atomic_int failed;
} render_state;

/* ---- 1. vertex transform ---------------------------------------------------------------------- */

static void transform_task(void *user, int64_t task, int thread)
{
    (void)thread;
    render_state *rs = (render_state *)user;
    uint32_t i = rs->vt_inst[task];
    const obs_instance *in = &rs->scene->instances[i];
    const obs_mesh *m = &rs->scene->meshes[in->mesh];
    obs_dmat4 mv = obs_dmat4_mul(obs_mat4_to_double(rs->vc->view), obs_mat4_to_double(in->world));
    uint32_t v0 = rs->vt_block[task] * RAST_VERTEX_BLOCK;
    uint32_t v1 = v0 + RAST_VERTEX_BLOCK < m->vertex_count ? v0 + RAST_VERTEX_BLOCK : m->vertex_count;
    double *out = rs->vpos[i];
    const double *a = mv.m;
    for (uint32_t v = v0; v < v1; v++) {
        double x = m->positions[3 * v], y = m->positions[3 * v + 1], z = m->positions[3 * v + 2];
        out[3 * v + 0] = a[0] * x + a[4] * y + a[8] * z + a[12];
        out[3 * v + 1] = a[1] * x + a[5] * y + a[9] * z + a[13];
        out[3 * v + 2] = a[2] * x + a[6] * y + a[10] * z + a[14];
    }
}

/* Inverse-transpose of the upper 3x3 of view*world, row-major (normals transform by it). */
static void normal_matrix(const obs_mat4 *view, const obs_mat4 *world, double out[9])
{
    obs_dmat4 mv = obs_dmat4_mul(obs_mat4_to_double(*view), obs_mat4_to_double(*world));
    /* a[r][c] = mv.m[c*4 + r] */
    double a00 = mv.m[0], a01 = mv.m[4], a02 = mv.m[8];
    double a10 = mv.m[1], a11 = mv.m[5], a12 = mv.m[9];
    double a20 = mv.m[2], a21 = mv.m[6], a22 = mv.m[10];
    /* cofactor matrix = det * inverse^T; the scale does not matter, normals are renormalised */
    out[0] = a11 * a22 - a12 * a21; out[1] = a12 * a20 - a10 * a22; out[2] = a10 * a21 - a11 * a20;
    out[3] = a02 * a21 - a01 * a22; out[4] = a00 * a22 - a02 * a20; out[5] = a01 * a20 - a00 * a21;
    out[6] = a01 * a12 - a02 * a11; out[7] = a02 * a10 - a00 * a12; out[8] = a00 * a11 - a01 * a10;
    double det = a00 * out[0] + a01 * out[1] + a02 * out[2];
    if (det < 0.0) /* a mirroring transform: keep the cofactor direction = inverse-transpose */
        for (int k = 0; k < 9; k++)
            out[k] = -out[k];
}

/* ---- 2. setup -------------------------------------------------------------------------------- */

typedef struct vtx { double x, y, z; } vtx;

/* Signed distance-like functions of the clip planes, in view space (linear, so clipping here is
 * the same as clipping in homogeneous clip space). */
enum { PL_NEAR, PL_FAR, PL_LEFT, PL_RIGHT, PL_BOTTOM, PL_TOP, PL_COUNT };

/* Guard-band planes in pixel units: sx = cx + fx * x / w must stay in [-G, W + G], i.e.
 *   left:   (cx + G) w + fx x >= 0     right: (W + G - cx) w - fx x >= 0
 *   top:    (cy + G) w - fy y >= 0     bottom: (H + G - cy) w + fy y >= 0   (row 0 at the top)
 * with G = RAST_GUARD_BAND_PX. Evaluated in double. */
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

/* Frustum (not guard band) outcode bits, for trivial rejection. */
static unsigned frustum_outcode(const render_state *rs, const vtx *v)
{
    double w = rs->ortho ? 1.0 : -v->z;
    double sx = rs->fx * v->x, sy = rs->fy * v->y; /* screen offsets times w */
    unsigned c = 0;
    if (-v->z < rs->znear) c |= 1u;
    if (isfinite(rs->zfar) && -v->z > rs->zfar) c |= 2u;
    if (sx < -rs->cx * w) c |= 4u;
    if (sx > ((double)rs->W - rs->cx) * w) c |= 8u;
    if (sy > rs->cy * w) c |= 16u;
    if (sy < -((double)rs->H - rs->cy) * w) c |= 32u;
    return c;
}

static int chunk_push(chunk_data *cd, const rast_i_tri *t)
{
    if (cd->count == cd->cap) {
        uint32_t ncap = cd->cap ? cd->cap * 2 : 1024;
        rast_i_tri *n = (rast_i_tri *)realloc(cd->tris, (size_t)ncap * sizeof *n);
        if (!n) {
            cd->oom = 1;
            return 0;
        }
        cd->tris = n;
        cd->cap = ncap;
    }
    cd->tris[cd->count++] = *t;
    return 1;
}

/* Set up one snapped triangle (screen-space vertices in pixels, keys) and push it.
 * Returns 1 if pushed, 0 if zero area or no pixel centre inside its box. */
static int setup_piece(const render_state *rs, chunk_data *cd, const double sx[3], const double sy[3],
                       const double key[3], uint32_t instance, uint32_t prim)
{
    int64_t X[3], Y[3];
    const double lim = 8388607.0; /* 2^23 - 1 sub-pixel units; the guard band keeps us inside */
    for (int i = 0; i < 3; i++) {
        double xs = sx[i] * 256.0, ys = sy[i] * 256.0;
        xs = xs < -lim ? -lim : (xs > lim ? lim : xs);
        ys = ys < -lim ? -lim : (ys > lim ? lim : ys);
        X[i] = (int64_t)llround(xs);
        Y[i] = (int64_t)llround(ys);
    }
    int64_t area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
    if (area == 0)
        return 0;
    int o[3] = {0, 1, 2};
    if (area < 0) { /* make the orientation positive: inside has E_i >= 0 */
        o[1] = 2;
        o[2] = 1;
        area = -area;
    }
    rast_i_tri t;
    int64_t minX = X[0], maxX = X[0], minY = Y[0], maxY = Y[0];
    for (int i = 1; i < 3; i++) {
        minX = X[i] < minX ? X[i] : minX; maxX = X[i] > maxX ? X[i] : maxX;
        minY = Y[i] < minY ? Y[i] : minY; maxY = Y[i] > maxY ? Y[i] : maxY;
    }
    /* Pixel x is a candidate when its centre 256x+128 lies in [minX, maxX]. */
    int64_t px0 = (minX - 128 + 255 + ((int64_t)1 << 40)) / 256 - ((int64_t)1 << 32);
    int64_t px1 = (maxX - 128 + ((int64_t)1 << 40)) / 256 - ((int64_t)1 << 32);
    int64_t py0 = (minY - 128 + 255 + ((int64_t)1 << 40)) / 256 - ((int64_t)1 << 32);
    int64_t py1 = (maxY - 128 + ((int64_t)1 << 40)) / 256 - ((int64_t)1 << 32);
    if (px0 < 0) px0 = 0;
    if (py0 < 0) py0 = 0;
    if (px1 > rs->W - 1) px1 = rs->W - 1;
    if (py1 > rs->H - 1) py1 = rs->H - 1;
    if (px0 > px1 || py0 > py1)
        return 0;
    t.minx = (int32_t)px0; t.maxx = (int32_t)px1;
    t.miny = (int32_t)py0; t.maxy = (int32_t)py1;
    for (int i = 0; i < 3; i++) {
        int a = o[i], b = o[(i + 1) % 3];
        int64_t A = Y[a] - Y[b], B = X[b] - X[a];
        t.A[i] = (int32_t)A;
        t.B[i] = (int32_t)B;
        t.C[i] = -(A * X[a] + B * Y[a]);
        /* top-left rule (y down): left edge A > 0; top edge A == 0 and B > 0 */
        t.bias[i] = (A > 0 || (A == 0 && B > 0)) ? 0 : 1;
    }
    /* Key plane through the snapped vertices, referenced at the first candidate pixel centre. */
    double x0 = X[0] / 256.0, y0 = Y[0] / 256.0, x1 = X[1] / 256.0, y1 = Y[1] / 256.0;
    double x2 = X[2] / 256.0, y2 = Y[2] / 256.0;
    double det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    double kx = ((key[1] - key[0]) * (y2 - y0) - (key[2] - key[0]) * (y1 - y0)) / det;
    double ky = ((key[2] - key[0]) * (x1 - x0) - (key[1] - key[0]) * (x2 - x0)) / det;
    double ox = (double)px0 + 0.5, oy = (double)py0 + 0.5;
    t.k0 = (float)(key[0] + kx * (ox - x0) + ky * (oy - y0));
    t.kx = (float)kx;
    t.ky = (float)ky;
    t.ox = (float)ox;
    t.oy = (float)oy;
    t.instance = instance;
    t.prim = prim;
    return chunk_push(cd, &t);
}

static void project(const render_state *rs, const vtx *v, double *sx, double *sy, double *key)
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
                double t = da / (da - db);
                vtx c = {a->x + t * (b->x - a->x), a->y + t * (b->y - a->y), a->z + t * (b->z - a->z)};
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

static void setup_task(void *user, int64_t task, int thread)
{
    (void)thread;
    render_state *rs = (render_state *)user;
    chunk_data *cd = &rs->chunks[task];
    const obs_scene *sc = rs->scene;
    uint64_t g0 = (uint64_t)task * RAST_CHUNK;
    uint64_t g1 = g0 + RAST_CHUNK;
    uint64_t total = rs->tri_start[sc->instance_count];
    if (g1 > total)
        g1 = total;
    /* find the instance holding g0 (binary search over the prefix sums) */
    uint32_t lo = 0, hi = sc->instance_count;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (rs->tri_start[mid] <= g0) lo = mid; else hi = mid;
    }
    uint32_t inst = lo;
    const int finite_far = isfinite(rs->zfar);
    for (uint64_t g = g0; g < g1; g++) {
        while (g >= rs->tri_start[inst + 1])
            inst++;
        const obs_mesh *m = &sc->meshes[sc->instances[inst].mesh];
        uint32_t prim = (uint32_t)(g - rs->tri_start[inst]);
        const uint32_t *ix = &m->indices[3 * (size_t)prim];
        const double *P = rs->vpos[inst];
        vtx v[3];
        int finite = 1;
        for (int k = 0; k < 3; k++) {
            v[k].x = P[3 * (size_t)ix[k]];
            v[k].y = P[3 * (size_t)ix[k] + 1];
            v[k].z = P[3 * (size_t)ix[k] + 2];
            finite &= isfinite(v[k].x) && isfinite(v[k].y) && isfinite(v[k].z);
        }
        if (!finite) {
            cd->nonfinite++;
            continue;
        }
        if (ix[0] == ix[1] || ix[1] == ix[2] || ix[0] == ix[2]) {
            cd->degenerate++;
            continue;
        }
        /* Facing, in view space (exact sign up to double rounding): front = counter-clockwise
         * seen from the eye, i.e. the geometric normal points towards the eye. */
        vtx e1 = {v[1].x - v[0].x, v[1].y - v[0].y, v[1].z - v[0].z};
        vtx e2 = {v[2].x - v[0].x, v[2].y - v[0].y, v[2].z - v[0].z};
        vtx ng = {e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
        if (ng.x == 0.0 && ng.y == 0.0 && ng.z == 0.0) {
            cd->degenerate++;
            continue;
        }
        if (rs->p->cull != RAST_CULL_NONE) {
            double facing = rs->ortho ? ng.z : -(ng.x * v[0].x + ng.y * v[0].y + ng.z * v[0].z);
            int front = facing > 0.0;
            if ((rs->p->cull == RAST_CULL_BACK && !front) || (rs->p->cull == RAST_CULL_FRONT && front)) {
                cd->culled++;
                continue;
            }
        }
        unsigned oc0 = frustum_outcode(rs, &v[0]), oc1 = frustum_outcode(rs, &v[1]), oc2 = frustum_outcode(rs, &v[2]);
        if (oc0 & oc1 & oc2) {
            cd->culled++;
            continue;
        }
        /* Which clip planes does this triangle cross? */
        unsigned planes = 0;
        for (int pl = 0; pl < PL_COUNT; pl++) {
            if (pl == PL_FAR && !finite_far)
                continue;
            if (guard_eval(rs, pl, &v[0]) < 0.0 || guard_eval(rs, pl, &v[1]) < 0.0 || guard_eval(rs, pl, &v[2]) < 0.0)
                planes |= 1u << pl;
        }
        int pushed = 0;
        (void)pushed;
        if (!planes) {
            double sx[3], sy[3], key[3];
            for (int k = 0; k < 3; k++)
                project(rs, &v[k], &sx[k], &sy[k], &key[k]);
            /* A piece with zero area after snapping, or with no pixel centre in its box, is
             * dropped silently: that is sub-pixel geometry, not an error. */
            pushed = setup_piece(rs, cd, sx, sy, key, inst, prim);
        } else {
            cd->clipped++;
            vtx poly[12] = {v[0], v[1], v[2]};
            int n = clip_polygon(rs, poly, 3, planes);
            if (n < 3) {
                cd->culled++;
                continue;
            }
            double sx[12], sy[12], key[12];
            for (int k = 0; k < n; k++)
                project(rs, &poly[k], &sx[k], &sy[k], &key[k]);
            for (int k = 1; k + 1 < n; k++) {
                double fx3[3] = {sx[0], sx[k], sx[k + 1]}, fy3[3] = {sy[0], sy[k], sy[k + 1]};
                double fk3[3] = {key[0], key[k], key[k + 1]};
                pushed |= setup_piece(rs, cd, fx3, fy3, fk3, inst, prim);
            }
        }
        if (cd->oom)
            return;
    }
    /* Bin the chunk's records into tiles (counting sort keeps record order within a tile). */
    const obs_tiling *tl = &rs->tiling;
    int64_t ntiles = obs_tiling_count(tl);
    cd->bin_start = (uint32_t *)calloc((size_t)ntiles + 1, sizeof(uint32_t));
    if (!cd->bin_start) {
        cd->oom = 1;
        return;
    }
    uint64_t refs = 0;
    for (uint32_t i = 0; i < cd->count; i++) {
        const rast_i_tri *t = &cd->tris[i];
        int tx0 = t->minx / tl->tile, tx1 = t->maxx / tl->tile, ty0 = t->miny / tl->tile, ty1 = t->maxy / tl->tile;
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++)
                cd->bin_start[(int64_t)ty * tl->tiles_x + tx + 1]++;
        refs += (uint64_t)(tx1 - tx0 + 1) * (uint64_t)(ty1 - ty0 + 1);
    }
    if (refs > UINT32_MAX) {
        cd->oom = 1;
        return;
    }
    for (int64_t k = 0; k < ntiles; k++)
        cd->bin_start[k + 1] += cd->bin_start[k];
    cd->bin_list = (uint32_t *)malloc((size_t)(refs ? refs : 1) * sizeof(uint32_t));
    uint32_t *fill = (uint32_t *)malloc((size_t)ntiles * sizeof(uint32_t));
    if (!cd->bin_list || !fill) {
        free(fill);
        cd->oom = 1;
        return;
    }
    memcpy(fill, cd->bin_start, (size_t)ntiles * sizeof(uint32_t));
    for (uint32_t i = 0; i < cd->count; i++) {
        const rast_i_tri *t = &cd->tris[i];
        int tx0 = t->minx / tl->tile, tx1 = t->maxx / tl->tile, ty0 = t->miny / tl->tile, ty1 = t->maxy / tl->tile;
        for (int ty = ty0; ty <= ty1; ty++)
            for (int tx = tx0; tx <= tx1; tx++)
                cd->bin_list[fill[(int64_t)ty * tl->tiles_x + tx]++] = i;
    }
    free(fill);
}

/* ---- 3. tiles: visibility, then resolve ------------------------------------------------------ */

static void resolve_pixel(const render_state *rs, int x, int y, uint32_t inst, uint32_t prim, float key)
{
    rast_gbuffer *gb = rs->gb;
    const uint32_t out = gb->outputs;
    const obs_scene *sc = rs->scene;
    ptrdiff_t fo = (ptrdiff_t)y * gb->depth.stride + x; /* all planes share the stride (same size) */
    if (inst == RAST_ID_NONE) {
        if (out & RAST_OUT_DEPTH) gb->depth.data[fo] = INFINITY;
        if (out & RAST_OUT_NDC_DEPTH)
            gb->ndc_depth.data[(ptrdiff_t)y * gb->ndc_depth.stride + x] =
                rs->p->depth_convention == RAST_DEPTH_REVERSED_Z ? 0.0f : 1.0f;
        for (int c = 0; c < 3; c++) {
            if (out & RAST_OUT_NORMAL) gb->normal[c].data[(ptrdiff_t)y * gb->normal[c].stride + x] = 0.0f;
            if (out & RAST_OUT_FACE_NORMAL) gb->face_normal[c].data[(ptrdiff_t)y * gb->face_normal[c].stride + x] = 0.0f;
        }
        if (out & RAST_OUT_PRIM_ID) gb->prim_id.data[(ptrdiff_t)y * gb->prim_id.stride + x] = RAST_ID_NONE;
        if (out & RAST_OUT_INSTANCE_ID) gb->instance_id.data[(ptrdiff_t)y * gb->instance_id.stride + x] = RAST_ID_NONE;
        if (out & RAST_OUT_MATERIAL_ID) gb->material_id.data[(ptrdiff_t)y * gb->material_id.stride + x] = RAST_ID_NONE;
        return;
    }
    const obs_mesh *m = &sc->meshes[sc->instances[inst].mesh];
    const uint32_t *ix = &m->indices[3 * (size_t)prim];
    const double *P = rs->vpos[inst];
    obs_dvec3 v0 = obs_dv3(P[3 * (size_t)ix[0]], P[3 * (size_t)ix[0] + 1], P[3 * (size_t)ix[0] + 2]);
    obs_dvec3 v1 = obs_dv3(P[3 * (size_t)ix[1]], P[3 * (size_t)ix[1] + 1], P[3 * (size_t)ix[1] + 2]);
    obs_dvec3 v2 = obs_dv3(P[3 * (size_t)ix[2]], P[3 * (size_t)ix[2] + 1], P[3 * (size_t)ix[2] + 2]);
    /* The exact ray through the pixel centre (view space; see rast_pixel_ray). */
    double px = x + 0.5, py = y + 0.5;
    double ax = (px - rs->cx) / rs->fx, ay = -(py - rs->cy) / rs->fy;
    obs_dvec3 o = rs->ortho ? obs_dv3(ax, ay, 0.0) : obs_dv3(0.0, 0.0, 0.0);
    obs_dvec3 d = rs->ortho ? obs_dv3(0.0, 0.0, -1.0) : obs_dv3(ax, ay, -1.0);
    /* Moller-Trumbore [Moller97], in double: t is the linear depth because d.z = -1. */
    obs_dvec3 e1 = obs_dv3_sub(v1, v0), e2 = obs_dv3_sub(v2, v0);
    obs_dvec3 pv = obs_dv3_cross(d, e2);
    double det = obs_dv3_dot(e1, pv);
    double t, u, v;
    if (det != 0.0) {
        double inv = 1.0 / det;
        obs_dvec3 tv = obs_dv3_sub(o, v0);
        u = obs_dv3_dot(tv, pv) * inv;
        obs_dvec3 qv = obs_dv3_cross(tv, e1);
        v = obs_dv3_dot(d, qv) * inv;
        t = obs_dv3_dot(e2, qv) * inv;
    } else {
        t = NAN;
        u = v = 1.0 / 3.0;
    }
    if (!(t > 0.0) || !isfinite(t)) /* edge-on under snapping: fall back to the raster key */
        t = rs->ortho ? -(double)key : 1.0 / (double)key;
    obs_dvec3 ng = obs_dv3_cross(e1, e2);
    int back = obs_dv3_dot(ng, d) > 0.0;
    double flip = (back && rs->p->face_forward) ? -1.0 : 1.0;
    if (out & RAST_OUT_DEPTH)
        gb->depth.data[fo] = (float)t;
    if (out & RAST_OUT_NDC_DEPTH)
        gb->ndc_depth.data[(ptrdiff_t)y * gb->ndc_depth.stride + x] =
            (float)rast_ndc_depth_from_linear(rs->vc, rs->p->depth_convention, t);
    double ngl = sqrt(obs_dv3_dot(ng, ng));
    obs_dvec3 ngn = ngl > 0.0 ? obs_dv3(flip * ng.x / ngl, flip * ng.y / ngl, flip * ng.z / ngl) : obs_dv3(0, 0, 1);
    if (out & RAST_OUT_FACE_NORMAL) {
        gb->face_normal[0].data[(ptrdiff_t)y * gb->face_normal[0].stride + x] = (float)ngn.x;
        gb->face_normal[1].data[(ptrdiff_t)y * gb->face_normal[1].stride + x] = (float)ngn.y;
        gb->face_normal[2].data[(ptrdiff_t)y * gb->face_normal[2].stride + x] = (float)ngn.z;
    }
    if (out & RAST_OUT_NORMAL) {
        obs_dvec3 ns = ngn;
        if (m->normals) {
            /* Barycentrics clamped to the triangle (snapping can put a centre just outside). */
            double b1 = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u), b2 = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
            if (b1 + b2 > 1.0) {
                double s = b1 + b2;
                b1 /= s;
                b2 /= s;
            }
            double b0 = 1.0 - b1 - b2, bw[3] = {b0, b1, b2};
            const double *N = rs->nmat[inst];
            double sxv = 0, syv = 0, szv = 0;
            for (int k = 0; k < 3; k++) {
                const float *n = &m->normals[3 * (size_t)ix[k]];
                double nx = N[0] * n[0] + N[1] * n[1] + N[2] * n[2];
                double ny = N[3] * n[0] + N[4] * n[1] + N[5] * n[2];
                double nz = N[6] * n[0] + N[7] * n[1] + N[8] * n[2];
                double l = sqrt(nx * nx + ny * ny + nz * nz);
                if (l > 0.0 && isfinite(l)) {
                    sxv += bw[k] * nx / l;
                    syv += bw[k] * ny / l;
                    szv += bw[k] * nz / l;
                }
            }
            double l = sqrt(sxv * sxv + syv * syv + szv * szv);
            if (l > 1e-12 && isfinite(l))
                ns = obs_dv3(flip * sxv / l, flip * syv / l, flip * szv / l);
        }
        gb->normal[0].data[(ptrdiff_t)y * gb->normal[0].stride + x] = (float)ns.x;
        gb->normal[1].data[(ptrdiff_t)y * gb->normal[1].stride + x] = (float)ns.y;
        gb->normal[2].data[(ptrdiff_t)y * gb->normal[2].stride + x] = (float)ns.z;
    }
    if (out & RAST_OUT_PRIM_ID) gb->prim_id.data[(ptrdiff_t)y * gb->prim_id.stride + x] = prim;
    if (out & RAST_OUT_INSTANCE_ID) gb->instance_id.data[(ptrdiff_t)y * gb->instance_id.stride + x] = inst;
    if (out & RAST_OUT_MATERIAL_ID)
        gb->material_id.data[(ptrdiff_t)y * gb->material_id.stride + x] =
            m->material >= 0 ? (uint32_t)m->material : RAST_ID_NONE;
}

static void tile_task(void *user, int64_t task, int thread)
{
    render_state *rs = (render_state *)user;
    int x0, y0, x1, y1;
    obs_tiling_rect(&rs->tiling, task, &x0, &y0, &x1, &y1);
    const int T = rs->tiling.tile, tw = x1 - x0, th = y1 - y0;
    float *key = rs->tkey[thread];
    uint32_t *inst = rs->tinst[thread], *prim = rs->tprim[thread];
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            key[y * T + x] = -INFINITY;
            inst[y * T + x] = RAST_ID_NONE;
        }
    for (int64_t c = 0; c < rs->chunk_count; c++) {
        const chunk_data *cd = &rs->chunks[c];
        uint32_t b0 = cd->bin_start[task], b1 = cd->bin_start[task + 1];
        if (b1 > b0)
            rs->tile_fn(cd->tris, cd->bin_list + b0, b1 - b0, x0, y0, tw, th, T, key, inst, prim);
    }
    uint64_t covered = 0;
    for (int y = 0; y < th; y++)
        for (int x = 0; x < tw; x++) {
            uint32_t i = inst[y * T + x];
            covered += i != RAST_ID_NONE;
            resolve_pixel(rs, x0 + x, y0 + y, i, prim[y * T + x], key[y * T + x]);
        }
    rs->tile_covered[task] = covered;
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

static void free_state(render_state *rs, int threads)
{
    if (rs->vpos) {
        for (uint32_t i = 0; i < rs->scene->instance_count; i++)
            free(rs->vpos[i]);
        free(rs->vpos);
    }
    free(rs->nmat);
    free(rs->tri_start);
    free(rs->vt_inst);
    free(rs->vt_block);
    if (rs->chunks) {
        for (int64_t c = 0; c < rs->chunk_count; c++) {
            free(rs->chunks[c].tris);
            free(rs->chunks[c].bin_start);
            free(rs->chunks[c].bin_list);
        }
        free(rs->chunks);
    }
    if (rs->tkey) {
        for (int t = 0; t < threads; t++) {
            obs_aligned_free(rs->tkey[t]);
            obs_aligned_free(rs->tinst[t]);
            obs_aligned_free(rs->tprim[t]);
        }
    }
    free(rs->tkey);
    free(rs->tinst);
    free(rs->tprim);
    free(rs->tile_covered);
    memset(rs, 0, sizeof *rs);
}

static obs_status render_view(obs_context *ctx, obs_pool *pool, const obs_scene *sc, const obs_camera *cam,
                              const rast_params *p, rast_gbuffer *gb, rast_i_tile_fn tile_fn, rast_stats *st)
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
    rs.W = vc.full_width;
    rs.H = vc.full_height;
    rs.ortho = vc.projection_type == OBS_PROJECTION_ORTHOGRAPHIC;
    rs.fx = vc.fx; rs.fy = vc.fy; rs.cx = vc.cx; rs.cy = vc.cy;
    rs.znear = vc.znear; rs.zfar = vc.zfar;
    rs.tile_fn = tile_fn;
    rs.tiling = obs_tiling_make(rs.W, rs.H, p->tile_size);
    atomic_init(&rs.failed, 0);
    double t0 = obs_time_now();

    /* 1. transform */
    const uint32_t ni = sc->instance_count;
    rs.vpos = (double **)calloc(ni ? ni : 1, sizeof(double *));
    rs.nmat = (double(*)[9])calloc(ni ? ni : 1, sizeof(double[9]));
    rs.tri_start = (uint64_t *)calloc((size_t)ni + 1, sizeof(uint64_t));
    if (!rs.vpos || !rs.nmat || !rs.tri_start)
        goto oom;
    uint64_t ntasks = 0;
    for (uint32_t i = 0; i < ni; i++) {
        const obs_mesh *m = &sc->meshes[sc->instances[i].mesh];
        rs.tri_start[i + 1] = rs.tri_start[i] + m->triangle_count;
        size_t bytes;
        if (!obs_mul_size((size_t)m->vertex_count ? m->vertex_count : 1, 3 * sizeof(double), &bytes))
            goto oom;
        rs.vpos[i] = (double *)malloc(bytes);
        if (!rs.vpos[i])
            goto oom;
        normal_matrix(&vc.view, &sc->instances[i].world, rs.nmat[i]);
        ntasks += (m->vertex_count + RAST_VERTEX_BLOCK - 1) / RAST_VERTEX_BLOCK;
    }
    rs.vt_inst = (uint32_t *)malloc((size_t)(ntasks ? ntasks : 1) * sizeof(uint32_t));
    rs.vt_block = (uint32_t *)malloc((size_t)(ntasks ? ntasks : 1) * sizeof(uint32_t));
    if (!rs.vt_inst || !rs.vt_block)
        goto oom;
    ntasks = 0;
    for (uint32_t i = 0; i < ni; i++) {
        const obs_mesh *m = &sc->meshes[sc->instances[i].mesh];
        for (uint32_t b = 0; b * (uint64_t)RAST_VERTEX_BLOCK < m->vertex_count; b++) {
            rs.vt_inst[ntasks] = i;
            rs.vt_block[ntasks] = b;
            ntasks++;
        }
    }
    obs_pool_run(pool, (int64_t)ntasks, transform_task, &rs);

    /* 2. setup and binning */
    uint64_t total = rs.tri_start[ni];
    rs.chunk_count = (int64_t)((total + RAST_CHUNK - 1) / RAST_CHUNK);
    rs.chunks = (chunk_data *)calloc(rs.chunk_count ? (size_t)rs.chunk_count : 1, sizeof(chunk_data));
    if (!rs.chunks)
        goto oom;
    if (rs.chunk_count > 0)
        obs_pool_run(pool, rs.chunk_count, setup_task, &rs);
    for (int64_t c = 0; c < rs.chunk_count; c++) {
        chunk_data *cd = &rs.chunks[c];
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
    int64_t ntiles = obs_tiling_count(&rs.tiling);
    size_t tbytes = (size_t)p->tile_size * (size_t)p->tile_size * 4;
    rs.tkey = (float **)calloc((size_t)threads, sizeof(float *));
    rs.tinst = (uint32_t **)calloc((size_t)threads, sizeof(uint32_t *));
    rs.tprim = (uint32_t **)calloc((size_t)threads, sizeof(uint32_t *));
    rs.tile_covered = (uint64_t *)calloc((size_t)ntiles, sizeof(uint64_t));
    if (!rs.tkey || !rs.tinst || !rs.tprim || !rs.tile_covered)
        goto oom;
    for (int t = 0; t < threads; t++) {
        rs.tkey[t] = (float *)obs_aligned_alloc(tbytes);
        rs.tinst[t] = (uint32_t *)obs_aligned_alloc(tbytes);
        rs.tprim[t] = (uint32_t *)obs_aligned_alloc(tbytes);
        if (!rs.tkey[t] || !rs.tinst[t] || !rs.tprim[t])
            goto oom;
    }
    /* With no triangles there are no chunks, and every tile resolves to background. */
    obs_pool_run(pool, ntiles, tile_task, &rs);
    for (int64_t k = 0; k < ntiles; k++)
        st->pixels_covered += rs.tile_covered[k];
    double t2 = obs_time_now();
    st->seconds_setup += t1 - t0;
    st->seconds_raster += t2 - t1; /* visibility and resolve run fused per tile */
    free_state(&rs, threads);
    return OBS_STATUS_OK;
oom:
    free_state(&rs, threads);
    return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "rasterizer: out of memory while rendering %llu triangles",
                     (unsigned long long)obs_scene_triangle_count(sc));
}

obs_status rast_render(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const rast_view *views,
                       int view_count, const rast_params *params, rast_gbuffer *layers, rast_stats *stats)
{
    rast_stats local;
    rast_stats *st = stats ? stats : &local;
    memset(st, 0, sizeof *st);
    if (!scene || !views || !params || !layers || view_count < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_render: NULL argument or view_count %d < 1",
                         view_count);
    if (params->tile_size < 16 || params->tile_size > 256 || (params->tile_size & (params->tile_size - 1)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "rast_render: tile_size %d must be a power of two in [16, 256]",
                         params->tile_size);
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
        obs_status s = render_view(ctx, pool, scene, &views[k].camera, params, gb, fn, st);
        if (s != OBS_STATUS_OK)
            return s;
    }
    return OBS_STATUS_OK;
}
