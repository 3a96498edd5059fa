/* cmd_study.c: `obscura study ao` and `obscura study sss`: parse the flags into study_ao_options
 * or study_sss_options and drive the study libraries (src/study/study_ao.h, study_sss.h): open,
 * then the dry run, the references only, the sweep and/or the report. Everything a study does is
 * in its library; docs/study.md. */
#include "cli.h"
#include "study/study_ao.h"
#include "study/study_sss.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *study_help =
    "usage: obscura study ao [--quick] [-o DIR] [--report DIR] [options]\n"
    "       obscura study sss --help   (the subsurface-scattering study)\n"
    "Sweeps every AO technique and measures time per pass and error against its matched ground truth.\n"
    "  --quick                a small sweep for CI (the bunny, 192x108, 8 samples, radius 1 unit)\n"
    "  -o, --out DIR          results: DIR/results.csv, DIR/results.json, ground truth cache DIR/gt/\n"
    "                         (default out/study-ao); points already in results.csv are not redone\n"
    "  --report DIR           also write DIR/README.md with plots (SVG), image grids (PNG) and tables\n"
    "  --scenes LIST          comma-separated names from the study set (default: dragon_plane,village,room,bunny)\n"
    "  --views LIST           cameras (default: default,view2)\n"
    "  --methods LIST         techniques (default: every registered one, see 'obscura ao --list')\n"
    "  --resolutions LIST     e.g. 3840x2160,1920x1080,1280x720 (the default)\n"
    "  --samples LIST         samples per pixel (GTAO: slices x steps), default 4,8,16,32\n"
    "  --radii LIST           radius in scene units, default 0.5,1,1.5,2\n"
    "  --blur LIST            0,1 (default both)\n"
    "  --runs N               timed runs per point (default 5; the median is reported)\n"
    "  --gt-max-samples N     ground truth: samples per pixel at most at 1280x720 or less (default 256);\n"
    "                         larger images get it scaled by 921600 / pixels (1080p 112, 4K 32)\n"
    "  --budgets LIST         frame budgets in ms for the summary and the grids (default 1,2,4,8)\n"
    "  --data DIR             where the scenes are (default: the build's data directory)\n"
    "  --dry-run              print the points and the expected duration, measure nothing\n"
    "  --truth-only           compute (and cache) the ground truths the points need, measure nothing\n"
    "  --report-only          write the --report from DIR/results.csv as it is, measure nothing (the\n"
    "                         axes given still choose the tables' rows and columns)\n"
    "  --shard K/N            run only the K-th of N interleaved slices of the points, into\n"
    "                         DIR/shard-K-of-N/ (default: from SLURM_ARRAY_TASK_ID, _MIN and _COUNT when\n"
    "                         set); the ground truths go to the cache shared by the shards, DIR/gt/\n"
    "  --gt-dir DIR           the ground-truth cache (default OUT/gt; content-hashed names, a lock per\n"
    "                         frame: shards on a shared file system compute each ground truth once)\n"
    "       obscura study merge SHARD_DIR... -o DIR [--report DIR]\n"
    "                         merge shard tables (same configuration and version) into DIR/results.csv,\n"
    "                         in a single run's order; docs/scale.md\n";

#ifndef OBS_STUDY_DATA_DIR
#define OBS_STUDY_DATA_DIR "build/data"
#endif

static int cmd_study_sss(cli_globals *g, int argc, char **argv);
int cmd_study_volume(cli_globals *g, int argc, char **argv); /* cmd_study_volume.c */

/* `obscura study merge SHARD_DIR... -o DIR [--report DIR] [--data DIR]` (docs/scale.md). */
static int cmd_study_merge(cli_globals *g, int argc, char **argv)
{
    const char *out = NULL, *report = NULL, *data = OBS_STUDY_DATA_DIR;
    const char **dirs = (const char **)calloc((size_t)argc + 1, sizeof *dirs);
    int n = 0;
    if (!dirs)
        return CLI_EXIT_INTERNAL;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && v)
            out = v, i++;
        else if (!strcmp(a, "--report") && v)
            report = v, i++;
        else if (!strcmp(a, "--data") && v)
            data = v, i++;
        else if (a[0] == '-') {
            free(dirs);
            return cli_usage_error("study merge: unknown option '%s' (or a missing value)", a);
        } else
            dirs[n++] = a;
    }
    if (!out || n < 1) {
        free(dirs);
        return cli_usage_error("study merge: give the shard directories and -o DIR");
    }
    obs_context *ctx = obs_context_create();
    if (!ctx) {
        free(dirs);
        return CLI_EXIT_INTERNAL;
    }
    obs_context_set_limits(ctx, &g->limits);
    obs_pool *pool = report ? obs_pool_create(g->threads) : NULL;
    obs_status st = study_ao_merge(ctx, pool, dirs, n, out, report, data, g->quiet ? NULL : stderr);
    int code = CLI_EXIT_OK;
    if (st == OBS_STATUS_INVALID_ARGUMENT)
        code = (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_INPUT);
    else if (st != OBS_STATUS_OK)
        code = cli_fail(ctx, st);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    free(dirs);
    return code;
}

/* ---- the study libraries' steps for cli_study_main ---------------------------------------------- */

static obs_status ao_open(obs_context *ctx, const void *o, void **s)
{
    study_ao *p = NULL;
    const obs_status st = study_ao_open(ctx, (const study_ao_options *)o, &p);
    *s = p;
    return st;
}
static void ao_plan(const void *s, const void *o, const cli_globals *g, obs_pool *pool)
{
    (void)o;
    const study_ao_plan p = study_ao_plan_of((const study_ao *)s);
    if (!g->quiet)
        fprintf(stderr,
                "obscura: study ao: %lld points (%d scenes x %d views x %d resolutions x %d methods x %d samples "
                "x %d radii x %d blur), %d timed runs each, %d threads\n",
                (long long)p.points, p.scenes, p.views, p.resolutions, p.methods, p.samples, p.radii, p.blurs,
                p.runs, obs_pool_threads(pool));
    printf("expected duration: sweep %.0f-%.0f min, ground truth %.0f-%.0f min (first run; cached after)\n",
           p.sweep_min_lo, p.sweep_min_hi, p.truth_min_lo, p.truth_min_hi);
}
static obs_status ao_truth(obs_context *ctx, obs_pool *pool, void *s) { return study_ao_truth(ctx, pool, (study_ao *)s); }
static obs_status ao_sweep(obs_context *ctx, obs_pool *pool, void *s) { return study_ao_sweep(ctx, pool, (study_ao *)s); }
static obs_status ao_report(obs_context *ctx, obs_pool *pool, void *s) { return study_ao_report(ctx, pool, (study_ao *)s); }
static long long ao_rows(const void *s) { return (long long)study_ao_table((const study_ao *)s)->rows; }
static void ao_close(void *s) { study_ao_close((study_ao *)s); }
static const cli_study_steps ao_steps = {"study ao", ao_open, ao_plan, ao_truth, ao_sweep, ao_report, ao_rows, ao_close};

static obs_status sss_open(obs_context *ctx, const void *o, void **s)
{
    study_sss *p = NULL;
    const obs_status st = study_sss_open(ctx, (const study_sss_options *)o, &p);
    *s = p;
    return st;
}
static void sss_plan(const void *s, const void *o, const cli_globals *g, obs_pool *pool)
{
    (void)o, (void)g, (void)pool;
    const study_sss_plan p = study_sss_plan_of((const study_sss *)s);
    printf("study sss: %lld points (%d scenes x %d lights x %d resolutions; K %d, N %d, map sizes %d values, "
           "plus the seed's points), %d runs each\n",
           (long long)p.points, p.scenes, p.lights, p.resolutions, p.Ks, p.Ns, p.map_sizes, p.runs);
    printf("expected duration on 2 cores: sweep about %.0f min, references about %.0f min (first run; cached after)\n",
           p.sweep_min, p.ref_min);
}
static obs_status sss_truth(obs_context *ctx, obs_pool *pool, void *s) { return study_sss_truth(ctx, pool, (study_sss *)s); }
static obs_status sss_sweep(obs_context *ctx, obs_pool *pool, void *s) { return study_sss_sweep(ctx, pool, (study_sss *)s); }
static obs_status sss_report(obs_context *ctx, obs_pool *pool, void *s)
{
    return study_sss_report(ctx, pool, (study_sss *)s);
}
static long long sss_rows(const void *s) { return (long long)study_sss_table((const study_sss *)s)->rows; }
static void sss_close(void *s) { study_sss_close((study_sss *)s); }
static const cli_study_steps sss_steps = {"study sss", sss_open,   sss_plan, sss_truth,
                                          sss_sweep,   sss_report, sss_rows, sss_close};

int cmd_study(cli_globals *g, int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "sss"))
        return cmd_study_sss(g, argc, argv);
    if (argc >= 2 && !strcmp(argv[1], "volume"))
        return cmd_study_volume(g, argc, argv);
    if (argc >= 2 && !strcmp(argv[1], "merge"))
        return cmd_study_merge(g, argc, argv);
    if (argc < 2 || strcmp(argv[1], "ao") != 0) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            fputs(study_help, stdout);
            return CLI_EXIT_OK;
        }
        fputs(study_help, stderr);
        return argc < 2 ? CLI_EXIT_USAGE : cli_usage_error("study: unknown study '%s' (ao or sss)", argv[1]);
    }
    /* --quick chooses the starting point; flags given explicitly override it wherever they stand */
    study_ao_options o = cli_has_flag(argc, argv, 2, "--quick") ? study_ao_options_quick() : study_ao_options_default();
    o.data_dir = OBS_STUDY_DATA_DIR;
    cli_study_run run = {0, 0, 0};
    int shard_given = 0;
    const cli_string_flag strings[] = {
        {"--gt-dir", &o.gt_dir},   {"-o", &o.out_dir},        {"--out", &o.out_dir},
        {"--report", &o.report_dir}, {"--data", &o.data_dir}, {"--scenes", &o.scenes},
        {"--views", &o.views},     {"--methods", &o.methods}, {"--resolutions", &o.resolutions},
        {"--samples", &o.samples}, {"--radii", &o.radii},     {"--blur", &o.blurs},
        {"--budgets", &o.budgets}, {NULL, NULL}};
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--shard")) {
            if (!study_shard_parse(v, &o.shard, &o.shards))
                return cli_usage_error("--shard needs K/N with 1 <= K <= N");
            shard_given = 1, i++;
        } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--gt-max-samples")) {
            if (!cli_parse_int(v, 32, 1 << 20, &ll) || ll % 16 != 0)
                return cli_usage_error("--gt-max-samples needs a multiple of 16 in [32, 1048576]");
            o.gt_max_samples = ll, i++;
        } else if (cli_study_flags(g, "study ao", &run, 1, &o.runs, strings, argc, argv, &i)) {
            return CLI_EXIT_USAGE;
        }
    }
    if (cli_study_check("study ao", 1, &run, o.report_dir))
        return CLI_EXIT_USAGE;
    o.log = g->quiet ? NULL : stderr;
    /* A shard (--shard, or a Slurm array task) writes its own table in OUT/shard-K-of-N and shares
     * the ground-truth cache OUT/gt with the other shards (docs/scale.md). */
    char shard_out[4200], shard_gt[4200];
    if (!shard_given)
        study_shard_from_env(&o.shard, &o.shards);
    if (o.shards > 1) {
        snprintf(shard_gt, sizeof shard_gt, "%s/gt", o.out_dir);
        if (!o.gt_dir)
            o.gt_dir = shard_gt;
        snprintf(shard_out, sizeof shard_out, "%s/shard-%d-of-%d", o.out_dir, o.shard, o.shards);
        o.out_dir = shard_out;
        if (o.log)
            fprintf(o.log, "obscura: study ao: shard %d of %d into %s (ground truths in %s)\n", o.shard, o.shards,
                    o.out_dir, o.gt_dir);
    }
    return cli_study_main(g, &ao_steps, &o, &run, o.out_dir, o.report_dir);
}

/* ---- obscura study sss ------------------------------------------------------------------------ */

static const char *study_sss_help =
    "usage: obscura study sss [--quick] [-o DIR] [--report DIR] [options]\n"
    "Times the scattering maps (light G-buffers, maps, combination) and measures their error against\n"
    "the brute-force BSSRDF integral (the method's) and the random walk (the model's); docs/study.md.\n"
    "  --quick                a small sweep for CI (the sphere, 64x48, K 4, N 16, maps 64, 1024 candidates)\n"
    "  -o, --out DIR          results: DIR/results.csv, DIR/results.json, reference cache DIR/ref/\n"
    "                         (default out/study-sss); points already in results.csv are not redone\n"
    "  --report DIR           also write DIR/README.md with plots (SVG), image grids (PNG) and tables\n"
    "  --scenes LIST          default bunny_cream,dragon_skin,armadillo_marble,sphere_potato\n"
    "  --lights LIST          front (the scene's key light) and/or behind (its opposite); default both\n"
    "  --resolutions LIST     default 320x240\n"
    "  --samplers LIST        the maps' disk samplers (the technique axis), default russian-roulette\n"
    "  --K LIST               scattering-map directions, default 4,8,16,32\n"
    "  --N LIST               samples per texel, default 16,48,128\n"
    "  --map-sizes LIST       scattering-map side, default 256,512,1024\n"
    "  --no-seed-points       leave out the seed's Table 5.3 points (K 4, 8, 16 with N 12, 24, 48 at 512)\n"
    "  --runs N               timed runs per point (default 3; the median is reported)\n"
    "  --ref-samples N        candidates per pixel of both references, a multiple of 64 (default 16384)\n"
    "  --data DIR             where the scenes are (default: the build's data directory)\n"
    "  --dry-run              print the points and the expected duration, measure nothing\n"
    "  --truth-only           compute (and cache) the references, measure nothing\n"
    "  --report-only          write the --report from DIR/results.csv as it is\n";

static int cmd_study_sss(cli_globals *g, int argc, char **argv)
{
    /* The full study takes hours: a bare `obscura study sss` prints the usage instead of starting it */
    if (argc < 3) {
        fputs(study_sss_help, stderr);
        return cli_usage_error("study sss: give -o DIR (the full study takes hours: --dry-run says how long), or --quick");
    }
    study_sss_options o =
        cli_has_flag(argc, argv, 2, "--quick") ? study_sss_options_quick() : study_sss_options_default();
    o.data_dir = OBS_STUDY_DATA_DIR;
    cli_study_run run = {0, 0, 0};
    const cli_string_flag strings[] = {
        {"-o", &o.out_dir},          {"--out", &o.out_dir},           {"--report", &o.report_dir},
        {"--data", &o.data_dir},     {"--scenes", &o.scenes},         {"--lights", &o.lights},
        {"--resolutions", &o.resolutions}, {"--samplers", &o.samplers}, {"--K", &o.Ks},
        {"--N", &o.Ns},              {"--map-sizes", &o.map_sizes},   {NULL, NULL}};
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_sss_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--no-seed-points")) {
            o.seed_points = 0;
        } else if (!strcmp(a, "--ref-samples")) {
            if (!cli_parse_int(v, 64, 1 << 20, &ll) || ll % 64 != 0)
                return cli_usage_error("--ref-samples needs a multiple of 64 in [64, 1048576]");
            o.ref_samples = ll, i++;
        } else if (cli_study_flags(g, "study sss", &run, 1, &o.runs, strings, argc, argv, &i)) {
            return CLI_EXIT_USAGE;
        }
    }
    if (cli_study_check("study sss", 1, &run, o.report_dir))
        return CLI_EXIT_USAGE;
    o.log = g->quiet ? NULL : stderr;
    return cli_study_main(g, &sss_steps, &o, &run, o.out_dir, o.report_dir);
}
