/* fuzz_gltf.c: glTF JSON text and GLB bytes through io_gltf_load_memory (the loader's own GLB
 * container check, tinygltf's parser, and every range, limit and node-graph check of io_gltf.cpp).
 *
 * Invariants checked on every input:
 *   - failure leaves the scene empty (io.h: "left empty on failure");
 *   - success gives a scene that obs_scene_validate accepts again, whose every index is below its
 *     mesh's vertex count, whose instances name existing meshes, and whose arrays are readable to
 *     the last element (ASan checks the reads);
 *   - a small scene that loads renders a tiny G-buffer (the rasterizer then sees hostile
 *     geometry: NaN, huge or degenerate vertices, odd cameras) with the scalar path, and with the
 *     AVX2 path where available, and the two give identical bytes (raster.h's promise). */
#include "fuzz.h"

#include "io/io.h"
#include "raster/raster.h"

#include <math.h>
#include <string.h>

/* Read every element so that ASan sees an out-of-bounds array; return a checksum so the reads
 * are not optimised away. */
static uint32_t touch_scene(const obs_scene *s)
{
    uint32_t h = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const obs_mesh *mesh = &s->meshes[m];
        fuzz_require(mesh->vertex_count == 0 || mesh->positions != NULL, "a mesh with vertices has positions");
        fuzz_require(mesh->triangle_count == 0 || mesh->indices != NULL, "a mesh with triangles has indices");
        fuzz_require(mesh->material < 0 || (uint32_t)mesh->material < s->material_count, "mesh material in range");
        fuzz_require(memchr(mesh->name, '\0', sizeof mesh->name) != NULL, "mesh name is terminated");
        for (uint64_t i = 0; i < 3ull * mesh->vertex_count; i++) {
            uint32_t b;
            memcpy(&b, &mesh->positions[i], 4);
            h = h * 31u + b;
            if (mesh->normals) {
                memcpy(&b, &mesh->normals[i], 4);
                h = h * 31u + b;
            }
        }
        for (uint64_t i = 0; i < 3ull * mesh->triangle_count; i++) {
            fuzz_require(mesh->indices[i] < mesh->vertex_count, "every index is below the vertex count");
            h = h * 31u + mesh->indices[i];
        }
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        fuzz_require(s->instances[i].mesh < s->mesh_count, "instance mesh in range");
        fuzz_require(obs_mat4_is_finite(s->instances[i].world), "instance matrices are finite");
    }
    for (uint32_t c = 0; c < s->camera_count; c++) {
        const obs_camera *cam = &s->cameras[c];
        fuzz_require(cam->znear >= 0.0f && cam->zfar > cam->znear, "camera depth range is ordered");
        fuzz_require(memchr(cam->name, '\0', sizeof cam->name) != NULL, "camera name is terminated");
    }
    for (uint32_t m = 0; m < s->material_count; m++)
        if (s->materials[m].extras_json)
            h += (uint32_t)strlen(s->materials[m].extras_json);
    for (uint32_t l = 0; l < s->light_count; l++)
        fuzz_require(isfinite(s->lights[l].intensity), "light intensity finite");
    return h;
}

static int same_plane_f32(const obs_image_f32 *a, const obs_image_f32 *b)
{
    if (!a->data || !b->data)
        return a->data == b->data;
    for (int y = 0; y < a->height; y++)
        if (memcmp(obs_image_f32_row(a, y), obs_image_f32_row(b, y), (size_t)a->width * 4) != 0)
            return 0;
    return 1;
}

static int same_plane_u32(const obs_image_u32 *a, const obs_image_u32 *b)
{
    if (!a->data || !b->data)
        return a->data == b->data;
    for (int y = 0; y < a->height; y++)
        if (memcmp(obs_image_u32_row(a, y), obs_image_u32_row(b, y), (size_t)a->width * 4) != 0)
            return 0;
    return 1;
}

static int same_gbuffer(const rast_gbuffer *a, const rast_gbuffer *b)
{
    int ok = same_plane_f32(&a->depth, &b->depth) && same_plane_f32(&a->ndc_depth, &b->ndc_depth) &&
             same_plane_u32(&a->prim_id, &b->prim_id) && same_plane_u32(&a->instance_id, &b->instance_id) &&
             same_plane_u32(&a->material_id, &b->material_id);
    for (int k = 0; k < 3; k++)
        ok = ok && same_plane_f32(&a->normal[k], &b->normal[k]) && same_plane_f32(&a->face_normal[k], &b->face_normal[k]);
    return ok;
}

/* Render a 24x16 G-buffer (guard 2) of the first camera (or a framing one), scalar and AVX2. The
 * convention and the infinite far plane come from the input's size so that all are visited. */
static void render_small(obs_context *ctx, const obs_scene *s, size_t size)
{
    if (obs_scene_triangle_count(s) > 20000)
        return;
    rast_view view;
    if (s->camera_count > 0)
        view.camera = s->cameras[0];
    else
        view.camera = obs_camera_frame_bounds(s->bounds, (float)(45.0 * OBS_PI / 180.0));
    if (size & 1 && view.camera.projection == OBS_PROJECTION_PERSPECTIVE)
        view.camera.zfar = INFINITY;
    rast_params p = rast_params_default();
    p.width = 24;
    p.height = 16;
    p.guard = 2;
    p.depth_convention = (rast_depth_convention)((size >> 1) % RAST_DEPTH_COUNT);
    p.isa = RAST_ISA_SCALAR;
    rast_gbuffer a, b;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    if (rast_gbuffer_alloc(ctx, &p, &a) != OBS_STATUS_OK)
        return;
    obs_status sa = rast_render(ctx, NULL, s, &view, 1, &p, &a, NULL);
    if (rast_isa_available(RAST_ISA_AVX2) && rast_gbuffer_alloc(ctx, &p, &b) == OBS_STATUS_OK) {
        p.isa = RAST_ISA_AVX2;
        obs_status sb = rast_render(ctx, NULL, s, &view, 1, &p, &b, NULL);
        fuzz_require(sa == sb, "scalar and AVX2 renders return the same status");
        if (sa == OBS_STATUS_OK)
            fuzz_require(same_gbuffer(&a, &b), "scalar and AVX2 G-buffers are identical");
    }
    rast_gbuffer_free(&a);
    rast_gbuffer_free(&b);
}

int obs_fuzz_gltf(const uint8_t *data, size_t size)
{
    obs_context *ctx = fuzz_context();
    obs_scene s;
    /* the name only matters for messages and the .glb hint; the "glTF" magic selects GLB anyway */
    const char *name = size >= 4 && memcmp(data, "glTF", 4) == 0 ? "fuzz.glb" : "fuzz.gltf";
    io_gltf_options opt = io_gltf_options_default();
    if (size > 0 && (data[size - 1] & 1)) /* both modes of non-triangle primitives */
        opt.require_triangles = 0;
    obs_status st = io_gltf_load_memory(ctx, name, data, size, &opt, &s);
    if (st != OBS_STATUS_OK) {
        fuzz_require(s.mesh_count == 0 && s.meshes == NULL && s.instances == NULL && s.cameras == NULL &&
                         s.lights == NULL && s.materials == NULL,
                     "a failed load leaves the scene empty");
        fuzz_require(obs_context_last_error(ctx)[0] != '\0', "a failed load says why");
    } else {
        fuzz_require(obs_scene_validate(ctx, &s) == OBS_STATUS_OK, "a loaded scene validates again");
        volatile uint32_t h = touch_scene(&s);
        (void)h;
        render_small(ctx, &s, size);
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    return 0;
}
