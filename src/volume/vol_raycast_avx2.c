/* vol_raycast_avx2.c: the ray caster's run with AVX2 (compiled with -mavx2 and no
 * FMA; opt-in at run time with OBS_ISA=avx2, vol_i_rc_avx2_active: fewer instructions than the
 * scalar run but not faster in wall clock where measured). One
 * sample at a time, as the scalar run in vol_raycast.c (rc_trace_t), but the three axes of the
 * position and the splits are one vector each, and the trilinear sample's four x-lerps one vector
 * and its two y-lerps another. Each lane performs the scalar run's IEEE operations in the same
 * order (additions, multiplications, truncation, int -> double, double -> float: all exact or
 * correctly rounded in the default rounding mode, no contraction), so the image is the same bit for
 * bit (volume_raycast_avx2_run_matches_scalar_bit_for_bit). docs/volume/raycast.md, "Third round". */
#include "vol_raycast_internal.h"

#include <immintrin.h>
#include <string.h>

/* The run, specialised by the compiler for the precision and for shading (constants in the four
 * instances below), so the emission-absorption loop keeps its values in registers. */
static inline __attribute__((always_inline)) void rc_run(vol_i_rc_run *R, const int fast, const int shaded)
{
    const float *data = R->data;
    const size_t sy = R->sy, sz = R->sz;
    const __m256d c0 = _mm256_loadu_pd(R->c0), dc = _mm256_loadu_pd(R->dc);
    const __m256d o = _mm256_loadu_pd(R->o), d = _mm256_loadu_pd(R->d);
    const __m256d org = _mm256_loadu_pd(R->org), isp = _mm256_loadu_pd(R->inv_sp);
    const __m128i nel = _mm_loadu_si128((const __m128i *)R->nel);
    const __m128i um1 = _mm_set1_epi32((int)(R->urun - 1u)); /* x < urun  <=>  min(x, urun - 1) == x */
    const __m128 one = _mm_set1_ps(1.0f);
    const double t0 = R->t0, dt = R->dt, zb = R->zero_below, et = R->et;
    const int64_t kb = R->kb;
    double T = R->T, C0 = R->C[0], C1 = R->C[1], C2 = R->C[2];
    int64_t k = R->k, ns = 0, nsh = 0;
    int done = 0;
    for (; k <= kb; k++) {
        /* The position: fast c0 + k dc; exact (o + t_k d - org) inv_sp, t_k = t0 + (k + 1/2) dt. */
        __m256d c;
        if (fast) {
            c = _mm256_add_pd(c0, _mm256_mul_pd(_mm256_set1_pd((double)k), dc));
        } else {
            const double tm = t0 + ((double)k + 0.5) * dt;
            const __m256d xw = _mm256_add_pd(o, _mm256_mul_pd(_mm256_set1_pd(tm), d));
            c = _mm256_mul_pd(_mm256_sub_pd(xw, org), isp);
        }
        /* rc_split_inside per axis: f = (int)c (truncation; c > 0 here), t = (float)(c - f). */
        const __m128i f = _mm256_cvttpd_epi32(c);
        const __m128 t = _mm256_cvtpd_ps(_mm256_sub_pd(c, _mm256_cvtepi32_pd(f)));
        /* The brick test: (unsigned)v - nel < urun on every axis (lane 3: 0 - 0). */
        const __m128i x = _mm_sub_epi32(f, nel);
        if (_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(_mm_min_epu32(x, um1), x))) != 0xF)
            break;
        ns++;
        const int vx = _mm_cvtsi128_si32(f), vy = _mm_extract_epi32(f, 1), vz = _mm_extract_epi32(f, 2);
        const float *b = data + (size_t)vx + (size_t)vy * sy + (size_t)vz * sz;
        /* rc_sample_base: rows r00 = b, r10 = b + sy, r01 = b + sz, r11 = b + sy + sz, each the pair
         * (r[0], r[1]); A = the rows' r[0], Bv = their r[1]. */
        const __m128 q0 = _mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)b));
        const __m128 q1 = _mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(b + sy)));
        const __m128 q2 = _mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(b + sz)));
        const __m128 q3 = _mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(b + sy + sz)));
        const __m128 lo = _mm_movelh_ps(q0, q1), hi = _mm_movelh_ps(q2, q3);
        const __m128 A = _mm_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0));  /* r00[0] r10[0] r01[0] r11[0] */
        const __m128 Bv = _mm_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1)); /* r00[1] r10[1] r01[1] r11[1] */
        const __m128 u = _mm_sub_ps(one, t);                                /* ux uy uz */
        const __m128 tx = _mm_shuffle_ps(t, t, 0x00), ux = _mm_shuffle_ps(u, u, 0x00);
        /* c00 c10 c01 c11 = r[0] ux + r[1] tx */
        const __m128 X = _mm_add_ps(_mm_mul_ps(A, ux), _mm_mul_ps(Bv, tx));
        /* c0 = c00 uy + c10 ty, c1 = c01 uy + c11 ty (lanes 0 and 1) */
        const __m128 Y0 = _mm_shuffle_ps(X, X, _MM_SHUFFLE(2, 0, 2, 0)), Y1 = _mm_shuffle_ps(X, X, _MM_SHUFFLE(3, 1, 3, 1));
        const __m128 ty = _mm_shuffle_ps(t, t, 0x55), uy = _mm_shuffle_ps(u, u, 0x55);
        const __m128 Y = _mm_add_ps(_mm_mul_ps(Y0, uy), _mm_mul_ps(Y1, ty));
        /* c0 uz + c1 tz */
        const float tz = _mm_cvtss_f32(_mm_shuffle_ps(t, t, 0xAA)), uz = _mm_cvtss_f32(_mm_shuffle_ps(u, u, 0xAA));
        const float s = _mm_cvtss_f32(Y) * uz + _mm_cvtss_f32(_mm_shuffle_ps(Y, Y, 0x55)) * tz;
        if ((double)s <= zb)
            continue;
        float rgba[4], a;
        if (fast) {
            if (s != s)
                continue;
            /* rc_tf_table's arithmetic */
            float uu = (s - R->tft_lo) * R->tft_scale;
            if (!(uu > 0.0f))
                uu = 0.0f;
            if (uu > (float)(VOL_RC_FAST_TF_SIZE - 1))
                uu = (float)(VOL_RC_FAST_TF_SIZE - 1);
            int i = (int)uu;
            if (i > VOL_RC_FAST_TF_SIZE - 2)
                i = VOL_RC_FAST_TF_SIZE - 2;
            const float fr = uu - (float)i, e = 1.0f - fr;
            const float *p = R->tft + 4 * i;
            for (int q = 0; q < 4; q++)
                rgba[q] = p[q] * e + p[q + 4] * fr;
            if (!(rgba[3] > 0.0f))
                continue;
            a = rgba[3];
        } else {
            vol_i_rc_tf_eval(R->tf, s, rgba);
            if (!(rgba[3] > 0.0f))
                continue;
            a = vol_i_rc_alpha_full_step(rgba[3], R->h, R->ref_step);
        }
        nsh++;
        if (shaded) { /* Phong or light volume: vol_raycast.c's shading, on the same inputs */
            double cc[4];
            int v0[4];
            float tt[4];
            _mm256_storeu_pd(cc, c);
            _mm_storeu_si128((__m128i *)v0, f);
            _mm_storeu_ps(tt, t);
            R->shade(R->shade_user, k, cc, v0, tt, rgba);
        }
        /* [Porter84] "over", front to back, as the scalar run */
        const double w = T * (double)a;
        C0 += w * (double)rgba[0];
        C1 += w * (double)rgba[1];
        C2 += w * (double)rgba[2];
        T *= 1.0 - (double)a;
        if (1.0 - T >= et) {
            done = 1;
            break;
        }
    }
    R->k = k;
    R->T = T;
    R->C[0] = C0;
    R->C[1] = C1;
    R->C[2] = C2;
    R->samples += ns;
    R->shaded += nsh;
    R->done = done;
}

void vol_i_rc_run_avx2(vol_i_rc_run *R)
{
    if (R->fast) {
        if (R->shade)
            rc_run(R, 1, 1);
        else
            rc_run(R, 1, 0);
    } else {
        if (R->shade)
            rc_run(R, 0, 1);
        else
            rc_run(R, 0, 0);
    }
}
