/* cmd_volume.c: `obscura volume FILE` (ray cast a volume, optionally lit by Ropinski's light
 * volume; docs/volume.md) and `obscura truth volume FILE` (the exact transmittance against the
 * light volume; docs/volume/light.md). Only parses flags and calls the vol_ and truth_ passes. */
#include "cli.h"
#include "scale/scale.h"
#include "truth/truth.h"
#include "volume/vol.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *volume_help =
    "usage: obscura volume FILE [options] -o PREFIX\n"
    "       obscura truth volume FILE [options] -o PREFIX\n"
    "input:\n"
    "  FILE                  .nii/.nii.gz (NIfTI), .nrrd/.nhdr (NRRD), a raw file with --raw, or\n"
    "                        synth:NAME[:N] (bucky, slab, sphere, box; N^3 voxels, default 32)\n"
    "  --raw NXxNYxNZ:TYPE   raw samples (TYPE u8, u16, i16, f32), with --spacing and --big-endian\n"
    "  --spacing SX,SY,SZ    raw files: voxel spacing (default 1,1,1)\n"
    "  --big-endian          raw files: big-endian samples (default little)\n"
    "  --tf FILE.json|NAME   transfer function: a JSON file (docs/volume.md) or a preset (ct-skin,\n"
    "                        ct-bone, mri, bucky); default bucky for synthetic volumes, else ct-skin\n"
    "lighting:\n"
    "  --mode NAME           ea (emission-absorption), phong or lightvolume (default)\n"
    "  --light-dir X,Y,Z     a directional light travelling along X,Y,Z (default: from the camera's\n"
    "                        upper right)\n"
    "  --light-pos X,Y,Z     a point light at X,Y,Z (world units; may be inside the volume)\n"
    "  --lv-scale S          light-volume resolution: 1 (the data's, default), 2 (half) or 4\n"
    "  --cone DEG            chromaticity cone half-angle (default 45)\n"
    "  --no-blend            no second propagation direction\n"
    "  --kappa K             extinction scale of the light volume (default 1)\n"
    "  --eye-pass            lightvolume mode: also propagate from the camera and modulate the\n"
    "                        chromaticity by it (a reconstruction; docs/volume/light.md \"Eye pass\")\n"
    "ray casting:\n"
    "  --step H              world units (default half the smallest spacing)\n"
    "  --brick B             empty-space skipping brick side (0 = off; default 8)\n"
    "  --fast                classify through a pre-corrected 4096-entry TF table (changes bits;\n"
    "                        docs/volume/raycast.md \"Fast mode\"; default: exact)\n"
    "  --camera-dir X,Y,Z    look along X,Y,Z at the volume's centre, framing it (default -0.3,-0.4,-1)\n"
    "  --size WxH            image size (default 1280x720)\n"
    "  --reps N              also time N warm ray casts (brick table prepared once, after one\n"
    "                        warm-up): the sidecar's seconds_raycast_warm is their median\n"
    "output:\n"
    "  -o, --output PREFIX   volume: PREFIX.exr (R, G, B, A premultiplied), PREFIX.png (over black,\n"
    "                        sRGB), PREFIX.json; --write-light-volume adds PREFIX_l.nrrd (the light\n"
    "                        volume's transmittance). truth volume: PREFIX_T.nrrd (exact\n"
    "                        transmittance), PREFIX_err.nrrd (light volume - exact), PREFIX.json\n"
    "truth volume --image (the Monte Carlo single-scattering image reference; docs/volume/truth.md):\n"
    "  --image               also write PREFIX_mc.exr: R, G, B, A (premultiplied, over black) and\n"
    "                        SE.R, SE.G, SE.B, SE.A (replicate standard errors); the sidecar gets\n"
    "                        \"mc_image\" (default size 320x180: give --size for another)\n"
    "  --image-only          the MC image alone: no light volume, no exact transmittance volume\n"
    "                        (which costs minutes on the real datasets)\n"
    "  --samples N           samples per pixel, a multiple of --replicates (default 256)\n"
    "  --replicates R        independent replicates for the error bar, 2..32 (default 8)\n"
    "  --phase-g G           Henyey-Greenstein asymmetry in (-1, 1) (default 0: the ray caster's model)\n"
    "  --seed S              random seed (default 0)\n"
    "Under MPI (mpirun -np N obscura truth volume ...), the light volume's z slices and the MC image's\n"
    "tiles are dealt over the ranks and rank 0 gathers and writes the same files as one process, byte\n"
    "for byte, with a 'scale' object in the sidecar (docs/scale.md); OBS_NO_MPI=1 runs each rank as a\n"
    "plain process.\n";

static void json_stats(io_json *j, const char *key, const truth_volume_error_stats *s)
{
    io_json_begin_object(j, key);
    io_json_number(j, "max_abs", s->max_abs);
    io_json_number(j, "mean_abs", s->mean_abs);
    io_json_number(j, "rmse", s->rmse);
    io_json_number(j, "mean_signed", s->mean_signed);
    io_json_int(j, "voxels", (int64_t)s->voxels);
    io_json_end_object(j);
}

/* A grid as NRRD from a float plane laid out like the light volume. */
static obs_status write_lv_nrrd(obs_context *ctx, const char *path, const vol_light_volume *lv, const float *data)
{
    vol_grid g;
    memset(&g, 0, sizeof g);
    g.nx = lv->nx;
    g.ny = lv->ny;
    g.nz = lv->nz;
    for (int c = 0; c < 3; c++) {
        g.spacing[c] = lv->spacing[c];
        g.origin[c] = lv->origin[c];
    }
    g.data = (float *)data;
    g.source_type = VOL_TYPE_F32;
    return io_volume_write_nrrd(ctx, path, &g);
}

int cmd_volume(cli_globals *g, int argc, char **argv, int truth)
{
    const char *file = NULL, *tf_arg = NULL, *prefix = truth ? "truth_volume" : "volume", *raw = NULL;
    char prefix_buf[4000], exr_ext[5] = ".exr";
    int W = 1280, H = 720, write_lv = 0, light_dir_given = 0, light_pos_given = 0, big_endian = 0;
    double light_dir[3] = {0, 0, 0}, light_pos[3] = {0, 0, 0}, spacing[3] = {1, 1, 1};
    double cam_dir[3] = {-0.3, -0.4, -1.0};
    vol_lv_params lp = vol_lv_params_default();
    vol_rc_params rp = vol_rc_params_default();
    const int first = truth ? 2 : 1;
    /* truth volume --image (the MC image reference) */
    int mc_image = 0, size_given = 0, image_only = 0;
    int rc_reps = 0; /* --reps: warm ray casts timed after the first (issue 15 section 11, the VTK peer) */
    truth_volume_mc_params mcp = truth_volume_mc_params_default();
    if (argc <= first) {
        fputs(volume_help, stderr);
        return CLI_EXIT_USAGE;
    }
    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix", NULL,
                                 &W, &H, &size_given};
    for (int i = first; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double d;
        int r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(volume_help, stdout);
            return CLI_EXIT_OK;
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--tf")) {
            if (!v) return cli_usage_error("--tf needs a JSON file or a preset name");
            tf_arg = v; i++;
        } else if (!strcmp(a, "--raw")) {
            if (!v) return cli_usage_error("--raw needs NXxNYxNZ:TYPE");
            raw = v; i++;
        } else if (!strcmp(a, "--spacing")) {
            if (!cli_parse_triple(v, spacing)) return cli_usage_error("--spacing needs SX,SY,SZ");
            i++;
        } else if (!strcmp(a, "--big-endian")) {
            big_endian = 1;
        } else if (!strcmp(a, "--mode")) {
            if (!v || !vol_shading_from_name(v, &rp.shading)) return cli_usage_error("--mode needs ea, phong or lightvolume");
            i++;
        } else if (!strcmp(a, "--light-dir")) {
            if (!cli_parse_triple(v, light_dir) || (light_dir[0] == 0 && light_dir[1] == 0 && light_dir[2] == 0))
                return cli_usage_error("--light-dir needs X,Y,Z, not all zero");
            light_dir_given = 1; i++;
        } else if (!strcmp(a, "--light-pos")) {
            if (!cli_parse_triple(v, light_pos)) return cli_usage_error("--light-pos needs X,Y,Z");
            light_pos_given = 1; i++;
        } else if (!strcmp(a, "--camera-dir")) {
            if (!cli_parse_triple(v, cam_dir) || (cam_dir[0] == 0 && cam_dir[1] == 0 && cam_dir[2] == 0))
                return cli_usage_error("--camera-dir needs X,Y,Z, not all zero");
            i++;
        } else if (!strcmp(a, "--lv-scale")) {
            if (!cli_parse_int(v, 1, 4, &ll)) return cli_usage_error("--lv-scale needs 1, 2 or 4");
            lp.scale = (int)ll; i++;
        } else if (!strcmp(a, "--cone") || !strcmp(a, "--kappa") || !strcmp(a, "--step")) {
            if (!cli_parse_float(v, &d) || !isfinite(d)) return cli_usage_error("%s needs a number", a);
            if (!strcmp(a, "--cone")) lp.cone_angle_deg = d;
            else if (!strcmp(a, "--kappa")) lp.kappa = d;
            else rp.step = d;
            i++;
        } else if (!strcmp(a, "--reps")) {
            if (!cli_parse_int(v, 1, 1000, &ll)) return cli_usage_error("--reps needs an integer in [1, 1000]");
            rc_reps = (int)ll; i++;
        } else if (!strcmp(a, "--brick")) {
            if (!cli_parse_int(v, 0, 1024, &ll)) return cli_usage_error("--brick needs an integer in [0, 1024]");
            rp.brick = (int)ll; i++;
        } else if (!strcmp(a, "--fast")) {
            rp.precision = VOL_RC_FAST;
        } else if (!strcmp(a, "--no-blend")) {
            lp.blend_second = 0;
        } else if (!strcmp(a, "--eye-pass")) {
            lp.eye_pass = 1;
        } else if (!strcmp(a, "--write-light-volume")) {
            write_lv = 1;
        } else if (truth && !strcmp(a, "--image")) {
            mc_image = 1;
        } else if (truth && !strcmp(a, "--image-only")) {
            mc_image = image_only = 1;
        } else if (truth && (!strcmp(a, "--samples") || !strcmp(a, "--replicates") || !strcmp(a, "--seed"))) {
            if (!cli_parse_int(v, 0, (long long)1 << 40, &ll)) return cli_usage_error("%s needs a non-negative integer", a);
            if (!strcmp(a, "--samples")) mcp.samples = (int64_t)ll;
            else if (!strcmp(a, "--replicates")) mcp.replicates = ll > 1000 ? 1000 : (int)ll;
            else mcp.seed = (uint64_t)ll;
            i++;
        } else if (truth && !strcmp(a, "--phase-g")) {
            if (!cli_parse_float(v, &d) || !(d > -1.0 && d < 1.0)) return cli_usage_error("--phase-g needs a number in (-1, 1)");
            mcp.g = d; i++;
        } else if (a[0] == '-' && a[1]) {
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            return cli_usage_error("volume: unknown option '%s' (see 'obscura volume --help')", a);
        } else {
            if (file) return cli_usage_error("volume: one volume only ('%s' and '%s')", file, a);
            file = a;
        }
    }
    if (!file)
        return cli_usage_error("volume: no volume file given");
    if (light_dir_given && light_pos_given)
        return cli_usage_error("volume: give --light-dir or --light-pos, not both");
    if (lp.eye_pass && (truth || rp.shading != VOL_SHADING_LIGHT_VOLUME))
        return cli_usage_error("volume: --eye-pass applies to 'obscura volume' with --mode lightvolume only");
    if (truth && mc_image && !size_given) {
        W = 320; /* the MC reference costs samples x pixels: a smaller default image (ours) */
        H = 180;
    }
    if (!strncmp(file, "synth:", 6) && (raw || big_endian))
        return cli_usage_error("volume: --raw and --big-endian apply to raw files, not to %s", file);

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    /* truth volume under an MPI launcher: every rank loads the volume and builds the light volume
     * (cheap against the truth), computes the z slices and the MC image's tiles dealt to it, and
     * rank 0 gathers and writes (docs/scale.md, "truth volume"). */
    scale_comm *comm = NULL;
    const int mpi_code = truth ? cli_mpi_start(ctx, &argc, &argv, &comm) : CLI_EXIT_OK;
    if (mpi_code != CLI_EXIT_OK)
        return mpi_code;
    const int rank = scale_comm_rank(comm), ranks = scale_comm_size(comm);
    int *slice_owner = NULL, *task_owner = NULL;
    unsigned char *slice_mask = NULL, *task_mask = NULL;
    double *task_cost = NULL, *slice_seconds = NULL;
    scale_rank_stats *per_rank = NULL;
    int64_t ntasks = 0;
    double t_wait = 0.0, t_gather = 0.0, t_write = 0.0;
    obs_pool *pool = NULL;
    vol_grid grid;
    memset(&grid, 0, sizeof grid);
    vol_tf tf;
    memset(&tf, 0, sizeof tf);
    vol_light_volume lv, eyev;
    memset(&lv, 0, sizeof lv);
    memset(&eyev, 0, sizeof eyev);
    obs_image_f32 rgba[4] = {{0}};
    float *T = NULL, *err = NULL;
    truth_volume_image mci;
    memset(&mci, 0, sizeof mci);
    char *tf_text = NULL;
    io_json j;
    io_json_init(&j);
    int code = CLI_EXIT_OK;
    char path[4200];
    double t_load = 0, t_lv = 0, t_eye = 0, t_rc = 0, t_truth = 0, t0, t_rc_warm = 0;
    truth_volume_error_stats es;
    memset(&es, 0, sizeof es);
    int synthetic = 0;

    /* ---- The volume ---- */
    t0 = obs_time_now();
    obs_status st = OBS_STATUS_OK;
    if (!strncmp(file, "synth:", 6)) {
        char name[64];
        int n = 32;
        const char *colon = strchr(file + 6, ':');
        size_t len = colon ? (size_t)(colon - (file + 6)) : strlen(file + 6);
        if (len >= sizeof name) len = sizeof name - 1;
        memcpy(name, file + 6, len);
        name[len] = '\0';
        long long ll;
        if (colon && !cli_parse_int(colon + 1, 4, 4096, &ll)) {
            code = cli_usage_error("volume: %s: the size after the name must be an integer in [4, 4096]", file);
            goto done;
        }
        if (colon) n = (int)ll;
        st = vol_synth(ctx, name, n, &grid);
        synthetic = 1;
    } else {
        io_volume_options vo = io_volume_options_default();
        if (raw) {
            char type[16] = "";
            if (sscanf(raw, "%dx%dx%d:%15s", &vo.dims[0], &vo.dims[1], &vo.dims[2], type) != 4) {
                code = cli_usage_error("--raw needs NXxNYxNZ:TYPE (e.g. 256x256x108:i16)");
                goto done;
            }
            vol_type vt;
            if (!vol_type_from_name(type, &vt)) {
                code = cli_usage_error("--raw: unknown voxel type '%s' (u8, u16, i16 or f32)", type);
                goto done;
            }
            vo.format = IO_VOLUME_RAW;
            vo.type = (int)vt;
            vo.big_endian = big_endian;
            for (int c = 0; c < 3; c++)
                vo.spacing[c] = spacing[c];
        }
        st = io_volume_load(ctx, file, &vo, &grid);
    }
    if (comm) /* every rank reads the same file: one that cannot ends the job */
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK) {
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    /* ---- The transfer function ---- */
    if (!tf_arg)
        tf_arg = synthetic ? "bucky" : "ct-skin";
    {
        size_t n = strlen(tf_arg);
        if (n > 5 && !strcmp(tf_arg + n - 5, ".json")) {
            size_t len;
            st = io_read_file(ctx, tf_arg, (size_t)1 << 20, &tf_text, &len);
            if (st == OBS_STATUS_OK)
                st = vol_tf_parse_json(ctx, tf_text, tf_arg, &tf);
        } else {
            st = vol_tf_preset(ctx, tf_arg, &tf);
        }
    }
    if (comm)
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK && rank != 0) {
        code = CLI_EXIT_OK;
        goto done;
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_NOT_FOUND ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_USAGE)
                                          : cli_fail(ctx, st);
        goto done;
    }
    t_load = obs_time_now() - t0;

    /* ---- Camera (framing the volume) and light ---- */
    double lo[3], hi[3];
    vol_grid_bounds(&grid, lo, hi);
    obs_aabb box = {{(float)lo[0], (float)lo[1], (float)lo[2]}, {(float)hi[0], (float)hi[1], (float)hi[2]}};
    obs_vec3 ctr = obs_v3_scale(obs_v3_add(box.lo, box.hi), 0.5f);
    const double rad = 0.5 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                  (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const double cn = sqrt(cam_dir[0] * cam_dir[0] + cam_dir[1] * cam_dir[1] + cam_dir[2] * cam_dir[2]);
    const double yfov = 40.0 * 3.14159265358979323846 / 180.0, dist = rad / sin(0.5 * yfov) * 1.05;
    obs_vec3 eye = {(float)(ctr.x - cam_dir[0] / cn * dist), (float)(ctr.y - cam_dir[1] / cn * dist),
                    (float)(ctr.z - cam_dir[2] / cn * dist)};
    obs_vec3 up = fabs(cam_dir[1] / cn) > 0.99 ? obs_v3(0, 0, 1) : obs_v3(0, 1, 0);
    obs_camera cam = obs_camera_look_at(eye, ctr, up, (float)yfov, (float)fmax(1e-3 * dist, dist - 1.2 * rad),
                                        (float)(dist + 1.2 * rad));
    snprintf(cam.name, sizeof cam.name, "framing");
    cam.aspect = (float)W / (float)H;
    vol_light L;
    memset(&L, 0, sizeof L);
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    if (light_pos_given) {
        L.type = OBS_LIGHT_POINT;
        memcpy(L.position, light_pos, sizeof light_pos);
    } else {
        L.type = OBS_LIGHT_DIRECTIONAL;
        double d[3];
        if (light_dir_given) {
            memcpy(d, light_dir, sizeof d);
        } else { /* from the camera's upper right and behind it: view-space normalize(0.35, 0.6, 0.72) */
            const double lv3[3] = {0.35, 0.6, 0.72};
            const float *m = cam.world.m;
            for (int r = 0; r < 3; r++)
                d[r] = -(m[r] * lv3[0] + m[4 + r] * lv3[1] + m[8 + r] * lv3[2]);
        }
        const double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int c = 0; c < 3; c++)
            L.direction[c] = d[c] / n;
    }
    pool = obs_pool_create(g->threads);
    if (!pool) {
        fprintf(stderr, "obscura: error: cannot start %d threads\n", g->threads);
        scale_mpi_abort(comm, CLI_EXIT_INTERNAL); /* the other ranks would wait for this one */
        code = CLI_EXIT_INTERNAL;
        goto done;
    }

    /* ---- Light volume (independent of the camera) ---- */
    const int need_lv = (truth && !image_only) || (!truth && (rp.shading == VOL_SHADING_LIGHT_VOLUME || write_lv));
    t0 = obs_time_now();
    if (need_lv)
        st = vol_light_volume_build(ctx, pool, &grid, &tf, &L, &lp, &lv);
    t_lv = obs_time_now() - t0;
    if (comm)
        st = scale_mpi_agree(ctx, comm, st);
    if (st != OBS_STATUS_OK) {
        code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
        goto done;
    }
    if (!comm) { /* under MPI, rank 0 makes them once every rank has succeeded */
        st = cli_make_parent_dirs(ctx, prefix);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
    }
    if (truth) {
        /* ---- The exact transmittance and the light volume's error ---- */
        truth_volume_params tp = truth_volume_params_default();
        tp.kappa = lp.kappa;
        mcp.kappa = lp.kappa;
        t0 = obs_time_now();
        if (!image_only && !comm)
            st = truth_volume_light_error(ctx, pool, &grid, &tf, &L, &tp, &lv, &T, &err, &es);
        if (comm) {
            /* Deal: z slices interleaved (slice k to rank k mod N: neighbouring slices cost alike);
             * the MC image's tiles greedily by a uniform estimate (scale_deal_tasks: interleaved
             * too). Every rank computes the same dealing. */
            const int nz = image_only ? 0 : lv.nz;
            const size_t vox = image_only ? 0 : (size_t)lv.nx * lv.ny * lv.nz;
            ntasks = mc_image ? truth_volume_mc_task_count(W, H, mcp.tile) : 0;
            slice_owner = (int *)malloc(sizeof(int) * (size_t)(nz + 1));
            slice_mask = (unsigned char *)malloc((size_t)nz + 1);
            slice_seconds = (double *)calloc((size_t)ranks, sizeof(double));
            task_owner = (int *)malloc(sizeof(int) * (size_t)(ntasks + 1));
            task_mask = (unsigned char *)malloc((size_t)ntasks + 1);
            task_cost = (double *)malloc(sizeof(double) * (size_t)(ntasks + 1));
            per_rank = (scale_rank_stats *)calloc((size_t)ranks, sizeof(scale_rank_stats));
            if (vox) {
                T = (float *)calloc(vox, sizeof(float));
                err = (float *)calloc(vox, sizeof(float));
            }
            if (!slice_owner || !slice_mask || !slice_seconds || !task_owner || !task_mask || !task_cost || !per_rank ||
                (vox && (!T || !err)))
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth volume: out of memory");
            if (st == OBS_STATUS_OK && mc_image && ntasks == 0)
                st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume image: tile %d must be in [1, 64]", mcp.tile);
            for (int k = 0; st == OBS_STATUS_OK && k < nz; k++) {
                slice_owner[k] = k % ranks;
                slice_mask[k] = slice_owner[k] == rank;
            }
            if (st == OBS_STATUS_OK && !image_only)
                st = truth_volume_light_error_slices(ctx, pool, &grid, &tf, &L, &tp, &lv, slice_mask, T, err);
            t_truth = obs_time_now() - t0;
            for (int64_t t = 0; st == OBS_STATUS_OK && t < ntasks; t++)
                task_cost[t] = 1.0;
            if (st == OBS_STATUS_OK && ntasks > 0)
                st = scale_deal_tasks(ctx, task_cost, ntasks, ranks, task_owner);
            for (int64_t t = 0; st == OBS_STATUS_OK && t < ntasks; t++)
                task_mask[t] = task_owner[t] == rank;
            if (st == OBS_STATUS_OK && mc_image)
                st = truth_volume_mc_render_tasks(ctx, pool, &grid, &tf, &L, &cam, W, H, &mcp, task_mask, &mci);
            /* one failed rank fails the job, before anything is written */
            st = scale_fault_point(ctx, comm, st);
            const double tw = obs_time_now();
            st = scale_mpi_agree(ctx, comm, st);
            const double tg = obs_time_now();
            if (st == OBS_STATUS_OK)
                st = scale_mpi_gather_volume_slices(ctx, comm, slice_owner, nz, (int64_t)lv.nx * lv.ny, T, err, t_truth,
                                                    slice_seconds);
            if (st == OBS_STATUS_OK && mc_image)
                st = scale_mpi_gather_volume_image(ctx, comm, task_owner, task_cost, ntasks, mcp.tile, &mci, per_rank);
            t_wait = tg - tw;
            t_gather = obs_time_now() - tg;
            if (st == OBS_STATUS_OK && rank != 0)
                goto done; /* rank 0 writes */
            if (st == OBS_STATUS_OK && !image_only)
                truth_volume_error_stats_compute(err, (int64_t)vox, &es);
            if (st == OBS_STATUS_OK)
                st = cli_make_parent_dirs(ctx, prefix);
            if (st != OBS_STATUS_OK) {
                code = rank == 0 ? cli_fail(ctx, st) : CLI_EXIT_OK;
                goto done;
            }
        } else {
            t_truth = obs_time_now() - t0;
            if (st == OBS_STATUS_OK && mc_image)
                st = truth_volume_mc_render(ctx, pool, &grid, &tf, &L, &cam, W, H, &mcp, &mci);
        }
        t_write = obs_time_now();
        if (st == OBS_STATUS_OK && !image_only) {
            snprintf(path, sizeof path, "%s_T.nrrd", prefix);
            st = write_lv_nrrd(ctx, path, &lv, T);
        }
        if (st == OBS_STATUS_OK && !image_only) {
            snprintf(path, sizeof path, "%s_err.nrrd", prefix);
            st = write_lv_nrrd(ctx, path, &lv, err);
        }
        if (st == OBS_STATUS_OK && mc_image) {
            /* ---- The Monte Carlo single-scattering image reference (computed above) ---- */
            {
                io_channel ch[8] = {{"R", IO_PIXEL_FLOAT, &mci.rgba[0], NULL},
                                    {"G", IO_PIXEL_FLOAT, &mci.rgba[1], NULL},
                                    {"B", IO_PIXEL_FLOAT, &mci.rgba[2], NULL},
                                    {"A", IO_PIXEL_FLOAT, &mci.rgba[3], NULL},
                                    {"SE.R", IO_PIXEL_FLOAT, &mci.std_error[0], NULL},
                                    {"SE.G", IO_PIXEL_FLOAT, &mci.std_error[1], NULL},
                                    {"SE.B", IO_PIXEL_FLOAT, &mci.std_error[2], NULL},
                                    {"SE.A", IO_PIXEL_FLOAT, &mci.std_error[3], NULL}};
                io_attr at[2];
                memset(at, 0, sizeof at);
                strcpy(at[0].name, "obscura:version"); at[0].type = IO_ATTR_STRING; at[0].s = (char *)OBS_VERSION_STRING;
                strcpy(at[1].name, "obscura:conventions"); at[1].type = IO_ATTR_STRING;
                at[1].s = (char *)"R, G, B, A premultiplied over black: Monte Carlo single scattering (docs/volume/truth.md); "
                                  "SE.* the replicate standard errors; row 0 at top";
                snprintf(path, sizeof path, "%s_mc.exr", prefix);
                st = io_exr_write(ctx, path, ch, 8, at, 2);
            }
            if (st == OBS_STATUS_OK && !g->quiet)
                fprintf(stderr, "obscura: truth volume: MC image %dx%d, %lld samples per pixel in %.1f s; max error bar %.4g\n",
                        W, H, (long long)mcp.samples, mci.stats.seconds, mci.stats.max_std_error);
        }
        if (st == OBS_STATUS_OK && !g->quiet && !image_only)
            fprintf(stderr,
                    "obscura: truth volume: light volume %dx%dx%d (faces %d, %d; blend %.3f) in %.1f ms; exact "
                    "transmittance in %.1f ms; |l - T| max %.4g, mean %.4g, rmse %.4g\n",
                    lv.nx, lv.ny, lv.nz, lv.face0, lv.face1, (double)lv.blend_weight, 1e3 * t_lv, 1e3 * t_truth,
                    es.max_abs, es.mean_abs, es.rmse);
    } else {
        /* ---- The eye pass (depends on the camera): modulate the chromaticity before ray casting ---- */
        if (lp.eye_pass && need_lv) {
            t0 = obs_time_now();
            st = vol_eye_volume_build(ctx, pool, &grid, &tf, &cam, &lp, &eyev);
            if (st == OBS_STATUS_OK)
                st = vol_light_volume_modulate(ctx, &eyev, &lv);
            t_eye = obs_time_now() - t0;
            if (st != OBS_STATUS_OK) {
                code = cli_fail(ctx, st);
                goto done;
            }
        }
        /* ---- Ray casting ---- */
        t0 = obs_time_now();
        st = vol_raycast(ctx, pool, &grid, &tf, &L, need_lv ? &lv : NULL, &cam, W, H, NULL, &rp, rgba);
        t_rc = obs_time_now() - t0;
        if (st == OBS_STATUS_OK && rc_reps > 0) { /* --reps: one warm-up, then the median of rc_reps */
            vol_rc_prepared *prep = NULL;
            double tw[1000];
            st = vol_rc_prepare(ctx, pool, &grid, &tf, &rp, &prep);
            for (int r = -1; r < rc_reps && st == OBS_STATUS_OK; r++) {
                for (int c = 0; c < 4; c++) obs_image_f32_free(&rgba[c]);
                t0 = obs_time_now();
                st = vol_raycast_prepared(ctx, pool, prep, &L, need_lv ? &lv : NULL, &cam, W, H, NULL, &rp, rgba);
                if (r >= 0) tw[r] = obs_time_now() - t0;
            }
            vol_rc_prepared_free(prep);
            for (int a2 = 1; a2 < rc_reps; a2++) /* insertion sort: at most 1000 */
                for (int b2 = a2; b2 > 0 && tw[b2] < tw[b2 - 1]; b2--) { double x = tw[b2]; tw[b2] = tw[b2 - 1]; tw[b2 - 1] = x; }
            t_rc_warm = rc_reps % 2 ? tw[rc_reps / 2] : 0.5 * (tw[rc_reps / 2 - 1] + tw[rc_reps / 2]);
        }
        if (st == OBS_STATUS_OK) {
            io_channel ch[4] = {{"R", IO_PIXEL_FLOAT, &rgba[0], NULL},
                                {"G", IO_PIXEL_FLOAT, &rgba[1], NULL},
                                {"B", IO_PIXEL_FLOAT, &rgba[2], NULL},
                                {"A", IO_PIXEL_FLOAT, &rgba[3], NULL}};
            io_attr at[2];
            memset(at, 0, sizeof at);
            strcpy(at[0].name, "obscura:version"); at[0].type = IO_ATTR_STRING; at[0].s = (char *)OBS_VERSION_STRING;
            strcpy(at[1].name, "obscura:conventions"); at[1].type = IO_ATTR_STRING;
            at[1].s = (char *)"R, G, B, A premultiplied (front-to-back compositing; docs/volume/raycast.md); row 0 at top";
            snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
            st = io_exr_write(ctx, path, ch, 4, at, 2);
        }
        if (st == OBS_STATUS_OK) {
            snprintf(path, sizeof path, "%s.png", prefix);
            st = io_png_write(ctx, path, rgba, 3, IO_PNG_SRGB);   /* premultiplied = over black */
        }
        if (st == OBS_STATUS_OK && write_lv) {
            snprintf(path, sizeof path, "%s_l.nrrd", prefix);
            st = write_lv_nrrd(ctx, path, &lv, lv.l);
        }
        if (st == OBS_STATUS_OK && !g->quiet)
            fprintf(stderr, "obscura: volume %dx%dx%d, %s: light volume %.1f ms, ray casting %dx%d %.1f ms (%d threads)\n",
                    grid.nx, grid.ny, grid.nz, vol_shading_name(rp.shading), 1e3 * t_lv, W, H, 1e3 * t_rc,
                    obs_pool_threads(pool));
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    /* ---- Sidecar ---- */
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, truth ? "truth volume" : "volume", argc, argv);
    io_json_string(&j, "volume", file);
    io_json_begin_object(&j, "grid");
    io_json_int(&j, "nx", grid.nx);
    io_json_int(&j, "ny", grid.ny);
    io_json_int(&j, "nz", grid.nz);
    float sp[3] = {(float)grid.spacing[0], (float)grid.spacing[1], (float)grid.spacing[2]};
    io_json_floats(&j, "spacing", sp, 3);
    io_json_string(&j, "source_type", vol_type_name(grid.source_type));
    io_json_number(&j, "value_min", grid.value_min);
    io_json_number(&j, "value_max", grid.value_max);
    io_json_end_object(&j);
    io_json_string(&j, "transfer_function", tf.name[0] ? tf.name : tf_arg);
    io_json_begin_object(&j, "light");
    io_json_string(&j, "type", L.type == OBS_LIGHT_POINT ? "point" : "directional");
    float l3[3] = {(float)(L.type == OBS_LIGHT_POINT ? L.position[0] : L.direction[0]),
                   (float)(L.type == OBS_LIGHT_POINT ? L.position[1] : L.direction[1]),
                   (float)(L.type == OBS_LIGHT_POINT ? L.position[2] : L.direction[2])};
    io_json_floats(&j, L.type == OBS_LIGHT_POINT ? "position" : "direction", l3, 3);
    io_json_end_object(&j);
    io_json_begin_object(&j, "light_volume");
    io_json_bool(&j, "built", need_lv);
    io_json_int(&j, "scale", lp.scale);
    io_json_number(&j, "cone_angle_deg", lp.cone_angle_deg);
    io_json_bool(&j, "blend_second", lp.blend_second);
    io_json_number(&j, "kappa", lp.kappa);
    io_json_bool(&j, "eye_pass", lp.eye_pass);
    if (lp.eye_pass && eyev.l) {
        io_json_int(&j, "eye_face0", eyev.face0);
        io_json_int(&j, "eye_face1", eyev.face1);
        io_json_number(&j, "eye_blend_weight", eyev.blend_weight);
        io_json_number(&j, "eye_seconds", t_eye);
    }
    if (need_lv) {
        io_json_int(&j, "face0", lv.face0);
        io_json_int(&j, "face1", lv.face1);
        io_json_number(&j, "blend_weight", lv.blend_weight);
    }
    io_json_number(&j, "seconds", t_lv);
    io_json_end_object(&j);
    if (truth) {
        if (!image_only) {
            json_stats(&j, "light_volume_error", &es);
            io_json_number(&j, "seconds_exact_transmittance", t_truth);
        }
        if (mc_image) {
            io_json_begin_object(&j, "mc_image");
            cli_json_camera(&j, &cam);
            io_json_int(&j, "width", W);
            io_json_int(&j, "height", H);
            io_json_int(&j, "samples", mcp.samples);
            io_json_int(&j, "replicates", mcp.replicates);
            io_json_number(&j, "phase_g", mcp.g);
            io_json_number(&j, "kappa", mcp.kappa);
            io_json_int(&j, "seed", (int64_t)mcp.seed);
            io_json_number(&j, "majorant", mci.stats.majorant);
            io_json_number(&j, "max_std_error", mci.stats.max_std_error);
            io_json_int(&j, "tentative_collisions", (int64_t)mci.stats.tentative);
            io_json_int(&j, "real_collisions", (int64_t)mci.stats.collisions);
            io_json_int(&j, "over_majorant", (int64_t)mci.stats.over_majorant);
            io_json_int(&j, "pixels_hit", mci.stats.pixels_hit);
            io_json_number(&j, "seconds", mci.stats.seconds);
            io_json_string(&j, "file_suffix", "_mc.exr");
            io_json_end_object(&j);
        }
        if (comm) { /* the MPI run: ranks, dealing and balance (docs/scale.md, "truth volume") */
            double *sec = (double *)calloc(3 * (size_t)ranks, sizeof(double)); /* slices, image, collisions */
            for (int q = 0; sec && q < ranks; q++) {
                sec[q] = slice_seconds ? slice_seconds[q] : 0.0;
                sec[ranks + q] = per_rank ? per_rank[q].seconds_work : 0.0;
                sec[2 * ranks + q] = per_rank ? (double)per_rank[q].rays : 0.0;
            }
            io_json_begin_object(&j, "scale");
            io_json_int(&j, "ranks", ranks);
            io_json_int(&j, "slices", image_only ? 0 : lv.nz);
            io_json_string(&j, "slice_dealing", "interleaved: z slice k to rank k mod ranks");
            io_json_int(&j, "tasks", ntasks);
            io_json_string(&j, "dealing", "greedy by a uniform estimate in task order (interleaved tiles)");
            if (!image_only)
                io_json_number(&j, "imbalance_seconds_slices", sec ? scale_imbalance(sec, ranks) : NAN);
            if (mc_image) {
                io_json_number(&j, "imbalance_seconds_image", sec ? scale_imbalance(sec + ranks, ranks) : NAN);
                io_json_number(&j, "imbalance_collisions", sec ? scale_imbalance(sec + 2 * ranks, ranks) : NAN);
            }
            io_json_number(&j, "seconds_wait_rank0", t_wait);
            io_json_number(&j, "seconds_gather", t_gather);
            io_json_number(&j, "seconds_write", obs_time_now() - t_write);
            io_json_begin_array(&j, "per_rank");
            for (int q = 0; q < ranks; q++) {
                int64_t ns = 0;
                for (int k = 0; !image_only && k < lv.nz; k++)
                    ns += slice_owner[k] == q;
                io_json_begin_object(&j, NULL);
                io_json_int(&j, "rank", q);
                io_json_int(&j, "slices", ns);
                io_json_number(&j, "seconds_slices", sec ? sec[q] : NAN);
                if (mc_image) {
                    io_json_int(&j, "tasks", per_rank[q].tasks);
                    io_json_int(&j, "collisions", (int64_t)per_rank[q].rays);
                    io_json_number(&j, "seconds_image", per_rank[q].seconds_work);
                }
                io_json_end_object(&j);
            }
            io_json_end_array(&j);
            io_json_end_object(&j);
            free(sec);
        }
    } else {
        cli_json_camera(&j, &cam);
        io_json_int(&j, "width", W);
        io_json_int(&j, "height", H);
        io_json_string(&j, "mode", vol_shading_name(rp.shading));
        io_json_number(&j, "step", rp.step);
        io_json_int(&j, "brick", rp.brick);
        io_json_string(&j, "precision", rp.precision == VOL_RC_FAST ? "fast" : "exact");
        io_json_number(&j, "seconds_raycast", t_rc);
        if (rc_reps > 0) {
            io_json_int(&j, "raycast_reps", rc_reps);
            io_json_number(&j, "seconds_raycast_warm", t_rc_warm);
        }
    }
    io_json_number(&j, "seconds_load", t_load);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    code = cli_write_sidecar(ctx, &j, prefix);
done:
    free(slice_owner);
    free(slice_mask);
    free(slice_seconds);
    free(task_owner);
    free(task_mask);
    free(task_cost);
    free(per_rank);
    scale_mpi_finalize(comm);
    io_json_free(&j);
    free(tf_text);
    free(T);
    free(err);
    truth_volume_image_free(&mci);
    for (int c = 0; c < 4; c++)
        obs_image_f32_free(&rgba[c]);
    vol_light_volume_free(&lv);
    vol_light_volume_free(&eyev);
    vol_tf_free(&tf);
    vol_grid_free(&grid);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    return code;
}
