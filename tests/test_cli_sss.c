/* test_cli_sss.c: `obscura sss` end to end: its files, the materials from the scene or the
 * command line, refusals that name the problem and write nothing, determinism across threads. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int sss_exists(const char *dir, const char *name)
{
    struct stat st;
    return stat(test_path(dir, name), &st) == 0;
}

static const char *sss_scene(const char *name) { return test_path(test_data_dir(), name); }

/* The small settings every run here uses: seconds even under the sanitizers. */
#define SSS_SMALL "--size", "96x72", "--K", "4", "--N", "8", "--map-size", "64", "--light-map-size", "64"

TEST(cli_sss_writes_image_maps_and_sidecar_from_the_scene_materials)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/out/sphere", test_tmpdir());
    const char *a[] = {"sss", sss_scene("sphere_potato.glb"), SSS_SMALL, "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a, "run"), 0);
    const char *dir = test_path(test_tmpdir(), "out");
    CHECK(sss_exists(dir, "sphere.exr"));
    CHECK(sss_exists(dir, "sphere.png"));
    CHECK(sss_exists(dir, "sphere_maps.exr"));
    CHECK(sss_exists(dir, "sphere.json"));
    obs_context *ctx = obs_context_create();
    io_image im;
    memset(&im, 0, sizeof im);
    CHECK_EQ_INT(io_image_read(ctx, test_path(dir, "sphere.exr"), &im), OBS_STATUS_OK);
    int r = io_image_find_channel(&im, "R"), z = io_image_find_channel(&im, "Z");
    CHECK(r >= 0 && z >= 0);
    if (r >= 0 && z >= 0) {
        /* The lit sphere glows: radiance is finite, >= 0, and positive somewhere on it. */
        int64_t surf = 0, lit = 0, bad = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                float v = obs_image_f32_row(&im.f32[r], y)[x], d = obs_image_f32_row(&im.f32[z], y)[x];
                if (!isfinite(v) || v < 0.0f)
                    bad++;
                if (isfinite(d)) {
                    surf++;
                    lit += v > 0.0f;
                }
            }
        CHECK_EQ_INT(bad, 0);
        CHECK(surf > 500);
        CHECK(lit > surf / 4);
    }
    io_image_free(&im);
    /* The maps: 4 layers of R, G, B, Z. */
    CHECK_EQ_INT(io_image_read(ctx, test_path(dir, "sphere_maps.exr"), &im), OBS_STATUS_OK);
    CHECK(io_image_find_channel(&im, "k00.R") >= 0);
    CHECK(io_image_find_channel(&im, "k03.Z") >= 0);
    CHECK(io_image_find_channel(&im, "k04.R") < 0);
    io_image_free(&im);
    char *js = test_slurp(test_path(dir, "sphere.json"), NULL);
    CHECK(js && strstr(js, "\"Potato\"") && strstr(js, "seconds_maps") && strstr(js, "bssrdf_evaluations"));
    free(js);
    obs_context_destroy(ctx);
}

TEST(cli_sss_bytes_identical_for_1_2_and_8_threads)
{
    const char *threads[3] = {"1", "2", "8"};
    char prefix[3][4200];
    for (int t = 0; t < 3; t++) {
        snprintf(prefix[t], sizeof prefix[t], "%s/t%s", test_tmpdir(), threads[t]);
        const char *a[] = {"--threads", threads[t], "sss", sss_scene("bunny.glb"), "--material", "cream",
                           "--scale-mm", "150", SSS_SMALL, "-o", prefix[t], NULL};
        CHECK_EQ_INT(test_cli_run(a, threads[t]), 0);
    }
    const char *suffix[2] = {".exr", "_maps.exr"};
    for (int s = 0; s < 2; s++) {
        size_t l0 = 0, l1 = 0;
        char p0[4300], p1[4300];
        snprintf(p0, sizeof p0, "%s%s", prefix[0], suffix[s]);
        char *b0 = test_slurp(p0, &l0);
        CHECK(b0 != NULL);
        for (int t = 1; t < 3; t++) {
            snprintf(p1, sizeof p1, "%s%s", prefix[t], suffix[s]);
            char *b1 = test_slurp(p1, &l1);
            CHECK(b1 && b0 && l0 == l1 && memcmp(b0, b1, l0) == 0);
            free(b1);
        }
        free(b0);
    }
}

TEST(cli_sss_bad_materials_and_params_are_refused_and_write_nothing)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/never", test_tmpdir());
    /* An unknown preset: usage error, the message lists the presets. */
    const char *a1[] = {"sss", sss_scene("bunny.glb"), "--material", "jelly", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a1, "a1"), 2);
    CHECK(test_cli_stderr_has("a1", "jelly") && test_cli_stderr_has("a1", "Cream"));
    /* Negative and non-finite coefficients, eta <= 0. */
    const char *a2[] = {"sss", sss_scene("bunny.glb"), "--sigma-s-prime", "1,-2,1", "--sigma-a", "0.1,0.1,0.1",
                        "--eta", "1.3", "-o", prefix, NULL};
    CHECK(test_cli_run(a2, "a2") != 0);
    CHECK(test_cli_stderr_has("a2", "sigma"));
    const char *a3[] = {"sss", sss_scene("bunny.glb"), "--sigma-s-prime", "1,1,1", "--sigma-a", "0.1,nan,0.1",
                        "--eta", "1.3", "-o", prefix, NULL};
    CHECK(test_cli_run(a3, "a3") != 0);
    const char *a4[] = {"sss", sss_scene("bunny.glb"), "--sigma-s-prime", "1,1,1", "--sigma-a", "0.1,0.1,0.1",
                        "--eta", "0", "-o", prefix, NULL};
    CHECK(test_cli_run(a4, "a4") != 0);
    CHECK(test_cli_stderr_has("a4", "eta"));
    /* Parameters out of range. */
    const char *a5[] = {"sss", sss_scene("sphere_potato.glb"), "--K", "0", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a5, "a5"), 2);
    const char *a6[] = {"sss", sss_scene("sphere_potato.glb"), "--gamma", "0", "-o", prefix, NULL};
    CHECK(test_cli_run(a6, "a6") != 0);
    CHECK(test_cli_stderr_has("a6", "gamma"));
    /* A scene without a translucent material, and no --material: refused, naming the file. */
    const char *a7[] = {"sss", sss_scene("bunny.glb"), "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a7, "a7"), 3);
    CHECK(test_cli_stderr_has("a7", "bunny.glb") && test_cli_stderr_has("a7", "--material"));
    /* Two material sources at once. */
    const char *a8[] = {"sss", sss_scene("sphere_potato.glb"), "--material", "cream", "--from-scene", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a8, "a8"), 2);
    CHECK(!sss_exists(test_tmpdir(), "never.exr"));
    CHECK(!sss_exists(test_tmpdir(), "never.json"));
    CHECK(!sss_exists(test_tmpdir(), "never_maps.exr"));
}

TEST(cli_truth_sss_writes_both_references_and_refuses_an_open_mesh_for_the_walk)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/ref", test_tmpdir());
    const char *a[] = {"truth", "sss", sss_scene("sphere_potato.glb"), "--size", "24x18", "--min-samples", "512",
                       "--max-samples", "1024", "--batch", "512", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a, "ref"), 0);
    CHECK(sss_exists(test_tmpdir(), "ref.exr"));
    CHECK(sss_exists(test_tmpdir(), "ref_brute.png"));
    CHECK(sss_exists(test_tmpdir(), "ref_walk.png"));
    CHECK(sss_exists(test_tmpdir(), "ref.json"));
    obs_context *ctx = obs_context_create();
    io_image im;
    memset(&im, 0, sizeof im);
    CHECK_EQ_INT(io_image_read(ctx, test_path(test_tmpdir(), "ref.exr"), &im), OBS_STATUS_OK);
    static const char *need[] = {"brute.R", "brute.stderr.B", "brute.count", "walk.G", "walk.stderr.R", "walk.count", "Z"};
    for (size_t k = 0; k < sizeof need / sizeof need[0]; k++)
        CHECK(io_image_find_channel(&im, need[k]) >= 0);
    /* Both references see the same pixels, and light reaches some of them. */
    int bc = io_image_find_channel(&im, "brute.count"), wc = io_image_find_channel(&im, "walk.count");
    int br = io_image_find_channel(&im, "brute.R");
    if (bc >= 0 && wc >= 0 && br >= 0) {
        int64_t same = 0, lit = 0, n = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                const float b = obs_image_f32_row(&im.f32[bc], y)[x], w = obs_image_f32_row(&im.f32[wc], y)[x];
                same += (b > 0) == (w > 0);
                n += b > 0;
                lit += obs_image_f32_row(&im.f32[br], y)[x] > 0.0f;
            }
        CHECK_EQ_INT(same, (int64_t)im.width * im.height);
        CHECK(n > 50 && lit > n / 4);
    }
    io_image_free(&im);
    obs_context_destroy(ctx);
    /* dragon.glb has open edges: the random walk refuses it, naming the mesh; nothing is written. */
    snprintf(prefix, sizeof prefix, "%s/open", test_tmpdir());
    const char *b[] = {"truth", "sss", sss_scene("dragon.glb"), "--material", "skin1", "--reference", "random-walk",
                       "--size", "16x12", "-o", prefix, NULL};
    CHECK(test_cli_run(b, "open") != 0);
    CHECK(test_cli_stderr_has("open", "dragon") && test_cli_stderr_has("open", "closed"));
    CHECK(!sss_exists(test_tmpdir(), "open.exr"));
    CHECK(!sss_exists(test_tmpdir(), "open.json"));
}
