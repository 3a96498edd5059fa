/* vol_raycast_internal.h: the ray caster's internals shared with its tests and benchmark (not
 * installed; prefix vol_i_rc_). */
#ifndef VOL_RAYCAST_INTERNAL_H
#define VOL_RAYCAST_INTERNAL_H

#include "vol.h"

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Work counters of one vol_raycast call, summed over all pixels (sums of integers, so the same
 * for any thread count and tile order). */
typedef struct vol_i_rc_stats {
    int64_t rays;              /* pixels whose ray meets the volume's box (after near/far/depth) */
    int64_t samples;           /* samples at which the volume was read and the TF evaluated */
    int64_t samples_skipped;   /* samples jumped over inside empty bricks (never read) */
    int64_t samples_shaded;    /* samples with alpha > 0 (composited) */
    int64_t rays_terminated;   /* rays stopped by early termination */
    int64_t bricks;            /* bricks in the table (0 when skipping is off) */
    int64_t bricks_empty;      /* of which the TF's max alpha over the value range is 0 */
} vol_i_rc_stats;

/* vol_raycast with its counters (stats may be NULL). */
obs_status vol_i_rc_raycast_stats(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                  const vol_light *light, const vol_light_volume *lv, const obs_camera *camera,
                                  int width, int height, const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                  obs_image_f32 out[4], vol_i_rc_stats *stats);

/* vol_raycast_prepared with its counters (stats may be NULL; bricks come from the handle). */
obs_status vol_i_rc_raycast_prepared_stats(obs_context *ctx, obs_pool *pool, const vol_rc_prepared *prep,
                                           const vol_light *light, const vol_light_volume *lv,
                                           const obs_camera *camera, int width, int height,
                                           const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                           obs_image_f32 out[4], vol_i_rc_stats *stats);

/* The ray caster's inlined transfer function: bit for bit vol_tf_eval. */
void vol_i_rc_tf_eval(const vol_tf *tf, double value, float rgba[4]);

/* Validate ray-caster parameters: step >= 0 and finite (0 = the default), early_termination in
 * (0, 1], brick >= 0, ambient in [0, 1], specular_exponent >= 0, all finite, shading known.
 * Returns OK or INVALID_ARGUMENT. */
obs_status vol_i_rc_params_validate(obs_context *ctx, const vol_rc_params *p);

/* The largest TF alpha over the values [lo, hi] (piecewise linear: the maximum is at an end or
 * a control point). */
float vol_i_rc_tf_max_alpha(const vol_tf *tf, double lo, double hi);

/* The ray caster's inlined trilinear sample: bit for bit vol_grid_sample. */
float vol_i_rc_sample(const vol_grid *g, double ci, double cj, double ck);

/* The gradient of the trilinear field at continuous voxel coordinate c, in value per world unit:
 * central differences one voxel each way along each axis, divided by 2 x that axis' spacing. */
void vol_i_rc_gradient(const vol_grid *g, const double c[3], double grad[3]);

/* The march's gradient (the centre's splits shared with the six shifted samples): bit for bit
 * vol_i_rc_gradient. */
void vol_i_rc_gradient_fast(const vol_grid *g, const double c[3], double grad[3]);

/* The march's opacity correction for a full step h (h, ref_step > 0): bit for bit
 * vol_tf_alpha_correct(alpha, h, ref_step). */
float vol_i_rc_alpha_full_step(float alpha, double h, double ref_step);

/* The value at or below which the TF's alpha is exactly 0 (the march reads no TF there);
 * -inf when the first point's alpha is not 0. */
double vol_i_rc_zero_below(const vol_tf *tf);

#ifdef __cplusplus
}
#endif

#endif /* VOL_RAYCAST_INTERNAL_H */
