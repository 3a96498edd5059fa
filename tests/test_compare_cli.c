/* test_compare_cli.c: `obscura compare` end to end: the built CLI (OBS_CLI_PATH) run on EXRs
 * written here, checking exit codes and messages. */
#include "core/obs.h"
#include "io/io.h"
#include "test.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>


/* ---- helpers ------------------------------------------------------------------------------ */

static char g_out[8192], g_err[8192];

static void slurp(const char *path, char *buf, size_t size)
{
    buf[0] = '\0';
    FILE *f = fopen(path, "rb");
    if (!f)
        return;
    size_t n = fread(buf, 1, size - 1, f);
    buf[n] = '\0';
    fclose(f);
}

/* Run `obscura compare ARGS...` (NULL-terminated), stdout and stderr captured into g_out and
 * g_err. Returns the exit status, or -1 when the process could not run or was killed. */
static int run_compare(const char *first, ...)
{
    const char *args[64];
    int n = 0;
    args[n++] = OBS_CLI_PATH;
    args[n++] = "compare";
    va_list ap;
    va_start(ap, first);
    for (const char *a = first; a && n < 63; a = va_arg(ap, const char *))
        args[n++] = a;
    va_end(ap);
    args[n] = NULL;
    char out_path[4200], err_path[4200];
    snprintf(out_path, sizeof out_path, "%s/stdout.txt", test_tmpdir());
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", test_tmpdir());
    int rc = test_spawn(OBS_CLI_PATH, args + 1, out_path, err_path);
    slurp(out_path, g_out, sizeof g_out);
    slurp(err_path, g_err, sizeof g_err);
    return rc;
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && st.st_size > 0;
}

/* Write an EXR with the given float planes (and an optional Z plane). */
static obs_status write_exr(obs_context *ctx, const char *path, const char **names, const obs_image_f32 *planes, int n)
{
    io_channel ch[8];
    for (int i = 0; i < n; i++) {
        ch[i].name = names[i];
        ch[i].type = IO_PIXEL_FLOAT;
        ch[i].f32 = &planes[i];
        ch[i].u32 = NULL;
    }
    return io_exr_write(ctx, path, ch, n, NULL, 0);
}

static void fill_ao(obs_image_f32 *im, uint64_t seed)
{
    for (int y = 0; y < im->height; y++)
        for (int x = 0; x < im->width; x++)
            obs_image_f32_row(im, y)[x] =
                (float)(0.6 + 0.3 * sin(0.3 * x) * cos(0.2 * y)) +
                0.05f * (obs_rng_float((uint64_t)(y * im->width + x), 0, 0, seed) - 0.5f);
}

#define W 40
#define H 30

/* ---- tests -------------------------------------------------------------------------------- */

TEST(compare_identical_files_exits_zero)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ao = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ao), ctx);
    fill_ao(&ao, 1);
    const char *names[1] = {"AO"};
    const char *a = test_path(test_tmpdir(), "a.exr");
    CHECK_OK(write_exr(ctx, a, names, &ao, 1), ctx);
    int rc = run_compare(a, a, "--max-rmse", "0", "--max-abs", "0", "--min-ssim", "1", "--max-bias", "0",
                         "--max-over-threshold", "0", "--min-psnr", "1000", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    CHECK_MSG(strstr(g_out, "AO") && strstr(g_out, "inf") && strstr(g_out, "all hold"), "stdout: %s", g_out);
    /* --quiet prints no table. */
    rc = run_compare(a, a, "--quiet", NULL);
    CHECK_EQ_INT(rc, 0);
    CHECK(g_out[0] == '\0');
    obs_image_f32_free(&ao);
    obs_context_destroy(ctx);
}

TEST(compare_threshold_violation_exits_one)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ra = {0}, tb = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ra), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &tb), ctx);
    fill_ao(&ra, 1);
    fill_ao(&tb, 1);
    for (int y = 10; y < 15; y++)
        for (int x = 10; x < 15; x++)
            obs_image_f32_row(&tb, y)[x] -= 0.2f;
    const char *names[1] = {"AO"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names, &ra, 1), ctx);
    CHECK_OK(write_exr(ctx, b, names, &tb, 1), ctx);
    int rc = run_compare(a, b, "--max-rmse", "0.01", "--max-abs", "0.5", NULL);
    CHECK_MSG(rc == 1, "exit %d, stderr: %s", rc, g_err);
    CHECK_MSG(strstr(g_err, "--max-rmse") && !strstr(g_err, "--max-abs"), "stderr: %s", g_err);
    /* Every violated threshold is listed. */
    rc = run_compare(a, b, "--max-rmse", "0.01", "--max-abs", "0.1", "--min-ssim", "0.999", "--max-bias", "0.001",
                     NULL);
    CHECK_EQ_INT(rc, 1);
    CHECK_MSG(strstr(g_err, "--max-rmse") && strstr(g_err, "--max-abs") && strstr(g_err, "--min-ssim") &&
                  strstr(g_err, "--max-bias"), "stderr: %s", g_err);
    /* Loose thresholds hold. */
    rc = run_compare(a, b, "--max-rmse", "0.1", "--max-abs", "0.25", "--max-over-threshold", "0.05", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    obs_image_f32_free(&ra);
    obs_image_f32_free(&tb);
    obs_context_destroy(ctx);
}

TEST(compare_size_mismatch_is_a_clear_error)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ra = {0}, tb = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ra), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 16, 12, &tb), ctx);
    const char *names[1] = {"AO"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names, &ra, 1), ctx);
    CHECK_OK(write_exr(ctx, b, names, &tb, 1), ctx);
    int rc = run_compare(a, b, NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "40x30") && strstr(g_err, "16x12") && strstr(g_err, "size"), "stderr: %s", g_err);
    obs_image_f32_free(&ra);
    obs_image_f32_free(&tb);
    obs_context_destroy(ctx);
}

TEST(compare_missing_channel_lists_available_channels)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 planes[2] = {{0}, {0}};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &planes[0]), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &planes[1]), ctx);
    obs_image_f32_fill(&planes[0], 0.5f);
    obs_image_f32_fill(&planes[1], 2.0f);
    const char *names_a[2] = {"AO.mean", "Z"}, *names_b[2] = {"AO", "Z"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names_a, planes, 2), ctx);
    CHECK_OK(write_exr(ctx, b, names_b, planes, 2), ctx);
    int rc = run_compare(a, b, "--channel", "AO", NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "'AO'") && strstr(g_err, "AO.mean") && strstr(g_err, "Z") && strstr(g_err, "a.exr"),
              "stderr: %s", g_err);
    rc = run_compare(a, b, "--channel-a", "AO.mean", "--channel-b", "AOx", NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "'AOx'") && strstr(g_err, "b.exr") && strstr(g_err, "channels are:") &&
                  (strstr(g_err, "AO, Z") || strstr(g_err, "Z, AO")), "stderr: %s", g_err);
    /* The right pairing works; the default compares the common channel (Z) only. */
    rc = run_compare(a, b, "--channel-a", "AO.mean", "--channel-b", "AO", "--max-abs", "0", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    CHECK(strstr(g_out, "AO.mean/AO") != NULL);
    rc = run_compare(a, b, NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    CHECK_MSG(strstr(g_out, "AO.mean") == NULL && strstr(g_out, "\nZ "), "stdout: %s", g_out);
    obs_image_f32_free(&planes[0]);
    obs_image_f32_free(&planes[1]);
    obs_context_destroy(ctx);
}

TEST(compare_nan_input_is_a_clear_error)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 pa[2] = {{0}, {0}}, pb[2] = {{0}, {0}};
    for (int i = 0; i < 2; i++) {
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &pa[i]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &pb[i]), ctx);
    }
    fill_ao(&pa[0], 1);
    fill_ao(&pb[0], 1);
    obs_image_f32_fill(&pa[1], 3.0f); /* Z */
    obs_image_f32_fill(&pb[1], 3.0f);
    obs_image_f32_row(&pb[0], 3)[5] = NAN;
    const char *names[2] = {"AO", "Z"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names, pa, 2), ctx);
    CHECK_OK(write_exr(ctx, b, names, pb, 2), ctx);
    int rc = run_compare(a, b, "--channel", "AO", NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "b.exr") && strstr(g_err, "'AO'") && strstr(g_err, "(5, 3)") && strstr(g_err, "nan"),
              "stderr: %s", g_err);
    /* --ignore-nonfinite skips and counts it. */
    rc = run_compare(a, b, "--channel", "AO", "--ignore-nonfinite", "--max-abs", "0", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    CHECK_MSG(strstr(g_out, "1 non-finite"), "stdout: %s", g_out);
    /* A NaN on the background (Z = inf in the G-buffer convention) is not an error. */
    obs_image_f32_row(&pb[1], 3)[5] = INFINITY;
    CHECK_OK(write_exr(ctx, b, names, pb, 2), ctx);
    rc = run_compare(a, b, "--channel", "AO", "--max-abs", "0", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    for (int i = 0; i < 2; i++) {
        obs_image_f32_free(&pa[i]);
        obs_image_f32_free(&pb[i]);
    }
    obs_context_destroy(ctx);
}

TEST(compare_missing_file_is_a_clear_error)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ao = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ao), ctx);
    const char *names[1] = {"AO"};
    const char *a = test_path(test_tmpdir(), "a.exr");
    CHECK_OK(write_exr(ctx, a, names, &ao, 1), ctx);
    const char *missing = test_path(test_tmpdir(), "does_not_exist.exr");
    int rc = run_compare(a, missing, NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "does_not_exist.exr"), "stderr: %s", g_err);
    rc = run_compare(missing, a, NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "does_not_exist.exr"), "stderr: %s", g_err);
    /* A missing mask file too. */
    rc = run_compare(a, a, "--mask", missing, NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "does_not_exist.exr"), "stderr: %s", g_err);
    obs_image_f32_free(&ao);
    obs_context_destroy(ctx);
}

TEST(compare_writes_json_and_heatmap)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 pa[2] = {{0}, {0}}, pb[2] = {{0}, {0}};
    for (int i = 0; i < 2; i++) {
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &pa[i]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &pb[i]), ctx);
    }
    fill_ao(&pa[0], 1);
    fill_ao(&pb[0], 2);
    obs_image_f32_fill(&pa[1], 3.0f);
    obs_image_f32_fill(&pb[1], 3.0f);
    for (int x = 0; x < W; x++) /* background row: grey in the heat map */
        obs_image_f32_row(&pa[1], 0)[x] = INFINITY;
    const char *names[2] = {"AO", "Z"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names, pa, 2), ctx);
    CHECK_OK(write_exr(ctx, b, names, pb, 2), ctx);
    char json[4200], heat[4200];
    snprintf(json, sizeof json, "%s/out/cmp.json", test_tmpdir());
    snprintf(heat, sizeof heat, "%s/out/heat.png", test_tmpdir());
    int rc = run_compare(a, b, "--channel", "AO", "--json", json, "--heatmap", heat, "--calibrated", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    CHECK(file_exists(json));
    CHECK(file_exists(heat));
    char buf[8192];
    slurp(json, buf, sizeof buf);
    CHECK_MSG(strstr(buf, "\"rmse\"") && strstr(buf, "\"ssim\"") && strstr(buf, "\"gain\"") &&
                  strstr(buf, "\"power\"") && strstr(buf, "\"valid_pixels\": 1160") && strstr(buf, "\"compare\""),
              "json: %s", buf);
    io_image im;
    CHECK_OK(io_image_read(ctx, heat, &im), ctx);
    CHECK_EQ_INT(im.width, W);
    CHECK_EQ_INT(im.height, H);
    CHECK(im.channel_count >= 3);
    /* Row 0 is invalid (grey, R = G = B); row 1 is coloured. */
    float r0 = obs_image_f32_row(&im.f32[0], 0)[3], g0 = obs_image_f32_row(&im.f32[1], 0)[3];
    float b0 = obs_image_f32_row(&im.f32[2], 0)[3];
    CHECK(r0 == g0 && g0 == b0 && r0 > 0.1f);
    io_image_free(&im);
    /* An output that cannot be written: exit 5. */
    char bad[4200];
    snprintf(bad, sizeof bad, "%s/a.exr/sub/cmp.json", test_tmpdir());
    rc = run_compare(a, b, "--channel", "AO", "--json", bad, NULL);
    CHECK_MSG(rc == 5, "exit %d, stderr: %s", rc, g_err);
    for (int i = 0; i < 2; i++) {
        obs_image_f32_free(&pa[i]);
        obs_image_f32_free(&pb[i]);
    }
    obs_context_destroy(ctx);
}

TEST(compare_calibrated_thresholds_apply_after_the_fit)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ra = {0}, tb = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ra), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &tb), ctx);
    fill_ao(&ra, 4);
    /* test = inverse of calibrated(v) = 1 - 1.5 (1 - v^2) */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double r = obs_image_f32_row(&ra, y)[x];
            obs_image_f32_row(&tb, y)[x] = (float)sqrt(1.0 - (1.0 - r) / 1.5);
        }
    const char *names[1] = {"AO"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    CHECK_OK(write_exr(ctx, a, names, &ra, 1), ctx);
    CHECK_OK(write_exr(ctx, b, names, &tb, 1), ctx);
    int rc = run_compare(a, b, "--max-rmse", "0.001", NULL);
    CHECK_EQ_INT(rc, 1);
    char json[4200];
    snprintf(json, sizeof json, "%s/cal.json", test_tmpdir());
    rc = run_compare(a, b, "--max-rmse", "0.001", "--calibrated", "--json", json, NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s, stdout: %s", rc, g_err, g_out);
    CHECK_MSG(strstr(g_out, "gain 1.5") && strstr(g_out, "power 2"), "stdout: %s", g_out);
    /* beside the calibrated RMSE: the flat baseline and the skill (1: the fit is exact) */
    CHECK_MSG(strstr(g_out, "flat baseline rmse") && strstr(g_out, "skill 1") && !strstr(g_out, "not informative"),
              "stdout: %s", g_out);
    char jb[8192];
    slurp(json, jb, sizeof jb);
    CHECK_MSG(strstr(jb, "\"baseline_rmse\"") && strstr(jb, "\"skill\"") && strstr(jb, "\"fit_at_bound\": false"),
              "json: %s", jb);
    obs_image_f32_free(&ra);
    obs_image_f32_free(&tb);
    obs_context_destroy(ctx);
}

TEST(compare_mask_file_selects_pixels)
{
    obs_context *ctx = obs_context_create();
    obs_image_f32 ra = {0}, tb = {0}, m = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ra), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &tb), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &m), ctx);
    fill_ao(&ra, 1);
    fill_ao(&tb, 1);
    obs_image_f32_fill(&m, 1.0f);
    obs_image_f32_row(&tb, 7)[9] = NAN;
    obs_image_f32_row(&tb, 8)[9] = 5.0f;
    obs_image_f32_row(&m, 7)[9] = 0.0f;
    obs_image_f32_row(&m, 8)[9] = 0.0f;
    const char *names[1] = {"AO"}, *mnames[2] = {"other", "valid"};
    const char *a = test_path(test_tmpdir(), "a.exr"), *b = test_path(test_tmpdir(), "b.exr");
    const char *mk = test_path(test_tmpdir(), "mask.exr");
    CHECK_OK(write_exr(ctx, a, names, &ra, 1), ctx);
    CHECK_OK(write_exr(ctx, b, names, &tb, 1), ctx);
    obs_image_f32 mp[2] = {ra, m};
    CHECK_OK(write_exr(ctx, mk, mnames, mp, 2), ctx);
    char spec[4200];
    snprintf(spec, sizeof spec, "%s:valid", mk);
    int rc = run_compare(a, b, "--mask", spec, "--max-abs", "0", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    /* Two channels and no 'mask': the channel must be named. */
    rc = run_compare(a, b, "--mask", mk, NULL);
    CHECK_EQ_INT(rc, 3);
    CHECK_MSG(strstr(g_err, "other") && strstr(g_err, "valid"), "stderr: %s", g_err);
    /* PNG inputs are read too (as float). */
    const char *pa = test_path(test_tmpdir(), "a.png");
    CHECK_OK(io_png_write(ctx, pa, &ra, 1, IO_PNG_LINEAR), ctx);
    rc = run_compare(pa, pa, "--max-rmse", "0", NULL);
    CHECK_MSG(rc == 0, "exit %d, stderr: %s", rc, g_err);
    obs_image_f32_free(&ra);
    obs_image_f32_free(&tb);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}

TEST(compare_bad_flag_is_usage_error)
{
    const char *a = test_path(test_tmpdir(), "a.exr");
    int rc = run_compare(a, a, "--bogus", NULL);
    CHECK_EQ_INT(rc, 2);
    CHECK_MSG(strstr(g_err, "--bogus"), "stderr: %s", g_err);
    CHECK_EQ_INT(run_compare(a, "--max-rmse", "abc", a, NULL), 2);
    CHECK_EQ_INT(run_compare(a, a, "--max-rmse", NULL), 2);
    CHECK_EQ_INT(run_compare(a, a, "--max-over-threshold", "1.5", NULL), 2);
    CHECK_EQ_INT(run_compare(a, NULL), 2);
    CHECK_EQ_INT(run_compare(a, a, a, NULL), 2);
    CHECK_EQ_INT(run_compare(a, a, "--channel-a", "X", NULL), 2);
    CHECK_EQ_INT(run_compare("--help", NULL), 0);
    CHECK(strstr(g_out, "--max-rmse") != NULL);
}
