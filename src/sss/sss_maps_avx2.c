/* sss_maps_avx2.c: the exponential sampler's sample generation (sss_maps_internal.h,
 * sss_i_exp_sample) on 8 samples per vector. Compiled with -mavx2 (no FMA); selected by the
 * params' ISA like sss_eval_batch. Every lane runs the scalar helpers' float operations in the
 * same order (sss_i_logf, sss_i_atanh_tail, sss_i_exp_g, sss_i_exp_t, sss_i_sincos_2pi and the
 * kernel's sss_i_expf); their branches are computed on both sides and selected per lane. So the
 * two paths give the same bits (test sss_exponential_sampler_avx2_matches_scalar_bit_for_bit).
 *
 * The stream: lane j of a group uses draws 2j+1 (u1) and 2j+2 (u2) after the group's start
 * state, computed with the LCG's jump-ahead constants (state_{+k} = a_k state + c_k mod 2^32:
 * the same states as drawing one by one). */
#include "sss_maps_internal.h"

#if defined(OBS_HAVE_AVX2)
#include <immintrin.h>

typedef __m256 vf;
typedef __m256i vi;
#define VSET(x) _mm256_set1_ps(x)
#define VADD(a, b) _mm256_add_ps(a, b)
#define VSUB(a, b) _mm256_sub_ps(a, b)
#define VMUL(a, b) _mm256_mul_ps(a, b)
#define VDIV(a, b) _mm256_div_ps(a, b)
#define VSEL(mask, a, b) _mm256_blendv_ps(b, a, mask)

/* sss_i_logf */
static inline vf vlog(vf y)
{
    const vi b = _mm256_castps_si256(y);
    vi e = _mm256_sub_epi32(_mm256_srli_epi32(b, 23), _mm256_set1_epi32(127));
    vf m = _mm256_castsi256_ps(
        _mm256_or_si256(_mm256_and_si256(b, _mm256_set1_epi32(0x007fffff)), _mm256_set1_epi32(0x3f800000)));
    const vf big = _mm256_cmp_ps(m, VSET(1.41421356f), _CMP_GT_OQ);
    m = VSEL(big, VMUL(m, VSET(0.5f)), m);
    e = _mm256_sub_epi32(e, _mm256_castps_si256(big)); /* big lanes are -1 as integers: e + 1 */
    const vf s = VDIV(VSUB(m, VSET(1.0f)), VADD(m, VSET(1.0f))), s2 = VMUL(s, s);
    vf p = VSET(1.0f / 9.0f);
    p = VADD(VMUL(p, s2), VSET(1.0f / 7.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 5.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 3.0f));
    const vf two_s = VMUL(VSET(2.0f), s);
    const vf lnm = VADD(two_s, VMUL(two_s, VMUL(s2, p)));
    const vf ef = _mm256_cvtepi32_ps(e);
    return VADD(VMUL(ef, VSET(SSS_I_LN2_HI)), VADD(VMUL(ef, VSET(SSS_I_LN2_LO)), lnm));
}

/* sss_i_atanh_tail */
static inline vf vatanh_tail(vf s)
{
    const vf s2 = VMUL(s, s);
    vf p = VSET(1.0f / 15.0f);
    p = VADD(VMUL(p, s2), VSET(1.0f / 13.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 11.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 9.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 7.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 5.0f));
    p = VADD(VMUL(p, s2), VSET(1.0f / 3.0f));
    return VMUL(VMUL(VSET(2.0f), s), VMUL(s2, p));
}

/* sss_i_exp_g */
static inline vf vexp_g(vf t, vf w)
{
    const vf two_t = VADD(VSET(2.0f), t);
    const vf s = VDIV(t, two_t);
    const vf small = VSUB(VSUB(VDIV(VMUL(t, t), two_t), vatanh_tail(s)), w);
    const vf large = VSUB(VSUB(t, vlog(VADD(VSET(1.0f), t))), w);
    return VSEL(_mm256_cmp_ps(t, VSET(0.5f), _CMP_LT_OQ), small, large);
}

/* sss_i_expf (as sss_batch_avx2.c's vexp) */
static inline vf vexpf(vf x)
{
    const vf under = _mm256_cmp_ps(x, VSET(-87.0f), _CMP_LT_OQ);
    x = _mm256_min_ps(x, VSET(88.0f));
    const vf t = VMUL(x, VSET(SSS_I_EXPF_LOG2E));
    const vf n = VSUB(VADD(t, VSET(SSS_I_EXPF_MAGIC)), VSET(SSS_I_EXPF_MAGIC));
    const vf r = VSUB(VSUB(x, VMUL(n, VSET(SSS_I_EXPF_LN2_HI))), VMUL(n, VSET(SSS_I_EXPF_LN2_LO)));
    vf p = VSET(SSS_I_EXPF_C7);
    p = VADD(VMUL(p, r), VSET(SSS_I_EXPF_C6));
    p = VADD(VMUL(p, r), VSET(SSS_I_EXPF_C5));
    p = VADD(VMUL(p, r), VSET(SSS_I_EXPF_C4));
    p = VADD(VMUL(p, r), VSET(SSS_I_EXPF_C3));
    p = VADD(VMUL(p, r), VSET(SSS_I_EXPF_C2));
    p = VADD(VMUL(p, r), VSET(1.0f));
    p = VADD(VMUL(p, r), VSET(1.0f));
    const vi ni = _mm256_cvttps_epi32(n);
    const vi bits = _mm256_slli_epi32(_mm256_add_epi32(ni, _mm256_set1_epi32(127)), 23);
    return _mm256_andnot_ps(under, VMUL(p, _mm256_castsi256_ps(bits)));
}

/* (state >> 8) * 2^-24 of 8 states */
static inline vf vunit(vi st)
{
    return VMUL(_mm256_cvtepi32_ps(_mm256_srli_epi32(st, 8)), VSET(1.0f / 16777216.0f));
}

void sss_i_exp_samples_avx2(uint32_t *state, int groups, const sss_i_exp_disk *d, float *ox, float *oy, float *w)
{
    /* jump constants of draws 1, 3, .., 15 (u1) and 2, 4, .., 16 (u2) */
    int32_t a1[8], c1[8], a2[8], c2[8];
    for (int j = 0; j < 8; j++) {
        a1[j] = (int32_t)d->jump_a[2 * j];
        c1[j] = (int32_t)d->jump_c[2 * j];
        a2[j] = (int32_t)d->jump_a[2 * j + 1];
        c2[j] = (int32_t)d->jump_c[2 * j + 1];
    }
    const vi A1 = _mm256_loadu_si256((const vi *)a1), C1 = _mm256_loadu_si256((const vi *)c1);
    const vi A2 = _mm256_loadu_si256((const vi *)a2), C2 = _mm256_loadu_si256((const vi *)c2);
    const vf Z = VSET(d->Z), q = VSET(d->q), T = VSET(d->T), sigma = VSET(d->sigma), R = VSET(d->R);
    const vf w0 = VSET(d->w0), one = VSET(1.0f), zero = VSET(0.0f);
    uint32_t st = *state;
    for (int g = 0; g < groups; g++) {
        const vi s0 = _mm256_set1_epi32((int32_t)st);
        const vf u1 = vunit(_mm256_add_epi32(_mm256_mullo_epi32(A1, s0), C1));
        const vf u2 = vunit(_mm256_add_epi32(_mm256_mullo_epi32(A2, s0), C2));
        st = d->jump_a[15] * st + d->jump_c[15];
        /* sss_i_exp_t */
        const vf v = VMUL(u1, Z);
        const vf sv = VDIV(v, VSUB(VSET(2.0f), v));
        const vf w_small = VADD(VMUL(VSET(2.0f), sv), vatanh_tail(sv));
        const vf w_large = _mm256_xor_ps(vlog(VADD(VSUB(one, u1), VMUL(u1, q))), VSET(-0.0f));
        const vf wv = VSEL(_mm256_cmp_ps(v, VSET(0.5f), _CMP_LE_OQ), w_small, w_large);
        vf t = VADD(wv, _mm256_sqrt_ps(VMUL(VSET(2.0f), wv)));
        for (int it = 0; it < 3; it++) {
            const vf gg = vexp_g(t, wv);
            t = VSUB(t, VDIV(VMUL(gg, VADD(one, t)), _mm256_max_ps(t, VSET(1e-30f))));
        }
        t = _mm256_min_ps(_mm256_max_ps(t, zero), T);
        /* sss_i_exp_sample */
        const vf rho = _mm256_min_ps(VDIV(t, sigma), R);
        /* sss_i_sincos_2pi */
        const vf u4 = VMUL(VSET(4.0f), u2);
        const vi k = _mm256_cvttps_epi32(u4);
        const vf a = VMUL(VSUB(u4, _mm256_cvtepi32_ps(k)), VSET(1.57079632679f)), a2v = VMUL(a, a);
        vf ps = VSET(-1.0f / 39916800.0f);
        ps = VADD(VMUL(ps, a2v), VSET(1.0f / 362880.0f));
        ps = VSUB(VMUL(ps, a2v), VSET(1.0f / 5040.0f));
        ps = VADD(VMUL(ps, a2v), VSET(1.0f / 120.0f));
        ps = VSUB(VMUL(ps, a2v), VSET(1.0f / 6.0f));
        const vf sa = VADD(a, VMUL(a, VMUL(a2v, ps)));
        vf pc = VSET(1.0f / 479001600.0f);
        pc = VSUB(VMUL(pc, a2v), VSET(1.0f / 3628800.0f));
        pc = VADD(VMUL(pc, a2v), VSET(1.0f / 40320.0f));
        pc = VSUB(VMUL(pc, a2v), VSET(1.0f / 720.0f));
        pc = VADD(VMUL(pc, a2v), VSET(1.0f / 24.0f));
        pc = VSUB(VMUL(pc, a2v), VSET(0.5f));
        const vf ca = VADD(one, VMUL(a2v, pc));
        const vf odd = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(k, _mm256_set1_epi32(1)),
                                                              _mm256_set1_epi32(1)));
        const vf half = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(k, _mm256_set1_epi32(2)),
                                                               _mm256_set1_epi32(2)));
        const vf neg = VSET(-0.0f);
        const vf cc1 = VSEL(odd, _mm256_xor_ps(sa, neg), ca), ss1 = VSEL(odd, ca, sa);
        const vf cs = VSEL(half, _mm256_xor_ps(cc1, neg), cc1), sn = VSEL(half, _mm256_xor_ps(ss1, neg), ss1);
        _mm256_storeu_ps(ox + 8 * g, VMUL(rho, cs));
        _mm256_storeu_ps(oy + 8 * g, VMUL(rho, sn));
        _mm256_storeu_ps(w + 8 * g, VMUL(w0, vexpf(VMUL(sigma, rho))));
    }
    *state = st;
}

#endif /* OBS_HAVE_AVX2 */
