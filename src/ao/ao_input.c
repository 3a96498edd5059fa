/* ao_input.c: AO inputs: validation, our G-buffer, external G-buffers read from an image
 * (EXR) with their intrinsics, and normals reconstructed from depth. docs/ao/README.md. */
#include "ao.h"
#include "../io/io.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------------
 * Validation
 * ---------------------------------------------------------------------------------------------- */

static int plane_ok(const obs_image_f32 *p, int w, int h)
{
    return p && p->data && p->width == w && p->height == h && p->stride >= p->width;
}

obs_status ao_input_validate(obs_context *ctx, const ao_input *in)
{
    if (!in)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao input: NULL");
    if (in->width < 1 || in->height < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao input: buffer size %dx%d must be at least 1x1",
                         in->width, in->height);
    if (in->w < 1 || in->h < 1 || in->x0 < 0 || in->y0 < 0 || (int64_t)in->x0 + in->w > in->width ||
        (int64_t)in->y0 + in->h > in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao input: window x %d y %d %dx%d must be non-empty and inside the %dx%d buffer", in->x0,
                         in->y0, in->w, in->h, in->width, in->height);
    if (!plane_ok(in->depth, in->width, in->height))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao input: the depth plane is missing or not %dx%d", in->width, in->height);
    int nn = (in->normal[0] != NULL) + (in->normal[1] != NULL) + (in->normal[2] != NULL);
    if (nn != 0 && nn != 3)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao input: give all three normal planes or none");
    for (int c = 0; c < nn; c++)
        if (!plane_ok(in->normal[c], in->width, in->height))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao input: normal plane %d is not %dx%d", c,
                             in->width, in->height);
    if (!(in->fx > 0.0) || !(in->fy > 0.0) || !isfinite(in->fx) || !isfinite(in->fy) || !isfinite(in->cx) ||
        !isfinite(in->cy))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao input: pixel model fx %g fy %g cx %g cy %g: need finite values with fx, fy > 0", in->fx,
                         in->fy, in->cx, in->cy);
    if (in->projection != OBS_PROJECTION_PERSPECTIVE && in->projection != OBS_PROJECTION_ORTHOGRAPHIC)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao input: unknown projection %d", (int)in->projection);
    if (isnan(in->znear) || isnan(in->zfar) || in->znear < 0.0 || isinf(in->znear) || in->zfar < in->znear)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao input: znear %g, zfar %g: need 0 <= znear <= zfar (zfar may be infinite)", in->znear,
                         in->zfar);
    return OBS_STATUS_OK;
}

obs_status ao_input_from_gbuffer(obs_context *ctx, const rast_gbuffer *gb, int use_normals, ao_input *out)
{
    if (!gb || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_input_from_gbuffer: NULL argument");
    memset(out, 0, sizeof *out);
    if (!gb->depth.data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_input_from_gbuffer: the G-buffer has no depth plane");
    out->width = gb->width;
    out->height = gb->height;
    out->x0 = gb->guard;
    out->y0 = gb->guard;
    out->w = gb->width - 2 * gb->guard;
    out->h = gb->height - 2 * gb->guard;
    out->depth = &gb->depth;
    if (use_normals && gb->normal[0].data && gb->normal[1].data && gb->normal[2].data)
        for (int c = 0; c < 3; c++)
            out->normal[c] = &gb->normal[c];
    const rast_view_constants *vc = &gb->constants;
    out->fx = vc->fx;
    out->fy = vc->fy;
    out->cx = vc->cx;
    out->cy = vc->cy;
    out->projection = vc->projection_type;
    out->znear = vc->znear;
    out->zfar = vc->zfar;
    return ao_input_validate(ctx, out);
}

/* ------------------------------------------------------------------------------------------------
 * Normals from depth (MinDiff rule)
 * ---------------------------------------------------------------------------------------------- */

typedef struct normals_job {
    const ao_input *in;
    obs_image_f32 *out;
} normals_job;

static int depth_ok(float d) { return d > 0.0f && d < INFINITY; }

static void normals_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const normals_job *J = (const normals_job *)user;
    const ao_input *in = J->in;
    const int W = in->width, H = in->height, y = (int)task;
    const float *d0 = obs_image_f32_row(in->depth, y);
    const float *dm = y > 0 ? obs_image_f32_row(in->depth, y - 1) : NULL;
    const float *dp = y + 1 < H ? obs_image_f32_row(in->depth, y + 1) : NULL;
    float *o[3] = {obs_image_f32_row(&J->out[0], y), obs_image_f32_row(&J->out[1], y), obs_image_f32_row(&J->out[2], y)};
    for (int x = 0; x < W; x++) {
        o[0][x] = o[1][x] = o[2][x] = 0.0f;
        float d = d0[x];
        if (!depth_ok(d))
            continue;
        obs_vec3 C = ao_position(in, x, y, d);
        /* along x: the one-sided difference with the smaller depth step (MinDiff) */
        obs_vec3 dx = obs_v3(0.0f, 0.0f, 0.0f), dy = dx;
        int hx = 0, hy = 0;
        float bx = INFINITY, by = INFINITY;
        if (x + 1 < W && depth_ok(d0[x + 1]) && fabsf(d0[x + 1] - d) < bx) {
            dx = obs_v3_sub(ao_position(in, x + 1, y, d0[x + 1]), C);
            bx = fabsf(d0[x + 1] - d);
            hx = 1;
        }
        if (x > 0 && depth_ok(d0[x - 1]) && fabsf(d0[x - 1] - d) < bx) {
            dx = obs_v3_sub(C, ao_position(in, x - 1, y, d0[x - 1]));
            hx = 1;
        }
        /* along y (rows grow downwards: the row below is y + 1) */
        if (dp && depth_ok(dp[x]) && fabsf(dp[x] - d) < by) {
            dy = obs_v3_sub(C, ao_position(in, x, y + 1, dp[x]));
            by = fabsf(dp[x] - d);
            hy = 1;
        }
        if (dm && depth_ok(dm[x]) && fabsf(dm[x] - d) < by) {
            dy = obs_v3_sub(ao_position(in, x, y - 1, dm[x]), C);
            hy = 1;
        }
        if (!hx || !hy)
            continue;
        /* dx points right (+x), dy points up (+y): cross(dx, dy) faces the camera (+z view) */
        obs_vec3 n = obs_v3_normalize(obs_v3_cross(dx, dy));
        if (n.z < 0.0f)
            n = obs_v3_scale(n, -1.0f);
        o[0][x] = n.x;
        o[1][x] = n.y;
        o[2][x] = n.z;
    }
}

obs_status ao_normals_from_depth(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 out[3])
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_normals_from_depth: NULL output");
    for (int c = 0; c < 3; c++)
        if (!plane_ok(&out[c], in->width, in->height))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_normals_from_depth: output plane %d is not %dx%d",
                             c, in->width, in->height);
    normals_job J = {in, out};
    obs_pool_run(pool, in->height, normals_row, &J);
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Intrinsics: unknown, JSON
 * ---------------------------------------------------------------------------------------------- */

ao_intrinsics ao_intrinsics_unknown(void)
{
    ao_intrinsics k;
    memset(&k, 0, sizeof k);
    k.fx = k.fy = 0.0;
    k.cx = k.cy = NAN;
    k.projection = -1;
    k.znear = -1.0;
    k.zfar = NAN;
    k.depth_kind = AO_DEPTH_KIND_AUTO;
    k.window[2] = 0;
    return k;
}

static int depth_kind_from_name(const char *s, size_t n, int *out)
{
    static const struct { const char *name; int kind; } names[] = {
        {"linear", AO_DEPTH_KIND_LINEAR},
        {"gl", AO_DEPTH_KIND_NDC_GL},
        {"zero-to-one", AO_DEPTH_KIND_NDC_ZERO_TO_ONE},
        {"reversed-z", AO_DEPTH_KIND_NDC_REVERSED_Z},
        /* the names rast_depth_convention_name() writes into obscura:depth_convention */
        {"gl_standard", AO_DEPTH_KIND_NDC_GL},
        {"zero_to_one", AO_DEPTH_KIND_NDC_ZERO_TO_ONE},
        {"reversed_z", AO_DEPTH_KIND_NDC_REVERSED_Z},
    };
    for (size_t k = 0; k < sizeof names / sizeof names[0]; k++)
        if (strlen(names[k].name) == n && !strncmp(s, names[k].name, n)) {
            *out = names[k].kind;
            return 1;
        }
    return 0;
}

/* Find `"key"` followed by optional blanks and ':'; return a pointer past the ':' (blanks
 * skipped), or NULL. The first occurrence anywhere wins (so nested sidecar objects work). */
static const char *json_find_value(const char *text, const char *key)
{
    size_t kl = strlen(key);
    for (const char *p = text; (p = strchr(p, '"')) != NULL;) {
        const char *q = p + 1;
        if (!strncmp(q, key, kl) && q[kl] == '"') {
            const char *r = q + kl + 1;
            while (isspace((unsigned char)*r))
                r++;
            if (*r == ':') {
                r++;
                while (isspace((unsigned char)*r))
                    r++;
                return r;
            }
        }
        /* skip this string (with escapes) */
        q = p + 1;
        while (*q && *q != '"') {
            if (*q == '\\' && q[1])
                q++;
            q++;
        }
        if (!*q)
            return NULL;
        p = q + 1;
    }
    return NULL;
}

/* A JSON string value at v: sets *s, *n (no escapes expected in these values). */
static int json_string_at(const char *v, const char **s, size_t *n)
{
    if (*v != '"')
        return 0;
    const char *e = strchr(v + 1, '"');
    if (!e)
        return 0;
    *s = v + 1;
    *n = (size_t)(e - v - 1);
    return 1;
}

static int json_number_at(const char *v, double *out)
{
    const char *s;
    size_t n;
    if (json_string_at(v, &s, &n)) {
        if ((n == 8 && !strncmp(s, "infinity", 8)) || (n == 3 && !strncmp(s, "inf", 3))) {
            *out = INFINITY;
            return 1;
        }
        return 0;
    }
    char *end;
    errno = 0;
    double d = strtod(v, &end);
    if (end == v || errno)
        return 0;
    *out = d;
    return 1;
}

obs_status ao_intrinsics_parse_json(obs_context *ctx, const char *text, ao_intrinsics *out)
{
    if (!text || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_intrinsics_parse_json: NULL argument");
    ao_intrinsics k = ao_intrinsics_unknown();
    static const char *num_keys[] = {"fx", "fy", "cx", "cy", "znear", "zfar"};
    double *num_dst[] = {&k.fx, &k.fy, &k.cx, &k.cy, &k.znear, &k.zfar};
    for (int i = 0; i < 6; i++) {
        const char *v = json_find_value(text, num_keys[i]);
        if (v && !json_number_at(v, num_dst[i]))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "intrinsics JSON: \"%s\" is not a number", num_keys[i]);
        /* only zfar may be infinite; NaN (strtod accepts a bare "nan", JSON does not) never
         * (found by fuzz_gbuffer, F12) */
        if (v && (isnan(*num_dst[i]) || (i != 5 && isinf(*num_dst[i]))))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "intrinsics JSON: \"%s\" must be a finite number%s",
                             num_keys[i], i == 5 ? " or \"infinity\"" : "");
    }
    const char *v = json_find_value(text, "projection_type");
    if (!v)
        v = json_find_value(text, "projection");
    if (v) {
        const char *s = NULL;
        size_t n = 0;
        if (!json_string_at(v, &s, &n))
            n = 0;
        if (n == 11 && !strncmp(s, "perspective", 11))
            k.projection = OBS_PROJECTION_PERSPECTIVE;
        else if (n == 12 && !strncmp(s, "orthographic", 12))
            k.projection = OBS_PROJECTION_ORTHOGRAPHIC;
        else
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                             "intrinsics JSON: projection must be \"perspective\" or \"orthographic\"");
    }
    v = json_find_value(text, "depth_kind");
    if (!v)
        v = json_find_value(text, "depth_convention");
    if (v) {
        const char *s;
        size_t n;
        if (!json_string_at(v, &s, &n) || !depth_kind_from_name(s, n, &k.depth_kind))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                             "intrinsics JSON: depth kind must be \"linear\", \"gl\", \"zero-to-one\" or \"reversed-z\"");
    }
    v = json_find_value(text, "inner_window");
    if (v) {
        if (*v != '[')
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "intrinsics JSON: inner_window must be [x, y, w, h]");
        const char *p = v + 1;
        for (int i = 0; i < 4; i++) {
            char *end;
            long val = strtol(p, &end, 10);
            if (end == p || val < 0 || val > RAST_MAX_DIM * 4)
                return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "intrinsics JSON: inner_window must be 4 integers >= 0");
            k.window[i] = (int)val;
            p = end;
            while (isspace((unsigned char)*p) || *p == ',')
                p++;
        }
    }
    *out = k;
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * External G-buffers
 * ---------------------------------------------------------------------------------------------- */

ao_external_options ao_external_options_default(void)
{
    ao_external_options o;
    memset(&o, 0, sizeof o);
    o.depth_kind = AO_DEPTH_KIND_AUTO;
    o.normals = AO_EXTERNAL_NORMALS_AUTO;
    return o;
}

void ao_external_free(ao_external *e)
{
    if (!e)
        return;
    obs_image_f32_free(&e->depth);
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&e->normal[c]);
    memset(e, 0, sizeof *e);
}

static int find_channel(const io_image *im, const char *name)
{
    for (int c = 0; c < im->channel_count; c++)
        if (!strcmp(im->names[c], name))
            return c;
    return -1;
}

static const io_attr *find_attr(const io_image *im, const char *name)
{
    for (int i = 0; i < im->attr_count; i++)
        if (!strcmp(im->attrs[i].name, name))
            return &im->attrs[i];
    return NULL;
}

static const char *depth_kind_name(int k)
{
    switch (k) {
    case AO_DEPTH_KIND_LINEAR: return "linear";
    case AO_DEPTH_KIND_NDC_GL: return "gl";
    case AO_DEPTH_KIND_NDC_ZERO_TO_ONE: return "zero-to-one";
    case AO_DEPTH_KIND_NDC_REVERSED_Z: return "reversed-z";
    default: return "auto";
    }
}

obs_status ao_external_from_image(obs_context *ctx, const io_image *im, const ao_external_options *opt,
                                  ao_external *out)
{
    if (!im || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_external_from_image: NULL argument");
    memset(out, 0, sizeof *out);
    ao_external_options o = opt ? *opt : ao_external_options_default();
    if ((unsigned)o.depth_kind >= AO_DEPTH_KIND_COUNT || (unsigned)o.normals >= AO_EXTERNAL_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_external_from_image: bad option values");
    const int W = im->width, H = im->height;
    if (W < 1 || H < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "external G-buffer: empty image");

    /* ---- Depth channel ---- */
    int dc = -1;
    if (o.depth_channel) {
        dc = find_channel(im, o.depth_channel);
        if (dc < 0)
            return obs_error(ctx, OBS_STATUS_NOT_FOUND, "external G-buffer: no channel '%s'", o.depth_channel);
    } else {
        static const char *names[] = {"Z", "Zndc", "depth", "R"};
        for (int i = 0; i < 4 && dc < 0; i++)
            dc = find_channel(im, names[i]);
        if (dc < 0 && im->channel_count == 1) {
            /* a GPU depth buffer often arrives as a one-channel image (a PFM reads as channel
             * 'Y'): with nothing else to choose from, its only channel is the depth */
            dc = 0;
            obs_log(ctx, OBS_LOG_WARN, "external G-buffer: no Z, Zndc, depth or R channel; the image's only channel "
                                       "'%s' is used as depth",
                    im->names[0]);
        }
        if (dc < 0) {
            char list[512] = "";
            for (int c = 0; c < im->channel_count && strlen(list) < 400; c++) {
                strcat(list, c ? ", " : "");
                strncat(list, im->names[c], 60);
            }
            return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                             "external G-buffer: no depth channel (looked for Z, Zndc, depth, R; the image has: %s)",
                             list);
        }
    }
    if (im->types[dc] == IO_PIXEL_UINT || !im->f32[dc].data)
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "external G-buffer: depth channel '%s' is not a float channel",
                         im->names[dc]);
    snprintf(out->depth_channel, sizeof out->depth_channel, "%s", im->names[dc]);

    /* ---- Intrinsics: options, else metadata ---- */
    ao_intrinsics k = o.intrinsics ? *o.intrinsics : ao_intrinsics_unknown();
    const io_attr *a;
    if (!(k.fx > 0.0) || !(k.fy > 0.0) || isnan(k.cx) || isnan(k.cy)) {
        double m[4] = {0.0, 0.0, NAN, NAN};
        int have = 0;
        if ((a = find_attr(im, "obscura:pixel_model_fx_fy_cx_cy")) && a->type == IO_ATTR_FLOATS && a->n == 4 && a->v) {
            for (int i = 0; i < 4; i++)
                m[i] = a->v[i];
            have = 1;
        } else if ((a = find_attr(im, "obscura:projection")) && a->type == IO_ATTR_MATRIX44 && a->v) {
            /* GL column-major P: perspective x_ndc = P00 x/d - P02 ... -> fx = W P00/2,
             * cx = W/2 (1 - P02), cy = H/2 (1 + P12); orthographic (P33 = 1): cx = W/2 (1 + P03),
             * cy = H/2 (1 - P13). */
            const float *P = a->v;
            int ortho = P[15] == 1.0f && P[11] == 0.0f;
            m[0] = 0.5 * W * P[0];
            m[1] = 0.5 * H * P[5];
            m[2] = ortho ? 0.5 * W * (1.0 + P[12]) : 0.5 * W * (1.0 - P[8]);
            m[3] = ortho ? 0.5 * H * (1.0 - P[13]) : 0.5 * H * (1.0 + P[9]);
            if (k.projection < 0)
                k.projection = ortho ? OBS_PROJECTION_ORTHOGRAPHIC : OBS_PROJECTION_PERSPECTIVE;
            have = 1;
        }
        if (!have)
            return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                             "external G-buffer: no camera intrinsics (need obscura:pixel_model_fx_fy_cx_cy or "
                             "obscura:projection in the file, or an intrinsics JSON with fx, fy, cx, cy)");
        if (!(k.fx > 0.0)) k.fx = m[0];
        if (!(k.fy > 0.0)) k.fy = m[1];
        if (isnan(k.cx)) k.cx = m[2];
        if (isnan(k.cy)) k.cy = m[3];
    }
    if (k.projection < 0) {
        k.projection = OBS_PROJECTION_PERSPECTIVE;
        if ((a = find_attr(im, "obscura:projection_type")) && a->type == IO_ATTR_STRING && a->s) {
            if (!strcmp(a->s, "orthographic"))
                k.projection = OBS_PROJECTION_ORTHOGRAPHIC;
            else if (strcmp(a->s, "perspective") != 0)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "external G-buffer: obscura:projection_type '%s' is neither perspective nor orthographic",
                                 a->s);
        }
    }
    if (k.projection != OBS_PROJECTION_PERSPECTIVE && k.projection != OBS_PROJECTION_ORTHOGRAPHIC)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "external G-buffer: unknown projection %d", k.projection);
    if (k.znear < 0.0 && (a = find_attr(im, "obscura:znear")) && a->type == IO_ATTR_FLOAT)
        k.znear = a->f;
    if (isnan(k.zfar) && (a = find_attr(im, "obscura:zfar")) && a->type == IO_ATTR_FLOAT)
        k.zfar = a->f;
    if (k.window[2] <= 0 && (a = find_attr(im, "obscura:inner_window_x_y_w_h")) && a->type == IO_ATTR_FLOATS &&
        a->n == 4 && a->v)
        for (int i = 0; i < 4; i++) {
            /* a float outside int's range (or NaN) would make the conversion undefined (C11
             * 6.3.1.4): refuse it (found by fuzz_gbuffer) */
            if (!(a->v[i] >= -2147483648.0f && a->v[i] < 2147483648.0f))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "external G-buffer: obscura:inner_window_x_y_w_h[%d] = %g is not a pixel coordinate",
                                 i, (double)a->v[i]);
            k.window[i] = (int)a->v[i];
        }

    /* ---- Depth kind ---- */
    /* explicit option > "Z" is linear > the intrinsics' depth kind > the file's obscura:depth_convention
     * (which describes its Zndc channel) */
    int kind = o.depth_kind;
    if (kind == AO_DEPTH_KIND_AUTO && !strcmp(im->names[dc], "Z"))
        kind = AO_DEPTH_KIND_LINEAR;
    if (kind == AO_DEPTH_KIND_AUTO)
        kind = k.depth_kind;
    if (kind == AO_DEPTH_KIND_AUTO) {
        int file_kind = AO_DEPTH_KIND_AUTO;
        a = find_attr(im, "obscura:depth_convention");
        if (a && a->type == IO_ATTR_STRING && a->s && depth_kind_from_name(a->s, strlen(a->s), &file_kind) &&
            file_kind != AO_DEPTH_KIND_LINEAR) {
            kind = file_kind; /* the file says which depth-buffer convention its NDC channel holds */
        } else {
            return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                             "external G-buffer: channel '%s' is not 'Z' and the file has no "
                             "obscura:depth_convention: say what it holds (--depth-kind linear, gl, zero-to-one or "
                             "reversed-z)",
                             im->names[dc]);
        }
    }
    out->depth_kind = (ao_depth_kind)kind;

    if (!isfinite(k.fx) || !isfinite(k.fy) || !(k.fx > 0.0) || !(k.fy > 0.0) || !isfinite(k.cx) || !isfinite(k.cy))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "external G-buffer: pixel model fx %g fy %g cx %g cy %g: need finite values with fx, fy > 0",
                         k.fx, k.fy, k.cx, k.cy);
    rast_view_constants vc;
    memset(&vc, 0, sizeof vc);
    vc.projection_type = (obs_projection)k.projection;
    if (kind != AO_DEPTH_KIND_LINEAR) {
        if (k.znear < 0.0 || isnan(k.zfar))
            return obs_error(ctx, OBS_STATUS_NOT_FOUND,
                             "external G-buffer: %s depth needs znear and zfar (obscura:znear / obscura:zfar or the "
                             "intrinsics JSON)",
                             depth_kind_name(kind));
        int ortho = k.projection == OBS_PROJECTION_ORTHOGRAPHIC;
        if (!isfinite(k.znear) || (ortho ? k.znear < 0.0 : k.znear <= 0.0) || !(k.zfar > k.znear) ||
            (ortho && isinf(k.zfar)))
            return obs_error(ctx, OBS_STATUS_INVALID_DEPTH_RANGE,
                             "external G-buffer: znear %g, zfar %g cannot convert %s depth (need %s and zfar > znear%s)",
                             k.znear, k.zfar, depth_kind_name(kind), ortho ? "znear >= 0" : "znear > 0",
                             ortho ? ", finite" : "");
        vc.znear = k.znear;
        vc.zfar = k.zfar;
    } else {
        vc.znear = k.znear >= 0.0 && isfinite(k.znear) ? k.znear : 0.0;
        vc.zfar = !isnan(k.zfar) && k.zfar >= vc.znear ? k.zfar : INFINITY;
    }

    /* ---- Window ---- */
    int x0 = 0, y0 = 0, ww = W, wh = H;
    if (k.window[2] > 0) {
        x0 = k.window[0];
        y0 = k.window[1];
        ww = k.window[2];
        wh = k.window[3];
        if (x0 < 0 || y0 < 0 || ww < 1 || wh < 1 || (int64_t)x0 + ww > W || (int64_t)y0 + wh > H)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "external G-buffer: inner window x %d y %d %dx%d is not inside the %dx%d image", x0, y0, ww,
                             wh, W, H);
    }

    /* ---- Normals ---- */
    const char *pre = o.normal_prefix ? o.normal_prefix : "N";
    int nc[3] = {-1, -1, -1};
    if (o.normals != AO_EXTERNAL_NORMALS_NONE) {
        static const char *suffix[3] = {"X", "Y", "Z"};
        for (int c = 0; c < 3; c++) {
            char nm[80];
            snprintf(nm, sizeof nm, "%s.%s", pre, suffix[c]);
            nc[c] = find_channel(im, nm);
            if (nc[c] >= 0 && (im->types[nc[c]] == IO_PIXEL_UINT || !im->f32[nc[c]].data))
                nc[c] = -1;
        }
        if ((nc[0] < 0 || nc[1] < 0 || nc[2] < 0) && o.normals == AO_EXTERNAL_NORMALS_REQUIRE)
            return obs_error(ctx, OBS_STATUS_NOT_FOUND, "external G-buffer: normal channels %s.X, %s.Y, %s.Z required",
                             pre, pre, pre);
    }
    int have_normals = nc[0] >= 0 && nc[1] >= 0 && nc[2] >= 0;

    /* ---- Copy and convert ---- */
    obs_status st = obs_image_f32_alloc(ctx, W, H, &out->depth);
    for (int c = 0; st == OBS_STATUS_OK && have_normals && c < 3; c++)
        st = obs_image_f32_alloc(ctx, W, H, &out->normal[c]);
    if (st != OBS_STATUS_OK) {
        ao_external_free(out);
        return st;
    }
    const obs_image_f32 *src = &im->f32[dc];
    rast_depth_convention conv = kind == AO_DEPTH_KIND_NDC_GL ? RAST_DEPTH_GL_STANDARD
                                 : kind == AO_DEPTH_KIND_NDC_ZERO_TO_ONE ? RAST_DEPTH_ZERO_TO_ONE
                                                                         : RAST_DEPTH_REVERSED_Z;
    for (int y = 0; y < H; y++) {
        const float *s = obs_image_f32_row(src, y);
        float *d = obs_image_f32_row(&out->depth, y);
        for (int x = 0; x < W; x++) {
            float v = s[x];
            double lin;
            if (kind == AO_DEPTH_KIND_LINEAR) {
                lin = v;
            } else if (isnan(v)) {
                lin = NAN;
            } else {
                lin = rast_linear_from_ndc_depth(&vc, conv, (double)v);
            }
            if (lin == INFINITY) {
                out->background_pixels++;
                d[x] = INFINITY;
            } else if (!(lin > 0.0) || !(lin < INFINITY) || !((float)lin > 0.0f)) {
                /* NaN, -inf, <= 0: no surface we could place; document: treated as background */
                out->invalid_depth_pixels++;
                d[x] = INFINITY;
            } else {
                d[x] = (float)lin;
            }
        }
        if (have_normals) {
            /* ao_input promises unit normals. A file's normals within [0.5, 2] in length (unit up to
             * storage precision, e.g. 16-bit or 10-bit encodings) are kept as they are, so kernels
             * see the file's own values; others are renormalised in double when finite and nonzero,
             * else set to the zero vector (no normal: the kernels treat it as degenerate), and
             * counted. Found by fuzz_gbuffer: finite normals of length 1e36 overflowed MSSAO's
             * normalisation to NaN (docs/reliability.md, F11). */
            const float *sn[3] = {obs_image_f32_row(&im->f32[nc[0]], y), obs_image_f32_row(&im->f32[nc[1]], y),
                                  obs_image_f32_row(&im->f32[nc[2]], y)};
            float *dn[3] = {obs_image_f32_row(&out->normal[0], y), obs_image_f32_row(&out->normal[1], y),
                            obs_image_f32_row(&out->normal[2], y)};
            for (int x = 0; x < W; x++) {
                const double a = sn[0][x], b = sn[1][x], c = sn[2][x];
                const double len = sqrt(a * a + b * b + c * c);
                if (len >= 0.5 && len <= 2.0) {
                    dn[0][x] = sn[0][x];
                    dn[1][x] = sn[1][x];
                    dn[2][x] = sn[2][x];
                    continue;
                }
                if (!(d[x] < INFINITY)) { /* background: its normal is not used */
                    dn[0][x] = dn[1][x] = dn[2][x] = 0.0f;
                    continue;
                }
                out->renormalized_normal_pixels++;
                if (len > 0.0 && len < INFINITY) {
                    dn[0][x] = (float)(a / len);
                    dn[1][x] = (float)(b / len);
                    dn[2][x] = (float)(c / len);
                } else { /* NaN, inf (or a length overflowing double), zero */
                    dn[0][x] = dn[1][x] = dn[2][x] = 0.0f;
                }
            }
        }
    }
    if (out->renormalized_normal_pixels > 0)
        obs_log(ctx, OBS_LOG_WARN,
                "external G-buffer: %lld surface pixels of the normal channels are not unit length (outside [0.5, 2]): "
                "renormalised, or set to no normal where not finite or zero",
                (long long)out->renormalized_normal_pixels);
    if (out->invalid_depth_pixels > 0)
        obs_log(ctx, OBS_LOG_WARN,
                "external G-buffer: %lld pixels of '%s' hold no usable depth (NaN, -inf, <= 0 or outside the %s "
                "range): treated as background (visibility 1)",
                (long long)out->invalid_depth_pixels, out->depth_channel, depth_kind_name(kind));

    ao_input *in = &out->input;
    in->width = W;
    in->height = H;
    in->x0 = x0;
    in->y0 = y0;
    in->w = ww;
    in->h = wh;
    in->depth = &out->depth;
    for (int c = 0; c < 3; c++)
        in->normal[c] = have_normals ? &out->normal[c] : NULL;
    in->fx = k.fx;
    in->fy = k.fy;
    in->cx = k.cx;
    in->cy = k.cy;
    in->projection = (obs_projection)k.projection;
    in->znear = vc.znear;
    in->zfar = vc.zfar;
    st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        ao_external_free(out);
    return st;
}
