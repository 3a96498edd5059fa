/* vol.h: the public header of obscura's volume lighting (prefix vol_).
 *
 * Layers, each usable on its own:
 *   1. Volumes: a scalar grid with anisotropic spacing (loaders in src/io: NIfTI via nifticlib,
 *      NRRD via teem, raw), and synthetic volumes generated in code.
 *   2. Transfer functions: 1D RGBA, piecewise linear, from a documented JSON file or a preset;
 *      opacity correction for the step size.
 *   3. The light volume of Ropinski, Doering and Rezk-Salama 2010 [Ropinski10], as the public
 *      implementations do it (Voreen's LightVolumeGenerator, Inviwo's LightVolumeGL;
 *      ../shared/reference/volume.md section 1): slice-by-slice propagation from the face that
 *      most faces the light, transmittance with one bilinear fetch, chromaticity with a cone blur,
 *      a second direction blended in.
 *   4. The ray caster: front to back, trilinear, early termination, empty-space skipping with
 *      min-max bricks; emission-absorption, gradient Phong, or light-volume shading.
 *
 * Conventions (docs/volume.md):
 *   - Voxel (i, j, k) has its centre at world origin + (i sx, j sy, k sz) (no rotation: the
 *     volume's axes are the world's; a loader that meets a rotated qform/sform says so and keeps
 *     the axes). Data is x fastest, then y, then z.
 *   - Values are converted to float on load (with NIfTI's scl_slope/scl_inter applied).
 *   - Extinction: sigma_t(x) = -kappa ln(1 - alpha_TF(s(x))) / ref_step (per world unit), with
 *     alpha_TF the transfer function's opacity for a step of ref_step (alpha_TF = 1: opaque,
 *     infinite sigma_t); with kappa = 1 the transmittance over a path of length d through
 *     constant material is exp(-sigma_t d) = (1 - alpha_TF)^(d / ref_step): exactly the opacity
 *     correction (vol_tf_alpha_correct). The ray caster, the light volume and the ground truths
 *     all use this one convention (the ray caster with kappa = 1). (A first draft of this header
 *     wrote sigma_t = kappa alpha / ref_step, which agrees only for small alpha: at alpha 0.5,
 *     0.5 against ln 2 = 0.693 per ref_step.)
 *   - Light directions: a directional light's `direction` is the way light TRAVELS (glTF).
 */
#ifndef VOL_H
#define VOL_H

#include "../core/obs.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------------------
 * 1. Volumes
 * ---------------------------------------------------------------------------------------------- */

typedef enum vol_type {
    VOL_TYPE_U8 = 0,
    VOL_TYPE_U16,
    VOL_TYPE_I16,
    VOL_TYPE_F32,
    VOL_TYPE_COUNT
} vol_type;
const char *vol_type_name(vol_type t);                  /* "u8", "u16", "i16", "f32" */
int vol_type_from_name(const char *name, vol_type *out); /* also "uint8", "int16", "float" ... */

/* A scalar volume. Owned; free with vol_grid_free. */
typedef struct vol_grid {
    int nx, ny, nz;            /* >= 1 each */
    double spacing[3];         /* world units per voxel, > 0 */
    double origin[3];          /* world position of voxel (0, 0, 0)'s centre */
    float *data;               /* nx*ny*nz floats, x fastest */
    vol_type source_type;      /* the type as stored in the file */
    float value_min, value_max;/* over the data (finite values) */
    char source[512];          /* the file or generator, for messages */
} vol_grid;

/* Allocate a zeroed grid. Refuses (LIMIT_EXCEEDED, before allocating) sizes whose voxel count
 * passes obs_limits.max_voxels or whose bytes pass obs_limits.max_memory_bytes.
 * Returns OK, INVALID_ARGUMENT (a side < 1, spacing <= 0 or non-finite), LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status vol_grid_alloc(obs_context *ctx, int nx, int ny, int nz, const double spacing[3], vol_grid *out);
void vol_grid_free(vol_grid *g);   /* NULL-safe; zeroes it */
/* Recompute value_min / value_max. */
void vol_grid_update_range(vol_grid *g);
/* World-space bounds of the voxel centres' hull extended by half a voxel on each side. */
void vol_grid_bounds(const vol_grid *g, double lo[3], double hi[3]);
/* Trilinear sample at a continuous voxel coordinate (i, j, k) (voxel centres at integers),
 * clamped to the edge. */
float vol_grid_sample(const vol_grid *g, double i, double j, double k);

/* Synthetic volumes (vol_synth.c), generated deterministically:
 *   "bucky":   a fullerene-like molecule of 60 Gaussian blobs on a truncated icosahedron (as the
 *              seed's bucky, 32^3 by default), values in [0, 255];
 *   "slab":    a homogeneous slab of value 1 filling z in [nz/4, 3nz/4), 0 elsewhere;
 *   "sphere":  value 1 inside a sphere of radius 0.4 n (smooth edge of one voxel), 0 outside;
 *   "box":     a hollow box: value 1 in a shell 2 voxels thick at the border, 0 inside.
 * Returns OK, INVALID_ARGUMENT (unknown name: the message lists them), LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status vol_synth(obs_context *ctx, const char *name, int n, vol_grid *out);

/* ------------------------------------------------------------------------------------------------
 * 2. Transfer functions
 * ---------------------------------------------------------------------------------------------- */

typedef struct vol_tf_point {
    double value;              /* data value, strictly increasing along the list */
    float rgba[4];             /* linear RGB in [0, 1]; alpha = opacity per ref_step, in [0, 1] */
} vol_tf_point;

typedef struct vol_tf {
    char name[64];
    int count;                 /* >= 1 */
    vol_tf_point *points;      /* owned */
    double ref_step;           /* world units the opacities are given for; 0 (a file without
                                  "ref_step") means the smallest spacing of the volume it is used
                                  with (vol_tf_alpha_correct returns alpha unchanged for 0: the
                                  user resolves it, as the ray caster and light volume do) */
} vol_tf;

/* Parse the documented JSON (docs/volume.md, "Transfer functions"):
 *   {"name": "...", "ref_step": 0.5, "points": [[value, r, g, b, a], ...]}
 * Values strictly increasing, components finite and in [0, 1]. Unknown keys are errors.
 * `where` names the file in messages. Returns OK, PARSE_ERROR, INVALID_ARGUMENT, OUT_OF_MEMORY. */
obs_status vol_tf_parse_json(obs_context *ctx, const char *text, const char *where, vol_tf *out);
/* Presets: "ct-skin", "ct-bone" (Hounsfield units), "mri" (the MRI's intensity range), "bucky"
 * (0..255). Returns OK or NOT_FOUND listing them. */
obs_status vol_tf_preset(obs_context *ctx, const char *name, vol_tf *out);
void vol_tf_free(vol_tf *tf);   /* NULL-safe */
/* RGBA at a value: piecewise linear between points, constant beyond the ends. */
void vol_tf_eval(const vol_tf *tf, double value, float rgba[4]);
/* Opacity correction ([Engel06], the standard form; Inviwo's lightpropagation.frag uses it too,
 * volume.md 1.4): alpha for a step of length `step` from alpha
 * given for ref_step: 1 - (1 - alpha)^(step / ref_step). */
float vol_tf_alpha_correct(float alpha, double step, double ref_step);

/* The extinction of the convention above, per world unit: -ln(1 - alpha) / ref_step (times kappa
 * by the caller). alpha is clamped to 1 - 2^-24 so that an opaque value gives a large finite
 * extinction (16.6 per ref_step: transmittance 6e-8 over one ref_step) instead of infinity, which
 * keeps kappa = 0 and trapezoid means free of NaN. alpha <= 0 gives 0. */
double vol_sigma_from_alpha(float alpha, double ref_step);

/* ------------------------------------------------------------------------------------------------
 * 3. The light volume [Ropinski10]
 * ---------------------------------------------------------------------------------------------- */

typedef struct vol_light {
    obs_light_type type;       /* OBS_LIGHT_DIRECTIONAL or OBS_LIGHT_POINT */
    double direction[3];       /* directional: unit, the way light travels */
    double position[3];        /* point: world position (may be inside the volume) */
    float color[3];            /* linear RGB x intensity */
} vol_light;

typedef struct vol_lv_params {
    int scale;                 /* light-volume resolution: 1 (the data's), 2 (half) or 4 (quarter) */
    double cone_angle_deg;     /* chromaticity cone half-angle theta, (0, 80]; default 45 (Voreen's
                                  1-texel stencil, volume.md 1.6) */
    int blend_second;          /* blend the second-closest face's propagation (dir_blend) with
                                  Inviwo's continuous weight (volume.md 1.7); default 1 */
    int eye_pass;              /* add the eye-direction pass (a reconstruction: volume.md 1.8); default 0.
                                  It depends on the camera, so vol_light_volume_build ignores it:
                                  callers with a camera run vol_eye_volume_build and
                                  vol_light_volume_modulate when it is 1 */
    double kappa;              /* extinction scale (the convention above); default 1 */
} vol_lv_params;
vol_lv_params vol_lv_params_default(void);
obs_status vol_lv_params_validate(obs_context *ctx, const vol_lv_params *p);

/* The light volume: per light-volume voxel, transmittance l (hard shadow, one bilinear fetch per
 * slice) and scattering chromaticity c (cone-blurred), at (nx, ny, nz) = the data's / scale. */
typedef struct vol_light_volume {
    int nx, ny, nz, scale;
    double spacing[3], origin[3];  /* of the light volume's own voxel centres */
    float *l;                      /* transmittance towards the light, [0, 1] */
    float *c[3];                   /* chromaticity RGB */
    int face0, face1;              /* propagation faces chosen (0..5: -x, +x, -y, +y, -z, +z) */
    float blend_weight;            /* weight of face0's volume (1 when blend_second is off) */
} vol_light_volume;

/* Build the light volume: depends on the grid, the transfer function, the light and the params
 * only (never on the camera). Threads within each slice (slices depend on each other); the
 * output is identical for any thread count.
 * Returns OK, INVALID_ARGUMENT, UNSUPPORTED (spot light), LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status vol_light_volume_build(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                  const vol_light *light, const vol_lv_params *p, vol_light_volume *out);
void vol_light_volume_free(vol_light_volume *lv);   /* NULL-safe */
/* Trilinear l and c at a world position (clamped to the light volume's edge). */
void vol_light_volume_sample(const vol_light_volume *lv, const double x[3], float *l, float c[3]);

/* ---- Meshes shadow the volume (vol_occupancy.c; docs/volume/light.md "Meshes shadow the volume").
 * OUR construction, not [Ropinski10]'s (the paper's light volume holds the volume alone): closed
 * triangle meshes are voxelized into an occupancy grid with the light volume's own layout, and the
 * occupancy adds extinction to the rows the propagation classifies. */

/* Occupancy in [0, 1] per light-volume voxel: the fraction of the voxel inside the meshes. Owned;
 * free with vol_occupancy_free. Layout: exactly a vol_light_volume's (x fastest). */
typedef struct vol_occupancy {
    int nx, ny, nz;
    double spacing[3], origin[3];  /* the light volume's voxel centres (vol_light_volume) */
    float *f;                      /* nx*ny*nz, x fastest */
} vol_occupancy;

/* One mesh instance: obs_mesh positions (object space) mapped by `world` (obs_mat4_mul_point,
 * float, as the rasterizer places instances). */
typedef struct vol_occ_mesh {
    const obs_mesh *mesh;
    obs_mat4 world;
} vol_occ_mesh;

/* Sub-columns per voxel side: s x s sub-columns (parallel to z) per voxel column, on the regular
 * grid at ((a + 1/2)/s, (b + 1/2)/s) of the voxel's x-y cell; along each sub-column the covered
 * length is exact (not s point samples: an exact interval length needs no tie rule along z).
 * s = 4: 16 sub-columns, each integrated exactly along z (ours; docs/volume/light.md). */
#define VOL_OCC_DEFAULT_SUBCOLUMNS 4 /* [1, 16]; ours: 16 sub-columns a voxel; a radius-10-voxel sphere's volume to 0.005% (tests/test_volume_occupancy.c) */
#define VOL_OCC_MAX_SUBCOLUMNS 16

/* Allocate a zeroed occupancy grid with the layout vol_light_volume_build gives the light volume of
 * grid g at `scale` (1, 2, 4): ceil(n / scale) voxels covering vol_grid_bounds (at scale 1 the
 * data's own spacing and origin, bit for bit). Refuses (LIMIT_EXCEEDED, before allocating) sizes over
 * obs_limits.max_voxels / max_memory_bytes.
 * Returns OK, INVALID_ARGUMENT (NULL, empty grid, scale not 1/2/4), LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status vol_occupancy_alloc(obs_context *ctx, const vol_grid *g, int scale, vol_occupancy *out);
void vol_occupancy_free(vol_occupancy *o);   /* NULL-safe; zeroes it */

/* Voxelize `count` mesh instances into occ (overwritten; its layout from vol_occupancy_alloc):
 * along each of the s x s sub-columns of each (i, j) column (a line parallel to z, over the whole
 * line, not only the grid's z range), every triangle's crossing is found with exact integer edge
 * functions (vertices snapped to 1/256 of the sub-column pitch) and a symbolic-perturbation tie rule,
 * so that a line through a shared edge or vertex of a closed mesh crosses it exactly once; each
 * instance's crossings are sorted along z and paired (parity: [z0, z1], [z2, z3], ...; an odd
 * count, which only a non-closed mesh gives, drops the last crossing); the instances' intervals are
 * united; occ->f = covered length over the voxel's z extent, averaged over the sub-columns.
 * Non-closed meshes: the same rule (a single sheet crossed once fills nothing; an open box crossed
 * twice fills between). Triangles whose projection on x-y has zero area (parallel to z) are never
 * crossed. Threads over rows of columns; the output is identical for any thread count.
 * subcolumns: s in [1, VOL_OCC_MAX_SUBCOLUMNS] (VOL_OCC_DEFAULT_SUBCOLUMNS).
 * Returns OK, INVALID_ARGUMENT (NULL, an index out of range, non-finite positions, bad s),
 * LIMIT_EXCEEDED (the triangles' working memory over obs_limits.max_memory_bytes), OUT_OF_MEMORY. */
obs_status vol_occupancy_voxelize(obs_context *ctx, obs_pool *pool, const vol_occ_mesh *meshes, int count,
                                  int subcolumns, vol_occupancy *occ);

/* The light volume's extra extinction: an occupancy f (opaque meshes) maps to
 *   sigma_occ = vol_sigma_from_alpha(f, ref_step) = -ln(1 - f) / ref_step
 * (capped as that function caps: f = 1 gives 16.6 / ref_step), NOT scaled by kappa (kappa scales
 * the data's extinction; a mesh stays opaque). ref_step 0: the light volume's smallest spacing (a
 * voxel with occupancy f transmits about 1 - f across it). */
typedef struct vol_occluder {
    const vol_occupancy *occupancy;   /* the light volume's layout exactly; NULL: none (then entry
                                         must be set) */
    double ref_step;                  /* >= 0, finite */
    /* Optional (ours, docs/volume/light.md "Meshes shadow the volume"): the transmittance in
     * [0, 1] of the light's path OUTSIDE the light volume's box, for light that enters the box at
     * world point x: each first-slice voxel's l_{-1} = 1 becomes entry(x), x where its light ray
     * crosses the face the propagation starts from (chromaticity c_{-1} stays 1: an occluder is
     * grey). So meshes between the light and the box shadow the volume. Called from the pool's
     * threads: it must be thread-safe and a function of x only. NULL: 1. Values outside [0, 1]
     * are clamped, NaN is 1. */
    float (*entry)(void *user, const double x[3]);
    void *entry_user;
} vol_occluder;

/* vol_light_volume_build with the meshes' occupancy added to the extinction the propagation sees
 * (after each row's classification; the seed march of a light inside the slab range samples it
 * trilinearly). occ NULL, or an all-zero occupancy: vol_light_volume_build's output bit for bit.
 * Returns vol_light_volume_build's, and INVALID_ARGUMENT (occupancy NULL or of another layout,
 * negative or non-finite ref_step). */
obs_status vol_light_volume_build_ex(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                     const vol_light *light, const vol_lv_params *p, const vol_occluder *occ,
                                     vol_light_volume *out);

/* ---- Rebuilding into the same memory (docs/volume/light.md "Cost"). A GPU implementation keeps its
 * 3D textures from frame to frame; the CPU's equivalent: a fresh 256^3 light volume is 256 MiB the
 * kernel must zero on first touch (page faults, about a third of a 2-thread build), so a caller that
 * rebuilds for a new light writes into the old volume instead. */

/* The temporary volumes a build allocates (the second face's propagation when blending, the staged
 * output of a pass along x, the slice buffers), kept between rebuilds. Opaque; one per light volume
 * being rebuilt (not shared by concurrent builds). Holds up to two more 4-channel volumes. */
typedef struct vol_lv_workspace vol_lv_workspace;
vol_lv_workspace *vol_lv_workspace_create(void);       /* NULL: out of memory */
void vol_lv_workspace_free(vol_lv_workspace *ws);        /* NULL-safe */

/* vol_light_volume_build_ex into lv, reusing its memory: lv must be zeroed or hold a light volume
 * (from any build, rebuild, or the same layout: one obs_aligned_alloc block l, c[0..2] at 1, 2, 3
 * times nx ny nz floats). When lv's nx, ny, nz are the new volume's, the new one is written into
 * that block (no allocation, no page fault); otherwise lv is freed and built fresh. ws NULL: the
 * temporaries are allocated and freed as in a build; else they are ws's (allocated on first use,
 * kept). The output is the same bits as vol_light_volume_build_ex's into a zeroed lv
 * (volume_light_rebuild_* tests). On any error lv is freed (zeroed), as a build leaves out.
 * Returns vol_light_volume_build_ex's. */
obs_status vol_light_volume_rebuild(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                    const vol_light *light, const vol_lv_params *p, const vol_occluder *occ,
                                    vol_lv_workspace *ws, vol_light_volume *lv);

/* The eye-direction pass (vol_eye.c), a RECONSTRUCTION (volume.md 1.8: how [Ropinski10] combines
 * its second pass is unverified; docs/volume/light.md "Eye pass" says what we do): the same
 * slice-by-slice propagation run a second time, seeded from the volume face that most faces the
 * camera, with light travelling from the camera into the volume (the camera's view direction for
 * an orthographic camera, from the camera position for a perspective one); only the cone-blurred
 * chromaticity c is kept (outgoing scattering blurs toward the eye). Depends on the grid, the
 * transfer function, the camera's position (or direction) and p; out has the light volume's layout.
 * Returns OK, INVALID_ARGUMENT, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status vol_eye_volume_build(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                const obs_camera *camera, const vol_lv_params *p, vol_light_volume *out);
/* lv.c *= eye.c voxel by voxel (the two must have the same layout: INVALID_ARGUMENT otherwise). */
obs_status vol_light_volume_modulate(obs_context *ctx, const vol_light_volume *eye, vol_light_volume *lv);

/* ------------------------------------------------------------------------------------------------
 * 4. The ray caster
 * ---------------------------------------------------------------------------------------------- */

typedef enum vol_shading {
    VOL_SHADING_EMISSION_ABSORPTION = 0,  /* colour = TF rgb, no lighting */
    VOL_SHADING_PHONG,                    /* gradient Phong (central differences), specular weighted
                                             by the gradient magnitude */
    VOL_SHADING_LIGHT_VOLUME,             /* TF rgb x (l x light colour) x chromaticity c */
    VOL_SHADING_COUNT
} vol_shading;
const char *vol_shading_name(vol_shading s);                 /* "ea", "phong", "lightvolume" */
int vol_shading_from_name(const char *name, vol_shading *out);

/* The ray caster's arithmetic. VOL_RC_EXACT (default): the TF through vol_tf_eval's arithmetic and
 * vol_tf_alpha_correct per sample, bit for bit. VOL_RC_FAST: full steps classify through a 1D
 * table of the TF with the opacity correction for the step already applied (VOL_RC_FAST_TF_SIZE
 * nodes evenly over the TF's value range, linear interpolation in float), as VTK's CPU and the GPU
 * ray casters classify; changes bits (docs/volume/raycast.md "Fast mode": its measured error). */
typedef enum vol_rc_precision { VOL_RC_EXACT = 0, VOL_RC_FAST = 1 } vol_rc_precision;
#define VOL_RC_FAST_TF_SIZE 4096

typedef struct vol_rc_params {
    vol_shading shading;       /* default VOL_SHADING_LIGHT_VOLUME */
    double step;               /* world units; 0 = half the smallest spacing (default) */
    double early_termination;  /* stop when accumulated opacity >= this; default 0.99 */
    int brick;                 /* empty-space skipping brick side in voxels (0 = off); default 8 */
    float ambient;             /* Phong ambient; default 0.2 */
    float specular_exponent;   /* default 32 */
    float background[4];       /* composited behind the volume; default transparent black */
    vol_rc_precision precision; /* default VOL_RC_EXACT */
} vol_rc_params;
vol_rc_params vol_rc_params_default(void);

/* Ray cast the volume for a camera into out[4] (RGBA, premultiplied, width x height, allocated by
 * the call). depth_limit (optional) stops each ray at a mesh's linear view depth (the hybrid
 * scene: rasterized mesh depth, +inf where no mesh). lv is needed for VOL_SHADING_LIGHT_VOLUME.
 * Identical output for any thread count. */
obs_status vol_raycast(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                       const vol_light *light, const vol_light_volume *lv, const obs_camera *camera, int width,
                       int height, const obs_image_f32 *depth_limit, const vol_rc_params *p, obs_image_f32 out[4]);

/* The part of a ray cast that depends only on the grid, the TF and p->brick (the empty-space brick
 * table [Kruger03]), made once and kept across calls: vol_raycast is vol_rc_prepare +
 * vol_raycast_prepared + vol_rc_prepared_free, with the same output bits. The handle keeps
 * pointers to g and tf: they must outlive it and not change (a changed TF or data needs a new
 * handle). vol_raycast_prepared refuses (INVALID_ARGUMENT) params whose brick differs from the
 * prepared one; the other params (shading, step, early termination, ...) may change per call.
 * vol_rc_prepare returns OK, INVALID_ARGUMENT, OUT_OF_MEMORY; vol_rc_prepared_free is NULL-safe. */
/* Prepared with p->precision VOL_RC_FAST and p->shading VOL_SHADING_PHONG, the handle also holds
 * the fast mode's gradient volume (per voxel the central differences, float xyz: 12 bytes per
 * voxel, 3x the grid); fast Phong casts through a handle without it use the exact gradient
 * (docs/volume/raycast.md, "Third round"). */
typedef struct vol_rc_prepared vol_rc_prepared;
obs_status vol_rc_prepare(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                          const vol_rc_params *p, vol_rc_prepared **out);
obs_status vol_raycast_prepared(obs_context *ctx, obs_pool *pool, const vol_rc_prepared *prep,
                                const vol_light *light, const vol_light_volume *lv, const obs_camera *camera,
                                int width, int height, const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                obs_image_f32 out[4]);
void vol_rc_prepared_free(vol_rc_prepared *prep);

#ifdef __cplusplus
}
#endif

#endif /* VOL_H */
