/* io_glb_write.c: write an obs_scene as binary glTF 2.0 (GLB), atomically.
 * Layout per glTF 2.0 §4.4 (GLB file format): 12-byte header ("glTF", version 2, length), a JSON
 * chunk padded with spaces to 4 bytes, a BIN chunk padded with zeros. One buffer; per mesh a
 * POSITION accessor (FLOAT VEC3 with min/max, as the spec requires), an optional NORMAL accessor,
 * and UNSIGNED_INT indices. */
#include "io.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct bin_buf {
    unsigned char *data;
    size_t len, cap;
    int failed;
} bin_buf;

static size_t bin_append(bin_buf *b, const void *src, size_t n)
{
    size_t off = b->len, need;
    if (b->failed || !obs_add_size(b->len, n + 3, &need)) {
        b->failed = 1;
        return 0;
    }
    if (need > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < need)
            cap *= 2;
        unsigned char *d = (unsigned char *)realloc(b->data, cap);
        if (!d) {
            b->failed = 1;
            return 0;
        }
        b->data = d;
        b->cap = cap;
    }
    memcpy(b->data + b->len, src, n);
    b->len += n;
    while (b->len & 3) /* keep every view 4-byte aligned */
        b->data[b->len++] = 0;
    return off;
}

/* One bufferView + accessor pair; returns the accessor index. */
static int add_accessor(io_json *views, io_json *accs, int *nview, bin_buf *bin, const void *data, size_t bytes,
                        int component, int count, const char *type, int target, const float *mn, const float *mx)
{
    size_t off = bin_append(bin, data, bytes);
    io_json_begin_object(views, NULL);
    io_json_int(views, "buffer", 0);
    io_json_int(views, "byteOffset", (int64_t)off);
    io_json_int(views, "byteLength", (int64_t)bytes);
    io_json_int(views, "target", target);
    io_json_end_object(views);
    io_json_begin_object(accs, NULL);
    io_json_int(accs, "bufferView", *nview);
    io_json_int(accs, "componentType", component);
    io_json_int(accs, "count", count);
    io_json_string(accs, "type", type);
    if (mn && mx) {
        io_json_floats(accs, "min", mn, 3);
        io_json_floats(accs, "max", mx, 3);
    }
    io_json_end_object(accs);
    return (*nview)++;
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* The node matrix of a camera or light: its world matrix as 16 numbers. */
static void json_matrix(io_json *j, const obs_mat4 *m) { io_json_floats(j, "matrix", m->m, 16); }

obs_status io_glb_write(obs_context *ctx, const char *path, const obs_scene *sc)
{
    if (!path || !sc)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_glb_write: NULL argument");
    /* Validate before writing anything. */
    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        const obs_mesh *mesh = &sc->meshes[m];
        if (mesh->vertex_count == 0 || mesh->triangle_count == 0 || !mesh->positions || !mesh->indices)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: mesh %u (%s) is empty", path, m, mesh->name);
        if (mesh->vertex_count > INT32_MAX / 4 || mesh->triangle_count > INT32_MAX / 4)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: mesh %u (%s) is too large for one GLB", path, m,
                             mesh->name);
        for (uint64_t i = 0; i < 3 * (uint64_t)mesh->triangle_count; i++)
            if (mesh->indices[i] >= mesh->vertex_count)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: mesh %u (%s): index %u out of range", path, m,
                                 mesh->name, mesh->indices[i]);
        for (uint32_t v = 0; v < mesh->vertex_count; v++)
            if (!finite3(&mesh->positions[3 * (size_t)v]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: mesh %u (%s): vertex %u is not finite", path,
                                 m, mesh->name, v);
        if (mesh->material < -1 || mesh->material >= (int32_t)sc->material_count)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: mesh %u: material %d out of range", path, m,
                             mesh->material);
    }
    for (uint32_t i = 0; i < sc->instance_count; i++)
        if (sc->instances[i].mesh >= sc->mesh_count || !obs_mat4_is_finite(sc->instances[i].world))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: instance %u is invalid", path, i);

    bin_buf bin = {0};
    io_json views, accs, meshes, j;
    io_json_init(&views);
    io_json_init(&accs);
    io_json_init(&meshes);
    io_json_init(&j);
    io_json_begin_array(&views, NULL);
    io_json_begin_array(&accs, NULL);
    io_json_begin_array(&meshes, NULL);
    int nview = 0;
    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        const obs_mesh *mesh = &sc->meshes[m];
        float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (uint32_t v = 0; v < mesh->vertex_count; v++)
            for (int c = 0; c < 3; c++) {
                float x = mesh->positions[3 * (size_t)v + c];
                mn[c] = x < mn[c] ? x : mn[c];
                mx[c] = x > mx[c] ? x : mx[c];
            }
        int apos = add_accessor(&views, &accs, &nview, &bin, mesh->positions, 12 * (size_t)mesh->vertex_count, 5126,
                                (int)mesh->vertex_count, "VEC3", 34962, mn, mx);
        int anrm = -1;
        if (mesh->normals)
            anrm = add_accessor(&views, &accs, &nview, &bin, mesh->normals, 12 * (size_t)mesh->vertex_count, 5126,
                                (int)mesh->vertex_count, "VEC3", 34962, NULL, NULL);
        int aidx = add_accessor(&views, &accs, &nview, &bin, mesh->indices, 12 * (size_t)mesh->triangle_count, 5125,
                                (int)(3 * mesh->triangle_count), "SCALAR", 34963, NULL, NULL);
        io_json_begin_object(&meshes, NULL);
        io_json_string(&meshes, "name", mesh->name);
        io_json_begin_array(&meshes, "primitives");
        io_json_begin_object(&meshes, NULL);
        io_json_begin_object(&meshes, "attributes");
        io_json_int(&meshes, "POSITION", apos);
        if (anrm >= 0)
            io_json_int(&meshes, "NORMAL", anrm);
        io_json_end_object(&meshes);
        io_json_int(&meshes, "indices", aidx);
        io_json_int(&meshes, "mode", 4);
        if (mesh->material >= 0)
            io_json_int(&meshes, "material", mesh->material);
        io_json_end_object(&meshes);
        io_json_end_array(&meshes);
        io_json_end_object(&meshes);
    }
    io_json_end_array(&views);
    io_json_end_array(&accs);
    io_json_end_array(&meshes);

    /* The document. Arrays built above are pasted as raw JSON text (they are complete values). */
    char version[64];
    snprintf(version, sizeof version, "obscura %s", OBS_VERSION_STRING);
    io_json_begin_object(&j, NULL);
    io_json_begin_object(&j, "asset");
    io_json_string(&j, "version", "2.0");
    io_json_string(&j, "generator", version);
    io_json_end_object(&j);
    if (sc->light_count) {
        io_json_begin_array(&j, "extensionsUsed");
        io_json_string(&j, NULL, "KHR_lights_punctual");
        io_json_end_array(&j);
    }
    io_json_int(&j, "scene", 0);
    uint32_t nnodes = sc->instance_count + sc->camera_count + sc->light_count;
    io_json_begin_array(&j, "scenes");
    io_json_begin_object(&j, NULL);
    io_json_begin_array(&j, "nodes");
    for (uint32_t n = 0; n < nnodes; n++)
        io_json_int(&j, NULL, n);
    io_json_end_array(&j);
    io_json_end_object(&j);
    io_json_end_array(&j);
    io_json_begin_array(&j, "nodes");
    for (uint32_t i = 0; i < sc->instance_count; i++) {
        io_json_begin_object(&j, NULL);
        char nm[OBS_NAME_MAX + 16];
        snprintf(nm, sizeof nm, "%s.%u", sc->meshes[sc->instances[i].mesh].name, i);
        io_json_string(&j, "name", nm);
        io_json_int(&j, "mesh", sc->instances[i].mesh);
        json_matrix(&j, &sc->instances[i].world);
        io_json_end_object(&j);
    }
    for (uint32_t c = 0; c < sc->camera_count; c++) {
        io_json_begin_object(&j, NULL);
        io_json_string(&j, "name", sc->cameras[c].name);
        io_json_int(&j, "camera", c);
        json_matrix(&j, &sc->cameras[c].world);
        io_json_end_object(&j);
    }
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const obs_light *L = &sc->lights[l];
        /* Place the light at its position, with -Z along its direction. */
        obs_mat4 w = obs_mat4_look_at(L->position, obs_v3_add(L->position, L->direction),
                                      fabsf(L->direction.y) > 0.9f ? obs_v3(1, 0, 0) : obs_v3(0, 1, 0));
        obs_mat4 wi;
        if (!obs_mat4_inverse(w, &wi))
            wi = obs_mat4_translation(L->position);
        io_json_begin_object(&j, NULL);
        io_json_string(&j, "name", L->name);
        json_matrix(&j, &wi);
        io_json_begin_object(&j, "extensions");
        io_json_begin_object(&j, "KHR_lights_punctual");
        io_json_int(&j, "light", l);
        io_json_end_object(&j);
        io_json_end_object(&j);
        io_json_end_object(&j);
    }
    io_json_end_array(&j);
    if (sc->camera_count) {
        io_json_begin_array(&j, "cameras");
        for (uint32_t c = 0; c < sc->camera_count; c++) {
            const obs_camera *cam = &sc->cameras[c];
            io_json_begin_object(&j, NULL);
            io_json_string(&j, "name", cam->name);
            if (cam->projection == OBS_PROJECTION_PERSPECTIVE) {
                io_json_string(&j, "type", "perspective");
                io_json_begin_object(&j, "perspective");
                io_json_number(&j, "yfov", cam->yfov);
                if (cam->aspect > 0.0f)
                    io_json_number(&j, "aspectRatio", cam->aspect);
                io_json_number(&j, "znear", cam->znear);
                if (isfinite(cam->zfar))
                    io_json_number(&j, "zfar", cam->zfar);
            } else {
                io_json_string(&j, "type", "orthographic");
                io_json_begin_object(&j, "orthographic");
                io_json_number(&j, "xmag", cam->xmag);
                io_json_number(&j, "ymag", cam->ymag);
                io_json_number(&j, "znear", cam->znear);
                io_json_number(&j, "zfar", cam->zfar);
            }
            io_json_end_object(&j);
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
    }
    if (sc->material_count) {
        io_json_begin_array(&j, "materials");
        for (uint32_t m = 0; m < sc->material_count; m++) {
            const obs_material *mat = &sc->materials[m];
            io_json_begin_object(&j, NULL);
            io_json_string(&j, "name", mat->name);
            io_json_begin_object(&j, "pbrMetallicRoughness");
            io_json_floats(&j, "baseColorFactor", mat->base_color, 4);
            io_json_number(&j, "metallicFactor", mat->metallic);
            io_json_number(&j, "roughnessFactor", mat->roughness);
            io_json_end_object(&j);
            io_json_bool(&j, "doubleSided", mat->double_sided);
            if (mat->extras_json && mat->extras_json[0])
                io_json_raw(&j, "extras", mat->extras_json);
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
    }
    if (sc->light_count) {
        static const char *types[] = {"directional", "point", "spot"};
        io_json_begin_object(&j, "extensions");
        io_json_begin_object(&j, "KHR_lights_punctual");
        io_json_begin_array(&j, "lights");
        for (uint32_t l = 0; l < sc->light_count; l++) {
            const obs_light *L = &sc->lights[l];
            io_json_begin_object(&j, NULL);
            io_json_string(&j, "name", L->name);
            io_json_string(&j, "type", types[L->type < OBS_LIGHT_COUNT ? L->type : 1]);
            float col[3] = {L->color.x, L->color.y, L->color.z};
            io_json_floats(&j, "color", col, 3);
            io_json_number(&j, "intensity", L->intensity);
            if (L->range > 0.0f)
                io_json_number(&j, "range", L->range);
            if (L->type == OBS_LIGHT_SPOT) {
                io_json_begin_object(&j, "spot");
                io_json_number(&j, "innerConeAngle", L->inner_cone);
                io_json_number(&j, "outerConeAngle", L->outer_cone);
                io_json_end_object(&j);
            }
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
        io_json_end_object(&j);
        io_json_end_object(&j);
    }
    io_json_raw(&j, "bufferViews", views.buf ? views.buf : "[]");
    io_json_raw(&j, "accessors", accs.buf ? accs.buf : "[]");
    io_json_raw(&j, "meshes", meshes.buf ? meshes.buf : "[]");
    io_json_begin_array(&j, "buffers");
    io_json_begin_object(&j, NULL);
    io_json_int(&j, "byteLength", (int64_t)bin.len);
    io_json_end_object(&j);
    io_json_end_array(&j);
    io_json_end_object(&j);

    obs_status st = OBS_STATUS_OK;
    if (bin.failed || j.failed || views.failed || accs.failed || meshes.failed) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory while building the GLB", path);
    } else {
        size_t jl = j.len, jpad = (jl + 3) & ~(size_t)3, total = 12 + 8 + jpad + 8 + bin.len;
        unsigned char *out = (unsigned char *)malloc(total);
        if (!out) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", path);
        } else {
            /* GLB header and chunk headers, little-endian: magic "glTF", version 2, length;
             * then JSON ("JSON") and BIN ("BIN\0") chunks (glTF 2.0 §4.4). */
            uint32_t h[5] = {0x46546C67u, 2u, (uint32_t)total, (uint32_t)jpad, 0x4E4F534Au};
            memcpy(out, h, 20);
            memcpy(out + 20, j.buf, jl);
            memset(out + 20 + jl, ' ', jpad - jl);
            uint32_t bh[2] = {(uint32_t)bin.len, 0x004E4942u};
            memcpy(out + 20 + jpad, bh, 8);
            if (bin.len)
                memcpy(out + 28 + jpad, bin.data, bin.len);
            st = io_write_file_atomic(ctx, path, out, total);
            free(out);
        }
    }
    free(bin.data);
    io_json_free(&views);
    io_json_free(&accs);
    io_json_free(&meshes);
    io_json_free(&j);
    return st;
}
