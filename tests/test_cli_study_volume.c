/* test_cli_study_volume.c: `obscura study volume` as a command (src/cli/cmd_study_volume.c): the
 * quick sweep writes its table and report, with the hybrid stage (the seed's Table 5.5) unless
 * --no-hybrid; bad flags are usage errors (exit 2) that write nothing. */
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

TEST(cli_study_volume_quick_writes_its_report_with_or_without_the_hybrid_stage)
{
    const char *dir = test_tmpdir();
    char out[1024], rep[1024], path[1100];
    for (int hybrid = 0; hybrid < 2; hybrid++) {
        snprintf(out, sizeof out, "%s/sv%d", dir, hybrid);
        snprintf(rep, sizeof rep, "%s/sv%d/report", dir, hybrid);
        const char *with[] = {"--quiet", "--threads", "2", "study", "volume", "--quick", "--datasets", "bucky",
                              "-o", out, "--report", rep, NULL};
        const char *without[] = {"--quiet", "--threads", "2", "study", "volume", "--quick", "--datasets", "bucky",
                                 "--no-hybrid", "-o", out, "--report", rep, NULL};
        CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, hybrid ? with : without, NULL, NULL), 0);
        snprintf(path, sizeof path, "%s/results.csv", out);
        CHECK_MSG(exists(path), "%s missing", path);
        snprintf(path, sizeof path, "%s/README.md", rep);
        char *readme = test_slurp(path, NULL);
        CHECK_MSG(readme != NULL, "%s missing", path);
        if (readme) {
            CHECK(strstr(readme, "Table 5.4") != NULL);
            const int has = strstr(readme, "Table 5.5") != NULL;
            CHECK_MSG(has == hybrid, "hybrid %d: the Table 5.5 section is %s", hybrid, has ? "there" : "missing");
            if (hybrid)
                CHECK(strstr(readme, "12.63") && strstr(readme, "5.07"));
        }
        free(readme);
        snprintf(path, sizeof path, "%s/hybrid.csv", out);
        CHECK_MSG(exists(path) == hybrid, "hybrid %d: hybrid.csv %s", hybrid, exists(path) ? "written" : "missing");
    }
}

TEST(cli_study_volume_bad_flags_are_usage_errors_and_write_nothing)
{
    const char *dir = test_tmpdir();
    char out[1024], err[1100];
    snprintf(out, sizeof out, "%s/svbad", dir);
    snprintf(err, sizeof err, "%s/svbad.err", dir);
    const char *samples[] = {"study", "volume", "--quick", "--ref-samples", "7", "-o", out, NULL};
    const char *unknown[] = {"study", "volume", "--quick", "--no-such-flag", "-o", out, NULL};
    const char *nodata[] = {"study", "volume", "--quick", "--data", NULL};
    const char *only[] = {"study", "volume", "--quick", "--report-only", "-o", out, NULL};
    const char *const *cases[] = {samples, unknown, nodata, only};
    const char *names[] = {"--ref-samples", "--no-such-flag", "--data", "--report-only"};
    for (int k = 0; k < 4; k++) {
        CHECK_EQ_INT(test_spawn(OBS_CLI_PATH, cases[k], NULL, err), 2);
        char *e = test_slurp(err, NULL);
        CHECK_MSG(e && strstr(e, names[k]), "the error does not name %s: %s", names[k], e ? e : "");
        free(e);
    }
    CHECK_MSG(!exists(out), "%s was created by a refused command", out);
}
