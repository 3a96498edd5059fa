/* glsl_gauss21.h: the seed thesis' 21-tap separable Gaussian (ao_blur_gaussian21, docs/ao/blur.md)
 * as a GLSL port, shared by the techniques that blur with it (crytek, alchemy, ue4's --blur). */
#ifndef OBS_TESTS_GLSL_GAUSS21_H
#define OBS_TESTS_GLSL_GAUSS21_H

#include "ao/ao.h"
#include "gl/glh.h"
#include "gl/glsl_ports.h"

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


/* The same blur in its texel-fetch form, for blurs of a level of any size (mssao, mssao-seed):
 * taps at texel centres clamped to the edge (texelFetch, where the listing's GL_NEAREST texture()
 * at texel centres reads the same texels), horizontal then vertical in GL pixels. The two forms
 * differ only in how a tap addresses its texel; both add the same 21 terms in the listing's order. */
#if GLH_AVAILABLE
static const char *const glsl_gauss21_fs =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D textureMap; uniform float kernel[21];\n"
    "layout(location=0) out vec4 o;\n"
    "void main() {\n"
    "  ivec2 c = ivec2(gl_FragCoord.xy), last = textureSize(textureMap, 0) - 1;\n"
    "  float colour = 0.0; int index = 20;\n"
    "  for (int i = -10; i <= 10; i++)\n"
    "    colour += kernel[index--] * texelFetch(textureMap, clamp(c + i * ivec2(DIR), ivec2(0), last), 0).x;\n"
    "  o = vec4(colour);\n"
    "}\n";

/* The two programs (horizontal, vertical) with their kernel set, owned by r. Returns 1 or 0. */
static inline int glsl_gauss21_programs(glh *g, glh_run *r, GLuint prog[2])
{
    prog[0] = glh_run_own_program(r, glh_program(g, glsl_gauss21_fs, "#define DIR 1, 0\n"));
    prog[1] = glh_run_own_program(r, glh_program(g, glsl_gauss21_fs, "#define DIR 0, 1\n"));
    if (!prog[0] || !prog[1])
        return 0;
    for (int d = 0; d < 2; d++)
        glh_setfv(g, prog[d], "kernel", 1, 2 * AO_GAUSS21_RADIUS + 1, ao_gauss21_kernel);
    return 1;
}
#endif

#endif
