/* vol_tf.c: 1D RGBA transfer functions (vol.h section 2): the documented JSON (docs/volume.md,
 * "Transfer functions"), the presets (the same numbers as data/transfer/<name>.json; a test checks
 * they agree), piecewise-linear evaluation and opacity correction [Engel06]. */
#include "vol.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- Presets ------------------------------------------------------------------------------------
 * Chosen by hand for this project [R]: they are starting points for the datasets of docs/volume.md,
 * not published tables. Every preset leaves ref_step at 0 (one voxel of the grid's smallest spacing).
 * The CT anchors are the Hounsfield scale's definition (air -1000 HU, water 0 HU) and the usual
 * ranges for soft tissue (about 0..100 HU) and bone (about +300 HU and up) [R]. */
typedef struct vol_tf_preset_def {
    const char *name;
    int count;
    const double (*pts)[5];
} vol_tf_preset_def;

/* ct-skin: air transparent; the skin surface where air meets tissue (about -500 HU) faint and
 * skin-coloured; bone (from about +300 HU) brighter and denser. */
static const double vol_tf_ct_skin[][5] = {
    {-1024.0, 0.0, 0.0, 0.0, 0.0},  {-600.0, 0.0, 0.0, 0.0, 0.0},   {-400.0, 0.9, 0.65, 0.55, 0.1},
    {100.0, 0.9, 0.65, 0.55, 0.15}, {300.0, 0.95, 0.9, 0.8, 0.6},   {2000.0, 1.0, 1.0, 0.95, 0.9},
};
/* ct-bone: everything below +150 HU transparent; bone ramps to nearly opaque by +2000 HU. */
static const double vol_tf_ct_bone[][5] = {
    {-1024.0, 0.0, 0.0, 0.0, 0.0}, {150.0, 0.0, 0.0, 0.0, 0.0},     {300.0, 0.9, 0.82, 0.7, 0.25},
    {700.0, 0.95, 0.92, 0.85, 0.7}, {2000.0, 1.0, 1.0, 0.97, 0.95},
};
/* mri: for ch2better's T1 intensities (0..130, docs/volume.md "Datasets"): background clear, dark
 * CSF faint, grey matter (about 80) translucent, white matter (about 110) denser. */
static const double vol_tf_mri[][5] = {
    {0.0, 0.0, 0.0, 0.0, 0.0},      {20.0, 0.0, 0.0, 0.0, 0.0},     {50.0, 0.55, 0.35, 0.3, 0.02},
    {80.0, 0.85, 0.6, 0.55, 0.1},   {110.0, 0.95, 0.9, 0.85, 0.3},  {130.0, 1.0, 1.0, 1.0, 0.4},
};
/* bucky: the synthetic molecule's 0..255: the blobs' outer shells blue and faint, the cores
 * yellow-white and dense. */
static const double vol_tf_bucky[][5] = {
    {0.0, 0.0, 0.0, 0.0, 0.0},      {40.0, 0.0, 0.0, 0.0, 0.0},     {80.0, 0.2, 0.5, 0.9, 0.05},
    {160.0, 0.9, 0.8, 0.3, 0.4},    {255.0, 1.0, 0.95, 0.9, 0.9},
};

#define VOL_TF_PRESET(n, a) {n, (int)(sizeof a / sizeof a[0]), a}
static const vol_tf_preset_def vol_tf_presets[] = {
    VOL_TF_PRESET("ct-skin", vol_tf_ct_skin),
    VOL_TF_PRESET("ct-bone", vol_tf_ct_bone),
    VOL_TF_PRESET("mri", vol_tf_mri),
    VOL_TF_PRESET("bucky", vol_tf_bucky),
};
#define VOL_TF_PRESET_COUNT ((int)(sizeof vol_tf_presets / sizeof vol_tf_presets[0]))

void vol_tf_free(vol_tf *tf)
{
    if (!tf)
        return;
    free(tf->points);
    memset(tf, 0, sizeof *tf);
}

obs_status vol_tf_preset(obs_context *ctx, const char *name, vol_tf *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_tf_preset: out is NULL");
    memset(out, 0, sizeof *out);
    for (int p = 0; name && p < VOL_TF_PRESET_COUNT; p++) {
        const vol_tf_preset_def *d = &vol_tf_presets[p];
        if (strcmp(name, d->name) != 0)
            continue;
        out->points = (vol_tf_point *)calloc((size_t)d->count, sizeof *out->points);
        if (!out->points)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate transfer function '%s'", d->name);
        snprintf(out->name, sizeof out->name, "%s", d->name);
        out->count = d->count;
        out->ref_step = 0.0;
        for (int i = 0; i < d->count; i++) {
            out->points[i].value = d->pts[i][0];
            for (int c = 0; c < 4; c++)
                out->points[i].rgba[c] = (float)d->pts[i][1 + c];
        }
        return OBS_STATUS_OK;
    }
    return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                     "unknown transfer-function preset '%s' (known: ct-skin, ct-bone, mri, bucky)",
                     name ? name : "(null)");
}

/* ---- JSON -------------------------------------------------------------------------------------- */

obs_status vol_tf_parse_json(obs_context *ctx, const char *text, const char *where, vol_tf *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_tf_parse_json: out is NULL");
    memset(out, 0, sizeof *out);
    if (!where || !where[0])
        where = "<transfer function>";
    if (!text)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: no text", where);

    const char *end = NULL;
    size_t len = strlen(text);
    cJSON *root = cJSON_ParseWithLengthOpts(text, len + 1, &end, 1); /* + 1: the terminating NUL is part of the buffer */
    if (!root) {
        size_t off = end && end >= text ? (size_t)(end - text) : 0;
        int line = 1;
        for (size_t i = 0; i < off && i < len; i++)
            line += text[i] == '\n';
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: malformed JSON near byte %zu (line %d)", where, off, line);
    }

    obs_status st = OBS_STATUS_OK;
    vol_tf tf;
    memset(&tf, 0, sizeof tf);
    const cJSON *points = NULL;
    if (!cJSON_IsObject(root)) {
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: the top level must be an object", where);
        goto done;
    }

    /* Keys: name (string), ref_step (number), points (array), description (string, ignored).
     * Anything else, or a key given twice, is an error: a misspelt key must not pass silently. */
    int seen_name = 0, seen_ref = 0, seen_desc = 0;
    for (const cJSON *it = root->child; it; it = it->next) {
        const char *k = it->string ? it->string : "";
        if (strcmp(k, "name") == 0) {
            if (seen_name++ || !cJSON_IsString(it)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: \"name\" must be one string", where);
                goto done;
            }
            if (strlen(it->valuestring) >= sizeof tf.name) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: \"name\" is longer than %d characters", where,
                               (int)sizeof tf.name - 1);
                goto done;
            }
            snprintf(tf.name, sizeof tf.name, "%s", it->valuestring);
        } else if (strcmp(k, "ref_step") == 0) {
            if (seen_ref++ || !cJSON_IsNumber(it) || !isfinite(it->valuedouble) || !(it->valuedouble > 0.0)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                               "%s: \"ref_step\" must be one finite number > 0 (world units; omit it for one "
                               "voxel of the smallest spacing)",
                               where);
                goto done;
            }
            tf.ref_step = it->valuedouble;
        } else if (strcmp(k, "description") == 0) {
            if (seen_desc++ || !cJSON_IsString(it)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: \"description\" must be one string", where);
                goto done;
            }
        } else if (strcmp(k, "points") == 0) {
            if (points || !cJSON_IsArray(it)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: \"points\" must be one array", where);
                goto done;
            }
            points = it;
        } else {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                           "%s: unknown key \"%s\" (known: name, ref_step, points, description)", where, k);
            goto done;
        }
    }
    if (!points) {
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: missing \"points\"", where);
        goto done;
    }
    int count = cJSON_GetArraySize(points);
    if (count < 1) {
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: \"points\" is empty (at least one point is needed)", where);
        goto done;
    }
    tf.points = (vol_tf_point *)calloc((size_t)count, sizeof *tf.points);
    if (!tf.points) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate %d points", where, count);
        goto done;
    }
    static const char *const comp[5] = {"value", "r", "g", "b", "a"};
    int i = 0;
    for (const cJSON *p = points->child; p; p = p->next, i++) {
        if (!cJSON_IsArray(p) || cJSON_GetArraySize(p) != 5) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: point %d must be an array [value, r, g, b, a]", where, i);
            goto done;
        }
        double v[5];
        int c = 0;
        for (const cJSON *e = p->child; e; e = e->next, c++) {
            if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: point %d: %s must be a finite number", where, i,
                               comp[c]);
                goto done;
            }
            v[c] = e->valuedouble;
            if (c > 0 && !(v[c] >= 0.0 && v[c] <= 1.0)) {
                st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: point %d: %s = %g is outside [0, 1]", where, i,
                               comp[c], v[c]);
                goto done;
            }
        }
        if (i > 0 && !(v[0] > tf.points[i - 1].value)) {
            st = obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                           "%s: point %d: value %g does not follow %g (values must increase strictly)", where, i, v[0],
                           tf.points[i - 1].value);
            goto done;
        }
        tf.points[i].value = v[0];
        for (c = 0; c < 4; c++)
            tf.points[i].rgba[c] = (float)v[1 + c];
    }
    tf.count = count;
    *out = tf;
    tf.points = NULL;

done:
    free(tf.points);
    cJSON_Delete(root);
    return st;
}

/* ---- Evaluation -------------------------------------------------------------------------------- */

void vol_tf_eval(const vol_tf *tf, double value, float rgba[4])
{
    const vol_tf_point *p = tf->points;
    int n = tf->count;
    /* NaN data is empty space: transparent black (docs/volume.md). */
    if (n < 1 || isnan(value)) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 0.0f;
        return;
    }
    /* Constant beyond the ends. */
    if (value <= p[0].value) {
        memcpy(rgba, p[0].rgba, 4 * sizeof(float));
        return;
    }
    if (value >= p[n - 1].value) {
        memcpy(rgba, p[n - 1].rgba, 4 * sizeof(float));
        return;
    }
    /* Binary search for the segment p[lo].value <= value < p[hi].value, hi = lo + 1. */
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (p[mid].value <= value)
            lo = mid;
        else
            hi = mid;
    }
    double t = (value - p[lo].value) / (p[hi].value - p[lo].value);
    for (int c = 0; c < 4; c++)
        rgba[c] = (float)((double)p[lo].rgba[c] * (1.0 - t) + (double)p[hi].rgba[c] * t);
}

float vol_tf_alpha_correct(float alpha, double step, double ref_step)
{
    /* [Engel06] opacity correction: alpha' = 1 - (1 - alpha)^(step / ref_step), evaluated as
     * -expm1(r log1p(-alpha)) for accuracy at small alpha. */
    if (!(alpha > 0.0f))
        return 0.0f;
    if (alpha >= 1.0f)
        return 1.0f;
    if (step == ref_step)
        return alpha;
    if (!(step > 0.0))
        return 0.0f; /* a zero-length step absorbs nothing */
    if (!(ref_step > 0.0) || !isfinite(ref_step))
        return alpha; /* an unresolved ref_step (0): no correction; the caller resolves it first */
    double r = step / ref_step;
    double a = -expm1(r * log1p(-(double)alpha));
    return (float)(a < 0.0 ? 0.0 : a > 1.0 ? 1.0 : a);
}

double vol_sigma_from_alpha(float alpha, double ref_step)
{
    /* vol.h's convention: (1 - alpha)^(d / ref_step) = exp(-sigma d). */
    if (!(alpha > 0.0f) || !(ref_step > 0.0))
        return 0.0;
    const double a = alpha < 1.0f - 0x1p-24f ? (double)alpha : 1.0 - 0x1p-24;
    return -log1p(-a) / ref_step;
}
