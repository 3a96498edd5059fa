/* sss_internal.h: cross-file internals of the SSS module (prefix sss_i_). Not installed.
 *
 * The float kernel (sss_batch.c scalar path, sss_batch_avx2.c AVX2 path) is written as a plain
 * sequence of IEEE float operations (+, -, *, /, sqrtf, compare/select, min/max with the SSE
 * MAXPS/MINPS semantics), so that a GLSL port can reproduce it within rounding and so that the
 * scalar and AVX2 paths give identical bits (no FMA: the build has -ffp-contract=off, and -mavx2
 * does not enable FMA). docs/sss/model.md has the details. */
#ifndef SSS_INTERNAL_H
#define SSS_INTERNAL_H

#include "sss.h"

#include <stdint.h>
#include <string.h>

/* n_i* guard (sss.md 1.3, "Recommended: use n_i when |n_i x x| < eps r"): below this relative
 * size of n_i x (x_o - x_i) the modified tangent-plane normal is n_i. Same value in the double
 * reference and the float kernel so that both take the same branch (except within float
 * rounding of the threshold). Covers r = 0 and x_o - x_i parallel to n_i. */
#define SSS_I_PARALLEL_EPS 1e-4

/* Distance floor of the dipole sources, in units of D (deviation, docs/sss/model.md "Guards"):
 * d_r and d_v are at least 0.01 D. Only reached when r < 0.01 D and mu0 < 0.01 (front-lit,
 * a refracted ray almost tangent to the exit plane: curved or creased geometry), or when x_o
 * lies on the virtual source. It keeps 1/d^3 finite in float for D >= 1e-9 scene units. It is
 * a much smaller floor than Jensen 2001's "minimum distance of 1/sigma_t'" ([Jensen01] sec. 4,
 * sss.md 2), which would change the reference values of sss.md 1.2. */
#define SSS_I_DIST_FLOOR_D 0.01

/* 1/(4 pi^2) and 1/(4 pi), 1/pi */
#define SSS_I_INV_4PI2 0.025330295910584444
#define SSS_I_INV_4PI 0.07957747154594767
#define SSS_I_INV_PI 0.3183098861837907

/* ---- float helpers: the exact operations of the kernel ---------------------------------------- */

/* max/min with SSE semantics: MAXPS(a, b) = a > b ? a : b (b when either is NaN). */
static inline float sss_i_maxf(float a, float b) { return a > b ? a : b; }
static inline float sss_i_minf(float a, float b) { return a < b ? a : b; }

/* The kernel's own exp (docs/sss/model.md "Float exp"): Cody-Waite reduction x = n ln2 + r,
 * |r| <= ln2/2, n = round-to-nearest-even(x log2 e) by the 1.5*2^23 trick, e^r by the degree-7
 * Taylor polynomial in Horner form, times 2^n built from its bits. Domain: x < -87 -> 0 (the true
 * value is < 1.7e-38), x > 88 clamped to 88. Measured max relative error vs double exp on
 * [-87, 88]: 1.0e-7 (about 1.7 ulp; test sss_float_exp_error_is_bounded asserts SSS_I_EXPF_MAX_REL). */
#define SSS_I_EXPF_MAX_REL 2e-7
#define SSS_I_EXPF_LOG2E 1.44269504088896341f
#define SSS_I_EXPF_MAGIC 12582912.0f       /* 1.5 * 2^23 */
#define SSS_I_EXPF_LN2_HI 0.693145751953125f /* 0x3f317200: 15 significant bits, n*hi exact */
#define SSS_I_EXPF_LN2_LO 1.42860676533018704e-6f
#define SSS_I_EXPF_C7 (1.0f / 5040.0f)
#define SSS_I_EXPF_C6 (1.0f / 720.0f)
#define SSS_I_EXPF_C5 (1.0f / 120.0f)
#define SSS_I_EXPF_C4 (1.0f / 24.0f)
#define SSS_I_EXPF_C3 (1.0f / 6.0f)
#define SSS_I_EXPF_C2 0.5f

static inline float sss_i_expf(float x)
{
    if (x < -87.0f)
        return 0.0f;
    x = sss_i_minf(x, 88.0f);
    /* range reduction: n = rint(x log2 e), r = x - n ln2 (two-part ln2, Cody-Waite) */
    const float t = x * SSS_I_EXPF_LOG2E;
    const float n = (t + SSS_I_EXPF_MAGIC) - SSS_I_EXPF_MAGIC;
    const float r = (x - n * SSS_I_EXPF_LN2_HI) - n * SSS_I_EXPF_LN2_LO;
    /* e^r, degree-7 Taylor polynomial, Horner */
    float p = SSS_I_EXPF_C7;
    p = p * r + SSS_I_EXPF_C6;
    p = p * r + SSS_I_EXPF_C5;
    p = p * r + SSS_I_EXPF_C4;
    p = p * r + SSS_I_EXPF_C3;
    p = p * r + SSS_I_EXPF_C2;
    p = p * r + 1.0f;
    p = p * r + 1.0f;
    /* 2^n from its bits (n in [-126, 127]) */
    const int32_t ni = (int32_t)n;
    const uint32_t bits = (uint32_t)(ni + 127) << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/* The float kernel for samples [begin, end) of b (scalar path). */
void sss_i_eval_scalar(const sss_gpu_constants *g, const float xo[3], const float no[3], const sss_batch *b,
                       int with_t12, int begin, int end);
/* The AVX2 kernel for samples [begin, begin + 8*groups): 8 samples per vector. Defined only when
 * OBS_HAVE_AVX2. */
void sss_i_eval_avx2(const sss_gpu_constants *g, const float xo[3], const float no[3], const sss_batch *b,
                     int with_t12, int begin, int groups);

#endif /* SSS_INTERNAL_H */
