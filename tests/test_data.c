/* test_data.c: the bundled scenes, the OFF reader, and the GLB writer. */
#include "../src/tools/off.h"
#include "io/io.h"
#include "test.h"

#include <stdlib.h>
#include <string.h>

TEST(data_generated_scenes_load_validate_and_have_a_default_camera)
{
    static const char *files[] = {"plane.glb", "sphere_on_plane.glb", "corner2.glb", "corner3.glb",
                                  "cornell_box.glb", "closed_box.glb", "village.glb", "room.glb",
                                  "bunny.glb", "dragon.glb", "armadillo.glb", "dragon_plane.glb"};
    obs_context *ctx = obs_context_create();
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        obs_scene s;
        io_gltf_options opt = io_gltf_options_default();
        CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), files[k]), &opt, &s), ctx);
        CHECK_OK(obs_scene_validate(ctx, &s), ctx);
        CHECK_MSG(obs_scene_triangle_count(&s) > 0, "%s has no triangles", files[k]);
        int has_default = 0;
        for (uint32_t c = 0; c < s.camera_count; c++)
            has_default |= !strcmp(s.cameras[c].name, "default");
        CHECK_MSG(has_default, "%s has no camera named default", files[k]);
        /* every mesh carries unit normals */
        for (uint32_t m = 0; m < s.mesh_count; m++) {
            CHECK(s.meshes[m].normals != NULL);
            for (uint32_t v = 0; v < s.meshes[m].vertex_count; v += 97) {
                const float *n = &s.meshes[m].normals[3 * v];
                CHECK_NEAR(n[0] * n[0] + n[1] * n[1] + n[2] * n[2], 1.0, 1e-5);
            }
        }
        obs_scene_free(&s);
    }
    obs_context_destroy(ctx);
}

TEST(data_real_meshes_keep_their_size_and_face_outwards)
{
    /* The bunny: 75,408 triangles (build-notes.md), unit bounding sphere, and a positive signed
     * volume (counter-clockwise seen from outside). */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "bunny.glb"), &opt, &s), ctx);
    CHECK_EQ_INT(obs_scene_triangle_count(&s), 75408);
    const obs_mesh *m = &s.meshes[0];
    double r2 = 0, vol = 0;
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        const float *p = &m->positions[3 * v];
        double d = (double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2];
        r2 = d > r2 ? d : r2;
    }
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        const float *a = &m->positions[3 * m->indices[3 * t]], *b = &m->positions[3 * m->indices[3 * t + 1]],
                    *c = &m->positions[3 * m->indices[3 * t + 2]];
        vol += (a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
                a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0])) / 6.0;
    }
    CHECK_NEAR(sqrt(r2), 1.0, 1e-6);
    CHECK(vol > 0.1);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

static obs_status parse(obs_context *ctx, const char *text)
{
    float *p;
    uint32_t *i, nv, nt;
    obs_status st = off_parse(ctx, "t.off", text, strlen(text), &p, &nv, &i, &nt);
    if (st == OBS_STATUS_OK) {
        free(p);
        free(i);
    }
    return st;
}

TEST(data_off_reader_rejects_malformed_files_with_line_numbers)
{
    obs_context *ctx = obs_context_create();
    CHECK_OK(parse(ctx, "OFF\n# comment\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"), ctx);
    CHECK_OK(parse(ctx, "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"), ctx); /* a quad: fanned */
    const char *bad[] = {
        "",                                                   /* empty */
        "PLY\n3 1 0\n",                                       /* wrong header */
        "OFF\n3\n",                                           /* truncated counts */
        "OFF\n-3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",        /* negative count */
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",         /* index out of range */
        "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",      /* non-numeric */
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 nan\n3 0 1 2\n",       /* non-finite */
        "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",         /* a face missing */
        "OFF\n2000000000 2000000000 0\n0 0 0\n",              /* absurd counts: refused before allocating */
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",           /* a face with 2 vertices */
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        obs_context_clear_error(ctx);
        obs_status st = parse(ctx, bad[k]);
        CHECK_MSG(st == OBS_STATUS_PARSE_ERROR, "case %zu: status %s", k, obs_status_string(st));
        CHECK_MSG(strstr(obs_context_last_error(ctx), "t.off") != NULL, "case %zu: %s", k, obs_context_last_error(ctx));
    }
    obs_limits lim = obs_limits_default();
    lim.max_vertices = 3;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK(parse(ctx, "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n") == OBS_STATUS_LIMIT_EXCEEDED);
    obs_context_destroy(ctx);
}

TEST(glb_writer_round_trips_through_the_loader)
{
    obs_context *ctx = obs_context_create();
    float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5f};
    float nrm[] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0.6f, 0.8f};
    uint32_t idx[] = {0, 1, 2, 1, 3, 2};
    obs_mesh mesh = {.name = "quad", .vertex_count = 4, .triangle_count = 2, .positions = pos, .normals = nrm,
                     .indices = idx, .material = 0};
    obs_material mat = {.name = "m", .base_color = {0.1f, 0.2f, 0.3f, 1}, .roughness = 0.5f,
                        .extras_json = (char *)"{\"sigma_a\":[0.1,0.2,0.3],\"eta\":1.3}"};
    obs_instance inst[2] = {{0, 0, obs_mat4_identity()},
                            {0, 1, obs_mat4_from_trs(obs_v3(1, 2, 3), (obs_vec4){0, 0.6f, 0, 0.8f}, obs_v3(2, 2, 2))}};
    obs_camera cam = obs_camera_look_at(obs_v3(0, 1, 5), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, INFINITY);
    strcpy(cam.name, "default");
    obs_light light = {.name = "sun", .type = OBS_LIGHT_DIRECTIONAL, .color = {1, 0.9f, 0.8f}, .intensity = 3,
                       .position = {0, 10, 0}, .direction = {0, -1, 0}};
    obs_scene s;
    obs_scene_init(&s);
    s.meshes = &mesh; s.mesh_count = 1;
    s.instances = inst; s.instance_count = 2;
    s.cameras = &cam; s.camera_count = 1;
    s.lights = &light; s.light_count = 1;
    s.materials = &mat; s.material_count = 1;
    const char *path = test_path(test_tmpdir(), "rt.glb");
    CHECK_OK(io_glb_write(ctx, path, &s), ctx);
    obs_scene r;
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, path, &opt, &r), ctx);
    CHECK_EQ_INT(r.mesh_count, 1);
    CHECK_EQ_INT(r.instance_count, 2);
    CHECK(memcmp(r.meshes[0].positions, pos, sizeof pos) == 0);
    CHECK(memcmp(r.meshes[0].normals, nrm, sizeof nrm) == 0);
    CHECK(memcmp(r.meshes[0].indices, idx, sizeof idx) == 0);
    for (int k = 0; k < 16; k++)
        CHECK_NEAR(r.instances[1].world.m[k], inst[1].world.m[k], 1e-6);
    CHECK_EQ_INT(r.camera_count, 1);
    CHECK(!strcmp(r.cameras[0].name, "default"));
    CHECK(isinf(r.cameras[0].zfar));
    for (int k = 0; k < 16; k++)
        CHECK_NEAR(r.cameras[0].view.m[k], cam.view.m[k], 1e-5);
    CHECK_EQ_INT(r.light_count, 1);
    CHECK(r.lights[0].type == OBS_LIGHT_DIRECTIONAL);
    CHECK_NEAR(r.lights[0].direction.y, -1.0, 1e-6);
    CHECK_NEAR(r.lights[0].intensity, 3.0, 0);
    CHECK(r.materials[0].extras_json && strstr(r.materials[0].extras_json, "sigma_a"));
    CHECK_NEAR(r.materials[0].base_color[2], 0.3, 1e-7);
    obs_scene_free(&r);
    /* invalid input is refused before anything is written */
    idx[5] = 9;
    const char *bad = test_path(test_tmpdir(), "bad.glb");
    CHECK(io_glb_write(ctx, bad, &s) == OBS_STATUS_INVALID_ARGUMENT);
    FILE *f = fopen(bad, "rb");
    CHECK(f == NULL);
    obs_context_destroy(ctx);
}
