/* test_sss_bssrdf.c: the SSS materials and BSSRDF layer (src/sss/sss.h sections 1 and 2).
 * Reference figures are ../shared/reference/sss.md's (cited by section); docs/sss/model.md lists
 * what each test guards. */
#include "test.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#include "core/obs.h"
#include "sss/sss.h"
#include "sss/sss_internal.h"

#include <cjson/cJSON.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- helpers ------------------------------------------------------------------------------------ */

static sss_material mat_of(const char *name, double ssp_r, double ssp_g, double ssp_b, double sa_r, double sa_g,
                           double sa_b, double g, double eta)
{
    sss_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%s", name);
    m.sigma_s[0] = ssp_r;
    m.sigma_s[1] = ssp_g;
    m.sigma_s[2] = ssp_b;
    m.sigma_a[0] = sa_r;
    m.sigma_a[1] = sa_g;
    m.sigma_a[2] = sa_b;
    m.g = g;
    m.eta = eta;
    return m;
}

static int preset_index(const char *name)
{
    for (int i = 0; i < sss_preset_count(); i++)
        if (!strcmp(sss_preset(i)->name, name))
            return i;
    return -1;
}

static sss_constants consts_of(const sss_material *m, double mm_per_unit)
{
    sss_constants c;
    memset(&c, 0, sizeof c);
    obs_status st = sss_constants_make(NULL, m, mm_per_unit, &c);
    if (st != OBS_STATUS_OK)
        fprintf(stderr, "sss_constants_make failed for %s\n", m->name);
    return c;
}

/* |v - ref| within half a unit of ref's last printed digit (ref printed with `sig` significant
 * digits): rounding v to that many digits gives the printed value. */
static int matches_decimals(double v, double ref, int dec)
{
    return fabs(v - ref) <= 0.5 * pow(10.0, -dec) * (1.0 + 1e-9);
}

static int matches_printed(double v, double ref, int sig)
{
    const double e = floor(log10(fabs(ref)));
    const double half_ulp = 0.5 * pow(10.0, e - (sig - 1));
    return fabs(v - ref) <= half_ulp * (1.0 + 1e-9);
}

/* a deterministic xorshift64* stream for random inputs */
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double urand(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

static void rand_unit(double v[3])
{
    const double z = 2.0 * urand() - 1.0, phi = 2.0 * M_PI * urand();
    const double s = sqrt(1.0 - z * z);
    v[0] = s * cos(phi);
    v[1] = s * sin(phi);
    v[2] = z;
}

/* ---- 1. reference values ---------------------------------------------------------------------------- */

/* sss.md 1.2: potato, flat plane n = (0,0,1), x_i = 0, w_i = (sin t, 0, cos t), x_o = (+-r, 0, 0) */
TEST(sss_dirpole_matches_reference_values)
{
    const sss_material *potato = sss_preset(preset_index("Potato"));
    CHECK(potato);
    const sss_constants c = consts_of(potato, 1.0);
    static const struct {
        int ch;
        double r;
        double v[5]; /* theta 0; 45 +r; 45 -r; 80 +r; 80 -r */
    } rows[] = {
        {0, 0.01, {1.2638e-01, 1.7552e-01, 1.7719e-01, 2.8279e-01, 2.8772e-01}},
        {0, 0.1, {8.0199e-02, 1.0453e-01, 1.1450e-01, 1.5552e-01, 1.8389e-01}},
        {0, 1.0, {9.5672e-03, 7.4578e-03, 1.3098e-02, 5.7169e-03, 1.5893e-02}},
        {0, 5.0, {7.2071e-04, 5.2586e-04, 8.6691e-04, 4.2118e-04, 9.0901e-04}},
        {2, 1.0, {6.8635e-03, 5.2566e-03, 9.9902e-03, 3.8681e-03, 1.2666e-02}},
    };
    const double xi[3] = {0, 0, 0}, n[3] = {0, 0, 1};
    const double theta[5] = {0.0, 45.0, 45.0, 80.0, 80.0};
    const double sign[5] = {1.0, 1.0, -1.0, 1.0, -1.0};
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++)
        for (int j = 0; j < 5; j++) {
            const double t = theta[j] * M_PI / 180.0;
            const double wi[3] = {sin(t), 0.0, cos(t)};
            const double xo[3] = {sign[j] * rows[i].r, 0.0, 0.0};
            const double v = sss_sd(&c, SSS_MODEL_DIRECTIONAL, rows[i].ch, xi, n, wi, xo, n);
            /* the table has 5 significant digits: the value rounds to it (relative <= 4e-5) */
            CHECK_MSG(matches_printed(v, rows[i].v[j], 5), "ch %d r %g theta %g sign %g: %.6e vs %.4e", rows[i].ch,
                      rows[i].r, theta[j], sign[j], v, rows[i].v[j]);
        }
    /* the float batch (both paths) on the same configurations: within 1e-4 relative of the table
     * (x_o = 0, x_i = -(x_o - x_i) of the table) */
    sss_gpu_constants g;
    sss_gpu_constants_make(&c, SSS_MODEL_DIRECTIONAL, &g);
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        float fx[3][5], fn[3][5], fw[3][5], fo[3][5];
        for (int j = 0; j < 5; j++) {
            const double t = theta[j] * M_PI / 180.0;
            fx[0][j] = (float)(-sign[j] * rows[i].r);
            fx[1][j] = fx[2][j] = 0.0f;
            fn[0][j] = fn[1][j] = 0.0f;
            fn[2][j] = 1.0f;
            fw[0][j] = (float)sin(t);
            fw[1][j] = 0.0f;
            fw[2][j] = (float)cos(t);
        }
        const float xo[3] = {0, 0, 0}, no[3] = {0, 0, 1};
        sss_batch b = {5, {fx[0], fx[1], fx[2]}, {fn[0], fn[1], fn[2]}, {fw[0], fw[1], fw[2]}, {fo[0], fo[1], fo[2]}};
        for (int isa = SSS_ISA_SCALAR; isa < SSS_ISA_COUNT; isa++) {
            if (!sss_isa_available((sss_isa)isa))
                continue;
            CHECK_OK(sss_eval_batch(NULL, &g, xo, no, &b, 0, (sss_isa)isa), NULL);
            for (int j = 0; j < 5; j++)
                CHECK_MSG(fabs(fo[rows[i].ch][j] - rows[i].v[j]) <= 1e-4 * rows[i].v[j],
                          "float isa %d ch %d r %g theta %g: %.6e vs %.4e", isa, rows[i].ch, rows[i].r, theta[j],
                          (double)fo[rows[i].ch][j], rows[i].v[j]);
        }
    }
}

/* sss.md 1.1 (constants row), 1.2 (derived constants) and 2 (F_dr, A) */
TEST(sss_constants_match_reference_values)
{
    const sss_constants p = consts_of(sss_preset(preset_index("Potato")), 1.0);
    const sss_constants m = consts_of(sss_preset(preset_index("Marble")), 1.0);
    /* eta 1.3 and 1.5 rows: 2C1, 3C2, C_phi, C_E, A_dir, 1/(4 C_phi(1/eta)) (6 decimals) */
    const double row13[6] = {0.445295, 0.297448, 0.138676, 0.351276, 2.338986, 1.065094};
    const double row15[6] = {0.596541, 0.462609, 0.100865, 0.268695, 3.625171, 1.101048};
    const sss_constants *cs[2] = {&p, &m};
    const double *rows[2] = {row13, row15};
    for (int k = 0; k < 2; k++) {
        const sss_constants *c = cs[k];
        const double got[6] = {c->two_c1, c->three_c2, c->c_phi, c->c_e, c->a_dir, c->norm_dir};
        for (int j = 0; j < 6; j++)
            CHECK_MSG(fabs(got[j] - rows[k][j]) <= 5e-7, "eta %g column %d: %.7f vs %.6f", c->eta, j, got[j],
                      rows[k][j]);
    }
    /* C_phi(1/eta) columns: 0.234721 and 0.227056 */
    CHECK_NEAR(0.25 * (1.0 - sss_fresnel_two_c1(1.0 / 1.3)), 0.234721, 5e-7);
    CHECK_NEAR(0.25 * (1.0 - sss_fresnel_two_c1(1.0 / 1.5)), 0.227056, 5e-7);
    /* potato R: D = 0.4885, sigma_tr = 0.0701, d_e = 1.0428, 2A d_e = 4.878 mm */
    CHECK(matches_printed(p.ch[0].D, 0.4885, 4));
    CHECK(matches_decimals(p.ch[0].sigma_tr, 0.0701, 4));
    CHECK(matches_printed(p.ch[0].d_e, 1.0428, 5));
    CHECK(matches_printed(p.ch[0].two_a_de, 4.878, 4));
    /* marble R: D = 0.1521, sigma_tr = 0.1175, d_e = 0.3242, 2A d_e = 2.3505 */
    CHECK(matches_printed(m.ch[0].D, 0.1521, 4));
    CHECK(matches_printed(m.ch[0].sigma_tr, 0.1175, 4));
    CHECK(matches_printed(m.ch[0].d_e, 0.3242, 4));
    CHECK(matches_printed(m.ch[0].two_a_de, 2.3505, 5));
    /* Jensen's F_dr and A (sss.md 2): 0.444763, 2.602064 at 1.3; 0.596733, 3.959497 at 1.5 */
    CHECK_NEAR(p.f_dr, 0.444763, 5e-7);
    CHECK_NEAR(p.a_jensen, 2.602064, 5e-7);
    CHECK_NEAR(m.f_dr, 0.596733, 5e-7);
    CHECK_NEAR(m.a_jensen, 3.959497, 5e-7);
    CHECK_NEAR(sss_fresnel_dr(1.3), 0.444763, 5e-7);
    /* sigma_tr table (sss.md 2): Apple, Potato, Ketchup, Marble per channel; 1/min sigma_tr */
    static const struct {
        const char *name;
        double tr[3];
        double inv_min;
    } trs[] = {{"Apple", {0.1437, 0.1562, 0.5275}, 6.96},
               {"Potato", {0.0701, 0.1384, 0.4911}, 14.27},
               {"Ketchup", {0.2100, 1.7397, 2.5373}, 4.76},
               {"Marble", {0.1175, 0.1797, 0.2531}, 8.51}};
    for (size_t i = 0; i < sizeof trs / sizeof trs[0]; i++) {
        const sss_constants c = consts_of(sss_preset(preset_index(trs[i].name)), 1.0);
        for (int j = 0; j < 3; j++)
            CHECK_MSG(matches_decimals(c.ch[j].sigma_tr, trs[i].tr[j], 4), "%s %d: %.6f", trs[i].name, j,
                      c.ch[j].sigma_tr);
        CHECK_MSG(matches_decimals(1.0 / c.min_sigma_tr, trs[i].inv_min, 2), "%s: 1/min %.4f", trs[i].name,
                  1.0 / c.min_sigma_tr);
    }
    /* units: the same potato in metres (1000 mm per unit) has coefficients x1000, lengths /1000 */
    const sss_constants pm = consts_of(sss_preset(preset_index("Potato")), 1000.0);
    CHECK_NEAR(pm.ch[0].sigma_tr / p.ch[0].sigma_tr, 1000.0, 1e-9);
    CHECK_NEAR(p.ch[0].d_e / pm.ch[0].d_e, 1000.0, 1e-9);
    CHECK_NEAR(pm.ch[0].alpha_p, p.ch[0].alpha_p, 1e-15);
}

/* sss.md 2: R_d(r) of the corrected eq. 4, potato R */
TEST(sss_stddipole_rd_matches_reference_values)
{
    const sss_constants p = consts_of(sss_preset(preset_index("Potato")), 1.0);
    const double r[5] = {0.0, 0.1, 1.0, 5.0, 20.0};
    const double ref[5] = {3.8449e-2, 3.8192e-2, 2.2306e-2, 1.6004e-3, 4.0048e-5};
    for (int i = 0; i < 5; i++) {
        const double v = sss_stddipole_rd(&p, 0, r[i]);
        CHECK_MSG(matches_printed(v, ref[i], 5), "r %g: %.6e vs %.4e", r[i], v, ref[i]);
    }
    /* sss_sd of the standard model is R_d/pi (no Fresnel factors) */
    const double xi[3] = {0, 0, 0}, n[3] = {0, 0, 1}, xo[3] = {1.0, 0, 0};
    CHECK_NEAR(sss_sd(&p, SSS_MODEL_STANDARD, 0, xi, n, n, xo, n), 2.2306e-2 / M_PI, 1e-7);
}

/* [Jensen01]'s measured R_d column vs the closed-form total R_d (sss.md 2) */
TEST(sss_stddipole_total_rd_matches_jensen_measured)
{
    for (int i = 0; i < sss_preset_count(); i++) {
        const sss_material *m = sss_preset(i);
        const sss_constants c = consts_of(m, 1.0);
        double rd[3];
        CHECK(sss_preset_measured_rd(i, rd));
        for (int j = 0; j < 3; j++) {
            const double v = sss_stddipole_total_rd(c.ch[j].alpha_p, m->eta);
            printf("%-10s %.3f (measured %.2f)%s", j ? "" : m->name, v, rd[j], j == 2 ? "\n" : "  ");
            double tol = 0.01;
            if ((!strcmp(m->name, "Chicken1") && j == 2) || (!strcmp(m->name, "Chicken2") && j == 2) ||
                (!strcmp(m->name, "Ketchup") && j == 1))
                tol = 0.03; /* sss.md 2: the largest deviations of the closed form */
            CHECK_MSG(fabs(v - rd[j]) <= tol, "%s channel %d: closed form %.4f vs measured %.2f", m->name, j, v,
                      rd[j]);
        }
    }
    /* the figures sss.md 2 computed: potato (0.764, 0.613, 0.213) */
    const sss_constants p = consts_of(sss_preset(preset_index("Potato")), 1.0);
    CHECK_NEAR(sss_stddipole_total_rd(p.ch[0].alpha_p, 1.3), 0.764, 5e-4);
    CHECK_NEAR(sss_stddipole_total_rd(p.ch[1].alpha_p, 1.3), 0.613, 5e-4);
    CHECK_NEAR(sss_stddipole_total_rd(p.ch[2].alpha_p, 1.3), 0.213, 5e-4);
    CHECK(sss_preset_measured_rd(-1, (double[3]){0}) == 0);
    CHECK(sss_preset_measured_rd(12, (double[3]){0}) == 0);
}

/* integral over the plane of a radial profile: 2 pi int f(r) r dr, r = e^u, composite Simpson */
typedef double (*radial_fn)(const void *user, double r);
static double plane_integral(radial_fn f, const void *user, double r_min, double r_max, int n)
{
    const double u0 = log(r_min), u1 = log(r_max);
    const double h = (u1 - u0) / n;
    double s = 0.0;
    for (int i = 0; i <= n; i++) {
        const double r = exp(u0 + h * i);
        const double w = (i == 0 || i == n) ? 1.0 : (i & 1) ? 4.0 : 2.0;
        s += w * f(user, r) * r * r;
    }
    /* plus the disk r < r_min with the value at r_min (negligible) */
    return 2.0 * M_PI * (s * h / 3.0 + f(user, r_min) * 0.5 * r_min * r_min);
}

typedef struct {
    const sss_constants *c;
    int ch;
} rd_user;
static double rd_fn(const void *u, double r)
{
    const rd_user *p = u;
    return sss_stddipole_rd(p->c, p->ch, r);
}

/* 2 pi int R_d(r) r dr = the closed form (sss.md 2: 0.764423 vs 0.764422 for potato R) for every
 * preset channel (Spectralon included: sigma_a floored at 1e-8 mm^-1, r_max ~ 60/sigma_tr) */
TEST(sss_stddipole_plane_integral_equals_closed_form)
{
    double worst = 0.0;
    for (int i = 0; i < sss_preset_count(); i++) {
        const sss_material *m = sss_preset(i);
        const sss_constants c = consts_of(m, 1.0);
        for (int j = 0; j < 3; j++) {
            rd_user u = {&c, j};
            const double r_max = 60.0 / c.ch[j].sigma_tr + 100.0 * c.ch[j].z_v;
            const double num = plane_integral(rd_fn, &u, 1e-6, r_max, 20000);
            const double closed = sss_stddipole_total_rd(c.ch[j].alpha_p, m->eta);
            CHECK_MSG(fabs(num - closed) <= 2e-6 * (closed > 1e-3 ? closed : 1e-3), "%s %d: numeric %.7f closed %.7f",
                      m->name, j, num, closed);
            if (fabs(num - closed) / closed > worst)
                worst = fabs(num - closed) / closed;
            if (!strcmp(m->name, "Potato") && j == 0) {
                printf("potato R: numeric %.6f closed %.6f (sss.md: 0.764423 vs 0.764422)\n", num, closed);
                /* sss.md's own quadrature is 1e-6 above the closed form; ours agrees better */
                CHECK_NEAR(num, 0.764423, 2e-6);
                CHECK_NEAR(closed, 0.764422, 1e-6);
            }
        }
    }
    printf("36 preset channels: max |numeric - closed| / closed = %.3g\n", worst);
}

typedef struct {
    const sss_constants *c;
    int ch;
} sd_user;
static double sd_fn(const void *u, double r)
{
    const sd_user *p = u;
    const double xi[3] = {0, 0, 0}, n[3] = {0, 0, 1}, xo[3] = {r, 0, 0};
    return sss_sd(p->c, SSS_MODEL_DIRECTIONAL, p->ch, xi, n, n, xo, n);
}

/* The directional dipole's plane exitance at normal incidence (no T12, exitance = 4 pi
 * C_phi(1/eta) int S_d dA) vs the standard dipole's total R_d: sss.md 1.4's figures. The
 * directional dipole is brighter (1.000 vs 0.764 for potato R): a property of the model, not a bug. */
TEST(sss_dirpole_plane_energy_matches_computed_figures)
{
    static const struct {
        const char *what;
        double alpha, eta;
        double dir, std;
    } rows[] = {{"potato R", -1.0, 1.3, 1.000, 0.764},
                {"eta 1 alpha' 0.99", 0.99, 1.0, 1.087, 0.747},
                {"eta 1 alpha' 0.9", 0.9, 1.0, 0.710, 0.385},
                {"eta 1 alpha' 0.5", 0.5, 1.0, 0.350, 0.088}};
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        sss_material m = rows[i].alpha < 0 ? *sss_preset(preset_index("Potato"))
                                           : mat_of("a", rows[i].alpha, rows[i].alpha, rows[i].alpha,
                                                    1.0 - rows[i].alpha, 1.0 - rows[i].alpha, 1.0 - rows[i].alpha,
                                                    0.0, rows[i].eta);
        const sss_constants c = consts_of(&m, 1.0);
        sd_user u = {&c, 0};
        const double r_max = 60.0 / c.ch[0].sigma_tr + 100.0 * c.ch[0].two_a_de;
        const double E = M_PI / c.norm_dir * plane_integral(sd_fn, &u, 1e-7, r_max, 40000);
        const double S = sss_stddipole_total_rd(c.ch[0].alpha_p, m.eta);
        printf("%-20s directional %.4f (sss.md %.3f)  standard %.4f (sss.md %.3f)\n", rows[i].what, E, rows[i].dir, S,
               rows[i].std);
        CHECK_MSG(fabs(E - rows[i].dir) <= 0.01 * rows[i].dir, "%s: directional %.4f vs %.3f", rows[i].what, E,
                  rows[i].dir);
        CHECK_MSG(fabs(S - rows[i].std) <= 0.01 * rows[i].std, "%s: standard %.4f vs %.3f", rows[i].what, S,
                  rows[i].std);
    }
}

/* S'_d of sss.md 1.2, written out for the test below */
static double sp_ref(const sss_constants *c, int ch, double r, double x_w, double x_no, double w_no)
{
    const sss_channel *h = &c->ch[ch];
    const double s = h->sigma_tr * r, D = h->D;
    const double inner = (1.0 + s) + 3.0 * D * (3.0 * (1.0 + s) + s * s) / (r * r) * x_w;
    return exp(-s) / (r * r * r) *
           (c->c_phi * (r * r / D + 3.0 * (1.0 + s) * x_w) - c->c_e * (3.0 * D * (1.0 + s) * w_no - inner * x_no));
}

/* x_o = x_i, light at normal incidence, n_o tilted so that mu0 = n_o.z sweeps towards 0+:
 * the front-lit d_r = D mu0 -> 0 would make S_d grow as 1/mu0^2 without bound; the floor
 * d_r >= 0.01 D (SSS_I_DIST_FLOOR_D, docs/sss/model.md "Deviations" 1) acts only below
 * mu0 = 0.01. Checked against sss.md 1.2's formula written out here (n_o tilted: a geometry the
 * reference table does not cover), double and float. */
TEST(sss_distance_floor_acts_only_near_tangent_refraction)
{
    const sss_constants c = consts_of(sss_preset(preset_index("Potato")), 1.0);
    sss_gpu_constants g;
    sss_gpu_constants_make(&c, SSS_MODEL_DIRECTIONAL, &g);
    const double z[3] = {0, 0, 0}, n[3] = {0, 0, 1};
    const double mus[] = {0.9, 0.5, 0.05, 0.0101, 0.0099, 1e-3, 1e-6, 1e-12};
    for (size_t i = 0; i < sizeof mus / sizeof mus[0]; i++) {
        const double mu0 = mus[i];
        const double no[3] = {sqrt(1.0 - mu0 * mu0), 0.0, mu0};
        for (int ch = 0; ch < 3; ch++) {
            const sss_channel *h = &c.ch[ch];
            const double dr = fmax(h->D * mu0, SSS_I_DIST_FLOOR_D * h->D);
            const double dv = h->two_a_de;
            /* real: x = 0; w12 = -n: w.n_o = -mu0. virtual: x_v = -2A d_e n, w_v = +n */
            const double real = sp_ref(&c, ch, dr, 0.0, 0.0, -mu0);
            const double virt = sp_ref(&c, ch, dv, -dv, -dv * mu0, mu0);
            double ref = c.norm_dir * SSS_I_INV_4PI2 * (real - virt);
            ref = ref > 0.0 ? ref : 0.0;
            const double v = sss_sd(&c, SSS_MODEL_DIRECTIONAL, ch, z, n, n, z, no);
            CHECK_MSG(fabs(v - ref) <= 1e-12 * ref, "mu0 %g ch %d: %.12g vs %.12g", mu0, ch, v, ref);
            /* float, scalar path: finite, within 1e-3 where mu0 is representable as a tilt */
            float fz[1] = {0}, fn1[1] = {1}, fo[3];
            const float fxo[3] = {0, 0, 0}, fno[3] = {(float)no[0], 0.0f, (float)no[2]};
            sss_batch b = {1, {fz, fz, fz}, {fz, fz, fn1}, {fz, fz, fn1}, {&fo[0], &fo[1], &fo[2]}};
            CHECK_OK(sss_eval_batch(NULL, &g, fxo, fno, &b, 0, SSS_ISA_SCALAR), NULL);
            CHECK(isfinite(fo[ch]) && fo[ch] >= 0.0f);
            CHECK_MSG(fabs(fo[ch] - v) <= 1e-3 * v, "float mu0 %g ch %d: %.9g vs %.9g", mu0, ch, (double)fo[ch], v);
        }
    }
}

/* ---- 2. Fresnel --------------------------------------------------------------------------------------- */

static double poly_pow(const double *c, const int *p, int n, double eta)
{
    long double s = 0.0L;
    for (int i = 0; i < n; i++)
        s += (long double)c[i] * powl((long double)eta, (long double)p[i]);
    return (double)s;
}

/* Both branches of [dEon11]'s fits at 0.8 and 1.3 against term-by-term powl sums; the exact values
 * at eta = 1; 3C2 in float cancels (sss.md 1.3: 3C2(1.01) 5% off), so the constants are double */
TEST(sss_fresnel_fits_both_branches_and_double_precision)
{
    static const double c1_lo[6] = {0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881};
    static const double c2_lo[6] = {0.828421, -2.62051, 3.36231, -1.95284, 0.236494, 0.145787};
    static const double c1_hi[6] = {-9.23372, 22.2272, -20.9292, 10.2291, -2.54396, 0.254913};
    static const double c2_hi[9] = {-1641.1, 135.926, -656.175, 1376.53, 1213.67, -568.556, 164.798, -27.0181, 1.91826};
    static const int p6[6] = {0, 1, 2, 3, 4, 5};
    static const int p9[9] = {0, -3, -2, -1, 1, 2, 3, 4, 5};
    CHECK_NEAR(sss_fresnel_two_c1(0.8), poly_pow(c1_lo, p6, 6, 0.8), 1e-12);
    CHECK_NEAR(sss_fresnel_three_c2(0.8), poly_pow(c2_lo, p6, 6, 0.8), 1e-12);
    CHECK_NEAR(sss_fresnel_two_c1(1.3), poly_pow(c1_hi, p6, 6, 1.3), 1e-12);
    CHECK_NEAR(sss_fresnel_three_c2(1.3), poly_pow(c2_hi, p9, 9, 1.3), 1e-11);
    /* branch boundary (sss.md 1.3): 2C1(1-) = 0.000207, 2C1(1+) = 0.004333, 3C2(1-) = -0.000338, 3C2(1+) = -0.006840 */
    CHECK_NEAR(sss_fresnel_two_c1(nextafter(1.0, 0.0)), 0.000207, 5e-7);
    CHECK_NEAR(sss_fresnel_two_c1(1.0), 0.004333, 5e-7);
    CHECK_NEAR(sss_fresnel_three_c2(nextafter(1.0, 0.0)), -0.000338, 5e-7);
    CHECK_NEAR(sss_fresnel_three_c2(1.0), -0.006840, 5e-7);
    /* eta = 1 exactly: the constants use the exact 2C1 = 3C2 = 0, A = 1, normaliser 1 */
    sss_material m1 = mat_of("m1", 1, 1, 1, 0.01, 0.01, 0.01, 0.0, 1.0);
    const sss_constants c1 = consts_of(&m1, 1.0);
    CHECK(c1.two_c1 == 0.0 && c1.three_c2 == 0.0 && c1.a_dir == 1.0 && c1.norm_dir == 1.0);
    CHECK(c1.c_phi == 0.25 && c1.c_e == 0.5 && c1.a_jensen == 1.0 && c1.f_dr == 0.0);
    /* 3C2(1.01): double -0.0010977 (sss.md 1.3); the same sum in float is far off */
    const double d = sss_fresnel_three_c2(1.01);
    CHECK_NEAR(d, -0.0010977, 5e-8);
    const float e = 1.01f, e2 = e * e, e3 = e2 * e, e4 = e3 * e, e5 = e4 * e;
    const float f = -1641.1f + 135.926f / e3 - 656.175f / e2 + 1376.53f / e + 1213.67f * e - 568.556f * e2 +
                    164.798f * e3 - 27.0181f * e4 + 1.91826f * e5;
    printf("3C2(1.01): double %.7f, float %.7f (relative error %.3f)\n", d, (double)f, fabs(f - d) / fabs(d));
    CHECK(fabs(f - d) > 0.01 * fabs(d)); /* why the constants are computed in double */
    /* eta < 1 constants are valid (C_phi > 0 etc.): 0.7 */
    sss_material m7 = mat_of("m7", 1, 1, 1, 0.01, 0.01, 0.01, 0.0, 0.7);
    sss_constants c7;
    CHECK_OK(sss_constants_make(NULL, &m7, 1.0, &c7), NULL);
    CHECK(c7.c_phi > 0.0 && c7.norm_dir > 0.0 && c7.a_dir > 0.0);
    CHECK_NEAR(c7.three_c2, poly_pow(c2_lo, p6, 6, 0.7), 1e-12);
    CHECK_NEAR(c7.norm_dir, 1.0 / (1.0 - poly_pow(c1_hi, p6, 6, 1.0 / 0.7)), 1e-12);
}

/* Unpolarised dielectric Fresnel: normal incidence ((eta-1)/(eta+1))^2, grazing 1, TIR 1,
 * index-matched 0, cos clamped; the float T12 of the batch agrees */
TEST(sss_fresnel_reflectance_properties)
{
    CHECK_NEAR(sss_fresnel_reflectance(1.0, 1.5), 0.04, 1e-15);
    CHECK_NEAR(sss_fresnel_reflectance(1.0, 1.3), (0.3 / 2.3) * (0.3 / 2.3), 1e-15);
    CHECK_NEAR(sss_fresnel_reflectance(0.0, 1.3), 1.0, 1e-15);
    CHECK_NEAR(sss_fresnel_reflectance(0.5, 1.0), 0.0, 1e-15);
    CHECK(sss_fresnel_reflectance(0.1, 0.7) == 1.0);  /* sin_i = 0.995 > 0.7: TIR */
    CHECK(sss_fresnel_reflectance(0.9, 0.7) < 1.0);
    CHECK(sss_fresnel_reflectance(-0.5, 1.3) == 1.0); /* clamped to 0 */
    CHECK(sss_fresnel_reflectance(1.5, 1.3) == sss_fresnel_reflectance(1.0, 1.3));
    /* monotone in cos for eta > 1 */
    double prev = 2.0;
    for (int i = 0; i <= 100; i++) {
        const double f = sss_fresnel_reflectance(i / 100.0, 1.3);
        CHECK(f <= prev + 1e-15 && f >= 0.0 && f <= 1.0);
        prev = f;
    }
    /* the batch's T12: S_d with and without it, ratio = 1 - F */
    const sss_constants c = consts_of(sss_preset(preset_index("Potato")), 1.0);
    sss_gpu_constants g;
    sss_gpu_constants_make(&c, SSS_MODEL_STANDARD, &g);
    float xi[3][8], ni[3][8], wi[3][8], o1[3][8], o2[3][8];
    for (int k = 0; k < 8; k++) {
        const double t = k * (M_PI / 2.0) / 7.0;
        xi[0][k] = 0.5f; xi[1][k] = 0.0f; xi[2][k] = 0.0f;
        ni[0][k] = 0.0f; ni[1][k] = 0.0f; ni[2][k] = 1.0f;
        wi[0][k] = (float)sin(t); wi[1][k] = 0.0f; wi[2][k] = (float)cos(t);
    }
    const float xo[3] = {0, 0, 0}, no[3] = {0, 0, 1};
    sss_batch b = {8, {xi[0], xi[1], xi[2]}, {ni[0], ni[1], ni[2]}, {wi[0], wi[1], wi[2]}, {o1[0], o1[1], o1[2]}};
    CHECK_OK(sss_eval_batch(NULL, &g, xo, no, &b, 1, SSS_ISA_SCALAR), NULL);
    sss_batch b2 = b;
    b2.out[0] = o2[0]; b2.out[1] = o2[1]; b2.out[2] = o2[2];
    CHECK_OK(sss_eval_batch(NULL, &g, xo, no, &b2, 0, SSS_ISA_SCALAR), NULL);
    for (int k = 0; k < 8; k++) {
        const double cosk = (double)wi[2][k] * 1.0;
        const double T = 1.0 - sss_fresnel_reflectance(cosk, 1.3);
        CHECK_MSG(fabs(o1[0][k] / o2[0][k] - T) <= 1e-6, "k %d: %.7f vs %.7f", k, o1[0][k] / o2[0][k], T);
    }
}

/* ---- 3. the float kernel ---------------------------------------------------------------------------- */

/* The kernel's own exp against double exp, dense sweep of [-87, 88] (plus the end cases) */
TEST(sss_float_exp_error_is_bounded)
{
    double worst = 0.0, at = 0.0, libm = 0.0;
    for (int i = 0; i <= 2000000; i++) {
        const float x = (float)(-87.0 + 175.0 * i / 2000000.0);
        const double ref = exp((double)x);
        if (fabs((double)expf(x) - ref) / ref > libm)
            libm = fabs((double)expf(x) - ref) / ref;
        const double rel = fabs((double)sss_i_expf(x) - ref) / ref;
        if (rel > worst) {
            worst = rel;
            at = x;
        }
    }
    /* every 61st float in [-1, 0] (17M values: all mantissa patterns of the reduced argument) */
    for (float x = -1.0f; x <= 0.0f;) {
        const double ref = exp((double)x);
        const double rel = fabs((double)sss_i_expf(x) - ref) / ref;
        if (rel > worst) {
            worst = rel;
            at = x;
        }
        uint32_t u;
        memcpy(&u, &x, sizeof u);
        u = u > 61u + 0x80000000u ? u - 61u : 0x80000000u; /* towards -0 */
        if (u == 0x80000000u)
            break;
        memcpy(&x, &u, sizeof u);
    }
    printf("float exp: max relative error %.3g (at %.6g); libm expf on the sweep: %.3g\n", worst, at, libm);
    CHECK(worst <= SSS_I_EXPF_MAX_REL);
    CHECK(sss_i_expf(0.0f) == 1.0f);
    CHECK(sss_i_expf(-87.5f) == 0.0f);
    CHECK(sss_i_expf(-1e30f) == 0.0f);
    CHECK(isfinite(sss_i_expf(1000.0f)));
}

/* random geometry on a sphere of radius R (mm), and the hard cases appended */
typedef struct {
    int n;
    float *xi[3], *ni[3], *wi[3], *out[3];
    float xo[3], no[3];
} fbatch;

static void fbatch_alloc(fbatch *f, int n)
{
    f->n = n;
    for (int t = 0; t < 3; t++) {
        f->xi[t] = calloc((size_t)n, sizeof(float));
        f->ni[t] = calloc((size_t)n, sizeof(float));
        f->wi[t] = calloc((size_t)n, sizeof(float));
        f->out[t] = calloc((size_t)n, sizeof(float));
    }
}
static void fbatch_free(fbatch *f)
{
    for (int t = 0; t < 3; t++) {
        free(f->xi[t]);
        free(f->ni[t]);
        free(f->wi[t]);
        free(f->out[t]);
    }
}
static sss_batch fbatch_view(const fbatch *f, float **out)
{
    sss_batch b = {f->n,
                   {f->xi[0], f->xi[1], f->xi[2]},
                   {f->ni[0], f->ni[1], f->ni[2]},
                   {f->wi[0], f->wi[1], f->wi[2]},
                   {out[0], out[1], out[2]}};
    return b;
}

/* Sample k: x_i on the sphere near x_o (a cap of angle cap), n_i its normal, w_i a random unit
 * vector (upper hemisphere with probability 0.9, else anything: below-surface and grazing light) */
static void fill_random_sphere(fbatch *f, double R, double cap, int exact_grazing_every)
{
    double o[3];
    rand_unit(o);
    for (int t = 0; t < 3; t++) {
        f->xo[t] = (float)(R * o[t]);
        f->no[t] = (float)o[t];
    }
    for (int k = 0; k < f->n; k++) {
        double d[3], n[3], w[3];
        do {
            rand_unit(d);
        } while ((d[0] * o[0] + d[1] * o[1]) + d[2] * o[2] < cos(cap));
        for (int t = 0; t < 3; t++)
            n[t] = d[t];
        rand_unit(w);
        double c = (w[0] * n[0] + w[1] * n[1]) + w[2] * n[2];
        if (c < 0.0 && urand() < 0.9)
            for (int t = 0; t < 3; t++)
                w[t] -= 2.0 * c * n[t];
        if (exact_grazing_every && k % exact_grazing_every == 0) {
            /* w_i perpendicular to n_i */
            c = (w[0] * n[0] + w[1] * n[1]) + w[2] * n[2];
            double l = 0.0;
            for (int t = 0; t < 3; t++) {
                w[t] -= c * n[t];
                l += w[t] * w[t];
            }
            for (int t = 0; t < 3; t++)
                w[t] /= sqrt(l);
        }
        for (int t = 0; t < 3; t++) {
            f->xi[t][k] = (float)(R * d[t]);
            f->ni[t][k] = (float)n[t];
            f->wi[t][k] = (float)w[t];
        }
    }
}

static void fset(fbatch *f, int k, const double xi[3], const double ni[3], const double wi[3])
{
    for (int t = 0; t < 3; t++) {
        f->xi[t][k] = (float)xi[t];
        f->ni[t][k] = (float)ni[t];
        f->wi[t][k] = (float)wi[t];
    }
}

/* sample k's inputs, for failure messages */
static const char *describe(const fbatch *f, int k)
{
    static char buf[512];
    snprintf(buf, sizeof buf, "k %d xi (%.9g %.9g %.9g) ni (%.9g %.9g %.9g) wi (%.9g %.9g %.9g) xo (%.9g %.9g %.9g) "
             "no (%.9g %.9g %.9g)", k, f->xi[0][k], f->xi[1][k], f->xi[2][k], f->ni[0][k], f->ni[1][k], f->ni[2][k],
             f->wi[0][k], f->wi[1][k], f->wi[2][k], f->xo[0], f->xo[1], f->xo[2], f->no[0], f->no[1], f->no[2]);
    return buf;
}

/* the double reference at the float inputs */
static double ref_at(const sss_constants *c, sss_model model, int ch, const fbatch *f, int k, int with_t12)
{
    double xi[3], ni[3], wi[3], xo[3], no[3];
    for (int t = 0; t < 3; t++) {
        xi[t] = f->xi[t][k];
        ni[t] = f->ni[t][k];
        wi[t] = f->wi[t][k];
        xo[t] = f->xo[t];
        no[t] = f->no[t];
    }
    double v = sss_sd(c, model, ch, xi, ni, wi, xo, no);
    if (with_t12)
        v *= 1.0 - sss_fresnel_reflectance((ni[0] * wi[0] + ni[1] * wi[1]) + ni[2] * wi[2], c->eta);
    return v;
}

/* hard-case batch (sss.md 1.3) for a given exit point x_o = 0, n_o = (0,0,1); returns count */
static int fill_hard_cases(fbatch *f, const sss_constants *c)
{
    int k = 0;
    const double z[3] = {0, 0, 0}, up[3] = {0, 0, 1}, dn[3] = {0, 0, -1};
    const double tilt[3] = {0.6, 0.0, 0.8}, graze[3] = {1, 0, 0}, below[3] = {0.6, 0, -0.8};
    f->xo[0] = f->xo[1] = f->xo[2] = 0.0f;
    f->no[0] = f->no[1] = 0.0f;
    f->no[2] = 1.0f;
    /* r -> 0: x_i = x_o exactly, 1e-9 away in the plane and along the normal */
    fset(f, k++, z, up, up);
    fset(f, k++, z, up, tilt);
    fset(f, k++, z, up, graze);
    fset(f, k++, z, up, below);
    fset(f, k++, (double[3]){1e-9, 0, 0}, up, up);
    fset(f, k++, (double[3]){0, 1e-9, 0}, up, tilt);
    fset(f, k++, (double[3]){0, 0, 1e-9}, up, up);
    fset(f, k++, (double[3]){0, 0, -1e-9}, up, tilt);
    /* x_o - x_i parallel to n_i: thin slab [-t, 0] lit from behind (x_o = x_i - t n_i, n_o = -n_i):
     * x_i = (0,0,-t) on the bottom face, n_i = (0,0,-1), light from below (cases 8..10) */
    fset(f, k++, (double[3]){0, 0, -1.0}, dn, dn);
    fset(f, k++, (double[3]){0, 0, -1e-6}, dn, dn);
    fset(f, k++, (double[3]){0, 0, -3.0}, dn, (double[3]){0.6, 0, -0.8});
    /* x_o straight above x_i along n_i = -n_o (x_o outside x_i's surface: a fold) */
    fset(f, k++, (double[3]){0, 0, 1.0}, dn, dn);
    fset(f, k++, (double[3]){0, 0, 1e-6}, dn, dn);
    /* eta < 1: a TIR direction when eta = 0.7 (cos 0.3: sin 0.95 > 0.7) */
    fset(f, k++, (double[3]){-0.5, 0, 0}, up, (double[3]){0.953939, 0, 0.3});
    /* x_o on the virtual source of channel 0: x_o = x_i + 2 A d_e n_i (n_i = n_o) */
    fset(f, k++, (double[3]){0, 0, -c->ch[0].two_a_de}, up, up);
    fset(f, k++, (double[3]){0, 0, -c->ch[1].two_a_de}, up, tilt);
    /* grazing light (w_i perpendicular to n_i) at several distances */
    for (int i = 0; i < 4; i++)
        fset(f, k++, (double[3]){-pow(10.0, -3 + 2 * i), 0, 0}, up, graze);
    /* mu0 crossing 0: n_i tilted so that n_o . w12 sweeps through 0, x_i very close */
    for (int i = 0; i <= 40; i++) {
        const double a = (i - 20) * (M_PI / 2.0) / 20.0; /* -90 .. 90 deg */
        const double ni[3] = {sin(a), 0.0, cos(a)};
        fset(f, k++, (double[3]){1e-4, 0, 0}, ni, ni);
    }
    /* a finer sweep around the crossing itself (n_i at ~90 deg to n_o) */
    for (int i = 0; i <= 20; i++) {
        const double a = M_PI / 2.0 + (i - 10) * 1e-4;
        const double ni[3] = {sin(a), 0.0, cos(a)};
        const double wi[3] = {sin(a), 0.0, cos(a)};
        fset(f, k++, (double[3]){(i - 10) * 1e-7, 0, 0}, ni, wi);
    }
    return k;
}

static sss_material hard_material(int i, double *mm_per_unit)
{
    *mm_per_unit = 1.0;
    switch (i) {
    case 0: return *sss_preset(preset_index("Potato"));
    case 1: return *sss_preset(preset_index("Marble"));
    case 2: return mat_of("eta1", 0.99, 0.9, 0.5, 0.01, 0.1, 0.5, 0.0, 1.0);
    case 3: return mat_of("eta0.7", 0.99, 0.9, 0.5, 0.01, 0.1, 0.5, 0.0, 0.7);
    case 4: return mat_of("alpha0", 1e-12, 0.0, 1e-30, 1.0, 1.0, 1.0, 0.0, 1.3); /* alpha' -> 0 and = 0 */
    case 5: return *sss_preset(preset_index("Spectralon"));                    /* alpha' = 1 */
    case 6: return mat_of("huge", 1e6, 1e6, 1e6, 1e6, 1.0, 1e-3, 0.0, 1.3);     /* 1e6 per mm */
    case 7: *mm_per_unit = 1000.0; return *sss_preset(preset_index("Ketchup")); /* metres */
    case 8: return mat_of("g0.9", 10.0, 10.0, 10.0, 0.01, 0.1, 1.0, 0.9, 1.3);
    default: return mat_of("eta2", 1.0, 1.0, 1.0, 0.01, 0.1, 1.0, -0.5, 2.0);
    }
}
#define HARD_MATERIALS 10

/* Finite, non-negative S_d (double and both float paths, both models) in the hard cases */
TEST(sss_hard_cases_are_finite_and_non_negative)
{
    fbatch f;
    fbatch_alloc(&f, 256);
    for (int mi = 0; mi < HARD_MATERIALS; mi++) {
        double mpu;
        const sss_material m = hard_material(mi, &mpu);
        sss_constants c;
        CHECK_OK(sss_constants_make(NULL, &m, mpu, &c), NULL);
        const int n = fill_hard_cases(&f, &c);
        CHECK(n <= 256);
        f.n = n;
        for (int model = 0; model < SSS_MODEL_COUNT; model++) {
            sss_gpu_constants g;
            sss_gpu_constants_make(&c, (sss_model)model, &g);
            for (int isa = SSS_ISA_SCALAR; isa < SSS_ISA_COUNT; isa++) {
                if (!sss_isa_available((sss_isa)isa))
                    continue;
                for (int t12 = 0; t12 < 2; t12++) {
                    sss_batch b = fbatch_view(&f, f.out);
                    CHECK_OK(sss_eval_batch(NULL, &g, f.xo, f.no, &b, t12, (sss_isa)isa), NULL);
                    for (int k = 0; k < n; k++)
                        for (int ch = 0; ch < 3; ch++) {
                            const float v = f.out[ch][k];
                            CHECK_MSG(isfinite(v) && v >= 0.0f, "%s model %d isa %d t12 %d case %d ch %d: float %g",
                                      m.name, model, isa, t12, k, ch, (double)v);
                            const double d = ref_at(&c, (sss_model)model, ch, &f, k, t12);
                            CHECK_MSG(isfinite(d) && d >= 0.0, "%s model %d case %d ch %d: double %g", m.name, model,
                                      k, ch, d);
                        }
                }
            }
        }
        /* the back-lit slab transmits: S_d > 0 through 1 mm of potato (case 8) */
        if (mi == 0) {
            CHECK(ref_at(&c, SSS_MODEL_DIRECTIONAL, 0, &f, 8, 1) > 0.0);
            CHECK(ref_at(&c, SSS_MODEL_STANDARD, 0, &f, 8, 1) > 0.0);
        }
        /* eta = 0.7: the TIR direction's T12 is 0, so the product is exactly 0 */
        if (mi == 3) {
            sss_gpu_constants g;
            sss_gpu_constants_make(&c, SSS_MODEL_DIRECTIONAL, &g);
            sss_batch b = fbatch_view(&f, f.out);
            CHECK_OK(sss_eval_batch(NULL, &g, f.xo, f.no, &b, 1, SSS_ISA_SCALAR), NULL);
            CHECK(f.out[0][13] == 0.0f && ref_at(&c, SSS_MODEL_DIRECTIONAL, 0, &f, 13, 1) == 0.0);
        }
        /* alpha' = 0 (the G channel of "alpha0") gives exactly 0 */
        if (mi == 4) {
            const double xi[3] = {0.1, 0, 0}, n[3] = {0, 0, 1}, xo[3] = {0, 0, 0};
            CHECK(sss_sd(&c, SSS_MODEL_DIRECTIONAL, 1, xi, n, n, xo, n) == 0.0);
            CHECK(sss_sd(&c, SSS_MODEL_STANDARD, 1, xi, n, n, xo, n) == 0.0);
        }
    }
    /* random geometry with every hard material, double path */
    for (int mi = 0; mi < HARD_MATERIALS; mi++) {
        double mpu;
        const sss_material m = hard_material(mi, &mpu);
        const sss_constants c = consts_of(&m, mpu);
        f.n = 256;
        fill_random_sphere(&f, 5.0, M_PI, 7);
        for (int k = 0; k < f.n; k++)
            for (int model = 0; model < SSS_MODEL_COUNT; model++)
                for (int ch = 0; ch < 3; ch++) {
                    const double d = ref_at(&c, (sss_model)model, ch, &f, k, 1);
                    CHECK_MSG(isfinite(d) && d >= 0.0, "%s random %d: %g", m.name, k, d);
                }
    }
    fbatch_free(&f);
}

/* The AVX2 path gives the scalar float path's bits: random geometry (near and far, grazing and
 * below-surface light), the hard cases, every hard material, both models, with and without T12,
 * batch sizes that are not multiples of 8 */
TEST(sss_batch_avx2_matches_scalar_bit_for_bit)
{
    if (!sss_isa_available(SSS_ISA_AVX2)) {
        printf("AVX2 not available: nothing to compare\n");
        return;
    }
    fbatch f;
    fbatch_alloc(&f, 1027);
    float *o2[3];
    for (int t = 0; t < 3; t++)
        o2[t] = calloc(1027, sizeof(float));
    long compared = 0;
    for (int mi = 0; mi < HARD_MATERIALS; mi++) {
        double mpu;
        const sss_material m = hard_material(mi, &mpu);
        const sss_constants c = consts_of(&m, mpu);
        for (int rep = 0; rep < 6; rep++) {
            if (rep == 0) {
                f.n = fill_hard_cases(&f, &c);
            } else {
                f.n = 1027 - rep;
                const double R = mpu == 1.0 ? (rep & 1 ? 5.0 : 50.0) : 0.02;
                fill_random_sphere(&f, R, rep < 3 ? 0.3 : M_PI, 11);
            }
            for (int model = 0; model < SSS_MODEL_COUNT; model++) {
                sss_gpu_constants g;
                sss_gpu_constants_make(&c, (sss_model)model, &g);
                for (int t12 = 0; t12 < 2; t12++) {
                    sss_batch bs = fbatch_view(&f, f.out), bv = fbatch_view(&f, o2);
                    CHECK_OK(sss_eval_batch(NULL, &g, f.xo, f.no, &bs, t12, SSS_ISA_SCALAR), NULL);
                    CHECK_OK(sss_eval_batch(NULL, &g, f.xo, f.no, &bv, t12, SSS_ISA_AVX2), NULL);
                    for (int ch = 0; ch < 3; ch++)
                        for (int k = 0; k < f.n; k++) {
                            CHECK_MSG(!memcmp(&f.out[ch][k], &o2[ch][k], sizeof(float)),
                                      "%s model %d t12 %d rep %d k %d ch %d: scalar %.9g avx2 %.9g", m.name, model,
                                      t12, rep, k, ch, (double)f.out[ch][k], (double)o2[ch][k]);
                            compared++;
                        }
                }
            }
        }
    }
    printf("%ld values compared, all identical\n", compared);
    for (int t = 0; t < 3; t++)
        free(o2[t]);
    fbatch_free(&f);
}

/* The float batch against the double reference at the same (float) inputs, on random geometry
 * (spheres of 5 and 30 mm, all presets and eta 1, 0.7, g 0.9; light from anywhere, 10% below the
 * surface). Bound: |float - double| <= FLOAT_VS_DOUBLE_REL |double| + 1e-6 peak, where peak is the
 * channel's S_d at x_o = x_i under normal incidence. Measured (printed): max relative error 3.0e-4
 * on values above 1e-4 peak; below that the real and virtual terms cancel and the error is
 * < 6e-8 peak. Not covered: inputs within float rounding of a discontinuity (mu0 = 0, the n_i*
 * guard's threshold), where the two may take different branches (docs/sss/model.md). */
#define FLOAT_VS_DOUBLE_REL 1e-3
TEST(sss_batch_float_agrees_with_double_reference)
{
    fbatch f;
    fbatch_alloc(&f, 4096);
    double worst_rel = 0.0, worst_abs = 0.0;
    for (int i = 0; i < sss_preset_count() + 3; i++) {
        sss_material m;
        if (i < sss_preset_count())
            m = *sss_preset(i);
        else
            m = mat_of(i == 12 ? "eta1" : i == 13 ? "eta0.7" : "g0.9", 0.99, 0.9, 0.5, 0.01, 0.1, 0.5,
                       i == 14 ? 0.9 : 0.0, i == 12 ? 1.0 : i == 13 ? 0.7 : 1.3);
        const sss_constants c = consts_of(&m, 1.0);
        for (int model = 0; model < SSS_MODEL_COUNT; model++) {
            sss_gpu_constants g;
            sss_gpu_constants_make(&c, (sss_model)model, &g);
            double peak[3];
            for (int ch = 0; ch < 3; ch++) {
                const double z[3] = {0, 0, 0}, n[3] = {0, 0, 1};
                peak[ch] = sss_sd(&c, (sss_model)model, ch, z, n, n, z, n);
            }
            for (int rep = 0; rep < 2; rep++) {
                fill_random_sphere(&f, rep ? 30.0 : 5.0, rep ? 0.5 : M_PI, 0);
                sss_batch b = fbatch_view(&f, f.out);
                CHECK_OK(sss_eval_batch(NULL, &g, f.xo, f.no, &b, 1, SSS_ISA_AUTO), NULL);
                for (int k = 0; k < f.n; k++)
                    for (int ch = 0; ch < 3; ch++) {
                        const double d = ref_at(&c, (sss_model)model, ch, &f, k, 1);
                        const double v = f.out[ch][k];
                        const double ad = fabs(v - d);
                        if (d <= 1e-4 * peak[ch] && ad / peak[ch] > worst_abs)
                            worst_abs = ad / peak[ch];
                        CHECK_MSG(ad <= 1e-6 * peak[ch] + FLOAT_VS_DOUBLE_REL * d,
                                  "%s model %d ch %d: %.9g vs %.9g (peak %.3g) at %s", m.name, model, ch, v, d,
                                  peak[ch], describe(&f, k));
                        if (d > 1e-4 * peak[ch]) {
                            const double rel = ad / d;
                            if (rel > worst_rel)
                                worst_rel = rel;
                            CHECK_MSG(rel <= FLOAT_VS_DOUBLE_REL, "%s model %d ch %d: %.9g vs %.9g (rel %.3g) at %s",
                                      m.name, model, ch, v, d, rel, describe(&f, k));
                        }
                    }
            }
        }
    }
    printf("float vs double: max relative error %.3g (values > 1e-4 peak), max error / peak %.3g "
           "(values <= 1e-4 peak)\n",
           worst_rel, worst_abs);
    fbatch_free(&f);
}

/* ---- 4. presets, validation, extras ------------------------------------------------------------------ */

TEST(sss_presets_are_jensen_table)
{
    static const char *names[12] = {"Apple",  "Chicken1", "Chicken2", "Cream",    "Ketchup",    "Marble",
                                    "Potato", "Skimmilk", "Skin1",    "Skin2",    "Spectralon", "Wholemilk"};
    CHECK_EQ_INT(sss_preset_count(), 12);
    CHECK(sss_preset(-1) == NULL && sss_preset(12) == NULL);
    for (int i = 0; i < 12; i++) {
        CHECK(!strcmp(sss_preset(i)->name, names[i]));
        CHECK_OK(sss_material_validate(NULL, sss_preset(i), "preset"), NULL);
        CHECK(sss_preset(i)->g == 0.0);
    }
    /* the corrected entries (sss.md 2 "known corrupted copies") */
    CHECK(sss_preset(1)->sigma_a[0] == 0.015 && sss_preset(2)->sigma_a[0] == 0.018 &&
          sss_preset(0)->sigma_a[2] == 0.046);
    obs_context *ctx = obs_context_create();
    sss_material m;
    CHECK_OK(sss_material_find(ctx, "cream", &m), ctx);
    CHECK(!strcmp(m.name, "Cream") && m.sigma_s[0] == 7.38);
    CHECK_OK(sss_material_find(ctx, "SKIN1", &m), ctx);
    CHECK(!strcmp(m.name, "Skin1"));
    CHECK_EQ_INT(sss_material_find(ctx, "jelly", &m), OBS_STATUS_NOT_FOUND);
    const char *msg = obs_context_last_error(ctx);
    CHECK_MSG(strstr(msg, "jelly") && strstr(msg, "Apple") && strstr(msg, "Wholemilk"), "message: %s", msg);
    obs_context_destroy(ctx);
}

TEST(sss_presets_match_the_json_table)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/data/materials/jensen2001.json", OBS_TEST_SOURCE_DIR);
    char *text = test_slurp(path, NULL);
    CHECK_MSG(text, "cannot read %s", path);
    cJSON *root = cJSON_Parse(text);
    free(text);
    CHECK(root);
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(root, "materials");
    CHECK(cJSON_IsArray(mats));
    CHECK_EQ_INT(cJSON_GetArraySize(mats), sss_preset_count());
    for (int i = 0; i < sss_preset_count(); i++) {
        const cJSON *o = cJSON_GetArrayItem(mats, i);
        const sss_material *p = sss_preset(i);
        double rd[3];
        sss_preset_measured_rd(i, rd);
        CHECK(!strcmp(cJSON_GetObjectItemCaseSensitive(o, "name")->valuestring, p->name));
        CHECK(cJSON_GetObjectItemCaseSensitive(o, "eta")->valuedouble == p->eta);
        for (int j = 0; j < 3; j++) {
            CHECK(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(o, "sigma_s_prime"), j)->valuedouble ==
                  p->sigma_s[j]);
            CHECK(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(o, "sigma_a"), j)->valuedouble == p->sigma_a[j]);
            CHECK(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(o, "rd"), j)->valuedouble == rd[j]);
        }
    }
    cJSON_Delete(root);
}

TEST(sss_bad_materials_are_refused)
{
    obs_context *ctx = obs_context_create();
    const sss_material good = *sss_preset(6);
    static const struct {
        int field; /* 0 sigma_s, 1 sigma_a, 2 g, 3 eta, 4 sigma_t = 0 */
        double v;
        const char *expect;
    } bad[] = {{0, -1.0, "sigma_s[1]"}, {0, NAN, "sigma_s[1]"}, {0, INFINITY, "sigma_s[1]"},
               {1, -0.1, "sigma_a[1]"}, {1, NAN, "sigma_a[1]"}, {1, -INFINITY, "sigma_a[1]"},
               {2, 1.0, "g"},           {2, -1.0, "g"},         {2, NAN, "g"},
               {3, 0.0, "eta"},         {3, -1.3, "eta"},       {3, INFINITY, "eta"},
               {3, NAN, "eta"},         {4, 0.0, "sigma_t[1]"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        sss_material m = good;
        switch (bad[i].field) {
        case 0: m.sigma_s[1] = bad[i].v; break;
        case 1: m.sigma_a[1] = bad[i].v; break;
        case 2: m.g = bad[i].v; break;
        case 3: m.eta = bad[i].v; break;
        default: m.sigma_s[1] = 0.0; m.sigma_a[1] = 0.0; break;
        }
        obs_context_clear_error(ctx);
        CHECK_EQ_INT(sss_material_validate(ctx, &m, "scene.gltf"), OBS_STATUS_INVALID_ARGUMENT);
        const char *msg = obs_context_last_error(ctx);
        CHECK_MSG(strstr(msg, "scene.gltf") && strstr(msg, bad[i].expect), "case %zu: %s", i, msg);
        sss_constants c;
        obs_context_clear_error(ctx);
        CHECK_EQ_INT(sss_constants_make(ctx, &m, 1.0, &c), OBS_STATUS_INVALID_ARGUMENT);
    }
    sss_constants c;
    /* eta valid for sss_material_validate but outside the fits' range ([0.352, 2.843]:
     * C_phi(eta), C_phi(1/eta) > 0 and 0 < C_E < 1) is refused by the constants step */
    for (int i = 0; i < 2; i++) {
        sss_material m = good;
        m.eta = i ? 3.0 : 0.3;
        CHECK_OK(sss_material_validate(ctx, &m, NULL), ctx);
        obs_context_clear_error(ctx);
        CHECK_EQ_INT(sss_constants_make(ctx, &m, 1.0, &c), OBS_STATUS_INVALID_ARGUMENT);
        CHECK(strstr(obs_context_last_error(ctx), "eta"));
        m.eta = i ? 2.8 : 0.36;
        CHECK_OK(sss_constants_make(ctx, &m, 1.0, &c), ctx);
    }
    CHECK_EQ_INT(sss_constants_make(ctx, &good, 0.0, &c), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(sss_constants_make(ctx, &good, NAN, &c), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(sss_constants_make(ctx, &good, -1.0, &c), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(sss_material_validate(ctx, NULL, NULL), OBS_STATUS_INVALID_ARGUMENT);
    obs_context_destroy(ctx);
}

TEST(sss_extras_schema_parses_and_refuses_bad_input)
{
    obs_context *ctx = obs_context_create();
    sss_material m;
    int found = -1;
    /* no member, not an object, NULL: found = 0, OK */
    CHECK_OK(sss_material_from_extras(ctx, "{\"other\": 1}", "a.gltf", &m, &found), ctx);
    CHECK(found == 0);
    CHECK_OK(sss_material_from_extras(ctx, "[1, 2]", "a.gltf", &m, &found), ctx);
    CHECK(found == 0);
    CHECK_OK(sss_material_from_extras(ctx, NULL, "a.gltf", &m, &found), ctx);
    CHECK(found == 0);
    /* preset, with and without a name */
    CHECK_OK(sss_material_from_extras(ctx, "{\"obscura_sss\": {\"preset\": \"cream\"}}", "a.gltf", &m, &found), ctx);
    CHECK(found == 1 && !strcmp(m.name, "Cream"));
    CHECK_OK(sss_material_from_extras(ctx, "{\"obscura_sss\": {\"preset\": \"Potato\", \"name\": \"spud\"}}", "a.gltf",
                                      &m, &found),
             ctx);
    CHECK(found == 1 && !strcmp(m.name, "spud") && m.sigma_a[2] == 0.12);
    /* reduced coefficients */
    CHECK_OK(sss_material_from_extras(
                 ctx, "{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0.1, 0.2, 0.3], \"eta\": 1.4}}",
                 "a.gltf", &m, &found),
             ctx);
    CHECK(found == 1 && m.sigma_s[2] == 3.0 && m.g == 0.0 && m.eta == 1.4 && m.sigma_a[1] == 0.2);
    /* sigma_s with g */
    CHECK_OK(sss_material_from_extras(
                 ctx,
                 "{\"obscura_sss\": {\"sigma_s\": [10, 20, 30], \"g\": 0.8, \"sigma_a\": [0, 0.2, 0.3], \"eta\": 1.3, "
                 "\"name\": \"x\"}}",
                 "a.gltf", &m, &found),
             ctx);
    CHECK(found == 1 && m.sigma_s[0] == 10.0 && m.g == 0.8 && !strcmp(m.name, "x"));

    static const struct {
        const char *json;
        obs_status st;
        const char *key;
    } bad[] = {
        {"{\"obscura_sss\": {\"preset\": \"cream\"", OBS_STATUS_PARSE_ERROR, "not valid JSON"},
        {"{\"obscura_sss\": 3}", OBS_STATUS_INVALID_ARGUMENT, "obscura_sss"},
        {"{\"obscura_sss\": {\"preset\": \"jelly\"}}", OBS_STATUS_INVALID_ARGUMENT, "preset"},
        {"{\"obscura_sss\": {\"preset\": 3}}", OBS_STATUS_INVALID_ARGUMENT, "preset"},
        {"{\"obscura_sss\": {\"preset\": \"cream\", \"eta\": 1.3}}", OBS_STATUS_INVALID_ARGUMENT, "preset"},
        {"{\"obscura_sss\": {\"preset\": \"cream\", \"colour\": 1}}", OBS_STATUS_INVALID_ARGUMENT, "colour"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2], \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_s_prime"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3, 4], \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_s_prime"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, \"2\", 3], \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_s_prime[1]"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": 1, \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_s_prime"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, -1, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_a[1]"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 1e999, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_a[1]"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": 0}}",
         OBS_STATUS_INVALID_ARGUMENT, "eta"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": -1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "eta"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": \"1.3\"}}",
         OBS_STATUS_INVALID_ARGUMENT, "eta"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0]}}", OBS_STATUS_INVALID_ARGUMENT,
         "eta"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"eta\": 1.3}}", OBS_STATUS_INVALID_ARGUMENT, "sigma_a"},
        {"{\"obscura_sss\": {\"sigma_a\": [1, 2, 3], \"eta\": 1.3}}", OBS_STATUS_INVALID_ARGUMENT, "sigma_s"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_s\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": "
         "1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_s"},
        {"{\"obscura_sss\": {\"sigma_s\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "obscura_sss.g"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"g\": 0.5, \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "obscura_sss.g"},
        {"{\"obscura_sss\": {\"sigma_s\": [1, 2, 3], \"g\": 1.0, \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "obscura_sss.g"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 0, 3], \"sigma_a\": [0, 0, 0], \"eta\": 1.3}}",
         OBS_STATUS_INVALID_ARGUMENT, "sigma_t[1]"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": 1.3, \"name\": 5}}",
         OBS_STATUS_INVALID_ARGUMENT, "name"},
        {"{\"obscura_sss\": {\"sigma_s_prime\": [1, 2, 3], \"sigma_a\": [0, 0, 0], \"eta\": 1.3, \"Eta\": 1}}",
         OBS_STATUS_INVALID_ARGUMENT, "Eta"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        obs_context_clear_error(ctx);
        found = -1;
        const obs_status st = sss_material_from_extras(ctx, bad[i].json, "mesh.gltf material 2", &m, &found);
        const char *msg = obs_context_last_error(ctx);
        CHECK_MSG(st == bad[i].st, "case %zu: status %s, message %s", i, obs_status_string(st), msg);
        CHECK_MSG(found == 0, "case %zu: found %d", i, found);
        CHECK_MSG(strstr(msg, "mesh.gltf material 2") && strstr(msg, bad[i].key), "case %zu: %s", i, msg);
    }
    obs_context_destroy(ctx);
}

TEST(sss_model_and_isa_names_round_trip)
{
    sss_model m;
    CHECK(sss_model_from_name("directional", &m) && m == SSS_MODEL_DIRECTIONAL);
    CHECK(sss_model_from_name("standard", &m) && m == SSS_MODEL_STANDARD);
    CHECK(!sss_model_from_name("better", &m) && !sss_model_from_name(NULL, &m));
    CHECK(!strcmp(sss_model_name(SSS_MODEL_STANDARD), "standard"));
    CHECK(!strcmp(sss_isa_name(SSS_ISA_AVX2), "avx2") && !strcmp(sss_isa_name(SSS_ISA_SCALAR), "scalar"));
    CHECK(sss_isa_available(SSS_ISA_SCALAR) && sss_isa_available(SSS_ISA_AUTO));
    /* bad batch arguments */
    const sss_constants c = consts_of(sss_preset(6), 1.0);
    sss_gpu_constants g;
    sss_gpu_constants_make(&c, SSS_MODEL_DIRECTIONAL, &g);
    CHECK(g.model == 0.0f && g.eta == 1.3f && g.sigma_tr[3] == 0.0f);
    const float xo[3] = {0, 0, 0}, no[3] = {0, 0, 1};
    sss_batch b;
    memset(&b, 0, sizeof b);
    b.n = -1;
    CHECK_EQ_INT(sss_eval_batch(NULL, &g, xo, no, &b, 1, SSS_ISA_SCALAR), OBS_STATUS_INVALID_ARGUMENT);
    b.n = 0;
    CHECK_EQ_INT(sss_eval_batch(NULL, &g, xo, no, &b, 1, SSS_ISA_SCALAR), OBS_STATUS_OK);
    b.n = 3;
    CHECK_EQ_INT(sss_eval_batch(NULL, &g, xo, no, &b, 1, SSS_ISA_SCALAR), OBS_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(sss_eval_batch(NULL, NULL, xo, no, &b, 1, SSS_ISA_SCALAR), OBS_STATUS_INVALID_ARGUMENT);
    if (!sss_isa_available(SSS_ISA_AVX2)) {
        float v[3] = {0};
        sss_batch one = {1, {v, v, v}, {v, v, v}, {v, v, v}, {v, v, v}};
        CHECK_EQ_INT(sss_eval_batch(NULL, &g, xo, no, &one, 1, SSS_ISA_AVX2), OBS_STATUS_UNSUPPORTED_ISA);
    }
}
