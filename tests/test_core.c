/* test_core.c: core behaviours: RNG known answers and keying, low-discrepancy sequences,
 * maths, images and limits, the pool's determinism, and the error context. */
#include "core/obs.h"
#include "test.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

TEST(philox_matches_random123_known_answers)
{
    /* Random123 kat_vectors, "philox4x32 10" lines: counter, key -> output. */
    static const uint32_t cases[3][10] = {
        {0, 0, 0, 0, 0, 0, 0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8},
        {0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0x408f276d, 0x41c83b0e,
         0xa20bc7c6, 0x6d5451fd},
        {0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344, 0xa4093822, 0x299f31d0, 0xd16cfe09, 0x94fdcceb,
         0x5001e420, 0x24126ea1},
    };
    for (int i = 0; i < 3; i++) {
        uint32_t out[4];
        obs_philox4x32_10(cases[i], cases[i] + 4, out);
        for (int k = 0; k < 4; k++)
            CHECK_MSG(out[k] == cases[i][6 + k], "case %d word %d: %08x != %08x", i, k, out[k], cases[i][6 + k]);
    }
}

TEST(rng_four_at_a_time_equals_one_at_a_time)
{
    /* obs_rng_u32x4_n (SSE2, 4 Philox calls at once) against obs_rng_u32x4, every count 0..37
     * (the scalar tail included), pixels and seeds with high halves, sample indices that wrap */
    static const uint64_t pixels[] = {0, 1, 2073599, 0x123456789abcdefull, ~0ull};
    static const uint64_t seeds[] = {0, 7, 0xfedcba9876543210ull};
    static const uint32_t starts[] = {0, 5, 0xFFFFFFFEu};
    uint32_t got[37][4], want[4];
    for (size_t a = 0; a < sizeof pixels / sizeof pixels[0]; a++)
        for (size_t b = 0; b < sizeof seeds / sizeof seeds[0]; b++)
            for (size_t c = 0; c < sizeof starts / sizeof starts[0]; c++)
                for (int n = 0; n <= 37; n++) {
                    memset(got, 0xAB, sizeof got);
                    obs_rng_u32x4_n(pixels[a], starts[c], n, 3u * (uint32_t)c, seeds[b], got);
                    for (int k = 0; k < n; k++) {
                        obs_rng_u32x4(pixels[a], starts[c] + (uint32_t)k, 3u * (uint32_t)c, seeds[b], want);
                        CHECK_MSG(!memcmp(got[k], want, sizeof want), "pixel %llu seed %llu sample %u: words differ",
                                  (unsigned long long)pixels[a], (unsigned long long)seeds[b], starts[c] + (uint32_t)k);
                    }
                    if (n < 37)
                        CHECK(got[n][0] == 0xABABABABu); /* nothing written past n */
                }
}

TEST(rng_depends_only_on_pixel_sample_dimension_seed)
{
    float a = obs_rng_float(12345, 7, 3, 42), b = obs_rng_float(12345, 7, 3, 42);
    CHECK(a == b);
    CHECK(obs_rng_float(12346, 7, 3, 42) != a);
    CHECK(obs_rng_float(12345, 8, 3, 42) != a);
    CHECK(obs_rng_float(12345, 7, 4, 42) != a);
    CHECK(obs_rng_float(12345, 7, 3, 43) != a);
    /* Uniformity: chi-square over 64 bins of 2^16 draws; 63 dof, p = 0.001 critical value 103.4. */
    enum { BINS = 64, N = 1 << 16 };
    int hist[BINS] = {0};
    for (uint32_t i = 0; i < N; i++) {
        float u = obs_rng_float(i, 0, 0, 1);
        CHECK(u >= 0.0f && u < 1.0f);
        hist[(int)(u * BINS)]++;
    }
    double chi2 = 0, e = (double)N / BINS;
    for (int k = 0; k < BINS; k++)
        chi2 += (hist[k] - e) * (hist[k] - e) / e;
    CHECK_MSG(chi2 < 103.4, "chi2 = %g", chi2);
    double d = obs_rng_double(5, 6, 7, 8);
    CHECK(d >= 0.0 && d < 1.0);
}

TEST(radical_inverse_matches_hand_values)
{
    CHECK(obs_radical_inverse(2, 0) == 0.0);
    CHECK(obs_radical_inverse(2, 1) == 0.5);
    CHECK(obs_radical_inverse(2, 2) == 0.25);
    CHECK(obs_radical_inverse(2, 3) == 0.75);
    CHECK(obs_radical_inverse(2, 6) == 0.375);
    CHECK_NEAR(obs_radical_inverse(3, 1), 1.0 / 3.0, 1e-15);
    CHECK_NEAR(obs_radical_inverse(3, 4), 1.0 / 3.0 + 1.0 / 9.0, 1e-15);
    CHECK_NEAR(obs_radical_inverse(5, 7), 2.0 / 5.0 + 1.0 / 25.0, 1e-15);
    CHECK_EQ_INT(obs_prime(0), 2);
    CHECK_EQ_INT(obs_prime(1), 3);
    CHECK_EQ_INT(obs_prime(999), 7919);
    CHECK_EQ_INT(obs_prime(1000), 0);
    CHECK_NEAR(obs_halton(1, 1), 1.0 / 3.0, 1e-15);
    /* Stratification: the first 2^k base-2 points hit each of 2^k intervals once. */
    int seen[256] = {0};
    for (int i = 0; i < 256; i++)
        seen[(int)(obs_radical_inverse(2, (uint64_t)i) * 256)]++;
    for (int i = 0; i < 256; i++)
        CHECK(seen[i] == 1);
    CHECK_NEAR(obs_cp_rotate(0.75, 0.5), 0.25, 1e-15);
}

TEST(mat4_inverse_trs_and_look_at_are_consistent)
{
    obs_mat4 m = obs_mat4_from_trs(obs_v3(1, 2, 3), (obs_vec4){0.2f, -0.3f, 0.1f, 0.927f}, obs_v3(2, 0.5f, 1.5f));
    obs_mat4 inv;
    CHECK(obs_mat4_inverse(m, &inv));
    obs_mat4 id = obs_mat4_mul(m, inv);
    for (int i = 0; i < 16; i++)
        CHECK_NEAR(id.m[i], (i % 5 == 0) ? 1.0 : 0.0, 1e-5);
    obs_vec3 p = obs_mat4_mul_point(m, obs_v3(0, 0, 0));
    CHECK_NEAR(p.x, 1, 1e-6);
    CHECK_NEAR(p.z, 3, 1e-6);
    obs_mat4 sing = obs_mat4_scale(obs_v3(1, 0, 1));
    CHECK(!obs_mat4_inverse(sing, &inv));
    /* look_at: the target lands on the -Z axis, up stays in the +Y half-plane */
    obs_mat4 v = obs_mat4_look_at(obs_v3(3, 4, 5), obs_v3(0, 1, 0), obs_v3(0, 1, 0));
    obs_vec3 t = obs_mat4_mul_point(v, obs_v3(0, 1, 0));
    CHECK_NEAR(t.x, 0, 1e-5);
    CHECK_NEAR(t.y, 0, 1e-5);
    CHECK(t.z < 0);
    obs_vec3 up = obs_mat4_mul_dir(v, obs_v3(0, 1, 0));
    CHECK(up.y > 0);
    CHECK(obs_v3_length(obs_v3_normalize(obs_v3(NAN, 0, 0))) == 0.0f);
    CHECK_NEAR(obs_v3_length(obs_v3_normalize(obs_v3(1e-30f, 0, 0))), 1.0, 1e-6);
}

TEST(projection_matches_gltf_spec_formulas)
{
    obs_camera c = obs_camera_look_at(obs_v3(0, 0, 0), obs_v3(0, 0, -1), obs_v3(0, 1, 0), 1.0f, 0.1f, 100.0f);
    obs_mat4 p = obs_camera_projection_gl(&c, 2.0f);
    double t = 1.0 / tan(0.5);
    CHECK_NEAR(p.m[0], t / 2.0, 1e-6);
    CHECK_NEAR(p.m[5], t, 1e-6);
    CHECK_NEAR(p.m[10], (100.1) / (0.1 - 100.0), 1e-6);
    CHECK_NEAR(p.m[14], 2 * 100 * 0.1 / (0.1 - 100), 1e-6);
    CHECK(p.m[11] == -1.0f);
    c.zfar = INFINITY;
    p = obs_camera_projection_gl(&c, 2.0f);
    CHECK(p.m[10] == -1.0f);
    CHECK_NEAR(p.m[14], -0.2, 1e-7);
}

TEST(image_alloc_refuses_absurd_sizes_before_allocating)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 im;
    CHECK(obs_image_f32_alloc(ctx, 0, 10, &im) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(obs_image_f32_alloc(ctx, -5, 10, &im) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_clear_error(ctx);
    CHECK(obs_image_f32_alloc(ctx, 1 << 30, 1 << 30, &im) == OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-pixels") != NULL);
    obs_limits lim = obs_limits_default();
    lim.max_memory_bytes = 1000;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK(obs_image_u32_alloc(ctx, 100, 100, (obs_image_u32 *)&im) == OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-memory") != NULL);
    obs_context_destroy(ctx);
    size_t out;
    CHECK(!obs_mul_size(SIZE_MAX / 2 + 1, 2, &out));
    CHECK(!obs_add_size(SIZE_MAX, 1, &out));
    CHECK(obs_mul_size(3, 5, &out) && out == 15);
}

TEST(image_planes_have_aligned_rows_and_windows_share_data)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 im;
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 5, &im), ctx);
    CHECK(im.stride >= 37 && im.stride % 16 == 0);
    CHECK(((uintptr_t)im.data & 63) == 0);
    CHECK(im.data[im.stride * 4 + 36] == 0.0f);
    obs_image_f32_fill(&im, 2.5f);
    obs_image_f32 w = obs_image_f32_window(&im, 3, 1, 10, 2);
    CHECK(w.width == 10 && w.data == im.data + im.stride + 3);
    w.data[0] = 7.0f;
    CHECK(obs_image_f32_row(&im, 1)[3] == 7.0f);
    obs_image_f32 bad = obs_image_f32_window(&im, 30, 0, 10, 1);
    CHECK(bad.data == NULL);
    obs_image_f32_free(&im);
    CHECK(im.data == NULL);
    obs_context_destroy(ctx);
}

typedef struct pool_probe { atomic_int *hits; int64_t count; } pool_probe;
static void probe_task(void *user, int64_t task, int thread)
{
    (void)thread;
    pool_probe *p = (pool_probe *)user;
    atomic_fetch_add(&p->hits[task], 1);
}

TEST(pool_runs_every_task_exactly_once_for_any_thread_count)
{
    int counts[] = {1, 2, 3, 8};
    for (int c = 0; c < 4; c++) {
        obs_pool *pool = obs_pool_create(counts[c]);
        CHECK(pool != NULL);
        CHECK_EQ_INT(obs_pool_threads(pool), counts[c]);
        for (int rep = 0; rep < 20; rep++) {
            int64_t n = 1 + rep * 37;
            atomic_int *hits = calloc((size_t)n, sizeof(atomic_int));
            pool_probe p = {hits, n};
            obs_pool_run(pool, n, probe_task, &p);
            for (int64_t i = 0; i < n; i++)
                CHECK(atomic_load(&hits[i]) == 1);
            free(hits);
        }
        obs_pool_destroy(pool);
    }
}

TEST(tiling_covers_the_image_exactly_once)
{
    obs_tiling t = obs_tiling_make(130, 67, 64);
    CHECK_EQ_INT(obs_tiling_count(&t), 3 * 2);
    static unsigned char seen[67][130];
    memset(seen, 0, sizeof seen);
    for (int64_t k = 0; k < obs_tiling_count(&t); k++) {
        int x0, y0, x1, y1;
        obs_tiling_rect(&t, k, &x0, &y0, &x1, &y1);
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++)
                seen[y][x]++;
    }
    for (int y = 0; y < 67; y++)
        for (int x = 0; x < 130; x++)
            CHECK(seen[y][x] == 1);
}

static int g_cb_calls;
static void count_cb(void *user, obs_status st, const char *msg)
{
    (void)user; (void)st; (void)msg;
    g_cb_calls++;
}

TEST(context_keeps_the_first_error_and_calls_back_for_each)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_error_callback(ctx, count_cb, NULL);
    CHECK(obs_context_last_status(ctx) == OBS_STATUS_OK);
    CHECK(obs_error(ctx, OBS_STATUS_IO_ERROR, "first %d", 1) == OBS_STATUS_IO_ERROR);
    obs_error(ctx, OBS_STATUS_PARSE_ERROR, "second");
    CHECK(obs_context_last_status(ctx) == OBS_STATUS_IO_ERROR);
    CHECK(strcmp(obs_context_last_error(ctx), "first 1") == 0);
    CHECK_EQ_INT(g_cb_calls, 2);
    obs_context_clear_error(ctx);
    CHECK(obs_context_last_error(ctx)[0] == '\0');
    for (int s = 0; s < OBS_STATUS_COUNT; s++)
        CHECK(strlen(obs_status_string((obs_status)s)) > 0);
    obs_context_destroy(ctx);
}

TEST(scene_validate_rejects_bad_indices_and_transforms)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    obs_scene_init(&s);
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t idx[3] = {0, 1, 3};
    obs_mesh m = {.name = "tri", .vertex_count = 3, .triangle_count = 1, .positions = pos, .indices = idx,
                  .material = -1};
    obs_instance in = {.mesh = 0, .node = 0, .world = obs_mat4_identity()};
    s.meshes = &m;
    s.mesh_count = 1;
    s.instances = &in;
    s.instance_count = 1;
    CHECK(obs_scene_validate(ctx, &s) == OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "index") != NULL);
    idx[2] = 2;
    obs_context_clear_error(ctx);
    CHECK_OK(obs_scene_validate(ctx, &s), ctx);
    in.world.m[5] = NAN;
    CHECK(obs_scene_validate(ctx, &s) == OBS_STATUS_PARSE_ERROR);
    in.world = obs_mat4_identity();
    obs_limits lim = obs_limits_default();
    lim.max_triangles = 0;
    obs_context_set_limits(ctx, &lim);
    obs_context_clear_error(ctx);
    CHECK(obs_scene_validate(ctx, &s) == OBS_STATUS_LIMIT_EXCEEDED);
    CHECK(strstr(obs_context_last_error(ctx), "--max-triangles") != NULL);
    obs_scene_update_bounds(&s);
    CHECK(s.bounds.lo.x == 0.0f && s.bounds.hi.y == 1.0f);
    obs_context_destroy(ctx);
}

TEST(timer_measures_monotonic_time)
{
    obs_timer t = {0};
    obs_timer_start(&t);
    double a = obs_time_now();
    while (obs_time_now() - a < 0.002) {
    }
    obs_timer_stop(&t);
    CHECK(obs_timer_seconds(&t) >= 0.002);
    CHECK(obs_timer_seconds(&t) < 1.0);
}
