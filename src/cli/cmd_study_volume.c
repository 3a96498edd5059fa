/* cmd_study_volume.c: `obscura study volume`: parse the flags into study_volume_options and drive
 * the study library (src/study/study_volume.h): open, then the sweep and/or the report.
 * docs/volume/truth.md, "The study". Dispatched from cmd_study.c. */
#include "cli.h"
#include "study/study_volume.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cmd_study_volume(cli_globals *g, int argc, char **argv);

static const char *study_volume_help =
    "usage: obscura study volume [--quick] [-o DIR] [--report DIR] [options]\n"
    "Ropinski's light volume and the ray caster: time per stage and error against the exact\n"
    "transmittance (l) and the Monte Carlo single-scattering image reference (docs/volume/truth.md).\n"
    "  --quick                a reduced sweep for CI: bucky 32^3, scales 1,2,4, cone 45, blend 0,1,\n"
    "                         step 0.5, 64x64, 128 reference samples (seconds)\n"
    "  -o, --out DIR          DIR/results.csv and results.json (default out/study-volume); points\n"
    "                         already there are not redone\n"
    "  --report DIR           also write DIR/README.md, DIR/error_vs_time.svg, DIR/results.csv\n"
    "  --datasets LIST        bucky, cranium, mri (default all three; a missing file is skipped)\n"
    "  --volumes DIR          where cranium.nrrd and ch2better.nii.gz are (default data/cache/volumes,\n"
    "                         scripts/fetch_volumes.sh)\n"
    "  --scales LIST          light-volume scales 1,2,4 (default all)\n"
    "  --cones LIST           cone half-angles in degrees (default 22.5,45,67.5)\n"
    "  --blends LIST          0,1 (default both)\n"
    "  --steps LIST           ray-caster steps x the smallest spacing (default 0.25,0.5,1)\n"
    "  --size WxH             image size (default 256x256)\n"
    "  --runs N               timed runs per stage (default 3; the median is reported)\n"
    "  --ref-samples N        MC reference samples per pixel, a multiple of 8 (default 256)\n"
    "  --dry-run              print the number of points, measure nothing\n"
    "  --report-only          write the --report from DIR/results.csv, measure nothing\n";

int cmd_study_volume(cli_globals *g, int argc, char **argv)
{
    if (argc < 3) {
        fputs(study_volume_help, stderr);
        return cli_usage_error("study volume: give -o DIR, or --quick");
    }
    int quick = 0;
    for (int i = 2; i < argc; i++)
        quick |= !strcmp(argv[i], "--quick");
    study_volume_options o = quick ? study_volume_options_quick() : study_volume_options_default();
    int dry_run = 0, report_only = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_volume_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--quick")) {
            continue;
        } else if (!strcmp(a, "--dry-run")) {
            dry_run = 1;
        } else if (!strcmp(a, "--report-only")) {
            report_only = 1;
        } else if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && v) {
            o.out_dir = v, i++;
        } else if (!strcmp(a, "--report") && v) {
            o.report_dir = v, i++;
        } else if (!strcmp(a, "--datasets") && v) {
            o.datasets = v, i++;
        } else if (!strcmp(a, "--volumes") && v) {
            o.volume_dir = v, i++;
        } else if (!strcmp(a, "--scales") && v) {
            o.scales = v, i++;
        } else if (!strcmp(a, "--cones") && v) {
            o.cones = v, i++;
        } else if (!strcmp(a, "--blends") && v) {
            o.blends = v, i++;
        } else if (!strcmp(a, "--steps") && v) {
            o.steps = v, i++;
        } else if (!strcmp(a, "--size") && v) {
            o.size = v, i++;
        } else if (!strcmp(a, "--runs")) {
            if (!cli_parse_int(v, 1, 64, &ll))
                return cli_usage_error("--runs needs an integer in [1, 64]");
            o.runs = (int)ll, i++;
        } else if (!strcmp(a, "--ref-samples")) {
            if (!cli_parse_int(v, 8, 1 << 20, &ll) || ll % 8 != 0)
                return cli_usage_error("--ref-samples needs a multiple of 8 in [8, 1048576]");
            o.ref_samples = ll, i++;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r > 0)
                continue;
            return cli_usage_error("study volume: unknown option '%s' (or a missing value)", a);
        }
    }
    if (report_only && !o.report_dir)
        return cli_usage_error("study volume: --report-only needs --report DIR");
    if (report_only && dry_run)
        return cli_usage_error("study volume: --report-only and --dry-run exclude each other");
    o.log = g->quiet ? NULL : stderr;
    char cmdline[2048];
    {
        size_t n = (size_t)snprintf(cmdline, sizeof cmdline, "obscura study volume");
        for (int i = 2; i < argc && n < sizeof cmdline; i++)
            n += (size_t)snprintf(cmdline + n, sizeof cmdline - n, " %s", argv[i]);
        o.command_line = cmdline;
    }

    obs_context *ctx = obs_context_create();
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    int code = CLI_EXIT_OK;
    study_volume *s = NULL;
    obs_status st = study_volume_open(ctx, &o, &s);
    if (st == OBS_STATUS_INVALID_ARGUMENT) {
        code = cli_usage_error("%s", obs_context_last_error(ctx));
        obs_context_destroy(ctx);
        return code;
    }
    obs_pool *pool = st == OBS_STATUS_OK ? obs_pool_create(g->threads) : NULL;
    if (st == OBS_STATUS_OK && !pool)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: cannot create the thread pool");
    if (st == OBS_STATUS_OK && dry_run) {
        int present = 0;
        long long n = (long long)study_volume_points(s, &present);
        printf("study volume: %lld points over %d dataset%s present, %d runs each\n", n, present,
               present == 1 ? "" : "s", o.runs);
    } else if (st == OBS_STATUS_OK) {
        if (!report_only)
            st = study_volume_sweep(ctx, pool, s);
        if (st == OBS_STATUS_OK && o.report_dir)
            st = study_volume_report(ctx, s);
        if (st == OBS_STATUS_OK && !g->quiet)
            fprintf(stderr, "obscura: study volume: %lld points in %s/results.csv%s%s\n",
                    (long long)study_volume_table(s)->rows, o.out_dir, o.report_dir ? ", report in " : "",
                    o.report_dir ? o.report_dir : "");
    }
    if (st != OBS_STATUS_OK)
        code = cli_fail(ctx, st);
    study_volume_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    return code;
}
