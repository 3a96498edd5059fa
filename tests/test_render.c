/* test_render.c: the scene-driven render (src/render): pass selection, the cache (memory and
 * disk), thread-count independence, the reference, bad settings. Scenes are built in code or
 * loaded from the generated data (build/data); settings are built in code (no JSON). */
#include "test.h"
#include "render_test_util.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/io.h"
#include "render/render.h"

/* ---- scenes ------------------------------------------------------------------------------ */

static void add_mesh(obs_scene *s, const char *name, const float *pos, int nv, const uint32_t *idx, int nt, int material)
{
    obs_mesh *m = &s->meshes[s->mesh_count];
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->vertex_count = (uint32_t)nv;
    m->triangle_count = (uint32_t)nt;
    m->positions = (float *)malloc(sizeof(float) * 3 * (size_t)nv);
    m->indices = (uint32_t *)malloc(sizeof(uint32_t) * 3 * (size_t)nt);
    memcpy(m->positions, pos, sizeof(float) * 3 * (size_t)nv);
    memcpy(m->indices, idx, sizeof(uint32_t) * 3 * (size_t)nt);
    m->material = material;
    obs_instance *in = &s->instances[s->instance_count];
    in->mesh = s->mesh_count;
    in->node = s->instance_count;
    in->world = obs_mat4_identity();
    s->mesh_count++;
    s->instance_count++;
}

/* A floor (opaque), a 4 cm cube (translucent potato when `translucent`, else opaque), a
 * directional light, two cameras. Optionally a volume (settings, see use_volume below). */
static void make_scene(obs_scene *s, int translucent, const char *preset)
{
    obs_scene_init(s);
    s->meshes = (obs_mesh *)calloc(2, sizeof *s->meshes);
    s->instances = (obs_instance *)calloc(2, sizeof *s->instances);
    s->materials = (obs_material *)calloc(2, sizeof *s->materials);
    s->lights = (obs_light *)calloc(1, sizeof *s->lights);
    s->cameras = (obs_camera *)calloc(2, sizeof *s->cameras);
    const float floor_p[] = {-0.1f, 0, -0.1f, 0.1f, 0, -0.1f, 0.1f, 0, 0.1f, -0.1f, 0, 0.1f};
    const uint32_t floor_i[] = {0, 2, 1, 0, 3, 2};
    add_mesh(s, "floor", floor_p, 4, floor_i, 2, 0);
    const float h = 0.02f;
    float cp[24];
    for (int v = 0; v < 8; v++) {
        cp[3 * v + 0] = (v & 1) ? h : -h;
        cp[3 * v + 1] = ((v & 2) ? 2 * h : 0.0f) + 0.001f;
        cp[3 * v + 2] = (v & 4) ? h : -h;
    }
    const uint32_t ci[] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                           2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    add_mesh(s, "cube", cp, 8, ci, 12, 1);
    s->material_count = 2;
    snprintf(s->materials[0].name, OBS_NAME_MAX, "white");
    snprintf(s->materials[1].name, OBS_NAME_MAX, "cube");
    for (int m = 0; m < 2; m++) {
        s->materials[m].base_color[0] = s->materials[m].base_color[1] = s->materials[m].base_color[2] = 0.8f;
        s->materials[m].base_color[3] = 1.0f;
    }
    if (translucent) {
        char buf[128];
        snprintf(buf, sizeof buf, "{\"obscura_sss\":{\"preset\":\"%s\"}}", preset ? preset : "potato");
        s->materials[1].extras_json = strdup(buf);
    }
    s->light_count = 1;
    snprintf(s->lights[0].name, OBS_NAME_MAX, "key");
    s->lights[0].type = OBS_LIGHT_DIRECTIONAL;
    s->lights[0].color = obs_v3(1, 1, 1);
    s->lights[0].intensity = 3.0f;
    s->lights[0].direction = obs_v3_normalize(obs_v3(-0.4f, -1.0f, -0.3f));
    s->camera_count = 2;
    s->cameras[0] = obs_camera_look_at(obs_v3(0.1f, 0.12f, 0.2f), obs_v3(0, 0.02f, 0), obs_v3(0, 1, 0), 0.8f, 0.05f, 1.0f);
    s->cameras[1] = obs_camera_look_at(obs_v3(-0.15f, 0.1f, 0.15f), obs_v3(0, 0.02f, 0), obs_v3(0, 1, 0), 0.8f, 0.05f, 1.0f);
    snprintf(s->cameras[0].name, OBS_NAME_MAX, "front");
    snprintf(s->cameras[1].name, OBS_NAME_MAX, "side");
    snprintf(s->source, sizeof s->source, "test_render:built");
    obs_scene_update_bounds(s);
}

/* Small, fast settings. */
static render_settings small_settings(void)
{
    render_settings st = render_settings_default();
    st.width = 48;
    st.height = 32;
    st.shadow_map_size = 128;
    st.sss.K = 4;
    st.sss.N = 8;
    st.sss.map_size = 48;
    st.sss.light_map_size = 48;
    return st;
}

static void use_volume(render_settings *st)
{
    st->volume.enabled = 1;
    snprintf(st->volume.source, sizeof st->volume.source, "synth:bucky:16");
    snprintf(st->volume.transfer, sizeof st->volume.transfer, "bucky");
    st->volume.has_box = 1;
    const double lo[3] = {0.03, 0.0, -0.05}, hi[3] = {0.07, 0.04, -0.01};
    memcpy(st->volume.box_lo, lo, sizeof lo);
    memcpy(st->volume.box_hi, hi, sizeof hi);
}

static const render_pass_record *rec(const render_frame *f, const char *name)
{
    for (int i = 0; i < f->pass_count; i++)
        if (!strcmp(f->passes[i].name, name))
            return &f->passes[i];
    return NULL;
}
static int state_of(const render_frame *f, const char *name)
{
    const render_pass_record *r = rec(f, name);
    return r ? (int)r->state : -1;
}

static render_session *session(obs_context *ctx, int threads, const char *dir)
{
    render_options o = render_options_default();
    o.threads = threads;
    o.cache_dir = dir;
    return render_session_create(ctx, &o);
}

static int frames_equal(const render_frame *a, const render_frame *b)
{
    return a->outputs == b->outputs && rtu_planes_equal(a->beauty, b->beauty, 3) && rtu_planes_equal(a->direct, b->direct, 3) &&
           rtu_planes_equal(a->ambient, b->ambient, 3) && rtu_planes_equal(&a->ao, &b->ao, 1) &&
           rtu_planes_equal(a->sss, b->sss, 3) && rtu_planes_equal(a->volume, b->volume, 4) &&
           rtu_planes_equal(&a->depth, &b->depth, 1) && rtu_planes_equal(a->normal, b->normal, 3) &&
           rtu_planes_equal(a->albedo, b->albedo, 3);
}

static int load(obs_context *ctx, const char *name, obs_scene *s)
{
    obs_scene_init(s);
    io_gltf_options o = io_gltf_options_default();
    return io_gltf_load(ctx, test_path(test_data_dir(), name), &o, s) == OBS_STATUS_OK;
}

/* ---- pass selection ------------------------------------------------------------------------ */

TEST(render_opaque_scene_runs_no_sss_or_volume_pass)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK(load(ctx, "cornell_box.glb", &s));
    render_settings st = small_settings();
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    obs_status r = render_frame_run(ses, &s, &st, 0, &f);
    CHECK_MSG(r == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    const char *culled[] = {"sss_light_maps", "sss_maps", "sss_combine", "volume_load", "light_volume", "raycast"};
    for (int i = 0; i < 6; i++)
        CHECK_MSG(state_of(&f, culled[i]) == RENDER_PASS_CULLED, "%s not culled", culled[i]);
    CHECK(strstr(rec(&f, "sss_maps")->reason, "no translucent material") != NULL);
    CHECK(strstr(rec(&f, "light_volume")->reason, "no volume") != NULL);
    const char *ran[] = {"gbuffer", "shadow_maps", "direct", "ao", "ambient", "compose"};
    for (int i = 0; i < 6; i++)
        CHECK_MSG(state_of(&f, ran[i]) == RENDER_PASS_RAN, "%s did not run", ran[i]);
    CHECK(f.beauty[0].data && !f.sss[0].data && !f.volume[0].data);
    CHECK(!(f.outputs & (RENDER_OUT_SSS | RENDER_OUT_VOLUME)));
    /* the lit floor under the ceiling light is bright, not black */
    double sum = 0;
    for (int y = 0; y < f.height; y++)
        for (int x = 0; x < f.width; x++)
            sum += obs_image_f32_row(&f.beauty[1], y)[x];
    CHECK(sum / (f.width * f.height) > 0.05);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_sss_scene_runs_no_light_volume)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK(load(ctx, "sphere_potato.glb", &s));
    render_settings st = small_settings();
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f, "light_volume") == RENDER_PASS_CULLED);
    CHECK(state_of(&f, "raycast") == RENDER_PASS_CULLED);
    CHECK(state_of(&f, "sss_light_maps") == RENDER_PASS_RAN);
    CHECK(state_of(&f, "sss_maps") == RENDER_PASS_RAN);
    CHECK(state_of(&f, "sss_combine") == RENDER_PASS_RAN);
    /* no opaque mesh: no direct light, AO or ambient */
    CHECK(state_of(&f, "direct") == RENDER_PASS_CULLED);
    CHECK(state_of(&f, "ao") == RENDER_PASS_CULLED);
    double sum = 0;
    for (int y = 0; y < f.height; y++)
        for (int x = 0; x < f.width; x++)
            sum += obs_image_f32_row(&f.beauty[0], y)[x];
    CHECK(sum > 0);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_ao_off_runs_no_ao_pass)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 0, NULL);
    render_settings st = small_settings();
    st.ao = NULL;
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f, "ao") == RENDER_PASS_CULLED);
    CHECK(!strcmp(rec(&f, "ao")->reason, "AO off"));
    CHECK(state_of(&f, "ambient") == RENDER_PASS_RAN);
    CHECK(!f.ao.data && !(f.outputs & RENDER_OUT_AO));
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_ao_output_alone_culls_sss_volume_and_direct)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    st.outputs = RENDER_OUT_AO;
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    CHECK_MSG(render_plan(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f, "ao") == RENDER_PASS_PLANNED && state_of(&f, "gbuffer") == RENDER_PASS_PLANNED);
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    const char *culled[] = {"shadow_maps", "direct", "ambient", "sss_light_maps", "sss_maps", "sss_combine",
                            "volume_load", "light_volume", "raycast", "compose"};
    for (int i = 0; i < 10; i++)
        CHECK_MSG(state_of(&f, culled[i]) == RENDER_PASS_CULLED, "%s not culled", culled[i]);
    CHECK(strstr(rec(&f, "direct")->reason, "not requested") != NULL);
    CHECK(state_of(&f, "ao") == RENDER_PASS_RAN);
    CHECK(f.outputs == RENDER_OUT_AO && f.ao.data && !f.beauty[0].data);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_point_light_inside_a_room_lights_a_translucent_block)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK(load(ctx, "cornell_box.glb", &s));
    /* the tall block becomes potato: a new material slot with the SSS extras */
    obs_material *m = (obs_material *)realloc(s.materials, (s.material_count + 1) * sizeof *m);
    CHECK(m);
    s.materials = m;
    memset(&m[s.material_count], 0, sizeof *m);
    snprintf(m[s.material_count].name, OBS_NAME_MAX, "potato");
    m[s.material_count].base_color[0] = m[s.material_count].base_color[1] = m[s.material_count].base_color[2] = 0.9f;
    m[s.material_count].extras_json = strdup("{\"obscura_sss\":{\"preset\":\"potato\"}}");
    int tall = -1;
    for (uint32_t i = 0; i < s.mesh_count; i++)
        if (strstr(s.meshes[i].name, "tall_block"))
            tall = (int)i;
    CHECK(tall >= 0);
    s.meshes[tall].material = (int32_t)s.material_count;
    s.material_count++;
    render_settings st = small_settings();
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f, "sss_maps") == RENDER_PASS_RAN && state_of(&f, "direct") == RENDER_PASS_RAN);
    double sum = 0;
    for (int y = 0; y < f.height; y++)
        for (int x = 0; x < f.width; x++)
            sum += obs_image_f32_row(&f.sss[0], y)[x];
    CHECK(sum > 0);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- the cache ----------------------------------------------------------------------------- */

TEST(render_cache_hit_on_second_view_is_byte_identical_to_cold)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    render_session *warm = session(ctx, 2, NULL), *cold = session(ctx, 2, NULL);
    render_frame f0, f1, c1;
    CHECK_MSG(render_frame_run(warm, &s, &st, 0, &f0) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f0, "sss_maps") == RENDER_PASS_RAN && state_of(&f0, "light_volume") == RENDER_PASS_RAN);
    CHECK(render_frame_run(warm, &s, &st, 1, &f1) == OBS_STATUS_OK);
    const char *hit[] = {"shadow_maps", "sss_light_maps", "sss_maps", "volume_load", "light_volume"};
    for (int i = 0; i < 5; i++)
        CHECK_MSG(state_of(&f1, hit[i]) == RENDER_PASS_CACHED_MEMORY, "%s not from memory (%d)", hit[i],
                  state_of(&f1, hit[i]));
    CHECK(state_of(&f1, "gbuffer") == RENDER_PASS_RAN && state_of(&f1, "sss_combine") == RENDER_PASS_RAN);
    CHECK(render_frame_run(cold, &s, &st, 1, &c1) == OBS_STATUS_OK);
    CHECK(state_of(&c1, "sss_maps") == RENDER_PASS_RAN);
    CHECK(f1.outputs & RENDER_OUT_SSS);
    CHECK(f1.outputs & RENDER_OUT_VOLUME);
    CHECK(frames_equal(&f1, &c1));
    render_cache_stats cs;
    render_session_cache_stats(warm, &cs);
    CHECK(cs.hits_memory == 5 && cs.misses == 5 && cs.entries == 5 && cs.bytes > 0);
    render_frame_free(&f0);
    render_frame_free(&f1);
    render_frame_free(&c1);
    render_session_destroy(warm);
    render_session_destroy(cold);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_keys_change_with_the_light_and_material_not_the_camera)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    st.width = 16, st.height = 12;
    render_session *ses = session(ctx, 1, NULL);
    render_frame a, b, c, d;
    CHECK(render_frame_run(ses, &s, &st, 0, &a) == OBS_STATUS_OK);
    CHECK(render_frame_run(ses, &s, &st, 1, &b) == OBS_STATUS_OK);
    const char *vi[] = {"shadow_maps", "sss_light_maps", "sss_maps", "light_volume"};
    for (int i = 0; i < 4; i++) {
        CHECK_MSG(rec(&a, vi[i])->key[0] != '\0', "%s has no key", vi[i]);
        CHECK_MSG(!strcmp(rec(&a, vi[i])->key, rec(&b, vi[i])->key), "%s key changed with the camera", vi[i]);
    }
    /* the light moves: every light-dependent key changes */
    s.lights[0].direction = obs_v3_normalize(obs_v3(0.3f, -1.0f, -0.2f));
    CHECK(render_frame_run(ses, &s, &st, 0, &c) == OBS_STATUS_OK);
    for (int i = 0; i < 4; i++)
        CHECK_MSG(strcmp(rec(&a, vi[i])->key, rec(&c, vi[i])->key) != 0, "%s key ignores the light", vi[i]);
    CHECK(state_of(&c, "sss_maps") == RENDER_PASS_RAN && state_of(&c, "light_volume") == RENDER_PASS_RAN);
    CHECK(state_of(&c, "volume_load") == RENDER_PASS_CACHED_MEMORY);
    /* the cube's material changes: its maps' key changes, the volume's and the shadows' do not */
    free(s.materials[1].extras_json);
    s.materials[1].extras_json = strdup("{\"obscura_sss\":{\"preset\":\"marble\"}}");
    CHECK(render_frame_run(ses, &s, &st, 0, &d) == OBS_STATUS_OK);
    CHECK(strcmp(rec(&c, "sss_maps")->key, rec(&d, "sss_maps")->key) != 0);
    CHECK(!strcmp(rec(&c, "sss_light_maps")->key, rec(&d, "sss_light_maps")->key));
    CHECK(!strcmp(rec(&c, "light_volume")->key, rec(&d, "light_volume")->key));
    CHECK(!strcmp(rec(&c, "shadow_maps")->key, rec(&d, "shadow_maps")->key));
    CHECK(state_of(&d, "light_volume") == RENDER_PASS_CACHED_MEMORY);
    CHECK(state_of(&d, "sss_maps") == RENDER_PASS_RAN);
    /* an opaque mesh moves (the floor): its shadows' key changes, the SSS maps' does not (they see
       the translucent instances only) */
    render_frame e;
    s.instances[0].world = obs_mat4_translation(obs_v3(0, -0.001f, 0));
    obs_scene_update_bounds(&s);
    CHECK(render_frame_run(ses, &s, &st, 0, &e) == OBS_STATUS_OK);
    CHECK(strcmp(rec(&d, "shadow_maps")->key, rec(&e, "shadow_maps")->key) != 0);
    CHECK(!strcmp(rec(&d, "sss_maps")->key, rec(&e, "sss_maps")->key));
    CHECK(state_of(&e, "sss_maps") == RENDER_PASS_CACHED_MEMORY);
    render_frame_free(&e);
    render_frame_free(&a);
    render_frame_free(&b);
    render_frame_free(&c);
    render_frame_free(&d);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_disk_cache_round_trips_and_a_truncated_file_is_a_miss)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_log_level(ctx, OBS_LOG_ERROR);
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    const char *dir = test_path(test_tmpdir(), "cache");
    char dirbuf[1024];
    snprintf(dirbuf, sizeof dirbuf, "%s", dir);
    render_session *a = session(ctx, 2, dirbuf);
    render_frame fa, fb, fc;
    CHECK_MSG(render_frame_run(a, &s, &st, 0, &fa) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    render_session_destroy(a);
    render_session *b = session(ctx, 2, dirbuf);
    CHECK(render_frame_run(b, &s, &st, 0, &fb) == OBS_STATUS_OK);
    render_session_destroy(b);
    CHECK(state_of(&fb, "sss_light_maps") == RENDER_PASS_CACHED_DISK);
    CHECK(state_of(&fb, "sss_maps") == RENDER_PASS_CACHED_DISK);
    CHECK(state_of(&fb, "light_volume") == RENDER_PASS_CACHED_DISK);
    CHECK(frames_equal(&fa, &fb));
    /* truncate the maps' file: a miss (rebuilt), the same output */
    char path[1200];
    snprintf(path, sizeof path, "%s/sss_maps-%s.bin", dirbuf, rec(&fa, "sss_maps")->key);
    size_t len = 0;
    char *data = test_slurp(path, &len);
    CHECK_MSG(data && len > 100, "no cache file %s", path);
    FILE *fp = fopen(path, "wb");
    CHECK(fp);
    fwrite(data, 1, len / 2, fp);
    fclose(fp);
    free(data);
    render_session *c = session(ctx, 2, dirbuf);
    CHECK_MSG(render_frame_run(c, &s, &st, 0, &fc) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    render_session_destroy(c);
    CHECK(state_of(&fc, "sss_maps") == RENDER_PASS_RAN);
    CHECK(state_of(&fc, "sss_light_maps") == RENDER_PASS_CACHED_DISK);
    CHECK(frames_equal(&fa, &fc));
    render_frame_free(&fa);
    render_frame_free(&fb);
    render_frame_free(&fc);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

TEST(render_output_is_identical_for_1_2_and_8_threads)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    render_frame f[3];
    const int threads[3] = {1, 2, 8};
    for (int i = 0; i < 3; i++) {
        render_session *ses = session(ctx, threads[i], NULL);
        CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f[i]) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
        render_session_destroy(ses);
    }
    CHECK(f[0].outputs == (RENDER_OUT_ALL));
    CHECK(frames_equal(&f[0], &f[1]));
    CHECK(frames_equal(&f[0], &f[2]));
    for (int i = 0; i < 3; i++)
        render_frame_free(&f[i]);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

typedef struct progress_log { int calls; int64_t last_done, last_total; int monotonic; } progress_log;
static void on_progress(void *user, int64_t done, int64_t total)
{
    progress_log *p = (progress_log *)user;
    if (done < p->last_done || done > total)
        p->monotonic = 0;
    p->calls++;
    p->last_done = done;
    p->last_total = total;
}

TEST(render_eight_views_of_an_sss_scene_build_the_maps_once)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    CHECK(load(ctx, "bunny_cream.glb", &s));
    render_settings st = small_settings();
    st.camera_count = 8;
    for (int i = 0; i < 8; i++)
        st.cameras[i] = i % 2;
    CHECK(render_view_count(&s, &st) == 8);
    progress_log pl = {0, 0, 0, 1};
    render_options o = render_options_default();
    o.threads = 2;
    o.progress = on_progress;
    o.progress_user = &pl;
    render_session *ses = render_session_create(ctx, &o);
    int ran_maps = 0, ran_lm = 0, ran_comb = 0;
    for (int v = 0; v < 8; v++) {
        render_frame f;
        CHECK_MSG(render_frame_run(ses, &s, &st, v, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
        ran_maps += state_of(&f, "sss_maps") == RENDER_PASS_RAN;
        ran_lm += state_of(&f, "sss_light_maps") == RENDER_PASS_RAN;
        ran_comb += state_of(&f, "sss_combine") == RENDER_PASS_RAN;
        CHECK(f.camera == v % 2);
        render_frame_free(&f);
    }
    CHECK(ran_maps == 1 && ran_lm == 1 && ran_comb == 8);
    /* progress over the whole batch: monotonic, ending at done == total */
    CHECK(pl.calls > 8 && pl.monotonic && pl.last_done == pl.last_total);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- the reference ------------------------------------------------------------------------- */

TEST(render_reference_fills_the_error_of_each_layer)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    st.width = 24, st.height = 16;
    st.reference = 1;
    st.ref_ao.min_samples = 64;
    st.ref_ao.max_samples = 64;
    st.ref_sss.min_samples = 4096;
    st.ref_sss.max_samples = 4096;
    st.ref_sss.batch = 4096;
    render_session *ses = session(ctx, 2, NULL);
    render_frame f;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK(f.has_reference);
    const char *layers[] = {"beauty", "ao", "ambient", "sss", "volume"};
    for (int i = 0; i < 5; i++) {
        int found = 0;
        for (int e = 0; e < f.error_count; e++)
            if (!strcmp(f.errors[e].layer, layers[i])) {
                found = 1;
                CHECK_MSG(f.errors[e].pixels > 0 && f.errors[e].rmse >= 0 && f.errors[e].rmse < 1e3,
                          "layer %s: %lld pixels, rmse %g", layers[i], (long long)f.errors[e].pixels, f.errors[e].rmse);
            }
        CHECK_MSG(found, "no error for layer %s", layers[i]);
    }
    CHECK(f.ref_beauty[0].data && f.ref_ao.data && f.ref_sss[0].data && f.ref_volume[3].data);
    CHECK(f.seconds_reference > 0 && f.seconds_approx > 0);
    /* the files: layered EXR with ref_ layers, PNG, JSON with the errors */
    const char *prefix = test_path(test_tmpdir(), "frame");
    char pbuf[1024];
    snprintf(pbuf, sizeof pbuf, "%s", prefix);
    CHECK_MSG(render_frame_write(ctx, &f, &s, &st, pbuf, 0, NULL) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    char path[1100];
    snprintf(path, sizeof path, "%s.exr", pbuf);
    io_image im;
    CHECK(io_image_read(ctx, path, &im) == OBS_STATUS_OK);
    CHECK(io_image_find_channel(&im, "beauty.R") >= 0 && io_image_find_channel(&im, "ao.Y") >= 0 &&
          io_image_find_channel(&im, "volume.A") >= 0 && io_image_find_channel(&im, "depth.Z") >= 0 &&
          io_image_find_channel(&im, "ref_beauty.R") >= 0 && io_image_find_channel(&im, "ref_sss.G") >= 0);
    io_image_free(&im);
    snprintf(path, sizeof path, "%s.json", pbuf);
    char *json = test_slurp(path, NULL);
    CHECK(json && strstr(json, "\"passes\"") && strstr(json, "\"rmse\"") && strstr(json, "\"ref_sss\""));
    free(json);
    snprintf(path, sizeof path, "%s.png", pbuf);
    CHECK(access(path, R_OK) == 0);
    render_pass_log_print(stdout, &f);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* ---- bad settings -------------------------------------------------------------------------- */

TEST(render_bad_settings_give_errors_naming_the_problem)
{
    obs_context *ctx = obs_context_create();
    obs_context_set_log_level(ctx, OBS_LOG_ERROR);
    obs_scene s;
    make_scene(&s, 0, NULL);
    render_settings st = small_settings();
    render_session *ses = session(ctx, 1, NULL);
    render_frame f;
    st.camera_count = 1;
    st.cameras[0] = 5;
    CHECK(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_INVALID_ARGUMENT);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "camera index 5 out of range") != NULL, "%s",
              obs_context_last_error(ctx));
    obs_context_clear_error(ctx);
    st = small_settings();
    st.volume.enabled = 1;
    snprintf(st.volume.source, sizeof st.volume.source, "no_such_volume.nrrd");
    snprintf(st.volume.transfer, sizeof st.volume.transfer, "bucky");
    CHECK(render_frame_run(ses, &s, &st, 0, &f) == OBS_STATUS_NOT_FOUND);
    CHECK_MSG(strstr(obs_context_last_error(ctx), "no_such_volume.nrrd") != NULL &&
                  strstr(obs_context_last_error(ctx), "volume_load") != NULL,
              "%s", obs_context_last_error(ctx));
    CHECK(state_of(&f, "volume_load") == RENDER_PASS_RAN || state_of(&f, "volume_load") == RENDER_PASS_PLANNED);
    obs_context_clear_error(ctx);
    CHECK(render_frame_run(ses, &s, &st, 3, &f) == OBS_STATUS_INVALID_ARGUMENT);
    render_frame_free(&f);
    render_session_destroy(ses);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* The volume's eye pass (vol_eye_volume_build, a reconstruction) runs in the view's raycast pass on a
 * copy of the cached light volume: the light volume's product and key stay the light's, a second
 * view still reuses it, and the volume layer changes (never brighter: chromaticity is multiplied by
 * the eye volume's, which is in [0, 1]). */
TEST(render_volume_eye_pass_runs_per_view_and_keeps_the_light_volume_cached)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 0, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    render_frame plain, eye, again;
    render_session *ses = session(ctx, 2, NULL);
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &plain) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    st.volume.lv.eye_pass = 1;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &eye) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &again) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    render_session_destroy(ses);
    const render_pass_record *lp = rec(&plain, "light_volume"), *le = rec(&eye, "light_volume");
    const render_pass_record *re = rec(&eye, "raycast");
    CHECK(lp && le && re);
    if (lp && le && re) {
        CHECK_MSG(!strcmp(lp->key, le->key), "eye_pass must not change the light volume's key");
        CHECK_EQ_INT(le->state, RENDER_PASS_CACHED_MEMORY);
        CHECK_MSG(strstr(re->reason, "eye pass") != NULL, "raycast reason: %s", re->reason);
    }
    CHECK(frames_equal(&eye, &again));
    int differ = 0, brighter = 0, alpha_changed = 0;
    CHECK(plain.volume[3].data && eye.volume[3].data);
    for (int c = 0; c < 4 && plain.volume[c].data && eye.volume[c].data; c++)
        for (int y = 0; y < plain.height; y++) {
            const float *a = obs_image_f32_row(&plain.volume[c], y), *b = obs_image_f32_row(&eye.volume[c], y);
            for (int x = 0; x < plain.width; x++) {
                if (c == 3) {
                    alpha_changed += a[x] != b[x];
                    continue;
                }
                differ += a[x] != b[x];
                brighter += b[x] > a[x] + 1e-6f;
            }
        }
    CHECK_MSG(differ > 0, "the eye pass changed no pixel of the volume layer");
    CHECK_EQ_INT(brighter, 0);
    CHECK_EQ_INT(alpha_changed, 0);
    render_frame_free(&plain);
    render_frame_free(&eye);
    render_frame_free(&again);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* The hybrid scene (issue 15, item 6): the volume shadows the meshes. The direct pass reads the light
 * volume and multiplies each light's term by the volume's transmittance toward it, so with the
 * volume on the floor some pixels of the direct layer get darker and none brighter; without light-
 * volume shading (emission-absorption) the volume casts no shadow and the layer is the plain one. */
TEST(render_volume_shadows_the_meshes_through_the_light_volume)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 0, NULL);
    render_settings st = small_settings();
    st.outputs = RENDER_OUT_DIRECT;
    render_frame plain, shadowed, ea;
    render_session *ses = session(ctx, 2, NULL);
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &plain) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    use_volume(&st);
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &shadowed) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    st.volume.rc.shading = VOL_SHADING_EMISSION_ABSORPTION;
    CHECK_MSG(render_frame_run(ses, &s, &st, 0, &ea) == OBS_STATUS_OK, "%s", obs_context_last_error(ctx));
    render_session_destroy(ses);
    const render_pass_record *d = rec(&shadowed, "direct");
    CHECK(d != NULL);
    if (d) {
        CHECK_MSG(strstr(d->reads, "light_volume") != NULL, "direct reads: %s", d->reads);
        CHECK_MSG(strstr(d->reason, "shadowed by the volume") != NULL, "direct: %s", d->reason);
    }
    CHECK_EQ_INT(state_of(&shadowed, "light_volume"), RENDER_PASS_RAN); /* only direct was asked for */
    CHECK_EQ_INT(state_of(&shadowed, "raycast"), RENDER_PASS_CULLED);
    int darker = 0, brighter = 0;
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < plain.height; y++) {
            const float *a = obs_image_f32_row(&plain.direct[c], y), *b = obs_image_f32_row(&shadowed.direct[c], y);
            for (int x = 0; x < plain.width; x++) {
                darker += b[x] < a[x] - 1e-6f;
                brighter += b[x] > a[x] + 1e-6f;
            }
        }
    CHECK_MSG(darker > 0, "the volume darkened no pixel of the direct layer");
    CHECK_EQ_INT(brighter, 0);
    CHECK(rtu_planes_equal(plain.direct, ea.direct, 3));
    render_frame_free(&plain);
    render_frame_free(&shadowed);
    render_frame_free(&ea);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}

/* The memory budget: products not used by the current frame are dropped, least recently used
 * first, once the cache holds more than the budget; what the frame uses is kept; a dropped product
 * is rebuilt (or read from disk) with the same bytes. */
TEST(render_memory_cache_stays_within_its_budget_and_rebuilds_what_it_dropped)
{
    obs_context *ctx = obs_context_create();
    obs_scene s;
    make_scene(&s, 1, NULL);
    render_settings st = small_settings();
    use_volume(&st);
    render_frame a0, a1, b0, a2, big;
    /* the cold run's footprint: every product of one light */
    render_session *roomy = session(ctx, 2, NULL);
    CHECK(render_frame_run(roomy, &s, &st, 0, &big) == OBS_STATUS_OK);
    render_cache_stats one;
    render_session_cache_stats(roomy, &one);
    CHECK(one.entries == 5 && one.evictions == 0 && one.bytes > 0);

    /* a budget of one light's products: the second light's frame must drop the first light's
     * light-dependent products (maps, light volume, shadow maps) but keep the volume it shares */
    render_options o = render_options_default();
    o.threads = 2;
    o.cache_memory = one.bytes;
    render_session *tight = render_session_create(ctx, &o);
    CHECK(tight != NULL);
    CHECK(render_frame_run(tight, &s, &st, 0, &a0) == OBS_STATUS_OK);
    CHECK(render_frame_run(tight, &s, &st, 1, &a1) == OBS_STATUS_OK); /* same light: all hits */
    CHECK(state_of(&a1, "sss_maps") == RENDER_PASS_CACHED_MEMORY);
    const obs_vec3 d0 = s.lights[0].direction;
    s.lights[0].direction = obs_v3_normalize(obs_v3(0.3f, -1.0f, -0.2f));
    CHECK(render_frame_run(tight, &s, &st, 0, &b0) == OBS_STATUS_OK);
    CHECK(state_of(&b0, "sss_maps") == RENDER_PASS_RAN && state_of(&b0, "volume_load") == RENDER_PASS_CACHED_MEMORY);
    render_cache_stats cs;
    render_session_cache_stats(tight, &cs);
    CHECK_MSG(cs.evictions >= 3, "%lld evictions", (long long)cs.evictions);
    CHECK_MSG(cs.bytes <= one.bytes, "%llu bytes held over a budget of %llu", (unsigned long long)cs.bytes,
              (unsigned long long)one.bytes);
    /* back to the first light: its products were dropped, so they are rebuilt, with the same bytes */
    s.lights[0].direction = d0;
    CHECK(render_frame_run(tight, &s, &st, 0, &a2) == OBS_STATUS_OK);
    CHECK(state_of(&a2, "sss_maps") == RENDER_PASS_RAN && state_of(&a2, "light_volume") == RENDER_PASS_RAN);
    CHECK(frames_equal(&a0, &a2));
    CHECK(frames_equal(&big, &a2));

    /* a budget smaller than one product: the frame still completes (what it uses is kept while it
     * runs), and every later frame rebuilds */
    o.cache_memory = 1;
    render_session *tiny = render_session_create(ctx, &o);
    render_frame t0, t1;
    CHECK(render_frame_run(tiny, &s, &st, 0, &t0) == OBS_STATUS_OK);
    CHECK(render_frame_run(tiny, &s, &st, 1, &t1) == OBS_STATUS_OK);
    CHECK(state_of(&t1, "sss_maps") == RENDER_PASS_RAN);
    CHECK(frames_equal(&t0, &a0));
    render_frame_free(&t0);
    render_frame_free(&t1);
    render_session_destroy(tiny);

    render_frame_free(&a0);
    render_frame_free(&a1);
    render_frame_free(&b0);
    render_frame_free(&a2);
    render_frame_free(&big);
    render_session_destroy(roomy);
    render_session_destroy(tight);
    obs_scene_free(&s);
    obs_context_destroy(ctx);
}
