/* test_gl_mssao_seed.c: our mssao-seed (ao_mssao_seed_compute: Alchemy at five resolutions, each
 * blurred, blended) against its GLSL port (glsl_mssao_seed.c: every level's G-buffer, Alchemy pass and
 * Gaussian, and the blend, as fragment passes) run on Mesa's llvmpipe, on the sphere scene at
 * 160 x 120 and at an odd 161 x 91 with a guard band: the thesis' defaults (blurred), the raw levels
 * (blur off), and every level at full intensity. */
#include "gl/port_compare.h"

#if GLH_AVAILABLE
static void seed_case(glh *g, obs_context *ctx, const pc_scene *sc, const ao_mssao_seed_params *p, const char *what,
                      double med_max, double p99_max, int over_max)
{
    obs_image_f32 ours;
    CHECK_OK(obs_image_f32_alloc(ctx, sc->in.w, sc->in.h, &ours), ctx);
    CHECK_OK(ao_mssao_seed_compute(ctx, NULL, &sc->in, p, &ours, NULL, NULL), ctx);
    glh_run r;
    const int built = glsl_mssao_seed_build(g, ctx, &sc->in, p, &r);
    char label[128];
    snprintf(label, sizeof label, "%s %dx%d", what, sc->in.w, sc->in.h);
    pc_check_port(g, ctx, built, &r, &ours, &sc->mask, label, med_max, p99_max, over_max);
}

static void seed_cases(glh *g, obs_context *ctx, const pc_scene *sc, int first)
{
    ao_mssao_seed_params p = ao_mssao_seed_params_default();
    seed_case(g, ctx, sc, &p, "thesis (blurred levels)", 1e-6, 1e-5, 2);
    p.alchemy.blur = 0;
    seed_case(g, ctx, sc, &p, "raw levels", 1e-6, 1e-5, 2);
    if (first) {
        CHECK(ao_mssao_seed_params_preset("full-intensity", &p));
        seed_case(g, ctx, sc, &p, "full intensity", 1e-6, 1e-5, 2);
    }
}
#endif

/* Measured (Mesa 22.3.6, LLVM 15, llvmpipe): medians 0 to 6e-8, p99 <= 1.2e-6, max 6.3e-4 (raw levels at
 * 160 x 120: an Alchemy tap ivec2(ssR (cos, sin)) that truncates to the next texel with llvmpipe's
 * cos/sin; 1.3e-5 once blurred), none over 1e-3. Bounds: median 1e-6, p99 1e-5, at most 2 pixels
 * over 1e-3. Moving vUV by 0.05 px in the blend raises the p99 to 2.7e-3. */
TEST(mssao_seed_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    pc_run_sizes(&g, seed_cases);
#endif
}
