/* volume_test_util.h: lights shared by the light-volume tests (test_volume_light.c,
 * test_volume_occupancy.c). */
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

#endif
