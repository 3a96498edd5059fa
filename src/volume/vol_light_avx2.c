/* vol_light_avx2.c: the light volume's row kernels, 8 voxels of a row at a time (AVX2, compiled
 * with -mavx2 and no FMA; selected at run time by vol_i_lv_avx2_active, OBS_ISA=scalar forces the
 * scalar forms). Each lane performs the scalar form's IEEE operations in the same order
 * (vol_light_internal.h; vol_light.c vol_i_lv_classify_scalar, vol_i_lv_span_scalar), so the two
 * give the same bits (volume_light_avx2_matches_scalar_bit_for_bit). log1p is needed where
 * alpha > 0 and exp where its argument is not 0 (vol_sigma_from_alpha returns 0 for alpha <= 0, and
 * exp(+-0) = 1, C11 F.10.3.1); there they are evaluated 4 lanes at a time in double and rounded to
 * float where that is libm's float for certain, libm lane by lane elsewhere ("libm's results"
 * below; docs/volume/light.md step 10). */
#include "vol_light_internal.h"

#include <immintrin.h>
#include <math.h>
#include <string.h>

/* ---- libm's results, 4 lanes at a time ------------------------------------------------------------ */

/* The kernels round libm's double exp and log1p to float. A vector evaluation of the same function
 * in double gives the same float as libm's whenever both doubles lie on the same side of every
 * float rounding boundary: the float's round-to-nearest boundaries are the midpoints between
 * adjacent floats, the doubles whose low 29 mantissa bits are exactly 2^28 (in any binade of the
 * normal float range). So where our double y is more than LV_GUARD double ulps from such a
 * midpoint, and both evaluations are within LV_GUARD / 2 ulps of the true value, (float)y is
 * libm's float bit for bit; elsewhere (and outside the normal float range) the lane calls libm.
 * Our evaluations err by a few ulps (below); glibc documents exp and log1p within 1 to 2 ulps
 * (glibc manual, "Known Maximum Errors in Math Functions", x86_64); LV_GUARD = 2^16 ulps is four
 * orders of magnitude of slack, and lanes near a midpoint are 2^17 / 2^29 = 2.4e-4 of them. */

/* 1 in the lanes (all-ones) where (float)y may round differently from (float)y' with |y - y'| <
 * LV_GUARD ulps of y: y within LV_GUARD ulps of a float midpoint. y positive and normal. */
static inline __m256i lv_near_midpoint(__m256d y)
{
    const __m256i low = _mm256_and_si256(_mm256_castpd_si256(y), _mm256_set1_epi64x(((long long)1 << 29) - 1));
    const __m256i d = _mm256_sub_epi64(low, _mm256_set1_epi64x((long long)1 << 28));
    /* |d| < LV_GUARD: d + LV_GUARD in [0, 2 LV_GUARD) as an unsigned compare, by a signed one */
    const __m256i e = _mm256_add_epi64(d, _mm256_set1_epi64x(LV_GUARD));
    return _mm256_andnot_si256(_mm256_cmpgt_epi64(_mm256_setzero_si256(), e),
                               _mm256_cmpgt_epi64(_mm256_set1_epi64x(2 * LV_GUARD), e));
}

/* 2^n for integral n (as double) in [-1022, 1023]: the exponent field. */
static inline __m256d lv_pow2(__m256d n)
{
    const __m256i k = _mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(n));
    return _mm256_castsi256_pd(_mm256_slli_epi64(_mm256_add_epi64(k, _mm256_set1_epi64x(1023)), 52));
}

/* exp(x) for x in [-87, 0]: x = n ln2 + r (Cody and Waite's two-part ln2, fdlibm's ln2_hi with
 * 32 trailing zero bits, so n ln2_hi is exact), |r| <= ln2 / 2, exp(r) by its Taylor series to
 * degree 13 (remainder below 0.35^14 / 14! = 4e-18, 2^-57), Horner; then 2^n exactly. Error: a
 * few ulps (r's rounding 2^-55 absolute, Horner's 13 roundings). */
static inline __m256d lv_exp4(__m256d x)
{
    const __m256d n = _mm256_round_pd(_mm256_mul_pd(x, _mm256_set1_pd(VOL_I_LV_LOG2E)),
                                      _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    const __m256d r = _mm256_sub_pd(_mm256_sub_pd(x, _mm256_mul_pd(n, _mm256_set1_pd(VOL_I_LV_LN2_HI))),
                                    _mm256_mul_pd(n, _mm256_set1_pd(VOL_I_LV_LN2_LO)));
    const double *c = vol_i_lv_exp_c;
    __m256d p = _mm256_set1_pd(c[VOL_I_LV_EXP_DEGREE]);
    for (int k = VOL_I_LV_EXP_DEGREE - 1; k >= 0; k--)
        p = _mm256_add_pd(_mm256_mul_pd(p, r), _mm256_set1_pd(c[k]));
    return _mm256_mul_pd(p, lv_pow2(n));
}

/* log(u) for u in [2^-24, 1): u = 2^e m with m in [sqrt(2)/2, sqrt(2)), log m = 2 atanh(s) with
 * s = (m - 1) / (m + 1), |s| <= 0.172, by its series to s^23 (remainder below 0.0295^12 / 25 =
 * 2^-66 relative), then e ln2 with the two-part ln2 of lv_exp4. m - 1 is exact (Sterbenz), the
 * rest a few ulps. */
static inline __m256d lv_log4(__m256d u)
{
    const __m256i bits = _mm256_castpd_si256(u);
    const __m256i mant = _mm256_and_si256(bits, _mm256_set1_epi64x(0x000FFFFFFFFFFFFFLL));
    __m256d m = _mm256_castsi256_pd(_mm256_or_si256(mant, _mm256_set1_epi64x(0x3FF0000000000000LL))); /* [1, 2) */
    /* e = the biased exponent - 1023, as double (the exponent field of u is in [999, 1022]) */
    const __m256i ebits = _mm256_srli_epi64(bits, 52);
    const __m256i e32 = _mm256_permutevar8x32_epi32(ebits, _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6));
    __m256d e = _mm256_sub_pd(_mm256_cvtepi32_pd(_mm256_castsi256_si128(e32)), _mm256_set1_pd(1023.0));
    const __m256d big = _mm256_cmp_pd(m, _mm256_set1_pd(1.4142135623730951), _CMP_GT_OQ);
    m = _mm256_blendv_pd(m, _mm256_mul_pd(m, _mm256_set1_pd(0.5)), big); /* exact */
    e = _mm256_add_pd(e, _mm256_and_pd(big, _mm256_set1_pd(1.0)));
    const __m256d one = _mm256_set1_pd(1.0);
    const __m256d sv = _mm256_div_pd(_mm256_sub_pd(m, one), _mm256_add_pd(m, one));
    const __m256d s2 = _mm256_mul_pd(sv, sv);
    __m256d p = _mm256_set1_pd(1.0 / 23);
    for (int k = 10; k >= 0; k--)
        p = _mm256_add_pd(_mm256_mul_pd(p, s2), _mm256_set1_pd(1.0 / (2 * k + 1)));
    const __m256d lm = _mm256_mul_pd(_mm256_add_pd(sv, sv), p);
    return _mm256_add_pd(_mm256_mul_pd(e, _mm256_set1_pd(VOL_I_LV_LN2_HI)),
                         _mm256_add_pd(_mm256_mul_pd(e, _mm256_set1_pd(VOL_I_LV_LN2_LO)), lm));
}

/* (float)exp(x[q]) for the 8 lanes of x (two halves of 4 doubles), libm's bits: lv_exp4 where x
 * is in [-87, 0] (the result a normal float) and not near a float midpoint, else libm. */
static inline __m256 lv_expf8(__m256d xlo, __m256d xhi)
{
    const __m256d lo = _mm256_set1_pd(-87.0), zero = _mm256_setzero_pd();
    const __m256d ylo = lv_exp4(xlo), yhi = lv_exp4(xhi);
    const __m256i okr_lo = _mm256_castpd_si256(
        _mm256_and_pd(_mm256_cmp_pd(xlo, lo, _CMP_GE_OQ), _mm256_cmp_pd(xlo, zero, _CMP_LE_OQ)));
    const __m256i okr_hi = _mm256_castpd_si256(
        _mm256_and_pd(_mm256_cmp_pd(xhi, lo, _CMP_GE_OQ), _mm256_cmp_pd(xhi, zero, _CMP_LE_OQ)));
    const int good = _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_andnot_si256(lv_near_midpoint(ylo), okr_lo))) |
                    (_mm256_movemask_pd(_mm256_castsi256_pd(_mm256_andnot_si256(lv_near_midpoint(yhi), okr_hi))) << 4);
    __m256 f = _mm256_set_m128(_mm256_cvtpd_ps(yhi), _mm256_cvtpd_ps(ylo));
    if (good != 0xFF) {
        double x[8];
        float t[8];
        _mm256_storeu_pd(x, xlo);
        _mm256_storeu_pd(x + 4, xhi);
        _mm256_storeu_ps(t, f);
        for (int q = 0; q < 8; q++)
            if (!((good >> q) & 1))
                t[q] = (float)exp(x[q]);
        f = _mm256_loadu_ps(t);
    }
    return f;
}

/* ---- Classification ----------------------------------------------------------------------------- */

/* Entry idx (0..7, one per 64-bit lane) of a table of 8 doubles held in two registers (entries
 * 0-3 and 4-7): two permutations of 32-bit pairs and a blend, the same values a gather reads. */
static inline __m256d lv_tab8(__m256d t03, __m256d t47, __m256i idx)
{
    const __m256i two = _mm256_slli_epi64(_mm256_and_si256(idx, _mm256_set1_epi64x(3)), 1);
    const __m256i pair = _mm256_or_si256(two, _mm256_slli_epi64(_mm256_add_epi64(two, _mm256_set1_epi64x(1)), 32));
    const __m256d a = _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(t03), pair));
    const __m256d b = _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(t47), pair));
    return _mm256_blendv_pd(a, b, _mm256_castsi256_pd(_mm256_cmpgt_epi64(idx, _mm256_set1_epi64x(3))));
}

/* vol_tf_eval, 4 values at a time in double (its arithmetic: t = (v - v_lo) / (v_hi - v_lo),
 * rgba = (float)(rgba_lo (1 - t) + rgba_hi t); constant beyond the ends; NaN -> 0), then sigma_t. */
void vol_i_lv_classify_avx2(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                            float *c2)
{
    const int np = T->n;
    const __m256d vfirst = _mm256_set1_pd(T->value[0]), vlast = _mm256_set1_pd(T->value[np - 1]);
    const __m256d one = _mm256_set1_pd(1.0), vzero = _mm256_set1_pd(T->zero_upto);
    float *outc[3] = {c0, c1, c2};
    if (n < 4) {
        vol_i_lv_classify_scalar(T, s, n, sigma, c0, c1, c2);
        return;
    }
    /* Blocks of 4; the last block overlaps the one before where n is not a multiple of 4
     * (recomputing a value writes the same bits). */
    const __m256 vzero8 = _mm256_set1_ps(T->zero_upto_f);
    /* A TF of at most 7 points: its padded tables (np + 1 entries) in two registers each, a lane's
     * entries by permutation (lv_tab8) instead of gathers: the same values, so the same bits. */
    const int tab = np + 1 <= 8;
    __m256d tv[2], trgba[4][2];
    {
        double b[5][8];
        memset(b, 0, sizeof b);
        for (int q = 0; tab && q <= np; q++) {
            b[0][q] = T->value[q];
            for (int c = 0; c < 4; c++)
                b[c + 1][q] = T->rgba[c][q];
        }
        tv[0] = _mm256_loadu_pd(b[0]), tv[1] = _mm256_loadu_pd(b[0] + 4);
        for (int c = 0; c < 4; c++)
            trgba[c][0] = _mm256_loadu_pd(b[c + 1]), trgba[c][1] = _mm256_loadu_pd(b[c + 1] + 4);
    }
    for (int i = 0;; i += 4) {
        if (i > n - 4)
            i = n - 4;
        /* Empty space 8 at a time (all eight at or below zero_upto: v <= zero_upto_f in float is
         * the same test): the two blocks of 4 below would store the same +0. */
        if (i + 8 <= n &&
            _mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(s + i), vzero8, _CMP_LE_OQ)) == 0xFF) {
            const __m256 z8 = _mm256_setzero_ps();
            _mm256_storeu_ps(c0 + i, z8);
            _mm256_storeu_ps(c1 + i, z8);
            _mm256_storeu_ps(c2 + i, z8);
            _mm256_storeu_ps(sigma + i, z8);
            if (i + 8 >= n)
                break;
            i += 4; /* and the loop's 4 */
            continue;
        }
        const __m256d v = _mm256_cvtps_pd(_mm_loadu_ps(s + i));
        /* Empty space (all four at or below zero_upto, none NaN): +0 everywhere, exactly. */
        if (_mm256_movemask_pd(_mm256_cmp_pd(v, vzero, _CMP_LE_OQ)) == 0xF) {
            const __m128 z = _mm_setzero_ps();
            _mm_storeu_ps(c0 + i, z);
            _mm_storeu_ps(c1 + i, z);
            _mm_storeu_ps(c2 + i, z);
            _mm_storeu_ps(sigma + i, z);
            if (i + 4 >= n)
                break;
            continue;
        }
        /* lo = the largest q in [0, np - 2] with value[q] <= v (the binary search's segment, values
         * strictly increasing): the count of q in [1, np - 2] with value[q] <= v. */
        __m256i lo = _mm256_setzero_si256();
        for (int q = 1; q <= np - 2; q++)
            lo = _mm256_sub_epi64(lo, _mm256_castpd_si256(_mm256_cmp_pd(_mm256_set1_pd(T->value[q]), v, _CMP_LE_OQ)));
        const __m256i hi = _mm256_add_epi64(lo, _mm256_set1_epi64x(1));
        /* One segment for all four (smooth data): broadcasts instead of gathers, the same values. */
        const long long q0 = _mm256_extract_epi64(lo, 0);
        const int uni =
            _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(lo, _mm256_set1_epi64x(q0)))) == 0xF;
        const __m256d vl = uni   ? _mm256_set1_pd(T->value[q0])
                           : tab ? lv_tab8(tv[0], tv[1], lo)
                                 : _mm256_i64gather_pd(T->value, lo, 8);
        const __m256d vh = uni   ? _mm256_set1_pd(T->value[q0 + 1])
                           : tab ? lv_tab8(tv[0], tv[1], hi)
                                 : _mm256_i64gather_pd(T->value, hi, 8);
        const __m256d t = _mm256_div_pd(_mm256_sub_pd(v, vl), _mm256_sub_pd(vh, vl));
        const __m256d omt = _mm256_sub_pd(one, t);
        const __m256d below = _mm256_cmp_pd(v, vfirst, _CMP_LE_OQ), above = _mm256_cmp_pd(v, vlast, _CMP_GE_OQ);
        const __m256d nan = _mm256_cmp_pd(v, v, _CMP_UNORD_Q);
        __m128 ch[4];
        for (int c = 0; c < 4; c++) {
            const __m256d cl = uni   ? _mm256_set1_pd(T->rgba[c][q0])
                               : tab ? lv_tab8(trgba[c][0], trgba[c][1], lo)
                                     : _mm256_i64gather_pd(T->rgba[c], lo, 8);
            const __m256d chh = uni   ? _mm256_set1_pd(T->rgba[c][q0 + 1])
                                : tab ? lv_tab8(trgba[c][0], trgba[c][1], hi)
                                      : _mm256_i64gather_pd(T->rgba[c], hi, 8);
            __m256d r = _mm256_add_pd(_mm256_mul_pd(cl, omt), _mm256_mul_pd(chh, t));
            /* vol_tf_eval's order: NaN first, then value <= first, then value >= last. */
            r = _mm256_blendv_pd(r, _mm256_set1_pd(T->rgba[c][np - 1]), above);
            r = _mm256_blendv_pd(r, _mm256_set1_pd(T->rgba[c][0]), below);
            r = _mm256_andnot_pd(nan, r);
            ch[c] = _mm256_cvtpd_ps(r);
        }
        for (int c = 0; c < 3; c++)
            _mm_storeu_ps(outc[c] + i, ch[c]);
        /* sigma_t = (float)(kappa * vol_sigma_from_alpha(alpha)): 0 where alpha <= 0 (or NaN). */
        const int pos = _mm_movemask_ps(_mm_cmpgt_ps(ch[3], _mm_setzero_ps()));
        if (!pos) {
            _mm_storeu_ps(sigma + i, _mm_setzero_ps());
        } else {
            /* vol_sigma_from_alpha's operations in double, log1p(-a) = log(1 - a) by lv_log4 (1 - a
             * is exact for a float a >= 2^-20: its bits lie within 2^-1 .. 2^-44), libm's float
             * where the lane is not in that range or near a float midpoint (lv_near_midpoint). */
            const __m256d ad = _mm256_cvtps_pd(ch[3]);
            const __m256d ac = _mm256_blendv_pd(_mm256_set1_pd(1.0 - 0x1p-24), ad,
                                                _mm256_cmp_pd(ad, _mm256_set1_pd(1.0 - 0x1p-24), _CMP_LT_OQ));
            const __m256d L = lv_log4(_mm256_sub_pd(one, ac));
            const __m256d y = _mm256_mul_pd(_mm256_set1_pd(T->kappa),
                                            _mm256_div_pd(_mm256_sub_pd(_mm256_setzero_pd(), L), _mm256_set1_pd(T->ref_step)));
            const __m256d okr = _mm256_and_pd(_mm256_cmp_pd(ad, _mm256_set1_pd(0x1p-20), _CMP_GE_OQ),
                                              _mm256_and_pd(_mm256_cmp_pd(y, _mm256_set1_pd(0x1p-125), _CMP_GE_OQ),
                                                            _mm256_cmp_pd(y, _mm256_set1_pd(0x1p127), _CMP_LE_OQ)));
            const int good = T->ref_step > 0.0 ? _mm256_movemask_pd(_mm256_castsi256_pd(
                                                     _mm256_andnot_si256(lv_near_midpoint(y), _mm256_castpd_si256(okr))))
                                               : 0;
            __m128 sv = _mm_and_ps(_mm256_cvtpd_ps(y), _mm_cmpgt_ps(ch[3], _mm_setzero_ps()));
            if (((good | ~pos) & 0xF) != 0xF) {
                float a[4], t[4];
                _mm_storeu_ps(a, ch[3]);
                _mm_storeu_ps(t, sv);
                for (int q = 0; q < 4; q++)
                    if (((pos & ~good) >> q) & 1)
                        t[q] = (float)(T->kappa * vol_sigma_from_alpha(a[q], T->ref_step));
                sv = _mm_loadu_ps(t);
            }
            _mm_storeu_ps(sigma + i, sv);
        }
        if (i + 4 >= n)
            break;
    }
}

/* ---- The kernel path's row ------------------------------------------------------------------------- */

/* The span with the kernel's size as arguments: inlined with constants, the kernel loops unroll. */
static inline __attribute__((always_inline)) void lv_span8(const vol_i_lv_span *S, int iu0, int iu1, const int kW,
                                                           const int kH)
{
    const ptrdiff_t nu = S->stride; /* row stride */
    const __m256 fu = _mm256_set1_ps(S->fu), fv = _mm256_set1_ps(S->fv), Ksum = _mm256_set1_ps(S->Ksum);
    const __m256 one = _mm256_set1_ps(1.0f);
    const __m256d ds = _mm256_set1_pd(S->ds), mhalf = _mm256_set1_pd(-0.5), zero = _mm256_setzero_pd();
    const float *K = S->K;
    const ptrdiff_t ob = (ptrdiff_t)(S->jv + S->bv) * nu + S->bu;
    const ptrdiff_t kb = (ptrdiff_t)(S->jv + S->kJ0) * nu + S->kI0;
    if (iu1 - iu0 < 8) {
        vol_i_lv_span_scalar(S, iu0, iu1);
        return;
    }
    /* Blocks of 8; the last block overlaps the one before where the span is not a multiple of 8
     * (a voxel reads only the previous slice and its row's classification: recomputing it writes
     * the same bits). */
    for (int iu = iu0;; iu += 8) {
        if (iu > iu1 - 8)
            iu = iu1 - 8;
        const __m256 sigma = _mm256_loadu_ps(S->sigma + iu);
        const float *s0 = S->prev_sigma + ob + iu, *s1 = s0 + nu;
        const float *l0 = S->prev_l + ob + iu, *l1 = l0 + nu;
        const __m256 s00 = _mm256_loadu_ps(s0), s01 = _mm256_loadu_ps(s0 + 1);
        const __m256 s10 = _mm256_loadu_ps(s1), s11 = _mm256_loadu_ps(s1 + 1);
        const __m256 sa = _mm256_add_ps(s00, _mm256_mul_ps(_mm256_sub_ps(s01, s00), fu));
        const __m256 sb = _mm256_add_ps(s10, _mm256_mul_ps(_mm256_sub_ps(s11, s10), fu));
        const __m256 sigma_p = _mm256_add_ps(sa, _mm256_mul_ps(_mm256_sub_ps(sb, sa), fv));
        /* arg = -0.5 * ((double)sigma + (double)sigma_p) * ds, in two halves of 4 doubles */
        const __m256d alo = _mm256_mul_pd(
            _mm256_mul_pd(mhalf, _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(sigma)),
                                               _mm256_cvtps_pd(_mm256_castps256_ps128(sigma_p)))),
            ds);
        const __m256d ahi = _mm256_mul_pd(
            _mm256_mul_pd(mhalf, _mm256_add_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(sigma, 1)),
                                               _mm256_cvtps_pd(_mm256_extractf128_ps(sigma_p, 1)))),
            ds);
        const int nz = _mm256_movemask_pd(_mm256_cmp_pd(alo, zero, _CMP_NEQ_UQ)) |
                       (_mm256_movemask_pd(_mm256_cmp_pd(ahi, zero, _CMP_NEQ_UQ)) << 4);
        /* tau = (float)exp(arg) (libm's bits, lv_expf8), 1 where arg is +-0 (exp(+-0) = 1) */
        __m256 tau = one;
        if (nz) {
            const __m256 e = lv_expf8(alo, ahi);
            const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            const __m256i z = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(nz), bit), _mm256_setzero_si256());
            tau = _mm256_blendv_ps(e, one, _mm256_castsi256_ps(z));
        }
        const __m256 l00 = _mm256_loadu_ps(l0), l01 = _mm256_loadu_ps(l0 + 1);
        const __m256 l10 = _mm256_loadu_ps(l1), l11 = _mm256_loadu_ps(l1 + 1);
        const __m256 la = _mm256_add_ps(l00, _mm256_mul_ps(_mm256_sub_ps(l01, l00), fu));
        const __m256 lb = _mm256_add_ps(l10, _mm256_mul_ps(_mm256_sub_ps(l11, l10), fu));
        const __m256 l = _mm256_mul_ps(tau, _mm256_add_ps(la, _mm256_mul_ps(_mm256_sub_ps(lb, la), fv)));
        __m256 acc0 = _mm256_setzero_ps(), acc1 = _mm256_setzero_ps(), acc2 = _mm256_setzero_ps();
        for (int dj = 0; dj < kH; dj++) {
            const ptrdiff_t ro = kb + (ptrdiff_t)dj * nu + iu;
            const float *r0 = S->prev_c[0] + ro, *r1 = S->prev_c[1] + ro, *r2 = S->prev_c[2] + ro;
            const float *Kr = K + dj * kW;
            for (int di = 0; di < kW; di++) {
                const __m256 w = _mm256_set1_ps(Kr[di]);
                acc0 = _mm256_add_ps(acc0, _mm256_mul_ps(w, _mm256_loadu_ps(r0 + di)));
                acc1 = _mm256_add_ps(acc1, _mm256_mul_ps(w, _mm256_loadu_ps(r1 + di)));
                acc2 = _mm256_add_ps(acc2, _mm256_mul_ps(w, _mm256_loadu_ps(r2 + di)));
            }
        }
        const __m256 omt = _mm256_sub_ps(one, tau);
        __m256 cc[3];
        cc[0] = _mm256_add_ps(_mm256_mul_ps(tau, _mm256_div_ps(acc0, Ksum)), _mm256_mul_ps(omt, _mm256_loadu_ps(S->ctf[0] + iu)));
        cc[1] = _mm256_add_ps(_mm256_mul_ps(tau, _mm256_div_ps(acc1, Ksum)), _mm256_mul_ps(omt, _mm256_loadu_ps(S->ctf[1] + iu)));
        cc[2] = _mm256_add_ps(_mm256_mul_ps(tau, _mm256_div_ps(acc2, Ksum)), _mm256_mul_ps(omt, _mm256_loadu_ps(S->ctf[2] + iu)));
        _mm256_storeu_ps(S->cur_l + iu, l);
        _mm256_storeu_ps(S->cur_sigma + iu, sigma);
        for (int c = 0; c < 3; c++)
            _mm256_storeu_ps(S->cur_c[c] + iu, cc[c]);
        if (S->out_stride == 1) {
            _mm256_storeu_ps(S->out_l + iu, l);
            for (int c = 0; c < 3; c++)
                _mm256_storeu_ps(S->out_c[c] + iu, cc[c]);
        } else {
            float t[4][8];
            _mm256_storeu_ps(t[0], l);
            for (int c = 0; c < 3; c++)
                _mm256_storeu_ps(t[c + 1], cc[c]);
            for (int q = 0; q < 8; q++) {
                const ptrdiff_t oi = (ptrdiff_t)(iu + q) * S->out_stride;
                S->out_l[oi] = t[0][q];
                S->out_c[0][oi] = t[1][q];
                S->out_c[1][oi] = t[2][q];
                S->out_c[2][oi] = t[3][q];
            }
        }
        if (iu + 8 >= iu1)
            break;
    }
}

void vol_i_lv_span_avx2(const vol_i_lv_span *S, int iu0, int iu1)
{
    if (S->kW == 3 && S->kH == 3)
        lv_span8(S, iu0, iu1, 3, 3); /* the default 45-degree cone along an axis */
    else
        lv_span8(S, iu0, iu1, S->kW, S->kH);
}

/* ---- Test hooks (vol_light_internal.h) ------------------------------------------------------------ */

int vol_i_lv_exp_test_avx2(const double *x, int n, double *y, float *f)
{
    for (int i = 0; i + 8 <= n; i += 8) {
        const __m256d lo = _mm256_loadu_pd(x + i), hi = _mm256_loadu_pd(x + i + 4);
        _mm256_storeu_pd(y + i, lv_exp4(lo));
        _mm256_storeu_pd(y + i + 4, lv_exp4(hi));
        _mm256_storeu_ps(f + i, lv_expf8(lo, hi));
    }
    return 1;
}

int vol_i_lv_log1p_test_avx2(const double *a, int n, double *y)
{
    for (int i = 0; i + 4 <= n; i += 4)
        _mm256_storeu_pd(y + i, lv_log4(_mm256_sub_pd(_mm256_set1_pd(1.0), _mm256_loadu_pd(a + i))));
    return 1;
}
