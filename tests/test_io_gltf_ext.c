/* test_io_gltf_ext.c: glTF as users have it: files written by gltfpack and gltf-pipeline
 * (KHR_mesh_quantization, EXT_meshopt_compression, KHR_draco_mesh_compression; tests/data/gltf),
 * versions other than 2.x, unsupported required extensions, and scenes with nothing to draw. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *gdata(const char *name)
{
    static char b[4][4096];
    static int n;
    char *p = b[n++ & 3];
    snprintf(p, sizeof b[0], "%s/tests/data/gltf/%s", test_source_dir(), name);
    return p;
}

static int exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0;
}

/* Render path's G-buffer through the command (camera 'default', 160x120); 0 on success. */
static int render(const char *path, const char *tag)
{
    char out[4200], err[4200];
    snprintf(out, sizeof out, "%s/%s.exr", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    const char *a[] = {"gbuffer", path, "-o", out, "--size", "160x120", NULL};
    return test_spawn(OBS_CLI_PATH, a, NULL, err);
}

typedef struct zstats {
    long covered_ref, coverage_mismatch, both, over_tol;
    double max_err_within; /* the largest |dZ| among pixels within the tolerance */
    int identical;         /* Z planes bit-identical */
} zstats;

/* Compare the Z channels of <a>.exr and <b>.exr (tags in the test directory). */
static int compare_z(const char *a, const char *b, double tol, zstats *s)
{
    obs_context *ctx = obs_context_create();
    io_image ia, ib;
    char pa[4200], pb[4200];
    snprintf(pa, sizeof pa, "%s/%s.exr", test_tmpdir(), a);
    snprintf(pb, sizeof pb, "%s/%s.exr", test_tmpdir(), b);
    memset(s, 0, sizeof *s);
    int ok = io_image_read(ctx, pa, &ia) == OBS_STATUS_OK;
    if (ok && io_image_read(ctx, pb, &ib) != OBS_STATUS_OK) {
        io_image_free(&ia);
        ok = 0;
    }
    if (!ok) {
        obs_context_destroy(ctx);
        return 0;
    }
    int za = io_image_find_channel(&ia, "Z"), zb = io_image_find_channel(&ib, "Z");
    ok = za >= 0 && zb >= 0 && ia.width == ib.width && ia.height == ib.height;
    s->identical = ok;
    for (int y = 0; ok && y < ia.height; y++)
        for (int x = 0; x < ia.width; x++) {
            float u = obs_image_f32_row(&ia.f32[za], y)[x], v = obs_image_f32_row(&ib.f32[zb], y)[x];
            if (memcmp(&u, &v, sizeof u) != 0)
                s->identical = 0;
            s->covered_ref += isfinite(u);
            if (isfinite(u) != isfinite(v)) {
                s->coverage_mismatch++;
                continue;
            }
            if (!isfinite(u))
                continue;
            s->both++;
            double e = fabs((double)u - (double)v);
            if (e > tol)
                s->over_tol++;
            else if (e > s->max_err_within)
                s->max_err_within = e;
        }
    io_image_free(&ia);
    io_image_free(&ib);
    obs_context_destroy(ctx);
    return ok;
}

TEST(gltf_compressed_and_quantized_files_give_the_source_gbuffer)
{
    CHECK_EQ_INT(render(gdata("source.glb"), "source"), 0);
    /* tol: |dZ| allowed at a pixel that sees the same surface in both renders, from the
     * quantization step over the scene's 2 m extent: gltfpack's 14-bit positions (1.2e-4 m) and
     * Draco's default 11 bits (9.8e-4 m), each with a factor for the slope of the surface as seen
     * from the camera. silhouette: the share of pixels allowed to see another surface (or none)
     * because an edge moved by up to one quantization step. */
    struct {
        const char *file;
        double tol, silhouette;
    } cases[] = {
        {"separate.gltf", 0.0, 0.0},        /* the same floats: bit-identical */
        {"meshopt_float.glb", 1e-5, 0.002}, /* lossless, but gltfpack merges the meshes (float rounding of the baked transform) */
        {"quantized.glb", 1e-3, 0.005},
        {"meshopt.glb", 1e-3, 0.005},
        {"meshopt_filters.glb", 1e-3, 0.005},
        {"draco.glb", 5e-3, 0.005},
        {"draco_embedded.gltf", 5e-3, 0.005},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char tag[64];
        snprintf(tag, sizeof tag, "t%zu", k);
        int rc = render(gdata(cases[k].file), tag);
        CHECK_MSG(rc == 0, "%s: exit %d", cases[k].file, rc);
        zstats s;
        CHECK(compare_z("source", tag, cases[k].tol, &s));
        printf("%-22s covered %ld, coverage mismatch %ld, |dZ| > %g at %ld of %ld, max |dZ| within %.3g%s\n",
               cases[k].file, s.covered_ref, s.coverage_mismatch, cases[k].tol, s.over_tol, s.both,
               s.max_err_within, s.identical ? ", bit-identical" : "");
        CHECK(s.covered_ref > 5000);
        if (cases[k].tol == 0.0) {
            CHECK_MSG(s.identical, "%s: Z differs from the source", cases[k].file);
            continue;
        }
        CHECK_MSG(s.coverage_mismatch + s.over_tol <= (long)(cases[k].silhouette * s.covered_ref),
                  "%s: %ld + %ld pixels differ, over %.1f%% of %ld", cases[k].file, s.coverage_mismatch, s.over_tol,
                  100 * cases[k].silhouette, s.covered_ref);
    }
    /* meshopt is lossless over the quantized data, and its filter changes only the normals */
    zstats s;
    CHECK(compare_z("t2", "t3", 0.0, &s));
    CHECK_MSG(s.identical, "meshopt.glb's Z differs from quantized.glb's");
    CHECK(compare_z("t2", "t4", 0.0, &s));
    CHECK_MSG(s.identical, "meshopt_filters.glb's Z differs from quantized.glb's");
}

TEST(gltf_quantized_and_compressed_scene_bounds_match_the_source_within_the_step)
{
    /* the world-space bounds (mesh positions through the node transforms, where gltfpack puts the
     * dequantization) agree with the source's within the quantization step */
    const char *files[] = {"quantized.glb", "meshopt.glb", "meshopt_filters.glb", "meshopt_float.glb", "draco.glb",
                           "draco_embedded.gltf", "separate.gltf"};
    const double step[] = {2.0 / 16383, 2.0 / 16383, 2.0 / 16383, 1e-6, 2.0 / 2047, 2.0 / 2047, 0.0};
    obs_context *ctx = obs_context_create();
    io_gltf_options opt = io_gltf_options_default();
    obs_scene ref;
    CHECK_OK(io_gltf_load(ctx, gdata("source.glb"), &opt, &ref), ctx);
    for (int k = 0; k < 7; k++) {
        obs_scene s;
        CHECK_OK(io_gltf_load(ctx, gdata(files[k]), &opt, &s), ctx);
        uint64_t tris = 0, ref_tris = 0;
        for (uint32_t i = 0; i < s.instance_count; i++)
            tris += s.meshes[s.instances[i].mesh].triangle_count;
        for (uint32_t i = 0; i < ref.instance_count; i++)
            ref_tris += ref.meshes[ref.instances[i].mesh].triangle_count;
        CHECK_MSG(tris == ref_tris, "%s: %llu triangles drawn, the source %llu", files[k], (unsigned long long)tris,
                  (unsigned long long)ref_tris);
        CHECK_NEAR(s.bounds.lo.x, ref.bounds.lo.x, step[k]);
        CHECK_NEAR(s.bounds.lo.y, ref.bounds.lo.y, step[k]);
        CHECK_NEAR(s.bounds.lo.z, ref.bounds.lo.z, step[k]);
        CHECK_NEAR(s.bounds.hi.x, ref.bounds.hi.x, step[k]);
        CHECK_NEAR(s.bounds.hi.y, ref.bounds.hi.y, step[k]);
        CHECK_NEAR(s.bounds.hi.z, ref.bounds.hi.z, step[k]);
        CHECK(s.camera_count == 1);
        obs_scene_free(&s);
    }
    obs_scene_free(&ref);
    obs_context_destroy(ctx);
}

/* ---- glTF documents in memory ---------------------------------------------------------------- */

/* A triangle as base64 of 3 positions (36 bytes of floats): (0,0,0) (1,0,0) (0,1,0) */
static const char *tri_json(const char *asset, const char *extra)
{
    static char buf[4096];
    snprintf(buf, sizeof buf,
             "{\"asset\":%s,%s\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
             "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             asset, extra);
    return buf;
}

static obs_status load_text(obs_context *ctx, const char *name, const char *json, obs_scene *s)
{
    io_gltf_options opt = io_gltf_options_default();
    obs_context_clear_error(ctx);
    return io_gltf_load_memory(ctx, name, json, strlen(json), &opt, s);
}

static int msg_has(obs_context *ctx, const char *a, const char *b)
{
    const char *m = obs_context_last_error(ctx);
    int ok = strstr(m, a) != NULL && (!b || strstr(m, b) != NULL);
    if (!ok)
        fprintf(stderr, "message: %s\n", m);
    return ok;
}

TEST(gltf_version_other_than_2_is_refused_naming_file_and_version)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    /* the version that loaded as an empty scene with exit 0 */
    CHECK_EQ_INT(load_text(ctx, "old.gltf", tri_json("{\"version\":\"1.0\"}", ""), &s), OBS_STATUS_UNSUPPORTED);
    CHECK(msg_has(ctx, "old.gltf", "version 1.0"));
    CHECK(s.mesh_count == 0 && s.instance_count == 0);
    CHECK_EQ_INT(load_text(ctx, "three.gltf", tri_json("{\"version\":\"3.0\"}", ""), &s), OBS_STATUS_UNSUPPORTED);
    CHECK(msg_has(ctx, "three.gltf", "3.0"));
    /* minVersion above what we read */
    CHECK_EQ_INT(load_text(ctx, "min.gltf", tri_json("{\"version\":\"2.1\",\"minVersion\":\"2.1\"}", ""), &s),
                 OBS_STATUS_UNSUPPORTED);
    CHECK(msg_has(ctx, "min.gltf", "minVersion 2.1"));
    /* malformed or missing */
    CHECK_EQ_INT(load_text(ctx, "bad.gltf", tri_json("{\"version\":\"two\"}", ""), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "bad.gltf", "'two'"));
    CHECK_EQ_INT(load_text(ctx, "none.gltf", tri_json("{\"generator\":\"x\"}", ""), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "none.gltf", "asset.version"));
    /* a later 2.x without a minVersion, and minVersion 2.0, load (a 2.0 loader reads them) */
    CHECK_OK(load_text(ctx, "later.gltf", tri_json("{\"version\":\"2.1\"}", ""), &s), ctx);
    CHECK(s.mesh_count == 1);
    obs_scene_free(&s);
    CHECK_OK(load_text(ctx, "min20.gltf", tri_json("{\"version\":\"2.0\",\"minVersion\":\"2.0\"}", ""), &s), ctx);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(gltf_unsupported_required_extension_is_named_before_tinygltf_checks)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    const char *v2 = "{\"version\":\"2.0\"}";
    CHECK_EQ_INT(load_text(ctx, "ext.gltf", tri_json(v2, "\"extensionsRequired\":[\"EXT_frobnicate\"],"), &s),
                 OBS_STATUS_UNSUPPORTED);
    CHECK(msg_has(ctx, "ext.gltf", "EXT_frobnicate"));
    /* a file tinygltf would refuse for its buffers: the extension is still what is named */
    char broken[4096];
    snprintf(broken, sizeof broken, "%s", tri_json(v2, "\"extensionsRequired\":[\"KHR_gaussian_splatting\"],"));
    char *bl = strstr(broken, "\"byteLength\":36,\"uri\"");
    CHECK(bl != NULL);
    memcpy(bl, "\"byteLength\":99", 15);
    CHECK_EQ_INT(load_text(ctx, "ext2.gltf", broken, &s), OBS_STATUS_UNSUPPORTED);
    CHECK(msg_has(ctx, "ext2.gltf", "KHR_gaussian_splatting"));
    /* the supported ones load (quantization declared over float data is legal) */
    CHECK_OK(load_text(ctx, "q.gltf",
                       tri_json(v2, "\"extensionsUsed\":[\"KHR_mesh_quantization\",\"KHR_lights_punctual\"],"
                                    "\"extensionsRequired\":[\"KHR_mesh_quantization\"],"),
                       &s),
             ctx);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* one triangle with POSITION and NORMAL of the given accessor types, from a 24-byte buffer:
 * bytes 0..11 positions (3 x 4-byte-aligned elements), 12..23 normals */
static const char *quant_json(const char *ext, int pos_ct, int pos_norm, int nrm_ct, int nrm_norm, int pos_count)
{
    static char buf[4096];
    /* base64 of: 7f 80 00 00 | ff 00 7f 00 | 00 7f 81 00 | 7f 00 00 00 | 00 81 00 00 | 00 00 7f 00 */
    snprintf(buf, sizeof buf,
             "{\"asset\":{\"version\":\"2.0\"},%s\"buffers\":[{\"byteLength\":24,\"uri\":"
             "\"data:application/octet-stream;base64,f4AAAP8AfwAAf4EAfwAAAACBAAAAAH8A\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":12,\"byteStride\":4},"
             "{\"buffer\":0,\"byteOffset\":12,\"byteLength\":12,\"byteStride\":4}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":%d,\"normalized\":%s,\"count\":%d,\"type\":\"VEC3\"},"
             "{\"bufferView\":1,\"componentType\":%d,\"normalized\":%s,\"count\":3,\"type\":\"VEC3\"}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1}}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             ext, pos_ct, pos_norm ? "true" : "false", pos_count, nrm_ct, nrm_norm ? "true" : "false");
    return buf;
}

TEST(gltf_quantized_attributes_dequantize_per_spec_and_are_range_checked)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    const char *q = "\"extensionsUsed\":[\"KHR_mesh_quantization\"],\"extensionsRequired\":[\"KHR_mesh_quantization\"],";
    /* normalized BYTE positions: max(c / 127, -1), so -128 and -127 both give -1 */
    CHECK_OK(load_text(ctx, "b.gltf", quant_json(q, 5120, 1, 5120, 1, 3), &s), ctx);
    CHECK(s.mesh_count == 1 && s.meshes[0].normals != NULL);
    const float *p = s.meshes[0].positions, *n = s.meshes[0].normals;
    CHECK(p[0] == 1.0f && p[1] == -1.0f && p[2] == 0.0f);           /* 7f 80 00 */
    CHECK(p[3] == -1.0f / 127.0f && p[4] == 0.0f && p[5] == 1.0f);  /* ff 00 7f */
    CHECK(p[6] == 0.0f && p[7] == 1.0f && p[8] == -1.0f);           /* 00 7f 81 */
    CHECK(n[0] == 1.0f && n[1] == 0.0f && n[2] == 0.0f);
    CHECK(n[3] == 0.0f && n[4] == -1.0f && n[5] == 0.0f);
    obs_scene_free(&s);
    /* UNSIGNED_BYTE positions, not normalized: the integer values; normalized: c / 255 */
    CHECK_OK(load_text(ctx, "ub.gltf", quant_json(q, 5121, 0, 5120, 1, 3), &s), ctx);
    p = s.meshes[0].positions;
    CHECK(p[0] == 127.0f && p[1] == 128.0f && p[3] == 255.0f);
    obs_scene_free(&s);
    CHECK_OK(load_text(ctx, "ubn.gltf", quant_json(q, 5121, 1, 5120, 1, 3), &s), ctx);
    p = s.meshes[0].positions;
    CHECK(p[0] == 127.0f / 255.0f && p[3] == 1.0f);
    obs_scene_free(&s);
    /* without the extension declared: refused naming it */
    CHECK_EQ_INT(load_text(ctx, "noext.gltf", quant_json("", 5120, 1, 5120, 1, 3), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "noext.gltf", "KHR_mesh_quantization"));
    /* NORMAL as UNSIGNED_BYTE (not allowed by the extension), and BYTE not normalized */
    CHECK_EQ_INT(load_text(ctx, "n1.gltf", quant_json(q, 5120, 1, 5121, 1, 3), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "n1.gltf", "NORMAL"));
    CHECK_EQ_INT(load_text(ctx, "n2.gltf", quant_json(q, 5120, 1, 5120, 0, 3), &s), OBS_STATUS_PARSE_ERROR);
    /* an INT position is not a quantized type */
    CHECK_EQ_INT(load_text(ctx, "i.gltf", quant_json(q, 5125, 0, 5120, 1, 3), &s), OBS_STATUS_PARSE_ERROR);
    /* the range check uses the quantized element size: 4 elements do not fit 12 bytes at stride 4 */
    CHECK_EQ_INT(load_text(ctx, "r.gltf", quant_json(q, 5120, 1, 5120, 1, 4), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "r.gltf", "byteLength 12"));
    /* SHORT positions need 6 bytes per element: 3 of them at stride 4 overrun the 12-byte view */
    CHECK_EQ_INT(load_text(ctx, "s.gltf", quant_json(q, 5122, 1, 5120, 1, 3), &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "s.gltf", "byteStride 4 < element size 6"));
    obs_context_destroy(ctx);
}

/* ---- damaged compressed files ---------------------------------------------------------------- */

static uint32_t rd32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static void wr32(unsigned char *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(v >> (8 * k));
}

/* A GLB whose JSON chunk has `from` replaced by `to` (first occurrence); malloc'd; NULL if absent. */
static unsigned char *glb_edit(const unsigned char *g, size_t n, const char *from, const char *to, size_t *out_len)
{
    uint32_t jl = rd32(g + 12);
    char *js = malloc(jl + 1);
    memcpy(js, g + 20, jl);
    js[jl] = 0;
    char *at = strstr(js, from);
    if (!at) {
        free(js);
        return NULL;
    }
    size_t nj = jl - strlen(from) + strlen(to);
    size_t pad = (4 - nj % 4) % 4, rest = n - 20 - jl;
    unsigned char *o = malloc(20 + nj + pad + rest);
    size_t pre = (size_t)(at - js);
    memcpy(o, g, 20);
    memcpy(o + 20, js, pre);
    memcpy(o + 20 + pre, to, strlen(to));
    memcpy(o + 20 + pre + strlen(to), at + strlen(from), jl - pre - strlen(from));
    memset(o + 20 + nj, ' ', pad);
    memcpy(o + 20 + nj + pad, g + 20 + jl, rest);
    wr32(o + 8, (uint32_t)(20 + nj + pad + rest));
    wr32(o + 12, (uint32_t)(nj + pad));
    *out_len = 20 + nj + pad + rest;
    free(js);
    return o;
}

TEST(gltf_damaged_meshopt_and_draco_data_is_refused_naming_the_extension)
{
    obs_context *ctx = obs_context_create();
    io_gltf_options opt = io_gltf_options_default();
    obs_scene s;
    size_t n = 0, m = 0;
    unsigned char *g = (unsigned char *)test_slurp(gdata("meshopt.glb"), &n);
    CHECK(g != NULL);
    const size_t bin = 20 + rd32(g + 12) + 8; /* the BIN chunk's data */
    /* a corrupt vertex codec header */
    g[bin] ^= 0x5A;
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "m.glb", g, n, &opt, &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "m.glb", "EXT_meshopt_compression"));
    g[bin] ^= 0x5A;
    CHECK_OK(io_gltf_load_memory(ctx, "m.glb", g, n, &opt, &s), ctx);
    obs_scene_free(&s);
    /* a count whose decoded size is over the declared bufferView: refused before decoding */
    unsigned char *e = glb_edit(g, n, "\"count\":227}", "\"count\":99999}", &m);
    CHECK(e != NULL);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "count.glb", e, m, &opt, &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "count.glb", "byteLength"));
    free(e);
    /* an absurd fallback buffer (4 GB - 1) is refused by the memory limit before it is allocated */
    e = glb_edit(g, n, "{\"byteLength\":5220", "{\"byteLength\":4294967295", &m);
    CHECK(e != NULL);
    obs_context_clear_error(ctx);
    obs_limits lim = *obs_context_limits(ctx);
    lim.max_memory_bytes = 1 << 20;
    obs_context_set_limits(ctx, &lim);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "huge.glb", e, m, &opt, &s), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(msg_has(ctx, "huge.glb", "--max-memory"));
    free(e);
    /* a byteStride the decoder does not take (it asserts on it) */
    e = glb_edit(g, n, "\"byteStride\":4,\"mode\"", "\"byteStride\":3,\"mode\"", &m);
    CHECK(e != NULL);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "stride.glb", e, m, &opt, &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "stride.glb", "byteStride 3"));
    free(e);
    free(g);

    g = (unsigned char *)test_slurp(gdata("draco.glb"), &n);
    CHECK(g != NULL);
    const size_t dbin = 20 + rd32(g + 12) + 8;
    for (size_t k = 0; k < 40; k++) /* the Draco header and the start of the first mesh */
        g[dbin + k] ^= 0xFF;
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(io_gltf_load_memory(ctx, "d.glb", g, n, &opt, &s), OBS_STATUS_PARSE_ERROR);
    CHECK(msg_has(ctx, "d.glb", "KHR_draco_mesh_compression"));
    free(g);

    /* any byte of either file's BIN chunk flipped: a scene or an error, never a crash (run
     * under OBS_SANITIZE for the memory checks) */
    const char *files[] = {"meshopt.glb", "meshopt_filters.glb", "draco.glb"};
    uint32_t rng = 12345;
    for (int f = 0; f < 3; f++) {
        g = (unsigned char *)test_slurp(gdata(files[f]), &n);
        CHECK(g != NULL);
        const size_t b0 = 20 + rd32(g + 12) + 8;
        for (int it = 0; it < 300; it++) {
            rng = rng * 1664525u + 1013904223u;
            size_t at = b0 + (rng >> 8) % (n - b0);
            unsigned char old = g[at];
            g[at] ^= (unsigned char)(1u + (rng & 0xFE));
            obs_status st = io_gltf_load_memory(ctx, files[f], g, n, &opt, &s);
            if (st == OBS_STATUS_OK)
                obs_scene_free(&s);
            g[at] = old;
        }
        free(g);
    }
    obs_context_destroy(ctx);
}

/* ---- nothing to draw ----------------------------------------------------------------------- */

TEST(cli_scene_without_triangles_is_an_input_error_for_gbuffer_ao_and_truth)
{
    /* a valid glTF whose scene draws nothing (a mesh no node uses), and one with no meshes */
    const char *empty_path = test_path(test_tmpdir(), "empty.gltf");
    FILE *f = fopen(empty_path, "w");
    CHECK(f != NULL);
    fputs("{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"name\":\"cam\",\"camera\":0}],"
          "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"znear\":0.1}}],"
          "\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
          f);
    fclose(f);
    const char *unused_path = test_path(test_tmpdir(), "unused.gltf");
    f = fopen(unused_path, "w");
    CHECK(f != NULL);
    fputs(tri_json("{\"version\":\"2.0\"}", ""), f);
    fclose(f);
    /* the same file with the node list emptied: its mesh is drawn by no node */
    char *t = test_slurp(unused_path, NULL);
    char *sc = strstr(t, "\"scenes\":[{\"nodes\":[0]}]");
    CHECK(sc != NULL);
    memcpy(sc, "\"scenes\":[{\"nodes\":[ ]}]", strlen("\"scenes\":[{\"nodes\":[ ]}]"));
    f = fopen(unused_path, "w");
    fputs(t, f);
    fclose(f);
    free(t);
    const char *scenes[] = {empty_path, unused_path};
    for (int k = 0; k < 2; k++) {
        char o1[4200], o2[4200], o3[4200], err[4200];
        snprintf(o1, sizeof o1, "%s/g%d", test_tmpdir(), k);
        snprintf(o2, sizeof o2, "%s/a%d", test_tmpdir(), k);
        snprintf(o3, sizeof o3, "%s/t%d", test_tmpdir(), k);
        snprintf(err, sizeof err, "%s/err%d.txt", test_tmpdir(), k);
        const char *g[] = {"gbuffer", scenes[k], "-o", o1, "--size", "16x16", NULL};
        const char *a[] = {"ao", "--method", "sao", "--scene", scenes[k], "-o", o2, "--size", "16x16", NULL};
        const char *tr[] = {"truth", "ao", scenes[k], "-o", o3, "--size", "16x16", NULL};
        const char *const *cmds[] = {g, a, tr};
        const char *outs[] = {o1, o2, o3};
        for (int c = 0; c < 3; c++) {
            int rc = test_spawn(OBS_CLI_PATH, cmds[c], NULL, err);
            CHECK_MSG(rc == 3, "%s on %s: exit %d", cmds[c][0], scenes[k], rc);
            char *e = test_slurp(err, NULL);
            CHECK_MSG(e && strstr(e, scenes[k]) && strstr(e, "no triangles"), "%s", e ? e : "");
            free(e);
            char p[4300];
            snprintf(p, sizeof p, "%s.exr", outs[c]);
            CHECK_MSG(!exists(p), "%s written", p);
        }
    }
    /* info still describes such a scene */
    const char *i[] = {"info", empty_path, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, i, NULL, NULL), 0);
}
