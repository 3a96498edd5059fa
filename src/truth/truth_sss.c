/* truth_sss.c: subsurface-scattering ground truth on Embree (truth.h, "SSS ground truth").
 *
 * Two estimators of the radiance L_o(x_o, w_o) that leaves a translucent surface by subsurface
 * scattering (docs/sss/truth.md writes out every pdf and weight):
 *   brute force  L_o = T21 Int_A T12 S_d E dA with the BSSRDF of the scattering maps, by uniform
 *                area sampling with Frisvad's Russian-roulette acceptance (dirpole.cpp trace(),
 *                ../shared/reference/sss.md s4) [Frisvad14];
 *   random walk  radiative transfer in the closed mesh (free paths, HG phase, albedo weighting,
 *                Fresnel boundary), MCML's scheme [Wang95] on a mesh, scored at x_o by a
 *                collision estimator onto a surface disk of radius rho.
 * Randomness: obs_rng_u32x4(pixel, candidate, dimension, seed) only; tasks are tiles; the output
 * does not depend on the thread count. */
#include "truth_internal.h"

#include "../raster/raster.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <xmmintrin.h>

#define ID_NONE 0xFFFFFFFFu
/* Dimensions of the random stream per candidate: 0 (triangle pick, acceptance), 1 (barycentrics),
 * then the walks: WALK_DIM0 + (stream << 21) + 2 * event (+1), stream = light * 3 + channel. */
#define WALK_DIM0 16u
#define WALK_MAX_STREAMS 2047
#define WALK_MAX_EVENTS ((1 << 20) - 1)
/* Weight roulette of the walk: below this fraction of its start, a photon survives with
 * probability w / RR_LEVEL and carries RR_LEVEL (unbiased; [Wang95]'s roulette, 1/10). */
#define RR_LEVEL 0.1

/* ------------------------------------------------------------------------------------------------
 * Small double-precision vector helpers
 * ---------------------------------------------------------------------------------------------- */

static inline double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void sub3(const double *a, const double *b, double *o) { o[0] = a[0] - b[0]; o[1] = a[1] - b[1]; o[2] = a[2] - b[2]; }
static inline double len3(const double *a) { return sqrt(dot3(a, a)); }
static inline int norm3(double *a)
{
    double l = len3(a);
    if (!(l > 0.0) || !isfinite(l))
        return 0;
    a[0] /= l; a[1] /= l; a[2] /= l;
    return 1;
}
static inline void cross3(const double *a, const double *b, double *o)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* 53-bit uniform in [0, 1) from two words. */
static inline double u53(uint32_t hi, uint32_t lo) { return (double)(((uint64_t)hi << 21) ^ (uint64_t)(lo >> 11)) * 0x1p-53; }
/* uniform in (0, 1) from one word */
static inline double u32o(uint32_t w) { return ((double)w + 0.5) * 0x1p-32; }

/* Refraction of a direction d travelling towards the surface (d.n < 0, n unit outward) into a
 * medium of relative index eta = n_inside / n_outside; Snell's law in vector form. Returns 0 on
 * total internal reflection. */
static int refract_in(const double *d, const double *n, double eta, double *t)
{
    double ci = -dot3(d, n);
    double s2 = (1.0 - ci * ci) / (eta * eta);
    if (s2 >= 1.0)
        return 0;
    double ct = sqrt(1.0 - s2);
    for (int a = 0; a < 3; a++)
        t[a] = d[a] / eta + (ci / eta - ct) * n[a];
    return norm3(t);
}

/* Henyey-Greenstein phase function, normalised over the sphere: (1/4pi)(1-g^2)/(1+g^2-2g cos)^1.5 */
static inline double hg_pdf(double g, double c)
{
    double den = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * OBS_PI * den * sqrt(den));
}

/* Sample HG around d (unit): the inverse CDF of cos theta (Henyey & Greenstein 1941, as MCML
 * [Wang95] eq. 3.28), azimuth uniform. */
static void hg_sample(double g, const double *d, double u1, double u2, double *out)
{
    double c;
    if (fabs(g) < 1e-6) {
        c = 1.0 - 2.0 * u1;
    } else {
        double q = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1);
        c = (1.0 + g * g - q * q) / (2.0 * g);
    }
    if (c > 1.0) c = 1.0;
    if (c < -1.0) c = -1.0;
    double s = sqrt(fmax(0.0, 1.0 - c * c)), phi = 2.0 * OBS_PI * u2;
    double t[3], b[3];
    double a[3] = {0.0, 0.0, 0.0};
    a[fabs(d[0]) < 0.6 ? 0 : (fabs(d[1]) < 0.6 ? 1 : 2)] = 1.0;
    cross3(d, a, t);
    norm3(t);
    cross3(d, t, b);
    for (int k = 0; k < 3; k++)
        out[k] = c * d[k] + s * (cos(phi) * t[k] + sin(phi) * b[k]);
    norm3(out);
}

/* ------------------------------------------------------------------------------------------------
 * Names, params
 * ---------------------------------------------------------------------------------------------- */

static const char *const EST_NAMES[TRUTH_SSS_ESTIMATOR_COUNT] = {"brute-force", "random-walk"};

const char *truth_sss_estimator_name(truth_sss_estimator e)
{
    return (unsigned)e < TRUTH_SSS_ESTIMATOR_COUNT ? EST_NAMES[e] : "?";
}

int truth_sss_estimator_from_name(const char *name, truth_sss_estimator *out)
{
    if (!name)
        return 0;
    for (int i = 0; i < TRUTH_SSS_ESTIMATOR_COUNT; i++)
        if (!strcmp(name, EST_NAMES[i])) {
            if (out)
                *out = (truth_sss_estimator)i;
            return 1;
        }
    return 0;
}

truth_sss_params truth_sss_params_default(void)
{
    truth_sss_params p;
    memset(&p, 0, sizeof p);
    p.estimator = TRUTH_SSS_BRUTE_FORCE;
    p.model = SSS_MODEL_DIRECTIONAL;
    p.target_rel_error = 0.01;   /* 1%: well under the differences between the maps and the truth
                                    that docs/sss.md studies (tens of percent, sss.md 1.4) */
    p.min_samples = 16384;
    p.max_samples = 1048576;     /* obs_limits_default().max_samples */
    p.batch = 4096;
    p.replicates = 8;            /* as truth_ao (docs/truth.md s5: 7 degrees of freedom) */
    p.sigma_star = 0.0;
    p.patch_radius = 0.05;
    p.max_bounces = 1000000;
    p.offset_ulps = 64.0f;       /* as truth_ao (docs/truth.md s4) */
    p.tile = 4;
    p.seed = 0;
    return p;
}

obs_status truth_sss_params_validate(obs_context *ctx, const truth_sss_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: params is NULL");
    if ((unsigned)p->estimator >= TRUTH_SSS_ESTIMATOR_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: estimator %d out of range", (int)p->estimator);
    if ((unsigned)p->model >= SSS_MODEL_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: model %d out of range", (int)p->model);
    if (!(p->target_rel_error > 0.0) || !isfinite(p->target_rel_error))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: target_rel_error must be > 0 and finite (got %g)", p->target_rel_error);
    if (p->replicates < 2 || p->replicates > TRUTH_SSS_MAX_REPLICATES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: replicates %d not in [2, %d]", p->replicates,
                         TRUTH_SSS_MAX_REPLICATES);
    if (p->batch < p->replicates || p->batch > 65536 || p->batch % p->replicates)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: batch %d must be a multiple of replicates (%d) in [replicates, 65536]", p->batch,
                         p->replicates);
    if (p->min_samples < p->batch || p->min_samples % p->batch)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: min_samples %lld must be a positive multiple of batch (%d)",
                         (long long)p->min_samples, p->batch);
    if (p->max_samples < p->min_samples || p->max_samples % p->batch)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: max_samples %lld must be a multiple of batch (%d) and >= min_samples (%lld)",
                         (long long)p->max_samples, p->batch, (long long)p->min_samples);
    if (p->max_samples > ((int64_t)1 << 32))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: max_samples %lld over 2^32",
                         (long long)p->max_samples);
    if (!(p->sigma_star >= 0.0) || !isfinite(p->sigma_star))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: sigma_star must be >= 0 and finite (got %g)",
                         p->sigma_star);
    if (!(p->patch_radius > 0.0) || !isfinite(p->patch_radius))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: patch_radius must be > 0 and finite (got %g)",
                         p->patch_radius);
    if (p->max_bounces < 1 || p->max_bounces > WALK_MAX_EVENTS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: max_bounces %d not in [1, %d]", p->max_bounces,
                         WALK_MAX_EVENTS);
    if (!(p->offset_ulps >= 0.0f) || !isfinite(p->offset_ulps))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: offset_ulps must be >= 0 and finite (got %g)",
                         (double)p->offset_ulps);
    if (p->tile < 1 || p->tile > 64)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: tile %d not in [1, 64]", p->tile);
    return OBS_STATUS_OK;
}

/* ------------------------------------------------------------------------------------------------
 * Closed-mesh check
 * ---------------------------------------------------------------------------------------------- */

static const float *vpos(const obs_mesh *m, uint32_t i) { return m->positions + 3 * (size_t)i; }

/* A vertex for the weld: its position's bits and its index. */
typedef struct weld_key {
    uint32_t bits[3];
    uint32_t id;
} weld_key;

static int cmp_weld(const void *pa, const void *pb)
{
    const weld_key *a = (const weld_key *)pa, *b = (const weld_key *)pb;
    for (int k = 0; k < 3; k++)
        if (a->bits[k] != b->bits[k])
            return a->bits[k] < b->bits[k] ? -1 : 1;
    return a->id < b->id ? -1 : a->id > b->id;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return a < b ? -1 : a > b;
}

/* The weld sorts vertices by their positions' bits (equal floats weld; -0 and +0 do not, which
 * only makes the check stricter). Re-entrant. */
int truth_sss_mesh_is_closed(const obs_mesh *mesh, uint64_t *open_edges)
{
    if (open_edges)
        *open_edges = 0;
    if (!mesh || !mesh->positions || !mesh->indices)
        return 0;
    uint32_t nv = mesh->vertex_count, nt = mesh->triangle_count;
    weld_key *order = (weld_key *)malloc(sizeof(weld_key) * (nv ? nv : 1));
    uint32_t *canon = (uint32_t *)malloc(sizeof(uint32_t) * (nv ? nv : 1));
    uint64_t *edges = (uint64_t *)malloc(sizeof(uint64_t) * 3 * (nt ? nt : 1));
    if (!order || !canon || !edges) {
        free(order); free(canon); free(edges);
        return -1;
    }
    for (uint32_t i = 0; i < nv; i++) {
        memcpy(order[i].bits, vpos(mesh, i), 12);
        order[i].id = i;
    }
    qsort(order, nv, sizeof(weld_key), cmp_weld);
    for (uint32_t i = 0; i < nv; i++) {
        if (i > 0 && !memcmp(order[i].bits, order[i - 1].bits, 12))
            canon[order[i].id] = canon[order[i - 1].id];
        else
            canon[order[i].id] = order[i].id;
    }
    size_t ne = 0;
    uint64_t nonfinite = 0;
    for (uint32_t t = 0; t < nt; t++) {
        uint32_t v[3];
        int ok = 1;
        for (int k = 0; k < 3; k++) {
            uint32_t id = mesh->indices[3 * (size_t)t + k];
            if (id >= nv) { ok = 0; break; }
            const float *p = vpos(mesh, id);
            if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) { ok = 0; break; }
            v[k] = canon[id];
        }
        if (!ok) {
            nonfinite++; /* a triangle that is not there leaves its neighbours open */
            continue;
        }
        if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2])
            continue; /* degenerate: no edges */
        for (int k = 0; k < 3; k++) {
            uint32_t a = v[k], b = v[(k + 1) % 3];
            edges[ne++] = a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
        }
    }
    qsort(edges, ne, sizeof(uint64_t), cmp_u64);
    uint64_t bad = 0;
    for (size_t i = 0; i < ne;) {
        size_t j = i;
        while (j < ne && edges[j] == edges[i])
            j++;
        if (j - i != 2)
            bad++;
        i = j;
    }
    free(order); free(canon); free(edges);
    if (ne == 0 && nonfinite == 0)
        bad = bad ? bad : 1; /* no surface at all: not a closed mesh */
    if (open_edges)
        *open_edges = bad + (bad ? 0 : nonfinite);
    return bad == 0 && nonfinite == 0;
}

/* ------------------------------------------------------------------------------------------------
 * Per-instance geometry: world-space triangles in double, their area CDF
 * ---------------------------------------------------------------------------------------------- */

typedef struct inst_geo {
    const sss_constants *c;   /* NULL: not translucent */
    uint32_t n;               /* triangles */
    double *tri;              /* 12 per triangle: p0, e1, e2, unit outward normal (zero if degenerate) */
    double *cdf;              /* n: cumulative area / total */
    uint32_t *guide;          /* guide_n + 1: guide[j] = the first t with cdf[t] > j / guide_n */
    uint32_t guide_n;         /* a power of two, about n / 4 */
    double area;
} inst_geo;

static const sss_constants *inst_material(const obs_scene *s, const sss_scene_materials *m, uint32_t i)
{
    const obs_mesh *mesh = &s->meshes[s->instances[i].mesh];
    if (mesh->material < 0)
        return m->none;
    if ((uint32_t)mesh->material >= m->count)
        return NULL;
    return m->translucent[mesh->material] ? &m->constants[mesh->material] : NULL;
}

static void xform_point(const obs_dmat4 *M, const float *p, double *o)
{
    for (int r = 0; r < 3; r++)
        o[r] = M->m[r] * p[0] + M->m[4 + r] * p[1] + M->m[8 + r] * p[2] + M->m[12 + r];
}

static uint32_t cdf_search(const double *cdf, uint32_t lo, uint32_t hi, double u);

static obs_status geo_build(obs_context *ctx, const obs_scene *s, uint32_t i, inst_geo *g)
{
    const obs_mesh *mesh = &s->meshes[s->instances[i].mesh];
    obs_dmat4 M = obs_mat4_to_double(s->instances[i].world);
    g->n = mesh->triangle_count;
    g->tri = (double *)malloc(sizeof(double) * 12 * (g->n ? g->n : 1));
    g->cdf = (double *)malloc(sizeof(double) * (g->n ? g->n : 1));
    if (!g->tri || !g->cdf)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory for mesh '%s'", mesh->name);
    double acc = 0.0;
    for (uint32_t t = 0; t < g->n; t++) {
        double p[3][3], *T = g->tri + 12 * (size_t)t;
        int ok = 1;
        for (int k = 0; k < 3; k++) {
            const float *v = vpos(mesh, mesh->indices[3 * (size_t)t + k]);
            if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
                ok = 0;
            xform_point(&M, v, p[k]);
        }
        double area = 0.0;
        memset(T, 0, sizeof(double) * 12);
        if (ok) {
            memcpy(T, p[0], sizeof(double) * 3);
            sub3(p[1], p[0], T + 3);
            sub3(p[2], p[0], T + 6);
            cross3(T + 3, T + 6, T + 9);
            area = 0.5 * len3(T + 9);
            if (!(area > 0.0) || !isfinite(area) || !norm3(T + 9)) {
                area = 0.0;
                T[9] = T[10] = T[11] = 0.0;
            }
        }
        acc += area;
        g->cdf[t] = acc;
    }
    g->area = acc;
    if (!(acc > 0.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: translucent mesh '%s' (instance %u) has no area",
                         mesh->name, i);
    for (uint32_t t = 0; t < g->n; t++)
        g->cdf[t] /= acc;
    g->cdf[g->n - 1] = 1.0;
    g->guide_n = 1;
    while (g->guide_n < g->n / 4 && g->guide_n < (1u << 24))
        g->guide_n *= 2;
    g->guide = (uint32_t *)malloc(sizeof(uint32_t) * (g->guide_n + 1));
    if (!g->guide)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory for mesh '%s'", mesh->name);
    for (uint32_t j = 0; j < g->guide_n; j++)
        g->guide[j] = cdf_search(g->cdf, 0, g->n - 1, (double)j / (double)g->guide_n);
    g->guide[g->guide_n] = g->n - 1;
    return OBS_STATUS_OK;
}

/* The first t with cdf[t] > u in [lo, hi] (cdf[hi] > u), by bisection. */
static uint32_t cdf_search(const double *cdf, uint32_t lo, uint32_t hi, double u)
{
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (cdf[mid] > u)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* The triangle for u in [0, 1): the first t with cdf[t] > u. The guide table (an indexed search)
 * narrows the bisection to [guide[j], guide[j + 1]] with j = floor(u guide_n), exact since guide_n
 * is a power of two; the answer is the same t as a bisection over all n (cdf is non-decreasing),
 * with a few cache lines touched instead of ~log2(n) (docs/sss/truth.md, section 6). */
static uint32_t cdf_pick(const inst_geo *g, double u)
{
    uint32_t j = (uint32_t)(u * (double)g->guide_n);
    if (j >= g->guide_n)
        j = g->guide_n - 1;
    return cdf_search(g->cdf, g->guide[j], g->guide[j + 1], u);
}

/* ------------------------------------------------------------------------------------------------
 * The job
 * ---------------------------------------------------------------------------------------------- */

typedef struct light_i {
    int point;
    double pos[3], dir_to[3]; /* point: position; directional: unit direction towards the light */
    double rgb[3];            /* colour * intensity */
} light_i;

typedef struct task_stats {
    uint64_t candidates, accepted, rays, events, lost;
    int64_t surface, skipped, converged, at_max;
    double trace_s;           /* truth_sss_hooks.time_trace: seconds inside rtcOccluded1M */
    uint64_t trace_calls;     /* rtcOccluded1M calls (shadow-ray batches) */
} task_stats;

/* The shadow rays of the brute force (and of the walk's entry points) are traced in batches:
 * the kept candidates of a pixel's round are generated in order, their shadow rays (one per light
 * that faces the point) collected into a stream of at most STREAM_RAYS rays, traced by one
 * rtcOccluded1M call, and then the candidates' contributions accumulated in candidate order with
 * the verdicts, as the per-ray code did (docs/sss/truth.md, "Shadow rays in batches"). */
#define STREAM_RAYS 1024

/* One light's share of a kept candidate: what is known before its shadow ray. */
typedef struct shadow_rec {
    double w[3];              /* unit direction towards the light */
    double e[3];              /* rgb * n.w [/ d^2]: the irradiance if unoccluded */
    int light;
} shadow_rec;

/* A kept candidate waiting for its shadow rays' verdicts. */
typedef struct kept_rec {
    uint32_t k;               /* candidate index (sample) */
    int first, count;         /* its shadow records / rays: [first, first + count) */
    const double *tri;        /* its triangle (12 doubles: n_i at +9) */
    double xi[3];
    double wgt;               /* A / p_accept */
} kept_rec;

/* Per-thread scratch for the stream. */
typedef struct sss_stream {
    RTCRay *rays;             /* STREAM_RAYS + nlights (16-byte aligned, as Embree asks) */
    shadow_rec *sh;           /* the same count */
    kept_rec *kept;           /* STREAM_RAYS */
    int nrays, nkept;
    int64_t task, batch;      /* the ray sink's (task, batch) */
} sss_stream;

typedef struct sss_job {
    const truth_scene *ts;
    const obs_scene *scene;
    const obs_camera *cam;
    const rast_gbuffer *gb;
    truth_sss_params p;
    inst_geo *geo;            /* per instance */
    light_i *lights;
    int nlights;
    double extent;            /* scene bounds' largest side (offset rule) */
    obs_tiling tiling;
    truth_sss_result *out;
    task_stats *ts_stats;     /* per task */
    int64_t task_offset;      /* of the chunk being run */
    const unsigned char *task_mask; /* truth_sss_render_tasks: the tasks to render (NULL = all) */
    const truth_sss_hooks *hooks;   /* truth_sss_render_ex (NULL = none) */
    sss_stream *streams;            /* per pool thread */
} sss_job;

static double offset_at(const sss_job *J, const double *p)
{
    double m = fmax(fmax(fabs(p[0]), fabs(p[1])), fmax(fabs(p[2]), J->extent));
    return (double)J->p.offset_ulps * 0x1p-24 * m;
}

static void trace(const truth_scene *ts, const double *o, const double *d, double tnear, double tfar, truth_hit *h)
{
    truth_intersect1(ts, obs_v3((float)o[0], (float)o[1], (float)o[2]), obs_v3((float)d[0], (float)d[1], (float)d[2]),
                     (float)tnear, isinf(tfar) ? INFINITY : (float)tfar, h);
}

/* Light L at x (normal n): whether it can light x (n.w > 0), and if so its irradiance factor
 * e = rgb * n.w [/ d^2] if unoccluded, the direction w to it, and its shadow ray: from
 * x + eps n along w over [0, d - 2 eps] (point) or [0, inf) (directional), in float as
 * truth_intersect1 takes it. V = 1 iff nothing is hit on it. */
static int light_setup(const sss_job *J, const light_i *L, const double *x, const double *n, double *w, double *e,
                       RTCRay *ray)
{
    double dist = INFINITY, scale = 1.0;
    if (L->point) {
        sub3(L->pos, x, w);
        dist = len3(w);
        if (!norm3(w))
            return 0;
        scale = 1.0 / (dist * dist);
    } else {
        memcpy(w, L->dir_to, sizeof(double) * 3);
    }
    double c = dot3(n, w);
    if (!(c > 0.0))
        return 0;
    double eps = offset_at(J, x), o[3];
    for (int a = 0; a < 3; a++)
        o[a] = x[a] + eps * n[a];
    for (int k = 0; k < 3; k++)
        e[k] = L->rgb[k] * c * scale;
    const double tfar = isinf(dist) ? INFINITY : dist - 2.0 * eps;
    ray->org_x = (float)o[0]; ray->org_y = (float)o[1]; ray->org_z = (float)o[2];
    ray->tnear = 0.0f;
    ray->dir_x = (float)w[0]; ray->dir_y = (float)w[1]; ray->dir_z = (float)w[2];
    ray->time = 0.0f;
    ray->tfar = isinf(tfar) ? INFINITY : (float)tfar;
    ray->mask = 0xFFFFFFFFu;
    ray->id = 0;
    ray->flags = 0;
    return 1;
}

/* What a walk scores. */
typedef struct walk_target {
    int score;                /* 0: count escaped power (reflectance mode) */
    const double *xo, *wt;    /* x_o and the inside direction travelling to it */
    double rho;
} walk_target;

/* One photon of unit power walking inside instance `inst` from x (on the surface) along d.
 * Returns the score: with a target, Sum over collisions of W alpha p_HG(d_in.w_t) e^{-sigma_t s}
 * / |n(x').w_t| for the collisions whose ray along w_t first leaves the medium at x' within rho of
 * x_o; without, the escaped power. Streams: dims base + 2 * event (+1). */
static double walk(const sss_job *J, uint32_t inst, const sss_channel *ch, double g, double eta, const double *x0,
                   const double *d0, uint64_t pix, uint32_t sample, uint32_t base, const walk_target *tg,
                   task_stats *S)
{
    const double sigma_t = ch->sigma_t, albedo = ch->sigma_s / ch->sigma_t;
    double x[3] = {x0[0], x0[1], x0[2]}, d[3] = {d0[0], d0[1], d0[2]};
    double W = 1.0, score = 0.0, tnear = offset_at(J, x0);
    if (!(sigma_t > 0.0))
        return 0.0;
    for (int ev = 0;; ev++) {
        if (ev >= J->p.max_bounces) {
            S->lost++;
            return score;
        }
        uint32_t w[4], w2[4];
        obs_rng_u32x4(pix, sample, base + 2u * (uint32_t)ev, J->p.seed, w);
        S->events++;
        double s = -log(1.0 - u53(w[0], w[1])) / sigma_t; /* free path, pdf sigma_t e^{-sigma_t s} */
        truth_hit h;
        trace(J->ts, x, d, tnear, s, &h);
        S->rays++;
        if (h.instance != ID_NONE && (double)h.t <= s) {
            double n[3] = {h.ng.x, h.ng.y, h.ng.z};
            double c = dot3(n, d);
            if (h.instance != inst || !(c > 0.0)) {
                S->lost++; /* another object, or a hit from outside: a leak (counted, not scored) */
                return score;
            }
            obs_rng_u32x4(pix, sample, base + 2u * (uint32_t)ev + 1u, J->p.seed, w2);
            /* Fresnel from inside: the ray arrives at cos c with relative index 1/eta
             * (sss_fresnel_reflectance returns 1 on total internal reflection). */
            double F = eta == 1.0 ? 0.0 : sss_fresnel_reflectance(c, 1.0 / eta);
            for (int a = 0; a < 3; a++)
                x[a] += (double)h.t * d[a];
            if (u32o(w2[0]) < F) {
                for (int a = 0; a < 3; a++)
                    d[a] -= 2.0 * c * n[a];
                norm3(d);
                tnear = offset_at(J, x);
                continue;
            }
            if (!tg->score)
                score += W;
            return score;
        }
        /* a collision at v = x + s d */
        for (int a = 0; a < 3; a++)
            x[a] += s * d[a];
        tnear = 0.0;
        if (tg->score) {
            double r[3], c = 0.0;
            sub3(x, tg->xo, r);
            double along = dot3(r, tg->wt), perp2 = dot3(r, r) - along * along;
            /* prefilter: a point of the disk lies within rho of x_o, so v within rho of the line
             * x_o + t w_t (exact: the distance from v to the line equals that from x') */
            if (perp2 < tg->rho * tg->rho) {
                truth_hit hs;
                trace(J->ts, x, tg->wt, 0.0, INFINITY, &hs);
                S->rays++;
                if (hs.instance == inst) {
                    double n[3] = {hs.ng.x, hs.ng.y, hs.ng.z}, xp[3], q[3];
                    c = dot3(n, tg->wt);
                    for (int a = 0; a < 3; a++)
                        xp[a] = x[a] + (double)hs.t * tg->wt[a];
                    sub3(xp, tg->xo, q);
                    if (c > 0.0 && dot3(q, q) < tg->rho * tg->rho)
                        score += W * albedo * hg_pdf(g, dot3(d, tg->wt)) * exp(-sigma_t * (double)hs.t) / c;
                }
            }
        }
        W *= albedo; /* absorption by weight */
        obs_rng_u32x4(pix, sample, base + 2u * (uint32_t)ev + 1u, J->p.seed, w2);
        if (W < RR_LEVEL) {
            if (u32o(w2[1]) * RR_LEVEL >= W)
                return score; /* roulette: survive with probability W / RR_LEVEL */
            W = RR_LEVEL;
        }
        double nd[3];
        hg_sample(g, d, u32o(w[2]), u32o(w[3]), nd);
        memcpy(d, nd, sizeof nd);
    }
}

typedef struct pixel_in {
    uint64_t pix;
    uint32_t inst;
    const sss_constants *c;
    double xo[3], no[3], wo[3], wt[3];
    double sigma_star;
    int wt_ok;
} pixel_in;

/* Trace the stream's rays: one rtcOccluded1M call on the truth scene (an occluded ray gets
 * tfar = -inf, Embree's mark). Any hit within [tnear, tfar] is what the per-ray code asked of
 * truth_intersect1's closest hit (h.instance != none), so the verdicts are the same (measured:
 * docs/sss/truth.md, "Shadow rays in batches"). hooks->per_ray keeps that per-ray path, for the
 * test that compares the two. */
static void stream_trace(const sss_job *J, sss_stream *st, task_stats *S)
{
    const int n = st->nrays;
    if (n == 0)
        return;
    const truth_sss_hooks *H = J->hooks;
    if (H && H->ray_sink)
        H->ray_sink(H->user, st->task, st->batch, st->rays, n, sizeof(RTCRay));
    if (H && H->per_ray) {
        for (int i = 0; i < n; i++) {
            RTCRay *r = &st->rays[i];
            truth_hit h;
            truth_intersect1(J->ts, obs_v3(r->org_x, r->org_y, r->org_z), obs_v3(r->dir_x, r->dir_y, r->dir_z), r->tnear,
                             r->tfar, &h);
            if (h.instance != ID_NONE)
                r->tfar = -INFINITY;
        }
    } else {
        struct RTCIntersectContext ictx;
        rtcInitIntersectContext(&ictx); /* the default incoherent flag, as truth_ao */
        if (H && H->time_trace) {
            const double t0 = obs_time_now();
            rtcOccluded1M(J->ts->top, &ictx, st->rays, (unsigned)n, sizeof(RTCRay));
            S->trace_s += obs_time_now() - t0;
        } else {
            rtcOccluded1M(J->ts->top, &ictx, st->rays, (unsigned)n, sizeof(RTCRay));
        }
    }
    if (H && H->traced_sink)
        H->traced_sink(H->user, st->task, st->batch, st->rays, n, sizeof(RTCRay));
    S->rays += (uint64_t)n;
    S->trace_calls++;
    st->batch++;
}

/* Candidate k: drawn, played the roulette; if kept, queued with its shadow rays. Returns 1 if
 * kept (the caller flushes the stream first when it may not have room). */
static int candidate_gen(const sss_job *J, const pixel_in *P, uint32_t k, sss_stream *st, task_stats *S)
{
    const inst_geo *G = &J->geo[P->inst];
    uint32_t w[4], b[4];
    S->candidates++;
    obs_rng_u32x4(P->pix, k, 0, J->p.seed, w);
    uint32_t t = cdf_pick(G, u53(w[0], w[1]));
    const double *T = G->tri + 12 * (size_t)t;
    obs_rng_u32x4(P->pix, k, 1, J->p.seed, b);
    /* uniform point in the triangle: (1 - sqrt(u1)) p0 + sqrt(u1)(1 - u2) p1 + sqrt(u1) u2 p2 */
    double su = sqrt(u53(b[0], b[1])), u2 = u53(b[2], b[3]), xi[3], r[3];
    for (int a = 0; a < 3; a++)
        xi[a] = T[a] + su * (1.0 - u2) * T[3 + a] + su * u2 * T[6 + a];
    sub3(xi, P->xo, r);
    double dist = len3(r);
    double pacc = exp(-P->sigma_star * dist); /* Russian roulette, dirpole.cpp trace() */
    if (!(u53(w[2], w[3]) < pacc))
        return 0;
    S->accepted++;
    kept_rec *K = &st->kept[st->nkept++];
    K->k = k;
    K->tri = T;
    memcpy(K->xi, xi, sizeof xi);
    K->wgt = G->area / pacc; /* 1 / (pdf_area * p_accept) */
    K->first = st->nrays;
    for (int l = 0; l < J->nlights; l++) {
        shadow_rec *R = &st->sh[st->nrays];
        if (!light_setup(J, &J->lights[l], xi, T + 9, R->w, R->e, &st->rays[st->nrays]))
            continue;
        R->light = l;
        st->nrays++;
    }
    K->count = st->nrays - K->first;
    return 1;
}

/* The contribution f[3] of a kept candidate (before the T21 / patch factors), its shadow rays
 * traced: the per-ray code's sum, light by light in the same order. */
static void candidate_eval(const sss_job *J, const pixel_in *P, const kept_rec *K, const sss_stream *st, double f[3],
                           task_stats *S)
{
    const double *ni = K->tri + 9, *xi = K->xi, wgt = K->wgt;
    f[0] = f[1] = f[2] = 0.0;
    for (int j = K->first; j < K->first + K->count; j++) {
        if (st->rays[j].tfar == -INFINITY)
            continue; /* occluded */
        const shadow_rec *R = &st->sh[j];
        const double *wi = R->w, *e = R->e;
        const int l = R->light;
        double t12 = 1.0 - sss_fresnel_reflectance(dot3(ni, wi), P->c->eta);
        if (J->p.estimator == TRUTH_SSS_BRUTE_FORCE) {
            for (int c = 0; c < 3; c++)
                if (e[c] != 0.0)
                    f[c] += wgt * e[c] * t12 * sss_sd(P->c, J->p.model, c, xi, ni, wi, P->xo, P->no);
        } else {
            double din[3], dl[3] = {-wi[0], -wi[1], -wi[2]};
            if (!refract_in(dl, ni, P->c->eta, din))
                continue;
            walk_target tg = {1, P->xo, P->wt, J->p.patch_radius};
            for (int c = 0; c < 3; c++) {
                if (e[c] == 0.0)
                    continue;
                uint32_t base = WALK_DIM0 + ((uint32_t)(l * 3 + c) << 21);
                f[c] += wgt * e[c] * t12 *
                        walk(J, P->inst, &P->c->ch[c], P->c->material.g, P->c->eta, xi, din, P->pix, K->k, base, &tg, S);
            }
        }
    }
}

/* Trace the stream and add its kept candidates' contributions to their replicates, in candidate
 * order. The rejected candidates in between contributed 0.0 in the per-ray code: adding +0.0
 * changes no sum (a sum that starts at +0.0 is never -0.0 under round-to-nearest), so they are
 * not queued. */
static void stream_flush(const sss_job *J, const pixel_in *P, sss_stream *st, double (*sum)[3], int Rn, task_stats *S)
{
    stream_trace(J, st, S);
    for (int i = 0; i < st->nkept; i++) {
        double f[3];
        candidate_eval(J, P, &st->kept[i], st, f, S);
        int r = (int)(st->kept[i].k % (uint32_t)Rn);
        for (int c = 0; c < 3; c++)
            sum[r][c] += f[c];
    }
    st->nrays = st->nkept = 0;
}

static inline double lum(const double *v) { return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]; }

static void do_pixel(sss_job *J, int x, int y, sss_stream *st, task_stats *S)
{
    const rast_gbuffer *gb = J->gb;
    const int gx = x + gb->guard, gy = y + gb->guard;
    truth_sss_result *R = J->out;
    float depth = obs_image_f32_row(&gb->depth, gy)[gx];
    uint32_t inst = obs_image_u32_row(&gb->instance_id, gy)[gx];
    uint32_t prim = obs_image_u32_row(&gb->prim_id, gy)[gx];
    if (!isfinite(depth) || inst >= J->scene->instance_count || !J->geo[inst].c || prim >= J->geo[inst].n) {
        S->skipped++;
        return;
    }
    pixel_in P;
    P.pix = (uint64_t)y * (uint64_t)R->width + (uint64_t)x;
    P.inst = inst;
    P.c = J->geo[inst].c;
    obs_dvec3 o, d;
    rast_pixel_ray(&gb->constants, J->cam, gx + 0.5, gy + 0.5, &o, &d);
    double dd[3] = {d.x, d.y, d.z};
    P.xo[0] = o.x + (double)depth * d.x;
    P.xo[1] = o.y + (double)depth * d.y;
    P.xo[2] = o.z + (double)depth * d.z;
    memcpy(P.no, J->geo[inst].tri + 12 * (size_t)prim + 9, sizeof P.no);
    P.wo[0] = -dd[0]; P.wo[1] = -dd[1]; P.wo[2] = -dd[2];
    double cos_o = norm3(P.wo) ? dot3(P.no, P.wo) : 0.0;
    if (!(cos_o > 0.0)) {
        S->skipped++; /* degenerate triangle, or the surface seen from inside */
        return;
    }
    /* w_t: the camera ray refracted into the medium, reversed (it travels out to x_o) */
    double tin[3] = {0, 0, 0};
    {
        double dn[3] = {dd[0], dd[1], dd[2]};
        norm3(dn);
        P.wt_ok = refract_in(dn, P.no, P.c->eta, tin);
    }
    P.wt[0] = -tin[0]; P.wt[1] = -tin[1]; P.wt[2] = -tin[2];
    P.sigma_star = J->p.sigma_star > 0.0 ? J->p.sigma_star : P.c->min_sigma_tr;
    const double t21 = 1.0 - sss_fresnel_reflectance(cos_o, P.c->eta);
    double scale = t21;
    if (J->p.estimator == TRUTH_SSS_RANDOM_WALK)
        /* radiance leaving = T21 L_inside / eta^2 (n^2-scaled radiance), averaged over the disk */
        scale = t21 / (P.c->eta * P.c->eta * OBS_PI * J->p.patch_radius * J->p.patch_radius);
    const int Rn = J->p.replicates, B = J->p.batch;
    double sum[TRUTH_SSS_MAX_REPLICATES][3];
    memset(sum, 0, sizeof sum);
    int64_t n = 0;
    double mean[3] = {0, 0, 0}, se[3] = {0, 0, 0};
    int converged = 0;
    S->surface++;
    if (J->p.estimator == TRUTH_SSS_RANDOM_WALK && !P.wt_ok)
        n = J->p.min_samples; /* total internal reflection of the view ray: nothing leaves (T21 = 0) */
    while (n < J->p.max_samples && !(J->p.estimator == TRUTH_SSS_RANDOM_WALK && !P.wt_ok)) {
        for (int k = 0; k < B; k++) {
            if (st->nkept == STREAM_RAYS || st->nrays + J->nlights > STREAM_RAYS)
                stream_flush(J, &P, st, sum, Rn, S); /* room for one more kept candidate */
            candidate_gen(J, &P, (uint32_t)(n + k), st, S);
        }
        stream_flush(J, &P, st, sum, Rn, S);
        n += B;
        if (n < J->p.min_samples)
            continue;
        /* replicate means m_r = sum_r / (n/R); estimate = mean of m_r; SE = sd(m_r)/sqrt(R) */
        const double per = (double)(n / Rn);
        double my = 0.0, vy = 0.0;
        for (int c = 0; c < 3; c++) {
            double m = 0.0, v = 0.0;
            for (int r = 0; r < Rn; r++)
                m += sum[r][c] / per;
            m /= Rn;
            for (int r = 0; r < Rn; r++) {
                double q = sum[r][c] / per - m;
                v += q * q;
            }
            mean[c] = m;
            se[c] = sqrt(v / ((double)Rn * (Rn - 1)));
        }
        my = lum(mean);
        for (int r = 0; r < Rn; r++) {
            double mr[3] = {sum[r][0] / per, sum[r][1] / per, sum[r][2] / per};
            double q = lum(mr) - my;
            vy += q * q;
        }
        double sey = sqrt(vy / ((double)Rn * (Rn - 1)));
        /* Never stop on zero variance: replicates that all agree (a pixel that has seen no light,
         * or a light path rarer than 1/n) say nothing about the error, so such a pixel goes on to
         * max_samples (docs/sss/truth.md, "Statistics"). */
        if (sey > 0.0 && sey <= J->p.target_rel_error * my) {
            converged = 1;
            break;
        }
    }
    if (converged)
        S->converged++;
    if (n >= J->p.max_samples && !converged)
        S->at_max++;
    for (int c = 0; c < 3; c++) {
        obs_image_f32_row(&R->radiance[c], y)[x] = (float)(mean[c] * scale);
        obs_image_f32_row(&R->std_error[c], y)[x] = (float)(se[c] * scale);
    }
    obs_image_f32_row(&R->count, y)[x] = (float)n;
}

static void sss_task(void *user, int64_t task, int thread)
{
    sss_job *J = (sss_job *)user;
    const unsigned int saved_csr = _mm_getcsr();
    truth_thread_init(); /* FTZ/DAZ, as Embree asks; restored below */
    task += J->task_offset;
    task_stats *S = &J->ts_stats[task];
    memset(S, 0, sizeof *S);
    if (J->task_mask && !J->task_mask[task]) { /* another caller's task: its pixels stay zero */
        _mm_setcsr(saved_csr);
        return;
    }
    int x0, y0, x1, y1;
    obs_tiling_rect(&J->tiling, task, &x0, &y0, &x1, &y1);
    sss_stream *st = &J->streams[thread];
    st->nrays = st->nkept = 0;
    st->task = task;
    st->batch = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++)
            do_pixel(J, x, y, st, S);
    _mm_setcsr(saved_csr);
}

void truth_sss_result_free(truth_sss_result *r)
{
    if (!r)
        return;
    for (int c = 0; c < 3; c++) {
        obs_image_f32_free(&r->radiance[c]);
        obs_image_f32_free(&r->std_error[c]);
    }
    obs_image_f32_free(&r->count);
    memset(r, 0, sizeof *r);
}

static void geo_free(inst_geo *g, uint32_t n)
{
    if (!g)
        return;
    for (uint32_t i = 0; i < n; i++) {
        free(g[i].tri);
        free(g[i].cdf);
        free(g[i].guide);
    }
    free(g);
}

/* Materials, geometry and (walk) closedness of every translucent instance. */
static obs_status prepare(obs_context *ctx, const obs_scene *scene, const sss_scene_materials *mats, int walk,
                          inst_geo **geo_out)
{
    inst_geo *geo = (inst_geo *)calloc(scene->instance_count ? scene->instance_count : 1, sizeof(inst_geo));
    if (!geo)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory");
    obs_status st = OBS_STATUS_OK;
    for (uint32_t i = 0; i < scene->instance_count && st == OBS_STATUS_OK; i++) {
        if (scene->instances[i].mesh >= scene->mesh_count) {
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: instance %u names no mesh", i);
            break;
        }
        const sss_constants *c = inst_material(scene, mats, i);
        if (!c)
            continue;
        const obs_mesh *mesh = &scene->meshes[scene->instances[i].mesh];
        if (walk) {
            uint64_t open = 0;
            int closed = truth_sss_mesh_is_closed(mesh, &open);
            if (closed < 0) {
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory checking mesh '%s'", mesh->name);
                break;
            }
            if (!closed) {
                st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                               "truth sss: the random walk needs a closed mesh, but mesh '%s' (instance %u) has %llu "
                               "edge(s) not shared by exactly two triangles",
                               mesh->name, i, (unsigned long long)open);
                break;
            }
        }
        geo[i].c = c;
        st = geo_build(ctx, scene, i, &geo[i]);
    }
    if (st != OBS_STATUS_OK) {
        geo_free(geo, scene->instance_count);
        return st;
    }
    *geo_out = geo;
    return OBS_STATUS_OK;
}

static obs_status check_mats(obs_context *ctx, const obs_scene *scene, const sss_scene_materials *mats)
{
    if (!mats)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: materials is NULL");
    if (mats->count != scene->material_count || (mats->count && (!mats->constants || !mats->translucent)))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: materials has %u entries (constants/translucent %s), the scene %u",
                         mats->count, mats->count && (!mats->constants || !mats->translucent) ? "NULL" : "set",
                         scene->material_count);
    return OBS_STATUS_OK;
}

int64_t truth_sss_task_count(int width, int height, int tile)
{
    if (width < 1 || height < 1 || tile < 1 || tile > 64)
        return 0;
    obs_tiling t = obs_tiling_make(width, height, tile);
    return obs_tiling_count(&t);
}

void truth_sss_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1)
{
    obs_tiling t = obs_tiling_make(width, height, tile);
    obs_tiling_rect(&t, task, x0, y0, x1, y1);
}

static obs_status render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                               const sss_scene_materials *mats, const obs_camera *camera, const struct rast_gbuffer *gb,
                               const truth_sss_params *p, const unsigned char *task_mask, truth_sss_result *out,
                               const truth_sss_hooks *hooks);

obs_status truth_sss_render(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                            const sss_scene_materials *mats, const obs_camera *camera, const struct rast_gbuffer *gb,
                            const truth_sss_params *p, truth_sss_result *out)
{
    return render_tasks(ctx, pool, ts, scene, mats, camera, gb, p, NULL, out, NULL);
}

obs_status truth_sss_render_ex(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                               const sss_scene_materials *mats, const obs_camera *camera,
                               const struct rast_gbuffer *gb, const truth_sss_params *p, truth_sss_result *out,
                               const truth_sss_hooks *hooks)
{
    return render_tasks(ctx, pool, ts, scene, mats, camera, gb, p, NULL, out, hooks);
}

obs_status truth_sss_render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                  const sss_scene_materials *mats, const obs_camera *camera,
                                  const struct rast_gbuffer *gb, const truth_sss_params *p,
                                  const unsigned char *task_mask, truth_sss_result *out)
{
    return render_tasks(ctx, pool, ts, scene, mats, camera, gb, p, task_mask, out, NULL);
}

static void streams_free(sss_stream *s, int n)
{
    for (int i = 0; s && i < n; i++) {
        obs_aligned_free(s[i].rays);
        free(s[i].sh);
        free(s[i].kept);
    }
    free(s);
}

/* One stream per pool thread; NULL when out of memory. */
static sss_stream *streams_alloc(int n)
{
    sss_stream *s = (sss_stream *)calloc((size_t)n, sizeof(sss_stream));
    for (int i = 0; s && i < n; i++) {
        s[i].rays = (RTCRay *)obs_aligned_alloc(sizeof(RTCRay) * STREAM_RAYS);
        s[i].sh = (shadow_rec *)malloc(sizeof(shadow_rec) * STREAM_RAYS);
        s[i].kept = (kept_rec *)malloc(sizeof(kept_rec) * STREAM_RAYS);
        if (!s[i].rays || !s[i].sh || !s[i].kept) {
            streams_free(s, n);
            return NULL;
        }
    }
    return s;
}

static obs_status render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                               const sss_scene_materials *mats, const obs_camera *camera, const struct rast_gbuffer *gb,
                               const truth_sss_params *p, const unsigned char *task_mask, truth_sss_result *out,
                               const truth_sss_hooks *hooks)
{
    double t0 = obs_time_now();
    if (out)
        memset(out, 0, sizeof *out);
    if (!ts || !scene || !camera || !gb || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: a NULL argument (ts, scene, camera, gb or out)");
    obs_status st = truth_sss_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    if ((st = check_mats(ctx, scene, mats)) != OBS_STATUS_OK)
        return st;
    const obs_limits lim_def = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &lim_def;
    if (p->max_samples > lim->max_samples)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "truth sss: max_samples %lld over the limit %lld (raise it with --max-spp)",
                         (long long)p->max_samples, (long long)lim->max_samples);
    if (!gb->depth.data || !gb->prim_id.data || !gb->instance_id.data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss: the G-buffer lacks a plane (needs depth, prim_id and instance_id)");
    if (gb->constants.full_width != gb->width || gb->constants.full_height != gb->height)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: the G-buffer has not been rendered (no constants)");
    if (scene->light_count > WALK_MAX_STREAMS / 3)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "truth sss: %u lights, at most %d", scene->light_count,
                         WALK_MAX_STREAMS / 3);
    sss_job J;
    memset(&J, 0, sizeof J);
    J.lights = (light_i *)calloc(scene->light_count ? scene->light_count : 1, sizeof(light_i));
    if (!J.lights)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory");
    for (uint32_t l = 0; l < scene->light_count; l++) {
        const obs_light *L = &scene->lights[l];
        light_i *o = &J.lights[J.nlights];
        if (L->type == OBS_LIGHT_SPOT) {
            free(J.lights);
            return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "truth sss: light '%s' is a spot light (directional and point only)",
                             L->name);
        }
        o->point = L->type == OBS_LIGHT_POINT;
        o->pos[0] = L->position.x; o->pos[1] = L->position.y; o->pos[2] = L->position.z;
        o->dir_to[0] = -(double)L->direction.x; o->dir_to[1] = -(double)L->direction.y; o->dir_to[2] = -(double)L->direction.z;
        o->rgb[0] = (double)L->color.x * L->intensity;
        o->rgb[1] = (double)L->color.y * L->intensity;
        o->rgb[2] = (double)L->color.z * L->intensity;
        if ((!o->point && !norm3(o->dir_to)) || !isfinite(o->rgb[0] + o->rgb[1] + o->rgb[2]) ||
            !isfinite(o->pos[0] + o->pos[1] + o->pos[2])) {
            free(J.lights);
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss: light '%s' has a non-finite or zero field",
                             L->name);
        }
        J.nlights++;
    }
    st = prepare(ctx, scene, mats, p->estimator == TRUTH_SSS_RANDOM_WALK, &J.geo);
    if (st != OBS_STATUS_OK) {
        free(J.lights);
        return st;
    }
    const int W = gb->width - 2 * gb->guard, H = gb->height - 2 * gb->guard;
    out->width = W;
    out->height = H;
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++) {
        st = obs_image_f32_alloc(ctx, W, H, &out->radiance[c]);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &out->std_error[c]);
    }
    if (st == OBS_STATUS_OK)
        st = obs_image_f32_alloc(ctx, W, H, &out->count);
    J.tiling = obs_tiling_make(W, H, p->tile);
    int64_t ntasks = obs_tiling_count(&J.tiling);
    const int nthreads = pool ? obs_pool_threads(pool) : 1;
    if (st == OBS_STATUS_OK) {
        J.ts_stats = (task_stats *)calloc((size_t)ntasks, sizeof(task_stats));
        J.streams = streams_alloc(nthreads);
        if (!J.ts_stats || !J.streams)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss: out of memory");
    }
    if (st != OBS_STATUS_OK) {
        free(J.ts_stats);
        streams_free(J.streams, nthreads);
        truth_sss_result_free(out);
        geo_free(J.geo, scene->instance_count);
        free(J.lights);
        return st;
    }
    J.ts = ts;
    J.scene = scene;
    J.cam = camera;
    J.gb = gb;
    J.p = *p;
    J.out = out;
    J.task_mask = task_mask; /* the planes are zeroed at allocation: the tasks left out stay 0 */
    J.hooks = hooks;
    {
        obs_aabb b = scene->bounds;
        double e = fmax(fmax(b.hi.x - b.lo.x, b.hi.y - b.lo.y), b.hi.z - b.lo.z);
        J.extent = isfinite(e) && e > 0.0 ? e : 1.0;
    }
    /* run in chunks so that progress is reported on this thread between them; the chunking does
     * not change the output (a task is a tile, its pixels' streams are their own) */
    const int64_t chunk = (int64_t)(pool ? obs_pool_threads(pool) : 1) * 4;
    for (int64_t first = 0; first < ntasks; first += chunk) {
        int64_t cnt = ntasks - first < chunk ? ntasks - first : chunk;
        J.task_offset = first;
        obs_pool_run(pool, cnt, sss_task, &J);
        if (p->progress) {
            uint64_t rays = 0;
            for (int64_t k = 0; k < first + cnt; k++)
                rays += J.ts_stats[k].rays;
            p->progress(p->progress_user, first + cnt, ntasks, rays);
        }
    }
    truth_sss_stats *S = &out->stats;
    double trace_s = 0.0;
    uint64_t trace_calls = 0;
    for (int64_t k = 0; k < ntasks; k++) {
        const task_stats *T = &J.ts_stats[k];
        S->candidates += T->candidates;
        S->accepted += T->accepted;
        S->rays += T->rays;
        S->walk_events += T->events;
        S->walks_lost += T->lost;
        S->pixels_surface += T->surface;
        S->pixels_skipped += T->skipped;
        S->pixels_converged += T->converged;
        S->pixels_at_max += T->at_max;
        trace_s += T->trace_s;
        trace_calls += T->trace_calls;
    }
    if (hooks && hooks->trace_seconds)
        *hooks->trace_seconds = trace_s;
    if (hooks && hooks->trace_calls)
        *hooks->trace_calls = trace_calls;
    free(J.ts_stats);
    streams_free(J.streams, nthreads);
    geo_free(J.geo, scene->instance_count);
    free(J.lights);
    S->seconds = obs_time_now() - t0;
    return OBS_STATUS_OK;
}

obs_status truth_sss_walk_reflectance(obs_context *ctx, const truth_scene *ts, const obs_scene *scene,
                                      const sss_scene_materials *mats, uint32_t instance, const double x_i[3],
                                      const double n_i[3], const double dir[3], int channel, int64_t count,
                                      uint64_t seed, double *reflectance, double *std_error)
{
    if (!ts || !scene || !x_i || !n_i || !dir || !reflectance || !std_error)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss walk: a NULL argument");
    if (count < 2 || count > ((int64_t)1 << 32) || channel < 0 || channel > 2)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss walk: count %lld not in [2, 2^32] or channel %d not in [0, 2]",
                         (long long)count, channel);
    obs_status st = check_mats(ctx, scene, mats);
    if (st != OBS_STATUS_OK)
        return st;
    if (instance >= scene->instance_count || scene->instances[instance].mesh >= scene->mesh_count)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss walk: no instance %u", instance);
    const sss_constants *c = inst_material(scene, mats, instance);
    const obs_mesh *mesh = &scene->meshes[scene->instances[instance].mesh];
    if (!c)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss walk: mesh '%s' (instance %u) is not translucent",
                         mesh->name, instance);
    uint64_t open = 0;
    int closed = truth_sss_mesh_is_closed(mesh, &open);
    if (closed < 0)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth sss walk: out of memory");
    if (!closed)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth sss walk: the random walk needs a closed mesh, but mesh '%s' (instance %u) has %llu "
                         "edge(s) not shared by exactly two triangles",
                         mesh->name, instance, (unsigned long long)open);
    sss_job J;
    memset(&J, 0, sizeof J);
    J.ts = ts;
    J.scene = scene;
    J.p = truth_sss_params_default();
    J.p.seed = seed;
    {
        obs_aabb b = scene->bounds;
        double e = fmax(fmax(b.hi.x - b.lo.x, b.hi.y - b.lo.y), b.hi.z - b.lo.z);
        J.extent = isfinite(e) && e > 0.0 ? e : 1.0;
    }
    double d[3] = {dir[0], dir[1], dir[2]};
    if (!norm3(d) || !(dot3(d, n_i) < 0.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth sss walk: dir must point into the medium (dir.n_i < 0)");
    const unsigned int saved_csr = _mm_getcsr();
    truth_thread_init();
    task_stats S;
    memset(&S, 0, sizeof S);
    walk_target tg = {0, NULL, NULL, 0.0};
    double s1 = 0.0, s2 = 0.0;
    for (int64_t k = 0; k < count; k++) {
        double r = walk(&J, instance, &c->ch[channel], c->material.g, c->eta, x_i, d, 0, (uint32_t)k,
                        WALK_DIM0 + ((uint32_t)channel << 21), &tg, &S);
        s1 += r;
        s2 += r * r;
    }
    _mm_setcsr(saved_csr);
    double m = s1 / (double)count, v = (s2 / (double)count - m * m) * (double)count / (double)(count - 1);
    *reflectance = m;
    *std_error = sqrt(fmax(0.0, v) / (double)count);
    return OBS_STATUS_OK;
}
