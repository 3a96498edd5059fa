/* glsl_sss.h: a GLSL port of the scattering-map gather of [DalCorso14]'s final shader
 * (ss_array_render_to_arraymap_multilight_directional.frag, #define RUSSIAN_ROULETTE) and of the
 * thesis text's N-of-M variant, and of our exponential sampler (the default), as src/sss/sss_maps.c
 * does them, run by the GL harness (glh.h) on
 * llvmpipe. tests/gl/test_gl_sss.c compares it with sss_maps_build texel by texel; docs/gl.md,
 * "SSS scattering maps", has the figures.
 *
 * The port reads what a GPU renderer would have in textures: our light G-buffers (world position,
 * instance id, world normal per texel, from sss_light_map_render) and our K map views (linear
 * depth, view-space normal, instance and material ids, the rasterised G-buffers in
 * sss_maps.views). It reconstructs x_o and n_o, draws the per-texel stream, maps the disk,
 * applies the skip rules and evaluates the float BSSRDF kernel (sss_batch.c, with its own exp)
 * in one fragment pass over an atlas of the K layers (layer k at x in [k size, (k + 1) size)).
 * Rows are as ours (GLH_ROWS_AS_IS): texel (x, y) of a layer is our (x, y), row 0 at the top. */
#ifndef OBS_TESTS_GLSL_SSS_H
#define OBS_TESTS_GLSL_SSS_H

#include "gl/glh.h"
#include "sss/sss.h"

#define GLSL_SSS_MAX_LIGHTS 2    /* light maps per pass (two texture units each) */
#define GLSL_SSS_MAX_MATERIALS 4 /* distinct translucent materials in the views */

/* Build the gather for the maps `maps` (built by sss_maps_build with the same scene, materials,
 * lights and params: only its dirs, size and views are read) into r: one pass writing an RGBA32F
 * atlas of (K size) x size, RGB = the radiance of the layer's texel. Returns 1, or 0 after
 * printing why (too many lights or materials, an unknown sampler). */
int glsl_sss_gather_build(glh *g, obs_context *ctx, const obs_scene *scene, const sss_scene_materials *mats,
                          const sss_light_map *lights, int light_count, const sss_maps *maps, const sss_params *p,
                          glh_run *r);

/* Draw r (all passes) and read the atlas back as 3K planes of size x size in sss_maps.radiance's
 * layout (layer k channel c at [3k + c]), allocated by the call. */
obs_status glsl_sss_gather_read(glh *g, const glh_run *r, obs_context *ctx, int K, int size, obs_image_f32 *planes);

/* Pass 3, the combination (sss_combine.c; [DalCorso14] ss_array_combination.frag) for a camera
 * G-buffer (depth, normals, material ids, from rast_render with face_forward = 0) seen by `camera`:
 * the shrink, the receiver-plane shadow taps (PRODUCT5 or PCF3X3) against the K views' depths, the
 * bilinear radiance lookup of our maps (maps->radiance uploaded as textures), T21 and the gamma.
 * One pass writing an RGBA32F image of the G-buffer's full size, rows as ours. The specular term
 * is not ported (p->specular must be 0). Returns 1, or 0 after printing why. */
int glsl_sss_combine_build(glh *g, obs_context *ctx, const sss_scene_materials *mats, const sss_maps *maps,
                           const rast_gbuffer *camera_gb, const obs_camera *camera, const sss_params *p, glh_run *r);
/* Draw r and read its RGB into 3 planes of w x h (allocated by the call). */
obs_status glsl_sss_read_rgb(glh *g, const glh_run *r, obs_context *ctx, obs_image_f32 out[3]);

#endif
