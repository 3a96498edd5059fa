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
    const vi A1 = _mm256_loadu_si256((const vi *)d->lane2_a[0]), C1 = _mm256_loadu_si256((const vi *)d->lane2_c[0]);
    const vi A2 = _mm256_loadu_si256((const vi *)d->lane2_a[1]), C2 = _mm256_loadu_si256((const vi *)d->lane2_c[1]);
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

/* sss_i_tea16 on 8 lanes */
static inline vi vtea16(vi v0, vi v1)
{
    vi s0 = _mm256_setzero_si256();
    const vi d = _mm256_set1_epi32((int32_t)0x9e3779b9u), k0 = _mm256_set1_epi32((int32_t)0xa341316cu),
             k1 = _mm256_set1_epi32((int32_t)0xc8013ea4u), k2 = _mm256_set1_epi32((int32_t)0xad90777du),
             k3 = _mm256_set1_epi32((int32_t)0x7e95761eu);
    for (int n = 0; n < 16; n++) {
        s0 = _mm256_add_epi32(s0, d);
        v0 = _mm256_add_epi32(
            v0, _mm256_xor_si256(_mm256_xor_si256(_mm256_add_epi32(_mm256_slli_epi32(v1, 4), k0), _mm256_add_epi32(v1, s0)),
                                 _mm256_add_epi32(_mm256_srli_epi32(v1, 5), k1)));
        v1 = _mm256_add_epi32(
            v1, _mm256_xor_si256(_mm256_xor_si256(_mm256_add_epi32(_mm256_slli_epi32(v0, 4), k2), _mm256_add_epi32(v0, s0)),
                                 _mm256_add_epi32(_mm256_srli_epi32(v0, 5), k3)));
    }
    return v0;
}

void sss_i_stream_seeds_avx2(uint32_t texel0, int count, uint32_t layer_frame, uint64_t seed, uint32_t *out)
{
    const vi lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const vi lf = _mm256_set1_epi32((int32_t)layer_frame);
    const vi sf = _mm256_set1_epi32((int32_t)((uint32_t)seed ^ (uint32_t)(seed >> 32)));
    for (int i = 0; i < count; i += 8) {
        const vi t = _mm256_add_epi32(_mm256_set1_epi32((int32_t)(texel0 + (uint32_t)i)), lanes);
        _mm256_storeu_si256((vi *)(out + i), vtea16(vtea16(t, lf), sf));
    }
}

/* The kept lanes of one group, left-packed by perm (lut), appended at n: positions, normals, the
 * light map's RGB (l0..l2, already packed), the weights widened to double; returns the new n. */
static inline int pack_store(vf px, vf py, vf pz, vf n0, vf n1, vf n2, vi perm, vf l0, vf l1, vf l2, const float *w8,
                             int mask, float *xi[3], float *ni[3], float *wi[3], double *wout, int n)
{
    _mm256_storeu_ps(xi[0] + n, _mm256_permutevar8x32_ps(px, perm));
    _mm256_storeu_ps(xi[1] + n, _mm256_permutevar8x32_ps(py, perm));
    _mm256_storeu_ps(xi[2] + n, _mm256_permutevar8x32_ps(pz, perm));
    _mm256_storeu_ps(ni[0] + n, _mm256_permutevar8x32_ps(n0, perm));
    _mm256_storeu_ps(ni[1] + n, _mm256_permutevar8x32_ps(n1, perm));
    _mm256_storeu_ps(ni[2] + n, _mm256_permutevar8x32_ps(n2, perm));
    _mm256_storeu_ps(wi[0] + n, l0);
    _mm256_storeu_ps(wi[1] + n, l1);
    _mm256_storeu_ps(wi[2] + n, l2);
    const vf wp = _mm256_permutevar8x32_ps(_mm256_loadu_ps(w8), perm);
    _mm256_storeu_pd(wout + n, _mm256_cvtps_pd(_mm256_castps256_ps128(wp)));
    _mm256_storeu_pd(wout + n + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(wp, 1)));
    return n + __builtin_popcount((unsigned)mask);
}

int sss_i_exp_fetch_dir_avx2(const sss_i_fetch_in *in, int groups, const float *ox, const float *oy,
                             const float *w, const int32_t *lut, float *xi[3], float *ni[3], float *wi[3],
                             double *wout, int n)
{
    const vf cx = VSET(in->cx), cy = VSET(in->cy), ppu = VSET(in->ppu), size = VSET(in->size), zero = VSET(0.0f);
    const vi pst = _mm256_set1_epi32((int32_t)in->pst), ist = _mm256_set1_epi32((int32_t)in->ist);
    const vi inst = _mm256_set1_epi32((int32_t)in->inst);
    const vf l0 = VSET(in->l[0]), l1 = VSET(in->l[1]), l2 = VSET(in->l[2]);
    for (int g = 0; g < groups; g++) {
        const vf tx = VADD(cx, VMUL(_mm256_loadu_ps(ox + 8 * g), ppu));
        const vf ty = VSUB(cy, VMUL(_mm256_loadu_ps(oy + 8 * g), ppu));
        vf inside = _mm256_and_ps(
            _mm256_and_ps(_mm256_cmp_ps(tx, zero, _CMP_GE_OQ), _mm256_cmp_ps(ty, zero, _CMP_GE_OQ)),
            _mm256_and_ps(_mm256_cmp_ps(tx, size, _CMP_LT_OQ), _mm256_cmp_ps(ty, size, _CMP_LT_OQ)));
        if (_mm256_testz_ps(inside, inside))
            continue;
        const vi ix = _mm256_and_si256(_mm256_cvttps_epi32(tx), _mm256_castps_si256(inside));
        const vi iy = _mm256_and_si256(_mm256_cvttps_epi32(ty), _mm256_castps_si256(inside));
        if (in->block) {
            const vi dx = _mm256_sub_epi32(ix, _mm256_set1_epi32(in->bx)), dy = _mm256_sub_epi32(iy, _mm256_set1_epi32(in->by));
            const vi three = _mm256_set1_epi32(3), m1 = _mm256_set1_epi32(-1);
            const vi inb = _mm256_and_si256(
                _mm256_and_si256(_mm256_cmpgt_epi32(three, dx), _mm256_cmpgt_epi32(dx, m1)),
                _mm256_and_si256(_mm256_cmpgt_epi32(three, dy), _mm256_cmpgt_epi32(dy, m1)));
            inside = _mm256_andnot_ps(_mm256_castsi256_ps(inb), inside);
        }
        if (in->pack) {
            /* the interleaved records: the same values from one cache line per sample */
            const vi r8 = _mm256_slli_epi32(_mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32(in->pack_w)), ix), 3);
            const float *pk = (const float *)in->pack;
            const vf px = _mm256_mask_i32gather_ps(zero, pk, r8, inside, 4);
            const vi id = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), (const int *)in->pack + 6, r8,
                                                      _mm256_castps_si256(inside), 4);
            const vf keepv = _mm256_and_ps(_mm256_and_ps(inside, _mm256_cmp_ps(px, px, _CMP_ORD_Q)),
                                           _mm256_castsi256_ps(_mm256_cmpeq_epi32(id, inst)));
            const int mask = _mm256_movemask_ps(keepv);
            if (!mask)
                continue;
            const vi perm = _mm256_loadu_si256((const vi *)(lut + 8 * mask));
            const vf py = _mm256_mask_i32gather_ps(zero, pk + 1, r8, keepv, 4);
            const vf pz = _mm256_mask_i32gather_ps(zero, pk + 2, r8, keepv, 4);
            const vf n0 = _mm256_mask_i32gather_ps(zero, pk + 3, r8, keepv, 4);
            const vf n1 = _mm256_mask_i32gather_ps(zero, pk + 4, r8, keepv, 4);
            const vf n2 = _mm256_mask_i32gather_ps(zero, pk + 5, r8, keepv, 4);
            n = pack_store(px, py, pz, n0, n1, n2, perm, l0, l1, l2, w + 8 * g, mask, xi, ni, wi, wout, n);
            continue;
        }
        const vi o = _mm256_add_epi32(_mm256_mullo_epi32(iy, pst), ix);
        const vi oi = _mm256_add_epi32(_mm256_mullo_epi32(iy, ist), ix);
        const vf px = _mm256_mask_i32gather_ps(zero, in->P[0], o, inside, 4);
        const vi id = _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), (const int *)in->iid, oi,
                                                  _mm256_castps_si256(inside), 4);
        const vf keepv = _mm256_and_ps(_mm256_and_ps(inside, _mm256_cmp_ps(px, px, _CMP_ORD_Q)),
                                       _mm256_castsi256_ps(_mm256_cmpeq_epi32(id, inst)));
        const int mask = _mm256_movemask_ps(keepv);
        if (!mask)
            continue;
        const vi perm = _mm256_loadu_si256((const vi *)(lut + 8 * mask));
        const vf py = _mm256_mask_i32gather_ps(zero, in->P[1], o, keepv, 4);
        const vf pz = _mm256_mask_i32gather_ps(zero, in->P[2], o, keepv, 4);
        const vf n0 = _mm256_mask_i32gather_ps(zero, in->W[0], o, keepv, 4);
        const vf n1 = _mm256_mask_i32gather_ps(zero, in->W[1], o, keepv, 4);
        const vf n2 = _mm256_mask_i32gather_ps(zero, in->W[2], o, keepv, 4);
        n = pack_store(px, py, pz, n0, n1, n2, perm, l0, l1, l2, w + 8 * g, mask, xi, ni, wi, wout, n);
    }
    return n;
}

int sss_i_exp_block_dir_avx2(const sss_i_fetch_in *in, double wgt, const int32_t *lut, float *xi[3], float *ni[3],
                             float *wi[3], double *wout, int n)
{
    /* lane j: texel (bx + j mod 3, by + j div 3), j = 0..7, the scalar loop's first 8 */
    const vi dx = _mm256_setr_epi32(0, 1, 2, 0, 1, 2, 0, 1), dy = _mm256_setr_epi32(0, 0, 0, 1, 1, 1, 2, 2);
    const vi ix = _mm256_add_epi32(_mm256_set1_epi32(in->bx), dx), iy = _mm256_add_epi32(_mm256_set1_epi32(in->by), dy);
    /* planes, or the interleaved records (sss_i_fetch_in.pack: record r, field f at 8 r + f) */
    const int pk = in->pack != NULL;
    const float *P0 = pk ? (const float *)in->pack : in->P[0], *P1 = pk ? P0 + 1 : in->P[1], *P2 = pk ? P0 + 2 : in->P[2];
    const float *W0 = pk ? P0 + 3 : in->W[0], *W1 = pk ? P0 + 4 : in->W[1], *W2 = pk ? P0 + 5 : in->W[2];
    const int *ID = pk ? (const int *)in->pack + 6 : (const int *)in->iid;
    const vi o = pk ? _mm256_slli_epi32(_mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32(in->pack_w)), ix), 3)
                    : _mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32((int32_t)in->pst)), ix);
    const vi oi = pk ? o : _mm256_add_epi32(_mm256_mullo_epi32(iy, _mm256_set1_epi32((int32_t)in->ist)), ix);
    const vf px = _mm256_i32gather_ps(P0, o, 4);
    const vi id = _mm256_i32gather_epi32(ID, oi, 4);
    const vf keepv = _mm256_and_ps(_mm256_cmp_ps(px, px, _CMP_ORD_Q),
                                   _mm256_castsi256_ps(_mm256_cmpeq_epi32(id, _mm256_set1_epi32((int32_t)in->inst))));
    const int mask = _mm256_movemask_ps(keepv);
    if (mask) {
        /* masked gathers: dropped lanes read 0, so the lanes past the count stay finite */
        const vf zero = VSET(0.0f);
        const vi perm = _mm256_loadu_si256((const vi *)(lut + 8 * mask));
        const vf pxk = _mm256_and_ps(px, keepv);
        const vf py = _mm256_mask_i32gather_ps(zero, P1, o, keepv, 4);
        const vf pz = _mm256_mask_i32gather_ps(zero, P2, o, keepv, 4);
        const vf n0 = _mm256_mask_i32gather_ps(zero, W0, o, keepv, 4);
        const vf n1 = _mm256_mask_i32gather_ps(zero, W1, o, keepv, 4);
        const vf n2 = _mm256_mask_i32gather_ps(zero, W2, o, keepv, 4);
        _mm256_storeu_ps(xi[0] + n, _mm256_permutevar8x32_ps(pxk, perm));
        _mm256_storeu_ps(xi[1] + n, _mm256_permutevar8x32_ps(py, perm));
        _mm256_storeu_ps(xi[2] + n, _mm256_permutevar8x32_ps(pz, perm));
        _mm256_storeu_ps(ni[0] + n, _mm256_permutevar8x32_ps(n0, perm));
        _mm256_storeu_ps(ni[1] + n, _mm256_permutevar8x32_ps(n1, perm));
        _mm256_storeu_ps(ni[2] + n, _mm256_permutevar8x32_ps(n2, perm));
        _mm256_storeu_ps(wi[0] + n, VSET(in->l[0]));
        _mm256_storeu_ps(wi[1] + n, VSET(in->l[1]));
        _mm256_storeu_ps(wi[2] + n, VSET(in->l[2]));
        _mm256_storeu_pd(wout + n, _mm256_set1_pd(wgt));
        _mm256_storeu_pd(wout + n + 4, _mm256_set1_pd(wgt));
        n += __builtin_popcount((unsigned)mask);
    }
    /* the ninth texel, (bx + 2, by + 2) */
    const ptrdiff_t o8 = (ptrdiff_t)(in->by + 2) * in->pst + in->bx + 2;
    const float p8 = in->P[0][o8];
    if (p8 == p8 && in->iid[(ptrdiff_t)(in->by + 2) * in->ist + in->bx + 2] == in->inst) {
        xi[0][n] = p8;
        xi[1][n] = in->P[1][o8];
        xi[2][n] = in->P[2][o8];
        ni[0][n] = in->W[0][o8];
        ni[1][n] = in->W[1][o8];
        ni[2][n] = in->W[2][o8];
        wi[0][n] = in->l[0];
        wi[1][n] = in->l[1];
        wi[2][n] = in->l[2];
        wout[n] = wgt;
        n++;
    }
    return n;
}

void sss_i_wsum3_avx2(const double *w, const float *const o[3], int n, double out[3])
{
    /* the three channels in one pass (w loaded once per 4 samples); each channel's sums are the
     * same operations in the same order as one pass per channel: lane l of acc_c holds
     * sum over q = l mod 4 of w_q o_c,q, in q order */
    const int n4 = n & ~3;
    __m256d acc0 = _mm256_setzero_pd(), acc1 = _mm256_setzero_pd(), acc2 = _mm256_setzero_pd();
    const float *o0 = o[0], *o1 = o[1], *o2 = o[2];
    for (int q = 0; q < n4; q += 4) {
        const __m256d wq = _mm256_loadu_pd(w + q);
        acc0 = _mm256_add_pd(acc0, _mm256_mul_pd(wq, _mm256_cvtps_pd(_mm_loadu_ps(o0 + q))));
        acc1 = _mm256_add_pd(acc1, _mm256_mul_pd(wq, _mm256_cvtps_pd(_mm_loadu_ps(o1 + q))));
        acc2 = _mm256_add_pd(acc2, _mm256_mul_pd(wq, _mm256_cvtps_pd(_mm_loadu_ps(o2 + q))));
    }
    double a[3][4];
    _mm256_storeu_pd(a[0], acc0);
    _mm256_storeu_pd(a[1], acc1);
    _mm256_storeu_pd(a[2], acc2);
    for (int c = 0; c < 3; c++) {
        for (int q = n4; q < n; q++)
            a[c][q - n4] += w[q] * (double)o[c][q];
        out[c] = (a[c][0] + a[c][1]) + (a[c][2] + a[c][3]);
    }
}

int sss_i_rr_prefilter_avx2(uint32_t *state, int groups, const sss_i_rr_filter *f, float *u1, float *u2,
                            float *zeta)
{
    /* lane j: states 3j+1 (u1), 3j+2 (u2), 3j+3 (zeta) after the group's start; the bound is a
     * table lookup on the u1 state's top 10 bits, compared with the zeta state's top 24 bits
     * (integers: no sqrt, no exp) */
    vi A[3], C[3];
    for (int d = 0; d < 3; d++) {
        A[d] = _mm256_loadu_si256((const vi *)f->jd->lane3_a[d]);
        C[d] = _mm256_loadu_si256((const vi *)f->jd->lane3_c[d]);
    }
    uint32_t st = *state;
    int n = 0;
    for (int g = 0; g < groups; g++) {
        const vi s0 = _mm256_set1_epi32((int32_t)st);
        const vi s1 = _mm256_add_epi32(_mm256_mullo_epi32(A[0], s0), C[0]);
        const vi s3 = _mm256_add_epi32(_mm256_mullo_epi32(A[2], s0), C[2]);
        const uint32_t g0 = st;
        st = f->jd->jump_a[23] * st + f->jd->jump_c[23];
        const vi zmax = _mm256_i32gather_epi32((const int *)f->zmax, _mm256_srli_epi32(s1, 22), 4);
        /* keep: (s3 >> 8) < zmax (both < 2^25: a signed compare is exact) */
        const vi keepv = _mm256_cmpgt_epi32(zmax, _mm256_srli_epi32(s3, 8));
        unsigned keep = (unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(keepv));
        while (keep) {
            const int j = __builtin_ctz(keep);
            keep &= keep - 1;
            /* the three draws of lane j, as sss_i_rand gives them */
            const uint32_t a1 = f->jd->jump_a[3 * j] * g0 + f->jd->jump_c[3 * j];
            const uint32_t a2 = f->jd->jump_a[3 * j + 1] * g0 + f->jd->jump_c[3 * j + 1];
            const uint32_t a3 = f->jd->jump_a[3 * j + 2] * g0 + f->jd->jump_c[3 * j + 2];
            u1[n] = (float)(a1 >> 8) * (1.0f / 16777216.0f);
            u2[n] = (float)(a2 >> 8) * (1.0f / 16777216.0f);
            zeta[n] = (float)(a3 >> 8) * (1.0f / 16777216.0f);
            n++;
        }
    }
    *state = st;
    return n;
}

#endif /* OBS_HAVE_AVX2 */
