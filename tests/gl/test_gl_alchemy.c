/* test_gl_alchemy.c: our Alchemy AO against its GLSL port (glsl_alchemy.c) on Mesa's llvmpipe, on
 * the bunny at 160x120 and 161x91: the default with and without the Gaussian, the `port` preset
 * (contrast 1.5: the pow path, 16 taps, r 1 m) and the estimator without the range check.
 * Measured numbers are in docs/ao/alchemy.md, "GLSL port". */
#include "gl/glb_bunny.h"
#include "gl/glsl_ports.h"

TEST(alchemy_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
    obs_context *ctx = obs_context_create();
    glb_bunny b;
    glb_bunny_load(ctx, &b);
    const int sizes[2][2] = {{160, 120}, {161, 91}};
    const char *const cases[4] = {"default", "default + gauss21", "port", "no range check"};
    for (int si = 0; si < 2; si++) {
        glb_bunny_render(ctx, &b, sizes[si][0], sizes[si][1]);
        for (int ci = 0; ci < 4; ci++) {
            ao_alchemy_params p;
            CHECK(ao_alchemy_params_preset(ci == 2 ? "port" : "default", &p));
            p.blur = ci == 1;
            if (ci == 3)
                p.range_check = 0;
            obs_image_f32 ours = {0};
            CHECK_OK(obs_image_f32_alloc(ctx, b.in.w, b.in.h, &ours), ctx);
            CHECK_OK(ao_alchemy_compute(ctx, NULL, &b.in, &p, &ours, NULL, NULL), ctx);
            glh_run r;
            CHECK(glsl_alchemy_build(&g, ctx, &b.in, &p, &r));
            const glh_diff d = glb_compare_run(&g, ctx, &r, &ours, &b.in, cases[ci]);
            glh_run_free(&g, &r);
            /* measured (Mesa 22.3.6, LLVM 15, both sizes): bit for bit except `port` (pow with
             * k = 1.5: p99 1.8e-7, max 2.4e-7); median 0 everywhere. A GPU's cos/sin may move a
             * tap's truncated offset by a pixel: the count over 1e-3 allows for it. */
            glb_check_agreement(&d, cases[ci]);
            obs_image_f32_free(&ours);
        }
    }
    glb_bunny_free(&b);
    obs_context_destroy(ctx);
    glh_close(&g);
}
