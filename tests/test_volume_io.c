/* test_volume_io.c: volumes (vol.h sections 1 and 2) and their loaders (io.h, "Volumes"): grid
 * limits, trilinear sampling, transfer functions (JSON, presets, evaluation, opacity correction),
 * synthetic volumes, NIfTI / NRRD / raw round trips and refusals, the real datasets when fetched. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"
#include "volume/vol.h"

#include <stdlib.h>
#include <string.h>

/* ---- helpers ---------------------------------------------------------------------------------- */

static int msg_has(obs_context *ctx, const char *needle)
{
    return strstr(obs_context_last_error(ctx), needle) != NULL;
}

/* ---- grids ------------------------------------------------------------------------------------ */

TEST(volume_grid_alloc_refuses_absurd_sizes_before_allocating)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {1, 1, 1};
    /* 10^15 voxels: an attempt to allocate would fail or take the machine down; the refusal
     * must come from the limit check. */
    CHECK_EQ_INT(vol_grid_alloc(ctx, 100000, 100000, 100000, sp, &g), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(msg_has(ctx, "--max-voxels"));
    CHECK(g.data == NULL);
    /* The largest int on every side overflows size_t arithmetic on the way: still a clean refusal. */
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(vol_grid_alloc(ctx, 2147483647, 2147483647, 2147483647, sp, &g), OBS_STATUS_LIMIT_EXCEEDED);
    /* Within max_voxels but over max_memory_bytes. */
    obs_limits lim = *obs_context_limits(ctx);
    lim.max_memory_bytes = 4 * 1000 - 1;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK_EQ_INT(vol_grid_alloc(ctx, 10, 10, 10, sp, &g), OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(msg_has(ctx, "--max-memory"));
    lim.max_memory_bytes = 4 * 1000;
    lim.max_voxels = 999;
    obs_context_set_limits(ctx, &lim);
    CHECK_EQ_INT(vol_grid_alloc(ctx, 10, 10, 10, sp, &g), OBS_STATUS_LIMIT_EXCEEDED);
    lim.max_voxels = 1000;
    obs_context_set_limits(ctx, &lim);
    CHECK_OK(vol_grid_alloc(ctx, 10, 10, 10, sp, &g), ctx);
    for (int i = 0; i < 1000; i++)
        CHECK(g.data[i] == 0.0f);
    vol_grid_free(&g);
    CHECK(g.data == NULL);
    vol_grid_free(NULL);
    obs_context_destroy(ctx);
}

TEST(volume_grid_alloc_refuses_bad_sides_and_spacing)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double ok[3] = {1, 2, 3};
    CHECK_EQ_INT(vol_grid_alloc(ctx, 0, 4, 4, ok, &g), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(vol_grid_alloc(ctx, 4, -1, 4, ok, &g), OBS_STATUS_INVALID_ARGUMENT);
    const double bad[][3] = {{0, 1, 1}, {1, -1, 1}, {1, 1, NAN}, {1, INFINITY, 1}};
    for (int i = 0; i < 4; i++) {
        obs_context_clear_error(ctx);
        CHECK_EQ_INT(vol_grid_alloc(ctx, 4, 4, 4, bad[i], &g), OBS_STATUS_INVALID_ARGUMENT);
        CHECK(msg_has(ctx, "spacing"));
    }
    obs_context_destroy(ctx);
}

TEST(volume_grid_sample_is_exact_at_centres_and_linear_between)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    const double sp[3] = {0.5, 1.0, 2.0};
    CHECK_OK(vol_grid_alloc(ctx, 5, 4, 3, sp, &g), ctx);
    /* Arbitrary values at the centres. */
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 5; i++)
                g.data[(k * 4 + j) * 5 + i] = (float)((i * 7 + j * 13 + k * 29) % 17) - 3.25f;
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 5; i++)
                CHECK(vol_grid_sample(&g, i, j, k) == g.data[(k * 4 + j) * 5 + i]);
    /* Along each axis between two centres the sample is the lerp. */
    for (int s = 0; s <= 8; s++) {
        double t = s / 8.0;
        float a = g.data[(1 * 4 + 2) * 5 + 1], b = g.data[(1 * 4 + 2) * 5 + 2];
        CHECK_NEAR(vol_grid_sample(&g, 1 + t, 2, 1), a + (b - a) * t, 1e-5);
        a = g.data[(1 * 4 + 0) * 5 + 3], b = g.data[(1 * 4 + 1) * 5 + 3];
        CHECK_NEAR(vol_grid_sample(&g, 3, 0 + t, 1), a + (b - a) * t, 1e-5);
        a = g.data[(0 * 4 + 3) * 5 + 4], b = g.data[(1 * 4 + 3) * 5 + 4];
        CHECK_NEAR(vol_grid_sample(&g, 4, 3, 0 + t), a + (b - a) * t, 1e-5);
    }
    /* A field linear in (i, j, k) is reproduced exactly (up to rounding) anywhere inside. */
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 5; i++)
                g.data[(k * 4 + j) * 5 + i] = (float)(0.5 * i - 1.25 * j + 2.0 * k + 1.0);
    for (int s = 0; s < 50; s++) {
        double x = 4.0 * ((s * 37) % 50) / 49.0, y = 3.0 * ((s * 11) % 50) / 49.0, z = 2.0 * s / 49.0;
        CHECK_NEAR(vol_grid_sample(&g, x, y, z), 0.5 * x - 1.25 * y + 2.0 * z + 1.0, 1e-5);
    }
    /* Clamped beyond the edge. */
    CHECK(vol_grid_sample(&g, -3, -1, -7) == g.data[0]);
    CHECK(vol_grid_sample(&g, 10, 10, 10) == g.data[59]);
    /* Range and bounds. */
    vol_grid_update_range(&g);
    CHECK_NEAR(g.value_min, 1.0 - 3.75, 1e-6);
    CHECK_NEAR(g.value_max, 2.0 + 4.0 + 1.0, 1e-6);
    double lo[3], hi[3];
    g.origin[0] = 10.0;
    vol_grid_bounds(&g, lo, hi);
    CHECK_NEAR(lo[0], 9.75, 1e-12);
    CHECK_NEAR(hi[0], 10.0 + 4.5 * 0.5, 1e-12);
    CHECK_NEAR(lo[2], -1.0, 1e-12);
    CHECK_NEAR(hi[2], 5.0, 1e-12);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_type_names_round_trip)
{
    for (int t = 0; t < VOL_TYPE_COUNT; t++) {
        vol_type back;
        CHECK(vol_type_from_name(vol_type_name((vol_type)t), &back));
        CHECK_EQ_INT(back, t);
    }
    vol_type t;
    CHECK(vol_type_from_name("uint8", &t) && t == VOL_TYPE_U8);
    CHECK(vol_type_from_name("int16", &t) && t == VOL_TYPE_I16);
    CHECK(vol_type_from_name("FLOAT", &t) && t == VOL_TYPE_F32);
    CHECK(!vol_type_from_name("f64", &t));
}

/* ---- transfer functions ------------------------------------------------------------------------ */

TEST(volume_tf_json_parses_the_documented_form)
{
    obs_context *ctx = obs_context_create();
    vol_tf tf;
    const char *text = "{\"name\": \"t\", \"ref_step\": 0.5, \"description\": \"x\",\n"
                       " \"points\": [[-10, 0, 0, 0, 0], [0, 1, 0.5, 0.25, 0.5], [20, 1, 1, 1, 1]]}";
    CHECK_OK(vol_tf_parse_json(ctx, text, "t.json", &tf), ctx);
    CHECK(strcmp(tf.name, "t") == 0);
    CHECK_EQ_INT(tf.count, 3);
    CHECK(tf.ref_step == 0.5);
    CHECK(tf.points[1].value == 0.0 && tf.points[1].rgba[2] == 0.25f);
    vol_tf_free(&tf);
    /* ref_step may be omitted (0: one voxel of the smallest spacing); a single point is enough. */
    CHECK_OK(vol_tf_parse_json(ctx, "{\"points\": [[3, 0.1, 0.2, 0.3, 0.4]]}", "one.json", &tf), ctx);
    CHECK(tf.ref_step == 0.0 && tf.count == 1);
    float c[4];
    vol_tf_eval(&tf, -1e30, c);
    CHECK(c[3] == 0.4f);
    vol_tf_eval(&tf, 1e30, c);
    CHECK(c[0] == 0.1f);
    vol_tf_free(&tf);
    vol_tf_free(NULL);
    obs_context_destroy(ctx);
}

TEST(volume_tf_json_refuses_bad_files_naming_them)
{
    static const char *const bad[] = {
        "{\"points\": [[0, 0, 0, 0, 0], [0, 1, 1, 1, 1]]}",            /* not strictly increasing */
        "{\"points\": [[1, 0, 0, 0, 0], [0, 1, 1, 1, 1]]}",            /* unsorted */
        "{\"points\": [[0, 0, 0, 0, 1.5]]}",                           /* alpha > 1 */
        "{\"points\": [[0, -0.1, 0, 0, 1]]}",                          /* r < 0 */
        "{\"points\": [[1e999, 0, 0, 0, 1]]}",                         /* value overflows to inf */
        "{\"points\": [[0, 0, 0, 0, 1e999]]}",                         /* inf component */
        "{\"points\": [[0, 0, 0, \"x\", 1]]}",                         /* not a number */
        "{\"points\": [[0, 0, 0, 1]]}",                                /* four components */
        "{\"points\": []}",                                            /* empty */
        "{\"name\": \"a\"}",                                           /* no points */
        "{\"points\": [[0, 0, 0, 0, 1]], \"colour\": 1}",              /* unknown key */
        "{\"points\": [[0, 0, 0, 0, 1]], \"ref_step\": 0}",            /* ref_step 0 given */
        "{\"points\": [[0, 0, 0, 0, 1]], \"ref_step\": -1}",           /* negative */
        "{\"points\": [[0, 0, 0, 0, 1]], \"name\": \"a\", \"name\": \"b\"}", /* duplicate key */
        "[[0, 0, 0, 0, 1]]",                                           /* not an object */
        "{\"points\": [[0, 0, 0, 0, 1]]",                              /* malformed */
        "{\"points\": [[0, 0, 0, 0, 1]]} trailing",                    /* trailing garbage */
    };
    obs_context *ctx = obs_context_create();
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        vol_tf tf;
        obs_context_clear_error(ctx);
        obs_status st = vol_tf_parse_json(ctx, bad[i], "bad-tf.json", &tf);
        CHECK_MSG(st == OBS_STATUS_PARSE_ERROR, "case %zu (%s) gave %s", i, bad[i], obs_status_string(st));
        CHECK_MSG(msg_has(ctx, "bad-tf.json"), "case %zu: message '%s'", i, obs_context_last_error(ctx));
        CHECK(tf.points == NULL && tf.count == 0);
    }
    obs_context_destroy(ctx);
}

TEST(volume_tf_eval_is_piecewise_linear_and_clamped)
{
    obs_context *ctx = obs_context_create();
    vol_tf tf;
    CHECK_OK(vol_tf_parse_json(ctx, "{\"points\": [[0, 0, 0, 0, 0], [10, 1, 0.5, 0, 0.2], [30, 0, 1, 1, 1]]}",
                               "lin.json", &tf),
             ctx);
    float c[4];
    vol_tf_eval(&tf, -5, c);
    CHECK(c[0] == 0 && c[3] == 0);
    vol_tf_eval(&tf, 100, c);
    CHECK(c[1] == 1 && c[3] == 1);
    vol_tf_eval(&tf, 10, c);
    CHECK(c[0] == 1.0f && c[1] == 0.5f && c[3] == 0.2f);
    vol_tf_eval(&tf, 5, c);
    CHECK_NEAR(c[0], 0.5, 1e-7);
    CHECK_NEAR(c[3], 0.1, 1e-7);
    vol_tf_eval(&tf, 25, c);
    CHECK_NEAR(c[0], 0.25, 1e-7);
    CHECK_NEAR(c[1], 0.875, 1e-7);
    CHECK_NEAR(c[3], 0.8, 1e-7);
    vol_tf_eval(&tf, NAN, c);
    CHECK(c[0] == 0 && c[3] == 0);
    vol_tf_free(&tf);
    obs_context_destroy(ctx);
}

TEST(volume_tf_alpha_correction_composes)
{
    /* A step of ref_step gives alpha itself. */
    for (int i = 0; i <= 20; i++) {
        float a = i / 20.0f;
        CHECK(vol_tf_alpha_correct(a, 0.7, 0.7) == a);
    }
    /* Two half steps compose to one full step: 1 - (1 - a_half)^2 = a [Engel06]. */
    for (int i = 1; i < 100; i++) {
        float a = i / 100.0f;
        double h = vol_tf_alpha_correct(a, 0.25, 0.5);
        CHECK_NEAR(1.0 - (1.0 - h) * (1.0 - h), a, 2e-7);
        double q = vol_tf_alpha_correct(a, 1.5, 0.5);
        CHECK_NEAR(q, 1.0 - pow(1.0 - a, 3.0), 2e-7);
        CHECK(h < a && q > a);
    }
    CHECK(vol_tf_alpha_correct(0.0f, 3.0, 1.0) == 0.0f);
    CHECK(vol_tf_alpha_correct(1.0f, 0.01, 1.0) == 1.0f);
    CHECK(vol_tf_alpha_correct(0.5f, 0.0, 1.0) == 0.0f);
}

static char *slurp_source(const char *rel)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", test_source_dir(), rel);
    return test_slurp(path, NULL);
}

TEST(volume_tf_presets_equal_the_data_files)
{
    static const char *const names[] = {"ct-skin", "ct-bone", "mri", "bucky"};
    obs_context *ctx = obs_context_create();
    for (int p = 0; p < 4; p++) {
        char rel[128];
        snprintf(rel, sizeof rel, "data/transfer/%s.json", names[p]);
        char *text = slurp_source(rel);
        CHECK_MSG(text, "cannot read %s", rel);
        vol_tf a, b;
        CHECK_OK(vol_tf_parse_json(ctx, text, rel, &a), ctx);
        free(text);
        CHECK_OK(vol_tf_preset(ctx, names[p], &b), ctx);
        CHECK(strcmp(a.name, b.name) == 0);
        CHECK(a.ref_step == b.ref_step);
        CHECK_EQ_INT(a.count, b.count);
        for (int i = 0; i < a.count; i++) {
            CHECK(a.points[i].value == b.points[i].value);
            CHECK(memcmp(a.points[i].rgba, b.points[i].rgba, sizeof a.points[i].rgba) == 0);
        }
        vol_tf_free(&a);
        vol_tf_free(&b);
    }
    vol_tf t;
    CHECK_EQ_INT(vol_tf_preset(ctx, "ct-lungs", &t), OBS_STATUS_NOT_FOUND);
    CHECK(msg_has(ctx, "ct-bone"));
    obs_context_destroy(ctx);
}

/* ---- synthetic volumes ------------------------------------------------------------------------- */

TEST(volume_synth_is_deterministic_and_bucky_has_60_maxima)
{
    obs_context *ctx = obs_context_create();
    vol_grid a, b;
    CHECK_OK(vol_synth(ctx, "bucky", 0, &a), ctx);
    CHECK_OK(vol_synth(ctx, "bucky", 32, &b), ctx);
    CHECK(a.nx == 32 && a.ny == 32 && a.nz == 32);
    CHECK(memcmp(a.data, b.data, sizeof(float) * 32 * 32 * 32) == 0);
    CHECK(a.value_min >= 0.0f && a.value_max <= 255.0f && a.value_max > 200.0f);
    /* Local maxima over the 26-neighbourhood, above half the peak. */
    int maxima = 0;
    const int n = 32;
    for (int k = 1; k < n - 1; k++)
        for (int j = 1; j < n - 1; j++)
            for (int i = 1; i < n - 1; i++) {
                float v = a.data[(k * n + j) * n + i];
                if (v < 0.5f * a.value_max)
                    continue;
                int is_max = 1;
                for (int dz = -1; dz <= 1 && is_max; dz++)
                    for (int dy = -1; dy <= 1 && is_max; dy++)
                        for (int dx = -1; dx <= 1; dx++)
                            if (dx || dy || dz) {
                                /* A plateau of equal voxels (a blob centred between voxels, as the
                                 * 12 with a zero coordinate are) counts once: at its first voxel. */
                                float w = a.data[((k + dz) * n + j + dy) * n + i + dx];
                                int later = dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)));
                                if (w > v || (w == v && !later)) {
                                    is_max = 0;
                                    break;
                                }
                            }
                maxima += is_max;
            }
    CHECK_EQ_INT(maxima, 60);
    /* Centred on the world origin; symmetric under x -> -x (the polyhedron is). */
    CHECK(a.origin[0] == -15.5);
    for (int q = 0; q < n * n * n; q += 97) {
        int i = q % n, j = (q / n) % n, k = q / (n * n);
        CHECK_NEAR(a.data[q], a.data[(k * n + j) * n + (n - 1 - i)], 1e-3);
    }
    vol_grid_free(&a);
    vol_grid_free(&b);
    obs_context_destroy(ctx);
}

TEST(volume_synth_slab_sphere_box_values)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "slab", 16, &g), ctx);
    for (int k = 0; k < 16; k++)
        for (int q = 0; q < 256; q += 17)
            CHECK(g.data[k * 256 + q] == ((k >= 4 && k < 12) ? 1.0f : 0.0f));
    CHECK(g.value_min == 0.0f && g.value_max == 1.0f);
    vol_grid_free(&g);
    CHECK_OK(vol_synth(ctx, "sphere", 20, &g), ctx);
    CHECK(g.data[(10 * 20 + 10) * 20 + 10] == 1.0f);
    CHECK(g.data[0] == 0.0f);
    /* Voxel (2, 9, 9): r = sqrt(7.5^2 + 0.5) about the centre 9.5; R = 8; value R + 0.5 - r. */
    CHECK_NEAR(g.data[(9 * 20 + 9) * 20 + 2], 8.5 - sqrt(56.75), 1e-6);
    CHECK(g.data[(9 * 20 + 9) * 20 + 1] == 0.0f); /* r = 8.53 */
    vol_grid_free(&g);
    CHECK_OK(vol_synth(ctx, "box", 10, &g), ctx);
    CHECK(g.data[(5 * 10 + 5) * 10 + 1] == 1.0f);
    CHECK(g.data[(5 * 10 + 5) * 10 + 2] == 0.0f);
    CHECK(g.data[(5 * 10 + 8) * 10 + 5] == 1.0f);
    CHECK(g.data[(5 * 10 + 5) * 10 + 5] == 0.0f);
    vol_grid_free(&g);
    CHECK_EQ_INT(vol_synth(ctx, "engine", 32, &g), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(msg_has(ctx, "bucky"));
    CHECK_EQ_INT(vol_synth(ctx, "slab", 2, &g), OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

/* ---- loaders: fixtures written here, independently of the loaders ------------------------------ */

/* Sample q (0..59) of the 5x4x3 fixtures as type t: spans negative values for i16/f32. */
static double fixture_value(vol_type t, int q)
{
    switch (t) {
    case VOL_TYPE_U8: return (q * 37) % 256;
    case VOL_TYPE_U16: return (q * 1117) % 65536;
    case VOL_TYPE_I16: return (q * 1117) % 65536 - 32768;
    default: return (q - 30) * 0.375;
    }
}

static size_t fixture_bytes(vol_type t)
{
    return t == VOL_TYPE_U8 ? 1 : t == VOL_TYPE_F32 ? 4 : 2;
}

/* The 60 samples of a fixture, little endian. */
static void fixture_samples(vol_type t, unsigned char *out)
{
    for (int q = 0; q < 60; q++) {
        double v = fixture_value(t, q);
        unsigned char *p = out + (size_t)q * fixture_bytes(t);
        if (t == VOL_TYPE_U8) {
            p[0] = (unsigned char)v;
        } else if (t == VOL_TYPE_F32) {
            float f = (float)v;
            uint32_t u;
            memcpy(&u, &f, 4);
            for (int b = 0; b < 4; b++)
                p[b] = (unsigned char)(u >> (8 * b));
        } else {
            uint16_t u = t == VOL_TYPE_U16 ? (uint16_t)v : (uint16_t)(int16_t)v;
            p[0] = (unsigned char)u;
            p[1] = (unsigned char)(u >> 8);
        }
    }
}

static void put16(unsigned char *h, int off, int v)
{
    h[off] = (unsigned char)(v & 255);
    h[off + 1] = (unsigned char)((v >> 8) & 255);
}
static void put32(unsigned char *h, int off, uint32_t v)
{
    for (int b = 0; b < 4; b++)
        h[off + b] = (unsigned char)(v >> (8 * b));
}
static void putf(unsigned char *h, int off, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put32(h, off, u);
}

typedef struct nii_spec {
    int dims[8];       /* dim[0..7] */
    int datatype, bitpix;
    float pixdim[3];
    float slope, inter;
    int qform_code;
    float quatern[3];  /* b, c, d */
    long data_bytes;   /* bytes of samples actually written (may be short) */
    const unsigned char *data;
} nii_spec;

/* A NIfTI-1 single file (.nii) by the standard's byte layout [NIfTI1]: 348-byte header, 4 bytes
 * of extension flags, data at byte 352. */
static int write_nii(const char *path, const nii_spec *s)
{
    unsigned char h[352];
    memset(h, 0, sizeof h);
    put32(h, 0, 348);
    for (int i = 0; i < 8; i++)
        put16(h, 40 + 2 * i, s->dims[i]);
    put16(h, 70, s->datatype);
    put16(h, 72, s->bitpix);
    putf(h, 76, 1.0f); /* qfac */
    for (int i = 0; i < 3; i++)
        putf(h, 80 + 4 * i, s->pixdim[i]);
    putf(h, 108, 352.0f);
    putf(h, 112, s->slope);
    putf(h, 116, s->inter);
    put16(h, 252, s->qform_code);
    for (int i = 0; i < 3; i++)
        putf(h, 256 + 4 * i, s->quatern[i]);
    memcpy(h + 344, "n+1", 4);
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    int ok = fwrite(h, 1, 352, f) == 352 && fwrite(s->data, 1, (size_t)s->data_bytes, f) == (size_t)s->data_bytes;
    return fclose(f) == 0 && ok;
}

static nii_spec nii_fixture(vol_type t, const unsigned char *data)
{
    static const int dt[4] = {2, 512, 4, 16};
    nii_spec s;
    memset(&s, 0, sizeof s);
    s.dims[0] = 3;
    s.dims[1] = 5;
    s.dims[2] = 4;
    s.dims[3] = 3;
    for (int i = 4; i < 8; i++)
        s.dims[i] = 1;
    s.datatype = dt[t];
    s.bitpix = 8 * (int)fixture_bytes(t);
    s.pixdim[0] = 0.5f;
    s.pixdim[1] = 0.75f;
    s.pixdim[2] = 2.0f;
    s.data_bytes = (long)(60 * fixture_bytes(t));
    s.data = data;
    return s;
}

static int write_bytes(const char *path, const void *a, size_t na, const void *b, size_t nb)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    int ok = fwrite(a, 1, na, f) == na && (nb == 0 || fwrite(b, 1, nb, f) == nb);
    return fclose(f) == 0 && ok;
}

static int gzip_to(const char *src, const char *dst)
{
    const char *args[] = {"-c", "-n", src, NULL};
    return test_spawn("/bin/gzip", args, dst, NULL) == 0;
}

/* The grid must hold the fixture's values, with the spacing given. */
static int grid_matches_fixture(const vol_grid *g, vol_type t, double slope, double inter, const double sp[3])
{
    if (g->nx != 5 || g->ny != 4 || g->nz != 3 || g->source_type != t)
        return 0;
    for (int a = 0; a < 3; a++)
        if (fabs(g->spacing[a] - sp[a]) > 1e-12)
            return 0;
    for (int q = 0; q < 60; q++)
        if (g->data[q] != (float)(slope * fixture_value(t, q) + inter))
            return 0;
    return 1;
}

TEST(volume_nifti_and_nrrd_round_trips_equal_raw)
{
    obs_context *ctx = obs_context_create();
    const char *dir = test_tmpdir();
    const double sp[3] = {0.5, 0.75, 2.0};
    static const char *const nrrd_type[4] = {"uchar", "ushort", "short", "float"};
    for (int t = 0; t < VOL_TYPE_COUNT; t++) {
        unsigned char data[240];
        fixture_samples((vol_type)t, data);
        size_t nb = 60 * fixture_bytes((vol_type)t);
        /* raw */
        char raw[512], nii[512], niigz[512], nrrd[512], nrrdgz[512], nhdr[512], tmp[512];
        snprintf(raw, sizeof raw, "%s", test_path(dir, "v.raw"));
        snprintf(nii, sizeof nii, "%s", test_path(dir, "v.nii"));
        snprintf(niigz, sizeof niigz, "%s", test_path(dir, "v.nii.gz"));
        snprintf(nrrd, sizeof nrrd, "%s", test_path(dir, "v.nrrd"));
        snprintf(nrrdgz, sizeof nrrdgz, "%s", test_path(dir, "vgz.nrrd"));
        snprintf(nhdr, sizeof nhdr, "%s", test_path(dir, "v.nhdr"));
        snprintf(tmp, sizeof tmp, "%s", test_path(dir, "data.gz"));
        CHECK(write_bytes(raw, data, nb, NULL, 0));
        io_volume_options o = io_volume_options_default();
        o.format = IO_VOLUME_RAW;
        o.dims[0] = 5, o.dims[1] = 4, o.dims[2] = 3;
        o.type = t;
        o.spacing[0] = sp[0], o.spacing[1] = sp[1], o.spacing[2] = sp[2];
        vol_grid gr, g;
        CHECK_OK(io_volume_load(ctx, raw, &o, &gr), ctx);
        CHECK(grid_matches_fixture(&gr, (vol_type)t, 1, 0, sp));
        /* NIfTI, plain and gzipped */
        nii_spec s = nii_fixture((vol_type)t, data);
        CHECK(write_nii(nii, &s));
        CHECK_OK(io_volume_load(ctx, nii, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0 && grid_matches_fixture(&g, (vol_type)t, 1, 0, sp));
        CHECK(strcmp(g.source, nii) == 0);
        vol_grid_free(&g);
        CHECK(gzip_to(nii, niigz));
        CHECK_OK(io_volume_load(ctx, niigz, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0 && grid_matches_fixture(&g, (vol_type)t, 1, 0, sp));
        vol_grid_free(&g);
        /* NRRD attached raw with spacings */
        char head[512];
        int hl = snprintf(head, sizeof head,
                          "NRRD0004\ntype: %s\ndimension: 3\nsizes: 5 4 3\nspacings: 0.5 0.75 2\n%sencoding: raw\n\n",
                          nrrd_type[t], t == VOL_TYPE_U8 ? "" : "endian: little\n");
        CHECK(write_bytes(nrrd, head, (size_t)hl, data, nb));
        CHECK_OK(io_volume_load(ctx, nrrd, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0 && grid_matches_fixture(&g, (vol_type)t, 1, 0, sp));
        vol_grid_free(&g);
        /* NRRD gzip encoding with space directions (spacing = their lengths) and an origin */
        CHECK(gzip_to(raw, tmp));
        size_t gzlen = 0;
        char *gz = test_slurp(tmp, &gzlen);
        CHECK(gz);
        hl = snprintf(head, sizeof head,
                      "NRRD0005\ntype: %s\ndimension: 3\nspace: right-anterior-superior\nsizes: 5 4 3\n"
                      "space directions: (0.5,0,0) (0,0.75,0) (0,0,2)\nspace origin: (1,2,3)\n%sencoding: gzip\n\n",
                      nrrd_type[t], t == VOL_TYPE_U8 ? "" : "endian: little\n");
        CHECK(write_bytes(nrrdgz, head, (size_t)hl, gz, gzlen));
        free(gz);
        CHECK_OK(io_volume_load(ctx, nrrdgz, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0 && grid_matches_fixture(&g, (vol_type)t, 1, 0, sp));
        CHECK(g.origin[0] == 1.0 && g.origin[1] == 2.0 && g.origin[2] == 3.0);
        vol_grid_free(&g);
        /* NRRD detached header pointing at the raw file */
        hl = snprintf(head, sizeof head,
                      "NRRD0004\ntype: %s\ndimension: 3\nsizes: 5 4 3\nspacings: 0.5 0.75 2\n%sencoding: raw\n"
                      "data file: v.raw\n",
                      nrrd_type[t], t == VOL_TYPE_U8 ? "" : "endian: little\n");
        CHECK(write_bytes(nhdr, head, (size_t)hl, NULL, 0));
        CHECK_OK(io_volume_load(ctx, nhdr, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0);
        vol_grid_free(&g);
        /* Our own writer reads back exactly */
        char out[512];
        snprintf(out, sizeof out, "%s", test_path(dir, "w.nrrd"));
        CHECK_OK(io_volume_write_nrrd(ctx, out, &gr), ctx);
        CHECK_OK(io_volume_load(ctx, out, NULL, &g), ctx);
        CHECK(memcmp(g.data, gr.data, 60 * sizeof(float)) == 0 && g.source_type == VOL_TYPE_F32);
        CHECK(g.spacing[0] == 0.5 && g.spacing[1] == 0.75 && g.spacing[2] == 2.0);
        vol_grid_free(&g);
        vol_grid_free(&gr);
    }
    obs_context_destroy(ctx);
}

TEST(volume_nifti_applies_scl_slope)
{
    obs_context *ctx = obs_context_create();
    const double sp[3] = {0.5, 0.75, 2.0};
    unsigned char data[240];
    for (int t = 0; t < VOL_TYPE_COUNT; t++) {
        fixture_samples((vol_type)t, data);
        nii_spec s = nii_fixture((vol_type)t, data);
        s.slope = 2.0f;
        s.inter = -10.0f;
        const char *p = test_path(test_tmpdir(), "slope.nii");
        CHECK(write_nii(p, &s));
        vol_grid g;
        CHECK_OK(io_volume_load(ctx, p, NULL, &g), ctx);
        CHECK(grid_matches_fixture(&g, (vol_type)t, 2.0, -10.0, sp));
        vol_grid_free(&g);
    }
    obs_context_destroy(ctx);
}

/* Expect a refusal whose message names the file. */
#define CHECK_REFUSED(expr, path)                                                                    \
    do {                                                                                             \
        obs_context_clear_error(ctx);                                                                \
        vol_grid g_;                                                                                 \
        obs_status s_ = (expr);                                                                      \
        CHECK_MSG(s_ != OBS_STATUS_OK, "%s was accepted", #expr);                                    \
        CHECK_MSG(strstr(obs_context_last_error(ctx), path), "message '%s' does not name %s",        \
                  obs_context_last_error(ctx), path);                                                \
        CHECK(g_.data == NULL);                                                                      \
        printf("refused (%s): %s\n", obs_status_string(s_), obs_context_last_error(ctx));           \
    } while (0)

TEST(volume_loaders_refuse_bad_files_naming_them)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_log_level(ctx, OBS_LOG_ERROR);
    const char *dir = test_tmpdir();
    unsigned char data[240];
    fixture_samples(VOL_TYPE_U16, data);
    char p[512];

    /* NIfTI: truncated data (the header says more voxels than the file has). */
    nii_spec s = nii_fixture(VOL_TYPE_U16, data);
    s.data_bytes = 100;
    snprintf(p, sizeof p, "%s", test_path(dir, "short.nii"));
    CHECK(write_nii(p, &s));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    CHECK(strstr(obs_context_last_error(ctx), "truncated"));
    /* ... and gzipped: caught by the read. */
    char pgz[512];
    snprintf(pgz, sizeof pgz, "%s", test_path(dir, "short.nii.gz"));
    CHECK(gzip_to(p, pgz));
    CHECK_REFUSED(io_volume_load(ctx, pgz, NULL, &g_), pgz);
    /* A header cut short. */
    snprintf(p, sizeof p, "%s", test_path(dir, "cut.nii"));
    CHECK(write_bytes(p, "\x5c\x01\0\0", 4, NULL, 0));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    /* 4D with t = 2. */
    s = nii_fixture(VOL_TYPE_U16, data);
    s.dims[0] = 4;
    s.dims[3] = 1;
    s.dims[4] = 2;
    s.data_bytes = 5 * 4 * 2 * 2;
    snprintf(p, sizeof p, "%s", test_path(dir, "4d.nii"));
    CHECK(write_nii(p, &s));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    CHECK_EQ_INT(obs_context_last_status(ctx), OBS_STATUS_UNSUPPORTED);
    /* A zero dimension. */
    s = nii_fixture(VOL_TYPE_U16, data);
    s.dims[3] = 0;
    snprintf(p, sizeof p, "%s", test_path(dir, "zero.nii"));
    CHECK(write_nii(p, &s));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    /* Complex (DT_COMPLEX64 = 32), RGB (DT_RGB24 = 128), double (64), an unknown code. */
    static const int dts[4][2] = {{32, 64}, {128, 24}, {64, 64}, {4242, 16}};
    for (int i = 0; i < 4; i++) {
        s = nii_fixture(VOL_TYPE_U16, data);
        s.datatype = dts[i][0];
        s.bitpix = dts[i][1];
        s.data_bytes = 60;
        snprintf(p, sizeof p, "%s", test_path(dir, "type.nii"));
        CHECK(write_nii(p, &s));
        CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    }
    /* Absurd sizes: refused by the limits before anything is read or allocated. */
    s = nii_fixture(VOL_TYPE_U16, data);
    s.dims[1] = s.dims[2] = s.dims[3] = 32767;
    snprintf(p, sizeof p, "%s", test_path(dir, "huge.nii"));
    CHECK(write_nii(p, &s));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    CHECK_EQ_INT(obs_context_last_status(ctx), OBS_STATUS_LIMIT_EXCEEDED);

    /* NRRD: truncated raw, a 4D file, an unsupported type, absurd sizes, zero spacing, a missing
     * data file, garbage (a truncated gzip NRRD: its own test below). */
    static const char *const bad_nrrd[] = {
        "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 5 4 3\nendian: little\nencoding: raw\n\n",
        "NRRD0004\ntype: ushort\ndimension: 4\nsizes: 5 4 3 1\nendian: little\nencoding: raw\n\n",
        "NRRD0004\ntype: double\ndimension: 3\nsizes: 5 4 3\nendian: little\nencoding: raw\n\n",
        "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 100000 100000 100000\nendian: little\nencoding: raw\n\n",
        "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 5 4 3\nspacings: 1 0 1\nendian: little\nencoding: raw\n\n",
        "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 5 4 3\nendian: little\nencoding: raw\ndata file: missing.raw\n",
        "NRRD0004\nthis is not a header\n\n",
    };
    for (size_t i = 0; i < sizeof bad_nrrd / sizeof bad_nrrd[0]; i++) {
        snprintf(p, sizeof p, "%s", test_path(dir, i == 5 ? "bad.nhdr" : "bad.nrrd"));
        CHECK(write_bytes(p, bad_nrrd[i], strlen(bad_nrrd[i]), data, i == 5 ? 0 : 50));
        CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    }
    snprintf(p, sizeof p, "%s", test_path(dir, "absent.nrrd"));
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    CHECK_EQ_INT(obs_context_last_status(ctx), OBS_STATUS_IO_ERROR);

    /* Raw: bad options, and a file shorter than they describe. */
    snprintf(p, sizeof p, "%s", test_path(dir, "v.raw"));
    CHECK(write_bytes(p, data, 120, NULL, 0));
    io_volume_options o = io_volume_options_default();
    o.format = IO_VOLUME_RAW;
    o.dims[0] = 5, o.dims[1] = 4, o.dims[2] = 3;
    o.type = VOL_TYPE_U16;
    vol_grid g;
    CHECK_OK(io_volume_load(ctx, p, &o, &g), ctx);
    vol_grid_free(&g);
    for (int i = 0; i < 7; i++) {
        io_volume_options b = o;
        switch (i) {
        case 0: b.dims[1] = 0; break;
        case 1: b.type = 9; break;
        case 2: b.spacing[2] = 0.0; break;
        case 3: b.spacing[0] = NAN; break;
        case 4: b.header_skip = -4; break;
        case 5: b.header_skip = 2; break;          /* then the file is 2 bytes short */
        default: b.dims[2] = 4; break;             /* more voxels than the file has */
        }
        CHECK_REFUSED(io_volume_load(ctx, p, &b, &g_), p);
    }
    /* Auto never guesses raw. */
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    obs_context_destroy(ctx);
}

/* ---- the real datasets (scripts/fetch_volumes.sh; docs/volume.md "Datasets") ------------------- */

TEST(volume_real_datasets_load_when_fetched)
{
    obs_context *ctx = obs_context_create();
    char p[1024];
    int found = 0;
    snprintf(p, sizeof p, "%s/data/cache/volumes/ch2better.nii.gz", test_source_dir());
    FILE *f = fopen(p, "rb");
    if (f) {
        fclose(f);
        found++;
        vol_grid g;
        CHECK_OK(io_volume_load(ctx, p, NULL, &g), ctx);
        CHECK(g.nx == 301 && g.ny == 370 && g.nz == 316 && g.source_type == VOL_TYPE_U8);
        CHECK_NEAR(g.spacing[0], 0.5, 1e-6);
        CHECK_NEAR(g.spacing[2], 0.5, 1e-6);
        CHECK(g.value_min == 0.0f && g.value_max == 130.0f);
        printf("ch2better.nii.gz: %dx%dx%d %s, spacing %g %g %g, origin %g %g %g, values %g..%g\n", g.nx, g.ny, g.nz,
               vol_type_name(g.source_type), g.spacing[0], g.spacing[1], g.spacing[2], g.origin[0], g.origin[1],
               g.origin[2], g.value_min, g.value_max);
        vol_grid_free(&g);
    } else {
        printf("dataset absent: %s (run scripts/fetch_volumes.sh); its checks were skipped\n", p);
    }
    snprintf(p, sizeof p, "%s/data/cache/volumes/cranium.nrrd", test_source_dir());
    f = fopen(p, "rb");
    if (f) {
        fclose(f);
        found++;
        vol_grid g;
        CHECK_OK(io_volume_load(ctx, p, NULL, &g), ctx);
        CHECK(g.nx == 256 && g.ny == 256 && g.nz == 108 && g.source_type == VOL_TYPE_I16);
        CHECK_NEAR(g.spacing[0], 0.9570312, 1e-9);
        CHECK_NEAR(g.spacing[2], 1.5, 1e-12);
        CHECK(g.value_min == -1024.0f && g.value_max == 2986.0f);
        printf("cranium.nrrd: %dx%dx%d %s, spacing %g %g %g, values %g..%g\n", g.nx, g.ny, g.nz,
               vol_type_name(g.source_type), g.spacing[0], g.spacing[1], g.spacing[2], g.value_min, g.value_max);
        vol_grid_free(&g);
    } else {
        printf("dataset absent: %s (run scripts/fetch_volumes.sh); its checks were skipped\n", p);
    }
    printf("%d of 2 real datasets present and checked\n", found);
    obs_context_destroy(ctx);
}

/* Separate from the test above: teem 1.12.0~20160122 (Debian 12) leaks its gzip reader's state
 * (_nrrdGzOpen, about 23 kB) when a gzip NRRD's data is short, which LeakSanitizer reports; the
 * sanitizer build needs the suppression `leak:_nrrdGzOpen` for this test. */
TEST(volume_nrrd_truncated_gzip_is_refused)
{
    obs_context *ctx = obs_context_create();
    unsigned char data[240];
    fixture_samples(VOL_TYPE_U16, data);
    const char *dir = test_tmpdir();
    char raw[512], gz[512], p[512];
    snprintf(raw, sizeof raw, "%s", test_path(dir, "part.raw"));
    snprintf(gz, sizeof gz, "%s", test_path(dir, "part.gz"));
    snprintf(p, sizeof p, "%s", test_path(dir, "short-gzip.nrrd"));
    CHECK(write_bytes(raw, data, 60, NULL, 0)); /* half the samples */
    CHECK(gzip_to(raw, gz));
    size_t gzlen = 0;
    char *z = test_slurp(gz, &gzlen);
    CHECK(z);
    const char *head = "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 5 4 3\nendian: little\nencoding: gzip\n\n";
    int ok = write_bytes(p, head, strlen(head), z, gzlen);
    free(z);
    CHECK(ok);
    CHECK_REFUSED(io_volume_load(ctx, p, NULL, &g_), p);
    CHECK_EQ_INT(obs_context_last_status(ctx), OBS_STATUS_IO_ERROR);
    obs_context_destroy(ctx);
}
