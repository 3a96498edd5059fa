/* test_ao_gtao.c: GTAO as XeGTAO (docs/ao/gtao.md): the flat-plane value, the noise (Hilbert + R2),
 * the fast acos bound, the tap pattern and MIP choice of a given pixel, edges, the depth prefilter,
 * a hand-computed plane pixel, the denoiser (constants kept, crop = full run), accuracy against the
 * matched ground truth ("cos", r = Radius), hard cases, parameter checks and presets. */
#include "ao/ao.h"
#include "ao/ao_internal.h"
#include "core/obs.h"
#include "raster/raster.h"
#include "truth/truth.h"
#include "ao_test_util.h"
#include "test.h"

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

static obs_status run_gtao(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_params *p,
                           obs_image_f32 *out, obs_image_f32 *raw)
{
    obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
    if (st == OBS_STATUS_OK && raw)
        st = obs_image_f32_alloc(ctx, in->w, in->h, raw);
    if (st == OBS_STATUS_OK)
        st = ao_gtao_compute(ctx, pool, in, p, out, raw, NULL);
    return st;
}

static double frac_d(double v) { return v - floor(v); }

/* ---- flat plane -------------------------------------------------------------------------------- */

TEST(gtao_flat_open_plane_is_unoccluded_within_the_documented_band)
{
    /* A plane facing the camera at z = -5 and one tilted 50 degrees, 128x96, f = 110 px. The
     * documented flat value is 1: the closed form integrates to exactly 1 over all slice angles,
     * but XeGTAO's fast acos (FastSqrt(1) = 0.98873) and the finite slices / noise move single
     * pixels. Measured over the whole image (docs/ao/gtao.md): facing, min 0.9582 (raw) / 0.9672
     * (denoised), mean 0.9941; tilted, min 0.8187 / 0.8842 at the top corner, where clamp-to-edge
     * taps leave the plane, mean 0.9978 / 0.9991. */
    obs_context *ctx = obs_context_create();
    const double t = 50.0 * OBS_PI / 180.0;
    const obs_dvec3 normals[2] = {obs_dv3(0, 0, 1), obs_dv3(0, sin(t), cos(t))};
    for (int pl = 0; pl < 2; pl++)
        for (int blur = 0; blur < 2; blur++) {
            tu_synth s;
            CHECK_OK(tu_synth_plane(ctx, 128, 96, 110.0, normals[pl], -5.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
            ao_gtao_params p = ao_gtao_params_default();
            p.blur = blur;
            obs_image_f32 out, raw;
            CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &out, &raw), ctx);
            double mn = 1, sum = 0;
            for (int y = 0; y < out.height; y++)
                for (int x = 0; x < out.width; x++) {
                    const double v = obs_image_f32_row(&out, y)[x];
                    mn = v < mn ? v : mn;
                    sum += v;
                }
            const double mean = sum / (out.width * out.height);
            printf("gtao flat plane %d blur %d: min %.5f mean %.5f\n", pl, blur, mn, mean);
            CHECK_MSG(mn >= (pl ? 0.80 : 0.95), "plane %d blur %d: min %g", pl, blur, mn);
            CHECK_MSG(mean >= 0.99, "plane %d blur %d: mean %g", pl, blur, mean);
            CHECK(all_finite_unit(&out) && all_finite_unit(&raw));
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
            obs_image_f32_free(&s.depth);
        }
    obs_context_destroy(ctx);
}

/* ---- hand-computed: the centre pixel of a camera-facing plane ---------------------------------- */

TEST(gtao_camera_facing_plane_centre_pixel_matches_the_hand_computation)
{
    /* At the image centre of a plane facing the camera, V = n = (0,0,-1) (XeGTAO space), so in every
     * slice projN = n, |projN| = 1, cosNorm = 1, n = 0, and the horizons are the tangent plane:
     * horizonCos = dot(normalize(delta), V) = 0 (the tap falls on the plane). Then
     *   h1 = FastACos(0) = 1.570796 * FastSqrt(1), h0 = -h1,
     *   iarc0 + iarc1 = 2 * (1 - cos(2 h1)) / 4, vis = (that)^2.2 (slices average the same value).
     * The small-radius fade saturate((10 - ssR)/100) * 0.5 is added before the division by the
     * slice count. Plane at z = 3, r = 0.5, f = 60: ssR = 0.7285 / (3 * 0.99999 / 60) = 14.6 px
     * (no fade); the centre pull (0.99999) makes the horizon cos -1e-5 / distance, negligible.
     * W, H odd so a pixel centre is exactly on the axis. */
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 65, 65, 60.0, obs_dv3(0, 0, 1), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_gtao_params p = ao_gtao_params_default();
    p.blur = 0;
    obs_image_f32 out, raw;
    CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &out, &raw), ctx);
    const double fs1 = 0x1.fa3beap-1;           /* asfloat(0x1fbd1df5 + (0x3f800000 >> 1)) = 0x3f7d1df5 */
    CHECK(fabs((double)ao_gtao_fast_sqrt(1.0f) - fs1) < 1e-9);
    const double h1 = 1.570796 * fs1;
    const double slice_vis = 2.0 * (1.0 - cos(2.0 * h1)) / 4.0;
    /* the 0.05 fudge is lerp(1, 1, .05) = 1 */
    const double ssr = 0.5 * 1.457 / (3.0 * 0.99999 / 60.0);
    const double fade = fmin(1, fmax(0, (10 - ssr) / 100)) * 0.5;
    const double expect = pow((fade + 3 * slice_vis) / 3, 2.2);
    const double got = obs_image_f32_row(&raw, 32)[32];
    printf("gtao plane centre: expected %.6f got %.6f\n", expect, got);
    CHECK_NEAR(got, expect, 2e-4);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- noise ------------------------------------------------------------------------------------- */

TEST(gtao_noise_is_hilbert_level6_then_r2)
{
    /* HilbertIndex is a bijection of the 64x64 tile onto 0..4095 whose consecutive indices are
     * 4-neighbours (the Hilbert property, checked independently of the construction), starting at
     * (0,0) and ending at (63,0); only the low 6 bits of x, y matter. */
    static int seen[4096][2];
    for (int i = 0; i < 4096; i++)
        seen[i][0] = -1;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            uint32_t d = ao_gtao_hilbert_index((uint32_t)x, (uint32_t)y);
            CHECK(d < 4096);
            CHECK(seen[d][0] == -1);
            seen[d][0] = x;
            seen[d][1] = y;
            CHECK_EQ_INT((int)ao_gtao_hilbert_index((uint32_t)x + 64u * 7u, (uint32_t)y + 64u * 3u), (int)d);
        }
    for (int i = 1; i < 4096; i++)
        CHECK_EQ_INT(abs(seen[i][0] - seen[i - 1][0]) + abs(seen[i][1] - seen[i - 1][1]), 1);
    CHECK_EQ_INT((int)ao_gtao_hilbert_index(0, 0), 0);
    CHECK_EQ_INT((int)ao_gtao_hilbert_index(63, 0), 4095);
    /* R2 at pixel (3, 5), NoiseIndex 0 and 5: frac(0.5 + i * a) in double vs our float32 */
    for (int ni = 0; ni < 6; ni += 5) {
        const uint32_t i = ao_gtao_hilbert_index(3, 5) + 288u * (uint32_t)ni;
        float n[2];
        ao_gtao_noise(3, 5, ni, n);
        CHECK_NEAR(n[0], frac_d(0.5 + i * 0.75487766624669276005), 2e-4 * (1 + i / 1000.0));
        CHECK_NEAR(n[1], frac_d(0.5 + i * 0.5698402909980532659114), 2e-4 * (1 + i / 1000.0));
    }
    /* the texture a port uploads holds the same values */
    static float tex[64 * 64 * 2];
    ao_gtao_noise_texture(0, tex);
    float n35[2];
    ao_gtao_noise(3, 5, 0, n35);
    CHECK(tex[2 * (5 * 64 + 3)] == n35[0] && tex[2 * (5 * 64 + 3) + 1] == n35[1]);
}

/* ---- fast acos --------------------------------------------------------------------------------- */

TEST(gtao_fast_acos_error_is_bounded)
{
    /* XeGTAO_FastACos = Lagarde's polynomial times the 0x1fbd1df5 sqrt: measured max |error|
     * 0.0554 rad (at x = 0.5: FastSqrt(0.5) = 0.7387 vs 0.7071); FastSqrt's relative error is at
     * most 4.5% over (0, 1]. XeGTAO's auto-tuned constants were fitted with these errors in. */
    double worst = 0, worst_x = 0, worst_sqrt = 0;
    for (int i = 0; i <= 200000; i++) {
        const float x = -1.0f + 2.0f * (float)i / 200000.0f;
        const double e = fabs((double)ao_gtao_fast_acos(x) - acos((double)x));
        if (e > worst)
            worst = e, worst_x = x;
        const float y = (float)i / 200000.0f;
        if (y > 0) {
            const double r = fabs((double)ao_gtao_fast_sqrt(y) / sqrt((double)y) - 1.0);
            worst_sqrt = r > worst_sqrt ? r : worst_sqrt;
        }
    }
    printf("gtao fast acos: max error %.5f rad at x = %.4f; fast sqrt max rel. error %.4f\n", worst, worst_x,
           worst_sqrt);
    CHECK(worst < 0.056);
    CHECK(worst_sqrt < 0.046);
    CHECK(ao_gtao_fast_acos(1.0f) == 0.0f * 1.0f + ao_gtao_fast_acos(1.0f)); /* finite */
    CHECK(fabs(ao_gtao_fast_acos(-1.0f) - 3.141593f) < 1e-6);
}

/* ---- constants and the tap pattern ------------------------------------------------------------- */

TEST(gtao_constants_and_taps_of_pixel_3_5_match_an_independent_computation)
{
    /* 96x64 buffer, fx = fy = 80, centred: tanHalfFOV = (0.6, 0.4), NDCToViewMul = (1.2, -0.8),
     * NDCToViewAdd = (-0.6, 0.4), NDCToViewMul_x_PixelSize = (0.0125, -0.0125). */
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 96, 64, 80.0, obs_dv3(0, 0, 1), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_gtao_params p = ao_gtao_params_default();
    const ao_gtao_constants k = ao_gtao_constants_from_params(&p, &s.in);
    CHECK_NEAR(k.camera_tan_half_fov[0], 0.6, 1e-7);
    CHECK_NEAR(k.camera_tan_half_fov[1], 0.4, 1e-7);
    CHECK(k.ndc_to_view_mul[0] == 2.0f * k.camera_tan_half_fov[0]);
    CHECK(k.ndc_to_view_mul[1] == -2.0f * k.camera_tan_half_fov[1]);
    CHECK(k.ndc_to_view_add[0] == -k.camera_tan_half_fov[0] && k.ndc_to_view_add[1] == k.camera_tan_half_fov[1]);
    CHECK_NEAR(k.ndc_to_view_mul_x_pixel_size[0], 0.0125, 1e-8);
    CHECK_NEAR(k.ndc_to_view_mul_x_pixel_size[1], -0.0125, 1e-8);
    CHECK(k.denoise_blur_beta == 1.2f && k.noise_index == 0 && k.slice_count == 3 && k.steps_per_slice == 3);
    CHECK_NEAR(k.depth_unpack_consts[0], 0.1, 1e-7); /* infinite far: (znear, 1) */
    CHECK(k.depth_unpack_consts[1] == 1.0f);
    p.denoise_passes = 0;
    CHECK(ao_gtao_constants_from_params(&p, &s.in).denoise_blur_beta == 1e4f);

    /* Pixel (3, 5) at z = 3 (pulled 0.99999): ssR = 1.457 * 0.5 / (3 * 0.99999 * 0.0125) px.
     * Tap (slice j, step i): phi = (j + n.x)/3 * pi, s = ((i + frac(n.y + (j + 3i) * 0.618..))/3)^2 +
     * 1.3/ssR, offset = s * ssR * (cos phi, -sin phi), mip = clamp(log2|offset| - 3.3, 0, 5). */
    float noise[2];
    ao_gtao_noise(3, 5, 0, noise);
    const double z = 3.0 * 0.99999, ssr = 1.457 * 0.5 / (z * 0.0125);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) {
            ao_gtao_tap t;
            ao_gtao_tap_at(&k, (float)(3.0f * 0.99999f), noise, j, i, &t);
            const double phi = (j + noise[0]) / 3.0 * OBS_PI;
            const double sn = (i + frac_d(noise[1] + (j + 3.0 * i) * 0.6180339887498948482)) / 3.0;
            const double sv = sn * sn + 1.3 / ssr;
            const double ox = sv * ssr * cos(phi), oy = -sv * ssr * sin(phi);
            CHECK_NEAR(t.offset[0], ox, 1e-3);
            CHECK_NEAR(t.offset[1], oy, 1e-3);
            double m = log2(sqrt(ox * ox + oy * oy)) - 3.3;
            m = m < 0 ? 0 : m > 5 ? 5 : m;
            CHECK_NEAR(t.mip_level, m, 1e-4);
            CHECK_EQ_INT(t.mip, (int)fmin(4.0, floor(m + 0.5)));
            CHECK(t.rounded[0] == (float)nearbyint(t.offset[0]) && t.rounded[1] == (float)nearbyint(t.offset[1]));
        }
    /* the largest tap of slice 0 (s ~ 1) is ~19 px: MIP level log2(19.4) - 3.3 = 0.98 -> level 1 */
    ao_gtao_tap t;
    ao_gtao_tap_at(&k, 3.0f * 0.99999f, (const float[2]){0.0f, 0.999f}, 0, 2, &t);
    CHECK_EQ_INT(t.mip, 1);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- edges ------------------------------------------------------------------------------------- */

TEST(gtao_edges_follow_calculate_edges_and_pack_two_bits_each)
{
    float e[4];
    /* a plane with a constant slope: every edge fully open (slope-adjusted difference 0) */
    ao_gtao_calculate_edges(10.0f, 9.9f, 10.1f, 10.2f, 9.8f, e);
    for (int i = 0; i < 4; i++)
        CHECK_NEAR(e[i], 1.0, 1e-6);
    CHECK_EQ_INT((int)ao_gtao_pack_edges(e), 0xFF);
    /* a step of 1 m to the right of a pixel at z = 10: right edge closed, left open:
     * |dR| = 1, slope-adjusted |1 - 0.5| = 0.5 -> 1.25 - 0.5/0.11 < 0 -> 0 */
    ao_gtao_calculate_edges(10.0f, 10.0f, 11.0f, 10.0f, 10.0f, e);
    CHECK(e[1] == 0.0f);
    /* left: |0| and slope-adjusted |0 + 0.5|: min 0 -> saturate(1.25) = 1 (open) */
    CHECK(e[0] == 1.0f && e[2] == 1.0f && e[3] == 1.0f);
    /* packing levels: round(e * 2.9): 0.17 -> 0, 0.52 -> 2, 0.85 -> 2, 0.87 -> 3 */
    const float lv[4] = {0.17f, 0.52f, 0.85f, 0.87f};
    CHECK_EQ_INT((int)ao_gtao_pack_edges(lv), (0 << 6) | (2 << 4) | (2 << 2) | 3);
    float u[4];
    ao_gtao_unpack_edges((1u << 6) | (3u << 4) | (0u << 2) | 2u, u);
    CHECK_NEAR(u[0], 1.0 / 3, 1e-7);
    CHECK(u[1] == 1.0f && u[2] == 0.0f);
    CHECK_NEAR(u[3], 2.0 / 3, 1e-7);
}

/* ---- prefilter --------------------------------------------------------------------------------- */

TEST(gtao_prefilter_is_the_falloff_weighted_average_of_children)
{
    /* 4x4 buffer; level 1 pixel (0,0) has children 2, 2, 2, 3 (metres). Radius 0.5 * 1.457 * 0.75 =
     * 0.546375 = effectRadius; falloffRange = 0.615 * that, falloffFrom = effectRadius * 0.385:
     * weight(d) = saturate((3 - d) * (-1/range) + from/range + 1): for d = 3: 1 + 0.626 -> 1;
     * for d = 2: (1 - 1/0.336) + 0.626 + ... computed in double below. Background -> 65504. */
    obs_context *ctx = obs_context_create();
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, 4, 4, &depth), ctx);
    const float vals[16] = {2, 2, 5, 5, 2, 3, 5, 5, 1, 1, INFINITY, 1, 1, 1, 1, 1};
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            obs_image_f32_row(&depth, y)[x] = vals[4 * y + x];
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = 4;
    in.height = in.h = 4;
    in.depth = &depth;
    in.fx = in.fy = 4;
    in.cx = in.cy = 2;
    in.projection = OBS_PROJECTION_PERSPECTIVE;
    ao_gtao_params p = ao_gtao_params_default();
    const ao_gtao_constants k = ao_gtao_constants_from_params(&p, &in);
    obs_image_f32 lv[AO_GTAO_DEPTH_MIP_LEVELS];
    CHECK_OK(ao_gtao_prefilter_depths(ctx, NULL, &in, &k, lv), ctx);
    CHECK(obs_image_f32_row(&lv[0], 2)[2] == 65504.0f);
    CHECK_EQ_INT(lv[1].width, 2);
    CHECK_EQ_INT(lv[2].width, 1);
    CHECK_EQ_INT(lv[4].width, 1);
    const double er = 0.75 * 0.5 * 1.457, range = 0.615 * er, from = er * (1 - 0.615);
    const double w2 = fmin(1, fmax(0, (3.0 - 2.0) * (-1 / range) + from / range + 1));
    const double expect = (3 * w2 * 2 + 1 * 3) / (3 * w2 + 1);
    CHECK_NEAR(obs_image_f32_row(&lv[1], 0)[0], expect, 1e-6);
    CHECK_NEAR(obs_image_f32_row(&lv[1], 0)[1], 5.0, 1e-6);
    /* the 65504 child dominates its quad: the others are far below it and get weight 0 */
    CHECK_NEAR(obs_image_f32_row(&lv[1], 1)[1], 65504.0, 1e-2);
    ao_gtao_mips_free(lv);
    obs_image_f32_free(&depth);
    obs_context_destroy(ctx);
}

/* ---- denoiser ---------------------------------------------------------------------------------- */

TEST(gtao_denoised_window_equals_the_full_buffer_run_cropped)
{
    /* The sphere scene at 96x72; the window [20, 70) x [10, 50) of the full buffer, for 1, 2 and 3
     * passes: the main pass runs over the window plus one pixel per pass, so the crop must be
     * byte-identical to the full-buffer result. */
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &scene, tu_ao_camera(), 96, 72, 0, &gb), ctx);
    ao_input full;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &full), ctx);
    for (int passes = 0; passes <= 3; passes++) {
        ao_gtao_params p = ao_gtao_params_default();
        p.denoise_passes = passes;
        obs_image_f32 a, b;
        CHECK_OK(run_gtao(ctx, NULL, &full, &p, &a, NULL), ctx);
        ao_input win = full;
        win.x0 = full.x0 + 20;
        win.y0 = full.y0 + 10;
        win.w = 50;
        win.h = 40;
        CHECK_OK(run_gtao(ctx, NULL, &win, &p, &b, NULL), ctx);
        int same = 1;
        for (int y = 0; y < 40; y++)
            same &= !memcmp(obs_image_f32_row(&b, y), obs_image_f32_row(&a, y + 10) + 20, 50 * sizeof(float));
        CHECK_MSG(same, "passes %d: cropped window differs from the full run", passes);
        obs_image_f32_free(&a);
        obs_image_f32_free(&b);
    }
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

TEST(gtao_denoiser_keeps_constants_and_respects_depth_edges)
{
    /* Two planes facing the camera, z = 4 (left half) and z = 8 (right half): the raw AO is the
     * same (near) constant per half away from the step; the denoiser keeps it (weights sum), and the
     * edge detection stops leakage across the step: the right column next to the step keeps its
     * raw value to within the leak (3+ closed edges only). */
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 64, 48, 60.0, obs_dv3(0, 0, 1), -4.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    for (int y = 0; y < 48; y++)
        for (int x = 32; x < 64; x++)
            obs_image_f32_row(&s.depth, y)[x] *= 2.0f;
    for (int passes = 1; passes <= 3; passes++) {
        ao_gtao_params p = ao_gtao_params_default();
        p.denoise_passes = passes;
        obs_image_f32 out, raw;
        CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &out, &raw), ctx);
        CHECK(all_finite_unit(&out));
        /* mean over the step-side column x = 32 (far plane next to the near one): the raw AO there
         * is dark-free (the near plane is in front: no occlusion of the far plane's pixel is seen as
         * a horizon only within the radius); the near column x = 31 sees a 4 m drop: unoccluded */
        double dmax = 0;
        for (int y = 4; y < 44; y++) {
            const double d = fabs(obs_image_f32_row(&out, y)[31] - obs_image_f32_row(&raw, y)[31]);
            dmax = d > dmax ? d : dmax;
        }
        CHECK_MSG(dmax < 0.05, "passes %d: near column changed by %g", passes, dmax);
        obs_image_f32_free(&out);
        obs_image_f32_free(&raw);
    }
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- accuracy vs the matched ground truth ------------------------------------------------------ */

TEST(gtao_matches_cos_ground_truth_on_the_sphere_scene)
{
    /* tu_ao_scene at 160x120 (guard 8), ground truth "cos" with r = Radius = 0.5 (XeGTAO's RT
     * reference), 256..1024 samples, target error 0.004, all surface pixels. The bounds are the
     * measured RMSE / bias (docs/ao/gtao.md) plus a margin. */
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    const obs_camera cam = tu_ao_camera();
    rast_params rp = rast_params_default();
    rp.width = 160;
    rp.height = 120;
    rp.guard = 8;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, NULL, &scene, &v, 1, &rp, &gb, NULL), ctx);
    truth_scene *ts = NULL;
    CHECK_OK(truth_scene_create(ctx, &scene, TRUTH_BUILD_MEDIUM, &ts), ctx);
    obs_pool *pool = obs_pool_create(2);
    truth_ao_params tp = truth_ao_params_default();
    CHECK(truth_ao_estimator_from_name(ao_i_method_gtao.truth_estimator(NULL), &tp.estimator));
    tp.radius = 0.5f;
    tp.min_samples = 256;
    tp.max_samples = 1024;
    tp.target_error = 0.004;
    truth_ao_result tr;
    CHECK_OK(truth_ao_render(ctx, pool, ts, &scene, &cam, &gb, &tp, &tr), ctx);
    for (int blur = 0; blur < 2; blur++)
        for (int use_n = 0; use_n < 2; use_n++) {
            ao_input in;
            CHECK_OK(ao_input_from_gbuffer(ctx, &gb, use_n, &in), ctx);
            ao_gtao_params p = ao_gtao_params_default();
            p.blur = blur;
            obs_image_f32 out;
            CHECK_OK(run_gtao(ctx, pool, &in, &p, &out, NULL), ctx);
            double se = 0, bias = 0;
            int64_t n = 0;
            for (int y = 0; y < out.height; y++)
                for (int x = 0; x < out.width; x++) {
                    if (obs_image_f32_row(&tr.count, y)[x] == 0.0f)
                        continue;
                    const double d = (double)obs_image_f32_row(&out, y)[x] - obs_image_f32_row(&tr.mean, y)[x];
                    se += d * d;
                    bias += d;
                    n++;
                }
            const double rmse = sqrt(se / (double)n), b = bias / (double)n;
            printf("gtao vs cos(r=0.5), blur %d, normals %s: RMSE %.4f bias %+.4f over %lld px\n", blur,
                   use_n ? "gbuffer" : "depth", rmse, b, (long long)n);
            /* measured: raw 0.0739 / +0.0077 (depth normals), 0.0709 / +0.0025 (G-buffer);
             * denoised 0.0591 / +0.0137, 0.0600 / +0.0081 */
            const double rmse_bound = blur ? 0.070 : 0.085, bias_bound = 0.025;
            CHECK_MSG(rmse < rmse_bound, "RMSE %g > %g", rmse, rmse_bound);
            CHECK_MSG(fabs(b) < bias_bound, "bias %g", b);
            obs_image_f32_free(&out);
        }
    truth_ao_result_free(&tr);
    obs_pool_destroy(pool);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

/* ---- hard cases -------------------------------------------------------------------------------- */

TEST(gtao_hard_cases_stay_finite_and_background_is_one)
{
    obs_context *ctx = obs_context_create();
    /* NaN, 0, negative and +inf depths, a depth step, and huge depths (reversed-Z infinite far) */
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 33, 21, 30.0, obs_dv3(0, 0.6, 0.8), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    float *r3 = obs_image_f32_row(&s.depth, 3), *r7 = obs_image_f32_row(&s.depth, 7);
    r3[4] = NAN, r3[5] = 0.0f, r3[6] = -1.0f, r3[7] = INFINITY, r3[8] = 1e30f, r3[9] = 7e4f;
    for (int x = 0; x < 33; x++)
        r7[x] = x < 16 ? 0.2f : 1e6f;
    const float radii[3] = {1e-5f, 0.5f, 1e5f};
    for (int ri = 0; ri < 3; ri++)
        for (int q = 0; q < 4; q++) {
            ao_gtao_params p;
            ao_gtao_params_preset(q == 0 ? "low" : q == 1 ? "medium" : q == 2 ? "high" : "ultra", &p);
            p.radius = radii[ri];
            p.denoise_passes = q;
            obs_image_f32 out, raw;
            CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &out, &raw), ctx);
            CHECK_MSG(all_finite_unit(&out) && all_finite_unit(&raw), "radius %g preset %d", (double)radii[ri], q);
            for (int x = 4; x < 8; x++)
                CHECK(obs_image_f32_row(&out, 3)[x] == 1.0f && obs_image_f32_row(&raw, 3)[x] == 1.0f);
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
        }
    obs_image_f32_free(&s.depth);
    /* 1x1, 2x3 and 17x1 images (MIP levels deeper than the image), orthographic, grazing planes */
    const int sizes[3][2] = {{1, 1}, {2, 3}, {17, 1}};
    for (int i = 0; i < 3; i++)
        for (int proj = 0; proj < 2; proj++) {
            CHECK_OK(tu_synth_plane(ctx, sizes[i][0], sizes[i][1], 10.0, obs_dv3(0, 0.999, 0.0447), -1.0,
                                    proj ? OBS_PROJECTION_ORTHOGRAPHIC : OBS_PROJECTION_PERSPECTIVE, &s),
                     ctx);
            ao_gtao_params p = ao_gtao_params_default();
            obs_image_f32 out, raw;
            CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &out, &raw), ctx);
            CHECK(all_finite_unit(&out) && all_finite_unit(&raw));
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
            obs_image_f32_free(&s.depth);
        }
    obs_context_destroy(ctx);
}

/* ---- params ------------------------------------------------------------------------------------ */

TEST(gtao_bad_params_are_rejected_naming_the_field)
{
    obs_context *ctx = obs_context_create();
    const char *words[] = {"slices", "steps", "radius", "radius multiplier", "falloff range",
                           "sample distribution power", "thin occluder compensation", "final value power",
                           "depth MIP sampling offset", "normals", "blur", "denoise passes", "frame index"};
    for (int i = 0; i < 13; i++) {
        ao_gtao_params p = ao_gtao_params_default();
        switch (i) {
        case 0: p.slices = 0; break;
        case 1: p.steps = 65; break;
        case 2: p.radius = -1.0f; break;
        case 3: p.radius_multiplier = 0.1f; break;
        case 4: p.falloff_range = 0.0f; break;
        case 5: p.sample_distribution_power = NAN; break;
        case 6: p.thin_occluder_compensation = 0.8f; break;
        case 7: p.final_value_power = 6.0f; break;
        case 8: p.depth_mip_sampling_offset = -1.0f; break;
        case 9: p.normals = (ao_gtao_normals)7; break;
        case 10: p.blur = 2; break;
        case 11: p.denoise_passes = 4; break;
        default: p.frame_index = -1; break;
        }
        obs_context *c = obs_context_create();
        CHECK(ao_gtao_params_validate(c, &p) == OBS_STATUS_INVALID_ARGUMENT);
        const char *msg = obs_context_last_error(c);
        CHECK_MSG(msg && strstr(msg, words[i]), "case %d: message '%s' does not name '%s'", i, msg ? msg : "",
                  words[i]);
        obs_context_destroy(c);
    }
    /* normals = gbuffer without normals in the input */
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 8, 8, 10.0, obs_dv3(0, 0, 1), -2.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_gtao_params p = ao_gtao_params_default();
    p.normals = AO_GTAO_NORMALS_GBUFFER;
    obs_image_f32 out;
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 8, &out), ctx);
    CHECK(ao_gtao_compute(ctx, NULL, &s.in, &p, &out, NULL, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&out);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

TEST(gtao_presets_and_the_study_sample_mapping)
{
    ao_gtao_params p;
    const struct { const char *name; int slices, steps, passes; } pr[] = {
        {"default", 3, 3, 1}, {"xegtao", 3, 3, 1}, {"low", 1, 2, 1}, {"medium", 2, 2, 1}, {"high", 3, 3, 1},
        {"ultra", 9, 3, 1}, {"sharp", 3, 3, 1}, {"medium-denoise", 3, 3, 2}, {"soft", 3, 3, 3}};
    for (size_t i = 0; i < sizeof pr / sizeof pr[0]; i++) {
        CHECK(ao_gtao_params_preset(pr[i].name, &p));
        CHECK(p.slices == pr[i].slices && p.steps == pr[i].steps && p.denoise_passes == pr[i].passes);
        CHECK(p.radius == 0.5f && p.radius_multiplier == 1.457f && p.falloff_range == 0.615f);
        CHECK(p.final_value_power == 2.2f && p.depth_mip_sampling_offset == 3.30f);
        CHECK(ao_gtao_params_validate(NULL, &p) == OBS_STATUS_OK);
    }
    CHECK(!ao_gtao_params_preset("thesis", &p));
    const int n[8] = {4, 8, 16, 32, 18, 54, 12, 64};
    const int e[8][2] = {{1, 2}, {2, 2}, {2, 4}, {4, 4}, {3, 3}, {9, 3}, {2, 3}, {8, 4}};
    for (int i = 0; i < 8; i++) {
        int sl, st;
        ao_gtao_slices_steps_for_samples(n[i], &sl, &st);
        CHECK_MSG(sl == e[i][0] && st == e[i][1], "n = %d: %d x %d", n[i], sl, st);
        CHECK_EQ_INT(2 * sl * st, n[i]);
    }
    char buf[512];
    p = ao_gtao_params_default();
    CHECK(ao_gtao_params_to_string(&p, buf, sizeof buf) < (int)sizeof buf);
    CHECK(strstr(buf, "slices=3 steps=3") && strstr(buf, "normals=auto"));
}

TEST(gtao_output_identical_for_1_2_8_threads_with_three_denoise_passes)
{
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &scene, tu_ao_camera(), 80, 60, 4, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    ao_gtao_params p = ao_gtao_params_default();
    p.denoise_passes = 3;
    obs_image_f32 o[3];
    const int threads[3] = {1, 2, 8};
    for (int t = 0; t < 3; t++) {
        obs_pool *pool = obs_pool_create(threads[t]);
        CHECK_OK(run_gtao(ctx, pool, &in, &p, &o[t], NULL), ctx);
        obs_pool_destroy(pool);
    }
    CHECK(tu_same_plane(&o[0], &o[1]) && tu_same_plane(&o[0], &o[2]));
    for (int t = 0; t < 3; t++)
        obs_image_f32_free(&o[t]);
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

/* ---- speed: the fast main pass against the plain port ------------------------------------------ */

static int gtao_fast_equals_reference(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_params *p)
{
    obs_image_f32 o[2], r[2];
    int same = 0;
    if (obs_image_f32_alloc(ctx, in->w, in->h, &o[0]) == OBS_STATUS_OK &&
        obs_image_f32_alloc(ctx, in->w, in->h, &o[1]) == OBS_STATUS_OK &&
        obs_image_f32_alloc(ctx, in->w, in->h, &r[0]) == OBS_STATUS_OK &&
        obs_image_f32_alloc(ctx, in->w, in->h, &r[1]) == OBS_STATUS_OK &&
        ao_gtao_compute(ctx, pool, in, p, &o[0], &r[0], NULL) == OBS_STATUS_OK &&
        ao_gtao_compute_reference(ctx, pool, in, p, &o[1], &r[1], NULL) == OBS_STATUS_OK)
        same = tu_same_plane(&o[0], &o[1]) && tu_same_plane(&r[0], &r[1]);
    for (int i = 0; i < 2; i++)
        obs_image_f32_free(&o[i]), obs_image_f32_free(&r[i]);
    return same;
}

TEST(gtao_fast_main_pass_scalar_and_avx2_are_byte_identical_to_the_plain_port)
{
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &scene, tu_ao_camera(), 150, 100, 4, &gb), ctx);
    /* background (the camera sees past the ground), plus NaN, 0, negative, +inf and huge depths
     * (1e30: beyond the 65504 clamp; 7e4) in a band and in single pixels on the sphere */
    for (int x = 10; x < 60; x++) {
        float *r = obs_image_f32_row(&gb.depth, 40 + x % 7);
        r[x] = x % 5 == 0 ? NAN : x % 5 == 1 ? 1e30f : x % 5 == 2 ? 7e4f : x % 5 == 3 ? INFINITY : -1.0f;
    }
    obs_image_f32_row(&gb.depth, 55)[80] = 0.0f;
    obs_image_f32_row(&gb.normal[0], 60)[75] = NAN; /* a degenerate G-buffer normal */
    obs_pool *pool = obs_pool_create(2);
    for (int use_n = 0; use_n < 2; use_n++) {
        ao_input in;
        CHECK_OK(ao_input_from_gbuffer(ctx, &gb, use_n, &in), ctx);
        for (int c = 0; c < 12; c++) {
            ao_gtao_params p;
            ao_gtao_params_preset(c == 1 ? "low" : c == 2 ? "medium" : c == 3 ? "ultra" : "high", &p);
            if (c == 4)
                p.sample_distribution_power = 1.7f, p.final_value_power = 1.0f;
            if (c == 5)
                p.thin_occluder_compensation = 0.4f, p.falloff_range = 0.2f;
            if (c == 6)
                p.depth_mip_sampling_offset = 0.0f, p.radius = 3.0f;
            if (c == 7)
                p.depth_mip_sampling_offset = 30.0f, p.radius = 1e-5f;
            if (c == 8)
                p.gpu_packing = 1, p.denoise_passes = 2;
            if (c == 9)
                p.denoise_passes = 0, p.frame_index = 37, p.slices = 5, p.steps = 4;
            if (c == 10)
                p.blur = 0, p.radius = 1e5f, p.radius_multiplier = 3.0f;
            if (c == 11)
                p.denoise_passes = 3, p.frame_index = 70, p.normals = AO_GTAO_NORMALS_DEPTH;
            /* the AVX2 lanes (where the CPU has them) and the scalar loop */
            CHECK_MSG(gtao_fast_equals_reference(ctx, pool, &in, &p), "normals %d case %d", use_n, c);
            setenv("OBS_ISA", "scalar", 1);
            CHECK_MSG(gtao_fast_equals_reference(ctx, pool, &in, &p), "scalar: normals %d case %d", use_n, c);
            unsetenv("OBS_ISA");
        }
    }
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    /* orthographic */
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 40, 30, 12.0, obs_dv3(0, 0.6, 0.8), -3.0, OBS_PROJECTION_ORTHOGRAPHIC, &s), ctx);
    obs_image_f32_row(&s.depth, 9)[9] = NAN;
    obs_image_f32_row(&s.depth, 12)[20] = 1e30f;
    ao_gtao_params p = ao_gtao_params_default();
    CHECK(gtao_fast_equals_reference(ctx, pool, &s.in, &p));
    p.thin_occluder_compensation = 0.7f, p.slices = 9;
    CHECK(gtao_fast_equals_reference(ctx, pool, &s.in, &p));
    obs_image_f32_free(&s.depth);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* The 8-pixel set-up and finish (AVX2): image widths 44 to 98, every residue mod 8 and across the
 * 64-pixel chunk (blocks of 8, the scalar set-up for a chunk's last < 8, pending lanes carried
 * across blocks and chunks, the row's drain with 1..7 lanes),
 * background, degenerate normals (NaN, zero, +inf, a huge finite one whose square overflows) at
 * every lane position, perspective and orthographic cameras with G-buffer normals, final powers
 * 2.2 (the vector x^2.2) and 3.3; against the plain port, with the AVX2 lanes and OBS_ISA=scalar. */
TEST(gtao_eight_pixel_setup_and_finish_equal_the_plain_port)
{
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    obs_pool *pool = obs_pool_create(2);
    for (int ortho = 0; ortho < 2; ortho++) {
        obs_camera cam = tu_ao_camera();
        if (ortho)
            cam.projection = OBS_PROJECTION_ORTHOGRAPHIC, cam.xmag = 3.0f, cam.ymag = 2.0f;
        for (int w = 1; w <= 19; w += ortho ? 3 : 1) {
            rast_gbuffer gb;
            CHECK_OK(tu_render_depth_normal(ctx, &scene, cam, 3 * w + 41, 31, 2, &gb), ctx);
            const int W = gb.depth.width, H = gb.depth.height;
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    const int m = (x * 7 + y * 3) % 23;
                    if (m == 0)
                        obs_image_f32_row(&gb.normal[0], y)[x] = NAN;
                    else if (m == 1)
                        obs_image_f32_row(&gb.normal[0], y)[x] = 0.0f, obs_image_f32_row(&gb.normal[1], y)[x] = 0.0f,
                        obs_image_f32_row(&gb.normal[2], y)[x] = 0.0f;
                    else if (m == 2)
                        obs_image_f32_row(&gb.normal[1], y)[x] = INFINITY;
                    else if (m == 3)
                        obs_image_f32_row(&gb.normal[2], y)[x] = 3e19f;
                    else if (m == 4)
                        obs_image_f32_row(&gb.depth, y)[x] = (x + y) % 2 ? NAN : -1.0f;
                }
            ao_input in;
            CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
            for (int c = 0; c < 3; c++) {
                ao_gtao_params p;
                ao_gtao_params_preset(c == 1 ? "low" : "high", &p);
                if (c == 2)
                    p.final_value_power = 3.3f, p.denoise_passes = 0;
                CHECK_MSG(gtao_fast_equals_reference(ctx, pool, &in, &p), "ortho %d w %d case %d", ortho, w, c);
                setenv("OBS_ISA", "scalar", 1);
                CHECK_MSG(gtao_fast_equals_reference(ctx, pool, &in, &p), "scalar: ortho %d w %d case %d", ortho, w, c);
                unsetenv("OBS_ISA");
            }
            rast_gbuffer_free(&gb);
        }
    }
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

TEST(gtao_mip_thresholds_equal_the_log2_choice)
{
    /* every float within 4096 ulps of each level boundary, and a stride over [2^-8, 2^24], for
     * the default offset and others; plus 0, NaN, +inf */
    const float offsets[5] = {AO_GTAO_DEFAULT_DEPTH_MIP_SAMPLING_OFFSET, 0.0f, 1.0f, 3.15f, 30.0f};
    int bad = 0;
    for (int o = 0; o < 5; o++) {
        const float off = offsets[o];
        const float special[4] = {0.0f, -0.0f, NAN, INFINITY};
        for (int i = 0; i < 4; i++)
            bad += ao_gtao_mip_of_length(special[i], off, 0) != ao_gtao_mip_of_length(special[i], off, 1);
        for (int j = 1; j <= 4; j++) {
            /* the boundary of level j: log2(len) = off + j - 0.5 */
            const float b = (float)exp2((double)off + j - 0.5);
            uint32_t u;
            memcpy(&u, &b, 4);
            for (int d = -4096; d <= 4096; d++) {
                const uint32_t w = u + (uint32_t)d;
                float x;
                memcpy(&x, &w, 4);
                bad += ao_gtao_mip_of_length(x, off, 0) != ao_gtao_mip_of_length(x, off, 1);
            }
        }
        for (uint32_t w = 0x3b800000u; w < 0x4b800000u; w += 4099u) {
            float x;
            memcpy(&x, &w, 4);
            bad += ao_gtao_mip_of_length(x, off, 0) != ao_gtao_mip_of_length(x, off, 1);
        }
    }
    CHECK_MSG(bad == 0, "%d lengths differ", bad);
}

TEST(ao_cli_gtao_takes_its_own_options_and_writes_the_constant_block)
{
    const char *dir = test_tmpdir();
    char scene[1024], err[1024], prefix[1024], path[1100];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(prefix, sizeof prefix, "%s/gtao_cli/ao", dir);
    snprintf(err, sizeof err, "%s/gtao_cli.err", dir);
    const char *a[] = {"ao", "--method", "gtao", "--scene", scene, "--size", "48x32", "--preset", "ultra",
                       "--denoise-passes", "3", "--steps", "4", "--normals", "depth", "--frame-index", "70",
                       "-o", prefix, NULL};
    int rc = test_spawn(OBS_CLI_PATH, a, NULL, err);
    char *e = test_slurp(err, NULL);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, e ? e : "");
    free(e);
    snprintf(path, sizeof path, "%s.json", prefix);
    char *j = test_slurp(path, NULL);
    CHECK(j != NULL);
    if (j) {
        /* slices 9 from the preset, steps 4 and the options, NoiseIndex 70 % 64 = 6 */
        CHECK_MSG(strstr(j, "\"sliceCount\": 9") && strstr(j, "\"stepsPerSlice\": 4") &&
                      strstr(j, "\"denoisePassesRun\": 3") && strstr(j, "\"NoiseIndex\": 6") &&
                      strstr(j, "\"DenoiseBlurBeta\": 1.20000005"),
                  "sidecar lacks the constant block: %.400s", j);
        free(j);
    }
    const char *b[] = {"ao", "--method", "gtao", "--scene", scene, "--denoise-passes", "4", "-o", prefix, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b, NULL, NULL), 2);
}

TEST(gtao_normals_from_depth_agree_with_exact_gbuffer_normals_on_a_plane)
{
    /* A plane tilted 40 degrees: XeGTAO_CalculateNormal (edge-weighted cross products) must give the
     * plane's normal, so AO with normals from depth equals AO with the exact normal fed as a
     * G-buffer (our right-handed view space, converted to XeGTAO's by z -> -z) away from the border. */
    obs_context *ctx = obs_context_create();
    const double t = 40.0 * OBS_PI / 180.0;
    const obs_dvec3 n = obs_dv3(0.3 * sin(t), sin(t), cos(t));
    const double ln = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 64, 48, 60.0, obs_dv3(n.x / ln, n.y / ln, n.z / ln), -4.0,
                            OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    obs_image_f32 nrm[3];
    for (int c = 0; c < 3; c++) {
        CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &nrm[c]), ctx);
        const float v = (float)((c == 0 ? n.x : c == 1 ? n.y : n.z) / ln);
        for (int y = 0; y < 48; y++)
            for (int x = 0; x < 64; x++)
                obs_image_f32_row(&nrm[c], y)[x] = v;
    }
    ao_gtao_params p = ao_gtao_params_default();
    p.blur = 0;
    p.normals = AO_GTAO_NORMALS_DEPTH;
    obs_image_f32 a, b;
    CHECK_OK(run_gtao(ctx, NULL, &s.in, &p, &a, NULL), ctx);
    ao_input in = s.in;
    for (int c = 0; c < 3; c++)
        in.normal[c] = &nrm[c];
    p.normals = AO_GTAO_NORMALS_AUTO; /* the G-buffer's, since the input has them */
    CHECK_OK(run_gtao(ctx, NULL, &in, &p, &b, NULL), ctx);
    double worst = 0;
    for (int y = 2; y < 46; y++)
        for (int x = 2; x < 62; x++) {
            const double d = fabs(obs_image_f32_row(&a, y)[x] - obs_image_f32_row(&b, y)[x]);
            worst = d > worst ? d : worst;
        }
    printf("gtao normals from depth vs exact: worst AO difference %.2e\n", worst);
    CHECK_MSG(worst < 2e-4, "worst %g", worst); /* measured 4.1e-5 */
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&nrm[c]);
    obs_image_f32_free(&a);
    obs_image_f32_free(&b);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

TEST(gtao_gpu_packing_quantises_like_xegtao_storage_and_stays_close_to_fp32)
{
    /* gpu_packing: the final value is a byte (k/255), the raw term a byte of saturate(v / 1.5)
     * times 1.5; against the FP32 reference the sphere scene differs by at most a few bytes
     * (measured: 0.0052 without passes, 0.0038 .. 0.0047 with 1 .. 3; bound 0.01). */
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    tu_ao_scene(&scene);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &scene, tu_ao_camera(), 96, 72, 0, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    for (int passes = 0; passes <= 3; passes++) {
        ao_gtao_params p = ao_gtao_params_default();
        p.denoise_passes = passes;
        obs_image_f32 a, ar, b, br;
        CHECK_OK(run_gtao(ctx, NULL, &in, &p, &a, &ar), ctx);
        p.gpu_packing = 1;
        CHECK_OK(run_gtao(ctx, NULL, &in, &p, &b, &br), ctx);
        double worst = 0;
        int bytes = 1, raw_bytes = 1;
        for (int y = 0; y < b.height; y++)
            for (int x = 0; x < b.width; x++) {
                const double v = obs_image_f32_row(&b, y)[x], r = obs_image_f32_row(&br, y)[x];
                bytes &= fabs(v * 255.0 - nearbyint(v * 255.0)) < 1e-3;
                raw_bytes &= r == 1.0 || fabs(r / 1.5 * 255.0 - nearbyint(r / 1.5 * 255.0)) < 1e-3;
                const double d = fabs(v - obs_image_f32_row(&a, y)[x]);
                worst = d > worst ? d : worst;
            }
        printf("gtao gpu packing, %d passes: worst difference to FP32 %.4f\n", passes, worst);
        CHECK(bytes && raw_bytes);
        CHECK_MSG(worst < 0.01, "passes %d: worst %g", passes, worst);
        obs_image_f32_free(&a);
        obs_image_f32_free(&ar);
        obs_image_f32_free(&b);
        obs_image_f32_free(&br);
    }
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

/* ---- speed (issue 12): the outputs' bits, recorded before the fixed-cost changes ---------------- */

/* FNV-1a 64 of a plane's float bits, row by row */
static uint64_t plane_hash(const obs_image_f32 *a, uint64_t h)
{
    for (int y = 0; y < a->height; y++) {
        const unsigned char *b = (const unsigned char *)obs_image_f32_row(a, y);
        for (size_t i = 0; i < sizeof(float) * (size_t)a->width; i++)
            h = (h ^ b[i]) * 0x100000001b3ull;
    }
    return h;
}

/* The 14 parameter sets of gtao_outputs_keep_their_recorded_bits */
static void golden_params(int c, ao_gtao_params *p)
{
    static const char *const pre[5] = {"low", "medium", "high", "ultra", "soft"};
    ao_gtao_params_preset(c < 5 ? pre[c] : "default", p);
    if (c == 5)
        p->final_value_power = 1.0f, p->sample_distribution_power = 1.7f;
    if (c == 6)
        p->final_value_power = 3.3f, p->thin_occluder_compensation = 0.4f;
    if (c == 7)
        p->gpu_packing = 1, p->denoise_passes = 2;
    if (c == 8)
        p->denoise_passes = 0, p->frame_index = 37;
    if (c == 9)
        p->blur = 0, p->slices = 1, p->steps = 2;
    if (c == 10)
        p->normals = AO_GTAO_NORMALS_DEPTH, p->slices = 1, p->steps = 2;
    if (c == 11)
        p->normals = AO_GTAO_NORMALS_DEPTH, p->denoise_passes = 3, p->frame_index = 70;
    if (c == 12)
        p->radius = 1e-5f, p->depth_mip_sampling_offset = 0.0f;
    if (c == 13)
        p->radius = 3.0f, p->radius_multiplier = 3.0f;
}

/* The final and raw planes of the sphere scene at W x H (guard 6: the window is a crop), with
 * background, a band of NaN / 1e30 / 7e4 / +inf / negative depths, a zero depth, a NaN G-buffer
 * normal, and params set c; hashed together. */
static obs_status golden_hash(obs_context *ctx, obs_pool *pool, const rast_gbuffer *gb, int c, uint64_t *h)
{
    ao_input in;
    obs_status st = ao_input_from_gbuffer(ctx, gb, 1, &in);
    ao_gtao_params p;
    golden_params(c, &p);
    obs_image_f32 o = {0}, r = {0};
    if (st == OBS_STATUS_OK)
        st = run_gtao(ctx, pool, &in, &p, &o, &r);
    if (st == OBS_STATUS_OK)
        *h = plane_hash(&r, plane_hash(&o, 0xcbf29ce484222325ull));
    obs_image_f32_free(&o);
    obs_image_f32_free(&r);
    return st;
}

static obs_status golden_gbuffer(obs_context *ctx, int W, int H, rast_gbuffer *gb)
{
    obs_scene scene;
    tu_ao_scene(&scene);
    obs_status st = tu_render_depth_normal(ctx, &scene, tu_ao_camera(), W, H, 6, gb);
    obs_scene_free(&scene);
    if (st != OBS_STATUS_OK)
        return st;
    for (int x = 12; x < 70; x++) {
        float *row = obs_image_f32_row(&gb->depth, 50 + x % 7);
        row[x] = x % 5 == 0 ? NAN : x % 5 == 1 ? 1e30f : x % 5 == 2 ? 7e4f : x % 5 == 3 ? INFINITY : -1.0f;
    }
    obs_image_f32_row(&gb->depth, 70)[100] = 0.0f;
    obs_image_f32_row(&gb->normal[0], 80)[95] = NAN;
    return OBS_STATUS_OK;
}

/* Recorded with the code before issue 12's changes (commit e0da11c's ao_gtao.c, glibc's pow), on
 * x86-64 with AVX2 and with OBS_ISA=scalar (the same values). */
static const uint64_t golden_expected[14] = {
    0xdbd199be62386cb3ull, /* 0 */
    0x3f2d086d577abb72ull, /* 1 */
    0xc910e498f12a92e2ull, /* 2 */
    0x4340eb46caedc6bcull, /* 3 */
    0x752af54eb8d157ddull, /* 4 */
    0x362b76a53f7b8455ull, /* 5 */
    0x76d48fb3bd71b7c9ull, /* 6 */
    0xa86b190c5e58d572ull, /* 7 */
    0xea0eac3032058593ull, /* 8 */
    0x0abba5d7888f01e9ull, /* 9 */
    0x5f0911b6ca1947c7ull, /* 10 */
    0xa874c6c83bd5cf1full, /* 11 */
    0xd034bc57c53b1a9cull, /* 12 */
    0xd689e49ba04fa097ull, /* 13 */
};

TEST(gtao_outputs_keep_their_recorded_bits)
{
    /* Issue 12 ("GTAO's fixed cost") changed how the planes are allocated and kept, how the final
     * power is evaluated, and which pixels get edges and set-up, without changing an output bit:
     * these are the final and raw planes' hashes from before, for 14 parameter sets (presets, powers,
     * packing, 0-3 denoise passes, normals from depth, tiny and huge radii), for 1 and 3 threads,
     * the AVX2 and the scalar paths, and with the context's kept workspace reused across calls of
     * other sizes and params (a stale plane would show). */
    obs_context *ctx = obs_context_create();
    rast_gbuffer gb, small;
    CHECK_OK(golden_gbuffer(ctx, 160, 120, &gb), ctx);
    CHECK_OK(golden_gbuffer(ctx, 131, 97, &small), ctx);
    const int print = getenv("OBS_GTAO_PRINT_GOLDEN") != NULL;
    for (int isa = 0; isa < 2; isa++) {
        if (isa)
            setenv("OBS_ISA", "scalar", 1);
        for (int t = 1; t <= 3; t += 2) {
            obs_pool *pool = obs_pool_create(t);
            for (int c = 0; c < 14; c++) {
                uint64_t h = 0, hs = 0;
                CHECK_OK(golden_hash(ctx, pool, &gb, c, &h), ctx);
                if (print)
                    printf("    0x%016llxull, /* %d */\n", (unsigned long long)h, c);
                else
                    CHECK_MSG(h == golden_expected[c], "set %d, isa %d, threads %d: 0x%016llx", c, isa, t,
                              (unsigned long long)h);
                /* a call of another size and other params in between, then set c again */
                CHECK_OK(golden_hash(ctx, pool, &small, 13 - c, &hs), ctx);
                CHECK_OK(golden_hash(ctx, pool, &gb, c, &hs), ctx);
                CHECK_MSG(hs == h, "set %d after a smaller call: 0x%016llx", c, (unsigned long long)hs);
            }
            obs_pool_destroy(pool);
        }
        unsetenv("OBS_ISA");
    }
    /* a fresh context gives the same bits as the one that kept its workspace */
    obs_context *fresh = obs_context_create();
    uint64_t h = 0;
    CHECK_OK(golden_hash(fresh, NULL, &gb, 2, &h), fresh);
    CHECK(print || h == golden_expected[2]);
    obs_context_destroy(fresh);
    rast_gbuffer_free(&small);
    rast_gbuffer_free(&gb);
    obs_context_destroy(ctx);
}

TEST(gtao_background_edges_are_packed_ones)
{
    /* the main pass writes 0xFF without arithmetic for a background pixel whose five MIP-0 taps are
     * the 65504 clamp (ao_gtao.c, main_row): that is what XeGTAO_CalculateEdges / PackEdges give */
    float e[4];
    ao_gtao_calculate_edges(AO_GTAO_DEPTH_CLAMP, AO_GTAO_DEPTH_CLAMP, AO_GTAO_DEPTH_CLAMP, AO_GTAO_DEPTH_CLAMP,
                            AO_GTAO_DEPTH_CLAMP, e);
    for (int i = 0; i < 4; i++)
        CHECK(e[i] == 1.0f);
    CHECK_EQ_INT(ao_gtao_pack_edges(e), 0xFF);
}

TEST(gtao_final_power_equals_libm_pow)
{
    /* ao_gtao_final_power against (float)pow((double)x, (double)p), the main pass's power before
     * issue 12: every 509th float in [0, 2] (2.1 M inputs), the 256 floats around each of the
     * 127 x 128 table cells' starts, the ends and special values, for p = 2.2f (the table path) and,
     * sampled, for other powers (pow itself). The exhaustive check of [0, 2] is
     * scripts/gtao_final_power_check.c (0 differences). */
    long bad = 0, n = 0;
    const float p = 2.2f;
#define CMP(xv, pv)                                                                                 \
    do {                                                                                            \
        const float x_ = (xv), a_ = ao_gtao_final_power(x_, (pv)), b_ = (float)pow((double)x_, (double)(pv)); \
        bad += memcmp(&a_, &b_, 4) != 0 && !(isnan(a_) && isnan(b_));                               \
        n++;                                                                                        \
    } while (0)
    for (uint32_t u = 0; u <= 0x40000000u; u += 509) {
        float x;
        memcpy(&x, &u, 4);
        CMP(x, p);
        if (u % (509u * 64u) == 0) {
            CMP(x, 1.7f);
            CMP(x, 3.3f);
            CMP(x, 2.0f);
        }
    }
    for (uint32_t e = 1; e <= 127; e++)
        for (uint32_t i = 0; i < 128; i++)
            for (int d = -128; d < 128; d++) {
                const uint32_t u = (e << 23) + (i << 16) + (uint32_t)d;
                float x;
                memcpy(&x, &u, 4);
                CMP(x, p);
            }
    const float special[] = {0.0f, -0.0f, -1.0f, -0.5f, 0x1p-126f, 0x1p-149f, 0x1.fffffep-127f, 1.0f, 2.0f,
                             0x1.fffffep0f, 1.5f, 0.03f, 0.2034f, 3.0f, 1e30f, INFINITY, -INFINITY, NAN};
    for (size_t i = 0; i < sizeof special / sizeof special[0]; i++)
        CMP(special[i], p);
#undef CMP
    CHECK_MSG(bad == 0, "%ld of %ld differ", bad, n);
}
