/* truth.h: the public header of obscura's ground-truth module (prefix truth_).
 *
 * An Embree 3 scene built from the same obs_scene the rasterizer draws: one Embree triangle
 * geometry per obs_mesh, placed by one instance per obs_instance with the same float transform,
 * so both see identical geometry. Used for primary-ray agreement tests now, and for ray-traced
 * ambient-occlusion ground truth (docs/truth.md) next.
 *
 * Conventions: world space as in obs.h. Embree is built with the robust flag off and the
 * incoherent context flag (build-notes.md: the coherent flag made AO rays 2.8x slower).
 * Threads that trace must have FTZ/DAZ set (truth_thread_init does it). */
#ifndef TRUTH_H
#define TRUTH_H

#include "../core/obs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct truth_scene truth_scene;

typedef enum truth_build_quality {
    TRUTH_BUILD_LOW = 0,    /* build-notes.md: 6 ms for the bunny */
    TRUTH_BUILD_MEDIUM,     /* default: 17 ms; high (88 ms) gave no traversal gain */
    TRUTH_BUILD_HIGH,
    TRUTH_BUILD_COUNT
} truth_build_quality;

/* Build the Embree scene. Non-finite vertices are kept out (their triangles are removed from
 * the Embree geometry by zeroing them to a degenerate triangle, which Embree never hits).
 * Returns OK, OUT_OF_MEMORY, INTERNAL (Embree error, with Embree's message). */
obs_status truth_scene_create(obs_context *ctx, const obs_scene *scene, truth_build_quality quality,
                              truth_scene **out);
void truth_scene_destroy(truth_scene *ts);

/* Set FTZ and DAZ for the calling thread (Embree asks for it in every tracing thread). */
void truth_thread_init(void);

/* One closest hit. instance = obs_scene instance index, prim = triangle index within its mesh,
 * both RAST_ID_NONE-like (0xFFFFFFFF) on a miss; t = ray parameter (tfar); ng = unit geometric
 * normal in WORLD space, oriented as the triangle's winding (not flipped to face the ray);
 * u, v = Embree's barycentrics of vertices 1 and 2. */
typedef struct truth_hit {
    uint32_t instance, prim;
    float t, u, v;
    obs_vec3 ng;
} truth_hit;

/* Trace one ray (origin, dir; dir need not be unit) with t in [tnear, tfar]. */
void truth_intersect1(const truth_scene *ts, obs_vec3 origin, obs_vec3 dir, float tnear, float tfar,
                      truth_hit *hit);

#ifdef __cplusplus
}
#endif

#endif
