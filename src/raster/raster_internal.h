/* raster_internal.h: what raster.c shares with the per-ISA tile rasterizers. Not public. */
#ifndef RASTER_INTERNAL_H
#define RASTER_INTERNAL_H

#include "raster.h"

/* One triangle (or clipped piece) after setup, in full-image pixel space.
 * Edge i goes from vertex i to vertex (i+1)%3 of the snapped, counter-clockwise-in-y-down
 * (i.e. positive-area) triangle. For pixel (x, y), with centre (256x+128, 256y+128) in
 * sub-pixel units:
 *     E_i(x, y) = A_i * (256x + 128) + B_i * (256y + 128) + C_i      (exact integer)
 * and the pixel is covered when E_i >= bias_i for all three edges, bias_i = 0 for top-left
 * edges and 1 otherwise (the top-left rule on integers).
 * |A|,|B| < 2^24 and |x_sub|,|y_sub| < 2^23, so |E| < 2^49: exact in int64 and in double. */
typedef struct rast_i_tri {
    int64_t C[3];
    int32_t A[3], B[3];
    int32_t bias[3];
    int32_t minx, miny, maxx, maxy;  /* inclusive pixel bbox, clamped to the image */
    /* 1 when the snapped vertices span at most 2^14 sub-pixel units (64 px) on both axes. Then
     * |A|, |B| <= 2^14 and, for every pixel centre in the box (plus 7 px of SIMD overhang),
     * |E| < 2^30: the AVX2 path evaluates such triangles exactly in 32-bit integer lanes. */
    int32_t small;
    /* Visibility key ("closeness", larger is closer): 1/w for perspective, -z_ndc for
     * orthographic; a plane in screen space, evaluated in float by rast_i_key() only. */
    float k0, kx, ky, ox, oy;
    uint32_t instance, prim;
} rast_i_tri;

/* The visibility key at pixel (x, y). Both ISA paths evaluate exactly this expression, in this
 * order, in float without contraction, so their depth tests agree bit for bit. */
static inline float rast_i_key(const rast_i_tri *t, int x, int y)
{
    float fx = (float)x + 0.5f, fy = (float)y + 0.5f;
    return t->k0 + t->kx * (fx - t->ox) + t->ky * (fy - t->oy);
}

/* What the resolve needs of one visible triangle, computed once per run of pixels that show it.
 * The hit of ray o + t d with the triangle's plane n.p = n.v0 is t = (n.v0 - n.o) / (n.d); the
 * barycentrics of the hit P are u = (P - v0).m1, v = (P - v0).m2 with the dual basis
 * m1 = (e2 x n)/|n|^2, m2 = (n x e1)/|n|^2 (so that P - v0 = u e1 + v e2). All in double. */
/* How far (relative) a pixel's exact plane depth may leave its triangle's vertex depth range and
 * still be kept as it is. Snapping (1/256 px) lets a covered pixel centre lie up to ~1/362 px
 * outside the true triangle, where the plane depth legitimately extrapolates a little beyond the
 * vertices' range: keeping those as they are leaves the output of ordinary scenes unchanged. Only
 * a (nearly) edge-on triangle, whose plane (nearly) holds the eye, moves its plane depth by more
 * than this over such a distance (hard-cases F8: depth 1.01 for a triangle spanning 3.3-8.3). */
#define RAST_I_DEPTH_RANGE_SLACK 1e-4

typedef struct resolve_tri {
    uint32_t inst, prim;
    obs_dvec3 v0, n, m1, m2, nunit;
    double n_v0, c1, c2;   /* n.v0, v0.m1, v0.m2 */
    double z_lo, z_hi;     /* the visible piece's depth range: the vertices' linear depths within
                              [znear, zfar] (docs/raster.md, "Depth of edge-on triangles") */
    double t_lo, t_hi;     /* the plane depths accepted as they are: [z_lo, z_hi] widened by
                              RAST_I_DEPTH_RANGE_SLACK (relative); outside it the depth is the
                              raster key's, clamped into [z_lo, z_hi] */
    float vn[3][3];        /* unit view-space vertex normals (when has_vn) */
    int has_vn;
    uint32_t material;
} resolve_tri;

typedef struct out_rows {
    float *depth, *ndc, *n[3], *ng[3];
    uint32_t *prim, *inst, *mat;
    double depth_exact[4];   /* the SIMD resolve's t per lane, for the NDC depth */
} out_rows;

/* Resolve 4 adjacent pixels (row offset i, absolute x = px0) that show the same triangle r,
 * writing every output of o at i..i+3 except the NDC depth (left to the caller, from
 * o->depth_exact). Must equal the scalar resolve bit for bit. Returns 0, having written
 * nothing, when a lane needs the scalar fallback (an edge-on triangle). */
typedef int (*rast_i_resolve4_fn)(const resolve_tri *r, out_rows *o, int i, int px0, double ay, double cx,
                                  double inv_fx, int ortho, int face_forward);
#if defined(OBS_HAVE_AVX2)
int rast_i_resolve4_avx2(const resolve_tri *r, out_rows *o, int i, int px0, double ay, double cx, double inv_fx,
                         int ortho, int face_forward);
#endif

/* Rasterise the triangles tris[list[0..n)] in order into a tile whose top-left pixel is
 * (tx0, ty0), size tw x th; key/inst/prim are tile-local with row stride `stride`. A pixel
 * takes a triangle when its key is strictly greater than the stored one (ties: first wins). */
typedef void (*rast_i_tile_fn)(const rast_i_tri *tris, const uint32_t *list, uint32_t n, int tx0, int ty0,
                               int tw, int th, int stride, float *key, uint32_t *inst, uint32_t *prim);

void rast_i_tile_scalar(const rast_i_tri *tris, const uint32_t *list, uint32_t n, int tx0, int ty0, int tw,
                        int th, int stride, float *key, uint32_t *inst, uint32_t *prim);
#if defined(OBS_HAVE_AVX2)
void rast_i_tile_avx2(const rast_i_tri *tris, const uint32_t *list, uint32_t n, int tx0, int ty0, int tw,
                      int th, int stride, float *key, uint32_t *inst, uint32_t *prim);
#endif

#endif
