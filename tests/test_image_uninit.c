/* test_image_uninit.c: the not-zeroed plane allocation (obs_image_*_alloc_uninit,
 * rast_gbuffer_alloc_uninit). Its producers must write every element; with OBS_POISON_UNINIT=1
 * the planes start as signalling-NaN bits, so a producer that misses an element (a background
 * pixel, the guard band, a tile edge) changes the output bytes and fails these tests. */
#include "test.h"

#include "raster/raster.h"
#include "scene_util.h"
#include "sss/sss.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define POISON_BITS 0x7FA5A5A5u

static void poison(int on)
{
    if (on)
        setenv("OBS_POISON_UNINIT", "1", 1);
    else
        unsetenv("OBS_POISON_UNINIT");
}

/* Whole rows, padding included (stride elements), byte for byte. */
static int rows_equal(const void *a, ptrdiff_t sa, const void *b, ptrdiff_t sb, int w, int h)
{
    if (!a || !b)
        return a == b;
    if (sa != sb || sa < w)
        return 0;
    return memcmp(a, b, (size_t)sa * (size_t)h * 4) == 0;
}

/* Elements carrying the poison bits, over the width x height area. */
static size_t poisoned(const void *data, ptrdiff_t stride, int w, int h)
{
    size_t n = 0;
    if (!data)
        return 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            n += ((const uint32_t *)data)[(size_t)y * (size_t)stride + (size_t)x] == POISON_BITS;
    return n;
}

#define FOR_PLANES(gb, F)                                                                               \
    do {                                                                                                \
        F((gb).depth);                                                                                  \
        F((gb).ndc_depth);                                                                              \
        for (int c_ = 0; c_ < 3; c_++) {                                                                \
            F((gb).normal[c_]);                                                                         \
            F((gb).face_normal[c_]);                                                                    \
        }                                                                                               \
        F((gb).prim_id);                                                                                \
        F((gb).instance_id);                                                                            \
        F((gb).material_id);                                                                            \
    } while (0)

static int gbuffers_equal(const rast_gbuffer *a, const rast_gbuffer *b)
{
    int ok = a->width == b->width && a->height == b->height && a->outputs == b->outputs;
#define EQ(field) ok = ok && rows_equal(a->field.data, a->field.stride, b->field.data, b->field.stride, a->width, a->height)
    EQ(depth);
    EQ(ndc_depth);
    for (int c = 0; c < 3; c++) {
        EQ(normal[c]);
        EQ(face_normal[c]);
    }
    EQ(prim_id);
    EQ(instance_id);
    EQ(material_id);
#undef EQ
    return ok;
}

static size_t gbuffer_poisoned(const rast_gbuffer *g)
{
    size_t n = 0;
#define P(plane) n += poisoned((plane).data, (plane).stride, g->width, g->height)
    FOR_PLANES(*g, P);
#undef P
    return n;
}

TEST(image_uninit_poison_fills_every_element_and_zeroes_the_padding)
{
    obs_context *ctx = obs_context_create();
    poison(1);
    obs_image_f32 f;
    obs_image_u32 u;
    CHECK_OK(obs_image_f32_alloc_uninit(ctx, 37, 5, &f), ctx);
    CHECK_OK(obs_image_u32_alloc_uninit(ctx, 16, 3, &u), ctx);
    poison(0);
    CHECK(f.stride == 48 && u.stride == 16);
    CHECK_EQ_INT((int)poisoned(f.data, f.stride, f.width, f.height), 37 * 5);
    CHECK_EQ_INT((int)poisoned(u.data, u.stride, u.width, u.height), 16 * 3);
    CHECK(isnan(obs_image_f32_row(&f, 4)[36]));
    for (int y = 0; y < f.height; y++)
        for (int x = f.width; x < f.stride; x++)
            CHECK(obs_image_f32_row(&f, y)[x] == 0.0f && !signbit(obs_image_f32_row(&f, y)[x]));
    obs_image_f32_free(&f);
    obs_image_u32_free(&u);
    /* the zeroing allocation ignores the variable */
    poison(1);
    CHECK_OK(obs_image_f32_alloc(ctx, 37, 5, &f), ctx);
    poison(0);
    CHECK_EQ_INT((int)poisoned(f.data, f.stride, f.width, f.height), 0);
    for (int y = 0; y < f.height; y++)
        for (int x = 0; x < f.stride; x++)
            CHECK(obs_image_f32_row(&f, y)[x] == 0.0f);
    obs_image_f32_free(&f);
    /* bad sizes are still refused */
    CHECK(obs_image_f32_alloc_uninit(ctx, 0, 5, &f) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(obs_image_u32_alloc_uninit(ctx, 4, 5, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

TEST(raster_uninit_gbuffer_is_fully_written_on_every_path)
{
    /* Two spheres covering part of the image (background, partial and full tiles), a guard
     * band, tiles that stop at the image edge (size not a multiple of the tile), every output,
     * perspective and orthographic views, both ISAs, back-face culling and three views in one
     * call: the poisoned uninitialised G-buffer must equal the zeroed one byte for byte. */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_sphere(&s, 40, 20, 1.0f, obs_v3(0, 0, 0), 0.1f);
    s.instances = (obs_instance *)realloc(s.instances, 2 * sizeof(obs_instance));
    s.instance_count = 2;
    s.instances[1] = s.instances[0];
    s.instances[1].node = 1;
    s.instances[1].world = obs_mat4_translation(obs_v3(1.6f, 0.3f, -1.0f));
    obs_scene_update_bounds(&s);
    rast_view views[3];
    views[0].camera = obs_camera_look_at(obs_v3(0.5f, 0.5f, 6.0f), obs_v3(0.5f, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.5f, 50.0f);
    views[1].camera = obs_camera_look_at(obs_v3(-4.0f, 1.0f, 3.0f), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.5f, 0.3f, INFINITY);
    views[2].camera = views[0].camera;
    views[2].camera.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    views[2].camera.xmag = views[2].camera.ymag = 1.7f;
    obs_pool *pool = obs_pool_create(2);
    size_t total_covered = 0;
    for (int variant = 0; variant < 6; variant++) {
        rast_params p = rast_params_default();
        p.width = 157;
        p.height = 91;
        p.guard = (variant & 1) ? 7 : 0;
        p.isa = (variant & 2) ? RAST_ISA_SCALAR : RAST_ISA_AUTO;
        p.cull = variant >= 4 ? RAST_CULL_BACK : RAST_CULL_NONE;
        p.depth_convention = (rast_depth_convention)(variant % RAST_DEPTH_COUNT);
        p.tile_size = variant >= 4 ? 16 : 64;
        if (variant == 5)
            p.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
        rast_gbuffer a[3], b[3];
        rast_stats sa, sb;
        for (int k = 0; k < 3; k++)
            CHECK_OK(rast_gbuffer_alloc(ctx, &p, &a[k]), ctx);
        poison(1);
        for (int k = 0; k < 3; k++)
            CHECK_OK(rast_gbuffer_alloc_uninit(ctx, &p, &b[k]), ctx);
        poison(0);
        CHECK(gbuffer_poisoned(&b[0]) > 0);
        CHECK_OK(rast_render(ctx, pool, &s, views, 3, &p, a, &sa), ctx);
        CHECK_OK(rast_render(ctx, pool, &s, views, 3, &p, b, &sb), ctx);
        CHECK(sa.pixels_covered == sb.pixels_covered && sa.pixels_covered > 0 &&
              sa.pixels_covered < 3u * (uint64_t)a[0].width * (uint64_t)a[0].height);
        total_covered += sa.pixels_covered;
        for (int k = 0; k < 3; k++) {
            CHECK_MSG(gbuffer_poisoned(&b[k]) == 0, "variant %d view %d: %zu elements never written", variant, k,
                      gbuffer_poisoned(&b[k]));
            CHECK_MSG(gbuffers_equal(&a[k], &b[k]), "variant %d view %d: planes differ", variant, k);
            rast_gbuffer_free(&a[k]);
            rast_gbuffer_free(&b[k]);
        }
    }
    CHECK(total_covered > 0);
    obs_pool_destroy(pool);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

static void set_one_material(obs_scene *s)
{
    s->materials = (obs_material *)calloc(1, sizeof(obs_material));
    s->material_count = 1;
    strcpy(s->materials[0].name, "sss");
    for (uint32_t i = 0; i < s->mesh_count; i++)
        s->meshes[i].material = 0;
}

static int planes_f32_equal(const obs_image_f32 *a, const obs_image_f32 *b)
{
    return a->width == b->width && a->height == b->height &&
           rows_equal(a->data, a->stride, b->data, b->stride, a->width, a->height);
}

TEST(sss_maps_are_the_same_bytes_with_poisoned_uninit_planes)
{
    /* The light map (G-buffer, world positions and normals) and the scattering maps' views and
     * radiance, with OBS_POISON_UNINIT=1 and without. */
    obs_context *ctx = obs_context_create();
    obs_scene s;
    tu_sphere(&s, 48, 24, 10.0f, obs_v3(0, 0, 0), 0.0f);
    set_one_material(&s);
    sss_material m;
    memset(&m, 0, sizeof m);
    strcpy(m.name, "potato");
    double ss[3] = {0.68, 0.70, 0.55}, sa[3] = {0.0024, 0.0090, 0.12}; /* test values only */
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = ss[c];
        m.sigma_a[c] = sa[c];
    }
    m.eta = 1.3;
    sss_constants cst;
    CHECK_OK(sss_constants_make(ctx, &m, 1.0, &cst), ctx);
    uint8_t translucent = 1;
    sss_scene_materials mats;
    memset(&mats, 0, sizeof mats);
    mats.count = 1;
    mats.constants = &cst;
    mats.translucent = &translucent;
    obs_light L;
    memset(&L, 0, sizeof L);
    strcpy(L.name, "sun");
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.color = obs_v3(1, 1, 1);
    L.intensity = 3.0f;
    L.direction = obs_v3(0.6666667f, -0.6666667f, -0.3333333f);
    sss_params p = sss_params_default();
    p.K = 3;
    p.map_size = 48;
    p.light_map_size = 72;
    p.N = 16;
    obs_pool *pool = obs_pool_create(2);
    sss_light_map lm[2];
    sss_maps mp[2];
    for (int run = 0; run < 2; run++) {
        poison(run == 1);
        CHECK_OK(sss_light_map_render(ctx, pool, &s, &L, &p, &lm[run]), ctx);
        CHECK_OK(sss_maps_build(ctx, pool, &s, &mats, &lm[run], 1, &p, &mp[run]), ctx);
    }
    poison(0);
    CHECK(gbuffer_poisoned(&lm[1].gb) == 0 && gbuffers_equal(&lm[0].gb, &lm[1].gb));
    for (int a = 0; a < 3; a++) {
        CHECK(planes_f32_equal(&lm[0].position[a], &lm[1].position[a]));
        CHECK(planes_f32_equal(&lm[0].wnormal[a], &lm[1].wnormal[a]));
        CHECK(poisoned(lm[1].position[a].data, lm[1].position[a].stride, lm[1].position[a].width,
                       lm[1].position[a].height) == 0);
    }
    CHECK(mp[0].K == 3 && mp[1].K == 3 && mp[0].samples_evaluated == mp[1].samples_evaluated);
    double sum = 0;
    for (int k = 0; k < mp[0].K; k++) {
        CHECK(gbuffer_poisoned(&mp[1].views[k]) == 0 && gbuffers_equal(&mp[0].views[k], &mp[1].views[k]));
        for (int c = 0; c < 3; c++) {
            const obs_image_f32 *r = &mp[1].radiance[3 * k + c];
            CHECK(planes_f32_equal(&mp[0].radiance[3 * k + c], r));
            for (int y = 0; y < r->height; y++)
                for (int x = 0; x < r->width; x++)
                    sum += obs_image_f32_row(r, y)[x];
        }
    }
    CHECK(sum > 0 && isfinite(sum));
    for (int run = 0; run < 2; run++) {
        sss_maps_free(&mp[run]);
        sss_light_map_free(&lm[run]);
    }
    obs_pool_destroy(pool);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
