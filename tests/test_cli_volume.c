/* test_cli_volume.c: `obscura volume` and `obscura truth volume` end to end: their files, a lit
 * synthetic volume, refusals that name the problem and write nothing. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int vol_exists(const char *name)
{
    struct stat st;
    return stat(test_path(test_tmpdir(), name), &st) == 0;
}

TEST(cli_volume_ray_casts_a_lit_synthetic_volume_and_writes_its_files)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/bucky", test_tmpdir());
    const char *a[] = {"volume", "synth:bucky:24", "--size", "80x60", "--write-light-volume", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a, "run"), 0);
    CHECK(vol_exists("bucky.exr") && vol_exists("bucky.png") && vol_exists("bucky.json") && vol_exists("bucky_l.nrrd"));
    obs_context *ctx = obs_context_create();
    io_image im;
    memset(&im, 0, sizeof im);
    CHECK_EQ_INT(io_image_read(ctx, test_path(test_tmpdir(), "bucky.exr"), &im), OBS_STATUS_OK);
    int ca = io_image_find_channel(&im, "A"), cr = io_image_find_channel(&im, "R");
    CHECK(ca >= 0 && cr >= 0);
    if (ca >= 0 && cr >= 0) {
        int64_t covered = 0, bad = 0;
        for (int y = 0; y < im.height; y++)
            for (int x = 0; x < im.width; x++) {
                const float al = obs_image_f32_row(&im.f32[ca], y)[x], r = obs_image_f32_row(&im.f32[cr], y)[x];
                bad += !(al >= 0.0f && al <= 1.0f + 1e-6f) || !(r >= 0.0f && r <= al + 1e-5f);
                covered += al > 0.01f;
            }
        CHECK_EQ_INT(bad, 0);          /* premultiplied: 0 <= R <= A <= 1 */
        CHECK(covered > 200);
    }
    io_image_free(&im);
    obs_context_destroy(ctx);
    char *js = test_slurp(test_path(test_tmpdir(), "bucky.json"), NULL);
    CHECK(js && strstr(js, "\"lightvolume\"") && strstr(js, "face0"));
    free(js);
}

TEST(cli_truth_volume_writes_the_exact_transmittance_and_the_error)
{
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/tv", test_tmpdir());
    const char *a[] = {"truth", "volume", "synth:sphere:20", "--light-dir", "0,0,-1", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a, "tv"), 0);
    CHECK(vol_exists("tv_T.nrrd") && vol_exists("tv_err.nrrd") && vol_exists("tv.json"));
    char *js = test_slurp(test_path(test_tmpdir(), "tv.json"), NULL);
    CHECK(js && strstr(js, "light_volume_error") && strstr(js, "max_abs"));
    free(js);
}

TEST(cli_volume_bad_inputs_are_refused_naming_the_problem_and_write_nothing)
{
    char prefix[4200], path[4200];
    snprintf(prefix, sizeof prefix, "%s/never", test_tmpdir());
    /* a truncated NRRD: the header promises more samples than the file holds */
    snprintf(path, sizeof path, "%s/short.nrrd", test_tmpdir());
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs("NRRD0004\ntype: float\ndimension: 3\nsizes: 8 8 8\nencoding: raw\nendian: little\n\n", f);
        float v[10] = {0};
        fwrite(v, sizeof v[0], 10, f);
        fclose(f);
    }
    const char *a1[] = {"volume", path, "-o", prefix, NULL};
    CHECK(test_cli_run(a1, "a1") != 0);
    CHECK(test_cli_stderr_has("a1", "short.nrrd"));
    const char *a2[] = {"volume", "synth:bucky:16", "--tf", "glass", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a2, "a2"), 2);
    CHECK(test_cli_stderr_has("a2", "glass"));
    const char *a3[] = {"volume", "synth:teapot", "-o", prefix, NULL};
    CHECK(test_cli_run(a3, "a3") != 0);
    CHECK(test_cli_stderr_has("a3", "teapot"));
    const char *a4[] = {"volume", "synth:bucky:16", "--lv-scale", "3", "-o", prefix, NULL};
    CHECK(test_cli_run(a4, "a4") != 0);
    const char *a5[] = {"volume", "synth:bucky:16", "--raw", "8x8:u8", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a5, "a5"), 2);
    const char *a6[] = {"volume", "synth:bucky:16", "--mode", "xray", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a6, "a6"), 2);
    CHECK(!vol_exists("never.exr") && !vol_exists("never.png") && !vol_exists("never.json"));
}

/* --eye-pass (docs/volume/light.md, "Eye pass"): the eye volume modulates the chromaticity before
 * ray casting, so the image changes; the sidecar says so; other modes refuse the flag. */
TEST(cli_volume_eye_pass_modulates_the_image_and_is_recorded)
{
    char p0[4200], p1[4200];
    snprintf(p0, sizeof p0, "%s/eye0", test_tmpdir());
    snprintf(p1, sizeof p1, "%s/eye1", test_tmpdir());
    const char *a0[] = {"volume", "synth:bucky:24", "--size", "64x48", "--light-dir", "0.3,-1,0.2", "-o", p0, NULL};
    const char *a1[] = {"volume", "synth:bucky:24", "--size", "64x48", "--light-dir", "0.3,-1,0.2", "--eye-pass",
                        "-o", p1, NULL};
    CHECK_EQ_INT(test_cli_run(a0, "eye0"), 0);
    CHECK_EQ_INT(test_cli_run(a1, "eye1"), 0);
    char *js = test_slurp(test_path(test_tmpdir(), "eye1.json"), NULL);
    CHECK(js && strstr(js, "\"eye_pass\": true") && strstr(js, "eye_face0"));
    free(js);
    js = test_slurp(test_path(test_tmpdir(), "eye0.json"), NULL);
    CHECK(js && strstr(js, "\"eye_pass\": false") && !strstr(js, "eye_face0"));
    free(js);
    obs_context *ctx = obs_context_create();
    io_image im0, im1;
    memset(&im0, 0, sizeof im0);
    memset(&im1, 0, sizeof im1);
    CHECK_EQ_INT(io_image_read(ctx, test_path(test_tmpdir(), "eye0.exr"), &im0), OBS_STATUS_OK);
    CHECK_EQ_INT(io_image_read(ctx, test_path(test_tmpdir(), "eye1.exr"), &im1), OBS_STATUS_OK);
    int r0 = io_image_find_channel(&im0, "R"), r1 = io_image_find_channel(&im1, "R");
    int a0c = io_image_find_channel(&im0, "A"), a1c = io_image_find_channel(&im1, "A");
    CHECK(r0 >= 0 && r1 >= 0 && a0c >= 0 && a1c >= 0);
    if (r0 >= 0 && r1 >= 0 && a0c >= 0 && a1c >= 0 && im0.width == im1.width && im0.height == im1.height) {
        int changed = 0, brighter = 0, alpha_diff = 0;
        for (int y = 0; y < im0.height; y++)
            for (int x = 0; x < im0.width; x++) {
                float v0 = obs_image_f32_row(&im0.f32[r0], y)[x], v1 = obs_image_f32_row(&im1.f32[r1], y)[x];
                changed += fabsf(v0 - v1) > 1e-4f;
                brighter += v1 > v0 + 1e-6f;  /* c_eye <= 1: modulation only darkens */
                alpha_diff += obs_image_f32_row(&im0.f32[a0c], y)[x] != obs_image_f32_row(&im1.f32[a1c], y)[x];
            }
        CHECK(changed > 50);
        CHECK_EQ_INT(brighter, 0);
        CHECK_EQ_INT(alpha_diff, 0); /* opacity does not depend on the lighting */
    }
    io_image_free(&im0);
    io_image_free(&im1);
    obs_context_destroy(ctx);
    char prefix[4200];
    snprintf(prefix, sizeof prefix, "%s/never_eye", test_tmpdir());
    const char *a2[] = {"volume", "synth:bucky:16", "--mode", "phong", "--eye-pass", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a2, "eye2"), 2);
    CHECK(test_cli_stderr_has("eye2", "--eye-pass"));
    const char *a3[] = {"truth", "volume", "synth:bucky:16", "--eye-pass", "-o", prefix, NULL};
    CHECK_EQ_INT(test_cli_run(a3, "eye3"), 2);
    CHECK(!vol_exists("never_eye.exr") && !vol_exists("never_eye.json"));
}

/* --reps N: N warm ray casts through the prepared handle after the first; the image is the same
 * bytes as without it, and the sidecar records the count and the warm median. */
TEST(cli_volume_reps_times_warm_casts_and_keeps_the_image)
{
    char p1[4200], p2[4200];
    snprintf(p1, sizeof p1, "%s/once", test_tmpdir());
    snprintf(p2, sizeof p2, "%s/reps", test_tmpdir());
    const char *a[] = {"volume", "synth:bucky:24", "--size", "64x48", "--mode", "phong", "-o", p1, NULL};
    const char *b[] = {"volume", "synth:bucky:24", "--size", "64x48", "--mode", "phong", "--reps", "3", "-o", p2, NULL};
    CHECK_EQ_INT(test_cli_run(a, "once"), 0);
    CHECK_EQ_INT(test_cli_run(b, "reps"), 0);
    size_t la = 0, lb = 0;
    char *ea = test_slurp(test_path(test_tmpdir(), "once.exr"), &la), *eb = test_slurp(test_path(test_tmpdir(), "reps.exr"), &lb);
    CHECK(ea && eb && la == lb && la > 0 && memcmp(ea, eb, la) == 0);
    free(ea);
    free(eb);
    char *js = test_slurp(test_path(test_tmpdir(), "reps.json"), NULL);
    CHECK(js && strstr(js, "\"raycast_reps\": 3") && strstr(js, "seconds_raycast_warm"));
    free(js);
    const char *bad[] = {"volume", "synth:bucky:24", "--reps", "0", "-o", p2, NULL};
    CHECK_EQ_INT(test_cli_run(bad, "bad"), 2);
}
