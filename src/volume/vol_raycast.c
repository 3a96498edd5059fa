/* vol_raycast.c: the volume ray caster (vol.h section 4; docs/volume/raycast.md).
 *
 * Per pixel: the rasterizer's exact camera ray (rast_pixel_ray), clipped to the near/far planes,
 * to the volume's box and to an optional mesh depth; front-to-back compositing [Levoy88]
 * [Engel06] of trilinear samples at the midpoints of equal steps (the last one shorter), each
 * step's opacity corrected for its length; early ray termination and empty-space skipping with
 * min-max bricks [Kruger03]; emission-absorption, gradient Phong or light-volume shading.
 *
 * Determinism: each pixel is a pure function of its ray; tiles of VOL_RC_TILE pixels are the pool's
 * tasks, so the image is the same for any thread count. Accumulation is in double. */
#include "vol.h"
#include "vol_raycast_internal.h"

#include "../raster/raster.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- Defaults (vol_rc_params_default) ---------------------------------------------------------- */

#define VOL_RC_DEFAULT_SHADING VOL_SHADING_LIGHT_VOLUME /* vol.h: the technique this module exists for */
#define VOL_RC_DEFAULT_STEP 0.0 /* world units; 0 = VOL_RC_AUTO_STEP_FRACTION x the smallest spacing */
#define VOL_RC_AUTO_STEP_FRACTION 0.5 /* two samples per voxel (the Nyquist rate of the voxel
                                         spacing); ours, a common choice, not checked against a
                                         source */
#define VOL_RC_DEFAULT_EARLY_TERMINATION 0.99 /* (0, 1]; vol.h default (ours): at most 1% of the
                                                 remaining light is dropped, see raycast.md */
#define VOL_RC_DEFAULT_BRICK 8 /* voxels, >= 0 (0 = off); 8^3 blocks as in [Kruger03] (block size
                                  from memory, UNVERIFIED); measured in raycast.md */
#define VOL_RC_DEFAULT_AMBIENT 0.2f /* [0, 1]; ours (vol.h) */
#define VOL_RC_DEFAULT_SPECULAR_EXPONENT 32.0f /* >= 0; ours (vol.h), a common Phong shininess */
/* Surfaceness: s = min(1, VOL_RC_SURFACENESS_GAIN * |grad| * min spacing / value range). Voreen's
 * rc_shadow.frag uses 0.06 |grad| in its own gradient units (volume.md 1.8); ours is made
 * resolution- and range-independent: s = 1 from a central difference of 1/4 of the data range per
 * voxel (half the sharpest possible step). Ours, not from a paper. */
#define VOL_RC_SURFACENESS_GAIN 4.0
/* Empty-space skipping's safety margin, in steps: a skip stops this far before the brick's exit
 * (ours: 1e-6 step is ~5e-7 voxel at the default step, 10^6 times the double rounding of the
 * sample positions). */
#define VOL_RC_SKIP_MARGIN 1e-6
/* The half-step opacity correction's rounding guard (rc_alpha_full_step): 2^-40 relative, ~2000
 * times the two evaluations' combined error bound (~6 ulp of double, 7e-16), far below a float's
 * half ulp (3e-8), so the fallback to libm is taken about once in 2^16 samples. Ours. */
#define VOL_RC_ALPHA_TIE 0x1p-40
/* Image tile side (pool tasks): a fixed decomposition independent of the thread count. */
#define VOL_RC_TILE 32
/* Most steps one ray may take (2^24): refuses a step so small against the volume that a call would
 * not finish; the box diagonal / step is checked before anything is rendered. */
#define VOL_RC_MAX_STEPS_PER_RAY 16777216.0

/* ---- Names and parameters ---------------------------------------------------------------------- */

static const char *const vol_shading_names[VOL_SHADING_COUNT] = {"ea", "phong", "lightvolume"};

const char *vol_shading_name(vol_shading s)
{
    if ((int)s < 0 || s >= VOL_SHADING_COUNT)
        return "unknown";
    return vol_shading_names[s];
}

int vol_shading_from_name(const char *name, vol_shading *out)
{
    if (!name || !out)
        return 0;
    for (int s = 0; s < VOL_SHADING_COUNT; s++) {
        if (strcmp(name, vol_shading_names[s]) == 0) {
            *out = (vol_shading)s;
            return 1;
        }
    }
    /* Longer spellings. */
    if (strcmp(name, "emission-absorption") == 0) {
        *out = VOL_SHADING_EMISSION_ABSORPTION;
        return 1;
    }
    if (strcmp(name, "light-volume") == 0) {
        *out = VOL_SHADING_LIGHT_VOLUME;
        return 1;
    }
    return 0;
}

vol_rc_params vol_rc_params_default(void)
{
    vol_rc_params p;
    memset(&p, 0, sizeof p);
    p.shading = VOL_RC_DEFAULT_SHADING;
    p.step = VOL_RC_DEFAULT_STEP;
    p.early_termination = VOL_RC_DEFAULT_EARLY_TERMINATION;
    p.brick = VOL_RC_DEFAULT_BRICK;
    p.ambient = VOL_RC_DEFAULT_AMBIENT;
    p.specular_exponent = VOL_RC_DEFAULT_SPECULAR_EXPONENT;
    for (int c = 0; c < 4; c++)
        p.background[c] = 0.0f;
    return p;
}

obs_status vol_i_rc_params_validate(obs_context *ctx, const vol_rc_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: params is NULL");
    if ((int)p->shading < 0 || p->shading >= VOL_SHADING_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: unknown shading %d (ea, phong, lightvolume)",
                         (int)p->shading);
    if (p->precision != VOL_RC_EXACT && p->precision != VOL_RC_FAST)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: unknown precision %d (exact, fast)",
                         (int)p->precision);
    if (!isfinite(p->step) || p->step < 0.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "vol_raycast: step %g must be finite and > 0 (0 = half the smallest spacing)", p->step);
    if (!(p->early_termination > 0.0 && p->early_termination <= 1.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: early_termination %g must be in (0, 1]",
                         p->early_termination);
    if (p->brick < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: brick %d must be >= 0 (0 = no skipping)",
                         p->brick);
    if (!(p->ambient >= 0.0f && p->ambient <= 1.0f))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: ambient %g must be in [0, 1]",
                         (double)p->ambient);
    if (!(p->specular_exponent >= 0.0f) || !isfinite(p->specular_exponent))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: specular_exponent %g must be finite and >= 0",
                         (double)p->specular_exponent);
    for (int c = 0; c < 4; c++) {
        if (!isfinite(p->background[c]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: background[%d] is not finite", c);
    }
    return OBS_STATUS_OK;
}

/* ---- Transfer-function bounds for skipping ----------------------------------------------------- */

float vol_i_rc_tf_max_alpha(const vol_tf *tf, double lo, double hi)
{
    /* Piecewise linear and constant beyond the ends: over [lo, hi] the maximum is at lo, at hi or
     * at a control point between them. */
    float rgba[4];
    vol_tf_eval(tf, lo, rgba);
    float m = rgba[3];
    vol_tf_eval(tf, hi, rgba);
    if (rgba[3] > m)
        m = rgba[3];
    for (int i = 0; i < tf->count; i++) {
        double v = tf->points[i].value;
        if (v >= lo && v <= hi && tf->points[i].rgba[3] > m)
            m = tf->points[i].rgba[3];
    }
    return m;
}

/* ---- The job ----------------------------------------------------------------------------------- */

typedef struct rc_job {
    const vol_grid *g;
    const vol_tf *tf;
    const vol_light_volume *lv;
    const obs_camera *cam;
    const obs_image_f32 *depth;
    const vol_rc_params *p;
    obs_image_f32 *out;
    rast_view_constants vc;
    obs_tiling tiling;
    double lo[3], hi[3];       /* world box */
    double inv_sp[3];          /* 1 / spacing */
    double h;                  /* step, world units */
    double ref_step;           /* the TF's ref_step, resolved */
    double et;                 /* early termination threshold */
    double surf_scale;         /* VOL_RC_SURFACENESS_GAIN * min spacing / value range */
    /* Lighting */
    int light_point;           /* 1: point light at light_pos; 0: directional, towards-light light_dir */
    double light_dir[3];       /* unit, towards the light (directional) */
    double light_pos[3];
    float light_color[3];
    /* Bricks (brick == 0: none) */
    int brick, nb[3];
    const uint8_t *empty;      /* per brick, x fastest: 1 = the TF's alpha is 0 over its footprint */
    const int32_t *bidx[3];    /* per axis: base voxel -> brick index (voxel / brick) */
    int avx2;                  /* vol_i_rc_avx2_active() at the cast's start */
    int rx0, rx1, ry0, ry1;    /* pixels outside [rx0, rx1) x [ry0, ry1) surely miss the box (rc_screen_rect) */
    int spec_int;              /* VOL_RC_FAST: the specular exponent when an integer in [0, 1024], else -1 */
    const float *gradv;        /* VOL_RC_FAST Phong: the prepared gradient volume (NULL: none) */
    double r_h;                /* h / ref_step: the opacity-correction exponent of a full step */
    double zero_below;         /* values <= this have TF alpha exactly 0 (-inf: none) */
    /* VOL_RC_FAST: the pre-corrected TF table (NULL in the exact mode) */
    float *tft;                /* VOL_RC_FAST_TF_SIZE nodes x rgba, alpha corrected for a full step */
    float tft_lo, tft_scale;   /* node index u = (value - tft_lo) x tft_scale */
    /* Brick-table build */
    uint8_t *empty_w;
    vol_i_rc_stats *tile_stats;
    int64_t *row_empty;        /* per brick row (z), bricks found empty */
} rc_job;

/* The prepared state (vol.h, vol_rc_prepare): what depends only on the grid, the TF and the
 * brick size. */
struct vol_rc_prepared {
    const vol_grid *g;
    const vol_tf *tf;
    int brick, nb[3];
    uint8_t *empty;            /* NULL when brick == 0 */
    int32_t *bidx[3];
    int64_t bricks, bricks_empty;
    float *gradv;              /* VOL_RC_FAST Phong: per voxel the gradient, float xyz (12 bytes per
                                  voxel, 3x the grid); NULL unless prepared with fast Phong */
};

/* The AVX2 run is opt-in (OBS_ISA=avx2): it executes ~11% fewer instructions than the scalar run
 * on the head CT (EA exact), but in alternating wall-clock runs on the development machine it was
 * slower in 7 of 8 (EA exact) and 5 of 8 (EA fast) pairs, and Phong through its callback slower
 * still (docs/volume/raycast.md, "Third round"), so the scalar run is the default until an idle
 * measurement says otherwise. */
int vol_i_rc_avx2_active(void)
{
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
    const char *env = getenv("OBS_ISA");
    if (!env || strcmp(env, "avx2") != 0)
        return 0;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    return 0;
#endif
}

/* ---- Trilinear sampling ------------------------------------------------------------------------ */

/* vol_grid_sample's arithmetic, inlined: the same clamping (c <= 0 or NaN -> voxel 0 with weight 0,
 * c >= n - 1 -> voxel n - 1), the same float fraction and the same three nested lerps in the same
 * order, so the result is bit for bit the same (tests/test_volume_raycast.c checks it); what is
 * saved is the call and libm's floor (c > 0 here, so truncation is floor). */
static inline void rc_split(double c, int n, int *i0, int *i1, float *t)
{
    if (!(c > 0.0)) {
        *i0 = *i1 = 0;
        *t = 0.0f;
        return;
    }
    if (c >= (double)(n - 1)) {
        *i0 = *i1 = n - 1;
        *t = 0.0f;
        return;
    }
    int f = (int)c;
    *i0 = f;
    *i1 = f + 1;
    *t = (float)(c - (double)f);
}

/* rc_split for 0 < c < n - 1 (the caller knows it): the same arithmetic without the clamps. */
static inline void rc_split_inside(double c, int *i0, int *i1, float *t)
{
    int f = (int)c;
    *i0 = f;
    *i1 = f + 1;
    *t = (float)(c - (double)f);
}

static inline float rc_sample(const vol_grid *g, double ci, double cj, double ck)
{
    int x0, x1, y0, y1, z0, z1;
    float tx, ty, tz;
    rc_split(ci, g->nx, &x0, &x1, &tx);
    rc_split(cj, g->ny, &y0, &y1, &ty);
    rc_split(ck, g->nz, &z0, &z1, &tz);
    const size_t sy = (size_t)g->nx, sz = (size_t)g->nx * (size_t)g->ny;
    const float *r00 = g->data + (size_t)y0 * sy + (size_t)z0 * sz, *r10 = g->data + (size_t)y1 * sy + (size_t)z0 * sz;
    const float *r01 = g->data + (size_t)y0 * sy + (size_t)z1 * sz, *r11 = g->data + (size_t)y1 * sy + (size_t)z1 * sz;
    float ux = 1.0f - tx, uy = 1.0f - ty, uz = 1.0f - tz;
    float c00 = r00[x0] * ux + r00[x1] * tx, c10 = r10[x0] * ux + r10[x1] * tx;
    float c01 = r01[x0] * ux + r01[x1] * tx, c11 = r11[x0] * ux + r11[x1] * tx;
    float c0 = c00 * uy + c10 * ty, c1 = c01 * uy + c11 * ty;
    return c0 * uz + c1 * tz;
}

float vol_i_rc_sample(const vol_grid *g, double ci, double cj, double ck)
{
    return rc_sample(g, ci, cj, ck);
}

/* rc_sample with the splits already made (the march makes them once for the brick look-up and the
 * sample): the same loads and lerps in the same order, so the same bits. */
static inline float rc_sample_split(const vol_grid *g, int x0, int x1, float tx, int y0, int y1, float ty, int z0,
                                    int z1, float tz)
{
    const size_t sy = (size_t)g->nx, sz = (size_t)g->nx * (size_t)g->ny;
    const float *r00 = g->data + (size_t)y0 * sy + (size_t)z0 * sz, *r10 = g->data + (size_t)y1 * sy + (size_t)z0 * sz;
    const float *r01 = g->data + (size_t)y0 * sy + (size_t)z1 * sz, *r11 = g->data + (size_t)y1 * sy + (size_t)z1 * sz;
    float ux = 1.0f - tx, uy = 1.0f - ty, uz = 1.0f - tz;
    float c00 = r00[x0] * ux + r00[x1] * tx, c10 = r10[x0] * ux + r10[x1] * tx;
    float c01 = r01[x0] * ux + r01[x1] * tx, c11 = r11[x0] * ux + r11[x1] * tx;
    float c0 = c00 * uy + c10 * ty, c1 = c01 * uy + c11 * ty;
    return c0 * uz + c1 * tz;
}

/* rc_sample_split for a sample strictly inside the grid (x1 = x0 + 1, ...): the eight corners
 * addressed from the base voxel's offset (one index per sample instead of four row pointers);
 * the same values in the same lerps in the same order, so the same bits. */
static inline float rc_sample_base(const float *b, size_t sy, size_t sz, float tx, float ty, float tz)
{
    float ux = 1.0f - tx, uy = 1.0f - ty, uz = 1.0f - tz;
    float c00 = b[0] * ux + b[1] * tx, c10 = b[sy] * ux + b[sy + 1] * tx;
    float c01 = b[sz] * ux + b[sz + 1] * tx, c11 = b[sy + sz] * ux + b[sy + sz + 1] * tx;
    float c0 = c00 * uy + c10 * ty, c1 = c01 * uy + c11 * ty;
    return c0 * uz + c1 * tz;
}

/* ---- The transfer function, inlined ------------------------------------------------------------ */

/* vol_tf_eval's arithmetic, inlined (bit for bit: tests/test_volume_raycast.c checks it): the same
 * NaN and end cases, the same segment (p[lo].value <= value < p[lo + 1].value, unique for strictly
 * increasing values, found by a forward scan for short lists instead of the binary search), the
 * same double division and lerps. What is saved is the call and the search's branches. */
static inline void rc_tf_eval(const vol_tf *tf, double value, float rgba[4])
{
    const vol_tf_point *p = tf->points;
    const int n = tf->count;
    if (isnan(value)) {
        rgba[0] = rgba[1] = rgba[2] = rgba[3] = 0.0f;
        return;
    }
    if (value <= p[0].value) {
        memcpy(rgba, p[0].rgba, 4 * sizeof(float));
        return;
    }
    if (value >= p[n - 1].value) {
        memcpy(rgba, p[n - 1].rgba, 4 * sizeof(float));
        return;
    }
    int lo = 0;
    if (n <= 16) {
        while (p[lo + 1].value <= value)
            lo++;
    } else {
        int hi = n - 1;
        while (hi - lo > 1) {
            int mid = (lo + hi) / 2;
            if (p[mid].value <= value)
                lo = mid;
            else
                hi = mid;
        }
    }
    const int hi = lo + 1;
    double t = (value - p[lo].value) / (p[hi].value - p[lo].value);
    for (int c = 0; c < 4; c++)
        rgba[c] = (float)((double)p[lo].rgba[c] * (1.0 - t) + (double)p[hi].rgba[c] * t);
}

void vol_i_rc_tf_eval(const vol_tf *tf, double value, float rgba[4])
{
    rc_tf_eval(tf, value, rgba);
}

/* The largest value below which vol_tf_eval's alpha is exactly 0: the last point of the leading
 * run of points with alpha 0 (at or below p[0] the alpha is p[0]'s; inside a segment whose two
 * alphas are 0 the lerp 0 (1 - t) + 0 t is 0 for any t in [0, 1)); -inf when p[0]'s alpha is not 0.
 * NaN compares false, so it still goes through the TF (which returns 0 for it). */
static double rc_zero_below(const vol_tf *tf)
{
    double z = -INFINITY;
    for (int i = 0; i < tf->count && tf->points[i].rgba[3] == 0.0f; i++)
        z = tf->points[i].value;
    return z;
}

double vol_i_rc_zero_below(const vol_tf *tf)
{
    return rc_zero_below(tf);
}

/* vol_tf_alpha_correct(alpha, h, ref_step) for the full step h, with h / ref_step divided once per
 * call (r_h) instead of per sample; the same branches and the same double expression, so the same
 * bits (h > 0 and ref_step > 0, finite, are resolved before the march). */
static inline float rc_alpha_full_step(float alpha, double h, double ref_step, double r_h)
{
    if (!(alpha > 0.0f))
        return 0.0f;
    if (alpha >= 1.0f)
        return 1.0f;
    if (h == ref_step)
        return alpha;
    if (r_h == 0.5) {
        /* The default step (half the smallest spacing) against the default ref_step (one
         * spacing): 1 - (1 - a)^(1/2) = a / (1 + sqrt(1 - a)) (no cancellation; 1 - a is exact in
         * double for a float a, sqrt correctly rounded: relative error <= 3 ulp of double). The
         * libm form -expm1(log1p(-a)/2) is within ~3 ulp of double of the same real number too
         * (glibc's log1p and expm1 are < 1 ulp; |x e^x / (e^x - 1)| <= 1 for x <= 0 bounds the
         * propagation). Both therefore round to the same float unless the real value lies within
         * ~1e-15 (relative) of a midpoint between two floats; we take this quotient when it lies
         * further than VOL_RC_ALPHA_TIE (relative) from the midpoints around its float, and
         * otherwise the libm form: the float is the libm form's in every case (tests check it on
         * 2^24 alphas). */
        const double a = (double)alpha;
        const double q = a / (1.0 + sqrt(1.0 - a));
        const float f = (float)q;
        /* f's float neighbours from its bits (f >= 0 finite; f = 0 gives a NaN neighbour, so
         * the comparisons fail and libm decides) */
        uint32_t fb;
        memcpy(&fb, &f, sizeof fb);
        const uint32_t ub = fb + 1u, db = fb - 1u;
        float fu, fd;
        memcpy(&fu, &ub, sizeof fu);
        memcpy(&fd, &db, sizeof fd);
        const double up = 0.5 * ((double)f + (double)fu);
        const double dn = 0.5 * ((double)f + (double)fd);
        if (up - q > VOL_RC_ALPHA_TIE * q && q - dn > VOL_RC_ALPHA_TIE * q)
            return f;
    }
    double a = -expm1(r_h * log1p(-(double)alpha));
    return (float)(a < 0.0 ? 0.0 : a > 1.0 ? 1.0 : a);
}

float vol_i_rc_alpha_full_step(float alpha, double h, double ref_step)
{
    return rc_alpha_full_step(alpha, h, ref_step, h / ref_step);
}

/* ---- The fast mode's TF table (VOL_RC_FAST) ---------------------------------------------------- */

/* N = VOL_RC_FAST_TF_SIZE nodes v_i = lo + i (hi - lo) / (N - 1) over the TF's points [lo, hi], each
 * the exact TF (rc_tf_eval) with its alpha corrected for the full step (rc_alpha_full_step): the
 * pre-classified table of VTK's CPU ray caster and of the GPU ray casters' 1D TF texture [Engel06],
 * read with linear interpolation. Outside [lo, hi] the TF is constant, so clamping the index is
 * exact there. Interpolating the corrected alpha is not correcting the interpolated alpha (the
 * correction is concave): one source of the mode's error, with the nodes missing the TF's points. */
static void rc_tf_table_fill(const vol_tf *tf, double h, double ref_step, double r_h, float *tab, float *lo_out,
                             float *scale_out)
{
    const int N = VOL_RC_FAST_TF_SIZE;
    const double lo = tf->points[0].value, hi = tf->points[tf->count - 1].value;
    const double span = hi - lo;
    for (int i = 0; i < N; i++) {
        double v = span > 0.0 ? lo + span * (double)i / (double)(N - 1) : lo;
        float rgba[4];
        rc_tf_eval(tf, v, rgba);
        rgba[3] = rc_alpha_full_step(rgba[3], h, ref_step, r_h);
        memcpy(tab + 4 * i, rgba, sizeof rgba);
    }
    *lo_out = (float)lo;
    *scale_out = span > 0.0 ? (float)((double)(N - 1) / span) : 0.0f;
}

/* The table's linear interpolation at value s (float): the node index clamped to [0, N - 1]. */
static inline void rc_tf_table(const float *tab, float lo, float scale, float s, float rgba[4])
{
    float u = (s - lo) * scale;
    if (!(u > 0.0f))
        u = 0.0f;
    if (u > (float)(VOL_RC_FAST_TF_SIZE - 1))
        u = (float)(VOL_RC_FAST_TF_SIZE - 1);
    int i = (int)u;
    if (i > VOL_RC_FAST_TF_SIZE - 2)
        i = VOL_RC_FAST_TF_SIZE - 2;
    const float f = u - (float)i, e = 1.0f - f;
    const float *a = tab + 4 * i;
    for (int c = 0; c < 4; c++)
        rgba[c] = a[c] * e + a[c + 4] * f;
}

/* ---- Brick table ------------------------------------------------------------------------------- */

/* One z-row of bricks. A brick (bx, by, bz) holds the samples whose base voxel lies in
 * [bx B, (bx+1) B) x ...; their trilinear footprint is voxels [bx B, (bx+1) B] (the one-voxel apron
 * on the upper side, clipped to the grid), over which we take min and max. A brick with a
 * non-finite voxel is never empty. The TF's max alpha over [min, max], widened by a relative 1e-5
 * for the float rounding of the trilinear lerps (which may overshoot the corner values by a few
 * ulps), decides. */
static void rc_brick_row(void *user, int64_t task, int thread)
{
    (void)thread;
    rc_job *J = (rc_job *)user;
    const vol_grid *g = J->g;
    const int B = J->brick, bz = (int)task;
    const size_t sy = (size_t)g->nx, sz = (size_t)g->nx * (size_t)g->ny;
    int64_t nempty = 0;
    int z0 = bz * B, z1 = (bz + 1) * B < g->nz - 1 ? (bz + 1) * B : g->nz - 1;
    for (int by = 0; by < J->nb[1]; by++) {
        int y0 = by * B, y1 = (by + 1) * B < g->ny - 1 ? (by + 1) * B : g->ny - 1;
        for (int bx = 0; bx < J->nb[0]; bx++) {
            int x0 = bx * B, x1 = (bx + 1) * B < g->nx - 1 ? (bx + 1) * B : g->nx - 1;
            float vmin = INFINITY, vmax = -INFINITY;
            int bad = 0;
            for (int z = z0; z <= z1; z++) {
                for (int y = y0; y <= y1; y++) {
                    const float *row = g->data + (size_t)z * sz + (size_t)y * sy;
                    for (int x = x0; x <= x1; x++) {
                        float v = row[x];
                        if (!isfinite(v))
                            bad = 1;
                        if (v < vmin)
                            vmin = v;
                        if (v > vmax)
                            vmax = v;
                    }
                }
            }
            int empty = 0;
            if (!bad) {
                double lo = vmin, hi = vmax;
                double mag = fabs(lo) > fabs(hi) ? fabs(lo) : fabs(hi);
                double widen = 1e-5 * (mag > 1.0 ? mag : 1.0);
                empty = vol_i_rc_tf_max_alpha(J->tf, lo - widen, hi + widen) == 0.0f;
            }
            J->empty_w[((size_t)bz * J->nb[1] + by) * J->nb[0] + bx] = (uint8_t)empty;
            nempty += empty;
        }
    }
    J->row_empty[bz] = nempty;
}

/* ---- The fast mode's gradient volume (vol_rc_prepare with VOL_RC_FAST and Phong) ---------------- */

typedef struct rc_grad_job {
    const vol_grid *g;
    float *G;
} rc_grad_job;

/* One z-slice: per voxel and axis (s(i+1) - s(i-1)) / (2 spacing) ([Levoy88] eq. 4), the neighbour
 * index clamped to the grid as vol_grid_sample clamps (so one-sided at the faces, as the exact
 * mode's shifted samples are there), in double, stored as float. */
static void rc_grad_slice(void *user, int64_t task, int thread)
{
    (void)thread;
    const rc_grad_job *GJ = (const rc_grad_job *)user;
    const vol_grid *g = GJ->g;
    const int nx = g->nx, ny = g->ny, nz = g->nz, z = (int)task;
    const size_t sy = (size_t)nx, sz = (size_t)nx * (size_t)ny;
    const double inv2[3] = {1.0 / (2.0 * g->spacing[0]), 1.0 / (2.0 * g->spacing[1]), 1.0 / (2.0 * g->spacing[2])};
    const int zm = z > 0 ? z - 1 : 0, zp = z < nz - 1 ? z + 1 : nz - 1;
    for (int y = 0; y < ny; y++) {
        const int ym = y > 0 ? y - 1 : 0, yp = y < ny - 1 ? y + 1 : ny - 1;
        const float *row = g->data + (size_t)z * sz + (size_t)y * sy;
        const float *rym = g->data + (size_t)z * sz + (size_t)ym * sy, *ryp = g->data + (size_t)z * sz + (size_t)yp * sy;
        const float *rzm = g->data + (size_t)zm * sz + (size_t)y * sy, *rzp = g->data + (size_t)zp * sz + (size_t)y * sy;
        float *out = GJ->G + 3 * ((size_t)z * sz + (size_t)y * sy);
        for (int x = 0; x < nx; x++) {
            const int xm = x > 0 ? x - 1 : 0, xp = x < nx - 1 ? x + 1 : nx - 1;
            out[3 * x + 0] = (float)(((double)row[xp] - (double)row[xm]) * inv2[0]);
            out[3 * x + 1] = (float)(((double)ryp[x] - (double)rym[x]) * inv2[1]);
            out[3 * x + 2] = (float)(((double)rzp[x] - (double)rzm[x]) * inv2[2]);
        }
    }
}

/* ---- Shading ----------------------------------------------------------------------------------- */

void vol_i_rc_gradient(const vol_grid *g, const double c[3], double grad[3])
{
    for (int a = 0; a < 3; a++) {
        double cp[3] = {c[0], c[1], c[2]}, cm[3] = {c[0], c[1], c[2]};
        cp[a] += 1.0;
        cm[a] -= 1.0;
        double sp = rc_sample(g, cp[0], cp[1], cp[2]);
        double sm = rc_sample(g, cm[0], cm[1], cm[2]);
        /* [Levoy88] eq. 4 (central differences), divided by the axis' own spacing; at the grid's
         * edge the sampler clamps, so the difference is one-sided in effect there. */
        grad[a] = (sp - sm) / (2.0 * g->spacing[a]);
    }
}

/* vol_i_rc_gradient with the centre's splits given (the march made them): the sample one voxel
 * along axis a shares the other two axes' splits with the centre (the same coordinates), so only
 * the six shifted splits are made; the shifted coordinates (c +- 1, in double), the loads, the lerps
 * and the difference quotient are vol_i_rc_gradient's, so the same bits (a test checks it). */
typedef struct rc_split3 {
    int i0[3], i1[3];
    float t[3];
} rc_split3;

static inline void rc_gradient_split(const vol_grid *g, const double c[3], const rc_split3 *S, double grad[3])
{
    const int nv[3] = {g->nx, g->ny, g->nz};
    for (int a = 0; a < 3; a++) {
        rc_split3 P = *S, M = *S;
        rc_split(c[a] + 1.0, nv[a], &P.i0[a], &P.i1[a], &P.t[a]);
        rc_split(c[a] - 1.0, nv[a], &M.i0[a], &M.i1[a], &M.t[a]);
        double sp = rc_sample_split(g, P.i0[0], P.i1[0], P.t[0], P.i0[1], P.i1[1], P.t[1], P.i0[2], P.i1[2], P.t[2]);
        double sm = rc_sample_split(g, M.i0[0], M.i1[0], M.t[0], M.i0[1], M.i1[1], M.t[1], M.i0[2], M.i1[2], M.t[2]);
        grad[a] = (sp - sm) / (2.0 * g->spacing[a]); /* as vol_i_rc_gradient: [Levoy88] eq. 4 */
    }
}

void vol_i_rc_gradient_fast(const vol_grid *g, const double c[3], double grad[3])
{
    rc_split3 S;
    rc_split(c[0], g->nx, &S.i0[0], &S.i1[0], &S.t[0]);
    rc_split(c[1], g->ny, &S.i0[1], &S.i1[1], &S.t[1]);
    rc_split(c[2], g->nz, &S.i0[2], &S.i1[2], &S.t[2]);
    rc_gradient_split(g, c, &S, grad);
}

/* x^e for an integer e >= 0 by repeated squaring (VOL_RC_FAST's specular power for an integer
 * exponent, e.g. the default 32: five squarings instead of libm's pow). Each product rounds once
 * (relative 2^-53) and a squaring doubles the relative error it receives, so the result is within
 * about 2 e 2^-53 (relative) of x^e, ~7e-15 for e = 32: far below the float it ends in. Ours. */
static inline double rc_powi(double x, unsigned e)
{
    double r = 1.0;
    while (e) {
        if (e & 1u)
            r *= x;
        e >>= 1;
        if (e)
            x *= x;
    }
    return r;
}

/* VOL_RC_FAST's gradient: the prepared gradient volume (vol_rc_prepare: per voxel the central
 * differences of the voxel values, [Levoy88] eq. 4, clamped at the grid's faces as the sampler
 * clamps, divided by 2 x spacing, as float xyz) interpolated trilinearly with the sample's own
 * splits, component by component in the sampler's lerp order. For c strictly inside (0, n - 1) on
 * every axis this is the exact mode's gradient in real arithmetic: along x, with f = floor(c) and
 * t = c - f, s(c + 1) - s(c - 1) = lerp(v[f+1], v[f+2], t) - lerp(v[f-1], v[f], t)
 * = lerp(v[f+1] - v[f-1], v[f+2] - v[f], t), the lerp of the voxel differences, and the y and z
 * lerps are linear in both; the clamped neighbour index at f = 0 or f + 1 = n - 1 matches the
 * sampler's clamped coordinate (c - 1 < 0 reads v[0], c + 1 > n - 1 reads v[n-1]). So the two
 * differ only by float rounding there; in the outer half voxel (c <= 0 or c >= n - 1) they differ
 * and the exact gradient is used (docs/volume/raycast.md, "Third round"). VTK's CPU ray caster
 * also shades from per-voxel gradients (quantised; ours stay float). */
static inline void rc_gradient_volume(const float *G, int x0, int x1, float tx, int y0, int y1, float ty, int z0,
                                      int z1, float tz, size_t sy, size_t sz, double gr[3])
{
    const float *r00 = G + 3 * ((size_t)y0 * sy + (size_t)z0 * sz), *r10 = G + 3 * ((size_t)y1 * sy + (size_t)z0 * sz);
    const float *r01 = G + 3 * ((size_t)y0 * sy + (size_t)z1 * sz), *r11 = G + 3 * ((size_t)y1 * sy + (size_t)z1 * sz);
    const size_t i0 = 3 * (size_t)x0, i1 = 3 * (size_t)x1;
    const float ux = 1.0f - tx, uy = 1.0f - ty, uz = 1.0f - tz;
    for (int a = 0; a < 3; a++) {
        float c00 = r00[i0 + a] * ux + r00[i1 + a] * tx, c10 = r10[i0 + a] * ux + r10[i1 + a] * tx;
        float c01 = r01[i0 + a] * ux + r01[i1 + a] * tx, c11 = r11[i0 + a] * ux + r11[i1 + a] * tx;
        float e0 = c00 * uy + c10 * ty, e1 = c01 * uy + c11 * ty;
        gr[a] = (double)(e0 * uz + e1 * tz);
    }
}

/* Gradient Phong at world point x with gradient gr (rc_gradient_split or rc_gradient_volume) and TF colour rgb; V = unit vector towards
 * the eye. Our formula (docs/volume/raycast.md, "Phong"):
 *   g    = central differences of s, one voxel each way, in world units ([Levoy88] eq. 4 with
 *          the anisotropic spacing);
 *   n    = -g / |g| (outward: the value decreases outwards);
 *   s    = min(1, VOL_RC_SURFACENESS_GAIN |g| min_spacing / range)  (Voreen's "surfaceness",
 *          volume.md 1.8, in our units);
 *   diff = max(0, n.L);  spec = (n.L > 0) ? max(0, R.V)^e, R = 2 (n.L) n - L   [Phong75];
 *   out  = ka c + (1 - ka) Lc (c ((1 - s) + s diff) + s spec).
 * Where the gradient is weak the sample is lit unshaded (as Voreen's (1 - surf) l term). */
static inline void rc_shade_phong(const rc_job *J, const double x[3], const double gr[3], const double V[3], float rgb[3],
                                  const int fast)
{
    double gm = sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
    double s = 0.0, diff = 0.0, spec = 0.0;
    if (gm > 0.0 && isfinite(gm)) {
        double n[3] = {-gr[0] / gm, -gr[1] / gm, -gr[2] / gm};
        double L[3];
        if (J->light_point) {
            double dl[3] = {J->light_pos[0] - x[0], J->light_pos[1] - x[1], J->light_pos[2] - x[2]};
            double ll = sqrt(dl[0] * dl[0] + dl[1] * dl[1] + dl[2] * dl[2]);
            if (ll > 0.0) {
                for (int a = 0; a < 3; a++)
                    L[a] = dl[a] / ll;
            } else {
                for (int a = 0; a < 3; a++)
                    L[a] = n[a]; /* the light at the sample: full diffuse */
            }
        } else {
            for (int a = 0; a < 3; a++)
                L[a] = J->light_dir[a];
        }
        s = gm * J->surf_scale;
        if (s > 1.0)
            s = 1.0;
        double nl = n[0] * L[0] + n[1] * L[1] + n[2] * L[2];
        if (nl > 0.0) {
            diff = nl;
            double R[3] = {2.0 * nl * n[0] - L[0], 2.0 * nl * n[1] - L[1], 2.0 * nl * n[2] - L[2]};
            double rv = R[0] * V[0] + R[1] * V[1] + R[2] * V[2];
            if (!(rv > 0.0))
                spec = 0.0;
            else if (fast && J->spec_int >= 0)
                spec = rc_powi(rv, (unsigned)J->spec_int); /* VOL_RC_FAST: integer exponent by squaring */
            else
                spec = pow(rv, (double)J->p->specular_exponent);
        }
    }
    const double ka = J->p->ambient;
    for (int k = 0; k < 3; k++) {
        double lit = (double)rgb[k] * ((1.0 - s) + s * diff) + s * spec;
        rgb[k] = (float)(ka * rgb[k] + (1.0 - ka) * (double)J->light_color[k] * lit);
    }
}

/* ---- One ray ----------------------------------------------------------------------------------- */

typedef struct rc_ray_stats {
    int64_t rays, samples, skipped, shaded, terminated;
} rc_ray_stats;

/* The ray parameter at which the ray (o, d) leaves brick index cb along axis a: the brick's upper
 * face for d > 0, its lower face for d < 0; +inf for the last brick in the direction of travel
 * (its region is open that way) and for d = 0. */
static inline double rc_brick_exit(const rc_job *J, const double o[3], const double d[3], int a, int cb)
{
    const vol_grid *g = J->g;
    if (d[a] > 0.0 && cb < J->nb[a] - 1)
        return (g->origin[a] + (double)((cb + 1) * J->brick) * g->spacing[a] - o[a]) / d[a];
    if (d[a] < 0.0 && cb > 0)
        return (g->origin[a] + (double)(cb * J->brick) * g->spacing[a] - o[a]) / d[a];
    return INFINITY;
}

/* The AVX2 run's shading callback (vol_i_rc_run.shade): the scalar run's shading of a composited
 * full step k, on the same inputs (the world point from t_k, the gradient from the same splits),
 * so the same bits. */
typedef struct rc_shade_ctx {
    const rc_job *J;
    const double *o, *d, *V;
    double t0, dt;
    int fast;
} rc_shade_ctx;

static void rc_run_shade(const void *user, int64_t k, const double c[3], const int v0[3], const float t[3],
                         float rgb[3])
{
    const rc_shade_ctx *S = (const rc_shade_ctx *)user;
    const rc_job *J = S->J;
    double xw[3];
    const double tm = S->t0 + ((double)k + 0.5) * S->dt;
    for (int a = 0; a < 3; a++)
        xw[a] = S->o[a] + tm * S->d[a];
    if (J->p->shading == VOL_SHADING_PHONG) {
        double gr[3];
        const size_t sy = (size_t)J->g->nx, sz = (size_t)J->g->nx * (size_t)J->g->ny;
        if (S->fast && J->gradv) {
            rc_gradient_volume(J->gradv, v0[0], v0[0] + 1, t[0], v0[1], v0[1] + 1, t[1], v0[2], v0[2] + 1, t[2], sy, sz,
                               gr);
        } else {
            const rc_split3 SP = {{v0[0], v0[1], v0[2]}, {v0[0] + 1, v0[1] + 1, v0[2] + 1}, {t[0], t[1], t[2]}};
            rc_gradient_split(J->g, c, &SP, gr);
        }
        rc_shade_phong(J, xw, gr, S->V, rgb, S->fast);
    } else {
        float l, cc[3];
        vol_light_volume_sample(J->lv, xw, &l, cc);
        for (int q = 0; q < 3; q++)
            rgb[q] = rgb[q] * J->light_color[q] * l * cc[q]; /* as the general body */
    }
}

/* Composite the ray of pixel (x, y) (full-image pixel centre) into rgba (premultiplied).
 * Specialised by the compiler for the two precisions (rc_trace_exact, rc_trace_fast; fast is a
 * constant there). What VOL_RC_FAST changes here (docs/volume/raycast.md "Fast mode, third round"):
 * a full step's voxel coordinates are c0 + k dc (one multiply-add per axis from the ray's first
 * sample) instead of o + t_k d mapped to voxels; a full step classifies through the pre-corrected
 * table; Phong reads the prepared gradient volume when the handle has one. */
static inline __attribute__((always_inline)) void rc_trace_t(const rc_job *J, int x, int y, float out_rgba[4],
                                                             rc_ray_stats *st, const int fast)
{
    const vol_grid *g = J->g;
    const vol_rc_params *P = J->p;
    obs_dvec3 O, D;
    rast_pixel_ray(&J->vc, J->cam, (double)x + 0.5, (double)y + 0.5, &O, &D);
    const double o[3] = {O.x, O.y, O.z}, d[3] = {D.x, D.y, D.z};
    const double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);

    /* Ray interval: the parameter t is the linear view depth (rast_pixel_ray: view-space
     * dir.z = -1, origin at z = 0), so near/far and the mesh depth clip t directly. */
    double t0 = J->vc.znear, t1 = J->vc.zfar;
    if (J->depth) {
        double dv = obs_image_f32_row(J->depth, y)[x];
        if (dv < t1) /* NaN: no limit */
            t1 = dv;
    }
    /* Clip to the box (slabs; an axis the ray runs parallel to keeps t unless outside). */
    int hit = dl > 0.0;
    for (int a = 0; a < 3 && hit; a++) {
        if (d[a] == 0.0) {
            if (o[a] < J->lo[a] || o[a] > J->hi[a])
                hit = 0;
            continue;
        }
        double ta = (J->lo[a] - o[a]) / d[a], tb = (J->hi[a] - o[a]) / d[a];
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > t0)
            t0 = ta;
        if (tb < t1)
            t1 = tb;
    }
    double T = 1.0, C[3] = {0.0, 0.0, 0.0};
    if (hit && t1 > t0) {
        st->rays++;
        /* Steps of world length h (parameter dt); step k covers [t0 + k dt, t0 + (k+1) dt], the
         * last one ends at t1. Each is sampled at its midpoint and its opacity corrected for its
         * length: alpha = 1 - (1 - alpha_TF)^(len / ref_step), [Engel06]'s opacity
         * correction (vol_tf_alpha_correct; equation number not checked), vol.h's convention. */
        const double dt = J->h / dl;
        const int64_t n = (int64_t)ceil((t1 - t0) / dt);
        const double V[3] = {-d[0] / dl, -d[1] / dl, -d[2] / dl};
        const int B = J->brick;
        /* VOL_RC_FAST: the voxel coordinates of sample k (a full step) are c0 + k dc, the midpoint
         * of step 0 mapped to voxels plus k steps in voxels; within ~1e-13 voxel of the exact
         * mode's (o + t_k d - origin) / spacing and, like it, monotone in k (a correctly rounded
         * product by a constant and a sum with a constant are monotone), which the clamp-free
         * range below needs. */
        double c0[3] = {0.0, 0.0, 0.0}, dc[3] = {0.0, 0.0, 0.0};
        if (fast) {
            const double tf0 = t0 + 0.5 * dt;
            for (int a = 0; a < 3; a++) {
                c0[a] = (o[a] + tf0 * d[a] - g->origin[a]) * J->inv_sp[a];
                dc[a] = dt * d[a] * J->inv_sp[a];
            }
        }
        const size_t sy = (size_t)g->nx, sz = (size_t)g->nx * (size_t)g->ny;
        /* Loop invariants in locals (the stores to st and the image could otherwise alias them);
         * the counters are summed locally and added once. */
        const int nx = g->nx, ny = g->ny, nz = g->nz;
        int64_t n_samples = 0, n_skipped = 0, n_shaded = 0;
        /* The base-voxel range [nel, nel + B) of the last brick found non-empty: samples inside it
         * need no look-up. One test per axis: v is in it iff v - nel < B in unsigned arithmetic;
         * nel = -B: none yet (v - nel = v + B >= B for 0 <= v, B < 2^31). */
        int nel[3] = {-B, -B, -B};
        const unsigned UB = (unsigned)B;
        /* Clamp-free splits: along the full steps, c is a monotone function of k (the parameter
         * t0 + (k + 1/2) dt, o + t d and (x - origin) / spacing all round monotonically), so when
         * samples ka and kb lie strictly inside (0, n - 1) on every axis, every sample between them
         * does, and rc_split's clamping branches cannot fire there: rc_split_inside is then its
         * arithmetic, the same bits. [ka, kb] is estimated from the box planes with one step of
         * margin and then checked with the march's own expressions (empty if the check fails). */
        int64_t ka = 0, kb = n - 2; /* the last sample (a shorter step) always takes rc_split */
        {
            const int na[3] = {nx, ny, nz};
            for (int a = 0; a < 3 && ka <= kb; a++) {
                if (d[a] == 0.0)
                    continue; /* c constant: the check below decides */
                double ta = (g->origin[a] - o[a]) / d[a];
                double tb = (g->origin[a] + (double)(na[a] - 1) * g->spacing[a] - o[a]) / d[a];
                if (ta > tb) {
                    double tmp = ta;
                    ta = tb;
                    tb = tmp;
                }
                const double klo = ceil((ta - t0) / dt - 0.5) + 1.0, khi = floor((tb - t0) / dt - 0.5) - 1.0;
                if (!(klo <= khi)) {
                    ka = 1;
                    kb = 0;
                    break;
                }
                if (klo > (double)ka)
                    ka = klo < (double)n ? (int64_t)klo : n;
                if (khi < (double)kb)
                    kb = khi >= 0.0 ? (int64_t)khi : -1;
            }
            for (int e = 0; e < 2 && ka <= kb; e++) {
                const double ke = (double)(e ? kb : ka);
                const double tm = t0 + (ke + 0.5) * dt;
                for (int a = 0; a < 3; a++) {
                    const double xa = o[a] + tm * d[a];
                    const double ca = fast ? c0[a] + ke * dc[a] : (xa - g->origin[a]) * J->inv_sp[a];
                    if (!(ca > 0.0 && ca < (double)(na[a] - 1))) {
                        ka = 1;
                        kb = 0;
                        break;
                    }
                }
            }
        }
        /* B = 0 (no skipping): every base voxel counts as in the "non-empty brick", so the runs below
         * need no test of their own (v - 0 < UINT_MAX for 0 <= v < 2^31). */
        const unsigned URUN = B > 0 ? UB : 0xffffffffu;
        if (B == 0)
            nel[0] = nel[1] = nel[2] = 0;
        int done = 0;
        /* The AVX2 run (vol_raycast_avx2.c; the same bits): its ray-invariant inputs. */
        vol_i_rc_run R;
        rc_shade_ctx SC;
        const int use_avx2 = J->avx2;
        if (use_avx2) {
            R.c0[3] = R.dc[3] = R.o[3] = R.d[3] = R.org[3] = R.inv_sp[3] = 0.0; /* the padding lane */
            R.nel[3] = 0;
            R.shade = NULL;
            R.shade_user = NULL;
            R.data = g->data;
            R.sy = sy;
            R.sz = sz;
            R.fast = fast;
            for (int a = 0; a < 3; a++) {
                R.c0[a] = c0[a];
                R.dc[a] = dc[a];
                R.o[a] = o[a];
                R.d[a] = d[a];
                R.org[a] = g->origin[a];
                R.inv_sp[a] = J->inv_sp[a];
            }
            R.t0 = t0;
            R.dt = dt;
            R.urun = URUN;
            R.zero_below = J->zero_below;
            R.et = J->et;
            R.tft = J->tft;
            R.tft_lo = J->tft_lo;
            R.tft_scale = J->tft_scale;
            R.tf = J->tf;
            R.h = J->h;
            R.ref_step = J->ref_step;
            if (P->shading != VOL_SHADING_EMISSION_ABSORPTION) {
                SC.J = J;
                SC.o = o;
                SC.d = d;
                SC.V = V;
                SC.t0 = t0;
                SC.dt = dt;
                SC.fast = fast;
                R.shade = rc_run_shade;
                R.shade_user = &SC;
            }
        }
        for (int64_t k = 0; k < n; k++) {
            /* The run: full steps inside the clamp-free range [ka, kb] whose base voxel stays in the
             * last non-empty brick need neither rc_split's clamps nor a brick look-up; they are
             * marched here in a tight loop (the invariants in locals, so the compiler can keep them
             * in registers) with the general body's arithmetic in the general body's order, so the
             * same bits (the images are compared byte for byte with the general body alone in
             * volume_raycast_fast_run_loop_*; the exact mode's head-CT EXR is byte-identical). The
             * first sample that leaves the brick or the range goes to the general body below. */
            if (use_avx2 && k >= ka && k <= kb && (B == 0 || nel[0] >= 0)) {
                for (int a = 0; a < 3; a++)
                    R.nel[a] = nel[a];
                R.k = k;
                R.kb = kb;
                R.T = T;
                R.C[0] = C[0];
                R.C[1] = C[1];
                R.C[2] = C[2];
                R.samples = R.shaded = 0;
                R.done = 0;
#if defined(OBS_HAVE_AVX2)
                vol_i_rc_run_avx2(&R); /* use_avx2 is 0 without it */
#endif
                k = R.k;
                T = R.T;
                C[0] = R.C[0];
                C[1] = R.C[1];
                C[2] = R.C[2];
                n_samples += R.samples;
                n_shaded += R.shaded;
                if (R.done) {
                    st->terminated++;
                    break;
                }
                if (k >= n)
                    break;
            } else if (k >= ka && k <= kb && (B == 0 || nel[0] >= 0)) {
                const float *data = g->data;
                const double zb = J->zero_below, et = J->et, hh = J->h, href = J->ref_step, rh = J->r_h;
                const float *tft = J->tft;
                const float tlo = J->tft_lo, tsc = J->tft_scale;
                const unsigned n0 = (unsigned)nel[0], n1 = (unsigned)nel[1], n2 = (unsigned)nel[2];
                const vol_shading shading = P->shading;
                for (; k <= kb; k++) {
                    double c[3], xw[3], tm = 0.0;
                    if (fast) {
                        for (int a = 0; a < 3; a++)
                            c[a] = c0[a] + (double)k * dc[a];
                    } else {
                        tm = t0 + ((double)k + 0.5) * dt;
                        for (int a = 0; a < 3; a++) {
                            xw[a] = o[a] + tm * d[a];
                            c[a] = (xw[a] - g->origin[a]) * J->inv_sp[a];
                        }
                    }
                    int vx0, vx1, vy0, vy1, vz0, vz1;
                    float ftx, fty, ftz;
                    rc_split_inside(c[0], &vx0, &vx1, &ftx);
                    rc_split_inside(c[1], &vy0, &vy1, &fty);
                    rc_split_inside(c[2], &vz0, &vz1, &ftz);
                    if (!((unsigned)vx0 - n0 < URUN && (unsigned)vy0 - n1 < URUN && (unsigned)vz0 - n2 < URUN))
                        break; /* another brick: the general body looks it up */
                    n_samples++;
                    const float s =
                        rc_sample_base(data + (size_t)vx0 + (size_t)vy0 * sy + (size_t)vz0 * sz, sy, sz, ftx, fty, ftz);
                    if ((double)s <= zb)
                        continue;
                    float rgba[4], a;
                    if (fast) {
                        if (s != s)
                            continue;
                        rc_tf_table(tft, tlo, tsc, s, rgba);
                        if (!(rgba[3] > 0.0f))
                            continue;
                        a = rgba[3];
                    } else {
                        rc_tf_eval(J->tf, s, rgba);
                        if (!(rgba[3] > 0.0f))
                            continue;
                        a = rc_alpha_full_step(rgba[3], hh, href, rh);
                    }
                    n_shaded++;
                    float rgb[3] = {rgba[0], rgba[1], rgba[2]};
                    if (shading != VOL_SHADING_EMISSION_ABSORPTION) {
                        if (fast) {
                            tm = t0 + ((double)k + 0.5) * dt;
                            for (int a2 = 0; a2 < 3; a2++)
                                xw[a2] = o[a2] + tm * d[a2];
                        }
                        if (shading == VOL_SHADING_PHONG) {
                            double gr[3];
                            if (fast && J->gradv) {
                                rc_gradient_volume(J->gradv, vx0, vx1, ftx, vy0, vy1, fty, vz0, vz1, ftz, sy, sz, gr);
                            } else {
                                const rc_split3 S = {{vx0, vy0, vz0}, {vx1, vy1, vz1}, {ftx, fty, ftz}};
                                rc_gradient_split(g, c, &S, gr);
                            }
                            rc_shade_phong(J, xw, gr, V, rgb, fast);
                        } else {
                            float l, cc[3];
                            vol_light_volume_sample(J->lv, xw, &l, cc);
                            for (int q = 0; q < 3; q++)
                                rgb[q] = rgb[q] * J->light_color[q] * l * cc[q]; /* as the general body */
                        }
                    }
                    /* As the general body: [Porter84] "over", front to back. */
                    const double w = T * (double)a;
                    for (int q = 0; q < 3; q++)
                        C[q] += w * (double)rgb[q];
                    T *= 1.0 - (double)a;
                    if (1.0 - T >= et) {
                        done = 1;
                        break;
                    }
                }
                if (done) {
                    st->terminated++;
                    break;
                }
                if (k >= n)
                    break;
                /* k: the first sample not taken by the run (outside [ka, kb] or another brick) */
            }
            double tm, len;
            if (k + 1 < n) {
                tm = t0 + ((double)k + 0.5) * dt;
                len = J->h;
            } else {
                double ta = t0 + (double)k * dt;
                tm = 0.5 * (ta + t1);
                len = (t1 - ta) * dl;
                if (!(len > 0.0))
                    break;
            }
            double xw[3], c[3];
            if (fast && k + 1 < n) {
                for (int a = 0; a < 3; a++)
                    c[a] = c0[a] + (double)k * dc[a];
            } else {
                for (int a = 0; a < 3; a++) {
                    xw[a] = o[a] + tm * d[a];
                    c[a] = (xw[a] - g->origin[a]) * J->inv_sp[a];
                }
            }
            const int inside = k >= ka && k <= kb;
            /* The trilinear splits, made once for the brick look-up and the sample (the split's
             * lower voxel is the sample's base voxel: its brick). */
            int vx0, vx1, vy0, vy1, vz0, vz1;
            float ftx, fty, ftz;
            if (inside) {
                rc_split_inside(c[0], &vx0, &vx1, &ftx);
                rc_split_inside(c[1], &vy0, &vy1, &fty);
                rc_split_inside(c[2], &vz0, &vz1, &ftz);
            } else {
                rc_split(c[0], nx, &vx0, &vx1, &ftx);
                rc_split(c[1], ny, &vy0, &vy1, &fty);
                rc_split(c[2], nz, &vz0, &vz1, &ftz);
            }
            /* Empty-space skipping [Kruger03]: in a brick where the TF's alpha is 0 everywhere,
             * jump past the run of empty bricks the ray crosses from here. */
            if (B > 0 && !((unsigned)vx0 - (unsigned)nel[0] < UB && (unsigned)vy0 - (unsigned)nel[1] < UB &&
                           (unsigned)vz0 - (unsigned)nel[2] < UB)) {
                const int bi[3] = {J->bidx[0][vx0], J->bidx[1][vy0], J->bidx[2][vz0]};
                if (!J->empty[((size_t)bi[2] * J->nb[1] + bi[1]) * J->nb[0] + bi[0]]) {
                    for (int a = 0; a < 3; a++)
                        nel[a] = bi[a] * B;
                } else {
                    /* The brick's region in voxel coordinates: [bi B, (bi+1) B) per axis, open
                     * towards -inf for the first brick and +inf for the last. From it we walk
                     * brick by brick along the ray (a 3D DDA over the brick grid, as [Amanatides87]
                     * walks voxels) while the bricks are empty: texit is where the ray leaves the
                     * last empty brick of the run (before: one brick per skip, each skip costing a
                     * sample position and a look-up; the image is the same). Each crossing is
                     * computed from the brick's world boundary, not accumulated. */
                    int cb[3] = {bi[0], bi[1], bi[2]};
                    double tn[3];
                    for (int a = 0; a < 3; a++)
                        tn[a] = rc_brick_exit(J, o, d, a, cb[a]);
                    double texit;
                    for (;;) {
                        /* the axis of the nearest crossing: tn[0] <= tn[1] ? (tn[0] <= tn[2] ? 0 : 2)
                         * : (tn[1] <= tn[2] ? 1 : 2), written as selects (it was the march's most
                         * mispredicted branch: 142 k of 330 k steps on the head CT) */
                        const int a01 = tn[1] < tn[0];
                        const double t01 = a01 ? tn[1] : tn[0];
                        const int ax = t01 <= tn[2] ? a01 : 2;
                        texit = tn[ax];
                        if (!(texit < t1))
                            break;
                        cb[ax] += d[ax] > 0.0 ? 1 : -1;
                        if (!J->empty[((size_t)cb[2] * J->nb[1] + cb[1]) * J->nb[0] + cb[0]])
                            break;
                        tn[ax] = rc_brick_exit(J, o, d, ax, cb[ax]);
                    }
                    int64_t knew = n;
                    if (texit < t1) {
                        /* Sample k' (at t0 + (k' + 1/2) dt) lies before texit when
                         * k' < u = (texit - t0)/dt - 1/2; we skip those with
                         * k' < u - VOL_RC_SKIP_MARGIN (in steps), a margin far above the double
                         * rounding of t, c and texit (~1e-13 voxel), so every skipped sample's base
                         * voxel is in one of the walked empty bricks. (Before: a margin of one whole
                         * step; the image is the same, the counters count the same way.) */
                        double u = ceil((texit - t0) / dt - 0.5 - VOL_RC_SKIP_MARGIN);
                        knew = u < (double)n ? (int64_t)u : n;
                    }
                    if (knew < k + 1)
                        knew = k + 1;
                    n_skipped += knew - k;
                    k = knew - 1;
                    continue;
                }
            }
            n_samples++;
            float rgba[4], a;
            float s = inside ? rc_sample_base(g->data + (size_t)vx0 + (size_t)vy0 * sy + (size_t)vz0 * sz, sy, sz, ftx,
                                              fty, ftz)
                             : rc_sample_split(g, vx0, vx1, ftx, vy0, vy1, fty, vz0, vz1, ftz);
            if ((double)s <= J->zero_below)
                continue; /* alpha exactly 0 (rc_zero_below): the TF need not be evaluated */
            if (fast && k + 1 < n) {
                /* VOL_RC_FAST, a full step: the pre-corrected table (NaN: alpha 0, as the TF) */
                if (s != s)
                    continue;
                rc_tf_table(J->tft, J->tft_lo, J->tft_scale, s, rgba);
                if (!(rgba[3] > 0.0f))
                    continue;
                n_shaded++;
                a = rgba[3];
            } else {
                rc_tf_eval(J->tf, s, rgba);
                if (!(rgba[3] > 0.0f))
                    continue; /* contributes exactly nothing: shading skipped */
                n_shaded++;
                a = k + 1 < n ? rc_alpha_full_step(rgba[3], J->h, J->ref_step, J->r_h)
                              : vol_tf_alpha_correct(rgba[3], len, J->ref_step);
            }
            float rgb[3] = {rgba[0], rgba[1], rgba[2]};
            if (fast && k + 1 < n && P->shading != VOL_SHADING_EMISSION_ABSORPTION) {
                for (int a2 = 0; a2 < 3; a2++) /* the fast march did not need the world point */
                    xw[a2] = o[a2] + tm * d[a2];
            }
            switch (P->shading) {
            case VOL_SHADING_PHONG: {
                double gr[3];
                if (fast && J->gradv && c[0] > 0.0 && c[0] < (double)(nx - 1) && c[1] > 0.0 &&
                    c[1] < (double)(ny - 1) && c[2] > 0.0 && c[2] < (double)(nz - 1)) {
                    /* strictly inside: there the gradient volume's lerp is the exact mode's
                     * central difference in real arithmetic (rc_gradient_volume); in the outer
                     * half voxel, where the exact mode's shifted coordinates clamp, it is not */
                    rc_gradient_volume(J->gradv, vx0, vx1, ftx, vy0, vy1, fty, vz0, vz1, ftz, sy, sz, gr);
                } else {
                    const rc_split3 S = {{vx0, vy0, vz0}, {vx1, vy1, vz1}, {ftx, fty, ftz}};
                    rc_gradient_split(J->g, c, &S, gr);
                }
                rc_shade_phong(J, xw, gr, V, rgb, fast);
                break;
            }
            case VOL_SHADING_LIGHT_VOLUME: {
                float l, cc[3];
                vol_light_volume_sample(J->lv, xw, &l, cc);
                for (int q = 0; q < 3; q++)
                    rgb[q] = rgb[q] * J->light_color[q] * l * cc[q]; /* vol.h: TF rgb x (l Lc) x c */
                break;
            }
            default:
                break;
            }
            /* Front to back, premultiplied: [Porter84] "over" with the ray in front, as in [Levoy88]
             * and [Engel06]: C += T a c, T *= 1 - a (T = 1 - accumulated alpha). */
            double w = T * (double)a;
            for (int q = 0; q < 3; q++)
                C[q] += w * (double)rgb[q];
            T *= 1.0 - (double)a;
            if (1.0 - T >= J->et) {
                st->terminated++;
                break;
            }
        }
        st->samples += n_samples;
        st->skipped += n_skipped;
        st->shaded += n_shaded;
    }
    /* The background behind what the ray saw (premultiplied). */
    for (int q = 0; q < 3; q++)
        out_rgba[q] = (float)(C[q] + T * (double)P->background[q]);
    out_rgba[3] = (float)((1.0 - T) + T * (double)P->background[3]);
}

/* The pixels whose rays may meet the box: the box's eight corners taken to view space with the
 * inverse of the camera's world matrix (its 3x3 part inverted in double), projected as
 * rast_pixel_ray's slopes (ax, ay) = (X, Y) / -Z (perspective; orthographic (X, Y)); a ray whose
 * slopes lie outside the corners' bounding rectangle misses the box's convex image, so its pixel
 * is the background (what rc_trace gives for a ray that misses: C = 0, T = 1). Widened by
 * VOL_RC_RECT_MARGIN pixels, far above the double rounding here and in rast_pixel_ray's float
 * matrix. No culling (the whole image) when a corner is not in front of the camera
 * (perspective) or the matrix is singular. Ours: it changes no bit and no counter. */
#define VOL_RC_RECT_MARGIN 2
static void rc_screen_rect(rc_job *J, const obs_camera *cam, int W, int H)
{
    J->rx0 = 0;
    J->rx1 = W;
    J->ry0 = 0;
    J->ry1 = H;
    const float *w = cam->world.m;
    const double a[3][3] = {{w[0], w[4], w[8]}, {w[1], w[5], w[9]}, {w[2], w[6], w[10]}}; /* world = a view + t */
    const double t[3] = {w[12], w[13], w[14]};
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                       a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                       a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if (!(fabs(det) > 1e-6) || !isfinite(det))
        return;
    double inv[3][3];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) {
            /* the adjugate's (r, c) = cofactor (c, r) */
            const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            inv[r][c] = (a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]) / det;
        }
    }
    const int persp = J->vc.projection_type == OBS_PROJECTION_PERSPECTIVE;
    double amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
    for (int k = 0; k < 8; k++) {
        const double x[3] = {k & 1 ? J->hi[0] : J->lo[0], k & 2 ? J->hi[1] : J->lo[1], k & 4 ? J->hi[2] : J->lo[2]};
        double v[3];
        for (int r = 0; r < 3; r++)
            v[r] = inv[r][0] * (x[0] - t[0]) + inv[r][1] * (x[1] - t[1]) + inv[r][2] * (x[2] - t[2]);
        double ax = v[0], ay = v[1];
        if (persp) {
            if (!(v[2] < -1e-9 * (fabs(v[0]) + fabs(v[1]) + fabs(v[2]))))
                return; /* a corner at or behind the eye's plane: no culling */
            ax = v[0] / -v[2];
            ay = v[1] / -v[2];
        }
        if (!isfinite(ax) || !isfinite(ay))
            return;
        amin = ax < amin ? ax : amin;
        amax = ax > amax ? ax : amax;
        bmin = ay < bmin ? ay : bmin;
        bmax = ay > bmax ? ay : bmax;
    }
    /* rast_pixel_ray: ax = (px - cx) / fx, ay = -(py - cy) / fy at px = x + 1/2, py = y + 1/2 */
    const double p0 = J->vc.cx + amin * J->vc.fx - 0.5, p1 = J->vc.cx + amax * J->vc.fx - 0.5;
    const double q0 = J->vc.cy - bmin * J->vc.fy - 0.5, q1 = J->vc.cy - bmax * J->vc.fy - 0.5;
    const double xlo = (p0 < p1 ? p0 : p1) - VOL_RC_RECT_MARGIN, xhi = (p0 < p1 ? p1 : p0) + VOL_RC_RECT_MARGIN;
    const double ylo = (q0 < q1 ? q0 : q1) - VOL_RC_RECT_MARGIN, yhi = (q0 < q1 ? q1 : q0) + VOL_RC_RECT_MARGIN;
    if (!(xlo < 1e9 && xhi > -1e9 && ylo < 1e9 && yhi > -1e9))
        return;
    J->rx0 = xlo > 0.0 ? (int)floor(xlo) : 0;
    J->rx1 = xhi < (double)W ? (int)ceil(xhi) + 1 : W;
    J->ry0 = ylo > 0.0 ? (int)floor(ylo) : 0;
    J->ry1 = yhi < (double)H ? (int)ceil(yhi) + 1 : H;
    if (J->rx1 > W)
        J->rx1 = W;
    if (J->ry1 > H)
        J->ry1 = H;
    if (J->rx0 > J->rx1)
        J->rx0 = J->rx1;
    if (J->ry0 > J->ry1)
        J->ry0 = J->ry1;
}

static void rc_trace_exact(const rc_job *J, int x, int y, float out_rgba[4], rc_ray_stats *st)
{
    rc_trace_t(J, x, y, out_rgba, st, 0);
}

static void rc_trace_fast(const rc_job *J, int x, int y, float out_rgba[4], rc_ray_stats *st)
{
    rc_trace_t(J, x, y, out_rgba, st, 1);
}

static void rc_tile(void *user, int64_t task, int thread)
{
    (void)thread;
    rc_job *J = (rc_job *)user;
    int x0, y0, x1, y1;
    obs_tiling_rect(&J->tiling, task, &x0, &y0, &x1, &y1);
    rc_ray_stats st = {0, 0, 0, 0, 0};
    for (int y = y0; y < y1; y++) {
        float *r = obs_image_f32_row(&J->out[0], y), *gg = obs_image_f32_row(&J->out[1], y);
        float *b = obs_image_f32_row(&J->out[2], y), *a = obs_image_f32_row(&J->out[3], y);
        for (int x = x0; x < x1; x++) {
            float px[4];
            if (x < J->rx0 || x >= J->rx1 || y < J->ry0 || y >= J->ry1) {
                /* surely misses the box (rc_screen_rect): rc_trace's C = 0, T = 1 */
                const vol_rc_params *P = J->p;
                for (int q = 0; q < 3; q++)
                    px[q] = (float)(0.0 + 1.0 * (double)P->background[q]);
                px[3] = (float)((1.0 - 1.0) + 1.0 * (double)P->background[3]);
            } else if (J->p->precision == VOL_RC_FAST)
                rc_trace_fast(J, x, y, px, &st);
            else
                rc_trace_exact(J, x, y, px, &st);
            r[x] = px[0];
            gg[x] = px[1];
            b[x] = px[2];
            a[x] = px[3];
        }
    }
    vol_i_rc_stats *ts = &J->tile_stats[task];
    ts->rays = st.rays;
    ts->samples = st.samples;
    ts->samples_skipped = st.skipped;
    ts->samples_shaded = st.shaded;
    ts->rays_terminated = st.terminated;
}

/* ---- Entry points ------------------------------------------------------------------------------ */

static obs_status rc_check_light(obs_context *ctx, const vol_light *light, rc_job *J)
{
    if (!light)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: %s shading needs a light",
                         vol_shading_name(J->p->shading));
    for (int k = 0; k < 3; k++) {
        if (!isfinite(light->color[k]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: light colour is not finite");
        J->light_color[k] = light->color[k];
    }
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        if (!(len > 0.0) || !isfinite(len))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "vol_raycast: directional light direction must be finite and non-zero");
        J->light_point = 0;
        for (int a = 0; a < 3; a++)
            J->light_dir[a] = -light->direction[a] / len; /* towards the light */
    } else if (light->type == OBS_LIGHT_POINT) {
        for (int a = 0; a < 3; a++) {
            if (!isfinite(light->position[a]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: point light position is not finite");
            J->light_pos[a] = light->position[a];
        }
        J->light_point = 1;
    } else {
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "vol_raycast: only directional and point lights are supported");
    }
    return OBS_STATUS_OK;
}

/* The grid and TF checks shared by vol_rc_prepare (and so vol_raycast). */
static obs_status rc_check_grid_tf(obs_context *ctx, const vol_grid *g, const vol_tf *tf)
{
    if (!g || !g->data || !tf || !tf->points || tf->count < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: grid, transfer function or camera missing");
    if (g->nx < 1 || g->ny < 1 || g->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: grid %dx%dx%d is empty", g->nx, g->ny, g->nz);
    for (int a = 0; a < 3; a++) {
        if (!(g->spacing[a] > 0.0) || !isfinite(g->spacing[a]) || !isfinite(g->origin[a]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: grid spacing/origin invalid on axis %d", a);
    }
    if (tf->ref_step < 0.0 || !isfinite(tf->ref_step))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: TF ref_step %g must be >= 0 and finite",
                         tf->ref_step);
    return OBS_STATUS_OK;
}

int vol_i_rc_gradient_volume_at(const vol_rc_prepared *prep, const double c[3], double grad[3])
{
    if (!prep || !prep->gradv)
        return 0;
    const vol_grid *g = prep->g;
    rc_split3 S;
    rc_split(c[0], g->nx, &S.i0[0], &S.i1[0], &S.t[0]);
    rc_split(c[1], g->ny, &S.i0[1], &S.i1[1], &S.t[1]);
    rc_split(c[2], g->nz, &S.i0[2], &S.i1[2], &S.t[2]);
    rc_gradient_volume(prep->gradv, S.i0[0], S.i1[0], S.t[0], S.i0[1], S.i1[1], S.t[1], S.i0[2], S.i1[2], S.t[2],
                       (size_t)g->nx, (size_t)g->nx * (size_t)g->ny, grad);
    return 1;
}

void vol_rc_prepared_free(vol_rc_prepared *prep)
{
    if (!prep)
        return;
    free(prep->empty);
    for (int a = 0; a < 3; a++)
        free(prep->bidx[a]);
    free(prep->gradv);
    free(prep);
}

obs_status vol_rc_prepare(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                          const vol_rc_params *p, vol_rc_prepared **out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_rc_prepare: out is NULL");
    *out = NULL;
    obs_status st = rc_check_grid_tf(ctx, g, tf);
    if (st != OBS_STATUS_OK)
        return st;
    st = vol_i_rc_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    vol_rc_prepared *P = (vol_rc_prepared *)calloc(1, sizeof *P);
    if (!P)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_rc_prepare: out of memory");
    P->g = g;
    P->tf = tf;
    if (p->brick > 0) {
        const int B = p->brick, nv[3] = {g->nx, g->ny, g->nz};
        P->brick = B;
        for (int a = 0; a < 3; a++)
            P->nb[a] = (nv[a] + B - 1) / B;
        size_t nbricks = (size_t)P->nb[0] * P->nb[1] * P->nb[2];
        P->empty = (uint8_t *)malloc(nbricks);
        int64_t *row_empty = (int64_t *)calloc((size_t)P->nb[2], sizeof *row_empty);
        for (int a = 0; a < 3; a++)
            P->bidx[a] = (int32_t *)malloc((size_t)nv[a] * sizeof(int32_t));
        if (!P->empty || !row_empty || !P->bidx[0] || !P->bidx[1] || !P->bidx[2]) {
            free(row_empty);
            vol_rc_prepared_free(P);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_raycast: out of memory (brick table)");
        }
        for (int a = 0; a < 3; a++)
            for (int i = 0; i < nv[a]; i++)
                P->bidx[a][i] = i / B;
        rc_job J;
        memset(&J, 0, sizeof J);
        J.g = g;
        J.tf = tf;
        J.brick = B;
        for (int a = 0; a < 3; a++)
            J.nb[a] = P->nb[a];
        J.empty_w = P->empty;
        J.row_empty = row_empty;
        obs_pool_run(pool, P->nb[2], rc_brick_row, &J);
        P->bricks = (int64_t)nbricks;
        for (int z = 0; z < P->nb[2]; z++)
            P->bricks_empty += row_empty[z];
        free(row_empty);
    }
    if (p->precision == VOL_RC_FAST && p->shading == VOL_SHADING_PHONG) {
        /* The fast mode's gradient volume (rc_grad_slice): 12 bytes per voxel. */
        const size_t nvox = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
        P->gradv = nvox <= SIZE_MAX / (3 * sizeof(float)) ? (float *)malloc(nvox * 3 * sizeof(float)) : NULL;
        if (!P->gradv) {
            vol_rc_prepared_free(P);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_rc_prepare: out of memory (gradient volume, %zu voxels)",
                             nvox);
        }
        rc_grad_job GJ = {g, P->gradv};
        obs_pool_run(pool, g->nz, rc_grad_slice, &GJ);
    }
    *out = P;
    return OBS_STATUS_OK;
}

static obs_status rc_cast(obs_context *ctx, obs_pool *pool, const vol_rc_prepared *prep, const vol_light *light,
                          const vol_light_volume *lv, const obs_camera *camera, int width, int height,
                          const obs_image_f32 *depth_limit, const vol_rc_params *p, obs_image_f32 out[4],
                          vol_i_rc_stats *stats)
{
    if (stats)
        memset(stats, 0, sizeof *stats);
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: out is NULL");
    for (int c = 0; c < 4; c++)
        memset(&out[c], 0, sizeof out[c]);
    if (!prep || !camera)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: grid, transfer function or camera missing");
    obs_status st = vol_i_rc_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    if (p->brick != prep->brick)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "vol_raycast_prepared: params brick %d, but the prepared table has brick %d", p->brick,
                         prep->brick);
    const vol_grid *g = prep->g;
    const vol_tf *tf = prep->tf;

    rc_job J;
    memset(&J, 0, sizeof J);
    J.g = g;
    J.tf = tf;
    J.lv = lv;
    J.cam = camera;
    J.p = p;
    J.et = p->early_termination;

    /* Shading inputs */
    for (int k = 0; k < 3; k++)
        J.light_color[k] = 1.0f;
    if (p->shading != VOL_SHADING_EMISSION_ABSORPTION) {
        st = rc_check_light(ctx, light, &J);
        if (st != OBS_STATUS_OK)
            return st;
    }
    if (p->shading == VOL_SHADING_LIGHT_VOLUME && (!lv || !lv->l || !lv->c[0] || !lv->c[1] || !lv->c[2]))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: lightvolume shading needs a built light volume");

    /* The camera: the rasterizer's pixel ray model (no guard band), so a mesh depth lines up. */
    rast_params rp = rast_params_default();
    rp.width = width;
    rp.height = height;
    rp.guard = 0;
    st = rast_view_constants_make(ctx, &rp, camera, &J.vc);
    if (st != OBS_STATUS_OK)
        return st;
    if (depth_limit) {
        if (!depth_limit->data || depth_limit->width != width || depth_limit->height != height)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "vol_raycast: depth_limit is %dx%d, the image %dx%d", depth_limit->width,
                             depth_limit->height, width, height);
        J.depth = depth_limit;
    }
    {
        obs_limits deflim = obs_limits_default();
        const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
        if ((int64_t)width * height * 4 > lim->max_image_pixels)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "vol_raycast: %dx%d x 4 planes is over the limit of %lld pixels (--max-pixels)", width,
                             height, (long long)lim->max_image_pixels);
    }

    /* Geometry: box, step, ref_step */
    double smin = g->spacing[0];
    for (int a = 1; a < 3; a++)
        if (g->spacing[a] < smin)
            smin = g->spacing[a];
    vol_grid_bounds(g, J.lo, J.hi);
    for (int a = 0; a < 3; a++)
        J.inv_sp[a] = 1.0 / g->spacing[a];
    J.h = p->step > 0.0 ? p->step : VOL_RC_AUTO_STEP_FRACTION * smin;
    J.ref_step = tf->ref_step > 0.0 ? tf->ref_step : smin; /* vol.h: 0 = one voxel of the smallest spacing */
    J.r_h = J.h / J.ref_step;                              /* vol_tf_alpha_correct's r for a full step */
    J.zero_below = rc_zero_below(tf);
    {
        double diag = 0.0;
        for (int a = 0; a < 3; a++)
            diag += (J.hi[a] - J.lo[a]) * (J.hi[a] - J.lo[a]);
        diag = sqrt(diag);
        if (!(diag / J.h <= VOL_RC_MAX_STEPS_PER_RAY))
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "vol_raycast: step %g gives %.3g steps across the volume, over %.0f", J.h, diag / J.h,
                             VOL_RC_MAX_STEPS_PER_RAY);
    }
    {
        double range = (double)g->value_max - (double)g->value_min;
        J.surf_scale = range > 0.0 && isfinite(range) ? VOL_RC_SURFACENESS_GAIN * smin / range : 0.0;
    }
    /* The prepared brick table */
    J.brick = prep->brick;
    for (int a = 0; a < 3; a++) {
        J.nb[a] = prep->nb[a];
        J.bidx[a] = prep->bidx[a];
    }
    J.empty = prep->empty;
    J.gradv = p->precision == VOL_RC_FAST ? prep->gradv : NULL;
    J.avx2 = vol_i_rc_avx2_active();
    rc_screen_rect(&J, camera, width, height);
    J.spec_int = p->specular_exponent == floorf(p->specular_exponent) && p->specular_exponent <= 1024.0f
                     ? (int)p->specular_exponent
                     : -1;

    /* The fast mode's pre-corrected TF table (depends on the step: made per call, 64 KiB) */
    if (p->precision == VOL_RC_FAST) {
        J.tft = (float *)malloc((size_t)VOL_RC_FAST_TF_SIZE * 4 * sizeof(float));
        if (!J.tft)
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_raycast: out of memory (TF table)");
        rc_tf_table_fill(tf, J.h, J.ref_step, J.r_h, J.tft, &J.tft_lo, &J.tft_scale);
    }
    /* Allocations: the output, the per-tile counters. */
    J.tiling = obs_tiling_make(width, height, VOL_RC_TILE);
    int64_t ntiles = obs_tiling_count(&J.tiling);
    J.tile_stats = (vol_i_rc_stats *)calloc((size_t)ntiles, sizeof *J.tile_stats);
    if (!J.tile_stats) {
        free(J.tft);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "vol_raycast: out of memory (tile counters)");
    }
    for (int c = 0; c < 4 && st == OBS_STATUS_OK; c++)
        st = obs_image_f32_alloc(ctx, width, height, &out[c]);
    if (st == OBS_STATUS_OK) {
        J.out = out;
        obs_pool_run(pool, ntiles, rc_tile, &J);
        if (stats) {
            stats->bricks = prep->bricks;
            stats->bricks_empty = prep->bricks_empty;
            for (int64_t t = 0; t < ntiles; t++) {
                stats->rays += J.tile_stats[t].rays;
                stats->samples += J.tile_stats[t].samples;
                stats->samples_skipped += J.tile_stats[t].samples_skipped;
                stats->samples_shaded += J.tile_stats[t].samples_shaded;
                stats->rays_terminated += J.tile_stats[t].rays_terminated;
            }
        }
    } else {
        for (int c = 0; c < 4; c++)
            obs_image_f32_free(&out[c]);
    }
    free(J.tile_stats);
    free(J.tft);
    return st;
}

obs_status vol_i_rc_raycast_prepared_stats(obs_context *ctx, obs_pool *pool, const vol_rc_prepared *prep,
                                           const vol_light *light, const vol_light_volume *lv,
                                           const obs_camera *camera, int width, int height,
                                           const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                           obs_image_f32 out[4], vol_i_rc_stats *stats)
{
    return rc_cast(ctx, pool, prep, light, lv, camera, width, height, depth_limit, p, out, stats);
}

obs_status vol_raycast_prepared(obs_context *ctx, obs_pool *pool, const vol_rc_prepared *prep,
                                const vol_light *light, const vol_light_volume *lv, const obs_camera *camera,
                                int width, int height, const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                obs_image_f32 out[4])
{
    return rc_cast(ctx, pool, prep, light, lv, camera, width, height, depth_limit, p, out, NULL);
}

obs_status vol_i_rc_raycast_stats(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                  const vol_light *light, const vol_light_volume *lv, const obs_camera *camera,
                                  int width, int height, const obs_image_f32 *depth_limit, const vol_rc_params *p,
                                  obs_image_f32 out[4], vol_i_rc_stats *stats)
{
    if (stats)
        memset(stats, 0, sizeof *stats);
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: out is NULL");
    for (int c = 0; c < 4; c++)
        memset(&out[c], 0, sizeof out[c]);
    if (!camera)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_raycast: grid, transfer function or camera missing");
    vol_rc_prepared *prep = NULL;
    obs_status st = vol_rc_prepare(ctx, pool, g, tf, p, &prep);
    if (st != OBS_STATUS_OK)
        return st;
    st = rc_cast(ctx, pool, prep, light, lv, camera, width, height, depth_limit, p, out, stats);
    vol_rc_prepared_free(prep);
    return st;
}

obs_status vol_raycast(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf, const vol_light *light,
                       const vol_light_volume *lv, const obs_camera *camera, int width, int height,
                       const obs_image_f32 *depth_limit, const vol_rc_params *p, obs_image_f32 out[4])
{
    return vol_i_rc_raycast_stats(ctx, pool, g, tf, light, lv, camera, width, height, depth_limit, p, out, NULL);
}
