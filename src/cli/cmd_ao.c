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
    "method and parameters (each method's flags, defaults and presets: --list):\n"
    "  --method NAME          the technique (see --list)\n"
    "  --preset NAME          start from a named parameter set; parameter flags apply on top of it,\n"
    "                         whatever their order\n"
    "  --PARAM VALUE          a number, or a choice for named options; --PARAM / --no-PARAM for\n"
    "                         switches (e.g. --no-blur)\n"
    "output:\n"
    "  -o, --output PREFIX    PREFIX.exr (channels AO, AO.raw, Z), PREFIX.png (AO preview),\n"
    "                         PREFIX_blend.png (AO times a Lambert-plus-ambient shading), PREFIX.json\n"
    "                         (default prefix: ao); -o out.exr names the EXR itself and the rest go\n"
    "                         beside it (out.png, out_blend.png, out.json); missing directories are\n"
    "                         created\n"
    "AO is visibility: 1 = unoccluded. AO.raw is before the blur (equal to AO with --no-blur).\n"
    "The preview is AO quantised linearly (gamma 1.0), background black. The blend is\n"
    "AO * (0.25 + 0.75 max(0, n.l)) with the view-space light l = normalize(0.35, 0.6, 0.72) (from the\n"
    "upper right, behind the viewer) and n the G-buffer normal (else reconstructed from depth), written\n"
    "sRGB-encoded, background black.\n";

/* ---- method table (for --list and the sidecar) ------------------------------------------------ */

static void format_param_value(const ao_param_desc *d, const void *params, char *buf, size_t size)
{
    const char *base = (const char *)params + d->offset;
    int iv;
    float fv;
    switch (d->type) {
    case AO_PARAM_FLOAT:
        memcpy(&fv, base, sizeof fv);
        snprintf(buf, size, "%g", (double)fv);
        break;
    case AO_PARAM_INT:
        memcpy(&iv, base, sizeof iv);
        snprintf(buf, size, "%d", iv);
        break;
    case AO_PARAM_BOOL:
        memcpy(&iv, base, sizeof iv);
        snprintf(buf, size, "%s", iv ? "on" : "off");
        break;
    default: {
        memcpy(&iv, base, sizeof iv);
        int n = 0;
        while (d->choices[n])
            n++;
        snprintf(buf, size, "%s", iv >= 0 && iv < n ? d->choices[iv] : "?");
    }
    }
}

static void list_methods(void)
{
    unsigned char params[AO_PARAMS_MAX_SIZE];
    for (const ao_method *const *mp = ao_methods(); *mp; mp++) {
        const ao_method *m = *mp;
        m->params_default(params);
        printf("%-10s %s\n           (%s; matched ground truth: obscura truth ao --estimator %s)\n", m->name, m->title,
               m->doc, m->truth_estimator(params));
        printf("  %-22s %-10s %s\n", "parameter", "default", "meaning");
        for (int i = 0; i < m->param_count; i++) {
            const ao_param_desc *d = &m->params[i];
            char flag[64], val[64], range[160] = "";
            snprintf(flag, sizeof flag, "--%s", d->name);
            if (d->type == AO_PARAM_BOOL)
                snprintf(flag, sizeof flag, "--[no-]%s", d->name);
            format_param_value(d, params, val, sizeof val);
            if (d->type == AO_PARAM_ENUM) {
                size_t o = 0;
                for (int c = 0; d->choices[c] && o < sizeof range; c++)
                    o += (size_t)snprintf(range + o, sizeof range - o, "%s%s", c ? "|" : " [", d->choices[c]);
                if (o < sizeof range)
                    snprintf(range + o, sizeof range - o, "]");
            } else if (d->type != AO_PARAM_BOOL) {
                snprintf(range, sizeof range, " [%g, %g]", d->min, d->max);
            }
            printf("  %-22s %-10s %s%s\n", flag, val, d->help, range);
        }
        printf("  presets (--preset):");
        for (const char *const *n = m->preset_names; *n; n++)
            printf(" %s", *n);
        printf("\n");
        for (const char *const *n = m->preset_names; *n; n++) {
            char buf[1024];
            if (!m->params_preset(*n, params))
                continue;
            m->params_to_string(params, buf, sizeof buf);
            printf("    %-10s %s\n", *n, buf);
        }
        printf("\n");
    }
}

/* Apply one parameter flag (argv[*i] is "--NAME" or "--no-NAME"). Returns 1 when it was the
 * method's, 0 when it is not a parameter of m, -1 on a usage error (printed). */
static int apply_param_flag(const ao_method *m, void *params, unsigned char *given, int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    if (strncmp(a, "--", 2) != 0)
        return 0;
    const char *name = a + 2;
    int negated = 0;
    const ao_param_desc *d = ao_method_param(m, name);
    if (!d && !strncmp(name, "no-", 3)) {
        d = ao_method_param(m, name + 3);
        negated = 1;
        if (d && !(d->type == AO_PARAM_BOOL || (d->type == AO_PARAM_ENUM && !strcmp(d->choices[0], "none"))))
            return cli_usage_error("%s: %s is not a switch", m->name, a), -1;
    }
    if (!d)
        return 0;
    given[d - m->params] = 1;
    char *field = (char *)params + d->offset;
    const char *v = *i + 1 < argc ? argv[*i + 1] : NULL;
    int iv;
    if (negated || d->type == AO_PARAM_BOOL) {
        iv = negated ? 0 : 1;
        memcpy(field, &iv, sizeof iv);
        return 1;
    }
    if (d->type == AO_PARAM_FLOAT) {
        double x;
        if (!cli_parse_float(v, &x) || !isfinite(x) || x < d->min || x > d->max)
            return cli_usage_error("%s: %s needs a number in [%g, %g]", m->name, a, d->min, d->max), -1;
        float fv = (float)x;
        memcpy(field, &fv, sizeof fv);
    } else if (d->type == AO_PARAM_INT) {
        long long ll;
        if (!cli_parse_int(v, (long long)d->min, (long long)d->max, &ll))
            return cli_usage_error("%s: %s needs an integer in [%lld, %lld]", m->name, a, (long long)d->min,
                                   (long long)d->max), -1;
        iv = (int)ll;
        memcpy(field, &iv, sizeof iv);
    } else {
        int c = 0;
        while (d->choices[c] && (!v || strcmp(d->choices[c], v) != 0))
            c++;
        if (!d->choices[c]) {
            char list[256];
            size_t o = 0;
            for (int k = 0; d->choices[k] && o < sizeof list; k++)
                o += (size_t)snprintf(list + o, sizeof list - o, "%s%s", k ? ", " : "", d->choices[k]);
            return cli_usage_error("%s: %s needs one of: %s", m->name, a, list), -1;
        }
        memcpy(field, &c, sizeof c);
    }
    (*i)++;
    return 1;
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
    char prefix_buf[4000], exr_ext[5] = ".exr";
    const char *intrinsics_path = NULL;
    int W = 1920, H = 1080, size_given = 0, guard = 0, infinite_far = 0, gbuffer_normals = 1;
    ao_external_options xo = ao_external_options_default();
    /* Parameters: the method's defaults, then --preset, then the parameter flags in their order
     * (so flags apply on top of the preset, whatever their order). */
    const char *preset = NULL;
    const ao_method *m = NULL;
    unsigned char params[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
    unsigned char given[256];
    memset(given, 0, sizeof given);

    if (argc < 2) {
        fputs(ao_help, stderr);
        return CLI_EXIT_USAGE;
    }
    /* Pre-pass: the method and the preset decide what the parameter flags mean. */
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(ao_help, stdout);
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--list")) {
            list_methods();
            return CLI_EXIT_OK;
        } else if (!strcmp(a, "--method") && i + 1 < argc) {
            method = argv[++i];
        } else if (!strcmp(a, "--preset") && i + 1 < argc) {
            preset = argv[++i];
        }
    }
    if (!method)
        return cli_usage_error("ao: no --method given (see 'obscura ao --list')");
    m = ao_method_find(method);
    if (!m)
        return cli_usage_error("ao: unknown method '%s' (see 'obscura ao --list')", method);
    if (m->params_size > sizeof params || m->param_count > (int)sizeof given)
        return CLI_EXIT_INTERNAL;
    m->params_default(params);
    if (preset && !m->params_preset(preset, params))
        return cli_usage_error("ao: unknown %s preset '%s' (see 'obscura ao --list')", m->name, preset);

    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix or an .exr path",
                                 &camera, &W, &H, &size_given};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        int r;
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
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
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
            i++;
        } else {
            r = apply_param_flag(m, params, given, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            return cli_usage_error("ao: unknown option '%s' (input is --scene or --gbuffer)", a);
        }
    }
    if (!scene_path == !gbuffer_path)
        return cli_usage_error("ao: give exactly one of --scene and --gbuffer");
    if (gbuffer_path && (size_given || guard || infinite_far || camera[0]))
        return cli_usage_error("ao: --camera, --size, --guard and --infinite-far apply to --scene only");
    if (scene_path && (xo.depth_channel || xo.depth_kind != AO_DEPTH_KIND_AUTO || intrinsics_path))
        return cli_usage_error("ao: --depth-channel, --depth-kind and --intrinsics apply to --gbuffer only");
    if (m->params_adjust)
        m->params_adjust(params, given);

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
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

    obs_status st = m->params_validate(ctx, params);
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
        st = cli_scene_and_camera(ctx, scene_path, camera, &scene, &cam);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        if (infinite_far && cam.projection == OBS_PROJECTION_PERSPECTIVE)
            cam.zfar = INFINITY;
        if ((code = cli_size_from_camera(&cam, size_given, &W, &H)) != CLI_EXIT_OK)
            goto done;
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

    /* ---- AO ---- */
    st = obs_image_f32_alloc(ctx, in.w, in.h, &ao);
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, in.w, in.h, &ao_raw);
    ao_stats stats;
    memset(&stats, 0, sizeof stats);
    t_ao0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = m->compute(ctx, pool, &in, params, &ao, &ao_raw, &stats);
    t_ao1 = obs_time_now();
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    char params_text[1024];
    m->params_to_string(params, params_text, sizeof params_text);
    if (!g->quiet)
        fprintf(stderr, "obscura: ao %s: %dx%d (buffer %dx%d), %s: %.2f ms (%d threads)\n", m->name, in.w, in.h, in.width,
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
    if (st == OBS_STATUS_OK)
        st = ao_blend_lambert(ctx, pool, &in, &ao, bn, &blend);
    if (st == OBS_STATUS_OK)
        for (int y = 0; y < in.h; y++)
            for (int x = 0; x < in.w; x++) {
                const float d = obs_image_f32_row(in.depth, in.y0 + y)[in.x0 + x];
                obs_image_f32_row(&preview, y)[x] = d > 0.0f && d < INFINITY ? obs_image_f32_row(&ao, y)[x] : 0.0f;
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
    strcpy(at[na].name, "obscura:method"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)m->name; na++;
    strcpy(at[na].name, "obscura:params"); at[na].type = IO_ATTR_STRING; at[na].s = params_text; na++;
    strcpy(at[na].name, "obscura:pixel_model_fx_fy_cx_cy"); at[na].type = IO_ATTR_FLOATS; at[na].v = fxyc; at[na].n = 4; na++;
    strcpy(at[na].name, "obscura:projection_type"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(in.projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic"); na++;
    strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
    strcpy(at[na].name, "obscura:input"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(scene_path ? scene_path : gbuffer_path); na++;
    strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)"AO = visibility (1 = unoccluded), after the blur; AO.raw = before the blur; row 0 at top; "
                       "Z = linear depth, inf = background; the technique's sample pattern as its page says "
                       "(docs/ao/)";
    na++;
    char path[4200];
    st = cli_make_parent_dirs(ctx, prefix);
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
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
    io_json_string(&j, "method", m->name);
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
        io_json_int(&j, "renormalized_normal_pixels", ext.renormalized_normal_pixels);
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
    io_json_string(&j, "preset", preset ? preset : "default");
    for (int i = 0; i < m->param_count; i++) {
        const ao_param_desc *d = &m->params[i];
        const char *field = (const char *)params + d->offset;
        int iv;
        float fv;
        char val[64];
        if (d->type == AO_PARAM_FLOAT) {
            memcpy(&fv, field, sizeof fv);
            io_json_number(&j, d->name, fv);
        } else if (d->type == AO_PARAM_INT) {
            memcpy(&iv, field, sizeof iv);
            io_json_int(&j, d->name, iv);
        } else if (d->type == AO_PARAM_BOOL) {
            memcpy(&iv, field, sizeof iv);
            io_json_bool(&j, d->name, iv);
        } else {
            format_param_value(d, params, val, sizeof val);
            io_json_string(&j, d->name, val);
        }
    }
    io_json_string(&j, "resolved", params_text);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    io_json_string(&j, "matched_ground_truth_estimator", m->truth_estimator(params));
    io_json_number(&j, "matched_ground_truth_radius", m->get_radius(params));
    if (m->constants_to_json) {
        int need = m->constants_to_json(params, &in, NULL, 0);
        char *ktext = need > 0 ? malloc((size_t)need + 1) : NULL;
        if (ktext) {
            m->constants_to_json(params, &in, ktext, (size_t)need + 1);
            io_json_raw(&j, "constants", ktext);
            free(ktext);
        }
    }
    io_json_begin_object(&j, "stats");
    io_json_int(&j, "pixels_computed", stats.pixels_computed);
    io_json_int(&j, "pixels_background", stats.pixels_background);
    io_json_int(&j, "surface_pixels_in_window", nsurf);
    io_json_number(&j, "mean_visibility_surface", nsurf ? sum / (double)nsurf : 1.0);
    io_json_number(&j, "seconds_input", t_in1 - t_in0);
    io_json_number(&j, "seconds_prepare", stats.seconds_prepare);
    io_json_number(&j, "seconds_kernel", stats.seconds_kernel);
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
    code = cli_write_sidecar(ctx, &j, prefix);
    if (code != CLI_EXIT_OK)
        goto done;
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s%s, %s.png, %s_blend.png, %s.json\n", prefix, exr_ext, prefix, prefix, prefix);
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
