/* test_study.c: the study machinery (src/study/study.h), the AO study library (study_ao.h) and
 * `obscura study ao` (issue 5): the library is driven directly, the command for its flags, exit
 * codes and resume. */
#include "test.h"
#include "study/study.h"
#include "study/study_ao.h"
#include "ao/ao.h"
#include "io/io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

TEST(study_table_round_trips_through_csv_with_quoting)
{
    obs_context *ctx = obs_context_create();
    const char *names[] = {"scene", "method", "params", "value"};
    study_table t, u;
    CHECK_OK(study_table_init(ctx, &t, names, 4, 2), ctx);
    const char *r0[] = {"bunny", "sao", "a=1, b=\"x\"", "0.125"};
    const char *r1[] = {"room", "gtao", "multi\nline", ""};
    CHECK_OK(study_table_append(ctx, &t, r0), ctx);
    CHECK_OK(study_table_append(ctx, &t, r1), ctx);
    const char *key[] = {"room", "gtao"};
    CHECK(study_table_find(&t, key) == 1);
    const char *nokey[] = {"room", "sao"};
    CHECK(study_table_find(&t, nokey) == -1);
    CHECK(study_table_num(&t, 0, 3) == 0.125);
    CHECK(isnan(study_table_num(&t, 1, 3)) && isnan(study_table_num(&t, 0, 2)));
    const char *path = test_path(test_tmpdir(), "t.csv");
    CHECK_OK(study_table_write_csv(ctx, &t, path), ctx);
    CHECK_OK(study_table_init(ctx, &u, names, 4, 2), ctx);
    int64_t n = 0;
    CHECK_OK(study_table_read_csv(ctx, &u, path, &n), ctx);
    CHECK(n == 2 && u.rows == 2);
    for (int64_t r = 0; r < 2; r++)
        for (int c = 0; c < 4; c++)
            CHECK_MSG(!strcmp(study_table_get(&t, r, c), study_table_get(&u, r, c)), "cell %lld,%d", (long long)r, c);
    /* a missing file is an empty table, not an error */
    CHECK_OK(study_table_read_csv(ctx, &u, test_path(test_tmpdir(), "none.csv"), &n), ctx);
    CHECK(n == 0);
    /* another study's columns, and a malformed record, are refused with the file named */
    const char *other[] = {"a", "b", "c", "d"};
    study_table w;
    CHECK_OK(study_table_init(ctx, &w, other, 4, 1), ctx);
    CHECK(study_table_read_csv(ctx, &w, path, &n) == OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "t.csv") != NULL);
    obs_context_clear_error(ctx);
    FILE *f = fopen(test_path(test_tmpdir(), "bad.csv"), "w");
    fputs("scene,method,params,value\nbunny,\"sao,x,1\n", f);
    fclose(f);
    study_table_free(&w);
    CHECK_OK(study_table_init(ctx, &w, names, 4, 2), ctx);
    CHECK(study_table_read_csv(ctx, &w, test_path(test_tmpdir(), "bad.csv"), &n) == OBS_STATUS_PARSE_ERROR);
    CHECK(strstr(obs_context_last_error(ctx), "line 2") != NULL);
    /* bad column sets */
    const char *dup[] = {"a", "a"};
    study_table z;
    CHECK(study_table_init(ctx, &z, dup, 2, 1) == OBS_STATUS_INVALID_ARGUMENT);
    const char *comma[] = {"a,b"};
    CHECK(study_table_init(ctx, &z, comma, 1, 1) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(study_table_init(ctx, &z, names, 4, 5) == OBS_STATUS_INVALID_ARGUMENT);
    /* JSON: numbers as numbers, the rest as strings */
    const char *jpath = test_path(test_tmpdir(), "t.json");
    CHECK_OK(study_table_write_json(ctx, &t, jpath), ctx);
    char *j = test_slurp(jpath, NULL);
    CHECK(j && strstr(j, "\"value\": 0.125") && strstr(j, "\"params\": \"a=1, b=\\\"x\\\"\"") &&
          strstr(j, "\"params\": \"multi\\u000aline\""));
    free(j);
    study_table_free(&t);
    study_table_free(&u);
    study_table_free(&w);
    obs_context_destroy(ctx);
}

/* A CSV whose header is a prefix of the table's columns (written before columns were appended) is
 * read with the new cells empty; one that is not a prefix, or lacks key columns, is refused;
 * study_table_set replaces a cell. */
TEST(study_table_reads_older_tables_and_sets_cells)
{
    obs_context *ctx = obs_context_create();
    const char *dir = test_tmpdir();
    const char *path = test_path(dir, "old.csv");
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fputs("a,b,c\n1,2,3\n4,5,6\n", f);
        fclose(f);
    }
    const char *names[] = {"a", "b", "c", "d"};
    study_table t;
    CHECK_OK(study_table_init(ctx, &t, names, 4, 1), ctx);
    int64_t n = 0;
    CHECK_OK(study_table_read_csv(ctx, &t, path, &n), ctx);
    CHECK(n == 2 && t.rows == 2);
    CHECK(!strcmp(study_table_get(&t, 1, 2), "6") && !strcmp(study_table_get(&t, 1, 3), ""));
    CHECK_OK(study_table_set(ctx, &t, 1, 3, "7.5"), ctx);
    CHECK(study_table_num(&t, 1, 3) == 7.5);
    CHECK(study_table_set(ctx, &t, 2, 0, "x") == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(study_table_set(ctx, &t, 0, 4, "x") == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_clear_error(ctx);
    study_table_free(&t);
    /* not a prefix: refused, naming the file */
    static const char *const bad[] = {"a,c\n1,2\n", "x,b,c\n1,2,3\n", "a,b,c,d,e\n1,2,3,4,5\n", "a,b\n1,2,3\n"};
    const char *k2[] = {"a", "b", "c", "d"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        f = fopen(path, "w");
        if (f) {
            fputs(bad[i], f);
            fclose(f);
        }
        CHECK_OK(study_table_init(ctx, &t, k2, 4, 2), ctx);
        obs_status st = study_table_read_csv(ctx, &t, path, &n);
        CHECK_MSG(st == OBS_STATUS_PARSE_ERROR && strstr(obs_context_last_error(ctx), "old.csv"), "case %zu: %d %s", i,
                  (int)st, obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
        study_table_free(&t);
    }
    obs_context_destroy(ctx);
}

TEST(study_stats_and_pareto_front_match_hand_values)
{
    double v[] = {5, 1, 4, 2, 3};
    study_stats s = study_stats_of(v, 5);
    CHECK(s.median == 3 && s.min == 1 && s.max == 5 && s.n == 5);
    double w[] = {4, 1, 3, 2};
    s = study_stats_of(w, 4);
    CHECK(s.median == 2.5);
    s = study_stats_of(w, 0);
    CHECK(isnan(s.median));
    /* points (cost, error): the front is the lower-left staircase */
    const double c[] = {1, 2, 3, 2, 4, 5, NAN, 0.5, 3};
    const double e[] = {5, 3, 4, 3, 1, 1, 0, 9, 2};
    unsigned char on[9];
    int n = study_pareto_front(c, e, 9, on);
    /* 0.5/9 (cheapest), 1/5, 2/3 twice (duplicates), 3/2, 4/1; not 3/4, 5/1 (dominated by 4/1), NaN */
    const unsigned char want[9] = {1, 1, 0, 1, 1, 0, 0, 1, 1};
    for (int i = 0; i < 9; i++)
        CHECK_MSG(on[i] == want[i], "point %d: on_front %d, want %d", i, on[i], want[i]);
    CHECK_EQ_INT(n, 6);
    /* brute force on pseudo-random points: a point is on the front iff nothing dominates it */
    double rc[200], re[200];
    unsigned char ro[200];
    uint32_t x = 12345;
    for (int i = 0; i < 200; i++) {
        x = x * 1664525u + 1013904223u;
        rc[i] = (double)(x >> 24);
        x = x * 1664525u + 1013904223u;
        re[i] = (double)(x >> 24);
    }
    study_pareto_front(rc, re, 200, ro);
    for (int i = 0; i < 200; i++) {
        int dominated = 0;
        for (int k = 0; k < 200; k++)
            dominated |= rc[k] <= rc[i] && re[k] <= re[i] && (rc[k] < rc[i] || re[k] < re[i]);
        CHECK_MSG(ro[i] == !dominated, "random point %d", i);
    }
}

TEST(study_svg_scatter_has_axes_legend_and_front)
{
    obs_context *ctx = obs_context_create();
    const double x1[] = {1, 2, 4}, y1[] = {0.3, 0.2, 0.25}, x2[] = {0.5, 8, -1}, y2[] = {0.4, 0.1, 0.1};
    study_series s[2] = {{"alpha", x1, y1, 3}, {"beta <b>", x2, y2, 3}};
    study_plot p = {"Title", "time (ms)", "RMSE", 1, 0, 1, 0, 0};
    const char *path = test_path(test_tmpdir(), "p.svg");
    CHECK_OK(study_svg_scatter(ctx, path, &p, s, 2), ctx);
    char *t = test_slurp(path, NULL);
    CHECK(t && strstr(t, "<svg") && strstr(t, "</svg>") && strstr(t, "time (ms)") && strstr(t, "RMSE") &&
          strstr(t, "alpha") && strstr(t, "beta &lt;b&gt;") && strstr(t, "Pareto front (4)") &&
          strstr(t, "1 points not drawable"));
    free(t);
    CHECK(study_svg_scatter(ctx, path, &p, s, 0) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

/* Read a study's results.csv through the library, with the columns its header names. */
static int read_results(const char *path, study_table *t, obs_context *ctx)
{
    char *csv = test_slurp(path, NULL);
    if (!csv)
        return 0;
    char *nl = strchr(csv, '\n');
    if (nl)
        *nl = '\0';
    const char *names[STUDY_MAX_COLUMNS];
    int n = 0;
    for (char *tok = strtok(csv, ","); tok && n < STUDY_MAX_COLUMNS; tok = strtok(NULL, ","))
        names[n++] = tok;
    int ok = study_table_init(ctx, t, names, n, 8) == OBS_STATUS_OK;
    free(csv);
    int64_t rows = 0;
    return ok && study_table_read_csv(ctx, t, path, &rows) == OBS_STATUS_OK;
}

TEST(study_ao_quick_runs_resumes_and_reports)
{
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], err[1100], data[1024];
    snprintf(out, sizeof out, "%s/study", dir);
    snprintf(rep, sizeof rep, "%s/study/report", dir);
    snprintf(err, sizeof err, "%s/err.txt", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    /* the first run through the library: the quick options, a sweep, a report */
    {
        study_ao_options o = study_ao_options_quick();
        o.data_dir = data;
        o.out_dir = out;
        o.report_dir = rep;
        obs_context *ctx = obs_context_create();
        obs_pool *pool = obs_pool_create(2);
        study_ao *s = NULL;
        CHECK_OK(study_ao_open(ctx, &o, &s), ctx);
        if (s) {
            CHECK(study_ao_table(s)->rows == 0);
            CHECK_OK(study_ao_sweep(ctx, pool, s), ctx);
            CHECK_OK(study_ao_report(ctx, pool, s), ctx);
        }
        study_ao_close(s);
        obs_pool_destroy(pool);
        obs_context_destroy(ctx);
    }
    const char *a[] = {"--threads", "2", "study", "ao", "--quick", "--data", data, "-o", out, "--report", rep, NULL};
    char *csv = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK(csv != NULL);
    /* every registered method, blur off and on; every row measured ("ok") with finite errors */
    int rows = 0, ok = 0;
    for (char *p = csv ? strchr(csv, '\n') : NULL; p && p[1]; p = strchr(p + 1, '\n')) {
        rows++;
        ok += strstr(p + 1, ",ok,") != NULL && strchr(p + 1, '\n') > strstr(p + 1, ",ok,");
    }
    int methods = 0;
    for (const ao_method *const *m = ao_methods(); *m; m++)
        methods++;
    CHECK_MSG(rows == 2 * methods && rows == ok, "%d rows, %d ok, %d methods", rows, ok, methods);
    CHECK(csv && !strstr(csv, "nan") && !strstr(csv, "inf"));
    char *md = test_slurp(test_path(rep, "README.md"), NULL);
    /* the table is copied beside the page */
    char *rcsv = test_slurp(test_path(rep, "results.csv"), NULL);
    CHECK(rcsv && csv && !strcmp(rcsv, csv));
    free(rcsv);
    CHECK(md && strstr(md, "Best technique per frame budget") && strstr(md, "pareto_all.svg") &&
          strstr(md, "grid_bunny.png"));
    /* it ends with the generated summary: budgets, the Pareto front, each technique's hard case */
    const char *sm = md ? strstr(md, "\n## Summary") : NULL;
    CHECK(sm && strstr(sm, "Per frame budget at 192x108") && strstr(sm, "On the Pareto front") &&
          strstr(sm, "Hard cases") && !strstr(sm + 1, "\n## "));
    /* the seed's Table 24: MSSAO's 5 levels, each with a time and an error */
    const char *lv = md ? strstr(md, "MSSAO per level") : NULL;
    CHECK(lv && strstr(lv, "| bunny | 0 | 192x108 |") && strstr(lv, "| bunny | 4 | 12x7 |"));
    char *svg = test_slurp(test_path(rep, "pareto_all.svg"), NULL);
    CHECK(svg && strstr(svg, "Pareto front"));
    free(svg);
    size_t plen = 0;
    char *png = test_slurp(test_path(rep, "grid_bunny.png"), &plen);
    CHECK(png && plen > 100);
    free(png);
    /* the grid labels itself: three 192-wide columns under a light title band (test_font.c checks
     * the labels themselves) */
    {
        obs_context *ictx = obs_context_create();
        io_image gi;
        memset(&gi, 0, sizeof gi);
        CHECK_OK(io_image_read(ictx, test_path(rep, "grid_bunny.png"), &gi), ictx);
        CHECK_EQ_INT(gi.width, 3 * 192 + 2 * 4);
        CHECK(gi.channel_count >= 3 && gi.f32 && gi.f32[0].data && fabsf(obs_image_f32_row(&gi.f32[0], 0)[0] - 0.85f) < 0.01f);
        io_image_free(&gi);
        obs_context_destroy(ictx);
    }
    /* the budget table and each technique's best rank only informative configurations: none of
     * their points has its fit at a bound (the summary says which were left out) */
    {
        obs_context *ctx = obs_context_create();
        study_table t;
        CHECK(read_results(test_path(out, "results.csv"), &t, ctx));
        const char *tb = md ? strstr(md, "| budget | technique |") : NULL;
        CHECK(tb && strstr(tb, "| flat baseline | skill |"));
        int ranked = 0;
        for (const char *line = tb ? strchr(strchr(tb, '\n') + 1, '\n') : NULL; line && line[1] == '|';
             line = strchr(line + 1, '\n')) {
            char method[64];
            int smp, blur_yes;
            double rad;
            char blur[8];
            if (sscanf(line + 1, "| %*s ms | %63s | %d | %lf | %7s |", method, &smp, &rad, blur) != 4)
                continue;
            blur_yes = !strcmp(blur, "yes");
            ranked++;
            for (int64_t r = 0; r < t.rows; r++)
                if (!strcmp(study_table_get(&t, r, study_table_column(&t, "method")), method) &&
                    study_table_num(&t, r, study_table_column(&t, "samples")) == smp &&
                    study_table_num(&t, r, study_table_column(&t, "radius_units")) == rad &&
                    study_table_num(&t, r, study_table_column(&t, "blur")) == blur_yes)
                    CHECK_MSG(study_table_num(&t, r, study_table_column(&t, "cal_skill_nc")) > STUDY_SKILL_MIN,
                              "ranked %s %d/%g/%s has an uninformative point", method, smp, rad, blur);
        }
        CHECK(ranked > 0);
        study_table_free(&t);
        obs_context_destroy(ctx);
    }
    free(md);
    /* a second run, through the command, measures nothing again: every point is resumed, the table
     * is unchanged */
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, NULL, err), 0);
    char *e = test_slurp(err, NULL);
    CHECK(e && strstr(e, "resuming"));
    free(e);
    char *csv2 = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK(csv && csv2 && !strcmp(csv, csv2));
    free(csv2);
    free(csv);
    /* bad arguments */
    const char *b1[] = {"study", "ao", "--methods", "nope", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b1, NULL, NULL), 2);
    const char *b2[] = {"study", "ao", "--radii", "-1", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b2, NULL, NULL), 2);
    const char *b6[] = {"study", "ao", "--report-only", "-o", out, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b6, NULL, NULL), 2);
    const char *b7[] = {"study", "ao", "--report-only", "--truth-only", "--report", rep, "-o", out, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b7, NULL, NULL), 2);
    const char *b3[] = {"study", "sss", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b3, NULL, NULL), 2);
    const char *b4[] = {"study", "ao", "--quick", "--data", "/nonexistent", "-o", out, NULL};
    int rc = test_spawn(OBS_CLI_PATH, b4, NULL, NULL);
    CHECK_MSG(rc == 0, "a study whose points are all measured already succeeds without its scenes: %d", rc);
    const char *b5[] = {"study", "ao", "--quick", "--data", "/nonexistent", "-o", test_path(dir, "fresh"), NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b5, NULL, NULL), 3);
    /* --dry-run prints the expected duration and measures nothing */
    char dout[1100];
    snprintf(dout, sizeof dout, "%s/dry.txt", dir);
    const char *d[] = {"study", "ao", "--dry-run", "-o", test_path(dir, "dry"), NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, d, dout, NULL), 0);
    char *dt = test_slurp(dout, NULL);
    CHECK(dt && strstr(dt, "expected duration"));
    free(dt);
}

/* The quick study over the given radii through the library: its truth step (truth_only) or its
 * sweep, logging to log_path (truncated). Returns the status. */
static obs_status quick_step(const char *data, const char *out, const char *radii, int truth_only,
                             const char *log_path)
{
    study_ao_options o = study_ao_options_quick();
    o.data_dir = data;
    o.out_dir = out;
    o.radii = radii;
    o.log = fopen(log_path, "w");
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    study_ao *s = NULL;
    obs_status st = study_ao_open(ctx, &o, &s);
    if (st == OBS_STATUS_OK)
        st = truth_only ? study_ao_truth(ctx, pool, s) : study_ao_sweep(ctx, pool, s);
    if (st != OBS_STATUS_OK)
        fprintf(stderr, "quick_step: %s\n", obs_context_last_error(ctx));
    study_ao_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    if (o.log)
        fclose(o.log);
    return st;
}

/* --truth-only computes the ground truths (the hemisphere estimators of one family from one ray
 * set) and measures nothing; the sweep then reuses them; every RMSE has its noise-corrected
 * companion, sqrt(rmse^2 - gt_rms_std_error^2) clamped at 0, never above the raw value;
 * --report-only writes the report from the table without measuring. */
TEST(study_truth_only_then_sweep_then_report_only)
{
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], err[1100], data[1024];
    snprintf(out, sizeof out, "%s/study-t", dir);
    snprintf(rep, sizeof rep, "%s/study-t/report", dir);
    snprintf(err, sizeof err, "%s/err-t.txt", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    CHECK_EQ_INT(quick_step(data, out, "0.5,1", 1, err), OBS_STATUS_OK);
    char *e = test_slurp(err, NULL);
    /* two radii of the cosine family (cos, obs-sao, obs-mssao, ...) in one set: "N outputs" */
    CHECK_MSG(e && strstr(e, "ground truth bunny/default 192x108") && strstr(e, " outputs (cos"), "stderr: %s", e ? e : "");
    /* once: the reference's noise comes from its own replicates, not from a second seed */
    CHECK_MSG(e && !strstr(e, "(replicate)"), "a second-seed ground truth was computed: %s", e ? e : "");
    free(e);
    char *csv = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK_MSG(!csv || !strchr(strchr(csv, '\n') ? strchr(csv, '\n') : "", ','), "truth-only measured points");
    free(csv);
    CHECK_EQ_INT(quick_step(data, out, "0.5,1", 0, err), OBS_STATUS_OK);
    e = test_slurp(err, NULL);
    CHECK_MSG(e && !strstr(e, "ground truth bunny"), "the sweep recomputed a cached ground truth: %s", e ? e : "");
    free(e);
    obs_context *ctx = obs_context_create();
    study_table t;
    CHECK(read_results(test_path(out, "results.csv"), &t, ctx));
    int cr = study_table_column(&t, "rmse"), cn = study_table_column(&t, "rmse_nc"),
        cc = study_table_column(&t, "cal_rmse"), ccn = study_table_column(&t, "cal_rmse_nc"),
        cg = study_table_column(&t, "gt_noise_rms"), cs = study_table_column(&t, "gt_rms_std_error"),
        cm = study_table_column(&t, "gt_mean_std_error");
    CHECK(cr >= 0 && cn >= 0 && cc >= 0 && ccn >= 0 && cg >= 0 && cs >= 0 && cm >= 0);
    int methods = 0;
    for (const ao_method *const *m = ao_methods(); *m; m++)
        methods++;
    CHECK_MSG(t.rows == 4 * methods, "%lld rows", (long long)t.rows);
    for (int64_t r = 0; r < t.rows; r++) {
        double raw = study_table_num(&t, r, cr), nc = study_table_num(&t, r, cn), g = study_table_num(&t, r, cg);
        double cal = study_table_num(&t, r, cc), cnc = study_table_num(&t, r, ccn);
        CHECK(study_table_num(&t, r, cs) >= study_table_num(&t, r, cm) - 1e-9); /* rms >= mean */
        /* the noise estimate is positive where the reference is noisy, and it is the RMS of the
         * truth's replicate standard errors over the scored pixels (calibrated: test_truth_ao.c) */
        CHECK_MSG(g > 0.0 && fabs(g - study_table_num(&t, r, cs)) <= 1e-6 * (1.0 + g), "row %lld: noise %g, rms SE %g",
                  (long long)r, g, study_table_num(&t, r, cs));
        CHECK(nc >= 0.0 && nc <= raw && cnc >= 0.0 && cnc <= cal);
        double want = raw > g ? sqrt(raw * raw - g * g) : 0.0;
        CHECK_MSG(fabs(nc - want) <= 1e-6 * (1.0 + want), "row %lld: rmse_nc %g, want %g", (long long)r, nc, want);
        /* the flat baseline and the skill [Murphy88]: skill = 1 - cal_rmse^2 / baseline^2, the same
         * with the noise s^2 taken out of both; the baseline is the truth's standard deviation, so
         * the skill is at most 1; the bound flag is the fitted power's */
        double base = study_table_num(&t, r, study_table_column(&t, "baseline_rmse"));
        double base_nc = study_table_num(&t, r, study_table_column(&t, "baseline_rmse_nc"));
        double sk = study_table_num(&t, r, study_table_column(&t, "cal_skill"));
        double sk_nc = study_table_num(&t, r, study_table_column(&t, "cal_skill_nc"));
        double at = study_table_num(&t, r, study_table_column(&t, "fit_at_bound"));
        CHECK_MSG(base > 0.0 && base_nc > 0.0 && base_nc <= base, "row %lld: baseline %g, nc %g", (long long)r, base,
                  base_nc);
        CHECK_MSG(fabs(base_nc - sqrt(base * base - g * g)) <= 1e-6, "row %lld: baseline_nc %g", (long long)r, base_nc);
        CHECK_MSG(fabs(sk - (1.0 - cal * cal / (base * base))) <= 1e-6 && sk <= 1.0, "row %lld: skill %g", (long long)r,
                  sk);
        CHECK_MSG(fabs(sk_nc - (1.0 - cnc * cnc / (base_nc * base_nc))) <= 1e-5 && sk_nc <= 1.0,
                  "row %lld: skill_nc %g", (long long)r, sk_nc);
        CHECK(at == (double)met_fit_power_at_bound(study_table_num(&t, r, study_table_column(&t, "cal_power"))));
    }
    /* a table written before gt_noise_rms existed (its header ending before it, so without the
     * skill columns appended after it either) is read, and its rows get the noise, the corrected
     * RMSEs, the flat baseline, the skill and the bound flag filled in, without being measured
     * again */
    {
        char *full = test_slurp(test_path(out, "results.csv"), NULL);
        CHECK(full != NULL);
        FILE *fo = full ? fopen(test_path(out, "results.csv"), "w") : NULL;
        CHECK(fo != NULL);
        for (char *line = full; fo && line && *line;) { /* keep each line's first cg cells */
            char *end = strchr(line, '\n');
            size_t len = end ? (size_t)(end - line) : strlen(line);
            size_t keep = len;
            int cells = 0, quoted = 0;
            for (size_t q = 0; q < len; q++) {
                quoted ^= line[q] == '"';
                if (line[q] == ',' && !quoted && ++cells == cg) {
                    keep = q;
                    break;
                }
            }
            fwrite(line, 1, keep, fo);
            fputc('\n', fo);
            line = end ? end + 1 : NULL;
        }
        if (fo)
            fclose(fo);
        free(full);
        CHECK_EQ_INT(quick_step(data, out, "0.5,1", 0, err), OBS_STATUS_OK);
        study_table t2;
        CHECK(read_results(test_path(out, "results.csv"), &t2, ctx));
        CHECK(t2.rows == t.rows);
        for (int64_t r = 0; r < t.rows && r < t2.rows; r++) {
            CHECK(!strcmp(study_table_get(&t, r, study_table_column(&t, "total_ms")),
                          study_table_get(&t2, r, study_table_column(&t2, "total_ms")))); /* not re-measured */
            CHECK(!strcmp(study_table_get(&t, r, cg), study_table_get(&t2, r, cg)));
            /* recomputed from the 9-digit raw cells: equal to about 1e-8 */
            CHECK(fabs(study_table_num(&t, r, ccn) - study_table_num(&t2, r, ccn)) <= 1e-7);
            CHECK(fabs(study_table_num(&t, r, cn) - study_table_num(&t2, r, cn)) <= 1e-7);
            static const char *const added[] = {"baseline_rmse", "baseline_rmse_nc", "cal_skill", "cal_skill_nc",
                                                "fit_at_bound"};
            for (int k = 0; k < 5; k++) {
                const double v1 = study_table_num(&t, r, study_table_column(&t, added[k]));
                const double v2 = study_table_num(&t2, r, study_table_column(&t2, added[k]));
                CHECK_MSG(fabs(v1 - v2) <= 1e-6 * (1.0 + fabs(v1)), "row %lld %s: %.9g measured, %.9g completed",
                          (long long)r, added[k], v1, v2);
            }
        }
        study_table_free(&t2);
    }
    study_table_free(&t);
    obs_context_destroy(ctx);
    /* the report from the table alone: nothing measured, the table unchanged */
    char *before = test_slurp(test_path(out, "results.csv"), NULL);
    const char *c[] = {"study", "ao", "--quick", "--data", data, "-o", out, "--radii", "0.5,1", "--report-only",
                       "--report", rep, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, c, NULL, err), 0);
    char *after = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK(before && after && !strcmp(before, after));
    free(before);
    free(after);
    char *md = test_slurp(test_path(rep, "README.md"), NULL);
    char cover[128];
    snprintf(cover, sizeof cover, "192x108: %d (samples 8; radii 0.5,1)", 4 * methods);
    CHECK_MSG(md && strstr(md, cover) && strstr(md, "noise taken out"), "report lacks '%s'", cover);
    free(md);
}

/* The ground truth's sampling settings come from one function: a fixed count (min = max = the
 * cap: no adaptive stopping, so no stopping bias) in batches of 16 with 8 replicates whose
 * standard error (not floored) is the SE plane, the cap scaled by 921600 / pixels above 1280x720
 * (a multiple of 16, at least 32), the seed passed through. */
TEST(study_ao_truth_params_scale_the_cap_with_the_pixels)
{
    const study_ao_options o = study_ao_options_default();
    truth_ao_params tp = study_ao_truth_params(&o, 1280, 720, 0);
    CHECK(tp.min_samples == 256 && tp.batch == 16 && tp.max_samples == 256 && tp.seed == 0);
    CHECK(tp.replicates == 8 && tp.error_bar == TRUTH_AO_BAR_REPLICATES);
    CHECK_EQ_INT((int)study_ao_truth_params(&o, 640, 480, 0).max_samples, 256);
    CHECK_EQ_INT((int)study_ao_truth_params(&o, 1920, 1080, 0).max_samples, 112); /* 256 * 0.444 = 113.8 -> 112 */
    CHECK_EQ_INT((int)study_ao_truth_params(&o, 3840, 2160, 0).max_samples, 32);  /* 28.4 -> 32 (the floor) */
    CHECK_EQ_INT((int)study_ao_truth_params(&o, 1920, 1080, 1).seed, 1);
    const study_ao_options q = study_ao_options_quick();
    tp = study_ao_truth_params(&q, 192, 108, 1);
    CHECK(tp.min_samples == 128 && tp.max_samples == 128 && tp.seed == 1);
    CHECK_EQ_INT((int)study_ao_truth_params(&q, 1920, 1080, 0).max_samples, 64); /* 56.9 -> 64 */
}

/* The library refuses bad options with INVALID_ARGUMENT and a message that names the culprit,
 * before touching the output directory. */
TEST(study_ao_open_refuses_bad_options_with_a_message)
{
    obs_context *ctx = obs_context_create();
    char out[1024];
    snprintf(out, sizeof out, "%s/never", test_tmpdir());
    static const struct {
        const char *field, *value, *message;
    } cases[] = {
        {"methods", "sao,nope", "nope"}, {"radii", "1,-1", "-1"},       {"resolutions", "192by108", "192by108"},
        {"blurs", "2", "--blur"},        {"samples", "0", "'0'"},        {"budgets", "0", "budget"},
        {"scenes", "", "scenes"},        {"views", ",,", "views"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        study_ao_options o = study_ao_options_quick();
        o.out_dir = out;
        if (!strcmp(cases[i].field, "methods")) o.methods = cases[i].value;
        if (!strcmp(cases[i].field, "radii")) o.radii = cases[i].value;
        if (!strcmp(cases[i].field, "resolutions")) o.resolutions = cases[i].value;
        if (!strcmp(cases[i].field, "blurs")) o.blurs = cases[i].value;
        if (!strcmp(cases[i].field, "samples")) o.samples = cases[i].value;
        if (!strcmp(cases[i].field, "budgets")) o.budgets = cases[i].value;
        if (!strcmp(cases[i].field, "scenes")) o.scenes = cases[i].value;
        if (!strcmp(cases[i].field, "views")) o.views = cases[i].value;
        study_ao *s = (study_ao *)&o; /* must be reset to NULL */
        obs_status st = study_ao_open(ctx, &o, &s);
        CHECK_MSG(st == OBS_STATUS_INVALID_ARGUMENT && s == NULL && strstr(obs_context_last_error(ctx), cases[i].message),
                  "%s=%s: status %d, '%s'", cases[i].field, cases[i].value, (int)st, obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
    }
    study_ao_options o = study_ao_options_quick();
    o.out_dir = out;
    o.runs = 0;
    study_ao *s = NULL;
    CHECK(study_ao_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT && s == NULL);
    obs_context_clear_error(ctx);
    o.runs = 3;
    o.gt_max_samples = 100; /* not a multiple of 16 */
    CHECK(study_ao_open(ctx, &o, &s) == OBS_STATUS_INVALID_ARGUMENT && s == NULL);
    CHECK(access(out, F_OK) != 0);
    /* good options open an empty study; the dry run counts its points */
    o = study_ao_options_quick();
    o.out_dir = out;
    o.methods = "sao,gtao";
    o.radii = "0.5,1";
    CHECK_OK(study_ao_open(ctx, &o, &s), ctx);
    if (s) {
        const study_ao_plan p = study_ao_plan_of(s);
        CHECK(p.points == 1 * 1 * 1 * 2 * 1 * 2 * 2 && p.methods == 2 && p.radii == 2 && p.runs == 3);
        CHECK(p.sweep_min_lo > 0.0 && p.sweep_min_lo < p.sweep_min_hi && p.truth_min_lo < p.truth_min_hi);
        CHECK(study_ao_table(s)->rows == 0);
        CHECK(study_ao_report(ctx, NULL, s) == OBS_STATUS_INVALID_ARGUMENT); /* no report directory */
        obs_context_clear_error(ctx);
    }
    study_ao_close(s);
    obs_context_destroy(ctx);
}

/* The generic score against a noisy ground truth, by hand: MSEs 0.02 (raw) and 0.01 (calibrated),
 * truth variance 0.05, noise s = 0.05 (s^2 = 0.0025). */
TEST(study_score_matches_hand_values)
{
    study_score s = study_score_of(0.02, 0.01, 0.05, 0.05, 0);
    CHECK_NEAR(s.rmse, sqrt(0.02), 1e-15);
    CHECK_NEAR(s.rmse_nc, sqrt(0.0175), 1e-15);
    CHECK_NEAR(s.cal_rmse, 0.1, 1e-15);
    CHECK_NEAR(s.cal_rmse_nc, sqrt(0.0075), 1e-15);
    CHECK_NEAR(s.baseline_rmse, sqrt(0.05), 1e-15);
    CHECK_NEAR(s.baseline_rmse_nc, sqrt(0.0475), 1e-15);
    CHECK_NEAR(s.cal_skill, 0.8, 1e-14);                    /* 1 - 0.01 / 0.05 */
    CHECK_NEAR(s.cal_skill_nc, 1.0 - 0.0075 / 0.0475, 1e-14);
    CHECK(s.fit_at_bound == 0 && study_score_informative(s.cal_skill_nc));
    /* a flat prediction (MSE = variance) has skill 0: not informative, nor is one that explains at
     * most 5% of the variance; a fit at its bound is flagged, and ranked on its skill */
    s = study_score_of(0.05, 0.05, 0.05, 0.0, 1);
    CHECK(s.cal_skill == 0.0 && s.fit_at_bound == 1 && !study_score_informative(s.cal_skill));
    CHECK(study_score_informative(0.9) && !study_score_informative(0.05) && !study_score_informative(NAN) &&
          !study_score_informative(-0.1));
    CHECK_NEAR(study_noise_corrected(0.05, 0.03), 0.04, 1e-15);
    CHECK(study_noise_corrected(0.03, 0.05) == 0.0);
    /* the replicate noise: g0 - g1 = +-0.25 on the two unmasked pixels: sqrt(0.0625 / 2) */
    obs_context *ctx = obs_context_create();
    obs_image_f32 g0 = {0}, g1 = {0}, m = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 1, &g0), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 1, &g1), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, 3, 1, &m), ctx);
    const float a[3] = {0.5f, 0.75f, 0.0f}, b[3] = {0.25f, 1.0f, 1.0f}, mk[3] = {1, 1, 0};
    for (int x = 0; x < 3; x++) {
        obs_image_f32_row(&g0, 0)[x] = a[x];
        obs_image_f32_row(&g1, 0)[x] = b[x];
        obs_image_f32_row(&m, 0)[x] = mk[x];
    }
    CHECK_NEAR(study_replicate_noise_rms(&g0, &g1, &m), sqrt(0.0625 / 2.0), 1e-15);
    obs_image_f32_free(&g0);
    obs_image_f32_free(&g1);
    obs_image_f32_free(&m);
    obs_context_destroy(ctx);
}
