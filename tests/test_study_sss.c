/* test_study_sss.c: the SSS study (src/study/study_sss.h): the quick configuration end to end
 * (points, finite errors, the Pareto front, the report's files, resume), a missing reference
 * reported with its reason, the reference cache's content key and its refusal of a mismatched
 * file, the options' refusals, and the error function by hand. docs/study.md, "Subsurface
 * scattering". */
#include "test.h"
#include "study/study_sss.h"
#include "study/study_sss_internal.h"
#include "io/io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int file_exists(const char *dir, const char *name)
{
    struct stat sb;
    return stat(test_path(dir, name), &sb) == 0 && sb.st_size > 0;
}

TEST(study_sss_quick_runs_resumes_and_reports)
{
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], data[1024];
    snprintf(out, sizeof out, "%s/sss", dir);
    snprintf(rep, sizeof rep, "%s/sss/report", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    study_sss_options o = study_sss_options_quick();
    o.data_dir = data;
    o.out_dir = out;
    o.report_dir = rep;
    o.Ks = "4,8";   /* four points: enough for a front */
    o.Ns = "16,32";
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    study_sss *s = NULL;
    CHECK_OK(study_sss_open(ctx, &o, &s), ctx);
    CHECK(study_sss_table(s)->rows == 0);
    CHECK_OK(study_sss_sweep(ctx, pool, s), ctx);
    const study_table *t = study_sss_table(s);
    CHECK_EQ_INT(t->rows, 4);
    /* the expected keys, each measured, both references present, errors finite */
    static const char *const ks[4][2] = {{"4", "16"}, {"4", "32"}, {"8", "16"}, {"8", "32"}};
    double cost[4], err[4];
    for (int i = 0; i < 4; i++) {
        const char *key[STUDY_SSS_KEY_COLUMNS] = {"sphere_potato", "front", "64", "48", "russian-roulette",
                                                  ks[i][0], ks[i][1], "64"};
        const int64_t r = study_table_find(t, key);
        CHECK_MSG(r >= 0, "no row for K %s N %s", ks[i][0], ks[i][1]);
        CHECK(!strcmp(study_table_get(t, r, study_table_column(t, "status")), "ok"));
        CHECK(!strcmp(study_table_get(t, r, study_table_column(t, "bf_status")), "ok"));
        CHECK(!strcmp(study_table_get(t, r, study_table_column(t, "rw_status")), "ok"));
        static const char *const cols[] = {"rebuilt_ms", "fixed_ms", "maps_ms", "bf_rmse", "bf_rel_rmse_nc",
                                           "bf_mean_ratio", "rw_rmse", "rw_rel_rmse_nc", "rw_mean_ratio",
                                           "bf_noise_rms", "bf_pixels"};
        for (size_t c = 0; c < sizeof cols / sizeof cols[0]; c++) {
            const double v = study_table_num(t, r, study_table_column(t, cols[c]));
            CHECK_MSG(isfinite(v) && v >= 0.0, "%s = %g", cols[c], v);
        }
        CHECK(study_table_num(t, r, study_table_column(t, "bf_pixels")) > 100);
        /* the maps' sampler is the one the study sets, whatever the library's default */
        CHECK(strstr(study_table_get(t, r, study_table_column(t, "params")), "sampler=russian-roulette") != NULL);
        cost[i] = study_table_num(t, r, study_table_column(t, "rebuilt_ms"));
        err[i] = study_table_num(t, r, study_table_column(t, "bf_rel_rmse_nc"));
    }
    /* the Pareto front is non-dominated, and every other point is dominated */
    unsigned char on[4];
    const int nf = study_pareto_front(cost, err, 4, on);
    CHECK(nf >= 1);
    for (int i = 0; i < 4; i++) {
        int dominated = 0;
        for (int j = 0; j < 4; j++)
            dominated |= j != i && cost[j] <= cost[i] && err[j] <= err[i] && (cost[j] < cost[i] || err[j] < err[i]);
        CHECK_MSG(on[i] == !dominated, "point %d: on front %d, dominated %d", i, on[i], dominated);
    }
    CHECK_OK(study_sss_report(ctx, pool, s), ctx);
    CHECK(file_exists(rep, "README.md"));
    CHECK(file_exists(rep, "error_bf.svg"));
    CHECK(file_exists(rep, "error_rw.svg"));
    CHECK(file_exists(rep, "grid_sphere_potato.png"));
    CHECK(file_exists(rep, "results.csv"));
    char *md = test_slurp(test_path(rep, "README.md"), NULL);
    CHECK(md && strstr(md, "Pareto front") && strstr(md, "Table 5.3") && strstr(md, "None: every point has both"));
    free(md);
    char *before = test_slurp(test_path(out, "results.csv"), NULL);
    study_sss_close(s);
    s = NULL;
    /* resume: a second sweep over the same grid measures nothing and leaves the table as it was */
    CHECK_OK(study_sss_open(ctx, &o, &s), ctx);
    CHECK_EQ_INT(study_sss_table(s)->rows, 4);
    CHECK_OK(study_sss_sweep(ctx, pool, s), ctx);
    CHECK_EQ_INT(study_sss_table(s)->rows, 4);
    char *after = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK(before && after && !strcmp(before, after));
    free(after);
    study_sss_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    /* and through the command: everything resumed, the table unchanged, the report rewritten */
    char log[1100];
    snprintf(log, sizeof log, "%s/sss_cli.txt", dir);
    const char *a[] = {"--threads", "2", "study", "sss", "--quick", "--data", data, "-o", out, "--report", rep,
                       "--K", "4,8", "--N", "16,32", "--samplers", "Russian-Roulette", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, NULL, log), 0);
    after = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK(before && after && !strcmp(before, after));
    free(before);
    free(after);
    char *msg = test_slurp(log, NULL);
    CHECK(msg && strstr(msg, "resuming: 4 points"));
    free(msg);
    /* a bare `study sss` does not start the hours-long full study: a usage error */
    const char *c0[] = {"study", "sss", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, c0, NULL, NULL), 2);
    /* a bad axis is a usage error */
    const char *b[] = {"study", "sss", "--quick", "-o", out, "--lights", "side", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b, NULL, NULL), 2);
}

TEST(study_sss_missing_reference_is_recorded_with_its_reason)
{
    /* dragon_skin's mesh has open edges: the random walk refuses it; the row says so */
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], data[1024];
    snprintf(out, sizeof out, "%s/sssd", dir);
    snprintf(rep, sizeof rep, "%s/sssd/report", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    study_sss_options o = study_sss_options_quick();
    o.data_dir = data;
    o.out_dir = out;
    o.report_dir = rep;
    o.scenes = "dragon_skin";
    o.resolutions = "32x24";
    o.ref_samples = 256;
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    study_sss *s = NULL;
    CHECK_OK(study_sss_open(ctx, &o, &s), ctx);
    CHECK_OK(study_sss_sweep(ctx, pool, s), ctx);
    const study_table *t = study_sss_table(s);
    CHECK_EQ_INT(t->rows, 1);
    CHECK(!strcmp(study_table_get(t, 0, study_table_column(t, "status")), "ok"));
    CHECK(!strcmp(study_table_get(t, 0, study_table_column(t, "bf_status")), "ok"));
    char rw[1024];
    snprintf(rw, sizeof rw, "%s", study_table_get(t, 0, study_table_column(t, "rw_status")));
    CHECK_MSG(!strncmp(rw, "missing: ", 9) && strstr(rw, "closed"), "rw_status = %s", rw);
    CHECK(isnan(study_table_num(t, 0, study_table_column(t, "rw_rmse"))));
    CHECK(isfinite(study_table_num(t, 0, study_table_column(t, "bf_rmse"))));
    CHECK_OK(study_sss_report(ctx, pool, s), ctx);
    char *md = test_slurp(test_path(rep, "README.md"), NULL);
    CHECK(md && strstr(md, "## Missing references") && strstr(md, "dragon_skin, light front, random walk: missing"));
    free(md);
    study_sss_close(s);
    /* a new point over the same frame reads the reason from the cache */
    o.Ns = "16,17";
    s = NULL;
    CHECK_OK(study_sss_open(ctx, &o, &s), ctx);
    CHECK_OK(study_sss_sweep(ctx, pool, s), ctx);
    t = study_sss_table(s);
    CHECK_EQ_INT(t->rows, 2);
    CHECK(!strcmp(study_table_get(t, 1, study_table_column(t, "rw_status")), rw));
    study_sss_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(study_sss_reference_cache_is_keyed_by_content_and_refuses_a_mismatch)
{
    const char *dir = test_tmpdir();
    char out[1024], data[1024];
    snprintf(out, sizeof out, "%s/sssc", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    study_sss_options o = study_sss_options_quick();
    o.data_dir = data;
    o.out_dir = out;
    o.lights = "front,behind";
    obs_context *ctx = obs_context_create();
    study_sss *s = NULL;
    CHECK_OK(study_sss_open(ctx, &o, &s), ctx);
    study_sss_i_frame f0, f1;
    CHECK_OK(study_sss_i_frame_render(ctx, NULL, s, "sphere_potato", "front", 16, 12, &f0), ctx);
    CHECK_OK(study_sss_i_frame_render(ctx, NULL, s, "sphere_potato", "behind", 16, 12, &f1), ctx);
    /* behind is front's light travelling the opposite way */
    CHECK_NEAR(f0.light.direction.x, -f1.light.direction.x, 0);
    CHECK_NEAR(f0.light.direction.z, -f1.light.direction.z, 0);
    char p0[4400], p1[4400], p2[4400], q0[4400];
    study_sss_i_ref_path(s, "x", "y", &f0, TRUTH_SSS_BRUTE_FORCE, p0, sizeof p0);
    study_sss_i_ref_path(s, "x", "y", &f1, TRUTH_SSS_BRUTE_FORCE, p1, sizeof p1);
    study_sss_i_ref_path(s, "x", "y", &f0, TRUTH_SSS_RANDOM_WALK, q0, sizeof q0);
    CHECK(strcmp(p0, p1) != 0); /* the light is in the key, not only in the name */
    CHECK(strcmp(p0, q0) != 0);
    s->o.ref_samples = 2048; /* the reference's parameters are in the key */
    study_sss_i_ref_path(s, "x", "y", &f0, TRUTH_SSS_BRUTE_FORCE, p2, sizeof p2);
    CHECK(strcmp(p0, p2) != 0);
    s->o.ref_samples = o.ref_samples;
    /* a cached file of the wrong size is not used: the reference is computed again */
    study_sss_i_ref_path(s, "sphere_potato", "front", &f0, TRUTH_SSS_BRUTE_FORCE, p0, sizeof p0);
    char exr[4500], refdir[1100];
    snprintf(exr, sizeof exr, "%s.exr", p0);
    snprintf(refdir, sizeof refdir, "%s/ref", out);
    CHECK_OK(io_make_dirs(ctx, refdir), ctx);
    obs_image_f32 im = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 8, 8, &im), ctx);
    io_channel ch[7] = {{"R", IO_PIXEL_FLOAT, &im, NULL},    {"G", IO_PIXEL_FLOAT, &im, NULL},
                        {"B", IO_PIXEL_FLOAT, &im, NULL},    {"SE.R", IO_PIXEL_FLOAT, &im, NULL},
                        {"SE.G", IO_PIXEL_FLOAT, &im, NULL}, {"SE.B", IO_PIXEL_FLOAT, &im, NULL},
                        {"count", IO_PIXEL_FLOAT, &im, NULL}};
    CHECK_OK(io_exr_write(ctx, exr, ch, 7, NULL, 0), ctx);
    obs_image_f32_free(&im);
    study_sss_i_ref r;
    CHECK_OK(study_sss_i_ref_get(ctx, NULL, s, "sphere_potato", "front", &f0, TRUTH_SSS_BRUTE_FORCE, &r), ctx);
    CHECK(!r.cached && !r.missing && r.count.width == 16 && r.count.height == 12);
    study_sss_i_ref_free(&r);
    /* now cached with the right size: read back, the same pixels */
    CHECK_OK(study_sss_i_ref_get(ctx, NULL, s, "sphere_potato", "front", &f0, TRUTH_SSS_BRUTE_FORCE, &r), ctx);
    CHECK(r.cached && r.count.width == 16);
    study_sss_i_ref_free(&r);
    study_sss_i_frame_free(&f0);
    study_sss_i_frame_free(&f1);
    study_sss_close(s);
    obs_context_destroy(ctx);
}

TEST(study_sss_options_refuse_bad_values)
{
    obs_context *ctx = obs_context_create();
    study_sss *s = NULL;
    study_sss_options o = study_sss_options_quick();
    o.out_dir = test_tmpdir();
    o.lights = "side";
    CHECK(study_sss_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT && !s);
    CHECK(strstr(obs_context_last_error(ctx), "side") != NULL);
    o = study_sss_options_quick();
    o.out_dir = test_tmpdir();
    o.Ks = "0";
    CHECK(study_sss_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o.Ks = "4";
    o.ref_samples = 100;
    CHECK(study_sss_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o.ref_samples = 1024;
    o.resolutions = "64by48";
    CHECK(study_sss_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

TEST(study_sss_error_function_by_hand)
{
    /* ours = 2 x the reference on the masked pixels: ratio of means 2, relative RMSE 1, the best
     * gain 1/2 with no calibrated error; the reference's noise s_Y = sum_c w_c se_c taken out */
    obs_context *ctx = obs_context_create();
    study_sss_i_ref r;
    memset(&r, 0, sizeof r);
    obs_image_f32 ours[3] = {{0}};
    for (int c = 0; c < 3; c++) {
        CHECK_OK(obs_image_f32_alloc(ctx, 4, 2, &r.rgb[c]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, 4, 2, &r.se[c]), ctx);
        CHECK_OK(obs_image_f32_alloc(ctx, 4, 2, &ours[c]), ctx);
    }
    CHECK_OK(obs_image_f32_alloc(ctx, 4, 2, &r.count), ctx);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 4; x++) {
            const float v = (float)(1 + x + 4 * y);
            for (int c = 0; c < 3; c++) {
                obs_image_f32_row(&r.rgb[c], y)[x] = v;
                obs_image_f32_row(&ours[c], y)[x] = y == 1 && x == 3 ? 999.0f : 2.0f * v; /* outside the mask */
                obs_image_f32_row(&r.se[c], y)[x] = 0.5f;
            }
            obs_image_f32_row(&r.count, y)[x] = y == 1 && x == 3 ? 0.0f : 64.0f;
        }
    const study_sss_i_err e = study_sss_i_error(ours, &r);
    CHECK_EQ_INT(e.pixels, 7);
    const double mean = (1 + 2 + 3 + 4 + 5 + 6 + 7) / 7.0; /* luminance weights sum to 1 */
    double mse = 0;
    for (int k = 1; k <= 7; k++)
        mse += (double)k * k / 7.0;
    CHECK_NEAR(e.mean, mean, 1e-12);
    CHECK_NEAR(e.mean_ratio, 2.0, 1e-12);
    CHECK_NEAR(e.rmse, sqrt(mse), 1e-9);
    CHECK_NEAR(e.rel_rmse, sqrt(mse) / mean, 1e-9);
    CHECK_NEAR(e.noise_rms, 0.5, 1e-12);
    CHECK_NEAR(e.rmse_nc, sqrt(mse - 0.25), 1e-9);
    CHECK_NEAR(e.gain, 0.5, 1e-12);
    CHECK_NEAR(e.score.cal_rmse, 0.0, 1e-6);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&ours[c]);
    study_sss_i_ref_free(&r);
    obs_context_destroy(ctx);
}
