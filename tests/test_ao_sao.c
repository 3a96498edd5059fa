/* test_ao_sao.c: SAO [McGuire12]: the flat-plane value, thread determinism, background handling,
 * the GLSL hash, the rotated-grid MIP pyramid, the blur, hard cases, and the CLI. The match against
 * the reference shaders on llvmpipe is test_ao_llvmpipe.c. */
#include "ao/ao.h"
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "ao_test_util.h"
#include "test.h"

#include <fcntl.h>
#include <math.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

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

typedef tu_synth synth;
static obs_status synth_plane(obs_context *ctx, int W, int H, double f, obs_dvec3 n, double c, synth *s)
{
    return tu_synth_plane(ctx, W, H, f, n, c, OBS_PROJECTION_PERSPECTIVE, s);
}

/* ---- flat plane ------------------------------------------------------------------------------- */

TEST(sao_flat_open_plane_is_fully_visible)
{
    obs_context *ctx = obs_context_create();
    /* Facing the camera (z = -5) and tilted 50 degrees: every tap lands on the plane, so
     * vn = v.n is rounding noise (~1e-6 m) and vn - bias < 0: each tap adds exactly 0 and
     * A = max(0, 1 - 0) = 1, for MIP and no-MIP, both variants, depth or G-buffer-free normals. */
    const obs_dvec3 normals[2] = {{0, 0, 1}, {0, 0.766044443, 0.642787610}};
    const double offsets[2] = {-5.0, -4.0};
    for (int pl = 0; pl < 2; pl++) {
        synth s;
        CHECK_OK(synth_plane(ctx, 96, 64, 80.0, normals[pl], offsets[pl], &s), ctx);
        obs_image_f32 raw = {0}, out = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, 96, 64, &raw), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, 96, 64, &out), ctx);
        for (int variant = 0; variant < AO_SAO_VARIANT_COUNT; variant++)
            for (int mip = 0; mip <= 5; mip += 5) {
                ao_sao_params p = ao_sao_params_default();
                p.variant = (ao_sao_variant)variant;
                p.max_mip_level = mip;
                p.radius = 0.5f;
                if (variant == AO_SAO_VARIANT_G3D_HQ)
                    p.bias = 0.023f;
                ao_sao_stats st;
                CHECK_OK(ao_sao_compute(ctx, NULL, &s.in, &p, &out, &raw, &st), ctx);
                /* away from the borders: 2 px (the derivative quads and nothing else reach out;
                 * a constant-depth plane is exact everywhere) */
                int border = pl == 0 ? 0 : 2;
                for (int y = border; y < 64 - border; y++)
                    for (int x = border; x < 96 - border; x++)
                        CHECK_MSG(obs_image_f32_row(&raw, y)[x] == 1.0f,
                                  "plane %d variant %d mip %d: raw AO at (%d,%d) = %.9g, not 1", pl, variant, mip, x, y,
                                  (double)obs_image_f32_row(&raw, y)[x]);
                CHECK(st.pixels_background == 0);
                CHECK(all_finite_unit(&out));
            }
        obs_image_f32_free(&raw);
        obs_image_f32_free(&out);
        obs_image_f32_free(&s.depth);
    }
    obs_context_destroy(ctx);
}

/* ---- determinism ------------------------------------------------------------------------------- */

TEST(sao_output_identical_for_1_2_8_threads)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 160, 97, 6, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    CHECK_EQ_INT(in.w, 160);
    CHECK_EQ_INT(in.h, 97);
    const int threads[3] = {1, 2, 8};
    for (int cfg = 0; cfg < 3; cfg++) {
        ao_sao_params p = ao_sao_params_default();
        p.radius = 0.6f;
        if (cfg == 1) {
            p.max_mip_level = 0;
            p.normals = AO_SAO_NORMALS_GBUFFER;
        }
        if (cfg == 2) {
            /* G3D HQ rejects depth normals longer than C.z^2 * 6e-5 (tuned for ~1080p): at 160 px
             * nearly every depth normal is rejected, so this run uses the G-buffer's normals */
            ao_sao_params_preset("g3d-hq", &p);
            p.normals = AO_SAO_NORMALS_GBUFFER;
        }
        obs_image_f32 ref = {0}, ref_raw = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &ref), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &ref_raw), ctx);
        for (int t = 0; t < 3; t++) {
            obs_pool *pool = obs_pool_create(threads[t]);
            obs_image_f32 out = {0}, raw = {0};
            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &out), ctx);
            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &raw), ctx);
            CHECK_OK(ao_sao_compute(ctx, pool, &in, &p, &out, &raw, NULL), ctx);
            if (t == 0) {
                for (int y = 0; y < in.h; y++) {
                    memcpy(obs_image_f32_row(&ref, y), obs_image_f32_row(&out, y), sizeof(float) * in.w);
                    memcpy(obs_image_f32_row(&ref_raw, y), obs_image_f32_row(&raw, y), sizeof(float) * in.w);
                }
                CHECK(all_finite_unit(&out));
                /* the scene has occlusion: some pixel is darker than 0.9 */
                int dark = 0;
                for (int y = 0; y < in.h; y++)
                    for (int x = 0; x < in.w; x++)
                        dark += obs_image_f32_row(&raw, y)[x] < 0.97f;
                CHECK_MSG(dark > 50, "config %d: only %d occluded pixels", cfg, dark);
            } else {
                CHECK_MSG(tu_same_plane(&ref, &out) && tu_same_plane(&ref_raw, &raw),
                          "config %d: %d threads differ from 1 thread", cfg, threads[t]);
            }
            obs_image_f32_free(&out);
            obs_image_f32_free(&raw);
            obs_pool_destroy(pool);
        }
        obs_image_f32_free(&ref);
        obs_image_f32_free(&ref_raw);
    }
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- background ---------------------------------------------------------------------------------- */

TEST(sao_background_pixels_are_one_and_never_nan)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_sphere(&s, 32, 16, 1.0f, obs_v3(0.0f, 0.0f, -4.0f), 0.1f); /* a sphere alone: lots of sky */
    rast_gbuffer gb;
    obs_camera cam = obs_camera_look_at(obs_v3(0, 0, 0), obs_v3(0, 0, -4), obs_v3(0, 1, 0), 0.8f, 0.1f, 50.0f);
    CHECK_OK(tu_render_depth_normal(ctx, &s, cam, 81, 63, 0, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    obs_image_f32 out = {0}, raw = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &out), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &raw), ctx);
    for (int variant = 0; variant < AO_SAO_VARIANT_COUNT; variant++) {
        ao_sao_params p = ao_sao_params_default();
        p.variant = (ao_sao_variant)variant;
        p.radius = 2.0f; /* taps from the rim reach the sky */
        ao_sao_stats st;
        CHECK_OK(ao_sao_compute(ctx, NULL, &in, &p, &out, &raw, &st), ctx);
        int64_t bg = 0;
        for (int y = 0; y < in.h; y++)
            for (int x = 0; x < in.w; x++) {
                float d = obs_image_f32_row(in.depth, y)[x];
                float a = obs_image_f32_row(&out, y)[x], r = obs_image_f32_row(&raw, y)[x];
                CHECK_MSG(a == a && r == r, "NaN at (%d,%d)", x, y);
                CHECK(a >= 0.0f && a <= 1.0f && r >= 0.0f && r <= 1.0f);
                if (!(d < INFINITY)) {
                    bg++;
                    CHECK_MSG(a == 1.0f && r == 1.0f, "background (%d,%d): %g %g", x, y, (double)a, (double)r);
                }
            }
        CHECK(bg > 1000);
        CHECK_EQ_INT(st.pixels_background, bg); /* no blur margin: the window is the buffer */
    }
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- hash ------------------------------------------------------------------------------------- */

TEST(sao_hash_matches_glsl_int_semantics)
{
    /* float(((3x) ^ (y + xy)) * 10) with int32 wrap-around; expected values computed by hand
     * (Python with explicit 32-bit wrapping and float32 rounding). */
    static const struct { int x, y; float spin; } cases[] = {
        {0, 0, 0.0f},
        {1, 1, 10.0f},                    /* 3 ^ 2 = 1 */
        {2, 3, 150.0f},                   /* 6 ^ 9 = 15 */
        {5, 7, 370.0f},                   /* 15 ^ 42 = 37 */
        {1919, 1079, 20671970.0f},        /* 5757 ^ 2071680 = 2067197; float exact (even) */
        {3839, 2159, 83020768.0f},        /* 83020770 rounds to the float 83020768 */
        {16383, 16383, -1610940416.0f},   /* * 10 wraps past 2^31: -1610940446 -> float */
        {50000, 50000, -770467776.0f},    /* x*y = 2.5e9 wraps before the xor */
        {46341, 46341, 1863850.0f},       /* x*y = 2147488281 wraps just past 2^31 */
        {65535, 1, 2621410.0f},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        float s = ao_sao_spin(cases[i].x, cases[i].y);
        CHECK_MSG(s == cases[i].spin, "spin(%d, %d) = %.1f, expected %.1f", cases[i].x, cases[i].y, (double)s,
                  (double)cases[i].spin);
    }
    /* '+' binds tighter than '^': (3x) ^ (y + xy), not ((3x) ^ y) + xy */
    CHECK(ao_sao_spin(2, 3) != (float)((((3 * 2) ^ 3) + 2 * 3) * 10));
}

/* ---- MIP pyramid --------------------------------------------------------------------------------- */

TEST(sao_mip_pyramid_uses_rotated_grid)
{
    obs_context *ctx = obs_context_create();
    /* level 0 (GL coordinates): value 100 y + x on 8 x 6 */
    obs_image_f32 l0 = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 6, &l0), ctx);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 8; x++)
            obs_image_f32_row(&l0, y)[x] = (float)(100 * y + x);
    obs_image_f32 lv[4];
    CHECK_OK(ao_sao_mip_build(ctx, NULL, &l0, 3, lv), ctx);
    CHECK(lv[0].data == l0.data);
    CHECK_EQ_INT(lv[1].width, 4);
    CHECK_EQ_INT(lv[1].height, 3);
    CHECK_EQ_INT(lv[2].width, 2);
    CHECK_EQ_INT(lv[2].height, 1);
    CHECK_EQ_INT(lv[3].width, 1);
    CHECK_EQ_INT(lv[3].height, 1);
    /* level 1, texel p takes level-0 texel 2p + (p.y & 1, p.x & 1):
     *   p=(0,0) -> (0,0) = 0;   p=(1,0) -> (2,1) = 102;  p=(0,1) -> (1,2) = 201;
     *   p=(1,1) -> (3,3) = 303; p=(3,2) -> (6,5) = 506;  p=(2,2) -> (4,4) = 404 */
    static const int l1[][3] = {{0, 0, 0}, {1, 0, 102}, {0, 1, 201}, {1, 1, 303}, {3, 2, 506}, {2, 2, 404}, {3, 0, 106}};
    for (size_t i = 0; i < sizeof l1 / sizeof l1[0]; i++)
        CHECK_MSG(obs_image_f32_row(&lv[1], l1[i][1])[l1[i][0]] == (float)l1[i][2], "level 1 (%d,%d) = %g, expected %d",
                  l1[i][0], l1[i][1], (double)obs_image_f32_row(&lv[1], l1[i][1])[l1[i][0]], l1[i][2]);
    /* level 2 is built from level 1 (not level 0): p=(1,0) -> level-1 (2,1) -> level-0 (5,2) = 205;
     * p=(0,0) -> 0. Straight from level 0 with the same rule at 4p it would be (4,1) = 104. */
    CHECK(obs_image_f32_row(&lv[2], 0)[1] == 205.0f);
    CHECK(obs_image_f32_row(&lv[2], 0)[0] == 0.0f);
    CHECK(obs_image_f32_row(&lv[3], 0)[0] == 0.0f);
    ao_sao_mip_free(lv, 3);

    /* the clamp: a 4 x 1 level 0 -> level 1 is 2 x 1, p=(1,0) -> (2, 1) clamps to (2, 0) */
    obs_image_f32 row = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 4, 1, &row), ctx);
    for (int x = 0; x < 4; x++)
        obs_image_f32_row(&row, 0)[x] = (float)(10 + x);
    obs_image_f32 lr[6];
    CHECK_OK(ao_sao_mip_build(ctx, NULL, &row, 5, lr), ctx);
    CHECK_EQ_INT(lr[1].width, 2);
    CHECK_EQ_INT(lr[1].height, 1);
    CHECK(obs_image_f32_row(&lr[1], 0)[1] == 12.0f);
    CHECK(obs_image_f32_row(&lr[1], 0)[0] == 10.0f);
    CHECK_EQ_INT(lr[5].width, 1); /* deeper than the image: stays 1 x 1 */
    CHECK(obs_image_f32_row(&lr[5], 0)[0] == 10.0f);
    ao_sao_mip_free(lr, 5);
    obs_image_f32_free(&row);

    /* The CSZ buffer is in GL row order: our top row (y = 0) is GL row H - 1. */
    obs_image_f32 depth = {0}, csz = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 4, &depth), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 4, &csz), ctx);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 3; x++)
            obs_image_f32_row(&depth, y)[x] = y == 1 && x == 2 ? INFINITY : (float)(1 + y);
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = in.w = 3;
    in.height = in.h = 4;
    in.depth = &depth;
    in.fx = in.fy = 2.0;
    in.cx = 1.5;
    in.cy = 2.0;
    in.zfar = INFINITY;
    CHECK_OK(ao_sao_csz_from_input(ctx, NULL, &in, &csz), ctx);
    CHECK(obs_image_f32_row(&csz, 3)[0] == -1.0f); /* our row 0 */
    CHECK(obs_image_f32_row(&csz, 0)[0] == -4.0f); /* our row 3 */
    CHECK(obs_image_f32_row(&csz, 2)[2] == 0.0f);  /* background -> 0 sentinel */
    obs_image_f32_free(&csz);
    obs_image_f32_free(&depth);
    obs_image_f32_free(&l0);
    obs_context_destroy(ctx);
}

/* ---- blur ----------------------------------------------------------------------------------------- */

TEST(sao_blur_passes_background_through_and_preserves_constants)
{
    obs_context *ctx = obs_context_create();
    const int W = 37, H = 23;
    obs_image_f32 ao = {0}, z = {0}, out = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ao), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &z), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &out), ctx);

    /* A. A constant image stays constant: every tap has weight 0.3 + g[|r|] (equal keys), edges
     * included (clamped taps repeat the edge texel), so each pass multiplies by W/(W + 1e-4) with
     * W = g0 + 2 sum(0.3 + g[r]): the reference's 1e-4 regulariser costs 6e-5 over both passes. */
    obs_image_f32_fill(&ao, 0.6f);
    obs_image_f32_fill(&z, -5.0f);
    CHECK_OK(ao_sao_blur_gl(ctx, NULL, &ao, &z, 2, 2000.0f / 300.0f, &out), ctx);
    double Wsum = ao_sao_blur_gaussian[0];
    for (int r = 1; r <= 4; r++)
        Wsum += 2.0 * (0.3 + ao_sao_blur_gaussian[r]);
    const double gain = (Wsum / (Wsum + 1e-4)) * (Wsum / (Wsum + 1e-4));
    CHECK(gain < 1.0 && gain > 0.9999);
    const float c0 = obs_image_f32_row(&out, 0)[0];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            CHECK_MSG(obs_image_f32_row(&out, y)[x] == c0, "(%d,%d) = %.9g, (0,0) = %.9g", x, y,
                      (double)obs_image_f32_row(&out, y)[x], (double)c0);
    CHECK_NEAR(c0, 0.6 * gain, 1e-6); /* float sums of 9 weights */

    /* B. Left part AO 0.2 at z = -5, right part (x >= 20) AO 0.8 at z = -10: |dz| = 5 gives the
     * edge weight max(0, 1 - 6.67 * 5) = 0, so nothing bleeds across; a background block (key 0)
     * holding odd values passes through bit for bit and lends no weight either. */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int bg = x >= 5 && x < 9 && y >= 3 && y < 12;
            obs_image_f32_row(&ao, y)[x] = bg ? 0.3f + 0.01f * (float)(x + y) : x < 20 ? 0.2f : 0.8f;
            obs_image_f32_row(&z, y)[x] = bg ? 0.0f : x < 20 ? -5.0f : -10.0f;
        }
    CHECK_OK(ao_sao_blur_gl(ctx, NULL, &ao, &z, 2, 2000.0f / 300.0f, &out), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float v = obs_image_f32_row(&out, y)[x];
            if (obs_image_f32_row(&z, y)[x] == 0.0f) {
                CHECK_MSG(v == obs_image_f32_row(&ao, y)[x], "background (%d,%d) changed", x, y);
                continue;
            }
            /* only the regulariser's share (<= 1e-4 relative) differs from the region's value */
            CHECK_NEAR(v, x < 20 ? 0.2 : 0.8, 1e-4);
        }

    /* C. Size checks and aliasing are refused. */
    CHECK(ao_sao_blur_gl(ctx, NULL, &ao, &z, 2, 1.0f, &ao) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(ao_sao_blur_gl(ctx, NULL, &ao, &z, 0, 1.0f, &out) == OBS_STATUS_INVALID_ARGUMENT);
    obs_image_f32_free(&out);
    obs_image_f32_free(&z);
    obs_image_f32_free(&ao);
    obs_context_destroy(ctx);
}

/* ---- hard cases ------------------------------------------------------------------------------------ */

static void run_finite(obs_context *ctx, const ao_input *in, const ao_sao_params *p, const char *what)
{
    obs_image_f32 out = {0}, raw = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, in->w, in->h, &out), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, in->w, in->h, &raw), ctx);
    CHECK_OK(ao_sao_compute(ctx, NULL, in, p, &out, &raw, NULL), ctx);
    CHECK_MSG(all_finite_unit(&out) && all_finite_unit(&raw), "%s: values outside [0, 1] or NaN", what);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
}

TEST(sao_hard_cases_stay_finite)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    /* sizes: 1x1, a row, a column, odd sizes; MIP levels deeper than the image (15) */
    static const int sizes[][2] = {{1, 1}, {1, 7}, {9, 1}, {3, 5}, {7, 2}, {33, 17}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        rast_gbuffer gb;
        CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), sizes[i][0], sizes[i][1], 0, &gb), ctx);
        ao_input in;
        CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
        for (int v = 0; v < AO_SAO_VARIANT_COUNT; v++) {
            ao_sao_params p = ao_sao_params_default();
            p.variant = (ao_sao_variant)v;
            p.max_mip_level = AO_SAO_MAX_MIP;
            run_finite(ctx, &in, &p, "small sizes, deep MIP");
            p.normals = AO_SAO_NORMALS_GBUFFER;
            run_finite(ctx, &in, &p, "small sizes, G-buffer normals");
        }
        rast_gbuffer_free(&gb);
    }
    /* depth discontinuities (sphere silhouettes against the far ground), grazing ground, tiny and
     * huge radii, huge bias and intensity, the table's turns, a guard band */
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 120, 80, 9, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    const float radii[] = {1e-4f, 0.01f, 1.0f, 50.0f, 1e5f};
    for (size_t i = 0; i < sizeof radii / sizeof radii[0]; i++)
        for (int v = 0; v < AO_SAO_VARIANT_COUNT; v++) {
            ao_sao_params p = ao_sao_params_default();
            p.variant = (ao_sao_variant)v;
            p.radius = radii[i];
            p.samples = 13;
            p.spiral_turns = AO_SAO_TURNS_FROM_TABLE;
            run_finite(ctx, &in, &p, "radius sweep");
            p.intensity = 1e6f;
            p.bias = -10.0f;
            run_finite(ctx, &in, &p, "radius sweep, extreme intensity and bias");
        }
    rast_gbuffer_free(&gb);

    /* orthographic */
    obs_camera oc = tu_ao_camera();
    oc.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    oc.xmag = 3.0f;
    oc.ymag = 2.0f;
    oc.znear = 0.0f;
    CHECK_OK(tu_render_depth_normal(ctx, &s, oc, 90, 60, 0, &gb), ctx);
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    {
        ao_sao_params p = ao_sao_params_default();
        p.radius = 0.5f;
        run_finite(ctx, &in, &p, "orthographic");
    }
    rast_gbuffer_free(&gb);

    /* External G-buffers: reversed-Z with an infinite far plane, and NaN / negative / -inf depths. */
    obs_camera rc = tu_ao_camera();
    rc.zfar = INFINITY;
    rast_params rp = rast_params_default();
    rp.width = 64;
    rp.height = 48;
    rp.depth_convention = RAST_DEPTH_REVERSED_Z;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NDC_DEPTH;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view view = {rc};
    CHECK_OK(rast_render(ctx, NULL, &s, &view, 1, &rp, &gb, NULL), ctx);
    /* poison some linear depths */
    obs_image_f32_row(&gb.depth, 10)[10] = NAN;
    obs_image_f32_row(&gb.depth, 11)[10] = -1.0f;
    obs_image_f32_row(&gb.depth, 12)[10] = -INFINITY;
    obs_image_f32_row(&gb.depth, 13)[10] = 0.0f;
    obs_image_f32_row(&gb.ndc_depth, 20)[20] = NAN;
    const rast_view_constants *vc = &gb.constants;
    float fxyc[4] = {(float)vc->fx, (float)vc->fy, (float)vc->cx, (float)vc->cy};
    io_attr at[4];
    memset(at, 0, sizeof at);
    strcpy(at[0].name, "obscura:pixel_model_fx_fy_cx_cy"); at[0].type = IO_ATTR_FLOATS; at[0].v = fxyc; at[0].n = 4;
    strcpy(at[1].name, "obscura:znear"); at[1].type = IO_ATTR_FLOAT; at[1].f = rc.znear;
    strcpy(at[2].name, "obscura:zfar"); at[2].type = IO_ATTR_FLOAT; at[2].f = INFINITY;
    strcpy(at[3].name, "obscura:depth_convention"); at[3].type = IO_ATTR_STRING; at[3].s = (char *)"reversed_z";
    io_channel ch[2] = {{"Z", IO_PIXEL_FLOAT, &gb.depth, NULL}, {"Zndc", IO_PIXEL_FLOAT, &gb.ndc_depth, NULL}};
    const char *path = test_path(test_tmpdir(), "revz.exr");
    CHECK_OK(io_exr_write(ctx, path, ch, 2, at, 4), ctx);
    io_image im;
    CHECK_OK(io_image_read(ctx, path, &im), ctx);
    for (int which = 0; which < 2; which++) {
        ao_external_options o = ao_external_options_default();
        o.depth_channel = which == 0 ? "Z" : "Zndc";
        ao_external e;
        CHECK_OK(ao_external_from_image(ctx, &im, &o, &e), ctx);
        CHECK_EQ_INT(e.depth_kind, which == 0 ? AO_DEPTH_KIND_LINEAR : AO_DEPTH_KIND_NDC_REVERSED_Z);
        CHECK_EQ_INT(e.invalid_depth_pixels, which == 0 ? 4 : 1);
        CHECK(e.background_pixels > 0);
        CHECK(isinf(e.input.zfar));
        /* invalid depths became background */
        CHECK(isinf(obs_image_f32_row(&e.depth, which == 0 ? 10 : 20)[which == 0 ? 10 : 20]));
        ao_sao_params p = ao_sao_params_default();
        p.radius = 0.5f;
        obs_image_f32 out = {0};
        CHECK_OK(obs_image_f32_alloc(ctx, 64, 48, &out), ctx);
        CHECK_OK(ao_sao_compute(ctx, NULL, &e.input, &p, &out, NULL, NULL), ctx);
        CHECK(all_finite_unit(&out));
        CHECK(obs_image_f32_row(&out, which == 0 ? 10 : 20)[which == 0 ? 10 : 20] == 1.0f);
        obs_image_f32_free(&out);
        ao_external_free(&e);
    }
    io_image_free(&im);
    rast_gbuffer_free(&gb);

    /* extreme depths in one buffer: denormal, tiny, huge, FLT_MAX next to ordinary ones (disk
     * radii overflow to inf, taps clamp, the MIP selection saturates) */
    {
        synth sy;
        CHECK_OK(synth_plane(ctx, 40, 30, 30.0, obs_dv3(0, 0, 1), -3.0, &sy), ctx);
        const float extreme[] = {1e-42f, 1e-30f, 1e-6f, 1e6f, 1e30f, 3.4e38f, INFINITY, NAN, -2.0f, 0.0f};
        for (int i = 0; i < 40 * 30; i += 7)
            obs_image_f32_row(&sy.depth, i / 40)[i % 40] = extreme[(i / 7) % 10];
        for (int v = 0; v < AO_SAO_VARIANT_COUNT; v++) {
            ao_sao_params p = ao_sao_params_default();
            p.variant = (ao_sao_variant)v;
            run_finite(ctx, &sy.in, &p, "extreme depths");
            p.normals = AO_SAO_NORMALS_FROM_DEPTH;
            p.radius = 1e5f;
            run_finite(ctx, &sy.in, &p, "extreme depths, huge radius");
        }
        obs_image_f32_free(&sy.depth);
    }

    /* invalid parameters are refused, not computed */
    ao_sao_params p = ao_sao_params_default();
    rast_gbuffer empty;
    memset(&empty, 0, sizeof empty);
    CHECK(ao_input_from_gbuffer(ctx, &empty, 0, &in) == OBS_STATUS_INVALID_ARGUMENT);
    const float bad_r[] = {0.0f, -1.0f, NAN, INFINITY, 1e-8f, 1e8f};
    for (size_t i = 0; i < sizeof bad_r / sizeof bad_r[0]; i++) {
        p = ao_sao_params_default();
        p.radius = bad_r[i];
        CHECK_MSG(ao_sao_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT, "radius %g accepted",
                  (double)bad_r[i]);
    }
    p = ao_sao_params_default();
    p.samples = 0;
    CHECK(ao_sao_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    p = ao_sao_params_default();
    p.max_mip_level = AO_SAO_MAX_MIP + 1;
    CHECK(ao_sao_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    p = ao_sao_params_default();
    p.epsilon = 0.0f;
    CHECK(ao_sao_params_validate(ctx, &p) == OBS_STATUS_INVALID_ARGUMENT);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(sao_params_presets_and_turn_table)
{
    /* McGuire's table (G3D numSpiralTurns): spot values, and the prime beyond 99 */
    CHECK_EQ_INT(ao_sao_turns_for_samples(8), 3);
    CHECK_EQ_INT(ao_sao_turns_for_samples(9), 2);
    CHECK_EQ_INT(ao_sao_turns_for_samples(11), 3);
    CHECK_EQ_INT(ao_sao_turns_for_samples(19), 7);
    CHECK_EQ_INT(ao_sao_turns_for_samples(20), 9);
    CHECK_EQ_INT(ao_sao_turns_for_samples(99), 29);
    CHECK_EQ_INT(ao_sao_turns_for_samples(100), 5779);
    ao_sao_params p;
    CHECK(ao_sao_params_preset("thesis", &p));
    CHECK(p.radius == 10.0f && p.samples == 8 && p.spiral_turns == AO_SAO_TURNS_FROM_TABLE);
    CHECK(ao_sao_params_preset("g3d", &p));
    CHECK(p.radius == 0.75f && p.samples == 19 && p.bias == 0.023f && p.variant == AO_SAO_VARIANT_HPG12);
    CHECK(ao_sao_params_preset("hpg12", &p));
    CHECK_EQ_INT(p.max_mip_level, 4);
    CHECK(!ao_sao_params_preset("nonsense", &p));
    /* the defaults are the peer's */
    p = ao_sao_params_default();
    CHECK(p.radius == 1.0f && p.bias == 0.01f && p.intensity == 1.0f && p.epsilon == 0.01f && p.samples == 11 &&
          p.spiral_turns == 7 && p.max_mip_level == 5 && p.log_max_offset == 3 && p.blur_stride == 2);
    for (const char *const *n = ao_sao_preset_names(); *n; n++) {
        CHECK(ao_sao_params_preset(*n, &p));
        CHECK_OK(ao_sao_params_validate(NULL, &p), (obs_context *)NULL);
    }
    /* constants mirror the peer's uniforms for a centred frustum */
    ao_input in;
    memset(&in, 0, sizeof in);
    in.width = 640;
    in.height = 360;
    in.fx = 0.5 * 640 * 1.35799515;
    in.fy = 0.5 * 360 * 2.41421342;
    in.cx = 320;
    in.cy = 180;
    p = ao_sao_params_default();
    ao_sao_constants k = ao_sao_constants_from_params(&p, &in);
    CHECK_NEAR(k.proj_info[0], -2.0 / (640 * 1.35799515), 1e-9);
    CHECK_NEAR(k.proj_info[1], -2.0 / (360 * 2.41421342), 1e-9);
    CHECK_NEAR(k.proj_info[2], 1.0 / 1.35799515, 1e-7);
    CHECK_NEAR(k.proj_info[3], 1.0 / 2.41421342, 1e-7);
    CHECK(k.proj_scale == (float)(360 * 2.41421342 * 0.5));
    CHECK(k.turns_angle == 7.0f * 6.28f);
    CHECK(k.edge_k == 2000.0f / 300.0f);
    char buf[512];
    CHECK(ao_sao_params_to_string(&p, buf, sizeof buf) > 0 && strstr(buf, "samples=11"));
}

/* ---- CLI -------------------------------------------------------------------------------------------- */

static int run_cli(const char *const *args, const char *tag)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = OBS_CLI_PATH;
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    char out[4200], err[4200];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid;
    int rc = posix_spawn(&pid, OBS_CLI_PATH, &fa, NULL, (char *const *)argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0)
        return -1;
    int status;
    if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status))
        return -1;
    return WEXITSTATUS(status);
}

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    size_t got = fread(b, 1, (size_t)n, f);
    fclose(f);
    b[got] = '\0';
    if (len)
        *len = got;
    return b;
}

static int file_contains(const char *path, const char *needle)
{
    char *b = slurp(path, NULL);
    int r = b && strstr(b, needle) != NULL;
    free(b);
    return r;
}

static int same_bytes(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = slurp(a, &la), *y = slurp(b, &lb);
    int r = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return r;
}

static int exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && st.st_size > 0;
}

TEST(ao_cli_sao_writes_outputs_and_rejects_bad_input)
{
    const char *dir = test_tmpdir();
    char scene[4200], pre1[4200], pre2[4200], pre3[4200], gbp[4200], path[4400];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(pre1, sizeof pre1, "%s/out/a1", dir);
    snprintf(pre2, sizeof pre2, "%s/out/a2", dir);
    snprintf(pre3, sizeof pre3, "%s/out/a3", dir);
    snprintf(gbp, sizeof gbp, "%s/gb", dir);

    /* --list */
    const char *list[] = {"ao", "--list", NULL};
    CHECK_EQ_INT(run_cli(list, "list"), 0);
    snprintf(path, sizeof path, "%s/list.stdout", dir);
    CHECK(file_contains(path, "sao") && file_contains(path, "--radius") && file_contains(path, "thesis"));

    /* a scene, 1 and 2 threads: all four outputs, identical EXRs */
    const char *a1[] = {"--threads", "1", "ao", "--method", "sao", "--scene", scene, "--size", "96x64", "--guard", "4",
                        "-o", pre1, NULL};
    CHECK_EQ_INT(run_cli(a1, "a1"), 0);
    const char *a2[] = {"--threads", "2", "ao", "--method", "sao", "--scene", scene, "--size", "96x64", "--guard", "4",
                        "-o", pre2, NULL};
    CHECK_EQ_INT(run_cli(a2, "a2"), 0);
    static const char *suffix[] = {".exr", ".png", "_blend.png", ".json"};
    for (int i = 0; i < 4; i++) {
        snprintf(path, sizeof path, "%s%s", pre1, suffix[i]);
        CHECK_MSG(exists(path), "missing %s", path);
    }
    char e1[4400], e2[4400];
    snprintf(e1, sizeof e1, "%s.exr", pre1);
    snprintf(e2, sizeof e2, "%s.exr", pre2);
    CHECK(same_bytes(e1, e2));
    snprintf(path, sizeof path, "%s.json", pre1);
    CHECK(file_contains(path, "\"method\": \"sao\"") && file_contains(path, "\"projInfo\""));
    obs_context *ctx = obs_context_create();
    io_image im;
    CHECK_OK(io_image_read(ctx, e1, &im), ctx);
    CHECK_EQ_INT(im.width, 96);
    CHECK_EQ_INT(im.height, 64);
    int c_ao = io_image_find_channel(&im, "AO"), c_raw = io_image_find_channel(&im, "AO.raw");
    CHECK(c_ao >= 0 && c_raw >= 0 && io_image_find_channel(&im, "Z") >= 0);
    CHECK(all_finite_unit(&im.f32[c_ao]) && all_finite_unit(&im.f32[c_raw]));

    /* the same through an external G-buffer written by `obscura gbuffer` (guard kept) */
    const char *g[] = {"gbuffer", scene, "--size", "96x64", "--guard", "4", "--keep-guard", "-o", gbp, NULL};
    CHECK_EQ_INT(run_cli(g, "g"), 0);
    char gexr[4400];
    snprintf(gexr, sizeof gexr, "%s.exr", gbp);
    const char *a3[] = {"ao", "--method", "sao", "--gbuffer", gexr, "-o", pre3, NULL};
    CHECK_EQ_INT(run_cli(a3, "a3"), 0);
    snprintf(path, sizeof path, "%s.exr", pre3);
    io_image im3;
    CHECK_OK(io_image_read(ctx, path, &im3), ctx);
    CHECK_EQ_INT(im3.width, 96); /* the inner window of the kept guard band */
    CHECK_EQ_INT(im3.height, 64);
    int c3 = io_image_find_channel(&im3, "AO");
    CHECK(c3 >= 0);
    /* same depth, intrinsics through float metadata: nearly the same AO */
    int64_t off = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 96; x++)
            off += fabsf(obs_image_f32_row(&im3.f32[c3], y)[x] - obs_image_f32_row(&im.f32[c_ao], y)[x]) > 1e-3f;
    CHECK_MSG(off <= 96 * 64 / 100, "%lld pixels differ by more than 1e-3 between --scene and --gbuffer", (long long)off);
    io_image_free(&im3);
    io_image_free(&im);
    /* the NDC channel of the same file, with its own convention */
    snprintf(path, sizeof path, "%s/out/a4", dir);
    const char *a4[] = {"ao", "--method", "sao", "--gbuffer", gexr, "--depth-channel", "Zndc", "--no-blur", "-o", path, NULL};
    CHECK_EQ_INT(run_cli(a4, "a4"), 0);

    /* refusals */
    const char *b1[] = {"ao", "--scene", scene, "-o", pre3, NULL};                                /* no method */
    CHECK_EQ_INT(run_cli(b1, "b1"), 2);
    const char *b2[] = {"ao", "--method", "nope", "--scene", scene, NULL};
    CHECK_EQ_INT(run_cli(b2, "b2"), 2);
    const char *b3[] = {"ao", "--method", "sao", "--scene", scene, "--gbuffer", gexr, NULL};
    CHECK_EQ_INT(run_cli(b3, "b3"), 2);
    const char *b4[] = {"ao", "--method", "sao", "--gbuffer", "/nonexistent/x.exr", "-o", pre3, NULL};
    CHECK_EQ_INT(run_cli(b4, "b4"), 3);
    const char *b5[] = {"ao", "--method", "sao", "--scene", scene, "--radius", "-1", "-o", pre3, NULL};
    CHECK_EQ_INT(run_cli(b5, "b5"), 2);
    const char *b6[] = {"ao", "--method", "sao", "--scene", scene, "--preset", "nope", NULL};
    CHECK_EQ_INT(run_cli(b6, "b6"), 2);
    const char *b7[] = {"ao", "--method", "sao", "--scene", scene, "--samples", "0", NULL};
    CHECK_EQ_INT(run_cli(b7, "b7"), 2);
    const char *b8[] = {"ao", "--method", "sao", "--gbuffer", gexr, "--depth-kind", "weird", NULL};
    CHECK_EQ_INT(run_cli(b8, "b8"), 2);
    /* a PNG has no depth channel the reader recognises as such: R is taken, but its kind is unknown */
    snprintf(path, sizeof path, "%s.png", pre1);
    const char *b9[] = {"ao", "--method", "sao", "--gbuffer", path, "-o", pre3, NULL};
    CHECK_EQ_INT(run_cli(b9, "b9"), 3);
    obs_context_destroy(ctx);
}

/* ---- the float cos/sin and log2 the taps use --------------------------------------------------- */

#include "ao/ao_internal.h"

TEST(sao_trig_and_log2_match_correctly_rounded_libm)
{
    /* ao_i_cos_sin must give (float)cos((double)a) and (float)sin((double)a) (docs/ao/sao.md has
     * the exhaustive check over [0, 3e9)); here 2^20 random float angles of either sign, every
     * magnitude up to 3e9, and a dense run of small ones. */
    uint64_t st = 0x9E3779B97F4A7C15ull;
    int64_t bad = 0;
    for (int i = 0; i < (1 << 20) + 4096; i++) {
        float a;
        if (i < (1 << 20)) {
            st ^= st << 13;
            st ^= st >> 7;
            st ^= st << 17;
            uint32_t bits = (uint32_t)(st >> 11) % 0x4F32D05Fu; /* |a| < 3e9 (the reduction's range) */
            memcpy(&a, &bits, sizeof a);
            if (st & 1)
                a = -a;
        } else {
            a = (float)(i - (1 << 20)) * 0.00153398f; /* [0, 2pi] densely */
        }
        float c, s;
        ao_i_cos_sin(a, &c, &s);
        bad += c != (float)cos((double)a) || s != (float)sin((double)a);
    }
    CHECK_MSG(bad == 0, "%lld angles differ from the correctly rounded cos/sin", (long long)bad);
    /* floor of the rounded log2: exact exponents, and the floats just below a power of two whose
     * float log2 rounds up to the next integer */
    for (int e = -20; e <= 100; e++)
        for (int j = 0; j <= 80; j++) {
            float x = ldexpf(2.0f - (float)j * 0x1p-23f, e);
            int want = (int)floorf((float)log2((double)x));
            CHECK_MSG(ao_i_floor_log2f(x) == want, "floor_log2(%a) = %d, expected %d", (double)x, ao_i_floor_log2f(x),
                      want);
        }
    CHECK_EQ_INT(ao_i_floor_log2f(8.0f), 3);
    CHECK_EQ_INT(ao_i_floor_log2f(nextafterf(8.0f, 0.0f)), 3); /* log2 = 3 - 8.6e-8 rounds to 3.0f */
    CHECK_EQ_INT(ao_i_floor_log2f(7.9999f), 2);
    CHECK(ao_i_floor_log2f(0.0f) == INT32_MIN && ao_i_floor_log2f(-1.0f) == INT32_MIN);
    CHECK(ao_i_floor_log2f(NAN) == INT32_MIN && ao_i_floor_log2f(INFINITY) == INT32_MAX);
    CHECK_EQ_INT(ao_i_floor_log2f(0x1p-140f), -140); /* denormal */
}

/* ---- the AVX2 path against the scalar one ------------------------------------------------------- */

#include "ao/ao_sao_internal.h"

/* Run the scalar path (1 thread) and each SIMD path this build and CPU have (AVX2, AVX512; 3
 * threads) on in with k and compare the raw and final planes and the counts byte for byte;
 * report the first differing pixel. */
static void sao_paths_agree_k(obs_context *ctx, const ao_input *in, const ao_sao_constants k, const char *what)
{
    obs_image_f32 o[2] = {{0}}, r[2] = {{0}};
    ao_sao_stats st[2];
    for (int i = 0; i < 2; i++) {
        CHECK_OK(obs_image_f32_alloc(ctx, in->w, in->h, &o[i]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, in->w, in->h, &r[i]), ctx);
    }
    ao_i_sao_isa used = AO_I_SAO_ISA_AUTO;
    CHECK_OK(ao_i_sao_compute_isa(ctx, NULL, in, &k, &o[0], &r[0], &st[0], AO_I_SAO_ISA_SCALAR, &used), ctx);
    CHECK(used == AO_I_SAO_ISA_SCALAR);
    const ao_i_sao_isa simd[2] = {AO_I_SAO_ISA_AVX2, AO_I_SAO_ISA_AVX512};
    const char *simd_name[2] = {"AVX2", "AVX512"};
    for (int s = 0; s < 2; s++) {
        if (!ao_i_sao_isa_available(simd[s]))
            continue;
        obs_pool *pool = obs_pool_create(3);
        CHECK_OK(ao_i_sao_compute_isa(ctx, pool, in, &k, &o[1], &r[1], &st[1], simd[s], &used), ctx);
        obs_pool_destroy(pool);
        CHECK(used == simd[s]);
        int64_t bad = 0;
        for (int y = 0; y < in->h; y++)
            for (int x = 0; x < in->w; x++) {
                const float a = obs_image_f32_row(&r[0], y)[x], b = obs_image_f32_row(&r[1], y)[x];
                const float fa = obs_image_f32_row(&o[0], y)[x], fb = obs_image_f32_row(&o[1], y)[x];
                if (memcmp(&a, &b, 4) || memcmp(&fa, &fb, 4)) {
                    if (!bad)
                        fprintf(stderr, "%s: first difference at (%d,%d): raw scalar %.9g %s %.9g, final %.9g %.9g\n",
                                what, x, y, (double)a, simd_name[s], (double)b, (double)fa, (double)fb);
                    bad++;
                }
            }
        CHECK_MSG(bad == 0, "%s: %lld pixels differ between the scalar and %s paths", what, (long long)bad,
                  simd_name[s]);
        CHECK_MSG(st[0].pixels_background == st[1].pixels_background &&
                      st[0].pixels_degenerate_normal == st[1].pixels_degenerate_normal &&
                      st[0].pixels_below_min_radius == st[1].pixels_below_min_radius,
                  "%s (%s): counts differ: background %lld/%lld, degenerate %lld/%lld, min radius %lld/%lld", what,
                  simd_name[s], (long long)st[0].pixels_background, (long long)st[1].pixels_background,
                  (long long)st[0].pixels_degenerate_normal, (long long)st[1].pixels_degenerate_normal,
                  (long long)st[0].pixels_below_min_radius, (long long)st[1].pixels_below_min_radius);
    }
    for (int i = 0; i < 2; i++) {
        obs_image_f32_free(&o[i]);
        obs_image_f32_free(&r[i]);
    }
}

static void sao_paths_agree(obs_context *ctx, const ao_input *in, const ao_sao_params *p, const char *what)
{
    sao_paths_agree_k(ctx, in, ao_sao_constants_from_params(p, in), what);
}

TEST(sao_simd_and_scalar_paths_are_bit_identical)
{
    if (!ao_i_sao_isa_available(AO_I_SAO_ISA_AVX2)) {
        printf("AVX2 path not compiled or not supported here: nothing to compare\n");
        return;
    }
    if (!ao_i_sao_isa_available(AO_I_SAO_ISA_AVX512))
        printf("AVX512 path not compiled or not supported here: AVX2 against scalar only\n");
    obs_context *ctx = obs_context_create();
    /* 1. the sphere over the ground (odd sizes, a guard band: the region starts at odd columns) */
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 203, 117, 5, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 1, &in), ctx);
    /* 2. a synthetic buffer: a tilted plane with background, NaN, -inf, 0 and negative depths,
     * 1080p-like focal length so that G3D HQ keeps its depth normals */
    synth sy;
    const obs_dvec3 nrm = {0.3, 0.766044443, 0.56};
    CHECK_OK(tu_synth_plane(ctx, 157, 93, 900.0, nrm, -4.0, OBS_PROJECTION_PERSPECTIVE, &sy), ctx);
    for (int y = 0; y < 93; y++)
        for (int x = 0; x < 157; x++) {
            float *d = &obs_image_f32_row(&sy.depth, y)[x];
            const int h = (x * 7 + y * 13) % 23;
            if (h == 0)
                *d = NAN;
            else if (h == 1)
                *d = INFINITY;
            else if (h == 2 && x > 60)
                *d = -1.0f;
            else if (h == 3 && y < 30)
                *d = 0.0f;
            else if (h == 4)
                *d = -INFINITY;
            else if (x > 100 && y > 50)
                *d = INFINITY; /* a block of sky */
            else if ((x / 9 + y / 7) % 3 == 0)
                *d *= 0.8f; /* steps: occlusion */
        }
    synth so; /* orthographic */
    CHECK_OK(tu_synth_plane(ctx, 64, 41, 30.0, nrm, -4.0, OBS_PROJECTION_ORTHOGRAPHIC, &so), ctx);
    const ao_input *inputs[3] = {&in, &sy.in, &so.in};
    const char *names[3] = {"sphere over ground", "synthetic with NaN and background", "orthographic"};
    for (int j = 0; j < 3; j++)
        for (int variant = 0; variant < AO_SAO_VARIANT_COUNT; variant++)
            for (int nm = 0; nm < AO_SAO_NORMALS_COUNT; nm++)
                for (int mip = 0; mip < 3; mip++) {
                    if (nm == AO_SAO_NORMALS_GBUFFER && !inputs[j]->normal[0])
                        continue;
                    ao_sao_params p;
                    ao_sao_params_preset(variant == AO_SAO_VARIANT_G3D_HQ ? "g3d-hq" : "default", &p);
                    p.normals = (ao_sao_normals)nm;
                    p.max_mip_level = mip == 0 ? 0 : mip == 1 ? 5 : 15;
                    p.radius = j == 0 ? 0.8f : 1.5f;
                    if (mip == 2) {
                        p.samples = 23;
                        p.spiral_turns = 1000;
                        p.log_max_offset = 0;
                        p.intensity = 1.7f;
                    }
                    char what[160];
                    snprintf(what, sizeof what, "%s, %s, %s normals, max mip %d", names[j],
                             variant ? "g3d-hq" : "hpg12", nm ? "gbuffer" : "depth", p.max_mip_level);
                    sao_paths_agree(ctx, inputs[j], &p, what);
                }
    /* 3. the lanes the AVX2 kernel hands back to the scalar helpers. (a) floor(log2(ssR)) just
     * below a power of two, where the float log2 rounds up: a plane at depth 1 facing the camera,
     * f = 16 - 2^-20 px and r = 1, one tap (alpha = 0.5): ssR = 8 - 2^-21 at every pixel of depth 1,
     * whose float log2 is 3.0 (the exponent says 2); every third pixel nearer, so that the texel a
     * tap reads depends on the level. */
    synth sp;
    const obs_dvec3 facing = {0, 0, 1};
    CHECK_OK(tu_synth_plane(ctx, 96, 64, 16.0 - 0x1p-20, facing, -1.0, OBS_PROJECTION_PERSPECTIVE, &sp), ctx);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 96; x++)
            if ((x + 2 * y) % 3 == 0)
                obs_image_f32_row(&sp.depth, y)[x] = 0.93f;
    ao_sao_params pn = ao_sao_params_default();
    pn.samples = 1;
    pn.blur = 0;
    pn.max_mip_level = 5;
    pn.log_max_offset = 0;
    pn.radius = 1.0f;
    {
        const ao_sao_constants kn = ao_sao_constants_from_params(&pn, &sp.in);
        const float ssR = (0.5f * kn.inv_num_samples) * ((-kn.proj_scale * kn.radius) / -1.0f); /* alpha disk */
        CHECK_MSG(ssR == 8.0f - 0x1p-21f, "ssR %a is not 8 - 2^-21", (double)ssR);
        CHECK_EQ_INT(ao_i_floor_log2f(ssR), 3);
        sao_paths_agree_k(ctx, &sp.in, kn, "log2 just below a power of two");
        /* (b) angles past 3e9, which ao_i_cos_sin sends to libm: only reachable through an external
         * constant block (turns_angle is not range-checked there) */
        ao_sao_constants kb = ao_sao_constants_from_params(&pn, &sp.in);
        kb.turns_angle = 7.5e9f;
        sao_paths_agree_k(ctx, &sp.in, kb, "angles beyond the exact reduction");
    }
    obs_image_f32_free(&sp.depth);
    obs_image_f32_free(&sy.depth);
    obs_image_f32_free(&so.depth);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
