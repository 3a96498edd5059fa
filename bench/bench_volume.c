/* bench_volume.c: the cost of the volume ray caster (issue 15; docs/volume/raycast.md, "Cost").
 *
 *   obscura_bench_volume [--synth bucky|sphere|slab|box] [--n 256] [--file PATH] [--tf bucky]
 *                        [--shading ea|phong|lightvolume] [--step 0] [--brick 8] [--et 0.99]
 *                        [--threads 2] [--reps 3] [--size 1920x1080] [--sweep]
 *                        [--lv-only] [--light X,Y,Z] [--blend 0|1] [--scale 1|2|4] [--cone DEG]
 *
 * Ray casts a synthetic volume (vol_synth, n^3, default the bucky at 256^3) with a transfer-function
 * preset (or a file io_volume_load reads, e.g. the head CT as NRRD with --tf ct-skin), from a fixed
 * perspective camera that frames it (the volume fills most of the image), at
 * --size. After one warm-up, REPS timed repetitions; the RESULT line gives the median (min, max) in
 * ms, the samples read, skipped and composited, and the rate of samples read per second. With
 * --shading lightvolume the light volume (vol_lv_params_default) is built once first and its build
 * time printed; the ray casts reuse it.
 * --sweep times the brick sizes {0, 4, 8, 16} and the early-termination thresholds {1, 0.99, 0.95}
 * (one RESULT line each). Wall clock (CLOCK_MONOTONIC): on a shared machine, take the minimum.
 * --lv-only times vol_light_volume_build alone (issue 15 item 11: 256^3, a directional light, the
 * default 45-degree cone, 2 threads: <= 25 ms): one warm-up build, then REPS timed builds; the RESULT
 * line gives the median (min, max) in ms and ns per light-volume voxel. --light sets the directional
 * light's travel direction (default -0.4,-0.7,-0.6, normalised; 0,0,1 is the bar's axis-aligned
 * light with its 3x3 cone), --blend, --scale and --cone the vol_lv_params. */
#include "core/obs.h"
#include "io/io.h"
#include "volume/vol.h"
#include "volume/vol_raycast_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

typedef struct bench {
    obs_context *ctx;
    obs_pool *pool;
    vol_grid g;
    vol_tf tf;
    vol_light light;
    vol_light_volume lv;
    int have_lv;
    obs_camera cam;
    int W, H, reps;
} bench;

static void die(bench *b)
{
    fprintf(stderr, "obscura_bench_volume: %s\n", obs_context_last_error(b->ctx));
    exit(1);
}

static void run_one(bench *b, const vol_rc_params *p, const char *label)
{
    obs_image_f32 out[4];
    vol_i_rc_stats st;
    /* warm-up */
    if (vol_i_rc_raycast_stats(b->ctx, b->pool, &b->g, &b->tf, &b->light, b->have_lv ? &b->lv : NULL, &b->cam, b->W, b->H, NULL, p, out,
                               &st) != OBS_STATUS_OK)
        die(b);
    for (int c = 0; c < 4; c++)
        obs_image_f32_free(&out[c]);
    double *ms = (double *)malloc(sizeof(double) * (size_t)b->reps);
    for (int r = 0; r < b->reps; r++) {
        double t0 = now_ms();
        if (vol_raycast(b->ctx, b->pool, &b->g, &b->tf, &b->light, b->have_lv ? &b->lv : NULL, &b->cam, b->W, b->H, NULL, p, out) !=
            OBS_STATUS_OK)
            die(b);
        ms[r] = now_ms() - t0;
        for (int c = 0; c < 4; c++)
            obs_image_f32_free(&out[c]);
    }
    qsort(ms, (size_t)b->reps, sizeof(double), cmp_double);
    double med = b->reps % 2 ? ms[b->reps / 2] : 0.5 * (ms[b->reps / 2 - 1] + ms[b->reps / 2]);
    printf("RESULT %-28s %s brick %2d et %.2f step %.3g: %9.1f ms (min %.1f, max %.1f); rays %lld, samples read "
           "%lld, skipped %lld, composited %lld, terminated %lld; %.1f M samples read/s; bricks empty %lld/%lld\n",
           label, vol_shading_name(p->shading), p->brick, p->early_termination, p->step, med, ms[0], ms[b->reps - 1],
           (long long)st.rays, (long long)st.samples, (long long)st.samples_skipped, (long long)st.samples_shaded,
           (long long)st.rays_terminated, st.samples / (ms[0] * 1e3), (long long)st.bricks_empty,
           (long long)st.bricks);
    fflush(stdout);
    free(ms);
}

int main(int argc, char **argv)
{
    bench b;
    memset(&b, 0, sizeof b);
    const char *synth = "bucky", *tfname = NULL, *file = NULL;
    int n = 256, threads = 2, sweep = 0, lv_only = 0;
    double ldir[3] = {-0.4, -0.7, -0.6};
    vol_lv_params lp = vol_lv_params_default();
    b.W = 1920;
    b.H = 1080;
    b.reps = 3;
    vol_rc_params p = vol_rc_params_default();
    p.shading = VOL_SHADING_PHONG;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--sweep")) {
            sweep = 1;
            continue;
        }
        if (!strcmp(a, "--lv-only")) {
            lv_only = 1;
            continue;
        }
        if (!v) {
            fprintf(stderr, "obscura_bench_volume: %s needs a value (see the file's head for usage)\n", a);
            return 2;
        }
        i++;
        if (!strcmp(a, "--synth"))
            synth = v;
        else if (!strcmp(a, "--file"))
            file = v;
        else if (!strcmp(a, "--n"))
            n = atoi(v);
        else if (!strcmp(a, "--tf"))
            tfname = v;
        else if (!strcmp(a, "--shading")) {
            if (!vol_shading_from_name(v, &p.shading)) {
                fprintf(stderr, "obscura_bench_volume: --shading ea, phong or lightvolume\n");
                return 2;
            }
        } else if (!strcmp(a, "--step"))
            p.step = atof(v);
        else if (!strcmp(a, "--brick"))
            p.brick = atoi(v);
        else if (!strcmp(a, "--et"))
            p.early_termination = atof(v);
        else if (!strcmp(a, "--light")) {
            if (sscanf(v, "%lf,%lf,%lf", &ldir[0], &ldir[1], &ldir[2]) != 3) {
                fprintf(stderr, "obscura_bench_volume: --light X,Y,Z\n");
                return 2;
            }
        } else if (!strcmp(a, "--blend"))
            lp.blend_second = atoi(v);
        else if (!strcmp(a, "--scale"))
            lp.scale = atoi(v);
        else if (!strcmp(a, "--cone"))
            lp.cone_angle_deg = atof(v);
        else if (!strcmp(a, "--threads"))
            threads = atoi(v);
        else if (!strcmp(a, "--reps"))
            b.reps = atoi(v) > 0 ? atoi(v) : 1;
        else if (!strcmp(a, "--size")) {
            if (sscanf(v, "%dx%d", &b.W, &b.H) != 2) {
                fprintf(stderr, "obscura_bench_volume: --size WxH\n");
                return 2;
            }
        } else {
            fprintf(stderr, "obscura_bench_volume: unknown option %s\n", a);
            return 2;
        }
    }
    b.ctx = obs_context_create();
    b.pool = obs_pool_create(threads);
    if (!b.ctx || !b.pool)
        return 1;
    double t0 = now_ms();
    if (file) {
        io_volume_options vo = io_volume_options_default();
        if (io_volume_load(b.ctx, file, &vo, &b.g) != OBS_STATUS_OK)
            die(&b);
        synth = "file";
    } else if (vol_synth(b.ctx, synth, n, &b.g) != OBS_STATUS_OK) {
        die(&b);
    }
    vol_grid_update_range(&b.g);
    double t_synth = now_ms() - t0;
    if (!tfname)
        tfname = !strcmp(synth, "bucky") ? "bucky" : NULL;
    if (tfname) {
        if (vol_tf_preset(b.ctx, tfname, &b.tf) != OBS_STATUS_OK)
            die(&b);
    } else {
        /* sphere, slab, box: values in [0, 1] */
        static vol_tf_point pts[3] = {{0.4, {0, 0, 0, 0}}, {0.7, {0.9f, 0.6f, 0.3f, 0.1f}}, {1.0, {1, 1, 1, 0.5f}}};
        strcpy(b.tf.name, "bench");
        b.tf.count = 3;
        b.tf.points = pts;
    }
    /* A light from the upper right front; a camera framing the box (vol_synth centres it on 0). */
    b.light.type = OBS_LIGHT_DIRECTIONAL;
    double l = sqrt(ldir[0] * ldir[0] + ldir[1] * ldir[1] + ldir[2] * ldir[2]);
    for (int a = 0; a < 3; a++)
        b.light.direction[a] = ldir[a] / l;
    b.light.color[0] = b.light.color[1] = b.light.color[2] = 1.0f;
    /* The box's centre and half diagonal: for vol_synth (centred on 0, n^3) the camera is at
     * (1.3, 0.9, 2.6) x n/2. */
    double lo[3], hi[3];
    vol_grid_bounds(&b.g, lo, hi);
    float ctr[3], r = 0.0f;
    for (int a = 0; a < 3; a++) {
        ctr[a] = (float)(0.5 * (lo[a] + hi[a]));
        float e = (float)(0.5 * (hi[a] - lo[a]));
        r = e > r ? e : r;
    }
    b.cam = obs_camera_look_at(obs_v3(ctr[0] + 1.3f * r, ctr[1] + 0.9f * r, ctr[2] + 2.6f * r),
                               obs_v3(ctr[0], ctr[1], ctr[2]), obs_v3(0, 1, 0), 0.7f, 0.01f * r, 100.0f * r);
    printf("# obscura_bench_volume: %s %dx%dx%d (made/loaded in %.0f ms), TF %s, %dx%d, %d threads, %d reps\n",
           file ? file : synth, b.g.nx, b.g.ny, b.g.nz, t_synth,
           tfname ? tfname : "bench", b.W, b.H, threads, b.reps);
    if (lv_only) {
        double *ms = (double *)malloc(sizeof(double) * (size_t)(b.reps + 1));
        for (int r = 0; r <= b.reps; r++) { /* r = 0: the warm-up */
            double tl = now_ms();
            if (vol_light_volume_build(b.ctx, b.pool, &b.g, &b.tf, &b.light, &lp, &b.lv) != OBS_STATUS_OK)
                die(&b);
            ms[r] = now_ms() - tl;
            if (r == 0)
                printf("# light volume %dx%dx%d, light (%.3f, %.3f, %.3f), faces %d/%d, blend weight %.3f, scale %d, "
                       "cone %g\n", b.lv.nx, b.lv.ny, b.lv.nz, b.light.direction[0], b.light.direction[1],
                       b.light.direction[2], b.lv.face0, b.lv.face1, b.lv.blend_weight, lp.scale, lp.cone_angle_deg);
            vol_light_volume_free(&b.lv);
        }
        qsort(ms + 1, (size_t)b.reps, sizeof(double), cmp_double);
        double med = b.reps % 2 ? ms[1 + b.reps / 2] : 0.5 * (ms[b.reps / 2] + ms[1 + b.reps / 2]);
        double vox = (double)((b.g.nx + lp.scale - 1) / lp.scale) * ((b.g.ny + lp.scale - 1) / lp.scale) *
                     ((b.g.nz + lp.scale - 1) / lp.scale);
        printf("RESULT lightvolume %s%d threads %d: %9.1f ms (min %.1f, max %.1f); %.1f ns per voxel (median)\n", synth,
               b.g.nx, threads, med, ms[1], ms[b.reps], med * 1e6 / vox);
        free(ms);
        if (tfname)
            vol_tf_free(&b.tf);
        vol_grid_free(&b.g);
        obs_pool_destroy(b.pool);
        obs_context_destroy(b.ctx);
        return 0;
    }
    if (p.shading == VOL_SHADING_LIGHT_VOLUME) {
        double tl = now_ms();
        if (vol_light_volume_build(b.ctx, b.pool, &b.g, &b.tf, &b.light, &lp, &b.lv) != OBS_STATUS_OK)
            die(&b);
        b.have_lv = 1;
        printf("# light volume %dx%dx%d built in %.1f ms (defaults, %d threads)\n", b.lv.nx, b.lv.ny, b.lv.nz,
               now_ms() - tl, threads);
    }
    char label[64];
    snprintf(label, sizeof label, "%s%d", synth, b.g.nx);
    if (!sweep) {
        run_one(&b, &p, label);
    } else {
        const int bricks[] = {0, 4, 8, 16};
        for (int i = 0; i < 4; i++) {
            vol_rc_params q = p;
            q.brick = bricks[i];
            run_one(&b, &q, label);
        }
        const double ets[] = {1.0, 0.95};
        for (int i = 0; i < 2; i++) {
            vol_rc_params q = p;
            q.early_termination = ets[i];
            run_one(&b, &q, label);
        }
        vol_rc_params q = p;
        q.shading = VOL_SHADING_EMISSION_ABSORPTION;
        run_one(&b, &q, label);
    }
    if (b.have_lv)
        vol_light_volume_free(&b.lv);
    if (tfname)
        vol_tf_free(&b.tf);
    vol_grid_free(&b.g);
    obs_pool_destroy(b.pool);
    obs_context_destroy(b.ctx);
    return 0;
}
