/* test_ao_alchemy.c: Alchemy AO [McGuire11]: the flat-plane value, the sample pattern and constants
 * against an independent recomputation, a hand-computed single-tap case, the range check, the
 * guard-band equivalence of the blur, accuracy against GT-cos on the analytic scene, hard cases,
 * parameter validation and the CLI. (Thread identity and the registry-wide properties are in
 * test_ao_methods.c.) */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "test.h"
#include "truth/truth.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ----------------------------------------------------------------------------------- */

static int all_finite_unit(const obs_image_f32 *a)
{
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++) {
            float v = obs_image_f32_row(a, y)[x];
            if (!(v >= 0.0f && v <= 1.0f))
                return 0;
        }
    return 1;
}

static obs_status run_alchemy(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_params *p,
                              obs_image_f32 *out, obs_image_f32 *raw)
{
    memset(out, 0, sizeof *out);
    memset(raw, 0, sizeof *raw);
    obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in->w, in->h, raw);
    if (st == OBS_STATUS_OK)
        st = ao_alchemy_compute(ctx, pool, in, p, out, raw, NULL);
    return st;
}

/* ---- flat plane ------------------------------------------------------------------------------- */

TEST(alchemy_flat_open_plane_is_fully_visible)
{
    /* On a plane every v lies in the tangent plane: v.n is rounding noise (~1e-6 m), far below the
     * bias term z_C beta (-5e-4 at 5 m), so every tap adds exactly 0 and A = 1 exactly (raw). */
    obs_context *ctx = obs_context_create();
    const obs_dvec3 normals[3] = {{0, 0, 1}, {0, 0.766044443, 0.642787610}, {0.5, -0.3, 0.812403840}};
    for (int pl = 0; pl < 3; pl++) {
        tu_synth s;
        CHECK_OK(tu_synth_plane(ctx, 80, 60, 70.0, normals[pl], -5.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
        const char *presets[] = {"hpg11", "thesis", "port"};
        for (int pi = 0; pi < 3; pi++) {
            ao_alchemy_params p;
            CHECK(ao_alchemy_params_preset(presets[pi], &p));
            obs_image_f32 out, raw;
            CHECK_OK(run_alchemy(ctx, NULL, &s.in, &p, &out, &raw), ctx);
            for (int y = 0; y < 60; y++)
                for (int x = 0; x < 80; x++) {
                    if (!(obs_image_f32_row(&s.depth, y)[x] < INFINITY))
                        continue;
                    CHECK_MSG(obs_image_f32_row(&raw, y)[x] == 1.0f, "plane %d %s: raw (%d,%d) = %.9g", pl,
                              presets[pi], x, y, (double)obs_image_f32_row(&raw, y)[x]);
                    CHECK_MSG(fabsf(obs_image_f32_row(&out, y)[x] - 1.0f) <= 3e-7f, "plane %d %s: (%d,%d) = %.9g", pl,
                              presets[pi], x, y, (double)obs_image_f32_row(&out, y)[x]);
                    if (test_failed())
                        break;
                }
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
        }
        obs_image_f32_free(&s.depth);
    }
    obs_context_destroy(ctx);
}

/* ---- the sample pattern and constants ---------------------------------------------------------- */

TEST(alchemy_tap_pattern_and_constants_match_independent_recomputation)
{
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 64, 48, 50.0, obs_dv3(0, 0, 1), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_alchemy_params p = ao_alchemy_params_default();
    p.samples = 16;
    p.spiral_turns = 7;
    p.intensity = 1.5f;
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(&p, &s.in);
    /* the constant block: 2 sigma / s, 1/s, tau * 6.28, projInfo for fx = fy = 50, c = (32, 24) */
    CHECK(k.intensity_scale == 3.0f / 16.0f);
    CHECK(k.inv_num_samples == 0.0625f);
    CHECK(k.turns_angle == 7.0f * 6.28f);
    CHECK(k.proj_info[0] == (float)(-1.0 / 50.0) && k.proj_info[1] == (float)(-1.0 / 50.0));
    CHECK(k.proj_info[2] == (float)(32.0 / 50.0) && k.proj_info[3] == (float)(24.0 / 50.0));
    CHECK(k.proj_scale == 50.0f && k.radius2 == 0.25f && k.range_check == 1 && k.normals_from_gbuffer == 0);
    /* the hash at GL pixel (3, 5): ((3*3) ^ (5 + 3*5)) * 10 = (9 ^ 20) * 10 = 29 * 10 = 290 */
    CHECK(ao_sao_spin(3, 5) == 290.0f);
    /* tap offsets of GL pixel (3, 5), disk 9.5 px: alpha = (i + 0.5)/16, angle = alpha * 43.96 + 290,
     * offset = trunc(alpha * 9.5 * (cos, sin)(angle)), recomputed here in double: the float path
     * rounds each step, so compare with the double value unless it sits within 1e-4 of an integer */
    const float disk = 9.5f;
    int agree = 0, checked = 0;
    for (int i = 0; i < 16; i++) {
        int off[2];
        ao_alchemy_tap_offset(&k, 3, 5, disk, i, off);
        const double alpha = (i + 0.5) / 16.0, angle = alpha * (7.0 * 6.28) + 290.0;
        const double ex = alpha * 9.5 * cos(angle), ey = alpha * 9.5 * sin(angle);
        const double fx = ex - trunc(ex), fy = ey - trunc(ey);
        if (fabs(fx) > 1e-4 && fabs(fx) < 1.0 - 1e-4 && fabs(fy) > 1e-4 && fabs(fy) < 1.0 - 1e-4) {
            checked++;
            agree += off[0] == (int)trunc(ex) && off[1] == (int)trunc(ey);
            CHECK_MSG(off[0] == (int)trunc(ex) && off[1] == (int)trunc(ey), "tap %d: (%d, %d), expected (%d, %d)", i,
                      off[0], off[1], (int)trunc(ex), (int)trunc(ey));
        }
        /* every tap stays inside the disk */
        CHECK(off[0] * off[0] + off[1] * off[1] <= (int)ceil(disk * disk));
    }
    CHECK(checked >= 14 && agree == checked);
    /* the first taps by hand: i = 0, alpha = 1/32, angle = 291.37375 rad: cos = -0.7787.., sin =
     * -0.6273..; ssR = 0.297 px -> (0, 0): the first tap reads the centre pixel */
    int o0[2];
    ao_alchemy_tap_offset(&k, 3, 5, disk, 0, o0);
    CHECK(o0[0] == 0 && o0[1] == 0);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- a hand-computed case ---------------------------------------------------------------------- */

TEST(alchemy_single_tap_matches_hand_computed_estimator)
{
    /* A wall facing the camera at d = 5 with a block at d = 4.8 (20 cm in front of it). One tap
     * (s = 1, tau = 1): alpha = 0.5, the tap lies half a disk radius from the pixel in the direction
     * spin + 3.14. For each wall pixel whose tap lands in the block, the expected A is evaluated
     * here in double from the definition: v = Q - C, A = max(0, 1 - 2 sigma (max(0, v.n + z_C beta)
     * / (v.v + eps)))^k with n = (0, 0, 1); elsewhere A = 1. */
    obs_context *ctx = obs_context_create();
    const int W = 64, H = 48;
    const double f = 60.0;
    obs_image_f32 depth, n[3];
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
    for (int a = 0; a < 3; a++)
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &n[a]), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            obs_image_f32_row(&depth, y)[x] = (x >= 28 && x < 40 && y >= 18 && y < 30) ? 4.8f : 5.0f;
            obs_image_f32_row(&n[0], y)[x] = 0.0f;
            obs_image_f32_row(&n[1], y)[x] = 0.0f;
            obs_image_f32_row(&n[2], y)[x] = 1.0f;
        }
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = W;
    in.height = in.h = H;
    in.depth = &depth;
    for (int a = 0; a < 3; a++)
        in.normal[a] = &n[a];
    in.fx = in.fy = f;
    in.cx = 0.5 * W;
    in.cy = 0.5 * H;
    in.projection = OBS_PROJECTION_PERSPECTIVE;
    ao_alchemy_params p = ao_alchemy_params_default();
    p.samples = 1;
    p.spiral_turns = 1;
    p.radius = 1.0f;
    p.intensity = 0.8f;
    p.contrast = 1.5f;
    p.bias = 0.01f;
    p.blur = 0;
    obs_image_f32 out, raw;
    CHECK_OK(run_alchemy(ctx, NULL, &in, &p, &out, &raw), ctx);
    int occluded = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const double d = obs_image_f32_row(&depth, y)[x];
            const int gx = x, gy = H - 1 - y;
            const double spin = (double)ao_sao_spin(gx, gy);
            const double disk = f * 1.0 / d, ssR = 0.5 * disk, ang = 0.5 * 6.28 + spin;
            const int tx = gx + (int)trunc(ssR * cos(ang)), ty = gy + (int)trunc(ssR * sin(ang));
            const int cx = tx < 0 ? 0 : tx > W - 1 ? W - 1 : tx, cy = ty < 0 ? 0 : ty > H - 1 ? H - 1 : ty;
            const double dq = obs_image_f32_row(&depth, H - 1 - cy)[cx];
            /* positions: P = d ((x + 0.5 - cx)/f, -(y + 0.5 - cy)/f, -1), y in our rows */
            const double Cx = d * (x + 0.5 - in.cx) / f, Cy = -d * (y + 0.5 - in.cy) / f, Cz = -d;
            const double qy = H - 1 - cy;
            const double Qx = dq * (cx + 0.5 - in.cx) / f, Qy = -dq * (qy + 0.5 - in.cy) / f, Qz = -dq;
            const double vx = Qx - Cx, vy = Qy - Cy, vz = Qz - Cz;
            const double vv = vx * vx + vy * vy + vz * vz, vn = vz;
            double term = vv < 1.0 ? fmax(0.0, vn + Cz * 0.01) / (vv + 1e-5) : 0.0;
            double A = pow(fmax(0.0, 1.0 - 2.0 * 0.8 * term), 1.5);
            const double got = obs_image_f32_row(&out, y)[x];
            if (A < 1.0)
                occluded++;
            CHECK_MSG(fabs(got - A) <= 2e-5 * (1.0 + A), "(%d,%d): %.7f, expected %.7f", x, y, got, A);
            if (test_failed())
                goto done;
        }
    CHECK_MSG(occluded > 40, "only %d pixels saw the block", occluded);
done:
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&depth);
    for (int a = 0; a < 3; a++)
        obs_image_f32_free(&n[a]);
    obs_context_destroy(ctx);
}

TEST(alchemy_range_check_drops_distant_occluders)
{
    /* A wall at 10 m with a square at 2 m: with the range check (default) the wall around the
     * square is untouched (every v there is ~8 m > r); without it, the 1/|v| tail of the estimator
     * darkens it by about 2 sigma/s * h * 8/64 for h taps on the square. */
    obs_context *ctx = obs_context_create();
    const int W = 96, H = 64;
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&depth, y)[x] = (x >= 32 && x < 64 && y >= 20 && y < 44) ? 2.0f : 10.0f;
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = W;
    in.height = in.h = H;
    in.depth = &depth;
    in.fx = in.fy = 100.0;
    in.cx = 0.5 * W;
    in.cy = 0.5 * H;
    in.projection = OBS_PROJECTION_PERSPECTIVE;
    ao_alchemy_params p = ao_alchemy_params_default();
    p.blur = 0;
    double halo[2] = {0, 0};
    for (int rc = 0; rc < 2; rc++) {
        p.range_check = rc;
        obs_image_f32 out, raw;
        CHECK_OK(run_alchemy(ctx, NULL, &in, &p, &out, &raw), ctx);
        for (int y = 10; y < 54; y++)
            for (int x = 22; x < 74; x++)
                if (!(x >= 32 && x < 64 && y >= 20 && y < 44))
                    halo[rc] = fmax(halo[rc], 1.0 - obs_image_f32_row(&out, y)[x]);
        obs_image_f32_free(&out);
        obs_image_f32_free(&raw);
    }
    printf("  halo without the range check %.4f, with %.4f\n", halo[0], halo[1]);
    CHECK(halo[1] == 0.0);
    CHECK(halo[0] > 0.05); /* measured 0.1 */
    obs_image_f32_free(&depth);
    obs_context_destroy(ctx);
}

/* ---- guard band and blur --------------------------------------------------------------------- */

TEST(alchemy_window_equals_full_buffer_cropped)
{
    /* The AO pass runs over the window plus the Gaussian's 10 px: the result over a window equals
     * the whole buffer's result cropped, byte for byte, with and without the blur. */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 70, 50, 0, &gb), ctx);
    ao_input full;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &full), ctx);
    for (int blur = 0; blur < 2; blur++)
        for (int nm = 0; nm < 2; nm++) {
            ao_alchemy_params p = ao_alchemy_params_default();
            p.blur = blur;
            p.normals = nm ? AO_ALCHEMY_NORMALS_DEPTH : AO_ALCHEMY_NORMALS_AUTO;
            obs_image_f32 fo, fr;
            CHECK_OK(run_alchemy(ctx, NULL, &full, &p, &fo, &fr), ctx);
            const int wins[3][4] = {{7, 5, 40, 30}, {0, 0, 13, 50}, {55, 31, 15, 19}};
            for (int wi = 0; wi < 3; wi++) {
                ao_input in = full;
                in.x0 = wins[wi][0];
                in.y0 = wins[wi][1];
                in.w = wins[wi][2];
                in.h = wins[wi][3];
                obs_image_f32 o, r;
                CHECK_OK(run_alchemy(ctx, NULL, &in, &p, &o, &r), ctx);
                for (int y = 0; y < in.h; y++)
                    CHECK_MSG(!memcmp(obs_image_f32_row(&o, y), obs_image_f32_row(&fo, y + in.y0) + in.x0,
                                      sizeof(float) * (size_t)in.w) &&
                                  !memcmp(obs_image_f32_row(&r, y), obs_image_f32_row(&fr, y + in.y0) + in.x0,
                                          sizeof(float) * (size_t)in.w),
                              "blur %d normals %d window %d row %d differs", blur, nm, wi, y);
                obs_image_f32_free(&o);
                obs_image_f32_free(&r);
            }
            /* and the blurred output is the Gaussian of the raw one (the whole buffer here) */
            if (blur) {
                obs_image_f32 g;
                CHECK_OK(obs_image_f32_alloc(ctx, fr.width, fr.height, &g), ctx);
                CHECK_OK(ao_blur_gaussian21(ctx, NULL, &fr, &g), ctx);
                int same = 1;
                for (int y = 0; y < g.height; y++)
                    for (int x = 0; x < g.width; x++) {
                        const float d = obs_image_f32_row(full.depth, y)[x];
                        const float want = (d > 0.0f && d < INFINITY) ? obs_image_f32_row(&g, y)[x] : 1.0f;
                        same &= obs_image_f32_row(&fo, y)[x] == want;
                    }
                CHECK(same);
                obs_image_f32_free(&g);
            }
            obs_image_f32_free(&fo);
            obs_image_f32_free(&fr);
        }
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- accuracy against the matched ground truth ------------------------------------------------ */

/* RMSE and mean signed error (AO - truth) over the pixels the truth marks valid. */
static void ao_vs_truth(const obs_image_f32 *ao, const truth_ao_result *t, double *rmse, double *bias, int64_t *n)
{
    double s2 = 0, s1 = 0;
    int64_t c = 0;
    for (int y = 0; y < t->height; y++)
        for (int x = 0; x < t->width; x++) {
            if (!(obs_image_f32_row(&t->count, y)[x] > 0.0f))
                continue;
            const double e = (double)obs_image_f32_row(ao, y)[x] - obs_image_f32_row(&t->mean, y)[x];
            s2 += e * e;
            s1 += e;
            c++;
        }
    *rmse = c ? sqrt(s2 / c) : 0.0;
    *bias = c ? s1 / c : 0.0;
    *n = c;
}

TEST(alchemy_accuracy_against_gt_cos_on_the_sphere_scene)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    const obs_camera cam = tu_ao_camera();
    rast_params rp = rast_params_default();
    rp.width = 96;
    rp.height = 72;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, NULL, &s, &v, 1, &rp, &gb, NULL), ctx);
    truth_scene *ts = NULL;
    CHECK_OK(truth_scene_create(ctx, &s, TRUTH_BUILD_MEDIUM, &ts), ctx);
    obs_pool *pool = obs_pool_create(2);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    /* measured (96x72, GT-cos at 0.005 target error, blurred output): hpg11 r = 0.5 RMSE 0.2161
     * bias -0.0850; thesis r = 1 RMSE 0.1084 bias -0.0074 (docs/ao/alchemy.md). The bound is the
     * measured value plus a margin: a change of the pattern or estimator moves them. */
    static const struct {
        const char *preset;
        float radius;
        double rmse_bound, bias_lo, bias_hi;
    } cases[] = {
        {"hpg11", 0.5f, 0.225, -0.095, -0.075},
        {"thesis", 1.0f, 0.115, -0.017, 0.003},
    };
    for (int c = 0; c < 2; c++) {
        ao_alchemy_params p;
        CHECK(ao_alchemy_params_preset(cases[c].preset, &p));
        truth_ao_params tp = truth_ao_params_default();
        tp.estimator = TRUTH_AO_COS;
        tp.radius = p.radius;
        tp.target_error = 0.005;
        tp.max_samples = 1024;
        truth_ao_result t;
        CHECK_OK(truth_ao_render(ctx, pool, ts, &s, &cam, &gb, &tp, &t), ctx);
        obs_image_f32 out, raw;
        CHECK_OK(run_alchemy(ctx, pool, &in, &p, &out, &raw), ctx);
        double rmse, bias, rr, rb;
        int64_t n;
        ao_vs_truth(&out, &t, &rmse, &bias, &n);
        ao_vs_truth(&raw, &t, &rr, &rb, &n);
        printf("  %s r=%g: blurred RMSE %.4f bias %+.4f, raw RMSE %.4f bias %+.4f (%lld px)\n", cases[c].preset,
               (double)p.radius, rmse, bias, rr, rb, (long long)n);
        CHECK_MSG(rmse <= cases[c].rmse_bound && bias >= cases[c].bias_lo && bias <= cases[c].bias_hi,
                  "%s: RMSE %.4f bias %.4f", cases[c].preset, rmse, bias);
        CHECK(n > 3000);
        obs_image_f32_free(&out);
        obs_image_f32_free(&raw);
        truth_ao_result_free(&t);
    }
    obs_pool_destroy(pool);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- hard cases -------------------------------------------------------------------------------- */

TEST(alchemy_hard_cases_stay_finite)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 33, 21, 3, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    const float radii[] = {1e-6f, 1e-3f, 0.5f, 50.0f, 1e6f};
    for (int ri = 0; ri < 5; ri++)
        for (int rc = 0; rc < 2; rc++) {
            ao_alchemy_params p = ao_alchemy_params_default();
            p.radius = radii[ri];
            p.range_check = rc;
            p.intensity = ri == 4 ? 1e30f : 1.0f;
            p.contrast = ri == 0 ? 1e-30f : 20.0f;
            p.epsilon = ri == 3 ? 1e-30f : 1e-5f;
            p.samples = ri == 2 ? AO_ALCHEMY_MAX_SAMPLES : 16;
            obs_image_f32 out, raw;
            CHECK_OK(run_alchemy(ctx, NULL, &in, &p, &out, &raw), ctx);
            CHECK_MSG(all_finite_unit(&out) && all_finite_unit(&raw), "radius %g range check %d", (double)radii[ri], rc);
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
        }
    /* NaN and inf depths next to surfaces, depth-reconstructed normals */
    obs_image_f32 bad;
    CHECK_OK(obs_image_f32_alloc(ctx, gb.width, gb.height, &bad), ctx);
    for (int y = 0; y < gb.height; y++)
        for (int x = 0; x < gb.width; x++)
            obs_image_f32_row(&bad, y)[x] = (x + y) % 5 == 0 ? NAN : (x * y) % 7 == 1 ? 1e-30f
                                           : obs_image_f32_row(&gb.depth, y)[x];
    ao_input bi = in;
    bi.depth = &bad;
    bi.normal[0] = bi.normal[1] = bi.normal[2] = NULL;
    ao_alchemy_params p = ao_alchemy_params_default();
    obs_image_f32 out, raw;
    CHECK_OK(run_alchemy(ctx, NULL, &bi, &p, &out, &raw), ctx);
    CHECK(all_finite_unit(&out) && all_finite_unit(&raw));
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    /* GBUFFER normals asked for without normals */
    p.normals = AO_ALCHEMY_NORMALS_GBUFFER;
    CHECK_OK(obs_image_f32_alloc(ctx, bi.w, bi.h, &out), ctx);
    CHECK(ao_alchemy_compute(ctx, NULL, &bi, &p, &out, NULL, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "normals") != NULL);
    obs_image_f32_free(&out);
    /* 1x1 and a reversed-Z-like huge linear depth range */
    tu_synth sp;
    CHECK_OK(tu_synth_plane(ctx, 1, 1, 1.0, obs_dv3(0, 0, 1), -2.0, OBS_PROJECTION_PERSPECTIVE, &sp), ctx);
    p = ao_alchemy_params_default();
    CHECK_OK(run_alchemy(ctx, NULL, &sp.in, &p, &out, &raw), ctx);
    CHECK(fabsf(obs_image_f32_row(&out, 0)[0] - 1.0f) <= 3e-7f && obs_image_f32_row(&raw, 0)[0] == 1.0f);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&sp.depth);
    CHECK_OK(tu_synth_plane(ctx, 41, 29, 20.0, obs_dv3(0, 0.999, 0.0447101778), -0.02, OBS_PROJECTION_PERSPECTIVE, &sp),
             ctx);
    CHECK_OK(run_alchemy(ctx, NULL, &sp.in, &p, &out, &raw), ctx);
    CHECK(all_finite_unit(&out) && all_finite_unit(&raw));
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&sp.depth);
    obs_image_f32_free(&bad);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- SIMD against scalar ---------------------------------------------------------------------- */

/* The raw pass on ISA isa over the whole buffer. */
static obs_status raw_on(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_params *p,
                         const obs_image_f32 *const nrm[3], ao_alchemy_isa isa, obs_image_f32 *out, int64_t counts[2])
{
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(p, in);
    const int rect[4] = {0, 0, in->width, in->height};
    return ao_alchemy_raw_isa(ctx, pool, in, &k, nrm, rect, out, counts, isa);
}

TEST(alchemy_avx2_and_avx512_equal_scalar_bit_for_bit)
{
    /* The AVX2 pass promises the scalar pass's bits (ao.h, ao_alchemy_isa). A real scene (spheres on
     * a plane, background around), 97 px wide so that rows end in partial vector groups, with
     * NaN, +-inf, 0, negative, denormal, 1e-30 and 1e30 depths and zero / NaN / huge normals
     * scattered over it; every preset, the range check off, tiny and huge radii, 1024 samples,
     * orthographic planes; 1 and 2 threads. The AVX-512 path (the taps' cos/sin on 8 doubles per
     * register) is checked the same way where the CPU has it (else AVX2 twice). */
    obs_context *ctx = obs_context_create();
    const ao_alchemy_isa wide =
        ao_alchemy_isa_available(AO_ALCHEMY_ISA_AVX512) ? AO_ALCHEMY_ISA_AVX512 : AO_ALCHEMY_ISA_AVX2;
    fprintf(stderr, "  (wide path: %s)\n", wide == AO_ALCHEMY_ISA_AVX512 ? "AVX-512" : "AVX2 again");
    if (!ao_alchemy_isa_available(AO_ALCHEMY_ISA_AVX2)) {
        fprintf(stderr, "  (no AVX2 here: only the UNSUPPORTED_ISA answer is checked)\n");
        obs_image_f32 o;
        tu_synth sp;
        CHECK_OK(tu_synth_plane(ctx, 8, 8, 8.0, obs_dv3(0, 0, 1), -2.0, OBS_PROJECTION_PERSPECTIVE, &sp), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, 8, 8, &o), ctx);
        ao_alchemy_params p = ao_alchemy_params_default();
        const obs_image_f32 *nr[3] = {&sp.depth, &sp.depth, &sp.depth};
        CHECK(raw_on(ctx, NULL, &sp.in, &p, nr, AO_ALCHEMY_ISA_AVX2, &o, NULL) == OBS_STATUS_UNSUPPORTED_ISA);
        obs_image_f32_free(&o);
        obs_image_f32_free(&sp.depth);
        obs_context_destroy(ctx);
        return;
    }
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 97, 61, 0, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    obs_image_f32 bad, bn[3];
    CHECK_OK(obs_image_f32_alloc(ctx, gb.width, gb.height, &bad), ctx);
    for (int a = 0; a < 3; a++)
        CHECK_OK(obs_image_f32_alloc(ctx, gb.width, gb.height, &bn[a]), ctx);
    const float specials[] = {NAN, INFINITY, -INFINITY, 0.0f, -1.0f, 1e-40f, 1e-30f, 1e30f, 3e38f};
    int nspecial = 0;
    for (int y = 0; y < gb.height; y++)
        for (int x = 0; x < gb.width; x++) {
            const unsigned h = (unsigned)(x * 73856093u) ^ (unsigned)(y * 19349663u);
            float d = obs_image_f32_row(&gb.depth, y)[x];
            if (h % 11 == 0) {
                d = specials[(h / 11) % 9];
                nspecial++;
            }
            obs_image_f32_row(&bad, y)[x] = d;
            for (int a = 0; a < 3; a++)
                obs_image_f32_row(&bn[a], y)[x] = obs_image_f32_row(in.normal[a], y)[x];
            if (h % 13 == 1)
                obs_image_f32_row(&bn[0], y)[x] = obs_image_f32_row(&bn[1], y)[x] = obs_image_f32_row(&bn[2], y)[x] = 0.0f;
            if (h % 17 == 2)
                obs_image_f32_row(&bn[(h / 17) % 3], y)[x] = (h / 51) % 2 ? NAN : 1e20f;
        }
    CHECK(nspecial > 100);
    ao_input bi = in;
    bi.depth = &bad;
    const obs_image_f32 *gn[3] = {in.normal[0], in.normal[1], in.normal[2]};
    const obs_image_f32 *badn[3] = {&bn[0], &bn[1], &bn[2]};
    obs_pool *pool2 = obs_pool_create(2);
    const char *presets[] = {"default", "thesis", "port"};
    int cases = 0;
    for (int pi = 0; pi < 3; pi++)
        for (int var = 0; var < 5; var++)
            for (int scene = 0; scene < 2; scene++) {
                ao_alchemy_params p;
                CHECK(ao_alchemy_params_preset(presets[pi], &p));
                if (var == 1)
                    p.range_check = 0;
                if (var == 2)
                    p.radius = 1e-4f;
                if (var == 3) {
                    p.radius = 1e5f;
                    p.range_check = pi != 1;
                }
                if (var == 4) {
                    p.samples = pi == 0 ? AO_ALCHEMY_MAX_SAMPLES : 37;
                    p.spiral_turns = pi == 2 ? 999999 : 3;
                }
                const ao_input *ip = scene ? &bi : &in;
                const obs_image_f32 *const *np = scene ? badn : gn;
                obs_image_f32 a, b, c;
                CHECK_OK(obs_image_f32_alloc(ctx, in.width, in.height, &a), ctx);
                CHECK_OK(obs_image_f32_alloc(ctx, in.width, in.height, &b), ctx);
                CHECK_OK(obs_image_f32_alloc(ctx, in.width, in.height, &c), ctx);
                int64_t ca[2], cb[2], cc[2];
                CHECK_OK(raw_on(ctx, NULL, ip, &p, np, AO_ALCHEMY_ISA_SCALAR, &a, ca), ctx);
                CHECK_OK(raw_on(ctx, NULL, ip, &p, np, AO_ALCHEMY_ISA_AVX2, &b, cb), ctx);
                CHECK_OK(raw_on(ctx, pool2, ip, &p, np, wide, &c, cc), ctx);
                int same = ca[0] == cb[0] && ca[1] == cb[1] && ca[0] == cc[0] && ca[1] == cc[1];
                for (int y = 0; y < a.height; y++)
                    same &= !memcmp(obs_image_f32_row(&a, y), obs_image_f32_row(&b, y), sizeof(float) * (size_t)a.width) &&
                            !memcmp(obs_image_f32_row(&a, y), obs_image_f32_row(&c, y), sizeof(float) * (size_t)a.width);
                CHECK_MSG(same, "preset %s variant %d scene %d: AVX2 or AVX-512 (on 2 threads) differs from scalar",
                          presets[pi], var, scene);
                obs_image_f32_free(&a);
                obs_image_f32_free(&b);
                obs_image_f32_free(&c);
                cases++;
            }
    /* orthographic and perspective planes, tilted to the horizon, a wide field of view (f = 4 px:
     * |csPos.xy| >> |z|), FLT_MAX depths scattered over them (so that v overflows to inf and
     * inf * 0 makes v.n NaN, which maxf must pass on as the shader's max does), the normal constant
     * with n.x = 0 exactly, the range check on and off */
    for (int pr = 0; pr < 2; pr++)
        for (int rc = 0; rc < 2; rc++) {
            tu_synth sp;
            CHECK_OK(tu_synth_plane(ctx, 45, 23, pr ? 0.5 : 4.0, obs_dv3(0, 0.9, 0.4358898944), -3.0,
                                    pr ? OBS_PROJECTION_ORTHOGRAPHIC : OBS_PROJECTION_PERSPECTIVE, &sp),
                     ctx);
            for (int y = 0; y < 23; y++)
                for (int x = 0; x < 45; x++)
                    if ((x * 7 + y * 3) % 5 == 0)
                        obs_image_f32_row(&sp.depth, y)[x] = (x + y) % 2 ? 3.4028235e38f : specials[(x + y) % 9];
            ao_alchemy_params p = ao_alchemy_params_default();
            p.range_check = rc;
            obs_image_f32 rn[3], a, b;
            const float nc[3] = {0.0f, 0.9f, 0.4358898944f};
            for (int q = 0; q < 3; q++) {
                CHECK_OK(obs_image_f32_alloc(ctx, 45, 23, &rn[q]), ctx);
                for (int y = 0; y < 23; y++)
                    for (int x = 0; x < 45; x++)
                        obs_image_f32_row(&rn[q], y)[x] = nc[q];
            }
            const obs_image_f32 *rp[3] = {&rn[0], &rn[1], &rn[2]};
            CHECK_OK(obs_image_f32_alloc(ctx, 45, 23, &a), ctx);
            CHECK_OK(obs_image_f32_alloc(ctx, 45, 23, &b), ctx);
            CHECK_OK(raw_on(ctx, NULL, &sp.in, &p, rp, AO_ALCHEMY_ISA_SCALAR, &a, NULL), ctx);
            CHECK_OK(raw_on(ctx, NULL, &sp.in, &p, rp, AO_ALCHEMY_ISA_AVX2, &b, NULL), ctx);
            int same = 1;
            for (int y = 0; y < a.height; y++)
                same &= !memcmp(obs_image_f32_row(&a, y), obs_image_f32_row(&b, y), sizeof(float) * (size_t)a.width);
            CHECK_MSG(same, "plane, projection %d, range check %d: AVX2 differs from scalar", pr, rc);
            CHECK_OK(raw_on(ctx, NULL, &sp.in, &p, rp, wide, &b, NULL), ctx);
            for (int y = 0; y < a.height; y++)
                same &= !memcmp(obs_image_f32_row(&a, y), obs_image_f32_row(&b, y), sizeof(float) * (size_t)a.width);
            CHECK_MSG(same, "plane, projection %d, range check %d: AVX-512 differs from scalar", pr, rc);
            for (int q = 0; q < 3; q++)
                obs_image_f32_free(&rn[q]);
            obs_image_f32_free(&a);
            obs_image_f32_free(&b);
            obs_image_f32_free(&sp.depth);
        }
    CHECK(cases == 30);
    CHECK(ao_alchemy_isa_available(AO_ALCHEMY_ISA_SCALAR) && !ao_alchemy_isa_available(AO_ALCHEMY_ISA_COUNT));
    obs_pool_destroy(pool2);
    for (int a = 0; a < 3; a++)
        obs_image_f32_free(&bn[a]);
    obs_image_f32_free(&bad);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- params ------------------------------------------------------------------------------------ */

TEST(alchemy_params_presets_and_validation)
{
    obs_context *ctx = obs_context_create();
    ao_alchemy_params p = ao_alchemy_params_default();
    CHECK(p.radius == 0.5f && p.bias == 1e-4f && p.intensity == 1.0f && p.contrast == 1.0f && p.epsilon == 1e-5f &&
          p.samples == 12 && p.spiral_turns == 7 && p.range_check == 1 && p.blur == 1);
    CHECK(ao_alchemy_params_preset("thesis", &p) && p.radius == 1.0f && p.samples == 16);
    CHECK(ao_alchemy_params_preset("port", &p) && p.radius == 1.0f && p.contrast == 1.5f && p.bias == 0.002f &&
          p.epsilon == 1e-5f && p.spiral_turns == 7 && p.samples == 16 && p.intensity == 1.0f);
    CHECK(!ao_alchemy_params_preset("nope", &p));
    /* each spoiled field is rejected with a message naming it */
    const char *names[] = {"radius", "radius", "bias", "intensity", "contrast", "epsilon", "samples", "samples",
                           "spiral turns", "normals", "range check", "blur"};
    for (int i = 0; i < 12; i++) {
        p = ao_alchemy_params_default();
        switch (i) {
        case 0: p.radius = 0.0f; break;
        case 1: p.radius = NAN; break;
        case 2: p.bias = -1.0f; break;
        case 3: p.intensity = INFINITY; break;
        case 4: p.contrast = 0.0f; break;
        case 5: p.epsilon = 0.0f; break;
        case 6: p.samples = 0; break;
        case 7: p.samples = AO_ALCHEMY_MAX_SAMPLES + 1; break;
        case 8: p.spiral_turns = 0; break;
        case 9: p.normals = (ao_alchemy_normals)7; break;
        case 10: p.range_check = 2; break;
        default: p.blur = -1; break;
        }
        obs_context *c2 = obs_context_create();
        CHECK_MSG(ao_alchemy_params_validate(c2, &p) == OBS_STATUS_INVALID_ARGUMENT, "case %d accepted", i);
        CHECK_MSG(strstr(obs_context_last_error(c2), names[i]) != NULL, "case %d: message '%s' does not name %s", i,
                  obs_context_last_error(c2), names[i]);
        obs_context_destroy(c2);
    }
    char buf[512];
    p = ao_alchemy_params_default();
    CHECK(ao_alchemy_params_to_string(&p, buf, sizeof buf) > 0 && strstr(buf, "contrast=1") && strstr(buf, "range_check=1"));
    obs_context_destroy(ctx);
}

/* ---- CLI ----------------------------------------------------------------------------------------- */

TEST(ao_cli_alchemy_presets_and_range_check_flag)
{
    const char *dir = test_tmpdir();
    char scene[4200], pre[4200], json[4400];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(pre, sizeof pre, "%s/a", dir);
    const char *a[] = {"ao", "--method", "alchemy", "--preset", "thesis", "--no-range-check", "--contrast", "1.25",
                       "--scene", scene, "--size", "64x48", "-o", pre, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, test_path(dir, "a.out"), test_path(dir, "a.err")), 0);
    snprintf(json, sizeof json, "%s.json", pre);
    char *j = test_slurp(json, NULL);
    CHECK(j != NULL);
    if (j) {
        CHECK(strstr(j, "\"range_check\": 0") != NULL);
        CHECK(strstr(j, "\"contrast\": 1.25") != NULL);
        CHECK(strstr(j, "\"NUM_SAMPLES\": 16") != NULL);
        CHECK(strstr(j, "\"radius\": 1,") != NULL);
    }
    free(j);
    const char *b[] = {"ao", "--method", "alchemy", "--contrast", "0", "--scene", scene, "--size", "64x48", "-o", pre,
                       NULL};
    CHECK(test_spawn(OBS_CLI_PATH, b, test_path(dir, "b.out"), test_path(dir, "b.err")) != 0);
}
