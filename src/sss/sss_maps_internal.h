/* sss_maps_internal.h: shared pieces of the scattering-map passes (sss_maps.c, sss_combine.c) and
 * the hooks tests/test_sss_maps.c uses to check the samplers. Not installed. */
#ifndef SSS_MAPS_INTERNAL_H
#define SSS_MAPS_INTERNAL_H

#include "sss.h"
#include "sss_internal.h"

#include <math.h>
#include <string.h>

/* ---- The per-texel random stream (docs/sss/maps.md, "Randomness": the exact recipe) ---------
 * Seeded with TEA [Wheeler94], 16 rounds, the key constants of Dal Corso's
 * ss_aincludes_random.glinc (the OptiX SDK's tea<16>), then advanced by the LCG
 * state = 1664525 state + 1013904223 (mod 2^32) (Numerical Recipes' constants, as the same
 * file's lcg()). A float is the TOP 24 bits of the new state times 2^-24 (the shader masks the
 * LOW 24 bits, which have short periods: a deviation, documented). uint32 operations only. */
static inline uint32_t sss_i_tea16(uint32_t v0, uint32_t v1)
{
    uint32_t s0 = 0;
    for (int n = 0; n < 16; n++) {
        s0 += 0x9e3779b9u;
        v0 += ((v1 << 4) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5) + 0xc8013ea4u);
        v1 += ((v0 << 4) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5) + 0x7e95761eu);
    }
    return v0;
}
/* The stream of texel `texel` (y * size + x), layer k, frame f of `frames`, seed:
 * state0 = tea16(tea16(texel, k * frames + f), seed_lo ^ seed_hi). */
static inline uint32_t sss_i_stream_seed(uint32_t texel, uint32_t layer_frame, uint64_t seed)
{
    return sss_i_tea16(sss_i_tea16(texel, layer_frame), (uint32_t)seed ^ (uint32_t)(seed >> 32));
}
/* The seeds of `count` consecutive texels texel0, texel0 + 1, ... (count a multiple of 8) with
 * AVX2 (sss_maps_avx2.c; the same uint32 operations, so the same values as sss_i_stream_seed). */
void sss_i_stream_seeds_avx2(uint32_t texel0, int count, uint32_t layer_frame, uint64_t seed, uint32_t *out);
static inline float sss_i_rand(uint32_t *state)
{
    *state = 1664525u * *state + 1013904223u;
    return (float)(*state >> 8) * (1.0f / 16777216.0f);
}

/* One Russian-roulette candidate ([DalCorso14] final shader, sss.md 3.4): three draws, in this
 * order: rho = R sqrt(z1), phi = 2 pi z2, zeta = z3; the disk offset is (rho cos phi, rho sin phi)
 * in the light-map plane (x right, y up). The caller accepts when zeta < exp(-sigma* |x_o - x_i|). */
static inline void sss_i_rr_offset(double R, float u1, float u2, double *ox, double *oy)
{
    double rho = R * sqrt((double)u1), phi = 2.0 * OBS_PI * (double)u2;
    *ox = rho * cos(phi);
    *oy = rho * sin(phi);
}
static inline void sss_i_rr_candidate(uint32_t *state, double R, double *ox, double *oy, double *zeta)
{
    float u1 = sss_i_rand(state), u2 = sss_i_rand(state);
    *zeta = sss_i_rand(state);
    sss_i_rr_offset(R, u1, u2, ox, oy);
}
/* The Russian-roulette pre-filter (a speed-up that changes no bit; docs/sss/maps.md "Cost"): for
 * an orthographic light map the 3D distance |x_o - x_i| is at least the in-plane distance, which
 * is at least rho - m for a margin m of half a texel diagonal plus float rounding, so the exact
 * test's p is at most exp(-sigma* (rho - m)). rho = R sqrt(u1) with u1 = (s1 >> 8) 2^-24 from the
 * candidate's first LCG state s1, so rho >= R sqrt(b / 1024) in bin b = s1 >> 22, and the
 * candidate is certainly rejected when its zeta = (s3 >> 8) 2^-24 is >= the bin's bound
 * p_b = (1 + 1e-4) exp(-sigma* (R sqrt(b / 1024) - m)) (in double), i.e. when the integer
 * s3 >> 8 >= ceil(p_b 2^24): a table of 1024 integers per material and light
 * (sss_i_rr_table_make), with m taken at its largest over the scene (the per-texel margin of the
 * first version was 0.75 texel + 1e-4 R + 1e-5 (|x_o|_inf + R); here |x_o|_inf is bounded by the
 * scene's bounds). Such candidates are skipped without their cos, sin, fetch and exp. Draws N
 * candidates (3 draws each, in order) from *state and returns how many may pass; their draws are
 * packed into u1, u2, zeta (room for N). */
/* Test hook: non-zero turns the pre-filter off (test sss_rr_prefilter_changes_no_bit). */
extern int sss_i_rr_prefilter_off;
/* Test hook: non-zero renders the K views with back faces culled (RAST_CULL_BACK). Off: culling
 * is not bit-identical in general, even on closed meshes (docs/sss/maps.md "Not done"). */
extern int sss_i_maps_cull_back;
#define SSS_I_RR_BINS 1024
typedef struct sss_i_rr_filter {
    const uint32_t *zmax;    /* SSS_I_RR_BINS bounds: reject when (s3 >> 8) >= zmax[s1 >> 22] */
    const struct sss_i_exp_disk *jd; /* the LCG's jump-ahead constants */
} sss_i_rr_filter;
/* zmax[b] = min(2^24 + 1, ceil((1 + 1e-4) exp(-sigma (R sqrt(b / 1024) - m)) 2^24)) */
void sss_i_rr_table_make(double sigma, double R, double m, uint32_t *zmax);
int sss_i_rr_prefilter(uint32_t *state, int N, const sss_i_rr_filter *f, float *u1, float *u2, float *zeta,
                       int use_avx2);
int sss_i_rr_prefilter_avx2(uint32_t *state, int groups, const sss_i_rr_filter *f, float *u1, float *u2,
                            float *zeta);

/* ---- The exponential sampler (SSS_SAMPLER_EXPONENTIAL; docs/sss/maps.md "Samplers") ----------
 * Importance sampling of the 2D density p(x) = sigma^2 e^{-sigma rho} / (2 pi Z) on the disk of
 * radius R (sigma = sigma*, T = sigma R, Z = 1 - (1 + T) e^{-T}), i.e. the radial density
 * sigma^2 rho e^{-sigma rho} / Z on [0, R] (the density Russian roulette accepts with, sss.md
 * 3.5), by inversion of its CDF F(rho) = (1 - (1 + t) e^{-t}) / Z, t = sigma rho:
 *   u1 -> w = -ln(1 - u1 Z)  (= -ln((1 - u1) + u1 (1+T) e^{-T})),
 *   t solves t - ln(1 + t) = w (Newton from t0 = w + sqrt(2 w), which lies right of the root:
 *   e^s >= 1 + s + s^2/2 with s = sqrt(2 w); g convex increasing, so the iterates decrease
 *   monotonically; 3 steps reach float precision, test sss_exponential_sampler_inverts_the_cdf),
 *   rho = min(t / sigma, R); phi = 2 pi u2.
 * Weight of a sample: 1 / (N p(x)) = 2 pi Z e^{sigma rho} / (N sigma^2) (unbiased; every sample
 * counts, none is rejected). Two draws per sample, u1 then u2, from the texel's stream.
 * The near field (sss_maps.c, docs/sss/maps.md): the 3 x 3 light-map texels around x_o's
 * projection are added exactly (value x texel area) and samples landing in them count 0.
 * Everything is plain float arithmetic (+ - * / sqrt, compares, the kernel's sss_i_expf and the
 * log below) so that the AVX2 path (sss_maps_avx2.c) gives the same bits. */
typedef struct sss_i_exp_disk {
    float sigma, R, T;       /* sigma*, the disk radius, T = sigma R (all float) */
    float q, Z;              /* q = (1 + T) e^{-T}, Z = 1 - q (from double) */
    float w0;                /* 2 pi Z / (N sigma^2) (from double) */
    uint32_t jump_a[24], jump_c[24]; /* LCG jump-ahead: state_{+k} = a_k state + c_k, k = 1..24 */
    /* the same in lane order for 8-wide groups: draw d of sample j is k = D j + d + 1 (D = 2 for
     * this sampler, 3 for the Russian-roulette pre-filter) */
    uint32_t lane2_a[2][8], lane2_c[2][8], lane3_a[3][8], lane3_c[3][8];
} sss_i_exp_disk;
void sss_i_exp_disk_make(double sigma, double R, int N, sss_i_exp_disk *d);

/* Natural log of a positive normal float: y = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m =
 * 2 atanh(s), s = (m - 1)/(m + 1), |s| <= 0.1716, series to s^9 (truncation < 1e-9), plus e ln 2
 * (ln 2 in two parts). Plain float operations (a GLSL port can follow them). */
#define SSS_I_LN2_HI 0.693145751953125f
#define SSS_I_LN2_LO 1.42860676533018704e-6f
static inline float sss_i_logf(float y)
{
    uint32_t b;
    memcpy(&b, &y, sizeof b);
    int32_t e = (int32_t)(b >> 23) - 127;
    uint32_t mb = (b & 0x007fffffu) | 0x3f800000u;
    float m;
    memcpy(&m, &mb, sizeof m);
    if (m > 1.41421356f) {
        m = m * 0.5f;
        e = e + 1;
    }
    const float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
    float p = 1.0f / 9.0f;
    p = p * s2 + 1.0f / 7.0f;
    p = p * s2 + 1.0f / 5.0f;
    p = p * s2 + 1.0f / 3.0f;
    const float lnm = (2.0f * s) + (2.0f * s) * (s2 * p);
    const float ef = (float)e;
    return ef * SSS_I_LN2_HI + (ef * SSS_I_LN2_LO + lnm);
}
/* 2 atanh(s) - 2 s = 2 (s^3/3 + s^5/5 + ... + s^15/15), for |s| <= 1/3 (truncation < 1e-9 s). */
static inline float sss_i_atanh_tail(float s)
{
    const float s2 = s * s;
    float p = 1.0f / 15.0f;
    p = p * s2 + 1.0f / 13.0f;
    p = p * s2 + 1.0f / 11.0f;
    p = p * s2 + 1.0f / 9.0f;
    p = p * s2 + 1.0f / 7.0f;
    p = p * s2 + 1.0f / 5.0f;
    p = p * s2 + 1.0f / 3.0f;
    return (2.0f * s) * (s2 * p);
}
/* g(t) = t - ln(1 + t) - w without cancellation: for t < 0.5, with s = t/(2 + t),
 * t - ln(1 + t) = t^2/(2 + t) - (2 atanh(s) - 2 s); else t - ln(1 + t) directly. */
static inline float sss_i_exp_g(float t, float w)
{
    if (t < 0.5f) {
        const float s = t / (2.0f + t);
        return ((t * t) / (2.0f + t) - sss_i_atanh_tail(s)) - w;
    }
    return (t - sss_i_logf(1.0f + t)) - w;
}
/* The radius t = sigma rho of draw u1 (see above). */
static inline float sss_i_exp_t(float u1, const sss_i_exp_disk *d)
{
    const float v = u1 * d->Z;
    float w;
    if (v <= 0.5f) {
        const float s = v / (2.0f - v); /* -ln(1 - v) = 2 atanh(v / (2 - v)) */
        w = 2.0f * s + sss_i_atanh_tail(s);
    } else {
        w = -sss_i_logf((1.0f - u1) + u1 * d->q);
    }
    float t = w + sqrtf(2.0f * w);
    for (int it = 0; it < 3; it++) {
        const float g = sss_i_exp_g(t, w);
        t = t - (g * (1.0f + t)) / sss_i_maxf(t, 1e-30f);
    }
    return sss_i_minf(sss_i_maxf(t, 0.0f), d->T);
}
/* cos and sin of 2 pi u, u in [0, 1): quadrant k = floor(4 u), a = (4 u - k) pi/2 in [0, pi/2),
 * Taylor polynomials to a^11 (sin) and a^12 (cos) (truncation < 6e-8), rotated by k pi/2. */
static inline void sss_i_sincos_2pi(float u, float *c, float *s)
{
    const float u4 = 4.0f * u;
    const int32_t k = (int32_t)u4;
    const float a = (u4 - (float)k) * 1.57079632679f, a2 = a * a;
    float ps = -1.0f / 39916800.0f;
    ps = ps * a2 + 1.0f / 362880.0f;
    ps = ps * a2 - 1.0f / 5040.0f;
    ps = ps * a2 + 1.0f / 120.0f;
    ps = ps * a2 - 1.0f / 6.0f;
    const float sa = a + a * (a2 * ps);
    float pc = 1.0f / 479001600.0f;
    pc = pc * a2 - 1.0f / 3628800.0f;
    pc = pc * a2 + 1.0f / 40320.0f;
    pc = pc * a2 - 1.0f / 720.0f;
    pc = pc * a2 + 1.0f / 24.0f;
    pc = pc * a2 - 0.5f;
    const float ca = 1.0f + a2 * pc;
    /* rotation by k quarter turns: (c, s) -> (-s, c) per turn */
    const float c1 = (k & 1) ? -sa : ca, s1 = (k & 1) ? ca : sa;
    *c = (k & 2) ? -c1 : c1;
    *s = (k & 2) ? -s1 : s1;
}
/* One sample from draws (u1, u2): disk offset (ox, oy) (x right, y up in the light-map plane)
 * and weight 1 / (N p(x)). */
static inline void sss_i_exp_sample(float u1, float u2, const sss_i_exp_disk *d, float *ox, float *oy, float *w)
{
    const float t = sss_i_exp_t(u1, d);
    const float rho = sss_i_minf(t / d->sigma, d->R);
    float c, s;
    sss_i_sincos_2pi(u2, &c, &s);
    *ox = rho * c;
    *oy = rho * s;
    *w = d->w0 * sss_i_expf(d->sigma * rho);
}
/* n samples from *state (2 draws each, in order): the scalar path, and the AVX2 path for
 * `groups` groups of 8 (sss_maps_avx2.c, same bits; defined only with OBS_HAVE_AVX2). Both
 * advance *state past the draws they used. */
void sss_i_exp_samples_scalar(uint32_t *state, int n, const sss_i_exp_disk *d, float *ox, float *oy, float *w);
void sss_i_exp_samples_avx2(uint32_t *state, int groups, const sss_i_exp_disk *d, float *ox, float *oy, float *w);
/* The exponential sampler's fetch for a directional light, AVX2, `groups` groups of 8 samples:
 * texel (int)(cx + ox ppu), (int)(cy - oy ppu) (float), kept when inside the map, not empty
 * (position x not NaN) and of instance inst; kept samples are appended in order at index n of the
 * SoA outputs (x_i, n_i, w_i = l, weight as double). Returns the new n. The same float
 * operations as the scalar loop of sss_maps.c, so the same samples. lut: 256 x 8 left-pack
 * indices (sss_i_pack_lut_make). */
typedef struct sss_i_fetch_in {
    const float *P[3], *W[3];   /* light map world positions and normals */
    const uint32_t *iid;        /* instance ids */
    ptrdiff_t pst, ist;         /* their strides */
    float cx, cy, ppu, size;
    uint32_t inst;
    float l[3];
    int bx, by, block;          /* block: samples in texels [bx, bx+3) x [by, by+3) are dropped */
    /* optional (NULL: the planes above): the same texels interleaved, one 32-byte record per
     * texel (P[0..2], W[0..2], the instance id's bits, 0), pack_w records a row, so that a
     * sample's seven values share one cache line instead of seven (sss_maps.c builds it once per
     * light and build; the values, so the bits, are the planes') */
    const uint32_t *pack;
    int pack_w;
} sss_i_fetch_in;
int sss_i_exp_fetch_dir_avx2(const sss_i_fetch_in *in, int groups, const float *ox, const float *oy,
                             const float *w, const int32_t *lut, float *xi[3], float *ni[3], float *wi[3],
                             double *wout, int n);
/* The exponential sampler's near-field block for a directional light, AVX2: the 3 x 3 light-map
 * texels from (bx, by), all inside the map, appended in row order as sss_maps.c's scalar loop
 * does (position not NaN and instance inst; wi = l, weight wgt): the first 8 texels as one
 * gathered, left-packed vector, the ninth alone. Writes up to 8 lanes from index n (the scratch
 * holds N + 9 rounded up to 8, so n <= N + 1 leaves room); returns the new n. */
int sss_i_exp_block_dir_avx2(const sss_i_fetch_in *in, double wgt, const int32_t *lut, float *xi[3], float *ni[3],
                             float *wi[3], double *wout, int n);
void sss_i_pack_lut_make(int32_t lut[256 * 8]);
/* The exponential sampler's weighted sums of one batch, AVX2: for each channel c, four partial sums
 * a_i = sum over q = i (mod 4) of w[q] o_c[q] (in increasing q), then (a0 + a1) + (a2 + a3): the
 * order of the scalar loop in sss_maps.c, one partial sum per double lane, so the same bits. */
void sss_i_wsum3_avx2(const double *w, const float *const o[3], int n, double out[3]);
/* Dispatch: AVX2 for whole groups of 8 when use_avx2, the rest scalar. */
void sss_i_exp_samples(uint32_t *state, int n, const sss_i_exp_disk *d, float *ox, float *oy, float *w, int use_avx2);

/* ---- The N-of-M candidate set: M Halton (2,3) points on the disk of radius 1 ----------------
 * [DalCorso14] method.tex "planeHaltonCircleRejectionExponential" with the final code's
 * area-uniform mapping (miscellaneous.cpp haltonPointCircle): rho = sqrt(Phi_2(j)),
 * phi = 2 pi Phi_3(j), j = 1..M. Kept sorted by rho (ties by j) so that the nearest accepted
 * points come first. */
typedef struct sss_i_halton_disk {
    int M;
    float *rho;    /* M, ascending */
    float *phi;    /* M */
} sss_i_halton_disk;
obs_status sss_i_halton_disk_make(obs_context *ctx, int M, sss_i_halton_disk *out);
void sss_i_halton_disk_free(sss_i_halton_disk *h);
/* Visit the candidates in order of rho, drawing one zeta per visited candidate from *state, and
 * accept candidate j when exp(-sigma_r * rho_j) > zeta (sigma_r = sigma* R: rho is on the unit
 * disk); stop after `keep` acceptances (keep <= 0: visit all M). Writes accepted indices into
 * idx (room for M) and returns how many. */
int sss_i_nofm_accept(const sss_i_halton_disk *h, uint32_t *state, double sigma_r, int keep, int *idx, int *visited);
/* The same with the acceptance probabilities precomputed: p[i] = exp(-sigma_r * (double)h->rho[i])
 * (the same expression, so the same accepted set; sss_maps_build makes one table per material). */
int sss_i_nofm_accept_tab(const sss_i_halton_disk *h, uint32_t *state, const double *p, int keep, int *idx,
                          int *visited);

/* The receiver's depth in a map as a plane over pixel positions:
 * depth(x, y) = d0 + gx (x - px0) + gy (y - py0). */
typedef struct sss_i_depth_plane {
    double px0, py0, d0, gx, gy;
} sss_i_depth_plane;
/* A map sees x_o only when n_o . w_d > this (cos 87 degrees): at grazing angles the texel's
 * radiance belongs to a sliver of surface and the depth plane is ill-conditioned. */
#define SSS_I_MIN_FACING 0.05
/* The visibility of a point whose (shrunk) projection is at pixel position (px, py) in map layer
 * gb (sss_combine.c): PRODUCT5 in {0, 1}, PCF3X3 in {0, 1/9, .., 1}. bias in depth units. */
double sss_i_visibility(const rast_gbuffer *gb, sss_visibility mode, double px, double py,
                        const sss_i_depth_plane *pl, double bias);

/* One map layer's constants for the combination (sss_combine.c), hoisted out of the per-pixel
 * loop: the view matrix's rows as doubles (the same values sss_i_project converts per call), the
 * pixel model, the direction and the planes. The combination keeps the order of sss_i_project,
 * the shadow tap and the bilinear lookup, so its bits are those of per-call code (and of the GLSL
 * port, tests/gl/glsl_sss.c). */
typedef struct sss_i_combine_map {
    double r0[4], r1[4], r2[4];    /* view rows x, y, z: v_r = ((r[0] p0 + r[1] p1) + r[2] p2) + r[3] */
    double cx, cy, fx, fy;
    double wd[3];
    int W, H;
    const float *depth;
    ptrdiff_t dstride;
    const float *rad[3];
    ptrdiff_t rstride;
} sss_i_combine_map;
/* The combination's map loop (PRODUCT5 visibility) for 4 pixels, AVX2, lanes = pixels
 * (sss_combine_avx2.c): xo, no as [component][lane]; out acc[channel][lane], sumv, seen. The
 * same double operations per lane as sss_combine.c's scalar loop, so the same bits (test
 * sss_combination_avx2_matches_scalar_bit_for_bit). */
void sss_i_combine_maps_avx2(const sss_i_combine_map *cm, int K, double eps, double bias, const double xo[3][4],
                             const double no[3][4], double acc[3][4], double sumv[4], int seen[4]);

/* ---- Geometry helpers -------------------------------------------------------------------- */
/* Projection of a world point into a view's full image: continuous pixel coordinates (pixel
 * centre x + 0.5, row 0 top), linear depth, and pixels per world unit in the view plane at
 * that depth. Returns 0 behind a perspective eye. Uses the view constants only (the inverse of
 * rast_pixel_ray's model). */
int sss_i_project(const rast_view_constants *vc, const double p[3], double *px, double *py, double *depth,
                  double *px_per_unit);
/* World position of pixel position (px, py) at linear depth `depth` (rast_pixel_ray's model;
 * the view matrix is rigid, so view -> world is R^T (p - t), in double). */
void sss_i_pixel_world(const rast_view_constants *vc, double px, double py, double depth, double out[3]);
/* View-space normal -> world (R^T n), normalised; zero stays zero. */
void sss_i_normal_world(const rast_view_constants *vc, const float nv[3], double out[3]);
/* The same three, with a view's constants converted to double once (sss_i_view_geo_make) instead
 * of per call: the per-texel work of the maps' gather. Every expression is the functions' above,
 * term for term and in the same order, so the results are their bits (test
 * sss_maps_view_geo_matches_the_helpers). */
typedef struct sss_i_view_geo {
    double m[16];             /* the view matrix (column-major), as doubles */
    double cx, cy, fx, fy;
    int perspective;
} sss_i_view_geo;
static inline void sss_i_view_geo_make(const rast_view_constants *vc, sss_i_view_geo *g)
{
    for (int i = 0; i < 16; i++)
        g->m[i] = (double)vc->view.m[i];
    g->cx = vc->cx;
    g->cy = vc->cy;
    g->fx = vc->fx;
    g->fy = vc->fy;
    g->perspective = vc->projection_type == OBS_PROJECTION_PERSPECTIVE;
}
static inline int sss_i_geo_project(const sss_i_view_geo *g, const double p[3], double *px, double *py, double *depth,
                                    double *px_per_unit)
{
    const double *m = g->m;
    double v[3];
    for (int r = 0; r < 3; r++)
        v[r] = m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
    const double d = -v[2];
    if (g->perspective) {
        if (!(d > 0.0))
            return 0;
        *px = g->cx + g->fx * v[0] / d;
        *py = g->cy - g->fy * v[1] / d;
        *px_per_unit = g->fx / d;
    } else {
        *px = g->cx + g->fx * v[0];
        *py = g->cy - g->fy * v[1];
        *px_per_unit = g->fx;
    }
    *depth = d;
    return 1;
}
static inline void sss_i_geo_pixel_world(const sss_i_view_geo *g, double px, double py, double depth, double out[3])
{
    const double ax = (px - g->cx) / g->fx, ay = -(py - g->cy) / g->fy;
    double q[3];
    if (g->perspective) {
        q[0] = ax * depth;
        q[1] = ay * depth;
    } else {
        q[0] = ax;
        q[1] = ay;
    }
    q[2] = -depth;
    const double *m = g->m;
    for (int r = 0; r < 3; r++)
        q[r] -= m[12 + r];
    for (int c = 0; c < 3; c++)
        out[c] = m[c * 4 + 0] * q[0] + m[c * 4 + 1] * q[1] + m[c * 4 + 2] * q[2];
}
static inline void sss_i_geo_normal_world(const sss_i_view_geo *g, const float nv[3], double out[3])
{
    const double *m = g->m;
    double l2 = 0.0;
    for (int c = 0; c < 3; c++) {
        out[c] = m[c * 4 + 0] * nv[0] + m[c * 4 + 1] * nv[1] + m[c * 4 + 2] * nv[2];
        l2 += out[c] * out[c];
    }
    if (l2 > 0.0) {
        const double inv = 1.0 / sqrt(l2);
        for (int c = 0; c < 3; c++)
            out[c] *= inv;
    }
}
/* The material constants of a G-buffer material id, or NULL when opaque. */
const sss_constants *sss_i_material(const sss_scene_materials *mats, uint32_t material_id);
/* Scene framing: centre and radius of the bounds' bounding sphere. INVALID_ARGUMENT when empty. */
obs_status sss_i_scene_sphere(obs_context *ctx, const obs_scene *scene, double c[3], double *radius);

#endif
