/* cmd_ao.c: `obscura ao`: screen-space AO on our G-buffer of a scene or on an external G-buffer
 * (EXR): AO as EXR, a PNG preview, a blended PNG and a JSON sidecar. docs/ao/README.md. */
#include "cli.h"
#include "ao/ao.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *ao_help =
    "usage: obscura ao --method NAME (--scene S.glb | --gbuffer G.exr) [options] -o PREFIX\n"
    "       obscura ao --list          print each method with its parameters and defaults\n"
    "input (one of):\n"
    "  --scene S.glb          render our G-buffer of a glTF scene, then run the method on it\n"
    "    --camera NAME|INDEX  camera (default: 'default', else the first, else a framing one)\n"
    "    --size WxH           image size (default 1920x1080, or 1920 wide at the camera's aspect)\n"
    "    --guard G            guard band: render (W+2G)x(H+2G), compute the inner WxH (default 0)\n"
    "    --infinite-far       infinite far plane (perspective cameras)\n"
    "  --gbuffer G.exr        an external G-buffer (what `obscura gbuffer` writes, or your own)\n"
    "    --depth-channel NAME depth channel (default: Z, else Zndc, else depth, else R)\n"
    "    --depth-kind KIND    linear, gl, zero-to-one or reversed-z (default: linear for Z, else the\n"
    "                         file's obscura:depth_convention)\n"
    "    --intrinsics F.json  fx, fy, cx, cy, projection, znear, zfar, depth_kind, inner_window (they\n"
    "                         override the EXR's obscura:* metadata; our gbuffer sidecar works too)\n"
    "    --no-gbuffer-normals ignore N.X/N.Y/N.Z (normals for the blend are then reconstructed)\n"
    "method and parameters (see --list):\n"
    "  --method NAME          sao\n"
    "  --preset NAME          start from a named parameter set (sao: default, peer, hpg12, thesis, g3d, g3d-hq)\n"
    "  --radius R --bias B --intensity I --epsilon E --samples N --turns T (0 = from the table)\n"
    "  --max-mip L (0 = no MIP pyramid) --log-max-offset K --normals depth|gbuffer --variant hpg12|g3d-hq\n"
    "  --no-blur --blur-stride S --edge-sharpness K --blur-key-far Z\n"
    "output:\n"
    "  -o, --output PREFIX    PREFIX.exr (channels AO, AO.raw, Z), PREFIX.png (AO preview),\n"
    "                         PREFIX_blend.png (AO times a Lambert-plus-ambient shading), PREFIX.json\n"
    "                         (default prefix: ao); missing directories are created\n"
    "AO is visibility: 1 = unoccluded. AO.raw is before the blur (equal to AO with --no-blur).\n"
    "The preview is AO quantised linearly (gamma 1.0), background black. The blend is\n"
    "AO * (0.25 + 0.75 max(0, n.l)) with the view-space light l = normalize(0.35, 0.6, 0.72) (from the\n"
    "upper right, behind the viewer) and n the G-buffer normal (else reconstructed from depth), written\n"
    "sRGB-encoded, background black.\n";

/* ---- method table (for --list and the sidecar) ------------------------------------------------ */

static void list_methods(void)
{
    ao_sao_params d = ao_sao_params_default();
    printf("sao     Scalable Ambient Obscurance [McGuire12]: the HPG12 shader as the llvmpipe peer runs it\n"
           "        (docs/ao/sao.md)\n");
    printf("  %-22s %-10s %s\n", "parameter", "default", "meaning");
    printf("  %-22s %-10s %s\n", "--variant", "hpg12", "hpg12 (falloff B) or g3d-hq (later G3D HIGH_QUALITY estimator)");
    printf("  %-22s %-10g %s\n", "--radius", (double)d.radius, "world-space radius r (m)");
    printf("  %-22s %-10g %s\n", "--bias", (double)d.bias, "bias (m)");
    printf("  %-22s %-10g %s\n", "--intensity", (double)d.intensity, "intensity (g3d-hq: the exponent)");
    printf("  %-22s %-10g %s\n", "--epsilon", (double)d.epsilon, "epsilon in (vn - bias)/(vv + epsilon)");
    printf("  %-22s %-10d %s\n", "--samples", d.samples, "taps N (NUM_SAMPLES)");
    printf("  %-22s %-10d %s\n", "--turns", d.spiral_turns,
           "spiral turns (NUM_SPIRAL_TURNS); 0 = McGuire's minimum-discrepancy table for N;\n"
           "                                    --samples without --turns uses the table");
    printf("  %-22s %-10d %s\n", "--max-mip", d.max_mip_level, "deepest depth MIP level a tap may read (0 = none)");
    printf("  %-22s %-10d %s\n", "--log-max-offset", d.log_max_offset, "LOG_MAX_OFFSET of the MIP selection");
    printf("  %-22s %-10s %s\n", "--normals", "depth", "depth: face normals from depth (reference); gbuffer");
    printf("  %-22s %-10s %s\n", "--no-blur", "(blur on)", "skip the separable bilateral blur (R = 4)");
    printf("  %-22s %-10d %s\n", "--blur-stride", d.blur_stride, "blur tap spacing (px)");
    printf("  %-22s %-10g %s\n", "--edge-sharpness", (double)d.edge_sharpness, "blur EDGE_SHARPNESS");
    printf("  %-22s %-10g %s\n", "--blur-key-far", (double)d.blur_key_far,
           "blur key scale (m): edgeK = sharpness * 2000 / this");
    printf("  presets (--preset):");
    for (const char *const *n = ao_sao_preset_names(); *n; n++)
        printf(" %s", *n);
    printf("\n");
    for (const char *const *n = ao_sao_preset_names(); *n; n++) {
        ao_sao_params p;
        char buf[512];
        ao_sao_params_preset(*n, &p);
        ao_sao_params_to_string(&p, buf, sizeof buf);
        printf("    %-8s %s\n", *n, buf);
    }
}

/* mkdir -p for the directory part of path (as cmd_gbuffer.c does). */
static obs_status make_parent_dirs(obs_context *ctx, const char *path)
{
    char buf[4096];
    size_t n = strlen(path);
    if (n >= sizeof buf)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "output path too long: %s", path);
    memcpy(buf, path, n + 1);
    char *slash = strrchr(buf, '/');
    if (!slash)
        return OBS_STATUS_OK;
    *slash = '\0';
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot create directory %s: %s", buf, strerror(errno));
        *p = '/';
    }
    if (buf[0] && mkdir(buf, 0777) != 0 && errno != EEXIST)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot create directory %s: %s", buf, strerror(errno));
    return OBS_STATUS_OK;
}

static int parse_depth_kind(const char *v, ao_depth_kind *out)
{
    if (!v) return 0;
    if (!strcmp(v, "linear")) *out = AO_DEPTH_KIND_LINEAR;
    else if (!strcmp(v, "gl")) *out = AO_DEPTH_KIND_NDC_GL;
    else if (!strcmp(v, "zero-to-one")) *out = AO_DEPTH_KIND_NDC_ZERO_TO_ONE;
    else if (!strcmp(v, "reversed-z")) *out = AO_DEPTH_KIND_NDC_REVERSED_Z;
    else return 0;
    return 1;
}

static const char *depth_kind_name(ao_depth_kind k)
{
    switch (k) {
    case AO_DEPTH_KIND_LINEAR: return "linear";
    case AO_DEPTH_KIND_NDC_GL: return "gl";
    case AO_DEPTH_KIND_NDC_ZERO_TO_ONE: return "zero-to-one";
    case AO_DEPTH_KIND_NDC_REVERSED_Z: return "reversed-z";
    default: return "auto";
    }
}

/* ---- the command ---------------------------------------------------------------------------- */

int cmd_ao(cli_globals *g, int argc, char **argv)
{
    const char *method = NULL, *scene_path = NULL, *gbuffer_path = NULL, *prefix = "ao", *camera = "";
    const char *intrinsics_path = NULL;
    int W = 1920, H = 1080, size_given = 0, guard = 0, infinite_far = 0, gbuffer_normals = 1;
    ao_external_options xo = ao_external_options_default();
    ao_sao_params sp = ao_sao_params_default();
    /* Parameter flags are applied after --preset, whatever their order: remember them. */
    const char *preset = NULL;
    double radius = NAN, bias = NAN, intensity = NAN, epsilon = NAN, edge = NAN, keyfar = NAN;
    long long samples = -1, turns = -1, max_mip = -1, log_max_offset = -1, blur_stride = -1;
    int no_blur = 0, normals = -1, variant = -1;

    if (argc < 2) {
        fputs(ao_help, stderr);
        return CLI_EXIT_USAGE;
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double d;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(ao_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--list")) {
            list_methods();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--method")) {
            if (!v) return cli_usage_error("--method needs a name (see 'obscura ao --list')");
            method = v; i++;
        } else if (!strcmp(a, "--scene")) {
            if (!v) return cli_usage_error("--scene needs a .gltf/.glb path");
            scene_path = v; i++;
        } else if (!strcmp(a, "--gbuffer")) {
            if (!v) return cli_usage_error("--gbuffer needs an image path");
            gbuffer_path = v; i++;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            if (!v) return cli_usage_error("%s needs a path prefix", a);
            prefix = v; i++;
        } else if (!strcmp(a, "--camera")) {
            if (!v) return cli_usage_error("--camera needs a name or index");
            camera = v; i++;
        } else if (!strcmp(a, "--size")) {
            if (!cli_parse_size(v, &W, &H))
                return cli_usage_error("--size needs WxH with each side in [1, %d]", RAST_MAX_DIM);
            size_given = 1; i++;
        } else if (!strcmp(a, "--guard")) {
            if (!cli_parse_int(v, 0, RAST_MAX_DIM / 2, &ll)) return cli_usage_error("--guard needs an integer >= 0");
            guard = (int)ll; i++;
        } else if (!strcmp(a, "--infinite-far")) {
            infinite_far = 1;
        } else if (!strcmp(a, "--depth-channel")) {
            if (!v) return cli_usage_error("--depth-channel needs a channel name");
            xo.depth_channel = v; i++;
        } else if (!strcmp(a, "--depth-kind")) {
            if (!parse_depth_kind(v, &xo.depth_kind))
                return cli_usage_error("--depth-kind needs linear, gl, zero-to-one or reversed-z");
            i++;
        } else if (!strcmp(a, "--intrinsics")) {
            if (!v) return cli_usage_error("--intrinsics needs a JSON path");
            intrinsics_path = v; i++;
        } else if (!strcmp(a, "--no-gbuffer-normals")) {
            gbuffer_normals = 0;
        } else if (!strcmp(a, "--preset")) {
            if (!v) return cli_usage_error("--preset needs a name (see 'obscura ao --list')");
            preset = v; i++;
        } else if (!strcmp(a, "--radius") || !strcmp(a, "--bias") || !strcmp(a, "--intensity") ||
                   !strcmp(a, "--epsilon") || !strcmp(a, "--edge-sharpness") || !strcmp(a, "--blur-key-far")) {
            if (!cli_parse_float(v, &d) || !isfinite(d)) return cli_usage_error("%s needs a finite number", a);
            if (!strcmp(a, "--radius")) radius = d;
            else if (!strcmp(a, "--bias")) bias = d;
            else if (!strcmp(a, "--intensity")) intensity = d;
            else if (!strcmp(a, "--epsilon")) epsilon = d;
            else if (!strcmp(a, "--edge-sharpness")) edge = d;
            else keyfar = d;
            i++;
        } else if (!strcmp(a, "--samples")) {
            if (!cli_parse_int(v, 1, AO_SAO_MAX_SAMPLES, &samples))
                return cli_usage_error("--samples needs an integer in [1, %d]", AO_SAO_MAX_SAMPLES);
            i++;
        } else if (!strcmp(a, "--turns")) {
            if (!cli_parse_int(v, 0, 1000000, &turns)) return cli_usage_error("--turns needs an integer in [0, 1000000]");
            i++;
        } else if (!strcmp(a, "--max-mip")) {
            if (!cli_parse_int(v, 0, AO_SAO_MAX_MIP, &max_mip))
                return cli_usage_error("--max-mip needs an integer in [0, %d]", AO_SAO_MAX_MIP);
            i++;
        } else if (!strcmp(a, "--log-max-offset")) {
            if (!cli_parse_int(v, 0, 30, &log_max_offset)) return cli_usage_error("--log-max-offset needs an integer in [0, 30]");
            i++;
        } else if (!strcmp(a, "--blur-stride")) {
            if (!cli_parse_int(v, 1, 64, &blur_stride)) return cli_usage_error("--blur-stride needs an integer in [1, 64]");
            i++;
        } else if (!strcmp(a, "--no-blur")) {
            no_blur = 1;
        } else if (!strcmp(a, "--normals")) {
            if (v && !strcmp(v, "depth")) normals = AO_SAO_NORMALS_FROM_DEPTH;
            else if (v && !strcmp(v, "gbuffer")) normals = AO_SAO_NORMALS_GBUFFER;
            else return cli_usage_error("--normals needs depth or gbuffer");
            i++;
        } else if (!strcmp(a, "--variant")) {
            if (v && !strcmp(v, "hpg12")) variant = AO_SAO_VARIANT_HPG12;
            else if (v && !strcmp(v, "g3d-hq")) variant = AO_SAO_VARIANT_G3D_HQ;
            else return cli_usage_error("--variant needs hpg12 or g3d-hq");
            i++;
        } else {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            return cli_usage_error("ao: unknown option '%s' (input is --scene or --gbuffer)", a);
        }
    }
    if (!method)
        return cli_usage_error("ao: no --method given (see 'obscura ao --list')");
    if (strcmp(method, "sao") != 0)
        return cli_usage_error("ao: unknown method '%s' (see 'obscura ao --list')", method);
    if (!scene_path == !gbuffer_path)
        return cli_usage_error("ao: give exactly one of --scene and --gbuffer");
    if (gbuffer_path && (size_given || guard || infinite_far || camera[0]))
        return cli_usage_error("ao: --camera, --size, --guard and --infinite-far apply to --scene only");
    if (scene_path && (xo.depth_channel || xo.depth_kind != AO_DEPTH_KIND_AUTO || intrinsics_path))
        return cli_usage_error("ao: --depth-channel, --depth-kind and --intrinsics apply to --gbuffer only");
    if (preset && !ao_sao_params_preset(preset, &sp))
        return cli_usage_error("ao: unknown sao preset '%s' (see 'obscura ao --list')", preset);
    if (variant >= 0) sp.variant = (ao_sao_variant)variant;
    if (!isnan(radius)) sp.radius = (float)radius;
    if (!isnan(bias)) sp.bias = (float)bias;
    if (!isnan(intensity)) sp.intensity = (float)intensity;
    if (!isnan(epsilon)) sp.epsilon = (float)epsilon;
    if (!isnan(edge)) sp.edge_sharpness = (float)edge;
    if (!isnan(keyfar)) sp.blur_key_far = (float)keyfar;
    if (samples > 0) {
        sp.samples = (int)samples;
        if (turns < 0)
            sp.spiral_turns = AO_SAO_TURNS_FROM_TABLE; /* documented: --samples alone takes the table's turns */
    }
    if (turns >= 0) sp.spiral_turns = (int)turns;
    if (max_mip >= 0) sp.max_mip_level = (int)max_mip;
    if (log_max_offset >= 0) sp.log_max_offset = (int)log_max_offset;
    if (blur_stride > 0) sp.blur_stride = (int)blur_stride;
    if (no_blur) sp.blur = 0;
    if (normals >= 0) sp.normals = (ao_sao_normals)normals;

    obs_context *ctx = obs_context_create();
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    obs_scene scene;
    obs_scene_init(&scene);
    obs_pool *pool = NULL;
    rast_gbuffer gb;
    memset(&gb, 0, sizeof gb);
    io_image im;
    memset(&im, 0, sizeof im);
    ao_external ext;
    memset(&ext, 0, sizeof ext);
    obs_image_f32 ao = {0}, ao_raw = {0}, preview = {0}, blend = {0}, nrm[3] = {{0}};
    io_json j;
    io_json_init(&j);
    char *intr_text = NULL;
    int code = CLI_EXIT_OK;
    obs_camera cam;
    memset(&cam, 0, sizeof cam);
    ao_input in;
    memset(&in, 0, sizeof in);
    ao_intrinsics intr = ao_intrinsics_unknown();
    double t_in0 = obs_time_now(), t_in1, t_ao0, t_ao1;

    obs_status st = ao_sao_params_validate(ctx, &sp);
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    pool = obs_pool_create(g->threads);
    if (!pool) {
        fprintf(stderr, "obscura: error: cannot start %d threads\n", g->threads);
        code = CLI_EXIT_INTERNAL;
        goto done;
    }

    /* ---- Input ---- */
    if (scene_path) {
        st = cli_load_scene(ctx, scene_path, &scene);
        if (st == OBS_STATUS_OK)
            st = cli_pick_camera(ctx, &scene, camera, &cam);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        if (infinite_far && cam.projection == OBS_PROJECTION_PERSPECTIVE)
            cam.zfar = INFINITY;
        if (!size_given && cam.projection == OBS_PROJECTION_PERSPECTIVE && cam.aspect > 0.0f) {
            W = 1920;
            H = (int)lround(1920.0 / cam.aspect);
            if (H < 1 || H > RAST_MAX_DIM) {
                code = cli_usage_error("camera aspect %g gives an unusable height; pass --size", (double)cam.aspect);
                goto done;
            }
        }
        rast_params rp = rast_params_default();
        rp.width = W;
        rp.height = H;
        rp.guard = guard;
        rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
        st = rast_gbuffer_alloc(ctx, &rp, &gb);
        rast_view view = {cam};
        if (st == OBS_STATUS_OK)
            st = rast_render(ctx, pool, &scene, &view, 1, &rp, &gb, NULL);
        if (st == OBS_STATUS_OK)
            st = ao_input_from_gbuffer(ctx, &gb, 1, &in);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
    } else {
        if (intrinsics_path) {
            size_t len;
            st = io_read_file(ctx, intrinsics_path, (size_t)16 << 20, &intr_text, &len);
            if (st == OBS_STATUS_OK)
                st = ao_intrinsics_parse_json(ctx, intr_text, &intr);
            if (st != OBS_STATUS_OK) {
                code = cli_fail(ctx, st);
                goto done;
            }
            xo.intrinsics = &intr;
        }
        xo.normals = gbuffer_normals ? AO_EXTERNAL_NORMALS_AUTO : AO_EXTERNAL_NORMALS_NONE;
        st = io_image_read(ctx, gbuffer_path, &im);
        if (st == OBS_STATUS_OK)
            st = ao_external_from_image(ctx, &im, &xo, &ext);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        in = ext.input; /* planes point into ext, which stays put */
        W = in.w;
        H = in.h;
    }
    t_in1 = obs_time_now();
    if (sp.normals == AO_SAO_NORMALS_GBUFFER && !in.normal[0]) {
        code = cli_usage_error("ao: --normals gbuffer, but the G-buffer has no normals");
        goto done;
    }

    /* ---- AO ---- */
    st = obs_image_f32_alloc(ctx, in.w, in.h, &ao);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in.w, in.h, &ao_raw);
    ao_sao_stats stats;
    memset(&stats, 0, sizeof stats);
    t_ao0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = ao_sao_compute(ctx, pool, &in, &sp, &ao, &ao_raw, &stats);
    t_ao1 = obs_time_now();
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    ao_sao_constants K = ao_sao_constants_from_params(&sp, &in);
    char params_text[512];
    ao_sao_params_to_string(&sp, params_text, sizeof params_text);
    if (!g->quiet)
        fprintf(stderr, "obscura: ao sao: %dx%d (buffer %dx%d), %s: %.2f ms (%d threads)\n", in.w, in.h, in.width,
                in.height, params_text, 1e3 * (t_ao1 - t_ao0), obs_pool_threads(pool));

    /* ---- Normals for the blend: the G-buffer's, else reconstructed from depth ---- */
    const obs_image_f32 *bn[3] = {in.normal[0], in.normal[1], in.normal[2]};
    if (!bn[0]) {
        for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
            st = obs_image_f32_alloc(ctx, in.width, in.height, &nrm[c]);
        if (st == OBS_STATUS_OK)
            st = ao_normals_from_depth(ctx, pool, &in, nrm);
        for (int c = 0; c < 3; c++)
            bn[c] = &nrm[c];
    }
    /* ---- Preview and blend ---- */
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in.w, in.h, &preview);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in.w, in.h, &blend);
    if (st == OBS_STATUS_OK) {
        const float L[3] = {0.35f, 0.6f, 0.72f};
        const float il = 1.0f / sqrtf(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
        for (int y = 0; y < in.h; y++)
            for (int x = 0; x < in.w; x++) {
                const int fx = in.x0 + x, fy = in.y0 + y;
                const float d = obs_image_f32_row(in.depth, fy)[fx];
                const float a = obs_image_f32_row(&ao, y)[x];
                const int bg = !(d > 0.0f && d < INFINITY);
                obs_image_f32_row(&preview, y)[x] = bg ? 0.0f : a;
                float ndl = (obs_image_f32_row(bn[0], fy)[fx] * L[0] + obs_image_f32_row(bn[1], fy)[fx] * L[1] +
                             obs_image_f32_row(bn[2], fy)[fx] * L[2]) * il;
                ndl = ndl > 0.0f ? ndl : 0.0f;
                obs_image_f32_row(&blend, y)[x] = bg ? 0.0f : a * (0.25f + 0.75f * ndl);
            }
    }
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }

    /* ---- Files ---- */
    obs_image_f32 zwin = obs_image_f32_window(in.depth, in.x0, in.y0, in.w, in.h);
    io_channel ch[3] = {
        {"AO", IO_PIXEL_FLOAT, &ao, NULL},
        {"AO.raw", IO_PIXEL_FLOAT, &ao_raw, NULL},
        {"Z", IO_PIXEL_FLOAT, &zwin, NULL},
    };
    float fxyc[4] = {(float)in.fx, (float)in.fy, (float)(in.cx - in.x0), (float)(in.cy - in.y0)};
    io_attr at[12];
    memset(at, 0, sizeof at);
    int na = 0;
    strcpy(at[na].name, "obscura:method"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)"sao"; na++;
    strcpy(at[na].name, "obscura:params"); at[na].type = IO_ATTR_STRING; at[na].s = params_text; na++;
    strcpy(at[na].name, "obscura:pixel_model_fx_fy_cx_cy"); at[na].type = IO_ATTR_FLOATS; at[na].v = fxyc; at[na].n = 4; na++;
    strcpy(at[na].name, "obscura:projection_type"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(in.projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic"); na++;
    strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
    strcpy(at[na].name, "obscura:input"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(scene_path ? scene_path : gbuffer_path); na++;
    strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)"AO = visibility (1 = unoccluded), after the blur; AO.raw = before the blur; row 0 at top; "
                       "Z = linear depth, inf = background; SAO's pattern in GL pixel coordinates of the full "
                       "buffer (docs/ao/sao.md)";
    na++;
    char path[4200];
    st = make_parent_dirs(ctx, prefix);
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s.exr", prefix);
        st = io_exr_write(ctx, path, ch, 3, at, na);
    }
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s.png", prefix);
        st = io_png_write(ctx, path, &preview, 1, IO_PNG_LINEAR);
    }
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s_blend.png", prefix);
        st = io_png_write(ctx, path, &blend, 1, IO_PNG_SRGB);
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    /* ---- JSON sidecar ---- */
    double sum = 0.0;
    int64_t nsurf = 0;
    for (int y = 0; y < in.h; y++)
        for (int x = 0; x < in.w; x++) {
            float d = obs_image_f32_row(in.depth, in.y0 + y)[in.x0 + x];
            if (d > 0.0f && d < INFINITY) {
                sum += obs_image_f32_row(&ao, y)[x];
                nsurf++;
            }
        }
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, "ao", argc, argv);
    io_json_string(&j, "method", "sao");
    io_json_begin_object(&j, "input");
    if (scene_path) {
        io_json_string(&j, "scene", scene_path);
        io_json_string(&j, "camera", cam.name);
        io_json_int(&j, "guard", guard);
    } else {
        io_json_string(&j, "gbuffer", gbuffer_path);
        io_json_string(&j, "depth_channel", ext.depth_channel);
        io_json_string(&j, "depth_kind", depth_kind_name(ext.depth_kind));
        io_json_int(&j, "background_pixels", ext.background_pixels);
        io_json_int(&j, "invalid_depth_pixels", ext.invalid_depth_pixels);
        if (intrinsics_path)
            io_json_string(&j, "intrinsics", intrinsics_path);
    }
    io_json_int(&j, "buffer_width", in.width);
    io_json_int(&j, "buffer_height", in.height);
    io_json_int(&j, "window_x", in.x0);
    io_json_int(&j, "window_y", in.y0);
    io_json_int(&j, "width", in.w);
    io_json_int(&j, "height", in.h);
    io_json_number(&j, "fx", in.fx);
    io_json_number(&j, "fy", in.fy);
    io_json_number(&j, "cx", in.cx);
    io_json_number(&j, "cy", in.cy);
    io_json_string(&j, "projection", in.projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic");
    io_json_number(&j, "znear", in.znear);
    if (isinf(in.zfar))
        io_json_string(&j, "zfar", "infinity");
    else
        io_json_number(&j, "zfar", in.zfar);
    io_json_bool(&j, "has_normals", in.normal[0] != NULL);
    io_json_end_object(&j);
    io_json_begin_object(&j, "params");
    io_json_string(&j, "variant", sp.variant == AO_SAO_VARIANT_G3D_HQ ? "g3d-hq" : "hpg12");
    io_json_string(&j, "preset", preset ? preset : "default");
    io_json_number(&j, "radius", sp.radius);
    io_json_number(&j, "bias", sp.bias);
    io_json_number(&j, "intensity", sp.intensity);
    io_json_number(&j, "epsilon", sp.epsilon);
    io_json_int(&j, "samples", sp.samples);
    io_json_int(&j, "spiral_turns", K.num_spiral_turns);
    io_json_bool(&j, "spiral_turns_from_table", sp.spiral_turns == AO_SAO_TURNS_FROM_TABLE);
    io_json_int(&j, "max_mip_level", sp.max_mip_level);
    io_json_int(&j, "log_max_offset", sp.log_max_offset);
    io_json_string(&j, "normals", sp.normals == AO_SAO_NORMALS_GBUFFER ? "gbuffer" : "depth");
    io_json_bool(&j, "blur", sp.blur);
    io_json_int(&j, "blur_radius", AO_SAO_BLUR_RADIUS);
    io_json_int(&j, "blur_stride", sp.blur_stride);
    io_json_number(&j, "edge_sharpness", sp.edge_sharpness);
    io_json_number(&j, "blur_key_far", sp.blur_key_far);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    io_json_begin_object(&j, "constants");
    io_json_floats(&j, "projInfo", K.proj_info, 4);
    io_json_number(&j, "projScale", K.proj_scale);
    io_json_number(&j, "radius2", K.radius2);
    io_json_number(&j, "inv_num_samples", K.inv_num_samples);
    io_json_number(&j, "turns_angle", K.turns_angle);
    io_json_number(&j, "final_scale", K.final_scale);
    io_json_int(&j, "max_mip", K.max_mip);
    io_json_number(&j, "blur_edgeK", K.edge_k);
    io_json_floats(&j, "blur_gaussian", ao_sao_blur_gaussian, AO_SAO_BLUR_RADIUS + 1);
    io_json_end_object(&j);
    io_json_begin_object(&j, "stats");
    io_json_int(&j, "pixels_computed", stats.pixels_computed);
    io_json_int(&j, "pixels_background", stats.pixels_background);
    io_json_int(&j, "pixels_degenerate_normal", stats.pixels_degenerate_normal);
    io_json_int(&j, "pixels_below_min_radius", stats.pixels_below_min_radius);
    io_json_int(&j, "surface_pixels_in_window", nsurf);
    io_json_number(&j, "mean_visibility_surface", nsurf ? sum / (double)nsurf : 1.0);
    io_json_number(&j, "seconds_input", t_in1 - t_in0);
    io_json_number(&j, "seconds_csz", stats.seconds_csz);
    io_json_number(&j, "seconds_mip", stats.seconds_mip);
    io_json_number(&j, "seconds_ao", stats.seconds_ao);
    io_json_number(&j, "seconds_blur", stats.seconds_blur);
    io_json_number(&j, "seconds_total_ao", t_ao1 - t_ao0);
    io_json_end_object(&j);
    io_json_begin_array(&j, "channels");
    for (int c = 0; c < 3; c++)
        io_json_string(&j, NULL, ch[c].name);
    io_json_end_array(&j);
    io_json_string(&j, "preview_png", "AO, linear quantisation (gamma 1.0); background black");
    io_json_string(&j, "blend_png", "AO * (0.25 + 0.75 max(0, n.l)), l = normalize(0.35, 0.6, 0.72) view space, "
                                    "sRGB-encoded; background black");
    io_json_end_object(&j);
    snprintf(path, sizeof path, "%s.json", prefix);
    st = io_json_write(ctx, &j, path);
    if (st != OBS_STATUS_OK) {
        fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
        code = CLI_EXIT_OUTPUT;
        goto done;
    }
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s.exr, %s.png, %s_blend.png, %s.json\n", prefix, prefix, prefix, prefix);
done:
    free(intr_text);
    io_json_free(&j);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&nrm[c]);
    obs_image_f32_free(&blend);
    obs_image_f32_free(&preview);
    obs_image_f32_free(&ao_raw);
    obs_image_f32_free(&ao);
    ao_external_free(&ext);
    io_image_free(&im);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
    return code;
}
