/* truth_internal.h: internals of the truth module, shared by truth_scene.c, truth_ao.c and the
 * truth benchmark (bench/bench_truth.c). Not installed; not a public API. Includes Embree. */
#ifndef TRUTH_INTERNAL_H
#define TRUTH_INTERNAL_H

#include "truth.h"

#include <embree3/rtcore.h>
#include <stddef.h>

/* Embree 3's C headers declare the ray structs without typedefs. */
typedef struct RTCRay RTCRay;
typedef struct RTCRayHit RTCRayHit;

struct truth_scene {
    RTCDevice device;
    RTCScene top;            /* the one scene traced: a triangle geometry per flattened instance,
                                an instance geometry per two-level one; geomID = instance index */
    RTCScene *meshes;        /* per obs_mesh: its object-space Embree scene when some instance
                                draws it two-level, else NULL */
    uint32_t mesh_count;
    obs_mat4 *normal_world;  /* per instance: normal matrix of the world transform */
    unsigned char *flat;     /* per instance: 1 flattened (world-space triangles), 0 two-level */
    float *ng_sign;          /* per instance: sign(det) of its 3x3 (truth_intersect1's ng) */
    uint32_t instance_count;
    uint32_t instances_two_level;
    uint64_t triangles_flat;
    int64_t flat_extra_bytes;
    truth_build_quality quality;
    enum RTCSceneFlags scene_flags;
};

/* Hooks into truth_ao_render for the benchmark: ray_sink, when set, is called with the rays of
 * every batch just before they are traced, from worker threads. `rays` points to `count`
 * RTCRay (occlusion estimators) or RTCRayHit (hit-distance estimators), `stride` bytes apart;
 * (tile, batch) pairs are unique, so a sink that stores per tile needs no lock. */
typedef struct truth_ao_hooks {
    void (*ray_sink)(void *user, int64_t tile, int64_t batch, const void *rays, int count, size_t stride);
    void *user;
} truth_ao_hooks;

/* The base-2 Owen scramble of truth_ao.c (docs/truth.md, "Sampling"), n values (any n >= 0):
 * out[k] = bitreverse(LK(v[k], seed[k])), v[k] a coordinate bit-reversed, LK Burley's
 * Laine-Karras permutation. SSE2, 4 at a time; truth_i_owen_scramble1 is its scalar form (the
 * tests check they agree). */
void truth_i_owen_scramble(const uint32_t *v, const uint32_t *seed, int n, uint32_t *out);
uint32_t truth_i_owen_scramble1(uint32_t v, uint32_t seed);

/* AVX2 forms of truth_ao.c's per-pixel sampling (truth_ao_avx2.c; only in OBS_HAVE_AVX2 builds,
 * called only on AVX2 CPUs). Each gives the same bits as its SSE2 reference in truth_ao.c
 * (tests/test_truth_ao.c compares them):
 *   truth_i_seeds_avx2: replicate r's seeds for r < R, Philox(pixel, r, 0, seed) words 0, 1 into
 *     shift[r] and words 2, 3 as (w3 << 32 | w2) into shift3[r] (obs_rng_u32x4_n's streams);
 *   truth_i_owen_scramble_avx2: truth_i_owen_scramble, 8 lanes at a time;
 *   truth_i_hemisphere_rays_avx2: a round of B hemisphere rays (B a multiple of 8) for each of
 *     `count` pixels, as pixel_points, local_dirs, world_dirs and gen_hemisphere_occ / _hit make
 *     them, written to `rays` (count x B RTCRay, or RTCRayHit when hit), pixel after pixel. */
typedef struct truth_i_hemi_in {
    const uint32_t *v0, *v1;      /* the round's points per ray k (bit-reversed), B of each */
    float radius;                 /* tfar */
    int B, m;                     /* rays per pixel, and per replicate (ray k is replicate k / m's) */
    int cosine;                   /* cosine-weighted, else uniform hemisphere */
    int hit;                      /* RTCRayHit records (hit-distance estimators), else RTCRay */
    /* the pixels, in ray order: pixel a is the record at base + active[a] * stride, holding 12
     * floats at `frame` (the ray origin, then the orthonormal basis t, b, n; n the normal) and
     * its replicates' two base-2 Owen seeds, uint32_t[R][2], at `shift` */
    const char *base;
    size_t stride, frame, shift;
    const int *active;
    int count;
} truth_i_hemi_in;
/* Philox's 10 round keys for a seed (the key and its Weyl bumps), each word repeated 8 times: what
 * truth_i_seeds_avx2_k reads instead of deriving them per pixel (truth_ao.c keeps one per job). */
typedef struct truth_i_philox_keys {
    uint32_t k[10][2][8]; /* read unaligned */
} truth_i_philox_keys;
/* The per-pixel set-up of truth_ao.c's setup_pixel for up to 8 pixels of a row at once, for its
 * common case (G-buffer origin, geometric normal, perspective camera, a hemisphere estimator): the
 * same IEEE operations in the same order, lane by lane, so the same bits (truth_i_setup8_avx2). */
typedef struct truth_i_setup8 {
    /* in */
    const float *depth, *nx, *ny, *nz; /* the G-buffer rows (depth, face normal) at the first pixel */
    int count;                         /* pixels, 1..8 (nothing past them is read) */
    double px0, py;                    /* the first pixel's centre and the row's, full-image coordinates */
    const float *world;                /* the camera's world matrix (obs_mat4.m) */
    double cx, cy, inv_fx, inv_fy;     /* the pixel ray's constants (truth_ao.c's pixel_ray) */
    double o[3], mo;                   /* its origin (the eye) and max3abs(o) */
    double k;                          /* offset_ulps * 2^-24 */
    /* out, per pixel */
    float frame[12][8];                /* org, t, b, n (px_state's 12 floats) */
    double p[3][8];                    /* the surface point */
    float ng[3][8];                    /* the geometric normal, facing the viewer */
    double m[8];                       /* max(max3abs(p), mo): the offset's scale before any triangle extent */
    int state[8];                      /* 1 surface, 0 background, -1 invalid normal */
} truth_i_setup8;

#if defined(OBS_HAVE_AVX2)
void truth_i_setup8_avx2(truth_i_setup8 *io);
void truth_i_seeds_avx2(uint64_t pixel, int R, uint64_t seed, uint32_t (*shift)[2], uint64_t *shift3);
/* The same with the keys precomputed; shift3 may be NULL (words 2, 3 are then not computed). */
void truth_i_philox_keys_make(uint64_t seed, truth_i_philox_keys *k);
void truth_i_seeds_avx2_k(uint64_t pixel, int R, const truth_i_philox_keys *keys, uint32_t (*shift)[2],
                          uint64_t *shift3);
/* truth_i_seeds_avx2_k(pixel[i], R, keys, shift[i], NULL) for i < n, in one call. */
void truth_i_seeds_n_avx2_k(int n, const uint64_t *pixel, uint32_t (*const *shift)[2], int R,
                            const truth_i_philox_keys *keys);
void truth_i_owen_scramble_avx2(const uint32_t *v, const uint32_t *seed, int n, uint32_t *out);
void truth_i_hemisphere_rays_avx2(const truth_i_hemi_in *in, void *rays); /* count x B rays */
#endif
/* The SSE2 reference of truth_i_hemisphere_rays_avx2 (any B >= 2; v0[k] = v0[k mod m]), run
 * pixel by pixel as truth_ao_render runs it without AVX2, for the agreement test. 0 when out of
 * memory. */
int truth_i_hemisphere_rays_sse2(const truth_i_hemi_in *in, void *rays);
/* 1 when truth_ao_render runs the AVX2 forms: the build has them, the CPU has AVX2 and the
 * environment's OBS_ISA is not "scalar" (read at each call). */
int truth_i_avx2_active(void);

/* truth_ao_render with hooks (NULL = none). */
obs_status truth_ao_render_ex(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                              const obs_camera *camera, const struct rast_gbuffer *gb, const truth_ao_params *p,
                              truth_ao_result *out, const truth_ao_hooks *hooks);

/* Hooks into truth_sss_render for the benchmark and the tests (truth_sss.c traces the shadow rays
 * of its kept entry candidates in batches of at most 1,024 RTCRay, one rtcOccluded1M call each on
 * ts->top; docs/sss/truth.md, "Shadow rays in batches"). All optional (NULL / 0 = off):
 *   ray_sink     called with each batch just before it is traced, from worker threads;
 *   traced_sink  called with each batch just after (occluded rays have tfar = -inf);
 *                (task, batch) pairs are unique (batch counts from 0 within a task: the tile), so
 *                a sink that stores per task needs no lock; `stride` = sizeof(RTCRay);
 *   time_trace   time every rtcOccluded1M call (obs_time_now before and after), summed over the
 *                tasks into *trace_seconds (the CPU-seconds inside Embree, all threads together);
 *   trace_seconds, trace_calls  out: that sum and the number of batches (calls);
 *   per_ray      trace each shadow ray alone with truth_intersect1 (a closest hit; occluded when
 *                it hits anything within [0, tfar]), the code before the batching: the reference
 *                the tests compare the batched path with (the same bytes). */
typedef struct truth_sss_hooks {
    void (*ray_sink)(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride);
    void (*traced_sink)(void *user, int64_t task, int64_t batch, const void *rays, int count, size_t stride);
    void *user;
    int time_trace;
    double *trace_seconds;
    uint64_t *trace_calls;
    int per_ray;
} truth_sss_hooks;

/* truth_sss_render with hooks (NULL = none: truth_sss_render itself). */
obs_status truth_sss_render_ex(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                               const sss_scene_materials *mats, const obs_camera *camera,
                               const struct rast_gbuffer *gb, const truth_sss_params *p, truth_sss_result *out,
                               const truth_sss_hooks *hooks);

#endif
