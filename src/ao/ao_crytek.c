/* ao_crytek.c: Crytek SSAO [Kajalin09] (Vladimir Kajalin, "Screen-Space Ambient Occlusion",
 * ShaderX7 §6.1, CryEngine 2), as the ShaderX7 listing computes it (read in its third-party copies:
 * the HLSL effect 18810930753 and the DirectCompute port 11093304203; ../shared/reference/ao.md
 * §1.1), with the seed thesis' 21-tap Gaussian as its blur.
 *
 * Per pixel, in GL pixel coordinates of the full buffer (x right, y up, y_gl = H - 1 - y; ao.h):
 *   uv = (p + 0.5) / size;  M = rotation matrix of vRotation = texel (p.x & 3, p.y & 3)
 *   for t < N:  o_t = normalize(corner_t) * (offsetScale *= offsetScaleStep)     (constants)
 *               R = o_t * M (row vector);  S = (uv + R.xy k_xy, dP + R.z k_z)
 *               dS = depth(S.xy);  acc += lerp(dS > S.z ? 1 : 0, 0.5, saturate((dP - dS) / dS))
 *   A = acc / N;  out = saturate(A * A + A)
 * Space "screen" is the listing (k_xy = 1, k_z = 2 dP); space "world" (default) scales the same
 * taps so that they fill a world ball of radius r metres (docs/ao/crytek.md, "Space").
 *
 * Float32 in the listing's operation order (the build uses -ffp-contract=off). Every difference
 * from the listing is marked "Deviation" here and listed in docs/ao/crytek.md.
 *
 * Two paths, the same bytes: the scalar reference (pixel_ao) and, where the CPU and build have it,
 * an AVX2 path of 8 pixels per vector (block_avx2; lanes described there). docs/ao/crytek.md, "Speed".
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ================================================================================================
 * The rotation texture
 * ============================================================================================== */

/* Our definition of the 4x4 rotation texture (the listing's g_RotSampler4x4 is an art asset whose
 * contents were never published; ao.h documents the generator, test_ao_crytek.c recomputes it in
 * double). Texel (i, j) at index 4 j + i, i = x_gl & 3, j = y_gl & 3. */
const float ao_crytek_rotation[AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE][3] = {
    {0.248039186f, 0.0f, 0.96875f},               /* texel (0, 0): k =  0 */
    {0.829731524f, 0.303016603f, 0.46875f},       /* texel (1, 0): k =  8 */
    {0.046924565f, -0.534681261f, 0.84375f},      /* texel (2, 0): k =  2 */
    {0.398017317f, -0.850539923f, 0.34375f},      /* texel (3, 0): k = 10 */
    {-0.84425658f, -0.489263952f, 0.21875f},      /* texel (0, 1): k = 12 */
    {-0.684640348f, -0.121103242f, 0.71875f},     /* texel (1, 1): k =  4 */
    {-0.572596431f, 0.814459503f, 0.09375f},      /* texel (2, 1): k = 14 */
    {-0.208890498f, 0.777062237f, 0.59375f},      /* texel (3, 1): k =  6 */
    {0.379798651f, 0.495380074f, 0.78125f},       /* texel (0, 2): k =  3 */
    {0.287203133f, 0.915648818f, 0.28125f},       /* texel (1, 2): k = 11 */
    {-0.311716914f, 0.285558224f, 0.90625f},      /* texel (2, 2): k =  1 */
    {-0.844631791f, 0.348651737f, 0.40625f},      /* texel (3, 2): k =  9 */
    {-0.12844792f, -0.991223752f, 0.03125f},      /* texel (0, 3): k = 15 */
    {-0.390487403f, -0.751859725f, 0.53125f},     /* texel (1, 3): k =  7 */
    {0.964679778f, -0.212082148f, 0.15625f},      /* texel (2, 3): k = 13 */
    {0.636650085f, -0.404984683f, 0.65625f},      /* texel (3, 3): k =  5 */
};

void ao_crytek_rotation_matrix(const float r[3], float m[9])
{
    /* [Kajalin09] ShaderX7 §6.1 listing (ao.md §1.1): "float h = 1 / (1 + vRotation.z)" and
     * rotMat._m00 .. _m22, in the listing's operation order (h * y * y is (h * y) * y). The HLSL
     * copy 18810930753 drops two minus signs (_m01 = +h y x, _m11 = -h x x + z), which makes the
     * matrix non-orthogonal; the compute port 11093304203, the ReShade copies and ao.md agree on
     * the signs used here. */
    const float x = r[0], y = r[1], z = r[2];
    const float h = 1.0f / (1.0f + z);
    m[0] = h * y * y + z;
    m[1] = -h * y * x;
    m[2] = -x;
    m[3] = -h * y * x;
    m[4] = h * x * x + z;
    m[5] = -y;
    m[6] = x;
    m[7] = y;
    m[8] = z;
}

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_crytek_params ao_crytek_params_default(void)
{
    ao_crytek_params p;
    memset(&p, 0, sizeof p);
    p.space = AO_CRYTEK_SPACE_WORLD;
    p.radius = AO_CRYTEK_DEFAULT_RADIUS;
    p.offset_scale = AO_CRYTEK_DEFAULT_OFFSET_SCALE;
    p.samples = AO_CRYTEK_DEFAULT_SAMPLES;
    p.sky = AO_CRYTEK_SKY_VISIBLE;
    p.filter = AO_CRYTEK_FILTER_LINEAR; /* the HLSL effect copy's sampler state */
    p.output = AO_CRYTEK_OUTPUT_REMAP;
    p.blur = 1; /* the seed thesis (ssao-thesis-2017 §4.2.3) blurs every technique's AO */
    return p;
}

static const char *const preset_names[] = {"default", "kajalin", "compute-port", NULL};

const char *const *ao_crytek_preset_names(void) { return preset_names; }

int ao_crytek_params_preset(const char *name, ao_crytek_params *out)
{
    if (!name || !out)
        return 0;
    ao_crytek_params p = ao_crytek_params_default();
    if (!strcmp(name, "default")) {
        /* the defaults */
    } else if (!strcmp(name, "kajalin") || !strcmp(name, "compute-port")) {
        /* ShaderX7 §6.1 listing: "nSamplesNum = 16; float offsetScale = 0.01;", offsets in UV units,
         * the AO pass alone (no blur in the listing) */
        p.space = AO_CRYTEK_SPACE_SCREEN;
        p.offset_scale = 0.01f;
        p.samples = 16;
        p.blur = 0;
        if (!strcmp(name, "compute-port")) {
            /* 11093304203: "float offsetScale = 0.001f;", and a tap on MINF (no depth) is skipped */
            p.offset_scale = 0.001f;
            p.sky = AO_CRYTEK_SKY_SKIP;
            p.filter = AO_CRYTEK_FILTER_NEAREST; /* input[(int2)(vSamplePos.xy * size)] */
        }
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

static int samples_ok(int n) { return n == 4 || (n >= 8 && n <= AO_CRYTEK_MAX_SAMPLES && n % 8 == 0); }

obs_status ao_crytek_params_validate(obs_context *ctx, const ao_crytek_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: NULL params");
    if ((unsigned)p->space >= AO_CRYTEK_SPACE_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: unknown space %d", (int)p->space);
    if (!(p->radius > 0.0f) || !(p->radius <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: radius %g must be in (0, 1e6] m",
                         (double)p->radius);
    if (!(p->offset_scale > 0.0f) || !(p->offset_scale <= 1e3f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: offset scale %g must be in (0, 1e3] (UV units)",
                         (double)p->offset_scale);
    if (!samples_ok(p->samples))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "crytek: samples %d must be 4 or a multiple of 8 in [8, %d] (rounds of the 8 cube corners)",
                         p->samples, AO_CRYTEK_MAX_SAMPLES);
    if ((unsigned)p->sky >= AO_CRYTEK_SKY_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: unknown sky mode %d", (int)p->sky);
    if ((unsigned)p->filter >= AO_CRYTEK_FILTER_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: unknown filter %d", (int)p->filter);
    if ((unsigned)p->output >= AO_CRYTEK_OUTPUT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: unknown output %d", (int)p->output);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: blur %d must be 0 or 1", p->blur);
    /* the largest tap radius offsetScale * step^N must stay finite (N = 256: 1.0094^256 = 11) */
    return OBS_STATUS_OK;
}

static const char *const space_names[] = {"world", "screen", NULL};
static const char *const sky_names[] = {"visible", "skip", NULL};
static const char *const filter_names[] = {"linear", "nearest", NULL};
static const char *const output_names[] = {"remap", "accessibility", NULL};

int ao_crytek_params_to_string(const ao_crytek_params *p, char *buf, size_t size)
{
    return snprintf(buf, size, "space=%s radius=%.9g offset_scale=%.9g samples=%d sky=%s filter=%s output=%s blur=%d",
                    space_names[(unsigned)p->space < AO_CRYTEK_SPACE_COUNT ? p->space : 0], (double)p->radius,
                    (double)p->offset_scale, p->samples, sky_names[(unsigned)p->sky < AO_CRYTEK_SKY_COUNT ? p->sky : 0],
                    filter_names[(unsigned)p->filter < AO_CRYTEK_FILTER_COUNT ? p->filter : 0],
                    output_names[(unsigned)p->output < AO_CRYTEK_OUTPUT_COUNT ? p->output : 0], p->blur);
}

void ao_crytek_constants_from_params(const ao_crytek_params *p, const ao_input *in, ao_crytek_constants *k)
{
    memset(k, 0, sizeof *k);
    k->full_width = in->width;
    k->full_height = in->height;
    k->orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k->space = (int)p->space;
    k->sky = (int)p->sky;
    k->filter = (int)p->filter;
    k->output = (int)p->output;
    k->blur = p->blur != 0;
    k->num_samples = p->samples;
    k->num_samples_f = (float)p->samples;
    k->inv_size[0] = 1.0f / (float)in->width;
    k->inv_size[1] = 1.0f / (float)in->height;
    k->size[0] = (float)in->width;
    k->size[1] = (float)in->height;
    k->offset_scale = p->offset_scale;
    /* [Kajalin09] "const float offsetScaleStep = 1 + 2.4 / nSamplesNum", in float */
    k->offset_scale_step = 1.0f + 2.4f / (float)p->samples;
    /* normalize(float3(+-1, +-1, +-1)) = +-1/sqrt(3): the compiler folds it (the loop is unrolled
     * over constants); we take the correctly rounded float. */
    k->inv_corner = (float)(1.0 / sqrt(3.0));

    /* ---- The taps, in the listing's loop order ----
     * for (i < N/8) for (x = -1; x <= 1; x += 2) for (y ...) for (z ...):
     *   vOffset = normalize(float3(x, y, z)) * (offsetScale *= offsetScaleStep)
     * Our N = 4 (the listing needs N >= 8): the corners with y == z, in loop order, i.e. the two
     * antipodal pairs (-1,-1,-1), (-1,1,1), (1,-1,-1), (1,1,1), so that a plane still splits the
     * taps in halves. */
    float s = p->offset_scale;
    int t = 0;
    const int rounds = p->samples >= 8 ? p->samples / 8 : 1;
    for (int i = 0; i < rounds; i++)
        for (int x = -1; x <= 1; x += 2)
            for (int y = -1; y <= 1; y += 2)
                for (int z = -1; z <= 1; z += 2) {
                    if (p->samples == 4 && y != z)
                        continue;
                    s *= k->offset_scale_step;
                    k->offsets[t][0] = (float)x * k->inv_corner * s;
                    k->offsets[t][1] = (float)y * k->inv_corner * s;
                    k->offsets[t][2] = (float)z * k->inv_corner * s;
                    t++;
                }
    const float s_last = s; /* s_N: the largest tap radius of the pattern (|o_N| = s_N) */

    /* ---- The mapping to the screen ----
     * screen (the listing): S = (uv, dP) + (R.xy, R.z * dP * 2): k_xy = 1, k_z = 2 (times dP).
     * world (ours): the tap offsets R r / s_N are view-space metres: depth shift R.z kz with
     * kz = r / s_N, screen shift kxy (R.xy - a R.z) / S.z with kxy = (r / s_N)(fx / W, fy / H) and
     * a the pixel's ray slopes (perspective, the exact projection of P + R r / s_N); orthographic
     * R.xy kxy. Computed in double, rounded once. */
    if (p->space == AO_CRYTEK_SPACE_SCREEN) {
        k->kxy[0] = 1.0f;
        k->kxy[1] = 1.0f;
        k->kz = AO_CRYTEK_DEFAULT_DEPTH_SCALE;
    } else {
        const double m = (double)p->radius / (double)s_last;
        k->kxy[0] = (float)(m * in->fx / (double)in->width);
        k->kxy[1] = (float)(m * in->fy / (double)in->height);
        k->kz = (float)m;
        /* the ray slopes of the pixel centres: a_x = (x + 0.5 - cx)/fx = ray[0] + x ray[2], a_y (GL
         * rows) = (y_gl + 0.5 - (H - cy))/fy = ray[1] + y_gl ray[3] */
        k->ray[0] = (float)((0.5 - in->cx) / in->fx);
        k->ray[1] = (float)((0.5 - ((double)in->height - in->cy)) / in->fy);
        k->ray[2] = (float)(1.0 / in->fx);
        k->ray[3] = (float)(1.0 / in->fy);
    }
    for (int e = 0; e < AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE; e++)
        ao_crytek_rotation_matrix(ao_crytek_rotation[e], k->rot_mat[e]);
}

/* ================================================================================================
 * The AO pass
 * ============================================================================================== */

typedef struct crytek_job {
    const ao_crytek_constants *k;
    const float *rtab;             /* [16][N][3]: the rotated taps R = o_t * M per texel */
    const float *rtab8;            /* NULL (scalar), or [4][N][3][8]: rtab lane-expanded for the
                                      AVX2 path, lane l of texel row j = texel 4 j + (l & 3) */
    const obs_image_f32 *dgl;      /* the depth in GL row order: a view of in->depth with rows
                                      reversed (data = row H - 1, stride negated), no copy */
    const ao_input *in;
    int rx0, ry0;                  /* region origin, our row order */
    obs_image_f32 *ao;             /* region-sized, our row order */
    int64_t *background;           /* per row */
} crytek_job;

static inline int is_surface(float d) { return d > 0.0f && d < INFINITY; } /* NaN -> 0 */

/* The tap texel along one axis: clamp(floor(v), 0, n - 1), NaN -> 0 (CLAMP_TO_EDGE, GL_NEAREST).
 * Deviation from the compute port, which truncates `(int2)(S.xy * size)` and does not clamp (an
 * out-of-range SRV load returns 0 in D3D): the brief's GL clamp-to-edge rule.
 * Deviation from the D3D9 listing (copy 18810930753): its g_SceneDepthSampler has
 * ADDRESSU = ADDRESSV = Border and no BorderColor, i.e. D3D9's default border colour 0, so an
 * off-screen tap reads depth 0 and counts 0.5 (fRangeIsInvalid = saturate((dP - 0) / 0) = 1, then
 * lerp(., 0.5, 1)); here it reads the edge texel. docs/ao/crytek.md, "Differences", "addressing". */
static inline int texel(float v, int n)
{
    if (!(v >= 0.0f))
        return 0;
    if (v >= (float)n)
        return n - 1;
    return (int)v; /* v >= 0: truncation is floor */
}

/* The depth at texture position (sx, sy) = S.xy * size (texels, GL rows up).
 * Nearest: texel (floor(sx), floor(sy)) clamped. Linear (GL_LINEAR, GL spec 8.14.2):
 * i0 = floor(sx - 0.5), a = frac(sx - 0.5), likewise j0, b; texels clamped to the edge; evaluated
 * as lerp(lerp(T00, T10, a), lerp(T01, T11, a), b) with lerp(x, y, s) = x + s (y - x), which is
 * exact on a constant footprint (the spec's (1-a)(1-b) T00 + ... form is not, by an ulp, and an
 * ulp below dP is a non-zero range check). Deviation: if any of the 4 texels is
 * background (+inf here, a finite far value on a GPU), the nearest texel is returned instead
 * (a port gets this with a second, point-sampled fetch). GPUs quantise a and b (8 fractional bits
 * on most hardware), so a port matches the linear filter to about 1/256 of a texel's depth step. */
static inline float fetch(const obs_image_f32 *G, int W, int H, float sx, float sy, int linear)
{
    const float Wm1 = (float)(W - 1), Hm1 = (float)(H - 1); /* exact: W, H < 2^24 */
    if (linear) {
        const float fx = sx - 0.5f, fy = sy - 0.5f;
        float t00, t10, t01, t11, a, b;
        if (fx >= 0.0f && fy >= 0.0f && fx < Wm1 && fy < Hm1) {
            /* interior footprint (the common case): no clamps, floor = truncation */
            const int i0 = (int)fx, j0 = (int)fy;
            a = fx - (float)i0;
            b = fy - (float)j0;
            const float *r0 = obs_image_f32_row(G, j0) + i0, *r1 = obs_image_f32_row(G, j0 + 1) + i0;
            t00 = r0[0];
            t10 = r0[1];
            t01 = r1[0];
            t11 = r1[1];
        } else if (fx == fx && fy == fy) {
            /* at the edges: limit to [-1, size] (keeps the int conversion defined; beyond it both
             * texels clamp to the edge texel anyway), floor, clamp each texel to the edge */
            const float cx = fx < -1.0f ? -1.0f : fx > (float)W ? (float)W : fx;
            const float cy = fy < -1.0f ? -1.0f : fy > (float)H ? (float)H : fy;
            int i0 = (int)cx, j0 = (int)cy;
            i0 -= (float)i0 > cx; /* floor without a libm call: exact */
            j0 -= (float)j0 > cy;
            a = cx - (float)i0;
            b = cy - (float)j0;
            int i1 = i0 + 1, j1 = j0 + 1;
            i0 = i0 < 0 ? 0 : i0 > W - 1 ? W - 1 : i0;
            j0 = j0 < 0 ? 0 : j0 > H - 1 ? H - 1 : j0;
            i1 = i1 < 0 ? 0 : i1 > W - 1 ? W - 1 : i1;
            j1 = j1 < 0 ? 0 : j1 > H - 1 ? H - 1 : j1;
            const float *r0 = obs_image_f32_row(G, j0), *r1 = obs_image_f32_row(G, j1);
            t00 = r0[i0];
            t10 = r0[i1];
            t01 = r1[i0];
            t11 = r1[i1];
        } else {
            return obs_image_f32_row(G, texel(sy, H))[texel(sx, W)]; /* NaN: the nearest path */
        }
        /* a branch-free test of the four for background (NaN, <= 0, +inf): is_surface of each */
        if ((t00 > 0.0f) & (t10 > 0.0f) & (t01 > 0.0f) & (t11 > 0.0f) & (t00 < INFINITY) & (t10 < INFINITY) &
            (t01 < INFINITY) & (t11 < INFINITY)) {
            const float r0v = t00 + a * (t10 - t00), r1v = t01 + a * (t11 - t01);
            return r0v + b * (r1v - r0v);
        }
        /* touching background: the nearest texel */
    }
    return obs_image_f32_row(G, texel(sy, H))[texel(sx, W)];
}

/* The scalar reference of the pass: the AO of one surface pixel. */
__attribute__((always_inline)) static inline float pixel_ao_body(const crytek_job *J, int x, int y_gl, float v, float dP,
                                                                 const int persp, const int linear);

/* One surface pixel (x, y_gl) of centre depth dP, v = uv.y: pixel_ao_body with its loop
 * specialised on the projection and the filter (compile-time constants there). */
static inline float pixel_ao(const crytek_job *J, int x, int y_gl, float v, float dP)
{
    const ao_crytek_constants *k = J->k;
    const int persp = k->space == AO_CRYTEK_SPACE_WORLD && !k->orthographic;
    if (k->filter == AO_CRYTEK_FILTER_LINEAR)
        return persp ? pixel_ao_body(J, x, y_gl, v, dP, 1, 1) : pixel_ao_body(J, x, y_gl, v, dP, 0, 1);
    return persp ? pixel_ao_body(J, x, y_gl, v, dP, 1, 0) : pixel_ao_body(J, x, y_gl, v, dP, 0, 0);
}

__attribute__((always_inline)) static inline float pixel_ao_body(const crytek_job *J, int x, int y_gl, float v, float dP,
                                                                 const int persp, const int linear)
{
    const ao_crytek_constants *k = J->k;
    const int W = k->full_width, H = k->full_height, N = k->num_samples;
    const int world = k->space == AO_CRYTEK_SPACE_WORLD;
    const float sky_value = k->sky == AO_CRYTEK_SKY_VISIBLE ? 1.0f : 0.0f;
    const float u = ((float)x + 0.5f) * k->inv_size[0];
    /* ---- Per-pixel rotation: rotationTC = screenTC * screenSize / 4 on a 4x4 texture = texel
     * (p & 3); the matrix depends on the texel only, so it is precomputed (same floats) ---- */
    const float *Rt = J->rtab + (size_t)(4 * (y_gl & 3) + (x & 3)) * 3 * (size_t)N;
    /* ---- Screen mapping of this pixel ---- */
    const float kx = k->kxy[0], ky = k->kxy[1];
    float kz = k->kz;
    if (!world)
        kz = kz * dP; /* listing: vRotatedOffset.z * fSceneDepthP * 2 == R.z * (2 dP) exactly */
    /* world, perspective: the pixel's ray slopes a = (x + 0.5 - cx)/fx, (y_gl + 0.5 - (H - cy))/fy */
    const float ax = k->ray[0] + (float)x * k->ray[2], ay = k->ray[1] + (float)y_gl * k->ray[3];
    const obs_image_f32 G = *J->dgl; /* a local copy: its fields stay in registers across the taps */
    const float size0 = k->size[0], size1 = k->size[1];
    /* ---- Taps ---- */
    float acc = 0.0f;
    for (int t = 0; t < N; t++) {
        /* vRotatedOffset = mul(vOffset, rotMat): R_j = o.x M0j + o.y M1j + o.z M2j */
        /* (precomputed per texel by rotate_taps, the same floats) */
        const float R0 = Rt[3 * t], R1 = Rt[3 * t + 1], R2 = Rt[3 * t + 2];
        /* vSamplePos = float3(screenTC, dP) + float3(R.xy, R.z * dP * 2) */
        const float Sz = dP + R2 * kz;
        float Sx, Sy;
        if (!persp) {
            Sx = u + R0 * kx;
            Sy = v + R1 * ky;
        } else {
            /* Deviation (space world, perspective): the tap is the view-space point
             * P + R r / s_N, projected exactly: uv' = uv + kxy (R.xy - a R.z) / (dP + R.z kz),
             * kxy = (r / s_N)(fx / W, fy / H). A tap behind the eye (S.z <= 0) is visible. */
            if (!(Sz > 0.0f)) {
                acc += 1.0f;
                continue;
            }
            Sx = u + kx * (R0 - ax * R2) / Sz;
            Sy = v + ky * (R1 - ay * R2) / Sz;
        }
        /* fSceneDepthS = tex2D(depth, S.xy), clamp to edge (GL rows up). Deviation: the D3D9
         * listing's sampler uses border addressing with border 0 (an off-screen tap counts 0.5,
         * and a linear footprint half off the edge blends toward depth 0); see texel() and
         * docs/ao/crytek.md, "Differences", "addressing". */
        const float dS = fetch(&G, W, H, Sx * size0, Sy * size1, linear);
        if (!is_surface(dS)) {
            /* Deviation from the listing (which has no sky test): sky taps are visible (1) or
             * skipped (0), ao.h ao_crytek_sky */
            acc += sky_value;
            continue;
        }
        /* fRangeIsInvalid = saturate((dP - dS) / dS);
         * Accessibility += lerp(dS > S.z ? 1 : 0, 0.5, fRangeIsInvalid), lerp(a, b, s) = a + s (b - a) */
        float r = (dP - dS) / dS;
        r = r > 0.0f ? (r < 1.0f ? r : 1.0f) : 0.0f;
        const float a = dS > Sz ? 1.0f : 0.0f;
        acc += a + r * (0.5f - a);
    }
    /* Accessibility = Accessibility / nSamplesNum; return saturate(A * A + A) */
    const float A = acc / k->num_samples_f;
    float res = k->output == AO_CRYTEK_OUTPUT_REMAP ? A * A + A : A;
    return res > 0.0f ? (res < 1.0f ? res : 1.0f) : 0.0f;
}

/* Pixels [i0, i1) of region row `task` (our row order), scalar. Returns the background count. */
static int64_t row_scalar(const crytek_job *J, int task, int i0, int i1)
{
    const ao_crytek_constants *k = J->k;
    const int H = k->full_height;
    const int y = J->ry0 + task, y_gl = H - 1 - y;
    const float *drow = obs_image_f32_row(J->in->depth, y);
    float *out = obs_image_f32_row(J->ao, task);
    /* uv.y = (y_gl + 0.5) / H, the fragment's interpolated texture coordinate */
    const float v = ((float)y_gl + 0.5f) * k->inv_size[1];
    int64_t n_bg = 0;
    for (int i = i0; i < i1; i++) {
        const int x = J->rx0 + i;
        /* ---- Centre depth; background -> 1 (the listing has no test: we keep NaN out) ---- */
        const float dP = drow[x];
        if (!is_surface(dP)) {
            out[i] = 1.0f;
            n_bg++;
            continue;
        }
        out[i] = pixel_ao(J, x, y_gl, v, dP);
    }
    return n_bg;
}

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#define CRYTEK_AVX2 1
#include <immintrin.h>

/* ---- The AVX2 path ----
 * Lanes: 8 horizontally adjacent pixels x0 .. x0 + 7 of one row, x0 a multiple of 4, so that lane
 * l uses rotation texel (l & 3) of the row's texel row (J->rtab8: [4][N][3][8], lane-expanded
 * copies of rtab, the same floats). Every lane evaluates pixel_ao's operations in its order, with
 * the same IEEE operations (-mavx2 without FMA, vdivps is the correctly rounded division, the
 * min/max pair is the scalar saturate including r = NaN -> 0); each lane's accumulator adds the
 * taps in tap order, so the sums are bit-identical. Fetches: a footprint inside the buffer away
 * from the edges and free of background is gathered (4 texels); every other tap (edges, NaN or
 * huge positions, background in the footprint, nearest fetches outside the buffer) is fetched by
 * the scalar fetch() lane by lane. test_ao_crytek.c checks scalar == AVX2 byte for byte. */
/* Per-pass vector constants of the AVX2 path, set once per block (kept out of the tap loop). */
typedef struct crytek_v8 {
    __m256 zero, one, half, inf, sky_value, kx, ky, size0, size1, wm1, hm1, w, h;
    __m256i stride, perm;
} crytek_v8;

#define CK_AVX2 __attribute__((target("avx2"), always_inline)) static inline

/* fetch() for 8 lanes; lanes outside `need` are don't-care. linear is a compile-time constant at
 * every call. */
CK_AVX2 __m256 fetch8(const crytek_job *J, const crytek_v8 *c, __m256 sx, __m256 sy, __m256 need, const int linear)
{
    const obs_image_f32 *G = J->dgl;
    __m256 dS, done;
    if (linear) {
        const __m256 fx = _mm256_sub_ps(sx, c->half), fy = _mm256_sub_ps(sy, c->half);
        __m256 inter = _mm256_and_ps(_mm256_cmp_ps(fx, c->zero, _CMP_GE_OQ), _mm256_cmp_ps(fy, c->zero, _CMP_GE_OQ));
        inter = _mm256_and_ps(inter, _mm256_cmp_ps(fx, c->wm1, _CMP_LT_OQ));
        inter = _mm256_and_ps(inter, _mm256_cmp_ps(fy, c->hm1, _CMP_LT_OQ));
        inter = _mm256_and_ps(inter, need);
        /* interior footprint: floor = truncation, a = frac */
        const __m256i i0 = _mm256_cvttps_epi32(fx), j0 = _mm256_cvttps_epi32(fy);
        const __m256 a = _mm256_sub_ps(fx, _mm256_cvtepi32_ps(i0)), b = _mm256_sub_ps(fy, _mm256_cvtepi32_ps(j0));
        __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(j0, c->stride), i0);
        idx = _mm256_and_si256(idx, _mm256_castps_si256(inter)); /* unused lanes read texel 0 */
        /* (T00, T10) and (T01, T11) are adjacent: gather them as 64-bit pairs, lanes
         * {0, 1, 4, 5} and {2, 3, 6, 7}, so that the even/odd split comes out in lane order */
        const __m256i ip = _mm256_permutevar8x32_epi32(idx, c->perm);
        const __m128i ilo = _mm256_castsi256_si128(ip), ihi = _mm256_extracti128_si256(ip, 1);
        const double *row0 = (const double *)(const void *)G->data;
        const double *row1 = (const double *)(const void *)(G->data + G->stride);
        const __m256 p0lo = _mm256_castpd_ps(_mm256_i32gather_pd(row0, ilo, 4));
        const __m256 p0hi = _mm256_castpd_ps(_mm256_i32gather_pd(row0, ihi, 4));
        const __m256 p1lo = _mm256_castpd_ps(_mm256_i32gather_pd(row1, ilo, 4));
        const __m256 p1hi = _mm256_castpd_ps(_mm256_i32gather_pd(row1, ihi, 4));
        const __m256 t00 = _mm256_shuffle_ps(p0lo, p0hi, _MM_SHUFFLE(2, 0, 2, 0));
        const __m256 t10 = _mm256_shuffle_ps(p0lo, p0hi, _MM_SHUFFLE(3, 1, 3, 1));
        const __m256 t01 = _mm256_shuffle_ps(p1lo, p1hi, _MM_SHUFFLE(2, 0, 2, 0));
        const __m256 t11 = _mm256_shuffle_ps(p1lo, p1hi, _MM_SHUFFLE(3, 1, 3, 1));
        /* is_surface of the four, as float compares (ordered: NaN fails; the same classification
         * as the scalar path under any MXCSR, DAZ included) */
        __m256 ok = _mm256_and_ps(_mm256_cmp_ps(t00, c->zero, _CMP_GT_OQ), _mm256_cmp_ps(t00, c->inf, _CMP_LT_OQ));
        ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(t10, c->zero, _CMP_GT_OQ), _mm256_cmp_ps(t10, c->inf, _CMP_LT_OQ)));
        ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(t01, c->zero, _CMP_GT_OQ), _mm256_cmp_ps(t01, c->inf, _CMP_LT_OQ)));
        ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(t11, c->zero, _CMP_GT_OQ), _mm256_cmp_ps(t11, c->inf, _CMP_LT_OQ)));
        done = _mm256_and_ps(inter, ok);
        /* lerp(lerp(T00, T10, a), lerp(T01, T11, a), b) */
        const __m256 r0v = _mm256_add_ps(t00, _mm256_mul_ps(a, _mm256_sub_ps(t10, t00)));
        const __m256 r1v = _mm256_add_ps(t01, _mm256_mul_ps(a, _mm256_sub_ps(t11, t01)));
        dS = _mm256_add_ps(r0v, _mm256_mul_ps(b, _mm256_sub_ps(r1v, r0v)));
        /* touching background: the nearest texel (trunc(sx), trunc(sy)), inside the buffer
         * here (fx in [0, W - 1) gives sx in [0.5, W - 0.5]) */
        const __m256 near = _mm256_andnot_ps(ok, inter);
        if (!_mm256_testz_ps(near, near)) {
            __m256i in_ = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(sy), c->stride), _mm256_cvttps_epi32(sx));
            in_ = _mm256_and_si256(in_, _mm256_castps_si256(near));
            dS = _mm256_mask_i32gather_ps(dS, G->data, in_, near, 4);
            done = inter;
        }
    } else {
        /* nearest inside the buffer: texel (trunc(sx), trunc(sy)) */
        __m256 inside = _mm256_and_ps(_mm256_cmp_ps(sx, c->zero, _CMP_GE_OQ), _mm256_cmp_ps(sy, c->zero, _CMP_GE_OQ));
        inside = _mm256_and_ps(inside, _mm256_cmp_ps(sx, c->w, _CMP_LT_OQ));
        inside = _mm256_and_ps(inside, _mm256_cmp_ps(sy, c->h, _CMP_LT_OQ));
        done = _mm256_and_ps(inside, need);
        __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(sy), c->stride), _mm256_cvttps_epi32(sx));
        idx = _mm256_and_si256(idx, _mm256_castps_si256(done));
        dS = _mm256_i32gather_ps(G->data, idx, 4);
    }
    /* ---- The rest (edges, NaN or huge positions), lane by lane, through the scalar fetch ---- */
    int rest = _mm256_movemask_ps(_mm256_andnot_ps(done, need));
    if (__builtin_expect(rest != 0, 0)) {
        float fsx[8], fsy[8], fd[8];
        _mm256_storeu_ps(fsx, sx);
        _mm256_storeu_ps(fsy, sy);
        _mm256_storeu_ps(fd, dS);
        const int W = J->k->full_width, H = J->k->full_height;
        while (rest) {
            const int l = __builtin_ctz((unsigned)rest);
            rest &= rest - 1;
            fd[l] = fetch(G, W, H, fsx[l], fsy[l], linear);
        }
        dS = _mm256_loadu_ps(fd);
    }
    return dS;
}

/* The taps of 8 pixels: pixel_ao's loop, lane-wise (persp and linear are compile-time constants). */
CK_AVX2 __m256 taps8(const crytek_job *J, const crytek_v8 *c, const float *Rt, int N, __m256 dP, __m256 surf,
                     __m256 u, __m256 v, __m256 kz, __m256 ax, __m256 ay, const int persp, const int linear)
{
    __m256 acc = c->zero;
    for (int t = 0; t < N; t++) {
        const __m256 R0 = _mm256_loadu_ps(Rt + 24 * t), R1 = _mm256_loadu_ps(Rt + 24 * t + 8),
                     R2 = _mm256_loadu_ps(Rt + 24 * t + 16);
        /* vSamplePos = float3(screenTC, dP) + float3(R.xy, R.z * kz) */
        const __m256 Sz = _mm256_add_ps(dP, _mm256_mul_ps(R2, kz));
        __m256 Sx, Sy, need = surf, behind = c->zero;
        if (!persp) {
            Sx = _mm256_add_ps(u, _mm256_mul_ps(R0, c->kx));
            Sy = _mm256_add_ps(v, _mm256_mul_ps(R1, c->ky));
        } else {
            /* the exact projection; a tap behind the eye (!(S.z > 0)) is visible */
            behind = _mm256_cmp_ps(Sz, c->zero, _CMP_NGT_UQ);
            need = _mm256_andnot_ps(behind, surf);
            Sx = _mm256_add_ps(u, _mm256_div_ps(_mm256_mul_ps(c->kx, _mm256_sub_ps(R0, _mm256_mul_ps(ax, R2))), Sz));
            Sy = _mm256_add_ps(v, _mm256_div_ps(_mm256_mul_ps(c->ky, _mm256_sub_ps(R1, _mm256_mul_ps(ay, R2))), Sz));
        }
        const __m256 dS = fetch8(J, c, _mm256_mul_ps(Sx, c->size0), _mm256_mul_ps(Sy, c->size1), need, linear);
        const __m256 sdS = _mm256_and_ps(_mm256_cmp_ps(dS, c->zero, _CMP_GT_OQ), _mm256_cmp_ps(dS, c->inf, _CMP_LT_OQ));
        /* r = saturate((dP - dS) / dS); acc += a + r (0.5 - a), a = dS > S.z ? 1 : 0 */
        __m256 r = _mm256_div_ps(_mm256_sub_ps(dP, dS), dS);
        r = _mm256_min_ps(_mm256_max_ps(r, c->zero), c->one);
        const __m256 a = _mm256_and_ps(_mm256_cmp_ps(dS, Sz, _CMP_GT_OQ), c->one);
        __m256 add = _mm256_add_ps(a, _mm256_mul_ps(r, _mm256_sub_ps(c->half, a)));
        add = _mm256_blendv_ps(c->sky_value, add, sdS); /* background tap: 1 (visible) or 0 (skip) */
        if (persp)
            add = _mm256_blendv_ps(add, c->one, behind);
        acc = _mm256_add_ps(acc, add);
    }
    return acc;
}

/* 8 pixels starting at region column i (x0 = rx0 + i, a multiple of 4). Returns the background count. */
__attribute__((target("avx2"))) static int block_avx2(const crytek_job *J, int task, int i)
{
    const ao_crytek_constants *k = J->k;
    const int W = k->full_width, H = k->full_height, N = k->num_samples;
    const int y = J->ry0 + task, y_gl = H - 1 - y, x0 = J->rx0 + i;
    const float *drow = obs_image_f32_row(J->in->depth, y);
    float *out = obs_image_f32_row(J->ao, task) + i;
    crytek_v8 c;
    c.zero = _mm256_setzero_ps();
    c.one = _mm256_set1_ps(1.0f);
    c.inf = _mm256_set1_ps(INFINITY);
    /* ---- Centre depth; background -> 1 ---- */
    const __m256 dP = _mm256_loadu_ps(drow + x0);
    const __m256 surf = _mm256_and_ps(_mm256_cmp_ps(dP, c.zero, _CMP_GT_OQ), _mm256_cmp_ps(dP, c.inf, _CMP_LT_OQ));
    const int smask = _mm256_movemask_ps(surf);
    if (!smask) {
        _mm256_storeu_ps(out, c.one);
        return 8;
    }
    c.half = _mm256_set1_ps(0.5f);
    c.sky_value = _mm256_set1_ps(k->sky == AO_CRYTEK_SKY_VISIBLE ? 1.0f : 0.0f);
    c.kx = _mm256_set1_ps(k->kxy[0]);
    c.ky = _mm256_set1_ps(k->kxy[1]);
    c.size0 = _mm256_set1_ps(k->size[0]);
    c.size1 = _mm256_set1_ps(k->size[1]);
    c.wm1 = _mm256_set1_ps((float)(W - 1));
    c.hm1 = _mm256_set1_ps((float)(H - 1));
    c.w = _mm256_set1_ps((float)W);
    c.h = _mm256_set1_ps((float)H);
    c.stride = _mm256_set1_epi32((int)J->dgl->stride);
    c.perm = _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7);
    const int world = k->space == AO_CRYTEK_SPACE_WORLD, persp = world && !k->orthographic;
    const int linear = k->filter == AO_CRYTEK_FILTER_LINEAR;
    /* u = (x + 0.5) / W, v = (y_gl + 0.5) / H; the pixel's ray slopes; kz (screen: kz dP) */
    const __m256 xf = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(x0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
    const __m256 u = _mm256_mul_ps(_mm256_add_ps(xf, c.half), _mm256_set1_ps(k->inv_size[0]));
    const __m256 v = _mm256_set1_ps(((float)y_gl + 0.5f) * k->inv_size[1]);
    const float *Rt = J->rtab8 + (size_t)(y_gl & 3) * 24 * (size_t)N;
    __m256 kz = _mm256_set1_ps(k->kz);
    if (!world)
        kz = _mm256_mul_ps(kz, dP);
    const __m256 ax = _mm256_add_ps(_mm256_set1_ps(k->ray[0]), _mm256_mul_ps(xf, _mm256_set1_ps(k->ray[2])));
    const __m256 ay = _mm256_set1_ps(k->ray[1] + (float)y_gl * k->ray[3]);
    /* ---- Taps ---- */
    __m256 acc;
    if (persp)
        acc = linear ? taps8(J, &c, Rt, N, dP, surf, u, v, kz, ax, ay, 1, 1)
                     : taps8(J, &c, Rt, N, dP, surf, u, v, kz, ax, ay, 1, 0);
    else
        acc = linear ? taps8(J, &c, Rt, N, dP, surf, u, v, kz, ax, ay, 0, 1)
                     : taps8(J, &c, Rt, N, dP, surf, u, v, kz, ax, ay, 0, 0);
    /* Accessibility / nSamplesNum; saturate(A * A + A) */
    const __m256 A = _mm256_div_ps(acc, _mm256_set1_ps(k->num_samples_f));
    __m256 res = k->output == AO_CRYTEK_OUTPUT_REMAP ? _mm256_add_ps(_mm256_mul_ps(A, A), A) : A;
    res = _mm256_min_ps(_mm256_max_ps(res, c.zero), c.one);
    _mm256_storeu_ps(out, _mm256_blendv_ps(c.one, res, surf));
    return 8 - __builtin_popcount((unsigned)smask);
}
#undef CK_AVX2

static int avx2_available(void) { return __builtin_cpu_supports("avx2") ? 1 : 0; }
#else
static int avx2_available(void) { return 0; }
#endif

static void crytek_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const crytek_job *J = (const crytek_job *)user;
    const int w = J->ao->width;
    int64_t n_bg = 0;
#if defined(CRYTEK_AVX2)
    if (J->rtab8) {
        /* scalar up to the first x that is a multiple of 4, then blocks of 8, then scalar */
        int i = (4 - (J->rx0 & 3)) & 3;
        if (i > w)
            i = w;
        n_bg += row_scalar(J, (int)task, 0, i);
        for (; i + 8 <= w; i += 8)
            n_bg += block_avx2(J, (int)task, i);
        n_bg += row_scalar(J, (int)task, i, w);
        J->background[task] = n_bg;
        return;
    }
#endif
    n_bg = row_scalar(J, (int)task, 0, w);
    J->background[task] = n_bg;
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

/* The rotated taps of every texel: R = mul(vOffset, rotMat), R_j = o.x M0j + o.y M1j + o.z M2j in
 * that order (the listing computes them per pixel; they depend on the texel only). */
static void rotate_taps(const ao_crytek_constants *k, float *rtab)
{
    const int N = k->num_samples;
    for (int e = 0; e < AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE; e++) {
        const float *M = k->rot_mat[e];
        for (int t = 0; t < N; t++) {
            const float *o = k->offsets[t];
            float *R = rtab + ((size_t)e * N + t) * 3;
            R[0] = o[0] * M[0] + o[1] * M[3] + o[2] * M[6];
            R[1] = o[0] * M[1] + o[1] * M[4] + o[2] * M[7];
            R[2] = o[0] * M[2] + o[1] * M[5] + o[2] * M[8];
        }
    }
}

/* rtab lane-expanded for the AVX2 path: rtab8[((j N + t) 3 + c) 8 + l] = R_c of tap t, texel
 * 4 j + (l & 3) (copies, the same floats). */
static void expand_taps(const ao_crytek_constants *k, const float *rtab, float *rtab8)
{
    const int N = k->num_samples;
    for (int j = 0; j < AO_CRYTEK_ROT_TILE; j++)
        for (int t = 0; t < N; t++)
            for (int c = 0; c < 3; c++)
                for (int l = 0; l < 8; l++)
                    rtab8[(((size_t)j * N + t) * 3 + c) * 8 + l] =
                        rtab[((size_t)(4 * j + (l & 3)) * N + t) * 3 + c];
}

static obs_status check_constants(obs_context *ctx, const ao_input *in, const ao_crytek_constants *k)
{
    if (!k)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: NULL constants");
    if (k->full_width != in->width || k->full_height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: constants for a %dx%d buffer, input is %dx%d",
                         k->full_width, k->full_height, in->width, in->height);
    if (!samples_ok(k->num_samples) || (unsigned)k->space >= AO_CRYTEK_SPACE_COUNT ||
        (unsigned)k->sky >= AO_CRYTEK_SKY_COUNT ||
        (unsigned)k->filter >= AO_CRYTEK_FILTER_COUNT || (unsigned)k->output >= AO_CRYTEK_OUTPUT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: constants out of range (samples %d, space %d, "
                         "sky %d, output %d)", k->num_samples, k->space, k->sky, k->output);
    if (!isfinite(k->kxy[0]) || !isfinite(k->kxy[1]) || !isfinite(k->kz) || !(k->num_samples_f > 0.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: kxy, kz must be finite");
    return OBS_STATUS_OK;
}

int ao_crytek_isa_available(ao_crytek_isa isa)
{
    switch (isa) {
    case AO_CRYTEK_ISA_AUTO:
    case AO_CRYTEK_ISA_SCALAR: return 1;
    case AO_CRYTEK_ISA_AVX2: return avx2_available();
    default: return 0;
    }
}

obs_status ao_crytek_compute_constants(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                       const ao_crytek_constants *k, obs_image_f32 *out, obs_image_f32 *out_raw,
                                       ao_stats *stats)
{
    return ao_crytek_compute_constants_isa(ctx, pool, in, k, AO_CRYTEK_ISA_AUTO, out, out_raw, stats);
}

obs_status ao_crytek_compute_constants_isa(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                           const ao_crytek_constants *k, ao_crytek_isa isa, obs_image_f32 *out,
                                           obs_image_f32 *out_raw, ao_stats *stats)
{
    if ((unsigned)isa >= AO_CRYTEK_ISA_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: unknown isa %d", (int)isa);
    if (!ao_crytek_isa_available(isa))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "crytek: AVX2 requested, not in this CPU or build");
    if (isa == AO_CRYTEK_ISA_AUTO) {
        /* AVX2 where the CPU and build have it, unless OBS_ISA=scalar (as the rasterizer) */
        const char *env = getenv("OBS_ISA");
        isa = (env && !strcmp(env, "scalar")) || !avx2_available() ? AO_CRYTEK_ISA_SCALAR : AO_CRYTEK_ISA_AVX2;
    }
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = check_constants(ctx, in, k);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "crytek: output planes must be %dx%d (the window)", in->w,
                         in->h);
    if (stats)
        memset(stats, 0, sizeof *stats);

    /* ---- 1. The region: the window, plus the blur's reach ---- */
    int rect[4];
    ao_blur_reach(in, k->blur ? AO_GAUSS21_RADIUS : 0, rect);
    const int rx0 = rect[0], ry0 = rect[1], rw = rect[2], rh = rect[3];
    obs_image_f32 raw = {0}, blurred = {0};
    /* Where the region is the window (no guard band, or no blur), the passes write the caller's
     * planes directly: the AO into out_raw (or into out without the blur), the blur into out; only
     * what is missing is allocated (saves zeroing and copying up to two planes per call) */
    const int direct = rx0 == in->x0 && ry0 == in->y0 && rw == in->w && rh == in->h;
    const int raw_is_out_raw = direct && out_raw && out_raw->data != out->data;
    const int raw_is_out = direct && !k->blur && !raw_is_out_raw;
    const int blur_into_out = direct && k->blur;
    if (raw_is_out_raw)
        raw = *out_raw;
    else if (raw_is_out)
        raw = *out;
    /* the depth texture as the shader sees it: GL row order (row j = our row H - 1 - j) */
    const obs_image_f32 dgl = {obs_image_f32_row(in->depth, in->height - 1), in->width, in->height, -in->depth->stride};
    int64_t *bg = NULL;
    double t0 = obs_time_now();
    float *rtab = (float *)malloc(sizeof(float) * 3 * AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE * (size_t)k->num_samples);
    float *rtab8 = NULL;
    st = !rtab ? obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory")
         : raw_is_out_raw || raw_is_out ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, rw, rh, &raw);
    /* the AVX2 path gathers with int32 texel indices j stride + i (+ stride + 1), stride < 0 */
    if (st == OBS_STATUS_OK && isa == AO_CRYTEK_ISA_AVX2 && (int64_t)(in->height + 1) * in->depth->stride < INT32_MAX) {
        rtab8 = (float *)malloc(sizeof(float) * 3 * 8 * AO_CRYTEK_ROT_TILE * (size_t)k->num_samples);
        if (!rtab8)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory");
    }
    if (st == OBS_STATUS_OK) {
        rotate_taps(k, rtab);
        if (rtab8)
            expand_taps(k, rtab, rtab8);
        bg = (int64_t *)calloc((size_t)rh, sizeof *bg);
        if (!bg)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory");
    }
    /* ---- 2. The AO pass over the region ---- */
    if (st == OBS_STATUS_OK) {
        crytek_job J = {k, rtab, rtab8, &dgl, in, rx0, ry0, &raw, bg};
        obs_pool_run(pool, rh, crytek_row, &J);
    }
    double t1 = obs_time_now();
    /* ---- 3. The seed's 21-tap Gaussian over the region (clamp to edge: at a side clipped by the
     * buffer, the region's edge is the buffer's) ---- */
    const obs_image_f32 *final = &raw;
    if (st == OBS_STATUS_OK && k->blur) {
        st = blur_into_out ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, rw, rh, &blurred);
        if (st == OBS_STATUS_OK)
            st = ao_blur_gaussian21(ctx, pool, &raw, blur_into_out ? out : &blurred);
        final = blur_into_out ? out : &blurred;
    }
    double t2 = obs_time_now();
    /* ---- 4. Crop the window; background stays 1 through the blur ---- */
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < in->h; y++) {
            const int ry = in->y0 + y - ry0;
            float *o = obs_image_f32_row(out, y);
            if (!blur_into_out && !raw_is_out)
                memcpy(o, obs_image_f32_row(final, ry) + (in->x0 - rx0), sizeof(float) * in->w);
            if (k->blur) /* Deviation from the seed (which blurs the whole AO texture): background
                          * pixels keep visibility 1 (ao.h input rule), as SAO's blur passes its sky */
                ao_i_background_to_one(in, y, o);
            if (out_raw && out_raw->data != raw.data)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(&raw, ry) + (in->x0 - rx0),
                       sizeof(float) * in->w);
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rw * rh;
            for (int r = 0; r < rh; r++)
                stats->pixels_background += bg[r];
            stats->seconds_kernel = t1 - t0;
            stats->seconds_blur = t2 - t1;
        }
    }
    free(bg);
    free(rtab8);
    free(rtab);
    obs_image_f32_free(&blurred);
    if (!raw_is_out_raw && !raw_is_out)
        obs_image_f32_free(&raw);
    return st;
}

obs_status ao_crytek_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_crytek_params *params,
                             obs_image_f32 *out, obs_image_f32 *out_raw, ao_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_crytek_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    double t0 = obs_time_now();
    ao_crytek_constants *k = (ao_crytek_constants *)malloc(sizeof *k);
    if (!k)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory");
    ao_crytek_constants_from_params(params, in, k);
    double t1 = obs_time_now();
    st = ao_crytek_compute_constants(ctx, pool, in, k, out, out_raw, stats);
    if (st == OBS_STATUS_OK && stats)
        stats->seconds_prepare = t1 - t0;
    free(k);
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_crytek_space) == sizeof(int) && sizeof(ao_crytek_sky) == sizeof(int) &&
                   sizeof(ao_crytek_filter) == sizeof(int) &&
                   sizeof(ao_crytek_output) == sizeof(int),
               "ENUM params are int-sized");
_Static_assert(sizeof(ao_crytek_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define CK_F(field) offsetof(ao_crytek_params, field)
static const ao_param_desc crytek_param_descs[] = {
    {"space", AO_PARAM_ENUM, CK_F(space), 0, 0, space_names,
     "world: taps fill a world ball of --radius m (ours); screen: the listing's UV offsets (--offset-scale)"},
    {"radius", AO_PARAM_FLOAT, CK_F(radius), 1e-6, 1e6, NULL, "world-space ball radius r (m), space world"},
    {"offset-scale", AO_PARAM_FLOAT, CK_F(offset_scale), 1e-9, 1e3, NULL,
     "initial offsetScale (UV units, space screen; ShaderX7 0.01)"},
    {"samples", AO_PARAM_INT, CK_F(samples), 4, AO_CRYTEK_MAX_SAMPLES, NULL,
     "taps N: 4 or a multiple of 8 (N/8 rounds of the cube corners)"},
    {"sky", AO_PARAM_ENUM, CK_F(sky), 0, 0, sky_names, "a tap on background: visible (adds 1) or skip (adds 0)"},
    {"filter", AO_PARAM_ENUM, CK_F(filter), 0, 0, filter_names,
     "depth fetch: linear (the HLSL effect's sampler) or nearest (the compute port)"},
    {"output", AO_PARAM_ENUM, CK_F(output), 0, 0, output_names,
     "remap: saturate(A^2 + A) (the listing); accessibility: A = acc / N"},
    {"blur", AO_PARAM_BOOL, CK_F(blur), 0, 1, NULL, "the seed thesis' 21-tap separable Gaussian"},
};
#undef CK_F

static void m_default(void *p) { *(ao_crytek_params *)p = ao_crytek_params_default(); }
static int m_preset(const char *name, void *p) { return ao_crytek_params_preset(name, (ao_crytek_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p)
{
    return ao_crytek_params_validate(ctx, (const ao_crytek_params *)p);
}
static int m_to_string(const void *p, char *buf, size_t size)
{
    return ao_crytek_params_to_string((const ao_crytek_params *)p, buf, size);
}
/* The study's sample axis: N is used as is (4, 8, 16, 32 are all valid; others are rejected by
 * validate). */
static void m_set_samples(void *p, int n) { ((ao_crytek_params *)p)->samples = n; }
static void m_set_radius(void *p, float r) { ((ao_crytek_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_crytek_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_crytek_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* ao.md §2: Crytek estimates the fraction of a ball around p that the camera sees (GT-vol, the
     * camera-visibility variant); a lone plane gives 1/2, which saturate(A^2 + A) maps to 0.75. */
    (void)p;
    return "vol";
}
/* snprintf at buf + *n (when it still fits), adding the length needed to *n */
static void appendf(char *buf, size_t size, size_t *n, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void appendf(char *buf, size_t size, size_t *n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int r = buf && *n < size ? vsnprintf(buf + *n, size - *n, fmt, ap) : vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    *n += r > 0 ? (size_t)r : 0;
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    ao_crytek_constants *K = (ao_crytek_constants *)malloc(sizeof *K);
    if (!K)
        return snprintf(buf, size, "{}");
    ao_crytek_constants_from_params((const ao_crytek_params *)p, in, K);
    size_t n = 0;
#define CK_PUT(...) appendf(buf, size, &n, __VA_ARGS__)
    CK_PUT("{\"size\": [%d, %d], \"orthographic\": %d, \"space\": \"%s\", \"sky\": \"%s\", \"filter\": \"%s\", \"output\": \"%s\", "
           "\"blur\": %d, \"nSamples\": %d, \"invSize\": [%.9g, %.9g], \"offsetScale\": %.9g, "
           "\"offsetScaleStep\": %.9g, \"invCorner\": %.9g, \"kxy\": [%.9g, %.9g], \"kz\": %.9g, \"kzTimesDepth\": %d, "
           "\"projected\": %d, \"ray\": [%.9g, %.9g, %.9g, %.9g], \"offsets\": [",
           K->full_width, K->full_height, K->orthographic, space_names[K->space], sky_names[K->sky], filter_names[K->filter],
           output_names[K->output], K->blur, K->num_samples, (double)K->inv_size[0], (double)K->inv_size[1],
           (double)K->offset_scale, (double)K->offset_scale_step, (double)K->inv_corner, (double)K->kxy[0],
           (double)K->kxy[1], (double)K->kz, K->space == AO_CRYTEK_SPACE_SCREEN,
           K->space == AO_CRYTEK_SPACE_WORLD && !K->orthographic, (double)K->ray[0], (double)K->ray[1],
           (double)K->ray[2], (double)K->ray[3]);
    for (int t = 0; t < K->num_samples; t++)
        CK_PUT("%s[%.9g, %.9g, %.9g]", t ? ", " : "", (double)K->offsets[t][0], (double)K->offsets[t][1],
               (double)K->offsets[t][2]);
    CK_PUT("], \"rotation\": [");
    for (int e = 0; e < AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE; e++)
        CK_PUT("%s[%.9g, %.9g, %.9g]", e ? ", " : "", (double)ao_crytek_rotation[e][0],
               (double)ao_crytek_rotation[e][1], (double)ao_crytek_rotation[e][2]);
    CK_PUT("], \"rotationIndex\": \"4 * (y_gl & 3) + (x & 3)\", \"blurKernel\": \"ao_gauss21_kernel\"}");
#undef CK_PUT
    free(K);
    return (int)n;
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    return ao_crytek_compute(ctx, pool, in, (const ao_crytek_params *)p, out, out_raw, stats);
}

const ao_method ao_i_method_crytek = {
    .name = "crytek",
    .title = "Crytek SSAO [Kajalin09]: the ShaderX7 listing, cube-corner taps, range check, saturate(A^2 + A)",
    .doc = "docs/ao/crytek.md",
    .params_size = sizeof(ao_crytek_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = crytek_param_descs,
    .param_count = (int)(sizeof crytek_param_descs / sizeof crytek_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    /* A = 1/2 exactly on a camera-facing plane (antipodal tap pairs: one in front, one behind), so
     * 0.75 exactly after the remap. On the registry's 50-degree plane single pixels move by whole
     * taps: where the texel's rotation puts corners in the plane (n.R ~ 0), the sub-texel error of
     * the depth fetch decides them; unblurred values span [0.5, 1] (max |dev| 0.25 measured, 330 of
     * 4928 px beyond 0.1), blurred max |dev| 0.063. docs/ao/crytek.md, "Flat plane". */
    .flat_value = 0.75f,
    .flat_tolerance = 0.26f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
