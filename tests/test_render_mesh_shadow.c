/* Meshes shadow the volume in the scene-driven render (src/render/render_passes_volume.c,
 * volume.mesh_shadows; docs/render.md "Meshes shadow the volume"): the bundled hybrid scene
 * (cornell_hybrid, mkdata) with its tall block moved into the volume's box, between the point
 * light and the buckyball, as a slab, seen from the side. */
#include "test.h"
#include "render_test_util.h"

#include <stdlib.h>
#include <string.h>

#include "io/io.h"
#include "render/render.h"

static int load_hybrid_at(obs_context *ctx, obs_scene *s, float slab_z)
{
    obs_scene_init(s);
    io_gltf_options o = io_gltf_options_default();
    if (io_gltf_load(ctx, test_path(test_data_dir(), "cornell_hybrid.glb"), &o, s) != OBS_STATUS_OK)
        return 0;
    /* The tall block (a 1.65 x 3.3 x 1.65 box on the floor) scaled into a slab across the front of
     * the volume's box [0.5, 3.6, -2.1] - [1.7, 4.8, -0.9] (the point light is in front, at z = 3):
     * x [0.44, 1.76], y [3.55, 4.87], z [-1.17, -0.93]. */
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (!strncmp(s->meshes[s->instances[i].mesh].name, "tall_block", 10)) { /* "tall_block/prim0" */
            const obs_vec4 q = {0, 0, 0, 1};
            s->instances[i].world = obs_mat4_from_trs(obs_v3(1.1f, 3.55f, slab_z), q, obs_v3(0.8f, 0.4f, 0.15f));
            /* the camera inside the room, right of the volume and looking at it along -x (the
             * scene's own camera, in front, would see the slab rather than the volume) */
            if (s->camera_count < 1)
                return 0;
            char name[OBS_NAME_MAX];
            memcpy(name, s->cameras[0].name, sizeof name);
            s->cameras[0] = obs_camera_look_at(obs_v3(4.9f, 4.2f, -1.5f), obs_v3(1.1f, 4.2f, -1.5f), obs_v3(0, 1, 0), 0.5f,
                                               0.5f, 30.0f);
            memcpy(s->cameras[0].name, name, sizeof name);
            obs_scene_update_bounds(s);
            return 1;
        }
    return 0;
}

static int load_hybrid(obs_context *ctx, obs_scene *s) { return load_hybrid_at(ctx, s, -1.05f); }

static render_settings hybrid_settings(obs_context *ctx, const obs_scene *s)
{
    render_settings st = render_settings_default();
    if (render_settings_from_scene(ctx, s, &st) != OBS_STATUS_OK)
        return st;
    st.width = 64;
    st.height = 48;
    st.shadow_map_size = 128;
    st.sss.K = 4;
    st.sss.N = 8;
    st.sss.map_size = 48;
    st.sss.light_map_size = 48;
    return st;
}

static const render_pass_record *rec(const render_frame *f, const char *name)
{
    for (int i = 0; i < f->pass_count; i++)
        if (!strcmp(f->passes[i].name, name))
            return &f->passes[i];
    return NULL;
}

/* The volume layers' RGB compared value by value: how many are darker or brighter in `on` than in
 * `off` (by more than 1e-6), and each side's sum. */
static void compare_volume(const render_frame *on, const render_frame *off, int *darker, int *brighter, double *sum_on,
                           double *sum_off)
{
    for (int c = 0; c < 3 && on->volume[0].data && off->volume[0].data; c++)
        for (int y = 0; y < on->height; y++) {
            const float *a = obs_image_f32_row(&on->volume[c], y), *b = obs_image_f32_row(&off->volume[c], y);
            for (int x = 0; x < on->width; x++) {
                *darker += a[x] < b[x] - 1e-6f;
                *brighter += a[x] > b[x] + 1e-6f;
                *sum_on += a[x];
                *sum_off += b[x];
            }
        }
}

static int run_in(obs_context *ctx, const obs_scene *s, const render_settings *st, const char *cache_dir,
                  render_frame *f)
{
    render_options o = render_options_default();
    o.threads = 2;
    o.cache_dir = cache_dir;
    render_session *ses = render_session_create(ctx, &o);
    if (!ses)
        return 0;
    const obs_status r = render_frame_run(ses, s, st, 0, f);
    render_session_destroy(ses);
    return r == OBS_STATUS_OK;
}
static int run(obs_context *ctx, const obs_scene *s, const render_settings *st, render_frame *f)
{
    return run_in(ctx, s, st, NULL, f);
}

/* volume.mesh_shadows off against on: the light_volume key differs, every other pass's key is the
 * same; every layer but the volume (and the beauty that composes it) is bit-identical (the meshes
 * sample the volume's own light volume: direct does not change); the volume's alpha is the same
 * (lighting changes colour only) and its colour is darker where the slab shadows it, nowhere
 * brighter. */
TEST(render_mesh_shadows_darken_only_the_volume_layer)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK_MSG(load_hybrid(ctx, &s), "%s", obs_context_last_error(ctx));
    render_settings st = hybrid_settings(ctx, &s);
    CHECK_EQ_INT(st.volume.enabled, 1);
    CHECK_EQ_INT(st.volume.mesh_shadows, 1); /* the default */
    render_frame on, off;
    CHECK_MSG(run(ctx, &s, &st, &on), "%s", obs_context_last_error(ctx));
    st.volume.mesh_shadows = 0;
    CHECK_MSG(run(ctx, &s, &st, &off), "%s", obs_context_last_error(ctx));
    const render_pass_record *lon = rec(&on, "light_volume"), *loff = rec(&off, "light_volume");
    CHECK(lon && loff);
    if (lon && loff) {
        CHECK(lon->key[0] && strcmp(lon->key, loff->key) != 0);
        CHECK_MSG(strstr(lon->reason, "with mesh_shadows") != NULL, "%s", lon->reason);
    }
    for (int i = 0; i < on.pass_count; i++) {
        const render_pass_record *b = rec(&off, on.passes[i].name);
        CHECK(b != NULL);
        if (b && strcmp(on.passes[i].name, "light_volume") != 0)
            CHECK_MSG(!strcmp(on.passes[i].key, b->key), "pass %s: key changed", on.passes[i].name);
    }
    CHECK(rtu_planes_equal(on.direct, off.direct, 3));
    CHECK(rtu_planes_equal(on.ambient, off.ambient, 3));
    CHECK(rtu_planes_equal(&on.ao, &off.ao, 1));
    CHECK(rtu_planes_equal(on.sss, off.sss, 3));
    CHECK(rtu_planes_equal(&on.depth, &off.depth, 1));
    CHECK(rtu_planes_equal(on.normal, off.normal, 3));
    CHECK(rtu_planes_equal(on.albedo, off.albedo, 3));
    CHECK(on.volume[0].data != NULL);
    CHECK(rtu_planes_equal(&on.volume[3], &off.volume[3], 1));
    int darker = 0, brighter = 0;
    double sum_on = 0, sum_off = 0;
    compare_volume(&on, &off, &darker, &brighter, &sum_on, &sum_off);
    if (getenv("OBS_TEST_VERBOSE"))
        fprintf(stderr, "volume rgb sum %.5g with the slab, %.5g without; %d values darker\n", sum_on, sum_off, darker);
    CHECK_MSG(darker > 20, "only %d volume values darker", darker);
    CHECK_EQ_INT(brighter, 0);
    CHECK_MSG(sum_on < 0.5 * sum_off, "volume light %.4g with the slab, %.4g without", sum_on, sum_off);
    render_frame_free(&on);
    render_frame_free(&off);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* The bundled scene unchanged: no mesh meets the volume's box, so mesh_shadows changes the key
 * but no pixel (the own light volume serves the ray cast); and the setting parses (JSON). */
TEST(render_mesh_shadows_without_meshes_in_the_box_change_no_pixel)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    obs_scene_init(&s);
    io_gltf_options o = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "cornell_hybrid.glb"), &o, &s), ctx);
    render_settings st = hybrid_settings(ctx, &s);
    st.outputs = RENDER_OUT_VOLUME;
    render_frame on, off;
    CHECK_MSG(run(ctx, &s, &st, &on), "%s", obs_context_last_error(ctx));
    CHECK_OK(render_settings_apply_json(ctx, "{\"volume\":{\"mesh_shadows\":false}}", "test", &s, &st), ctx);
    CHECK_EQ_INT(st.volume.mesh_shadows, 0);
    CHECK_MSG(run(ctx, &s, &st, &off), "%s", obs_context_last_error(ctx));
    CHECK(rtu_planes_equal(on.volume, off.volume, 4));
    CHECK_EQ_INT(render_settings_apply_json(ctx, "{\"volume\":{\"mesh_shadows\":1}}", "test", &s, &st),
                 OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "mesh_shadows") != NULL);
    render_frame_free(&on);
    render_frame_free(&off);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}


/* The light_volume product with both light volumes goes through the disk cache: a second session
 * reads it back (CACHED_DISK) and the volume layer is bit-identical. */
TEST(render_mesh_shadows_light_volumes_round_trip_through_the_disk_cache)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_log_level(ctx, OBS_LOG_ERROR);
    obs_scene s;
    CHECK_MSG(load_hybrid(ctx, &s), "%s", obs_context_last_error(ctx));
    render_settings st = hybrid_settings(ctx, &s);
    st.outputs = RENDER_OUT_VOLUME;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", test_path(test_tmpdir(), "cache_mesh_shadow"));
    render_frame a, b;
    CHECK_MSG(run_in(ctx, &s, &st, dir, &a), "%s", obs_context_last_error(ctx));
    CHECK_MSG(run_in(ctx, &s, &st, dir, &b), "%s", obs_context_last_error(ctx));
    const render_pass_record *r = rec(&b, "light_volume");
    CHECK(r && r->state == RENDER_PASS_CACHED_DISK);
    CHECK(rtu_planes_equal(a.volume, b.volume, 4));
    render_frame_free(&a);
    render_frame_free(&b);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* A slab OUTSIDE the volume's box, between the point light and the box (z [-0.62, -0.38]; the box
 * ends at z = -0.9): the voxelizer selects no mesh, and the light enters the box through the
 * light's shadow map (vol_occluder.entry), so the volume darkens, nowhere brightens, keeps its
 * alpha; with the shadow maps off (no entry test) mesh_shadows changes no pixel. */
TEST(render_mesh_shadows_from_outside_the_box_enter_through_the_shadow_map)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK_MSG(load_hybrid_at(ctx, &s, -0.5f), "%s", obs_context_last_error(ctx));
    render_settings st = hybrid_settings(ctx, &s);
    st.outputs = RENDER_OUT_VOLUME;
    st.shadow_map_size = 256;
    render_frame on, off, on_noshadow, off_noshadow;
    CHECK_MSG(run(ctx, &s, &st, &on), "%s", obs_context_last_error(ctx));
    const render_pass_record *sm = rec(&on, "shadow_maps");
    CHECK(sm && sm->state == RENDER_PASS_RAN); /* the volume alone reads them */
    st.volume.mesh_shadows = 0;
    CHECK(run(ctx, &s, &st, &off));
    int darker = 0, brighter = 0;
    double sum_on = 0, sum_off = 0;
    compare_volume(&on, &off, &darker, &brighter, &sum_on, &sum_off);
    if (getenv("OBS_TEST_VERBOSE"))
        fprintf(stderr, "volume rgb sum %.5g with the slab outside, %.5g without; %d darker\n", sum_on, sum_off, darker);
    CHECK_MSG(darker > 20, "only %d volume values darker", darker);
    CHECK_EQ_INT(brighter, 0);
    CHECK_MSG(sum_on < 0.8 * sum_off, "volume light %.4g with the slab, %.4g without", sum_on, sum_off);
    CHECK(rtu_planes_equal(&on.volume[3], &off.volume[3], 1));
    /* no shadow maps: nothing to test the entry against */
    st.shadows = 0;
    st.volume.mesh_shadows = 1;
    CHECK(run(ctx, &s, &st, &on_noshadow));
    st.volume.mesh_shadows = 0;
    CHECK(run(ctx, &s, &st, &off_noshadow));
    CHECK(rtu_planes_equal(on_noshadow.volume, off_noshadow.volume, 4));
    CHECK(rtu_planes_equal(off_noshadow.volume, off.volume, 4));
    render_frame_free(&on);
    render_frame_free(&off);
    render_frame_free(&on_noshadow);
    render_frame_free(&off_noshadow);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* The reference sees the same meshes: with the slab outside the box, the Monte Carlo volume
 * reference's shadow rays meet it (Embree, through ref_scene), so its volume layer darkens as the
 * approximation's does; with mesh_shadows off it does not (the reference ignores the meshes). */
TEST(render_mesh_shadows_reach_the_volume_reference)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK_MSG(load_hybrid_at(ctx, &s, -0.5f), "%s", obs_context_last_error(ctx));
    render_settings st = hybrid_settings(ctx, &s);
    st.outputs = RENDER_OUT_VOLUME;
    st.width = 32;
    st.height = 24;
    st.reference = 1;
    st.ref_volume_samples = 16;
    render_frame on, off;
    CHECK_MSG(run(ctx, &s, &st, &on), "%s", obs_context_last_error(ctx));
    const render_pass_record *rs = rec(&on, "ref_scene");
    CHECK(rs && rs->state == RENDER_PASS_RAN);
    st.volume.mesh_shadows = 0;
    CHECK(run(ctx, &s, &st, &off));
    double r_on = 0, r_off = 0;
    for (int c = 0; c < 3 && on.ref_volume[0].data && off.ref_volume[0].data; c++)
        for (int y = 0; y < on.height; y++)
            for (int x = 0; x < on.width; x++) {
                r_on += obs_image_f32_row(&on.ref_volume[c], y)[x];
                r_off += obs_image_f32_row(&off.ref_volume[c], y)[x];
            }
    if (getenv("OBS_TEST_VERBOSE"))
        fprintf(stderr, "reference volume rgb sum %.5g with the slab outside, %.5g without\n", r_on, r_off);
    CHECK_MSG(r_off > 0 && r_on < 0.8 * r_off, "reference volume light %.4g with mesh shadows, %.4g without", r_on,
              r_off);
    render_frame_free(&on);
    render_frame_free(&off);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
