/* sss_batch.c: the float batch evaluation of S_d (the scattering maps' kernel): float constants,
 * ISA dispatch and the scalar float path.
 *
 * Lanes are incidence samples k = 0..n-1 (structure of arrays); the exit point (x_o, n_o) is
 * shared. The kernel is the double reference of sss_dipole.c (same steps, same guards, same
 * citations) written as a plain sequence of IEEE float operations (sss_internal.h): +, -, *, /,
 * sqrtf, compares and selects, MAXPS-style max/min, and the kernel's own exp (sss_i_expf).
 * sss_batch_avx2.c runs the same operations in the same order on 8 samples at a time, so the two
 * paths give identical bits (test sss_batch_avx2_matches_scalar_bit_for_bit). A GLSL port of
 * this file reproduces it within rounding (GLSL's sqrt and division need not be correctly
 * rounded). */
#include "sss_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- ISA ----------------------------------------------------------------------------------------- */

static const char *const sss_isa_names[SSS_ISA_COUNT] = {"auto", "scalar", "avx2"};

const char *sss_isa_name(sss_isa isa)
{
    return (unsigned)isa < SSS_ISA_COUNT ? sss_isa_names[isa] : "unknown";
}

int sss_isa_available(sss_isa isa)
{
    switch (isa) {
    case SSS_ISA_AUTO:
    case SSS_ISA_SCALAR:
        return 1;
    case SSS_ISA_AVX2:
#if defined(OBS_HAVE_AVX2) && (defined(__x86_64__) || defined(__i386__))
        return __builtin_cpu_supports("avx2") ? 1 : 0;
#else
        return 0;
#endif
    default:
        return 0;
    }
}

/* ---- Float constants ------------------------------------------------------------------------------- */

void sss_gpu_constants_make(const sss_constants *c, sss_model model, sss_gpu_constants *out)
{
    if (!c || !out)
        return;
    memset(out, 0, sizeof *out);
    for (int j = 0; j < 3; j++) {
        const sss_channel *h = &c->ch[j];
        out->sigma_tr[j] = (float)h->sigma_tr;
        out->D[j] = (float)h->D;
        out->d_e[j] = (float)h->d_e;
        out->two_a_de[j] = (float)h->two_a_de;
        out->backlit_d2[j] = (float)h->backlit_d2;
        out->z_r[j] = (float)h->z_r;
        out->z_v[j] = (float)h->z_v;
        out->alpha_p[j] = (float)h->alpha_p;
    }
    out->c_phi = (float)c->c_phi;
    out->c_e = (float)c->c_e;
    out->norm_dir = (float)c->norm_dir;
    out->eta = (float)c->eta;
    out->inv_eta = (float)(1.0 / c->eta);
    out->model = model == SSS_MODEL_STANDARD ? 1.0f : 0.0f;
}

/* ---- The scalar float kernel ------------------------------------------------------------------------ */

static inline float dotf(float a0, float a1, float a2, float b0, float b1, float b2)
{
    return (a0 * b0 + a1 * b1) + a2 * b2;
}

/* T12 = 1 - F(cos_i, eta): sss_fresnel_reflectance in float (cos clamped to [0, 1], F = 1 on
 * total internal reflection); sss.md 1.2 "Fresnel at entry and exit". */
static inline float t12f(float cos_raw, float eta)
{
    float c = sss_i_maxf(cos_raw, 0.0f);
    c = sss_i_minf(c, 1.0f);
    const float eta2 = eta * eta;
    const float cos2_t = ((eta2 - 1.0f) + c * c) / eta2; /* 1 - sin_t^2, as sss_fresnel_reflectance */
    if (cos2_t <= 0.0f)
        return 0.0f;
    const float cos_t = sqrtf(cos2_t);
    const float rs = (c - eta * cos_t) / (c + eta * cos_t);
    const float rp = (eta * c - cos_t) / (eta * c + cos_t);
    return 1.0f - 0.5f * (rs * rs + rp * rp);
}

/* S'_d(x, w, r) without the normaliser ([Frisvad14], sss.md 1.2; the double sp_d of sss_dipole.c) */
static inline float spf(float sigma_tr, float D, float c_phi, float c_e, float x0, float x1, float x2, float w0,
                        float w1, float w2, float r, float n0, float n1, float n2)
{
    const float s = sigma_tr * r;
    const float one_p = 1.0f + s;
    const float x_w = dotf(x0, x1, x2, w0, w1, w2);
    const float x_no = dotf(x0, x1, x2, n0, n1, n2);
    const float w_no = dotf(w0, w1, w2, n0, n1, n2);
    const float D3 = 3.0f * D;
    const float t_phi = c_phi * (r * r / D + (3.0f * one_p) * x_w);
    const float t_e = c_e * ((D3 * one_p) * w_no - (one_p + ((D3 * (3.0f * one_p + s * s)) / (r * r)) * x_w) * x_no);
    const float e = sss_i_expf(-s);
    return (e / ((r * r) * r)) * (t_phi - t_e);
}

void sss_i_eval_scalar(const sss_gpu_constants *g, const float xo[3], const float no[3], const sss_batch *b,
                       int with_t12, int begin, int end)
{
    const float eta = g->eta;
    const float eta2 = eta * eta;
    const float norm_k = g->norm_dir * (float)SSS_I_INV_4PI2;
    const int standard = g->model != 0.0f;
    for (int k = begin; k < end; k++) {
        const float xi0 = b->xi[0][k], xi1 = b->xi[1][k], xi2 = b->xi[2][k];
        const float ni0 = b->ni[0][k], ni1 = b->ni[1][k], ni2 = b->ni[2][k];
        const float wi0 = b->wi[0][k], wi1 = b->wi[1][k], wi2 = b->wi[2][k];
        /* x = x_o - x_i, r = |x| */
        const float x0 = xo[0] - xi0, x1 = xo[1] - xi1, x2 = xo[2] - xi2;
        const float r2 = dotf(x0, x1, x2, x0, x1, x2);
        const float cos_i = dotf(wi0, wi1, wi2, ni0, ni1, ni2);
        const float T = with_t12 ? t12f(cos_i, eta) : 1.0f;

        if (standard) {
            /* [Jensen01] eq. 4 corrected (sss.md 2), S_d = R_d(r)/pi */
            for (int c = 0; c < 3; c++) {
                float v = 0.0f;
                if (g->alpha_p[c] != 0.0f) {
                    const float st = g->sigma_tr[c], zr = g->z_r[c], zv = g->z_v[c];
                    const float dr = sqrtf(r2 + zr * zr);
                    const float dv = sqrtf(r2 + zv * zv);
                    const float sr = st * dr, sv = st * dv;
                    const float real = ((zr * (1.0f + sr)) * sss_i_expf(-sr)) / ((dr * dr) * dr);
                    const float virt = ((zv * (1.0f + sv)) * sss_i_expf(-sv)) / ((dv * dv) * dv);
                    v = T * ((g->alpha_p[c] * (float)SSS_I_INV_4PI2) * (real + virt));
                }
                b->out[c][k] = v;
            }
            continue;
        }

        /* [Frisvad14] directional dipole: the steps of sss_dipole.c sd_directional */
        const float r = sqrtf(r2);
        /* w12 = refract(w_i), TIR-clamped (sss.md 1.2, 1.3) */
        const float kk = sss_i_maxf(((eta2 - 1.0f) + cos_i * cos_i) / eta2, 0.0f);
        const float a = (-cos_i) / eta + sqrtf(kk);
        float w0 = (-wi0) / eta - ni0 * a, w1 = (-wi1) / eta - ni1 * a, w2 = (-wi2) / eta - ni2 * a;
        const float wl = sqrtf(dotf(w0, w1, w2, w0, w1, w2));
        w0 = w0 / wl;
        w1 = w1 / wl;
        w2 = w2 / wl;
        /* n_i*, guarded (sss.md 1.3) */
        const float c0 = ni1 * x2 - ni2 * x1, c1 = ni2 * x0 - ni0 * x2, c2 = ni0 * x1 - ni1 * x0;
        const float cl = sqrtf(dotf(c0, c1, c2, c0, c1, c2));
        float s0 = ni0, s1 = ni1, s2 = ni2;
        if (cl > (float)SSS_I_PARALLEL_EPS * r) {
            const float h0 = x0 / r, h1 = x1 / r, h2 = x2 / r;
            const float e0 = c0 / cl, e1 = c1 / cl, e2 = c2 / cl;
            s0 = h1 * e2 - h2 * e1;
            s1 = h2 * e0 - h0 * e2;
            s2 = h0 * e1 - h1 * e0;
        }
        /* mu0 = -(n_o . w12) */
        const float mu0 = -dotf(no[0], no[1], no[2], w0, w1, w2);
        const float x_w12 = dotf(x0, x1, x2, w0, w1, w2);
        /* w_v = w12 - 2 (w12 . n_i*) n_i* */
        const float wn2 = 2.0f * dotf(w0, w1, w2, s0, s1, s2);
        const float v0 = w0 - wn2 * s0, v1 = w1 - wn2 * s1, v2 = w2 - wn2 * s2;
        const float num = sss_i_maxf(r2 - x_w12 * x_w12, 0.0f);
        for (int c = 0; c < 3; c++) {
            float out = 0.0f;
            if (g->alpha_p[c] != 0.0f) {
                const float D = g->D[c], de = g->d_e[c], st = g->sigma_tr[c];
                const float floor_d = (float)SSS_I_DIST_FLOOR_D * D;
                float dr;
                if (mu0 > 0.0f) {
                    const float cos_beta = -sqrtf(num / (r2 + de * de));
                    const float Dmu0 = D * mu0;
                    dr = sqrtf(r2 + Dmu0 * (Dmu0 - (2.0f * de) * cos_beta));
                } else {
                    dr = sqrtf(r2 + g->backlit_d2[c]);
                }
                dr = sss_i_maxf(dr, floor_d);
                const float ad = g->two_a_de[c];
                const float y0 = x0 - ad * s0, y1 = x1 - ad * s1, y2 = x2 - ad * s2;
                const float dv = sss_i_maxf(sqrtf(dotf(y0, y1, y2, y0, y1, y2)), floor_d);
                const float sr = spf(st, D, g->c_phi, g->c_e, x0, x1, x2, w0, w1, w2, dr, no[0], no[1], no[2]);
                const float sv = spf(st, D, g->c_phi, g->c_e, y0, y1, y2, v0, v1, v2, dv, no[0], no[1], no[2]);
                const float sd = sss_i_maxf(norm_k * (sr - sv), 0.0f);
                out = T * sd;
            }
            b->out[c][k] = out;
        }
    }
}

/* ---- Dispatch ------------------------------------------------------------------------------------------ */

obs_status sss_eval_batch(obs_context *ctx, const sss_gpu_constants *g, const float xo[3], const float no[3],
                          const sss_batch *b, int with_t12, sss_isa isa)
{
    if (!g || !xo || !no || !b)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_eval_batch: NULL argument");
    if (b->n < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_eval_batch: n = %d < 0", b->n);
    if ((unsigned)isa >= SSS_ISA_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_eval_batch: unknown isa %d", (int)isa);
    if (b->n == 0)
        return OBS_STATUS_OK;
    for (int t = 0; t < 3; t++)
        if (!b->xi[t] || !b->ni[t] || !b->wi[t] || !b->out[t])
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "sss_eval_batch: NULL array in the batch");
    if (isa == SSS_ISA_AVX2 && !sss_isa_available(SSS_ISA_AVX2))
        return obs_error(ctx, OBS_STATUS_UNSUPPORTED_ISA, "sss_eval_batch: AVX2 requested but %s",
#if defined(OBS_HAVE_AVX2)
                         "this CPU lacks it"
#else
                         "this build has no AVX2 path (OBS_ENABLE_SIMD=OFF)"
#endif
        );
    int use_avx2 = 0;
    if (isa == SSS_ISA_AVX2)
        use_avx2 = 1;
    else if (isa == SSS_ISA_AUTO) {
        const char *env = getenv("OBS_ISA");
        use_avx2 = !(env && !strcmp(env, "scalar")) && sss_isa_available(SSS_ISA_AVX2);
    }
    int done = 0;
#if defined(OBS_HAVE_AVX2)
    if (use_avx2) {
        const int groups = b->n / 8;
        sss_i_eval_avx2(g, xo, no, b, with_t12, 0, groups);
        done = groups * 8;
    }
#else
    (void)use_avx2;
#endif
    /* the tail (or everything) on the scalar float path: same bits */
    sss_i_eval_scalar(g, xo, no, b, with_t12, done, b->n);
    return OBS_STATUS_OK;
}
