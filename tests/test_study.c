/* test_study.c: the study machinery (src/study/study.h) and `obscura study ao --quick` (issue 5). */
#include "test.h"
#include "study/study.h"
#include "ao/ao.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

TEST(study_ao_quick_runs_resumes_and_reports)
{
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], err[1100], data[1024];
    snprintf(out, sizeof out, "%s/study", dir);
    snprintf(rep, sizeof rep, "%s/study/report", dir);
    snprintf(err, sizeof err, "%s/err.txt", dir);
    snprintf(data, sizeof data, "%s", test_data_dir());
    const char *a[] = {"--threads", "2", "study", "ao", "--quick", "--data", data, "-o", out, "--report", rep, NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, NULL, err), 0);
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
    free(md);
    char *svg = test_slurp(test_path(rep, "pareto_all.svg"), NULL);
    CHECK(svg && strstr(svg, "Pareto front"));
    free(svg);
    size_t plen = 0;
    char *png = test_slurp(test_path(rep, "grid_bunny.png"), &plen);
    CHECK(png && plen > 100);
    free(png);
    /* a second run measures nothing again: every point is resumed, the table is unchanged */
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
    const char *a[] = {"study", "ao", "--quick", "--data", data, "-o", out, "--truth-only", "--radii", "0.5,1", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, a, NULL, err), 0);
    char *e = test_slurp(err, NULL);
    /* two radii of the cosine family (cos, obs-sao, obs-mssao, ...) in one set: "N outputs" */
    CHECK_MSG(e && strstr(e, "ground truth bunny/default 192x108") && strstr(e, " outputs (cos"), "stderr: %s", e ? e : "");
    /* and each again with another seed: the replicate that measures the reference's noise */
    CHECK_MSG(e && strstr(e, "ground truth bunny/default 192x108 (replicate)"), "no replicate: %s", e ? e : "");
    free(e);
    char *csv = test_slurp(test_path(out, "results.csv"), NULL);
    CHECK_MSG(!csv || !strchr(strchr(csv, '\n') ? strchr(csv, '\n') : "", ','), "truth-only measured points");
    free(csv);
    const char *b[] = {"study", "ao", "--quick", "--data", data, "-o", out, "--radii", "0.5,1", NULL};
    CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b, NULL, err), 0);
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
        /* the replicate's noise estimate is positive where the reference is noisy, and below the
         * i.i.d. SE, which over-estimates a low-discrepancy estimate's spread */
        CHECK_MSG(g > 0.0 && g < 1.5 * study_table_num(&t, r, cs), "row %lld: noise %g, rms SE %g", (long long)r, g,
                  study_table_num(&t, r, cs));
        CHECK(nc >= 0.0 && nc <= raw && cnc >= 0.0 && cnc <= cal);
        double want = raw > g ? sqrt(raw * raw - g * g) : 0.0;
        CHECK_MSG(fabs(nc - want) <= 1e-6 * (1.0 + want), "row %lld: rmse_nc %g, want %g", (long long)r, nc, want);
    }
    /* a table written before gt_noise_rms existed (its header one column short) is read, and its
     * rows get the noise and the corrected RMSEs filled in, without being measured again */
    {
        char *full = test_slurp(test_path(out, "results.csv"), NULL);
        CHECK(full != NULL);
        FILE *fo = full ? fopen(test_path(out, "results.csv"), "w") : NULL;
        CHECK(fo != NULL);
        for (char *line = full; fo && line && *line;) { /* drop each line's last cell (no quotes in it) */
            char *end = strchr(line, '\n');
            size_t len = end ? (size_t)(end - line) : strlen(line);
            char *comma = NULL;
            for (char *q = line; q < line + len; q++)
                if (*q == ',')
                    comma = q;
            fwrite(line, 1, comma ? (size_t)(comma - line) : len, fo);
            fputc('\n', fo);
            line = end ? end + 1 : NULL;
        }
        if (fo)
            fclose(fo);
        free(full);
        CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, b, NULL, err), 0);
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
