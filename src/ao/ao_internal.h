/* ao_internal.h: cross-file internals of the AO module (prefix ao_i_), exposed to the tests. Not
 * installed, not part of the API. */
#ifndef AO_INTERNAL_H
#define AO_INTERNAL_H

#include <stdint.h>

/* cos and sin of a float angle, each rounded to float from a double-precision evaluation with an
 * exact argument reduction: the same floats as (float)cos((double)a), (float)sin((double)a) with a
 * correctly rounded libm, for every finite angle (checked exhaustively for |a| < 2^31, see
 * docs/ao/sao.md), using only IEEE double + - * (identical on every platform). */
void ao_i_cos_sin(float angle, float *c, float *s);

/* MT19937 [Matsumoto98]: init_genrand(seed) and genrand_int32, the generator of Wagner's MTRand
 * (MersenneTwister.h: MTRand::seed(s), randInt) used by the HBAO random textures (ao_hbao.c).
 * Reference outputs: seed 5489, the 10000th output is 4123659995 (ISO C++ [rand.predef]); seed 0
 * starts 2357136044, 2546248239. */
typedef struct ao_i_mt19937 {
    uint32_t s[624];
    int i;
} ao_i_mt19937;
void ao_i_mt19937_seed(ao_i_mt19937 *m, uint32_t seed);
uint32_t ao_i_mt19937_next(ao_i_mt19937 *m);

/* floor((float)log2(x)) for x > 0: the floor of the correctly rounded float log2 (which rounds
 * up to the next integer for x a few ulps below a power of two). x <= 0 or NaN: INT32_MIN;
 * +inf: INT32_MAX. */
int ao_i_floor_log2f(float x);

/* Window row y (0 .. in->h - 1) of an AO plane: background pixels (depth not finite and > 0) set to
 * exactly 1, the others kept. For the methods that run the seed's Gaussian, which is not depth-aware
 * and would leave 1 - 2.4e-7 or blurred-in AO on the sky (ao_blur.c, docs/ao/blur.md). */
struct ao_input;
void ao_i_background_to_one(const struct ao_input *in, int y, float *row);

/* A call's scratch kept between calls (ao_workspace.c), for the methods whose planes were fresh
 * allocations per call (MSSAO, MSSAO seed, HBAO, UE4): page faults cost ~13 us per 4 KiB page on
 * the development VM, more than the kernels' arithmetic on a coarse level. The i-th plane (buffer)
 * a call asks for reuses the memory of the i-th plane (buffer) of the previous call with the same
 * context and key, grown when needed. ao_i_ws_plane returns a plane exactly as obs_image_f32_alloc
 * does (the same size checks and errors, rows of 16-float multiples, ALL zeroed), so a kernel sees
 * the same bytes as with a fresh plane and its output cannot change; zeroing memory already
 * mapped costs ~1/50 of first-touching it. The planes belong to the workspace: never free them.
 * Usage: ws = ao_i_ws_take(ctx, &key) (NULL: out of memory); ao_i_ws_plane / ao_i_ws_buf ...;
 * ao_i_ws_put(ctx, &key, ws) on every path out (parks it in ctx, obs_context_scratch_put). */
#include "core/obs.h"
typedef struct ao_i_ws ao_i_ws;
ao_i_ws *ao_i_ws_take(obs_context *ctx, const void *key);
void ao_i_ws_put(obs_context *ctx, const void *key, ao_i_ws *ws);
obs_status ao_i_ws_plane(obs_context *ctx, ao_i_ws *ws, int width, int height, obs_image_f32 *out);
/* ao_i_ws_plane without the zeroing (the bytes a previous call left, or fresh memory's): only for a
 * plane whose caller writes every pixel of [0, width) x [0, height) before anything reads it, and
 * nothing reads the row padding. */
obs_status ao_i_ws_plane_unzeroed(obs_context *ctx, ao_i_ws *ws, int width, int height, obs_image_f32 *out);
/* bytes of memory (64-byte aligned, obs_aligned_alloc), zeroed when zero is set (calloc's
 * contract), else not (malloc's); NULL when out of memory. */
void *ao_i_ws_buf(ao_i_ws *ws, size_t bytes, int zero);
/* ao_blur_gaussian21 with its intermediate plane from ws (NULL: a fresh one) */
obs_status ao_i_blur_gaussian21_ws(obs_context *ctx, obs_pool *pool, ao_i_ws *ws, const obs_image_f32 *in,
                                   obs_image_f32 *out);

/* The method descriptors (ao.h, "The method registry"), one per technique file; ao_methods.c lists
 * them. */
struct ao_method;
extern const struct ao_method ao_i_method_crytek;     /* ao_crytek.c */
extern const struct ao_method ao_i_method_alchemy;    /* ao_alchemy.c */
extern const struct ao_method ao_i_method_sao;        /* ao_sao.c */
extern const struct ao_method ao_i_method_hbao;       /* ao_hbao.c */
extern const struct ao_method ao_i_method_ue4;        /* ao_ue4.c */
extern const struct ao_method ao_i_method_gtao;       /* ao_gtao.c */
extern const struct ao_method ao_i_method_mssao;      /* ao_mssao.c */
extern const struct ao_method ao_i_method_mssao_seed; /* ao_mssao_seed.c */

/* The Cody-Waite reduction of ao_i_cos_sin on a register of doubles (W: _mm256 or _mm512, T its
 * type), shared by the SAO and Alchemy vector cos/sin: kd = nearest integer to x * 2/pi (by the
 * 1.5 * 2^52 rounder), r = x - kd (P1 + P2 + P3 + P4), each step rounded (fdlibm's split of pi/2). */
#define AO_I_REDUCE_PIO2_PD(W, T, x, kd, r)                                                              \
    do {                                                                                                 \
        const T P1_ = W##_set1_pd(0x1.921fbp+0), P2_ = W##_set1_pd(0x1.5110bp-22),                       \
                P3_ = W##_set1_pd(0x1.18469800p-44), P4_ = W##_set1_pd(0x1.3198a2e037073p-69);           \
        const T ROUNDER_ = W##_set1_pd(0x1.8p52);                                                        \
        kd = W##_sub_pd(W##_add_pd(W##_mul_pd(x, W##_set1_pd(0x1.45f306dc9c883p-1)), ROUNDER_), ROUNDER_); \
        r = W##_sub_pd(x, W##_mul_pd(kd, P1_));                                                          \
        r = W##_sub_pd(r, W##_mul_pd(kd, P2_));                                                          \
        r = W##_sub_pd(r, W##_mul_pd(kd, P3_));                                                          \
        r = W##_sub_pd(r, W##_mul_pd(kd, P4_));                                                          \
    } while (0)

#endif
