/* ao_sao.c: Scalable Ambient Obscurance [McGuire12], its depth MIP pyramid and its separable
 * bilateral blur, exact to the HPG12 reference shaders (SAO_AO.pix, SAO_minify.pix, SAO_blur.pix)
 * as the llvmpipe peer runs them (../shared/tools/llvmpipe-peer/README.md, section 5).
 *
 * Everything here works in the shader's own pixel grid: GL window coordinates, x to the right,
 * y UP (row 0 of every internal plane is the BOTTOM row of the image). Our images have row 0 at
 * the top, so the input depth is flipped once when the CSZ buffer is built and the output is
 * flipped back when written: the hash, the 2x2 derivative quads, the rotated-grid MIP texels and
 * the blur's tap order then all match a GPU given the same buffers.
 *
 * Arithmetic is float32 in the shader's operation order (the build uses -ffp-contract=off). The
 * differences from the reference that remain (libm cos/sin/log2f against the GPU's, inversesqrt
 * as 1/sqrt) are listed in docs/ao/sao.md with their measured effect.
 */
#include "ao.h"
#include "ao_internal.h"
#include "ao_sao_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* [McGuire12] SAO_blur.pix: Gaussian with stddev 2, "gaussian[0..4]". */
const float ao_sao_blur_gaussian[AO_SAO_BLUR_RADIUS + 1] = {0.153170f, 0.144893f, 0.122649f, 0.092902f, 0.062970f};

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_sao_params ao_sao_params_default(void)
{
    ao_sao_params p;
    memset(&p, 0, sizeof p);
    p.variant = AO_SAO_VARIANT_HPG12;
    p.radius = AO_SAO_DEFAULT_RADIUS;
    p.bias = AO_SAO_DEFAULT_BIAS;
    p.intensity = AO_SAO_DEFAULT_INTENSITY;
    p.epsilon = AO_SAO_DEFAULT_EPSILON;
    p.samples = AO_SAO_DEFAULT_SAMPLES;
    p.spiral_turns = AO_SAO_DEFAULT_SPIRAL_TURNS;
    p.max_mip_level = AO_SAO_DEFAULT_MAX_MIP_LEVEL;
    p.log_max_offset = AO_SAO_DEFAULT_LOG_MAX_OFFSET;
    p.normals = AO_SAO_NORMALS_FROM_DEPTH;
    p.blur = 1;
    p.blur_stride = AO_SAO_DEFAULT_BLUR_STRIDE;
    p.edge_sharpness = AO_SAO_DEFAULT_EDGE_SHARPNESS;
    p.blur_key_far = AO_SAO_DEFAULT_BLUR_KEY_FAR;
    return p;
}

static const char *const preset_names[] = {"default", "peer", "hpg12", "thesis", "g3d", "g3d-hq", NULL};

const char *const *ao_sao_preset_names(void) { return preset_names; }

int ao_sao_params_preset(const char *name, ao_sao_params *out)
{
    if (!name || !out)
        return 0;
    ao_sao_params p = ao_sao_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "peer")) {
        /* the llvmpipe peer's parameters */
    } else if (!strcmp(name, "hpg12")) {
        p.max_mip_level = 4; /* HPG12 SAO_AO.pix MAX_MIP_LEVEL 4 (later G3D and the peer: 5) */
    } else if (!strcmp(name, "thesis")) {
        /* ssao-thesis-2017, Tabla 3: "Scalable AO  Radio(m) 10  Muestras 8" */
        p.radius = 10.0f;
        p.samples = 8;
        p.spiral_turns = AO_SAO_TURNS_FROM_TABLE;
    } else if (!strcmp(name, "g3d") || !strcmp(name, "g3d-hq")) {
        /* G3D GLG3D.lib/source/AmbientOcclusionSettings.cpp (edited 2014-12-30): radius 0.75 m,
         * bias 0.023, intensity 1.0, numSamples 19, edgeSharpness 1.0, blurStepSize 2,
         * blurRadius 4; turns from numSpiralTurns() (table: 19 -> 7). */
        p.radius = 0.75f;
        p.bias = 0.023f;
        p.intensity = 1.0f;
        p.samples = 19;
        p.spiral_turns = AO_SAO_TURNS_FROM_TABLE;
        p.blur_stride = 2;
        p.edge_sharpness = 1.0f;
        if (!strcmp(name, "g3d-hq")) {
            p.variant = AO_SAO_VARIANT_G3D_HQ;
            p.epsilon = 0.001f; /* AmbientOcclusion_AO.pix aoValueFromPositionsAndNormal: const 0.001 */
        }
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

int ao_sao_turns_for_samples(int n)
{
    /* McGuire's minDiscrepancyArray[100] (G3D AmbientOcclusionSettings::numSpiralTurns(), also in
     * DeepGBufferRadiositySettings.cpp); for n >= 100 G3D returns the prime 5779. */
    static const unsigned char table[100] = {
        1,  1,  1,  2,  3,  2,  5,  2,  3,  2,  3,  3,  5,  5,  3,  4,  7,  5,  5,  7,
        9,  8,  5,  5,  7,  7,  7,  8,  5,  8,  11, 12, 7,  10, 13, 8,  11, 8,  7,  14,
        11, 11, 13, 12, 13, 19, 17, 13, 11, 18, 19, 11, 11, 14, 17, 21, 15, 16, 17, 18,
        13, 17, 11, 17, 19, 18, 25, 18, 19, 19, 29, 21, 19, 27, 31, 29, 21, 18, 17, 29,
        31, 31, 23, 18, 25, 26, 25, 23, 19, 34, 19, 27, 21, 25, 39, 29, 17, 21, 27, 29};
    if (n < 1)
        return 1;
    return n < 100 ? table[n] : 5779;
}

obs_status ao_sao_params_validate(obs_context *ctx, const ao_sao_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: NULL params");
    if ((unsigned)p->variant >= AO_SAO_VARIANT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: unknown variant %d", (int)p->variant);
    const float r2 = p->radius * p->radius, r6 = r2 * r2 * r2;
    if (!(p->radius > 0.0f) || !isfinite(p->radius) || !(r6 > 0.0f) || !isfinite(r6))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sao: radius %g must be > 0 with r^6 a finite, non-zero float (about 1e-6 .. 1e6)",
                         (double)p->radius);
    if (!isfinite(p->bias))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: bias %g must be finite", (double)p->bias);
    if (!(p->intensity >= 0.0f) || !isfinite(p->intensity))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: intensity %g must be finite and >= 0",
                         (double)p->intensity);
    if (!(p->epsilon > 0.0f) || !isfinite(p->epsilon))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: epsilon %g must be finite and > 0",
                         (double)p->epsilon);
    if (p->samples < 1 || p->samples > AO_SAO_MAX_SAMPLES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: samples %d must be in [1, %d]", p->samples,
                         AO_SAO_MAX_SAMPLES);
    if (p->spiral_turns < 0 || p->spiral_turns > 1000000)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sao: spiral turns %d must be in [1, 1000000] (0 = from the minimum-discrepancy table)",
                         p->spiral_turns);
    if (p->max_mip_level < 0 || p->max_mip_level > AO_SAO_MAX_MIP)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: max MIP level %d must be in [0, %d]",
                         p->max_mip_level, AO_SAO_MAX_MIP);
    if (p->log_max_offset < 0 || p->log_max_offset > 30)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: log max offset %d must be in [0, 30]",
                         p->log_max_offset);
    if ((unsigned)p->normals >= AO_SAO_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: unknown normals mode %d", (int)p->normals);
    if (p->blur_stride < 1 || p->blur_stride > 64)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: blur stride %d must be in [1, 64]", p->blur_stride);
    if (!(p->edge_sharpness >= 0.0f) || !isfinite(p->edge_sharpness))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: edge sharpness %g must be finite and >= 0",
                         (double)p->edge_sharpness);
    if (!(p->blur_key_far > 0.0f) || !isfinite(p->blur_key_far))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: blur key far %g must be finite and > 0",
                         (double)p->blur_key_far);
    return OBS_STATUS_OK;
}

static int resolved_turns(const ao_sao_params *p)
{
    return p->spiral_turns == AO_SAO_TURNS_FROM_TABLE ? ao_sao_turns_for_samples(p->samples) : p->spiral_turns;
}

int ao_sao_params_to_string(const ao_sao_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "variant=%s radius=%.9g bias=%.9g intensity=%.9g epsilon=%.9g samples=%d spiral_turns=%d%s "
                    "max_mip_level=%d log_max_offset=%d normals=%s blur=%d blur_radius=%d blur_stride=%d "
                    "edge_sharpness=%.9g blur_key_far=%.9g",
                    p->variant == AO_SAO_VARIANT_G3D_HQ ? "g3d-hq" : "hpg12", (double)p->radius, (double)p->bias,
                    (double)p->intensity, (double)p->epsilon, p->samples, resolved_turns(p),
                    p->spiral_turns == AO_SAO_TURNS_FROM_TABLE ? "(table)" : "", p->max_mip_level, p->log_max_offset,
                    p->normals == AO_SAO_NORMALS_GBUFFER ? "gbuffer" : "depth", p->blur, AO_SAO_BLUR_RADIUS,
                    p->blur_stride, (double)p->edge_sharpness, (double)p->blur_key_far);
}

ao_sao_constants ao_sao_constants_from_params(const ao_sao_params *p, const ao_input *in)
{
    ao_sao_constants k;
    memset(&k, 0, sizeof k);
    k.full_width = in->width;
    k.full_height = in->height;
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.variant = (int)p->variant;
    k.normals_from_gbuffer = p->normals == AO_SAO_NORMALS_GBUFFER;
    /* projInfo in GL pixel coordinates (y_gl + 0.5 = H - (y + 0.5)): see ao_sao_constants. For a
     * centred frustum (cx = W/2, cy = H/2) this is the peer's (-2/(W P00), -2/(H P11), 1/P00, 1/P11). */
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
    /* projScale: "the height in pixels of a 1m object if viewed from 1m away" = H P11 / 2 = fy. */
    k.proj_scale = (float)in->fy;
    k.radius = p->radius;
    k.radius2 = p->radius * p->radius;
    k.inv_radius2 = 1.0f / k.radius2;
    k.bias = p->bias;
    k.intensity = p->intensity;
    k.epsilon = p->epsilon;
    k.num_samples = p->samples;
    k.num_spiral_turns = resolved_turns(p);
    /* GLSL constant folding, in float: (1.0 / float(NUM_SAMPLES)), float(NUM_SPIRAL_TURNS) * 6.28 */
    k.inv_num_samples = 1.0f / (float)p->samples;
    k.turns_angle = (float)k.num_spiral_turns * 6.28f;
    if (p->variant == AO_SAO_VARIANT_HPG12)
        k.final_scale = 5.0f / (k.radius2 * k.radius2 * k.radius2 * (float)p->samples);
    else
        k.final_scale = 3.0f / (float)p->samples;
    k.max_mip = p->max_mip_level;
    k.log_max_offset = p->log_max_offset;
    k.blur = p->blur != 0;
    k.blur_radius = AO_SAO_BLUR_RADIUS;
    k.blur_stride = p->blur_stride;
    /* SAO_blur.pix: weight *= max(0, 1 - (EDGE_SHARPNESS * 2000) * |key_r - key|), key = z / FAR */
    k.edge_k = (p->edge_sharpness * 2000.0f) / p->blur_key_far;
    return k;
}

/* ================================================================================================
 * Small exact helpers
 * ============================================================================================== */

float ao_sao_spin(int x_gl, int y_gl)
{
    /* [McGuire12] SAO_AO.pix: "Hash function used in the HPG12 AlchemyAO paper"
     *   float randomPatternRotationAngle = (3 * ssC.x ^ ssC.y + ssC.x * ssC.y) * 10;
     * '+' binds tighter than '^' in GLSL and C: ((3x) ^ (y + xy)) * 10. GLSL int arithmetic is
     * 32-bit two's complement and wraps on overflow; C signed overflow is undefined, so the
     * products and sums run in uint32 (same bits) and the result is reinterpreted as int32. */
    uint32_t ux = (uint32_t)x_gl, uy = (uint32_t)y_gl;
    uint32_t h = ((3u * ux) ^ (uy + ux * uy)) * 10u;
    int32_t s = h <= (uint32_t)INT32_MAX ? (int32_t)h : (int32_t)(h - 2147483648u) - INT32_MAX - 1;
    return (float)s; /* int -> float: round to nearest even, as cvtdq2ps and GLSL float(int) */
}

static inline float maxf(float a, float b) { return a > b ? a : b; } /* GLSL max; NaN a -> b (x86 maxps) */

/* GLSL int(f) truncates toward zero; values outside int range are undefined there. We clamp to
 * +-2^30 so that the tap coordinate (+ a coordinate < 2^15) cannot overflow; NaN -> 0. */
static inline int trunc_to_int(float v)
{
    v = v == v ? v : 0.0f;                         /* NaN -> 0 */
    v = v < 1073741824.0f ? v : 1073741824.0f;     /* min(v, 2^30) */
    v = v > -1073741824.0f ? v : -1073741824.0f;   /* max(v, -2^30) */
    return (int)v;                                 /* exact for |v| <= 2^30 */
}

/* cos and sin of a float angle, as the ideal GLSL cos()/sin(): the float nearest to the exact
 * value. The angle is the hash times 10 plus the spiral, up to ~2^31 rad, so the reduction
 * modulo pi/2 must be exact; libm's double cos/sin do that too, but cost ~4x more, and their
 * last-bit behaviour differs between libms. Here:
 *   k = nearest integer to x * 2/pi (|k| < 2^31 for |x| < 3.3e9; larger angles go to libm);
 *   r = x - k*P1 - k*P2 - k*P3 - k*P4 with pi/2 = P1 + P2 + P3 + P4 split into 22-bit pieces
 *       (exact products k*Pi for |k| < 2^31; the first two differences are exact by Sterbenz and
 *       alignment, the absolute error is ~2^-88, far below r for any float x);
 *   sin r, cos r by fdlibm's minimax kernels on |r| <= pi/4 (k_sin.c, k_cos.c: degree 13 and 14,
 *       |error| < 2^-58; the same coefficients are in musl's __sin.c / __cos.c), Horner in double;
 *       the quadrant k mod 4 picks the signs.
 * Agreement with (float)cos((double)a) and (float)sin((double)a) was checked for every float
 * angle in [0, 3e9) (docs/ao/sao.md, "Speed"); the result is odd/even in a exactly. The AVX2
 * kernel (ao_sao_avx2.c, cos_sin_pd) runs the same operations in the same order. */
static inline __attribute__((always_inline)) void cos_sin_inline(float angle, float *c, float *s)
{
    const double x = (double)angle;
    if (!(fabs(x) < 3.0e9)) { /* not reached by SAO's angles; NaN and inf go through libm too */
        *c = (float)cos(x);
        *s = (float)sin(x);
        return;
    }
    static const double P1 = 0x1.921fbp+0, P2 = 0x1.5110bp-22, P3 = 0x1.18469800p-44, P4 = 0x1.3198a2e037073p-69;
    static const double TWO_OVER_PI = 0x1.45f306dc9c883p-1, ROUNDER = 0x1.8p52;
    const double kd = (x * TWO_OVER_PI + ROUNDER) - ROUNDER; /* round to nearest (|.| < 2^51) */
    double r = x - kd * P1;
    r = r - kd * P2;
    r = r - kd * P3;
    r = r - kd * P4;
    const double z = r * r;
    const double sn = r + r * z * (AO_I_SIN_S1 + z * (AO_I_SIN_S2 + z * (AO_I_SIN_S3 + z * (AO_I_SIN_S4 +
                                   z * (AO_I_SIN_S5 + z * AO_I_SIN_S6)))));
    const double cs = 1.0 - 0.5 * z + z * z * (AO_I_COS_C1 + z * (AO_I_COS_C2 + z * (AO_I_COS_C3 + z * (AO_I_COS_C4 +
                                               z * (AO_I_COS_C5 + z * AO_I_COS_C6)))));
    switch ((int)((int64_t)kd & 3)) {
    case 0: *c = (float)cs; *s = (float)sn; break;
    case 1: *c = (float)-sn; *s = (float)cs; break;
    case 2: *c = (float)-cs; *s = (float)-sn; break;
    default: *c = (float)sn; *s = (float)-cs; break;
    }
}

void ao_i_cos_sin(float angle, float *c, float *s) { cos_sin_inline(angle, c, s); }

int ao_i_floor_log2f(float x)
{
    if (!(x > 0.0f))
        return INT32_MIN;
    if (!(x < INFINITY))
        return INT32_MAX;
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    const uint32_t m = b & 0x7FFFFFu;
    const int e = (int)((b >> 23) & 0xFFu);
    /* The exponent is floor(log2 x) exactly, but the float nearest to log2(x) is the next integer
     * when x is a few ulps below a power of two (log2 = e + 1 - delta with delta under half an
     * ulp of e + 1; at most 44 ulps of x for any finite float). Those, denormals and infinity
     * take the double log2, rounded to float. */
    if (e == 0 || m >= 0x7FFFFFu - 64u)
        return (int)floorf((float)log2((double)x));
    return e - 127;
}

/* ================================================================================================
 * CSZ buffer and MIP pyramid (GL row order)
 * ============================================================================================== */

typedef struct csz_job {
    const ao_input *in;
    obs_image_f32 *out;
} csz_job;

static void csz_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const csz_job *J = (const csz_job *)user;
    const int H = J->in->height, W = J->in->width, r = (int)task;
    const float *d = obs_image_f32_row(J->in->depth, H - 1 - r);
    float *o = obs_image_f32_row(J->out, r);
    for (int x = 0; x < W; x++) {
        float v = d[x];
        /* reconstructCSZ: camera-space z is negative; background (and any unusable depth) is the
         * 0 sentinel the shaders test for. */
        o[x] = (v > 0.0f && v < INFINITY) ? -v : 0.0f;
    }
}

obs_status ao_sao_csz_from_input(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->width || out->height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_csz_from_input: output must be a %dx%d plane",
                         in->width, in->height);
    csz_job J = {in, out};
    obs_pool_run(pool, in->height, csz_row, &J);
    return OBS_STATUS_OK;
}

typedef struct mip_job {
    const obs_image_f32 *prev;
    obs_image_f32 *cur;
} mip_job;

static void mip_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const mip_job *J = (const mip_job *)user;
    const int py = (int)task, pw = J->prev->width, ph = J->prev->height;
    float *o = obs_image_f32_row(J->cur, py);
    /* [McGuire12] SAO_minify.pix: "Rotated grid subsampling to avoid XY directional bias or Z
     * precision bias while downsampling": texel clamp(2p + (p.y & 1, p.x & 1), 0, size - 1) of the
     * previous level, p in GL coordinates (y up). */
    for (int px = 0; px < J->cur->width; px++) {
        const int sx = 2 * px + (py & 1), sy = 2 * py + (px & 1);
        int cx = sx < pw - 1 ? sx : pw - 1, cy = sy < ph - 1 ? sy : ph - 1;
        o[px] = obs_image_f32_row(J->prev, cy)[cx];
    }
}

obs_status ao_sao_mip_build(obs_context *ctx, obs_pool *pool, const obs_image_f32 *level0, int max_level,
                            obs_image_f32 *levels)
{
    if (!level0 || !level0->data || !levels || level0->width < 1 || level0->height < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_mip_build: NULL or empty argument");
    if (max_level < 0 || max_level > AO_SAO_MAX_MIP)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_mip_build: max level %d must be in [0, %d]",
                         max_level, AO_SAO_MAX_MIP);
    levels[0] = *level0;
    for (int l = 1; l <= max_level; l++)
        memset(&levels[l], 0, sizeof levels[l]);
    for (int l = 1; l <= max_level; l++) {
        /* level l: max(1, size_0 >> l) (the peer's viewport; GL's own mip size rule) */
        int w = level0->width >> l, h = level0->height >> l;
        w = w < 1 ? 1 : w;
        h = h < 1 ? 1 : h;
        obs_status st = obs_image_f32_alloc(ctx, w, h, &levels[l]);
        if (st != OBS_STATUS_OK) {
            ao_sao_mip_free(levels, max_level);
            return st;
        }
        mip_job J = {&levels[l - 1], &levels[l]};
        obs_pool_run(pool, h, mip_row, &J);
    }
    return OBS_STATUS_OK;
}

/* Make *block hold n floats (capacity *cap floats), growing it when needed: obs_aligned_alloc
 * memory, not zeroed. Returns 0 when out of memory. */
static int ws_block(float **block, size_t *cap, size_t n)
{
    if (*block && n <= *cap)
        return 1;
    obs_aligned_free(*block);
    *block = (float *)obs_aligned_alloc(n * sizeof(float));
    *cap = *block ? n : 0;
    return *block != NULL;
}

/* The AO pass's tiles (ao_i_sao_job.seg_w): SAO_SEG_W columns (a multiple of 8; 0: the whole row)
 * by SAO_SEG_H rows. Default: whole rows, one task each, as before tiles existed. Measured on the
 * 2-core Zen 5 VM (bunny 1080p, 11 taps, level 0, 1 thread): 128 x 32 tiles took the same CPU time
 * per call as rows (24.9 against 25.3 ms, noise +-2 ms) and 3 % more instructions (141.2 M against
 * 136.9 M: the per-row set-up runs per tile); the taps' band of rows (+-50 px, ~0.8 MB) fits L2. */
#ifndef SAO_SEG_W
#define SAO_SEG_W 0
#endif
#ifndef SAO_SEG_H
#define SAO_SEG_H 1
#endif

/* The pass's own pyramid: level 0 (CSZ) and levels 1..max_mip in ONE block, each level's rows
 * 64-byte aligned, so that the AVX2 kernel gathers from any level with 32-bit indices relative to
 * levels[0].data (ao_i_sao_job). Sizes as ao_sao_mip_build. The block holds at most
 * (W + 15) H 4/3 + 16 (max_mip + 1) floats < 2^31 for any image within the pixel limit (2^28);
 * larger blocks are refused. The block is the workspace's (*block, capacity *cap floats), grown
 * when needed; not zeroed (every texel a tap can read is written first; the row padding is never
 * read, every index being clamped into its level). */
static obs_status pyramid_alloc(obs_context *ctx, int W, int H, int max_mip, obs_image_f32 *levels, float **block,
                                size_t *cap)
{
    size_t off[AO_SAO_MAX_MIP + 2];
    off[0] = 0;
    for (int l = 0; l <= max_mip; l++) {
        int w = W >> l, h = H >> l;
        w = w < 1 ? 1 : w;
        h = h < 1 ? 1 : h;
        levels[l].width = w;
        levels[l].height = h;
        levels[l].stride = ((ptrdiff_t)w + 15) & ~(ptrdiff_t)15;
        off[l + 1] = off[l] + (size_t)levels[l].stride * (size_t)h;
    }
    const size_t total = off[max_mip + 1];
    if (total > (size_t)INT32_MAX || (int64_t)total * 4 > obs_context_limits(ctx)->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "sao: a %dx%d depth pyramid needs %zu floats, over the limit",
                         W, H, total);
    if (!ws_block(block, cap, total))
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sao: cannot allocate the %dx%d depth pyramid", W, H);
    for (int l = 0; l <= max_mip; l++)
        levels[l].data = *block + off[l];
    return OBS_STATUS_OK;
}

/* The pass's working planes (raw AO, and for the blur its two passes) in one block, not zeroed:
 * every pixel of each is written before it is read. One block of 4 MiB or more gets huge pages
 * (obs_aligned_alloc); at 720p each plane alone (3.7 MB) would not, and first-touching it in
 * 4 KiB pages cost more than the blur's arithmetic. The block is the workspace's (*block,
 * capacity *cap floats), grown when needed, so that repeated calls fault no pages at all. */
static obs_status work_planes_alloc(obs_context *ctx, int n, const int (*wh)[2], obs_image_f32 *planes, float **block,
                                    size_t *cap)
{
    size_t off[4] = {0};
    for (int i = 0; i < n; i++) {
        planes[i].width = wh[i][0];
        planes[i].height = wh[i][1];
        planes[i].stride = ((ptrdiff_t)wh[i][0] + 15) & ~(ptrdiff_t)15;
        off[i + 1] = off[i] + (size_t)planes[i].stride * (size_t)wh[i][1];
    }
    if ((int64_t)off[n] * 4 > obs_context_limits(ctx)->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "sao: the working planes need %zu floats, over the limit",
                         off[n]);
    if (!ws_block(block, cap, off[n]))
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sao: cannot allocate the working planes");
    for (int i = 0; i < n; i++)
        planes[i].data = *block + off[i];
    return OBS_STATUS_OK;
}

/* ---- The workspace: what a call needs besides its output, kept between calls ------------------
 * The pyramid block, the working planes, the per-row counts and the job are parked in the
 * caller's context (obs_context_scratch_put, as ao_gtao.c's workspace) and reused by the next
 * call with that context: no allocation and no page faults (a 1080p call first-touched ~18 MB,
 * huge pages zeroed by the kernel inside the timed passes: docs/performance.md). Nothing is
 * zeroed: every plane is written before it is read (above), and every row's counts by its row.
 * Blocks only grow; the context frees them (obs_context_destroy). */
typedef struct sao_workspace {
    float *pyramid, *work;
    size_t pyramid_cap, work_cap; /* floats */
    int64_t (*counts)[3];
    size_t counts_cap;            /* rows */
    ao_i_sao_job job;
} sao_workspace;

static const char sao_workspace_key; /* its address names our slot in the context */

static void sao_workspace_destroy(void *p)
{
    sao_workspace *ws = (sao_workspace *)p;
    if (!ws)
        return;
    obs_aligned_free(ws->pyramid);
    obs_aligned_free(ws->work);
    free(ws->counts);
    free(ws);
}

void ao_sao_mip_free(obs_image_f32 *levels, int max_level)
{
    if (!levels)
        return;
    for (int l = 1; l <= max_level && l <= AO_SAO_MAX_MIP; l++)
        obs_image_f32_free(&levels[l]);
}

/* ================================================================================================
 * The AO pass (scalar; the reference for the AVX2 kernel in ao_sao_avx2.c)
 * ============================================================================================== */

/* csPos: [McGuire12] SAO_AO.pix reconstructCSPosition, GL pixel s, camera-space z. */
static inline void cs_pos(const ao_sao_constants *k, const int ortho, int sx, int sy, float z, float P[3])
{
    float ax = ((float)sx + 0.5f) * k->proj_info[0] + k->proj_info[2];
    float ay = ((float)sy + 0.5f) * k->proj_info[1] + k->proj_info[3];
    if (!ortho) {
        P[0] = ax * z;
        P[1] = ay * z;
        P[2] = z;
    } else {
        P[0] = ax;
        P[1] = ay;
        P[2] = z;
    }
}

/* texelFetch of level 0 for the derivative quads: coordinates outside the buffer read 0, as a GPU
 * with robust access (and llvmpipe) returns for out-of-range texelFetch (helper lanes past the
 * last row/column of an odd-sized buffer). docs/ao/sao.md, "Borders". */
static inline float csz_at(const obs_image_f32 *L0, int x, int y)
{
    if (x < 0 || y < 0 || x >= L0->width || y >= L0->height)
        return 0.0f;
    return obs_image_f32_row(L0, y)[x];
}

/* One row. hq, ortho and use_mip are compile-time constants at the specialised call sites below
 * (the branches on them then vanish from the tap loop); the arithmetic is the same for all. */
static inline __attribute__((always_inline)) void sao_row_impl(const ao_i_sao_job *J, int task, const int hq,
                                                              const int ortho, const int use_mip)
{
    const ao_sao_constants *k = J->k;
    const obs_image_f32 *L0 = &J->levels[0];
    const float *base = L0->data;
    int row, i0, i1, slot;
    ao_i_sao_segment(J, task, &row, &i0, &i1, &slot);
    const int gy = J->ry0 + row;
    float *out = obs_image_f32_row(J->ao, row);
    int64_t n_bg = 0, n_degen = 0, n_minr = 0;
    const float r2 = k->radius2, bias = k->bias, eps = k->epsilon, inv_r2 = k->inv_radius2;
    const int N = k->num_samples, lmo = k->log_max_offset, max_mip = k->max_mip;
    const float *zrow = obs_image_f32_row(L0, gy);
    /* ssDiskRadius = -projScale * radius / C.z (perspective); orthographic: projScale * radius */
    const float disk_num = !ortho ? -k->proj_scale * k->radius : k->proj_scale * k->radius;

    for (int i = i0; i < i1; i++) {
        const int gx = J->rx0 + i;
        /* ---- Centre: ssC = ivec2(gl_FragCoord.xy); z = texelFetch(CSZ, ssC, 0); C = csPos(ssC, z) ---- */
        const float z = zrow[gx];
        if (z == 0.0f) { /* background: if (z == 0.0) { result = vec2(1.0, 0.0); return; } */
            out[i] = 1.0f;
            n_bg++;
            continue;
        }
        float C[3];
        cs_pos(k, ortho, gx, gy, z, C);
        /* ---- Normal ---- */
        float n[3];
        if (!k->normals_from_gbuffer) {
            /* nC = normalize(cross(dFdxFine(C), dFdyFine(C))): fine derivatives within the GL 2x2
             * quad, dFdx = C(x|1, y) - C(x&~1, y), dFdy = C(x, y|1) - C(x, y&~1), each C computed by
             * its own lane from its own texel (background lanes: z = 0, so C = 0). */
            const int xa = gx & ~1, xb = gx | 1, ya = gy & ~1, yb = gy | 1;
            float Pa[3], Pb[3], dx[3], dy[3];
            cs_pos(k, ortho, xa, gy, csz_at(L0, xa, gy), Pa);
            cs_pos(k, ortho, xb, gy, csz_at(L0, xb, gy), Pb);
            dx[0] = Pb[0] - Pa[0];
            dx[1] = Pb[1] - Pa[1];
            dx[2] = Pb[2] - Pa[2];
            cs_pos(k, ortho, gx, ya, csz_at(L0, gx, ya), Pa);
            cs_pos(k, ortho, gx, yb, csz_at(L0, gx, yb), Pb);
            dy[0] = Pb[0] - Pa[0];
            dy[1] = Pb[1] - Pa[1];
            dy[2] = Pb[2] - Pa[2];
            float c[3] = {dx[1] * dy[2] - dx[2] * dy[1], dx[2] * dy[0] - dx[0] * dy[2], dx[0] * dy[1] - dx[1] * dy[0]};
            float l2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
            if (hq) {
                /* G3D AmbientOcclusion_AO.pix: reject normals across depth discontinuities,
                 * if (dot(n_C, n_C) > square(C.z * C.z * 0.00006)) visibility = 1 */
                float t = C[2] * C[2] * 0.00006f;
                if (l2 > t * t) {
                    out[i] = 1.0f;
                    n_degen++;
                    continue;
                }
            }
            /* A zero or non-finite cross product normalises to NaN on a GPU, every tap's
             * max((vn - bias)/(eps + vv), 0) then yields 0 (x86 max semantics) and A = 1. */
            if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
                out[i] = 1.0f;
                n_degen++;
                continue;
            }
            float inv = 1.0f / sqrtf(l2); /* normalize(v) = v * inversesqrt(dot(v, v)) */
            n[0] = c[0] * inv;
            n[1] = c[1] * inv;
            n[2] = c[2] * inv;
        } else {
            /* G-buffer normal (view space, y up: the same axes as camera space), normalised */
            const int y = k->full_height - 1 - gy;
            float a = obs_image_f32_row(J->in->normal[0], y)[gx], b = obs_image_f32_row(J->in->normal[1], y)[gx],
                  c = obs_image_f32_row(J->in->normal[2], y)[gx];
            float l2 = a * a + b * b + c * c;
            if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
                out[i] = 1.0f;
                n_degen++;
                continue;
            }
            float inv = 1.0f / sqrtf(l2);
            n[0] = a * inv;
            n[1] = b * inv;
            n[2] = c * inv;
        }
        /* ---- Per-pixel spin and screen-space disk radius ---- */
        const float spin = ao_sao_spin(gx, gy);
        const float disk = !ortho ? disk_num / C[2] : disk_num;
        if (hq && disk <= 3.0f) { /* G3D: if (ssDiskRadius <= MIN_RADIUS) visibility = 1 */
            out[i] = 1.0f;
            n_minr++;
            continue;
        }
        const float angular = hq ? 1.0f * (1.0f - 0.35f) + maxf(0.0f, 1.5f * n[2]) * 0.35f : 1.0f;
        /* ---- Taps ---- */
        float sum = 0.0f;
        for (int t = 0; t < N; t++) {
            /* tapLocation: alpha = (i + 0.5) / N; angle = alpha * (NUM_SPIRAL_TURNS * 6.28) + spin
             * (alpha and alpha * (tau * 6.28) are the per-tap constants of J) */
            const float angle = J->alpha_angle[t] + spin;
            float ssR = J->alpha[t] * disk;
            if (hq)
                ssR = maxf(0.75f, ssR); /* G3D: "Ensure that the taps are at least 1 pixel away" */
            float cs, sn;
            cos_sin_inline(angle, &cs, &sn); /* ao_i_cos_sin */
            /* ssP = ivec2(ssR * unitOffset) + ssC  (truncation toward zero) */
            const int px = trunc_to_int(ssR * cs) + gx, py = trunc_to_int(ssR * sn) + gy;
            /* mipLevel = clamp(int(floor(log2(ssR))) - LOG_MAX_OFFSET, 0, MAX_MIP_LEVEL) */
            int mip = 0;
            if (use_mip && ssR >= 1.0f) { /* below 1 px, floor(log2) - 3 < 0 anyway */
                const int m = ao_i_floor_log2f(ssR) - lmo;
                mip = m < 0 ? 0 : m > max_mip ? max_mip : m;
            }
            /* mipP = clamp(ssP >> mip, 0, max(size_0 >> mip, 1) - 1); P.z = texelFetch(CSZ, mipP, mip) */
            int mx = px < 0 ? 0 : px >> mip, my = py < 0 ? 0 : py >> mip;
            mx = mx > J->lvl_wm1[mip] ? J->lvl_wm1[mip] : mx;
            my = my > J->lvl_hm1[mip] ? J->lvl_hm1[mip] : my;
            const float zq = base[J->lvl_off[mip] + my * J->lvl_stride[mip] + mx];
            /* Q at the full-resolution tap pixel centre */
            float Q[3];
            cs_pos(k, ortho, px, py, zq, Q);
            const float v0 = Q[0] - C[0], v1 = Q[1] - C[1], v2 = Q[2] - C[2];
            const float vv = v0 * v0 + v1 * v1 + v2 * v2;
            const float vn = v0 * n[0] + v1 * n[1] + v2 * n[2];
            if (!hq) {
                /* falloff B: f = max(r2 - vv, 0); f * f * f * max((vn - bias) / (epsilon + vv), 0) */
                const float f = maxf(r2 - vv, 0.0f);
                sum += f * f * f * maxf((vn - bias) / (eps + vv), 0.0f);
            } else {
                /* HIGH_QUALITY: f = max(1 - vv * invRadius2, 0); f * max((vn - bias) * rsqrt(eps + vv), 0),
                 * times the angular adjustment lerp(1, max(0, 1.5 n_C.z), 0.35) */
                const float f = maxf(1.0f - vv * inv_r2, 0.0f);
                sum += f * maxf((vn - bias) * (1.0f / sqrtf(eps + vv)), 0.0f) * angular;
            }
        }
        float A;
        if (!hq) {
            /* A = max(0, 1 - sum * intensity * (5 / (r2 * r2 * r2 * N))) */
            A = maxf(0.0f, 1.0f - sum * k->intensity * k->final_scale);
        } else {
            /* A = pow(max(0, 1 - sqrt(sum * (3 / N))), intensity); fade in above MIN_RADIUS:
             * visibility = lerp(1, A, saturate(ssDiskRadius - MIN_RADIUS)) */
            A = powf(maxf(0.0f, 1.0f - sqrtf(sum * k->final_scale)), k->intensity);
            float s = disk - 3.0f;
            s = s < 0.0f ? 0.0f : s > 1.0f ? 1.0f : s;
            A = 1.0f * (1.0f - s) + A * s;
        }
        out[i] = A == A ? A : 1.0f; /* cannot be NaN (every step above is guarded); belt and braces */
    }
    J->counts[slot][0] = n_bg;
    J->counts[slot][1] = n_degen;
    J->counts[slot][2] = n_minr;
}

void ao_i_sao_row_scalar(const ao_i_sao_job *J, int task)
{
    const ao_sao_constants *k = J->k;
    const int hq = k->variant == AO_SAO_VARIANT_G3D_HQ, mip = k->max_mip > 0;
    if (k->orthographic)
        sao_row_impl(J, task, hq, 1, mip);
    else if (!hq && !mip)
        sao_row_impl(J, task, 0, 0, 0);
    else if (!hq)
        sao_row_impl(J, task, 0, 0, 1);
    else if (!mip)
        sao_row_impl(J, task, 1, 0, 0);
    else
        sao_row_impl(J, task, 1, 0, 1);
}

int ao_i_sao_isa_available(ao_i_sao_isa isa)
{
    switch (isa) {
    case AO_I_SAO_ISA_AUTO:
    case AO_I_SAO_ISA_SCALAR: return 1;
    case AO_I_SAO_ISA_AVX2:
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
        return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
        return 0;
#endif
    case AO_I_SAO_ISA_AVX512:
#if defined(AO_I_SAO_HAVE_AVX512)
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") ? 1 : 0;
#else
        return 0;
#endif
    default: return 0;
    }
}

typedef struct sao_pool_job {
    const ao_i_sao_job *J;
    ao_i_sao_isa isa;
} sao_pool_job;

static void sao_row_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const sao_pool_job *P = (const sao_pool_job *)user;
#if defined(AO_I_SAO_HAVE_AVX512)
    if (P->isa == AO_I_SAO_ISA_AVX512) {
        ao_i_sao_row_avx512(P->J, (int)task);
        return;
    }
#endif
#if defined(OBS_HAVE_AVX2)
    if (P->isa == AO_I_SAO_ISA_AVX2) {
        ao_i_sao_row_avx2(P->J, (int)task);
        return;
    }
#endif
    ao_i_sao_row_scalar(P->J, (int)task);
}

/* ================================================================================================
 * The blur (GL coordinates)
 * ============================================================================================== */

void ao_i_sao_blur_row_scalar(const ao_i_sao_blur_job *J, int task)
{
    const float *g = ao_sao_blur_gaussian;
    const int gy = J->dy0 + (int)task;
    float *o = obs_image_f32_row(J->dst, (int)task);
    const float *zrow = obs_image_f32_row(J->z, gy);
    const float *arow = obs_image_f32_row(J->a, gy - J->ay0);
    for (int i = 0; i < J->dst->width; i++) {
        const int gx = J->dx0 + i;
        /* c = texelFetch(src, p, 0).rg = (A, key) */
        const float ca = arow[gx - J->ax0], cz = zrow[gx];
        if (cz == 0.0f) { /* if (c.g == 0.0) { result = c; return; } */
            o[i] = ca;
            continue;
        }
        float sum = ca * g[0], wsum = g[0];
        for (int r = -AO_SAO_BLUR_RADIUS; r <= AO_SAO_BLUR_RADIUS; r++) {
            if (r == 0)
                continue;
            /* t = texelFetch(src, clamp(p + axis * (r * SCALE), 0, size - 1), 0).rg */
            int tx = gx, ty = gy;
            if (J->axis == 0) {
                tx = gx + r * J->stride;
                tx = tx < 0 ? 0 : tx > J->W - 1 ? J->W - 1 : tx;
            } else {
                ty = gy + r * J->stride;
                ty = ty < 0 ? 0 : ty > J->H - 1 ? J->H - 1 : ty;
            }
            const float ta = obs_image_f32_row(J->a, ty - J->ay0)[tx - J->ax0];
            const float tz = obs_image_f32_row(J->z, ty)[tx];
            /* w = (0.3 + g[|r|]) * max(0, 1 - edgeK * |t.key - c.key|) */
            const float w = (0.3f + g[r < 0 ? -r : r]) * maxf(0.0f, 1.0f - J->edge_k * fabsf(tz - cz));
            sum += ta * w;
            wsum += w;
        }
        o[i] = sum / (wsum + 0.0001f);
    }
}

typedef struct blur_pool_job {
    const ao_i_sao_blur_job *J;
    int avx2;
} blur_pool_job;

static void blur_row_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const blur_pool_job *P = (const blur_pool_job *)user;
#if defined(OBS_HAVE_AVX2)
    if (P->avx2) {
        ao_i_sao_blur_row_avx2(P->J, (int)task);
        return;
    }
#endif
    ao_i_sao_blur_row_scalar(P->J, (int)task);
}

static ao_i_sao_isa auto_isa(void)
{
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return AO_I_SAO_ISA_SCALAR;
    if (!(env && !strcmp(env, "avx2")) && ao_i_sao_isa_available(AO_I_SAO_ISA_AVX512))
        return AO_I_SAO_ISA_AVX512;
    if (ao_i_sao_isa_available(AO_I_SAO_ISA_AVX2))
        return AO_I_SAO_ISA_AVX2;
    return AO_I_SAO_ISA_SCALAR;
}

static void blur_run(obs_pool *pool, const obs_image_f32 *a, int ax0, int ay0, const obs_image_f32 *z,
                     obs_image_f32 *dst, int dx0, int dy0, int axis, int stride, float edge_k, ao_i_sao_isa path)
{
    ao_i_sao_blur_job J = {a, ax0, ay0, z, dst, dx0, dy0, z->width, z->height, axis, stride, edge_k};
    blur_pool_job P = {&J, path == AO_I_SAO_ISA_AVX2 || path == AO_I_SAO_ISA_AVX512}; /* AVX512: AVX2's blur */
    obs_pool_run(pool, dst->height, blur_row_task, &P);
}

obs_status ao_sao_blur_gl(obs_context *ctx, obs_pool *pool, const obs_image_f32 *ao, const obs_image_f32 *csz,
                          int stride, float edge_k, obs_image_f32 *out)
{
    if (!ao || !csz || !out || !ao->data || !csz->data || !out->data || ao->data == out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_blur_gl: NULL or aliased planes");
    if (ao->width != csz->width || ao->height != csz->height || out->width != ao->width || out->height != ao->height ||
        ao->width < 1 || ao->height < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_blur_gl: planes must have the same, non-zero size");
    if (stride < 1 || stride > 64 || !(edge_k >= 0.0f) || !isfinite(edge_k))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_sao_blur_gl: stride %d in [1, 64], edge_k %g finite >= 0",
                         stride, (double)edge_k);
    obs_image_f32 tmp = {0};
    obs_status st = obs_image_f32_alloc(ctx, ao->width, ao->height, &tmp);
    if (st != OBS_STATUS_OK)
        return st;
    const ao_i_sao_isa path = auto_isa();
    blur_run(pool, ao, 0, 0, csz, &tmp, 0, 0, 0, stride, edge_k, path);
    blur_run(pool, &tmp, 0, 0, csz, out, 0, 0, 1, stride, edge_k, path);
    obs_image_f32_free(&tmp);
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

static obs_status check_constants(obs_context *ctx, const ao_input *in, const ao_sao_constants *k)
{
    if (!k)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: NULL constants");
    if (k->full_width != in->width || k->full_height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: constants for a %dx%d buffer, input is %dx%d",
                         k->full_width, k->full_height, in->width, in->height);
    if (k->num_samples < 1 || k->num_samples > AO_SAO_MAX_SAMPLES || k->max_mip < 0 || k->max_mip > AO_SAO_MAX_MIP ||
        k->log_max_offset < 0 || k->log_max_offset > 30 || k->blur_stride < 1 || k->blur_stride > 64 ||
        (unsigned)k->variant >= AO_SAO_VARIANT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: constants out of range (samples %d, max mip %d, "
                         "log max offset %d, blur stride %d, variant %d)", k->num_samples, k->max_mip,
                         k->log_max_offset, k->blur_stride, k->variant);
    for (int i = 0; i < 4; i++)
        if (!isfinite(k->proj_info[i]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: projInfo[%d] is not finite", i);
    if (!isfinite(k->proj_scale) || !(k->proj_scale > 0.0f) || !isfinite(k->final_scale) || !isfinite(k->edge_k))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: projScale, final scale and edgeK must be finite");
    if (k->normals_from_gbuffer && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sao: normals from the G-buffer were asked for, but the input has none");
    return OBS_STATUS_OK;
}

obs_status ao_i_sao_compute_isa(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_constants *k,
                                obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats, ao_i_sao_isa isa,
                                ao_i_sao_isa *isa_used)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = check_constants(ctx, in, k);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sao: output planes must be %dx%d (the window)", in->w,
                         in->h);
    if (stats)
        memset(stats, 0, sizeof *stats);
    const int W = in->width, H = in->height;
    const ao_i_sao_isa path = isa == AO_I_SAO_ISA_AUTO ? auto_isa() : isa;
    if ((unsigned)path >= AO_I_SAO_ISA_COUNT || !ao_i_sao_isa_available(path))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "sao: the %s path is not available in this build or CPU",
                         path == AO_I_SAO_ISA_AVX2 ? "avx2" : path == AO_I_SAO_ISA_AVX512 ? "avx512" : "requested");
    if (isa_used)
        *isa_used = path;
    obs_image_f32 levels[AO_SAO_MAX_MIP + 1];
    memset(levels, 0, sizeof levels);
    obs_image_f32 raw = {0}, hpass = {0}, vpass = {0};
    int64_t(*counts)[3] = NULL;
    ao_i_sao_job *job = NULL;

    /* ---- 0. The workspace: the context's, or a fresh one (parked in the context at the end) ---- */
    sao_workspace *ws = (sao_workspace *)obs_context_scratch_take(ctx, &sao_workspace_key);
    if (!ws && !(ws = (sao_workspace *)calloc(1, sizeof *ws)))
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sao: out of memory");

    /* ---- 1. CSZ (GL row order), level 0 of the pyramid's block ---- */
    double t0 = obs_time_now();
    st = pyramid_alloc(ctx, W, H, k->max_mip, levels, &ws->pyramid, &ws->pyramid_cap);
    if (st == OBS_STATUS_OK)
        st = ao_sao_csz_from_input(ctx, pool, in, &levels[0]);
    const obs_image_f32 csz = levels[0];
    double t1 = obs_time_now();
    /* ---- 2. MIP pyramid (levels the taps can select), each level from the previous one ---- */
    if (st == OBS_STATUS_OK)
        for (int l = 1; l <= k->max_mip; l++) {
            mip_job M = {&levels[l - 1], &levels[l]};
            obs_pool_run(pool, levels[l].height, mip_row, &M);
        }
    double t2 = obs_time_now();

    /* ---- 3. AO over the window plus the blur's reach (GL coordinates) ---- */
    const int m = k->blur ? k->blur_radius * k->blur_stride : 0;
    const int wx0 = in->x0, wx1 = in->x0 + in->w - 1;          /* window columns */
    const int wy0 = H - in->y0 - in->h, wy1 = H - 1 - in->y0;  /* window rows, GL */
    const int rx0 = wx0 - m < 0 ? 0 : wx0 - m, rx1 = wx1 + m > W - 1 ? W - 1 : wx1 + m;
    const int ry0 = wy0 - m < 0 ? 0 : wy0 - m, ry1 = wy1 + m > H - 1 ? H - 1 : wy1 + m;
    const int rw = rx1 - rx0 + 1, rh = ry1 - ry0 + 1;
    const int seg_w = SAO_SEG_W > 0 ? SAO_SEG_W : (rw + 7) & ~7, seg_h = SAO_SEG_H;
    const int segs_x = (rw + seg_w - 1) / seg_w;
    if (st == OBS_STATUS_OK) {
        const int wh[3][2] = {{rw, rh}, {in->w, rh}, {in->w, in->h}};
        obs_image_f32 planes[3];
        memset(planes, 0, sizeof planes);
        st = work_planes_alloc(ctx, k->blur ? 3 : 1, wh, planes, &ws->work, &ws->work_cap);
        raw = planes[0];
        hpass = planes[1];
        vpass = planes[2];
    }
    if (st == OBS_STATUS_OK) {
        if (!ws->counts || (size_t)rh * (size_t)segs_x > ws->counts_cap) {
            free(ws->counts);
            ws->counts = (int64_t(*)[3])malloc((size_t)rh * (size_t)segs_x * sizeof *ws->counts);
            ws->counts_cap = ws->counts ? (size_t)rh * (size_t)segs_x : 0;
        }
        counts = ws->counts;
        if (!counts)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "sao: out of memory");
    }
    if (st == OBS_STATUS_OK) {
        job = &ws->job;
        memset(job, 0, sizeof *job);
        job->k = k;
        job->levels = levels;
        for (int l = 0; l <= k->max_mip; l++) {
            job->lvl_off[l] = (int32_t)(levels[l].data - levels[0].data);
            job->lvl_stride[l] = (int32_t)levels[l].stride;
            job->lvl_wm1[l] = levels[l].width - 1;
            job->lvl_hm1[l] = levels[l].height - 1;
        }
        job->in = in;
        job->rx0 = rx0;
        job->ry0 = ry0;
        job->ao = &raw;
        job->counts = counts;
        job->seg_w = seg_w;
        job->seg_h = seg_h;
        job->segs_x = segs_x;
        for (int t = 0; t < k->num_samples; t++) {
            job->alpha[t] = ((float)t + 0.5f) * k->inv_num_samples;
            job->alpha_angle[t] = job->alpha[t] * k->turns_angle;
        }
        sao_pool_job P = {job, path};
        obs_pool_run(pool, (int64_t)rh * segs_x, sao_row_task, &P);
    }
    double t3 = obs_time_now();

    /* ---- 4. Blur: horizontal over (window columns x region rows), then vertical over the window ---- */
    const obs_image_f32 *final = NULL;
    int fx0 = rx0, fy0 = ry0;
    if (st == OBS_STATUS_OK && k->blur) {
        {
            blur_run(pool, &raw, rx0, ry0, &csz, &hpass, wx0, ry0, 0, k->blur_stride, k->edge_k, path);
            blur_run(pool, &hpass, wx0, ry0, &csz, &vpass, wx0, wy0, 1, k->blur_stride, k->edge_k, path);
            final = &vpass;
            fx0 = wx0;
            fy0 = wy0;
        }
    } else if (st == OBS_STATUS_OK) {
        final = &raw;
    }
    double t4 = obs_time_now();

    /* ---- 5. Write the window in our row order ---- */
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < in->h; y++) {
            const int gy = H - 1 - (in->y0 + y);
            memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, gy - fy0) + (wx0 - fx0), sizeof(float) * in->w);
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(&raw, gy - ry0) + (wx0 - rx0),
                       sizeof(float) * in->w);
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rw * rh;
            for (int r = 0; r < rh * segs_x; r++) {
                stats->pixels_background += counts[r][0];
                stats->pixels_degenerate_normal += counts[r][1];
                stats->pixels_below_min_radius += counts[r][2];
            }
            stats->seconds_csz = t1 - t0;
            stats->seconds_mip = t2 - t1;
            stats->seconds_ao = t3 - t2;
            stats->seconds_blur = t4 - t3;
        }
    }
    obs_context_scratch_put(ctx, &sao_workspace_key, ws, sao_workspace_destroy);
    return st;
}

obs_status ao_sao_compute_constants(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_constants *k,
                                    obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats)
{
    return ao_i_sao_compute_isa(ctx, pool, in, k, out, out_raw, stats, AO_I_SAO_ISA_AUTO, NULL);
}

obs_status ao_sao_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_params *params,
                          obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_sao_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    ao_sao_constants k = ao_sao_constants_from_params(params, in);
    return ao_sao_compute_constants(ctx, pool, in, &k, out, out_raw, stats);
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_sao_variant) == sizeof(int) && sizeof(ao_sao_normals) == sizeof(int),
               "ENUM params are int-sized");
_Static_assert(sizeof(ao_sao_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

static const char *const sao_variant_names[] = {"hpg12", "g3d-hq", NULL};
static const char *const sao_normals_names[] = {"depth", "gbuffer", NULL};

#define SAO_F(field) offsetof(ao_sao_params, field)
static const ao_param_desc sao_param_descs[] = {
    {"variant", AO_PARAM_ENUM, SAO_F(variant), 0, 0, sao_variant_names,
     "hpg12 (falloff B) or g3d-hq (the later G3D HIGH_QUALITY estimator)"},
    {"radius", AO_PARAM_FLOAT, SAO_F(radius), 1e-6, 1e6, NULL, "world-space radius r (m)"},
    {"bias", AO_PARAM_FLOAT, SAO_F(bias), -1e30, 1e30, NULL, "bias (m)"},
    {"intensity", AO_PARAM_FLOAT, SAO_F(intensity), 0, 1e30, NULL, "intensity (g3d-hq: the exponent)"},
    {"epsilon", AO_PARAM_FLOAT, SAO_F(epsilon), 1e-30, 1e30, NULL, "epsilon in (vn - bias)/(vv + epsilon)"},
    {"samples", AO_PARAM_INT, SAO_F(samples), 1, AO_SAO_MAX_SAMPLES, NULL,
     "taps N (NUM_SAMPLES); without --turns, the turns come from the table"},
    {"turns", AO_PARAM_INT, SAO_F(spiral_turns), 0, 1000000, NULL,
     "spiral turns (NUM_SPIRAL_TURNS); 0 = McGuire's minimum-discrepancy table for N"},
    {"max-mip", AO_PARAM_INT, SAO_F(max_mip_level), 0, AO_SAO_MAX_MIP, NULL,
     "deepest depth MIP level a tap may read (0 = none)"},
    {"log-max-offset", AO_PARAM_INT, SAO_F(log_max_offset), 0, 30, NULL, "LOG_MAX_OFFSET of the MIP selection"},
    {"normals", AO_PARAM_ENUM, SAO_F(normals), 0, 0, sao_normals_names,
     "depth: face normals from depth (reference); gbuffer: the G-buffer's"},
    {"blur", AO_PARAM_BOOL, SAO_F(blur), 0, 1, NULL, "the separable bilateral blur (R = 4), SAO_blur.pix"},
    {"blur-stride", AO_PARAM_INT, SAO_F(blur_stride), 1, 64, NULL, "blur tap spacing (px)"},
    {"edge-sharpness", AO_PARAM_FLOAT, SAO_F(edge_sharpness), 0, 1e30, NULL, "blur EDGE_SHARPNESS"},
    {"blur-key-far", AO_PARAM_FLOAT, SAO_F(blur_key_far), 1e-30, 1e30, NULL,
     "blur key scale (m): edgeK = sharpness * 2000 / this"},
};
#undef SAO_F

static void m_default(void *p) { *(ao_sao_params *)p = ao_sao_params_default(); }
static int m_preset(const char *name, void *p) { return ao_sao_params_preset(name, (ao_sao_params *)p); }
static void m_adjust(void *p, const unsigned char *given)
{
    /* --samples without --turns: the minimum-discrepancy table's turns (documented in --list). */
    const ptrdiff_t i_samples = ao_method_param(&ao_i_method_sao, "samples") - sao_param_descs;
    const ptrdiff_t i_turns = ao_method_param(&ao_i_method_sao, "turns") - sao_param_descs;
    if (given[i_samples] && !given[i_turns])
        ((ao_sao_params *)p)->spiral_turns = AO_SAO_TURNS_FROM_TABLE;
}
static obs_status m_validate(obs_context *ctx, const void *p) { return ao_sao_params_validate(ctx, (const ao_sao_params *)p); }
static int m_to_string(const void *p, char *buf, size_t size) { return ao_sao_params_to_string((const ao_sao_params *)p, buf, size); }
static void m_set_samples(void *p, int n)
{
    ((ao_sao_params *)p)->samples = n;
    ((ao_sao_params *)p)->spiral_turns = AO_SAO_TURNS_FROM_TABLE;
}
static void m_set_radius(void *p, float r) { ((ao_sao_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_sao_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_sao_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* HPG12 estimates obscurance with falloff B, (1 - d^2/r^2)^3; G3D HQ the linear one. */
    return ((const ao_sao_params *)p)->variant == AO_SAO_VARIANT_G3D_HQ ? "obs-sao-linear" : "obs-sao";
}
static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_sao_constants K = ao_sao_constants_from_params((const ao_sao_params *)p, in);
    return snprintf(buf, size,
                    "{\"projInfo\": [%.9g, %.9g, %.9g, %.9g], \"projScale\": %.9g, \"radius2\": %.9g, "
                    "\"bias\": %.9g, \"intensity\": %.9g, \"epsilon\": %.9g, \"NUM_SAMPLES\": %d, "
                    "\"NUM_SPIRAL_TURNS\": %d, \"inv_num_samples\": %.9g, \"turns_angle\": %.9g, "
                    "\"final_scale\": %.9g, \"max_mip\": %d, \"LOG_MAX_OFFSET\": %d, \"blur\": %d, "
                    "\"blur_R\": %d, \"blur_stride\": %d, \"blur_edgeK\": %.9g, "
                    "\"blur_gaussian\": [%.9g, %.9g, %.9g, %.9g, %.9g]}",
                    (double)K.proj_info[0], (double)K.proj_info[1], (double)K.proj_info[2], (double)K.proj_info[3],
                    (double)K.proj_scale, (double)K.radius2, (double)K.bias, (double)K.intensity, (double)K.epsilon,
                    K.num_samples, K.num_spiral_turns, (double)K.inv_num_samples, (double)K.turns_angle,
                    (double)K.final_scale, K.max_mip, K.log_max_offset, K.blur, K.blur_radius, K.blur_stride,
                    (double)K.edge_k, (double)ao_sao_blur_gaussian[0], (double)ao_sao_blur_gaussian[1],
                    (double)ao_sao_blur_gaussian[2], (double)ao_sao_blur_gaussian[3], (double)ao_sao_blur_gaussian[4]);
}
static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_sao_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_sao_compute(ctx, pool, in, (const ao_sao_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_csz + s.seconds_mip;
        stats->seconds_kernel = s.seconds_ao;
        stats->seconds_blur = s.seconds_blur;
    }
    return st;
}

const ao_method ao_i_method_sao = {
    .name = "sao",
    .title = "Scalable Ambient Obscurance [McGuire12]: the HPG12 shader as the llvmpipe peer runs it",
    .doc = "docs/ao/sao.md",
    .params_size = sizeof(ao_sao_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = sao_param_descs,
    .param_count = (int)(sizeof sao_param_descs / sizeof sao_param_descs[0]),
    .params_adjust = m_adjust,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* raw AO is exactly 1 on a plane; the blur divides by (wsum + 1e-4) (SAO_blur.pix), which
     * gives 1 - 5.9e-5 for a constant 1 with all weights, and down to 1 - 6.8e-4 on a tilted plane
     * where the depth key leaves little weight (measured: test_ao_methods.c) */
    .flat_tolerance = 1e-3f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
