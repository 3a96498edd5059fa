/* gl_bench_volume.c: the light volume of [Ropinski10], our vol_light_volume_build beside its GLSL
 * port on Mesa's llvmpipe (tests/gl/glsl_volume.c: one fragment pass per slice into 3D textures,
 * as the paper's GPU method), timed side by side in one process, alternating (issue 13: a ratio to
 * a peer counts only when both sides ran in the same run on the same machine; issue 15 item 11:
 * "≥ 3x the GLSL stage on llvmpipe").
 *
 *   obscura_gl_bench_volume [VOLUME] [--light-dir X,Y,Z | --light-pos X,Y,Z] [--scale S] [--cone DEG]
 *                           [--no-blend] [--threads T] [--pairs P] [--reps R]
 *
 * VOLUME: synth:NAME:N (default synth:bucky:256) or a file io_volume_load reads (NIfTI, NRRD); the
 * TF is the bucky preset for synthetic volumes, ct-skin otherwise. Default light: directional along
 * -z (one propagation, the "directional light and a 3x3 cone": the default 45 degree cone is
 * the centre and one ring of 8 taps). P pairs of R timed GLSL runs (all passes + glFinish) then R
 * timed runs of ours, after one untimed warm-up of each; each side's figure is the median of its R
 * runs. The data is uploaded before timing, as a GPU renderer holds it. llvmpipe gets T threads too
 * (LP_NUM_THREADS). */
#define _POSIX_C_SOURCE 200809L /* setenv */
#include "gl/glsl_volume.h"
#include "io/io.h"

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
    const char *file = "synth:bucky:256";
    int threads = 2, pairs = 3, reps = 3, bad = 0, point = 0;
    double lvec[3] = {0.0, 0.0, -1.0};
    vol_lv_params p = vol_lv_params_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if ((!strcmp(a, "--light-dir") || !strcmp(a, "--light-pos")) &&
            sscanf(v, "%lf,%lf,%lf", &lvec[0], &lvec[1], &lvec[2]) == 3) {
            point = !strcmp(a, "--light-pos");
            i++;
        } else if (!strcmp(a, "--scale")) { p.scale = atoi(v); i++; }
        else if (!strcmp(a, "--cone")) { p.cone_angle_deg = atof(v); i++; }
        else if (!strcmp(a, "--no-blend")) p.blend_second = 0;
        else if (!strcmp(a, "--threads")) { threads = atoi(v); i++; }
        else if (!strcmp(a, "--pairs")) { pairs = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (a[0] != '-') file = a;
        else bad = 1;
    }
    if (bad || threads < 1 || pairs < 1 || reps < 1 || pairs > 1000 || reps > 1000) {
        fprintf(stderr, "usage: obscura_gl_bench_volume [synth:NAME:N | FILE] [--light-dir X,Y,Z | --light-pos X,Y,Z] "
                        "[--scale S] [--cone DEG] [--no-blend] [--threads T] [--pairs P] [--reps R]\n");
        return 2;
    }
    char nt[16];
    snprintf(nt, sizeof nt, "%d", threads);
    setenv("LP_NUM_THREADS", nt, 1);
    glh g;
    char why[512];
    if (!glh_open(&g, why, sizeof why)) {
        fprintf(stderr, "gl_bench_volume: llvmpipe unavailable: %s\n", why);
        return 77;
    }
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(threads);
    vol_grid grid;
    vol_tf tf;
    memset(&grid, 0, sizeof grid);
    memset(&tf, 0, sizeof tf);
    obs_status st;
    int synthetic = !strncmp(file, "synth:", 6);
    if (synthetic) {
        char name[64] = "bucky";
        int n = 256;
        if (sscanf(file + 6, "%63[^:]:%d", name, &n) < 1)
            n = 256;
        st = vol_synth(ctx, name, n, &grid);
    } else {
        io_volume_options vo = io_volume_options_default();
        st = io_volume_load(ctx, file, &vo, &grid);
    }
    if (st == OBS_STATUS_OK)
        st = vol_tf_preset(ctx, synthetic ? "bucky" : "ct-skin", &tf);
    if (st != OBS_STATUS_OK) {
        fprintf(stderr, "gl_bench_volume: %s\n", obs_context_last_error(ctx));
        return 3;
    }
    vol_light L;
    memset(&L, 0, sizeof L);
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    L.type = point ? OBS_LIGHT_POINT : OBS_LIGHT_DIRECTIONAL;
    for (int c = 0; c < 3; c++) {
        if (point)
            L.position[c] = lvec[c];
        else
            L.direction[c] = lvec[c];
    }
    glsl_volume r;
    if (!glsl_volume_build(&g, ctx, &grid, &tf, &L, &p, &r)) {
        fprintf(stderr, "gl_bench_volume: the GLSL port does not build\n");
        return 3;
    }
    printf("# %s %dx%dx%d, %s light (%g, %g, %g), scale %d, cone %g, blend %d (faces %d, %d, w %.4f), %d threads "
           "(llvmpipe %s), %d pairs x %d reps\n",
           file, grid.nx, grid.ny, grid.nz, point ? "point" : "directional", lvec[0], lvec[1], lvec[2], p.scale,
           p.cone_angle_deg, p.blend_second, r.face0, r.face1, (double)r.blend_weight, threads, nt, pairs, reps);
    double *tg = (double *)malloc(sizeof(double) * (size_t)reps), *to = (double *)malloc(sizeof(double) * (size_t)reps);
    double *mg = (double *)malloc(sizeof(double) * (size_t)pairs), *mo = (double *)malloc(sizeof(double) * (size_t)pairs);
    double *ra = (double *)malloc(sizeof(double) * (size_t)pairs);
    for (int q = 0; q < pairs; q++) {
        for (int k = 0; k <= reps; k++) {
            const double t = glsl_volume_time_ms(&g, &r);
            if (k > 0)
                tg[k - 1] = t;
        }
        for (int k = 0; k <= reps; k++) {
            vol_light_volume lv;
            const double t0 = obs_time_now();
            st = vol_light_volume_build(ctx, pool, &grid, &tf, &L, &p, &lv);
            const double t = (obs_time_now() - t0) * 1e3;
            vol_light_volume_free(&lv);
            if (st != OBS_STATUS_OK) {
                fprintf(stderr, "gl_bench_volume: %s\n", obs_context_last_error(ctx));
                return 3;
            }
            if (k > 0)
                to[k - 1] = t;
        }
        mg[q] = median(tg, reps);
        mo[q] = median(to, reps);
        ra[q] = mg[q] / mo[q];
        printf("RESULT pass=lightvolume stage=propagation pair=%d glsl_ms=%.3f obscura_ms=%.3f ratio=%.2f\n", q, mg[q],
               mo[q], ra[q]);
        fflush(stdout);
    }
    printf("SUMMARY pass=lightvolume stage=propagation glsl_ms=%.3f obscura_ms=%.3f ratio=%.2f\n", median(mg, pairs),
           median(mo, pairs), median(ra, pairs));
    free(tg);
    free(to);
    free(mg);
    free(mo);
    free(ra);
    glsl_volume_free(&g, &r);
    vol_tf_free(&tf);
    vol_grid_free(&grid);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    glh_close(&g);
    return 0;
}
