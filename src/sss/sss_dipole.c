/* sss_dipole.c: the BSSRDF constants and the scalar double-precision references of the
 * directional dipole [Frisvad14] and the standard dipole [Jensen01] (corrected eq. 4).
 *
 * Facts and equation numbers: ../shared/reference/sss.md (cited as "sss.md N"); the page of this
 * module is docs/sss/model.md (guards, deviations, measured energy).
 * Conventions (sss.h): coefficients per scene unit after sss_constants_make; w_i points from x_i
 * towards the light; n_i, n_o are unit outward normals; eta = n_inside / n_outside. */
#include "sss_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ---- Model names --------------------------------------------------------------------------------- */

static const char *const sss_model_names[SSS_MODEL_COUNT] = {"directional", "standard"};

const char *sss_model_name(sss_model m)
{
    return (unsigned)m < SSS_MODEL_COUNT ? sss_model_names[m] : "unknown";
}

int sss_model_from_name(const char *name, sss_model *out)
{
    if (!name)
        return 0;
    for (int i = 0; i < SSS_MODEL_COUNT; i++)
        if (!strcmp(name, sss_model_names[i])) {
            if (out)
                *out = (sss_model)i;
            return 1;
        }
    return 0;
}

/* ---- Fresnel terms --------------------------------------------------------------------------------- */

/* [dEon11] polynomial fits of the first two Fresnel moments, giving 2C1 and 3C2 directly
 * (sss.md 1.1; pbrt's FresnelMoment1/2 are these divided by 2 and 3). Branch: eta < 1 low,
 * eta >= 1 high (ray_engine's and pbrt's convention, sss.md 1.1). eta == 1 exactly is NOT
 * special-cased here (the pure fit); sss_constants_make uses the exact 0 there. */
double sss_fresnel_two_c1(double eta)
{
    const double e = eta, e2 = e * e, e3 = e2 * e, e4 = e3 * e, e5 = e4 * e;
    if (eta < 1.0) /* [dEon11] 2C1, eta < 1 (sss.md 1.1) */
        return 0.919317 - 3.4793 * e + 6.75335 * e2 - 7.80989 * e3 + 4.98554 * e4 - 1.36881 * e5;
    /* [dEon11] 2C1, eta >= 1 (sss.md 1.1) */
    return -9.23372 + 22.2272 * e - 20.9292 * e2 + 10.2291 * e3 - 2.54396 * e4 + 0.254913 * e5;
}

double sss_fresnel_three_c2(double eta)
{
    const double e = eta, e2 = e * e, e3 = e2 * e, e4 = e3 * e, e5 = e4 * e;
    if (eta < 1.0) /* [dEon11] 3C2, eta < 1 (sss.md 1.1; dirpole.cpp lacks this branch) */
        return 0.828421 - 2.62051 * e + 3.36231 * e2 - 1.95284 * e3 + 0.236494 * e4 + 0.145787 * e5;
    /* [dEon11] 3C2, eta >= 1 (sss.md 1.1): terms ~1e3 cancel to ~0.3, hence double (sss.md 1.3) */
    return -1641.1 + 135.926 / e3 - 656.175 / e2 + 1376.53 / e + 1213.67 * e - 568.556 * e2 + 164.798 * e3 -
           27.0181 * e4 + 1.91826 * e5;
}

/* Unpolarised dielectric Fresnel reflectance (sss.md 1.2, "Fresnel at entry and exit": the
 * average of r_s^2 and r_p^2, 1 on total internal reflection), cos_i clamped to [0, 1]. */
double sss_fresnel_reflectance(double cos_i, double eta)
{
    double c = cos_i > 0.0 ? (cos_i < 1.0 ? cos_i : 1.0) : 0.0;
    if (!(eta > 0.0) || cos_i != cos_i)
        return 1.0;
    /* Snell: sin_t = sin_i / eta, cos_t^2 = 1 - sin_t^2 = ((eta^2 - 1) + cos_i^2)/eta^2 (this form
     * does not cancel near grazing incidence when eta ~ 1) */
    const double eta2 = eta * eta;
    const double cos2_t = ((eta2 - 1.0) + c * c) / eta2;
    if (cos2_t <= 0.0)
        return 1.0; /* total internal reflection (only for eta < 1), or grazing at eta = 1 */
    const double cos_t = sqrt(cos2_t);
    const double rs = (c - eta * cos_t) / (c + eta * cos_t);
    const double rp = (eta * c - cos_t) / (eta * c + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

/* [Jensen01] eq. (after 5) fit of the diffuse Fresnel reflectance, with +0.0636 eta as in the
 * PDF (the thesis' 0.0036 is a typo, sss.md 2). */
double sss_fresnel_dr(double eta)
{
    return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
}

/* Jensen's boundary term A = (1 + F_dr)/(1 - F_dr) [Jensen01] (sss.md 2). eta == 1 exactly:
 * F_dr = 0, A = 1 (the exact index-matched value; the fit gives F_dr(1) = 0.0016). */
static double sss_jensen_a(double eta)
{
    if (eta == 1.0)
        return 1.0;
    const double f = sss_fresnel_dr(eta);
    return (1.0 + f) / (1.0 - f);
}

/* [Jensen01] total diffuse reflectance of the standard dipole (sss.md 2):
 * R_d = (alpha'/2)(1 + e^{-(4/3) A sqrt(3(1-alpha'))}) e^{-sqrt(3(1-alpha'))}. */
double sss_stddipole_total_rd(double alpha_p, double eta)
{
    const double A = sss_jensen_a(eta);
    const double one_m = 1.0 - alpha_p;
    const double s = sqrt(3.0 * (one_m > 0.0 ? one_m : 0.0));
    return 0.5 * alpha_p * (1.0 + exp(-(4.0 / 3.0) * A * s)) * exp(-s);
}

/* ---- Constants ------------------------------------------------------------------------------------- */

obs_status sss_constants_make(obs_context *ctx, const sss_material *m, double mm_per_unit, sss_constants *out)
{
    if (!m || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_constants_make: NULL argument");
    if (!(mm_per_unit > 0.0) || !isfinite(mm_per_unit))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sss_constants_make: mm_per_unit must be > 0 and finite (got %g)", mm_per_unit);
    obs_status st = sss_material_validate(ctx, m, "sss_constants_make");
    if (st != OBS_STATUS_OK)
        return st;

    sss_constants c;
    memset(&c, 0, sizeof c);
    c.material = *m;
    c.mm_per_unit = mm_per_unit;
    const double eta = m->eta;
    c.eta = eta;

    /* Fresnel moments: exact values at eta == 1 (2C1 = 3C2 = 0; the fits' branches disagree
     * there, sss.md 1.3), else [dEon11] (sss.md 1.1). */
    double two_c1_inv;
    if (eta == 1.0) {
        c.two_c1 = 0.0;
        c.three_c2 = 0.0;
        two_c1_inv = 0.0;
    } else {
        c.two_c1 = sss_fresnel_two_c1(eta);
        c.three_c2 = sss_fresnel_three_c2(eta);
        two_c1_inv = sss_fresnel_two_c1(1.0 / eta);
    }
    c.c_phi = 0.25 * (1.0 - c.two_c1);                  /* C_phi = (1 - 2C1)/4  [Frisvad14], sss.md 1.1 */
    c.c_e = 0.5 * (1.0 - c.three_c2);                   /* C_E = (1 - 3C2)/2    [Frisvad14], sss.md 1.1 */
    const double c_phi_inv = 0.25 * (1.0 - two_c1_inv); /* C_phi(1/eta) */
    if (!(c.c_phi > 0.0) || !(c_phi_inv > 0.0) || !(c.c_e > 0.0 && c.c_e < 1.0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "sss_constants_make: material \"%s\": eta = %g is outside the range where the "
                         "d'Eon-Irving fits give valid Fresnel moments (C_phi = %g, C_phi(1/eta) = %g, C_E = %g)",
                         m->name, eta, c.c_phi, c_phi_inv, c.c_e);
    c.a_dir = (1.0 - c.c_e) / (2.0 * c.c_phi); /* A = (1 - C_E)/(2 C_phi)  [Frisvad14], sss.md 1.1 */
    c.norm_dir = 1.0 / (4.0 * c_phi_inv);      /* 1/(4 C_phi(1/eta)), dirpole.cpp "Cp_norm", sss.md 1.1 */
    c.f_dr = eta == 1.0 ? 0.0 : sss_fresnel_dr(eta); /* [Jensen01], sss.md 2 (exact 0 at eta == 1) */
    c.a_jensen = sss_jensen_a(eta);                  /* [Jensen01] A = (1 + F_dr)/(1 - F_dr) */

    c.min_sigma_tr = INFINITY;
    for (int j = 0; j < 3; j++) {
        sss_channel *h = &c.ch[j];
        /* Units: coefficient per unit = coefficient per mm * mm per unit (sss.h). sigma_a is
         * floored at SSS_SIGMA_A_FLOOR mm^-1 (ray_engine's clamp, sss.md 1.3) so sigma_tr > 0. */
        const double sa_mm = m->sigma_a[j] > SSS_SIGMA_A_FLOOR ? m->sigma_a[j] : SSS_SIGMA_A_FLOOR;
        h->sigma_a = sa_mm * mm_per_unit;
        h->sigma_s = m->sigma_s[j] * mm_per_unit;
        h->sigma_t = h->sigma_s + h->sigma_a;                 /* unreduced, back-lit d_r only (sss.md 1.1) */
        h->sigma_s_p = h->sigma_s * (1.0 - m->g);             /* sigma_s' = sigma_s (1 - g), sss.md 1.1 */
        h->sigma_t_p = h->sigma_s_p + h->sigma_a;             /* sigma_t' */
        h->alpha_p = h->sigma_s_p / h->sigma_t_p;             /* alpha' = sigma_s'/sigma_t' */
        h->D = 1.0 / (3.0 * h->sigma_t_p);                    /* D = 1/(3 sigma_t'), sss.md 1.1 */
        h->sigma_tr = sqrt(h->sigma_a / h->D);                /* sigma_tr = sqrt(sigma_a / D), sss.md 1.1 */
        h->backlit_d2 = 1.0 / ((3.0 * h->sigma_t) * (3.0 * h->sigma_t)); /* 1/(3 sigma_t)^2, sss.md 1.2 */
        if (h->alpha_p > 0.0) {
            h->d_e = 2.131 * h->D / sqrt(h->alpha_p);         /* d_e = 2.131 D / sqrt(alpha'), sss.md 1.1 */
            h->two_a_de = 2.0 * c.a_dir * h->d_e;             /* virtual source offset 2 A d_e, sss.md 1.2 */
        } else {
            /* alpha' = 0 (sigma_s = 0): d_e would be infinite; the channel's S_d is 0
             * (appleseed's guard, sss.md 1.3). */
            h->d_e = 0.0;
            h->two_a_de = 0.0;
        }
        h->z_r = 1.0 / h->sigma_t_p;                          /* z_r = 1/sigma_t'  [Jensen01], sss.md 2 */
        h->z_v = h->z_r + 4.0 * c.a_jensen * h->D;            /* z_v = z_r + 4 A D [Jensen01], sss.md 2 */
        if (h->sigma_tr < c.min_sigma_tr)
            c.min_sigma_tr = h->sigma_tr;
    }
    *out = c;
    return OBS_STATUS_OK;
}

/* ---- Small vector helpers (double) ---------------------------------------------------------------- */

static inline double dot3(const double a[3], const double b[3])
{
    return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];
}

static inline void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* ---- Standard dipole [Jensen01] ---------------------------------------------------------------------- */

double sss_stddipole_rd(const sss_constants *c, int channel, double r)
{
    const sss_channel *h = &c->ch[channel];
    if (!(h->alpha_p > 0.0))
        return 0.0;
    const double r2 = r * r;
    const double d_r = sqrt(r2 + h->z_r * h->z_r); /* d_r = sqrt(r^2 + z_r^2)  [Jensen01], sss.md 2 */
    const double d_v = sqrt(r2 + h->z_v * h->z_v); /* d_v = sqrt(r^2 + z_v^2)  [Jensen01], sss.md 2 */
    const double s_r = h->sigma_tr * d_r, s_v = h->sigma_tr * d_v;
    /* [Jensen01] eq. 4, corrected (sss.md 2: the PDF's extra 1/sigma_t' on the virtual term is a
     * typo): R_d = alpha'/(4 pi) [z_r (1 + s d_r) e^{-s d_r}/d_r^3 + z_v (1 + s d_v) e^{-s d_v}/d_v^3] */
    const double real = h->z_r * (1.0 + s_r) * exp(-s_r) / (d_r * d_r * d_r);
    const double virt = h->z_v * (1.0 + s_v) * exp(-s_v) / (d_v * d_v * d_v);
    return h->alpha_p * SSS_I_INV_4PI * (real + virt);
}

/* ---- Directional dipole [Frisvad14] ------------------------------------------------------------------ */

/* S'_d(x, w, r) of [Frisvad14] eq. (the dipole source term; sss.md 1.2): x the vector from the
 * source to x_o, w the source direction, r the SCALAR distance (d_r for the real source, not
 * |x|: sss.md 1.2 "easy to get wrong"), n_o the exit normal. Without the normaliser. */
static double sp_d(const sss_channel *h, double c_phi, double c_e, const double x[3], const double w[3], double r,
                   const double no[3])
{
    const double s_tr_r = h->sigma_tr * r;
    const double one_p = 1.0 + s_tr_r;
    const double x_w = dot3(x, w), x_no = dot3(x, no), w_no = dot3(w, no);
    const double D = h->D;
    /* C_phi(eta) (r^2/D + 3(1 + s r)(x.w))   [Frisvad14], sss.md 1.2 */
    const double t_phi = c_phi * (r * r / D + 3.0 * one_p * x_w);
    /* C_E(eta) (3D(1 + s r)(w.n_o) - ((1 + s r) + 3D (3(1 + s r) + (s r)^2)/r^2 (x.w)) (x.n_o)) */
    const double t_e = c_e * (3.0 * D * one_p * w_no -
                              (one_p + 3.0 * D * (3.0 * one_p + s_tr_r * s_tr_r) / (r * r) * x_w) * x_no);
    /* exp(-s r)/r^3 [...]  (the 1/(4 pi^2) and 1/(4 C_phi(1/eta)) factors are applied by the caller) */
    return exp(-s_tr_r) / (r * r * r) * (t_phi - t_e);
}

static double sd_directional(const sss_constants *c, int channel, const double xi[3], const double ni[3],
                             const double wi[3], const double xo[3], const double no[3])
{
    const sss_channel *h = &c->ch[channel];
    /* alpha' = 0: no scattering, S_d = 0 (sss.md 1.3, appleseed's guard; d_e would be infinite) */
    if (!(h->alpha_p > 0.0))
        return 0.0;
    const double eta = c->eta;
    const double floor_d = SSS_I_DIST_FLOOR_D * h->D; /* distance floor, sss_internal.h */

    /* x = x_o - x_i, r = |x| */
    const double x[3] = {xo[0] - xi[0], xo[1] - xi[1], xo[2] - xi[2]};
    const double r2 = dot3(x, x);
    const double r = sqrt(r2);

    /* w12 = refract(w_i): -(1/eta) w_i - n_i (-(w_i.n_i)/eta + sqrt(1 - (1 - (w_i.n_i)^2)/eta^2)),
     * normalised (sss.md 1.2 "Geometry terms"). The sqrt argument 1 - (1 - cos^2)/eta^2 is
     * evaluated as ((eta^2 - 1) + cos^2)/eta^2 (same value; no cancellation near grazing light
     * when eta ~ 1, which cost float 4e-3 relative) and clamped at 0: under total internal
     * reflection (eta < 1) w12 becomes the critical, tangent direction (continuous; T12 = 0
     * there anyway). Guard, sss.md 1.3 "refraction sqrt". */
    const double cos_i = dot3(wi, ni);
    const double eta2 = eta * eta;
    double k = ((eta2 - 1.0) + cos_i * cos_i) / eta2;
    k = k > 0.0 ? k : 0.0;
    const double a = -cos_i / eta + sqrt(k);
    double w12[3] = {-wi[0] / eta - ni[0] * a, -wi[1] / eta - ni[1] * a, -wi[2] / eta - ni[2] * a};
    const double wl = sqrt(dot3(w12, w12));
    for (int t = 0; t < 3; t++)
        w12[t] /= wl;

    /* n_i* = (x/|x|) x (n_i x x)/|n_i x x|, the modified tangent-plane normal (sss.md 1.2);
     * n_i when |n_i x x| <= eps r: r = 0 (the paper's case) and x parallel to n_i (thin back-lit
     * slab), where the reference code returns NaN (sss.md 1.3). */
    double nstar[3] = {ni[0], ni[1], ni[2]};
    double cx[3];
    cross3(ni, x, cx);
    const double cl = sqrt(dot3(cx, cx));
    if (cl > SSS_I_PARALLEL_EPS * r) {
        const double xh[3] = {x[0] / r, x[1] / r, x[2] / r};
        const double ch[3] = {cx[0] / cl, cx[1] / cl, cx[2] / cl};
        cross3(xh, ch, nstar);
    }

    /* Real source: mu0 = -(n_o . w12); front-lit (mu0 > 0 strictly, as the reference code) uses
     * d_r^2 = r^2 + D mu0 (D mu0 - 2 d_e cos beta), cos beta = -sqrt((r^2 - (x.w12)^2)/(r^2 + d_e^2))
     * (argument clamped at 0, sss.md 1.3); back-lit d_r^2 = r^2 + 1/(3 sigma_t)^2 with the
     * UNreduced sigma_t (sss.md 1.2). */
    const double mu0 = -dot3(no, w12);
    double d_r;
    if (mu0 > 0.0) {
        const double x_w12 = dot3(x, w12);
        double num = r2 - x_w12 * x_w12;
        num = num > 0.0 ? num : 0.0;
        const double cos_beta = -sqrt(num / (r2 + h->d_e * h->d_e));
        const double Dmu0 = h->D * mu0;
        d_r = sqrt(r2 + Dmu0 * (Dmu0 - 2.0 * h->d_e * cos_beta));
    } else {
        d_r = sqrt(r2 + h->backlit_d2);
    }
    d_r = d_r > floor_d ? d_r : floor_d;

    /* Virtual source: x_v = x_i + 2 A d_e n_i*, w_v = w12 - 2 (w12.n_i*) n_i*, d_v = |x_o - x_v|
     * (sss.md 1.2). x_o - x_v is formed as x - 2 A d_e n_i* (no large absolute coordinates). */
    const double wn = dot3(w12, nstar);
    const double wv[3] = {w12[0] - 2.0 * wn * nstar[0], w12[1] - 2.0 * wn * nstar[1], w12[2] - 2.0 * wn * nstar[2]};
    const double xv[3] = {x[0] - h->two_a_de * nstar[0], x[1] - h->two_a_de * nstar[1],
                          x[2] - h->two_a_de * nstar[2]};
    double d_v = sqrt(dot3(xv, xv));
    d_v = d_v > floor_d ? d_v : floor_d;

    /* S_d = S'_d(x_o - x_i, w12, d_r) - S'_d(x_o - x_v, w_v, d_v), times 1/(4 C_phi(1/eta)) 1/(4 pi^2),
     * clamped to >= 0 ([Frisvad14] sec. 6.1 via appleseed; sss.md 1.2) */
    const double s = sp_d(h, c->c_phi, c->c_e, x, w12, d_r, no) - sp_d(h, c->c_phi, c->c_e, xv, wv, d_v, no);
    const double sd = c->norm_dir * SSS_I_INV_4PI2 * s;
    return sd > 0.0 ? sd : 0.0;
}

double sss_sd(const sss_constants *c, sss_model model, int channel, const double xi[3], const double ni[3],
              const double wi[3], const double xo[3], const double no[3])
{
    if (!c || channel < 0 || channel > 2)
        return 0.0;
    if (model == SSS_MODEL_STANDARD) {
        /* S_d = R_d(|x_o - x_i|)/pi, WITHOUT Jensen's F_t factors ([Jensen01] eq. 5 less the
         * Fresnel terms; the batch multiplies T12 and the combination T21, as for the
         * directional model). */
        const double d[3] = {xo[0] - xi[0], xo[1] - xi[1], xo[2] - xi[2]};
        return sss_stddipole_rd(c, channel, sqrt(dot3(d, d))) * SSS_I_INV_PI;
    }
    if (model == SSS_MODEL_DIRECTIONAL)
        return sd_directional(c, channel, xi, ni, wi, xo, no);
    return 0.0;
}
