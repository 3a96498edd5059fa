/* io_glb_write.c: write an obs_scene as binary glTF 2.0 (GLB), atomically.
 *
 * Layout per glTF 2.0 §4.4 (GLB file format): a 12-byte header ("glTF", version 2, total length),
 * a JSON chunk padded with spaces to 4 bytes, a BIN chunk padded with zeros. One buffer; per mesh
 * a POSITION accessor (FLOAT VEC3 with min/max, which the spec requires), an optional NORMAL
 * accessor, and UNSIGNED_INT indices, each in its own bufferView (targets 34962 / 34963).
 *
 * Nodes, all roots of scene 0, in this order (so node indices are predictable):
 *   [0, instance_count)                 one per obs_instance: "mesh" and "matrix" (its world);
 *   then camera_count camera nodes      "camera" and the camera's world matrix;
 *   then light_count light nodes        KHR_lights_punctual, placed at the light's position with
 *                                       -Z along its direction (translation only when the
 *                                       direction is zero).
 * Identity matrices are omitted (the glTF default). Numbers are printed with %.9g, enough to
 * round-trip every float.
 *
 * Everything is validated before anything is written, with the same rules the loader applies, so
 * that what this writes loads again: the writer never emits null for a number, an index out of
 * range, or extras that are not JSON. */
#include "io.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* glTF enums (glTF 2.0 §5.1.2, §5.11.1). */
#define GLB_COMPONENT_FLOAT 5126
#define GLB_COMPONENT_UNSIGNED_INT 5125
#define GLB_TARGET_ARRAY_BUFFER 34962
#define GLB_TARGET_ELEMENT_ARRAY_BUFFER 34963
#define GLB_MODE_TRIANGLES 4
#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */

/* ------------------------------------------------------------------------------------------------
 * Validation
 * ---------------------------------------------------------------------------------------------- */

/* A name field as a NUL-terminated string even when all OBS_NAME_MAX bytes are used. */
typedef struct name_buf { char s[OBS_NAME_MAX + 1]; } name_buf;
static name_buf name_of(const char *field)
{
    name_buf b;
    size_t n = 0;
    while (n < OBS_NAME_MAX && field[n])
        n++;
    memcpy(b.s, field, n);
    b.s[n] = '\0';
    return b;
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }
static int finite_v3(obs_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }
static int unit_range(float x) { return x >= 0.0f && x <= 1.0f; } /* false for NaN */

/* An affine node matrix: finite, bottom row (0, 0, 0, 1) (glTF 2.0 §5.25: node.matrix must be
 * decomposable to TRS, which a projective row never is). */
static int affine(const obs_mat4 *m)
{
    return obs_mat4_is_finite(*m) && m->m[3] == 0.0f && m->m[7] == 0.0f && m->m[11] == 0.0f && m->m[15] == 1.0f;
}

static int is_identity(const obs_mat4 *m)
{
    for (int k = 0; k < 16; k++)
        if (m->m[k] != ((k % 5) == 0 ? 1.0f : 0.0f))
            return 0;
    return 1;
}

/* A small RFC 8259 syntax check for extras_json (which is pasted verbatim): returns the end of
 * one value starting at p (after leading whitespace), or NULL. depth bounds the recursion. */
static const char *json_ws(const char *p)
{
    while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r')
        p++;
    return p;
}

static const char *json_value(const char *p, int depth);

static const char *json_string_end(const char *p) /* p at the opening quote */
{
    for (p++;; p++) {
        unsigned char c = (unsigned char)*p;
        if (c == '"')
            return p + 1;
        if (c < 0x20) /* control characters, including the terminating NUL */
            return NULL;
        if (c == '\\') {
            p++;
            if (*p == 'u') {
                for (int k = 1; k <= 4; k++)
                    if (!strchr("0123456789abcdefABCDEF", p[k]) || !p[k])
                        return NULL;
                p += 4;
            } else if (!*p || !strchr("\"\\/bfnrt", *p)) {
                return NULL;
            }
        }
    }
}

static const char *json_number_end(const char *p)
{
    if (*p == '-')
        p++;
    if (*p == '0')
        p++;
    else if (*p >= '1' && *p <= '9')
        while (*p >= '0' && *p <= '9')
            p++;
    else
        return NULL;
    if (*p == '.') {
        p++;
        if (!(*p >= '0' && *p <= '9'))
            return NULL;
        while (*p >= '0' && *p <= '9')
            p++;
    }
    if (*p == 'e' || *p == 'E') {
        p++;
        if (*p == '+' || *p == '-')
            p++;
        if (!(*p >= '0' && *p <= '9'))
            return NULL;
        while (*p >= '0' && *p <= '9')
            p++;
    }
    return p;
}

static const char *json_value(const char *p, int depth)
{
    if (depth > 64)
        return NULL;
    p = json_ws(p);
    switch (*p) {
    case '"':
        return json_string_end(p);
    case '{':
    case '[': {
        const char close = *p == '{' ? '}' : ']';
        const int object = *p == '{';
        p = json_ws(p + 1);
        if (*p == close)
            return p + 1;
        for (;;) {
            if (object) {
                if (*p != '"' || !(p = json_string_end(p)))
                    return NULL;
                p = json_ws(p);
                if (*p++ != ':')
                    return NULL;
            }
            if (!(p = json_value(p, depth + 1)))
                return NULL;
            p = json_ws(p);
            if (*p == close)
                return p + 1;
            if (*p++ != ',')
                return NULL;
            p = json_ws(p);
        }
    }
    case 't':
        return strncmp(p, "true", 4) ? NULL : p + 4;
    case 'f':
        return strncmp(p, "false", 5) ? NULL : p + 5;
    case 'n':
        return strncmp(p, "null", 4) ? NULL : p + 4;
    default:
        return json_number_end(p);
    }
}

static int json_valid(const char *text)
{
    const char *e = json_value(text, 0);
    return e && *json_ws(e) == '\0';
}

static obs_status validate(obs_context *ctx, const char *path, const obs_scene *sc)
{
#define BAD(...) obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, __VA_ARGS__)
    if ((sc->mesh_count && !sc->meshes) || (sc->instance_count && !sc->instances) ||
        (sc->camera_count && !sc->cameras) || (sc->light_count && !sc->lights) ||
        (sc->material_count && !sc->materials))
        return BAD("%s: a scene array is NULL while its count is not zero", path);
    /* Nodes and accessors are counted in JSON integers we print from int64; keep them in int32. */
    if ((uint64_t)sc->instance_count + sc->camera_count + sc->light_count > INT32_MAX ||
        (uint64_t)sc->mesh_count * 3 > INT32_MAX)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: too many nodes or meshes for one glTF file", path);

    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        const obs_mesh *mesh = &sc->meshes[m];
        const name_buf nb = name_of(mesh->name);
        const char *nm = nb.s;
        if (mesh->vertex_count == 0 || mesh->triangle_count == 0 || !mesh->positions || !mesh->indices)
            return BAD("%s: mesh %u (%s) is empty (glTF accessors need count >= 1)", path, m, nm);
        /* Per-accessor counts are int32 in our JSON and byte lengths must fit the 4 GiB GLB. */
        if (mesh->vertex_count > INT32_MAX / 12 || mesh->triangle_count > INT32_MAX / 12)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: mesh %u (%s) is too large for one GLB", path, m, nm);
        for (uint64_t i = 0; i < 3 * (uint64_t)mesh->triangle_count; i++)
            if (mesh->indices[i] >= mesh->vertex_count)
                return BAD("%s: mesh %u (%s): index %llu is %u, not below the vertex count %u", path, m, nm,
                           (unsigned long long)i, mesh->indices[i], mesh->vertex_count);
        for (uint32_t v = 0; v < mesh->vertex_count; v++) {
            /* min/max are required and JSON has no NaN or infinity: positions must be finite. */
            if (!finite3(&mesh->positions[3 * (size_t)v]))
                return BAD("%s: mesh %u (%s): position %u is not finite", path, m, nm, v);
            if (mesh->normals && !finite3(&mesh->normals[3 * (size_t)v]))
                return BAD("%s: mesh %u (%s): normal %u is not finite", path, m, nm, v);
        }
        if (mesh->material < -1 || mesh->material >= (int64_t)sc->material_count)
            return BAD("%s: mesh %u (%s): material %d out of range (%u materials)", path, m, nm, mesh->material,
                       sc->material_count);
    }
    for (uint32_t i = 0; i < sc->instance_count; i++) {
        if (sc->instances[i].mesh >= sc->mesh_count)
            return BAD("%s: instance %u: mesh %u out of range (%u meshes)", path, i, sc->instances[i].mesh,
                       sc->mesh_count);
        if (!affine(&sc->instances[i].world))
            return BAD("%s: instance %u: world matrix not finite or not affine (bottom row must be 0 0 0 1)", path,
                       i);
    }
    for (uint32_t c = 0; c < sc->camera_count; c++) {
        const obs_camera *cam = &sc->cameras[c];
        const name_buf nb = name_of(cam->name);
        const char *nm = nb.s;
        if (!affine(&cam->world))
            return BAD("%s: camera %u (%s): world matrix not finite or not affine", path, c, nm);
        if (cam->projection == OBS_PROJECTION_PERSPECTIVE) {
            if (!(cam->yfov > 0.0f && cam->yfov < OBS_PI_F))
                return BAD("%s: camera %u (%s): yfov %g is not in (0, pi)", path, c, nm, cam->yfov);
            if (!(cam->znear > 0.0f) || !isfinite(cam->znear))
                return BAD("%s: camera %u (%s): znear %g is not finite and > 0", path, c, nm, cam->znear);
            if (!(cam->zfar > cam->znear)) /* +INFINITY allowed: written without zfar */
                return BAD("%s: camera %u (%s): zfar %g is not > znear %g", path, c, nm, cam->zfar, cam->znear);
            if (!(cam->aspect >= 0.0f) || !isfinite(cam->aspect))
                return BAD("%s: camera %u (%s): aspect %g is not finite and >= 0", path, c, nm, cam->aspect);
        } else if (cam->projection == OBS_PROJECTION_ORTHOGRAPHIC) {
            if (!(cam->xmag != 0.0f && isfinite(cam->xmag)) || !(cam->ymag != 0.0f && isfinite(cam->ymag)))
                return BAD("%s: camera %u (%s): xmag %g / ymag %g must be finite and non-zero", path, c, nm,
                           cam->xmag, cam->ymag);
            if (!(cam->znear >= 0.0f) || !isfinite(cam->znear) || !(cam->zfar > cam->znear) || !isfinite(cam->zfar))
                return BAD("%s: camera %u (%s): orthographic znear %g / zfar %g need 0 <= znear < zfar, finite",
                           path, c, nm, cam->znear, cam->zfar);
        } else {
            return BAD("%s: camera %u (%s): unknown projection %d", path, c, nm, (int)cam->projection);
        }
    }
    for (uint32_t l = 0; l < sc->light_count; l++) {
        const obs_light *L = &sc->lights[l];
        const name_buf nb = name_of(L->name);
        const char *nm = nb.s;
        if ((unsigned)L->type >= OBS_LIGHT_COUNT)
            return BAD("%s: light %u (%s): unknown type %d", path, l, nm, (int)L->type);
        if (!finite_v3(L->color) || L->color.x < 0 || L->color.y < 0 || L->color.z < 0 ||
            !(L->intensity >= 0.0f) || !isfinite(L->intensity) || !(L->range >= 0.0f) || !isfinite(L->range))
            return BAD("%s: light %u (%s): color, intensity %g and range %g must be finite and >= 0", path, l, nm,
                       L->intensity, L->range);
        if (!finite_v3(L->position) || !finite_v3(L->direction))
            return BAD("%s: light %u (%s): position or direction not finite", path, l, nm);
        if (L->type != OBS_LIGHT_POINT && obs_v3_length(L->direction) == 0.0f)
            return BAD("%s: light %u (%s): a %s light needs a non-zero direction", path, l, nm,
                       L->type == OBS_LIGHT_SPOT ? "spot" : "directional");
        if (L->type == OBS_LIGHT_SPOT &&
            !(L->inner_cone >= 0.0f && L->inner_cone < L->outer_cone && L->outer_cone <= OBS_PI_F / 2))
            return BAD("%s: light %u (%s): spot cone angles inner %g, outer %g need 0 <= inner < outer <= pi/2",
                       path, l, nm, L->inner_cone, L->outer_cone);
    }
    for (uint32_t m = 0; m < sc->material_count; m++) {
        const obs_material *mat = &sc->materials[m];
        const name_buf nb = name_of(mat->name);
        const char *nm = nb.s;
        /* glTF 2.0 §5.22: factors are in [0, 1]. */
        for (int k = 0; k < 4; k++)
            if (!unit_range(mat->base_color[k]))
                return BAD("%s: material %u (%s): baseColorFactor[%d] = %g is not in [0, 1]", path, m, nm, k,
                           mat->base_color[k]);
        if (!unit_range(mat->metallic) || !unit_range(mat->roughness))
            return BAD("%s: material %u (%s): metallic %g / roughness %g not in [0, 1]", path, m, nm, mat->metallic,
                       mat->roughness);
        if (mat->extras_json && mat->extras_json[0] && !json_valid(mat->extras_json))
            return BAD("%s: material %u (%s): extras_json is not one valid JSON value", path, m, nm);
    }
    if (sc->extras_json && sc->extras_json[0] && !json_valid(sc->extras_json))
        return BAD("%s: the scene's extras_json is not one valid JSON value", path);
#undef BAD
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Writing
 * ---------------------------------------------------------------------------------------------- */

/* Where each mesh's arrays go in the BIN chunk (all 4-byte multiples, so no padding between). */
typedef struct mesh_layout { size_t pos, nrm, idx, pos_bytes, idx_bytes; } mesh_layout;

/* The light's node matrix: at its position, with -Z along its direction and +Y as close to world
 * up as possible (world +X when the direction is nearly vertical). Computed in double so the
 * frame is orthonormal to float precision. A zero direction (point lights) gives a translation. */
static obs_mat4 light_matrix(const obs_light *L)
{
    obs_mat4 m = obs_mat4_translation(L->position);
    double dx = L->direction.x, dy = L->direction.y, dz = L->direction.z;
    double len = sqrt(dx * dx + dy * dy + dz * dz);
    if (!(len > 0.0))
        return m;
    double z[3] = {-dx / len, -dy / len, -dz / len};
    double up[3] = {0, 1, 0};
    if (fabs(z[1]) > 0.9) {
        up[0] = 1;
        up[1] = 0;
    }
    double x[3] = {up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]};
    double xl = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++)
        x[k] /= xl;
    double y[3] = {z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]};
    for (int k = 0; k < 3; k++) {
        m.m[0 + k] = (float)x[k];
        m.m[4 + k] = (float)y[k];
        m.m[8 + k] = (float)z[k];
    }
    return m;
}

static void json_node_matrix(io_json *j, const obs_mat4 *m)
{
    if (!is_identity(m))
        io_json_floats(j, "matrix", m->m, 16);
}

static void put_u32le(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v & 0xFF);
    p[1] = (unsigned char)((v >> 8) & 0xFF);
    p[2] = (unsigned char)((v >> 16) & 0xFF);
    p[3] = (unsigned char)((v >> 24) & 0xFF);
}

static void put_floats_le(unsigned char *dst, const float *src, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &src[i], 4);
        put_u32le(dst + 4 * i, u);
    }
}

static void json_view(io_json *j, size_t offset, size_t bytes, int target)
{
    io_json_begin_object(j, NULL);
    io_json_int(j, "buffer", 0);
    io_json_int(j, "byteOffset", (int64_t)offset);
    io_json_int(j, "byteLength", (int64_t)bytes);
    io_json_int(j, "target", target);
    io_json_end_object(j);
}

static void json_accessor(io_json *j, int view, int component, int64_t count, const char *type, const float *mn,
                          const float *mx)
{
    io_json_begin_object(j, NULL);
    io_json_int(j, "bufferView", view);
    io_json_int(j, "componentType", component);
    io_json_int(j, "count", count);
    io_json_string(j, "type", type);
    if (mn && mx) {
        io_json_floats(j, "min", mn, 3);
        io_json_floats(j, "max", mx, 3);
    }
    io_json_end_object(j);
}

/* The glTF JSON document. layout[] gives each mesh's place in the BIN chunk of bin_len bytes. */
static void build_json(io_json *j, const obs_scene *sc, const mesh_layout *layout, size_t bin_len)
{
    char generator[64];
    snprintf(generator, sizeof generator, "obscura %s", OBS_VERSION_STRING);
    const uint32_t nnodes = sc->instance_count + sc->camera_count + sc->light_count;

    io_json_begin_object(j, NULL);
    io_json_begin_object(j, "asset");
    io_json_string(j, "version", "2.0");
    io_json_string(j, "generator", generator);
    io_json_end_object(j);
    if (sc->light_count) {
        io_json_begin_array(j, "extensionsUsed");
        io_json_string(j, NULL, "KHR_lights_punctual");
        io_json_end_array(j);
    }

    /* Scene 0 with every node as a root ("nodes" needs at least one element when present). */
    io_json_int(j, "scene", 0);
    io_json_begin_array(j, "scenes");
    io_json_begin_object(j, NULL);
    if (sc->extras_json && sc->extras_json[0])
        io_json_raw(j, "extras", sc->extras_json); /* checked by json_valid() */
    if (nnodes) {
        io_json_begin_array(j, "nodes");
        for (uint32_t n = 0; n < nnodes; n++)
            io_json_int(j, NULL, n);
        io_json_end_array(j);
    }
    io_json_end_object(j);
    io_json_end_array(j);

    if (nnodes) {
        io_json_begin_array(j, "nodes");
        for (uint32_t i = 0; i < sc->instance_count; i++) {
            char nm[OBS_NAME_MAX + 16];
            snprintf(nm, sizeof nm, "%s.%u", name_of(sc->meshes[sc->instances[i].mesh].name).s, i);
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", nm);
            io_json_int(j, "mesh", sc->instances[i].mesh);
            json_node_matrix(j, &sc->instances[i].world);
            io_json_end_object(j);
        }
        for (uint32_t c = 0; c < sc->camera_count; c++) {
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(sc->cameras[c].name).s);
            io_json_int(j, "camera", c);
            json_node_matrix(j, &sc->cameras[c].world);
            io_json_end_object(j);
        }
        for (uint32_t l = 0; l < sc->light_count; l++) {
            obs_mat4 w = light_matrix(&sc->lights[l]);
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(sc->lights[l].name).s);
            json_node_matrix(j, &w);
            io_json_begin_object(j, "extensions");
            io_json_begin_object(j, "KHR_lights_punctual");
            io_json_int(j, "light", l);
            io_json_end_object(j);
            io_json_end_object(j);
            io_json_end_object(j);
        }
        io_json_end_array(j);
    }

    if (sc->mesh_count) {
        /* Views and accessors: per mesh POSITION, [NORMAL], indices, numbered in that order. */
        io_json_begin_array(j, "meshes");
        int acc = 0;
        for (uint32_t m = 0; m < sc->mesh_count; m++) {
            const obs_mesh *mesh = &sc->meshes[m];
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(mesh->name).s);
            io_json_begin_array(j, "primitives");
            io_json_begin_object(j, NULL);
            io_json_begin_object(j, "attributes");
            io_json_int(j, "POSITION", acc++);
            if (mesh->normals)
                io_json_int(j, "NORMAL", acc++);
            io_json_end_object(j);
            io_json_int(j, "indices", acc++);
            io_json_int(j, "mode", GLB_MODE_TRIANGLES);
            if (mesh->material >= 0)
                io_json_int(j, "material", mesh->material);
            io_json_end_object(j);
            io_json_end_array(j);
            io_json_end_object(j);
        }
        io_json_end_array(j);

        io_json_begin_array(j, "accessors");
        int view = 0;
        for (uint32_t m = 0; m < sc->mesh_count; m++) {
            const obs_mesh *mesh = &sc->meshes[m];
            float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (uint32_t v = 0; v < mesh->vertex_count; v++)
                for (int c = 0; c < 3; c++) {
                    float x = mesh->positions[3 * (size_t)v + c];
                    mn[c] = x < mn[c] ? x : mn[c];
                    mx[c] = x > mx[c] ? x : mx[c];
                }
            json_accessor(j, view++, GLB_COMPONENT_FLOAT, mesh->vertex_count, "VEC3", mn, mx);
            if (mesh->normals)
                json_accessor(j, view++, GLB_COMPONENT_FLOAT, mesh->vertex_count, "VEC3", NULL, NULL);
            json_accessor(j, view++, GLB_COMPONENT_UNSIGNED_INT, 3 * (int64_t)mesh->triangle_count, "SCALAR", NULL,
                          NULL);
        }
        io_json_end_array(j);

        io_json_begin_array(j, "bufferViews");
        for (uint32_t m = 0; m < sc->mesh_count; m++) {
            json_view(j, layout[m].pos, layout[m].pos_bytes, GLB_TARGET_ARRAY_BUFFER);
            if (sc->meshes[m].normals)
                json_view(j, layout[m].nrm, layout[m].pos_bytes, GLB_TARGET_ARRAY_BUFFER);
            json_view(j, layout[m].idx, layout[m].idx_bytes, GLB_TARGET_ELEMENT_ARRAY_BUFFER);
        }
        io_json_end_array(j);

        io_json_begin_array(j, "buffers");
        io_json_begin_object(j, NULL);
        io_json_int(j, "byteLength", (int64_t)bin_len);
        io_json_end_object(j);
        io_json_end_array(j);
    }

    if (sc->camera_count) {
        io_json_begin_array(j, "cameras");
        for (uint32_t c = 0; c < sc->camera_count; c++) {
            const obs_camera *cam = &sc->cameras[c];
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(cam->name).s);
            if (cam->projection == OBS_PROJECTION_PERSPECTIVE) {
                io_json_string(j, "type", "perspective");
                io_json_begin_object(j, "perspective");
                io_json_number(j, "yfov", cam->yfov);
                if (cam->aspect > 0.0f)
                    io_json_number(j, "aspectRatio", cam->aspect);
                io_json_number(j, "znear", cam->znear);
                if (isfinite(cam->zfar)) /* no zfar: an infinite projection (glTF 2.0 §3.10.3) */
                    io_json_number(j, "zfar", cam->zfar);
            } else {
                io_json_string(j, "type", "orthographic");
                io_json_begin_object(j, "orthographic");
                io_json_number(j, "xmag", cam->xmag);
                io_json_number(j, "ymag", cam->ymag);
                io_json_number(j, "znear", cam->znear);
                io_json_number(j, "zfar", cam->zfar);
            }
            io_json_end_object(j);
            io_json_end_object(j);
        }
        io_json_end_array(j);
    }

    if (sc->material_count) {
        io_json_begin_array(j, "materials");
        for (uint32_t m = 0; m < sc->material_count; m++) {
            const obs_material *mat = &sc->materials[m];
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(mat->name).s);
            io_json_begin_object(j, "pbrMetallicRoughness");
            io_json_floats(j, "baseColorFactor", mat->base_color, 4);
            io_json_number(j, "metallicFactor", mat->metallic);
            io_json_number(j, "roughnessFactor", mat->roughness);
            io_json_end_object(j);
            if (mat->double_sided)
                io_json_bool(j, "doubleSided", 1);
            if (mat->extras_json && mat->extras_json[0])
                io_json_raw(j, "extras", mat->extras_json); /* checked by json_valid() */
            io_json_end_object(j);
        }
        io_json_end_array(j);
    }

    if (sc->light_count) {
        static const char *const types[OBS_LIGHT_COUNT] = {"directional", "point", "spot"};
        io_json_begin_object(j, "extensions");
        io_json_begin_object(j, "KHR_lights_punctual");
        io_json_begin_array(j, "lights");
        for (uint32_t l = 0; l < sc->light_count; l++) {
            const obs_light *L = &sc->lights[l];
            float col[3] = {L->color.x, L->color.y, L->color.z};
            io_json_begin_object(j, NULL);
            io_json_string(j, "name", name_of(L->name).s);
            io_json_string(j, "type", types[L->type]);
            io_json_floats(j, "color", col, 3);
            io_json_number(j, "intensity", L->intensity);
            if (L->range > 0.0f) /* absent = infinite */
                io_json_number(j, "range", L->range);
            if (L->type == OBS_LIGHT_SPOT) {
                io_json_begin_object(j, "spot");
                io_json_number(j, "innerConeAngle", L->inner_cone);
                io_json_number(j, "outerConeAngle", L->outer_cone);
                io_json_end_object(j);
            }
            io_json_end_object(j);
        }
        io_json_end_array(j);
        io_json_end_object(j);
        io_json_end_object(j);
    }
    io_json_end_object(j);
}

obs_status io_glb_write(obs_context *ctx, const char *path, const obs_scene *sc)
{
    if (!path || !path[0] || !sc)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_glb_write: NULL or empty argument");
    obs_status st = validate(ctx, path, sc);
    if (st != OBS_STATUS_OK)
        return st;

    /* Lay out the BIN chunk, with overflow-checked sizes (every piece is a multiple of 4). */
    mesh_layout *layout = NULL;
    size_t bin_len = 0;
    if (sc->mesh_count) {
        layout = (mesh_layout *)calloc(sc->mesh_count, sizeof *layout);
        if (!layout)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", path);
    }
    int ok = 1;
    for (uint32_t m = 0; m < sc->mesh_count && ok; m++) {
        const obs_mesh *mesh = &sc->meshes[m];
        mesh_layout *L = &layout[m];
        ok = obs_mul_size(mesh->vertex_count, 12, &L->pos_bytes) && obs_mul_size(mesh->triangle_count, 12, &L->idx_bytes);
        L->pos = bin_len;
        ok = ok && obs_add_size(bin_len, L->pos_bytes, &bin_len);
        L->nrm = bin_len;
        if (ok && mesh->normals)
            ok = obs_add_size(bin_len, L->pos_bytes, &bin_len);
        L->idx = bin_len;
        ok = ok && obs_add_size(bin_len, L->idx_bytes, &bin_len);
        ok = ok && bin_len <= UINT32_MAX;
    }
    if (!ok) {
        free(layout);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: the mesh data exceed the 4 GiB a GLB can hold", path);
    }

    io_json j;
    io_json_init(&j);
    build_json(&j, sc, layout, bin_len);
    if (j.failed || !j.buf) {
        io_json_free(&j);
        free(layout);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory while building the glTF JSON", path);
    }

    /* Header (12) + JSON chunk header (8) + padded JSON [+ BIN chunk header (8) + BIN]. */
    size_t jpad = 0, total = 0;
    ok = obs_add_size(j.len, 3, &jpad);
    jpad &= ~(size_t)3;
    ok = ok && obs_add_size(20, jpad, &total);
    if (ok && bin_len)
        ok = obs_add_size(total, 8, &total) && obs_add_size(total, bin_len, &total);
    if (!ok || total > UINT32_MAX) {
        io_json_free(&j);
        free(layout);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: the GLB would exceed 4 GiB", path);
    }
    unsigned char *out = (unsigned char *)malloc(total);
    if (!out) {
        io_json_free(&j);
        free(layout);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate %zu bytes for the GLB", path, total);
    }

    /* GLB header and chunks, little-endian whatever the host (glTF 2.0 §4.4.3-4.4.4). */
    put_u32le(out, GLB_MAGIC);
    put_u32le(out + 4, 2u);
    put_u32le(out + 8, (uint32_t)total);
    put_u32le(out + 12, (uint32_t)jpad);
    put_u32le(out + 16, GLB_CHUNK_JSON);
    memcpy(out + 20, j.buf, j.len);
    memset(out + 20 + j.len, ' ', jpad - j.len);
    if (bin_len) {
        unsigned char *bin = out + 20 + jpad + 8;
        put_u32le(out + 20 + jpad, (uint32_t)bin_len);
        put_u32le(out + 24 + jpad, GLB_CHUNK_BIN);
        for (uint32_t m = 0; m < sc->mesh_count; m++) {
            const obs_mesh *mesh = &sc->meshes[m];
            put_floats_le(bin + layout[m].pos, mesh->positions, 3 * (size_t)mesh->vertex_count);
            if (mesh->normals)
                put_floats_le(bin + layout[m].nrm, mesh->normals, 3 * (size_t)mesh->vertex_count);
            for (size_t i = 0; i < 3 * (size_t)mesh->triangle_count; i++)
                put_u32le(bin + layout[m].idx + 4 * i, mesh->indices[i]);
        }
    }
    st = io_write_file_atomic(ctx, path, out, total);
    free(out);
    io_json_free(&j);
    free(layout);
    return st;
}
