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
    "  --no-hybrid            skip the hybrid stage (the seed's Table 5.5: cornell_hybrid.glb with\n"
    "                         bucky or the head CT, and the bunny or the dragon; DIR/hybrid.csv)\n"
    "  --data DIR             where cornell_hybrid.glb and dragon.glb are (default the build's data)\n"
    "  --dry-run              print the number of points, measure nothing\n"
    "  --report-only          write the --report from DIR/results.csv, measure nothing\n";

/* study_volume's steps for cli_study_main (no --truth-only: the references are part of the sweep). */
static obs_status volume_open(obs_context *ctx, const void *o, void **s)
{
    study_volume *p = NULL;
    const obs_status st = study_volume_open(ctx, (const study_volume_options *)o, &p);
    *s = p;
    return st;
}
static void volume_plan(const void *s, const void *o, const cli_globals *g, obs_pool *pool)
{
    (void)g, (void)pool;
    int present = 0;
    long long n = (long long)study_volume_points((const study_volume *)s, &present);
    printf("study volume: %lld points over %d dataset%s present, %d runs each\n", n, present,
           present == 1 ? "" : "s", ((const study_volume_options *)o)->runs);
}
static obs_status volume_sweep(obs_context *ctx, obs_pool *pool, void *s)
{
    return study_volume_sweep(ctx, pool, (study_volume *)s);
}
static obs_status volume_report(obs_context *ctx, obs_pool *pool, void *s)
{
    (void)pool;
    return study_volume_report(ctx, (study_volume *)s);
}
static long long volume_rows(const void *s) { return (long long)study_volume_table((const study_volume *)s)->rows; }
static void volume_close(void *s) { study_volume_close((study_volume *)s); }
static const cli_study_steps volume_steps = {"study volume", volume_open,   volume_plan, NULL,
                                             volume_sweep,   volume_report, volume_rows, volume_close};

int cmd_study_volume(cli_globals *g, int argc, char **argv)
{
    if (argc < 3) {
        fputs(study_volume_help, stderr);
        return cli_usage_error("study volume: give -o DIR, or --quick");
    }
    study_volume_options o =
        cli_has_flag(argc, argv, 2, "--quick") ? study_volume_options_quick() : study_volume_options_default();
    cli_study_run run = {0, 0, 0};
    const cli_string_flag strings[] = {
        {"-o", &o.out_dir},        {"--out", &o.out_dir},     {"--report", &o.report_dir},
        {"--datasets", &o.datasets}, {"--volumes", &o.volume_dir}, {"--scales", &o.scales},
        {"--cones", &o.cones},     {"--blends", &o.blends},   {"--steps", &o.steps},
        {"--size", &o.size},       {"--data", &o.data_dir},   {NULL, NULL}};
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_volume_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--no-hybrid")) {
            o.no_hybrid = 1;
        } else if (!strcmp(a, "--ref-samples")) {
            if (!cli_parse_int(v, 8, 1 << 20, &ll) || ll % 8 != 0)
                return cli_usage_error("--ref-samples needs a multiple of 8 in [8, 1048576]");
            o.ref_samples = ll, i++;
        } else if (cli_study_flags(g, "study volume", &run, 0, &o.runs, strings, argc, argv, &i)) {
            return CLI_EXIT_USAGE;
        }
    }
    if (cli_study_check("study volume", 0, &run, o.report_dir))
        return CLI_EXIT_USAGE;
    o.log = g->quiet ? NULL : stderr;
    char cmdline[2048];
    {
        size_t n = (size_t)snprintf(cmdline, sizeof cmdline, "obscura study volume");
        for (int i = 2; i < argc && n < sizeof cmdline; i++)
            n += (size_t)snprintf(cmdline + n, sizeof cmdline - n, " %s", argv[i]);
        o.command_line = cmdline;
    }
    return cli_study_main(g, &volume_steps, &o, &run, o.out_dir, o.report_dir);
}
