/* volume_test_util.h: lights shared by the light-volume tests (test_volume_light.c,
 * test_volume_occupancy.c), and RGBA plane helpers shared by the ray-caster tests. */
#ifndef VOLUME_TEST_UTIL_H
#define VOLUME_TEST_UTIL_H

#include <math.h>
#include <string.h>

#include "volume/vol.h"

/* A white directional light travelling along (x, y, z) (normalised). */
static inline vol_light vtu_dir_light(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    const double n = sqrt(x * x + y * y + z * z);
    L.direction[0] = x / n, L.direction[1] = y / n, L.direction[2] = z / n;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

/* A white point light at (x, y, z). */
static inline vol_light vtu_point_light(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_POINT;
    L.position[0] = x, L.position[1] = y, L.position[2] = z;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}


/* RGBA image planes (vol_raycast output): free, compare byte for byte, largest difference. */
static inline void vtu_free4(obs_image_f32 im[4])
{
    for (int c = 0; c < 4; c++)
        obs_image_f32_free(&im[c]);
}

/* Byte-identical RGBA planes (sizes too). */
static inline int vtu_same4(const obs_image_f32 a[4], const obs_image_f32 b[4])
{
    for (int c = 0; c < 4; c++) {
        if (a[c].width != b[c].width || a[c].height != b[c].height)
            return 0;
        for (int y = 0; y < a[c].height; y++)
            if (memcmp(obs_image_f32_row(&a[c], y), obs_image_f32_row(&b[c], y), sizeof(float) * a[c].width) != 0)
                return 0;
    }
    return 1;
}

static inline double vtu_maxdiff4(const obs_image_f32 a[4], const obs_image_f32 b[4])
{
    double m = 0.0;
    for (int c = 0; c < 4; c++)
        for (int y = 0; y < a[c].height; y++)
            for (int x = 0; x < a[c].width; x++) {
                double d = fabs((double)obs_image_f32_row(&a[c], y)[x] - (double)obs_image_f32_row(&b[c], y)[x]);
                if (d > m)
                    m = d;
            }
    return m;
}

#endif
