/* test_gl_crytek.c: our Crytek SSAO against its GLSL port (glsl_crytek.c) on Mesa's llvmpipe, on
 * the bunny at 160x120 and 161x91: the default (world ball, linear, sky visible, remap) with and
 * without the Gaussian, and the presets that change the shader (kajalin: screen space; compute-port:
 * nearest fetch, sky skipped). Measured numbers are in docs/ao/crytek.md, "GLSL port". */
#include "gl/glb_bunny.h"
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

TEST(crytek_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
    obs_context *ctx = obs_context_create();
    glb_bunny b;
    glb_bunny_load(ctx, &b);
    const int sizes[2][2] = {{160, 120}, {161, 91}};
    const char *const presets[3] = {"default", "kajalin", "compute-port"};
    for (int si = 0; si < 2; si++) {
        glb_bunny_render(ctx, &b, sizes[si][0], sizes[si][1]);
        for (int pi = 0; pi < 3; pi++) {
            ao_crytek_params p;
            CHECK(ao_crytek_params_preset(presets[pi], &p));
            const int blur = p.blur;
            /* the kernel alone */
            p.blur = 0;
            obs_image_f32 ours = {0};
            CHECK_OK(obs_image_f32_alloc(ctx, b.in.w, b.in.h, &ours), ctx);
            CHECK_OK(ao_crytek_compute(ctx, NULL, &b.in, &p, &ours, NULL, NULL), ctx);
            glh_run r;
            CHECK(glsl_crytek_build(&g, ctx, &b.in, &p, &r));
            const glh_diff d = glb_compare_run(&g, ctx, &r, &ours, &b.in, presets[pi]);
            glh_run_free(&g, &r);
            /* measured (Mesa 22.3.6, LLVM 15, both sizes, each preset): median 0, p99 0, max 1.8e-7
             * (compute-port, all IEEE operations and nearest fetches: bit for bit) */
            glb_check_agreement(&d, presets[pi]);
            /* with the Gaussian (the default's): compared over every surface pixel */
            if (blur) {
                p.blur = 1;
                obs_image_f32 ob = {0};
                CHECK_OK(obs_image_f32_alloc(ctx, b.in.w, b.in.h, &ob), ctx);
                CHECK_OK(ao_crytek_compute(ctx, NULL, &b.in, &p, &ob, NULL, NULL), ctx);
                CHECK(glsl_crytek_build(&g, ctx, &b.in, &p, &r));
                CHECK(r.npass == 3 && r.nkernel == 1);
                const glh_diff db = glb_compare_run(&g, ctx, &r, &ob, &b.in, "default + gauss21");
                glh_run_free(&g, &r);
                /* measured: median 0, p99 0, max 1.2e-7 */
                glb_check_agreement(&db, "default + gauss21");
                obs_image_f32_free(&ob);
            }
            obs_image_f32_free(&ours);
        }
    }
    glb_bunny_free(&b);
    obs_context_destroy(ctx);
    glh_close(&g);
}

/* The blur alone, fed our own kernel output: the port of the seed's Gaussian against ao_blur_gaussian21. */
TEST(gauss21_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    obs_context *ctx = obs_context_create();
    glb_bunny b;
    glb_bunny_load(ctx, &b);
    glb_bunny_render(ctx, &b, 161, 91);
    obs_image_f32 k = {0}, ours = {0};
    CHECK_OK(glsl_port_crytek.ours_kernel(ctx, NULL, &b.in, &k), ctx);
    CHECK_OK(glsl_port_crytek.ours_blur(ctx, NULL, &b.in, &k, &ours), ctx);
    glh_run r = {0};
    GLuint src = glh_run_own_texture(&r, glh_texture_from_image(&g, &k, GLH_ROWS_FLIP, INFINITY, GL_NEAREST,
                                                                 GL_CLAMP_TO_EDGE));
    GLuint dt = glh_run_own_texture(&r, glh_texture_from_image(&g, b.in.depth, GLH_ROWS_FLIP, INFINITY, GL_NEAREST,
                                                                GL_CLAMP_TO_EDGE));
    CHECK(src && dt && glsl_gauss21_add(&g, &b.in, &r, src, dt, GLH_ROWS_FLIP));
    r.nkernel = 0;
    const glh_diff d = glb_compare_run(&g, ctx, &r, &ours, &b.in, "gauss21 alone");
    /* every pixel, background included (1 on both sides) */
    obs_image_f32 gl = {0};
    CHECK_OK(glh_run_read(&g, &r, ctx, &gl), ctx);
    const glh_diff all = glh_compare(&ours, &gl, NULL, 1e-6f);
    printf("  gauss21 over all %d px: max %.3g\n", all.n, all.max);
    /* measured: bit for bit (max 0) */
    CHECK(all.max <= 2e-6);
    CHECK(d.max <= 2e-6);
    obs_image_f32_free(&gl);
    glh_run_free(&g, &r);
    obs_image_f32_free(&k);
    obs_image_f32_free(&ours);
    glb_bunny_free(&b);
    obs_context_destroy(ctx);
    glh_close(&g);
#endif
}
