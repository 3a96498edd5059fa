/* vol_light_volume_rebuild (src/volume/vol_light.c, vol.h): a rebuild into a light volume of the
 * same layout writes into its memory, and its output is the same bits as a fresh build (same grid,
 * TF, light, params, occluder); a rebuild into a volume of another size builds fresh. Lights cover
 * the passes: a z face blended with a y face, an x face (the staged pass along x), a point light
 * outside and one inside the volume; blend on/off, scales 1 and 2, 1 and 2 threads, with and
 * without a workspace, with and without an occluder (occupancy and entry). */
#include "test.h"

#include "core/obs.h"
#include "volume/vol.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static vol_light rb_dir(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    double n = sqrt(x * x + y * y + z * z);
    L.direction[0] = x / n, L.direction[1] = y / n, L.direction[2] = z / n;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

static vol_light rb_point(double x, double y, double z)
{
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_POINT;
    L.position[0] = x, L.position[1] = y, L.position[2] = z;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    return L;
}

/* 1 when a and b have the same layout and the same bytes in every channel and field. */
static int rb_same(const vol_light_volume *a, const vol_light_volume *b)
{
    if (a->nx != b->nx || a->ny != b->ny || a->nz != b->nz || a->scale != b->scale || a->face0 != b->face0 ||
        a->face1 != b->face1 || memcmp(&a->blend_weight, &b->blend_weight, sizeof a->blend_weight) != 0 ||
        memcmp(a->spacing, b->spacing, sizeof a->spacing) != 0 || memcmp(a->origin, b->origin, sizeof a->origin) != 0)
        return 0;
    size_t bytes = (size_t)a->nx * a->ny * a->nz * sizeof(float);
    if (memcmp(a->l, b->l, bytes) != 0)
        return 0;
    for (int c = 0; c < 3; c++)
        if (memcmp(a->c[c], b->c[c], bytes) != 0)
            return 0;
    return 1;
}

/* The 4 channels in one block, as a build lays them out. */
static int rb_one_block(const vol_light_volume *lv)
{
    size_t v = (size_t)lv->nx * lv->ny * lv->nz;
    return lv->l && lv->c[0] == lv->l + v && lv->c[1] == lv->l + 2 * v && lv->c[2] == lv->l + 3 * v;
}

static float rb_entry(void *user, const double x[3])
{
    (void)user;
    return x[0] < 0.0 ? 0.25f : 0.9f;
}

/* For each of threads 1, 2, scales 1, 2, blend 0, 1, workspace off/on: build with the first light,
 * then rebuild with every light in turn (and the first again): each rebuild stays in the same block
 * and equals a fresh build. */
static void rb_sequence(obs_context *ctx, const vol_grid *g, const vol_tf *tf, int with_occ)
{
    const vol_light Ls[5] = {rb_dir(0.3, -0.5, 0.8), rb_dir(0.9, 0.3, -0.2), rb_point(-3.8, 1.0, 4.4),
                             rb_point(0.1, -0.2, 0.05), rb_dir(0.0, 0.0, 1.0)};
    double lo[3], hi[3];
    vol_grid_bounds(g, lo, hi);
    for (int c = 0; c < 3; c++) /* the second point light is inside the volume (the seeded passes) */
        CHECK(Ls[3].position[c] > lo[c] && Ls[3].position[c] < hi[c]);
    for (int threads = 1; threads <= 2; threads++) {
        obs_pool *pool = obs_pool_create(threads);
        CHECK(pool);
        for (int scale = 1; scale <= 2; scale++) {
            vol_occupancy o;
            memset(&o, 0, sizeof o);
            vol_occluder oc = {NULL, 0.0, NULL, NULL};
            if (with_occ) {
                CHECK_OK(vol_occupancy_alloc(ctx, g, scale, &o), ctx);
                /* an opaque-ish block in one corner */
                for (int k = 0; k < o.nz / 2; k++)
                    for (int j = 0; j < o.ny / 3; j++)
                        for (int i = o.nx / 2; i < o.nx; i++)
                            o.f[((size_t)k * o.ny + j) * o.nx + i] = 0.7f;
                oc.occupancy = &o;
                oc.entry = rb_entry;
            }
            const vol_occluder *occ = with_occ ? &oc : NULL;
            for (int blend = 0; blend <= 1; blend++)
                for (int use_ws = 0; use_ws <= 1; use_ws++) {
                    vol_lv_params p = vol_lv_params_default();
                    p.scale = scale;
                    p.blend_second = blend;
                    vol_lv_workspace *ws = use_ws ? vol_lv_workspace_create() : NULL;
                    CHECK(!use_ws || ws);
                    vol_light_volume lv;
                    memset(&lv, 0, sizeof lv);
                    /* a zeroed lv: a fresh build */
                    CHECK_OK(vol_light_volume_rebuild(ctx, pool, g, tf, &Ls[0], &p, occ, ws, &lv), ctx);
                    CHECK(rb_one_block(&lv));
                    const float *block = lv.l;
                    for (int q = 1; q <= 5; q++) {
                        const vol_light *L = &Ls[q % 5];
                        CHECK_OK(vol_light_volume_rebuild(ctx, pool, g, tf, L, &p, occ, ws, &lv), ctx);
                        CHECK_MSG(lv.l == block, "rebuild moved the block (threads %d scale %d blend %d ws %d light %d)",
                                  threads, scale, blend, use_ws, q % 5);
                        CHECK(rb_one_block(&lv));
                        if (q == 1) /* the staged pass along x runs */
                            CHECK_EQ_INT(lv.face0 >> 1, 0);
                        if (q == 5 && blend) /* a blended second face (the workspace's tmp) */
                            CHECK(lv.blend_weight < 1.0f);
                        vol_light_volume fresh;
                        CHECK_OK(vol_light_volume_build_ex(ctx, pool, g, tf, L, &p, occ, &fresh), ctx);
                        CHECK_MSG(rb_same(&lv, &fresh), "rebuild differs from a fresh build (threads %d scale %d "
                                  "blend %d ws %d light %d occ %d)", threads, scale, blend, use_ws, q % 5, with_occ);
                        vol_light_volume_free(&fresh);
                    }
                    vol_light_volume_free(&lv);
                    vol_lv_workspace_free(ws);
                }
            vol_occupancy_free(&o);
        }
        obs_pool_destroy(pool);
    }
}

TEST(volume_light_rebuild_matches_fresh_build_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    rb_sequence(ctx, &g, &tf, 0);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_light_rebuild_with_occluder_matches_fresh_build_bit_for_bit)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    rb_sequence(ctx, &g, &tf, 1);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

/* A rebuild into a volume of another size (another grid, or another scale) builds fresh: the new
 * layout, the same bits as a fresh build; the same workspace serves both sizes. */
TEST(volume_light_rebuild_into_other_size_builds_fresh)
{
    obs_context *ctx = obs_context_create();
    vol_grid g1, g2;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g1), ctx);
    CHECK_OK(vol_synth(ctx, "bucky", 17, &g2), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    obs_pool *pool = obs_pool_create(2);
    CHECK(pool);
    vol_lv_workspace *ws = vol_lv_workspace_create();
    CHECK(ws);
    const vol_light L = rb_dir(0.8, 0.5, 0.3), L2 = rb_dir(-0.2, 0.9, 0.4);
    vol_lv_params p = vol_lv_params_default();
    vol_light_volume lv;
    memset(&lv, 0, sizeof lv);
    CHECK_OK(vol_light_volume_rebuild(ctx, pool, &g1, &tf, &L, &p, NULL, ws, &lv), ctx);
    CHECK_EQ_INT(lv.nx, 24);
    const vol_grid *gs[3] = {&g2, &g1, &g1};
    const int scales[3] = {1, 1, 2};
    for (int s = 0; s < 3; s++) {
        p.scale = scales[s];
        const vol_light *Ls = s == 1 ? &L2 : &L;
        CHECK_OK(vol_light_volume_rebuild(ctx, pool, gs[s], &tf, Ls, &p, NULL, ws, &lv), ctx);
        vol_light_volume fresh;
        CHECK_OK(vol_light_volume_build(ctx, pool, gs[s], &tf, Ls, &p, &fresh), ctx);
        CHECK_EQ_INT(lv.nx, fresh.nx);
        CHECK(rb_one_block(&lv));
        CHECK(rb_same(&lv, &fresh));
        vol_light_volume_free(&fresh);
    }
    /* an error frees lv (zeroed) */
    vol_light spot = L;
    spot.type = OBS_LIGHT_SPOT;
    CHECK_EQ_INT(vol_light_volume_rebuild(ctx, pool, &g1, &tf, &spot, &p, NULL, ws, &lv), OBS_STATUS_UNSUPPORTED);
    CHECK(lv.l == NULL && lv.nx == 0);
    CHECK_EQ_INT(vol_light_volume_rebuild(ctx, pool, &g1, &tf, &L, &p, NULL, ws, NULL), OBS_STATUS_INVALID_ARGUMENT);
    vol_lv_workspace_free(ws);
    vol_lv_workspace_free(NULL);
    obs_pool_destroy(pool);
    vol_tf_free(&tf);
    vol_grid_free(&g1);
    vol_grid_free(&g2);
    obs_context_destroy(ctx);
}
