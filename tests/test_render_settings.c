/* test_render_settings.c: the scene-driven render's settings (render_settings.c, docs/render.md
 * "Scene settings"): the defaults and their sources, every key of the schema, the errors a bad
 * scene gets (each naming the key path), the scene's extras, validation against the scene, and the
 * sidecar's "settings" object read back into the same settings. */
#include "core/obs.h"
#include "io/io.h"
#include "render/render.h"
#include "test.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A scene with three cameras ("front", "side", "top") and a point and a spot light; no meshes
 * (the settings never look at geometry). */
static void rs_scene(obs_scene *sc)
{
    obs_scene_init(sc);
    snprintf(sc->source, sizeof sc->source, "test_scene.glb");
    sc->camera_count = 3;
    sc->cameras = (obs_camera *)calloc(3, sizeof(obs_camera));
    static const char *names[3] = {"front", "side", "top"};
    for (int c = 0; c < 3; c++) {
        sc->cameras[c] = obs_camera_look_at(obs_v3(0, 0, 5), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 100.0f);
        snprintf(sc->cameras[c].name, sizeof sc->cameras[c].name, "%s", names[c]);
    }
    sc->light_count = 2;
    sc->lights = (obs_light *)calloc(2, sizeof(obs_light));
    sc->lights[0].type = OBS_LIGHT_POINT;
    snprintf(sc->lights[0].name, sizeof sc->lights[0].name, "bulb");
    sc->lights[1].type = OBS_LIGHT_SPOT;
    snprintf(sc->lights[1].name, sizeof sc->lights[1].name, "spot");
}

static int rs_same(const render_settings *a, const render_settings *b);

/* Apply json to the defaults; the status must be `want` and the message must contain `needle`. */
static int rs_expect(const char *json, const obs_scene *sc, obs_status want, const char *needle)
{
    obs_context *ctx = obs_context_create();
    render_settings s = render_settings_default(), before = s;
    obs_status st = render_settings_apply_json(ctx, json, "test.glb", sc, &s);
    const char *msg = obs_context_last_error(ctx);
    int ok = st == want && (!needle || strstr(msg, needle) != NULL);
    /* A refused object changes nothing. */
    if (st != OBS_STATUS_OK && !rs_same(&s, &before))
        ok = 0;
    if (!ok)
        fprintf(stderr, "  %s\n    -> %s (want %s), \"%s\" (want \"%s\")\n", json, obs_status_string(st),
                obs_status_string(want), msg, needle ? needle : "");
    obs_context_destroy(ctx);
    return ok;
}

/* Field by field (the structs have padding, which memcmp would read). */
static int rs_same_sss(const sss_params *a, const sss_params *b)
{
    return a->model == b->model && a->K == b->K && a->N == b->N && a->M == b->M && a->map_size == b->map_size &&
           a->light_map_size == b->light_map_size && a->frames == b->frames && a->spread_q == b->spread_q &&
           a->disk_radius == b->disk_radius && a->sampler == b->sampler && a->visibility == b->visibility &&
           a->shadow_bias == b->shadow_bias && a->shrink_eps == b->shrink_eps && a->gamma == b->gamma &&
           a->specular == b->specular && a->specular_exponent == b->specular_exponent && a->seed == b->seed &&
           a->isa == b->isa;
}
static int rs_same_lv(const vol_lv_params *a, const vol_lv_params *b)
{
    return a->scale == b->scale && a->cone_angle_deg == b->cone_angle_deg && a->blend_second == b->blend_second &&
           a->eye_pass == b->eye_pass && a->kappa == b->kappa;
}
static int rs_same_rc(const vol_rc_params *a, const vol_rc_params *b)
{
    return a->shading == b->shading && a->step == b->step && a->early_termination == b->early_termination &&
           a->brick == b->brick && a->ambient == b->ambient && a->specular_exponent == b->specular_exponent &&
           !memcmp(a->background, b->background, sizeof a->background);
}
static int rs_same_tsss(const truth_sss_params *a, const truth_sss_params *b)
{
    return a->estimator == b->estimator && a->model == b->model && a->target_rel_error == b->target_rel_error &&
           a->min_samples == b->min_samples && a->max_samples == b->max_samples && a->batch == b->batch &&
           a->replicates == b->replicates && a->sigma_star == b->sigma_star && a->patch_radius == b->patch_radius &&
           a->max_bounces == b->max_bounces && a->offset_ulps == b->offset_ulps && a->tile == b->tile &&
           a->seed == b->seed;
}

TEST(render_settings_defaults_are_the_documented_ones)
{
    render_settings s = render_settings_default();
    CHECK_EQ_INT(s.width, 0);
    CHECK_EQ_INT(s.height, 0);
    CHECK_EQ_INT(s.camera_count, 0);
    CHECK_EQ_INT(s.outputs, RENDER_OUT_ALL);
    CHECK(s.ao == ao_method_find("sao"));
    unsigned char p[AO_PARAMS_MAX_SIZE];
    memset(p, 0, sizeof p);
    s.ao->params_default(p);
    CHECK(memcmp(p, s.ao_params, s.ao->params_size) == 0);
    for (int c = 0; c < 3; c++)
        CHECK(s.ambient[c] == RENDER_DEFAULT_AMBIENT);
    CHECK(RENDER_DEFAULT_AMBIENT == AO_BLEND_AMBIENT);
    CHECK_EQ_INT(s.shadows, 1);
    CHECK_EQ_INT(s.shadow_map_size, RENDER_DEFAULT_SHADOW_MAP_SIZE);
    sss_params sp = sss_params_default();
    CHECK(rs_same_sss(&sp, &s.sss));
    CHECK(s.mm_per_unit == SSS_DEFAULT_MM_PER_UNIT);
    CHECK_EQ_INT(s.volume.enabled, 0);
    CHECK_EQ_INT(s.volume.light, -1);
    vol_lv_params lv = vol_lv_params_default();
    vol_rc_params rc = vol_rc_params_default();
    CHECK(rs_same_lv(&lv, &s.volume.lv));
    CHECK(rs_same_rc(&rc, &s.volume.rc));
    CHECK_EQ_INT(s.seed, 0);
    CHECK_EQ_INT(s.reference, 0);
    /* The reference AO: truth's defaults with the technique's radius and matched estimator. */
    truth_ao_params ta = truth_ao_params_default();
    CHECK(s.ref_ao.radius == s.ao->get_radius(s.ao_params));
    truth_ao_estimator e;
    CHECK(truth_ao_estimator_from_name(s.ao->truth_estimator(s.ao_params), &e));
    CHECK_EQ_INT(s.ref_ao.estimator, e);
    CHECK(s.ref_ao.target_error == ta.target_error && s.ref_ao.min_samples == ta.min_samples);
    truth_sss_params ts = truth_sss_params_default();
    CHECK(rs_same_tsss(&ts, &s.ref_sss));
    CHECK_EQ_INT(s.ref_volume_samples, 256);
    /* The defaults pass validation, with and without a scene. */
    obs_scene sc;
    rs_scene(&sc);
    obs_context *ctx = obs_context_create();
    CHECK_OK(render_settings_validate(ctx, NULL, &s), ctx);
    CHECK_OK(render_settings_validate(ctx, &sc, &s), ctx);
    obs_context_destroy(ctx);
    obs_scene_free(&sc);
}

TEST(render_settings_output_names_round_trip)
{
    for (unsigned b = 1; b < RENDER_OUT_ALL; b <<= 1) {
        const char *n = render_output_name(b);
        CHECK(n != NULL);
        CHECK_EQ_INT(render_output_from_name(n), b);
    }
    CHECK(render_output_name(RENDER_OUT_ALL + 1u) == NULL);
    CHECK(render_output_name(3u) == NULL);
    CHECK_EQ_INT(render_output_from_name("Beauty"), 0);
    CHECK_EQ_INT(render_output_from_name(NULL), 0);
    CHECK_EQ_INT(render_output_from_name("sss"), RENDER_OUT_SSS);
}

TEST(render_settings_apply_a_full_object_sets_every_key)
{
    obs_scene sc;
    rs_scene(&sc);
    const char *json =
        "{\"size\":[640,360],\"cameras\":[\"side\",0,\"2\"],\"outputs\":[\"beauty\",\"ao\",\"sss\"],"
        "\"ambient\":[0.1,0.2,0.3],\"seed\":42,"
        "\"ao\":{\"method\":\"gtao\",\"radius\":0.3},"
        "\"shadows\":{\"size\":1024},"
        "\"sss\":{\"mm_per_unit\":40,\"model\":\"standard\",\"K\":8,\"N\":16,\"M\":500,\"map_size\":256,"
        "\"light_map_size\":128,\"frames\":2,\"q\":0.5,\"disk_radius\":0.1,\"sampler\":\"rr\","
        "\"visibility\":\"pcf3x3\",\"shadow_bias\":0.002,\"shrink_eps\":0.001,\"gamma\":1.8,\"specular\":true,"
        "\"specular_exponent\":32},"
        "\"volume\":{\"source\":\"synth:bucky:32\",\"transfer\":\"bucky\",\"box\":[[1,2,3],[2,3.5,4]],\"light\":0,"
        "\"shading\":\"phong\",\"step\":0.01,\"early_termination\":0.95,\"brick\":4,\"phong_ambient\":0.3,"
        "\"specular_exponent\":16,\"scale\":2,\"cone_angle\":30,\"blend_second\":false,\"eye_pass\":true,"
        "\"kappa\":2},"
        "\"reference\":{\"ao_target_error\":0.01,\"ao_min_samples\":32,\"ao_max_samples\":1024,"
        "\"sss_estimator\":\"random-walk\",\"sss_target_rel_error\":0.05,\"sss_min_samples\":4096,"
        "\"sss_max_samples\":65536,\"sss_batch\":1024,\"sss_patch_radius\":0.01,\"volume_samples\":64}}";
    obs_context *ctx = obs_context_create();
    render_settings s = render_settings_default();
    CHECK_OK(render_settings_apply_json(ctx, json, "test.glb", &sc, &s), ctx);
    CHECK_EQ_INT(s.width, 640);
    CHECK_EQ_INT(s.height, 360);
    CHECK_EQ_INT(s.camera_count, 3);
    CHECK_EQ_INT(s.cameras[0], 1);
    CHECK_EQ_INT(s.cameras[1], 0);
    CHECK_EQ_INT(s.cameras[2], 2);
    CHECK_EQ_INT(s.outputs, RENDER_OUT_BEAUTY | RENDER_OUT_AO | RENDER_OUT_SSS);
    CHECK(s.ambient[0] == 0.1f && s.ambient[1] == 0.2f && s.ambient[2] == 0.3f);
    CHECK_EQ_INT(s.seed, 42);
    CHECK(s.ao == ao_method_find("gtao"));
    CHECK_NEAR(s.ao->get_radius(s.ao_params), 0.3, 1e-7);
    CHECK_NEAR(s.ref_ao.radius, 0.3, 1e-7); /* the reference follows the technique */
    CHECK_EQ_INT(s.shadows, 1);
    CHECK_EQ_INT(s.shadow_map_size, 1024);
    CHECK(s.mm_per_unit == 40.0);
    CHECK_EQ_INT(s.sss.model, SSS_MODEL_STANDARD);
    CHECK_EQ_INT(s.sss.K, 8);
    CHECK_EQ_INT(s.sss.N, 16);
    CHECK_EQ_INT(s.sss.M, 500);
    CHECK_EQ_INT(s.sss.map_size, 256);
    CHECK_EQ_INT(s.sss.light_map_size, 128);
    CHECK_EQ_INT(s.sss.frames, 2);
    CHECK(s.sss.spread_q == 0.5 && s.sss.disk_radius == 0.1 && s.sss.shadow_bias == 0.002 &&
          s.sss.shrink_eps == 0.001 && s.sss.gamma == 1.8 && s.sss.specular_exponent == 32.0);
    CHECK_EQ_INT(s.sss.sampler, SSS_SAMPLER_RUSSIAN_ROULETTE);
    CHECK_EQ_INT(s.sss.visibility, SSS_VISIBILITY_PCF3X3);
    CHECK_EQ_INT(s.sss.specular, 1);
    CHECK_EQ_INT(s.volume.enabled, 1);
    CHECK(!strcmp(s.volume.source, "synth:bucky:32") && !strcmp(s.volume.transfer, "bucky"));
    CHECK_EQ_INT(s.volume.has_box, 1);
    CHECK(s.volume.box_lo[0] == 1 && s.volume.box_lo[1] == 2 && s.volume.box_lo[2] == 3);
    CHECK(s.volume.box_hi[0] == 2 && s.volume.box_hi[1] == 3.5 && s.volume.box_hi[2] == 4);
    CHECK_EQ_INT(s.volume.light, 0);
    CHECK_EQ_INT(s.volume.rc.shading, VOL_SHADING_PHONG);
    CHECK(s.volume.rc.step == 0.01 && s.volume.rc.early_termination == 0.95 && s.volume.rc.ambient == 0.3f &&
          s.volume.rc.specular_exponent == 16.0f);
    CHECK_EQ_INT(s.volume.rc.brick, 4);
    CHECK_EQ_INT(s.volume.lv.scale, 2);
    CHECK(s.volume.lv.cone_angle_deg == 30.0 && s.volume.lv.kappa == 2.0);
    CHECK_EQ_INT(s.volume.lv.blend_second, 0);
    CHECK_EQ_INT(s.volume.lv.eye_pass, 1);
    CHECK_EQ_INT(s.reference, 1); /* an object turns it on */
    CHECK(s.ref_ao.target_error == 0.01);
    CHECK_EQ_INT(s.ref_ao.min_samples, 32);
    CHECK_EQ_INT(s.ref_ao.max_samples, 1024);
    CHECK_EQ_INT(s.ref_sss.estimator, TRUTH_SSS_RANDOM_WALK);
    CHECK(s.ref_sss.target_rel_error == 0.05 && s.ref_sss.patch_radius == 0.01);
    CHECK_EQ_INT(s.ref_sss.min_samples, 4096);
    CHECK_EQ_INT(s.ref_sss.max_samples, 65536);
    CHECK_EQ_INT(s.ref_sss.batch, 1024);
    CHECK_EQ_INT(s.ref_volume_samples, 64);
    CHECK_OK(render_settings_validate(ctx, &sc, &s), ctx);

    /* Keys not given keep their values: a second object changes only what it names. */
    CHECK_OK(render_settings_apply_json(ctx, "{\"ao\":{\"radius\":0.6},\"sss\":{\"K\":4}}", "x", &sc, &s), ctx);
    CHECK(s.ao == ao_method_find("gtao"));
    CHECK_NEAR(s.ao->get_radius(s.ao_params), 0.6, 1e-7);
    CHECK_EQ_INT(s.sss.K, 4);
    CHECK_EQ_INT(s.sss.N, 16);
    /* Switches: false turns a section off, true back on. */
    CHECK_OK(render_settings_apply_json(ctx, "{\"ao\":false,\"shadows\":false,\"volume\":false,\"reference\":false}",
                                        "x", &sc, &s), ctx);
    CHECK(s.ao == NULL);
    CHECK_EQ_INT(s.shadows, 0);
    CHECK_EQ_INT(s.volume.enabled, 0);
    CHECK_EQ_INT(s.reference, 0);
    CHECK_OK(render_settings_apply_json(ctx, "{\"ao\":true,\"ambient\":0.5,\"outputs\":\"all\",\"cameras\":[]}", "x",
                                        &sc, &s), ctx);
    CHECK(s.ao == ao_method_find("sao"));
    CHECK(s.ambient[0] == 0.5f && s.ambient[2] == 0.5f);
    CHECK_EQ_INT(s.outputs, RENDER_OUT_ALL);
    CHECK_EQ_INT(s.camera_count, 0);
    /* A preset, then parameters on top of it (as `obscura ao --preset`). */
    CHECK_OK(render_settings_apply_json(ctx, "{\"ao\":{\"method\":\"sao\",\"preset\":\"thesis\",\"samples\":12}}", "x",
                                        &sc, &s), ctx);
    CHECK_NEAR(s.ao->get_radius(s.ao_params), 10.0, 1e-6);
    obs_context_destroy(ctx);
    obs_scene_free(&sc);
}

TEST(render_settings_unknown_keys_are_errors_naming_the_path)
{
    obs_scene sc;
    rs_scene(&sc);
    CHECK(rs_expect("{\"sizes\":[1,2]}", &sc, OBS_STATUS_INVALID_ARGUMENT, "test.glb: obscura_render.sizes: unknown key; known: size"));
    CHECK(rs_expect("{\"sss\":{\"KK\":3}}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.sss.KK: unknown key; known: mm_per_unit"));
    CHECK(rs_expect("{\"ao\":{\"radiuss\":1}}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.ao.radiuss: unknown key"));
    CHECK(rs_expect("{\"ao\":{\"method\":\"hbao\",\"turns\":3}}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.ao.turns"));
    CHECK(rs_expect("{\"shadows\":{\"resolution\":512}}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.shadows.resolution: unknown key"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"colour\":1}}", &sc,
                    OBS_STATUS_INVALID_ARGUMENT, "obscura_render.volume.colour: unknown key"));
    CHECK(rs_expect("{\"reference\":{\"ao_rays\":10}}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.reference.ao_rays: unknown key"));
    CHECK(rs_expect("{\"seed\":1,\"seed\":2}", &sc, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.seed: given twice"));
    obs_scene_free(&sc);
}

TEST(render_settings_wrong_types_and_ranges_are_errors_naming_the_key)
{
    obs_scene sc;
    rs_scene(&sc);
    const obs_status BAD = OBS_STATUS_INVALID_ARGUMENT;
    CHECK(rs_expect("[1,2]", &sc, BAD, "obscura_render: must be a JSON object"));
    CHECK(rs_expect("{\"size\":\"640x480\"}", &sc, BAD, "obscura_render.size: must be [width, height]"));
    CHECK(rs_expect("{\"size\":[640.5,480]}", &sc, BAD, "obscura_render.size[0]: must be an integer"));
    CHECK(rs_expect("{\"size\":[640,0]}", &sc, BAD, "obscura_render.size: give both sides"));
    CHECK(rs_expect("{\"size\":[99999,10]}", &sc, BAD, "obscura_render.size[0]: must be in [0, 16384]"));
    CHECK(rs_expect("{\"outputs\":[\"beauty\",\"bloom\"]}", &sc, BAD, "obscura_render.outputs[1]: \"bloom\" is not a layer"));
    CHECK(rs_expect("{\"outputs\":[]}", &sc, BAD, "obscura_render.outputs: asks for no layer"));
    CHECK(rs_expect("{\"ambient\":-1}", &sc, BAD, "obscura_render.ambient: must be >= 0"));
    /* finite as a double, +inf as the float it is stored in (found by fuzz_render_settings) */
    CHECK(rs_expect("{\"ambient\":[1e300,0,0]}", &sc, BAD, "obscura_render.ambient[0]: must be at most"));
    CHECK(rs_expect("{\"ambient\":[1,2]}", &sc, BAD, "obscura_render.ambient: must be a number or [r, g, b]"));
    CHECK(rs_expect("{\"seed\":-3}", &sc, BAD, "obscura_render.seed: must be in [0,"));
    CHECK(rs_expect("{\"ao\":\"sao\"}", &sc, BAD, "obscura_render.ao: must be false, true or an object"));
    CHECK(rs_expect("{\"ao\":{\"radius\":\"big\"}}", &sc, BAD, "obscura_render.ao.radius: must be a number"));
    CHECK(rs_expect("{\"ao\":{\"samples\":0}}", &sc, BAD, "obscura_render.ao.samples: must be in [1,"));
    CHECK(rs_expect("{\"ao\":{\"blur\":1}}", &sc, BAD, "obscura_render.ao.blur: must be true or false"));
    CHECK(rs_expect("{\"ao\":{\"variant\":\"hpg13\"}}", &sc, BAD, "obscura_render.ao.variant: must be one of: hpg12"));
    CHECK(rs_expect("{\"shadows\":{\"size\":8}}", &sc, BAD, "obscura_render.shadows.size: must be in [16, 16384]"));
    CHECK(rs_expect("{\"sss\":{\"K\":0}}", &sc, BAD, "obscura_render.sss: sss params: K = 0"));
    CHECK(rs_expect("{\"sss\":{\"K\":\"8\"}}", &sc, BAD, "obscura_render.sss.K: must be an integer"));
    CHECK(rs_expect("{\"sss\":{\"mm_per_unit\":0}}", &sc, BAD, "obscura_render.sss.mm_per_unit: must be > 0 (got 0)"));
    CHECK(rs_expect("{\"sss\":{\"sampler\":\"uniform\"}}", &sc, BAD, "obscura_render.sss.sampler: \"uniform\" is not a sampler"));
    CHECK(rs_expect("{\"sss\":{\"visibility\":\"pcf5\"}}", &sc, BAD, "obscura_render.sss.visibility"));
    CHECK(rs_expect("{\"sss\":{\"specular\":\"yes\"}}", &sc, BAD, "obscura_render.sss.specular: must be true or false"));
    /* Non-finite: JSON has no NaN or infinity, but 1e999 overflows to one. */
    CHECK(rs_expect("{\"sss\":{\"gamma\":1e999}}", &sc, BAD, "obscura_render.sss.gamma: must be finite"));
    CHECK(rs_expect("{\"ambient\":[0,1e999,0]}", &sc, BAD, "obscura_render.ambient[1]: must be finite"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\"}}", &sc, BAD, "obscura_render.volume.transfer: is required"));
    CHECK(rs_expect("{\"volume\":{\"transfer\":\"bucky\"}}", &sc, BAD, "obscura_render.volume.source: is empty"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky:1\",\"transfer\":\"bucky\"}}", &sc, BAD,
                    "obscura_render.volume.source: \"synth:bucky:1\""));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"box\":[[0,0,0],[1,0,1]]}}", &sc,
                    BAD, "obscura_render.volume.box: low corner must be below the high corner on every axis (axis y"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"box\":[[0,0,0],[1,1]]}}", &sc,
                    BAD, "obscura_render.volume.box[1]: must be [x, y, z]"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"light\":5}}", &sc, BAD,
                    "obscura_render.volume.light: light 5 does not exist in test_scene.glb"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"cone_angle\":90}}", &sc, BAD,
                    "obscura_render.volume: light volume: cone angle 90"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"shading\":\"pbr\"}}", &sc, BAD,
                    "obscura_render.volume.shading: \"pbr\" is not a shading"));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"bucky\",\"early_termination\":0}}", &sc,
                    BAD, "obscura_render.volume.early_termination: must be in (0, 1]"));
    CHECK(rs_expect("{\"volume\":true}", &sc, BAD, "obscura_render.volume: must be false or an object"));
    CHECK(rs_expect("{\"reference\":{\"ao_min_samples\":33}}", &sc, BAD,
                    "obscura_render.reference.ao_min_samples: must be a multiple"));
    CHECK(rs_expect("{\"reference\":{\"sss_estimator\":\"photon\"}}", &sc, BAD,
                    "obscura_render.reference.sss_estimator: \"photon\" is not an estimator"));
    CHECK(rs_expect("{\"reference\":{\"volume_samples\":0}}", &sc, BAD,
                    "obscura_render.reference.volume_samples: must be in [8, 1048576]"));
    /* strings must be UTF-8 (a Latin-1 byte would not round-trip through the sidecar) */
    CHECK(rs_expect("{\"volume\":{\"source\":\"caf\xe9.nrrd\"}}", &sc, BAD,
                    "obscura_render.volume.source: is not valid UTF-8"));
    CHECK(rs_expect("{\"reference\":{\"volume_samples\":12}}", &sc, BAD,
                    "obscura_render.reference.volume_samples: must be a multiple of 8"));
    /* Malformed JSON is a parse error. */
    CHECK(rs_expect("{\"size\":[1,2}", &sc, OBS_STATUS_PARSE_ERROR, "test.glb: obscura_render is not valid JSON"));
    CHECK(rs_expect("{} trailing", &sc, OBS_STATUS_PARSE_ERROR, "not valid JSON"));
    obs_scene_free(&sc);
}

TEST(render_settings_unknown_cameras_methods_and_presets_are_not_found)
{
    obs_scene sc;
    rs_scene(&sc);
    CHECK(rs_expect("{\"cameras\":[\"front\",\"back\"]}", &sc, OBS_STATUS_NOT_FOUND,
                    "obscura_render.cameras[1]: no camera named or numbered \"back\" in test_scene.glb (cameras: \"front\""));
    CHECK(rs_expect("{\"cameras\":[3]}", &sc, OBS_STATUS_NOT_FOUND, "obscura_render.cameras[0]: camera 3 does not exist"));
    CHECK(rs_expect("{\"cameras\":\"top\"}", &sc, OBS_STATUS_OK, NULL));
    /* Without a scene, only indices resolve. */
    CHECK(rs_expect("{\"cameras\":[\"front\"]}", NULL, OBS_STATUS_NOT_FOUND, "names need a scene"));
    CHECK(rs_expect("{\"cameras\":[7]}", NULL, OBS_STATUS_OK, NULL));
    CHECK(rs_expect("{\"ao\":{\"method\":\"ssdo\"}}", &sc, OBS_STATUS_NOT_FOUND,
                    "obscura_render.ao.method: no AO method \"ssdo\" (methods: "));
    CHECK(rs_expect("{\"ao\":{\"method\":\"sao\",\"preset\":\"ultra\"}}", &sc, OBS_STATUS_NOT_FOUND,
                    "obscura_render.ao.preset: sao has no preset \"ultra\""));
    CHECK(rs_expect("{\"volume\":{\"source\":\"synth:bucky\",\"transfer\":\"neon\"}}", &sc, OBS_STATUS_NOT_FOUND,
                    "obscura_render.volume.transfer: "));
    obs_scene_free(&sc);
}

TEST(render_settings_validate_checks_against_the_scene)
{
    obs_scene sc;
    rs_scene(&sc);
    obs_context *ctx = obs_context_create();
    render_settings s = render_settings_default();
    s.camera_count = 1;
    s.cameras[0] = 3;
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "obscura_render.cameras") != NULL);
    obs_context_clear_error(ctx);
    s = render_settings_default();
    s.volume.enabled = 1;
    snprintf(s.volume.source, sizeof s.volume.source, "synth:bucky");
    snprintf(s.volume.transfer, sizeof s.volume.transfer, "bucky");
    CHECK_OK(render_settings_validate(ctx, &sc, &s), ctx);
    s.volume.light = 1; /* the spot light */
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "spot light") != NULL);
    obs_context_clear_error(ctx);
    s.volume.light = 0;
    s.volume.box_lo[0] = 1.0;
    s.volume.box_hi[0] = 1.0;
    s.volume.has_box = 1;
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "obscura_render.volume.box") != NULL);
    obs_context_clear_error(ctx);
    s = render_settings_default();
    s.width = 100;
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    obs_context_clear_error(ctx);
    s = render_settings_default();
    s.sss.N = 0;
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "obscura_render.sss") != NULL);
    obs_context_clear_error(ctx);
    s = render_settings_default();
    s.outputs = 0;
    CHECK_EQ_INT(render_settings_validate(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
    obs_scene_free(&sc);
}

/* The settings' fields the schema covers, compared one by one. */
static int rs_same(const render_settings *a, const render_settings *b)
{
    int same = a->width == b->width && a->height == b->height && a->camera_count == b->camera_count &&
               !memcmp(a->cameras, b->cameras, sizeof(int) * (size_t)a->camera_count) && a->outputs == b->outputs &&
               !memcmp(a->ambient, b->ambient, sizeof a->ambient) && a->seed == b->seed && a->ao == b->ao &&
               (!a->ao || !memcmp(a->ao_params, b->ao_params, a->ao->params_size)) && a->shadows == b->shadows &&
               a->shadow_map_size == b->shadow_map_size && rs_same_sss(&a->sss, &b->sss) &&
               a->mm_per_unit == b->mm_per_unit && a->reference == b->reference &&
               a->ref_volume_samples == b->ref_volume_samples &&
               rs_same_tsss(&a->ref_sss, &b->ref_sss) && (!a->ao || (a->ref_ao.radius == b->ref_ao.radius &&
               a->ref_ao.estimator == b->ref_ao.estimator)) && /* (no AO: nothing to match) */ a->ref_ao.target_error == b->ref_ao.target_error &&
               a->ref_ao.min_samples == b->ref_ao.min_samples && a->ref_ao.max_samples == b->ref_ao.max_samples;
    const render_volume_settings *u = &a->volume, *v = &b->volume;
    same = same && u->enabled == v->enabled && !strcmp(u->source, v->source) && !strcmp(u->transfer, v->transfer) &&
           u->has_box == v->has_box && u->light == v->light && rs_same_lv(&u->lv, &v->lv) &&
           rs_same_rc(&u->rc, &v->rc);
    if (same && u->has_box)
        same = !memcmp(u->box_lo, v->box_lo, sizeof u->box_lo) && !memcmp(u->box_hi, v->box_hi, sizeof u->box_hi);
    return same;
}

/* to_json, then the "settings" object applied to the defaults. */
static int rs_round_trip(const render_settings *s, const obs_scene *sc)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    render_settings_to_json(s, &j);
    io_json_end_object(&j);
    /* The document is {"settings": {...}}: the object's own text, as the writer wrote it (cJSON's
     * printer would shorten doubles to 15 digits where they are within an epsilon). */
    cJSON *root = j.failed ? NULL : cJSON_Parse(j.buf);
    char *text = NULL;
    if (root && cJSON_IsObject(cJSON_GetObjectItemCaseSensitive(root, "settings"))) {
        const char *open = strchr(strchr(j.buf, ':'), '{'), *close = strrchr(j.buf, '}');
        text = strndup(open, (size_t)(close - open));
    }
    obs_context *ctx = obs_context_create();
    render_settings back = render_settings_default();
    obs_status st = text ? render_settings_apply_json(ctx, text, "sidecar", sc, &back) : OBS_STATUS_PARSE_ERROR;
    int ok = st == OBS_STATUS_OK && rs_same(s, &back);
    if (!ok)
        fprintf(stderr, "  round trip: %s (%s)\n  %s\n", obs_status_string(st), obs_context_last_error(ctx),
                j.buf ? j.buf : "");
    obs_context_destroy(ctx);
    free(text);
    cJSON_Delete(root);
    io_json_free(&j);
    return ok;
}

TEST(render_settings_sidecar_json_reads_back_to_the_same_settings)
{
    obs_scene sc;
    rs_scene(&sc);
    render_settings s = render_settings_default();
    CHECK(rs_round_trip(&s, &sc));
    obs_context *ctx = obs_context_create();
    /* Every key away from its default, doubles that need 17 digits, a disabled reference with
     * non-default counts (kept), each AO method with its defaults. */
    CHECK_OK(render_settings_apply_json(
                 ctx,
                 "{\"size\":[320,200],\"cameras\":[2,0],\"outputs\":[\"beauty\",\"depth\"],\"ambient\":[0.1,0.7,0.3],"
                 "\"seed\":9007199254740992,\"ao\":{\"method\":\"hbao\",\"radius\":0.123456789},"
                 "\"shadows\":{\"enabled\":false,\"size\":512},"
                 "\"sss\":{\"mm_per_unit\":33.333333333333336,\"K\":5,\"sampler\":\"nearest-n-of-m\",\"M\":777,"
                 "\"q\":0.1,\"gamma\":2.2,\"disk_radius\":0.30000000000000004},"
                 "\"volume\":{\"source\":\"head.nrrd\",\"transfer\":\"tf.json\",\"box\":[[-0.1,0.2,-3],[0.7,1.1,1e-3]],"
                 "\"light\":0,\"kappa\":0.7,\"step\":0.001,\"eye_pass\":true},"
                 "\"reference\":{\"enabled\":false,\"ao_min_samples\":128,\"sss_patch_radius\":0.02}}",
                 "x", &sc, &s),
             ctx);
    CHECK_EQ_INT(s.reference, 0);
    CHECK_EQ_INT(s.ref_ao.min_samples, 128);
    CHECK(rs_round_trip(&s, &sc));
    s.ao = NULL;
    CHECK(rs_round_trip(&s, &sc));
    for (const ao_method *const *m = ao_methods(); *m; m++) {
        render_settings t = render_settings_default();
        t.ao = *m;
        (*m)->params_default(t.ao_params);
        /* as render_settings_apply_json leaves it: the reference follows the technique */
        t.ref_ao.radius = (*m)->get_radius(t.ao_params);
        truth_ao_estimator e;
        CHECK(truth_ao_estimator_from_name((*m)->truth_estimator(t.ao_params), &e));
        t.ref_ao.estimator = e;
        CHECK_MSG(rs_round_trip(&t, &sc), "method %s", (*m)->name);
    }
    obs_context_destroy(ctx);
    obs_scene_free(&sc);
}

TEST(render_settings_from_scene_reads_the_scene_extras)
{
    obs_context *ctx = obs_context_create();
    obs_scene sc;
    rs_scene(&sc);
    render_settings s = render_settings_default();
    /* No extras, extras that are not an object, extras without our key: the defaults stay. */
    CHECK_OK(render_settings_from_scene(ctx, &sc, &s), ctx);
    sc.extras_json = strdup("[1,2]");
    CHECK_OK(render_settings_from_scene(ctx, &sc, &s), ctx);
    free(sc.extras_json);
    sc.extras_json = strdup("{\"author\":\"someone\",\"obscura_render\":{\"seed\":5,\"cameras\":[\"top\"]}}");
    CHECK_OK(render_settings_from_scene(ctx, &sc, &s), ctx);
    CHECK_EQ_INT(s.seed, 5);
    CHECK_EQ_INT(s.camera_count, 1);
    CHECK_EQ_INT(s.cameras[0], 2);
    /* A bad key: the message names the scene file and the key. */
    free(sc.extras_json);
    sc.extras_json = strdup("{\"obscura_render\":{\"ao\":{\"radius\":-1}}}");
    CHECK_EQ_INT(render_settings_from_scene(ctx, &sc, &s), OBS_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(obs_context_last_error(ctx), "test_scene.glb: obscura_render.ao.radius") != NULL);
    obs_context_clear_error(ctx);
    obs_scene_free(&sc);

    /* The bundled default scene (mkdata): its AO radius and SSS scale suit a 5.5 m box, and the
     * volume it holds is placed in the box. */
    obs_scene hy;
    obs_scene_init(&hy);
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "cornell_hybrid.glb"), &opt, &hy), ctx);
    s = render_settings_default();
    CHECK_OK(render_settings_from_scene(ctx, &hy, &s), ctx);
    CHECK_OK(render_settings_validate(ctx, &hy, &s), ctx);
    CHECK(s.ao == ao_method_find("sao"));
    const float r = s.ao->get_radius(s.ao_params);
    CHECK(r > 0.1f && r < 1.5f);
    CHECK(s.mm_per_unit < SSS_DEFAULT_MM_PER_UNIT);
    CHECK_EQ_INT(s.volume.enabled, 1);
    CHECK_EQ_INT(s.volume.has_box, 1);
    const double blo[3] = {hy.bounds.lo.x, hy.bounds.lo.y, hy.bounds.lo.z};
    const double bhi[3] = {hy.bounds.hi.x, hy.bounds.hi.y, hy.bounds.hi.z};
    for (int c = 0; c < 3; c++)
        CHECK(s.volume.box_lo[c] >= blo[c] - 1e-3 && s.volume.box_hi[c] <= bhi[c] + 1e-3);
    CHECK(hy.camera_count >= 1 && !strcmp(hy.cameras[0].name, "default"));
    obs_scene_free(&hy);
    obs_context_destroy(ctx);
}
