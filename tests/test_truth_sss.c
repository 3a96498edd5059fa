/* test_truth_sss.c: the SSS ground truth (src/truth/truth_sss.c; docs/sss/truth.md).
 * Exact references: Chandrasekhar's H-function for the semi-infinite isotropic medium
 * [Chandrasekhar60], and the plane integral of the double-precision S_d by radial quadrature. */
#include "scene_util.h"
#include "sss_truth_test_util.h"
#include "test.h"

#include "core/obs.h"
#include "raster/raster.h"
#include "sss/sss.h"
#include "truth/truth.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- scenes ----------------------------------------------------------------------------------- */


/* A square [-L, L]^2 at height z, normal +z (counter-clockwise seen from +z). */
static void add_square(obs_scene *s, const char *name, double L, double z, int32_t material)
{
    double p[12] = {-L, -L, z, L, -L, z, L, L, z, -L, L, z};
    uint32_t i[6] = {0, 1, 2, 0, 2, 3};
    tu_add_mesh(s, name, p, 4, i, 2, material);
}




static obs_status run_sss(stu_run *R, obs_pool *pool, const truth_sss_params *p, truth_sss_result *res)
{
    return truth_sss_render(R->ctx, pool, R->ts, &R->scene, &R->mats, &R->cam, &R->gb, p, res);
}

static float px(const obs_image_f32 *im, int x, int y) { return obs_image_f32_row(im, y)[x]; }

static sss_material grey_material(double albedo, double eta)
{
    sss_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "grey%.2f", albedo);
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = albedo;
        m.sigma_a[c] = 1.0 - albedo;
    }
    m.g = 0.0;
    m.eta = eta;
    return m;
}

/* ---- Chandrasekhar's H-function for isotropic scattering, albedo a ----------------------------- */

/* Gauss-Legendre nodes and weights on [0, 1] (Newton on P_n). */
static void gauss_legendre01(int n, double *x, double *w)
{
    for (int i = 0; i < n; i++) {
        double z = cos(OBS_PI * (i + 0.75) / (n + 0.5)), pp = 1.0;
        for (int it = 0; it < 100; it++) {
            double p1 = 1.0, p2 = 0.0;
            for (int j = 1; j <= n; j++) {
                double p3 = p2;
                p2 = p1;
                p1 = ((2.0 * j - 1.0) * z * p2 - (j - 1.0) * p3) / j;
            }
            pp = n * (z * p1 - p2) / (z * z - 1.0);
            double dz = p1 / pp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = 0.5 * (1.0 - z);
        w[i] = 1.0 / ((1.0 - z * z) * pp * pp);
    }
}

/* H(mu) from 1/H(mu) = sqrt(1 - a) + (a/2) Int_0^1 mu' H(mu') / (mu + mu') dmu' [Chandrasekhar60,
 * ch. V, eq. (the "alternative form" of the H-equation for the characteristic function a/2)],
 * iterated to a fixed point on Gauss-Legendre nodes (Nystrom), then evaluated at mu. */
#define HN 96
static double h_function(double a, double mu)
{
    double x[HN], w[HN], H[HN];
    gauss_legendre01(HN, x, w);
    for (int i = 0; i < HN; i++)
        H[i] = 1.0;
    for (int it = 0; it < 20000; it++) {
        double change = 0.0;
        for (int i = 0; i < HN; i++) {
            double s = 0.0;
            for (int j = 0; j < HN; j++)
                s += w[j] * x[j] * H[j] / (x[i] + x[j]);
            double h = 1.0 / (sqrt(1.0 - a) + 0.5 * a * s);
            change = fmax(change, fabs(h - H[i]));
            H[i] = h;
        }
        if (change < 1e-14)
            break;
    }
    double s = 0.0;
    for (int j = 0; j < HN; j++)
        s += w[j] * x[j] * H[j] / (mu + x[j]);
    return 1.0 / (sqrt(1.0 - a) + 0.5 * a * s);
}

TEST(truth_sss_h_function_matches_chandrasekhars_table)
{
    /* H(1) = 2.9078 for conservative isotropic scattering (Chandrasekhar's table), and the exact
     * zeroth moment Int_0^1 H dmu = (2/a)(1 - sqrt(1 - a)) [Chandrasekhar60, ch. V] */
    CHECK_NEAR(h_function(1.0, 1.0), 2.9078, 2e-4);
    double x[64], w[64];
    gauss_legendre01(64, x, w);
    const double as[3] = {0.5, 0.9, 0.99};
    for (int k = 0; k < 3; k++) {
        double m0 = 0.0;
        for (int i = 0; i < 64; i++)
            m0 += w[i] * h_function(as[k], x[i]);
        CHECK_NEAR(m0, 2.0 / as[k] * (1.0 - sqrt(1.0 - as[k])), 1e-6);
    }
}

/* ---- the random walk against the H-function ---------------------------------------------------- */

TEST(truth_sss_walk_slab_reflectance_matches_h_function)
{
    const double albedo[3] = {0.5, 0.9, 0.99};
    const int64_t count[3] = {400000, 200000, 80000};
    for (int k = 0; k < 3; k++) {
        stu_run R;
        memset(&R, 0, sizeof R);
        obs_scene_init(&R.scene);
        tu_add_box(&R.scene, "slab", 150.0, 150.0, -1);
        sss_material m = grey_material(albedo[k], 1.0);
        CHECK_MSG(stu_run_setup(&R, &m, 1.0, 10.0, 1.0f, 2), "setup: %s", obs_context_last_error(R.ctx));
        double xi[3] = {0, 0, 0}, ni[3] = {0, 0, 1}, d[3] = {0, 0, -1}, r = 0, se = 0;
        double t0 = obs_time_now();
        CHECK_OK(truth_sss_walk_reflectance(R.ctx, R.ts, &R.scene, &R.mats, 0, xi, ni, d, 0, count[k], 7, &r, &se),
                 R.ctx);
        double exact = 1.0 - h_function(albedo[k], 1.0) * sqrt(1.0 - albedo[k]);
        printf("slab eta=1 a=%.2f: walk R = %.5f +- %.5f, H-function %.5f, (walk-exact)/se = %+.2f, %lld photons %.2fs\n",
               albedo[k], r, se, exact, (r - exact) / se, (long long)count[k], obs_time_now() - t0);
        CHECK_MSG(fabs(r - exact) <= 3.0 * se, "a=%.2f: %.5f vs %.5f (se %.5f)", albedo[k], r, exact, se);
        /* eta = 1.3: the standard dipole's closed form is an approximation; report, assert loosely */
        sss_material m2 = grey_material(albedo[k], 1.3);
        sss_constants c2;
        CHECK_OK(sss_constants_make(R.ctx, &m2, 1.0, &c2), R.ctx);
        R.mats.none = &c2;
        double r2 = 0, se2 = 0;
        CHECK_OK(truth_sss_walk_reflectance(R.ctx, R.ts, &R.scene, &R.mats, 0, xi, ni, d, 0, count[k], 7, &r2, &se2),
                 R.ctx);
        double dip = sss_stddipole_total_rd(albedo[k], 1.3);
        printf("slab eta=1.3 a=%.2f: walk R = %.5f +- %.5f, standard dipole R_d %.5f\n", albedo[k], r2, se2, dip);
        CHECK_MSG(fabs(r2 - dip) < 0.12, "eta 1.3, a=%.2f: walk %.4f vs dipole %.4f", albedo[k], r2, dip);
        CHECK(r2 < r); /* internal reflection gives absorption more chances */
        stu_run_free(&R);
    }
}

/* The pixel estimator (collision estimator onto the patch) on the slab under uniform light at
 * normal incidence, seen at normal exitance: L = a E H(1)^2 / (8 pi) [Chandrasekhar60]
 * (reflected intensity (a F / 4) mu0 H(mu) H(mu0) / (mu + mu0), E = pi F mu0). Uniform light: no
 * patch bias, so the estimate must agree within 3 bars. */
TEST(truth_sss_walk_pixel_radiance_matches_h_function)
{
    stu_run R;
    memset(&R, 0, sizeof R);
    obs_scene_init(&R.scene);
    tu_add_box(&R.scene, "slab", 25.0, 25.0, -1);
    tu_add_light(&R.scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(1, 1, 1), 2.0f);
    const double a = 0.9;
    sss_material m = grey_material(a, 1.0);
    CHECK_MSG(stu_run_setup(&R, &m, 1.0, 10.0, 1e-3f, 2), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.estimator = TRUTH_SSS_RANDOM_WALK;
    p.patch_radius = 1.0;
    p.batch = 65536;
    p.min_samples = p.max_samples = 65536 * 64;
    obs_limits lim = *obs_context_limits(R.ctx);
    lim.max_samples = p.max_samples;
    obs_context_set_limits(R.ctx, &lim);
    truth_sss_result res;
    double t0 = obs_time_now();
    CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
    double H1 = h_function(a, 1.0), exact = a * 2.0 * H1 * H1 / (8.0 * OBS_PI);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 2; x++) {
            double L = px(&res.radiance[0], x, y), se = px(&res.std_error[0], x, y);
            printf("slab pixel (%d,%d): L = %.5f +- %.5f, exact %.5f, (L-exact)/se = %+.2f\n", x, y, L, se, exact,
                   (L - exact) / se);
            CHECK_MSG(fabs(L - exact) <= 3.0 * se, "pixel %d,%d: %.5f vs %.5f (se %.5f)", x, y, L, exact, se);
        }
    printf("  %llu candidates, %llu accepted, %llu rays, %llu events, lost %llu, %.2fs\n",
           (unsigned long long)res.stats.candidates, (unsigned long long)res.stats.accepted,
           (unsigned long long)res.stats.rays, (unsigned long long)res.stats.walk_events,
           (unsigned long long)res.stats.walks_lost, obs_time_now() - t0);
    CHECK_EQ_INT(res.stats.walks_lost, 0);
    truth_sss_result_free(&res);
    stu_run_free(&R);
}

/* ---- the brute force against the plane integral ------------------------------------------------ */

/* Int over the square [-L, L]^2 (x_o at its centre) of S_d at normal incidence, which is radial:
 * Int_0^{L sqrt2} S(r) r theta(r) dr, theta = 2 pi (r < L), 2 pi - 8 acos(L / r) beyond.
 * Composite 8-point Gauss-Legendre on geometric intervals. */
static double sd_radial(const sss_constants *c, sss_model model, int ch, double r)
{
    double xi[3] = {r, 0, 0}, n[3] = {0, 0, 1}, xo[3] = {0, 0, 0};
    return sss_sd(c, model, ch, xi, n, n, xo, n);
}

static double plane_integral(const sss_constants *c, sss_model model, int ch, double L)
{
    double gx[8], gw[8];
    gauss_legendre01(8, gx, gw);
    double sum = 0.0;
    const int N = 4000;
    double r0 = 0.0;
    for (int i = 0; i <= N; i++) {
        double r1 = i == 0 ? L * 1e-9 : L * 1e-9 * pow(1e9, (double)i / N);
        for (int k = 0; k < 8; k++) {
            double r = r0 + (r1 - r0) * gx[k];
            sum += gw[k] * (r1 - r0) * sd_radial(c, model, ch, r) * r * 2.0 * OBS_PI;
        }
        r0 = r1;
    }
    /* the corners: r in [L, L sqrt2], substitute r = L + v^2 for the square-root edge */
    const int M = 400;
    double vmax = sqrt(L * (sqrt(2.0) - 1.0));
    for (int i = 0; i < M; i++) {
        double v0 = vmax * i / M, v1 = vmax * (i + 1) / M;
        for (int k = 0; k < 8; k++) {
            double v = v0 + (v1 - v0) * gx[k], r = L + v * v;
            double th = 2.0 * OBS_PI - 8.0 * acos(fmin(1.0, L / r));
            sum += gw[k] * (v1 - v0) * 2.0 * v * sd_radial(c, model, ch, r) * r * th;
        }
    }
    return sum;
}

static sss_material skin1(void)
{
    sss_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "skin1");
    const double ss[3] = {0.74, 0.88, 1.01}, sa[3] = {0.032, 0.17, 0.48}; /* [Jensen01] Fig. 5(b) */
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = ss[c];
        m.sigma_a[c] = sa[c];
    }
    m.eta = 1.3;
    return m;
}

#define PLANE_L 8.0
static int plane_setup(stu_run *R, int W, int blocker)
{
    memset(R, 0, sizeof *R);
    obs_scene_init(&R->scene);
    add_square(&R->scene, "plane", PLANE_L, 0.0, -1);
    if (blocker)
        add_square(&R->scene, "blocker", 30.0, 3.0, 0); /* opaque, above the camera */
    tu_add_light(&R->scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(1, 1, 1), 3.0f);
    sss_material m = skin1();
    return stu_run_setup(R, &m, 1.0, blocker ? 1.0 : 10.0, 1e-3f, W);
}

TEST(truth_sss_brute_force_plane_matches_radial_quadrature)
{
    stu_run R;
    CHECK_MSG(plane_setup(&R, 2, 0), "setup: %s", obs_context_last_error(R.ctx));
    for (int model = 0; model < SSS_MODEL_COUNT; model++) {
        truth_sss_params p = truth_sss_params_default();
        p.model = (sss_model)model;
        p.target_rel_error = 0.003;
        p.max_samples = 1 << 20;
        truth_sss_result res;
        CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
        double t = 1.0 - sss_fresnel_reflectance(1.0, 1.3);
        for (int c = 0; c < 3; c++) {
            double exact = t * t * 3.0 * plane_integral(&R.c, (sss_model)model, c, PLANE_L);
            double L = px(&res.radiance[c], 0, 0), se = px(&res.std_error[c], 0, 0);
            printf("plane %s ch%d: L = %.6g +- %.3g, exact %.6g, (L-exact)/se = %+.2f, n = %.0f\n",
                   sss_model_name((sss_model)model), c, L, se, exact, (L - exact) / se, px(&res.count, 0, 0));
            CHECK_MSG(fabs(L - exact) <= 3.0 * se, "%s ch %d: %.6g vs %.6g (se %.3g)", sss_model_name((sss_model)model),
                      c, L, exact, se);
        }
        CHECK(res.stats.pixels_surface == 4 && res.stats.pixels_converged + res.stats.pixels_at_max == 4);
        truth_sss_result_free(&res);
    }
    stu_run_free(&R);
}

/* Every pixel sees the plane's centre (orthographic, half size 1e-3), each with its own streams:
 * 256 independent estimates at a fixed N, against the exact value. With R = 8 replicates the bar
 * has 7 degrees of freedom: |error| > 2 bars 8.6% of the time (Student's t). Checked at N = 4096
 * (about 50 kept candidates: the rare-event end, where the f/p tail is least sampled) and 32768. */
TEST(truth_sss_error_bars_are_calibrated)
{
    stu_run R;
    CHECK_MSG(plane_setup(&R, 16, 0), "setup: %s", obs_context_last_error(R.ctx));
    const double t = 1.0 - sss_fresnel_reflectance(1.0, 1.3);
    double exact[3];
    for (int c = 0; c < 3; c++)
        exact[c] = t * t * 3.0 * plane_integral(&R.c, SSS_MODEL_DIRECTIONAL, c, PLANE_L);
    const int64_t Ns[3] = {4096, 32768, 131072};
    for (int k = 0; k < 3; k++) {
        truth_sss_params p = truth_sss_params_default();
        p.batch = 4096;
        p.min_samples = p.max_samples = Ns[k];
        p.seed = 11;
        truth_sss_result res;
        CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
        int n = 0, out2 = 0, out3 = 0;
        double rms = 0.0;
        for (int y = 0; y < 16; y++)
            for (int x = 0; x < 16; x++)
                for (int c = 0; c < 3; c++) {
                    double e = (px(&res.radiance[c], x, y) - exact[c]) / px(&res.std_error[c], x, y);
                    n++;
                    out2 += fabs(e) > 2.0;
                    out3 += fabs(e) > 3.0;
                    rms += e * e;
                }
        rms = sqrt(rms / n);
        printf("calibration N=%lld: %d estimates, %.1f%% beyond 2 bars, %.1f%% beyond 3, RMS(error/bar) %.3f\n",
               (long long)Ns[k], n, 100.0 * out2 / n, 100.0 * out3 / n, rms);
        if (k > 0) { /* N = 4096 is reported only: see docs/sss/truth.md, "Error bars" */
            CHECK(out2 >= n / 100 && out2 <= n * 16 / 100);
            CHECK(out3 <= n * 5 / 100);
            CHECK(rms > 0.7 && rms < 1.4);
        }
        truth_sss_result_free(&res);
    }
    stu_run_free(&R);
}

static int same_planes(const truth_sss_result *a, const truth_sss_result *b)
{
    for (int y = 0; y < a->height; y++) {
        for (int c = 0; c < 3; c++) {
            if (memcmp(obs_image_f32_row(&a->radiance[c], y), obs_image_f32_row(&b->radiance[c], y), 4 * (size_t)a->width) ||
                memcmp(obs_image_f32_row(&a->std_error[c], y), obs_image_f32_row(&b->std_error[c], y), 4 * (size_t)a->width))
                return 0;
        }
        if (memcmp(obs_image_f32_row(&a->count, y), obs_image_f32_row(&b->count, y), 4 * (size_t)a->width))
            return 0;
    }
    return 1;
}

TEST(truth_sss_output_is_identical_for_any_thread_count)
{
    stu_run R;
    CHECK_MSG(plane_setup(&R, 6, 0), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.target_rel_error = 0.02; /* adaptive: the stopping rule must not depend on threads either */
    p.tile = 2;
    truth_sss_result ref, r;
    CHECK_OK(run_sss(&R, NULL, &p, &ref), R.ctx);
    const int threads[3] = {1, 2, 8};
    for (int k = 0; k < 3; k++) {
        obs_pool *pool = obs_pool_create(threads[k]);
        CHECK(pool != NULL);
        CHECK_OK(run_sss(&R, pool, &p, &r), R.ctx);
        obs_pool_destroy(pool);
        CHECK_MSG(same_planes(&ref, &r), "%d threads differ", threads[k]);
        truth_sss_result_free(&r);
    }
    /* another seed: different bits, consistent values */
    p.seed = 99;
    CHECK_OK(run_sss(&R, NULL, &p, &r), R.ctx);
    CHECK(!same_planes(&ref, &r));
    int far = 0;
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++)
            for (int c = 0; c < 3; c++) {
                double a = px(&ref.radiance[c], x, y), b = px(&r.radiance[c], x, y);
                double s = hypot(px(&ref.std_error[c], x, y), px(&r.std_error[c], x, y));
                far += fabs(a - b) > 4.0 * s;
            }
    CHECK(far <= 1);
    truth_sss_result_free(&r);
    truth_sss_result_free(&ref);
    stu_run_free(&R);
}

TEST(truth_sss_walk_is_identical_for_any_thread_count)
{
    stu_run R;
    memset(&R, 0, sizeof R);
    obs_scene_init(&R.scene);
    tu_add_box(&R.scene, "slab", 10.0, 10.0, -1);
    tu_add_light(&R.scene, OBS_LIGHT_POINT, obs_v3(1, 0, 2), obs_v3(0, 0, -1), obs_v3(1, 1, 1), 20.0f);
    sss_material m = grey_material(0.9, 1.3);
    CHECK_MSG(stu_run_setup(&R, &m, 1.0, 10.0, 2.0f, 4), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.estimator = TRUTH_SSS_RANDOM_WALK;
    p.patch_radius = 0.5;
    p.batch = 4096;
    p.min_samples = p.max_samples = 8192;
    p.tile = 1;
    truth_sss_result ref, r;
    CHECK_OK(run_sss(&R, NULL, &p, &ref), R.ctx);
    CHECK(ref.stats.pixels_surface == 16);
    for (int k = 0; k < 2; k++) {
        obs_pool *pool = obs_pool_create(k ? 8 : 2);
        CHECK_OK(run_sss(&R, pool, &p, &r), R.ctx);
        obs_pool_destroy(pool);
        CHECK(same_planes(&ref, &r));
        truth_sss_result_free(&r);
    }
    truth_sss_result_free(&ref);
    stu_run_free(&R);
}

TEST(truth_sss_walk_refuses_an_open_mesh)
{
    stu_run R;
    CHECK_MSG(plane_setup(&R, 2, 0), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.estimator = TRUTH_SSS_RANDOM_WALK;
    truth_sss_result res;
    CHECK(run_sss(&R, NULL, &p, &res) == OBS_STATUS_INVALID_ARGUMENT);
    const char *msg = obs_context_last_error(R.ctx);
    CHECK_MSG(strstr(msg, "'plane'") && strstr(msg, "closed"), "message: %s", msg);
    CHECK(res.radiance[0].data == NULL);
    double x[3] = {0, 0, 0}, n[3] = {0, 0, 1}, d[3] = {0, 0, -1}, rr, se;
    CHECK(truth_sss_walk_reflectance(R.ctx, R.ts, &R.scene, &R.mats, 0, x, n, d, 0, 10, 0, &rr, &se) ==
          OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(R.ctx), "'plane'") != NULL);
    stu_run_free(&R);
    /* the mesh check itself: a box is closed, a box less one triangle is not */
    obs_scene s;
    obs_scene_init(&s);
    tu_add_box(&s, "box", 1, 1, -1);
    uint64_t open = 99;
    CHECK(truth_sss_mesh_is_closed(&s.meshes[0], &open) == 1 && open == 0);
    s.meshes[0].triangle_count = 11;
    CHECK(truth_sss_mesh_is_closed(&s.meshes[0], &open) == 0 && open == 3);
    obs_scene_free(&s);
}

TEST(truth_sss_refuses_bad_params)
{
    truth_sss_params p = truth_sss_params_default();
    CHECK(truth_sss_params_validate(NULL, &p) == OBS_STATUS_OK);
    obs_context *ctx = obs_context_create();
    p.target_rel_error = 0.0;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "target_rel_error") != NULL);
    p.target_rel_error = NAN;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_sss_params_default();
    p.min_samples = p.max_samples * 2;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "max_samples") != NULL, "%s", obs_context_last_error(ctx));
    p = truth_sss_params_default();
    p.patch_radius = NAN;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "patch_radius") != NULL);
    p = truth_sss_params_default();
    p.sigma_star = -1.0;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_sss_params_default();
    p.batch = 4095;
    obs_context_clear_error(ctx);
    CHECK(truth_sss_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_sss_params_default();
    p.max_samples = (int64_t)1 << 21; /* over the default limit 2^20 */
    stu_run R;
    if (plane_setup(&R, 2, 0)) {
        truth_sss_result res;
        CHECK(run_sss(&R, NULL, &p, &res) == OBS_STATUS_LIMIT_EXCEEDED);
    }
    stu_run_free(&R);
    obs_context_destroy(ctx);
}

/* An opaque square between the light and the whole plane (above the camera): every pixel is
 * estimated (count > 0) and exactly 0, and with min < max it is not stopped on zero variance;
 * without the square they are lit. */
TEST(truth_sss_shadowed_points_get_no_light)
{
    stu_run R;
    CHECK_MSG(plane_setup(&R, 4, 1), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.min_samples = p.max_samples = 8192;
    p.batch = 4096;
    truth_sss_result res;
    CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
    CHECK(res.stats.pixels_surface == 16);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            CHECK(px(&res.count, x, y) == 8192.0f);
            for (int c = 0; c < 3; c++)
                CHECK(px(&res.radiance[c], x, y) == 0.0f);
        }
    CHECK(res.stats.accepted > 0);
    truth_sss_result_free(&res);
    /* Never stopped on zero variance: with min < max, a pixel whose replicates all read 0 goes on
     * to max_samples and is counted at max (docs/sss/truth.md, "Statistics"). */
    p.min_samples = 4096;
    p.max_samples = 12288;
    CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            CHECK(px(&res.count, x, y) == 12288.0f);
    CHECK(res.stats.pixels_at_max == 16 && res.stats.pixels_converged == 0);
    truth_sss_result_free(&res);
    p.min_samples = p.max_samples = 8192;
    stu_run_free(&R);
    CHECK_MSG(plane_setup(&R, 4, 0), "setup: %s", obs_context_last_error(R.ctx));
    CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
    CHECK(px(&res.radiance[0], 1, 1) > 0.0f);
    truth_sss_result_free(&res);
    stu_run_free(&R);
}

/* The walk's patch bias (docs/sss/truth.md, "Biases"): a slab (a = 0.9, eta = 1.3) lit by a point
 * light 2 mean free paths above x_o, so that L_o falls off over a few mean free paths; the disk
 * average over radius rho is lower than the centre value by about c rho^2. Estimates at rho = 2, 1,
 * 0.5 with a fixed count: rho = 2 must be below rho = 1, and rho = 0.5 must agree within 3 bars with
 * the Richardson extrapolation (4 L(1) - L(2)) / 3 of the two larger (the rho^2 law). */
TEST(truth_sss_walk_patch_bias_shrinks_with_radius)
{
    stu_run R;
    memset(&R, 0, sizeof R);
    obs_scene_init(&R.scene);
    tu_add_box(&R.scene, "slab", 8.0, 8.0, -1);
    tu_add_light(&R.scene, OBS_LIGHT_POINT, obs_v3(0, 0, 2), obs_v3(0, 0, -1), obs_v3(1, 1, 1), 10.0f);
    sss_material m = grey_material(0.9, 1.3);
    CHECK_MSG(stu_run_setup(&R, &m, 1.0, 1.0, 1e-3f, 1), "setup: %s", obs_context_last_error(R.ctx));
    const double rho[3] = {2.0, 1.0, 0.5};
    double L[3], se[3];
    obs_limits lim = *obs_context_limits(R.ctx);
    lim.max_samples = (int64_t)1 << 21;
    obs_context_set_limits(R.ctx, &lim);
    for (int k = 0; k < 3; k++) {
        truth_sss_params p = truth_sss_params_default();
        p.estimator = TRUTH_SSS_RANDOM_WALK;
        p.patch_radius = rho[k];
        p.batch = 65536;
        p.min_samples = p.max_samples = (int64_t)1 << 21;
        truth_sss_result res;
        double t0 = obs_time_now();
        CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
        L[k] = px(&res.radiance[0], 0, 0);
        se[k] = px(&res.std_error[0], 0, 0);
        printf("patch rho=%.2f: L = %.5f +- %.5f (%.1f%%), %llu kept, %llu rays, lost %llu, %.2fs\n", rho[k], L[k],
               se[k], 100.0 * se[k] / L[k], (unsigned long long)res.stats.accepted, (unsigned long long)res.stats.rays,
               (unsigned long long)res.stats.walks_lost, obs_time_now() - t0);
        truth_sss_result_free(&res);
    }
    double rich = (4.0 * L[1] - L[0]) / 3.0, rse = hypot(4.0 * se[1], se[0]) / 3.0;
    printf("patch: Richardson rho->0 from rho = 2, 1: %.5f +- %.5f; rho = 0.5 is %+.2f%% from it\n", rich, rse,
           100.0 * (L[2] - rich) / rich);
    CHECK(L[0] < L[1] - 3.0 * hypot(se[0], se[1]));
    CHECK(fabs(L[2] - rich) <= 3.0 * hypot(se[2], rse));
    stu_run_free(&R);
}

/* Model error, reported (docs/sss/truth.md, "Model vs method"): on the closed slab (a = 0.9, g = 0,
 * eta = 1.3, uniform light at normal incidence, seen straight down), the brute force with each
 * dipole against the random walk. The dipoles are approximations (sss.md 1.4): asserted only to
 * within a factor 2 of the walk. */
TEST(truth_sss_dipoles_against_the_walk_on_a_slab)
{
    stu_run R;
    memset(&R, 0, sizeof R);
    obs_scene_init(&R.scene);
    tu_add_box(&R.scene, "slab", 25.0, 25.0, -1);
    tu_add_light(&R.scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(1, 1, 1), 1.0f);
    const double albedo[2] = {0.9, 0.99};
    for (int k = 0; k < 2; k++) {
        sss_material m = grey_material(albedo[k], 1.3);
        if (k == 0)
            CHECK_MSG(stu_run_setup(&R, &m, 1.0, 10.0, 1e-3f, 1), "setup: %s", obs_context_last_error(R.ctx));
        else
            CHECK_OK(sss_constants_make(R.ctx, &m, 1.0, &R.c), R.ctx);
        obs_limits lim = *obs_context_limits(R.ctx);
        lim.max_samples = (int64_t)1 << 22;
        obs_context_set_limits(R.ctx, &lim);
        double L[3], se[3];
        for (int e = 0; e < 3; e++) {
            truth_sss_params p = truth_sss_params_default();
            p.estimator = e < 2 ? TRUTH_SSS_BRUTE_FORCE : TRUTH_SSS_RANDOM_WALK;
            p.model = e == 1 ? SSS_MODEL_STANDARD : SSS_MODEL_DIRECTIONAL;
            p.patch_radius = 2.0; /* uniform light on a plane: no patch bias */
            p.batch = 65536;
            p.min_samples = p.max_samples = (int64_t)1 << (k == 0 ? 22 : 20);
            truth_sss_result res;
            double t0 = obs_time_now();
            CHECK_OK(run_sss(&R, NULL, &p, &res), R.ctx);
            L[e] = px(&res.radiance[0], 0, 0);
            se[e] = px(&res.std_error[0], 0, 0);
            printf("slab a=%.2f eta=1.3 %s%s: L = %.5f +- %.5f (%.2fs, %llu rays)\n", albedo[k],
                   truth_sss_estimator_name(p.estimator), e == 0 ? " directional" : e == 1 ? " standard" : "", L[e],
                   se[e], obs_time_now() - t0, (unsigned long long)res.stats.rays);
            truth_sss_result_free(&res);
        }
        printf("  directional / walk = %.3f, standard / walk = %.3f\n", L[0] / L[2], L[1] / L[2]);
        CHECK(L[0] > 0.5 * L[2] && L[0] < 2.0 * L[2]);
        CHECK(L[1] > 0.5 * L[2] && L[1] < 2.0 * L[2]);
    }
    stu_run_free(&R);
}
