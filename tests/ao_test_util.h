/* ao_test_util.h: scenes, G-buffers and synthetic depth buffers shared by the AO tests
 * (header-only, static). */
#ifndef OBS_AO_TEST_UTIL_H
#define OBS_AO_TEST_UTIL_H

#include "ao/ao.h"
#include "scene_util.h"

/* A bumpy UV sphere of radius 1 at (0, 0, -4) (slices x stacks, radial bump amplitude `bump`) over
 * a ground quad at y = ground_y reaching +-half_width in x and from z = 10 to z = far_z. */
static inline void tu_sphere_over_ground(obs_scene *s, int slices, int stacks, float bump, float ground_y,
                                         float half_width, float far_z)
{
    tu_sphere(s, slices, stacks, 1.0f, obs_v3(0.0f, 0.0f, -4.0f), bump);
    obs_mesh *m = &s->meshes[0];
    uint32_t nv = m->vertex_count, nt = m->triangle_count;
    m->positions = (float *)realloc(m->positions, sizeof(float) * 3 * (nv + 4));
    m->normals = (float *)realloc(m->normals, sizeof(float) * 3 * (nv + 4));
    m->indices = (uint32_t *)realloc(m->indices, sizeof(uint32_t) * 3 * (nt + 2));
    const float q[4][3] = {{-half_width, ground_y, 10}, {half_width, ground_y, 10}, {half_width, ground_y, far_z},
                           {-half_width, ground_y, far_z}};
    for (int i = 0; i < 4; i++)
        for (int a = 0; a < 3; a++) {
            m->positions[3 * (nv + i) + a] = q[i][a];
            m->normals[3 * (nv + i) + a] = a == 1 ? 1.0f : 0.0f;
        }
    const uint32_t t[6] = {nv, nv + 1, nv + 2, nv, nv + 2, nv + 3};
    memcpy(m->indices + 3 * nt, t, sizeof t);
    m->vertex_count = nv + 4;
    m->triangle_count = nt + 2;
    obs_scene_update_bounds(s);
}

/* The AO tests' scene: the sphere resting near the ground (48 x 24, bump 0.08, ground y = -1.05),
 * and a camera looking down at it (50 degrees, near 0.1, far 100). */
static inline void tu_ao_scene(obs_scene *s) { tu_sphere_over_ground(s, 48, 24, 0.08f, -1.05f, 20.0f, -40.0f); }

static inline obs_camera tu_ao_camera(void)
{
    return obs_camera_look_at(obs_v3(0.3f, 0.6f, 0.0f), obs_v3(0.0f, -0.5f, -4.0f), obs_v3(0, 1, 0),
                              (float)(50.0 * OBS_PI / 180.0), 0.1f, 100.0f);
}

/* Depth and normals of s seen by cam at W x H with a guard band. */
static inline obs_status tu_render_depth_normal(obs_context *ctx, const obs_scene *s, obs_camera cam, int W, int H,
                                                int guard, rast_gbuffer *gb)
{
    rast_params p = rast_params_default();
    p.width = W;
    p.height = H;
    p.guard = guard;
    p.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    obs_status st = rast_gbuffer_alloc(ctx, &p, gb);
    rast_view v = {cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, NULL, s, &v, 1, &p, gb, NULL);
    return st;
}

/* Byte-identical planes. */
static inline int tu_same_plane(const obs_image_f32 *a, const obs_image_f32 *b)
{
    if (a->width != b->width || a->height != b->height)
        return 0;
    for (int y = 0; y < a->height; y++)
        if (memcmp(obs_image_f32_row(a, y), obs_image_f32_row(b, y), sizeof(float) * (size_t)a->width) != 0)
            return 0;
    return 1;
}

/* A synthetic input: the depth of the view-space plane n.p = c seen by a centred camera with focal
 * length f pixels (perspective or orthographic), znear 0.1, zfar +inf. Free depth. */
typedef struct tu_synth {
    obs_image_f32 depth;
    ao_input in;
} tu_synth;

static inline obs_status tu_synth_plane(obs_context *ctx, int W, int H, double f, obs_dvec3 n, double c,
                                        obs_projection proj, tu_synth *s)
{
    memset(s, 0, sizeof *s);
    obs_status st = obs_image_f32_alloc(ctx, W, H, &s->depth);
    if (st != OBS_STATUS_OK)
        return st;
    ao_input *in = &s->in;
    in->width = in->w = W;
    in->height = in->h = H;
    in->depth = &s->depth;
    in->fx = in->fy = f;
    in->cx = 0.5 * W;
    in->cy = 0.5 * H;
    in->projection = proj;
    in->znear = 0.1;
    in->zfar = INFINITY;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double ax = (x + 0.5 - in->cx) / f, ay = -(y + 0.5 - in->cy) / f, t;
            if (proj == OBS_PROJECTION_PERSPECTIVE)
                t = c / obs_dv3_dot(n, obs_dv3(ax, ay, -1.0)); /* the depth is t (the ray's z is -1) */
            else
                t = (n.x * ax + n.y * ay - c) / n.z; /* n.(ax, ay, -d) = c */
            obs_image_f32_row(&s->depth, y)[x] = t > 0.0 ? (float)t : INFINITY;
        }
    return OBS_STATUS_OK;
}

#endif
