/* cmd_truth.c: `obscura truth ao SCENE`: ray-traced AO ground truth (docs/truth.md) for a glTF
 * scene seen through one of its cameras: EXR (mean, standard error, sample count, depth), a PNG
 * preview and a JSON sidecar. */
#include "cli.h"
#include "scale/scale.h"
#include "truth/truth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *truth_help =
    "usage: obscura truth ao SCENE [options]   (and 'obscura truth sss --help': the SSS references)\n"
    "  -o, --output PREFIX   write PREFIX.exr, PREFIX.png, PREFIX.json (default: truth_ao);\n"
    "                        -o out.exr names the EXR itself and the rest go beside it (out.png,\n"
    "                        out.json); missing directories are created\n"
    "  --camera NAME|INDEX   camera to use (default: 'default', else the first, else a framing one)\n"
    "  --size WxH            image size (default 1920x1080, or 1920 wide at the camera's aspect)\n"
    "  --estimator NAME      cos (default): cosine-weighted visibility within the radius (GT-cos, XeGTAO's)\n"
    "                        unif: uniform-weighted visibility within the radius (GT-unif)\n"
    "                        obs-sao: obscurance, falloff (1-d^2/r^2)^3, cosine-weighted (SAO option B)\n"
    "                        obs-sao-linear: falloff 1-d^2/r^2, cosine-weighted (G3D SAO high quality)\n"
    "                        obs-mssao: falloff 1-d^2/dMax^2, cosine-weighted (MSSAO; = obs-sao-linear)\n"
    "                        obs-hbao: falloff 1-d^2/R^2, uniform-weighted (classic HBAO)\n"
    "                        vol: share of the ball of radius r visible from the eye (Crytek's quantity)\n"
    "  --radius R            world units, > 0; 'inf' for cos and unif (default 0.5, XeGTAO's default)\n"
    "  --target-error E      stop a pixel once its error bar is <= E (default 0.002); the bar is\n"
    "                        max(replicate standard error, floor(n) ~ 1.41/n): rays that all agree\n"
    "                        cannot stop a pixel before floor(n) <= E (704 samples at 0.002)\n"
    "  --min-samples N       samples per pixel before the target may stop it (default 64)\n"
    "  --max-samples N       samples per pixel at most (default 4096; at most the limit that the\n"
    "                        global --max-spp sets, 1048576 by default)\n"
    "  --batch B             samples per pixel per round, a divisor of both counts (default 16)\n"
    "  --replicates R        independent scramblings per pixel, 2..32, dividing B (default 8): the\n"
    "                        standard error is the spread of their means (docs/truth.md)\n"
    "  --seed S              random seed (default 0); output depends only on inputs and seed\n"
    "  --normal KIND         geometric (default, XeGTAO's reference) or shading\n"
    "  --origin KIND         gbuffer (default: the rasterized G-buffer point) or embree (a primary hit)\n"
    "  --offset-ulps K       self-intersection offset, K * 2^-24 * scale (default 64; docs/truth.md)\n"
    "  --tile T              tile side in pixels, 4..32 (default 8)\n"
    "  --build Q             Embree BVH quality: low, medium (default), high\n"
    "  --scene-layout L      Embree scene: auto (default: world-space triangles, two-level instances\n"
    "                        only for meshes whose copies would pass 1 GiB), flat or instanced\n"
    "EXR channels: AO.mean (visibility, 1 = unoccluded), AO.stderr (its error bar), AO.count\n"
    "(samples; 0 = no surface there, mean 1), Z (the G-buffer's linear depth, inf = background).\n"
    "The PNG is AO.mean quantised linearly (255 = visibility 1), tagged linear (gamma 1.0), with\n"
    "the background (AO.count 0) drawn black.\n"
    "A progress bar with an ETA is drawn on stderr when it is a terminal.\n"
    "Under MPI (mpirun -np N obscura truth ao ...), the tiles are dealt over the ranks and rank 0\n"
    "gathers and writes the same files as one process, byte for byte, with a 'scale' object in the\n"
    "sidecar (docs/scale.md); OBS_NO_MPI=1 runs each rank as a plain process.\n";


/* ---- the command ------------------------------------------------------------------------------ */

int cmd_truth(cli_globals *g, int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        if (argc < 2) {
            fputs(truth_help, stderr);
            return CLI_EXIT_USAGE;
        }
        fputs(truth_help, stdout);
        return CLI_EXIT_OK;
    }
    /* `truth ao`, `truth sss` and `truth volume` split their work over MPI ranks under a launcher
     * (docs/scale.md). */
    if (!strcmp(argv[1], "sss"))
        return cmd_truth_sss(g, argc, argv);
    if (!strcmp(argv[1], "volume"))
        return cmd_volume(g, argc, argv, 1);
    if (strcmp(argv[1], "ao") != 0)
        return cli_usage_error("truth: unknown kind '%s' ('truth ao', 'truth sss' or 'truth volume')", argv[1]);
    const char *scene_path = NULL, *prefix = "truth_ao", *camera = "";
    char prefix_buf[4000], exr_ext[5] = ".exr";
    truth_ao_params p = truth_ao_params_default();
    truth_build_quality build = TRUTH_BUILD_MEDIUM;
    truth_scene_layout layout = TRUTH_SCENE_AUTO;
    int W = 1920, H = 1080, size_given = 0;
    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix or an .exr path",
                                 &camera, &W, &H, &size_given};
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double d;
        int r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(truth_help, stdout);
            return CLI_EXIT_OK;
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--estimator")) {
            if (!truth_ao_estimator_from_name(v, &p.estimator))
                return cli_usage_error("--estimator needs cos, unif, obs-sao, obs-sao-linear, obs-mssao, obs-hbao or vol");
            i++;
        } else if (!strcmp(a, "--radius")) {
            if (!cli_parse_float(v, &d)) return cli_usage_error("--radius needs a number (or inf)");
            p.radius = (float)d; i++;
        } else if (!strcmp(a, "--target-error")) {
            if (!cli_parse_float(v, &d)) return cli_usage_error("--target-error needs a number");
            p.target_error = d; i++;
        } else if (!strcmp(a, "--min-samples")) {
            if (!cli_parse_int(v, 1, (long long)1 << 40, &ll)) return cli_usage_error("--min-samples needs a positive integer");
            p.min_samples = ll; i++;
        } else if (!strcmp(a, "--max-samples")) {
            if (!cli_parse_int(v, 1, (long long)1 << 40, &ll)) return cli_usage_error("--max-samples needs a positive integer");
            p.max_samples = ll; i++;
        } else if (!strcmp(a, "--batch")) {
            if (!cli_parse_int(v, 1, 1 << 20, &ll)) return cli_usage_error("--batch needs a positive integer");
            p.batch = (int)ll; i++;
        } else if (!strcmp(a, "--replicates")) {
            if (!cli_parse_int(v, 1, 1 << 20, &ll)) return cli_usage_error("--replicates needs a positive integer");
            p.replicates = (int)ll; i++;
        } else if (!strcmp(a, "--seed")) {
            if (!cli_parse_int(v, 0, INT64_MAX, &ll)) return cli_usage_error("--seed needs an integer >= 0");
            p.seed = (uint64_t)ll; i++;
        } else if (!strcmp(a, "--normal")) {
            if (v && !strcmp(v, "geometric")) p.normal = TRUTH_AO_NORMAL_GEOMETRIC;
            else if (v && !strcmp(v, "shading")) p.normal = TRUTH_AO_NORMAL_SHADING;
            else return cli_usage_error("--normal needs geometric or shading");
            i++;
        } else if (!strcmp(a, "--origin")) {
            if (v && !strcmp(v, "gbuffer")) p.origin = TRUTH_AO_ORIGIN_GBUFFER;
            else if (v && !strcmp(v, "embree")) p.origin = TRUTH_AO_ORIGIN_EMBREE;
            else return cli_usage_error("--origin needs gbuffer or embree");
            i++;
        } else if (!strcmp(a, "--offset-ulps")) {
            if (!cli_parse_float(v, &d)) return cli_usage_error("--offset-ulps needs a number");
            p.offset_ulps = (float)d; i++;
        } else if (!strcmp(a, "--tile")) {
            if (!cli_parse_int(v, 1, 1024, &ll)) return cli_usage_error("--tile needs a positive integer");
            p.tile = (int)ll; i++;
        } else if (!strcmp(a, "--build")) {
            if (v && !strcmp(v, "low")) build = TRUTH_BUILD_LOW;
            else if (v && !strcmp(v, "medium")) build = TRUTH_BUILD_MEDIUM;
            else if (v && !strcmp(v, "high")) build = TRUTH_BUILD_HIGH;
            else return cli_usage_error("--build needs low, medium or high");
            i++;
        } else if (!strcmp(a, "--scene-layout")) {
            if (v && !strcmp(v, "auto")) layout = TRUTH_SCENE_AUTO;
            else if (v && !strcmp(v, "flat")) layout = TRUTH_SCENE_FLAT;
            else if (v && !strcmp(v, "instanced")) layout = TRUTH_SCENE_INSTANCED;
            else return cli_usage_error("--scene-layout needs auto, flat or instanced");
            i++;
        } else {
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            if (a[0] == '-') return cli_usage_error("truth ao: unknown option '%s'", a);
            if (scene_path) return cli_usage_error("truth ao: more than one scene given ('%s')", a);
            scene_path = a;
        }
    }
    if (!scene_path)
        return cli_usage_error("truth ao: no scene given");

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    /* Under an MPI launcher: every rank loads the scene and draws the G-buffer, renders the tasks
     * dealt to it, and rank 0 gathers and writes (docs/scale.md). */
    scale_comm *comm = NULL;
    const int mpi_code = cli_mpi_start(ctx, &argc, &argv, &comm);
    if (mpi_code != CLI_EXIT_OK)
        return mpi_code;
    const int rank = scale_comm_rank(comm), ranks = scale_comm_size(comm);
    int *owner = NULL;
    double *task_cost = NULL;
    unsigned char *task_mask = NULL;
    scale_rank_stats *per_rank = NULL;
    int64_t ntasks = 0;
    obs_scene scene;
    obs_scene_init(&scene);
    obs_pool *pool = NULL;
    truth_scene *ts = NULL;
    rast_gbuffer gb;
    memset(&gb, 0, sizeof gb);
    truth_ao_result res;
    memset(&res, 0, sizeof res);
    obs_image_f32 preview = {0};
    io_json j;
    io_json_init(&j);
    int code = CLI_EXIT_OK;
    obs_camera cam;
    double t_load = obs_time_now();
    obs_status st = cli_scene_and_camera(ctx, scene_path, camera, &scene, &cam);
    if (comm) /* every rank reads the same files: one that cannot ends the job (docs/scale.md) */
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK) { /* rank 0 reports an agreed failure; mpirun returns its code */
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
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
    /* The G-buffer the estimators start from (docs/truth.md, "Inputs"). */
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_FACE_NORMAL | RAST_OUT_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    double t_raster = obs_time_now();
    st = rast_gbuffer_alloc(ctx, &rp, &gb);
    rast_view view = {cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &scene, &view, 1, &rp, &gb, NULL);
    double t_bvh = obs_time_now();
    if (st == OBS_STATUS_OK)
    {
        truth_scene_options so = truth_scene_options_default();
        so.quality = build;
        so.layout = layout;
        st = truth_scene_create_ex(ctx, &scene, &so, &ts);
    }
    double t_ao = obs_time_now();
    cli_progress pr = {t_ao, 0.0, 0, "truth ao"};
    if (!g->quiet && !comm && isatty(fileno(stderr))) {
        p.progress = cli_progress_draw;
        p.progress_user = &pr;
    }
    if (comm && st == OBS_STATUS_OK) {
        /* Deal the tasks (the pool's units, truth_ao_task_rect) by estimated cost: every rank
         * computes the same dealing from the same G-buffer (docs/scale.md, "Balance"). */
        ntasks = truth_ao_task_count(W, H, p.tile);
        owner = (int *)malloc(sizeof(int) * (size_t)(ntasks > 0 ? ntasks : 1));
        task_cost = (double *)malloc(sizeof(double) * (size_t)(ntasks > 0 ? ntasks : 1));
        task_mask = (unsigned char *)malloc((size_t)(ntasks > 0 ? ntasks : 1));
        per_rank = (scale_rank_stats *)calloc((size_t)ranks, sizeof(scale_rank_stats));
        if (!owner || !task_cost || !task_mask || !per_rank)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth ao: out of memory");
        if (st == OBS_STATUS_OK && ntasks == 0)
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth ao: tile %d out of range", p.tile);
        if (st == OBS_STATUS_OK)
            st = scale_ao_task_costs(ctx, &gb, p.tile, task_cost, ntasks);
        if (st == OBS_STATUS_OK)
            st = scale_deal_tasks(ctx, task_cost, ntasks, ranks, owner);
        for (int64_t t = 0; st == OBS_STATUS_OK && t < ntasks; t++)
            task_mask[t] = owner[t] == rank;
    }
    if (st == OBS_STATUS_OK)
        st = comm ? truth_ao_render_tasks(ctx, pool, ts, &scene, &cam, &gb, &p, task_mask, &res)
                  : truth_ao_render(ctx, pool, ts, &scene, &cam, &gb, &p, &res);
    double t_wait = 0.0, t_gather = 0.0; /* rank 0: waiting for the slowest rank, then the gather */
    if (comm) { /* one failed rank fails the job, before anything is written */
        st = scale_fault_point(ctx, comm, st);
        const double t0 = obs_time_now();
        st = scale_mpi_agree(ctx, comm, st);
        const double t1 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = scale_mpi_gather_ao(ctx, comm, owner, task_cost, ntasks, p.tile, &res, per_rank);
        t_wait = t1 - t0;
        t_gather = obs_time_now() - t1;
        if (st == OBS_STATUS_OK && rank != 0)
            goto done; /* rank 0 writes */
    }
    double t_end = obs_time_now();
    if (pr.drawn)
        fputc('\n', stderr);
    if (st != OBS_STATUS_OK) {
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    const truth_ao_stats *S = &res.stats;
    double ao_seconds = t_end - t_ao;
    double mrays = ao_seconds > 0 ? (double)S->rays / ao_seconds * 1e-6 : 0.0;
    if (!g->quiet)
        fprintf(stderr,
                "obscura: %s: %dx%d, %s, r = %g: %lld surface pixels, %llu rays in %.2f s (%.2f Mrays/s, %d threads); "
                "%lld at the target error, %lld at max samples\n",
                scene_path, W, H, truth_ao_estimator_name(p.estimator), (double)p.radius, (long long)S->pixels_surface,
                (unsigned long long)S->rays, ao_seconds, mrays, obs_pool_threads(pool), (long long)S->pixels_converged,
                (long long)S->pixels_at_max);

    /* EXR: the three planes and the G-buffer's depth (the inner window; the guard is 0 here). */
    obs_image_f32 depth = obs_image_f32_window(&gb.depth, gb.guard, gb.guard, W, H);
    io_channel ch[4] = {
        {"AO.mean", IO_PIXEL_FLOAT, &res.mean, NULL},
        {"AO.stderr", IO_PIXEL_FLOAT, &res.std_error, NULL},
        {"AO.count", IO_PIXEL_FLOAT, &res.count, NULL},
        {"Z", IO_PIXEL_FLOAT, &depth, NULL},
    };
    const rast_view_constants *vc = &gb.constants;
    obs_mat4 world_to_ndc = obs_mat4_mul(vc->projection_inner, vc->view);
    float radius_attr = p.radius;
    io_attr at[16];
    memset(at, 0, sizeof at);
    int na = 0;
    strcpy(at[na].name, "worldToCamera"); at[na].type = IO_ATTR_MATRIX44; at[na].v = (float *)cam.view.m; na++;
    strcpy(at[na].name, "worldToNDC"); at[na].type = IO_ATTR_MATRIX44; at[na].v = world_to_ndc.m; na++;
    strcpy(at[na].name, "obscura:estimator"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)truth_ao_estimator_name(p.estimator); na++;
    strcpy(at[na].name, "obscura:radius"); at[na].type = IO_ATTR_FLOAT; at[na].f = radius_attr; na++;
    strcpy(at[na].name, "obscura:normal"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(p.normal == TRUTH_AO_NORMAL_GEOMETRIC ? "geometric" : "shading"); na++;
    strcpy(at[na].name, "obscura:origin"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(p.origin == TRUTH_AO_ORIGIN_GBUFFER ? "gbuffer" : "embree"); na++;
    strcpy(at[na].name, "obscura:target_error"); at[na].type = IO_ATTR_FLOAT; at[na].f = (float)p.target_error; na++;
    strcpy(at[na].name, "obscura:min_samples"); at[na].type = IO_ATTR_INT; at[na].i = p.min_samples; na++;
    strcpy(at[na].name, "obscura:max_samples"); at[na].type = IO_ATTR_INT; at[na].i = p.max_samples; na++;
    strcpy(at[na].name, "obscura:replicates"); at[na].type = IO_ATTR_INT; at[na].i = p.replicates; na++;
    strcpy(at[na].name, "obscura:seed"); at[na].type = IO_ATTR_STRING;
    char seed_text[32];
    snprintf(seed_text, sizeof seed_text, "%llu", (unsigned long long)p.seed);
    at[na].s = seed_text; na++;
    strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
    strcpy(at[na].name, "obscura:scene"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)scene_path; na++;
    strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)"AO.mean = visibility (1 = unoccluded); AO.count = 0 where no surface (mean 1 there); "
                       "row 0 at top; Z = linear depth, inf = background; docs/truth.md";
    na++;

    char path[4200];
    const double t_write = obs_time_now();
    st = cli_make_parent_dirs(ctx, prefix);
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
        st = io_exr_write(ctx, path, ch, 4, at, na);
    }
    if (st == OBS_STATUS_OK) { /* the preview: AO.mean, background (count 0) black */
        st = obs_image_f32_alloc(ctx, W, H, &preview);
        for (int y = 0; st == OBS_STATUS_OK && y < H; y++)
            for (int x = 0; x < W; x++)
                obs_image_f32_row(&preview, y)[x] =
                    obs_image_f32_row(&res.count, y)[x] > 0.0f ? obs_image_f32_row(&res.mean, y)[x] : 0.0f;
        snprintf(path, sizeof path, "%s.png", prefix);
        if (st == OBS_STATUS_OK)
            st = io_png_write(ctx, path, &preview, 1, IO_PNG_LINEAR);
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    const double seconds_write = obs_time_now() - t_write;
    /* JSON sidecar: every parameter, timing and counters. */
    double se_sum = 0.0, n_sum = 0.0;
    for (int y = 0; y < res.height; y++)
        for (int x = 0; x < res.width; x++)
            if (obs_image_f32_row(&res.count, y)[x] > 0.0f) {
                se_sum += obs_image_f32_row(&res.std_error, y)[x];
                n_sum += obs_image_f32_row(&res.count, y)[x];
            }
    double surf = S->pixels_surface > 0 ? (double)S->pixels_surface : 1.0;
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, "truth ao", argc, argv);
    io_json_string(&j, "scene", scene_path);
    cli_json_camera(&j, &cam);
    io_json_begin_object(&j, "params");
    io_json_int(&j, "width", W);
    io_json_int(&j, "height", H);
    io_json_string(&j, "estimator", truth_ao_estimator_name(p.estimator));
    if (isinf(p.radius))
        io_json_string(&j, "radius", "infinity");
    else
        io_json_number(&j, "radius", p.radius);
    io_json_number(&j, "target_error", p.target_error);
    io_json_int(&j, "min_samples", p.min_samples);
    io_json_int(&j, "max_samples", p.max_samples);
    io_json_int(&j, "batch", p.batch);
    io_json_int(&j, "replicates", p.replicates);
    io_json_string(&j, "seed", seed_text);
    io_json_string(&j, "normal", p.normal == TRUTH_AO_NORMAL_GEOMETRIC ? "geometric" : "shading");
    io_json_string(&j, "origin", p.origin == TRUTH_AO_ORIGIN_GBUFFER ? "gbuffer" : "embree");
    io_json_number(&j, "offset_ulps", p.offset_ulps);
    io_json_int(&j, "tile", p.tile);
    io_json_string(&j, "build_quality", build == TRUTH_BUILD_LOW ? "low" : build == TRUTH_BUILD_HIGH ? "high" : "medium");
    io_json_string(&j, "scene_layout", truth_scene_layout_name(layout));
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    io_json_begin_object(&j, "stats");
    io_json_int(&j, "rays", (int64_t)S->rays);
    io_json_int(&j, "primary_rays", (int64_t)S->primary_rays);
    io_json_int(&j, "pixels_surface", S->pixels_surface);
    io_json_int(&j, "pixels_background", S->pixels_background);
    io_json_int(&j, "pixels_invalid", S->pixels_invalid);
    io_json_int(&j, "pixels_converged", S->pixels_converged);
    io_json_int(&j, "pixels_at_max_samples", S->pixels_at_max);
    io_json_number(&j, "mean_samples_per_surface_pixel", n_sum / surf);
    io_json_number(&j, "mean_std_error", se_sum / surf);
    io_json_number(&j, "max_std_error", S->max_std_error);
    io_json_number(&j, "error_floor_at_min_samples", truth_ao_error_floor(p.min_samples));
    io_json_number(&j, "max_offset", S->max_offset);
    {
        truth_scene_info si;
        truth_scene_get_info(ts, &si);
        io_json_int(&j, "embree_instances_flat", si.instances_flat);
        io_json_int(&j, "embree_instances_two_level", si.instances_two_level);
    }
    io_json_number(&j, "seconds_load", t_raster - t_load);
    io_json_number(&j, "seconds_raster", t_bvh - t_raster);
    io_json_number(&j, "seconds_bvh", t_ao - t_bvh);
    io_json_number(&j, "seconds_ao", ao_seconds);
    io_json_number(&j, "seconds_ao_work", S->seconds_work);
    io_json_number(&j, "mrays_per_second", mrays);
    io_json_end_object(&j);
    if (comm) { /* the MPI run: ranks, dealing and balance (docs/scale.md) */
        const int nr = ranks;
        double *rr = (double *)malloc(sizeof(double) * 2 * (size_t)nr), *rs = rr ? rr + nr : NULL;
        for (int r = 0; rr && r < nr; r++) {
            rr[r] = (double)per_rank[r].rays;
            rs[r] = per_rank[r].seconds_work;
        }
        io_json_begin_object(&j, "scale");
        io_json_int(&j, "ranks", ranks);
        io_json_int(&j, "tasks", ntasks);
        io_json_string(&j, "dealing", "greedy by estimated cost (surface pixels) in task order");
        io_json_number(&j, "imbalance_rays", rr ? scale_imbalance(rr, nr) : NAN);
        io_json_number(&j, "imbalance_seconds", rr ? scale_imbalance(rs, nr) : NAN);
        free(rr);
        io_json_number(&j, "seconds_wait_rank0", t_wait);   /* rank 0 waiting for the slowest rank */
        io_json_number(&j, "seconds_gather", t_gather);     /* the pixels and counters to rank 0 */
        io_json_number(&j, "seconds_write", seconds_write); /* EXR and PNG, rank 0 */
        io_json_begin_array(&j, "per_rank");
        for (int r = 0; r < nr; r++) {
            io_json_begin_object(&j, NULL);
            io_json_int(&j, "rank", r);
            io_json_int(&j, "tasks", per_rank[r].tasks);
            io_json_number(&j, "cost_estimate", per_rank[r].cost_estimate);
            io_json_int(&j, "rays", (int64_t)per_rank[r].rays);
            io_json_number(&j, "seconds_work", per_rank[r].seconds_work);
            io_json_end_object(&j);
        }
        io_json_end_array(&j);
        io_json_end_object(&j);
    }
    io_json_begin_array(&j, "channels");
    for (int c = 0; c < 4; c++)
        io_json_string(&j, NULL, ch[c].name);
    io_json_end_array(&j);
    io_json_string(&j, "preview_png", "AO.mean, linear quantisation, gamma 1.0; background (AO.count = 0) black");
    io_json_end_object(&j);
    code = cli_write_sidecar(ctx, &j, prefix);
    if (code != CLI_EXIT_OK)
        goto done;
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s%s, %s.png, %s.json\n", prefix, exr_ext, prefix, prefix);
done:
    free(owner);
    free(task_cost);
    free(task_mask);
    free(per_rank);
    scale_mpi_finalize(comm);
    io_json_free(&j);
    obs_image_f32_free(&preview);
    truth_ao_result_free(&res);
    truth_scene_destroy(ts);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
    return code;
}
