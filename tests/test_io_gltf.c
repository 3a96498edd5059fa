/* test_io_gltf.c: the glTF 2.0 loader (io_gltf_load): valid .gltf/.glb/data-URI scenes, and
 * malformed or hostile files, which must give a clear error naming the file and an empty scene. */
#include "test.h"

#include "io/io.h"

#include <stdlib.h>
#include <string.h>

/* ---- building inputs ------------------------------------------------------------------------ */

/* The triangle's binary buffer: 3 positions, 3 normals, 3 uint16 indices (+2 bytes padding). */
#define TRI_BIN_SIZE 80
static void tri_bin(unsigned char out[TRI_BIN_SIZE], uint16_t i0, uint16_t i1, uint16_t i2)
{
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float nrm[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    const uint16_t idx[4] = {i0, i1, i2, 0};
    memcpy(out, pos, 36);
    memcpy(out + 36, nrm, 36);
    memcpy(out + 72, idx, 8);
}

static int write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    size_t n = len ? fwrite(data, 1, len, f) : 0;
    return fclose(f) == 0 && n == len;
}

static int write_text(const char *path, const char *text) { return write_file(path, text, strlen(text)); }

/* The parts of a glTF document; each is the JSON text after its key. */
typedef struct gl_parts {
    const char *buffers, *views, *accessors, *meshes, *materials, *nodes, *scenes, *extra;
} gl_parts;

#define DEF_VIEWS                                                                                    \
    "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36}," \
    "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]"
#define DEF_ACCESSORS                                                                                \
    "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}," \
    "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"                         \
    "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]"
#define DEF_MESHES                                                                                   \
    "[{\"name\":\"tri\",\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,\"material\":0}]}]"
#define DEF_MATERIALS                                                                                \
    "[{\"name\":\"red\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0,0,1],\"metallicFactor\":0.25," \
    "\"roughnessFactor\":0.5},\"doubleSided\":true}]"
/* parent: T(10,0,0) S(2); child: T(0,1,0) R(90 deg about +Z), with the mesh */
#define DEF_NODES                                                                                    \
    "[{\"name\":\"parent\",\"translation\":[10,0,0],\"scale\":[2,2,2],\"children\":[1]},"                \
    "{\"name\":\"child\",\"mesh\":0,\"translation\":[0,1,0],\"rotation\":[0,0,0.70710678,0.70710678]}]"
#define DEF_SCENES "[{\"nodes\":[0]}],\"scene\":0"

static gl_parts default_parts(const char *buffers)
{
    gl_parts p = {buffers, DEF_VIEWS, DEF_ACCESSORS, DEF_MESHES, DEF_MATERIALS, DEF_NODES, DEF_SCENES, ""};
    return p;
}

static char *format_json(const gl_parts *p)
{
    static char buf[16384];
    snprintf(buf, sizeof buf,
             "{\"asset\":{\"version\":\"2.0\"},\"buffers\":%s,\"bufferViews\":%s,\"accessors\":%s,"
             "\"meshes\":%s,\"materials\":%s,\"nodes\":%s,\"scenes\":%s%s}",
             p->buffers, p->views, p->accessors, p->meshes, p->materials, p->nodes, p->scenes, p->extra);
    return buf;
}

/* Write <name> (.gltf JSON) and tri.bin into the test directory; returns the .gltf path. */
static const char *write_gltf(const char *name, const gl_parts *p, const unsigned char *bin)
{
    static char path[4096];
    unsigned char def[TRI_BIN_SIZE];
    if (!bin) {
        tri_bin(def, 0, 1, 2);
        bin = def;
    }
    write_file(test_path(test_tmpdir(), "tri.bin"), bin, TRI_BIN_SIZE);
    snprintf(path, sizeof path, "%s", test_path(test_tmpdir(), name));
    write_text(path, format_json(p));
    return path;
}

#define EXT_BUFFERS "[{\"uri\":\"tri.bin\",\"byteLength\":80}]"

/* A .glb image of the default scene in memory (caller frees). */
static unsigned char *make_glb(size_t *len_out)
{
    gl_parts p = default_parts("[{\"byteLength\":80}]");
    const char *json = format_json(&p);
    size_t jlen = strlen(json), jpad = (jlen + 3) & ~(size_t)3;
    size_t total = 12 + 8 + jpad + 8 + TRI_BIN_SIZE;
    unsigned char *b = calloc(1, total);
    uint32_t w;
    memcpy(b, "glTF", 4);
    w = 2; memcpy(b + 4, &w, 4);
    w = (uint32_t)total; memcpy(b + 8, &w, 4);
    w = (uint32_t)jpad; memcpy(b + 12, &w, 4);
    w = 0x4E4F534A; memcpy(b + 16, &w, 4);
    memcpy(b + 20, json, jlen);
    memset(b + 20 + jlen, ' ', jpad - jlen);
    size_t off = 20 + jpad;
    w = TRI_BIN_SIZE; memcpy(b + off, &w, 4);
    w = 0x004E4942; memcpy(b + off + 4, &w, 4);
    tri_bin(b + off + 8, 0, 1, 2);
    *len_out = total;
    return b;
}

static void base64(const unsigned char *in, size_t n, char *out)
{
    static const char tbl[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16;
        if (i + 1 < n) v |= (uint32_t)in[i + 1] << 8;
        if (i + 2 < n) v |= in[i + 2];
        out[o++] = tbl[(v >> 18) & 63];
        out[o++] = tbl[(v >> 12) & 63];
        out[o++] = i + 1 < n ? tbl[(v >> 6) & 63] : '=';
        out[o++] = i + 2 < n ? tbl[v & 63] : '=';
    }
    out[o] = '\0';
}

static void quiet_log(void *user, obs_log_level level, const char *msg)
{
    (void)level;
    (void)msg;
    if (user)
        (*(int *)user)++;
}

static obs_context *make_ctx(int *warnings)
{
    obs_context *ctx = obs_context_create();
    if (ctx)
        obs_context_set_log_callback(ctx, quiet_log, warnings);
    return ctx;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Load path expecting `want` (or `want2` if not OBS_STATUS_OK); checks the message names the file,
 * contains `needle` (if not NULL), and the scene is empty. Returns 1 on success. */
static int expect_failure(const char *path, const io_gltf_options *opt, obs_status want, obs_status want2,
                          const char *needle)
{
    obs_context *ctx = make_ctx(NULL);
    obs_scene s;
    memset(&s, 0xAB, sizeof s);
    obs_status st = io_gltf_load(ctx, path, opt, &s);
    const char *msg = obs_context_last_error(ctx);
    if (getenv("OBS_TEST_VERBOSE"))
        fprintf(stderr, "[%s] %s\n", obs_status_string(st), msg);
    int ok = 1;
    if (st != want && !(want2 != OBS_STATUS_OK && st == want2)) {
        fprintf(stderr, "%s: got %s, want %s: %s\n", path, obs_status_string(st), obs_status_string(want), msg);
        ok = 0;
    }
    if (!msg[0] || !strstr(msg, base_name(path))) {
        fprintf(stderr, "%s: message does not name the file: '%s'\n", path, msg);
        ok = 0;
    }
    if (needle && !strstr(msg, needle)) {
        fprintf(stderr, "%s: message lacks '%s': '%s'\n", path, needle, msg);
        ok = 0;
    }
    if (s.mesh_count != 0 || s.meshes || s.instance_count != 0 || s.material_count != 0 || s.camera_count != 0 ||
        s.light_count != 0) {
        fprintf(stderr, "%s: scene not empty after failure\n", path);
        ok = 0;
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    return ok;
}

/* Checks shared by the external-buffer, GLB and data-URI loads of the default scene. */
static int check_default_scene(const obs_scene *s)
{
#define REQ(c)                                                                                       \
    do {                                                                                             \
        if (!(c)) {                                                                                  \
            fprintf(stderr, "%s:%d: %s\n", __FILE__, __LINE__, #c);                                  \
            return 0;                                                                                \
        }                                                                                            \
    } while (0)
#define NEAR(a, b) REQ(fabs((double)(a) - (double)(b)) < 1e-5)
    REQ(s->mesh_count == 1);
    const obs_mesh *m = &s->meshes[0];
    REQ(strcmp(m->name, "tri/prim0") == 0);
    REQ(m->vertex_count == 3 && m->triangle_count == 1);
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int i = 0; i < 9; i++)
        NEAR(m->positions[i], pos[i]);
    REQ(m->normals != NULL);
    for (int v = 0; v < 3; v++) {
        NEAR(m->normals[3 * v], 0);
        NEAR(m->normals[3 * v + 1], 0);
        NEAR(m->normals[3 * v + 2], 1);
    }
    REQ(m->indices[0] == 0 && m->indices[1] == 1 && m->indices[2] == 2);
    REQ(m->material == 0);
    REQ(s->material_count == 1);
    REQ(strcmp(s->materials[0].name, "red") == 0);
    NEAR(s->materials[0].base_color[0], 1);
    NEAR(s->materials[0].base_color[1], 0);
    NEAR(s->materials[0].metallic, 0.25);
    NEAR(s->materials[0].roughness, 0.5);
    REQ(s->materials[0].double_sided == 1);
    REQ(s->materials[0].extras_json == NULL);
    REQ(s->instance_count == 1);
    REQ(s->instances[0].mesh == 0);
    REQ(s->instances[0].node == 1);
    /* world = T(10,0,0) S(2) T(0,1,0) Rz(90): x axis -> (0,2,0), y axis -> (-2,0,0), origin -> (10,2,0) */
    const obs_mat4 *w = &s->instances[0].world;
    const float want[16] = {0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 2, 0, 10, 2, 0, 1};
    for (int i = 0; i < 16; i++)
        NEAR(w->m[i], want[i]);
    /* vertices land at (10,2,0), (10,4,0), (8,2,0) */
    NEAR(s->bounds.lo.x, 8);
    NEAR(s->bounds.lo.y, 2);
    NEAR(s->bounds.lo.z, 0);
    NEAR(s->bounds.hi.x, 10);
    NEAR(s->bounds.hi.y, 4);
    NEAR(s->bounds.hi.z, 0);
    REQ(s->camera_count == 0 && s->light_count == 0);
    return 1;
#undef NEAR
#undef REQ
}

/* ---- valid files ---------------------------------------------------------------------------- */

TEST(gltf_loads_triangle_with_external_buffer)
{
    obs_context *ctx = make_ctx(NULL);
    gl_parts p = default_parts(EXT_BUFFERS);
    const char *path = write_gltf("scene.gltf", &p, NULL);
    io_gltf_options opt = io_gltf_options_default();
    CHECK_EQ_INT(opt.scene_index, -1);
    CHECK_EQ_INT(opt.require_triangles, 1);
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, &opt, &s), ctx);
    CHECK(check_default_scene(&s));
    CHECK(strcmp(s.source, path) == 0);
    obs_scene_free(&s);
    /* NULL options mean the defaults */
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK(check_default_scene(&s));
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(glb_loads_same_scene_as_gltf)
{
    obs_context *ctx = make_ctx(NULL);
    size_t len;
    unsigned char *glb = make_glb(&len);
    const char *path = test_path(test_tmpdir(), "scene.glb");
    CHECK(write_file(path, glb, len));
    obs_scene a, b;
    CHECK_OK(io_gltf_load(ctx, path, NULL, &a), ctx);
    CHECK(check_default_scene(&a));
    /* an unknown extension is sniffed by the magic */
    const char *odd = test_path(test_tmpdir(), "scene.bytes");
    CHECK(write_file(odd, glb, len));
    CHECK_OK(io_gltf_load(ctx, odd, NULL, &b), ctx);
    CHECK(check_default_scene(&b));
    CHECK(memcmp(a.meshes[0].positions, b.meshes[0].positions, 36) == 0);
    obs_scene_free(&b);
    /* and the same scene as the .gltf with an external buffer */
    gl_parts p = default_parts(EXT_BUFFERS);
    const char *gpath = write_gltf("scene.gltf", &p, NULL);
    CHECK_OK(io_gltf_load(ctx, gpath, NULL, &b), ctx);
    CHECK_EQ_INT(a.mesh_count, b.mesh_count);
    CHECK(memcmp(a.meshes[0].positions, b.meshes[0].positions, 36) == 0);
    CHECK(memcmp(a.meshes[0].normals, b.meshes[0].normals, 36) == 0);
    CHECK(memcmp(a.meshes[0].indices, b.meshes[0].indices, 12) == 0);
    CHECK(memcmp(&a.instances[0].world, &b.instances[0].world, sizeof(obs_mat4)) == 0);
    CHECK(memcmp(&a.bounds, &b.bounds, sizeof a.bounds) == 0);
    obs_scene_free(&a);
    obs_scene_free(&b);
    free(glb);
    obs_context_destroy(ctx);
}

TEST(gltf_data_uri_buffer_loads)
{
    obs_context *ctx = make_ctx(NULL);
    unsigned char bin[TRI_BIN_SIZE];
    tri_bin(bin, 0, 1, 2);
    char b64[256], buffers[512];
    base64(bin, sizeof bin, b64);
    snprintf(buffers, sizeof buffers, "[{\"uri\":\"data:application/octet-stream;base64,%s\",\"byteLength\":80}]", b64);
    gl_parts p = default_parts(buffers);
    const char *path = test_path(test_tmpdir(), "embedded.gltf");
    CHECK(write_text(path, format_json(&p)));
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK(check_default_scene(&s));
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- malformed files ------------------------------------------------------------------------ */

TEST(gltf_truncated_glb_is_parse_error)
{
    size_t len;
    unsigned char *glb = make_glb(&len);
    const char *path = test_path(test_tmpdir(), "cut.glb");
    /* every proper prefix of the file, down to empty */
    for (size_t n = 0; n < len; n++) {
        CHECK(write_file(path, glb, n));
        CHECK_MSG(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL), "prefix of %zu bytes", n);
    }
    /* a BIN chunk length that runs 4 bytes past the end (tinygltf's own check misses this) */
    {
        CHECK(len >= 32);
        unsigned char *b = calloc(1, len + 8);
        CHECK(b != NULL);
        memcpy(b, glb, len);
        uint32_t jpad = 0, c1 = 0;
        memcpy(&jpad, b + 12, 4);
        memcpy(&c1, b + 20 + jpad, 4);
        c1 += 4;
        memcpy(b + 20 + jpad, &c1, 4);
        CHECK(write_file(path, b, len));
        free(b);
        CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "GLB"));
    }
    free(glb);
}

TEST(gltf_truncated_json_is_parse_error)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    char *json = strdup(format_json(&p));
    size_t len = strlen(json);
    unsigned char bin[TRI_BIN_SIZE];
    tri_bin(bin, 0, 1, 2);
    CHECK(write_file(test_path(test_tmpdir(), "tri.bin"), bin, sizeof bin));
    const char *path = test_path(test_tmpdir(), "cut.gltf");
    for (size_t n = 1; n < len; n += (n < 40 ? 1 : 13)) {
        CHECK(write_file(path, json, n));
        CHECK_MSG(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL), "prefix of %zu bytes", n);
    }
    CHECK(write_file(path, json, len - 1));
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL));
    /* deep nesting is refused before tinygltf recurses into it */
    {
        size_t depth = 100000;
        char *deep = malloc(depth * 2 + 256);
        size_t o = (size_t)sprintf(deep, "{\"asset\":{\"version\":\"2.0\"},\"extras\":");
        for (size_t i = 0; i < depth; i++)
            deep[o++] = '[';
        for (size_t i = 0; i < depth; i++)
            deep[o++] = ']';
        deep[o++] = '}';
        CHECK(write_file(path, deep, o));
        free(deep);
        CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "nested"));
    }
    free(json);
}

TEST(gltf_accessor_out_of_range_is_error)
{
    /* count 1000 in a 36-byte bufferView */
    gl_parts p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":1000,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    const char *path = write_gltf("count.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "accessor 0 (bufferView 0)"));
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "byteLength 36"));
    /* a byteOffset that pushes the last element out */
    p.accessors = "[{\"bufferView\":0,\"byteOffset\":4,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("offset.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "accessor"));
    /* a stride that overflows 64 bits when multiplied by the count */
    p.views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36,\"byteStride\":4611686018427387904},"
              "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]";
    p.accessors = DEF_ACCESSORS;
    path = write_gltf("stride.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL));
    /* an accessor byteOffset that wraps 64 bits when the element size is added */
    p.views = DEF_VIEWS;
    p.accessors = "[{\"bufferView\":0,\"byteOffset\":18446744073709551608,\"componentType\":5126,\"count\":1,"
                  "\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("wrap.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "accessor 0"));
    /* an accessor index past the end of the accessor array */
    p = default_parts(EXT_BUFFERS);
    p.meshes = "[{\"name\":\"tri\",\"primitives\":[{\"attributes\":{\"POSITION\":9},\"indices\":2}]}]";
    path = write_gltf("index.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "accessor 9"));
    /* a stride smaller than the element */
    p = default_parts(EXT_BUFFERS);
    p.views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36,\"byteStride\":8},"
              "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]";
    path = write_gltf("small_stride.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "byteStride"));
    /* normals that do not match the positions */
    p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("normals.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "NORMAL count"));
    /* sparse accessors are refused clearly */
    p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":1,"
                  "\"indices\":{\"bufferView\":2,\"componentType\":5123},\"values\":{\"bufferView\":1}}},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("sparse.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_UNSUPPORTED, OBS_STATUS_OK, "sparse"));
}

TEST(gltf_bufferview_out_of_buffer_is_error)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    p.views = "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":200},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},"
              "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]";
    const char *path = write_gltf("view.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "bufferView 0"));
    /* offset + length overflowing 64 bits */
    p.views = "[{\"buffer\":0,\"byteOffset\":18446744073709551600,\"byteLength\":36},"
              "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]";
    path = write_gltf("view_wrap.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL));
    /* a bufferView naming a buffer that does not exist */
    p.views = "[{\"buffer\":3,\"byteOffset\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},"
              "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}]";
    path = write_gltf("view_buffer.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "buffer 3"));
    /* an accessor naming a bufferView that does not exist */
    p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":7,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("view_index.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "bufferView 7"));
}

TEST(gltf_wrong_component_type_is_error)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5123,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    const char *path = write_gltf("pos_type.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "wrong component type"));
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5126,\"count\":1,\"type\":\"SCALAR\"}]";
    path = write_gltf("idx_type.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "wrong component type"));
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("pos_vec2.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "wrong component type"));
    /* the accessor's bufferView is not the problem: a bufferless FLOAT VEC3 normal is fine,
     * but a signed-short index accessor is not */
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5122,\"count\":3,\"type\":\"SCALAR\"}]";
    path = write_gltf("idx_signed.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "wrong component type"));
}

TEST(gltf_missing_buffer_file_is_io_error)
{
    gl_parts p = default_parts("[{\"uri\":\"missing_buffer.bin\",\"byteLength\":80}]");
    const char *path = write_gltf("nobin.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_IO_ERROR, OBS_STATUS_OK, "missing_buffer.bin"));
    /* present but of the wrong size is a content error */
    p = default_parts("[{\"uri\":\"tri.bin\",\"byteLength\":96}]");
    path = write_gltf("shortbin.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "tri.bin"));
}

TEST(gltf_cyclic_node_graph_is_error)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    p.nodes = "[{\"children\":[1]},{\"mesh\":0,\"children\":[2]},{\"children\":[1]}]";
    const char *path = write_gltf("cycle.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL));
    /* a pure cycle with no root at all, and no scenes */
    p.nodes = "[{\"mesh\":0,\"children\":[1]},{\"children\":[0]}]";
    p.scenes = "[]";
    path = write_gltf("loop.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "cyclic node graph at node"));
    /* a node that is its own child */
    p = default_parts(EXT_BUFFERS);
    p.nodes = "[{\"mesh\":0,\"children\":[0]}]";
    path = write_gltf("self.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "cyclic node graph at node 0"));
    /* two parents (a DAG, which glTF forbids) */
    p.nodes = "[{\"children\":[2]},{\"children\":[2]},{\"mesh\":0}]";
    p.scenes = "[{\"nodes\":[0,1]}]";
    path = write_gltf("dag.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "node 2"));
    /* a child index out of range */
    p.nodes = "[{\"children\":[5]}]";
    p.scenes = "[{\"nodes\":[0]}]";
    path = write_gltf("child.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "child index 5"));
    /* a deep chain is fine (no recursion) */
    {
        static char nodes[600000];
        size_t o = 0, n = 20000;
        nodes[o++] = '[';
        for (size_t i = 0; i + 1 < n; i++)
            o += (size_t)sprintf(nodes + o, "{\"children\":[%zu]},", i + 1);
        o += (size_t)sprintf(nodes + o, "{\"mesh\":0}]");
        p = default_parts(EXT_BUFFERS);
        p.nodes = nodes;
        path = test_path(test_tmpdir(), "chain.gltf");
        char *json = malloc(o + 4096);
        snprintf(json, o + 4096,
                 "{\"asset\":{\"version\":\"2.0\"},\"buffers\":%s,\"bufferViews\":%s,\"accessors\":%s,"
                 "\"meshes\":%s,\"materials\":%s,\"nodes\":%s,\"scenes\":[{\"nodes\":[0]}]}",
                 p.buffers, p.views, p.accessors, p.meshes, p.materials, nodes);
        CHECK(write_text(path, json));
        free(json);
        obs_context *ctx = make_ctx(NULL);
        obs_scene s;
        CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
        CHECK_EQ_INT(s.instance_count, 1);
        CHECK_EQ_INT(s.instances[0].node, n - 1);
        obs_scene_free(&s);
        obs_context_destroy(ctx);
    }
}

TEST(gltf_index_out_of_range_is_error)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    unsigned char bin[TRI_BIN_SIZE];
    tri_bin(bin, 0, 7, 2);
    const char *path = write_gltf("badindex.gltf", &p, bin);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "vertex count 3"));
    /* an index count that is not a multiple of 3 */
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":2,\"type\":\"SCALAR\"}]";
    path = write_gltf("twoindices.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "multiple of 3"));
    /* a material index out of range */
    p = default_parts(EXT_BUFFERS);
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":2,\"material\":4}]}]";
    path = write_gltf("badmaterial.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "material 4"));
    /* a node mesh index out of range */
    p = default_parts(EXT_BUFFERS);
    p.nodes = "[{\"mesh\":3}]";
    path = write_gltf("badmesh.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "mesh 3"));
}

TEST(gltf_absurd_counts_are_refused)
{
    /* 2^31 vertices claimed in a 36-byte view: refused without allocating */
    gl_parts p = default_parts(EXT_BUFFERS);
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":2147483648,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    const char *path = write_gltf("huge.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_LIMIT_EXCEEDED, OBS_STATUS_PARSE_ERROR, NULL));
    /* 2^31 zero vertices (no bufferView: legal, all zeros): the limit refuses it */
    p.accessors = "[{\"componentType\":5126,\"count\":2147483648,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]";
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":2}]}]";
    path = write_gltf("zeros.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_LIMIT_EXCEEDED, OBS_STATUS_OK, "--max-vertices"));
    /* 2^40 - 1 indices in a 6-byte view (tinygltf itself refuses index accessors without a
     * bufferView, so the range check or the limit must catch it) */
    p.accessors = "[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                  "{\"bufferView\":2,\"componentType\":5125,\"count\":1099511627775,\"type\":\"SCALAR\"}]";
    path = write_gltf("hugeidx.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_LIMIT_EXCEEDED, NULL));

    /* a valid file over small context limits */
    p = default_parts(EXT_BUFFERS);
    path = write_gltf("small.gltf", &p, NULL);
    obs_context *ctx = make_ctx(NULL);
    obs_limits lim = obs_limits_default();
    lim.max_vertices = 2;
    obs_context_set_limits(ctx, &lim);
    obs_scene s;
    CHECK_EQ_INT(io_gltf_load(ctx, path, NULL, &s), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "small.gltf") != NULL);
    CHECK(strstr(obs_context_last_error(ctx), "--max-vertices") != NULL);
    CHECK_EQ_INT(s.mesh_count, 0);
    obs_context_clear_error(ctx);
    lim = obs_limits_default();
    lim.max_triangles = 0;
    obs_context_set_limits(ctx, &lim);
    CHECK_EQ_INT(io_gltf_load(ctx, path, NULL, &s), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "small.gltf") != NULL);
    CHECK(strstr(obs_context_last_error(ctx), "--max-triangles") != NULL);
    CHECK_EQ_INT(s.mesh_count, 0);
    obs_context_clear_error(ctx);
    lim = obs_limits_default();
    lim.max_vertices = 3;
    lim.max_triangles = 1;
    obs_context_set_limits(ctx, &lim);
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_non_triangle_mode_is_unsupported)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    p.meshes = "[{\"name\":\"mixed\",\"primitives\":["
               "{\"attributes\":{\"POSITION\":0},\"mode\":1},"
               "{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,\"mode\":4}]}]";
    const char *path = write_gltf("lines.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_UNSUPPORTED, OBS_STATUS_OK, "LINES"));
    /* with require_triangles = 0 the lines are skipped with a warning */
    int warnings = 0;
    obs_context *ctx = make_ctx(&warnings);
    io_gltf_options opt = io_gltf_options_default();
    opt.require_triangles = 0;
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, &opt, &s), ctx);
    CHECK(warnings >= 1);
    CHECK_EQ_INT(s.mesh_count, 1);
    CHECK(strcmp(s.meshes[0].name, "mixed/prim1") == 0);
    CHECK_EQ_INT(s.meshes[0].material, -1);
    CHECK_EQ_INT(s.instance_count, 1);
    CHECK_EQ_INT(s.instances[0].mesh, 0);
    obs_scene_free(&s);
    /* a non-indexed primitive gets 0..n-1 */
    p.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}]";
    path = write_gltf("nonindexed.gltf", &p, NULL);
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK_EQ_INT(s.meshes[0].triangle_count, 1);
    CHECK(s.meshes[0].normals == NULL);
    CHECK(strcmp(s.meshes[0].name, "mesh0/prim0") == 0);
    CHECK(s.meshes[0].indices[0] == 0 && s.meshes[0].indices[1] == 1 && s.meshes[0].indices[2] == 2);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_required_unknown_extension_is_unsupported)
{
    gl_parts p = default_parts(EXT_BUFFERS);
    p.extra = ",\"extensionsUsed\":[\"EXT_mesh_gpu_instancing\"],"
              "\"extensionsRequired\":[\"EXT_mesh_gpu_instancing\"]";
    const char *path = write_gltf("instancing.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_UNSUPPORTED, OBS_STATUS_OK, "EXT_mesh_gpu_instancing"));
    /* a required extension that only affects materials does not stop the load */
    p.extra = ",\"extensionsUsed\":[\"KHR_materials_emissive_strength\"],"
              "\"extensionsRequired\":[\"KHR_materials_emissive_strength\"]";
    path = write_gltf("emissive.gltf", &p, NULL);
    obs_context *ctx = make_ctx(NULL);
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK(check_default_scene(&s));
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_reads_cameras_and_lights)
{
    obs_context *ctx = make_ctx(NULL);
    gl_parts p = default_parts(EXT_BUFFERS);
    p.nodes = "["
              /* 0: perspective with zfar, at (0,0,5), scaled by 3 (the scale must be removed) */
              "{\"name\":\"camnode\",\"camera\":0,\"translation\":[0,0,5],\"scale\":[3,3,3]},"
              /* 1: perspective without zfar or aspect, under node 5 (translation (1,0,0)) */
              "{\"camera\":1,\"translation\":[0,2,0]},"
              /* 2: orthographic, rotated 90 deg about +Y: looks along -X */
              "{\"camera\":2,\"rotation\":[0,0.70710678,0,0.70710678]},"
              /* 3: point light under node 5 */
              "{\"name\":\"bulb\",\"translation\":[0,0,-2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
              /* 4: spot light at (1,2,3) rotated +90 deg about X: -Z turns to +Y */
              "{\"translation\":[1,2,3],\"rotation\":[0.70710678,0,0,0.70710678],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},"
              /* 5: parent */
              "{\"translation\":[1,0,0],\"children\":[1,3]}]";
    p.scenes = "[{\"nodes\":[0,2,4,5]}]";
    p.extra = ",\"cameras\":["
              "{\"name\":\"main\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"aspectRatio\":1.5,"
              "\"znear\":0.1,\"zfar\":100}},"
              "{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.0,\"znear\":0.05}},"
              "{\"name\":\"ortho\",\"type\":\"orthographic\",\"orthographic\":{\"xmag\":2,\"ymag\":1.5,"
              "\"znear\":0,\"zfar\":50}}],"
              "\"extensionsUsed\":[\"KHR_lights_punctual\"],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
              "{\"name\":\"pt\",\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":20,\"range\":10},"
              "{\"type\":\"spot\",\"spot\":{\"innerConeAngle\":0.2,\"outerConeAngle\":0.5}}]}}";
    const char *path = write_gltf("camlight.gltf", &p, NULL);
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK_EQ_INT(s.instance_count, 0);
    CHECK_EQ_INT(s.camera_count, 3);
    CHECK_EQ_INT(s.light_count, 2);

    /* scene order: node 0, 2, 4, 5 (then its children 1, 3) */
    const obs_camera *c0 = &s.cameras[0], *c1 = &s.cameras[2], *co = &s.cameras[1];
    CHECK(strcmp(c0->name, "main") == 0);
    CHECK_EQ_INT(c0->projection, OBS_PROJECTION_PERSPECTIVE);
    CHECK_NEAR(c0->yfov, 0.8, 1e-6);
    CHECK_NEAR(c0->aspect, 1.5, 1e-6);
    CHECK_NEAR(c0->znear, 0.1, 1e-6);
    CHECK_NEAR(c0->zfar, 100, 1e-4);
    const float id_at_z5[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1};
    for (int i = 0; i < 16; i++)
        CHECK_NEAR(c0->world.m[i], id_at_z5[i], 1e-5);
    obs_vec3 vo = obs_mat4_mul_point(c0->view, obs_v3(0, 0, 5));
    CHECK_NEAR(obs_v3_length(vo), 0, 1e-5);

    CHECK(c1->name[0] == '\0');
    CHECK_EQ_INT(c1->projection, OBS_PROJECTION_PERSPECTIVE);
    CHECK_NEAR(c1->aspect, 0, 0);
    CHECK(isinf(c1->zfar) && c1->zfar > 0);
    CHECK_NEAR(c1->world.m[12], 1, 1e-6);
    CHECK_NEAR(c1->world.m[13], 2, 1e-6);
    CHECK_NEAR(c1->world.m[14], 0, 1e-6);

    CHECK(strcmp(co->name, "ortho") == 0);
    CHECK_EQ_INT(co->projection, OBS_PROJECTION_ORTHOGRAPHIC);
    CHECK_NEAR(co->xmag, 2, 1e-6);
    CHECK_NEAR(co->ymag, 1.5, 1e-6);
    CHECK_NEAR(co->znear, 0, 0);
    CHECK_NEAR(co->zfar, 50, 1e-5);
    obs_vec3 fwd = obs_mat4_mul_dir(co->world, obs_v3(0, 0, -1));
    CHECK_NEAR(fwd.x, -1, 1e-5);
    CHECK_NEAR(fwd.y, 0, 1e-5);
    CHECK_NEAR(fwd.z, 0, 1e-5);

    const obs_light *spot = &s.lights[0], *pt = &s.lights[1];
    CHECK_EQ_INT(spot->type, OBS_LIGHT_SPOT);
    CHECK_EQ_INT(spot->node, 4);
    CHECK_NEAR(spot->position.x, 1, 1e-5);
    CHECK_NEAR(spot->position.y, 2, 1e-5);
    CHECK_NEAR(spot->position.z, 3, 1e-5);
    CHECK_NEAR(spot->direction.x, 0, 1e-5);
    CHECK_NEAR(spot->direction.y, 1, 1e-5);
    CHECK_NEAR(spot->direction.z, 0, 1e-5);
    CHECK_NEAR(spot->inner_cone, 0.2, 1e-6);
    CHECK_NEAR(spot->outer_cone, 0.5, 1e-6);
    CHECK_NEAR(spot->intensity, 1, 0);          /* default */
    CHECK_NEAR(spot->color.x, 1, 0);
    CHECK_NEAR(spot->range, 0, 0);

    CHECK_EQ_INT(pt->type, OBS_LIGHT_POINT);
    CHECK(strcmp(pt->name, "pt") == 0);
    CHECK_EQ_INT(pt->node, 3);
    CHECK_NEAR(pt->position.x, 1, 1e-6);
    CHECK_NEAR(pt->position.y, 0, 1e-6);
    CHECK_NEAR(pt->position.z, -2, 1e-6);
    CHECK_NEAR(pt->direction.z, -1, 1e-6);
    CHECK_NEAR(pt->color.y, 0.5, 1e-6);
    CHECK_NEAR(pt->color.z, 0.25, 1e-6);
    CHECK_NEAR(pt->intensity, 20, 1e-5);
    CHECK_NEAR(pt->range, 10, 1e-5);
    obs_scene_free(&s);

    /* invalid camera parameters name the camera */
    p.extra = ",\"cameras\":[{\"name\":\"wide\",\"type\":\"perspective\",\"perspective\":{\"yfov\":4,\"znear\":0.1}},"
              "{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}},"
              "{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"znear\":0,\"zfar\":1}}],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\"},{\"type\":\"point\"}]}}";
    path = write_gltf("badcam.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "camera 0 'wide'"));
    p.extra = ",\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":1,\"zfar\":0.5}},"
              "{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}},"
              "{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"znear\":0,\"zfar\":1}}],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\"},{\"type\":\"point\"}]}}";
    path = write_gltf("badfar.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "zfar"));
    /* a light reference out of range */
    p.extra = ",\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}},"
              "{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}},"
              "{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"znear\":0,\"zfar\":1}}],"
              "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\"}]}}";
    path = write_gltf("badlight.gltf", &p, NULL);
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, "light 1"));
    obs_context_destroy(ctx);
}

TEST(gltf_material_extras_are_kept_as_json)
{
    obs_context *ctx = make_ctx(NULL);
    gl_parts p = default_parts(EXT_BUFFERS);
    p.materials = "[{\"name\":\"floor\",\"extras\":{\"tag\":\"floor\",\"id\":7,\"w\":0.5,\"flags\":[true,false],"
                  "\"s\":\"a\\\"b\\\\c\\n\\u0001\\u00e9\",\"nested\":{\"k\":[1,2.5,-3e-20]}}},"
                  "{\"name\":\"plain\"}]";
    const char *path = write_gltf("extras.gltf", &p, NULL);
    obs_scene s;
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK_EQ_INT(s.material_count, 2);
    CHECK(s.materials[0].extras_json != NULL);
    const char *want = "{\"flags\":[true,false],\"id\":7,\"nested\":{\"k\":[1,2.5,-3e-20]},"
                       "\"s\":\"a\\\"b\\\\c\\n\\u0001\xc3\xa9\",\"tag\":\"floor\",\"w\":0.5}";
    CHECK_MSG(strcmp(s.materials[0].extras_json, want) == 0, "extras: %s\n  want: %s", s.materials[0].extras_json,
              want);
    CHECK(s.materials[1].extras_json == NULL);
    /* defaults per spec */
    CHECK_NEAR(s.materials[1].base_color[0], 1, 0);
    CHECK_NEAR(s.materials[1].base_color[3], 1, 0);
    CHECK_NEAR(s.materials[1].metallic, 1, 0);
    CHECK_NEAR(s.materials[1].roughness, 1, 0);
    CHECK_EQ_INT(s.materials[1].double_sided, 0);
    obs_scene_free(&s);
    /* a long name is cut to OBS_NAME_MAX - 1 characters */
    p.materials = "[{\"name\":\"aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\"}]";
    path = write_gltf("longname.gltf", &p, NULL);
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK_EQ_INT(strlen(s.materials[0].name), OBS_NAME_MAX - 1);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_missing_file_is_io_error)
{
    const char *path = test_path(test_tmpdir(), "does_not_exist.gltf");
    CHECK(expect_failure(path, NULL, OBS_STATUS_IO_ERROR, OBS_STATUS_OK, "does_not_exist.gltf"));
    path = test_path(test_tmpdir(), "does_not_exist.glb");
    CHECK(expect_failure(path, NULL, OBS_STATUS_IO_ERROR, OBS_STATUS_OK, NULL));
    /* a directory is not a file */
    CHECK(expect_failure(test_tmpdir(), NULL, OBS_STATUS_IO_ERROR, OBS_STATUS_OK, NULL));
    /* an empty file is a parse error, not a crash */
    path = test_path(test_tmpdir(), "empty.gltf");
    CHECK(write_file(path, "", 0));
    CHECK(expect_failure(path, NULL, OBS_STATUS_PARSE_ERROR, OBS_STATUS_OK, NULL));
    /* a requested scene that does not exist */
    gl_parts p = default_parts(EXT_BUFFERS);
    path = write_gltf("onescene.gltf", &p, NULL);
    io_gltf_options opt = io_gltf_options_default();
    opt.scene_index = 3;
    CHECK(expect_failure(path, &opt, OBS_STATUS_NOT_FOUND, OBS_STATUS_OK, "scene 3"));
}
