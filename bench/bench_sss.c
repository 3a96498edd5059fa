/* bench_sss.c: the cost of the scattering maps (issue 14, "Speed"; docs/performance.md).
 *
 *   obscura_bench_sss [SCENE] [--K 16] [--N 48] [--map-size 512] [--light-map-size 512]
 *                     [--sampler NAME] [--threads 2] [--reps 7] [--size 1920x1080]
 *                     [--sweep [--no-largest]] [--views 8]
 *
 * SCENE defaults to build/data/bunny_cream.glb (the bunny, 75k triangles, 30 cm, in cream, its
 * key light). After one warm-up, REPS timed repetitions of:
 *   light  = sss_light_map_render for every light (the light G-buffers);
 *   maps   = sss_maps_build (the K views' rasterization and the gather), fresh storage;
 *   rebuild = sss_maps_rebuild of the same maps into the storage of the previous repetition's, with
 *            a kept sss_maps_workspace: what a scene change costs when the maps' storage is kept, as
 *            the GPU keeps its framebuffers and texture arrays (the seed's 543.5 ms for 16 cameras
 *            reuses them). The bar, <= 150 ms for the bunny at K = 16, N = 48, 512^2 on 2
 *            threads, is judged on the rebuild (BAR line); maps_rebuild_minflt counts the process's
 *            minor page faults during the rebuilds (median), rebuild_same_bytes compares the
 *            last rebuild with the last build byte for byte, and maps_cpu_ms /
 *            maps_rebuild_cpu_ms are the process's CPU ms (user + system, all threads) of each,
 *            less sensitive to a shared machine than the wall clock;
 *   camera = the camera's G-buffer (rast_render) at --size;
 *   comb   = sss_combine for that camera (a fixed scene: the maps reused).
 * RESULT lines give the medians (min, max) in ms, the BSSRDF evaluations and their rate.
 * --views V also times V camera views that reuse one set of maps ("8 views cost about one map
 *  build plus 8 cheap combinations", issue 16), each view a different Halton direction.
 * --dump PREFIX writes the last repetition's maps (PREFIX.maps.f32: 3K planes of size^2 floats) and
 *  combination (PREFIX.comb.f32: 3 planes) as raw floats, to compare the output bits of two builds
 *  with cmp (docs/sss/maps.md, "Cost").
 * --warmup 0 skips the warm-up (for callgrind: one build under the tool).
 * --isa scalar|avx2 picks the maps' and kernels' ISA (default auto).
 * --sweep (or --growth) times the maps over K in {4, 8, 16, 32} (N 48, 512^2), N in {16, 48, 128}
 * (K 16, 512^2) and map size in {256, 512, 1024} (K 16, N 48), for the exponential and the Russian
 * roulette samplers (only --sampler's if given): each point the light maps (untimed), a warm-up
 * build, then the median of REPS builds (default 3 with --sweep). One SWEEP line per point, then
 * per axis a table (median, min, max, ns per texel-sample = ms / (K size^2 N), the fitted time and
 * the relative residual) and a FIT line: the least-squares line t = a + b x with R^2 (x = K, N or
 * the texel count size^2): the cost growth, expected linear in K, in N and in the map's area
 * (docs/results/cost-growth.md). --no-largest drops K 32, N 128 and 1024^2 (a quick check). */
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "sss/sss.h"

#include "bench_scene.h"

#include <math.h>
#include <sys/resource.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static long minflt_now(void)
{
    struct rusage ru;
    return getrusage(RUSAGE_SELF, &ru) == 0 ? ru.ru_minflt : 0;
}

/* The process's CPU seconds (user + system, all threads): less sensitive than the wall clock to
 * other processes on a shared machine (it still counts their cache and SMT contention). */
static double cpu_now(void)
{
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0)
        return 0.0;
    return (double)ru.ru_utime.tv_sec + 1e-6 * ru.ru_utime.tv_usec + (double)ru.ru_stime.tv_sec +
           1e-6 * ru.ru_stime.tv_usec;
}

/* The radiance planes and view depths of two maps, byte for byte. */
static int maps_same_bytes(const sss_maps *a, const sss_maps *b)
{
    if (a->K != b->K || a->size != b->size)
        return 0;
    const size_t row = sizeof(float) * (size_t)a->size;
    for (int k = 0; k < a->K; k++)
        for (int y = 0; y < a->size; y++) {
            if (memcmp(obs_image_f32_row(&a->views[k].depth, y), obs_image_f32_row(&b->views[k].depth, y), row))
                return 0;
            for (int c = 0; c < 3; c++)
                if (memcmp(obs_image_f32_row(&a->radiance[3 * k + c], y), obs_image_f32_row(&b->radiance[3 * k + c], y),
                           row))
                    return 0;
        }
    return 1;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

typedef struct bench {
    obs_context *ctx;
    obs_pool *pool;
    obs_scene scene;
    sss_scene_setup setup;
    obs_camera cam;
    int W, H;
} bench;

static void die_status(bench *b, obs_status st)
{
    fprintf(stderr, "obscura_bench_sss: %s\n", obs_context_last_error(b->ctx));
    exit(st == OBS_STATUS_OK ? 0 : 1);
}

/* One maps build at p (light maps rendered first, untimed here); returns its milliseconds. */
static double time_maps(bench *b, const sss_params *p, sss_light_map *lm, uint64_t *evals)
{
    sss_maps maps;
    memset(&maps, 0, sizeof maps);
    double t0 = obs_time_now();
    obs_status st = sss_maps_build(b->ctx, b->pool, &b->scene, &b->setup.mats, lm, (int)b->scene.light_count, p, &maps);
    double ms = 1e3 * (obs_time_now() - t0);
    if (st != OBS_STATUS_OK)
        die_status(b, st);
    if (evals)
        *evals = maps.samples_evaluated;
    sss_maps_free(&maps);
    return ms;
}

static void render_light_maps(bench *b, const sss_params *p, sss_light_map *lm)
{
    for (uint32_t l = 0; l < b->scene.light_count; l++) {
        obs_status st = sss_light_map_render(b->ctx, b->pool, &b->scene, &b->scene.lights[l], p, &lm[l]);
        if (st != OBS_STATUS_OK)
            die_status(b, st);
    }
}

static void free_light_maps(bench *b, sss_light_map *lm)
{
    for (uint32_t l = 0; l < b->scene.light_count; l++)
        sss_light_map_free(&lm[l]);
}

/* ---- --sweep: the cost growth of the maps (issue 14, section 8; docs/results/cost-growth.md) ---- */
typedef struct sweep_done {
    sss_sampler sampler;
    int K, N, S;
    bench_point pt;
    uint64_t evals;
} sweep_done;

/* One configuration: the light maps (untimed), a warm-up build (unless --warmup 0), then REPS timed
 * builds; the median, minimum and maximum in pt, the BSSRDF evaluations of the last build. */
static void sweep_point(bench *b, const sss_params *p, int reps, int warmup, bench_point *pt, uint64_t *evals)
{
    sss_light_map lm[8];
    memset(lm, 0, sizeof lm);
    render_light_maps(b, p, lm);
    if (warmup)
        time_maps(b, p, lm, NULL);
    double t[64];
    for (int r = 0; r < reps; r++)
        t[r] = time_maps(b, p, lm, evals);
    free_light_maps(b, lm);
    pt->ms = median(t, reps); /* sorts t */
    pt->ms_min = t[0];
    pt->ms_max = t[reps - 1];
}

/* One axis (0: K, 1: N, 2: the map side) over VALS, the other two at BASE's; a configuration
 * already measured on an earlier axis (the base point) is reused, not timed again. Prints one
 * SWEEP line per point as it is measured, then the table and the fit (bench_growth_print). */
static void sweep_axis(bench *b, const sss_params *base, int axis, const int *vals, int n, int reps, int warmup,
                       sweep_done *done, int *ndone)
{
    static const char *const names[3] = {"K", "N", "map_size"};
    bench_point pt[8];
    for (int i = 0; i < n; i++) {
        sss_params p = *base;
        if (axis == 0) p.K = vals[i];
        else if (axis == 1) p.N = vals[i];
        else p.map_size = vals[i];
        const double texels = (double)p.map_size * p.map_size;
        pt[i].param = vals[i];
        pt[i].x = axis == 2 ? texels : vals[i];
        pt[i].units = p.K * texels * p.N; /* texel-samples: K maps of size^2 texels, N samples each */
        uint64_t evals = 0;
        int j = 0, reused = 0;
        for (; j < *ndone; j++)
            if (done[j].sampler == p.sampler && done[j].K == p.K && done[j].N == p.N && done[j].S == p.map_size)
                break;
        if (j < *ndone) {
            reused = 1;
            pt[i].ms = done[j].pt.ms;
            pt[i].ms_min = done[j].pt.ms_min;
            pt[i].ms_max = done[j].pt.ms_max;
            evals = done[j].evals;
        } else {
            sweep_point(b, &p, reps, warmup, &pt[i], &evals);
            if (*ndone < 32) {
                done[*ndone] = (sweep_done){p.sampler, p.K, p.N, p.map_size, pt[i], evals};
                (*ndone)++;
            }
        }
        printf("SWEEP axis=%s value=%d K=%d N=%d map_size=%d maps_median_ms=%.2f maps_min_ms=%.2f maps_max_ms=%.2f "
               "sampler=%s bssrdf_evals=%llu ns_per_texel_sample=%.4g%s\n",
               names[axis], vals[i], p.K, p.N, p.map_size, pt[i].ms, pt[i].ms_min, pt[i].ms_max,
               sss_sampler_name(p.sampler), (unsigned long long)evals, pt[i].ms * 1e6 / pt[i].units,
               reused ? " reused=1" : "");
        fflush(stdout);
    }
    char tag[128];
    snprintf(tag, sizeof tag, "sss sampler=%s axis=%s", sss_sampler_name(base->sampler), names[axis]);
    bench_growth_print(tag, names[axis], axis == 2 ? "texels" : names[axis], "K map_size^2 N texel-samples", pt, n);
}

int main(int argc, char **argv)
{
    const char *scene_path = "build/data/bunny_cream.glb";
    sss_params p = sss_params_default();
    int threads = 2, reps = 7, sweep = 0, views = 0, warmup = 1, reps_set = 0, sampler_set = 0, no_largest = 0;
    const char *dump = NULL;
    bench b;
    memset(&b, 0, sizeof b);
    b.W = 1920;
    b.H = 1080;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--K") && v) p.K = atoi(argv[++i]);
        else if (!strcmp(a, "--N") && v) p.N = atoi(argv[++i]);
        else if (!strcmp(a, "--map-size") && v) p.map_size = atoi(argv[++i]);
        else if (!strcmp(a, "--light-map-size") && v) p.light_map_size = atoi(argv[++i]);
        else if (!strcmp(a, "--threads") && v) threads = atoi(argv[++i]);
        else if (!strcmp(a, "--reps") && v) reps = atoi(argv[++i]), reps_set = 1;
        else if (!strcmp(a, "--views") && v) views = atoi(argv[++i]);
        else if (!strcmp(a, "--sweep") || !strcmp(a, "--growth")) sweep = 1;
        else if (!strcmp(a, "--no-largest")) no_largest = 1;
        else if (!strcmp(a, "--dump") && v) dump = argv[++i];
        else if (!strcmp(a, "--warmup") && v) warmup = atoi(argv[++i]) != 0;
        else if (!strcmp(a, "--isa") && v) {
            const char *n = argv[++i];
            p.isa = !strcmp(n, "scalar") ? SSS_ISA_SCALAR : !strcmp(n, "avx2") ? SSS_ISA_AVX2 : SSS_ISA_AUTO;
        }
        else if (!strcmp(a, "--size") && v) {
            if (sscanf(argv[++i], "%dx%d", &b.W, &b.H) != 2) return 2;
        } else if (!strcmp(a, "--sampler") && v) {
            if (!sss_sampler_from_name(argv[++i], &p.sampler)) {
                fprintf(stderr, "obscura_bench_sss: unknown sampler '%s'\n", argv[i]);
                return 2;
            }
            sampler_set = 1;
        } else if (a[0] != '-') scene_path = a;
        else {
            fprintf(stderr, "usage: obscura_bench_sss [SCENE] [--K K] [--N N] [--map-size S] [--light-map-size S] "
                            "[--sampler NAME] [--threads T] [--reps R] [--size WxH] [--views V] [--sweep [--no-largest]]\n");
            return 2;
        }
    }
    if (sweep && !reps_set)
        reps = 3; /* the sweep's default R (docs/results/cost-growth.md: about 3 minutes in all, idle) */
    if (reps < 1 || reps > 64 || views < 0 || views > 64) return 2;
    b.ctx = obs_context_create();
    b.pool = obs_pool_create(threads);
    obs_scene_init(&b.scene);
    io_gltf_options go = io_gltf_options_default();
    obs_status st = io_gltf_load(b.ctx, scene_path, &go, &b.scene);
    if (st == OBS_STATUS_OK)
        st = sss_params_validate(b.ctx, &p);
    if (st == OBS_STATUS_OK)
        st = sss_scene_setup_make(b.ctx, &b.scene, NULL, SSS_DEFAULT_MM_PER_UNIT, &b.setup);
    if (st != OBS_STATUS_OK)
        die_status(&b, st);
    if (b.scene.light_count == 0 || b.scene.camera_count == 0 || b.scene.light_count > 8) {
        fprintf(stderr, "obscura_bench_sss: %s needs 1..8 lights and a camera\n", scene_path);
        return 1;
    }
    b.cam = b.scene.cameras[0];
    printf("# obscura_bench_sss %s: %llu triangles, %u light(s), threads=%d reps=%d, model=%s sampler=%s\n", scene_path,
           (unsigned long long)obs_scene_triangle_count(&b.scene), b.scene.light_count, obs_pool_threads(b.pool), reps,
           sss_model_name(p.model), sss_sampler_name(p.sampler));
    if (sweep) {
        /* Issue 14, section 8: K in {4, 8, 16, 32} at N 48, 512^2; N in {16, 48, 128} at K 16, 512^2;
         * map side in {256, 512, 1024} at K 16, N 48 (the fixed values are --K, --N, --map-size);
         * both samplers unless --sampler names one. --no-largest drops each axis's last value. */
        static const int Ks[] = {4, 8, 16, 32}, Ns[] = {16, 48, 128}, Ss[] = {256, 512, 1024};
        const sss_sampler samplers[2] = {SSS_SAMPLER_EXPONENTIAL, SSS_SAMPLER_RUSSIAN_ROULETTE};
        const int nsamplers = sampler_set ? 1 : 2, drop = no_largest ? 1 : 0;
        sweep_done done[32];
        int ndone = 0;
        const double t0 = obs_time_now();
        printf("# sweep: the maps' build (sss_maps_build; light maps untimed), median of %d after %s; K, N, map size; "
               "fixed K %d, N %d, map %d^2, light map %d^2\n",
               reps, warmup ? "one warm-up build" : "no warm-up", p.K, p.N, p.map_size, p.light_map_size);
        for (int s = 0; s < nsamplers; s++) {
            sss_params q = p;
            if (!sampler_set)
                q.sampler = samplers[s];
            sweep_axis(&b, &q, 0, Ks, 4 - drop, reps, warmup, done, &ndone);
            sweep_axis(&b, &q, 1, Ns, 3 - drop, reps, warmup, done, &ndone);
            sweep_axis(&b, &q, 2, Ss, 3 - drop, reps, warmup, done, &ndone);
        }
        printf("# sweep: %.1f s in all\n", obs_time_now() - t0);
        sss_scene_setup_free(&b.setup);
        obs_scene_free(&b.scene);
        obs_pool_destroy(b.pool);
        obs_context_destroy(b.ctx);
        return 0;
    }
    /* ---- One configuration: light maps, maps, camera G-buffer, combination ---- */
    rast_params rp = rast_params_default();
    rp.width = b.W;
    rp.height = b.H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_MATERIAL_ID | RAST_OUT_INSTANCE_ID;
    rp.face_forward = 0;
    rast_gbuffer gb;
    if (rast_gbuffer_alloc(b.ctx, &rp, &gb) != OBS_STATUS_OK)
        die_status(&b, OBS_STATUS_OUT_OF_MEMORY);
    double tl[64], tm[64], tc[64], tb[64], tr[64], fr[64], cm[64], cr[64];
    uint64_t evals = 0;
    int same_bytes = -1;
    sss_maps rmaps; /* the rebuilt maps: storage kept across repetitions */
    memset(&rmaps, 0, sizeof rmaps);
    sss_maps_workspace *rws = sss_maps_workspace_create();
    if (!rws)
        die_status(&b, OBS_STATUS_OUT_OF_MEMORY);
    for (int r = warmup ? -1 : 0; r < reps; r++) {
        sss_light_map lm[8];
        memset(lm, 0, sizeof lm);
        double t0 = obs_time_now();
        render_light_maps(&b, &p, lm);
        double t1 = obs_time_now();
        const double c1 = cpu_now();
        sss_maps maps;
        memset(&maps, 0, sizeof maps);
        st = sss_maps_build(b.ctx, b.pool, &b.scene, &b.setup.mats, lm, (int)b.scene.light_count, &p, &maps);
        double t2 = obs_time_now();
        const double c2 = cpu_now();
        const long f0 = minflt_now();
        const double tr0 = obs_time_now();
        if (st == OBS_STATUS_OK)
            st = sss_maps_rebuild(b.ctx, b.pool, &b.scene, &b.setup.mats, lm, (int)b.scene.light_count, &p, rws, &rmaps);
        const double tr1 = obs_time_now();
        const double c3 = cpu_now();
        const long f1 = minflt_now();
        if (st == OBS_STATUS_OK && r == reps - 1)
            same_bytes = maps_same_bytes(&maps, &rmaps) && maps.samples_evaluated == rmaps.samples_evaluated;
        if (r >= 0) {
            tr[r] = 1e3 * (tr1 - tr0);
            fr[r] = (double)(f1 - f0);
            cm[r] = 1e3 * (c2 - c1);
            cr[r] = 1e3 * (c3 - c2);
        }
        const double t2b = obs_time_now(); /* the camera's G-buffer is timed from here */
        rast_view view = {b.cam};
        if (st == OBS_STATUS_OK)
            st = rast_render(b.ctx, b.pool, &b.scene, &view, 1, &rp, &gb, NULL);
        double t3 = obs_time_now();
        obs_image_f32 out[3] = {{0}};
        if (st == OBS_STATUS_OK)
            st = sss_combine(b.ctx, b.pool, &b.scene, &b.setup.mats, &maps, lm, (int)b.scene.light_count, &gb, &b.cam,
                             &p, out, NULL);
        double t4 = obs_time_now();
        if (st != OBS_STATUS_OK)
            die_status(&b, st);
        if (r >= 0) {
            tl[r] = 1e3 * (t1 - t0);
            tm[r] = 1e3 * (t2 - t1);
            tb[r] = 1e3 * (t3 - t2b);
            tc[r] = 1e3 * (t4 - t3);
        }
        evals = maps.samples_evaluated;
        /* ---- Views reusing the maps (last repetition only): the camera orbits the scene's
         * centre about +Y in `views` equal steps; each view = its G-buffer + the combination. ---- */
        if (views > 0 && r == reps - 1) {
            obs_vec3 c = obs_v3_scale(obs_v3_add(b.scene.bounds.lo, b.scene.bounds.hi), 0.5f);
            double tv0 = obs_time_now();
            for (int v = 0; v < views && st == OBS_STATUS_OK; v++) {
                const double th = 2.0 * 3.14159265358979323846 * v / views;
                const float q[4] = {0.0f, (float)sin(0.5 * th), 0.0f, (float)cos(0.5 * th)};
                obs_mat4 rot = obs_mat4_from_quat((obs_vec4){q[0], q[1], q[2], q[3]});
                obs_mat4 w = obs_mat4_mul(obs_mat4_translation(c),
                                          obs_mat4_mul(rot, obs_mat4_mul(obs_mat4_translation(obs_v3_scale(c, -1.0f)),
                                                                         b.cam.world)));
                obs_camera cv = b.cam;
                obs_camera_set_world(&cv, w);
                rast_view vv = {cv};
                obs_image_f32 o2[3] = {{0}};
                st = rast_render(b.ctx, b.pool, &b.scene, &vv, 1, &rp, &gb, NULL);
                if (st == OBS_STATUS_OK)
                    st = sss_combine(b.ctx, b.pool, &b.scene, &b.setup.mats, &maps, lm, (int)b.scene.light_count, &gb,
                                     &cv, &p, o2, NULL);
                for (int k = 0; k < 3; k++)
                    obs_image_f32_free(&o2[k]);
            }
            double tv = 1e3 * (obs_time_now() - tv0);
            if (st != OBS_STATUS_OK)
                die_status(&b, st);
            printf("VIEWS views=%d maps_ms=%.2f views_total_ms=%.2f per_view_ms=%.2f total_ms=%.2f "
                   "(one map build + %d camera G-buffers and combinations)\n",
                   views, tm[r], tv, tv / views, tl[r] + tm[r] + tv, views);
        }
        if (dump && r == reps - 1) {
            char fn[1024];
            snprintf(fn, sizeof fn, "%s.maps.f32", dump);
            FILE *f = fopen(fn, "wb");
            for (int i = 0; f && i < 3 * maps.K; i++)
                for (int y = 0; y < maps.size; y++)
                    fwrite(obs_image_f32_row(&maps.radiance[i], y), sizeof(float), (size_t)maps.size, f);
            if (f)
                fclose(f);
            snprintf(fn, sizeof fn, "%s.comb.f32", dump);
            f = fopen(fn, "wb");
            for (int c = 0; f && c < 3; c++)
                for (int y = 0; y < out[c].height; y++)
                    fwrite(obs_image_f32_row(&out[c], y), sizeof(float), (size_t)out[c].width, f);
            if (f)
                fclose(f);
        }
        for (int c = 0; c < 3; c++)
            obs_image_f32_free(&out[c]);
        sss_maps_free(&maps);
        free_light_maps(&b, lm);
    }
    sss_maps_free(&rmaps);
    sss_maps_workspace_free(rws);
    const double mr = median(tr, reps), mf = median(fr, reps); /* sorts tr */
    const double mcm = median(cm, reps), mcr = median(cr, reps);
    double ml = median(tl, reps), mm = median(tm, reps), mb = median(tb, reps), mc = median(tc, reps);
    printf("RESULT sss scene=%s K=%d N=%d map_size=%d light_map_size=%d size=%dx%d threads=%d light_ms=%.2f maps_ms=%.2f "
           "camera_gbuffer_ms=%.2f combine_ms=%.2f rebuilt_ms=%.2f fixed_scene_ms=%.2f bssrdf_evals=%llu "
           "mevals_per_s=%.1f maps_min_ms=%.2f maps_max_ms=%.2f\n",
           scene_path, p.K, p.N, p.map_size, p.light_map_size, b.W, b.H, obs_pool_threads(b.pool), ml, mm, mb, mc,
           ml + mm + mb + mc, mb + mc, (unsigned long long)evals, mm > 0 ? (double)evals / (mm * 1e3) : 0.0, tm[0],
           tm[reps - 1]);
    printf("REBUILD maps_rebuild_ms=%.2f maps_rebuild_min_ms=%.2f maps_rebuild_max_ms=%.2f maps_rebuild_minflt=%.0f "
           "rebuild_same_bytes=%d maps_ms=%.2f maps_cpu_ms=%.2f maps_rebuild_cpu_ms=%.2f (sss_maps_rebuild into kept "
           "storage with a kept workspace vs sss_maps_build into fresh storage; cpu = user + system of all threads)\n",
           mr, tr[0], tr[reps - 1], mf, same_bytes, mm, mcm, mcr);
    printf("BAR maps_rebuild_ms=%.2f bar_ms=150 (bunny, K=16, N=48, 512^2, 2 threads; the rebuild into kept storage, "
           "as the GPU figure reuses its framebuffers; fresh build maps_ms=%.2f) %s\n",
           mr, mm, mr <= 150.0 ? "met" : "NOT met");
    rast_gbuffer_free(&gb);
    sss_scene_setup_free(&b.setup);
    obs_scene_free(&b.scene);
    obs_pool_destroy(b.pool);
    obs_context_destroy(b.ctx);
    return 0;
}
