/* cmd_truth_sss.c: `obscura truth sss SCENE`: the two SSS ground truths (docs/sss/truth.md) for a
 * glTF scene seen through one of its cameras: the brute-force BSSRDF integral (the method's
 * reference: the same BSSRDF as the scattering maps) and the volumetric random walk (the model's
 * reference), each as an EXR layer with its error bars, a PNG each, and a JSON sidecar. */
#include "cli_sss.h"
#include "scale/scale.h"
#include "truth/truth.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *truth_sss_help_head =
    "usage: obscura truth sss SCENE [options] -o PREFIX\n";
static const char *truth_sss_help =
    "references:\n"
    "  --reference NAME      both (default), brute-force (the BSSRDF integrated over the lit surface:\n"
    "                        isolates the scattering maps' error) or random-walk (radiative transfer in\n"
    "                        the closed mesh: measures the dipole model's error; refuses open meshes)\n"
    "  --model NAME          the brute force's BSSRDF: directional (default) or standard\n"
    "  --target-error E      stop a pixel when its luminance's standard error <= E x luminance (default 0.01)\n"
    "  --min-samples N       entry candidates per pixel before the target may stop it (default 16384)\n"
    "  --max-samples N       at most (default 1048576; the global --max-spp limits it)\n"
    "  --batch B             candidates per round, a multiple of the replicates (default 4096)\n"
    "  --replicates R        independent replicates for the error bar, 2..32 (default 8)\n"
    "  --patch-radius RHO    random walk: the exit patch's radius, scene units (default 0: half the\n"
    "                        smallest reduced mean free path of the scene's materials; docs/sss/truth.md)\n"
    "  --seed S              random seed (default 0)\n"
    "view and output:\n"
    "  --camera NAME|INDEX   camera (default: 'default', else the first, else a framing one)\n"
    "  --size WxH            image size (default 1920x1080, or 1920 wide at the camera's aspect)\n"
    "  --exposure E          PNGs only: multiply by E before the sRGB encoding (default 1)\n"
    "  -o, --output PREFIX   PREFIX.exr (layers brute.R/G/B, brute.stderr.R/G/B, brute.count, the\n"
    "                        same for walk, Z), PREFIX_brute.png, PREFIX_walk.png, PREFIX.json\n"
    "                        (default prefix: truth_sss)\n"
    "Under MPI (mpirun -np N obscura truth sss ...), the tiles are dealt over the ranks and rank 0\n"
    "gathers and writes the same files as one process, byte for byte, with a 'scale' object in the\n"
    "sidecar (docs/scale.md); OBS_NO_MPI=1 runs each rank as a plain process.\n";

typedef struct ref_run {
    const char *tag;               /* "brute" or "walk" */
    truth_sss_estimator estimator;
    int wanted;
    truth_sss_result res;
    double seconds;
} ref_run;

/* Half the smallest reduced mean free path 1/sigma_t' over the translucent materials and
 * channels, in scene units: the random walk's patch radius with about 0.3% bias on the
 * point-lit slab (docs/sss/truth.md, "Patch bias"). */
static double default_patch_radius(const sss_scene_setup *s)
{
    double mfp = INFINITY;
    for (uint32_t m = 0; m <= s->mats.count; m++) {
        const sss_constants *c = m < s->mats.count ? (s->mats.translucent[m] ? &s->mats.constants[m] : NULL) : s->mats.none;
        for (int ch = 0; c && ch < 3; ch++)
            if (c->ch[ch].sigma_t_p > 0.0)
                mfp = fmin(mfp, 1.0 / c->ch[ch].sigma_t_p);
    }
    return isfinite(mfp) ? 0.5 * mfp : 0.0;
}

int cmd_truth_sss(cli_globals *g, int argc, char **argv)
{
    const char *scene_path = NULL, *prefix = "truth_sss", *camera = "", *which = "both";
    char prefix_buf[4000], exr_ext[5] = ".exr";
    int W = 1920, H = 1080, size_given = 0;
    double exposure = 1.0;
    cli_sss_options so;
    cli_sss_options_init(&so);
    truth_sss_params p = truth_sss_params_default();
    const double default_patch = p.patch_radius;
    int patch_given = 0;
    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix or an .exr path",
                                 &camera, &W, &H, &size_given};
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double d;
        int r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(truth_sss_help_head, stdout);
            fputs(cli_sss_help_material_light, stdout);
            fputs(truth_sss_help, stdout);
            return CLI_EXIT_OK;
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--reference")) {
            if (!v || (strcmp(v, "both") && strcmp(v, "brute-force") && strcmp(v, "random-walk")))
                return cli_usage_error("--reference needs both, brute-force or random-walk");
            which = v; i++;
        } else if (!strcmp(a, "--model")) {
            if (!v || !sss_model_from_name(v, &p.model)) return cli_usage_error("--model needs directional or standard");
            i++;
        } else if (!strcmp(a, "--target-error") || !strcmp(a, "--patch-radius") || !strcmp(a, "--exposure")) {
            if (!cli_parse_float(v, &d) || !isfinite(d)) return cli_usage_error("%s needs a number", a);
            if (!strcmp(a, "--target-error")) p.target_rel_error = d;
            else if (!strcmp(a, "--exposure")) exposure = d;
            else { p.patch_radius = d; patch_given = 1; }
            i++;
        } else if (!strcmp(a, "--min-samples") || !strcmp(a, "--max-samples")) {
            if (!cli_parse_int(v, 1, (long long)1 << 40, &ll)) return cli_usage_error("%s needs a positive integer", a);
            if (a[2] == 'm' && a[3] == 'i') p.min_samples = ll; else p.max_samples = ll;
            i++;
        } else if (!strcmp(a, "--batch") || !strcmp(a, "--replicates")) {
            if (!cli_parse_int(v, 1, 1 << 20, &ll)) return cli_usage_error("%s needs a positive integer", a);
            if (!strcmp(a, "--batch")) p.batch = (int)ll; else p.replicates = (int)ll;
            i++;
        } else if (!strcmp(a, "--seed")) {
            if (!cli_parse_int(v, 0, INT64_MAX, &ll)) return cli_usage_error("--seed needs an integer >= 0");
            p.seed = (uint64_t)ll; i++;
        } else if (a[0] == '-' && a[1]) {
            r = cli_sss_flag(&so, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            return cli_usage_error("truth sss: unknown option '%s' (see 'obscura truth sss --help')", a);
        } else {
            if (scene_path) return cli_usage_error("truth sss: one scene only ('%s' and '%s')", scene_path, a);
            scene_path = a;
        }
    }
    if (!scene_path)
        return cli_usage_error("truth sss: no scene given");
    if (cli_sss_options_check(&so, "truth sss"))
        return CLI_EXIT_USAGE;
    if (!(exposure >= 0))
        return cli_usage_error("--exposure needs a number >= 0");
    if (patch_given && !(p.patch_radius > 0))
        return cli_usage_error("--patch-radius needs a number > 0");

    ref_run runs[2] = {{"brute", TRUTH_SSS_BRUTE_FORCE, 0, {0}, 0.0}, {"walk", TRUTH_SSS_RANDOM_WALK, 0, {0}, 0.0}};
    runs[0].wanted = strcmp(which, "random-walk") != 0;
    runs[1].wanted = strcmp(which, "brute-force") != 0;

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    /* Under an MPI launcher: every rank loads the scene, draws the G-buffer and builds the BVH,
     * renders the tasks (tiles) dealt to it for each reference, and rank 0 gathers and writes
     * (docs/scale.md, as truth ao). */
    scale_comm *comm = NULL;
    const int mpi_code = cli_mpi_start(ctx, &argc, &argv, &comm);
    if (mpi_code != CLI_EXIT_OK)
        return mpi_code;
    const int rank = scale_comm_rank(comm), ranks = scale_comm_size(comm);
    int *owner = NULL;
    double *task_cost = NULL;
    unsigned char *task_mask = NULL;
    scale_rank_stats *per_rank[2] = {NULL, NULL};
    int64_t ntasks = 0;
    double t_wait = 0.0, t_gather = 0.0, seconds_write = 0.0;
    obs_scene scene;
    obs_scene_init(&scene);
    obs_pool *pool = NULL;
    truth_scene *ts = NULL;
    rast_gbuffer gb;
    memset(&gb, 0, sizeof gb);
    sss_scene_setup setup;
    memset(&setup, 0, sizeof setup);
    obs_image_f32 png[3] = {{0}};
    io_json j;
    io_json_init(&j);
    int code = CLI_EXIT_OK;
    obs_camera cam;
    memset(&cam, 0, sizeof cam);
    char path[4200];

    obs_status st = truth_sss_params_validate(ctx, &p);
    if (st == OBS_STATUS_OK)
        st = cli_scene_and_camera(ctx, scene_path, camera, &scene, &cam);
    if (comm) /* every rank reads the same files: one that cannot ends the job (docs/scale.md) */
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK) { /* rank 0 reports an agreed failure; mpirun returns its code */
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    st = cli_sss_prepare(ctx, &so, scene_path, &scene, &cam, &setup);
    if (comm)
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK) {
        code = rank == 0 ? cli_sss_exit_for(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    if (!patch_given) {
        const double rho = default_patch_radius(&setup);
        p.patch_radius = rho > 0.0 ? rho : default_patch;
    }
    if ((code = cli_size_from_camera(&cam, size_given, &W, &H)) != CLI_EXIT_OK)
        goto done;
    pool = obs_pool_create(g->threads);
    if (!pool) {
        fprintf(stderr, "obscura: error: cannot start %d threads\n", g->threads);
        scale_mpi_abort(comm, CLI_EXIT_INTERNAL); /* the other ranks would wait for this one */
        code = CLI_EXIT_INTERNAL;
        goto done;
    }
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    st = rast_gbuffer_alloc(ctx, &rp, &gb);
    rast_view view = {cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &scene, &view, 1, &rp, &gb, NULL);
    if (st == OBS_STATUS_OK)
        st = truth_scene_create(ctx, &scene, TRUTH_BUILD_MEDIUM, &ts);
    if (comm && st == OBS_STATUS_OK) {
        /* Deal the tasks (the pool's tiles, truth_sss_task_rect) by estimated cost, the
         * translucent surface pixels: every rank computes the same dealing from the same G-buffer
         * (docs/scale.md, "Balance"); both references use it. */
        ntasks = truth_sss_task_count(W, H, p.tile);
        owner = (int *)malloc(sizeof(int) * (size_t)(ntasks > 0 ? ntasks : 1));
        task_cost = (double *)malloc(sizeof(double) * (size_t)(ntasks > 0 ? ntasks : 1));
        task_mask = (unsigned char *)malloc((size_t)(ntasks > 0 ? ntasks : 1));
        per_rank[0] = (scale_rank_stats *)calloc((size_t)ranks, sizeof(scale_rank_stats));
        per_rank[1] = (scale_rank_stats *)calloc((size_t)ranks, sizeof(scale_rank_stats));
        if (!owner || !task_cost || !task_mask || !per_rank[0] || !per_rank[1])
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory");
        if (st == OBS_STATUS_OK && ntasks == 0)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: tile %d out of range", p.tile);
        if (st == OBS_STATUS_OK)
            st = scale_sss_task_costs(ctx, &gb, &scene, &setup.mats, p.tile, task_cost, ntasks);
        if (st == OBS_STATUS_OK)
            st = scale_deal_tasks(ctx, task_cost, ntasks, ranks, owner);
        for (int64_t t = 0; st == OBS_STATUS_OK && t < ntasks; t++)
            task_mask[t] = owner[t] == rank;
    }
    for (int r = 0; r < 2 && st == OBS_STATUS_OK; r++) {
        if (!runs[r].wanted)
            continue;
        truth_sss_params q = p;
        q.estimator = runs[r].estimator;
        char label[64];
        snprintf(label, sizeof label, "truth sss %s", truth_sss_estimator_name(q.estimator));
        cli_progress pr = {obs_time_now(), 0.0, 0, label};
        if (!g->quiet && !comm && isatty(fileno(stderr))) {
            q.progress = cli_progress_draw;
            q.progress_user = &pr;
        }
        const double t0 = obs_time_now();
        st = comm ? truth_sss_render_tasks(ctx, pool, ts, &scene, &setup.mats, &cam, &gb, &q, task_mask, &runs[r].res)
                  : truth_sss_render(ctx, pool, ts, &scene, &setup.mats, &cam, &gb, &q, &runs[r].res);
        runs[r].seconds = obs_time_now() - t0;
        if (pr.drawn)
            fputc('\n', stderr);
        if (st == OBS_STATUS_OK && !g->quiet && !comm) {
            const truth_sss_stats *S = &runs[r].res.stats;
            fprintf(stderr,
                    "obscura: truth sss %s: %dx%d: %lld surface pixels (%lld at the target, %lld at max samples), "
                    "%llu rays in %.2f s (%d threads)\n",
                    truth_sss_estimator_name(q.estimator), W, H, (long long)S->pixels_surface,
                    (long long)S->pixels_converged, (long long)S->pixels_at_max, (unsigned long long)S->rays,
                    runs[r].seconds, obs_pool_threads(pool));
        }
    }
    if (comm) { /* one failed rank fails the job, before anything is written */
        st = scale_fault_point(ctx, comm, st);
        const double t0 = obs_time_now();
        st = scale_mpi_agree(ctx, comm, st);
        const double t1 = obs_time_now();
        for (int r = 0; r < 2 && st == OBS_STATUS_OK; r++)
            if (runs[r].wanted)
                st = scale_mpi_gather_sss(ctx, comm, owner, task_cost, ntasks, p.tile, &runs[r].res, per_rank[r]);
        t_wait = t1 - t0;
        t_gather = obs_time_now() - t1;
        if (st == OBS_STATUS_OK && rank != 0)
            goto done; /* rank 0 writes */
        for (int r = 0; r < 2 && st == OBS_STATUS_OK && !g->quiet; r++) {
            if (!runs[r].wanted)
                continue;
            const truth_sss_stats *S = &runs[r].res.stats;
            fprintf(stderr,
                    "obscura: truth sss %s: %dx%d: %lld surface pixels (%lld at the target, %lld at max samples), "
                    "%llu rays in %.2f s (%d ranks of %d threads)\n",
                    truth_sss_estimator_name(runs[r].estimator), W, H, (long long)S->pixels_surface,
                    (long long)S->pixels_converged, (long long)S->pixels_at_max, (unsigned long long)S->rays,
                    runs[r].seconds, ranks, obs_pool_threads(pool));
        }
    }
    if (st != OBS_STATUS_OK) {
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    const double t_write = obs_time_now();

    /* ---- EXR: one layer per reference, then the depth ---- */
    {
        io_channel ch[2 * 7 + 1];
        char names[2 * 7][32];
        int n = 0;
        static const char *cn[3] = {"R", "G", "B"};
        for (int r = 0; r < 2; r++) {
            if (!runs[r].wanted)
                continue;
            for (int c = 0; c < 3; c++) {
                snprintf(names[n], 32, "%s.%s", runs[r].tag, cn[c]);
                ch[n] = (io_channel){names[n], IO_PIXEL_FLOAT, &runs[r].res.radiance[c], NULL};
                n++;
            }
            for (int c = 0; c < 3; c++) {
                snprintf(names[n], 32, "%s.stderr.%s", runs[r].tag, cn[c]);
                ch[n] = (io_channel){names[n], IO_PIXEL_FLOAT, &runs[r].res.std_error[c], NULL};
                n++;
            }
            snprintf(names[n], 32, "%s.count", runs[r].tag);
            ch[n] = (io_channel){names[n], IO_PIXEL_FLOAT, &runs[r].res.count, NULL};
            n++;
        }
        obs_image_f32 depth = obs_image_f32_window(&gb.depth, gb.guard, gb.guard, W, H);
        ch[n++] = (io_channel){"Z", IO_PIXEL_FLOAT, &depth, NULL};
        char seed_text[32];
        snprintf(seed_text, sizeof seed_text, "%llu", (unsigned long long)p.seed);
        io_attr at[6];
        memset(at, 0, sizeof at);
        int na = 0;
        strcpy(at[na].name, "worldToCamera"); at[na].type = IO_ATTR_MATRIX44; at[na].v = (float *)cam.view.m; na++;
        strcpy(at[na].name, "obscura:model"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)sss_model_name(p.model); na++;
        strcpy(at[na].name, "obscura:seed"); at[na].type = IO_ATTR_STRING; at[na].s = seed_text; na++;
        strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
        strcpy(at[na].name, "obscura:scene"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)scene_path; na++;
        strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
        at[na].s = (char *)"<ref>.R/G/B = outgoing radiance towards the camera (the lights' units); <ref>.stderr = "
                           "replicate standard error; <ref>.count = entry candidates (0 = not estimated: background, "
                           "opaque); brute = brute-force BSSRDF integral, walk = volumetric random walk; row 0 at top; "
                           "docs/sss/truth.md";
        na++;
        st = cli_make_parent_dirs(ctx, prefix);
        if (st == OBS_STATUS_OK) {
            snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
            st = io_exr_write(ctx, path, ch, n, at, na);
        }
    }
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
        st = obs_image_f32_alloc(ctx, W, H, &png[c]);
    for (int r = 0; r < 2 && st == OBS_STATUS_OK; r++) {
        if (!runs[r].wanted)
            continue;
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++)
                    obs_image_f32_row(&png[c], y)[x] = (float)(exposure * obs_image_f32_row(&runs[r].res.radiance[c], y)[x]);
        snprintf(path, sizeof path, "%s_%s.png", prefix, runs[r].tag);
        st = io_png_write(ctx, path, png, 3, IO_PNG_SRGB);
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    seconds_write = obs_time_now() - t_write;
    /* ---- JSON sidecar ---- */
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, "truth sss", argc, argv);
    io_json_string(&j, "scene", scene_path);
    cli_json_camera(&j, &cam);
    io_json_int(&j, "width", W);
    io_json_int(&j, "height", H);
    cli_sss_json_setup(&j, &so, &setup, &scene);
    io_json_begin_object(&j, "params");
    io_json_string(&j, "model", sss_model_name(p.model));
    io_json_number(&j, "target_rel_error", p.target_rel_error);
    io_json_int(&j, "min_samples", p.min_samples);
    io_json_int(&j, "max_samples", p.max_samples);
    io_json_int(&j, "batch", p.batch);
    io_json_int(&j, "replicates", p.replicates);
    io_json_number(&j, "patch_radius", p.patch_radius);
    io_json_number(&j, "sigma_star", p.sigma_star);
    io_json_int(&j, "seed", (int64_t)p.seed);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    for (int r = 0; r < 2; r++) {
        if (!runs[r].wanted)
            continue;
        const truth_sss_stats *S = &runs[r].res.stats;
        io_json_begin_object(&j, runs[r].tag);
        io_json_string(&j, "estimator", truth_sss_estimator_name(runs[r].estimator));
        io_json_int(&j, "candidates", (int64_t)S->candidates);
        io_json_int(&j, "accepted", (int64_t)S->accepted);
        io_json_int(&j, "rays", (int64_t)S->rays);
        io_json_int(&j, "walk_events", (int64_t)S->walk_events);
        io_json_int(&j, "walks_lost", (int64_t)S->walks_lost);
        io_json_int(&j, "pixels_surface", S->pixels_surface);
        io_json_int(&j, "pixels_skipped", S->pixels_skipped);
        io_json_int(&j, "pixels_converged", S->pixels_converged);
        io_json_int(&j, "pixels_at_max_samples", S->pixels_at_max);
        io_json_number(&j, "seconds", runs[r].seconds);
        io_json_end_object(&j);
    }
    if (comm) { /* the MPI run: ranks, dealing and balance (docs/scale.md) */
        const int nr = ranks;
        double *rr = (double *)calloc(6 * (size_t)nr, sizeof(double)); /* total, brute, walk: rays, seconds */
        for (int q = 0; rr && q < nr; q++)
            for (int r = 0; r < 2; r++)
                if (runs[r].wanted) {
                    rr[(size_t)(1 + r) * nr + q] = (double)per_rank[r][q].rays;
                    rr[(size_t)(4 + r) * nr + q] = per_rank[r][q].seconds_work;
                    rr[q] += (double)per_rank[r][q].rays;
                    rr[(size_t)3 * nr + q] += per_rank[r][q].seconds_work;
                }
        const scale_rank_stats *pr0 = runs[0].wanted ? per_rank[0] : per_rank[1];
        io_json_begin_object(&j, "scale");
        io_json_int(&j, "ranks", ranks);
        io_json_int(&j, "tasks", ntasks);
        io_json_string(&j, "dealing", "greedy by estimated cost (translucent surface pixels) in task order");
        io_json_number(&j, "imbalance_rays", rr ? scale_imbalance(rr, nr) : NAN);
        io_json_number(&j, "imbalance_seconds", rr ? scale_imbalance(rr + (size_t)3 * nr, nr) : NAN);
        for (int r = 0; r < 2; r++) {
            if (!runs[r].wanted)
                continue;
            io_json_begin_object(&j, runs[r].tag);
            io_json_number(&j, "imbalance_rays", rr ? scale_imbalance(rr + (size_t)(1 + r) * nr, nr) : NAN);
            io_json_number(&j, "imbalance_seconds", rr ? scale_imbalance(rr + (size_t)(4 + r) * nr, nr) : NAN);
            io_json_end_object(&j);
        }
        io_json_number(&j, "seconds_wait_rank0", t_wait);   /* rank 0 waiting for the slowest rank */
        io_json_number(&j, "seconds_gather", t_gather);     /* the pixels and counters to rank 0 */
        io_json_number(&j, "seconds_write", seconds_write); /* EXR and PNGs, rank 0 */
        io_json_begin_array(&j, "per_rank");
        for (int q = 0; q < nr; q++) {
            io_json_begin_object(&j, NULL);
            io_json_int(&j, "rank", q);
            io_json_int(&j, "tasks", pr0[q].tasks);
            io_json_number(&j, "cost_estimate", pr0[q].cost_estimate);
            io_json_int(&j, "rays", rr ? (int64_t)rr[q] : 0); /* both references */
            io_json_number(&j, "seconds_work", rr ? rr[(size_t)3 * nr + q] : NAN);
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
        io_json_end_object(&j);
        free(rr);
    }
    io_json_string(&j, "png", "<PREFIX>_<ref>.png: R, G, B times --exposure, sRGB-encoded, clamped to [0, 1]");
    io_json_end_object(&j);
    code = cli_write_sidecar(ctx, &j, prefix);
    if (code != CLI_EXIT_OK)
        goto done;
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s%s, %s%s%s%s%s.json\n", prefix, exr_ext,
                runs[0].wanted ? prefix : "", runs[0].wanted ? "_brute.png, " : "",
                runs[1].wanted ? prefix : "", runs[1].wanted ? "_walk.png, " : "", prefix);
done:
    free(owner);
    free(task_cost);
    free(task_mask);
    free(per_rank[0]);
    free(per_rank[1]);
    scale_mpi_finalize(comm);
    io_json_free(&j);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&png[c]);
    for (int r = 0; r < 2; r++)
        truth_sss_result_free(&runs[r].res);
    truth_scene_destroy(ts);
    sss_scene_setup_free(&setup);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
    return code;
}
