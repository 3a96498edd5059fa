/* ao_gtao.c: GTAO [Jimenez16] as Intel's XeGTAO computes it (ao.h, "GTAO as XeGTAO";
 * docs/ao/gtao.md).
 *
 * Reference: GameTechDev/XeGTAO @ a5b1686 (v1.30 shaders): XeGTAO.h (GTAOConstants,
 * GTAOUpdateConstants, HilbertIndex, defaults), XeGTAO.hlsli (XeGTAO_PrefilterDepths16x16,
 * XeGTAO_MainPass, XeGTAO_Denoise, XeGTAO_CalculateNormal), vaGTAO.hlsl (SpatioTemporalNoise,
 * quality presets), Effects/vaGTAO.cpp (pass sequence). We follow the FP32 path
 * (XE_GTAO_FP32_DEPTHS, lpfloat = float) and its float32 operation order, one rounding per
 * operation (no mad/FMA contraction). Differences are marked "DIFF:" here and listed in the page.
 *
 * Coordinates: XeGTAO's pixCoord (D3D, y down) is our full-buffer (x, y); view space is XeGTAO's
 * left-handed one, P = ((NDCToViewMul * uv + NDCToViewAdd) * z, z) with z = depth > 0.
 *
 * Passes: 1. prefilter (MIP 0..4 of the clamped view-space depth), 2. main pass over the window
 * plus the denoiser's reach (visibility working term and packed edges), 3. denoise passes, each
 * shrinking the region by one pixel, 4. the window is written clamped to [0, 1].
 * Rows go through obs_pool; each output value depends only on its pixel. */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* AVX2 accelerators (bit-identical to the scalar loops; docs/ao/gtao.md, "Speed") */
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#define GTAO_AVX2 1
#include <immintrin.h>
#define AVX2_FN __attribute__((target("avx2")))
#else
#define GTAO_AVX2 0
#endif

/* The AVX2 paths when the build and the CPU have AVX2, unless OBS_ISA=scalar (as the rasterizer
 * chooses). Either gives the same bits. */
static int gtao_use_avx2(void)
{
#if GTAO_AVX2
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return 0;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    return 0;
#endif
}

#if GTAO_AVX2
/* saturate: v > 0 ? (v < 1 ? v : 1) : 0 (NaN -> 0) */
AVX2_FN static inline __m256 v_sat(__m256 v)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 lt1 = _mm256_blendv_ps(one, v, _mm256_cmp_ps(v, one, _CMP_LT_OQ));
    return _mm256_blendv_ps(zero, lt1, _mm256_cmp_ps(v, zero, _CMP_GT_OQ));
}
#endif

/* ================================================================================================
 * Params, presets, validation
 * ============================================================================================== */

ao_gtao_params ao_gtao_params_default(void)
{
    ao_gtao_params p;
    memset(&p, 0, sizeof p);
    p.slices = AO_GTAO_DEFAULT_SLICES;
    p.steps = AO_GTAO_DEFAULT_STEPS;
    p.radius = AO_GTAO_DEFAULT_RADIUS;
    p.radius_multiplier = AO_GTAO_DEFAULT_RADIUS_MULTIPLIER;
    p.falloff_range = AO_GTAO_DEFAULT_FALLOFF_RANGE;
    p.sample_distribution_power = AO_GTAO_DEFAULT_SAMPLE_DISTRIBUTION_POWER;
    p.thin_occluder_compensation = AO_GTAO_DEFAULT_THIN_OCCLUDER_COMPENSATION;
    p.final_value_power = AO_GTAO_DEFAULT_FINAL_VALUE_POWER;
    p.depth_mip_sampling_offset = AO_GTAO_DEFAULT_DEPTH_MIP_SAMPLING_OFFSET;
    p.normals = AO_GTAO_NORMALS_AUTO;
    p.blur = 1;                     /* vaGTAO.cpp always runs at least the last denoise pass */
    p.denoise_passes = AO_GTAO_DEFAULT_DENOISE_PASSES;
    p.frame_index = 0;              /* no TAA: NoiseIndex 0 */
    p.gpu_packing = 0;              /* the FP32 reference */
    return p;
}

static const char *const preset_names[] = {"default", "xegtao", "low", "medium", "high", "ultra",
                                           "sharp", "medium-denoise", "soft", NULL};

const char *const *ao_gtao_preset_names(void) { return preset_names; }

int ao_gtao_params_preset(const char *name, ao_gtao_params *out)
{
    if (!name || !out)
        return 0;
    ao_gtao_params p = ao_gtao_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "xegtao") || !strcmp(name, "high") || !strcmp(name, "sharp")) {
        /* QualityLevel 2, DenoisePasses 1 */
    } else if (!strcmp(name, "low")) {
        p.slices = 1, p.steps = 2;  /* CSGTAOLow */
    } else if (!strcmp(name, "medium")) {
        p.slices = 2, p.steps = 2;  /* CSGTAOMedium */
    } else if (!strcmp(name, "ultra")) {
        p.slices = 9, p.steps = 3;  /* CSGTAOUltra */
    } else if (!strcmp(name, "medium-denoise")) {
        p.denoise_passes = 2;
    } else if (!strcmp(name, "soft")) {
        p.denoise_passes = 3;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

void ao_gtao_slices_steps_for_samples(int n, int *slices, int *steps)
{
    int sl, st;
    if (n <= 4)
        sl = 1, st = 2;             /* Low */
    else if (n == 8)
        sl = 2, st = 2;             /* Medium */
    else if (n == 18)
        sl = 3, st = 3;             /* High */
    else if (n == 54)
        sl = 9, st = 3;             /* Ultra */
    else {
        const int half = (n + 1) / 2;
        st = half % 4 == 0 ? 4 : half % 3 == 0 ? 3 : half % 2 == 0 ? 2 : 1;
        sl = half / st;
    }
    if (sl > AO_GTAO_MAX_SLICES)
        sl = AO_GTAO_MAX_SLICES;
    if (st > AO_GTAO_MAX_STEPS)
        st = AO_GTAO_MAX_STEPS;
    *slices = sl;
    *steps = st;
}

#define CHECK_RANGE(field, lo, hi, name)                                                                     \
    if (!(p->field >= (lo) && p->field <= (hi)))                                                             \
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: " name " %g must be in [%g, %g]",          \
                         (double)p->field, (double)(lo), (double)(hi));

obs_status ao_gtao_params_validate(obs_context *ctx, const ao_gtao_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: NULL params");
    if (p->slices < 1 || p->slices > AO_GTAO_MAX_SLICES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: slices %d must be in [1, %d]", p->slices,
                         AO_GTAO_MAX_SLICES);
    if (p->steps < 1 || p->steps > AO_GTAO_MAX_STEPS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: steps %d must be in [1, %d]", p->steps,
                         AO_GTAO_MAX_STEPS);
    /* radius * multiplier * 0.75 and its falloff must stay finite, non-zero floats */
    if (!(p->radius >= 1e-6f && p->radius <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: radius %g must be in [1e-6, 1e6] m",
                         (double)p->radius);
    CHECK_RANGE(radius_multiplier, 0.3f, 3.0f, "radius multiplier")      /* GTAOImGuiSettings clamp */
    /* XeGTAO's UI allows 0, which makes falloffMul = -1/0 and the tap weights NaN: we need > 0 */
    if (!(p->falloff_range > 0.0f && p->falloff_range <= 1.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: falloff range %g must be in (0, 1]",
                         (double)p->falloff_range);
    CHECK_RANGE(sample_distribution_power, 1.0f, 3.0f, "sample distribution power")
    CHECK_RANGE(thin_occluder_compensation, 0.0f, 0.7f, "thin occluder compensation")
    CHECK_RANGE(final_value_power, 0.5f, 5.0f, "final value power")
    CHECK_RANGE(depth_mip_sampling_offset, 0.0f, 30.0f, "depth MIP sampling offset")
    if ((unsigned)p->normals >= AO_GTAO_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: unknown normals mode %d", (int)p->normals);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: blur %d must be 0 or 1", p->blur);
    if (p->denoise_passes < 0 || p->denoise_passes > 3)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: denoise passes %d must be in [0, 3]",
                         p->denoise_passes);
    if (p->gpu_packing != 0 && p->gpu_packing != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: gpu packing %d must be 0 or 1", p->gpu_packing);
    if (p->frame_index < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: frame index %d must be >= 0", p->frame_index);
    return OBS_STATUS_OK;
}
#undef CHECK_RANGE

static const char *const normals_names[] = {"auto", "depth", "gbuffer", NULL};

int ao_gtao_params_to_string(const ao_gtao_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "slices=%d steps=%d radius=%.9g radius_multiplier=%.9g falloff_range=%.9g "
                    "sample_distribution_power=%.9g thin_occluder_compensation=%.9g final_value_power=%.9g "
                    "depth_mip_sampling_offset=%.9g normals=%s blur=%d denoise_passes=%d frame_index=%d gpu_packing=%d",
                    p->slices, p->steps, (double)p->radius, (double)p->radius_multiplier, (double)p->falloff_range,
                    (double)p->sample_distribution_power, (double)p->thin_occluder_compensation,
                    (double)p->final_value_power, (double)p->depth_mip_sampling_offset,
                    (unsigned)p->normals < AO_GTAO_NORMALS_COUNT ? normals_names[p->normals] : "?", p->blur,
                    p->denoise_passes, p->frame_index, p->gpu_packing);
}

/* ================================================================================================
 * Constants (XeGTAO.h GTAOUpdateConstants)
 * ============================================================================================== */

_Static_assert(offsetof(ao_gtao_constants, noise_index) == 92, "GTAOConstants layout: 96 bytes");

ao_gtao_constants ao_gtao_constants_from_params(const ao_gtao_params *p, const ao_input *in)
{
    ao_gtao_constants k;
    memset(&k, 0, sizeof k);
    const int W = in->width, H = in->height;
    k.viewport_size[0] = W;
    k.viewport_size[1] = H;
    k.viewport_pixel_size[0] = 1.0f / (float)W;
    k.viewport_pixel_size[1] = 1.0f / (float)H;
    /* DepthUnpackConsts of a D3D [0,1] projection: -P32 and P22 (informational; we read linear depth) */
    if (in->znear > 0.0 && isfinite(in->znear)) {
        if (isinf(in->zfar)) {
            k.depth_unpack_consts[0] = (float)in->znear;
            k.depth_unpack_consts[1] = 1.0f;
        } else if (in->zfar > in->znear) {
            k.depth_unpack_consts[0] = (float)(in->znear * in->zfar / (in->zfar - in->znear));
            k.depth_unpack_consts[1] = (float)(in->zfar / (in->zfar - in->znear));
        }
    }
    /* tanHalfFOV = 1/P00, 1/P11; for our pixel model P00 = 2 fx / W. NDCToViewMul = (2 tanX, -2 tanY),
     * NDCToViewAdd = (-tanX, tanY) for a centred principal point; the general (W/fx, -H/fy),
     * (-cx/fx, cy/fy) equals them bit for bit there (scaling by 2 is exact). */
    k.camera_tan_half_fov[0] = (float)(W / (2.0 * in->fx));
    k.camera_tan_half_fov[1] = (float)(H / (2.0 * in->fy));
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.ndc_to_view_mul[0] = (float)(W / in->fx);
    k.ndc_to_view_mul[1] = (float)(-H / in->fy);
    k.ndc_to_view_add[0] = (float)(-in->cx / in->fx);
    k.ndc_to_view_add[1] = (float)(in->cy / in->fy);
    k.ndc_to_view_mul_x_pixel_size[0] = k.ndc_to_view_mul[0] * k.viewport_pixel_size[0];
    k.ndc_to_view_mul_x_pixel_size[1] = k.ndc_to_view_mul[1] * k.viewport_pixel_size[1];
    k.effect_radius = p->radius;
    k.effect_falloff_range = p->falloff_range;
    k.denoise_blur_beta = p->denoise_passes == 0 ? 1e4f : AO_GTAO_DENOISE_BLUR_BETA;
    k.radius_multiplier = p->radius_multiplier;
    k.sample_distribution_power = p->sample_distribution_power;
    k.thin_occluder_compensation = p->thin_occluder_compensation;
    k.final_value_power = p->final_value_power;
    k.depth_mip_sampling_offset = p->depth_mip_sampling_offset;
    /* NoiseIndex = DenoisePasses > 0 ? frameCounter % 64 : 0; with our blur off, no denoiser runs */
    k.noise_index = (p->blur && p->denoise_passes > 0) ? p->frame_index % 64 : 0;
    k.padding0 = 0.0f;
    k.slice_count = p->slices;
    k.steps_per_slice = p->steps;
    k.denoise_passes = p->blur ? (p->denoise_passes > 1 ? p->denoise_passes : 1) : 0;
    k.gpu_packing = p->gpu_packing;
    k.normals_from_gbuffer =
        p->normals == AO_GTAO_NORMALS_GBUFFER || (p->normals == AO_GTAO_NORMALS_AUTO && in->normal[0] != NULL);
    return k;
}

/* ================================================================================================
 * Small float helpers with HLSL semantics
 * ============================================================================================== */

/* saturate: NaN -> 0 (D3D) */
static inline float sat(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }
/* HLSL max/min: a NaN operand yields the other (D3D IEEE-754 2008 maxNum) */
static inline float hmax(float a, float b) { return fmaxf(a, b); }
static inline float hsign(float v) { return v > 0.0f ? 1.0f : (v < 0.0f ? -1.0f : 0.0f); }
/* lerp(a, b, t) = a + t * (b - a) (fxc/dxc expand it so; no mad here) */
static inline float hlerp(float a, float b, float t) { return a + t * (b - a); }
static inline float hfrac(float v) { return v - floorf(v); }
/* cos, sin: correctly rounded (ao_i_cos_sin). DIFF: a GPU's cos/sin are approximations. */
static inline float hcos(float a) { float c, s; ao_i_cos_sin(a, &c, &s); return c; }
static inline float hsin(float a) { float c, s; ao_i_cos_sin(a, &c, &s); return s; }
/* pow, log2: double evaluation rounded to float. DIFF: GPUs use exp2(y * log2(x)) in float. */
static inline float hpow(float x, float y)
{
    /* y = 2 (the default distribution power): x * x in float is the same correctly rounded value */
    return (y == 2.0f && x >= 0.0f) ? x * x : (float)pow((double)x, (double)y); /* x < 0: NaN, as HLSL */
}
static inline float hlog2(float x) { return (float)log2((double)x); }
/* length / normalize: sqrt of the left-to-right dot. DIFF: GPUs use rsqrt approximations. */
static inline float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline float len3(const float a[3]) { return sqrtf(dot3(a, a)); }
static inline void normalize3(float a[3])
{
    const float l = len3(a);
    a[0] = a[0] / l, a[1] = a[1] / l, a[2] = a[2] / l;
}
static inline void cross3(const float a[3], const float b[3], float o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* XeGTAO_FLOAT3_to_R11G11B10_UNORM(saturate(n * 0.5 + 0.5)) then the decode of vaGTAO.hlsl
 * LoadNormal: x/2047, y/2047, z/1023, * 2 - 1, normalize (gpu_packing only). */
static inline void normal_r11g11b10(float n[3])
{
    const float sc[3] = {2047.0f, 2047.0f, 1023.0f};
    for (int i = 0; i < 3; i++) {
        float e = n[i] * 0.5f + 0.5f;
        e = e > 0.0f ? (e < 1.0f ? e : 1.0f) : 0.0f;
        const unsigned q = (unsigned)(e * sc[i] + 0.5f);
        n[i] = ((float)q / sc[i]) * 2.0f - 1.0f;
    }
    const float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    n[0] = n[0] / l, n[1] = n[1] / l, n[2] = n[2] / l;
}

/* uint(v * 255 + 0.5) / 255 of a value in [0, 1] (the 8-bit AO stores, gpu_packing only) */
static inline float unorm8(float v)
{
    v = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
    return (float)(unsigned)(v * 255.0f + 0.5f) / 255.0f;
}

static inline uint32_t f2u(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static inline float u2f(uint32_t u) { float f; memcpy(&f, &u, 4); return f; }

/* XeGTAO_FastSqrt: asfloat(0x1fbd1df5 + (asint(x) >> 1)), int32 arithmetic shift, wrapping add */
float ao_gtao_fast_sqrt(float x)
{
    const uint32_t i = f2u(x);
    const uint32_t sh = (i >> 1) | (i & 0x80000000u); /* arithmetic >> 1 of the int32 */
    return u2f(0x1fbd1df5u + sh);
}

/* XeGTAO_FastACos: input [-1, 1], output [0, pi] (Lagarde 2014); its own PI = 3.141593,
 * HALF_PI = 1.570796 */
float ao_gtao_fast_acos(float in_x)
{
    const float x = fabsf(in_x);
    float res = -0.156583f * x + 1.570796f;
    res = res * ao_gtao_fast_sqrt(1.0f - x);
    return in_x >= 0.0f ? res : 3.141593f - res;
}

/* ================================================================================================
 * Speed: exact shortcuts used by the fast main pass (docs/ao/gtao.md, "Speed"). Each gives the
 * same float bits as the expression it replaces; ao_gtao_compute_reference keeps the plain form and
 * the tests compare the two byte for byte.
 * ============================================================================================== */

/* fmaxf as glibc's x86-64 s_fmaxf.S computes it for ordered operands (maxss: a > b ? a : b, so
 * an equal pair, +-0 included, yields b); NaN operands go to the library call. */
static inline float hmax_fast(float a, float b)
{
    if (a == a && b == b)
        return a > b ? a : b;
    return fmaxf(a, b);
}

/* The cos (or sin) half of a correctly rounded cos/sin: the exact reduction of ao_i_cos_sin
 * (ao_sao.c) and the one Taylor polynomial the quadrant selects. ao_i_cos_sin itself now uses
 * fdlibm's shorter kernels; both are correctly rounded for every float below 3e9 (each checked
 * exhaustively, docs/ao/sao.md), so they give the same float. (A shared copy for all the kernels'
 * scalar and AVX2 paths is a follow-up: alchemy, gtao and sao each carry one now.) */
static const double CS_P1 = 0x1.921fbp+0, CS_P2 = 0x1.5110bp-22, CS_P3 = 0x1.18469800p-44,
                    CS_P4 = 0x1.3198a2e037073p-69;
static const double CS_TWO_OVER_PI = 0x1.45f306dc9c883p-1, CS_ROUNDER = 0x1.8p52;
static inline double cs_sin_poly(double r, double z)
{
    return r + r * z * (-1.0 / 6.0 + z * (1.0 / 120.0 + z * (-1.0 / 5040.0 + z * (1.0 / 362880.0 +
           z * (-1.0 / 39916800.0 + z * (1.0 / 6227020800.0 + z * (-1.0 / 1307674368000.0 +
           z * (1.0 / 355687428096000.0 + z * (-1.0 / 121645100408832000.0)))))))));
}
static inline double cs_cos_poly(double z)
{
    return 1.0 - 0.5 * z + z * z * (1.0 / 24.0 + z * (-1.0 / 720.0 + z * (1.0 / 40320.0 + z * (-1.0 / 3628800.0 +
           z * (1.0 / 479001600.0 + z * (-1.0 / 87178291200.0 + z * (1.0 / 20922789888000.0 +
           z * (-1.0 / 6402373705728000.0 + z * (1.0 / 2432902008176640000.0)))))))));
}
/* which = 0: cos, 1: sin */
static inline float cos_or_sin(float angle, int which)
{
    const double x = (double)angle;
    if (!(fabs(x) < 3.0e9)) {
        float c, s;
        ao_i_cos_sin(angle, &c, &s);
        return which ? s : c;
    }
    const double kd = (x * CS_TWO_OVER_PI + CS_ROUNDER) - CS_ROUNDER;
    double r = x - kd * CS_P1;
    r = r - kd * CS_P2;
    r = r - kd * CS_P3;
    r = r - kd * CS_P4;
    const double z = r * r;
    /* ao_i_cos_sin: q 0: (cs, sn), 1: (-sn, cs), 2: (-cs, -sn), 3: (sn, -cs) */
    const int q = (int)(((int64_t)kd + (which ? 3 : 0)) & 3); /* sin at k = cos at k + 3 */
    switch (q) {
    case 0: return (float)cs_cos_poly(z);
    case 1: return (float)-cs_sin_poly(r, z);
    case 2: return (float)-cs_cos_poly(z);
    default: return (float)cs_sin_poly(r, z);
    }
}
static inline float hcos_fast(float a) { return cos_or_sin(a, 0); }
static inline float hsin_fast(float a) { return cos_or_sin(a, 1); }

/* The per-tap MIP choice of XeGTAO_MainPass, as main_pixel computes it: mipLevel =
 * clamp(log2(offsetLength) - DepthMIPSamplingOffset, 0, 5), then the point-MIP level
 * min(floor(mipLevel + 0.5), 4). */
static int mip_of_length(float off_len, float mip_offset)
{
    float mip = hlog2(off_len) - mip_offset;
    mip = mip > 0.0f ? (mip < (float)AO_GTAO_DEPTH_MIP_LEVELS ? mip : (float)AO_GTAO_DEPTH_MIP_LEVELS) : 0.0f;
    int li = (int)floorf(mip + 0.5f);
    return li > AO_GTAO_DEPTH_MIP_LEVELS - 1 ? AO_GTAO_DEPTH_MIP_LEVELS - 1 : li;
}

/* That choice is a non-decreasing step function of the length (log2, the subtraction, the clamp
 * and floor are monotonic; lengths are >= 0 or NaN), so it equals the count of thresholds t_j
 * (j = 1..4, the least float with level >= j) the length reaches: NaN reaches none (level 0, as
 * the clamp gives), +inf all (level 4). t_j by bisection over the bit patterns of [0, +inf], which
 * order as the floats do. This replaces a double log2 per tap by four compares. */
static void mip_thresholds(float mip_offset, float t[AO_GTAO_DEPTH_MIP_LEVELS - 1])
{
    for (int j = 1; j < AO_GTAO_DEPTH_MIP_LEVELS; j++) {
        uint32_t lo = 0u, hi = 0x7f800000u; /* level(lo) < j <= level(hi) (level(+inf) = 4) */
        if (mip_of_length(0.0f, mip_offset) >= j) {
            t[j - 1] = 0.0f;
            continue;
        }
        while (hi - lo > 1u) {
            const uint32_t mid = lo + (hi - lo) / 2u;
            if (mip_of_length(u2f(mid), mip_offset) >= j)
                hi = mid;
            else
                lo = mid;
        }
        t[j - 1] = u2f(hi);
    }
}

static inline int mip_from_thresholds(float off_len, const float t[AO_GTAO_DEPTH_MIP_LEVELS - 1])
{
    return (off_len >= t[0]) + (off_len >= t[1]) + (off_len >= t[2]) + (off_len >= t[3]);
}

/* Test hook (ao.h): the threshold form against the log2 form for one length. */
int ao_gtao_mip_of_length(float off_len, float mip_offset, int fast)
{
    if (!fast)
        return mip_of_length(off_len, mip_offset);
    float t[AO_GTAO_DEPTH_MIP_LEVELS - 1];
    mip_thresholds(mip_offset, t);
    return mip_from_thresholds(off_len, t);
}
_Static_assert(AO_GTAO_DEPTH_MIP_LEVELS == 5, "mip_from_thresholds counts four thresholds");

/* ================================================================================================
 * Noise (XeGTAO.h HilbertIndex, vaGTAO.hlsl SpatioTemporalNoise)
 * ============================================================================================== */

uint32_t ao_gtao_hilbert_index(uint32_t x, uint32_t y)
{
    const uint32_t width = 1u << AO_GTAO_HILBERT_LEVEL;
    uint32_t index = 0;
    for (uint32_t cur = width / 2u; cur > 0u; cur /= 2u) {
        const uint32_t rx = (x & cur) > 0u, ry = (y & cur) > 0u;
        index += cur * cur * ((3u * rx) ^ ry);
        if (ry == 0u) {
            if (rx == 1u) {
                x = (width - 1u) - x;
                y = (width - 1u) - y;
            }
            const uint32_t t = x;
            x = y;
            y = t;
        }
    }
    return index;
}

void ao_gtao_noise(uint32_t x, uint32_t y, int noise_index, float out[2])
{
    uint32_t index = ao_gtao_hilbert_index(x, y);
    index += 288u * (uint32_t)(noise_index % 64); /* "why 288? ... the best so far" */
    /* R2 sequence: frac(0.5 + float(index) * float2(a1, a2)), float32 */
    const float fi = (float)index;
    out[0] = hfrac(0.5f + fi * 0.75487766624669276005f);
    out[1] = hfrac(0.5f + fi * 0.5698402909980532659114f);
}

void ao_gtao_noise_texture(int noise_index, float out[64 * 64 * 2])
{
    for (uint32_t y = 0; y < 64; y++)
        for (uint32_t x = 0; x < 64; x++)
            ao_gtao_noise(x, y, noise_index, out + 2 * (y * 64 + x));
}

/* ================================================================================================
 * Edges (XeGTAO_CalculateEdges, XeGTAO_PackEdges, XeGTAO_UnpackEdges)
 * ============================================================================================== */

static inline void calculate_edges(float c, float l, float r, float t, float b, float out[4])
{
    float e[4] = {l - c, r - c, t - c, b - c};
    const float slope_lr = (e[1] - e[0]) * 0.5f;
    const float slope_tb = (e[3] - e[2]) * 0.5f;
    const float adj[4] = {e[0] + slope_lr, e[1] - slope_lr, e[2] + slope_tb, e[3] - slope_tb};
    const float denom = c * 0.011f;
    for (int i = 0; i < 4; i++) {
        const float a = fabsf(e[i]), s = fabsf(adj[i]);
        const float m = a < s ? a : s; /* min(abs(e), abs(e_adjusted)) */
        out[i] = sat(1.25f - m / denom);
    }
}

static inline unsigned pack_edges(const float e[4])
{
    /* round(saturate(e) * 2.9) per edge (round_ne), dot with (64, 16, 4, 1)/255, stored in R8_UNORM:
     * exactly the integer (L << 6) | (R << 4) | (T << 2) | B. */
    unsigned q[4];
    for (int i = 0; i < 4; i++)
        q[i] = (unsigned)rintf(sat(e[i]) * 2.9f);
    return (q[0] << 6) | (q[1] << 4) | (q[2] << 2) | q[3];
}

void ao_gtao_calculate_edges(float c, float l, float r, float t, float b, float out[4])
{
    calculate_edges(c, l, r, t, b, out);
}

unsigned ao_gtao_pack_edges(const float e[4]) { return pack_edges(e); }

void ao_gtao_unpack_edges(unsigned p, float out[4])
{
    out[0] = (float)((p >> 6) & 3u) / 3.0f;
    out[1] = (float)((p >> 4) & 3u) / 3.0f;
    out[2] = (float)((p >> 2) & 3u) / 3.0f;
    out[3] = (float)(p & 3u) / 3.0f;
}

/* ================================================================================================
 * Prefilter (XeGTAO_PrefilterDepths16x16, XeGTAO_DepthMIPFilter, XeGTAO_ClampDepth)
 * ============================================================================================== */

/* XeGTAO_ClampDepth. DIFF (none in effect): it tests `#ifdef XE_GTAO_USE_HALF_FLOAT_PRECISION`, a
 * macro XeGTAO.hlsli always defines (to 0 or 1), so even the FP32 path clamps to 65504; we do the
 * same. Our background (+inf, NaN, <= 0) becomes 65504, what an infinite-far reversed-Z buffer gives. */
static inline float clamp_depth(float d)
{
    if (!(d > 0.0f) || !isfinite(d))
        return AO_GTAO_DEPTH_CLAMP; /* our background */
    return d < AO_GTAO_DEPTH_CLAMP ? d : AO_GTAO_DEPTH_CLAMP;
}
static inline int is_background(float d) { return !(d > 0.0f) || !isfinite(d); }

typedef struct mip_filter {
    float falloff_mul, falloff_add;
} mip_filter;

/* XeGTAO_DepthMIPFilter: effectRadius = 0.75 * Radius * RadiusMultiplier ("found empirically"),
 * falloffRange = FalloffRange * effectRadius, falloffFrom = effectRadius * (1 - FalloffRange). */
static mip_filter mip_filter_from(const ao_gtao_constants *k)
{
    mip_filter f;
    const float effect_radius = 0.75f * k->effect_radius * k->radius_multiplier;
    const float falloff_range = k->effect_falloff_range * effect_radius;
    const float falloff_from = effect_radius * (1.0f - k->effect_falloff_range);
    f.falloff_mul = -1.0f / falloff_range;
    f.falloff_add = falloff_from / falloff_range + 1.0f;
    return f;
}

static inline float depth_mip_filter(const mip_filter *f, float d0, float d1, float d2, float d3)
{
    const float max_depth = hmax_fast(hmax_fast(d0, d1), hmax_fast(d2, d3)); /* = hmax */
    const float w0 = sat((max_depth - d0) * f->falloff_mul + f->falloff_add);
    const float w1 = sat((max_depth - d1) * f->falloff_mul + f->falloff_add);
    const float w2 = sat((max_depth - d2) * f->falloff_mul + f->falloff_add);
    const float w3 = sat((max_depth - d3) * f->falloff_mul + f->falloff_add);
    const float wsum = w0 + w1 + w2 + w3;
    return (w0 * d0 + w1 * d1 + w2 * d2 + w3 * d3) / wsum;
}

typedef struct prefilter_job {
    const ao_input *in;
    obs_image_f32 *dst;
    const obs_image_f32 *src; /* NULL: level 0 from the input */
    mip_filter f;
    int avx2;                 /* 1: 8 texels at a time where no child is clamped */
} prefilter_job;

#if GTAO_AVX2
/* clamp_depth of 8 depths: d > 0 and finite ? min(d, 65504) : 65504 */
AVX2_FN static inline void clamp8_avx2(const float *d, float *o)
{
    const __m256 v = _mm256_loadu_ps(d), cl = _mm256_set1_ps(AO_GTAO_DEPTH_CLAMP);
    const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(v, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(v, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    const __m256 m = _mm256_blendv_ps(cl, v, _mm256_cmp_ps(v, cl, _CMP_LT_OQ));
    _mm256_storeu_ps(o, _mm256_blendv_ps(cl, m, fg));
}

/* depth_mip_filter of 8 texels (children 2x, 2x + 1 of rows r0, r1). hmax as maxss for ordered
 * operands; returns 0 (nothing written) if a child is NaN, for the scalar loop. */
AVX2_FN static inline int mip8_avx2(const mip_filter *f, const float *r0, const float *r1, float *o)
{
    const __m256 a0 = _mm256_loadu_ps(r0), b0 = _mm256_loadu_ps(r0 + 8);
    const __m256 a1 = _mm256_loadu_ps(r1), b1 = _mm256_loadu_ps(r1 + 8);
#define EVEN(a, b) _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0))), _MM_SHUFFLE(3, 1, 2, 0)))
#define ODD(a, b) _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1))), _MM_SHUFFLE(3, 1, 2, 0)))
    const __m256 d0 = EVEN(a0, b0), d1 = ODD(a0, b0), d2 = EVEN(a1, b1), d3 = ODD(a1, b1);
#undef EVEN
#undef ODD
    const __m256 nan = _mm256_or_ps(_mm256_cmp_ps(d0, d1, _CMP_UNORD_Q), _mm256_cmp_ps(d2, d3, _CMP_UNORD_Q));
    if (_mm256_movemask_ps(nan))
        return 0;
    /* hmax(a, b) = a > b ? a : b */
#define HMAX(a, b) _mm256_blendv_ps(b, a, _mm256_cmp_ps(a, b, _CMP_GT_OQ))
    const __m256 m01 = HMAX(d0, d1), m23 = HMAX(d2, d3);
    const __m256 max_depth = HMAX(m01, m23);
#undef HMAX
    const __m256 fm = _mm256_set1_ps(f->falloff_mul), fa = _mm256_set1_ps(f->falloff_add);
    const __m256 w0 = v_sat(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(max_depth, d0), fm), fa));
    const __m256 w1 = v_sat(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(max_depth, d1), fm), fa));
    const __m256 w2 = v_sat(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(max_depth, d2), fm), fa));
    const __m256 w3 = v_sat(_mm256_add_ps(_mm256_mul_ps(_mm256_sub_ps(max_depth, d3), fm), fa));
    const __m256 wsum = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(w0, w1), w2), w3);
    const __m256 num = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, d0), _mm256_mul_ps(w1, d1)),
                                                   _mm256_mul_ps(w2, d2)),
                                     _mm256_mul_ps(w3, d3));
    _mm256_storeu_ps(o, _mm256_div_ps(num, wsum));
    return 1;
}
#endif

static void prefilter_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const prefilter_job *J = (const prefilter_job *)user;
    const int y = (int)task;
    float *o = obs_image_f32_row(J->dst, y);
    if (!J->src) {
        const float *d = obs_image_f32_row(J->in->depth, y);
        int x = 0;
#if GTAO_AVX2
        if (J->avx2)
            for (; x + 8 <= J->dst->width; x += 8)
                clamp8_avx2(d + x, o + x);
#endif
        for (; x < J->dst->width; x++)
            o[x] = clamp_depth(d[x]);
        return;
    }
    /* children 2p + (0,0), (1,0), (0,1), (1,1) = depth0..3 (the GatherRed .w, .z, .x, .y order) */
    const obs_image_f32 *s = J->src;
    const int y0 = 2 * y, y1 = 2 * y + 1 < s->height ? 2 * y + 1 : s->height - 1;
    const float *r0 = obs_image_f32_row(s, y0), *r1 = obs_image_f32_row(s, y1);
    for (int x = 0; x < J->dst->width; x++) {
#if GTAO_AVX2
        /* children 2x .. 2x + 15 inside the parent row */
        if (J->avx2 && x + 8 <= J->dst->width && 2 * x + 16 <= s->width && mip8_avx2(&J->f, r0 + 2 * x, r1 + 2 * x, o + x)) {
            x += 7;
            continue;
        }
#endif
        const int x0 = 2 * x, x1 = 2 * x + 1 < s->width ? 2 * x + 1 : s->width - 1;
        o[x] = depth_mip_filter(&J->f, r0[x0], r0[x1], r1[x0], r1[x1]);
    }
}

void ao_gtao_mips_free(obs_image_f32 levels[AO_GTAO_DEPTH_MIP_LEVELS])
{
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++)
        obs_image_f32_free(&levels[l]);
}

/* Level l's size: max(1, size >> 1) per level */
static void level_size(int W, int H, int l, int *w, int *h)
{
    for (int i = 0; i < l; i++) {
        W = W > 1 ? W >> 1 : 1;
        H = H > 1 ? H >> 1 : 1;
    }
    *w = W, *h = H;
}

/* Fill levels[0..4], already sized (level_size); every texel is written. */
static void prefilter_fill(obs_pool *pool, const ao_input *in, const ao_gtao_constants *k,
                           obs_image_f32 levels[AO_GTAO_DEPTH_MIP_LEVELS], int avx2)
{
    prefilter_job J = {in, NULL, NULL, mip_filter_from(k), avx2};
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++) {
        J.dst = &levels[l];
        J.src = l ? &levels[l - 1] : NULL;
        obs_pool_run(pool, levels[l].height, prefilter_row, &J);
    }
}

obs_status ao_gtao_prefilter_depths(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_constants *k,
                                    obs_image_f32 levels[AO_GTAO_DEPTH_MIP_LEVELS])
{
    if (!in || !k || !levels || !in->depth)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: prefilter: NULL argument");
    memset(levels, 0, sizeof(obs_image_f32) * AO_GTAO_DEPTH_MIP_LEVELS);
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++) {
        int w, h;
        level_size(in->width, in->height, l, &w, &h);
        obs_status st = obs_image_f32_alloc(ctx, w, h, &levels[l]);
        if (st != OBS_STATUS_OK) {
            ao_gtao_mips_free(levels);
            return st;
        }
    }
    prefilter_fill(pool, in, k, levels, gtao_use_avx2());
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * Main pass (XeGTAO_MainPass)
 * ============================================================================================== */

/* XeGTAO_ComputeViewspacePosition: ((NDCToViewMul * screenPos + NDCToViewAdd) * z, z).
 * Orthographic (our extension): the xy term is not scaled by z. */
static inline void view_pos(const ao_gtao_constants *k, float u, float v, float z, float P[3])
{
    const float a = k->ndc_to_view_mul[0] * u + k->ndc_to_view_add[0];
    const float b = k->ndc_to_view_mul[1] * v + k->ndc_to_view_add[1];
    P[0] = k->orthographic ? a : a * z;
    P[1] = k->orthographic ? b : b * z;
    P[2] = z;
}

/* Point sampling at screen uv with CLAMP addressing on a level: texel floor(uv * size).
 * DIFF: GPUs snap uv to 8+ bits of sub-texel precision first; NaN uv reads texel 0. */
static inline int texel(float uv, int size)
{
    const float t = uv * (float)size;
    if (!(t >= 0.0f))
        return 0;
    if (t >= (float)size)
        return size - 1;
    return (int)t;
}

void ao_gtao_tap_at(const ao_gtao_constants *k, float viewspace_z, const float noise[2], int slice, int step,
                    ao_gtao_tap *out)
{
    /* the same float steps as main_pixel below */
    const float effect_radius = k->effect_radius * k->radius_multiplier;
    const float pixel_size_x = k->orthographic ? k->ndc_to_view_mul_x_pixel_size[0]
                                               : viewspace_z * k->ndc_to_view_mul_x_pixel_size[0];
    const float ssr = effect_radius / pixel_size_x;
    const float min_s = 1.3f / ssr;
    const float slice_count = (float)k->slice_count, steps = (float)k->steps_per_slice;
    const float phi = (((float)slice + noise[0]) / slice_count) * 3.14159265358979323846f;
    float cphi, sphi;
    ao_i_cos_sin(phi, &cphi, &sphi);
    const float omega[2] = {cphi * ssr, -sphi * ssr};
    const float step_base = ((float)slice + (float)step * steps) * 0.6180339887498948482f;
    const float step_noise = hfrac(noise[1] + step_base);
    float s = ((float)step + step_noise) / steps;
    s = hpow(s, k->sample_distribution_power);
    s = s + min_s;
    out->offset[0] = s * omega[0];
    out->offset[1] = s * omega[1];
    out->offset_length = sqrtf(out->offset[0] * out->offset[0] + out->offset[1] * out->offset[1]);
    float m = hlog2(out->offset_length) - k->depth_mip_sampling_offset;
    m = m > 0.0f ? (m < (float)AO_GTAO_DEPTH_MIP_LEVELS ? m : (float)AO_GTAO_DEPTH_MIP_LEVELS) : 0.0f;
    out->mip_level = m;
    /* point MIP filter: the nearest level, floor(lod + 0.5), clamped to the last level (4) */
    int li = (int)floorf(m + 0.5f);
    out->mip = li > AO_GTAO_DEPTH_MIP_LEVELS - 1 ? AO_GTAO_DEPTH_MIP_LEVELS - 1 : li;
    out->rounded[0] = rintf(out->offset[0]); /* HLSL round -> round_ne */
    out->rounded[1] = rintf(out->offset[1]);
}

typedef struct main_consts {
    float effect_radius, falloff_mul, falloff_add, min_s_num, thin_scale;
} main_consts;

/* XeGTAO_ComputeViewspaceNormal / XeGTAO_CalculateNormal from MIP 0 (clamped depths).
 * DIFF: XeGTAO's normal pass converts NDC depth without XeGTAO_ClampDepth (identical for depth <=
 * 65504), and stores the normal in R11G11B10_UNORM (we keep float32). */
/* e: XeGTAO_CalculateEdges of the same five depths (the main pass's edges) */
static int normal_from_depth_e(const ao_gtao_constants *k, const obs_image_f32 *z0, int x, int y, const float e[4],
                               float nrm[3])
{
    const int W = z0->width, H = z0->height;
    const int xl = x > 0 ? x - 1 : 0, xr = x < W - 1 ? x + 1 : W - 1;
    const int yt = y > 0 ? y - 1 : 0, yb = y < H - 1 ? y + 1 : H - 1;
    const float zc = obs_image_f32_row(z0, y)[x];
    const float zl = obs_image_f32_row(z0, y)[xl], zr = obs_image_f32_row(z0, y)[xr];
    const float zt = obs_image_f32_row(z0, yt)[x], zb = obs_image_f32_row(z0, yb)[x];
    const float psx = k->viewport_pixel_size[0], psy = k->viewport_pixel_size[1];
    const float u = ((float)x + 0.5f) * psx, v = ((float)y + 0.5f) * psy;
    float C[3], L[3], R[3], T[3], B[3];
    view_pos(k, u, v, zc, C);
    view_pos(k, u + -1.0f * psx, v + 0.0f * psy, zl, L);
    view_pos(k, u + 1.0f * psx, v + 0.0f * psy, zr, R);
    view_pos(k, u + 0.0f * psx, v + -1.0f * psy, zt, T);
    view_pos(k, u + 0.0f * psx, v + 1.0f * psy, zb, B);
    const float acc[4] = {sat(e[0] * e[2] + 0.01f), sat(e[2] * e[1] + 0.01f), sat(e[1] * e[3] + 0.01f),
                          sat(e[3] * e[0] + 0.01f)};
    for (int i = 0; i < 3; i++) {
        L[i] = L[i] - C[i], R[i] = R[i] - C[i], T[i] = T[i] - C[i], B[i] = B[i] - C[i];
    }
    normalize3(L), normalize3(R), normalize3(T), normalize3(B);
    float c0[3], c1[3], c2[3], c3[3];
    cross3(L, T, c0), cross3(T, R, c1), cross3(R, B, c2), cross3(B, L, c3);
    for (int i = 0; i < 3; i++)
        nrm[i] = acc[0] * c0[i] + acc[1] * c1[i] + acc[2] * c2[i] + acc[3] * c3[i];
    const float l2 = dot3(nrm, nrm);
    if (!(l2 > 0.0f) || !isfinite(l2))
        return 0;
    normalize3(nrm);
    return 1;
}

static int normal_from_depth(const ao_gtao_constants *k, const obs_image_f32 *z0, int x, int y, float nrm[3])
{
    const int W = z0->width, H = z0->height;
    const int xl = x > 0 ? x - 1 : 0, xr = x < W - 1 ? x + 1 : W - 1;
    const int yt = y > 0 ? y - 1 : 0, yb = y < H - 1 ? y + 1 : H - 1;
    float e[4];
    ao_gtao_calculate_edges(obs_image_f32_row(z0, y)[x], obs_image_f32_row(z0, y)[xl], obs_image_f32_row(z0, y)[xr],
                            obs_image_f32_row(z0, yt)[x], obs_image_f32_row(z0, yb)[x], e);
    return normal_from_depth_e(k, z0, x, y, e, nrm);
}

/* One pixel of XeGTAO_MainPass: the working visibility (before the UNORM packing) and the packed
 * edges. Returns 0 for a background pixel, 2 for a degenerate normal (visibility 1), else 1. */
static int main_pixel(const ao_gtao_constants *k, const main_consts *mc, const obs_image_f32 *levels,
                      const ao_input *in, int x, int y, float *vis_out, unsigned char *edges_out)
{
    const obs_image_f32 *z0 = &levels[0];
    const int W = z0->width, H = z0->height;
    /* valuesUL / valuesBR gathers: centre, left, top, right, bottom (CLAMP) */
    const int xl = x > 0 ? x - 1 : 0, xr = x < W - 1 ? x + 1 : W - 1;
    const int yt = y > 0 ? y - 1 : 0, yb = y < H - 1 ? y + 1 : H - 1;
    float viewspace_z = obs_image_f32_row(z0, y)[x];
    float e[4];
    ao_gtao_calculate_edges(viewspace_z, obs_image_f32_row(z0, y)[xl], obs_image_f32_row(z0, y)[xr],
                            obs_image_f32_row(z0, yt)[x], obs_image_f32_row(z0, yb)[x], e);
    *edges_out = (unsigned char)ao_gtao_pack_edges(e);

    /* DIFF: background (our depth not finite or <= 0) is visibility 1; XeGTAO shades the far plane */
    if (is_background(obs_image_f32_row(in->depth, y)[x])) {
        *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
        return 0;
    }

    /* Normal: LoadNormal (normalized G-buffer normal, ours -> XeGTAO's left-handed view space:
     * z flipped) or XeGTAO_ComputeViewspaceNormal */
    float n[3];
    if (k->normals_from_gbuffer) {
        n[0] = obs_image_f32_row(in->normal[0], y)[x];
        n[1] = obs_image_f32_row(in->normal[1], y)[x];
        n[2] = -obs_image_f32_row(in->normal[2], y)[x];
        const float l2 = dot3(n, n);
        if (!(l2 > 0.0f) || !isfinite(l2)) {
            *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
            return 2;
        }
        normalize3(n);
    } else if (!normal_from_depth(k, z0, x, y, n)) {
        *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
        return 2;
    }
    if (k->gpu_packing)
        normal_r11g11b10(n); /* the normal map's R11G11B10_UNORM (generated or the engine's) */

    /* Move the centre toward the camera (FP32: 0.99999) */
    viewspace_z = viewspace_z * AO_GTAO_CENTER_Z_PULL;
    const float psx = k->viewport_pixel_size[0], psy = k->viewport_pixel_size[1];
    const float u = ((float)x + 0.5f) * psx, v = ((float)y + 0.5f) * psy;
    float C[3];
    view_pos(k, u, v, viewspace_z, C);
    float V[3] = {-C[0], -C[1], -C[2]};
    if (k->orthographic)
        V[0] = 0.0f, V[1] = 0.0f, V[2] = -1.0f; /* our extension: parallel view rays */
    else
        normalize3(V);

    float noise[2];
    ao_gtao_noise((uint32_t)x, (uint32_t)y, k->noise_index, noise);
    const float noise_slice = noise[0], noise_sample = noise[1];

    /* Screen-space radius: effectRadius / (z * NDCToViewMul_x_PixelSize.x) */
    const float pixel_size_x = k->orthographic ? k->ndc_to_view_mul_x_pixel_size[0]
                                               : viewspace_z * k->ndc_to_view_mul_x_pixel_size[0];
    const float ssr = mc->effect_radius / pixel_size_x;
    /* fade out for small screen radii (added before the slice loop, so it is divided by sliceCount) */
    float visibility = sat((10.0f - ssr) / 100.0f) * 0.5f;
    const float min_s = mc->min_s_num / ssr;   /* pixelTooCloseThreshold 1.3 / screenspaceRadius */
    const float slice_count = (float)k->slice_count, steps = (float)k->steps_per_slice;
    const obs_image_f32 *lv = levels;

    for (int sl = 0; sl < k->slice_count; sl++) {
        const float slice = (float)sl;
        /* [Jimenez16] Alg. 1 lines 5, 6 */
        const float slice_k = (slice + noise_slice) / slice_count;
        const float phi = slice_k * 3.14159265358979323846f; /* XE_GTAO_PI */
        float cos_phi, sin_phi;
        ao_i_cos_sin(phi, &cos_phi, &sin_phi);
        const float omega[2] = {cos_phi * ssr, -sin_phi * ssr}; /* screen y is down */
        /* line 8: direction; line 9: orthoDirectionVec = dir - (dir . V) V */
        const float dir[3] = {cos_phi, sin_phi, 0.0f};
        const float dv = dot3(dir, V);
        const float ortho[3] = {dir[0] - dv * V[0], dir[1] - dv * V[1], dir[2] - dv * V[2]};
        /* line 10: axis = normalize(cross(orthoDir, V)) */
        float axis[3];
        cross3(ortho, V, axis);
        normalize3(axis);
        /* line 11: projected normal */
        const float na = dot3(n, axis);
        const float pn[3] = {n[0] - axis[0] * na, n[1] - axis[1] * na, n[2] - axis[2] * na};
        /* line 13: sign; line 14: |projN| and cos; line 15: n (XeGTAO_FastACos, as XeGTAO) */
        const float sign_norm = hsign(dot3(ortho, pn));
        float pn_len = len3(pn);
        const float cos_norm = sat(dot3(pn, V) / pn_len);
        const float nang = sign_norm * ao_gtao_fast_acos(cos_norm);
        /* lower horizon targets cos(n +- pi/2) (the paper uses -1) */
        const float low0 = hcos(nang + 1.57079632679489661923f);
        const float low1 = hcos(nang - 1.57079632679489661923f);
        float hc0 = low0, hc1 = low1;

        for (int st = 0; st < k->steps_per_slice; st++) {
            const float step = (float)st;
            /* R1 sequence per step */
            const float step_base = (slice + step * steps) * 0.6180339887498948482f;
            const float step_noise = hfrac(noise_sample + step_base);
            /* approx line 20, with noise and the distribution power */
            float s = (step + step_noise) / steps;
            s = hpow(s, k->sample_distribution_power);
            s = s + min_s;
            /* lines 21-22 */
            float off[2] = {s * omega[0], s * omega[1]};
            const float off_len = sqrtf(off[0] * off[0] + off[1] * off[1]);
            float mip = hlog2(off_len) - k->depth_mip_sampling_offset;
            mip = mip > 0.0f ? (mip < (float)AO_GTAO_DEPTH_MIP_LEVELS ? mip : (float)AO_GTAO_DEPTH_MIP_LEVELS) : 0.0f;
            int li = (int)floorf(mip + 0.5f); /* point MIP filter */
            if (li > AO_GTAO_DEPTH_MIP_LEVELS - 1)
                li = AO_GTAO_DEPTH_MIP_LEVELS - 1;
            /* snap to pixel centres */
            off[0] = rintf(off[0]) * psx;
            off[1] = rintf(off[1]) * psy;
            const obs_image_f32 *L = &lv[li];
            const float u0 = u + off[0], v0 = v + off[1], u1 = u - off[0], v1 = v - off[1];
            const float sz0 = obs_image_f32_row(L, texel(v0, L->height))[texel(u0, L->width)];
            const float sz1 = obs_image_f32_row(L, texel(v1, L->height))[texel(u1, L->width)];
            float P0[3], P1[3];
            view_pos(k, u0, v0, sz0, P0);
            view_pos(k, u1, v1, sz1, P1);
            const float d0[3] = {P0[0] - C[0], P0[1] - C[1], P0[2] - C[2]};
            const float d1[3] = {P1[0] - C[0], P1[1] - C[1], P1[2] - C[2]};
            const float dist0 = len3(d0), dist1 = len3(d1);
            /* approx lines 23, 24 */
            const float hv0[3] = {d0[0] / dist0, d0[1] / dist0, d0[2] / dist0};
            const float hv1[3] = {d1[0] / dist1, d1[1] / dist1, d1[2] / dist1};
            /* falloff weight ("4.3 Bounding the sampling area", modified); the thin-occluder form
             * equals the plain distance for compensation 0 (z * 1 is exact) */
            const float fb0[3] = {d0[0], d0[1], d0[2] * mc->thin_scale};
            const float fb1[3] = {d1[0], d1[1], d1[2] * mc->thin_scale};
            const float w0 = sat(len3(fb0) * mc->falloff_mul + mc->falloff_add);
            const float w1 = sat(len3(fb1) * mc->falloff_mul + mc->falloff_add);
            float shc0 = dot3(hv0, V), shc1 = dot3(hv1, V);
            shc0 = hlerp(low0, shc0, w0);
            shc1 = hlerp(low1, shc1, w1);
            /* thickness heuristic disabled (XeGTAO's #else branch): plain max */
            hc0 = hmax(hc0, shc0);
            hc1 = hmax(hc1, shc1);
        }

        /* the |projN| fudge: "0.05 is close (PSNR 21.34) to disabled (PSNR 21.45)" */
        pn_len = hlerp(pn_len, 1.0f, 0.05f);
        /* line ~27: h0, h1 with XeGTAO_FastACos; the clamp to n +- pi/2 is off (#if 0) */
        const float h0 = -ao_gtao_fast_acos(hc1);
        const float h1 = ao_gtao_fast_acos(hc0);
        /* the closed-form inner integral [Jimenez16] Eq. 10, with cos(n) taken as cosNorm */
        const float sin_n = hsin(nang);
        const float iarc0 = (cos_norm + 2.0f * h0 * sin_n - hcos(2.0f * h0 - nang)) / 4.0f;
        const float iarc1 = (cos_norm + 2.0f * h1 * sin_n - hcos(2.0f * h1 - nang)) / 4.0f;
        visibility = visibility + pn_len * (iarc0 + iarc1);
    }
    visibility = visibility / slice_count;
    visibility = hpow(visibility, k->final_value_power);
    visibility = hmax(0.03f, visibility); /* "disallow total occlusion" */
    /* XeGTAO_OutputWorkingTerm: saturate(visibility / 1.5) into UNORM8. DIFF (FP32 default): no 8-bit
     * quantisation; the working term is min(visibility, 1.5) (the denoiser is linear in it). With
     * gpu_packing, the working term is the decoded 8-bit value in XeGTAO's scaled units. */
    if (k->gpu_packing)
        *vis_out = unorm8(sat(visibility / AO_GTAO_OCCLUSION_TERM_SCALE));
    else
        *vis_out = visibility < AO_GTAO_OCCLUSION_TERM_SCALE ? visibility : AO_GTAO_OCCLUSION_TERM_SCALE;
    return 1;
}

/* ---- The fast main pass: per-call tables and the per-pixel loop ----------------------------------
 * Everything that depends only on the pixel's noise cell (x mod 64, y mod 64), the slice and the
 * step is computed once per call with main_pixel's own expressions: the noise pair, cos/sin of the
 * slice angle phi, and the step's s^power before the per-pixel + minS. The MIP choice uses
 * mip_thresholds. The remaining per-pixel and per-tap float operations are main_pixel's, in its
 * order. */
typedef struct main_tables {
    float noise[64 * 64][2];        /* ao_gtao_noise of the cell */
    float *cs;                      /* [cell][slice][2]: cos phi, sin phi */
    float *spow;                    /* [cell][slice][step]: hpow((step + stepNoise) / steps, power) */
    float mip_t[AO_GTAO_DEPTH_MIP_LEVELS - 1];
} main_tables;

static void main_tables_free(main_tables *T)
{
    if (!T)
        return;
    free(T->cs);
    free(T->spow);
    free(T);
}

static main_tables *main_tables_create(const ao_gtao_constants *k)
{
    main_tables *T = (main_tables *)calloc(1, sizeof *T);
    if (!T)
        return NULL;
    const int ns = k->slice_count, nt = k->steps_per_slice;
    T->cs = (float *)malloc(sizeof(float) * 4096u * (size_t)ns * 2u);
    T->spow = (float *)malloc(sizeof(float) * 4096u * (size_t)ns * (size_t)nt);
    if (!T->cs || !T->spow) {
        main_tables_free(T);
        return NULL;
    }
    const float slice_count = (float)ns, steps = (float)nt;
    for (uint32_t c = 0; c < 4096u; c++) {
        ao_gtao_noise(c & 63u, c >> 6, k->noise_index, T->noise[c]);
        const float noise_slice = T->noise[c][0], noise_sample = T->noise[c][1];
        for (int sl = 0; sl < ns; sl++) {
            const float slice = (float)sl;
            const float slice_k = (slice + noise_slice) / slice_count;
            const float phi = slice_k * 3.14159265358979323846f;
            float *cs = T->cs + ((size_t)c * (size_t)ns + (size_t)sl) * 2u;
            ao_i_cos_sin(phi, &cs[0], &cs[1]);
            float *sp = T->spow + ((size_t)c * (size_t)ns + (size_t)sl) * (size_t)nt;
            for (int st = 0; st < nt; st++) {
                const float step = (float)st;
                const float step_base = (slice + step * steps) * 0.6180339887498948482f;
                const float step_noise = hfrac(noise_sample + step_base);
                const float s = (step + step_noise) / steps;
                sp[st] = hpow(s, k->sample_distribution_power);
            }
        }
    }
    mip_thresholds(k->depth_mip_sampling_offset, T->mip_t);
    return T;
}

/* What main_pixel has computed per pixel when the slice loop starts. */
typedef struct px_setup {
    float n[3], C[3], V[3];
    float u, v, ssr, min_s, vis0;
    int cell;                       /* (y mod 64) * 64 + x mod 64 */
} px_setup;

/* main_pixel up to the slice loop: the edges, then 0 (background) or 2 (degenerate normal) with
 * *vis_out set, or 1 with S filled. */
static int pixel_setup(const ao_gtao_constants *k, const main_consts *mc, const obs_image_f32 *levels,
                       const ao_input *in, int x, int y, const float e[4], float *vis_out, px_setup *S)
{
    const obs_image_f32 *z0 = &levels[0];
    float viewspace_z = obs_image_f32_row(z0, y)[x];

    if (is_background(obs_image_f32_row(in->depth, y)[x])) {
        *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
        return 0;
    }
    float *n = S->n;
    if (k->normals_from_gbuffer) {
        n[0] = obs_image_f32_row(in->normal[0], y)[x];
        n[1] = obs_image_f32_row(in->normal[1], y)[x];
        n[2] = -obs_image_f32_row(in->normal[2], y)[x];
        const float l2 = dot3(n, n);
        if (!(l2 > 0.0f) || !isfinite(l2)) {
            *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
            return 2;
        }
        normalize3(n);
    } else if (!normal_from_depth_e(k, z0, x, y, e, n)) {
        *vis_out = k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
        return 2;
    }
    if (k->gpu_packing)
        normal_r11g11b10(n);

    viewspace_z = viewspace_z * AO_GTAO_CENTER_Z_PULL;
    const float psx = k->viewport_pixel_size[0], psy = k->viewport_pixel_size[1];
    S->u = ((float)x + 0.5f) * psx, S->v = ((float)y + 0.5f) * psy;
    view_pos(k, S->u, S->v, viewspace_z, S->C);
    float *V = S->V;
    V[0] = -S->C[0], V[1] = -S->C[1], V[2] = -S->C[2];
    if (k->orthographic)
        V[0] = 0.0f, V[1] = 0.0f, V[2] = -1.0f;
    else
        normalize3(V);
    S->cell = ((y & 63) << 6) | (x & 63);
    const float pixel_size_x = k->orthographic ? k->ndc_to_view_mul_x_pixel_size[0]
                                               : viewspace_z * k->ndc_to_view_mul_x_pixel_size[0];
    S->ssr = mc->effect_radius / pixel_size_x;
    S->vis0 = sat((10.0f - S->ssr) / 100.0f) * 0.5f;
    S->min_s = mc->min_s_num / S->ssr;
    return 1;
}

/* ---- The final power, x^2.2 without libm's pow (issue 12) -------------------------------------------
 * The reference is hpow(x, p) = (float)pow((double)x, (double)p), once per pixel. For p = 2.2f (the
 * default FinalValuePower; a = (double)2.2f = 2.2000000476837158..., not 2.2) and x in [2^-126, 2):
 * x = (t_i + d) 2^e with t_i = 1 + i/128 (the mantissa's top 7 bits), d < 2^-7 exact, r = d / t_i
 * (as d * T_INV[i]), and x^a = T_MANT[i] (1 + r)^a T_EXP[e], (1 + r)^a by its binomial series to
 * r^7 (truncation < |C(a, 8)| 2^-56 < 2^-62). In double: each table entry is the value rounded to
 * the nearest double (scripts/gen_gtao_pow22.py), r carries 2 roundings, the Horner steps with
 * |r| < 2^-7 about 2 ulps, the 2 products 1 each: y is within 8 * 2^-53 = 2^-50 of x^a (relative),
 * and glibc's pow within 0.52 ulp (2^-52.9; its documented bound since 2.28). Both lie in
 * [y (1 - 2^-48), y (1 + 2^-48)] (the bounds as computed: y 2^-48 is exact, the sum rounds by at most
 * 2^-53 y). Rounding to float is monotone, so where both ends of that interval round to the same
 * float, pow's double rounds to that float too: we return it. Elsewhere (x^a within 2^-48 of a
 * float rounding boundary: a fraction of about 2^-23 of the inputs) and outside the domain we call
 * hpow itself. So the result is hpow's bit for bit, as long as libm's pow keeps its 0.52 ulp; it
 * was checked for every float in [0, 2] against glibc (scripts/gtao_final_power_check.c: 0
 * differences among 1,073,741,825 inputs) and gtao_final_power_equals_libm_pow checks a dense
 * sample. Costs about 25 instructions instead of glibc's ~125. */
/* generated by scripts/gen_gtao_pow22.py: a = (double)2.2f = 2.200000047683716 */
static const double POW22_T_MANT[128] = {
    0x1.0000000000000p+0, 0x1.046baeca0b63ep+0, 0x1.08e1f125b78cdp+0, 0x1.0d62cb42576b5p+0,
    0x1.11ee4148ab51fp+0, 0x1.1684575af8020p+0, 0x1.1b2511951d3bcp+0, 0x1.1fd0740cabd54p+0,
    0x1.248682d0fb5b9p+0, 0x1.294741eb3f414p+0, 0x1.2e12b55e9b9d7p+0, 0x1.32e8e128397f5p+0,
    0x1.37c9c93f5ad74p+0, 0x1.3cb571956dfacp+0, 0x1.41abde1620c39p+0, 0x1.46ad12a7734f1p+0,
    0x1.4bb91329ca5e2p+0, 0x1.50cfe3780159fp+0, 0x1.55f187677bff1p+0, 0x1.5b1e02c837b18p+0,
    0x1.60555964dc7b8p+0, 0x1.65978f02cdba9p+0, 0x1.6ae4a7623a7aep+0, 0x1.703ca63e2d853p+0,
    0x1.759f8f4c9d1f6p+0, 0x1.7b0d663e7a833p+0, 0x1.80862ebfc10b8p+0, 0x1.8609ec77851b4p+0,
    0x1.8b98a30802befp+0, 0x1.9132560eac0a7p+0, 0x1.96d7092437359p+0, 0x1.9c86bfdcac77ap+0,
    0x1.a2417dc773a4bp+0, 0x1.a807466f618dep+0, 0x1.add81d5ac5251p+0, 0x1.b3b4060b74672p+0,
    0x1.b99b03fed90c9p+0, 0x1.bf8d1aadfd02dp+0, 0x1.c58a4d8d96aedp+0, 0x1.cb92a00e14fafp+0,
    0x1.d1a6159bab306p+0, 0x1.d7c4b19e5c9e7p+0, 0x1.ddee777a080fcp+0, 0x1.e4236a8e730f0p+0,
    0x1.ea638e3754fcdp+0, 0x1.f0aee5cc61f67p+0, 0x1.f70574a1558ffp+0, 0x1.fd673e05fd613p+0,
    0x1.01ea22a321b44p+1, 0x1.052646d51c20ep+1, 0x1.08680d3b0e9a7p+1, 0x1.0baf7775370d9p+1,
    0x1.0efc8721f58e7p+1, 0x1.124f3dddd1246p+1, 0x1.15a79d437c81dp+1, 0x1.1905a6ebdaaa5p+1,
    0x1.1c695c6e0385fp+1, 0x1.1fd2bf5f4862cp+1, 0x1.2341d1533864cp+1, 0x1.26b693dba4e51p+1,
    0x1.2a310888a5bfbp+1, 0x1.2db130e89d914p+1, 0x1.31370e883de48p+1, 0x1.34c2a2f28b4ffp+1,
    0x1.3853efb0e183dp+1, 0x1.3beaf64af7498p+1, 0x1.3f87b846e2730p+1, 0x1.432a37291bbd1p+1,
    0x1.46d2747482a20p+1, 0x1.4a8071aa611ecp+1, 0x1.4e34304a6f6aap+1, 0x1.51edb1d2d7a0ep+1,
    0x1.55acf7c0395d8p+1, 0x1.5972038dad4d0p+1, 0x1.5d3cd6b4c8af1p+1, 0x1.610d72ada0cd4p+1,
    0x1.64e3d8eece650p+1, 0x1.68c00aed7105fp+1, 0x1.6ca20a1d32641p+1, 0x1.7089d7f0499e6p+1,
    0x1.747775d77e7aap+1, 0x1.786ae5422c953p+1, 0x1.7c64279e46864p+1, 0x1.80633e5858fc8p+1,
    0x1.84682adb8dccep+1, 0x1.8872ee91aef81p+1, 0x1.8c838ae329a5cp+1, 0x1.909a013711162p+1,
    0x1.94b652f321890p+1, 0x1.98d8817bc31bfp+1, 0x1.9d008e340c9e4p+1, 0x1.a12e7a7dc65c3p+1,
    0x1.a56247b96ce09p+1, 0x1.a99bf74633adbp+1, 0x1.addb8a8207ed2p+1, 0x1.b22102c993172p+1,
    0x1.b66c61783d913p+1, 0x1.babda7e831446p+1, 0x1.bf14d7725c2b4p+1, 0x1.c371f16e72d80p+1,
    0x1.c7d4f732f2f1fp+1, 0x1.cc3dea1525abep+1, 0x1.d0accb6922328p+1, 0x1.d5219c81d012cp+1,
    0x1.d99c5eb0e9995p+1, 0x1.de1d1346fe2a8p+1, 0x1.e2a3bb9374930p+1, 0x1.e73058e48d514p+1,
    0x1.ebc2ec8764d83p+1, 0x1.f05b77c7f5cadp+1, 0x1.f4f9fbf11b313p+1, 0x1.f99e7a4c92a6cp+1,
    0x1.fe48f422fe81ep+1, 0x1.017cb55df3fa9p+2, 0x1.03d7efaee0954p+2, 0x1.063629a6f3abbp+2,
    0x1.089763e85265dp+2, 0x1.0afb9f14997cfp+2, 0x1.0d62dbccde3d0p+2, 0x1.0fcd1ab1af82dp+2,
    0x1.123a5c6316b76p+2, 0x1.14aaa18098c8cp+2, 0x1.171deaa9371fap+2, 0x1.1994387b70923p+2,
    0x1.1c0d8b954254bp+2, 0x1.1e89e49428e70p+2, 0x1.2109441520ff4p+2, 0x1.238baab4a872dp+2};
static const double POW22_T_INV[128] = {
    0x1.0000000000000p+0, 0x1.fc07f01fc07f0p-1, 0x1.f81f81f81f820p-1, 0x1.f44659e4a4271p-1,
    0x1.f07c1f07c1f08p-1, 0x1.ecc07b301ecc0p-1, 0x1.e9131abf0b767p-1, 0x1.e573ac901e574p-1,
    0x1.e1e1e1e1e1e1ep-1, 0x1.de5d6e3f8868ap-1, 0x1.dae6076b981dbp-1, 0x1.d77b654b82c34p-1,
    0x1.d41d41d41d41dp-1, 0x1.d0cb58f6ec074p-1, 0x1.cd85689039b0bp-1, 0x1.ca4b3055ee191p-1,
    0x1.c71c71c71c71cp-1, 0x1.c3f8f01c3f8f0p-1, 0x1.c0e070381c0e0p-1, 0x1.bdd2b899406f7p-1,
    0x1.bacf914c1bad0p-1, 0x1.b7d6c3dda338bp-1, 0x1.b4e81b4e81b4fp-1, 0x1.b2036406c80d9p-1,
    0x1.af286bca1af28p-1, 0x1.ac5701ac5701bp-1, 0x1.a98ef606a63bep-1, 0x1.a6d01a6d01a6dp-1,
    0x1.a41a41a41a41ap-1, 0x1.a16d3f97a4b02p-1, 0x1.9ec8e951033d9p-1, 0x1.9c2d14ee4a102p-1,
    0x1.999999999999ap-1, 0x1.970e4f80cb872p-1, 0x1.948b0fcd6e9e0p-1, 0x1.920fb49d0e229p-1,
    0x1.8f9c18f9c18fap-1, 0x1.8d3018d3018d3p-1, 0x1.8acb90f6bf3aap-1, 0x1.886e5f0abb04ap-1,
    0x1.8618618618618p-1, 0x1.83c977ab2beddp-1, 0x1.8181818181818p-1, 0x1.7f405fd017f40p-1,
    0x1.7d05f417d05f4p-1, 0x1.7ad2208e0ecc3p-1, 0x1.78a4c8178a4c8p-1, 0x1.767dce434a9b1p-1,
    0x1.745d1745d1746p-1, 0x1.724287f46debcp-1, 0x1.702e05c0b8170p-1, 0x1.6e1f76b4337c7p-1,
    0x1.6c16c16c16c17p-1, 0x1.6a13cd1537290p-1, 0x1.6816816816817p-1, 0x1.661ec6a5122f9p-1,
    0x1.642c8590b2164p-1, 0x1.623fa77016240p-1, 0x1.6058160581606p-1, 0x1.5e75bb8d015e7p-1,
    0x1.5c9882b931057p-1, 0x1.5ac056b015ac0p-1, 0x1.58ed2308158edp-1, 0x1.571ed3c506b3ap-1,
    0x1.5555555555555p-1, 0x1.5390948f40febp-1, 0x1.51d07eae2f815p-1, 0x1.5015015015015p-1,
    0x1.4e5e0a72f0539p-1, 0x1.4cab88725af6ep-1, 0x1.4afd6a052bf5bp-1, 0x1.49539e3b2d067p-1,
    0x1.47ae147ae147bp-1, 0x1.460cbc7f5cf9ap-1, 0x1.446f86562d9fbp-1, 0x1.42d6625d51f87p-1,
    0x1.4141414141414p-1, 0x1.3fb013fb013fbp-1, 0x1.3e22cbce4a902p-1, 0x1.3c995a47babe7p-1,
    0x1.3b13b13b13b14p-1, 0x1.3991c2c187f63p-1, 0x1.3813813813814p-1, 0x1.3698df3de0748p-1,
    0x1.3521cfb2b78c1p-1, 0x1.33ae45b57bcb2p-1, 0x1.323e34a2b10bfp-1, 0x1.30d190130d190p-1,
    0x1.2f684bda12f68p-1, 0x1.2e025c04b8097p-1, 0x1.2c9fb4d812ca0p-1, 0x1.2b404ad012b40p-1,
    0x1.29e4129e4129ep-1, 0x1.288b01288b013p-1, 0x1.27350b8812735p-1, 0x1.25e22708092f1p-1,
    0x1.2492492492492p-1, 0x1.23456789abcdfp-1, 0x1.21fb78121fb78p-1, 0x1.20b470c67c0d9p-1,
    0x1.1f7047dc11f70p-1, 0x1.1e2ef3b3fb874p-1, 0x1.1cf06ada2811dp-1, 0x1.1bb4a4046ed29p-1,
    0x1.1a7b9611a7b96p-1, 0x1.19453808ca29cp-1, 0x1.1811811811812p-1, 0x1.16e0689427379p-1,
    0x1.15b1e5f75270dp-1, 0x1.1485f0e0acd3bp-1, 0x1.135c81135c811p-1, 0x1.12358e75d3033p-1,
    0x1.1111111111111p-1, 0x1.0fef010fef011p-1, 0x1.0ecf56be69c90p-1, 0x1.0db20a88f4696p-1,
    0x1.0c9714fbcda3bp-1, 0x1.0b7e6ec259dc8p-1, 0x1.0a6810a6810a7p-1, 0x1.0953f39010954p-1,
    0x1.0842108421084p-1, 0x1.073260a47f7c6p-1, 0x1.0624dd2f1a9fcp-1, 0x1.05197f7d73404p-1,
    0x1.0410410410410p-1, 0x1.03091b51f5e1ap-1, 0x1.0204081020408p-1, 0x1.0101010101010p-1};
static const double POW22_T_EXP[127] = {
    0x1.bdb854078f411p-278, 0x1.ffff755ef00afp-276, 0x1.2610c96fa1cfep-273, 0x1.51caeb3c285b8p-271,
    0x1.840599b0fb942p-269, 0x1.bdb858db5ba76p-267, 0x1.ffff7aea7f520p-265, 0x1.2610cc9ef47d7p-262,
    0x1.51caeee4b7c31p-260, 0x1.84059de4ced25p-258, 0x1.bdb85daf281b2p-256, 0x1.ffff80760ea87p-254,
    0x1.2610cfce4733cp-251, 0x1.51caf28d4734dp-249, 0x1.8405a218a21c2p-247, 0x1.bdb86282f49c3p-245,
    0x1.ffff86019e0e4p-243, 0x1.2610d2fd99f30p-240, 0x1.51caf635d6b0bp-238, 0x1.8405a64c7571ap-236,
    0x1.bdb86756c12abp-234, 0x1.ffff8b8d2d837p-232, 0x1.2610d62cecbb0p-229, 0x1.51caf9de6636cp-227,
    0x1.8405aa8048d2cp-225, 0x1.bdb86c2a8dc69p-223, 0x1.ffff9118bd080p-221, 0x1.2610d95c3f8bep-218,
    0x1.51cafd86f5c6ep-216, 0x1.8405aeb41c3f8p-214, 0x1.bdb870fe5a6fep-212, 0x1.ffff96a44c9bfp-210,
    0x1.2610dc8b92659p-207, 0x1.51cb012f85613p-205, 0x1.8405b2e7efb7fp-203, 0x1.bdb875d227268p-201,
    0x1.ffff9c2fdc3f4p-199, 0x1.2610dfbae5481p-196, 0x1.51cb04d81505bp-194, 0x1.8405b71bc33c0p-192,
    0x1.bdb87aa5f3ea9p-190, 0x1.ffffa1bb6bf1fp-188, 0x1.2610e2ea38337p-185, 0x1.51cb0880a4b44p-183,
    0x1.8405bb4f96cbcp-181, 0x1.bdb87f79c0bbfp-179, 0x1.ffffa746fbb40p-177, 0x1.2610e6198b27ap-174,
    0x1.51cb0c29346d0p-172, 0x1.8405bf836a672p-170, 0x1.bdb8844d8d9acp-168, 0x1.ffffacd28b857p-166,
    0x1.2610e948de24ap-163, 0x1.51cb0fd1c42fep-161, 0x1.8405c3b73e0e3p-159, 0x1.bdb889215a86fp-157,
    0x1.ffffb25e1b664p-155, 0x1.2610ec78312a8p-152, 0x1.51cb137a53fcfp-150, 0x1.8405c7eb11c0dp-148,
    0x1.bdb88df527808p-146, 0x1.ffffb7e9ab567p-144, 0x1.2610efa784393p-141, 0x1.51cb1722e3d42p-139,
    0x1.8405cc1ee57f3p-137, 0x1.bdb892c8f4877p-135, 0x1.ffffbd753b560p-133, 0x1.2610f2d6d750bp-130,
    0x1.51cb1acb73b57p-128, 0x1.8405d052b9493p-126, 0x1.bdb8979cc19bdp-124, 0x1.ffffc300cb64fp-122,
    0x1.2610f6062a710p-119, 0x1.51cb1e7403a0ep-117, 0x1.8405d4868d1edp-115, 0x1.bdb89c708ebd8p-113,
    0x1.ffffc88c5b834p-111, 0x1.2610f9357d9a3p-108, 0x1.51cb221c93968p-106, 0x1.8405d8ba61002p-104,
    0x1.bdb8a1445becap-102, 0x1.ffffce17ebb0fp-100, 0x1.2610fc64d0cc3p-97, 0x1.51cb25c523964p-95,
    0x1.8405dcee34ed1p-93, 0x1.bdb8a61829292p-91, 0x1.ffffd3a37bee0p-89, 0x1.2610ff9424070p-86,
    0x1.51cb296db3a02p-84, 0x1.8405e12208e5ap-82, 0x1.bdb8aaebf6730p-80, 0x1.ffffd92f0c3a7p-78,
    0x1.261102c3774aap-75, 0x1.51cb2d1643b42p-73, 0x1.8405e555dce9ep-71, 0x1.bdb8afbfc3ca4p-69,
    0x1.ffffdeba9c964p-67, 0x1.261105f2ca972p-64, 0x1.51cb30bed3d25p-62, 0x1.8405e989b0f9dp-60,
    0x1.bdb8b493912eep-58, 0x1.ffffe4462d017p-56, 0x1.261109221dec7p-53, 0x1.51cb346763faap-51,
    0x1.8405edbd85155p-49, 0x1.bdb8b9675ea0fp-47, 0x1.ffffe9d1bd7c0p-45, 0x1.26110c51714aap-42,
    0x1.51cb380ff42d2p-40, 0x1.8405f1f1593c9p-38, 0x1.bdb8be3b2c206p-36, 0x1.ffffef5d4e05fp-34,
    0x1.26110f80c4b19p-31, 0x1.51cb3bb88469bp-29, 0x1.8405f6252d6f6p-27, 0x1.bdb8c30ef9ad2p-25,
    0x1.fffff4e8de9f4p-23, 0x1.261112b018216p-20, 0x1.51cb3f6114b07p-18, 0x1.8405fa5901adep-16,
    0x1.bdb8c7e2c7475p-14, 0x1.fffffa746f47fp-12, 0x1.261115df6b9a0p-9, 0x1.51cb4309a5016p-7,
    0x1.8405fe8cd5f81p-5, 0x1.bdb8ccb694eeep-3, 0x1.0000000000000p+0};
static const double POW22_C[7] = {0x1.19999a0000000p+1, 0x1.51eb867ae1480p+0, 0x1.6872b735ee465p-4, -0x1.205bc4a462d8ep-6, 0x1.9f3c769a910c6p-8, -0x1.838dc398ffc9dp-9, 0x1.a4c5ccb3edfedp-10};

float ao_gtao_final_power(float x, float p)
{
    if (f2u(p) == f2u(2.2f) && x >= 0x1p-126f && x < 2.0f) {
        const uint32_t u = f2u(x);
        const int e = (int)(u >> 23) - 127; /* -126 .. 0 */
        const uint32_t mb = u & 0x7FFFFFu;
        const int i = (int)(mb >> 16);
        const double r = (double)(mb & 0xFFFFu) * 0x1p-23 * POW22_T_INV[i];
        double q = POW22_C[6];
        for (int c = 5; c >= 0; c--)
            q = POW22_C[c] + r * q;
        const double y = (POW22_T_MANT[i] * (1.0 + r * q)) * POW22_T_EXP[e + 126];
        const double tol = y * 0x1p-48;
        const float lo = (float)(y - tol), hi = (float)(y + tol);
        if (lo == hi)
            return lo;
    }
    return hpow(x, p);
}

/* main_pixel after the slice loop: the mean, the power, the floor and the working-term store. */
static void pixel_finish(const ao_gtao_constants *k, float visibility, float *vis_out)
{
    visibility = visibility / (float)k->slice_count;
    visibility = ao_gtao_final_power(visibility, k->final_value_power); /* = hpow, bit for bit */
    visibility = hmax_fast(0.03f, visibility);
    if (k->gpu_packing)
        *vis_out = unorm8(sat(visibility / AO_GTAO_OCCLUSION_TERM_SCALE));
    else
        *vis_out = visibility < AO_GTAO_OCCLUSION_TERM_SCALE ? visibility : AO_GTAO_OCCLUSION_TERM_SCALE;
}

/* main_pixel's slice loop with the tables (same result bits): the visibility sum. */
static float pixel_slices(const ao_gtao_constants *k, const main_consts *mc, const main_tables *T,
                          const obs_image_f32 *levels, const px_setup *S)
{
    const float *n = S->n, *C = S->C, *V = S->V;
    const float u = S->u, v = S->v, ssr = S->ssr, min_s = S->min_s;
    const float psx = k->viewport_pixel_size[0], psy = k->viewport_pixel_size[1];
    const int cell = S->cell;
    float visibility = S->vis0;
    const int ns = k->slice_count, nt = k->steps_per_slice;
    const float *cs_cell = T->cs + (size_t)cell * (size_t)ns * 2u;
    const float *sp_cell = T->spow + (size_t)cell * (size_t)ns * (size_t)nt;

    const int thin = mc->thin_scale != 1.0f; /* z * 1 is exact: the falloff distance is the distance */
    /* view_pos of a tap, split: a = mul * u + add, then * z (perspective) */
    const float mx = k->ndc_to_view_mul[0], my = k->ndc_to_view_mul[1];
    const float ax = k->ndc_to_view_add[0], ay = k->ndc_to_view_add[1];
    const int ortho_proj = k->orthographic;

    for (int sl = 0; sl < ns; sl++) {
        const float cos_phi = cs_cell[2 * sl], sin_phi = cs_cell[2 * sl + 1];
        const float omega[2] = {cos_phi * ssr, -sin_phi * ssr};
        const float dir[3] = {cos_phi, sin_phi, 0.0f};
        const float dv = dot3(dir, V);
        const float ortho[3] = {dir[0] - dv * V[0], dir[1] - dv * V[1], dir[2] - dv * V[2]};
        float axis[3];
        cross3(ortho, V, axis);
        normalize3(axis);
        const float na = dot3(n, axis);
        const float pn[3] = {n[0] - axis[0] * na, n[1] - axis[1] * na, n[2] - axis[2] * na};
        const float sign_norm = hsign(dot3(ortho, pn));
        float pn_len = len3(pn);
        const float cos_norm = sat(dot3(pn, V) / pn_len);
        const float nang = sign_norm * ao_gtao_fast_acos(cos_norm);
        const float low0 = hcos_fast(nang + 1.57079632679489661923f);
        const float low1 = hcos_fast(nang - 1.57079632679489661923f);
        float hc0 = low0, hc1 = low1;
        const float *sp = sp_cell + (size_t)sl * (size_t)nt;

        for (int st = 0; st < nt; st++) {
            const float s = sp[st] + min_s;
            float off[2] = {s * omega[0], s * omega[1]};
            const float off_len = sqrtf(off[0] * off[0] + off[1] * off[1]);
            const int li = mip_from_thresholds(off_len, T->mip_t);
            off[0] = rintf(off[0]) * psx;
            off[1] = rintf(off[1]) * psy;
            const obs_image_f32 *L = &levels[li];
            const float u0 = u + off[0], v0 = v + off[1], u1 = u - off[0], v1 = v - off[1];
            const float sz0 = obs_image_f32_row(L, texel(v0, L->height))[texel(u0, L->width)];
            const float sz1 = obs_image_f32_row(L, texel(v1, L->height))[texel(u1, L->width)];
            const float a0 = mx * u0 + ax, b0 = my * v0 + ay, a1 = mx * u1 + ax, b1 = my * v1 + ay;
            const float d0[3] = {(ortho_proj ? a0 : a0 * sz0) - C[0], (ortho_proj ? b0 : b0 * sz0) - C[1], sz0 - C[2]};
            const float d1[3] = {(ortho_proj ? a1 : a1 * sz1) - C[0], (ortho_proj ? b1 : b1 * sz1) - C[1], sz1 - C[2]};
            const float dist0 = len3(d0), dist1 = len3(d1);
            const float hv0[3] = {d0[0] / dist0, d0[1] / dist0, d0[2] / dist0};
            const float hv1[3] = {d1[0] / dist1, d1[1] / dist1, d1[2] / dist1};
            float fl0 = dist0, fl1 = dist1;
            if (thin) {
                const float fb0[3] = {d0[0], d0[1], d0[2] * mc->thin_scale};
                const float fb1[3] = {d1[0], d1[1], d1[2] * mc->thin_scale};
                fl0 = len3(fb0), fl1 = len3(fb1);
            }
            const float w0 = sat(fl0 * mc->falloff_mul + mc->falloff_add);
            const float w1 = sat(fl1 * mc->falloff_mul + mc->falloff_add);
            float shc0 = dot3(hv0, V), shc1 = dot3(hv1, V);
            shc0 = hlerp(low0, shc0, w0);
            shc1 = hlerp(low1, shc1, w1);
            hc0 = hmax_fast(hc0, shc0);
            hc1 = hmax_fast(hc1, shc1);
        }

        pn_len = hlerp(pn_len, 1.0f, 0.05f);
        const float h0 = -ao_gtao_fast_acos(hc1);
        const float h1 = ao_gtao_fast_acos(hc0);
        const float sin_n = hsin_fast(nang);
        const float iarc0 = (cos_norm + 2.0f * h0 * sin_n - hcos_fast(2.0f * h0 - nang)) / 4.0f;
        const float iarc1 = (cos_norm + 2.0f * h1 * sin_n - hcos_fast(2.0f * h1 - nang)) / 4.0f;
        visibility = visibility + pn_len * (iarc0 + iarc1);
    }
    return visibility;
}


/* ---- The 8-lane slice loop (AVX2) ------------------------------------------------------------------
 * Lane l is the l-th pixel of a row that needs a slice loop (its px_setup). Every lane does
 * pixel_slices' float operations in its order with the IEEE single-rounding vector forms (add,
 * sub, mul, div, sqrt; round-to-nearest-even; truncating converts; compares and blends for the
 * branches), no FMA (the target is "avx2" without "fma"; -ffp-contract=off), and the cosines in
 * double with the same reduction and polynomial: so the same bits as the scalar loop, which the
 * tests check. The depth taps are scalar loads (the MIP level differs per lane). */
#if GTAO_AVX2

AVX2_FN static inline __m256 v_sign(__m256 v)
{
    const __m256 zero = _mm256_setzero_ps();
    const __m256 neg = _mm256_blendv_ps(zero, _mm256_set1_ps(-1.0f), _mm256_cmp_ps(v, zero, _CMP_LT_OQ));
    return _mm256_blendv_ps(neg, _mm256_set1_ps(1.0f), _mm256_cmp_ps(v, zero, _CMP_GT_OQ));
}

/* ao_gtao_fast_acos */
AVX2_FN static inline __m256 v_fast_acos(__m256 in_x)
{
    const __m256 x = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), in_x);
    __m256 res = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(-0.156583f), x), _mm256_set1_ps(1.570796f));
    const __m256i i = _mm256_castps_si256(_mm256_sub_ps(_mm256_set1_ps(1.0f), x));
    const __m256 fs = _mm256_castsi256_ps(_mm256_add_epi32(_mm256_set1_epi32(0x1fbd1df5), _mm256_srai_epi32(i, 1)));
    res = _mm256_mul_ps(res, fs);
    const __m256 ge = _mm256_cmp_ps(in_x, _mm256_setzero_ps(), _CMP_GE_OQ);
    return _mm256_blendv_ps(_mm256_sub_ps(_mm256_set1_ps(3.141593f), res), res, ge);
}

/* hmax_fast(a, b) where a is never NaN here (the running horizon cosine and 0.03): b NaN gives a */
AVX2_FN static inline __m256 v_max_a(__m256 a, __m256 b)
{
    const __m256 take_a = _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_GT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q));
    return _mm256_blendv_ps(b, a, take_a);
}

/* cos_or_sin of 4 angles (double) with the quadrant offset add (0 cos, 3 sin) */
AVX2_FN static inline __m128 v_cos_or_sin4(__m256d x, int add)
{
    const __m256d rounder = _mm256_set1_pd(CS_ROUNDER);
    const __m256d kd = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(x, _mm256_set1_pd(CS_TWO_OVER_PI)), rounder), rounder);
    __m256d r = _mm256_sub_pd(x, _mm256_mul_pd(kd, _mm256_set1_pd(CS_P1)));
    r = _mm256_sub_pd(r, _mm256_mul_pd(kd, _mm256_set1_pd(CS_P2)));
    r = _mm256_sub_pd(r, _mm256_mul_pd(kd, _mm256_set1_pd(CS_P3)));
    r = _mm256_sub_pd(r, _mm256_mul_pd(kd, _mm256_set1_pd(CS_P4)));
    const __m256d z = _mm256_mul_pd(r, r);
#define C_(v) _mm256_set1_pd(v)
#define A_(a, b) _mm256_add_pd(a, b)
#define M_(a, b) _mm256_mul_pd(a, b)
    /* sn = r + r * z * (-1/6 + z * (1/120 + ... )) */
    __m256d ps = C_(-1.0 / 121645100408832000.0);
    ps = A_(C_(1.0 / 355687428096000.0), M_(z, ps));
    ps = A_(C_(-1.0 / 1307674368000.0), M_(z, ps));
    ps = A_(C_(1.0 / 6227020800.0), M_(z, ps));
    ps = A_(C_(-1.0 / 39916800.0), M_(z, ps));
    ps = A_(C_(1.0 / 362880.0), M_(z, ps));
    ps = A_(C_(-1.0 / 5040.0), M_(z, ps));
    ps = A_(C_(1.0 / 120.0), M_(z, ps));
    ps = A_(C_(-1.0 / 6.0), M_(z, ps));
    const __m256d sn = A_(r, M_(M_(r, z), ps));
    /* cs = 1 - 0.5 z + z * z * (1/24 + z * (-1/720 + ...)) */
    __m256d pc = C_(1.0 / 2432902008176640000.0);
    pc = A_(C_(-1.0 / 6402373705728000.0), M_(z, pc));
    pc = A_(C_(1.0 / 20922789888000.0), M_(z, pc));
    pc = A_(C_(-1.0 / 87178291200.0), M_(z, pc));
    pc = A_(C_(1.0 / 479001600.0), M_(z, pc));
    pc = A_(C_(-1.0 / 3628800.0), M_(z, pc));
    pc = A_(C_(1.0 / 40320.0), M_(z, pc));
    pc = A_(C_(-1.0 / 720.0), M_(z, pc));
    pc = A_(C_(1.0 / 24.0), M_(z, pc));
    const __m256d cs = A_(_mm256_sub_pd(C_(1.0), M_(C_(0.5), z)), M_(M_(z, z), pc));
#undef C_
#undef A_
#undef M_
    /* q 0: cs, 1: -sn, 2: -cs, 3: sn */
    const __m128i q = _mm_and_si128(_mm_add_epi32(_mm256_cvtpd_epi32(kd), _mm_set1_epi32(add)), _mm_set1_epi32(3));
    const __m128i odd = _mm_cmpeq_epi32(_mm_and_si128(q, _mm_set1_epi32(1)), _mm_set1_epi32(1));
    const __m128i neg = _mm_cmpeq_epi32(_mm_and_si128(_mm_xor_si128(q, _mm_srli_epi32(q, 1)), _mm_set1_epi32(1)),
                                        _mm_set1_epi32(1));
    __m256d v = _mm256_blendv_pd(cs, sn, _mm256_castsi256_pd(_mm256_cvtepi32_epi64(odd)));
    v = _mm256_xor_pd(v, _mm256_and_pd(_mm256_castsi256_pd(_mm256_cvtepi32_epi64(neg)), _mm256_set1_pd(-0.0)));
    return _mm256_cvtpd_ps(v);
}

/* hcos_fast / hsin_fast of 8 floats; lanes outside the polynomial's range go to the scalar form */
AVX2_FN static inline __m256 v_cos_or_sin(__m256 a, int which)
{
    const int add = which ? 3 : 0;
    const __m128 lo = v_cos_or_sin4(_mm256_cvtps_pd(_mm256_castps256_ps128(a)), add);
    const __m128 hi = v_cos_or_sin4(_mm256_cvtps_pd(_mm256_extractf128_ps(a, 1)), add);
    __m256 r = _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
    const __m256 absa = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), a);
    const int bad = _mm256_movemask_ps(_mm256_cmp_ps(absa, _mm256_set1_ps(3.0e9f), _CMP_NLT_UQ));
    if (bad) {
        float av[8], rv[8];
        _mm256_storeu_ps(av, a);
        _mm256_storeu_ps(rv, r);
        for (int l = 0; l < 8; l++)
            if (bad & (1 << l))
                rv[l] = cos_or_sin(av[l], which);
        r = _mm256_loadu_ps(rv);
    }
    return r;
}

/* texel() of 8 lanes: floor(uv * size) clamped, NaN and negative -> 0 */
AVX2_FN static inline __m256i v_texel(__m256 uv, __m256i size)
{
    const __m256 sf = _mm256_cvtepi32_ps(size);
    const __m256 t = _mm256_mul_ps(uv, sf);
    const __m256i ti = _mm256_cvttps_epi32(t);
    const __m256i last = _mm256_sub_epi32(size, _mm256_set1_epi32(1));
    __m256i r = _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(ti), _mm256_castsi256_ps(last),
                                                     _mm256_cmp_ps(t, sf, _CMP_GE_OQ)));
    r = _mm256_andnot_si256(_mm256_castps_si256(_mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_NGE_UQ)), r);
    return r;
}

/* The pending lanes of a row in structure-of-arrays form: what pixel_setup gives per pixel, lane l
 * of field f in t[f][l] (lanes 0..7 run next; 8..15 take the overflow of an 8-pixel set-up). */
enum { LN_N0, LN_N1, LN_N2, LN_C0, LN_C1, LN_C2, LN_V0, LN_V1, LN_V2, LN_U, LN_V, LN_SSR, LN_MIN_S, LN_VIS0,
       LN_FIELDS };
typedef struct lanes8 {
    float t[LN_FIELDS][16];
    int cell[16];
    int idx[16];                    /* the pixel's index in the row */
    int na;                         /* pending lanes */
} lanes8;

AVX2_FN static void slices_avx2(const ao_gtao_constants *k, const main_consts *mc, const main_tables *T,
                                const obs_image_f32 *levels, const lanes8 *P, float out[8])
{
    const float(*t)[16] = P->t;
    const int *cells = P->cell;
#define LD(i) _mm256_loadu_ps(t[i])
    const __m256 n0 = LD(0), n1 = LD(1), n2 = LD(2), C0 = LD(3), C1 = LD(4), C2 = LD(5);
    const __m256 V0 = LD(6), V1 = LD(7), V2 = LD(8), u = LD(9), v = LD(10), ssr = LD(11), min_s = LD(12);
    __m256 visibility = LD(13);
#undef LD
    const int ns = k->slice_count, nt = k->steps_per_slice;
    const __m256i cell = _mm256_loadu_si256((const __m256i *)cells);
    const __m256i cs_base = _mm256_mullo_epi32(cell, _mm256_set1_epi32(2 * ns));
    const __m256i sp_base = _mm256_mullo_epi32(cell, _mm256_set1_epi32(ns * nt));
    const __m256 psx = _mm256_set1_ps(k->viewport_pixel_size[0]), psy = _mm256_set1_ps(k->viewport_pixel_size[1]);
    const __m256 mx = _mm256_set1_ps(k->ndc_to_view_mul[0]), my = _mm256_set1_ps(k->ndc_to_view_mul[1]);
    const __m256 ax = _mm256_set1_ps(k->ndc_to_view_add[0]), ay = _mm256_set1_ps(k->ndc_to_view_add[1]);
    const __m256 fmul = _mm256_set1_ps(mc->falloff_mul), fadd = _mm256_set1_ps(mc->falloff_add);
    const __m256 thin_scale = _mm256_set1_ps(mc->thin_scale);
    const int thin = mc->thin_scale != 1.0f, ortho_proj = k->orthographic;
    const __m256 zero = _mm256_setzero_ps();
    int wl[8] = {0}, hl[8] = {0};
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS; l++)
        wl[l] = levels[l].width, hl[l] = levels[l].height;
    const __m256i Wl = _mm256_loadu_si256((const __m256i *)wl), Hl = _mm256_loadu_si256((const __m256i *)hl);
    const __m256 mt0 = _mm256_set1_ps(T->mip_t[0]), mt1 = _mm256_set1_ps(T->mip_t[1]);
    const __m256 mt2 = _mm256_set1_ps(T->mip_t[2]), mt3 = _mm256_set1_ps(T->mip_t[3]);
#define ADD _mm256_add_ps
#define SUB _mm256_sub_ps
#define MUL _mm256_mul_ps
#define DIV _mm256_div_ps
#define DOT3(a0, a1, a2, b0, b1, b2) ADD(ADD(MUL(a0, b0), MUL(a1, b1)), MUL(a2, b2))

    for (int sl = 0; sl < ns; sl++) {
        const __m256 cos_phi = _mm256_i32gather_ps(T->cs, _mm256_add_epi32(cs_base, _mm256_set1_epi32(2 * sl)), 4);
        const __m256 sin_phi = _mm256_i32gather_ps(T->cs, _mm256_add_epi32(cs_base, _mm256_set1_epi32(2 * sl + 1)), 4);
        const __m256 om0 = MUL(cos_phi, ssr), om1 = MUL(_mm256_xor_ps(sin_phi, _mm256_set1_ps(-0.0f)), ssr);
        const __m256 dv = DOT3(cos_phi, sin_phi, zero, V0, V1, V2);
        const __m256 o0 = SUB(cos_phi, MUL(dv, V0)), o1 = SUB(sin_phi, MUL(dv, V1)), o2 = SUB(zero, MUL(dv, V2));
        /* cross3(ortho, V), normalize3 */
        __m256 x0 = SUB(MUL(o1, V2), MUL(o2, V1)), x1 = SUB(MUL(o2, V0), MUL(o0, V2)), x2 = SUB(MUL(o0, V1), MUL(o1, V0));
        const __m256 xl = _mm256_sqrt_ps(DOT3(x0, x1, x2, x0, x1, x2));
        x0 = DIV(x0, xl), x1 = DIV(x1, xl), x2 = DIV(x2, xl);
        const __m256 na = DOT3(n0, n1, n2, x0, x1, x2);
        const __m256 p0 = SUB(n0, MUL(x0, na)), p1 = SUB(n1, MUL(x1, na)), p2 = SUB(n2, MUL(x2, na));
        const __m256 sign_norm = v_sign(DOT3(o0, o1, o2, p0, p1, p2));
        __m256 pn_len = _mm256_sqrt_ps(DOT3(p0, p1, p2, p0, p1, p2));
        const __m256 cos_norm = v_sat(DIV(DOT3(p0, p1, p2, V0, V1, V2), pn_len));
        const __m256 nang = MUL(sign_norm, v_fast_acos(cos_norm));
        const __m256 low0 = v_cos_or_sin(ADD(nang, _mm256_set1_ps(1.57079632679489661923f)), 0);
        const __m256 low1 = v_cos_or_sin(SUB(nang, _mm256_set1_ps(1.57079632679489661923f)), 0);
        __m256 hc0 = low0, hc1 = low1;

        for (int st = 0; st < nt; st++) {
            const __m256 sp = _mm256_i32gather_ps(T->spow, _mm256_add_epi32(sp_base, _mm256_set1_epi32(sl * nt + st)), 4);
            const __m256 s = ADD(sp, min_s);
            __m256 f0 = MUL(s, om0), f1 = MUL(s, om1);
            const __m256 off_len = _mm256_sqrt_ps(ADD(MUL(f0, f0), MUL(f1, f1)));
            const __m256i li = _mm256_sub_epi32(
                _mm256_setzero_si256(),
                _mm256_add_epi32(_mm256_add_epi32(_mm256_castps_si256(_mm256_cmp_ps(off_len, mt0, _CMP_GE_OQ)),
                                                  _mm256_castps_si256(_mm256_cmp_ps(off_len, mt1, _CMP_GE_OQ))),
                                 _mm256_add_epi32(_mm256_castps_si256(_mm256_cmp_ps(off_len, mt2, _CMP_GE_OQ)),
                                                  _mm256_castps_si256(_mm256_cmp_ps(off_len, mt3, _CMP_GE_OQ)))));
            f0 = MUL(_mm256_round_ps(f0, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC), psx);
            f1 = MUL(_mm256_round_ps(f1, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC), psy);
            const __m256 u0 = ADD(u, f0), v0 = ADD(v, f1), u1 = SUB(u, f0), v1 = SUB(v, f1);
            const __m256i lw = _mm256_permutevar8x32_epi32(Wl, li), lh = _mm256_permutevar8x32_epi32(Hl, li);
            int lv[8], tx0[8], ty0[8], tx1[8], ty1[8];
            _mm256_storeu_si256((__m256i *)lv, li);
            _mm256_storeu_si256((__m256i *)tx0, v_texel(u0, lw));
            _mm256_storeu_si256((__m256i *)ty0, v_texel(v0, lh));
            _mm256_storeu_si256((__m256i *)tx1, v_texel(u1, lw));
            _mm256_storeu_si256((__m256i *)ty1, v_texel(v1, lh));
            float z0v[8], z1v[8];
            for (int l = 0; l < 8; l++) {
                const obs_image_f32 *L = &levels[lv[l]];
                z0v[l] = obs_image_f32_row(L, ty0[l])[tx0[l]];
                z1v[l] = obs_image_f32_row(L, ty1[l])[tx1[l]];
            }
            const __m256 sz0 = _mm256_loadu_ps(z0v), sz1 = _mm256_loadu_ps(z1v);
            const __m256 a0 = ADD(MUL(mx, u0), ax), b0 = ADD(MUL(my, v0), ay);
            const __m256 a1 = ADD(MUL(mx, u1), ax), b1 = ADD(MUL(my, v1), ay);
            const __m256 d00 = SUB(ortho_proj ? a0 : MUL(a0, sz0), C0), d01 = SUB(ortho_proj ? b0 : MUL(b0, sz0), C1);
            const __m256 d02 = SUB(sz0, C2);
            const __m256 d10 = SUB(ortho_proj ? a1 : MUL(a1, sz1), C0), d11 = SUB(ortho_proj ? b1 : MUL(b1, sz1), C1);
            const __m256 d12 = SUB(sz1, C2);
            const __m256 dist0 = _mm256_sqrt_ps(DOT3(d00, d01, d02, d00, d01, d02));
            const __m256 dist1 = _mm256_sqrt_ps(DOT3(d10, d11, d12, d10, d11, d12));
            __m256 fl0 = dist0, fl1 = dist1;
            if (thin) {
                const __m256 e02 = MUL(d02, thin_scale), e12 = MUL(d12, thin_scale);
                fl0 = _mm256_sqrt_ps(DOT3(d00, d01, e02, d00, d01, e02));
                fl1 = _mm256_sqrt_ps(DOT3(d10, d11, e12, d10, d11, e12));
            }
            const __m256 w0 = v_sat(ADD(MUL(fl0, fmul), fadd)), w1 = v_sat(ADD(MUL(fl1, fmul), fadd));
            __m256 shc0 = DOT3(DIV(d00, dist0), DIV(d01, dist0), DIV(d02, dist0), V0, V1, V2);
            __m256 shc1 = DOT3(DIV(d10, dist1), DIV(d11, dist1), DIV(d12, dist1), V0, V1, V2);
            shc0 = ADD(low0, MUL(w0, SUB(shc0, low0)));
            shc1 = ADD(low1, MUL(w1, SUB(shc1, low1)));
            hc0 = v_max_a(hc0, shc0);
            hc1 = v_max_a(hc1, shc1);
        }

        pn_len = ADD(pn_len, MUL(_mm256_set1_ps(0.05f), SUB(_mm256_set1_ps(1.0f), pn_len)));
        const __m256 h0 = _mm256_xor_ps(v_fast_acos(hc1), _mm256_set1_ps(-0.0f));
        const __m256 h1 = v_fast_acos(hc0);
        const __m256 sin_n = v_cos_or_sin(nang, 1);
        const __m256 two = _mm256_set1_ps(2.0f), four = _mm256_set1_ps(4.0f);
        const __m256 c0 = v_cos_or_sin(SUB(MUL(two, h0), nang), 0);
        const __m256 c1 = v_cos_or_sin(SUB(MUL(two, h1), nang), 0);
        const __m256 iarc0 = DIV(SUB(ADD(cos_norm, MUL(MUL(two, h0), sin_n)), c0), four);
        const __m256 iarc1 = DIV(SUB(ADD(cos_norm, MUL(MUL(two, h1), sin_n)), c1), four);
        visibility = ADD(visibility, MUL(pn_len, ADD(iarc0, iarc1)));
    }
#undef ADD
#undef SUB
#undef MUL
#undef DIV
#undef DOT3
    _mm256_storeu_ps(out, visibility);
}
/* ---- Edges of a row (XeGTAO_CalculateEdges, XeGTAO_PackEdges), 8 pixels at a time ---------------
 * calculate_edges and pack_edges in the vector forms of the same float operations. */
AVX2_FN static void row_edges_avx2(const float *zc, const float *zl, const float *zr, const float *zt,
                                   const float *zb, float e[][4], unsigned char *packed)
{
    const __m256 c = _mm256_loadu_ps(zc), sign = _mm256_set1_ps(-0.0f), half = _mm256_set1_ps(0.5f);
    const __m256 e0 = _mm256_sub_ps(_mm256_loadu_ps(zl), c), e1 = _mm256_sub_ps(_mm256_loadu_ps(zr), c);
    const __m256 e2 = _mm256_sub_ps(_mm256_loadu_ps(zt), c), e3 = _mm256_sub_ps(_mm256_loadu_ps(zb), c);
    const __m256 slope_lr = _mm256_mul_ps(_mm256_sub_ps(e1, e0), half);
    const __m256 slope_tb = _mm256_mul_ps(_mm256_sub_ps(e3, e2), half);
    const __m256 ev[4] = {e0, e1, e2, e3};
    const __m256 adj[4] = {_mm256_add_ps(e0, slope_lr), _mm256_sub_ps(e1, slope_lr), _mm256_add_ps(e2, slope_tb),
                           _mm256_sub_ps(e3, slope_tb)};
    const __m256 denom = _mm256_mul_ps(c, _mm256_set1_ps(0.011f));
    __m256i pk = _mm256_setzero_si256();
    float o[4][8];
    for (int i = 0; i < 4; i++) {
        const __m256 a = _mm256_andnot_ps(sign, ev[i]), s = _mm256_andnot_ps(sign, adj[i]);
        const __m256 m = _mm256_blendv_ps(s, a, _mm256_cmp_ps(a, s, _CMP_LT_OQ));
        const __m256 out = v_sat(_mm256_sub_ps(_mm256_set1_ps(1.25f), _mm256_div_ps(m, denom)));
        _mm256_storeu_ps(o[i], out);
        const __m256 q = _mm256_round_ps(_mm256_mul_ps(v_sat(out), _mm256_set1_ps(2.9f)),
                                         _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
        pk = _mm256_or_si256(_mm256_slli_epi32(pk, 2), _mm256_cvttps_epi32(q));
    }
    int pv[8];
    _mm256_storeu_si256((__m256i *)pv, pk);
    for (int l = 0; l < 8; l++) {
        packed[l] = (unsigned char)pv[l];
        for (int i = 0; i < 4; i++)
            e[l][i] = o[i][l];
    }
}

/* 1 when the 8 pixels are all background (our depth d) and their centre, left, right, top and
 * bottom MIP-0 depths are all the 65504 clamp: their edges are 0xFF and they need no setup. */
AVX2_FN static inline int bg8_avx2(const float *d, const float *zc, const float *zt, const float *zb)
{
    const __m256 dv = _mm256_loadu_ps(d), cl = _mm256_set1_ps(AO_GTAO_DEPTH_CLAMP);
    const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(dv, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(dv, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    if (_mm256_movemask_ps(fg))
        return 0;
    __m256 eq = _mm256_and_ps(_mm256_cmp_ps(_mm256_loadu_ps(zc), cl, _CMP_EQ_OQ),
                              _mm256_cmp_ps(_mm256_loadu_ps(zc - 1), cl, _CMP_EQ_OQ));
    eq = _mm256_and_ps(eq, _mm256_cmp_ps(_mm256_loadu_ps(zc + 1), cl, _CMP_EQ_OQ));
    eq = _mm256_and_ps(eq, _mm256_cmp_ps(_mm256_loadu_ps(zt), cl, _CMP_EQ_OQ));
    eq = _mm256_and_ps(eq, _mm256_cmp_ps(_mm256_loadu_ps(zb), cl, _CMP_EQ_OQ));
    return _mm256_movemask_ps(eq) == 0xFF;
}
#endif

typedef struct main_job {
    const ao_gtao_constants *k;
    main_consts mc;
    const obs_image_f32 *levels;
    const ao_input *in;
    int rx0, ry0;
    obs_image_f32 *vis;
    unsigned char *edges;   /* rw x rh */
    int64_t (*counts)[2];
    const main_tables *tables;      /* NULL: the reference main_pixel */
    int avx2;                       /* 1: the 8-lane slice loop */
} main_job;

#if GTAO_AVX2
/* ---- The 8-pixel set-up and finish (AVX2) ----------------------------------------------------------
 * Lane l is pixel i + l of the row. setup8_avx2 is pixel_setup for G-buffer normals without
 * gpu_packing, in the vector forms of its float operations in its order (the left-to-right dots,
 * sqrt, division; no FMA); the surface lanes are compacted (in their order) into the pending lanes,
 * which feed slices_avx2 directly. finish8_avx2 is pixel_finish of 8 lanes, with
 * ao_gtao_final_power's x^2.2 in double 4 lanes at a time (the same table steps; the lanes its
 * rounding test rejects, and other powers, call it per lane). */

/* pixel_finish of the 8 lanes of acc; lanes 0..cnt-1 stored at o[idx[l]] */
AVX2_FN static void finish8_avx2(const ao_gtao_constants *k, __m256 acc, const int *idx, int cnt, float *o)
{
    __m256 v = _mm256_div_ps(acc, _mm256_set1_ps((float)k->slice_count));
    float vv[8];
    if (f2u(k->final_value_power) == f2u(2.2f)) {
        /* ao_gtao_final_power's domain [2^-126, 2); other lanes compute with x = 1 and call it */
        const __m256 dom = _mm256_and_ps(_mm256_cmp_ps(v, _mm256_set1_ps(0x1p-126f), _CMP_GE_OQ),
                                         _mm256_cmp_ps(v, _mm256_set1_ps(2.0f), _CMP_LT_OQ));
        const __m256 x = _mm256_blendv_ps(_mm256_set1_ps(1.0f), v, dom);
        const __m256i u = _mm256_castps_si256(x);
        const __m256i ei = _mm256_add_epi32(_mm256_srli_epi32(u, 23), _mm256_set1_epi32(126 - 127));
        const __m256i mb = _mm256_and_si256(u, _mm256_set1_epi32(0x7FFFFF));
        const __m256i ii = _mm256_srli_epi32(mb, 16);
        const __m256i lo16 = _mm256_and_si256(mb, _mm256_set1_epi32(0xFFFF));
        __m128 res[2];
        int ok = _mm256_movemask_ps(dom);
        for (int h = 0; h < 2; h++) {
            const __m128i i4 = h ? _mm256_extracti128_si256(ii, 1) : _mm256_castsi256_si128(ii);
            const __m128i e4 = h ? _mm256_extracti128_si256(ei, 1) : _mm256_castsi256_si128(ei);
            const __m128i m4 = h ? _mm256_extracti128_si256(lo16, 1) : _mm256_castsi256_si128(lo16);
            const __m256d r = _mm256_mul_pd(_mm256_mul_pd(_mm256_cvtepi32_pd(m4), _mm256_set1_pd(0x1p-23)),
                                            _mm256_i32gather_pd(POW22_T_INV, i4, 8));
            __m256d q = _mm256_set1_pd(POW22_C[6]);
            for (int c = 5; c >= 0; c--)
                q = _mm256_add_pd(_mm256_set1_pd(POW22_C[c]), _mm256_mul_pd(r, q));
            const __m256d y = _mm256_mul_pd(
                _mm256_mul_pd(_mm256_i32gather_pd(POW22_T_MANT, i4, 8),
                              _mm256_add_pd(_mm256_set1_pd(1.0), _mm256_mul_pd(r, q))),
                _mm256_i32gather_pd(POW22_T_EXP, e4, 8));
            const __m256d tol = _mm256_mul_pd(y, _mm256_set1_pd(0x1p-48));
            const __m128 lo = _mm256_cvtpd_ps(_mm256_sub_pd(y, tol)), hi = _mm256_cvtpd_ps(_mm256_add_pd(y, tol));
            ok &= ~((~_mm_movemask_ps(_mm_cmpeq_ps(lo, hi)) & 15) << (4 * h));
            res[h] = lo;
        }
        _mm256_storeu_ps(vv, v);
        __m256 pw = _mm256_insertf128_ps(_mm256_castps128_ps256(res[0]), res[1], 1);
        if (ok != 0xFF) {
            float pv[8];
            _mm256_storeu_ps(pv, pw);
            for (int l = 0; l < 8; l++)
                if (!(ok & (1 << l)))
                    pv[l] = ao_gtao_final_power(vv[l], k->final_value_power);
            pw = _mm256_loadu_ps(pv);
        }
        v = pw;
    } else {
        _mm256_storeu_ps(vv, v);
        for (int l = 0; l < 8; l++)
            vv[l] = ao_gtao_final_power(vv[l], k->final_value_power);
        v = _mm256_loadu_ps(vv);
    }
    v = v_max_a(_mm256_set1_ps(0.03f), v); /* hmax_fast(0.03f, v) */
    if (k->gpu_packing) {
        _mm256_storeu_ps(vv, v);
        for (int l = 0; l < cnt; l++)
            o[idx[l]] = unorm8(sat(vv[l] / AO_GTAO_OCCLUSION_TERM_SCALE));
        return;
    }
    const __m256 sc = _mm256_set1_ps(AO_GTAO_OCCLUSION_TERM_SCALE);
    v = _mm256_blendv_ps(sc, v, _mm256_cmp_ps(v, sc, _CMP_LT_OQ));
    _mm256_storeu_ps(vv, v);
    for (int l = 0; l < cnt; l++)
        o[idx[l]] = vv[l];
}

/* the slice loops and finish of pending lanes 0..7, then lanes 8.. moved down */
AVX2_FN static void lanes_run8(const main_job *J, lanes8 *P, float *o)
{
    float acc[8];
    slices_avx2(J->k, &J->mc, J->tables, J->levels, P, acc);
    finish8_avx2(J->k, _mm256_loadu_ps(acc), P->idx, 8, o);
    P->na -= 8;
    for (int f = 0; f < LN_FIELDS; f++)
        _mm256_storeu_ps(&P->t[f][0], _mm256_loadu_ps(&P->t[f][8]));
    _mm256_storeu_si256((__m256i *)&P->cell[0], _mm256_loadu_si256((const __m256i *)&P->cell[8]));
    _mm256_storeu_si256((__m256i *)&P->idx[0], _mm256_loadu_si256((const __m256i *)&P->idx[8]));
}

/* one scalar pixel_setup result as the next pending lane */
AVX2_FN static void lanes_push(const main_job *J, lanes8 *P, const px_setup *S, int i, float *o)
{
    const int l = P->na;
    for (int a = 0; a < 3; a++)
        P->t[LN_N0 + a][l] = S->n[a], P->t[LN_C0 + a][l] = S->C[a], P->t[LN_V0 + a][l] = S->V[a];
    P->t[LN_U][l] = S->u, P->t[LN_V][l] = S->v, P->t[LN_SSR][l] = S->ssr, P->t[LN_MIN_S][l] = S->min_s;
    P->t[LN_VIS0][l] = S->vis0;
    P->cell[l] = S->cell, P->idx[l] = i;
    if (++P->na == 8)
        lanes_run8(J, P, o);
}

/* the row's last pending lanes: 2..7 padded with copies of lane 0 (results unused), 1 scalar */
AVX2_FN static void lanes_drain(const main_job *J, lanes8 *P, float *o)
{
    const int na = P->na;
    if (na >= 2) {
        for (int l = na; l < 8; l++) {
            for (int f = 0; f < LN_FIELDS; f++)
                P->t[f][l] = P->t[f][0];
            P->cell[l] = P->cell[0];
        }
        float acc[8];
        slices_avx2(J->k, &J->mc, J->tables, J->levels, P, acc);
        finish8_avx2(J->k, _mm256_loadu_ps(acc), P->idx, na, o);
    } else if (na == 1) {
        px_setup S;
        for (int a = 0; a < 3; a++)
            S.n[a] = P->t[LN_N0 + a][0], S.C[a] = P->t[LN_C0 + a][0], S.V[a] = P->t[LN_V0 + a][0];
        S.u = P->t[LN_U][0], S.v = P->t[LN_V][0], S.ssr = P->t[LN_SSR][0], S.min_s = P->t[LN_MIN_S][0];
        S.vis0 = P->t[LN_VIS0][0], S.cell = P->cell[0];
        pixel_finish(J->k, pixel_slices(J->k, &J->mc, J->tables, J->levels, &S), &o[P->idx[0]]);
    }
    P->na = 0;
}

/* pixel_setup of pixels i..i+7 of row y (x = rx0 + i ..), G-buffer normals, no gpu_packing */
AVX2_FN static void setup8_avx2(const main_job *J, int y, int i, float *o, lanes8 *P, int64_t *bg, int64_t *deg)
{
    const ao_gtao_constants *k = J->k;
    const int x = J->rx0 + i;
    const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    const __m256 d = _mm256_loadu_ps(obs_image_f32_row(J->in->depth, y) + x);
    const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OQ), _mm256_cmp_ps(d, inf, _CMP_LT_OQ));
    const int fgm = _mm256_movemask_ps(fg);
    const __m256 bgv = _mm256_set1_ps(1.0f); /* no gpu_packing */
    if (!fgm) {
        _mm256_storeu_ps(o + i, bgv);
        *bg += 8;
        return;
    }
#define ADD _mm256_add_ps
#define SUB _mm256_sub_ps
#define MUL _mm256_mul_ps
#define DIV _mm256_div_ps
#define DOT3(a0, a1, a2, b0, b1, b2) ADD(ADD(MUL(a0, b0), MUL(a1, b1)), MUL(a2, b2))
    /* LoadNormal: z flipped, then the degenerate test and normalize3 */
    __m256 n0 = _mm256_loadu_ps(obs_image_f32_row(J->in->normal[0], y) + x);
    __m256 n1 = _mm256_loadu_ps(obs_image_f32_row(J->in->normal[1], y) + x);
    __m256 n2 = _mm256_xor_ps(_mm256_loadu_ps(obs_image_f32_row(J->in->normal[2], y) + x), _mm256_set1_ps(-0.0f));
    const __m256 l2 = DOT3(n0, n1, n2, n0, n1, n2);
    const __m256 nok = _mm256_and_ps(_mm256_cmp_ps(l2, zero, _CMP_GT_OQ), _mm256_cmp_ps(l2, inf, _CMP_LT_OQ));
    const int surf = fgm & _mm256_movemask_ps(nok);
    *bg += 8 - __builtin_popcount((unsigned)fgm);
    *deg += __builtin_popcount((unsigned)(fgm & ~surf));
    if (surf != 0xFF)
        _mm256_maskstore_ps(o + i, _mm256_castps_si256(_mm256_xor_ps(_mm256_castsi256_ps(_mm256_set1_epi32(-1)),
                                                                     _mm256_and_ps(fg, nok))),
                            bgv);
    if (!surf)
        return;
    const __m256 nl = _mm256_sqrt_ps(l2);
    n0 = DIV(n0, nl), n1 = DIV(n1, nl), n2 = DIV(n2, nl);
    /* the centre pulled toward the camera, its view position and the view vector */
    const __m256 vz = MUL(_mm256_loadu_ps(obs_image_f32_row(&J->levels[0], y) + x), _mm256_set1_ps(AO_GTAO_CENTER_Z_PULL));
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i xi = _mm256_add_epi32(_mm256_set1_epi32(x), lane);
    const __m256 u = MUL(ADD(_mm256_cvtepi32_ps(xi), _mm256_set1_ps(0.5f)), _mm256_set1_ps(k->viewport_pixel_size[0]));
    const __m256 v = _mm256_set1_ps(((float)y + 0.5f) * k->viewport_pixel_size[1]);
    const __m256 a = ADD(MUL(_mm256_set1_ps(k->ndc_to_view_mul[0]), u), _mm256_set1_ps(k->ndc_to_view_add[0]));
    const __m256 b = ADD(MUL(_mm256_set1_ps(k->ndc_to_view_mul[1]), v), _mm256_set1_ps(k->ndc_to_view_add[1]));
    const __m256 C0 = k->orthographic ? a : MUL(a, vz), C1 = k->orthographic ? b : MUL(b, vz), C2 = vz;
    const __m256 sgn = _mm256_set1_ps(-0.0f);
    __m256 V0, V1, V2;
    if (k->orthographic) {
        V0 = zero, V1 = zero, V2 = _mm256_set1_ps(-1.0f);
    } else {
        V0 = _mm256_xor_ps(C0, sgn), V1 = _mm256_xor_ps(C1, sgn), V2 = _mm256_xor_ps(C2, sgn);
        const __m256 vl = _mm256_sqrt_ps(DOT3(V0, V1, V2, V0, V1, V2));
        V0 = DIV(V0, vl), V1 = DIV(V1, vl), V2 = DIV(V2, vl);
    }
    /* the screen-space radius, the small-radius fade and minS */
    const __m256 psz = k->orthographic ? _mm256_set1_ps(k->ndc_to_view_mul_x_pixel_size[0])
                                       : MUL(vz, _mm256_set1_ps(k->ndc_to_view_mul_x_pixel_size[0]));
    const __m256 ssr = DIV(_mm256_set1_ps(J->mc.effect_radius), psz);
    const __m256 vis0 = MUL(v_sat(DIV(SUB(_mm256_set1_ps(10.0f), ssr), _mm256_set1_ps(100.0f))), _mm256_set1_ps(0.5f));
    const __m256 min_s = DIV(_mm256_set1_ps(J->mc.min_s_num), ssr);
    const __m256i cell = _mm256_or_si256(_mm256_set1_epi32((y & 63) << 6), _mm256_and_si256(xi, _mm256_set1_epi32(63)));
    const __m256i idx = _mm256_add_epi32(_mm256_set1_epi32(i), lane);
#undef ADD
#undef SUB
#undef MUL
#undef DIV
#undef DOT3
    /* compact the surface lanes (in order) onto the pending ones */
    __m256i perm = lane;
    if (surf != 0xFF) {
        int pv[8] = {0}, c = 0;
        for (int l = 0; l < 8; l++)
            if (surf & (1 << l))
                pv[c++] = l;
        perm = _mm256_loadu_si256((const __m256i *)pv);
    }
    const __m256 f[LN_FIELDS] = {n0, n1, n2, C0, C1, C2, V0, V1, V2, u, v, ssr, min_s, vis0};
    const int na = P->na;
    for (int q = 0; q < LN_FIELDS; q++)
        _mm256_storeu_ps(&P->t[q][na], _mm256_permutevar8x32_ps(f[q], perm));
    _mm256_storeu_si256((__m256i *)&P->cell[na], _mm256_permutevar8x32_epi32(cell, perm));
    _mm256_storeu_si256((__m256i *)&P->idx[na], _mm256_permutevar8x32_epi32(idx, perm));
    P->na = na + __builtin_popcount((unsigned)surf);
    if (P->na >= 8)
        lanes_run8(J, P, o);
}
#endif

static void main_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const main_job *J = (const main_job *)user;
    const int r = (int)task, y = J->ry0 + r, rw = J->vis->width;
    float *o = obs_image_f32_row(J->vis, r);
    unsigned char *e = J->edges + (size_t)r * (size_t)rw;
    int64_t bg = 0, deg = 0;
    if (!J->tables) {
        for (int i = 0; i < rw; i++) {
            const int c = main_pixel(J->k, &J->mc, J->levels, J->in, J->rx0 + i, y, &o[i], &e[i]);
            bg += c == 0;
            deg += c == 2;
        }
    } else {
        /* per chunk of 64 pixels: the edges (8 at a time with AVX2 where the neighbours are inside
         * the row), then the setup per pixel; the slice loops of the pixels that need one, 8 lanes
         * at a time (AVX2) or one by one (the row's last < 8 and the scalar build); the finish.
         * Background pixels (our depth) need no setup: the working term bgv. Where a background
         * pixel's five MIP-0 taps are all 65504 (the clamp; our background's value) its edges need
         * no arithmetic: calculate_edges(z, z, z, z, z) with z * 0.011 > 0 is (1.25 - 0 / (z * 0.011))
         * saturated = 1 each, packed round(1 * 2.9) = 3 each, 0xFF (the denoiser reads them where a
         * neighbour is foreground; gtao_background_edges_are_packed_ones checks the value). */
        const obs_image_f32 *z0 = &J->levels[0];
        const int W = z0->width, H = z0->height;
        const int yt = y > 0 ? y - 1 : 0, yb = y < H - 1 ? y + 1 : H - 1;
        const float *zr = obs_image_f32_row(z0, y), *zt = obs_image_f32_row(z0, yt), *zb = obs_image_f32_row(z0, yb);
        const float *dr = obs_image_f32_row(J->in->depth, y);
        const float cl = AO_GTAO_DEPTH_CLAMP;
        const float bgv = J->k->gpu_packing ? unorm8(1.0f / AO_GTAO_OCCLUSION_TERM_SCALE) : 1.0f;
#if GTAO_AVX2
        lanes8 P;
        P.na = 0;
        const int fast8 = J->k->normals_from_gbuffer && !J->k->gpu_packing;
#endif
        float ech[64][4];
        for (int i0 = 0; i0 < rw; i0 += 64) {
            const int n = rw - i0 < 64 ? rw - i0 : 64;
            for (int j = 0; j < n;) {
                const int x = J->rx0 + i0 + j;
#if GTAO_AVX2
                if (J->avx2 && j + 8 <= n && x >= 1 && x + 8 <= W - 1) {
                    if (bg8_avx2(dr + x, zr + x, zt + x, zb + x)) {
                        memset(&e[i0 + j], 0xFF, 8);
                        j += 8;
                        continue;
                    }
                    row_edges_avx2(zr + x, zr + x - 1, zr + x + 1, zt + x, zb + x, &ech[j], &e[i0 + j]);
                    j += 8;
                    continue;
                }
#endif
                const int xl = x > 0 ? x - 1 : 0, xr = x < W - 1 ? x + 1 : W - 1;
                if (is_background(dr[x]) && zr[x] == cl && zr[xl] == cl && zr[xr] == cl && zt[x] == cl &&
                    zb[x] == cl) {
                    e[i0 + j] = 0xFF;
                    j++;
                    continue;
                }
                calculate_edges(zr[x], zr[xl], zr[xr], zt[x], zb[x], ech[j]);
                e[i0 + j] = (unsigned char)pack_edges(ech[j]);
                j++;
            }
            for (int j = 0; j < n; j++) {
                const int i = i0 + j;
#if GTAO_AVX2
                if (J->avx2) {
                    /* 8 pixels at a time (G-buffer normals, no gpu_packing), else pixel_setup */
                    if (fast8 && j + 8 <= n) {
                        setup8_avx2(J, y, i, o, &P, &bg, &deg);
                        j += 7;
                        continue;
                    }
                    if (is_background(dr[J->rx0 + i])) {
                        o[i] = bgv;
                        bg++;
                        continue;
                    }
                    px_setup S1;
                    const int c = pixel_setup(J->k, &J->mc, J->levels, J->in, J->rx0 + i, y, ech[j], &o[i], &S1);
                    bg += c == 0;
                    deg += c == 2;
                    if (c == 1)
                        lanes_push(J, &P, &S1, i, o);
                    continue;
                }
#endif
                if (is_background(dr[J->rx0 + i])) {
                    o[i] = bgv;
                    bg++;
                    continue;
                }
                px_setup S1;
                const int c = pixel_setup(J->k, &J->mc, J->levels, J->in, J->rx0 + i, y, ech[j], &o[i], &S1);
                bg += c == 0;
                deg += c == 2;
                if (c == 1)
                    pixel_finish(J->k, pixel_slices(J->k, &J->mc, J->tables, J->levels, &S1), &o[i]);
            }
        }
#if GTAO_AVX2
        if (J->avx2)
            lanes_drain(J, &P, o);
#endif
    }
    J->counts[r][0] = bg;
    J->counts[r][1] = deg;
}

/* ================================================================================================
 * Denoise (XeGTAO_Denoise): one 3x3 edge-aware pass, per pixel
 * ============================================================================================== */

typedef struct denoise_job {
    const obs_image_f32 *src;       /* AO over region A (origin ax0, ay0) */
    int ax0, ay0;
    const unsigned char *edges;     /* packed edges over the main region (origin ex0, ey0, width ew) */
    int ex0, ey0, ew;
    obs_image_f32 *dst;             /* region D (origin dx0, dy0), inside A */
    int dx0, dy0;
    int W, H;                       /* the full buffer (CLAMP addressing) */
    float blur_amount;              /* beta (last pass) or beta / 5 */
    int pack;                       /* gpu_packing: 1 intermediate (8-bit store), 2 last (* 1.5, 8-bit) */
    const obs_image_f32 *skip_bg;   /* last pass: the input depth; its background pixels are written 1
                                       (ao_gtao_compute overwrites them with 1 anyway). NULL: all */
    int avx2;                       /* 1: 8 pixels at a time where no CLAMP applies */
} denoise_job;

/* XeGTAO_UnpackEdges per 2-bit value: q / 3 (the same float division, folded) */
static const float unpack_q3[4] = {0.0f / 3.0f, 1.0f / 3.0f, 2.0f / 3.0f, 3.0f / 3.0f};
static inline void unpack_edges_lut(unsigned p, float out[4])
{
    out[0] = unpack_q3[(p >> 6) & 3u];
    out[1] = unpack_q3[(p >> 4) & 3u];
    out[2] = unpack_q3[(p >> 2) & 3u];
    out[3] = unpack_q3[p & 3u];
}

#if GTAO_AVX2
/* ---- Denoise, 8 pixels of a row at a time (AVX2) --------------------------------------------------
 * denoise_row's float operations per lane in its order (XeGTAO_UnpackEdges' q / 3 from the same
 * folded table). Only for pixels whose left and right neighbours are inside the
 * buffer (no CLAMP), so the source reads are plain unaligned loads. */
static const float unpack_q3_8[8] = {0.0f / 3.0f, 1.0f / 3.0f, 2.0f / 3.0f, 3.0f / 3.0f, 0.0f, 0.0f, 0.0f, 0.0f};

AVX2_FN static inline __m256 v_unpack(__m256i p, int shift)
{
    const __m256i q = _mm256_and_si256(_mm256_srli_epi32(p, shift), _mm256_set1_epi32(3));
    return _mm256_permutevar8x32_ps(_mm256_loadu_ps(unpack_q3_8), q);
}

AVX2_FN static inline __m256i v_load8u(const unsigned char *p)
{
    return _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)p));
}

AVX2_FN static inline __m256 v_unorm8(__m256 v)
{
    v = v_sat(v);
    const __m256i q = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(v, _mm256_set1_ps(255.0f)), _mm256_set1_ps(0.5f)));
    return _mm256_div_ps(_mm256_cvtepi32_ps(q), _mm256_set1_ps(255.0f));
}

/* 1 when the 8 depths are all background (not > 0 and finite) */
AVX2_FN static inline int all_bg8_avx2(const float *d)
{
    const __m256 dv = _mm256_loadu_ps(d);
    const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(dv, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(dv, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    return _mm256_movemask_ps(fg) == 0;
}

AVX2_FN static void denoise8_avx2(const denoise_job *J, const float *rc, const float *rt, const float *rb,
                                  const unsigned char *ec, const unsigned char *et, const unsigned char *eb,
                                  const float *bg, float *o)
{
    /* rc, rt, rb: the source rows at the centre column; ec, et, eb: the edge rows there */
    const __m256i pC = v_load8u(ec), pL = v_load8u(ec - 1), pR = v_load8u(ec + 1), pT = v_load8u(et),
                  pB = v_load8u(eb);
    __m256 eC0 = v_unpack(pC, 6), eC1 = v_unpack(pC, 4), eC2 = v_unpack(pC, 2), eC3 = v_unpack(pC, 0);
    const __m256 eL1 = v_unpack(pL, 4), eL2 = v_unpack(pL, 2), eL3 = v_unpack(pL, 0);
    const __m256 eR0 = v_unpack(pR, 6), eR2 = v_unpack(pR, 2), eR3 = v_unpack(pR, 0);
    const __m256 eT0 = v_unpack(pT, 6), eT1 = v_unpack(pT, 4), eT3 = v_unpack(pT, 0);
    const __m256 eB0 = v_unpack(pB, 6), eB1 = v_unpack(pB, 4), eB2 = v_unpack(pB, 2);
    eC0 = _mm256_mul_ps(eC0, eL1);
    eC1 = _mm256_mul_ps(eC1, eR0);
    eC2 = _mm256_mul_ps(eC2, eT3);
    eC3 = _mm256_mul_ps(eC3, eB2);
    const __m256 sum_e = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(eC0, eC1), eC2), eC3);
    const __m256 edginess = _mm256_mul_ps(
        _mm256_div_ps(v_sat(_mm256_sub_ps(_mm256_set1_ps(4.0f - 2.5f), sum_e)), _mm256_set1_ps(4.0f - 2.5f)),
        _mm256_set1_ps(0.5f));
    eC0 = v_sat(_mm256_add_ps(eC0, edginess));
    eC1 = v_sat(_mm256_add_ps(eC1, edginess));
    eC2 = v_sat(_mm256_add_ps(eC2, edginess));
    eC3 = v_sat(_mm256_add_ps(eC3, edginess));
    const __m256 diag = _mm256_set1_ps(0.85f * 0.5f);
#define M _mm256_mul_ps
#define A _mm256_add_ps
    const __m256 wTL = M(diag, A(M(eC0, eL2), M(eC2, eT0)));
    const __m256 wTR = M(diag, A(M(eC2, eT1), M(eC1, eR2)));
    const __m256 wBL = M(diag, A(M(eC3, eB0), M(eC0, eL3)));
    const __m256 wBR = M(diag, A(M(eC1, eR3), M(eC3, eB1)));
    __m256 sum_w = _mm256_set1_ps(J->blur_amount);
    __m256 sum = M(_mm256_loadu_ps(rc), sum_w);
    const __m256 vals[8] = {_mm256_loadu_ps(rc - 1), _mm256_loadu_ps(rc + 1), _mm256_loadu_ps(rt),
                            _mm256_loadu_ps(rb),     _mm256_loadu_ps(rt - 1), _mm256_loadu_ps(rt + 1),
                            _mm256_loadu_ps(rb - 1), _mm256_loadu_ps(rb + 1)};
    const __m256 ws[8] = {eC0, eC1, eC2, eC3, wTL, wTR, wBL, wBR};
    for (int q = 0; q < 8; q++) {
        sum = A(sum, M(ws[q], vals[q]));
        sum_w = A(sum_w, ws[q]);
    }
#undef M
#undef A
    __m256 v = _mm256_div_ps(sum, sum_w);
    if (J->pack == 1)
        v = v_unorm8(v);
    else if (J->pack == 2)
        v = v_unorm8(_mm256_mul_ps(v, _mm256_set1_ps(AO_GTAO_OCCLUSION_TERM_SCALE)));
    if (bg) {
        const __m256 d = _mm256_loadu_ps(bg);
        const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(d, _mm256_setzero_ps(), _CMP_GT_OQ),
                                        _mm256_cmp_ps(d, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
        v = _mm256_blendv_ps(_mm256_set1_ps(1.0f), v, fg);
    }
    _mm256_storeu_ps(o, v);
}
#endif

static void denoise_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const denoise_job *J = (const denoise_job *)user;
    const int y = J->dy0 + (int)task;
    const int yt = y > 0 ? y - 1 : 0, yb = y < J->H - 1 ? y + 1 : J->H - 1;
    const float *rc = obs_image_f32_row(J->src, y - J->ay0), *rt = obs_image_f32_row(J->src, yt - J->ay0),
                *rb = obs_image_f32_row(J->src, yb - J->ay0);
    const unsigned char *ec = J->edges + (size_t)(y - J->ey0) * J->ew, *et = J->edges + (size_t)(yt - J->ey0) * J->ew,
                        *eb = J->edges + (size_t)(yb - J->ey0) * J->ew;
    const int ex0 = J->ex0;
    float *o = obs_image_f32_row(J->dst, (int)task);
    const float diag = 0.85f * 0.5f;
    const float *bgrow = J->skip_bg ? obs_image_f32_row(J->skip_bg, y) : NULL;
    for (int i = 0; i < J->dst->width; i++) {
        const int x = J->dx0 + i;
#if GTAO_AVX2
        if (J->avx2 && i + 8 <= J->dst->width && x >= 1 && x + 8 <= J->W - 1) {
            if (bgrow && all_bg8_avx2(bgrow + x)) { /* denoise8_avx2 would blend in 1 for each */
                for (int l = 0; l < 8; l++)
                    o[i + l] = 1.0f;
                i += 7;
                continue;
            }
            denoise8_avx2(J, rc + (x - J->ax0), rt + (x - J->ax0), rb + (x - J->ax0), ec + (x - ex0), et + (x - ex0),
                          eb + (x - ex0), bgrow ? bgrow + x : NULL, o + i);
            i += 7;
            continue;
        }
#endif
        if (bgrow && is_background(bgrow[x])) {
            o[i] = 1.0f;
            continue;
        }
        const int xl = x > 0 ? x - 1 : 0, xr = x < J->W - 1 ? x + 1 : J->W - 1;
        const int c = x - J->ax0, l = xl - J->ax0, r = xr - J->ax0;
        float eC[4], eL[4], eR[4], eT[4], eB[4];
        unpack_edges_lut(ec[x - ex0], eC);
        unpack_edges_lut(ec[xl - ex0], eL);
        unpack_edges_lut(ec[xr - ex0], eR);
        unpack_edges_lut(et[x - ex0], eT);
        unpack_edges_lut(eb[x - ex0], eB);
        /* enforce symmetry with the neighbours' facing edges */
        eC[0] = eC[0] * eL[1];
        eC[1] = eC[1] * eR[0];
        eC[2] = eC[2] * eT[3];
        eC[3] = eC[3] * eB[2];
        /* leak a little AO through pixels with 3-4 edges (leak_threshold 2.5, leak_strength 0.5) */
        const float sum_e = eC[0] + eC[1] + eC[2] + eC[3];
        const float edginess = (sat(4.0f - 2.5f - sum_e) / (4.0f - 2.5f)) * 0.5f;
        for (int q = 0; q < 4; q++)
            eC[q] = sat(eC[q] + edginess);
        /* diagonal weights */
        const float wTL = diag * (eC[0] * eL[2] + eC[2] * eT[0]);
        const float wTR = diag * (eC[2] * eT[1] + eC[1] * eR[2]);
        const float wBL = diag * (eC[3] * eB[0] + eC[0] * eL[3]);
        const float wBR = diag * (eC[1] * eR[3] + eC[3] * eB[1]);
        float sum_w = J->blur_amount;
        float sum = rc[c] * sum_w;
        /* XeGTAO_AddSample order: L, R, T, B, TL, TR, BL, BR */
        const float vals[8] = {rc[l], rc[r], rt[c], rb[c], rt[l], rt[r], rb[l], rb[r]};
        const float ws[8] = {eC[0], eC[1], eC[2], eC[3], wTL, wTR, wBL, wBR};
        for (int q = 0; q < 8; q++) {
            sum = sum + ws[q] * vals[q];
            sum_w = sum_w + ws[q];
        }
        const float v = sum / sum_w;
        /* XeGTAO_Output: intermediate passes store uint(v * 255 + 0.5); the last multiplies by 1.5
         * first (R8_UINT; we saturate the stored byte at 255) */
        o[i] = J->pack == 1 ? unorm8(v) : J->pack == 2 ? unorm8(v * AO_GTAO_OCCLUSION_TERM_SCALE) : v;
    }
}

/* ================================================================================================
 * Compute
 * ============================================================================================== */

static obs_status check_planes(obs_context *ctx, const ao_input *in, const obs_image_f32 *out,
                               const obs_image_f32 *out_raw)
{
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "gtao: output planes must be %dx%d (the window)", in->w,
                         in->h);
    return OBS_STATUS_OK;
}

static inline float clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

#if GTAO_AVX2
/* step 4 of ao_gtao_compute for 8 pixels: background 1, else clamp01 (of the value * 1.5 when the
 * flag says so) */
AVX2_FN static void output8_avx2(const float *f, const float *r, const float *d, float *o, float *orw, int scale_f,
                                 int scale_r)
{
    const __m256 dv = _mm256_loadu_ps(d), one = _mm256_set1_ps(1.0f), sc = _mm256_set1_ps(AO_GTAO_OCCLUSION_TERM_SCALE);
    const __m256 fg = _mm256_and_ps(_mm256_cmp_ps(dv, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(dv, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    __m256 fv = _mm256_loadu_ps(f);
    if (scale_f)
        fv = _mm256_mul_ps(fv, sc);
    _mm256_storeu_ps(o, _mm256_blendv_ps(one, v_sat(fv), fg));
    if (orw) {
        __m256 rv = _mm256_loadu_ps(r);
        if (scale_r)
            rv = _mm256_mul_ps(rv, sc);
        _mm256_storeu_ps(orw, _mm256_blendv_ps(one, v_sat(rv), fg));
    }
}
#endif

/* ---- The workspace (issue 12): what a call needs besides its output, kept between calls ------------
 * The MIP levels, the main pass's working term, edges and counts, the denoiser's two planes and the
 * per-call tables are parked in the caller's context (obs_context_scratch_put) and reused by the
 * next call with that context: no allocation, no page faults, and no zeroing, because every plane
 * is fully written before it is read (the prefilter writes every texel of each level, main_row every
 * pixel of the region and every row's counts, each denoise pass every pixel of its view, which is
 * all the next pass and the output read). The tables are rebuilt only when their inputs change.
 * Planes only grow; the context frees them (obs_context_destroy). */
enum { WS_VIS = AO_GTAO_DEPTH_MIP_LEVELS, WS_PING, WS_PONG, WS_PLANES };
typedef struct gtao_workspace {
    obs_image_f32 plane[WS_PLANES]; /* levels 0..4, vis, ping, pong */
    size_t cap[WS_PLANES];          /* floats each plane's memory holds */
    unsigned char *edges;
    size_t edges_cap;
    int64_t (*counts)[2];
    size_t counts_cap;
    main_tables *tables;            /* built for these inputs: */
    int tables_slices, tables_steps, tables_noise_index;
    float tables_power, tables_mip_offset;
} gtao_workspace;

static const char gtao_workspace_key; /* its address names our slot in the context */

static void gtao_workspace_destroy(void *p)
{
    gtao_workspace *ws = (gtao_workspace *)p;
    if (!ws)
        return;
    for (int i = 0; i < WS_PLANES; i++)
        obs_aligned_free(ws->plane[i].data);
    free(ws->edges);
    free(ws->counts);
    main_tables_free(ws->tables);
    free(ws);
}

/* Make *im a w x h plane (rows of 16-float multiples, as obs_image_f32_alloc) in memory that holds
 * *cap floats, growing it when needed, with obs_image_f32_alloc's limits. Not zeroed. */
static obs_status ws_plane(obs_context *ctx, obs_image_f32 *im, size_t *cap, int w, int h)
{
    const size_t row = ((size_t)w + 15) & ~(size_t)15;
    size_t elems, bytes;
    if (!obs_mul_size(row, (size_t)h, &elems) || !obs_mul_size(elems, 4, &bytes))
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "image size %dx%d overflows size_t", w, h);
    const obs_limits *lim = obs_context_limits(ctx);
    if ((int64_t)w * (int64_t)h > lim->max_image_pixels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d has %lld pixels, over the limit of %lld (raise it with --max-pixels)", w, h,
                         (long long)w * h, (long long)lim->max_image_pixels);
    if ((int64_t)bytes > lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d needs %lld bytes, over the limit of %lld (raise it with --max-memory)", w, h,
                         (long long)bytes, (long long)lim->max_memory_bytes);
    if (elems > *cap || !im->data) {
        obs_aligned_free(im->data);
        im->data = (float *)obs_aligned_alloc(bytes);
        *cap = im->data ? elems : 0;
        if (!im->data)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes for a %dx%d image", bytes, w,
                             h);
    }
    im->width = w;
    im->height = h;
    im->stride = (ptrdiff_t)row;
    return OBS_STATUS_OK;
}

/* n elements of `size` bytes in *p (capacity *cap), growing it when needed. Returns 0 when out of
 * memory. Not zeroed. */
static int ws_array(void **p, size_t *cap, size_t n, size_t size)
{
    if (n <= *cap && *p)
        return 1;
    free(*p);
    *p = malloc(n * size);
    *cap = *p ? n : 0;
    return *p != NULL;
}

/* The per-call tables for k, rebuilt only when their inputs changed. */
static const main_tables *ws_tables(gtao_workspace *ws, const ao_gtao_constants *k)
{
    if (ws->tables && ws->tables_slices == k->slice_count && ws->tables_steps == k->steps_per_slice &&
        ws->tables_noise_index == k->noise_index && f2u(ws->tables_power) == f2u(k->sample_distribution_power) &&
        f2u(ws->tables_mip_offset) == f2u(k->depth_mip_sampling_offset))
        return ws->tables;
    main_tables_free(ws->tables);
    ws->tables = main_tables_create(k);
    ws->tables_slices = k->slice_count;
    ws->tables_steps = k->steps_per_slice;
    ws->tables_noise_index = k->noise_index;
    ws->tables_power = k->sample_distribution_power;
    ws->tables_mip_offset = k->depth_mip_sampling_offset;
    return ws->tables;
}

static obs_status gtao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_params *params,
                               obs_image_f32 *out, obs_image_f32 *out_raw, ao_gtao_stats *stats, int reference)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_gtao_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    st = check_planes(ctx, in, out, out_raw);
    if (st != OBS_STATUS_OK)
        return st;
    if (params->normals == AO_GTAO_NORMALS_GBUFFER && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "gtao: normals from the G-buffer were asked for, but the input has none");
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_gtao_constants k = ao_gtao_constants_from_params(params, in);
    const int W = in->width, H = in->height;

    const int gtao_avx2 = gtao_use_avx2();
    (void)gtao_avx2;

    /* ---- 0. The workspace: the context's, or a fresh one (parked in the context at the end) ---- */
    gtao_workspace *ws = (gtao_workspace *)obs_context_scratch_take(ctx, &gtao_workspace_key);
    if (!ws && !(ws = (gtao_workspace *)calloc(1, sizeof *ws)))
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "gtao: out of memory");
    obs_image_f32 *levels = ws->plane;

    /* ---- 1. PrefilterDepths ---- */
    double t0 = obs_time_now();
    st = OBS_STATUS_OK;
    for (int l = 0; l < AO_GTAO_DEPTH_MIP_LEVELS && st == OBS_STATUS_OK; l++) {
        int lw, lh;
        level_size(W, H, l, &lw, &lh);
        st = ws_plane(ctx, &levels[l], &ws->cap[l], lw, lh);
    }
    if (st != OBS_STATUS_OK) {
        obs_context_scratch_put(ctx, &gtao_workspace_key, ws, gtao_workspace_destroy);
        return st;
    }
    prefilter_fill(pool, in, &k, levels, !reference && gtao_avx2);
    double t1 = obs_time_now();

    /* ---- 2. MainPass over the window plus one pixel per denoise pass (the denoiser's reach) ---- */
    const int m = k.denoise_passes;
    const int rx0 = in->x0 - m < 0 ? 0 : in->x0 - m, rx1 = in->x0 + in->w - 1 + m > W - 1 ? W - 1 : in->x0 + in->w - 1 + m;
    const int ry0 = in->y0 - m < 0 ? 0 : in->y0 - m, ry1 = in->y0 + in->h - 1 + m > H - 1 ? H - 1 : in->y0 + in->h - 1 + m;
    const int rw = rx1 - rx0 + 1, rh = ry1 - ry0 + 1;
    obs_image_f32 *vis = &ws->plane[WS_VIS], *ping = &ws->plane[WS_PING], *pong = &ws->plane[WS_PONG];
    const main_tables *tables = NULL;
    st = ws_plane(ctx, vis, &ws->cap[WS_VIS], rw, rh);
    if (st == OBS_STATUS_OK) {
        const int ok_e = ws_array((void **)&ws->edges, &ws->edges_cap, (size_t)rw * (size_t)rh, 1);
        const int ok_c = ws_array((void **)&ws->counts, &ws->counts_cap, (size_t)rh, sizeof *ws->counts);
        if (!reference)
            tables = ws_tables(ws, &k);
        if (!ok_e || !ok_c || (!reference && !tables))
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "gtao: out of memory");
    }
    unsigned char *edges = ws->edges;
    int64_t(*counts)[2] = ws->counts;
    if (st == OBS_STATUS_OK) {
        main_job J;
        memset(&J, 0, sizeof J);
        J.k = &k;
        /* XeGTAO_MainPass constants, in its float order (the runtime-constant branch; with
         * XE_GTAO_USE_DEFAULT_CONSTANTS the shader folds the same default values) */
        J.mc.effect_radius = k.effect_radius * k.radius_multiplier;
        const float falloff_range = k.effect_falloff_range * J.mc.effect_radius;
        const float falloff_from = J.mc.effect_radius * (1.0f - k.effect_falloff_range);
        J.mc.falloff_mul = -1.0f / falloff_range;
        J.mc.falloff_add = falloff_from / falloff_range + 1.0f;
        J.mc.min_s_num = 1.3f;
        J.mc.thin_scale = 1.0f + k.thin_occluder_compensation;
        J.levels = levels;
        J.in = in;
        J.rx0 = rx0;
        J.ry0 = ry0;
        J.vis = vis;
        J.edges = edges;
        J.counts = counts;
        J.tables = tables;
        J.avx2 = gtao_avx2;
        obs_pool_run(pool, rh, main_row, &J);
    }
    double t2 = obs_time_now();

    /* ---- 3. Denoise: passes-1 intermediate passes (beta / 5), then the last (beta) ---- */
    const obs_image_f32 *final = vis;
    int fx0 = rx0, fy0 = ry0;
    if (st == OBS_STATUS_OK && m > 0) {
        st = ws_plane(ctx, ping, &ws->cap[WS_PING], rw, rh);
        if (st == OBS_STATUS_OK && m > 1)
            st = ws_plane(ctx, pong, &ws->cap[WS_PONG], rw, rh);
        const obs_image_f32 *src = vis;
        int ax0 = rx0, ay0 = ry0;
        for (int pass = 0; st == OBS_STATUS_OK && pass < m; pass++) {
            const int last = pass == m - 1;
            const int reach = m - 1 - pass; /* what later passes still need around the window */
            const int dx0 = in->x0 - reach < 0 ? 0 : in->x0 - reach;
            const int dx1 = in->x0 + in->w - 1 + reach > W - 1 ? W - 1 : in->x0 + in->w - 1 + reach;
            const int dy0 = in->y0 - reach < 0 ? 0 : in->y0 - reach;
            const int dy1 = in->y0 + in->h - 1 + reach > H - 1 ? H - 1 : in->y0 + in->h - 1 + reach;
            obs_image_f32 *dst = (pass & 1) ? pong : ping;
            obs_image_f32 view = *dst;
            view.width = dx1 - dx0 + 1;
            view.height = dy1 - dy0 + 1;
            denoise_job D;
            D.src = src;
            D.ax0 = ax0;
            D.ay0 = ay0;
            D.dst = &view;
            D.dx0 = dx0;
            D.dy0 = dy0;
            D.W = W;
            D.H = H;
            D.blur_amount = last ? k.denoise_blur_beta : k.denoise_blur_beta / 5.0f;
            D.pack = k.gpu_packing ? (last ? 2 : 1) : 0;
            D.edges = edges;
            D.ex0 = rx0;
            D.ey0 = ry0;
            D.ew = rw;
            /* the reference runs the plain loop over every pixel (the test compares the two) */
            D.skip_bg = last && !reference ? in->depth : NULL;
            D.avx2 = !reference && gtao_avx2;
            obs_pool_run(pool, view.height, denoise_row, &D);
            src = dst;
            ax0 = dx0, ay0 = dy0;
            final = dst;
            fx0 = dx0, fy0 = dy0;
        }
    }
    double t3 = obs_time_now();

    /* ---- 4. The window, clamped to [0, 1]; background exactly 1 ---- */
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < in->h; y++) {
            const int gy = in->y0 + y;
            const float *f = obs_image_f32_row(final, gy - fy0) + (in->x0 - fx0);
            const float *r = obs_image_f32_row(vis, gy - ry0) + (in->x0 - rx0);
            const float *d = obs_image_f32_row(in->depth, gy) + in->x0;
            float *o = obs_image_f32_row(out, y);
            float *orw = out_raw ? obs_image_f32_row(out_raw, y) : NULL;
            int x = 0;
#if GTAO_AVX2
            if (!reference && gtao_avx2)
                for (; x + 8 <= in->w; x += 8)
                    output8_avx2(f + x, r + x, d + x, o + x, orw ? orw + x : NULL, k.gpu_packing && m == 0,
                                 k.gpu_packing);
#endif
            for (; x < in->w; x++) {
                const int bg = is_background(d[x]);
                /* without the denoiser, the packed working term is in XeGTAO's scaled units */
                o[x] = bg ? 1.0f : clamp01((k.gpu_packing && m == 0) ? f[x] * AO_GTAO_OCCLUSION_TERM_SCALE : f[x]);
                if (orw)
                    orw[x] = bg ? 1.0f : clamp01(k.gpu_packing ? r[x] * AO_GTAO_OCCLUSION_TERM_SCALE : r[x]);
            }
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rw * rh;
            for (int r = 0; r < rh; r++) {
                stats->pixels_background += counts[r][0];
                stats->pixels_degenerate_normal += counts[r][1];
            }
            stats->seconds_prefilter = t1 - t0;
            stats->seconds_main = t2 - t1;
            stats->seconds_denoise = t3 - t2;
        }
    }
    obs_context_scratch_put(ctx, &gtao_workspace_key, ws, gtao_workspace_destroy);
    return st;
}

obs_status ao_gtao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_gtao_params *params,
                           obs_image_f32 *out, obs_image_f32 *out_raw, ao_gtao_stats *stats)
{
    return gtao_compute(ctx, pool, in, params, out, out_raw, stats, 0);
}

obs_status ao_gtao_compute_reference(obs_context *ctx, obs_pool *pool, const ao_input *in,
                                     const ao_gtao_params *params, obs_image_f32 *out, obs_image_f32 *out_raw,
                                     ao_gtao_stats *stats)
{
    return gtao_compute(ctx, pool, in, params, out, out_raw, stats, 1);
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_gtao_normals) == sizeof(int), "ENUM params are int-sized");
_Static_assert(sizeof(ao_gtao_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define GT_F(field) offsetof(ao_gtao_params, field)
static const ao_param_desc gtao_param_descs[] = {
    {"slices", AO_PARAM_INT, GT_F(slices), 1, AO_GTAO_MAX_SLICES, NULL,
     "sliceCount (Low 1, Medium 2, High 3, Ultra 9)"},
    {"steps", AO_PARAM_INT, GT_F(steps), 1, AO_GTAO_MAX_STEPS, NULL, "stepsPerSlice, per side (2 or 3)"},
    {"radius", AO_PARAM_FLOAT, GT_F(radius), 1e-6, 1e6, NULL, "Radius: world-space radius (m) of the RT reference"},
    {"radius-multiplier", AO_PARAM_FLOAT, GT_F(radius_multiplier), 0.3, 3.0, NULL,
     "RadiusMultiplier: sampling radius = radius * this"},
    {"falloff-range", AO_PARAM_FLOAT, GT_F(falloff_range), 1e-6, 1.0, NULL,
     "FalloffRange: fraction of the sampling radius over which taps fade"},
    {"sample-distribution-power", AO_PARAM_FLOAT, GT_F(sample_distribution_power), 1.0, 3.0, NULL,
     "SampleDistributionPower: s^p tap spacing"},
    {"thin-occluder-compensation", AO_PARAM_FLOAT, GT_F(thin_occluder_compensation), 0.0, 0.7, NULL,
     "ThinOccluderCompensation: z scale of the falloff distance"},
    {"final-value-power", AO_PARAM_FLOAT, GT_F(final_value_power), 0.5, 5.0, NULL,
     "FinalValuePower: visibility = mean^p"},
    {"depth-mip-sampling-offset", AO_PARAM_FLOAT, GT_F(depth_mip_sampling_offset), 0.0, 30.0, NULL,
     "DepthMIPSamplingOffset: mip = log2(|offset px|) - this"},
    {"normals", AO_PARAM_ENUM, GT_F(normals), 0, 0, normals_names,
     "auto (G-buffer if present, else from depth), depth (XeGTAO_ComputeViewspaceNormal), gbuffer"},
    {"blur", AO_PARAM_BOOL, GT_F(blur), 0, 1, NULL, "XeGTAO_Denoise (3x3 edge-aware) after the main pass"},
    {"denoise-passes", AO_PARAM_INT, GT_F(denoise_passes), 0, 3, NULL,
     "DenoisePasses: 0 (one pass, beta 1e4), 1 sharp, 2 medium, 3 soft"},
    {"frame-index", AO_PARAM_INT, GT_F(frame_index), 0, 1000000000, NULL,
     "frameCounter: noise index = frame % 64 when denoising (TAA); 0 without"},
    {"gpu-packing", AO_PARAM_BOOL, GT_F(gpu_packing), 0, 1, NULL,
     "emulate XeGTAO's 8-bit AO terms and R11G11B10 normals (default: FP32 reference)"},
};
#undef GT_F

static void m_default(void *p) { *(ao_gtao_params *)p = ao_gtao_params_default(); }
static int m_preset(const char *name, void *p) { return ao_gtao_params_preset(name, (ao_gtao_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p) { return ao_gtao_params_validate(ctx, (const ao_gtao_params *)p); }
static int m_to_string(const void *p, char *buf, size_t size) { return ao_gtao_params_to_string((const ao_gtao_params *)p, buf, size); }
static void m_set_samples(void *p, int n)
{
    ao_gtao_params *g = (ao_gtao_params *)p;
    ao_gtao_slices_steps_for_samples(n, &g->slices, &g->steps);
}
static void m_set_radius(void *p, float r) { ((ao_gtao_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_gtao_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_gtao_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* XeGTAO's ReferenceRTAO (vaGTAO_RT.hlsl): cosine-weighted hemisphere rays about the geometric
     * normal, TMax = TotalRaysLength = Radius (no multiplier), binary visibility (albedo 0, 1 bounce) */
    (void)p;
    return "cos";
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_gtao_constants K = ao_gtao_constants_from_params((const ao_gtao_params *)p, in);
    return snprintf(buf, size,
                    "{\"ViewportSize\": [%d, %d], \"ViewportPixelSize\": [%.9g, %.9g], "
                    "\"DepthUnpackConsts\": [%.9g, %.9g], \"CameraTanHalfFOV\": [%.9g, %.9g], "
                    "\"NDCToViewMul\": [%.9g, %.9g], \"NDCToViewAdd\": [%.9g, %.9g], "
                    "\"NDCToViewMul_x_PixelSize\": [%.9g, %.9g], \"EffectRadius\": %.9g, "
                    "\"EffectFalloffRange\": %.9g, \"RadiusMultiplier\": %.9g, \"Padding0\": %.9g, "
                    "\"FinalValuePower\": %.9g, \"DenoiseBlurBeta\": %.9g, \"SampleDistributionPower\": %.9g, "
                    "\"ThinOccluderCompensation\": %.9g, \"DepthMIPSamplingOffset\": %.9g, \"NoiseIndex\": %d, "
                    "\"sliceCount\": %d, \"stepsPerSlice\": %d, \"denoisePassesRun\": %d, "
                    "\"normalsFromGBuffer\": %d, \"orthographic\": %d, \"gpuPacking\": %d, \"centerZPull\": %.9g, "
                    "\"depthClamp\": %.9g, \"noise\": \"HilbertIndex(x, y) level 6 + 288 * NoiseIndex, R2\"}",
                    K.viewport_size[0], K.viewport_size[1], (double)K.viewport_pixel_size[0],
                    (double)K.viewport_pixel_size[1], (double)K.depth_unpack_consts[0],
                    (double)K.depth_unpack_consts[1], (double)K.camera_tan_half_fov[0],
                    (double)K.camera_tan_half_fov[1], (double)K.ndc_to_view_mul[0], (double)K.ndc_to_view_mul[1],
                    (double)K.ndc_to_view_add[0], (double)K.ndc_to_view_add[1],
                    (double)K.ndc_to_view_mul_x_pixel_size[0], (double)K.ndc_to_view_mul_x_pixel_size[1],
                    (double)K.effect_radius, (double)K.effect_falloff_range, (double)K.radius_multiplier,
                    (double)K.padding0, (double)K.final_value_power, (double)K.denoise_blur_beta,
                    (double)K.sample_distribution_power, (double)K.thin_occluder_compensation,
                    (double)K.depth_mip_sampling_offset, K.noise_index, K.slice_count, K.steps_per_slice,
                    K.denoise_passes, K.normals_from_gbuffer, K.orthographic, K.gpu_packing, (double)AO_GTAO_CENTER_Z_PULL,
                    (double)AO_GTAO_DEPTH_CLAMP);
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_gtao_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_gtao_compute(ctx, pool, in, (const ao_gtao_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_prefilter;
        stats->seconds_kernel = s.seconds_main;
        stats->seconds_blur = s.seconds_denoise;
    }
    return st;
}

const ao_method ao_i_method_gtao = {
    .name = "gtao",
    .title = "Ground-Truth AO [Jimenez16] as Intel's XeGTAO computes it (FP32 path)",
    .doc = "docs/ao/gtao.md",
    .params_size = sizeof(ao_gtao_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = gtao_param_descs,
    .param_count = (int)(sizeof gtao_param_descs / sizeof gtao_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* Not exactly 1: XeGTAO_FastACos (error up to 0.055 rad) and 3 noisy slices leave single pixels
     * of an open plane below 1 (values above 1 are clamped). Measured with the registry's planes
     * (96x64, f = 80, 4 px border): facing, worst 1 - 0.0260 (raw) / 0.0196 (denoised), mean 0.9955;
     * tilted 50 degrees, worst 0.0413 / 0.0049, mean 0.9994 (docs/ao/gtao.md) */
    .flat_tolerance = 0.05f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
