/* test_io_memory.c: the in-memory entry points io_gltf_load_memory and io_image_read_memory
 * (used by the fuzz targets, tests/fuzz/): they give the same results as the file versions on
 * valid input, the same statuses on broken input, and a clear IO_ERROR for a glTF whose buffers
 * live in external files. */
#include "test.h"

#include "io/io.h"

#include <stdlib.h>
#include <string.h>

static int write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    size_t n = len ? fwrite(data, 1, len, f) : 0;
    return fclose(f) == 0 && n == len;
}

static void base64(const unsigned char *in, size_t n, char *out)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)in[i] << 16 | (i + 1 < n ? (unsigned)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
        out[o++] = t[v >> 18 & 63];
        out[o++] = t[v >> 12 & 63];
        out[o++] = i + 1 < n ? t[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? t[v & 63] : '=';
    }
    out[o] = '\0';
}

/* One triangle (positions then uint16 indices + padding: 44 bytes) as a .gltf whose buffer is
 * `uri_json` (a JSON string value, e.g. "\"data:...\"" or "\"tri.bin\""). */
static const char *tri_gltf(const char *uri_json)
{
    static char buf[4096];
    snprintf(buf, sizeof buf,
             "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":%s,\"byteLength\":44}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
             "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             uri_json);
    return buf;
}

static void tri_bin(unsigned char out[44])
{
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint16_t idx[4] = {0, 1, 2, 0};
    memcpy(out, pos, 36);
    memcpy(out + 36, idx, 8);
}

static int same_scene(const obs_scene *a, const obs_scene *b)
{
    if (a->mesh_count != b->mesh_count || a->instance_count != b->instance_count ||
        a->camera_count != b->camera_count || a->light_count != b->light_count ||
        a->material_count != b->material_count)
        return 0;
    for (uint32_t m = 0; m < a->mesh_count; m++) {
        const obs_mesh *x = &a->meshes[m], *y = &b->meshes[m];
        if (x->vertex_count != y->vertex_count || x->triangle_count != y->triangle_count ||
            memcmp(x->positions, y->positions, (size_t)x->vertex_count * 12) != 0 ||
            memcmp(x->indices, y->indices, (size_t)x->triangle_count * 12) != 0 || (!x->normals) != (!y->normals) ||
            (x->normals && memcmp(x->normals, y->normals, (size_t)x->vertex_count * 12) != 0))
            return 0;
    }
    for (uint32_t i = 0; i < a->instance_count; i++)
        if (memcmp(&a->instances[i], &b->instances[i], sizeof(obs_instance)) != 0)
            return 0;
    for (uint32_t c = 0; c < a->camera_count; c++)
        if (memcmp(&a->cameras[c], &b->cameras[c], sizeof(obs_camera)) != 0)
            return 0;
    return memcmp(&a->bounds, &b->bounds, sizeof a->bounds) == 0;
}

static obs_context *quiet_ctx(void)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_log_level(ctx, OBS_LOG_ERROR);
    return ctx;
}

/* ---- glTF ----------------------------------------------------------------------------------- */

TEST(gltf_memory_loads_the_same_scene_as_the_file)
{
    obs_context *ctx = quiet_ctx();
    const char *names[] = {"plane.glb", "closed_box.glb", "cornell_box.glb"};
    for (int k = 0; k < 3; k++) {
        const char *path = test_path(test_data_dir(), names[k]);
        size_t len = 0;
        unsigned char *bytes = (unsigned char *)test_slurp(path, &len);
        CHECK_MSG(bytes != NULL, "cannot read %s", path);
        obs_scene a, b;
        CHECK_OK(io_gltf_load(ctx, path, NULL, &a), ctx);
        /* a name without the .glb extension: the magic selects the binary container */
        CHECK_OK(io_gltf_load_memory(ctx, "scene-bytes", bytes, len, NULL, &b), ctx);
        CHECK_MSG(same_scene(&a, &b), "%s: memory and file loads differ", names[k]);
        CHECK(strcmp(b.source, "scene-bytes") == 0);
        obs_scene_free(&a);
        obs_scene_free(&b);
        free(bytes);
    }
    obs_context_destroy(ctx);
}

TEST(gltf_memory_text_with_data_uri_loads)
{
    obs_context *ctx = quiet_ctx();
    unsigned char bin[44];
    tri_bin(bin);
    char b64[128], uri[256];
    base64(bin, sizeof bin, b64);
    snprintf(uri, sizeof uri, "\"data:application/octet-stream;base64,%s\"", b64);
    const char *text = tri_gltf(uri);
    obs_scene s;
    CHECK_OK(io_gltf_load_memory(ctx, NULL, text, strlen(text), NULL, &s), ctx);
    CHECK_EQ_INT(s.mesh_count, 1);
    CHECK_EQ_INT(s.meshes[0].triangle_count, 1);
    CHECK_EQ_INT(s.instance_count, 1);
    CHECK(strcmp(s.source, "<memory>") == 0);
    CHECK_NEAR(s.meshes[0].positions[3], 1.0, 0.0);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_memory_external_buffer_is_io_error_even_when_the_file_exists)
{
    obs_context *ctx = quiet_ctx();
    /* tri.bin exists in the current directory and beside a file of that name: from memory it must
     * still not resolve (the bytes have no directory) */
    unsigned char bin[44];
    tri_bin(bin);
    CHECK(write_file(test_path(test_tmpdir(), "tri.bin"), bin, sizeof bin));
    const char *text = tri_gltf("\"tri.bin\"");
    obs_scene s;
    obs_status st = io_gltf_load_memory(ctx, test_path(test_tmpdir(), "scene.gltf"), text, strlen(text), NULL, &s);
    CHECK_EQ_INT(st, OBS_STATUS_IO_ERROR);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "from memory") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK_MSG(strstr(obs_context_last_error(ctx), "scene.gltf") != NULL, "message: %s", obs_context_last_error(ctx));
    CHECK_EQ_INT(s.mesh_count, 0);
    CHECK(s.meshes == NULL);
    /* the same text from a file beside tri.bin loads: the difference is the memory source only */
    const char *path = test_path(test_tmpdir(), "scene.gltf");
    CHECK(write_file(path, text, strlen(text)));
    obs_context_clear_error(ctx);
    CHECK_OK(io_gltf_load(ctx, path, NULL, &s), ctx);
    CHECK_EQ_INT(s.mesh_count, 1);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_memory_broken_input_gives_the_file_statuses)
{
    obs_context *ctx = quiet_ctx();
    const char *path = test_path(test_data_dir(), "plane.glb");
    size_t len = 0;
    unsigned char *glb = (unsigned char *)test_slurp(path, &len);
    CHECK(glb != NULL && len > 64);
    obs_scene s;
    /* every prefix of a valid GLB is refused with PARSE_ERROR and leaves the scene empty */
    for (size_t n = 1; n < len; n += (n < 64 ? 1 : 97)) {
        obs_context_clear_error(ctx);
        obs_status st = io_gltf_load_memory(ctx, "cut.glb", glb, n, NULL, &s);
        CHECK_MSG(st == OBS_STATUS_PARSE_ERROR, "prefix of %zu bytes: %s (%s)", n, obs_status_string(st),
                  obs_context_last_error(ctx));
        CHECK(s.mesh_count == 0 && s.meshes == NULL && s.instances == NULL);
    }
    /* no bytes, NULL data, NULL output */
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "empty.glb", glb, 0, NULL, &s), OBS_STATUS_PARSE_ERROR);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "null.glb", NULL, 10, NULL, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "null.glb", glb, len, NULL, NULL), OBS_STATUS_INVALID_ARGUMENT);
    /* limits hold for memory input too: the byte count against --max-memory, then the triangles */
    obs_limits lim = obs_limits_default();
    lim.max_memory_bytes = 100;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "plane.glb", glb, len, NULL, &s), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-memory") != NULL);
    lim = obs_limits_default();
    lim.max_triangles = 1;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "plane.glb", glb, len, NULL, &s), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-triangles") != NULL);
    /* JSON that is not glTF */
    lim = obs_limits_default();
    obs_context_set_limits(ctx, &lim);
    const char *junk = "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":7}}]}],"
                       "\"nodes\":[{\"mesh\":0}]}";
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "junk.gltf", junk, strlen(junk), NULL, &s), OBS_STATUS_PARSE_ERROR);
    free(glb);
    obs_context_destroy(ctx);
}

/* ---- images --------------------------------------------------------------------------------- */

static int same_image(const io_image *a, const io_image *b)
{
    if (a->width != b->width || a->height != b->height || a->channel_count != b->channel_count ||
        a->attr_count != b->attr_count)
        return 0;
    for (int c = 0; c < a->channel_count; c++) {
        if (strcmp(a->names[c], b->names[c]) != 0 || a->types[c] != b->types[c])
            return 0;
        for (int y = 0; y < a->height; y++) {
            if (a->types[c] == IO_PIXEL_UINT) {
                if (memcmp(obs_image_u32_row(&a->u32[c], y), obs_image_u32_row(&b->u32[c], y), (size_t)a->width * 4))
                    return 0;
            } else if (memcmp(obs_image_f32_row(&a->f32[c], y), obs_image_f32_row(&b->f32[c], y),
                              (size_t)a->width * 4)) {
                return 0;
            }
        }
    }
    return 1;
}

/* A 7x5 EXR with a float, a half and a uint channel and a few attributes; a 7x5 grey PNG. */
static int write_samples(obs_context *ctx, const char *exr, const char *png)
{
    obs_image_f32 f, h, g;
    obs_image_u32 u;
    if (obs_image_f32_alloc(ctx, 7, 5, &f) || obs_image_f32_alloc(ctx, 7, 5, &h) ||
        obs_image_u32_alloc(ctx, 7, 5, &u) || obs_image_f32_alloc(ctx, 7, 5, &g))
        return 0;
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 7; x++) {
            obs_image_f32_row(&f, y)[x] = x == 3 && y == 2 ? INFINITY : (float)(x * 0.37 - y * 1.5);
            obs_image_f32_row(&h, y)[x] = (float)(x + y) * 0.25f;
            obs_image_u32_row(&u, y)[x] = x == 0 ? 0xFFFFFFFFu : (uint32_t)(x * 100000 + y);
            obs_image_f32_row(&g, y)[x] = (float)(x + 7 * y) / 34.0f;
        }
    io_channel ch[3] = {{"Z", IO_PIXEL_FLOAT, &f, NULL}, {"N.X", IO_PIXEL_HALF, &h, NULL}, {"primid", IO_PIXEL_UINT, NULL, &u}};
    float m[16];
    for (int i = 0; i < 16; i++)
        m[i] = (float)i;
    io_attr at[3];
    memset(at, 0, sizeof at);
    strcpy(at[0].name, "obscura:text"); at[0].type = IO_ATTR_STRING; at[0].s = "memory test";
    strcpy(at[1].name, "obscura:count"); at[1].type = IO_ATTR_INT; at[1].i = 42;
    strcpy(at[2].name, "worldToCamera"); at[2].type = IO_ATTR_MATRIX44; at[2].v = m;
    int ok = io_exr_write(ctx, exr, ch, 3, at, 3) == OBS_STATUS_OK &&
             io_png_write(ctx, png, &g, 1, IO_PNG_LINEAR) == OBS_STATUS_OK;
    obs_image_f32_free(&f);
    obs_image_f32_free(&h);
    obs_image_f32_free(&g);
    obs_image_u32_free(&u);
    return ok;
}

TEST(image_memory_reads_exr_and_png_like_the_file_reader_whatever_the_name)
{
    obs_context *ctx = quiet_ctx();
    const char *exr = test_path(test_tmpdir(), "sample.exr");
    const char *png = test_path(test_tmpdir(), "sample.png");
    CHECK_MSG(write_samples(ctx, exr, png), "%s", obs_context_last_error(ctx));
    const char *files[2] = {exr, png};
    const char *names[2] = {"bytes.exr", "bytes.png"};
    for (int k = 0; k < 2; k++) {
        size_t len = 0;
        unsigned char *bytes = (unsigned char *)test_slurp(files[k], &len);
        CHECK(bytes != NULL);
        io_image a, b;
        CHECK_OK(io_image_read(ctx, files[k], &a), ctx);
        CHECK_OK(io_image_read_memory(ctx, names[k], bytes, len, &b), ctx);
        CHECK_MSG(same_image(&a, &b), "%s: memory and file reads differ", names[k]);
        if (k == 0) {
            const io_attr *t = io_image_find_attr(&b, "obscura:text");
            CHECK(t && t->type == IO_ATTR_STRING && strcmp(t->s, "memory test") == 0);
            const io_attr *n = io_image_find_attr(&b, "obscura:count");
            CHECK(n && n->type == IO_ATTR_INT && n->i == 42);
            const io_attr *mm = io_image_find_attr(&b, "worldToCamera");
            CHECK(mm && mm->type == IO_ATTR_MATRIX44 && mm->v[13] == 13.0f);
            int pc = io_image_find_channel(&b, "primid");
            CHECK(pc >= 0 && b.types[pc] == IO_PIXEL_UINT && obs_image_u32_row(&b.u32[pc], 4)[6] == 600004u);
            /* EXR and PNG bytes are recognised by their magic numbers, whatever the name says */
            io_image c;
            CHECK_OK(io_image_read_memory(ctx, "no-extension", bytes, len, &c), ctx);
            CHECK(same_image(&a, &c));
            io_image_free(&c);
        }
        io_image_free(&a);
        io_image_free(&b);
        free(bytes);
    }
    obs_context_destroy(ctx);
}

TEST(image_memory_broken_input_gives_the_file_statuses)
{
    obs_context *ctx = quiet_ctx();
    const char *exr = test_path(test_tmpdir(), "sample.exr");
    const char *png = test_path(test_tmpdir(), "sample.png");
    CHECK_MSG(write_samples(ctx, exr, png), "%s", obs_context_last_error(ctx));
    size_t len = 0;
    unsigned char *bytes = (unsigned char *)test_slurp(exr, &len);
    CHECK(bytes != NULL && len > 64);
    io_image im;
    /* garbage, no bytes, NULL arguments */
    const char garbage[] = "this is not an image at all, just text that goes on for a while";
    CHECK_EQ_INT(io_image_read_memory(ctx, "garbage.exr", garbage, sizeof garbage, &im), OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "garbage.exr") != NULL);
    CHECK(im.channel_count == 0 && im.f32 == NULL);
    CHECK_EQ_INT(io_image_read_memory(ctx, "empty.exr", bytes, 0, &im), OBS_STATUS_PARSE_ERROR);
    CHECK_EQ_INT(io_image_read_memory(ctx, "null.exr", NULL, 10, &im), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(io_image_read_memory(ctx, "null.exr", bytes, len, NULL), OBS_STATUS_INVALID_ARGUMENT);
    /* truncated EXRs fail cleanly (status, empty image), whatever OpenEXR reports */
    for (size_t n = 1; n < len; n += n < 64 ? 7 : 61) {
        obs_context_clear_error(ctx);
        obs_status st = io_image_read_memory(ctx, "cut.exr", bytes, n, &im);
        CHECK_MSG(st != OBS_STATUS_OK, "a prefix of %zu of %zu bytes read OK", n, len);
        CHECK(im.channel_count == 0 && im.f32 == NULL && im.u32 == NULL && im.attrs == NULL);
    }
    /* limits are checked before decoding */
    obs_limits lim = obs_limits_default();
    lim.max_image_pixels = 20;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_image_read_memory(ctx, "big.exr", bytes, len, &im), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-pixels") != NULL);
    free(bytes);
    obs_context_destroy(ctx);
}
