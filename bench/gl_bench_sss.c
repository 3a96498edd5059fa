/* gl_bench_sss.c: the scattering maps of [DalCorso14], our CPU passes beside their GLSL port on
 * Mesa's llvmpipe (tests/gl/glsl_sss.c), timed side by side in one process, alternating (issue 13:
 * a ratio to a peer counts only when both sides ran in the same run on the same machine).
 *
 *   obscura_gl_bench_sss SCENE.glb [--K K] [--N N] [--map S] [--size WxH] [--threads T] [--pairs P]
 *                                  [--reps R]
 *
 * SCENE is a translucent scene (glTF extras "obscura_sss", e.g. build/data/bunny_cream.glb) with a
 * light and a camera. The light G-buffers, our maps and the camera G-buffer are computed once; the
 * GLSL side gets them as textures uploaded before timing. Two stages, each P pairs of R timed GLSL
 * runs (draw + glFinish) then R timed runs of ours, after one untimed warm-up of each; each side's
 * figure is the median of its R runs:
 *   maps         the GLSL gather (one pass, K layers) vs sss_maps_build. Ours includes the
 *                rasterisation of the K views (the public pass does both), the GLSL side reads
 *                our views: ours is charged for the views, which the thesis renders as well.
 *   combination  the GLSL combination vs sss_combine, on the same maps and camera G-buffer.
 * Sampler: Russian roulette, set explicitly. llvmpipe gets T threads too (LP_NUM_THREADS). */
#define _POSIX_C_SOURCE 200809L /* setenv */
#include "gl/glsl_sss.h"
#include "io/io.h"
#include "raster/raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int main(int argc, char **argv)
{
    const char *file = NULL;
    int K = 16, N = 48, S = 256, W = 640, H = 480, threads = 2, pairs = 3, reps = 3;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--K")) { K = atoi(v); i++; }
        else if (!strcmp(a, "--N")) { N = atoi(v); i++; }
        else if (!strcmp(a, "--map")) { S = atoi(v); i++; }
        else if (!strcmp(a, "--size") && sscanf(v, "%dx%d", &W, &H) == 2) i++;
        else if (!strcmp(a, "--threads")) { threads = atoi(v); i++; }
        else if (!strcmp(a, "--pairs")) { pairs = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (a[0] != '-' && !file) file = a;
        else file = NULL, i = argc;
    }
    if (!file || K < 1 || K > 64 || N < 1 || S < 16 || W < 16 || H < 16 || threads < 1 || pairs < 1 || reps < 1 ||
        pairs > 1000 || reps > 1000) {
        fprintf(stderr, "usage: obscura_gl_bench_sss SCENE.glb [--K K] [--N N] [--map S] [--size WxH] [--threads T] "
                        "[--pairs P] [--reps R]\n");
        return 2;
    }
    char nt[16];
    snprintf(nt, sizeof nt, "%d", threads);
    setenv("LP_NUM_THREADS", nt, 1);
    glh g;
    char why[512];
    if (!glh_open(&g, why, sizeof why)) {
        fprintf(stderr, "gl_bench_sss: llvmpipe unavailable: %s\n", why);
        return 77;
    }
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(threads);
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    sss_scene_setup setup;
    obs_status st = io_gltf_load(ctx, file, &opt, &s);
    if (st == OBS_STATUS_OK)
        st = sss_scene_setup_make(ctx, &s, NULL, SSS_DEFAULT_MM_PER_UNIT, &setup);
    if (st != OBS_STATUS_OK || s.light_count < 1 || s.camera_count < 1) {
        fprintf(stderr, "gl_bench_sss: %s: %s\n", file,
                st != OBS_STATUS_OK ? obs_context_last_error(ctx) : "needs a light and a camera");
        return 3;
    }
    sss_params p = sss_params_default();
    p.sampler = SSS_SAMPLER_RUSSIAN_ROULETTE;
    p.K = K;
    p.N = N;
    p.map_size = S;
    p.light_map_size = S;
    sss_light_map lm;
    sss_maps maps;
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_MATERIAL_ID | RAST_OUT_INSTANCE_ID;
    rp.face_forward = 0;
    rast_gbuffer cgb;
    obs_camera cam = s.cameras[0];
    rast_view view = {cam};
    st = sss_light_map_render(ctx, pool, &s, &s.lights[0], &p, &lm);
    if (st == OBS_STATUS_OK)
        st = sss_maps_build(ctx, pool, &s, &setup.mats, &lm, 1, &p, &maps);
    if (st == OBS_STATUS_OK)
        st = rast_gbuffer_alloc(ctx, &rp, &cgb);
    if (st == OBS_STATUS_OK)
        st = rast_render(ctx, pool, &s, &view, 1, &rp, &cgb, NULL);
    if (st != OBS_STATUS_OK) {
        fprintf(stderr, "gl_bench_sss: %s\n", obs_context_last_error(ctx));
        return 3;
    }
    glh_run rg, rc;
    if (!glsl_sss_gather_build(&g, ctx, &s, &setup.mats, &lm, 1, &maps, &p, &rg) ||
        !glsl_sss_combine_build(&g, ctx, &setup.mats, &maps, &cgb, &cam, &p, &rc)) {
        fprintf(stderr, "gl_bench_sss: the GLSL port does not build\n");
        return 3;
    }
    printf("# %s: K=%d N=%d maps %d^2, light map %d^2, camera %dx%d, %d threads (llvmpipe %s), %d pairs x %d reps\n",
           file, K, N, S, S, W, H, threads, nt, pairs, reps);
    const char *stages[2] = {"maps", "combination"};
    for (int stg = 0; stg < 2; stg++) {
        const glh_run *r = stg == 0 ? &rg : &rc;
        double *tg = (double *)malloc(sizeof(double) * (size_t)reps);
        double *to = (double *)malloc(sizeof(double) * (size_t)reps);
        double *mg = (double *)malloc(sizeof(double) * (size_t)pairs);
        double *mo = (double *)malloc(sizeof(double) * (size_t)pairs);
        double *ra = (double *)malloc(sizeof(double) * (size_t)pairs);
        for (int q = 0; q < pairs; q++) {
            for (int k = 0; k <= reps; k++) {
                const double t = glh_run_time_ms(&g, r, 0, r->npass);
                if (k > 0)
                    tg[k - 1] = t;
            }
            for (int k = 0; k <= reps; k++) {
                const double t0 = obs_time_now();
                if (stg == 0) {
                    sss_maps m2;
                    st = sss_maps_build(ctx, pool, &s, &setup.mats, &lm, 1, &p, &m2);
                    sss_maps_free(&m2);
                } else {
                    obs_image_f32 out[3];
                    st = sss_combine(ctx, pool, &s, &setup.mats, &maps, &lm, 1, &cgb, &cam, &p, out, NULL);
                    for (int c = 0; c < 3; c++)
                        obs_image_f32_free(&out[c]);
                }
                const double t = (obs_time_now() - t0) * 1e3;
                if (st != OBS_STATUS_OK) {
                    fprintf(stderr, "gl_bench_sss: %s\n", obs_context_last_error(ctx));
                    return 3;
                }
                if (k > 0)
                    to[k - 1] = t;
            }
            mg[q] = median(tg, reps);
            mo[q] = median(to, reps);
            ra[q] = mg[q] / mo[q];
            printf("RESULT pass=sss stage=%s pair=%d glsl_ms=%.3f obscura_ms=%.3f ratio=%.2f\n", stages[stg], q, mg[q],
                   mo[q], ra[q]);
            fflush(stdout);
        }
        printf("SUMMARY pass=sss stage=%s glsl_ms=%.3f obscura_ms=%.3f ratio=%.2f\n", stages[stg], median(mg, pairs),
               median(mo, pairs), median(ra, pairs));
        free(tg);
        free(to);
        free(mg);
        free(mo);
        free(ra);
    }
    glh_run_free(&g, &rg);
    glh_run_free(&g, &rc);
    rast_gbuffer_free(&cgb);
    sss_maps_free(&maps);
    sss_light_map_free(&lm);
    sss_scene_setup_free(&setup);
    obs_scene_free(&s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    glh_close(&g);
    return 0;
}
