/* render_settings.c: the scene-driven render's settings (render.h section 1): the defaults, the
 * scene's "obscura_render" JSON (docs/render.md, "Scene settings"), validation against the scene,
 * and the sidecar's "settings" object.
 *
 * One rule for every key: a key that is given replaces the value, a key that is not given keeps
 * it, and a key that is not in the schema is an error naming its path and the known keys (a
 * misspelt key must not silently become a default). The command line goes through the same parser
 * (cmd_render.c writes its flags as one "obscura_render" object), so a flag and a scene key are
 * checked by the same code and their errors read the same.
 *
 * Ranges: where a module already validates its parameters (the AO methods' params_validate,
 * sss_params_validate, vol_lv_params_validate, truth_sss_params_validate), that function is the
 * authority and its message is passed on with `where` and the key path in front; the parser here
 * only checks types (and the ranges of the AO parameter descriptors, as `obscura ao` does).
 * The keys the render owns (size, cameras, outputs, ambient, shadows, the volume's placement, the
 * references' sample counts) are range-checked here. */
#include "render.h"

#include "../io/io.h"
#include "../raster/raster.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Largest integer a JSON number (an IEEE double) carries exactly: 2^53. Seeds and sample counts
 * beyond it could not round-trip through the sidecar. */
#define RS_MAX_EXACT_INT 9007199254740992.0
#define RS_MAX_SHADOW_MAP_SIZE 16384       /* = RAST_MAX_DIM: one shadow map is one raster view */
#define RS_MIN_SHADOW_MAP_SIZE 16          /* as SSS_MIN_SIZE for the SSS light G-buffers */
#define RS_MAX_SYNTH_SIZE 1024             /* synth:NAME:N side; 1024^3 floats = 4 GiB */
#define RS_MAX_VOLUME_SAMPLES 1048576     /* the volume reference's samples per pixel (obs_limits' default max_samples) */

/* ------------------------------------------------------------------------------------------------
 * Outputs
 * ---------------------------------------------------------------------------------------------- */

/* By bit (render.h), NULL-terminated. */
static const char *const rs_output_names[] = {"beauty", "direct", "ambient", "ao",     "sss",
                                              "volume", "depth",  "normal",  "albedo", NULL};
#define RS_OUTPUT_COUNT 9

const char *render_output_name(unsigned bit)
{
    for (int i = 0; i < RS_OUTPUT_COUNT; i++)
        if (bit == (1u << i))
            return rs_output_names[i];
    return NULL;
}

unsigned render_output_from_name(const char *name)
{
    if (!name)
        return 0;
    for (int i = 0; i < RS_OUTPUT_COUNT; i++)
        if (!strcmp(name, rs_output_names[i]))
            return 1u << i;
    return 0;
}

/* ------------------------------------------------------------------------------------------------
 * Defaults
 * ---------------------------------------------------------------------------------------------- */

/* The reference AO follows the AO technique: its radius and its matched estimator (render.h). */
static void rs_sync_ref_ao(render_settings *s)
{
    if (!s->ao)
        return;
    if (s->ao->get_radius)
        s->ref_ao.radius = s->ao->get_radius(s->ao_params);
    truth_ao_estimator e;
    if (s->ao->truth_estimator && truth_ao_estimator_from_name(s->ao->truth_estimator(s->ao_params), &e))
        s->ref_ao.estimator = e;
}

render_settings render_settings_default(void)
{
    render_settings s;
    memset(&s, 0, sizeof s);
    s.width = 0;                               /* RENDER_DEFAULT_WIDTH at the camera's aspect */
    s.height = 0;
    s.camera_count = 0;                        /* every camera of the scene */
    s.outputs = RENDER_OUT_ALL;
    s.ao = ao_method_find("sao");              /* render.h: SAO [McGuire12] with its defaults */
    if (s.ao)
        s.ao->params_default(s.ao_params);
    for (int c = 0; c < 3; c++)
        s.ambient[c] = RENDER_DEFAULT_AMBIENT; /* AO_BLEND_AMBIENT */
    s.shadows = 1;
    s.shadow_map_size = RENDER_DEFAULT_SHADOW_MAP_SIZE;
    s.sss = sss_params_default();              /* the seed thesis' final code (sss.h) */
    s.mm_per_unit = SSS_DEFAULT_MM_PER_UNIT;   /* glTF units are metres */
    s.volume.enabled = 0;
    s.volume.light = -1;                       /* the first directional or point light */
    s.volume.lv = vol_lv_params_default();
    s.volume.rc = vol_rc_params_default();
    s.volume.mesh_shadows = 1;                 /* ours: meshes shadow the volume (docs/render.md) */
    s.seed = 0;
    s.reference = 0;
    s.ref_ao = truth_ao_params_default();
    s.ref_sss = truth_sss_params_default();
    s.ref_volume_samples = 256;                /* render.h: TRUTH_VOLUME_MC_DEFAULT_SAMPLES */
    rs_sync_ref_ao(&s);
    return s;
}

/* ------------------------------------------------------------------------------------------------
 * The JSON reader's helpers. Every message is "WHERE: PATH.KEY: what is wrong".
 * ---------------------------------------------------------------------------------------------- */

typedef struct rs_parse {
    obs_context *ctx;
    const char *where;
    const obs_scene *scene;
} rs_parse;

static obs_status rs_err(const rs_parse *P, obs_status st, const char *path, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));
static obs_status rs_err(const rs_parse *P, obs_status st, const char *path, const char *key, const char *fmt, ...)
{
    char msg[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return obs_error(P->ctx, st, "%s: %s%s%s: %s", P->where, path, key ? "." : "", key ? key : "", msg);
}

/* Unknown keys are errors; the message lists the known ones. */
static obs_status rs_check_keys(const rs_parse *P, const char *path, const cJSON *o, const char *const *known)
{
    for (const cJSON *it = o->child; it; it = it->next) {
        int ok = 0;
        for (const char *const *k = known; *k; k++)
            if (it->string && !strcmp(it->string, *k))
                ok = 1;
        if (!ok) {
            char list[512];
            size_t n = 0;
            list[0] = 0;
            for (const char *const *k = known; *k && n < sizeof list; k++)
                n += (size_t)snprintf(list + n, sizeof list - n, "%s%s", k == known ? "" : ", ", *k);
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, it->string ? it->string : "", "unknown key; known: %s",
                          list);
        }
    }
    /* Duplicate keys: cJSON keeps both and finds the first; a scene that says a thing twice is
     * ambiguous. */
    for (const cJSON *a = o->child; a; a = a->next)
        for (const cJSON *b = a->next; b; b = b->next)
            if (a->string && b->string && !strcmp(a->string, b->string))
                return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, a->string, "given twice");
    return OBS_STATUS_OK;
}

static const char *rs_type_name(const cJSON *v)
{
    if (cJSON_IsBool(v)) return "a boolean";
    if (cJSON_IsNull(v)) return "null";
    if (cJSON_IsNumber(v)) return "a number";
    if (cJSON_IsString(v)) return "a string";
    if (cJSON_IsArray(v)) return "an array";
    if (cJSON_IsObject(v)) return "an object";
    return "invalid";
}

/* A finite number in [lo, hi] (lo_open: lo excluded). */
static obs_status rs_number(const rs_parse *P, const char *path, const char *key, const cJSON *v, double lo, double hi,
                            int lo_open, double *out)
{
    if (!cJSON_IsNumber(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be a number (got %s)", rs_type_name(v));
    const double d = v->valuedouble;
    if (!isfinite(d))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be finite");
    if ((lo_open ? !(d > lo) : !(d >= lo)) || !(d <= hi)) {
        if (isinf(hi))
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be %s %g (got %g)", lo_open ? ">" : ">=", lo,
                          d);
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be in %s%g, %g] (got %g)", lo_open ? "(" : "[",
                      lo, hi, d);
    }
    *out = d;
    return OBS_STATUS_OK;
}

/* An integer in [lo, hi]. */
static obs_status rs_integer(const rs_parse *P, const char *path, const char *key, const cJSON *v, double lo, double hi,
                             int64_t *out)
{
    if (!cJSON_IsNumber(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be an integer (got %s)", rs_type_name(v));
    const double d = v->valuedouble;
    if (!isfinite(d) || d != floor(d))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be an integer (got %g)", d);
    if (d < lo || d > hi)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be in [%.17g, %.17g] (got %.17g)", lo, hi, d);
    *out = (int64_t)d;
    return OBS_STATUS_OK;
}

static obs_status rs_int(const rs_parse *P, const char *path, const char *key, const cJSON *v, int lo, int hi, int *out)
{
    int64_t x;
    obs_status st = rs_integer(P, path, key, v, lo, hi, &x);
    if (st == OBS_STATUS_OK)
        *out = (int)x;
    return st;
}

static obs_status rs_bool(const rs_parse *P, const char *path, const char *key, const cJSON *v, int *out)
{
    if (!cJSON_IsBool(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be true or false (got %s)", rs_type_name(v));
    *out = cJSON_IsTrue(v) ? 1 : 0;
    return OBS_STATUS_OK;
}

static obs_status rs_string(const rs_parse *P, const char *path, const char *key, const cJSON *v, size_t size,
                            char *out)
{
    if (!cJSON_IsString(v) || !v->valuestring)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be a string (got %s)", rs_type_name(v));
    if (strlen(v->valuestring) >= size)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "is longer than %zu bytes", size - 1);
    /* JSON text is UTF-8 (RFC 8259 section 8.1): other bytes would come back from the sidecar as
     * U+FFFD, a different (and longer) string (found by fuzz_render_settings) */
    if (!io_json_utf8_valid(v->valuestring))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "is not valid UTF-8");
    snprintf(out, size, "%s", v->valuestring);
    return OBS_STATUS_OK;
}

/* "a, b, c" from a NULL-terminated list. */
static void rs_list(const char *const *names, char *buf, size_t size)
{
    size_t n = 0;
    buf[0] = 0;
    for (int i = 0; names[i] && n < size; i++)
        n += (size_t)snprintf(buf + n, size - n, "%s%s", i ? ", " : "", names[i]);
}

/* A module's validate function run on a scratch context, its message passed on under our path. */
typedef obs_status (*rs_validate_fn)(obs_context *ctx, const void *p, const void *aux);
static obs_status rs_wrap_validate(const rs_parse *P, const char *path, rs_validate_fn fn, const void *p,
                                   const void *aux)
{
    obs_context *tmp = obs_context_create();
    if (!tmp)
        return obs_error(P->ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", P->where);
    obs_status st = fn(tmp, p, aux);
    if (st != OBS_STATUS_OK)
        st = obs_error(P->ctx, st, "%s: %s: %s", P->where, path, obs_context_last_error(tmp));
    obs_context_destroy(tmp);
    return st;
}
static obs_status rs_sss_validate(obs_context *c, const void *p, const void *aux)
{
    (void)aux;
    return sss_params_validate(c, (const sss_params *)p);
}
static obs_status rs_lv_validate(obs_context *c, const void *p, const void *aux)
{
    (void)aux;
    return vol_lv_params_validate(c, (const vol_lv_params *)p);
}
static obs_status rs_tsss_validate(obs_context *c, const void *p, const void *aux)
{
    (void)aux;
    return truth_sss_params_validate(c, (const truth_sss_params *)p);
}
/* aux: the ao_method */
static obs_status rs_ao_validate(obs_context *c, const void *p, const void *aux)
{
    return ((const ao_method *)aux)->params_validate(c, p);
}

/* ------------------------------------------------------------------------------------------------
 * Cameras
 * ---------------------------------------------------------------------------------------------- */

/* A camera by name (first match), else a decimal index (as cli_pick_camera). */
static obs_status rs_camera(const rs_parse *P, const char *path, const cJSON *v, int *out)
{
    const obs_scene *sc = P->scene;
    if (cJSON_IsString(v) && v->valuestring) {
        const char *name = v->valuestring;
        if (sc)
            for (uint32_t c = 0; c < sc->camera_count; c++)
                if (!strcmp(sc->cameras[c].name, name)) {
                    *out = (int)c;
                    return OBS_STATUS_OK;
                }
        char *end = NULL;
        long long idx = name[0] && isdigit((unsigned char)name[0]) ? strtoll(name, &end, 10) : -1;
        if (end && *end == '\0' && idx >= 0 && idx <= 0x7fffffff && (!sc || idx < (long long)sc->camera_count)) {
            *out = (int)idx;
            return OBS_STATUS_OK;
        }
        if (!sc)
            return rs_err(P, OBS_STATUS_NOT_FOUND, path, NULL,
                          "camera \"%s\": names need a scene to resolve against; give an index", name);
        char list[512];
        size_t n = 0;
        list[0] = 0;
        for (uint32_t c = 0; c < sc->camera_count && n < sizeof list; c++)
            n += (size_t)snprintf(list + n, sizeof list - n, "%s\"%s\"", c ? ", " : "", sc->cameras[c].name);
        return rs_err(P, OBS_STATUS_NOT_FOUND, path, NULL, "no camera named or numbered \"%s\" in %s (cameras: %s)",
                      name, sc->source[0] ? sc->source : "the scene", sc->camera_count ? list : "none");
    }
    int64_t idx;
    obs_status st = rs_integer(P, path, NULL, v, 0, RS_MAX_EXACT_INT, &idx);
    if (st != OBS_STATUS_OK)
        return st;
    if (sc && idx >= (int64_t)sc->camera_count)
        return rs_err(P, OBS_STATUS_NOT_FOUND, path, NULL, "camera %lld does not exist in %s (it has %u)",
                      (long long)idx, sc->source[0] ? sc->source : "the scene", sc->camera_count);
    if (idx > 0x7fffffff)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, NULL, "camera index %lld is too large", (long long)idx);
    *out = (int)idx;
    return OBS_STATUS_OK;
}

static obs_status rs_cameras(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.cameras";
    int cams[RENDER_MAX_CAMERAS], n = 0;
    if (cJSON_IsString(v) || cJSON_IsNumber(v)) {
        obs_status st = rs_camera(P, path, v, &cams[0]);
        if (st != OBS_STATUS_OK)
            return st;
        n = 1;
    } else if (cJSON_IsArray(v)) {
        const int count = cJSON_GetArraySize(v);
        if (count > RENDER_MAX_CAMERAS)
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "cameras",
                          "lists %d cameras; at most %d per scene", count, RENDER_MAX_CAMERAS);
        int i = 0;
        for (const cJSON *it = v->child; it; it = it->next, i++) {
            char p[64];
            snprintf(p, sizeof p, "%s[%d]", path, i);
            obs_status st = rs_camera(P, p, it, &cams[n]);
            if (st != OBS_STATUS_OK)
                return st;
            n++;
        }
    } else {
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "cameras",
                      "must be an array of camera names or indices (got %s)", rs_type_name(v));
    }
    s->camera_count = n; /* [] = every camera of the scene */
    memcpy(s->cameras, cams, sizeof(int) * (size_t)n);
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * The sections
 * ---------------------------------------------------------------------------------------------- */

static obs_status rs_outputs(const rs_parse *P, const cJSON *v, render_settings *s)
{
    if (cJSON_IsString(v) && v->valuestring && !strcmp(v->valuestring, "all")) {
        s->outputs = RENDER_OUT_ALL;
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsArray(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "outputs",
                      "must be \"all\" or an array of layer names (got %s)", rs_type_name(v));
    unsigned bits = 0;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, i++) {
        char p[64];
        snprintf(p, sizeof p, "obscura_render.outputs[%d]", i);
        unsigned b = cJSON_IsString(it) ? render_output_from_name(it->valuestring) : 0;
        if (!b) {
            char list[256];
            rs_list(rs_output_names, list, sizeof list);
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, p, NULL, "%s%s%s is not a layer (layers: %s)",
                          cJSON_IsString(it) ? "\"" : "", cJSON_IsString(it) ? it->valuestring : rs_type_name(it),
                          cJSON_IsString(it) ? "\"" : "", list);
        }
        bits |= b;
    }
    if (!bits)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "outputs", "asks for no layer");
    s->outputs = bits;
    return OBS_STATUS_OK;
}

/* A number stored as a float: a finite double above FLT_MAX would become +inf (found by
 * fuzz_render_settings), so it is refused here. st is rs_number's status for x. */
static obs_status rs_float_range(const rs_parse *P, const char *path, const char *key, obs_status st, double x)
{
    if (st == OBS_STATUS_OK && fabs(x) > FLT_MAX)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be at most %g (it is stored as a float; got %g)",
                      (double)FLT_MAX, x);
    return st;
}

static obs_status rs_rgb(const rs_parse *P, const char *path, const char *key, const cJSON *v, float out[3])
{
    double x = 0.0;
    if (cJSON_IsNumber(v)) {
        obs_status st = rs_number(P, path, key, v, 0.0, INFINITY, 0, &x);
        st = rs_float_range(P, path, key, st, x);
        if (st != OBS_STATUS_OK)
            return st;
        out[0] = out[1] = out[2] = (float)x;
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be a number or [r, g, b] (got %s)",
                      rs_type_name(v));
    float t[3];
    for (int c = 0; c < 3; c++) {
        char k[64];
        snprintf(k, sizeof k, "%s[%d]", key, c);
        obs_status st = rs_number(P, path, k, cJSON_GetArrayItem(v, c), 0.0, INFINITY, 0, &x);
        st = rs_float_range(P, path, k, st, x);
        if (st != OBS_STATUS_OK)
            return st;
        t[c] = (float)x;
    }
    memcpy(out, t, sizeof t);
    return OBS_STATUS_OK;
}

/* "ao": false | true | {"method": NAME, "preset": NAME, PARAM: VALUE, ...} */
static obs_status rs_ao(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.ao";
    if (cJSON_IsBool(v)) {
        if (cJSON_IsFalse(v)) {
            s->ao = NULL;
        } else if (!s->ao) {
            s->ao = ao_method_find("sao");
            if (s->ao)
                s->ao->params_default(s->ao_params);
        }
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsObject(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "ao",
                      "must be false, true or an object {\"method\": ..., parameters} (got %s)", rs_type_name(v));
    /* The method: given, else the current one, else SAO. A different method starts from its own
     * defaults; the same method keeps the values it has (keys given replace them). */
    const ao_method *m = s->ao ? s->ao : ao_method_find("sao");
    const cJSON *mv = cJSON_GetObjectItemCaseSensitive(v, "method");
    if (mv) {
        if (!cJSON_IsString(mv))
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "method", "must be a string (got %s)",
                          rs_type_name(mv));
        m = ao_method_find(mv->valuestring);
        if (!m) {
            const char *names[64];
            int n = 0;
            for (const ao_method *const *it = ao_methods(); *it && n < 63; it++)
                names[n++] = (*it)->name;
            names[n] = NULL;
            char list[512];
            rs_list(names, list, sizeof list);
            return rs_err(P, OBS_STATUS_NOT_FOUND, path, "method", "no AO method \"%s\" (methods: %s)",
                          mv->valuestring, list);
        }
    }
    if (!m)
        return rs_err(P, OBS_STATUS_INTERNAL, path, NULL, "the default AO method (sao) is not registered");
    _Alignas(16) unsigned char params[AO_PARAMS_MAX_SIZE];
    memset(params, 0, sizeof params); /* padding too: the sidecar round trip compares bytes */
    if (m == s->ao)
        memcpy(params, s->ao_params, sizeof params);
    else
        m->params_default(params);
    const cJSON *pv = cJSON_GetObjectItemCaseSensitive(v, "preset");
    if (pv) {
        if (!cJSON_IsString(pv))
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "preset", "must be a string (got %s)",
                          rs_type_name(pv));
        if (!m->params_preset || !m->params_preset(pv->valuestring, params)) {
            char list[512] = "none";
            if (m->preset_names && m->preset_names[0])
                rs_list(m->preset_names, list, sizeof list);
            return rs_err(P, OBS_STATUS_NOT_FOUND, path, "preset", "%s has no preset \"%s\" (presets: %s)", m->name,
                          pv->valuestring, list);
        }
    }
    /* The parameters, by the method's descriptors (as `obscura ao`'s flags). */
    unsigned char given[256];
    memset(given, 0, sizeof given);
    for (const cJSON *it = v->child; it; it = it->next) {
        const char *k = it->string ? it->string : "";
        if (!strcmp(k, "method") || !strcmp(k, "preset"))
            continue;
        const ao_param_desc *d = ao_method_param(m, k);
        if (!d) {
            char list[1024];
            size_t n = (size_t)snprintf(list, sizeof list, "method, preset");
            for (int i = 0; i < m->param_count && n < sizeof list; i++)
                n += (size_t)snprintf(list + n, sizeof list - n, ", %s", m->params[i].name);
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "unknown key (not a parameter of %s); known: %s",
                          m->name, list);
        }
        const int idx = (int)(d - m->params);
        if (idx >= 0 && idx < (int)sizeof given) {
            if (given[idx])
                return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "given twice");
            given[idx] = 1;
        }
        unsigned char *field = params + d->offset;
        if (d->type == AO_PARAM_FLOAT) {
            double x = 0.0;
            obs_status st = rs_number(P, path, k, it, d->min, d->max, 0, &x);
            if (st != OBS_STATUS_OK)
                return st;
            float f = (float)x;
            memcpy(field, &f, sizeof f);
        } else if (d->type == AO_PARAM_INT) {
            int x = 0;
            obs_status st = rs_int(P, path, k, it, (int)d->min, (int)d->max, &x);
            if (st != OBS_STATUS_OK)
                return st;
            memcpy(field, &x, sizeof x);
        } else if (d->type == AO_PARAM_BOOL) {
            int x = 0;
            obs_status st = rs_bool(P, path, k, it, &x);
            if (st != OBS_STATUS_OK)
                return st;
            memcpy(field, &x, sizeof x);
        } else {
            int c = 0;
            while (d->choices[c] && !(cJSON_IsString(it) && !strcmp(d->choices[c], it->valuestring)))
                c++;
            if (!d->choices[c]) {
                char list[512];
                rs_list(d->choices, list, sizeof list);
                return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "must be one of: %s", list);
            }
            memcpy(field, &c, sizeof c);
        }
    }
    if (m->params_adjust)
        m->params_adjust(params, given);
    if (m->params_validate) {
        obs_status st = rs_wrap_validate(P, path, rs_ao_validate, params, m);
        if (st != OBS_STATUS_OK)
            return st;
    }
    s->ao = m;
    memcpy(s->ao_params, params, sizeof params);
    return OBS_STATUS_OK;
}

/* "shadows": false | true | {"enabled": bool, "size": N} */
static obs_status rs_shadows(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.shadows";
    if (cJSON_IsBool(v)) {
        s->shadows = cJSON_IsTrue(v);
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsObject(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "shadows",
                      "must be false, true or an object {\"size\": N} (got %s)", rs_type_name(v));
    static const char *const known[] = {"enabled", "size", NULL};
    obs_status st = rs_check_keys(P, path, v, known);
    int enabled = 1, size = s->shadow_map_size;
    const cJSON *it;
    if (st == OBS_STATUS_OK && (it = cJSON_GetObjectItemCaseSensitive(v, "enabled")))
        st = rs_bool(P, path, "enabled", it, &enabled);
    if (st == OBS_STATUS_OK && (it = cJSON_GetObjectItemCaseSensitive(v, "size")))
        st = rs_int(P, path, "size", it, RS_MIN_SHADOW_MAP_SIZE, RS_MAX_SHADOW_MAP_SIZE, &size);
    if (st != OBS_STATUS_OK)
        return st;
    s->shadows = enabled;
    s->shadow_map_size = size;
    return OBS_STATUS_OK;
}

static int rs_sampler_from(const char *v, sss_sampler *o)
{
    /* The short names `obscura sss --sampler` takes, too. */
    if (!strcmp(v, "rr")) { *o = SSS_SAMPLER_RUSSIAN_ROULETTE; return 1; }
    if (!strcmp(v, "nearest")) { *o = SSS_SAMPLER_NEAREST_N_OF_M; return 1; }
    return sss_sampler_from_name(v, o);
}

/* "sss": {"mm_per_unit", "model", "K", "N", "M", "map_size", "light_map_size", "frames", "q",
 *         "disk_radius", "sampler", "visibility", "shadow_bias", "shrink_eps", "gamma",
 *         "specular", "specular_exponent"} */
static obs_status rs_sss(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.sss";
    if (!cJSON_IsObject(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "sss", "must be an object (got %s)",
                      rs_type_name(v));
    static const char *const known[] = {"mm_per_unit", "model", "K", "N", "M", "map_size", "light_map_size", "frames",
                                        "q", "disk_radius", "sampler", "visibility", "shadow_bias", "shrink_eps",
                                        "gamma", "specular", "specular_exponent", NULL};
    obs_status st = rs_check_keys(P, path, v, known);
    if (st != OBS_STATUS_OK)
        return st;
    sss_params p = s->sss;
    double mm = s->mm_per_unit;
    for (const cJSON *it = v->child; it && st == OBS_STATUS_OK; it = it->next) {
        const char *k = it->string;
        char name[64];
        if (!strcmp(k, "mm_per_unit")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 1, &mm);
        } else if (!strcmp(k, "K")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.K);
        } else if (!strcmp(k, "N")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.N);
        } else if (!strcmp(k, "M")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.M);
        } else if (!strcmp(k, "map_size")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.map_size);
        } else if (!strcmp(k, "light_map_size")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.light_map_size);
        } else if (!strcmp(k, "frames")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &p.frames);
        } else if (!strcmp(k, "q")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 1, &p.spread_q);
        } else if (!strcmp(k, "disk_radius")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &p.disk_radius);
        } else if (!strcmp(k, "shadow_bias")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &p.shadow_bias);
        } else if (!strcmp(k, "shrink_eps")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &p.shrink_eps);
        } else if (!strcmp(k, "gamma")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 1, &p.gamma);
        } else if (!strcmp(k, "specular_exponent")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &p.specular_exponent);
        } else if (!strcmp(k, "specular")) {
            st = rs_bool(P, path, k, it, &p.specular);
        } else if (!strcmp(k, "model")) {
            st = rs_string(P, path, k, it, sizeof name, name);
            if (st == OBS_STATUS_OK && !sss_model_from_name(name, &p.model))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "\"%s\" is not a model (directional, standard)",
                            name);
        } else if (!strcmp(k, "sampler")) {
            st = rs_string(P, path, k, it, sizeof name, name);
            if (st == OBS_STATUS_OK && !rs_sampler_from(name, &p.sampler))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "\"%s\" is not a sampler (exponential, russian-roulette or rr, nearest-n-of-m or nearest)",
                            name);
        } else if (!strcmp(k, "visibility")) {
            st = rs_string(P, path, k, it, sizeof name, name);
            if (st == OBS_STATUS_OK && !sss_visibility_from_name(name, &p.visibility))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "\"%s\" is not a visibility (product5, pcf3x3)",
                            name);
        }
    }
    if (st == OBS_STATUS_OK)
        st = rs_wrap_validate(P, path, rs_sss_validate, &p, NULL);
    if (st != OBS_STATUS_OK)
        return st;
    s->sss = p;
    s->mm_per_unit = mm;
    return OBS_STATUS_OK;
}

/* "synth:NAME" or "synth:NAME:N" (N in [2, RS_MAX_SYNTH_SIZE]), or a file name. */
static obs_status rs_check_source(const rs_parse *P, const char *path, const char *src)
{
    if (!src[0])
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "source", "is empty");
    if (strncmp(src, "synth:", 6) != 0)
        return OBS_STATUS_OK;
    const char *name = src + 6, *colon = strchr(name, ':');
    const size_t nl = colon ? (size_t)(colon - name) : strlen(name);
    if (nl == 0)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "source",
                      "\"%s\": synth:NAME or synth:NAME:N (NAME: bucky, slab, sphere, box; vol.h)", src);
    if (colon) {
        char *end = NULL;
        long long n = isdigit((unsigned char)colon[1]) ? strtoll(colon + 1, &end, 10) : -1;
        if (!end || *end || n < 2 || n > RS_MAX_SYNTH_SIZE)
            return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "source",
                          "\"%s\": the size after NAME: must be an integer in [2, %d]", src, RS_MAX_SYNTH_SIZE);
    }
    return OBS_STATUS_OK;
}

static int rs_ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    if (a < b)
        return 0;
    for (size_t i = 0; i < b; i++)
        if (tolower((unsigned char)s[a - b + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

/* A transfer function: a file ending in .json, else a preset (checked here). */
static obs_status rs_check_transfer(const rs_parse *P, const char *path, const char *tf)
{
    if (!tf[0])
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "transfer",
                      "is required with a volume (a preset: ct-skin, ct-bone, mri, bucky; or a .json file)");
    if (rs_ends_with(tf, ".json"))
        return OBS_STATUS_OK;
    obs_context *tmp = obs_context_create();
    if (!tmp)
        return obs_error(P->ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory", P->where);
    vol_tf t;
    memset(&t, 0, sizeof t);
    obs_status st = vol_tf_preset(tmp, tf, &t);
    vol_tf_free(&t);
    if (st != OBS_STATUS_OK)
        st = rs_err(P, OBS_STATUS_NOT_FOUND, path, "transfer", "%s (or a file ending in .json)",
                    obs_context_last_error(tmp));
    obs_context_destroy(tmp);
    return st;
}

static obs_status rs_vec3(const rs_parse *P, const char *path, const char *key, const cJSON *v, double out[3])
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, key, "must be [x, y, z] (got %s)", rs_type_name(v));
    for (int c = 0; c < 3; c++) {
        char k[64];
        snprintf(k, sizeof k, "%s[%d]", key, c);
        obs_status st = rs_number(P, path, k, cJSON_GetArrayItem(v, c), -INFINITY, INFINITY, 0, &out[c]);
        if (st != OBS_STATUS_OK)
            return st;
    }
    return OBS_STATUS_OK;
}

/* "volume": false | {"enabled", "source", "transfer", "box", "light", "shading", "step",
 *   "early_termination", "brick", "phong_ambient", "specular_exponent", "scale", "cone_angle",
 *   "blend_second", "eye_pass", "kappa", "mesh_shadows"} */
static obs_status rs_volume(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.volume";
    if (cJSON_IsFalse(v)) {
        s->volume.enabled = 0;
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsObject(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "volume",
                      "must be false or an object {\"source\": ..., \"transfer\": ...} (got %s)", rs_type_name(v));
    static const char *const known[] = {"enabled", "source", "transfer", "box", "light", "shading", "step",
                                        "early_termination", "brick", "phong_ambient", "specular_exponent", "scale",
                                        "cone_angle", "blend_second", "eye_pass", "kappa", "mesh_shadows", NULL};
    obs_status st = rs_check_keys(P, path, v, known);
    if (st != OBS_STATUS_OK)
        return st;
    render_volume_settings vs = s->volume;
    vs.enabled = 1;
    for (const cJSON *it = v->child; it && st == OBS_STATUS_OK; it = it->next) {
        const char *k = it->string;
        double x = 0.0;
        if (!strcmp(k, "enabled")) {
            st = rs_bool(P, path, k, it, &vs.enabled);
        } else if (!strcmp(k, "source")) {
            st = rs_string(P, path, k, it, sizeof vs.source, vs.source);
            if (st == OBS_STATUS_OK && vs.source[0])
                st = rs_check_source(P, path, vs.source);
        } else if (!strcmp(k, "transfer")) {
            st = rs_string(P, path, k, it, sizeof vs.transfer, vs.transfer);
            if (st == OBS_STATUS_OK && vs.transfer[0])
                st = rs_check_transfer(P, path, vs.transfer);
        } else if (!strcmp(k, "box")) {
            if (cJSON_IsFalse(it) || cJSON_IsNull(it)) {
                vs.has_box = 0;
                continue;
            }
            if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != 2)
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "must be [[x, y, z], [x, y, z]] (the low and high corners; got %s)", rs_type_name(it));
            double lo[3], hi[3];
            if (st == OBS_STATUS_OK)
                st = rs_vec3(P, path, "box[0]", cJSON_GetArrayItem(it, 0), lo);
            if (st == OBS_STATUS_OK)
                st = rs_vec3(P, path, "box[1]", cJSON_GetArrayItem(it, 1), hi);
            for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
                if (!(lo[c] < hi[c]))
                    st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                                "low corner must be below the high corner on every axis (axis %c: %g >= %g)", "xyz"[c],
                                lo[c], hi[c]);
            if (st == OBS_STATUS_OK) {
                vs.has_box = 1;
                memcpy(vs.box_lo, lo, sizeof lo);
                memcpy(vs.box_hi, hi, sizeof hi);
            }
        } else if (!strcmp(k, "light")) {
            st = rs_int(P, path, k, it, -1, 0x7fffffff, &vs.light);
            if (st == OBS_STATUS_OK && P->scene && vs.light >= (int)P->scene->light_count)
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "light %d does not exist in %s (it has %u)",
                            vs.light, P->scene->source[0] ? P->scene->source : "the scene", P->scene->light_count);
            /* the same rule as render_settings_validate (found by fuzz_render_settings: a spot light
             * was accepted here and refused there) */
            if (st == OBS_STATUS_OK && P->scene && vs.light >= 0 &&
                P->scene->lights[vs.light].type != OBS_LIGHT_DIRECTIONAL &&
                P->scene->lights[vs.light].type != OBS_LIGHT_POINT)
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "light %d (%s) is a spot light; the light volume takes directional and point lights",
                            vs.light, P->scene->lights[vs.light].name);
        } else if (!strcmp(k, "shading")) {
            char name[64];
            st = rs_string(P, path, k, it, sizeof name, name);
            if (st == OBS_STATUS_OK && !vol_shading_from_name(name, &vs.rc.shading))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "\"%s\" is not a shading (ea, phong, lightvolume)",
                            name);
        } else if (!strcmp(k, "step")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &vs.rc.step);
        } else if (!strcmp(k, "early_termination")) {
            st = rs_number(P, path, k, it, 0.0, 1.0, 1, &vs.rc.early_termination);
        } else if (!strcmp(k, "brick")) {
            st = rs_int(P, path, k, it, 0, 1024, &vs.rc.brick);
        } else if (!strcmp(k, "phong_ambient")) {
            st = rs_number(P, path, k, it, 0.0, 1.0, 0, &x);
            vs.rc.ambient = (float)x;
        } else if (!strcmp(k, "specular_exponent")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 0, &x);
            st = rs_float_range(P, path, k, st, x);
            vs.rc.specular_exponent = (float)x;
        } else if (!strcmp(k, "scale")) {
            st = rs_int(P, path, k, it, 0, 0x7fffffff, &vs.lv.scale);
        } else if (!strcmp(k, "cone_angle")) {
            st = rs_number(P, path, k, it, -INFINITY, INFINITY, 0, &vs.lv.cone_angle_deg);
        } else if (!strcmp(k, "blend_second")) {
            st = rs_bool(P, path, k, it, &vs.lv.blend_second);
        } else if (!strcmp(k, "eye_pass")) {
            st = rs_bool(P, path, k, it, &vs.lv.eye_pass);
        } else if (!strcmp(k, "mesh_shadows")) {
            st = rs_bool(P, path, k, it, &vs.mesh_shadows);
        } else if (!strcmp(k, "kappa")) {
            st = rs_number(P, path, k, it, -INFINITY, INFINITY, 0, &vs.lv.kappa);
        }
    }
    if (st == OBS_STATUS_OK)
        st = rs_wrap_validate(P, path, rs_lv_validate, &vs.lv, NULL);
    if (st == OBS_STATUS_OK && vs.enabled) {
        st = rs_check_source(P, path, vs.source);
        if (st == OBS_STATUS_OK)
            st = rs_check_transfer(P, path, vs.transfer);
    }
    if (st != OBS_STATUS_OK)
        return st;
    s->volume = vs;
    return OBS_STATUS_OK;
}

/* "reference": false | true | {"enabled", "ao_target_error", "ao_min_samples", "ao_max_samples",
 *   "sss_estimator", "sss_target_rel_error", "sss_min_samples", "sss_max_samples", "sss_batch",
 *   "sss_patch_radius", "volume_samples"} */
static obs_status rs_reference(const rs_parse *P, const cJSON *v, render_settings *s)
{
    const char *path = "obscura_render.reference";
    if (cJSON_IsBool(v)) {
        s->reference = cJSON_IsTrue(v);
        return OBS_STATUS_OK;
    }
    if (!cJSON_IsObject(v))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", "reference",
                      "must be false, true or an object (got %s)", rs_type_name(v));
    static const char *const known[] = {"enabled",         "ao_target_error",      "ao_min_samples",
                                        "ao_max_samples",  "sss_estimator",        "sss_target_rel_error",
                                        "sss_min_samples", "sss_max_samples",      "sss_batch",
                                        "sss_patch_radius", "volume_samples", NULL};
    obs_status st = rs_check_keys(P, path, v, known);
    if (st != OBS_STATUS_OK)
        return st;
    int enabled = 1, vsamples = s->ref_volume_samples;
    truth_ao_params ra = s->ref_ao;
    truth_sss_params rss = s->ref_sss;
    for (const cJSON *it = v->child; it && st == OBS_STATUS_OK; it = it->next) {
        const char *k = it->string;
        if (!strcmp(k, "enabled")) {
            st = rs_bool(P, path, k, it, &enabled);
        } else if (!strcmp(k, "ao_target_error")) {
            st = rs_number(P, path, k, it, 0.0, 1.0, 0, &ra.target_error);
        } else if (!strcmp(k, "ao_min_samples")) {
            st = rs_integer(P, path, k, it, 1, 2147483648.0, &ra.min_samples);
        } else if (!strcmp(k, "ao_max_samples")) {
            st = rs_integer(P, path, k, it, 1, 2147483648.0, &ra.max_samples);
        } else if (!strcmp(k, "sss_estimator")) {
            char name[64];
            st = rs_string(P, path, k, it, sizeof name, name);
            if (st == OBS_STATUS_OK && !truth_sss_estimator_from_name(name, &rss.estimator))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "\"%s\" is not an estimator (brute-force, random-walk)", name);
        } else if (!strcmp(k, "sss_target_rel_error")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 1, &rss.target_rel_error);
        } else if (!strcmp(k, "sss_min_samples")) {
            st = rs_integer(P, path, k, it, 1, RS_MAX_EXACT_INT, &rss.min_samples);
        } else if (!strcmp(k, "sss_max_samples")) {
            st = rs_integer(P, path, k, it, 1, RS_MAX_EXACT_INT, &rss.max_samples);
        } else if (!strcmp(k, "sss_batch")) {
            st = rs_int(P, path, k, it, 1, 0x7fffffff, &rss.batch);
        } else if (!strcmp(k, "sss_patch_radius")) {
            st = rs_number(P, path, k, it, 0.0, INFINITY, 1, &rss.patch_radius);
        } else if (!strcmp(k, "volume_samples")) {
            st = rs_int(P, path, k, it, 8, RS_MAX_VOLUME_SAMPLES, &vsamples);
            if (st == OBS_STATUS_OK && vsamples % 8 != 0)
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "must be a multiple of 8 (the volume reference's replicates; got %d)", vsamples);
        }
    }
    /* truth_ao has no separate validate: its sample counts must be multiples of the batch, the
     * maximum at least the minimum (truth.h). */
    if (st == OBS_STATUS_OK && (ra.min_samples % ra.batch != 0 || ra.max_samples % ra.batch != 0))
        st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, ra.min_samples % ra.batch ? "ao_min_samples" : "ao_max_samples",
                    "must be a multiple of the reference AO's batch (%d samples)", ra.batch);
    if (st == OBS_STATUS_OK && ra.max_samples < ra.min_samples)
        st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, "ao_max_samples", "must be >= ao_min_samples (%lld)",
                    (long long)ra.min_samples);
    if (st == OBS_STATUS_OK)
        st = rs_wrap_validate(P, path, rs_tsss_validate, &rss, NULL);
    if (st != OBS_STATUS_OK)
        return st;
    s->reference = enabled;
    s->ref_ao = ra;
    s->ref_sss = rss;
    s->ref_volume_samples = vsamples;
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * The object
 * ---------------------------------------------------------------------------------------------- */

static obs_status rs_apply_object(const rs_parse *P, const cJSON *o, render_settings *out)
{
    if (!cJSON_IsObject(o))
        return rs_err(P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render", NULL, "must be a JSON object (got %s)",
                      rs_type_name(o));
    static const char *const known[] = {"size",   "cameras", "outputs", "ambient",   "seed", "ao",
                                        "shadows", "sss",    "volume",  "reference", NULL};
    obs_status st = rs_check_keys(P, "obscura_render", o, known);
    if (st != OBS_STATUS_OK)
        return st;
    /* Work on a copy: on an error, *out is unchanged. */
    render_settings s = *out;
    const char *path = "obscura_render";
    for (const cJSON *it = o->child; it && st == OBS_STATUS_OK; it = it->next) {
        const char *k = it->string;
        if (!strcmp(k, "size")) {
            if (!cJSON_IsArray(it) || cJSON_GetArraySize(it) != 2) {
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k, "must be [width, height] (got %s)",
                            rs_type_name(it));
                break;
            }
            int w = 0, h = 0;
            st = rs_int(P, path, "size[0]", cJSON_GetArrayItem(it, 0), 0, RAST_MAX_DIM, &w);
            if (st == OBS_STATUS_OK)
                st = rs_int(P, path, "size[1]", cJSON_GetArrayItem(it, 1), 0, RAST_MAX_DIM, &h);
            if (st == OBS_STATUS_OK && ((w == 0) != (h == 0)))
                st = rs_err(P, OBS_STATUS_INVALID_ARGUMENT, path, k,
                            "give both sides in [1, %d], or [0, 0] for %d wide at the camera's aspect", RAST_MAX_DIM,
                            RENDER_DEFAULT_WIDTH);
            s.width = w;
            s.height = h;
        } else if (!strcmp(k, "cameras")) {
            st = rs_cameras(P, it, &s);
        } else if (!strcmp(k, "outputs")) {
            st = rs_outputs(P, it, &s);
        } else if (!strcmp(k, "ambient")) {
            st = rs_rgb(P, path, k, it, s.ambient);
        } else if (!strcmp(k, "seed")) {
            int64_t seed;
            st = rs_integer(P, path, k, it, 0, RS_MAX_EXACT_INT, &seed);
            s.seed = (uint64_t)seed;
        } else if (!strcmp(k, "ao")) {
            st = rs_ao(P, it, &s);
        } else if (!strcmp(k, "shadows")) {
            st = rs_shadows(P, it, &s);
        } else if (!strcmp(k, "sss")) {
            st = rs_sss(P, it, &s);
        } else if (!strcmp(k, "volume")) {
            st = rs_volume(P, it, &s);
        } else if (!strcmp(k, "reference")) {
            st = rs_reference(P, it, &s);
        }
    }
    if (st != OBS_STATUS_OK)
        return st;
    rs_sync_ref_ao(&s);
    *out = s;
    return OBS_STATUS_OK;
}

obs_status render_settings_apply_json(obs_context *ctx, const char *json, const char *where, const obs_scene *scene,
                                      render_settings *s)
{
    const char *w = where ? where : "obscura_render";
    if (!json || !s)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: render_settings_apply_json: NULL argument", w);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(json, &end, 1);
    if (!root)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: obscura_render is not valid JSON (at byte %td, near \"%.20s\")",
                         w, end ? end - json : (ptrdiff_t)0, end ? end : "");
    rs_parse P = {ctx, w, scene};
    obs_status st = rs_apply_object(&P, root, s);
    cJSON_Delete(root);
    return st;
}

obs_status render_settings_from_scene(obs_context *ctx, const obs_scene *scene, render_settings *s)
{
    if (!scene || !s)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render_settings_from_scene: NULL argument");
    const char *w = scene->source[0] ? scene->source : "scene";
    if (!scene->extras_json)
        return OBS_STATUS_OK;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(scene->extras_json, &end, 0);
    if (!root)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: the scene's extras are not valid JSON (at byte %td)", w,
                         end ? end - scene->extras_json : (ptrdiff_t)0);
    /* glTF extras may be any JSON value; only an object carries "obscura_render". The scene's
     * other keys are not ours. */
    const cJSON *o = cJSON_IsObject(root) ? cJSON_GetObjectItemCaseSensitive(root, "obscura_render") : NULL;
    obs_status st = OBS_STATUS_OK;
    if (o) {
        rs_parse P = {ctx, w, scene};
        st = rs_apply_object(&P, o, s);
    }
    cJSON_Delete(root);
    return st;
}

/* ------------------------------------------------------------------------------------------------
 * Validation against the scene
 * ---------------------------------------------------------------------------------------------- */

obs_status render_settings_validate(obs_context *ctx, const obs_scene *scene, const render_settings *s)
{
    if (!s)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render settings: NULL");
    rs_parse P = {ctx, scene && scene->source[0] ? scene->source : "render settings", scene};
    const char *path = "obscura_render";
    if (s->width < 0 || s->height < 0 || s->width > RAST_MAX_DIM || s->height > RAST_MAX_DIM ||
        ((s->width == 0) != (s->height == 0)))
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "size",
                      "%dx%d: both sides in [1, %d], or 0x0 for the default", s->width, s->height, RAST_MAX_DIM);
    if (s->camera_count < 0 || s->camera_count > RENDER_MAX_CAMERAS)
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "cameras", "%d cameras; at most %d", s->camera_count,
                      RENDER_MAX_CAMERAS);
    for (int i = 0; i < s->camera_count; i++)
        if (s->cameras[i] < 0 || (scene && s->cameras[i] >= (int)scene->camera_count))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "cameras", "camera %d does not exist (the scene has %u)",
                          s->cameras[i], scene ? scene->camera_count : 0u);
    if (!s->outputs || (s->outputs & ~(unsigned)RENDER_OUT_ALL))
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "outputs", "0x%x is not a set of layers", s->outputs);
    for (int c = 0; c < 3; c++)
        if (!(isfinite(s->ambient[c]) && s->ambient[c] >= 0.0f))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "ambient", "must be finite and >= 0");
    if (s->ao && s->ao->params_validate) {
        obs_status st = rs_wrap_validate(&P, "obscura_render.ao", rs_ao_validate, s->ao_params, s->ao);
        if (st != OBS_STATUS_OK)
            return st;
    }
    if (s->shadows != 0 && s->shadows != 1)
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, path, "shadows", "must be 0 or 1");
    if (s->shadow_map_size < RS_MIN_SHADOW_MAP_SIZE || s->shadow_map_size > RS_MAX_SHADOW_MAP_SIZE)
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.shadows", "size", "%d is not in [%d, %d]",
                      s->shadow_map_size, RS_MIN_SHADOW_MAP_SIZE, RS_MAX_SHADOW_MAP_SIZE);
    obs_status st = rs_wrap_validate(&P, "obscura_render.sss", rs_sss_validate, &s->sss, NULL);
    if (st != OBS_STATUS_OK)
        return st;
    if (!(isfinite(s->mm_per_unit) && s->mm_per_unit > 0.0))
        return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.sss", "mm_per_unit", "must be finite and > 0");
    const render_volume_settings *v = &s->volume;
    if (v->enabled) {
        const char *vp = "obscura_render.volume";
        if (memchr(v->source, 0, sizeof v->source) == NULL || memchr(v->transfer, 0, sizeof v->transfer) == NULL)
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, NULL, "source or transfer is not terminated");
        if ((st = rs_check_source(&P, vp, v->source)) != OBS_STATUS_OK)
            return st;
        if ((st = rs_check_transfer(&P, vp, v->transfer)) != OBS_STATUS_OK)
            return st;
        if (v->has_box)
            for (int c = 0; c < 3; c++)
                if (!(isfinite(v->box_lo[c]) && isfinite(v->box_hi[c]) && v->box_lo[c] < v->box_hi[c]))
                    return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "box",
                                  "axis %c: the corners must be finite with low < high", "xyz"[c]);
        if (v->light < -1)
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "light", "%d: an index >= 0, or -1", v->light);
        if (scene && v->light >= 0) {
            if (v->light >= (int)scene->light_count)
                return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "light", "light %d does not exist (the scene has %u)",
                              v->light, scene->light_count);
            const obs_light_type t = scene->lights[v->light].type;
            if (t != OBS_LIGHT_DIRECTIONAL && t != OBS_LIGHT_POINT)
                return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "light",
                              "light %d (%s) is a spot light; the light volume takes directional and point lights",
                              v->light, scene->lights[v->light].name);
        }
        if ((st = rs_wrap_validate(&P, vp, rs_lv_validate, &v->lv, NULL)) != OBS_STATUS_OK)
            return st;
        const vol_rc_params *rc = &v->rc;
        if ((unsigned)rc->shading >= VOL_SHADING_COUNT)
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "shading", "is not a shading mode");
        if (!(isfinite(rc->step) && rc->step >= 0.0))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "step", "must be finite and >= 0");
        if (!(rc->early_termination > 0.0 && rc->early_termination <= 1.0))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "early_termination", "must be in (0, 1]");
        if (rc->brick < 0)
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "brick", "must be >= 0");
        if (!(rc->ambient >= 0.0f && rc->ambient <= 1.0f))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "phong_ambient", "must be in [0, 1]");
        if (!(isfinite(rc->specular_exponent) && rc->specular_exponent >= 0.0f))
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, vp, "specular_exponent", "must be finite and >= 0");
    }
    if (s->reference) {
        if ((st = rs_wrap_validate(&P, "obscura_render.reference", rs_tsss_validate, &s->ref_sss, NULL)) != OBS_STATUS_OK)
            return st;
        if (s->ref_volume_samples < 8 || s->ref_volume_samples > RS_MAX_VOLUME_SAMPLES || s->ref_volume_samples % 8)
            return rs_err(&P, OBS_STATUS_INVALID_ARGUMENT, "obscura_render.reference", "volume_samples",
                          "%d is not a multiple of 8 in [8, %d]", s->ref_volume_samples, RS_MAX_VOLUME_SAMPLES);
    }
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * The sidecar: the same schema, every key written, so that applying it to the defaults gives the
 * same settings back (doubles with 17 significant digits; floats fit in io_json's 9).
 * ---------------------------------------------------------------------------------------------- */

static void rs_json_double(io_json *j, const char *key, double v)
{
    char buf[40];
    if (!isfinite(v)) {
        io_json_null(j, key);
        return;
    }
    snprintf(buf, sizeof buf, "%.17g", v);
    io_json_raw(j, key, buf);
}

static void rs_json_vec3(io_json *j, const char *key, const double v[3])
{
    io_json_begin_array(j, key);
    for (int c = 0; c < 3; c++)
        rs_json_double(j, NULL, v[c]);
    io_json_end_array(j);
}

void render_settings_to_json(const render_settings *s, struct io_json *j)
{
    if (!s || !j)
        return;
    io_json_begin_object(j, "settings");
    io_json_begin_array(j, "size");
    io_json_int(j, NULL, s->width);
    io_json_int(j, NULL, s->height);
    io_json_end_array(j);
    io_json_begin_array(j, "cameras");
    for (int i = 0; i < s->camera_count && i < RENDER_MAX_CAMERAS; i++)
        io_json_int(j, NULL, s->cameras[i]);
    io_json_end_array(j);
    io_json_begin_array(j, "outputs");
    for (int i = 0; i < RS_OUTPUT_COUNT; i++)
        if (s->outputs & (1u << i))
            io_json_string(j, NULL, rs_output_names[i]);
    io_json_end_array(j);
    io_json_floats(j, "ambient", s->ambient, 3);
    io_json_int(j, "seed", (int64_t)s->seed);
    if (!s->ao) {
        io_json_bool(j, "ao", 0);
    } else {
        io_json_begin_object(j, "ao");
        io_json_string(j, "method", s->ao->name);
        for (int i = 0; i < s->ao->param_count; i++) {
            const ao_param_desc *d = &s->ao->params[i];
            const unsigned char *field = s->ao_params + d->offset;
            int iv;
            float fv;
            if (d->type == AO_PARAM_FLOAT) {
                memcpy(&fv, field, sizeof fv);
                io_json_number(j, d->name, fv);
            } else if (d->type == AO_PARAM_INT) {
                memcpy(&iv, field, sizeof iv);
                io_json_int(j, d->name, iv);
            } else if (d->type == AO_PARAM_BOOL) {
                memcpy(&iv, field, sizeof iv);
                io_json_bool(j, d->name, iv);
            } else {
                memcpy(&iv, field, sizeof iv);
                int n = 0;
                while (d->choices[n])
                    n++;
                io_json_string(j, d->name, iv >= 0 && iv < n ? d->choices[iv] : "?");
            }
        }
        io_json_end_object(j);
    }
    io_json_begin_object(j, "shadows");
    io_json_bool(j, "enabled", s->shadows);
    io_json_int(j, "size", s->shadow_map_size);
    io_json_end_object(j);

    const sss_params *p = &s->sss;
    io_json_begin_object(j, "sss");
    rs_json_double(j, "mm_per_unit", s->mm_per_unit);
    io_json_string(j, "model", sss_model_name(p->model));
    io_json_int(j, "K", p->K);
    io_json_int(j, "N", p->N);
    io_json_int(j, "M", p->M);
    io_json_int(j, "map_size", p->map_size);
    io_json_int(j, "light_map_size", p->light_map_size);
    io_json_int(j, "frames", p->frames);
    rs_json_double(j, "q", p->spread_q);
    rs_json_double(j, "disk_radius", p->disk_radius);
    io_json_string(j, "sampler", sss_sampler_name(p->sampler));
    io_json_string(j, "visibility", sss_visibility_name(p->visibility));
    rs_json_double(j, "shadow_bias", p->shadow_bias);
    rs_json_double(j, "shrink_eps", p->shrink_eps);
    rs_json_double(j, "gamma", p->gamma);
    io_json_bool(j, "specular", p->specular);
    rs_json_double(j, "specular_exponent", p->specular_exponent);
    io_json_end_object(j);

    const render_volume_settings *v = &s->volume;
    io_json_begin_object(j, "volume");
    io_json_bool(j, "enabled", v->enabled);
    io_json_string(j, "source", v->source);
    io_json_string(j, "transfer", v->transfer);
    if (v->has_box) {
        io_json_begin_array(j, "box");
        rs_json_vec3(j, NULL, v->box_lo);
        rs_json_vec3(j, NULL, v->box_hi);
        io_json_end_array(j);
    } else {
        io_json_null(j, "box");
    }
    io_json_int(j, "light", v->light);
    io_json_string(j, "shading", vol_shading_name(v->rc.shading));
    rs_json_double(j, "step", v->rc.step);
    rs_json_double(j, "early_termination", v->rc.early_termination);
    io_json_int(j, "brick", v->rc.brick);
    io_json_number(j, "phong_ambient", v->rc.ambient);
    io_json_number(j, "specular_exponent", v->rc.specular_exponent);
    io_json_int(j, "scale", v->lv.scale);
    rs_json_double(j, "cone_angle", v->lv.cone_angle_deg);
    io_json_bool(j, "blend_second", v->lv.blend_second);
    io_json_bool(j, "eye_pass", v->lv.eye_pass);
    rs_json_double(j, "kappa", v->lv.kappa);
    io_json_bool(j, "mesh_shadows", v->mesh_shadows);
    io_json_end_object(j);

    io_json_begin_object(j, "reference");
    io_json_bool(j, "enabled", s->reference);
    rs_json_double(j, "ao_target_error", s->ref_ao.target_error);
    io_json_int(j, "ao_min_samples", s->ref_ao.min_samples);
    io_json_int(j, "ao_max_samples", s->ref_ao.max_samples);
    io_json_string(j, "sss_estimator", truth_sss_estimator_name(s->ref_sss.estimator));
    rs_json_double(j, "sss_target_rel_error", s->ref_sss.target_rel_error);
    io_json_int(j, "sss_min_samples", s->ref_sss.min_samples);
    io_json_int(j, "sss_max_samples", s->ref_sss.max_samples);
    io_json_int(j, "sss_batch", s->ref_sss.batch);
    rs_json_double(j, "sss_patch_radius", s->ref_sss.patch_radius);
    io_json_int(j, "volume_samples", s->ref_volume_samples);
    io_json_end_object(j);
    io_json_end_object(j);
}
