/* The volume study (src/study/study_volume.c; docs/volume/truth.md, "The study"): a reduced sweep
 * on bucky records every point with finite errors and times, resumes without measuring again,
 * writes its report; bad options are refused; a missing dataset is skipped. */
#include "test.h"

#include "core/obs.h"
#include "study/study_volume.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static study_volume_options small_options(const char *dir)
{
    study_volume_options o = study_volume_options_quick();
    o.out_dir = dir;
    o.size = "32x32";
    o.ref_samples = 64;
    o.scales = "1,4";
    o.blends = "0,1";
    return o;
}

static double num(const study_table *t, int64_t r, const char *col)
{
    return study_table_num(t, r, study_table_column(t, col));
}

static const char *str(const study_table *t, int64_t r, const char *col)
{
    return study_table_get(t, r, study_table_column(t, col));
}

TEST(study_volume_quick_sweep_records_every_point_and_resumes)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    const char *dir = test_tmpdir();
    study_volume_options o = small_options(dir);
    char report[4096];
    snprintf(report, sizeof report, "%s/report", dir);
    o.report_dir = report;
    study_volume *s = NULL;
    CHECK_OK(study_volume_open(ctx, &o, &s), ctx);
    int present = 0;
    CHECK_EQ_INT(study_volume_points(s, &present), 6); /* 2 scales x 2 blends + ea + phong */
    CHECK_EQ_INT(present, 1);
    CHECK_OK(study_volume_sweep(ctx, pool, s), ctx);
    const study_table *t = study_volume_table(s);
    CHECK_EQ_INT(t->rows, 6);
    double l_rmse_scale[5] = {0, 0, 0, 0, 0};
    for (int64_t r = 0; r < t->rows; r++) {
        CHECK_MSG(!strcmp(str(t, r, "status"), "ok"), "row %lld: %s", (long long)r, str(t, r, "status"));
        CHECK(num(t, r, "rc_ms") > 0.0);
        if (strcmp(str(t, r, "method"), "lightvolume")) {
            CHECK(isnan(num(t, r, "img_rmse")) && isnan(num(t, r, "lv_ms")));
            continue;
        }
        double lr = num(t, r, "l_rmse"), lm = num(t, r, "l_max_abs");
        CHECK(lr >= 0.0 && lr <= lm && lm <= 1.0);
        CHECK(num(t, r, "lv_ms") > 0.0);
        CHECK_NEAR(num(t, r, "scene_change_ms"), num(t, r, "lv_ms") + num(t, r, "rc_ms"), 1e-6);
        double e = num(t, r, "img_rmse"), enc = num(t, r, "img_rmse_nc"), noise = num(t, r, "ref_noise_rms");
        CHECK(e > 0.0 && enc >= 0.0 && enc <= e && noise > 0.0 && isfinite(num(t, r, "lonly_rmse_nc")));
        CHECK(num(t, r, "pixels") > 0.0);
        int sc = (int)num(t, r, "scale");
        if (sc == 1 || sc == 4)
            l_rmse_scale[sc] = lr;
        printf("scale %d blend %.0f: l RMSE %.4f, image RMSE (nc) %.4f, shadows-only %.4f; build %.2f ms, cast %.2f ms\n",
               sc, num(t, r, "blend"), lr, enc, num(t, r, "lonly_rmse_nc"), num(t, r, "lv_ms"), num(t, r, "rc_ms"));
    }
    /* a quarter-resolution light volume is further from the exact transmittance than the data's */
    CHECK(l_rmse_scale[4] > l_rmse_scale[1]);
    CHECK_OK(study_volume_report(ctx, s), ctx);
    char *md = test_slurp(test_path(report, "README.md"), NULL);
    CHECK(md && strstr(md, "Table 5.4") && strstr(md, "| bucky |"));
    free(md);
    char *svg = test_slurp(test_path(report, "error_vs_time.svg"), NULL);
    CHECK(svg && strstr(svg, "<svg"));
    free(svg);
    study_volume_close(s);
    /* resume: every point is read back, nothing is measured again */
    s = NULL;
    CHECK_OK(study_volume_open(ctx, &o, &s), ctx);
    CHECK_EQ_INT(study_volume_table(s)->rows, 6);
    double t0 = obs_time_now();
    CHECK_OK(study_volume_sweep(ctx, pool, s), ctx);
    CHECK_EQ_INT(study_volume_table(s)->rows, 6);
    CHECK(obs_time_now() - t0 < 0.5); /* the dataset is not even loaded */
    study_volume_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(study_volume_refuses_bad_options_and_skips_missing_datasets)
{
    obs_context *ctx = obs_context_create();
    const char *dir = test_tmpdir();
    study_volume *s = NULL;
    study_volume_options o = small_options(dir);
    o.scales = "3";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT && !s);
    o = small_options(dir);
    o.cones = "0";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.blends = "2";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.datasets = "bonsai";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.ref_samples = 12;
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.size = "abc";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.steps = "nan";
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.runs = 0;
    CHECK(study_volume_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT);
    o = small_options(dir);
    o.datasets = "cranium";
    o.volume_dir = test_path(dir, "no-such-dir");
    CHECK_OK(study_volume_open(ctx, &o, &s), ctx);
    int present = -1;
    CHECK_EQ_INT(study_volume_points(s, &present), 0);
    CHECK_EQ_INT(present, 0);
    CHECK_OK(study_volume_sweep(ctx, NULL, s), ctx);
    CHECK_EQ_INT(study_volume_table(s)->rows, 0);
    study_volume_close(s);
    obs_context_destroy(ctx);
}
