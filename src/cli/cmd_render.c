/* cmd_render.c: `obscura render SCENE...`: the scene-driven render (docs/render.md). For every
 * scene and every view it calls for, the pass graph runs what the scene's settings (its glTF
 * extras "obscura_render") and the flags ask for, and writes DIR/<stem>[_<camera>].{exr,png,json}.
 * Only parses flags and calls the render library (render.h): the flags become one
 * "obscura_render" object applied on top of each scene's own, so they are checked by the same
 * code as the scene's keys. */
#include "cli.h"
#include "render/render.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char *render_help =
    "usage: obscura render SCENE... [options]\n"
    "\n"
    "Renders each scene from each of its cameras with only the passes its content and settings call\n"
    "for (G-buffer, shadow maps, AO, SSS maps, light volume, ray casting, composition), reusing the\n"
    "products that do not depend on the view. The settings come from the scene's glTF extras\n"
    "\"obscura_render\" (docs/render.md, \"Scene settings\"); the flags below override them.\n"
    "\n"
    "output:\n"
    "  -o, --output DIR        write DIR/<scene stem>[_<camera>].exr (every layer), .png (the beauty\n"
    "                          image, sRGB) and .json (settings, camera, pass log); the camera suffix\n"
    "                          is added when a scene renders more than one view (default DIR: out)\n"
    "  --outputs A,B,...       layers: beauty, direct, ambient, ao, sss, volume, depth, normal, albedo,\n"
    "                          or all (default); fewer layers cull the passes only they need\n"
    "  --dry-run               print each view's pass graph (and why each pass is there) and write nothing\n"
    "views:\n"
    "  --camera NAME|INDEX     render this camera (repeat for several; default: the scene's \"cameras\",\n"
    "                          else every camera of the scene, else a framing camera)\n"
    "  --size WxH              image size (default: 1920 wide at the camera's aspect)\n"
    "effects:\n"
    "  --ao METHOD|none        the AO technique ('obscura ao --list'; default sao) or none\n"
    "  --ao-preset NAME        start the AO parameters from a preset\n"
    "  --ao-param KEY=VALUE    one AO parameter (repeat), e.g. --ao-param radius=0.5\n"
    "  --ambient V|R,G,B       ambient radiance (default 0.25)\n"
    "  --no-shadows            direct light without shadow maps\n"
    "  --shadow-map-size N     shadow map side (default 2048)\n"
    "  --scale-mm S            SSS: millimetres per scene unit (default 1000)\n"
    "  --no-volume             leave the scene's volume out\n"
    "  --set PATH=VALUE        any key of the scene schema, e.g. --set sss.K=8, --set volume.kappa=2,\n"
    "                          --set volume.box=[[0,0,0],[1,1,1]] (VALUE is JSON; a bare word is a string)\n"
    "  --seed S                every random choice (default 0)\n"
    "  --reference             also render the references (ray-traced AO, the SSS brute force, the\n"
    "                          volume's exact transmittance) and report the per-layer error and time\n"
    "run:\n"
    "  --cache DIR             keep view-independent products (SSS maps, light volumes, shadow maps)\n"
    "                          in DIR as well as in memory, and reuse them across runs\n"
    "  --cache-memory MB       at most MB megabytes of products kept in memory between views (least\n"
    "                          recently used dropped first; default: half the machine's memory)\n"
    "  --threads N             worker threads (default: all CPUs); the output is identical for any N\n"
    "\n"
    "A progress bar over the whole batch is drawn on stderr when it is a terminal. Exit codes as every\n"
    "command: 2 for a bad flag, 3 for a bad scene (including a bad \"obscura_render\" key), 5 when an\n"
    "output cannot be written.\n";

/* ---- The flags as one "obscura_render" object ------------------------------------------------- */

/* The object at a dotted path under root, created as needed (a non-object there is replaced). */
static cJSON *render_obj_at(cJSON *root, const char *path)
{
    cJSON *o = root;
    char part[128];
    const char *p = path;
    while (*p) {
        const char *dot = strchr(p, '.');
        size_t n = dot ? (size_t)(dot - p) : strlen(p);
        if (n == 0 || n >= sizeof part)
            return NULL;
        memcpy(part, p, n);
        part[n] = 0;
        cJSON *c = cJSON_GetObjectItemCaseSensitive(o, part);
        if (!cJSON_IsObject(c)) {
            if (c)
                cJSON_DeleteItemFromObjectCaseSensitive(o, part);
            c = cJSON_AddObjectToObject(o, part);
            if (!c)
                return NULL;
        }
        o = c;
        p = dot ? dot + 1 : p + n;
    }
    return o;
}

/* VALUE as JSON (a number, true/false, an array ...); on/off and yes/no as booleans; anything
 * else as a string. */
static cJSON *render_value(const char *v)
{
    if (!strcmp(v, "on") || !strcmp(v, "yes"))
        return cJSON_CreateTrue();
    if (!strcmp(v, "off") || !strcmp(v, "no"))
        return cJSON_CreateFalse();
    cJSON *j = cJSON_ParseWithOpts(v, NULL, 1);
    return j ? j : cJSON_CreateString(v);
}

/* Set PATH (dotted) to value under root; the last part is the key. Returns 0 on a malformed path. */
static int render_set(cJSON *root, const char *path, cJSON *value)
{
    if (!value)
        return 0;
    const char *last = strrchr(path, '.');
    cJSON *o = root;
    if (last) {
        char parent[256];
        size_t n = (size_t)(last - path);
        if (n >= sizeof parent) {
            cJSON_Delete(value);
            return 0;
        }
        memcpy(parent, path, n);
        parent[n] = 0;
        o = render_obj_at(root, parent);
    }
    const char *key = last ? last + 1 : path;
    if (!o || !key[0]) {
        cJSON_Delete(value);
        return 0;
    }
    cJSON_DeleteItemFromObjectCaseSensitive(o, key);
    cJSON_AddItemToObject(o, key, value);
    return 1;
}

/* ---- Names ------------------------------------------------------------------------------------- */

/* The file name without its directory and its extension. */
static void render_stem(const char *path, char *out, size_t size)
{
    const char *b = strrchr(path, '/');
    b = b ? b + 1 : path;
    const char *dot = strrchr(b, '.');
    size_t n = dot && dot != b ? (size_t)(dot - b) : strlen(b);
    if (n >= size)
        n = size - 1;
    memcpy(out, b, n);
    out[n] = 0;
}

/* A camera name made safe for a file name: letters, digits, '-', '_', '.'; others become '_'. */
static void render_safe_name(const char *name, int index, char *out, size_t size)
{
    size_t n = 0;
    for (const char *p = name; *p && n + 1 < size; p++)
        out[n++] = (isalnum((unsigned char)*p) || *p == '-' || *p == '_' || *p == '.') ? *p : '_';
    out[n] = 0;
    if (n == 0 || out[0] == '.')
        snprintf(out, size, "camera%d", index);
}

/* ---- Progress over the whole batch -------------------------------------------------------------- */

typedef struct render_batch_progress {
    int64_t views_done, views_total;
    int64_t scene_base, scene_views;   /* the views before the current scene, and its own */
    double t0, last;
    int drawn;
} render_batch_progress;

/* The session reports (done, total) over the current scene's views (render.c: pass k of view v of
 * V views with P live passes is v P + k + 1 of V P); this places that share in the batch. */
static void render_progress_draw(void *user, int64_t done, int64_t total)
{
    render_batch_progress *b = (render_batch_progress *)user;
    const double now = obs_time_now();
    double f = total > 0 ? (double)done / (double)total : 0.0;
    f = f < 0.0 ? 0.0 : f > 1.0 ? 1.0 : f;
    double all = b->views_total > 0 ? ((double)b->scene_base + f * (double)b->scene_views) / (double)b->views_total : 1.0;
    all = all > 1.0 ? 1.0 : all;
    if (all < 1.0 && now - b->last < 0.2)
        return;
    b->last = now;
    const int width = 30, fill = (int)(all * width);
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < fill ? '=' : i == fill ? '>' : ' ';
    bar[width] = 0;
    const double el = now - b->t0, eta = all > 0.0 ? el * (1.0 - all) / all : 0.0;
    const int es = (int)(eta + 0.5);
    fprintf(stderr, "\robscura: render [%s] %5.1f%%  view %lld/%lld  ETA %d:%02d:%02d ", bar, 100.0 * all,
            (long long)(b->views_done + (b->views_done < b->views_total)), (long long)b->views_total, es / 3600,
            es / 60 % 60, es % 60);
    fflush(stderr);
    b->drawn = 1;
}

static void render_progress_end(render_batch_progress *b)
{
    if (b->drawn) {
        fputc('\n', stderr);
        b->drawn = 0;
    }
}

/* ---- One scene --------------------------------------------------------------------------------- */

typedef struct render_job {
    const char *path;
    obs_scene scene;
    render_settings st;
    int views;
    char stem[256];
} render_job;

static void render_print_reference(const render_frame *f)
{
    if (!f->has_reference)
        return;
    printf("  reference: approximation %.3f s, reference %.3f s\n", f->seconds_approx, f->seconds_reference);
    printf("    %-8s %12s %12s %12s %8s\n", "layer", "rmse", "mae", "bias", "psnr");
    for (int e = 0; e < f->error_count && e < RENDER_MAX_LAYER_ERRORS; e++) {
        const render_layer_error *le = &f->errors[e];
        printf("    %-8s %12.6g %12.6g %12.6g %8.2f\n", le->layer, le->rmse, le->mae, le->bias, le->psnr);
    }
}

int cmd_render(cli_globals *g, int argc, char **argv);
int cmd_render(cli_globals *g, int argc, char **argv)
{
    const char *out_dir = "out", *cache_dir = NULL;
    uint64_t cache_memory = 0;
    int dry_run = 0, threads = g->threads, ao_none = 0, ao_touched = 0;
    const char **scenes = (const char **)calloc((size_t)argc, sizeof *scenes);
    cJSON *over = cJSON_CreateObject(), *cams = NULL;
    int nscenes = 0, code = CLI_EXIT_OK;
    if (!scenes || !over) {
        free(scenes);
        cJSON_Delete(over);
        return CLI_EXIT_INTERNAL;
    }
#define RENDER_USAGE(...)                                                                                    \
    do {                                                                                                   \
        code = cli_usage_error(__VA_ARGS__);                                                               \
        goto done_flags;                                                                                   \
    } while (0)
    if (argc < 2) {
        fputs(render_help, stderr);
        code = CLI_EXIT_USAGE;
        goto done_flags;
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        long long ll;
        int w, h;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(render_help, stdout);
            goto done_flags;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            if (!v || !v[0]) RENDER_USAGE("%s needs a directory", a);
            out_dir = v; i++;
        } else if (!strcmp(a, "--cache")) {
            if (!v || !v[0]) RENDER_USAGE("--cache needs a directory");
            cache_dir = v; i++;
        } else if (!strcmp(a, "--cache-memory")) {
            if (!cli_parse_int(v, 1, 1ll << 40, &ll)) RENDER_USAGE("--cache-memory needs megabytes, an integer >= 1");
            cache_memory = (uint64_t)ll * 1000000u; i++;
        } else if (!strcmp(a, "--dry-run")) {
            dry_run = 1;
        } else if (!strcmp(a, "--threads")) {
            if (!cli_parse_int(v, 0, 256, &ll)) RENDER_USAGE("--threads needs an integer in [0, 256]");
            threads = (int)ll; i++;
        } else if (!strcmp(a, "--camera")) {
            if (!v || !v[0]) RENDER_USAGE("--camera needs a name or an index");
            if (!cams && !(cams = cJSON_AddArrayToObject(over, "cameras"))) RENDER_USAGE("out of memory");
            if (cJSON_GetArraySize(cams) >= RENDER_MAX_CAMERAS)
                RENDER_USAGE("--camera: at most %d cameras", RENDER_MAX_CAMERAS);
            cJSON_AddItemToArray(cams, cJSON_CreateString(v)); /* a name, else an index */
            i++;
        } else if (!strcmp(a, "--size")) {
            if (!cli_parse_size(v, &w, &h)) RENDER_USAGE("--size needs WxH with each side in [1, %d]", RAST_MAX_DIM);
            const int wh[2] = {w, h};
            render_set(over, "size", cJSON_CreateIntArray(wh, 2));
            i++;
        } else if (!strcmp(a, "--outputs")) {
            if (!v || !v[0]) RENDER_USAGE("--outputs needs a comma-separated list of layers (or all)");
            if (!strcmp(v, "all")) {
                render_set(over, "outputs", cJSON_CreateString("all"));
            } else {
                cJSON *arr = cJSON_CreateArray();
                char buf[512];
                snprintf(buf, sizeof buf, "%s", v);
                for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ","))
                    cJSON_AddItemToArray(arr, cJSON_CreateString(tok));
                render_set(over, "outputs", arr);
            }
            i++;
        } else if (!strcmp(a, "--ao")) {
            if (!v || !v[0]) RENDER_USAGE("--ao needs a method name or none ('obscura ao --list')");
            if (!strcmp(v, "none")) {
                ao_none = 1;
            } else {
                if (!ao_method_find(v)) RENDER_USAGE("render: unknown AO method '%s' (see 'obscura ao --list')", v);
                ao_none = 0;
                render_set(over, "ao.method", cJSON_CreateString(v));
            }
            i++;
        } else if (!strcmp(a, "--ao-preset")) {
            if (!v || !v[0]) RENDER_USAGE("--ao-preset needs a name ('obscura ao --list')");
            render_set(over, "ao.preset", cJSON_CreateString(v));
            ao_touched = 1;
            i++;
        } else if (!strcmp(a, "--ao-param") || !strcmp(a, "--set")) {
            const int ao = !strcmp(a, "--ao-param");
            const char *eq = v ? strchr(v, '=') : NULL;
            if (!eq || eq == v) RENDER_USAGE("%s needs %s=VALUE", a, ao ? "KEY" : "PATH");
            char key[256];
            snprintf(key, sizeof key, "%s%.*s", ao ? "ao." : "", (int)(eq - v), v);
            if (!render_set(over, key, render_value(eq + 1))) RENDER_USAGE("%s: bad key in '%s'", a, v);
            if (ao || !strncmp(key, "ao.", 3))
                ao_touched = 1;
            i++;
        } else if (!strcmp(a, "--ambient")) {
            double rgb[3];
            if (v && cli_parse_triple(v, rgb)) {
                render_set(over, "ambient", cJSON_CreateDoubleArray(rgb, 3));
            } else {
                double x;
                if (!v || !cli_parse_float(v, &x) || !isfinite(x)) RENDER_USAGE("--ambient needs V or R,G,B");
                render_set(over, "ambient", cJSON_CreateNumber(x));
            }
            i++;
        } else if (!strcmp(a, "--no-shadows")) {
            render_set(over, "shadows.enabled", cJSON_CreateFalse());
        } else if (!strcmp(a, "--shadow-map-size")) {
            if (!cli_parse_int(v, 1, RAST_MAX_DIM, &ll)) RENDER_USAGE("--shadow-map-size needs a positive integer");
            render_set(over, "shadows.size", cJSON_CreateNumber((double)ll));
            i++;
        } else if (!strcmp(a, "--scale-mm")) {
            double x;
            if (!v || !cli_parse_float(v, &x) || !(x > 0) || !isfinite(x))
                RENDER_USAGE("--scale-mm needs a number > 0 (millimetres per scene unit)");
            render_set(over, "sss.mm_per_unit", cJSON_CreateNumber(x));
            i++;
        } else if (!strcmp(a, "--no-volume")) {
            render_set(over, "volume", cJSON_CreateFalse());
        } else if (!strcmp(a, "--seed")) {
            /* 2^53: the largest seed the sidecar's JSON carries exactly */
            if (!cli_parse_int(v, 0, 9007199254740992LL, &ll)) RENDER_USAGE("--seed needs an integer in [0, 2^53]");
            render_set(over, "seed", cJSON_CreateNumber((double)ll));
            i++;
        } else if (!strcmp(a, "--reference")) {
            render_set(over, "reference.enabled", cJSON_CreateTrue());
        } else if (a[0] == '-' && a[1]) {
            int r = cli_limit_flag(g, argc, argv, &i);
            if (r < 0) { code = CLI_EXIT_USAGE; goto done_flags; }
            if (r > 0) continue;
            RENDER_USAGE("render: unknown option '%s' (see 'obscura render --help')", a);
        } else {
            scenes[nscenes++] = a;
        }
    }
    if (nscenes == 0)
        RENDER_USAGE("render: no scene given");
    if (ao_none && ao_touched)
        RENDER_USAGE("render: --ao none with AO parameters (--ao-preset, --ao-param, --set ao.*)");
    if (ao_none)
        render_set(over, "ao", cJSON_CreateFalse());
#undef RENDER_USAGE

    char *over_text = cJSON_PrintUnformatted(over);
    cJSON_Delete(over);
    over = NULL;
    if (!over_text) {
        free(scenes);
        return CLI_EXIT_INTERNAL;
    }

    obs_context *ctx = obs_context_create();
    render_job *jobs = (render_job *)calloc((size_t)nscenes, sizeof *jobs);
    render_session *session = NULL;
    render_frame frame;
    memset(&frame, 0, sizeof frame);
    render_batch_progress bp;
    memset(&bp, 0, sizeof bp);
    if (!ctx || !jobs) {
        code = CLI_EXIT_INTERNAL;
        goto done;
    }
    obs_context_set_limits(ctx, &g->limits);
    obs_context_set_log_level(ctx, g->quiet ? OBS_LOG_ERROR : g->verbose ? OBS_LOG_DEBUG : OBS_LOG_WARN);
    for (int k = 0; k < nscenes; k++)
        obs_scene_init(&jobs[k].scene);

    /* ---- Every scene and its settings first: a bad scene stops the batch before any work ---- */
    obs_status st = OBS_STATUS_OK;
    int64_t total_views = 0;
    for (int k = 0; k < nscenes; k++) {
        render_job *J = &jobs[k];
        J->path = scenes[k];
        render_stem(J->path, J->stem, sizeof J->stem);
        for (int q = 0; q < k; q++)
            if (!strcmp(jobs[q].stem, J->stem)) {
                fprintf(stderr, "obscura: render: '%s' and '%s' would write the same files (%s/%s.*)\n",
                        jobs[q].path, J->path, out_dir, J->stem);
                code = CLI_EXIT_USAGE;
                goto done;
            }
        st = cli_load_scene(ctx, J->path, &J->scene);
        if (st == OBS_STATUS_OK)
            st = cli_require_triangles(ctx, &J->scene);
        J->st = render_settings_default();
        /* the scene's own settings: a bad key there is a bad input file (exit 3) */
        if (st == OBS_STATUS_OK && ((st = render_settings_from_scene(ctx, &J->scene, &J->st)) != OBS_STATUS_OK ||
                                    (st = render_settings_validate(ctx, &J->scene, &J->st)) != OBS_STATUS_OK)) {
            fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
            code = st == OBS_STATUS_OUT_OF_MEMORY ? CLI_EXIT_INTERNAL : CLI_EXIT_INPUT;
            goto done;
        }
        /* the flags on top: a bad value there is a usage error (exit 2), except a camera the scene
         * does not have (NOT_FOUND: exit 3, as the other commands) */
        if (st == OBS_STATUS_OK)
            st = render_settings_apply_json(ctx, over_text, "command line", &J->scene, &J->st);
        if (st == OBS_STATUS_OK)
            st = render_settings_validate(ctx, &J->scene, &J->st);
        if (st != OBS_STATUS_OK) {
            code = cli_fail(ctx, st);
            goto done;
        }
        J->views = render_view_count(&J->scene, &J->st);
        total_views += J->views;
    }

    render_options opt = render_options_default();
    opt.threads = threads;
    opt.cache_dir = cache_dir;
    opt.cache_memory = cache_memory;
    bp.views_total = total_views;
    bp.t0 = obs_time_now();
    if (!dry_run && !g->quiet && isatty(fileno(stderr))) {
        opt.progress = render_progress_draw;
        opt.progress_user = &bp;
    }
    session = render_session_create(ctx, &opt);
    if (!session) {
        code = cli_fail(ctx, obs_context_last_status(ctx));
        goto done;
    }
    if (!dry_run && (st = io_make_dirs(ctx, out_dir)) != OBS_STATUS_OK) {
        fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
        code = CLI_EXIT_OUTPUT;
        goto done;
    }

    /* ---- The views ---- */
    for (int k = 0; k < nscenes; k++) {
        render_job *J = &jobs[k];
        bp.scene_base = bp.views_done;
        bp.scene_views = J->views;
        for (int v = 0; v < J->views; v++) {
            const int cam = J->st.camera_count > 0 ? J->st.cameras[v] : (J->scene.camera_count > 0 ? v : -1);
            const char *cam_name = cam >= 0 ? J->scene.cameras[cam].name : "(framing camera)";
            char prefix[4400], safe[128];
            if (J->views > 1) {
                render_safe_name(cam >= 0 ? J->scene.cameras[cam].name : "", cam, safe, sizeof safe);
                /* a name two views share (the same camera twice, or two cameras of one name) gets
                 * the view's slot too, so that no view overwrites another */
                int shared = 0;
                for (int u = 0; u < J->views && !shared; u++) {
                    const int cu = J->st.camera_count > 0 ? J->st.cameras[u] : u;
                    char other[128];
                    render_safe_name(J->scene.cameras[cu].name, cu, other, sizeof other);
                    shared = u != v && !strcmp(other, safe);
                }
                if (shared)
                    snprintf(prefix, sizeof prefix, "%s/%s_%s_%d", out_dir, J->stem, safe, v);
                else
                    snprintf(prefix, sizeof prefix, "%s/%s_%s", out_dir, J->stem, safe);
            } else {
                snprintf(prefix, sizeof prefix, "%s/%s", out_dir, J->stem);
            }
            render_frame_free(&frame);
            st = dry_run ? render_plan(session, &J->scene, &J->st, v, &frame)
                         : render_frame_run(session, &J->scene, &J->st, v, &frame);
            if (st != OBS_STATUS_OK) {
                render_progress_end(&bp);
                code = st == OBS_STATUS_IO_ERROR ? CLI_EXIT_INPUT : cli_exit_for(st);
                fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
                goto done;
            }
            if (!dry_run) {
                st = render_frame_write(ctx, &frame, &J->scene, &J->st, prefix, argc, argv);
                bp.views_done++;
                render_progress_end(&bp);
                if (st != OBS_STATUS_OK) {
                    fprintf(stderr, "obscura: error: %s\n", obs_context_last_error(ctx));
                    code = st == OBS_STATUS_IO_ERROR ? CLI_EXIT_OUTPUT : cli_exit_for(st);
                    goto done;
                }
            }
            /* ---- What was done, where it is ---- */
            printf("%s, camera \"%s\" (%d/%lld), %dx%d%s", J->path, cam_name, (int)(bp.views_done + (dry_run ? 1 : 0)),
                   (long long)total_views, frame.width, frame.height, dry_run ? ": the plan (--dry-run)\n" : "");
            if (dry_run)
                bp.views_done++;
            else
                printf(": %.3f s\n", frame.seconds);
            render_pass_log_print(stdout, &frame);
            if (!dry_run) {
                render_print_reference(&frame);
                printf("  beauty PNG:  %s.png\n  layered EXR: %s.exr\n  sidecar:     %s.json\n", prefix, prefix, prefix);
            }
            fflush(stdout);
        }
    }
    if (!dry_run && !g->quiet) {
        render_cache_stats cs;
        render_session_cache_stats(session, &cs);
        fprintf(stderr,
                "obscura: render: %lld view(s); cache: %lld hit(s) in memory, %lld on disk, %lld miss(es), "
                "%lld dropped from memory\n",
                (long long)total_views, (long long)cs.hits_memory, (long long)cs.hits_disk, (long long)cs.misses,
                (long long)cs.evictions);
    }
done:
    render_progress_end(&bp);
    render_frame_free(&frame);
    render_session_destroy(session);
    for (int k = 0; jobs && k < nscenes; k++)
        obs_scene_free(&jobs[k].scene);
    free(jobs);
    free(over_text);
    free(scenes);
    obs_context_destroy(ctx);
    return code;
done_flags:
    cJSON_Delete(over);
    free(scenes);
    return code;
}
