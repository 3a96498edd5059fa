/* test_agreement.c: the rasterizer agrees with Embree primary rays on real meshes.
 * Issue 2's bar: on the bunny and the dragon at 1920x1080, at least 99.9% of the pixels that
 * either renderer covers hit the same primitive; where they do, the depth's relative error is at
 * most 1e-5 and the face normals agree within 1e-4 per component. */
#include "io/io.h"
#include "raster/raster.h"
#include "test.h"
#include "truth/truth.h"

#include <string.h>

static void agreement_on(const char *file)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), file), &opt, &s), ctx);
    obs_camera cam = s.cameras[0];
    for (uint32_t c = 0; c < s.camera_count; c++)
        if (!strcmp(s.cameras[c].name, "default"))
            cam = s.cameras[c];
    rast_params p = rast_params_default();
    p.width = 1920;
    p.height = 1080;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &p, &gb), ctx);
    obs_pool *pool = obs_pool_create(0);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, pool, &s, &v, 1, &p, &gb, NULL), ctx);
    truth_scene *ts;
    CHECK_OK(truth_scene_create(ctx, &s, TRUTH_BUILD_MEDIUM, &ts), ctx);
    truth_thread_init();
    long long either = 0, same = 0, depth_bad = 0, normal_bad = 0;
    double worst_depth = 0, worst_normal = 0;
    for (int y = 0; y < p.height; y++)
        for (int x = 0; x < p.width; x++) {
            obs_dvec3 o, d;
            rast_pixel_ray(&gb.constants, &cam, x + 0.5, y + 0.5, &o, &d);
            truth_hit h;
            truth_intersect1(ts, obs_v3((float)o.x, (float)o.y, (float)o.z), obs_v3((float)d.x, (float)d.y, (float)d.z),
                             cam.znear, isinf(cam.zfar) ? INFINITY : cam.zfar, &h);
            uint32_t inst = obs_image_u32_row(&gb.instance_id, y)[x], prim = obs_image_u32_row(&gb.prim_id, y)[x];
            if (inst == RAST_ID_NONE && h.instance == 0xFFFFFFFFu)
                continue;
            either++;
            if (inst != h.instance || prim != h.prim)
                continue;
            same++;
            double dr = obs_image_f32_row(&gb.depth, y)[x];
            double rel = fabs(dr - h.t) / h.t; /* t is the linear depth: dir has view z = -1 */
            worst_depth = rel > worst_depth ? rel : worst_depth;
            depth_bad += rel > 1e-5;
            /* Embree's normal, to view space, flipped to face the viewer like ours */
            obs_vec3 nv = obs_mat4_mul_dir(cam.view, h.ng);
            obs_vec3 dv = obs_mat4_mul_dir(cam.view, obs_v3((float)d.x, (float)d.y, (float)d.z));
            if (obs_v3_dot(nv, dv) > 0)
                nv = obs_v3_scale(nv, -1.0f);
            double e = 0;
            for (int c = 0; c < 3; c++) {
                double a = obs_image_f32_row(&gb.face_normal[c], y)[x], b = c == 0 ? nv.x : c == 1 ? nv.y : nv.z;
                e = fabs(a - b) > e ? fabs(a - b) : e;
            }
            worst_normal = e > worst_normal ? e : worst_normal;
            normal_bad += e > 1e-4;
        }
    printf("%s: %lld pixels covered by either, %lld same primitive (%.4f%%); worst depth rel %.3g (%lld over 1e-5); "
           "worst normal %.3g (%lld over 1e-4)\n",
           file, either, same, 100.0 * same / (double)(either ? either : 1), worst_depth, depth_bad, worst_normal,
           normal_bad);
    CHECK(either > 100000);
    CHECK_MSG(same >= either - either / 1000, "only %lld of %lld pixels hit the same primitive", same, either);
    CHECK_MSG(depth_bad == 0, "%lld pixels with depth relative error over 1e-5 (worst %g)", depth_bad, worst_depth);
    CHECK_MSG(normal_bad == 0, "%lld pixels with a normal component off by more than 1e-4 (worst %g)", normal_bad,
              worst_normal);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(raster_agrees_with_embree_primary_rays_on_bunny)
{
    agreement_on("bunny.glb");
}

TEST(raster_agrees_with_embree_primary_rays_on_dragon)
{
    agreement_on("dragon.glb");
}
