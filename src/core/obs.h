/* obs.h: the public header of obscura's core module (prefix obs_).
 *
 * Conventions (the full page is docs/conventions.md):
 *   - World and view space are right-handed, metres, glTF style: the camera looks down -Z, +Y is up,
 *     +X is right. View-space z of a visible point is negative; "linear depth" is -z_view > 0.
 *   - Matrices are 4x4 float, column-major (m[col*4 + row]), as glTF and OpenGL store them.
 *     Points are column vectors: p' = M p.
 *   - Images are row-major with row 0 at the TOP (as EXR and PNG store them). Pixel (x, y) covers
 *     [x, x+1) x [y, y+1); its centre is at (x+0.5, y+0.5). OpenGL's gl_FragCoord.y is H - y - 0.5.
 *   - Image planes are float32 or uint32 with an explicit stride in elements.
 *
 * Ownership: every *_create has a matching *_destroy; views (obs_image_*) never own their data
 * unless obtained from obs_image_*_alloc, which must be freed with obs_image_*_free.
 *
 * Threading: obs_context is not thread-safe; use one per thread of the caller. obs_pool runs
 * tasks with a decomposition that never depends on the number of threads.
 */
#ifndef OBS_H
#define OBS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define OBS_VERSION_MAJOR 0
#define OBS_VERSION_MINOR 1
#define OBS_VERSION_PATCH 0
#define OBS_VERSION_STRING "0.1.0"

/* ------------------------------------------------------------------------------------------------
 * Status and context
 * ---------------------------------------------------------------------------------------------- */

/* The one status enum of the project. Messages with details live in the context. */
typedef enum obs_status {
    OBS_STATUS_OK = 0,               /* success */
    OBS_STATUS_INVALID_ARGUMENT,     /* a parameter is out of its documented range or NULL */
    OBS_STATUS_OUT_OF_MEMORY,        /* an allocation failed */
    OBS_STATUS_LIMIT_EXCEEDED,       /* a size is over a documented resource limit (see obs_limits) */
    OBS_STATUS_IO_ERROR,             /* a file could not be opened, read, written or renamed */
    OBS_STATUS_PARSE_ERROR,          /* a file's content is malformed or inconsistent */
    OBS_STATUS_UNSUPPORTED,          /* valid input that obscura does not handle (e.g. glTF lines) */
    OBS_STATUS_UNSUPPORTED_ISA,      /* a SIMD path was requested that this CPU or build lacks */
    OBS_STATUS_INVALID_DEPTH_RANGE,  /* near/far planes that do not define a projection */
    OBS_STATUS_NOT_FOUND,            /* a named channel, camera, node or file is absent */
    OBS_STATUS_INTERNAL,             /* an invariant broke: a bug in obscura */
    OBS_STATUS_COUNT
} obs_status;

/* A short constant name for a status ("invalid argument"). Never NULL. */
const char *obs_status_string(obs_status s);

typedef enum obs_log_level {
    OBS_LOG_ERROR = 0,
    OBS_LOG_WARN,
    OBS_LOG_INFO,
    OBS_LOG_DEBUG,
    OBS_LOG_COUNT
} obs_log_level;

typedef void (*obs_error_fn)(void *user, obs_status status, const char *message);
typedef void (*obs_log_fn)(void *user, obs_log_level level, const char *message);

/* Resource limits, checked before allocation. Every limit has a CLI flag that raises it
 * (named in the refusal message). Defaults: see obs_limits_default(). */
typedef struct obs_limits {
    int64_t max_image_pixels;     /* width*height*layers; default 2^28 (16k x 16k); --max-pixels */
    int64_t max_triangles;        /* per scene; default 2^28; --max-triangles */
    int64_t max_vertices;         /* per scene; default 2^28; --max-vertices */
    int64_t max_memory_bytes;     /* estimate for one allocation group; default 16 GiB; --max-memory */
    int64_t max_samples;          /* Monte Carlo samples per pixel; default 2^20; --max-spp (the limit on
                                     truth ao's --max-samples) */
    int64_t max_voxels;           /* volume voxels; default 2^31; --max-voxels */
} obs_limits;

obs_limits obs_limits_default(void);

/* Opaque per-caller context: keeps the first error message, a log level and callbacks. */
typedef struct obs_context obs_context;

/* Returns NULL only when out of memory. */
obs_context *obs_context_create(void);
void obs_context_destroy(obs_context *ctx);

/* Record an error (printf format). The FIRST error since the last obs_context_clear_error is
 * kept (as Embree does); later ones are still passed to the callback. Returns `status` so that
 * callers can write `return obs_error(ctx, OBS_STATUS_IO_ERROR, "...")`. ctx may be NULL. */
obs_status obs_error(obs_context *ctx, obs_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* The kept message ("" when none). Valid until the next clear or destroy. */
const char *obs_context_last_error(const obs_context *ctx);
obs_status obs_context_last_status(const obs_context *ctx);
void obs_context_clear_error(obs_context *ctx);
void obs_context_set_error_callback(obs_context *ctx, obs_error_fn fn, void *user);

/* Logging: messages at or below the level are passed to the callback (default: stderr). */
void obs_context_set_log_level(obs_context *ctx, obs_log_level level);
obs_log_level obs_context_log_level(const obs_context *ctx);
void obs_context_set_log_callback(obs_context *ctx, obs_log_fn fn, void *user);
void obs_log(obs_context *ctx, obs_log_level level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Limits in force for this context (defaults at creation). */
const obs_limits *obs_context_limits(const obs_context *ctx);
void obs_context_set_limits(obs_context *ctx, const obs_limits *limits);

/* Scratch kept between calls: a module parks one reusable object (its scratch memory) per key, the
 * address of one of its statics, so that repeated calls with the same context allocate and zero
 * nothing (ao_gtao_compute keeps its planes so). take removes the key's object from the context and
 * returns it (NULL when none is parked: make a fresh one); put parks obj, or destroys it at once
 * when the key already has one or all OBS_CONTEXT_SCRATCH_SLOTS are used. A nested call finds the
 * slot empty and makes its own. obs_context_destroy and obs_context_scratch_release destroy what is
 * parked. Like the rest of the context, not for concurrent use. ctx may be NULL (take returns NULL,
 * put destroys). */
#define OBS_CONTEXT_SCRATCH_SLOTS 8
void *obs_context_scratch_take(obs_context *ctx, const void *key);
void obs_context_scratch_put(obs_context *ctx, const void *key, void *obj, void (*destroy)(void *));
void obs_context_scratch_release(obs_context *ctx);

/* Overflow-checked size arithmetic: return 0 and leave *out untouched on overflow. */
int obs_mul_size(size_t a, size_t b, size_t *out);
int obs_add_size(size_t a, size_t b, size_t *out);

/* ------------------------------------------------------------------------------------------------
 * Vector and matrix maths (header-inline, float; double where noted)
 * ---------------------------------------------------------------------------------------------- */

#define OBS_PI 3.14159265358979323846
#define OBS_PI_F 3.14159265358979323846f

typedef struct obs_vec2 { float x, y; } obs_vec2;
typedef struct obs_vec3 { float x, y, z; } obs_vec3;
typedef struct obs_vec4 { float x, y, z, w; } obs_vec4;
typedef struct obs_dvec3 { double x, y, z; } obs_dvec3;
/* Column-major 4x4: m[c*4 + r]. */
typedef struct obs_mat4 { float m[16]; } obs_mat4;
typedef struct obs_dmat4 { double m[16]; } obs_dmat4;

static inline obs_vec3 obs_v3(float x, float y, float z) { obs_vec3 v = {x, y, z}; return v; }
static inline obs_vec3 obs_v3_add(obs_vec3 a, obs_vec3 b) { return obs_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline obs_vec3 obs_v3_sub(obs_vec3 a, obs_vec3 b) { return obs_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline obs_vec3 obs_v3_scale(obs_vec3 a, float s) { return obs_v3(a.x * s, a.y * s, a.z * s); }
static inline float obs_v3_dot(obs_vec3 a, obs_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline obs_vec3 obs_v3_cross(obs_vec3 a, obs_vec3 b)
{
    return obs_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
float obs_v3_length(obs_vec3 a);
/* Returns the zero vector for a zero or non-finite input. */
obs_vec3 obs_v3_normalize(obs_vec3 a);

static inline obs_dvec3 obs_dv3(double x, double y, double z) { obs_dvec3 v = {x, y, z}; return v; }
static inline obs_dvec3 obs_dv3_sub(obs_dvec3 a, obs_dvec3 b) { return obs_dv3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline double obs_dv3_dot(obs_dvec3 a, obs_dvec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline obs_dvec3 obs_dv3_cross(obs_dvec3 a, obs_dvec3 b)
{
    return obs_dv3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

obs_mat4 obs_mat4_identity(void);
obs_mat4 obs_mat4_mul(obs_mat4 a, obs_mat4 b);           /* a * b */
/* General inverse (cofactors, in double). Returns 0 if singular or non-finite. */
int obs_mat4_inverse(obs_mat4 a, obs_mat4 *out);
obs_mat4 obs_mat4_transpose(obs_mat4 a);
obs_mat4 obs_mat4_translation(obs_vec3 t);
obs_mat4 obs_mat4_scale(obs_vec3 s);
/* Unit quaternion (x, y, z, w), glTF order. */
obs_mat4 obs_mat4_from_quat(obs_vec4 q);
/* glTF node TRS: T * R * S. */
obs_mat4 obs_mat4_from_trs(obs_vec3 t, obs_vec4 q, obs_vec3 s);
/* A view matrix (world -> view) for an eye looking at a target, right-handed, -Z forward. */
obs_mat4 obs_mat4_look_at(obs_vec3 eye, obs_vec3 target, obs_vec3 up);
obs_vec3 obs_mat4_mul_point(obs_mat4 m, obs_vec3 p);     /* w assumed 1, no divide */
obs_vec3 obs_mat4_mul_dir(obs_mat4 m, obs_vec3 d);       /* w = 0 */
obs_vec4 obs_mat4_mul_vec4(obs_mat4 m, obs_vec4 v);
/* Normal matrix: inverse-transpose of the upper 3x3, as 3 columns in a mat4 (w row/col zero).
 * Returns 0 if the 3x3 is singular. */
int obs_mat4_normal_matrix(obs_mat4 m, obs_mat4 *out);
obs_dmat4 obs_mat4_to_double(obs_mat4 a);
obs_dmat4 obs_dmat4_mul(obs_dmat4 a, obs_dmat4 b);
int obs_mat4_is_finite(obs_mat4 a);

/* ------------------------------------------------------------------------------------------------
 * Image planes
 * ---------------------------------------------------------------------------------------------- */

/* A float32 plane view. stride is in elements (floats) between row starts, >= width. */
typedef struct obs_image_f32 {
    float *data;
    int width, height;
    ptrdiff_t stride;
} obs_image_f32;

typedef struct obs_image_u32 {
    uint32_t *data;
    int width, height;
    ptrdiff_t stride;
} obs_image_u32;

static inline float *obs_image_f32_row(const obs_image_f32 *im, int y) { return im->data + (ptrdiff_t)y * im->stride; }
static inline uint32_t *obs_image_u32_row(const obs_image_u32 *im, int y) { return im->data + (ptrdiff_t)y * im->stride; }

/* Allocate a zeroed plane. The stride is rounded up to a multiple of 16 floats (64 bytes) and
 * rows are 64-byte aligned. Sizes are overflow-checked and checked against ctx's
 * max_image_pixels / max_memory_bytes before allocating.
 * Returns: OK; INVALID_ARGUMENT (w or h < 1, NULL out); LIMIT_EXCEEDED; OUT_OF_MEMORY. */
obs_status obs_image_f32_alloc(obs_context *ctx, int width, int height, obs_image_f32 *out);
obs_status obs_image_u32_alloc(obs_context *ctx, int width, int height, obs_image_u32 *out);
/* As above, but the width x height elements are NOT zeroed: the caller writes every element
 * before anything reads it (only the row padding past width is zeroed). For planes whose producer
 * is proven to write every pixel (the rasterizer's G-buffer, docs/raster.md); it saves the
 * zeroing pass and its cache misses. With the environment variable OBS_POISON_UNINIT=1 the
 * elements are filled with the signalling-NaN bits 0x7FA5A5A5 instead, so a test comparing the
 * output with and without it catches a missed element. */
obs_status obs_image_f32_alloc_uninit(obs_context *ctx, int width, int height, obs_image_f32 *out);
obs_status obs_image_u32_alloc_uninit(obs_context *ctx, int width, int height, obs_image_u32 *out);
void obs_image_f32_free(obs_image_f32 *im);   /* NULL-safe; zeroes the view */
void obs_image_u32_free(obs_image_u32 *im);
void obs_image_f32_fill(obs_image_f32 *im, float v);
void obs_image_u32_fill(obs_image_u32 *im, uint32_t v);
/* A sub-window view (no copy). Returns a zero-size view when out of range. */
obs_image_f32 obs_image_f32_window(const obs_image_f32 *im, int x0, int y0, int w, int h);
obs_image_u32 obs_image_u32_window(const obs_image_u32 *im, int x0, int y0, int w, int h);

/* Aligned allocation helpers (64 bytes); obs_aligned_free is NULL-safe. */
void *obs_aligned_alloc(size_t bytes);
void obs_aligned_free(void *p);

/* ------------------------------------------------------------------------------------------------
 * Thread pool
 * ---------------------------------------------------------------------------------------------- */

typedef struct obs_pool obs_pool;

/* threads <= 0 means the number of online CPUs. A pool with 1 thread runs tasks on the caller.
 * Returns NULL when out of memory or when threads cannot be started. */
obs_pool *obs_pool_create(int threads);
void obs_pool_destroy(obs_pool *pool);
int obs_pool_threads(const obs_pool *pool);

/* Task function: task index in [0, count), and the index of the worker thread running it
 * (in [0, threads)) for per-thread scratch only. Output must depend on task only. */
typedef void (*obs_task_fn)(void *user, int64_t task, int thread);

/* Run count tasks and wait for all of them. Tasks are handed out dynamically; determinism
 * comes from the decomposition, which callers make independent of the thread count.
 * pool may be NULL (runs serially). Not re-entrant: do not call from inside a task. */
void obs_pool_run(obs_pool *pool, int64_t count, obs_task_fn fn, void *user);

/* A deterministic 2D tile decomposition of a w x h image into tile x tile squares
 * (edge tiles are smaller), numbered row-major. */
typedef struct obs_tiling {
    int width, height, tile;
    int tiles_x, tiles_y;
} obs_tiling;
obs_tiling obs_tiling_make(int width, int height, int tile);
static inline int64_t obs_tiling_count(const obs_tiling *t) { return (int64_t)t->tiles_x * t->tiles_y; }
/* Pixel rectangle [x0,x1) x [y0,y1) of a tile. */
void obs_tiling_rect(const obs_tiling *t, int64_t index, int *x0, int *y0, int *x1, int *y1);

/* ------------------------------------------------------------------------------------------------
 * Random numbers: counter-based (Philox4x32-10, Salmon et al. SC'11), and low-discrepancy
 * ---------------------------------------------------------------------------------------------- */

/* Philox4x32 with 10 rounds: the raw bijection (for known-answer tests). */
void obs_philox4x32_10(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]);

/* Four independent 32-bit words keyed by (pixel index, sample index, dimension, seed).
 * The same key always gives the same words, whatever thread asks. */
void obs_rng_u32x4(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed, uint32_t out[4]);
/* obs_rng_u32x4 for n consecutive samples sample0 .. sample0 + n - 1 (n >= 0) of one pixel,
 * dimension and seed: out[k] = the words of sample sample0 + k, bit for bit. Four Philox calls at
 * a time in SSE2 (baseline x86-64; integer arithmetic, so the same bits as the scalar form, which
 * obs_rng_u32x4_n_scalar is and tests/test_core.c compares). */
void obs_rng_u32x4_n(uint64_t pixel, uint32_t sample0, int n, uint32_t dimension, uint64_t seed, uint32_t (*out)[4]);
void obs_rng_u32x4_n_scalar(uint64_t pixel, uint32_t sample0, int n, uint32_t dimension, uint64_t seed,
                            uint32_t (*out)[4]);
/* A uniform float in [0, 1) from the first word: (w >> 8) * 2^-24. */
float obs_rng_float(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed);
/* A uniform double in [0, 1) from two words (53 bits). */
double obs_rng_double(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed);
static inline float obs_u32_to_unit_float(uint32_t w) { return (float)(w >> 8) * (1.0f / 16777216.0f); }

/* Van der Corput radical inverse of i in the given prime base (2 <= base). Exact for base 2. */
double obs_radical_inverse(uint32_t base, uint64_t i);
/* The n-th prime, n in [0, 1000). Returns 0 when out of range. */
uint32_t obs_prime(int n);
/* Halton point: component `dimension` of point i uses base obs_prime(dimension). */
static inline double obs_halton(uint64_t i, int dimension) { return obs_radical_inverse(obs_prime(dimension), i); }
/* Cranley-Patterson rotation: (u + shift) mod 1, result in [0,1). */
double obs_cp_rotate(double u, double shift);

/* ------------------------------------------------------------------------------------------------
 * Parsing numbers from text (command lines, option lists)
 * ---------------------------------------------------------------------------------------------- */

/* The whole of s as a base-10 integer in [lo, hi]: 1 and *out set, or 0 (NULL, empty, trailing
 * characters, overflow, out of range). */
int obs_parse_int(const char *s, long long lo, long long hi, long long *out);
/* The whole of s as a number (strtod: "inf" accepted, NaN refused): 1 and *out set, or 0. */
int obs_parse_double(const char *s, double *out);
/* "WxH" with each side an integer in [1, max]: 1 and *w, *h set, or 0. */
int obs_parse_size(const char *s, int max, int *w, int *h);

/* ------------------------------------------------------------------------------------------------
 * Timers
 * ---------------------------------------------------------------------------------------------- */

/* Monotonic time in seconds (CLOCK_MONOTONIC). */
double obs_time_now(void);

typedef struct obs_timer { double start, elapsed; int running; } obs_timer;
void obs_timer_start(obs_timer *t);
void obs_timer_stop(obs_timer *t);       /* accumulates into elapsed */
double obs_timer_seconds(const obs_timer *t);

/* ------------------------------------------------------------------------------------------------
 * Scene data (filled by src/io's glTF loader or by generators; consumed by raster and truth)
 * ---------------------------------------------------------------------------------------------- */

#define OBS_NAME_MAX 64

/* One triangle mesh (a glTF primitive in TRIANGLES mode). Positions and normals are xyz floats;
 * normals may be NULL (then face normals are used for shading). indices has 3*triangle_count
 * entries, each < vertex_count (validated by obs_scene_validate). */
typedef struct obs_mesh {
    char name[OBS_NAME_MAX];
    uint32_t vertex_count;
    uint32_t triangle_count;
    float *positions;   /* 3*vertex_count */
    float *normals;     /* 3*vertex_count or NULL */
    uint32_t *indices;  /* 3*triangle_count */
    int32_t material;   /* index into obs_scene.materials, or -1 */
} obs_mesh;

/* An instance of a mesh in the world: the flattened node hierarchy. */
typedef struct obs_instance {
    uint32_t mesh;      /* index into obs_scene.meshes */
    uint32_t node;      /* glTF node index: the "instance id" written to G-buffers */
    obs_mat4 world;     /* object -> world */
} obs_instance;

typedef enum obs_projection {
    OBS_PROJECTION_PERSPECTIVE = 0,
    OBS_PROJECTION_ORTHOGRAPHIC,
    OBS_PROJECTION_COUNT
} obs_projection;

/* A camera, glTF conventions (glTF 2.0 spec, section 3.10 "Cameras"). */
typedef struct obs_camera {
    char name[OBS_NAME_MAX];
    obs_projection projection;
    float yfov;          /* perspective: vertical field of view, radians, (0, pi) */
    float aspect;        /* width/height; 0 = take it from the image size */
    float xmag, ymag;    /* orthographic: half width and half height of the view volume, metres */
    float znear;         /* > 0 (perspective); >= 0 allowed for orthographic */
    float zfar;          /* > znear, or INFINITY for an infinite perspective projection */
    obs_mat4 world;      /* camera -> world (the node's world matrix, without scale) */
    obs_mat4 view;       /* world -> view = inverse(world) */
} obs_camera;

typedef enum obs_light_type {
    OBS_LIGHT_DIRECTIONAL = 0,
    OBS_LIGHT_POINT,
    OBS_LIGHT_SPOT,
    OBS_LIGHT_COUNT
} obs_light_type;

/* KHR_lights_punctual light, placed in the world by its node. */
typedef struct obs_light {
    char name[OBS_NAME_MAX];
    obs_light_type type;
    obs_vec3 color;        /* linear RGB, default (1,1,1) */
    float intensity;       /* candela (point/spot) or lux (directional); default 1 */
    float range;           /* metres; 0 = infinite */
    float inner_cone, outer_cone; /* spot: radians; defaults 0 and pi/4 */
    obs_vec3 position;     /* world */
    obs_vec3 direction;    /* world, unit: the direction light travels (node's -Z) */
    uint32_t node;
} obs_light;

typedef struct obs_material {
    char name[OBS_NAME_MAX];
    float base_color[4];   /* pbrMetallicRoughness.baseColorFactor, linear */
    float metallic, roughness;
    int double_sided;
    char *extras_json;     /* the material's "extras" as compact JSON text, or NULL */
} obs_material;

typedef struct obs_aabb { obs_vec3 lo, hi; } obs_aabb;

/* A loaded scene. Owned arrays; free with obs_scene_free. */
typedef struct obs_scene {
    obs_mesh *meshes;         uint32_t mesh_count;
    obs_instance *instances;  uint32_t instance_count;
    obs_camera *cameras;      uint32_t camera_count;
    obs_light *lights;        uint32_t light_count;
    obs_material *materials;  uint32_t material_count;
    obs_aabb bounds;          /* world-space bounds of all instances (lo > hi when empty) */
    char source[512];         /* the file it came from, for messages */
    char *extras_json;        /* the glTF scene's "extras" (of the scene loaded) as compact JSON
                                 text, or NULL; `obscura render` reads its settings from the key
                                 "obscura_render" there (docs/render.md) */
} obs_scene;

void obs_scene_init(obs_scene *s);         /* zero it, bounds empty */
void obs_scene_free(obs_scene *s);         /* frees all owned arrays, then re-inits */
/* Checks indices < vertex_count, finite transforms, instance->mesh in range, counts against
 * limits. Non-finite vertex positions are allowed (the rasterizer skips and counts them).
 * Returns OK, PARSE_ERROR (with a message naming the mesh and index) or LIMIT_EXCEEDED. */
obs_status obs_scene_validate(obs_context *ctx, const obs_scene *s);
/* Recompute s->bounds from instances (finite positions only). */
void obs_scene_update_bounds(obs_scene *s);
/* Total triangles over all instances. */
uint64_t obs_scene_triangle_count(const obs_scene *s);

/* Camera helpers. The projection matrix is OpenGL's (clip z in [-w, w]) for standard depth.
 * aspect_fallback is used when cam->aspect == 0. */
obs_mat4 obs_camera_projection_gl(const obs_camera *cam, float aspect_fallback);
/* A perspective camera looking from eye at target, up +Y. */
obs_camera obs_camera_look_at(obs_vec3 eye, obs_vec3 target, obs_vec3 up, float yfov, float znear, float zfar);
/* Set cam->view from cam->world (or world from view). Returns 0 if singular. */
int obs_camera_set_world(obs_camera *cam, obs_mat4 world);
/* A camera that frames the scene bounds (used when a scene has no camera): looks along
 * -Z from +Z, with a small downward tilt, fits the bounding sphere. */
obs_camera obs_camera_frame_bounds(obs_aabb bounds, float yfov);

#ifdef __cplusplus
}
#endif

#endif /* OBS_H */
