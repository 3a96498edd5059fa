/* sss_material.c: Jensen et al. 2001's measured materials as presets, material validation, and
 * the glTF extras schema "obscura_sss" (docs/sss/model.md "Materials").
 *
 * The table is [Jensen01] Fig. 5(b) as sss.md 2 gives it (extracted from the paper's PDF and
 * checked against pbrt-v3's SubsurfaceParameterTable). Jensen measured sigma_s' directly (g
 * unknown), so a preset has sigma_s = sigma_s' and g = 0, as pbrt-v3 does. Known corrupted copies
 * (sss.md 2) are NOT used: Chicken1 sigma_a R = 0.015 (not 0.0015), Chicken2 sigma_a R = 0.018
 * (not 0.0018), Apple sigma_a B = 0.046 (not 0.0046). data/materials/jensen2001.json holds the
 * same numbers (test sss_presets_match_the_json_table). */
#include "sss_internal.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <stddef.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

typedef struct sss_preset_row {
    sss_material m;
    double rd[3]; /* Jensen's measured total diffuse reflectance, per channel */
} sss_preset_row;

/* name, sigma_s' (mm^-1) R G B, sigma_a (mm^-1) R G B, g, eta; measured R_d R G B  [Jensen01] Fig. 5(b) */
static const sss_preset_row sss_presets[SSS_PRESET_COUNT] = {
    {{"Apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}, 0.0, 1.3}, {0.85, 0.84, 0.53}},
    {{"Chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}, 0.0, 1.3}, {0.31, 0.15, 0.10}},
    {{"Chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}, 0.0, 1.3}, {0.32, 0.16, 0.10}},
    {{"Cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}, 0.0, 1.3}, {0.98, 0.90, 0.73}},
    {{"Ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}, 0.0, 1.3}, {0.16, 0.01, 0.00}},
    {{"Marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}, 0.0, 1.5}, {0.83, 0.79, 0.75}},
    {{"Potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}, 0.0, 1.3}, {0.77, 0.62, 0.21}},
    {{"Skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, 0.0, 1.3}, {0.81, 0.81, 0.69}},
    {{"Skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, 0.0, 1.3}, {0.44, 0.22, 0.13}},
    {{"Skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}, 0.0, 1.3}, {0.63, 0.44, 0.34}},
    {{"Spectralon", {11.6, 20.4, 14.9}, {0.00, 0.00, 0.00}, 0.0, 1.3}, {1.00, 1.00, 1.00}},
    {{"Wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}, 0.0, 1.3}, {0.91, 0.88, 0.76}},
};

int sss_preset_count(void) { return SSS_PRESET_COUNT; }

const sss_material *sss_preset(int i)
{
    return (i >= 0 && i < SSS_PRESET_COUNT) ? &sss_presets[i].m : NULL;
}

int sss_preset_measured_rd(int i, double rd[3])
{
    if (i < 0 || i >= SSS_PRESET_COUNT || !rd)
        return 0;
    memcpy(rd, sss_presets[i].rd, sizeof sss_presets[i].rd);
    return 1;
}

static int streq_nocase(const char *a, const char *b)
{
    for (; *a && *b; a++, b++)
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b))
            return 0;
    return *a == *b;
}

/* "Apple, Chicken1, ..." */
static void preset_list(char *buf, size_t size)
{
    size_t o = 0;
    buf[0] = 0;
    for (int i = 0; i < SSS_PRESET_COUNT && o < size; i++) {
        int k = snprintf(buf + o, size - o, "%s%s", i ? ", " : "", sss_presets[i].m.name);
        if (k < 0)
            break;
        o += (size_t)k;
    }
}

obs_status sss_material_find(obs_context *ctx, const char *name, sss_material *out)
{
    if (!name || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_material_find: NULL argument");
    for (int i = 0; i < SSS_PRESET_COUNT; i++)
        if (streq_nocase(name, sss_presets[i].m.name)) {
            *out = sss_presets[i].m;
            return OBS_STATUS_OK;
        }
    char list[512];
    preset_list(list, sizeof list);
    return obs_error(ctx, OBS_STATUS_NOT_FOUND, "no SSS material preset named \"%s\" (presets: %s)", name, list);
}

obs_status sss_material_validate(obs_context *ctx, const sss_material *m, const char *where)
{
    const char *w = where ? where : "material";
    if (!m)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: NULL material", w);
    static const char *const ch[3] = {"R", "G", "B"};
    for (int j = 0; j < 3; j++) {
        if (!isfinite(m->sigma_s[j]) || m->sigma_s[j] < 0.0)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: material \"%s\": sigma_s[%d] (%s) must be finite and >= 0 (got %g)", w, m->name, j,
                             ch[j], m->sigma_s[j]);
        if (!isfinite(m->sigma_a[j]) || m->sigma_a[j] < 0.0)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: material \"%s\": sigma_a[%d] (%s) must be finite and >= 0 (got %g)", w, m->name, j,
                             ch[j], m->sigma_a[j]);
        if (!(m->sigma_s[j] + m->sigma_a[j] > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: material \"%s\": sigma_t[%d] (%s) = sigma_s + sigma_a must be > 0", w, m->name, j,
                             ch[j]);
    }
    if (!isfinite(m->g) || !(m->g > -1.0 && m->g < 1.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: material \"%s\": g must be in (-1, 1) (got %g)", w,
                         m->name, m->g);
    if (!isfinite(m->eta) || !(m->eta > 0.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: material \"%s\": eta must be > 0 and finite (got %g)",
                         w, m->name, m->eta);
    return OBS_STATUS_OK;
}

/* ---- The glTF extras schema "obscura_sss" ------------------------------------------------------------ */

static obs_status read_rgb(obs_context *ctx, const cJSON *o, const char *key, const char *w, double out[3])
{
    const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.%s must be an array of 3 numbers", w,
                         key);
    for (int j = 0; j < 3; j++) {
        const cJSON *v = cJSON_GetArrayItem(a, j);
        if (!cJSON_IsNumber(v))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.%s[%d] must be a number", w, key, j);
        const double d = v->valuedouble;
        if (!isfinite(d) || d < 0.0)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss.%s[%d] must be finite and >= 0 (got %g)", w, key, j, d);
        out[j] = d;
    }
    return OBS_STATUS_OK;
}

static obs_status read_number(obs_context *ctx, const cJSON *o, const char *key, const char *w, double *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.%s must be a finite number", w, key);
    *out = v->valuedouble;
    return OBS_STATUS_OK;
}

static obs_status parse_sss_object(obs_context *ctx, const cJSON *o, const char *w, sss_material *out)
{
    static const char *const known[] = {"preset", "name", "sigma_s_prime", "sigma_s", "g", "sigma_a", "eta"};
    if (!cJSON_IsObject(o))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss must be a JSON object", w);
    /* Unknown keys are an error (a misspelt key must not silently become a default). */
    for (const cJSON *it = o->child; it; it = it->next) {
        int ok = 0;
        for (size_t k = 0; k < sizeof known / sizeof known[0]; k++)
            if (it->string && !strcmp(it->string, known[k]))
                ok = 1;
        if (!ok)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss: unknown key \"%s\" (known: preset, name, sigma_s_prime, sigma_s, g, "
                             "sigma_a, eta)",
                             w, it->string ? it->string : "");
    }
    const int has_preset = cJSON_HasObjectItem(o, "preset"), has_ssp = cJSON_HasObjectItem(o, "sigma_s_prime"),
              has_ss = cJSON_HasObjectItem(o, "sigma_s"), has_g = cJSON_HasObjectItem(o, "g"),
              has_sa = cJSON_HasObjectItem(o, "sigma_a"), has_eta = cJSON_HasObjectItem(o, "eta");
    sss_material m;
    memset(&m, 0, sizeof m);
    if (has_preset) {
        if (has_ssp || has_ss || has_g || has_sa || has_eta)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss.preset cannot be combined with sigma_s_prime, sigma_s, g, sigma_a or "
                             "eta (only with name)",
                             w);
        const cJSON *p = cJSON_GetObjectItemCaseSensitive(o, "preset");
        if (!cJSON_IsString(p))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.preset must be a string", w);
        int found = 0;
        for (int i = 0; i < SSS_PRESET_COUNT; i++)
            if (streq_nocase(p->valuestring, sss_presets[i].m.name)) {
                m = sss_presets[i].m;
                found = 1;
            }
        if (!found) {
            char list[512];
            preset_list(list, sizeof list);
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss.preset: no preset named \"%s\" (presets: %s)", w, p->valuestring, list);
        }
    } else {
        if (has_ssp == has_ss)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss needs exactly one of sigma_s_prime or sigma_s (or a preset)", w);
        if (has_ssp && has_g)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss.g goes with sigma_s, not with sigma_s_prime (already reduced)", w);
        if (has_ss && !has_g)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.g is required with sigma_s", w);
        if (!has_sa)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.sigma_a is required", w);
        if (!has_eta)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.eta is required", w);
        obs_status st = read_rgb(ctx, o, has_ssp ? "sigma_s_prime" : "sigma_s", w, m.sigma_s);
        if (st == OBS_STATUS_OK)
            st = read_rgb(ctx, o, "sigma_a", w, m.sigma_a);
        if (st == OBS_STATUS_OK && has_g)
            st = read_number(ctx, o, "g", w, &m.g);
        if (st == OBS_STATUS_OK)
            st = read_number(ctx, o, "eta", w, &m.eta);
        if (st != OBS_STATUS_OK)
            return st;
        if (has_g && !(m.g > -1.0 && m.g < 1.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.g must be in (-1, 1) (got %g)", w, m.g);
        if (!(m.eta > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: obscura_sss.eta must be > 0 (got %g)", w, m.eta);
        snprintf(m.name, sizeof m.name, "%s", "custom");
    }
    const cJSON *nm = cJSON_GetObjectItemCaseSensitive(o, "name");
    if (nm) {
        if (!cJSON_IsString(nm) || strlen(nm->valuestring) >= OBS_NAME_MAX)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: obscura_sss.name must be a string shorter than %d bytes", w, OBS_NAME_MAX);
        snprintf(m.name, sizeof m.name, "%s", nm->valuestring);
    }
    obs_status st = sss_material_validate(ctx, &m, w);
    if (st != OBS_STATUS_OK)
        return st;
    *out = m;
    return OBS_STATUS_OK;
}

obs_status sss_material_from_extras(obs_context *ctx, const char *extras_json, const char *where,
                                    sss_material *out, int *found)
{
    const char *w = where ? where : "extras";
    if (!out || !found)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: sss_material_from_extras: NULL argument", w);
    *found = 0;
    if (!extras_json)
        return OBS_STATUS_OK;
    /* the error position comes back through `end` (cJSON_GetErrorPtr is a process global) */
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(extras_json, &end, 0);
    if (!root)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: extras is not valid JSON (at byte %td, near \"%.20s\")", w,
                         end ? end - extras_json : (ptrdiff_t)0, end ? end : "");
    /* glTF extras may be any JSON value; only an object can carry "obscura_sss". */
    const cJSON *o = cJSON_IsObject(root) ? cJSON_GetObjectItemCaseSensitive(root, "obscura_sss") : NULL;
    obs_status st = OBS_STATUS_OK;
    if (o) {
        sss_material m;
        st = parse_sss_object(ctx, o, w, &m);
        if (st == OBS_STATUS_OK) {
            *out = m;
            *found = 1;
        }
    }
    cJSON_Delete(root);
    return st;
}
