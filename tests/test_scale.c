/* test_scale.c: scale-out (docs/scale.md): dealing tasks, rendering a subset of tasks, and the
 * MPI runs (mpirun -np 1, 2, 3 on loopback give the plain command's bytes; a killed or failing rank
 * fails the job with no file written). The MPI tests exit 77 (skipped) in a build without MPI. */
#include "test.h"

#include "io/io.h"
#include "raster/raster.h"
#include "scale/scale.h"
#include "truth/truth.h"
#include "volume/vol.h"

#include <math.h>

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- dealing ---------------------------------------------------------------------------------- */

TEST(scale_deal_tasks_balances_estimates_and_is_deterministic)
{
    enum { N = 1000 };
    double cost[N];
    uint32_t s = 12345u;
    for (int t = 0; t < N; t++) { /* clustered costs: a band of expensive tasks, like an object */
        s = s * 1664525u + 1013904223u;
        cost[t] = (t > 300 && t < 600 ? 64.0 : 0.25) * (double)(s >> 24) / 255.0;
    }
    for (int nr = 1; nr <= 7; nr++) {
        int a[N], b[N];
        CHECK_OK(scale_deal_tasks(NULL, cost, N, nr, a), (obs_context *)NULL);
        CHECK_OK(scale_deal_tasks(NULL, cost, N, nr, b), (obs_context *)NULL);
        CHECK(!memcmp(a, b, sizeof a));
        double load[8] = {0}, maxc = 0.0;
        for (int t = 0; t < N; t++) {
            CHECK(a[t] >= 0 && a[t] < nr);
            load[a[t]] += cost[t];
            maxc = cost[t] > maxc ? cost[t] : maxc;
        }
        /* list scheduling: every rank within one task's cost of every other */
        for (int r = 0; r < nr; r++)
            for (int q = 0; q < nr; q++)
                CHECK(load[r] - load[q] <= maxc + 1e-9);
    }
    int o[4];
    double bad[4] = {1, -1, 1, 1};
    CHECK(scale_deal_tasks(NULL, bad, 4, 2, o) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(scale_deal_tasks(NULL, cost, 4, 0, o) == OBS_STATUS_INVALID_ARGUMENT);
    const double v[3] = {1.0, 1.0, 1.3};
    CHECK_NEAR(scale_imbalance(v, 3), 1.3 / 1.1 - 1.0, 1e-12);
}

TEST(scale_ao_task_rects_tile_the_image_once)
{
    const int sizes[][3] = {{64, 48, 8}, {67, 45, 8}, {100, 33, 5}, {31, 17, 16}, {40, 40, 32}, {1, 1, 4}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        const int W = sizes[k][0], H = sizes[k][1], T = sizes[k][2];
        const int64_t n = truth_ao_task_count(W, H, T);
        CHECK(n > 0);
        unsigned char *hit = (unsigned char *)calloc((size_t)W * H, 1);
        for (int64_t t = 0; t < n; t++) {
            int x0, y0, x1, y1;
            truth_ao_task_rect(W, H, T, t, &x0, &y0, &x1, &y1);
            CHECK(x0 >= 0 && y0 >= 0 && x1 <= W && y1 <= H && x0 < x1 && y0 < y1);
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++)
                    hit[(size_t)y * W + x]++;
        }
        for (int i = 0; i < W * H; i++)
            CHECK_MSG(hit[i] == 1, "%dx%d tile %d: pixel %d covered %d times", W, H, T, i, hit[i]);
        free(hit);
    }
    CHECK_EQ_INT(truth_ao_task_count(0, 10, 8), 0);
}

/* ---- a partition of the tasks, rendered apart, equals the whole ------------------------------- */

TEST(scale_truth_ao_task_partition_equals_whole_render)
{
    obs_context *ctx = obs_context_create();
    obs_scene scene;
    io_gltf_options go = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "bunny.glb"), &go, &scene), ctx);
    CHECK(scene.camera_count > 0);
    rast_params rp = rast_params_default();
    rp.width = 64;
    rp.height = 48;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_FACE_NORMAL | RAST_OUT_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view v = {scene.cameras[0]};
    CHECK_OK(rast_render(ctx, NULL, &scene, &v, 1, &rp, &gb, NULL), ctx);
    truth_scene *ts = NULL;
    CHECK_OK(truth_scene_create(ctx, &scene, TRUTH_BUILD_MEDIUM, &ts), ctx);
    truth_ao_params p = truth_ao_params_default();
    p.max_samples = 256;
    truth_ao_result whole;
    CHECK_OK(truth_ao_render(ctx, NULL, ts, &scene, &scene.cameras[0], &gb, &p, &whole), ctx);

    const int64_t nt = truth_ao_task_count(64, 48, p.tile);
    double *cost = (double *)malloc(sizeof(double) * (size_t)nt);
    int *owner = (int *)malloc(sizeof(int) * (size_t)nt);
    unsigned char *mask = (unsigned char *)malloc((size_t)nt);
    CHECK_OK(scale_ao_task_costs(ctx, &gb, p.tile, cost, nt), ctx);
    CHECK_OK(scale_deal_tasks(ctx, cost, nt, 3, owner), ctx);
    obs_pool *pool = obs_pool_create(2);
    truth_ao_stats sum;
    memset(&sum, 0, sizeof sum);
    for (int r = 0; r < 3; r++) {
        for (int64_t t = 0; t < nt; t++)
            mask[t] = owner[t] == r;
        truth_ao_result part;
        CHECK_OK(truth_ao_render_tasks(ctx, pool, ts, &scene, &scene.cameras[0], &gb, &p, mask, &part), ctx);
        for (int64_t t = 0; t < nt; t++) {
            int x0, y0, x1, y1;
            truth_ao_task_rect(64, 48, p.tile, t, &x0, &y0, &x1, &y1);
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++) {
                    const float m = obs_image_f32_row(&part.mean, y)[x], c = obs_image_f32_row(&part.count, y)[x];
                    const float e = obs_image_f32_row(&part.std_error, y)[x];
                    if (mask[t]) { /* bit for bit */
                        CHECK(!memcmp(&m, obs_image_f32_row(&whole.mean, y) + x, 4));
                        CHECK(!memcmp(&e, obs_image_f32_row(&whole.std_error, y) + x, 4));
                        CHECK(!memcmp(&c, obs_image_f32_row(&whole.count, y) + x, 4));
                    } else {
                        CHECK(m == 0.0f && e == 0.0f && c == 0.0f);
                    }
                }
        }
        sum.rays += part.stats.rays;
        sum.pixels_surface += part.stats.pixels_surface;
        sum.pixels_background += part.stats.pixels_background;
        sum.pixels_converged += part.stats.pixels_converged;
        sum.pixels_at_max += part.stats.pixels_at_max;
        sum.max_std_error = part.stats.max_std_error > sum.max_std_error ? part.stats.max_std_error : sum.max_std_error;
        sum.max_offset = part.stats.max_offset > sum.max_offset ? part.stats.max_offset : sum.max_offset;
        truth_ao_result_free(&part);
    }
    CHECK_EQ_INT(sum.rays, whole.stats.rays);
    CHECK_EQ_INT(sum.pixels_surface, whole.stats.pixels_surface);
    CHECK_EQ_INT(sum.pixels_background, whole.stats.pixels_background);
    CHECK_EQ_INT(sum.pixels_converged, whole.stats.pixels_converged);
    CHECK_EQ_INT(sum.pixels_at_max, whole.stats.pixels_at_max);
    CHECK(sum.max_std_error == whole.stats.max_std_error);
    CHECK(sum.max_offset == whole.stats.max_offset);
    obs_pool_destroy(pool);
    free(cost);
    free(owner);
    free(mask);
    truth_ao_result_free(&whole);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

/* The same for truth_sss: the tiles tile the image once; three subsets of them, dealt by the
 * translucent-pixel estimate and rendered apart (2 threads), give the whole render's seven planes
 * bit for bit, zeros elsewhere, and counters that sum to the whole's. */
TEST(scale_truth_sss_task_partition_equals_whole_render)
{
    const int sizes[][3] = {{24, 18, 4}, {25, 17, 4}, {10, 7, 3}, {5, 5, 64}};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        const int W = sizes[k][0], H = sizes[k][1], T = sizes[k][2];
        const int64_t n = truth_sss_task_count(W, H, T);
        CHECK(n > 0);
        unsigned char *hit = (unsigned char *)calloc((size_t)W * H, 1);
        for (int64_t t = 0; t < n; t++) {
            int x0, y0, x1, y1;
            truth_sss_task_rect(W, H, T, t, &x0, &y0, &x1, &y1);
            CHECK(x0 >= 0 && y0 >= 0 && x1 <= W && y1 <= H && x0 < x1 && y0 < y1);
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++)
                    hit[(size_t)y * W + x]++;
        }
        for (int i = 0; i < W * H; i++)
            CHECK_MSG(hit[i] == 1, "%dx%d tile %d: pixel %d covered %d times", W, H, T, i, hit[i]);
        free(hit);
    }
    CHECK_EQ_INT(truth_sss_task_count(0, 10, 4), 0);
    CHECK_EQ_INT(truth_sss_task_count(10, 10, 65), 0);

    obs_context *ctx = obs_context_create();
    obs_scene scene;
    io_gltf_options go = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "sphere_potato.glb"), &go, &scene), ctx);
    CHECK(scene.camera_count > 0);
    sss_scene_setup setup;
    CHECK_OK(sss_scene_setup_make(ctx, &scene, NULL, 1.0, &setup), ctx);
    CHECK(setup.translucent_slots > 0);
    enum { W = 24, H = 18 };
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    rast_gbuffer gb;
    CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &gb), ctx);
    rast_view v = {scene.cameras[0]};
    CHECK_OK(rast_render(ctx, NULL, &scene, &v, 1, &rp, &gb, NULL), ctx);
    truth_scene *ts = NULL;
    CHECK_OK(truth_scene_create(ctx, &scene, TRUTH_BUILD_MEDIUM, &ts), ctx);
    truth_sss_params p = truth_sss_params_default();
    p.min_samples = p.max_samples = p.batch = 256;
    p.patch_radius = 0.05;
    const int64_t nt = truth_sss_task_count(W, H, p.tile);
    double *cost = (double *)malloc(sizeof(double) * (size_t)nt);
    int *owner = (int *)malloc(sizeof(int) * (size_t)nt);
    unsigned char *mask = (unsigned char *)malloc((size_t)nt);
    CHECK_OK(scale_sss_task_costs(ctx, &gb, &scene, &setup.mats, p.tile, cost, nt), ctx);
    double total = 0.0;
    for (int64_t t = 0; t < nt; t++)
        total += cost[t];
    CHECK(total > 1.0 && total < (double)W * H); /* some translucent pixels, not all */
    CHECK_OK(scale_deal_tasks(ctx, cost, nt, 3, owner), ctx);
    obs_pool *pool = obs_pool_create(2);
    for (int e = 0; e < 2; e++) {
        p.estimator = e ? TRUTH_SSS_RANDOM_WALK : TRUTH_SSS_BRUTE_FORCE;
        truth_sss_result whole;
        CHECK_OK(truth_sss_render(ctx, NULL, ts, &scene, &setup.mats, &scene.cameras[0], &gb, &p, &whole), ctx);
        CHECK(whole.stats.pixels_surface > 0);
        truth_sss_stats sum;
        memset(&sum, 0, sizeof sum);
        for (int r = 0; r < 3; r++) {
            for (int64_t t = 0; t < nt; t++)
                mask[t] = owner[t] == r;
            truth_sss_result part;
            CHECK_OK(truth_sss_render_tasks(ctx, pool, ts, &scene, &setup.mats, &scene.cameras[0], &gb, &p, mask, &part),
                     ctx);
            const obs_image_f32 *pa[7] = {&part.radiance[0], &part.radiance[1], &part.radiance[2], &part.std_error[0],
                                          &part.std_error[1], &part.std_error[2], &part.count};
            const obs_image_f32 *pw[7] = {&whole.radiance[0], &whole.radiance[1], &whole.radiance[2], &whole.std_error[0],
                                          &whole.std_error[1], &whole.std_error[2], &whole.count};
            for (int64_t t = 0; t < nt; t++) {
                int x0, y0, x1, y1;
                truth_sss_task_rect(W, H, p.tile, t, &x0, &y0, &x1, &y1);
                for (int y = y0; y < y1; y++)
                    for (int x = x0; x < x1; x++)
                        for (int q = 0; q < 7; q++) {
                            const float a = obs_image_f32_row(pa[q], y)[x];
                            if (mask[t]) /* bit for bit */
                                CHECK(!memcmp(&a, obs_image_f32_row(pw[q], y) + x, 4));
                            else
                                CHECK(a == 0.0f);
                        }
            }
            sum.candidates += part.stats.candidates;
            sum.accepted += part.stats.accepted;
            sum.rays += part.stats.rays;
            sum.walk_events += part.stats.walk_events;
            sum.pixels_surface += part.stats.pixels_surface;
            sum.pixels_skipped += part.stats.pixels_skipped;
            sum.pixels_converged += part.stats.pixels_converged;
            sum.pixels_at_max += part.stats.pixels_at_max;
            truth_sss_result_free(&part);
        }
        CHECK_EQ_INT(sum.candidates, whole.stats.candidates);
        CHECK_EQ_INT(sum.accepted, whole.stats.accepted);
        CHECK_EQ_INT(sum.rays, whole.stats.rays);
        CHECK_EQ_INT(sum.walk_events, whole.stats.walk_events);
        CHECK_EQ_INT(sum.pixels_surface, whole.stats.pixels_surface);
        CHECK_EQ_INT(sum.pixels_skipped, whole.stats.pixels_skipped);
        CHECK_EQ_INT(sum.pixels_converged, whole.stats.pixels_converged);
        CHECK_EQ_INT(sum.pixels_at_max, whole.stats.pixels_at_max);
        truth_sss_result_free(&whole);
    }
    obs_pool_destroy(pool);
    free(cost);
    free(owner);
    free(mask);
    truth_scene_destroy(ts);
    sss_scene_setup_free(&setup);
    rast_gbuffer_free(&gb);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
}

/* truth volume's split: the light volume's error computed by z slices under three masks that
 * partition the slices, and the MC image by tiles under three masks that partition the tiles, put
 * together give truth_volume_light_error's and truth_volume_mc_render's values bit for bit, and
 * the tiles' stats add up to the whole render's. */
TEST(scale_truth_volume_slice_and_task_partition_equals_whole_render)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    vol_tf tf;
    CHECK_OK(vol_synth(ctx, "bucky", 16, &g), ctx);
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.direction[0] = 0.48, L.direction[1] = -0.6, L.direction[2] = 0.64;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    vol_lv_params lp = vol_lv_params_default();
    vol_light_volume lv;
    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &lp, &lv), ctx);
    truth_volume_params tp = truth_volume_params_default();
    float *T = NULL, *err = NULL;
    truth_volume_error_stats es, es2;
    CHECK_OK(truth_volume_light_error(ctx, pool, &g, &tf, &L, &tp, &lv, &T, &err, &es), ctx);
    const size_t vox = (size_t)lv.nx * lv.ny * lv.nz;
    float *T2 = (float *)calloc(vox, sizeof(float)), *e2 = (float *)calloc(vox, sizeof(float));
    unsigned char *mask = (unsigned char *)malloc((size_t)lv.nz);
    for (int part = 0; part < 3; part++) {
        for (int k = 0; k < lv.nz; k++)
            mask[k] = (unsigned char)(k % 3 == part);
        CHECK_OK(truth_volume_light_error_slices(ctx, pool, &g, &tf, &L, &tp, &lv, mask, T2, e2), ctx);
    }
    CHECK(!memcmp(T, T2, vox * sizeof(float)));
    CHECK(!memcmp(err, e2, vox * sizeof(float)));
    truth_volume_error_stats_compute(e2, (int64_t)vox, &es2);
    CHECK(!memcmp(&es, &es2, sizeof es));
    CHECK_EQ_INT(truth_volume_light_error_slices(ctx, pool, &g, &tf, &L, &tp, &lv, mask, NULL, e2),
                 OBS_STATUS_INVALID_ARGUMENT);

    const int W = 21, H = 13;
    obs_camera cam = obs_camera_look_at(obs_v3(0.5f, 0.4f, 3.0f), obs_v3(0.5f, 0.5f, 0.5f), obs_v3(0, 1, 0), 0.7f, 0.5f,
                                        6.0f);
    cam.aspect = (float)W / (float)H;
    truth_volume_mc_params p = truth_volume_mc_params_default();
    p.samples = 16;
    p.replicates = 4;
    p.tile = 4;
    truth_volume_image whole, part[3];
    CHECK_OK(truth_volume_mc_render(ctx, pool, &g, &tf, &L, &cam, W, H, &p, &whole), ctx);
    const int64_t nt = truth_volume_mc_task_count(W, H, p.tile);
    CHECK_EQ_INT(nt, 6 * 4);
    CHECK_EQ_INT(truth_volume_mc_task_count(W, H, 0), 0);
    unsigned char *tm = (unsigned char *)malloc((size_t)nt);
    uint64_t tent = 0, coll = 0;
    int64_t hit = 0;
    for (int q = 0; q < 3; q++) {
        for (int64_t t = 0; t < nt; t++)
            tm[t] = (unsigned char)(t % 3 == q);
        CHECK_OK(truth_volume_mc_render_tasks(ctx, pool, &g, &tf, &L, &cam, W, H, &p, tm, &part[q]), ctx);
        tent += part[q].stats.tentative;
        coll += part[q].stats.collisions;
        hit += part[q].stats.pixels_hit;
    }
    int same = 1;
    for (int64_t t = 0; t < nt; t++) {
        int x0, y0, x1, y1;
        truth_volume_mc_task_rect(W, H, p.tile, t, &x0, &y0, &x1, &y1);
        const truth_volume_image *pi = &part[t % 3];
        for (int c = 0; c < 4; c++)
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++) {
                    same &= obs_image_f32_row(&pi->rgba[c], y)[x] == obs_image_f32_row(&whole.rgba[c], y)[x];
                    same &= obs_image_f32_row(&pi->std_error[c], y)[x] == obs_image_f32_row(&whole.std_error[c], y)[x];
                    /* another part's pixel reads 0 */
                    same &= obs_image_f32_row(&part[(t + 1) % 3].rgba[c], y)[x] == 0.0f;
                }
    }
    CHECK(same);
    CHECK(tent == whole.stats.tentative);
    CHECK(coll == whole.stats.collisions);
    CHECK_EQ_INT(hit, whole.stats.pixels_hit);
    CHECK(whole.stats.pixels_hit > 0);
    for (int q = 0; q < 3; q++)
        truth_volume_image_free(&part[q]);
    truth_volume_image_free(&whole);
    free(tm);
    free(mask);
    free(T2);
    free(e2);
    obs_aligned_free(T);
    obs_aligned_free(err);
    vol_light_volume_free(&lv);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* ---- MPI runs ----------------------------------------------------------------------------------- */

#define SKIP_CODE 77

/* A sidecar without its timings and its "scale" object (what differs between runs). */
static char *sidecar_without_timings(const char *path)
{
    char *s = test_slurp(path, NULL);
    if (!s)
        return NULL;
    char *out = (char *)malloc(strlen(s) + 1), *o = out;
    int in_scale = 0;
    for (char *line = s; *line;) {
        char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line + 1) : strlen(line);
        int keep = 1;
        if (!strncmp(line, "  \"scale\": {", 12))
            in_scale = 1;
        if (in_scale) {
            keep = 0;
            if (!strncmp(line, "  },", 4) || !strncmp(line, "  }\n", 4))
                in_scale = 0;
        }
        char saved = line[len - (end ? 1 : 0)];
        line[len - (end ? 1 : 0)] = 0;
        if (strstr(line, "\"seconds") || strstr(line, "\"mrays_per_second"))
            keep = 0;
        line[len - (end ? 1 : 0)] = saved;
        if (keep) {
            memcpy(o, line, len);
            o += len;
        }
        line += len;
    }
    *o = 0;
    free(s);
    return out;
}

static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    char *x = test_slurp(a, &na), *y = test_slurp(b, &nb);
    int same = x && y && na == nb && !memcmp(x, y, na);
    if (!same)
        fprintf(stderr, "%s and %s differ (%zu and %zu bytes)\n", a, b, na, nb);
    free(x);
    free(y);
    return same;
}

#ifdef OBS_TEST_MPIEXEC
/* mpiexec -np N [flags] obscura --threads 1 truth ao ... -o <dir>/x/t, run from the test. The flags
 * are what a container needs (docs/scale.md, "Running on one machine"): root allowed, more ranks
 * than cores, no binding (ranks share the 2 cores). */
static int run_mpi_args(int np, const char *const *cmd, const char *tag)
{
    char npb[16];
    snprintf(npb, sizeof npb, "%d", np);
    const char *args[64] = {"--allow-run-as-root", "--oversubscribe", "--bind-to", "none", "-np", npb, OBS_CLI_PATH};
    int na = 7;
    for (int i = 0; cmd[i] && na < 63; i++)
        args[na++] = cmd[i];
    args[na] = NULL;
    /* OpenMPI's libraries (not instrumented) keep allocations at exit that LeakSanitizer would
     * report in every rank of a sanitizer build: leak checks off for the ranks (obscura's own
     * leaks are checked by the plain runs of every other test). */
    const char *asan = getenv("ASAN_OPTIONS");
    if (asan && !strstr(asan, "detect_leaks=0")) {
        char *opts = (char *)malloc(strlen(asan) + 32);
        sprintf(opts, "%s:detect_leaks=0", asan);
        setenv("ASAN_OPTIONS", opts, 1);
        free(opts);
    }
    char out[8400], err[8400];
    snprintf(out, sizeof out, "%s/%s.stdout", test_tmpdir(), tag);
    snprintf(err, sizeof err, "%s/%s.stderr", test_tmpdir(), tag);
    return test_spawn(OBS_TEST_MPIEXEC, args, out, err);
}

static int run_mpi(int np, const char *out_prefix, const char *tag)
{
    const char *cmd[] = {"--quiet", "--threads", "1", "truth", "ao", test_path(test_data_dir(), "bunny.glb"),
                         "--size", "48x32", "--max-samples", "128", "-o", out_prefix, NULL};
    return run_mpi_args(np, cmd, tag);
}

/* cmd, writing to the prefix DIR/x/t, run plainly, then under mpiexec over 1, 2 and 3 ranks: each
 * file t<ext> (ext ends at NULL) and the sidecar, timings and "scale" aside, equal the plain run's,
 * and the sidecar holds each of keys. With fault: a failing rank fails the job, named by rank 0,
 * and nothing is written. */
static void check_ranks_give_the_plain_bytes(const char **cmd, const char *const *ext, const char *const *keys,
                                             int fault)
{
    const char *dir = test_tmpdir();
    char prefix[8400], plain[8400], from[8400], to[8400];
    snprintf(prefix, sizeof prefix, "%s/x/t", dir);
    snprintf(plain, sizeof plain, "%s/plain", dir);
    snprintf(from, sizeof from, "%s/x", dir);
    CHECK_EQ_INT(test_cli_run(cmd, "plain"), 0);
    CHECK(rename(from, plain) == 0);
    for (int np = 1; np <= 3; np++) {
        char tag[16];
        snprintf(tag, sizeof tag, "np%d", np);
        int rc = run_mpi_args(np, cmd, tag);
        if (rc != 0) {
            char e[8400];
            snprintf(e, sizeof e, "%s/%s.stderr", dir, tag);
            char *b = test_slurp(e, NULL);
            fprintf(stderr, "mpiexec -np %d: exit %d: %s\n", np, rc, b ? b : "");
            free(b);
        }
        CHECK_EQ_INT(rc, 0);
        for (int k = 0; ext[k]; k++) {
            char a[8600], b[8600];
            snprintf(a, sizeof a, "%s/t%s", plain, ext[k]);
            snprintf(b, sizeof b, "%s%s", prefix, ext[k]);
            CHECK_MSG(same_file(a, b), "-np %d: %s differs from the plain run's", np, ext[k]);
        }
        char a[8600], b[8600];
        snprintf(a, sizeof a, "%s/t.json", plain);
        snprintf(b, sizeof b, "%s.json", prefix);
        char *ja = sidecar_without_timings(a), *jb = sidecar_without_timings(b), *full = test_slurp(b, NULL);
        CHECK(ja && jb && full);
        CHECK_MSG(!strcmp(ja, jb), "-np %d: the sidecars differ beyond timings:\n%s\n---\n%s", np, ja, jb);
        for (int k = 0; keys[k]; k++)
            CHECK_MSG(strstr(full, keys[k]) != NULL, "-np %d: the sidecar lacks %s", np, keys[k]);
        free(ja);
        free(jb);
        free(full);
        snprintf(to, sizeof to, "%s/np%d", dir, np);
        CHECK(rename(from, to) == 0);
    }
    if (!fault)
        return;
    /* a failing rank fails the job, named by rank 0, and nothing is written */
    setenv("OBS_SCALE_FAULT", "fail:1", 1);
    int rc = run_mpi_args(2, cmd, "failed");
    unsetenv("OBS_SCALE_FAULT");
    CHECK_EQ_INT(rc, 6);
    CHECK(test_cli_stderr_has("failed", "rank 1 of 2 failed: injected failure"));
    struct stat sb;
    CHECK_MSG(stat(from, &sb) != 0, "the failed job left %s", from);
}
#endif

TEST(scale_mpi_truth_ao_any_rank_count_gives_the_plain_bytes)
{
#ifndef OBS_TEST_MPIEXEC
    fprintf(stderr, "skipped: a build without MPI (OBS_WITH_MPI off)\n");
    exit(SKIP_CODE);
#else
    char prefix[8400];
    snprintf(prefix, sizeof prefix, "%s/x/t", test_tmpdir());
    const char *args[] = {"--quiet", "--threads", "1", "truth", "ao", test_path(test_data_dir(), "bunny.glb"), "--size",
                          "48x32", "--max-samples", "128", "-o", prefix, NULL};
    const char *ext[] = {".exr", ".png", NULL}, *keys[] = {"\"imbalance_rays\"", NULL};
    check_ranks_give_the_plain_bytes(args, ext, keys, 0);
#endif
}

/* truth sss over 1, 2 and 3 ranks: both references (brute force and random walk), tiny and few
 * samples; the EXR, both PNGs and the sidecar (timings and "scale" aside) equal the plain run's. */
TEST(scale_mpi_truth_sss_any_rank_count_gives_the_plain_bytes)
{
#ifndef OBS_TEST_MPIEXEC
    fprintf(stderr, "skipped: a build without MPI (OBS_WITH_MPI off)\n");
    exit(SKIP_CODE);
#else
    char prefix[8400];
    snprintf(prefix, sizeof prefix, "%s/x/t", test_tmpdir());
    const char *cmd[] = {"--quiet", "--threads", "1", "truth", "sss", test_path(test_data_dir(), "sphere_potato.glb"),
                         "--size", "20x15", "--min-samples", "256", "--max-samples", "256", "--batch", "256",
                         "-o", prefix, NULL};
    const char *ext[] = {".exr", "_brute.png", "_walk.png", NULL};
    const char *keys[] = {"\"imbalance_rays\"", "translucent surface pixels", NULL};
    check_ranks_give_the_plain_bytes(cmd, ext, keys, 1);
#endif
}

TEST(scale_mpi_killed_or_failing_rank_fails_the_job_without_output)
{
#ifndef OBS_TEST_MPIEXEC
    fprintf(stderr, "skipped: a build without MPI (OBS_WITH_MPI off)\n");
    exit(SKIP_CODE);
#else
    const char *dir = test_tmpdir();
    char prefix[8400], d[8400];
    struct stat sb;
    /* a rank killed (SIGKILL) after its tiles, before the gather: mpirun ends the job */
    snprintf(prefix, sizeof prefix, "%s/killed/t", dir);
    setenv("OBS_SCALE_FAULT", "kill:1", 1);
    int rc = run_mpi(3, prefix, "killed");
    CHECK(rc != 0);
    snprintf(d, sizeof d, "%s/killed", dir);
    CHECK_MSG(stat(d, &sb) != 0, "the killed job left %s", d);
    /* a rank whose work fails: every rank hears it, rank 0 names it, nothing is written */
    snprintf(prefix, sizeof prefix, "%s/failed/t", dir);
    setenv("OBS_SCALE_FAULT", "fail:2", 1);
    rc = run_mpi(3, prefix, "failed");
    unsetenv("OBS_SCALE_FAULT");
    CHECK_EQ_INT(rc, 6); /* CLI_EXIT_INTERNAL: the injected failure's status */
    CHECK(test_cli_stderr_has("failed", "rank 2 of 3 failed: injected failure"));
    snprintf(d, sizeof d, "%s/failed", dir);
    CHECK_MSG(stat(d, &sb) != 0, "the failed job left %s", d);
#endif
}

TEST(scale_mpi_launcher_is_detected_from_the_environment)
{
    unsetenv("OMPI_COMM_WORLD_SIZE");
    unsetenv("PMIX_RANK");
    unsetenv("PMI_SIZE");
    unsetenv("OBS_NO_MPI");
    CHECK(!scale_mpi_launched());
    setenv("OMPI_COMM_WORLD_SIZE", "2", 1);
    CHECK(scale_mpi_launched());
    setenv("OBS_NO_MPI", "1", 1);
    CHECK(!scale_mpi_launched());
    unsetenv("OBS_NO_MPI");
    unsetenv("OMPI_COMM_WORLD_SIZE");
    setenv("PMI_SIZE", "2", 1);
    CHECK(scale_mpi_launched());
    unsetenv("PMI_SIZE");
}

/* A build without MPI, started by a launcher, says so and fails (the stub adapter). */
TEST(scale_mpi_not_built_is_reported_under_a_launcher)
{
#ifdef OBS_WITH_MPI
    fprintf(stderr, "skipped: this build has MPI\n");
    exit(SKIP_CODE);
#else
    CHECK(!scale_mpi_built());
    setenv("OMPI_COMM_WORLD_SIZE", "2", 1);
    char prefix[8400];
    snprintf(prefix, sizeof prefix, "%s/t", test_tmpdir());
    const char *args[] = {"truth", "ao", test_path(test_data_dir(), "bunny.glb"), "--size", "16x12", "-o", prefix, NULL};
    int rc = test_cli_run(args, "nompi");
    unsetenv("OMPI_COMM_WORLD_SIZE");
    CHECK_EQ_INT(rc, 2);
    CHECK(test_cli_stderr_has("nompi", "MPI support is not built"));
#endif
}

/* truth volume does not split over ranks yet: under a launcher it refuses to start (truth ao
 * and truth sss split, scale_mpi_truth_*_any_rank_count_gives_the_plain_bytes). */
/* truth volume over 1, 2 and 3 ranks: the light volume's exact transmittance (z slices) and the
 * MC image (tiles), tiny and few samples; both NRRDs, the EXR and the sidecar (timings and "scale"
 * aside) equal the plain run's; a failing rank fails the job and nothing is written. */
TEST(scale_mpi_truth_volume_any_rank_count_gives_the_plain_bytes)
{
#ifndef OBS_TEST_MPIEXEC
    fprintf(stderr, "skipped: a build without MPI (OBS_WITH_MPI off)\n");
    exit(SKIP_CODE);
#else
    char prefix[8400];
    snprintf(prefix, sizeof prefix, "%s/x/t", test_tmpdir());
    const char *cmd[] = {"--quiet", "--threads", "1", "truth", "volume", "synth:bucky:16", "--image", "--size", "24x16",
                         "--samples", "16", "--replicates", "4", "-o", prefix, NULL};
    const char *ext[] = {"_T.nrrd", "_err.nrrd", "_mc.exr", NULL};
    const char *keys[] = {"\"imbalance_seconds_slices\"", "\"imbalance_collisions\"", NULL};
    check_ranks_give_the_plain_bytes(cmd, ext, keys, 1);
#endif
}
