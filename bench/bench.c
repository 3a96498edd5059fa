/* bench.c: obscura's benchmarks. Speed is measured here, never in tests.
 *
 *   obscura_bench gbuffer MESH.glb [--size WxH] [--threads N] [--reps R] [--warmup W]
 *                                  [--outputs peer|all] [--isa auto|scalar|avx2] [--tile 16..256]
 *
 * The scene is framed exactly as the llvmpipe peer (../shared/tools/llvmpipe-peer) frames its
 * OFF mesh, so both render the same pixels: the mesh is centred on its bounding-box centre and
 * scaled so that the farthest vertex is at radius 10; the camera sits at (0, 0, dist) looking
 * down -Z with fovy 45 degrees, dist = 10 / sin(fovy/2), near = max(dist - 11, 0.5),
 * far = dist + 11. `--outputs peer` renders what the peer's gbuffer stage renders (depth and the
 * shading normal); `all` renders every plane. Prints one RESULT line with the median, min and max
 * of the timed repetitions in milliseconds, and the screen coverage. */
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
    io_gltf_options opt = io_gltf_options_default();
    if (io_gltf_load(ctx, mesh, &opt, &s) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 3;
    }
    /* Peer framing: bbox centre, farthest vertex at radius 10 (world space of the loaded scene). */
    obs_scene_update_bounds(&s);
    obs_vec3 c = obs_v3_scale(obs_v3_add(s.bounds.lo, s.bounds.hi), 0.5f);
    double r2 = 0;
    for (uint32_t i = 0; i < s.instance_count; i++) {
        const obs_mesh *m = &s.meshes[s.instances[i].mesh];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            obs_vec3 w = obs_mat4_mul_point(s.instances[i].world, obs_v3(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]));
            obs_vec3 d = obs_v3_sub(w, c);
            double dd = (double)d.x * d.x + (double)d.y * d.y + (double)d.z * d.z;
            r2 = dd > r2 ? dd : r2;
        }
    }
    float scale = (float)(10.0 / sqrt(r2));
    obs_mat4 fit = obs_mat4_mul(obs_mat4_scale(obs_v3(scale, scale, scale)), obs_mat4_translation(obs_v3_scale(c, -1.0f)));
    for (uint32_t i = 0; i < s.instance_count; i++)
        s.instances[i].world = obs_mat4_mul(fit, s.instances[i].world);
    const float fovy = (float)(45.0 * OBS_PI / 180.0);
    float dist = 10.0f / sinf(0.5f * fovy);
    obs_camera cam = obs_camera_look_at(obs_v3(0, 0, dist), obs_v3(0, 0, 0), obs_v3(0, 1, 0), fovy,
                                        fmaxf(dist - 11.0f, 0.5f), dist + 11.0f);
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

int main(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "gbuffer"))
        return bench_gbuffer(argc, argv);
    fprintf(stderr, "usage: obscura_bench gbuffer MESH.glb [options]\n");
    return 2;
}
