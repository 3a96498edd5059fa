/* TEST-ONLY STUB, removed when p/bssrdf's sections 1-2 land: a minimal standard-dipole stand-in for
 * sss_constants_make / sss_sd / sss_eval_batch so that the scattering-map tests can run. Not a
 * reference for anything. */
#include "sss/sss.h"

#include <math.h>
#include <string.h>

int sss_isa_available(sss_isa isa) { return isa == SSS_ISA_AUTO || isa == SSS_ISA_SCALAR; }
const char *sss_isa_name(sss_isa isa) { return isa == SSS_ISA_AVX2 ? "avx2" : isa == SSS_ISA_SCALAR ? "scalar" : "auto"; }

double sss_fresnel_reflectance(double ci, double eta)
{
    if (ci > 1.0)
        ci = 1.0;
    if (ci < 0.0)
        ci = 0.0;
    double si2 = 1.0 - ci * ci, st2 = si2 / (eta * eta);
    if (st2 >= 1.0)
        return 1.0;
    double ct = sqrt(1.0 - st2);
    double rs = (ci - eta * ct) / (ci + eta * ct), rp = (eta * ci - ct) / (eta * ci + ct);
    return 0.5 * (rs * rs + rp * rp);
}

obs_status sss_constants_make(obs_context *ctx, const sss_material *m, double mm_per_unit, sss_constants *out)
{
    (void)ctx;
    memset(out, 0, sizeof *out);
    out->material = *m;
    out->mm_per_unit = mm_per_unit;
    out->eta = m->eta;
    double fdr = -1.440 / (m->eta * m->eta) + 0.710 / m->eta + 0.668 + 0.0636 * m->eta;
    out->f_dr = fdr;
    out->a_jensen = (1 + fdr) / (1 - fdr);
    out->min_sigma_tr = 1e300;
    for (int c = 0; c < 3; c++) {
        sss_channel *h = &out->ch[c];
        h->sigma_a = m->sigma_a[c] * mm_per_unit;
        h->sigma_s = m->sigma_s[c] * mm_per_unit;
        h->sigma_s_p = h->sigma_s * (1 - m->g);
        h->sigma_t_p = h->sigma_s_p + h->sigma_a;
        h->alpha_p = h->sigma_s_p / h->sigma_t_p;
        h->D = 1.0 / (3 * h->sigma_t_p);
        h->sigma_tr = sqrt(h->sigma_a / h->D);
        h->z_r = 1.0 / h->sigma_t_p;
        h->z_v = h->z_r + 4 * out->a_jensen * h->D;
        if (h->sigma_tr < out->min_sigma_tr)
            out->min_sigma_tr = h->sigma_tr;
    }
    return OBS_STATUS_OK;
}

void sss_gpu_constants_make(const sss_constants *c, sss_model model, sss_gpu_constants *g)
{
    memset(g, 0, sizeof *g);
    for (int i = 0; i < 3; i++) {
        g->sigma_tr[i] = (float)c->ch[i].sigma_tr;
        g->z_r[i] = (float)c->ch[i].z_r;
        g->z_v[i] = (float)c->ch[i].z_v;
        g->alpha_p[i] = (float)c->ch[i].alpha_p;
    }
    g->eta = (float)c->eta;
    g->model = (float)model;
}

static double rd(double a, double tr, double zr, double zv, double r)
{
    double dr = sqrt(r * r + zr * zr), dv = sqrt(r * r + zv * zv);
    return a / (4 * OBS_PI) *
           (zr * (1 + tr * dr) * exp(-tr * dr) / (dr * dr * dr) + zv * (1 + tr * dv) * exp(-tr * dv) / (dv * dv * dv));
}

double sss_sd(const sss_constants *c, sss_model model, int ch, const double xi[3], const double ni[3],
              const double wi[3], const double xo[3], const double no[3])
{
    (void)model; (void)ni; (void)wi; (void)no;
    double r = sqrt((xo[0] - xi[0]) * (xo[0] - xi[0]) + (xo[1] - xi[1]) * (xo[1] - xi[1]) + (xo[2] - xi[2]) * (xo[2] - xi[2]));
    const sss_channel *h = &c->ch[ch];
    return rd(h->alpha_p, h->sigma_tr, h->z_r, h->z_v, r) / OBS_PI;
}

obs_status sss_eval_batch(obs_context *ctx, const sss_gpu_constants *g, const float xo[3], const float no[3],
                          const sss_batch *b, int with_t12, sss_isa isa)
{
    (void)ctx; (void)no; (void)isa;
    for (int k = 0; k < b->n; k++) {
        float dx = xo[0] - b->xi[0][k], dy = xo[1] - b->xi[1][k], dz = xo[2] - b->xi[2][k];
        double r = sqrt((double)(dx * dx + dy * dy + dz * dz));
        double t = 1.0;
        if (with_t12) {
            double cs = (double)b->ni[0][k] * b->wi[0][k] + (double)b->ni[1][k] * b->wi[1][k] + (double)b->ni[2][k] * b->wi[2][k];
            t = 1.0 - sss_fresnel_reflectance(cs, g->eta);
        }
        for (int c = 0; c < 3; c++)
            b->out[c][k] = (float)(t * rd(g->alpha_p[c], g->sigma_tr[c], g->z_r[c], g->z_v[c], r) / OBS_PI);
    }
    return OBS_STATUS_OK;
}
