/* vol_light.c: the light volume of Ropinski, Doering and Rezk-Salama 2010 [Ropinski10], as the
 * public implementations build it (Voreen's LightVolumeGenerator, Inviwo's LightVolumeGL;
 * ../shared/reference/volume.md section 1). docs/volume/light.md describes the algorithm step by
 * step, what is a reconstruction, and the measured errors.
 *
 * Per light-volume voxel x, on slice i of the propagation axis (dir_max = -n_F0):
 *   sigma_t(x) = -kappa ln(1 - alpha_TF(s(x))) / ref_step                (vol.h convention,
 *                                                                        vol_sigma_from_alpha)
 *   p          = where the light ray through x meets slice i-1             (volume.md 1.4)
 *   ds         = |x - p| = Delta_a / |cos gamma|                            (volume.md 1.4)
 *   tau        = exp(-ds * (sigma_t(x) + sigma_t(p)) / 2)                   (trapezoid: see below)
 *   l_i(x)     = tau * l_{i-1}(p)                  one bilinear fetch      (volume.md 1.5 [R])
 *   c_bar      = normalised Gaussian ring of bilinear taps of c_{i-1} around p, radius
 *                r = ds tan(theta)                                          (volume.md 1.6 [R])
 *   c_i(x)     = tau * c_bar + (1 - tau) * c_TF(s(x))                       (volume.md 1.5, Voreen)
 *
 * Deviation (documented in docs/volume/light.md, "Differences"): Voreen and Inviwo attenuate the
 * step p -> x with the opacity at one end only (Inviwo: at x; Voreen: at p). We use the mean of the
 * two ends' extinction (the trapezoid rule on the segment): exact where sigma_t is constant along
 * the segment, second-order accurate otherwise; the one-ended forms shift the shadow by half a
 * voxel. sigma_t is post-classified, -ln(1 - alpha_TF(s)) of the trilinear s, so even along a grid
 * line (an axis-aligned light, s linear between voxel centres) it is not linear where s varies:
 * for a TF alpha linear from 0 to a over a one-voxel ramp the trapezoid counts -ln(1 - a) / 2
 * against the exact 1 + (1 - a) ln(1 - a) / a (a = 0.3: 0.178 against 0.168 per ramp, 0.0089 in
 * transmittance; docs/volume/light.md, "Measured errors").
 *
 * Threads: slices depend on each other. A propagation chain is one pool job of bands of rows, slice
 * after slice, each band waiting for the whole previous slice (lv_run_chain); each voxel reads only
 * the previous slice, so the output is identical for any thread count.
 *
 * Speed (docs/volume/light.md, steps 8 and 10, "Cost"): each row is classified at once and the
 * kernel path's span runs as a row kernel (vol_light_internal.h), scalar, AVX2 or AVX-512F with the
 * same bits. The span covers the slice's edge voxels too, their kernels reading the slice buffers'
 * border padding (lv_row): the one place where the output differs from the per-voxel loop it
 * replaced, by float rounding within the kernel path's bound (its sums against the per-tap
 * path's, docs/volume/light.md step 8). */
#include "vol.h"
#include "vol_light_internal.h"

#include <math.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---- Defaults ---------------------------------------------------------------------------------- */

#define VOL_LV_DEFAULT_SCALE 1            /* {1, 2, 4}; Voreen scalingMode_ "full" (volume.md 1.2) */
#define VOL_LV_DEFAULT_CONE_ANGLE_DEG 45.0 /* (0, 80]; Voreen's 1-texel stencil one slice back is
                                             atan(1) = 45 deg along the axes (volume.md 1.6 [R]) */
#define VOL_LV_DEFAULT_BLEND_SECOND 1     /* Inviwo always computes and merges both faces (1.3, 1.7) */
#define VOL_LV_DEFAULT_EYE_PASS 0         /* the eye pass is a reconstruction (volume.md 1.8) */
#define VOL_LV_DEFAULT_KAPPA 1.0          /* sigma_t = -ln(1 - alpha_TF) / ref_step: the opacity correction (vol.h) */
#define VOL_LV_MAX_CONE_DEG 80.0          /* vol.h: (0, 80]; tan 80 = 5.7 slabs of footprint */
#define VOL_LV_MAX_RINGS 4                /* cone stencil rings; 1 + 8 (1 + 2 + 3 + 4) = 81 taps at most */
#define VOL_LV_SEED_STEP_FRACTION 0.5     /* seed slices of a light inside: march step, x min data spacing */
#define LV_TAPS_MAX (8 * (VOL_LV_MAX_RINGS * (VOL_LV_MAX_RINGS + 1) / 2)) /* ring taps of R = 4 */

vol_lv_params vol_lv_params_default(void)
{
    vol_lv_params p;
    p.scale = VOL_LV_DEFAULT_SCALE;
    p.cone_angle_deg = VOL_LV_DEFAULT_CONE_ANGLE_DEG;
    p.blend_second = VOL_LV_DEFAULT_BLEND_SECOND;
    p.eye_pass = VOL_LV_DEFAULT_EYE_PASS;
    p.kappa = VOL_LV_DEFAULT_KAPPA;
    return p;
}

obs_status vol_lv_params_validate(obs_context *ctx, const vol_lv_params *p)
{
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: params is NULL");
    if (p->scale != 1 && p->scale != 2 && p->scale != 4)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "light volume: scale %d must be 1, 2 or 4 (Voreen's full, half, quarter)", p->scale);
    if (!isfinite(p->cone_angle_deg) || !(p->cone_angle_deg > 0.0) || p->cone_angle_deg > VOL_LV_MAX_CONE_DEG)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: cone angle %g deg must be in (0, %g]",
                         p->cone_angle_deg, VOL_LV_MAX_CONE_DEG);
    if (p->blend_second != 0 && p->blend_second != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: blend_second %d must be 0 or 1",
                         p->blend_second);
    if (p->eye_pass != 0 && p->eye_pass != 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: eye_pass %d must be 0 or 1", p->eye_pass);
    /* eye_pass = 1 is accepted: the eye pass depends on the camera, so vol_light_volume_build
     * ignores the flag and callers with a camera run vol_eye_volume_build and
     * vol_light_volume_modulate (vol.h). */
    if (!isfinite(p->kappa) || p->kappa < 0.0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: kappa %g must be finite and >= 0", p->kappa);
    return OBS_STATUS_OK;
}

/* ---- One propagation pass ---------------------------------------------------------------------- */

enum { LV_L = 0, LV_C0, LV_C1, LV_C2, LV_SIGMA, LV_CH };
#define LV_PAD 3 /* border texels around the slice buffers: fetches reach 2 texels out (lv_fetch) */

typedef enum lv_mode {
    LV_MODE_FACE = 0,   /* first slice next to the face the light enters by: l_{-1} = 1, c_{-1} = 1 */
    LV_MODE_PROPAGATE,  /* from the previous slice */
    LV_MODE_SEED        /* light inside the slab range: march straight to the light */
} lv_mode;

typedef struct lv_pass {
    const vol_grid *g;
    const vol_tf *tf;
    double sigma_scale;         /* kappa */
    double ref_step;
    int scale;
    int n[3];
    double sp[3], org[3];       /* light-volume grid */
    double lo[3], hi[3];        /* the data's bounds (vol_grid_bounds) */
    int a, u, v;                /* propagation axis; in-plane axes (u fastest in the slice buffers) */
    int nu, nv;
    int W;                      /* row stride of the slice buffers: nu + 2 LV_PAD (lv_propagate) */
    int point;                  /* 1: point light at P; 0: directional, travel direction D */
    double P[3], D[3];
    double tan_theta;
    /* The cone stencils for R = 1..VOL_LV_MAX_RINGS rings (lv_stencil_init): tap k of stencil R at
     * unit offset (cu, cv) (ring j at radius j/R, 8j taps at angles 2 pi m / 8j), Gaussian weight
     * w = exp(-|o|^2 / (2 (1/2)^2)) = exp(-2 (j/R)^2), and the weights' sum with the centre's 1. */
    int st_count[VOL_LV_MAX_RINGS + 1];
    const double *st_cu[VOL_LV_MAX_RINGS + 1], *st_cv[VOL_LV_MAX_RINGS + 1];
    const float *st_w[VOL_LV_MAX_RINGS + 1];
    float st_wsum[VOL_LV_MAX_RINGS + 1];
    /* The kernel path (directional lights; lv_kernel_init): every voxel of a pass has the same
     * offsets to p and to the cone's taps, so the bilinear fetch of l and sigma_t is one fixed 2x2
     * kernel at (bu, bv) with fractions (fu, fv), and the cone one fixed kW x kH kernel K at
     * (kI0, kJ0) with the sum Ksum. Used for voxels whose kernels lie inside the slice. */
    int kern;
    int bu, bv, kI0, kJ0, kW, kH;
    float fu, fv, Ksum;
    float *K;
    /* The per-tap path's per-pass constants for a directional light (lv_taps_init): the same
     * expressions lv_voxel evaluates per voxel, evaluated once (so the same bits): ds, the offset
     * ds D_u / sp_u and ds D_v / sp_v of p from x, the rings R and the taps' offsets ru cu[m],
     * rv cv[m]. taps_dir = 0 for point lights (D varies per voxel). */
    int taps_dir;
    double t_ds, t_ou, t_ov;
    int t_R;
    double t_du[LV_TAPS_MAX], t_dv[LV_TAPS_MAX];
    /* the slice being computed */
    int k, kprev;
    lv_mode mode;
    float *prev[LV_CH], *cur[LV_CH];
    float *out_l, *out_c[3];
    size_t ostr[3];             /* out_* elements per step along x, y, z (lv_propagate) */
    int stage_ok;               /* a pass along x may stage its output slice-major (lv_propagate) */
    vol_lv_workspace *ws;       /* the rebuild's kept blocks (vol_light_volume_rebuild); NULL: none */
    /* the row kernels (vol_light_internal.h) */
    int avx2;                   /* vol_i_lv_avx2_active() at the build's start */
    int avx512;                 /* vol_i_lv_isa() == 2: the span 16 voxels at a time */
    vol_i_lv_tf T;              /* the TF prepared for row classification */
    float *scratch;             /* per thread: the row's values, sigma_t and c_TF (5 rows of nu_pad) */
    size_t nu_pad;
    int rows_per_task;
    const float *occ_sigma;     /* the meshes' extra extinction (vol_i_occ_sigma), NULL: none */
    float (*entry)(void *user, const double x[3]); /* vol_occluder.entry: NULL, l_{-1} = 1 */
    void *entry_user;
} lv_pass;

/* Classification (vol_light_internal.h): the TF at each value, sigma_t by vol.h's convention. */
void vol_i_lv_classify_scalar(const vol_i_lv_tf *T, const float *s, int n, float *sigma, float *c0, float *c1,
                              float *c2)
{
    for (int i = 0; i < n; i++) {
        float rgba[4];
        vol_tf_eval(T->tf, s[i], rgba);
        sigma[i] = (float)(T->kappa * vol_sigma_from_alpha(rgba[3], T->ref_step));
        c0[i] = rgba[0];
        c1[i] = rgba[1];
        c2[i] = rgba[2];
    }
}

#if !defined(OBS_HAVE_AVX2)
int vol_i_lv_exp_test_avx2(const double *x, int n, double *y, float *f)
{
    (void)x, (void)n, (void)y, (void)f;
    return 0;
}
int vol_i_lv_log1p_test_avx2(const double *a, int n, double *y)
{
    (void)a, (void)n, (void)y;
    return 0;
}
#endif

int vol_i_lv_isa(void)
{
    if (!vol_i_lv_avx2_active())
        return 0;
#if defined(VOL_I_LV_HAVE_AVX512)
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "avx2"))
        return 1;
    return __builtin_cpu_supports("avx512f") ? 2 : 1;
#else
    return 1;
#endif
}

int vol_i_lv_avx2_active(void)
{
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
    const char *env = getenv("OBS_ISA");
    if (env && !strcmp(env, "scalar"))
        return 0;
    return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    return 0;
#endif
}

/* The kernel path's row (vol_light_internal.h), one voxel after the other. The arithmetic is the
 * per-voxel kernel path's, operation for operation; exp is skipped where its argument is 0
 * (exp(+-0) = 1 exactly, C11 F.10.3.1), which changes no bit. */
static inline __attribute__((always_inline)) void lv_span1(const vol_i_lv_span *S, int iu0, int iu1, const int kW,
                                                           const int kH)
{
    const ptrdiff_t nu = S->stride; /* row stride */
    const float fu = S->fu, fv = S->fv, Ksum = S->Ksum;
    const float *K = S->K;
    const ptrdiff_t ob = (ptrdiff_t)(S->jv + S->bv) * nu + S->bu;
    const ptrdiff_t kb = (ptrdiff_t)(S->jv + S->kJ0) * nu + S->kI0;
    for (int iu = iu0; iu < iu1; iu++) {
        const float sigma = S->sigma[iu];
        const float *s0 = S->prev_sigma + ob + iu, *s1 = s0 + nu;
        const float *l0 = S->prev_l + ob + iu, *l1 = l0 + nu;
        float sa = s0[0] + (s0[1] - s0[0]) * fu, sb = s1[0] + (s1[1] - s1[0]) * fu;
        float sigma_p = sa + (sb - sa) * fv;
        double arg = -0.5 * ((double)sigma + (double)sigma_p) * S->ds;
        float tau = arg == 0.0 ? 1.0f : (float)exp(arg);
        float la = l0[0] + (l0[1] - l0[0]) * fu, lb = l1[0] + (l1[1] - l1[0]) * fu;
        float l = tau * (la + (lb - la) * fv);
        float acc[3] = {0.0f, 0.0f, 0.0f};
        for (int dj = 0; dj < kH; dj++) {
            const ptrdiff_t ro = kb + (ptrdiff_t)dj * nu + iu;
            const float *r0 = S->prev_c[0] + ro, *r1 = S->prev_c[1] + ro, *r2 = S->prev_c[2] + ro;
            const float *Kr = K + dj * kW;
            for (int di = 0; di < kW; di++) {
                float w = Kr[di];
                acc[0] += w * r0[di];
                acc[1] += w * r1[di];
                acc[2] += w * r2[di];
            }
        }
        S->cur_l[iu] = l;
        S->cur_sigma[iu] = sigma;
        const ptrdiff_t oi = (ptrdiff_t)iu * S->out_stride;
        S->out_l[oi] = l;
        for (int c = 0; c < 3; c++) {
            float cc = tau * (acc[c] / Ksum) + (1.0f - tau) * S->ctf[c][iu];
            S->cur_c[c][iu] = cc;
            S->out_c[c][oi] = cc;
        }
    }
}

/* The kernel's size as constants for the default 45-degree cone along an axis (the loops unroll). */
void vol_i_lv_span_scalar(const vol_i_lv_span *S, int iu0, int iu1)
{
    if (S->kW == 3 && S->kH == 3)
        lv_span1(S, iu0, iu1, 3, 3);
    else
        lv_span1(S, iu0, iu1, S->kW, S->kH);
}

/* Extinction of the data at a world point: trilinear value, then TF (post-classification); 0
 * outside the bounds (the same definition as truth_volume). */
static double lv_sigma_world(const lv_pass *P, const double y[3])
{
    const vol_grid *g = P->g;
    for (int c = 0; c < 3; c++)
        if (y[c] < P->lo[c] || y[c] > P->hi[c])
            return 0.0;
    float s = vol_grid_sample(g, (y[0] - g->origin[0]) / g->spacing[0], (y[1] - g->origin[1]) / g->spacing[1],
                              (y[2] - g->origin[2]) / g->spacing[2]);
    float rgba[4];
    vol_tf_eval(P->tf, s, rgba);
    if (P->occ_sigma) /* the meshes' occupancy (vol.h vol_occluder) */
        return P->sigma_scale * vol_sigma_from_alpha(rgba[3], P->ref_step) +
               vol_i_occ_sigma_at(P->occ_sigma, P->n, P->org, P->sp, y);
    return P->sigma_scale * vol_sigma_from_alpha(rgba[3], P->ref_step);
}

/* Seed slices of a light inside the slab range: transmittance from x straight to the light, by
 * the trapezoid rule on the data (step VOL_LV_SEED_STEP_FRACTION x the smallest data spacing). */
static double lv_seed_march(const lv_pass *P, const double x[3])
{
    double d[3] = {P->P[0] - x[0], P->P[1] - x[1], P->P[2] - x[2]};
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 0.0))
        return 1.0;
    double hmin = fmin(P->g->spacing[0], fmin(P->g->spacing[1], P->g->spacing[2])) * VOL_LV_SEED_STEP_FRACTION;
    int steps = (int)ceil(len / hmin);
    if (steps < 1)
        steps = 1;
    double h = len / steps, acc = 0.0, prev = lv_sigma_world(P, x);
    for (int s = 1; s <= steps; s++) {
        double t = (double)s / steps, y[3] = {x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]};
        double cur = lv_sigma_world(P, y);
        acc += 0.5 * (prev + cur) * h; /* trapezoid rule */
        prev = cur;
    }
    return exp(-acc);
}

/* floor(x), exactly, without the libm call for |x| < 2^30 (the fetch coordinates; beyond, libm's). */
static inline double lv_floor(double x)
{
    if (!(x > -1073741824.0 && x < 1073741824.0))
        return floor(x);
    double t = (double)(int)x; /* truncation toward zero: exact in this range */
    return t > x ? t - 1.0 : t;
}

/* Bilinear fetch of channel ch of the previous slice at continuous (pu, pv) (centres at integers),
 * texels outside the slice read `border` (GL's CLAMP_TO_BORDER: outside the light volume the light
 * is unattenuated, Inviwo's border colour 1, volume.md 1.2). The slice buffers carry LV_PAD texels
 * of each channel's border value around the slice (lv_propagate), so a texel outside the slice
 * reads the border value from memory instead of a test per texel; beyond 2 texels out the fetch
 * returns the border value itself (the same number: a lerp of equal values is exact). */
static inline float lv_fetch(const lv_pass *P, int ch, double pu, double pv, float border)
{
    const int nu = P->nu, nv = P->nv;
    const ptrdiff_t W = P->W;
    int i0, j0;
    float tu, tv;
    if (pu >= 0.0 && pv >= 0.0 && pu < (double)(nu - 1) && pv < (double)(nv - 1)) {
        /* Interior: truncation is floor. */
        i0 = (int)pu, j0 = (int)pv;
        tu = (float)(pu - (double)i0), tv = (float)(pv - (double)j0);
    } else {
        if (pu > (double)nu + 1.0 || pv > (double)nv + 1.0 || pu < -2.0 || pv < -2.0)
            return border;
        double fu = lv_floor(pu), fv = lv_floor(pv);
        i0 = (int)fu, j0 = (int)fv; /* in [-2, n + 1]: inside the padding */
        tu = (float)(pu - fu), tv = (float)(pv - fv);
    }
    const float *r0 = P->prev[ch] + (ptrdiff_t)j0 * W + i0, *r1 = r0 + W;
    /* Lerps as a + (b - a) t: a constant field is reproduced exactly (the empty-TF limit l = 1). */
    float a = r0[0] + (r0[1] - r0[0]) * tu, b = r1[0] + (r1[1] - r1[0]) * tu;
    return a + (b - a) * tv;
}

/* lv_fetch of l with an entry transmittance (vol.h vol_occluder.entry): a texel outside the
 * previous slice is the light entering the box there, so instead of the border value l = 1 it is
 * entry() at that texel's world position (on the previous slice's plane, outside the box: the
 * light's path from it is outside the box). Texels inside read the slice; the lerps are
 * lv_fetch's. Only called with entry set (without it the build keeps lv_fetch's bits). */
static float lv_fetch_l_entry(const lv_pass *P, double pu, double pv)
{
    const int nu = P->nu, nv = P->nv;
    if (pu >= 0.0 && pv >= 0.0 && pu < (double)(nu - 1) && pv < (double)(nv - 1))
        return lv_fetch(P, LV_L, pu, pv, 1.0f);
    const double fu = lv_floor(pu), fv = lv_floor(pv);
    const float tu = (float)(pu - fu), tv = (float)(pv - fv);
    float t[4];
    for (int q = 0; q < 4; q++) {
        const double iu = fu + (q & 1), jv = fv + (q >> 1);
        if (iu >= 0.0 && jv >= 0.0 && iu <= (double)(nu - 1) && jv <= (double)(nv - 1)) {
            t[q] = P->prev[LV_L][(ptrdiff_t)jv * P->W + (ptrdiff_t)iu];
        } else {
            double x[3];
            x[P->a] = P->org[P->a] + (double)P->kprev * P->sp[P->a];
            x[P->u] = P->org[P->u] + iu * P->sp[P->u];
            x[P->v] = P->org[P->v] + jv * P->sp[P->v];
            const float e = P->entry(P->entry_user, x);
            t[q] = e >= 0.0f ? (e <= 1.0f ? e : 1.0f) : (e < 0.0f ? 0.0f : 1.0f);
        }
    }
    const float a = t[0] + (t[1] - t[0]) * tu, b = t[2] + (t[3] - t[2]) * tu;
    return a + (b - a) * tv;
}

/* The same bilinear fetch of three channels (the chromaticity) sharing the index arithmetic. */
static inline void lv_fetch3(const lv_pass *P, int ch0, double pu, double pv, float border, float out[3])
{
    const int nu = P->nu, nv = P->nv;
    const ptrdiff_t W = P->W;
    int i0, j0;
    float tu, tv;
    if (pu >= 0.0 && pv >= 0.0 && pu < (double)(nu - 1) && pv < (double)(nv - 1)) {
        /* Interior fast path: for pu, pv in [0, n-1) truncation is floor (no libm call). */
        i0 = (int)pu, j0 = (int)pv;
        tu = (float)(pu - (double)i0), tv = (float)(pv - (double)j0);
    } else {
        if (pu > (double)nu + 1.0 || pv > (double)nv + 1.0 || pu < -2.0 || pv < -2.0) {
            out[0] = out[1] = out[2] = border;
            return;
        }
        double fu = lv_floor(pu), fv = lv_floor(pv);
        i0 = (int)fu, j0 = (int)fv;
        tu = (float)(pu - fu), tv = (float)(pv - fv);
    }
    const ptrdiff_t o = (ptrdiff_t)j0 * W + i0;
    for (int c = 0; c < 3; c++) {
        const float *r0 = P->prev[ch0 + c] + o, *r1 = r0 + W;
        float a = r0[0] + (r0[1] - r0[0]) * tu, b = r1[0] + (r1[1] - r1[0]) * tu;
        out[c] = a + (b - a) * tv;
    }
}

/* One voxel (iu, jv) of the current slice by the general path (every mode; the per-tap cone, and
 * the kernel path where its kernels lie inside the slice), from its classification. */
static void lv_voxel(const lv_pass *P, int iu, int jv, float sigma, const float ctf[3])
{
    const int a = P->a, u = P->u, v = P->v;
    int idx[3];
    idx[a] = P->k;
    idx[u] = iu;
    idx[v] = jv;
    double x[3];
    for (int c = 0; c < 3; c++)
        x[c] = P->org[c] + idx[c] * P->sp[c];
    ptrdiff_t si = (ptrdiff_t)jv * P->W + iu;
    float l, cc[3];

    /* Travel direction of the light at x: constant (directional) or away from the light (point). */
    double D[3];
    if (P->point) {
        double dx = x[0] - P->P[0], dy = x[1] - P->P[1], dz = x[2] - P->P[2];
        double len = sqrt(dx * dx + dy * dy + dz * dz);
        if (len > 0.0)
            D[0] = dx / len, D[1] = dy / len, D[2] = dz / len;
        else
            D[0] = D[1] = 0.0, D[2] = 1.0;
    } else {
        D[0] = P->D[0], D[1] = P->D[1], D[2] = P->D[2];
    }
    double cos_g = fabs(D[a]);

    if (P->mode == LV_MODE_SEED) {
        /* Light inside the slab range: no previous slice lies between x and the light; march
         * straight to it (a reconstruction, docs/volume/light.md "A light inside"). */
        double T = lv_seed_march(P, x);
        l = (float)T;
        for (int c = 0; c < 3; c++)
            cc[c] = (float)(T + (1.0 - T) * ctf[c]);
    } else if (P->mode == LV_MODE_FACE || cos_g < 1e-12) {
        /* First slice: from the voxel centre back to the face it lies half a slab behind,
         * through constant sigma_t(x) (the edge value); l_{-1} = c_{-1} = 1 beyond. */
        double ds = cos_g > 0.0 ? 0.5 * P->sp[a] / cos_g : 0.0;
        const double arg = -(double)sigma * ds;
        float tau = arg == 0.0 ? 1.0f : (float)exp(arg); /* exp(+-0) = 1 exactly (C11 F.10.3.1) */
        l = tau;
        if (P->entry) { /* l_{-1}: the light's path outside the box (vol.h vol_occluder.entry) */
            double xf[3];
            for (int c = 0; c < 3; c++)
                xf[c] = x[c] - D[c] * ds; /* back along the light ray to the face */
            float e = P->entry(P->entry_user, xf);
            e = e >= 0.0f ? (e <= 1.0f ? e : 1.0f) : (e < 0.0f ? 0.0f : 1.0f);
            l = tau * e;
        }
        for (int c = 0; c < 3; c++)
            cc[c] = tau + (1.0f - tau) * ctf[c];
    } else if (P->kern && iu + P->kI0 >= 0 && iu + P->kI0 + P->kW <= P->nu && jv + P->kJ0 >= 0 &&
               jv + P->kJ0 + P->kH <= P->nv && iu + P->bu >= 0 && iu + P->bu + 1 < P->nu &&
               jv + P->bv >= 0 && jv + P->bv + 1 < P->nv) {
        /* The kernel path: the same quantities as the per-tap path below, with the bilinear
         * weights of all taps gathered into one kernel per pass (lv_kernel_init). */
        double ds = P->sp[a] / cos_g;
        ptrdiff_t o = (ptrdiff_t)(jv + P->bv) * P->W + (iu + P->bu);
        const float *s0 = P->prev[LV_SIGMA] + o, *s1 = s0 + P->W;
        const float *l0 = P->prev[LV_L] + o, *l1 = l0 + P->W;
        float fu = P->fu, fv = P->fv;
        float sa = s0[0] + (s0[1] - s0[0]) * fu, sb = s1[0] + (s1[1] - s1[0]) * fu;
        float sigma_p = sa + (sb - sa) * fv;
        float tau = (float)exp(-0.5 * ((double)sigma + (double)sigma_p) * ds);
        float la = l0[0] + (l0[1] - l0[0]) * fu, lb = l1[0] + (l1[1] - l1[0]) * fu;
        l = tau * (la + (lb - la) * fv);
        float acc[3] = {0.0f, 0.0f, 0.0f};
        const float *K = P->K;
        ptrdiff_t ko = (ptrdiff_t)(jv + P->kJ0) * P->W + (iu + P->kI0);
        for (int dj = 0; dj < P->kH; dj++) {
            const float *r0 = P->prev[LV_C0] + ko + (ptrdiff_t)dj * P->W;
            const float *r1 = P->prev[LV_C1] + ko + (ptrdiff_t)dj * P->W;
            const float *r2 = P->prev[LV_C2] + ko + (ptrdiff_t)dj * P->W;
            for (int di = 0; di < P->kW; di++) {
                float w = K[dj * P->kW + di];
                acc[0] += w * r0[di];
                acc[1] += w * r1[di];
                acc[2] += w * r2[di];
            }
        }
        for (int c = 0; c < 3; c++)
            cc[c] = tau * (acc[c] / P->Ksum) + (1.0f - tau) * ctf[c];
    } else {
        /* Where the light ray through x meets the previous slice ([Ropinski10] via Voreen /
         * Inviwo, volume.md 1.4): p = x - t D with t = Delta_a / |D_a| (= ds, |D| = 1). A
         * directional light's ds and offsets are the pass's constants (lv_taps_init: the same
         * expressions, so the same bits). */
        const int dir = P->taps_dir;
        double ds = dir ? P->t_ds : P->sp[a] / cos_g;
        double pu = (double)iu - (dir ? P->t_ou : ds * D[u] / P->sp[u]);
        double pv = (double)jv - (dir ? P->t_ov : ds * D[v] / P->sp[v]);
        /* tau = exp(-sigma_t ds), sigma_t the segment's trapezoid mean (deviation: see top). */
        float sigma_p = lv_fetch(P, LV_SIGMA, pu, pv, 0.0f);
        const double arg = -0.5 * ((double)sigma + (double)sigma_p) * ds;
        float tau = arg == 0.0 ? 1.0f : (float)exp(arg); /* exp(+-0) = 1 exactly: empty space skips libm */
        /* Hard shadow: one bilinear fetch (volume.md 1.5). */
        l = tau * (P->entry ? lv_fetch_l_entry(P, pu, pv) : lv_fetch(P, LV_L, pu, pv, 1.0f));
        /* Chromaticity: cone of half-angle theta, footprint radius r = ds tan(theta) on slice
         * i-1 (volume.md 1.6 [R]): the centre tap and R rings of 8j bilinear taps at radius
         * r j / R, Gaussian weights exp(-|o|^2 / (2 (r/2)^2)), normalised. */
        float acc[3], q[3];
        int R;
        lv_fetch3(P, LV_C0, pu, pv, 1.0f, acc);
        if (dir) {
            R = P->t_R;
            const int cnt = P->st_count[R];
            const float *w = P->st_w[R];
            for (int m = 0; m < cnt; m++) {
                lv_fetch3(P, LV_C0, pu + P->t_du[m], pv + P->t_dv[m], 1.0f, q);
                for (int c = 0; c < 3; c++)
                    acc[c] += w[m] * q[c];
            }
        } else {
            double r = ds * P->tan_theta, ru = r / P->sp[u], rv = r / P->sp[v];
            double rmax = ru > rv ? ru : rv;
            R = (int)ceil(rmax - 1e-9);
            if (R < 1)
                R = 1;
            if (R > VOL_LV_MAX_RINGS)
                R = VOL_LV_MAX_RINGS;
            const int cnt = P->st_count[R];
            const double *cu = P->st_cu[R], *cv = P->st_cv[R];
            const float *w = P->st_w[R];
            for (int m = 0; m < cnt; m++) {
                lv_fetch3(P, LV_C0, pu + ru * cu[m], pv + rv * cv[m], 1.0f, q);
                for (int c = 0; c < 3; c++)
                    acc[c] += w[m] * q[c];
            }
        }
        const float wsum = P->st_wsum[R];
        for (int c = 0; c < 3; c++)
            cc[c] = tau * (acc[c] / wsum) + (1.0f - tau) * ctf[c];
    }

    P->cur[LV_L][si] = l;
    P->cur[LV_C0][si] = cc[0];
    P->cur[LV_C1][si] = cc[1];
    P->cur[LV_C2][si] = cc[2];
    P->cur[LV_SIGMA][si] = sigma;
    size_t oi = idx[0] * P->ostr[0] + idx[1] * P->ostr[1] + idx[2] * P->ostr[2];
    P->out_l[oi] = l;
    P->out_c[0][oi] = cc[0];
    P->out_c[1][oi] = cc[1];
    P->out_c[2][oi] = cc[2];
}

/* A voxel iu of the span whose 2x2 bilinear fetch of l reaches outside the previous slice, with an
 * entry transmittance (vol.h vol_occluder.entry): l again, with the texels outside the slice
 * entry() at their world positions (on the previous slice's plane) instead of the padding's 1,
 * as lv_fetch_l_entry does for the per-tap path; tau is lv_span1's, the lerps the span's (so with
 * entry() = 1 the bits are the span's). */
static void lv_span_l_entry(const lv_pass *P, const vol_i_lv_span *S, int iu)
{
    const ptrdiff_t W = S->stride;
    const float *s0 = S->prev_sigma + (ptrdiff_t)(S->jv + S->bv) * W + S->bu + iu, *s1 = s0 + W;
    const float sigma = S->sigma[iu];
    const float sa = s0[0] + (s0[1] - s0[0]) * S->fu, sb = s1[0] + (s1[1] - s1[0]) * S->fu;
    const float sigma_p = sa + (sb - sa) * S->fv;
    const double arg = -0.5 * ((double)sigma + (double)sigma_p) * S->ds;
    const float tau = arg == 0.0 ? 1.0f : (float)exp(arg);
    float t[4];
    for (int q = 0; q < 4; q++) {
        const int ti = iu + S->bu + (q & 1), tj = S->jv + S->bv + (q >> 1);
        if (ti >= 0 && tj >= 0 && ti < P->nu && tj < P->nv) {
            t[q] = S->prev_l[(ptrdiff_t)tj * W + ti];
        } else {
            double x[3];
            x[P->a] = P->org[P->a] + (double)P->kprev * P->sp[P->a];
            x[P->u] = P->org[P->u] + (double)ti * P->sp[P->u];
            x[P->v] = P->org[P->v] + (double)tj * P->sp[P->v];
            const float e = P->entry(P->entry_user, x);
            t[q] = e >= 0.0f ? (e <= 1.0f ? e : 1.0f) : (e < 0.0f ? 0.0f : 1.0f);
        }
    }
    const float la = t[0] + (t[1] - t[0]) * S->fu, lb = t[2] + (t[3] - t[2]) * S->fu;
    const float l = tau * (la + (lb - la) * S->fv);
    S->cur_l[iu] = l;
    S->out_l[(ptrdiff_t)iu * S->out_stride] = l;
}

/* One row (v) of the current slice: classify the row, then the kernel path's span [iu_lo, iu_hi)
 * (the voxels whose 2x2 and kW x kH kernels lie inside the previous slice and its LV_PAD border
 * texels) by the row kernel (vol_light_internal.h, scalar or AVX2: the same bits), the rest voxel
 * by voxel. */
static void lv_row(const lv_pass *P, int jv, float *scr)
{
    const int a = P->a, u = P->u, v = P->v, nu = P->nu;
    const vol_grid *g = P->g;
    float *s = scr, *sig = scr + P->nu_pad, *ctf[3] = {sig + P->nu_pad, sig + 2 * P->nu_pad, sig + 3 * P->nu_pad};
    const float *rs = s; /* the row's values */
    if (P->scale == 1) {
        /* The light volume's voxels are the data's: the exact voxel values. */
        const size_t dstr[3] = {1, (size_t)g->nx, (size_t)g->nx * (size_t)g->ny};
        const float *d = g->data + (size_t)P->k * dstr[a] + (size_t)jv * dstr[v];
        const size_t su = dstr[u];
        if (su == 1) {
            rs = d; /* the data's row itself (x fastest): classified in place, no copy */
            if (jv + 2 < P->nv) /* two rows ahead: the data comes from memory */
                for (int iu = 0; iu < nu; iu += 16)
                    __builtin_prefetch(d + 2 * dstr[v] + iu, 0, 0);
        } else
            for (int iu = 0; iu < nu; iu++)
                s[iu] = d[(size_t)iu * su];
    } else {
        /* The data trilinearly at the light-volume voxel's centre. */
        for (int iu = 0; iu < nu; iu++) {
            int idx[3];
            idx[a] = P->k;
            idx[u] = iu;
            idx[v] = jv;
            double x[3];
            for (int c = 0; c < 3; c++)
                x[c] = P->org[c] + idx[c] * P->sp[c];
            s[iu] = vol_grid_sample(g, (x[0] - g->origin[0]) / g->spacing[0], (x[1] - g->origin[1]) / g->spacing[1],
                                    (x[2] - g->origin[2]) / g->spacing[2]);
        }
    }
#if defined(VOL_I_LV_HAVE_AVX512)
    if (P->avx512)
        vol_i_lv_classify_avx512(&P->T, rs, nu, sig, ctf[0], ctf[1], ctf[2]);
    else
#endif
#if defined(OBS_HAVE_AVX2)
    if (P->avx2)
        vol_i_lv_classify_avx2(&P->T, rs, nu, sig, ctf[0], ctf[1], ctf[2]);
    else
#endif
        vol_i_lv_classify_scalar(&P->T, rs, nu, sig, ctf[0], ctf[1], ctf[2]);
    if (P->occ_sigma) { /* the meshes' extra extinction (vol.h vol_occluder), both paths alike */
        const size_t os[3] = {1, (size_t)P->n[0], (size_t)P->n[0] * (size_t)P->n[1]};
        const float *o = P->occ_sigma + (size_t)P->k * os[a] + (size_t)jv * os[v];
        for (int iu = 0; iu < nu; iu++)
            if (o[(size_t)iu * os[u]] != 0.0f)
                sig[iu] += o[(size_t)iu * os[u]];
    }

    /* The span: the voxels whose 2x2 and kW x kH kernels lie inside the previous slice's buffer,
     * the slice and its LV_PAD texels of border values around it (lv_propagate). The slice's edge
     * voxels read the border from the padding, as the per-tap path does (lv_fetch): the same
     * sums as the per-tap path, in the kernel's order (docs/volume/light.md, step 8; before, the
     * edge voxels took the per-tap path). */
    int iu_lo = 0, iu_hi = 0;
    if (P->mode == LV_MODE_PROPAGATE && P->kern && jv + P->kJ0 >= -LV_PAD && jv + P->kJ0 + P->kH <= P->nv + LV_PAD &&
        jv + P->bv >= -LV_PAD && jv + P->bv + 1 < P->nv + LV_PAD) {
        /* iu + kI0 >= -LV_PAD, iu + kI0 + kW <= nu + LV_PAD, iu + bu >= -LV_PAD, iu + bu + 1 < nu + LV_PAD */
        iu_lo = -LV_PAD - P->kI0 > -LV_PAD - P->bu ? -LV_PAD - P->kI0 : -LV_PAD - P->bu;
        iu_lo = iu_lo > 0 ? iu_lo : 0;
        iu_hi = nu + LV_PAD - P->kI0 - P->kW + 1 < nu + LV_PAD - P->bu - 1 ? nu + LV_PAD - P->kI0 - P->kW + 1
                                                                          : nu + LV_PAD - P->bu - 1;
        /* and 0 <= iu < nu: a kernel wholly to one side of p (a small cone, |p - x| > 1 texel in
         * the second face's pass, or a slice narrower than the offset) moves a bound past nu */
        iu_lo = iu_lo < nu ? iu_lo : nu;
        iu_hi = iu_hi < nu ? iu_hi : nu;
        if (iu_hi < iu_lo)
            iu_hi = iu_lo;
    }
    for (int iu = 0; iu < iu_lo; iu++) {
        const float c3[3] = {ctf[0][iu], ctf[1][iu], ctf[2][iu]};
        lv_voxel(P, iu, jv, sig[iu], c3);
    }
    if (iu_hi > iu_lo) {
        const size_t *stride = P->ostr;
        vol_i_lv_span S;
        S.prev_l = P->prev[LV_L];
        S.prev_sigma = P->prev[LV_SIGMA];
        for (int c = 0; c < 3; c++) {
            S.prev_c[c] = P->prev[LV_C0 + c];
            S.ctf[c] = ctf[c];
            S.cur_c[c] = P->cur[LV_C0 + c] + (ptrdiff_t)jv * P->W;
            S.out_c[c] = P->out_c[c] + (size_t)P->k * stride[a] + (size_t)jv * stride[v];
        }
        S.stride = P->W, S.jv = jv;
        S.bu = P->bu, S.bv = P->bv, S.kI0 = P->kI0, S.kJ0 = P->kJ0, S.kW = P->kW, S.kH = P->kH;
        S.fu = P->fu, S.fv = P->fv, S.Ksum = P->Ksum;
        S.K = P->K;
        S.ds = P->sp[a] / fabs(P->D[a]); /* the kernel path's ds (directional: cos_g = |D_a|) */
        S.sigma = sig;
        S.cur_l = P->cur[LV_L] + (ptrdiff_t)jv * P->W;
        S.cur_sigma = P->cur[LV_SIGMA] + (ptrdiff_t)jv * P->W;
        S.out_l = P->out_l + (size_t)P->k * stride[a] + (size_t)jv * stride[v];
        S.out_stride = (ptrdiff_t)stride[u];
#if defined(VOL_I_LV_HAVE_AVX512)
        if (P->avx512)
            vol_i_lv_span_avx512(&S, iu_lo, iu_hi);
        else
#endif
#if defined(OBS_HAVE_AVX2)
        if (P->avx2)
            vol_i_lv_span_avx2(&S, iu_lo, iu_hi);
        else
#endif
            vol_i_lv_span_scalar(&S, iu_lo, iu_hi);
        if (P->entry) /* texels outside the slice are the light entering there, not l = 1 */
            for (int iu = iu_lo; iu < iu_hi; iu++)
                if (iu + P->bu < 0 || iu + P->bu + 1 >= nu || jv + P->bv < 0 || jv + P->bv + 1 >= P->nv)
                    lv_span_l_entry(P, &S, iu);
    }
    for (int iu = iu_hi > iu_lo ? iu_hi : iu_lo; iu < nu; iu++) {
        const float c3[3] = {ctf[0][iu], ctf[1][iu], ctf[2][iu]};
        lv_voxel(P, iu, jv, sig[iu], c3);
    }
}

/* A band of rows_per_task rows of the current slice (thread's own scratch rows). */
static void lv_band_task(void *user, int64_t task, int thread)
{
    const lv_pass *P = (const lv_pass *)user;
    int j0 = (int)task * P->rows_per_task, j1 = j0 + P->rows_per_task;
    if (j1 > P->nv)
        j1 = P->nv;
    float *scr = P->scratch + (size_t)thread * 5 * P->nu_pad;
    for (int jv = j0; jv < j1; jv++)
        lv_row(P, jv, scr);
}

/* A chain of slices k0, k0 + dir, ... (count of them), the first in mode `first`, the others
 * propagated from the one before, as ONE pool job: item t is band t % bands of slice t / bands
 * (lv_band_task), and waits until the bands b - reach .. b + reach of the slice before are done
 * (done[], one flag per slice and band; reach = bands, every band, for a point light, whose
 * fetches are not bounded per pass; lv_band_reach). The pool hands items out in increasing order,
 * so an item's dependencies were all handed out before it to threads that are running them: no
 * deadlock for any thread count, and no wake-up of the pool per slice. Slice i reads buffer i & 1
 * and writes buffer (i + 1) & 1, which holds slice i - 2: band b of slice i overwrites only rows
 * that the bands of slice i - 1 within `reach` read, and it waits for those. Which thread computes
 * a voxel, and when, never changes it. */
typedef struct lv_chain {
    const lv_pass *P;
    float *(*slices)[LV_CH];
    int k0, dir, count, bands, reach;
    lv_mode first;
    atomic_int *done;
} lv_chain;

static void lv_chain_task(void *user, int64_t task, int thread)
{
    const lv_chain *C = (const lv_chain *)user;
    const int i = (int)(task / C->bands), b = (int)(task % C->bands);
    if (i > 0) {
        const int b0 = b - C->reach > 0 ? b - C->reach : 0;
        const int b1 = b + C->reach < C->bands - 1 ? b + C->reach : C->bands - 1;
        const atomic_int *d = C->done + (size_t)(i - 1) * (size_t)C->bands;
        int spins = 0;
        for (int q = b0; q <= b1; q++)
            while (!atomic_load_explicit(&d[q], memory_order_acquire))
                if (++spins > 64) {
                    sched_yield();
                    spins = 0;
                }
    }
    lv_pass L = *C->P;
    L.k = C->k0 + C->dir * i;
    L.kprev = L.k - C->dir; /* the slice prev holds (lv_fetch_l_entry's texel positions) */
    L.mode = i == 0 ? C->first : LV_MODE_PROPAGATE;
    for (int c = 0; c < LV_CH; c++) {
        L.prev[c] = C->slices[i & 1][c];
        L.cur[c] = C->slices[(i + 1) & 1][c];
    }
    lv_band_task(&L, b, thread);
    atomic_store_explicit(&C->done[(size_t)i * (size_t)C->bands + (size_t)b], 1, memory_order_release);
}

/* The bands of the previous slice a band depends on, either side (lv_chain): a directional
 * light's fetches (the 2x2 bilinear of l and sigma_t, the kernel, the per-tap cone) read rows
 * within |ds D_v / sp_v| + max |rv cv[m]| + 1 of the voxel's row (lv_taps_init); a point light's
 * are not bounded per pass, so it waits for every band. */
static int lv_band_reach(const lv_pass *P, int bands)
{
    if (!P->taps_dir)
        return bands;
    double rows = fabs(P->t_ov);
    double m = 0.0;
    for (int q = 0; q < P->st_count[P->t_R]; q++)
        m = fabs(P->t_dv[q]) > m ? fabs(P->t_dv[q]) : m;
    rows += m + 2.0; /* the bilinear's second row, and a margin for rounding */
    if (!(rows < (double)P->nv))
        return bands;
    const int reach = ((int)ceil(rows) + P->rows_per_task - 1) / P->rows_per_task;
    return reach < bands ? reach : bands;
}

static void lv_run_chain(obs_pool *pool, const lv_pass *P, int k0, int dir, int count, lv_mode first,
                         float *slices[2][LV_CH], atomic_int *done)
{
    if (count <= 0)
        return;
    lv_chain C;
    C.P = P;
    C.slices = slices;
    C.k0 = k0, C.dir = dir, C.count = count, C.first = first;
    C.bands = (P->nv + P->rows_per_task - 1) / P->rows_per_task;
    C.reach = lv_band_reach(P, C.bands);
    C.done = done;
    for (size_t i = 0; i < (size_t)count * (size_t)C.bands; i++)
        atomic_init(&done[i], 0);
    obs_pool_run(pool, (int64_t)count * C.bands, lv_chain_task, &C);
}

/* Set up the kernel path for a directional light along axis a (P->kern = 0 otherwise, or when
 * the environment's OBS_LV_PER_TAP=1 asks for the per-tap reference). The kernel gathers, per integer texel offset, the
 * bilinear weights of the centre tap (weight 1) and of every ring tap (weight w_m) at the pass's
 * constant offsets; Ksum is the sum of its entries in the order the voxel loop uses them, so a
 * constant slice gives exactly that constant. Agreement with the per-tap path:
 * volume_light_kernel_path_matches_per_tap_path. Returns 0 when out of memory. */
#define LV_KERNEL_MAX 64 /* texels per side of the gathered kernel; wider footprints use the per-tap path */
static int lv_kernel_init(lv_pass *P)
{
    free(P->K);
    P->K = NULL;
    P->kern = 0;
    const char *env = getenv("OBS_LV_PER_TAP");
    if (P->point || (env && strcmp(env, "1") == 0))
        return 1;
    const int a = P->a, u = P->u, v = P->v;
    double cos_g = fabs(P->D[a]);
    if (cos_g < 1e-12)
        return 1;
    double ds = P->sp[a] / cos_g;
    double ou = -ds * P->D[u] / P->sp[u], ov = -ds * P->D[v] / P->sp[v]; /* p - x in voxels */
    double r = ds * P->tan_theta, ru = r / P->sp[u], rv = r / P->sp[v];
    double rmax = ru > rv ? ru : rv;
    int R = (int)ceil(rmax - 1e-9);
    R = R < 1 ? 1 : (R > VOL_LV_MAX_RINGS ? VOL_LV_MAX_RINGS : R);
    const int cnt = P->st_count[R];
    /* The taps' offsets: the centre, then the rings. */
    int lo_u = 1 << 30, hi_u = -(1 << 30), lo_v = 1 << 30, hi_v = -(1 << 30);
    for (int m = -1; m < cnt; m++) {
        double qu = ou + (m < 0 ? 0.0 : ru * P->st_cu[R][m]), qv = ov + (m < 0 ? 0.0 : rv * P->st_cv[R][m]);
        int iu0 = (int)floor(qu), iv0 = (int)floor(qv);
        lo_u = iu0 < lo_u ? iu0 : lo_u;
        hi_u = iu0 + 1 > hi_u ? iu0 + 1 : hi_u;
        lo_v = iv0 < lo_v ? iv0 : lo_v;
        hi_v = iv0 + 1 > hi_v ? iv0 + 1 : hi_v;
    }
    P->kI0 = lo_u, P->kJ0 = lo_v, P->kW = hi_u - lo_u + 1, P->kH = hi_v - lo_v + 1;
    if (P->kW < 2 || P->kH < 2 || P->kW > LV_KERNEL_MAX || P->kH > LV_KERNEL_MAX)
        return 1; /* a footprint wider than the kernel limit: the per-tap path */
    P->K = (float *)calloc((size_t)P->kW * (size_t)P->kH, sizeof(float));
    if (!P->K)
        return 0;
    for (int m = -1; m < cnt; m++) {
        double qu = ou + (m < 0 ? 0.0 : ru * P->st_cu[R][m]), qv = ov + (m < 0 ? 0.0 : rv * P->st_cv[R][m]);
        double fu = floor(qu), fv = floor(qv);
        float tu = (float)(qu - fu), tv = (float)(qv - fv), w = m < 0 ? 1.0f : P->st_w[R][m];
        int i = (int)fu - lo_u, j = (int)fv - lo_v;
        P->K[j * P->kW + i] += w * (1.0f - tu) * (1.0f - tv);
        P->K[j * P->kW + i + 1] += w * tu * (1.0f - tv);
        P->K[(j + 1) * P->kW + i] += w * (1.0f - tu) * tv;
        P->K[(j + 1) * P->kW + i + 1] += w * tu * tv;
    }
    float ks = 0.0f;
    for (int k = 0; k < P->kW * P->kH; k++)
        ks += P->K[k];
    P->Ksum = ks;
    double fbu = floor(ou), fbv = floor(ov);
    P->bu = (int)fbu, P->bv = (int)fbv;
    P->fu = (float)(ou - fbu), P->fv = (float)(ov - fbv);
    P->kern = 1;
    return 1;
}

/* The per-tap path's constants for a directional light along axis a (lv_pass taps_dir): the
 * expressions lv_voxel's per-tap branch evaluates per voxel, in the same form, evaluated once per
 * pass. Point lights (D per voxel) and a light parallel to the slices (cos_g < 1e-12: lv_voxel's
 * face branch) keep the per-voxel form. */
static void lv_taps_init(lv_pass *P)
{
    P->taps_dir = 0;
    const int a = P->a, u = P->u, v = P->v;
    const double cos_g = fabs(P->D[a]);
    if (P->point || cos_g < 1e-12)
        return;
    const double ds = P->sp[a] / cos_g;
    P->t_ds = ds;
    P->t_ou = ds * P->D[u] / P->sp[u];
    P->t_ov = ds * P->D[v] / P->sp[v];
    double r = ds * P->tan_theta, ru = r / P->sp[u], rv = r / P->sp[v];
    double rmax = ru > rv ? ru : rv;
    int R = (int)ceil(rmax - 1e-9);
    if (R < 1)
        R = 1;
    if (R > VOL_LV_MAX_RINGS)
        R = VOL_LV_MAX_RINGS;
    P->t_R = R;
    for (int m = 0; m < P->st_count[R]; m++) {
        P->t_du[m] = ru * P->st_cu[R][m];
        P->t_dv[m] = rv * P->st_cv[R][m];
    }
    P->taps_dir = 1;
}

/* First touch of a fresh output block by every thread of the pool, 2 MiB a task (one byte
 * written per 4 KiB page; every value is written again by the propagation). Touched during the
 * propagation instead, each huge page (obs_aligned_alloc advises them) holds 8 slices of a
 * channel at 256^2, so both threads fault on the same page and one waits while the kernel
 * zeroes it (about 34 ms of system time per 256^3 build on this machine): here the zeroing is
 * shared between the threads. Nothing with one thread. */
#define LV_TOUCH_CHUNK ((size_t)2 << 20)
typedef struct lv_touch {
    unsigned char *p;
    size_t bytes;
} lv_touch;

static void lv_touch_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const lv_touch *T = (const lv_touch *)user;
    const size_t b0 = (size_t)task * LV_TOUCH_CHUNK;
    const size_t b1 = b0 + LV_TOUCH_CHUNK < T->bytes ? b0 + LV_TOUCH_CHUNK : T->bytes;
    for (size_t q = b0; q < b1; q += 4096)
        ((volatile unsigned char *)T->p)[q] = 0;
}

static void lv_first_touch(obs_pool *pool, void *p, size_t bytes)
{
    if (!p || obs_pool_threads(pool) < 2)
        return;
    lv_touch T = {(unsigned char *)p, bytes};
    obs_pool_run(pool, (int64_t)((bytes + LV_TOUCH_CHUNK - 1) / LV_TOUCH_CHUNK), lv_touch_task, &T);
}

/* ---- The rebuild's workspace (vol.h vol_lv_workspace) ------------------------------------------ */

/* One kept block: obs_aligned_alloc'd, `bytes` long (0: none). */
typedef struct lv_block {
    void *p;
    size_t bytes;
} lv_block;

struct vol_lv_workspace {
    lv_block stage; /* a pass along x's staged output (lv_propagate): 4 channels */
    lv_block tmp;   /* the second face's propagation (blend): 4 channels */
    lv_block buf;   /* the two slice buffers of lv_propagate */
};

vol_lv_workspace *vol_lv_workspace_create(void)
{
    return (vol_lv_workspace *)calloc(1, sizeof(vol_lv_workspace));
}

void vol_lv_workspace_free(vol_lv_workspace *ws)
{
    if (!ws)
        return;
    obs_aligned_free(ws->stage.p);
    obs_aligned_free(ws->tmp.p);
    obs_aligned_free(ws->buf.p);
    free(ws);
}

/* A block of `bytes` bytes: without a workspace (b NULL) a fresh one (the caller frees it), first
 * touched by the pool when `touch`; with one, b's block when it has that size up to twice it (kept
 * from a previous build: its pages are already there, nothing to touch), else b's block replaced by a fresh
 * one (b keeps it; the caller does not free it). Every value is written before it is read, so the
 * old contents never matter. */
static void *lv_block_take(obs_pool *pool, lv_block *b, size_t bytes, int touch)
{
    if (b && b->p && b->bytes >= bytes && b->bytes / 2 <= bytes) /* not over twice what is needed */
        return b->p;
    if (b) {
        obs_aligned_free(b->p);
        b->p = NULL;
        b->bytes = 0;
    }
    void *p = obs_aligned_alloc(bytes);
    if (p && touch)
        lv_first_touch(pool, p, bytes);
    if (b && p) {
        b->p = p;
        b->bytes = bytes;
    }
    return p;
}

/* Give back a block lv_block_take returned: freed unless the workspace keeps it. */
static void lv_block_give(lv_block *b, void *p)
{
    if (!b)
        obs_aligned_free(p);
}

/* The staged output of a pass along x (lv_propagate) into the x-fastest output: task z moves the
 * plane z, in tiles of 16 x values (16 rows of the stage read, 16 consecutive floats written). */
typedef struct lv_unstage {
    const float *stage;
    float *out[4];
    int nx, ny, nz;
    size_t voxels;
} lv_unstage;

static void lv_unstage_task(void *user, int64_t task, int thread)
{
    (void)thread;
    const lv_unstage *U = (const lv_unstage *)user;
    const int z = (int)task, nx = U->nx, ny = U->ny;
    const size_t sx = (size_t)U->ny * (size_t)U->nz; /* stage elements per x */
    for (int c = 0; c < 4; c++) {
        const float *st = U->stage + (size_t)c * U->voxels + (size_t)z * (size_t)ny;
        float *o = U->out[c] + (size_t)z * (size_t)ny * (size_t)nx;
        for (int x0 = 0; x0 < nx; x0 += 16) {
            const int x1 = x0 + 16 < nx ? x0 + 16 : nx;
            for (int y = 0; y < ny; y++)
                for (int x = x0; x < x1; x++)
                    o[(size_t)y * nx + x] = st[(size_t)x * sx + y];
        }
    }
}

/* Propagate along axis a (light entering from the low side when lowside, else the high side, for a
 * light outside the slab range; both ways from the light's plane for a light inside it). */
static obs_status lv_propagate(obs_context *ctx, obs_pool *pool, lv_pass *P, int a, int lowside, float *out_l,
                               float *out_c[3])
{
    P->a = a;
    P->u = a == 0 ? 1 : 0;
    P->v = a == 2 ? 1 : 2;
    P->nu = P->n[P->u];
    P->nv = P->n[P->v];
    P->out_l = out_l;
    for (int c = 0; c < 3; c++)
        P->out_c[c] = out_c[c];
    P->ostr[0] = 1, P->ostr[1] = (size_t)P->n[0], P->ostr[2] = (size_t)P->n[0] * (size_t)P->n[1];
    /* A pass along x would write every voxel of a slice to its own cache line (the output is x
     * fastest): stage it slice-major (x slowest, then z, then y: the slices' own order) and
     * transpose it into out_* at the end (lv_unstage_task). The values are the same. */
    const size_t voxels = (size_t)P->n[0] * (size_t)P->n[1] * (size_t)P->n[2];
    lv_block *ws_stage = P->ws ? &P->ws->stage : NULL, *ws_buf = P->ws ? &P->ws->buf : NULL;
    float *stage = NULL;
    if (a == 0 && P->stage_ok)
        stage = (float *)lv_block_take(pool, ws_stage, voxels * 4 * sizeof(float), 1);
    if (stage) {
        P->out_l = stage;
        for (int c = 0; c < 3; c++)
            P->out_c[c] = stage + (size_t)(c + 1) * voxels;
        P->ostr[0] = (size_t)P->n[1] * (size_t)P->n[2], P->ostr[1] = 1, P->ostr[2] = (size_t)P->n[1];
    }
    /* Two slice buffers of each channel, with LV_PAD texels of the channel's border value (l, c: 1;
     * sigma_t: 0) around the slice that no voxel overwrites (lv_fetch). */
    P->W = P->nu + 2 * LV_PAD;
    size_t plane = (size_t)P->W * (size_t)(P->nv + 2 * LV_PAD);
    float *buf = (float *)lv_block_take(pool, ws_buf, plane * 2 * LV_CH * sizeof(float), 0);
    if (!buf) {
        lv_block_give(ws_stage, stage);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory for the slice buffers");
    }
    float *slices[2][LV_CH];
    for (int s = 0; s < 2; s++)
        for (int c = 0; c < LV_CH; c++) {
            float *b = buf + (size_t)(s * LV_CH + c) * plane, fill = c == LV_SIGMA ? 0.0f : 1.0f;
            for (size_t q = 0; q < plane; q++)
                b[q] = fill;
            slices[s][c] = b + (size_t)LV_PAD * (size_t)P->W + LV_PAD;
        }
    lv_taps_init(P);
    if (!lv_kernel_init(P)) {
        lv_block_give(ws_stage, stage);
        lv_block_give(ws_buf, buf);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory for the cone kernel");
    }
    /* Per thread: one row's values, sigma_t and c_TF (lv_row). Tasks are bands of rows, about four
     * per thread and slice (which rows a task holds never changes a voxel's value). */
    const int threads = obs_pool_threads(pool);
    P->nu_pad = ((size_t)P->nu + 15) & ~(size_t)7;
    P->scratch = (float *)obs_aligned_alloc((size_t)threads * 5 * P->nu_pad * sizeof(float));
    {
        int tasks = 4 * threads < P->nv ? 4 * threads : P->nv;
        P->rows_per_task = (P->nv + tasks - 1) / tasks;
    }
    const size_t bands = (size_t)((P->nv + P->rows_per_task - 1) / P->rows_per_task);
    atomic_int *done = (atomic_int *)malloc((size_t)P->n[a] * bands * sizeof(atomic_int)); /* lv_run_chain */
    if (!P->scratch || !done) {
        obs_aligned_free(P->scratch);
        P->scratch = NULL;
        free(done);
        lv_block_give(ws_buf, buf);
        lv_block_give(ws_stage, stage);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory for the row buffers");
    }
    const int na = P->n[a];

    /* The light's plane in light-volume slice units (point lights only). */
    double kL = 0.0;
    int inside = 0;
    if (P->point) {
        kL = (P->P[a] - P->org[a]) / P->sp[a];
        inside = kL >= -0.5 && kL <= (double)na - 0.5;
    }
    if (!inside) {
        int low = P->point ? (kL < -0.5) : lowside;
        if (low) {
            lv_run_chain(pool, P, 0, 1, na, LV_MODE_FACE, slices, done);
        } else {
            lv_run_chain(pool, P, na - 1, -1, na, LV_MODE_FACE, slices, done);
        }
    } else {
        /* A light inside the slab range ([Ropinski10] via the seed thesis, "PROPAGACION DE LA LUZ":
         * light can propagate both ways from x_l; the thesis projects x_l onto F0 instead). We seed
         * the two slices next to the light's plane by marching straight to the light, then
         * propagate outward: upward from the upper seed, downward from the lower one. */
        int kup = (int)ceil(kL);
        int kdn = kup - 1;
        if (kup < na) {
            lv_run_chain(pool, P, kup, 1, na - kup, LV_MODE_SEED, slices, done);
        }
        if (kdn >= 0) {
            lv_run_chain(pool, P, kdn, -1, kdn + 1, LV_MODE_SEED, slices, done);
        }
    }
    lv_block_give(ws_buf, buf);
    free(done);
    obs_aligned_free(P->scratch);
    P->scratch = NULL;
    if (stage) {
        lv_unstage U;
        U.stage = stage;
        U.out[0] = out_l;
        for (int c = 0; c < 3; c++)
            U.out[c + 1] = out_c[c];
        U.nx = P->n[0], U.ny = P->n[1], U.nz = P->n[2];
        U.voxels = voxels;
        obs_pool_run(pool, P->n[2], lv_unstage_task, &U);
        lv_block_give(ws_stage, stage);
        P->out_l = out_l;
        for (int c = 0; c < 3; c++)
            P->out_c[c] = out_c[c];
    }
    return OBS_STATUS_OK;
}

/* ---- Cone stencils ------------------------------------------------------------------------------ */

#define LV_STENCIL_TAPS (8 * (VOL_LV_MAX_RINGS * (VOL_LV_MAX_RINGS + 1) / 2)) /* all rings of R = 4 */
typedef struct lv_stencils {
    double cu[VOL_LV_MAX_RINGS + 1][LV_STENCIL_TAPS], cv[VOL_LV_MAX_RINGS + 1][LV_STENCIL_TAPS];
    float w[VOL_LV_MAX_RINGS + 1][LV_STENCIL_TAPS];
} lv_stencils;

/* The Gaussian ring stencils (volume.md 1.6 [R]: "centre + a ring of 4-8, more as r grows",
 * w = exp(-|u|^2 / (2 (r/2)^2))), in units of the footprint radius r. */
static void lv_stencil_init(lv_pass *P, lv_stencils *S)
{
    for (int R = 1; R <= VOL_LV_MAX_RINGS; R++) {
        int k = 0;
        float wsum = 1.0f; /* the centre tap */
        for (int j = 1; j <= R; j++) {
            double f = (double)j / R;
            float w = (float)exp(-2.0 * f * f);
            int taps = 8 * j;
            for (int m = 0; m < taps; m++, k++) {
                double phi = 2.0 * OBS_PI * m / taps;
                S->cu[R][k] = f * cos(phi);
                S->cv[R][k] = f * sin(phi);
                S->w[R][k] = w;
                wsum += w;
            }
        }
        P->st_count[R] = k;
        P->st_cu[R] = S->cu[R];
        P->st_cv[R] = S->cv[R];
        P->st_w[R] = S->w[R];
        P->st_wsum[R] = wsum;
    }
}

/* ---- Face choice ------------------------------------------------------------------------------- */

/* c_k = n_k . l_hat for the six faces (0..5: -x, +x, -y, +y, -z, +z; n_k outward), l_hat the unit
 * direction towards the light. F0 = argmax c_k, F1 = argmax over the two other axes (volume.md 1.3:
 * Inviwo's updatePermuationMatrices; for a directional light the axis of the largest |component|).
 * Ties go to the lower face index. */
static void lv_choose_faces(const double lhat[3], int *f0, int *f1, double *c0)
{
    int best = 0;
    double bc = -2.0;
    for (int f = 0; f < 6; f++) {
        double c = (f & 1 ? 1.0 : -1.0) * lhat[f >> 1];
        if (c > bc)
            bc = c, best = f;
    }
    int second = -1;
    double sc = -2.0;
    for (int f = 0; f < 6; f++) {
        if ((f >> 1) == (best >> 1))
            continue;
        double c = (f & 1 ? 1.0 : -1.0) * lhat[f >> 1];
        if (c > sc)
            sc = c, second = f;
    }
    *f0 = best;
    *f1 = second;
    *c0 = bc;
}

/* ---- Build ------------------------------------------------------------------------------------- */

void vol_light_volume_free(vol_light_volume *lv)
{
    if (!lv)
        return;
    obs_aligned_free(lv->l);
    memset(lv, 0, sizeof *lv);
}

static void lv_blend_task(void *user, int64_t task, int thread)
{
    (void)thread;
    void **args = (void **)user;
    vol_light_volume *lv = (vol_light_volume *)args[0];
    const float *tmp = (const float *)args[1];
    size_t voxels = *(const size_t *)args[2];
    size_t chunk = 1 << 16, b = (size_t)task * chunk, e = b + chunk < voxels ? b + chunk : voxels;
    float w = lv->blend_weight;
    float *ch[4] = {lv->l, lv->c[0], lv->c[1], lv->c[2]};
    for (int c = 0; c < 4; c++) {
        const float *t = tmp + (size_t)c * voxels;
        /* Merge pass (Inviwo lightvolumeblend.frag, volume.md 1.7): w LV_F0 + (1 - w) LV_F1. */
        for (size_t i = b; i < e; i++)
            ch[c][i] = t[i] + w * (ch[c][i] - t[i]); /* = w LV_F0 + (1 - w) LV_F1, exact when equal */
    }
}

obs_status vol_light_volume_build(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                  const vol_light *light, const vol_lv_params *p, vol_light_volume *out)
{
    return vol_light_volume_build_ex(ctx, pool, g, tf, light, p, NULL, out);
}

/* old: NULL (a fresh build), or the light volume a rebuild may write into (vol_light_volume_rebuild):
 * its block is adopted by out when the layout matches (old->l then NULL), else left to the caller. */
static obs_status lv_build(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                           const vol_light *light, const vol_lv_params *p, const vol_occluder *occ,
                           vol_lv_workspace *ws, vol_light_volume *old, vol_light_volume *out)
{
    memset(out, 0, sizeof *out);
    if (!g || !tf || !light)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_light_volume_build: grid, tf or light is NULL");
    obs_status st = vol_lv_params_validate(ctx, p);
    if (st != OBS_STATUS_OK)
        return st;
    if (!g->data || g->nx < 1 || g->ny < 1 || g->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: the grid is empty");
    for (int c = 0; c < 3; c++)
        if (!isfinite(g->spacing[c]) || !(g->spacing[c] > 0.0) || !isfinite(g->origin[c]))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: grid spacing/origin must be finite, > 0");
    if (tf->count < 1 || !tf->points)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: the transfer function has no points");

    lv_pass P;
    memset(&P, 0, sizeof P);
    P.g = g;
    P.tf = tf;
    P.scale = p->scale;
    /* ref_step 0 = one voxel of the grid's smallest spacing (vol.h, vol_tf). */
    double ref_step = tf->ref_step;
    if (!(ref_step > 0.0))
        ref_step = fmin(g->spacing[0], fmin(g->spacing[1], g->spacing[2]));
    P.sigma_scale = p->kappa;
    P.ref_step = ref_step;
    P.tan_theta = tan(p->cone_angle_deg * OBS_PI / 180.0);
    vol_grid_bounds(g, P.lo, P.hi);

    /* The light, and l_hat (towards the light) for the face choice. */
    double lhat[3];
    if (light->type == OBS_LIGHT_SPOT)
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "light volume: spot lights are not supported (directional, point)");
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        double len = sqrt(light->direction[0] * light->direction[0] + light->direction[1] * light->direction[1] +
                          light->direction[2] * light->direction[2]);
        if (!isfinite(len) || !(len > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "light volume: the directional light's direction must be finite and non-zero");
        for (int c = 0; c < 3; c++) {
            P.D[c] = light->direction[c] / len;
            lhat[c] = -P.D[c];
        }
    } else if (light->type == OBS_LIGHT_POINT) {
        for (int c = 0; c < 3; c++)
            if (!isfinite(light->position[c]))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: the point light's position must be finite");
        P.point = 1;
        /* Inviwo: from the volume's centre (0.5, 0.5, 0.5) to the light, in texture space. */
        double len = 0.0;
        for (int c = 0; c < 3; c++) {
            P.P[c] = light->position[c];
            lhat[c] = (light->position[c] - P.lo[c]) / (P.hi[c] - P.lo[c]) - 0.5;
            len += lhat[c] * lhat[c];
        }
        len = sqrt(len);
        for (int c = 0; c < 3; c++)
            lhat[c] = len > 0.0 ? lhat[c] / len : (c == 2 ? 1.0 : 0.0);
    } else {
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "light volume: unknown light type %d", (int)light->type);
    }

    /* The light volume's own grid: ceil(n / scale) voxels covering the data's bounds exactly. */
    const int nd[3] = {g->nx, g->ny, g->nz};
    for (int c = 0; c < 3; c++) {
        P.n[c] = (nd[c] + p->scale - 1) / p->scale;
        P.sp[c] = (P.hi[c] - P.lo[c]) / P.n[c];
        P.org[c] = P.lo[c] + 0.5 * P.sp[c];
        if (p->scale == 1) { /* the data's own centres, bit for bit */
            P.sp[c] = g->spacing[c];
            P.org[c] = g->origin[c];
        }
    }
    int f0, f1;
    double c0;
    lv_choose_faces(lhat, &f0, &f1, &c0);
    /* Inviwo's continuous weight (volume.md 1.7): w = 1 - 2 acos(c_max) / pi. */
    if (c0 > 1.0)
        c0 = 1.0;
    float w = p->blend_second ? (float)(1.0 - 2.0 * acos(c0) / OBS_PI) : 1.0f;
    int need_second = p->blend_second && w < 1.0f;

    float *occ_sigma = NULL; /* the meshes' extra extinction: checked against the layout above */
    st = vol_i_occ_sigma(ctx, occ, P.n, P.sp, P.org, &occ_sigma);
    if (st != OBS_STATUS_OK)
        return st;
    P.occ_sigma = occ_sigma;
    P.entry = occ ? occ->entry : NULL;
    P.entry_user = occ ? occ->entry_user : NULL;
    size_t voxels = (size_t)P.n[0] * (size_t)P.n[1] * (size_t)P.n[2];
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    size_t bytes = voxels * 4 * sizeof(float) * (need_second ? 2 : 1);
    if ((int64_t)voxels > lim->max_voxels || (int64_t)bytes > lim->max_memory_bytes) {
        obs_aligned_free(occ_sigma);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "light volume %dx%dx%d needs %.3g bytes, over the limits (raise --max-voxels/--max-memory)",
                         P.n[0], P.n[1], P.n[2], (double)bytes);
    }
    /* A rebuild writes into old's block when it is one block of exactly these 4 channels (as below:
     * l, then c[0..2]); every voxel is written again by the propagation (and the blend), so the
     * old values never reach the output. Otherwise old is freed first (the peak stays one volume). */
    float *mem = NULL;
    if (old && old->l && old->nx == P.n[0] && old->ny == P.n[1] && old->nz == P.n[2] &&
        old->c[0] == old->l + voxels && old->c[1] == old->l + 2 * voxels && old->c[2] == old->l + 3 * voxels) {
        mem = old->l;
        memset(old, 0, sizeof *old);
    } else {
        vol_light_volume_free(old);
        mem = (float *)obs_aligned_alloc(voxels * 4 * sizeof(float));
        if (!mem) {
            obs_aligned_free(occ_sigma);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory (%.3g bytes)", (double)bytes);
        }
        lv_first_touch(pool, mem, voxels * 4 * sizeof(float));
    }
    out->nx = P.n[0], out->ny = P.n[1], out->nz = P.n[2], out->scale = p->scale;
    for (int c = 0; c < 3; c++) {
        out->spacing[c] = P.sp[c];
        out->origin[c] = P.org[c];
        out->c[c] = mem + (size_t)(c + 1) * voxels;
    }
    out->l = mem;
    /* Staging a pass along x (lv_propagate) costs one more volume of 4 channels: only within the
     * limits. */
    P.stage_ok = (int64_t)(bytes + voxels * 4 * sizeof(float)) <= lim->max_memory_bytes;
    P.ws = ws;
    out->face0 = f0;
    out->face1 = p->blend_second ? f1 : -1;
    out->blend_weight = w;

    lv_stencils *stencils = (lv_stencils *)malloc(sizeof *stencils);
    /* The TF for the row classification (vol_light_internal.h): values and RGBA as doubles, the
     * last point repeated once. */
    const int ntf = tf->count;
    double *tft = (double *)malloc((size_t)5 * (size_t)(ntf + 1) * sizeof(double));
    if (!stencils || !tft) {
        free(stencils);
        free(tft);
        vol_light_volume_free(out);
        obs_aligned_free(occ_sigma);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory");
    }
    lv_stencil_init(&P, stencils);
    for (int i = 0; i <= ntf; i++) {
        const vol_tf_point *q = &tf->points[i < ntf ? i : ntf - 1];
        tft[i] = q->value;
        for (int c = 0; c < 4; c++)
            tft[(size_t)(c + 1) * (size_t)(ntf + 1) + (size_t)i] = (double)q->rgba[c];
    }
    P.T.n = ntf;
    P.T.value = tft;
    for (int c = 0; c < 4; c++)
        P.T.rgba[c] = tft + (size_t)(c + 1) * (size_t)(ntf + 1);
    P.T.tf = tf;
    /* The TF is +0 (every component's bits 0) from -inf up to point zq's value: there
     * vol_tf_eval returns +0 exactly (point 0's copy below it; 0 (1 - t) + 0 t = +0 with t in
     * [0, 1) between two such points), and vol_sigma_from_alpha(+0) = 0. */
    P.T.zero_upto = -HUGE_VAL;
    for (int i = 0; i < ntf; i++) {
        uint32_t bits = 0;
        for (int c = 0; c < 4; c++) {
            uint32_t b;
            memcpy(&b, &tf->points[i].rgba[c], sizeof b);
            bits |= b;
        }
        if (bits != 0)
            break;
        P.T.zero_upto = tf->points[i].value;
    }
    P.T.zero_upto_f = (float)P.T.zero_upto; /* rounded to nearest; one float down where that is above */
    if ((double)P.T.zero_upto_f > P.T.zero_upto)
        P.T.zero_upto_f = nextafterf(P.T.zero_upto_f, -HUGE_VALF);
    P.T.kappa = P.sigma_scale;
    P.T.ref_step = P.ref_step;
    P.avx2 = vol_i_lv_avx2_active();
    P.avx512 = vol_i_lv_isa() == 2;

    /* F0: light enters by face f0 (dir_max = -n_F0): from the low side when f0 is a minus face. */
    st = lv_propagate(ctx, pool, &P, f0 >> 1, (f0 & 1) == 0, out->l, out->c);
    if (st == OBS_STATUS_OK && need_second) {
        lv_block *ws_tmp = ws ? &ws->tmp : NULL;
        float *tmp = (float *)lv_block_take(pool, ws_tmp, voxels * 4 * sizeof(float), 1);
        if (!tmp) {
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "light volume: out of memory for the second face");
        } else {
            float *tc[3] = {tmp + voxels, tmp + 2 * voxels, tmp + 3 * voxels};
            st = lv_propagate(ctx, pool, &P, f1 >> 1, (f1 & 1) == 0, tmp, tc);
            if (st == OBS_STATUS_OK) {
                void *args[3] = {out, tmp, &voxels};
                obs_pool_run(pool, (int64_t)((voxels + (1 << 16) - 1) >> 16), lv_blend_task, args);
            }
            lv_block_give(ws_tmp, tmp);
        }
    }
    free(stencils);
    free(tft);
    free(P.K);
    obs_aligned_free(occ_sigma);
    if (st != OBS_STATUS_OK)
        vol_light_volume_free(out);
    return st;
}

obs_status vol_light_volume_build_ex(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                     const vol_light *light, const vol_lv_params *p, const vol_occluder *occ,
                                     vol_light_volume *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_light_volume_build: out is NULL");
    return lv_build(ctx, pool, g, tf, light, p, occ, NULL, NULL, out);
}

obs_status vol_light_volume_rebuild(obs_context *ctx, obs_pool *pool, const vol_grid *g, const vol_tf *tf,
                                    const vol_light *light, const vol_lv_params *p, const vol_occluder *occ,
                                    vol_lv_workspace *ws, vol_light_volume *lv)
{
    if (!lv)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "vol_light_volume_rebuild: lv is NULL");
    vol_light_volume old = *lv;
    obs_status st = lv_build(ctx, pool, g, tf, light, p, occ, ws, &old, lv);
    vol_light_volume_free(&old); /* NULL-safe: nothing when lv adopted its block */
    return st;
}

void vol_light_volume_sample(const vol_light_volume *lv, const double x[3], float *l, float c[3])
{
    /* Trilinear, clamped to the edge: the grid sampler over each channel. */
    vol_grid gg;
    memset(&gg, 0, sizeof gg);
    gg.nx = lv->nx, gg.ny = lv->ny, gg.nz = lv->nz;
    double i = (x[0] - lv->origin[0]) / lv->spacing[0];
    double j = (x[1] - lv->origin[1]) / lv->spacing[1];
    double k = (x[2] - lv->origin[2]) / lv->spacing[2];
    if (l) {
        gg.data = lv->l;
        *l = vol_grid_sample(&gg, i, j, k);
    }
    if (c) {
        for (int ch = 0; ch < 3; ch++) {
            gg.data = lv->c[ch];
            c[ch] = vol_grid_sample(&gg, i, j, k);
        }
    }
}
