/* vol_light_internal.h: the light volume's row kernels shared by vol_light.c (scalar) and
 * vol_light_avx2.c (AVX2, compiled with -mavx2, no FMA), for its tests (not installed; prefix
 * vol_i_lv_).
 *
 * All forms of each kernel (scalar, AVX2, AVX-512F) perform the same IEEE operations in the same
 * order per voxel, so they give the same bits (volume_light_avx2_matches_scalar_bit_for_bit,
 * volume_light_avx512_avx2_scalar_bit_for_bit); the transcendental functions (log1p in the
 * classification, exp in tau) give libm's floats in all: the scalar forms call libm; the vector
 * forms evaluate them in double and keep the result where it rounds to libm's float for certain
 * (more than 2^16 ulps from a float midpoint), calling libm lane by lane elsewhere
 * (vol_light_avx2.c, "libm's results"); exp is skipped where its argument is 0 (exp(0) = 1
 * exactly), and an alpha of 0 gives sigma_t 0 without log1p. */
#ifndef VOL_LIGHT_INTERNAL_H
#define VOL_LIGHT_INTERNAL_H

#include "vol.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The transfer function prepared for row classification: point values and RGBA as doubles,
 * padded with one copy of the last point (so that index lo + 1 is always readable). */
typedef struct vol_i_lv_tf {
    int n;                 /* tf->count */
    const double *value;   /* n + 1 */
    const double *rgba[4]; /* n + 1 each, (double) of the float components */
    const vol_tf *tf;      /* the original (the scalar path calls vol_tf_eval on it) */
    double kappa, ref_step;
    double zero_upto;      /* every value v <= zero_upto classifies to RGBA +0 and sigma_t +0 (the
                              points up to it are all +0 bits); -inf when point 0 is not */
    float zero_upto_f;     /* the largest float <= zero_upto (-inf with it): for a float v,
                              v <= zero_upto exactly when v <= zero_upto_f (NaN: neither) */
} vol_i_lv_tf;

/* Classification of n values s[i] (the data's, trilinear at scale 2 and 4):
 *   rgba = vol_tf_eval(tf, s), sigma[i] = (float)(kappa * vol_sigma_from_alpha(rgba[3], ref_step)),
 *   c0/c1/c2[i] = rgba[0..2]. */
void vol_i_lv_classify_scalar(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                              float *c2);
void vol_i_lv_classify_avx2(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                            float *c2);

/* One row of the kernel path (directional light, voxels whose kernels lie inside the previous
 * slice; vol_light.c lv_kernel_init): for iu in [iu0, iu1) of row jv,
 *   sigma_p = bilinear(prev_sigma at (iu + bu + fu, jv + bv + fv)),
 *   tau     = (float)exp(-0.5 * ((double)sigma + (double)sigma_p) * ds),
 *   l       = tau * bilinear(prev_l, same weights),
 *   acc_c   = sum over dj < kH, di < kW (in that order) of K[dj kW + di] * prev_c[(jv + kJ0 + dj) stride + iu + kI0 + di],
 *   c_c     = tau * (acc_c / Ksum) + (1 - tau) * ctf_c,
 * written to the current slice (cur_*[iu]) and the output (out_*[iu * out_stride]). */
typedef struct vol_i_lv_span {
    const float *prev_l, *prev_sigma, *prev_c[3];
    ptrdiff_t stride;                     /* row stride of the slice buffers (prev_*, cur_*) */
    int jv;
    int bu, bv, kI0, kJ0, kW, kH;
    float fu, fv, Ksum;
    const float *K;
    double ds;
    const float *sigma, *ctf[3];          /* the row's classification, index iu */
    float *cur_l, *cur_sigma, *cur_c[3];  /* the current slice's row, index iu */
    float *out_l, *out_c[3];              /* the output at iu = 0 of this row */
    ptrdiff_t out_stride;                 /* output elements between iu and iu + 1 */
} vol_i_lv_span;
void vol_i_lv_span_scalar(const vol_i_lv_span *S, int iu0, int iu1);
void vol_i_lv_span_avx2(const vol_i_lv_span *S, int iu0, int iu1);

/* 1 when the AVX2 kernels run: built with OBS_ENABLE_SIMD, the CPU has AVX2, and the environment's
 * OBS_ISA is not "scalar" (read at each vol_light_volume_build). */
int vol_i_lv_avx2_active(void);

/* The constants of the vector exp and log of the AVX2 and AVX-512F kernels (vol_light_avx2.c
 * lv_exp4 / lv_log4, vol_light_avx512.c lv_exp8: the same operations at two widths):
 * log2(e); ln2 split as ln2_hi (fdlibm e_exp.c, 32 trailing zero bits) + ln2_lo [CodyWaite80]
 * [fdlibm]; the Taylor coefficients 1/k! of exp(r), k = 0..13; LV_GUARD, the double ulps a result
 * must keep from a float midpoint to be rounded as libm's (vol_light_avx2.c, top) [glibcErr]. */
#define VOL_I_LV_LOG2E 1.4426950408889634
#define VOL_I_LV_LN2_HI 6.93147180369123816490e-01
#define VOL_I_LV_LN2_LO 1.90821492927058770002e-10
#define VOL_I_LV_EXP_DEGREE 13
#define LV_GUARD 65536
static const double vol_i_lv_exp_c[VOL_I_LV_EXP_DEGREE + 1] = {
    1.0,           1.0,            1.0 / 2,          1.0 / 6,           1.0 / 24,
    1.0 / 120,     1.0 / 720,      1.0 / 5040,       1.0 / 40320,       1.0 / 362880,
    1.0 / 3628800, 1.0 / 39916800, 1.0 / 479001600,  1.0 / 6227020800.0};

/* The AVX-512F span (vol_light_avx512.c: GCC's #pragma GCC target on x86-64, as ao_sao_avx512.c;
 * other compilers: AVX2 at most). Same bits as the AVX2 and scalar spans. */
#if defined(OBS_HAVE_AVX2) && defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define VOL_I_LV_HAVE_AVX512 1
void vol_i_lv_span_avx512(const vol_i_lv_span *S, int iu0, int iu1);
void vol_i_lv_classify_avx512(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                              float *c2);
#endif
/* The row kernels' instruction set for this build: 0 scalar, 1 AVX2, 2 AVX-512F (the span and
 * the classification). The highest the build and the CPU have, capped by the environment's
 * OBS_ISA: "scalar" 0, "avx2" at most 1 (read at each vol_light_volume_build). */
int vol_i_lv_isa(void);

/* Test hooks (tests/test_volume_light_speed.c) for the guarded exp and log1p of
 * vol_light_avx2.c: for n values (n a multiple of 8), y = the vector evaluation in double before
 * the guard (exp of x; log1p of -a as log(1 - a)), f = the float the kernel uses (libm's bits by
 * construction). Built with AVX2 only; without it they return 0 and write nothing. */
int vol_i_lv_exp_test_avx2(const double *x, int n, double *y, float *f);
int vol_i_lv_log1p_test_avx2(const double *a, int n, double *y);

/* The meshes' extra extinction (vol_occupancy.c, vol.h vol_occluder): sigma_occ per light-volume
 * voxel (layout n, x fastest) = vol_sigma_from_alpha(f, ref_step) (ref_step 0: min(sp)). *out NULL
 * (and OK) when occ is NULL or every f is 0: the build then runs exactly as without it. Checks
 * that the occupancy has the layout (n, sp, org) bit for bit. Returns OK, INVALID_ARGUMENT,
 * OUT_OF_MEMORY. Free *out with obs_aligned_free. */
obs_status vol_i_occ_sigma(obs_context *ctx, const vol_occluder *occ, const int n[3], const double sp[3],
                           const double org[3], float **out);
/* sigma_occ trilinear at world x (clamped to the edge), 0 outside the voxel hull + half a voxel. */
double vol_i_occ_sigma_at(const float *sigma, const int n[3], const double org[3], const double sp[3],
                          const double x[3]);

#ifdef __cplusplus
}
#endif

#endif /* VOL_LIGHT_INTERNAL_H */
