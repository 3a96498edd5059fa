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

/* One run of a ray (vol_raycast.c, rc_trace_t: full steps inside the clamp-free
 * range whose base voxel stays in the last non-empty brick), for the AVX2 form
 * (vol_raycast_avx2.c, compiled with -mavx2, no FMA): the three axes of the position and of the
 * splits in one vector each, the four x-lerps of the trilinear sample in one vector, the two
 * y-lerps in another; every lane performs the scalar run's IEEE operations in the same order, so
 * the image is the same bit for bit (volume_raycast_avx2_run_matches_scalar_bit_for_bit). Lane 3
 * of the vectors is padding (0). */
typedef struct vol_i_rc_run {
    const float *data;          /* the grid's voxels, x fastest */
    size_t sy, sz;              /* voxels per row, per slice */
    int fast;                   /* VOL_RC_FAST: c(k) = c0 + k dc and the table; else the exact forms */
    double c0[4], dc[4];        /* fast: voxel coordinates of sample k = c0 + k dc */
    double t0, dt;              /* exact: t_k = t0 + (k + 1/2) dt, */
    double o[4], d[4];          /*   x = o + t_k d, */
    double org[4], inv_sp[4];   /*   c = (x - org) inv_sp */
    int32_t nel[4];             /* the run stops where a base voxel v leaves [nel, nel + urun) */
    uint32_t urun;              /*   (unsigned v - nel < urun on each axis) */
    int64_t k, kb;              /* in: the first sample; the run takes samples k..kb at most.
                                   out: the first sample not taken (kb + 1 or the one that left) */
    double zero_below, et;      /* values <= zero_below have alpha 0; stop when 1 - T >= et */
    const float *tft;           /* fast: the pre-corrected table */
    float tft_lo, tft_scale;
    const vol_tf *tf;           /* exact: the TF, the full step and ref_step */
    double h, ref_step;
    double T, C[3];             /* in/out: transmittance, premultiplied colour */
    int64_t samples, shaded;    /* out: added to */
    int done;                   /* out: 1 when early termination stopped the ray (at sample k) */
    /* Phong and light-volume shading: called for each composited sample with its index k, its
     * voxel coordinates c, base voxel v0 and fractions t, to turn the TF's rgb into the shaded
     * colour (NULL: emission-absorption) */
    void (*shade)(const void *user, int64_t k, const double c[3], const int v0[3], const float t[3], float rgb[3]);
    const void *shade_user;
} vol_i_rc_run;
void vol_i_rc_run_avx2(vol_i_rc_run *R);

/* VOL_RC_FAST Phong's gradient at voxel coordinate c: the handle's gradient volume interpolated
 * with c's splits (rc_gradient_volume, the splits clamped as vol_grid_sample's). Returns 0 (grad
 * untouched) when the handle has no gradient volume (prepared without VOL_RC_FAST and Phong). */
int vol_i_rc_gradient_volume_at(const vol_rc_prepared *prep, const double c[3], double grad[3]);

/* 1 when the ray caster's AVX2 run is used: built with OBS_ENABLE_SIMD, the CPU has AVX2, and the
 * environment's OBS_ISA is "avx2" (read at each cast). Opt-in, unlike vol_i_lv_avx2_active: the
 * scalar run measured faster in wall clock (vol_raycast.c). */
int vol_i_rc_avx2_active(void);

#ifdef __cplusplus
}
#endif

#endif /* VOL_RAYCAST_INTERNAL_H */
