/* bench.c: obscura's benchmarks. Speed is measured here, never in tests.
 *
 *   obscura_bench gbuffer MESH.glb [--size WxH] [--threads N] [--reps R] [--warmup W]
 *                                  [--outputs peer|all] [--isa auto|scalar|avx2] [--tile 16..256]
 *   obscura_bench methods          (the registered AO methods, one per line)
 *   obscura_bench ao MESH.glb --method NAME [--preset P] [--samples N] [--radius R] [--blur on|off]
 *                             [--set NAME=VALUE]... [--size WxH] [--threads N] [--reps R] [--warmup W]
 *
 * `ao` renders the G-buffer once (depth and shading normals, the peer's framing) and times the
 * method's compute over the whole image: total, and the method's own split into prepare (depth
 * conversion, MIPs, normals), kernel and blur (ao_stats). --set sets any registry parameter by
 * name (numbers for FLOAT/INT, on/off for BOOL, a choice name for ENUM). Radii are in the scene's
 * units: the mesh's bounding sphere has radius 10, as in the peer.
 *
 * The scene is framed exactly as the llvmpipe peer (../shared/tools/llvmpipe-peer) frames its
 * OFF mesh, so both render the same pixels: the mesh is centred on its bounding-box centre and
 * scaled so that the farthest vertex is at radius 10; the camera sits at (0, 0, dist) looking
 * down -Z with fovy 45 degrees, dist = 10 / sin(fovy/2), near = max(dist - 11, 0.5),
 * far = dist + 11. `--outputs peer` renders what the peer's gbuffer stage renders (depth and the
 * shading normal); `all` renders every plane. Prints one RESULT line with the median, min and max
 * of the timed repetitions in milliseconds, and the screen coverage. */
#include "ao/ao.h"
#include "bench_scene.h"
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int bench_gbuffer(int argc, char **argv)
{
    const char *mesh = NULL;
    int W = 1920, H = 1080, threads = 0, reps = 20, warmup = 5;
    rast_params p = rast_params_default();
    p.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--size")) { if (sscanf(v, "%dx%d", &W, &H) != 2) return 2; i++; }
        else if (!strcmp(a, "--threads")) { threads = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (!strcmp(a, "--warmup")) { warmup = atoi(v); i++; }
        else if (!strcmp(a, "--tile")) { p.tile_size = atoi(v); i++; }
        else if (!strcmp(a, "--outputs")) { p.outputs = !strcmp(v, "all") ? RAST_OUT_ALL : RAST_OUT_DEPTH | RAST_OUT_NORMAL; i++; }
        else if (!strcmp(a, "--isa")) { p.isa = !strcmp(v, "scalar") ? RAST_ISA_SCALAR : !strcmp(v, "avx2") ? RAST_ISA_AVX2 : RAST_ISA_AUTO; i++; }
        else if (a[0] != '-') mesh = a;
        else { fprintf(stderr, "unknown option %s\n", a); return 2; }
    }
    if (!mesh || reps < 1 || W < 1 || H < 1) {
        fprintf(stderr, "usage: obscura_bench gbuffer MESH.glb [--size WxH] [--threads N] [--reps R]\n");
        return 2;
    }
    p.width = W;
    p.height = H;
    obs_context *ctx = obs_context_create();
    obs_scene s;
    obs_camera cam;
    if (bench_load_framed(ctx, mesh, &s, &cam) != 0)
        return 3;
    obs_pool *pool = obs_pool_create(threads);
    rast_gbuffer gb;
    rast_workspace *ws = rast_workspace_create(); /* reused across frames, as a renderer would */
    if (!ws || rast_gbuffer_alloc(ctx, &p, &gb) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 4;
    }
    rast_view view = {cam};
    double *t = calloc((size_t)reps, sizeof(double));
    rast_stats st;
    double setup = 0;
    for (int k = 0; k < warmup + reps; k++) {
        double t0 = obs_time_now();
        if (rast_render_ws(ctx, pool, ws, &s, &view, 1, &p, &gb, &st) != OBS_STATUS_OK) {
            fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
            return 5;
        }
        double t1 = obs_time_now();
        if (k >= warmup) {
            t[k - warmup] = 1e3 * (t1 - t0);
            setup += 1e3 * st.seconds_setup / reps;
        }
    }
    qsort(t, (size_t)reps, sizeof(double), cmp_double);
    double median = reps % 2 ? t[reps / 2] : 0.5 * (t[reps / 2 - 1] + t[reps / 2]);
    printf("RESULT gbuffer mesh=%s size=%dx%d tile=%d threads=%d isa=%s outputs=%s tris=%llu coverage=%.4f "
           "median_ms=%.3f min_ms=%.3f max_ms=%.3f setup_ms=%.3f reps=%d\n",
           mesh, W, H, p.tile_size, obs_pool_threads(pool), rast_isa_name(st.isa_used), p.outputs == RAST_OUT_ALL ? "all" : "peer",
           (unsigned long long)st.triangles_in, (double)st.pixels_covered / ((double)W * H), median, t[0],
           t[reps - 1], setup, reps);
    free(t);
    rast_workspace_destroy(ws);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    return 0;
}

static double median_sorted(double *t, int n)
{
    qsort(t, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? t[n / 2] : 0.5 * (t[n / 2 - 1] + t[n / 2]);
}

/* NAME=VALUE through the method's parameter descriptor. Returns 0, or 2 on a bad setting. */
static int set_param(const ao_method *m, void *params, const char *kv)
{
    char name[64];
    const char *eq = strchr(kv, '=');
    if (!eq || (size_t)(eq - kv) >= sizeof name)
        return 2;
    memcpy(name, kv, (size_t)(eq - kv));
    name[eq - kv] = 0;
    const char *v = eq + 1;
    const ao_param_desc *d = ao_method_param(m, name);
    if (!d)
        return 2;
    char *field = (char *)params + d->offset;
    int iv = 0;
    if (d->type == AO_PARAM_FLOAT) {
        float f = strtof(v, NULL);
        memcpy(field, &f, sizeof f);
        return 0;
    }
    if (d->type == AO_PARAM_INT)
        iv = atoi(v);
    else if (d->type == AO_PARAM_BOOL)
        iv = !strcmp(v, "on") || !strcmp(v, "1");
    else {
        while (d->choices[iv] && strcmp(d->choices[iv], v))
            iv++;
        if (!d->choices[iv])
            return 2;
    }
    memcpy(field, &iv, sizeof iv);
    return 0;
}

static int bench_ao(int argc, char **argv)
{
    const char *mesh = NULL, *method = NULL, *preset = NULL;
    int W = 1920, H = 1080, threads = 0, reps = 10, warmup = 2, samples = 0, blur = -1;
    float radius = 0.0f;
    const char *sets[32];
    int nsets = 0;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--size")) { if (sscanf(v, "%dx%d", &W, &H) != 2) return 2; i++; }
        else if (!strcmp(a, "--threads")) { threads = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (!strcmp(a, "--warmup")) { warmup = atoi(v); i++; }
        else if (!strcmp(a, "--method")) { method = v; i++; }
        else if (!strcmp(a, "--preset")) { preset = v; i++; }
        else if (!strcmp(a, "--samples")) { samples = atoi(v); i++; }
        else if (!strcmp(a, "--radius")) { radius = strtof(v, NULL); i++; }
        else if (!strcmp(a, "--blur")) { blur = !strcmp(v, "on"); i++; }
        else if (!strcmp(a, "--set") && nsets < 32) { sets[nsets++] = v; i++; }
        else if (a[0] != '-') mesh = a;
        else { fprintf(stderr, "unknown option %s\n", a); return 2; }
    }
    const ao_method *m = method ? ao_method_find(method) : NULL;
    if (!mesh || !m || reps < 1 || W < 1 || H < 1) {
        fprintf(stderr, "usage: obscura_bench ao MESH.glb --method NAME [options] (unknown method?)\n");
        return 2;
    }
    unsigned char params[AO_PARAMS_MAX_SIZE] __attribute__((aligned(16)));
    m->params_default(params);
    if (preset && !m->params_preset(preset, params)) {
        fprintf(stderr, "bench: %s has no preset %s\n", m->name, preset);
        return 2;
    }
    if (samples > 0)
        m->set_samples(params, samples);
    if (radius > 0.0f)
        m->set_radius(params, radius);
    if (blur >= 0)
        m->set_blur(params, blur);
    for (int k = 0; k < nsets; k++)
        if (set_param(m, params, sets[k])) {
            fprintf(stderr, "bench: bad --set %s for %s\n", sets[k], m->name);
            return 2;
        }
    obs_context *ctx = obs_context_create();
    if (m->params_validate(ctx, params) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 2;
    }
    obs_scene s;
    obs_camera cam;
    if (bench_load_framed(ctx, mesh, &s, &cam) != 0)
        return 3;
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    obs_pool *pool = obs_pool_create(threads);
    rast_gbuffer gb;
    rast_view view = {cam};
    rast_stats rs;
    ao_input in;
    obs_image_f32 out = {0}, raw = {0};
    if (rast_gbuffer_alloc(ctx, &rp, &gb) != OBS_STATUS_OK ||
        rast_render(ctx, pool, &s, &view, 1, &rp, &gb, &rs) != OBS_STATUS_OK ||
        ao_input_from_gbuffer(ctx, &gb, 1, &in) != OBS_STATUS_OK || obs_image_f32_alloc(ctx, W, H, &out) != OBS_STATUS_OK ||
        obs_image_f32_alloc(ctx, W, H, &raw) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 4;
    }
    double *t = calloc((size_t)reps * 4, sizeof(double));
    double *tp = t + reps, *tk = t + 2 * reps, *tb = t + 3 * reps;
    ao_stats st;
    for (int k = 0; k < warmup + reps; k++) {
        double t0 = obs_time_now();
        if (m->compute(ctx, pool, &in, params, &out, &raw, &st) != OBS_STATUS_OK) {
            fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
            return 5;
        }
        double t1 = obs_time_now();
        if (k >= warmup) {
            t[k - warmup] = 1e3 * (t1 - t0);
            tp[k - warmup] = 1e3 * st.seconds_prepare;
            tk[k - warmup] = 1e3 * st.seconds_kernel;
            tb[k - warmup] = 1e3 * st.seconds_blur;
        }
    }
    double mp = median_sorted(tp, reps), mk = median_sorted(tk, reps), mb = median_sorted(tb, reps);
    double med = median_sorted(t, reps);
    char desc[1024];
    m->params_to_string(params, desc, sizeof desc);
    for (char *c = desc; *c; c++)
        if (*c == ' ')
            *c = ',';
    const double mpix = (double)W * H / 1e6;
    printf("RESULT ao method=%s mesh=%s size=%dx%d threads=%d coverage=%.4f median_ms=%.3f min_ms=%.3f max_ms=%.3f "
           "prepare_ms=%.3f kernel_ms=%.3f blur_ms=%.3f ns_per_pixel=%.2f pixels=%lld background=%lld reps=%d params=%s\n",
           m->name, mesh, W, H, obs_pool_threads(pool), (double)rs.pixels_covered / ((double)W * H), med, t[0],
           t[reps - 1], mp, mk, mb, med / mpix, (long long)st.pixels_computed, (long long)st.pixels_background,
           reps, desc);
    free(t);
    obs_image_f32_free(&out);
    obs_image_f32_free(&raw);
    rast_gbuffer_free(&gb);
    obs_pool_destroy(pool);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "gbuffer"))
        return bench_gbuffer(argc, argv);
    if (argc >= 2 && !strcmp(argv[1], "ao"))
        return bench_ao(argc, argv);
    if (argc >= 2 && !strcmp(argv[1], "methods")) { /* the registered AO methods, one per line */
        for (const ao_method *const *m = ao_methods(); *m; m++)
            printf("%s\n", (*m)->name);
        return 0;
    }
    fprintf(stderr, "usage: obscura_bench gbuffer|ao MESH.glb [options]\n");
    return 2;
}
