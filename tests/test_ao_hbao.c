/* test_ao_hbao.c: HBAO (src/ao/ao_hbao.c): the flat plane, the random texture and the per-pixel
 * pattern recomputed independently, hand-computed horizons (a step and a 90-degree wall), accuracy
 * on the sphere-over-ground scene against the matched ground truth, the blur, determinism, hard
 * cases, parameter validation and the CLI. docs/ao/hbao.md records the figures. */
#include "ao/ao.h"
#include "ao/ao_internal.h"
#include "ao_test_util.h"
#include "test.h"
#include "truth/truth.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static obs_status hb_run(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_hbao_params *p,
                         obs_image_f32 *out, obs_image_f32 *raw, ao_hbao_stats *stats)
{
    memset(out, 0, sizeof *out);
    memset(raw, 0, sizeof *raw);
    obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in->w, in->h, raw);
    if (st == OBS_STATUS_OK)
        st = ao_hbao_compute(ctx, pool, in, p, out, raw, stats);
    return st;
}

static float px(const obs_image_f32 *a, int x, int y) { return obs_image_f32_row(a, y)[x]; }

/* ---- flat plane ------------------------------------------------------------------------------ */

TEST(hbao_flat_open_plane_is_fully_visible)
{
    obs_context *ctx = obs_context_create();
    /* facing the camera and tilted 50 degrees; both variants, depth and G-buffer-free normals */
    const obs_dvec3 normals[2] = {{0, 0, 1}, {0, 0.766044443, 0.642787610}};
    const double offsets[2] = {-5.0, -4.0};
    for (int pl = 0; pl < 2; pl++) {
        tu_synth s;
        CHECK_OK(tu_synth_plane(ctx, 96, 64, 80.0, normals[pl], offsets[pl], OBS_PROJECTION_PERSPECTIVE, &s), ctx);
        for (int var = 0; var < 2; var++) {
            ao_hbao_params p = ao_hbao_params_default();
            p.variant = (ao_hbao_variant)var;
            p.radius = 0.5f;
            p.blur = 0;
            obs_image_f32 out, raw;
            CHECK_OK(hb_run(ctx, NULL, &s.in, &p, &out, &raw, NULL), ctx);
            /* exactly 1 away from the first/last row and column (CLAMP_TO_EDGE artifact there) */
            for (int y = 1; y < 63; y++)
                for (int x = 1; x < 95; x++)
                    CHECK_MSG(px(&out, x, y) == 1.0f, "plane %d variant %d: AO(%d,%d) = %.9g", pl, var, x, y,
                              (double)px(&out, x, y));
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
        }
        obs_image_f32_free(&s.depth);
    }
    obs_context_destroy(ctx);
}

/* ---- the random texture and the pattern --------------------------------------------------------- */

TEST(mt19937_matches_its_published_reference_outputs)
{
    ao_i_mt19937 m;
    /* ISO C++ [rand.predef]: the 10000th output of a default-constructed std::mt19937 (seed 5489)
     * is 4123659995; its first is 3499211612 */
    ao_i_mt19937_seed(&m, 5489u);
    uint32_t v = ao_i_mt19937_next(&m), last = v;
    CHECK(v == 3499211612u);
    for (int i = 1; i < 10000; i++)
        last = ao_i_mt19937_next(&m);
    CHECK_MSG(last == 4123659995u, "10000th output %u", (unsigned)last);
    /* init_genrand(0) (MTRand::seed(0), std::mt19937(0)): 2357136044, 2546248239, 3071714933 */
    ao_i_mt19937_seed(&m, 0u);
    CHECK(ao_i_mt19937_next(&m) == 2357136044u);
    CHECK(ao_i_mt19937_next(&m) == 2546248239u);
    CHECK(ao_i_mt19937_next(&m) == 3071714933u);
}

TEST(hbao_noise_texture_is_mt19937_seed_0_in_snorm16)
{
    /* gl_ssao's 4 x 4: r = float(genrand * 2^-32); MT19937 init_genrand(0) starts 2357136044, 2546248239 */
    const double r1 = (double)(float)(2357136044.0 / 4294967296.0);
    const double r2 = (double)(float)(2546248239.0 / 4294967296.0);
    int16_t sh[64];
    float t[16][4];
    ao_hbao_noise_texture(8, sh, t);
    /* texel 0: alpha = 2 pi r1 / 8 */
    const double a = (double)(2.0f * 3.14159265f * (float)r1 / 8.0f);
    CHECK_EQ_INT(sh[0], (int)(32768.0 * (double)(float)cos(a)));
    CHECK_EQ_INT(sh[1], (int)(32768.0 * (double)(float)sin(a)));
    CHECK_EQ_INT(sh[2], (int)(32768.0 * r2));
    CHECK_EQ_INT(sh[3], 0);
    CHECK(t[0][0] == (float)(sh[0] / 32767.0) && t[0][2] == (float)(sh[2] / 32767.0));
    /* every texel: a unit rotation within [0, 2 pi / N_d), jitter in [0, 1] */
    for (int nd = 1; nd <= 32; nd *= 2) {
        ao_hbao_noise_texture(nd, sh, t);
        for (int i = 0; i < 16; i++) {
            double ang = atan2(t[i][1], t[i][0]);
            ang = ang < -1e-4 ? ang + 2.0 * OBS_PI : ang;
            CHECK_MSG(ang >= -1e-4 && ang < 2.0 * OBS_PI / nd + 1e-4, "N_d %d texel %d angle %g", nd, i, ang);
            CHECK_NEAR(t[i][0] * t[i][0] + t[i][1] * t[i][1], 1.0, 2e-4);
            CHECK(t[i][2] >= 0.0f && t[i][2] <= 1.0f && t[i][3] == 0.0f);
        }
    }
}

TEST(hbao_sdk_noise_texture_is_update_dirs_mt19937_seed_0)
{
    enum { N = AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK };
    static int16_t sh[N * 4];
    static float t[N][4];
    /* HorizonBasedAOEngine.cpp UpdateDirs with m_NumDirs 16: per texel, angle = float(2pi_f * randExc / 16)
     * in double, (short)(32768 cosf / sinf), (short)(32768 randExc) = genrand >> 17 */
    ao_hbao_noise_texture_sdk(16, sh, t);
    ao_i_mt19937 m;
    ao_i_mt19937_seed(&m, 0u);
    int bad = 0, wrapped = 0;
    for (int i = 0; i < N; i++) {
        const uint32_t g1 = ao_i_mt19937_next(&m), g2 = ao_i_mt19937_next(&m);
        const float ang = (float)((double)(2.0f * 3.141592654f) * ((double)g1 / 4294967296.0) / 16.0);
        int c = (int)(32768.0f * (float)cos((double)ang));
        const int s = (int)(32768.0f * (float)sin((double)ang));
        /* cosf = 1.0 gives 32768, which a short cannot hold: MSVC keeps the low 16 bits, -32768 */
        wrapped += c == 32768;
        c = c == 32768 ? -32768 : c;
        bad += sh[4 * i] != c || sh[4 * i + 1] != s || sh[4 * i + 2] != (int)(g2 >> 17) || sh[4 * i + 3] != 0;
        bad += t[i][2] != (float)((double)(g2 >> 17) / 32767.0);
        bad += sh[4 * i] == -32768 && t[i][0] != -1.0f;
    }
    CHECK_EQ_INT(bad, 0);
    printf("  N_d 16: %d of 4096 texels have cosf(angle) = 1 (stored -32768)\n", wrapped);
    /* texel 0 by hand: genrand 2357136044, 2546248239 */
    CHECK_EQ_INT(sh[2], (int)(2546248239u >> 17));
    /* every N_d: unit rotations within [0, 2 pi / N_d), jitter in [0, 1) */
    for (int nd = 1; nd <= 32; nd *= 2) {
        ao_hbao_noise_texture_sdk(nd, sh, t);
        for (int i = 0; i < N; i++) {
            CHECK_NEAR(t[i][0] * t[i][0] + t[i][1] * t[i][1], 1.0, 2e-4);
            CHECK(t[i][2] >= 0.0f && t[i][2] < 1.0f && t[i][3] == 0.0f);
            if (sh[4 * i] == -32768 || sh[4 * i + 1] == -32768) /* wrapped (cosf or sinf = 1): not a rotation in range */
                continue;
            double ang = atan2(t[i][1], t[i][0]);
            ang = ang < -1e-4 ? ang + 2.0 * OBS_PI : ang;
            CHECK_MSG(ang >= -1e-4 && ang < 2.0 * OBS_PI / nd + 1e-4, "N_d %d texel %d angle %g", nd, i, ang);
        }
    }
}

TEST(hbao_pattern_constants_and_noise_index_match_the_shaders)
{
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 40, 30, 25.0, obs_dv3(0, 0, 1), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_hbao_params p = ao_hbao_params_default();
    ao_hbao_constants k = ao_hbao_constants_from_params(&p, &s.in);
    /* SDK defaults: 16 x 8, 30 degrees, g_Contrast = 1.4 / (1 - sin 30deg) = 2.8 */
    CHECK_EQ_INT(k.num_dirs, 16);
    CHECK_EQ_INT(k.num_steps, 8);
    CHECK_NEAR(k.angle_bias, OBS_PI / 6.0, 1e-7);
    CHECK_NEAR(k.contrast, 2.8, 1e-6);
    CHECK_NEAR(k.tan_angle_bias, 0.577350269, 1e-7);
    /* g_FocalLen = 1/tan(fov/2) = 2 f / size: 2 * 25 / 40 and 2 * 25 / 30 */
    CHECK_NEAR(k.focal_len[0], 1.25, 1e-7);
    CHECK_NEAR(k.focal_len[1], 50.0 / 30.0, 1e-6);
    CHECK_NEAR(k.dirs[4][0], 0.0, 1e-7);
    CHECK_NEAR(k.dirs[4][1], 1.0, 1e-7);
    /* D3D uv -> view: pixel (3, 5) at depth 3 is ((3.5 - 20)/25 * 3, -(5.5 - 15)/25 * 3, 3) */
    const float u = 3.5f / 40.0f, v = 5.5f / 30.0f;
    CHECK_NEAR((u * k.uv_to_view[0] + k.uv_to_view[2]) * 3.0f, (3.5 - 20.0) / 25.0 * 3.0, 1e-6);
    CHECK_NEAR((v * k.uv_to_view[1] + k.uv_to_view[3]) * 3.0f, -(5.5 - 15.0) / 25.0 * 3.0, 1e-6);
    /* noise index: CLASSIC D3D rows, the SDK's 64 x 64 ((y & 63) * 64 + (x & 63)); with gl_ssao's
     * 4 x 4 (y & 3); PLUS GL rows ((H - 1 - y) & 3) */
    CHECK_EQ_INT(k.noise, AO_HBAO_NOISE_SDK);
    CHECK_EQ_INT(k.noise_size, 64);
    CHECK_EQ_INT(ao_hbao_noise_index(&k, 3, 5), 5 * 64 + 3);
    CHECK_EQ_INT(ao_hbao_noise_index(&k, 70, 129), 1 * 64 + 6);
    {
        ao_hbao_params q4 = p;
        q4.noise = AO_HBAO_NOISE_GL_SSAO;
        const ao_hbao_constants k4 = ao_hbao_constants_from_params(&q4, &s.in);
        CHECK_EQ_INT(k4.noise_size, 4);
        CHECK_EQ_INT(ao_hbao_noise_index(&k4, 3, 5), 1 * 4 + 3);
    }
    ao_hbao_params q;
    CHECK(ao_hbao_params_preset("plus", &q));
    ao_hbao_constants kp = ao_hbao_constants_from_params(&q, &s.in);
    CHECK_EQ_INT(kp.noise, AO_HBAO_NOISE_GL_SSAO);
    CHECK_EQ_INT(ao_hbao_noise_index(&kp, 3, 5), ((30 - 1 - 5) & 3) * 4 + 3);
    CHECK_EQ_INT(kp.num_dirs, 8);
    CHECK_EQ_INT(kp.num_steps, 4);
    /* HBAO+: RadiusToScreen = R * 0.5 / tan(fovy/2) * H = R fy; AOMultiplier = 1/(1 - 0.1) */
    CHECK_NEAR(kp.radius_to_screen, 25.0, 1e-6);
    CHECK_NEAR(kp.ao_multiplier, 1.0 / 0.9, 1e-7);
    CHECK_NEAR(kp.alpha, 0.785398163, 1e-7);
    /* GL projInfo: pixel (3, y_gl = 30 - 1 - 5 = 24) at depth 3 */
    const float vg = 24.5f / 30.0f;
    CHECK_NEAR((vg * kp.uv_to_view[1] + kp.uv_to_view[3]) * 3.0f, -(5.5 - 15.0) / 25.0 * 3.0, 1e-6);
    /* blur: sigma = (4 + 1)/2, BlurFalloff = 1/(2 sigma^2) = 0.08; gl-ssao: sigma 1.5 */
    CHECK_NEAR(kp.blur_falloff, 0.08, 1e-8);
    CHECK(ao_hbao_params_preset("gl-ssao", &q));
    kp = ao_hbao_constants_from_params(&q, &s.in);
    CHECK_NEAR(kp.blur_falloff, 1.0 / 4.5, 1e-7);
    CHECK_NEAR(kp.radius_to_screen, 50.0, 1e-6);
    /* the JSON has the texture and the per-variant block */
    char buf[8192];
    const ao_method *m = ao_method_find("hbao");
    CHECK(m != NULL);
    int n = m->constants_to_json(&p, &s.in, buf, sizeof buf);
    CHECK(n > 0 && n < (int)sizeof buf);
    CHECK(m->constants_to_json(&p, &s.in, NULL, 0) == n);
    CHECK(strstr(buf, "\"g_Contrast\"") && strstr(buf, "\"g_Dirs\"") && strstr(buf, "\"random_texture\": \"dx10-sdk\""));
    CHECK(m->constants_to_json(&q, &s.in, buf, sizeof buf) < (int)sizeof buf);
    CHECK(strstr(buf, "random_texture_rgba16_snorm"));
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- hand-computed horizons ---------------------------------------------------------------- */

/* An orthographic view (0.1 m per pixel) of a floor at depth 10 with a block 1 m nearer to the
 * right of column 32. Far from the step and on the block: 1. Left of it: darker towards the step.
 * Then, with 1 direction and 1 step, every pixel whose tap lands on the block is checked against
 * the horizon formula evaluated by hand in double: AO = 1 - W(r) (sin S - sin H0) g_Contrast. */
TEST(hbao_step_occludes_by_the_horizon_formula)
{
    obs_context *ctx = obs_context_create();
    const int W = 64, H = 16;
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
    const float h = 1.0f;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&depth, y)[x] = x >= 32 ? 10.0f - h : 10.0f;
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = W;
    in.height = in.h = H;
    in.depth = &depth;
    in.fx = in.fy = 10.0; /* 0.1 m per pixel */
    in.cx = 0.5 * W;
    in.cy = 0.5 * H;
    in.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    ao_hbao_params p = ao_hbao_params_default();
    p.blur = 0;
    p.radius = 2.0f;
    p.contrast = 1.0f;
    p.attenuation = 0.0f; /* W = 1: the value is the horizon term alone */
    obs_image_f32 out, raw;
    CHECK_OK(hb_run(ctx, NULL, &in, &p, &out, &raw, NULL), ctx);
    /* far from the step (beyond R = 20 px) and on top of it: unoccluded */
    CHECK(px(&out, 5, 8) == 1.0f);
    CHECK(px(&out, 40, 8) == 1.0f);
    /* left of the step: occluded, more so closer to it (monotone within the reach) */
    for (int x = 14; x < 31; x++)
        CHECK_MSG(px(&out, x, 8) <= px(&out, x - 1, 8) + 1e-6f, "not monotone at %d: %g > %g", x,
                  (double)px(&out, x, 8), (double)px(&out, x - 1, 8));
    const float a31 = px(&out, 31, 8);
    CHECK_MSG(a31 > 0.5f && a31 < 0.95f, "AO next to the step %g", (double)a31);
    /* By hand: 1 direction, 1 step, attenuation 1. numSteps = min(1, 20 px) = 1, so the step is
     * 20 / 2 = 10 px; deltaUV = rand.xy * 10 px; the tap sits at round(rand.z * delta) + round(delta)
     * (D3D rows: +v is our +y). On the flat floor T.z = 0: H0 = the 30 degree bias, sin H0 = 1/2. */
    {
        ao_hbao_params q = p;
        q.directions = 1;
        q.steps = 1;
        q.attenuation = 1.0f;
        obs_image_f32 o1, r1;
        CHECK_OK(hb_run(ctx, NULL, &in, &q, &o1, &r1, NULL), ctx);
        static float tex[64 * 64][4]; /* the classic default: the SDK's 64 x 64 texture, D3D rows */
        ao_hbao_noise_texture_sdk(1, NULL, tex);
        int checked = 0;
        for (int y0 = 3; y0 < 13; y0++)
            for (int x0 = 18; x0 < 32; x0++) {
                const float *rd = tex[(y0 & 63) * 64 + (x0 & 63)];
                const double dx = 10.0 * rd[0], dy = 10.0 * rd[1];
                const int ox = (int)nearbyint(rd[2] * dx) + (int)nearbyint(dx);
                const int oy = (int)nearbyint(rd[2] * dy) + (int)nearbyint(dy);
                if (x0 + ox < 32 || x0 + ox >= W || y0 + oy < 0 || y0 + oy >= H)
                    continue;
                const double dxy2 = (0.1 * ox) * (0.1 * ox) + (0.1 * oy) * (0.1 * oy), d2 = dxy2 + (double)h * h;
                double expect = 1.0;
                const double tanS = (double)h / sqrt(dxy2);
                if (d2 < 4.0 && tanS > tan(OBS_PI / 6.0)) {
                    const double sinS = tanS / sqrt(1.0 + tanS * tanS);
                    expect = 1.0 - (1.0 - d2 / 4.0) * (sinS - 0.5) * 2.0;
                }
                CHECK_MSG(fabs(px(&o1, x0, y0) - expect) <= 2e-6, "(%d,%d): %.7f, by hand %.7f", x0, y0,
                          (double)px(&o1, x0, y0), expect);
                checked += expect < 1.0;
            }
        CHECK_MSG(checked >= 3, "only %d occluded pixels checked", checked);
        obs_image_f32_free(&o1);
        obs_image_f32_free(&r1);
    }
    /* PLUS on the same step: each tap on the block top has N.V/|V| = sin of its elevation */
    p.variant = AO_HBAO_VARIANT_PLUS;
    p.pow_exponent = 1.0f;
    p.ndotv_bias = 0.0f;
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    CHECK_OK(hb_run(ctx, NULL, &in, &p, &out, &raw, NULL), ctx);
    CHECK(px(&out, 5, 8) == 1.0f);
    CHECK(px(&out, 31, 8) < 1.0f && px(&out, 31, 8) > 0.0f);
    printf("  step: classic AO(31) %.6f, plus AO(31) %.6f\n", (double)a31, (double)px(&out, 31, 8));
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&depth);
    obs_context_destroy(ctx);
}

/* A single tap, computed by hand: PLUS with 1 direction and 1 step on a constant-depth plane whose
 * pixel (x0, y) looks at a wall. The tap distance is round(RayPixels * dir) px, the tap's value
 * saturate(N.V/|V| - bias) * saturate(1 - |V|^2/R^2), AO = saturate(1 - 2 * tap / (1 - bias))^p. */
TEST(hbao_plus_single_tap_matches_hand_computation)
{
    obs_context *ctx = obs_context_create();
    const int W = 32, H = 32;
    const double f = 20.0;
    obs_image_f32 depth;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &depth), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&depth, y)[x] = 4.0f;
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = W;
    in.height = in.h = H;
    in.depth = &depth;
    in.fx = in.fy = f;
    in.cx = 0.5 * W;
    in.cy = 0.5 * H;
    in.projection = OBS_PROJECTION_PERSPECTIVE;
    ao_hbao_params p;
    CHECK(ao_hbao_params_preset("plus", &p));
    p.blur = 0;
    p.directions = 1;
    p.steps = 1;
    p.radius = 1.0f;
    p.pow_exponent = 1.0f;
    const int x0 = 16, y0 = 16, y_gl = H - 1 - y0;
    ao_hbao_constants k = ao_hbao_constants_from_params(&p, &in);
    float tex[16][4];
    ao_hbao_noise_texture(1, NULL, tex);
    const float *rd = tex[((y_gl & 3) * 4) + (x0 & 3)];
    /* radius 20 px at depth 1 -> 5 px at depth 4; step = 5 / 2; first tap at rand.z * 2.5 + 1 */
    const double ray = rd[2] * 2.5 + 1.0;
    const int ox = (int)nearbyint(ray * rd[0]), oy_gl = (int)nearbyint(ray * rd[1]);
    /* put a nearer occluder (depth 3.5) at that tap */
    obs_image_f32_row(&depth, H - 1 - (y_gl + oy_gl))[x0 + ox] = 3.5f;
    obs_image_f32 out, raw;
    CHECK_OK(hb_run(ctx, NULL, &in, &p, &out, &raw, NULL), ctx);
    /* by hand, in the shader's eye space (z into the screen, y up): P, S, N = (0, 0, -1) */
    const double Px = (x0 + 0.5 - 16) / f * 4, Py = (y_gl + 0.5 - 16) / f * 4;
    const double Sx = (x0 + ox + 0.5 - 16) / f * 3.5, Sy = (y_gl + oy_gl + 0.5 - 16) / f * 3.5;
    const double Vx = Sx - Px, Vy = Sy - Py, Vz = 3.5 - 4.0;
    const double VV = Vx * Vx + Vy * Vy + Vz * Vz;
    const double ndv = -Vz / sqrt(VV);
    double tap = fmin(fmax(ndv - 0.1, 0), 1) * fmin(fmax(1 - VV, 0), 1);
    const double A = fmin(fmax(1 - 2 * tap / 0.9, 0), 1);
    CHECK_NEAR(px(&out, x0, y0), A, 2e-6);
    CHECK(px(&out, x0, y0) < 1.0f);
    /* HBAO+'s split (CoarseAO_PS): the single step is the first, weighing 2 * SmallScaleAO / (1 - bias) */
    p.small_scale_ao = 1.0f;
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    CHECK_OK(hb_run(ctx, NULL, &in, &p, &out, &raw, NULL), ctx);
    CHECK_NEAR(px(&out, x0, y0), fmin(fmax(1 - 2 * (2 * tap / 0.9), 0), 1), 2e-6);
    (void)k;
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&depth);
    obs_context_destroy(ctx);
}

/* ---- accuracy on the analytic scene -------------------------------------------------------- */

typedef struct acc_result {
    double rmse, bias;
    int64_t n;
} acc_result;

static int accuracy(obs_context *ctx, const ao_hbao_params *p, acc_result *res)
{
    obs_scene s;
    tu_ao_scene(&s);
    const obs_camera cam = tu_ao_camera();
    rast_params rp = rast_params_default();
    rp.width = 128;
    rp.height = 96;
    rp.guard = 16;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    rast_gbuffer gb;
    int ok = rast_gbuffer_alloc(ctx, &rp, &gb) == OBS_STATUS_OK;
    rast_view v = {cam};
    ok = ok && rast_render(ctx, NULL, &s, &v, 1, &rp, &gb, NULL) == OBS_STATUS_OK;
    truth_scene *ts = NULL;
    ok = ok && truth_scene_create(ctx, &s, TRUTH_BUILD_MEDIUM, &ts) == OBS_STATUS_OK;
    ao_input in;
    ok = ok && ao_input_from_gbuffer(ctx, &gb, 0, &in) == OBS_STATUS_OK;
    obs_image_f32 out = {0}, raw = {0};
    ok = ok && hb_run(ctx, NULL, &in, p, &out, &raw, NULL) == OBS_STATUS_OK;
    truth_ao_params tp = truth_ao_params_default();
    const ao_method *m = ao_method_find("hbao");
    ok = ok && truth_ao_estimator_from_name(m->truth_estimator(p), &tp.estimator);
    tp.radius = p->radius;
    tp.target_error = 0.01;
    tp.max_samples = 1024;
    truth_ao_result tr;
    memset(&tr, 0, sizeof tr);
    ok = ok && truth_ao_render(ctx, NULL, ts, &s, &cam, &gb, &tp, &tr) == OBS_STATUS_OK;
    double se = 0, sb = 0;
    int64_t n = 0;
    if (ok)
        for (int y = 0; y < in.h; y++)
            for (int x = 0; x < in.w; x++) {
                if (px(&tr.count, x, y) <= 0.0f)
                    continue;
                const double e = (double)px(&out, x, y) - (double)px(&tr.mean, x, y);
                se += e * e;
                sb += e;
                n++;
            }
    res->n = n;
    res->rmse = n ? sqrt(se / (double)n) : 1.0;
    res->bias = n ? sb / (double)n : 1.0;
    truth_ao_result_free(&tr);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    return ok;
}

TEST(hbao_accuracy_against_matched_ground_truth)
{
    obs_context *ctx = obs_context_create();
    /* the bounds are the measured values (docs/ao/hbao.md) plus a margin */
    struct {
        const char *what;
        int variant;
        float contrast, pow_exponent;
        double rmse_max, bias_lo, bias_hi;
    } cases[] = {
        /* measured: RMSE 0.0597 bias +0.0062; 0.0467 +0.0115; 0.0722 +0.0130 (9801 pixels) */
        {"classic, defaults (contrast 1.4) vs obs-hbao", 0, 1.4f, 1.0f, 0.075, -0.02, 0.03},
        {"classic, contrast 1 vs obs-hbao", 0, 1.0f, 1.0f, 0.06, -0.01, 0.035},
        {"plus, PowExponent 1 vs obs-mssao", 1, 1.0f, 1.0f, 0.09, -0.01, 0.04},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        ao_hbao_params p = ao_hbao_params_default();
        p.variant = (ao_hbao_variant)cases[i].variant;
        p.radius = 0.5f;
        p.blur = 0;
        p.contrast = cases[i].contrast;
        p.pow_exponent = cases[i].pow_exponent;
        acc_result r;
        CHECK_MSG(accuracy(ctx, &p, &r), "%s: %s", cases[i].what, obs_context_last_error(ctx));
        printf("  %s: RMSE %.4f, bias %+.4f over %lld pixels\n", cases[i].what, r.rmse, r.bias, (long long)r.n);
        fflush(stdout);
        if (getenv("HBAO_MEASURE"))
            continue;
        CHECK(r.n > 1000);
        CHECK_MSG(r.rmse <= cases[i].rmse_max, "%s: RMSE %.4f > %.4f", cases[i].what, r.rmse, cases[i].rmse_max);
        CHECK_MSG(r.bias >= cases[i].bias_lo && r.bias <= cases[i].bias_hi, "%s: bias %.4f", cases[i].what, r.bias);
    }
    obs_context_destroy(ctx);
}

/* ---- the blur ------------------------------------------------------------------------------- */

TEST(hbao_blur_keeps_constants_respects_edges_and_background)
{
    obs_context *ctx = obs_context_create();
    const int W = 24, H = 16;
    obs_image_f32 ao, z, out;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ao), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &z), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &out), ctx);
    /* constant AO on a tilted plane (depth linear in x): stays constant with the depth slope */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            obs_image_f32_row(&ao, y)[x] = 0.625f;
            obs_image_f32_row(&z, y)[x] = 2.0f + 0.25f * (float)x;
        }
    CHECK_OK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, 16.0f, 1, &out), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            CHECK_NEAR(px(&out, x, y), 0.625, 2e-7);
    /* a depth edge with sharpness 16: the far side's AO does not leak across (weight
     * exp2(-(1 m * 16)^2) = 2^-256 ~ 0) */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            obs_image_f32_row(&ao, y)[x] = x < 12 ? 1.0f : 0.0f;
            obs_image_f32_row(&z, y)[x] = x < 12 ? 3.0f : 2.0f;
        }
    CHECK_OK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, 16.0f, 0, &out), ctx);
    CHECK(px(&out, 11, 5) == 1.0f && px(&out, 12, 5) == 0.0f);
    /* without an edge, an AO step is smoothed: weights by hand at r = 1..4, sigma 2.5 */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&z, y)[x] = 3.0f;
    CHECK_OK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, 16.0f, 0, &out), ctx);
    double w[5], wsum = 1.0, right = 0.0;
    for (int r = 1; r <= 4; r++) {
        w[r] = exp2(-(double)r * r * 0.08);
        wsum += 2 * w[r];
        right += w[r];
    }
    /* pixel 11: itself and the 4 left taps are 1, the 4 right taps 0 (horizontal pass; the
     * vertical pass sees a constant column) */
    CHECK_NEAR(px(&out, 11, 8), (1.0 + right) / wsum, 2e-6);
    /* background centres pass through, background taps weigh 0 */
    obs_image_f32_row(&z, 8)[13] = INFINITY;
    obs_image_f32_row(&ao, 8)[13] = 0.25f;
    CHECK_OK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, 16.0f, 1, &out), ctx);
    CHECK(px(&out, 13, 8) == 0.25f);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            CHECK(isfinite(px(&out, x, y)) && px(&out, x, y) >= 0.0f && px(&out, x, y) <= 1.0f);
    /* a window: equals the full blur cropped */
    obs_image_f32 win;
    CHECK_OK(obs_image_f32_alloc(ctx, 7, 5, &win), ctx);
    CHECK_OK(ao_hbao_blur(ctx, NULL, &ao, &z, 9, 6, 4, 0.0f, 16.0f, 1, &win), ctx);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 7; x++)
            CHECK(px(&win, x, y) == px(&out, 9 + x, 6 + y));
    /* bad arguments */
    CHECK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 0, 0.0f, 16.0f, 1, &out) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, -1.0f, 1, &out) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_hbao_blur(ctx, NULL, &ao, &z, 20, 0, 4, 0.0f, 16.0f, 1, &win) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_hbao_blur(ctx, NULL, &ao, &z, 0, 0, 4, 0.0f, 16.0f, 1, &ao) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&win);
    obs_image_f32_free(&ao);
    obs_image_f32_free(&z);
    obs_image_f32_free(&out);
    obs_context_destroy(ctx);
}

TEST(hbao_window_with_guard_band_equals_full_buffer_cropped)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 60, 44, 9, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    ao_input full = in;
    full.x0 = full.y0 = 0;
    full.w = full.width;
    full.h = full.height;
    for (int var = 0; var < 2; var++)
        for (int nm = 0; nm < 2; nm++) {
            ao_hbao_params p = ao_hbao_params_default();
            p.variant = (ao_hbao_variant)var;
            p.normals = (ao_hbao_normals)nm;
            obs_image_f32 a, ar, b, br;
            CHECK_OK(hb_run(ctx, NULL, &in, &p, &a, &ar, NULL), ctx);
            CHECK_OK(hb_run(ctx, NULL, &full, &p, &b, &br, NULL), ctx);
            for (int y = 0; y < in.h; y++)
                for (int x = 0; x < in.w; x++) {
                    CHECK_MSG(px(&a, x, y) == px(&b, in.x0 + x, in.y0 + y), "variant %d normals %d (%d,%d)", var,
                              nm, x, y);
                    CHECK(px(&ar, x, y) == px(&br, in.x0 + x, in.y0 + y));
                }
            obs_image_f32_free(&a);
            obs_image_f32_free(&ar);
            obs_image_f32_free(&b);
            obs_image_f32_free(&br);
        }
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- against Mesa llvmpipe: tests/gl/test_gl_hbao.c (the ports are in tests/gl/glsl_hbao.c) ---- */

/* ---- determinism and hard cases --------------------------------------------------------------- */

TEST(hbao_output_identical_for_1_2_8_threads)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 71, 53, 5, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    obs_pool *pools[3] = {obs_pool_create(1), obs_pool_create(2), obs_pool_create(8)};
    for (int var = 0; var < 2; var++)
        for (int nm = 0; nm < 2; nm++) {
            ao_hbao_params p = ao_hbao_params_default();
            p.variant = (ao_hbao_variant)var;
            p.normals = (ao_hbao_normals)nm;
            obs_image_f32 out[3], raw[3];
            for (int t = 0; t < 3; t++)
                CHECK_OK(hb_run(ctx, pools[t], &in, &p, &out[t], &raw[t], NULL), ctx);
            for (int t = 1; t < 3; t++)
                CHECK(tu_same_plane(&out[0], &out[t]) && tu_same_plane(&raw[0], &raw[t]));
            for (int t = 0; t < 3; t++) {
                obs_image_f32_free(&out[t]);
                obs_image_f32_free(&raw[t]);
            }
        }
    for (int t = 0; t < 3; t++)
        obs_pool_destroy(pools[t]);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

static int all_unit(const obs_image_f32 *a)
{
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++) {
            float v = px(a, x, y);
            if (!(v >= 0.0f && v <= 1.0f))
                return 0;
        }
    return 1;
}

TEST(hbao_hard_cases_stay_finite)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    static const int sizes[][2] = {{1, 1}, {1, 7}, {9, 1}, {3, 5}, {7, 2}, {33, 17}, {80, 60}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        rast_gbuffer gb;
        CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), sizes[i][0], sizes[i][1], 0, &gb), ctx);
        ao_input in;
        CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
        for (int var = 0; var < 2; var++)
            for (int nm = 0; nm < 2; nm++)
                for (int r = 0; r < 4; r++) {
                    static const float radii[] = {1e-4f, 0.5f, 50.0f, 1e5f};
                    ao_hbao_params p = ao_hbao_params_default();
                    p.variant = (ao_hbao_variant)var;
                    p.normals = (ao_hbao_normals)nm;
                    p.radius = radii[r];
                    p.directions = 32;
                    p.steps = r == 3 ? 32 : 0;
                    p.angle_bias_deg = r == 2 ? 0.0f : 30.0f;
                    obs_image_f32 out, raw;
                    CHECK_OK(hb_run(ctx, NULL, &in, &p, &out, &raw, NULL), ctx);
                    CHECK_MSG(all_unit(&out) && all_unit(&raw), "size %dx%d variant %d normals %d radius %g",
                              sizes[i][0], sizes[i][1], var, nm, (double)radii[r]);
                    obs_image_f32_free(&out);
                    obs_image_f32_free(&raw);
                }
        rast_gbuffer_free(&gb);
    }
    /* an external reversed-Z buffer with an infinite far plane: linear depth up to 1e4 m over a
     * grazing plane, and NaN / -inf / 0 / negative depths */
    tu_synth sp;
    CHECK_OK(tu_synth_plane(ctx, 40, 30, 30.0, obs_dv3(0, 0.99, 0.1410674), -0.05, OBS_PROJECTION_PERSPECTIVE, &sp),
             ctx);
    obs_image_f32_row(&sp.depth, 3)[4] = NAN;
    obs_image_f32_row(&sp.depth, 20)[10] = -INFINITY;
    obs_image_f32_row(&sp.depth, 21)[11] = 0.0f;
    obs_image_f32_row(&sp.depth, 22)[12] = -2.0f;
    obs_image_f32_row(&sp.depth, 23)[13] = 3e37f;
    for (int var = 0; var < 2; var++) {
        ao_hbao_params p = ao_hbao_params_default();
        p.variant = (ao_hbao_variant)var;
        obs_image_f32 out, raw;
        ao_hbao_stats st;
        CHECK_OK(hb_run(ctx, NULL, &sp.in, &p, &out, &raw, &st), ctx);
        CHECK(all_unit(&out) && all_unit(&raw));
        CHECK(px(&out, 4, 3) == 1.0f && px(&raw, 12, 22) == 1.0f);
        CHECK(st.pixels_background >= 4);
        obs_image_f32_free(&out);
        obs_image_f32_free(&raw);
    }
    obs_image_f32_free(&sp.depth);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- parameters ------------------------------------------------------------------------------ */

TEST(hbao_bad_params_are_rejected_naming_the_field)
{
    obs_context *ctx = obs_context_create();
    for (int i = 0; i < 14; i++) {
        ao_hbao_params p = ao_hbao_params_default();
        const char *field = "";
        switch (i) {
        case 0: p.radius = 0.0f; field = "radius"; break;
        case 1: p.radius = NAN; field = "radius"; break;
        case 2: p.directions = 33; field = "directions"; break;
        case 3: p.steps = -1; field = "steps"; break;
        case 4: p.angle_bias_deg = 90.0f; field = "angle bias"; break;
        case 5: p.attenuation = -1.0f; field = "attenuation"; break;
        case 6: p.contrast = INFINITY; field = "contrast"; break;
        case 7: p.ndotv_bias = 1.0f; field = "ndotv bias"; break;
        case 8: p.pow_exponent = -0.5f; field = "pow exponent"; break;
        case 9: p.blur_radius = 17; field = "blur radius"; break;
        case 10: p.blur_sharpness = NAN; field = "blur sharpness"; break;
        case 11: p.blur_sigma = -1.0f; field = "blur sigma"; break;
        case 12: p.small_scale_ao = 3.0f; field = "small scale ao"; break;
        default: p.variant = (ao_hbao_variant)7; field = "variant"; break;
        }
        CHECK_EQ_INT(ao_hbao_params_validate(ctx, &p), OBS_STATUS_INVALID_ARGUMENT);
        CHECK_MSG(strstr(obs_context_last_error(ctx), field) != NULL, "case %d: '%s' does not name %s", i,
                  obs_context_last_error(ctx), field);
        obs_context_clear_error(ctx);
    }
    /* every preset validates; unknown presets are refused */
    for (const char *const *n = ao_hbao_preset_names(); *n; n++) {
        ao_hbao_params p;
        CHECK(ao_hbao_params_preset(*n, &p));
        CHECK_OK(ao_hbao_params_validate(ctx, &p), ctx);
    }
    ao_hbao_params p;
    CHECK(!ao_hbao_params_preset("thesis", &p));
    /* G-buffer normals without normals in the input */
    tu_synth sp;
    CHECK_OK(tu_synth_plane(ctx, 8, 8, 8.0, obs_dv3(0, 0, 1), -2.0, OBS_PROJECTION_PERSPECTIVE, &sp), ctx);
    p = ao_hbao_params_default();
    p.normals = AO_HBAO_NORMALS_GBUFFER;
    obs_image_f32 out, raw;
    CHECK(hb_run(ctx, NULL, &sp.in, &p, &out, &raw, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&sp.depth);
    obs_context_destroy(ctx);
}

TEST(ao_cli_hbao_plus_preset_writes_outputs_and_constants)
{
    const char *dir = test_tmpdir();
    char scene[1024], prefix[1024], err[1100], path[1100];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(prefix, sizeof prefix, "%s/hb", dir);
    snprintf(err, sizeof err, "%s/hb.err", dir);
    const char *a[] = {"ao", "--method", "hbao", "--preset", "gl-ssao", "--blur-depth-slope", "--directions", "6",
                       "--scene", scene, "--size", "40x30", "-o", prefix, NULL};
    int rc = test_spawn(OBS_CLI_PATH, a, NULL, err);
    char *e = test_slurp(err, NULL);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, e ? e : "");
    free(e);
    snprintf(path, sizeof path, "%s.json", prefix);
    char *j = test_slurp(path, NULL);
    CHECK(j != NULL);
    if (j) {
        CHECK(strstr(j, "\"RadiusToScreen\"") && strstr(j, "\"num_dirs\": 6") && strstr(j, "obs-mssao"));
        CHECK(strstr(j, "\"blur_USE_DEPTH_SLOPE\": 1"));
    }
    free(j);
    const char *b[] = {"ao", "--method", "hbao", "--angle-bias", "95", "--scene", scene, "-o", prefix, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b, NULL, err), 2);
}

/* ---- SIMD = scalar ------------------------------------------------------------------------------ */

/* Run with OBS_ISA=scalar (the scalar tap loops, libm's exp2/atan/tan) and without (the AVX2 loops
 * and their rounding-certain exp2/atan/tan, where the build and CPU have AVX2); every bit equal. */
static int hb_same_both_isas(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_hbao_params *p)
{
    const char *old = getenv("OBS_ISA");
    char saved[64] = {0};
    if (old)
        snprintf(saved, sizeof saved, "%s", old);
    obs_image_f32 out[2], raw[2];
    int ok = 1;
    for (int isa = 0; isa < 2; isa++) {
        if (isa == 0)
            setenv("OBS_ISA", "scalar", 1);
        else
            unsetenv("OBS_ISA");
        if (hb_run(ctx, pool, in, p, &out[isa], &raw[isa], NULL) != OBS_STATUS_OK)
            ok = 0;
    }
    if (old)
        setenv("OBS_ISA", saved, 1);
    else
        unsetenv("OBS_ISA");
    ok = ok && tu_same_plane(&out[0], &out[1]) && tu_same_plane(&raw[0], &raw[1]);
    for (int isa = 0; isa < 2; isa++) {
        obs_image_f32_free(&out[isa]);
        obs_image_f32_free(&raw[isa]);
    }
    return ok;
}

TEST(hbao_avx2_paths_give_the_scalar_bits)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    /* 83 columns: every row ends in a partial group of 8 */
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 83, 61, 5, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    /* background is there already (the sky); add NaN, +-inf, 0, negative, huge and tiny depths */
    obs_image_f32 *d = (obs_image_f32 *)in.depth;
    static const float hard[] = {NAN, INFINITY, -INFINITY, 0.0f, -2.0f, 3e37f, 1e30f, 1e-30f};
    for (int i = 0; i < 48; i++)
        obs_image_f32_row(d, (i * 53 + 7) % d->height)[(i * 37 + 3) % d->width] = hard[i % 8];
    static const char *presets[] = {"default", "plus", "hbaoplus", "gl-ssao"};
    int n = 0;
    for (int pi = 0; pi < 4; pi++)
        for (int nm = 0; nm < 2; nm++)
            for (int r = 0; r < 3; r++) {
                static const float radii[] = {0.5f, 4.0f, 1e4f};
                ao_hbao_params p;
                CHECK(ao_hbao_params_preset(presets[pi], &p));
                p.normals = (ao_hbao_normals)nm;
                p.radius = radii[r];
                if (r == 1) { /* odd counts, no bias, a wide blur */
                    p.directions = 7;
                    p.steps = 5;
                    p.angle_bias_deg = 0.0f;
                    p.blur_radius = 9;
                }
                CHECK_MSG(hb_same_both_isas(ctx, pool, &in, &p), "preset %s normals %d radius %g", presets[pi], nm,
                          (double)radii[r]);
                n++;
            }
    /* orthographic, a grazing plane with hard depths */
    tu_synth sp;
    CHECK_OK(tu_synth_plane(ctx, 45, 30, 30.0, obs_dv3(0, 0.99, 0.1410674), -0.05, OBS_PROJECTION_ORTHOGRAPHIC, &sp),
             ctx);
    for (int i = 0; i < 16; i++)
        obs_image_f32_row(&sp.depth, (i * 7) % 30)[(i * 11) % 45] = hard[i % 8];
    for (int var = 0; var < 2; var++) {
        ao_hbao_params p = ao_hbao_params_default();
        p.variant = (ao_hbao_variant)var;
        CHECK_MSG(hb_same_both_isas(ctx, pool, &sp.in, &p), "orthographic variant %d", var);
        n++;
    }
    printf("  %d configurations: scalar and %s paths bit-identical\n", n,
           ao_hbao_simd_available() ? "AVX2" : "(no AVX2 here: scalar again)");
    obs_image_f32_free(&sp.depth);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
