/* test_truth_sss_batch.c: the SSS ground truth's shadow rays traced in batches (src/truth/truth_sss.c,
 * one rtcOccluded1M call per stream of up to 1,024 rays; docs/sss/truth.md, "Shadow rays in
 * batches"). The batched path must give the bytes of the per-ray path it replaced (kept behind
 * truth_sss_hooks.per_ray: each shadow ray a truth_intersect1 closest hit), for any thread count,
 * directional and point lights, both estimators; the ray sink must see every shadow ray once; and
 * every batched verdict must equal the closest-hit one. */
#include "scene_util.h"
#include "sss_truth_test_util.h"
#include "test.h"

#include "core/obs.h"
#include "raster/raster.h"
#include "sss/sss.h"
#include "truth/truth.h"
#include "truth/truth_internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- scenes ----------------------------------------------------------------------------------- */


/* A quad p0 p1 p2 p3 (two triangles, counter-clockwise as given). */
static void add_quad(obs_scene *s, const char *name, const double q[12], int32_t material)
{
    uint32_t i[6] = {0, 1, 2, 0, 2, 3};
    tu_add_mesh(s, name, q, 4, i, 2, material);
}




/* Skin1 [Jensen01] Fig. 5(b), per mm, 1 mm per unit. */
static sss_material skin1(void)
{
    sss_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "skin1");
    const double ss[3] = {0.74, 0.88, 1.01}, sa[3] = {0.032, 0.17, 0.48};
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = ss[c];
        m.sigma_a[c] = sa[c];
    }
    m.eta = 1.3;
    return m;
}

/* A translucent square [-4, 4]^2 at z = 0 (Skin1) with an opaque wall x = 0.5, y in [-3, 3],
 * z in [0.02, 1.5] standing on it, so that the lights from +x leave a shadow on the x < 0.5 side;
 * with `many` lights, 40 point lights on a ring above, else a directional light from +x above, a
 * point light at (2, 0.5, 1) and a directional light from below (facing away: no ray). */
static int wall_setup(stu_run *R, int W, int many)
{
    memset(R, 0, sizeof *R);
    obs_scene_init(&R->scene);
    const double sq[12] = {-4, -4, 0, 4, -4, 0, 4, 4, 0, -4, 4, 0};
    add_quad(&R->scene, "plane", sq, -1);
    const double wall[12] = {0.5, -3, 0.02, 0.5, 3, 0.02, 0.5, 3, 1.5, 0.5, -3, 1.5};
    add_quad(&R->scene, "wall", wall, 0);
    if (many) {
        for (int l = 0; l < 40; l++) {
            double a = 2.0 * OBS_PI * l / 40.0;
            tu_add_light(&R->scene, OBS_LIGHT_POINT, obs_v3((float)(3.0 * cos(a)), (float)(3.0 * sin(a)), 1.0f + 0.02f * l),
                      obs_v3(0, 0, -1), obs_v3(1.0f, 0.8f, 0.6f), 2.0f);
        }
    } else {
        tu_add_light(&R->scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(-0.8f, 0.1f, -0.6f), obs_v3(1.0f, 0.8f, 0.6f), 3.0f);
        tu_add_light(&R->scene, OBS_LIGHT_POINT, obs_v3(2.0f, 0.5f, 1.0f), obs_v3(0, 0, -1), obs_v3(1.0f, 0.8f, 0.6f), 4.0f);
        tu_add_light(&R->scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(0, 0, 1), obs_v3(1.0f, 0.8f, 0.6f), 1.0f);
    }
    sss_material m = skin1();
    return stu_run_setup(R, &m, 1.0, 10.0, 1.5f, W);
}

static int same_planes(const truth_sss_result *a, const truth_sss_result *b)
{
    if (a->width != b->width || a->height != b->height)
        return 0;
    for (int y = 0; y < a->height; y++) {
        for (int c = 0; c < 3; c++)
            if (memcmp(obs_image_f32_row(&a->radiance[c], y), obs_image_f32_row(&b->radiance[c], y), 4 * (size_t)a->width) ||
                memcmp(obs_image_f32_row(&a->std_error[c], y), obs_image_f32_row(&b->std_error[c], y), 4 * (size_t)a->width))
                return 0;
        if (memcmp(obs_image_f32_row(&a->count, y), obs_image_f32_row(&b->count, y), 4 * (size_t)a->width))
            return 0;
    }
    return a->stats.candidates == b->stats.candidates && a->stats.accepted == b->stats.accepted &&
           a->stats.rays == b->stats.rays && a->stats.walk_events == b->stats.walk_events;
}

static obs_status render(stu_run *R, obs_pool *pool, const truth_sss_params *p, const truth_sss_hooks *h,
                         truth_sss_result *res)
{
    return truth_sss_render_ex(R->ctx, pool, R->ts, &R->scene, &R->mats, &R->cam, &R->gb, p, res, h);
}

/* The batched render against the per-ray reference, 1, 2 and 8 threads. */
static void check_same_as_per_ray(stu_run *R, const truth_sss_params *p, const char *what)
{
    truth_sss_hooks per_ray;
    memset(&per_ray, 0, sizeof per_ray);
    per_ray.per_ray = 1;
    truth_sss_result ref, r;
    CHECK_OK(render(R, NULL, p, &per_ray, &ref), R->ctx);
    CHECK_MSG(ref.stats.pixels_surface > 0 && ref.stats.accepted > 0, "%s: nothing estimated", what);
    const int threads[3] = {1, 2, 8};
    for (int k = 0; k < 3; k++) {
        obs_pool *pool = obs_pool_create(threads[k]);
        CHECK(pool != NULL);
        CHECK_OK(render(R, pool, p, NULL, &r), R->ctx);
        CHECK_MSG(same_planes(&ref, &r), "%s: batched, %d threads, differs from the per-ray path", what, threads[k]);
        truth_sss_result_free(&r);
        /* truth_sss_render itself is the batched path */
        CHECK_OK(truth_sss_render(R->ctx, pool, R->ts, &R->scene, &R->mats, &R->cam, &R->gb, p, &r), R->ctx);
        CHECK_MSG(same_planes(&ref, &r), "%s: truth_sss_render, %d threads, differs", what, threads[k]);
        truth_sss_result_free(&r);
        obs_pool_destroy(pool);
    }
    truth_sss_result_free(&ref);
}

/* Some pixels must be partly shadowed for the comparison to mean anything: the radiance right of
 * the wall (x > 0.5) is above that at the same distance on its left. */
static void check_shadow_seen(stu_run *R, const truth_sss_params *p)
{
    truth_sss_result r;
    CHECK_OK(render(R, NULL, p, NULL, &r), R->ctx);
    const int W = r.width;
    /* the outer columns of the middle row: x = -1.5 + 1.5/W (in the wall's shadow) and 1.5 - 1.5/W */
    double left = obs_image_f32_row(&r.radiance[0], W / 2)[0], right = obs_image_f32_row(&r.radiance[0], W / 2)[W - 1];
    CHECK_MSG(right > left, "no shadow seen: left %g right %g", left, right);
    truth_sss_result_free(&r);
}

TEST(truth_sss_batched_shadow_rays_give_the_per_ray_bytes)
{
    stu_run R;
    /* directional and point lights (and one facing away), brute force, both dipoles, adaptive */
    CHECK_MSG(wall_setup(&R, 8, 0), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.min_samples = 4096;
    p.max_samples = 16384;
    p.batch = 4096;
    p.target_rel_error = 0.05;
    p.tile = 2;
    check_same_as_per_ray(&R, &p, "brute force, directional dipole");
    check_shadow_seen(&R, &p);
    p.model = SSS_MODEL_STANDARD;
    check_same_as_per_ray(&R, &p, "brute force, standard dipole");
    /* nearly every candidate kept (sigma* small): a round's rays overflow one stream many times */
    p.model = SSS_MODEL_DIRECTIONAL;
    p.sigma_star = 1e-3;
    p.min_samples = p.max_samples = p.batch = 2048;
    check_same_as_per_ray(&R, &p, "brute force, sigma* = 1e-3");
    stu_run_free(&R);

    /* 40 point lights, most candidates kept: flushes on the ray count (40 rays per candidate) */
    CHECK_MSG(wall_setup(&R, 4, 1), "setup: %s", obs_context_last_error(R.ctx));
    p = truth_sss_params_default();
    p.sigma_star = 1e-2;
    p.min_samples = p.max_samples = p.batch = 1024;
    p.tile = 1;
    check_same_as_per_ray(&R, &p, "40 point lights");
    stu_run_free(&R);
}

TEST(truth_sss_batched_walk_gives_the_per_ray_bytes)
{
    /* the random walk's entry points are lit through the same batched shadow rays */
    stu_run R;
    memset(&R, 0, sizeof R);
    obs_scene_init(&R.scene);
    tu_add_box(&R.scene, "slab", 6.0, 6.0, -1);
    const double wall[12] = {0.5, -3, 0.02, 0.5, 3, 0.02, 0.5, 3, 1.5, 0.5, -3, 1.5};
    add_quad(&R.scene, "wall", wall, 0);
    tu_add_light(&R.scene, OBS_LIGHT_POINT, obs_v3(2.0f, 0.5f, 1.0f), obs_v3(0, 0, -1), obs_v3(1.0f, 0.8f, 0.6f), 20.0f);
    tu_add_light(&R.scene, OBS_LIGHT_DIRECTIONAL, obs_v3(0, 0, 0), obs_v3(-0.8f, 0.1f, -0.6f), obs_v3(1.0f, 0.8f, 0.6f), 3.0f);
    sss_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "grey");
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = 0.9;
        m.sigma_a[c] = 0.1;
    }
    m.eta = 1.3;
    CHECK_MSG(stu_run_setup(&R, &m, 1.0, 10.0, 1.0f, 4), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.estimator = TRUTH_SSS_RANDOM_WALK;
    p.patch_radius = 0.5;
    p.sigma_star = 0.3;
    p.batch = 1024;
    p.min_samples = p.max_samples = 2048;
    p.tile = 1;
    check_same_as_per_ray(&R, &p, "random walk");
    stu_run_free(&R);
}

/* ---- the sinks -------------------------------------------------------------------------------- */

typedef struct sink_state {
    const truth_scene *ts;
    int64_t tasks;
    uint64_t *rays;          /* per task: rays seen */
    int64_t *next_batch;     /* per task: the batch index expected next */
    RTCRay **copy;           /* per task: the batch as handed to ray_sink (before tracing) */
    int *copy_n;
    uint64_t *occluded, *mismatch, *bad; /* per task */
} sink_state;

static void sink_before(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride)
{
    sink_state *s = (sink_state *)user;
    if (task < 0 || task >= s->tasks || stride != sizeof(RTCRay) || count < 1 || count > 1024 ||
        batch != s->next_batch[task]) {
        if (task >= 0 && task < s->tasks)
            s->bad[task]++;
        return;
    }
    memcpy(s->copy[task], rays, sizeof(RTCRay) * (size_t)count);
    s->copy_n[task] = count;
    s->rays[task] += (uint64_t)count;
}

/* Each verdict of the batch against truth_intersect1's closest hit on the same ray. */
static void sink_after(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride)
{
    sink_state *s = (sink_state *)user;
    if (task < 0 || task >= s->tasks)
        return;
    if (stride != sizeof(RTCRay) || batch != s->next_batch[task] || count != s->copy_n[task]) {
        s->bad[task]++;
        return;
    }
    s->next_batch[task]++;
    const RTCRay *r = (const RTCRay *)rays, *c = s->copy[task];
    for (int i = 0; i < count; i++) {
        truth_hit h;
        truth_intersect1(s->ts, obs_v3(c[i].org_x, c[i].org_y, c[i].org_z), obs_v3(c[i].dir_x, c[i].dir_y, c[i].dir_z),
                         c[i].tnear, c[i].tfar, &h);
        const int occ = r[i].tfar == -INFINITY;
        s->occluded[task] += (uint64_t)occ;
        s->mismatch[task] += (uint64_t)(occ != (h.instance != 0xFFFFFFFFu));
        /* everything but tfar is as handed out */
        s->bad[task] += (uint64_t)(memcmp(&r[i], &c[i], offsetof(RTCRay, tfar)) != 0);
    }
}

TEST(truth_sss_ray_sink_sees_every_shadow_ray_once)
{
    stu_run R;
    CHECK_MSG(wall_setup(&R, 8, 0), "setup: %s", obs_context_last_error(R.ctx));
    truth_sss_params p = truth_sss_params_default();
    p.min_samples = 4096;
    p.max_samples = 8192;
    p.target_rel_error = 0.05;
    p.tile = 2;
    for (int pass = 0; pass < 2; pass++) {
        if (pass == 1) { /* most candidates kept: several batches per round */
            p.sigma_star = 1e-2;
            p.min_samples = p.max_samples = p.batch = 4096;
        }
        sink_state s;
        memset(&s, 0, sizeof s);
        s.ts = R.ts;
        s.tasks = truth_sss_task_count(8, 8, p.tile);
        s.rays = (uint64_t *)calloc((size_t)s.tasks, sizeof(uint64_t));
        s.next_batch = (int64_t *)calloc((size_t)s.tasks, sizeof(int64_t));
        s.copy = (RTCRay **)calloc((size_t)s.tasks, sizeof(RTCRay *));
        s.copy_n = (int *)calloc((size_t)s.tasks, sizeof(int));
        s.occluded = (uint64_t *)calloc((size_t)s.tasks, sizeof(uint64_t));
        s.mismatch = (uint64_t *)calloc((size_t)s.tasks, sizeof(uint64_t));
        s.bad = (uint64_t *)calloc((size_t)s.tasks, sizeof(uint64_t));
        for (int64_t t = 0; t < s.tasks; t++)
            s.copy[t] = (RTCRay *)obs_aligned_alloc(sizeof(RTCRay) * 1024);
        double trace_s = -1.0;
        uint64_t calls = 0;
        truth_sss_hooks h;
        memset(&h, 0, sizeof h);
        h.ray_sink = sink_before;
        h.traced_sink = sink_after;
        h.user = &s;
        h.time_trace = 1;
        h.trace_seconds = &trace_s;
        h.trace_calls = &calls;
        obs_pool *pool = obs_pool_create(2);
        truth_sss_result res, plain;
        CHECK_OK(render(&R, pool, &p, &h, &res), R.ctx);
        CHECK_OK(render(&R, pool, &p, NULL, &plain), R.ctx);
        CHECK(same_planes(&res, &plain)); /* the hooks change nothing */
        obs_pool_destroy(pool);
        uint64_t rays = 0, batches = 0, occ = 0, mis = 0, bad = 0;
        for (int64_t t = 0; t < s.tasks; t++) {
            rays += s.rays[t];
            batches += (uint64_t)s.next_batch[t];
            occ += s.occluded[t];
            mis += s.mismatch[t];
            bad += s.bad[t];
        }
        CHECK_MSG(rays == res.stats.rays, "sink saw %llu rays, stats.rays %llu", (unsigned long long)rays,
                  (unsigned long long)res.stats.rays);
        CHECK(batches == calls && calls > 0);
        CHECK(bad == 0);
        CHECK_MSG(mis == 0, "%llu of %llu batched verdicts differ from the closest hit", (unsigned long long)mis,
                  (unsigned long long)rays);
        CHECK_MSG(occ > rays / 20 && occ < rays - rays / 20, "occluded %llu of %llu: want both verdicts",
                  (unsigned long long)occ, (unsigned long long)rays);
        CHECK(trace_s >= 0.0);
        printf("pass %d: %llu shadow rays in %llu batches, %llu occluded, %llu verdicts differ from the closest hit\n",
               pass, (unsigned long long)rays, (unsigned long long)batches, (unsigned long long)occ,
               (unsigned long long)mis);
        if (pass == 1)
            CHECK(batches > (uint64_t)res.stats.pixels_surface); /* more than one batch per pixel-round */
        for (int64_t t = 0; t < s.tasks; t++)
            obs_aligned_free(s.copy[t]);
        free(s.rays); free(s.next_batch); free(s.copy); free(s.copy_n); free(s.occluded); free(s.mismatch); free(s.bad);
        truth_sss_result_free(&res);
        truth_sss_result_free(&plain);
    }
    stu_run_free(&R);
}
