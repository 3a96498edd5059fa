/* truth.h: the public header of obscura's ground-truth module (prefix truth_).
 *
 * An Embree 3 scene built from the same obs_scene the rasterizer draws: by default one
 * world-space Embree triangle geometry per obs_instance (its mesh's vertices through its float
 * transform, computed in double), two-level instancing only where flattening would take too much
 * memory (truth_scene_options), so both see the same geometry. Used for primary-ray agreement tests now, and for ray-traced
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

/* How the Embree scene places the instances (docs/truth.md, "The Embree scene"). */
typedef enum truth_scene_layout {
    TRUTH_SCENE_AUTO = 0,      /* default: flattened, except meshes whose extra copies would take
                                  the flattened memory over flat_limit_bytes (those stay two-level) */
    TRUTH_SCENE_FLAT,          /* every instance flattened, whatever the memory */
    TRUTH_SCENE_INSTANCED,     /* every instance two-level (one Embree instance per obs_instance) */
    TRUTH_SCENE_LAYOUT_COUNT
} truth_scene_layout;

/* Estimated Embree memory per triangle beyond its 12-byte index triple and its vertices: the BVH.
 * Measured with rtcSetDeviceMemoryMonitorFunction (Embree 3.13.5, bunny and dragon): 70 bytes
 * kept after a medium or high build, 99 after a low one, 126 at the build's peak; 100 covers
 * every quality's kept size (docs/truth.md, "The Embree scene"). */
#define TRUTH_SCENE_BVH_BYTES_PER_TRIANGLE 100
/* Default flat_limit_bytes: 1 GiB of EXTRA memory for the flattened copies of meshes drawn more
 * than once (a mesh drawn once costs the same either way): about 9 M extra triangles at ~120
 * bytes each. Past it a scene is one of massive instancing (a forest of one tree), where copies
 * would cost gigabytes and the two-level scene is the point; below it flat tracing wins (issue 13:
 * raw rtcOccluded1M traced the bench's bunny rays about 1.8x faster flat than through one
 * instance; docs/truth.md). */
#define TRUTH_SCENE_FLAT_LIMIT_BYTES ((int64_t)1 << 30)

typedef struct truth_scene_options {
    truth_build_quality quality;  /* default TRUTH_BUILD_MEDIUM */
    truth_scene_layout layout;    /* default TRUTH_SCENE_AUTO */
    int64_t flat_limit_bytes;     /* AUTO only: the most extra bytes (estimated as
                                     truth_scene_mesh_bytes per extra copy) flattening may add;
                                     >= 0; default TRUTH_SCENE_FLAT_LIMIT_BYTES */
} truth_scene_options;

truth_scene_options truth_scene_options_default(void);
const char *truth_scene_layout_name(truth_scene_layout l); /* "auto", "flat", "instanced" ("?") */
/* The estimate of one flattened copy of a mesh: 16 bytes a vertex, 12 + the BVH estimate a triangle. */
int64_t truth_scene_mesh_bytes(const obs_mesh *mesh);

/* Build the Embree scene. Non-finite vertices are kept out (their triangles are removed from
 * the Embree geometry by zeroing them to a degenerate triangle, which Embree never hits); a
 * flattened instance takes its vertices to world space in double, rounded once to float.
 * truth_scene_create is truth_scene_create_ex with the default options and the given quality.
 * Returns OK, INVALID_ARGUMENT (a NULL, an option out of range, an instance naming no mesh),
 * OUT_OF_MEMORY, INTERNAL (Embree error, with Embree's message). */
obs_status truth_scene_create(obs_context *ctx, const obs_scene *scene, truth_build_quality quality,
                              truth_scene **out);
obs_status truth_scene_create_ex(obs_context *ctx, const obs_scene *scene, const truth_scene_options *options,
                                 truth_scene **out);

/* What was built. */
typedef struct truth_scene_info {
    uint32_t instances_flat;       /* instances flattened into world-space triangles */
    uint32_t instances_two_level;  /* instances kept as Embree instances */
    uint64_t triangles_flat;       /* world-space triangles in the top-level scene */
    int64_t flat_extra_bytes;      /* estimated extra bytes of the flattened copies */
    truth_build_quality quality;
    unsigned scene_flags;          /* Embree's RTCSceneFlags of every scene (RTC_SCENE_FLAG_NONE) */
} truth_scene_info;
void truth_scene_get_info(const truth_scene *ts, truth_scene_info *info);
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

/* ================================================================================================
 * AO ground truth (truth_ao.c; every integral, the sampling, the offset rule and the convergence
 * test are written out in docs/truth.md; the definitions are ../shared/reference/ao.md section 2)
 * ================================================================================================
 *
 * For each pixel of a G-buffer from our rasterizer, the origin p is the G-buffer point (pixel ray
 * and linear depth) or an Embree primary hit, and n is the geometric (face) normal or the
 * shading normal, both facing the viewer. The estimators (V = visibility, 1 = unoccluded; t(w) =
 * distance to the first hit along direction w, infinity on a miss; theta = angle from n):
 *
 *   COS             V = (1/pi)  Int_H [t(w) > r] cos(theta) dw        GT-cos(r), XeGTAO's reference
 *   UNIF            V = (1/2pi) Int_H [t(w) > r] dw                   GT-unif(r)
 *   OBS_SAO_B       V = 1 - (1/pi) Int_H rho(t) cos(theta) dw, rho(d) = (1 - d^2/r^2)^3 for d < r, else 0
 *   OBS_SAO_LINEAR  as OBS_SAO_B with rho(d) = 1 - d^2/r^2           (G3D's high-quality SAO)
 *   OBS_MSSAO       as OBS_SAO_B with rho(d) = 1 - d^2/dMax^2, dMax = r   (the same integral as
 *                   OBS_SAO_LINEAR: both names exist so each method's pairing reads explicitly)
 *   OBS_HBAO        V = 1 - (1/2pi) Int_H rho(t) dw, rho(d) = 1 - d^2/R^2, R = r: UNIFORM weighting,
 *                   classic HBAO's slice integral (Bavoil & Sainz 2008; ao.md 1.6 and 2). HBAO+ and
 *                   gl_ssao weight by cos instead: their reference is OBS_MSSAO.
 *   VOL             V = fraction of the ball B(p, r) whose points q are visible from the eye (the
 *                   segment eye->q meets no surface): the "camera-visibility variant" of GT-vol(r)
 *                   (ao.md 2), the quantity Crytek SSAO approximates; a lone plane gives 1/2.
 *
 * COS and UNIF accept r = INFINITY; the others need a finite r. */

struct rast_gbuffer; /* raster/raster.h */

typedef enum truth_ao_estimator {
    TRUTH_AO_COS = 0,
    TRUTH_AO_UNIF,
    TRUTH_AO_OBS_SAO_B,
    TRUTH_AO_OBS_SAO_LINEAR,
    TRUTH_AO_OBS_MSSAO,
    TRUTH_AO_OBS_HBAO,
    TRUTH_AO_VOL,
    TRUTH_AO_COUNT
} truth_ao_estimator;

typedef enum truth_ao_normal {
    TRUTH_AO_NORMAL_GEOMETRIC = 0,  /* the triangle's normal: XeGTAO's RT reference (ao.md 1.8) */
    TRUTH_AO_NORMAL_SHADING,        /* interpolated vertex normals; directions below the geometric
                                       tangent plane are blocked by the surface itself */
    TRUTH_AO_NORMAL_COUNT
} truth_ao_normal;

/* What the std_error plane holds. The stopping rule always uses max(s_R, floor(n)). */
typedef enum truth_ao_error_bar {
    TRUTH_AO_BAR_FLOORED = 0,       /* max(s_R, floor(n)): never 0 on a surface (default) */
    TRUTH_AO_BAR_REPLICATES,        /* s_R alone: with a fixed count (min = max) its square is an
                                       unbiased estimate of the variance of the mean, what a study
                                       subtracts from its squared errors (docs/study.md); 0 where
                                       every replicate agrees */
    TRUTH_AO_BAR_COUNT
} truth_ao_error_bar;

typedef enum truth_ao_origin {
    TRUTH_AO_ORIGIN_GBUFFER = 0,    /* pixel ray origin + depth * ray direction (rast_pixel_ray) */
    TRUTH_AO_ORIGIN_EMBREE,         /* the Embree primary hit along the same pixel ray */
    TRUTH_AO_ORIGIN_COUNT
} truth_ao_origin;

/* Progress: called on the calling thread only, after each task it finishes (one or more tiles;
 * tiles finished by other threads are counted too). rays = AO rays traced so far. */
typedef void (*truth_progress_fn)(void *user, int64_t tiles_done, int64_t tiles_total, uint64_t rays);

typedef struct truth_ao_params {
    truth_ao_estimator estimator; /* default TRUTH_AO_COS (ao.md 2: the common target) */
    float radius;                 /* r in world units, > 0; INFINITY allowed for COS and UNIF.
                                     Default 0.5: XeGTAO's default Radius (ao.md 1.8) */
    double target_error;          /* stop a pixel when its error bar <= this (and min_samples are
                                     done); >= 0. Default 0.002 (issue 3, "for example 0.002"). The
                                     error bar is max(replicate standard error, floor(n)), where
                                     floor(n) is the Agresti-Coull standard error of n identical
                                     outcomes (docs/truth.md, "Convergence"): identical samples
                                     cannot stop a pixel before floor(n) <= target_error */
    int64_t min_samples;          /* default 64; a positive multiple of batch */
    int64_t max_samples;          /* default 4096; a multiple of batch, >= min_samples, <= 2^31, and
                                     <= obs_limits.max_samples (LIMIT_EXCEEDED otherwise) */
    int batch;                    /* B, samples per pixel per round, in [2, 1024], a multiple of
                                     replicates. Default 16: 16 rays per pixel of an 8x8 tile is the
                                     1024-ray rtcOccluded1M batch that build-notes.md measured fastest */
    int replicates;               /* R, independent randomisations of the point set per pixel, in
                                     [2, TRUTH_AO_MAX_REPLICATES]; each takes B/R samples a round. The
                                     standard error is the spread of their means (randomised QMC,
                                     [LEcuyer02]). Default 8 (docs/truth.md, "Convergence": 7 degrees
                                     of freedom; the calibration test's choice) */
    uint64_t seed;                /* default 0; output is a function of (inputs, params, seed) only,
                                     not of the thread count, tile size or guard band */
    truth_ao_normal normal;       /* default TRUTH_AO_NORMAL_GEOMETRIC */
    truth_ao_origin origin;       /* default TRUTH_AO_ORIGIN_GBUFFER (issue 3, item 1) */
    int tile;                     /* tile side in pixels, in [4, 32]; default 8 (build-notes.md) */
    float offset_ulps;            /* k of the self-intersection offset eps = k * 2^-24 * m along the
                                     geometric normal, m = max(|p|inf, |eye|inf, triangle extent);
                                     >= 0, default 64 (docs/truth.md, "Self-intersection") */
    truth_ao_error_bar error_bar; /* default TRUTH_AO_BAR_FLOORED */
    truth_progress_fn progress;   /* default NULL */
    void *progress_user;
} truth_ao_params;

#define TRUTH_AO_MAX_REPLICATES 32
/* The floor's z: Agresti & Coull's "add two successes and two failures" (z^2 = 4, a 95% interval). */
#define TRUTH_AO_FLOOR_Z 2.0

truth_ao_params truth_ao_params_default(void);

/* floor(n) = sqrt(p (1 - p) / (n + z^2)), p = (z^2 / 2) / (n + z^2), z = TRUTH_AO_FLOOR_Z: the
 * Agresti-Coull standard error of a proportion seen n times out of n (or 0 times), the smallest it
 * gives for any outcome [Agresti98]. About 1.41 / n. */
double truth_ao_error_floor(int64_t n);

/* "cos", "unif", "obs-sao", "obs-sao-linear", "obs-mssao", "obs-hbao", "vol" ("?" if out of range). */
const char *truth_ao_estimator_name(truth_ao_estimator e);
/* The inverse; returns 1 and sets *out, or 0 for an unknown name. */
int truth_ao_estimator_from_name(const char *name, truth_ao_estimator *out);

typedef struct truth_ao_stats {
    uint64_t rays;              /* AO rays traced (occlusion, hit-distance or VOL segments) */
    uint64_t primary_rays;      /* Embree primary rays (TRUTH_AO_ORIGIN_EMBREE only) */
    int64_t pixels_surface;     /* pixels with a surface: count > 0 */
    int64_t pixels_background;  /* no surface (depth +inf, or an Embree miss): count = 0 */
    int64_t pixels_invalid;     /* a surface with an unusable normal (zero, non-finite): count = 0 */
    int64_t pixels_converged;   /* surface pixels whose error bar (std_error) of THIS output is
                                   <= target_error when they stopped */
    int64_t pixels_at_max;      /* surface pixels that reached max_samples */
    double max_std_error;       /* of this output's std_error plane, over surface pixels */
    double max_offset;          /* the largest self-intersection offset eps used, world units */
    double seconds;             /* wall time of the whole call */
    double seconds_work;        /* of which the tile work: sampling, tracing, accumulation (not the
                                   validation, set-up and allocation of the output planes) */
} truth_ao_stats;

/* Planes of the INNER image (the G-buffer without its guard band), row 0 at the top. Pixels with
 * no usable surface (background, invalid normal) hold mean 1, std_error 0, count 0: count is the
 * validity mask. No plane ever holds NaN or infinity. */
typedef struct truth_ao_result {
    int width, height;
    obs_image_f32 mean;         /* estimated visibility V in [0, 1] */
    obs_image_f32 std_error;    /* the error bar of mean: max(s_R, floor(n)), s_R the standard
                                   error from the spread of the R replicates' means [LEcuyer02],
                                   floor(n) = truth_ao_error_floor (docs/truth.md, "Convergence");
                                   s_R alone with error_bar = TRUTH_AO_BAR_REPLICATES */
    obs_image_f32 count;        /* samples taken (an integer; exact in float up to 2^24) */
    truth_ao_stats stats;
} truth_ao_result;

/* Estimate the AO ground truth for every pixel of gb.
 *   ts     the Embree scene built (truth_scene_create) from `scene`, the scene gb was rendered from;
 *   camera the camera gb was rendered with; gb holds the constants (rast_render fills them).
 *   gb must hold, for TRUTH_AO_ORIGIN_GBUFFER: RAST_OUT_DEPTH, RAST_OUT_FACE_NORMAL,
 *   RAST_OUT_PRIM_ID and RAST_OUT_INSTANCE_ID (+ RAST_OUT_NORMAL for the shading normal);
 *   for TRUTH_AO_ORIGIN_EMBREE only its size and constants are used.
 * The output is identical for any pool (NULL = serial) and thread count. *out is allocated here
 * (free it with truth_ao_result_free) and left zeroed on failure.
 * Returns: OK; INVALID_ARGUMENT (a NULL, a parameter out of its documented range, a missing
 * G-buffer plane, a G-buffer not rendered yet, an Embree scene from another scene: the message
 * names it); LIMIT_EXCEEDED (max_samples over obs_limits.max_samples, image or scratch size over
 * the limits); OUT_OF_MEMORY. */
obs_status truth_ao_render(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                           const obs_camera *camera, const struct rast_gbuffer *gb, const truth_ao_params *p,
                           truth_ao_result *out);
void truth_ao_result_free(truth_ao_result *r);   /* NULL-safe; zeroes it */

/* Several estimates from ONE set of rays: a study needs every estimator at several radii on the
 * same G-buffer, and the hemisphere estimators that share a direction distribution differ only in
 * what they make of the hit distance t. The rays go to the largest radius with a hit record; for
 * an output of radius r <= r_max the closest hit within r_max is its closest hit within r when
 * t <= r, so each output is the estimate its own truth_ao_render would compute from the same
 * rays (the same directions: they depend on pixel, sample index and seed only). A pixel stops
 * when EVERY output's error bar is <= target_error (after min_samples), or at max_samples:
 * every output of a pixel has the same count. Outputs must be all cosine-weighted (COS,
 * OBS_SAO_B, OBS_SAO_LINEAR, OBS_MSSAO) or all uniform (UNIF, OBS_HBAO), in any order; VOL only
 * alone. p->estimator and p->radius are ignored; the rest of p as for truth_ao_render.
 * out[0..count-1] are allocated here (free each with truth_ao_result_free). Each output's stats
 * share the ray set's counters (rays, pixels, at_max, times) and have their own
 * pixels_converged and max_std_error. With count 1 the result is bit-identical to
 * truth_ao_render's. */
#define TRUTH_AO_MAX_OUTPUTS 16
typedef struct truth_ao_output {
    truth_ao_estimator estimator;
    float radius;
} truth_ao_output;

obs_status truth_ao_render_multi(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const struct rast_gbuffer *gb, const truth_ao_params *p,
                                 const truth_ao_output *outputs, int count, truth_ao_result *out);

/* Subsets of the image's tasks (scale-out over MPI ranks, docs/scale.md). truth_ao_render splits
 * the inner image into tiles of p->tile pixels (row-major), and hands its thread pool TASKS: runs
 * of ceil(16 / tile) horizontally adjacent tiles of one tile row (one tile for tile >= 16), row-
 * major. A pixel's result depends on (inputs, params, seed) only, so any partition of the tasks,
 * rendered anywhere and put together, equals the whole image bit for bit.
 * truth_ao_task_count: the number of tasks of a width x height inner image (0 for a bad size or tile).
 * truth_ao_task_rect: task `task`'s pixel rectangle [x0, x1) x [y0, y1) of the inner image. */
int64_t truth_ao_task_count(int width, int height, int tile);
void truth_ao_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1);

/* truth_ao_render for the tasks whose task_mask[task] is nonzero only (task_mask holds
 * truth_ao_task_count bytes; NULL = every task, truth_ao_render itself). The pixels of the
 * selected tasks are bit-identical to truth_ao_render's; the others hold mean 0, std_error 0 and
 * count 0 (not the background's mean 1). The stats count the selected tasks only: their sums
 * (rays, pixels) and maxima (max_std_error, max_offset) over any partition combine to
 * truth_ao_render's. Returns as truth_ao_render. */
obs_status truth_ao_render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const struct rast_gbuffer *gb, const truth_ao_params *p,
                                 const unsigned char *task_mask, truth_ao_result *out);

/* ============================================ end of AO ground truth ============================ */

/* ================================================================================================
 * SSS ground truth (truth_sss.c; the estimators, their pdfs and weights, the statistics and the
 * measured biases are written out in docs/sss/truth.md; facts in ../shared/reference/sss.md s4)
 * ================================================================================================
 *
 * For each camera pixel on a translucent surface: x_o = pixel ray origin + depth * ray direction
 * (rast_pixel_ray, as TRUTH_AO_ORIGIN_GBUFFER), n_o = the outward (winding) normal of the G-buffer's
 * triangle in world space, w_o = unit direction to the camera. Both estimate the radiance
 * L_o(x_o, w_o) leaving the surface by subsurface scattering of the scene's directional and point
 * lights (E(x_i) = colour * intensity * max(0, n_i.w_i) * V(x_i -> light), / d^2 for a point
 * light), entering over the lit surface of the SAME instance:
 *
 *   TRUTH_SSS_BRUTE_FORCE  ("method" reference, the BSSRDF held fixed; Frisvad's dirpole.cpp
 *       trace(), sss.md s4): L_o = T21(n_o.w_o) Int_A T12(n_i.w_i) S_d(x_i, w_i; x_o) E(x_i) dA,
 *       S_d = sss_sd of params.model, the same constants as the scattering maps.
 *   TRUTH_SSS_RANDOM_WALK  ("model" reference: radiative transfer in the closed mesh, unreduced
 *       sigma_s, sigma_a, Henyey-Greenstein g, Fresnel boundary of relative index eta):
 *       photons enter at x_i as above, walk inside; every collision scores, by a collision
 *       estimator, the radiance it sends along the refracted view direction to a surface disk of
 *       radius patch_radius around x_o (the patch average; docs/sss/truth.md, "Random walk").
 *
 * Entry points (both): a candidate x_i uniform on the instance's world-space area (triangle CDF),
 * kept with probability p = exp(-sigma* |x_i - x_o|) (Russian roulette, dirpole.cpp), weight
 * A / p; sigma* = min over channels of sigma_tr unless params.sigma_star > 0.
 * Randomness is a function of (pixel, candidate index, dimension, seed) only. A "sample" is one
 * candidate (kept or not). Candidate k belongs to replicate k mod R; the error bar is the
 * standard error from the spread of the R replicates' means (as truth_ao, docs/truth.md s5). */

#include "../sss/sss.h"

typedef enum truth_sss_estimator {
    TRUTH_SSS_BRUTE_FORCE = 0,
    TRUTH_SSS_RANDOM_WALK,
    TRUTH_SSS_ESTIMATOR_COUNT
} truth_sss_estimator;
const char *truth_sss_estimator_name(truth_sss_estimator e);      /* "brute-force", "random-walk" */
int truth_sss_estimator_from_name(const char *name, truth_sss_estimator *out);

#define TRUTH_SSS_MAX_REPLICATES 32

typedef struct truth_sss_params {
    truth_sss_estimator estimator;  /* default TRUTH_SSS_BRUTE_FORCE */
    sss_model model;                /* brute force: the BSSRDF; default SSS_MODEL_DIRECTIONAL (the maps') */
    double target_rel_error;        /* stop a pixel when SE(Y) <= target_rel_error * Y, Y the luminance
                                       0.2126 R + 0.7152 G + 0.0722 B of the estimate and SE(Y) its
                                       replicate standard error; > 0, finite. Default 0.01 */
    int64_t min_samples;            /* candidates per pixel; a positive multiple of batch; default 16384 */
    int64_t max_samples;            /* multiple of batch, >= min_samples, <= obs_limits.max_samples
                                       (LIMIT_EXCEEDED otherwise); default 1048576 (= the default limit) */
    int batch;                      /* candidates per pixel per round, a multiple of replicates, in
                                       [replicates, 65536]; default 4096 */
    int replicates;                 /* R in [2, TRUTH_SSS_MAX_REPLICATES]; default 8 (as truth_ao) */
    double sigma_star;              /* roulette rate per scene unit; 0 = min sigma_tr (default, dirpole.cpp) */
    double patch_radius;            /* random walk: rho, world units, > 0 finite; default 0.05 */
    int max_bounces;                /* random walk: events (collisions + reflections) before a walk is
                                       dropped and counted lost; default 1000000 */
    float offset_ulps;              /* self-intersection offset k * 2^-24 * max(|p|inf, scene extent),
                                       as truth_ao; >= 0, default 64 */
    int tile;                       /* tile side in pixels, [1, 64]; default 4 */
    uint64_t seed;                  /* default 0 */
    truth_progress_fn progress;     /* default NULL; rays = Embree rays so far */
    void *progress_user;
} truth_sss_params;

truth_sss_params truth_sss_params_default(void);
/* Range checks (NaN refused). Returns OK or INVALID_ARGUMENT naming the field. ctx may be NULL. */
obs_status truth_sss_params_validate(obs_context *ctx, const truth_sss_params *p);

typedef struct truth_sss_stats {
    uint64_t candidates;            /* entry candidates drawn */
    uint64_t accepted;              /* kept by the roulette */
    uint64_t rays;                  /* Embree rays: shadow, walk and scoring rays */
    uint64_t walk_events;           /* random walk: collisions and boundary events */
    uint64_t walks_lost;            /* random walk: walks ended by a hit on another instance, a hit
                                       from outside (a leak) or max_bounces (should be 0) */
    int64_t pixels_surface;         /* translucent surface pixels estimated (count > 0) */
    int64_t pixels_skipped;         /* background, opaque, or seen from inside (n_o.w_o <= 0) */
    int64_t pixels_converged;       /* stopped with SE(Y) <= target_rel_error * Y */
    int64_t pixels_at_max;          /* reached max_samples */
    double seconds;
} truth_sss_stats;

/* Planes of the INNER image, row 0 at the top; background and opaque pixels hold 0, count 0. */
typedef struct truth_sss_result {
    int width, height;
    obs_image_f32 radiance[3];      /* L_o, RGB, the lights' units per sr */
    obs_image_f32 std_error[3];     /* replicate standard error of each channel */
    obs_image_f32 count;            /* candidates used (the mask: 0 = not estimated) */
    truth_sss_stats stats;
} truth_sss_result;

/* Estimate the SSS ground truth for every pixel of gb (which must hold RAST_OUT_DEPTH,
 * RAST_OUT_PRIM_ID and RAST_OUT_INSTANCE_ID; rendered from `scene` with `camera`). ts is the
 * Embree scene of `scene` (truth_scene_create); mats as for sss_maps_build. Lights: the scene's
 * directional and point lights (a spot light is UNSUPPORTED; range is ignored).
 * The random walk refuses (INVALID_ARGUMENT, naming the mesh and instance) a translucent instance
 * whose mesh is not closed: after welding vertices of equal position, every edge of a
 * non-degenerate triangle must be shared by exactly two triangles.
 * Output identical for any pool and thread count. *out allocated here (truth_sss_result_free),
 * zeroed on failure. Returns OK, INVALID_ARGUMENT, UNSUPPORTED, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status truth_sss_render(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                            const sss_scene_materials *mats, const obs_camera *camera, const struct rast_gbuffer *gb,
                            const truth_sss_params *p, truth_sss_result *out);
void truth_sss_result_free(truth_sss_result *r);   /* NULL-safe; zeroes it */

/* Subsets of the image's tasks (scale-out over MPI ranks, docs/scale.md), as truth_ao's.
 * truth_sss_render hands its thread pool TASKS: the tiles of p->tile pixels of the inner image,
 * row-major (obs_tiling). A pixel's result depends on (inputs, params, seed) only, so any
 * partition of the tasks, rendered anywhere and put together, equals the whole image bit for bit.
 * truth_sss_task_count: the number of tasks of a width x height inner image (0 for a bad size or
 * a tile outside [1, 64]). truth_sss_task_rect: task `task`'s pixel rectangle [x0, x1) x [y0, y1). */
int64_t truth_sss_task_count(int width, int height, int tile);
void truth_sss_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1);

/* truth_sss_render for the tasks whose task_mask[task] is nonzero only (task_mask holds
 * truth_sss_task_count bytes; NULL = every task, truth_sss_render itself). The pixels of the
 * selected tasks are bit-identical to truth_sss_render's; the others hold 0 in every plane. The
 * stats count the selected tasks only (all sums: over any partition they add up to
 * truth_sss_render's); seconds is this call's. Returns as truth_sss_render. */
obs_status truth_sss_render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                  const sss_scene_materials *mats, const obs_camera *camera,
                                  const struct rast_gbuffer *gb, const truth_sss_params *p,
                                  const unsigned char *task_mask, truth_sss_result *out);

/* The random walk's flux reflectance from one entry point: `count` photons of unit power enter
 * instance `instance` at x_i (on its surface, outward normal n_i) along direction `dir` (already
 * inside the medium, dir.n_i < 0; no entry Fresnel), channel `channel`; *reflectance = the mean
 * fraction of the power that escapes (anywhere), *std_error its i.i.d. standard error. Photon k
 * uses the stream (pixel 0, sample k, seed). For the slab tests (H-function, docs/sss/truth.md).
 * Returns OK or INVALID_ARGUMENT (NULLs, count < 2, an open or non-translucent instance). */
obs_status truth_sss_walk_reflectance(obs_context *ctx, const truth_scene *ts, const obs_scene *scene,
                                      const sss_scene_materials *mats, uint32_t instance, const double x_i[3],
                                      const double n_i[3], const double dir[3], int channel, int64_t count,
                                      uint64_t seed, double *reflectance, double *std_error);

/* 1 when every edge of mesh `mesh` (vertices welded by equal position, degenerate triangles
 * skipped) is shared by exactly two triangles; 0 otherwise (*open_edges, may be NULL, gets the
 * number of edges that are not), or -1 when out of memory. */
int truth_sss_mesh_is_closed(const obs_mesh *mesh, uint64_t *open_edges);

/* ============================================ end of SSS ground truth =========================== */

/* ============================================ volume light ground truth ========================= */
/* truth_volume.c: the exact hard-shadow transmittance that the light volume of [Ropinski10]
 * (vol.h section 3) approximates (docs/volume/light.md, "Ground truth"; volume.md 1.9):
 *   T(x) = exp(-integral_0^L sigma_t(x + t w) dt),
 * w the unit direction towards the light, L the distance to the point light or to where the ray
 * leaves the data's bounds (vol_grid_bounds); sigma_t = -kappa ln(1 - alpha_TF(s)) / ref_step
 * (vol.h's convention, vol_sigma_from_alpha; ref_step 0 = the smallest spacing), s the data's
 * trilinear value, 0 outside the bounds. Trapezoid rule with step step_fraction x the smallest
 * spacing: second order in the step (sigma is not linear in s across a cell, so no step is exact
 * there; docs/volume/light.md measures the error). */
struct vol_grid;
struct vol_tf;
struct vol_light;
struct vol_light_volume;

typedef struct truth_volume_params {
    double kappa;                   /* extinction scale, as vol_lv_params.kappa; default 1 */
    double step_fraction;           /* march step / smallest spacing, (0, 1]; default 1/16 (the
                                       march's error is second order: 2.7e-5 in transmittance on
                                       a ramped slab at 1/16, docs/volume/light.md) */
} truth_volume_params;
truth_volume_params truth_volume_params_default(void);

/* T(x) at one world point (directional or point light; no checks: valid inputs assumed). */
double truth_volume_transmittance_at(const struct vol_grid *g, const struct vol_tf *tf,
                                     const struct vol_light *light, const truth_volume_params *p,
                                     const double x[3]);

typedef struct truth_volume_error_stats {
    double max_abs;                 /* max |l - T| over the light volume's voxels */
    double mean_abs, rmse;          /* mean |l - T| and root mean square of l - T */
    double mean_signed;             /* mean of l - T (> 0: the light volume is too bright) */
    int64_t argmax;                 /* voxel index (x fastest) of max_abs */
    int64_t voxels;
} truth_volume_error_stats;

/* T at every voxel centre of lv (built from g, tf, light) and the error volume err = lv->l - T.
 * *T_out and *err_out (either pointer may be NULL: not wanted) get lv->nx*ny*nz floats, x fastest,
 * allocated here (free with obs_aligned_free). stats (may be NULL) are reduced in voxel order.
 * Output identical for any pool and thread count.
 * Returns OK, INVALID_ARGUMENT (NULLs, kappa < 0 or non-finite, step_fraction outside (0, 1], a zero
 * direction, a non-finite position), UNSUPPORTED (spot light), OUT_OF_MEMORY. */
obs_status truth_volume_light_error(obs_context *ctx, obs_pool *pool, const struct vol_grid *g,
                                    const struct vol_tf *tf, const struct vol_light *light,
                                    const truth_volume_params *p, const struct vol_light_volume *lv,
                                    float **T_out, float **err_out, truth_volume_error_stats *stats);

/* ---- The Monte Carlo single-scattering image reference (truth_volume.c; docs/volume/truth.md) ----
 * What it computes, per pixel (the ray caster's camera ray, rast_pixel_ray, t in [znear, zfar]
 * clipped to the data's bounds; d_hat its unit direction, s the distance along it):
 *
 *   L = Int_0^D T_v(s) sigma_t(x) rho(x) E f(x) T(x) ds      (premultiplied RGB over black)
 *   A = 1 - T_v(D)                                           (its alpha)
 *
 * T_v the view transmittance, sigma_t vol.h's extinction (kappa as given), rho = the TF's RGB (the
 * scattering albedo/colour), E the light's colour (no distance fall-off for a point light, as the
 * light volume and the ray caster), T(x) the exact transmittance to the light (as above), and the
 * phase factor f = 4 pi p_HG(w_in . w_out) [Henyey41] (w_in the light's travel direction at x, w_out =
 * -d_hat): f = 1 for g = 0, which is the ray caster's light-volume mode with c = 1 (docs/volume/
 * truth.md derives the match). It is single scattering with hard shadows: the light volume's l part.
 * Its cone-blurred chromaticity c has no ground truth here (it is not the solution of a transport
 * equation: docs/volume/truth.md says why).
 * Estimator: free-flight distances by delta (Woodcock) tracking against piecewise-constant
 * majorants, one per min-max brick of 8^3 voxels (the largest sigma_t the TF gives over the brick's
 * value range, with a one-voxel apron); at the real collision, T(x) by ratio tracking against the
 * same majorants (with Russian roulette below 1e-2);
 * both unbiased ([Woodcock65], [Novak14]). Sample k of a pixel draws its numbers from
 * obs_rng_u32x4(pixel, k, dimension 0, 1, 2 ..., seed) and belongs to replicate k mod R; the error
 * bar is the spread of the R replicates' means (docs/truth.md section 5, as truth_ao / truth_sss).
 * Output identical for any pool and thread count. */
typedef struct truth_volume_mc_params {
    int64_t samples;                /* per pixel, a multiple of replicates, [replicates, obs_limits.max_samples];
                                       default 256 */
    int replicates;                 /* R in [2, TRUTH_VOLUME_MC_MAX_REPLICATES]; default 8 (as truth_ao) */
    double g;                       /* Henyey-Greenstein asymmetry, (-1, 1); default 0 (f = 1: the ray caster's model) */
    double kappa;                   /* extinction scale, >= 0; default 1 (as vol_lv_params) */
    uint64_t seed;                  /* default 0 */
    int tile;                       /* tile side in pixels, [1, 64]; default 8 */
    const obs_image_f32 *depth_limit; /* optional (default NULL): per pixel, the linear view depth
                                       where the view ray stops (the hybrid scene's rasterized mesh
                                       depth, as vol_raycast's depth_limit; +inf or NaN: none);
                                       width x height */
    /* Optional (default NULL): the visibility in [0, 1] of the segment from x towards the light
     * (unit direction w; length dist, +inf for a directional light) through what the volume does
     * not hold (the hybrid scene's meshes): every shadow ray's transmittance is multiplied by it.
     * Called from the pool's threads: thread-safe and a function of its arguments only. */
    double (*visibility)(void *user, const double x[3], const double w[3], double dist);
    void *visibility_user;
} truth_volume_mc_params;
#define TRUTH_VOLUME_MC_MAX_REPLICATES 32
truth_volume_mc_params truth_volume_mc_params_default(void);

typedef struct truth_volume_mc_stats {
    uint64_t tentative;             /* delta/ratio tracking steps (sigma_t evaluations) */
    uint64_t collisions;            /* real collisions (shadow rays traced) */
    uint64_t over_majorant;         /* sigma_t found above the majorant (should be 0) */
    int64_t pixels_hit;             /* pixels whose ray meets the bounds */
    double majorant;                /* the largest brick majorant, per world unit */
    double max_std_error;           /* over the RGB planes */
    double seconds;
} truth_volume_mc_stats;

/* Planes, row 0 at the top. The deterministic march (truth_volume_march_image) leaves std_error 0. */
typedef struct truth_volume_image {
    int width, height;
    obs_image_f32 rgba[4];          /* L (RGB) and A */
    obs_image_f32 std_error[4];     /* replicate standard error of each */
    truth_volume_mc_stats stats;
} truth_volume_image;
void truth_volume_image_free(truth_volume_image *im);   /* NULL-safe; zeroes it */

/* The Monte Carlo reference for camera at width x height. *out allocated here, zeroed on failure.
 * Returns OK, INVALID_ARGUMENT (NULLs, a parameter out of range, an empty grid, a bad camera),
 * UNSUPPORTED (spot light), LIMIT_EXCEEDED (samples over obs_limits.max_samples, image too large),
 * OUT_OF_MEMORY. */
obs_status truth_volume_mc_render(obs_context *ctx, obs_pool *pool, const struct vol_grid *g,
                                  const struct vol_tf *tf, const struct vol_light *light, const obs_camera *camera,
                                  int width, int height, const truth_volume_mc_params *p, truth_volume_image *out);

/* The same integral by a deterministic fine-step march (the ray caster with the exact
 * transmittance): steps of `step` world units along the view ray (the last shorter), each sampled
 * at its midpoint, a = 1 - exp(-sigma_t len), C += T_v a rho E f T(x), T_v *= 1 - a, no early
 * termination; T(x) by truth_volume_transmittance_at with tp (tp->kappa is used for both). Second
 * order in step. For the MC's agreement test and small studies (it costs a shadow march per
 * non-empty sample). Same returns as truth_volume_mc_render (mc->samples, replicates, seed unused). */
obs_status truth_volume_march_image(obs_context *ctx, obs_pool *pool, const struct vol_grid *g,
                                    const struct vol_tf *tf, const struct vol_light *light, const obs_camera *camera,
                                    int width, int height, double step, const truth_volume_params *tp,
                                    double g_hg, truth_volume_image *out);

/* ---- Splitting the work (MPI: docs/scale.md) ----
 * The light volume's error by z slices: T and err (caller's arrays, lv->nx*ny*nz floats each, x
 * fastest) get the slices k with slice_mask[k] (NULL: all), the others untouched; the values are
 * truth_volume_light_error's bit for bit (a voxel depends on its position only). Same checks and
 * returns as truth_volume_light_error (OUT_OF_MEMORY aside). */
obs_status truth_volume_light_error_slices(obs_context *ctx, obs_pool *pool, const struct vol_grid *g,
                                           const struct vol_tf *tf, const struct vol_light *light,
                                           const truth_volume_params *p, const struct vol_light_volume *lv,
                                           const unsigned char *slice_mask, float *T, float *err);
/* truth_volume_light_error's statistics of an error volume of `voxels` floats (in voxel order). */
void truth_volume_error_stats_compute(const float *err, int64_t voxels, truth_volume_error_stats *stats);

/* The MC image's tasks: its tiles of side `tile` (the pool's; obs_tiling order). count 0 for a bad
 * size or tile. truth_volume_mc_render_tasks is truth_volume_mc_render computing only the tiles t
 * with task_mask[t] (ntasks = truth_volume_mc_task_count entries): their pixels are
 * truth_volume_mc_render's bit for bit (a pixel depends on (inputs, pixel, sample, seed) only), the
 * other pixels 0, and the stats count the computed tiles only (majorant: the whole grid's). */
int64_t truth_volume_mc_task_count(int width, int height, int tile);
void truth_volume_mc_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1);
obs_status truth_volume_mc_render_tasks(obs_context *ctx, obs_pool *pool, const struct vol_grid *g,
                                        const struct vol_tf *tf, const struct vol_light *light,
                                        const obs_camera *camera, int width, int height,
                                        const truth_volume_mc_params *p, const unsigned char *task_mask,
                                        truth_volume_image *out);

/* ============================================ end of volume light ground truth ================== */

#ifdef __cplusplus
}
#endif

#endif
