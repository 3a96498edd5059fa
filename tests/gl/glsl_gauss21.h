/* glsl_gauss21.h: the seed thesis' 21-tap separable Gaussian (ao_blur_gaussian21, docs/ao/blur.md)
 * as a GLSL port, shared by the techniques that blur with it (crytek, alchemy, ue4's --blur). */
#ifndef OBS_TESTS_GLSL_GAUSS21_H
#define OBS_TESTS_GLSL_GAUSS21_H

#include "ao/ao.h"
#include "gl/glh.h"

/* Append the two passes (horizontal, then vertical) that blur src (an R32F texture of the full
 * buffer, GL_NEAREST, clamp to edge) into r; the vertical pass also writes visibility 1 where
 * depth_tex (the depth, R32F, +inf background as is) is background, as our kernels do after the
 * blur (a documented deviation of theirs). rows: how src and depth_tex were uploaded (GLH_ROWS_FLIP
 * or GLH_ROWS_AS_IS); our vertical taps run i = -10..10 over our row y - i, so the pass walks GL
 * rows up (FLIP) or down (AS_IS) to add the same terms in the same order. Sets r->out_fbo.
 * Returns 1, or 0 after printing why. */
int glsl_gauss21_add(glh *g, const ao_input *in, glh_run *r, GLuint src, GLuint depth_tex, int rows);

/* Ours: ao_blur_gaussian21 over the kernel output (window = buffer), then background -> 1. */
obs_status glsl_gauss21_ours(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *kernel_out,
                             obs_image_f32 *out);

#endif
