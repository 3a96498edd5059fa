/* ao_sao_internal.h: what ao_sao.c shares with its AVX2 kernel (ao_sao_avx2.c) and the tests.
 * Not installed, not part of the API. */
#ifndef AO_SAO_INTERNAL_H
#define AO_SAO_INTERNAL_H

#include "ao.h"

#include <stdint.h>

/* The minimax kernels of ao_i_cos_sin on |r| <= pi/4 (fdlibm k_sin.c, k_cos.c; musl __sin.c,
 * __cos.c): sin r = r + r z (S1 + z (S2 + ... + z S6)), cos r = 1 - z/2 + z^2 (C1 + ... + z C6),
 * z = r^2, |error| < 2^-58. Shared by the scalar and AVX2 evaluations. */
#define AO_I_SIN_S1 -1.66666666666666324348e-01
#define AO_I_SIN_S2 8.33333333332248946124e-03
#define AO_I_SIN_S3 -1.98412698298579493134e-04
#define AO_I_SIN_S4 2.75573137070700676789e-06
#define AO_I_SIN_S5 -2.50507602534068634195e-08
#define AO_I_SIN_S6 1.58969099521155010221e-10
#define AO_I_COS_C1 4.16666666666666019037e-02
#define AO_I_COS_C2 -1.38888888888741095749e-03
#define AO_I_COS_C3 2.48015872894767294178e-05
#define AO_I_COS_C4 -2.75573143513906633035e-07
#define AO_I_COS_C5 2.08757232129817482790e-09
#define AO_I_COS_C6 -1.13596475577881948265e-11

/* The AO pass's instruction-set paths. AUTO: the widest the build and the CPU have (AVX512, then
 * AVX2), unless the environment sets OBS_ISA=scalar (as the rasterizer's RAST_ISA_AUTO) or
 * OBS_ISA=avx2 (at most AVX2). All paths give the same bytes (tests/test_ao_sao.c,
 * sao_simd_and_scalar_paths_are_bit_identical). AVX512 is the AVX2 kernel with its cos/sin on 8
 * doubles per register (ao_sao_avx512.c); the blur is AVX2's. */
typedef enum ao_i_sao_isa {
    AO_I_SAO_ISA_AUTO = 0,
    AO_I_SAO_ISA_SCALAR,
    AO_I_SAO_ISA_AVX2,
    AO_I_SAO_ISA_AVX512,
    AO_I_SAO_ISA_COUNT
} ao_i_sao_isa;

/* The AVX512 path needs GCC's #pragma GCC target on x86-64 (other compilers: AVX2 at most). */
#if defined(OBS_HAVE_AVX2) && defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define AO_I_SAO_HAVE_AVX512 1
#endif

/* 1 when the path is compiled in and the CPU runs it (SCALAR and AUTO: always). */
int ao_i_sao_isa_available(ao_i_sao_isa isa);

/* One AO pass, shared by the scalar and AVX2 row kernels. All planes in GL row order.
 * The depth pyramid lies in ONE block starting at levels[0].data: level l starts lvl_off[l]
 * floats after it, so that a gather can address any level with 32-bit indices. */
typedef struct ao_i_sao_job {
    const ao_sao_constants *k;
    const obs_image_f32 *levels;   /* [0..k->max_mip]; level 0 = CSZ */
    int32_t lvl_off[AO_SAO_MAX_MIP + 1];    /* element offset of level l from levels[0].data */
    int32_t lvl_stride[AO_SAO_MAX_MIP + 1]; /* row stride of level l (elements) */
    int32_t lvl_wm1[AO_SAO_MAX_MIP + 1];    /* width - 1 of level l */
    int32_t lvl_hm1[AO_SAO_MAX_MIP + 1];    /* height - 1 of level l */
    const ao_input *in;            /* G-buffer normals (our row order) */
    int rx0, ry0;                  /* region origin, GL coordinates */
    obs_image_f32 *ao;             /* region-sized, GL order */
    /* The pass's tasks are row segments of seg_w columns (a multiple of 8), taken tile by tile:
     * tiles of seg_w x seg_h pixels in row-major order, and the seg_h segments of a tile in row
     * order (ao_i_sao_segment). Any tiling gives the same bytes: every pixel is computed on its
     * own. ao_sao.c uses whole rows (SAO_SEG_W, measured there). */
    int seg_w, seg_h, segs_x;
    int64_t (*counts)[3];          /* per segment (row * segs_x + column segment): background,
                                    * degenerate normal, below min radius */
    /* Per-tap constants, hoisted out of the pixel loop (the same floats the shader computes):
     * alpha[t] = (float(t) + 0.5) * (1.0 / float(N)), alpha_angle[t] = alpha[t] * (tau * 6.28). */
    float alpha[AO_SAO_MAX_SAMPLES];
    float alpha_angle[AO_SAO_MAX_SAMPLES];
} ao_i_sao_job;

/* Task -> region row, columns [i0, i1) and counts slot (see ao_i_sao_job.seg_w). */
static inline void ao_i_sao_segment(const ao_i_sao_job *J, int task, int *row, int *i0, int *i1, int *slot)
{
    const int rh = J->ao->height, band = J->seg_h * J->segs_x; /* tasks per band of seg_h rows */
    const int by = task / band, rem = task % band;
    const int bh = rh - by * J->seg_h < J->seg_h ? rh - by * J->seg_h : J->seg_h; /* rows in this band */
    const int sx = rem / bh, r = by * J->seg_h + rem % bh;
    *row = r;
    *i0 = sx * J->seg_w;
    *i1 = *i0 + J->seg_w < J->ao->width ? *i0 + J->seg_w : J->ao->width;
    *slot = r * J->segs_x + sx;
}

/* One task (a row segment: ao_i_sao_segment) of the AO pass. */
void ao_i_sao_row_scalar(const ao_i_sao_job *J, int task);
#if defined(OBS_HAVE_AVX2)
void ao_i_sao_row_avx2(const ao_i_sao_job *J, int task);
#endif
#if defined(AO_I_SAO_HAVE_AVX512)
void ao_i_sao_row_avx512(const ao_i_sao_job *J, int task);
#endif

/* One pass of the separable blur (SAO_blur.pix), GL coordinates; task = destination row. */
typedef struct ao_i_sao_blur_job {
    const obs_image_f32 *a;        /* source AO; its pixel (0,0) is full-image (ax0, ay0) */
    int ax0, ay0;
    const obs_image_f32 *z;        /* key (CSZ), full image */
    obs_image_f32 *dst;            /* destination; its pixel (0,0) is full-image (dx0, dy0) */
    int dx0, dy0;
    int W, H;                      /* full image, for the edge clamp */
    int axis;                      /* 0: horizontal (axis (1,0)), 1: vertical (axis (0,1), GL up) */
    int stride;
    float edge_k;
} ao_i_sao_blur_job;

void ao_i_sao_blur_row_scalar(const ao_i_sao_blur_job *J, int task);
#if defined(OBS_HAVE_AVX2)
void ao_i_sao_blur_row_avx2(const ao_i_sao_blur_job *J, int task);
#endif

/* ao_sao_compute_constants with an explicit path (the tests run both in one binary). isa_used
 * (may be NULL) receives the path taken. Returns as ao_sao_compute_constants, and
 * UNSUPPORTED_ISA for a path this build or CPU lacks. */
obs_status ao_i_sao_compute_isa(obs_context *ctx, obs_pool *pool, const ao_input *in, const ao_sao_constants *k,
                                obs_image_f32 *out, obs_image_f32 *out_raw, ao_sao_stats *stats, ao_i_sao_isa isa,
                                ao_i_sao_isa *isa_used);

#endif
