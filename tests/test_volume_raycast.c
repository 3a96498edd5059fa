/* test_volume_raycast.c: the volume ray caster (vol.h section 4; docs/volume/raycast.md):
 * Beer-Lambert through homogeneous media (orthographic and perspective), independence of the step,
 * a slab against a fine quadrature of its optical depth, EA colour and background, empty-space
 * skipping (identical images, fewer samples), early termination's bound, the depth limit, Phong on
 * a sphere (lit side, radial gradient), light-volume shading (the product, the shadowed side),
 * thread-count independence, refusals. */
#include "core/obs.h"
#include "raster/raster.h"
#include "scene_util.h"
#include "test.h"
#include "volume_test_util.h"
#include "volume/vol.h"
#include "volume/vol_raycast_internal.h"

#include <stdlib.h>
#include <string.h>

/* ---- helpers ---------------------------------------------------------------------------------- */

typedef float (*fill_fn)(double x, double y, double z, const void *user);

/* A grid with value fill(i, j, k) at voxel (i, j, k) (voxel coordinates). */
static obs_status mk_grid(obs_context *ctx, int nx, int ny, int nz, const double sp[3], fill_fn fill, const void *user,
                          vol_grid *g)
{
    obs_status st = vol_grid_alloc(ctx, nx, ny, nz, sp, g);
    if (st != OBS_STATUS_OK)
        return st;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                g->data[((size_t)k * ny + j) * nx + i] = fill(i, j, k, user);
    vol_grid_update_range(g);
    return OBS_STATUS_OK;
}

static float fill_const(double x, double y, double z, const void *u)
{
    (void)x, (void)y, (void)z;
    return *(const float *)u;
}

/* Value 1 for z in [z0, z1) (voxel indices), 0 elsewhere. */
static float fill_slab(double x, double y, double z, const void *u)
{
    (void)x, (void)y;
    const int *r = (const int *)u;
    return (z >= r[0] && z < r[1]) ? 1.0f : 0.0f;
}

/* A sphere of radius r around c (voxel units) with a one-voxel linear edge: 1 inside, 0 outside. */
static float fill_sphere(double x, double y, double z, const void *u)
{
    const double *s = (const double *)u; /* cx, cy, cz, r */
    double d = sqrt((x - s[0]) * (x - s[0]) + (y - s[1]) * (y - s[1]) + (z - s[2]) * (z - s[2]));
    double v = 0.5 - (d - s[3]);
    return (float)(v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v);
}

/* A few Gaussian blobs (values 0..255), a stand-in for the bucky where vol_synth is absent. */
static float fill_blobs(double x, double y, double z, const void *u)
{
    const int n = *(const int *)u;
    double v = 0.0;
    for (int b = 0; b < 7; b++) {
        double cx = n * (0.2 + 0.1 * b), cy = n * (0.5 + 0.3 * sin(1.7 * b)), cz = n * (0.5 + 0.3 * cos(2.3 * b));
        double r2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
        v += 255.0 * exp(-r2 / (0.012 * n * n));
    }
    return (float)(v > 255.0 ? 255.0 : v);
}

/* A transfer function from (value, r, g, b, a) rows (points held by the caller). */
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

/* Orthographic camera at (cx, cy, z) looking down -Z, half extents xm, ym. */
static obs_camera ortho_down(double cx, double cy, double z, double xm, double ym)
{
    obs_camera c = obs_camera_look_at(obs_v3((float)cx, (float)cy, (float)z), obs_v3((float)cx, (float)cy, (float)z - 1.0f),
                                      obs_v3(0, 1, 0), 1.0f, 0.0f, 1000.0f);
    c.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    c.xmag = (float)xm;
    c.ymag = (float)ym;
    c.znear = 0.0f;
    c.zfar = 1000.0f;
    return c;
}


/* The ray's parameter interval inside the box [lo, hi] (independent of the ray caster's clip). */
static int box_clip(const double lo[3], const double hi[3], obs_dvec3 O, obs_dvec3 D, double *t0, double *t1)
{
    double o[3] = {O.x, O.y, O.z}, d[3] = {D.x, D.y, D.z};
    double a0 = -INFINITY, a1 = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a])
                return 0;
            continue;
        }
        double u = (lo[a] - o[a]) / d[a], v = (hi[a] - o[a]) / d[a];
        if (u > v) {
            double w = u;
            u = v;
            v = w;
        }
        a0 = u > a0 ? u : a0;
        a1 = v < a1 ? v : a1;
    }
    *t0 = a0;
    *t1 = a1;
    return a1 > a0;
}

/* ---- names, params ---------------------------------------------------------------------------- */

TEST(volume_raycast_shading_names_round_trip)
{
    for (int s = 0; s < VOL_SHADING_COUNT; s++) {
        vol_shading back;
        CHECK(vol_shading_from_name(vol_shading_name((vol_shading)s), &back));
        CHECK_EQ_INT(back, s);
    }
    vol_shading x;
    CHECK(!vol_shading_from_name("gouraud", &x));
    CHECK(strcmp(vol_shading_name(VOL_SHADING_COUNT), "unknown") == 0);
    vol_rc_params p = vol_rc_params_default();
    CHECK_EQ_INT(p.shading, VOL_SHADING_LIGHT_VOLUME);
    CHECK(p.step == 0.0 && p.early_termination == 0.99 && p.brick == 8);
}

TEST(volume_raycast_refuses_bad_params)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 4, 4, 4, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {1, 1, 1, 0.1f}}, {1.0, {1, 1, 1, 0.1f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    obs_camera cam = ortho_down(1.5, 1.5, 10, 3, 3);
    obs_image_f32 out[4];
    const double bad_steps[] = {-1.0, NAN, INFINITY, -INFINITY};
    for (size_t i = 0; i < sizeof bad_steps / sizeof bad_steps[0]; i++) {
        vol_rc_params p = vol_rc_params_default();
        p.shading = VOL_SHADING_EMISSION_ABSORPTION;
        p.step = bad_steps[i];
        CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out),
                     OBS_STATUS_INVALID_ARGUMENT);
        CHECK(out[0].data == NULL);
    }
    const double bad_et[] = {0.0, -0.1, 1.5, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad_et / sizeof bad_et[0]; i++) {
        vol_rc_params p = vol_rc_params_default();
        p.shading = VOL_SHADING_EMISSION_ABSORPTION;
        p.early_termination = bad_et[i];
        CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out),
                     OBS_STATUS_INVALID_ARGUMENT);
    }
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.brick = -1;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), OBS_STATUS_INVALID_ARGUMENT);
    p.brick = 8;
    p.ambient = 1.5f;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), OBS_STATUS_INVALID_ARGUMENT);
    p.ambient = 0.2f;
    p.background[2] = NAN;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), OBS_STATUS_INVALID_ARGUMENT);
    p.background[2] = 0.0f;
    /* Phong without a light, light volume without a light volume, a depth image of the wrong size,
     * a step so small the rays would never end. */
    p.shading = VOL_SHADING_PHONG;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), OBS_STATUS_INVALID_ARGUMENT);
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {0, 0, -1}, {0, 0, 0}, {1, 1, 1}};
    p.shading = VOL_SHADING_LIGHT_VOLUME;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, &light, NULL, &cam, 8, 8, NULL, &p, out),
                 OBS_STATUS_INVALID_ARGUMENT);
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    obs_image_f32 dimg;
    CHECK_OK(obs_image_f32_alloc(ctx, 7, 8, &dimg), ctx);
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, &dimg, &p, out), OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&dimg);
    p.step = 1e-9;
    CHECK_EQ_INT(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), OBS_STATUS_LIMIT_EXCEEDED);
    /* And the defaults work. */
    p.step = 0.0;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 8, 8, NULL, &p, out), ctx);
    vtu_free4(out);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The ray caster's inlined trilinear sample is vol_grid_sample bit for bit, at random points, on
 * voxel centres and planes, outside the grid (clamped) and at NaN. */
TEST(volume_raycast_inlined_trilinear_is_vol_grid_sample_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.7, 1.0, 1.3};
    CHECK_OK(vol_grid_alloc(ctx, 7, 5, 6, sp, &g), ctx);
    uint32_t r = 12345u;
    for (int i = 0; i < 7 * 5 * 6; i++) {
        r = r * 1664525u + 1013904223u;
        g.data[i] = (float)((r >> 8) * (1.0 / 16777216.0) * 2000.0 - 1000.0);
    }
    const double special[] = {-3.0, -0.5, 0.0, 0.25, 1.0, 3.5, 4.0, 4.999999, 5.0, 5.5, 6.0, 7.0, 100.0, NAN};
    const int ns = (int)(sizeof special / sizeof special[0]);
    for (int a = 0; a < ns; a++)
        for (int b = 0; b < ns; b++)
            for (int c = 0; c < ns; c++) {
                float u = vol_grid_sample(&g, special[a], special[b], special[c]);
                float v = vol_i_rc_sample(&g, special[a], special[b], special[c]);
                CHECK(memcmp(&u, &v, sizeof u) == 0);
            }
    for (int i = 0; i < 100000; i++) {
        double q[3];
        for (int a = 0; a < 3; a++) {
            r = r * 1664525u + 1013904223u;
            q[a] = (r >> 8) * (1.0 / 16777216.0) * 10.0 - 2.0;
        }
        float u = vol_grid_sample(&g, q[0], q[1], q[2]);
        float v = vol_i_rc_sample(&g, q[0], q[1], q[2]);
        CHECK_MSG(memcmp(&u, &v, sizeof u) == 0, "at (%.17g, %.17g, %.17g): %.9g vs %.9g", q[0], q[1], q[2], u, v);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- Beer-Lambert ------------------------------------------------------------------------------ */

/* A homogeneous medium (alpha 0.1 per ref_step 1) filling the whole 16^3 box, seen orthographically
 * along z: every pixel whose ray runs through the box has alpha 1 - 0.9^16 = 1 - exp(-sigma d),
 * sigma = -ln(0.9); premultiplied colour = rgb x alpha. */
TEST(volume_raycast_homogeneous_medium_matches_beer_lambert)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 16, 16, 16, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {0.8f, 0.4f, 0.2f, 0.1f}}, {1.0, {0.8f, 0.4f, 0.2f, 0.1f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    obs_camera cam = ortho_down(7.5, 7.5, 40, 10, 10);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.early_termination = 1.0;
    obs_image_f32 out[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 20, 20, NULL, &p, out), ctx);
    const double expect = 1.0 - pow(0.9, 16.0);
    const double rgb[3] = {0.8, 0.4, 0.2};
    int inside = 0;
    for (int y = 0; y < 20; y++)
        for (int x = 0; x < 20; x++) {
            /* pixel centre world x = 7.5 - 10 + x + 0.5: inside the box [-0.5, 15.5] for x in [2, 17] */
            int in = x >= 2 && x <= 17 && y >= 2 && y <= 17;
            double a = obs_image_f32_row(&out[3], y)[x];
            if (in) {
                inside++;
                CHECK_NEAR(a, expect, 2e-6);
                for (int c = 0; c < 3; c++)
                    CHECK_NEAR(obs_image_f32_row(&out[c], y)[x], rgb[c] * expect, 2e-6);
            } else {
                CHECK(a == 0.0f);
            }
        }
    CHECK_EQ_INT(inside, 256);
    vtu_free4(out);

    /* Perspective, anisotropic spacing, and a background: alpha = 1 - 0.9^(len / ref) with len the
     * ray's world length in the box, computed here independently; colour = rgb a + (1 - a) bg. */
    vol_grid_free(&g);
    const double sp2[3] = {0.5, 0.8, 1.25};
    CHECK_OK(mk_grid(ctx, 12, 10, 9, sp2, fill_const, &one, &g), ctx);
    tf.ref_step = 0.7;
    obs_camera pc = obs_camera_look_at(obs_v3(14, 9, 20), obs_v3(3, 4, 5), obs_v3(0, 1, 0), 0.6f, 0.1f, 100.0f);
    p.background[0] = 0.1f;
    p.background[1] = 0.2f;
    p.background[2] = 0.3f;
    p.background[3] = 1.0f;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &pc, 33, 25, NULL, &p, out), ctx);
    rast_params rp = rast_params_default();
    rp.width = 33;
    rp.height = 25;
    rast_view_constants vc;
    CHECK_OK(rast_view_constants_make(ctx, &rp, &pc, &vc), ctx);
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    int hits = 0;
    for (int y = 0; y < 25; y++)
        for (int x = 0; x < 33; x++) {
            obs_dvec3 O, D;
            rast_pixel_ray(&vc, &pc, x + 0.5, y + 0.5, &O, &D);
            double t0, t1, a = 0.0;
            if (box_clip(lo, hi, O, D, &t0, &t1)) {
                hits++;
                double len = (t1 - t0) * sqrt(D.x * D.x + D.y * D.y + D.z * D.z);
                a = 1.0 - pow(0.9, len / 0.7);
            }
            CHECK_NEAR(obs_image_f32_row(&out[3], y)[x], a + (1.0 - a) * 1.0, 2e-6);
            for (int c = 0; c < 3; c++)
                CHECK_NEAR(obs_image_f32_row(&out[c], y)[x], rgb[c] * a + (1.0 - a) * p.background[c], 2e-6);
        }
    CHECK(hits > 100);
    vtu_free4(out);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The step's opacity correction makes a homogeneous medium's image independent of the step. */
TEST(volume_raycast_step_size_does_not_change_homogeneous_result)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1.5};
    CHECK_OK(mk_grid(ctx, 16, 16, 16, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {0.3f, 0.6f, 0.9f, 0.05f}}, {1.0, {0.3f, 0.6f, 0.9f, 0.05f}}};
    vol_tf tf = mk_tf(pts, 2, 0.0); /* ref_step 0: one voxel of the smallest spacing */
    obs_camera pc = obs_camera_look_at(obs_v3(30, 20, 40), obs_v3(7.5, 7.5, 11), obs_v3(0, 1, 0), 0.7f, 0.1f, 200.0f);
    const double steps[] = {0.5, 0.37, 1.3, 0.05};
    obs_image_f32 ref[4], out[4];
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.early_termination = 1.0;
    p.step = steps[0];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &pc, 24, 24, NULL, &p, ref), ctx);
    double amax = 0.0;
    for (int y = 0; y < 24; y++)
        for (int x = 0; x < 24; x++)
            amax = fmax(amax, obs_image_f32_row(&ref[3], y)[x]);
    CHECK(amax > 0.5); /* the test means something */
    for (size_t i = 1; i < sizeof steps / sizeof steps[0]; i++) {
        p.step = steps[i];
        CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &pc, 24, 24, NULL, &p, out), ctx);
        double d = vtu_maxdiff4(ref, out);
        CHECK_MSG(d <= 2e-6, "step %g vs %g: max difference %.3g", steps[i], steps[0], d);
        vtu_free4(out);
    }
    vtu_free4(ref);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The synthetic slab (value 1 for z in [8, 24) of 32, a one-voxel linear edge from trilinear
 * reconstruction), TF alpha 0.3 x value: the ray's alpha against 1 - exp(integral of ln(1 - alpha(z))
 * / ref_step), integrated here with 10^5 midpoints; the ray caster's error is its step's. */
TEST(volume_raycast_slab_matches_optical_depth_integral)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    int zr[2] = {8, 24};
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 8, 8, 32, sp, fill_slab, zr, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {1, 1, 1, 0.0f}}, {1.0, {1, 1, 1, 0.3f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    /* Reference along the voxel-z axis: box z in [-0.5, 31.5]. */
    const int N = 100000;
    double od = 0.0;
    for (int i = 0; i < N; i++) {
        double z = -0.5 + 32.0 * (i + 0.5) / N;
        double zc = z < 0.0 ? 0.0 : z > 31.0 ? 31.0 : z;
        int k0 = (int)floor(zc);
        int k1 = k0 + 1 > 31 ? 31 : k0 + 1;
        double f = zc - k0;
        double v = (1.0 - f) * fill_slab(0, 0, k0, zr) + f * fill_slab(0, 0, k1, zr);
        od += log(1.0 - 0.3 * v) * (32.0 / N);
    }
    const double expect = 1.0 - exp(od);
    const double steps[] = {0.5, 0.25, 0.1};
    const double tol[] = {2e-3, 5e-4, 1e-4};
    for (int s = 0; s < 3; s++) {
        obs_camera cam = ortho_down(3.5, 3.5, 50, 2, 2);
        vol_rc_params p = vol_rc_params_default();
        p.shading = VOL_SHADING_EMISSION_ABSORPTION;
        p.early_termination = 1.0;
        p.step = steps[s];
        obs_image_f32 out[4];
        CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 4, 4, NULL, &p, out), ctx);
        CHECK_NEAR(obs_image_f32_row(&out[3], 1)[2], expect, tol[s]);
        vtu_free4(out);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A perspective eye inside the volume starts its rays at the near plane: alpha = 1 - 0.9^len with
 * len from t = znear to the box's exit. And a NaN voxel (TF: transparent) leaves the image finite
 * and the same with and without skipping. */
TEST(volume_raycast_eye_inside_and_nan_voxels)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 16, 16, 16, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {1, 1, 1, 0.1f}}, {1.0, {1, 1, 1, 0.1f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    obs_camera cam = obs_camera_look_at(obs_v3(7, 8, 6), obs_v3(9, 7, -3), obs_v3(0, 1, 0), 1.2f, 0.25f, 100.0f);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.early_termination = 1.0;
    obs_image_f32 out[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, 30, 20, NULL, &p, out), ctx);
    rast_params rp = rast_params_default();
    rp.width = 30;
    rp.height = 20;
    rast_view_constants vc;
    CHECK_OK(rast_view_constants_make(ctx, &rp, &cam, &vc), ctx);
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    for (int y = 0; y < 20; y++)
        for (int x = 0; x < 30; x++) {
            obs_dvec3 O, D;
            rast_pixel_ray(&vc, &cam, x + 0.5, y + 0.5, &O, &D);
            double t0, t1;
            CHECK(box_clip(lo, hi, O, D, &t0, &t1) && t0 < 0.0);
            double a = 1.0 - pow(0.9, (t1 - vc.znear) * sqrt(D.x * D.x + D.y * D.y + D.z * D.z));
            CHECK_NEAR(obs_image_f32_row(&out[3], y)[x], a, 2e-6);
        }
    vtu_free4(out);
    vol_grid_free(&g);

    const double sph[4] = {15.5, 15.5, 15.5, 10.0};
    CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_sphere, sph, &g), ctx);
    g.data[(20 * 32 + 16) * 32 + 16] = NAN;
    g.data[(2 * 32 + 3) * 32 + 4] = NAN; /* in empty space */
    vol_grid_update_range(&g);
    vol_tf_point sp3[3] = {{0.5, {0, 0, 0, 0}}, {0.75, {1, 0.5f, 0.2f, 0.1f}}, {1.0, {0.2f, 0.9f, 1, 0.4f}}};
    vol_tf stf = mk_tf(sp3, 3, 1.0);
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {-0.3, -0.8, -0.5}, {0, 0, 0}, {1, 1, 1}};
    obs_camera pc = obs_camera_look_at(obs_v3(45, 35, 60), obs_v3(15.5, 15.5, 18), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f);
    obs_image_f32 ref[4];
    p = vol_rc_params_default();
    p.shading = VOL_SHADING_PHONG;
    p.brick = 0;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &stf, &light, NULL, &pc, 40, 30, NULL, &p, ref), ctx);
    p.brick = 4;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &stf, &light, NULL, &pc, 40, 30, NULL, &p, out), ctx);
    CHECK(vtu_same4(ref, out));
    for (int c = 0; c < 4; c++)
        for (int y = 0; y < 30; y++)
            for (int x = 0; x < 40; x++)
                CHECK(isfinite(obs_image_f32_row(&out[c], y)[x]));
    vtu_free4(out);
    vtu_free4(ref);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- early termination, depth limit ------------------------------------------------------------ */

TEST(volume_raycast_early_termination_error_below_one_minus_threshold)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sph[4] = {15.5, 15.5, 15.5, 13.0};
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_sphere, sph, &g), ctx);
    vol_tf_point pts[3] = {{0.0, {0, 0, 0, 0}}, {0.5, {1, 0.5f, 0.2f, 0.05f}}, {1.0, {0.2f, 0.9f, 1, 0.2f}}};
    vol_tf tf = mk_tf(pts, 3, 1.0);
    obs_camera pc = obs_camera_look_at(obs_v3(50, 40, 60), obs_v3(15.5, 15.5, 15.5), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.background[0] = p.background[1] = p.background[2] = p.background[3] = 1.0f;
    p.early_termination = 1.0;
    obs_image_f32 full[4], cut[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &pc, 40, 40, NULL, &p, full), ctx);
    const double thr[] = {0.99, 0.9, 0.5};
    for (int i = 0; i < 3; i++) {
        p.early_termination = thr[i];
        vol_i_rc_stats st;
        CHECK_OK(vol_i_rc_raycast_stats(ctx, NULL, &g, &tf, NULL, NULL, &pc, 40, 40, NULL, &p, cut, &st), ctx);
        CHECK(st.rays_terminated > 0);
        double d = vtu_maxdiff4(full, cut);
        CHECK_MSG(d < 1.0 - thr[i], "threshold %g: max difference %.4g", thr[i], d);
        vtu_free4(cut);
    }
    vtu_free4(full);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A mesh plane at linear depth d inside a homogeneous box cuts each ray there exactly: alpha is the
 * box's portion in front of d, 1 - 0.9^(len(d) / ref). Orthographic and perspective. */
TEST(volume_raycast_depth_limit_cuts_the_ray_exactly)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 16, 16, 16, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {1, 1, 1, 0.1f}}, {1.0, {1, 1, 1, 0.1f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.early_termination = 1.0;
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    for (int persp = 0; persp < 2; persp++) {
        obs_camera cam = persp ? obs_camera_look_at(obs_v3(7, 8, 40), obs_v3(7.5, 7.5, 7.5), obs_v3(0, 1, 0), 0.5f, 0.1f,
                                                    200.0f)
                               : ortho_down(7.5, 7.5, 40, 10, 10);
        const int W = 21, H = 19;
        obs_image_f32 depth, out[4];
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
        /* depths: a tilted plane through the box, +inf on some pixels, in front of the box on others */
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float dv = (float)(30.0 + 0.37 * x + 0.21 * y);
                if (x == 3)
                    dv = INFINITY;
                if (x == 4)
                    dv = 10.0f; /* before the box */
                obs_image_f32_row(&depth, y)[x] = dv;
            }
        CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, W, H, &depth, &p, out), ctx);
        rast_params rp = rast_params_default();
        rp.width = W;
        rp.height = H;
        rast_view_constants vc;
        CHECK_OK(rast_view_constants_make(ctx, &rp, &cam, &vc), ctx);
        int cut = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                obs_dvec3 O, D;
                rast_pixel_ray(&vc, &cam, x + 0.5, y + 0.5, &O, &D);
                double t0, t1, a = 0.0;
                if (box_clip(lo, hi, O, D, &t0, &t1)) {
                    double dv = obs_image_f32_row(&depth, y)[x];
                    if (dv < t1) {
                        t1 = dv;
                        cut++;
                    }
                    if (t1 > t0)
                        a = 1.0 - pow(0.9, (t1 - t0) * sqrt(D.x * D.x + D.y * D.y + D.z * D.z));
                }
                CHECK_NEAR(obs_image_f32_row(&out[3], y)[x], a, 2e-6);
            }
        CHECK(cut > 50);
        vtu_free4(out);
        obs_image_f32_free(&depth);
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The hybrid scene: the rasterizer's own depth plane of a tilted quad cutting through a
 * homogeneous box stops each ray where the quad is: alpha = 1 - 0.9^(len), with len the world
 * length from the box's entry to the quad's analytic plane (or the box's exit). */
TEST(volume_raycast_rasterized_mesh_depth_lines_up_with_the_rays)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    float one = 1.0f;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(mk_grid(ctx, 16, 16, 16, sp, fill_const, &one, &g), ctx);
    vol_tf_point pts[2] = {{0.0, {1, 1, 1, 0.1f}}, {1.0, {1, 1, 1, 0.1f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    /* The quad: the plane z = 12 - 0.32 (x + 5), over x, y in [-5, 20]. */
    const float pos[12] = {-5, -5, 12, 20, -5, 4, 20, 20, 4, -5, 20, 12};
    const float nrm[12] = {0.3047f, 0, 0.9524f, 0.3047f, 0, 0.9524f, 0.3047f, 0, 0.9524f, 0.3047f, 0, 0.9524f};
    const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    obs_scene scene;
    tu_scene_one_mesh(&scene, pos, 4, nrm, idx, 2);
    const int W = 64, H = 48;
    for (int persp = 0; persp < 2; persp++) {
        obs_camera cam = persp ? obs_camera_look_at(obs_v3(9, 6, 40), obs_v3(7.5f, 7.5f, 7.5f), obs_v3(0, 1, 0), 0.6f,
                                                    0.5f, 100.0f)
                               : ortho_down(7.5, 7.5, 40, 12, 9);
        rast_params rp = rast_params_default();
        rp.width = W;
        rp.height = H;
        rp.outputs = RAST_OUT_DEPTH;
        rast_gbuffer gb;
        CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
        rast_view view = {cam};
        CHECK_OK(rast_render(ctx, NULL, &scene, &view, 1, &rp, &gb, NULL), ctx);
        vol_rc_params p = vol_rc_params_default();
        p.shading = VOL_SHADING_EMISSION_ABSORPTION;
        p.early_termination = 1.0;
        obs_image_f32 out[4];
        CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &cam, W, H, &gb.depth, &p, out), ctx);
        double lo[3], hi[3];
        vol_grid_bounds(&g, lo, hi);
        int cut = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                obs_dvec3 O, D;
                rast_pixel_ray(&gb.constants, &cam, x + 0.5, y + 0.5, &O, &D);
                /* The analytic plane: n.p = n.v0 with n = (0.32, 0, 1). */
                double nd = 0.32 * D.x + D.z, tp = INFINITY;
                if (nd != 0.0) {
                    double th = ((0.32 * -5.0 + 12.0) - (0.32 * O.x + O.z)) / nd;
                    double px = O.x + th * D.x, py = O.y + th * D.y;
                    if (th > 0.0 && px > -5.0 && px < 20.0 && py > -5.0 && py < 20.0)
                        tp = th;
                }
                double dz = obs_image_f32_row(&gb.depth, y)[x];
                double t0, t1, a = 0.0;
                if (box_clip(lo, hi, O, D, &t0, &t1)) {
                    if (tp < t1) {
                        t1 = tp;
                        cut++;
                        CHECK_NEAR(dz, tp, 1e-5 * tp);
                    }
                    if (t1 > t0)
                        a = 1.0 - pow(0.9, (t1 - t0) * sqrt(D.x * D.x + D.y * D.y + D.z * D.z));
                }
                CHECK_NEAR(obs_image_f32_row(&out[3], y)[x], a, 1e-5);
            }
        CHECK(cut > 200);
        vtu_free4(out);
        rast_gbuffer_free(&gb);
    }
    obs_scene_free(&scene);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- skipping ---------------------------------------------------------------------------------- */

static void check_skipping(obs_context *ctx, const vol_grid *g, const vol_tf *tf, const obs_camera *cam,
                           vol_shading shading)
{
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {-0.3, -0.8, -0.5}, {0, 0, 0}, {1, 0.9f, 0.8f}};
    vol_rc_params p = vol_rc_params_default();
    p.shading = shading;
    p.brick = 0;
    obs_image_f32 ref[4], out[4];
    vol_i_rc_stats s0, s1;
    CHECK_OK(vol_i_rc_raycast_stats(ctx, NULL, g, tf, &light, NULL, cam, 48, 40, NULL, &p, ref, &s0), ctx);
    CHECK_MSG(s0.samples_shaded > 1000, "only %lld shaded samples", (long long)s0.samples_shaded);
    const int bricks[] = {8, 4, 3, 5};
    for (int i = 0; i < 4; i++) {
        p.brick = bricks[i];
        CHECK_OK(vol_i_rc_raycast_stats(ctx, NULL, g, tf, &light, NULL, cam, 48, 40, NULL, &p, out, &s1), ctx);
        CHECK_MSG(vtu_same4(ref, out), "brick %d changes the image (max diff %.3g)", bricks[i], vtu_maxdiff4(ref, out));
        CHECK(s1.bricks_empty > 0);
        CHECK_MSG(s1.samples < s0.samples, "brick %d: %lld samples vs %lld without skipping", bricks[i],
                  (long long)s1.samples, (long long)s0.samples);
        CHECK_EQ_INT(s1.samples_shaded, s0.samples_shaded);
        CHECK(s1.samples_skipped > 0);
        vtu_free4(out);
    }
    vtu_free4(ref);
}

TEST(volume_raycast_skipping_keeps_the_image_and_reads_fewer_samples)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    /* The synthetic sphere (centred on the origin), TF transparent below 0.5 */
    CHECK_OK(vol_synth(ctx, "sphere", 32, &g), ctx);
    vol_grid_update_range(&g);
    vol_tf_point pts[3] = {{0.5, {0, 0, 0, 0}}, {0.75, {1, 0.5f, 0.2f, 0.1f}}, {1.0, {0.2f, 0.9f, 1, 0.4f}}};
    vol_tf tf = mk_tf(pts, 3, 1.0);
    obs_camera pc = obs_camera_look_at(obs_v3(30, 20, 45), obs_v3(0, 0, 2.5f), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f);
    check_skipping(ctx, &g, &tf, &pc, VOL_SHADING_EMISSION_ABSORPTION);
    check_skipping(ctx, &g, &tf, &pc, VOL_SHADING_PHONG);
    vol_grid_free(&g);
    /* Anisotropic spacing, own blobs */
    {
        const double sp[3] = {1, 1, 1.2};
        int n = 32;
        CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_blobs, &n, &g), ctx);
        vol_tf_point bp[3] = {{30.0, {0, 0, 0, 0}}, {120.0, {1, 0.3f, 0.1f, 0.3f}}, {255.0, {0.9f, 0.9f, 1, 0.8f}}};
        vol_tf btf = mk_tf(bp, 3, 1.0);
        obs_camera bc = obs_camera_look_at(obs_v3(-20, 45, 50), obs_v3(15.5, 15.5, 18), obs_v3(0, 1, 0), 0.8f, 0.1f,
                                           300.0f);
        check_skipping(ctx, &g, &btf, &bc, VOL_SHADING_PHONG);
        vol_grid_free(&g);
    }
    /* The synthetic bucky: its preset TF, and one with several transparent value ranges */
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_grid_update_range(&g);
    vol_tf preset;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &preset), ctx);
    obs_camera bc = obs_camera_look_at(obs_v3(-35, 30, 35), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f);
    check_skipping(ctx, &g, &preset, &bc, VOL_SHADING_PHONG);
    vol_tf_free(&preset);
    vol_tf_point bp[5] = {{40.0, {0, 0, 0, 0}},
                          {80.0, {1, 0.3f, 0.1f, 0.2f}},
                          {100.0, {0, 0, 0, 0}},
                          {180.0, {0, 0, 0, 0}},
                          {220.0, {0.9f, 0.9f, 1, 0.6f}}};
    vol_tf btf = mk_tf(bp, 5, 1.0);
    check_skipping(ctx, &g, &btf, &bc, VOL_SHADING_EMISSION_ABSORPTION);
    obs_camera oc = ortho_down(0, 0, 100, 18, 15);
    check_skipping(ctx, &g, &btf, &oc, VOL_SHADING_PHONG);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- Phong ------------------------------------------------------------------------------------- */

TEST(volume_raycast_phong_sphere_lit_side_brighter_and_gradient_radial)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    const double sph[4] = {15.5, 15.5, 15.5, 10.0};
    CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_sphere, sph, &g), ctx);
    /* The gradient at shell points is radial, pointing inwards (the value grows inwards). */
    for (int i = 0; i < 200; i++) {
        double th = 0.1 + 2.9 * (i / 200.0), ph = 0.7 * i;
        double r = 10.0 + 0.3 * sin(3.0 * i);
        double u[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
        double c[3] = {15.5 + r * u[0], 15.5 + r * u[1], 15.5 + r * u[2]};
        double gr[3];
        vol_i_rc_gradient(&g, c, gr);
        double gm = sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
        CHECK(gm > 0.1);
        double cosang = -(gr[0] * u[0] + gr[1] * u[1] + gr[2] * u[2]) / gm;
        CHECK_MSG(cosang > 0.97, "sample %d: gradient at %.3f of radial", i, cosang);
    }
    /* Anisotropic spacing: the gradient is in world units (a linear ramp 2 per voxel along z with
     * sz = 4 has d/dz = 0.5). */
    {
        vol_grid r;
        const double sp2[3] = {1, 1, 4};
        CHECK_OK(vol_grid_alloc(ctx, 5, 5, 5, sp2, &r), ctx);
        for (int k = 0; k < 5; k++)
            for (int j = 0; j < 5; j++)
                for (int i = 0; i < 5; i++)
                    r.data[(k * 5 + j) * 5 + i] = 2.0f * k + 0.5f * i;
        double c[3] = {2.0, 2.0, 2.0}, gr[3];
        vol_i_rc_gradient(&r, c, gr);
        CHECK_NEAR(gr[0], 0.5, 1e-9);
        CHECK_NEAR(gr[1], 0.0, 1e-9);
        CHECK_NEAR(gr[2], 0.5, 1e-9);
        vol_grid_free(&r);
    }
    /* Lit from +x (light travelling -x), seen along -z: the +x half of the disc is brighter. */
    vol_tf_point pts[2] = {{0.3, {0.8f, 0.8f, 0.8f, 0.0f}}, {1.0, {0.8f, 0.8f, 0.8f, 1.0f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {-1, 0, 0}, {0, 0, 0}, {1, 1, 1}};
    obs_camera cam = ortho_down(15.5, 15.5, 100, 16, 16);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_PHONG;
    obs_image_f32 out[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, &light, NULL, &cam, 32, 32, NULL, &p, out), ctx);
    double lit = 0.0, dark = 0.0;
    for (int y = 10; y < 22; y++)
        for (int x = 0; x < 16; x++) {
            dark += obs_image_f32_row(&out[0], y)[x];
            lit += obs_image_f32_row(&out[0], y)[31 - x];
        }
    CHECK_MSG(lit > 1.5 * dark, "lit side %.4g, shadowed side %.4g", lit, dark);
    /* Alpha does not depend on shading: left-right symmetric. */
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 16; x++)
            CHECK_NEAR(obs_image_f32_row(&out[3], y)[x], obs_image_f32_row(&out[3], y)[31 - x], 1e-6);
    vtu_free4(out);
    /* A point light at +x far away does the same. */
    vol_light pl = {OBS_LIGHT_POINT, {0, 0, 0}, {200, 15.5, 15.5}, {1, 1, 1}};
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, &pl, NULL, &cam, 32, 32, NULL, &p, out), ctx);
    double lit2 = 0.0, dark2 = 0.0;
    for (int y = 10; y < 22; y++)
        for (int x = 0; x < 16; x++) {
            dark2 += obs_image_f32_row(&out[0], y)[x];
            lit2 += obs_image_f32_row(&out[0], y)[31 - x];
        }
    CHECK(lit2 > 1.5 * dark2);
    vtu_free4(out);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- threads ----------------------------------------------------------------------------------- */

TEST(volume_raycast_identical_for_1_2_and_8_threads)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    int n = 32;
    CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_blobs, &n, &g), ctx);
    vol_tf_point bp[3] = {{30.0, {0, 0, 0, 0}}, {120.0, {1, 0.3f, 0.1f, 0.3f}}, {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 3, 1.0);
    vol_light light = {OBS_LIGHT_POINT, {0, 0, 0}, {40, 50, 30}, {1, 1, 1}};
    obs_camera pc = obs_camera_look_at(obs_v3(-20, 45, 50), obs_v3(15.5, 15.5, 15.5), obs_v3(0, 1, 0), 0.8f, 0.1f,
                                       300.0f);
    vol_lv_params lp = vol_lv_params_default();
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &light, &lp, &lv), ctx);
    /* A depth limit on half the image. */
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, 100, 70, &depth), ctx);
    for (int y = 0; y < 70; y++)
        for (int x = 0; x < 100; x++)
            obs_image_f32_row(&depth, y)[x] = x < 50 ? INFINITY : 62.0f + 0.1f * y;
    for (int mode = 0; mode < VOL_SHADING_COUNT; mode++) {
        vol_rc_params p = vol_rc_params_default();
        p.shading = (vol_shading)mode;
        obs_image_f32 ref[4], out[4];
        obs_pool *p1 = obs_pool_create(1);
        CHECK_OK(vol_raycast(ctx, p1, &g, &tf, &light, &lv, &pc, 100, 70, &depth, &p, ref), ctx);
        obs_pool_destroy(p1);
        const int threads[] = {2, 8};
        for (int i = 0; i < 2; i++) {
            obs_pool *pool = obs_pool_create(threads[i]);
            CHECK(pool != NULL);
            CHECK_OK(vol_raycast(ctx, pool, &g, &tf, &light, &lv, &pc, 100, 70, &depth, &p, out), ctx);
            obs_pool_destroy(pool);
            CHECK_MSG(vtu_same4(ref, out), "%s: %d threads differ from 1", vol_shading_name(p.shading), threads[i]);
            vtu_free4(out);
        }
        vtu_free4(ref);
    }
    obs_image_f32_free(&depth);
    vol_light_volume_free(&lv);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- light-volume shading ---------------------------------------------------------------------- */

/* With a constant light volume (l = 0.5, c = (1, 0.5, 0.25)) the light-volume image is the EA image
 * times Lc l c per channel (vol.h's product), alpha unchanged. */
TEST(volume_raycast_light_volume_mode_is_tf_times_light_times_l_times_c)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "sphere", 24, &g), ctx);
    vol_grid_update_range(&g);
    vol_tf_point pts[3] = {{0.3, {0, 0, 0, 0}}, {0.7, {1, 0.5f, 0.2f, 0.2f}}, {1.0, {0.2f, 0.9f, 1, 0.5f}}};
    vol_tf tf = mk_tf(pts, 3, 1.0);
    enum { N = 6 };
    static float lvl[N * N * N], c0[N * N * N], c1[N * N * N], c2[N * N * N];
    for (int i = 0; i < N * N * N; i++) {
        lvl[i] = 0.5f;
        c0[i] = 1.0f;
        c1[i] = 0.5f;
        c2[i] = 0.25f;
    }
    vol_light_volume lv;
    memset(&lv, 0, sizeof lv);
    lv.nx = lv.ny = lv.nz = N;
    lv.scale = 4;
    for (int a = 0; a < 3; a++) {
        lv.spacing[a] = 4.0;
        lv.origin[a] = -10.0;
    }
    lv.l = lvl;
    lv.c[0] = c0;
    lv.c[1] = c1;
    lv.c[2] = c2;
    lv.blend_weight = 1.0f;
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {0, -1, 0}, {0, 0, 0}, {0.8f, 1.0f, 2.0f}};
    obs_camera pc = obs_camera_look_at(obs_v3(20, 15, 30), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    obs_image_f32 ea[4], lvimg[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, NULL, NULL, &pc, 40, 30, NULL, &p, ea), ctx);
    p.shading = VOL_SHADING_LIGHT_VOLUME;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, &light, &lv, &pc, 40, 30, NULL, &p, lvimg), ctx);
    const double f[3] = {0.8 * 0.5 * 1.0, 1.0 * 0.5 * 0.5, 2.0 * 0.5 * 0.25};
    double amax = 0.0;
    for (int y = 0; y < 30; y++)
        for (int x = 0; x < 40; x++) {
            double a = obs_image_f32_row(&ea[3], y)[x];
            amax = fmax(amax, a);
            CHECK(obs_image_f32_row(&lvimg[3], y)[x] == (float)a);
            for (int c = 0; c < 3; c++)
                CHECK_NEAR(obs_image_f32_row(&lvimg[c], y)[x], f[c] * obs_image_f32_row(&ea[c], y)[x], 1e-6);
        }
    CHECK(amax > 0.3);
    vtu_free4(ea);
    vtu_free4(lvimg);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A built light volume on the sphere lit from +x: the +x half is brighter than the -x half (the
 * far side is in the sphere's own shadow), and skipping still changes nothing. */
TEST(volume_raycast_light_volume_sphere_lit_side_brighter)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "sphere", 32, &g), ctx);
    vol_grid_update_range(&g);
    vol_tf_point pts[2] = {{0.3, {0.8f, 0.8f, 0.8f, 0.0f}}, {1.0, {0.8f, 0.8f, 0.8f, 0.3f}}};
    vol_tf tf = mk_tf(pts, 2, 1.0);
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {-1, 0, 0}, {0, 0, 0}, {1, 1, 1}};
    vol_lv_params lp = vol_lv_params_default();
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &light, &lp, &lv), ctx);
    obs_camera cam = ortho_down(0, 0, 100, 16, 16);
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_LIGHT_VOLUME;
    obs_image_f32 out[4], out0[4];
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, &light, &lv, &cam, 32, 32, NULL, &p, out), ctx);
    double lit = 0.0, dark = 0.0;
    for (int y = 10; y < 22; y++)
        for (int x = 0; x < 16; x++) {
            dark += obs_image_f32_row(&out[0], y)[x];
            lit += obs_image_f32_row(&out[0], y)[31 - x];
        }
    CHECK_MSG(lit > 1.5 * dark, "lit side %.4g, shadowed side %.4g", lit, dark);
    p.brick = 0;
    CHECK_OK(vol_raycast(ctx, NULL, &g, &tf, &light, &lv, &cam, 32, 32, NULL, &p, out0), ctx);
    CHECK(vtu_same4(out, out0));
    vtu_free4(out);
    vtu_free4(out0);
    vol_light_volume_free(&lv);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* ---- the fast path's pieces, against the library's own functions ------------------------------- */

/* The ray caster's inlined TF (a forward segment scan for short lists, the binary search for long
 * ones) gives vol_tf_eval's bits: the presets and a 40-point TF, at the control points, next to
 * them (one ulp either side), beyond the ends, NaN and a dense sweep. */
TEST(volume_raycast_inlined_tf_is_vol_tf_eval_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    const char *names[] = {"ct-skin", "ct-bone", "mri", "bucky"};
    vol_tf_point many[40];
    for (int i = 0; i < 40; i++) {
        many[i].value = -3.0 + 0.37 * i + 0.01 * (i % 3);
        for (int c = 0; c < 4; c++)
            many[i].rgba[c] = (float)((i * (c + 3)) % 11) / 10.0f;
    }
    for (int t = 0; t < 5; t++) {
        vol_tf tf;
        if (t < 4) {
            CHECK_OK(vol_tf_preset(ctx, names[t], &tf), ctx);
        } else {
            tf = mk_tf(many, 40, 1.0);
        }
        double lo = tf.points[0].value, hi = tf.points[tf.count - 1].value;
        int bad = 0;
        long n = 0;
        for (int i = -1; i <= 200001 && !bad; i++) {
            double v[4];
            int nv = 1;
            if (i == -1) {
                v[0] = NAN;
            } else if (i == 200001) {
                v[0] = lo - 1e9;
                v[1] = hi + 1e9;
                nv = 2;
            } else {
                v[0] = (double)(float)(lo - 0.1 * (hi - lo) + 1.2 * (hi - lo) * i / 200000.0);
            }
            if (i >= 0 && i < tf.count) { /* the control points and their float neighbours */
                float f = (float)tf.points[i].value;
                v[0] = tf.points[i].value;
                v[1] = nextafterf(f, -INFINITY);
                v[2] = nextafterf(f, INFINITY);
                v[3] = f;
                nv = 4;
            }
            for (int k = 0; k < nv; k++, n++) {
                float a[4], b[4];
                vol_tf_eval(&tf, v[k], a);
                vol_i_rc_tf_eval(&tf, v[k], b);
                if (memcmp(a, b, sizeof a) != 0) {
                    CHECK_MSG(0, "TF %d: value %.17g: vol_tf_eval (%g %g %g %g) != inlined (%g %g %g %g)", t, v[k],
                              a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]);
                    bad = 1;
                    break;
                }
            }
        }
        CHECK(n > 200000);
        /* The march's shortcut: at or below vol_i_rc_zero_below the alpha is exactly 0. */
        double z = vol_i_rc_zero_below(&tf);
        CHECK((tf.points[0].rgba[3] == 0.0f) == (z > -INFINITY));
        if (z > -INFINITY) {
            for (int i = 0; i <= 100000; i++) {
                float f = (float)(z - (z - lo + 10.0) * (i / 100000.0)), a[4];
                if ((double)f > z)
                    continue;
                vol_tf_eval(&tf, f, a);
                CHECK_MSG(a[3] == 0.0f, "TF %d: alpha %g at %g <= %g", t, a[3], (double)f, z);
            }
            float a[4], zf = nextafterf((float)z, INFINITY);
            vol_tf_eval(&tf, (double)zf, a); /* just above: the first non-zero segment */
            CHECK(a[3] > 0.0f);
        }
        if (t < 4)
            vol_tf_free(&tf);
    }
    obs_context_destroy(ctx);
}

/* A prepared handle (the brick table made once) gives vol_raycast's bits for every shading, for two
 * cameras and a depth limit, reused across calls; its counters are vol_raycast's; a brick size
 * other than the prepared one is refused; bad arguments are refused. */
TEST(volume_raycast_prepared_handle_matches_vol_raycast_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1.2};
    int n = 32;
    CHECK_OK(mk_grid(ctx, 32, 32, 32, sp, fill_blobs, &n, &g), ctx);
    vol_tf_point bp[4] = {{30.0, {0, 0, 0, 0}},
                          {120.0, {1, 0.3f, 0.1f, 0.3f}},
                          {200.0, {0.5f, 0.6f, 0.2f, 0.5f}},
                          {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 4, 0.0);
    vol_light light = {OBS_LIGHT_DIRECTIONAL, {-0.3, -0.8, -0.5}, {0, 0, 0}, {1, 0.9f, 0.8f}};
    vol_lv_params lp = vol_lv_params_default();
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &light, &lp, &lv), ctx);
    obs_camera cams[2] = {
        obs_camera_look_at(obs_v3(-20, 45, 50), obs_v3(15.5, 15.5, 18), obs_v3(0, 1, 0), 0.8f, 0.1f, 300.0f),
        ortho_down(15.5, 15.5, 100, 20, 15)};
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &depth), ctx);
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++)
            obs_image_f32_row(&depth, y)[x] = x < 32 ? INFINITY : 70.0f + 0.2f * y;
    obs_pool *pool = obs_pool_create(2);
    vol_rc_params p = vol_rc_params_default();
    vol_rc_prepared *prep = NULL;
    CHECK_OK(vol_rc_prepare(ctx, pool, &g, &tf, &p, &prep), ctx);
    CHECK(prep != NULL);
    for (int rep = 0; rep < 2; rep++) {
        for (int c = 0; c < 2; c++) {
            for (int mode = 0; mode < VOL_SHADING_COUNT; mode++) {
                p.shading = (vol_shading)mode;
                p.step = rep ? 0.7 : 0.0; /* the step may change per call */
                const obs_image_f32 *dl = c ? NULL : &depth;
                obs_image_f32 ref[4], out[4];
                vol_i_rc_stats sr, sp2;
                CHECK_OK(vol_i_rc_raycast_stats(ctx, pool, &g, &tf, &light, &lv, &cams[c], 64, 48, dl, &p, ref, &sr),
                         ctx);
                CHECK_OK(vol_i_rc_raycast_prepared_stats(ctx, pool, prep, &light, &lv, &cams[c], 64, 48, dl, &p, out,
                                                         &sp2),
                         ctx);
                CHECK_MSG(vtu_same4(ref, out), "%s camera %d rep %d: prepared differs", vol_shading_name(p.shading), c,
                          rep);
                CHECK(memcmp(&sr, &sp2, sizeof sr) == 0);
                CHECK(sr.samples > 0 && sr.bricks > 0);
                vtu_free4(out);
                CHECK_OK(vol_raycast_prepared(ctx, pool, prep, &light, &lv, &cams[c], 64, 48, dl, &p, out), ctx);
                CHECK(vtu_same4(ref, out));
                vtu_free4(out);
                vtu_free4(ref);
            }
        }
    }
    /* refusals */
    obs_image_f32 out[4];
    p = vol_rc_params_default();
    p.shading = VOL_SHADING_EMISSION_ABSORPTION;
    p.brick = 4;
    CHECK(vol_raycast_prepared(ctx, pool, prep, &light, &lv, &cams[0], 64, 48, NULL, &p, out) ==
          OBS_STATUS_INVALID_ARGUMENT);
    CHECK(out[0].data == NULL);
    p.brick = 8;
    CHECK(vol_raycast_prepared(ctx, pool, NULL, &light, &lv, &cams[0], 64, 48, NULL, &p, out) ==
          OBS_STATUS_INVALID_ARGUMENT);
    CHECK(vol_raycast_prepared(ctx, pool, prep, &light, &lv, NULL, 64, 48, NULL, &p, out) ==
          OBS_STATUS_INVALID_ARGUMENT);
    vol_rc_prepared *bad = (vol_rc_prepared *)&p;
    CHECK(vol_rc_prepare(ctx, pool, NULL, &tf, &p, &bad) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(bad == NULL);
    CHECK(vol_rc_prepare(ctx, pool, &g, &tf, &p, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    p.brick = -1;
    CHECK(vol_rc_prepare(ctx, pool, &g, &tf, &p, &bad) == OBS_STATUS_INVALID_ARGUMENT);
    /* brick 0: no table; still the same bits */
    p.brick = 0;
    vol_rc_prepared *p0 = NULL;
    CHECK_OK(vol_rc_prepare(ctx, pool, &g, &tf, &p, &p0), ctx);
    obs_image_f32 ref[4];
    CHECK_OK(vol_raycast(ctx, pool, &g, &tf, &light, &lv, &cams[0], 64, 48, NULL, &p, ref), ctx);
    CHECK_OK(vol_raycast_prepared(ctx, pool, p0, &light, &lv, &cams[0], 64, 48, NULL, &p, out), ctx);
    CHECK(vtu_same4(ref, out));
    vtu_free4(ref);
    vtu_free4(out);
    vol_rc_prepared_free(p0);
    vol_rc_prepared_free(prep);
    vol_rc_prepared_free(NULL);
    obs_pool_destroy(pool);
    obs_image_f32_free(&depth);
    vol_light_volume_free(&lv);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The march's gradient (the centre's splits shared with the shifted samples) is vol_i_rc_gradient
 * bit for bit, inside, at the edges (clamping) and beyond them. */
TEST(volume_raycast_fast_gradient_is_the_reference_gradient_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.7, 1.0, 1.3};
    CHECK_OK(vol_grid_alloc(ctx, 7, 5, 6, sp, &g), ctx);
    uint32_t r = 777u;
    for (int i = 0; i < 7 * 5 * 6; i++) {
        r = r * 1664525u + 1013904223u;
        g.data[i] = (float)((r >> 8) * (1.0 / 16777216.0) * 2000.0 - 1000.0);
    }
    const double special[] = {-3.0, -1.0, -0.5, 0.0, 0.25, 1.0, 1.5, 3.5, 4.0, 4.999999, 5.0, 5.5, 6.0, 7.0, 100.0};
    const int ns = (int)(sizeof special / sizeof special[0]);
    for (int i = 0; i < ns * ns * ns + 200000; i++) {
        double q[3];
        if (i < ns * ns * ns) {
            q[0] = special[i % ns];
            q[1] = special[(i / ns) % ns];
            q[2] = special[i / (ns * ns)];
        } else {
            for (int a = 0; a < 3; a++) {
                r = r * 1664525u + 1013904223u;
                q[a] = (r >> 8) * (1.0 / 16777216.0) * 10.0 - 2.0;
            }
        }
        double u[3], v[3];
        vol_i_rc_gradient(&g, q, u);
        vol_i_rc_gradient_fast(&g, q, v);
        if (memcmp(u, v, sizeof u) != 0) {
            CHECK_MSG(0, "at (%.17g, %.17g, %.17g): (%g %g %g) vs (%g %g %g)", q[0], q[1], q[2], u[0], u[1], u[2],
                      v[0], v[1], v[2]);
            break;
        }
    }
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The march's full-step opacity correction is vol_tf_alpha_correct bit for bit: the half step (its
 * own quotient with the rounding guard) on 2^24 alphas spread over every binade of (0, 1) plus the
 * edges, and other step ratios (the libm form). */
TEST(volume_raycast_full_step_alpha_correction_is_vol_tf_alpha_correct_bit_for_bit)
{
    const double steps[][2] = {{0.5, 1.0}, {0.478515595, 0.95703119}, {0.25, 1.0}, {1.0, 1.0}, {0.7, 0.3}};
    uint32_t r = 4242u;
    for (int s = 0; s < 5; s++) {
        const double h = steps[s][0], ref = steps[s][1];
        const long count = s < 2 ? (1L << 24) : (1L << 18);
        long bad = 0;
        for (long i = 0; i < count + 8 && !bad; i++) {
            float a;
            if (i < 8) {
                const float edge[8] = {0.0f, -0.0f, 1.0f, 0x1p-149f, 0x1p-126f, 1.0f - 0x1p-24f, 0.5f, NAN};
                a = edge[i];
            } else {
                /* uniform in the bits of (0, 1): every binade gets its share */
                r = r * 1664525u + 1013904223u;
                uint32_t bits = r % 0x3f800000u;
                memcpy(&a, &bits, sizeof a);
            }
            float x = vol_tf_alpha_correct(a, h, ref), y = vol_i_rc_alpha_full_step(a, h, ref);
            if (memcmp(&x, &y, sizeof x) != 0) {
                CHECK_MSG(0, "h %g ref %g alpha %.9g: %.9g vs %.9g", h, ref, (double)a, (double)x, (double)y);
                bad = 1;
            }
        }
    }
}

/* ---- the fast mode (VOL_RC_FAST) --------------------------------------------------------------- */

/* The fast mode (the pre-corrected TF table) stays within VOL_RC_TEST_FAST_MAX of the exact mode on
 * the blobs (EA and Phong, perspective, every pixel and channel; the bound is the measured maximum
 * with a margin, docs/volume/raycast.md "Fast mode"), differs from it (it is a different path), is
 * the same byte for byte for 1, 2 and 8 threads, and an unknown precision is refused. */
#define VOL_RC_TEST_FAST_MAX 1e-4 /* measured 9.1e-6 (EA and Phong), 2026-12-02 */
TEST(volume_raycast_fast_mode_close_to_exact_and_same_for_1_2_and_8_threads)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    int n = 48;
    CHECK_OK(mk_grid(ctx, 48, 48, 48, sp, fill_blobs, &n, &g), ctx);
    vol_tf_point bp[4] = {{30.0, {0, 0, 0, 0}},
                          {77.3, {0.8f, 0.4f, 0.2f, 0.05f}},
                          {120.0, {1, 0.3f, 0.1f, 0.3f}},
                          {255.0, {0.9f, 0.9f, 1, 0.8f}}};
    vol_tf tf = mk_tf(bp, 4, 1.0);
    vol_light light = {OBS_LIGHT_POINT, {0, 0, 0}, {60, 70, 50}, {1, 1, 1}};
    obs_camera pc = obs_camera_look_at(obs_v3(-30, 65, 75), obs_v3(23.5f, 23.5f, 23.5f), obs_v3(0, 1, 0), 0.8f, 0.1f,
                                       400.0f);
    const vol_shading modes[2] = {VOL_SHADING_EMISSION_ABSORPTION, VOL_SHADING_PHONG};
    for (int m = 0; m < 2; m++) {
        vol_rc_params pe = vol_rc_params_default();
        pe.shading = modes[m];
        vol_rc_params pf = pe;
        pf.precision = VOL_RC_FAST;
        obs_image_f32 ex[4], fa[4], out[4];
        obs_pool *p1 = obs_pool_create(1);
        CHECK_OK(vol_raycast(ctx, p1, &g, &tf, &light, NULL, &pc, 96, 64, NULL, &pe, ex), ctx);
        CHECK_OK(vol_raycast(ctx, p1, &g, &tf, &light, NULL, &pc, 96, 64, NULL, &pf, fa), ctx);
        obs_pool_destroy(p1);
        double md = vtu_maxdiff4(ex, fa), se = 0.0, cnt = 0.0;
        for (int c = 0; c < 4; c++)
            for (int y = 0; y < 64; y++)
                for (int x = 0; x < 96; x++) {
                    double d = (double)obs_image_f32_row(&ex[c], y)[x] - (double)obs_image_f32_row(&fa[c], y)[x];
                    se += d * d;
                    cnt += 1.0;
                }
        printf("  fast vs exact, %s: max %.3g, rmse %.3g\n", vol_shading_name(pe.shading), md, sqrt(se / cnt));
        CHECK_MSG(md <= VOL_RC_TEST_FAST_MAX, "%s: fast mode max diff %g > %g", vol_shading_name(pe.shading), md,
                  VOL_RC_TEST_FAST_MAX);
        CHECK_MSG(md > 0.0, "%s: the fast mode gave the exact image (is it in use?)", vol_shading_name(pe.shading));
        const int threads[] = {2, 8};
        for (int i = 0; i < 2; i++) {
            obs_pool *pool = obs_pool_create(threads[i]);
            CHECK(pool != NULL);
            CHECK_OK(vol_raycast(ctx, pool, &g, &tf, &light, NULL, &pc, 96, 64, NULL, &pf, out), ctx);
            obs_pool_destroy(pool);
            CHECK_MSG(vtu_same4(fa, out), "fast %s: %d threads differ from 1", vol_shading_name(pe.shading), threads[i]);
            vtu_free4(out);
        }
        vtu_free4(ex);
        vtu_free4(fa);
    }
    vol_rc_params bad = vol_rc_params_default();
    bad.shading = VOL_SHADING_EMISSION_ABSORPTION;
    bad.precision = (vol_rc_precision)7;
    obs_image_f32 o[4];
    CHECK(vol_raycast(ctx, NULL, &g, &tf, &light, NULL, &pc, 8, 8, NULL, &bad, o) == OBS_STATUS_INVALID_ARGUMENT);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}
