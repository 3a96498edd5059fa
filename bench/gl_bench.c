/* gl_bench.c: every AO kernel and blur, our CPU code beside its GLSL port on Mesa's llvmpipe, timed
 * side by side in one process, alternating (issue 13: a ratio to a peer counts only when both sides
 * ran in the same benchmark run on the same machine, alternating).
 *
 *   obscura_gl_bench MESH.glb [--size WxH] [--threads N] [--pairs P] [--reps R] [--only a,b,...]
 *
 * The scene is the bunny framed as the llvmpipe peer frames it (bench_scene.h); its G-buffer
 * (depth and shading normals) is rendered once, and both sides start from the same ao_input: the
 * GLSL side gets it as textures, uploaded once before timing (a GPU renderer has its G-buffer in
 * memory already). For each port (tests/gl/glsl_ports.h) and each stage (kernel, blur) the
 * benchmark runs P pairs; a pair is R timed GLSL runs (draw + glFinish) then R timed runs of ours,
 * after one untimed warm-up of each; each side's figure is the median of its R runs. It prints one
 * RESULT line per pair and a summary per stage with the medians over pairs of each side and of the
 * per-pair ratios (llvmpipe / obscura). llvmpipe gets N threads too (LP_NUM_THREADS). */
#include "bench_scene.h"
#include "gl/glsl_ports.h"
#include "raster/raster.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const glsl_port *const ports[] = {
    &glsl_port_sao,    &glsl_port_hbao_classic, &glsl_port_hbao_plus, &glsl_port_crytek,     &glsl_port_alchemy,
    &glsl_port_ue4,    &glsl_port_gtao,         &glsl_port_mssao,     &glsl_port_mssao_seed, &glsl_port_mssao_seed_blurred,
};

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

static int listed(const char *only, const char *name)
{
    if (!only)
        return 1;
    const size_t n = strlen(name);
    for (const char *p = only; (p = strstr(p, name)) != NULL; p += n)
        if ((p == only || p[-1] == ',') && (p[n] == ',' || p[n] == '\0'))
            return 1;
    return 0;
}

enum { STAGE_KERNEL, STAGE_BLUR, STAGE_FULL };
static const char *const stage_names[] = {"kernel", "blur", "kernel+blur"};

/* time R runs of ours at a stage into the preallocated plane out (kin: the kernel's output, for
 * the blur); returns the median, or -1 */
static double time_ours(obs_context *ctx, obs_pool *pool, const glsl_port *pt, const ao_input *in, int stage,
                        const obs_image_f32 *kin, obs_image_f32 *out, int reps, double *t)
{
    for (int k = 0; k <= reps; k++) {
        const double t0 = obs_time_now();
        const obs_status st = stage == STAGE_BLUR   ? pt->ours_blur(ctx, pool, in, kin, out)
                              : stage == STAGE_FULL ? pt->ours_full(ctx, pool, in, out)
                                                    : pt->ours_kernel(ctx, pool, in, out);
        const double t1 = obs_time_now();
        if (st != OBS_STATUS_OK) {
            fprintf(stderr, "gl_bench: %s: %s\n", pt->name, obs_context_last_error(ctx));
            return -1.0;
        }
        if (k > 0)
            t[k - 1] = (t1 - t0) * 1e3;
    }
    return median(t, reps);
}

static double time_glsl(glh *g, const glh_run *r, int first, int count, int reps, double *t)
{
    glh_run_time_ms(g, r, first, count); /* warm-up */
    for (int k = 0; k < reps; k++)
        t[k] = glh_run_time_ms(g, r, first, count);
    return median(t, reps);
}

int main(int argc, char **argv)
{
    const char *mesh = NULL, *only = NULL;
    int W = 1920, H = 1080, threads = 2, pairs = 5, reps = 5;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--size") && sscanf(v, "%dx%d", &W, &H) == 2) i++;
        else if (!strcmp(a, "--threads")) { threads = atoi(v); i++; }
        else if (!strcmp(a, "--pairs")) { pairs = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (!strcmp(a, "--only")) { only = v; i++; }
        else if (a[0] != '-' && !mesh) mesh = a;
        else {
            fprintf(stderr, "usage: obscura_gl_bench MESH.glb [--size WxH] [--threads N] [--pairs P] [--reps R] "
                            "[--only a,b]\n");
            return 2;
        }
    }
    if (!mesh || W < 16 || H < 16 || threads < 1 || pairs < 1 || reps < 1 || reps > 1000 || pairs > 1000) {
        fprintf(stderr, "usage: obscura_gl_bench MESH.glb [--size WxH] [--threads N] [--pairs P] [--reps R]\n");
        return 2;
    }
    char nt[16];
    snprintf(nt, sizeof nt, "%d", threads);
    setenv("LP_NUM_THREADS", nt, 1);
    glh g;
    char why[512];
    if (!glh_open(&g, why, sizeof why)) {
        fprintf(stderr, "gl_bench: llvmpipe unavailable: %s\n", why);
        return 77;
    }
    obs_context *ctx = obs_context_create();
    obs_scene s;
    obs_camera cam;
    if (bench_load_framed(ctx, mesh, &s, &cam) != 0)
        return 3;
    obs_pool *pool = obs_pool_create(threads);
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    rast_gbuffer gb;
    ao_input in;
    rast_view view = {cam};
    if (rast_gbuffer_alloc(ctx, &rp, &gb) != OBS_STATUS_OK ||
        rast_render(ctx, pool, &s, &view, 1, &rp, &gb, NULL) != OBS_STATUS_OK ||
        ao_input_from_gbuffer(ctx, &gb, 1, &in) != OBS_STATUS_OK) {
        fprintf(stderr, "gl_bench: %s\n", obs_context_last_error(ctx));
        return 4;
    }
    printf("# %s, %s; obscura %d threads (pool %d); size %dx%d; %d pairs of %d timed runs\n", g.renderer, g.version,
           threads, obs_pool_threads(pool), W, H, pairs, reps);
    double *t = calloc((size_t)reps, sizeof(double));
    double *sg = calloc((size_t)pairs, sizeof(double)), *so = calloc((size_t)pairs, sizeof(double)),
           *sr = calloc((size_t)pairs, sizeof(double));
    int rc = 0;
    for (size_t pi = 0; pi < sizeof ports / sizeof ports[0]; pi++) {
        const glsl_port *pt = ports[pi];
        if (!listed(only, pt->name))
            continue;
        glh_run r = {0};
        if (!pt->build(&g, ctx, &in, &r)) {
            fprintf(stderr, "gl_bench: %s: the GLSL port does not build\n", pt->name);
            rc = 5;
            continue;
        }
        /* the output planes, allocated once (as a renderer keeps its targets) */
        obs_image_f32 kout = {0}, bout = {0};
        if (obs_image_f32_alloc(ctx, in.w, in.h, &kout) != OBS_STATUS_OK ||
            obs_image_f32_alloc(ctx, in.w, in.h, &bout) != OBS_STATUS_OK ||
            pt->ours_kernel(ctx, pool, &in, &kout) != OBS_STATUS_OK) {
            fprintf(stderr, "gl_bench: %s: %s\n", pt->name, obs_context_last_error(ctx));
            obs_image_f32_free(&kout);
            obs_image_f32_free(&bout);
            glh_run_free(&g, &r);
            rc = 5;
            continue;
        }
        for (int stage = STAGE_KERNEL; stage <= STAGE_FULL; stage++) {
            /* the blur alone where ours can run it alone; otherwise kernel and blur together */
            if (r.npass == r.nkernel && stage != STAGE_KERNEL)
                break;
            if ((stage == STAGE_BLUR && !pt->ours_blur) || (stage == STAGE_FULL && (pt->ours_blur || !pt->ours_full)))
                continue;
            const int first = stage == STAGE_BLUR ? r.nkernel : 0;
            const int count = stage == STAGE_BLUR ? r.npass - r.nkernel : stage == STAGE_FULL ? r.npass : r.nkernel;
            int ok = 1;
            for (int p = 0; p < pairs && ok; p++) {
                sg[p] = time_glsl(&g, &r, first, count, reps, t);
                so[p] = time_ours(ctx, pool, pt, &in, stage, &kout, stage == STAGE_KERNEL ? &kout : &bout, reps, t);
                ok = so[p] > 0.0;
                sr[p] = ok ? sg[p] / so[p] : 0.0;
                if (ok)
                    printf("RESULT pass=%s stage=%s pair=%d glsl_ms=%.3f obscura_ms=%.3f ratio=%.2f\n", pt->name,
                           stage_names[stage], p + 1, sg[p], so[p], sr[p]);
            }
            if (!ok) {
                rc = 5;
                break;
            }
            const double mg = median(sg, pairs), mo = median(so, pairs);
            const double mr = median(sr, pairs); /* sorts sr: sr[0] and sr[pairs - 1] are the extremes */
            printf("SUMMARY pass=%s stage=%s variant=\"%s\" size=%dx%d threads=%d glsl_ms=%.2f obscura_ms=%.2f "
                   "ratio=%.2f ratio_min=%.2f ratio_max=%.2f\n",
                   pt->name, stage_names[stage], pt->variant, W, H, threads, mg, mo, mr, sr[0], sr[pairs - 1]);
            fflush(stdout);
        }
        obs_image_f32_free(&bout);
        obs_image_f32_free(&kout);
        glh_run_free(&g, &r);
    }
    free(t), free(sg), free(so), free(sr);
    rast_gbuffer_free(&gb);
    obs_scene_free(&s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
    glh_close(&g);
    return rc;
}
