/* bench_scene.c: the benchmarks' scene framing (bench_scene.h). */
#include "bench_scene.h"
#include "io/io.h"

#include <math.h>
#include <stdio.h>

/* Load MESH and frame it as the llvmpipe peer does (see the top comment). Returns 0, or 3 with
 * the error printed. */
int bench_load_framed(obs_context *ctx, const char *mesh, obs_scene *out_scene, obs_camera *out_cam)
{
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    if (io_gltf_load(ctx, mesh, &opt, &s) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 3;
    }
    /* Peer framing: bbox centre, farthest vertex at radius 10 (world space of the loaded scene). */
    obs_scene_update_bounds(&s);
    obs_vec3 c = obs_v3_scale(obs_v3_add(s.bounds.lo, s.bounds.hi), 0.5f);
    double r2 = 0;
    for (uint32_t i = 0; i < s.instance_count; i++) {
        const obs_mesh *m = &s.meshes[s.instances[i].mesh];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            obs_vec3 w = obs_mat4_mul_point(s.instances[i].world, obs_v3(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]));
            obs_vec3 d = obs_v3_sub(w, c);
            double dd = (double)d.x * d.x + (double)d.y * d.y + (double)d.z * d.z;
            r2 = dd > r2 ? dd : r2;
        }
    }
    float scale = (float)(10.0 / sqrt(r2));
    obs_mat4 fit = obs_mat4_mul(obs_mat4_scale(obs_v3(scale, scale, scale)), obs_mat4_translation(obs_v3_scale(c, -1.0f)));
    for (uint32_t i = 0; i < s.instance_count; i++)
        s.instances[i].world = obs_mat4_mul(fit, s.instances[i].world);
    const float fovy = (float)(45.0 * OBS_PI / 180.0);
    float dist = 10.0f / sinf(0.5f * fovy);
    obs_camera cam = obs_camera_look_at(obs_v3(0, 0, dist), obs_v3(0, 0, 0), obs_v3(0, 1, 0), fovy,
                                        fmaxf(dist - 11.0f, 0.5f), dist + 11.0f);
    *out_scene = s;
    *out_cam = cam;
    return 0;
}

