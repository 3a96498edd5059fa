/* sss_combine_avx2.c: the combination's map loop (sss_combine.c, pixel_maps_scalar, PRODUCT5
 * visibility) on 4 pixels per vector, in double. Compiled with -mavx2 (no FMA); selected by the
 * params' ISA like the maps.
 *
 * Lanes are 4 translucent pixels of a row (the caller packs them; pad lanes repeat lane 0 and are
 * not written back). Every lane runs the scalar loop's double operations in the same order:
 *   - +, -, *, / are IEEE in both; no FMA (-ffp-contract=off, no -mfma);
 *   - the scalar `continue`s (facing, bounds, a shadowed tap) become a lane mask; a lane's acc,
 *     sumv and seen change only where its mask is set, by the same additions (v = 1 for a lit
 *     lane: acc + 1 r = acc + r);
 *   - the scalar (int) truncation is CVTTPD2DQ (both give INT_MIN for out-of-range values), the
 *     clamps are integer max/min, floor is ROUNDPD toward -inf (exact, as the scalar floor);
 *   - depth and radiance texels are gathered as floats and widened exactly.
 * So the two paths give the same bits (test sss_combination_avx2_matches_scalar_bit_for_bit). */
#include "sss_maps_internal.h"

#if defined(OBS_HAVE_AVX2)
#include <immintrin.h>

typedef __m256d vd;
#define DSET(x) _mm256_set1_pd(x)
#define DADD(a, b) _mm256_add_pd(a, b)
#define DSUB(a, b) _mm256_sub_pd(a, b)
#define DMUL(a, b) _mm256_mul_pd(a, b)
#define DDIV(a, b) _mm256_div_pd(a, b)
#define DAND(a, b) _mm256_and_pd(a, b)
#define DSEL(mask, a, b) _mm256_blendv_pd(b, a, mask)

/* ((r[0] p0 + r[1] p1) + r[2] p2) (+ r[3] when affine) */
static inline vd vrow(const double r[4], vd p0, vd p1, vd p2)
{
    return DADD(DADD(DMUL(DSET(r[0]), p0), DMUL(DSET(r[1]), p1)), DMUL(DSET(r[2]), p2));
}

/* clamp(i, 0, n - 1) on 4 int32 */
static inline __m128i vclamp(__m128i i, int n)
{
    return _mm_min_epi32(_mm_max_epi32(i, _mm_setzero_si128()), _mm_set1_epi32(n - 1));
}

/* 4 floats of plane `base` at int32 offsets `o` (lanes outside `mask` read nothing, give 0), widened */
static inline vd vgather(const float *base, __m128i o, vd mask)
{
    /* the low halves of the 64-bit lane masks as 32-bit lane masks */
    const __m256i m = _mm256_permutevar8x32_epi32(_mm256_castpd_si256(mask), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0));
    return _mm256_cvtps_pd(_mm_mask_i32gather_ps(_mm_setzero_ps(), base, o, _mm256_castps256_ps128(_mm256_castsi256_ps(m)), 4));
}

/* one shadow tap (sss_combine.c tap_fast) of 4 lanes: lit mask */
static inline vd vtap(const sss_i_combine_map *c, vd px, vd py, vd d0, vd px0, vd py0, vd gx, vd gy, vd bias, vd mask)
{
    const __m128i ix = vclamp(_mm256_cvttpd_epi32(px), c->W), iy = vclamp(_mm256_cvttpd_epi32(py), c->H);
    const vd half = DSET(0.5);
    const vd d = DADD(DADD(d0, DMUL(gx, DSUB(DADD(_mm256_cvtepi32_pd(ix), half), px0))),
                      DMUL(gy, DSUB(DADD(_mm256_cvtepi32_pd(iy), half), py0)));
    const __m128i o = _mm_add_epi32(_mm_mullo_epi32(iy, _mm_set1_epi32((int)c->dstride)), ix);
    const vd z = vgather(c->depth, o, mask);
    return DAND(mask, _mm256_cmp_pd(DSUB(d, bias), z, _CMP_LE_OQ));
}

void sss_i_combine_maps_avx2(const sss_i_combine_map *cm, int K, double eps, double bias, const double xo[3][4],
                             const double no[3][4], double acc[3][4], double sumv[4], int seen[4])
{
    const vd xo0 = _mm256_loadu_pd(xo[0]), xo1 = _mm256_loadu_pd(xo[1]), xo2 = _mm256_loadu_pd(xo[2]);
    const vd no0 = _mm256_loadu_pd(no[0]), no1 = _mm256_loadu_pd(no[1]), no2 = _mm256_loadu_pd(no[2]);
    const vd zero = DSET(0.0), one = DSET(1.0), half = DSET(0.5), veps = DSET(eps), vbias = DSET(bias);
    const vd neg = DSET(-0.0);
    vd a0 = zero, a1 = zero, a2 = zero, sv = zero;
    __m256i cnt = _mm256_setzero_si256();
    for (int k = 0; k < K; k++) {
        const sss_i_combine_map *c = &cm[k];
        /* facing: !(nvz > SSS_I_MIN_FACING) skips */
        const vd nvz = vrow(c->r2, no0, no1, no2);
        vd mask = _mm256_cmp_pd(nvz, DSET(SSS_I_MIN_FACING), _CMP_GT_OQ);
        if (_mm256_testz_pd(mask, mask))
            continue;
        /* the shrink: nd = (no0 wd0 + no1 wd1) + no2 wd2, xs = xo - eps (no - wd nd) */
        const vd wd0 = DSET(c->wd[0]), wd1 = DSET(c->wd[1]), wd2 = DSET(c->wd[2]);
        const vd nd = DADD(DADD(DMUL(no0, wd0), DMUL(no1, wd1)), DMUL(no2, wd2));
        const vd xs0 = DSUB(xo0, DMUL(veps, DSUB(no0, DMUL(wd0, nd))));
        const vd xs1 = DSUB(xo1, DMUL(veps, DSUB(no1, DMUL(wd1, nd))));
        const vd xs2 = DSUB(xo2, DMUL(veps, DSUB(no2, DMUL(wd2, nd))));
        const vd cx = DSET(c->cx), cy = DSET(c->cy), fx = DSET(c->fx), fy = DSET(c->fy);
        const vd px = DADD(cx, DMUL(fx, DADD(vrow(c->r0, xs0, xs1, xs2), DSET(c->r0[3]))));
        const vd py = DSUB(cy, DMUL(fy, DADD(vrow(c->r1, xs0, xs1, xs2), DSET(c->r1[3]))));
        /* bounds: px < 0 || py < 0 || px >= W || py >= H skips (unordered compares keep NaN lanes, as
         * the scalar test does) */
        const vd W = DSET((double)c->W), H = DSET((double)c->H);
        mask = DAND(mask, DAND(DAND(_mm256_cmp_pd(px, zero, _CMP_NLT_UQ), _mm256_cmp_pd(py, zero, _CMP_NLT_UQ)),
                               DAND(_mm256_cmp_pd(px, W, _CMP_NGE_UQ), _mm256_cmp_pd(py, H, _CMP_NGE_UQ))));
        if (_mm256_testz_pd(mask, mask))
            continue;
        /* the receiver plane */
        const vd nvx = vrow(c->r0, no0, no1, no2), nvy = vrow(c->r1, no0, no1, no2);
        const vd px0 = DADD(cx, DMUL(fx, DADD(vrow(c->r0, xo0, xo1, xo2), DSET(c->r0[3]))));
        const vd py0 = DSUB(cy, DMUL(fy, DADD(vrow(c->r1, xo0, xo1, xo2), DSET(c->r1[3]))));
        const vd d0 = _mm256_xor_pd(DADD(vrow(c->r2, xo0, xo1, xo2), DSET(c->r2[3])), neg);
        const vd gx = DDIV(nvx, DMUL(nvz, fx));
        const vd gy = DDIV(_mm256_xor_pd(nvy, neg), DMUL(nvz, fy));
        /* PRODUCT5: the centre and the rotated grid */
        mask = vtap(c, px, py, d0, px0, py0, gx, gy, vbias, mask);
        if (_mm256_testz_pd(mask, mask))
            continue;
        mask = vtap(c, DADD(px, DSET(0.5)), DADD(py, DSET(1.5)), d0, px0, py0, gx, gy, vbias, mask);
        if (_mm256_testz_pd(mask, mask))
            continue;
        mask = vtap(c, DADD(px, DSET(-1.5)), DADD(py, DSET(0.5)), d0, px0, py0, gx, gy, vbias, mask);
        if (_mm256_testz_pd(mask, mask))
            continue;
        mask = vtap(c, DADD(px, DSET(-0.5)), DADD(py, DSET(-1.5)), d0, px0, py0, gx, gy, vbias, mask);
        if (_mm256_testz_pd(mask, mask))
            continue;
        mask = vtap(c, DADD(px, DSET(1.5)), DADD(py, DSET(-0.5)), d0, px0, py0, gx, gy, vbias, mask);
        if (_mm256_testz_pd(mask, mask))
            continue;
        /* bilinear (GL_LINEAR, clamp to edge) */
        const vd u = DSUB(px, half), vv = DSUB(py, half);
        const vd fu = _mm256_floor_pd(u), fv = _mm256_floor_pd(vv);
        const vd a = DSUB(u, fu), b = DSUB(vv, fv);
        const __m128i x0 = _mm256_cvttpd_epi32(fu), y0 = _mm256_cvttpd_epi32(fv);
        const __m128i one_i = _mm_set1_epi32(1);
        const __m128i xa = vclamp(x0, c->W), xb = vclamp(_mm_add_epi32(x0, one_i), c->W);
        const __m128i ya = vclamp(y0, c->H), yb = vclamp(_mm_add_epi32(y0, one_i), c->H);
        const __m128i rs = _mm_set1_epi32((int)c->rstride);
        const __m128i ra = _mm_mullo_epi32(ya, rs), rb = _mm_mullo_epi32(yb, rs);
        const __m128i o00 = _mm_add_epi32(ra, xa), o01 = _mm_add_epi32(ra, xb);
        const __m128i o10 = _mm_add_epi32(rb, xa), o11 = _mm_add_epi32(rb, xb);
        const vd oa = DSUB(one, a), ob = DSUB(one, b);
        vd r[3];
        for (int ch = 0; ch < 3; ch++) {
            const float *pl = c->rad[ch];
            const vd top = DADD(DMUL(oa, vgather(pl, o00, mask)), DMUL(a, vgather(pl, o01, mask)));
            const vd bot = DADD(DMUL(oa, vgather(pl, o10, mask)), DMUL(a, vgather(pl, o11, mask)));
            /* v r with v = 1 */
            r[ch] = DMUL(one, DADD(DMUL(ob, top), DMUL(b, bot)));
        }
        a0 = DSEL(mask, DADD(a0, r[0]), a0);
        a1 = DSEL(mask, DADD(a1, r[1]), a1);
        a2 = DSEL(mask, DADD(a2, r[2]), a2);
        sv = DSEL(mask, DADD(sv, one), sv);
        cnt = _mm256_sub_epi64(cnt, _mm256_castpd_si256(mask));
    }
    _mm256_storeu_pd(acc[0], a0);
    _mm256_storeu_pd(acc[1], a1);
    _mm256_storeu_pd(acc[2], a2);
    _mm256_storeu_pd(sumv, sv);
    int64_t c4[4];
    _mm256_storeu_si256((__m256i *)c4, cnt);
    for (int q = 0; q < 4; q++)
        seen[q] = (int)c4[q];
}

#endif /* OBS_HAVE_AVX2 */
