/* fuzz_render_settings.c: render_settings_apply_json (docs/render.md, "Scene settings") on
 * arbitrary bytes, against a small scene with three cameras and two lights. Invariants:
 *   - the status is OK, PARSE_ERROR, INVALID_ARGUMENT or NOT_FOUND, and an error has a message;
 *   - an error leaves the settings byte for byte as they were;
 *   - settings that were accepted pass render_settings_validate against the same scene, and their
 *     sidecar object (render_settings_to_json) is valid JSON that applies to the defaults without
 *     an error and writes the same text again (the schema round-trips).
 * The input is the text of one "obscura_render" object (NUL-terminated copy). */
#include "fuzz.h"

#include "io/io.h"
#include "render/render.h"

#include <stdlib.h>
#include <string.h>

int obs_fuzz_render_settings(const uint8_t *data, size_t size);

static void fz_scene(obs_scene *sc)
{
    obs_scene_init(sc);
    snprintf(sc->source, sizeof sc->source, "fuzz.glb");
    sc->cameras = (obs_camera *)calloc(3, sizeof(obs_camera));
    sc->lights = (obs_light *)calloc(2, sizeof(obs_light));
    fuzz_require(sc->cameras && sc->lights, "allocation");
    sc->camera_count = 3;
    static const char *names[3] = {"front", "side", "1"};
    for (int c = 0; c < 3; c++) {
        sc->cameras[c] = obs_camera_look_at(obs_v3(0, 0, 5), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.8f, 0.1f, 100.0f);
        snprintf(sc->cameras[c].name, sizeof sc->cameras[c].name, "%s", names[c]);
    }
    sc->light_count = 2;
    sc->lights[0].type = OBS_LIGHT_DIRECTIONAL;
    sc->lights[1].type = OBS_LIGHT_SPOT;
}

/* The "settings" object's text of s (malloc'd). */
static char *fz_settings_text(const render_settings *s)
{
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    render_settings_to_json(s, &j);
    io_json_end_object(&j);
    fuzz_require(!j.failed && j.buf != NULL, "render_settings_to_json: a valid document");
    const char *open = strchr(strchr(j.buf, ':'), '{'), *close = strrchr(j.buf, '}');
    fuzz_require(open && close && close > open, "render_settings_to_json: one object \"settings\"");
    char *t = strndup(open, (size_t)(close - open));
    fuzz_require(t != NULL, "allocation");
    io_json_free(&j);
    return t;
}

int obs_fuzz_render_settings(const uint8_t *data, size_t size)
{
    if (size > 1 << 16)
        return 0;
    char *text = (char *)malloc(size + 1);
    fuzz_require(text != NULL, "allocation");
    memcpy(text, data, size);
    text[size] = 0;
    obs_context *ctx = fuzz_context();
    obs_scene sc;
    fz_scene(&sc);
    render_settings s = render_settings_default(), before;
    memcpy(&before, &s, sizeof s);
    obs_status st = render_settings_apply_json(ctx, text, "fuzz", &sc, &s);
    fuzz_require(st == OBS_STATUS_OK || st == OBS_STATUS_PARSE_ERROR || st == OBS_STATUS_INVALID_ARGUMENT ||
                     st == OBS_STATUS_NOT_FOUND,
                 "render_settings_apply_json: a documented status");
    if (st != OBS_STATUS_OK) {
        fuzz_require(obs_context_last_error(ctx)[0] != 0, "an error has a message");
        fuzz_require(memcmp(&s, &before, sizeof s) == 0, "an error leaves the settings unchanged");
    } else {
        fuzz_require(render_settings_validate(ctx, &sc, &s) == OBS_STATUS_OK, "accepted settings validate");
        char *t1 = fz_settings_text(&s);
        render_settings back = render_settings_default();
        fuzz_require(render_settings_apply_json(ctx, t1, "sidecar", &sc, &back) == OBS_STATUS_OK,
                     "the sidecar's settings apply");
        char *t2 = fz_settings_text(&back);
        fuzz_require(strcmp(t1, t2) == 0, "the sidecar's settings round-trip");
        free(t1);
        free(t2);
    }
    obs_scene_free(&sc);
    obs_context_destroy(ctx);
    free(text);
    return 0;
}
