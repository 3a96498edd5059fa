/* test_ao_crytek.c: Crytek SSAO [Kajalin09] (src/ao/ao_crytek.c): the flat-plane value, the tap
 * sequence and constants of the ShaderX7 listing, the rotation texture and its matrices, an
 * independent double-precision evaluation of single pixels, hand-computed range-check cases,
 * accuracy against the matched "vol" ground truth, the guard band and blur reach, threads, hard
 * cases, parameter errors and the CLI. Registry-wide properties are in test_ao_methods.c. */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "test.h"
#include "truth/truth.h"

#include <math.h>
#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ----------------------------------------------------------------------------------- */

static obs_status run_crytek(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_crytek_params *p,
                             obs_image_f32 *out, obs_image_f32 *raw)
{
    memset(out, 0, sizeof *out);
    if (raw)
        memset(raw, 0, sizeof *raw);
    obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
    if (st == OBS_STATUS_OK && raw)
        st = obs_image_f32_alloc(ctx, in->w, in->h, raw);
    if (st == OBS_STATUS_OK)
        st = ao_crytek_compute(ctx, pool, in, p, out, raw, NULL);
    return st;
}

static float at(const obs_image_f32 *im, int x, int y) { return obs_image_f32_row(im, y)[x]; }

/* A W x H input over a depth plane filled by the caller (centred pinhole, focal f). */
static void input_over(ao_input *in, obs_image_f32 *depth, double f)
{
    memset(in, 0, sizeof *in);
    in->width = in->w = depth->width;
    in->height = in->h = depth->height;
    in->depth = depth;
    in->fx = in->fy = f;
    in->cx = 0.5 * depth->width;
    in->cy = 0.5 * depth->height;
    in->projection = OBS_PROJECTION_PERSPECTIVE;
    in->znear = 0.1;
    in->zfar = INFINITY;
}

/* ---- flat plane ------------------------------------------------------------------------------- */

TEST(crytek_camera_facing_plane_is_exactly_three_quarters)
{
    /* ao.md 1.1: "A flat, unoccluded surface gives A = 0.5, which maps to 0.75". The 8 corners are 4
     * antipodal pairs (and N = 4 is two of them); on a camera-facing plane dS = dP everywhere, so
     * the range check is 0 and exactly one tap of each pair is in front (R.z < 0): A = 1/2 and
     * saturate(A^2 + A) = 0.75, both exact in float, at every pixel (the edge clamp reads the same
     * depth), for both spaces, filters, every study sample count, with and without the blur. */
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 96, 64, 80.0, obs_dv3(0, 0, 1), -5.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    static const int ns[] = {4, 8, 16, 32};
    for (int space = 0; space < AO_CRYTEK_SPACE_COUNT; space++)
        for (int filter = 0; filter < AO_CRYTEK_FILTER_COUNT; filter++)
            for (int k = 0; k < 4; k++)
                for (int blur = 0; blur < 2; blur++)
                    for (int output = 0; output < AO_CRYTEK_OUTPUT_COUNT; output++) {
                        ao_crytek_params p = ao_crytek_params_default();
                        p.space = (ao_crytek_space)space;
                        p.filter = (ao_crytek_filter)filter;
                        p.samples = ns[k];
                        p.blur = blur;
                        p.output = (ao_crytek_output)output;
                        obs_image_f32 out, raw;
                        CHECK_OK(run_crytek(ctx, NULL, &s.in, &p, &out, &raw), ctx);
                        const float want = output == AO_CRYTEK_OUTPUT_REMAP ? 0.75f : 0.5f;
                        for (int y = 0; y < 64; y++)
                            for (int x = 0; x < 96; x++) {
                                CHECK_MSG(at(&raw, x, y) == want, "space %d filter %d N %d output %d: raw (%d,%d) = %.9g",
                                          space, filter, ns[k], output, x, y, (double)at(&raw, x, y));
                                /* the 21 weights sum to 1 - 1.2e-7 in float (docs/ao/blur.md) */
                                CHECK_MSG(fabsf(at(&out, x, y) - want) <= 2e-7f, "blurred (%d,%d) = %.9g", x, y,
                                          (double)at(&out, x, y));
                            }
                        obs_image_f32_free(&out);
                        obs_image_f32_free(&raw);
                    }
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

TEST(crytek_tilted_plane_stays_near_three_quarters)
{
    /* The registry's 50-degree plane, r = 0.5 m (test_ao_methods.c). Single pixels move by whole
     * taps where the texel's rotation puts corners in the plane (docs/ao/crytek.md, "Flat plane");
     * measured (interior, 12 px from the borders): mean 0.7672 unblurred, max |dev| 0.0222 blurred.
     * Bounds: mean within 0.025 of 0.75, blurred max |dev| <= 0.03. */
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 96, 64, 80.0, obs_dv3(0, 0.766044443, 0.642787610), -4.0,
                            OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    ao_crytek_params p = ao_crytek_params_default();
    p.radius = 0.5f;
    obs_image_f32 out, raw;
    CHECK_OK(run_crytek(ctx, NULL, &s.in, &p, &out, &raw), ctx);
    double sum = 0.0, worst = 0.0;
    int n = 0;
    for (int y = 12; y < 52; y++)
        for (int x = 12; x < 84; x++) {
            sum += at(&raw, x, y);
            n++;
            double e = fabs(at(&out, x, y) - 0.75);
            worst = e > worst ? e : worst;
        }
    printf("  tilted plane: mean raw %.5f, blurred max |dev| %.5f\n", sum / n, worst);
    CHECK_NEAR(sum / n, 0.75, 0.025);
    CHECK(worst <= 0.03);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

/* ---- the tap sequence and the constants -------------------------------------------------------- */

TEST(crytek_taps_follow_the_shaderx7_loop)
{
    obs_context *ctx = obs_context_create();
    tu_synth s;
    CHECK_OK(tu_synth_plane(ctx, 64, 48, 50.0, obs_dv3(0, 0, 1), -3.0, OBS_PROJECTION_PERSPECTIVE, &s), ctx);
    static ao_crytek_constants k;
    /* kajalin: offsetScale 0.01, step 1 + 2.4/16 = 1.15, taps normalize(x, y, z) * 0.01 * 1.15^(t+1)
     * in the order for (i < 2) for x for y for z, with x, y, z in {-1, +1} */
    ao_crytek_params p;
    CHECK(ao_crytek_params_preset("kajalin", &p));
    CHECK_OK(ao_crytek_params_validate(ctx, &p), ctx);
    ao_crytek_constants_from_params(&p, &s.in, &k);
    CHECK_EQ_INT(k.num_samples, 16);
    CHECK(k.space == AO_CRYTEK_SPACE_SCREEN && k.blur == 0);
    CHECK(k.offset_scale == 0.01f && k.offset_scale_step == 1.15f);
    CHECK(k.kxy[0] == 1.0f && k.kxy[1] == 1.0f && k.kz == 2.0f);
    for (int t = 0; t < 16; t++) {
        const int c = t % 8;
        const double sx = (c & 4) ? 1 : -1, sy = (c & 2) ? 1 : -1, sz = (c & 1) ? 1 : -1;
        const double sc = 0.01 * pow(1.15, t + 1) / sqrt(3.0);
        CHECK_NEAR(k.offsets[t][0], sx * sc, 2e-6 * sc);
        CHECK_NEAR(k.offsets[t][1], sy * sc, 2e-6 * sc);
        CHECK_NEAR(k.offsets[t][2], sz * sc, 2e-6 * sc);
    }
    /* radii grow from 0.0115 to 0.01 * 1.15^16 = 0.0936 UV units (ao.md 1.1: "from 0.0115 to about 0.094") */
    CHECK_NEAR(sqrt(3.0) * fabs(k.offsets[0][0]), 0.0115, 1e-6);
    CHECK_NEAR(sqrt(3.0) * fabs(k.offsets[15][0]), 0.0935762, 1e-6);
    /* N = 32: step 1.075, four rounds; N = 4: the corners with y == z, step 1.6 */
    p.samples = 32;
    ao_crytek_constants_from_params(&p, &s.in, &k);
    CHECK(k.offset_scale_step == 1.075f);
    CHECK_NEAR(sqrt(3.0) * fabs(k.offsets[31][2]), 0.01 * pow(1.075, 32), 1e-6);
    p.samples = 4;
    ao_crytek_constants_from_params(&p, &s.in, &k);
    CHECK(k.offset_scale_step == 1.6f);
    static const int c4[4][3] = {{-1, -1, -1}, {-1, 1, 1}, {1, -1, -1}, {1, 1, 1}};
    for (int t = 0; t < 4; t++)
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(k.offsets[t][a], c4[t][a] * 0.01 * pow(1.6, t + 1) / sqrt(3.0), 1e-8);
    /* world: the largest tap is r: kxy = (r / s_N) (f / W, f / H), kz = r / s_N */
    p = ao_crytek_params_default();
    p.radius = 0.75f;
    ao_crytek_constants_from_params(&p, &s.in, &k);
    const double sN = 0.01 * pow(1.15, 16);
    CHECK_NEAR(k.kz, 0.75 / sN, 1e-5 * 0.75 / sN);
    CHECK_NEAR(k.kxy[0], 0.75 / sN * 50.0 / 64.0, 1e-4);
    CHECK_NEAR(k.kxy[1], 0.75 / sN * 50.0 / 48.0, 1e-4);
    /* the world offsets are independent of offset_scale except through rounding */
    CHECK_NEAR(k.kz * sqrt(3.0) * fabs(k.offsets[15][0]), 0.75, 1e-5);
    /* the JSON constant block carries what a port needs */
    char buf[16384];
    const ao_method *m = ao_method_find("crytek");
    CHECK(m && m->constants_to_json);
    int len = m->constants_to_json(&p, &s.in, buf, sizeof buf);
    CHECK(len > 0 && len < (int)sizeof buf);
    CHECK(strstr(buf, "\"offsetScaleStep\": 1.14999998") && strstr(buf, "\"rotation\": [[0.248039186, 0, 0.96875]"));
    obs_image_f32_free(&s.depth);
    obs_context_destroy(ctx);
}

TEST(crytek_rotation_texture_is_the_documented_generator)
{
    /* ao.h: texel (i, j) holds vector k = bayer4[j][i] of the golden-angle spiral over the upper
     * hemisphere, z = 1 - (k + 1/2)/16, phi = k pi (3 - sqrt 5), in double rounded to float. */
    static const int bayer[4][4] = {{0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}};
    const double ga = 3.14159265358979323846 * (3.0 - sqrt(5.0));
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            const int kk = bayer[j][i];
            const double z = 1.0 - (kk + 0.5) / 16.0, rho = sqrt(1.0 - z * z), phi = kk * ga;
            const float *r = ao_crytek_rotation[4 * j + i];
            CHECK_MSG(r[0] == (float)(rho * cos(phi)) && r[1] == (float)(rho * sin(phi)) && r[2] == (float)z,
                      "texel (%d,%d)", i, j);
            /* the matrix: a proper rotation taking +z to r (row vector convention: e_z M = row 2) */
            float m[9];
            ao_crytek_rotation_matrix(r, m);
            CHECK(m[6] == r[0] && m[7] == r[1] && m[8] == r[2]);
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) {
                    double d = (double)m[3 * a] * m[3 * b] + (double)m[3 * a + 1] * m[3 * b + 1] +
                               (double)m[3 * a + 2] * m[3 * b + 2];
                    CHECK_NEAR(d, a == b ? 1.0 : 0.0, 1e-6);
                }
            double det = (double)m[0] * (m[4] * m[8] - m[5] * m[7]) - (double)m[1] * (m[3] * m[8] - m[5] * m[6]) +
                         (double)m[2] * (m[3] * m[7] - m[4] * m[6]);
            CHECK_NEAR(det, 1.0, 1e-6);
        }
    /* ao.md 1.1 matrix by hand for r = (0.6, 0, 0.8): h = 1/1.8; row 0 = (0.8, 0, -0.6), row 1 =
     * (0, 0.36/1.8 + 0.8 = 1, 0) */
    float m[9];
    const float r[3] = {0.6f, 0.0f, 0.8f};
    ao_crytek_rotation_matrix(r, m);
    CHECK_NEAR(m[0], 0.8, 1e-7);
    CHECK_NEAR(m[1], 0.0, 1e-7);
    CHECK_NEAR(m[2], -0.6, 1e-7);
    CHECK_NEAR(m[4], 1.0, 1e-7);
    CHECK_NEAR(m[5], 0.0, 1e-7);
    /* pixel (3, 5) of a 64-row buffer: y_gl = 58, texel (3, 2), index 11, vector k = 9 */
    CHECK(ao_crytek_rotation[4 * (58 & 3) + (3 & 3)][2] == (float)(1.0 - 9.5 / 16.0));
}

/* ---- an independent evaluation ----------------------------------------------------------------- */

/* The depth at GL texture position (sx, sy) in texels: nearest, or GL_LINEAR (spec form) with clamp
 * to edge (no background in these buffers). */
static double ref_fetch(const ao_input *in, double sx, double sy, int linear)
{
    const int W = in->width, H = in->height;
    if (!linear) {
        int tx = (int)floor(sx), ty = (int)floor(sy);
        tx = tx < 0 ? 0 : tx > W - 1 ? W - 1 : tx;
        ty = ty < 0 ? 0 : ty > H - 1 ? H - 1 : ty;
        return at(in->depth, tx, H - 1 - ty);
    }
    const double fx = sx - 0.5, fy = sy - 0.5, i0 = floor(fx), j0 = floor(fy), a = fx - i0, b = fy - j0;
    double T[2][2];
    for (int dj = 0; dj < 2; dj++)
        for (int di = 0; di < 2; di++) {
            int i = (int)i0 + di, j = (int)j0 + dj;
            i = i < 0 ? 0 : i > W - 1 ? W - 1 : i;
            j = j < 0 ? 0 : j > H - 1 ? H - 1 : j;
            T[dj][di] = at(in->depth, i, H - 1 - j);
        }
    return (1 - a) * (1 - b) * T[0][0] + a * (1 - b) * T[0][1] + (1 - a) * b * T[1][0] + a * b * T[1][1];
}

/* The listing for one pixel, written out again in double from the formulas (sky visible): taps,
 * rotation, projection, fetch, range check, remap. */
static double crytek_ref_pixel(const ao_input *in, int space, int linear, double radius, double offset_scale, int N,
                               int x, int y)
{
    const int W = in->width, H = in->height, y_gl = H - 1 - y;
    const double dP = at(in->depth, x, y);
    const float *rv = ao_crytek_rotation[4 * (y_gl % 4) + (x % 4)];
    const double rx = rv[0], ry = rv[1], rz = rv[2], h = 1.0 / (1.0 + rz);
    const double M[3][3] = {{h * ry * ry + rz, -h * ry * rx, -rx}, {-h * ry * rx, h * rx * rx + rz, -ry}, {rx, ry, rz}};
    const double step = 1.0 + 2.4 / N, sN = offset_scale * pow(step, N);
    const double u = (x + 0.5) / W, v = (y_gl + 0.5) / H;
    double acc = 0.0, s = offset_scale;
    int t = 0;
    for (int i = 0; i < N / 8; i++)
        for (int cx = -1; cx <= 1; cx += 2)
            for (int cy = -1; cy <= 1; cy += 2)
                for (int cz = -1; cz <= 1; cz += 2, t++) {
                    s *= step;
                    const double o[3] = {cx * s / sqrt(3.0), cy * s / sqrt(3.0), cz * s / sqrt(3.0)};
                    double R[3];
                    for (int j = 0; j < 3; j++)
                        R[j] = o[0] * M[0][j] + o[1] * M[1][j] + o[2] * M[2][j];
                    double Sx, Sy, Sz;
                    if (space == AO_CRYTEK_SPACE_SCREEN) {
                        Sx = u + R[0];
                        Sy = v + R[1];
                        Sz = dP + R[2] * dP * 2.0;
                    } else {
                        /* the view-space point P + R r / s_N, projected */
                        const double m = radius / sN;
                        const double ax = (x + 0.5 - in->cx) / in->fx, ay = (y_gl + 0.5 - (H - in->cy)) / in->fy;
                        const double P[3] = {ax * dP, ay * dP, dP}; /* (x, y, depth) */
                        const double Q[3] = {P[0] + R[0] * m, P[1] + R[1] * m, P[2] + R[2] * m};
                        Sz = Q[2];
                        Sx = (Q[0] / Q[2] * in->fx + in->cx) / W;
                        Sy = (Q[1] / Q[2] * in->fy + (H - in->cy)) / H;
                    }
                    const double dS = ref_fetch(in, Sx * W, Sy * H, linear);
                    double r = (dP - dS) / dS;
                    r = r < 0 ? 0 : r > 1 ? 1 : r;
                    const double a = dS > Sz ? 1.0 : 0.0;
                    acc += a + r * (0.5 - a);
                }
    const double A = acc / N, o = A * A + A;
    return o > 1 ? 1 : o;
}

TEST(crytek_pixels_match_an_independent_double_evaluation)
{
    /* A bumpy depth field with steps (so that taps read different depths and the range check is
     * neither 0 nor 1): pixels (3, 5) and others, both spaces, both filters, N = 8 and 16. A tap decision that
     * rounds differently in float and double would change a value by >= 1/(2N) in A; the bound
     * 1e-5 allows only rounding of the range-check terms. */
    obs_context *ctx = obs_context_create();
    obs_image_f32 d;
    const int W = 48, H = 40;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &d), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&d, y)[x] =
                (float)(4.0 + 0.3 * sin(0.7 * x) * cos(0.45 * y) + (x > 20 ? -1.1 : 0.0) + (y > 25 ? 0.8 : 0.0));
    ao_input in;
    input_over(&in, &d, 40.0);
    static const int px[][2] = {{3, 5}, {20, 20}, {21, 26}, {30, 12}, {10, 33}, {44, 2}};
    for (int space = 0; space < 2; space++)
        for (int N = 8; N <= 16; N += 8)
        for (int linear = 0; linear < 2; linear++) {
            ao_crytek_params p = ao_crytek_params_default();
            p.space = (ao_crytek_space)space;
            p.filter = linear ? AO_CRYTEK_FILTER_LINEAR : AO_CRYTEK_FILTER_NEAREST;
            p.samples = N;
            p.blur = 0;
            p.radius = 0.6f;
            p.offset_scale = 0.02f;
            obs_image_f32 out;
            CHECK_OK(run_crytek(ctx, NULL, &in, &p, &out, NULL), ctx);
            int distinct = 0; /* the case is not trivial: the pixels differ from each other and from 0.75 */
            for (size_t i = 0; i < sizeof px / sizeof px[0]; i++) {
                int seen = at(&out, px[i][0], px[i][1]) == 0.75f;
                for (size_t j = 0; j < i; j++)
                    seen |= at(&out, px[i][0], px[i][1]) == at(&out, px[j][0], px[j][1]);
                distinct += !seen;
            }
            CHECK_MSG(distinct >= 3, "space %d N %d linear %d: only %d distinct values", space, N, linear, distinct);
            for (size_t i = 0; i < sizeof px / sizeof px[0]; i++) {
                const double want = crytek_ref_pixel(&in, space, linear, 0.6, 0.02, N, px[i][0], px[i][1]);
                CHECK_MSG(fabs(at(&out, px[i][0], px[i][1]) - want) <= 1e-5,
                          "space %d N %d linear %d pixel (%d,%d): %.7f, want %.7f", space, N, linear, px[i][0], px[i][1],
                          (double)at(&out, px[i][0], px[i][1]), want);
            }
            obs_image_f32_free(&out);
        }
    obs_image_f32_free(&d);
    obs_context_destroy(ctx);
}

/* ---- hand-computed cases: the range check ------------------------------------------------------- */

TEST(crytek_range_check_hand_computed_cases)
{
    /* One pixel at depth dP in a W = 512 buffer of constant depth dN (screen space, offsetScale
     * 0.01, nearest filter, N = 16). Every rotated tap has |R.xy| >= 0.2 |R| >= 0.0023 UV = 1.18 px
     * (checked below), so no tap reads the centre pixel itself; every tap reads dN.
     *   dN = 8,  dP = 10: range (10-8)/8 = 0.25; S.z >= 10 (1 - 2 * 0.094) > 8: hidden (0);
     *                     each tap 0 + 0.25 (0.5 - 0) = 0.125; A = 0.125; out = A^2 + A = 0.140625
     *   dN = 4,  dP = 10: range saturate(1.5) = 1: each tap 0.5 ("an occluder far in front counts
     *                     as 0.5"); A = 0.5; out = 0.75
     *   dN = 10, dP = 4:  S.z <= 4 (1 + 2 * 0.094) < 10: seen (1), range < 0 -> 0: A = 1, out = 1
     *   dN = +inf, dP = 4: every tap on the sky: visible -> A = 1, out 1; skip -> A = 0, out 0 */
    obs_context *ctx = obs_context_create();
    const int W = 512, H = 512, cx = 300, cy = 200;
    obs_image_f32 d;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &d), ctx);
    ao_input in;
    input_over(&in, &d, 400.0);
    in.x0 = cx;
    in.y0 = cy;
    in.w = in.h = 1;
    ao_crytek_params p;
    CHECK(ao_crytek_params_preset("kajalin", &p));
    p.filter = AO_CRYTEK_FILTER_NEAREST;
    static ao_crytek_constants k;
    ao_crytek_constants_from_params(&p, &in, &k);
    const float *M = k.rot_mat[4 * ((H - 1 - cy) & 3) + (cx & 3)];
    for (int t = 0; t < 16; t++) {
        const float *o = k.offsets[t];
        double R[3], l2 = 0.0;
        for (int j = 0; j < 3; j++) {
            R[j] = o[0] * M[j] + o[1] * M[3 + j] + o[2] * M[6 + j];
            l2 += R[j] * R[j];
        }
        CHECK_MSG(R[0] * R[0] + R[1] * R[1] >= 0.04 * l2, "tap %d nearly along z", t);
    }
    static const struct {
        float dN, dP;
        int sky;
        float want;
    } cases[] = {{8.0f, 10.0f, 0, 0.140625f}, {4.0f, 10.0f, 0, 0.75f}, {10.0f, 4.0f, 0, 1.0f},
                 {INFINITY, 4.0f, AO_CRYTEK_SKY_VISIBLE, 1.0f}, {INFINITY, 4.0f, AO_CRYTEK_SKY_SKIP, 0.0f}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                obs_image_f32_row(&d, y)[x] = cases[c].dN;
        obs_image_f32_row(&d, cy)[cx] = cases[c].dP;
        p.sky = (ao_crytek_sky)cases[c].sky;
        obs_image_f32 out;
        CHECK_OK(run_crytek(ctx, NULL, &in, &p, &out, NULL), ctx);
        CHECK_MSG(at(&out, 0, 0) == cases[c].want, "case %zu: %.9g, want %.9g", c, (double)at(&out, 0, 0),
                  (double)cases[c].want);
        obs_image_f32_free(&out);
    }
    obs_image_f32_free(&d);
    obs_context_destroy(ctx);
}

/* ---- accuracy against the matched ground truth ------------------------------------------------- */

TEST(crytek_accuracy_against_vol_on_the_analytic_scene)
{
    /* The sphere over the ground (tu_ao_scene), 80 x 60, r = 0.5 m, N = 32, no blur. The matched
     * truth is VOL (the fraction of the ball B(p, r) the eye sees; truth.h). Compared over surface
     * pixels: A (output "accessibility") against VOL, and the remapped output against
     * saturate(VOL^2 + VOL). Measured values and bounds are recorded in docs/ao/crytek.md. */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    const obs_camera cam = tu_ao_camera();
    rast_params rp = rast_params_default();
    rp.width = 80;
    rp.height = 60;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, NULL, &s, &v, 1, &rp, &gb, NULL), ctx);
    truth_scene *ts = NULL;
    CHECK_OK(truth_scene_create(ctx, &s, TRUTH_BUILD_MEDIUM, &ts), ctx);
    truth_ao_params tp = truth_ao_params_default();
    tp.estimator = TRUTH_AO_VOL;
    tp.radius = 0.5f;
    tp.target_error = 0.005;
    tp.max_samples = 2048;
    obs_pool *pool = obs_pool_create(2);
    truth_ao_result tr;
    CHECK_OK(truth_ao_render(ctx, pool, ts, &s, &cam, &gb, &tp, &tr), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    ao_crytek_params p = ao_crytek_params_default();
    p.radius = 0.5f;
    p.samples = 32;
    p.blur = 0;
    double err[2][3] = {{0}}; /* [A, remap][sum e, sum e^2, max |e|] */
    int n = 0;
    for (int o = 0; o < 2; o++) {
        p.output = o ? AO_CRYTEK_OUTPUT_REMAP : AO_CRYTEK_OUTPUT_ACCESSIBILITY;
        obs_image_f32 out;
        CHECK_OK(run_crytek(ctx, pool, &in, &p, &out, NULL), ctx);
        n = 0;
        for (int y = 0; y < in.h; y++)
            for (int x = 0; x < in.w; x++) {
                if (at(&tr.count, x, y) == 0.0f)
                    continue;
                double V = at(&tr.mean, x, y), want = o ? fmin(1.0, V * V + V) : V;
                double e = at(&out, x, y) - want;
                err[o][0] += e;
                err[o][1] += e * e;
                err[o][2] = fmax(err[o][2], fabs(e));
                n++;
            }
        obs_image_f32_free(&out);
    }
    CHECK(n > 1000);
    const double biasA = err[0][0] / n, rmseA = sqrt(err[0][1] / n), biasR = err[1][0] / n, rmseR = sqrt(err[1][1] / n);
    printf("  vs vol (r = 0.5, N = 32, %d px): A bias %+.4f RMSE %.4f max %.3f; remapped bias %+.4f RMSE %.4f max %.3f\n",
           n, biasA, rmseA, err[0][2], biasR, rmseR, err[1][2]);
    /* measured (docs/ao/crytek.md): A bias +0.0144, RMSE 0.0621; remapped bias +0.0236, RMSE 0.1004.
     * Bounds: those plus a margin (the truth's standard error is <= 0.005 per pixel) */
    CHECK(biasA >= -0.005 && biasA <= 0.025 && rmseA <= 0.075);
    CHECK(biasR >= -0.005 && biasR <= 0.035 && rmseR <= 0.115);
    truth_ao_result_free(&tr);
    truth_scene_destroy(ts);
    obs_pool_destroy(pool);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- guard band, blur reach, threads ------------------------------------------------------------ */

TEST(crytek_window_equals_the_crop_of_the_whole_buffer)
{
    /* With a guard band the AO pass runs over the window plus the blur's 10 px reach, so the window's
     * result equals the whole buffer's result cropped (what a GPU computing both passes over the
     * whole buffer gives), byte for byte; with 1, 2 and 8 threads. */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 61, 47, 13, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    ao_input full = in;
    full.x0 = full.y0 = 0;
    full.w = in.width;
    full.h = in.height;
    obs_pool *pools[3] = {obs_pool_create(1), obs_pool_create(2), obs_pool_create(8)};
    for (int blur = 0; blur < 2; blur++) {
        ao_crytek_params p = ao_crytek_params_default();
        p.blur = blur;
        obs_image_f32 fo, fr;
        CHECK_OK(run_crytek(ctx, NULL, &full, &p, &fo, &fr), ctx);
        for (int t = 0; t < 3; t++) {
            obs_image_f32 wo, wr;
            CHECK_OK(run_crytek(ctx, pools[t], &in, &p, &wo, &wr), ctx);
            for (int y = 0; y < in.h; y++) {
                CHECK_MSG(!memcmp(obs_image_f32_row(&wo, y), obs_image_f32_row(&fo, y + in.y0) + in.x0, 4 * (size_t)in.w),
                          "blur %d, %d threads: row %d differs from the full buffer's", blur, t, y);
                CHECK(!memcmp(obs_image_f32_row(&wr, y), obs_image_f32_row(&fr, y + in.y0) + in.x0, 4 * (size_t)in.w));
            }
            obs_image_f32_free(&wo);
            obs_image_f32_free(&wr);
        }
        obs_image_f32_free(&fo);
        obs_image_f32_free(&fr);
    }
    for (int t = 0; t < 3; t++)
        obs_pool_destroy(pools[t]);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(crytek_output_planes_do_not_change_the_result)
{
    /* Over the whole buffer the passes write the caller's planes directly (AO into out_raw or out,
     * the blur into out): with and without out_raw, with and without the blur, the bytes are those
     * of the windowed path (a 1 px guard band, which allocates and crops). */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 64, 48, 0, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    for (int blur = 0; blur < 2; blur++) {
        ao_crytek_params p = ao_crytek_params_default();
        p.blur = blur;
        obs_image_f32 o1, r1, o2;
        CHECK_OK(run_crytek(ctx, NULL, &in, &p, &o1, &r1), ctx);
        CHECK_OK(run_crytek(ctx, NULL, &in, &p, &o2, NULL), ctx);
        CHECK_MSG(tu_same_plane(&o1, &o2), "blur %d: out depends on out_raw", blur);
        if (!blur)
            CHECK(tu_same_plane(&o1, &r1));
        /* the inner 62 x 46 window (region = window + reach, allocated and cropped) */
        ao_input w = in;
        w.x0 = w.y0 = 1;
        w.w = in.width - 2;
        w.h = in.height - 2;
        obs_image_f32 wo, wr;
        CHECK_OK(run_crytek(ctx, NULL, &w, &p, &wo, &wr), ctx);
        for (int y = 0; y < w.h; y++) {
            CHECK(!memcmp(obs_image_f32_row(&wo, y), obs_image_f32_row(&o1, y + 1) + 1, 4 * (size_t)w.w));
            CHECK(!memcmp(obs_image_f32_row(&wr, y), obs_image_f32_row(&r1, y + 1) + 1, 4 * (size_t)w.w));
        }
        obs_image_f32_free(&o1);
        obs_image_f32_free(&r1);
        obs_image_f32_free(&o2);
        obs_image_f32_free(&wo);
        obs_image_f32_free(&wr);
    }
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- hard cases ---------------------------------------------------------------------------------- */

static int unit_finite(const obs_image_f32 *a)
{
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++)
            if (!(at(a, x, y) >= 0.0f && at(a, x, y) <= 1.0f))
                return 0;
    return 1;
}

TEST(crytek_hard_cases_stay_finite_and_in_unit_range)
{
    obs_context *ctx = obs_context_create();
    /* reversed-Z with an infinite far plane gives linear depths from near to huge: a grazing plane
     * to the horizon (depths up to ~1e30 and +inf), NaN, 0 and negative depths, tiny and huge radii
     * (taps behind the eye), 1x1 and odd sizes, every space, filter, sky mode and output */
    obs_image_f32 d;
    const int W = 37, H = 23;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &d), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double t = 0.01 / pow(10.0, 32.0 * y / (H - 1)); /* 0.01 .. 1e-34 */
            float v = (float)(0.01 / t);                        /* z = near / d_ndc: 1 .. 1e32 */
            int h = (x * 5 + y * 3) % 17;
            obs_image_f32_row(&d, y)[x] = h == 0 ? NAN : h == 1 ? INFINITY : h == 2 ? 0.0f : h == 3 ? -2.0f
                                          : h == 4 ? 3e38f : v;
        }
    ao_input in;
    input_over(&in, &d, 20.0);
    static const float radii[] = {1e-6f, 0.5f, 1e6f};
    for (int space = 0; space < 2; space++)
        for (int filter = 0; filter < 2; filter++)
            for (int sky = 0; sky < 2; sky++)
                for (int r = 0; r < 3; r++)
                    for (int o = 0; o < 2; o++) {
                        ao_crytek_params p = ao_crytek_params_default();
                        p.space = (ao_crytek_space)space;
                        p.filter = (ao_crytek_filter)filter;
                        p.sky = (ao_crytek_sky)sky;
                        p.radius = radii[r];
                        p.offset_scale = r == 2 ? 1e3f : 0.01f;
                        p.output = (ao_crytek_output)o;
                        obs_image_f32 out, raw;
                        CHECK_OK(run_crytek(ctx, NULL, &in, &p, &out, &raw), ctx);
                        CHECK_MSG(unit_finite(&out) && unit_finite(&raw), "space %d filter %d sky %d radius %g", space,
                                  filter, sky, (double)radii[r]);
                        for (int y = 0; y < H; y++)
                            for (int x = 0; x < W; x++) {
                                float dv = at(&d, x, y);
                                if (!(dv > 0.0f && dv < INFINITY))
                                    CHECK(at(&out, x, y) == 1.0f && at(&raw, x, y) == 1.0f);
                            }
                        obs_image_f32_free(&out);
                        obs_image_f32_free(&raw);
                    }
    /* 1x1 and orthographic */
    obs_image_f32 one;
    CHECK_OK(obs_image_f32_alloc(ctx, 1, 1, &one), ctx);
    obs_image_f32_row(&one, 0)[0] = 3.0f;
    input_over(&in, &one, 1.0);
    for (int pr = 0; pr < 2; pr++) {
        in.projection = pr ? OBS_PROJECTION_ORTHOGRAPHIC : OBS_PROJECTION_PERSPECTIVE;
        ao_crytek_params p = ao_crytek_params_default();
        obs_image_f32 out;
        CHECK_OK(run_crytek(ctx, NULL, &in, &p, &out, NULL), ctx);
        /* one pixel of constant depth: every tap reads it, a plane facing the camera: 0.75 */
        CHECK_NEAR(at(&out, 0, 0), 0.75, 2e-7);
        obs_image_f32_free(&out);
    }
    obs_image_f32_free(&one);
    obs_image_f32_free(&d);
    obs_context_destroy(ctx);
}

/* ---- scalar == AVX2 ------------------------------------------------------------------------------ */

TEST(crytek_avx2_equals_scalar_byte_for_byte)
{
    /* The AVX2 path (8 pixels per vector, gathered bilinear footprints, scalar fetches at edges and
     * background) against the scalar reference on the analytic scene with its sky, plus NaN, +inf,
     * 0, negative, huge (3e38) and far (1e30) depths scattered over it; a window whose region does
     * not start on a multiple of 4; every space, filter, sky, output, N, tiny/default/huge radii
     * (taps behind the eye), perspective and orthographic, with and without blur, 1 and 2 threads. */
    if (!ao_crytek_isa_available(AO_CRYTEK_ISA_AVX2)) {
        printf("    (no AVX2 in this CPU or build: only AUTO == SCALAR is checked)\n");
    }
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    rast_gbuffer gb;
    CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), 117, 71, 13, &gb), ctx);
    ao_input in;
    CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
    obs_image_f32 *depth = (obs_image_f32 *)in.depth;
    for (int y = 0; y < depth->height; y++)
        for (int x = 0; x < depth->width; x++) {
            const int h = (x * 7 + y * 13) % 53;
            float *d = obs_image_f32_row(depth, y) + x;
            if (h == 0)
                *d = NAN;
            else if (h == 1)
                *d = INFINITY;
            else if (h == 2)
                *d = 0.0f;
            else if (h == 3)
                *d = -1.0f;
            else if (h == 4)
                *d = 3e38f;
            else if (h == 5)
                *d = 1e30f;
            else if (h == 6)
                *d = 1e-40f; /* denormal: a surface, or background under DAZ (below) */
        }
    const ao_crytek_isa isas[3] = {AO_CRYTEK_ISA_SCALAR, AO_CRYTEK_ISA_AVX2, AO_CRYTEK_ISA_AUTO};
    const int nisa = ao_crytek_isa_available(AO_CRYTEK_ISA_AVX2) ? 3 : 1;
    obs_pool *pool2 = obs_pool_create(2);
    static const float radii[] = {1e-6f, 0.5f, 3.0f, 1e6f};
    static const int samples[] = {4, 8, 16, 32};
    int cases = 0;
    for (int pr = 0; pr < 2; pr++)
        for (int space = 0; space < 2; space++)
            for (int filter = 0; filter < 2; filter++)
                for (int sky = 0; sky < 2; sky++)
                    for (int ri = 0; ri < 4; ri++)
                        for (int ni = 0; ni < 4; ni++) {
                            if (ni != 2 && ri != 1)
                                continue; /* N varies at the default radius only */
                            in.projection = pr ? OBS_PROJECTION_ORTHOGRAPHIC : OBS_PROJECTION_PERSPECTIVE;
                            ao_crytek_params p = ao_crytek_params_default();
                            p.space = (ao_crytek_space)space;
                            p.filter = (ao_crytek_filter)filter;
                            p.sky = (ao_crytek_sky)sky;
                            p.radius = radii[ri];
                            p.offset_scale = ri == 3 ? 0.3f : 0.01f;
                            p.samples = samples[ni];
                            p.output = (ao_crytek_output)((ri + ni) & 1);
                            p.blur = (sky + ni) & 1;
                            ao_crytek_constants *k = (ao_crytek_constants *)malloc(sizeof *k);
                            ao_crytek_constants_from_params(&p, &in, k);
                            obs_image_f32 ref, ref_raw;
                            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &ref), ctx);
                            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &ref_raw), ctx);
                            CHECK_OK(ao_crytek_compute_constants_isa(ctx, NULL, &in, k, AO_CRYTEK_ISA_SCALAR, &ref,
                                                                     &ref_raw, NULL),
                                     ctx);
                            for (int ii = 0; ii < nisa; ii++)
                                for (int th = 0; th < 2; th++) {
                                    obs_image_f32 o, r;
                                    CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &o), ctx);
                                    CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &r), ctx);
                                    CHECK_OK(ao_crytek_compute_constants_isa(ctx, th ? pool2 : NULL, &in, k, isas[ii],
                                                                             &o, &r, NULL),
                                             ctx);
                                    CHECK_MSG(tu_same_plane(&o, &ref) && tu_same_plane(&r, &ref_raw),
                                              "isa %d threads %d: ortho %d space %d filter %d sky %d r %g N %d differ",
                                              (int)isas[ii], th + 1, pr, space, filter, sky, (double)radii[ri],
                                              samples[ni]);
                                    obs_image_f32_free(&o);
                                    obs_image_f32_free(&r);
                                }
                            obs_image_f32_free(&ref);
                            obs_image_f32_free(&ref_raw);
                            free(k);
                            cases++;
                        }
    CHECK(cases == 2 * 2 * 2 * 2 * 7);
#if defined(__SSE__) || defined(__x86_64__)
    /* with denormals-are-zero and flush-to-zero set (as Embree asks of its threads), both paths
     * classify the denormal depths alike */
    if (nisa > 1) {
        const unsigned csr = _mm_getcsr();
        _mm_setcsr(csr | 0x8040u); /* FTZ | DAZ */
        for (int filter = 0; filter < 2; filter++) {
            in.projection = OBS_PROJECTION_PERSPECTIVE;
            ao_crytek_params p = ao_crytek_params_default();
            p.filter = (ao_crytek_filter)filter;
            ao_crytek_constants *k = (ao_crytek_constants *)malloc(sizeof *k);
            ao_crytek_constants_from_params(&p, &in, k);
            obs_image_f32 a, b;
            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &a), ctx);
            CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &b), ctx);
            CHECK_OK(ao_crytek_compute_constants_isa(ctx, NULL, &in, k, AO_CRYTEK_ISA_SCALAR, &a, NULL, NULL), ctx);
            CHECK_OK(ao_crytek_compute_constants_isa(ctx, NULL, &in, k, AO_CRYTEK_ISA_AVX2, &b, NULL, NULL), ctx);
            CHECK_MSG(tu_same_plane(&a, &b), "DAZ, filter %d: AVX2 differs from scalar", filter);
            obs_image_f32_free(&a);
            obs_image_f32_free(&b);
            free(k);
        }
        _mm_setcsr(csr);
    }
#endif
    /* an ISA this build or CPU lacks is an error, not a silent fallback */
    if (!ao_crytek_isa_available(AO_CRYTEK_ISA_AVX2)) {
        ao_crytek_params p = ao_crytek_params_default();
        ao_crytek_constants *k = (ao_crytek_constants *)malloc(sizeof *k);
        ao_crytek_constants_from_params(&p, &in, k);
        obs_image_f32 o;
        CHECK_OK(obs_image_f32_alloc(ctx, in.w, in.h, &o), ctx);
        CHECK(ao_crytek_compute_constants_isa(ctx, NULL, &in, k, AO_CRYTEK_ISA_AVX2, &o, NULL, NULL) ==
              OBS_STATUS_UNSUPPORTED_ISA);
        obs_image_f32_free(&o);
        free(k);
    }
    obs_pool_destroy(pool2);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- parameters --------------------------------------------------------------------------------- */

TEST(crytek_bad_params_are_rejected_naming_the_field)
{
    obs_context *ctx = obs_context_create();
    static const struct {
        const char *field;
        int which;
        double value;
    } cases[] = {{"samples", 0, 12}, {"samples", 0, 0}, {"samples", 0, 264}, {"radius", 1, 0.0}, {"radius", 1, NAN},
                 {"radius", 1, INFINITY}, {"offset scale", 2, -0.01}, {"offset scale", 2, NAN}, {"space", 3, 7},
                 {"sky", 4, 2}, {"filter", 5, -1}, {"output", 6, 9}, {"blur", 7, 2}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        ao_crytek_params p = ao_crytek_params_default();
        switch (cases[i].which) {
        case 0: p.samples = (int)cases[i].value; break;
        case 1: p.radius = (float)cases[i].value; break;
        case 2: p.offset_scale = (float)cases[i].value; break;
        case 3: p.space = (ao_crytek_space)(int)cases[i].value; break;
        case 4: p.sky = (ao_crytek_sky)(int)cases[i].value; break;
        case 5: p.filter = (ao_crytek_filter)(int)cases[i].value; break;
        case 6: p.output = (ao_crytek_output)(int)cases[i].value; break;
        default: p.blur = (int)cases[i].value; break;
        }
        obs_context *c2 = obs_context_create();
        CHECK_EQ_INT(ao_crytek_params_validate(c2, &p), OBS_STATUS_INVALID_ARGUMENT);
        CHECK_MSG(strstr(obs_context_last_error(c2), cases[i].field), "case %zu: '%s' does not name %s", i,
                  obs_context_last_error(c2), cases[i].field);
        obs_context_destroy(c2);
    }
    CHECK(ao_crytek_params_validate(ctx, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    /* the study's sample counts are valid */
    for (int n = 4; n <= 32; n *= 2) {
        ao_crytek_params p = ao_crytek_params_default();
        p.samples = n;
        CHECK_OK(ao_crytek_params_validate(ctx, &p), ctx);
    }
    /* presets */
    ao_crytek_params p;
    CHECK(ao_crytek_params_preset("compute-port", &p));
    CHECK(p.offset_scale == 0.001f && p.sky == AO_CRYTEK_SKY_SKIP && p.filter == AO_CRYTEK_FILTER_NEAREST);
    CHECK(!ao_crytek_params_preset("nope", &p));
    char buf[256];
    CHECK(ao_crytek_params_to_string(&p, buf, sizeof buf) > 0 && strstr(buf, "space=screen") &&
          strstr(buf, "offset_scale=0.001"));
    obs_context_destroy(ctx);
}

/* ---- CLI ------------------------------------------------------------------------------------------ */

TEST(ao_cli_crytek_kajalin_preset_writes_its_constants)
{
    const char *dir = test_tmpdir();
    char scene[1024], prefix[1024], err[1024], path[1100];
    snprintf(scene, sizeof scene, "%s/sphere_on_plane.glb", test_data_dir());
    snprintf(prefix, sizeof prefix, "%s/kaj", dir);
    snprintf(err, sizeof err, "%s/kaj.err", dir);
    const char *a[] = {"ao", "--method", "crytek", "--preset", "kajalin", "--filter", "nearest", "--sky", "skip",
                       "--scene", scene, "--size", "40x30", "-o", prefix, NULL};
    int rc = test_spawn(OBS_CLI_PATH, a, NULL, err);
    char *e = test_slurp(err, NULL);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, e ? e : "");
    free(e);
    snprintf(path, sizeof path, "%s.json", prefix);
    char *j = test_slurp(path, NULL);
    CHECK(j != NULL);
    CHECK_MSG(strstr(j, "\"offsetScale\": 0.00999999978") && strstr(j, "\"space\": \"screen\"") &&
                  strstr(j, "\"filter\": \"nearest\"") && strstr(j, "\"sky\": \"skip\"") && strstr(j, "\"kz\": 2"),
              "sidecar: %s", j);
    free(j);
    /* --samples 12 is refused naming the field */
    const char *b[] = {"ao", "--method", "crytek", "--scene", scene, "--samples", "12", "-o", prefix, NULL};
    CHECK(test_spawn(OBS_CLI_PATH, b, NULL, err) != 0);
    e = test_slurp(err, NULL);
    CHECK_MSG(e && strstr(e, "samples"), "%s", e ? e : "");
    free(e);
}
