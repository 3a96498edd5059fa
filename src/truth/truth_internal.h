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

/* truth_ao_render with hooks (NULL = none). */
obs_status truth_ao_render_ex(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                              const obs_camera *camera, const struct rast_gbuffer *gb, const truth_ao_params *p,
                              truth_ao_result *out, const truth_ao_hooks *hooks);

#endif
