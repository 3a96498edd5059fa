/* rng.c: Philox4x32-10 counter-based generator [Salmon11] and radical-inverse sequences.
 *
 * [Salmon11] J. K. Salmon, M. A. Moraes, R. O. Dror, D. E. Shaw, "Parallel Random Numbers: As Easy
 * as 1, 2, 3", SC'11. Philox-4x32: multipliers 0xD2511F53, 0xCD9E8D57 and Weyl key increments
 * 0x9E3779B9, 0xBB67AE85 (Table 2 / Random123's philox.h); 10 rounds is the recommended count.
 * The known-answer vectors of Random123's kat_vectors file are checked in tests/test_core.c. */
#include "obs.h"

#include <emmintrin.h>
#include <math.h>
#include <pthread.h>

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

void obs_philox4x32_10(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4])
{
    uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
    uint32_t k0 = key[0], k1 = key[1];
    for (int round = 0; round < 10; round++) {
        if (round > 0) { /* key schedule: bump between rounds */
            k0 += PHILOX_W0;
            k1 += PHILOX_W1;
        }
        uint64_t p0 = (uint64_t)PHILOX_M0 * c0;
        uint64_t p1 = (uint64_t)PHILOX_M1 * c2;
        uint32_t hi0 = (uint32_t)(p0 >> 32), lo0 = (uint32_t)p0;
        uint32_t hi1 = (uint32_t)(p1 >> 32), lo1 = (uint32_t)p1;
        c0 = hi1 ^ c1 ^ k0;
        c1 = lo1;
        c2 = hi0 ^ c3 ^ k1;
        c3 = lo0;
    }
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

/* The counter is (pixel lo, pixel hi, sample, dimension); the key is the 64-bit seed. Every
 * (pixel, sample, dimension, seed) tuple is a distinct counter/key pair, so streams never overlap. */
void obs_rng_u32x4(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed, uint32_t out[4])
{
    uint32_t ctr[4] = {(uint32_t)pixel, (uint32_t)(pixel >> 32), sample, dimension};
    uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32)};
    obs_philox4x32_10(ctr, key, out);
}

void obs_rng_u32x4_n_scalar(uint64_t pixel, uint32_t sample0, int n, uint32_t dimension, uint64_t seed,
                            uint32_t (*out)[4])
{
    for (int k = 0; k < n; k++)
        obs_rng_u32x4(pixel, sample0 + (uint32_t)k, dimension, seed, out[k]);
}

/* hi and lo 32-bit halves of m * c, per lane: pmuludq multiplies lanes 0 and 2; the odd lanes are
 * shifted down for a second one. */
static inline void mulhilo4(__m128i c, __m128i m, __m128i *hi, __m128i *lo)
{
    __m128i even = _mm_mul_epu32(c, m), odd = _mm_mul_epu32(_mm_srli_epi64(c, 32), m);
    /* even = (lo0, hi0, lo2, hi2), odd = (lo1, hi1, lo3, hi3) */
    __m128i l02 = _mm_shuffle_epi32(even, _MM_SHUFFLE(3, 1, 2, 0)); /* lo0 lo2 hi0 hi2 */
    __m128i l13 = _mm_shuffle_epi32(odd, _MM_SHUFFLE(3, 1, 2, 0));  /* lo1 lo3 hi1 hi3 */
    *lo = _mm_unpacklo_epi32(l02, l13);                             /* lo0 lo1 lo2 lo3 */
    *hi = _mm_unpackhi_epi32(l02, l13);                             /* hi0 hi1 hi2 hi3 */
}

void obs_rng_u32x4_n(uint64_t pixel, uint32_t sample0, int n, uint32_t dimension, uint64_t seed, uint32_t (*out)[4])
{
    const __m128i m0 = _mm_set1_epi32((int)PHILOX_M0), m1 = _mm_set1_epi32((int)PHILOX_M1);
    int k = 0;
    for (; k + 4 <= n; k += 4) {
        /* four Philox4x32-10 calls on the counters (pixel lo, pixel hi, sample0 + k + lane, dim) */
        __m128i c0 = _mm_set1_epi32((int)(uint32_t)pixel), c1 = _mm_set1_epi32((int)(uint32_t)(pixel >> 32));
        __m128i c2 = _mm_add_epi32(_mm_set1_epi32((int)(sample0 + (uint32_t)k)), _mm_setr_epi32(0, 1, 2, 3));
        __m128i c3 = _mm_set1_epi32((int)dimension);
        uint32_t k0 = (uint32_t)seed, k1 = (uint32_t)(seed >> 32);
        for (int round = 0; round < 10; round++) {
            if (round > 0) {
                k0 += PHILOX_W0;
                k1 += PHILOX_W1;
            }
            __m128i hi0, lo0, hi1, lo1;
            mulhilo4(c0, m0, &hi0, &lo0);
            mulhilo4(c2, m1, &hi1, &lo1);
            c0 = _mm_xor_si128(_mm_xor_si128(hi1, c1), _mm_set1_epi32((int)k0));
            c1 = lo1;
            c2 = _mm_xor_si128(_mm_xor_si128(hi0, c3), _mm_set1_epi32((int)k1));
            c3 = lo0;
        }
        /* transpose the four lanes' (c0, c1, c2, c3) into out[k .. k + 3] */
        __m128i t0 = _mm_unpacklo_epi32(c0, c1), t1 = _mm_unpackhi_epi32(c0, c1);
        __m128i t2 = _mm_unpacklo_epi32(c2, c3), t3 = _mm_unpackhi_epi32(c2, c3);
        _mm_storeu_si128((__m128i *)out[k], _mm_unpacklo_epi64(t0, t2));
        _mm_storeu_si128((__m128i *)out[k + 1], _mm_unpackhi_epi64(t0, t2));
        _mm_storeu_si128((__m128i *)out[k + 2], _mm_unpacklo_epi64(t1, t3));
        _mm_storeu_si128((__m128i *)out[k + 3], _mm_unpackhi_epi64(t1, t3));
    }
    obs_rng_u32x4_n_scalar(pixel, sample0 + (uint32_t)k, n - k, dimension, seed, out + k);
}

float obs_rng_float(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed)
{
    uint32_t w[4];
    obs_rng_u32x4(pixel, sample, dimension, seed, w);
    return obs_u32_to_unit_float(w[0]);
}

double obs_rng_double(uint64_t pixel, uint32_t sample, uint32_t dimension, uint64_t seed)
{
    uint32_t w[4];
    obs_rng_u32x4(pixel, sample, dimension, seed, w);
    uint64_t bits = ((uint64_t)w[0] << 21) ^ ((uint64_t)w[1] >> 11); /* 53 bits */
    bits &= ((uint64_t)1 << 53) - 1;
    return (double)bits * (1.0 / 9007199254740992.0);
}

/* Radical inverse phi_b(i) = sum_k d_k b^-(k+1) for i = sum_k d_k b^k [Halton60]. Base 2 is done
 * by bit reversal (exact); other bases accumulate in double, clamped below 1. */
double obs_radical_inverse(uint32_t base, uint64_t i)
{
    if (base < 2)
        return 0.0;
    if (base == 2) {
        uint64_t v = i;
        v = ((v & 0x5555555555555555ull) << 1) | ((v >> 1) & 0x5555555555555555ull);
        v = ((v & 0x3333333333333333ull) << 2) | ((v >> 2) & 0x3333333333333333ull);
        v = ((v & 0x0F0F0F0F0F0F0F0Full) << 4) | ((v >> 4) & 0x0F0F0F0F0F0F0F0Full);
        v = ((v & 0x00FF00FF00FF00FFull) << 8) | ((v >> 8) & 0x00FF00FF00FF00FFull);
        v = ((v & 0x0000FFFF0000FFFFull) << 16) | ((v >> 16) & 0x0000FFFF0000FFFFull);
        v = (v << 32) | (v >> 32);
        return (double)(v >> 11) * (1.0 / 9007199254740992.0);
    }
    const double inv = 1.0 / (double)base;
    uint64_t reversed = 0;
    double inv_pow = 1.0;
    while (i) {
        uint64_t next = i / base;
        uint64_t digit = i - next * base;
        reversed = reversed * base + digit;
        inv_pow *= inv;
        i = next;
    }
    double r = (double)reversed * inv_pow;
    return r < 0.99999999999999989 ? r : 0.99999999999999989;
}

static uint32_t g_primes[1000];
static pthread_once_t g_primes_once = PTHREAD_ONCE_INIT;

static void fill_primes(void)
{
    int count = 0; /* trial division by the primes found so far */
    for (uint32_t c = 2; count < 1000; c++) {
        int is_prime = 1;
        for (int k = 0; k < count && g_primes[k] * g_primes[k] <= c; k++)
            if (c % g_primes[k] == 0) {
                is_prime = 0;
                break;
            }
        if (is_prime)
            g_primes[count++] = c;
    }
}

uint32_t obs_prime(int n)
{
    if (n < 0 || n >= 1000)
        return 0;
    pthread_once(&g_primes_once, fill_primes);
    return g_primes[n];
}

double obs_cp_rotate(double u, double shift)
{
    double v = u + shift;
    v -= floor(v);
    return v < 1.0 ? v : 0.0;
}
