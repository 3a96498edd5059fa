/* glsl_gauss21.c: the seed thesis' 21-tap Gaussian in GLSL (glsl_gauss21.h).
 *
 * Source: the blur the seed thesis prints (ssao-thesis-2017 §4.2.3, Figura 31), which is Movania's
 * OpenGL Development Cookbook SSAO recipe's fragment shader (Chapter 6, "GaussH.frag"/"GaussV.frag"):
 *     for (int i = -10; i <= 10; i++) colour += kernel[index--] * texture(textureMap, vUV + vec2(i * delta.x, 0)).r;
 * re-typed with the kernel as a uniform (our ao_gauss21_kernel, the 9-decimal literals), one shader
 * for both directions (delta = (1/W, 0) or (0, +-1/H)). Taps land on texel centres (nearest,
 * clamp to edge, as ao_blur.c). Our background rule (visibility 1 after the blur) is the last
 * pass's final select. */
#include "gl/glsl_gauss21.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#if GLH_AVAILABLE
static const char *const fs_gauss21 =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D textureMap;\n"
    "layout(binding=1) uniform sampler2D depthMap;\n"
    "uniform vec2 delta; uniform float kernel[21]; uniform int bgToOne;\n"
    "in vec2 texCoord; layout(location=0) out vec4 vFragColor;\n"
    "void main(){\n"
    "  float colour = 0.0; int index = 20;\n"
    "  for (int i = -10; i <= 10; i++)\n"
    "    colour += kernel[index--] * texture(textureMap, texCoord + vec2(float(i) * delta.x, float(i) * delta.y)).r;\n"
    "  if (bgToOne != 0) { float d = texelFetch(depthMap, ivec2(gl_FragCoord.xy), 0).r;\n"
    "    if (!(d > 0.0 && d < 1.0 / 0.0)) colour = 1.0; }\n"
    "  vFragColor = vec4(colour);\n"
    "}\n";
#endif

int glsl_gauss21_add(glh *g, const ao_input *in, glh_run *r, GLuint src, GLuint depth_tex, int rows)
{
#if GLH_AVAILABLE
    const int W = in->width, H = in->height;
    GLuint p = glh_run_own_program(r, glh_program(g, fs_gauss21, NULL));
    GLuint tmp = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint dst = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint p2 = glh_run_own_program(r, glh_program(g, fs_gauss21, NULL));
    GLuint ft = glh_run_own_fbo(r, glh_framebuffer(g, tmp, 0)), fd = glh_run_own_fbo(r, glh_framebuffer(g, dst, 0));
    if (!p || !p2 || !tmp || !dst || !ft || !fd) {
        printf("  gauss21: GL objects could not be made\n");
        return 0;
    }
    glh_setfv(g, p, "kernel", 1, 21, ao_gauss21_kernel);
    glh_setfv(g, p2, "kernel", 1, 21, ao_gauss21_kernel);
    glh_set2f(g, p, "delta", 1.0f / (float)W, 0.0f);
    glh_set1i(g, p, "bgToOne", 0);
    /* ours: tap i at our row y - i; GL row y_gl + i (rows flipped) or y - i (as is) */
    glh_set2f(g, p2, "delta", 0.0f, (rows == GLH_ROWS_FLIP ? 1.0f : -1.0f) / (float)H);
    glh_set1i(g, p2, "bgToOne", 1);
    const GLuint t1[2] = {src, depth_tex}, t2[2] = {tmp, depth_tex};
    if (glh_run_add(r, "gauss21 horizontal", p, ft, W, H, 2, t1) < 0 ||
        glh_run_add(r, "gauss21 vertical", p2, fd, W, H, 2, t2) < 0)
        return 0;
    r->out_fbo = fd;
    r->out_w = W;
    r->out_h = H;
    r->out_rows = rows;
    return 1;
#else
    (void)g, (void)in, (void)r, (void)src, (void)depth_tex, (void)rows;
    return 0;
#endif
}

obs_status glsl_gauss21_ours(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *kernel_out,
                             obs_image_f32 *out)
{
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, kernel_out->width, kernel_out->height, out);
    if (st == OBS_STATUS_OK)
        st = ao_blur_gaussian21(ctx, pool, kernel_out, out);
    if (st != OBS_STATUS_OK)
        return st;
    for (int y = 0; y < out->height; y++) {
        const float *d = obs_image_f32_row(in->depth, in->y0 + y) + in->x0;
        float *o = obs_image_f32_row(out, y);
        for (int x = 0; x < out->width; x++)
            o[x] = d[x] > 0.0f && d[x] < INFINITY ? o[x] : 1.0f;
    }
    return OBS_STATUS_OK;
}
