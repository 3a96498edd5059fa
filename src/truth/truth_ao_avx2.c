/* truth_ao_avx2.c: the AVX2 forms of truth_ao.c's per-pixel sampling, 8 rays (or 8 replicates)
 * per vector. Built with -mavx2 (no FMA: CMakeLists.txt turns contraction off) and called only
 * when the build has OBS_HAVE_AVX2, the CPU has AVX2 and OBS_ISA is not "scalar".
 *
 * Every function here performs, lane for lane, the same integer operations and the same IEEE
 * single-precision operations in the same order as its SSE2 reference in truth_ao.c (the
 * reference stays the path of every other machine), so the rays, and so the truth EXRs, are the
 * same bits (tests/test_truth_ao.c, truth_avx2_rays_and_seeds_equal_the_sse2_reference):
 *   - truth_i_seeds_avx2: the R replicate seeds, Philox4x32-10 [Salmon11] on eight counters at
 *     once (obs_rng_u32x4_n's arithmetic: 32x32 -> 64-bit products, xors, the Weyl key bump);
 *   - truth_i_hemisphere_rays_avx2: pixel_points (the Owen scramble [Burley20]), local_dirs (the
 *     concentric map [Shirley97] and the cosine / uniform lift [Malley88]), world_dirs (the ONB of
 *     [Duff17]) and the ray stores of gen_hemisphere_occ / gen_hemisphere_hit, fused into one
 *     pass per 8 rays. The bit reversal of the scrambled coordinate is a byte swap and two 16-entry
 *     nibble look-ups (pshufb), which reverse the same 32 bits as bit_reverse32's swaps.
 *
 * [Salmon11] J. K. Salmon et al., "Parallel Random Numbers: As Easy as 1, 2, 3", SC'11.
 * [Burley20], [Shirley97], [Malley88], [Duff17]: as in truth_ao.c's header. */
#include "truth_internal.h"

#if defined(OBS_HAVE_AVX2)

#include <immintrin.h>
#include <math.h>
#include <string.h>

#define PHILOX_M0 0xD2511F53u /* core/rng.c's constants [Salmon11] */
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

/* hi and lo halves of the 32x32 -> 64-bit products c * m, per lane. */
static inline void mulhilo8(__m256i c, __m256i m, __m256i *hi, __m256i *lo)
{
    __m256i even = _mm256_mul_epu32(c, m), odd = _mm256_mul_epu32(_mm256_srli_epi64(c, 32), m);
    *lo = _mm256_blend_epi32(even, _mm256_slli_epi64(odd, 32), 0xAA);
    *hi = _mm256_blend_epi32(_mm256_srli_epi64(even, 32), odd, 0xAA);
}

void truth_i_philox_keys_make(uint64_t seed, truth_i_philox_keys *k)
{
    uint32_t k0 = (uint32_t)seed, k1 = (uint32_t)(seed >> 32);
    for (int round = 0; round < 10; round++) {
        if (round > 0) { /* the key bump, mod 2^32 */
            k0 += PHILOX_W0;
            k1 += PHILOX_W1;
        }
        for (int l = 0; l < 8; l++) {
            k->k[round][0][l] = k0;
            k->k[round][1][l] = k1;
        }
    }
}

void truth_i_seeds_avx2(uint64_t pixel, int R, uint64_t seed, uint32_t (*shift)[2], uint64_t *shift3)
{
    truth_i_philox_keys k;
    truth_i_philox_keys_make(seed, &k);
    truth_i_seeds_avx2_k(pixel, R, &k, shift, shift3);
}

static inline __attribute__((always_inline)) void seeds_k(uint64_t pixel, int R, const truth_i_philox_keys *keys,
                                                          uint32_t (*shift)[2], uint64_t *shift3)
{
    const __m256i m0 = _mm256_set1_epi32((int)PHILOX_M0), m1 = _mm256_set1_epi32((int)PHILOX_M1);
    for (int r0 = 0; r0 < R; r0 += 8) {
        /* Philox(pixel lo, pixel hi, r0 + lane, 0) keyed by the seed: the counters of
         * obs_rng_u32x4_n(pixel, 0, R, 0, seed); the round keys come precomputed */
        __m256i c0 = _mm256_set1_epi32((int)(uint32_t)pixel), c1 = _mm256_set1_epi32((int)(uint32_t)(pixel >> 32));
        __m256i c2 = _mm256_add_epi32(_mm256_set1_epi32(r0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        __m256i c3 = _mm256_setzero_si256();
        for (int round = 0; round < 9; round++) {
            const __m256i k0 = _mm256_loadu_si256((const __m256i *)keys->k[round][0]);
            const __m256i k1 = _mm256_loadu_si256((const __m256i *)keys->k[round][1]);
            __m256i hi0, lo0, hi1, lo1;
            mulhilo8(c0, m0, &hi0, &lo0);
            mulhilo8(c2, m1, &hi1, &lo1);
            c0 = _mm256_xor_si256(_mm256_xor_si256(hi1, c1), k0);
            c1 = lo1;
            c2 = _mm256_xor_si256(_mm256_xor_si256(hi0, c3), k1);
            c3 = lo0;
        }
        { /* round 10: words 2, 3 (c0's product) only when asked for */
            __m256i hi1, lo1;
            mulhilo8(c2, m1, &hi1, &lo1);
            if (shift3) {
                __m256i hi0, lo0;
                mulhilo8(c0, m0, &hi0, &lo0);
                c2 = _mm256_xor_si256(_mm256_xor_si256(hi0, c3), _mm256_loadu_si256((const __m256i *)keys->k[9][1]));
                c3 = lo0;
            }
            c0 = _mm256_xor_si256(_mm256_xor_si256(hi1, c1), _mm256_loadu_si256((const __m256i *)keys->k[9][0]));
            c1 = lo1;
        }
        /* (c0, c1) interleaved are shift[r][0..1]; (c2, c3) interleaved are shift3[r] (lo, hi) */
        __m256i a0 = _mm256_unpacklo_epi32(c0, c1), a1 = _mm256_unpackhi_epi32(c0, c1); /* r 0 1 | 4 5; 2 3 | 6 7 */
        if (R - r0 >= 8) { /* a whole chunk: straight into place */
            _mm256_storeu_si256((__m256i *)shift[r0], _mm256_permute2x128_si256(a0, a1, 0x20));
            _mm256_storeu_si256((__m256i *)shift[r0 + 4], _mm256_permute2x128_si256(a0, a1, 0x31));
            if (shift3) {
                __m256i b0 = _mm256_unpacklo_epi32(c2, c3), b1 = _mm256_unpackhi_epi32(c2, c3);
                _mm256_storeu_si256((__m256i *)(shift3 + r0), _mm256_permute2x128_si256(b0, b1, 0x20));
                _mm256_storeu_si256((__m256i *)(shift3 + r0 + 4), _mm256_permute2x128_si256(b0, b1, 0x31));
            }
            continue;
        }
        _Alignas(32) uint32_t w01[16], w23[16];
        _mm256_store_si256((__m256i *)w01, _mm256_permute2x128_si256(a0, a1, 0x20));
        _mm256_store_si256((__m256i *)(w01 + 8), _mm256_permute2x128_si256(a0, a1, 0x31));
        const int n = R - r0;
        memcpy(shift[r0], w01, sizeof(uint32_t) * 2 * (size_t)n);
        if (shift3) {
            __m256i b0 = _mm256_unpacklo_epi32(c2, c3), b1 = _mm256_unpackhi_epi32(c2, c3);
            _mm256_store_si256((__m256i *)w23, _mm256_permute2x128_si256(b0, b1, 0x20));
            _mm256_store_si256((__m256i *)(w23 + 8), _mm256_permute2x128_si256(b0, b1, 0x31));
            memcpy(shift3 + r0, w23, sizeof(uint64_t) * (size_t)n); /* little-endian: (c2, c3) = c3 << 32 | c2 */
        }
    }
}

/* The low 32 bits of v * c: one vpmulld. */
void truth_i_seeds_avx2_k(uint64_t pixel, int R, const truth_i_philox_keys *keys, uint32_t (*shift)[2],
                          uint64_t *shift3)
{
    seeds_k(pixel, R, keys, shift, shift3);
}

void truth_i_seeds_n_avx2_k(int n, const uint64_t *pixel, uint32_t (*const *shift)[2], int R,
                            const truth_i_philox_keys *keys)
{
    for (int i = 0; i < n; i++)
        seeds_k(pixel[i], R, keys, shift[i], NULL);
}

static inline __m256i owen8(__m256i v, __m256i seed)
{
    v = _mm256_add_epi32(v, seed);
    v = _mm256_xor_si256(v, _mm256_mullo_epi32(v, _mm256_set1_epi32((int)0x6c50b47cu)));
    v = _mm256_xor_si256(v, _mm256_mullo_epi32(v, _mm256_set1_epi32((int)0xb82f1e52u)));
    v = _mm256_xor_si256(v, _mm256_mullo_epi32(v, _mm256_set1_epi32((int)0xc7afe638u)));
    v = _mm256_xor_si256(v, _mm256_mullo_epi32(v, _mm256_set1_epi32((int)0x8d22f6e6u)));
    /* bit reversal of each 32-bit lane: bytes swapped, then each byte's bits via two nibble
     * look-ups (rev4(lo) << 4 | rev4(hi)) */
    const __m256i bswap = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12, 3, 2, 1, 0, 7, 6, 5, 4,
                                           11, 10, 9, 8, 15, 14, 13, 12);
    const __m256i rev4 = _mm256_setr_epi8(0x0, 0x8, 0x4, 0xC, 0x2, 0xA, 0x6, 0xE, 0x1, 0x9, 0x5, 0xD, 0x3, 0xB, 0x7, 0xF,
                                          0x0, 0x8, 0x4, 0xC, 0x2, 0xA, 0x6, 0xE, 0x1, 0x9, 0x5, 0xD, 0x3, 0xB, 0x7, 0xF);
    const __m256i lo4 = _mm256_set1_epi8(0x0F);
    v = _mm256_shuffle_epi8(v, bswap);
    __m256i lo = _mm256_shuffle_epi8(rev4, _mm256_and_si256(v, lo4));
    __m256i hi = _mm256_shuffle_epi8(rev4, _mm256_and_si256(_mm256_srli_epi16(v, 4), lo4));
    return _mm256_or_si256(_mm256_slli_epi16(lo, 4), hi);
}

void truth_i_owen_scramble_avx2(const uint32_t *v, const uint32_t *seed, int n, uint32_t *out)
{
    int k = 0;
    for (; k + 8 <= n; k += 8)
        _mm256_storeu_si256((__m256i *)(out + k), owen8(_mm256_loadu_si256((const __m256i *)(v + k)),
                                                        _mm256_loadu_si256((const __m256i *)(seed + k))));
    for (; k < n; k++)
        out[k] = truth_i_owen_scramble1(v[k], seed[k]);
}

/* m ? a : b per lane, m a compare's all-ones / all-zeros mask: the bits of a or of b, as
 * sel_ps's and / andnot / or give them */
static inline __m256 sel8(__m256 m, __m256 a, __m256 b) { return _mm256_blendv_ps(b, a, m); }

static inline __m256 fixed_to_signed_unit8(__m256i u)
{
    __m256i odd = _mm256_sub_epi32(_mm256_or_si256(_mm256_srli_epi32(u, 7), _mm256_set1_epi32(1)),
                                   _mm256_set1_epi32(1 << 24));
    return _mm256_mul_ps(_mm256_cvtepi32_ps(odd), _mm256_set1_ps(0x1p-24f));
}

/* The seeds of rays k .. k+7: lane l takes replicate (k + l) / m's. */
static inline void lane_seeds(const uint32_t (*shift)[2], int k, int m, __m256i *s0, __m256i *s1)
{
    if (m == 2) { /* words s0 s1 of replicates r .. r+3 */
        __m256i w = _mm256_loadu_si256((const __m256i *)shift[k >> 1]);
        *s0 = _mm256_permutevar8x32_epi32(w, _mm256_setr_epi32(0, 0, 2, 2, 4, 4, 6, 6));
        *s1 = _mm256_permutevar8x32_epi32(w, _mm256_setr_epi32(1, 1, 3, 3, 5, 5, 7, 7));
    } else if (m == 1) { /* replicates r .. r+7 */
        const __m256i even = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
        __m256i a = _mm256_permutevar8x32_epi32(_mm256_loadu_si256((const __m256i *)shift[k]), even);
        __m256i b = _mm256_permutevar8x32_epi32(_mm256_loadu_si256((const __m256i *)shift[k + 4]), even);
        *s0 = _mm256_permute2x128_si256(a, b, 0x20);
        *s1 = _mm256_permute2x128_si256(a, b, 0x31);
    } else if (m % 8 == 0) {
        *s0 = _mm256_set1_epi32((int)shift[k / m][0]);
        *s1 = _mm256_set1_epi32((int)shift[k / m][1]);
    } else {
        _Alignas(32) uint32_t a[8], b[8];
        for (int l = 0; l < 8; l++) {
            a[l] = shift[(k + l) / m][0];
            b[l] = shift[(k + l) / m][1];
        }
        *s0 = _mm256_load_si256((const __m256i *)a);
        *s1 = _mm256_load_si256((const __m256i *)b);
    }
}

/* hit and cosine are constants in each call below, so each of the four forms is compiled with
 * its own stride and lift. */
static inline __attribute__((always_inline)) void hemisphere_rays(const truth_i_hemi_in *in, void *rays, const int hit,
                                                                  const int cosine)
{
    const __m256 absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
    const __m256 one = _mm256_set1_ps(1.0f), two = _mm256_set1_ps(2.0f), pi4 = _mm256_set1_ps(0.78539816339744831f);
    const __m256 c6 = _mm256_set1_ps(1.0f / 6.0f), c20 = _mm256_set1_ps(1.0f / 20.0f), c42 = _mm256_set1_ps(1.0f / 42.0f),
                 c72 = _mm256_set1_ps(1.0f / 72.0f);
    const __m256 c2 = _mm256_set1_ps(0.5f), c12 = _mm256_set1_ps(1.0f / 12.0f), c30 = _mm256_set1_ps(1.0f / 30.0f),
                 c56 = _mm256_set1_ps(1.0f / 56.0f), c90 = _mm256_set1_ps(1.0f / 90.0f);
    uint32_t rbits;
    memcpy(&rbits, &in->radius, sizeof rbits);
    const __m128 tail = _mm_castsi128_ps(_mm_setr_epi32((int)rbits, -1, 0, 0)); /* tfar, mask, id, flags */
    const __m128 h0 = _mm_setzero_ps();                                            /* Ng, u */
    const __m128 h1 = _mm_castsi128_ps(_mm_setr_epi32(0, (int)RTC_INVALID_GEOMETRY_ID, (int)RTC_INVALID_GEOMETRY_ID,
                                                      (int)RTC_INVALID_GEOMETRY_ID)); /* v, primID, geomID, instID */
    const int B = in->B, m = in->m;
    const size_t stride = (hit ? sizeof(RTCRayHit) : sizeof(RTCRay)) / sizeof(float);
    float *r = (float *)rays;
    for (int a = 0; a < in->count; a++) {
    const char *px = in->base + (size_t)in->active[a] * in->stride;
    const float *f = (const float *)(px + in->frame); /* org, t, b, n */
    const uint32_t(*shift)[2] = (const uint32_t(*)[2])(px + in->shift);
    const __m256 t0 = _mm256_broadcast_ss(f + 3), t1 = _mm256_broadcast_ss(f + 4), t2 = _mm256_broadcast_ss(f + 5);
    const __m256 b0 = _mm256_broadcast_ss(f + 6), b1 = _mm256_broadcast_ss(f + 7), b2 = _mm256_broadcast_ss(f + 8);
    const __m256 n0 = _mm256_broadcast_ss(f + 9), n1 = _mm256_broadcast_ss(f + 10), n2 = _mm256_broadcast_ss(f + 11);
    const __m128 org = _mm_setr_ps(f[0], f[1], f[2], 0.0f);
    const __m256 tail_org = _mm256_set_m128(org, tail); /* ray i's tfar.. flags, then ray i+1's origin */
    for (int k = 0; k < B; k += 8) {
        __m256i s0, s1;
        lane_seeds(shift, k, m, &s0, &s1);
        __m256i ua = owen8(_mm256_loadu_si256((const __m256i *)(in->v0 + k)), s0);
        __m256i ub = owen8(_mm256_loadu_si256((const __m256i *)(in->v1 + k)), s1);
        /* local_dirs */
        __m256 a = fixed_to_signed_unit8(ua), b = fixed_to_signed_unit8(ub);
        __m256 first = _mm256_cmp_ps(_mm256_and_ps(a, absmask), _mm256_and_ps(b, absmask), _CMP_GT_OQ);
        __m256 rad = sel8(first, a, b);
        __m256 q = _mm256_div_ps(sel8(first, b, a), rad);
        __m256 x = _mm256_mul_ps(pi4, q), x2 = _mm256_mul_ps(x, x);
        __m256 sn = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c42), _mm256_sub_ps(one, _mm256_mul_ps(x2, c72))));
        sn = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c20), sn));
        sn = _mm256_mul_ps(x, _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c6), sn)));
        __m256 cs = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c56), _mm256_sub_ps(one, _mm256_mul_ps(x2, c90))));
        cs = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c30), cs));
        cs = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c12), cs));
        cs = _mm256_sub_ps(one, _mm256_mul_ps(_mm256_mul_ps(x2, c2), cs));
        __m256 px = _mm256_mul_ps(rad, sel8(first, cs, sn)), py = _mm256_mul_ps(rad, sel8(first, sn, cs));
        __m256 rr = _mm256_mul_ps(rad, rad), pz;
        if (cosine) {
            pz = _mm256_sqrt_ps(_mm256_sub_ps(one, rr));
        } else {
            __m256 sc = _mm256_sqrt_ps(_mm256_sub_ps(two, rr));
            px = _mm256_mul_ps(px, sc);
            py = _mm256_mul_ps(py, sc);
            pz = _mm256_sub_ps(one, rr); /* xor with a zero sign: the same bits */
        }
        /* world_dirs */
        __m256 dx = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(px, t0), _mm256_mul_ps(py, b0)), _mm256_mul_ps(pz, n0));
        __m256 dy = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(px, t1), _mm256_mul_ps(py, b1)), _mm256_mul_ps(pz, n1));
        __m256 dz = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(px, t2), _mm256_mul_ps(py, b2)), _mm256_mul_ps(pz, n2));
        /* transposed to one (dx, dy, dz, 0) per ray: q_i holds rays i and i + 4 (one per 128-bit
         * half), from four unpacks and four shuffles */
        const __m256 zero8 = _mm256_setzero_ps();
        const __m256 t01 = _mm256_unpacklo_ps(dx, dy), t23 = _mm256_unpackhi_ps(dx, dy); /* x0 y0 x1 y1, x2 y2 x3 y3 */
        const __m256 z01 = _mm256_unpacklo_ps(dz, zero8), z23 = _mm256_unpackhi_ps(dz, zero8); /* z0 0 z1 0, z2 0 z3 0 */
        const __m256 q0 = _mm256_shuffle_ps(t01, z01, _MM_SHUFFLE(1, 0, 1, 0)), q1 = _mm256_shuffle_ps(t01, z01, _MM_SHUFFLE(3, 2, 3, 2));
        const __m256 q2 = _mm256_shuffle_ps(t23, z23, _MM_SHUFFLE(1, 0, 1, 0)), q3 = _mm256_shuffle_ps(t23, z23, _MM_SHUFFLE(3, 2, 3, 2));
        for (int half = 0; half < 2; half++) {
            const __m128 x4 = half ? _mm256_extractf128_ps(q0, 1) : _mm256_castps256_ps128(q0);
            const __m128 y4 = half ? _mm256_extractf128_ps(q1, 1) : _mm256_castps256_ps128(q1);
            const __m128 z4 = half ? _mm256_extractf128_ps(q2, 1) : _mm256_castps256_ps128(q2);
            const __m128 w4 = half ? _mm256_extractf128_ps(q3, 1) : _mm256_castps256_ps128(q3);
            if (!hit) { /* RTCRay: a ray's tail and the next one's origin are adjacent (the same bytes) */
                _mm_store_ps(r, org);
                _mm_store_ps(r + 4, x4); /* time = 0 */
                _mm256_storeu_ps(r + 8, tail_org);
                _mm_store_ps(r + stride + 4, y4);
                _mm256_storeu_ps(r + stride + 8, tail_org);
                _mm_store_ps(r + 2 * stride + 4, z4);
                _mm256_storeu_ps(r + 2 * stride + 8, tail_org);
                _mm_store_ps(r + 3 * stride + 4, w4);
                _mm_store_ps(r + 3 * stride + 8, tail);
                r += 4 * stride;
                continue;
            }
            _mm_store_ps(r, org);
            _mm_store_ps(r + 4, x4); /* time = 0 */
            _mm_store_ps(r + 8, tail);
            _mm_store_ps(r + stride, org);
            _mm_store_ps(r + stride + 4, y4);
            _mm_store_ps(r + stride + 8, tail);
            _mm_store_ps(r + 2 * stride, org);
            _mm_store_ps(r + 2 * stride + 4, z4);
            _mm_store_ps(r + 2 * stride + 8, tail);
            _mm_store_ps(r + 3 * stride, org);
            _mm_store_ps(r + 3 * stride + 4, w4);
            _mm_store_ps(r + 3 * stride + 8, tail);
            if (hit)
                for (int l = 0; l < 4; l++) {
                    _mm_store_ps(r + l * stride + 12, h0);
                    _mm_store_ps(r + l * stride + 16, h1);
                }
            r += 4 * stride;
        }
    }
    }
}

void truth_i_hemisphere_rays_avx2(const truth_i_hemi_in *in, void *rays)
{
    if (in->hit)
        in->cosine ? hemisphere_rays(in, rays, 1, 1) : hemisphere_rays(in, rays, 1, 0);
    else
        in->cosine ? hemisphere_rays(in, rays, 0, 1) : hemisphere_rays(in, rays, 0, 0);
}

/* truth_ao.c's setup_pixel, 8 pixels of a row per vector (its common case: G-buffer origin,
 * geometric normal, perspective), the same operations in the same order lane by lane:
 *   the face normal to world space (mul_dir, float), unit3 (1 / sqrt, zero when the squared length
 *   is not in (0, inf)), the pixel ray (pixel_ray, double, two 4-lane halves), p = o + depth d,
 *   the flip towards the viewer (double dot product), unit_ok, max3abs(p) (rounded to float as it
 *   returns), max with mo, the offset origin (double, rounded to float) and onb_duff ([Duff17]). */
static inline __m256d selpd(__m256d m, __m256d a, __m256d b) { return _mm256_blendv_pd(b, a, m); }

static inline __m256d max3abs4(__m256d x, __m256d y, __m256d z)
{
    const __m256d sign = _mm256_set1_pd(-0.0);
    __m256d m = _mm256_andnot_pd(sign, x), ay = _mm256_andnot_pd(sign, y), az = _mm256_andnot_pd(sign, z);
    m = selpd(_mm256_cmp_pd(ay, m, _CMP_GT_OQ), ay, m);
    m = selpd(_mm256_cmp_pd(az, m, _CMP_GT_OQ), az, m);
    return _mm256_cvtps_pd(_mm256_cvtpd_ps(m)); /* max3abs returns a float */
}

void truth_i_setup8_avx2(truth_i_setup8 *io)
{
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i lm = _mm256_cmpgt_epi32(_mm256_set1_epi32(io->count), lane);
    const __m256 dep = _mm256_maskload_ps(io->depth, lm);
    const __m256 fx = _mm256_maskload_ps(io->nx, lm), fy = _mm256_maskload_ps(io->ny, lm), fz = _mm256_maskload_ps(io->nz, lm);
    const float *w = io->world;
    /* mul_dir(&cam->world, nv) */
    __m256 ax = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(w[0]), fx), _mm256_mul_ps(_mm256_set1_ps(w[4]), fy)),
                              _mm256_mul_ps(_mm256_set1_ps(w[8]), fz));
    __m256 ay = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(w[1]), fx), _mm256_mul_ps(_mm256_set1_ps(w[5]), fy)),
                              _mm256_mul_ps(_mm256_set1_ps(w[9]), fz));
    __m256 az = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(w[2]), fx), _mm256_mul_ps(_mm256_set1_ps(w[6]), fy)),
                              _mm256_mul_ps(_mm256_set1_ps(w[10]), fz));
    /* unit3 */
    const __m256 zero = _mm256_setzero_ps(), inf = _mm256_set1_ps(INFINITY);
    __m256 l2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, ax), _mm256_mul_ps(ay, ay)), _mm256_mul_ps(az, az));
    __m256 okl = _mm256_and_ps(_mm256_cmp_ps(l2, zero, _CMP_GT_OQ), _mm256_cmp_ps(l2, inf, _CMP_LT_OQ));
    __m256 inv = _mm256_div_ps(_mm256_set1_ps(1.0f), _mm256_sqrt_ps(l2));
    __m256 nx = _mm256_and_ps(okl, _mm256_mul_ps(ax, inv)), ny = _mm256_and_ps(okl, _mm256_mul_ps(ay, inv)),
           nz = _mm256_and_ps(okl, _mm256_mul_ps(az, inv));
    /* pixel_ray, p and the flip: two halves of 4 pixels in double */
    const double ayd = -(io->py - io->cy) * io->inv_fy, azd = -1.0;
    const __m256d W0 = _mm256_set1_pd((double)w[0]), W1 = _mm256_set1_pd((double)w[1]), W2 = _mm256_set1_pd((double)w[2]);
    const __m256d W4ay = _mm256_set1_pd((double)w[4] * ayd), W5ay = _mm256_set1_pd((double)w[5] * ayd),
                  W6ay = _mm256_set1_pd((double)w[6] * ayd);
    const __m256d W8az = _mm256_set1_pd((double)w[8] * azd), W9az = _mm256_set1_pd((double)w[9] * azd),
                  W10az = _mm256_set1_pd((double)w[10] * azd);
    const __m256d ox = _mm256_set1_pd(io->o[0]), oy = _mm256_set1_pd(io->o[1]), oz = _mm256_set1_pd(io->o[2]);
    __m256d dx[2], dy[2], dz[2], px[2], py[2], pz[2];
    int flipbits = 0;
    for (int h = 0; h < 2; h++) {
        const __m256d pxl = _mm256_add_pd(_mm256_set1_pd(io->px0), _mm256_setr_pd(4 * h, 4 * h + 1, 4 * h + 2, 4 * h + 3));
        const __m256d axd = _mm256_mul_pd(_mm256_sub_pd(pxl, _mm256_set1_pd(io->cx)), _mm256_set1_pd(io->inv_fx));
        dx[h] = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(W0, axd), W4ay), W8az);
        dy[h] = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(W1, axd), W5ay), W9az);
        dz[h] = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(W2, axd), W6ay), W10az);
        const __m256d dd = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(dep, 1) : _mm256_castps256_ps128(dep));
        px[h] = _mm256_add_pd(ox, _mm256_mul_pd(dd, dx[h]));
        py[h] = _mm256_add_pd(oy, _mm256_mul_pd(dd, dy[h]));
        pz[h] = _mm256_add_pd(oz, _mm256_mul_pd(dd, dz[h]));
        const __m256d gx = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(nx, 1) : _mm256_castps256_ps128(nx));
        const __m256d gy = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(ny, 1) : _mm256_castps256_ps128(ny));
        const __m256d gz = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(nz, 1) : _mm256_castps256_ps128(nz));
        const __m256d dot = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(gx, dx[h]), _mm256_mul_pd(gy, dy[h])),
                                          _mm256_mul_pd(gz, dz[h]));
        flipbits |= _mm256_movemask_pd(_mm256_cmp_pd(dot, _mm256_setzero_pd(), _CMP_GT_OQ)) << (4 * h);
    }
    const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    const __m256 flip = _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(flipbits), bit), bit));
    const __m256 m1 = _mm256_set1_ps(-1.0f);
    nx = _mm256_blendv_ps(nx, _mm256_mul_ps(nx, m1), flip);
    ny = _mm256_blendv_ps(ny, _mm256_mul_ps(ny, m1), flip);
    nz = _mm256_blendv_ps(nz, _mm256_mul_ps(nz, m1), flip);
    /* unit_ok(ng), and the state */
    __m256 l = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, nx), _mm256_mul_ps(ny, ny)), _mm256_mul_ps(nz, nz));
    __m256 uok = _mm256_and_ps(_mm256_cmp_ps(l, _mm256_set1_ps(0.5f), _CMP_GT_OQ), _mm256_cmp_ps(l, _mm256_set1_ps(1.5f), _CMP_LT_OQ));
    __m256 surf = _mm256_and_ps(_mm256_cmp_ps(dep, zero, _CMP_GT_OQ), _mm256_cmp_ps(dep, inf, _CMP_LT_OQ));
    surf = _mm256_and_ps(surf, _mm256_castsi256_ps(lm));
    /* 1 surface, -1 invalid normal, 0 background */
    __m256i st = _mm256_and_si256(_mm256_castps_si256(surf),
                                  _mm256_blendv_epi8(_mm256_set1_epi32(-1), _mm256_set1_epi32(1), _mm256_castps_si256(uok)));
    _mm256_storeu_si256((__m256i *)io->state, st);
    _mm256_storeu_ps(io->ng[0], nx);
    _mm256_storeu_ps(io->ng[1], ny);
    _mm256_storeu_ps(io->ng[2], nz);
    /* the offset origin: m = max(max3abs(p), mo), eps = k m, org = (float)(p + eps ng) */
    const __m256d mo = _mm256_set1_pd(io->mo), k = _mm256_set1_pd(io->k);
    __m128 org[3][2];
    for (int h = 0; h < 2; h++) {
        __m256d m = max3abs4(px[h], py[h], pz[h]);
        m = selpd(_mm256_cmp_pd(mo, m, _CMP_GT_OQ), mo, m);
        _mm256_storeu_pd(io->m + 4 * h, m);
        _mm256_storeu_pd(io->p[0] + 4 * h, px[h]);
        _mm256_storeu_pd(io->p[1] + 4 * h, py[h]);
        _mm256_storeu_pd(io->p[2] + 4 * h, pz[h]);
        const __m256d eps = _mm256_mul_pd(k, m);
        const __m256d gx = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(nx, 1) : _mm256_castps256_ps128(nx));
        const __m256d gy = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(ny, 1) : _mm256_castps256_ps128(ny));
        const __m256d gz = _mm256_cvtps_pd(h ? _mm256_extractf128_ps(nz, 1) : _mm256_castps256_ps128(nz));
        org[0][h] = _mm256_cvtpd_ps(_mm256_add_pd(px[h], _mm256_mul_pd(eps, gx)));
        org[1][h] = _mm256_cvtpd_ps(_mm256_add_pd(py[h], _mm256_mul_pd(eps, gy)));
        org[2][h] = _mm256_cvtpd_ps(_mm256_add_pd(pz[h], _mm256_mul_pd(eps, gz)));
    }
    for (int c = 0; c < 3; c++)
        _mm256_storeu_ps(io->frame[c], _mm256_set_m128(org[c][1], org[c][0]));
    /* onb_duff(n): [Duff17], listing 3 */
    const __m256 sgnbit = _mm256_set1_ps(-0.0f), one = _mm256_set1_ps(1.0f);
    const __m256 sign = _mm256_or_ps(_mm256_and_ps(nz, sgnbit), one); /* copysignf(1, n2) */
    const __m256 a = _mm256_div_ps(m1, _mm256_add_ps(sign, nz));
    const __m256 bb = _mm256_mul_ps(_mm256_mul_ps(nx, ny), a);
    _mm256_storeu_ps(io->frame[3], _mm256_add_ps(one, _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(sign, nx), nx), a)));
    _mm256_storeu_ps(io->frame[4], _mm256_mul_ps(sign, bb));
    _mm256_storeu_ps(io->frame[5], _mm256_mul_ps(_mm256_xor_ps(sign, sgnbit), nx));
    _mm256_storeu_ps(io->frame[6], bb);
    _mm256_storeu_ps(io->frame[7], _mm256_add_ps(sign, _mm256_mul_ps(_mm256_mul_ps(ny, ny), a)));
    _mm256_storeu_ps(io->frame[8], _mm256_xor_ps(ny, sgnbit));
    _mm256_storeu_ps(io->frame[9], nx);
    _mm256_storeu_ps(io->frame[10], ny);
    _mm256_storeu_ps(io->frame[11], nz);
}

#endif
