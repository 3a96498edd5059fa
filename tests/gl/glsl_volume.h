/* glsl_volume.h: a GLSL port of the light-volume propagation of [Ropinski10] as
 * src/volume/vol_light.c does it (docs/volume/light.md, "GLSL port"), run by the GL harness
 * (glh.h) on llvmpipe, slice by slice into 3D textures as the paper's GPU method does
 * (Voreen's LightVolumeGenerator, Inviwo's LightVolumeGL; ../shared/reference/volume.md 1.2-1.7).
 *
 * Per propagation face, one fragment pass per slice renders layer k of two 3D textures (RGBA32F:
 * l, c.rgb; R32F: sigma_t) of the face's permuted size (nu, nv, n_axis), reading layer k -/+ 1 of
 * the same textures with texelFetch (disjoint layers, glTextureBarrier between the draws: GL 4.5
 * 9.3.1 and ARB_texture_barrier) and the data as a 3D R32F texture. A last pass per z layer merges
 * the two faces (Inviwo's lightvolumeblend.frag, volume.md 1.7) into an RGBA32F 3D texture in the
 * light volume's own layout (x fastest), read back with glGetTexImage.
 *
 * The host side (face choice, grid, weights, cone stencils) is computed here from the documented
 * formulas (docs/volume/light.md, volume.md 1.3-1.7), not taken from vol_light.c, so the test
 * checks both. */
#ifndef OBS_TESTS_GLSL_VOLUME_H
#define OBS_TESTS_GLSL_VOLUME_H

#include "gl/glh.h"
#include "volume/vol.h"

#define GLSL_VOLUME_MAX_TF 64 /* transfer-function points the port's uniforms hold */

/* One draw of the port. */
typedef struct glsl_volume_draw {
    int pass;        /* 0, 1: face F0, F1 propagation; 2: the merge */
    int k, kprev;    /* layer written, layer read (propagation) */
    int mode;        /* 0 face slice, 1 propagate, 2 seed (a light inside) */
    GLuint fbo;
} glsl_volume_draw;

typedef struct glsl_volume {
    int n[3];                  /* the light volume's size */
    int face0, face1;          /* chosen faces (0..5: -x, +x, -y, +y, -z, +z); face1 -1 when not blended */
    float blend_weight;        /* weight of F0 (1 when the second face is not propagated) */
    int nfaces;                /* 1 or 2 propagations */
    int axis[2], dims[2][3];   /* per face: propagation axis a, and (nu, nv, na) */
    GLuint data_tex, lv_tex[2], sig_tex[2], out_tex;
    GLuint prog_prop, prog_merge;
    glsl_volume_draw *draws;
    int ndraws, nprop_draws;   /* draws [0, nprop_draws) propagate; the rest merge */
} glsl_volume;

/* Build the port for (grid, tf, light, p) as vol_light_volume_build would (p->eye_pass ignored,
 * as there). Returns 1, or 0 after printing why (a spot light, too many TF points, GL errors). */
int glsl_volume_build(glh *g, obs_context *ctx, const vol_grid *grid, const vol_tf *tf, const vol_light *light,
                      const vol_lv_params *p, glsl_volume *r);
/* Draw every pass (no glFinish). */
void glsl_volume_run(glh *g, const glsl_volume *r);
/* Draw, then read the result into out (a vol_light_volume of the light volume's layout, free with
 * vol_light_volume_free; spacing/origin left 0, face0/face1/blend_weight as chosen). */
obs_status glsl_volume_read(glh *g, const glsl_volume *r, obs_context *ctx, vol_light_volume *out);
/* Milliseconds for one glsl_volume_run + glFinish (the benchmark's hook). */
double glsl_volume_time_ms(glh *g, const glsl_volume *r);
void glsl_volume_free(glh *g, glsl_volume *r);

#endif
