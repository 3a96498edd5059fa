/* bench_truth.c: throughput of the AO ground truth against raw Embree on the same rays.
 *
 *   obscura_bench_truth [MESH...] [--size WxH] [--spp N] [--threads 2] [--reps R] [--radius-frac F]
 *                       [--tile T] [--layout auto|flat|instanced] [--raw-build low|medium|high]
 *
 * MESH is a .glb/.gltf (the data generator's bunny.glb, dragon.glb) or an .off file (the CGAL
 * meshes in data/cache); with none, build/data/bunny.glb, else data/cache/bunny00.off. Each mesh is
 * framed as bench.c frames it (bounding-box centre at the origin, farthest vertex at radius 10,
 * camera at (0, 0, 10/sin(22.5 deg)) looking down -Z, fovy 45 degrees), rasterized once, and then:
 *   (a) pipeline: truth_ao_render with the cosine estimator, r = F x 10 (F = 0.1), exactly N
 *       samples per hit pixel (min = max = batch = N = 16), 8x8 tiles: one rtcOccluded1M call of
 *       64 x 16 rays per tile, on the truth scene of truth_scene_create_ex (--layout, default
 *       auto: flat); the whole call is timed (setup, sampling, tracing, accumulation, planes);
 *   (b) raw: the very same rays, captured from the pipeline once through its ray-sink hook and
 *       stored per tile, traced by a loop of rtcOccluded1M per tile over the same obs_pool (tfar
 *       is reset between runs, untimed), on a FLAT one-level scene built here on its own device:
 *       ONE triangle geometry holding every instance's triangles in world space (the same floats
 *       as the truth scene's), scene flags none, build quality --raw-build (default medium; see
 *       docs/truth.md for why), i.e. Embree's fastest configuration for these rays.
 * (a) and (b) alternate, R times (default 9) per thread count (default 2) after one warm-up pair.
 * The RESULT line gives the medians, the rays per second, the ratio of the medians, and the
 * median of the per-pair ratios raw time / pipeline time, which the RATIO line repeats with the
 * bar (issue 13: >= 0.90) and the scenes' flags and build qualities. The occluded-ray counts of
 * (a) and (b) are printed as a check that the rays and the geometry are the same. */
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "truth/truth.h"
#include "truth/truth_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <xmmintrin.h>

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

/* A minimal OFF reader (triangles and fans of polygons), into a one-mesh scene. */
static int load_off(const char *path, obs_scene *s)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char tag[16];
    unsigned nv, nf, ne;
    if (fscanf(f, "%15s %u %u %u", tag, &nv, &nf, &ne) != 4 || strcmp(tag, "OFF") != 0) {
        fclose(f);
        return 0;
    }
    float *pos = (float *)malloc(sizeof(float) * 3 * nv);
    uint32_t cap = nf * 3, nt = 0;
    uint32_t *idx = (uint32_t *)malloc(sizeof(uint32_t) * 3 * cap);
    for (unsigned v = 0; v < nv; v++)
        if (fscanf(f, "%f %f %f", &pos[3 * v], &pos[3 * v + 1], &pos[3 * v + 2]) != 3)
            goto bad;
    for (unsigned k = 0; k < nf; k++) {
        unsigned n, first, prev, cur;
        if (fscanf(f, "%u %u %u", &n, &first, &prev) != 3 || n < 3)
            goto bad;
        for (unsigned j = 2; j < n; j++) {
            if (fscanf(f, "%u", &cur) != 1 || first >= nv || prev >= nv || cur >= nv)
                goto bad;
            if (nt == cap) {
                cap *= 2;
                idx = (uint32_t *)realloc(idx, sizeof(uint32_t) * 3 * cap);
            }
            idx[3 * nt] = first;
            idx[3 * nt + 1] = prev;
            idx[3 * nt + 2] = cur;
            nt++;
            prev = cur;
        }
    }
    fclose(f);
    obs_scene_init(s);
    s->meshes = (obs_mesh *)calloc(1, sizeof(obs_mesh));
    s->mesh_count = 1;
    strcpy(s->meshes[0].name, "off");
    s->meshes[0].vertex_count = nv;
    s->meshes[0].triangle_count = nt;
    s->meshes[0].positions = pos;
    s->meshes[0].indices = idx;
    s->meshes[0].material = -1;
    s->instances = (obs_instance *)calloc(1, sizeof(obs_instance));
    s->instance_count = 1;
    s->instances[0].world = obs_mat4_identity();
    obs_scene_update_bounds(s);
    snprintf(s->source, sizeof s->source, "%s", path);
    return 1;
bad:
    fclose(f);
    free(pos);
    free(idx);
    return 0;
}

/* bench.c's framing: bounding-box centre to the origin, farthest vertex at radius 10. */
static obs_camera frame_scene(obs_scene *s)
{
    obs_scene_update_bounds(s);
    obs_vec3 c = obs_v3_scale(obs_v3_add(s->bounds.lo, s->bounds.hi), 0.5f);
    double r2 = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const obs_mesh *m = &s->meshes[s->instances[i].mesh];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            obs_vec3 w = obs_mat4_mul_point(s->instances[i].world,
                                            obs_v3(m->positions[3 * v], m->positions[3 * v + 1], m->positions[3 * v + 2]));
            obs_vec3 d = obs_v3_sub(w, c);
            double dd = (double)d.x * d.x + (double)d.y * d.y + (double)d.z * d.z;
            r2 = dd > r2 ? dd : r2;
        }
    }
    float scale = (float)(10.0 / sqrt(r2));
    obs_mat4 fit = obs_mat4_mul(obs_mat4_scale(obs_v3(scale, scale, scale)), obs_mat4_translation(obs_v3_scale(c, -1.0f)));
    for (uint32_t i = 0; i < s->instance_count; i++)
        s->instances[i].world = obs_mat4_mul(fit, s->instances[i].world);
    obs_scene_update_bounds(s);
    const float fovy = (float)(45.0 * OBS_PI / 180.0);
    float dist = 10.0f / sinf(0.5f * fovy);
    return obs_camera_look_at(obs_v3(0, 0, dist), obs_v3(0, 0, 0), obs_v3(0, 1, 0), fovy, fmaxf(dist - 11.0f, 0.5f),
                              dist + 11.0f);
}

/* ---- the raw side's flat scene ---------------------------------------------------------------- */

typedef struct raw_scene {
    RTCDevice device;
    RTCScene scene;
    enum RTCSceneFlags flags;
    enum RTCBuildQuality quality;
} raw_scene;

static const char *quality_name(enum RTCBuildQuality q)
{
    return q == RTC_BUILD_QUALITY_LOW ? "low" : q == RTC_BUILD_QUALITY_HIGH ? "high" : "medium";
}

/* Every instance's triangles in world space (each vertex M v in double, rounded once: the floats
 * truth_scene.c writes), as ONE triangle geometry of a one-level scene. Triangles with a
 * non-finite vertex are dropped. */
static int raw_scene_build(const obs_scene *s, enum RTCBuildQuality q, raw_scene *out)
{
    memset(out, 0, sizeof *out);
    out->flags = RTC_SCENE_FLAG_NONE;
    out->quality = q;
    uint64_t nv = 0, nt = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        nv += s->meshes[s->instances[i].mesh].vertex_count;
        nt += s->meshes[s->instances[i].mesh].triangle_count;
    }
    out->device = rtcNewDevice(NULL);
    if (!out->device || nv > 0xFFFFFFFFu || nt > 0xFFFFFFFFu)
        return 0;
    out->scene = rtcNewScene(out->device);
    rtcSetSceneFlags(out->scene, out->flags);
    rtcSetSceneBuildQuality(out->scene, q);
    RTCGeometry g = rtcNewGeometry(out->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, q);
    float *vb = (float *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 16, nv ? nv : 1);
    unsigned *ib = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt ? nt : 1);
    if (!vb || !ib)
        return 0;
    uint64_t v0 = 0, t = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const obs_mesh *m = &s->meshes[s->instances[i].mesh];
        double M[16];
        for (int k = 0; k < 16; k++)
            M[k] = (double)s->instances[i].world.m[k];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            const float *p = &m->positions[3 * (size_t)v];
            float *w = &vb[4 * (v0 + v)];
            for (int c = 0; c < 3; c++)
                w[c] = (float)(M[c] * p[0] + M[4 + c] * p[1] + M[8 + c] * p[2] + M[12 + c]);
            w[3] = 0.0f;
        }
        for (uint32_t k = 0; k < m->triangle_count; k++) {
            const uint32_t *ix = &m->indices[3 * (size_t)k];
            int finite = 1;
            for (int j = 0; j < 3; j++)
                for (int c = 0; c < 3; c++)
                    finite &= isfinite(vb[4 * (v0 + ix[j]) + c]) != 0;
            if (!finite)
                continue;
            for (int j = 0; j < 3; j++)
                ib[3 * t + j] = (unsigned)(v0 + ix[j]);
            t++;
        }
        v0 += m->vertex_count;
    }
    for (; t < (nt ? nt : 1); t++) /* dropped triangles: degenerate (0, 0, 0), never hit */
        ib[3 * t] = ib[3 * t + 1] = ib[3 * t + 2] = 0;
    rtcCommitGeometry(g);
    rtcAttachGeometry(out->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(out->scene);
    return rtcGetDeviceError(out->device) == RTC_ERROR_NONE;
}

static void raw_scene_free(raw_scene *r)
{
    if (r->scene)
        rtcReleaseScene(r->scene);
    if (r->device)
        rtcReleaseDevice(r->device);
    memset(r, 0, sizeof *r);
}

/* ---- captured rays ----------------------------------------------------------------------------- */

typedef struct capture {
    int64_t tiles;
    RTCRay **rays;      /* per tile (one round per tile here) */
    int *count;
    int64_t total;
    float tfar;
    RTCScene scene;     /* the raw side's flat scene */
    uint64_t *occluded; /* per thread, padded */
} capture;

static void sink(void *user, int64_t tile, int64_t round, const void *rays, int count, size_t stride)
{
    capture *c = (capture *)user;
    if (round != 0 || stride != sizeof(RTCRay)) /* min = max = batch: one round per tile */
        abort();
    c->rays[tile] = (RTCRay *)obs_aligned_alloc(sizeof(RTCRay) * (size_t)(count ? count : 1));
    memcpy(c->rays[tile], rays, sizeof(RTCRay) * (size_t)count);
    c->count[tile] = count;
}

static void raw_task(void *user, int64_t tile, int thread)
{
    capture *c = (capture *)user;
    int n = c->count[tile];
    if (!n)
        return;
    unsigned int csr = _mm_getcsr();
    truth_thread_init();
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    rtcOccluded1M(c->scene, &ictx, c->rays[tile], (unsigned)n, sizeof(RTCRay));
    uint64_t occ = 0;
    for (int i = 0; i < n; i++)
        occ += c->rays[tile][i].tfar == -INFINITY;
    c->occluded[8 * thread] += occ;
    _mm_setcsr(csr);
}

static int has_ext(const char *p, const char *e)
{
    size_t n = strlen(p), m = strlen(e);
    return n >= m && !strcasecmp(p + n - m, e);
}

int main(int argc, char **argv)
{
    const char *meshes[16];
    int nmesh = 0, W = 1920, H = 1080, spp = 16, reps = 9, tile = 8;
    int threads[8] = {2}, nthreads = 1;
    truth_scene_layout layout = TRUTH_SCENE_AUTO;
    enum RTCBuildQuality raw_q = RTC_BUILD_QUALITY_MEDIUM;
    double radius_frac = 0.1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--size")) { if (sscanf(v, "%dx%d", &W, &H) != 2) return 2; i++; }
        else if (!strcmp(a, "--spp")) { spp = atoi(v); i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (!strcmp(a, "--tile")) { tile = atoi(v); i++; }
        else if (!strcmp(a, "--radius-frac")) { radius_frac = atof(v); i++; }
        else if (!strcmp(a, "--layout")) {
            if (!strcmp(v, "auto")) layout = TRUTH_SCENE_AUTO;
            else if (!strcmp(v, "flat")) layout = TRUTH_SCENE_FLAT;
            else if (!strcmp(v, "instanced")) layout = TRUTH_SCENE_INSTANCED;
            else { fprintf(stderr, "--layout needs auto, flat or instanced\n"); return 2; }
            i++;
        } else if (!strcmp(a, "--raw-build")) {
            if (!strcmp(v, "low")) raw_q = RTC_BUILD_QUALITY_LOW;
            else if (!strcmp(v, "medium")) raw_q = RTC_BUILD_QUALITY_MEDIUM;
            else if (!strcmp(v, "high")) raw_q = RTC_BUILD_QUALITY_HIGH;
            else { fprintf(stderr, "--raw-build needs low, medium or high\n"); return 2; }
            i++;
        }
        else if (!strcmp(a, "--threads")) {
            nthreads = 0;
            for (const char *p = v; *p && nthreads < 8;) {
                threads[nthreads++] = atoi(p);
                const char *comma = strchr(p, ',');
                if (!comma) break;
                p = comma + 1;
            }
            i++;
        } else if (a[0] != '-' && nmesh < 16) meshes[nmesh++] = a;
        else { fprintf(stderr, "unknown option %s\n", a); return 2; }
    }
    if (!nmesh) { /* the default: the bunny, as the set-up generates it, else the CGAL mesh */
        FILE *f = fopen("build/data/bunny.glb", "rb");
        meshes[nmesh++] = f ? "build/data/bunny.glb" : "data/cache/bunny00.off";
        if (f)
            fclose(f);
    }
    if (reps < 1 || spp < 2 || spp > 1024) {
        fprintf(stderr, "usage: obscura_bench_truth [MESH.glb|MESH.off ...] [--size WxH] [--spp N] [--threads 2] "
                        "[--reps R] [--radius-frac F] [--tile T] [--layout auto|flat|instanced] "
                        "[--raw-build low|medium|high]\n");
        return 2;
    }
    for (int mi = 0; mi < nmesh; mi++) {
        const char *mesh = meshes[mi];
        obs_context *ctx = obs_context_create();
        obs_scene s;
        if (has_ext(mesh, ".off")) {
            if (!load_off(mesh, &s)) {
                fprintf(stderr, "bench: cannot read %s\n", mesh);
                return 3;
            }
        } else {
            io_gltf_options opt = io_gltf_options_default();
            if (io_gltf_load(ctx, mesh, &opt, &s) != OBS_STATUS_OK) {
                fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
                return 3;
            }
        }
        obs_camera cam = frame_scene(&s);
        rast_params rp = rast_params_default();
        rp.width = W;
        rp.height = H;
        rp.outputs = RAST_OUT_DEPTH | RAST_OUT_FACE_NORMAL | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
        rast_gbuffer gb;
        truth_scene_options so = truth_scene_options_default();
        so.layout = layout;
        obs_pool *pool0 = obs_pool_create(0);
        rast_view view = {cam};
        truth_scene *ts = NULL;
        if (rast_gbuffer_alloc(ctx, &rp, &gb) != OBS_STATUS_OK ||
            rast_render(ctx, pool0, &s, &view, 1, &rp, &gb, NULL) != OBS_STATUS_OK ||
            truth_scene_create_ex(ctx, &s, &so, &ts) != OBS_STATUS_OK) {
            fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
            return 4;
        }
        raw_scene raw;
        if (!raw_scene_build(&s, raw_q, &raw)) {
            fprintf(stderr, "bench: building the raw flat scene failed (Embree error %d)\n",
                    (int)rtcGetDeviceError(raw.device));
            return 4;
        }
        truth_scene_info si;
        truth_scene_get_info(ts, &si);
        char scenes[256];
        snprintf(scenes, sizeof scenes,
                 "pipeline_scene=%s(flat_instances=%u,two_level_instances=%u,flags=0x%x,build=%s) "
                 "raw_scene=one-level(1 triangle geometry,flags=0x%x,build=%s)",
                 truth_scene_layout_name(layout), si.instances_flat, si.instances_two_level, si.scene_flags,
                 si.quality == TRUTH_BUILD_LOW ? "low" : si.quality == TRUTH_BUILD_HIGH ? "high" : "medium",
                 (unsigned)raw.flags, quality_name(raw.quality));
        obs_pool_destroy(pool0);
        truth_ao_params p = truth_ao_params_default();
        p.estimator = TRUTH_AO_COS;
        p.radius = (float)(radius_frac * 10.0);
        p.min_samples = p.max_samples = spp;
        p.batch = spp;
        p.tile = tile;

        /* capture the rays once */
        obs_tiling tiling = obs_tiling_make(W, H, p.tile);
        capture cap;
        memset(&cap, 0, sizeof cap);
        cap.tiles = obs_tiling_count(&tiling);
        cap.rays = (RTCRay **)calloc((size_t)cap.tiles, sizeof(RTCRay *));
        cap.count = (int *)calloc((size_t)cap.tiles, sizeof(int));
        cap.tfar = p.radius;
        cap.scene = raw.scene;
        cap.occluded = (uint64_t *)calloc(8 * 256, sizeof(uint64_t));
        truth_ao_hooks hooks = {sink, &cap};
        truth_ao_result res;
        if (truth_ao_render_ex(ctx, NULL, ts, &s, &cam, &gb, &p, &res, &hooks) != OBS_STATUS_OK) {
            fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
            return 5;
        }
        for (int64_t t = 0; t < cap.tiles; t++)
            cap.total += cap.count[t];
        double pipe_occluded = 0;
        for (int y = 0; y < res.height; y++)
            for (int x = 0; x < res.width; x++) {
                float c = obs_image_f32_row(&res.count, y)[x];
                pipe_occluded += c * (1.0 - obs_image_f32_row(&res.mean, y)[x]);
            }
        if ((uint64_t)cap.total != res.stats.rays) {
            fprintf(stderr, "bench: captured %lld rays, the pipeline traced %llu\n", (long long)cap.total,
                    (unsigned long long)res.stats.rays);
            return 6;
        }
        truth_ao_result_free(&res);

        for (int ti = 0; ti < nthreads; ti++) {
            obs_pool *pool = obs_pool_create(threads[ti]);
            double *tp = (double *)calloc((size_t)reps, sizeof(double)), *tr = (double *)calloc((size_t)reps, sizeof(double));
            double *tw = (double *)calloc((size_t)reps, sizeof(double));
            double *pr = (double *)calloc((size_t)reps, sizeof(double));
            uint64_t raw_occluded = 0;
            /* warm-up: one of each */
            truth_ao_render(ctx, pool, ts, &s, &cam, &gb, &p, &res);
            truth_ao_result_free(&res);
            for (int k = 0; k < reps + 1; k++) {
                /* (b) raw, on freshly reset rays */
                for (int64_t t = 0; t < cap.tiles; t++)
                    for (int i = 0; i < cap.count[t]; i++)
                        cap.rays[t][i].tfar = cap.tfar;
                memset(cap.occluded, 0, 8 * 256 * sizeof(uint64_t));
                double t0 = obs_time_now();
                obs_pool_run(pool, cap.tiles, raw_task, &cap);
                double t1 = obs_time_now();
                /* (a) the pipeline */
                if (truth_ao_render(ctx, pool, ts, &s, &cam, &gb, &p, &res) != OBS_STATUS_OK) {
                    fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
                    return 5;
                }
                double t2 = obs_time_now();
                double work = res.stats.seconds_work;
                truth_ao_result_free(&res);
                if (k == 0)
                    continue; /* the raw loop's first pass is its warm-up */
                tr[k - 1] = t1 - t0;
                tp[k - 1] = t2 - t1;
                tw[k - 1] = work;
                pr[k - 1] = (t1 - t0) / (t2 - t1);
                raw_occluded = 0;
                for (int th = 0; th < 256; th++)
                    raw_occluded += cap.occluded[8 * th];
            }
            double lo_pr = 1e300, hi_pr = 0;
            for (int k = 0; k < reps; k++) {
                lo_pr = pr[k] < lo_pr ? pr[k] : lo_pr;
                hi_pr = pr[k] > hi_pr ? pr[k] : hi_pr;
            }
            double mp = median(tp, reps), mr = median(tr, reps), mw = median(tw, reps), mpr = median(pr, reps);
            double rays = (double)cap.total;
            /* ratio: raw time / whole-call time; ratio_work: raw time / the call's tile work (the
             * whole call also allocates and zeroes its three output planes, page faults included) */
            printf("RESULT truth_ao mesh=%s size=%dx%d spp=%d tile=%d radius=%g threads=%d tris=%llu rays=%.0f "
                   "pipeline_ms=%.2f pipeline_work_ms=%.2f pipeline_mrays_s=%.2f raw_ms=%.2f raw_mrays_s=%.2f "
                   "ratio=%.3f ratio_work=%.3f pair_ratio_median=%.3f pair_ratio_range=%.3f-%.3f "
                   "occluded_pipeline=%.0f occluded_raw=%llu reps=%d %s\n",
                   mesh, W, H, spp, tile, (double)p.radius, obs_pool_threads(pool),
                   (unsigned long long)obs_scene_triangle_count(&s), rays, 1e3 * mp, 1e3 * mw, rays / mp * 1e-6,
                   1e3 * mr, rays / mr * 1e-6, mr / mp, mr / mw, mpr, lo_pr, hi_pr, pipe_occluded,
                   (unsigned long long)raw_occluded, reps, scenes);
            printf("RATIO %s threads=%d: pipeline / raw flat rtcOccluded1M = %.3f (median of %d alternating pairs; "
                   "bar >= 0.90: %s)\n",
                   mesh, obs_pool_threads(pool), mpr, reps, mpr >= 0.90 ? "met" : "NOT met");
            fflush(stdout);
            free(tp);
            free(tr);
            free(tw);
            free(pr);
            obs_pool_destroy(pool);
        }
        for (int64_t t = 0; t < cap.tiles; t++)
            obs_aligned_free(cap.rays[t]);
        free(cap.rays);
        free(cap.count);
        free(cap.occluded);
        truth_scene_destroy(ts);
        raw_scene_free(&raw);
        rast_gbuffer_free(&gb);
        obs_scene_free(&s);
        obs_context_destroy(ctx);
    }
    return 0;
}
