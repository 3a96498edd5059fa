/* ao_sao_avx2.c: the SAO AO pass with AVX2, 8 pixels at a time. Compiled with -mavx2 only (no
 * FMA), selected at run time (ao_i_sao_isa_available; OBS_ISA=scalar forces the scalar path).
 * ao_sao_avx512.c compiles this file again (AO_I_SAO_AVX512_BUILD) as ao_i_sao_row_avx512, whose
 * cos/sin run on 8 doubles in one AVX-512F register (cos_sin_pd8) instead of two 4-wide halves;
 * the rest, and the blur (compiled here only), are the same.
 *
 * Lanes: 8 horizontally adjacent pixels (gx .. gx+7) of one GL row; every float lane runs the
 * scalar kernel's operations (ao_sao.c, sao_row_impl) in the same order, so the two paths agree
 * bit for bit (tests/test_ao_sao.c, sao_simd_and_scalar_paths_are_bit_identical):
 *   - +, -, *, /, sqrt are IEEE in both; no FMA (-ffp-contract=off, no -mfma);
 *   - the scalar maxf(a, b) = a > b ? a : b is exactly MAXPS(a, b) (NaN or equal: b);
 *   - int -> float is CVTDQ2PS (round to nearest even), as the scalar cast;
 *   - cos/sin run ao_i_cos_sin's double-precision reduction and series on two 4-wide halves,
 *     with the same operations in the same order; lanes it sends to libm (|angle| >= 3e9, NaN)
 *     and lanes whose floor(log2(ssR)) needs the double log2 (a few ulps below a power of two)
 *     are redone by the scalar helpers themselves;
 *   - G3D HQ's pow() is the scalar powf per lane.
 * Taps gather from the one-block pyramid (ao_i_sao_job.lvl_off) with 32-bit indices, in blocks
 * of TAP_BLOCK taps (all cos/sin of the block, then its fetches, then its falloff terms, summed in
 * tap order). Lanes that are background, outside the row, or have no usable normal compute
 * garbage that is masked out at the end (every index is clamped into the level, so no lane reads
 * out of bounds). The blur (ao_i_sao_blur_row_avx2, at the end) has its own comment. */
#include "ao_sao_internal.h"
#include "ao_internal.h"

#if defined(OBS_HAVE_AVX2) && (!defined(AO_I_SAO_AVX512_BUILD) || defined(AO_I_SAO_HAVE_AVX512))
#if defined(AO_I_SAO_AVX512_BUILD)
/* ao_sao_avx512.c: this kernel again, its cos/sin on 8 doubles in one register */
#pragma GCC target("avx2,avx512f")
#define SAO_WIDE 1
#define SAO_ROW_FN ao_i_sao_row_avx512
#else
#define SAO_WIDE 0
#define SAO_ROW_FN ao_i_sao_row_avx2
#endif
#include <immintrin.h>
#include <math.h>
#include <string.h>

/* ---- cos and sin: ao_i_cos_sin on 4 (AVX2) or 8 (AVX-512F) doubles -------------------------------- */

/* The reduction and the two kernels of ao_i_cos_sin on one register of doubles x, for the vector
 * width W (_mm256 or _mm512, T its __m256d or __m512d): kd, cs and sn receive the quadrant (as a
 * double) and the kernels' cos and sin of the reduced angle. One source for both widths, so that
 * each lane runs the same operations in the same order. */
#define SAO_COS_SIN_KERNELS(W, T, x, kd, cs, sn)                                                            \
    do {                                                                                                  \
        T r_;                                                                                            \
        AO_I_REDUCE_PIO2_PD(W, T, x, kd, r_);                                                            \
        const T z_ = W##_mul_pd(r_, r_);                                                                  \
        /* sn = r + r z (S1 + z (S2 + ... + z S6)); cs = 1 - 0.5 z + z z (C1 + z (C2 + ... + z C6));     \
         * each a + b * c is two roundings (no FMA) */                                                    \
        T ps_ = W##_add_pd(W##_set1_pd(AO_I_SIN_S5), W##_mul_pd(z_, W##_set1_pd(AO_I_SIN_S6)));           \
        ps_ = W##_add_pd(W##_set1_pd(AO_I_SIN_S4), W##_mul_pd(z_, ps_));                                  \
        ps_ = W##_add_pd(W##_set1_pd(AO_I_SIN_S3), W##_mul_pd(z_, ps_));                                  \
        ps_ = W##_add_pd(W##_set1_pd(AO_I_SIN_S2), W##_mul_pd(z_, ps_));                                  \
        ps_ = W##_add_pd(W##_set1_pd(AO_I_SIN_S1), W##_mul_pd(z_, ps_));                                  \
        sn = W##_add_pd(r_, W##_mul_pd(W##_mul_pd(r_, z_), ps_));                                         \
        T pc_ = W##_add_pd(W##_set1_pd(AO_I_COS_C5), W##_mul_pd(z_, W##_set1_pd(AO_I_COS_C6)));           \
        pc_ = W##_add_pd(W##_set1_pd(AO_I_COS_C4), W##_mul_pd(z_, pc_));                                  \
        pc_ = W##_add_pd(W##_set1_pd(AO_I_COS_C3), W##_mul_pd(z_, pc_));                                  \
        pc_ = W##_add_pd(W##_set1_pd(AO_I_COS_C2), W##_mul_pd(z_, pc_));                                  \
        pc_ = W##_add_pd(W##_set1_pd(AO_I_COS_C1), W##_mul_pd(z_, pc_));                                  \
        cs = W##_add_pd(W##_sub_pd(W##_set1_pd(1.0), W##_mul_pd(W##_set1_pd(0.5), z_)),                  \
                        W##_mul_pd(W##_mul_pd(z_, z_), pc_));                                             \
    } while (0)

/* The quadrant q = kd mod 4 picks the signs: 0 (cs, sn), 1 (-sn, cs), 2 (-cs, -sn), 3 (sn, -cs); the
 * float rounding is symmetric, so negating after it is the scalar (float)-v. For odd q the two swap
 * (bit 0 of q moved to the sign bit, which is what blendv reads); cos is negative for q = 1, 2 (bit 1
 * of q + 1), sin for q = 2, 3 (bit 1 of q), each moved to the sign bit. V: _mm (4 lanes) or _mm256
 * (8), F its float and I its integer vector type, S the integer suffix (si128 or si256). */
#define SAO_QUADRANT_SIGNS(V, F, I, S, q, csf, snf, c, s)                                                   \
    do {                                                                                                  \
        const F swap_ = V##_castsi##S##_ps(V##_slli_epi32(q, 31));                                        \
        const F c0_ = V##_blendv_ps(csf, snf, swap_), s0_ = V##_blendv_ps(snf, csf, swap_);               \
        const I sgn_ = V##_set1_epi32((int)0x80000000u);                                                  \
        const I cneg_ = V##_and_si##S(V##_slli_epi32(V##_add_epi32(q, V##_set1_epi32(1)), 30), sgn_);    \
        const I sneg_ = V##_and_si##S(V##_slli_epi32(q, 30), sgn_);                                       \
        *(c) = V##_xor_ps(c0_, V##_castsi##S##_ps(cneg_));                                                \
        *(s) = V##_xor_ps(s0_, V##_castsi##S##_ps(sneg_));                                                \
    } while (0)

static inline void cos_sin_pd(__m256d x, __m128 *c, __m128 *s)
{
    __m256d kd, cs, sn;
    SAO_COS_SIN_KERNELS(_mm256, __m256d, x, kd, cs, sn);
    const __m128 csf = _mm256_cvtpd_ps(cs), snf = _mm256_cvtpd_ps(sn);
    const __m128i q = _mm256_cvtpd_epi32(kd); /* exact: kd is an integer, |kd| < 2^31 */
    SAO_QUADRANT_SIGNS(_mm, __m128, __m128i, 128, q, csf, snf, c, s);
}

#if SAO_WIDE
/* cos_sin_pd on 8 doubles (AVX-512F): the same operations in the same order per lane, so the same
 * bits; the 8 float results and quadrants then fill one 256-bit register each. */
static inline void cos_sin_pd8(__m512d x, __m256 *c, __m256 *s)
{
    __m512d kd, cs, sn;
    SAO_COS_SIN_KERNELS(_mm512, __m512d, x, kd, cs, sn);
    const __m256 csf = _mm512_cvtpd_ps(cs), snf = _mm512_cvtpd_ps(sn);
    const __m256i q = _mm512_cvtpd_epi32(kd); /* exact: kd is an integer, |kd| < 2^31 */
    SAO_QUADRANT_SIGNS(_mm256, __m256, __m256i, 256, q, csf, snf, c, s);
}
#endif

static inline void cos_sin_ps(__m256 angle, __m256 *c, __m256 *s, const int check_big)
{
#if SAO_WIDE
    cos_sin_pd8(_mm512_cvtps_pd(angle), c, s);
#else
    __m128 c_lo, s_lo, c_hi, s_hi;
    cos_sin_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(angle)), &c_lo, &s_lo);
    cos_sin_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(angle, 1)), &c_hi, &s_hi);
    *c = _mm256_insertf128_ps(_mm256_castps128_ps256(c_lo), c_hi, 1);
    *s = _mm256_insertf128_ps(_mm256_castps128_ps256(s_lo), s_hi, 1);
#endif
    /* ao_i_cos_sin sends !(|x| < 3e9) (large or NaN) to libm: redo those lanes with it (the
     * row skips this test when no angle can get there) */
    if (!check_big)
        return;
    const __m256 absx = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), angle);
    const int big = _mm256_movemask_ps(_mm256_cmp_ps(absx, _mm256_set1_ps(3.0e9f), _CMP_NLT_UQ));
    if (big) {
        float a[8], cc[8], ss[8];
        _mm256_storeu_ps(a, angle);
        _mm256_storeu_ps(cc, *c);
        _mm256_storeu_ps(ss, *s);
        for (int l = 0; l < 8; l++)
            if (big >> l & 1)
                ao_i_cos_sin(a[l], &cc[l], &ss[l]);
        *c = _mm256_loadu_ps(cc);
        *s = _mm256_loadu_ps(ss);
    }
}

/* ---- small helpers ------------------------------------------------------------------------------- */

/* trunc_to_int of ao_sao.c: NaN -> 0, clamp to +-2^30, truncate toward zero */
static inline __m256i trunc_to_int_v(__m256 v)
{
    v = _mm256_and_ps(v, _mm256_cmp_ps(v, v, _CMP_ORD_Q));
    v = _mm256_min_ps(v, _mm256_set1_ps(1073741824.0f));  /* v < 2^30 ? v : 2^30 */
    v = _mm256_max_ps(v, _mm256_set1_ps(-1073741824.0f)); /* v > -2^30 ? v : -2^30 */
    return _mm256_cvttps_epi32(v);
}

typedef struct pos3 { __m256 x, y, z; } pos3;

/* csPos((s + 0.5) projInfo.xy + projInfo.zw) with the float coordinate products ax, ay given */
static inline pos3 cs_pos_v(__m256 ax, __m256 ay, __m256 z, int ortho)
{
    pos3 P;
    P.x = ortho ? ax : _mm256_mul_ps(ax, z);
    P.y = ortho ? ay : _mm256_mul_ps(ay, z);
    P.z = z;
    return P;
}

static inline __m256 coord_x(__m256i sx, const ao_sao_constants *k)
{
    return _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(sx), _mm256_set1_ps(0.5f)),
                                       _mm256_set1_ps(k->proj_info[0])),
                         _mm256_set1_ps(k->proj_info[2]));
}

static inline __m256 coord_y(__m256i sy, const ao_sao_constants *k)
{
    return _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(_mm256_cvtepi32_ps(sy), _mm256_set1_ps(0.5f)),
                                       _mm256_set1_ps(k->proj_info[1])),
                         _mm256_set1_ps(k->proj_info[3]));
}

/* Load n (1..8) floats, zeros in the other lanes. */
static inline __m256 load_n(const float *p, int n, __m256i lane)
{
    if (n == 8)
        return _mm256_loadu_ps(p);
    return _mm256_maskload_ps(p, _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane));
}

/* Taps per block of the AO pass's tap loop (a few KB of stack; any value gives the same result) */
#define TAP_BLOCK 12

/* ---- the row -------------------------------------------------------------------------------------- */

static inline __attribute__((always_inline)) void sao_row_avx2_impl(const ao_i_sao_job *J, int task, const int hq,
                                                                   const int ortho, const int use_mip)
{
    const ao_sao_constants *k = J->k;
    const obs_image_f32 *L0 = &J->levels[0];
    const float *base = L0->data;
    const int W = L0->width, H = L0->height;
    int row, i0, i1, slot;
    ao_i_sao_segment(J, task, &row, &i0, &i1, &slot);
    const int gy = J->ry0 + row;
    float *out = obs_image_f32_row(J->ao, row);
    int64_t n_bg = 0, n_degen = 0, n_minr = 0;
    const int N = k->num_samples;
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 r2 = _mm256_set1_ps(k->radius2), bias = _mm256_set1_ps(k->bias), eps = _mm256_set1_ps(k->epsilon),
                 inv_r2 = _mm256_set1_ps(k->inv_radius2);
    const float disk_num = !ortho ? -k->proj_scale * k->radius : k->proj_scale * k->radius;
    const __m256i vgy = _mm256_set1_epi32(gy);
    const __m256 ay = coord_y(vgy, k);
    /* the derivative quad's rows: ya = gy & ~1, yb = gy | 1 (past the last row: 0, robust access) */
    const int ya = gy & ~1, yb = gy | 1;
    const __m256 ay_a = coord_y(_mm256_set1_epi32(ya), k), ay_b = coord_y(_mm256_set1_epi32(yb), k);
    const float *zrow = obs_image_f32_row(L0, gy), *zrow_a = obs_image_f32_row(L0, ya);
    const float *zrow_b = yb < H ? obs_image_f32_row(L0, yb) : NULL;
    /* MIP level tables for the lanes' per-tap levels (permutevar8x32 on levels 0..7 and 8..15) */
    __m256i t_off[2], t_stride[2], t_wm1[2], t_hm1[2];
    {
        int32_t o[16] = {0}, s[16] = {0}, w[16] = {0}, h[16] = {0};
        for (int l = 0; l <= k->max_mip; l++) {
            o[l] = J->lvl_off[l];
            s[l] = J->lvl_stride[l];
            w[l] = J->lvl_wm1[l];
            h[l] = J->lvl_hm1[l];
        }
        for (int i = 0; i < 2; i++) {
            t_off[i] = _mm256_loadu_si256((const __m256i *)(o + 8 * i));
            t_stride[i] = _mm256_loadu_si256((const __m256i *)(s + 8 * i));
            t_wm1[i] = _mm256_loadu_si256((const __m256i *)(w + 8 * i));
            t_hm1[i] = _mm256_loadu_si256((const __m256i *)(h + 8 * i));
        }
    }
    const __m256i max_mip = _mm256_set1_epi32(k->max_mip), lmo = _mm256_set1_epi32(k->log_max_offset + 127);
    const int deep = k->max_mip > 7;
    /* |spin| <= 2^31, so |angle| <= 2^31 + max |alpha_angle| (+ one rounding): below 3e9, where
     * ao_i_cos_sin would go to libm, when every |alpha_angle| < 8e8 (tau up to ~1.2e8) */
    int check_big = 0;
    for (int t = 0; t < N; t++)
        check_big |= !(fabsf(J->alpha_angle[t]) < 8.0e8f);
    const __m256i wm1_0 = _mm256_set1_epi32(J->lvl_wm1[0]), hm1_0 = _mm256_set1_epi32(J->lvl_hm1[0]),
                  stride_0 = _mm256_set1_epi32(J->lvl_stride[0]);

    for (int i = i0; i < i1; i += 8) {
        const int gx0 = J->rx0 + i, n = i1 - i < 8 ? i1 - i : 8;
        const __m256i vgx = _mm256_add_epi32(_mm256_set1_epi32(gx0), lane);
        const __m256 valid = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane));
        /* ---- Centre ---- */
        const __m256 z = load_n(zrow + gx0, n, lane);
        const __m256 bg = _mm256_and_ps(valid, _mm256_cmp_ps(z, zero, _CMP_EQ_OQ));
        __m256 live = _mm256_andnot_ps(bg, valid);
        if (_mm256_testz_ps(live, live)) {
            n_bg += __builtin_popcount((unsigned)_mm256_movemask_ps(bg));
            _mm256_maskstore_ps(out + i, _mm256_castps_si256(valid), one);
            continue;
        }
        const __m256 ax = coord_x(vgx, k);
        const pos3 C = cs_pos_v(ax, ay, z, ortho);
        /* ---- Normal ---- */
        pos3 nrm;
        __m256 degen;
        __m256 l2_check;
        if (!k->normals_from_gbuffer) {
            /* dFdxFine: C(x|1) - C(x&~1) of this row; dFdyFine: C(y|1) - C(y&~1) of this column */
            const __m256i xa = _mm256_and_si256(vgx, _mm256_set1_epi32(~1));
            const __m256i xb = _mm256_or_si256(vgx, _mm256_set1_epi32(1));
            const __m256i in_a = _mm256_castps_si256(valid);
            const __m256i in_b = _mm256_and_si256(in_a, _mm256_cmpgt_epi32(_mm256_set1_epi32(W), xb));
            const __m256 za = _mm256_mask_i32gather_ps(zero, zrow, xa, _mm256_castsi256_ps(in_a), 4);
            const __m256 zb = _mm256_mask_i32gather_ps(zero, zrow, xb, _mm256_castsi256_ps(in_b), 4);
            const pos3 Pa = cs_pos_v(coord_x(xa, k), ay, za, ortho), Pb = cs_pos_v(coord_x(xb, k), ay, zb, ortho);
            const __m256 dx0 = _mm256_sub_ps(Pb.x, Pa.x), dx1 = _mm256_sub_ps(Pb.y, Pa.y),
                         dx2 = _mm256_sub_ps(Pb.z, Pa.z);
            const __m256 zya = load_n(zrow_a + gx0, n, lane);
            const __m256 zyb = zrow_b ? load_n(zrow_b + gx0, n, lane) : zero;
            const pos3 Qa = cs_pos_v(ax, ay_a, zya, ortho), Qb = cs_pos_v(ax, ay_b, zyb, ortho);
            const __m256 dy0 = _mm256_sub_ps(Qb.x, Qa.x), dy1 = _mm256_sub_ps(Qb.y, Qa.y),
                         dy2 = _mm256_sub_ps(Qb.z, Qa.z);
            const __m256 c0 = _mm256_sub_ps(_mm256_mul_ps(dx1, dy2), _mm256_mul_ps(dx2, dy1));
            const __m256 c1 = _mm256_sub_ps(_mm256_mul_ps(dx2, dy0), _mm256_mul_ps(dx0, dy2));
            const __m256 c2 = _mm256_sub_ps(_mm256_mul_ps(dx0, dy1), _mm256_mul_ps(dx1, dy0));
            const __m256 l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(c0, c0), _mm256_mul_ps(c1, c1)),
                                            _mm256_mul_ps(c2, c2));
            degen = _mm256_setzero_ps();
            if (hq) { /* dot(n_C, n_C) > square(C.z * C.z * 0.00006) */
                const __m256 t = _mm256_mul_ps(_mm256_mul_ps(C.z, C.z), _mm256_set1_ps(0.00006f));
                degen = _mm256_cmp_ps(l2, _mm256_mul_ps(t, t), _CMP_GT_OQ);
            }
            l2_check = l2;
            const __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
            nrm.x = _mm256_mul_ps(c0, inv);
            nrm.y = _mm256_mul_ps(c1, inv);
            nrm.z = _mm256_mul_ps(c2, inv);
        } else {
            const int y = k->full_height - 1 - gy;
            const __m256 a = load_n(obs_image_f32_row(J->in->normal[0], y) + gx0, n, lane);
            const __m256 b = load_n(obs_image_f32_row(J->in->normal[1], y) + gx0, n, lane);
            const __m256 c = load_n(obs_image_f32_row(J->in->normal[2], y) + gx0, n, lane);
            const __m256 l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a, a), _mm256_mul_ps(b, b)), _mm256_mul_ps(c, c));
            degen = _mm256_setzero_ps();
            l2_check = l2;
            const __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(l2));
            nrm.x = _mm256_mul_ps(a, inv);
            nrm.y = _mm256_mul_ps(b, inv);
            nrm.z = _mm256_mul_ps(c, inv);
        }
        /* !(l2 > 0) || !(l2 < inf): zero or non-finite normal */
        const __m256 l2_ok = _mm256_and_ps(_mm256_cmp_ps(l2_check, zero, _CMP_GT_OQ),
                                           _mm256_cmp_ps(l2_check, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
        degen = _mm256_and_ps(live, _mm256_or_ps(degen, _mm256_andnot_ps(l2_ok, _mm256_castsi256_ps(_mm256_set1_epi32(-1)))));
        live = _mm256_andnot_ps(degen, live);
        /* ---- Per-pixel spin and screen-space disk radius ---- */
        const __m256i ux3 = _mm256_mullo_epi32(vgx, _mm256_set1_epi32(3));
        const __m256i h = _mm256_mullo_epi32(
            _mm256_xor_si256(ux3, _mm256_add_epi32(vgy, _mm256_mullo_epi32(vgx, vgy))), _mm256_set1_epi32(10));
        const __m256 spin = _mm256_cvtepi32_ps(h);
        const __m256 disk = !ortho ? _mm256_div_ps(_mm256_set1_ps(disk_num), C.z) : _mm256_set1_ps(disk_num);
        __m256 minr = zero;
        if (hq) {
            minr = _mm256_and_ps(live, _mm256_cmp_ps(disk, _mm256_set1_ps(3.0f), _CMP_LE_OQ));
            live = _mm256_andnot_ps(minr, live);
        }
        n_bg += __builtin_popcount((unsigned)_mm256_movemask_ps(bg));
        n_degen += __builtin_popcount((unsigned)_mm256_movemask_ps(degen));
        n_minr += __builtin_popcount((unsigned)_mm256_movemask_ps(minr));
        if (_mm256_testz_ps(live, live)) {
            _mm256_maskstore_ps(out + i, _mm256_castps_si256(valid), one);
            continue;
        }
        const __m256 angular =
            hq ? _mm256_add_ps(_mm256_set1_ps(1.0f * (1.0f - 0.35f)),
                               _mm256_mul_ps(_mm256_max_ps(zero, _mm256_mul_ps(_mm256_set1_ps(1.5f), nrm.z)),
                                             _mm256_set1_ps(0.35f)))
               : one;
        /* ---- Taps, in blocks of TAP_BLOCK: first the block's cos/sin (independent of each other,
         * so they overlap in the pipeline instead of waiting on each tap's gather and division),
         * then its fetches and falloff terms, summed in tap order as the scalar loop ---- */
        __m256 sum = zero;
        for (int t0 = 0; t0 < N; t0 += TAP_BLOCK) {
            const int tn = N - t0 < TAP_BLOCK ? N - t0 : TAP_BLOCK;
            __m256 b_ssR[TAP_BLOCK], b_cs[TAP_BLOCK], b_sn[TAP_BLOCK], b_zq[TAP_BLOCK], b_ax[TAP_BLOCK], b_ay[TAP_BLOCK];
            for (int u = 0; u < tn; u++) {
                const int t = t0 + u;
                const __m256 angle = _mm256_add_ps(_mm256_set1_ps(J->alpha_angle[t]), spin);
                __m256 ssR = _mm256_mul_ps(_mm256_set1_ps(J->alpha[t]), disk);
                if (hq)
                    ssR = _mm256_max_ps(_mm256_set1_ps(0.75f), ssR);
                b_ssR[u] = ssR;
                cos_sin_ps(angle, &b_cs[u], &b_sn[u], check_big);
            }
            for (int u = 0; u < tn; u++) {
                const __m256 ssR = b_ssR[u], cs = b_cs[u], sn = b_sn[u];
                const __m256i px = _mm256_add_epi32(trunc_to_int_v(_mm256_mul_ps(ssR, cs)), vgx);
                const __m256i py = _mm256_add_epi32(trunc_to_int_v(_mm256_mul_ps(ssR, sn)), vgy);
                __m256i idx;
                if (!use_mip) {
                    const __m256i mx = _mm256_min_epi32(_mm256_max_epi32(px, _mm256_setzero_si256()), wm1_0);
                    const __m256i my = _mm256_min_epi32(_mm256_max_epi32(py, _mm256_setzero_si256()), hm1_0);
                    idx = _mm256_add_epi32(_mm256_mullo_epi32(my, stride_0), mx);
                } else {
                    /* mip = clamp(floor(log2(ssR)) - LOG_MAX_OFFSET, 0, maxMip) for ssR >= 1, else 0;
                     * floor(log2) is the exponent, except a few ulps below a power of two (scalar) */
                    const __m256i bits = _mm256_castps_si256(ssR);
                    const __m256 ge1 = _mm256_cmp_ps(ssR, one, _CMP_GE_OQ);
                    __m256i m = _mm256_sub_epi32(_mm256_srli_epi32(bits, 23), lmo);
                    m = _mm256_min_epi32(_mm256_max_epi32(m, _mm256_setzero_si256()), max_mip);
                    m = _mm256_and_si256(m, _mm256_castps_si256(ge1));
                    const __m256i near = _mm256_and_si256(
                        _mm256_castps_si256(ge1),
                        _mm256_cmpgt_epi32(_mm256_and_si256(bits, _mm256_set1_epi32(0x7FFFFF)),
                                           _mm256_set1_epi32(0x7FFFFF - 64 - 1)));
                    if (!_mm256_testz_si256(near, near)) {
                        float r[8];
                        int32_t mm[8];
                        _mm256_storeu_ps(r, ssR);
                        _mm256_storeu_si256((__m256i *)mm, m);
                        const int nm = _mm256_movemask_ps(_mm256_castsi256_ps(near));
                        for (int l = 0; l < 8; l++)
                            if (nm >> l & 1) {
                                const int e = ao_i_floor_log2f(r[l]) - k->log_max_offset;
                                mm[l] = e < 0 ? 0 : e > k->max_mip ? k->max_mip : e;
                            }
                        m = _mm256_loadu_si256((const __m256i *)mm);
                    }
                    __m256i off = _mm256_permutevar8x32_epi32(t_off[0], m);
                    __m256i str = _mm256_permutevar8x32_epi32(t_stride[0], m);
                    __m256i wm1 = _mm256_permutevar8x32_epi32(t_wm1[0], m);
                    __m256i hm1 = _mm256_permutevar8x32_epi32(t_hm1[0], m);
                    if (deep) {
                        const __m256i hi = _mm256_cmpgt_epi32(m, _mm256_set1_epi32(7));
                        off = _mm256_blendv_epi8(off, _mm256_permutevar8x32_epi32(t_off[1], m), hi);
                        str = _mm256_blendv_epi8(str, _mm256_permutevar8x32_epi32(t_stride[1], m), hi);
                        wm1 = _mm256_blendv_epi8(wm1, _mm256_permutevar8x32_epi32(t_wm1[1], m), hi);
                        hm1 = _mm256_blendv_epi8(hm1, _mm256_permutevar8x32_epi32(t_hm1[1], m), hi);
                    }
                    /* px < 0 ? 0 : px >> mip (arithmetic shift of a negative stays negative) */
                    const __m256i mx = _mm256_min_epi32(_mm256_max_epi32(_mm256_srav_epi32(px, m), _mm256_setzero_si256()), wm1);
                    const __m256i my = _mm256_min_epi32(_mm256_max_epi32(_mm256_srav_epi32(py, m), _mm256_setzero_si256()), hm1);
                    idx = _mm256_add_epi32(_mm256_add_epi32(off, _mm256_mullo_epi32(my, str)), mx);
                }
                b_zq[u] = _mm256_i32gather_ps(base, idx, 4);
                b_ax[u] = coord_x(px, k);
                b_ay[u] = coord_y(py, k);
            }
            for (int u = 0; u < tn; u++) {
                const pos3 Q = cs_pos_v(b_ax[u], b_ay[u], b_zq[u], ortho);
                const __m256 v0 = _mm256_sub_ps(Q.x, C.x), v1 = _mm256_sub_ps(Q.y, C.y), v2 = _mm256_sub_ps(Q.z, C.z);
                const __m256 vv = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, v0), _mm256_mul_ps(v1, v1)),
                                                _mm256_mul_ps(v2, v2));
                const __m256 vn = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(v0, nrm.x), _mm256_mul_ps(v1, nrm.y)),
                                                _mm256_mul_ps(v2, nrm.z));
                if (!hq) {
                    const __m256 f = _mm256_max_ps(_mm256_sub_ps(r2, vv), zero);
                    const __m256 w = _mm256_max_ps(_mm256_div_ps(_mm256_sub_ps(vn, bias), _mm256_add_ps(eps, vv)), zero);
                    sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(f, f), f), w));
                } else {
                    const __m256 f = _mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(vv, inv_r2)), zero);
                    const __m256 w = _mm256_max_ps(
                        _mm256_mul_ps(_mm256_sub_ps(vn, bias), _mm256_div_ps(one, _mm256_sqrt_ps(_mm256_add_ps(eps, vv)))),
                        zero);
                    sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_mul_ps(f, w), angular));
                }
            }
        }
        __m256 A;
        if (!hq) {
            A = _mm256_max_ps(zero, _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(sum, _mm256_set1_ps(k->intensity)),
                                                                     _mm256_set1_ps(k->final_scale))));
        } else {
            const __m256 b = _mm256_max_ps(
                zero, _mm256_sub_ps(one, _mm256_sqrt_ps(_mm256_mul_ps(sum, _mm256_set1_ps(k->final_scale)))));
            float bb[8];
            _mm256_storeu_ps(bb, b);
            const int lm = _mm256_movemask_ps(live);
            for (int l = 0; l < 8; l++)
                bb[l] = lm >> l & 1 ? powf(bb[l], k->intensity) : 1.0f;
            A = _mm256_loadu_ps(bb);
            /* s = saturate(disk - 3): s < 0 ? 0 : s > 1 ? 1 : s; A = 1 (1 - s) + A s */
            const __m256 s = _mm256_min_ps(one, _mm256_max_ps(zero, _mm256_sub_ps(disk, _mm256_set1_ps(3.0f))));
            A = _mm256_add_ps(_mm256_sub_ps(one, s), _mm256_mul_ps(A, s));
        }
        A = _mm256_blendv_ps(one, A, _mm256_cmp_ps(A, A, _CMP_ORD_Q)); /* A == A ? A : 1 */
        A = _mm256_blendv_ps(one, A, live);
        if (n == 8)
            _mm256_storeu_ps(out + i, A);
        else
            _mm256_maskstore_ps(out + i, _mm256_castps_si256(valid), A);
    }
    J->counts[slot][0] = n_bg;
    J->counts[slot][1] = n_degen;
    J->counts[slot][2] = n_minr;
}

void SAO_ROW_FN(const ao_i_sao_job *J, int task)
{
    const ao_sao_constants *k = J->k;
    const int hq = k->variant == AO_SAO_VARIANT_G3D_HQ, mip = k->max_mip > 0;
    if (k->orthographic)
        sao_row_avx2_impl(J, task, hq, 1, mip);
    else if (!hq && !mip)
        sao_row_avx2_impl(J, task, 0, 0, 0);
    else if (!hq)
        sao_row_avx2_impl(J, task, 0, 0, 1);
    else if (!mip)
        sao_row_avx2_impl(J, task, 1, 0, 0);
    else
        sao_row_avx2_impl(J, task, 1, 0, 1);
}

#if !SAO_WIDE /* the blur has no cos/sin: ao_sao_avx512.c uses this one */
/* ---- the blur: 8 destination pixels (gx .. gx+7) of one row per step ------------------------------ */

/* SAO_blur.pix as ao_i_sao_blur_row_scalar, same operations in the same order per lane: taps are
 * contiguous across lanes in both passes (horizontal: columns gx + r stride; vertical: one row per
 * tap), so they are plain loads; a horizontal tap that the edge clamp reaches, and a short last
 * step, gather with clamped indices instead. */
void ao_i_sao_blur_row_avx2(const ao_i_sao_blur_job *J, int task)
{
    enum { R = AO_SAO_BLUR_RADIUS };
    const float *g = ao_sao_blur_gaussian;
    const int gy = J->dy0 + task, S = J->stride, W = J->W, H = J->H, ax0 = J->ax0;
    float *o = obs_image_f32_row(J->dst, task);
    const float *zrow = obs_image_f32_row(J->z, gy);
    const float *arow = obs_image_f32_row(J->a, gy - J->ay0);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), g0 = _mm256_set1_ps(g[0]);
    const __m256 edge_k = _mm256_set1_ps(J->edge_k), absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
    __m256 gw[2 * R + 1];
    const float *ar[2 * R + 1], *zr[2 * R + 1];
    for (int r = -R; r <= R; r++) {
        gw[r + R] = _mm256_set1_ps(0.3f + g[r < 0 ? -r : r]); /* (0.3 + gaussian[|r|]) */
        if (J->axis == 1) {
            int ty = gy + r * S;
            ty = ty < 0 ? 0 : ty > H - 1 ? H - 1 : ty;
            ar[r + R] = obs_image_f32_row(J->a, ty - J->ay0) + (J->dx0 - ax0);
            zr[r + R] = obs_image_f32_row(J->z, ty) + J->dx0;
        }
    }
    const int width = J->dst->width;
    for (int i = 0; i < width; i += 8) {
        const int gx0 = J->dx0 + i, n = width - i < 8 ? width - i : 8;
        const __m256 valid = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane));
        __m256 ca, cz;
        if (n == 8) {
            ca = _mm256_loadu_ps(arow + (gx0 - ax0));
            cz = _mm256_loadu_ps(zrow + gx0);
        } else {
            ca = _mm256_maskload_ps(arow + (gx0 - ax0), _mm256_castps_si256(valid));
            cz = _mm256_maskload_ps(zrow + gx0, _mm256_castps_si256(valid));
        }
        /* key 0 (background): the centre passes through */
        const __m256 bg = _mm256_cmp_ps(cz, zero, _CMP_EQ_OQ);
        if ((_mm256_movemask_ps(bg) | (~_mm256_movemask_ps(valid) & 0xFF)) == 0xFF) {
            _mm256_maskstore_ps(o + i, _mm256_castps_si256(valid), ca);
            continue;
        }
        __m256 sum = _mm256_mul_ps(ca, g0), wsum = g0;
        for (int r = -R; r <= R; r++) {
            if (r == 0)
                continue;
            __m256 ta, tz;
            if (J->axis == 0) {
                const int t0 = gx0 + r * S;
                if (n == 8 && t0 >= 0 && t0 + 7 <= W - 1) {
                    ta = _mm256_loadu_ps(arow + (t0 - ax0));
                    tz = _mm256_loadu_ps(zrow + t0);
                } else { /* clamp(p + axis * r * SCALE, 0, size - 1) per lane */
                    __m256i tx = _mm256_add_epi32(_mm256_set1_epi32(t0), lane);
                    tx = _mm256_min_epi32(_mm256_max_epi32(tx, _mm256_setzero_si256()), _mm256_set1_epi32(W - 1));
                    ta = _mm256_mask_i32gather_ps(zero, arow, _mm256_sub_epi32(tx, _mm256_set1_epi32(ax0)), valid, 4);
                    tz = _mm256_mask_i32gather_ps(zero, zrow, tx, valid, 4);
                }
            } else if (n == 8) {
                ta = _mm256_loadu_ps(ar[r + R] + i);
                tz = _mm256_loadu_ps(zr[r + R] + i);
            } else {
                ta = _mm256_maskload_ps(ar[r + R] + i, _mm256_castps_si256(valid));
                tz = _mm256_maskload_ps(zr[r + R] + i, _mm256_castps_si256(valid));
            }
            /* w = (0.3 + g[|r|]) * max(0, 1 - edgeK * |t.key - c.key|) */
            const __m256 w = _mm256_mul_ps(
                gw[r + R],
                _mm256_max_ps(zero, _mm256_sub_ps(one, _mm256_mul_ps(edge_k, _mm256_and_ps(_mm256_sub_ps(tz, cz), absmask)))));
            sum = _mm256_add_ps(sum, _mm256_mul_ps(ta, w));
            wsum = _mm256_add_ps(wsum, w);
        }
        __m256 res = _mm256_div_ps(sum, _mm256_add_ps(wsum, _mm256_set1_ps(0.0001f)));
        res = _mm256_blendv_ps(res, ca, bg);
        if (n == 8)
            _mm256_storeu_ps(o + i, res);
        else
            _mm256_maskstore_ps(o + i, _mm256_castps_si256(valid), res);
    }
}

#endif /* !SAO_WIDE */

#else
typedef int ao_sao_avx2_unused; /* ISO C: a translation unit is not empty */
#endif
