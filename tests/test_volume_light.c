/* Ropinski's light volume (src/volume/vol_light.c) against analytic transmittance and against the
 * exact march of src/truth/truth_volume.c; limits, continuity, scales, threads, refusals.
 * The bounds asserted here are the measured errors rounded up (docs/volume/light.md, "Measured").
 * Extinction is vol.h's convention, sigma_t = -kappa ln(1 - alpha_TF) / ref_step: with the
 * two-point TFs below (alpha linear in the data value) sigma_t is NOT linear in the trilinear value,
 * so the light volume's trapezoid is exact only where sigma_t is constant along the step
 * (homogeneous media); across a one-voxel ramp it carries a discretisation error, measured here. */
#include "test.h"
#include "volume_test_util.h"

#include "core/obs.h"
#include "truth/truth.h"
#include "volume/vol.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A two-point TF: value 0 -> (rgb, alpha0), value 1 -> (rgb, alpha1); linear between, so alpha_TF
 * of a trilinear value is itself trilinear (sigma_t = -ln(1 - alpha_TF) is not). ref_step 0 (one
 * voxel). alpha0 = alpha1: a homogeneous medium over the data's range. */
static int make_tf(vol_tf *tf, float alpha0, float alpha1, const float rgb[3])
{
    memset(tf, 0, sizeof *tf);
    tf->points = (vol_tf_point *)calloc(2, sizeof *tf->points);
    if (!tf->points)
        return 0;
    tf->count = 2;
    snprintf(tf->name, sizeof tf->name, "test");
    tf->points[0].value = 0.0;
    tf->points[1].value = 1.0;
    for (int c = 0; c < 3; c++)
        tf->points[0].rgba[c] = tf->points[1].rgba[c] = rgb[c];
    tf->points[0].rgba[3] = alpha0;
    tf->points[1].rgba[3] = alpha1;
    return 1;
}

static int lv_all_finite_unit(const vol_light_volume *lv)
{
    size_t n = (size_t)lv->nx * lv->ny * lv->nz;
    for (size_t i = 0; i < n; i++) {
        if (!(lv->l[i] >= 0.0f && lv->l[i] <= 1.0f))
            return 0;
        for (int c = 0; c < 3; c++)
            if (!(lv->c[c][i] >= 0.0f && lv->c[c][i] <= 1.0f + 1e-6f))
                return 0;
    }
    return 1;
}

/* The slab's optical depth in voxels from voxel k (light travelling +z) as the light volume's
 * trapezoid sees it, in units of the slab's sigma_t: 1 on [k0, k1], the one-voxel trilinear ramps
 * either side counted as 1/2 (the mean of their end values); the face is half a voxel below voxel 0.
 * Exact for a sigma_t linear in the data value (the mean of a linear ramp). */
static double slab_depth(int k, int k0, int k1)
{
    double d = (double)k - k0 + 0.5;
    double N = (double)(k1 - k0 + 1);
    return d < 0.0 ? 0.0 : (d > N ? N : d);
}

/* The exact optical depth, in voxels, of the same slab under vol.h's convention with the TF alpha
 * linear from 0 to a over the data's [0, 1] and ref_step one voxel: sigma_t(v) = -ln(1 - a v), so
 * inside the slab sigma_1 = -ln(1 - a), and each one-voxel ramp (v from 0 to 1) contributes
 *   integral_0^1 -ln(1 - a v) dv = 1 + (1 - a) ln(1 - a) / a
 * (substitute u = 1 - a v: (1/a) integral_{1-a}^1 -ln u du). The light volume's trapezoid counts a
 * ramp as sigma_1 / 2, which is larger (-ln(1 - a v) is convex in v): the post-classification
 * discretisation error that vol.h's convention brings (docs/volume/light.md, "Measured errors"). */
static double slab_depth_exact(int k, int k0, int k1, double a)
{
    const double s1 = -log1p(-a), ramp = 1.0 + (1.0 - a) * log1p(-a) / a;
    if (k < k0)
        return 0.0;
    if (k <= k1)
        return ramp + (double)(k - k0) * s1;
    return 2.0 * ramp + (double)(k1 - k0) * s1;
}

/* The slab's data with a TF constant over the data's range [0, 1]: a homogeneous medium filling
 * the box (no ramps), sigma_1 = -ln(1 - 0.3) per voxel. The light volume is then exact where its
 * fetches stay inside the slices: along the axis everywhere, along a diagonal wherever the ray
 * towards the light leaves by the lit face (the issue: "a homogeneous slab gives transmittance
 * exp(-sigma d) exactly, with the light along an axis and along a diagonal"). */
TEST(volume_light_homogeneous_slab_is_exact)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "slab", 32, &g), ctx);
    const float white[3] = {1, 1, 1};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.3f, 0.3f, white));
    const double s1 = -log1p(-(double)0.3f); /* per voxel (ref_step 0: one voxel) */
    const int n = 32;
    vol_light Ls[3] = {vtu_dir_light(0, 0, 1), vtu_dir_light(0, 0, -1), vtu_dir_light(0.6, 0.0, 0.8)};
    for (int t = 0; t < 3; t++) {
        vol_lv_params p = vol_lv_params_default();
        p.blend_second = 0; /* the F1 pass of the diagonal reads the border where rays leave by z */
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &lv), ctx);
        CHECK(lv_all_finite_unit(&lv));
        CHECK_EQ_INT(lv.face0, t == 1 ? 5 : 4);
        truth_volume_params tp = truth_volume_params_default();
        truth_volume_error_stats st;
        float *T = NULL;
        CHECK_OK(truth_volume_light_error(ctx, NULL, &g, &tf, &Ls[t], &tp, &lv, &T, NULL, &st), ctx);
        double maxa = 0.0, maxm = 0.0, maxam = 0.0;
        int cnt = 0;
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double d; /* path length in voxels to the lit face */
                    if (t < 2) {
                        d = (t == 0 ? k : n - 1 - k) + 0.5;
                    } else {
                        /* p = x - (0.75, 0, 1) voxels: voxel i of slice k fetches i - 1 and i of
                         * slice k - 1, so its domain of dependence reaches i - k on slice 0 and
                         * stays clear of the border (exact values only) iff i >= k. */
                        if (i < k)
                            continue;
                        d = ((double)k + 0.5) / 0.8;
                    }
                    size_t idx = ((size_t)k * n + j) * n + i;
                    double Ta = exp(-s1 * d);
                    maxa = fmax(maxa, fabs(lv.l[idx] - Ta));
                    maxm = fmax(maxm, fabs(lv.l[idx] - (double)T[idx]));
                    maxam = fmax(maxam, fabs((double)T[idx] - Ta));
                    cnt++;
                }
        obs_aligned_free(T);
        printf("homogeneous slab, light %d (%d voxels): max |l - exp(-sigma d)| %.3g, |l - march| %.3g, "
               "|march - exp(-sigma d)| %.3g; all voxels vs march: max %.3g mean %.3g\n",
               t, cnt, maxa, maxm, maxam, st.max_abs, st.mean_abs);
        CHECK_EQ_INT(cnt, t < 2 ? n * n * n : n * n * (n + 1) / 2);
        CHECK(maxa <= 2e-6);
        CHECK(maxm <= 2e-6);
        if (t < 2)
            CHECK(st.max_abs <= 2e-6);
        vol_light_volume_free(&lv);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_truth_march_matches_slab_analytic)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "slab", 32, &g), ctx);
    const float white[3] = {1, 1, 1};
    const double a = (double)0.3f, s1 = -log1p(-a);
    truth_volume_params tp = truth_volume_params_default();
    const int n = 32, k0 = n / 4, k1 = 3 * n / 4 - 1;
    vol_light L = vtu_dir_light(0.6, 0.0, 0.8);
    /* Homogeneous (TF constant): exact at every voxel of a plane, the path ending at the -z face
     * or at the -x face, whichever comes first. */
    vol_tf tf;
    CHECK(make_tf(&tf, 0.3f, 0.3f, white));
    double maxh = 0.0;
    for (int k = 0; k < n; k++)
        for (int i = 0; i < n; i++) {
            double x[3] = {g.origin[0] + i * g.spacing[0], g.origin[1] + 5 * g.spacing[1], g.origin[2] + k * g.spacing[2]};
            double d = fmin(((double)k + 0.5) / 0.8, ((double)i + 0.5) / 0.6);
            double T = truth_volume_transmittance_at(&g, &tf, &L, &tp, x);
            maxh = fmax(maxh, fabs(T - exp(-s1 * d)));
        }
    vol_tf_free(&tf);
    /* The ramped slab (TF alpha 0 -> 0.3 over the data's [0, 1]): the depth is the vertical one over
     * cos(gamma) where the ray leaves by the bottom face (x far enough from the -x face); with
     * vol.h's convention sigma_t is not linear across the ramps, so the march's trapezoid (h = 1/16
     * voxel) has an O(h^2) error there. */
    CHECK(make_tf(&tf, 0.0f, 0.3f, white));
    double maxr = 0.0;
    for (int k = 0; k < n; k++)
        for (int i = 0; i < n; i++) {
            if ((double)i - 0.75 * ((double)k + 0.5) < 0.0)
                continue;
            double x[3] = {g.origin[0] + i * g.spacing[0], g.origin[1] + 5 * g.spacing[1], g.origin[2] + k * g.spacing[2]};
            double T = truth_volume_transmittance_at(&g, &tf, &L, &tp, x);
            maxr = fmax(maxr, fabs(T - exp(-slab_depth_exact(k, k0, k1, a) / 0.8)));
        }
    /* Halving the step quarters the ramp error: a discretisation error of order h^2, not a bias. */
    tp.step_fraction = 1.0 / 32.0;
    double maxr2 = 0.0;
    for (int k = 0; k < n; k++)
        for (int i = 0; i < n; i++) {
            if ((double)i - 0.75 * ((double)k + 0.5) < 0.0)
                continue;
            double x[3] = {g.origin[0] + i * g.spacing[0], g.origin[1] + 5 * g.spacing[1], g.origin[2] + k * g.spacing[2]};
            double T = truth_volume_transmittance_at(&g, &tf, &L, &tp, x);
            maxr2 = fmax(maxr2, fabs(T - exp(-slab_depth_exact(k, k0, k1, a) / 0.8)));
        }
    printf("march vs analytic, diagonal: homogeneous max %.3g; ramped slab max %.3g at h = 1/16, %.3g at h = 1/32\n",
           maxh, maxr, maxr2);
    CHECK(maxh <= 1e-12);
    CHECK(maxr <= 3e-5);
    CHECK(maxr2 <= maxr / 3.5 && maxr2 >= maxr / 4.5);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* The ramped slab (TF alpha 0 -> 0.3): the light volume's trapezoid counts each one-voxel ramp as
 * sigma_1 / 2 (slab_depth), the exact integral is 1 + (1 - a) ln(1 - a) / a (slab_depth_exact).
 * Along the axis the light volume is exactly its own discretisation, exp(-sigma_1 slab_depth), and
 * its error against the exact T is the difference of the two, which the test computes and bounds. */
TEST(volume_light_ramped_slab_within_bound)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "slab", 32, &g), ctx);
    const float white[3] = {1, 1, 1};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f, 0.3f, white));
    const double a = (double)0.3f, s1 = -log1p(-a);
    const int n = 32, k0 = n / 4, k1 = 3 * n / 4 - 1;
    double disc = 0.0; /* max over k of |exp(-s1 slab_depth) - exp(-slab_depth_exact)|: the ramp error */
    for (int k = 0; k < n; k++)
        disc = fmax(disc, fabs(exp(-s1 * slab_depth(k, k0, k1)) - exp(-slab_depth_exact(k, k0, k1, a))));
    printf("ramped slab: the trapezoid's ramp error, analytic: max %.4g\n", disc);
    for (int sgn = -1; sgn <= 1; sgn += 2) {
        vol_lv_params p = vol_lv_params_default();
        vol_light L = vtu_dir_light(0, 0, sgn);
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
        CHECK_EQ_INT(lv.face0, sgn > 0 ? 4 : 5);
        CHECK(lv.blend_weight == 1.0f);
        double maxd = 0.0, maxe = 0.0;
        for (int k = 0; k < n; k++) {
            int kk = sgn > 0 ? k : n - 1 - k; /* index counted from the lit face */
            int a0 = sgn > 0 ? k0 : n - 1 - k1, a1 = sgn > 0 ? k1 : n - 1 - k0;
            double Td = exp(-s1 * slab_depth(kk, a0, a1)), Te = exp(-slab_depth_exact(kk, a0, a1, a));
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double l = lv.l[((size_t)k * n + j) * n + i];
                    maxd = fmax(maxd, fabs(l - Td));
                    maxe = fmax(maxe, fabs(l - Te));
                }
        }
        truth_volume_params tp = truth_volume_params_default();
        truth_volume_error_stats st;
        CHECK_OK(truth_volume_light_error(ctx, NULL, &g, &tf, &L, &tp, &lv, NULL, NULL, &st), ctx);
        printf("ramped slab axis sgn %d: max |l - exp(-sigma_1 slab_depth)| %.3g; |l - exact| %.4g; vs march: "
               "max %.4g mean %.3g bias %.3g\n",
               sgn, maxd, maxe, st.max_abs, st.mean_abs, st.mean_signed);
        CHECK(maxd <= 2e-6);                   /* exactly its own trapezoid */
        CHECK(fabs(maxe - disc) <= 2e-6);      /* so its error is the ramp error, no more */
        CHECK(fabs(st.max_abs - disc) <= 5e-5); /* the march agrees (its own O(h^2) in the ramps) */
        CHECK(st.max_abs <= 0.0095);
        CHECK(st.mean_signed < 0.0);           /* darker: the trapezoid of a convex sigma_t(v) */
        vol_light_volume_free(&lv);
    }
    vol_light L = vtu_dir_light(0.6, 0.0, 0.8);
    for (int blend = 0; blend <= 1; blend++) {
        vol_lv_params p = vol_lv_params_default();
        p.blend_second = blend;
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
        CHECK(lv_all_finite_unit(&lv));
        CHECK_EQ_INT(lv.face0, 4);
        /* Interior voxels (the ray leaves by the bottom face): against the light volume's own
         * discretisation exp(-sigma_1 slab_depth / cos gamma) and against the exact depth. */
        double maxd = 0.0, maxe = 0.0;
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    if ((double)i - 0.75 * ((double)k + 0.5) < 2.0)
                        continue;
                    double l = lv.l[((size_t)k * n + j) * n + i];
                    maxd = fmax(maxd, fabs(l - exp(-s1 * slab_depth(k, k0, k1) / 0.8)));
                    maxe = fmax(maxe, fabs(l - exp(-slab_depth_exact(k, k0, k1, a) / 0.8)));
                }
        truth_volume_params tp = truth_volume_params_default();
        truth_volume_error_stats st;
        CHECK_OK(truth_volume_light_error(ctx, NULL, &g, &tf, &L, &tp, &lv, NULL, NULL, &st), ctx);
        printf("ramped slab diagonal (0.6,0,0.8) blend %d (w %.4f): interior max |l - own trapezoid| %.3g, "
               "|l - exact| %.4g; all voxels vs march: max %.4g mean %.4g rmse %.4g bias %.3g\n",
               blend, lv.blend_weight, maxd, maxe, st.max_abs, st.mean_abs, st.rmse, st.mean_signed);
        if (!blend) {
            CHECK(maxd <= 1e-5);       /* laterally constant: the bilinear fetch is exact inside */
            CHECK(maxe <= 0.012);      /* the ramp error over a longer path */
            CHECK(st.max_abs <= 0.17); /* the edge where rays leave by the -x face */
            CHECK(st.mean_abs <= 0.006);
        } else {
            CHECK(st.max_abs <= 0.14);
            CHECK(st.mean_abs <= 0.006);
        }
        vol_light_volume_free(&lv);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

static void error_on(const char *name, int n, const char *tfname, vol_light L, int blend, double bound_max,
                     double bound_mean)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, name, n, &g), ctx);
    vol_tf tf;
    if (tfname) {
        CHECK_OK(vol_tf_preset(ctx, tfname, &tf), ctx);
    } else {
        const float rgb[3] = {0.9f, 0.6f, 0.3f};
        CHECK(make_tf(&tf, 0.0f, 0.25f, rgb));
    }
    vol_lv_params p = vol_lv_params_default();
    p.blend_second = blend;
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
    CHECK(lv_all_finite_unit(&lv));
    truth_volume_params tp = truth_volume_params_default();
    tp.step_fraction = 1.0 / 8.0; /* still on every kink of an axis-aligned ray; halves the test's time */
    truth_volume_error_stats st;
    float *T = NULL;
    CHECK_OK(truth_volume_light_error(ctx, NULL, &g, &tf, &L, &tp, &lv, &T, NULL, &st), ctx);
    printf("  argmax voxel (%d %d %d): l %.4f T %.4f\n", (int)(st.argmax % lv.nx), (int)(st.argmax / lv.nx % lv.ny),
           (int)(st.argmax / lv.nx / lv.ny), lv.l[st.argmax], T[st.argmax]);
    obs_aligned_free(T);
    printf("%s %d^3, %s light (%g %g %g), blend %d (faces %d/%d, w %.4f): |l - T| max %.4g mean %.4g rmse %.4g "
           "bias %.4g\n",
           name, n, L.type == OBS_LIGHT_POINT ? "point" : "directional",
           L.type == OBS_LIGHT_POINT ? L.position[0] : L.direction[0],
           L.type == OBS_LIGHT_POINT ? L.position[1] : L.direction[1],
           L.type == OBS_LIGHT_POINT ? L.position[2] : L.direction[2], blend, lv.face0, lv.face1, lv.blend_weight,
           st.max_abs, st.mean_abs, st.rmse, st.mean_signed);
    CHECK(st.max_abs <= bound_max);
    CHECK(st.mean_abs <= bound_mean);
    vol_light_volume_free(&lv);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_sphere_error_within_bound)
{
    /* Along +z the only error is the post-classification ramp error: the sphere's one-voxel edge
     * (value linear in r) through sigma_t(v) = -ln(1 - 0.25 v), convex, so the trapezoid over an
     * edge cell overestimates the extinction (bias < 0); the rest adds the bilinear diffusion. */
    error_on("sphere", 40, NULL, vtu_dir_light(0, 0, 1), 1, 0.006, 2e-4);
    if (test_failed())
        return;
    error_on("sphere", 40, NULL, vtu_dir_light(0.3, -0.5, 0.8), 0, 0.4, 0.02);
    if (test_failed())
        return;
    error_on("sphere", 40, NULL, vtu_dir_light(0.3, -0.5, 0.8), 1, 0.38, 0.016);
    if (test_failed())
        return;
    error_on("sphere", 40, NULL, vtu_point_light(-30.0, 20.0, 70.0), 1, 0.28, 0.013);
}

TEST(volume_light_bucky_error_within_bound)
{
    error_on("bucky", 32, "bucky", vtu_dir_light(0, 0, 1), 1, 0.09, 0.007);
    if (test_failed())
        return;
    error_on("bucky", 32, "bucky", vtu_dir_light(0.3, -0.5, 0.8), 0, 0.65, 0.075);
    if (test_failed())
        return;
    error_on("bucky", 32, "bucky", vtu_dir_light(0.3, -0.5, 0.8), 1, 0.58, 0.064);
}

TEST(volume_light_point_light_inside_is_finite_and_near_exact)
{
    /* Near the sphere's centre (the grid is centred on the origin), and off-centre exactly on a slice plane
     * (x = -5.5 is a voxel centre plane). */
    error_on("sphere", 32, NULL, vtu_point_light(0.25, -0.4, 0.1), 1, 0.13, 0.0065);
    if (test_failed())
        return;
    error_on("sphere", 32, NULL, vtu_point_light(-5.5, 4.25, -3.0), 1, 0.17, 0.0075);
    if (test_failed())
        return;
    error_on("sphere", 32, NULL, vtu_point_light(-5.5, 4.25, -3.0), 0, 0.19, 0.0098);
}

TEST(volume_light_one_voxel_thick_volume)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(vol_grid_alloc(ctx, 16, 12, 1, sp, &g), ctx);
    for (int i = 0; i < 16 * 12; i++)
        g.data[i] = 1.0f;
    vol_grid_update_range(&g);
    const float rgb[3] = {0.5f, 0.5f, 0.5f};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f, 0.4f, rgb));
    vol_lv_params p = vol_lv_params_default();
    /* Along z: half a voxel of sigma_t = -ln(1 - 0.4) (a homogeneous medium) between the centre and
     * the face: l = (1 - 0.4)^(1/2). */
    vol_light L = vtu_dir_light(0, 0, 1);
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
    CHECK(lv_all_finite_unit(&lv));
    for (int i = 0; i < 16 * 12; i++)
        CHECK_NEAR(lv.l[i], exp(0.5 * log1p(-(double)0.4f)), 1e-6);
    vol_light_volume_free(&lv);
    /* Diagonal and in-plane lights, a point light in the plane: finite, in [0, 1]. */
    vol_light Ls[3] = {vtu_dir_light(0.5, 0.3, 0.8), vtu_dir_light(1, 0.2, 0.01), vtu_point_light(7.0, 5.0, 0.0)};
    for (int t = 0; t < 3; t++) {
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &lv), ctx);
        CHECK(lv_all_finite_unit(&lv));
        truth_volume_params tp = truth_volume_params_default();
        truth_volume_error_stats st;
        CHECK_OK(truth_volume_light_error(ctx, NULL, &g, &tf, &Ls[t], &tp, &lv, NULL, NULL, &st), ctx);
        printf("1-voxel-thick, light %d: faces %d/%d, |l - T| max %.4g mean %.4g\n", t, lv.face0, lv.face1, st.max_abs,
               st.mean_abs);
        CHECK(st.max_abs <= 0.5);
        vol_light_volume_free(&lv);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_empty_tf_lights_everything)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g), ctx);
    const float rgb[3] = {0.2f, 0.7f, 0.4f};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f, 0.0f, rgb));
    vol_light Ls[3] = {vtu_dir_light(0.3, -0.5, 0.8), vtu_point_light(40, -5, 3), vtu_point_light(-0.7, 0.0, 2.3)};
    for (int t = 0; t < 3; t++) {
        vol_lv_params p = vol_lv_params_default();
        p.scale = t == 1 ? 2 : 1;
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &lv), ctx);
        size_t n = (size_t)lv.nx * lv.ny * lv.nz;
        for (size_t i = 0; i < n; i++) {
            CHECK_MSG(lv.l[i] == 1.0f, "light %d voxel %zu: l = %.9g", t, i, lv.l[i]);
            for (int c = 0; c < 3; c++)
                CHECK_MSG(lv.c[c][i] == 1.0f, "light %d voxel %zu: c = %.9g", t, i, lv.c[c][i]);
        }
        vol_light_volume_free(&lv);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_opaque_volume_is_dark_beyond_first_slice)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(vol_grid_alloc(ctx, 16, 16, 16, sp, &g), ctx);
    for (int i = 0; i < 16 * 16 * 16; i++)
        g.data[i] = 1.0f;
    vol_grid_update_range(&g);
    const float rgb[3] = {0.8f, 0.4f, 0.2f};
    vol_tf tf;
    CHECK(make_tf(&tf, 1.0f, 1.0f, rgb));
    /* alpha_TF = 1 everywhere with the default kappa = 1. vol_sigma_from_alpha clamps alpha to
     * 1 - 2^-24, so the medium is not opaque but 24 ln 2 = 16.6 per voxel (ref_step 0: one voxel):
     * transmittance 2^-24 = 6.0e-8 per voxel of path (vol.h). The claim, precisely: every voxel has
     * l <= 2^-12 (each propagation step is at least one voxel long, ds >= 1, what it fetches is
     * <= 1, and the trapezoid counts at least half the step's medium: exp(-ds sigma_t / 2) even
     * where the fetch reads the border's sigma_t = 0) and l > 0 on the lit face's slice. Beyond
     * that slice, where no fetch of l and sigma_t reads the border, l <= 2^-24 and c = c_TF to
     * within 2^-24 (c = tau c_bar + (1 - tau) c_TF). Along the axis no fetch reads the border, and
     * m slices beyond the lit one l = 2^-(12 + 24 m): a float 0 from m = 6 on (2^-156 is below the
     * smallest subnormal). For the oblique light (ds = 1.077 voxels, p = x + (-0.22, -1, +0.33)
     * voxels) the fetch reads the border at i = 0 and k = 15: there the light does enter through
     * the side faces after less than a voxel of medium, and l reaches 4.5e-7. */
    vol_lv_params p = vol_lv_params_default();
    CHECK(p.kappa == 1.0);
    const double t1 = ldexp(1.0, -24);
    vol_light Ls[2] = {vtu_dir_light(0, -1, 0), vtu_dir_light(0.2, 0.9, -0.3)};
    for (int t = 0; t < 2; t++) {
        vol_light_volume lv;
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &lv), ctx);
        CHECK(lv_all_finite_unit(&lv));
        int first = t == 0 ? 15 : 0; /* the lit face's slice along y */
        double maxl = 0.0, maxc = 0.0, maxe = 0.0;
        for (int k = 0; k < 16; k++)
            for (int j = 0; j < 16; j++)
                for (int i = 0; i < 16; i++) {
                    size_t idx = ((size_t)k * 16 + j) * 16 + i;
                    CHECK_MSG(lv.l[idx] <= ldexp(1.0, -12) * (1.0 + 1e-5), "light %d voxel (%d %d %d): l = %g", t,
                              i, j, k, lv.l[idx]);
                    if (j == first) {
                        CHECK_MSG(lv.l[idx] > 0.0f, "light %d voxel (%d %d %d): l = 0", t, i, j, k);
                        continue;
                    }
                    if (t == 1 && (i == 0 || k == 15)) {
                        maxe = fmax(maxe, lv.l[idx]);
                        continue; /* the fetch reads the border (see above) */
                    }
                    CHECK_MSG(lv.l[idx] <= t1 * (1.0 + 1e-5), "light %d voxel (%d %d %d): l = %g", t, i, j, k,
                              lv.l[idx]);
                    maxl = fmax(maxl, lv.l[idx]);
                    if (t == 0) {
                        int m = 15 - j;
                        if (m >= 6)
                            CHECK_MSG(lv.l[idx] == 0.0f, "voxel (%d %d %d): l = %g", i, j, k, lv.l[idx]);
                        else
                            CHECK_NEAR(lv.l[idx] / ldexp(1.0, -(12 + 24 * m)), 1.0, 1e-4);
                    }
                    for (int c = 0; c < 3; c++) {
                        maxc = fmax(maxc, fabs(lv.c[c][idx] - rgb[c]));
                        CHECK_NEAR(lv.c[c][idx], rgb[c], t1 + 6e-8); /* + one float ulp at 0.8 */
                    }
                }
        printf("alpha 1, light %d: beyond the lit slice max l %.3g (%.3g where the fetch reads the border), "
               "max |c - c_TF| %.3g\n", t, maxl, maxe, maxc);
        vol_light_volume_free(&lv);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

static double lv_maxdiff(const vol_light_volume *a, const vol_light_volume *b)
{
    size_t n = (size_t)a->nx * a->ny * a->nz;
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a->l[i] - b->l[i]);
        for (int c = 0; c < 3; c++)
            d = fmax(d, fabs((double)a->c[c][i] - b->c[c][i]));
        if (d > m)
            m = d;
    }
    return m;
}

TEST(volume_light_blend_continuous_across_face_switch)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    /* Sweep the light in the xz plane through 45 degrees, where F0 switches from -x to -z. */
    const double deg[] = {44.0, 44.9, 44.99, 45.01, 45.1, 46.0};
    const int N = (int)(sizeof deg / sizeof deg[0]);
    double jump[2] = {0, 0}, step_before[2] = {0, 0};
    for (int blend = 0; blend <= 1; blend++) {
        vol_light_volume lv[6];
        vol_lv_params p = vol_lv_params_default();
        p.blend_second = blend;
        for (int s = 0; s < N; s++) {
            double a = deg[s] * OBS_PI / 180.0;
            vol_light L = vtu_dir_light(cos(a), 0.0, sin(a));
            CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv[s]), ctx);
            if (blend) {
                double w = lv[s].blend_weight;
                CHECK_NEAR(w, 1.0 - 2.0 * (deg[s] < 45.0 ? deg[s] : 90.0 - deg[s]) / 180.0, 1e-6);
            }
        }
        CHECK_EQ_INT(lv[2].face0, 0);
        CHECK_EQ_INT(lv[3].face0, 4);
        jump[blend] = lv_maxdiff(&lv[2], &lv[3]);      /* across the switch, 0.02 deg apart */
        step_before[blend] = lv_maxdiff(&lv[1], &lv[2]); /* 0.09 deg apart, same faces */
        for (int s = 1; s < N; s++)
            printf("blend %d: %.2f -> %.2f deg: max change %.4g (w %.4f -> %.4f)\n", blend, deg[s - 1], deg[s],
                   lv_maxdiff(&lv[s - 1], &lv[s]), lv[s - 1].blend_weight, lv[s].blend_weight);
        for (int s = 0; s < N; s++)
            vol_light_volume_free(&lv[s]);
    }
    /* Without the blend the volume jumps where F0 switches; with it the change over 0.02 deg is of
     * the order of the change over 0.09 deg within one face pair. */
    printf("jump over 0.02 deg at the switch: %.4g without the blend, %.4g with it; 0.09 deg before it: %.4g\n",
           jump[0], jump[1], step_before[1]);
    double rate = step_before[1] * (0.02 / 0.09); /* the change expected over 0.02 deg at that rate */
    CHECK(jump[1] <= 0.01);
    CHECK(jump[1] <= 2.0 * rate + 1e-3);
    CHECK(jump[0] > 2.0 * rate + 1e-3); /* the check above would catch a missing blend */
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_scales_agree_on_smooth_data)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    const int n = 64;
    CHECK_OK(vol_grid_alloc(ctx, n, n, n, sp, &g), ctx);
    /* A smooth Gaussian blob. */
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double dx = i - 30.0, dy = j - 33.0, dz = k - 31.0, s = 12.0;
                g.data[((size_t)k * n + j) * n + i] = (float)exp(-(dx * dx + dy * dy + dz * dz) / (2 * s * s));
            }
    vol_grid_update_range(&g);
    const float rgb[3] = {0.9f, 0.5f, 0.2f};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.0f, 0.15f, rgb));
    vol_light L = vtu_dir_light(0.3, -0.5, 0.8);
    vol_light_volume lv[3];
    const int scales[3] = {1, 2, 4};
    for (int s = 0; s < 3; s++) {
        vol_lv_params p = vol_lv_params_default();
        p.scale = scales[s];
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv[s]), ctx);
        CHECK_EQ_INT(lv[s].nx, n / scales[s]);
        CHECK(lv_all_finite_unit(&lv[s]));
    }
    /* Compare at the scale-4 volume's voxel centres (away from the outermost ones). */
    double md[2] = {0, 0}, mean[2] = {0, 0};
    int cnt = 0;
    for (int k = 1; k < lv[2].nz - 1; k++)
        for (int j = 1; j < lv[2].ny - 1; j++)
            for (int i = 1; i < lv[2].nx - 1; i++) {
                double x[3] = {lv[2].origin[0] + i * lv[2].spacing[0], lv[2].origin[1] + j * lv[2].spacing[1],
                               lv[2].origin[2] + k * lv[2].spacing[2]};
                float l1, l2, l4;
                vol_light_volume_sample(&lv[0], x, &l1, NULL);
                vol_light_volume_sample(&lv[1], x, &l2, NULL);
                vol_light_volume_sample(&lv[2], x, &l4, NULL);
                md[0] = fmax(md[0], fabs(l2 - l1));
                md[1] = fmax(md[1], fabs(l4 - l1));
                mean[0] += fabs(l2 - l1);
                mean[1] += fabs(l4 - l1);
                cnt++;
            }
    printf("scale 2 vs 1: max %.4g mean %.4g; scale 4 vs 1: max %.4g mean %.4g\n", md[0], mean[0] / cnt, md[1],
           mean[1] / cnt);
    CHECK(md[0] <= 0.03);
    CHECK(md[1] <= 0.06);
    for (int s = 0; s < 3; s++)
        vol_light_volume_free(&lv[s]);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_identical_for_1_2_8_threads)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_light Ls[2] = {vtu_dir_light(0.3, -0.5, 0.8), vtu_point_light(-3.8, 1.0, 4.4)};
    const int threads[3] = {1, 2, 8};
    for (int t = 0; t < 2; t++) {
        vol_light_volume lv[3];
        for (int s = 0; s < 3; s++) {
            obs_pool *pool = obs_pool_create(threads[s]);
            CHECK(pool);
            vol_lv_params p = vol_lv_params_default();
            CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &Ls[t], &p, &lv[s]), ctx);
            obs_pool_destroy(pool);
        }
        size_t bytes = (size_t)lv[0].nx * lv[0].ny * lv[0].nz * sizeof(float);
        for (int s = 1; s < 3; s++) {
            CHECK(memcmp(lv[0].l, lv[s].l, bytes) == 0);
            for (int c = 0; c < 3; c++)
                CHECK(memcmp(lv[0].c[c], lv[s].c[c], bytes) == 0);
        }
        for (int s = 0; s < 3; s++)
            vol_light_volume_free(&lv[s]);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_bad_params_refused)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "sphere", 8, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_light L = vtu_dir_light(0, 0, 1);
    vol_light_volume lv;
    vol_lv_params p = vol_lv_params_default();
    CHECK_EQ_INT(vol_lv_params_validate(ctx, &p), OBS_STATUS_OK);
    p.scale = 3;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(lv.l == NULL);
    const double cones[4] = {0.0, 90.0, -5.0, NAN};
    for (int i = 0; i < 4; i++) {
        p = vol_lv_params_default();
        p.cone_angle_deg = cones[i];
        CHECK_EQ_INT(vol_lv_params_validate(ctx, &p), OBS_STATUS_INVALID_ARGUMENT);
        CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    }
    p = vol_lv_params_default();
    p.kappa = NAN;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    p.kappa = -1.0;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    p = vol_lv_params_default();
    p.eye_pass = 2;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    p = vol_lv_params_default();
    vol_light S = L;
    S.type = OBS_LIGHT_SPOT;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &S, &p, &lv), OBS_STATUS_UNSUPPORTED);
    vol_light Z = L;
    Z.direction[0] = Z.direction[1] = Z.direction[2] = 0.0;
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &Z, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    vol_light Pn = vtu_point_light(NAN, 0, 0);
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, &g, &tf, &Pn, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_light_volume_build(ctx, NULL, NULL, &tf, &L, &p, &lv), OBS_STATUS_INVALID_ARGUMENT);
    truth_volume_params tp = truth_volume_params_default();
    tp.step_fraction = 0.0;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
    CHECK_EQ_INT(truth_volume_light_error(ctx, NULL, &g, &tf, &L, &tp, &lv, NULL, NULL, NULL),
                 OBS_STATUS_INVALID_ARGUMENT);
    tp = truth_volume_params_default();
    CHECK_EQ_INT(truth_volume_light_error(ctx, NULL, &g, &tf, &S, &tp, &lv, NULL, NULL, NULL), OBS_STATUS_UNSUPPORTED);
    vol_light_volume_free(&lv);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_sample_is_trilinear)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "sphere", 16, &g), ctx);
    vol_tf tf;
    const float rgb[3] = {0.9f, 0.6f, 0.3f};
    CHECK(make_tf(&tf, 0.0f, 0.3f, rgb));
    vol_light L = vtu_dir_light(0.2, 0.3, 0.9);
    vol_lv_params p = vol_lv_params_default();
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &L, &p, &lv), ctx);
    /* At a voxel centre: the voxel's values; halfway between two along x: their mean. */
    size_t i0 = ((size_t)5 * 16 + 6) * 16 + 7;
    double x[3] = {lv.origin[0] + 7 * lv.spacing[0], lv.origin[1] + 6 * lv.spacing[1], lv.origin[2] + 5 * lv.spacing[2]};
    float l, c[3];
    vol_light_volume_sample(&lv, x, &l, c);
    CHECK(l == lv.l[i0]);
    CHECK(c[1] == lv.c[1][i0]);
    x[0] += 0.5 * lv.spacing[0];
    vol_light_volume_sample(&lv, x, &l, c);
    CHECK_NEAR(l, 0.5 * (lv.l[i0] + lv.l[i0 + 1]), 1e-6);
    CHECK_NEAR(c[2], 0.5 * (lv.c[2][i0] + lv.c[2][i0 + 1]), 1e-6);
    vol_light_volume_free(&lv);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_kernel_path_matches_per_tap_path)
{
    /* Directional lights use one gathered kernel per pass (vol_light.c, lv_kernel_init);
     * OBS_LV_PER_TAP=1 forces the per-tap reference (OBS_ISA=scalar did before the AVX2 path). Same sums, other rounding: agree to 1e-5. */
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_light Ls[3] = {vtu_dir_light(0, 0, 1), vtu_dir_light(0.3, -0.5, 0.8), vtu_dir_light(-0.7, 0.2, 0.1)};
    const double cones[3] = {45.0, 20.0, 70.0};
    for (int t = 0; t < 3; t++) {
        vol_lv_params p = vol_lv_params_default();
        p.cone_angle_deg = cones[t];
        p.scale = t == 2 ? 2 : 1;
        vol_light_volume a, b;
        unsetenv("OBS_LV_PER_TAP");
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &a), ctx);
        setenv("OBS_LV_PER_TAP", "1", 1);
        CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[t], &p, &b), ctx);
        unsetenv("OBS_LV_PER_TAP");
        double d = lv_maxdiff(&a, &b);
        printf("light %d, cone %g: kernel vs per-tap max diff %.3g\n", t, cones[t], d);
        CHECK(d <= 1e-5);
        vol_light_volume_free(&a);
        vol_light_volume_free(&b);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_avx2_matches_scalar_bit_for_bit)
{
    /* The row kernels (vol_light_internal.h): the AVX2 forms perform the scalar forms' operations
     * lane by lane, so the default build (AVX2 where the CPU has it) and OBS_ISA=scalar give the
     * same bytes: volumes of odd and even sizes (8-voxel blocks and scalar tails), anisotropic
     * spacing, directional lights along each axis both ways and oblique, point lights outside and
     * inside, scales 1, 2, 4, blend on and off, three cones. Without AVX2 both runs are scalar. */
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    CHECK(pool);
    const char *names[3] = {"bucky", "sphere", "box"};
    const int sizes[3] = {26, 21, 17};
    vol_light Ls[10] = {vtu_dir_light(0, 0, 1),         vtu_dir_light(0, 0, -1),        vtu_dir_light(1, 0, 0),
                        vtu_dir_light(0, -1, 0),        vtu_dir_light(0.3, -0.5, 0.8),  vtu_dir_light(-0.7, 0.2, 0.1),
                        vtu_dir_light(-0.4, -0.7, -0.6), vtu_point_light(-40.0, 15.0, 50.0), vtu_point_light(1.0, -2.0, 0.5),
                        vtu_dir_light(0.02, 0.05, -1)};
    const float rgb[3] = {0.9f, 0.6f, 0.3f};
    int cases = 0;
    for (int v = 0; v < 3; v++) {
        vol_grid g;
        CHECK_OK(vol_synth(ctx, names[v], sizes[v], &g), ctx);
        vol_tf tf;
        if (v == 0) {
            CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
        } else {
            CHECK(make_tf(&tf, 0.05f, 0.4f, rgb));
            g.spacing[1] = v == 1 ? 0.8 : 1.0;
            g.spacing[2] = v == 1 ? 1.3 : 1.0;
        }
        for (int l = 0; l < 10; l++)
            for (int s = 0; s < 3; s++)
                for (int b = 0; b < 2; b++) {
                    vol_lv_params p = vol_lv_params_default();
                    p.scale = 1 << s;
                    p.blend_second = b;
                    p.cone_angle_deg = (l + s) % 3 == 0 ? 45.0 : ((l + s) % 3 == 1 ? 20.0 : 70.0);
                    vol_light_volume a, c;
                    unsetenv("OBS_ISA");
                    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &Ls[l], &p, &a), ctx);
                    setenv("OBS_ISA", "scalar", 1);
                    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &Ls[l], &p, &c), ctx);
                    unsetenv("OBS_ISA");
                    size_t bytes = (size_t)a.nx * a.ny * a.nz * sizeof(float);
                    int same = memcmp(a.l, c.l, bytes) == 0;
                    for (int ch = 0; ch < 3; ch++)
                        same = same && memcmp(a.c[ch], c.c[ch], bytes) == 0;
                    if (!same)
                        printf("differ: volume %s, light %d, scale %d, blend %d\n", names[v], l, p.scale, b);
                    CHECK(same);
                    cases++;
                    vol_light_volume_free(&a);
                    vol_light_volume_free(&c);
                }
        vol_tf_free(&tf);
        vol_grid_free(&g);
    }
    printf("%d cases identical\n", cases);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_light_kernel_span_bounds_on_thin_slices_and_small_cones)
{
    /* The kernel path's span per row (vol_light.c lv_row) is bounded by where the 2x2 and the
     * cone's kernels lie inside the slice; with a small cone in the second face's pass (|p - x| > 1
     * texel: the kernel wholly to one side of x) or slices narrower than the offset, those bounds
     * pass the row's end and must be clipped to it (a heap overflow before: found by AddressSanitizer
     * on exactly these cases). Checked: finite values in [0, 1], AVX2 and scalar byte for byte, and
     * the kernel path against the per-tap path (OBS_LV_PER_TAP=1) within its rounding bound. */
    obs_context *ctx = obs_context_create();
    const int dims[3][3] = {{19, 14, 21}, {3, 2, 9}, {1, 12, 16}};
    const double sps[3][3] = {{1, 1, 1}, {1, 2.5, 0.4}, {0.3, 1, 1}};
    const vol_light Ls[3] = {vtu_dir_light(0.8, 0, 0.6), vtu_dir_light(0.7, 0.7, 0.1), vtu_dir_light(0.1, -0.9, 0.42)};
    const float rgb[3] = {0.2f, 0.5f, 0.9f};
    vol_tf tf;
    CHECK(make_tf(&tf, 0.05f, 0.6f, rgb));
    for (int v = 0; v < 3; v++) {
        vol_grid g;
        CHECK_OK(vol_grid_alloc(ctx, dims[v][0], dims[v][1], dims[v][2], sps[v], &g), ctx);
        size_t n = (size_t)g.nx * g.ny * g.nz;
        for (size_t i = 0; i < n; i++)
            g.data[i] = (float)((i * 2654435761u) % 1000u) / 1000.0f;
        vol_grid_update_range(&g);
        for (int l = 0; l < 3; l++)
            for (int c = 0; c < 2; c++) {
                vol_lv_params p = vol_lv_params_default();
                p.cone_angle_deg = c == 0 ? 1.0 : 5.0;
                p.blend_second = 1;
                vol_light_volume a, b, t;
                unsetenv("OBS_ISA");
                CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[l], &p, &a), ctx);
                setenv("OBS_ISA", "scalar", 1);
                CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[l], &p, &b), ctx);
                unsetenv("OBS_ISA");
                setenv("OBS_LV_PER_TAP", "1", 1);
                CHECK_OK(vol_light_volume_build(ctx, NULL, &g, &tf, &Ls[l], &p, &t), ctx);
                unsetenv("OBS_LV_PER_TAP");
                CHECK(lv_all_finite_unit(&a));
                size_t bytes = (size_t)a.nx * a.ny * a.nz * sizeof(float);
                CHECK(memcmp(a.l, b.l, bytes) == 0);
                for (int ch = 0; ch < 3; ch++)
                    CHECK(memcmp(a.c[ch], b.c[ch], bytes) == 0);
                CHECK(lv_maxdiff(&a, &t) <= 1e-5);
                vol_light_volume_free(&a);
                vol_light_volume_free(&b);
                vol_light_volume_free(&t);
            }
        vol_grid_free(&g);
    }
    vol_tf_free(&tf);
    obs_context_destroy(ctx);
}
