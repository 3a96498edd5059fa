/* ao_hbao.c: Horizon-Based Ambient Occlusion [Bavoil08] in two variants, each exact to its
 * reference shader, and the HBAO+-style cross-bilateral blur (docs/ao/hbao.md has every detail).
 *
 *   CLASSIC  NVIDIA DX10 SDK sample, HorizonBasedAOEngine.fx (Bavoil & Sainz),
 *            HORIZON_BASED_AO_PS(useNormal, qualityMode = 1) and AccumulatedHorizonOcclusion.
 *   PLUS     HBAO+'s per-tap estimator as nvpro-samples/gl_ssao hbao.frag.glsl computes it with
 *            AO_DEINTERLEAVED 0 (full resolution; ComputeCoarseAO, ComputeAO, ReconstructNormal).
 *   Blur     HBAOPlus src/shaders/src/Blur_Common.hlsl (CrossBilateralWeight, ProcessRadius1,
 *            USE_DEPTH_SLOPE) and gl_ssao bilateralblur.frag.glsl, separable, point taps.
 *
 * Pixel coordinates: each variant evaluates its per-pixel pattern (noise texel, texture
 * coordinates of the taps, neighbour order) in its reference's own convention: CLASSIC is D3D
 * (SV_Position and texUV with y DOWN: our row y), PLUS is GL (gl_FragCoord and texCoord with
 * y UP: y_gl = H - 1 - y). Planes stay in our row order; fetches convert.
 *
 * Arithmetic is float32 in the shaders' operation order (-ffp-contract=off). Transcendentals are
 * the ideal functions: cos/sin via ao_i_cos_sin, atan/tan/exp2/pow as the double libm result
 * rounded to float, sqrt correctly rounded, inversesqrt as 1/sqrt; round() is round-half-even
 * (D3D round_ne). Deviations from the references are marked "Deviation:" and listed in hbao.md.
 *
 * SIMD: the scalar code is the reference and always compiled. With AVX2 (OBS_HAVE_AVX2, the CPU,
 * OBS_ISA not "scalar") the tap loops, CLASSIC's direction set-up, PLUS's pixel set-up and the blur
 * run 8 pixels of a row per lane group (lane i = pixel x + i), each lane with the scalar float
 * operations in the scalar order (no FMA), taps gathered; exp2/atan/tan are evaluated in double
 * and rounded to float only where that rounding is certain (else libm), so every output bit is
 * the scalar path's (hbao.md "Speed"; test hbao_avx2_paths_give_the_scalar_bits).
 */
#include "ao.h"
#include "ao_internal.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#define HB_HAVE_AVX2 1
#define HB_AVX2 __attribute__((target("avx2")))
#else
#define HB_HAVE_AVX2 0
#endif

#define HBAO_PI_F 3.14159265f /* HorizonBasedAOEngine.fx and hbao.frag.glsl: #define M_PI 3.14159265f */

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_hbao_params ao_hbao_params_default(void)
{
    ao_hbao_params p;
    memset(&p, 0, sizeof p);
    p.variant = AO_HBAO_VARIANT_CLASSIC;
    p.radius = AO_HBAO_DEFAULT_RADIUS;
    p.directions = 0; /* the variant's default: 16 (SDK m_NumDirs) / 8 (gl_ssao NUM_DIRECTIONS) */
    p.steps = 0;      /* 8 (SDK m_NumSteps) / 4 (gl_ssao NUM_STEPS) */
    p.angle_bias_deg = AO_HBAO_DEFAULT_ANGLE_BIAS_DEG;
    p.attenuation = AO_HBAO_DEFAULT_ATTENUATION;
    p.contrast = AO_HBAO_DEFAULT_CONTRAST;
    p.ndotv_bias = AO_HBAO_DEFAULT_NDOTV_BIAS;
    p.pow_exponent = AO_HBAO_DEFAULT_POW_EXPONENT;
    p.small_scale_ao = 0.0f; /* gl_ssao hbao.frag.glsl: one sum over all steps */
    p.normals = AO_HBAO_NORMALS_DEPTH;
    p.blur = 1;
    p.blur_radius = AO_HBAO_DEFAULT_BLUR_RADIUS;
    p.blur_sharpness = AO_HBAO_DEFAULT_BLUR_SHARPNESS;
    p.blur_sigma = 0.0f; /* (KERNEL_RADIUS + 1) / 2, Blur_Common.hlsl CrossBilateralWeight */
    p.blur_depth_slope = 1; /* Blur_Common.hlsl #define USE_DEPTH_SLOPE 1 */
    return p;
}

static const char *const hbao_preset_names[] = {"default", "sdk", "plus", "hbaoplus", "gl-ssao", NULL};

const char *const *ao_hbao_preset_names(void) { return hbao_preset_names; }

int ao_hbao_params_preset(const char *name, ao_hbao_params *out)
{
    if (!name || !out)
        return 0;
    ao_hbao_params p = ao_hbao_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "sdk")) {
        /* HorizonBasedAOEngine constructor (verification.md 2) */
    } else if (!strcmp(name, "plus") || !strcmp(name, "hbaoplus")) {
        /* GFSDK_SSAO.h GFSDK_SSAO_Parameters(): Radius(1.f), Bias(0.1f), PowerExponent(2.f),
         * StepCount 4; Blur: Radius 4, Sharpness(16.f); Blur_Common.hlsl USE_DEPTH_SLOPE 1 */
        p.variant = AO_HBAO_VARIANT_PLUS;
        p.radius = 1.0f;
        p.ndotv_bias = 0.1f;
        p.pow_exponent = 2.0f;
        p.blur_radius = 4;
        p.blur_sharpness = 16.0f;
        p.blur_depth_slope = 1;
        /* GFSDK_SSAO_Parameters SmallScaleAO(1.f), LargeScaleAO(1.f) (CoarseAO_PS.hlsl split) */
        p.small_scale_ao = !strcmp(name, "hbaoplus") ? 1.0f : 0.0f;
    } else if (!strcmp(name, "gl-ssao")) {
        /* gl_ssao ssao.cpp Tweak: intensity 1.5, bias 0.1, radius 2.0, blurSharpness 40;
         * bilateralblur.frag.glsl KERNEL_RADIUS 3, BlurSigma = KERNEL_RADIUS * 0.5, no slope */
        p.variant = AO_HBAO_VARIANT_PLUS;
        p.radius = 2.0f;
        p.ndotv_bias = 0.1f;
        p.pow_exponent = 1.5f;
        p.blur_radius = 3;
        p.blur_sigma = 1.5f;
        p.blur_sharpness = 40.0f;
        p.blur_depth_slope = 0;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

static int resolved_dirs(const ao_hbao_params *p)
{
    if (p->directions > 0)
        return p->directions;
    return p->variant == AO_HBAO_VARIANT_PLUS ? AO_HBAO_DEFAULT_DIRECTIONS_PLUS : AO_HBAO_DEFAULT_DIRECTIONS_CLASSIC;
}

static int resolved_steps(const ao_hbao_params *p)
{
    if (p->steps > 0)
        return p->steps;
    return p->variant == AO_HBAO_VARIANT_PLUS ? AO_HBAO_DEFAULT_STEPS_PLUS : AO_HBAO_DEFAULT_STEPS_CLASSIC;
}

obs_status ao_hbao_params_validate(obs_context *ctx, const ao_hbao_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: NULL params");
    if ((unsigned)p->variant >= AO_HBAO_VARIANT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: unknown variant %d", (int)p->variant);
    const float r2 = p->radius * p->radius;
    if (!(p->radius > 0.0f) || !isfinite(p->radius) || !(r2 >= 1e-30f) || !isfinite(r2))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "hbao: radius %g must be > 0 with radius^2 a finite normal float (about 1e-15 .. 1e19)",
                         (double)p->radius);
    if (p->directions < 0 || p->directions > AO_HBAO_MAX_DIRECTIONS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: directions %d must be in [1, %d] (0 = the variant's)",
                         p->directions, AO_HBAO_MAX_DIRECTIONS);
    if (p->steps < 0 || p->steps > AO_HBAO_MAX_STEPS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: steps %d must be in [1, %d] (0 = the variant's)",
                         p->steps, AO_HBAO_MAX_STEPS);
    if (!(p->angle_bias_deg >= 0.0f && p->angle_bias_deg <= 89.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: angle bias %g must be in [0, 89] degrees",
                         (double)p->angle_bias_deg);
    if (!(p->attenuation >= 0.0f) || !isfinite(p->attenuation))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: attenuation %g must be finite and >= 0",
                         (double)p->attenuation);
    if (!(p->contrast >= 0.0f) || !isfinite(p->contrast))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: contrast %g must be finite and >= 0",
                         (double)p->contrast);
    if (!(p->ndotv_bias >= 0.0f && p->ndotv_bias < 1.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: ndotv bias %g must be in [0, 1)",
                         (double)p->ndotv_bias);
    if (!(p->pow_exponent >= 0.0f) || !isfinite(p->pow_exponent))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: pow exponent %g must be finite and >= 0",
                         (double)p->pow_exponent);
    if (!(p->small_scale_ao >= 0.0f && p->small_scale_ao <= 2.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "hbao: small scale ao %g must be in [0, 2] (0 = gl_ssao's unsplit sum; HBAO+ clamps to [0, 2])",
                         (double)p->small_scale_ao);
    if ((unsigned)p->normals >= AO_HBAO_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: unknown normals mode %d", (int)p->normals);
    if ((unsigned)p->noise >= AO_HBAO_NOISE_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: unknown noise texture %d (auto, sdk, gl-ssao)",
                         (int)p->noise);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: blur %d must be 0 or 1", p->blur);
    if (p->blur_radius < 1 || p->blur_radius > AO_HBAO_MAX_BLUR_RADIUS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: blur radius %d must be in [1, %d]", p->blur_radius,
                         AO_HBAO_MAX_BLUR_RADIUS);
    if (!(p->blur_sharpness >= 0.0f) || !isfinite(p->blur_sharpness))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: blur sharpness %g must be finite and >= 0",
                         (double)p->blur_sharpness);
    if (!(p->blur_sigma == 0.0f || (p->blur_sigma >= 0.01f && p->blur_sigma <= 1e4f)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "hbao: blur sigma %g must be 0 (= (radius + 1) / 2) or in [0.01, 1e4] pixels",
                         (double)p->blur_sigma);
    if (p->blur_depth_slope != 0 && p->blur_depth_slope != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: blur depth slope %d must be 0 or 1",
                         p->blur_depth_slope);
    return OBS_STATUS_OK;
}

static float resolved_sigma(const ao_hbao_params *p)
{
    /* Blur_Common.hlsl: const float BlurSigma = ((float)KERNEL_RADIUS+1.0) * 0.5 */
    return p->blur_sigma > 0.0f ? p->blur_sigma : ((float)p->blur_radius + 1.0f) * 0.5f;
}

int ao_hbao_params_to_string(const ao_hbao_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "variant=%s radius=%.9g directions=%d steps=%d angle_bias_deg=%.9g attenuation=%.9g "
                    "contrast=%.9g ndotv_bias=%.9g pow_exponent=%.9g small_scale_ao=%.9g normals=%s noise=%s blur=%d blur_radius=%d "
                    "blur_sharpness=%.9g blur_sigma=%.9g blur_depth_slope=%d",
                    p->variant == AO_HBAO_VARIANT_PLUS ? "plus" : "classic", (double)p->radius, resolved_dirs(p),
                    resolved_steps(p), (double)p->angle_bias_deg, (double)p->attenuation, (double)p->contrast,
                    (double)p->ndotv_bias, (double)p->pow_exponent, (double)p->small_scale_ao,
                    p->normals == AO_HBAO_NORMALS_GBUFFER ? "gbuffer" : "depth",
                    (p->noise == AO_HBAO_NOISE_SDK || (p->noise == AO_HBAO_NOISE_AUTO && p->variant != AO_HBAO_VARIANT_PLUS))
                        ? "sdk"
                        : "gl-ssao",
                    p->blur, p->blur_radius,
                    (double)p->blur_sharpness, (double)resolved_sigma(p), p->blur_depth_slope);
}

static inline float f_atan(float x) { return (float)atan((double)x); }
static inline float f_tan(float x) { return (float)tan((double)x); }
static inline float f_exp2(float x) { return (float)exp2((double)x); }

/* (float)exp2((double)x), fast and bit-identical (the blur's weights). 2^x = 2^n 2^f, n = rint(x),
 * |f| <= 1/2, 2^f by its Taylor series to degree 13 in double (truncation < 2e-17, Horner
 * rounding a few ulp: relative error below 2^-50), which glibc's exp2 (< 1 ulp) also is. The float
 * rounding of the exact 2^x is then certain unless a float rounding boundary lies within
 * 2^-46 (relative) of our double: we check that y (1 - 2^-46) and y (1 + 2^-46) round to the same
 * float, and else call libm (1.5e-5 of the floats in [-160, 0], measured). x < -151 gives +0 (2^x < 2^-150, half the
 * least subnormal), NaN and x > 127 go to libm. The AVX2 version (hb_exp2f8) gets there with a table. */
#define HB_EXP2_SAFE_LO (1.0 - 0x1p-46)
#define HB_EXP2_SAFE_HI (1.0 + 0x1p-46)
static const double hb_exp2_c[14] = {
    1.0, 0.6931471805599453, 0.24022650695910072, 0.05550410866482158, 0.009618129107628477,
    0.0013333558146428443, 0.0001540353039338161, 1.5252733804059841e-05, 1.321548679014431e-06,
    1.01780860092397e-07, 7.054911620801123e-09, 4.4455382718708116e-10, 2.5678435993488206e-11,
    1.3691488853904128e-12}; /* ln(2)^k / k!, correctly rounded */

static inline float hb_exp2f(float x)
{
    if (!(x >= -151.0f))
        return x != x ? f_exp2(x) : 0.0f;
    if (!(x <= 127.0f))
        return f_exp2(x);
    const double xd = (double)x;
    const double n = (xd + 6755399441055744.0) - 6755399441055744.0; /* rint: 1.5 * 2^52 */
    const double f = xd - n;                                        /* exact */
    double p = hb_exp2_c[13];
    for (int i = 12; i >= 0; i--)
        p = p * f + hb_exp2_c[i];
    const uint64_t bits = (uint64_t)((int64_t)n + 1023) << 52;
    double sc;
    memcpy(&sc, &bits, sizeof sc);
    const double y = p * sc;
    const float lo = (float)(y * HB_EXP2_SAFE_LO), hi = (float)(y * HB_EXP2_SAFE_HI);
    return lo == hi ? lo : f_exp2(x);
}
static inline float f_sin(float x)
{
    float c, s;
    ao_i_cos_sin(x, &c, &s);
    return s;
}

ao_hbao_constants ao_hbao_constants_from_params(const ao_hbao_params *p, const ao_input *in)
{
    ao_hbao_constants k;
    memset(&k, 0, sizeof k);
    const double W = in->width, H = in->height;
    k.full_width = in->width;
    k.full_height = in->height;
    k.variant = (int)p->variant;
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.normals_from_gbuffer = p->normals == AO_HBAO_NORMALS_GBUFFER;
    k.num_dirs = resolved_dirs(p);
    k.num_steps = resolved_steps(p);
    /* uv -> view. Our pixel model: x_view = (x + 0.5 - cx)/fx * d, y_view = -(y + 0.5 - cy)/fy * d.
     * CLASSIC (D3D uv, y down): HBAO+ SetProjectionConstants' UVToViewA/B form, (2 tanX, -2 tanY,
     * -tanX, tanY) for a centred frustum. PLUS (GL uv, y up): gl_ssao projInfo
     * (2/P00, 2/P11, -(1 - P20)/P00, -(1 + P21)/P11). */
    if (p->variant == AO_HBAO_VARIANT_CLASSIC) {
        k.uv_to_view[0] = (float)(W / in->fx);
        k.uv_to_view[1] = (float)(-H / in->fy);
        k.uv_to_view[2] = (float)(-in->cx / in->fx);
        k.uv_to_view[3] = (float)(in->cy / in->fy);
    } else {
        k.uv_to_view[0] = (float)(W / in->fx);
        k.uv_to_view[1] = (float)(H / in->fy);
        k.uv_to_view[2] = (float)(-in->cx / in->fx);
        k.uv_to_view[3] = (float)(-(H - in->cy) / in->fy);
    }
    k.resolution[0] = (float)in->width;
    k.resolution[1] = (float)in->height;
    k.inv_resolution[0] = 1.0f / (float)in->width;
    k.inv_resolution[1] = 1.0f / (float)in->height;
    /* CLASSIC cb1 (HorizonBasedAOEngine.cpp Update*): g_FocalLen = 1/tan(fov/2) per axis, which is
     * 2 f / size in our pixel model; g_R = R; g_inv_R = 1/R; g_sqr_R = R^2 */
    k.focal_len[0] = (float)(2.0 * in->fx / W);
    k.focal_len[1] = (float)(2.0 * in->fy / H);
    k.R = p->radius;
    k.inv_R = 1.0f / p->radius;
    k.sqr_R = p->radius * p->radius;
    k.angle_bias = (float)((double)p->angle_bias_deg * OBS_PI / 180.0);
    k.tan_angle_bias = f_tan(k.angle_bias);
    k.attenuation = p->attenuation;
    /* UpdateContrast: g_Contrast = m_Contrast / (1.0f - sin(angleBias)) (verification.md 2) */
    k.contrast = p->contrast / (1.0f - f_sin(k.angle_bias));
    /* cb0 g_Dirs (HorizonBasedAOEngine.cpp UpdateDirs): float inc = 2.0f * D3DX_PI / (float)m_NumDirs;
     * float angle = inc*(float)(i/2); dirs = cos(angle), sin(angle) (C++ float overloads: cosf, sinf) */
    {
        const float inc = 2.0f * 3.141592654f / (float)k.num_dirs;
        for (int d = 0; d < k.num_dirs; d++)
            ao_i_cos_sin(inc * (float)d, &k.dirs[d][0], &k.dirs[d][1]);
    }
    /* the random texture: AUTO = the variant's reference (CLASSIC the SDK's 64 x 64, PLUS gl_ssao's 4 x 4) */
    k.noise = p->noise == AO_HBAO_NOISE_AUTO
                  ? (p->variant == AO_HBAO_VARIANT_PLUS ? AO_HBAO_NOISE_GL_SSAO : AO_HBAO_NOISE_SDK)
                  : (int)p->noise;
    k.noise_size = k.noise == AO_HBAO_NOISE_SDK ? AO_HBAO_NOISE_SIZE_SDK : AO_HBAO_NOISE_SIZE;
    /* PLUS HBAOData (HBAO+ SetAORadiusConstants / SetAOParameters; gl_ssao prepareHbaoData):
     * RadiusToScreen = R * 0.5f / TanHalfFovy * Height = R fy; R2; NegInvR2 = -1 / R2;
     * AOMultiplier = 1 / (1 - NDotVBias). Orthographic: gl_ssao projScale = H / projInfo[1] = fy. */
    k.radius_to_screen = p->radius * (float)in->fy;
    k.R2 = p->radius * p->radius;
    k.neg_inv_R2 = -1.0f / k.R2;
    k.ndotv_bias = p->ndotv_bias;
    k.ao_multiplier = 1.0f / (1.0f - p->ndotv_bias);
    k.pow_exponent = p->pow_exponent;
    /* HBAO+ SetAOParameters: fSmallScaleAOAmount = Small * AOAmountScaleFactor * 2.f,
     * fLargeScaleAOAmount = Large * AOAmountScaleFactor, AOAmountScaleFactor = 1 / (1 - bias) */
    k.small_scale_amount = p->small_scale_ao > 0.0f ? p->small_scale_ao * k.ao_multiplier * 2.0f : 0.0f;
    k.large_scale_amount = p->small_scale_ao > 0.0f ? 1.0f * k.ao_multiplier : 0.0f;
    k.alpha = 2.0f * HBAO_PI_F / (float)k.num_dirs; /* const float Alpha = 2.0 * M_PI / NUM_DIRECTIONS */
    for (int d = 0; d < k.num_dirs; d++) /* Angle = Alpha * DirectionIndex; cos(Angle), sin(Angle) */
        ao_i_cos_sin(k.alpha * (float)d, &k.plus_dirs[d][0], &k.plus_dirs[d][1]);
    /* Blur */
    k.blur = p->blur != 0;
    k.blur_radius = p->blur_radius;
    k.blur_depth_slope = p->blur_depth_slope != 0;
    k.blur_sharpness = p->blur_sharpness;
    const float sigma = resolved_sigma(p);
    k.blur_falloff = 1.0f / (2.0f * sigma * sigma); /* BlurFalloff = 1.0 / (2.0*BlurSigma*BlurSigma) */
    return k;
}

/* ================================================================================================
 * The random texture
 * ============================================================================================== */

/* MT19937 [Matsumoto98], init_genrand / genrand_int32 (mt19937ar.c): the generator of Wagner's
 * MTRand (MersenneTwister.h) that both references use, MTRand::seed(0): the DX10 SDK sample's
 * HorizonBasedAOEngine.cpp (a global MTRand rng, rng.seed((unsigned)0) in UpdateDirs) and
 * gl_ssao's noise/mersennetwister1.h. Tested against the published outputs (ao_internal.h). */
void ao_i_mt19937_seed(ao_i_mt19937 *m, uint32_t seed)
{
    m->s[0] = seed;
    for (int i = 1; i < 624; i++) /* mt[i] = 1812433253 * (mt[i-1] ^ (mt[i-1] >> 30)) + i */
        m->s[i] = 1812433253u * (m->s[i - 1] ^ (m->s[i - 1] >> 30)) + (uint32_t)i;
    m->i = 624;
}

uint32_t ao_i_mt19937_next(ao_i_mt19937 *m)
{
    if (m->i >= 624) { /* regenerate the 624 words: UPPER_MASK 0x80000000, LOWER_MASK 0x7fffffff, MATRIX_A */
        for (int k = 0; k < 624; k++) {
            uint32_t y = (m->s[k] & 0x80000000u) | (m->s[(k + 1) % 624] & 0x7fffffffu);
            m->s[k] = m->s[(k + 397) % 624] ^ (y >> 1) ^ ((y & 1u) ? 0x9908b0dfu : 0u);
        }
        m->i = 0;
    }
    uint32_t y = m->s[m->i++]; /* tempering */
    y ^= y >> 11;
    y ^= (y << 7) & 0x9d2c5680u;
    y ^= (y << 15) & 0xefc60000u;
    y ^= y >> 18;
    return y;
}

/* GL_RGBA16_SNORM upload of gl_ssao initMisc: (signed short)(SCALE * v), SCALE = 1 << 15,
 * truncation toward zero (v a float, or the SDK's double jitter: the product is exact either way).
 * 32768 * 1.0 does not fit a short (C++ leaves it undefined); we clamp to 32767 (not reached by the
 * 16 texels of any direction count 1..32, nor by a jitter < 1). */
static int16_t snorm16_encode(double v)
{
    const double s = 32768.0 * v;
    if (s >= 32767.0)
        return 32767;
    if (s <= -32768.0)
        return -32768;
    return (int16_t)s;
}

/* GL 4.4 section 2.3.5.2: f = max(c / (2^15 - 1), -1.0) */
static float snorm16_decode(int16_t c)
{
    float f = (float)((double)c / 32767.0);
    return f < -1.0f ? -1.0f : f;
}

/* Texel i of a random texture: the shorts to upload (may be NULL) and the decoded floats (may be NULL). */
static void noise_store(int i, const int16_t q[4], int16_t *shorts, float (*texels)[4])
{
    for (int ch = 0; ch < 4; ch++) {
        if (shorts)
            shorts[4 * i + ch] = q[ch];
        if (texels)
            texels[i][ch] = snorm16_decode(q[ch]);
    }
}

void ao_hbao_noise_texture(int num_dirs, int16_t shorts[AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE * 4],
                           float texels[AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE][4])
{
    if (num_dirs < 1)
        num_dirs = 1;
    ao_i_mt19937 m;
    ao_i_mt19937_seed(&m, 0u);
    for (int i = 0; i < AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE; i++) {
        /* float Rand1 = rng.randExc(); float Rand2 = rng.randExc();  (double(randInt()) * 2^-32) */
        const float r1 = (float)((double)ao_i_mt19937_next(&m) * (1.0 / 4294967296.0));
        const float r2 = (float)((double)ao_i_mt19937_next(&m) * (1.0 / 4294967296.0));
        /* float Angle = 2.f * nv_pi * Rand1 / numDir; (cosf, sinf)(Angle) */
        const float angle = 2.0f * HBAO_PI_F * r1 / (float)num_dirs;
        float c, s;
        ao_i_cos_sin(angle, &c, &s);
        const int16_t q[4] = {snorm16_encode(c), snorm16_encode(s), snorm16_encode(r2), 0};
        noise_store(i, q, shorts, texels);
    }
}

/* (signed short)(SCALE * v) of a float v in [-1, 1] as the SDK's compiler (MSVC, x86/x64) converts
 * it: float -> 32-bit int (truncation, cvttss2si), then the low 16 bits. 32768 * 1.0 = 32768 does not
 * fit a short (undefined in C++): it becomes -32768, which decodes to -1. This happens where
 * cosf(angle) rounds to 1 (angle < 2.5e-4 rad: 4 of the 4096 texels for N_d = 16), turning that
 * texel's rotation by pi (hbao.md, "The random texture"). */
static int16_t snorm16_encode_msvc(float v)
{
    const float s = 32768.0f * v; /* exact */
    const int32_t i = (int32_t)s; /* |s| <= 32768 */
    const uint32_t lo = (uint32_t)i & 0xFFFFu;
    return lo >= 0x8000u ? (int16_t)((int32_t)lo - 65536) : (int16_t)lo;
}

void ao_hbao_noise_texture_sdk(int num_dirs, int16_t shorts[AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK * 4],
                               float texels[AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK][4])
{
    if (num_dirs < 1)
        num_dirs = 1;
    ao_i_mt19937 m;
    ao_i_mt19937_seed(&m, 0u); /* rng.seed((unsigned)0) */
    /* D3DX_PI = ((FLOAT)3.141592654f); 2.0f*D3DX_PI in float (exact doubling) */
    const double two_pi_f = (double)(2.0f * 3.141592654f);
    for (int i = 0; i < AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK; i++) {
        /* float angle = 2.0f*D3DX_PI * rng.randExc() / (float)m_NumDirs;  float * double -> double,
         * / float -> double, assigned to float (one rounding) */
        const double r1 = (double)ao_i_mt19937_next(&m) * (1.0 / 4294967296.0);
        const float angle = (float)(two_pi_f * r1 / (double)(float)num_dirs);
        /* f[i] = (signed short)(SCALE*cos(angle)): cos of a float is C++'s float overload (cosf),
         * SCALE * float in float (exact: a power of two), truncated */
        float c, s;
        ao_i_cos_sin(angle, &c, &s);
        /* f[i+2] = (signed short)(SCALE*rng.randExc()): int * double, exact, truncated */
        const double r2 = (double)ao_i_mt19937_next(&m) * (1.0 / 4294967296.0);
        const int16_t q[4] = {snorm16_encode_msvc(c), snorm16_encode_msvc(s), snorm16_encode(r2), 0};
        noise_store(i, q, shorts, texels);
    }
}

int ao_hbao_noise_index(const ao_hbao_constants *k, int x, int y)
{
    /* CLASSIC: tRandom.Load(int3((int)IN.pos.x & 63, (int)IN.pos.y & 63, 0)), D3D rows (64 x 64: the
     * SDK's; & 3 with gl_ssao's 4 x 4); PLUS: textureLod(texRandom, gl_FragCoord.xy / AO_RANDOMTEX_SIZE, 0),
     * REPEAT + NEAREST, GL rows */
    const int n = k->noise_size == AO_HBAO_NOISE_SIZE_SDK ? AO_HBAO_NOISE_SIZE_SDK : AO_HBAO_NOISE_SIZE;
    const int iy = k->variant == AO_HBAO_VARIANT_PLUS ? k->full_height - 1 - y : y;
    return (iy & (n - 1)) * n + (x & (n - 1));
}

/* ================================================================================================
 * The AO pass
 * ============================================================================================== */

typedef struct hbao_job {
    const ao_hbao_constants *k;
    const ao_input *in;
    const obs_image_f32 *z;        /* linear depth, background = +inf, full buffer, our rows */
    float noise[AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK][4]; /* the resolved texture (first 16 for 4 x 4) */
    int rx0, ry0;                  /* region origin (our coordinates) */
    obs_image_f32 *ao;             /* region-sized, our rows */
    int64_t (*counts)[3];          /* per row: background, small radius, degenerate normal */
    int avx2;                      /* 1: the 8-pixel AVX2 tap loops (bit-identical to the scalar ones) */
} hbao_job;

typedef struct v3 {
    float x, y, z;
} v3;

static inline v3 v3_sub(v3 a, v3 b) { return (v3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline float v3_dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline float clampf01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; } /* NaN -> 0 */

/* Point sampling with CLAMP addressing: texel floor(u * size), clamped (NaN -> 0). */
static inline int texel_of(float u, float size, int n)
{
    const float t = u * size;
    if (!(t >= 0.0f))
        return 0;
    if (t >= (float)n)
        return n - 1;
    return (int)t;
}

/* fetch_eye_pos / FetchViewPos: the texel's depth, the position at the UNCLAMPED uv. gl: the v
 * coordinate is GL (row from the bottom). */
static inline v3 fetch_pos(const ao_hbao_constants *k, const obs_image_f32 *z, float u, float v, int gl)
{
    const int W = k->full_width, H = k->full_height;
    const int tx = texel_of(u, k->resolution[0], W);
    int ty = texel_of(v, k->resolution[1], H);
    if (gl)
        ty = H - 1 - ty;
    const float d = obs_image_f32_row(z, ty)[tx];
    /* uv_to_eye / UVToView: vec3((uv * A + B) * eye_z, eye_z); orthographic: no "* eye_z" */
    const float ax = u * k->uv_to_view[0] + k->uv_to_view[2], ay = v * k->uv_to_view[1] + k->uv_to_view[3];
    if (!k->orthographic)
        return (v3){ax * d, ay * d, d};
    return (v3){ax, ay, d};
}

/* min_diff / MinDiff: the shorter of the one-sided differences. Deviation (background only):
 * a NaN length (a background neighbour at +inf whose x or y is 0 * inf) loses, as a neighbour at
 * a large finite far depth would on a GPU. */
static inline v3 min_diff(v3 P, v3 Pr, v3 Pl)
{
    const v3 V1 = v3_sub(Pr, P), V2 = v3_sub(P, Pl);
    const float l1 = v3_dot(V1, V1), l2 = v3_dot(V2, V2);
    return (l1 < l2 || l2 != l2) ? V1 : V2;
}

/* snap_uv_offset: round(uv * g_Resolution) * g_InvResolution (HLSL round = round_ne) */
static inline float snap(float u, float res, float inv) { return rintf(u * res) * inv; }

/* ---- CLASSIC: HorizonBasedAOEngine.fx ----
 * Split in three steps so that the AVX2 path shares the per-pixel and per-direction set-up with
 * the scalar one and only runs the tap loop 8 pixels at a time: classic_setup (the pixel),
 * classic_dir (one direction's start, increment and horizon), classic_taps (the steps). */

typedef struct classic_px {
    float u0, v0;          /* IN.texUV */
    v3 P, dPdu, dPdv;
    float sx, sy;          /* step_size (uv), already divided by numSteps + 1 */
    float numSteps;        /* not an integer in general */
    const float *rd;       /* (cos(alpha), sin(alpha), jitter) */
} classic_px;

typedef struct classic_ray {
    float u, v, du, dv;    /* start (jittered, snapped) and snapped increment */
    float tanH, sinH;      /* the biased tangent's horizon */
    int valid;             /* 0: the direction adds 0 (degenerate basis or horizon at pi/2) */
} classic_ray;

/* tangent_eye_pos: intersect the view ray through uv with the tangent plane (N, w), except for
 * silhouette edges (NdotV >= 0) */
static inline v3 tangent_eye_pos(const ao_hbao_constants *k, const obs_image_f32 *z, float u, float v, v3 N, float w)
{
    v3 V = fetch_pos(k, z, u, v, 0);
    const float NdotV = v3_dot(N, V);
    if (NdotV < 0.0f) {
        const float s = w / NdotV;
        V = (v3){V.x * s, V.y * s, V.z * s};
    }
    return V;
}

/* HORIZON_BASED_AO_PS up to the direction loop. Returns 0 with *early set when the pixel is done. */
static int classic_setup(const hbao_job *J, int x, int y, classic_px *c, float *early, int64_t *n_small,
                         int64_t *n_degen)
{
    const ao_hbao_constants *k = J->k;
    const obs_image_f32 *z = J->z;
    /* IN.texUV at the pixel centre (D3D: y down) */
    const float u0 = ((float)x + 0.5f) / k->resolution[0], v0 = ((float)y + 0.5f) / k->resolution[1];
    const v3 P = fetch_pos(k, z, u0, v0, 0);
    /* Project the radius of influence g_R from eye space to texture space:
     * step_size = 0.5 * g_R * g_FocalLen / P.z (orthographic extension: no "/ P.z") */
    float sx = 0.5f * k->R * k->focal_len[0], sy = 0.5f * k->R * k->focal_len[1];
    if (!k->orthographic) {
        sx = sx / P.z;
        sy = sy / P.z;
    }
    /* Early out if the projected radius is smaller than 1 pixel */
    const float m = fminf(sx * k->resolution[0], sy * k->resolution[1]);
    const float numSteps = fminf((float)k->num_steps, m);
    if (!(numSteps >= 1.0f)) {
        (*n_small)++;
        *early = 1.0f;
        return 0;
    }
    sx = sx / (numSteps + 1.0f);
    sy = sy / (numSteps + 1.0f);

    /* Nearest neighbor pixels (on the tangent plane with normals) */
    const float iu = k->inv_resolution[0], iv = k->inv_resolution[1];
    v3 Pr, Pl, Pt, Pb;
    if (k->normals_from_gbuffer) {
        /* N = normalize(tNormal): our view-space normal in the sample's eye space (z into the screen) */
        const float *n0 = obs_image_f32_row(J->in->normal[0], y), *n1 = obs_image_f32_row(J->in->normal[1], y),
                    *n2 = obs_image_f32_row(J->in->normal[2], y);
        v3 N = {n0[x], n1[x], -n2[x]};
        const float l2 = v3_dot(N, N);
        if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
            (*n_degen)++;
            *early = 1.0f; /* no usable G-buffer normal */
            return 0;
        }
        const float inv = 1.0f / sqrtf(l2);
        N = (v3){N.x * inv, N.y * inv, N.z * inv};
        const float w = v3_dot(P, N); /* tangentPlane = float4(N, dot(P, N)) */
        Pr = tangent_eye_pos(k, z, u0 + iu, v0, N, w);
        Pl = tangent_eye_pos(k, z, u0 + -iu, v0, N, w);
        Pt = tangent_eye_pos(k, z, u0, v0 + iv, N, w);
        Pb = tangent_eye_pos(k, z, u0, v0 + -iv, N, w);
    } else {
        Pr = fetch_pos(k, z, u0 + iu, v0, 0);
        Pl = fetch_pos(k, z, u0 + -iu, v0, 0);
        Pt = fetch_pos(k, z, u0, v0 + iv, 0);
        Pb = fetch_pos(k, z, u0, v0 + -iv, 0);
    }
    /* Screen-aligned basis for the tangent plane: dPdu = min_diff(P, Pr, Pl),
     * dPdv = min_diff(P, Pt, Pb) * (g_Resolution.y * g_InvResolution.x) */
    const v3 dPdu = min_diff(P, Pr, Pl);
    v3 dPdv = min_diff(P, Pt, Pb);
    const float aspect = k->resolution[1] * k->inv_resolution[0];
    dPdv = (v3){dPdv.x * aspect, dPdv.y * aspect, dPdv.z * aspect};
    c->u0 = u0;
    c->v0 = v0;
    c->P = P;
    c->dPdu = dPdu;
    c->dPdv = dPdv;
    c->sx = sx;
    c->sy = sy;
    c->numSteps = numSteps;
    c->rd = J->noise[ao_hbao_noise_index(k, x, y)];
    return 1;
}

/* The direction loop's body up to AccumulatedHorizonOcclusion's step loop (qualityMode 1) */
static inline void classic_dir(const ao_hbao_constants *k, const classic_px *c, int d, classic_ray *o)
{
    const float *rd = c->rd;
    /* deltaUV = rotate(g_Dirs[d], rand_Dir.xy) * step_size.xy */
    float du = (k->dirs[d][0] * rd[0] - k->dirs[d][1] * rd[1]) * c->sx;
    float dv = (k->dirs[d][0] * rd[1] + k->dirs[d][1] * rd[0]) * c->sy;
    /* Randomize starting point within the first sample distance: uv = uv0 + snap_uv_offset(randstep * deltaUV) */
    o->u = c->u0 + snap(rd[2] * du, k->resolution[0], k->inv_resolution[0]);
    o->v = c->v0 + snap(rd[2] * dv, k->resolution[1], k->inv_resolution[1]);
    /* Snap increments to pixels: deltaUV = snap_uv_offset(deltaUV) */
    du = snap(du, k->resolution[0], k->inv_resolution[0]);
    dv = snap(dv, k->resolution[1], k->inv_resolution[1]);
    o->du = du;
    o->dv = dv;
    o->valid = 0;
    o->tanH = o->sinH = 0.0f;
    /* Compute tangent vector using the tangent plane: T = deltaUV.x * dPdu + deltaUV.y * dPdv */
    const v3 dPdu = c->dPdu, dPdv = c->dPdv;
    const v3 T = {du * dPdu.x + dv * dPdv.x, du * dPdu.y + dv * dPdv.y, du * dPdu.z + dv * dPdv.z};
    /* biased_tangent: phi = atan(tangent(T)) + g_AngleBias; tan(min(phi, M_PI*0.5)),
     * tangent(T) = -T.z / length(T.xy) */
    const float tanT = -T.z / sqrtf(T.x * T.x + T.y * T.y);
    if (!isfinite(tanT))
        return; /* Deviation: a degenerate tangent basis (background on both sides) adds 0 */
    const float phi = f_atan(tanT) + k->angle_bias;
    /* Deviation: tan(min(phi, M_PI*0.5)) with M_PI*0.5 = 1.57079637f, 4.4e-8 ABOVE pi/2: an exact
     * tan gives -2.3e7 there (the horizon flips to straight down and every tap counts), a GPU's
     * sin/cos approximation either sign. We take the intended limit: a vertical horizon, tanH =
     * +inf, sinH = 1, so no tap counts (hbao.md, "Differences"). */
    if (!(phi < HBAO_PI_F * 0.5f))
        return;
    const float tanH = f_tan(phi);
    o->tanH = tanH;
    o->sinH = tanH / sqrtf(1.0f + tanH * tanH);
    o->valid = 1;
}

/* AccumulatedHorizonOcclusion's step loop */
static float classic_taps(const ao_hbao_constants *k, const obs_image_f32 *z, const classic_px *c,
                          const classic_ray *o)
{
    if (!o->valid)
        return 0.0f;
    const v3 P = c->P;
    const float du = o->du, dv = o->dv, numSteps = c->numSteps;
    float u = o->u, v = o->v, tanH = o->tanH, sinH = o->sinH;
    float ao = 0.0f;
    /* for (float j = 1; j <= numSteps; ++j): numSteps is not an integer in general */
    for (float j = 1.0f; j <= numSteps; j += 1.0f) {
        u += du;
        v += dv;
        const v3 S = fetch_pos(k, z, u, v, 0);
        /* Ignore any samples outside the radius of influence */
        const v3 D = v3_sub(S, P);
        const float d2 = v3_dot(D, D);
        if (d2 < k->sqr_R) {
            /* tangent(P, S) = (P.z - S.z) / length(S.xy - P.xy) */
            const float dx = S.x - P.x, dy = S.y - P.y;
            const float tanS = (P.z - S.z) / sqrtf(dx * dx + dy * dy);
            if (tanS > tanH && tanS < INFINITY) {
                /* Accumulate AO between the horizon and the sample: ao += falloff(r) * (sinS - sinH),
                 * sinS = tanS / sqrt(1 + tanS^2), r = sqrt(d2) * g_inv_R, falloff = 1 - att r r */
                const float sinS = tanS / sqrtf(1.0f + tanS * tanS);
                const float r = sqrtf(d2) * k->inv_R;
                ao += (1.0f - k->attenuation * r * r) * (sinS - sinH);
                /* Update the current horizon angle */
                tanH = tanS;
                sinH = sinS;
            }
        }
    }
    return ao;
}

/* return 1.0 - ao / g_NumDir * g_Contrast.
 * Deviation: saturated (the reference's value leaves [0, 1] when the horizon flips, hbao.md) */
static inline float classic_finish(const ao_hbao_constants *k, float ao)
{
    return clampf01(1.0f - ao / (float)k->num_dirs * k->contrast);
}

static float classic_pixel(const hbao_job *J, int x, int y, int64_t *n_small, int64_t *n_degen)
{
    classic_px c;
    float early;
    if (!classic_setup(J, x, y, &c, &early, n_small, n_degen))
        return early;
    float ao = 0.0f;
    for (int d = 0; d < J->k->num_dirs; d++) {
        classic_ray o;
        classic_dir(J->k, &c, d, &o);
        ao += classic_taps(J->k, J->z, &c, &o);
    }
    return classic_finish(J->k, ao);
}

/* ---- PLUS: gl_ssao hbao.frag.glsl, AO_DEINTERLEAVED 0 ---- */

typedef struct plus_px {
    float u0, v0;          /* texCoord */
    v3 P, N;
    float stepSizePixels;
    const float *rd;       /* (cos(Alpha), sin(Alpha), rand1, rand2) */
} plus_px;

/* main() up to the direction loop. Returns 0 with *early set when the pixel is done. */
static int plus_setup(const hbao_job *J, int x, int y, plus_px *c, float *early, int64_t *n_degen)
{
    const ao_hbao_constants *k = J->k;
    const obs_image_f32 *z = J->z;
    const int y_gl = k->full_height - 1 - y;
    /* texCoord at the pixel centre (GL: y up) */
    const float u0 = ((float)x + 0.5f) / k->resolution[0], v0 = ((float)y_gl + 0.5f) / k->resolution[1];
    const v3 P = fetch_pos(k, z, u0, v0, 1);
    v3 N;
    if (!k->normals_from_gbuffer) {
        /* ViewNormal = -ReconstructNormal(uv, P):
         * normalize(cross(MinDiff(P, Pr, Pl), MinDiff(P, Pt, Pb))), neighbours at uv +- InvFullResolution */
        const float iu = k->inv_resolution[0], iv = k->inv_resolution[1];
        const v3 Pr = fetch_pos(k, z, u0 + iu, v0, 1), Pl = fetch_pos(k, z, u0 + -iu, v0, 1);
        const v3 Pt = fetch_pos(k, z, u0, v0 + iv, 1), Pb = fetch_pos(k, z, u0, v0 + -iv, 1);
        const v3 a = min_diff(P, Pr, Pl), b = min_diff(P, Pt, Pb);
        const v3 cr = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
        const float l2 = v3_dot(cr, cr);
        if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
            (*n_degen)++;
            *early = 1.0f; /* Deviation: NaN normal on a GPU; visibility 1 here */
            return 0;
        }
        const float inv = 1.0f / sqrtf(l2); /* normalize(v) = v * inversesqrt(dot(v, v)) */
        N = (v3){-(cr.x * inv), -(cr.y * inv), -(cr.z * inv)};
    } else {
        /* the G-buffer's view-space normal in the shader's eye space (z into the screen) */
        N = (v3){obs_image_f32_row(J->in->normal[0], y)[x], obs_image_f32_row(J->in->normal[1], y)[x],
                 -obs_image_f32_row(J->in->normal[2], y)[x]};
        const float l2 = v3_dot(N, N);
        if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
            (*n_degen)++;
            *early = 1.0f;
            return 0;
        }
        const float inv = 1.0f / sqrtf(l2);
        N = (v3){N.x * inv, N.y * inv, N.z * inv};
    }
    /* Compute projection of disk of radius control.R into screen space:
     * RadiusPixels = RadiusToScreen / (projOrtho != 0 ? 1.0 : ViewPosition.z) */
    const float radiusPixels = k->radius_to_screen / (k->orthographic ? 1.0f : P.z);
    /* HBAO+ CoarseAO_PS: early exit if the projected radius is smaller than 1 full-res pixel */
    if (k->small_scale_amount > 0.0f && radiusPixels < 1.0f) {
        *early = 1.0f;
        return 0;
    }
    c->u0 = u0;
    c->v0 = v0;
    c->P = P;
    c->N = N;
    /* Get jitter vector for the current full-res pixel: (cos(Alpha), sin(Alpha), rand1, rand2) */
    c->rd = J->noise[ao_hbao_noise_index(k, x, y)];
    /* ComputeCoarseAO: Divide by NUM_STEPS+1 so that the farthest samples are not fully attenuated */
    c->stepSizePixels = radiusPixels / ((float)k->num_steps + 1.0f);
    return 1;
}

/* ComputeCoarseAO's loops. *smallAO: HBAO+'s SmallScaleAO (the first steps) when split, else 0. */
static float plus_taps(const ao_hbao_constants *k, const obs_image_f32 *z, const plus_px *c, float *smallAO_out)
{
    const int split = k->small_scale_amount > 0.0f;
    const float *rd = c->rd;
    const float stepSizePixels = c->stepSizePixels, u0 = c->u0, v0 = c->v0;
    const v3 P = c->P, N = c->N;
    float AO = 0.0f, smallAO = 0.0f; /* HBAO+: SmallScaleAO (first step), LargeScaleAO (in AO) */
    for (int d = 0; d < k->num_dirs; d++) {
        const float cs = k->plus_dirs[d][0], sn = k->plus_dirs[d][1]; /* (cos, sin)(Alpha * d) */
        /* Direction = RotateDirection(vec2(cos(Angle), sin(Angle)), Rand.xy) */
        const float dirx = cs * rd[0] - sn * rd[1], diry = cs * rd[1] + sn * rd[0];
        /* Jitter starting sample within the first step: RayPixels = Rand.z * StepSizePixels + 1.0 */
        float rayPixels = rd[2] * stepSizePixels + 1.0f;
        for (int st = 0; st < k->num_steps; st++) {
            /* SnappedUV = round(RayPixels * Direction) * InvFullResolution + FullResUV */
            const float su = rintf(rayPixels * dirx) * k->inv_resolution[0] + u0;
            const float sv = rintf(rayPixels * diry) * k->inv_resolution[1] + v0;
            const v3 S = fetch_pos(k, z, su, sv, 1);
            rayPixels += stepSizePixels;
            /* ComputeAO: V = S - P; NdotV = dot(N, V) * 1.0/sqrt(VdotV);
             * clamp(NdotV - NDotVBias, 0, 1) * clamp(VdotV * NegInvR2 + 1.0, 0, 1) */
            const v3 V = v3_sub(S, P);
            const float VdotV = v3_dot(V, V);
            if (!(VdotV > 0.0f) || !(VdotV < INFINITY))
                continue; /* Deviation: a background tap (+inf) adds 0, as a far one would */
            const float NdotV = v3_dot(N, V) * (1.0f / sqrtf(VdotV));
            const float t = clampf01(NdotV - k->ndotv_bias) * clampf01(VdotV * k->neg_inv_R2 + 1.0f);
            if (split && st == 0)
                smallAO += t;
            else
                AO += t;
        }
    }
    *smallAO_out = smallAO;
    return AO;
}

static float plus_finish(const ao_hbao_constants *k, float AO, float smallAO)
{
    if (!(k->small_scale_amount > 0.0f)) {
        /* AO *= control.AOMultiplier / (NUM_DIRECTIONS * NUM_STEPS); clamp(1.0 - AO * 2.0, 0, 1) */
        AO *= k->ao_multiplier / (float)(k->num_dirs * k->num_steps);
    } else {
        /* AO = (SmallScaleAO * g_fSmallScaleAOAmount) + (LargeScaleAO * g_fLargeScaleAOAmount);
         * AO /= (NUM_DIRECTIONS * NUM_STEPS) */
        AO = (smallAO * k->small_scale_amount) + (AO * k->large_scale_amount);
        AO /= (float)(k->num_dirs * k->num_steps);
    }
    const float A = clampf01(1.0f - AO * 2.0f);
    /* pow(AO, control.PowExponent) */
    return (float)pow((double)A, (double)k->pow_exponent);
}

static float plus_pixel(const hbao_job *J, int x, int y, int64_t *n_degen)
{
    plus_px c;
    float early, smallAO;
    if (!plus_setup(J, x, y, &c, &early, n_degen))
        return early;
    const float AO = plus_taps(J->k, J->z, &c, &smallAO);
    return plus_finish(J->k, AO, smallAO);
}

/* ---- AVX2: the tap loops, 8 pixels of a row per call (lane i = pixel x + i) ----
 * Every lane runs the scalar loop's float operations in the scalar loop's order (separate mul and
 * add, no FMA: neither -mfma nor contraction), so each lane's result is bit-identical to
 * classic_taps / plus_taps; the scalar set-up (classic_setup, classic_dir, plus_setup) and the
 * finish are shared. Skipped taps are masked (blend), never added as 0. */
#if HB_HAVE_AVX2

/* texel_of over 8 lanes: !(t >= 0) -> 0, t >= n -> n - 1, else (int)t */
HB_AVX2 static inline __m256i hb_texel8(__m256 t, __m256 nf, __m256i nm1)
{
    __m256i ti = _mm256_cvttps_epi32(t);
    ti = _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(ti), _mm256_castsi256_ps(nm1),
                                              _mm256_cmp_ps(t, nf, _CMP_GE_OQ)));
    return _mm256_and_si256(ti, _mm256_castps_si256(_mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GE_OQ)));
}

typedef struct hb_fetcher {
    __m256 res0, res1, w_f, h_f, a0, a1, a2, a3;
    __m256i w_m1, h_m1, stride;
    const float *z;
    int gl, ortho;
} hb_fetcher;

HB_AVX2 static void hb_fetch8_init(hb_fetcher *f, const ao_hbao_constants *k, const obs_image_f32 *z, int gl)
{
    f->res0 = _mm256_set1_ps(k->resolution[0]);
    f->res1 = _mm256_set1_ps(k->resolution[1]);
    f->w_f = _mm256_set1_ps((float)k->full_width);
    f->h_f = _mm256_set1_ps((float)k->full_height);
    f->w_m1 = _mm256_set1_epi32(k->full_width - 1);
    f->h_m1 = _mm256_set1_epi32(k->full_height - 1);
    f->stride = _mm256_set1_epi32((int)z->stride);
    f->a0 = _mm256_set1_ps(k->uv_to_view[0]);
    f->a1 = _mm256_set1_ps(k->uv_to_view[1]);
    f->a2 = _mm256_set1_ps(k->uv_to_view[2]);
    f->a3 = _mm256_set1_ps(k->uv_to_view[3]);
    f->z = z->data;
    f->gl = gl;
    f->ortho = k->orthographic;
}

/* fetch_pos over 8 lanes */
HB_AVX2 static inline void hb_fetch8(const hb_fetcher *f, __m256 u, __m256 v, __m256 *Sx, __m256 *Sy, __m256 *Sz)
{
    const __m256i tx = hb_texel8(_mm256_mul_ps(u, f->res0), f->w_f, f->w_m1);
    __m256i ty = hb_texel8(_mm256_mul_ps(v, f->res1), f->h_f, f->h_m1);
    if (f->gl)
        ty = _mm256_sub_epi32(f->h_m1, ty);
    const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(ty, f->stride), tx);
    const __m256 d = _mm256_i32gather_ps(f->z, idx, 4);
    const __m256 ax = _mm256_add_ps(_mm256_mul_ps(u, f->a0), f->a2);
    const __m256 ay = _mm256_add_ps(_mm256_mul_ps(v, f->a1), f->a3);
    if (!f->ortho) {
        *Sx = _mm256_mul_ps(ax, d);
        *Sy = _mm256_mul_ps(ay, d);
    } else {
        *Sx = ax;
        *Sy = ay;
    }
    *Sz = d;
}

/* (float)atan((double)x) and (float)tan((double)x) over 8 lanes, bit-identical to f_atan / f_tan
 * by construction (as hb_exp2f): the value in double with a relative error far below 2^-46, then
 * the float rounding taken only where y (1 -+ 2^-46) round alike; other lanes in need (about 1 in
 * 2^21) call libm. atan: |x| > 1 -> pi/2 - atan(1/|x|); atan(y) = atan(c) + atan(u),
 * c = rint(16 y)/16, u = (y - c)/(1 + y c), |u| <= 1/32, odd series to u^13. tan: |x| <= pi/4 ->
 * sin/cos series (to t^17, t^16); else cos(t)/sin(t) with t = pi/2 - |x| taken exactly
 * (Sterbenz) plus pi/2's low part. Lanes not in need may come back as anything. */
static const double hb_atan_tab[17] = {
    0.0, 0.06241880999595735, 0.12435499454676144, 0.18534794999569476, 0.24497866312686414,
    0.3028848683749714, 0.35877067027057225, 0.4124104415973873, 0.4636476090008061, 0.5123894603107377,
    0.5585993153435624, 0.6022873461349642, 0.6435011087932844, 0.6823165548747481, 0.7188299996216245,
    0.7531512809621944, 0.7853981633974483}; /* atan(i/16) */
static const double hb_atan_q[6] = {-0.3333333333333333, 0.2, -0.14285714285714285, 0.1111111111111111,
                                    -0.09090909090909091, 0.07692307692307693}; /* (-1)^k / (2k + 1) */
static const double hb_sin_c[8] = {-0.16666666666666666, 0.008333333333333333, -0.0001984126984126984,
                                   2.7557319223985893e-06, -2.505210838544172e-08, 1.6059043836821613e-10,
                                   -7.647163731819816e-13, 2.8114572543455206e-15}; /* (-1)^k / (2k+1)! */
static const double hb_cos_c[8] = {-0.5, 0.041666666666666664, -0.001388888888888889, 2.48015873015873e-05,
                                   -2.755731922398589e-07, 2.08767569878681e-09, -1.1470745597729725e-11,
                                   4.779477332387385e-14}; /* (-1)^k / (2k)! */
#define HB_PIO2_HI 0x1.921fb54442d18p+0
#define HB_PIO2_LO 0x1.1a62633145c07p-54

HB_AVX2 static inline __m256d hb_atan4d(__m256d x)
{
    const __m256d sgn = _mm256_set1_pd(-0.0), one = _mm256_set1_pd(1.0);
    __m256d ax = _mm256_min_pd(_mm256_andnot_pd(sgn, x), _mm256_set1_pd(1e300)); /* NaN, inf -> 1e300 */
    const __m256d inv = _mm256_cmp_pd(ax, one, _CMP_GT_OQ);
    const __m256d y = _mm256_blendv_pd(ax, _mm256_div_pd(one, ax), inv);
    const __m256d ci = _mm256_round_pd(_mm256_mul_pd(y, _mm256_set1_pd(16.0)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    const __m256d atc = _mm256_i32gather_pd(hb_atan_tab, _mm256_cvtpd_epi32(ci), 8);
    const __m256d c = _mm256_mul_pd(ci, _mm256_set1_pd(0.0625));
    const __m256d u = _mm256_div_pd(_mm256_sub_pd(y, c), _mm256_add_pd(one, _mm256_mul_pd(y, c)));
    const __m256d u2 = _mm256_mul_pd(u, u);
    __m256d q = _mm256_set1_pd(hb_atan_q[5]);
    for (int k = 4; k >= 0; k--)
        q = _mm256_add_pd(_mm256_mul_pd(q, u2), _mm256_set1_pd(hb_atan_q[k]));
    const __m256d a = _mm256_add_pd(atc, _mm256_add_pd(u, _mm256_mul_pd(_mm256_mul_pd(u, u2), q)));
    const __m256d r = _mm256_blendv_pd(
        a, _mm256_add_pd(_mm256_sub_pd(_mm256_set1_pd(HB_PIO2_HI), a), _mm256_set1_pd(HB_PIO2_LO)), inv);
    return _mm256_or_pd(r, _mm256_and_pd(x, sgn));
}

HB_AVX2 static inline __m256d hb_tan4d(__m256d x)
{
    const __m256d sgn = _mm256_set1_pd(-0.0), one = _mm256_set1_pd(1.0);
    const __m256d ax = _mm256_min_pd(_mm256_andnot_pd(sgn, x), _mm256_set1_pd(2.0)); /* NaN -> 2 */
    const __m256d big = _mm256_cmp_pd(ax, _mm256_set1_pd(0x1.921fb54442d18p-1), _CMP_GT_OQ);
    const __m256d t = _mm256_blendv_pd(
        ax, _mm256_add_pd(_mm256_sub_pd(_mm256_set1_pd(HB_PIO2_HI), ax), _mm256_set1_pd(HB_PIO2_LO)), big);
    const __m256d t2 = _mm256_mul_pd(t, t);
    __m256d ps = _mm256_set1_pd(hb_sin_c[7]), pc = _mm256_set1_pd(hb_cos_c[7]);
    for (int k = 6; k >= 0; k--) {
        ps = _mm256_add_pd(_mm256_mul_pd(ps, t2), _mm256_set1_pd(hb_sin_c[k]));
        pc = _mm256_add_pd(_mm256_mul_pd(pc, t2), _mm256_set1_pd(hb_cos_c[k]));
    }
    const __m256d s = _mm256_add_pd(t, _mm256_mul_pd(_mm256_mul_pd(t, t2), ps));
    const __m256d c = _mm256_add_pd(one, _mm256_mul_pd(t2, pc));
    const __m256d r = _mm256_div_pd(_mm256_blendv_pd(s, c, big), _mm256_blendv_pd(c, s, big));
    return _mm256_xor_pd(r, _mm256_and_pd(x, sgn));
}

/* The float rounding of 4 doubles where certain, NaN where not */
HB_AVX2 static inline __m128 hb_round_certain4(__m256d y)
{
    const __m128 lo = _mm256_cvtpd_ps(_mm256_mul_pd(y, _mm256_set1_pd(HB_EXP2_SAFE_LO)));
    const __m128 hi = _mm256_cvtpd_ps(_mm256_mul_pd(y, _mm256_set1_pd(HB_EXP2_SAFE_HI)));
    return _mm_blendv_ps(_mm_set1_ps(NAN), lo, _mm_cmpeq_ps(lo, hi));
}

/* fn 0: atan, 1: tan */
HB_AVX2 static inline __m256 hb_trig8(__m256 x, __m256 need, int fn)
{
    __m128 r[2];
    for (int h = 0; h < 2; h++) {
        const __m256d xd = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(x, 1) : _mm256_castps256_ps128(x));
        r[h] = hb_round_certain4(fn ? hb_tan4d(xd) : hb_atan4d(xd));
    }
    __m256 res = _mm256_set_m128(r[1], r[0]);
    /* the domain: finite x (atan), |x| <= 1.6 (tan); false for NaN */
    const __m256 dom = _mm256_cmp_ps(_mm256_andnot_ps(_mm256_set1_ps(-0.0f), x),
                                     _mm256_set1_ps(fn ? 1.6f : FLT_MAX), _CMP_LE_OQ);
    const int mb = _mm256_movemask_ps(
        _mm256_and_ps(need, _mm256_or_ps(_mm256_cmp_ps(res, res, _CMP_UNORD_Q), _mm256_xor_ps(dom, _mm256_castsi256_ps(_mm256_set1_epi32(-1))))));
    if (mb) {
        float xs[8], rs[8];
        _mm256_storeu_ps(xs, x);
        _mm256_storeu_ps(rs, res);
        for (int i = 0; i < 8; i++)
            if (mb >> i & 1)
                rs[i] = fn ? f_tan(xs[i]) : f_atan(xs[i]);
        res = _mm256_loadu_ps(rs);
    }
    return res;
}

/* snap_uv_offset over 8 lanes */
HB_AVX2 static inline __m256 hb_snap8(__m256 u, __m256 res, __m256 inv)
{
    return _mm256_mul_ps(_mm256_round_ps(_mm256_mul_ps(u, res), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC), inv);
}

/* classic_dir + classic_taps for 8 pixels (live[i]: lane i runs), every direction; ao_out[i] is
 * the sum over directions in direction order, as classic_pixel's */
HB_AVX2 static void classic_group8(const ao_hbao_constants *k, const hb_fetcher *f, const classic_px *c,
                                   const int *live, float *ao_out)
{
    float L[17][8];
    int first = 0;
    while (!live[first])
        first++;
    for (int i = 0; i < 8; i++) {
        const classic_px *q = live[i] ? &c[i] : &c[first];
        const float vals[17] = {q->u0,     q->v0,     q->P.x,  q->P.y,  q->P.z,  q->dPdu.x,
                                q->dPdu.y, q->dPdu.z, q->dPdv.x, q->dPdv.y, q->dPdv.z, q->sx,
                                q->sy,     live[i] ? q->numSteps : 0.0f, q->rd[0], q->rd[1], q->rd[2]};
        for (int j = 0; j < 17; j++)
            L[j][i] = vals[j];
    }
    const __m256 u0 = _mm256_loadu_ps(L[0]), v0 = _mm256_loadu_ps(L[1]);
    const __m256 px = _mm256_loadu_ps(L[2]), py = _mm256_loadu_ps(L[3]), pz = _mm256_loadu_ps(L[4]);
    const __m256 dPdux = _mm256_loadu_ps(L[5]), dPduy = _mm256_loadu_ps(L[6]), dPduz = _mm256_loadu_ps(L[7]);
    const __m256 dPdvx = _mm256_loadu_ps(L[8]), dPdvy = _mm256_loadu_ps(L[9]), dPdvz = _mm256_loadu_ps(L[10]);
    const __m256 sx = _mm256_loadu_ps(L[11]), sy = _mm256_loadu_ps(L[12]), ns = _mm256_loadu_ps(L[13]);
    const __m256 rd0 = _mm256_loadu_ps(L[14]), rd1 = _mm256_loadu_ps(L[15]), rd2 = _mm256_loadu_ps(L[16]);
    const __m256 one = _mm256_set1_ps(1.0f), inf = _mm256_set1_ps(INFINITY), sgn = _mm256_set1_ps(-0.0f);
    const __m256 res0 = _mm256_set1_ps(k->resolution[0]), res1 = _mm256_set1_ps(k->resolution[1]);
    const __m256 inv0 = _mm256_set1_ps(k->inv_resolution[0]), inv1 = _mm256_set1_ps(k->inv_resolution[1]);
    const __m256 bias = _mm256_set1_ps(k->angle_bias), halfpi = _mm256_set1_ps(HBAO_PI_F * 0.5f);
    const __m256 sqrR = _mm256_set1_ps(k->sqr_R), invR = _mm256_set1_ps(k->inv_R);
    const __m256 att = _mm256_set1_ps(k->attenuation);
    const __m256 liveM = _mm256_cmp_ps(ns, one, _CMP_GE_OQ); /* live lanes have numSteps >= 1 */
    __m256 aoT = _mm256_setzero_ps();
    for (int d = 0; d < k->num_dirs; d++) {
        /* classic_dir */
        const __m256 cd = _mm256_set1_ps(k->dirs[d][0]), sd = _mm256_set1_ps(k->dirs[d][1]);
        __m256 du = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(cd, rd0), _mm256_mul_ps(sd, rd1)), sx);
        __m256 dv = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(cd, rd1), _mm256_mul_ps(sd, rd0)), sy);
        __m256 u = _mm256_add_ps(u0, hb_snap8(_mm256_mul_ps(rd2, du), res0, inv0));
        __m256 v = _mm256_add_ps(v0, hb_snap8(_mm256_mul_ps(rd2, dv), res1, inv1));
        du = hb_snap8(du, res0, inv0);
        dv = hb_snap8(dv, res1, inv1);
        const __m256 Tx = _mm256_add_ps(_mm256_mul_ps(du, dPdux), _mm256_mul_ps(dv, dPdvx));
        const __m256 Ty = _mm256_add_ps(_mm256_mul_ps(du, dPduy), _mm256_mul_ps(dv, dPdvy));
        const __m256 Tz = _mm256_add_ps(_mm256_mul_ps(du, dPduz), _mm256_mul_ps(dv, dPdvz));
        const __m256 tanT = _mm256_div_ps(_mm256_xor_ps(Tz, sgn),
                                          _mm256_sqrt_ps(_mm256_add_ps(_mm256_mul_ps(Tx, Tx), _mm256_mul_ps(Ty, Ty))));
        const __m256 ok1 = _mm256_and_ps(liveM, _mm256_cmp_ps(_mm256_andnot_ps(sgn, tanT), inf, _CMP_LT_OQ));
        __m256 ao = _mm256_setzero_ps();
        if (_mm256_movemask_ps(ok1)) {
            const __m256 phi = _mm256_add_ps(hb_trig8(tanT, ok1, 0), bias);
            const __m256 ok = _mm256_and_ps(ok1, _mm256_cmp_ps(phi, halfpi, _CMP_LT_OQ));
            if (_mm256_movemask_ps(ok)) {
                __m256 tanH = hb_trig8(phi, ok, 1);
                __m256 sinH = _mm256_div_ps(tanH, _mm256_sqrt_ps(_mm256_add_ps(one, _mm256_mul_ps(tanH, tanH))));
                float nsd[8];
                _mm256_storeu_ps(nsd, _mm256_and_ps(ns, ok));
                float maxSteps = 0.0f;
                for (int i = 0; i < 8; i++)
                    maxSteps = nsd[i] > maxSteps ? nsd[i] : maxSteps;
                const __m256 nsv = _mm256_loadu_ps(nsd);
                /* classic_taps */
                for (float j = 1.0f; j <= maxSteps; j += 1.0f) {
                    const __m256 on = _mm256_cmp_ps(_mm256_set1_ps(j), nsv, _CMP_LE_OQ);
                    u = _mm256_add_ps(u, du);
                    v = _mm256_add_ps(v, dv);
                    __m256 Sx, Sy, Sz;
                    hb_fetch8(f, u, v, &Sx, &Sy, &Sz);
                    const __m256 Dx = _mm256_sub_ps(Sx, px), Dy = _mm256_sub_ps(Sy, py), Dz = _mm256_sub_ps(Sz, pz);
                    const __m256 dxy = _mm256_add_ps(_mm256_mul_ps(Dx, Dx), _mm256_mul_ps(Dy, Dy));
                    const __m256 d2 = _mm256_add_ps(dxy, _mm256_mul_ps(Dz, Dz));
                    const __m256 tanS = _mm256_div_ps(_mm256_sub_ps(pz, Sz), _mm256_sqrt_ps(dxy));
                    __m256 m = _mm256_and_ps(on, _mm256_cmp_ps(d2, sqrR, _CMP_LT_OQ));
                    m = _mm256_and_ps(m, _mm256_cmp_ps(tanS, tanH, _CMP_GT_OQ));
                    m = _mm256_and_ps(m, _mm256_cmp_ps(tanS, inf, _CMP_LT_OQ));
                    if (_mm256_movemask_ps(m)) {
                        const __m256 sinS =
                            _mm256_div_ps(tanS, _mm256_sqrt_ps(_mm256_add_ps(one, _mm256_mul_ps(tanS, tanS))));
                        const __m256 r = _mm256_mul_ps(_mm256_sqrt_ps(d2), invR);
                        const __m256 w = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(att, r), r));
                        ao = _mm256_blendv_ps(ao, _mm256_add_ps(ao, _mm256_mul_ps(w, _mm256_sub_ps(sinS, sinH))), m);
                        tanH = _mm256_blendv_ps(tanH, tanS, m);
                        sinH = _mm256_blendv_ps(sinH, sinS, m);
                    }
                }
            }
        }
        aoT = _mm256_add_ps(aoT, ao); /* ao += AccumulatedHorizonOcclusion(...); 0 where it adds 0 */
    }
    _mm256_storeu_ps(ao_out, aoT);
}

/* plus_taps for 8 lanes; lanes with live[i] == 0 are computed on a copy of lane 0's state or
 * garbage and ignored by the caller */
HB_AVX2 static void plus_taps8(const ao_hbao_constants *k, const hb_fetcher *f, const plus_px *c, const int *live,
                               float *AO_out, float *small_out)
{
    const int split = k->small_scale_amount > 0.0f;
    float Px[8], Py[8], Pz[8], Nx[8], Ny[8], Nz[8], U0[8], V0[8], St[8], R0[8], R1[8], R2[8];
    int first = 0;
    while (!live[first])
        first++;
    for (int i = 0; i < 8; i++) {
        const plus_px *q = live[i] ? &c[i] : &c[first];
        Px[i] = q->P.x;
        Py[i] = q->P.y;
        Pz[i] = q->P.z;
        Nx[i] = q->N.x;
        Ny[i] = q->N.y;
        Nz[i] = q->N.z;
        U0[i] = q->u0;
        V0[i] = q->v0;
        St[i] = q->stepSizePixels;
        R0[i] = q->rd[0];
        R1[i] = q->rd[1];
        R2[i] = q->rd[2];
    }
    const __m256 px = _mm256_loadu_ps(Px), py = _mm256_loadu_ps(Py), pz = _mm256_loadu_ps(Pz);
    const __m256 nx = _mm256_loadu_ps(Nx), ny = _mm256_loadu_ps(Ny), nz = _mm256_loadu_ps(Nz);
    const __m256 u0 = _mm256_loadu_ps(U0), v0 = _mm256_loadu_ps(V0), step = _mm256_loadu_ps(St);
    const __m256 r0 = _mm256_loadu_ps(R0), r1 = _mm256_loadu_ps(R1), r2 = _mm256_loadu_ps(R2);
    const __m256 inv0 = _mm256_set1_ps(k->inv_resolution[0]), inv1 = _mm256_set1_ps(k->inv_resolution[1]);
    const __m256 bias = _mm256_set1_ps(k->ndotv_bias), nir2 = _mm256_set1_ps(k->neg_inv_R2);
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    __m256 AO = zero, smallAO = zero;
    for (int d = 0; d < k->num_dirs; d++) {
        const __m256 cs = _mm256_set1_ps(k->plus_dirs[d][0]), sn = _mm256_set1_ps(k->plus_dirs[d][1]);
        const __m256 dirx = _mm256_sub_ps(_mm256_mul_ps(cs, r0), _mm256_mul_ps(sn, r1));
        const __m256 diry = _mm256_add_ps(_mm256_mul_ps(cs, r1), _mm256_mul_ps(sn, r0));
        __m256 ray = _mm256_add_ps(_mm256_mul_ps(r2, step), one);
        for (int st = 0; st < k->num_steps; st++) {
            const __m256 su = _mm256_add_ps(
                _mm256_mul_ps(_mm256_round_ps(_mm256_mul_ps(ray, dirx), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC),
                              inv0),
                u0);
            const __m256 sv = _mm256_add_ps(
                _mm256_mul_ps(_mm256_round_ps(_mm256_mul_ps(ray, diry), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC),
                              inv1),
                v0);
            __m256 Sx, Sy, Sz;
            hb_fetch8(f, su, sv, &Sx, &Sy, &Sz);
            ray = _mm256_add_ps(ray, step);
            const __m256 Vx = _mm256_sub_ps(Sx, px), Vy = _mm256_sub_ps(Sy, py), Vz = _mm256_sub_ps(Sz, pz);
            const __m256 VdotV = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(Vx, Vx), _mm256_mul_ps(Vy, Vy)),
                                               _mm256_mul_ps(Vz, Vz));
            const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(VdotV, zero, _CMP_GT_OQ), _mm256_cmp_ps(VdotV, inf, _CMP_LT_OQ));
            const __m256 NdotV = _mm256_mul_ps(
                _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, Vx), _mm256_mul_ps(ny, Vy)), _mm256_mul_ps(nz, Vz)),
                _mm256_div_ps(one, _mm256_sqrt_ps(VdotV)));
            /* clampf01: v > 0 ? (v < 1 ? v : 1) : 0 */
            const __m256 a = _mm256_sub_ps(NdotV, bias);
            const __m256 ca = _mm256_and_ps(_mm256_blendv_ps(one, a, _mm256_cmp_ps(a, one, _CMP_LT_OQ)),
                                            _mm256_cmp_ps(a, zero, _CMP_GT_OQ));
            const __m256 b = _mm256_add_ps(_mm256_mul_ps(VdotV, nir2), one);
            const __m256 cb = _mm256_and_ps(_mm256_blendv_ps(one, b, _mm256_cmp_ps(b, one, _CMP_LT_OQ)),
                                            _mm256_cmp_ps(b, zero, _CMP_GT_OQ));
            const __m256 t = _mm256_mul_ps(ca, cb);
            if (split && st == 0)
                smallAO = _mm256_blendv_ps(smallAO, _mm256_add_ps(smallAO, t), ok);
            else
                AO = _mm256_blendv_ps(AO, _mm256_add_ps(AO, t), ok);
        }
    }
    _mm256_storeu_ps(AO_out, AO);
    _mm256_storeu_ps(small_out, smallAO);
}

/* min_diff over 8 lanes */
HB_AVX2 static inline void hb_min_diff8(__m256 Px, __m256 Py, __m256 Pz, __m256 Rx, __m256 Ry, __m256 Rz, __m256 Lx,
                                        __m256 Ly, __m256 Lz, __m256 *ox, __m256 *oy, __m256 *oz)
{
    const __m256 ax = _mm256_sub_ps(Rx, Px), ay = _mm256_sub_ps(Ry, Py), az = _mm256_sub_ps(Rz, Pz);
    const __m256 bx = _mm256_sub_ps(Px, Lx), by = _mm256_sub_ps(Py, Ly), bz = _mm256_sub_ps(Pz, Lz);
    const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, ax), _mm256_mul_ps(ay, ay)), _mm256_mul_ps(az, az));
    const __m256 l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(bx, bx), _mm256_mul_ps(by, by)), _mm256_mul_ps(bz, bz));
    /* (l1 < l2 || l2 != l2) ? V1 : V2 */
    const __m256 m = _mm256_or_ps(_mm256_cmp_ps(l1, l2, _CMP_LT_OQ), _mm256_cmp_ps(l2, l2, _CMP_UNORD_Q));
    *ox = _mm256_blendv_ps(bx, ax, m);
    *oy = _mm256_blendv_ps(by, ay, m);
    *oz = _mm256_blendv_ps(bz, az, m);
}

/* tangent_eye_pos over 8 lanes */
HB_AVX2 static inline void hb_tangent8(const hb_fetcher *f, __m256 u, __m256 v, __m256 Nx, __m256 Ny, __m256 Nz,
                                       __m256 w, __m256 *X, __m256 *Y, __m256 *Z)
{
    hb_fetch8(f, u, v, X, Y, Z);
    const __m256 NdotV =
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(Nx, *X), _mm256_mul_ps(Ny, *Y)), _mm256_mul_ps(Nz, *Z));
    const __m256 m = _mm256_cmp_ps(NdotV, _mm256_setzero_ps(), _CMP_LT_OQ);
    const __m256 sc = _mm256_div_ps(w, NdotV);
    *X = _mm256_blendv_ps(*X, _mm256_mul_ps(*X, sc), m);
    *Y = _mm256_blendv_ps(*Y, _mm256_mul_ps(*Y, sc), m);
    *Z = _mm256_blendv_ps(*Z, _mm256_mul_ps(*Z, sc), m);
}

/* classic_setup for the 8 pixels x .. x + 7 of row y (lanes >= n and background lanes are not
 * live); fills c[i] and live[i] for the live lanes, counts as classic_setup (background, then
 * small radius, then a degenerate G-buffer normal); every early value is 1. fminf: its operands
 * are never NaN here (P.z of a surface pixel is finite and > 0), so it is min. */
HB_AVX2 static void classic_setup8(const hbao_job *J, const hb_fetcher *f, int x, int y, int n, classic_px *c,
                                   int *live, int64_t *n_bg, int64_t *n_small, int64_t *n_degen)
{
    const ao_hbao_constants *k = J->k;
    const float *zr = obs_image_f32_row(J->z, y);
    int any = 0;
    for (int i = 0; i < 8; i++)
        live[i] = 0;
    for (int i = 0; i < n; i++)
        any |= zr[x + i] < INFINITY;
    if (!any) {
        *n_bg += n;
        return;
    }
    float X[8];
    for (int i = 0; i < 8; i++)
        X[i] = (float)(x + (i < n ? i : 0));
    const __m256 one = _mm256_set1_ps(1.0f), inf = _mm256_set1_ps(INFINITY), zero = _mm256_setzero_ps();
    const __m256 res0 = _mm256_set1_ps(k->resolution[0]), res1 = _mm256_set1_ps(k->resolution[1]);
    const __m256 u0 = _mm256_div_ps(_mm256_add_ps(_mm256_loadu_ps(X), _mm256_set1_ps(0.5f)), res0);
    const __m256 v0 = _mm256_set1_ps(((float)y + 0.5f) / k->resolution[1]);
    __m256 Px, Py, Pz;
    hb_fetch8(f, u0, v0, &Px, &Py, &Pz);
    __m256 sx = _mm256_set1_ps(0.5f * k->R * k->focal_len[0]), sy = _mm256_set1_ps(0.5f * k->R * k->focal_len[1]);
    if (!k->orthographic) {
        sx = _mm256_div_ps(sx, Pz);
        sy = _mm256_div_ps(sy, Pz);
    }
    const __m256 m = _mm256_min_ps(_mm256_mul_ps(sx, res0), _mm256_mul_ps(sy, res1));
    const __m256 numSteps = _mm256_min_ps(_mm256_set1_ps((float)k->num_steps), m);
    const int big = _mm256_movemask_ps(_mm256_cmp_ps(numSteps, one, _CMP_GE_OQ));
    sx = _mm256_div_ps(sx, _mm256_add_ps(numSteps, one));
    sy = _mm256_div_ps(sy, _mm256_add_ps(numSteps, one));
    const __m256 iu = _mm256_set1_ps(k->inv_resolution[0]), iv = _mm256_set1_ps(k->inv_resolution[1]);
    const __m256 niu = _mm256_set1_ps(-k->inv_resolution[0]), niv = _mm256_set1_ps(-k->inv_resolution[1]);
    __m256 Rx, Ry, Rz, Lx, Ly, Lz, Tx, Ty, Tz, Bx, By, Bz;
    int nok = 0xff;
    if (k->normals_from_gbuffer) {
        float G[3][8];
        for (int i = 0; i < 8; i++) {
            const int xi = x + (i < n ? i : 0);
            G[0][i] = obs_image_f32_row(J->in->normal[0], y)[xi];
            G[1][i] = obs_image_f32_row(J->in->normal[1], y)[xi];
            G[2][i] = -obs_image_f32_row(J->in->normal[2], y)[xi];
        }
        const __m256 gx = _mm256_loadu_ps(G[0]), gy = _mm256_loadu_ps(G[1]), gz = _mm256_loadu_ps(G[2]);
        const __m256 l2 =
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(gx, gx), _mm256_mul_ps(gy, gy)), _mm256_mul_ps(gz, gz));
        nok = _mm256_movemask_ps(_mm256_and_ps(_mm256_cmp_ps(l2, zero, _CMP_GT_OQ), _mm256_cmp_ps(l2, inf, _CMP_LT_OQ)));
        const __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
        const __m256 Nx = _mm256_mul_ps(gx, inv), Ny = _mm256_mul_ps(gy, inv), Nz = _mm256_mul_ps(gz, inv);
        const __m256 w = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(Px, Nx), _mm256_mul_ps(Py, Ny)), _mm256_mul_ps(Pz, Nz));
        hb_tangent8(f, _mm256_add_ps(u0, iu), v0, Nx, Ny, Nz, w, &Rx, &Ry, &Rz);
        hb_tangent8(f, _mm256_add_ps(u0, niu), v0, Nx, Ny, Nz, w, &Lx, &Ly, &Lz);
        hb_tangent8(f, u0, _mm256_add_ps(v0, iv), Nx, Ny, Nz, w, &Tx, &Ty, &Tz);
        hb_tangent8(f, u0, _mm256_add_ps(v0, niv), Nx, Ny, Nz, w, &Bx, &By, &Bz);
    } else {
        hb_fetch8(f, _mm256_add_ps(u0, iu), v0, &Rx, &Ry, &Rz);
        hb_fetch8(f, _mm256_add_ps(u0, niu), v0, &Lx, &Ly, &Lz);
        hb_fetch8(f, u0, _mm256_add_ps(v0, iv), &Tx, &Ty, &Tz);
        hb_fetch8(f, u0, _mm256_add_ps(v0, niv), &Bx, &By, &Bz);
    }
    __m256 ux, uy, uz, vx, vy, vz;
    hb_min_diff8(Px, Py, Pz, Rx, Ry, Rz, Lx, Ly, Lz, &ux, &uy, &uz);
    hb_min_diff8(Px, Py, Pz, Tx, Ty, Tz, Bx, By, Bz, &vx, &vy, &vz);
    const __m256 aspect = _mm256_set1_ps(k->resolution[1] * k->inv_resolution[0]);
    vx = _mm256_mul_ps(vx, aspect);
    vy = _mm256_mul_ps(vy, aspect);
    vz = _mm256_mul_ps(vz, aspect);
    float A[14][8];
    const __m256 vals[14] = {u0, Px, Py, Pz, ux, uy, uz, vx, vy, vz, sx, sy, numSteps, v0};
    for (int j = 0; j < 14; j++)
        _mm256_storeu_ps(A[j], vals[j]);
    for (int i = 0; i < n; i++) {
        if (!(zr[x + i] < INFINITY)) { /* background (cleaned to +inf): visibility 1 */
            (*n_bg)++;
        } else if (!(big >> i & 1)) {
            (*n_small)++;
        } else if (!(nok >> i & 1)) {
            (*n_degen)++;
        } else {
            live[i] = 1;
            c[i].u0 = A[0][i];
            c[i].v0 = A[13][i];
            c[i].P = (v3){A[1][i], A[2][i], A[3][i]};
            c[i].dPdu = (v3){A[4][i], A[5][i], A[6][i]};
            c[i].dPdv = (v3){A[7][i], A[8][i], A[9][i]};
            c[i].sx = A[10][i];
            c[i].sy = A[11][i];
            c[i].numSteps = A[12][i];
            c[i].rd = J->noise[ao_hbao_noise_index(k, x + i, y)];
        }
    }
}

/* plus_setup for the 8 pixels x .. x + 7 of row y (lanes >= n and background lanes are not live);
 * fills c[i] and live[i] for the live lanes, counts background and degenerate normals as
 * plus_setup does; every early value is 1. */
HB_AVX2 static void plus_setup8(const hbao_job *J, const hb_fetcher *f, int x, int y, int n, plus_px *c, int *live,
                                int64_t *n_bg, int64_t *n_degen)
{
    const ao_hbao_constants *k = J->k;
    const float *zr = obs_image_f32_row(J->z, y);
    int any = 0;
    for (int i = 0; i < 8; i++)
        live[i] = 0;
    for (int i = 0; i < n; i++)
        any |= zr[x + i] < INFINITY;
    if (!any) { /* all background (most groups of a typical frame) */
        *n_bg += n;
        return;
    }
    const int y_gl = k->full_height - 1 - y;
    float X[8];
    for (int i = 0; i < 8; i++)
        X[i] = (float)(x + (i < n ? i : 0));
    const __m256 half = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(1.0f), inf = _mm256_set1_ps(INFINITY);
    const __m256 zero = _mm256_setzero_ps();
    const __m256 u0 = _mm256_div_ps(_mm256_add_ps(_mm256_loadu_ps(X), half), _mm256_set1_ps(k->resolution[0]));
    const __m256 v0 = _mm256_set1_ps(((float)y_gl + 0.5f) / k->resolution[1]);
    __m256 Px, Py, Pz;
    hb_fetch8(f, u0, v0, &Px, &Py, &Pz);
    __m256 Nx, Ny, Nz, l2;
    if (!k->normals_from_gbuffer) {
        const __m256 iu = _mm256_set1_ps(k->inv_resolution[0]), iv = _mm256_set1_ps(k->inv_resolution[1]);
        const __m256 niu = _mm256_set1_ps(-k->inv_resolution[0]), niv = _mm256_set1_ps(-k->inv_resolution[1]);
        __m256 Rx, Ry, Rz, Lx, Ly, Lz, Tx, Ty, Tz, Bx, By, Bz;
        hb_fetch8(f, _mm256_add_ps(u0, iu), v0, &Rx, &Ry, &Rz);
        hb_fetch8(f, _mm256_add_ps(u0, niu), v0, &Lx, &Ly, &Lz);
        hb_fetch8(f, u0, _mm256_add_ps(v0, iv), &Tx, &Ty, &Tz);
        hb_fetch8(f, u0, _mm256_add_ps(v0, niv), &Bx, &By, &Bz);
        __m256 ax, ay, az, bx, by, bz;
        hb_min_diff8(Px, Py, Pz, Rx, Ry, Rz, Lx, Ly, Lz, &ax, &ay, &az);
        hb_min_diff8(Px, Py, Pz, Tx, Ty, Tz, Bx, By, Bz, &bx, &by, &bz);
        /* c = cross(a, b) */
        const __m256 cx = _mm256_sub_ps(_mm256_mul_ps(ay, bz), _mm256_mul_ps(az, by));
        const __m256 cy = _mm256_sub_ps(_mm256_mul_ps(az, bx), _mm256_mul_ps(ax, bz));
        const __m256 cz = _mm256_sub_ps(_mm256_mul_ps(ax, by), _mm256_mul_ps(ay, bx));
        l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(cx, cx), _mm256_mul_ps(cy, cy)), _mm256_mul_ps(cz, cz));
        const __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
        const __m256 sgn = _mm256_set1_ps(-0.0f);
        Nx = _mm256_xor_ps(_mm256_mul_ps(cx, inv), sgn);
        Ny = _mm256_xor_ps(_mm256_mul_ps(cy, inv), sgn);
        Nz = _mm256_xor_ps(_mm256_mul_ps(cz, inv), sgn);
    } else {
        float G[3][8];
        for (int i = 0; i < 8; i++) {
            const int xi = x + (i < n ? i : 0);
            G[0][i] = obs_image_f32_row(J->in->normal[0], y)[xi];
            G[1][i] = obs_image_f32_row(J->in->normal[1], y)[xi];
            G[2][i] = -obs_image_f32_row(J->in->normal[2], y)[xi];
        }
        const __m256 gx = _mm256_loadu_ps(G[0]), gy = _mm256_loadu_ps(G[1]), gz = _mm256_loadu_ps(G[2]);
        l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(gx, gx), _mm256_mul_ps(gy, gy)), _mm256_mul_ps(gz, gz));
        const __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
        Nx = _mm256_mul_ps(gx, inv);
        Ny = _mm256_mul_ps(gy, inv);
        Nz = _mm256_mul_ps(gz, inv);
    }
    const __m256 normal_ok = _mm256_and_ps(_mm256_cmp_ps(l2, zero, _CMP_GT_OQ), _mm256_cmp_ps(l2, inf, _CMP_LT_OQ));
    const __m256 rp = _mm256_div_ps(_mm256_set1_ps(k->radius_to_screen), k->orthographic ? one : Pz);
    const __m256 small = k->small_scale_amount > 0.0f ? _mm256_cmp_ps(rp, one, _CMP_LT_OQ) : zero;
    const __m256 step = _mm256_div_ps(rp, _mm256_set1_ps((float)k->num_steps + 1.0f));
    const int nok = _mm256_movemask_ps(normal_ok), sm = _mm256_movemask_ps(small);
    float A[10][8];
    const __m256 v[10] = {u0, v0, Px, Py, Pz, Nx, Ny, Nz, step, zero};
    for (int j = 0; j < 9; j++)
        _mm256_storeu_ps(A[j], v[j]);
    for (int i = 0; i < n; i++) {
        if (!(zr[x + i] < INFINITY)) { /* background (cleaned to +inf): visibility 1 */
            (*n_bg)++;
        } else if (!(nok >> i & 1)) {
            (*n_degen)++;
        } else if (!(sm >> i & 1)) {
            live[i] = 1;
            c[i].u0 = A[0][i];
            c[i].v0 = A[1][i];
            c[i].P = (v3){A[2][i], A[3][i], A[4][i]};
            c[i].N = (v3){A[5][i], A[6][i], A[7][i]};
            c[i].stepSizePixels = A[8][i];
            c[i].rd = J->noise[ao_hbao_noise_index(k, x + i, y)];
        }
    }
}

/* hbao_row's pixels x .. x + n - 1 (n <= 8) through the AVX2 tap loops */
HB_AVX2 static void hbao_group8(const hbao_job *J, const hb_fetcher *f, int x, int y, int n, float *out,
                                int64_t *n_bg, int64_t *n_small, int64_t *n_degen)
{
    const ao_hbao_constants *k = J->k;
    int live[8] = {0};
    int nlive = 0;
    if (k->variant == AO_HBAO_VARIANT_CLASSIC) {
        classic_px c[8];
        classic_setup8(J, f, x, y, n, c, live, n_bg, n_small, n_degen);
        for (int i = 0; i < n; i++) {
            if (live[i])
                nlive++;
            else
                out[i] = 1.0f; /* background, radius under a pixel, or no usable G-buffer normal */
        }
        if (!nlive)
            return;
        float ao[8];
        classic_group8(k, f, c, live, ao);
        for (int i = 0; i < n; i++)
            if (live[i]) {
                const float r = classic_finish(k, ao[i]);
                out[i] = r == r ? r : 1.0f;
            }
    } else {
        plus_px c[8];
        plus_setup8(J, f, x, y, n, c, live, n_bg, n_degen);
        for (int i = 0; i < n; i++) {
            if (live[i])
                nlive++;
            else
                out[i] = 1.0f; /* background, degenerate normal, or (split) radius < 1 px */
        }
        if (!nlive)
            return;
        float AO[8], smallAO[8];
        plus_taps8(k, f, c, live, AO, smallAO);
        for (int i = 0; i < n; i++)
            if (live[i]) {
                const float r = plus_finish(k, AO[i], smallAO[i]);
                out[i] = r == r ? r : 1.0f;
            }
    }
}
#endif

static void hbao_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const hbao_job *J = (const hbao_job *)user;
    const int y = J->ry0 + (int)task;
    float *out = obs_image_f32_row(J->ao, (int)task);
    const float *zr = obs_image_f32_row(J->z, y);
    int64_t n_bg = 0, n_small = 0, n_degen = 0;
#if HB_HAVE_AVX2
    if (J->avx2) {
        hb_fetcher f;
        hb_fetch8_init(&f, J->k, J->z, J->k->variant == AO_HBAO_VARIANT_PLUS);
        for (int i = 0; i < J->ao->width; i += 8) {
            const int n = J->ao->width - i < 8 ? J->ao->width - i : 8;
            hbao_group8(J, &f, J->rx0 + i, y, n, out + i, &n_bg, &n_small, &n_degen);
        }
        J->counts[task][0] = n_bg;
        J->counts[task][1] = n_small;
        J->counts[task][2] = n_degen;
        return;
    }
#endif
    for (int i = 0; i < J->ao->width; i++) {
        const int x = J->rx0 + i;
        if (!(zr[x] < INFINITY)) { /* background (cleaned to +inf): visibility 1 */
            out[i] = 1.0f;
            n_bg++;
            continue;
        }
        const float a = J->k->variant == AO_HBAO_VARIANT_CLASSIC ? classic_pixel(J, x, y, &n_small, &n_degen)
                                                                 : plus_pixel(J, x, y, &n_degen);
        out[i] = a == a ? a : 1.0f; /* cannot be NaN (every step is guarded); belt and braces */
    }
    J->counts[task][0] = n_bg;
    J->counts[task][1] = n_small;
    J->counts[task][2] = n_degen;
}

/* ================================================================================================
 * The blur
 * ============================================================================================== */

int ao_hbao_simd_available(void)
{
#if HB_HAVE_AVX2
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return 0;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    return 0;
#endif
}

/* The AVX2 loops when ao_hbao_simd_available() (the build, the CPU, OBS_ISA=scalar as the
 * rasterizer) and every texel index of the depth plane fits the 32-bit gather. Same bits. */
static int hbao_use_avx2(const obs_image_f32 *z)
{
    return (int64_t)z->stride * z->height < ((int64_t)1 << 31) && ao_hbao_simd_available();
}

typedef struct blur_job {
    const obs_image_f32 *a;        /* source AO; its pixel (0,0) is buffer (ax0, ay0) */
    int ax0, ay0;
    const obs_image_f32 *z;        /* clean linear depth, full buffer */
    obs_image_f32 *dst;            /* its pixel (0,0) is buffer (dx0, dy0) */
    int dx0, dy0;
    int axis;                      /* 0: x (+x first), 1: y (+y_gl = our -y first) */
    int radius, slope;
    float falloff, sharpness;
    int avx2;                      /* 1: blur_group8 (bit-identical to blur_pixel) */
} blur_job;

/* One pixel of a blur pass (dst column i, buffer row y) */
static inline float blur_pixel(const blur_job *J, int i, int y)
{
    const int W = J->z->width, H = J->z->height;
    const int x = J->dx0 + i;
    const float c = obs_image_f32_row(J->a, y - J->ay0)[x - J->ax0];
    const float zc = obs_image_f32_row(J->z, y)[x];
    if (!(zc < INFINITY)) /* background centre: passes through */
        return c;
    /* ComputeBlur: TotalAO = AOZ.x; TotalW = 1.0; ProcessRadius1(+DeltaUV); ProcessRadius1(-DeltaUV) */
    float total = c, wt = 1.0f;
    for (int side = 0; side < 2; side++) {
        /* +DeltaUV: +x, or +v in GL (up: our row - 1) */
        const int step = J->axis == 0 ? (side == 0 ? 1 : -1) : (side == 0 ? -1 : 1);
        float slope = 0.0f;
        for (int r = 1; r <= J->radius; r++) {
            int tx = x, ty = y;
            if (J->axis == 0) {
                tx = x + step * r;
                tx = tx < 0 ? 0 : tx > W - 1 ? W - 1 : tx;
            } else {
                ty = y + step * r;
                ty = ty < 0 ? 0 : ty > H - 1 ? H - 1 : ty;
            }
            const float zt = obs_image_f32_row(J->z, ty)[tx];
            if (r == 1 && J->slope) /* ProcessRadius1: DepthSlope = AODepth.y - Center.Depth */
                slope = zt < INFINITY ? zt - zc : 0.0f; /* Deviation: no slope from background */
            if (!(zt < INFINITY))
                continue; /* Deviation: background taps get weight 0 */
            const float at = obs_image_f32_row(J->a, ty - J->ay0)[tx - J->ax0];
            /* CrossBilateralWeight: SampleDepth -= DepthSlope * R;
             * DeltaZ = (SampleDepth - Center.Depth) * Sharpness; exp2(-R*R*BlurFalloff - DeltaZ*DeltaZ) */
            const float fr = (float)r;
            const float sd = zt - slope * fr;
            const float dz = (sd - zc) * J->sharpness;
            const float w = hb_exp2f(-fr * fr * J->falloff - dz * dz);
            total += w * at;
            wt += w;
        }
    }
    return total / wt;
}

#if HB_HAVE_AVX2
/* hb_exp2f over 8 lanes, 2 x 4 doubles, with a table: 2^x = 2^e 2^(k/32) 2^f, n = rint(32 x),
 * k = n mod 32, e = n div 32, f = (32 x - n)/32 exact, |f| <= 1/64, 2^f to degree 6
 * (truncation < 2^-57); 2^(k/32) correctly rounded. Relative error below 2^-50, the same
 * rounding-certainty check as hb_exp2f, so the same floats as libm's (float)exp2((double)x).
 * Lanes not in need may come back as anything; lanes in need that are not certain call libm. */
static const double hb_exp2_tab[32] = {
    1.0, 1.0218971486541166, 1.0442737824274138, 1.0671404006768237, 1.0905077326652577,
    1.1143867425958924, 1.1387886347566916, 1.1637248587775775, 1.189207115002721, 1.215247359980469,
    1.241857812073484, 1.2690509571917332, 1.2968395546510096, 1.3252366431597413, 1.3542555469368927,
    1.383909881963832, 1.4142135623730951, 1.4451808069770467, 1.4768261459394993, 1.5091644275934228,
    1.5422108254079407, 1.5759808451078865, 1.6104903319492543, 1.645755478153965, 1.681792830507429,
    1.718619298122478, 1.7562521603732995, 1.7947090750031072, 1.8340080864093424, 1.8741676341103,
    1.9152065613971474, 1.9571441241754002}; /* 2^(k/32) */

HB_AVX2 static inline __m256 hb_exp2f8(__m256 x, __m256 need)
{
    const __m256 xc = _mm256_min_ps(_mm256_max_ps(x, _mm256_set1_ps(-151.0f)), _mm256_set1_ps(127.0f));
    __m128 r[2];
    for (int h = 0; h < 2; h++) {
        const __m256d x32 = _mm256_mul_pd(_mm256_cvtps_pd(h ? _mm256_extractf128_ps(xc, 1) : _mm256_castps256_ps128(xc)),
                                          _mm256_set1_pd(32.0));
        const __m256d n = _mm256_round_pd(x32, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
        const __m256d f = _mm256_mul_pd(_mm256_sub_pd(x32, n), _mm256_set1_pd(0.03125));
        __m256d p = _mm256_set1_pd(hb_exp2_c[6]);
        for (int i = 5; i >= 0; i--)
            p = _mm256_add_pd(_mm256_mul_pd(p, f), _mm256_set1_pd(hb_exp2_c[i]));
        const __m128i ni = _mm256_cvtpd_epi32(n);
        const __m256d t = _mm256_i32gather_pd(hb_exp2_tab, _mm_and_si128(ni, _mm_set1_epi32(31)), 8);
        const __m256i e = _mm256_slli_epi64(
            _mm256_add_epi64(_mm256_cvtepi32_epi64(_mm_srai_epi32(ni, 5)), _mm256_set1_epi64x(1023)), 52);
        const __m256d y = _mm256_mul_pd(_mm256_mul_pd(t, p), _mm256_castsi256_pd(e));
        const __m128 lo = _mm256_cvtpd_ps(_mm256_mul_pd(y, _mm256_set1_pd(HB_EXP2_SAFE_LO)));
        const __m128 hi = _mm256_cvtpd_ps(_mm256_mul_pd(y, _mm256_set1_pd(HB_EXP2_SAFE_HI)));
        r[h] = _mm_blendv_ps(_mm_set1_ps(NAN), lo, _mm_cmpeq_ps(lo, hi));
    }
    __m256 res = _mm256_set_m128(r[1], r[0]);
    /* x in [-151, 127] and certain: done; x < -151 came out as 2^-151 -> +0 (certain) */
    const __m256 inrange = _mm256_cmp_ps(x, _mm256_set1_ps(127.0f), _CMP_LE_OQ); /* false for NaN */
    const __m256 bad = _mm256_and_ps(need, _mm256_or_ps(_mm256_cmp_ps(res, res, _CMP_UNORD_Q),
                                                        _mm256_xor_ps(inrange, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))));
    int mb = _mm256_movemask_ps(bad);
    if (mb) {
        float xs[8], rs[8];
        _mm256_storeu_ps(xs, x);
        _mm256_storeu_ps(rs, res);
        for (int i = 0; i < 8; i++)
            if (mb >> i & 1)
                rs[i] = f_exp2(xs[i]);
        res = _mm256_loadu_ps(rs);
    }
    return res;
}

/* blur_pixel for dst columns i .. i + 7 (lane l = column i + l), bit-identical per lane; the
 * caller guarantees that no horizontal tap needs the edge clamp */
HB_AVX2 static void blur_group8(const blur_job *J, int i, int y, float *o)
{
    const int H = J->z->height;
    const int x = J->dx0 + i;
    const float *zrow = obs_image_f32_row(J->z, y) + x;
    const float *arow = obs_image_f32_row(J->a, y - J->ay0) + (x - J->ax0);
    const __m256 c = _mm256_loadu_ps(arow), zc = _mm256_loadu_ps(zrow);
    const __m256 inf = _mm256_set1_ps(INFINITY), one = _mm256_set1_ps(1.0f);
    const __m256 sharp = _mm256_set1_ps(J->sharpness);
    const __m256 centre = _mm256_cmp_ps(zc, inf, _CMP_LT_OQ);
    if (!_mm256_movemask_ps(centre)) {
        _mm256_storeu_ps(o, c);
        return;
    }
    __m256 total = c, wt = one;
    for (int side = 0; side < 2; side++) {
        const int step = J->axis == 0 ? (side == 0 ? 1 : -1) : (side == 0 ? -1 : 1);
        __m256 slope = _mm256_setzero_ps();
        for (int r = 1; r <= J->radius; r++) {
            const float *zp, *ap;
            if (J->axis == 0) {
                zp = zrow + step * r;
                ap = arow + step * r;
            } else {
                int ty = y + step * r;
                ty = ty < 0 ? 0 : ty > H - 1 ? H - 1 : ty;
                zp = obs_image_f32_row(J->z, ty) + x;
                ap = obs_image_f32_row(J->a, ty - J->ay0) + (x - J->ax0);
            }
            const __m256 zt = _mm256_loadu_ps(zp);
            const __m256 ok = _mm256_cmp_ps(zt, inf, _CMP_LT_OQ);
            if (r == 1 && J->slope)
                slope = _mm256_and_ps(_mm256_sub_ps(zt, zc), ok); /* zt < inf ? zt - zc : +0 */
            const __m256 need = _mm256_and_ps(ok, centre);
            if (!_mm256_movemask_ps(need))
                continue;
            const __m256 at = _mm256_loadu_ps(ap);
            const float fr = (float)r;
            const float cr = -fr * fr * J->falloff; /* the scalar expression's first term */
            const __m256 sd = _mm256_sub_ps(zt, _mm256_mul_ps(slope, _mm256_set1_ps(fr)));
            const __m256 dz = _mm256_mul_ps(_mm256_sub_ps(sd, zc), sharp);
            const __m256 w = hb_exp2f8(_mm256_sub_ps(_mm256_set1_ps(cr), _mm256_mul_ps(dz, dz)), need);
            total = _mm256_blendv_ps(total, _mm256_add_ps(total, _mm256_mul_ps(w, at)), ok);
            wt = _mm256_blendv_ps(wt, _mm256_add_ps(wt, w), ok);
        }
    }
    _mm256_storeu_ps(o, _mm256_blendv_ps(c, _mm256_div_ps(total, wt), centre));
}
#endif

static void blur_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const blur_job *J = (const blur_job *)user;
    const int y = J->dy0 + (int)task;
    float *o = obs_image_f32_row(J->dst, (int)task);
    int i = 0;
#if HB_HAVE_AVX2
    if (J->avx2) {
        const int W = J->z->width, reach = J->axis == 0 ? J->radius : 0;
        for (; i + 8 <= J->dst->width; i += 8) {
            const int x = J->dx0 + i;
            if (x - reach < 0 || x + 7 + reach > W - 1) {
                for (int l = 0; l < 8; l++)
                    o[i + l] = blur_pixel(J, i + l, y);
            } else {
                blur_group8(J, i, y, o + i);
            }
        }
    }
#endif
    for (; i < J->dst->width; i++)
        o[i] = blur_pixel(J, i, y);
}

static void blur_run(obs_pool *pool, const obs_image_f32 *a, int ax0, int ay0, const obs_image_f32 *z,
                     obs_image_f32 *dst, int dx0, int dy0, int axis, int radius, int slope, float falloff,
                     float sharpness)
{
    blur_job J = {a, ax0, ay0, z, dst, dx0, dy0, axis, radius, slope, falloff, sharpness, hbao_use_avx2(z)};
    obs_pool_run(pool, dst->height, blur_row, &J);
}

typedef struct clean_job {
    const obs_image_f32 *src;
    obs_image_f32 *dst;
} clean_job;

static void clean_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const clean_job *J = (const clean_job *)user;
    const float *s = obs_image_f32_row(J->src, (int)task);
    float *d = obs_image_f32_row(J->dst, (int)task);
    for (int x = 0; x < J->src->width; x++)
        d[x] = (s[x] > 0.0f && s[x] < INFINITY) ? s[x] : INFINITY; /* background: +inf */
}

/* dst: a fresh plane, or the workspace's when ws is set (ao_i_ws_plane) */
static obs_status clean_depth(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const obs_image_f32 *src,
                              obs_image_f32 *dst)
{
    obs_status st = ws ? ao_i_ws_plane(ctx, ws, src->width, src->height, dst)
                       : obs_image_f32_alloc(ctx, src->width, src->height, dst);
    if (st != OBS_STATUS_OK)
        return st;
    clean_job J = {src, dst};
    obs_pool_run(pool, src->height, clean_row, &J);
    return OBS_STATUS_OK;
}

obs_status ao_hbao_blur(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ao, const obs_image_f32 *depth,
                        int x0, int y0, int radius, float sigma, float sharpness, int depth_slope, obs_image_f32 *out)
{
    if (!ao || !depth || !out || !ao->data || !depth->data || !out->data || ao->data == out->data ||
        depth->data == out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_hbao_blur: NULL or aliased planes");
    if (ao->width != depth->width || ao->height != depth->height || ao->width < 1 || ao->height < 1 ||
        out->width < 1 || out->height < 1 || x0 < 0 || y0 < 0 || x0 + out->width > ao->width ||
        y0 + out->height > ao->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao_hbao_blur: ao and depth must have the same size and the output window lie inside them");
    if (radius < 1 || radius > AO_HBAO_MAX_BLUR_RADIUS || !(sigma == 0.0f || (sigma >= 0.01f && sigma <= 1e4f)) ||
        !(sharpness >= 0.0f) || !isfinite(sharpness))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao_hbao_blur: radius %d in [1, %d], sigma %g 0 or in [0.01, 1e4], sharpness %g finite >= 0",
                         radius, AO_HBAO_MAX_BLUR_RADIUS, (double)sigma, (double)sharpness);
    const float s = sigma > 0.0f ? sigma : ((float)radius + 1.0f) * 0.5f;
    const float falloff = 1.0f / (2.0f * s * s);
    const int H = ao->height;
    const int ry0 = y0 - radius < 0 ? 0 : y0 - radius;
    const int ry1 = y0 + out->height - 1 + radius > H - 1 ? H - 1 : y0 + out->height - 1 + radius;
    obs_image_f32 z = {0}, tmp = {0};
    obs_status st = clean_depth(ctx, pool, NULL, depth, &z);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, out->width, ry1 - ry0 + 1, &tmp);
    if (st == OBS_STATUS_OK) {
        blur_run(pool, ao, 0, 0, &z, &tmp, x0, ry0, 0, radius, depth_slope != 0, falloff, sharpness);
        blur_run(pool, &tmp, x0, ry0, &z, out, x0, y0, 1, radius, depth_slope != 0, falloff, sharpness);
    }
    obs_image_f32_free(&tmp);
    obs_image_f32_free(&z);
    return st;
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

static const char hbao_workspace_key; /* its address names our slot in the context */

obs_status ao_hbao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_hbao_params *params,
                           obs_image_f32 *out, obs_image_f32 *out_raw, ao_hbao_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_hbao_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "hbao: output planes must be %dx%d (the window)", in->w,
                         in->h);
    if (params->normals == AO_HBAO_NORMALS_GBUFFER && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "hbao: normals from the G-buffer were asked for, but the input has none");
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_hbao_constants k = ao_hbao_constants_from_params(params, in);
    const int W = in->width, H = in->height;
    /* The planes and counts come from the workspace kept in the context between calls
     * (ao_i_ws_*: zeroed as fresh planes, without a fresh plane's page faults) */
    ao_i_ws *ws = ao_i_ws_take(ctx, &hbao_workspace_key);
    hbao_job *J = (hbao_job *)calloc(1, sizeof *J);
    obs_image_f32 z = {0}, raw = {0}, hpass = {0}, vpass = {0};
    int64_t(*counts)[3] = NULL;
    if (!J || !ws) {
        free(J);
        ao_i_ws_put(ctx, &hbao_workspace_key, ws);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "hbao: out of memory");
    }

    /* ---- 1. Clean depth (background = +inf) and the random texture ---- */
    double t0 = obs_time_now();
    st = clean_depth(ctx, pool, ws, in->depth, &z);
    if (k.noise == AO_HBAO_NOISE_SDK)
        ao_hbao_noise_texture_sdk(k.num_dirs, NULL, J->noise);
    else
        ao_hbao_noise_texture(k.num_dirs, NULL, J->noise);
    double t1 = obs_time_now();

    /* ---- 2. AO over the window plus the blur's reach ---- */
    const int m = k.blur ? k.blur_radius : 0;
    const int rx0 = in->x0 - m < 0 ? 0 : in->x0 - m, rx1 = in->x0 + in->w - 1 + m > W - 1 ? W - 1 : in->x0 + in->w - 1 + m;
    const int ry0 = in->y0 - m < 0 ? 0 : in->y0 - m, ry1 = in->y0 + in->h - 1 + m > H - 1 ? H - 1 : in->y0 + in->h - 1 + m;
    const int rw = rx1 - rx0 + 1, rh = ry1 - ry0 + 1;
    if (st == OBS_STATUS_OK)
        st = ao_i_ws_plane(ctx, ws, rw, rh, &raw);
    if (st == OBS_STATUS_OK) {
        counts = (int64_t(*)[3])ao_i_ws_buf(ws, (size_t)rh * sizeof *counts, 1);
        if (!counts)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "hbao: out of memory");
    }
    if (st == OBS_STATUS_OK) {
        J->k = &k;
        J->in = in;
        J->z = &z;
        J->rx0 = rx0;
        J->ry0 = ry0;
        J->ao = &raw;
        J->counts = counts;
        J->avx2 = hbao_use_avx2(&z);
        obs_pool_run(pool, rh, hbao_row, J);
    }
    double t2 = obs_time_now();

    /* ---- 3. Blur: horizontal over (window columns x region rows), then vertical over the window ---- */
    const obs_image_f32 *final = &raw;
    int fx0 = rx0, fy0 = ry0;
    if (st == OBS_STATUS_OK && k.blur) {
        st = ao_i_ws_plane(ctx, ws, in->w, rh, &hpass);
        if (st == OBS_STATUS_OK)
            st = ao_i_ws_plane(ctx, ws, in->w, in->h, &vpass);
        if (st == OBS_STATUS_OK) {
            blur_run(pool, &raw, rx0, ry0, &z, &hpass, in->x0, ry0, 0, k.blur_radius, k.blur_depth_slope,
                     k.blur_falloff, k.blur_sharpness);
            blur_run(pool, &hpass, in->x0, ry0, &z, &vpass, in->x0, in->y0, 1, k.blur_radius, k.blur_depth_slope,
                     k.blur_falloff, k.blur_sharpness);
            final = &vpass;
            fx0 = in->x0;
            fy0 = in->y0;
        }
    }
    double t3 = obs_time_now();

    /* ---- 4. The window ---- */
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < in->h; y++) {
            memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, in->y0 + y - fy0) + (in->x0 - fx0),
                   sizeof(float) * (size_t)in->w);
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(&raw, in->y0 + y - ry0) + (in->x0 - rx0),
                       sizeof(float) * (size_t)in->w);
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rw * rh;
            for (int r = 0; r < rh; r++) {
                stats->pixels_background += counts[r][0];
                stats->pixels_small_radius += counts[r][1];
                stats->pixels_degenerate_normal += counts[r][2];
            }
            stats->seconds_prepare = t1 - t0;
            stats->seconds_ao = t2 - t1;
            stats->seconds_blur = t3 - t2;
        }
    }
    free(J);
    ao_i_ws_put(ctx, &hbao_workspace_key, ws); /* z, raw, hpass, vpass and counts are its */
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_hbao_variant) == sizeof(int) && sizeof(ao_hbao_normals) == sizeof(int),
               "ENUM params are int-sized");
_Static_assert(sizeof(ao_hbao_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

static const char *const hbao_variant_names[] = {"classic", "plus", NULL};
static const char *const hbao_normals_names[] = {"depth", "gbuffer", NULL};
static const char *const hbao_noise_names[] = {"auto", "sdk", "gl-ssao", NULL};
_Static_assert(sizeof(ao_hbao_noise) == sizeof(int), "enum params are read as int");

#define HB_F(field) offsetof(ao_hbao_params, field)
static const ao_param_desc hbao_param_descs[] = {
    {"variant", AO_PARAM_ENUM, HB_F(variant), 0, 0, hbao_variant_names,
     "classic (DX10 SDK horizon angles) or plus (HBAO+ per-tap form, gl_ssao hbao.frag.glsl)"},
    {"radius", AO_PARAM_FLOAT, HB_F(radius), 1e-15, 1e19, NULL, "world-space radius of influence R (m)"},
    {"directions", AO_PARAM_INT, HB_F(directions), 0, AO_HBAO_MAX_DIRECTIONS, NULL,
     "directions N_d (0 = the variant's: classic 16, plus 8)"},
    {"steps", AO_PARAM_INT, HB_F(steps), 0, AO_HBAO_MAX_STEPS, NULL,
     "steps per direction (0 = the variant's: classic 8, plus 4)"},
    {"angle-bias", AO_PARAM_FLOAT, HB_F(angle_bias_deg), 0, 89, NULL, "classic: angle bias (degrees)"},
    {"attenuation", AO_PARAM_FLOAT, HB_F(attenuation), 0, 1e30, NULL, "classic: W(r) = 1 - attenuation r^2"},
    {"contrast", AO_PARAM_FLOAT, HB_F(contrast), 0, 1e30, NULL, "classic: contrast (divided by 1 - sin(bias))"},
    {"ndotv-bias", AO_PARAM_FLOAT, HB_F(ndotv_bias), 0, 0.999999, NULL, "plus: NDotVBias"},
    {"pow-exponent", AO_PARAM_FLOAT, HB_F(pow_exponent), 0, 1e30, NULL, "plus: PowExponent of the output"},
    {"small-scale-ao", AO_PARAM_FLOAT, HB_F(small_scale_ao), 0, 2, NULL,
     "plus: 0 = gl_ssao's sum; > 0 = HBAO+ SmallScaleAO (first step weighs 2x this)"},
    {"normals", AO_PARAM_ENUM, HB_F(normals), 0, 0, hbao_normals_names,
     "depth: the shader's reconstruction from depth (reference); gbuffer: the G-buffer's"},
    {"noise", AO_PARAM_ENUM, HB_F(noise), 0, 0, hbao_noise_names,
     "random texture: auto (classic: sdk, plus: gl-ssao), sdk (DX10 SDK 64 x 64), gl-ssao (4 x 4)"},
    {"blur", AO_PARAM_BOOL, HB_F(blur), 0, 1, NULL, "the HBAO+ cross-bilateral blur (ao_hbao_blur)"},
    {"blur-radius", AO_PARAM_INT, HB_F(blur_radius), 1, AO_HBAO_MAX_BLUR_RADIUS, NULL, "blur KERNEL_RADIUS (px)"},
    {"blur-sharpness", AO_PARAM_FLOAT, HB_F(blur_sharpness), 0, 1e30, NULL, "blur depth sharpness (per m)"},
    {"blur-sigma", AO_PARAM_FLOAT, HB_F(blur_sigma), 0, 1e4, NULL, "blur sigma (px); 0 = (radius + 1) / 2"},
    {"blur-depth-slope", AO_PARAM_BOOL, HB_F(blur_depth_slope), 0, 1, NULL, "blur: HBAO+ depth-slope compensation"},
};
#undef HB_F

static void m_default(void *p) { *(ao_hbao_params *)p = ao_hbao_params_default(); }
static int m_preset(const char *name, void *p) { return ao_hbao_params_preset(name, (ao_hbao_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p) { return ao_hbao_params_validate(ctx, (const ao_hbao_params *)p); }
static int m_to_string(const void *p, char *buf, size_t size) { return ao_hbao_params_to_string((const ao_hbao_params *)p, buf, size); }
static void m_set_samples(void *p, int n)
{
    /* n taps = directions x steps: 2 steps below 16 taps, else 4 (gl_ssao's NUM_STEPS) */
    ao_hbao_params *q = (ao_hbao_params *)p;
    int steps = n < 16 ? 2 : 4, dirs = n / steps;
    dirs = dirs < 1 ? 1 : dirs > AO_HBAO_MAX_DIRECTIONS ? AO_HBAO_MAX_DIRECTIONS : dirs;
    q->steps = steps;
    q->directions = dirs;
}
static void m_set_radius(void *p, float r) { ((ao_hbao_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_hbao_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_hbao_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* CLASSIC: uniform (solid-angle) weighting with W = 1 - d^2/R^2; PLUS: cosine with 1 - d^2/R^2 */
    return ((const ao_hbao_params *)p)->variant == AO_HBAO_VARIANT_PLUS ? "obs-mssao" : "obs-hbao";
}

/* snprintf into (buf, size) at *len, tracking the length needed */
static void jcat(char *buf, size_t size, size_t *len, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static void jcat(char *buf, size_t size, size_t *len, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char *dst = buf && *len < size ? buf + *len : NULL;
    int n = vsnprintf(dst, dst ? size - *len : 0, fmt, ap);
    va_end(ap);
    if (n > 0)
        *len += (size_t)n;
}

static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_hbao_constants K = ao_hbao_constants_from_params((const ao_hbao_params *)p, in);
    size_t len = 0;
    if (buf && size)
        buf[0] = 0;
    jcat(buf, size, &len,
         "{\"variant\": \"%s\", \"pixel_convention\": \"%s\", \"uv_to_view\": [%.9g, %.9g, %.9g, %.9g], "
         "\"resolution\": [%.9g, %.9g], \"inv_resolution\": [%.9g, %.9g], \"num_dirs\": %d, \"num_steps\": %d, ",
         K.variant == AO_HBAO_VARIANT_PLUS ? "plus" : "classic",
         K.variant == AO_HBAO_VARIANT_PLUS ? "GL (y up)" : "D3D (y down)", (double)K.uv_to_view[0],
         (double)K.uv_to_view[1], (double)K.uv_to_view[2], (double)K.uv_to_view[3], (double)K.resolution[0],
         (double)K.resolution[1], (double)K.inv_resolution[0], (double)K.inv_resolution[1], K.num_dirs, K.num_steps);
    if (K.variant == AO_HBAO_VARIANT_CLASSIC) {
        jcat(buf, size, &len,
             "\"g_FocalLen\": [%.9g, %.9g], \"g_R\": %.9g, \"g_inv_R\": %.9g, \"g_sqr_R\": %.9g, "
             "\"g_AngleBias\": %.9g, \"g_TanAngleBias\": %.9g, \"g_Attenuation\": %.9g, \"g_Contrast\": %.9g, "
             "\"g_Dirs\": [",
             (double)K.focal_len[0], (double)K.focal_len[1], (double)K.R, (double)K.inv_R, (double)K.sqr_R,
             (double)K.angle_bias, (double)K.tan_angle_bias, (double)K.attenuation, (double)K.contrast);
        for (int d = 0; d < K.num_dirs; d++)
            jcat(buf, size, &len, "%s[%.9g, %.9g]", d ? ", " : "", (double)K.dirs[d][0], (double)K.dirs[d][1]);
        jcat(buf, size, &len, "], ");
    } else {
        jcat(buf, size, &len,
             "\"RadiusToScreen\": %.9g, \"R2\": %.9g, \"NegInvR2\": %.9g, \"NDotVBias\": %.9g, "
             "\"AOMultiplier\": %.9g, \"PowExponent\": %.9g, \"projOrtho\": %d, \"Alpha\": %.9g, "
             "\"g_fSmallScaleAOAmount\": %.9g, \"g_fLargeScaleAOAmount\": %.9g, ",
             (double)K.radius_to_screen, (double)K.R2, (double)K.neg_inv_R2, (double)K.ndotv_bias,
             (double)K.ao_multiplier, (double)K.pow_exponent, K.orthographic, (double)K.alpha,
             (double)K.small_scale_amount, (double)K.large_scale_amount);
    }
    if (K.noise == AO_HBAO_NOISE_SDK) {
        /* 16384 shorts: the generator instead (ao_hbao_noise_texture_sdk), and its first texel */
        int16_t t0[4];
        {
            int16_t *tmp = (int16_t *)malloc(sizeof(int16_t) * AO_HBAO_NOISE_SIZE_SDK * AO_HBAO_NOISE_SIZE_SDK * 4);
            if (tmp) {
                ao_hbao_noise_texture_sdk(K.num_dirs, tmp, NULL);
                memcpy(t0, tmp, sizeof t0);
                free(tmp);
            } else {
                memset(t0, 0, sizeof t0);
            }
        }
        jcat(buf, size, &len,
             "\"random_texture\": \"dx10-sdk\", \"random_texture_size\": 64, \"random_texture_format\": "
             "\"R16G16B16A16_SNORM\", \"random_texture_generator\": \"HorizonBasedAOEngine.cpp UpdateDirs: MT19937 "
             "init_genrand(0); per texel (cos, sin)(float(2pi_f * genrand/2^32 / N_d)), genrand/2^32, 0; "
             "(short)(32768 v)\", \"random_texture_texel0\": [%d, %d, %d, %d",
             (int)t0[0], (int)t0[1], (int)t0[2], (int)t0[3]);
    } else {
        int16_t sh[AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE * 4];
        ao_hbao_noise_texture(K.num_dirs, sh, NULL);
        jcat(buf, size, &len, "\"random_texture\": \"gl-ssao\", \"random_texture_size\": 4, \"random_texture_rgba16_snorm\": [");
        for (int i = 0; i < AO_HBAO_NOISE_SIZE * AO_HBAO_NOISE_SIZE * 4; i++)
            jcat(buf, size, &len, "%s%d", i ? ", " : "", (int)sh[i]);
    }
    jcat(buf, size, &len,
         "], \"blur\": %d, \"blur_KERNEL_RADIUS\": %d, \"blur_Sharpness\": %.9g, \"blur_BlurFalloff\": %.9g, "
         "\"blur_USE_DEPTH_SLOPE\": %d}",
         K.blur, K.blur_radius, (double)K.blur_sharpness, (double)K.blur_falloff, K.blur_depth_slope);
    return (int)len;
}

static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_hbao_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_hbao_compute(ctx, pool, in, (const ao_hbao_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_prepare;
        stats->seconds_kernel = s.seconds_ao;
        stats->seconds_blur = s.seconds_blur;
    }
    return st;
}

const ao_method ao_i_method_hbao = {
    .name = "hbao",
    .title = "Horizon-Based Ambient Occlusion [Bavoil08]: the DX10 SDK shader, or HBAO+'s taps as gl_ssao",
    .doc = "docs/ao/hbao.md",
    .params_size = sizeof(ao_hbao_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = hbao_preset_names,
    .params = hbao_param_descs,
    .param_count = (int)(sizeof hbao_param_descs / sizeof hbao_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    /* the angle bias starts the horizon above the tangent plane: no tap counts on a plane, the raw
     * AO is exactly 1 except in the first and last row and column, where CLAMP_TO_EDGE fetches put
     * a texel's depth at an unclamped uv (the reference's border artifact); the blur spreads that
     * up to blur_radius pixels inward: 2.6e-4 at 4 px from the border (measured, tilted plane) */
    .flat_value = 1.0f,
    .flat_tolerance = 1e-3f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
