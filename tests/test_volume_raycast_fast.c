/* test_volume_raycast_fast.c: the ray caster's third speed round (docs/volume/raycast.md, "Third
 * round"): the AVX2 run gives the scalar run's bits (every shading, both precisions, with and
 * without bricks, perspective and orthographic, with a depth limit), the fast mode's gradient
 * volume is the exact central difference up to float rounding strictly inside the grid, its
 * effect on a Phong image is bounded, and the screen rectangle skips only rays that miss the box
 * (the same counters and the background outside). */
#include "core/obs.h"
#include "raster/raster.h"
#include "test.h"
#include "volume_test_util.h"
#include "volume/vol.h"
#include "volume/vol_raycast_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ---------------------------------------------------------------------------------- */

/* Seven Gaussian blobs in [0, 255] over an n^3 frame (voxel coordinates), as test_volume_raycast.c. */
static float blobs_at(double x, double y, double z, double n)
{
    double v = 0.0;
    for (int b = 0; b < 7; b++) {
        double cx = n * (0.2 + 0.1 * b), cy = n * (0.5 + 0.3 * sin(1.7 * b)), cz = n * (0.5 + 0.3 * cos(2.3 * b));
        double r2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
        v += 255.0 * exp(-r2 / (0.012 * n * n));
    }
    return (float)(v > 255.0 ? 255.0 : v);
}

static obs_status mk_blobs(obs_context *ctx, int nx, int ny, int nz, const double sp[3], double n, vol_grid *g)
{
    obs_status st = vol_grid_alloc(ctx, nx, ny, nz, sp, g);
    if (st != OBS_STATUS_OK)
        return st;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                g->data[((size_t)k * ny + j) * nx + i] = blobs_at(i, j, k, n);
    vol_grid_update_range(g);
    return OBS_STATUS_OK;
}

static vol_tf mk_tf(vol_tf_point *pts, int count, double ref_step)
{
    vol_tf tf;
    memset(&tf, 0, sizeof tf);
    strcpy(tf.name, "test");
    tf.count = count;
    tf.points = pts;
    tf.ref_step = ref_step;
    return tf;
}

static vol_light point_light(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_POINT;
    L.position[0] = x, L.position[1] = y, L.position[2] = z;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

static vol_light dir_light(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    const double n = sqrt(x * x + y * y + z * z);
    L.direction[0] = x / n, L.direction[1] = y / n, L.direction[2] = z / n;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

/* A cast with its counters, OBS_ISA set to "scalar" (scalar = 1) or "avx2" (the AVX2 run where the
 * build and the CPU have it); the caller's OBS_ISA is restored. */
static obs_status cast_isa(obs_context *ctx, obs_pool *pool, int scalar, const vol_grid *g, const vol_tf *tf,
                           const vol_light *L, const vol_light_volume *lv, const obs_camera *cam, int w, int h,
                           const obs_image_f32 *depth, const vol_rc_params *p, obs_image_f32 out[4],
                           vol_i_rc_stats *st)
{
    const char *old = getenv("OBS_ISA");
    char keep[64] = {0};
    if (old)
        snprintf(keep, sizeof keep, "%s", old);
    setenv("OBS_ISA", scalar ? "scalar" : "avx2", 1);
    obs_status s = vol_i_rc_raycast_stats(ctx, pool, g, tf, L, lv, cam, w, h, depth, p, out, st);
    if (old)
        setenv("OBS_ISA", keep, 1);
    else
        unsetenv("OBS_ISA");
    return s;
}

static int same_stats(const vol_i_rc_stats *a, const vol_i_rc_stats *b)
{
    return a->rays == b->rays && a->samples == b->samples && a->samples_skipped == b->samples_skipped &&
           a->samples_shaded == b->samples_shaded && a->rays_terminated == b->rays_terminated &&
           a->bricks == b->bricks && a->bricks_empty == b->bricks_empty;
}

/* ---- the AVX2 run ------------------------------------------------------------------------------ */

TEST(volume_raycast_avx2_run_matches_scalar_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    const char *old = getenv("OBS_ISA");
    char keep[64] = {0};
    if (old)
        snprintf(keep, sizeof keep, "%s", old);
    setenv("OBS_ISA", "avx2", 1);
    const int avx2 = vol_i_rc_avx2_active();
    if (old)
        setenv("OBS_ISA", keep, 1);
    else
        unsetenv("OBS_ISA");
    if (!avx2)
        printf("  (the AVX2 run is not active here: the scalar run is compared with itself)\n");
    /* Two grids: isotropic 48^3 and an anisotropic 40 x 36 x 28 (spacing 0.9, 1.1, 1.6). */
    vol_grid grids[2];
    const double sp0[3] = {1, 1, 1}, sp1[3] = {0.9, 1.1, 1.6};
    CHECK_OK(mk_blobs(ctx, 48, 48, 48, sp0, 48.0, &grids[0]), ctx);
    CHECK_OK(mk_blobs(ctx, 40, 36, 28, sp1, 36.0, &grids[1]), ctx);
    vol_tf_point bp[4] = {{30.0, {0, 0, 0, 0}},
                          {77.3, {0.8f, 0.4f, 0.2f, 0.05f}},
                          {120.0, {1, 0.3f, 0.1f, 0.3f}},
                          {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 4, 1.0);
    const int W = 96, H = 64;
    /* A depth limit cutting the volume (a ramp), NaN in one corner (no limit there). */
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&depth, y)[x] = (x < 8 && y < 8) ? NAN : (float)(60.0 + 0.4 * x + 0.2 * y);
    int cases = 0;
    for (int gi = 0; gi < 2; gi++) {
        const vol_grid *g = &grids[gi];
        double lo[3], hi[3];
        vol_grid_bounds(g, lo, hi);
        const float cx = (float)(0.5 * (lo[0] + hi[0])), cy = (float)(0.5 * (lo[1] + hi[1])),
                    cz = (float)(0.5 * (lo[2] + hi[2]));
        obs_camera cams[2];
        cams[0] = obs_camera_look_at(obs_v3(cx - 55, cy + 40, cz + 50), obs_v3(cx, cy, cz), obs_v3(0, 1, 0), 0.8f, 0.1f,
                                     400.0f);
        cams[1] = cams[0];
        cams[1].projection = OBS_PROJECTION_ORTHOGRAPHIC;
        cams[1].xmag = 36.0f;
        cams[1].ymag = 24.0f;
        vol_light lights[2] = {point_light(cx + 40, cy + 50, cz + 30), dir_light(-0.4, -0.7, -0.6)};
        vol_light_volume lv;
        memset(&lv, 0, sizeof lv);
        vol_lv_params lp = vol_lv_params_default();
        CHECK_OK(vol_light_volume_build(ctx, pool, g, &tf, &lights[1], &lp, &lv), ctx);
        const vol_shading modes[4] = {VOL_SHADING_EMISSION_ABSORPTION, VOL_SHADING_PHONG, VOL_SHADING_PHONG,
                                      VOL_SHADING_LIGHT_VOLUME};
        for (int m = 0; m < 4; m++) {
            for (int prec = 0; prec < 2; prec++) {
                for (int bk = 0; bk < 2; bk++) {
                    for (int ci = 0; ci < 2; ci++) {
                        for (int dl = 0; dl < 2; dl++) {
                            if (dl && (ci || bk)) /* the depth limit once per mode and precision */
                                continue;
                            vol_rc_params p = vol_rc_params_default();
                            p.shading = modes[m];
                            p.precision = prec ? VOL_RC_FAST : VOL_RC_EXACT;
                            p.brick = bk ? 0 : 8;
                            const vol_light *L = &lights[m == 1 ? 0 : 1];
                            obs_image_f32 a[4], b[4];
                            vol_i_rc_stats sa, sb;
                            CHECK_OK(cast_isa(ctx, pool, 0, g, &tf, L, &lv, &cams[ci], W, H, dl ? &depth : NULL, &p,
                                              a, &sa),
                                     ctx);
                            CHECK_OK(cast_isa(ctx, pool, 1, g, &tf, L, &lv, &cams[ci], W, H, dl ? &depth : NULL, &p,
                                              b, &sb),
                                     ctx);
                            CHECK_MSG(vtu_same4(a, b),
                                      "grid %d %s %s brick %d camera %d depth %d: AVX2 and scalar runs differ (max %g)",
                                      gi, vol_shading_name(p.shading), prec ? "fast" : "exact", p.brick, ci, dl,
                                      vtu_maxdiff4(a, b));
                            CHECK_MSG(same_stats(&sa, &sb), "grid %d %s: counters differ", gi,
                                      vol_shading_name(p.shading));
                            CHECK(sa.samples_shaded > 0);
                            vtu_free4(a);
                            vtu_free4(b);
                            cases++;
                        }
                    }
                }
            }
        }
        vol_light_volume_free(&lv);
    }
    printf("  %d cases, AVX2 run %s\n", cases, avx2 ? "active" : "inactive");
    obs_image_f32_free(&depth);
    vol_grid_free(&grids[0]);
    vol_grid_free(&grids[1]);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* ---- the fast mode's gradient volume ----------------------------------------------------------- */

/* Strictly inside the grid the gradient volume's trilinear interpolation is the exact mode's
 * central difference of the trilinear field in real arithmetic (vol_raycast.c, rc_gradient_volume);
 * in float they differ by rounding: the exact one by the rounding of its two float samples (values
 * up to 255: ~255 x 2^-24 x a few, divided by 2 spacing), the volume's by its lerps. Bound: ours,
 * 1e-4 value units per world unit against gradients up to ~100 here (measured: see the output). */
#define VOL_RC_TEST_GRADV_MAX 1e-4

TEST(volume_raycast_fast_gradient_volume_is_the_central_difference_inside)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.9, 1.1, 1.6};
    CHECK_OK(mk_blobs(ctx, 40, 36, 28, sp, 36.0, &g), ctx);
    vol_tf_point bp[3] = {{30.0, {0, 0, 0, 0}}, {120.0, {1, 0.3f, 0.1f, 0.3f}}, {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 3, 1.0);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_PHONG;
    vol_rc_prepared *prep = NULL;
    /* Without fast Phong: no gradient volume. */
    CHECK_OK(vol_rc_prepare(ctx, NULL, &g, &tf, &p, &prep), ctx);
    double gr[3] = {7, 7, 7}, c0[3] = {5.5, 5.5, 5.5};
    CHECK(vol_i_rc_gradient_volume_at(prep, c0, gr) == 0 && gr[0] == 7.0);
    vol_rc_prepared_free(prep);
    p.precision = VOL_RC_FAST;
    CHECK_OK(vol_rc_prepare(ctx, NULL, &g, &tf, &p, &prep), ctx);
    const int nv[3] = {g.nx, g.ny, g.nz};
    uint64_t rng = 0x9E3779B97F4A7C15ull;
    double worst = 0.0, gmax = 0.0;
    for (int i = 0; i < 100000; i++) {
        double c[3];
        for (int a = 0; a < 3; a++) {
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            double u = (double)(rng >> 11) * 0x1p-53; /* [0, 1) */
            /* every 8th point a voxel centre, else uniform strictly inside (0, n - 1) */
            c[a] = (i % 8 == 0) ? (double)(1 + (int)(u * (nv[a] - 2))) : u * (nv[a] - 1);
            if (!(c[a] > 0.0))
                c[a] = 0.5;
        }
        double ge[3], gv[3];
        vol_i_rc_gradient(&g, c, ge);
        CHECK(vol_i_rc_gradient_volume_at(prep, c, gv) == 1);
        for (int a = 0; a < 3; a++) {
            double d = fabs(ge[a] - gv[a]);
            if (d > worst)
                worst = d;
            if (fabs(ge[a]) > gmax)
                gmax = fabs(ge[a]);
        }
    }
    printf("  gradient volume against the central difference, strictly inside: max |diff| %.3g (largest component "
           "%.3g)\n",
           worst, gmax);
    CHECK_MSG(worst <= VOL_RC_TEST_GRADV_MAX, "gradient volume differs by %g > %g", worst, VOL_RC_TEST_GRADV_MAX);
    CHECK(gmax > 10.0); /* the blobs' gradients are not trivial */
    vol_rc_prepared_free(prep);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The gradient volume's effect on a fast Phong image: against the same fast cast through a handle
 * prepared without it (the exact central difference), on the blobs, perspective, point and
 * directional light. Bound: ours (measured: see the output). */
#define VOL_RC_TEST_GRADV_IMAGE_MAX 1e-4

TEST(volume_raycast_fast_phong_gradient_volume_changes_the_image_within_bound)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_blobs(ctx, 48, 48, 48, sp, 48.0, &g), ctx);
    vol_tf_point bp[4] = {{30.0, {0, 0, 0, 0}},
                          {77.3, {0.8f, 0.4f, 0.2f, 0.05f}},
                          {120.0, {1, 0.3f, 0.1f, 0.3f}},
                          {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 4, 1.0);
    obs_camera cam = obs_camera_look_at(obs_v3(-30, 65, 75), obs_v3(23.5f, 23.5f, 23.5f), obs_v3(0, 1, 0), 0.8f, 0.1f,
                                        400.0f);
    vol_light lights[2] = {point_light(60, 70, 50), dir_light(-0.4, -0.7, -0.6)};
    vol_rc_params pf = vol_rc_params_default();
    pf.shading = VOL_SHADING_PHONG;
    pf.precision = VOL_RC_FAST;
    vol_rc_params pe = pf;
    pe.shading = VOL_SHADING_EMISSION_ABSORPTION; /* a handle without the gradient volume */
    vol_rc_prepared *with = NULL, *without = NULL;
    CHECK_OK(vol_rc_prepare(ctx, pool, &g, &tf, &pf, &with), ctx);
    CHECK_OK(vol_rc_prepare(ctx, pool, &g, &tf, &pe, &without), ctx);
    for (int l = 0; l < 2; l++) {
        obs_image_f32 a[4], b[4], e[4];
        CHECK_OK(vol_raycast_prepared(ctx, pool, with, &lights[l], NULL, &cam, 96, 64, NULL, &pf, a), ctx);
        CHECK_OK(vol_raycast_prepared(ctx, pool, without, &lights[l], NULL, &cam, 96, 64, NULL, &pf, b), ctx);
        vol_rc_params px = pf;
        px.precision = VOL_RC_EXACT;
        CHECK_OK(vol_raycast_prepared(ctx, pool, without, &lights[l], NULL, &cam, 96, 64, NULL, &px, e), ctx);
        const double md = vtu_maxdiff4(a, b), mx = vtu_maxdiff4(a, e);
        printf("  %s light: fast Phong with the gradient volume vs without: max %.3g; vs exact: max %.3g\n",
               l ? "directional" : "point", md, mx);
        CHECK_MSG(md <= VOL_RC_TEST_GRADV_IMAGE_MAX, "gradient volume changes the image by %g > %g", md,
                  VOL_RC_TEST_GRADV_IMAGE_MAX);
        CHECK_MSG(mx <= 1e-4, "fast Phong differs from exact by %g > 1e-4", mx); /* the fast mode's bound */
        vtu_free4(a);
        vtu_free4(b);
        vtu_free4(e);
    }
    vol_rc_prepared_free(with);
    vol_rc_prepared_free(without);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* ---- the screen rectangle ---------------------------------------------------------------------- */

/* Whether pixel (x, y)'s ray meets the box within [znear, zfar]: rc_trace's own test, written out
 * here without the screen rectangle. */
static int ray_hits(const rast_view_constants *vc, const obs_camera *cam, const double lo[3], const double hi[3], int x,
                    int y)
{
    obs_dvec3 O, D;
    rast_pixel_ray(vc, cam, x + 0.5, y + 0.5, &O, &D);
    const double o[3] = {O.x, O.y, O.z}, d[3] = {D.x, D.y, D.z};
    double t0 = vc->znear, t1 = vc->zfar;
    if (!(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) > 0.0))
        return 0;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a])
                return 0;
            continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > t0)
            t0 = ta;
        if (tb < t1)
            t1 = tb;
    }
    return t1 > t0;
}

TEST(volume_raycast_screen_rect_skips_only_rays_that_miss)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.9, 1.1, 1.6};
    CHECK_OK(mk_blobs(ctx, 40, 36, 28, sp, 36.0, &g), ctx);
    vol_tf_point bp[3] = {{30.0, {0, 0, 0, 0}}, {120.0, {1, 0.3f, 0.1f, 0.3f}}, {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 3, 1.0);
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    const int W = 120, H = 80;
    /* Far and small, off-centre; close and cut by the image's edges; orthographic; the eye inside
     * the box (no rectangle); a wide field of view with the box behind a corner of it. */
    obs_camera cams[5];
    cams[0] = obs_camera_look_at(obs_v3(150, 120, 200), obs_v3(-10, 40, 0), obs_v3(0, 1, 0), 0.5f, 0.1f, 1000.0f);
    cams[1] = obs_camera_look_at(obs_v3(60, 30, 70), obs_v3(30, 25, 15), obs_v3(0, 1, 0), 0.9f, 0.1f, 1000.0f);
    cams[2] = obs_camera_look_at(obs_v3(80, 60, 90), obs_v3(10, 15, 20), obs_v3(0, 1, 0), 0.8f, 0.1f, 1000.0f);
    cams[2].projection = OBS_PROJECTION_ORTHOGRAPHIC;
    cams[2].xmag = 30.0f;
    cams[2].ymag = 20.0f;
    cams[3] = obs_camera_look_at(obs_v3(18, 20, 22), obs_v3(40, 40, 60), obs_v3(0, 1, 0), 1.2f, 0.1f, 1000.0f);
    cams[4] = obs_camera_look_at(obs_v3(20, 20, 50), obs_v3(60, 20, 50), obs_v3(0, 1, 0), 2.6f, 0.1f, 1000.0f);
    for (int ci = 0; ci < 5; ci++) {
        vol_rc_params p = vol_rc_params_default();
        p.shading = VOL_SHADING_EMISSION_ABSORPTION;
        p.background[0] = 0.25f;
        p.background[1] = 0.5f;
        p.background[2] = 0.125f;
        p.background[3] = 0.75f;
        obs_image_f32 out[4];
        vol_i_rc_stats st;
        CHECK_OK(vol_i_rc_raycast_stats(ctx, NULL, &g, &tf, NULL, NULL, &cams[ci], W, H, NULL, &p, out, &st), ctx);
        rast_params rp = rast_params_default();
        rp.width = W;
        rp.height = H;
        rp.guard = 0;
        rast_view_constants vc;
        CHECK_OK(rast_view_constants_make(ctx, &rp, &cams[ci], &vc), ctx);
        int64_t hits = 0, bg_bad = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                if (ray_hits(&vc, &cams[ci], lo, hi, x, y)) {
                    hits++;
                } else {
                    for (int c = 0; c < 4; c++)
                        bg_bad += obs_image_f32_row(&out[c], y)[x] != p.background[c];
                }
            }
        printf("  camera %d: %lld of %d rays meet the box\n", ci, (long long)hits, W * H);
        CHECK_MSG(st.rays == hits, "camera %d: %lld rays cast, %lld meet the box", ci, (long long)st.rays,
                  (long long)hits);
        CHECK_MSG(bg_bad == 0, "camera %d: %lld missing pixels are not the background", ci, (long long)bg_bad);
        CHECK(ci == 3 || hits < (int64_t)W * H); /* the box does not fill the image (but from inside) */
        CHECK(hits > 0);
        vtu_free4(out);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}
