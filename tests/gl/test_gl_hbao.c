/* test_gl_hbao.c: our HBAO (ao_hbao_compute, ao_hbao_blur) against its GLSL ports (glsl_hbao.c: the
 * DX10 SDK's HorizonBasedAOEngine.fx, gl_ssao's hbao.frag.glsl and bilateralblur.frag.glsl) run on
 * Mesa's llvmpipe, on the sphere-over-ground scene at 160 x 120 and 161 x 91. Background gets a finite
 * far depth (500 m) on both sides (glsl_hbao.c). The figures are in docs/ao/hbao.md, "GLSL port". */
#include "ao/ao.h"
#include "ao_test_util.h"
#include "gl/glsl_ports.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#if GLH_AVAILABLE
/* One configuration: our result (kernel alone, or with the blur) against the port's, over surface
 * pixels. Returns the difference statistics. */
static void hb_compare(glh *g, obs_context *ctx, const ao_input *in, const obs_image_f32 *mask,
                       const ao_hbao_params *p, const char *what, glh_diff *out)
{
    glh_diff d = {0, 0, 1e30, 1e30, 1e30};
    *out = d;
    obs_image_f32 ours = {0}, gl = {0};
    CHECK_OK(obs_image_f32_alloc(ctx, in->w, in->h, &ours), ctx);
    CHECK_OK(ao_hbao_compute(ctx, NULL, in, p, &ours, NULL, NULL), ctx);
    glh_run r;
    CHECK_MSG(glsl_hbao_build(g, ctx, in, p, &r), "%s: the port does not build", what);
    glh_run_draw(g, &r, 0, r.npass);
    CHECK_OK(glh_run_read(g, &r, ctx, &gl), ctx);
    d = glh_compare(&ours, &gl, mask, 1e-3f);
    *out = d;
    printf("  %s %dx%d: %d surface pixels, |ours - llvmpipe| median %.3g, p99 %.3g, max %.3g, > 1e-3: %d\n", what,
           in->w, in->h, d.n, d.median, d.p99, d.max, d.over);
    glh_run_free(g, &r);
    obs_image_f32_free(&ours);
    obs_image_f32_free(&gl);
}
#endif

TEST(hbao_classic_plus_and_blur_match_their_glsl_ports_on_llvmpipe)
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
        obs_image_f32 d;
        CHECK_OK(obs_image_f32_alloc(ctx, W, H, &d), ctx);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const float v = obs_image_f32_row(&gb.depth, y)[x];
                obs_image_f32_row(&d, y)[x] = v < INFINITY ? v : 500.0f; /* glsl_hbao.c's far depth */
            }
        in.depth = &d;
        /* the kernels: classic (SDK defaults, the SDK's 64 x 64 texture), classic with gl_ssao's 4 x 4,
         * plus (HBAO+ defaults, PowExponent 1.5) */
        for (int c = 0; c < 3; c++) {
            ao_hbao_params p;
            CHECK(ao_hbao_params_preset(c == 2 ? "plus" : "default", &p));
            p.blur = 0;
            p.radius = 0.5f;
            p.pow_exponent = 1.5f;
            if (c == 1)
                p.noise = AO_HBAO_NOISE_GL_SSAO;
            const char *name = c == 0 ? "classic (sdk 64x64)" : c == 1 ? "classic (gl-ssao 4x4)" : "plus";
            glh_diff df;
            hb_compare(&g, ctx, &in, &gb.depth, &p, name, &df);
            /* measured (Mesa 22.3.6 llvmpipe, LLVM 15): docs/ao/hbao.md "GLSL port"; median 0,
             * p99 <= 4.2e-7, max <= 2e-6, none over 1e-3 */
            CHECK(df.n > 1000);
            CHECK_MSG(df.median <= 1e-6 && df.p99 <= 1e-5, "%s: median %g / p99 %g too large", name, df.median, df.p99);
            CHECK_MSG(df.over <= df.n / 1000, "%s: %d pixels differ by more than 1e-3", name, df.over);
        }
        /* the blur, end to end (our kernel + our blur against the port's kernel + blur passes), over
         * all pixels: HBAO+'s (radius 4, depth slope, sharpness 16) on classic; gl_ssao's (radius 3,
         * sigma 1.5, sharpness 40, no slope) on plus */
        for (int b = 0; b < 2 && si == 0; b++) {
            ao_hbao_params p;
            CHECK(ao_hbao_params_preset(b ? "gl-ssao" : "default", &p));
            p.radius = 0.5f;
            CHECK(p.blur == 1);
            const char *name = b ? "plus + gl_ssao blur (radius 3)" : "classic + HBAO+ blur (radius 4, slope)";
            glh_diff df;
            hb_compare(&g, ctx, &in, NULL, &p, name, &df);
            CHECK_MSG(df.median <= 1e-6 && df.p99 <= 1e-5, "%s: median %g / p99 %g too large", name, df.median, df.p99);
            CHECK_MSG(df.over <= df.n / 1000, "%s: %d pixels differ by more than 1e-3", name, df.over);
        }
        /* the benchmark's view (glsl_port_hbao_classic / _plus at their presets' defaults): the kernel
         * passes against ours_kernel, then ours_blur on llvmpipe's kernel output against the blur passes */
        const glsl_port *ports[2] = {&glsl_port_hbao_classic, &glsl_port_hbao_plus};
        for (int pi = 0; pi < 2 && si == 0; pi++) {
            glh_run r;
            CHECK_MSG(ports[pi]->build(&g, ctx, &in, &r), "%s: the port does not build", ports[pi]->variant);
            CHECK(r.nkernel == 1 && r.npass == 3);
            glh_run_draw(&g, &r, 0, r.npass);
            glh_run k = r;
            k.out_fbo = r.pass[r.nkernel - 1].fbo;
            obs_image_f32 kgl = {0}, bgl = {0}, kours = {0}, bours = {0};
            CHECK_OK(glh_run_read(&g, &k, ctx, &kgl), ctx);
            CHECK_OK(glh_run_read(&g, &r, ctx, &bgl), ctx);
            CHECK_OK(ports[pi]->ours_kernel(ctx, NULL, &in, &kours), ctx);
            CHECK_OK(ports[pi]->ours_blur(ctx, NULL, &in, &kgl, &bours), ctx);
            glh_diff dk = glh_compare(&kours, &kgl, &gb.depth, 1e-3f), db = glh_compare(&bours, &bgl, NULL, 1e-3f);
            printf("  port %s: kernel median %.3g p99 %.3g max %.3g (> 1e-3: %d); blur alone max %.3g\n",
                   ports[pi]->variant, dk.median, dk.p99, dk.max, dk.over, db.max);
            CHECK_MSG(dk.median <= 1e-6 && dk.p99 <= 1e-5 && dk.over <= dk.n / 1000, "%s kernel", ports[pi]->variant);
            CHECK_MSG(db.max <= 1e-5, "%s blur alone: max %g", ports[pi]->variant, db.max);
            obs_image_f32_free(&kgl);
            obs_image_f32_free(&bgl);
            obs_image_f32_free(&kours);
            obs_image_f32_free(&bours);
            glh_run_free(&g, &r);
        }
        obs_image_f32_free(&d);
        rast_gbuffer_free(&gb);
    }
    obs_scene_free(&s);
    obs_context_destroy(ctx);
    glh_close(&g);
#endif
}
