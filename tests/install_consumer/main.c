/* Renders a one-triangle scene through the installed headers and libraries. */
#include <obscura/core/obs.h>
#include <obscura/raster/raster.h>
#include <stdio.h>

int main(void)
{
    float pos[] = {-1, -1, -5, 1, -1, -5, 0, 1, -5};
    uint32_t idx[] = {0, 1, 2};
    obs_mesh m = {.name = "tri", .vertex_count = 3, .triangle_count = 1, .positions = pos, .indices = idx, .material = -1};
    obs_instance in = {.mesh = 0, .node = 0, .world = obs_mat4_identity()};
    obs_scene s;
    obs_scene_init(&s);
    s.meshes = &m;
    s.mesh_count = 1;
    s.instances = &in;
    s.instance_count = 1;
    obs_context *ctx = obs_context_create();
    rast_params p = rast_params_default();
    p.width = 32;
    p.height = 32;
    rast_gbuffer gb;
    rast_view v = {obs_camera_look_at(obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(0, 1, 0), 1.0f, 0.1f, 100.0f)};
    rast_stats st;
    if (rast_gbuffer_alloc(ctx, &p, &gb) != OBS_STATUS_OK || rast_render(ctx, NULL, &s, &v, 1, &p, &gb, &st) != OBS_STATUS_OK) {
        fprintf(stderr, "%s\n", obs_context_last_error(ctx));
        return 1;
    }
    printf("covered %llu pixels\n", (unsigned long long)st.pixels_covered);
    rast_gbuffer_free(&gb);
    obs_context_destroy(ctx);
    return st.pixels_covered > 0 ? 0 : 1;
}
