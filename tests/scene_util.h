/* scene_util.h: small procedural scenes for tests (header-only, static). */
#ifndef OBS_TEST_SCENE_UTIL_H
#define OBS_TEST_SCENE_UTIL_H

#include "core/obs.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A scene with one mesh (owned arrays, copied) and one identity instance. */
static inline void tu_scene_one_mesh(obs_scene *s, const float *pos, uint32_t nv, const float *nrm,
                                     const uint32_t *idx, uint32_t nt)
{
    obs_scene_init(s);
    s->meshes = (obs_mesh *)calloc(1, sizeof(obs_mesh));
    s->mesh_count = 1;
    obs_mesh *m = &s->meshes[0];
    strcpy(m->name, "test");
    m->vertex_count = nv;
    m->triangle_count = nt;
    m->positions = (float *)malloc(sizeof(float) * 3 * (nv ? nv : 1));
    memcpy(m->positions, pos, sizeof(float) * 3 * nv);
    if (nrm) {
        m->normals = (float *)malloc(sizeof(float) * 3 * (nv ? nv : 1));
        memcpy(m->normals, nrm, sizeof(float) * 3 * nv);
    }
    m->indices = (uint32_t *)malloc(sizeof(uint32_t) * 3 * (nt ? nt : 1));
    memcpy(m->indices, idx, sizeof(uint32_t) * 3 * nt);
    m->material = -1;
    s->instances = (obs_instance *)calloc(1, sizeof(obs_instance));
    s->instance_count = 1;
    s->instances[0].world = obs_mat4_identity();
    obs_scene_update_bounds(s);
}

/* A UV sphere (smooth normals) of radius r at centre c, with optional radial bumps of
 * relative amplitude `bump`; counter-clockwise outside. */
static inline void tu_sphere(obs_scene *s, int slices, int stacks, float r, obs_vec3 c, float bump)
{
    uint32_t nv = (uint32_t)((slices + 1) * (stacks + 1)), nt = (uint32_t)(2 * slices * stacks);
    float *pos = (float *)malloc(sizeof(float) * 3 * nv), *nrm = (float *)malloc(sizeof(float) * 3 * nv);
    uint32_t *idx = (uint32_t *)malloc(sizeof(uint32_t) * 3 * nt);
    uint32_t k = 0;
    for (int j = 0; j <= stacks; j++)
        for (int i = 0; i <= slices; i++, k++) {
            double th = OBS_PI * j / stacks, ph = 2 * OBS_PI * (i % slices) / slices;
            double n[3] = {sin(th) * cos(ph), cos(th), -sin(th) * sin(ph)};
            double rr = r * (1.0 + bump * sin(7 * th) * sin(5 * ph));
            for (int a = 0; a < 3; a++) {
                pos[3 * k + a] = (float)(rr * n[a]) + (a == 0 ? c.x : a == 1 ? c.y : c.z);
                nrm[3 * k + a] = (float)n[a];
            }
        }
    uint32_t t = 0;
    for (int j = 0; j < stacks; j++)
        for (int i = 0; i < slices; i++) {
            uint32_t a = (uint32_t)(j * (slices + 1) + i), b = a + 1, cc = a + (uint32_t)(slices + 1), d = cc + 1;
            /* outward CCW: (a, c, b) and (b, c, d) with this parameterisation */
            idx[3 * t] = a; idx[3 * t + 1] = cc; idx[3 * t + 2] = b; t++;
            idx[3 * t] = b; idx[3 * t + 1] = cc; idx[3 * t + 2] = d; t++;
        }
    tu_scene_one_mesh(s, pos, nv, nrm, idx, nt);
    free(pos);
    free(nrm);
    free(idx);
}

/* An orthographic camera looking down -Z from z = 0 where one world unit is one pixel:
 * world (x, y) = (px - W/2, H/2 - py). */
static inline obs_camera tu_pixel_ortho(int W, int H)
{
    obs_camera c = obs_camera_look_at(obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(0, 1, 0), 1.0f, 0.0f, 100.0f);
    c.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    c.xmag = 0.5f * W;
    c.ymag = 0.5f * H;
    c.znear = 0.0f;
    c.zfar = 100.0f;
    return c;
}

#endif
