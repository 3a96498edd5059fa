/* render.h: the public header of obscura's scene-driven render (prefix render_).
 *
 * `obscura render` and any library user: a scene says what it holds (opaque and translucent
 * meshes, lights, cameras, a volume, and the render settings in its extras); the render builds a
 * pass graph from it, culls every pass whose output nobody asked for, runs the rest in order, and
 * caches the products that do not depend on the view (shadow maps, the SSS light G-buffers and
 * scattering maps, the volume and its light volume) by a content hash of exactly what they read.
 * docs/render.md documents the scene schema, the graph and the cache;
 * ../shared/reference/render.md the anchors (frame graphs: declare, compile with culling,
 * execute; build systems with content hashes).
 *
 * Module layout (src/render):
 *   render_settings.c   settings: defaults, the scene's "obscura_render" JSON, validation, sidecar
 *   render_graph.c      the passes' declarations, culling from the requested outputs, the order
 *   render_cache.c      content hashes, the in-memory cache, the optional disk cache
 *   render_passes*.c    each pass: G-buffer, shadow maps, AO, SSS (light maps, maps, combination),
 *                       volume (load, light volume, ray cast), direct light, composition, references
 *   render_write.c      the layered EXR, the beauty PNG, the JSON sidecar with the pass log
 *   render.c            the session: runs frames, batches, progress
 * The library libobscura_render links libobscura and libobscura_io.
 */
#ifndef RENDER_H
#define RENDER_H

#include <stdio.h>

#include "../core/obs.h"
#include "../ao/ao.h"
#include "../sss/sss.h"
#include "../truth/truth.h"
#include "../volume/vol.h"

#ifdef __cplusplus
extern "C" {
#endif

struct io_json;

/* ------------------------------------------------------------------------------------------------
 * 1. Settings (render_settings.c)
 * ---------------------------------------------------------------------------------------------- */

/* The layers a render can write (bits of render_settings.outputs). The layered EXR holds each
 * asked-for layer as its own channels ("direct.R", "ao.Y", "volume.A", ...); the PNG is the beauty
 * image. Asking for fewer layers culls the passes only they need. */
enum {
    RENDER_OUT_BEAUTY = 1u << 0,   /* the composed image (RGB): needs every effect the scene has */
    RENDER_OUT_DIRECT = 1u << 1,   /* Lambert direct light on opaque meshes, shadowed (RGB) */
    RENDER_OUT_AMBIENT = 1u << 2,  /* ambient x albedo x AO on opaque meshes (RGB) */
    RENDER_OUT_AO = 1u << 3,       /* the AO technique's visibility (Y) */
    RENDER_OUT_SSS = 1u << 4,      /* SSS radiance on translucent meshes (RGB) */
    RENDER_OUT_VOLUME = 1u << 5,   /* the ray-cast volume, premultiplied, stopped at mesh depth (RGBA) */
    RENDER_OUT_DEPTH = 1u << 6,    /* linear view depth (Z) */
    RENDER_OUT_NORMAL = 1u << 7,   /* view-space normals (X, Y, Z) */
    RENDER_OUT_ALBEDO = 1u << 8,   /* base colour (RGB) */
    RENDER_OUT_ALL = (1u << 9) - 1u
};
/* "beauty", "direct", ... for one bit; NULL for anything else. */
const char *render_output_name(unsigned bit);
/* One name to its bit; 0 for an unknown name. */
unsigned render_output_from_name(const char *name);

#define RENDER_MAX_CAMERAS 64
#define RENDER_DEFAULT_AMBIENT 0.25f       /* ambient radiance: AO_BLEND_AMBIENT, the AO blend's share */
#define RENDER_DEFAULT_SHADOW_MAP_SIZE 2048 /* ours: one texel ~ 1 mm over a 2 m Cornell box */
#define RENDER_DEFAULT_WIDTH 1920           /* as every other command (cli_size_from_camera) */

typedef struct render_volume_settings {
    int enabled;                   /* 1 when the scene has a volume */
    char source[512];              /* "synth:NAME" or "synth:NAME:N" (vol_synth), or a file (.nrrd,
                                      .nhdr, .nii, .nii.gz), relative to the scene file's directory */
    char transfer[512];            /* a vol_tf_preset name, or a JSON file (relative, as source) */
    int has_box;                   /* 1: the volume's bounds are mapped onto [box_lo, box_hi] (the
                                      spacing scaled per axis, the origin moved); 0: its own */
    double box_lo[3], box_hi[3];   /* world units */
    int light;                     /* the scene light that lights it; -1 = the first directional or
                                      point light (default) */
    vol_lv_params lv;              /* vol_lv_params_default() */
    vol_rc_params rc;              /* vol_rc_params_default() */
    int mesh_shadows;              /* 1: the meshes inside the volume's box shadow it (their occupancy
                                      adds extinction to the light volume: vol.h vol_occluder; ours,
                                      docs/render.md); default 1 */
} render_volume_settings;

typedef struct render_settings {
    int width, height;             /* 0, 0: RENDER_DEFAULT_WIDTH wide at the camera's aspect */
    int camera_count;              /* 0: every camera of the scene (a framing camera when none) */
    int cameras[RENDER_MAX_CAMERAS]; /* scene camera indices, in render order */
    unsigned outputs;              /* RENDER_OUT_* asked for; default RENDER_OUT_ALL (layers the
                                      scene cannot have, e.g. sss without translucent materials,
                                      are left out of the EXR, and their passes never run) */
    const ao_method *ao;           /* NULL: no AO (no AO pass; ambient is unoccluded). Default:
                                      ao_method_find("sao") with its defaults */
    _Alignas(16) unsigned char ao_params[AO_PARAMS_MAX_SIZE]; /* the method's params struct */
    float ambient[3];              /* ambient radiance; RENDER_DEFAULT_AMBIENT each */
    int shadows;                   /* shadow the direct light with a shadow map per light; default 1 */
    int shadow_map_size;           /* RENDER_DEFAULT_SHADOW_MAP_SIZE */
    sss_params sss;                /* sss_params_default() */
    double mm_per_unit;            /* SSS_DEFAULT_MM_PER_UNIT */
    render_volume_settings volume;
    uint64_t seed;                 /* every random choice (SSS samplers, references); default 0 */
    /* --reference: the same frame with the references in place of the approximations */
    int reference;                 /* default 0 */
    truth_ao_params ref_ao;        /* truth_ao_params_default() with the AO method's radius and
                                      matched estimator (ao_method.truth_estimator) */
    truth_sss_params ref_sss;      /* truth_sss_params_default() */
    int ref_volume_samples;        /* the volume reference: truth_volume_mc_render's samples per pixel
                                      (a multiple of its 8 replicates, [8, 1048576]); default 256
                                      (TRUTH_VOLUME_MC_DEFAULT_SAMPLES) */
} render_settings;

render_settings render_settings_default(void);

/* Apply one "obscura_render" object (the JSON text of the object itself) to s: keys given replace
 * the values in s, others stay. Schema: docs/render.md "Scene settings". Unknown keys, wrong types
 * and out-of-range values are errors naming `where` and the key path ("obscura_render.ao.radius").
 * Camera names are resolved against scene (which may be NULL: then only indices are accepted).
 * Returns OK, PARSE_ERROR, INVALID_ARGUMENT, NOT_FOUND (a camera or AO method that does not exist). */
obs_status render_settings_apply_json(obs_context *ctx, const char *json, const char *where, const obs_scene *scene,
                                      render_settings *s);
/* render_settings_apply_json on the scene's extras "obscura_render" key when it has one (other keys
 * of the scene's extras are not ours and are ignored). OK when there is none. */
obs_status render_settings_from_scene(obs_context *ctx, const obs_scene *scene, render_settings *s);
/* Range and consistency checks against the scene (camera indices, light index, AO params through
 * the method's validate, sss params, volume params). Returns OK or INVALID_ARGUMENT. */
obs_status render_settings_validate(obs_context *ctx, const obs_scene *scene, const render_settings *s);
/* The settings as one JSON object "settings" in a sidecar (everything that decides the output). */
void render_settings_to_json(const render_settings *s, struct io_json *j);

/* ------------------------------------------------------------------------------------------------
 * 2. Sessions, frames and the pass log (render.c, render_graph.c, render_cache.c)
 * ---------------------------------------------------------------------------------------------- */

typedef enum render_pass_state {
    RENDER_PASS_PLANNED = 0,       /* in the graph, not run yet (a dry run stops here) */
    RENDER_PASS_RAN,               /* computed by this frame */
    RENDER_PASS_CACHED_MEMORY,     /* a view-independent product reused from this session */
    RENDER_PASS_CACHED_DISK,       /* ... read from the disk cache */
    RENDER_PASS_CULLED,            /* not needed: the scene does not call for it, or no requested
                                      output reads it (reason says which) */
    RENDER_PASS_STATE_COUNT
} render_pass_state;
const char *render_pass_state_name(render_pass_state s);   /* "planned", "ran", "memory", "disk", "culled" */

/* One line of the pass log. */
typedef struct render_pass_record {
    char name[48];                 /* "gbuffer", "shadow_maps", "ao", "sss_light_maps", "sss_maps",
                                      "sss_combine", "volume_load", "light_volume", "raycast",
                                      "direct", "compose", "ref_ao", "ref_sss", "ref_volume", ... */
    char reads[192];               /* declared inputs, comma separated ("gbuffer,sss_maps,camera") */
    char writes[96];               /* declared outputs */
    char reason[224];              /* why it is in the graph, or why it was culled */
    int view_dependent;
    render_pass_state state;
    char key[33];                  /* view-independent passes: the content key (128-bit hex); "" else */
    double seconds;                /* wall time of this pass in this frame (a cache hit: the lookup) */
    uint64_t output_bytes;         /* bytes of the products it wrote (or reused) */
    uint64_t peak_rss_bytes;       /* the process's peak resident set after the pass (getrusage) */
} render_pass_record;

/* Per-layer error of the approximation against the reference (--reference). */
typedef struct render_layer_error {
    char layer[16];                /* "beauty", "ao", "sss", "volume", "direct", "ambient" */
    double rmse, mae, bias, psnr;  /* over the pixels where either side is non-background */
    int64_t pixels;
} render_layer_error;

#define RENDER_MAX_PASSES 32
#define RENDER_MAX_LAYER_ERRORS 8

/* One rendered view. Planes are width x height, owned; a layer not computed has NULL data. */
typedef struct render_frame {
    int width, height;
    int camera;                    /* scene camera index, -1 for the framing camera */
    obs_camera cam;                /* as rendered */
    unsigned outputs;              /* the layers this frame holds (RENDER_OUT_* bits) */
    obs_image_f32 beauty[3], direct[3], ambient[3], ao, sss[3], volume[4], depth, normal[3], albedo[3];
    int pass_count;
    render_pass_record passes[RENDER_MAX_PASSES]; /* in execution order; culled passes last */
    double seconds;                /* the whole frame */
    /* --reference */
    int has_reference;
    obs_image_f32 ref_beauty[3], ref_ambient[3], ref_ao, ref_sss[3], ref_volume[4];
    double seconds_approx, seconds_reference; /* the passes of each side, summed */
    int error_count;
    render_layer_error errors[RENDER_MAX_LAYER_ERRORS];
} render_frame;
void render_frame_free(render_frame *f);   /* NULL-safe; zeroes it */

/* Called after each pass of a frame: done and total count the live passes over the views of the
 * current scene (render_view_count views x live passes); a batch over several scenes is totalled by
 * the caller (cmd_render.c does). */
typedef void (*render_progress_fn)(void *user, int64_t done, int64_t total);

typedef struct render_options {
    int threads;                   /* 0: all CPUs */
    const char *cache_dir;         /* NULL: memory only; else view-independent products are also
                                      read from and written to this directory (created if needed),
                                      one file per key, written to a temporary name then renamed */
    uint64_t cache_memory;         /* bytes the in-memory cache may hold between frames; 0: the default,
                                      half the machine's physical memory (ours). Least recently used
                                      products are dropped first (still on disk with cache_dir); a
                                      product the current frame uses is never dropped */
    render_progress_fn progress;   /* optional */
    void *progress_user;
} render_options;
render_options render_options_default(void);

/* A session owns the thread pool and the in-memory cache, so products are shared across the views
 * (and scenes) rendered through it. Not thread-safe: one frame at a time. */
typedef struct render_session render_session;
/* Returns NULL (with the error in ctx) on a bad option or no memory. */
render_session *render_session_create(obs_context *ctx, const render_options *opt);
void render_session_destroy(render_session *s);   /* NULL-safe */

/* Build the graph for one view without running it: out->passes gets every pass with state PLANNED
 * (or CULLED) and its reason, reads, writes and (view-independent passes) key. camera_slot indexes
 * st->cameras (or the scene's cameras when st->camera_count is 0). */
obs_status render_plan(render_session *s, const obs_scene *scene, const render_settings *st, int camera_slot,
                       render_frame *out);
/* Render one view: plan, then run the passes in order, reusing cached products. Output bytes are
 * identical for any thread count and whether a product came from the cache or not.
 * Returns OK or the first failing pass's status (its message names the pass and the scene). */
obs_status render_frame_run(render_session *s, const obs_scene *scene, const render_settings *st, int camera_slot,
                            render_frame *out);
/* How many views a scene renders under st (st->camera_count, or the scene's cameras, at least 1). */
int render_view_count(const obs_scene *scene, const render_settings *st);

/* Cache counters since the session began. */
typedef struct render_cache_stats {
    int64_t hits_memory, hits_disk, misses, entries;
    int64_t evictions;             /* products dropped from memory to stay within the budget */
    uint64_t bytes;                /* held in memory */
} render_cache_stats;
void render_session_cache_stats(const render_session *s, render_cache_stats *out);

/* ------------------------------------------------------------------------------------------------
 * 3. Writing (render_write.c)
 * ---------------------------------------------------------------------------------------------- */

/* The pass log as a short table (name, state, seconds, reason), as --dry-run and the README's main
 * command print it. */
void render_pass_log_print(FILE *out, const render_frame *f);
/* Write PREFIX.exr (every layer of f, plus "ref_*" layers with --reference), PREFIX.png (the beauty
 * image, sRGB-encoded) and PREFIX.json (settings, camera, the pass log, the reference's per-layer
 * errors and times). Atomic (temporary files renamed). argc/argv go to the sidecar. */
obs_status render_frame_write(obs_context *ctx, const render_frame *f, const obs_scene *scene,
                              const render_settings *st, const char *prefix, int argc, char **argv);

#ifdef __cplusplus
}
#endif

#endif /* RENDER_H */
