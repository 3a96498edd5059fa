/* raster.h: the public header of obscura's software rasterizer (prefix rast_).
 *
 * It renders an obs_scene into G-buffer planes for one or K views (a layered G-buffer).
 *
 * Conventions (docs/conventions.md has the full page):
 *   - glTF cameras: right-handed view space, -Z forward, +Y up, metres.
 *   - Pixel (x, y) has its centre at (x+0.5, y+0.5); row 0 is the TOP row.
 *   - Coverage: a pixel is covered when its centre is inside the triangle, with the top-left
 *     fill rule (D3D10/OpenGL rule: a centre exactly on a top or left edge is in, on a bottom or
 *     right edge is out), so triangles sharing an edge cover each pixel exactly once.
 *   - Vertex positions are snapped to 1/256 pixel (8 sub-pixel bits, as GPUs do) and the edge
 *     functions are evaluated exactly (integers held in doubles, |value| < 2^53).
 *   - Triangles are clipped exactly against the near plane (and the far plane when finite) in
 *     homogeneous clip space, and against a guard band of +-RAST_GUARD_BAND_PX pixels.
 *   - Depth test: closest wins; on an exact tie the earlier triangle (instance order, then index
 *     order) wins, as GL_LESS does.
 *   - Attributes are not interpolated from the vertices in screen space. After visibility, each
 *     covered pixel's exact view ray through its centre is intersected with the visible triangle
 *     (in double), which gives the depth, the perspective-correct barycentrics, and from them the
 *     shading normal. This is what makes the buffers agree with a ray tracer (Embree) to 1e-6.
 *
 * Outputs (each a separate plane, allocated only when asked for):
 *   depth        linear view-space depth -z_view, metres; background = +INFINITY
 *   ndc_depth    what an OpenGL depth buffer holds, for the chosen rast_depth_convention;
 *                background = the clear value (1 for standard, 0 for reversed-Z)
 *   normal[3]    shading normal (interpolated vertex normals), view space, unit; background 0
 *   face_normal[3] geometric normal, view space, unit; background 0
 *   prim_id      triangle index within its mesh; background RAST_ID_NONE
 *   instance_id  index into obs_scene.instances (its .node is the glTF node); background RAST_ID_NONE
 *   material_id  obs_mesh.material (RAST_ID_NONE when the mesh has none); background RAST_ID_NONE
 * With face_forward (default), both normals are flipped to face the viewer on back-facing
 * triangles, as a two-sided GL shader does with gl_FrontFacing.
 */
#ifndef RASTER_H
#define RASTER_H

#include "../core/obs.h"

#ifdef __cplusplus
extern "C" {
#endif

#define RAST_ID_NONE 0xFFFFFFFFu

/* Sub-pixel precision: 8 bits (1/256 px), as D3D10+ hardware. */
#define RAST_SUBPIXEL_BITS 8
/* Guard band half-extent in pixels around the render target. Screen coordinates stay within
 * +-(RAST_GUARD_BAND_PX + 2^14) px, i.e. < 2^23 sub-pixel units, so an edge function (a sum of two
 * products of such integers) stays below 2^47 and is exact in a double (53-bit mantissa). */
#define RAST_GUARD_BAND_PX 16384
/* Largest render target side, from the same arithmetic. */
#define RAST_MAX_DIM 16384

typedef enum rast_output_bits {
    RAST_OUT_DEPTH = 1u << 0,
    RAST_OUT_NDC_DEPTH = 1u << 1,
    RAST_OUT_NORMAL = 1u << 2,
    RAST_OUT_FACE_NORMAL = 1u << 3,
    RAST_OUT_PRIM_ID = 1u << 4,
    RAST_OUT_INSTANCE_ID = 1u << 5,
    RAST_OUT_MATERIAL_ID = 1u << 6,
    RAST_OUT_ALL = 0x7Fu
} rast_output_bits;

typedef enum rast_depth_convention {
    RAST_DEPTH_GL_STANDARD = 0, /* glDepthRange(0,1) of NDC z in [-1,1]: d = 0.5*z_ndc + 0.5; near 0, far 1 */
    RAST_DEPTH_ZERO_TO_ONE,     /* glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE), D3D: near 0, far 1 */
    RAST_DEPTH_REVERSED_Z,      /* GL_ZERO_TO_ONE with a reversed projection: near 1, far 0
                                   (infinite far: d = near / linear_depth) */
    RAST_DEPTH_COUNT
} rast_depth_convention;

typedef enum rast_cull {
    RAST_CULL_NONE = 0,   /* default: AO and ground truth see both sides */
    RAST_CULL_BACK,       /* counter-clockwise front faces, glTF's convention */
    RAST_CULL_FRONT,
    RAST_CULL_COUNT
} rast_cull;

typedef enum rast_isa {
    RAST_ISA_AUTO = 0,    /* AVX2 when the CPU and build have it, unless OBS_ISA=scalar is set */
    RAST_ISA_SCALAR,      /* always compiled */
    RAST_ISA_AVX2,
    RAST_ISA_COUNT
} rast_isa;

typedef struct rast_params {
    int width, height;                 /* inner (reported) image size, 1..RAST_MAX_DIM */
    int guard;                         /* guard band g >= 0: render (W+2g) x (H+2g); default 0 */
    uint32_t outputs;                  /* rast_output_bits; default RAST_OUT_ALL */
    rast_depth_convention depth_convention; /* default RAST_DEPTH_GL_STANDARD */
    rast_cull cull;                    /* default RAST_CULL_NONE */
    int face_forward;                  /* default 1 */
    rast_isa isa;                      /* default RAST_ISA_AUTO */
    int tile_size;                     /* screen tile side in pixels; default 64 (power of two, 16..256) */
} rast_params;

rast_params rast_params_default(void);

/* One view: a camera. Its aspect (when 0) comes from width/height of the INNER image. */
typedef struct rast_view {
    obs_camera camera;
} rast_view;

/* The derived constants of a view (pure function of params and camera): what the kernels and
 * a GPU port need to reconstruct positions from depth. */
typedef struct rast_view_constants {
    int full_width, full_height;       /* W + 2g, H + 2g */
    int inner_x0, inner_y0;            /* = g */
    obs_mat4 view;                     /* world -> view */
    obs_mat4 projection;               /* OpenGL projection of the FULL (guard-extended) image,
                                          standard convention (for reversed-Z see below) */
    obs_mat4 projection_reversed;      /* the reversed-Z zero-to-one projection of the full image */
    obs_mat4 projection_inner;         /* the projection of the inner image (as the camera says) */
    double znear, zfar;                /* zfar may be +inf */
    /* Pixel ray model, full image: for pixel centre (px, py) (row 0 top):
     *   perspective: dir_view = ((px - cx)/fx, -(py - cy)/fy, -1)   (origin at the eye)
     *   orthographic: org_view = ((px - cx)/fx, -(py - cy)/fy, 0), dir_view = (0, 0, -1) */
    double fx, fy, cx, cy;
    obs_projection projection_type;
} rast_view_constants;

/* Compute the constants of a view. Returns OK, INVALID_ARGUMENT (sizes, yfov, xmag/ymag),
 * INVALID_DEPTH_RANGE (near <= 0 for perspective, far <= near, non-finite). */
obs_status rast_view_constants_make(obs_context *ctx, const rast_params *p, const obs_camera *cam,
                                    rast_view_constants *out);

/* The exact world-space ray through pixel position (px, py) of the FULL image, as the
 * rasterizer's resolve step uses it (dir is not normalised; for perspective, dir has view z = -1,
 * so a hit at parameter t has linear depth t). */
void rast_pixel_ray(const rast_view_constants *vc, const obs_camera *cam, double px, double py,
                    obs_dvec3 *origin, obs_dvec3 *dir);

/* The depth-buffer value for a linear depth, per convention (double precision, documented in
 * docs/conventions.md). */
double rast_ndc_depth_from_linear(const rast_view_constants *vc, rast_depth_convention conv, double linear_depth);
/* Inverse of the above; background values return +INFINITY. */
double rast_linear_from_ndc_depth(const rast_view_constants *vc, rast_depth_convention conv, double d);

/* One layer of a G-buffer. Planes not requested in `outputs` have data == NULL. */
typedef struct rast_gbuffer {
    int width, height;                 /* full size: inner + 2*guard */
    int guard;
    uint32_t outputs;
    rast_depth_convention depth_convention;
    obs_image_f32 depth;
    obs_image_f32 ndc_depth;
    obs_image_f32 normal[3];
    obs_image_f32 face_normal[3];
    obs_image_u32 prim_id;
    obs_image_u32 instance_id;
    obs_image_u32 material_id;
    rast_view_constants constants;     /* filled by rast_render */
} rast_gbuffer;

/* Allocate the planes that params->outputs asks for, at full size.
 * Returns OK, INVALID_ARGUMENT, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status rast_gbuffer_alloc(obs_context *ctx, const rast_params *p, rast_gbuffer *out);
/* As rast_gbuffer_alloc, but the planes are not zeroed (obs_image_f32_alloc_uninit): for a layer
 * that goes straight to rast_render / rast_render_ws, which writes every element of every
 * requested plane, background and guard band included. After a failed render its contents are
 * undefined: free it. Saves the zeroing pass (docs/raster.md). */
obs_status rast_gbuffer_alloc_uninit(obs_context *ctx, const rast_params *p, rast_gbuffer *out);
void rast_gbuffer_free(rast_gbuffer *gb);   /* NULL-safe */

/* Counters of one render (summed over views). */
typedef struct rast_stats {
    uint64_t triangles_in;           /* triangles submitted (instances x triangles x views) */
    uint64_t triangles_nonfinite;    /* skipped: a NaN or Inf vertex position */
    uint64_t triangles_degenerate;   /* skipped: a repeated index or zero area in view space (pieces
                                        that snap to zero area are sub-pixel, dropped uncounted) */
    uint64_t triangles_culled;       /* back/front culled, or outside the frustum */
    uint64_t triangles_clipped;      /* crossed the near/far plane or the guard band and were clipped */
    uint64_t triangles_rasterized;   /* reached the tile rasterizer (after clipping, counts pieces) */
    uint64_t pixels_covered;         /* pixels with a visible surface */
    rast_isa isa_used;
    double seconds_setup, seconds_raster, seconds_resolve;
} rast_stats;

/* Render view_count views of the scene into layers[0..view_count-1], each allocated with
 * rast_gbuffer_alloc for the same params. The output is identical for any pool size and for
 * the scalar and AVX2 paths.
 * Returns: OK; INVALID_ARGUMENT (NULLs, size mismatch between params and layers, view_count < 1);
 * INVALID_DEPTH_RANGE; UNSUPPORTED_ISA (AVX2 requested but absent); OUT_OF_MEMORY;
 * LIMIT_EXCEEDED. The scene is assumed validated (obs_scene_validate). */
obs_status rast_render(obs_context *ctx, obs_pool *pool, const obs_scene *scene, const rast_view *views,
                       int view_count, const rast_params *params, rast_gbuffer *layers, rast_stats *stats);

/* A workspace keeps the rasterizer's scratch memory between renders, so that repeated renders
 * (benchmarks, studies, animation) allocate nothing and take no page faults. Not thread-safe:
 * one render at a time per workspace. rast_render parks one in ctx (obs_context_scratch_take/put),
 * so its calls with one context reuse it; with ctx NULL it uses a temporary one. */
typedef struct rast_workspace rast_workspace;
rast_workspace *rast_workspace_create(void);   /* NULL when out of memory */
void rast_workspace_destroy(rast_workspace *ws);
/* As rast_render, with a caller-owned workspace (ws must not be NULL). */
obs_status rast_render_ws(obs_context *ctx, obs_pool *pool, rast_workspace *ws, const obs_scene *scene,
                          const rast_view *views, int view_count, const rast_params *params, rast_gbuffer *layers,
                          rast_stats *stats);

/* Whether the AVX2 path is compiled in and supported by this CPU. */
int rast_isa_available(rast_isa isa);
const char *rast_isa_name(rast_isa isa);
const char *rast_depth_convention_name(rast_depth_convention c);

#ifdef __cplusplus
}
#endif

#endif /* RASTER_H */
