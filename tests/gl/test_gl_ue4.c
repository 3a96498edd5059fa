/* test_gl_ue4.c: our UE4 AO against its GLSL port (glsl_ue4.c: the shipped chain of
 * PostProcessAmbientOcclusion.usf, one GLSL pass per shader pass) on Mesa's llvmpipe, on the bunny
 * at 160x120 and 161x91 (odd: quads with helper lanes at both levels): the default (O1, 2 levels:
 * setup, AO and quad blur at level 1, AO with upsample and quad blur at level 0), the one-level
 * pass, classic-reconstruction, no normals (2 levels), quad blur 3, and the default with the
 * Gaussian. Measured numbers are in docs/ao/ue4.md, "GLSL port". */
#include "gl/glb_bunny.h"
#include "gl/glsl_ports.h"

TEST(ue4_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
    obs_context *ctx = obs_context_create();
    glb_bunny b;
    glb_bunny_load(ctx, &b);
    const int sizes[2][2] = {{160, 120}, {161, 91}};
    const char *const cases[6] = {"default", "ue4-one-level", "classic-reconstruction", "no normals",
                                  "quad blur 3", "default + gauss21"};
    for (int si = 0; si < 2; si++) {
        glb_bunny_render(ctx, &b, sizes[si][0], sizes[si][1]);
        for (int ci = 0; ci < 6; ci++) {
            ao_ue4_params p;
            CHECK(ao_ue4_params_preset(ci == 1 || ci == 2 ? cases[ci] : "default", &p));
            if (ci == 3)
                p.normals = AO_UE4_NORMALS_NONE;
            if (ci == 4)
                p.quad_blur = 3;
            p.blur = ci == 5;
            obs_image_f32 ours = {0};
            CHECK_OK(obs_image_f32_alloc(ctx, b.in.w, b.in.h, &ours), ctx);
            CHECK_OK(ao_ue4_compute(ctx, NULL, &b.in, &p, &ours, NULL, NULL), ctx);
            glh_run r;
            CHECK(glsl_ue4_build(&g, ctx, &b.in, &p, &r));
            const glh_diff d = glb_compare_run(&g, ctx, &r, &ours, &b.in, cases[ci]);
            glh_run_free(&g, &r);
            /* measured (Mesa 22.3.6, LLVM 15, both sizes, every case): median 0, p99 <= 1.8e-7,
             * max 3.6e-7 (the default at 161x91): llvmpipe's pow (Power, the quad blur's ^4) against
             * glibc's powf, nothing else */
            glb_check_agreement(&d, cases[ci]);
            obs_image_f32_free(&ours);
        }
    }
    glb_bunny_free(&b);
    obs_context_destroy(ctx);
    glh_close(&g);
}
