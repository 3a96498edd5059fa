/* glsl_gauss21.h: the seed thesis' 21-tap separable Gaussian (ssao-thesis-2017 Figura 31, the loop of
 * Movania's OpenGL Development Cookbook SSAO recipe, docs/ao/blur.md) as two fragment passes, for the
 * ports whose technique runs it (ao_blur_gaussian21): colour += kernel[index--] * tap(i) for
 * i = -10..10, taps at texel centres clamped to the edge (texelFetch, where GL_LINEAR and GL_NEAREST
 * agree), horizontal then vertical in GL pixels, kernel = ao_gauss21_kernel. */
#ifndef OBS_TESTS_GL_GLSL_GAUSS21_H
#define OBS_TESTS_GL_GLSL_GAUSS21_H

#include "gl/glsl_ports.h"

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
