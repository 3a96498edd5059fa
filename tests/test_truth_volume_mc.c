/* The Monte Carlo single-scattering image reference of src/truth/truth_volume.c
 * (truth_volume_mc_render; docs/volume/truth.md): a closed form on a homogeneous box, the error
 * bar's 1/sqrt(n) convergence, agreement with the deterministic fine-step march of the same
 * integral on bucky, thread-count independence, bad inputs. */
#include "test.h"

#include "core/obs.h"
#include "io/io.h"
#include "truth/truth.h"
#include "volume/vol.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A homogeneous box: n^3 voxels of spacing sp, every value 1, a one-point TF (rgb, alpha a0,
 * ref_step 0 = sp): sigma_t = -ln(1 - a0) / sp everywhere inside the bounds [-sp/2, (n - 1/2) sp]. */
static int make_box(obs_context *ctx, int n, double sp, float a0, const float rgb[3], vol_grid *g, vol_tf *tf)
{
    double s3[3] = {sp, sp, sp};
    if (vol_grid_alloc(ctx, n, n, n, s3, g) != OBS_STATUS_OK)
        return 0;
    for (size_t i = 0; i < (size_t)n * n * n; i++)
        g->data[i] = 1.0f;
    vol_grid_update_range(g);
    memset(tf, 0, sizeof *tf);
    tf->points = (vol_tf_point *)calloc(1, sizeof *tf->points);
    if (!tf->points)
        return 0;
    tf->count = 1;
    tf->points[0].value = 1.0;
    for (int c = 0; c < 3; c++)
        tf->points[0].rgba[c] = rgb[c];
    tf->points[0].rgba[3] = a0;
    return 1;
}

static vol_light light_dir(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    double n = sqrt(x * x + y * y + z * z);
    L.direction[0] = x / n, L.direction[1] = y / n, L.direction[2] = z / n;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

/* A camera above the box looking straight down (-z) at its centre, field of view fov_deg. */
static obs_camera top_camera(const double lo[3], const double hi[3], double fov_deg, int W, int H)
{
    obs_vec3 ctr = obs_v3((float)(0.5 * (lo[0] + hi[0])), (float)(0.5 * (lo[1] + hi[1])), (float)(0.5 * (lo[2] + hi[2])));
    double size = hi[2] - lo[2];
    obs_vec3 eye = obs_v3(ctr.x, ctr.y, (float)(hi[2] + 3.0 * size));
    obs_camera cam = obs_camera_look_at(eye, ctr, obs_v3(0, 1, 0), (float)(fov_deg * 3.14159265358979323846 / 180.0),
                                        (float)(0.5 * size), (float)(10.0 * size));
    cam.aspect = (float)W / (float)H;
    return cam;
}

/* The closed form, for a pixel ray entering the box through its top face z = z_hi (light
 * travelling along -z, so the light enters through the same face). With w the unit view direction
 * (w_z < 0), c = |w_z|, s the distance from the entry point and D the path length inside the box:
 * the view transmittance is T_v(s) = exp(-sigma s); the point at s lies c s below the top face, so
 * its transmittance to the light is T(s) = exp(-sigma c s); the phase factor f = 4 pi p_HG(cos theta)
 * is constant (cos theta = w_in . w_out = (0, 0, -1) . (-w) = w_z). Then [Max95]'s single
 * scattering integral (docs/volume/truth.md, eq. 1) is
 *
 *   L = rho E f Int_0^D sigma exp(-sigma s) exp(-sigma c s) ds = rho E f (1 - exp(-sigma (1 + c) D)) / (1 + c),
 *   A = 1 - T_v(D) = 1 - exp(-sigma D).
 *
 * Returns 0 when the pixel's ray does not enter through the top face. */
static int box_closed_form(const obs_camera *cam, int W, int H, int x, int y, const double lo[3], const double hi[3],
                           double sigma, double g, double *L_over_rhoE, double *A)
{
    /* The pixel ray, as rast_pixel_ray makes it for a perspective camera: view direction
     * ((px - cx)/fx, -(py - cy)/fy, -1) with fy = (H/2) / tan(yfov/2), fx = fy (aspect W/H). */
    double fy = 0.5 * H / tan(0.5 * (double)cam->yfov), fx = fy;
    double dv[3] = {((double)x + 0.5 - 0.5 * W) / fx, -((double)y + 0.5 - 0.5 * H) / fy, -1.0};
    const float *m = cam->world.m;
    double d[3], o[3] = {m[12], m[13], m[14]};
    for (int r = 0; r < 3; r++)
        d[r] = m[r] * dv[0] + m[4 + r] * dv[1] + m[8 + r] * dv[2];
    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int r = 0; r < 3; r++)
        d[r] /= dl;
    double t0 = 0.0, t1 = INFINITY;
    int entry_axis = -1;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0)
            continue;
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > t0) {
            t0 = ta;
            entry_axis = a;
        }
        if (tb < t1)
            t1 = tb;
    }
    if (!(t1 > t0) || entry_axis != 2)
        return 0;
    double D = t1 - t0, c = fabs(d[2]);
    double f = 1.0;
    if (g != 0.0) {
        double ct = d[2], den = 1.0 + g * g - 2.0 * g * ct;
        f = (1.0 - g * g) / (den * sqrt(den));
    }
    *L_over_rhoE = f * (1.0 - exp(-sigma * (1.0 + c) * D)) / (1.0 + c);
    *A = 1.0 - exp(-sigma * D);
    return 1;
}

TEST(volume_mc_homogeneous_box_matches_closed_form_within_error_bar)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    const float rgb[3] = {0.8f, 0.5f, 0.2f};
    const double sp = 0.25;
    CHECK(make_box(ctx, 8, sp, 0.2f, rgb, &g, &tf));
    const double sigma = -log(1.0 - (double)0.2f) / sp;
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    const int W = 9, H = 9;
    obs_camera cam = top_camera(lo, hi, 12.0, W, H);
    vol_light L = light_dir(0, 0, -1);
    const double gs[2] = {0.0, 0.5};
    for (int gi = 0; gi < 2; gi++) {
        truth_volume_mc_params p = truth_volume_mc_params_default();
        p.samples = 1024;
        p.g = gs[gi];
        truth_volume_image im;
        CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &im), ctx);
        CHECK_EQ_INT(im.stats.over_majorant, 0);
        int n = 0, beyond3 = 0;
        double z2 = 0.0, zmax = 0.0, dsum = 0.0, v2sum = 0.0;
        for (int y = 0; y < H; y++) {
            for (int x = 0; x < W; x++) {
                double Lr, A;
                if (!box_closed_form(&cam, W, H, x, y, lo, hi, sigma, gs[gi], &Lr, &A))
                    continue;
                for (int q = 0; q < 4; q++) {
                    double exact = q < 3 ? Lr * rgb[q] : A;
                    double est = obs_image_f32_row(&im.rgba[q], y)[x], se = obs_image_f32_row(&im.std_error[q], y)[x];
                    CHECK_MSG(se > 0.0 && isfinite(est), "pixel %d,%d channel %d: estimate %g, bar %g", x, y, q, est, se);
                    double z = (est - exact) / se;
                    z2 += z * z;
                    dsum += est - exact;
                    v2sum += se * se;
                    n++;
                    beyond3 += fabs(z) > 3.0;
                    if (fabs(z) > zmax)
                        zmax = fabs(z);
                }
            }
        }
        /* Each z is Student-t with R - 1 = 7 degrees of freedom (RMS sqrt(7/5) = 1.18, P(|t| > 3) =
         * 2%); the pooled z (sum of errors over the root of the summed squared bars) is ~N(0, 1) and
         * would show a bias. */
        double zrms = sqrt(z2 / n), pooled = dsum / sqrt(v2sum);
        printf("g %.1f: %d pixel-channels, RMS (est - exact)/bar %.3f, max %.2f, %d beyond 3 bars, pooled z %.2f; "
               "majorant %.3f\n",
               gs[gi], n, zrms, zmax, beyond3, pooled, im.stats.majorant);
        CHECK(n == 4 * W * H);
        CHECK(zmax < 6.5);
        CHECK(beyond3 <= n / 12);
        CHECK(zrms > 0.7 && zrms < 1.6);
        CHECK(fabs(pooled) < 3.5);
        truth_volume_image_free(&im);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_mc_error_bar_falls_as_one_over_sqrt_n)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    const float rgb[3] = {1.0f, 1.0f, 1.0f};
    const double sp = 0.25;
    CHECK(make_box(ctx, 8, sp, 0.3f, rgb, &g, &tf));
    const double sigma = -log(1.0 - (double)0.3f) / sp;
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    const int W = 8, H = 8;
    obs_camera cam = top_camera(lo, hi, 12.0, W, H);
    vol_light L = light_dir(0, 0, -1);
    const int64_t ns[3] = {64, 256, 1024};
    double bar[3], err[3];
    for (int k = 0; k < 3; k++) {
        truth_volume_mc_params p = truth_volume_mc_params_default();
        p.samples = ns[k];
        p.seed = 7;
        truth_volume_image im;
        CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &im), ctx);
        double b2 = 0.0, e2 = 0.0;
        int n = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double Lr, A;
                if (!box_closed_form(&cam, W, H, x, y, lo, hi, sigma, 0.0, &Lr, &A))
                    continue;
                double est = obs_image_f32_row(&im.rgba[0], y)[x], se = obs_image_f32_row(&im.std_error[0], y)[x];
                b2 += se * se;
                e2 += (est - Lr) * (est - Lr);
                n++;
            }
        CHECK(n == W * H);
        bar[k] = sqrt(b2 / n);
        err[k] = sqrt(e2 / n);
        printf("n %lld: RMS bar %.5f, RMS error against the closed form %.5f (ratio %.2f)\n", (long long)ns[k], bar[k],
               err[k], err[k] / bar[k]);
        truth_volume_image_free(&im);
    }
    /* 1/sqrt(n): x4 samples halve the bar (ratio 2 expected; the bar of one n is itself noisy
     * with 7 degrees of freedom, averaged over the pixels) */
    CHECK(bar[0] / bar[1] > 1.7 && bar[0] / bar[1] < 2.35);
    CHECK(bar[1] / bar[2] > 1.7 && bar[1] / bar[2] < 2.35);
    for (int k = 0; k < 3; k++)
        CHECK(err[k] / bar[k] > 0.6 && err[k] / bar[k] < 1.5);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* bucky 32^3 framed as `obscura volume` frames it. */
static obs_camera bucky_camera(const vol_grid *g, int W, int H)
{
    double lo[3], hi[3];
    vol_grid_bounds(g, lo, hi);
    obs_vec3 ctr = obs_v3((float)(0.5 * (lo[0] + hi[0])), (float)(0.5 * (lo[1] + hi[1])), (float)(0.5 * (lo[2] + hi[2])));
    double rad = 0.5 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                            (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double dir[3] = {-0.3, -0.4, -1.0}, dn = sqrt(0.09 + 0.16 + 1.0);
    double yfov = 40.0 * 3.14159265358979323846 / 180.0, dist = rad / sin(0.5 * yfov) * 1.05;
    obs_vec3 eye = obs_v3((float)(ctr.x - dir[0] / dn * dist), (float)(ctr.y - dir[1] / dn * dist),
                          (float)(ctr.z - dir[2] / dn * dist));
    obs_camera cam = obs_camera_look_at(eye, ctr, obs_v3(0, 1, 0), (float)yfov, (float)(dist - 1.2 * rad),
                                        (float)(dist + 1.2 * rad));
    cam.aspect = (float)W / (float)H;
    return cam;
}

TEST(volume_mc_agrees_with_fine_step_march_on_bucky)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    const int W = 20, H = 20;
    obs_camera cam = bucky_camera(&g, W, H);
    vol_light L = light_dir(0.4, -0.7, -0.6);
    truth_volume_mc_params p = truth_volume_mc_params_default();
    p.samples = 1024;
    truth_volume_image mc, mr, mr2;
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &mc), ctx);
    CHECK_EQ_INT(mc.stats.over_majorant, 0); /* the brick majorants bound sigma_t everywhere */
    truth_volume_params tp = truth_volume_params_default();
    tp.step_fraction = 1.0 / 16.0;
    const double h = tp.step_fraction * g.spacing[0];
    CHECK_OK(truth_volume_march_image(ctx, pool, &g, &tf, &L, &cam, W, H, h, &tp, 0.0, &mr), ctx);
    /* The march's own discretisation error, from halving both steps: far below the MC's bars. */
    tp.step_fraction = 1.0 / 32.0;
    CHECK_OK(truth_volume_march_image(ctx, pool, &g, &tf, &L, &cam, W, H, 0.5 * h, &tp, 0.0, &mr2), ctx);
    int n = 0, beyond4 = 0, beyond3 = 0;
    double z2 = 0.0, zsum = 0.0, march_diff = 0.0, bar_mean = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int q = 0; q < 4; q++) {
                double a = obs_image_f32_row(&mc.rgba[q], y)[x], b = obs_image_f32_row(&mr.rgba[q], y)[x];
                double b2 = obs_image_f32_row(&mr2.rgba[q], y)[x], se = obs_image_f32_row(&mc.std_error[q], y)[x];
                CHECK(isfinite(a) && isfinite(b));
                if (fabs(b - b2) > march_diff)
                    march_diff = fabs(b - b2);
                if (se == 0.0) {
                    CHECK_MSG(fabs(a - b) < 1e-4, "pixel %d,%d channel %d: MC %g (bar 0), march %g", x, y, q, a, b);
                    continue;
                }
                double z = (a - b) / se;
                z2 += z * z;
                zsum += z;
                bar_mean += se;
                n++;
                beyond3 += fabs(z) > 3.0;
                beyond4 += fabs(z) > 4.0;
            }
    double zrms = sqrt(z2 / n);
    printf("bucky 32^3, %dx%d, %lld samples: %d pixel-channels with a bar, mean bar %.4f, RMS z %.3f, mean z %.3f, "
           "%d beyond 3, %d beyond 4; the march moves by at most %.2g when its steps halve; MC %.2f s, march %.2f s\n",
           W, H, (long long)p.samples, n, bar_mean / n, zrms, zsum / n, beyond3, beyond4, march_diff, mc.stats.seconds,
           mr.stats.seconds);
    CHECK(n > 200);
    CHECK(march_diff < 0.2 * bar_mean / n);
    CHECK(zrms > 0.7 && zrms < 1.6);
    CHECK(fabs(zsum / n) < 4.0 / sqrt((double)n) + 0.1);
    CHECK(beyond4 <= n / 100);
    truth_volume_image_free(&mc);
    truth_volume_image_free(&mr);
    truth_volume_image_free(&mr2);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_mc_output_identical_for_1_and_2_threads)
{
    obs_context *ctx = obs_context_create();
    obs_pool *p1 = obs_pool_create(1), *p2 = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK_OK(vol_synth(ctx, "bucky", 16, &g), ctx);
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    const int W = 13, H = 11;
    obs_camera cam = bucky_camera(&g, W, H);
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_POINT; /* a point light inside the volume */
    L.position[0] = 7.5, L.position[1] = 7.5, L.position[2] = 7.5;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    truth_volume_mc_params p = truth_volume_mc_params_default();
    p.samples = 64;
    p.g = 0.3;
    truth_volume_image a, b, c;
    CHECK_OK(truth_volume_mc_render(ctx, p1, &g, &tf, &L, &cam, W, H, &p, &a), ctx);
    CHECK_OK(truth_volume_mc_render(ctx, p2, &g, &tf, &L, &cam, W, H, &p, &b), ctx);
    p.tile = 5;
    CHECK_OK(truth_volume_mc_render(ctx, p2, &g, &tf, &L, &cam, W, H, &p, &c), ctx);
    for (int q = 0; q < 4; q++)
        for (int y = 0; y < H; y++) {
            CHECK(!memcmp(obs_image_f32_row(&a.rgba[q], y), obs_image_f32_row(&b.rgba[q], y), W * sizeof(float)));
            CHECK(!memcmp(obs_image_f32_row(&a.std_error[q], y), obs_image_f32_row(&b.std_error[q], y),
                          W * sizeof(float)));
            CHECK(!memcmp(obs_image_f32_row(&a.rgba[q], y), obs_image_f32_row(&c.rgba[q], y), W * sizeof(float)));
            for (int x = 0; x < W; x++)
                CHECK(isfinite(obs_image_f32_row(&a.rgba[q], y)[x]));
        }
    CHECK(a.stats.tentative == b.stats.tentative && a.stats.collisions == b.stats.collisions);
    CHECK(a.stats.collisions > 0);
    truth_volume_image_free(&a);
    truth_volume_image_free(&b);
    truth_volume_image_free(&c);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(p1);
    obs_pool_destroy(p2);
    obs_context_destroy(ctx);
}

TEST(volume_mc_limits_empty_tf_and_opaque_volume)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    vol_tf tf;
    const float rgb[3] = {1.0f, 1.0f, 1.0f};
    CHECK(make_box(ctx, 4, 1.0, 0.0f, rgb, &g, &tf));
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    obs_camera cam = top_camera(lo, hi, 30.0, 5, 5);
    vol_light L = light_dir(0, 0, -1);
    truth_volume_mc_params p = truth_volume_mc_params_default();
    p.samples = 1024;
    truth_volume_image im;
    /* Empty TF: nothing scatters, nothing absorbs. */
    CHECK_OK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 5, 5, &p, &im), ctx);
    for (int q = 0; q < 4; q++)
        for (int y = 0; y < 5; y++)
            for (int x = 0; x < 5; x++)
                CHECK(obs_image_f32_row(&im.rgba[q], y)[x] == 0.0f && obs_image_f32_row(&im.std_error[q], y)[x] == 0.0f);
    truth_volume_image_free(&im);
    /* Opaque (alpha 1: vol_sigma_from_alpha's finite 16.6 per ref_step): the first collision is at
     * the top face, lit through almost nothing: L ~ rho E / (1 + c), A ~ 1. */
    tf.points[0].rgba[3] = 1.0f;
    CHECK_OK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 5, 5, &p, &im), ctx);
    double v = obs_image_f32_row(&im.rgba[0], 2)[2], a = obs_image_f32_row(&im.rgba[3], 2)[2];
    printf("opaque: centre L %.4f (closed form ~0.5), A %.6f\n", v, a);
    CHECK(v > 0.45 && v < 0.55 && a == 1.0f);
    truth_volume_image_free(&im);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_mc_refuses_bad_inputs)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    vol_tf tf;
    const float rgb[3] = {1.0f, 1.0f, 1.0f};
    CHECK(make_box(ctx, 4, 1.0, 0.1f, rgb, &g, &tf));
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    obs_camera cam = top_camera(lo, hi, 30.0, 4, 4);
    vol_light L = light_dir(0, 0, -1);
    truth_volume_image im;
    truth_volume_mc_params p = truth_volume_mc_params_default();
    CHECK(truth_volume_mc_render(ctx, NULL, NULL, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, NULL, &im) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, NULL, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    p.samples = 100; /* not a multiple of 8 */
    obs_context_clear_error(ctx);
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "multiple") != NULL, "message: %s", obs_context_last_error(ctx));
    p = truth_volume_mc_params_default();
    p.replicates = 1;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_volume_mc_params_default();
    p.g = 1.0;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    p.g = NAN;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_volume_mc_params_default();
    p.kappa = -1.0;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    p = truth_volume_mc_params_default();
    p.samples = (int64_t)1 << 40;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 4, 4, &p, &im) == OBS_STATUS_LIMIT_EXCEEDED);
    p = truth_volume_mc_params_default();
    vol_light S = L;
    S.type = OBS_LIGHT_SPOT;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &S, &cam, 4, 4, &p, &im) == OBS_STATUS_UNSUPPORTED);
    vol_light Z = L;
    Z.direction[0] = Z.direction[1] = Z.direction[2] = 0.0;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &Z, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    vol_light N = L;
    N.color[1] = NAN;
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &N, &cam, 4, 4, &p, &im) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_volume_mc_render(ctx, NULL, &g, &tf, &L, &cam, 0, 4, &p, &im) != OBS_STATUS_OK);
    CHECK(im.rgba[0].data == NULL);
    truth_volume_params tp = truth_volume_params_default();
    CHECK(truth_volume_march_image(ctx, NULL, &g, &tf, &L, &cam, 4, 4, 0.0, &tp, 0.0, &im) ==
          OBS_STATUS_INVALID_ARGUMENT);
    CHECK(truth_volume_march_image(ctx, NULL, &g, &tf, &L, &cam, 4, 4, 1e-12, &tp, 0.0, &im) ==
          OBS_STATUS_LIMIT_EXCEEDED);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_mc_cli_writes_exr_with_error_bars_and_refuses_bad_flags)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/mc", test_tmpdir());
    const char *a[] = {"truth", "volume", "synth:bucky:16", "--image", "--size", "12x10", "--samples", "32", "--seed",
                       "3", "--phase-g", "0.2", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a, "mc"), 0);
    obs_context *ctx = obs_context_create();
    io_image im;
    memset(&im, 0, sizeof im);
    CHECK_OK(io_image_read(ctx, test_path(test_tmpdir(), "mc_mc.exr"), &im), ctx);
    CHECK(im.width == 12 && im.height == 10);
    const char *names[8] = {"R", "G", "B", "A", "SE.R", "SE.G", "SE.B", "SE.A"};
    int covered = 0;
    for (int c = 0; c < 8; c++) {
        int k = io_image_find_channel(&im, names[c]);
        CHECK_MSG(k >= 0, "channel %s missing", names[c]);
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                float v = obs_image_f32_row(&im.f32[k], y)[x];
                CHECK(v >= 0.0f && isfinite(v));
                covered += c == 3 && v > 0.0f;
            }
    }
    CHECK(covered > 10);
    io_image_free(&im);
    obs_context_destroy(ctx);
    char *js = test_slurp(test_path(test_tmpdir(), "mc.json"), NULL);
    CHECK(js && strstr(js, "\"mc_image\"") && strstr(js, "\"samples\": 32") && strstr(js, "max_std_error"));
    free(js);
    /* --image-only: the MC image and its sidecar, no light volume and no exact transmittance volume */
    char prefix2[4200];
    snprintf(prefix2, sizeof prefix2, "%s/only", test_tmpdir());
    const char *a2[] = {"truth", "volume", "synth:bucky:16", "--image-only", "--size", "6x5", "--samples", "16",
                        "-o", prefix2, NULL};
    CHECK_EQ_INT(test_cli_run(a2, "only"), 0);
    char *js2 = test_slurp(test_path(test_tmpdir(), "only.json"), NULL);
    CHECK(js2 && strstr(js2, "\"mc_image\"") && !strstr(js2, "light_volume_error"));
    free(js2);
    char *exr2 = test_slurp(test_path(test_tmpdir(), "only_mc.exr"), NULL), *T2 = test_slurp(test_path(test_tmpdir(), "only_T.nrrd"), NULL);
    CHECK(exr2 && !T2);
    free(exr2);
    free(T2);
    const char *b1[] = {"truth", "volume", "synth:bucky:8", "--image", "--samples", "12", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(b1, "b1"), 2); /* not a multiple of the 8 replicates */
    CHECK(test_cli_stderr_has("b1", "multiple"));
    const char *b2[] = {"truth", "volume", "synth:bucky:16", "--image", "--phase-g", "1", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(b2, "b2"), 2);
    const char *b3[] = {"volume", "synth:bucky:16", "--image", "-o", prefix, NULL}; /* truth volume only */
    CHECK_EQ_INT(test_cli_run(b3, "b3"), 2);
}

/* The hybrid scene's depth limit: +inf everywhere is no limit (the same bytes as none); a limit in
 * front of the near plane leaves every pixel empty (L = 0, A = 0); a limit halfway through the
 * volume leaves alpha no larger than the whole ray's anywhere and smaller somewhere; a plane of
 * the wrong size is refused. */
TEST(volume_mc_depth_limit_stops_the_rays)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK_OK(vol_synth(ctx, "bucky", 16, &g), ctx);
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    const int W = 12, H = 10;
    obs_camera cam = bucky_camera(&g, W, H);
    vol_light L = light_dir(0.3, -1.0, 0.2);
    truth_volume_mc_params p = truth_volume_mc_params_default();
    p.samples = 32;
    obs_image_f32 lim;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &lim), ctx);
    truth_volume_image none, inf, zero, half;
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &none), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&lim, y)[x] = INFINITY;
    p.depth_limit = &lim;
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &inf), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&lim, y)[x] = 0.0f;
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &zero), ctx);
    /* halfway: the linear depth of the volume's centre, from the camera */
    double lo[3], hi[3];
    vol_grid_bounds(&g, lo, hi);
    const obs_vec3 ctr = obs_v3((float)(0.5 * (lo[0] + hi[0])), (float)(0.5 * (lo[1] + hi[1])), (float)(0.5 * (lo[2] + hi[2])));
    const float zc = -obs_mat4_mul_point(cam.view, ctr).z;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&lim, y)[x] = zc;
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &half), ctx);
    int smaller = 0, larger = 0;
    for (int q = 0; q < 4; q++)
        for (int y = 0; y < H; y++) {
            CHECK(!memcmp(obs_image_f32_row(&none.rgba[q], y), obs_image_f32_row(&inf.rgba[q], y), W * sizeof(float)));
            for (int x = 0; x < W; x++) {
                CHECK(obs_image_f32_row(&zero.rgba[q], y)[x] == 0.0f);
                if (q == 3) {
                    const float a = obs_image_f32_row(&none.rgba[3], y)[x], b = obs_image_f32_row(&half.rgba[3], y)[x];
                    smaller += b < a;
                    larger += b > a + 1e-6f;
                }
            }
        }
    CHECK_MSG(smaller > 0, "a limit halfway through the volume made no pixel more transparent");
    CHECK_EQ_INT(larger, 0);
    obs_image_f32 bad;
    CHECK_OK(obs_image_f32_alloc(ctx, W + 1, H, &bad), ctx);
    p.depth_limit = &bad;
    truth_volume_image out;
    CHECK_EQ_INT(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &out), OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&bad);
    obs_image_f32_free(&lim);
    truth_volume_image_free(&none);
    truth_volume_image_free(&inf);
    truth_volume_image_free(&zero);
    truth_volume_image_free(&half);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
