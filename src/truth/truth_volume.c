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

#include "../volume/vol.h"

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
    size_t voxels = (size_t)lv->nx * lv->ny * lv->nz;
    float *T = (float *)obs_aligned_alloc(voxels * sizeof(float));
    float *err = (float *)obs_aligned_alloc(voxels * sizeof(float));
    if (!T || !err) {
        obs_aligned_free(T);
        obs_aligned_free(err);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth volume: out of memory");
    }
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
    obs_pool_run(pool, lv->nz, tv_slice_task, &c);
    /* Statistics in voxel order (deterministic). */
    if (stats) {
        double sum = 0.0, sum2 = 0.0, sums = 0.0;
        stats->voxels = (int64_t)voxels;
        for (size_t i = 0; i < voxels; i++) {
            double e = err[i], ae = fabs(e);
            if (!(ae <= stats->max_abs)) {
                stats->max_abs = ae;
                stats->argmax = (int64_t)i;
            }
            sum += ae;
            sum2 += e * e;
            sums += e;
        }
        stats->mean_abs = sum / (double)voxels;
        stats->rmse = sqrt(sum2 / (double)voxels);
        stats->mean_signed = sums / (double)voxels;
    }
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
