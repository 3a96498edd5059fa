/* test_gl_harness.c: the GL harness itself (glh.h): a pass reads its input texels at the place our
 * row convention says, and writes exact IEEE results that read back unchanged. */
#include "gl/glh.h"
#include "test.h"

#include <stdlib.h>

#if GLH_AVAILABLE
static const char *const fs_affine =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D src; uniform float a; uniform float b;\n"
    "layout(location=0) out vec4 o;\n"
    "void main(){ o = vec4(texelFetch(src, ivec2(gl_FragCoord.xy), 0).x * a + b); }\n";
#endif

TEST(gl_harness_passes_round_trip_our_rows_exactly)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    obs_context *ctx = obs_context_create();
    const int W = 37, H = 23;
    obs_image_f32 in;
    CHECK_OK(obs_image_f32_alloc(ctx, W, H, &in), ctx);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            obs_image_f32_row(&in, y)[x] = (float)(y * 1000 + x) * 0.001f;
    glh_run r = {0};
    GLuint src = glh_run_own_texture(&r, glh_texture_from_image(&g, &in, GLH_ROWS_FLIP, INFINITY, GL_NEAREST,
                                                                 GL_CLAMP_TO_EDGE));
    GLuint dst = glh_run_own_texture(&r, glh_texture(&g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fb = glh_run_own_fbo(&r, glh_framebuffer(&g, dst, 0));
    GLuint p = glh_run_own_program(&r, glh_program(&g, fs_affine, NULL));
    CHECK(src && dst && fb && p);
    glh_set1f(&g, p, "a", 2.0f);
    glh_set1f(&g, p, "b", 0.25f);
    CHECK(glh_run_add(&r, "affine", p, fb, W, H, 1, &src) == 0);
    r.nkernel = 1;
    r.out_fbo = fb;
    r.out_w = W;
    r.out_h = H;
    r.out_rows = GLH_ROWS_FLIP;
    glh_run_draw(&g, &r, 0, r.npass);
    obs_image_f32 out;
    CHECK_OK(glh_run_read(&g, &r, ctx, &out), ctx);
    int bad = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            bad += obs_image_f32_row(&out, y)[x] != obs_image_f32_row(&in, y)[x] * 2.0f + 0.25f;
    CHECK_EQ_INT(bad, 0);
    CHECK(glh_run_time_ms(&g, &r, 0, 1) >= 0.0);
    obs_image_f32_free(&out);
    obs_image_f32_free(&in);
    glh_run_free(&g, &r);
    glh_close(&g);
    obs_context_destroy(ctx);
#endif
}
