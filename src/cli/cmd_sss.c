/* cmd_sss.c: `obscura sss SCENE`: subsurface scattering with Dal Corso et al.'s scattering maps
 * (docs/sss.md): the image from the scene's camera (EXR + PNG), the K maps as a layered EXR, and
 * a JSON sidecar. Only parses flags and calls the sss_ passes. */
#include "cli_sss.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *sss_help_head = "usage: obscura sss SCENE [options] -o PREFIX\n";
static const char *sss_help =
    "model and maps (defaults: the seed thesis' final code, docs/sss.md):\n"
    "  --model NAME          directional (default, Frisvad 2014) or standard (Jensen 2001)\n"
    "  --K K                 scattering-map directions (Halton points on the sphere; default 16)\n"
    "  --N N                 samples per texel (default 48)\n"
    "  --M M                 candidates of the nearest-N-of-M sampler (default 1000)\n"
    "  --sampler NAME        exponential (default), rr (the thesis shader's Russian roulette) or\n"
    "                        nearest (the thesis text's N nearest of M; biased): docs/sss/maps.md\n"
    "  --map-size S          scattering-map side (default 512)\n"
    "  --light-map-size S    light G-buffer side (default 512)\n"
    "  --frames F            progressive frames accumulated (default 1)\n"
    "  --q Q                 spread: sigma* = min sigma_tr / q (default 1)\n"
    "  --disk-radius R       gather disk radius, scene units (default 0: half the scene's diagonal)\n"
    "  --visibility NAME     product5 (default: the thesis' 5-tap product) or pcf3x3\n"
    "  --shadow-bias B       visibility bias, share of a map's depth range (default 0.001)\n"
    "  --gamma G             output L^(1/G) (default 1: linear)\n"
    "  --specular            add a Blinn-Phong highlight (exponent --specular-exponent, default 64)\n"
    "  --seed S              random seed (default 0)\n"
    "view and output:\n"
    "  --camera NAME|INDEX   camera (default: 'default', else the first, else a framing one)\n"
    "  --size WxH            image size (default 1920x1080, or 1920 wide at the camera's aspect)\n"
    "  --exposure E          PNG only: multiply by E before the sRGB encoding (default 1)\n"
    "  --no-maps             do not write PREFIX_maps.exr\n"
    "  -o, --output PREFIX   PREFIX.exr (R, G, B radiance; visible = maps that saw the pixel; Z),\n"
    "                        PREFIX.png (sRGB), PREFIX_maps.exr (layer kNN: R, G, B, Z), PREFIX.json\n"
    "                        (default prefix: sss); -o out.exr names the EXR itself\n";

static void print_help(FILE *f)
{
    fputs(sss_help_head, f);
    fputs(cli_sss_help_material_light, f);
    fputs(sss_help, f);
}

static int parse_choice(const char *v, int (*fn)(const char *, int *), int *out)
{
    return v && fn(v, out);
}
static int model_from(const char *v, int *o) { sss_model m; int r = sss_model_from_name(v, &m); *o = (int)m; return r; }
static int sampler_from(const char *v, int *o)
{
    if (!strcmp(v, "rr")) { *o = SSS_SAMPLER_RUSSIAN_ROULETTE; return 1; }
    if (!strcmp(v, "nearest")) { *o = SSS_SAMPLER_NEAREST_N_OF_M; return 1; }
    sss_sampler s;
    int r = sss_sampler_from_name(v, &s);
    *o = (int)s;
    return r;
}
static int visibility_from(const char *v, int *o) { sss_visibility s; int r = sss_visibility_from_name(v, &s); *o = (int)s; return r; }

int cmd_sss(cli_globals *g, int argc, char **argv)
{
    const char *scene_path = NULL, *prefix = "sss", *camera = "";
    char prefix_buf[4000], exr_ext[5] = ".exr";
    int W = 1920, H = 1080, size_given = 0, write_maps = 1;
    double exposure = 1.0;
    cli_sss_options so;
    cli_sss_options_init(&so);
    sss_params p = sss_params_default();

    if (argc < 2) {
        print_help(stderr);
        return CLI_EXIT_USAGE;
    }
    const cli_view_flags view_flags = {&prefix, prefix_buf, sizeof prefix_buf, exr_ext, "a path prefix or an .exr path",
                                 &camera, &W, &H, &size_given};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        double x;
        int c, r;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            print_help(stdout);
            return CLI_EXIT_OK;
        } else if ((r = cli_view_flag(&view_flags, argc, argv, &i)) != 0) {
            if (r < 0) return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--model")) {
            if (!parse_choice(v, model_from, &c)) return cli_usage_error("--model needs directional or standard");
            p.model = (sss_model)c; i++;
        } else if (!strcmp(a, "--sampler")) {
            if (!parse_choice(v, sampler_from, &c)) return cli_usage_error("--sampler needs exponential, rr (russian-roulette) or nearest (nearest-n-of-m)");
            p.sampler = (sss_sampler)c; i++;
        } else if (!strcmp(a, "--visibility")) {
            if (!parse_choice(v, visibility_from, &c)) return cli_usage_error("--visibility needs product5 or pcf3x3");
            p.visibility = (sss_visibility)c; i++;
        } else if (!strcmp(a, "--K") || !strcmp(a, "--N") || !strcmp(a, "--M") || !strcmp(a, "--map-size") ||
                   !strcmp(a, "--light-map-size") || !strcmp(a, "--frames")) {
            if (!cli_parse_int(v, 1, 1 << 20, &ll)) return cli_usage_error("%s needs a positive integer", a);
            int iv = (int)ll;
            if (!strcmp(a, "--K")) p.K = iv;
            else if (!strcmp(a, "--N")) p.N = iv;
            else if (!strcmp(a, "--M")) p.M = iv;
            else if (!strcmp(a, "--map-size")) p.map_size = iv;
            else if (!strcmp(a, "--light-map-size")) p.light_map_size = iv;
            else p.frames = iv;
            i++;
        } else if (!strcmp(a, "--seed")) {
            if (!cli_parse_int(v, 0, 0x7fffffffffffffffLL, &ll)) return cli_usage_error("--seed needs an integer >= 0");
            p.seed = (uint64_t)ll; i++;
        } else if (!strcmp(a, "--q") || !strcmp(a, "--disk-radius") || !strcmp(a, "--shadow-bias") ||
                   !strcmp(a, "--gamma") || !strcmp(a, "--specular-exponent") || !strcmp(a, "--exposure")) {
            if (!cli_parse_float(v, &x) || !isfinite(x)) return cli_usage_error("%s needs a number", a);
            if (!strcmp(a, "--q")) p.spread_q = x;
            else if (!strcmp(a, "--disk-radius")) p.disk_radius = x;
            else if (!strcmp(a, "--shadow-bias")) p.shadow_bias = x;
            else if (!strcmp(a, "--gamma")) p.gamma = x;
            else if (!strcmp(a, "--specular-exponent")) p.specular_exponent = x;
            else exposure = x;
            i++;
        } else if (!strcmp(a, "--specular")) {
            p.specular = 1;
        } else if (!strcmp(a, "--no-maps")) {
            write_maps = 0;
        } else if (a[0] == '-' && a[1]) {
            r = cli_sss_flag(&so, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) return CLI_EXIT_USAGE;
            if (r > 0) continue;
            return cli_usage_error("sss: unknown option '%s' (see 'obscura sss --help')", a);
        } else {
            if (scene_path) return cli_usage_error("sss: one scene only ('%s' and '%s')", scene_path, a);
            scene_path = a;
        }
    }
    if (!scene_path)
        return cli_usage_error("sss: no scene given");
    if (cli_sss_options_check(&so, "sss"))
        return CLI_EXIT_USAGE;
    if (!(exposure >= 0))
        return cli_usage_error("--exposure needs a number >= 0");

    obs_context *ctx = cli_context(g);
    if (!ctx)
        return CLI_EXIT_INTERNAL;
    obs_scene scene;
    obs_scene_init(&scene);
    obs_pool *pool = NULL;
    rast_gbuffer gb;
    memset(&gb, 0, sizeof gb);
    sss_scene_setup setup;
    memset(&setup, 0, sizeof setup);
    sss_light_map *lmaps = NULL;
    int light_count = 0;
    sss_maps maps;
    memset(&maps, 0, sizeof maps);
    obs_image_f32 rgb[3] = {{0}}, vis = {0}, png[3] = {{0}};
    io_channel *mch = NULL;
    char (*mnames)[32] = NULL;
    io_json j;
    io_json_init(&j);
    int code = CLI_EXIT_OK;
    obs_camera cam;
    memset(&cam, 0, sizeof cam);
    double t0, t_lm = 0, t_maps = 0, t_gb = 0, t_comb = 0;

    obs_status st = sss_params_validate(ctx, &p);
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

    /* ---- Scene, camera, materials, lights ---- */
    st = cli_scene_and_camera(ctx, scene_path, camera, &scene, &cam);
    if (st == OBS_STATUS_OK)
        st = cli_sss_prepare(ctx, &so, scene_path, &scene, &cam, &setup);
    if (st != OBS_STATUS_OK) {
        code = cli_sss_exit_for(ctx, st);
        goto done;
    }
    if ((code = cli_size_from_camera(&cam, size_given, &W, &H)) != CLI_EXIT_OK)
        goto done;
    const obs_light *lights = scene.lights;
    light_count = (int)scene.light_count;

    /* ---- Pass 1: light G-buffers ---- */
    lmaps = (sss_light_map *)calloc((size_t)light_count, sizeof *lmaps);
    if (!lmaps) {
        code = CLI_EXIT_INTERNAL;
        goto done;
    }
    t0 = obs_time_now();
    for (int l = 0; l < light_count && st == OBS_STATUS_OK; l++)
        st = sss_light_map_render(ctx, pool, &scene, &lights[l], &p, &lmaps[l]);
    t_lm = obs_time_now() - t0;
    /* ---- Pass 2: the scattering maps (independent of the camera) ---- */
    t0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = sss_maps_build(ctx, pool, &scene, &setup.mats, lmaps, light_count, &p, &maps);
    t_maps = obs_time_now() - t0;
    /* ---- The camera's G-buffer, pass 3: combination ---- */
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_MATERIAL_ID | RAST_OUT_INSTANCE_ID;
    rp.face_forward = 0;
    t0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = rast_gbuffer_alloc(ctx, &rp, &gb);
    rast_view view = {cam};
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &scene, &view, 1, &rp, &gb, NULL);
    t_gb = obs_time_now() - t0;
    t0 = obs_time_now();
    if (st == OBS_STATUS_OK)
        st = sss_combine(ctx, pool, &scene, &setup.mats, &maps, lmaps, light_count, &gb, &cam, &p, rgb, &vis);
    t_comb = obs_time_now() - t0;
    if (st != OBS_STATUS_OK) {
        code = cli_fail(ctx, st);
        goto done;
    }
    if (!g->quiet)
        fprintf(stderr,
                "obscura: sss %s, %s, K=%d N=%d maps %d^2, light maps %d^2: light G-buffers %.1f ms, maps %.1f ms, "
                "camera G-buffer %.1f ms, combination %.1f ms (%d threads)\n",
                sss_model_name(p.model), sss_sampler_name(p.sampler), p.K, p.N, p.map_size, p.light_map_size,
                1e3 * t_lm, 1e3 * t_maps, 1e3 * t_gb, 1e3 * t_comb, obs_pool_threads(pool));

    /* ---- Files: the image ---- */
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
        st = obs_image_f32_alloc(ctx, W, H, &png[c]);
    if (st == OBS_STATUS_OK)
        for (int c = 0; c < 3; c++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++)
                    obs_image_f32_row(&png[c], y)[x] = (float)(exposure * obs_image_f32_row(&rgb[c], y)[x]);
    io_channel ch[5] = {
        {"R", IO_PIXEL_FLOAT, &rgb[0], NULL}, {"G", IO_PIXEL_FLOAT, &rgb[1], NULL}, {"B", IO_PIXEL_FLOAT, &rgb[2], NULL},
        {"visible", IO_PIXEL_FLOAT, &vis, NULL}, {"Z", IO_PIXEL_FLOAT, &gb.depth, NULL},
    };
    char params_text[512];
    snprintf(params_text, sizeof params_text,
             "model=%s K=%d N=%d M=%d sampler=%s map_size=%d light_map_size=%d frames=%d q=%g disk_radius=%g "
             "visibility=%s shadow_bias=%g shrink_eps=%g gamma=%g specular=%d seed=%llu mm_per_unit=%g",
             sss_model_name(p.model), p.K, p.N, p.M, sss_sampler_name(p.sampler), p.map_size, p.light_map_size,
             p.frames, p.spread_q, p.disk_radius, sss_visibility_name(p.visibility), p.shadow_bias, p.shrink_eps,
             p.gamma, p.specular, (unsigned long long)p.seed, so.mm_per_unit);
    io_attr at[4];
    memset(at, 0, sizeof at);
    int na = 0;
    strcpy(at[na].name, "obscura:params"); at[na].type = IO_ATTR_STRING; at[na].s = params_text; na++;
    strcpy(at[na].name, "obscura:version"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)OBS_VERSION_STRING; na++;
    strcpy(at[na].name, "obscura:input"); at[na].type = IO_ATTR_STRING; at[na].s = (char *)scene_path; na++;
    strcpy(at[na].name, "obscura:conventions"); at[na].type = IO_ATTR_STRING;
    at[na].s = (char *)"R, G, B = outgoing radiance towards the camera in the light's units (L^(1/gamma)); "
                       "0 on opaque surfaces and background; visible = scattering maps that saw the pixel; "
                       "Z = linear depth, inf = background; row 0 at top";
    na++;
    char path[4200];
    if (st == OBS_STATUS_OK)
        st = cli_make_parent_dirs(ctx, prefix);
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s%s", prefix, exr_ext);
        st = io_exr_write(ctx, path, ch, 5, at, na);
    }
    if (st == OBS_STATUS_OK) {
        snprintf(path, sizeof path, "%s.png", prefix);
        st = io_png_write(ctx, path, png, 3, IO_PNG_SRGB);
    }
    /* ---- Files: the maps, one EXR layer per direction ---- */
    if (st == OBS_STATUS_OK && write_maps) {
        const int nch = 4 * maps.K;
        mch = (io_channel *)calloc((size_t)nch, sizeof *mch);
        mnames = (char (*)[32])calloc((size_t)nch, 32);
        if (!mch || !mnames) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory for the maps' channel list");
        } else {
            static const char *cn[4] = {"R", "G", "B", "Z"};
            for (int k = 0; k < maps.K; k++)
                for (int c = 0; c < 4; c++) {
                    snprintf(mnames[4 * k + c], 32, "k%02d.%s", k, cn[c]);
                    mch[4 * k + c].name = mnames[4 * k + c];
                    mch[4 * k + c].type = IO_PIXEL_FLOAT;
                    mch[4 * k + c].f32 = c < 3 ? &maps.radiance[3 * k + c] : &maps.views[k].depth;
                }
            io_attr mat_at[2];
            memset(mat_at, 0, sizeof mat_at);
            float *dirs = (float *)malloc(sizeof(float) * 3 * (size_t)maps.K);
            if (!dirs) {
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory");
            } else {
                for (int k = 0; k < 3 * maps.K; k++)
                    dirs[k] = (float)maps.dirs[k];
                strcpy(mat_at[0].name, "obscura:directions"); mat_at[0].type = IO_ATTR_FLOATS;
                mat_at[0].v = dirs; mat_at[0].n = 3 * maps.K;
                strcpy(mat_at[1].name, "obscura:params"); mat_at[1].type = IO_ATTR_STRING; mat_at[1].s = params_text;
                snprintf(path, sizeof path, "%s_maps.exr", prefix);
                st = io_exr_write(ctx, path, mch, nch, mat_at, 2);
                free(dirs);
            }
        }
    }
    if (st != OBS_STATUS_OK) {
        code = st == OBS_STATUS_IO_ERROR ? (fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx)), CLI_EXIT_OUTPUT)
                                         : cli_fail(ctx, st);
        goto done;
    }

    /* ---- JSON sidecar ---- */
    io_json_begin_object(&j, NULL);
    cli_json_header(&j, "sss", argc, argv);
    io_json_string(&j, "scene", scene_path);
    io_json_string(&j, "camera", cam.name);
    io_json_int(&j, "width", W);
    io_json_int(&j, "height", H);
    cli_sss_json_setup(&j, &so, &setup, &scene);
    io_json_string(&j, "params", params_text);
    io_json_begin_object(&j, "stats");
    io_json_number(&j, "seconds_light_gbuffers", t_lm);
    io_json_number(&j, "seconds_maps", t_maps);
    io_json_number(&j, "seconds_camera_gbuffer", t_gb);
    io_json_number(&j, "seconds_combination", t_comb);
    io_json_int(&j, "threads", obs_pool_threads(pool));
    io_json_int(&j, "bssrdf_evaluations", (int64_t)maps.samples_evaluated);
    io_json_int(&j, "disk_candidates", (int64_t)maps.candidates);
    io_json_end_object(&j);
    io_json_string(&j, "png", "R, G, B times --exposure, sRGB-encoded, clamped to [0, 1]");
    io_json_end_object(&j);
    code = cli_write_sidecar(ctx, &j, prefix);
    if (code != CLI_EXIT_OK)
        goto done;
    if (!g->quiet)
        fprintf(stderr, "obscura: wrote %s%s, %s.png, %s%s%s.json\n", prefix, exr_ext, prefix,
                write_maps ? prefix : "", write_maps ? "_maps.exr, " : "", prefix);
done:
    io_json_free(&j);
    free(mch);
    free(mnames);
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&rgb[c]);
        obs_image_f32_free(&png[c]);
    }
    obs_image_f32_free(&vis);
    sss_maps_free(&maps);
    for (int l = 0; lmaps && l < light_count; l++)
        sss_light_map_free(&lmaps[l]);
    free(lmaps);
    sss_scene_setup_free(&setup);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&scene);
    obs_context_destroy(ctx);
    return code;
}
