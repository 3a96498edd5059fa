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
    int quick = 0;
    for (int i = 2; i < argc; i++)
        quick |= !strcmp(argv[i], "--quick");
    study_ao_options o = quick ? study_ao_options_quick() : study_ao_options_default();
    o.data_dir = OBS_STUDY_DATA_DIR;
    int dry_run = 0, truth_only = 0, report_only = 0, shard_given = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--shard")) {
            if (!study_shard_parse(v, &o.shard, &o.shards))
                return cli_usage_error("--shard needs K/N with 1 <= K <= N");
            shard_given = 1, i++;
        } else if (!strcmp(a, "--gt-dir") && v) {
            o.gt_dir = v, i++;
        } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--quick")) {
            continue;
        } else if (!strcmp(a, "--dry-run")) {
            dry_run = 1;
        } else if (!strcmp(a, "--truth-only")) {
            truth_only = 1;
        } else if (!strcmp(a, "--report-only")) {
            report_only = 1;
        } else if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && v) {
            o.out_dir = v, i++;
        } else if (!strcmp(a, "--report") && v) {
            o.report_dir = v, i++;
        } else if (!strcmp(a, "--data") && v) {
            o.data_dir = v, i++;
        } else if (!strcmp(a, "--scenes") && v) {
            o.scenes = v, i++;
        } else if (!strcmp(a, "--views") && v) {
            o.views = v, i++;
        } else if (!strcmp(a, "--methods") && v) {
            o.methods = v, i++;
        } else if (!strcmp(a, "--resolutions") && v) {
            o.resolutions = v, i++;
        } else if (!strcmp(a, "--samples") && v) {
            o.samples = v, i++;
        } else if (!strcmp(a, "--radii") && v) {
            o.radii = v, i++;
        } else if (!strcmp(a, "--blur") && v) {
            o.blurs = v, i++;
        } else if (!strcmp(a, "--budgets") && v) {
            o.budgets = v, i++;
        } else if (!strcmp(a, "--runs")) {
            if (!cli_parse_int(v, 1, 64, &ll))
                return cli_usage_error("--runs needs an integer in [1, 64]");
            o.runs = (int)ll, i++;
        } else if (!strcmp(a, "--gt-max-samples")) {
            if (!cli_parse_int(v, 32, 1 << 20, &ll) || ll % 16 != 0)
                return cli_usage_error("--gt-max-samples needs a multiple of 16 in [32, 1048576]");
            o.gt_max_samples = ll, i++;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r > 0)
                continue;
            return cli_usage_error("study ao: unknown option '%s' (or a missing value)", a);
        }
    }
    if (report_only && !o.report_dir)
        return cli_usage_error("study ao: --report-only needs --report DIR");
    if (report_only + truth_only + dry_run > 1)
        return cli_usage_error("study ao: --report-only, --truth-only and --dry-run exclude each other");
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

    obs_context *ctx = obs_context_create();
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    int code = CLI_EXIT_OK;
    study_ao *s = NULL;
    obs_status st = study_ao_open(ctx, &o, &s);
    if (st == OBS_STATUS_INVALID_ARGUMENT) { /* a bad list, technique, size, ...: a usage error */
        code = cli_usage_error("%s", obs_context_last_error(ctx));
        obs_context_destroy(ctx);
        return code;
    }
    obs_pool *pool = st == OBS_STATUS_OK ? obs_pool_create(g->threads) : NULL;
    if (st == OBS_STATUS_OK && !pool)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study ao: cannot create the thread pool");
    if (st == OBS_STATUS_OK && dry_run) {
        const study_ao_plan p = study_ao_plan_of(s);
        if (!g->quiet)
            fprintf(stderr,
                    "obscura: study ao: %lld points (%d scenes x %d views x %d resolutions x %d methods x %d samples "
                    "x %d radii x %d blur), %d timed runs each, %d threads\n",
                    (long long)p.points, p.scenes, p.views, p.resolutions, p.methods, p.samples, p.radii, p.blurs,
                    p.runs, obs_pool_threads(pool));
        printf("expected duration: sweep %.0f-%.0f min, ground truth %.0f-%.0f min (first run; cached after)\n",
               p.sweep_min_lo, p.sweep_min_hi, p.truth_min_lo, p.truth_min_hi);
    } else if (st == OBS_STATUS_OK) {
        if (truth_only)
            st = study_ao_truth(ctx, pool, s);
        else if (!report_only)
            st = study_ao_sweep(ctx, pool, s);
        if (st == OBS_STATUS_OK && o.report_dir && !truth_only)
            st = study_ao_report(ctx, pool, s);
        if (st == OBS_STATUS_OK && !g->quiet)
            fprintf(stderr, "obscura: study ao: %lld points in %s/results.csv%s%s\n",
                    (long long)study_ao_table(s)->rows, o.out_dir, o.report_dir ? ", report in " : "",
                    o.report_dir ? o.report_dir : "");
    }
    if (st != OBS_STATUS_OK)
        code = cli_fail(ctx, st);
    study_ao_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    return code;
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
    int quick = 0;
    for (int i = 2; i < argc; i++)
        quick |= !strcmp(argv[i], "--quick");
    study_sss_options o = quick ? study_sss_options_quick() : study_sss_options_default();
    o.data_dir = OBS_STUDY_DATA_DIR;
    int dry_run = 0, truth_only = 0, report_only = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(study_sss_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--quick")) {
            continue;
        } else if (!strcmp(a, "--dry-run")) {
            dry_run = 1;
        } else if (!strcmp(a, "--truth-only")) {
            truth_only = 1;
        } else if (!strcmp(a, "--report-only")) {
            report_only = 1;
        } else if (!strcmp(a, "--no-seed-points")) {
            o.seed_points = 0;
        } else if ((!strcmp(a, "-o") || !strcmp(a, "--out")) && v) {
            o.out_dir = v, i++;
        } else if (!strcmp(a, "--report") && v) {
            o.report_dir = v, i++;
        } else if (!strcmp(a, "--data") && v) {
            o.data_dir = v, i++;
        } else if (!strcmp(a, "--scenes") && v) {
            o.scenes = v, i++;
        } else if (!strcmp(a, "--lights") && v) {
            o.lights = v, i++;
        } else if (!strcmp(a, "--resolutions") && v) {
            o.resolutions = v, i++;
        } else if (!strcmp(a, "--samplers") && v) {
            o.samplers = v, i++;
        } else if (!strcmp(a, "--K") && v) {
            o.Ks = v, i++;
        } else if (!strcmp(a, "--N") && v) {
            o.Ns = v, i++;
        } else if (!strcmp(a, "--map-sizes") && v) {
            o.map_sizes = v, i++;
        } else if (!strcmp(a, "--runs")) {
            if (!cli_parse_int(v, 1, 64, &ll))
                return cli_usage_error("--runs needs an integer in [1, 64]");
            o.runs = (int)ll, i++;
        } else if (!strcmp(a, "--ref-samples")) {
            if (!cli_parse_int(v, 64, 1 << 20, &ll) || ll % 64 != 0)
                return cli_usage_error("--ref-samples needs a multiple of 64 in [64, 1048576]");
            o.ref_samples = ll, i++;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r > 0)
                continue;
            return cli_usage_error("study sss: unknown option '%s' (or a missing value)", a);
        }
    }
    if (report_only && !o.report_dir)
        return cli_usage_error("study sss: --report-only needs --report DIR");
    if (report_only + truth_only + dry_run > 1)
        return cli_usage_error("study sss: --report-only, --truth-only and --dry-run exclude each other");
    o.log = g->quiet ? NULL : stderr;

    obs_context *ctx = obs_context_create();
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    int code = CLI_EXIT_OK;
    study_sss *s = NULL;
    obs_status st = study_sss_open(ctx, &o, &s);
    if (st == OBS_STATUS_INVALID_ARGUMENT) {
        code = cli_usage_error("%s", obs_context_last_error(ctx));
        obs_context_destroy(ctx);
        return code;
    }
    obs_pool *pool = st == OBS_STATUS_OK ? obs_pool_create(g->threads) : NULL;
    if (st == OBS_STATUS_OK && !pool)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study sss: cannot create the thread pool");
    if (st == OBS_STATUS_OK && dry_run) {
        const study_sss_plan p = study_sss_plan_of(s);
        printf("study sss: %lld points (%d scenes x %d lights x %d resolutions; K %d, N %d, map sizes %d values, "
               "plus the seed's points), %d runs each\n",
               (long long)p.points, p.scenes, p.lights, p.resolutions, p.Ks, p.Ns, p.map_sizes, p.runs);
        printf("expected duration on 2 cores: sweep about %.0f min, references about %.0f min (first run; cached after)\n",
               p.sweep_min, p.ref_min);
    } else if (st == OBS_STATUS_OK) {
        if (truth_only)
            st = study_sss_truth(ctx, pool, s);
        else if (!report_only)
            st = study_sss_sweep(ctx, pool, s);
        if (st == OBS_STATUS_OK && o.report_dir && !truth_only)
            st = study_sss_report(ctx, pool, s);
        if (st == OBS_STATUS_OK && !g->quiet)
            fprintf(stderr, "obscura: study sss: %lld points in %s/results.csv%s%s\n",
                    (long long)study_sss_table(s)->rows, o.out_dir, o.report_dir ? ", report in " : "",
                    o.report_dir ? o.report_dir : "");
    }
    if (st != OBS_STATUS_OK)
        code = cli_fail(ctx, st);
    study_sss_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    return code;
}
