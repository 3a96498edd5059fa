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
