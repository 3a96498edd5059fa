/* test_gl_gtao.c: our GTAO (XeGTAO, ao_gtao_compute) against its GLSL port (glsl_gtao.c: XeGTAO.hlsli
 * re-typed) run on Mesa's llvmpipe: the prefilter's MIP chain, the main pass at the Low (1 x 2) and
 * High (3 x 3) presets with normals from the G-buffer and from depth, and the denoiser (0, 1 and 3
 * passes), on the sphere scene at 160 x 120 and at an odd 161 x 91 with a guard band. */
#include "gl/port_compare.h"

#if GLH_AVAILABLE
static void gtao_case(glh *g, obs_context *ctx, const pc_scene *sc, const char *preset, int normals_gbuffer,
                      int blur, int passes, double med_max, double p99_max, int over_max)
{
    ao_gtao_params p;
    CHECK(ao_gtao_params_preset(preset, &p));
    p.normals = normals_gbuffer ? AO_GTAO_NORMALS_GBUFFER : AO_GTAO_NORMALS_DEPTH;
    p.blur = blur;
    p.denoise_passes = passes;
    obs_image_f32 ours;
    CHECK_OK(obs_image_f32_alloc(ctx, sc->in.w, sc->in.h, &ours), ctx);
    CHECK_OK(ao_gtao_compute(ctx, NULL, &sc->in, &p, &ours, NULL, NULL), ctx);
    glh_run r;
    const int built = glsl_gtao_build(g, ctx, &sc->in, &p, &r);
    char label[128];
    snprintf(label, sizeof label, "%s %dx%d normals %s, %s", preset, sc->in.w, sc->in.h,
             normals_gbuffer ? "gbuffer" : "depth", blur ? (passes == 3 ? "3 denoise passes" : passes ? "denoised" : "denoise 0 (beta 1e4)") : "raw");
    pc_check_port(g, ctx, built, &r, &ours, &sc->mask, label, med_max, p99_max, over_max);
}

static void gtao_cases(glh *g, obs_context *ctx, const pc_scene *sc, int first)
{
    for (int pr = 0; pr < 2; pr++)
        for (int nm = 0; nm < 2; nm++)
            for (int bl = 0; bl < 2; bl++)
                gtao_case(g, ctx, sc, pr ? "high" : "low", nm, bl, 1, 1e-6, 1e-5, 2);
    if (first) {
        gtao_case(g, ctx, sc, "high", 1, 1, 3, 1e-6, 1e-5, 2);
        gtao_case(g, ctx, sc, "high", 1, 1, 0, 1e-6, 1e-5, 2);
    }
}
#endif

/* Measured (Mesa 22.3.6, LLVM 15, llvmpipe): every case median 0, p99 <= 2.6e-6, max 7.0e-4 (one pixel
 * of High at 161 x 91 with normals from depth, raw: a tap whose rounding or MIP choice flips with the
 * GPU's cos/sin/pow/log2; 9.7e-5 after the denoiser), none over 1e-3. Bounds: median 1e-6, p99 1e-5,
 * at most 2 pixels over 1e-3. */
TEST(gtao_matches_its_xegtao_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    pc_run_sizes(&g, gtao_cases);
#endif
}
