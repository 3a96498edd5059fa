/* cmd_gbuffer.c: `obscura gbuffer SCENE`: render the G-buffer, write EXR + PNG + JSON. */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const char *gbuffer_help =
    "usage: obscura gbuffer SCENE [options]\n"
    "  -o, --output PREFIX   write PREFIX.exr, PREFIX_normal.png, PREFIX_depth.png, PREFIX.json\n"
    "                        (default: gbuffer); -o out.exr names the EXR itself and the rest go\n"
    "                        beside it (out_normal.png, ...); missing directories are created\n"
    "  --camera NAME|INDEX   camera to use (default: 'default', else the first, else a framing one)\n"
    "  --size WxH            inner image size (default 1920x1080, or 1920 wide at the camera's aspect)\n"
    "  --guard G             guard band in pixels around the image (default 0)\n"
    "  --keep-guard          write the full (W+2G)x(H+2G) buffers instead of the inner window\n"
    "  --depth CONV          NDC depth convention: gl (default), zero-to-one, reversed-z\n"
    "  --infinite-far        use an infinite far plane (perspective cameras)\n"
    "  --cull MODE           none (default), back, front\n"
    "  --isa ISA             auto (default), scalar, avx2\n"
    "  --outputs LIST        comma list of depth,ndc,normal,face,prim,inst,mat or all (default all)\n"
    "EXR channels: Z (linear depth, inf = background), Zndc, N.X N.Y N.Z (shading normal, view space),\n"
    "Ng.X Ng.Y Ng.Z (face normal), primid, instid, matid (uint, 4294967295 = none).\n";


static int parse_outputs(const char *s, uint32_t *out)
{
    static const struct { const char *name; uint32_t bit; } names[] = {
        {"depth", RAST_OUT_DEPTH}, {"ndc", RAST_OUT_NDC_DEPTH}, {"normal", RAST_OUT_NORMAL},
        {"face", RAST_OUT_FACE_NORMAL}, {"prim", RAST_OUT_PRIM_ID}, {"inst", RAST_OUT_INSTANCE_ID},
        {"mat", RAST_OUT_MATERIAL_ID}, {"all", RAST_OUT_ALL}};
    uint32_t bits = 0;
    char buf[256];
    if (strlen(s) >= sizeof buf)
        return 0;
    strcpy(buf, s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int found = 0;
        for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
            if (!strcmp(tok, names[k].name)) {
                bits |= names[k].bit;
                found = 1;
            }
        if (!found)
            return 0;
    }
    if (!bits)
        return 0;
    *out = bits;
    return 1;
}

static void json_mat(io_json *j, const char *key, const obs_mat4 *m) { io_json_floats(j, key, m->m, 16); }


int cmd_gbuffer(cli_globals *g, int argc, char **argv)
{
    const char *scene_path = NULL, *prefix = "gbuffer", *camera = "";
    char prefix_buf[4000], exr_ext[5] = ".exr";
    rast_params p = rast_params_default();
    int size_given = 0, keep_guard = 0, infinite_far = 0;
    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix or an .exr path",
                                 &camera, &p.width, &p.height, &size_given};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        int r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(gbuffer_help, stdout);
            return CLI_EXIT_OK;
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--guard")) {
            long long x;
            if (!cli_parse_int(v, 0, RAST_MAX_DIM / 2, &x)) return cli_usage_error("--guard needs an integer >= 0");
            p.guard = (int)x; i++;
        } else if (!strcmp(a, "--keep-guard")) {
            keep_guard = 1;
        } else if (!strcmp(a, "--infinite-far")) {
            infinite_far = 1;
        } else if (!strcmp(a, "--depth")) {
            if (v && !strcmp(v, "gl")) p.depth_convention = RAST_DEPTH_GL_STANDARD;
            else if (v && !strcmp(v, "zero-to-one")) p.depth_convention = RAST_DEPTH_ZERO_TO_ONE;
            else if (v && !strcmp(v, "reversed-z")) p.depth_convention = RAST_DEPTH_REVERSED_Z;
            else return cli_usage_error("--depth needs gl, zero-to-one or reversed-z");
            i++;
        } else if (!strcmp(a, "--cull")) {
            if (v && !strcmp(v, "none")) p.cull = RAST_CULL_NONE;
            else if (v && !strcmp(v, "back")) p.cull = RAST_CULL_BACK;
            else if (v && !strcmp(v, "front")) p.cull = RAST_CULL_FRONT;
            else return cli_usage_error("--cull needs none, back or front");
            i++;
        } else if (!strcmp(a, "--isa")) {
            if (v && !strcmp(v, "auto")) p.isa = RAST_ISA_AUTO;
            else if (v && !strcmp(v, "scalar")) p.isa = RAST_ISA_SCALAR;
            else if (v && !strcmp(v, "avx2")) p.isa = RAST_ISA_AVX2;
            else return cli_usage_error("--isa needs auto, scalar or avx2");
            i++;
        } else if (!strcmp(a, "--outputs")) {
            if (!v || !parse_outputs(v, &p.outputs))
                return cli_usage_error("--outputs needs a comma list of depth,ndc,normal,face,prim,inst,mat,all");
            i++;
        } else {
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            if (a[0] == '-') return cli_usage_error("gbuffer: unknown option '%s'", a);
            if (scene_path) return cli_usage_error("gbuffer: more than one scene given ('%s')", a);
            scene_path = a;
        }
    }
    if (!scene_path)
        return cli_usage_error("gbuffer: no scene given");

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_scene scene;
    obs_scene_init(&scene);
    obs_pool *pool = NULL;
    rast_gbuffer gb;
    memset(&gb, 0, sizeof gb);
    io_json j;
    io_json_init(&j);
    int code = CLI_EXIT_OK;
    obs_camera cam;
    obs_status st = cli_scene_and_camera(ctx, scene_path, camera, &scene, &cam);
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    if (infinite_far && cam.projection == OBS_PROJECTION_PERSPECTIVE)
        cam.zfar = INFINITY;
    if ((code = cli_size_from_camera(&cam, size_given, &p.width, &p.height)) != CLI_EXIT_OK)
        goto done;
    pool = obs_pool_create(g->threads);
    if (!pool) {
        fprintf(stderr, "obscura: error: cannot start %d threads\n", g->threads);
        code = CLI_EXIT_INTERNAL;
        goto done;
    }
    st = rast_gbuffer_alloc(ctx, &p, &gb);
    rast_stats stats;
    rast_view view = {cam};
    double t0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &scene, &view, 1, &p, &gb, &stats);
    double t1 = obs_time_now();
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    if (!g->quiet)
        fprintf(stderr, "obscura: %s: %dx%d, %llu triangles, %llu pixels covered, %.2f ms (%s, %d threads)\n",
                scene_path, p.width, p.height, (unsigned long long)stats.triangles_in,
                (unsigned long long)stats.pixels_covered, 1e3 * (t1 - t0), rast_isa_name(stats.isa_used),
                obs_pool_threads(pool));

    /* The window to write: inner by default. */
    int x0 = keep_guard ? 0 : p.guard, y0 = keep_guard ? 0 : p.guard;
    int w = keep_guard ? gb.width : p.width, h = keep_guard ? gb.height : p.height;
    obs_image_f32 depth = obs_image_f32_window(&gb.depth, x0, y0, w, h);
    obs_image_f32 ndc = obs_image_f32_window(&gb.ndc_depth, x0, y0, w, h);
    obs_image_f32 n[3], ng[3];
    for (int c = 0; c < 3; c++) {
        n[c] = obs_image_f32_window(&gb.normal[c], x0, y0, w, h);
        ng[c] = obs_image_f32_window(&gb.face_normal[c], x0, y0, w, h);
    }
    obs_image_u32 prim = obs_image_u32_window(&gb.prim_id, x0, y0, w, h);
    obs_image_u32 inst = obs_image_u32_window(&gb.instance_id, x0, y0, w, h);
    obs_image_u32 mat = obs_image_u32_window(&gb.material_id, x0, y0, w, h);
    io_channel ch[11];
    int nch = 0;
#define ADD_F(cond, nm, plane) if (cond) { ch[nch].name = nm; ch[nch].type = IO_PIXEL_FLOAT; ch[nch].f32 = &(plane); ch[nch].u32 = NULL; nch++; }
#define ADD_U(cond, nm, plane) if (cond) { ch[nch].name = nm; ch[nch].type = IO_PIXEL_UINT; ch[nch].u32 = &(plane); ch[nch].f32 = NULL; nch++; }
    ADD_F(p.outputs & RAST_OUT_DEPTH, "Z", depth);
    ADD_F(p.outputs & RAST_OUT_NDC_DEPTH, "Zndc", ndc);
    ADD_F(p.outputs & RAST_OUT_NORMAL, "N.X", n[0]);
    ADD_F(p.outputs & RAST_OUT_NORMAL, "N.Y", n[1]);
    ADD_F(p.outputs & RAST_OUT_NORMAL, "N.Z", n[2]);
    ADD_F(p.outputs & RAST_OUT_FACE_NORMAL, "Ng.X", ng[0]);
    ADD_F(p.outputs & RAST_OUT_FACE_NORMAL, "Ng.Y", ng[1]);
    ADD_F(p.outputs & RAST_OUT_FACE_NORMAL, "Ng.Z", ng[2]);
    ADD_U(p.outputs & RAST_OUT_PRIM_ID, "primid", prim);
    ADD_U(p.outputs & RAST_OUT_INSTANCE_ID, "instid", inst);
    ADD_U(p.outputs & RAST_OUT_MATERIAL_ID, "matid", mat);
#undef ADD_F
#undef ADD_U

    /* Metadata: EXR's standard worldToCamera / worldToNDC (Imath row-vector convention, which is
     * our column-major array read row-major), plus obscura's own. */
    const rast_view_constants *vc = &gb.constants;
    obs_mat4 proj_written = vc->projection;
    if (!keep_guard)
        proj_written = vc->projection_inner;
    obs_mat4 world_to_ndc = obs_mat4_mul(proj_written, vc->view);
    float fxyc[4] = {(float)vc->fx, (float)vc->fy, (float)(vc->cx - x0), (float)(vc->cy - y0)};
    float window[4] = {(float)(vc->inner_x0 - x0), (float)(vc->inner_y0 - y0), (float)p.width, (float)p.height};
    io_attr at[12];
    memset(at, 0, sizeof at);
    int na = 0;
    strcpy(at[na].name, "worldToCamera"); at[na].type = IO_ATTR_MATRIX44; at[na].v = (float *)cam.view.m; na++;
    strcpy(at[na].name, "worldToNDC"); at[na].type = IO_ATTR_MATRIX44; at[na].v = world_to_ndc.m; na++;
    strcpy(at[na].name, "obscura:projection"); at[na].type = IO_ATTR_MATRIX44; at[na].v = proj_written.m; na++;
    strcpy(at[na].name, "obscura:znear"); at[na].type = IO_ATTR_FLOAT; at[na].f = cam.znear; na++;
    strcpy(at[na].name, "obscura:zfar"); at[na].type = IO_ATTR_FLOAT; at[na].f = cam.zfar; na++;
    strcpy(at[na].name, "obscura:depth_convention"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)rast_depth_convention_name(p.depth_convention); na++;
    strcpy(at[na].name, "obscura:projection_type"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)(cam.projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic"); na++;
    strcpy(at[na].name, "obscura:pixel_model_fx_fy_cx_cy"); at[na].type = IO_ATTR_FLOATS; at[na].v = fxyc; at[na].n = 4; na++;
    strcpy(at[na].name, "obscura:inner_window_x_y_w_h"); at[na].type = IO_ATTR_FLOATS; at[na].v = window; at[na].n = 4; na++;
    strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
    strcpy(at[na].name, "obscura:scene"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)scene_path; na++;
    strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)"view space right-handed, -Z forward, +Y up, metres; row 0 at top; pixel centres at +0.5; "
                       "Z = linear depth, inf = background; ids 4294967295 = none";
    na++;

    char path[4200];
    st = cli_make_parent_dirs(ctx, prefix);
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
        st = io_exr_write(ctx, path, ch, nch, at, na);
    }
    /* PNG previews: normals as 0.5 n + 0.5, depth as a near-white / far-black ramp (both written
     * as data, IO_PNG_LINEAR). */
    if (st == OBS_STATUS_OK && (p.outputs & RAST_OUT_NORMAL)) {
        obs_image_f32 rgb[3] = {{0}};
        for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
            st = obs_image_f32_alloc(ctx, w, h, &rgb[c]);
            for (int y = 0; st == OBS_STATUS_OK && y < h; y++)
                for (int x = 0; x < w; x++) {
                    /* background is the zero normal: all three components, not this one */
                    int bg = obs_image_f32_row(&n[0], y)[x] == 0.0f && obs_image_f32_row(&n[1], y)[x] == 0.0f &&
                             obs_image_f32_row(&n[2], y)[x] == 0.0f;
                    float v = obs_image_f32_row(&n[c], y)[x];
                    obs_image_f32_row(&rgb[c], y)[x] = bg ? 0.0f : 0.5f * v + 0.5f;
                }
        }
        if (st == OBS_STATUS_OK) {
            snprintf(path, sizeof path, "%s_normal.png", prefix);
            st = io_png_write(ctx, path, rgb, 3, IO_PNG_LINEAR);
        }
        for (int c = 0; c < 3; c++)
            obs_image_f32_free(&rgb[c]);
    }
    if (st == OBS_STATUS_OK && (p.outputs & RAST_OUT_DEPTH)) {
        float lo = INFINITY, hi = 0.0f;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                float d = obs_image_f32_row(&depth, y)[x];
                if (isfinite(d)) {
                    lo = d < lo ? d : lo;
                    hi = d > hi ? d : hi;
                }
            }
        obs_image_f32 grey = {0};
        st = obs_image_f32_alloc(ctx, w, h, &grey);
        for (int y = 0; st == OBS_STATUS_OK && y < h; y++)
            for (int x = 0; x < w; x++) {
                float d = obs_image_f32_row(&depth, y)[x];
                obs_image_f32_row(&grey, y)[x] = isfinite(d) ? (hi > lo ? 1.0f - 0.8f * (d - lo) / (hi - lo) : 1.0f) : 0.0f;
            }
        if (st == OBS_STATUS_OK) {
            snprintf(path, sizeof path, "%s_depth.png", prefix);
            st = io_png_write(ctx, path, &grey, 1, IO_PNG_LINEAR);
        }
        obs_image_f32_free(&grey);
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    /* The JSON sidecar: every parameter, the constants, and the counters. */
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, "gbuffer", argc, argv);
    io_json_string(&j, "scene", scene_path);
    cli_json_camera(&j, &cam);
    io_json_begin_object(&j, "params");
    io_json_int(&j, "width", p.width);
    io_json_int(&j, "height", p.height);
    io_json_int(&j, "guard", p.guard);
    io_json_bool(&j, "keep_guard", keep_guard);
    io_json_int(&j, "outputs_mask", p.outputs);
    io_json_string(&j, "depth_convention", rast_depth_convention_name(p.depth_convention));
    io_json_string(&j, "cull", p.cull == RAST_CULL_NONE ? "none" : p.cull == RAST_CULL_BACK ? "back" : "front");
    io_json_bool(&j, "face_forward", p.face_forward);
    io_json_string(&j, "isa_requested", rast_isa_name(p.isa));
    io_json_int(&j, "tile_size", p.tile_size);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_end_object(&j);
    io_json_begin_object(&j, "constants");
    io_json_number(&j, "fx", vc->fx);
    io_json_number(&j, "fy", vc->fy);
    io_json_number(&j, "cx", vc->cx - x0);
    io_json_number(&j, "cy", vc->cy - y0);
    json_mat(&j, "projection_gl_column_major", &proj_written);
    json_mat(&j, "projection_reversed_z_column_major", &vc->projection_reversed);
    io_json_int(&j, "written_width", w);
    io_json_int(&j, "written_height", h);
    io_json_end_object(&j);
    io_json_begin_object(&j, "stats");
    io_json_int(&j, "triangles_in", (int64_t)stats.triangles_in);
    io_json_int(&j, "triangles_nonfinite", (int64_t)stats.triangles_nonfinite);
    io_json_int(&j, "triangles_degenerate", (int64_t)stats.triangles_degenerate);
    io_json_int(&j, "triangles_culled", (int64_t)stats.triangles_culled);
    io_json_int(&j, "triangles_clipped", (int64_t)stats.triangles_clipped);
    io_json_int(&j, "triangles_rasterized", (int64_t)stats.triangles_rasterized);
    io_json_int(&j, "pixels_covered", (int64_t)stats.pixels_covered);
    io_json_string(&j, "isa_used", rast_isa_name(stats.isa_used));
    io_json_number(&j, "seconds_total", t1 - t0);
    io_json_end_object(&j);
    io_json_begin_array(&j, "channels");
    for (int c = 0; c < nch; c++)
        io_json_string(&j, NULL, ch[c].name);
    io_json_end_array(&j);
    io_json_end_object(&j);
    code = cli_write_sidecar(ctx, &j, prefix);
    if (code != CLI_EXIT_OK)
        goto done;
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s%s, %s_normal.png, %s_depth.png, %s.json\n", prefix, exr_ext, prefix, prefix, prefix);
done:
    io_json_free(&j);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
    return code;
}
