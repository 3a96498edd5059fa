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
 * (a) and (b) are printed as a check that the rays and the geometry are the same.
 *
 *   obscura_bench_truth --sss [SCENE.glb] [--size 160x120] [--spp 1024] [--batch N] [--tile 4]
 *                       [--threads 2] [--reps R] [--raw-build low|medium|high]
 *
 * The SSS brute force's shadow rays (issue 14; docs/sss/truth.md, "Shadow rays in batches"). SCENE
 * (default build/data/bunny_cream.glb: the bunny in cream, its directional key light) seen through
 * its first camera, rasterized once; then
 *   (a) pipeline: truth_sss_render_ex, brute force, directional dipole, exactly N candidates per
 *       surface pixel (min = max = N, batch = --batch or N: one round), 4x4 tiles, timed whole,
 *       and with its hooks' time_trace: obs_time_now around each of its rtcOccluded1M calls,
 *       summed over the tasks (CPU-seconds inside Embree, both threads together);
 *   (b) raw: the very same shadow rays, captured once through the ray sink (per task and batch),
 *       each batch traced by one rtcOccluded1M call on the flat one-level scene above (raw_scene),
 *       tasks over the same obs_pool, each call timed the same way (tfar reset before, untimed).
 * The capture run also checks every batched verdict against truth_intersect1's closest hit on the
 * same ray (the per-ray code's test) and, after the warm-up, the raw scene's verdicts ray by ray.
 * (b) and (a) alternate, R times after one warm-up pair. RESULT gives the medians; RATIO 1 =
 * raw call time / the pipeline's call time (the bar: >= 0.90), RATIO 2 = raw wall / the whole
 * reference's wall (the rays' share of the reference), each the median of the per-pair ratios. */
#include "core/obs.h"
#include "io/io.h"
#include "raster/raster.h"
#include "sss/sss.h"
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

/* The raw flat scene (raw_scene_build) for the benchmark, or 0 with a message; and the RESULT line's
 * description of both scenes (the pipeline's layout, flags and quality; the raw one's). */
static int raw_scene_build_or_say(const obs_scene *s, enum RTCBuildQuality q, raw_scene *raw)
{
    if (raw_scene_build(s, q, raw))
        return 1;
    fprintf(stderr, "bench: building the raw flat scene failed (Embree error %d)\n", (int)rtcGetDeviceError(raw->device));
    return 0;
}

static void scenes_text(char *out, size_t size, truth_scene_layout layout, const truth_scene *ts, const raw_scene *raw)
{
    truth_scene_info si;
    truth_scene_get_info(ts, &si);
    snprintf(out, size,
             "pipeline_scene=%s(flat_instances=%u,two_level_instances=%u,flags=0x%x,build=%s) "
             "raw_scene=one-level(1 triangle geometry,flags=0x%x,build=%s)",
             truth_scene_layout_name(layout), si.instances_flat, si.instances_two_level, si.scene_flags,
             si.quality == TRUTH_BUILD_LOW ? "low" : si.quality == TRUTH_BUILD_HIGH ? "high" : "medium",
             (unsigned)raw->flags, quality_name(raw->quality));
}

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

/* ---- --sss: the SSS brute force's shadow rays against raw Embree ------------------------------ */

/* The shadow rays of truth_sss_render, captured per (task, batch) through its ray sink; the
 * verdicts of the capture run through its traced sink. */
typedef struct sssb_batch {
    RTCRay *rays;
    float *tfar;        /* as captured (reset before each raw run, untimed) */
    unsigned char *occ; /* the pipeline's verdicts (capture run) */
    int count;
} sssb_batch;

typedef struct sss_capture {
    int64_t tasks;
    sssb_batch **b;      /* per task: its batches */
    int64_t *nb, *cap;  /* per task: how many, allocated */
    RTCScene scene;     /* the raw side's flat scene */
    const truth_scene *ts;
    double *call_s;     /* per thread (padded by 8): seconds inside rtcOccluded1M, raw side */
    uint64_t *occluded; /* per thread (padded by 8), raw side */
    uint64_t *mismatch_closest; /* per task: pipeline verdict != truth_intersect1's closest hit */
} sss_capture;

static void sss_sink(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride)
{
    sss_capture *c = (sss_capture *)user;
    if (stride != sizeof(RTCRay) || task < 0 || task >= c->tasks || batch != c->nb[task])
        abort();
    if (c->nb[task] == c->cap[task]) {
        c->cap[task] = c->cap[task] ? 2 * c->cap[task] : 16;
        c->b[task] = (sssb_batch *)realloc(c->b[task], sizeof(sssb_batch) * (size_t)c->cap[task]);
    }
    sssb_batch *b = &c->b[task][c->nb[task]++];
    b->count = count;
    b->rays = (RTCRay *)obs_aligned_alloc(sizeof(RTCRay) * (size_t)count);
    b->tfar = (float *)malloc(sizeof(float) * (size_t)count);
    b->occ = (unsigned char *)malloc((size_t)count);
    memcpy(b->rays, rays, sizeof(RTCRay) * (size_t)count);
    for (int i = 0; i < count; i++)
        b->tfar[i] = b->rays[i].tfar;
}

/* The pipeline's verdicts, and each checked against the closest hit of truth_intersect1 on the
 * same ray (the per-ray code's test): any hit within [0, tfar] == closest hit within [0, tfar]. */
static void sss_traced(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride)
{
    sss_capture *c = (sss_capture *)user;
    (void)stride;
    sssb_batch *b = &c->b[task][batch];
    const RTCRay *r = (const RTCRay *)rays;
    for (int i = 0; i < count; i++) {
        b->occ[i] = r[i].tfar == -INFINITY;
        const RTCRay *q = &b->rays[i];
        truth_hit h;
        truth_intersect1(c->ts, obs_v3(q->org_x, q->org_y, q->org_z), obs_v3(q->dir_x, q->dir_y, q->dir_z), q->tnear,
                         b->tfar[i], &h);
        c->mismatch_closest[task] += (uint64_t)(b->occ[i] != (h.instance != 0xFFFFFFFFu));
    }
}

/* (b) raw: a task's batches, one rtcOccluded1M call each on the flat scene, each call timed as
 * the pipeline's are (obs_time_now before and after). */
static void sss_raw_task(void *user, int64_t task, int thread)
{
    sss_capture *c = (sss_capture *)user;
    if (!c->nb[task])
        return;
    unsigned int csr = _mm_getcsr();
    truth_thread_init();
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    double s = 0.0;
    uint64_t occ = 0;
    for (int64_t k = 0; k < c->nb[task]; k++) {
        sssb_batch *b = &c->b[task][k];
        const double t0 = obs_time_now();
        rtcOccluded1M(c->scene, &ictx, b->rays, (unsigned)b->count, sizeof(RTCRay));
        s += obs_time_now() - t0;
        for (int i = 0; i < b->count; i++)
            occ += b->rays[i].tfar == -INFINITY;
    }
    c->call_s[8 * thread] += s;
    c->occluded[8 * thread] += occ;
    _mm_setcsr(csr);
}

/* The ray-by-ray verdicts of the raw flat scene against the pipeline's (capture run). */
static uint64_t sss_raw_mismatches(const sss_capture *c)
{
    uint64_t m = 0;
    for (int64_t t = 0; t < c->tasks; t++)
        for (int64_t k = 0; k < c->nb[t]; k++) {
            const sssb_batch *b = &c->b[t][k];
            for (int i = 0; i < b->count; i++)
                m += (uint64_t)((b->rays[i].tfar == -INFINITY) != b->occ[i]);
        }
    return m;
}

/* The cost of one obs_time_now call, for the timers' overhead. */
static double time_now_cost(void)
{
    const int n = 1000000;
    double t0 = obs_time_now(), x = 0.0;
    for (int i = 0; i < n; i++)
        x += obs_time_now();
    double t1 = obs_time_now();
    return x > 0.0 ? (t1 - t0) / n : 0.0;
}

static int bench_sss(const char *path, int W, int H, int spp, int batch, int tile, const int *threads, int nthreads,
                     int reps, enum RTCBuildQuality raw_q)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    sss_scene_setup setup;
    memset(&setup, 0, sizeof setup);
    if (io_gltf_load(ctx, path, &opt, &s) != OBS_STATUS_OK ||
        sss_scene_setup_make(ctx, &s, NULL, SSS_DEFAULT_MM_PER_UNIT, &setup) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 3;
    }
    if (!s.camera_count || !s.light_count || !sss_scene_setup_any_translucent(&setup, &s)) {
        fprintf(stderr, "bench: %s needs a camera, a light and a translucent material\n", path);
        return 3;
    }
    obs_camera cam = s.cameras[0];
    rast_params rp = rast_params_default();
    rp.width = W;
    rp.height = H;
    rp.outputs = RAST_OUT_DEPTH | RAST_OUT_PRIM_ID | RAST_OUT_INSTANCE_ID;
    rast_gbuffer gb;
    obs_pool *pool0 = obs_pool_create(0);
    rast_view view = {cam};
    truth_scene *ts = NULL;
    truth_scene_options so = truth_scene_options_default();
    if (rast_gbuffer_alloc(ctx, &rp, &gb) != OBS_STATUS_OK ||
        rast_render(ctx, pool0, &s, &view, 1, &rp, &gb, NULL) != OBS_STATUS_OK ||
        truth_scene_create_ex(ctx, &s, &so, &ts) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 4;
    }
    obs_pool_destroy(pool0);
    raw_scene raw;
    if (!raw_scene_build_or_say(&s, raw_q, &raw))
        return 4;
    char scenes[256];
    scenes_text(scenes, sizeof scenes, so.layout, ts, &raw);
    truth_sss_params p = truth_sss_params_default();
    p.estimator = TRUTH_SSS_BRUTE_FORCE;
    p.min_samples = p.max_samples = spp;
    p.batch = batch;
    p.tile = tile;
    if (truth_sss_params_validate(ctx, &p) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 2;
    }

    /* capture the shadow rays and the pipeline's verdicts once (1 thread) */
    sss_capture cap;
    memset(&cap, 0, sizeof cap);
    cap.tasks = truth_sss_task_count(W, H, tile);
    cap.b = (sssb_batch **)calloc((size_t)cap.tasks, sizeof(sssb_batch *));
    cap.nb = (int64_t *)calloc((size_t)cap.tasks, sizeof(int64_t));
    cap.cap = (int64_t *)calloc((size_t)cap.tasks, sizeof(int64_t));
    cap.mismatch_closest = (uint64_t *)calloc((size_t)cap.tasks, sizeof(uint64_t));
    cap.scene = raw.scene;
    cap.ts = ts;
    cap.call_s = (double *)calloc(8 * 256, sizeof(double));
    cap.occluded = (uint64_t *)calloc(8 * 256, sizeof(uint64_t));
    truth_sss_hooks hooks;
    memset(&hooks, 0, sizeof hooks);
    hooks.ray_sink = sss_sink;
    hooks.traced_sink = sss_traced;
    hooks.user = &cap;
    truth_sss_result res;
    if (truth_sss_render_ex(ctx, NULL, ts, &s, &setup.mats, &cam, &gb, &p, &res, &hooks) != OBS_STATUS_OK) {
        fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
        return 5;
    }
    uint64_t total = 0, nbatches = 0, pipe_occluded = 0, closest_mismatch = 0;
    for (int64_t t = 0; t < cap.tasks; t++) {
        nbatches += (uint64_t)cap.nb[t];
        closest_mismatch += cap.mismatch_closest[t];
        for (int64_t k = 0; k < cap.nb[t]; k++) {
            total += (uint64_t)cap.b[t][k].count;
            for (int i = 0; i < cap.b[t][k].count; i++)
                pipe_occluded += cap.b[t][k].occ[i];
        }
    }
    if (total != res.stats.rays) {
        fprintf(stderr, "bench: captured %llu rays, the pipeline traced %llu\n", (unsigned long long)total,
                (unsigned long long)res.stats.rays);
        return 6;
    }
    const truth_sss_stats st0 = res.stats;
    truth_sss_result_free(&res);
    const double tnow = time_now_cost();
    printf("sss capture: %s %dx%d, %lld surface pixels x %d candidates (batch %d, tile %d): %llu candidates, %llu kept "
           "(%.2f%%), %llu shadow rays in %llu batches (%.1f rays a batch), %llu occluded; batched verdicts vs "
           "truth_intersect1 closest hit: %llu mismatches; obs_time_now %.1f ns a call\n",
           path, W, H, (long long)st0.pixels_surface, spp, batch, tile, (unsigned long long)st0.candidates,
           (unsigned long long)st0.accepted, 100.0 * (double)st0.accepted / (double)(st0.candidates ? st0.candidates : 1),
           (unsigned long long)total, (unsigned long long)nbatches, (double)total / (double)(nbatches ? nbatches : 1),
           (unsigned long long)pipe_occluded, (unsigned long long)closest_mismatch, 1e9 * tnow);
    fflush(stdout);

    for (int ti = 0; ti < nthreads; ti++) {
        obs_pool *pool = obs_pool_create(threads[ti]);
        const int nth = obs_pool_threads(pool);
        double *tp = (double *)calloc((size_t)reps, sizeof(double)), *tt = (double *)calloc((size_t)reps, sizeof(double));
        double *trw = (double *)calloc((size_t)reps, sizeof(double)), *trc = (double *)calloc((size_t)reps, sizeof(double));
        double *r1 = (double *)calloc((size_t)reps, sizeof(double)), *r2 = (double *)calloc((size_t)reps, sizeof(double));
        uint64_t raw_occluded = 0, raw_mismatch = 0;
        double pipe_trace = 0.0;
        uint64_t pipe_calls = 0;
        truth_sss_hooks th;
        memset(&th, 0, sizeof th);
        th.time_trace = 1;
        th.trace_seconds = &pipe_trace;
        th.trace_calls = &pipe_calls;
        for (int k = 0; k < reps + 1; k++) { /* pair 0 is the warm-up */
            /* (b) raw, on freshly reset rays */
            for (int64_t t = 0; t < cap.tasks; t++)
                for (int64_t j = 0; j < cap.nb[t]; j++)
                    for (int i = 0; i < cap.b[t][j].count; i++)
                        cap.b[t][j].rays[i].tfar = cap.b[t][j].tfar[i];
            memset(cap.occluded, 0, 8 * 256 * sizeof(uint64_t));
            memset(cap.call_s, 0, 8 * 256 * sizeof(double));
            double t0 = obs_time_now();
            obs_pool_run(pool, cap.tasks, sss_raw_task, &cap);
            double t1 = obs_time_now();
            /* (a) the pipeline, its trace calls timed */
            if (truth_sss_render_ex(ctx, pool, ts, &s, &setup.mats, &cam, &gb, &p, &res, &th) != OBS_STATUS_OK) {
                fprintf(stderr, "bench: %s\n", obs_context_last_error(ctx));
                return 5;
            }
            double t2 = obs_time_now();
            if (res.stats.rays != total || pipe_calls != nbatches) {
                fprintf(stderr, "bench: the pipeline traced %llu rays in %llu batches, the capture %llu in %llu\n",
                        (unsigned long long)res.stats.rays, (unsigned long long)pipe_calls, (unsigned long long)total,
                        (unsigned long long)nbatches);
                return 6;
            }
            truth_sss_result_free(&res);
            double raw_calls = 0.0;
            raw_occluded = 0;
            for (int th_ = 0; th_ < 256; th_++) {
                raw_calls += cap.call_s[8 * th_];
                raw_occluded += cap.occluded[8 * th_];
            }
            if (k == 0) {
                raw_mismatch = sss_raw_mismatches(&cap);
                continue;
            }
            trw[k - 1] = t1 - t0;
            trc[k - 1] = raw_calls;
            tp[k - 1] = t2 - t1;
            tt[k - 1] = pipe_trace;
            r1[k - 1] = raw_calls / pipe_trace;
            r2[k - 1] = (t1 - t0) / (t2 - t1);
        }
        double lo1 = 1e300, hi1 = 0.0;
        for (int k = 0; k < reps; k++) {
            lo1 = r1[k] < lo1 ? r1[k] : lo1;
            hi1 = r1[k] > hi1 ? r1[k] : hi1;
        }
        const double mr1 = median(r1, reps), mr2 = median(r2, reps);
        const double mp = median(tp, reps), mt = median(tt, reps), mrw = median(trw, reps), mrc = median(trc, reps);
        const double rays = (double)total;
        /* the timers: two obs_time_now calls per batch, on each side */
        const double timer_s = 2.0 * tnow * (double)nbatches;
        printf("RESULT truth_sss scene=%s size=%dx%d candidates=%d batch=%d tile=%d threads=%d tris=%llu "
               "surface_pixels=%lld kept=%llu rays=%.0f batches=%llu pipeline_ms=%.2f pipeline_trace_cpu_ms=%.2f "
               "pipeline_trace_mrays_per_cpu_s=%.2f raw_ms=%.2f raw_trace_cpu_ms=%.2f raw_trace_mrays_per_cpu_s=%.2f "
               "timer_overhead_cpu_ms=%.3f ratio1_median_pairs=%.3f ratio1_range=%.3f-%.3f ratio1_of_medians=%.3f "
               "ratio2_median_pairs=%.4f occluded_pipeline=%llu occluded_raw=%llu raw_vs_pipeline_verdict_mismatches=%llu "
               "closest_hit_mismatches=%llu reps=%d %s\n",
               path, W, H, spp, batch, tile, nth, (unsigned long long)obs_scene_triangle_count(&s),
               (long long)st0.pixels_surface, (unsigned long long)st0.accepted, rays, (unsigned long long)nbatches,
               1e3 * mp, 1e3 * mt, rays / mt * 1e-6, 1e3 * mrw, 1e3 * mrc, rays / mrc * 1e-6, 1e3 * timer_s, mr1, lo1,
               hi1, mrc / mt, mr2, (unsigned long long)pipe_occluded, (unsigned long long)raw_occluded,
               (unsigned long long)raw_mismatch, (unsigned long long)closest_mismatch, reps, scenes);
        printf("RATIO %s threads=%d: ratio 1 = raw flat rtcOccluded1M / the pipeline's rtcOccluded1M calls (CPU time "
               "inside the calls, summed over threads) = %.3f (median of %d alternating pairs; bar >= 0.90: %s)\n",
               path, nth, mr1, reps, mr1 >= 0.90 ? "met" : "NOT met");
        printf("RATIO %s threads=%d: ratio 2 = raw flat rtcOccluded1M wall / the whole brute-force reference wall = "
               "%.4f (the shadow rays' share of the reference; the rest is drawing and rejecting candidates and "
               "evaluating S_d)\n",
               path, nth, mr2);
        fflush(stdout);
        if (raw_occluded != pipe_occluded || raw_mismatch) {
            fprintf(stderr, "bench: occluded counts differ: pipeline %llu, raw %llu (%llu verdicts differ)\n",
                    (unsigned long long)pipe_occluded, (unsigned long long)raw_occluded,
                    (unsigned long long)raw_mismatch);
            return 7;
        }
        free(tp); free(tt); free(trw); free(trc); free(r1); free(r2);
        obs_pool_destroy(pool);
    }
    for (int64_t t = 0; t < cap.tasks; t++) {
        for (int64_t k = 0; k < cap.nb[t]; k++) {
            obs_aligned_free(cap.b[t][k].rays);
            free(cap.b[t][k].tfar);
            free(cap.b[t][k].occ);
        }
        free(cap.b[t]);
    }
    free(cap.b); free(cap.nb); free(cap.cap); free(cap.mismatch_closest); free(cap.call_s); free(cap.occluded);
    truth_scene_destroy(ts);
    raw_scene_free(&raw);
    rast_gbuffer_free(&gb);
    sss_scene_setup_free(&setup);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    return 0;
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
    int sss = 0, size_given = 0, spp_given = 0, tile_given = 0, batch = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--size")) { if (sscanf(v, "%dx%d", &W, &H) != 2) return 2; size_given = 1; i++; }
        else if (!strcmp(a, "--spp")) { spp = atoi(v); spp_given = 1; i++; }
        else if (!strcmp(a, "--reps")) { reps = atoi(v); i++; }
        else if (!strcmp(a, "--tile")) { tile = atoi(v); tile_given = 1; i++; }
        else if (!strcmp(a, "--sss")) sss = 1;
        else if (!strcmp(a, "--batch")) { batch = atoi(v); i++; }
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
    if (sss) { /* the SSS brute force's shadow rays (header comment) */
        if (!size_given)
            W = 160, H = 120;
        if (!spp_given)
            spp = 1024;
        if (!tile_given)
            tile = 4;
        if (reps < 1 || spp < 8 || nmesh > 1) {
            fprintf(stderr, "usage: obscura_bench_truth --sss [SCENE.glb] [--size WxH] [--spp N] [--batch B] "
                            "[--tile T] [--threads 2] [--reps R] [--raw-build low|medium|high]\n");
            return 2;
        }
        return bench_sss(nmesh ? meshes[0] : "build/data/bunny_cream.glb", W, H, spp, batch > 0 ? batch : spp, tile,
                         threads, nthreads, reps, raw_q);
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
        if (!raw_scene_build_or_say(&s, raw_q, &raw))
            return 4;
        char scenes[256];
        scenes_text(scenes, sizeof scenes, layout, ts, &raw);
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
