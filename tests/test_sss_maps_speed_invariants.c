/* test_sss_maps_speed_invariants.c: the maps' speed work changes no bit (docs/sss/maps.md,
 * "Cost", third round): the per-texel geometry with the view constants in double once, the
 * near-field block's AVX2 fetch, and why back-face culling of the K views stays off (identical
 * on closed meshes here, but an open mesh loses its back side, and closedness alone does not
 * make it provably identical: "Not done"). */
#include "test.h"

#include "io/io.h"
#include "raster/raster.h"
#include "scene_util.h"
#include "sss/sss.h"
#include "sss/sss_maps_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s;
}
static double urand(uint32_t *s) { return (double)(lcg(s) >> 8) / 16777216.0; }

/* The inline helpers (sss_i_view_geo) against the out-of-line ones, bit for bit, for an
 * orthographic and a perspective view. */
TEST(sss_maps_view_geo_matches_the_helpers_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    rast_params rp = rast_params_default();
    rp.width = rp.height = 256;
    obs_camera cams[2];
    cams[0] = obs_camera_look_at(obs_v3(3.1f, -2.0f, 7.5f), obs_v3(0.2f, 0.1f, -0.3f), obs_v3(0, 1, 0), 1.0f, 0.0f, 20.0f);
    cams[0].projection = OBS_PROJECTION_ORTHOGRAPHIC;
    cams[0].xmag = cams[0].ymag = 2.7f;
    cams[1] = obs_camera_look_at(obs_v3(-4.0f, 1.5f, 6.0f), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 50.0f);
    uint32_t seed = 12345u;
    for (int c = 0; c < 2; c++) {
        rast_view_constants vc;
        CHECK_OK(rast_view_constants_make(ctx, &rp, &cams[c], &vc), ctx);
        sss_i_view_geo g;
        sss_i_view_geo_make(&vc, &g);
        for (int i = 0; i < 2000; i++) {
            const double px = 256.0 * urand(&seed), py = 256.0 * urand(&seed), d = 0.5 + 8.0 * urand(&seed);
            double a[3], b[3];
            sss_i_pixel_world(&vc, px, py, d, a);
            sss_i_geo_pixel_world(&g, px, py, d, b);
            CHECK(memcmp(a, b, sizeof a) == 0);
            float nv[3] = {(float)(urand(&seed) - 0.5), (float)(urand(&seed) - 0.5), (float)(urand(&seed) - 0.5)};
            if (i == 0)
                nv[0] = nv[1] = nv[2] = 0.0f; /* zero stays zero */
            sss_i_normal_world(&vc, nv, a);
            sss_i_geo_normal_world(&g, nv, b);
            CHECK(memcmp(a, b, sizeof a) == 0);
            const double p[3] = {6.0 * urand(&seed) - 3.0, 6.0 * urand(&seed) - 3.0, 6.0 * urand(&seed) - 3.0};
            double r1[4] = {0, 0, 0, 0}, r2[4] = {0, 0, 0, 0};
            const int k1 = sss_i_project(&vc, p, &r1[0], &r1[1], &r1[2], &r1[3]);
            const int k2 = sss_i_geo_project(&g, p, &r2[0], &r2[1], &r2[2], &r2[3]);
            CHECK(k1 == k2);
            CHECK(memcmp(r1, r2, sizeof r1) == 0);
        }
    }
    obs_context_destroy(ctx);
}

/* The near-field block's AVX2 fetch (from the planes and from the interleaved records) against
 * the scalar loop of sss_maps.c (written out here):
 * the same count and the same values in the same order, on a map with empty texels (NaN) and
 * two instances, at every block position inside it. */
TEST(sss_exp_block_avx2_matches_the_scalar_loop)
{
#if defined(OBS_HAVE_AVX2)
    if (!sss_isa_available(SSS_ISA_AVX2)) {
        fprintf(stderr, "AVX2 not available: skipped\n");
        return;
    }
    enum { S = 20, ST = 24, NP = 32 };
    static float P[3][S * ST], W[3][S * ST];
    static uint32_t iid[S * ST];
    uint32_t seed = 99u;
    for (int i = 0; i < S * ST; i++) {
        for (int a = 0; a < 3; a++) {
            P[a][i] = (float)(urand(&seed) * 10.0 - 5.0);
            W[a][i] = (float)(urand(&seed) * 2.0 - 1.0);
        }
        const double u = urand(&seed);
        if (u < 0.2)
            P[0][i] = NAN; /* empty texel */
        iid[i] = u > 0.85 ? 7u : 3u;
    }
    /* the same map interleaved (sss_i_fetch_in.pack): 8 words per texel, S records a row */
    static uint32_t pack[S * S * 8];
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++) {
            uint32_t *r = pack + 8 * (y * S + x);
            for (int a = 0; a < 3; a++) {
                memcpy(&r[a], &P[a][y * ST + x], 4);
                memcpy(&r[3 + a], &W[a][y * ST + x], 4);
            }
            r[6] = iid[y * ST + x];
            r[7] = 0u;
        }
    static int32_t lut[256 * 8];
    sss_i_pack_lut_make(lut);
    static float buf[3][9][NP];
    static double w[3][NP];
    const float l[3] = {0.25f, -0.5f, 0.8306624f};
    const double wgt = 1.0 / 3.7;
    int tested = 0, kept = 0;
    for (int by = 0; by + 3 <= S; by++)
        for (int bx = 0; bx + 3 <= S; bx++)
            for (int start = 0; start <= NP - 9 - 8; start += 11) {
                /* earlier contents: finite values the lanes past the count may keep */
                for (int r = 0; r < 3; r++) {
                    for (int q = 0; q < 9; q++)
                        for (int i = 0; i < NP; i++)
                            buf[r][q][i] = (float)q;
                    for (int i = 0; i < NP; i++)
                        w[r][i] = -1.0;
                }
                float *xi[3][3], *ni[3][3], *wi[3][3];
                for (int r = 0; r < 3; r++)
                    for (int a = 0; a < 3; a++) {
                        xi[r][a] = buf[r][a];
                        ni[r][a] = buf[r][3 + a];
                        wi[r][a] = buf[r][6 + a];
                    }
                /* scalar: row by row, as sss_maps.c */
                int n = start;
                for (int iy = by; iy < by + 3; iy++)
                    for (int ix = bx; ix < bx + 3; ix++) {
                        const int o = iy * ST + ix;
                        if (P[0][o] != P[0][o] || iid[o] != 3u)
                            continue;
                        for (int a = 0; a < 3; a++) {
                            xi[0][a][n] = P[a][o];
                            ni[0][a][n] = W[a][o];
                            wi[0][a][n] = l[a];
                        }
                        w[0][n] = wgt;
                        n++;
                    }
                const sss_i_fetch_in in = {{P[0], P[1], P[2]}, {W[0], W[1], W[2]}, iid, ST, ST, 0.0f, 0.0f, 1.0f,
                                           (float)S, 3u, {l[0], l[1], l[2]}, bx, by, 1, NULL, 0};
                const int n2 = sss_i_exp_block_dir_avx2(&in, wgt, lut, xi[1], ni[1], wi[1], w[1], start);
                CHECK(n2 == n);
                sss_i_fetch_in inp = in;
                inp.pack = pack;
                inp.pack_w = S;
                CHECK(sss_i_exp_block_dir_avx2(&inp, wgt, lut, xi[2], ni[2], wi[2], w[2], start) == n);
                for (int q = 0; q < 9; q++)
                    CHECK(memcmp(buf[0][q] + start, buf[2][q] + start, sizeof(float) * (size_t)(n - start)) == 0);
                CHECK(memcmp(w[0] + start, w[2] + start, sizeof(double) * (size_t)(n - start)) == 0);
                for (int q = 0; q < 9; q++)
                    CHECK(memcmp(buf[0][q] + start, buf[1][q] + start, sizeof(float) * (size_t)(n - start)) == 0);
                CHECK(memcmp(w[0] + start, w[1] + start, sizeof(double) * (size_t)(n - start)) == 0);
                /* the lanes past the count stay finite (they may be padding of the kernel's batch) */
                for (int q = 0; q < 9; q++)
                    for (int i = n; i < NP; i++)
                        CHECK(isfinite(buf[1][q][i]));
                tested++;
                kept += n - start;
            }
    CHECK(tested > 300 && kept > tested * 4);
#else
    fprintf(stderr, "built without AVX2: skipped\n");
#endif
}

static int maps_identical(const sss_maps *a, const sss_maps *b)
{
    if (a->K != b->K || a->size != b->size || a->samples_evaluated != b->samples_evaluated)
        return 0;
    const size_t row = sizeof(float) * (size_t)a->size;
    for (int k = 0; k < a->K; k++)
        for (int y = 0; y < a->size; y++) {
            const rast_gbuffer *ga = &a->views[k], *gb = &b->views[k];
            if (memcmp(obs_image_f32_row(&ga->depth, y), obs_image_f32_row(&gb->depth, y), row) ||
                memcmp(obs_image_u32_row(&ga->instance_id, y), obs_image_u32_row(&gb->instance_id, y), row) ||
                memcmp(obs_image_u32_row(&ga->material_id, y), obs_image_u32_row(&gb->material_id, y), row))
                return 0;
            for (int c = 0; c < 3; c++)
                if (memcmp(obs_image_f32_row(&ga->normal[c], y), obs_image_f32_row(&gb->normal[c], y), row) ||
                    memcmp(obs_image_f32_row(&a->radiance[3 * k + c], y), obs_image_f32_row(&b->radiance[3 * k + c], y), row))
                    return 0;
        }
    return 1;
}

static long covered(const sss_maps *m)
{
    long n = 0;
    for (int k = 0; k < m->K; k++)
        for (int y = 0; y < m->size; y++)
            for (int x = 0; x < m->size; x++)
                n += obs_image_f32_row(&m->views[k].depth, y)[x] < INFINITY;
    return n;
}

/* Build the maps with and without back faces culled (the test hook sss_i_maps_cull_back);
 * returns whether they are identical, and the covered texels of each. */
static int cull_compare(obs_context *ctx, const obs_scene *s, const sss_scene_materials *mats, const obs_light *L,
                        const sss_params *p, long *cov_off, long *cov_on)
{
    obs_pool *pool = obs_pool_create(2);
    sss_light_map lm;
    sss_maps a, b;
    int same = 0;
    if (sss_light_map_render(ctx, pool, s, L, p, &lm) != OBS_STATUS_OK)
        goto out;
    sss_i_maps_cull_back = 0;
    obs_status st = sss_maps_build(ctx, pool, s, mats, &lm, 1, p, &a);
    sss_i_maps_cull_back = 1;
    obs_status st2 = sss_maps_build(ctx, pool, s, mats, &lm, 1, p, &b);
    sss_i_maps_cull_back = 0;
    if (st == OBS_STATUS_OK && st2 == OBS_STATUS_OK) {
        same = maps_identical(&a, &b);
        *cov_off = covered(&a);
        *cov_on = covered(&b);
    }
    sss_maps_free(&a);
    sss_maps_free(&b);
    sss_light_map_free(&lm);
out:
    obs_pool_destroy(pool);
    return same;
}

/* Back-face culling of the K views: on the closed, consistently wound bunny and a sphere the
 * maps come out identical (the nearest surface seen from outside is front-facing), which is why
 * it was considered; on an open mesh (a square seen from both sides) the views from behind lose
 * the surface, so the maps keep both faces (the default; sss_maps_build never culls). */
TEST(sss_maps_back_face_culling_is_identical_on_closed_meshes_but_not_on_open_ones)
{
    obs_context *ctx = obs_context_create();
    CHECK(sss_i_maps_cull_back == 0); /* off by default */
    sss_params p = sss_params_default();
    p.K = 4;
    p.map_size = 128;
    p.light_map_size = 128;
    p.N = 16;
    long c0 = 0, c1 = 0;

    /* the bunny in cream with its key light (build/data) */
    obs_scene s;
    obs_scene_init(&s);
    io_gltf_options go = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "bunny_cream.glb"), &go, &s), ctx);
    sss_scene_setup setup;
    CHECK_OK(sss_scene_setup_make(ctx, &s, NULL, SSS_DEFAULT_MM_PER_UNIT, &setup), ctx);
    CHECK(s.light_count >= 1);
    CHECK_MSG(cull_compare(ctx, &s, &setup.mats, &s.lights[0], &p, &c0, &c1), "bunny: culling changed the maps");
    CHECK(c0 > 1000 && c0 == c1);
    sss_scene_setup_free(&setup);
    obs_scene_free(&s);

    /* a sphere, one translucent material */
    tu_sphere(&s, 64, 32, 10.0f, obs_v3(0, 0, 0), 0.0f);
    s.materials = (obs_material *)calloc(1, sizeof(obs_material));
    s.material_count = 1;
    strcpy(s.materials[0].name, "sss");
    s.meshes[0].material = 0;
    sss_material mat;
    memset(&mat, 0, sizeof mat);
    strcpy(mat.name, "potato"); /* [Jensen01] Fig. 5b, per mm */
    const double ss[3] = {0.68, 0.70, 0.55}, sa[3] = {0.0024, 0.0090, 0.12};
    for (int c = 0; c < 3; c++) {
        mat.sigma_s[c] = ss[c];
        mat.sigma_a[c] = sa[c];
    }
    mat.eta = 1.3;
    sss_constants cc;
    CHECK_OK(sss_constants_make(ctx, &mat, 1.0, &cc), ctx);
    uint8_t tr = 1;
    sss_scene_materials mats = {1, &cc, &tr, NULL};
    obs_light L;
    memset(&L, 0, sizeof L);
    strcpy(L.name, "sun");
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.color = obs_v3(1, 1, 1);
    L.intensity = 3.0f;
    L.direction = obs_v3(0.6666667f, -0.6666667f, -0.3333333f);
    CHECK_MSG(cull_compare(ctx, &s, &mats, &L, &p, &c0, &c1), "sphere: culling changed the maps");
    CHECK(c0 > 1000 && c0 == c1);
    obs_scene_free(&s);

    /* an open mesh: one square facing +Z; the K Halton directions include views from behind */
    const float pos[12] = {-5, -5, 0, 5, -5, 0, 5, 5, 0, -5, 5, 0};
    const float nrm[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    tu_scene_one_mesh(&s, pos, 4, nrm, idx, 2);
    s.materials = (obs_material *)calloc(1, sizeof(obs_material));
    s.material_count = 1;
    strcpy(s.materials[0].name, "sss");
    s.meshes[0].material = 0;
    L.direction = obs_v3(0.0f, 0.0f, -1.0f);
    CHECK(!cull_compare(ctx, &s, &mats, &L, &p, &c0, &c1));
    CHECK_MSG(c1 < c0, "open square: %ld covered texels without culling, %ld with", c0, c1);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
