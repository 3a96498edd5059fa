/* raster_tile_avx2.c: the AVX2 tile rasterizer. Compiled with -mavx2 only (no FMA), selected
 * at run time. Lanes: 4 horizontally adjacent pixels (x, x+1, x+2, x+3) of one row.
 * Small triangles (t->small: at most 64 px across) use 8 lanes of 32-bit integers, (x .. x+7),
 * exact because |E| < 2^30 for them. Others use 4 lanes of doubles holding exact integers
 * (|E| < 2^49 < 2^53, see raster_internal.h). Either way coverage is identical to the int64
 * scalar path; the key uses the same float expression as
 * rast_i_key, in the same order, so depth tests agree bit for bit. */
#include "raster_internal.h"

#if defined(OBS_HAVE_AVX2)
#include <immintrin.h>
#include <math.h>

/* One small triangle, 8 pixels of a row at a time, edges in exact int32 lanes. */
static void tile_small(const rast_i_tri *t, int x0, int y0, int x1, int y1, int tx0, int ty0, int stride, float *key,
                       uint32_t *inst, uint32_t *prim)
{
    const __m256i lane8 = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    int32_t e_row[3], sx[3], sy[3];
    __m256i off[3], bm1[3];
    for (int i = 0; i < 3; i++) {
        e_row[i] = (int32_t)((int64_t)t->A[i] * (256 * (int64_t)x0 + 128) + (int64_t)t->B[i] * (256 * (int64_t)y0 + 128) +
                             t->C[i]);
        sx[i] = 256 * t->A[i];
        sy[i] = 256 * t->B[i];
        off[i] = _mm256_mullo_epi32(lane8, _mm256_set1_epi32(sx[i]));
        bm1[i] = _mm256_set1_epi32(t->bias[i] - 1); /* E >= bias  <=>  E > bias - 1 */
    }
    const __m256 k0 = _mm256_set1_ps(t->k0), kx = _mm256_set1_ps(t->kx), ky = _mm256_set1_ps(t->ky);
    const __m256 ox = _mm256_set1_ps(t->ox), oy = _mm256_set1_ps(t->oy);
    const __m256i inst_v = _mm256_set1_epi32((int)t->instance), prim_v = _mm256_set1_epi32((int)t->prim);
    const __m256i xlast = _mm256_set1_epi32(x1);
    for (int y = y0; y <= y1; y++) {
        const __m256 ky_dy = _mm256_mul_ps(ky, _mm256_sub_ps(_mm256_set1_ps((float)y + 0.5f), oy));
        int row = (y - ty0) * stride - tx0;
        for (int x = x0; x <= x1; x += 8) {
            int32_t dx = x - x0;
            __m256i m = _mm256_cmpgt_epi32(_mm256_add_epi32(_mm256_set1_epi32(e_row[0] + dx * sx[0]), off[0]), bm1[0]);
            m = _mm256_and_si256(m, _mm256_cmpgt_epi32(_mm256_add_epi32(_mm256_set1_epi32(e_row[1] + dx * sx[1]), off[1]), bm1[1]));
            m = _mm256_and_si256(m, _mm256_cmpgt_epi32(_mm256_add_epi32(_mm256_set1_epi32(e_row[2] + dx * sx[2]), off[2]), bm1[2]));
            __m256i xs = _mm256_add_epi32(_mm256_set1_epi32(x), lane8);
            m = _mm256_andnot_si256(_mm256_cmpgt_epi32(xs, xlast), m);
            if (_mm256_testz_si256(m, m))
                continue;
            /* key = k0 + kx*(fx - ox) + ky*(fy - oy), as rast_i_key */
            __m256 fx = _mm256_add_ps(_mm256_cvtepi32_ps(xs), _mm256_set1_ps(0.5f));
            __m256 z = _mm256_add_ps(_mm256_add_ps(k0, _mm256_mul_ps(kx, _mm256_sub_ps(fx, ox))), ky_dy);
            float *kp = key + row + x;
            __m256 old = _mm256_maskload_ps(kp, m);
            __m256i win = _mm256_and_si256(m, _mm256_castps_si256(_mm256_cmp_ps(z, old, _CMP_GT_OQ)));
            if (_mm256_testz_si256(win, win))
                continue;
            _mm256_maskstore_ps(kp, win, z);
            _mm256_maskstore_epi32((int *)(inst + row + x), win, inst_v);
            _mm256_maskstore_epi32((int *)(prim + row + x), win, prim_v);
        }
        for (int i = 0; i < 3; i++)
            e_row[i] += sy[i];
    }
}

void rast_i_tile_avx2(const rast_i_tri *tris, const uint32_t *list, uint32_t n, int tx0, int ty0, int tw, int th,
                      int stride, float *key, uint32_t *inst, uint32_t *prim)
{
    const __m128i lane_idx = _mm_setr_epi32(0, 1, 2, 3);
    const __m256d lane_d = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0);
    for (uint32_t k = 0; k < n; k++) {
        const rast_i_tri *t = &tris[list[k]];
        /* Records are visited through the bin list: fetch a few ahead (a hint only; the first
         * touch of each record was the tile loop's main stall). */
        if (k + 4 < n) {
            __builtin_prefetch(&tris[list[k + 4]]);
            __builtin_prefetch((const char *)&tris[list[k + 4]] + 64);
        }
        int x0 = t->minx > tx0 ? t->minx : tx0;
        int y0 = t->miny > ty0 ? t->miny : ty0;
        int x1 = t->maxx < tx0 + tw - 1 ? t->maxx : tx0 + tw - 1;
        int y1 = t->maxy < ty0 + th - 1 ? t->maxy : ty0 + th - 1;
        if (x0 > x1 || y0 > y1)
            continue;
        if (t->small) {
            tile_small(t, x0, y0, x1, y1, tx0, ty0, stride, key, inst, prim);
            continue;
        }
        int64_t e_row[3], step_x[3];
        __m256d lane_off[3], bias[3];
        for (int i = 0; i < 3; i++) {
            e_row[i] = (int64_t)t->A[i] * (256 * (int64_t)x0 + 128) + (int64_t)t->B[i] * (256 * (int64_t)y0 + 128) +
                       t->C[i];
            step_x[i] = 256 * (int64_t)t->A[i];
            lane_off[i] = _mm256_mul_pd(lane_d, _mm256_set1_pd((double)step_x[i])); /* exact: < 2^27 */
            bias[i] = _mm256_set1_pd((double)t->bias[i]);
        }
        const __m128 k0 = _mm_set1_ps(t->k0), kx = _mm_set1_ps(t->kx), ky = _mm_set1_ps(t->ky);
        const __m128 ox = _mm_set1_ps(t->ox), oy = _mm_set1_ps(t->oy);
        const __m128i inst_v = _mm_set1_epi32((int)t->instance), prim_v = _mm_set1_epi32((int)t->prim);
        const __m128i xlast = _mm_set1_epi32(x1);
        for (int y = y0; y <= y1; y++) {
            const __m128 dy = _mm_sub_ps(_mm_set1_ps((float)y + 0.5f), oy);
            const __m128 ky_dy = _mm_mul_ps(ky, dy);
            int row = (y - ty0) * stride - tx0;
            for (int x = x0; x <= x1; x += 4) {
                int64_t dx = x - x0;
                __m256d m = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
                for (int i = 0; i < 3; i++) {
                    __m256d e = _mm256_add_pd(_mm256_set1_pd((double)(e_row[i] + dx * step_x[i])), lane_off[i]);
                    m = _mm256_and_pd(m, _mm256_cmp_pd(e, bias[i], _CMP_GE_OQ));
                }
                int bits = _mm256_movemask_pd(m);
                if (!bits)
                    continue;
                /* 4 coverage bits -> 4 x 32-bit lane mask, and the lanes inside the bbox. */
                __m128i xs = _mm_add_epi32(_mm_set1_epi32(x), lane_idx);
                __m128i cover = _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(bits), _mm_setr_epi32(1, 2, 4, 8)),
                                                _mm_setr_epi32(1, 2, 4, 8));
                __m128i valid = _mm_andnot_si128(_mm_cmpgt_epi32(xs, xlast), cover);
                /* key = k0 + kx*(fx - ox) + ky*(fy - oy), as rast_i_key */
                __m128 fx = _mm_add_ps(_mm_cvtepi32_ps(xs), _mm_set1_ps(0.5f));
                __m128 z = _mm_add_ps(_mm_add_ps(k0, _mm_mul_ps(kx, _mm_sub_ps(fx, ox))), ky_dy);
                float *kp = key + row + x;
                __m128 old = _mm_maskload_ps(kp, valid);
                __m128i win = _mm_and_si128(valid, _mm_castps_si128(_mm_cmpgt_ps(z, old)));
                if (_mm_testz_si128(win, win))
                    continue;
                _mm_maskstore_ps(kp, win, z);
                _mm_maskstore_epi32((int *)(inst + row + x), win, inst_v);
                _mm_maskstore_epi32((int *)(prim + row + x), win, prim_v);
            }
            for (int i = 0; i < 3; i++)
                e_row[i] += 256 * (int64_t)t->B[i];
        }
    }
}
#endif

#if defined(OBS_HAVE_AVX2)
/* The resolve of 4 adjacent pixels showing one triangle. Lanes: pixels px0 .. px0+3 of a row.
 * Every expression is the scalar resolve's (raster.c, resolve_row), term for term and in the
 * same order, with IEEE operations only (no FMA, exact sqrt and division), so the outputs are
 * the same bits. */
int rast_i_resolve4_avx2(const resolve_tri *r, out_rows *o, int i, int px0, double ay, double cx, double inv_fx,
                         int ortho, int face_forward)
{
    const __m256d ax = _mm256_mul_pd(
        _mm256_sub_pd(_mm256_add_pd(_mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(px0), _mm_setr_epi32(0, 1, 2, 3))),
                                    _mm256_set1_pd(0.5)),
                      _mm256_set1_pd(cx)),
        _mm256_set1_pd(inv_fx));
    const __m256d vay = _mm256_set1_pd(ay);
    __m256d nd, t, b1, b2;
    if (!ortho) {
        nd = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->n.x), ax), _mm256_mul_pd(_mm256_set1_pd(r->n.y), vay)),
                           _mm256_set1_pd(r->n.z));
        t = _mm256_div_pd(_mm256_set1_pd(r->n_v0), nd);
        __m256d d1 = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->m1.x), ax), _mm256_mul_pd(_mm256_set1_pd(r->m1.y), vay)),
                                   _mm256_set1_pd(r->m1.z));
        __m256d d2 = _mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->m2.x), ax), _mm256_mul_pd(_mm256_set1_pd(r->m2.y), vay)),
                                   _mm256_set1_pd(r->m2.z));
        b1 = _mm256_sub_pd(_mm256_mul_pd(t, d1), _mm256_set1_pd(r->c1));
        b2 = _mm256_sub_pd(_mm256_mul_pd(t, d2), _mm256_set1_pd(r->c2));
    } else {
        nd = _mm256_set1_pd(-r->n.z);
        t = _mm256_div_pd(_mm256_sub_pd(_mm256_sub_pd(_mm256_set1_pd(r->n_v0), _mm256_mul_pd(_mm256_set1_pd(r->n.x), ax)),
                                        _mm256_mul_pd(_mm256_set1_pd(r->n.y), vay)),
                          nd);
        b1 = _mm256_sub_pd(_mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->m1.x), ax), _mm256_mul_pd(_mm256_set1_pd(r->m1.y), vay)),
                                         _mm256_mul_pd(_mm256_set1_pd(r->m1.z), t)),
                           _mm256_set1_pd(r->c1));
        b2 = _mm256_sub_pd(_mm256_sub_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(r->m2.x), ax), _mm256_mul_pd(_mm256_set1_pd(r->m2.y), vay)),
                                         _mm256_mul_pd(_mm256_set1_pd(r->m2.z), t)),
                           _mm256_set1_pd(r->c2));
    }
    /* The scalar fallback (t <= 0, NaN, or outside [t_lo, t_hi]: an edge-on triangle, F8) is
     * left to the caller. */
    __m256d ok = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(t, _mm256_setzero_pd(), _CMP_GT_OQ),
                                             _mm256_cmp_pd(t, _mm256_set1_pd(r->t_lo), _CMP_GE_OQ)),
                               _mm256_cmp_pd(t, _mm256_set1_pd(r->t_hi), _CMP_LE_OQ));
    if (_mm256_movemask_pd(ok) != 0xF)
        return 0;
    _mm256_storeu_pd(o->depth_exact, t);
    const __m128 flip = face_forward
                            ? _mm_blendv_ps(_mm_set1_ps(1.0f), _mm_set1_ps(-1.0f),
                                            _mm256_cvtpd_ps(_mm256_and_pd(_mm256_cmp_pd(nd, _mm256_setzero_pd(), _CMP_GT_OQ),
                                                                          _mm256_set1_pd(-1.0))))
                            : _mm_set1_ps(1.0f);
    if (o->depth)
        _mm_storeu_ps(o->depth + i, _mm256_cvtpd_ps(t));
    if (o->ng[0]) {
        _mm_storeu_ps(o->ng[0] + i, _mm_mul_ps(flip, _mm_set1_ps((float)r->nunit.x)));
        _mm_storeu_ps(o->ng[1] + i, _mm_mul_ps(flip, _mm_set1_ps((float)r->nunit.y)));
        _mm_storeu_ps(o->ng[2] + i, _mm_mul_ps(flip, _mm_set1_ps((float)r->nunit.z)));
    }
    if (o->n[0]) {
        __m128 nsx = _mm_set1_ps((float)r->nunit.x), nsy = _mm_set1_ps((float)r->nunit.y), nsz = _mm_set1_ps((float)r->nunit.z);
        if (r->has_vn) {
            const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
            /* b < 0 ? 0 : (b > 1 ? 1 : b), as the scalar code */
            b1 = _mm256_blendv_pd(_mm256_blendv_pd(b1, one, _mm256_cmp_pd(b1, one, _CMP_GT_OQ)), zero,
                                  _mm256_cmp_pd(b1, zero, _CMP_LT_OQ));
            b2 = _mm256_blendv_pd(_mm256_blendv_pd(b2, one, _mm256_cmp_pd(b2, one, _CMP_GT_OQ)), zero,
                                  _mm256_cmp_pd(b2, zero, _CMP_LT_OQ));
            __m256d sum = _mm256_add_pd(b1, b2);
            __m256d over = _mm256_cmp_pd(sum, one, _CMP_GT_OQ);
            __m256d sc = _mm256_div_pd(one, sum);
            b1 = _mm256_blendv_pd(b1, _mm256_mul_pd(b1, sc), over);
            b2 = _mm256_blendv_pd(b2, _mm256_mul_pd(b2, sc), over);
            __m128 fb1 = _mm256_cvtpd_ps(b1), fb2 = _mm256_cvtpd_ps(b2);
            __m128 fb0 = _mm_sub_ps(_mm_sub_ps(_mm_set1_ps(1.0f), fb1), fb2);
            __m128 s[3];
            for (int c = 0; c < 3; c++)
                s[c] = _mm_add_ps(_mm_add_ps(_mm_mul_ps(fb0, _mm_set1_ps(r->vn[0][c])), _mm_mul_ps(fb1, _mm_set1_ps(r->vn[1][c]))),
                                  _mm_mul_ps(fb2, _mm_set1_ps(r->vn[2][c])));
            __m128 l2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(s[0], s[0]), _mm_mul_ps(s[1], s[1])), _mm_mul_ps(s[2], s[2]));
            __m128 use = _mm_cmpgt_ps(l2, _mm_set1_ps(1e-12f));
            __m128 il = _mm_div_ps(_mm_set1_ps(1.0f), _mm_sqrt_ps(l2));
            nsx = _mm_blendv_ps(nsx, _mm_mul_ps(s[0], il), use);
            nsy = _mm_blendv_ps(nsy, _mm_mul_ps(s[1], il), use);
            nsz = _mm_blendv_ps(nsz, _mm_mul_ps(s[2], il), use);
        }
        _mm_storeu_ps(o->n[0] + i, _mm_mul_ps(flip, nsx));
        _mm_storeu_ps(o->n[1] + i, _mm_mul_ps(flip, nsy));
        _mm_storeu_ps(o->n[2] + i, _mm_mul_ps(flip, nsz));
    }
    if (o->prim)
        _mm_storeu_si128((__m128i *)(o->prim + i), _mm_set1_epi32((int)r->prim));
    if (o->inst)
        _mm_storeu_si128((__m128i *)(o->inst + i), _mm_set1_epi32((int)r->inst));
    if (o->mat)
        _mm_storeu_si128((__m128i *)(o->mat + i), _mm_set1_epi32((int)r->material));
    return 1;
}
#endif
