/* vol_light_avx512.c: the light volume's kernel-path row (vol_light_internal.h vol_i_lv_span_*),
 * 16 voxels of a row at a time in AVX-512F registers (GCC's #pragma GCC target, as
 * ao_sao_avx512.c; no FMA: -ffp-contract=off and no fused intrinsic). Each lane performs the
 * scalar form's IEEE operations in the same order (vol_light.c lv_span1, vol_light_avx2.c
 * lv_span8), and exp is libm's float bit for bit by the guarded evaluation of vol_light_avx2.c
 * (lv_expf8: the same polynomial and guard, 8 doubles a register here), so the three forms give
 * the same bytes (volume_light_avx512_avx2_scalar_bit_for_bit). Selected at run time where the
 * CPU has AVX-512F (vol_i_lv_isa); OBS_ISA=avx2 or OBS_ISA=scalar turn it off. The
 * classification (vol_i_lv_classify_avx512) takes 8 values a register of doubles, picks a small
 * TF's entries by permutation, and stores empty space 16 values at a time. */
#include "vol_light_internal.h"

#if defined(VOL_I_LV_HAVE_AVX512)
#pragma GCC target("avx2,avx512f")
#include <immintrin.h>
#include <math.h>


/* 1 bits in the lanes where y (positive, normal) is within LV_GUARD ulps of a float midpoint
 * (its low 29 mantissa bits within LV_GUARD of 2^28): vol_light_avx2.c lv_near_midpoint. */
static inline __mmask8 lv_near_midpoint8(__m512d y)
{
    const __m512i low = _mm512_and_si512(_mm512_castpd_si512(y), _mm512_set1_epi64(((long long)1 << 29) - 1));
    const __m512i e = _mm512_add_epi64(_mm512_sub_epi64(low, _mm512_set1_epi64((long long)1 << 28)),
                                       _mm512_set1_epi64(LV_GUARD));
    return _mm512_cmplt_epu64_mask(e, _mm512_set1_epi64(2 * LV_GUARD));
}

/* vol_light_avx2.c lv_exp4 on 8 doubles: the same operations in the same order. */
static inline __m512d lv_exp8(__m512d x)
{
    const __m512d n = _mm512_roundscale_pd(_mm512_mul_pd(x, _mm512_set1_pd(VOL_I_LV_LOG2E)),
                                           _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    const __m512d r = _mm512_sub_pd(_mm512_sub_pd(x, _mm512_mul_pd(n, _mm512_set1_pd(VOL_I_LV_LN2_HI))),
                                    _mm512_mul_pd(n, _mm512_set1_pd(VOL_I_LV_LN2_LO)));
    const double *c = vol_i_lv_exp_c;
    __m512d p = _mm512_set1_pd(c[VOL_I_LV_EXP_DEGREE]);
    for (int k = VOL_I_LV_EXP_DEGREE - 1; k >= 0; k--)
        p = _mm512_add_pd(_mm512_mul_pd(p, r), _mm512_set1_pd(c[k]));
    const __m512i k = _mm512_cvtepi32_epi64(_mm512_cvtpd_epi32(n));
    const __m512d two_n = _mm512_castsi512_pd(_mm512_slli_epi64(_mm512_add_epi64(k, _mm512_set1_epi64(1023)), 52));
    return _mm512_mul_pd(p, two_n);
}

static inline __m512 lv_join(__m256 lo, __m256 hi)
{
    return _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(lo)), _mm256_castps_pd(hi), 1));
}

/* (float)exp(x) for 16 lanes (two halves of 8 doubles), libm's bits: lv_exp8 where x is in
 * [-87, 0] and the double is not near a float midpoint, else libm's exp lane by lane. */
static inline __m512 lv_expf16(__m512d xlo, __m512d xhi)
{
    const __m512d lo = _mm512_set1_pd(-87.0), zero = _mm512_setzero_pd();
    const __m512d ylo = lv_exp8(xlo), yhi = lv_exp8(xhi);
    const __mmask8 glo = _mm512_cmp_pd_mask(xlo, lo, _CMP_GE_OQ) & _mm512_cmp_pd_mask(xlo, zero, _CMP_LE_OQ) &
                         (__mmask8)~lv_near_midpoint8(ylo);
    const __mmask8 ghi = _mm512_cmp_pd_mask(xhi, lo, _CMP_GE_OQ) & _mm512_cmp_pd_mask(xhi, zero, _CMP_LE_OQ) &
                         (__mmask8)~lv_near_midpoint8(yhi);
    __m512 f = lv_join(_mm512_cvtpd_ps(ylo), _mm512_cvtpd_ps(yhi));
    const unsigned good = (unsigned)glo | ((unsigned)ghi << 8);
    if (good != 0xFFFFu) {
        double x[16];
        float t[16];
        _mm512_storeu_pd(x, xlo);
        _mm512_storeu_pd(x + 8, xhi);
        _mm512_storeu_ps(t, f);
        for (int q = 0; q < 16; q++)
            if (!((good >> q) & 1))
                t[q] = (float)exp(x[q]);
        f = _mm512_loadu_ps(t);
    }
    return f;
}

static inline __m256 lv_lo8(__m512 v)
{
    return _mm512_castps512_ps256(v);
}
static inline __m256 lv_hi8(__m512 v)
{
    return _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1));
}

/* vol_light_avx2.c lv_log4 on 8 doubles: the same operations in the same order. */
static inline __m512d lv_log8(__m512d u)
{
    const __m512i bits = _mm512_castpd_si512(u);
    const __m512i mant = _mm512_and_si512(bits, _mm512_set1_epi64(0x000FFFFFFFFFFFFFLL));
    __m512d m = _mm512_castsi512_pd(_mm512_or_si512(mant, _mm512_set1_epi64(0x3FF0000000000000LL))); /* [1, 2) */
    __m512d e = _mm512_sub_pd(_mm512_cvtepi32_pd(_mm512_cvtepi64_epi32(_mm512_srli_epi64(bits, 52))),
                              _mm512_set1_pd(1023.0));
    const __mmask8 big = _mm512_cmp_pd_mask(m, _mm512_set1_pd(1.4142135623730951), _CMP_GT_OQ);
    m = _mm512_mask_blend_pd(big, m, _mm512_mul_pd(m, _mm512_set1_pd(0.5))); /* exact */
    e = _mm512_mask_add_pd(e, big, e, _mm512_set1_pd(1.0));
    const __m512d one = _mm512_set1_pd(1.0);
    const __m512d sv = _mm512_div_pd(_mm512_sub_pd(m, one), _mm512_add_pd(m, one));
    const __m512d s2 = _mm512_mul_pd(sv, sv);
    __m512d p = _mm512_set1_pd(1.0 / 23);
    for (int k = 10; k >= 0; k--)
        p = _mm512_add_pd(_mm512_mul_pd(p, s2), _mm512_set1_pd(1.0 / (2 * k + 1)));
    const __m512d lm = _mm512_mul_pd(_mm512_add_pd(sv, sv), p);
    return _mm512_add_pd(_mm512_mul_pd(e, _mm512_set1_pd(VOL_I_LV_LN2_HI)),
                         _mm512_add_pd(_mm512_mul_pd(e, _mm512_set1_pd(VOL_I_LV_LN2_LO)), lm));
}

/* vol_light_avx2.c vol_i_lv_classify_avx2 with 8 values in one register of doubles: vol_tf_eval's
 * arithmetic, then sigma_t by the guarded log (libm's float bit for bit). */
void vol_i_lv_classify_avx512(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                              float *c2)
{
    const int np = T->n;
    if (n < 8) {
        vol_i_lv_classify_avx2(T, s, n, sigma, c0, c1, c2);
        return;
    }
    const __m512d vfirst = _mm512_set1_pd(T->value[0]), vlast = _mm512_set1_pd(T->value[np - 1]);
    const __m512d one = _mm512_set1_pd(1.0);
    const __m256 vzero8 = _mm256_set1_ps(T->zero_upto_f);
    const __m512 vzero16 = _mm512_set1_ps(T->zero_upto_f);
    float *outc[3] = {c0, c1, c2};
    /* A TF of at most 7 points: its padded tables (np + 1 entries, vol_i_lv_tf) fit one register
     * of 8 doubles, and a lane's entry is picked by a permutation instead of a gather (the same
     * values, so the same bits; the gathers are slow on this machine). */
    const int tab = np + 1 <= 8;
    const __mmask8 tmask = (__mmask8)(tab ? (1u << (np + 1)) - 1u : 0u);
    const __m512d tv = _mm512_maskz_loadu_pd(tmask, T->value);
    __m512d trgba[4];
    for (int c = 0; c < 4; c++)
        trgba[c] = _mm512_maskz_loadu_pd(tmask, T->rgba[c]);
    /* Blocks of 8; the last block overlaps the one before (recomputing a value writes the same bits). */
    for (int i = 0;; i += 8) {
        if (i > n - 8)
            i = n - 8;
        /* Empty space 16 values at a time where the block and the next are both empty (the same
         * stores as two blocks of 8). */
        if (i + 16 <= n &&
            _mm512_cmp_ps_mask(_mm512_loadu_ps(s + i), vzero16, _CMP_LE_OQ) == (__mmask16)0xFFFF) {
            const __m512 z16 = _mm512_setzero_ps();
            _mm512_storeu_ps(c0 + i, z16);
            _mm512_storeu_ps(c1 + i, z16);
            _mm512_storeu_ps(c2 + i, z16);
            _mm512_storeu_ps(sigma + i, z16);
            if (i + 16 >= n)
                break;
            i += 8;
            continue;
        }
        const __m256 sf = _mm256_loadu_ps(s + i);
        /* Empty space (all eight at or below zero_upto): +0 everywhere, exactly (vol_light_avx2.c). */
        if (_mm256_movemask_ps(_mm256_cmp_ps(sf, vzero8, _CMP_LE_OQ)) == 0xFF) {
            const __m256 z8 = _mm256_setzero_ps();
            _mm256_storeu_ps(c0 + i, z8);
            _mm256_storeu_ps(c1 + i, z8);
            _mm256_storeu_ps(c2 + i, z8);
            _mm256_storeu_ps(sigma + i, z8);
            if (i + 8 >= n)
                break;
            continue;
        }
        const __m512d v = _mm512_cvtps_pd(sf);
        /* lo = the count of q in [1, np - 2] with value[q] <= v (the binary search's segment) */
        __m512i lo = _mm512_setzero_si512();
        for (int q = 1; q <= np - 2; q++)
            lo = _mm512_mask_add_epi64(lo, _mm512_cmp_pd_mask(_mm512_set1_pd(T->value[q]), v, _CMP_LE_OQ), lo,
                                       _mm512_set1_epi64(1));
        const __m512i hi = _mm512_add_epi64(lo, _mm512_set1_epi64(1));
        const long long q0 = _mm_cvtsi128_si64(_mm512_castsi512_si128(lo));
        const int uni = _mm512_cmpeq_epi64_mask(lo, _mm512_set1_epi64(q0)) == 0xFF;
        const __m512d vl = tab ? _mm512_permutexvar_pd(lo, tv)
                               : uni ? _mm512_set1_pd(T->value[q0]) : _mm512_i64gather_pd(lo, T->value, 8);
        const __m512d vh = tab ? _mm512_permutexvar_pd(hi, tv)
                               : uni ? _mm512_set1_pd(T->value[q0 + 1]) : _mm512_i64gather_pd(hi, T->value, 8);
        const __m512d t = _mm512_div_pd(_mm512_sub_pd(v, vl), _mm512_sub_pd(vh, vl));
        const __m512d omt = _mm512_sub_pd(one, t);
        const __mmask8 below = _mm512_cmp_pd_mask(v, vfirst, _CMP_LE_OQ), above = _mm512_cmp_pd_mask(v, vlast, _CMP_GE_OQ);
        const __mmask8 num = _mm512_cmp_pd_mask(v, v, _CMP_ORD_Q);
        __m256 ch[4];
        for (int c = 0; c < 4; c++) {
            const __m512d cl = tab   ? _mm512_permutexvar_pd(lo, trgba[c])
                               : uni ? _mm512_set1_pd(T->rgba[c][q0])
                                     : _mm512_i64gather_pd(lo, T->rgba[c], 8);
            const __m512d chh = tab   ? _mm512_permutexvar_pd(hi, trgba[c])
                                : uni ? _mm512_set1_pd(T->rgba[c][q0 + 1])
                                      : _mm512_i64gather_pd(hi, T->rgba[c], 8);
            __m512d r = _mm512_add_pd(_mm512_mul_pd(cl, omt), _mm512_mul_pd(chh, t));
            /* vol_tf_eval's order: NaN first, then value <= first, then value >= last. */
            r = _mm512_mask_blend_pd(above, r, _mm512_set1_pd(T->rgba[c][np - 1]));
            r = _mm512_mask_blend_pd(below, r, _mm512_set1_pd(T->rgba[c][0]));
            r = _mm512_maskz_mov_pd(num, r);
            ch[c] = _mm512_cvtpd_ps(r);
        }
        for (int c = 0; c < 3; c++)
            _mm256_storeu_ps(outc[c] + i, ch[c]);
        /* sigma_t = (float)(kappa * vol_sigma_from_alpha(alpha)): 0 where alpha <= 0 (or NaN). */
        const __m256 posv = _mm256_cmp_ps(ch[3], _mm256_setzero_ps(), _CMP_GT_OQ);
        const int pos = _mm256_movemask_ps(posv);
        if (!pos) {
            _mm256_storeu_ps(sigma + i, _mm256_setzero_ps());
        } else {
            const __m512d ad = _mm512_cvtps_pd(ch[3]);
            const __m512d ac = _mm512_mask_blend_pd(_mm512_cmp_pd_mask(ad, _mm512_set1_pd(1.0 - 0x1p-24), _CMP_LT_OQ),
                                                    _mm512_set1_pd(1.0 - 0x1p-24), ad);
            const __m512d L = lv_log8(_mm512_sub_pd(one, ac));
            const __m512d y = _mm512_mul_pd(_mm512_set1_pd(T->kappa),
                                            _mm512_div_pd(_mm512_sub_pd(_mm512_setzero_pd(), L), _mm512_set1_pd(T->ref_step)));
            const __mmask8 okr = _mm512_cmp_pd_mask(ad, _mm512_set1_pd(0x1p-20), _CMP_GE_OQ) &
                                 _mm512_cmp_pd_mask(y, _mm512_set1_pd(0x1p-125), _CMP_GE_OQ) &
                                 _mm512_cmp_pd_mask(y, _mm512_set1_pd(0x1p127), _CMP_LE_OQ);
            const int good = T->ref_step > 0.0 ? (int)(okr & (__mmask8)~lv_near_midpoint8(y)) : 0;
            __m256 sv = _mm256_and_ps(_mm512_cvtpd_ps(y), posv);
            if (((good | ~pos) & 0xFF) != 0xFF) {
                float a[8], tt[8];
                _mm256_storeu_ps(a, ch[3]);
                _mm256_storeu_ps(tt, sv);
                for (int q = 0; q < 8; q++)
                    if (((pos & ~good) >> q) & 1)
                        tt[q] = (float)(T->kappa * vol_sigma_from_alpha(a[q], T->ref_step));
                sv = _mm256_loadu_ps(tt);
            }
            _mm256_storeu_ps(sigma + i, sv);
        }
        if (i + 8 >= n)
            break;
    }
}

/* vol_light_avx2.c lv_span8 with 16 lanes. */
static inline __attribute__((always_inline)) void lv_span16(const vol_i_lv_span *S, int iu0, int iu1, const int kW,
                                                            const int kH)
{
    const ptrdiff_t nu = S->stride; /* row stride */
    const __m512 fu = _mm512_set1_ps(S->fu), fv = _mm512_set1_ps(S->fv), Ksum = _mm512_set1_ps(S->Ksum);
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512d ds = _mm512_set1_pd(S->ds), mhalf = _mm512_set1_pd(-0.5), zero = _mm512_setzero_pd();
    const float *K = S->K;
    const ptrdiff_t ob = (ptrdiff_t)(S->jv + S->bv) * nu + S->bu;
    const ptrdiff_t kb = (ptrdiff_t)(S->jv + S->kJ0) * nu + S->kI0;
    if (iu1 - iu0 < 16) {
        vol_i_lv_span_avx2(S, iu0, iu1);
        return;
    }
    /* Blocks of 16; the last block overlaps the one before (recomputing a voxel writes the same
     * bits: it reads only the previous slice and its row's classification). */
    for (int iu = iu0;; iu += 16) {
        if (iu > iu1 - 16)
            iu = iu1 - 16;
        const __m512 sigma = _mm512_loadu_ps(S->sigma + iu);
        const float *s0 = S->prev_sigma + ob + iu, *s1 = s0 + nu;
        const float *l0 = S->prev_l + ob + iu, *l1 = l0 + nu;
        const __m512 s00 = _mm512_loadu_ps(s0), s01 = _mm512_loadu_ps(s0 + 1);
        const __m512 s10 = _mm512_loadu_ps(s1), s11 = _mm512_loadu_ps(s1 + 1);
        const __m512 sa = _mm512_add_ps(s00, _mm512_mul_ps(_mm512_sub_ps(s01, s00), fu));
        const __m512 sb = _mm512_add_ps(s10, _mm512_mul_ps(_mm512_sub_ps(s11, s10), fu));
        const __m512 sigma_p = _mm512_add_ps(sa, _mm512_mul_ps(_mm512_sub_ps(sb, sa), fv));
        /* arg = -0.5 * ((double)sigma + (double)sigma_p) * ds, in two halves of 8 doubles */
        const __m512d alo = _mm512_mul_pd(
            _mm512_mul_pd(mhalf, _mm512_add_pd(_mm512_cvtps_pd(lv_lo8(sigma)), _mm512_cvtps_pd(lv_lo8(sigma_p)))), ds);
        const __m512d ahi = _mm512_mul_pd(
            _mm512_mul_pd(mhalf, _mm512_add_pd(_mm512_cvtps_pd(lv_hi8(sigma)), _mm512_cvtps_pd(lv_hi8(sigma_p)))), ds);
        const __mmask16 nz = (__mmask16)((unsigned)_mm512_cmp_pd_mask(alo, zero, _CMP_NEQ_UQ) |
                                         ((unsigned)_mm512_cmp_pd_mask(ahi, zero, _CMP_NEQ_UQ) << 8));
        /* tau = (float)exp(arg) (libm's bits), 1 where arg is +-0 (exp(+-0) = 1) */
        __m512 tau = one;
        if (nz)
            tau = _mm512_mask_blend_ps(nz, one, lv_expf16(alo, ahi));
        const __m512 l00 = _mm512_loadu_ps(l0), l01 = _mm512_loadu_ps(l0 + 1);
        const __m512 l10 = _mm512_loadu_ps(l1), l11 = _mm512_loadu_ps(l1 + 1);
        const __m512 la = _mm512_add_ps(l00, _mm512_mul_ps(_mm512_sub_ps(l01, l00), fu));
        const __m512 lb = _mm512_add_ps(l10, _mm512_mul_ps(_mm512_sub_ps(l11, l10), fu));
        const __m512 l = _mm512_mul_ps(tau, _mm512_add_ps(la, _mm512_mul_ps(_mm512_sub_ps(lb, la), fv)));
        __m512 acc0 = _mm512_setzero_ps(), acc1 = _mm512_setzero_ps(), acc2 = _mm512_setzero_ps();
        for (int dj = 0; dj < kH; dj++) {
            const ptrdiff_t ro = kb + (ptrdiff_t)dj * nu + iu;
            const float *r0 = S->prev_c[0] + ro, *r1 = S->prev_c[1] + ro, *r2 = S->prev_c[2] + ro;
            const float *Kr = K + dj * kW;
            for (int di = 0; di < kW; di++) {
                const __m512 w = _mm512_set1_ps(Kr[di]);
                acc0 = _mm512_add_ps(acc0, _mm512_mul_ps(w, _mm512_loadu_ps(r0 + di)));
                acc1 = _mm512_add_ps(acc1, _mm512_mul_ps(w, _mm512_loadu_ps(r1 + di)));
                acc2 = _mm512_add_ps(acc2, _mm512_mul_ps(w, _mm512_loadu_ps(r2 + di)));
            }
        }
        const __m512 omt = _mm512_sub_ps(one, tau);
        __m512 cc[3];
        cc[0] = _mm512_add_ps(_mm512_mul_ps(tau, _mm512_div_ps(acc0, Ksum)), _mm512_mul_ps(omt, _mm512_loadu_ps(S->ctf[0] + iu)));
        cc[1] = _mm512_add_ps(_mm512_mul_ps(tau, _mm512_div_ps(acc1, Ksum)), _mm512_mul_ps(omt, _mm512_loadu_ps(S->ctf[1] + iu)));
        cc[2] = _mm512_add_ps(_mm512_mul_ps(tau, _mm512_div_ps(acc2, Ksum)), _mm512_mul_ps(omt, _mm512_loadu_ps(S->ctf[2] + iu)));
        _mm512_storeu_ps(S->cur_l + iu, l);
        _mm512_storeu_ps(S->cur_sigma + iu, sigma);
        for (int c = 0; c < 3; c++)
            _mm512_storeu_ps(S->cur_c[c] + iu, cc[c]);
        if (S->out_stride == 1) {
            _mm512_storeu_ps(S->out_l + iu, l);
            for (int c = 0; c < 3; c++)
                _mm512_storeu_ps(S->out_c[c] + iu, cc[c]);
        } else {
            float t[4][16];
            _mm512_storeu_ps(t[0], l);
            for (int c = 0; c < 3; c++)
                _mm512_storeu_ps(t[c + 1], cc[c]);
            for (int q = 0; q < 16; q++) {
                const ptrdiff_t oi = (ptrdiff_t)(iu + q) * S->out_stride;
                S->out_l[oi] = t[0][q];
                S->out_c[0][oi] = t[1][q];
                S->out_c[1][oi] = t[2][q];
                S->out_c[2][oi] = t[3][q];
            }
        }
        if (iu + 16 >= iu1)
            break;
    }
}

void vol_i_lv_span_avx512(const vol_i_lv_span *S, int iu0, int iu1)
{
    if (S->kW == 3 && S->kH == 3)
        lv_span16(S, iu0, iu1, 3, 3); /* the default 45-degree cone along an axis */
    else
        lv_span16(S, iu0, iu1, S->kW, S->kH);
}
#endif /* VOL_I_LV_HAVE_AVX512 */
