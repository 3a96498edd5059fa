/* test_scale_study.c: studies as array jobs (docs/scale.md): shards merged equal one run, a table
 * of another configuration or version is refused, two shards started at once on an empty cache
 * compute each ground truth once; the shard helpers. */
#include "test.h"

#include "study/study.h"

#include <dirent.h>
#include <fcntl.h>
#include <spawn.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

/* A tiny AO study: the bunny at 64x36, two techniques, two sample counts, both blurs: 8 points,
 * one ground-truth ray set. */
#define STUDY_ARGS                                                                                       \
    "--quiet", "--threads", "1", "study", "ao", "--quick", "--methods", "sao,alchemy", "--samples", "4,8", \
        "--resolutions", "64x36", "--runs", "1", "--gt-max-samples", "32"

TEST(scale_study_shard_parse_and_slurm_environment)
{
    int k = 0, n = 0;
    CHECK(study_shard_parse("2/3", &k, &n) && k == 2 && n == 3);
    CHECK(!study_shard_parse("0/3", &k, &n));
    CHECK(!study_shard_parse("4/3", &k, &n));
    CHECK(!study_shard_parse("1/", &k, &n));
    CHECK(!study_shard_parse("1/3x", &k, &n));
    unsetenv("SLURM_ARRAY_TASK_ID");
    unsetenv("SLURM_ARRAY_TASK_COUNT");
    unsetenv("SLURM_ARRAY_TASK_MIN");
    CHECK(!study_shard_from_env(&k, &n));
    setenv("SLURM_ARRAY_TASK_ID", "0", 1);
    setenv("SLURM_ARRAY_TASK_COUNT", "4", 1);
    setenv("SLURM_ARRAY_TASK_MIN", "0", 1);
    CHECK(study_shard_from_env(&k, &n) && k == 1 && n == 4);
    setenv("SLURM_ARRAY_TASK_ID", "7", 1);
    setenv("SLURM_ARRAY_TASK_MIN", "5", 1);
    CHECK(study_shard_from_env(&k, &n) && k == 3 && n == 4);
    setenv("SLURM_ARRAY_TASK_ID", "9", 1); /* outside the array */
    CHECK(!study_shard_from_env(&k, &n));
    unsetenv("SLURM_ARRAY_TASK_ID");
    unsetenv("SLURM_ARRAY_TASK_COUNT");
    unsetenv("SLURM_ARRAY_TASK_MIN");
    /* interleaved slices: disjoint, and together every point */
    for (int64_t i = 0; i < 100; i++) {
        int owners = 0;
        for (int s = 1; s <= 3; s++)
            owners += study_shard_has(s, 3, i);
        CHECK_EQ_INT(owners, 1);
    }
    CHECK(study_hash_string(STUDY_HASH_INIT, "") == study_hash_bytes(STUDY_HASH_INIT, "", 1));
    CHECK(study_hash_bytes(STUDY_HASH_INIT, "a", 1) == 0xaf63dc4c8601ec8cull); /* FNV-1a 64 of "a" */
}

TEST(scale_study_lock_is_exclusive_and_stale_locks_are_taken)
{
    char path[8400];
    snprintf(path, sizeof path, "%s/x.lock", test_tmpdir());
    study_lock a, b;
    int waited = 0;
    CHECK_OK(study_lock_acquire(NULL, path, 10.0, &a, &waited), (obs_context *)NULL);
    CHECK(!waited);
    CHECK(study_lock_acquire(NULL, path, 0.2, &b, &waited) == OBS_STATUS_LIMIT_EXCEEDED && waited);
    study_lock_release(&a);
    CHECK(access(path, F_OK) != 0);
    /* a lock left by a process of this host that is gone */
    char host[256] = "";
    gethostname(host, sizeof host - 1);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    fprintf(f, "%s %d\n", host, 999999999);
    fclose(f);
    CHECK_OK(study_lock_acquire(NULL, path, 10.0, &b, &waited), (obs_context *)NULL);
    study_lock_release(&b);
}

/* The CSV without its timing columns (names ending in _ms or holding _ms_). */
static char *table_without_timings(const char *path)
{
    char *s = test_slurp(path, NULL);
    if (!s)
        return NULL;
    /* which columns are timings, from the header */
    int drop[128] = {0}, col = 0;
    const char *p = s;
    const char *hend = strchr(s, '\n');
    while (p < hend && col < 128) {
        const char *e = p;
        while (e < hend && *e != ',')
            e++;
        const int len = (int)(e - p);
        int mid = 0;
        for (int i = 0; i + 4 <= len; i++)
            mid |= !strncmp(p + i, "_ms_", 4);
        drop[col] = (len > 3 && !strncmp(e - 3, "_ms", 3)) || mid;
        col++;
        p = e + 1;
    }
    char *out = (char *)malloc(strlen(s) + 1), *o = out;
    col = 0;
    for (p = s; *p; p++) { /* cells have no quotes in these tables (no commas in values) */
        if (*p == '\n') {
            *o++ = '\n';
            col = 0;
            continue;
        }
        if (*p == ',') {
            col++;
            *o++ = ',';
            continue;
        }
        if (col >= 128 || !drop[col])
            *o++ = *p;
    }
    *o = 0;
    free(s);
    return out;
}

static int run_study(const char *out, const char *shard, const char *tag)
{
    const char *args[32] = {STUDY_ARGS};
    int n = 0;
    while (args[n])
        n++;
    args[n++] = "-o";
    args[n++] = out;
    if (shard) {
        args[n++] = "--shard";
        args[n++] = shard;
    }
    args[n] = NULL;
    return test_cli_run(args, tag);
}

TEST(scale_study_shards_merged_equal_one_run_and_mismatches_are_refused)
{
    const char *dir = test_tmpdir();
    char one[8400], sh[8400], merged[8400], other[8400];
    snprintf(one, sizeof one, "%s/one", dir);
    snprintf(sh, sizeof sh, "%s/sh", dir);
    snprintf(merged, sizeof merged, "%s/merged", dir);
    snprintf(other, sizeof other, "%s/other", dir);
    CHECK_EQ_INT(run_study(one, NULL, "one"), 0);
    const char *shards[] = {"1/3", "2/3", "3/3"};
    for (int k = 0; k < 3; k++)
        CHECK_EQ_INT(run_study(sh, shards[k], "shard"), 0);
    char d1[8600], d2[8600], d3[8600];
    snprintf(d1, sizeof d1, "%s/shard-1-of-3", sh);
    snprintf(d2, sizeof d2, "%s/shard-2-of-3", sh);
    snprintf(d3, sizeof d3, "%s/shard-3-of-3", sh);
    const char *margs[] = {"--quiet", "study", "merge", d1, d2, d3, "-o", merged, NULL};
    CHECK_EQ_INT(test_cli_run(margs, "merge"), 0);
    char a[8800], b[8800];
    snprintf(a, sizeof a, "%s/results.csv", one);
    snprintf(b, sizeof b, "%s/results.csv", merged);
    char *ta = table_without_timings(a), *tb = table_without_timings(b);
    CHECK(ta && tb);
    CHECK_MSG(!strcmp(ta, tb), "merged table differs from one run's:\n%s\n---\n%s", ta, tb);
    free(ta);
    free(tb);
    /* each shard measured its own slice only */
    snprintf(a, sizeof a, "%s/results.csv", d3);
    char *t3 = test_slurp(a, NULL);
    int lines = 0;
    for (char *p = t3; p && *p; p++)
        lines += *p == '\n';
    free(t3);
    CHECK_EQ_INT(lines, 1 + 2); /* header + points 2 and 5 of 0..7 */

    /* another configuration: a copy of shard 2 whose manifest has another configuration (what a
     * run with other axes writes: its config text and hash differ) is refused, naming it */
    char o2[8600], m2[8600], cmd[17300];
    snprintf(o2, sizeof o2, "%s/other-2-of-3", dir);
    snprintf(m2, sizeof m2, "%s/m2", dir);
    snprintf(cmd, sizeof cmd, "cp -r '%s' '%s'", d2, o2);
    CHECK_EQ_INT(system(cmd), 0);
    snprintf(a, sizeof a, "%s/manifest.json", o2);
    char *mo = test_slurp(a, NULL);
    CHECK(mo);
    char *h = strstr(mo, "\"config_hash\": \"");
    char *r = strstr(mo, "runs=1");
    CHECK(h && r);
    h[16] = h[16] == '0' ? '1' : '0'; /* the hash of "runs=2" differs from that of "runs=1" */
    r[5] = '2';
    FILE *fo = fopen(a, "wb");
    fputs(mo, fo);
    fclose(fo);
    free(mo);
    const char *bad[] = {"study", "merge", d1, o2, d3, "-o", m2, NULL};
    CHECK_EQ_INT(test_cli_run(bad, "badcfg"), 3);
    CHECK(test_cli_stderr_has("badcfg", "another configuration"));
    /* the same shard twice */
    const char *twice[] = {"study", "merge", d1, d1, "-o", m2, NULL};
    CHECK_EQ_INT(test_cli_run(twice, "twice"), 3);
    CHECK(test_cli_stderr_has("twice", "both shard 1 of 3"));
    /* another version: the manifest says so */
    snprintf(a, sizeof a, "%s/manifest.json", d2);
    char *man = test_slurp(a, NULL);
    CHECK(man);
    char *v = strstr(man, "\"version\": \"");
    CHECK(v);
    v[12] = '9'; /* "0.1.0" -> "9.1.0" */
    FILE *f = fopen(a, "wb");
    fputs(man, f);
    fclose(f);
    free(man);
    const char *badv[] = {"study", "merge", d1, d2, d3, "-o", m2, NULL};
    CHECK_EQ_INT(test_cli_run(badv, "badver"), 3);
    CHECK(test_cli_stderr_has("badver", "refusing to merge versions"));
}

/* Start the command without waiting; stderr to path. */
static pid_t spawn_cli(const char *const *args, const char *err_path)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = OBS_CLI_PATH;
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = args[i];
    argv[n] = NULL;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = -1;
    if (posix_spawn(&pid, OBS_CLI_PATH, &fa, NULL, (char *const *)argv, environ) != 0)
        pid = -1;
    posix_spawn_file_actions_destroy(&fa);
    return pid;
}

TEST(scale_study_shards_started_at_once_compute_each_ground_truth_once)
{
    const char *dir = test_tmpdir();
    char out[8400], e1[8400], e2[8400];
    snprintf(out, sizeof out, "%s/run", dir);
    snprintf(e1, sizeof e1, "%s/s1.stderr", dir);
    snprintf(e2, sizeof e2, "%s/s2.stderr", dir);
    /* not --quiet: each ground-truth ray set is logged ("ground truth ...: K outputs") */
    const char *a1[] = {"--threads", "1", "study", "ao", "--quick", "--methods", "sao,alchemy,hbao", "--samples", "4,8",
                        "--resolutions", "64x36", "--runs", "1", "--gt-max-samples", "32", "-o", out, "--shard", "1/2",
                        NULL};
    const char *a2[] = {"--threads", "1", "study", "ao", "--quick", "--methods", "sao,alchemy,hbao", "--samples", "4,8",
                        "--resolutions", "64x36", "--runs", "1", "--gt-max-samples", "32", "-o", out, "--shard", "2/2",
                        NULL};
    pid_t p1 = spawn_cli(a1, e1), p2 = spawn_cli(a2, e2);
    CHECK(p1 > 0 && p2 > 0);
    int s1 = 0, s2 = 0;
    waitpid(p1, &s1, 0);
    waitpid(p2, &s2, 0);
    CHECK(WIFEXITED(s1) && WEXITSTATUS(s1) == 0);
    CHECK(WIFEXITED(s2) && WEXITSTATUS(s2) == 0);
    /* outputs computed, over both logs */
    int computed = 0;
    const char *logs[] = {e1, e2};
    for (int k = 0; k < 2; k++) {
        char *t = test_slurp(logs[k], NULL);
        CHECK(t);
        for (char *p = strstr(t, "ground truth "); p; p = strstr(p + 1, "ground truth ")) {
            char *c = strstr(p, ": ");
            int n = 0;
            if (c && sscanf(c + 2, "%d output", &n) == 1 && strchr(p, '\n') > c)
                computed += n;
        }
        free(t);
    }
    /* the cache's files: one per output; no lock or temporary file left behind */
    char gt[8600];
    snprintf(gt, sizeof gt, "%s/gt", out);
    DIR *d = opendir(gt);
    CHECK(d);
    int files = 0, other = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.')
            continue;
        const size_t len = strlen(e->d_name);
        if (len > 4 && !strcmp(e->d_name + len - 4, ".exr"))
            files++;
        else
            other++;
    }
    closedir(d);
    CHECK(files >= 2); /* sao's obs-sao, hbao's and alchemy's estimators */
    CHECK_MSG(computed == files, "%d outputs computed for %d cached files", computed, files);
    CHECK_EQ_INT(other, 0);
}
