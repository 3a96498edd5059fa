/* raster_tile_scalar.c: the scalar tile rasterizer (always compiled; the reference for AVX2). */
#include "raster_internal.h"

void rast_i_tile_scalar(const rast_i_tri *tris, const uint32_t *list, uint32_t n, int tx0, int ty0, int tw,
                        int th, int stride, float *key, uint32_t *inst, uint32_t *prim)
{
    for (uint32_t k = 0; k < n; k++) {
        const rast_i_tri *t = &tris[list[k]];
        /* Records are visited through the bin list: fetch a few ahead (a hint only; the first
         * touch of each record was the tile loop's main stall). */
        if (k + 4 < n) {
            __builtin_prefetch(&tris[list[k + 4]]);
            __builtin_prefetch((const char *)&tris[list[k + 4]] + 64);
        }
        /* Clip the triangle's pixel bbox to the tile. */
        int x0 = t->minx > tx0 ? t->minx : tx0;
        int y0 = t->miny > ty0 ? t->miny : ty0;
        int x1 = t->maxx < tx0 + tw - 1 ? t->maxx : tx0 + tw - 1;
        int y1 = t->maxy < ty0 + th - 1 ? t->maxy : ty0 + th - 1;
        if (x0 > x1 || y0 > y1)
            continue;
        /* Edge values at the first pixel centre, then exact integer steps. */
        int64_t e_row[3];
        for (int i = 0; i < 3; i++)
            e_row[i] = (int64_t)t->A[i] * (256 * (int64_t)x0 + 128) + (int64_t)t->B[i] * (256 * (int64_t)y0 + 128) +
                       t->C[i];
        for (int y = y0; y <= y1; y++) {
            int64_t e0 = e_row[0], e1 = e_row[1], e2 = e_row[2];
            int row = (y - ty0) * stride - tx0;
            for (int x = x0; x <= x1; x++) {
                if (e0 >= t->bias[0] && e1 >= t->bias[1] && e2 >= t->bias[2]) {
                    float z = rast_i_key(t, x, y);
                    if (z > key[row + x]) {
                        key[row + x] = z;
                        inst[row + x] = t->instance;
                        prim[row + x] = t->prim;
                    }
                }
                e0 += 256 * (int64_t)t->A[0];
                e1 += 256 * (int64_t)t->A[1];
                e2 += 256 * (int64_t)t->A[2];
            }
            for (int i = 0; i < 3; i++)
                e_row[i] += 256 * (int64_t)t->B[i];
        }
    }
}
