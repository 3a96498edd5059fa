/* The eye-direction pass (src/volume/vol_eye.c), a reconstruction (volume.md 1.8;
 * docs/volume/light.md, "Eye pass"): its limits (an empty volume, a unit eye volume), that it is
 * exactly the light volume of "light from the eye", its dependence on the camera, threads, and
 * refusals. */
#include "test.h"

#include "core/obs.h"
#include "volume/vol.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A camera at distance `dist` from the grid's centre on the side `dir` points to, looking at the
 * centre; orthographic when ortho (xmag = ymag = the grid's half diagonal). */
static obs_camera eye_camera(const vol_grid *g, double dx, double dy, double dz, double dist, int ortho)
{
    double lo[3], hi[3];
    vol_grid_bounds(g, lo, hi);
    obs_vec3 ctr = obs_v3((float)(0.5 * (lo[0] + hi[0])), (float)(0.5 * (lo[1] + hi[1])), (float)(0.5 * (lo[2] + hi[2])));
    double n = sqrt(dx * dx + dy * dy + dz * dz);
    obs_vec3 eye = obs_v3((float)(ctr.x + dx / n * dist), (float)(ctr.y + dy / n * dist), (float)(ctr.z + dz / n * dist));
    obs_vec3 up = fabs(dy / n) > 0.99 ? obs_v3(0, 0, 1) : obs_v3(0, 1, 0);
    obs_camera cam = obs_camera_look_at(eye, ctr, up, 0.7f, 0.01f, 1000.0f);
    if (ortho) {
        cam.projection = OBS_PROJECTION_ORTHOGRAPHIC;
        cam.xmag = cam.ymag = (float)dist;
        cam.znear = 0.0f;
    }
    return cam;
}

/* An asymmetric volume: value 1 in the third of the grid with x < n/3 and in a small block at high
 * y, 0 elsewhere; with a coloured TF the chromaticity seen from +x and from -x differs. */
static int asym_grid(obs_context *ctx, int n, vol_grid *g)
{
    const double sp[3] = {1.0, 1.0, 1.0};
    if (vol_grid_alloc(ctx, n, n, n, sp, g) != OBS_STATUS_OK)
        return 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                float v = (i < n / 3) ? 1.0f : 0.0f;
                if (i > n / 2 && j > 3 * n / 4 && k > n / 3 && k < 2 * n / 3)
                    v = 0.7f;
                g->data[((size_t)k * n + j) * n + i] = v;
            }
    vol_grid_update_range(g);
    return 1;
}

/* TF over [0, 1]: 0 is empty, 1 is an orange absorber. */
static int coloured_tf(vol_tf *tf)
{
    memset(tf, 0, sizeof *tf);
    tf->points = (vol_tf_point *)calloc(2, sizeof *tf->points);
    if (!tf->points)
        return 0;
    tf->count = 2;
    snprintf(tf->name, sizeof tf->name, "test-orange");
    tf->points[0].value = 0.0;
    tf->points[1].value = 1.0;
    const float rgba1[4] = {1.0f, 0.5f, 0.1f, 0.25f};
    memcpy(tf->points[1].rgba, rgba1, sizeof rgba1);
    return 1;
}

static size_t lv_voxels(const vol_light_volume *lv) { return (size_t)lv->nx * lv->ny * lv->nz; }

TEST(volume_eye_empty_volume_gives_unit_chromaticity)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    const double sp[3] = {1.0, 0.8, 1.3};
    CHECK_OK(vol_grid_alloc(ctx, 20, 17, 12, sp, &g), ctx); /* zeroed: value 0 everywhere */
    vol_grid_update_range(&g);
    vol_tf tf;
    CHECK(coloured_tf(&tf));
    /* orthographic and perspective (outside, and inside the volume), scales 1 and 2, blend on/off */
    const double dirs[3][4] = {{0.3, 0.5, 1.0, 40.0}, {-1.0, 0.2, -0.4, 40.0}, {0.1, 0.0, 0.2, 2.0}};
    int checked = 0;
    for (int d = 0; d < 3; d++)
        for (int ortho = 0; ortho < 2; ortho++)
            for (int scale = 1; scale <= 2; scale++)
                for (int blend = 0; blend < 2; blend++) {
                    obs_camera cam = eye_camera(&g, dirs[d][0], dirs[d][1], dirs[d][2], dirs[d][3], ortho);
                    vol_lv_params p = vol_lv_params_default();
                    p.scale = scale;
                    p.blend_second = blend;
                    p.eye_pass = 1;
                    vol_light_volume eye;
                    CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &cam, &p, &eye), ctx);
                    size_t bad = 0;
                    for (size_t i = 0; i < lv_voxels(&eye); i++)
                        bad += eye.l[i] != 1.0f || eye.c[0][i] != 1.0f || eye.c[1][i] != 1.0f || eye.c[2][i] != 1.0f;
                    CHECK_MSG(bad == 0, "camera %d ortho %d scale %d blend %d: %zu voxels not exactly 1", d, ortho,
                              scale, blend, bad);
                    checked += (int)lv_voxels(&eye);
                    vol_light_volume_free(&eye);
                }
    CHECK(checked > 10000);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_eye_modulate_by_a_unit_eye_volume_is_the_identity)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g, empty;
    CHECK_OK(vol_synth(ctx, "bucky", 24, &g), ctx);
    const double sp[3] = {g.spacing[0], g.spacing[1], g.spacing[2]};
    CHECK_OK(vol_grid_alloc(ctx, g.nx, g.ny, g.nz, sp, &empty), ctx);
    memcpy(empty.origin, g.origin, sizeof g.origin);
    vol_grid_update_range(&empty);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.direction[0] = 0.48, L.direction[1] = -0.6, L.direction[2] = 0.64;
    L.color[0] = L.color[1] = L.color[2] = 1.0f;
    vol_lv_params p = vol_lv_params_default();
    p.eye_pass = 1;
    vol_light_volume lv, ref, eye;
    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &p, &lv), ctx);
    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &p, &ref), ctx);
    obs_camera cam = eye_camera(&g, -0.4, 0.3, 1.0, 60.0, 0);
    CHECK_OK(vol_eye_volume_build(ctx, pool, &empty, &tf, &cam, &p, &eye), ctx); /* c = 1 everywhere */
    CHECK_OK(vol_light_volume_modulate(ctx, &eye, &lv), ctx);
    const size_t bytes = lv_voxels(&lv) * sizeof(float);
    CHECK(memcmp(lv.l, ref.l, bytes) == 0);
    for (int c = 0; c < 3; c++)
        CHECK(memcmp(lv.c[c], ref.c[c], bytes) == 0);
    vol_light_volume_free(&lv);
    vol_light_volume_free(&ref);
    vol_light_volume_free(&eye);
    vol_tf_free(&tf);
    vol_grid_free(&empty);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

/* The eye volume is the light volume of "light from the eye" (a directional light along the view
 * direction, or a point light at the eye) with l set to 1; modulate multiplies c voxel by voxel. */
TEST(volume_eye_is_the_light_volume_of_light_from_the_eye)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    CHECK(asym_grid(ctx, 24, &g));
    vol_tf tf;
    CHECK(coloured_tf(&tf));
    for (int ortho = 0; ortho < 2; ortho++) {
        obs_camera cam = eye_camera(&g, 1.0, 0.35, -0.2, 50.0, ortho);
        vol_light L;
        memset(&L, 0, sizeof L);
        L.color[0] = L.color[1] = L.color[2] = 1.0f;
        if (ortho) {
            L.type = OBS_LIGHT_DIRECTIONAL;
            double n = sqrt((double)cam.world.m[8] * cam.world.m[8] + (double)cam.world.m[9] * cam.world.m[9] +
                            (double)cam.world.m[10] * cam.world.m[10]);
            for (int c = 0; c < 3; c++)
                L.direction[c] = -(double)cam.world.m[8 + c] / n;
        } else {
            L.type = OBS_LIGHT_POINT;
            for (int c = 0; c < 3; c++)
                L.position[c] = cam.world.m[12 + c];
        }
        vol_lv_params p = vol_lv_params_default();
        p.eye_pass = 1;
        vol_light_volume eye, ref, lv;
        CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &cam, &p, &eye), ctx);
        CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &p, &ref), ctx);
        CHECK_EQ_INT(eye.face0, 1); /* the camera is on the +x side */
        CHECK_EQ_INT(eye.face0, ref.face0);
        CHECK_EQ_INT(eye.face1, ref.face1);
        const size_t n = lv_voxels(&eye), bytes = n * sizeof(float);
        for (int c = 0; c < 3; c++)
            CHECK(memcmp(eye.c[c], ref.c[c], bytes) == 0);
        size_t not_one = 0, not_unit_c = 0;
        for (size_t i = 0; i < n; i++) {
            not_one += eye.l[i] != 1.0f;
            not_unit_c += eye.c[1][i] < 0.999f;
        }
        CHECK_EQ_INT((int)not_one, 0);
        CHECK(not_unit_c > n / 10); /* the orange absorber tints what lies behind it */
        /* modulate: c *= c_eye, l untouched */
        vol_lv_params pl = vol_lv_params_default();
        vol_light sun;
        memset(&sun, 0, sizeof sun);
        sun.type = OBS_LIGHT_DIRECTIONAL;
        sun.direction[1] = -1.0;
        CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &sun, &pl, &lv), ctx);
        vol_light_volume before;
        CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &sun, &pl, &before), ctx);
        CHECK_OK(vol_light_volume_modulate(ctx, &eye, &lv), ctx);
        size_t wrong = 0;
        for (size_t i = 0; i < n; i++) {
            wrong += lv.l[i] != before.l[i];
            for (int c = 0; c < 3; c++)
                wrong += lv.c[c][i] != before.c[c][i] * eye.c[c][i];
        }
        CHECK_EQ_INT((int)wrong, 0);
        vol_light_volume_free(&before);
        vol_light_volume_free(&lv);
        vol_light_volume_free(&eye);
        vol_light_volume_free(&ref);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_eye_depends_on_the_camera)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    vol_grid g;
    CHECK(asym_grid(ctx, 24, &g));
    vol_tf tf;
    CHECK(coloured_tf(&tf));
    for (int ortho = 0; ortho < 2; ortho++) {
        /* on the x axis, so that face0 alone carries the volume (blend weight 1, volume.md 1.7) */
        obs_camera a = eye_camera(&g, 1.0, 0.0, 0.0, 50.0, ortho), b = eye_camera(&g, -1.0, 0.0, 0.0, 50.0, ortho);
        vol_lv_params p = vol_lv_params_default();
        p.eye_pass = 1;
        vol_light_volume ea, eb;
        CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &a, &p, &ea), ctx);
        CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &b, &p, &eb), ctx);
        CHECK_EQ_INT(ea.face0, 1); /* +x */
        CHECK_EQ_INT(eb.face0, 0); /* -x */
        /* Seen from +x the absorber (x < n/3) lies behind the empty two thirds: the empty voxels
         * keep c = 1 there; seen from -x the light crosses it first and the empty voxels are tinted. */
        double mean_a = 0.0, mean_b = 0.0, maxdiff = 0.0;
        int cnt = 0;
        for (int k = 0; k < g.nz; k++)
            for (int j = 0; j < g.ny / 2; j++)
                for (int i = g.nx / 2; i < g.nx; i++) {
                    size_t o = ((size_t)k * g.ny + j) * g.nx + i;
                    mean_a += ea.c[2][o];
                    mean_b += eb.c[2][o];
                    cnt++;
                }
        for (size_t i = 0; i < lv_voxels(&ea); i++)
            maxdiff = fmax(maxdiff, fabs((double)ea.c[2][i] - eb.c[2][i]));
        mean_a /= cnt;
        mean_b /= cnt;
        printf("  ortho %d: mean blue chromaticity of the empty +x half: camera at +x %.4f, at -x %.4f; max |diff| %.4f\n",
               ortho, mean_a, mean_b, maxdiff);
        CHECK(mean_a > 0.99);
        CHECK(mean_b < 0.9);
        CHECK(maxdiff > 0.1);
        vol_light_volume_free(&ea);
        vol_light_volume_free(&eb);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}

TEST(volume_eye_identical_for_1_and_2_threads)
{
    obs_context *ctx = obs_context_create();
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "bucky", 32, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    for (int ortho = 0; ortho < 2; ortho++) {
        obs_camera cam = eye_camera(&g, 0.3, -0.5, 0.8, ortho ? 50.0 : 3.0, ortho); /* perspective: inside */
        vol_light_volume e[2];
        for (int t = 0; t < 2; t++) {
            obs_pool *pool = obs_pool_create(t + 1);
            CHECK(pool);
            vol_lv_params p = vol_lv_params_default();
            p.eye_pass = 1;
            CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &cam, &p, &e[t]), ctx);
            obs_pool_destroy(pool);
        }
        const size_t bytes = lv_voxels(&e[0]) * sizeof(float);
        CHECK(memcmp(e[0].l, e[1].l, bytes) == 0);
        for (int c = 0; c < 3; c++)
            CHECK(memcmp(e[0].c[c], e[1].c[c], bytes) == 0);
        vol_light_volume_free(&e[0]);
        vol_light_volume_free(&e[1]);
    }
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_context_destroy(ctx);
}

TEST(volume_eye_bad_inputs_refused)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(1);
    vol_grid g;
    CHECK_OK(vol_synth(ctx, "sphere", 16, &g), ctx);
    vol_tf tf;
    CHECK_OK(vol_tf_preset(ctx, "bucky", &tf), ctx);
    vol_lv_params p = vol_lv_params_default();
    p.eye_pass = 1;
    vol_light_volume eye, lv;
    obs_camera cam = eye_camera(&g, 0.0, 0.0, 1.0, 40.0, 0);
    /* a NULL camera, a non-finite camera, bad params */
    CHECK_EQ_INT(vol_eye_volume_build(ctx, pool, &g, &tf, NULL, &p, &eye), OBS_STATUS_INVALID_ARGUMENT);
    obs_camera nan_cam = cam;
    nan_cam.world.m[13] = NAN;
    CHECK_EQ_INT(vol_eye_volume_build(ctx, pool, &g, &tf, &nan_cam, &p, &eye), OBS_STATUS_INVALID_ARGUMENT);
    vol_lv_params bad = p;
    bad.scale = 3;
    CHECK_EQ_INT(vol_eye_volume_build(ctx, pool, &g, &tf, &cam, &bad, &eye), OBS_STATUS_INVALID_ARGUMENT);
    /* a mismatched layout: an eye volume at scale 2 against a light volume at scale 1 */
    vol_lv_params p2 = p;
    p2.scale = 2;
    CHECK_OK(vol_eye_volume_build(ctx, pool, &g, &tf, &cam, &p2, &eye), ctx);
    vol_light L;
    memset(&L, 0, sizeof L);
    L.type = OBS_LIGHT_DIRECTIONAL;
    L.direction[2] = -1.0;
    CHECK_OK(vol_light_volume_build(ctx, pool, &g, &tf, &L, &p, &lv), ctx);
    obs_context_clear_error(ctx); /* the first error sticks */
    CHECK_EQ_INT(vol_light_volume_modulate(ctx, &eye, &lv), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "layout") != NULL);
    CHECK_EQ_INT(vol_light_volume_modulate(ctx, NULL, &lv), OBS_STATUS_INVALID_ARGUMENT);
    vol_light_volume_free(&eye);
    vol_light_volume_free(&lv);
    vol_tf_free(&tf);
    vol_grid_free(&g);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
