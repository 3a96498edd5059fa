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
