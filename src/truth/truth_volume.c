/* truth_volume.c: the exact hard-shadow transmittance the light volume approximates
 * (../shared/reference/volume.md 1.9; docs/volume/light.md, "Ground truth").
 *
 * T(x) = exp(-integral_0^L sigma_t(x + t w) dt), w the unit direction towards the light, L the
 * distance to the point light or to where the ray leaves the data's bounds (vol_grid_bounds),
 * sigma_t(y) = -kappa ln(1 - alpha_TF(s(y))) / ref_step (vol.h's one convention,
 * vol_sigma_from_alpha), s the data's trilinear value (clamped to the edge inside the bounds),
 * 0 outside the bounds. The integral is the trapezoid rule with a fine step h = step_fraction x
 * the smallest spacing (the last step shortened to end exactly at L): exact (up to rounding) where
 * sigma_t is constant, O(h^2) otherwise. Along a grid line s is piecewise linear with kinks at the
 * voxel centres, and with 1/step_fraction an integer the samples from a voxel centre land on every
 * kink; sigma_t(s) is still curved between them (-ln(1 - alpha) is not linear in alpha): for the
 * slab with a one-voxel ramp and alpha 0 -> 0.3, 2.7e-5 in T at the default h = 1/16 voxel and
 * 6.8e-6 at 1/32 (volume_light_truth_march_matches_slab_analytic). */
#include "truth.h"

#include "../raster/raster.h"
#include "../volume/vol.h"
#include "../volume/vol_raycast_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TRUTH_VOLUME_DEFAULT_STEP_FRACTION (1.0 / 16.0) /* of the smallest spacing; 16 steps per voxel
                                                           land on every kink of an axis-aligned ray;
                                                           O(h^2) in the curved sigma_t between them */
#define TRUTH_VOLUME_DEFAULT_KAPPA 1.0                  /* as vol_lv_params_default (vol.h) */

truth_volume_params truth_volume_params_default(void)
{
    truth_volume_params p;
    p.kappa = TRUTH_VOLUME_DEFAULT_KAPPA;
    p.step_fraction = TRUTH_VOLUME_DEFAULT_STEP_FRACTION;
    return p;
}

typedef struct tv_ctx {
    const vol_grid *g;
    const vol_tf *tf;
    const vol_light *light;
    double sigma_scale, ref_step, h;
    double lo[3], hi[3];
    double D[3];                 /* directional: unit travel direction */
    const vol_light_volume *lv;
    float *T, *err;
    const unsigned char *slice_mask; /* NULL: every z slice; else only slices k with slice_mask[k] */
} tv_ctx;

static double tv_sigma(const tv_ctx *c, const double y[3])
{
    for (int a = 0; a < 3; a++)
        if (y[a] < c->lo[a] || y[a] > c->hi[a])
            return 0.0;
    const vol_grid *g = c->g;
    float s = vol_grid_sample(g, (y[0] - g->origin[0]) / g->spacing[0], (y[1] - g->origin[1]) / g->spacing[1],
                              (y[2] - g->origin[2]) / g->spacing[2]);
    float rgba[4];
    vol_tf_eval(c->tf, s, rgba);
    return c->sigma_scale * vol_sigma_from_alpha(rgba[3], c->ref_step);
}

static double tv_transmittance(const tv_ctx *c, const double x[3])
{
    /* Direction towards the light and the distance to integrate over. */
    double w[3], L;
    if (c->light->type == OBS_LIGHT_POINT) {
        double d[3] = {c->light->position[0] - x[0], c->light->position[1] - x[1], c->light->position[2] - x[2]};
        L = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(L > 0.0))
            return 1.0;
        for (int a = 0; a < 3; a++)
            w[a] = d[a] / L;
    } else {
        for (int a = 0; a < 3; a++)
            w[a] = -c->D[a];
        L = INFINITY;
    }
    /* Clip [0, L] to the bounds (slab method). x outside the bounds contributes only once the ray
     * enters them; the integrand is 0 outside anyway. */
    double t0 = 0.0, t1 = L;
    for (int a = 0; a < 3; a++) {
        if (w[a] == 0.0) {
            if (x[a] < c->lo[a] || x[a] > c->hi[a])
                return 1.0;
            continue;
        }
        double ta = (c->lo[a] - x[a]) / w[a], tb = (c->hi[a] - x[a]) / w[a];
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > t0)
            t0 = ta;
        if (tb < t1)
            t1 = tb;
    }
    if (!(t1 > t0))
        return 1.0;
    /* Trapezoid rule from t0 with step h, the last step ending at t1. */
    double acc = 0.0, tprev = t0;
    double y[3] = {x[0] + t0 * w[0], x[1] + t0 * w[1], x[2] + t0 * w[2]};
    double sprev = tv_sigma(c, y);
    int64_t steps = (int64_t)ceil((t1 - t0) / c->h - 1e-9);
    if (steps < 1)
        steps = 1;
    for (int64_t s = 1; s <= steps; s++) {
        double t = s == steps ? t1 : t0 + (double)s * c->h;
        for (int a = 0; a < 3; a++)
            y[a] = x[a] + t * w[a];
        /* The end point sits on the bounds by construction; keep it inside against rounding. */
        for (int a = 0; a < 3; a++)
            y[a] = y[a] < c->lo[a] ? c->lo[a] : (y[a] > c->hi[a] ? c->hi[a] : y[a]);
        double scur = tv_sigma(c, y);
        acc += 0.5 * (sprev + scur) * (t - tprev);
        sprev = scur;
        tprev = t;
    }
    return exp(-acc);
}

double truth_volume_transmittance_at(const vol_grid *g, const vol_tf *tf, const vol_light *light,
                                     const truth_volume_params *p, const double x[3])
{
    tv_ctx c;
    memset(&c, 0, sizeof c);
    c.g = g;
    c.tf = tf;
    c.light = light;
    double hmin = fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    double ref_step = tf->ref_step > 0.0 ? tf->ref_step : hmin;
    c.sigma_scale = p->kappa;
    c.ref_step = ref_step;
    c.h = p->step_fraction * hmin;
    vol_grid_bounds(g, c.lo, c.hi);
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        for (int a = 0; a < 3; a++)
            c.D[a] = light->direction[a] / len;
    }
    return tv_transmittance(&c, x);
}

/* One z slice of the light volume per task. */
static void tv_slice_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const tv_ctx *c = (const tv_ctx *)user;
    const vol_light_volume *lv = c->lv;
    int k = (int)task;
    if (c->slice_mask && !c->slice_mask[k])
        return; /* another rank's slab (truth_volume_light_error_slices) */
    for (int j = 0; j < lv->ny; j++) {
        for (int i = 0; i < lv->nx; i++) {
            double x[3] = {lv->origin[0] + i * lv->spacing[0], lv->origin[1] + j * lv->spacing[1],
                           lv->origin[2] + k * lv->spacing[2]};
            size_t idx = ((size_t)k * lv->ny + j) * lv->nx + i;
            double T = tv_transmittance(c, x);
            c->T[idx] = (float)T;
            if (c->err)
                c->err[idx] = (float)((double)lv->l[idx] - T);
        }
    }
}

/* Validation shared by truth_volume_light_error and truth_volume_light_error_slices. */
static obs_status tv_check(obs_context *ctx, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                           const truth_volume_params *p, const vol_light_volume *lv)
{
    if (!g || !tf || !light || !p || !lv || !lv->l || !g->data)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_light_error: a NULL argument");
    if (light->type == OBS_LIGHT_SPOT)
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "truth volume: spot lights are not supported");
    if (light->type != OBS_LIGHT_DIRECTIONAL && light->type != OBS_LIGHT_POINT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume: unknown light type %d", (int)light->type);
    if (!isfinite(p->kappa) || p->kappa < 0.0 || !isfinite(p->step_fraction) || !(p->step_fraction > 0.0) ||
        p->step_fraction > 1.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth volume: kappa %g must be finite and >= 0, step_fraction %g in (0, 1]", p->kappa,
                         p->step_fraction);
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        if (!isfinite(len) || !(len > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume: the light's direction must be non-zero");
    } else {
        for (int a = 0; a < 3; a++)
            if (!isfinite(light->position[a]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume: the light's position must be finite");
    }
    return OBS_STATUS_OK;
}

/* T (and err) at the voxel centres of the z slices slice_mask selects (NULL: all), into the
 * caller's full-size arrays. Inputs already checked by tv_check. */
static void tv_fill(obs_pool *pool, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                    const truth_volume_params *p, const vol_light_volume *lv, const unsigned char *slice_mask,
                    float *T, float *err)
{
    tv_ctx c;
    memset(&c, 0, sizeof c);
    c.g = g;
    c.tf = tf;
    c.light = light;
    double hmin = fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    double ref_step = tf->ref_step > 0.0 ? tf->ref_step : hmin;
    c.sigma_scale = p->kappa;
    c.ref_step = ref_step;
    c.h = p->step_fraction * hmin;
    vol_grid_bounds(g, c.lo, c.hi);
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        for (int a = 0; a < 3; a++)
            c.D[a] = light->direction[a] / len;
    }
    c.lv = lv;
    c.T = T;
    c.err = err;
    c.slice_mask = slice_mask;
    obs_pool_run(pool, lv->nz, tv_slice_task, &c);
}

void truth_volume_error_stats_compute(const float *err, int64_t voxels, truth_volume_error_stats *stats)
{
    if (!stats)
        return;
    memset(stats, 0, sizeof *stats);
    if (!err || voxels < 1)
        return;
    /* Statistics in voxel order (deterministic). */
    double sum = 0.0, sum2 = 0.0, sums = 0.0;
    stats->voxels = voxels;
    for (int64_t i = 0; i < voxels; i++) {
        double e = err[i], ae = fabs(e);
        if (!(ae <= stats->max_abs)) {
            stats->max_abs = ae;
            stats->argmax = i;
        }
        sum += ae;
        sum2 += e * e;
        sums += e;
    }
    stats->mean_abs = sum / (double)voxels;
    stats->rmse = sqrt(sum2 / (double)voxels);
    stats->mean_signed = sums / (double)voxels;
}

obs_status truth_volume_light_error_slices(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                           const vol_light *light, const truth_volume_params *p,
                                           const vol_light_volume *lv, const unsigned char *slice_mask, float *T,
                                           float *err)
{
    obs_status st = tv_check(ctx, g, tf, light, p, lv);
    if (st != OBS_STATUS_OK)
        return st;
    if (!T || !err)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_light_error_slices: NULL output arrays");
    tv_fill(pool, g, tf, light, p, lv, slice_mask, T, err);
    return OBS_STATUS_OK;
}

obs_status truth_volume_light_error(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                    const vol_light *light, const truth_volume_params *p,
                                    const vol_light_volume *lv, float **T_out, float **err_out,
                                    truth_volume_error_stats *stats)
{
    if (T_out)
        *T_out = NULL;
    if (err_out)
        *err_out = NULL;
    if (stats)
        memset(stats, 0, sizeof *stats);
    obs_status st = tv_check(ctx, g, tf, light, p, lv);
    if (st != OBS_STATUS_OK)
        return st;
    size_t voxels = (size_t)lv->nx * lv->ny * lv->nz;
    float *T = (float *)obs_aligned_alloc(voxels * sizeof(float));
    float *err = (float *)obs_aligned_alloc(voxels * sizeof(float));
    if (!T || !err) {
        obs_aligned_free(T);
        obs_aligned_free(err);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth volume: out of memory");
    }
    tv_fill(pool, g, tf, light, p, lv, NULL, T, err);
    if (stats)
        truth_volume_error_stats_compute(err, (int64_t)voxels, stats);
    if (T_out)
        *T_out = T;
    else
        obs_aligned_free(T);
    if (err_out)
        *err_out = err;
    else
        obs_aligned_free(err);
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * The Monte Carlo single-scattering image reference and its deterministic march
 * (truth.h, "The Monte Carlo single-scattering image reference"; docs/volume/truth.md).
 *
 * The integral [Max95] (single scattering with the source attenuated by the exact transmittance):
 *   L = Int_0^D T_v(s) sigma_t(x_s) rho(x_s) E f T(x_s) ds,   T_v(s) = exp(-Int_0^s sigma_t),
 * the continuous limit of the ray caster's light-volume mode (vol_raycast.c: C += T_v a rgb,
 * rgb = rho E l c, a = 1 - exp(-sigma_t len) -> sigma_t ds) with l = T and c = 1; f = 4 pi p_HG.
 * ================================================================================================ */

#define TRUTH_VOLUME_MC_DEFAULT_SAMPLES 256   /* ours: a few per cent error bar on bucky (measured in
                                                 docs/volume/truth.md); a fixed count, no adaptive stop */
#define TRUTH_VOLUME_MC_DEFAULT_REPLICATES 8  /* as truth_ao (docs/truth.md section 5: 7 degrees of freedom) */
#define TRUTH_VOLUME_MC_DEFAULT_TILE 8        /* ours; any value gives the same image */
#define TRUTH_VOLUME_RR_THRESHOLD 1e-2        /* ratio tracking's Russian roulette below this weight
                                                 (survive with 1/2, weight x2: unbiased); ours */
#define TRUTH_VOLUME_MAX_STEPS_PER_RAY 16777216.0 /* the march: as the ray caster's limit */

truth_volume_mc_params truth_volume_mc_params_default(void)
{
    truth_volume_mc_params p;
    memset(&p, 0, sizeof p);
    p.samples = TRUTH_VOLUME_MC_DEFAULT_SAMPLES;
    p.replicates = TRUTH_VOLUME_MC_DEFAULT_REPLICATES;
    p.g = 0.0;
    p.kappa = TRUTH_VOLUME_DEFAULT_KAPPA;
    p.seed = 0;
    p.tile = TRUTH_VOLUME_MC_DEFAULT_TILE;
    return p;
}

void truth_volume_image_free(truth_volume_image *im)
{
    if (!im)
        return;
    for (int c = 0; c < 4; c++) {
        obs_image_f32_free(&im->rgba[c]);
        obs_image_f32_free(&im->std_error[c]);
    }
    memset(im, 0, sizeof *im);
}

typedef struct tvi_job {
    tv_ctx tc;                     /* sigma_t, bounds, light (tv_sigma, tv_transmittance) */
    const obs_camera *cam;
    rast_view_constants vc;
    obs_tiling tiling;
    int width;
    double majorant;               /* the largest brick majorant, per world unit (MC) */
    int nb[3];                     /* bricks per axis (MC) */
    float *maj;                    /* per brick (x fastest): its majorant (MC) */
    double nudge;                  /* 1e-4 x the smallest spacing: how far past a boundary a brick is looked up */
    double g_hg;
    float light_color[3];
    int64_t samples;
    int R;
    uint64_t seed;
    double step;                   /* the march's step (world units); 0 = MC */
    const obs_image_f32 *depth_limit; /* MC: per pixel, where the view ray stops (NULL: none) */
    double (*visibility)(void *user, const double x[3], const double w[3], double dist); /* MC: or NULL */
    void *visibility_user;
    truth_volume_image *out;
    truth_volume_mc_stats *tile_stats;
    const unsigned char *task_mask; /* NULL: every tile; else only tiles t with task_mask[t] (MPI) */
} tvi_job;

/* A per-(pixel, sample) stream of uniforms in (0, 1): Philox words, 4 per dimension. */
typedef struct tvi_rng {
    uint64_t pixel, seed;
    uint32_t sample, dim;
    uint32_t buf[4];
    int left;
} tvi_rng;

static double tvi_uniform(tvi_rng *r)
{
    if (r->left == 0) {
        obs_rng_u32x4(r->pixel, r->sample, r->dim++, r->seed, r->buf);
        r->left = 4;
    }
    uint32_t u = r->buf[4 - r->left--];
    return ((double)u + 0.5) * (1.0 / 4294967296.0); /* never 0 or 1 */
}

/* The TF's RGB and sigma_t at world point y (0 outside the bounds). */
static double tvi_sample(const tv_ctx *c, const double y[3], float rho[3])
{
    for (int a = 0; a < 3; a++)
        if (y[a] < c->lo[a] || y[a] > c->hi[a]) {
            rho[0] = rho[1] = rho[2] = 0.0f;
            return 0.0;
        }
    const vol_grid *g = c->g;
    float s = vol_grid_sample(g, (y[0] - g->origin[0]) / g->spacing[0], (y[1] - g->origin[1]) / g->spacing[1],
                              (y[2] - g->origin[2]) / g->spacing[2]);
    float rgba[4];
    vol_tf_eval(c->tf, s, rgba);
    rho[0] = rgba[0];
    rho[1] = rgba[1];
    rho[2] = rgba[2];
    return c->sigma_scale * vol_sigma_from_alpha(rgba[3], c->ref_step);
}

/* Direction the light travels at x (unit) and the distance to the light (INFINITY: directional). */
static int tvi_light_dir(const tv_ctx *c, const double x[3], double w_in[3], double *dist)
{
    if (c->light->type == OBS_LIGHT_POINT) {
        double d[3] = {x[0] - c->light->position[0], x[1] - c->light->position[1], x[2] - c->light->position[2]};
        double L = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(L > 0.0))
            return 0;
        for (int a = 0; a < 3; a++)
            w_in[a] = d[a] / L;
        *dist = L;
    } else {
        for (int a = 0; a < 3; a++)
            w_in[a] = c->D[a];
        *dist = INFINITY;
    }
    return 1;
}

/* f = 4 pi p_HG(cos theta) = (1 - g^2) / (1 + g^2 - 2 g cos theta)^(3/2) [Henyey41] (the 1/(4 pi) of
 * p_HG cancelled: f = 1 for g = 0, the ray caster's unweighted source). cos theta = w_in . w_out. */
static double tvi_phase(double g, const double w_in[3], const double w_out[3])
{
    if (g == 0.0)
        return 1.0;
    double ct = w_in[0] * w_out[0] + w_in[1] * w_out[1] + w_in[2] * w_out[2];
    double den = 1.0 + g * g - 2.0 * g * ct;
    return (1.0 - g * g) / (den * sqrt(den));
}

/* The segment [t0, t1] of ray o + t w inside the bounds (slabs). 0 when none. */
static int tvi_clip(const tv_ctx *c, const double o[3], const double w[3], double *t0, double *t1)
{
    for (int a = 0; a < 3; a++) {
        if (w[a] == 0.0) {
            if (o[a] < c->lo[a] || o[a] > c->hi[a])
                return 0;
            continue;
        }
        double ta = (c->lo[a] - o[a]) / w[a], tb = (c->hi[a] - o[a]) / w[a];
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > *t0)
            *t0 = ta;
        if (tb < *t1)
            *t1 = tb;
    }
    return *t1 > *t0;
}

/* ---- Tracking against the min-max brick majorants -------------------------------------------
 * The majorant is piecewise constant over bricks of TRUTH_VOLUME_BRICK voxels (the ray caster's
 * min-max bricks [Kruger03]): brick b of an axis holds the samples whose continuous voxel coordinate
 * c is in [b B, (b+1) B) (the first brick open towards -inf, the last towards +inf, as the ray
 * caster's), and its majorant is kappa sigma(max alpha_TF over the min-max of the voxels
 * [b B - 1, (b+1) B + 1]): the trilinear footprint [b B, (b+1) B] plus one voxel of apron each way,
 * so a point that float rounding puts on the wrong side of a brick boundary is still bounded.
 * Free flights restart at each brick boundary (the exponential is memoryless: exact). */

#define TRUTH_VOLUME_BRICK 8 /* voxels; as the ray caster's default (vol_rc_params_default) */

/* The brick of world point y (x fastest) and the parameter where the ray o + t w leaves it (at
 * most t1). */
static int64_t tvi_brick_at(const tvi_job *J, const double o[3], const double w[3], double t, double t1,
                            double *texit)
{
    const vol_grid *g = J->tc.g;
    const int nv[3] = {g->nx, g->ny, g->nz};
    int bi[3];
    double te = t1;
    for (int a = 0; a < 3; a++) {
        double c = (o[a] + t * w[a] - g->origin[a]) / g->spacing[a];
        int v = !(c > 0.0) ? 0 : (c >= (double)(nv[a] - 1) ? nv[a] - 1 : (int)c);
        bi[a] = v / TRUTH_VOLUME_BRICK;
        if (w[a] > 0.0 && bi[a] < J->nb[a] - 1) {
            double tb = (g->origin[a] + (double)((bi[a] + 1) * TRUTH_VOLUME_BRICK) * g->spacing[a] - o[a]) / w[a];
            if (tb < te)
                te = tb;
        } else if (w[a] < 0.0 && bi[a] > 0) {
            double tb = (g->origin[a] + (double)(bi[a] * TRUTH_VOLUME_BRICK) * g->spacing[a] - o[a]) / w[a];
            if (tb < te)
                te = tb;
        }
    }
    *texit = te;
    return ((int64_t)bi[2] * J->nb[1] + bi[1]) * J->nb[0] + bi[0];
}

/* Track the unit ray o + t w over [t0, t1] against the brick majorants.
 *   ratio = 0: delta tracking [Woodcock65]: returns 1 at the first real collision (a tentative one
 *              is real with probability sigma_t / majorant), with *t_hit and its rho; 0 on escape.
 *              The real collision's density is T_v(t) sigma_t(t).
 *   ratio = 1: ratio tracking [Novak14]: returns T = prod (1 - sigma_t / majorant) over the
 *              tentative collisions (Russian roulette below TRUTH_VOLUME_RR_THRESHOLD: survive with
 *              1/2, weight x2), an unbiased estimate of the transmittance over [t0, t1]. */
static double tvi_track(const tvi_job *J, const double o[3], const double w[3], double t0, double t1, int ratio,
                        tvi_rng *rng, truth_volume_mc_stats *st, double *t_hit, float rho[3])
{
    double t = t0, T = 1.0;
    while (t < t1) {
        double texit;
        /* the brick just ahead of t (nudge: the apron keeps its majorant valid around it) */
        int64_t b = tvi_brick_at(J, o, w, t + J->nudge, t1, &texit);
        if (!(texit > t))
            texit = t + J->nudge < t1 ? t + J->nudge : t1;
        const double mu = J->maj[b];
        if (!(mu > 0.0)) {
            t = texit;
            continue;
        }
        for (;;) {
            double tc = t - log(tvi_uniform(rng)) / mu;
            if (tc >= texit) {
                t = texit;
                break;
            }
            t = tc;
            double y[3] = {o[0] + t * w[0], o[1] + t * w[1], o[2] + t * w[2]};
            float r3[3];
            double sig = tvi_sample(&J->tc, y, r3);
            st->tentative++;
            if (sig > mu) {
                st->over_majorant++;
                sig = mu;
            }
            if (ratio) {
                T *= 1.0 - sig / mu;
                if (T <= 0.0)
                    return 0.0;
                if (T < TRUTH_VOLUME_RR_THRESHOLD) {
                    if (tvi_uniform(rng) < 0.5)
                        return 0.0;
                    T *= 2.0;
                }
            } else if (tvi_uniform(rng) * mu < sig) {
                *t_hit = t;
                rho[0] = r3[0];
                rho[1] = r3[1];
                rho[2] = r3[2];
                return 1.0;
            }
        }
    }
    return ratio ? T : 0.0;
}

/* Ratio tracking of T from x towards the light (to the point light, or out of the bounds). */
static double tvi_ratio_track(const tvi_job *J, const double x[3], const double w_in[3], double dist, tvi_rng *rng,
                              truth_volume_mc_stats *st)
{
    double w[3] = {-w_in[0], -w_in[1], -w_in[2]};
    double t0 = 0.0, t1 = dist;
    if (!tvi_clip(&J->tc, x, w, &t0, &t1))
        return 1.0;
    return tvi_track(J, x, w, t0, t1, 1, rng, st, NULL, NULL);
}

/* One pixel of the MC reference: sums per replicate of (R, G, B, escape). */
static void tvi_mc_pixel(const tvi_job *J, int x, int y, double (*acc)[4], truth_volume_mc_stats *st)
{
    obs_dvec3 O, Dv;
    rast_pixel_ray(&J->vc, J->cam, (double)x + 0.5, (double)y + 0.5, &O, &Dv);
    const double o[3] = {O.x, O.y, O.z}, d[3] = {Dv.x, Dv.y, Dv.z};
    const double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int r = 0; r < J->R; r++)
        acc[r][0] = acc[r][1] = acc[r][2] = acc[r][3] = 0.0;
    /* The ray caster's interval: t is the linear depth (rast_pixel_ray), clipped to near/far, and
     * to the mesh depth when one is given (as vol_raycast's depth_limit). */
    double t0 = J->vc.znear, t1 = J->vc.zfar;
    if (J->depth_limit) {
        const float dz = obs_image_f32_row(J->depth_limit, y)[x];
        if (dz < t1) /* NaN and +inf leave the interval alone */
            t1 = dz;
    }
    if (!(dl > 0.0) || !(t1 > t0) || !tvi_clip(&J->tc, o, d, &t0, &t1)) {
        for (int r = 0; r < J->R; r++)
            acc[r][3] = (double)(J->samples / J->R); /* every sample escapes */
        return;
    }
    st->pixels_hit++;
    const double w[3] = {d[0] / dl, d[1] / dl, d[2] / dl}, w_out[3] = {-w[0], -w[1], -w[2]};
    const double s0 = t0 * dl, s1 = t1 * dl; /* world distances along the unit ray */
    const uint64_t pixel = (uint64_t)y * (uint64_t)J->width + (uint64_t)x;
    for (int64_t k = 0; k < J->samples; k++) {
        double *a = acc[k % J->R];
        if (!(J->majorant > 0.0)) {
            a[3] += 1.0;
            continue;
        }
        tvi_rng rng = {pixel, J->seed, (uint32_t)k, 0, {0, 0, 0, 0}, 0};
        /* Delta tracking of the view ray; at the real collision, scoring rho E f T estimates L. */
        double s;
        float rho[3];
        if (!tvi_track(J, o, w, s0, s1, 0, &rng, st, &s, rho)) {
            a[3] += 1.0; /* escaped: estimates T_v(D) */
            continue;
        }
        st->collisions++;
        double xs[3] = {o[0] + s * w[0], o[1] + s * w[1], o[2] + s * w[2]};
        double w_in[3], dist, f = 1.0, T = 1.0;
        if (tvi_light_dir(&J->tc, xs, w_in, &dist)) {
            f = tvi_phase(J->g_hg, w_in, w_out);
            T = tvi_ratio_track(J, xs, w_in, dist, &rng, st);
            if (J->visibility && T > 0.0) { /* the meshes on the shadow ray (truth.h) */
                const double wl[3] = {-w_in[0], -w_in[1], -w_in[2]};
                const double v = J->visibility(J->visibility_user, xs, wl, dist);
                T *= v >= 0.0 ? (v <= 1.0 ? v : 1.0) : (v < 0.0 ? 0.0 : 1.0);
            }
        } /* else at the point light: no direction, unshadowed (as truth_volume_transmittance_at) */
        for (int q = 0; q < 3; q++)
            a[q] += (double)rho[q] * (double)J->light_color[q] * f * T;
    }
}

/* One pixel of the deterministic march (no replicates: acc[0]). */
static void tvi_march_pixel(const tvi_job *J, int x, int y, double out[4], truth_volume_mc_stats *st)
{
    obs_dvec3 O, Dv;
    rast_pixel_ray(&J->vc, J->cam, (double)x + 0.5, (double)y + 0.5, &O, &Dv);
    const double o[3] = {O.x, O.y, O.z}, d[3] = {Dv.x, Dv.y, Dv.z};
    const double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    out[0] = out[1] = out[2] = out[3] = 0.0;
    double t0 = J->vc.znear, t1 = J->vc.zfar;
    if (!(dl > 0.0) || !tvi_clip(&J->tc, o, d, &t0, &t1))
        return;
    st->pixels_hit++;
    const double w[3] = {d[0] / dl, d[1] / dl, d[2] / dl}, w_out[3] = {-w[0], -w[1], -w[2]};
    const double s0 = t0 * dl, s1 = t1 * dl, h = J->step;
    const int64_t n = (int64_t)ceil((s1 - s0) / h);
    double Tv = 1.0;
    for (int64_t k = 0; k < n; k++) {
        double sa = s0 + (double)k * h, sb = k + 1 < n ? sa + h : s1;
        if (!(sb > sa))
            break;
        double sm = 0.5 * (sa + sb), len = sb - sa;
        double xs[3] = {o[0] + sm * w[0], o[1] + sm * w[1], o[2] + sm * w[2]};
        float rho[3];
        double sig = tvi_sample(&J->tc, xs, rho);
        st->tentative++;
        if (!(sig > 0.0))
            continue;
        double a = 1.0 - exp(-sig * len);
        double w_in[3], dist, f = 1.0, T = 1.0;
        if (tvi_light_dir(&J->tc, xs, w_in, &dist)) {
            f = tvi_phase(J->g_hg, w_in, w_out);
            T = tv_transmittance(&J->tc, xs);
        }
        st->collisions++;
        for (int q = 0; q < 3; q++)
            out[q] += Tv * a * (double)rho[q] * (double)J->light_color[q] * f * T;
        Tv *= 1.0 - a;
    }
    out[3] = 1.0 - Tv;
}

static void tvi_tile(void *user, int64_t task, int thread)
{
    (void)thread;
    tvi_job *J = (tvi_job *)user;
    int x0, y0, x1, y1;
    if (J->task_mask && !J->task_mask[task])
        return; /* another rank's tile (truth_volume_mc_render_tasks): its pixels stay 0 */
    obs_tiling_rect(&J->tiling, task, &x0, &y0, &x1, &y1);
    truth_volume_mc_stats *st = &J->tile_stats[task];
    double acc[TRUTH_VOLUME_MC_MAX_REPLICATES][4];
    const double R = (double)J->R, m = (double)(J->samples / J->R);
    for (int y = y0; y < y1; y++) {
        for (int x = x0; x < x1; x++) {
            double mean[4], se[4] = {0, 0, 0, 0};
            if (J->step > 0.0) {
                tvi_march_pixel(J, x, y, mean, st);
            } else {
                tvi_mc_pixel(J, x, y, acc, st);
                /* Replicate means m_r, their mean, and s_R = sqrt(sum (m_r - m)^2 / (R (R - 1)))
                 * (docs/truth.md section 5, L'Ecuyer & Lemieux 2002); channel 3 holds escapes. */
                for (int q = 0; q < 4; q++) {
                    double sum = 0.0;
                    for (int r = 0; r < J->R; r++)
                        sum += acc[r][q] / m;
                    double mu = sum / R, ss = 0.0;
                    for (int r = 0; r < J->R; r++) {
                        double e = acc[r][q] / m - mu;
                        ss += e * e;
                    }
                    mean[q] = mu;
                    se[q] = sqrt(ss / (R * (R - 1.0)));
                }
                mean[3] = 1.0 - mean[3]; /* alpha = 1 - T_v */
            }
            for (int q = 0; q < 4; q++) {
                obs_image_f32_row(&J->out->rgba[q], y)[x] = (float)mean[q];
                obs_image_f32_row(&J->out->std_error[q], y)[x] = (float)se[q];
                if (q < 3 && se[q] > st->max_std_error)
                    st->max_std_error = se[q];
            }
        }
    }
}

/* Shared validation and set-up of both image references. */
static obs_status tvi_setup(obs_context *ctx, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                            const obs_camera *camera, int width, int height, double kappa, double g_hg,
                            const char *who, tvi_job *J)
{
    memset(J, 0, sizeof *J);
    if (!g || !g->data || !tf || !tf->points || tf->count < 1 || !light || !camera)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: a NULL argument (grid, TF, light or camera)", who);
    if (g->nx < 1 || g->ny < 1 || g->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: grid %dx%dx%d is empty", who, g->nx, g->ny, g->nz);
    for (int a = 0; a < 3; a++)
        if (!(g->spacing[a] > 0.0) || !isfinite(g->spacing[a]) || !isfinite(g->origin[a]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: grid spacing/origin invalid on axis %d", who, a);
    if (tf->ref_step < 0.0 || !isfinite(tf->ref_step))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: TF ref_step %g must be >= 0 and finite", who,
                         tf->ref_step);
    if (!isfinite(kappa) || kappa < 0.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: kappa %g must be finite and >= 0", who, kappa);
    if (!(g_hg > -1.0 && g_hg < 1.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: the phase asymmetry g %g must be in (-1, 1)", who,
                         g_hg);
    if (light->type == OBS_LIGHT_SPOT)
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "%s: spot lights are not supported", who);
    if (light->type != OBS_LIGHT_DIRECTIONAL && light->type != OBS_LIGHT_POINT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: unknown light type %d", who, (int)light->type);
    for (int q = 0; q < 3; q++) {
        if (!isfinite(light->color[q]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: the light's colour is not finite", who);
        J->light_color[q] = light->color[q];
    }
    tv_ctx *c = &J->tc;
    c->g = g;
    c->tf = tf;
    c->light = light;
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        if (!isfinite(len) || !(len > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: the light's direction must be finite and non-zero",
                             who);
        for (int a = 0; a < 3; a++)
            c->D[a] = light->direction[a] / len;
    } else {
        for (int a = 0; a < 3; a++)
            if (!isfinite(light->position[a]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: the light's position must be finite", who);
    }
    double hmin = fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    c->sigma_scale = kappa;
    c->ref_step = tf->ref_step > 0.0 ? tf->ref_step : hmin;
    c->h = TRUTH_VOLUME_DEFAULT_STEP_FRACTION * hmin;
    vol_grid_bounds(g, c->lo, c->hi);
    J->g_hg = g_hg;
    J->cam = camera;
    J->width = width;
    rast_params rp = rast_params_default();
    rp.width = width;
    rp.height = height;
    rp.guard = 0;
    obs_status st = rast_view_constants_make(ctx, &rp, camera, &J->vc);
    if (st != OBS_STATUS_OK)
        return st;
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    if ((int64_t)width * height * 8 > lim->max_image_pixels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "%s: %dx%d x 8 planes is over the limit of %lld pixels", who,
                         width, height, (long long)lim->max_image_pixels);
    return OBS_STATUS_OK;
}

static obs_status tvi_run(obs_context *ctx, obs_pool *pool, tvi_job *J, int width, int height, int tile,
                          truth_volume_image *out)
{
    double t0 = obs_time_now();
    obs_status st = OBS_STATUS_OK;
    out->width = width;
    out->height = height;
    for (int q = 0; q < 4 && st == OBS_STATUS_OK; q++) {
        st = obs_image_f32_alloc(ctx, width, height, &out->rgba[q]);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, width, height, &out->std_error[q]);
    }
    J->tiling = obs_tiling_make(width, height, tile);
    int64_t ntiles = obs_tiling_count(&J->tiling);
    if (st == OBS_STATUS_OK) {
        J->tile_stats = (truth_volume_mc_stats *)calloc((size_t)ntiles, sizeof *J->tile_stats);
        if (!J->tile_stats)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth volume image: out of memory");
    }
    if (st != OBS_STATUS_OK) {
        truth_volume_image_free(out);
        return st;
    }
    J->out = out;
    for (int q = 0; q < 4 && J->task_mask; q++) /* the tiles not computed here read 0 */
        for (int y = 0; y < height; y++) {
            memset(obs_image_f32_row(&out->rgba[q], y), 0, sizeof(float) * (size_t)width);
            memset(obs_image_f32_row(&out->std_error[q], y), 0, sizeof(float) * (size_t)width);
        }
    obs_pool_run(pool, ntiles, tvi_tile, J);
    truth_volume_mc_stats *s = &out->stats;
    memset(s, 0, sizeof *s);
    for (int64_t t = 0; t < ntiles; t++) { /* tile order: deterministic */
        const truth_volume_mc_stats *ts = &J->tile_stats[t];
        s->tentative += ts->tentative;
        s->collisions += ts->collisions;
        s->over_majorant += ts->over_majorant;
        s->pixels_hit += ts->pixels_hit;
        if (ts->max_std_error > s->max_std_error)
            s->max_std_error = ts->max_std_error;
    }
    s->majorant = J->majorant;
    free(J->tile_stats);
    J->tile_stats = NULL;
    s->seconds = obs_time_now() - t0;
    return OBS_STATUS_OK;
}

int64_t truth_volume_mc_task_count(int width, int height, int tile)
{
    if (width < 1 || height < 1 || tile < 1 || tile > 64)
        return 0;
    obs_tiling t = obs_tiling_make(width, height, tile);
    return obs_tiling_count(&t);
}

void truth_volume_mc_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1)
{
    obs_tiling t = obs_tiling_make(width, height, tile);
    obs_tiling_rect(&t, task, x0, y0, x1, y1);
}

static obs_status tvi_mc(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                         const obs_camera *camera, int width, int height, const truth_volume_mc_params *p,
                         const unsigned char *task_mask, truth_volume_image *out);

obs_status truth_volume_mc_render(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                  const vol_light *light, const obs_camera *camera, int width, int height,
                                  const truth_volume_mc_params *p, truth_volume_image *out)
{
    return tvi_mc(ctx, pool, g, tf, light, camera, width, height, p, NULL, out);
}

obs_status truth_volume_mc_render_tasks(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                        const vol_light *light, const obs_camera *camera, int width, int height,
                                        const truth_volume_mc_params *p, const unsigned char *task_mask,
                                        truth_volume_image *out)
{
    if (!task_mask) {
        if (out)
            memset(out, 0, sizeof *out);
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_mc_render_tasks: task_mask is NULL");
    }
    return tvi_mc(ctx, pool, g, tf, light, camera, width, height, p, task_mask, out);
}

static obs_status tvi_mc(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                         const obs_camera *camera, int width, int height, const truth_volume_mc_params *p,
                         const unsigned char *task_mask, truth_volume_image *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_mc_render: out is NULL");
    memset(out, 0, sizeof *out);
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_mc_render: params is NULL");
    if (p->replicates < 2 || p->replicates > TRUTH_VOLUME_MC_MAX_REPLICATES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume image: replicates %d must be in [2, %d]",
                         p->replicates, TRUTH_VOLUME_MC_MAX_REPLICATES);
    if (p->samples < p->replicates || p->samples % p->replicates != 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth volume image: samples %lld must be a positive multiple of replicates %d",
                         (long long)p->samples, p->replicates);
    if (p->tile < 1 || p->tile > 64)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume image: tile %d must be in [1, 64]", p->tile);
    if (p->depth_limit && (!p->depth_limit->data || p->depth_limit->width != width || p->depth_limit->height != height))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "truth volume image: the depth limit must be a %d x %d plane", width, height);
    {
        obs_limits deflim = obs_limits_default();
        const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
        if (p->samples > lim->max_samples || p->samples > ((int64_t)1 << 31))
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "truth volume image: %lld samples per pixel is over the limit of %lld (--max-spp)",
                             (long long)p->samples, (long long)lim->max_samples);
    }
    tvi_job J;
    obs_status st = tvi_setup(ctx, g, tf, light, camera, width, height, p->kappa, p->g, "truth volume image", &J);
    if (st != OBS_STATUS_OK)
        return st;
    /* The brick majorants (above). A brick with a non-finite voxel gets the TF's largest alpha. */
    {
        double lo = g->value_min, hi = g->value_max;
        if (!isfinite(lo) || !isfinite(hi) || lo > hi)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "truth volume image: the grid's value range [%g, %g] is not finite (vol_grid_update_range?)",
                             lo, hi);
        const int B = TRUTH_VOLUME_BRICK, nv[3] = {g->nx, g->ny, g->nz};
        for (int a = 0; a < 3; a++)
            J.nb[a] = (nv[a] + B - 1) / B;
        size_t nbr = (size_t)J.nb[0] * J.nb[1] * J.nb[2];
        J.maj = (float *)malloc(nbr * sizeof(float));
        if (!J.maj)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth volume image: out of memory (majorants)");
        float amax_all = vol_i_rc_tf_max_alpha(tf, -INFINITY, INFINITY);
        J.majorant = 0.0;
        for (int bz = 0; bz < J.nb[2]; bz++)
            for (int by = 0; by < J.nb[1]; by++)
                for (int bx = 0; bx < J.nb[0]; bx++) {
                    int b0[3] = {bx, by, bz}, v0[3], v1[3];
                    for (int a = 0; a < 3; a++) {
                        v0[a] = b0[a] * B - 1 < 0 ? 0 : b0[a] * B - 1;
                        v1[a] = (b0[a] + 1) * B + 1 > nv[a] - 1 ? nv[a] - 1 : (b0[a] + 1) * B + 1;
                    }
                    float vmin = INFINITY, vmax = -INFINITY;
                    int bad = 0;
                    for (int z = v0[2]; z <= v1[2]; z++)
                        for (int y = v0[1]; y <= v1[1]; y++) {
                            const float *row = g->data + ((size_t)z * g->ny + y) * g->nx;
                            for (int x = v0[0]; x <= v1[0]; x++) {
                                float v = row[x];
                                bad |= !isfinite(v);
                                vmin = v < vmin ? v : vmin;
                                vmax = v > vmax ? v : vmax;
                            }
                        }
                    float amax = amax_all;
                    if (!bad) {
                        /* widened by a relative 1e-5 for the float lerps' rounding, as the ray caster's bricks */
                        double mag = fabs((double)vmin) > fabs((double)vmax) ? fabs((double)vmin) : fabs((double)vmax);
                        double widen = 1e-5 * (mag > 1.0 ? mag : 1.0);
                        amax = vol_i_rc_tf_max_alpha(tf, (double)vmin - widen, (double)vmax + widen);
                    }
                    double mu = p->kappa * vol_sigma_from_alpha(amax, J.tc.ref_step);
                    J.maj[((size_t)bz * J.nb[1] + by) * J.nb[0] + bx] = (float)(mu > 0.0 ? mu * (1.0 + 1e-6) : 0.0);
                    if (mu > J.majorant)
                        J.majorant = mu;
                }
        J.nudge = 1e-4 * fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    }
    J.samples = p->samples;
    J.R = p->replicates;
    J.seed = p->seed;
    J.step = 0.0;
    J.depth_limit = p->depth_limit;
    J.visibility = p->visibility;
    J.visibility_user = p->visibility_user;
    J.task_mask = task_mask;
    obs_status rs = tvi_run(ctx, pool, &J, width, height, p->tile, out);
    free(J.maj);
    return rs;
}

obs_status truth_volume_march_image(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                    const vol_light *light, const obs_camera *camera, int width, int height,
                                    double step, const truth_volume_params *tp, double g_hg, truth_volume_image *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_march_image: out is NULL");
    memset(out, 0, sizeof *out);
    if (!tp)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_volume_march_image: params is NULL");
    if (!isfinite(tp->step_fraction) || !(tp->step_fraction > 0.0) || tp->step_fraction > 1.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume march: step_fraction %g must be in (0, 1]",
                         tp->step_fraction);
    if (!isfinite(step) || !(step > 0.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth volume march: step %g must be finite and > 0", step);
    tvi_job J;
    obs_status st = tvi_setup(ctx, g, tf, light, camera, width, height, tp->kappa, g_hg, "truth volume march", &J);
    if (st != OBS_STATUS_OK)
        return st;
    double hmin = fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    J.tc.h = tp->step_fraction * hmin;
    double diag = 0.0;
    for (int a = 0; a < 3; a++)
        diag += (J.tc.hi[a] - J.tc.lo[a]) * (J.tc.hi[a] - J.tc.lo[a]);
    if (!(sqrt(diag) / step <= TRUTH_VOLUME_MAX_STEPS_PER_RAY))
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "truth volume march: step %g is too small for the volume",
                         step);
    J.step = step;
    J.R = 1;
    J.samples = 1;
    return tvi_run(ctx, pool, &J, width, height, TRUTH_VOLUME_MC_DEFAULT_TILE, out);
}
