/* Meshes shadow the volume (src/volume/vol_occupancy.c, vol.h vol_occluder): the exact-parity
 * voxelizer against analytic volumes, its tie rule (no stripes where edges and vertices lie on
 * sub-columns), the light volume's extra extinction (a slab's shadow; bit-identical output without
 * it), threads, refusals. docs/volume/light.md "Meshes shadow the volume". */
#include "test.h"
#include "volume_test_util.h"

#include "core/obs.h"
#include "scene_util.h"
#include "volume/vol.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- meshes -------------------------------------------------------------------------------- */

typedef struct tmesh {
    obs_mesh m;
    int vcap, tcap;
} tmesh;

static uint32_t tm_vertex(tmesh *t, double x, double y, double z)
{
    if ((int)t->m.vertex_count == t->vcap) {
        t->vcap = t->vcap ? 2 * t->vcap : 64;
        t->m.positions = (float *)realloc(t->m.positions, sizeof(float) * 3 * (size_t)t->vcap);
    }
    float *p = t->m.positions + 3 * (size_t)t->m.vertex_count;
    p[0] = (float)x, p[1] = (float)y, p[2] = (float)z;
    return t->m.vertex_count++;
}
static void tm_tri(tmesh *t, uint32_t a, uint32_t b, uint32_t c)
{
    if ((int)t->m.triangle_count == t->tcap) {
        t->tcap = t->tcap ? 2 * t->tcap : 64;
        t->m.indices = (uint32_t *)realloc(t->m.indices, sizeof(uint32_t) * 3 * (size_t)t->tcap);
    }
    uint32_t *q = t->m.indices + 3 * (size_t)t->m.triangle_count++;
    q[0] = a, q[1] = b, q[2] = c;
}
static void tm_free(tmesh *t)
{
    free(t->m.positions);
    free(t->m.indices);
    memset(t, 0, sizeof *t);
}

/* A closed box [lo, hi] (shared vertices, outward counter-clockwise), its top (z = hi) and
 * bottom (z = lo) faces an n x n grid of quads split along alternating diagonals, its four sides
 * n quads each along the rim (so that every rim vertex is shared by the side and the cap). */
static void tm_box(tmesh *t, const double lo[3], const double hi[3], int n)
{
    memset(t, 0, sizeof *t);
    uint32_t *cap[2];
    for (int f = 0; f < 2; f++) {
        cap[f] = (uint32_t *)malloc(sizeof(uint32_t) * (size_t)(n + 1) * (size_t)(n + 1));
        const double z = f ? hi[2] : lo[2];
        for (int b = 0; b <= n; b++)
            for (int a = 0; a <= n; a++)
                cap[f][b * (n + 1) + a] =
                    tm_vertex(t, lo[0] + (hi[0] - lo[0]) * a / n, lo[1] + (hi[1] - lo[1]) * b / n, z);
        for (int b = 0; b < n; b++)
            for (int a = 0; a < n; a++) {
                uint32_t v00 = cap[f][b * (n + 1) + a], v10 = v00 + 1, v01 = v00 + (uint32_t)(n + 1), v11 = v01 + 1;
                const int alt = (a + b) & 1;
                if (f) { /* top: normal +z (counter-clockwise seen from above) */
                    if (alt) tm_tri(t, v00, v10, v11), tm_tri(t, v00, v11, v01);
                    else tm_tri(t, v00, v10, v01), tm_tri(t, v10, v11, v01);
                } else { /* bottom: normal -z */
                    if (alt) tm_tri(t, v00, v11, v10), tm_tri(t, v00, v01, v11);
                    else tm_tri(t, v00, v01, v10), tm_tri(t, v10, v01, v11);
                }
            }
    }
    /* the rim, counter-clockwise seen from above: (a, 0) a up, (n, b) b up, (a, n) a down, (0, b) b down */
    int ring[4 * 64][2], m = 0;
    for (int a = 0; a < n; a++) ring[m][0] = a, ring[m][1] = 0, m++;
    for (int b = 0; b < n; b++) ring[m][0] = n, ring[m][1] = b, m++;
    for (int a = n; a > 0; a--) ring[m][0] = a, ring[m][1] = n, m++;
    for (int b = n; b > 0; b--) ring[m][0] = 0, ring[m][1] = b, m++;
    for (int q = 0; q < m; q++) {
        const int r = (q + 1) % m;
        uint32_t b0 = cap[0][ring[q][1] * (n + 1) + ring[q][0]], b1 = cap[0][ring[r][1] * (n + 1) + ring[r][0]];
        uint32_t t0 = cap[1][ring[q][1] * (n + 1) + ring[q][0]], t1 = cap[1][ring[r][1] * (n + 1) + ring[r][0]];
        tm_tri(t, b0, b1, t1);
        tm_tri(t, b0, t1, t0);
    }
    free(cap[0]);
    free(cap[1]);
}

/* The enclosed volume by the divergence theorem (signed tetrahedra to the origin), in double. */
static double mesh_volume(const obs_mesh *m)
{
    double v = 0.0;
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        const float *a = m->positions + 3 * m->indices[3 * t], *b = m->positions + 3 * m->indices[3 * t + 1],
                    *c = m->positions + 3 * m->indices[3 * t + 2];
        v += ((double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) -
              (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
              (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0])) / 6.0;
    }
    return v;
}

/* A grid n^3 of zeros, spacing 1, voxel (i, j, k) centred at (i, j, k). */
static int zero_grid(obs_context *ctx, int n, vol_grid *g)
{
    const double sp[3] = {1, 1, 1};
    return vol_grid_alloc(ctx, n, n, n, sp, g) == OBS_STATUS_OK;
}

static double occ_sum(const vol_occupancy *o)
{
    double s = 0;
    for (size_t i = 0; i < (size_t)o->nx * o->ny * o->nz; i++)
        s += o->f[i];
    return s * o->spacing[0] * o->spacing[1] * o->spacing[2];
}

static vol_occ_mesh one(const obs_mesh *m)
{
    vol_occ_mesh r;
    r.mesh = m;
    r.world = obs_mat4_identity();
    return r;
}

/* ---- the voxelizer ------------------------------------------------------------------------- */

TEST(volume_occupancy_cube_is_one_inside_and_zero_outside)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 16, &g));
    tmesh t;
    const double lo[3] = {3.5, 3.5, 3.5}, hi[3] = {11.5, 11.5, 11.5}; /* voxels 4..11 exactly */
    tm_box(&t, lo, hi, 1);
    vol_occupancy o;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    vol_occ_mesh mm = one(&t.m);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    int bad = 0;
    for (int k = 0; k < 16; k++)
        for (int j = 0; j < 16; j++)
            for (int i = 0; i < 16; i++) {
                const int in = i >= 4 && i <= 11 && j >= 4 && j <= 11 && k >= 4 && k <= 11;
                bad += o.f[((size_t)k * 16 + j) * 16 + i] != (in ? 1.0f : 0.0f);
            }
    CHECK_EQ_INT(bad, 0);
    vol_occupancy_free(&o);
    tm_free(&t);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A cube whose faces pass through voxel centres: faces 1/2, edges 1/4, corners 1/8 exactly (the
 * sub-columns split a voxel's side evenly); the sum is the cube's volume. Then the same cube
 * moved by a non-aligned offset: the sum within 1e-3 relative. */
TEST(volume_occupancy_half_offset_cube_has_exact_fractions)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 16, &g));
    tmesh t;
    const double lo[3] = {4, 4, 4}, hi[3] = {12, 12, 12};
    tm_box(&t, lo, hi, 2);
    vol_occupancy o;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    vol_occ_mesh mm = one(&t.m);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    int bad = 0;
    for (int k = 0; k < 16; k++)
        for (int j = 0; j < 16; j++)
            for (int i = 0; i < 16; i++) {
                const int idx[3] = {i, j, k};
                double e = 1.0;
                for (int a = 0; a < 3; a++)
                    e *= idx[a] < 4 || idx[a] > 12 ? 0.0 : (idx[a] == 4 || idx[a] == 12) ? 0.5 : 1.0;
                bad += o.f[((size_t)k * 16 + j) * 16 + i] != (float)e;
            }
    CHECK_EQ_INT(bad, 0);
    CHECK_NEAR(occ_sum(&o), 512.0, 1e-9);
    /* moved by (0.3, 0.17, 0.41): the sub-columns sample x-y (16 a voxel), z is exact */
    vol_occ_mesh mv = one(&t.m);
    mv.world = obs_mat4_translation(obs_v3(0.3f, 0.17f, 0.41f));
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mv, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    CHECK_MSG(fabs(occ_sum(&o) - 512.0) < 512.0 * 1e-3, "sum %.6f", occ_sum(&o));
    vol_occupancy_free(&o);
    tm_free(&t);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A UV sphere of radius 10 voxels (64 x 32: its polyhedral volume, computed exactly, is the
 * reference) at 32^3: the occupancy's volume within 1% (measured: see the message). */
TEST(volume_occupancy_sphere_volume_within_one_percent)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 32, &g));
    obs_scene s;
    tu_sphere(&s, 64, 32, 10.0f, obs_v3(15.3f, 16.1f, 15.7f), 0.0f);
    const double ref = mesh_volume(&s.meshes[0]);
    vol_occupancy o;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    vol_occ_mesh mm = one(&s.meshes[0]);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    const double got = occ_sum(&o);
    if (getenv("OBS_TEST_VERBOSE"))
        fprintf(stderr, "sphere: occupancy %.4f, mesh %.4f, %.4f%%\n", got, ref, 100 * (got - ref) / ref);
    CHECK_MSG(fabs(got - ref) < 0.01 * ref, "occupancy %.3f, mesh %.3f (%.4f%%)", got, ref, 100 * (got - ref) / ref);
    for (size_t i = 0; i < (size_t)32 * 32 * 32; i++)
        if (!(o.f[i] >= 0.0f && o.f[i] <= 1.0f)) {
            CHECK_MSG(0, "occupancy %g at %zu", (double)o.f[i], i);
            break;
        }
    /* the centre voxel is inside, a corner outside */
    CHECK(o.f[((size_t)16 * 32 + 16) * 32 + 15] == 1.0f);
    CHECK(o.f[0] == 0.0f);
    /* two overlapping instances unite (parity per instance): the same sphere twice = once */
    vol_occupancy o2;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o2), ctx);
    vol_occ_mesh m2[2] = {one(&s.meshes[0]), one(&s.meshes[0])};
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, m2, 2, VOL_OCC_DEFAULT_SUBCOLUMNS, &o2), ctx);
    CHECK(memcmp(o.f, o2.f, sizeof(float) * 32 * 32 * 32) == 0);
    vol_occupancy_free(&o2);
    vol_occupancy_free(&o);
    obs_scene_free(&s);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* Ties: a box whose rim, cap vertices and cap diagonals lie exactly on sub-column lines (s = 4:
 * sub-columns at x = i +- 1/8, i +- 3/8). Every sub-column must cross the top and the bottom
 * exactly once each or not at all: each voxel of a column inside the z range gets the same
 * occupancy, a multiple of 1/16, and no voxel outside it gets any (a double or missed crossing
 * would fill a sub-column to the grid's end: a stripe). The box is [2.125, 9.125]^2 x [1.5, 9.5]:
 * the tie rule (perturbation +x, then +y) takes the sub-columns at 2.125 and leaves those at 9.125,
 * so 28 x 28 sub-columns are inside. */
TEST(volume_occupancy_ties_on_edges_and_vertices_give_no_stripes)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 12, &g));
    const int nq[3] = {1, 7, 28}; /* cap grids: 28 quads a side put a vertex on every sub-column */
    for (int q = 0; q < 3; q++) {
        tmesh t;
        const double lo[3] = {2.125, 2.125, 1.5}, hi[3] = {9.125, 9.125, 9.5};
        tm_box(&t, lo, hi, nq[q]);
        vol_occupancy o;
        CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
        vol_occ_mesh mm = one(&t.m);
        CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, &o), ctx);
        int bad = 0, total = 0;
        for (int j = 0; j < 12; j++)
            for (int i = 0; i < 12; i++) {
                /* sub-columns of column i inside [2.125, 9.125): x = i - 3/8 + a/4 */
                int cx = 0, cy = 0;
                for (int a = 0; a < 4; a++) {
                    const double x = i - 0.375 + 0.25 * a, y = j - 0.375 + 0.25 * a;
                    cx += x >= 2.125 && x < 9.125;
                    cy += y >= 2.125 && y < 9.125;
                }
                const float e = (float)(cx * cy) / 16.0f;
                for (int k = 0; k < 12; k++) {
                    const float f = o.f[((size_t)k * 12 + j) * 12 + i];
                    bad += f != (k >= 2 && k <= 9 ? e : 0.0f);
                }
                total += cx * cy;
            }
        CHECK_MSG(bad == 0, "cap grid %d: %d voxels off", nq[q], bad);
        CHECK_EQ_INT(total, 28 * 28);
        vol_occupancy_free(&o);
        tm_free(&t);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A non-closed mesh: one quad (a single sheet crossed once per sub-column) fills nothing; an open
 * box without its caps' sides is still two sheets: filled between (docs). */
TEST(volume_occupancy_open_sheet_fills_nothing)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 8, &g));
    tmesh t;
    memset(&t, 0, sizeof t);
    uint32_t a = tm_vertex(&t, -1, -1, 3), b = tm_vertex(&t, 9, -1, 3), c = tm_vertex(&t, 9, 9, 3.5),
             d = tm_vertex(&t, -1, 9, 3.5);
    tm_tri(&t, a, b, c);
    tm_tri(&t, a, c, d);
    vol_occupancy o;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    vol_occ_mesh mm = one(&t.m);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    CHECK(occ_sum(&o) == 0.0);
    /* a second sheet below: the two sheets bound a slab */
    uint32_t e = tm_vertex(&t, -1, -1, 1), f = tm_vertex(&t, 9, -1, 1), h = tm_vertex(&t, 9, 9, 1), i = tm_vertex(&t, -1, 9, 1);
    tm_tri(&t, e, h, f);
    tm_tri(&t, e, i, h);
    mm = one(&t.m);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    CHECK(o.f[((size_t)2 * 8 + 4) * 8 + 4] == 1.0f);
    CHECK(o.f[((size_t)5 * 8 + 4) * 8 + 4] == 0.0f);
    vol_occupancy_free(&o);
    tm_free(&t);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- the light volume sees it ----------------------------------------------------------------- */

static int make_tf(vol_tf *tf, float alpha)
{
    memset(tf, 0, sizeof *tf);
    tf->points = (vol_tf_point *)calloc(2, sizeof *tf->points);
    if (!tf->points)
        return 0;
    tf->count = 2;
    snprintf(tf->name, sizeof tf->name, "test");
    tf->points[1].value = 1.0;
    for (int p = 0; p < 2; p++) {
        for (int c = 0; c < 3; c++)
            tf->points[p].rgba[c] = 1.0f;
        tf->points[p].rgba[3] = alpha;
    }
    return 1;
}
static int lv_equal(const vol_light_volume *a, const vol_light_volume *b)
{
    if (a->nx != b->nx || a->ny != b->ny || a->nz != b->nz)
        return 0;
    const size_t bytes = sizeof(float) * (size_t)a->nx * a->ny * a->nz;
    int ok = memcmp(a->l, b->l, bytes) == 0;
    for (int c = 0; c < 3; c++)
        ok &= memcmp(a->c[c], b->c[c], bytes) == 0;
    return ok;
}

/* An empty volume (alpha 0) and a slab mesh filling z in [9.5, 11.5] (voxels 10 and 11) across
 * the grid, the light travelling -z: the voxels behind the slab (k <= 8) get l ~ 0, those before
 * it (k >= 12) exactly 1. At scale 2 too, and with a point light far above. */
TEST(volume_occupancy_slab_shadows_the_volume_behind_it)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 16, &g));
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f));
    tmesh t;
    const double lo[3] = {-3, -3, 9.5}, hi[3] = {19, 19, 11.5};
    tm_box(&t, lo, hi, 1);
    vol_occ_mesh mm = one(&t.m);
    const vol_light Ls[2] = {vtu_dir_light(0, 0, -1), vtu_point_light(7.5, 7.5, 4000.0)};
    for (int li = 0; li < 2; li++)
        for (int scale = 1; scale <= 2; scale++) {
            vol_occupancy o;
            CHECK_OK(vol_occupancy_alloc(ctx, &g, scale, &o), ctx);
            CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
            vol_lv_params p = vol_lv_params_default();
            p.scale = scale;
            vol_occluder oc = {&o, 0.0, NULL, NULL};
            vol_light_volume lv;
            CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &Ls[li], &p, &oc, &lv), ctx);
            double max_behind = 0, min_front = 1;
            for (int k = 0; k < lv.nz; k++) {
                const double z = lv.origin[2] + k * lv.spacing[2];
                for (size_t q = 0; q < (size_t)lv.nx * lv.ny; q++) {
                    const float l = lv.l[(size_t)k * lv.nx * lv.ny + q];
                    if (z + 0.5 * lv.spacing[2] <= 9.5)
                        max_behind = l > max_behind ? l : max_behind;
                    if (z - 0.5 * lv.spacing[2] >= 11.5)
                        min_front = l < min_front ? l : min_front;
                }
            }
            CHECK_MSG(max_behind < 1e-4, "light %d scale %d: l behind the slab up to %g", li, scale, max_behind);
            CHECK_MSG(min_front > 1.0 - 1e-6, "light %d scale %d: l before the slab down to %.9f", li, scale, min_front);
            vol_light_volume_free(&lv);
            vol_occupancy_free(&o);
        }
    tm_free(&t);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* occ = NULL and an all-zero occupancy give vol_light_volume_build's bits (bucky, its TF, a
 * directional and a point light, scales 1 and 2). */
TEST(volume_occupancy_null_and_zero_occluders_are_bit_identical)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    const vol_light Ls[2] = {vtu_dir_light(0.3, -0.5, 0.8), vtu_point_light(-3.8, 1.0, 4.4)};
    obs_pool *pool = obs_pool_create(2);
    for (int li = 0; li < 2; li++)
        for (int scale = 1; scale <= 2; scale++) {
            vol_lv_params p = vol_lv_params_default();
            p.scale = scale;
            vol_light_volume a, b, c;
            vol_occupancy o;
            CHECK_OK(vol_occupancy_alloc(ctx, &g, scale, &o), ctx);
            vol_occluder oc = {&o, 0.0, NULL, NULL};
            CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &Ls[li], &p, &a), ctx);
            CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &Ls[li], &p, NULL, &b), ctx);
            CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &Ls[li], &p, &oc, &c), ctx);
            CHECK(lv_equal(&a, &b));
            CHECK(lv_equal(&a, &c));
            vol_light_volume_free(&a);
            vol_light_volume_free(&b);
            vol_light_volume_free(&c);
            vol_occupancy_free(&o);
        }
    obs_pool_destroy(pool);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The occupancy and the light volume built with it are identical for 1, 2 and 8 threads; the
 * AVX2 and scalar row paths (OBS_ISA=scalar) add the occupancy's extinction alike (bit for bit). */
TEST(volume_occupancy_identical_for_1_2_8_threads_and_both_isas)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    /* a sphere across a corner of the bucky's bounds, radius 0.3 of its side */
    double blo[3], bhi[3];
    vol_grid_bounds(&g, blo, bhi);
    obs_scene s;
    tu_sphere(&s, 48, 24, (float)(0.3 * (bhi[0] - blo[0])),
              obs_v3((float)(blo[0] + 0.63 * (bhi[0] - blo[0])), (float)(blo[1] + 0.68 * (bhi[1] - blo[1])),
                     (float)(blo[2] + 0.6 * (bhi[2] - blo[2]))),
              0.1f);
    vol_occ_mesh mm = one(&s.meshes[0]);
    const vol_light L = vtu_dir_light(-0.3, -0.5, -0.8);
    const int threads[3] = {1, 2, 8};
    vol_occupancy o[3];
    vol_light_volume lv[4];
    for (int q = 0; q < 3; q++) {
        obs_pool *pool = obs_pool_create(threads[q]);
        CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o[q]), ctx);
        CHECK_OK(vol_occupancy_voxelize(ctx, pool, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o[q]), ctx);
        vol_lv_params p = vol_lv_params_default();
        vol_occluder oc = {&o[q], 0.0, NULL, NULL};
        CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &L, &p, &oc, &lv[q]), ctx);
        obs_pool_destroy(pool);
    }
    const size_t bytes = sizeof(float) * 32 * 32 * 32;
    for (int q = 1; q < 3; q++) {
        CHECK(memcmp(o[0].f, o[q].f, bytes) == 0);
        CHECK(lv_equal(&lv[0], &lv[q]));
    }
    CHECK(occ_sum(&o[0]) > 0.05 * (bhi[0] - blo[0]) * (bhi[1] - blo[1]) * (bhi[2] - blo[2]));
    /* the occluder changed the light volume */
    vol_light_volume plain;
    vol_lv_params p = vol_lv_params_default();
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &plain), ctx);
    CHECK(!lv_equal(&plain, &lv[0]));
    vol_light_volume_free(&plain);
    /* scalar rows */
    const char *old = getenv("OBS_ISA");
    char *saved = old ? strdup(old) : NULL;
    setenv("OBS_ISA", "scalar", 1);
    vol_occluder oc = {&o[0], 0.0, NULL, NULL};
    CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv[3]), ctx);
    if (saved) {
        setenv("OBS_ISA", saved, 1);
        free(saved);
    } else {
        unsetenv("OBS_ISA");
    }
    CHECK(lv_equal(&lv[0], &lv[3]));
    for (int q = 0; q < 3; q++)
        vol_occupancy_free(&o[q]);
    for (int q = 0; q < 4; q++)
        vol_light_volume_free(&lv[q]);
    obs_scene_free(&s);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* vol_occupancy_alloc gives the light volume's layout bit for bit at scales 1, 2 and 4 (odd sizes,
 * anisotropic spacing, an offset origin). */
TEST(volume_occupancy_layout_is_the_light_volumes)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.7, 1.3, 0.45};
    CHECK_OK(vol_grid_alloc(ctx, 13, 10, 7, sp, &g), ctx);
    g.origin[0] = -2.1, g.origin[1] = 0.37, g.origin[2] = 5.0;
    vol_tf tf;
    CHECK(make_tf(&tf, 0.1f));
    const vol_light L = vtu_dir_light(0.2, 0.3, -1);
    for (int scale = 1; scale <= 4; scale *= 2) {
        vol_occupancy o;
        CHECK_OK(vol_occupancy_alloc(ctx, &g, scale, &o), ctx);
        vol_lv_params p = vol_lv_params_default();
        p.scale = scale;
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
        CHECK(o.nx == lv.nx && o.ny == lv.ny && o.nz == lv.nz);
        CHECK(memcmp(o.spacing, lv.spacing, sizeof o.spacing) == 0 && memcmp(o.origin, lv.origin, sizeof o.origin) == 0);
        vol_light_volume_free(&lv);
        vol_occupancy_free(&o);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_occupancy_bad_inputs_refused)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 16, &g));
    vol_tf tf;
    CHECK(make_tf(&tf, 0.1f));
    const vol_light L = vtu_dir_light(0, 0, -1);
    vol_occupancy o, o2;
    CHECK_EQ_INT(vol_occupancy_alloc(ctx, NULL, 1, &o), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_occupancy_alloc(ctx, &g, 3, &o), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_occupancy_alloc(ctx, &g, 1, NULL), OBS_STATUS_INVALID_ARGUMENT);
    /* absurd sizes: refused before allocating */
    obs_limits lim = obs_limits_default();
    lim.max_voxels = 1000;
    obs_context_set_limits(ctx, &lim);
    CHECK_EQ_INT(vol_occupancy_alloc(ctx, &g, 1, &o), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(o.f == NULL);
    lim = obs_limits_default();
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 2, &o2), ctx);
    tmesh t;
    const double lo[3] = {2, 2, 2}, hi[3] = {6, 6, 6};
    tm_box(&t, lo, hi, 1);
    vol_occ_mesh mm = one(&t.m);
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, NULL, 1, 4, &o), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, NULL), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 0, &o), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_MAX_SUBCOLUMNS + 1, &o), OBS_STATUS_INVALID_ARGUMENT);
    vol_occ_mesh nullmesh = {NULL, obs_mat4_identity()};
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &nullmesh, 1, 4, &o), OBS_STATUS_INVALID_ARGUMENT);
    t.m.indices[5] = 999; /* an index out of range */
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, &o), OBS_STATUS_INVALID_ARGUMENT);
    t.m.indices[5] = 0;
    t.m.positions[4] = NAN;
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, &o), OBS_STATUS_INVALID_ARGUMENT);
    t.m.positions[4] = 2.0f;
    /* triangles over the memory limit */
    lim.max_memory_bytes = 64;
    obs_context_set_limits(ctx, &lim);
    CHECK_EQ_INT(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, &o), OBS_STATUS_LIMIT_EXCEEDED);
    lim = obs_limits_default();
    obs_context_set_limits(ctx, &lim);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, 4, &o), ctx);
    /* the build: a layout mismatch, no grid, a bad ref_step, occupancy out of [0, 1] */
    vol_lv_params p = vol_lv_params_default();
    vol_light_volume lv;
    vol_occluder oc = {&o2, 0.0, NULL, NULL};
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "layout") != NULL);
    obs_context_clear_error(ctx);
    CHECK(lv.l == NULL);
    oc.occupancy = NULL;
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), OBS_STATUS_INVALID_ARGUMENT);
    oc.occupancy = &o;
    oc.ref_step = -1.0;
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), OBS_STATUS_INVALID_ARGUMENT);
    oc.ref_step = NAN;
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), OBS_STATUS_INVALID_ARGUMENT);
    oc.ref_step = 0.0;
    o.f[7] = 1.5f;
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), OBS_STATUS_INVALID_ARGUMENT);
    o.f[7] = 0.0f;
    CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), ctx);
    vol_light_volume_free(&lv);
    vol_occupancy_free(&o);
    vol_occupancy_free(&o2);
    vol_occupancy_free(NULL);
    tm_free(&t);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A point light inside the volume (the slices around it are seeded by a march straight to the
 * light, which samples the occupancy's extinction trilinearly) and an opaque cube between the light
 * and one corner: the voxels behind the cube are dark, those off its shadow stay lit. */
TEST(volume_occupancy_point_light_inside_the_volume_is_shadowed_by_a_cube)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK(zero_grid(ctx, 16, &g));
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f));
    tmesh t;
    const double lo[3] = {8.5, 8.5, 8.5}, hi[3] = {11.5, 11.5, 11.5};
    tm_box(&t, lo, hi, 1);
    vol_occ_mesh mm = one(&t.m);
    vol_occupancy o;
    CHECK_OK(vol_occupancy_alloc(ctx, &g, 1, &o), ctx);
    CHECK_OK(vol_occupancy_voxelize(ctx, NULL, &mm, 1, VOL_OCC_DEFAULT_SUBCOLUMNS, &o), ctx);
    const vol_light L = vtu_point_light(5.0, 5.0, 5.0);
    vol_lv_params p = vol_lv_params_default();
    vol_occluder oc = {&o, 0.0, NULL, NULL};
    vol_light_volume lv, plain;
    CHECK_OK(vol_light_volume_build_ex(ctx, NULL, &g, &tf, &L, &p, &oc, &lv), ctx);
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &plain), ctx);
    const size_t behind = ((size_t)14 * 16 + 14) * 16 + 14, off = ((size_t)5 * 16 + 2) * 16 + 14,
                 near = ((size_t)4 * 16 + 4) * 16 + 4;
    CHECK_MSG(lv.l[behind] < 0.01f, "l behind the cube %g", (double)lv.l[behind]);
    CHECK_MSG(lv.l[off] == plain.l[off] && lv.l[near] == plain.l[near], "l off the shadow %g / %g, near %g / %g",
              (double)lv.l[off], (double)plain.l[off], (double)lv.l[near], (double)plain.l[near]);
    CHECK(plain.l[behind] > 0.99f);
    vol_light_volume_free(&lv);
    vol_light_volume_free(&plain);
    vol_occupancy_free(&o);
    tm_free(&t);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* vol_occluder.entry alone (no occupancy): an empty volume lit along -z with an entry
 * transmittance of 0 where x < 8 and 0.5 elsewhere propagates those values straight through:
 * l = 0 over the first half, 0.5 over the second, at every slice (the light is along an axis, so
 * each voxel's fetch is its own column); the entry points lie on the face the light enters by
 * (z = n - 1 + 0.5) or beside a slice, outside the box (a texel a slice's edge fetch reads with
 * weight 0 here); out-of-range returns are clamped and NaN counts as 1; entry NULL with no
 * occupancy is refused. */
static float entry_half(void *user, const double x[3])
{
    int *bad = (int *)user;
    /* on the face the light enters by, or a texel beside a slice (outside the box in x or y) */
    const int on_face = fabs(x[2] - 15.5) <= 1e-9, beside = x[0] < 0.0 || x[0] > 15.0 || x[1] < 0.0 || x[1] > 15.0;
    if (!on_face && !beside)
        __atomic_fetch_add(bad, 1, __ATOMIC_RELAXED);
    return x[0] < 7.5 ? -3.0f : 0.5f;
}
static float entry_nan(void *user, const double x[3])
{
    (void)user;
    (void)x;
    return NAN;
}
TEST(volume_occupancy_entry_transmittance_seeds_the_first_slice)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK(zero_grid(ctx, 16, &g));
    CHECK(make_tf(&tf, 0.0f));
    const vol_light L = vtu_dir_light(0, 0, -1);
    vol_lv_params p = vol_lv_params_default();
    p.blend_second = 0;
    int bad = 0;
    vol_occluder oc = {NULL, 0.0, entry_half, &bad};
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &L, &p, &oc, &lv), ctx);
    CHECK_EQ_INT(bad, 0);
    int wrong = 0;
    for (int k = 0; k < lv.nz; k++)
        for (int j = 0; j < lv.ny; j++)
            for (int i = 0; i < lv.nx; i++) {
                const float l = lv.l[((size_t)k * lv.ny + j) * lv.nx + i];
                wrong += l != (i < 8 ? 0.0f : 0.5f);
            }
    CHECK_MSG(wrong == 0, "%d voxels off", wrong);
    vol_light_volume_free(&lv);
    vol_light_volume plain, nan_lv;
    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &p, &plain), ctx);
    vol_occluder on = {NULL, 0.0, entry_nan, NULL};
    CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &L, &p, &on, &nan_lv), ctx);
    CHECK(lv_equal(&plain, &nan_lv));
    vol_light_volume_free(&plain);
    vol_light_volume_free(&nan_lv);
    vol_occluder none = {NULL, 0.0, NULL, NULL};
    CHECK_EQ_INT(vol_light_volume_build_ex(ctx, pool, &g, &tf, &L, &p, &none, &lv), OBS_STATUS_INVALID_ARGUMENT);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* Light that enters the box through a side face is seen through the entry too: an empty volume lit
 * by an oblique directional light (and by a point light outside, above a corner) with an entry
 * transmittance of 0 everywhere is dark at every voxel (before, the propagation's fetches outside a
 * slice read the border l = 1, so the voxels near the side faces were lit); with entry 1 it is
 * lit everywhere, as without an occluder. Blend on and off. */
static float entry_zero(void *user, const double x[3])
{
    (void)user;
    (void)x;
    return 0.0f;
}
static float entry_one(void *user, const double x[3])
{
    (void)user;
    (void)x;
    return 1.0f;
}
TEST(volume_occupancy_entry_covers_light_entering_by_the_side_faces)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK(zero_grid(ctx, 16, &g));
    CHECK(make_tf(&tf, 0.0f));
    const vol_light lights[2] = {vtu_dir_light(0.5, -0.3, -0.8), vtu_point_light(-6, 24, 30)};
    for (int li = 0; li < 2; li++)
        for (int blend = 0; blend < 2; blend++) {
            vol_lv_params p = vol_lv_params_default();
            p.blend_second = blend;
            vol_occluder z = {NULL, 0.0, entry_zero, NULL}, o = {NULL, 0.0, entry_one, NULL};
            vol_light_volume dark, lit, plain;
            CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &lights[li], &p, &z, &dark), ctx);
            CHECK_OK(vol_light_volume_build_ex(ctx, pool, &g, &tf, &lights[li], &p, &o, &lit), ctx);
            CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &lights[li], &p, &plain), ctx);
            size_t lit_dark = 0, n = (size_t)dark.nx * dark.ny * dark.nz;
            for (size_t i = 0; i < n; i++)
                lit_dark += dark.l[i] != 0.0f;
            CHECK_MSG(lit_dark == 0, "light %d blend %d: %zu of %zu voxels lit through an entry of 0", li, blend,
                      lit_dark, n);
            CHECK(lv_equal(&lit, &plain));
            vol_light_volume_free(&dark);
            vol_light_volume_free(&lit);
            vol_light_volume_free(&plain);
        }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
