/* render_internal.h: what the render's files share (not installed). docs/render.md describes the
 * graph, the keys and the disk cache. */
#ifndef RENDER_INTERNAL_H
#define RENDER_INTERNAL_H

#include "render.h"
#include "../raster/raster.h"

/* ------------------------------------------------------------------------------------------------
 * Content hashes (render_cache.c)
 * ---------------------------------------------------------------------------------------------- */

/* A 128-bit content hash: two independent 64-bit lanes over the same 8-byte words (lane 0 an
 * FNV-1a-style xor-multiply, lane 1 an xxHash64-style add-multiply-rotate round), each finished
 * with the SplitMix64 finaliser over (lane, length). Not cryptographic: a key, not a signature. */
typedef struct render_hash {
    uint64_t h[2];
    uint64_t len;
    unsigned char tail[8];
    int ntail;
} render_hash;
typedef struct render_key { uint64_t k[2]; } render_key;

void render_hash_init(render_hash *h, const char *domain);
void render_hash_bytes(render_hash *h, const void *data, size_t n);
void render_hash_u64(render_hash *h, uint64_t v);
void render_hash_i(render_hash *h, int64_t v);
void render_hash_d(render_hash *h, double v);     /* -0 and 0 hash alike; one NaN */
void render_hash_str(render_hash *h, const char *s);
void render_hash_key(render_hash *h, render_key k);
render_key render_hash_final(const render_hash *h);
void render_key_hex(render_key k, char out[33]);
int render_key_eq(render_key a, render_key b);
/* The library version every key carries. */
#define RENDER_CACHE_VERSION "obscura " OBS_VERSION_STRING " render-cache 1"

/* ------------------------------------------------------------------------------------------------
 * Products and the cache (render_cache.c)
 * ---------------------------------------------------------------------------------------------- */

/* One blob of a serialised product. */
typedef struct render_blob { void *data; uint64_t bytes; } render_blob;
/* A serialiser builds a list of blobs (owned by the writer: freed after writing). */
typedef struct render_blobs { render_blob *b; int n, cap; } render_blobs;
int render_blobs_add_copy(render_blobs *bl, const void *data, uint64_t bytes);
void render_blobs_free(render_blobs *bl);
/* A reader walks the blobs of a loaded file in order. */
typedef struct render_reader { const render_blob *b; int n, i, bad; } render_reader;
/* The next blob when it is exactly `bytes` long (else marks the reader bad and returns NULL). */
const void *render_reader_take(render_reader *r, uint64_t bytes);

typedef struct render_product_ops {
    const char *kind;                                  /* "sss_maps", ... */
    void (*free_fn)(void *p);                          /* frees and zeroes the product's contents */
    /* Optional (disk-cached products): */
    obs_status (*save)(obs_context *ctx, const void *p, render_blobs *out);
    obs_status (*load)(obs_context *ctx, render_reader *in, void *p);   /* p zeroed on entry */
    size_t size;                                       /* sizeof the product struct */
    uint64_t (*bytes)(const void *p);                  /* bytes it holds (for the stats) */
} render_product_ops;

typedef struct render_cache render_cache;
/* budget: bytes the memory cache may hold between frames (least recently used dropped first). */
render_cache *render_cache_create(const char *dir, uint64_t budget);
/* A new frame: trims the cache to its budget; entries the frame finds or inserts are then kept
 * until the next frame begins. */
void render_cache_begin_frame(render_cache *c, obs_context *ctx);
void render_cache_destroy(render_cache *c);
/* Memory lookup: the product or NULL. */
void *render_cache_find(render_cache *c, render_key k, const render_product_ops *ops);
/* Disk lookup (when the cache has a directory and ops has load): a fresh product moved into the
 * memory cache, or NULL (a miss; a corrupt or truncated file is a miss with a warning). */
void *render_cache_load(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops);
/* Take ownership of p (a malloc'd struct of ops->size bytes) under k; writes it to disk when the
 * cache has a directory and ops has save (a failure to write is a warning, not an error). */
void *render_cache_put(render_cache *c, obs_context *ctx, render_key k, const render_product_ops *ops, void *p,
                       uint64_t bytes);
void render_cache_count(render_cache *c, int hit_memory, int hit_disk, int miss);
void render_cache_get_stats(const render_cache *c, render_cache_stats *out);

/* Plane (de)serialisation helpers. */
int render_blobs_add_plane(render_blobs *bl, const obs_image_f32 *im);
int render_blobs_add_plane_u32(render_blobs *bl, const obs_image_u32 *im);
obs_status render_reader_plane(obs_context *ctx, render_reader *r, int w, int h, obs_image_f32 *out);
obs_status render_reader_plane_u32(obs_context *ctx, render_reader *r, int w, int h, obs_image_u32 *out);
int render_blobs_add_gbuffer(render_blobs *bl, const rast_gbuffer *gb);
obs_status render_reader_gbuffer(obs_context *ctx, render_reader *r, rast_gbuffer *gb);

/* ------------------------------------------------------------------------------------------------
 * Resources, passes and the job (render_graph.c, render_passes_*.c)
 * ---------------------------------------------------------------------------------------------- */

/* The graph's resources (bits). Scene inputs (geometry, lights, camera...) are named in the
 * passes' `reads` text but are not resources: they always exist. */
enum {
    RES_GBUFFER = 1u << 0,
    RES_SHADOW_MAPS = 1u << 1,
    RES_DIRECT = 1u << 2,
    RES_AO = 1u << 3,
    RES_AMBIENT = 1u << 4,
    RES_SSS_LIGHT_MAPS = 1u << 5,
    RES_SSS_MAPS = 1u << 6,
    RES_SSS = 1u << 7,
    RES_VOLUME_GRID = 1u << 8,
    RES_LIGHT_VOLUME = 1u << 9,
    RES_VOLUME = 1u << 10,
    RES_BEAUTY = 1u << 11,
    RES_REF_SCENE = 1u << 12,
    RES_REF_AO = 1u << 13,
    RES_REF_AMBIENT = 1u << 14,
    RES_REF_SSS = 1u << 15,
    RES_REF_VOLUME = 1u << 16,
    RES_REF_BEAUTY = 1u << 17,
    RES_COUNT_BITS = 18
};

/* Products (view-independent, cached). */
typedef struct render_shadow_map {
    int faces;                     /* 1 (directional: orthographic) or 6 (point: a cube) */
    obs_camera cam[6];
    rast_view_constants vc[6];
    obs_image_f32 depth[6];        /* linear depth from the light's camera, +inf = empty */
    double texel_world;            /* orthographic: texel side; perspective: texel side at depth 1 */
} render_shadow_map;
typedef struct render_shadow_maps { int count; render_shadow_map *maps; /* one per render light */ } render_shadow_maps;
/* The fraction in [0, 1] of a 3x3 texel neighbourhood of the light's shadow map that sees world
 * point p, offset along its normal n (n = 0: no offset) (render_passes_surface.c). */
float render_shadow_lookup(const render_shadow_map *sm, const obs_light *L, obs_vec3 p, obs_vec3 n);
typedef struct render_sss_light_maps { int count; sss_light_map *lm; } render_sss_light_maps;
/* The loaded volume; rc is the ray caster's prepared handle (vol_rc_prepare: the brick table),
 * made by the first raycast that needs it with brick rc_brick and kept with the volume, so that
 * later views skip it (the same output bits as vol_raycast). */
typedef struct render_volume_data { vol_grid grid; vol_tf tf; vol_rc_prepared *rc; int rc_brick; } render_volume_data;
typedef struct render_truth_scene { truth_scene *ts; } render_truth_scene;
/* The light_volume product: the volume's own light volume, and (mesh.l != NULL) the one whose
 * extinction adds the occupancy of the meshes inside the volume's box (vol.h vol_occluder). */
typedef struct render_light_volumes { vol_light_volume own, mesh; int mesh_instances; double voxelize_ms; } render_light_volumes;

extern const render_product_ops render_ops_shadow_maps, render_ops_sss_light_maps, render_ops_sss_maps,
    render_ops_volume, render_ops_light_volume, render_ops_truth_scene;

struct render_session {
    obs_context *ctx;
    obs_pool *pool;
    render_cache *cache;
    render_options opt;
    char cache_dir[1024];
    sss_maps_workspace *sss_ws;    /* the scattering maps' scratch (rasterizer, per-thread buffers),
                                      kept across frames so a rebuild of the maps allocates only the
                                      maps themselves (sss_maps_rebuild; created on first use) */
};

/* Everything one frame's passes share. */
typedef struct render_job {
    render_session *session;
    obs_context *ctx;
    obs_pool *pool;
    const obs_scene *scene;
    const render_settings *st;
    render_frame *f;
    int W, H;
    obs_camera cam;
    /* the lights the render uses: the scene's directional and point lights (spot lights are left
       out, with a note in the log) */
    int light_count;
    obs_light *lights;
    int spot_lights;
    int volume_light;              /* index into scene->lights for the volume, -1 none */
    sss_scene_setup sss;           /* materials resolved (always made: it says what is translucent) */
    int any_translucent, any_opaque;
    sss_params sss_p;              /* settings.sss with the session seed folded in */
    obs_scene sss_scene;           /* a shallow view of the scene with only its translucent instances
                                      (own instances array; meshes, materials, lights shared): what the
                                      SSS light G-buffers and maps are built from */
    /* view products */
    rast_gbuffer gb;               /* face_forward 0 (outward normals, as sss_combine wants) */
    rast_gbuffer gb_ff;            /* the same planes with normals faced toward the viewer */
    obs_image_f32 nff[3], fnff[3];
    obs_image_f32 mask_opaque;     /* 1 on opaque surface pixels */
    obs_image_f32 mask_translucent;
    /* cached products (borrowed from the cache) */
    render_shadow_maps *shadow;
    render_sss_light_maps *slm;
    sss_maps *maps;
    render_volume_data *vol;
    vol_light_volume *lv;          /* the volume's own light volume: what the meshes sample (direct) */
    vol_light_volume *lv_rc;       /* what the ray cast samples: with the meshes' shadows
                                      (volume.mesh_shadows, meshes in the box), else lv */
    render_truth_scene *truth;
    vol_light vlight;
    /* keys */
    render_key key[RES_COUNT_BITS];
    int key_valid[RES_COUNT_BITS];
    double ref_seconds_shared;
} render_job;

typedef struct render_pass {
    const char *name;
    unsigned writes;                                   /* RES_* bits */
    int view_dependent;
    int is_reference;
    /* The resources it reads for this job, and the text of its declared inputs. */
    unsigned (*reads)(const render_job *j, char *text, size_t size);
    /* 1 when the scene calls for it; reason gets why (or why not). */
    int (*wanted)(const render_job *j, char *reason, size_t size);
    /* View-independent passes: the content key (0 when it cannot be known yet). */
    int (*key)(render_job *j, render_key *out);
    /* Run it (or take it from the cache): fills the job and the frame; returns the state. */
    obs_status (*run)(render_job *j, render_pass_state *state, uint64_t *bytes);
} render_pass;

/* The passes in execution order (render_graph.c). */
const render_pass *const *render_passes(int *count);
/* The resource name of one bit ("gbuffer"). */
const char *render_resource_name(unsigned bit);
/* Build the graph of a job into j->f->passes (states PLANNED or CULLED). live[i] says whether
 * pass i of render_passes() runs; order[] the records' pass indices. */
obs_status render_graph_compile(render_job *j, int live[], int order[]);

/* The passes (render_passes_*.c). */
extern const render_pass render_pass_gbuffer, render_pass_shadow_maps, render_pass_direct, render_pass_ao,
    render_pass_ambient, render_pass_sss_light_maps, render_pass_sss_maps, render_pass_sss_combine,
    render_pass_volume_load, render_pass_light_volume, render_pass_raycast, render_pass_compose,
    render_pass_ref_scene, render_pass_ref_ao, render_pass_ref_ambient, render_pass_ref_sss,
    render_pass_ref_volume, render_pass_ref_compose;

/* Helpers shared by the passes. */
obs_status render_planes_alloc(obs_context *ctx, int n, int w, int h, obs_image_f32 *out);
void render_planes_free(int n, obs_image_f32 *p);
int render_job_has_volume(const render_job *j);
/* Hash the geometry and transforms of every instance, the render lights, and the materials. */
void render_hash_geometry(render_hash *h, const obs_scene *scene);
void render_hash_lights(render_hash *h, const render_job *j);
void render_hash_materials(render_hash *h, const render_job *j);
void render_hash_sss_params(render_hash *h, const sss_params *p);
/* A cached view-independent product: look it up (memory, then disk), or build it with build() and
 * store it. *state gets RAN, CACHED_MEMORY or CACHED_DISK. */
obs_status render_cached(render_job *j, unsigned res, const render_product_ops *ops,
                         obs_status (*build)(render_job *j, void *p), void **out, render_pass_state *state,
                         uint64_t *bytes);
uint64_t render_planes_bytes(int n, const obs_image_f32 *p);
/* ambient x albedo x ao (ao NULL: 1) on opaque pixels; beauty from its layers (NULL data: absent). */
obs_status render_ambient_fill(render_job *j, const obs_image_f32 *ao, obs_image_f32 out[3]);
obs_status render_compose(render_job *j, const obs_image_f32 *direct, const obs_image_f32 *ambient,
                          const obs_image_f32 *sss, const obs_image_f32 *volume, obs_image_f32 out[3]);
/* The volume's light (j->vlight) from the scene light; the ray caster's params for the job. */
void render_volume_light(render_job *j);
vol_rc_params render_volume_rc_params(const render_job *j);
/* The record of a pass in the frame (NULL when absent). */
render_pass_record *render_job_record(render_job *j, const char *name);

#endif /* RENDER_INTERNAL_H */
