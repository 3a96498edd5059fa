/* test_gl_sao.c: our SAO (ao_sao_compute, ao_sao_blur_gl) against the project's own GLSL port of
 * McGuire's SAO shaders (glsl_sao.c: reconstructCSZ, SAO_minify, SAO_AO, SAO_blur) run on Mesa's
 * llvmpipe, on the sphere-over-ground scene at 160 x 120 and 161 x 91: the kernel reading level 0
 * only, the kernel with the MIP chain, the blur alone (on llvmpipe's own kernel output) and the
 * whole pass. Independent of ../shared (test_ao_llvmpipe.c checks against the external peer when it
 * is there). The figures are in docs/ao/sao.md, "GLSL port". */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "gl/glsl_ports.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
static void sao_report(const char *what, int W, int H, const glh_diff *d)
{
    printf("  %s %dx%d: %d pixels, |ours - llvmpipe| median %.3g, p99 %.3g, max %.3g, > 1e-3: %d\n", what, W, H, d->n,
           d->median, d->p99, d->max, d->over);
}
#endif

TEST(sao_kernel_mip_chain_and_blur_match_their_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_ao_scene(&s);
    const int sizes[2][2] = {{160, 120}, {161, 91}};
    for (int si = 0; si < 2; si++) {
        const int W = sizes[si][0], H = sizes[si][1];
        rast_gbuffer gb;
        CHECK_OK(tu_render_depth_normal(ctx, &s, tu_ao_camera(), W, H, 0, &gb), ctx);
        ao_input in;
        CHECK_OK(ao_input_from_gbuffer(ctx, &gb, 0, &in), ctx);
        /* 0: level 0 only (the peer's `sao` stage); 1: the MIP chain (defaults, max mip 5); 2: with the blur */
        for (int c = 0; c < 3; c++) {
            ao_sao_params p = ao_sao_params_default();
            p.max_mip_level = c == 0 ? 0 : p.max_mip_level;
            p.blur = c == 2;
            const char *name = c == 0 ? "kernel, level 0" : c == 1 ? "kernel, MIP chain" : "kernel + blur";
            obs_image_f32 ours = {0}, gl = {0};
            CHECK_OK(obs_image_f32_alloc(ctx, W, H, &ours), ctx);
            CHECK_OK(ao_sao_compute(ctx, NULL, &in, &p, &ours, NULL, NULL), ctx);
            glh_run r;
            CHECK_MSG(glsl_sao_build(&g, ctx, &in, &p, &r), "%s: the port does not build", name);
            CHECK_EQ_INT(r.nkernel, 2 + (c == 0 ? 0 : p.max_mip_level));
            glh_run_draw(&g, &r, 0, r.npass);
            CHECK_OK(glh_run_read(&g, &r, ctx, &gl), ctx);
            /* every pixel: background is 1 on both sides */
            glh_diff d = glh_compare(&ours, &gl, NULL, 1e-3f);
            sao_report(name, W, H, &d);
            if (getenv("SAO_GL_DEBUG")) /* list the pixels over 1e-3 */
                for (int y = 0; y < H; y++)
                    for (int x = 0; x < W; x++) {
                        const float va = obs_image_f32_row(&ours, y)[x], vb = obs_image_f32_row(&gl, y)[x];
                        if (fabsf(va - vb) > 1e-3f)
                            printf("    pixel (%d, %d) (GL y %d): ours %.9g, llvmpipe %.9g, depth %.9g\n", x, y, H - 1 - y,
                                   (double)va, (double)vb, (double)obs_image_f32_row(in.depth, y)[x]);
                    }
            if (c == 2) {
                /* the blur alone: our SAO_blur on llvmpipe's own kernel output */
                glh_run k = r;
                k.out_fbo = r.pass[r.nkernel - 1].fbo;
                obs_image_f32 kgl = {0}, bours = {0};
                CHECK_OK(glh_run_read(&g, &k, ctx, &kgl), ctx);
                CHECK_OK(glsl_port_sao.ours_blur(ctx, NULL, &in, &kgl, &bours), ctx);
                d = glh_compare(&bours, &gl, NULL, 1e-3f);
                sao_report("blur alone (on llvmpipe's kernel)", W, H, &d);
                CHECK_MSG(d.max <= 1e-5, "blur alone: max %g", d.max);
                obs_image_f32_free(&kgl);
                obs_image_f32_free(&bours);
            }
            glh_run_free(&g, &r);
            obs_image_f32_free(&ours);
            obs_image_f32_free(&gl);
        }
        rast_gbuffer_free(&gb);
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    glh_close(&g);
#endif
}
