/* sss_params.c: the scattering-map pipeline's parameters: defaults (each naming its source, in
 * sss.h), range checks, and the sampler / visibility names. docs/sss/maps.md lists them all. */
#include "sss.h"

#include <math.h>
#include <string.h>
#include <strings.h>

static const char *const k_sampler_names[SSS_SAMPLER_COUNT] = {"russian-roulette", "nearest-n-of-m", "exponential"};
static const char *const k_visibility_names[SSS_VISIBILITY_COUNT] = {"product5", "pcf3x3"};

const char *sss_sampler_name(sss_sampler s)
{
    return ((unsigned)s < SSS_SAMPLER_COUNT) ? k_sampler_names[s] : "unknown";
}

int sss_sampler_from_name(const char *name, sss_sampler *out)
{
    if (!name)
        return 0;
    for (int i = 0; i < SSS_SAMPLER_COUNT; i++)
        if (strcasecmp(name, k_sampler_names[i]) == 0) {
            if (out)
                *out = (sss_sampler)i;
            return 1;
        }
    return 0;
}

const char *sss_visibility_name(sss_visibility v)
{
    return ((unsigned)v < SSS_VISIBILITY_COUNT) ? k_visibility_names[v] : "unknown";
}

int sss_visibility_from_name(const char *name, sss_visibility *out)
{
    if (!name)
        return 0;
    for (int i = 0; i < SSS_VISIBILITY_COUNT; i++)
        if (strcasecmp(name, k_visibility_names[i]) == 0) {
            if (out)
                *out = (sss_visibility)i;
            return 1;
        }
    return 0;
}

sss_params sss_params_default(void)
{
    sss_params p;
    memset(&p, 0, sizeof p);
    p.model = SSS_MODEL_DIRECTIONAL;
    p.K = SSS_DEFAULT_K;
    p.N = SSS_DEFAULT_N;
    p.M = SSS_DEFAULT_M;
    p.map_size = SSS_DEFAULT_MAP_SIZE;
    p.light_map_size = SSS_DEFAULT_LIGHT_MAP_SIZE;
    p.frames = 1;
    p.spread_q = SSS_DEFAULT_SPREAD_Q;
    p.disk_radius = 0.0;
    /* DEVIATION (sss.h, docs/sss/maps.md): the shipped shader is rr with 1000 frames; a one-call
     * CPU reference needs an estimator that converges in one call */
    p.sampler = SSS_SAMPLER_EXPONENTIAL;
    p.visibility = SSS_VISIBILITY_PRODUCT5;
    p.shadow_bias = SSS_DEFAULT_SHADOW_BIAS;
    p.shrink_eps = SSS_DEFAULT_SHRINK_EPS;
    p.gamma = SSS_DEFAULT_GAMMA;
    p.specular = 0;
    p.specular_exponent = 64.0; /* a Blinn-Phong exponent of our choosing; the thesis' specular is an environment lookup */
    p.seed = 0;
    p.isa = SSS_ISA_AUTO;
    return p;
}

/* Documented limits (docs/sss/maps.md, "Parameters"). */
#define SSS_MAX_K 256
#define SSS_MAX_N 4096
#define SSS_MAX_M (1 << 20)
#define SSS_MIN_SIZE 16
#define SSS_MAX_SIZE 4096
#define SSS_MAX_FRAMES (1 << 20)

static obs_status bad(obs_context *ctx, const char *field, const char *why)
{
    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: %s %s", field, why);
}

obs_status sss_params_validate(obs_context *ctx, const sss_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: NULL");
    if ((unsigned)p->model >= SSS_MODEL_COUNT)
        return bad(ctx, "model", "is not a known BSSRDF model");
    if (p->K < 1 || p->K > SSS_MAX_K)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: K = %d out of [1, %d]", p->K, SSS_MAX_K);
    if (p->N < 1 || p->N > SSS_MAX_N)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: N = %d out of [1, %d]", p->N, SSS_MAX_N);
    if ((unsigned)p->sampler >= SSS_SAMPLER_COUNT)
        return bad(ctx, "sampler", "is not a known sampler");
    if (p->sampler == SSS_SAMPLER_NEAREST_N_OF_M && (p->M < p->N || p->M > SSS_MAX_M))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sss params: M = %d must be in [N = %d, %d] for the nearest-n-of-m sampler", p->M, p->N,
                         SSS_MAX_M);
    if (p->map_size < SSS_MIN_SIZE || p->map_size > SSS_MAX_SIZE)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: map_size = %d out of [%d, %d]", p->map_size,
                         SSS_MIN_SIZE, SSS_MAX_SIZE);
    if (p->light_map_size < SSS_MIN_SIZE || p->light_map_size > SSS_MAX_SIZE)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: light_map_size = %d out of [%d, %d]",
                         p->light_map_size, SSS_MIN_SIZE, SSS_MAX_SIZE);
    if (p->frames < 1 || p->frames > SSS_MAX_FRAMES)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss params: frames = %d out of [1, %d]", p->frames,
                         SSS_MAX_FRAMES);
    if (!(isfinite(p->spread_q) && p->spread_q > 0.0))
        return bad(ctx, "spread_q", "must be finite and > 0");
    if (!(isfinite(p->disk_radius) && p->disk_radius >= 0.0))
        return bad(ctx, "disk_radius", "must be finite and >= 0 (0 = from the scene bounds)");
    if ((unsigned)p->visibility >= SSS_VISIBILITY_COUNT)
        return bad(ctx, "visibility", "is not a known visibility test");
    if (!(isfinite(p->shadow_bias) && p->shadow_bias >= 0.0))
        return bad(ctx, "shadow_bias", "must be finite and >= 0");
    if (!(isfinite(p->shrink_eps) && p->shrink_eps >= 0.0))
        return bad(ctx, "shrink_eps", "must be finite and >= 0");
    if (!(isfinite(p->gamma) && p->gamma > 0.0))
        return bad(ctx, "gamma", "must be finite and > 0");
    if (!(isfinite(p->specular_exponent) && p->specular_exponent >= 0.0))
        return bad(ctx, "specular_exponent", "must be finite and >= 0");
    if ((unsigned)p->isa >= SSS_ISA_COUNT)
        return bad(ctx, "isa", "is not a known ISA");
    /* The map array (K layers of map_size^2 texels: G-buffer planes and 3 radiance planes) is
     * refused before allocation when K * map_size^2 exceeds the context's max_image_pixels
     * (default 2^28, raised with --max-pixels), as every layered image in obscura is. */
    {
        const obs_limits *lim = obs_context_limits(ctx);
        int64_t lim_px = lim ? lim->max_image_pixels : ((int64_t)1 << 28);
        int64_t texels = (int64_t)p->K * p->map_size * p->map_size;
        if (texels > lim_px)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "sss params: K * map_size^2 = %lld texels exceeds the limit %lld (max_image_pixels, "
                             "--max-pixels)",
                             (long long)texels, (long long)lim_px);
    }
    return OBS_STATUS_OK;
}
