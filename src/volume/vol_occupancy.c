/* vol_occupancy.c: meshes shadow the volume (vol.h, docs/volume/light.md "Meshes shadow the
 * volume"). OUR construction: [Ropinski10]'s light volume propagates the volume's own extinction
 * only; here closed triangle meshes are voxelized, by exact parity along columns, into an occupancy
 * grid with the light volume's layout, and vol_light_volume_build_ex adds the extinction the
 * occupancy maps to (vol_i_occ_sigma) to each classified row.
 *
 * Voxelization, step by step (vol_occupancy_voxelize):
 *   1. Every instance's vertices to world space (obs_mat4_mul_point, float), then x and y to fixed
 *      point: U = round((x - x_lo) / h_x * 256), h_x = spacing_x / s the sub-column pitch, clamped
 *      to +-2^24 (a vertex more than 65536 sub-columns from the grid; ours: such a triangle's
 *      projection is distorted, consistently for every triangle sharing the vertex, so parity stays
 *      watertight). Sub-column (a, b) (global, a in [0, nx s)) is the line x-y = ((a + 1/2) h_x,
 *      (b + 1/2) h_y), in fixed point (256 a + 128, 256 b + 128).
 *   2. Edge functions in int64: |differences| <= 2^25, products <= 2^50: exact. E_ab(p) = (b_x -
 *      a_x)(p_y - a_y) - (b_y - a_y)(p_x - a_x). A zero is broken by the symbolic perturbation p +
 *      (eps, eps^2) (the same for every triangle): sign(E) := sign(-(b_y - a_y)), or, when b_y = a_y,
 *      sign(b_x - a_x). The line crosses the triangle iff the three signs equal the sign of its
 *      projected area (area 0: never). Two triangles sharing an edge evaluate it with opposite
 *      signs, exactly, so the perturbed line is on one side only: it crosses a closed mesh once per
 *      sheet, also through shared edges and vertices (no double counts, no holes: no stripes).
 *   3. The crossing's z: barycentric weights E / area (double) on the world z.
 *   4. Per sub-column and instance, crossings sorted by z and paired ([z0, z1], [z2, z3], ...;
 *      an odd count drops the last); the instances' intervals united (sorted by start, merged).
 *   5. Each voxel's covered length of [z_k - sz/2, z_k + sz/2], divided by sz, averaged over the
 *      s x s sub-columns (in a fixed order: identical for any thread count). */
#include "vol_light_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define OCC_FRAC 256            /* fixed-point steps per sub-column pitch (8 bits) */
#define OCC_CLAMP ((int64_t)1 << 24)

/* The light volume's layout: vol_light_volume_build's arithmetic, expression for expression. */
static void occ_layout(const vol_grid *g, int scale, int n[3], double sp[3], double org[3])
{
    double lo[3], hi[3];
    vol_grid_bounds(g, lo, hi);
    const int nd[3] = {g->nx, g->ny, g->nz};
    for (int c = 0; c < 3; c++) {
        n[c] = (nd[c] + scale - 1) / scale;
        sp[c] = (hi[c] - lo[c]) / n[c];
        org[c] = lo[c] + 0.5 * sp[c];
        if (scale == 1) {
            sp[c] = g->spacing[c];
            org[c] = g->origin[c];
        }
    }
}

obs_status vol_occupancy_alloc(obs_context *ctx, const vol_grid *g, int scale, vol_occupancy *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_alloc: out is NULL");
    memset(out, 0, sizeof *out);
    if (!g || g->nx < 1 || g->ny < 1 || g->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_alloc: the grid is NULL or empty");
    if (scale != 1 && scale != 2 && scale != 4)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_alloc: scale %d is not 1, 2 or 4", scale);
    for (int c = 0; c < 3; c++)
        if (!isfinite(g->spacing[c]) || !(g->spacing[c] > 0.0) || !isfinite(g->origin[c]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_alloc: spacing/origin must be finite, > 0");
    int n[3];
    occ_layout(g, scale, n, out->spacing, out->origin);
    const int64_t voxels = (int64_t)n[0] * n[1] * n[2];
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    if (voxels > lim->max_voxels || voxels * (int64_t)sizeof(float) > lim->max_memory_bytes) {
        memset(out, 0, sizeof *out);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "occupancy %dx%dx%d (%.3g bytes) is over the limits (raise --max-voxels/--max-memory)", n[0],
                         n[1], n[2], (double)voxels * sizeof(float));
    }
    out->f = (float *)obs_aligned_alloc((size_t)voxels * sizeof(float));
    if (!out->f) {
        memset(out, 0, sizeof *out);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "occupancy: out of memory");
    }
    memset(out->f, 0, (size_t)voxels * sizeof(float));
    out->nx = n[0], out->ny = n[1], out->nz = n[2];
    return OBS_STATUS_OK;
}

void vol_occupancy_free(vol_occupancy *o)
{
    if (!o)
        return;
    obs_aligned_free(o->f);
    memset(o, 0, sizeof *o);
}

/* ---- the voxelizer ------------------------------------------------------------------------- */

/* A triangle prepared: fixed-point x-y, world z, its instance, its sub-row range. */
typedef struct occ_tri {
    int64_t X[3], Y[3];
    double z[3];
    int64_t area2;               /* twice the signed projected area (E_01(v2)), != 0 */
    int inst;
    int32_t a0, a1, b0, b1;      /* sub-columns covered by its fixed-point bounds (clamped) */
} occ_tri;

typedef struct occ_vtx { int64_t X, Y; double z; int ok; } occ_vtx;
typedef struct occ_cross { int32_t sc; int32_t inst; double z; } occ_cross;
typedef struct occ_iv { double z0, z1; } occ_iv;

typedef struct occ_job {
    vol_occupancy *occ;
    int s;
    const occ_tri *tri;
    const int32_t *row_start, *row_tri;   /* CSR: triangles touching voxel row j */
    double z_lo;                          /* the grid's lower z bound */
    int64_t mem_cap;                      /* bytes one row's crossings may take */
    int *failed;                          /* per row: 1 out of memory, 2 over the limit */
} occ_job;

static int64_t occ_fix(double u)
{
    double f = floor(u * OCC_FRAC + 0.5);
    if (f > (double)OCC_CLAMP)
        return OCC_CLAMP;
    if (f < -(double)OCC_CLAMP)
        return -OCC_CLAMP;
    return (int64_t)f;
}

/* sign of E_ab at p with the tie broken by p + (eps, eps^2) (step 2 above) */
static inline int occ_edge_sign(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py, int64_t *e)
{
    const int64_t E = (bx - ax) * (py - ay) - (by - ay) * (px - ax);
    *e = E;
    if (E != 0)
        return E > 0 ? 1 : -1;
    if (by != ay)
        return (ay - by) > 0 ? 1 : -1;
    return (bx - ax) > 0 ? 1 : (bx - ax) < 0 ? -1 : 0;
}

static int occ_cross_cmp(const void *pa, const void *pb)
{
    const occ_cross *a = (const occ_cross *)pa, *b = (const occ_cross *)pb;
    if (a->sc != b->sc)
        return a->sc < b->sc ? -1 : 1;
    if (a->inst != b->inst)
        return a->inst < b->inst ? -1 : 1;
    return a->z < b->z ? -1 : a->z > b->z ? 1 : 0;
}
static int occ_iv_cmp(const void *pa, const void *pb)
{
    const occ_iv *a = (const occ_iv *)pa, *b = (const occ_iv *)pb;
    if (a->z0 != b->z0)
        return a->z0 < b->z0 ? -1 : 1;
    return a->z1 < b->z1 ? -1 : a->z1 > b->z1 ? 1 : 0;
}

/* One voxel row j: its s sub-rows, nx s sub-columns each. */
static void occ_row_task(void *user, int64_t task, int thread)
{
    (void)thread;
    occ_job *J = (occ_job *)user;
    vol_occupancy *o = J->occ;
    const int j = (int)task, s = J->s, nsa = o->nx * s;
    const int32_t t0 = J->row_start[j], t1 = J->row_start[j + 1];
    size_t cap = 0, n = 0;
    occ_cross *cr = NULL;
    double *acc = NULL;
    occ_iv *iv = NULL;
    size_t ivcap = 0;
    /* Steps 2 and 3: the crossings of every triangle with the row's sub-columns. */
    for (int32_t q = t0; q < t1; q++) {
        const occ_tri *T = &J->tri[J->row_tri[q]];
        const int sa = T->area2 > 0 ? 1 : -1;
        const int b0 = T->b0 > j * s ? T->b0 : j * s, b1 = T->b1 < j * s + s - 1 ? T->b1 : j * s + s - 1;
        for (int b = b0; b <= b1; b++) {
            const int64_t py = (int64_t)b * OCC_FRAC + OCC_FRAC / 2;
            for (int a = T->a0; a <= T->a1; a++) {
                const int64_t px = (int64_t)a * OCC_FRAC + OCC_FRAC / 2;
                int64_t e0, e1, e2;
                /* E_12 weighs vertex 0, E_20 vertex 1, E_01 vertex 2 */
                if (occ_edge_sign(T->X[1], T->Y[1], T->X[2], T->Y[2], px, py, &e0) != sa ||
                    occ_edge_sign(T->X[2], T->Y[2], T->X[0], T->Y[0], px, py, &e1) != sa ||
                    occ_edge_sign(T->X[0], T->Y[0], T->X[1], T->Y[1], px, py, &e2) != sa)
                    continue;
                if (n == cap) {
                    size_t nc = cap ? 2 * cap : 256;
                    if ((int64_t)(nc * sizeof(occ_cross)) > J->mem_cap) {
                        J->failed[j] = 2;
                        goto done;
                    }
                    occ_cross *g = (occ_cross *)realloc(cr, nc * sizeof(occ_cross));
                    if (!g) {
                        J->failed[j] = 1;
                        goto done;
                    }
                    cr = g, cap = nc;
                }
                const double A = (double)T->area2;
                cr[n].sc = (int32_t)((int64_t)(b - j * s) * nsa + a);
                cr[n].inst = T->inst;
                cr[n].z = ((double)e0 * T->z[0] + (double)e1 * T->z[1] + (double)e2 * T->z[2]) / A;
                n++;
            }
        }
    }
    /* Steps 4 and 5. */
    acc = (double *)calloc((size_t)o->nz, sizeof(double));
    if (!acc) {
        J->failed[j] = 1;
        goto done;
    }
    if (n > 1)
        qsort(cr, n, sizeof *cr, occ_cross_cmp);
    const double sz = o->spacing[2], inv = 1.0 / ((double)s * s);
    for (int i = 0; i < o->nx; i++) {
        memset(acc, 0, sizeof(double) * (size_t)o->nz);
        for (int bb = 0; bb < s; bb++)
            for (int aa = 0; aa < s; aa++) {
                const int32_t sc = (int32_t)((int64_t)bb * nsa + (int64_t)i * s + aa);
                /* the crossings of sub-column sc: binary search in the sorted list */
                size_t lo = 0, hi = n;
                while (lo < hi) {
                    size_t mid = lo + (hi - lo) / 2;
                    if (cr[mid].sc < sc)
                        lo = mid + 1;
                    else
                        hi = mid;
                }
                size_t e = lo;
                while (e < n && cr[e].sc == sc)
                    e++;
                if (e - lo < 2)
                    continue;
                /* parity per instance */
                size_t m = 0;
                for (size_t p = lo; p < e;) {
                    size_t r = p;
                    while (r < e && cr[r].inst == cr[p].inst)
                        r++;
                    for (size_t k = p; k + 1 < r; k += 2) {
                        if (m == ivcap) {
                            size_t nc = ivcap ? 2 * ivcap : 64;
                            occ_iv *g = (occ_iv *)realloc(iv, nc * sizeof(occ_iv));
                            if (!g) {
                                J->failed[j] = 1;
                                goto done;
                            }
                            iv = g, ivcap = nc;
                        }
                        iv[m].z0 = cr[k].z, iv[m].z1 = cr[k + 1].z;
                        m++;
                    }
                    p = r;
                }
                if (m > 1)
                    qsort(iv, m, sizeof *iv, occ_iv_cmp);
                /* union, then the covered length per voxel */
                for (size_t k = 0; k < m;) {
                    double z0 = iv[k].z0, z1 = iv[k].z1;
                    size_t r = k + 1;
                    while (r < m && iv[r].z0 <= z1) {
                        if (iv[r].z1 > z1)
                            z1 = iv[r].z1;
                        r++;
                    }
                    k = r;
                    double u0 = (z0 - J->z_lo) / sz, u1 = (z1 - J->z_lo) / sz;
                    if (u1 <= 0.0 || u0 >= (double)o->nz || !(u1 > u0))
                        continue;
                    if (u0 < 0.0)
                        u0 = 0.0;
                    if (u1 > (double)o->nz)
                        u1 = (double)o->nz;
                    int k0 = (int)floor(u0), k1 = (int)floor(u1);
                    if (k1 >= o->nz)
                        k1 = o->nz - 1;
                    for (int kk = k0; kk <= k1; kk++) {
                        double a0 = u0 > kk ? u0 : kk, a1 = u1 < kk + 1 ? u1 : kk + 1;
                        if (a1 > a0)
                            acc[kk] += a1 - a0;
                    }
                }
            }
        for (int kk = 0; kk < o->nz; kk++) {
            double f = acc[kk] * inv;
            o->f[((size_t)kk * o->ny + j) * o->nx + i] = (float)(f > 1.0 ? 1.0 : f);
        }
    }
done:
    free(cr);
    free(acc);
    free(iv);
}

obs_status vol_occupancy_voxelize(obs_context *ctx, obs_pool *pool, const vol_occ_mesh *meshes, int count,
                                  int subcolumns, vol_occupancy *occ)
{
    if (!occ || !occ->f || occ->nx < 1 || occ->ny < 1 || occ->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_voxelize: the occupancy grid is NULL or empty");
    if (count < 0 || (count > 0 && !meshes))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_voxelize: meshes is NULL");
    if (subcolumns < 1 || subcolumns > VOL_OCC_MAX_SUBCOLUMNS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_voxelize: subcolumns %d is not in [1, %d]",
                         subcolumns, VOL_OCC_MAX_SUBCOLUMNS);
    for (int c = 0; c < 3; c++)
        if (!isfinite(occ->spacing[c]) || !(occ->spacing[c] > 0.0) || !isfinite(occ->origin[c]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_voxelize: bad spacing/origin");
    const int s = subcolumns;
    if ((int64_t)occ->nx * s > OCC_CLAMP / OCC_FRAC || (int64_t)occ->ny * s > OCC_CLAMP / OCC_FRAC)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "vol_occupancy_voxelize: %d x %d columns x %d^2 sub-columns "
                         "is over the fixed-point range (%lld sub-columns a side)", occ->nx, occ->ny, s,
                         (long long)(OCC_CLAMP / OCC_FRAC));
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    int64_t ntri = 0, nvmax = 0;
    for (int m = 0; m < count; m++) {
        const obs_mesh *M = meshes[m].mesh;
        if (!M || (M->triangle_count > 0 && (!M->positions || !M->indices)))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_occupancy_voxelize: mesh %d is NULL or has no arrays", m);
        ntri += M->triangle_count;
        nvmax = (int64_t)M->vertex_count > nvmax ? (int64_t)M->vertex_count : nvmax;
    }
    /* Refuse absurd sizes before allocating: the prepared triangles, one instance's vertices and
     * the row lists. */
    if (ntri * (int64_t)(sizeof(occ_tri) + 2 * sizeof(int32_t)) + nvmax * (int64_t)sizeof(occ_vtx) >
            lim->max_memory_bytes || ntri > INT32_MAX / 2)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "vol_occupancy_voxelize: %lld triangles are over the limits",
                         (long long)ntri);
    const double lo[3] = {occ->origin[0] - 0.5 * occ->spacing[0], occ->origin[1] - 0.5 * occ->spacing[1],
                          occ->origin[2] - 0.5 * occ->spacing[2]};
    const double h[2] = {occ->spacing[0] / s, occ->spacing[1] / s};
    const int nsa = occ->nx * s, nsb = occ->ny * s;
    occ_tri *tri = (occ_tri *)malloc((size_t)(ntri > 0 ? ntri : 1) * sizeof(occ_tri));
    int32_t *row_start = (int32_t *)calloc((size_t)occ->ny + 1, sizeof(int32_t));
    int *failed = (int *)calloc((size_t)occ->ny, sizeof(int));
    int32_t *row_tri = NULL;
    occ_vtx *vx = NULL;
    obs_status st = OBS_STATUS_OK;
    if (!tri || !row_start || !failed) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_occupancy_voxelize: out of memory");
        goto out;
    }
    /* Step 1: the triangles whose fixed-point bounds meet a sub-column of the grid (each
     * instance's vertices transformed and snapped once). */
    int64_t nt = 0, refs = 0;
    for (int m = 0; m < count; m++) {
        const obs_mesh *M = meshes[m].mesh;
        free(vx);
        vx = (occ_vtx *)malloc(sizeof(occ_vtx) * (size_t)(M->vertex_count ? M->vertex_count : 1));
        if (!vx) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_occupancy_voxelize: out of memory");
            goto out;
        }
        for (uint32_t v = 0; v < M->vertex_count; v++) {
            const float *pp = M->positions + 3 * (size_t)v;
            const obs_vec3 w = obs_mat4_mul_point(meshes[m].world, obs_v3(pp[0], pp[1], pp[2]));
            vx[v].ok = isfinite(w.x) && isfinite(w.y) && isfinite(w.z);
            vx[v].X = vx[v].ok ? occ_fix(((double)w.x - lo[0]) / h[0]) : 0;
            vx[v].Y = vx[v].ok ? occ_fix(((double)w.y - lo[1]) / h[1]) : 0;
            vx[v].z = (double)w.z;
        }
        for (uint32_t t = 0; t < M->triangle_count; t++) {
            occ_tri T;
            T.inst = m;
            int64_t xmin = INT64_MAX, xmax = INT64_MIN, ymin = INT64_MAX, ymax = INT64_MIN;
            for (int v = 0; v < 3; v++) {
                const uint32_t id = M->indices[3 * (size_t)t + (size_t)v];
                if (id >= M->vertex_count) {
                    st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                   "vol_occupancy_voxelize: mesh %d triangle %u has index %u >= %u vertices", m, t, id,
                                   M->vertex_count);
                    goto out;
                }
                if (!vx[id].ok) {
                    st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                   "vol_occupancy_voxelize: mesh %d has a non-finite world position", m);
                    goto out;
                }
                T.X[v] = vx[id].X;
                T.Y[v] = vx[id].Y;
                T.z[v] = vx[id].z;
                xmin = T.X[v] < xmin ? T.X[v] : xmin, xmax = T.X[v] > xmax ? T.X[v] : xmax;
                ymin = T.Y[v] < ymin ? T.Y[v] : ymin, ymax = T.Y[v] > ymax ? T.Y[v] : ymax;
            }
            T.area2 = (T.X[1] - T.X[0]) * (T.Y[2] - T.Y[0]) - (T.Y[1] - T.Y[0]) * (T.X[2] - T.X[0]);
            if (T.area2 == 0)
                continue; /* parallel to z (or degenerate): never crossed */
            /* sub-columns a with xmin <= 256 a + 128 <= xmax */
            int64_t a0 = (xmin - OCC_FRAC / 2 + OCC_FRAC - 1 + OCC_CLAMP * 2) / OCC_FRAC - OCC_CLAMP * 2 / OCC_FRAC;
            int64_t a1 = (xmax - OCC_FRAC / 2 + OCC_CLAMP * 2) / OCC_FRAC - OCC_CLAMP * 2 / OCC_FRAC;
            int64_t b0 = (ymin - OCC_FRAC / 2 + OCC_FRAC - 1 + OCC_CLAMP * 2) / OCC_FRAC - OCC_CLAMP * 2 / OCC_FRAC;
            int64_t b1 = (ymax - OCC_FRAC / 2 + OCC_CLAMP * 2) / OCC_FRAC - OCC_CLAMP * 2 / OCC_FRAC;
            if (a0 < 0) a0 = 0;
            if (b0 < 0) b0 = 0;
            if (a1 > nsa - 1) a1 = nsa - 1;
            if (b1 > nsb - 1) b1 = nsb - 1;
            if (a1 < a0 || b1 < b0)
                continue;
            T.a0 = (int32_t)a0, T.a1 = (int32_t)a1, T.b0 = (int32_t)b0, T.b1 = (int32_t)b1;
            tri[nt++] = T;
            for (int64_t j = b0 / s; j <= b1 / s; j++)
                row_start[j + 1]++;
            refs += b1 / s - b0 / s + 1;
        }
    }
    /* The rows' triangle lists (CSR, in triangle order). */
    if (refs > INT32_MAX || refs * (int64_t)sizeof(int32_t) > lim->max_memory_bytes) {
        st = obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "vol_occupancy_voxelize: %lld row references are over the limits",
                       (long long)refs);
        goto out;
    }
    row_tri = (int32_t *)malloc((size_t)(refs > 0 ? refs : 1) * sizeof(int32_t));
    if (!row_tri) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_occupancy_voxelize: out of memory");
        goto out;
    }
    for (int j = 0; j < occ->ny; j++)
        row_start[j + 1] += row_start[j];
    {
        int32_t *fill = (int32_t *)malloc((size_t)occ->ny * sizeof(int32_t));
        if (!fill) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_occupancy_voxelize: out of memory");
            goto out;
        }
        memcpy(fill, row_start, (size_t)occ->ny * sizeof(int32_t));
        for (int64_t t = 0; t < nt; t++)
            for (int j = tri[t].b0 / s; j <= tri[t].b1 / s; j++)
                row_tri[fill[j]++] = (int32_t)t;
        free(fill);
    }
    occ_job J;
    J.occ = occ, J.s = s, J.tri = tri, J.row_start = row_start, J.row_tri = row_tri, J.z_lo = lo[2];
    J.mem_cap = lim->max_memory_bytes;
    J.failed = failed;
    obs_pool_run(pool, occ->ny, occ_row_task, &J);
    for (int j = 0; j < occ->ny; j++)
        if (failed[j]) {
            st = failed[j] == 2 ? obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                                            "vol_occupancy_voxelize: row %d's crossings are over the memory limit", j)
                                : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_occupancy_voxelize: out of memory");
            break;
        }
out:
    free(vx);
    free(tri);
    free(row_start);
    free(row_tri);
    free(failed);
    return st;
}

/* ---- the light volume's extra extinction ------------------------------------------------------- */

obs_status vol_i_occ_sigma(obs_context *ctx, const vol_occluder *occ, const int n[3], const double sp[3],
                           const double org[3], float **out)
{
    *out = NULL;
    if (!occ)
        return OBS_STATUS_OK;
    const vol_occupancy *o = occ->occupancy;
    if (!o && occ->entry)
        return OBS_STATUS_OK; /* the entry transmittance alone */
    if (!o || !o->f)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: the occluder has no occupancy grid");
    if (!isfinite(occ->ref_step) || occ->ref_step < 0.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: the occluder's ref_step must be finite, >= 0");
    if (o->nx != n[0] || o->ny != n[1] || o->nz != n[2] || memcmp(o->spacing, sp, 3 * sizeof(double)) ||
        memcmp(o->origin, org, 3 * sizeof(double)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "light volume: the occupancy (%dx%dx%d) does not have the light volume's layout (%dx%dx%d, "
                         "spacing and origin bit for bit: vol_occupancy_alloc with the same grid and scale)",
                         o->nx, o->ny, o->nz, n[0], n[1], n[2]);
    const size_t nv = (size_t)n[0] * (size_t)n[1] * (size_t)n[2];
    size_t first = nv;
    for (size_t i = 0; i < nv; i++) {
        if (!(o->f[i] >= 0.0f && o->f[i] <= 1.0f))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: occupancy %g at voxel %zu is not in [0, 1]",
                             (double)o->f[i], i);
        if (o->f[i] > 0.0f && first == nv)
            first = i;
    }
    if (first == nv)
        return OBS_STATUS_OK; /* all zero: the build without it, bit for bit */
    const double ref = occ->ref_step > 0.0 ? occ->ref_step : fmin(sp[0], fmin(sp[1], sp[2]));
    float *sg = (float *)obs_aligned_alloc(nv * sizeof(float));
    if (!sg)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory for the occupancy's extinction");
    for (size_t i = 0; i < nv; i++)
        sg[i] = (float)vol_sigma_from_alpha(o->f[i], ref); /* vol.h vol_occluder: -ln(1 - f) / ref_step */
    *out = sg;
    return OBS_STATUS_OK;
}

double vol_i_occ_sigma_at(const float *sigma, const int n[3], const double org[3], const double sp[3],
                          const double x[3])
{
    double u[3];
    int i0[3], i1[3];
    double f[3];
    for (int c = 0; c < 3; c++) {
        u[c] = (x[c] - org[c]) / sp[c];
        if (u[c] < -0.5 || u[c] > n[c] - 0.5)
            return 0.0;
        double uc = u[c] < 0.0 ? 0.0 : u[c] > n[c] - 1 ? n[c] - 1 : u[c];
        i0[c] = (int)floor(uc);
        if (i0[c] > n[c] - 1)
            i0[c] = n[c] - 1;
        i1[c] = i0[c] + 1 < n[c] ? i0[c] + 1 : i0[c];
        f[c] = uc - i0[c];
    }
    double acc = 0.0;
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++) {
                const double w = (i ? f[0] : 1.0 - f[0]) * (j ? f[1] : 1.0 - f[1]) * (k ? f[2] : 1.0 - f[2]);
                const size_t id = ((size_t)(k ? i1[2] : i0[2]) * (size_t)n[1] + (size_t)(j ? i1[1] : i0[1])) * (size_t)n[0] +
                                  (size_t)(i ? i1[0] : i0[0]);
                acc += w * sigma[id];
            }
    return acc;
}
