/* test_gl_sss.c: our scattering maps (sss_maps_build) against the project's GLSL port of the
 * gather (glsl_sss.c) run on Mesa's llvmpipe, on the same light G-buffers and map views, for
 * Frisvad's potato sphere and the bunny in cream (build/data), both samplers set explicitly.
 * The figures are in docs/gl.md, "SSS scattering maps". */
#include "gl/glsl_sss.h"
#include "io/io.h"
#include "test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* What one comparison found, over the lit texels (ours or GL > 0 in any channel), all channels. */
typedef struct sss_diff {
    int lit, zero_mismatch;  /* lit texel-channels; texels lit on one side only */
    double peak;             /* max of ours */
    double max_abs, p99_abs; /* |ours - GL| */
    double max_rel, p99_rel; /* |ours - GL| / |ours| over channels with ours > 1e-6 peak */
    int over_rel;            /* channels with relative difference > 1e-4 */
    int unequal;             /* channels whose floats are not bit-identical */
} sss_diff;

/* ours, gl: K layers of 3 planes of W x H */
static sss_diff compare_maps(const obs_image_f32 *ours, const obs_image_f32 *gl, int K, int W, int H)
{
    sss_diff d;
    memset(&d, 0, sizeof d);
    const size_t n = (size_t)3 * K * W * H;
    double *ea = (double *)malloc(sizeof(double) * n), *er = (double *)malloc(sizeof(double) * n);
    int na = 0, nr = 0;
    for (int i = 0; i < 3 * K; i++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const double v = obs_image_f32_row(&ours[i], y)[x];
                if (v > d.peak)
                    d.peak = v;
            }
    for (int k = 0; k < K; k++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int lit_o = 0, lit_g = 0;
                for (int c = 0; c < 3; c++) {
                    lit_o |= obs_image_f32_row(&ours[3 * k + c], y)[x] != 0.0f;
                    lit_g |= obs_image_f32_row(&gl[3 * k + c], y)[x] != 0.0f;
                }
                if (lit_o != lit_g)
                    d.zero_mismatch++;
                if (!lit_o && !lit_g)
                    continue;
                for (int c = 0; c < 3; c++) {
                    const double a = obs_image_f32_row(&ours[3 * k + c], y)[x];
                    const double b = obs_image_f32_row(&gl[3 * k + c], y)[x];
                    const double e = (a == a && b == b) ? fabs(a - b) : INFINITY;
                    ea[na++] = e;
                    d.lit++;
                    d.unequal += memcmp(&obs_image_f32_row(&ours[3 * k + c], y)[x],
                                        &obs_image_f32_row(&gl[3 * k + c], y)[x], sizeof(float)) != 0;
                    if (fabs(a) > 1e-6 * d.peak) {
                        const double rel = e / fabs(a);
                        er[nr++] = rel;
                        d.over_rel += rel > 1e-4;
                    }
                }
            }
    if (na) {
        qsort(ea, (size_t)na, sizeof(double), cmp_double);
        d.max_abs = ea[na - 1];
        d.p99_abs = ea[(int)(0.99 * (na - 1))];
    }
    if (nr) {
        qsort(er, (size_t)nr, sizeof(double), cmp_double);
        d.max_rel = er[nr - 1];
        d.p99_rel = er[(int)(0.99 * (nr - 1))];
    }
    free(ea);
    free(er);
    return d;
}

typedef struct sss_case {
    const char *file;
    int size, K, N, M;
    sss_sampler sampler;
    sss_model model;
    int point_light;    /* add a point light (a perspective light map) to the scene's light */
    int frames;         /* 0: the default (1) */
    double disk_radius; /* 0: the default (the bounds' half diagonal) */
    int combine;        /* also compare the combination for the scene's default camera at 160 x 120 */
    sss_visibility visibility;
    double gamma;
    sss_isa isa;        /* 0: SSS_ISA_AUTO */
} sss_case;

static void print_diff(const char *what, const sss_diff *d)
{
    printf("    %s: %d lit texel-channels, peak %.4g; |ours - llvmpipe| max %.3g (%.3g of the peak), p99 %.3g; "
           "relative max %.3g, p99 %.3g, > 1e-4: %d; not bit-identical: %d; lit on one side only: %d\n",
           what, d->lit, d->peak, d->max_abs, d->peak > 0 ? d->max_abs / d->peak : 0.0, d->p99_abs, d->max_rel,
           d->p99_rel, d->over_rel, d->unequal, d->zero_mismatch);
    fflush(stdout);
}

/* The bounds every comparison asserts (the comment in run_case says why). */
static void check_diff(const char *what, const sss_diff *d)
{
    CHECK_MSG(d->lit > 1000, "%s: only %d lit texel-channels", what, d->lit);
    CHECK_MSG(d->zero_mismatch == 0, "%s: %d texels lit on one side only", what, d->zero_mismatch);
    CHECK_MSG(d->max_abs <= 1e-5 * d->peak, "%s: max |ours - llvmpipe| %.3g > 1e-5 of the peak %.3g", what,
              d->max_abs, d->peak);
    CHECK_MSG(d->over_rel == 0, "%s: %d channels differ by more than 1e-4 relative", what, d->over_rel);
}

/* Build our maps and the port's for one case, compare, check the bounds (docs/gl.md). */
static void run_case(glh *g, const sss_case *cs)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), cs->file), &opt, &s), ctx);
    sss_scene_setup setup;
    CHECK_OK(sss_scene_setup_make(ctx, &s, NULL, SSS_DEFAULT_MM_PER_UNIT, &setup), ctx);
    sss_params p = sss_params_default();
    p.sampler = cs->sampler; /* explicit: the default sampler may change */
    p.model = cs->model;
    p.K = cs->K;
    p.N = cs->N;
    p.M = cs->M > 0 ? cs->M : p.M;
    p.map_size = cs->size;
    p.light_map_size = cs->size;
    p.frames = cs->frames > 0 ? cs->frames : p.frames;
    p.disk_radius = cs->disk_radius;
    p.seed = 0x1234567890abcdefull; /* both halves of the seed matter */
    p.isa = cs->isa;
    obs_light L[2];
    int nl = 0;
    CHECK(s.light_count >= 1);
    L[nl++] = s.lights[0];
    if (cs->point_light) {
        memset(&L[nl], 0, sizeof L[nl]);
        snprintf(L[nl].name, sizeof L[nl].name, "test point");
        L[nl].type = OBS_LIGHT_POINT;
        const obs_aabb *b = &s.bounds;
        const float ext = fmaxf(b->hi.x - b->lo.x, fmaxf(b->hi.y - b->lo.y, b->hi.z - b->lo.z));
        L[nl].position = obs_v3(b->hi.x + 1.5f * ext, b->hi.y + 0.5f * ext, b->lo.z - 1.0f * ext);
        L[nl].color = obs_v3(1.0f, 0.9f, 0.8f);
        L[nl].intensity = 0.5f * ext * ext;
        nl++;
    }
    sss_light_map lm[2];
    memset(lm, 0, sizeof lm);
    obs_pool *pool = obs_pool_create(0);
    for (int l = 0; l < nl; l++)
        CHECK_OK(sss_light_map_render(ctx, pool, &s, &L[l], &p, &lm[l]), ctx);
    sss_maps maps;
    double t0 = obs_time_now();
    CHECK_OK(sss_maps_build(ctx, pool, &s, &setup.mats, lm, nl, &p, &maps), ctx);
    const double t_ours = obs_time_now() - t0;
    glh_run r;
    const int built = glsl_sss_gather_build(g, ctx, &s, &setup.mats, lm, nl, &maps, &p, &r);
    CHECK_MSG(built, "%s: the port was not built", cs->file);
    if (built) {
        obs_image_f32 *gl = (obs_image_f32 *)calloc(3 * (size_t)p.K, sizeof(obs_image_f32));
        t0 = obs_time_now();
        CHECK_OK(glsl_sss_gather_read(g, &r, ctx, p.K, p.map_size, gl), ctx);
        const double t_gl = obs_time_now() - t0;
        const sss_diff d = compare_maps(maps.radiance, gl, p.K, p.map_size, p.map_size);
        printf("  %s, %s, %s, %s, %d light(s), K=%d N=%d M=%d, %d frame(s), R %g, %d^2: ours %.0f ms, llvmpipe %.0f ms "
               "(first draw, with compile)\n",
               cs->file, sss_sampler_name(p.sampler), sss_model_name(p.model), sss_isa_name(p.isa), nl, p.K, p.N,
               p.sampler == SSS_SAMPLER_NEAREST_N_OF_M ? p.M : 0, p.frames, p.disk_radius, p.map_size, t_ours * 1e3,
               t_gl * 1e3);
        print_diff("maps", &d);
        /* Measured bit for bit on Mesa 22.3.6 / LLVM 15 (llvmpipe's float and double +, -, *, /, sqrt
         * are IEEE and the port keeps our order). The bound is float rounding with room for a GL whose
         * division and sqrt are not correctly rounded (GLSL allows 2.5 ulp for a / b): 1e-5 of the
         * peak absolute (about 80 ulp of the peak), 1e-4 relative per channel above 1e-6 of the peak,
         * no texel lit on one side only (docs/gl.md, "SSS scattering maps"). */
        check_diff("maps", &d);
        if (cs->combine) {
            /* pass 3 on our maps, for the scene's default camera */
            obs_camera cam = s.cameras[0];
            rast_params rp = rast_params_default();
            rp.width = 160;
            rp.height = 120;
            rp.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL | RAST_OUT_MATERIAL_ID | RAST_OUT_INSTANCE_ID;
            rp.face_forward = 0;
            rast_gbuffer cgb;
            CHECK_OK(rast_gbuffer_alloc(ctx, &rp, &cgb), ctx);
            rast_view view = {cam};
            CHECK_OK(rast_render(ctx, pool, &s, &view, 1, &rp, &cgb, NULL), ctx);
            sss_params pc = p;
            pc.visibility = cs->visibility;
            pc.gamma = cs->gamma;
            obs_image_f32 ours[3], glc[3];
            CHECK_OK(sss_combine(ctx, pool, &s, &setup.mats, &maps, lm, nl, &cgb, &cam, &pc, ours, NULL), ctx);
            glh_run rc;
            const int cbuilt = glsl_sss_combine_build(g, ctx, &setup.mats, &maps, &cgb, &cam, &pc, &rc);
            CHECK_MSG(cbuilt, "%s: the combination port was not built", cs->file);
            if (cbuilt) {
                CHECK_OK(glsl_sss_read_rgb(g, &rc, ctx, glc), ctx);
                const sss_diff dc = compare_maps(ours, glc, 1, 160, 120);
                char what[96];
                snprintf(what, sizeof what, "combination (%s, gamma %g)", sss_visibility_name(pc.visibility),
                         pc.gamma);
                print_diff(what, &dc);
                check_diff(what, &dc);
                for (int c = 0; c < 3; c++)
                    obs_image_f32_free(&glc[c]);
            }
            glh_run_free(g, &rc);
            for (int c = 0; c < 3; c++)
                obs_image_f32_free(&ours[c]);
            rast_gbuffer_free(&cgb);
        }
        for (int i = 0; i < 3 * p.K; i++)
            obs_image_f32_free(&gl[i]);
        free(gl);
    }
    glh_run_free(g, &r);
    sss_maps_free(&maps);
    for (int l = 0; l < nl; l++)
        sss_light_map_free(&lm[l]);
    obs_pool_destroy(pool);
    sss_scene_setup_free(&setup);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
#endif

TEST(gl_sss_russian_roulette_maps_match_their_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    const sss_case cases[] = {
        {"sphere_potato.glb", 96, 4, 32, 0, SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_MODEL_DIRECTIONAL, 0, 0, 0.0,
         0, SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
        /* cream scatters over a few cm: a 3 cm disk (the default, 15 cm, accepts almost nothing at N = 16) */
        {"bunny_cream.glb", 128, 4, 16, 0, SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_MODEL_DIRECTIONAL, 1, 0, 0.03,
         0, SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
        {"sphere_potato.glb", 64, 4, 16, 0, SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_MODEL_STANDARD, 1, 2, 0.0,
         0, SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i]);
    glh_close(&g);
#endif
}

TEST(gl_sss_n_of_m_maps_match_their_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    const sss_case cases[] = {
        {"sphere_potato.glb", 64, 4, 16, 200, SSS_SAMPLER_NEAREST_N_OF_M, SSS_MODEL_DIRECTIONAL, 0, 2, 0.0,
         0, SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
        {"bunny_cream.glb", 64, 4, 24, 300, SSS_SAMPLER_NEAREST_N_OF_M, SSS_MODEL_DIRECTIONAL, 1, 0, 0.0,
         0, SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i]);
    glh_close(&g);
#endif
}

TEST(gl_sss_combination_matches_its_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    /* the gather again (cheap), then pass 3 on our maps: product-5 linear, and pcf3x3 with the
     * thesis figures' gamma 1.8 */
    const sss_case cases[] = {
        {"sphere_potato.glb", 64, 4, 16, 0, SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_MODEL_DIRECTIONAL, 0, 0, 0.0, 1,
         SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
        {"bunny_cream.glb", 96, 4, 16, 0, SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_MODEL_DIRECTIONAL, 0, 0, 0.03, 1,
         SSS_VISIBILITY_PCF3X3, 1.8, SSS_ISA_AUTO},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i]);
    glh_close(&g);
#endif
}

TEST(gl_sss_exponential_maps_match_their_glsl_port_on_llvmpipe)
{
    glh g;
    glh_open_or_skip(&g);
#if GLH_AVAILABLE
    /* The default sampler (ours, docs/sss/maps.md "Samplers"): the inverse-CDF radius (float
     * Newton), phi, the weight 1/(N p), the 3 x 3 near-field block, the per-texel stream, the four
     * interleaved partial sums. The reference is the scalar C path (SSS_ISA_SCALAR); the last case
     * runs our default ISA (AVX2 where available) against the same port. The bound is check_diff's
     * (1e-5 of the peak absolute, 1e-4 relative, no texel lit on one side only); measured bit for
     * bit (docs/gl.md, "SSS scattering maps"). */
    const sss_case cases[] = {
        {"bunny_cream.glb", 32, 2, 8, 0, SSS_SAMPLER_EXPONENTIAL, SSS_MODEL_DIRECTIONAL, 0, 0, 0.0, 0,
         SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_SCALAR},
        /* a point light too (a perspective light map, 1/d^2), a 3 cm disk, two frames */
        {"bunny_cream.glb", 64, 2, 8, 0, SSS_SAMPLER_EXPONENTIAL, SSS_MODEL_DIRECTIONAL, 1, 2, 0.03, 0,
         SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_SCALAR},
        /* N = 13: one AVX2 group of 8 and a scalar tail of 5 */
        {"bunny_cream.glb", 32, 2, 13, 0, SSS_SAMPLER_EXPONENTIAL, SSS_MODEL_DIRECTIONAL, 0, 0, 0.0, 0,
         SSS_VISIBILITY_PRODUCT5, 1.0, SSS_ISA_AUTO},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        run_case(&g, &cases[i]);
    glh_close(&g);
#endif
}
