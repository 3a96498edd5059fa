/* render_test_util.h: helpers shared by the render tests (test_render.c, test_render_mesh_shadow.c). */
#ifndef RENDER_TEST_UTIL_H
#define RENDER_TEST_UTIL_H

#include <string.h>

#include "core/obs.h"

/* n planes equal: both absent, or the same size and the same bytes, row by row. */
static inline int rtu_planes_equal(const obs_image_f32 *a, const obs_image_f32 *b, int n)
{
    for (int c = 0; c < n; c++) {
        if ((a[c].data == NULL) != (b[c].data == NULL))
            return 0;
        if (!a[c].data)
            continue;
        if (a[c].width != b[c].width || a[c].height != b[c].height)
            return 0;
        for (int y = 0; y < a[c].height; y++)
            if (memcmp(obs_image_f32_row(&a[c], y), obs_image_f32_row(&b[c], y), sizeof(float) * (size_t)a[c].width))
                return 0;
    }
    return 1;
}

#endif
