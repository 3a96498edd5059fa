/* ao_alchemy.c: the Alchemy screen-space ambient obscurance algorithm [McGuire11] (McGuire, Osman,
 * Bukowski, Hennessy, "The Alchemy Screen-Space Ambient Obscurance Algorithm", HPG 2011).
 *
 * Per pixel C (camera space, z_C < 0) with unit normal n, s taps Q_i on a screen-space disk of the
 * projected world radius r, and
 *   A = max(0, 1 - (2 sigma / s) * sum_i max(0, v_i.n + z_C beta) / (v_i.v_i + epsilon))^k,
 * v_i = Q_i - C ([McGuire11] section 3, the estimator; the seed thesis prints it as its Figura 25;
 * a secondary design note numbers it eq. 10; docs/ao/alchemy.md says what was and was not verified).
 *
 * The tap pattern is SAO's (HPG12, [McGuire12]), in GL pixel coordinates (x_gl = x, y_gl = H-1-y of
 * the full buffer): the per-pixel rotation ao_sao_spin ("Hash function used in the HPG12 AlchemyAO
 * paper", SAO_AO.pix) and SAO's spiral tapLocation: alpha = (i + 0.5)/s, angle = alpha (tau 6.28) +
 * spin, ssR = alpha * ssDiskRadius, tap = ssC + ivec2(ssR (cos, sin)). Only this HPG12 pattern is
 * verified (SAO_AO.pix copies). The HPG11 paper's own sample construction is NOT verified (its
 * body could not be read): the hash is HPG11's only on SAO_AO.pix's word, and whether HPG11 used a
 * spiral at all is unknown. This is a deviation candidate, documented in docs/ao/alchemy.md
 * ("Differences from the paper", "Tap pattern"). Depth is read at level 0 (Alchemy
 * has no MIP pyramid), clamped to the buffer like a CLAMP_TO_EDGE texel fetch.
 *
 * Arithmetic is float32 in the estimator's order (the build uses -ffp-contract=off); cos/sin are
 * ao_i_cos_sin (correctly rounded), pow is (float)pow(double, double). docs/ao/alchemy.md lists every
 * difference from the paper and the ports.
 *
 * Two paths give the same bits (test alchemy_avx2_and_avx512_equal_scalar_bit_for_bit): the scalar one
 * (alchemy_span, the reference, always compiled) and, in OBS_HAVE_AVX2 builds on AVX2 CPUs, the
 * AVX2 one (alchemy_rect_avx2: lane j = the j-th surface pixel of a group of eight, in row-major
 * order within a 32x32 tile; docs/ao/alchemy.md "Speed"), whose taps' cos/sin run on two halves of
 * four doubles (AO_ALCHEMY_ISA_AVX2) or, on AVX-512F CPUs, on eight (AO_ALCHEMY_ISA_AVX512).
 */
#include "ao.h"
#include "ao_internal.h"
#include "ao_sao_internal.h" /* AO_I_SAO_HAVE_AVX512: where the build can compile AVX-512F code */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_alchemy_params ao_alchemy_params_default(void)
{
    ao_alchemy_params p;
    memset(&p, 0, sizeof p);
    p.radius = AO_ALCHEMY_DEFAULT_RADIUS;
    p.bias = AO_ALCHEMY_DEFAULT_BIAS;
    p.intensity = AO_ALCHEMY_DEFAULT_INTENSITY;
    p.contrast = AO_ALCHEMY_DEFAULT_CONTRAST;
    p.epsilon = AO_ALCHEMY_DEFAULT_EPSILON;
    p.samples = AO_ALCHEMY_DEFAULT_SAMPLES;
    p.spiral_turns = AO_ALCHEMY_DEFAULT_SPIRAL_TURNS;
    p.normals = AO_ALCHEMY_NORMALS_AUTO;
    p.range_check = 1;
    p.blur = 1;
    return p;
}

static const char *const preset_names[] = {"default", "hpg11", "thesis", "port", NULL};

const char *const *ao_alchemy_preset_names(void) { return preset_names; }

int ao_alchemy_params_preset(const char *name, ao_alchemy_params *out)
{
    if (!name || !out)
        return 0;
    ao_alchemy_params p = ao_alchemy_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "hpg11")) {
        /* [McGuire11] and its HPG11 talk ("Equation" slide): sigma 1, beta 1e-4, epsilon 1e-5, k 1 */
    } else if (!strcmp(name, "thesis")) {
        /* ssao-thesis-2017, Tabla 3: "Alchemy AO  Radio(m) 1  Muestras 16" */
        p.radius = 1.0f;
        p.samples = 16;
    } else if (!strcmp(name, "port")) {
        /* The AlchemyHPG11 GLSL ports ("From paper .../AlchemyHPG11/ and improvements here
         * .../SAOHPG12/"): radius 1, k 1.5, sigma 1, tau 7, beta 0.002, epsilon .00001, SAMPLES 16. */
        p.radius = 1.0f;
        p.contrast = 1.5f;
        p.intensity = 1.0f;
        p.spiral_turns = 7;
        p.bias = 0.002f;
        p.epsilon = 1e-5f;
        p.samples = 16;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

obs_status ao_alchemy_params_validate(obs_context *ctx, const ao_alchemy_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: NULL params");
    if (!(p->radius > 0.0f) || !isfinite(p->radius) || p->radius > 1e6f)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: radius %g must be in (0, 1e6] m",
                         (double)p->radius);
    /* beta >= 0: the bias only removes obscurance (z_C beta <= 0); a negative one would let every tap
     * add up to |z_C beta| / epsilon. */
    if (!(p->bias >= 0.0f) || !isfinite(p->bias))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: bias %g must be finite and >= 0",
                         (double)p->bias);
    if (!(p->intensity >= 0.0f) || !isfinite(p->intensity))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: intensity %g must be finite and >= 0",
                         (double)p->intensity);
    if (!(p->contrast > 0.0f) || !isfinite(p->contrast))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: contrast %g must be finite and > 0",
                         (double)p->contrast);
    if (!(p->epsilon > 0.0f) || !isfinite(p->epsilon))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: epsilon %g must be finite and > 0",
                         (double)p->epsilon);
    if (p->samples < 1 || p->samples > AO_ALCHEMY_MAX_SAMPLES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: samples %d must be in [1, %d]", p->samples,
                         AO_ALCHEMY_MAX_SAMPLES);
    if (p->spiral_turns < 1 || p->spiral_turns > 1000000)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: spiral turns %d must be in [1, 1000000]",
                         p->spiral_turns);
    if ((unsigned)p->normals >= AO_ALCHEMY_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: unknown normals mode %d", (int)p->normals);
    if (p->range_check != 0 && p->range_check != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: range check %d must be 0 or 1", p->range_check);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: blur %d must be 0 or 1", p->blur);
    return OBS_STATUS_OK;
}

static const char *const normals_names[] = {"auto", "gbuffer", "depth", NULL};

int ao_alchemy_params_to_string(const ao_alchemy_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "radius=%.9g bias=%.9g intensity=%.9g contrast=%.9g epsilon=%.9g samples=%d spiral_turns=%d "
                    "normals=%s range_check=%d blur=%d",
                    (double)p->radius, (double)p->bias, (double)p->intensity, (double)p->contrast,
                    (double)p->epsilon, p->samples, p->spiral_turns,
                    (unsigned)p->normals < AO_ALCHEMY_NORMALS_COUNT ? normals_names[p->normals] : "?", p->range_check, p->blur);
}

ao_alchemy_constants ao_alchemy_constants_from_params(const ao_alchemy_params *p, const ao_input *in)
{
    ao_alchemy_constants k;
    memset(&k, 0, sizeof k);
    k.full_width = in->width;
    k.full_height = in->height;
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.normals_from_gbuffer =
        p->normals == AO_ALCHEMY_NORMALS_GBUFFER || (p->normals == AO_ALCHEMY_NORMALS_AUTO && in->normal[0] != NULL);
    /* projInfo in GL pixel coordinates, exactly as SAO's (ao_sao_constants): (s + 0.5) with
     * s_y = H-1-y reproduces the rasterizer's pixel model -(y + 0.5 - cy)/fy. */
    const double H = in->height;
    if (!k.orthographic) {
        k.proj_info[0] = (float)(-1.0 / in->fx);
        k.proj_info[1] = (float)(-1.0 / in->fy);
        k.proj_info[2] = (float)(in->cx / in->fx);
        k.proj_info[3] = (float)((H - in->cy) / in->fy);
    } else {
        k.proj_info[0] = (float)(1.0 / in->fx);
        k.proj_info[1] = (float)(1.0 / in->fy);
        k.proj_info[2] = (float)(-in->cx / in->fx);
        k.proj_info[3] = (float)(-(H - in->cy) / in->fy);
    }
    /* "the height in pixels of a 1 m object viewed from 1 m": the disk radius is r fy / -z_C px */
    k.proj_scale = (float)in->fy;
    k.radius = p->radius;
    k.radius2 = p->radius * p->radius;
    k.range_check = p->range_check != 0;
    k.bias = p->bias;
    k.intensity = p->intensity;
    k.contrast = p->contrast;
    k.epsilon = p->epsilon;
    k.num_samples = p->samples;
    k.num_spiral_turns = p->spiral_turns;
    /* GLSL constant folding, in float: 1.0 / float(s); float(tau) * 6.28 (SAO_AO.pix tapLocation) */
    k.inv_num_samples = 1.0f / (float)p->samples;
    k.turns_angle = (float)p->spiral_turns * 6.28f;
    /* [McGuire11] estimator: the factor 2 sigma / s in front of the sum */
    k.intensity_scale = (2.0f * p->intensity) / (float)p->samples;
    k.blur = p->blur != 0;
    return k;
}

/* ================================================================================================
 * The AO pass
 * ============================================================================================== */

static inline float maxf(float a, float b) { return a > b ? a : b; } /* GLSL max; NaN a -> b */

/* GLSL int(f): truncation toward zero. Out-of-range values are clamped to +-2^30 (undefined in GLSL)
 * so that adding a pixel coordinate cannot overflow; NaN -> 0. */
static inline int trunc_to_int(float v)
{
    if (v != v)
        return 0;
    if (v >= 1073741824.0f)
        return 1073741824;
    if (v <= -1073741824.0f)
        return -1073741824;
    return (int)v;
}

static inline int is_surface(float d) { return d > 0.0f && d < INFINITY; }

/* csPos: camera-space position of GL pixel s at camera-space z (< 0), SAO's reconstructCSPosition. */
static inline void cs_pos(const ao_alchemy_constants *k, int sx, int sy, float z, float P[3])
{
    const float ax = ((float)sx + 0.5f) * k->proj_info[0] + k->proj_info[2];
    const float ay = ((float)sy + 0.5f) * k->proj_info[1] + k->proj_info[3];
    if (!k->orthographic) {
        P[0] = ax * z;
        P[1] = ay * z;
    } else {
        P[0] = ax;
        P[1] = ay;
    }
    P[2] = z;
}

/* The screen-space disk radius in pixels: ssDiskRadius = -projScale * r / z_C (orthographic:
 * projScale * r, the disk's size does not depend on depth). */
static inline float disk_radius(const ao_alchemy_constants *k, float z)
{
    return !k->orthographic ? (-k->proj_scale * k->radius) / z : k->proj_scale * k->radius;
}

/* One tap's offset: SAO_AO.pix tapLocation, ssP = ivec2(ssR * unitOffset) + ssC. */
static inline void tap(const ao_alchemy_constants *k, float spin, float disk, int i, int *ox, int *oy)
{
    const float alpha = ((float)i + 0.5f) * k->inv_num_samples;
    const float angle = alpha * k->turns_angle + spin;
    const float ssR = alpha * disk;
    float cs, sn;
    ao_i_cos_sin(angle, &cs, &sn);
    *ox = trunc_to_int(ssR * cs);
    *oy = trunc_to_int(ssR * sn);
}

void ao_alchemy_tap_offset(const ao_alchemy_constants *k, int x_gl, int y_gl, float disk_px, int i, int offset[2])
{
    tap(k, ao_sao_spin(x_gl, y_gl), disk_px, i, &offset[0], &offset[1]);
}

/* ---- A = max(0, 1 - (2 sigma / s) sum)^k (shared by every ISA) ---- */
static inline float alchemy_finish(const ao_alchemy_constants *k, float sum)
{
    const float base = maxf(0.0f, 1.0f - k->intensity_scale * sum);
    float A = k->contrast == 1.0f ? base : (float)pow((double)base, (double)k->contrast);
    return A >= 0.0f && A <= 1.0f ? A : (A > 1.0f ? 1.0f : 0.0f); /* NaN cannot occur; belt and braces */
}

typedef struct alchemy_job {
    const ao_alchemy_constants *k;
    const ao_input *in;
    const obs_image_f32 *const *n;  /* normal planes, full buffer, our row order */
    int rx0, ry0;                   /* rectangle origin, our row order */
    obs_image_f32 *out;
    int64_t (*counts)[2];           /* per task */
    int tiles_x;                    /* tiles per row of tiles */
} alchemy_job;

/* Tasks are AL_TILE x AL_TILE pixel tiles of the rectangle, in row-major order. Every pixel's value
 * depends only on the inputs, so the split changes no bit; square tiles keep the union of their
 * pixels' tap disks small ((32 + 2R)^2 depths instead of a whole row's (W + 2R) x 2R), which keeps
 * large disks (R of hundreds of pixels, a plane near the camera) in L2. */
#define AL_TILE 32

typedef void (*alchemy_rect_fn)(const alchemy_job *J, int r0, int r1, int i0, int i1, int64_t cnt[2]);

static void alchemy_tile(const alchemy_job *J, int64_t task, alchemy_rect_fn rect)
{
    const int tx = (int)(task % J->tiles_x), ty = (int)(task / J->tiles_x);
    const int i0 = tx * AL_TILE, i1 = i0 + AL_TILE < J->out->width ? i0 + AL_TILE : J->out->width;
    const int r0 = ty * AL_TILE, r1 = r0 + AL_TILE < J->out->height ? r0 + AL_TILE : J->out->height;
    int64_t cnt[2] = {0, 0};
    rect(J, r0, r1, i0, i1, cnt);
    J->counts[task][0] = cnt[0];
    J->counts[task][1] = cnt[1];
}

/* The scalar pass over output row `task`, columns [i_begin, i_end); adds to cnt {background,
 * degenerate normal}. */
static void alchemy_span(const alchemy_job *J, int64_t task, int i_begin, int i_end, int64_t cnt[2])
{
    const ao_alchemy_constants *k = J->k;
    const obs_image_f32 *D = J->in->depth;
    const int W = k->full_width, H = k->full_height;
    const int y = J->ry0 + (int)task, gy = H - 1 - y;
    const float *drow = obs_image_f32_row(D, y);
    const float *n0 = obs_image_f32_row(J->n[0], y), *n1 = obs_image_f32_row(J->n[1], y),
                *n2 = obs_image_f32_row(J->n[2], y);
    float *o = obs_image_f32_row(J->out, (int)task);
    int64_t n_bg = 0, n_degen = 0;
    for (int i = i_begin; i < i_end; i++) {
        const int x = J->rx0 + i, gx = x;
        /* ---- Centre: C = csPos(ssC, z_C), z_C = -depth; background gets visibility 1 ---- */
        const float d = drow[x];
        if (!is_surface(d)) {
            o[i] = 1.0f;
            n_bg++;
            continue;
        }
        const float zC = -d;
        float C[3];
        cs_pos(k, gx, gy, zC, C);
        /* ---- Normal: normalize(n) = n * inversesqrt(dot(n, n)); zero or non-finite -> 1 ---- */
        const float a = n0[x], b = n1[x], c = n2[x];
        const float l2 = a * a + b * b + c * c;
        if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
            o[i] = 1.0f;
            n_degen++;
            continue;
        }
        const float inv = 1.0f / sqrtf(l2);
        const float n[3] = {a * inv, b * inv, c * inv};
        /* ---- Per-pixel rotation and disk ---- */
        const float spin = ao_sao_spin(gx, gy);
        const float disk = disk_radius(k, zC);
        const float zb = zC * k->bias; /* [McGuire11]: the bias term z_C beta (<= 0) */
        /* ---- Taps: sum_i max(0, v.n + z_C beta) / (v.v + epsilon) ---- */
        float sum = 0.0f;
        for (int t = 0; t < k->num_samples; t++) {
            int ox, oy;
            tap(k, spin, disk, t, &ox, &oy);
            const int px = gx + ox, py = gy + oy;
            /* Q: the camera-space position buffer [McGuire11] (pipeline step 2) read at the tap
             * with CLAMP_TO_EDGE, i.e. the clamped texel's own point (not SAO's reconstruction at
             * the unclamped ssP, which puts edge depths at off-screen positions) */
            const int cx = px < 0 ? 0 : px > W - 1 ? W - 1 : px;
            const int cy = py < 0 ? 0 : py > H - 1 ? H - 1 : py;
            const float dq = obs_image_f32_row(D, H - 1 - cy)[cx];
            if (!is_surface(dq))
                continue; /* background: a point at infinity, whose term tends to 0 (documented) */
            float Q[3];
            cs_pos(k, cx, cy, -dq, Q);
            const float v0 = Q[0] - C[0], v1 = Q[1] - C[1], v2 = Q[2] - C[2];
            const float vv = v0 * v0 + v1 * v1 + v2 * v2;
            const float vn = v0 * n[0] + v1 * n[1] + v2 * n[2];
            /* range check [vv < r^2]: the Alchemy term with a step at r, as the authors' SAO_AO.pix
             * keeps it (falloff A, "From the HPG12 paper": float(vv < radius2) *
             * max((vn - bias) / (epsilon + vv), 0)); whether HPG11 itself has the step is [U] */
            if (k->range_check && !(vv < k->radius2))
                continue;
            sum += maxf(0.0f, vn + zb) / (vv + k->epsilon);
        }
        o[i] = alchemy_finish(k, sum);
    }
    cnt[0] += n_bg;
    cnt[1] += n_degen;
}

static void alchemy_rect_scalar(const alchemy_job *J, int r0, int r1, int i0, int i1, int64_t cnt[2])
{
    for (int r = r0; r < r1; r++)
        alchemy_span(J, r, i0, i1, cnt);
}

static void alchemy_tile_scalar(void *user, int64_t task, int thread)
{
    (void)thread;
    alchemy_tile((const alchemy_job *)user, task, alchemy_rect_scalar);
}

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define AL_AVX2 __attribute__((target("avx2")))

/* cos and sin on four doubles: ao_i_cos_sin's reduction, then the Taylor series of degree 19 / 20
 * (NOT ao_i_cos_sin's fdlibm kernels of degree 13 / 14: docs/ao/alchemy.md, "Note on the vector
 * cos/sin"); no FMA (-ffp-contract=off, separate mul/add intrinsics). Both are a few double ulps
 * from the exact value, so the float results agree with the scalar path's except within ~2^-50 of
 * a float midpoint (alchemy_avx2_and_avx512_equal_scalar_bit_for_bit has met no such angle).
 * Lanes with |x| >= 3e9 (or NaN) are flagged in *big for the caller to redo through ao_i_cos_sin
 * (its libm branch). AL_COS_SIN_SERIES is the reduction and the two series for a register of
 * doubles of either width (W: _mm256 or _mm512, T: its type), one source for the AVX2 and AVX-512
 * versions, so that each lane runs the same operations in the same order. */
#define AL_COS_SIN_SERIES(W, T, x, kd, csd, snd)                                                           \
    do {                                                                                                 \
        T r_;                                                                                            \
        AO_I_REDUCE_PIO2_PD(W, T, x, kd, r_);                                                            \
        const T z_ = W##_mul_pd(r_, r_);                                                                 \
        /* sn = r + r * z * (-1/6 + z * (1/120 + ... z * (-1/19!))), each cst + a * b two roundings */   \
        T ps_ = W##_set1_pd(-1.0 / 121645100408832000.0);                                                \
        ps_ = W##_add_pd(W##_set1_pd(1.0 / 355687428096000.0), W##_mul_pd(z_, ps_));                     \
        ps_ = W##_add_pd(W##_set1_pd(-1.0 / 1307674368000.0), W##_mul_pd(z_, ps_));                      \
        ps_ = W##_add_pd(W##_set1_pd(1.0 / 6227020800.0), W##_mul_pd(z_, ps_));                          \
        ps_ = W##_add_pd(W##_set1_pd(-1.0 / 39916800.0), W##_mul_pd(z_, ps_));                           \
        ps_ = W##_add_pd(W##_set1_pd(1.0 / 362880.0), W##_mul_pd(z_, ps_));                              \
        ps_ = W##_add_pd(W##_set1_pd(-1.0 / 5040.0), W##_mul_pd(z_, ps_));                               \
        ps_ = W##_add_pd(W##_set1_pd(1.0 / 120.0), W##_mul_pd(z_, ps_));                                 \
        ps_ = W##_add_pd(W##_set1_pd(-1.0 / 6.0), W##_mul_pd(z_, ps_));                                  \
        snd = W##_add_pd(r_, W##_mul_pd(W##_mul_pd(r_, z_), ps_));                                       \
        /* cs = 1 - 0.5 z + z z (1/24 + z * (-1/720 + ... z * (1/20!))) */                               \
        T pc_ = W##_set1_pd(1.0 / 2432902008176640000.0);                                                \
        pc_ = W##_add_pd(W##_set1_pd(-1.0 / 6402373705728000.0), W##_mul_pd(z_, pc_));                   \
        pc_ = W##_add_pd(W##_set1_pd(1.0 / 20922789888000.0), W##_mul_pd(z_, pc_));                      \
        pc_ = W##_add_pd(W##_set1_pd(-1.0 / 87178291200.0), W##_mul_pd(z_, pc_));                        \
        pc_ = W##_add_pd(W##_set1_pd(1.0 / 479001600.0), W##_mul_pd(z_, pc_));                           \
        pc_ = W##_add_pd(W##_set1_pd(-1.0 / 3628800.0), W##_mul_pd(z_, pc_));                            \
        pc_ = W##_add_pd(W##_set1_pd(1.0 / 40320.0), W##_mul_pd(z_, pc_));                               \
        pc_ = W##_add_pd(W##_set1_pd(-1.0 / 720.0), W##_mul_pd(z_, pc_));                                \
        pc_ = W##_add_pd(W##_set1_pd(1.0 / 24.0), W##_mul_pd(z_, pc_));                                  \
        csd = W##_add_pd(W##_sub_pd(W##_set1_pd(1.0), W##_mul_pd(W##_set1_pd(0.5), z_)),                 \
                         W##_mul_pd(W##_mul_pd(z_, z_), pc_));                                           \
    } while (0)

static inline AL_AVX2 void cos_sin_pd(__m256d x, __m256d *c, __m256d *s, int *big)
{
    const __m256d absmask = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7FFFFFFFFFFFFFFFll));
    *big = _mm256_movemask_pd(_mm256_cmp_pd(_mm256_and_pd(x, absmask), _mm256_set1_pd(3.0e9), _CMP_NLT_UQ));
    __m256d kd, sn, cs;
    AL_COS_SIN_SERIES(_mm256, __m256d, x, kd, cs, sn);
    /* quadrant k mod 4 (|k| < 2^31 here): 0 (cs, sn), 1 (-sn, cs), 2 (-cs, -sn), 3 (sn, -cs) */
    const __m256i q = _mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(kd));
    const __m256i one = _mm256_set1_epi64x(1), two = _mm256_set1_epi64x(2);
    const __m256d swap = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(q, one), one));
    const __m256d cneg = _mm256_castsi256_pd(
        _mm256_slli_epi64(_mm256_and_si256(_mm256_add_epi64(q, one), two), 62)); /* sign bit if q = 1, 2 */
    const __m256d sneg = _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_and_si256(q, two), 62)); /* q = 2, 3 */
    *c = _mm256_xor_pd(_mm256_blendv_pd(cs, sn, swap), cneg);
    *s = _mm256_xor_pd(_mm256_blendv_pd(sn, cs, swap), sneg);
}

/* trunc_to_int on eight floats: NaN -> 0, clamp to +-2^30, truncate */
static inline AL_AVX2 __m256i trunc_to_int8(__m256 v)
{
    const __m256 nan = _mm256_cmp_ps(v, v, _CMP_UNORD_Q);
    const __m256 cl = _mm256_min_ps(_mm256_max_ps(v, _mm256_set1_ps(-1073741824.0f)), _mm256_set1_ps(1073741824.0f));
    return _mm256_andnot_si256(_mm256_castps_si256(nan), _mm256_cvttps_epi32(cl));
}

/* Every tap's tapLocation angle, alpha_t turns_angle + spin (float, as tap()), and its cos and sin
 * for the eight lanes of spin: cs[8 t + j], sn[8 t + j]. The AVX2 and AVX-512 versions evaluate
 * cos_sin_pd's operations in the same order per lane, so they give the same bits. */
typedef void (*al_cos_sin_taps_fn)(const ao_alchemy_constants *k, const float *spin8, float *cs, float *sn);

/* the lanes of angle8 that cos_sin_pd flagged (|x| >= 3e9 or NaN) again through ao_i_cos_sin */
static void cos_sin_redo(const float *angle8, unsigned big, float *cs, float *sn)
{
    for (int j = 0; j < 8; j++)
        if ((big >> j) & 1)
            ao_i_cos_sin(angle8[j], &cs[j], &sn[j]);
}

static AL_AVX2 void cos_sin_taps_avx2(const ao_alchemy_constants *k, const float *spin8, float *cs, float *sn)
{
    const __m256 spin = _mm256_loadu_ps(spin8);
    for (int t = 0; t < k->num_samples; t++) {
        const float alpha = ((float)t + 0.5f) * k->inv_num_samples;
        const __m256 angle = _mm256_add_ps(_mm256_set1_ps(alpha * k->turns_angle), spin);
        __m256d clo, slo, chi, shi;
        int big_lo, big_hi;
        cos_sin_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(angle)), &clo, &slo, &big_lo);
        cos_sin_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(angle, 1)), &chi, &shi, &big_hi);
        _mm256_store_ps(cs + 8 * t, _mm256_set_m128(_mm256_cvtpd_ps(chi), _mm256_cvtpd_ps(clo)));
        _mm256_store_ps(sn + 8 * t, _mm256_set_m128(_mm256_cvtpd_ps(shi), _mm256_cvtpd_ps(slo)));
        if (big_lo | big_hi) { /* not reached by these angles (|spin| <= 2^31); kept exact */
            float la[8];
            _mm256_storeu_ps(la, angle);
            cos_sin_redo(la, (unsigned)(big_lo | big_hi << 4), cs + 8 * t, sn + 8 * t);
        }
    }
}

#if defined(AO_I_SAO_HAVE_AVX512)
#define AL_AVX512 __attribute__((target("avx2,avx512f")))
/* cos_sin_pd on 8 doubles in one AVX-512F register: the same operations in the same order per
 * lane. The quadrant's swap and signs are applied after the rounding to float, which gives the same
 * bits as before it (round to nearest is symmetric; a swap moves whole values). */
static AL_AVX512 void cos_sin_taps_avx512(const ao_alchemy_constants *k, const float *spin8, float *cs, float *sn)
{
    const __m256 spin = _mm256_loadu_ps(spin8);
    const __m512d absmask = _mm512_castsi512_pd(_mm512_set1_epi64(0x7FFFFFFFFFFFFFFFll));
    for (int t = 0; t < k->num_samples; t++) {
        const float alpha = ((float)t + 0.5f) * k->inv_num_samples;
        const __m256 angle = _mm256_add_ps(_mm256_set1_ps(alpha * k->turns_angle), spin);
        const __m512d x = _mm512_cvtps_pd(angle);
        const unsigned big = (unsigned)_mm512_cmp_pd_mask(
            _mm512_castsi512_pd(_mm512_and_si512(_mm512_castpd_si512(x), _mm512_castpd_si512(absmask))),
            _mm512_set1_pd(3.0e9), _CMP_NLT_UQ);
        __m512d kd, csd, snd;
        AL_COS_SIN_SERIES(_mm512, __m512d, x, kd, csd, snd);
        const __m256 csf = _mm512_cvtpd_ps(csd), snf = _mm512_cvtpd_ps(snd);
        /* quadrant q = kd mod 4 (kd an integer, |kd| < 2^31): 0 (cs, sn), 1 (-sn, cs), 2 (-cs, -sn),
         * 3 (sn, -cs); bit 0 of q to the sign bit for blendv, the signs from bit 1 of q + 1 and of q */
        const __m256i q = _mm512_cvtpd_epi32(kd);
        const __m256 swap = _mm256_castsi256_ps(_mm256_slli_epi32(q, 31));
        const __m256i sgn = _mm256_set1_epi32((int)0x80000000u);
        const __m256i cneg = _mm256_and_si256(_mm256_slli_epi32(_mm256_add_epi32(q, _mm256_set1_epi32(1)), 30), sgn);
        const __m256i sneg = _mm256_and_si256(_mm256_slli_epi32(q, 30), sgn);
        _mm256_store_ps(cs + 8 * t, _mm256_xor_ps(_mm256_blendv_ps(csf, snf, swap), _mm256_castsi256_ps(cneg)));
        _mm256_store_ps(sn + 8 * t, _mm256_xor_ps(_mm256_blendv_ps(snf, csf, swap), _mm256_castsi256_ps(sneg)));
        if (big) { /* not reached by these angles (|spin| <= 2^31); kept exact */
            float la[8];
            _mm256_storeu_ps(la, angle);
            cos_sin_redo(la, big, cs + 8 * t, sn + 8 * t);
        }
    }
}
#endif

#define AL_CHUNK 64 /* surface pixels compacted per chunk of a rectangle (a multiple of 8) */

/* The AVX2 pass over output rows [r0, r1), columns [i0, i1) (one tile): the scalar row's
 * per-pixel prologue (background, normal, spin, disk) compacts the rectangle's surface pixels into
 * lanes; the taps then run eight surface pixels per vector (lane j = the j-th surface pixel of the
 * group, in row-major order), tap t for all lanes at once, in the scalar order of operations. A skipped tap (background, range check) adds +0 to its lane, which leaves the
 * sum's bits unchanged (the sum starts at +0 and its terms are >= +0 or NaN, so it is never -0). */
static AL_AVX2 void alchemy_rect_avx2(const alchemy_job *J, int r0, int r1, int i0, int i1, int64_t cnt[2],
                                       al_cos_sin_taps_fn cos_sin_taps)
{
    const ao_alchemy_constants *k = J->k;
    const obs_image_f32 *D = J->in->depth;
    const int W = k->full_width, H = k->full_height;
    int64_t n_bg = 0, n_degen = 0;
    float aC0[AL_CHUNK], aC1[AL_CHUNK], aC2[AL_CHUNK], aN0[AL_CHUNK], aN1[AL_CHUNK], aN2[AL_CHUNK],
        aSpin[AL_CHUNK], aDisk[AL_CHUNK], aZb[AL_CHUNK], aSum[AL_CHUNK];
    int aGx[AL_CHUNK], aGy[AL_CHUNK];
    float *aOut[AL_CHUNK];
    _Alignas(32) float tcs[8 * AO_ALCHEMY_MAX_SAMPLES], tsn[8 * AO_ALCHEMY_MAX_SAMPLES];
    const __m256 pi0 = _mm256_set1_ps(k->proj_info[0]), pi1 = _mm256_set1_ps(k->proj_info[1]),
                 pi2 = _mm256_set1_ps(k->proj_info[2]), pi3 = _mm256_set1_ps(k->proj_info[3]);
    const __m256 half = _mm256_set1_ps(0.5f), zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    const __m256 r2 = _mm256_set1_ps(k->radius2), eps = _mm256_set1_ps(k->epsilon);
    const __m256 signbit = _mm256_set1_ps(-0.0f);
    const __m256i vWm1 = _mm256_set1_epi32(W - 1), vHm1 = _mm256_set1_epi32(H - 1),
                  izero = _mm256_setzero_si256(), vstride = _mm256_set1_epi32((int)D->stride);
    const int ortho = k->orthographic, range = k->range_check;
    int row = r0, i = i0; /* the next pixel of the rectangle, row-major */
    while (row < r1) {
        /* ---- Prologue: the scalar row's centre, normal, rotation and disk, compacted over the
         * rectangle's surface pixels in row-major order ---- */
        int m = 0;
        while (row < r1 && m < AL_CHUNK) {
            const int y = J->ry0 + row, gy = H - 1 - y;
            const float *drow = obs_image_f32_row(D, y);
            const float *n0 = obs_image_f32_row(J->n[0], y), *n1 = obs_image_f32_row(J->n[1], y),
                        *n2 = obs_image_f32_row(J->n[2], y);
            float *orow = obs_image_f32_row(J->out, row);
            for (; i < i1 && m < AL_CHUNK; i++) {
                /* eight background pixels at once (visibility 1, as below) */
                while (i + 8 <= i1) {
                    const __m256 d8 = _mm256_loadu_ps(drow + J->rx0 + i);
                    const __m256 s8 = _mm256_and_ps(_mm256_cmp_ps(d8, zero, _CMP_GT_OQ), _mm256_cmp_ps(d8, inf, _CMP_LT_OQ));
                    if (_mm256_movemask_ps(s8))
                        break;
                    _mm256_storeu_ps(orow + i, _mm256_set1_ps(1.0f));
                    n_bg += 8;
                    i += 8;
                }
                if (i == i1)
                    break;
                const int x = J->rx0 + i, gx = x;
                float *o = orow + i;
                const float d = drow[x];
                if (!is_surface(d)) {
                    *o = 1.0f;
                    n_bg++;
                    continue;
                }
                const float zC = -d;
                float C[3];
                cs_pos(k, gx, gy, zC, C);
                const float a = n0[x], b = n1[x], c = n2[x];
                const float l2 = a * a + b * b + c * c;
                if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
                    *o = 1.0f;
                    n_degen++;
                    continue;
                }
                const float inv = 1.0f / sqrtf(l2);
                aC0[m] = C[0], aC1[m] = C[1], aC2[m] = C[2];
                aN0[m] = a * inv, aN1[m] = b * inv, aN2[m] = c * inv;
                aSpin[m] = ao_sao_spin(gx, gy);
                aDisk[m] = disk_radius(k, zC);
                aZb[m] = zC * k->bias;
                aGx[m] = gx;
                aGy[m] = gy;
                aOut[m] = o;
                m++;
            }
            if (i == i1) {
                i = i0;
                row++;
            }
        }
        /* pad the last group with copies of its last pixel (results discarded) */
        const int mp = (m + 7) & ~7;
        for (int j = m; j < mp; j++) {
            aC0[j] = aC0[m - 1], aC1[j] = aC1[m - 1], aC2[j] = aC2[m - 1];
            aN0[j] = aN0[m - 1], aN1[j] = aN1[m - 1], aN2[j] = aN2[m - 1];
            aSpin[j] = aSpin[m - 1], aDisk[j] = aDisk[m - 1], aZb[j] = aZb[m - 1];
            aGx[j] = aGx[m - 1], aGy[j] = aGy[m - 1];
        }
        for (int g = 0; g < mp; g += 8) {
            const __m256 C0 = _mm256_loadu_ps(aC0 + g), C1 = _mm256_loadu_ps(aC1 + g), C2 = _mm256_loadu_ps(aC2 + g);
            const __m256 N0 = _mm256_loadu_ps(aN0 + g), N1 = _mm256_loadu_ps(aN1 + g), N2 = _mm256_loadu_ps(aN2 + g);
            const __m256 disk = _mm256_loadu_ps(aDisk + g);
            const __m256 zb = _mm256_loadu_ps(aZb + g);
            const __m256i gx = _mm256_loadu_si256((const __m256i *)(aGx + g));
            const __m256i vgy = _mm256_loadu_si256((const __m256i *)(aGy + g));
            __m256 sum = zero;
            cos_sin_taps(k, aSpin + g, tcs, tsn); /* every tap's angle, cos and sin for the 8 lanes */
            for (int t = 0; t < k->num_samples; t++) {
                /* ---- tapLocation (tap()): alpha, ssR; cos/sin of the angle from the group's table ---- */
                const float alpha = ((float)t + 0.5f) * k->inv_num_samples;
                const __m256 ssR = _mm256_mul_ps(_mm256_set1_ps(alpha), disk);
                const __m256 cs = _mm256_load_ps(tcs + 8 * t), sn = _mm256_load_ps(tsn + 8 * t);
                const __m256i ox = trunc_to_int8(_mm256_mul_ps(ssR, cs)), oy = trunc_to_int8(_mm256_mul_ps(ssR, sn));
                /* ---- CLAMP_TO_EDGE texel and its depth ---- */
                const __m256i cx = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(gx, ox), izero), vWm1);
                const __m256i cy = _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(vgy, oy), izero), vHm1);
                const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(vHm1, cy), vstride), cx);
                const __m256 dq = _mm256_i32gather_ps(D->data, idx, 4);
                __m256 ok = _mm256_and_ps(_mm256_cmp_ps(dq, zero, _CMP_GT_OQ), _mm256_cmp_ps(dq, inf, _CMP_LT_OQ));
                /* ---- Q = csPos(texel, -dq); v = Q - C ---- */
                const __m256 z = _mm256_xor_ps(dq, signbit);
                const __m256 ax = _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(cx), half), pi0), pi2);
                const __m256 ay = _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(cy), half), pi1), pi3);
                const __m256 Q0 = ortho ? ax : _mm256_mul_ps(ax, z), Q1 = ortho ? ay : _mm256_mul_ps(ay, z);
                const __m256 v0 = _mm256_sub_ps(Q0, C0), v1 = _mm256_sub_ps(Q1, C1), v2 = _mm256_sub_ps(z, C2);
                const __m256 vv = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, v0), _mm256_mul_ps(v1, v1)),
                                                _mm256_mul_ps(v2, v2));
                const __m256 vn = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, N0), _mm256_mul_ps(v1, N1)),
                                                _mm256_mul_ps(v2, N2));
                if (range)
                    ok = _mm256_and_ps(ok, _mm256_cmp_ps(vv, r2, _CMP_LT_OQ));
                /* maxf(0, x) = 0 > x ? 0 : x is MAXPS(0, x) (x NaN -> x) */
                const __m256 term = _mm256_div_ps(_mm256_max_ps(zero, _mm256_add_ps(vn, zb)), _mm256_add_ps(vv, eps));
                sum = _mm256_add_ps(sum, _mm256_and_ps(ok, term));
            }
            _mm256_storeu_ps(aSum + g, sum);
        }
        for (int j = 0; j < m; j++)
            *aOut[j] = alchemy_finish(k, aSum[j]);
    }
    cnt[0] += n_bg;
    cnt[1] += n_degen;
}
static void alchemy_rect_avx2_taps(const alchemy_job *J, int r0, int r1, int i0, int i1, int64_t cnt[2])
{
    alchemy_rect_avx2(J, r0, r1, i0, i1, cnt, cos_sin_taps_avx2);
}
static void alchemy_tile_avx2(void *user, int64_t task, int thread)
{
    (void)thread;
    alchemy_tile((const alchemy_job *)user, task, alchemy_rect_avx2_taps);
}
#if defined(AO_I_SAO_HAVE_AVX512)
static void alchemy_rect_avx512_taps(const alchemy_job *J, int r0, int r1, int i0, int i1, int64_t cnt[2])
{
    alchemy_rect_avx2(J, r0, r1, i0, i1, cnt, cos_sin_taps_avx512);
}
static void alchemy_tile_avx512(void *user, int64_t task, int thread)
{
    (void)thread;
    alchemy_tile((const alchemy_job *)user, task, alchemy_rect_avx512_taps);
}
#undef AL_AVX512
#endif
#undef AL_AVX2
#endif

int ao_alchemy_isa_available(ao_alchemy_isa isa)
{
    switch (isa) {
    case AO_ALCHEMY_ISA_AUTO:
    case AO_ALCHEMY_ISA_SCALAR: return 1;
    case AO_ALCHEMY_ISA_AVX2:
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
        return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
        return 0;
#endif
    case AO_ALCHEMY_ISA_AVX512:
#if defined(OBS_HAVE_AVX2) && defined(AO_I_SAO_HAVE_AVX512)
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") ? 1 : 0;
#else
        return 0;
#endif
    default: return 0;
    }
}

obs_status ao_alchemy_raw_isa(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_constants *k,
                              const obs_image_f32 *const normals[3], const int rect[4], obs_image_f32 *out,
                              int64_t counts[2], ao_alchemy_isa isa)
{
    if (!in || !k || !normals || !normals[0] || !normals[1] || !normals[2] || !rect || !out || !out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: NULL argument");
    if (k->full_width != in->width || k->full_height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: constants for %dx%d, input is %dx%d",
                         k->full_width, k->full_height, in->width, in->height);
    if (rect[2] < 1 || rect[3] < 1 || rect[0] < 0 || rect[1] < 0 || rect[0] + rect[2] > in->width ||
        rect[1] + rect[3] > in->height || out->width != rect[2] || out->height != rect[3])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao_alchemy_raw: rectangle (%d, %d, %d, %d) outside the %dx%d buffer or output not %dx%d",
                         rect[0], rect[1], rect[2], rect[3], in->width, in->height, rect[2], rect[3]);
    for (int a = 0; a < 3; a++)
        if (normals[a]->width != in->width || normals[a]->height != in->height)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: normal planes must be %dx%d",
                             in->width, in->height);
    if (k->num_samples < 1 || k->num_samples > AO_ALCHEMY_MAX_SAMPLES || !isfinite(k->intensity_scale) ||
        !(k->proj_scale > 0.0f) || !isfinite(k->proj_scale) || !(k->epsilon > 0.0f) || !(k->contrast > 0.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: constants out of range");
    if ((unsigned)isa >= AO_ALCHEMY_ISA_COUNT || !ao_alchemy_isa_available(isa))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "ao_alchemy_raw: ISA %d not available here", (int)isa);
    void (*tile_fn)(void *, int64_t, int) = alchemy_tile_scalar;
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
    if (isa == AO_ALCHEMY_ISA_AUTO) {
        const char *env = getenv("OBS_ISA");
        isa = (env && !strcmp(env, "scalar")) || !ao_alchemy_isa_available(AO_ALCHEMY_ISA_AVX2) ? AO_ALCHEMY_ISA_SCALAR
              : !(env && !strcmp(env, "avx2")) && ao_alchemy_isa_available(AO_ALCHEMY_ISA_AVX512)
                  ? AO_ALCHEMY_ISA_AVX512
                  : AO_ALCHEMY_ISA_AVX2;
    }
    /* the gather's 32-bit element index (H - 1 - cy) * stride + cx must fit: else the scalar row */
    if ((isa == AO_ALCHEMY_ISA_AVX2 || isa == AO_ALCHEMY_ISA_AVX512) &&
        (int64_t)in->depth->stride * in->height <= INT32_MAX)
        tile_fn = alchemy_tile_avx2;
#if defined(AO_I_SAO_HAVE_AVX512)
    if (isa == AO_ALCHEMY_ISA_AVX512 && tile_fn == alchemy_tile_avx2)
        tile_fn = alchemy_tile_avx512;
#endif
#endif
    const int tiles_x = (rect[2] + AL_TILE - 1) / AL_TILE, tiles_y = (rect[3] + AL_TILE - 1) / AL_TILE;
    const int64_t ntask = (int64_t)tiles_x * tiles_y;
    int64_t(*rc)[2] = (int64_t(*)[2])calloc((size_t)ntask, sizeof *rc);
    if (!rc)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "alchemy: out of memory");
    alchemy_job J = {k, in, normals, rect[0], rect[1], out, rc, tiles_x};
    obs_pool_run(pool, ntask, tile_fn, &J);
    if (counts) {
        counts[0] = counts[1] = 0;
        for (int64_t r = 0; r < ntask; r++) { /* fixed order: deterministic */
            counts[0] += rc[r][0];
            counts[1] += rc[r][1];
        }
    }
    free(rc);
    return OBS_STATUS_OK;
}

obs_status ao_alchemy_raw(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_constants *k,
                          const obs_image_f32 *const normals[3], const int rect[4], obs_image_f32 *out,
                          int64_t counts[2])
{
    return ao_alchemy_raw_isa(ctx, pool, in, k, normals, rect, out, counts, AO_ALCHEMY_ISA_AUTO);
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

obs_status ao_alchemy_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_params *params,
                              obs_image_f32 *out, obs_image_f32 *out_raw, ao_alchemy_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_alchemy_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: output planes must be %dx%d (the window)",
                         in->w, in->h);
    if (params->normals == AO_ALCHEMY_NORMALS_GBUFFER && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "alchemy: normals from the G-buffer were asked for, but the input has none");
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(params, in);

    /* ---- 1. Normals: the G-buffer's, or reconstructed from depth ---- */
    double t0 = obs_time_now();
    obs_image_f32 rec[3];
    memset(rec, 0, sizeof rec);
    const obs_image_f32 *nrm[3] = {in->normal[0], in->normal[1], in->normal[2]};
    if (!k.normals_from_gbuffer) {
        for (int a = 0; a < 3 && st == OBS_STATUS_OK; a++)
            st = obs_image_f32_alloc(ctx, in->width, in->height, &rec[a]);
        if (st == OBS_STATUS_OK)
            st = ao_normals_from_depth(ctx, pool, in, rec);
        nrm[0] = &rec[0];
        nrm[1] = &rec[1];
        nrm[2] = &rec[2];
    }
    double t1 = obs_time_now();

    /* ---- 2. AO over the window plus the blur's reach ---- */
    int rect[4];
    ao_blur_reach(in, k.blur ? AO_GAUSS21_RADIUS : 0, rect);
    obs_image_f32 raw = {0}, blurred = {0};
    int64_t counts[2] = {0, 0};
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, rect[2], rect[3], &raw);
    if (st == OBS_STATUS_OK)
        st = ao_alchemy_raw(ctx, pool, in, &k, nrm, rect, &raw, counts);
    double t2 = obs_time_now();

    /* ---- 3. The seed's 21-tap Gaussian over the computed rectangle (its clamp at a side that the
     * buffer clipped is the buffer's own edge; elsewhere the window's taps stay inside) ---- */
    const obs_image_f32 *final = &raw;
    if (st == OBS_STATUS_OK && k.blur) {
        st = obs_image_f32_alloc(ctx, rect[2], rect[3], &blurred);
        if (st == OBS_STATUS_OK)
            st = ao_blur_gaussian21(ctx, pool, &raw, &blurred);
        final = &blurred;
    }
    double t3 = obs_time_now();

    /* ---- 4. Crop the window ---- */
    if (st == OBS_STATUS_OK) {
        const int ox = in->x0 - rect[0], oy = in->y0 - rect[1];
        for (int y = 0; y < in->h; y++) {
            memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, y + oy) + ox, sizeof(float) * (size_t)in->w);
            /* background keeps visibility 1 exactly: the Gaussian (not depth-aware) would leave
             * 1 - 2.4e-7 or blurred-in AO there; no shading uses it (documented deviation) */
            ao_i_background_to_one(in, y, obs_image_f32_row(out, y));
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(&raw, y + oy) + ox,
                       sizeof(float) * (size_t)in->w);
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rect[2] * rect[3];
            stats->pixels_background = counts[0];
            stats->pixels_degenerate_normal = counts[1];
            stats->seconds_normals = t1 - t0;
            stats->seconds_ao = t2 - t1;
            stats->seconds_blur = t3 - t2;
        }
    }
    obs_image_f32_free(&blurred);
    obs_image_f32_free(&raw);
    for (int a = 0; a < 3; a++)
        obs_image_f32_free(&rec[a]);
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_alchemy_normals) == sizeof(int), "ENUM params are int-sized");
_Static_assert(sizeof(ao_alchemy_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define AL_F(field) offsetof(ao_alchemy_params, field)
static const ao_param_desc alchemy_param_descs[] = {
    {"radius", AO_PARAM_FLOAT, AL_F(radius), 1e-6, 1e6, NULL, "world-space radius r of the sample disk (m)"},
    {"bias", AO_PARAM_FLOAT, AL_F(bias), 0, 1e30, NULL, "shadow bias beta (the term is z_C beta, z_C < 0)"},
    {"intensity", AO_PARAM_FLOAT, AL_F(intensity), 0, 1e30, NULL, "intensity sigma (2 sigma / s scales the sum)"},
    {"contrast", AO_PARAM_FLOAT, AL_F(contrast), 1e-30, 1e30, NULL, "contrast k (the exponent)"},
    {"epsilon", AO_PARAM_FLOAT, AL_F(epsilon), 1e-30, 1e30, NULL, "epsilon in (v.n + z_C beta)/(v.v + epsilon) (m^2)"},
    {"samples", AO_PARAM_INT, AL_F(samples), 1, AO_ALCHEMY_MAX_SAMPLES, NULL, "taps s per pixel"},
    {"turns", AO_PARAM_INT, AL_F(spiral_turns), 1, 1000000, NULL, "spiral turns tau"},
    {"normals", AO_PARAM_ENUM, AL_F(normals), 0, 0, normals_names,
     "auto: the G-buffer's if present, else from depth; gbuffer; depth (ao_normals_from_depth)"},
    {"range-check", AO_PARAM_BOOL, AL_F(range_check), 0, 1, NULL,
     "count only taps with |v| < r (as SAO_AO.pix falloff A); off: every tap in the disk"},
    {"blur", AO_PARAM_BOOL, AL_F(blur), 0, 1, NULL, "the seed's 21-tap separable Gaussian after the AO pass"},
};
#undef AL_F

static void m_default(void *p) { *(ao_alchemy_params *)p = ao_alchemy_params_default(); }
static int m_preset(const char *name, void *p) { return ao_alchemy_params_preset(name, (ao_alchemy_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p)
{
    return ao_alchemy_params_validate(ctx, (const ao_alchemy_params *)p);
}
static int m_to_string(const void *p, char *buf, size_t size)
{
    return ao_alchemy_params_to_string((const ao_alchemy_params *)p, buf, size);
}
static void m_set_samples(void *p, int n) { ((ao_alchemy_params *)p)->samples = n; }
static void m_set_radius(void *p, float r) { ((ao_alchemy_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_alchemy_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_alchemy_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* No truth estimator has Alchemy's cancelling falloff; GT-cos(r) (every occluder within r counts,
     * cosine-weighted, no distance falloff) is the nearest (docs/ao/alchemy.md, "Ground truth"). */
    (void)p;
    return "cos";
}

int ao_alchemy_constants_to_json(const ao_alchemy_constants *K, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "{\"full_size\": [%d, %d], \"orthographic\": %d, \"normals_from_gbuffer\": %d, "
                    "\"projInfo\": [%.9g, %.9g, %.9g, %.9g], \"projScale\": %.9g, \"radius\": %.9g, \"radius2\": %.9g, \"range_check\": %d, "
                    "\"bias\": %.9g, \"intensity\": %.9g, \"contrast\": %.9g, \"epsilon\": %.9g, "
                    "\"NUM_SAMPLES\": %d, \"NUM_SPIRAL_TURNS\": %d, \"inv_num_samples\": %.9g, "
                    "\"turns_angle\": %.9g, \"intensity_scale\": %.9g, \"blur\": %d, \"blur_taps\": %d}",
                    K->full_width, K->full_height, K->orthographic, K->normals_from_gbuffer, (double)K->proj_info[0],
                    (double)K->proj_info[1], (double)K->proj_info[2], (double)K->proj_info[3], (double)K->proj_scale,
                    (double)K->radius, (double)K->radius2, K->range_check, (double)K->bias, (double)K->intensity, (double)K->contrast,
                    (double)K->epsilon, K->num_samples, K->num_spiral_turns, (double)K->inv_num_samples,
                    (double)K->turns_angle, (double)K->intensity_scale, K->blur, 2 * AO_GAUSS21_RADIUS + 1);
}

static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_alchemy_constants K = ao_alchemy_constants_from_params((const ao_alchemy_params *)p, in);
    return ao_alchemy_constants_to_json(&K, buf, size);
}

static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_alchemy_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_alchemy_compute(ctx, pool, in, (const ao_alchemy_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_normals;
        stats->seconds_kernel = s.seconds_ao;
        stats->seconds_blur = s.seconds_blur;
    }
    return st;
}

const ao_method ao_i_method_alchemy = {
    .name = "alchemy",
    .title = "Alchemy screen-space ambient obscurance [McGuire11], on SAO's HPG12 spiral",
    .doc = "docs/ao/alchemy.md",
    .params_size = sizeof(ao_alchemy_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = alchemy_param_descs,
    .param_count = (int)(sizeof alchemy_param_descs / sizeof alchemy_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* raw AO is exactly 1 on a plane (v.n is rounding noise, far below the bias z_C beta); the
     * Gaussian's float weights sum to 1 - 1.2e-7 (ao.h), two passes: 1 - 2.4e-7 */
    .flat_tolerance = 1e-5f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
