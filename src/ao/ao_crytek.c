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
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdarg.h>
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
    const obs_image_f32 *dgl;      /* the depth in GL row order, every non-surface value +inf */
    const ao_input *in;
    int rx0, ry0;                  /* region origin, our row order */
    obs_image_f32 *ao;             /* region-sized, our row order */
    int64_t *background;           /* per row */
} crytek_job;

static inline int is_surface(float d) { return d > 0.0f && d < INFINITY; } /* NaN -> 0 */

/* The tap texel along one axis: clamp(floor(v), 0, n - 1), NaN -> 0 (CLAMP_TO_EDGE, GL_NEAREST).
 * Deviation from the compute port, which truncates `(int2)(S.xy * size)` and does not clamp (an
 * out-of-range SRV load returns 0 in D3D): the brief's GL clamp-to-edge rule. */
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
    if (linear) {
        const float fx = sx - 0.5f, fy = sy - 0.5f;
        float t00, t10, t01, t11, a, b;
        if (fx >= 0.0f && fy >= 0.0f && fx < (float)(W - 1) && fy < (float)(H - 1)) {
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
        /* every non-surface depth is +inf in G (never NaN): a branch-free test of the four */
        if ((t00 < INFINITY) & (t10 < INFINITY) & (t01 < INFINITY) & (t11 < INFINITY)) {
            const float r0v = t00 + a * (t10 - t00), r1v = t01 + a * (t11 - t01);
            return r0v + b * (r1v - r0v);
        }
        /* touching background: the nearest texel */
    }
    return obs_image_f32_row(G, texel(sy, H))[texel(sx, W)];
}

static void crytek_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const crytek_job *J = (const crytek_job *)user;
    const ao_crytek_constants *k = J->k;
    const ao_input *in = J->in;
    const int W = k->full_width, H = k->full_height, N = k->num_samples;
    const int y = J->ry0 + (int)task, y_gl = H - 1 - y;
    const float *drow = obs_image_f32_row(in->depth, y);
    float *out = obs_image_f32_row(J->ao, (int)task);
    const int world = k->space == AO_CRYTEK_SPACE_WORLD, persp = world && !k->orthographic;
    const int linear = k->filter == AO_CRYTEK_FILTER_LINEAR;
    const float sky_value = k->sky == AO_CRYTEK_SKY_VISIBLE ? 1.0f : 0.0f;
    /* uv.y = (y_gl + 0.5) / H, the fragment's interpolated texture coordinate */
    const float v = ((float)y_gl + 0.5f) * k->inv_size[1];
    int64_t n_bg = 0;

    for (int i = 0; i < J->ao->width; i++) {
        const int x = J->rx0 + i;
        /* ---- Centre depth; background -> 1 (the listing has no test: we keep NaN out) ---- */
        const float dP = drow[x];
        if (!is_surface(dP)) {
            out[i] = 1.0f;
            n_bg++;
            continue;
        }
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
            /* fSceneDepthS = tex2D(depth, S.xy), clamp to edge (GL rows up) */
            const float dS = fetch(J->dgl, W, H, Sx * k->size[0], Sy * k->size[1], linear);
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
        res = res > 0.0f ? (res < 1.0f ? res : 1.0f) : 0.0f;
        out[i] = res;
    }
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

/* The depth texture as the shader sees it: GL row order, background (+inf, NaN, <= 0) as +inf. */
typedef struct dgl_job {
    const ao_input *in;
    obs_image_f32 *out;
} dgl_job;

static void dgl_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const dgl_job *J = (const dgl_job *)user;
    const int H = J->in->height, W = J->in->width, r = (int)task;
    const float *d = obs_image_f32_row(J->in->depth, H - 1 - r);
    float *o = obs_image_f32_row(J->out, r);
    for (int x = 0; x < W; x++)
        o[x] = is_surface(d[x]) ? d[x] : INFINITY;
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

obs_status ao_crytek_compute_constants(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                       const ao_crytek_constants *k, obs_image_f32 *out, obs_image_f32 *out_raw,
                                       ao_stats *stats)
{
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
    obs_image_f32 raw = {0}, blurred = {0}, dgl = {0};
    int64_t *bg = NULL;
    double t0 = obs_time_now();
    float *rtab = (float *)malloc(sizeof(float) * 3 * AO_CRYTEK_ROT_TILE * AO_CRYTEK_ROT_TILE * (size_t)k->num_samples);
    st = rtab ? obs_image_f32_alloc(ctx, rw, rh, &raw) : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory");
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in->width, in->height, &dgl);
    if (st == OBS_STATUS_OK) {
        dgl_job D = {in, &dgl};
        obs_pool_run(pool, in->height, dgl_row, &D);
        rotate_taps(k, rtab);
        bg = (int64_t *)calloc((size_t)rh, sizeof *bg);
        if (!bg)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "crytek: out of memory");
    }
    /* ---- 2. The AO pass over the region ---- */
    if (st == OBS_STATUS_OK) {
        crytek_job J = {k, rtab, &dgl, in, rx0, ry0, &raw, bg};
        obs_pool_run(pool, rh, crytek_row, &J);
    }
    double t1 = obs_time_now();
    /* ---- 3. The seed's 21-tap Gaussian over the region (clamp to edge: at a side clipped by the
     * buffer, the region's edge is the buffer's) ---- */
    const obs_image_f32 *final = &raw;
    if (st == OBS_STATUS_OK && k->blur) {
        st = obs_image_f32_alloc(ctx, rw, rh, &blurred);
        if (st == OBS_STATUS_OK)
            st = ao_blur_gaussian21(ctx, pool, &raw, &blurred);
        final = &blurred;
    }
    double t2 = obs_time_now();
    /* ---- 4. Crop the window; background stays 1 through the blur ---- */
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < in->h; y++) {
            const int ry = in->y0 + y - ry0;
            float *o = obs_image_f32_row(out, y);
            memcpy(o, obs_image_f32_row(final, ry) + (in->x0 - rx0), sizeof(float) * in->w);
            if (k->blur) {
                /* Deviation from the seed (which blurs the whole AO texture): background pixels
                 * keep visibility 1 (ao.h input rule), as SAO's blur passes its sky through */
                const float *d = obs_image_f32_row(in->depth, in->y0 + y) + in->x0;
                for (int x = 0; x < in->w; x++)
                    if (!is_surface(d[x]))
                        o[x] = 1.0f;
            }
            if (out_raw)
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
    free(rtab);
    obs_image_f32_free(&dgl);
    obs_image_f32_free(&blurred);
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
