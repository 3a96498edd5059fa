/* ao_ue4.c: Unreal Engine 4's screen-space ambient occlusion [Mittring12]: the passes of
 * PostProcessAmbientOcclusion.usf (the full-resolution pass, and the AO setup levels and the coarse
 * passes of the multi-resolution chain: 2 levels by default, as at quality 50) (UE 4.11/4.12,
 * Copyright 1998-2016; read in JimmieKJ/unrealTournament @ 89cfe56
 * Engine/Shaders/PostProcessAmbientOcclusion.usf), with the constant block of
 * FScreenSpaceAOandSSRShaderParameters::Set (PostProcessAmbientOcclusion.h) and the 4x4
 * SSAORandomization texture of FSystemTextures::InitializeTextures (SystemTextures.cpp).
 *
 * Pixel convention: UE4 is D3D. SV_Position has y DOWN from the top of the render target, which is
 * our row order, so the 4x4 noise texel and the 2x2 quads of the quad blur use (x, y) of the full
 * buffer as they are (a GL port uses (x, H - 1 - y_gl)). UE's ScreenPos is NDC with y UP:
 * sp = ((x + 0.5 - cx) 2/W, -(y + 0.5 - cy) 2/H) (UE assumes cx = W/2, cy = H/2).
 *
 * Units: UE scene units (uu = cm). Depths are multiplied by AO_UE4_UNITS_PER_METRE once, so the
 * shader's constants with a unit (FlatSurfaceBias 5, 1/AmbientOcclusionDistance, the O1 normal scale)
 * act as in a metre-scale UE scene.
 *
 * Arithmetic is float32 in the shader's operation order (built with -ffp-contract=off); HLSL
 * lerp(a, b, t) is a + t * (b - a), rsqrt is 1/sqrtf, pow is powf, saturate maps NaN to 0 (D3D).
 * Deviations from the shader (each also in docs/ao/ue4.md, "Differences from the reference"):
 *   - taps read the full-resolution depth at the nearest texel, not the HZB at MipLevel;
 *   - the classic path (variant "classic-reconstruction", which UE never ran: the shader defines
 *     OPTIMIZATION_O1 1, our default) uses InvHaloSize = 1 / (2 ActualAORadius) (view-space units,
 *     as |Delta|);
 *   - the multi-resolution chain (levels > 1; the default 2) keeps the setup in float32 (UE: FP16
 *     setup, 8-bit coarse AO) and builds each setup level from the previous one;
 *   - background, zero normals and depths beyond AO_UE4_MAX_DEPTH_M are handled explicitly;
 *   - the result is saturated (UE writes a UNORM target) but not quantised to 8 bits.
 *
 * Speed (docs/ao/ue4.md, "Speed"): level 0 reads the input's depth and normals in place; the AO
 * pass and the quad blur run fused per row pair of 128 x 32 tiles; ue4_pixel is the scalar
 * reference, ue4_pixels8 / quad_blur_pair_avx2 the AVX2 paths (8 pixels of a row per vector,
 * bit-identical, chosen at run time; OBS_ISA=scalar forces the scalar one). The coarse levels
 * (levels > 1) keep their planes in one unzeroed block, the workspace's (kept in the context
 * between calls, as the normals and the full-resolution planes); the setup (setup_texel /
 * setup_row_avx2) runs one task per row, the upsample (upsample / v_upsample) reads its taps at
 * texels tabulated per column and per row.
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_ue4_params ao_ue4_params_default(void)
{
    ao_ue4_params p;
    memset(&p, 0, sizeof p);
    p.variant = AO_UE4_DEFAULT_VARIANT;   /* OPTIMIZATION_O1 1: what UE ran (issue 12) */
    p.normals = AO_UE4_NORMALS_GBUFFER;   /* SSAO_NORMAL_MODE 1 (pixel shader default) */
    p.radius = AO_UE4_DEFAULT_RADIUS;
    p.radius_in_ws = AO_UE4_DEFAULT_RADIUS_IN_WS;
    p.power = AO_UE4_DEFAULT_POWER;
    p.intensity = AO_UE4_DEFAULT_INTENSITY;
    p.bias = AO_UE4_DEFAULT_BIAS;
    p.distance = AO_UE4_DEFAULT_DISTANCE;
    p.fade_distance = AO_UE4_DEFAULT_FADE_DISTANCE;
    p.fade_radius = AO_UE4_DEFAULT_FADE_RADIUS;
    p.sample_set = AO_UE4_DEFAULT_SAMPLE_SET;
    p.steps = AO_UE4_DEFAULT_STEPS;
    p.quad_blur = AO_UE4_DEFAULT_QUAD_BLUR;
    p.blur = 0;
    p.levels = AO_UE4_DEFAULT_LEVELS;     /* 2 at quality 50, with our chain's simplifications */
    p.mip_blend = AO_UE4_DEFAULT_MIP_BLEND;
    p.mip_scale = AO_UE4_DEFAULT_MIP_SCALE;
    return p;
}

static const char *const preset_names[] = {"default",   "ue4",       "ue4-o1",    "ue4-multires", "ue4-one-level",
                                           "classic-reconstruction", "thesis", "quality-0", "quality-1",
                                           "quality-2", "quality-3", "quality-4", NULL};

const char *const *ao_ue4_preset_names(void) { return preset_names; }

/* PostProcessAmbientOcclusion.usf: SHADER_QUALITY -> USE_SAMPLESET, SAMPLE_STEPS,
 * QUAD_MESSAGE_PASSING_BLUR; the C++ maps AmbientOcclusionQuality q to the shader level
 * (q > 75) + (q > 55) + (q > 25) + (q > 5) (FSSAOHelper::GetAmbientOcclusionShaderLevel) and,
 * separately, to the number of levels 1 + (q > 70) + (q > 35) (ComputeAmbientOcclusionPassCount).
 * The levels are not a function of the shader level: the fourth column is the count at a
 * representative q of the row (0, 25, 50 = the default, 60, 100); shader level 2 runs 1 level for
 * q in (25, 35], level 3 runs 3 for q in (70, 75] (docs/ao/ue4.md). */
static const int quality_table[5][4] = {{1, 1, 0, 1}, {1, 1, 2, 1}, {1, 2, 2, 2}, {1, 3, 0, 2}, {3, 3, 0, 3}};

int ao_ue4_params_preset(const char *name, ao_ue4_params *out)
{
    if (!name || !out)
        return 0;
    ao_ue4_params p = ao_ue4_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "ue4") || !strcmp(name, "ue4-o1") ||
        !strcmp(name, "ue4-multires")) {
        /* FPostProcessSettings defaults, OPTIMIZATION_O1 1, 2 levels at quality 50. "ue4-o1" and
         * "ue4-multires" named these two choices when the default was neither; they are kept as
         * names of the same, now default, settings. */
    } else if (!strcmp(name, "ue4-one-level")) {
        p.levels = 1; /* r.AmbientOcclusionLevels 1: the full-resolution pass alone */
    } else if (!strcmp(name, "classic-reconstruction")) {
        /* Our reconstruction of the OPTIMIZATION_O1 0 branch, which UE never ran (its 2016
         * InvHaloSize zeroes every weight; we use 1 / (2 ActualAORadius)), on one level: the
         * default before issue 12, kept so that older results can be reproduced. */
        p.variant = AO_UE4_VARIANT_CLASSIC;
        p.levels = 1;
    } else if (!strcmp(name, "thesis")) {
        /* ssao-thesis-2017, Tabla 3: "Unreal Engine AO  Radio(m) 0,05  Muestras 8". The thesis has no
         * UE4 code; it says UE4 "provee mayor oclusión conforme más lejos se encuentra de la cámara",
         * which is the view-space (screen-constant) radius. We read 0.05 as AORadiusInShader: radius =
         * 0.05 * 400 * 4 / 100 m = 0.8 m in view-space mode (docs/ao/ue4.md). */
        p.radius = 0.8f;
        p.radius_in_ws = 0;
        ao_ue4_samples_to_set(8, &p.sample_set, &p.steps);
        p.blur = 1; /* the thesis blurs every technique with its 21-tap Gaussian */
    } else if (!strncmp(name, "quality-", 8) && name[8] >= '0' && name[8] <= '4' && !name[9]) {
        const int q = name[8] - '0';
        p.sample_set = quality_table[q][0];
        p.steps = quality_table[q][1];
        p.quad_blur = quality_table[q][2];
        p.levels = quality_table[q][3];
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

void ao_ue4_samples_to_set(int n, int *sample_set, int *steps)
{
    int s = 1, k = 1;
    if (n <= 6) {
        s = 1, k = 1;
    } else if (n <= 12) {
        s = 1, k = 2;
    } else if (n <= 18) {
        s = 1, k = 3;
    } else if (n <= 36) {
        s = 3, k = 3;
    } else {
        s = 3;
        k = n / 12 + (n % 12 != 0);
        if (k > AO_UE4_MAX_STEPS)
            k = AO_UE4_MAX_STEPS;
    }
    if (sample_set)
        *sample_set = s;
    if (steps)
        *steps = k;
}

obs_status ao_ue4_params_validate(obs_context *ctx, const ao_ue4_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: NULL params");
    if ((unsigned)p->variant >= AO_UE4_VARIANT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: unknown variant %d", (int)p->variant);
    if ((unsigned)p->normals >= AO_UE4_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: unknown normals mode %d", (int)p->normals);
    if (!(p->radius >= 1e-6f && p->radius <= 1e4f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: radius %g must be in [1e-6, 1e4] m",
                         (double)p->radius);
    if (p->radius_in_ws != 0 && p->radius_in_ws != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: radius_in_ws %d must be 0 or 1", p->radius_in_ws);
    if (!(p->power > 0.0f && p->power <= 1e3f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: power %g must be in (0, 1000]", (double)p->power);
    if (!(p->intensity >= 0.0f && p->intensity <= 1.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: intensity %g must be in [0, 1]",
                         (double)p->intensity);
    if (!(p->bias >= 0.0f && p->bias <= 1000.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: bias %g must be in [0, 1000] (per mille of depth)",
                         (double)p->bias);
    if (!(p->distance >= 1e-4f && p->distance <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: distance %g must be in [1e-4, 1e6] m",
                         (double)p->distance);
    if (!(p->fade_distance >= 0.0f && p->fade_distance <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: fade_distance %g must be in [0, 1e6] m",
                         (double)p->fade_distance);
    if (!(p->fade_radius >= 0.0f && p->fade_radius <= 1e6f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: fade_radius %g must be in [0, 1e6] m",
                         (double)p->fade_radius);
    if (p->sample_set < 0 || p->sample_set > 3)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: sample_set %d must be in [0, 3]", p->sample_set);
    if (p->steps < 1 || p->steps > AO_UE4_MAX_STEPS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: steps %d must be in [1, %d]", p->steps,
                         AO_UE4_MAX_STEPS);
    if (p->quad_blur < 0 || p->quad_blur > 3)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: quad_blur %d must be in [0, 3]", p->quad_blur);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: blur %d must be 0 or 1", p->blur);
    if (p->levels < 1 || p->levels > AO_UE4_MAX_LEVELS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: levels %d must be in [1, %d]", p->levels,
                         AO_UE4_MAX_LEVELS);
    if (!(p->mip_blend >= 0.0f && p->mip_blend <= 1.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: mip_blend %g must be in [0, 1]", (double)p->mip_blend);
    if (!(p->mip_scale > 0.0f && p->mip_scale <= 16.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: mip_scale %g must be in (0, 16]", (double)p->mip_scale);
    return OBS_STATUS_OK;
}

/* AO_UE4_VARIANT_CLASSIC is named for what it is, a reconstruction: "--variant classic" is refused
 * with the list of names (docs/ao/ue4.md, "Names"). */
static const char *const variant_names[] = {"classic-reconstruction", "o1", NULL};
static const char *const normals_names[] = {"none", "gbuffer", "depth", NULL};

int ao_ue4_params_to_string(const ao_ue4_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "variant=%s normals=%s radius=%.9g radius_in_ws=%d power=%.9g intensity=%.9g bias=%.9g "
                    "distance=%.9g fade_distance=%.9g fade_radius=%.9g sample_set=%d steps=%d quad_blur=%d blur=%d "
                    "levels=%d mip_blend=%.9g mip_scale=%.9g",
                    (unsigned)p->variant < AO_UE4_VARIANT_COUNT ? variant_names[p->variant] : "?",
                    (unsigned)p->normals < AO_UE4_NORMALS_COUNT ? normals_names[p->normals] : "?", (double)p->radius,
                    p->radius_in_ws, (double)p->power, (double)p->intensity, (double)p->bias, (double)p->distance,
                    (double)p->fade_distance, (double)p->fade_radius, p->sample_set, p->steps, p->quad_blur, p->blur,
                    p->levels, (double)p->mip_blend, (double)p->mip_scale);
}

int ao_ue4_sample_set(int s, float xy[12])
{
    /* PostProcessAmbientOcclusion.usf OcclusionSamplesOffsets (float literals and products, folded in
     * float as the HLSL compiler does) */
    memset(xy, 0, sizeof(float) * 12);
    switch (s) {
    case 0: /* "one sample, for testing" */
        xy[0] = 0.500f, xy[1] = 0.500f;
        return 1;
    case 1: /* "3 points distributed on the unit disc, spiral order and distance" */
        xy[0] = 0.0f * 0.43f, xy[1] = -1.0f * 0.43f;
        xy[2] = 0.58f * 0.7f, xy[3] = 0.814f * 0.7f;
        xy[4] = -0.58f, xy[5] = 0.814f;
        return 3;
    case 2: /* "5 points distributed on a ring" */
        xy[0] = 0.156434f, xy[1] = 0.987688f;
        xy[2] = 0.987688f * 0.9f, xy[3] = 0.156434f * 0.9f;
        xy[4] = 0.453990f * 0.8f, xy[5] = -0.891007f * 0.8f;
        xy[6] = -0.707107f * 0.7f, xy[7] = -0.707107f * 0.7f;
        xy[8] = -0.891006f * 0.65f, xy[9] = 0.453991f * 0.65f;
        return 5;
    case 3: /* "6 points distributed on the unit disc, spiral order and distance" */
        xy[0] = 0.000f, xy[1] = 0.200f;
        xy[2] = 0.325f, xy[3] = 0.101f;
        xy[4] = 0.272f, xy[5] = -0.396f;
        xy[6] = -0.385f, xy[7] = -0.488f;
        xy[8] = -0.711f, xy[9] = 0.274f;
        xy[10] = 0.060f, xy[11] = 0.900f;
        return 6;
    default:
        return 0;
    }
}

static unsigned char quantize8_signed(float x)
{
    /* FMath::Quantize8SignedByte: y = x * 0.5f + 0.5f; (int32)(y * 255.999f) */
    const float y = x * 0.5f + 0.5f;
    int r = (int)(y * 255.999f);
    return (unsigned char)(r < 0 ? 0 : r > 255 ? 255 : r);
}

void ao_ue4_random_texture(unsigned char rgba[16][4])
{
    /* SystemTextures.cpp, "Create the SSAO randomization texture". FMath::Sin/Cos of a float are
     * evaluated correctly rounded (ao_i_cos_sin); PI is UE's float PI. */
    static const int reorder[16] = {0, 11, 7, 3, 10, 4, 15, 12, 6, 8, 1, 14, 13, 2, 9, 5};
    const float g_AngleOff2 = 198, g_AngleOff3 = 23, PI_F = 3.1415926535897932f;
    for (int pos = 0; pos < 16; pos++) {
        const int w = reorder[pos];
        const float ww = (float)w / 16.0f * PI_F;              /* "ordered sampling of the rotation basis" */
        float c1, s1, c, s;
        ao_i_cos_sin(g_AngleOff2 * (float)w * 0.01f, &c1, &s1);
        const float lenm = 1.0f - (s1 * 0.5f + 0.5f) * g_AngleOff3 * 0.01f; /* "randomize base scale" */
        ao_i_cos_sin(ww, &c, &s);
        s = s * lenm;
        c = c * lenm;
        rgba[pos][0] = quantize8_signed(c);
        rgba[pos][1] = quantize8_signed(s);
        rgba[pos][2] = quantize8_signed(-s);
        rgba[pos][3] = quantize8_signed(c);
    }
}

static int effective_normal_mode(const ao_ue4_params *p, const ao_input *in)
{
    if (p->normals == AO_UE4_NORMALS_GBUFFER && !(in && in->normal[0]))
        return AO_UE4_NORMALS_DEPTH; /* no G-buffer normals: UE's own fallback, SSAO_NORMAL_MODE 2 */
    return (int)p->normals;
}

ao_ue4_constants ao_ue4_constants_from_params(const ao_ue4_params *p, const ao_input *in)
{
    ao_ue4_constants k;
    memset(&k, 0, sizeof k);
    const float U = AO_UE4_UNITS_PER_METRE;
    k.full_width = in->width;
    k.full_height = in->height;
    k.units_per_metre = U;
    k.max_depth = AO_UE4_MAX_DEPTH_M * U;
    /* FScreenSpaceAOandSSRShaderParameters::Set (PostProcessAmbientOcclusion.h) at ScaleToFullRes 1 */
    float AORadiusInShader = p->radius * U, ScaleRadiusInWorldSpace = 1.0f;
    if (!p->radius_in_ws) {
        AORadiusInShader /= 400.0f; /* "radius is defined in view space in 400 units" */
        ScaleRadiusInWorldSpace = 0.0f;
    }
    /* "/4 is an adjustment for usage with multiple mips": pow(MipScale, log2(1)) = 1 */
    AORadiusInShader *= powf(AO_UE4_DEFAULT_MIP_SCALE, 0.0f) / 4.0f;
    const float fov_x = (float)(2.0 * in->fx / in->width), fov_y = (float)(2.0 * in->fy / in->height);
    const float FadeRadius = fmaxf(1.0f, p->fade_radius * U); /* "clamp to prevent user error" */
    const float InvFadeRadius = 1.0f / FadeRadius;
    k.power = p->power;
    k.bias_over_1000 = p->bias / 1000.0f;
    k.inv_distance = 1.0f / (p->distance * U);
    k.intensity = p->intensity;
    /* ViewportUVToRandomUV = InputTextureSize / 64 (SSAORandomization is 64x64 of the 4x4 tile) */
    k.viewport_uv_to_random_uv[0] = (float)in->width / 64.0f;
    k.viewport_uv_to_random_uv[1] = (float)in->height / 64.0f;
    k.ao_radius_in_shader = AORadiusInShader;
    k.ratio = fov_y / fov_x; /* UE: UnscaledViewRect W / H, i.e. P11 / P00 for square pixels */
    k.scale_factor = 1.0f;
    k.inv_threshold = 0.01f;  /* AmbientOcclusionMipThreshold / ScaleToFullRes (upsample only) */
    k.scale_radius_in_ws = ScaleRadiusInWorldSpace;
    k.mip_blend = p->mip_blend; /* AmbientOcclusionMipBlend (used with levels > 1) */
    k.temporal_offset[0] = k.temporal_offset[1] = 0.0f;
    k.static_fraction = 1.0f; /* AmbientOcclusionStaticFraction (base-pass AO, not used here) */
    k.inv_tan_half_fov = fov_x; /* ProjMatrix.M[0][0] */
    k.fade_mul = InvFadeRadius;
    k.fade_add = -(p->fade_distance * U - FadeRadius) * InvFadeRadius;
    k.fov_fix[0] = fov_x;
    k.fov_fix[1] = k.ratio * fov_x; /* FovFix = (InvTanHalfFov, Ratio * InvTanHalfFov, 1) */
    k.screen_scale[0] = (float)(2.0 / in->width);
    k.screen_scale[1] = (float)(-2.0 / in->height);
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.variant = (int)p->variant;
    k.normal_mode = effective_normal_mode(p, in);
    k.sample_set = p->sample_set;
    k.sample_count = ao_ue4_sample_set(p->sample_set, k.samples);
    k.steps = p->steps;
    k.quad_blur = p->quad_blur;
    k.blur = p->blur;
    k.levels = p->levels;
    k.mip_scale = p->mip_scale;
    return k;
}

/* ================================================================================================
 * The AO pass
 * ============================================================================================== */

/* HLSL saturate: NaN -> 0 (D3D10+ rules), clamp to [0, 1] */
static inline float saturatef(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }
/* HLSL lerp(a, b, t) = a + t * (b - a) (mad without fusing) */
static inline float lerpf(float a, float b, float t) { return a + t * (b - a); }
/* HLSL max (non-NaN operand wins) */
static inline float hmax(float a, float b) { return a > b ? a : (b == b ? b : a); }
static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* One resolution level: level 0 is the full buffer; level l (multi-resolution option) is the
 * AO setup of MainSetupPS, DivideAndRoundUp(size, 2) of level l - 1. */
typedef struct level {
    int w, h;
    float s;              /* ScaleToFullRes: 1, 2, 4 */
    float inv_s;          /* 1 / s: a power of two, so u * inv_s is u / s bit for bit */
    /* Levels >= 1 (the planes share one stride and one block of the workspace; every texel is
     * written before it is read, so nothing is zeroed): */
    obs_image_f32 z;      /* depth in uu; background -> max_depth */
    obs_image_f32 ln[3];  /* the setup's stored normal decoded, e * 2 - 1 (modes 1, 2): the upsample's
                             tap normal, and normalised (ue4_normal_at) the coarse pass's normal */
    obs_image_f32 e[3];   /* the setup's stored normal (n * 0.5 + 0.5, averaged); only where a
                             coarser level is built from it (modes 1, 2) */
    unsigned char *bg;    /* 1: background */
    obs_image_f32 ao;     /* the level's AO (after its quad blur) */
    /* Every level: */
    float *spx, *spy;     /* ScreenPos.x of column x in [0, w], ScreenPos.y of row y in [0, h]
                             (a quad's helper lane may be one past the edge) */
    /* Where a coarser level follows: ComputeUpsampleContribution's tap texels in the coarser
     * level, per column x in [0, w] (utx[k][x], k over the x offsets) and per row y in [0, h]
     * (uty[k][y]); 2 offsets (+-0.5) at level 0, 3 (-1, 0, 1) above. */
    int *utx[3], *uty[3];
    float radius;         /* AORadiusInShader of the level */
    float samples[12];
    int sample_count;
} level;

typedef struct prep {
    const ao_ue4_constants *k;
    const ao_input *in;
    level lv[AO_UE4_MAX_LEVELS];
    int levels;
    int simd;             /* 1: the AVX2 row kernel (bit-identical to the scalar one) */
    float rand_vec[16][2];/* RandomVec / ActualAORadius = .rg * 2 - 1 */
    float cx, cy, half_w, half_h; /* principal point and half size of the full buffer */
    float fov_fix[3], inv_fov_fix[3]; /* FovFix = (P00, P11, 1) and 1 / FovFix (per frame) */
    const obs_image_f32 *nsrc[3]; /* the source normals (ours: right-handed), NULL without */
} prep;

/* normalize(ViewSpaceNormal) from our view-space normal: right-handed, -Z forward, to UE's
 * left-handed +Z forward (x, y, -z), as v * rsqrt(dot(v, v)); zero when unusable. */
static inline void ue4_normal_from(float sx, float sy, float sz, float o[3])
{
    const float v[3] = {sx, sy, -sz};
    const float dd = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if (!(dd > 0.0f) || !isfinite(dd)) {
        o[0] = o[1] = o[2] = 0.0f;
        return;
    }
    const float rs = 1.0f / sqrtf(dd); /* normalize = v * rsqrt(dot(v, v)) */
    o[0] = v[0] * rs;
    o[1] = v[1] * rs;
    o[2] = v[2] * rs;
}

/* The coarse pass's normal from the setup's: normalize(rgb * 2 - 1), zero where the decoded
 * normal is zero. */
static inline void ue4_normal_from_setup(const float nv[3], float o[3])
{
    const float dd = nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2];
    const float rs = dd > 0.0f ? 1.0f / sqrtf(dd) : 0.0f;
    for (int c = 0; c < 3; c++)
        o[c] = nv[c] * rs;
}

/* The normal of texel (tx, ty): at a coarse level normalised from the setup's decoded normal, at
 * level 0 (which keeps no planes) converted from the source normals on the spot. */
static inline void ue4_normal_at(const prep *P, const level *L, int tx, int ty, float n[3])
{
    if (L->ln[0].data) {
        const float nv[3] = {obs_image_f32_row(&L->ln[0], ty)[tx], obs_image_f32_row(&L->ln[1], ty)[tx],
                             obs_image_f32_row(&L->ln[2], ty)[tx]};
        ue4_normal_from_setup(nv, n);
        return;
    }
    ue4_normal_from(obs_image_f32_row(P->nsrc[0], ty)[tx], obs_image_f32_row(P->nsrc[1], ty)[tx],
                    obs_image_f32_row(P->nsrc[2], ty)[tx], n);
}

/* Level 0 keeps no planes of its own (no per-call full-size allocation, whose page faults cost
 * more than the conversion): SceneDepth in uu and the background flag come straight from the
 * input depth. Background is a depth that is not finite or <= 0; background and huge depths read
 * max_depth ("sky and huge depths read as 100 km"). */
static inline int depth_is_bg(float dm) { return !(isfinite(dm) && dm > 0.0f); }
static inline float depth_uu(const prep *P, float dm)
{
    const float zmax = P->k->max_depth;
    const float v = depth_is_bg(dm) ? zmax : dm * P->k->units_per_metre;
    return v < zmax ? v : zmax;
}
static inline float level_depth(const prep *P, const level *L, int tx, int ty)
{
    if (L->z.data)
        return obs_image_f32_row(&L->z, ty)[tx];
    return depth_uu(P, obs_image_f32_row(P->in->depth, ty)[tx]);
}
/* The background flags of row ty, columns [x0, x1), at dst[x0 .. x1 - 1] (level 0), or a pointer
 * into the level's plane (indexed by x as well). */
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
static int bg_row_avx2(const float *d, int x0, int x1, unsigned char *dst);
#endif
static inline const unsigned char *level_bg_row(const prep *P, const level *L, int ty, int x0, int x1,
                                                unsigned char *dst)
{
    if (L->bg)
        return L->bg + (size_t)ty * L->w;
    const float *d = obs_image_f32_row(P->in->depth, ty);
    int x = x0;
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    if (P->simd)
        x = bg_row_avx2(d, x0, x1, dst);
#endif
    for (; x < x1; x++)
        dst[x] = (unsigned char)depth_is_bg(d[x]);
    return dst;
}

/* ScreenPosToHZBUV + point sampling on the level's depth: floor((sx * W/2 + cx) / s), clamped
 * to the level. The position is first clamped to +-1e9 (NaN -> -1e9), so the truncation below is
 * floorf exactly: (int)u rounds toward zero, one less where that was upwards. */
static inline int texel_clamp_floor(float u, int n)
{
    if (!(u > -1e9f))
        u = -1e9f;
    if (u > 1e9f)
        u = 1e9f;
    int i = (int)u;
    i -= (float)i > u;
    return clampi(i, 0, n - 1);
}
static inline int texel_x(const prep *P, const level *L, float sx)
{
    return texel_clamp_floor((sx * P->half_w + P->cx) * L->inv_s, L->w);
}
static inline int texel_y(const prep *P, const level *L, float sy)
{
    return texel_clamp_floor((P->cy - sy * P->half_h) * L->inv_s, L->h); /* NDC y up -> our row (down) */
}
static inline float depth_at(const prep *P, const level *L, float sx, float sy)
{
    return level_depth(P, L, texel_x(P, L, sx), texel_y(P, L, sy));
}

/* ComputeUpsampleContribution (AO_UPSAMPLE_QUALITY 0: 4 taps at +-0.5 coarse texel at full
 * resolution, 1: 9 taps at -1, 0, 1 at the coarse levels), point sampling, clamped. Weight
 * saturate(1 - |dz| 0.003) * saturate(dot(n_tap, n_centre)), normals decoded as rgb * 2 - 1 (the
 * coarser level's ln planes). The tap texels depend only on the column and on the row: they come
 * from the level's utx/uty tables (upsample_tables). Taps in the shader's order: (-0.5, +0.5),
 * (+0.5, +0.5), (-0.5, -0.5), (+0.5, -0.5) at level 0; (-1, -1), (0, -1), .. (1, 1) above. */
static const signed char upsample_taps4[4][2] = {{0, 1}, {1, 1}, {0, 0}, {1, 0}}; /* (x, y) offset indices */
static const signed char upsample_taps9[9][2] = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {1, 1}, {2, 1}, {0, 2}, {1, 2}, {2, 2}};

static void upsample_tables(const level *F, const level *C, int l)
{
    static const float o2[2] = {-0.5f, 0.5f}, o3[3] = {-1.0f, 0.0f, 1.0f};
    const int n = l == 0 ? 2 : 3;
    const float *o = l == 0 ? o2 : o3;
    for (int x = 0; x <= F->w; x++) {
        const float cu = ((float)x + 0.5f) / (float)F->w * (float)C->w;
        for (int k = 0; k < n; k++)
            F->utx[k][x] = clampi((int)floorf(cu + o[k]), 0, C->w - 1);
    }
    for (int y = 0; y <= F->h; y++) {
        const float cv = ((float)y + 0.5f) / (float)F->h * (float)C->h;
        for (int k = 0; k < n; k++)
            F->uty[k][y] = clampi((int)floorf(cv + o[k]), 0, C->h - 1);
    }
}

static float upsample(const prep *P, int l, int x, int y, float SceneDepth, const float cn[3])
{
    const level *F = &P->lv[l], *C = &P->lv[l + 1];
    const int n = l == 0 ? 4 : 9;
    const signed char(*taps)[2] = l == 0 ? upsample_taps4 : upsample_taps9;
    const int use_n = P->k->normal_mode != AO_UE4_NORMALS_NONE;
    const float SmallValue = 0.0001f;
    float WeightSum = SmallValue, Ret = SmallValue;
    for (int i = 0; i < n; i++) {
        const int tx = F->utx[taps[i][0]][x], ty = F->uty[taps[i][1]][y];
        const float SampleValue = obs_image_f32_row(&C->ao, ty)[tx];
        const float SampleDepth = obs_image_f32_row(&C->z, ty)[tx];
        float Weight = saturatef(1.0f - fabsf(SampleDepth - SceneDepth) * 0.003f); /* "crawling pattern at edges" */
        if (use_n) {
            const float ln[3] = {obs_image_f32_row(&C->ln[0], ty)[tx], obs_image_f32_row(&C->ln[1], ty)[tx],
                                 obs_image_f32_row(&C->ln[2], ty)[tx]};
            Weight *= saturatef(ln[0] * cn[0] + ln[1] * cn[1] + ln[2] * cn[2]);
        }
        Ret += SampleValue * Weight;
        WeightSum += Weight;
    }
    return Ret / WeightSum;
}

/* The end of MainPSandCS after the sample loop: r = Sum / WeightSum of the pixel, its upsampled
 * blend (coarser levels present), and at level 0 the fade and the user adjustment. n is the
 * pixel's normal (zero without normals), (tx, ty) its clamped texel. */
static float ue4_finish(const prep *P, int l, int x, int y, int tx, int ty, float r, float SceneDepth,
                        const float n[3])
{
    const ao_ue4_constants *k = P->k;
    const level *L = &P->lv[l];
    /* "recombined result from multiple resolutions": lerp(ao, upsampled, MipBlend) (USE_UPSAMPLE) */
    if (l + 1 < P->levels) {
        float cn[3] = {n[0], n[1], n[2]}; /* CenterWorldNormal: level 0 the G-buffer's, else the setup's */
        if (l > 0 && k->normal_mode != AO_UE4_NORMALS_NONE)
            for (int c = 0; c < 3; c++)
                cn[c] = obs_image_f32_row(&L->ln[c], ty)[tx];
        r = lerpf(r, upsample(P, l, x, y, SceneDepth, cn), k->mip_blend);
    }
    if (l > 0)
        return r;
    /* "soft fade out AO in the distance" */
    r = lerpf(r, 1.0f, saturatef(SceneDepth * k->fade_mul + k->fade_add));
    /* "user adjust AO": 1 - (1 - pow(abs(r), Power)) * Intensity; pow(1, y) = 1 exactly (C11
     * F.10.4.4), the unoccluded pixels skip the call */
    const float ar = fabsf(r);
    return 1.0f - (1.0f - (ar == 1.0f ? 1.0f : powf(ar, k->power))) * k->intensity;
}

/* One pixel of MainPSandCS at level l (x, y in the level, possibly one past its edge: a quad's
 * helper lane). *ao gets OutColor.r (level 0: after the fade and the user adjustment; coarser
 * levels: the raw AO, as USE_AO_SETUP_AS_INPUT skips them), before the quad blur; *depth the
 * SceneDepth (uu) and nxy normalize(ViewSpaceNormal).xy for the quad blur. Returns 1 for a
 * background pixel (ao = 1). The scalar reference: the AVX2 row kernel below computes the same
 * operations in the same order, eight pixels at a time. */
static int ue4_pixel(const prep *P, int l, int x, int y, const unsigned char *bgrow, float *ao, float *depth,
                     float nxy[2], int *bad_normal)
{
    const ao_ue4_constants *k = P->k;
    const level *L = &P->lv[l];
    const int tx = clampi(x, 0, L->w - 1), ty = clampi(y, 0, L->h - 1);
    nxy[0] = nxy[1] = 0.0f;
    *bad_normal = 0;
    const float SceneDepth = level_depth(P, L, tx, ty);
    *depth = SceneDepth;
    if (bgrow[tx]) {
        *ao = 1.0f;
        return 1;
    }
    /* ScreenPos (NDC, y up) of the pixel centre, from the principal point (computed in double:
     * the level's tables) */
    const float sp_x = L->spx[x], sp_y = L->spy[y];
    const float *FovFix = P->fov_fix, *InvFovFix = P->inv_fov_fix;

    /* ViewSpaceNormal = normalize(mul(WorldNormal, TranslatedWorldToView)) (prepared per pixel) */
    float n[3] = {0.0f, 0.0f, 0.0f};
    const int use_n = k->normal_mode != AO_UE4_NORMALS_NONE;
    if (use_n) {
        ue4_normal_at(P, L, tx, ty, n);
        if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) {
            *bad_normal = 1; /* UE would compute normalize(0) = NaN: we return visibility 1 */
            *ao = 1.0f;
            return 0;
        }
        nxy[0] = n[0];
        nxy[1] = n[1];
    }

    /* ReconstructCSPos(SceneDepth, ScreenPos) = (ScreenPos * SceneDepth, SceneDepth). Orthographic
     * (our extension, docs/ao/ue4.md): (ScreenPos * units_per_metre, SceneDepth). */
    const int ortho = k->orthographic;
    const float U = k->units_per_metre;
    float V[3] = {sp_x * (ortho ? U : SceneDepth), sp_y * (ortho ? U : SceneDepth), SceneDepth};
    /* ActualAORadius = AORadiusInShader * lerp(SceneDepth, 1, ScaleRadiusInWorldSpace) */
    const float ActualAORadius = L->radius * lerpf(SceneDepth, 1.0f, k->scale_radius_in_ws);
    /* "Add bias after fixup": ViewSpacePosition += Bias * SceneDepth * ScaleFactor * (n * FovFix) */
    if (use_n) {
        const float b = k->bias_over_1000 * SceneDepth * L->s;
        V[0] += b * (n[0] * FovFix[0]);
        V[1] += b * (n[1] * FovFix[1]);
        V[2] += b * (n[2] * FovFix[2]);
    }
    float WA[2] = {0.0001f, 0.0001f}; /* WeightAccumulator */

    /* AO_SAMPLE_QUALITY 3: RandomVec = (tex.rg * 2 - 1) * ActualAORadius, tex at pixel % 4
     * (UV * ViewportUVToRandomUV with a point-wrap sampler on the 64x64 texture; TemporalOffset 0) */
    const int ri = (((x % 4) + 4) % 4) + 4 * (((y % 4) + 4) % 4);
    const float RandomVec[2] = {P->rand_vec[ri][0] * ActualAORadius, P->rand_vec[ri][1] * ActualAORadius};
    const float csV = ortho ? U : V[2];
    const float invz = 1.0f / csV;
    const float FovFixXY[2] = {FovFix[0] * invz, FovFix[1] * invz};
    const float RandomBase[4] = {RandomVec[0] * FovFixXY[0], RandomVec[1] * FovFixXY[1],
                                 -RandomVec[1] * FovFixXY[0], RandomVec[0] * FovFixXY[1]};
    const float SSP[2] = {V[0] / csV, V[1] / csV}; /* ScreenSpacePos = ViewSpacePosition.xy / z */
    /* Deviation: the 2016 shader's InvHaloSize = 1 / (ActualAORadius * FovFixXY.x * 2) is in NDC
     * units while |Delta| is in uu, which zeroes every weight at UE's scale; we use the view-space
     * radius, 1 / (2 ActualAORadius) (docs/ao/ue4.md). */
    const float InvHaloSize = 1.0f / (ActualAORadius * 2.0f);
    float Ns[3] = {n[0], n[1], n[2]}; /* ScaledViewSpaceNormal */
    if (k->variant == AO_UE4_VARIANT_O1) {
        const float sc = 0.08f * lerpf(SceneDepth, 1000.0f, k->scale_radius_in_ws);
        Ns[0] *= sc, Ns[1] *= sc, Ns[2] *= sc;
    }
    const float InvD = k->inv_distance;
    const float ViewDepthAdd = 1.0f - V[2] * InvD;

    for (int i = 0; i < L->sample_count; i++) {
        const float ux = L->samples[2 * i], uy = L->samples[2 * i + 1];
        /* 2x2 rotation: LocalRandom = u.x * RandomBase.xy + u.y * RandomBase.zw */
        const float LR[2] = {ux * RandomBase[0] + uy * RandomBase[2], ux * RandomBase[1] + uy * RandomBase[3]};
        float acc[3] = {0.0f, 0.0f, 0.0f};
        for (int step = 0; step < k->steps; step++) {
            const float Scale = (float)(step + 1) / (float)k->steps;
            const float lr[2] = {Scale * LR[0], Scale * LR[1]};
            /* Wedge*: L = centre + lr, R = centre - lr; the tap's position uses the continuous
             * screen position and the depth of its texel */
            const float SL[2] = {SSP[0] + lr[0], SSP[1] + lr[1]}, SR[2] = {SSP[0] - lr[0], SSP[1] - lr[1]};
            const float AbsL = depth_at(P, L, SL[0], SL[1]), AbsR = depth_at(P, L, SR[0], SR[1]);
            const float cL = ortho ? U : AbsL, cR = ortho ? U : AbsR;
            const float PL[3] = {SL[0] * cL, SL[1] * cL, AbsL}, PR[3] = {SR[0] * cR, SR[1] * cR, AbsR};
            const float DL[3] = {(PL[0] - V[0]) * InvFovFix[0], (PL[1] - V[1]) * InvFovFix[1],
                                 (PL[2] - V[2]) * InvFovFix[2]};
            const float DR[3] = {(PR[0] - V[0]) * InvFovFix[0], (PR[1] - V[1]) * InvFovFix[1],
                                 (PR[2] - V[2]) * InvFovFix[2]};
            const float LL = DL[0] * DL[0] + DL[1] * DL[1] + DL[2] * DL[2];
            const float RR = DR[0] * DR[0] + DR[1] * DR[1] + DR[2] * DR[2];
            if (use_n) {
                /* WedgeWithNormal */
                const float dl = DL[0] * Ns[0] + DL[1] * Ns[1] + DL[2] * Ns[2];
                const float dr = DR[0] * Ns[0] + DR[1] * Ns[1] + DR[2] * Ns[2];
                float sL, sR, w;
                if (k->variant == AO_UE4_VARIANT_O1) {
                    sL = saturatef(dl / LL);
                    sR = saturatef(dr / RR);
                    w = 1.0f;
                } else {
                    sL = saturatef(dl * (1.0f / sqrtf(LL)));
                    sR = saturatef(dr * (1.0f / sqrtf(RR)));
                    w = saturatef(1.0f - sqrtf(LL) * InvHaloSize) * saturatef(1.0f - sqrtf(RR) * InvHaloSize);
                }
                /* "combine horizon samples": acc = lerp(acc, float3(max(acc.xy, s.xy), 1), w) */
                acc[0] = lerpf(acc[0], hmax(acc[0], sL), w);
                acc[1] = lerpf(acc[1], hmax(acc[1], sR), w);
                acc[2] = lerpf(acc[2], 1.0f, w);
            } else {
                /* WedgeNoNormal, OptionA: NormAngle = acosApproxNormAngle(dot(DL, DR) / sqrt(|DL|^2 |DR|^2)) */
                const float cosLR = (DL[0] * DR[0] + DL[1] * DR[1] + DL[2] * DR[2]) / sqrtf(LL * RR);
                float NormAngle = saturatef((1.0f - cosLR) * 0.5f * AO_UE4_CONTRAST_TWEAK);
                const float left = V[2] - AbsL, right = V[2] - AbsR;
                if (left + right < AO_UE4_FLAT_SURFACE_BIAS)
                    NormAngle = 1.0f; /* "fix concave case" */
                /* "to avoid halos around objects" */
                float Weight = 1.0f;
                Weight *= saturatef(PL[2] * InvD + ViewDepthAdd);
                Weight *= saturatef(PR[2] * InvD + ViewDepthAdd);
                const float sv = (1.0f - NormAngle) / (Weight + 0.001f);
                acc[0] = lerpf(acc[0], hmax(acc[0], sv), Weight);
                acc[2] = lerpf(acc[2], 1.0f, Weight);
            }
        }
        /* "Square(): the area scales quadratic with the angle" */
        if (use_n) {
            WA[0] += (1.0f - acc[0]) * (1.0f - acc[0]) * acc[2];
            WA[1] += acc[2];
            WA[0] += (1.0f - acc[1]) * (1.0f - acc[1]) * acc[2];
            WA[1] += acc[2];
        } else {
            WA[0] += (1.0f - acc[0]) * (1.0f - acc[0]) * acc[2];
            WA[1] += acc[2];
        }
    }
    *ao = ue4_finish(P, l, x, y, tx, ty, WA[0] / WA[1], SceneDepth, n);
    return 0;
}

#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#define UE4_AVX2 1
#include <immintrin.h>

/* ================================================================================================
 * The AVX2 row kernel: ue4_pixel for eight consecutive pixels of a row (lane i = pixel x0 + i),
 * step for step. Every operation is the IEEE one of the scalar code (add, sub, mul, div, sqrt are
 * correctly rounded in both; no FMA: this file has no -mfma and the build -ffp-contract=off), so
 * the results are bit-identical (tests/test_ao_ue4.c, ue4_avx2_matches_scalar_bit_for_bit).
 * Lanes are computed whole (background and zero-normal lanes too, on their clamped texels) and
 * their results replaced afterwards, as ue4_pixel's early returns do. Multiplications by 1.0f
 * (InvFovFix.z, the first Weight) are left out: they are exact.
 * ============================================================================================== */

#define UE4_AVX2_FN __attribute__((target("avx2")))

/* saturate: v > 0 ? (v < 1 ? v : 1) : 0 (max_ps(a, b) is a > b ? a : b, NaN -> b = 0) */
UE4_AVX2_FN static inline __m256 v_sat(__m256 v)
{
    return _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), _mm256_set1_ps(1.0f));
}
/* hmax(a, b) = a > b ? a : (b == b ? b : a) */
UE4_AVX2_FN static inline __m256 v_hmax(__m256 a, __m256 b)
{
    const __m256 keep_a = _mm256_or_ps(_mm256_cmp_ps(a, b, _CMP_GT_OQ), _mm256_cmp_ps(b, b, _CMP_UNORD_Q));
    return _mm256_blendv_ps(b, a, keep_a);
}
/* lerp(a, b, t) = a + t * (b - a) */
UE4_AVX2_FN static inline __m256 v_lerp(__m256 a, __m256 b, __m256 t)
{
    return _mm256_add_ps(a, _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
}
/* texel_clamp_floor of eight positions: clamp to +-1e9 (min/max_ps give the scalar's NaN rule),
 * floor, convert, clamp to [0, n - 1] */
UE4_AVX2_FN static inline __m256i v_texel(__m256 u, __m256i nm1)
{
    u = _mm256_max_ps(u, _mm256_set1_ps(-1e9f));
    u = _mm256_min_ps(u, _mm256_set1_ps(1e9f));
    const __m256i i = _mm256_cvttps_epi32(_mm256_floor_ps(u));
    return _mm256_min_epi32(_mm256_max_epi32(i, _mm256_setzero_si256()), nm1);
}

/* Pixels x0 .. x0 + 7 of row y of level l (all inside the level: x0 + 7 < w). Writes the eight
 * outputs of ue4_pixel and adds the background and zero-normal counts. */
/* depth_uu of eight input depths: background (not dm > 0 && dm < inf) and huge -> max_depth */
UE4_AVX2_FN static inline __m256 v_depth_uu(__m256 dm, __m256 U, __m256 zmax)
{
    const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(dm, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(dm, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    return _mm256_blendv_ps(zmax, _mm256_min_ps(_mm256_mul_ps(dm, U), zmax), ok);
}

/* level_bg_row's flags eight at a time (depth_is_bg: not (dm > 0 && dm < inf)); returns the
 * first column left */
UE4_AVX2_FN static int bg_row_avx2(const float *d, int x0, int x1, unsigned char *dst)
{
    int x = x0;
    for (; x + 8 <= x1; x += 8) {
        const __m256 dm = _mm256_loadu_ps(d + x);
        const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(dm, _mm256_setzero_ps(), _CMP_GT_OQ),
                                        _mm256_cmp_ps(dm, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
        const __m256i b = _mm256_andnot_si256(_mm256_castps_si256(ok), _mm256_set1_epi32(1)); /* 1 = background */
        const __m256i p16 = _mm256_packus_epi32(b, b), p8 = _mm256_packus_epi16(p16, p16);
        const uint32_t lo = (uint32_t)_mm_cvtsi128_si32(_mm256_castsi256_si128(p8));
        const uint32_t hi = (uint32_t)_mm_cvtsi128_si32(_mm256_extracti128_si256(p8, 1));
        memcpy(dst + x, &lo, 4);
        memcpy(dst + x + 4, &hi, 4);
    }
    return x;
}

/* ue4_normal_from of eight source normals (ours): (x, y, -z) * rsqrt(dot), zero unless the dot is
 * finite and > 0 */
UE4_AVX2_FN static inline void v_normal_from(__m256 sx, __m256 sy, __m256 sz, __m256 *o0, __m256 *o1, __m256 *o2)
{
    const __m256 n2 = _mm256_xor_ps(sz, _mm256_set1_ps(-0.0f));
    const __m256 dd = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(sx, sx), _mm256_mul_ps(sy, sy)), _mm256_mul_ps(n2, n2));
    const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(dd, _mm256_setzero_ps(), _CMP_GT_OQ),
                                    _mm256_cmp_ps(dd, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    const __m256 rs = _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_sqrt_ps(dd));
    *o0 = _mm256_and_ps(_mm256_mul_ps(sx, rs), ok);
    *o1 = _mm256_and_ps(_mm256_mul_ps(sy, rs), ok);
    *o2 = _mm256_and_ps(_mm256_mul_ps(n2, rs), ok);
}

/* ue4_normal_from_setup of eight decoded setup normals: nv * (dd > 0 ? 1 / sqrt(dd) : 0) */
UE4_AVX2_FN static inline void v_normal_from_setup(__m256 v0, __m256 v1, __m256 v2, __m256 *o0, __m256 *o1,
                                                   __m256 *o2)
{
    const __m256 dd = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, v0), _mm256_mul_ps(v1, v1)), _mm256_mul_ps(v2, v2));
    const __m256 rs = _mm256_and_ps(_mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_sqrt_ps(dd)),
                                    _mm256_cmp_ps(dd, _mm256_setzero_ps(), _CMP_GT_OQ));
    *o0 = _mm256_mul_ps(v0, rs);
    *o1 = _mm256_mul_ps(v1, rs);
    *o2 = _mm256_mul_ps(v2, rs);
}

/* upsample for the eight pixels x0 .. x0 + 7 of row y of level l (the coarser level's planes read
 * at the tap texels of the utx/uty tables; the same operations in the same order). The tables
 * increase with x, and eight pixels span about four coarse texels: where a tap's eight texels lie
 * within eight consecutive ones, one load of eight texels of the row (moved back from the row's end
 * to stay inside it) and a lane permutation fetch them: the same values as a gather, fewer loads. */
UE4_AVX2_FN static __m256 v_upsample(const prep *P, int l, int x0, int y, __m256 SceneDepth, __m256 cn0, __m256 cn1,
                                     __m256 cn2)
{
    const level *F = &P->lv[l], *C = &P->lv[l + 1];
    const int n = l == 0 ? 4 : 9;
    const signed char(*taps)[2] = l == 0 ? upsample_taps4 : upsample_taps9;
    const int use_n = P->k->normal_mode != AO_UE4_NORMALS_NONE;
    const __m256 one = _mm256_set1_ps(1.0f), sgn = _mm256_set1_ps(-0.0f), c0003 = _mm256_set1_ps(0.003f);
    __m256 WeightSum = _mm256_set1_ps(0.0001f), Ret = WeightSum;
    const __m256i stride = _mm256_set1_epi32((int)C->z.stride); /* every plane of C has this stride */
    for (int i = 0; i < n; i++) {
        const int *txt = F->utx[taps[i][0]] + x0;
        const int row = F->uty[taps[i][1]][y];
        const __m256i tx = _mm256_loadu_si256((const __m256i *)txt);
        __m256 SampleValue, SampleDepth, t0 = _mm256_setzero_ps(), t1 = t0, t2 = t0;
        if (txt[7] - txt[0] <= 7 && C->w >= 8) { /* one row load per plane, lanes permuted */
            const int base = txt[0] < C->w - 8 ? txt[0] : C->w - 8; /* txt[7] - base stays <= 7 */
            const size_t o = (size_t)row * (size_t)C->z.stride + (size_t)base;
            const __m256i perm = _mm256_sub_epi32(tx, _mm256_set1_epi32(base));
            SampleValue = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->ao.data + o), perm);
            SampleDepth = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->z.data + o), perm);
            if (use_n) {
                t0 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->ln[0].data + o), perm);
                t1 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->ln[1].data + o), perm);
                t2 = _mm256_permutevar8x32_ps(_mm256_loadu_ps(C->ln[2].data + o), perm);
            }
        } else {
            const __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_set1_epi32(row), stride), tx);
            SampleValue = _mm256_i32gather_ps(C->ao.data, idx, 4);
            SampleDepth = _mm256_i32gather_ps(C->z.data, idx, 4);
            if (use_n) {
                t0 = _mm256_i32gather_ps(C->ln[0].data, idx, 4);
                t1 = _mm256_i32gather_ps(C->ln[1].data, idx, 4);
                t2 = _mm256_i32gather_ps(C->ln[2].data, idx, 4);
            }
        }
        __m256 Weight = v_sat(_mm256_sub_ps(one, _mm256_mul_ps(_mm256_andnot_ps(sgn, _mm256_sub_ps(SampleDepth, SceneDepth)), c0003)));
        if (use_n) {
            Weight = _mm256_mul_ps(Weight, v_sat(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(t0, cn0), _mm256_mul_ps(t1, cn1)),
                                                               _mm256_mul_ps(t2, cn2))));
        }
        Ret = _mm256_add_ps(Ret, _mm256_mul_ps(SampleValue, Weight));
        WeightSum = _mm256_add_ps(WeightSum, Weight);
    }
    return _mm256_div_ps(Ret, WeightSum);
}

UE4_AVX2_FN static void ue4_pixels8(const prep *P, int l, int x0, int y, const unsigned char *bgrow, float *ao,
                                    float *depth, float *nx, float *ny, int64_t *nb, int64_t *nn)
{
    const ao_ue4_constants *k = P->k;
    const level *L = &P->lv[l];
    const int ty = clampi(y, 0, L->h - 1);
    const __m256 one = _mm256_set1_ps(1.0f);
    const int use_n = k->normal_mode != AO_UE4_NORMALS_NONE, o1 = k->variant == AO_UE4_VARIANT_O1;
    const int ortho = k->orthographic;
    const __m256 U = _mm256_set1_ps(k->units_per_metre), zmax = _mm256_set1_ps(k->max_depth);
    const int conv = !L->z.data; /* level 0: the input depth, converted */
    const obs_image_f32 *zimg = conv ? P->in->depth : &L->z;
    __m256 SceneDepth = _mm256_loadu_ps(obs_image_f32_row(zimg, ty) + x0);
    if (conv)
        SceneDepth = v_depth_uu(SceneDepth, U, zmax);
    __m256 n0 = _mm256_setzero_ps(), n1 = n0, n2 = n0, ln0 = n0, ln1 = n0, ln2 = n0;
    if (use_n) {
        if (L->ln[0].data) { /* ue4_normal_from_setup */
            ln0 = _mm256_loadu_ps(obs_image_f32_row(&L->ln[0], ty) + x0);
            ln1 = _mm256_loadu_ps(obs_image_f32_row(&L->ln[1], ty) + x0);
            ln2 = _mm256_loadu_ps(obs_image_f32_row(&L->ln[2], ty) + x0);
            v_normal_from_setup(ln0, ln1, ln2, &n0, &n1, &n2);
        } else { /* ue4_normal_from */
            v_normal_from(_mm256_loadu_ps(obs_image_f32_row(P->nsrc[0], ty) + x0),
                          _mm256_loadu_ps(obs_image_f32_row(P->nsrc[1], ty) + x0),
                          _mm256_loadu_ps(obs_image_f32_row(P->nsrc[2], ty) + x0), &n0, &n1, &n2);
        }
    }
    const __m256 sp_x = _mm256_loadu_ps(L->spx + x0), sp_y = _mm256_set1_ps(L->spy[y]);
    const __m256 FF0 = _mm256_set1_ps(P->fov_fix[0]), FF1 = _mm256_set1_ps(P->fov_fix[1]);
    const __m256 IF0 = _mm256_set1_ps(P->inv_fov_fix[0]), IF1 = _mm256_set1_ps(P->inv_fov_fix[1]);

    /* ReconstructCSPos, ActualAORadius, bias */
    const __m256 cV = ortho ? U : SceneDepth;
    __m256 V0 = _mm256_mul_ps(sp_x, cV), V1 = _mm256_mul_ps(sp_y, cV), V2 = SceneDepth;
    const __m256 ActualAORadius = _mm256_mul_ps(_mm256_set1_ps(L->radius),
                                                v_lerp(SceneDepth, one, _mm256_set1_ps(k->scale_radius_in_ws)));
    if (use_n) {
        const __m256 b = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(k->bias_over_1000), SceneDepth),
                                       _mm256_set1_ps(L->s));
        V0 = _mm256_add_ps(V0, _mm256_mul_ps(b, _mm256_mul_ps(n0, FF0)));
        V1 = _mm256_add_ps(V1, _mm256_mul_ps(b, _mm256_mul_ps(n1, FF1)));
        V2 = _mm256_add_ps(V2, _mm256_mul_ps(b, n2)); /* n.z * FovFix.z = n.z * 1 */
    }
    __m256 WA0 = _mm256_set1_ps(0.0001f), WA1 = WA0;

    /* RandomVec from the 4x4 texture at pixel % 4 */
    float rx[8], ry[8];
    const int ry4 = 4 * (((y % 4) + 4) % 4);
    for (int i = 0; i < 8; i++) {
        const int ri = (((x0 + i) % 4 + 4) % 4) + ry4;
        rx[i] = P->rand_vec[ri][0];
        ry[i] = P->rand_vec[ri][1];
    }
    const __m256 RV0 = _mm256_mul_ps(_mm256_loadu_ps(rx), ActualAORadius);
    const __m256 RV1 = _mm256_mul_ps(_mm256_loadu_ps(ry), ActualAORadius);
    const __m256 csV = ortho ? U : V2;
    const __m256 invz = _mm256_div_ps(one, csV);
    const __m256 FFX0 = _mm256_mul_ps(FF0, invz), FFX1 = _mm256_mul_ps(FF1, invz);
    const __m256 RB0 = _mm256_mul_ps(RV0, FFX0), RB1 = _mm256_mul_ps(RV1, FFX1);
    const __m256 RB2 = _mm256_mul_ps(_mm256_xor_ps(RV1, _mm256_set1_ps(-0.0f)), FFX0); /* -RandomVec.y (sign flip) */
    const __m256 RB3 = _mm256_mul_ps(RV0, FFX1);
    const __m256 SSP0 = _mm256_div_ps(V0, csV), SSP1 = _mm256_div_ps(V1, csV);
    const __m256 InvHaloSize = _mm256_div_ps(one, _mm256_mul_ps(ActualAORadius, _mm256_set1_ps(2.0f)));
    __m256 Ns0 = n0, Ns1 = n1, Ns2 = n2;
    if (o1) {
        const __m256 sc = _mm256_mul_ps(_mm256_set1_ps(0.08f),
                                        v_lerp(SceneDepth, _mm256_set1_ps(1000.0f), _mm256_set1_ps(k->scale_radius_in_ws)));
        Ns0 = _mm256_mul_ps(Ns0, sc), Ns1 = _mm256_mul_ps(Ns1, sc), Ns2 = _mm256_mul_ps(Ns2, sc);
    }
    const __m256 InvD = _mm256_set1_ps(k->inv_distance);
    const __m256 ViewDepthAdd = _mm256_sub_ps(one, _mm256_mul_ps(V2, InvD));

    /* the taps: texel = floor((sp * W/2 + cx) / s) (x), floor((cy - sp.y * H/2) / s) (y) */
    const __m256 half_w = _mm256_set1_ps(P->half_w), half_h = _mm256_set1_ps(P->half_h);
    const __m256 pcx = _mm256_set1_ps(P->cx), pcy = _mm256_set1_ps(P->cy), inv_s = _mm256_set1_ps(L->inv_s);
    const __m256i wm1 = _mm256_set1_epi32(L->w - 1), hm1 = _mm256_set1_epi32(L->h - 1);
    const __m256i stride = _mm256_set1_epi32((int)zimg->stride);
    const float *zbase = zimg->data;
    for (int i = 0; i < L->sample_count; i++) {
        const __m256 ux = _mm256_set1_ps(L->samples[2 * i]), uy = _mm256_set1_ps(L->samples[2 * i + 1]);
        const __m256 LR0 = _mm256_add_ps(_mm256_mul_ps(ux, RB0), _mm256_mul_ps(uy, RB2));
        const __m256 LR1 = _mm256_add_ps(_mm256_mul_ps(ux, RB1), _mm256_mul_ps(uy, RB3));
        __m256 acc0 = _mm256_setzero_ps(), acc1 = acc0, acc2 = acc0;
        for (int step = 0; step < k->steps; step++) {
            const __m256 Scale = _mm256_set1_ps((float)(step + 1) / (float)k->steps);
            const __m256 lr0 = _mm256_mul_ps(Scale, LR0), lr1 = _mm256_mul_ps(Scale, LR1);
            const __m256 SL0 = _mm256_add_ps(SSP0, lr0), SL1 = _mm256_add_ps(SSP1, lr1);
            const __m256 SR0 = _mm256_sub_ps(SSP0, lr0), SR1 = _mm256_sub_ps(SSP1, lr1);
            const __m256i txL = v_texel(_mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(SL0, half_w), pcx), inv_s), wm1);
            const __m256i tyL = v_texel(_mm256_mul_ps(_mm256_sub_ps(pcy, _mm256_mul_ps(SL1, half_h)), inv_s), hm1);
            const __m256i txR = v_texel(_mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(SR0, half_w), pcx), inv_s), wm1);
            const __m256i tyR = v_texel(_mm256_mul_ps(_mm256_sub_ps(pcy, _mm256_mul_ps(SR1, half_h)), inv_s), hm1);
            __m256 AbsL = _mm256_i32gather_ps(zbase, _mm256_add_epi32(_mm256_mullo_epi32(tyL, stride), txL), 4);
            __m256 AbsR = _mm256_i32gather_ps(zbase, _mm256_add_epi32(_mm256_mullo_epi32(tyR, stride), txR), 4);
            if (conv) {
                AbsL = v_depth_uu(AbsL, U, zmax);
                AbsR = v_depth_uu(AbsR, U, zmax);
            }
            const __m256 cL = ortho ? U : AbsL, cR = ortho ? U : AbsR;
            const __m256 DL0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(SL0, cL), V0), IF0);
            const __m256 DL1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(SL1, cL), V1), IF1);
            const __m256 DL2 = _mm256_sub_ps(AbsL, V2);
            const __m256 DR0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(SR0, cR), V0), IF0);
            const __m256 DR1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_mul_ps(SR1, cR), V1), IF1);
            const __m256 DR2 = _mm256_sub_ps(AbsR, V2);
            const __m256 LL = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(DL0, DL0), _mm256_mul_ps(DL1, DL1)),
                                            _mm256_mul_ps(DL2, DL2));
            const __m256 RR = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(DR0, DR0), _mm256_mul_ps(DR1, DR1)),
                                            _mm256_mul_ps(DR2, DR2));
            if (use_n) {
                /* WedgeWithNormal */
                const __m256 dl = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(DL0, Ns0), _mm256_mul_ps(DL1, Ns1)),
                                                _mm256_mul_ps(DL2, Ns2));
                const __m256 dr = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(DR0, Ns0), _mm256_mul_ps(DR1, Ns1)),
                                                _mm256_mul_ps(DR2, Ns2));
                __m256 sL, sR, w;
                if (o1) {
                    sL = v_sat(_mm256_div_ps(dl, LL));
                    sR = v_sat(_mm256_div_ps(dr, RR));
                    w = one;
                } else {
                    const __m256 qL = _mm256_sqrt_ps(LL), qR = _mm256_sqrt_ps(RR);
                    sL = v_sat(_mm256_mul_ps(dl, _mm256_div_ps(one, qL)));
                    sR = v_sat(_mm256_mul_ps(dr, _mm256_div_ps(one, qR)));
                    w = _mm256_mul_ps(v_sat(_mm256_sub_ps(one, _mm256_mul_ps(qL, InvHaloSize))),
                                      v_sat(_mm256_sub_ps(one, _mm256_mul_ps(qR, InvHaloSize))));
                }
                acc0 = v_lerp(acc0, v_hmax(acc0, sL), w);
                acc1 = v_lerp(acc1, v_hmax(acc1, sR), w);
                acc2 = v_lerp(acc2, one, w);
            } else {
                /* WedgeNoNormal */
                const __m256 dot = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(DL0, DR0), _mm256_mul_ps(DL1, DR1)),
                                                 _mm256_mul_ps(DL2, DR2));
                const __m256 cosLR = _mm256_div_ps(dot, _mm256_sqrt_ps(_mm256_mul_ps(LL, RR)));
                __m256 NormAngle = v_sat(_mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(one, cosLR), _mm256_set1_ps(0.5f)),
                                                       _mm256_set1_ps(AO_UE4_CONTRAST_TWEAK)));
                const __m256 lr_sum = _mm256_add_ps(_mm256_sub_ps(V2, AbsL), _mm256_sub_ps(V2, AbsR));
                NormAngle = _mm256_blendv_ps(NormAngle, one,
                                             _mm256_cmp_ps(lr_sum, _mm256_set1_ps(AO_UE4_FLAT_SURFACE_BIAS), _CMP_LT_OQ));
                const __m256 Weight = _mm256_mul_ps(v_sat(_mm256_add_ps(_mm256_mul_ps(AbsL, InvD), ViewDepthAdd)),
                                                    v_sat(_mm256_add_ps(_mm256_mul_ps(AbsR, InvD), ViewDepthAdd)));
                const __m256 sv = _mm256_div_ps(_mm256_sub_ps(one, NormAngle), _mm256_add_ps(Weight, _mm256_set1_ps(0.001f)));
                acc0 = v_lerp(acc0, v_hmax(acc0, sv), Weight);
                acc2 = v_lerp(acc2, one, Weight);
            }
        }
        /* "Square()" */
        const __m256 a0 = _mm256_sub_ps(one, acc0);
        WA0 = _mm256_add_ps(WA0, _mm256_mul_ps(_mm256_mul_ps(a0, a0), acc2));
        WA1 = _mm256_add_ps(WA1, acc2);
        if (use_n) {
            const __m256 a1 = _mm256_sub_ps(one, acc1);
            WA0 = _mm256_add_ps(WA0, _mm256_mul_ps(_mm256_mul_ps(a1, a1), acc2));
            WA1 = _mm256_add_ps(WA1, acc2);
        }
    }
    /* ue4_finish: the upsampled blend (a coarser level follows; CenterWorldNormal: level 0 the
     * G-buffer's, above the setup's decoded one), then at level 0 the fade and |r| (powf goes lane
     * by lane below) */
    float r[8], nv[3][8];
    __m256 rv = _mm256_div_ps(WA0, WA1);
    if (l + 1 < P->levels) {
        const __m256 up = l == 0 ? v_upsample(P, l, x0, y, SceneDepth, n0, n1, n2)
                                 : v_upsample(P, l, x0, y, SceneDepth, ln0, ln1, ln2);
        rv = v_lerp(rv, up, _mm256_set1_ps(k->mip_blend));
    }
    if (l == 0) {
        /* "soft fade out AO in the distance": lerp(r, 1, saturate(z * Mul + Add)) */
        rv = v_lerp(rv, one, v_sat(_mm256_add_ps(_mm256_mul_ps(SceneDepth, _mm256_set1_ps(k->fade_mul)),
                                                 _mm256_set1_ps(k->fade_add))));
        rv = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), rv);
    }
    _mm256_storeu_ps(r, rv);
    _mm256_storeu_ps(nv[0], n0);
    _mm256_storeu_ps(nv[1], n1);
    _mm256_storeu_ps(nv[2], n2);
    _mm256_storeu_ps(depth, SceneDepth);
    const unsigned char *bg = bgrow + x0;
    for (int i = 0; i < 8; i++) {
        nx[i] = ny[i] = 0.0f;
        if (bg[i]) {
            ao[i] = 1.0f;
            (*nb)++;
            continue;
        }
        const float n[3] = {nv[0][i], nv[1][i], nv[2][i]};
        if (use_n) {
            if (n[0] == 0.0f && n[1] == 0.0f && n[2] == 0.0f) {
                ao[i] = 1.0f;
                (*nn)++;
                continue;
            }
            nx[i] = n[0];
            ny[i] = n[1];
        }
        if (l == 0) /* "user adjust AO": 1 - (1 - pow(|r|, Power)) * Intensity, as ue4_finish */
            ao[i] = 1.0f - (1.0f - (r[i] == 1.0f ? 1.0f : powf(r[i], k->power))) * k->intensity;
        else
            ao[i] = r[i];
    }
}

/* ue4_pixel's outputs for eight background pixels at x0 of row ty: ao 1, SceneDepth, no normal */
UE4_AVX2_FN static void background8(const prep *P, const level *L, int x0, int ty, float *a, float *z, float *nx,
                                    float *ny)
{
    __m256 d;
    if (L->z.data)
        d = _mm256_loadu_ps(obs_image_f32_row(&L->z, ty) + x0);
    else
        d = v_depth_uu(_mm256_loadu_ps(obs_image_f32_row(P->in->depth, ty) + x0), _mm256_set1_ps(P->k->units_per_metre),
                       _mm256_set1_ps(P->k->max_depth));
    _mm256_storeu_ps(a, _mm256_set1_ps(1.0f));
    _mm256_storeu_ps(z, d);
    _mm256_storeu_ps(nx, _mm256_setzero_ps());
    _mm256_storeu_ps(ny, _mm256_setzero_ps());
}

/* Whether any of the eight pixels at x0 of row ty is not background (an all-background group
 * skips the kernel). */
static inline int any_surface8(const unsigned char *bg)
{
    uint64_t v;
    memcpy(&v, bg, 8);
    return v != 0x0101010101010101ull;
}
#endif

/* Row y of level l's AO pass over the region columns qx0 .. qx0 + width - 1: ao, SceneDepth and
 * the normal's xy of each pixel (ue4_pixel), and the row's background and zero-normal counts. */
static void ao_row_compute(const prep *P, int l, int qx0, int y, int width, const unsigned char *bgrow, float *a,
                           float *z, float *nx, float *ny, int64_t count[2])
{
    const level *L = &P->lv[l];
    int64_t nb = 0, nn = 0;
    int i = 0;
#ifdef UE4_AVX2
    const obs_image_f32 *zimg = L->z.data ? &L->z : P->in->depth;
    if (P->simd && (int64_t)zimg->stride * L->h <= INT32_MAX) { /* gather indices are 32-bit */
        const int ty = clampi(y, 0, L->h - 1);
        for (; qx0 + i + 7 < L->w && i + 8 <= width; i += 8) {
            const int x = qx0 + i;
            if (any_surface8(bgrow + x)) {
                ue4_pixels8(P, l, x, y, bgrow, a + i, z + i, nx + i, ny + i, &nb, &nn);
            } else { /* eight background pixels: ue4_pixel's early return */
                background8(P, L, x, ty, a + i, z + i, nx + i, ny + i);
                nb += 8;
            }
        }
    }
#else
    (void)L;
#endif
    for (; i < width; i++) {
        float nxy[2];
        int bad;
        nb += ue4_pixel(P, l, qx0 + i, y, bgrow, &a[i], &z[i], nxy, &bad);
        nn += bad;
        nx[i] = nxy[0];
        ny[i] = nxy[1];
    }
    count[0] = nb;
    count[1] = nn;
}

/* QUAD_MESSAGE_PASSING_BLUR: a 2x2-quad blur with ddx_fine/ddy_fine. Quads are aligned to even
 * (x, y) of the level (D3D SV_Position). For the output pixel, PixB is its horizontal quad partner
 * computed as Center - dX * (Mod.x * 2 - 1) (dX = right - left), PixC its vertical one.
 * One output row y: the AO pass's planes (ao, SceneDepth, nx, ny) of row y are r[0] and of its
 * quad partner row y ^ 1 are r[1], over region columns from qx0 (even); the output covers
 * columns rx0 .. rx0 + width - 1; bg is the level's background row y. */
static inline float recon_nz(float x, float y) { return sqrtf(1.0f - (x * x + y * y)); }

/* powf(x, 4) for x = saturate(.) in [0, 1] (never -0): pow(1, y) = 1 and pow(+0, y > 0) = +0 are
 * exact (C11 F.10.4.4), so those skip the call. */
static inline float pow4_sat(float x) { return x == 1.0f ? 1.0f : x == 0.0f ? 0.0f : powf(x, 4.0f); }

static void quad_blur_row(const ao_ue4_constants *k, const float *const r[2][4], int qx0, int rx0, int y, int width,
                          const unsigned char *bg, float *o, int saturate)
{
    const int mody = y & 1;
    for (int i = 0; i < width; i++) {
        if (bg[i]) {
            o[i] = 1.0f; /* background stays 1 (the quad blur would mix in its neighbours) */
            continue;
        }
        const int x = rx0 + i, lx = x - qx0, lxp = lx ^ 1;
        const int modx = x & 1;
        /* CenterPixel = (ao, SceneDepth, nx, ny) */
        const float A[4] = {r[0][0][lx], r[0][1][lx], r[0][2][lx], r[0][3][lx]};
        const float Bp[4] = {r[0][0][lxp], r[0][1][lxp], r[0][2][lxp], r[0][3][lxp]};
        const float Cp[4] = {r[1][0][lx], r[1][1][lx], r[1][2][lx], r[1][3][lx]};
        float B[4], C[4];
        for (int c = 0; c < 4; c++) {
            const float dX = modx ? A[c] - Bp[c] : Bp[c] - A[c]; /* ddx_fine: right - left */
            const float dY = mody ? A[c] - Cp[c] : Cp[c] - A[c]; /* ddy_fine: bottom - top */
            B[c] = A[c] - dX * (float)(modx * 2 - 1);
            C[c] = A[c] - dY * (float)(mody * 2 - 1);
        }
        float wA = 1.0f, wB = 1.0f, wC = 1.0f;
        if (k->quad_blur >= 2) {
            /* QUAD_MESSAGE_PASSING_NORMAL: NormalTweak 4 */
            const float nA[3] = {A[2], A[3], recon_nz(A[2], A[3])};
            const float nB[3] = {B[2], B[3], recon_nz(B[2], B[3])};
            const float nC[3] = {C[2], C[3], recon_nz(C[2], C[3])};
            wB *= saturatef(pow4_sat(saturatef(nA[0] * nB[0] + nA[1] * nB[1] + nA[2] * nB[2])));
            wC *= saturatef(pow4_sat(saturatef(nA[0] * nC[0] + nA[1] * nC[1] + nA[2] * nC[2])));
        }
        if (k->quad_blur >= 3) {
            /* QUAD_MESSAGE_PASSING_DEPTH: DepthTweak 1 */
            const float InvDepth = 1.0f / A[1];
            wB *= 1.0f - saturatef(fabsf(1.0f - B[1] * InvDepth) * 1.0f);
            wC *= 1.0f - saturatef(fabsf(1.0f - C[1] * InvDepth) * 1.0f);
        }
        const float inv = 1.0f / (wA + wB + wC);
        wA *= inv, wB *= inv, wC *= inv;
        const float v = wA * A[0] + wB * B[0] + wC * C[0];
        o[i] = saturate ? saturatef(v) : v;
    }
}

#ifdef UE4_AVX2
/* quad_blur_row for both rows of a quad row (y0 even, y0 + 1), AVX2, eight region columns at a
 * time from lx = 0 (lane i: lx0 + i; the horizontal partner is the neighbour lane i ^ 1, the
 * vertical one the other row's lane i). Same operations as the scalar row; multiplications by
 * wA = 1 are left out (exact). powf goes lane by lane, and a pair whose two inputs are the same
 * bits (horizontal partners, or vertical partners of the two rows: the usual case, as
 * A + (B - A) is B when B - A is exact) calls it once: a function of the same input gives the same
 * output. o[0], o[1]: the output rows, NULL when outside the rect; bg[0], bg[1]: the level's
 * background rows at column rx0. Returns the first output column left to the scalar row. */
UE4_AVX2_FN static int quad_blur_pair_avx2(const ao_ue4_constants *k, float *const rows[2][4], int qw, int qx0, int rx0,
                                           int width, int y0, const unsigned char *const bg[2], float *const o[2],
                                           int saturate)
{
    const int off = rx0 - qx0; /* 0 or 1: output column i is region column i + off */
    const __m256 one = _mm256_set1_ps(1.0f), sgn = _mm256_set1_ps(-0.0f);
    const __m256 odd = _mm256_castsi256_ps(_mm256_setr_epi32(0, -1, 0, -1, 0, -1, 0, -1)); /* modx = 1 */
    const __m256 sx = _mm256_setr_ps(-1, 1, -1, 1, -1, 1, -1, 1);                     /* modx * 2 - 1 */
    int lx0 = 0;
    for (; lx0 + 8 <= qw && lx0 - off < width; lx0 += 8) {
        if (lx0 - off >= 0 && lx0 - off + 8 <= width) {
            /* eight output columns: all background in both rows (or the row not output) -> 1 */
            int all_bg = 1;
            for (int rr = 0; rr < 2; rr++)
                all_bg &= !o[rr] || !any_surface8(bg[rr] + (lx0 - off));
            if (all_bg) {
                for (int rr = 0; rr < 2; rr++)
                    if (o[rr])
                        _mm256_storeu_ps(o[rr] + (lx0 - off), one);
                continue;
            }
        }
        /* the lanes that are output pixels, and which of them are surface pixels */
        int surf[2][8], any = 0;
        for (int rr = 0; rr < 2; rr++)
            for (int i = 0; i < 8; i++) {
                const int oi = lx0 + i - off;
                surf[rr][i] = o[rr] && oi >= 0 && oi < width && !bg[rr][oi];
                any |= surf[rr][i];
            }
        float res[2][8];
        if (any) {
            __m256 A[2][4], B[2][4], C[2][4], dB[2], dC[2];
            for (int rr = 0; rr < 2; rr++) {
                const float sy = (float)(((y0 + rr) & 1) * 2 - 1);
                for (int c = 0; c < 4; c++) {
                    A[rr][c] = _mm256_loadu_ps(rows[rr][c] + lx0);
                    const __m256 Bp = _mm256_permute_ps(A[rr][c], 0xB1); /* lanes i ^ 1 */
                    const __m256 Cp = _mm256_loadu_ps(rows[rr ^ 1][c] + lx0);
                    const __m256 dX = _mm256_blendv_ps(_mm256_sub_ps(Bp, A[rr][c]), _mm256_sub_ps(A[rr][c], Bp), odd);
                    const __m256 dY = rr ? _mm256_sub_ps(A[rr][c], Cp) : _mm256_sub_ps(Cp, A[rr][c]);
                    B[rr][c] = _mm256_sub_ps(A[rr][c], _mm256_mul_ps(dX, sx));
                    C[rr][c] = _mm256_sub_ps(A[rr][c], _mm256_mul_ps(dY, _mm256_set1_ps(sy)));
                }
                if (k->quad_blur >= 2) {
#define UE4_NZ(X, Y) _mm256_sqrt_ps(_mm256_sub_ps(one, _mm256_add_ps(_mm256_mul_ps(X, X), _mm256_mul_ps(Y, Y))))
                    const __m256 nA = UE4_NZ(A[rr][2], A[rr][3]), nB = UE4_NZ(B[rr][2], B[rr][3]),
                                 nC = UE4_NZ(C[rr][2], C[rr][3]);
#undef UE4_NZ
                    dB[rr] = v_sat(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(A[rr][2], B[rr][2]),
                                                               _mm256_mul_ps(A[rr][3], B[rr][3])),
                                                 _mm256_mul_ps(nA, nB)));
                    dC[rr] = v_sat(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(A[rr][2], C[rr][2]),
                                                               _mm256_mul_ps(A[rr][3], C[rr][3])),
                                                 _mm256_mul_ps(nA, nC)));
                }
            }
            __m256 wB[2] = {one, one}, wC[2] = {one, one};
            if (k->quad_blur >= 2) {
                /* powf(., 4) per surface lane, once per pair of equal inputs */
                float db[2][8], dc[2][8], pb[2][8], pc[2][8];
                uint32_t ub[2][8], uc[2][8];
                for (int rr = 0; rr < 2; rr++) {
                    _mm256_storeu_ps(db[rr], dB[rr]);
                    _mm256_storeu_ps(dc[rr], dC[rr]);
                    memcpy(ub[rr], db[rr], sizeof ub[rr]);
                    memcpy(uc[rr], dc[rr], sizeof uc[rr]);
                }
                for (int rr = 0; rr < 2; rr++)
                    for (int i = 0; i < 8; i++) {
                        pb[rr][i] = pc[rr][i] = 0.0f;
                        if (!surf[rr][i])
                            continue;
                        const int j = i ^ 1; /* horizontal partner: done already when j < i */
                        if (j < i && surf[rr][j] && ub[rr][j] == ub[rr][i])
                            pb[rr][i] = pb[rr][j];
                        else
                            pb[rr][i] = pow4_sat(db[rr][i]);
                        if (rr == 1 && surf[0][i] && uc[0][i] == uc[1][i])
                            pc[1][i] = pc[0][i];
                        else
                            pc[rr][i] = pow4_sat(dc[rr][i]);
                    }
                for (int rr = 0; rr < 2; rr++) {
                    wB[rr] = v_sat(_mm256_loadu_ps(pb[rr]));
                    wC[rr] = v_sat(_mm256_loadu_ps(pc[rr]));
                }
            }
            for (int rr = 0; rr < 2; rr++) {
                if (!o[rr])
                    continue;
                if (k->quad_blur >= 3) {
                    const __m256 InvDepth = _mm256_div_ps(one, A[rr][1]);
                    wB[rr] = _mm256_mul_ps(wB[rr], _mm256_sub_ps(one, v_sat(_mm256_andnot_ps(sgn, _mm256_sub_ps(one, _mm256_mul_ps(B[rr][1], InvDepth))))));
                    wC[rr] = _mm256_mul_ps(wC[rr], _mm256_sub_ps(one, v_sat(_mm256_andnot_ps(sgn, _mm256_sub_ps(one, _mm256_mul_ps(C[rr][1], InvDepth))))));
                }
                const __m256 inv = _mm256_div_ps(one, _mm256_add_ps(_mm256_add_ps(one, wB[rr]), wC[rr]));
                const __m256 b = _mm256_mul_ps(wB[rr], inv), c = _mm256_mul_ps(wC[rr], inv);
                __m256 v = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(inv, A[rr][0]), _mm256_mul_ps(b, B[rr][0])),
                                         _mm256_mul_ps(c, C[rr][0]));
                if (saturate)
                    v = v_sat(v);
                _mm256_storeu_ps(res[rr], v);
            }
        }
        for (int rr = 0; rr < 2; rr++) {
            if (!o[rr])
                continue;
            for (int i = 0; i < 8; i++) {
                const int oi = lx0 + i - off;
                if (oi >= 0 && oi < width)
                    o[rr][oi] = surf[rr][i] ? res[rr][i] : 1.0f; /* background stays 1 */
            }
        }
    }
    const int done = lx0 - off;
    return done < 0 ? 0 : done > width ? width : done;
}
#endif

/* MainSetupPS: level l from level l - 1. The four source texels (2x, 2y) .. (2x+1, 2y+1) (the
 * bilinear taps at +-0.5 source texel land on texel centres; clamped): MaxZ = max of the depths;
 * the normal = (0.0001 + sum (n * 0.5 + 0.5) w) / (0.0001 + sum w), w = saturate(1 - |z - MaxZ| *
 * MipThreshold / ScaleToFullRes). Background where MaxZ is the sky. Without normals (mode 0) only
 * the depth and the background are kept (nothing reads the normal). One task per output row; each
 * row reads its two source rows (clamped) and writes only its own texels. */
typedef struct setup_job {
    prep *P;
    int l, use_n;
} setup_job;

/* The source rows of output row y: depth (level 0: the input's, in metres; above: uu) and normals
 * (level 0: the source normals, ours; above: the stored e planes), rows 2y and 2y + 1 clamped. */
typedef struct setup_rows {
    const float *z[2];
    const float *n[2][3];
    int conv; /* 1: level 0's source (depth_uu, ue4_normal_from) */
} setup_rows;

/* Output texel x from source columns sx0, sx1 (2x, 2x + 1 clamped): the scalar reference. */
static inline void setup_texel(const setup_job *J, const setup_rows *R, level *D, int y, int x, int sx0, int sx1,
                               float InvThreshold, float zmax)
{
    const prep *P = J->P;
    float z[4], e[4][3];
    for (int i = 0; i < 4; i++) {
        const int r = i >> 1, sx = i & 1 ? sx1 : sx0;
        z[i] = R->conv ? depth_uu(P, R->z[r][sx]) : R->z[r][sx];
        if (!J->use_n)
            continue;
        if (R->conv) { /* level 0: from the source normals */
            float n0[3];
            ue4_normal_from(R->n[r][0][sx], R->n[r][1][sx], R->n[r][2][sx], n0);
            for (int c = 0; c < 3; c++)
                e[i][c] = n0[c] * 0.5f + 0.5f;
        } else {
            for (int c = 0; c < 3; c++)
                e[i][c] = R->n[r][c][sx];
        }
    }
    /* fmaxf: the depths are never NaN nor zero, so a > b ? a : b is the same */
    const float m01 = z[0] > z[1] ? z[0] : z[1], m23 = z[2] > z[3] ? z[2] : z[3];
    const float MaxZ = m01 > m23 ? m01 : m23;
    obs_image_f32_row(&D->z, y)[x] = MaxZ;
    D->bg[(size_t)y * D->w + x] = (unsigned char)(MaxZ >= zmax);
    if (!J->use_n)
        return;
    float acc[4] = {0.0001f, 0.0001f, 0.0001f, 0.0001f};
    for (int i = 0; i < 4; i++) {
        const float w = saturatef(1.0f - fabsf(z[i] - MaxZ) * InvThreshold); /* ComputeDepthSimilarity */
        acc[0] += e[i][0] * w, acc[1] += e[i][1] * w, acc[2] += e[i][2] * w, acc[3] += w;
    }
    for (int c = 0; c < 3; c++) {
        const float v = acc[c] / acc[3];
        if (D->e[c].data)
            obs_image_f32_row(&D->e[c], y)[x] = v;
        obs_image_f32_row(&D->ln[c], y)[x] = v * 2.0f - 1.0f; /* decoded: rgb * 2 - 1 */
    }
}

#ifdef UE4_AVX2
/* The even and the odd elements of p[0 .. 15] */
UE4_AVX2_FN static inline void v_deinterleave(const float *p, __m256 *even, __m256 *odd)
{
    const __m256 a = _mm256_loadu_ps(p), b = _mm256_loadu_ps(p + 8);
    /* per 128-bit half: (a0 a2 b0 b2)(a4 a6 b4 b6); then the 64-bit quarters in the order 0 2 1 3 */
    *even = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(a, b, 0x88)), 0xD8));
    *odd = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(a, b, 0xDD)), 0xD8));
}

/* Eight 0/1 flags from a compare mask */
UE4_AVX2_FN static inline void v_store_flags8(__m256 mask, unsigned char *dst)
{
    const __m256i b = _mm256_and_si256(_mm256_castps_si256(mask), _mm256_set1_epi32(1));
    const __m256i p16 = _mm256_packus_epi32(b, b), p8 = _mm256_packus_epi16(p16, p16);
    const uint32_t lo = (uint32_t)_mm_cvtsi128_si32(_mm256_castsi256_si128(p8));
    const uint32_t hi = (uint32_t)_mm_cvtsi128_si32(_mm256_extracti128_si256(p8, 1));
    memcpy(dst, &lo, 4);
    memcpy(dst + 4, &hi, 4);
}

/* setup_texel for output texels x .. x + 7 of row y while their 16 source columns are all inside
 * the source (no clamping); lane i = texel x + i. The same operations in the same order. Returns
 * the first texel left to the scalar loop. */
UE4_AVX2_FN static int setup_row_avx2(const setup_job *J, const setup_rows *R, level *D, int y, int src_w,
                                      float InvThreshold, float zmax)
{
    const prep *P = J->P;
    const __m256 one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f), two = _mm256_set1_ps(2.0f);
    const __m256 sgn = _mm256_set1_ps(-0.0f), vInvT = _mm256_set1_ps(InvThreshold), vzmax = _mm256_set1_ps(zmax);
    const __m256 U = _mm256_set1_ps(P->k->units_per_metre);
    int x = 0;
    for (; 2 * x + 16 <= src_w && x + 8 <= D->w; x += 8) {
        __m256 z[4], e[4][3];
        for (int r = 0; r < 2; r++) {
            v_deinterleave(R->z[r] + 2 * x, &z[2 * r], &z[2 * r + 1]);
            if (R->conv) {
                z[2 * r] = v_depth_uu(z[2 * r], U, vzmax);
                z[2 * r + 1] = v_depth_uu(z[2 * r + 1], U, vzmax);
            }
            if (!J->use_n)
                continue;
            __m256 ev[3], od[3];
            for (int c = 0; c < 3; c++)
                v_deinterleave(R->n[r][c] + 2 * x, &ev[c], &od[c]);
            if (R->conv) { /* ue4_normal_from, then n * 0.5 + 0.5 */
                v_normal_from(ev[0], ev[1], ev[2], &ev[0], &ev[1], &ev[2]);
                v_normal_from(od[0], od[1], od[2], &od[0], &od[1], &od[2]);
                for (int c = 0; c < 3; c++) {
                    ev[c] = _mm256_add_ps(_mm256_mul_ps(ev[c], half), half);
                    od[c] = _mm256_add_ps(_mm256_mul_ps(od[c], half), half);
                }
            }
            for (int c = 0; c < 3; c++) {
                e[2 * r][c] = ev[c];
                e[2 * r + 1][c] = od[c];
            }
        }
        const __m256 MaxZ = _mm256_max_ps(_mm256_max_ps(z[0], z[1]), _mm256_max_ps(z[2], z[3])); /* a > b ? a : b */
        _mm256_storeu_ps(obs_image_f32_row(&D->z, y) + x, MaxZ);
        v_store_flags8(_mm256_cmp_ps(MaxZ, vzmax, _CMP_GE_OQ), D->bg + (size_t)y * D->w + x);
        if (!J->use_n)
            continue;
        __m256 acc[4];
        acc[0] = acc[1] = acc[2] = acc[3] = _mm256_set1_ps(0.0001f);
        for (int i = 0; i < 4; i++) {
            const __m256 w = v_sat(_mm256_sub_ps(one, _mm256_mul_ps(_mm256_andnot_ps(sgn, _mm256_sub_ps(z[i], MaxZ)), vInvT)));
            for (int c = 0; c < 3; c++)
                acc[c] = _mm256_add_ps(acc[c], _mm256_mul_ps(e[i][c], w));
            acc[3] = _mm256_add_ps(acc[3], w);
        }
        for (int c = 0; c < 3; c++) {
            const __m256 v = _mm256_div_ps(acc[c], acc[3]);
            if (D->e[c].data)
                _mm256_storeu_ps(obs_image_f32_row(&D->e[c], y) + x, v);
            _mm256_storeu_ps(obs_image_f32_row(&D->ln[c], y) + x, _mm256_sub_ps(_mm256_mul_ps(v, two), one));
        }
    }
    return x;
}
#endif

static void setup_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const setup_job *J = (const setup_job *)user;
    const prep *P = J->P;
    const level *S = &P->lv[J->l - 1];
    level *D = &J->P->lv[J->l];
    const int y = (int)task;
    const float zmax = P->k->max_depth, InvThreshold = 0.01f / S->s; /* AmbientOcclusionMipThreshold */
    setup_rows R;
    memset(&R, 0, sizeof R);
    R.conv = J->l == 1;
    for (int r = 0; r < 2; r++) {
        const int sy = clampi(2 * y + r, 0, S->h - 1);
        R.z[r] = R.conv ? obs_image_f32_row(P->in->depth, sy) : obs_image_f32_row(&S->z, sy);
        for (int c = 0; c < 3 && J->use_n; c++)
            R.n[r][c] = R.conv ? obs_image_f32_row(P->nsrc[c], sy) : obs_image_f32_row(&S->e[c], sy);
    }
    int x = 0;
#ifdef UE4_AVX2
    if (P->simd)
        x = setup_row_avx2(J, &R, D, y, S->w, InvThreshold, zmax);
#endif
    for (; x < D->w; x++)
        setup_texel(J, &R, D, y, x, clampi(2 * x, 0, S->w - 1), clampi(2 * x + 1, 0, S->w - 1), InvThreshold, zmax);
}

/* The planes of coarse level L (z, bg, ao; ln with normals; e with normals where a coarser level
 * is built from it) in one allocation with one stride (the upsample gathers every plane with one
 * index), not zeroed: setup_row and the level's AO pass write every texel before it is read. */
static obs_status level_alloc(obs_context *ctx, ao_i_ws *ws, level *L, int use_n, int feeds_next)
{
    const size_t stride = ((size_t)L->w + 15) & ~(size_t)15, plane = stride * (size_t)L->h; /* floats */
    const int planes = 2 + (use_n ? 3 : 0) + (use_n && feeds_next ? 3 : 0);
    const size_t bg_bytes = ((size_t)L->w * (size_t)L->h + 63) & ~(size_t)63;
    const size_t bytes = sizeof(float) * plane * (size_t)planes + bg_bytes;
    if (plane > (size_t)INT32_MAX) /* 32-bit gather indices; a level is at most half the input */
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "ue4: level %dx%d too large", L->w, L->h);
    if ((double)bytes > (double)obs_context_limits(ctx)->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "ue4: a %dx%d level needs %zu bytes, over the limit (raise it with --max-memory)", L->w,
                         L->h, bytes);
    /* the workspace's memory (kept between calls: no page faults), not zeroed as before */
    float *b = (float *)ao_i_ws_buf(ws, bytes, 0);
    if (!b)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ue4: cannot allocate %zu bytes for a level", bytes);
    obs_image_f32 *const list[8] = {&L->z, &L->ao, &L->ln[0], &L->ln[1], &L->ln[2], &L->e[0], &L->e[1], &L->e[2]};
    for (int i = 0; i < planes; i++) {
        list[i]->data = b + (size_t)i * plane;
        list[i]->width = L->w;
        list[i]->height = L->h;
        list[i]->stride = (ptrdiff_t)stride;
    }
    L->bg = (unsigned char *)(b + (size_t)planes * plane);
    return OBS_STATUS_OK;
}

static void level_free(level *L)
{
    free(L->spx); /* the planes' block is the workspace's */
    free(L->spy);
    for (int k = 0; k < 3; k++) {
        free(L->utx[k]);
        free(L->uty[k]);
    }
    memset(L, 0, sizeof *L);
}

/* The AO pass of level l over [qx0, qx1) x [qy0, qy1) (quad-aligned when the quad blur is on),
 * then the quad blur (or a copy) into out over the rect (rx0, ry0, out->width, out->height),
 * saturated when `saturate` (level 0: the UNORM target). One task per tile of UE4_TILE_W x
 * UE4_TILE_H region pixels (even sizes from the region's even origin: whole quads), row pair by
 * row pair: the pair's AO rows go to the thread's scratch and its output pixels are written at
 * once, so no full-size intermediate planes are needed; each output pixel depends only on its
 * quad. Tiles rather than rows keep the taps' reads (up to ~160 px away at 1080p with UE's
 * default radius) in the core's L2: a tile reads about (128 + 2r) x (32 + 2r) depths. */
#ifndef UE4_TILE_W
#define UE4_TILE_W 128
#endif
#ifndef UE4_TILE_H
#define UE4_TILE_H 32
#endif
typedef struct level_job {
    const prep *P;
    int l;
    int qx0, qy0, qw, qh;  /* region (level coordinates; may be one past the edge) */
    int rx0, ry0;          /* origin of the output rect */
    int saturate;
    int tiles_x;
    obs_image_f32 *out;
    float *scratch;        /* per thread: 2 rows x 4 planes (ao, SceneDepth, nx, ny) of UE4_TILE_W floats */
    unsigned char *bg_scratch; /* per thread: 2 background rows of the level's width (level 0) */
    int64_t (*counts)[2];  /* per tile: background, zero normal */
} level_job;

static void level_task(void *user, int64_t task, int thread)
{
    const level_job *J = (const level_job *)user;
    const prep *P = J->P;
    const level *L = &P->lv[J->l];
    float *sc = J->scratch + (size_t)thread * 8 * UE4_TILE_W;
    unsigned char *bsc = J->bg_scratch + (size_t)thread * 2 * (size_t)L->w;
    const int tile_x = (int)(task % J->tiles_x), tile_y = (int)(task / J->tiles_x);
    /* the tile: region columns from tqx0 (level x), tqw wide; region rows [ga, gb) */
    const int lx0 = tile_x * UE4_TILE_W, tqw = J->qw - lx0 < UE4_TILE_W ? J->qw - lx0 : UE4_TILE_W;
    const int tqx0 = J->qx0 + lx0;
    const int ga = tile_y * UE4_TILE_H, gb = J->qh - ga < UE4_TILE_H ? J->qh : ga + UE4_TILE_H;
    /* its output columns [ox0, ox1) (level x), possibly none (a helper column alone) */
    const int ow = J->out->width;
    const int ox0 = J->rx0 > tqx0 ? J->rx0 : tqx0;
    const int ox1 = J->rx0 + ow < tqx0 + tqw ? J->rx0 + ow : tqx0 + tqw;
    const int bx0 = clampi(tqx0, 0, L->w - 1), bx1 = clampi(tqx0 + tqw, bx0 + 1, L->w);
    int64_t count[2] = {0, 0};
    float *rows[2][4];
    for (int rr = 0; rr < 2; rr++)
        for (int c = 0; c < 4; c++)
            rows[rr][c] = sc + (size_t)(4 * rr + c) * UE4_TILE_W;
    for (int g0 = ga; g0 < gb; g0 += 2) {
        const int g1 = g0 + 2 < gb ? g0 + 2 : gb;
        const unsigned char *bgrows[2] = {NULL, NULL}; /* background rows (clamped), indexed by x */
        float *orow[2] = {NULL, NULL};
        for (int g = g0; g < g1; g++) {
            float *const *rp = rows[g - g0];
            int64_t c2[2];
            const int ty = clampi(J->qy0 + g, 0, L->h - 1);
            bgrows[g - g0] = level_bg_row(P, L, ty, bx0, bx1, bsc + (size_t)(g - g0) * L->w);
            ao_row_compute(P, J->l, tqx0, J->qy0 + g, tqw, bgrows[g - g0], rp[0], rp[1], rp[2], rp[3], c2);
            count[0] += c2[0];
            count[1] += c2[1];
            const int oy = J->qy0 + g - J->ry0;
            if (oy >= 0 && oy < J->out->height && ox1 > ox0)
                orow[g - g0] = obs_image_f32_row(J->out, oy) + (ox0 - J->rx0);
        }
        int start = 0; /* output columns [ox0, ox0 + start) of the pair's rows are done */
#ifdef UE4_AVX2
        if (P->simd && P->k->quad_blur && g1 - g0 == 2 && (orow[0] || orow[1])) {
            const unsigned char *bgr[2] = {bgrows[0] + ox0, bgrows[1] + ox0};
            start = quad_blur_pair_avx2(P->k, rows, tqw, tqx0, ox0, ox1 - ox0, J->qy0 + g0, bgr, orow, J->saturate);
        }
#endif
        for (int g = g0; g < g1; g++) {
            const int y = J->qy0 + g;
            float *o = orow[g - g0];
            if (!o)
                continue;
            if (P->k->quad_blur) {
                const float *const r[2][4] = {{rows[g - g0][0], rows[g - g0][1], rows[g - g0][2], rows[g - g0][3]},
                                              {rows[(g - g0) ^ 1][0], rows[(g - g0) ^ 1][1], rows[(g - g0) ^ 1][2],
                                               rows[(g - g0) ^ 1][3]}};
                quad_blur_row(P->k, r, tqx0, ox0 + start, y, ox1 - ox0 - start, bgrows[g - g0] + ox0 + start,
                              o + start, J->saturate);
            } else {
                memcpy(o, rows[g - g0][0] + (ox0 - tqx0), sizeof(float) * (size_t)(ox1 - ox0));
                if (J->saturate)
                    for (int i = 0; i < ox1 - ox0; i++)
                        o[i] = saturatef(o[i]);
            }
        }
    }
    J->counts[task][0] = count[0];
    J->counts[task][1] = count[1];
}

static obs_status run_level(obs_context *ctx, obs_pool *pool, const prep *P, int l, int qx0, int qy0, int qx1, int qy1,
                            int rx0, int ry0, int saturate, obs_image_f32 *out, int64_t *background)
{
    const int qw = qx1 - qx0, qh = qy1 - qy0;
    const int threads = obs_pool_threads(pool);
    const int tiles_x = (qw + UE4_TILE_W - 1) / UE4_TILE_W, tiles_y = (qh + UE4_TILE_H - 1) / UE4_TILE_H;
    const int64_t tiles = (int64_t)tiles_x * tiles_y;
    obs_status st = OBS_STATUS_OK;
    int64_t(*counts)[2] = (int64_t(*)[2])calloc((size_t)tiles, sizeof *counts);
    float *scratch = (float *)malloc(sizeof(float) * 8 * UE4_TILE_W * (size_t)threads);
    unsigned char *bg_scratch = (unsigned char *)malloc(2 * (size_t)P->lv[l].w * (size_t)threads);
    if (!counts || !scratch || !bg_scratch)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ue4: out of memory");
    if (st == OBS_STATUS_OK) {
        level_job J = {P, l, qx0, qy0, qw, qh, rx0, ry0, saturate, tiles_x, out, scratch, bg_scratch, counts};
        obs_pool_run(pool, tiles, level_task, &J);
        if (background)
            for (int64_t t = 0; t < tiles; t++)
                *background += counts[t][0];
    }
    free(bg_scratch);
    free(scratch);
    free(counts);
    return st;
}

/* The AVX2 row kernel where the CPU has it, unless OBS_ISA=scalar (the scalar reference, as the
 * rasterizer's switch). */
static int ue4_use_avx2(const prep *P)
{
#ifdef UE4_AVX2
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return 0;
    (void)P;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    (void)P;
    return 0;
#endif
}

static const char ue4_workspace_key; /* its address names our slot in the context */

obs_status ao_ue4_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_ue4_params *params,
                          obs_image_f32 *out, obs_image_f32 *out_raw, ao_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_ue4_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ue4: output planes must be %dx%d (the window)", in->w,
                         in->h);
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_ue4_constants K = ao_ue4_constants_from_params(params, in);
    const int W = in->width, H = in->height;
    prep P;
    memset(&P, 0, sizeof P);
    P.k = &K;
    P.in = in;
    P.levels = K.levels;
    P.cx = (float)in->cx;
    P.cy = (float)in->cy;
    P.half_w = (float)(0.5 * W);
    P.half_h = (float)(0.5 * H);
    P.fov_fix[0] = K.fov_fix[0];
    P.fov_fix[1] = K.fov_fix[1];
    P.fov_fix[2] = 1.0f;
    for (int c = 0; c < 3; c++)
        P.inv_fov_fix[c] = 1.0f / P.fov_fix[c];
    P.simd = ue4_use_avx2(&P);
    /* The coarse levels' blocks, the normals, Q and G come from the workspace kept in the context
     * between calls (ao_i_ws_*: planes zeroed as fresh ones, without their page faults) */
    ao_i_ws *ws = ao_i_ws_take(ctx, &ue4_workspace_key);
    if (!ws)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ue4: out of memory");
    obs_image_f32 recon[3] = {{0}, {0}, {0}};
    obs_image_f32 Q = {0}, G = {0};
    const obs_image_f32 *nsrc[3] = {NULL, NULL, NULL};
    const int use_n = K.normal_mode != AO_UE4_NORMALS_NONE;
    int64_t background = 0, computed = 0;

    /* ---- 1. prepare: the random vectors, the ScreenPos tables, normals from depth (mode 2), and
     *         the AO setup levels (multi-resolution option); level 0 converts the input's depth
     *         (uu, background) and normals (UE view space) where it reads them ---- */
    const double t0 = obs_time_now();
    unsigned char tex[16][4];
    ao_ue4_random_texture(tex);
    for (int i = 0; i < 16; i++) {
        P.rand_vec[i][0] = (float)tex[i][0] / 255.0f * 2.0f - 1.0f; /* UNORM8 -> float, * 2 - 1 */
        P.rand_vec[i][1] = (float)tex[i][1] / 255.0f * 2.0f - 1.0f;
    }
    for (int l = 0; l < P.levels && st == OBS_STATUS_OK; l++) {
        level *L = &P.lv[l];
        L->w = l ? (P.lv[l - 1].w + 1) / 2 : W; /* DivideAndRoundUp(extent, 2) */
        L->h = l ? (P.lv[l - 1].h + 1) / 2 : H;
        L->s = (float)(1 << l);
        /* AORadiusInShader *= pow(MipScale, log2(ScaleToFullRes)) (the /4 is in the constant) */
        L->radius = K.ao_radius_in_shader * powf(K.mip_scale, (float)l);
        /* the coarse levels run USE_SAMPLESET 3 (USE_AO_SETUP_AS_INPUT 1) */
        L->sample_count = l ? ao_ue4_sample_set(3, L->samples) : K.sample_count;
        if (!l)
            memcpy(L->samples, K.samples, sizeof L->samples);
        L->inv_s = 1.0f / L->s;
        /* level 0 reads the input's depth and normals as they are (level_depth, level_bg_row,
         * ue4_normal_at): no full-size planes, whose fresh pages cost more than the conversion */
        if (l)
            st = level_alloc(ctx, ws, L, use_n, l + 1 < P.levels);
        if (st == OBS_STATUS_OK) {
            L->spx = (float *)malloc(sizeof(float) * ((size_t)L->w + 1));
            L->spy = (float *)malloc(sizeof(float) * ((size_t)L->h + 1));
            if (!L->spx || !L->spy)
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ue4: out of memory");
        }
        for (int k = 0; k < (l ? 3 : 2) && st == OBS_STATUS_OK && l + 1 < P.levels; k++) {
            L->utx[k] = (int *)malloc(sizeof(int) * ((size_t)L->w + 1));
            L->uty[k] = (int *)malloc(sizeof(int) * ((size_t)L->h + 1));
            if (!L->utx[k] || !L->uty[k])
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "ue4: out of memory");
        }
        if (st == OBS_STATUS_OK) {
            /* ScreenPos (NDC, y up) of the texel centres, from the principal point (in double) */
            const double s = L->s;
            for (int x = 0; x <= L->w; x++)
                L->spx[x] = (float)((((double)x + 0.5) * s - in->cx) * 2.0 / W);
            for (int y = 0; y <= L->h; y++)
                L->spy[y] = (float)(-(((double)y + 0.5) * s - in->cy) * 2.0 / H);
        }
    }
    for (int l = 0; l + 1 < P.levels && st == OBS_STATUS_OK; l++)
        upsample_tables(&P.lv[l], &P.lv[l + 1], l);
    if (st == OBS_STATUS_OK && use_n) {
        if (K.normal_mode == AO_UE4_NORMALS_GBUFFER) {
            nsrc[0] = in->normal[0], nsrc[1] = in->normal[1], nsrc[2] = in->normal[2];
        } else {
            /* SSAO_NORMAL_MODE 2 (ReconstructNormalFromDepthBuffer: the smaller one-sided delta, then a
             * cross product); ours picks the smaller linear-depth delta (UE: device Z) */
            for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
                st = ao_i_ws_plane(ctx, ws, W, H, &recon[c]);
            if (st == OBS_STATUS_OK)
                st = ao_normals_from_depth(ctx, pool, in, recon);
            nsrc[0] = &recon[0], nsrc[1] = &recon[1], nsrc[2] = &recon[2];
        }
    }
    if (st == OBS_STATUS_OK) {
        for (int c = 0; c < 3; c++)
            P.nsrc[c] = nsrc[c];
        for (int l = 1; l < P.levels; l++) {
            setup_job SJ = {&P, l, use_n};
            obs_pool_run(pool, P.lv[l].h, setup_row, &SJ);
        }
    }
    const double t1 = obs_time_now();

    /* ---- 2. the coarse levels, coarsest first, over their whole planes ---- */
    for (int l = P.levels - 1; l >= 1 && st == OBS_STATUS_OK; l--) {
        level *L = &P.lv[l];
        const int qx1 = K.quad_blur ? L->w + (L->w & 1) : L->w, qy1 = K.quad_blur ? L->h + (L->h & 1) : L->h;
        st = run_level(ctx, pool, &P, l, 0, 0, qx1, qy1, 0, 0, 0, &L->ao, NULL);
        computed += (int64_t)qx1 * qy1;
    }

    /* ---- 3. the full-resolution pass over the window plus the Gaussian's reach, aligned to 2x2
     *         quads, then its quad blur, saturated (the UNORM render target). Without the Gaussian
     *         the rect is the window, written straight into out. ---- */
    int rect[4];
    ao_blur_reach(in, K.blur ? AO_GAUSS21_RADIUS : 0, rect);
    int qx0 = rect[0], qy0 = rect[1], qx1 = rect[0] + rect[2], qy1 = rect[1] + rect[3]; /* exclusive */
    if (K.quad_blur) {
        qx0 &= ~1, qy0 &= ~1;
        qx1 += qx1 & 1, qy1 += qy1 & 1; /* may be one past the buffer: a helper lane */
    }
    const int direct = !K.blur && rect[0] == in->x0 && rect[1] == in->y0 && rect[2] == in->w && rect[3] == in->h;
    if (st == OBS_STATUS_OK && !direct)
        st = ao_i_ws_plane(ctx, ws, rect[2], rect[3], &Q);
    if (st == OBS_STATUS_OK) {
        st = run_level(ctx, pool, &P, 0, qx0, qy0, qx1, qy1, rect[0], rect[1], 1, direct ? out : &Q, &background);
        computed += (int64_t)(qx1 - qx0) * (qy1 - qy0);
    }
    const double t2 = obs_time_now();

    /* ---- 4. the seed thesis' Gaussian ---- */
    const obs_image_f32 *final = direct ? out : &Q;
    if (st == OBS_STATUS_OK && K.blur) {
        st = ao_i_ws_plane(ctx, ws, rect[2], rect[3], &G);
        if (st == OBS_STATUS_OK)
            st = ao_i_blur_gaussian21_ws(ctx, pool, ws, &Q, &G);
        final = &G;
    }
    const double t3 = obs_time_now();

    /* ---- 5. crop the window ---- */
    if (st == OBS_STATUS_OK) {
        const obs_image_f32 *raw = direct ? out : &Q;
        for (int y = 0; y < in->h; y++) {
            const int ry = in->y0 + y - rect[1];
            if (!direct)
                memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, ry) + (in->x0 - rect[0]),
                       sizeof(float) * in->w);
            if (final != raw) /* the Gaussian mixes background with its neighbours: background stays 1 (blur.md) */
                ao_i_background_to_one(in, y, obs_image_f32_row(out, y));
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(raw, ry) + (in->x0 - rect[0]),
                       sizeof(float) * in->w);
        }
        if (stats) {
            stats->pixels_computed = computed;
            stats->pixels_background = background;
            stats->seconds_prepare = t1 - t0;
            stats->seconds_kernel = t2 - t1;
            stats->seconds_blur = t3 - t2;
        }
    }
    for (int l = 0; l < AO_UE4_MAX_LEVELS; l++)
        level_free(&P.lv[l]);
    ao_i_ws_put(ctx, &ue4_workspace_key, ws); /* G, Q, recon and the level blocks are its */
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_ue4_variant) == sizeof(int) && sizeof(ao_ue4_normals) == sizeof(int),
               "ENUM params are int-sized");
_Static_assert(sizeof(ao_ue4_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define UE4_F(field) offsetof(ao_ue4_params, field)
static const ao_param_desc ue4_param_descs[] = {
    {"variant", AO_PARAM_ENUM, UE4_F(variant), 0, 0, variant_names,
     "o1 (OPTIMIZATION_O1 1, what UE 4.9+ compiles) or classic-reconstruction (our reading of the "
     "OPTIMIZATION_O1 0 branch UE never ran)"},
    {"normals", AO_PARAM_ENUM, UE4_F(normals), 0, 0, normals_names,
     "SSAO_NORMAL_MODE: none (WedgeNoNormal), gbuffer (from depth when absent), depth"},
    {"radius", AO_PARAM_FLOAT, UE4_F(radius), 1e-6, 1e4, NULL,
     "AmbientOcclusionRadius (m); view space: shader radius radius/16, world space: radius/4 m"},
    {"radius-in-ws", AO_PARAM_BOOL, UE4_F(radius_in_ws), 0, 1, NULL, "AmbientOcclusionRadiusInWS"},
    {"power", AO_PARAM_FLOAT, UE4_F(power), 1e-6, 1e3, NULL, "AmbientOcclusionPower"},
    {"intensity", AO_PARAM_FLOAT, UE4_F(intensity), 0, 1, NULL, "AmbientOcclusionIntensity"},
    {"bias", AO_PARAM_FLOAT, UE4_F(bias), 0, 1000, NULL, "AmbientOcclusionBias (per mille of depth)"},
    {"distance", AO_PARAM_FLOAT, UE4_F(distance), 1e-4, 1e6, NULL,
     "AmbientOcclusionDistance (m): anti-halo depth of the no-normal path"},
    {"fade-distance", AO_PARAM_FLOAT, UE4_F(fade_distance), 0, 1e6, NULL, "AmbientOcclusionFadeDistance (m)"},
    {"fade-radius", AO_PARAM_FLOAT, UE4_F(fade_radius), 0, 1e6, NULL, "AmbientOcclusionFadeRadius (m)"},
    {"sample-set", AO_PARAM_INT, UE4_F(sample_set), 0, 3, NULL, "USE_SAMPLESET: 0 (1 point), 1 (3), 2 (5), 3 (6)"},
    {"steps", AO_PARAM_INT, UE4_F(steps), 1, AO_UE4_MAX_STEPS, NULL, "SAMPLE_STEPS per direction"},
    {"quad-blur", AO_PARAM_INT, UE4_F(quad_blur), 0, 3, NULL, "QUAD_MESSAGE_PASSING_BLUR (2x2 ddx/ddy blur)"},
    {"blur", AO_PARAM_BOOL, UE4_F(blur), 0, 1, NULL, "the seed thesis' 21-tap Gaussian afterwards"},
    {"levels", AO_PARAM_INT, UE4_F(levels), 1, AO_UE4_MAX_LEVELS, NULL,
     "resolution levels (r.AmbientOcclusionLevels; UE: 2 at quality 50): 1 = full resolution only"},
    {"mip-blend", AO_PARAM_FLOAT, UE4_F(mip_blend), 0, 1, NULL, "AmbientOcclusionMipBlend (levels > 1)"},
    {"mip-scale", AO_PARAM_FLOAT, UE4_F(mip_scale), 1e-6, 16, NULL, "AmbientOcclusionMipScale (levels > 1)"},
};
#undef UE4_F

static void m_default(void *p) { *(ao_ue4_params *)p = ao_ue4_params_default(); }
static int m_preset(const char *name, void *p) { return ao_ue4_params_preset(name, (ao_ue4_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p) { return ao_ue4_params_validate(ctx, (const ao_ue4_params *)p); }
static int m_to_string(const void *p, char *buf, size_t size) { return ao_ue4_params_to_string((const ao_ue4_params *)p, buf, size); }
static void m_set_samples(void *p, int n)
{
    ao_ue4_params *q = (ao_ue4_params *)p;
    ao_ue4_samples_to_set(n, &q->sample_set, &q->steps);
}
/* The study's world-space radius r: world-space mode with AmbientOcclusionRadius 4r, so that
 * ActualAORadius (the reach of the outermost tap, and the halo radius / 2) is r. */
static void m_set_radius(void *p, float r)
{
    ((ao_ue4_params *)p)->radius = 4.0f * r;
    ((ao_ue4_params *)p)->radius_in_ws = 1;
}
static void m_set_blur(void *p, int on) { ((ao_ue4_params *)p)->blur = on != 0; }
/* World space: ActualAORadius in m (radius / 4). View space: the world radius at 1 m depth
 * (radius / 16 m); it grows linearly with depth. */
static float m_get_radius(const void *p)
{
    const ao_ue4_params *q = (const ao_ue4_params *)p;
    return q->radius_in_ws ? q->radius / 4.0f : q->radius / 16.0f;
}
static const char *m_truth(const void *p)
{
    (void)p;
    return "unif"; /* the unoccluded wedge angle per slice, uniform in angle (ao.md 2) */
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_ue4_constants K = ao_ue4_constants_from_params((const ao_ue4_params *)p, in);
    unsigned char t[16][4];
    ao_ue4_random_texture(t);
    char tex[16 * 20 + 4];
    int n = 0;
    for (int i = 0; i < 16; i++)
        n += snprintf(tex + n, sizeof tex - (size_t)n, "%s[%d,%d,%d,%d]", i ? "," : "", t[i][0], t[i][1], t[i][2],
                      t[i][3]);
    char smp[256];
    int m = 0;
    for (int i = 0; i < K.sample_count; i++)
        m += snprintf(smp + m, sizeof smp - (size_t)m, "%s[%.9g,%.9g]", i ? "," : "", (double)K.samples[2 * i],
                      (double)K.samples[2 * i + 1]);
    return snprintf(
        buf, size,
        "{\"ScreenSpaceAOParams\": [[%.9g, %.9g, %.9g, %.9g], [%.9g, %.9g, %.9g, %.9g], [%.9g, %.9g, %.9g, %.9g], "
        "[%.9g, %.9g, %.9g, %.9g], [%.9g, %.9g, 0, 0]], \"FovFix\": [%.9g, %.9g, 1], \"units_per_metre\": %.9g, "
        "\"OPTIMIZATION_O1\": %d, \"SSAO_NORMAL_MODE\": %d, \"USE_SAMPLESET\": %d, \"SAMPLESET_ARRAY_SIZE\": %d, "
        "\"SAMPLE_STEPS\": %d, \"QUAD_MESSAGE_PASSING_BLUR\": %d, \"AO_SAMPLE_QUALITY\": 3, "
        "\"OcclusionSamplesOffsets\": [%s], \"SSAORandomization_4x4_rgba8\": [%s], \"gaussian21_blur\": %d, "
        "\"levels\": %d, \"MipScale\": %.9g}",
        (double)K.power, (double)K.bias_over_1000, (double)K.inv_distance, (double)K.intensity,
        (double)K.viewport_uv_to_random_uv[0], (double)K.viewport_uv_to_random_uv[1], (double)K.ao_radius_in_shader,
        (double)K.ratio, (double)K.scale_factor, (double)K.inv_threshold, (double)K.scale_radius_in_ws,
        (double)K.mip_blend, (double)K.temporal_offset[0], (double)K.temporal_offset[1], (double)K.static_fraction,
        (double)K.inv_tan_half_fov, (double)K.fade_mul, (double)K.fade_add, (double)K.fov_fix[0],
        (double)K.fov_fix[1], (double)K.units_per_metre, K.variant == AO_UE4_VARIANT_O1, K.normal_mode, K.sample_set,
        K.sample_count, K.steps, K.quad_blur, smp, tex, K.blur, K.levels, (double)K.mip_scale);
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    return ao_ue4_compute(ctx, pool, in, (const ao_ue4_params *)p, out, out_raw, stats);
}

const ao_method ao_i_method_ue4 = {
    .name = "ue4",
    .title = "Unreal Engine 4 AO [Mittring12]: PostProcessAmbientOcclusion.usf (O1 wedge, 2 levels; classic reconstruction)",
    .doc = "docs/ao/ue4.md",
    .params_size = sizeof(ao_ue4_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = ue4_param_descs,
    .param_count = (int)(sizeof ue4_param_descs / sizeof ue4_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* exactly 1 on a camera-facing plane (every mode); on a tilted plane the tap reads its texel's
     * depth at its continuous screen position (point sampling, as UE's HZB fetch), which puts the
     * tap off the plane by up to half a texel's depth step, and O1's dot(D, n 0.08 z)/|D|^2 grows as
     * the tap nears the centre: measured 0.153 (0.138 with the Gaussian) on the registry's 50 degree
     * plane (96x64, f = 80 px, radius 0.5 m, border 4) with the default (O1, 2 levels); 0.0434 with
     * classic-reconstruction, which was the default until issue 12 (test_ao_ue4.c, docs/ao/ue4.md) */
    .flat_tolerance = 0.16f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
