/* test_sss_maps_rebuild.c: sss_maps_rebuild, the scattering maps written into the storage of
 * earlier maps with a kept workspace (src/sss/sss.h; docs/sss/maps.md "Fourth round: rebuild and
 * speed"). The rebuild must be the same bytes as a fresh sss_maps_build whatever the maps held
 * before (another scene, another sampler), refuse maps of another layout, and write every texel
 * (the radiance planes are not zeroed). */
#include "test.h"

#include "scene_util.h"
#include "sss/sss.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* One translucent material slot for every mesh. */
static void set_one_material(obs_scene *s)
{
    s->materials = (obs_material *)calloc(1, sizeof(obs_material));
    s->material_count = 1;
    strcpy(s->materials[0].name, "sss");
    for (uint32_t i = 0; i < s->mesh_count; i++)
        s->meshes[i].material = 0;
}

typedef struct fixture {
    obs_context *ctx;
    obs_scene scene[2]; /* [0]: a sphere; [1]: a bumpy, larger one off-centre (other coverage) */
    sss_constants cst;
    uint8_t translucent;
    sss_scene_materials mats;
    obs_light light;
} fixture;

static void fixture_make(fixture *f)
{
    memset(f, 0, sizeof *f);
    f->ctx = obs_context_create();
    tu_sphere(&f->scene[0], 40, 20, 10.0f, obs_v3(0, 0, 0), 0.0f);
    tu_sphere(&f->scene[1], 40, 20, 12.0f, obs_v3(3, -2, 1), 0.2f);
    for (int i = 0; i < 2; i++)
        set_one_material(&f->scene[i]);
    sss_material m;
    memset(&m, 0, sizeof m);
    strcpy(m.name, "potato");
    const double ss[3] = {0.68, 0.70, 0.55}, sa[3] = {0.0024, 0.0090, 0.12}; /* Jensen01 potato */
    for (int c = 0; c < 3; c++) {
        m.sigma_s[c] = ss[c];
        m.sigma_a[c] = sa[c];
    }
    m.eta = 1.3;
    (void)sss_constants_make(f->ctx, &m, 1.0, &f->cst);
    f->translucent = 1;
    f->mats.count = 1;
    f->mats.constants = &f->cst;
    f->mats.translucent = &f->translucent;
    strcpy(f->light.name, "sun");
    f->light.type = OBS_LIGHT_DIRECTIONAL;
    f->light.color = obs_v3(1, 1, 1);
    f->light.intensity = 3.0f;
    f->light.direction = obs_v3(0.6666667f, -0.6666667f, -0.3333333f);
}

static void fixture_free(fixture *f)
{
    for (int i = 0; i < 2; i++)
        obs_scene_free(&f->scene[i]);
    obs_context_destroy(f->ctx);
}

static sss_params small_params(sss_sampler s)
{
    sss_params p = sss_params_default();
    p.K = 3;
    p.map_size = 48;
    p.light_map_size = 64;
    p.N = 16;
    p.M = 200;
    p.sampler = s;
    return p;
}

/* The views' planes and the radiance planes byte for byte (size x size each), and the counters. */
static int maps_identical(const sss_maps *a, const sss_maps *b)
{
    if (a->K != b->K || a->size != b->size || a->samples_evaluated != b->samples_evaluated ||
        a->candidates != b->candidates)
        return 0;
    if (memcmp(a->dirs, b->dirs, sizeof(double) * 3 * (size_t)a->K))
        return 0;
    const size_t row = sizeof(float) * (size_t)a->size;
    for (int k = 0; k < a->K; k++) {
        const rast_gbuffer *ga = &a->views[k], *gb = &b->views[k];
        if (memcmp(&ga->constants, &gb->constants, sizeof ga->constants))
            return 0;
        for (int y = 0; y < a->size; y++) {
            if (memcmp(obs_image_f32_row(&ga->depth, y), obs_image_f32_row(&gb->depth, y), row) ||
                memcmp(obs_image_u32_row(&ga->instance_id, y), obs_image_u32_row(&gb->instance_id, y), row) ||
                memcmp(obs_image_u32_row(&ga->material_id, y), obs_image_u32_row(&gb->material_id, y), row))
                return 0;
            for (int c = 0; c < 3; c++)
                if (memcmp(obs_image_f32_row(&ga->normal[c], y), obs_image_f32_row(&gb->normal[c], y), row) ||
                    memcmp(obs_image_f32_row(&a->radiance[3 * k + c], y), obs_image_f32_row(&b->radiance[3 * k + c], y),
                           row))
                    return 0;
        }
    }
    return 1;
}

/* Sum of the radiance planes and the count of non-finite texels in them. */
static double radiance_sum(const sss_maps *m, long *nonfinite)
{
    double sum = 0.0;
    *nonfinite = 0;
    for (int i = 0; i < 3 * m->K; i++)
        for (int y = 0; y < m->size; y++)
            for (int x = 0; x < m->size; x++) {
                const float v = obs_image_f32_row(&m->radiance[i], y)[x];
                if (isfinite(v))
                    sum += v;
                else
                    (*nonfinite)++;
            }
    return sum;
}

/* For the three samplers and 1 and 2 threads: maps built fresh for scene 0, and the same maps
 * rebuilt (one workspace throughout) into storage that first held scene 1's maps with another
 * sampler and seed, then rebuilt a second time in place: all three are the same bytes. The texels
 * scene 1 covered and scene 0 does not must come back as 0; the workspace's scratch left over
 * from another sampler must change nothing. */
TEST(sss_maps_rebuild_matches_a_fresh_build_for_every_sampler_and_thread_count)
{
    fixture f;
    fixture_make(&f);
    const sss_sampler samplers[3] = {SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_SAMPLER_NEAREST_N_OF_M,
                                     SSS_SAMPLER_EXPONENTIAL};
    sss_maps fresh1[3];
    memset(fresh1, 0, sizeof fresh1);
    for (int threads = 1; threads <= 2; threads++) {
        obs_pool *pool = obs_pool_create(threads);
        sss_maps_workspace *ws = sss_maps_workspace_create();
        CHECK(ws != NULL);
        sss_maps re;
        memset(&re, 0, sizeof re);
        for (int si = 0; si < 3; si++) {
            const sss_params p = small_params(samplers[si]);
            sss_params q = small_params(samplers[(si + 1) % 3]);
            q.seed = 99;
            sss_light_map lm0, lm1;
            CHECK_OK(sss_light_map_render(f.ctx, pool, &f.scene[0], &f.light, &p, &lm0), f.ctx);
            CHECK_OK(sss_light_map_render(f.ctx, pool, &f.scene[1], &f.light, &q, &lm1), f.ctx);
            sss_maps fresh;
            CHECK_OK(sss_maps_build(f.ctx, pool, &f.scene[0], &f.mats, &lm0, 1, &p, &fresh), f.ctx);
            long nf = 0;
            CHECK(radiance_sum(&fresh, &nf) > 0.0 && nf == 0);
            /* the storage first holds scene 1's maps (zeroed re: allocated by the first call) */
            CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[1], &f.mats, &lm1, 1, &q, ws, &re), f.ctx);
            CHECK(!maps_identical(&re, &fresh));
            const float *data0 = re.radiance[0].data;
            CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm0, 1, &p, ws, &re), f.ctx);
            CHECK_MSG(maps_identical(&re, &fresh), "sampler %s, %d thread(s): rebuild != build",
                      sss_sampler_name(p.sampler), threads);
            CHECK(re.radiance[0].data == data0); /* written in place */
            CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm0, 1, &p, ws, &re), f.ctx);
            CHECK(maps_identical(&re, &fresh));
            /* NULL workspace: a temporary one, the same bytes */
            CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm0, 1, &p, NULL, &re), f.ctx);
            CHECK(maps_identical(&re, &fresh));
            if (threads == 1)
                fresh1[si] = fresh;
            else {
                CHECK_MSG(maps_identical(&fresh, &fresh1[si]), "sampler %s: 1 and 2 threads differ",
                          sss_sampler_name(p.sampler));
                sss_maps_free(&fresh);
            }
            sss_light_map_free(&lm0);
            sss_light_map_free(&lm1);
        }
        /* all opaque: every radiance texel of the rebuilt maps is 0 (none left from before) */
        {
            const sss_params p = small_params(SSS_SAMPLER_RUSSIAN_ROULETTE);
            sss_light_map lm0;
            CHECK_OK(sss_light_map_render(f.ctx, pool, &f.scene[0], &f.light, &p, &lm0), f.ctx);
            uint8_t opaque = 0;
            sss_scene_materials mo = f.mats;
            mo.translucent = &opaque;
            CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &mo, &lm0, 1, &p, ws, &re), f.ctx);
            long nf = 0;
            CHECK(radiance_sum(&re, &nf) == 0.0 && nf == 0);
            for (int i = 0; i < 3 * re.K; i++)
                for (int y = 0; y < re.size; y++)
                    for (int x = 0; x < re.size; x++)
                        CHECK(obs_image_f32_row(&re.radiance[i], y)[x] == 0.0f);
            sss_light_map_free(&lm0);
        }
        sss_maps_free(&re);
        sss_maps_workspace_free(ws);
        obs_pool_destroy(pool);
    }
    for (int si = 0; si < 3; si++)
        sss_maps_free(&fresh1[si]);
    fixture_free(&f);
}

/* Maps of another K or map size are refused with INVALID_ARGUMENT and a message naming both
 * layouts, and are left as they were (the same storage, the same bytes); a zeroed sss_maps is
 * built; maps neither zeroed nor built are refused. */
TEST(sss_maps_rebuild_refuses_maps_of_another_k_or_map_size)
{
    fixture f;
    fixture_make(&f);
    obs_pool *pool = obs_pool_create(2);
    sss_maps_workspace *ws = sss_maps_workspace_create();
    const sss_params p = small_params(SSS_SAMPLER_RUSSIAN_ROULETTE);
    sss_light_map lm;
    CHECK_OK(sss_light_map_render(f.ctx, pool, &f.scene[0], &f.light, &p, &lm), f.ctx);
    sss_maps a, ref;
    memset(&a, 0, sizeof a);
    CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, ws, &a), f.ctx); /* zeroed: built */
    CHECK_OK(sss_maps_build(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, &ref), f.ctx);
    CHECK(maps_identical(&a, &ref));
    const float *data0 = a.radiance[0].data;
    sss_params q = p;
    q.K = 4;
    CHECK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &q, ws, &a) == OBS_STATUS_INVALID_ARGUMENT);
    const char *msg = obs_context_last_error(f.ctx);
    CHECK_MSG(strstr(msg, "K = 3") && strstr(msg, "K = 4") && strstr(msg, "sss_maps_build"), "message: %s", msg);
    CHECK(a.K == 3 && a.radiance[0].data == data0 && maps_identical(&a, &ref));
    q = p;
    q.map_size = 64;
    obs_context_clear_error(f.ctx);
    CHECK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &q, ws, &a) == OBS_STATUS_INVALID_ARGUMENT);
    msg = obs_context_last_error(f.ctx);
    CHECK_MSG(strstr(msg, "48^2") && strstr(msg, "map_size = 64"), "message: %s", msg);
    CHECK(a.size == 48 && a.radiance[0].data == data0 && maps_identical(&a, &ref));
    /* half-made maps: refused */
    sss_maps bad;
    memset(&bad, 0, sizeof bad);
    bad.K = 3;
    bad.size = 48;
    CHECK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, ws, &bad) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, ws, NULL) == OBS_STATUS_INVALID_ARGUMENT);
    /* the other sampler fits the same storage */
    q = p;
    q.sampler = SSS_SAMPLER_EXPONENTIAL;
    CHECK_OK(sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &q, ws, &a), f.ctx);
    CHECK(a.radiance[0].data == data0);
    sss_maps_free(&a);
    sss_maps_free(&ref);
    sss_light_map_free(&lm);
    sss_maps_workspace_free(ws);
    obs_pool_destroy(pool);
    fixture_free(&f);
}

/* With OBS_POISON_UNINIT=1 the maps' planes start as signalling-NaN bits: a build, and a rebuild
 * into the poisoned storage, leave no NaN in the radiance planes, and give the bytes of a build
 * without poison (every texel written, 0 off the object). */
TEST(sss_maps_rebuild_leaves_no_texel_unwritten)
{
    fixture f;
    fixture_make(&f);
    obs_pool *pool = obs_pool_create(2);
    const sss_sampler samplers[3] = {SSS_SAMPLER_RUSSIAN_ROULETTE, SSS_SAMPLER_NEAREST_N_OF_M,
                                     SSS_SAMPLER_EXPONENTIAL};
    for (int si = 0; si < 3; si++) {
        const sss_params p = small_params(samplers[si]);
        sss_light_map lm;
        sss_maps clean, poisoned, re;
        memset(&re, 0, sizeof re);
        CHECK_OK(sss_light_map_render(f.ctx, pool, &f.scene[0], &f.light, &p, &lm), f.ctx);
        CHECK_OK(sss_maps_build(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, &clean), f.ctx);
        setenv("OBS_POISON_UNINIT", "1", 1);
        obs_status st1 = sss_maps_build(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, &poisoned);
        obs_status st2 = sss_maps_rebuild(f.ctx, pool, &f.scene[0], &f.mats, &lm, 1, &p, NULL, &re);
        unsetenv("OBS_POISON_UNINIT");
        CHECK(st1 == OBS_STATUS_OK && st2 == OBS_STATUS_OK);
        long nf = 0;
        CHECK(radiance_sum(&poisoned, &nf) > 0.0);
        CHECK_MSG(nf == 0, "sampler %s: %ld texels unwritten by the build", sss_sampler_name(p.sampler), nf);
        CHECK(radiance_sum(&re, &nf) > 0.0);
        CHECK_MSG(nf == 0, "sampler %s: %ld texels unwritten by the rebuild", sss_sampler_name(p.sampler), nf);
        CHECK(maps_identical(&clean, &poisoned) && maps_identical(&clean, &re));
        sss_maps_free(&clean);
        sss_maps_free(&poisoned);
        sss_maps_free(&re);
        sss_light_map_free(&lm);
    }
    obs_pool_destroy(pool);
    fixture_free(&f);
}
