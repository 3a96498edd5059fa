/* scene_util.h: small procedural scenes for tests (header-only, static). */
#ifndef OBS_TEST_SCENE_UTIL_H
#define OBS_TEST_SCENE_UTIL_H

#include "core/obs.h"

#include <math.h>
#include <stdio.h>
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

/* Append a mesh (double positions, copied as floats) and one identity instance of it. */
static inline void tu_add_mesh(obs_scene *s, const char *name, const double *pos, uint32_t nv, const uint32_t *idx,
                               uint32_t nt, int32_t material)
{
    s->meshes = (obs_mesh *)realloc(s->meshes, sizeof(obs_mesh) * (s->mesh_count + 1));
    obs_mesh *m = &s->meshes[s->mesh_count];
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->vertex_count = nv;
    m->triangle_count = nt;
    m->positions = (float *)malloc(sizeof(float) * 3 * nv);
    for (uint32_t i = 0; i < 3 * nv; i++)
        m->positions[i] = (float)pos[i];
    m->indices = (uint32_t *)malloc(sizeof(uint32_t) * 3 * nt);
    memcpy(m->indices, idx, sizeof(uint32_t) * 3 * nt);
    m->material = material;
    s->instances = (obs_instance *)realloc(s->instances, sizeof(obs_instance) * (s->instance_count + 1));
    obs_instance *in = &s->instances[s->instance_count];
    memset(in, 0, sizeof *in);
    in->mesh = s->mesh_count;
    in->node = s->instance_count;
    in->world = obs_mat4_identity();
    s->mesh_count++;
    s->instance_count++;
    obs_scene_update_bounds(s);
}

/* The closed box [-L, L]^2 x [-T, 0], outward counter-clockwise. */
static inline void tu_add_box(obs_scene *s, const char *name, double L, double T, int32_t material)
{
    double p[24];
    for (int k = 0; k < 8; k++) {
        p[3 * k] = (k & 1) ? L : -L;
        p[3 * k + 1] = (k & 2) ? L : -L;
        p[3 * k + 2] = (k & 4) ? 0.0 : -T;
    }
    /* faces as quads (a, b, c, d) counter-clockwise from outside */
    static const uint32_t q[6][4] = {{4, 5, 7, 6}, {0, 2, 3, 1}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    uint32_t idx[36];
    for (int f = 0; f < 6; f++) {
        uint32_t *t = idx + 6 * f;
        t[0] = q[f][0]; t[1] = q[f][1]; t[2] = q[f][2];
        t[3] = q[f][0]; t[4] = q[f][2]; t[5] = q[f][3];
    }
    tu_add_mesh(s, name, p, 8, idx, 12, material);
}

/* Append a light named "light<i>" of the given type, position, direction, colour and intensity. */
static inline void tu_add_light(obs_scene *s, obs_light_type type, obs_vec3 pos, obs_vec3 dir, obs_vec3 color,
                                float intensity)
{
    s->lights = (obs_light *)realloc(s->lights, sizeof(obs_light) * (s->light_count + 1));
    obs_light *l = &s->lights[s->light_count++];
    memset(l, 0, sizeof *l);
    snprintf(l->name, sizeof l->name, "light%u", s->light_count - 1);
    l->type = type;
    l->color = color;
    l->intensity = intensity;
    l->position = pos;
    l->direction = dir;
}

#endif
