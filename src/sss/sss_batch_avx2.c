/* sss_batch_avx2.c: the float batch kernel of sss_batch.c with AVX2, 8 samples per vector.
 * Compiled with -mavx2 (no FMA), selected at run time (sss_isa_available; OBS_ISA=scalar forces
 * the scalar path).
 *
 * Lanes: samples k .. k+7 of the batch; the exit point is broadcast. Every lane runs the scalar
 * kernel's operations (sss_batch.c, sss_i_eval_scalar) in the same order, so the two paths agree
 * bit for bit (test sss_batch_avx2_matches_scalar_bit_for_bit):
 *   - +, -, *, /, sqrt are IEEE in both; no FMA (-ffp-contract=off, no -mfma);
 *   - the scalar max(a, b) = a > b ? a : b is MAXPS(a, b), min likewise MINPS;
 *   - the scalar branches (TIR in T12, n_i* guard, mu0 > 0, alpha' = 0, exp's x < -87) are
 *     computed on both sides and selected per lane; the side a lane does not take may hold NaN or
 *     Inf, which the select drops;
 *   - the exp is sss_i_expf step for step (CVTTPS2DQ truncation of an integral float = the
 *     scalar (int32_t) cast). */
#include "sss_internal.h"

#if defined(OBS_HAVE_AVX2)
#include <immintrin.h>

typedef __m256 vf;
#define VSET(x) _mm256_set1_ps(x)
#define VADD(a, b) _mm256_add_ps(a, b)
#define VSUB(a, b) _mm256_sub_ps(a, b)
#define VMUL(a, b) _mm256_mul_ps(a, b)
#define VDIV(a, b) _mm256_div_ps(a, b)
#define VSQRT(a) _mm256_sqrt_ps(a)
#define VMAX(a, b) _mm256_max_ps(a, b)
#define VMIN(a, b) _mm256_min_ps(a, b)
#define VNEG(a) _mm256_xor_ps(a, _mm256_set1_ps(-0.0f))
/* mask ? a : b */
#define VSEL(mask, a, b) _mm256_blendv_ps(b, a, mask)

static inline vf vdot(vf a0, vf a1, vf a2, vf b0, vf b1, vf b2)
{
    return VADD(VADD(VMUL(a0, b0), VMUL(a1, b1)), VMUL(a2, b2));
}

/* sss_i_expf on 8 lanes */
static inline vf vexp(vf x)
{
    const vf under = _mm256_cmp_ps(x, VSET(-87.0f), _CMP_LT_OQ);
    x = VMIN(x, VSET(88.0f));
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
    const __m256i ni = _mm256_cvttps_epi32(n);
    const __m256i bits = _mm256_slli_epi32(_mm256_add_epi32(ni, _mm256_set1_epi32(127)), 23);
    const vf res = VMUL(p, _mm256_castsi256_ps(bits));
    return _mm256_andnot_ps(under, res);
}

/* t12f of sss_batch.c */
static inline vf vt12(vf cos_raw, vf eta)
{
    vf c = VMAX(cos_raw, VSET(0.0f));
    c = VMIN(c, VSET(1.0f));
    const vf eta2 = VMUL(eta, eta);
    const vf cos2_t = VDIV(VADD(VSUB(eta2, VSET(1.0f)), VMUL(c, c)), eta2);
    const vf tir = _mm256_cmp_ps(cos2_t, VSET(0.0f), _CMP_LE_OQ);
    const vf cos_t = VSQRT(VMAX(cos2_t, VSET(0.0f)));
    const vf ect = VMUL(eta, cos_t), ec = VMUL(eta, c);
    const vf rs = VDIV(VSUB(c, ect), VADD(c, ect));
    const vf rp = VDIV(VSUB(ec, cos_t), VADD(ec, cos_t));
    const vf T = VSUB(VSET(1.0f), VMUL(VSET(0.5f), VADD(VMUL(rs, rs), VMUL(rp, rp))));
    return _mm256_andnot_ps(tir, T);
}

/* spf of sss_batch.c, with its three dot products x.w, x.n_o, w.n_o passed in (the real source's
 * are the same for the three channels, and w.n_o of the virtual source too: computed once per group
 * instead of once per channel, the same values) and D3 = 3 D hoisted per call */
static inline vf vsp(vf sigma_tr, vf D, vf D3, vf c_phi, vf c_e, vf x_w, vf x_no, vf w_no, vf r)
{
    const vf s = VMUL(sigma_tr, r);
    const vf one_p = VADD(VSET(1.0f), s);
    const vf rr = VMUL(r, r);
    const vf three_one_p = VMUL(VSET(3.0f), one_p);
    const vf t_phi = VMUL(c_phi, VADD(VDIV(rr, D), VMUL(three_one_p, x_w)));
    const vf inner = VMUL(VDIV(VMUL(D3, VADD(three_one_p, VMUL(s, s))), rr), x_w);
    const vf t_e = VMUL(c_e, VSUB(VMUL(VMUL(D3, one_p), w_no), VMUL(VADD(one_p, inner), x_no)));
    const vf e = vexp(VNEG(s));
    return VMUL(VDIV(e, VMUL(rr, r)), VSUB(t_phi, t_e));
}

void sss_i_eval_avx2(const sss_gpu_constants *g, const float xo[3], const float no[3], const sss_batch *b,
                     int with_t12, int begin, int groups)
{
    const vf eta = VSET(g->eta);
    const vf eta2 = VMUL(eta, eta);
    const vf norm_k = VSET(g->norm_dir * (float)SSS_I_INV_4PI2);
    const int standard = g->model != 0.0f;
    const vf xo0 = VSET(xo[0]), xo1 = VSET(xo[1]), xo2 = VSET(xo[2]);
    const vf no0 = VSET(no[0]), no1 = VSET(no[1]), no2 = VSET(no[2]);
    const vf zero = VSET(0.0f), one = VSET(1.0f);
    /* the directional dipole's per-channel constants, once per call (the same float products as
     * the per-group expressions they replace, so the same bits) */
    vf cD[3], cD3[3], cde2[3], c2de[3], cst[3], cfloor[3], cback[3], cad[3];
    for (int c = 0; c < 3; c++) {
        cD[c] = VSET(g->D[c]);
        cD3[c] = VMUL(VSET(3.0f), cD[c]);
        const vf de = VSET(g->d_e[c]);
        cde2[c] = VMUL(de, de);
        c2de[c] = VMUL(VSET(2.0f), de);
        cst[c] = VSET(g->sigma_tr[c]);
        cfloor[c] = VMUL(VSET((float)SSS_I_DIST_FLOOR_D), cD[c]);
        cback[c] = VSET(g->backlit_d2[c]);
        cad[c] = VSET(g->two_a_de[c]);
    }
    const vf cphi = VSET(g->c_phi), ce = VSET(g->c_e);
    const int alpha_zero[3] = {g->alpha_p[0] == 0.0f, g->alpha_p[1] == 0.0f, g->alpha_p[2] == 0.0f};
    for (int gi = 0; gi < groups; gi++) {
        const int k = begin + 8 * gi;
        const vf ni0 = _mm256_loadu_ps(b->ni[0] + k), ni1 = _mm256_loadu_ps(b->ni[1] + k),
                 ni2 = _mm256_loadu_ps(b->ni[2] + k);
        const vf wi0 = _mm256_loadu_ps(b->wi[0] + k), wi1 = _mm256_loadu_ps(b->wi[1] + k),
                 wi2 = _mm256_loadu_ps(b->wi[2] + k);
        /* x = x_o - x_i, r = |x| */
        const vf x0 = VSUB(xo0, _mm256_loadu_ps(b->xi[0] + k)), x1 = VSUB(xo1, _mm256_loadu_ps(b->xi[1] + k)),
                 x2 = VSUB(xo2, _mm256_loadu_ps(b->xi[2] + k));
        const vf r2 = vdot(x0, x1, x2, x0, x1, x2);
        const vf cos_i = vdot(wi0, wi1, wi2, ni0, ni1, ni2);
        const vf T = with_t12 ? vt12(cos_i, eta) : one;

        if (standard) {
            /* [Jensen01] eq. 4 corrected (sss.md 2), S_d = R_d(r)/pi */
            for (int c = 0; c < 3; c++) {
                const vf st = VSET(g->sigma_tr[c]), zr = VSET(g->z_r[c]), zv = VSET(g->z_v[c]);
                const vf dr = VSQRT(VADD(r2, VMUL(zr, zr)));
                const vf dv = VSQRT(VADD(r2, VMUL(zv, zv)));
                const vf sr = VMUL(st, dr), sv = VMUL(st, dv);
                const vf real = VDIV(VMUL(VMUL(zr, VADD(one, sr)), vexp(VNEG(sr))), VMUL(VMUL(dr, dr), dr));
                const vf virt = VDIV(VMUL(VMUL(zv, VADD(one, sv)), vexp(VNEG(sv))), VMUL(VMUL(dv, dv), dv));
                vf v = VMUL(T, VMUL(VSET(g->alpha_p[c] * (float)SSS_I_INV_4PI2), VADD(real, virt)));
                if (g->alpha_p[c] == 0.0f)
                    v = zero;
                _mm256_storeu_ps(b->out[c] + k, v);
            }
            continue;
        }

        /* [Frisvad14] directional dipole: the steps of sss_dipole.c sd_directional */
        const vf r = VSQRT(r2);
        /* w12 = refract(w_i), TIR-clamped (sss.md 1.2, 1.3) */
        const vf kk = VMAX(VDIV(VADD(VSUB(eta2, one), VMUL(cos_i, cos_i)), eta2), zero);
        const vf a = VADD(VDIV(VNEG(cos_i), eta), VSQRT(kk));
        vf w0 = VSUB(VDIV(VNEG(wi0), eta), VMUL(ni0, a));
        vf w1 = VSUB(VDIV(VNEG(wi1), eta), VMUL(ni1, a));
        vf w2 = VSUB(VDIV(VNEG(wi2), eta), VMUL(ni2, a));
        const vf wl = VSQRT(vdot(w0, w1, w2, w0, w1, w2));
        w0 = VDIV(w0, wl);
        w1 = VDIV(w1, wl);
        w2 = VDIV(w2, wl);
        /* n_i*, guarded (sss.md 1.3) */
        const vf c0 = VSUB(VMUL(ni1, x2), VMUL(ni2, x1));
        const vf c1 = VSUB(VMUL(ni2, x0), VMUL(ni0, x2));
        const vf c2 = VSUB(VMUL(ni0, x1), VMUL(ni1, x0));
        const vf cl = VSQRT(vdot(c0, c1, c2, c0, c1, c2));
        const vf use_star = _mm256_cmp_ps(cl, VMUL(VSET((float)SSS_I_PARALLEL_EPS), r), _CMP_GT_OQ);
        const vf h0 = VDIV(x0, r), h1 = VDIV(x1, r), h2 = VDIV(x2, r);
        const vf e0 = VDIV(c0, cl), e1 = VDIV(c1, cl), e2 = VDIV(c2, cl);
        const vf s0 = VSEL(use_star, VSUB(VMUL(h1, e2), VMUL(h2, e1)), ni0);
        const vf s1 = VSEL(use_star, VSUB(VMUL(h2, e0), VMUL(h0, e2)), ni1);
        const vf s2 = VSEL(use_star, VSUB(VMUL(h0, e1), VMUL(h1, e0)), ni2);
        /* mu0 = -(n_o . w12) */
        const vf mu0 = VNEG(vdot(no0, no1, no2, w0, w1, w2));
        const vf front = _mm256_cmp_ps(mu0, zero, _CMP_GT_OQ);
        const vf x_w12 = vdot(x0, x1, x2, w0, w1, w2);
        /* w_v = w12 - 2 (w12 . n_i*) n_i* */
        const vf wn2 = VMUL(VSET(2.0f), vdot(w0, w1, w2, s0, s1, s2));
        const vf v0 = VSUB(w0, VMUL(wn2, s0)), v1 = VSUB(w1, VMUL(wn2, s1)), v2 = VSUB(w2, VMUL(wn2, s2));
        const vf num = VMAX(VSUB(r2, VMUL(x_w12, x_w12)), zero);
        /* the dot products of spf that do not depend on the channel */
        const vf r_w_no = vdot(w0, w1, w2, no0, no1, no2);
        const vf r_x_no = vdot(x0, x1, x2, no0, no1, no2);
        const vf v_w_no = vdot(v0, v1, v2, no0, no1, no2);
        for (int c = 0; c < 3; c++) {
            if (alpha_zero[c]) {
                _mm256_storeu_ps(b->out[c] + k, zero);
                continue;
            }
            const vf D = cD[c], st = cst[c];
            const vf floor_d = cfloor[c];
            const vf cos_beta = VNEG(VSQRT(VDIV(num, VADD(r2, cde2[c]))));
            const vf Dmu0 = VMUL(D, mu0);
            const vf dr_f = VSQRT(VADD(r2, VMUL(Dmu0, VSUB(Dmu0, VMUL(c2de[c], cos_beta)))));
            const vf dr_b = VSQRT(VADD(r2, cback[c]));
            const vf dr = VMAX(VSEL(front, dr_f, dr_b), floor_d);
            const vf ad = cad[c];
            const vf y0 = VSUB(x0, VMUL(ad, s0)), y1 = VSUB(x1, VMUL(ad, s1)), y2 = VSUB(x2, VMUL(ad, s2));
            const vf dv = VMAX(VSQRT(vdot(y0, y1, y2, y0, y1, y2)), floor_d);
            const vf sr = vsp(st, D, cD3[c], cphi, ce, x_w12, r_x_no, r_w_no, dr);
            const vf sv = vsp(st, D, cD3[c], cphi, ce, vdot(y0, y1, y2, v0, v1, v2), vdot(y0, y1, y2, no0, no1, no2),
                              v_w_no, dv);
            const vf sd = VMAX(VMUL(norm_k, VSUB(sr, sv)), zero);
            _mm256_storeu_ps(b->out[c] + k, VMUL(T, sd));
        }
    }
}

#endif /* OBS_HAVE_AVX2 */
