/* truth_ao.c: ray-traced ambient-occlusion ground truth for every estimator's definition.
 *
 * docs/truth.md is the full description: the integrals (../shared/reference/ao.md section 2),
 * the sampling, the self-intersection offset and the convergence test. In short, per pixel:
 *   - p and n from the G-buffer (or an Embree primary hit); n faces the viewer;
 *   - the origin is offset along the geometric normal by eps = k 2^-24 m (setup_pixel);
 *   - a pixel's samples come from R independent randomisations (replicates) of one
 *     low-discrepancy sequence (a (0,2)-sequence in base 2, plus base-3 van der Corput for a third
 *     dimension): replicate r's sample i is point i of the sequence, Owen-scrambled in base 2
 *     [Owen95, Burley20] and digitally shifted in base 3 [LEcuyer02], with seeds keyed by (pixel,
 *     r, seed). Both keep the sequence's (t,m,s)-net stratification, which the earlier
 *     Cranley-Patterson rotation (addition mod 1) broke; samples are taken in rounds of B, B/R
 *     per replicate;
 *   - each pixel keeps, per output and replicate, the sum of its sample values; the estimate is
 *     the mean of the replicates' means and its standard error s_R is their spread,
 *     sqrt(sum_r (m_r - m)^2 / (R (R - 1))) [LEcuyer02]; the error bar is max(s_R, floor(n)),
 *     floor(n) the Agresti-Coull standard error of n identical outcomes [Agresti98], so a pixel
 *     whose rays all agree cannot stop before floor(n) <= target (docs/truth.md, "Convergence");
 *   - a pixel stops after min_samples once its error bar is <= target, or at max_samples;
 *   - a tile's active pixels trace each round as one rtcOccluded1M / rtcIntersect1M batch.
 *
 * References:
 *   [Malley88]  T. Malley, "A Shading Method for Computer Generated Images", MSc thesis, Univ. of
 *               Utah, 1988: cosine-distributed directions by lifting uniform disk points.
 *   [Shirley97] P. Shirley, K. Chiu, "A Low Distortion Map Between Disk and Square", Journal of
 *               Graphics Tools 2(3), 1997: the concentric map; z = 1 - r^2 with (x,y) scaled by
 *               sqrt(2 - r^2) is its equal-area hemisphere.
 *   [Duff17]    T. Duff, J. Burgess, P. Christensen, C. Hery, A. Kensler, M. Liani, R. Villemin,
 *               "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017.
 *   [Kollig02]  T. Kollig, A. Keller, "Efficient Multidimensional Sampling", Computer Graphics
 *               Forum 21(3) (Eurographics 2002): the (0,2)-sequence (van der Corput, Sobol' dim 2).
 *   [LEcuyer02] P. L'Ecuyer, C. Lemieux, "Recent Advances in Randomized Quasi-Monte Carlo
 *               Methods", in Modeling Uncertainty, Kluwer, 2002: randomised QMC, the random
 *               digital shift (it preserves the net structure) and the variance estimate from
 *               independent replicates of a randomised point set.
 *   [Owen95]    A. B. Owen, "Randomly Permuted (t,m,s)-Nets and (t,s)-Sequences", Monte Carlo and
 *               Quasi-Monte Carlo Methods in Scientific Computing, LNS 106, Springer, 1995.
 *   [Burley20]  B. Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020.
 *   [Laine11]   S. Laine, T. Karras, "Stratified Sampling for Stochastic Transparency", Computer
 *               Graphics Forum 30(4) (EGSR 2011).
 *   [Agresti98] A. Agresti, B. A. Coull, "Approximate Is Better than 'Exact' for Interval
 *               Estimation of Binomial Proportions", The American Statistician 52(2), 1998: add
 *               z^2/2 successes and z^2/2 failures.
 *   [Wachter19] C. Waechter, N. Binder, "A Fast and Robust Method for Avoiding Self-Intersection",
 *               Ray Tracing Gems, ch. 6, 2019: offsets measured in ulps of the coordinates.
 */
#include "truth_internal.h"

#include "../raster/raster.h"

#include <emmintrin.h>
#include <math.h>
#include <pmmintrin.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <xmmintrin.h>

/* ------------------------------------------------------------------------------------------------
 * Names, defaults, per-estimator properties
 * ---------------------------------------------------------------------------------------------- */

typedef enum falloff_kind { FALLOFF_NONE = 0, FALLOFF_CUBIC, FALLOFF_QUADRATIC } falloff_kind;

typedef struct est_info {
    const char *name;
    int hit_distance;      /* needs rtcIntersect1M (hit distance) rather than rtcOccluded1M */
    int cosine;            /* cosine-weighted hemisphere (else uniform) */
    int volume;            /* VOL: points in a ball, segments from the eye */
    int needs_finite_r;
    falloff_kind falloff;
} est_info;

static const est_info k_est[TRUTH_AO_COUNT] = {
    [TRUTH_AO_COS] = {"cos", 0, 1, 0, 0, FALLOFF_NONE},
    [TRUTH_AO_UNIF] = {"unif", 0, 0, 0, 0, FALLOFF_NONE},
    /* SAO option B, "Recommended": (r^2 - vv)^3, normalised here to (1 - d^2/r^2)^3 (ao.md 1.3) */
    [TRUTH_AO_OBS_SAO_B] = {"obs-sao", 1, 1, 0, 1, FALLOFF_CUBIC},
    /* later G3D SAO, HIGH_QUALITY: max(1 - vv/r^2, 0) times n.v/|v| (ao.md 1.3) */
    [TRUTH_AO_OBS_SAO_LINEAR] = {"obs-sao-linear", 1, 1, 0, 1, FALLOFF_QUADRATIC},
    /* MSSAO: rho = 1 - min(1, d^2/dMax^2), times max(0, n.v/|v|) (ao.md 1.4) */
    [TRUTH_AO_OBS_MSSAO] = {"obs-mssao", 1, 1, 0, 1, FALLOFF_QUADRATIC},
    /* classic HBAO: W(r) = 1 - r^2 (r = |S-P|/R) over the solid angle, uniform (ao.md 1.6, 2) */
    [TRUTH_AO_OBS_HBAO] = {"obs-hbao", 1, 0, 0, 1, FALLOFF_QUADRATIC},
    [TRUTH_AO_VOL] = {"vol", 0, 0, 1, 1, FALLOFF_NONE},
};

truth_ao_params truth_ao_params_default(void)
{
    truth_ao_params p;
    memset(&p, 0, sizeof p);
    p.estimator = TRUTH_AO_COS;
    p.radius = 0.5f;          /* XeGTAO GTAOSettings::Radius default (ao.md 1.8) */
    p.target_error = 0.002;   /* issue 3, item 3 */
    p.min_samples = 64;
    p.max_samples = 4096;
    p.batch = 16;             /* 8x8 tile x 16 rays = one 1024-ray rtcOccluded1M call (build-notes.md) */
    p.replicates = 8;         /* docs/truth.md, "Convergence": 7 degrees of freedom per error bar */
    p.seed = 0;
    p.normal = TRUTH_AO_NORMAL_GEOMETRIC;
    p.origin = TRUTH_AO_ORIGIN_GBUFFER;
    p.tile = 8;               /* build-notes.md: "a batch per 8x8 tile" was the fastest */
    p.offset_ulps = 64.0f;    /* docs/truth.md, "Self-intersection" */
    return p;
}

double truth_ao_error_floor(int64_t n)
{
    /* [Agresti98]: p~ = (k + z^2/2) / (n + z^2) at k = 0 (or n), se = sqrt(p~ (1 - p~) / (n + z^2)) */
    const double z2 = TRUTH_AO_FLOOR_Z * TRUTH_AO_FLOOR_Z, nn = (double)(n > 0 ? n : 0) + z2;
    const double pt = 0.5 * z2 / nn;
    return sqrt(pt * (1.0 - pt) / nn);
}

const char *truth_ao_estimator_name(truth_ao_estimator e)
{
    return (unsigned)e < TRUTH_AO_COUNT ? k_est[e].name : "?";
}

int truth_ao_estimator_from_name(const char *name, truth_ao_estimator *out)
{
    if (!name)
        return 0;
    for (int e = 0; e < TRUTH_AO_COUNT; e++)
        if (!strcmp(name, k_est[e].name)) {
            *out = (truth_ao_estimator)e;
            return 1;
        }
    return 0;
}

void truth_ao_result_free(truth_ao_result *r)
{
    if (!r)
        return;
    obs_image_f32_free(&r->mean);
    obs_image_f32_free(&r->std_error);
    obs_image_f32_free(&r->count);
    memset(r, 0, sizeof *r);
}

/* ------------------------------------------------------------------------------------------------
 * Sampling
 * ---------------------------------------------------------------------------------------------- */

static uint32_t bit_reverse32(uint32_t v)
{
    v = ((v & 0x55555555u) << 1) | ((v >> 1) & 0x55555555u);
    v = ((v & 0x33333333u) << 2) | ((v >> 2) & 0x33333333u);
    v = ((v & 0x0F0F0F0Fu) << 4) | ((v >> 4) & 0x0F0F0F0Fu);
    v = ((v & 0x00FF00FFu) << 8) | ((v >> 8) & 0x00FF00FFu);
    return (v << 16) | (v >> 16);
}

/* Sobol' dimension 2 (generator: the Pascal matrix mod 2), as in [Kollig02]. */
static uint32_t sobol2(uint32_t i)
{
    uint32_t r = 0;
    for (uint32_t v = 1u << 31; i; i >>= 1, v ^= v >> 1)
        if (i & 1u)
            r ^= v;
    return r;
}

/* Local directions (z = the normal) of n samples (n a multiple of 4), 4 at a time with SSE2
 * (baseline x86-64: the reference path; truth_ao_avx2.c repeats the same operations 8 lanes at a
 * time on AVX2 CPUs, with the same bits, so results never depend on the CPU).
 *
 * Input: the samples' two coordinates in 32-bit fixed point, u0[i] and u1[i], already digitally
 * shifted (pixel_points). Each is taken to the centre of its 2^-25 cell of [-1, 1):
 * ((u >> 7) | 1 - 2^24) / 2^24, an odd integer over 2^24, never 0 and exact in float.
 *
 * Concentric map to the unit disk [Shirley97], in Shirley's two-case form: |a| > |b|: radius a,
 * angle (pi/4)(b/a); else radius b, angle pi/2 - (pi/4)(a/b). sin and cos on [-pi/4, pi/4] are
 * Taylor polynomials of degree 9 and 10 (truncation under 2e-9, below float rounding).
 *
 * Then, with rr = r^2:
 *   DIRS_COSINE:  z = sqrt(1 - rr), lifting uniform disk points: cosine-distributed [Malley88];
 *   DIRS_UNIFORM: z = 1 - rr, (x, y) scaled by sqrt(2 - rr): the equal-area hemisphere of
 *                 [Shirley97]; z is uniform in [0, 1) exactly as with "z = u1, phi = 2 pi u2";
 *   DIRS_SPHERE:  the top bit of the first coordinate picks the hemisphere (z sign), the other
 *                 31 bits (shifted up) feed DIRS_UNIFORM: uniform on the whole sphere. */
enum { DIRS_COSINE = 0, DIRS_UNIFORM, DIRS_SPHERE };

static inline __m128 sel_ps(__m128 m, __m128 a, __m128 b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); }

static inline __m128 fixed_to_signed_unit(__m128i u)
{
    __m128i odd = _mm_sub_epi32(_mm_or_si128(_mm_srli_epi32(u, 7), _mm_set1_epi32(1)), _mm_set1_epi32(1 << 24));
    return _mm_mul_ps(_mm_cvtepi32_ps(odd), _mm_set1_ps(0x1p-24f));
}

static void local_dirs(const uint32_t *u0, const uint32_t *u1, int n, int mode, float *lx, float *ly, float *lz)
{
    const __m128 absmask = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    const __m128 one = _mm_set1_ps(1.0f), two = _mm_set1_ps(2.0f), pi4 = _mm_set1_ps(0.78539816339744831f);
    const __m128 c6 = _mm_set1_ps(1.0f / 6.0f), c20 = _mm_set1_ps(1.0f / 20.0f), c42 = _mm_set1_ps(1.0f / 42.0f),
                 c72 = _mm_set1_ps(1.0f / 72.0f);
    const __m128 c2 = _mm_set1_ps(0.5f), c12 = _mm_set1_ps(1.0f / 12.0f), c30 = _mm_set1_ps(1.0f / 30.0f),
                 c56 = _mm_set1_ps(1.0f / 56.0f), c90 = _mm_set1_ps(1.0f / 90.0f);
    for (int i = 0; i < n; i += 4) {
        __m128i ua = _mm_load_si128((const __m128i *)(u0 + i));
        __m128i ub = _mm_load_si128((const __m128i *)(u1 + i));
        __m128 zsign = _mm_setzero_ps();
        if (mode == DIRS_SPHERE) {
            zsign = _mm_castsi128_ps(_mm_and_si128(ua, _mm_set1_epi32((int)0x80000000u)));
            ua = _mm_slli_epi32(ua, 1);
        }
        __m128 a = fixed_to_signed_unit(ua), b = fixed_to_signed_unit(ub);
        __m128 first = _mm_cmpgt_ps(_mm_and_ps(a, absmask), _mm_and_ps(b, absmask));
        __m128 rad = sel_ps(first, a, b);
        __m128 q = _mm_div_ps(sel_ps(first, b, a), rad);
        __m128 x = _mm_mul_ps(pi4, q), x2 = _mm_mul_ps(x, x);
        __m128 sn = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c42), _mm_sub_ps(one, _mm_mul_ps(x2, c72))));
        sn = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c20), sn));
        sn = _mm_mul_ps(x, _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c6), sn)));
        __m128 cs = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c56), _mm_sub_ps(one, _mm_mul_ps(x2, c90))));
        cs = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c30), cs));
        cs = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c12), cs));
        cs = _mm_sub_ps(one, _mm_mul_ps(_mm_mul_ps(x2, c2), cs));
        __m128 px = _mm_mul_ps(rad, sel_ps(first, cs, sn)), py = _mm_mul_ps(rad, sel_ps(first, sn, cs));
        __m128 rr = _mm_mul_ps(rad, rad), pz;
        if (mode == DIRS_COSINE) {
            pz = _mm_sqrt_ps(_mm_sub_ps(one, rr));
        } else {
            __m128 sc = _mm_sqrt_ps(_mm_sub_ps(two, rr));
            px = _mm_mul_ps(px, sc);
            py = _mm_mul_ps(py, sc);
            pz = _mm_xor_ps(_mm_sub_ps(one, rr), zsign);
        }
        _mm_store_ps(lx + i, px);
        _mm_store_ps(ly + i, py);
        _mm_store_ps(lz + i, pz);
    }
}

/* An orthonormal basis (t, b) around unit n, branchless [Duff17], listing 3. */
static void onb_duff(const float n[3], float t[3], float b[3])
{
    float sign = copysignf(1.0f, n[2]);
    float a = -1.0f / (sign + n[2]);
    float bb = n[0] * n[1] * a;
    t[0] = 1.0f + sign * n[0] * n[0] * a;
    t[1] = sign * bb;
    t[2] = -sign * n[0];
    b[0] = bb;
    b[1] = sign + n[1] * n[1] * a;
    b[2] = -n[1];
}

/* ------------------------------------------------------------------------------------------------
 * The job
 * ---------------------------------------------------------------------------------------------- */

typedef struct px_state {
    float org[3];          /* hemisphere estimators: the offset origin; VOL: p itself */
    float t[3], b[3], n[3]; /* org, t, b, n: the 12 floats truth_i_hemi_in.frame names */
    uint64_t pixel;        /* inner pixel index y*W + x: the RNG key */
    uint32_t shift[TRUTH_AO_MAX_REPLICATES][2]; /* per replicate: the Owen-scrambling seeds of the two
                           base-2 coordinates: Philox(pixel, r, 0, seed) words 0, 1 */
    uint64_t shift3[TRUTH_AO_MAX_REPLICATES]; /* per replicate (VOL): the base-3 digital shift, words 2,
                           3 as one 64-bit number whose base-3 digits are the shifts */
    double *acc;           /* nout x R sums of the sample values: acc[j R + r] (thread_scratch.acc) */
    int64_t count;         /* samples taken (count / R per replicate) */
    int x, y;
    int state;             /* 1 surface, 0 background, -1 invalid normal */
} px_state;
_Static_assert(offsetof(px_state, t) == offsetof(px_state, org) + 3 * sizeof(float) &&
                   offsetof(px_state, n) == offsetof(px_state, org) + 9 * sizeof(float),
               "org, t, b, n: 12 consecutive floats (truth_i_hemi_in.frame)");

typedef struct thread_scratch {
    _Alignas(64) px_state *px; /* 64-byte aligned, a multiple of 64 bytes: threads never share a cache line */
    int *active;
    uint32_t *b0, *b1, *b2; /* the round's points of the sequence, B/R of them: b0, b1 its two base-2
                               coordinates bit-reversed (b0 = the index), b2 the index (base 3) */
    uint32_t *u0, *u1, *u2; /* one pixel's round, shifted: B rounded up to 4 of each (pixel_points) */
    uint32_t *v0, *v1;     /* the round's points per ray k: b0, b1[k mod (B/R)] (B of each) */
    double *acc;           /* tile*tile pixels x nout x R replicate sums (px_state.acc) */
    float *lx, *ly, *lz;   /* local directions of one pixel's round */
    __m128 *d4;            /* world directions of one pixel's round, one (x, y, z, 0) per ray */
    void *rays;            /* RTCRay or RTCRayHit, tile*tile*batch of them */
    /* per-thread counters, summed at the end (deterministic) */
    uint64_t rays_traced, primary_rays;
    int64_t surface, background, invalid, at_max;
    int64_t converged[TRUTH_AO_MAX_OUTPUTS]; /* per output: stopped with its error bar <= target */
    double max_se[TRUTH_AO_MAX_OUTPUTS], max_eps;
} thread_scratch;

typedef struct ao_job {
    const truth_scene *ts;
    const obs_scene *scene;
    const obs_camera *cam;
    const rast_gbuffer *gb;
    truth_ao_params p;
    est_info ei;
    obs_tiling tiling;
    int W, H, guard;
    int group;             /* tiles per task, side by side (see ao_task) */
    float *inst_norm;      /* per instance: |M|inf of its 3x3 */
    double *inst_bound;    /* per instance: an upper bound of triangle_extent over its triangles
                           (mesh_extent_bound x inst_norm; NaN or inf when none is known) */
    _Atomic uint32_t *tri_extent; /* per triangle of every mesh: the bits of its object-space
                           bounding-box extent, computed at its first use (EXTENT_UNSET before);
                           NULL when no pixel can need one (see render_outputs) */
    /* rast_pixel_ray's arithmetic, hoisted (perspective cameras; see pixel_ray) */
    int persp;
    double cx, cy, inv_fx, inv_fy;
    obs_dvec3 eye_o;       /* rast_pixel_ray's origin: the same for every pixel in perspective */
    double mo;             /* max3abs(eye_o) */
    int setup8;            /* ao_tile sets pixels up with truth_i_setup8_avx2 (setup_row8) */
    int avx2;              /* the AVX2 forms of the sampling run (truth_i_avx2_active) */
    truth_i_philox_keys keys; /* the seed's Philox round keys (AVX2 seeds) */
    size_t *mesh_first;    /* per mesh: its first entry in tri_extent */
    thread_scratch *scratch;
    truth_ao_result *out;  /* outs[0] */
    truth_ao_result *outs; /* nout results, one per output */
    int nout;              /* 1, or several outputs of one ray set (truth_ao_render_multi) */
    int multi_hit;         /* nout > 1: rays traced with a hit record to the largest radius */
    int binary[TRUTH_AO_MAX_OUTPUTS];     /* the output is [t > r] (no falloff) */
    falloff_kind fk[TRUTH_AO_MAX_OUTPUTS];
    double inv_r2s[TRUTH_AO_MAX_OUTPUTS]; /* 1 / r^2 per output (0 for r = inf) */
    float radii[TRUTH_AO_MAX_OUTPUTS];
    const truth_ao_hooks *hooks;
    const unsigned char *task_mask; /* truth_ao_render_tasks: the tasks to render (NULL = all) */
    obs_vec3 eye;          /* perspective eye (world) */
    obs_vec3 cam_back;     /* camera +Z axis in world (orthographic VOL) */
    atomic_int_fast64_t tiles_done;
    atomic_uint_fast64_t rays_done;
} ao_job;

static inline float max3abs(double x, double y, double z)
{
    double m = fabs(x);
    m = fabs(y) > m ? fabs(y) : m;
    m = fabs(z) > m ? fabs(z) : m;
    return (float)m;
}

/* An upper bound of max_k |v_k - p|inf over the world-space vertices of the surface's triangle,
 * for p on it: the object-space bounding-box extent (largest side, precomputed per triangle)
 * times the instance's |M|inf (largest absolute row sum of its 3x3). 0 when the ids name no
 * triangle. */
#define EXTENT_UNSET 0xFFFFFFFFu /* a NaN's bits: never an extent (extents are >= 0 or +inf) */

/* The object-space bounding-box extent (largest side) of mesh triangle t. */
static float mesh_triangle_extent(const obs_mesh *mesh, uint32_t t)
{
    float ext = 0.0f;
    for (int c = 0; c < 3; c++) {
        float a = mesh->positions[3 * (size_t)mesh->indices[3 * (size_t)t] + c];
        float b = mesh->positions[3 * (size_t)mesh->indices[3 * (size_t)t + 1] + c];
        float d = mesh->positions[3 * (size_t)mesh->indices[3 * (size_t)t + 2] + c];
        float lo = fminf(a, fminf(b, d)), hi = fmaxf(a, fmaxf(b, d));
        float e = hi - lo;
        ext = e > ext ? e : ext; /* NaN (a non-finite vertex: never hit) leaves it */
    }
    return ext;
}

/* An upper bound of mesh_triangle_extent over the mesh's triangles: the largest side of the
 * bounding box of its vertices (NaN coordinates left out, as fminf / fmaxf leave them out of a
 * triangle's). A triangle's box lies in it, and float subtraction is monotone, so each
 * triangle's hi - lo is <= the box's. +inf with an infinite coordinate; 0 for no vertices. */
static float mesh_extent_bound(const obs_mesh *mesh)
{
    const float *v = mesh->positions;
    const size_t nf = 3 * (size_t)mesh->vertex_count;
    /* 4 vertices (12 floats) per step: lanes (x y z x), (y z x y), (z x y z) */
    __m128 lo0 = _mm_set1_ps(INFINITY), lo1 = lo0, lo2 = lo0;
    __m128 hi0 = _mm_set1_ps(-INFINITY), hi1 = hi0, hi2 = hi0;
    size_t i = 0;
    for (; i + 12 <= nf; i += 12) { /* minps / maxps return the second operand when one is NaN */
        __m128 a = _mm_loadu_ps(v + i), b = _mm_loadu_ps(v + i + 4), c = _mm_loadu_ps(v + i + 8);
        lo0 = _mm_min_ps(a, lo0), hi0 = _mm_max_ps(a, hi0);
        lo1 = _mm_min_ps(b, lo1), hi1 = _mm_max_ps(b, hi1);
        lo2 = _mm_min_ps(c, lo2), hi2 = _mm_max_ps(c, hi2);
    }
    _Alignas(16) float l[12], h[12];
    _mm_store_ps(l, lo0), _mm_store_ps(l + 4, lo1), _mm_store_ps(l + 8, lo2);
    _mm_store_ps(h, hi0), _mm_store_ps(h + 4, hi1), _mm_store_ps(h + 8, hi2);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 12; k++) {
        lo[k % 3] = l[k] < lo[k % 3] ? l[k] : lo[k % 3];
        hi[k % 3] = h[k] > hi[k % 3] ? h[k] : hi[k % 3];
    }
    for (; i < nf; i++) { /* NaN compares false: left out */
        lo[i % 3] = v[i] < lo[i % 3] ? v[i] : lo[i % 3];
        hi[i % 3] = v[i] > hi[i % 3] ? v[i] : hi[i % 3];
    }
    float ext = 0.0f;
    for (int c = 0; c < 3; c++) {
        float e = hi[c] - lo[c]; /* -inf when the coordinate had no value: ignored */
        ext = e > ext ? e : ext;
    }
    return ext;
}

static double triangle_extent(const ao_job *J, uint32_t inst, uint32_t prim)
{
    const obs_scene *sc = J->scene;
    if (inst >= sc->instance_count)
        return 0.0;
    uint32_t mesh = sc->instances[inst].mesh;
    if (prim >= sc->meshes[mesh].triangle_count)
        return 0.0;
    /* computed at the triangle's first use (only the triangles seen in a pixel: the full table cost
     * 13 M instructions per call on the bunny); two threads may both compute it, and store the
     * same bits */
    if (!J->tri_extent) /* no table (never reached when render_outputs leaves it out) */
        return (double)mesh_triangle_extent(&sc->meshes[mesh], prim) * (double)J->inst_norm[inst];
    _Atomic uint32_t *slot = &J->tri_extent[J->mesh_first[mesh] + prim];
    uint32_t bits = atomic_load_explicit(slot, memory_order_relaxed);
    float ext;
    if (bits == EXTENT_UNSET) {
        ext = mesh_triangle_extent(&sc->meshes[mesh], prim);
        memcpy(&bits, &ext, sizeof bits);
        atomic_store_explicit(slot, bits, memory_order_relaxed);
    } else {
        memcpy(&ext, &bits, sizeof ext);
    }
    return (double)ext * (double)J->inst_norm[inst];
}

/* Interpolated shading normal of an Embree hit, in world space (unit), or ng when the mesh has
 * no normals. */
static obs_vec3 hit_shading_normal(const ao_job *J, const truth_hit *h, obs_vec3 ng)
{
    const obs_scene *sc = J->scene;
    const obs_mesh *m = &sc->meshes[sc->instances[h->instance].mesh];
    if (!m->normals || h->prim >= m->triangle_count)
        return ng;
    const uint32_t *ix = &m->indices[3 * (size_t)h->prim];
    float w0 = 1.0f - h->u - h->v, w1 = h->u, w2 = h->v;
    obs_vec3 n = obs_v3(0, 0, 0);
    for (int c = 0; c < 3; c++) {
        float a = m->normals[3 * (size_t)ix[0] + c], b = m->normals[3 * (size_t)ix[1] + c],
              d = m->normals[3 * (size_t)ix[2] + c];
        float v = w0 * a + w1 * b + w2 * d;
        if (c == 0) n.x = v; else if (c == 1) n.y = v; else n.z = v;
    }
    return obs_v3_normalize(obs_mat4_mul_dir(J->ts->normal_world[h->instance], n));
}

/* obs_v3_normalize, inline (the zero vector for a zero or non-finite input). */
static inline obs_vec3 unit3(obs_vec3 a)
{
    float l2 = a.x * a.x + a.y * a.y + a.z * a.z;
    if (!(l2 > 0.0f) || !isfinite(l2))
        return obs_v3(0, 0, 0);
    float inv = 1.0f / sqrtf(l2);
    return obs_v3(a.x * inv, a.y * inv, a.z * inv);
}

static int unit_ok(obs_vec3 n)
{
    float l = n.x * n.x + n.y * n.y + n.z * n.z;
    return isfinite(l) && l > 0.5f && l < 1.5f;
}

/* rast_pixel_ray(&gb->constants, cam, px, py, o, d), the same operations in the same order on
 * the same values (so the same bits), without the call: in perspective the origin is the same for
 * every pixel (J->eye_o, from one call) and 1/fx, 1/fy are taken once per job. Other projections
 * call it. */
static inline void pixel_ray(const ao_job *J, double px, double py, obs_dvec3 *o, obs_dvec3 *d)
{
    if (!J->persp) {
        rast_pixel_ray(&J->gb->constants, J->cam, px, py, o, d);
        return;
    }
    const double ax = (px - J->cx) * J->inv_fx, ay = -(py - J->cy) * J->inv_fy, az = -1.0;
    const float *w = J->cam->world.m;
    *o = J->eye_o;
    d->x = w[0] * ax + w[4] * ay + w[8] * az;
    d->y = w[1] * ax + w[5] * ay + w[9] * az;
    d->z = w[2] * ax + w[6] * ay + w[10] * az;
}

/* obs_mat4_mul_dir, inline (the same float operations in the same order). */
static inline obs_vec3 mul_dir(const obs_mat4 *m, obs_vec3 d)
{
    const float *w = m->m;
    return obs_v3(w[0] * d.x + w[4] * d.y + w[8] * d.z, w[1] * d.x + w[5] * d.y + w[9] * d.z,
                  w[2] * d.x + w[6] * d.y + w[10] * d.z);
}

/* Set up one pixel: its point, normals and offset origin. */
static void setup_pixel(ao_job *J, thread_scratch *S, px_state *s, int x, int y)
{
    const rast_gbuffer *gb = J->gb;
    const obs_camera *cam = J->cam;
    int gx = x + J->guard, gy = y + J->guard;
    s->x = x;
    s->y = y;
    s->state = 0;
    s->pixel = (uint64_t)y * (uint64_t)J->W + (uint64_t)x;
    {
        const int n = J->nout * J->p.replicates; /* R >= 2: at least one pair */
        int j = 0;
        for (; j + 2 <= n; j += 2)
            _mm_storeu_pd(s->acc + j, _mm_setzero_pd());
        if (j < n)
            s->acc[j] = 0.0;
    }
    s->count = 0;
    float depth = 0.0f;
    if (J->p.origin == TRUTH_AO_ORIGIN_GBUFFER) {
        depth = obs_image_f32_row(&gb->depth, gy)[gx];
        if (!(depth > 0.0f) || !isfinite(depth))
            return; /* background */
    }
    obs_dvec3 o, d;
    pixel_ray(J, gx + 0.5, gy + 0.5, &o, &d);
    obs_dvec3 p;
    obs_vec3 ng, ns;
    uint32_t inst, prim;
    if (J->p.origin == TRUTH_AO_ORIGIN_GBUFFER) {
        p = obs_dv3(o.x + (double)depth * d.x, o.y + (double)depth * d.y, o.z + (double)depth * d.z);
        obs_vec3 nv = obs_v3(obs_image_f32_row(&gb->face_normal[0], gy)[gx], obs_image_f32_row(&gb->face_normal[1], gy)[gx],
                             obs_image_f32_row(&gb->face_normal[2], gy)[gx]);
        ng = unit3(mul_dir(&cam->world, nv));
        /* facing the viewer already, unless the G-buffer was rendered with face_forward = 0 */
        int flip = (double)ng.x * d.x + (double)ng.y * d.y + (double)ng.z * d.z > 0.0;
        if (flip)
            ng = obs_v3_scale(ng, -1.0f);
        if (J->p.normal == TRUTH_AO_NORMAL_SHADING) {
            obs_vec3 sv = obs_v3(obs_image_f32_row(&gb->normal[0], gy)[gx], obs_image_f32_row(&gb->normal[1], gy)[gx],
                                 obs_image_f32_row(&gb->normal[2], gy)[gx]);
            ns = unit3(mul_dir(&cam->world, sv));
            if (flip)
                ns = obs_v3_scale(ns, -1.0f);
        } else {
            ns = ng;
        }
        inst = obs_image_u32_row(&gb->instance_id, gy)[gx];
        prim = obs_image_u32_row(&gb->prim_id, gy)[gx];
    } else {
        obs_vec3 of = obs_v3((float)o.x, (float)o.y, (float)o.z), df = obs_v3((float)d.x, (float)d.y, (float)d.z);
        truth_hit h;
        truth_intersect1(J->ts, of, df, cam->znear, isinf(cam->zfar) ? INFINITY : cam->zfar, &h);
        S->primary_rays++;
        if (h.instance == 0xFFFFFFFFu)
            return; /* background */
        p = obs_dv3(of.x + (double)h.t * df.x, of.y + (double)h.t * df.y, of.z + (double)h.t * df.z);
        ng = h.ng;
        int flip = obs_v3_dot(ng, df) > 0.0f; /* face the viewer, as the rasterizer's face_forward */
        if (flip)
            ng = obs_v3_scale(ng, -1.0f);
        if (J->p.normal == TRUTH_AO_NORMAL_SHADING) {
            ns = hit_shading_normal(J, &h, flip ? obs_v3_scale(ng, -1.0f) : ng);
            if (flip)
                ns = obs_v3_scale(ns, -1.0f);
        } else {
            ns = ng;
        }
        inst = h.instance;
        prim = h.prim;
    }
    if (!unit_ok(ng) || (J->p.normal == TRUTH_AO_NORMAL_SHADING && !unit_ok(ns))) { /* else ns = ng */
        s->state = -1;
        return;
    }
    s->state = 1;
#if defined(OBS_HAVE_AVX2)
    if (J->avx2)
        truth_i_seeds_avx2_k(s->pixel, J->p.replicates, &J->keys, s->shift,
                             J->ei.volume ? s->shift3 : NULL); /* the same words (shift3: VOL's only) */
    else
#endif
    {
        /* replicate r's seeds: Philox(pixel, r, 0, seed), four calls at a time (same words) */
        uint32_t w[TRUTH_AO_MAX_REPLICATES][4];
        obs_rng_u32x4_n(s->pixel, 0, J->p.replicates, 0, J->p.seed, w);
        for (int r = 0; r < J->p.replicates; r++) {
            s->shift[r][0] = w[r][0];
            s->shift[r][1] = w[r][1];
            s->shift3[r] = ((uint64_t)w[r][3] << 32) | w[r][2];
        }
    }
    /* Self-intersection offset (docs/truth.md): eps = k 2^-24 m along the geometric normal, where
     * m bounds the magnitudes whose float rounding decides on which side of the surface's plane
     * Embree finds the origin: the point, the eye (the G-buffer depth is measured from it), and the
     * triangle's extent around p (Embree's plane test works on v0 - origin). */
    double m = max3abs(p.x, p.y, p.z);
    double mo = max3abs(o.x, o.y, o.z);
    m = mo > m ? mo : m;
    /* L > m only when the instance's bound exceeds m: else L <= bound <= m leaves m as it is */
    if (inst < J->scene->instance_count && !(J->inst_bound[inst] <= m)) {
        double L = triangle_extent(J, inst, prim);
        m = L > m ? L : m;
    }
    double eps = (double)J->p.offset_ulps * 0x1p-24 * m;
    S->max_eps = eps > S->max_eps ? eps : S->max_eps;
    if (J->ei.volume) {
        s->org[0] = (float)p.x;
        s->org[1] = (float)p.y;
        s->org[2] = (float)p.z;
    } else {
        s->org[0] = (float)(p.x + eps * ng.x);
        s->org[1] = (float)(p.y + eps * ng.y);
        s->org[2] = (float)(p.z + eps * ng.z);
    }
    s->n[0] = ns.x;
    s->n[1] = ns.y;
    s->n[2] = ns.z;
    onb_duff(s->n, s->t, s->b);
}

#if defined(OBS_HAVE_AVX2)
/* setup_pixel for the pixels [x0, x1) of row y, 8 at a time (truth_i_setup8_avx2; J->setup8: the
 * G-buffer origin, the geometric normal, a perspective camera, a hemisphere estimator): the same
 * values. Surface pixels take slots nactive.. of S->px; the others get their outputs. Returns the
 * new nactive. */
static int setup_row8(ao_job *J, thread_scratch *S, int y, int x0, int x1, int nactive, float *om, float *os, float *oc)
{
    const rast_gbuffer *gb = J->gb;
    const int g = J->guard, gy = y + g;
    truth_i_setup8 io;
    io.world = J->cam->world.m;
    io.cx = J->cx, io.cy = J->cy, io.inv_fx = J->inv_fx, io.inv_fy = J->inv_fy;
    io.o[0] = J->eye_o.x, io.o[1] = J->eye_o.y, io.o[2] = J->eye_o.z;
    io.mo = J->mo;
    const double k = (double)J->p.offset_ulps * 0x1p-24;
    io.k = k;
    io.py = gy + 0.5;
    const float *dr = obs_image_f32_row(&gb->depth, gy) + g, *n0 = obs_image_f32_row(&gb->face_normal[0], gy) + g,
                *n1 = obs_image_f32_row(&gb->face_normal[1], gy) + g, *n2 = obs_image_f32_row(&gb->face_normal[2], gy) + g;
    const uint32_t *ir = obs_image_u32_row(&gb->instance_id, gy) + g, *pr = obs_image_u32_row(&gb->prim_id, gy) + g;
    for (int xs = x0; xs < x1; xs += 8) {
        io.count = x1 - xs < 8 ? x1 - xs : 8;
        io.depth = dr + xs, io.nx = n0 + xs, io.ny = n1 + xs, io.nz = n2 + xs;
        io.px0 = (xs + g) + 0.5;
        truth_i_setup8_avx2(&io);
        uint64_t seed_px[8];
        uint32_t(*seed_out[8])[2];
        int nseed = 0;
        for (int l = 0; l < io.count; l++) {
            const int x = xs + l;
            if (io.state[l] != 1) {
                om[x] = 1.0f;
                os[x] = 0.0f;
                oc[x] = 0.0f;
                if (io.state[l] == 0)
                    S->background++;
                else
                    S->invalid++;
                continue;
            }
            px_state *s = &S->px[nactive];
            s->x = x;
            s->y = y;
            s->state = 1;
            s->pixel = (uint64_t)y * (uint64_t)J->W + (uint64_t)x;
            const int na = J->p.replicates; /* nout = 1 here; R >= 2 */
            if (na == 8) {
                for (int j = 0; j < 8; j += 2)
                    _mm_storeu_pd(s->acc + j, _mm_setzero_pd());
            } else {
                int j = 0;
                for (; j + 2 <= na; j += 2)
                    _mm_storeu_pd(s->acc + j, _mm_setzero_pd());
                if (j < na)
                    s->acc[j] = 0.0;
            }
            s->count = 0;
            for (int c = 0; c < 3; c++) {
                s->org[c] = io.frame[c][l];
                s->t[c] = io.frame[3 + c][l];
                s->b[c] = io.frame[6 + c][l];
                s->n[c] = io.frame[9 + c][l];
            }
            seed_px[nseed] = s->pixel; /* seeds below, for the group's surface pixels at once */
            seed_out[nseed++] = s->shift;
            double m = io.m[l];
            const uint32_t inst = ir[x], prim = pr[x];
            if (inst < J->scene->instance_count && !(J->inst_bound[inst] <= m)) { /* as setup_pixel */
                double L = triangle_extent(J, inst, prim);
                if (L > m) {
                    m = L;
                    const double eps = k * m;
                    s->org[0] = (float)(io.p[0][l] + eps * io.ng[0][l]);
                    s->org[1] = (float)(io.p[1][l] + eps * io.ng[1][l]);
                    s->org[2] = (float)(io.p[2][l] + eps * io.ng[2][l]);
                }
            }
            const double eps = k * m;
            S->max_eps = eps > S->max_eps ? eps : S->max_eps;
            S->active[nactive] = nactive;
            nactive++;
        }
        if (nseed)
            truth_i_seeds_n_avx2_k(nseed, seed_px, (uint32_t(*const *)[2])seed_out, J->p.replicates, &J->keys);
    }
    return nactive;
}
#endif

/* World directions d = x t + y b + z n of n local directions (n a multiple of 4), transposed to
 * one (dx, dy, dz, 0) vector per ray in d4[]. */
static void world_dirs(const px_state *s, const float *lx, const float *ly, const float *lz, int n, __m128 *d4)
{
    const __m128 t0 = _mm_set1_ps(s->t[0]), t1 = _mm_set1_ps(s->t[1]), t2 = _mm_set1_ps(s->t[2]);
    const __m128 b0 = _mm_set1_ps(s->b[0]), b1 = _mm_set1_ps(s->b[1]), b2 = _mm_set1_ps(s->b[2]);
    const __m128 n0 = _mm_set1_ps(s->n[0]), n1 = _mm_set1_ps(s->n[1]), n2 = _mm_set1_ps(s->n[2]);
    for (int i = 0; i < n; i += 4) {
        __m128 x = _mm_load_ps(lx + i), y = _mm_load_ps(ly + i), z = _mm_load_ps(lz + i);
        __m128 dx = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, t0), _mm_mul_ps(y, b0)), _mm_mul_ps(z, n0));
        __m128 dy = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, t1), _mm_mul_ps(y, b1)), _mm_mul_ps(z, n1));
        __m128 dz = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, t2), _mm_mul_ps(y, b2)), _mm_mul_ps(z, n2));
        __m128 w = _mm_setzero_ps();
        _MM_TRANSPOSE4_PS(dx, dy, dz, w);
        d4[i] = dx;
        d4[i + 1] = dy;
        d4[i + 2] = dz;
        d4[i + 3] = w;
    }
}

static inline uint32_t float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* The base-3 radical inverse of idx with every one of its 20 digits shifted by the matching base-3
 * digit of `shift`, mod 3: a base-3 random digital shift [LEcuyer02] (the base-2 XOR's analogue; it
 * keeps van der Corput's stratification in base-3 intervals). 3^20 > 2^31 covers every index; a
 * 64-bit shift taken mod 3^20 has digits uniform within 2e-10. As 32-bit fixed point. */
static uint32_t radical_inverse3_shifted(uint32_t idx, uint64_t shift)
{
    uint64_t v = 0;
    for (int k = 0; k < 20; k++) {
        uint32_t d = idx % 3u, e = (uint32_t)(shift % 3u);
        idx /= 3u;
        shift /= 3u;
        v = v * 3u + (d + e) % 3u;
    }
    return (uint32_t)((double)v * (4294967296.0 / 3486784401.0)); /* v / 3^20 * 2^32 < 2^32 */
}

/* Base-2 Owen scrambling of a coordinate given bit-reversed (its least significant digit first),
 * [Burley20] with the Laine-Karras permutation [Laine11]: v + seed, then four x ^= x * c with even
 * c. Each step changes a bit only as a function of the bits below it, so, read in the original
 * bit order, every digit is permuted as a function of the digits before it: a nested (Owen)
 * scramble, which keeps every (t,m,s)-net a net [Owen95]. For a uniform seed v + seed is uniform
 * and the rest is a fixed bijection, so each scrambled point is exactly uniform on the 2^32 grid.
 * The constants are [Burley20]'s listing. */
static inline uint32_t owen_reversed(uint32_t v, uint32_t seed)
{
    v += seed;
    v ^= v * 0x6c50b47cu;
    v ^= v * 0xb82f1e52u;
    v ^= v * 0xc7afe638u;
    v ^= v * 0x8d22f6e6u;
    return v;
}

uint32_t truth_i_owen_scramble1(uint32_t v, uint32_t seed) { return bit_reverse32(owen_reversed(v, seed)); }

/* The low 32 bits of a * c per lane (SSE2 has no pmulld: two pmuludq on the even and odd lanes). */
static inline __m128i mullo32(__m128i a, __m128i c)
{
    __m128i even = _mm_mul_epu32(a, c), odd = _mm_mul_epu32(_mm_srli_si128(a, 4), _mm_srli_si128(c, 4));
    return _mm_unpacklo_epi32(_mm_shuffle_epi32(even, _MM_SHUFFLE(0, 0, 2, 0)),
                              _mm_shuffle_epi32(odd, _MM_SHUFFLE(0, 0, 2, 0)));
}

static inline __m128i swap_bits(__m128i v, int sh, uint32_t mask)
{
    const __m128i m = _mm_set1_epi32((int)mask);
    return _mm_or_si128(_mm_slli_epi32(_mm_and_si128(v, m), sh), _mm_and_si128(_mm_srli_epi32(v, sh), m));
}

/* owen_reversed then bit_reverse32, 4 lanes: the same integer operations, so the same bits. */
static inline __m128i owen_scramble4(__m128i v, __m128i seed)
{
    v = _mm_add_epi32(v, seed);
    v = _mm_xor_si128(v, mullo32(v, _mm_set1_epi32((int)0x6c50b47cu)));
    v = _mm_xor_si128(v, mullo32(v, _mm_set1_epi32((int)0xb82f1e52u)));
    v = _mm_xor_si128(v, mullo32(v, _mm_set1_epi32((int)0xc7afe638u)));
    v = _mm_xor_si128(v, mullo32(v, _mm_set1_epi32((int)0x8d22f6e6u)));
    v = swap_bits(v, 1, 0x55555555u);
    v = swap_bits(v, 2, 0x33333333u);
    v = swap_bits(v, 4, 0x0F0F0F0Fu);
    v = swap_bits(v, 8, 0x00FF00FFu);
    return _mm_or_si128(_mm_slli_epi32(v, 16), _mm_srli_epi32(v, 16));
}

void truth_i_owen_scramble(const uint32_t *v, const uint32_t *seed, int n, uint32_t *out)
{
    int k = 0;
    for (; k + 4 <= n; k += 4)
        _mm_storeu_si128((__m128i *)(out + k), owen_scramble4(_mm_loadu_si128((const __m128i *)(v + k)),
                                                              _mm_loadu_si128((const __m128i *)(seed + k))));
    for (; k < n; k++)
        out[k] = truth_i_owen_scramble1(v[k], seed[k]);
}

/* One pixel's round of B samples, scrambled: ray k belongs to replicate r = k / (B/R) and takes
 * point i = k mod (B/R) of the round's points (round * B/R + i of the sequence), Owen-scrambled
 * with replicate r's two seeds (base 2) and digitally shifted with its base-3 shift. */
static void pixel_points(const ao_job *J, thread_scratch *S, const px_state *s)
{
    const int B = J->p.batch, R = J->p.replicates, m = B / R, B4 = (B + 3) & ~3;
    if (!J->ei.volume && (B & 3) == 0 && (m == 1 || m == 2 || (m & 3) == 0)) {
        /* The same lanes without the per-lane loop: the round's points for rays k .. k+3 are
         * S->v0/v1[k ..] (ao_tile lays them out once per round for all pixels), and the seeds of
         * their replicates come from one or two loads of s->shift: m = 2 (the default 16 / 8),
         * lanes (r, r, r+1, r+1); m = 1, lanes r .. r+3; m a multiple of 4, one replicate. */
        for (int k = 0; k < B; k += 4) {
            __m128i s0, s1;
            if (m == 2) {
                __m128i w = _mm_loadu_si128((const __m128i *)s->shift[k >> 1]); /* s0[r] s1[r] s0[r+1] s1[r+1] */
                s0 = _mm_shuffle_epi32(w, _MM_SHUFFLE(2, 2, 0, 0));
                s1 = _mm_shuffle_epi32(w, _MM_SHUFFLE(3, 3, 1, 1));
            } else if (m == 1) {
                __m128i a = _mm_loadu_si128((const __m128i *)s->shift[k]);     /* s0[r] s1[r] s0[r+1] s1[r+1] */
                __m128i b = _mm_loadu_si128((const __m128i *)s->shift[k + 2]); /* s0[r+2] s1[r+2] s0[r+3] s1[r+3] */
                a = _mm_shuffle_epi32(a, _MM_SHUFFLE(3, 1, 2, 0));             /* s0[r] s0[r+1] s1[r] s1[r+1] */
                b = _mm_shuffle_epi32(b, _MM_SHUFFLE(3, 1, 2, 0));
                s0 = _mm_unpacklo_epi64(a, b);
                s1 = _mm_unpackhi_epi64(a, b);
            } else {
                s0 = _mm_set1_epi32((int)s->shift[k / m][0]);
                s1 = _mm_set1_epi32((int)s->shift[k / m][1]);
            }
            _mm_store_si128((__m128i *)(S->u0 + k), owen_scramble4(_mm_load_si128((const __m128i *)(S->v0 + k)), s0));
            _mm_store_si128((__m128i *)(S->u1 + k), owen_scramble4(_mm_load_si128((const __m128i *)(S->v1 + k)), s1));
        }
        return;
    }
    for (int k = 0, r = 0, i = 0; k < B4; k += 4) {
        /* 4 rays at a time (owen_scramble4); padding lanes past B scramble 0 with seed 0, i.e. 0 */
        _Alignas(16) uint32_t v0[4], s0[4], v1[4], s1[4];
        for (int l = 0; l < 4; l++) {
            const int in = k + l < B;
            v0[l] = in ? S->b0[i] : 0u;
            v1[l] = in ? S->b1[i] : 0u;
            s0[l] = in ? s->shift[r][0] : 0u;
            s1[l] = in ? s->shift[r][1] : 0u;
            if (in && J->ei.volume)
                S->u2[k + l] = radical_inverse3_shifted(S->b2[i], s->shift3[r]);
            if (in && ++i == m) {
                i = 0;
                r++;
            }
        }
        _mm_store_si128((__m128i *)(S->u0 + k), owen_scramble4(_mm_load_si128((const __m128i *)v0),
                                                               _mm_load_si128((const __m128i *)s0)));
        _mm_store_si128((__m128i *)(S->u1 + k), owen_scramble4(_mm_load_si128((const __m128i *)v1),
                                                               _mm_load_si128((const __m128i *)s1)));
    }
    for (int k = B; k < B4; k++) /* padding: its directions are computed, never traced */
        S->u0[k] = S->u1[k] = S->u2[k] = 0u;
}

/* The B occlusion rays of one pixel's round: origin the offset point, tnear 0, tfar r. */
static void gen_hemisphere_occ(const ao_job *J, thread_scratch *S, const px_state *s, RTCRay *rays)
{
    const int B = J->p.batch, B4 = (B + 3) & ~3;
    pixel_points(J, S, s);
    local_dirs(S->u0, S->u1, B4, J->ei.cosine ? DIRS_COSINE : DIRS_UNIFORM, S->lx, S->ly, S->lz);
    world_dirs(s, S->lx, S->ly, S->lz, B4, S->d4);
    const __m128 org = _mm_setr_ps(s->org[0], s->org[1], s->org[2], 0.0f);
    const __m128 tail = _mm_castsi128_ps(_mm_setr_epi32((int)float_bits(J->p.radius), -1, 0, 0)); /* tfar, mask, id, flags */
    for (int i = 0; i < B; i++) {
        float *r = &rays[i].org_x;
        _mm_store_ps(r, org);
        _mm_store_ps(r + 4, S->d4[i]); /* time = 0 */
        _mm_store_ps(r + 8, tail);
    }
}

/* The same rays with a hit record, for the hit-distance estimators. */
static void gen_hemisphere_hit(const ao_job *J, thread_scratch *S, const px_state *s, RTCRayHit *rays)
{
    const int B = J->p.batch, B4 = (B + 3) & ~3;
    pixel_points(J, S, s);
    local_dirs(S->u0, S->u1, B4, J->ei.cosine ? DIRS_COSINE : DIRS_UNIFORM, S->lx, S->ly, S->lz);
    world_dirs(s, S->lx, S->ly, S->lz, B4, S->d4);
    const __m128 org = _mm_setr_ps(s->org[0], s->org[1], s->org[2], 0.0f);
    const __m128 tail = _mm_castsi128_ps(_mm_setr_epi32((int)float_bits(J->p.radius), -1, 0, 0));
    const __m128 h0 = _mm_setzero_ps(); /* Ng, u */
    const __m128 h1 = _mm_castsi128_ps(_mm_setr_epi32(0, (int)RTC_INVALID_GEOMETRY_ID, (int)RTC_INVALID_GEOMETRY_ID,
                                                      (int)RTC_INVALID_GEOMETRY_ID)); /* v, primID, geomID, instID */
    for (int i = 0; i < B; i++) {
        float *r = &rays[i].ray.org_x;
        _mm_store_ps(r, org);
        _mm_store_ps(r + 4, S->d4[i]);
        _mm_store_ps(r + 8, tail);
        _mm_store_ps(&rays[i].hit.Ng_x, h0);
        _mm_store_ps(&rays[i].hit.v, h1);
    }
}

int truth_i_avx2_active(void)
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

int truth_i_hemisphere_rays_sse2(const truth_i_hemi_in *in, void *rays)
{
    const int B = in->B, B4 = (B + 3) & ~3;
    ao_job J;
    thread_scratch S;
    memset(&J, 0, sizeof J);
    memset(&S, 0, sizeof S);
    J.p.batch = B;
    J.p.replicates = B / in->m;
    J.p.radius = in->radius;
    J.ei.cosine = in->cosine;
    uint32_t *w[7];
    float *f[3];
    int ok = 1;
    for (int k = 0; k < 7; k++)
        ok &= (w[k] = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * (size_t)B4)) != NULL;
    for (int k = 0; k < 3; k++)
        ok &= (f[k] = (float *)obs_aligned_alloc(sizeof(float) * (size_t)B4)) != NULL;
    S.d4 = (__m128 *)obs_aligned_alloc(sizeof(__m128) * (size_t)B4);
    ok &= S.d4 != NULL;
    if (ok) {
        S.v0 = w[0], S.v1 = w[1], S.b0 = w[2], S.b1 = w[3], S.u0 = w[4], S.u1 = w[5], S.u2 = w[6];
        S.lx = f[0], S.ly = f[1], S.lz = f[2];
        memcpy(S.v0, in->v0, sizeof(uint32_t) * (size_t)B);
        memcpy(S.v1, in->v1, sizeof(uint32_t) * (size_t)B);
        memcpy(S.b0, in->v0, sizeof(uint32_t) * (size_t)B); /* b0[i] = v0[i] for i < m (v0[k] = b0[k mod m]) */
        memcpy(S.b1, in->v1, sizeof(uint32_t) * (size_t)B);
        for (int a = 0; a < in->count; a++) {
            const char *px = in->base + (size_t)in->active[a] * in->stride;
            const float *fr = (const float *)(px + in->frame);
            const uint32_t(*shift)[2] = (const uint32_t(*)[2])(px + in->shift);
            px_state s;
            memset(&s, 0, sizeof s);
            for (int c = 0; c < 3; c++) {
                s.org[c] = fr[c];
                s.t[c] = fr[3 + c];
                s.b[c] = fr[6 + c];
                s.n[c] = fr[9 + c];
            }
            for (int r = 0; r < J.p.replicates && r < TRUTH_AO_MAX_REPLICATES; r++) {
                s.shift[r][0] = shift[r][0];
                s.shift[r][1] = shift[r][1];
            }
            if (in->hit)
                gen_hemisphere_hit(&J, &S, &s, (RTCRayHit *)rays + (size_t)a * B);
            else
                gen_hemisphere_occ(&J, &S, &s, (RTCRay *)rays + (size_t)a * B);
        }
    }
    for (int k = 0; k < 7; k++)
        obs_aligned_free(w[k]);
    for (int k = 0; k < 3; k++)
        obs_aligned_free(f[k]);
    obs_aligned_free(S.d4);
    return ok;
}

/* VOL: q = p + r cbrt(u3) w, w uniform on the sphere (DIRS_SPHERE), and the segment from the
 * eye (orthographic: from q's foot on the view plane) to q, as t in [0, 1]. */
static void gen_volume(const ao_job *J, thread_scratch *S, const px_state *s, RTCRay *rays)
{
    const int B = J->p.batch, B4 = (B + 3) & ~3;
    pixel_points(J, S, s);
    local_dirs(S->u0, S->u1, B4, DIRS_SPHERE, S->lx, S->ly, S->lz);
    world_dirs(s, S->lx, S->ly, S->lz, B4, S->d4);
    const float R = J->p.radius;
    const int persp = J->cam->projection == OBS_PROJECTION_PERSPECTIVE;
    for (int i = 0; i < B; i++) {
        float d[4];
        _mm_storeu_ps(d, S->d4[i]);
        uint32_t c = S->u2[i];
        float rad = R * cbrtf(((float)(c >> 8) + 0.5f) * 0x1p-24f);
        float qx = s->org[0] + rad * d[0], qy = s->org[1] + rad * d[1], qz = s->org[2] + rad * d[2];
        RTCRay *r = &rays[i];
        r->tnear = 0.0f;
        r->tfar = 1.0f;
        if (persp) {
            r->org_x = J->eye.x;
            r->org_y = J->eye.y;
            r->org_z = J->eye.z;
            r->dir_x = qx - J->eye.x;
            r->dir_y = qy - J->eye.y;
            r->dir_z = qz - J->eye.z;
        } else {
            /* q = C + X right + Y up + Zq back; its foot on the view plane is q - Zq back */
            float zq = (qx - J->eye.x) * J->cam_back.x + (qy - J->eye.y) * J->cam_back.y + (qz - J->eye.z) * J->cam_back.z;
            r->dir_x = zq * J->cam_back.x;
            r->dir_y = zq * J->cam_back.y;
            r->dir_z = zq * J->cam_back.z;
            r->org_x = qx - r->dir_x;
            r->org_y = qy - r->dir_y;
            r->org_z = qz - r->dir_z;
            if (!(zq < 0.0f)) { /* q behind the view plane: an empty segment, never occluded */
                r->dir_x = r->dir_y = 0.0f;
                r->dir_z = -1.0f;
                r->tfar = -1.0f;
            }
        }
        r->time = 0.0f;
        r->mask = 0xFFFFFFFFu;
        r->id = 0;
        r->flags = 0;
    }
}

/* Bit i set when ray i (of n, a multiple of 4, n <= 64) came back unoccluded: tfar != -inf
 * (NaN counts as unoccluded, as `tfar != -INFINITY` does). */
static inline uint64_t unoccluded_mask(const RTCRay *ry, int n)
{
    const __m128 ninf = _mm_set1_ps(-INFINITY);
    uint64_t bits = 0;
    for (int i = 0; i < n; i += 4) {
        __m128 t0 = _mm_load_ps(&ry[i].tfar), t1 = _mm_load_ps(&ry[i + 1].tfar); /* tfar, mask, id, flags */
        __m128 t2 = _mm_load_ps(&ry[i + 2].tfar), t3 = _mm_load_ps(&ry[i + 3].tfar);
        __m128 tf = _mm_movelh_ps(_mm_unpacklo_ps(t0, t1), _mm_unpacklo_ps(t2, t3)); /* 4 tfars */
        bits |= (uint64_t)_mm_movemask_ps(_mm_cmpneq_ps(tf, ninf)) << i;
    }
    return bits;
}

/* 1 when none of the n depths (n a multiple of 4) is a surface: !(d > 0 && d finite) for each,
 * the test ao_tile makes pixel by pixel. */
static inline int row_is_background(const float *depth, int n)
{
    const __m128 zero = _mm_setzero_ps(), inf = _mm_set1_ps(INFINITY);
    for (int i = 0; i < n; i += 4) {
        __m128 d = _mm_loadu_ps(depth + i);
        if (_mm_movemask_ps(_mm_and_ps(_mm_cmpgt_ps(d, zero), _mm_cmplt_ps(d, inf)))) /* 0 < d < inf */
            return 0;
    }
    return 1;
}

/* The unoccluded counts of two replicates (lanes r, r + 1) from their rays' bits: m = 2 (4 bits),
 * m = 1 (2 bits). Exact small integers, so acc + count is the same double as acc + (double)k. */
#define C2(a, b) {(double)(a), (double)(b)}
static const __m128d k_counts_m2[16] = {
    C2(0, 0), C2(1, 0), C2(1, 0), C2(2, 0), C2(0, 1), C2(1, 1), C2(1, 1), C2(2, 1),
    C2(0, 1), C2(1, 1), C2(1, 1), C2(2, 1), C2(0, 2), C2(1, 2), C2(1, 2), C2(2, 2)};
static const __m128d k_counts_m1[4] = {C2(0, 0), C2(1, 0), C2(0, 1), C2(1, 1)};
#undef C2

static const unsigned char k_popcount4[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};

static inline double falloff(falloff_kind k, double x) /* x = d^2 / r^2 in [0, 1] */
{
    double v = 1.0 - x;
    v = v > 0.0 ? v : 0.0;
    return k == FALLOFF_CUBIC ? v * v * v : v;
}

/* One output's replicate statistics from its R sums acc[r] (n samples, mr = n / R per replicate):
 * the mean mj = sum_r acc[r] / n and the spread se = sqrt(sum_r (acc[r]/mr - mj)^2 / (R (R - 1)))
 * [LEcuyer02]. Both sums run in r order, as plain loops would; the divisions and squares go two
 * replicates per SSE2 instruction (IEEE per lane: the same values). Inlined with R constant 8. */
static inline __attribute__((always_inline)) void replicate_stats(const double *acc, const int R, double n, double mr,
                                                                  double *mj_out, double *se_out)
{
    double tot = 0.0;
    for (int r = 0; r < R; r++)
        tot += acc[r];
    const double mj = tot / n;
    const __m128d mr2 = _mm_set1_pd(mr), mj2 = _mm_set1_pd(mj);
    double ss = 0.0;
    int r = 0;
    for (; r + 2 <= R; r += 2) {
        __m128d d = _mm_sub_pd(_mm_div_pd(_mm_loadu_pd(acc + r), mr2), mj2);
        d = _mm_mul_pd(d, d);
        ss += _mm_cvtsd_f64(d);
        ss += _mm_cvtsd_f64(_mm_unpackhi_pd(d, d));
    }
    for (; r < R; r++)
        ss += (acc[r] / mr - mj) * (acc[r] / mr - mj);
    *mj_out = mj;
    *se_out = sqrt(ss / ((double)R * (double)(R - 1)));
}

/* One tile: set up its pixels, then rounds of one ray batch each until every pixel stopped.
 * Returns the rays traced. */
static uint64_t ao_tile(ao_job *J, thread_scratch *S, int64_t tile)
{
    int x0, y0, x1, y1;
    obs_tiling_rect(&J->tiling, tile, &x0, &y0, &x1, &y1);
    const int B = J->p.batch, R = J->p.replicates, m = B / R;
    /* rows of background pixels only (the common case away from the object; bit y - y0), found
     * from the depth rows first: they need no other G-buffer plane */
    uint32_t bg_rows = 0;
    const int fast_bg = J->p.origin == TRUTH_AO_ORIGIN_GBUFFER && J->nout == 1 && ((x1 - x0) & 3) == 0;
    if (fast_bg)
        for (int y = y0; y < y1; y++)
            if (row_is_background(obs_image_f32_row(&J->gb->depth, y + J->guard) + J->guard + x0, x1 - x0))
                bg_rows |= 1u << (y - y0);
    if (bg_rows != (y1 - y0 < 32 ? (1u << (y1 - y0)) - 1u : 0xFFFFFFFFu)) {
        /* The tile's other rows in the G-buffer and output planes are strided: ask for all their
         * cache lines at once, so that the misses overlap instead of queueing pixel by pixel. */
        const rast_gbuffer *gb = J->gb;
        const int g = J->guard, from_gb = J->p.origin == TRUTH_AO_ORIGIN_GBUFFER;
        const size_t len = (size_t)(x1 - x0) * 4;
        /* each plane's first row in the tile and its row pitch (bytes), stepped row by row */
        const char *row[9] = {(const char *)(obs_image_f32_row(&J->out->mean, y0) + x0),
                              (const char *)(obs_image_f32_row(&J->out->std_error, y0) + x0),
                              (const char *)(obs_image_f32_row(&J->out->count, y0) + x0)};
        ptrdiff_t pitch[9] = {J->out->mean.stride * 4, J->out->std_error.stride * 4, J->out->count.stride * 4};
        int planes = 3;
        if (from_gb) {
            row[3] = (const char *)(obs_image_f32_row(&gb->depth, y0 + g) + x0 + g), pitch[3] = gb->depth.stride * 4;
            for (int c = 0; c < 3; c++) {
                row[4 + c] = (const char *)(obs_image_f32_row(&gb->face_normal[c], y0 + g) + x0 + g);
                pitch[4 + c] = gb->face_normal[c].stride * 4;
            }
            row[7] = (const char *)(obs_image_u32_row(&gb->prim_id, y0 + g) + x0 + g), pitch[7] = gb->prim_id.stride * 4;
            row[8] = (const char *)(obs_image_u32_row(&gb->instance_id, y0 + g) + x0 + g);
            pitch[8] = gb->instance_id.stride * 4;
            planes = 9;
        }
        for (int k = 0; k < planes; k++) { /* every cache line of [row, row + len), each row */
            const char *r = row[k];
            for (int y = y0; y < y1; y++, r += pitch[k]) {
                if (bg_rows >> (y - y0) & 1u)
                    continue;
                for (size_t off = 64; off < len; off += 64)
                    _mm_prefetch(r + off, _MM_HINT_T0);
                _mm_prefetch(r, _MM_HINT_T0);
                _mm_prefetch(r + len - 1, _MM_HINT_T0);
            }
        }
    }
    /* Set up the tile's surface pixels; the others get their output (mean 1, std_error 0,
     * count 0) at once. */
    int nactive = 0;
    const int from_gb = J->p.origin == TRUTH_AO_ORIGIN_GBUFFER;
    for (int y = y0; y < y1; y++) {
        const float *depth = from_gb ? obs_image_f32_row(&J->gb->depth, y + J->guard) + J->guard : NULL;
        float *om = obs_image_f32_row(&J->out->mean, y), *os = obs_image_f32_row(&J->out->std_error, y),
              *oc = obs_image_f32_row(&J->out->count, y);
        if (bg_rows >> (y - y0) & 1u) {
            /* a row of background pixels (the common case away from the object): the same outputs,
             * 4 at a time */
            for (int x = x0; x < x1; x += 4) {
                _mm_storeu_ps(om + x, _mm_set1_ps(1.0f));
                _mm_storeu_ps(os + x, _mm_setzero_ps());
                _mm_storeu_ps(oc + x, _mm_setzero_ps());
            }
            S->background += x1 - x0;
            continue;
        }
#if defined(OBS_HAVE_AVX2)
        if (J->setup8) {
            nactive = setup_row8(J, S, y, x0, x1, nactive, om, os, oc);
            continue;
        }
#endif
        for (int x = x0; x < x1; x++) {
            int state = 0;
            if (!from_gb || (depth[x] > 0.0f && isfinite(depth[x]))) {
                px_state *s = &S->px[nactive];
                setup_pixel(J, S, s, x, y);
                state = s->state;
            }
            if (state == 1) {
                S->active[nactive] = nactive;
                nactive++;
                continue;
            }
            om[x] = 1.0f;
            os[x] = 0.0f;
            oc[x] = 0.0f;
            for (int j = 1; j < J->nout; j++) {
                obs_image_f32_row(&J->outs[j].mean, y)[x] = 1.0f;
                obs_image_f32_row(&J->outs[j].std_error, y)[x] = 0.0f;
                obs_image_f32_row(&J->outs[j].count, y)[x] = 0.0f;
            }
            if (state == 0)
                S->background++;
            else
                S->invalid++;
        }
    }

    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx); /* RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, the default (build-notes.md) */
    const int hit_distance = J->ei.hit_distance || J->multi_hit;
    const int64_t max_n = J->p.max_samples, min_n = J->p.min_samples;
    uint64_t tile_rays = 0;
    for (int64_t round = 0; nactive > 0; round++) {
        /* this round's B/R points of the sequence, shared by the tile's pixels and replicates
         * (each shifts them): (van der Corput base 2, Sobol' dim 2) is a (0,2)-sequence
         * [Kollig02]; the third coordinate (VOL's radius) is van der Corput base 3, kept as the
         * index here and shifted digit by digit in pixel_points. */
        for (int i = 0; i < m; i++) {
            uint32_t idx = (uint32_t)(round * m + i);
            S->b0[i] = idx;                       /* van der Corput, bit-reversed back */
            S->b1[i] = bit_reverse32(sobol2(idx)); /* Sobol' dim 2, bit-reversed */
            S->b2[i] = idx;
        }
        for (int k = 0; k < B; k++) {
            S->v0[k] = S->b0[k % m];
            S->v1[k] = S->b1[k % m];
        }
        int nr = 0;
#if defined(OBS_HAVE_AVX2)
        if (J->avx2 && (B & 7) == 0 && !J->ei.volume) { /* every active pixel's rays in one pass */
            const truth_i_hemi_in in = {S->v0, S->v1, J->p.radius, B, m, J->ei.cosine, hit_distance,
                                        (const char *)S->px, sizeof(px_state), offsetof(px_state, org),
                                        offsetof(px_state, shift), S->active, nactive};
            truth_i_hemisphere_rays_avx2(&in, S->rays);
            nr = nactive * B;
        }
#endif
        for (int a = nr ? nactive : 0; a < nactive; a++) {
            const px_state *s = &S->px[S->active[a]];
            if (hit_distance)
                gen_hemisphere_hit(J, S, s, (RTCRayHit *)S->rays + nr);
            else if (J->ei.volume)
                gen_volume(J, S, s, (RTCRay *)S->rays + nr);
            else
                gen_hemisphere_occ(J, S, s, (RTCRay *)S->rays + nr);
            nr += B;
        }
        if (J->hooks && J->hooks->ray_sink)
            J->hooks->ray_sink(J->hooks->user, tile, round, S->rays, nr, hit_distance ? sizeof(RTCRayHit) : sizeof(RTCRay));
        if (hit_distance)
            rtcIntersect1M(J->ts->top, &ictx, (RTCRayHit *)S->rays, (unsigned)nr, sizeof(RTCRayHit));
        else
            rtcOccluded1M(J->ts->top, &ictx, (RTCRay *)S->rays, (unsigned)nr, sizeof(RTCRay));
        tile_rays += (uint64_t)nr;

        /* every active pixel of the tile started at round 0: each has taken (round + 1) B samples */
        const double fl = truth_ao_error_floor((round + 1) * B);
        int kept = 0;
        /* the defaults' case (one occlusion output, 16 rays, 8 replicates of 2) with its constants
         * in place: the same operations as the general loop below, in the same order */
        const int fast16 = !hit_distance && J->nout == 1 && B == 16 && R == 8;
        for (int a = 0; fast16 && a < nactive; a++) {
            px_state *s = &S->px[S->active[a]];
            const uint64_t bits = unoccluded_mask((const RTCRay *)S->rays + (size_t)a * 16, 16);
            for (int r = 0; r < 8; r += 2)
                _mm_storeu_pd(s->acc + r, _mm_add_pd(_mm_loadu_pd(s->acc + r), k_counts_m2[(bits >> (2 * r)) & 15u]));
            s->count += 16;
            const double n = (double)s->count, mr = n / 8;
            double mj, se;
            replicate_stats(s->acc, 8, n, mr, &mj, &se);
            const double mean = mj < 0.0 ? 0.0 : mj > 1.0 ? 1.0 : mj;
            const double bar = se > fl ? se : fl, worst = bar > 0.0 ? bar : 0.0;
            const int done_max = s->count >= max_n;
            const int done_target = s->count >= min_n && worst <= J->p.target_error;
            if (done_max || done_target) {
                const ptrdiff_t at = (ptrdiff_t)s->y * J->out->mean.stride + s->x;
                J->out->mean.data[at] = (float)mean;
                const double shown = J->p.error_bar == TRUTH_AO_BAR_REPLICATES ? se : bar;
                J->out->std_error.data[at] = (float)shown;
                J->out->count.data[at] = (float)s->count;
                S->converged[0] += bar <= J->p.target_error;
                S->max_se[0] = shown > S->max_se[0] ? shown : S->max_se[0];
                S->surface++;
                S->at_max += done_max;
            } else {
                S->active[kept++] = S->active[a];
            }
        }
        for (int a = 0; !fast16 && a < nactive; a++) {
            px_state *s = &S->px[S->active[a]];
            /* Each output's sample values, summed per replicate (ray k is replicate k / m's).
             * Occlusion rays (binary estimators alone; VOL): 1 where unoccluded (Embree marks an
             * occluded ray with tfar = -inf). Hit records: the closest hit within the output's
             * radius r_j (rays go to the largest radius; the closest hit within r_max is the
             * closest within r_j when t <= r_j, so each output gets exactly the values its own
             * single run would), then [t > r_j] or 1 - rho(t^2 / r_j^2). */
            if (hit_distance) {
                const RTCRayHit *h = (const RTCRayHit *)S->rays + (size_t)a * B;
                for (int j = 0; j < J->nout; j++) {
                    const float rj = J->radii[j];
                    double *acc = s->acc + (size_t)j * R;
                    for (int r = 0; r < R; r++) {
                        double sum = 0.0;
                        for (int i = r * m; i < r * m + m; i++) {
                            const int hit = h[i].hit.geomID != RTC_INVALID_GEOMETRY_ID && h[i].ray.tfar <= rj;
                            if (J->binary[j]) {
                                sum += hit ? 0.0 : 1.0;
                            } else if (hit) {
                                double dd = (double)h[i].ray.tfar; /* unit directions: the hit distance */
                                sum += 1.0 - falloff(J->fk[j], dd * dd * J->inv_r2s[j]);
                            } else {
                                sum += 1.0;
                            }
                        }
                        acc[r] += sum;
                    }
                }
            } else if (B <= 64 && (B & 3) == 0 && (m == 1 || m == 2 || m == 4)) {
                /* the same counts from a bit mask of the unoccluded rays, 4 rays per compare */
                const RTCRay *ry = (const RTCRay *)S->rays + (size_t)a * B;
                const uint64_t bits = unoccluded_mask(ry, B);
                if (m <= 2) { /* two replicates at a time (R is even): their counts from a table, as doubles */
                    const __m128d *tab = m == 2 ? k_counts_m2 : k_counts_m1;
                    const int per = 2 * m; /* bits of two replicates */
                    const uint64_t mask = (1u << per) - 1u;
                    uint64_t b = bits;
                    for (int r = 0; r < R; r += 2, b >>= per) {
                        const __m128d c = tab[b & mask];
                        _mm_storeu_pd(s->acc + r, _mm_add_pd(_mm_loadu_pd(s->acc + r), c));
                    }
                } else {
                    for (int r = 0; r < R; r++)
                        s->acc[r] += (double)k_popcount4[(bits >> (r * m)) & ((1u << m) - 1u)];
                }
            } else {
                const RTCRay *ry = (const RTCRay *)S->rays + (size_t)a * B;
                for (int r = 0; r < R; r++) {
                    int k = 0;
                    for (int i = r * m; i < r * m + m; i++)
                        k += ry[i].tfar != -INFINITY;
                    s->acc[r] += (double)k;
                }
            }
            s->count += B;
            /* Per output: the mean of the replicates' means, their spread s_R [LEcuyer02] and the
             * error bar max(s_R, floor(n)) [Agresti98]; the pixel stops when every output's bar is
             * within the target (after min_samples), or at max_samples. */
            const double n = (double)s->count, mr = n / R;
            double mean[TRUTH_AO_MAX_OUTPUTS], bar[TRUTH_AO_MAX_OUTPUTS], se_r[TRUTH_AO_MAX_OUTPUTS], worst = 0.0;
            for (int j = 0; j < J->nout; j++) {
                double mj, se;
                if (R == 8) /* the default, unrolled */
                    replicate_stats(s->acc + (size_t)j * R, 8, n, mr, &mj, &se);
                else
                    replicate_stats(s->acc + (size_t)j * R, R, n, mr, &mj, &se);
                mean[j] = mj < 0.0 ? 0.0 : mj > 1.0 ? 1.0 : mj;
                se_r[j] = se;
                bar[j] = se > fl ? se : fl;
                worst = bar[j] > worst ? bar[j] : worst;
            }
            const int done_max = s->count >= max_n;
            const int done_target = s->count >= min_n && worst <= J->p.target_error;
            if (done_max || done_target) {
                /* every output plane has the same stride (alloc_out_plane) */
                const ptrdiff_t at = (ptrdiff_t)s->y * J->out->mean.stride + s->x;
                for (int j = 0; j < J->nout; j++) {
                    J->outs[j].mean.data[at] = (float)mean[j];
                    const double shown = J->p.error_bar == TRUTH_AO_BAR_REPLICATES ? se_r[j] : bar[j];
                    J->outs[j].std_error.data[at] = (float)shown;
                    J->outs[j].count.data[at] = (float)s->count;
                    S->converged[j] += bar[j] <= J->p.target_error;
                    S->max_se[j] = shown > S->max_se[j] ? shown : S->max_se[j];
                }
                S->surface++;
                S->at_max += done_max;
            } else {
                S->active[kept++] = S->active[a];
            }
        }
        /* the active pixels' rays are regenerated densely next round */
        nactive = kept;
    }
    if (x1 == J->W) /* the tile at the right edge zeroes its rows' padding */
        for (int y = y0; y < y1; y++) {
            size_t pad = (size_t)(J->out->mean.stride - J->W) * sizeof(float);
            for (int j = 0; j < J->nout; j++) {
                memset(obs_image_f32_row(&J->outs[j].mean, y) + J->W, 0, pad);
                memset(obs_image_f32_row(&J->outs[j].std_error, y) + J->W, 0, pad);
                memset(obs_image_f32_row(&J->outs[j].count, y) + J->W, 0, pad);
            }
        }
    return tile_rays;
}

/* Tiles per task: at least 16 pixels wide (see ao_task). */
static int task_group(int tile) { return tile < 16 ? (16 + tile - 1) / tile : 1; }

/* A task is a run of `group` horizontally adjacent tiles, as many as make it at least 16 pixels
 * (64 bytes of an output row) wide: tiles that share a cache line of the output planes are then
 * written by the same thread (no false sharing between two 8-pixel tiles). */
static void ao_task(void *user, int64_t task, int thread)
{
    ao_job *J = (ao_job *)user;
    if (J->task_mask && !J->task_mask[task])
        return; /* another caller's task (truth_ao_render_tasks): its pixels stay zero */
    thread_scratch *S = &J->scratch[thread];
    const unsigned int saved_csr = _mm_getcsr();
    truth_thread_init(); /* FTZ/DAZ, as Embree asks; restored below */
    const int64_t groups_x = (J->tiling.tiles_x + J->group - 1) / J->group;
    const int64_t ty = task / groups_x, tx0 = (task % groups_x) * J->group;
    uint64_t rays = 0;
    int ntiles = 0;
    for (int64_t tx = tx0; tx < tx0 + J->group && tx < J->tiling.tiles_x; tx++, ntiles++)
        rays += ao_tile(J, S, ty * J->tiling.tiles_x + tx);
    S->rays_traced += rays;
    if (J->p.progress) { /* shared counters only when asked: their cache line is contended */
        int64_t done = atomic_fetch_add(&J->tiles_done, ntiles) + ntiles;
        uint64_t all = atomic_fetch_add(&J->rays_done, rays) + rays;
        if (thread == 0)
            J->p.progress(J->p.progress_user, done, obs_tiling_count(&J->tiling), all);
    }
    _mm_setcsr(saved_csr);
}

/* ------------------------------------------------------------------------------------------------
 * Entry points
 * ---------------------------------------------------------------------------------------------- */

/* An output plane, as obs_image_f32_alloc makes them (rows of a multiple of 16 floats, the same
 * limits, freed by obs_image_f32_free) but not zeroed: the tiles write every pixel and the row
 * padding. Large planes are 2 MiB aligned and advised for transparent huge pages: first touches
 * then fault 2 MiB at a time, not 4 KiB (on the reference VM, zero-filling three fresh 1080p
 * planes page by page took 60-80 ms, as long as 0.5 M rays; with huge pages about 2 ms). */
static obs_status alloc_out_plane(obs_context *ctx, int width, int height, obs_image_f32 *out)
{
    memset(out, 0, sizeof *out);
    const obs_limits *lim = obs_context_limits(ctx);
    size_t row = ((size_t)width + 15) & ~(size_t)15, elems, bytes;
    if (!obs_mul_size(row, (size_t)height, &elems) || !obs_mul_size(elems, sizeof(float), &bytes))
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "image size %dx%d overflows size_t", width, height);
    if ((int64_t)width * (int64_t)height > lim->max_image_pixels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d has %lld pixels, over the limit of %lld (raise it with --max-pixels)", width,
                         height, (long long)width * height, (long long)lim->max_image_pixels);
    if ((int64_t)bytes > lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "image %dx%d needs %lld bytes, over the limit of %lld (raise it with --max-memory)", width,
                         height, (long long)bytes, (long long)lim->max_memory_bytes);
    void *p = obs_aligned_alloc(bytes); /* huge-page advice for large planes (core/image.c) */
    if (!p)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes for a %dx%d image", bytes, width,
                         height);
    out->data = (float *)p;
    out->width = width;
    out->height = height;
    out->stride = (ptrdiff_t)row;
    return OBS_STATUS_OK;
}

static obs_status validate(obs_context *ctx, const truth_scene *ts, const obs_scene *scene, const obs_camera *cam,
                           const rast_gbuffer *gb, const truth_ao_params *p)
{
#define BAD(...) return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, __VA_ARGS__)
    if (!ts || !scene || !cam || !gb || !p)
        BAD("truth_ao_render: NULL argument");
    if ((unsigned)p->estimator >= TRUTH_AO_COUNT)
        BAD("truth_ao_render: estimator %d out of range", (int)p->estimator);
    if ((unsigned)p->normal >= TRUTH_AO_NORMAL_COUNT)
        BAD("truth_ao_render: normal %d out of range", (int)p->normal);
    if ((unsigned)p->error_bar >= TRUTH_AO_BAR_COUNT)
        BAD("truth_ao_render: error bar %d out of range", (int)p->error_bar);
    if ((unsigned)p->origin >= TRUTH_AO_ORIGIN_COUNT)
        BAD("truth_ao_render: origin %d out of range", (int)p->origin);
    const est_info *ei = &k_est[p->estimator];
    if (!(p->radius > 0.0f))
        BAD("truth_ao_render: radius %g must be > 0", (double)p->radius);
    if (isinf(p->radius) && ei->needs_finite_r)
        BAD("truth_ao_render: estimator '%s' needs a finite radius", ei->name);
    if (!(p->target_error >= 0.0) || !isfinite(p->target_error))
        BAD("truth_ao_render: target error %g must be finite and >= 0", p->target_error);
    if (p->batch < 2 || p->batch > 1024)
        BAD("truth_ao_render: batch %d must be in [2, 1024]", p->batch);
    if (p->replicates < 2 || p->replicates > TRUTH_AO_MAX_REPLICATES || p->batch % p->replicates)
        BAD("truth_ao_render: replicates %d must be in [2, %d] and divide the batch (%d)", p->replicates,
            TRUTH_AO_MAX_REPLICATES, p->batch);
    if (p->min_samples < p->batch || p->min_samples % p->batch)
        BAD("truth_ao_render: min samples %lld must be a positive multiple of the batch (%d)", (long long)p->min_samples,
            p->batch);
    if (p->max_samples < p->min_samples || p->max_samples % p->batch || p->max_samples > ((int64_t)1 << 31))
        BAD("truth_ao_render: max samples %lld must be a multiple of the batch (%d), >= min samples (%lld) and <= 2^31",
            (long long)p->max_samples, p->batch, (long long)p->min_samples);
    if (p->tile < 4 || p->tile > 32)
        BAD("truth_ao_render: tile %d must be in [4, 32]", p->tile);
    if (!(p->offset_ulps >= 0.0f) || !isfinite(p->offset_ulps))
        BAD("truth_ao_render: offset %g ulps must be finite and >= 0", (double)p->offset_ulps);
    if (gb->width < 1 || gb->height < 1 || gb->guard < 0 || gb->width - 2 * gb->guard < 1 ||
        gb->height - 2 * gb->guard < 1)
        BAD("truth_ao_render: G-buffer size %dx%d with guard %d is empty", gb->width, gb->height, gb->guard);
    if (gb->constants.full_width != gb->width || gb->constants.full_height != gb->height)
        BAD("truth_ao_render: the G-buffer's constants are not filled (render it with rast_render first)");
    if (p->origin == TRUTH_AO_ORIGIN_GBUFFER) {
        static const struct { uint32_t bit; const char *name; } need[] = {
            {RAST_OUT_DEPTH, "depth"}, {RAST_OUT_FACE_NORMAL, "face normal"}, {RAST_OUT_PRIM_ID, "primitive id"},
            {RAST_OUT_INSTANCE_ID, "instance id"}};
        for (size_t k = 0; k < sizeof need / sizeof need[0]; k++)
            if (!(gb->outputs & need[k].bit))
                BAD("truth_ao_render: the G-buffer lacks its %s plane (needed for origin = G-buffer)", need[k].name);
        if (p->normal == TRUTH_AO_NORMAL_SHADING && !(gb->outputs & RAST_OUT_NORMAL))
            BAD("truth_ao_render: the G-buffer lacks its shading-normal plane (needed for normal = shading)");
    }
    if (ts->instance_count != scene->instance_count || ts->mesh_count != scene->mesh_count)
        BAD("truth_ao_render: the Embree scene was not built from this scene (%u/%u instances, %u/%u meshes)",
            ts->instance_count, scene->instance_count, ts->mesh_count, scene->mesh_count);
    if (!obs_mat4_is_finite(cam->world))
        BAD("truth_ao_render: camera world matrix is not finite");
#undef BAD
    int64_t lim = obs_context_limits(ctx)->max_samples;
    if (p->max_samples > lim)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "truth_ao_render: max samples %lld per pixel is over the limit of %lld "
                         "(obs_limits.max_samples; raise it with --max-spp)",
                         (long long)p->max_samples, (long long)lim);
    return OBS_STATUS_OK;
}

obs_status truth_ao_render(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                           const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                           truth_ao_result *out)
{
    return truth_ao_render_ex(ctx, pool, ts, scene, camera, gb, p, out, NULL);
}

static obs_status render_outputs(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                                 const truth_ao_output *outputs, int nout, truth_ao_result *outs,
                                 const truth_ao_hooks *hooks, const unsigned char *task_mask);

obs_status truth_ao_render_ex(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                              const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                              truth_ao_result *out, const truth_ao_hooks *hooks)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render: NULL result");
    memset(out, 0, sizeof *out);
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render: NULL argument");
    truth_ao_output one = {p->estimator, p->radius};
    return render_outputs(ctx, pool, ts, scene, camera, gb, p, &one, 1, out, hooks, NULL);
}

int64_t truth_ao_task_count(int width, int height, int tile)
{
    if (width < 1 || height < 1 || tile < 1)
        return 0;
    const obs_tiling t = obs_tiling_make(width, height, tile);
    const int g = task_group(tile);
    return (int64_t)t.tiles_y * ((t.tiles_x + g - 1) / g);
}

void truth_ao_task_rect(int width, int height, int tile, int64_t task, int *x0, int *y0, int *x1, int *y1)
{
    const obs_tiling t = obs_tiling_make(width, height, tile);
    const int g = task_group(tile);
    const int64_t groups_x = (t.tiles_x + g - 1) / g;
    const int64_t ty = task / groups_x, tx0 = (task % groups_x) * g;
    *x0 = (int)(tx0 * tile);
    *y0 = (int)(ty * tile);
    *x1 = (int)((tx0 + g) * tile < width ? (tx0 + g) * tile : width);
    *y1 = *y0 + tile < height ? *y0 + tile : height;
}

obs_status truth_ao_render_tasks(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                                 const unsigned char *task_mask, truth_ao_result *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render_tasks: NULL result");
    memset(out, 0, sizeof *out);
    if (!p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render_tasks: NULL argument");
    truth_ao_output one = {p->estimator, p->radius};
    return render_outputs(ctx, pool, ts, scene, camera, gb, p, &one, 1, out, NULL, task_mask);
}

obs_status truth_ao_render_multi(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                                 const truth_ao_output *outputs, int count, truth_ao_result *out)
{
    if (!out || !outputs || !p)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render_multi: NULL argument");
    if (count < 1 || count > TRUTH_AO_MAX_OUTPUTS)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render_multi: %d outputs, must be in [1, %d]", count,
                         TRUTH_AO_MAX_OUTPUTS);
    memset(out, 0, sizeof *out * (size_t)count);
    truth_ao_params q = *p;
    q.estimator = outputs[0].estimator;
    q.radius = outputs[0].radius;
    if (count > 1) /* the shared rays' parameters: the family's binary estimator, which accepts any
                      radius (the largest output radius is taken below), whatever the outputs' order */
        q.estimator = k_est[outputs[0].estimator].cosine ? TRUTH_AO_COS : TRUTH_AO_UNIF;
    for (int j = 0; j < count; j++) {
        const truth_ao_output *o = &outputs[j];
        if ((unsigned)o->estimator >= TRUTH_AO_COUNT)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_ao_render_multi: output %d: estimator %d out of range",
                             j, (int)o->estimator);
        const est_info *ei = &k_est[o->estimator], *e0 = &k_est[outputs[0].estimator];
        if (!(o->radius > 0.0f) || (isinf(o->radius) && ei->needs_finite_r))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "truth_ao_render_multi: output %d: radius %g is not valid for estimator '%s'", j,
                             (double)o->radius, ei->name);
        if (count > 1 && (ei->volume || ei->cosine != e0->cosine))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "truth_ao_render_multi: output %d ('%s') cannot share rays with '%s': outputs must all be "
                             "cosine-weighted or all uniform hemisphere estimators, and 'vol' only alone",
                             j, ei->name, e0->name);
        q.radius = o->radius > q.radius ? o->radius : q.radius;
    }
    return render_outputs(ctx, pool, ts, scene, camera, gb, &q, outputs, count, out, NULL, NULL);
}

/* p->radius is the largest output radius (the rays' tfar); p->estimator the single output's, or
 * for several outputs (hit records, multi_hit) the binary estimator of their direction family. */
static obs_status render_outputs(obs_context *ctx, obs_pool *pool, const truth_scene *ts, const obs_scene *scene,
                                 const obs_camera *camera, const rast_gbuffer *gb, const truth_ao_params *p,
                                 const truth_ao_output *outputs, int nout, truth_ao_result *outs,
                                 const truth_ao_hooks *hooks, const unsigned char *task_mask)
{
    truth_ao_result *out = &outs[0];
    double t0 = obs_time_now();
    obs_status st = validate(ctx, ts, scene, camera, gb, p);
    if (st != OBS_STATUS_OK)
        return st;

    ao_job *J = (ao_job *)calloc(1, sizeof *J);
    if (!J)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_ao_render: out of memory");
    J->ts = ts;
    J->scene = scene;
    J->cam = camera;
    J->gb = gb;
    J->p = *p;
    J->ei = k_est[p->estimator];
    J->hooks = hooks;
    J->task_mask = task_mask;
    J->avx2 = truth_i_avx2_active();
#if defined(OBS_HAVE_AVX2)
    if (J->avx2)
        truth_i_philox_keys_make(p->seed, &J->keys);
#endif
    J->guard = gb->guard;
    J->W = gb->width - 2 * gb->guard;
    J->H = gb->height - 2 * gb->guard;
    J->tiling = obs_tiling_make(J->W, J->H, p->tile);
    J->outs = outs;
    J->nout = nout;
    J->multi_hit = nout > 1;
    for (int j = 0; j < nout; j++) {
        const est_info *ej = &k_est[outputs[j].estimator];
        J->radii[j] = outputs[j].radius;
        J->binary[j] = ej->falloff == FALLOFF_NONE;
        J->fk[j] = ej->falloff;
        J->inv_r2s[j] = isinf(outputs[j].radius) ? 0.0 : 1.0 / ((double)outputs[j].radius * (double)outputs[j].radius);
    }
    J->eye = obs_mat4_mul_point(camera->world, obs_v3(0, 0, 0));
    J->cam_back = obs_v3_normalize(obs_mat4_mul_dir(camera->world, obs_v3(0, 0, 1)));
    atomic_init(&J->tiles_done, 0);
    atomic_init(&J->rays_done, 0);
    const int threads = obs_pool_threads(pool);
    const size_t tile_px = (size_t)p->tile * (size_t)p->tile;
    size_t ray_bytes = 0;
    int ok = obs_mul_size(tile_px * (size_t)p->batch, J->ei.hit_distance || J->multi_hit ? sizeof(RTCRayHit) : sizeof(RTCRay),
                          &ray_bytes);
    if (!ok || (int64_t)ray_bytes > obs_context_limits(ctx)->max_memory_bytes) {
        free(J);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "truth_ao_render: ray scratch of %zu bytes over the memory limit",
                         ray_bytes);
    }
    size_t tri_total = 0;
    for (uint32_t m = 0; m < scene->mesh_count; m++)
        tri_total += scene->meshes[m].triangle_count; /* each < 2^32; the sum fits size_t on 64-bit */
    J->inst_norm = (float *)malloc(sizeof(float) * (scene->instance_count ? scene->instance_count : 1));
    J->mesh_first = (size_t *)malloc(sizeof(size_t) * (scene->mesh_count ? scene->mesh_count : 1));
    J->inst_bound = (double *)malloc(sizeof(double) * (scene->instance_count ? scene->instance_count : 1));
    J->scratch = (thread_scratch *)obs_aligned_alloc((size_t)threads * sizeof(thread_scratch));
    if (J->scratch)
        memset(J->scratch, 0, (size_t)threads * sizeof(thread_scratch));
    st = OBS_STATUS_OK;
    if (!J->inst_norm || !J->mesh_first || !J->inst_bound || !J->scratch) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_ao_render: out of memory");
        goto done;
    }
    for (int t = 0; t < threads && st == OBS_STATUS_OK; t++) {
        thread_scratch *S = &J->scratch[t];
        S->px = (px_state *)obs_aligned_alloc(tile_px * sizeof(px_state));
        S->active = (int *)malloc(tile_px * sizeof(int));
        S->rays = obs_aligned_alloc(ray_bytes);
        const size_t B4 = ((size_t)p->batch + 3) & ~(size_t)3;
        S->b0 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->b1 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->b2 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->lx = (float *)obs_aligned_alloc(sizeof(float) * B4);
        S->ly = (float *)obs_aligned_alloc(sizeof(float) * B4);
        S->lz = (float *)obs_aligned_alloc(sizeof(float) * B4);
        S->d4 = (__m128 *)obs_aligned_alloc(sizeof(__m128) * B4);
        S->u0 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->u1 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->u2 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->v0 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        S->v1 = (uint32_t *)obs_aligned_alloc(sizeof(uint32_t) * B4);
        const size_t per_px = (size_t)nout * (size_t)p->replicates;
        S->acc = (double *)obs_aligned_alloc(sizeof(double) * tile_px * per_px);
        if (!S->px || !S->active || !S->rays || !S->b0 || !S->b1 || !S->b2 || !S->lx || !S->ly || !S->lz || !S->d4 ||
            !S->u0 || !S->u1 || !S->u2 || !S->v0 || !S->v1 || !S->acc)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_ao_render: out of memory");
        else
            for (size_t k = 0; k < tile_px; k++)
                S->px[k].acc = S->acc + k * per_px;
    }
    if (st != OBS_STATUS_OK)
        goto done;
    /* the offset rule's triangle extents (docs/truth.md, "Self-intersection") */
    for (uint32_t i = 0; i < scene->instance_count; i++) {
        const float *w = scene->instances[i].world.m;
        float nrm = 0.0f;
        for (int r = 0; r < 3; r++) {
            float row = fabsf(w[r]) + fabsf(w[4 + r]) + fabsf(w[8 + r]);
            nrm = row > nrm ? row : nrm;
        }
        J->inst_norm[i] = nrm;
    }
    size_t first = 0;
    for (uint32_t m = 0; m < scene->mesh_count; m++) {
        J->mesh_first[m] = first;
        first += scene->meshes[m].triangle_count;
    }
    /* The pixel ray's constants (pixel_ray), and each instance's bound of its triangles' extents:
     * when it is <= the eye's magnitude (perspective: the same origin for every pixel), no pixel's
     * offset depends on a triangle extent, and the table is left out. */
    {
        const rast_view_constants *vc = &gb->constants;
        obs_dvec3 o, d;
        rast_pixel_ray(vc, camera, 0.5, 0.5, &o, &d);
        J->persp = vc->projection_type == OBS_PROJECTION_PERSPECTIVE;
        J->cx = vc->cx;
        J->cy = vc->cy;
        J->inv_fx = 1.0 / vc->fx; /* as rast_pixel_ray takes them */
        J->inv_fy = 1.0 / vc->fy;
        J->eye_o = o;
        const double mo = max3abs(o.x, o.y, o.z);
        J->mo = mo;
        J->setup8 = J->avx2 && J->persp && p->origin == TRUTH_AO_ORIGIN_GBUFFER && p->normal == TRUTH_AO_NORMAL_GEOMETRIC &&
                    !J->ei.volume && nout == 1;
        int need_table = !J->persp || p->origin != TRUTH_AO_ORIGIN_GBUFFER || !(mo >= 0.0);
        for (uint32_t i = 0; i < scene->instance_count; i++) {
            const uint32_t mesh = scene->instances[i].mesh;
            const double b = mesh < scene->mesh_count ? (double)mesh_extent_bound(&scene->meshes[mesh]) * (double)J->inst_norm[i]
                                                      : 0.0;
            J->inst_bound[i] = b;
            need_table |= !(b <= mo);
        }
        if (need_table) {
            J->tri_extent = (_Atomic uint32_t *)malloc(sizeof(uint32_t) * (tri_total ? tri_total : 1));
            if (!J->tri_extent) {
                st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_ao_render: out of memory");
                goto done;
            }
            for (size_t t = 0; t < tri_total; t++) /* filled at first use (triangle_extent) */
                atomic_init(&J->tri_extent[t], EXTENT_UNSET);
        }
    }

    for (int j = 0; j < nout && st == OBS_STATUS_OK; j++) {
        st = alloc_out_plane(ctx, J->W, J->H, &outs[j].mean);
        if (st == OBS_STATUS_OK)
            st = alloc_out_plane(ctx, J->W, J->H, &outs[j].std_error);
        if (st == OBS_STATUS_OK)
            st = alloc_out_plane(ctx, J->W, J->H, &outs[j].count);
        outs[j].width = J->W;
        outs[j].height = J->H;
    }
    if (st != OBS_STATUS_OK)
        goto done;
    if (task_mask) /* the tasks left out are not written by ao_task: zero, padding included */
        for (int j = 0; j < nout; j++) {
            obs_image_f32 *pl[3] = {&outs[j].mean, &outs[j].std_error, &outs[j].count};
            for (int k = 0; k < 3; k++)
                memset(pl[k]->data, 0, sizeof(float) * (size_t)pl[k]->stride * (size_t)pl[k]->height);
        }
    J->out = out;

    double tw = obs_time_now();
    J->group = task_group(p->tile);
    obs_pool_run(pool, (int64_t)J->tiling.tiles_y * ((J->tiling.tiles_x + J->group - 1) / J->group), ao_task, J);
    double t_work = obs_time_now() - tw;

    truth_ao_stats *stt = &out->stats;
    for (int t = 0; t < threads; t++) {
        const thread_scratch *S = &J->scratch[t];
        stt->rays += S->rays_traced;
        stt->primary_rays += S->primary_rays;
        stt->pixels_surface += S->surface;
        stt->pixels_background += S->background;
        stt->pixels_invalid += S->invalid;
        stt->pixels_at_max += S->at_max;
        stt->max_offset = S->max_eps > stt->max_offset ? S->max_eps : stt->max_offset;
    }
    stt->seconds = obs_time_now() - t0;
    stt->seconds_work = t_work;
    for (int j = 0; j < nout; j++) {
        if (j > 0)
            outs[j].stats = *stt; /* one ray set: the same counters ... */
        truth_ao_stats *sj = &outs[j].stats;
        sj->pixels_converged = 0; /* ... but each output's own convergence and error bars */
        sj->max_std_error = 0.0;
        for (int t = 0; t < threads; t++) {
            sj->pixels_converged += J->scratch[t].converged[j];
            sj->max_std_error = J->scratch[t].max_se[j] > sj->max_std_error ? J->scratch[t].max_se[j] : sj->max_std_error;
        }
    }

done:
    if (J->scratch)
        for (int t = 0; t < threads; t++) {
            obs_aligned_free(J->scratch[t].px);
            free(J->scratch[t].active);
            obs_aligned_free(J->scratch[t].rays);
            obs_aligned_free(J->scratch[t].b0);
            obs_aligned_free(J->scratch[t].b1);
            obs_aligned_free(J->scratch[t].b2);
            obs_aligned_free(J->scratch[t].lx);
            obs_aligned_free(J->scratch[t].ly);
            obs_aligned_free(J->scratch[t].lz);
            obs_aligned_free(J->scratch[t].d4);
            obs_aligned_free(J->scratch[t].u0);
            obs_aligned_free(J->scratch[t].u1);
            obs_aligned_free(J->scratch[t].u2);
            obs_aligned_free(J->scratch[t].v0);
            obs_aligned_free(J->scratch[t].v1);
            obs_aligned_free(J->scratch[t].acc);
        }
    obs_aligned_free(J->scratch);
    free(J->inst_norm);
    free(J->mesh_first);
    free(J->inst_bound);
    free((void *)J->tri_extent);
    free(J);
    if (st != OBS_STATUS_OK)
        for (int j = 0; j < nout; j++)
            truth_ao_result_free(&outs[j]);
    return st;
}
