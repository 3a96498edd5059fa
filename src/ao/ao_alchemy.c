/* ao_alchemy.c: the Alchemy screen-space ambient obscurance algorithm [McGuire11] (McGuire, Osman,
 * Bukowski, Hennessy, "The Alchemy Screen-Space Ambient Obscurance Algorithm", HPG 2011).
 *
 * Per pixel C (camera space, z_C < 0) with unit normal n, s taps Q_i on a screen-space disk of the
 * projected world radius r, and
 *   A = max(0, 1 - (2 sigma / s) * sum_i max(0, v_i.n + z_C beta) / (v_i.v_i + epsilon))^k,
 * v_i = Q_i - C ([McGuire11] section 3, the estimator; the seed thesis prints it as its Figura 25;
 * a secondary design note numbers it eq. 10; docs/ao/alchemy.md says what was and was not verified).
 *
 * The tap pattern is the HPG11/HPG12 lineage's, in GL pixel coordinates (x_gl = x, y_gl = H-1-y of
 * the full buffer): the per-pixel rotation ao_sao_spin ("Hash function used in the HPG12 AlchemyAO
 * paper", SAO_AO.pix) and SAO's spiral tapLocation: alpha = (i + 0.5)/s, angle = alpha (tau 6.28) +
 * spin, ssR = alpha * ssDiskRadius, tap = ssC + ivec2(ssR (cos, sin)). Depth is read at level 0 (Alchemy
 * has no MIP pyramid), clamped to the buffer like a CLAMP_TO_EDGE texel fetch.
 *
 * Arithmetic is float32 in the estimator's order (the build uses -ffp-contract=off); cos/sin are
 * ao_i_cos_sin (correctly rounded), pow is (float)pow(double, double). docs/ao/alchemy.md lists every
 * difference from the paper and the ports.
 */
#include "ao.h"
#include "ao_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ================================================================================================
 * Parameters, presets, constants
 * ============================================================================================== */

ao_alchemy_params ao_alchemy_params_default(void)
{
    ao_alchemy_params p;
    memset(&p, 0, sizeof p);
    p.radius = AO_ALCHEMY_DEFAULT_RADIUS;
    p.bias = AO_ALCHEMY_DEFAULT_BIAS;
    p.intensity = AO_ALCHEMY_DEFAULT_INTENSITY;
    p.contrast = AO_ALCHEMY_DEFAULT_CONTRAST;
    p.epsilon = AO_ALCHEMY_DEFAULT_EPSILON;
    p.samples = AO_ALCHEMY_DEFAULT_SAMPLES;
    p.spiral_turns = AO_ALCHEMY_DEFAULT_SPIRAL_TURNS;
    p.normals = AO_ALCHEMY_NORMALS_AUTO;
    p.range_check = 1;
    p.blur = 1;
    return p;
}

static const char *const preset_names[] = {"default", "hpg11", "thesis", "port", NULL};

const char *const *ao_alchemy_preset_names(void) { return preset_names; }

int ao_alchemy_params_preset(const char *name, ao_alchemy_params *out)
{
    if (!name || !out)
        return 0;
    ao_alchemy_params p = ao_alchemy_params_default();
    if (!strcmp(name, "default") || !strcmp(name, "hpg11")) {
        /* [McGuire11] and its HPG11 talk ("Equation" slide): sigma 1, beta 1e-4, epsilon 1e-5, k 1 */
    } else if (!strcmp(name, "thesis")) {
        /* ssao-thesis-2017, Tabla 3: "Alchemy AO  Radio(m) 1  Muestras 16" */
        p.radius = 1.0f;
        p.samples = 16;
    } else if (!strcmp(name, "port")) {
        /* The AlchemyHPG11 GLSL ports ("From paper .../AlchemyHPG11/ and improvements here
         * .../SAOHPG12/"): radius 1, k 1.5, sigma 1, tau 7, beta 0.002, epsilon .00001, SAMPLES 16. */
        p.radius = 1.0f;
        p.contrast = 1.5f;
        p.intensity = 1.0f;
        p.spiral_turns = 7;
        p.bias = 0.002f;
        p.epsilon = 1e-5f;
        p.samples = 16;
    } else {
        return 0;
    }
    *out = p;
    return 1;
}

obs_status ao_alchemy_params_validate(obs_context *ctx, const ao_alchemy_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: NULL params");
    if (!(p->radius > 0.0f) || !isfinite(p->radius) || p->radius > 1e6f)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: radius %g must be in (0, 1e6] m",
                         (double)p->radius);
    /* beta >= 0: the bias only removes obscurance (z_C beta <= 0); a negative one would let every tap
     * add up to |z_C beta| / epsilon. */
    if (!(p->bias >= 0.0f) || !isfinite(p->bias))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: bias %g must be finite and >= 0",
                         (double)p->bias);
    if (!(p->intensity >= 0.0f) || !isfinite(p->intensity))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: intensity %g must be finite and >= 0",
                         (double)p->intensity);
    if (!(p->contrast > 0.0f) || !isfinite(p->contrast))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: contrast %g must be finite and > 0",
                         (double)p->contrast);
    if (!(p->epsilon > 0.0f) || !isfinite(p->epsilon))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: epsilon %g must be finite and > 0",
                         (double)p->epsilon);
    if (p->samples < 1 || p->samples > AO_ALCHEMY_MAX_SAMPLES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: samples %d must be in [1, %d]", p->samples,
                         AO_ALCHEMY_MAX_SAMPLES);
    if (p->spiral_turns < 1 || p->spiral_turns > 1000000)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: spiral turns %d must be in [1, 1000000]",
                         p->spiral_turns);
    if ((unsigned)p->normals >= AO_ALCHEMY_NORMALS_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: unknown normals mode %d", (int)p->normals);
    if (p->range_check != 0 && p->range_check != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: range check %d must be 0 or 1", p->range_check);
    if (p->blur != 0 && p->blur != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: blur %d must be 0 or 1", p->blur);
    return OBS_STATUS_OK;
}

static const char *const normals_names[] = {"auto", "gbuffer", "depth", NULL};

int ao_alchemy_params_to_string(const ao_alchemy_params *p, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "radius=%.9g bias=%.9g intensity=%.9g contrast=%.9g epsilon=%.9g samples=%d spiral_turns=%d "
                    "normals=%s range_check=%d blur=%d",
                    (double)p->radius, (double)p->bias, (double)p->intensity, (double)p->contrast,
                    (double)p->epsilon, p->samples, p->spiral_turns,
                    (unsigned)p->normals < AO_ALCHEMY_NORMALS_COUNT ? normals_names[p->normals] : "?", p->range_check, p->blur);
}

ao_alchemy_constants ao_alchemy_constants_from_params(const ao_alchemy_params *p, const ao_input *in)
{
    ao_alchemy_constants k;
    memset(&k, 0, sizeof k);
    k.full_width = in->width;
    k.full_height = in->height;
    k.orthographic = in->projection == OBS_PROJECTION_ORTHOGRAPHIC;
    k.normals_from_gbuffer =
        p->normals == AO_ALCHEMY_NORMALS_GBUFFER || (p->normals == AO_ALCHEMY_NORMALS_AUTO && in->normal[0] != NULL);
    /* projInfo in GL pixel coordinates, exactly as SAO's (ao_sao_constants): (s + 0.5) with
     * s_y = H-1-y reproduces the rasterizer's pixel model -(y + 0.5 - cy)/fy. */
    const double H = in->height;
    if (!k.orthographic) {
        k.proj_info[0] = (float)(-1.0 / in->fx);
        k.proj_info[1] = (float)(-1.0 / in->fy);
        k.proj_info[2] = (float)(in->cx / in->fx);
        k.proj_info[3] = (float)((H - in->cy) / in->fy);
    } else {
        k.proj_info[0] = (float)(1.0 / in->fx);
        k.proj_info[1] = (float)(1.0 / in->fy);
        k.proj_info[2] = (float)(-in->cx / in->fx);
        k.proj_info[3] = (float)(-(H - in->cy) / in->fy);
    }
    /* "the height in pixels of a 1 m object viewed from 1 m": the disk radius is r fy / -z_C px */
    k.proj_scale = (float)in->fy;
    k.radius = p->radius;
    k.radius2 = p->radius * p->radius;
    k.range_check = p->range_check != 0;
    k.bias = p->bias;
    k.intensity = p->intensity;
    k.contrast = p->contrast;
    k.epsilon = p->epsilon;
    k.num_samples = p->samples;
    k.num_spiral_turns = p->spiral_turns;
    /* GLSL constant folding, in float: 1.0 / float(s); float(tau) * 6.28 (SAO_AO.pix tapLocation) */
    k.inv_num_samples = 1.0f / (float)p->samples;
    k.turns_angle = (float)p->spiral_turns * 6.28f;
    /* [McGuire11] estimator: the factor 2 sigma / s in front of the sum */
    k.intensity_scale = (2.0f * p->intensity) / (float)p->samples;
    k.blur = p->blur != 0;
    return k;
}

/* ================================================================================================
 * The AO pass
 * ============================================================================================== */

static inline float maxf(float a, float b) { return a > b ? a : b; } /* GLSL max; NaN a -> b */

/* GLSL int(f): truncation toward zero. Out-of-range values are clamped to +-2^30 (undefined in GLSL)
 * so that adding a pixel coordinate cannot overflow; NaN -> 0. */
static inline int trunc_to_int(float v)
{
    if (v != v)
        return 0;
    if (v >= 1073741824.0f)
        return 1073741824;
    if (v <= -1073741824.0f)
        return -1073741824;
    return (int)v;
}

static inline int is_surface(float d) { return d > 0.0f && d < INFINITY; }

/* csPos: camera-space position of GL pixel s at camera-space z (< 0), SAO's reconstructCSPosition. */
static inline void cs_pos(const ao_alchemy_constants *k, int sx, int sy, float z, float P[3])
{
    const float ax = ((float)sx + 0.5f) * k->proj_info[0] + k->proj_info[2];
    const float ay = ((float)sy + 0.5f) * k->proj_info[1] + k->proj_info[3];
    if (!k->orthographic) {
        P[0] = ax * z;
        P[1] = ay * z;
    } else {
        P[0] = ax;
        P[1] = ay;
    }
    P[2] = z;
}

/* The screen-space disk radius in pixels: ssDiskRadius = -projScale * r / z_C (orthographic:
 * projScale * r, the disk's size does not depend on depth). */
static inline float disk_radius(const ao_alchemy_constants *k, float z)
{
    return !k->orthographic ? (-k->proj_scale * k->radius) / z : k->proj_scale * k->radius;
}

/* One tap's offset: SAO_AO.pix tapLocation, ssP = ivec2(ssR * unitOffset) + ssC. */
static inline void tap(const ao_alchemy_constants *k, float spin, float disk, int i, int *ox, int *oy)
{
    const float alpha = ((float)i + 0.5f) * k->inv_num_samples;
    const float angle = alpha * k->turns_angle + spin;
    const float ssR = alpha * disk;
    float cs, sn;
    ao_i_cos_sin(angle, &cs, &sn);
    *ox = trunc_to_int(ssR * cs);
    *oy = trunc_to_int(ssR * sn);
}

void ao_alchemy_tap_offset(const ao_alchemy_constants *k, int x_gl, int y_gl, float disk_px, int i, int offset[2])
{
    tap(k, ao_sao_spin(x_gl, y_gl), disk_px, i, &offset[0], &offset[1]);
}

typedef struct alchemy_job {
    const ao_alchemy_constants *k;
    const ao_input *in;
    const obs_image_f32 *const *n;  /* normal planes, full buffer, our row order */
    int rx0, ry0;                   /* rectangle origin, our row order */
    obs_image_f32 *out;
    int64_t (*counts)[2];
} alchemy_job;

static void alchemy_row(void *user, int64_t task, int thread)
{
    (void)thread;
    const alchemy_job *J = (const alchemy_job *)user;
    const ao_alchemy_constants *k = J->k;
    const obs_image_f32 *D = J->in->depth;
    const int W = k->full_width, H = k->full_height;
    const int y = J->ry0 + (int)task, gy = H - 1 - y;
    const float *drow = obs_image_f32_row(D, y);
    const float *n0 = obs_image_f32_row(J->n[0], y), *n1 = obs_image_f32_row(J->n[1], y),
                *n2 = obs_image_f32_row(J->n[2], y);
    float *o = obs_image_f32_row(J->out, (int)task);
    int64_t n_bg = 0, n_degen = 0;
    for (int i = 0; i < J->out->width; i++) {
        const int x = J->rx0 + i, gx = x;
        /* ---- Centre: C = csPos(ssC, z_C), z_C = -depth; background gets visibility 1 ---- */
        const float d = drow[x];
        if (!is_surface(d)) {
            o[i] = 1.0f;
            n_bg++;
            continue;
        }
        const float zC = -d;
        float C[3];
        cs_pos(k, gx, gy, zC, C);
        /* ---- Normal: normalize(n) = n * inversesqrt(dot(n, n)); zero or non-finite -> 1 ---- */
        const float a = n0[x], b = n1[x], c = n2[x];
        const float l2 = a * a + b * b + c * c;
        if (!(l2 > 0.0f) || !(l2 < INFINITY)) {
            o[i] = 1.0f;
            n_degen++;
            continue;
        }
        const float inv = 1.0f / sqrtf(l2);
        const float n[3] = {a * inv, b * inv, c * inv};
        /* ---- Per-pixel rotation and disk ---- */
        const float spin = ao_sao_spin(gx, gy);
        const float disk = disk_radius(k, zC);
        const float zb = zC * k->bias; /* [McGuire11]: the bias term z_C beta (<= 0) */
        /* ---- Taps: sum_i max(0, v.n + z_C beta) / (v.v + epsilon) ---- */
        float sum = 0.0f;
        for (int t = 0; t < k->num_samples; t++) {
            int ox, oy;
            tap(k, spin, disk, t, &ox, &oy);
            const int px = gx + ox, py = gy + oy;
            /* Q: the camera-space position buffer [McGuire11] (pipeline step 2) read at the tap
             * with CLAMP_TO_EDGE, i.e. the clamped texel's own point (not SAO's reconstruction at
             * the unclamped ssP, which puts edge depths at off-screen positions) */
            const int cx = px < 0 ? 0 : px > W - 1 ? W - 1 : px;
            const int cy = py < 0 ? 0 : py > H - 1 ? H - 1 : py;
            const float dq = obs_image_f32_row(D, H - 1 - cy)[cx];
            if (!is_surface(dq))
                continue; /* background: a point at infinity, whose term tends to 0 (documented) */
            float Q[3];
            cs_pos(k, cx, cy, -dq, Q);
            const float v0 = Q[0] - C[0], v1 = Q[1] - C[1], v2 = Q[2] - C[2];
            const float vv = v0 * v0 + v1 * v1 + v2 * v2;
            const float vn = v0 * n[0] + v1 * n[1] + v2 * n[2];
            /* range check [vv < r^2]: the Alchemy term with a step at r, as the authors' SAO_AO.pix
             * keeps it (falloff A, "From the HPG12 paper": float(vv < radius2) *
             * max((vn - bias) / (epsilon + vv), 0)); whether HPG11 itself has the step is [U] */
            if (k->range_check && !(vv < k->radius2))
                continue;
            sum += maxf(0.0f, vn + zb) / (vv + k->epsilon);
        }
        /* ---- A = max(0, 1 - (2 sigma / s) sum)^k ---- */
        const float base = maxf(0.0f, 1.0f - k->intensity_scale * sum);
        float A = k->contrast == 1.0f ? base : (float)pow((double)base, (double)k->contrast);
        o[i] = A >= 0.0f && A <= 1.0f ? A : (A > 1.0f ? 1.0f : 0.0f); /* NaN cannot occur; belt and braces */
    }
    if (J->counts) {
        J->counts[task][0] = n_bg;
        J->counts[task][1] = n_degen;
    }
}

obs_status ao_alchemy_raw(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_constants *k,
                          const obs_image_f32 *const normals[3], const int rect[4], obs_image_f32 *out,
                          int64_t counts[2])
{
    if (!in || !k || !normals || !normals[0] || !normals[1] || !normals[2] || !rect || !out || !out->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: NULL argument");
    if (k->full_width != in->width || k->full_height != in->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: constants for %dx%d, input is %dx%d",
                         k->full_width, k->full_height, in->width, in->height);
    if (rect[2] < 1 || rect[3] < 1 || rect[0] < 0 || rect[1] < 0 || rect[0] + rect[2] > in->width ||
        rect[1] + rect[3] > in->height || out->width != rect[2] || out->height != rect[3])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "ao_alchemy_raw: rectangle (%d, %d, %d, %d) outside the %dx%d buffer or output not %dx%d",
                         rect[0], rect[1], rect[2], rect[3], in->width, in->height, rect[2], rect[3]);
    for (int a = 0; a < 3; a++)
        if (normals[a]->width != in->width || normals[a]->height != in->height)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: normal planes must be %dx%d",
                             in->width, in->height);
    if (k->num_samples < 1 || k->num_samples > AO_ALCHEMY_MAX_SAMPLES || !isfinite(k->intensity_scale) ||
        !(k->proj_scale > 0.0f) || !isfinite(k->proj_scale) || !(k->epsilon > 0.0f) || !(k->contrast > 0.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "ao_alchemy_raw: constants out of range");
    int64_t(*rc)[2] = (int64_t(*)[2])calloc((size_t)rect[3], sizeof *rc);
    if (!rc)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "alchemy: out of memory");
    alchemy_job J = {k, in, normals, rect[0], rect[1], out, rc};
    obs_pool_run(pool, rect[3], alchemy_row, &J);
    if (counts) {
        counts[0] = counts[1] = 0;
        for (int r = 0; r < rect[3]; r++) { /* fixed order: deterministic */
            counts[0] += rc[r][0];
            counts[1] += rc[r][1];
        }
    }
    free(rc);
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * The whole pass
 * ============================================================================================== */

obs_status ao_alchemy_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_alchemy_params *params,
                              obs_image_f32 *out, obs_image_f32 *out_raw, ao_alchemy_stats *stats)
{
    obs_status st = ao_input_validate(ctx, in);
    if (st != OBS_STATUS_OK)
        return st;
    st = ao_alchemy_params_validate(ctx, params);
    if (st != OBS_STATUS_OK)
        return st;
    if (!out || !out->data || out->width != in->w || out->height != in->h ||
        (out_raw && (!out_raw->data || out_raw->width != in->w || out_raw->height != in->h)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "alchemy: output planes must be %dx%d (the window)",
                         in->w, in->h);
    if (params->normals == AO_ALCHEMY_NORMALS_GBUFFER && !in->normal[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "alchemy: normals from the G-buffer were asked for, but the input has none");
    if (stats)
        memset(stats, 0, sizeof *stats);
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(params, in);

    /* ---- 1. Normals: the G-buffer's, or reconstructed from depth ---- */
    double t0 = obs_time_now();
    obs_image_f32 rec[3];
    memset(rec, 0, sizeof rec);
    const obs_image_f32 *nrm[3] = {in->normal[0], in->normal[1], in->normal[2]};
    if (!k.normals_from_gbuffer) {
        for (int a = 0; a < 3 && st == OBS_STATUS_OK; a++)
            st = obs_image_f32_alloc(ctx, in->width, in->height, &rec[a]);
        if (st == OBS_STATUS_OK)
            st = ao_normals_from_depth(ctx, pool, in, rec);
        nrm[0] = &rec[0];
        nrm[1] = &rec[1];
        nrm[2] = &rec[2];
    }
    double t1 = obs_time_now();

    /* ---- 2. AO over the window plus the blur's reach ---- */
    int rect[4];
    ao_blur_reach(in, k.blur ? AO_GAUSS21_RADIUS : 0, rect);
    obs_image_f32 raw = {0}, blurred = {0};
    int64_t counts[2] = {0, 0};
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, rect[2], rect[3], &raw);
    if (st == OBS_STATUS_OK)
        st = ao_alchemy_raw(ctx, pool, in, &k, nrm, rect, &raw, counts);
    double t2 = obs_time_now();

    /* ---- 3. The seed's 21-tap Gaussian over the computed rectangle (its clamp at a side that the
     * buffer clipped is the buffer's own edge; elsewhere the window's taps stay inside) ---- */
    const obs_image_f32 *final = &raw;
    if (st == OBS_STATUS_OK && k.blur) {
        st = obs_image_f32_alloc(ctx, rect[2], rect[3], &blurred);
        if (st == OBS_STATUS_OK)
            st = ao_blur_gaussian21(ctx, pool, &raw, &blurred);
        final = &blurred;
    }
    double t3 = obs_time_now();

    /* ---- 4. Crop the window ---- */
    if (st == OBS_STATUS_OK) {
        const int ox = in->x0 - rect[0], oy = in->y0 - rect[1];
        for (int y = 0; y < in->h; y++) {
            memcpy(obs_image_f32_row(out, y), obs_image_f32_row(final, y + oy) + ox, sizeof(float) * (size_t)in->w);
            /* background keeps visibility 1 exactly: the Gaussian (not depth-aware) would leave
             * 1 - 2.4e-7 or blurred-in AO there; no shading uses it (documented deviation) */
            const float *drow = obs_image_f32_row(in->depth, in->y0 + y) + in->x0;
            float *orow = obs_image_f32_row(out, y);
            for (int x = 0; x < in->w; x++)
                if (!is_surface(drow[x]))
                    orow[x] = 1.0f;
            if (out_raw)
                memcpy(obs_image_f32_row(out_raw, y), obs_image_f32_row(&raw, y + oy) + ox,
                       sizeof(float) * (size_t)in->w);
        }
        if (stats) {
            stats->pixels_computed = (int64_t)rect[2] * rect[3];
            stats->pixels_background = counts[0];
            stats->pixels_degenerate_normal = counts[1];
            stats->seconds_normals = t1 - t0;
            stats->seconds_ao = t2 - t1;
            stats->seconds_blur = t3 - t2;
        }
    }
    obs_image_f32_free(&blurred);
    obs_image_f32_free(&raw);
    for (int a = 0; a < 3; a++)
        obs_image_f32_free(&rec[a]);
    return st;
}

/* ================================================================================================
 * The registry descriptor (ao.h, "The method registry")
 * ============================================================================================== */

_Static_assert(sizeof(ao_alchemy_normals) == sizeof(int), "ENUM params are int-sized");
_Static_assert(sizeof(ao_alchemy_params) <= AO_PARAMS_MAX_SIZE, "AO_PARAMS_MAX_SIZE");

#define AL_F(field) offsetof(ao_alchemy_params, field)
static const ao_param_desc alchemy_param_descs[] = {
    {"radius", AO_PARAM_FLOAT, AL_F(radius), 1e-6, 1e6, NULL, "world-space radius r of the sample disk (m)"},
    {"bias", AO_PARAM_FLOAT, AL_F(bias), 0, 1e30, NULL, "shadow bias beta (the term is z_C beta, z_C < 0)"},
    {"intensity", AO_PARAM_FLOAT, AL_F(intensity), 0, 1e30, NULL, "intensity sigma (2 sigma / s scales the sum)"},
    {"contrast", AO_PARAM_FLOAT, AL_F(contrast), 1e-30, 1e30, NULL, "contrast k (the exponent)"},
    {"epsilon", AO_PARAM_FLOAT, AL_F(epsilon), 1e-30, 1e30, NULL, "epsilon in (v.n + z_C beta)/(v.v + epsilon) (m^2)"},
    {"samples", AO_PARAM_INT, AL_F(samples), 1, AO_ALCHEMY_MAX_SAMPLES, NULL, "taps s per pixel"},
    {"turns", AO_PARAM_INT, AL_F(spiral_turns), 1, 1000000, NULL, "spiral turns tau"},
    {"normals", AO_PARAM_ENUM, AL_F(normals), 0, 0, normals_names,
     "auto: the G-buffer's if present, else from depth; gbuffer; depth (ao_normals_from_depth)"},
    {"range-check", AO_PARAM_BOOL, AL_F(range_check), 0, 1, NULL,
     "count only taps with |v| < r (as SAO_AO.pix falloff A); off: every tap in the disk"},
    {"blur", AO_PARAM_BOOL, AL_F(blur), 0, 1, NULL, "the seed's 21-tap separable Gaussian after the AO pass"},
};
#undef AL_F

static void m_default(void *p) { *(ao_alchemy_params *)p = ao_alchemy_params_default(); }
static int m_preset(const char *name, void *p) { return ao_alchemy_params_preset(name, (ao_alchemy_params *)p); }
static obs_status m_validate(obs_context *ctx, const void *p)
{
    return ao_alchemy_params_validate(ctx, (const ao_alchemy_params *)p);
}
static int m_to_string(const void *p, char *buf, size_t size)
{
    return ao_alchemy_params_to_string((const ao_alchemy_params *)p, buf, size);
}
static void m_set_samples(void *p, int n) { ((ao_alchemy_params *)p)->samples = n; }
static void m_set_radius(void *p, float r) { ((ao_alchemy_params *)p)->radius = r; }
static void m_set_blur(void *p, int on) { ((ao_alchemy_params *)p)->blur = on != 0; }
static float m_get_radius(const void *p) { return ((const ao_alchemy_params *)p)->radius; }
static const char *m_truth(const void *p)
{
    /* No truth estimator has Alchemy's cancelling falloff; GT-cos(r) (every occluder within r counts,
     * cosine-weighted, no distance falloff) is the nearest (docs/ao/alchemy.md, "Ground truth"). */
    (void)p;
    return "cos";
}

int ao_alchemy_constants_to_json(const ao_alchemy_constants *K, char *buf, size_t size)
{
    return snprintf(buf, size,
                    "{\"full_size\": [%d, %d], \"orthographic\": %d, \"normals_from_gbuffer\": %d, "
                    "\"projInfo\": [%.9g, %.9g, %.9g, %.9g], \"projScale\": %.9g, \"radius\": %.9g, \"radius2\": %.9g, \"range_check\": %d, "
                    "\"bias\": %.9g, \"intensity\": %.9g, \"contrast\": %.9g, \"epsilon\": %.9g, "
                    "\"NUM_SAMPLES\": %d, \"NUM_SPIRAL_TURNS\": %d, \"inv_num_samples\": %.9g, "
                    "\"turns_angle\": %.9g, \"intensity_scale\": %.9g, \"blur\": %d, \"blur_taps\": %d}",
                    K->full_width, K->full_height, K->orthographic, K->normals_from_gbuffer, (double)K->proj_info[0],
                    (double)K->proj_info[1], (double)K->proj_info[2], (double)K->proj_info[3], (double)K->proj_scale,
                    (double)K->radius, (double)K->radius2, K->range_check, (double)K->bias, (double)K->intensity, (double)K->contrast,
                    (double)K->epsilon, K->num_samples, K->num_spiral_turns, (double)K->inv_num_samples,
                    (double)K->turns_angle, (double)K->intensity_scale, K->blur, 2 * AO_GAUSS21_RADIUS + 1);
}

static int m_constants_json(const void *p, const ao_input *in, char *buf, size_t size)
{
    const ao_alchemy_constants K = ao_alchemy_constants_from_params((const ao_alchemy_params *)p, in);
    return ao_alchemy_constants_to_json(&K, buf, size);
}

static obs_status m_compute(obs_context *ctx, obs_pool *pool, const ao_input *in, const void *p, obs_image_f32 *out,
                            obs_image_f32 *out_raw, ao_stats *stats)
{
    ao_alchemy_stats s;
    memset(&s, 0, sizeof s);
    obs_status st = ao_alchemy_compute(ctx, pool, in, (const ao_alchemy_params *)p, out, out_raw, &s);
    if (stats) {
        memset(stats, 0, sizeof *stats);
        stats->pixels_computed = s.pixels_computed;
        stats->pixels_background = s.pixels_background;
        stats->seconds_prepare = s.seconds_normals;
        stats->seconds_kernel = s.seconds_ao;
        stats->seconds_blur = s.seconds_blur;
    }
    return st;
}

const ao_method ao_i_method_alchemy = {
    .name = "alchemy",
    .title = "Alchemy screen-space ambient obscurance [McGuire11], on the HPG11/HPG12 spiral",
    .doc = "docs/ao/alchemy.md",
    .params_size = sizeof(ao_alchemy_params),
    .params_default = m_default,
    .params_preset = m_preset,
    .preset_names = preset_names,
    .params = alchemy_param_descs,
    .param_count = (int)(sizeof alchemy_param_descs / sizeof alchemy_param_descs[0]),
    .params_adjust = NULL,
    .params_validate = m_validate,
    .params_to_string = m_to_string,
    .set_samples = m_set_samples,
    .set_radius = m_set_radius,
    .set_blur = m_set_blur,
    .get_radius = m_get_radius,
    .truth_estimator = m_truth,
    .flat_value = 1.0f,
    /* raw AO is exactly 1 on a plane (v.n is rounding noise, far below the bias z_C beta); the
     * Gaussian's float weights sum to 1 - 1.2e-7 (ao.h), two passes: 1 - 2.4e-7 */
    .flat_tolerance = 1e-5f,
    .constants_to_json = m_constants_json,
    .compute = m_compute,
};
