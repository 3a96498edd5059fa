/* glsl_sss.c: the project's own GLSL port of the scattering-map gather (pass 2 of [DalCorso14]'s
 * pipeline; docs/sss/maps.md), re-typed in GLSL 4.50 for the harness (glh.h) after our C code,
 * which follows the thesis' final shader ss_array_render_to_arraymap_multilight_directional.frag
 * (../shared/reference/sss.md 3.4-3.5). The thesis' GPU method is this fragment pass; the port
 * checks that sss_maps.c is exactly it, within float rounding.
 *
 * What the port had to translate (docs/gl.md, "SSS scattering maps"):
 *   - Doubles. sss_maps.c does its geometry in double (x_o and n_o from the view G-buffer, the
 *     projection into the light map, the disk offset, the acceptance probability and the sample
 *     weights, the sums). GLSL 4.50 has double arithmetic and sqrt (ARB_gpu_shader_fp64, core in
 *     4.0; llvmpipe implements it) but no double exp, sin or cos, so the port carries its own:
 *     d_exp (Cody-Waite with fdlibm's split ln 2, degree-13 Taylor) and d_sincos (reduction by
 *     pi/2 in two parts, Taylor to degree 17/18), a few ulp from glibc's. A disk offset that
 *     differs by an ulp moves a tap across a texel edge only when it lies within ~1e-14 texel of
 *     it; an acceptance test flips only when exp(-sigma* r) lies within an ulp of a 24-bit zeta.
 *   - Double constants (view and light matrices as doubles, cx, cy, fx, fy, R, A_c, the light's
 *     direction, position and radiance, sigma*) travel as their bit patterns in an int uniform
 *     array and are rebuilt with packDouble2x32, so nothing is rounded through a decimal literal.
 *   - The float kernel (sss_batch.c sss_i_eval_scalar, T12 S_d) op for op, with our own exp
 *     (sss_i_expf: the magic-number rounding, the split ln 2, the Horner polynomial and 2^n from
 *     its bits, intBitsToFloat); the constants are the bits of sss_internal.h's macros. Every
 *     float and double temporary is `precise`: GLSL lets the compiler reassociate and contract
 *     (Mesa folds (t + MAGIC) - MAGIC, reassociates constant products and may fuse a * b + c),
 *     and `precise` keeps the order and rounding the C code has. Dot products are written out
 *     in our order ((a0 b0 + a1 b1) + a2 b2), max/min as the SSE-style selects of sss_i_maxf.
 *   - The random stream (sss_maps_internal.h): TEA-16 then the LCG, top 24 bits, in uint ops.
 *   - The nearest-texel light-map fetch is texelFetch at (int(tx), int(ty)), as ours.
 *   - Ids: material and instance ids are uploaded as floats (instance < 2^24; RAST_ID_NONE and
 *     opaque materials as -1: a CPU-side table maps a G-buffer material id to the material slot
 *     whose sss_gpu_constants the uniforms hold, as sss_maps.c's job_material does). Empty view
 *     texels have depth -1 (ours: +inf).
 *   - Empty light-map texels keep their NaN position and instance -1; the instance test alone
 *     rejects them, so the port does not depend on how Mesa treats isnan.
 *   - One pass draws all K layers as an atlas (layer k at x in [k size, (k + 1) size)); the
 *     thesis renders a layered texture array with one draw per layer. Same texels, same values.
 *   - llvmpipe flushes float subnormals to zero; ours does not. Only values below 1.2e-38 differ.
 *
 * The N-of-M sampler's candidate disk is our own sss_i_halton_disk_make (M points sorted by rho),
 * uploaded as an RG32F texture of M x 1, as a GPU renderer would hold it.
 *
 * The exponential sampler (ours, the default; sss_maps_internal.h sss_i_exp_sample) is float
 * arithmetic only in C (+ - * / sqrt, compares, bit manipulation), so the port follows it op for
 * op in float: -ln(1 - u1 Z) by the atanh series or sss_i_logf (frexp by floatBitsToUint), the
 * three Newton steps on t - ln(1 + t) = w, rho = min(t / sigma*, R), sss_i_sincos_2pi's quadrant
 * and Taylor polynomials, the weight w0 e^{sigma* rho} with the kernel's s_expf. Its float
 * constants (1/9, ..., 1/479001600, ln 2 in two parts, sqrt 2, pi/2, 1e-30) travel as the bits C
 * folded them to; its per-material constants (sigma*, R, T, q, Z, w0) come from sss_maps.c's own
 * sss_i_exp_disk_make, as uniforms. Then the float fetch (tx = fcx + ox ppu), the 3 x 3 near-field
 * block (its samples skipped, its 9 texels added after them with weight 1/ppu^2), and the double
 * sums into four partial sums by accepted-sample index mod 4, (s0 + s1) + (s2 + s3), as the scalar
 * C path sums them. */
#include "gl/glsl_sss.h"

#include "sss/sss_internal.h"
#include "sss/sss_maps_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
/* exp in double (GLSL has none): Cody-Waite with fdlibm's split ln 2, degree-13 Taylor, ldexp */
#define GLSL_D_EXP \
"double d_exp(double x) {\n" \
"  if (x < -745.0LF) return 0.0LF;\n" \
"  if (x > 709.0LF) x = 709.0LF;\n" \
"  precise double n = roundEven(x * DBL(0x652B82FEu, 0x3FF71547u)); /* x / ln 2 */\n" \
"  precise double r = (x - n * DBL(0xFEE00000u, 0x3FE62E42u)) - n * DBL(0x35793C76u, 0x3DEA39EFu);\n" \
"  precise double p = 1.0LF / 6227020800.0LF;\n" \
"  p = p * r + 1.0LF / 479001600.0LF;\n" \
"  p = p * r + 1.0LF / 39916800.0LF;\n" \
"  p = p * r + 1.0LF / 3628800.0LF;\n" \
"  p = p * r + 1.0LF / 362880.0LF;\n" \
"  p = p * r + 1.0LF / 40320.0LF;\n" \
"  p = p * r + 1.0LF / 5040.0LF;\n" \
"  p = p * r + 1.0LF / 720.0LF;\n" \
"  p = p * r + 1.0LF / 120.0LF;\n" \
"  p = p * r + 1.0LF / 24.0LF;\n" \
"  p = p * r + 1.0LF / 6.0LF;\n" \
"  p = p * r + 0.5LF;\n" \
"  p = p * r + 1.0LF;\n" \
"  p = p * r + 1.0LF;\n" \
"  precise double e = ldexp(p, int(n));\n" \
"  return e;\n" \
"}\n"

static const char *const fs_gather =
"#version 450\n"
"layout(binding=0) uniform sampler2D viewA;  /* (depth or -1, view-space normal) per texel, K layers side by side */\n"
"layout(binding=1) uniform sampler2D viewB;  /* (instance or -1, material slot or -1) */\n"
"layout(binding=2) uniform sampler2D lpos0;  /* light map 0: (world position, NaN where empty; instance or -1) */\n"
"layout(binding=3) uniform sampler2D lnrm0;  /* light map 0: world normal */\n"
"layout(binding=4) uniform sampler2D lpos1;\n"
"layout(binding=5) uniform sampler2D lnrm1;\n"
"layout(binding=6) uniform sampler2D hdisk;  /* N-of-M: (rho, phi) of the M sorted Halton points */\n"
"uniform int dbits[2 * ND];  /* the double constants, as bits */\n"
"uniform int lflags[NL];     /* bit 0: perspective light map, bit 1: point light */\n"
"uniform int seedx;          /* seed_lo ^ seed_hi */\n"
"uniform vec4 g_sigma_tr[NMAT], g_D[NMAT], g_de[NMAT], g_2ade[NMAT], g_bd2[NMAT], g_zr[NMAT], g_zv[NMAT];\n"
"uniform vec4 g_alpha[NMAT], g_misc0[NMAT], g_misc1[NMAT]; /* misc0: c_phi, c_e, norm_dir, eta; misc1.y: model */\n"
"layout(location=0) out vec4 result;\n"
"#define DBL(lo, hi) packDouble2x32(uvec2(lo, hi))\n"
"#define VB(k) ((k) * 20)\n"
"#define LB(l) (K * 20 + (l) * 29)\n"
"#define MB(s) (K * 20 + NL * 29 + (s))\n"
"#define GB (K * 20 + NL * 29 + NMAT)\n"
"double dc(int i) { return packDouble2x32(uvec2(uint(dbits[2 * i]), uint(dbits[2 * i + 1]))); }\n"
"\n"
"/* ---- the per-texel stream (sss_maps_internal.h) ---- */\n"
"uint tea16(uint v0, uint v1) {\n"
"  uint s0 = 0u;\n"
"  for (int n = 0; n < 16; n++) {\n"
"    s0 += 0x9e3779b9u;\n"
"    v0 += ((v1 << 4) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5) + 0xc8013ea4u);\n"
"    v1 += ((v0 << 4) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5) + 0x7e95761eu);\n"
"  }\n"
"  return v0;\n"
"}\n"
"float rnd(inout uint state) {\n"
"  state = 1664525u * state + 1013904223u;\n"
"  return float(state >> 8) * (1.0 / 16777216.0);\n"
"}\n"
"\n"
"/* ---- double exp, sin, cos (GLSL has none) ---- */\n"
GLSL_D_EXP
"dvec2 d_sincos(double x) { /* (sin x, cos x) */\n"
"  precise double n = roundEven(x * DBL(0x6DC9C883u, 0x3FE45F30u)); /* x * 2 / pi */\n"
"  precise double r = (x - n * DBL(0x54400000u, 0x3FF921FBu)) - n * DBL(0x1A626331u, 0x3DD0B461u);\n"
"  precise double r2 = r * r;\n"
"  precise double ps = 1.0LF / 355687428096000.0LF;\n"
"  ps = ps * r2 - 1.0LF / 1307674368000.0LF;\n"
"  ps = ps * r2 + 1.0LF / 6227020800.0LF;\n"
"  ps = ps * r2 - 1.0LF / 39916800.0LF;\n"
"  ps = ps * r2 + 1.0LF / 362880.0LF;\n"
"  ps = ps * r2 - 1.0LF / 5040.0LF;\n"
"  ps = ps * r2 + 1.0LF / 120.0LF;\n"
"  ps = ps * r2 - 1.0LF / 6.0LF;\n"
"  precise double s = r + (r * r2) * ps;\n"
"  precise double pc = 1.0LF / 6402373705728000.0LF;\n"
"  pc = pc * r2 - 1.0LF / 20922789888000.0LF;\n"
"  pc = pc * r2 + 1.0LF / 87178291200.0LF;\n"
"  pc = pc * r2 - 1.0LF / 479001600.0LF;\n"
"  pc = pc * r2 + 1.0LF / 3628800.0LF;\n"
"  pc = pc * r2 - 1.0LF / 40320.0LF;\n"
"  pc = pc * r2 + 1.0LF / 720.0LF;\n"
"  pc = pc * r2 - 1.0LF / 24.0LF;\n"
"  pc = pc * r2 + 0.5LF;\n"
"  precise double c = 1.0LF - r2 * pc;\n"
"  int q = int(n) & 3;\n"
"  return q == 0 ? dvec2(s, c) : q == 1 ? dvec2(c, -s) : q == 2 ? dvec2(-s, -c) : dvec2(-c, s);\n"
"}\n"
"\n"
"/* ---- the float kernel (sss_batch.c sss_i_eval_scalar, sss_internal.h) ---- */\n"
"float mx(float a, float b) { return a > b ? a : b; }\n"
"float mn(float a, float b) { return a < b ? a : b; }\n"
"float dotf(vec3 a, vec3 b) { precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z; return d; }\n"
"float s_expf(float xin) {\n"
"  if (xin < -87.0) return 0.0;\n"
"  precise float x = mn(xin, 88.0);\n"
"  precise float t = x * EXPF_LOG2E;\n"
"  precise float n = (t + EXPF_MAGIC) - EXPF_MAGIC;\n"
"  precise float r = (x - n * EXPF_LN2_HI) - n * EXPF_LN2_LO;\n"
"  precise float p = EXPF_C7;\n"
"  p = p * r + EXPF_C6;\n"
"  p = p * r + EXPF_C5;\n"
"  p = p * r + EXPF_C4;\n"
"  p = p * r + EXPF_C3;\n"
"  p = p * r + EXPF_C2;\n"
"  p = p * r + 1.0;\n"
"  p = p * r + 1.0;\n"
"  precise float scale = intBitsToFloat((int(n) + 127) << 23);\n"
"  precise float e = p * scale;\n"
"  return e;\n"
"}\n"
"float t12f(float cos_raw, float eta) {\n"
"  precise float c = mx(cos_raw, 0.0);\n"
"  c = mn(c, 1.0);\n"
"  precise float eta2 = eta * eta;\n"
"  precise float cos2_t = ((eta2 - 1.0) + c * c) / eta2;\n"
"  if (cos2_t <= 0.0) return 0.0;\n"
"  precise float cos_t = sqrt(cos2_t);\n"
"  precise float rs = (c - eta * cos_t) / (c + eta * cos_t);\n"
"  precise float rp = (eta * c - cos_t) / (eta * c + cos_t);\n"
"  precise float T = 1.0 - 0.5 * (rs * rs + rp * rp);\n"
"  return T;\n"
"}\n"
"float spf(float sigma_tr, float D, float c_phi, float c_e, vec3 x, vec3 w, float r, vec3 n) {\n"
"  precise float s = sigma_tr * r;\n"
"  precise float one_p = 1.0 + s;\n"
"  precise float x_w = dotf(x, w);\n"
"  precise float x_no = dotf(x, n);\n"
"  precise float w_no = dotf(w, n);\n"
"  precise float D3 = 3.0 * D;\n"
"  precise float t_phi = c_phi * (r * r / D + (3.0 * one_p) * x_w);\n"
"  precise float t_e = c_e * ((D3 * one_p) * w_no - (one_p + ((D3 * (3.0 * one_p + s * s)) / (r * r)) * x_w) * x_no);\n"
"  precise float e = s_expf(-s);\n"
"  precise float v = (e / ((r * r) * r)) * (t_phi - t_e);\n"
"  return v;\n"
"}\n"
"vec3 kernel(int ms, vec3 xo, vec3 no, vec3 xi, vec3 ni, vec3 wi) {\n"
"  float eta = g_misc0[ms].w;\n"
"  precise float eta2 = eta * eta;\n"
"  precise float norm_k = g_misc0[ms].z * INV_4PI2F;\n"
"  precise vec3 x = xo - xi;\n"
"  precise float r2 = dotf(x, x);\n"
"  precise float cos_i = dotf(wi, ni);\n"
"  precise float T = t12f(cos_i, eta);\n"
"  precise vec3 o = vec3(0.0);\n"
"  if (g_misc1[ms].y != 0.0) { /* [Jensen01] standard dipole */\n"
"    for (int c = 0; c < 3; c++) {\n"
"      if (g_alpha[ms][c] != 0.0) {\n"
"        float st = g_sigma_tr[ms][c], zr = g_zr[ms][c], zv = g_zv[ms][c];\n"
"        precise float dr = sqrt(r2 + zr * zr);\n"
"        precise float dv = sqrt(r2 + zv * zv);\n"
"        precise float sr = st * dr;\n"
"        precise float sv = st * dv;\n"
"        precise float real = ((zr * (1.0 + sr)) * s_expf(-sr)) / ((dr * dr) * dr);\n"
"        precise float virt = ((zv * (1.0 + sv)) * s_expf(-sv)) / ((dv * dv) * dv);\n"
"        o[c] = T * ((g_alpha[ms][c] * INV_4PI2F) * (real + virt));\n"
"      }\n"
"    }\n"
"    return o;\n"
"  }\n"
"  /* [Frisvad14] directional dipole */\n"
"  precise float r = sqrt(r2);\n"
"  precise float kk = mx(((eta2 - 1.0) + cos_i * cos_i) / eta2, 0.0);\n"
"  precise float a = (-cos_i) / eta + sqrt(kk);\n"
"  precise vec3 w = (-wi) / eta - ni * a;\n"
"  precise float wl = sqrt(dotf(w, w));\n"
"  w = w / wl;\n"
"  precise vec3 cr = vec3(ni.y * x.z - ni.z * x.y, ni.z * x.x - ni.x * x.z, ni.x * x.y - ni.y * x.x);\n"
"  precise float cl = sqrt(dotf(cr, cr));\n"
"  precise vec3 s = ni;\n"
"  if (cl > PAR_EPS_F * r) {\n"
"    precise vec3 h = x / r;\n"
"    precise vec3 e = cr / cl;\n"
"    s = vec3(h.y * e.z - h.z * e.y, h.z * e.x - h.x * e.z, h.x * e.y - h.y * e.x);\n"
"  }\n"
"  precise float mu0 = -dotf(no, w);\n"
"  precise float x_w12 = dotf(x, w);\n"
"  precise float wn2 = 2.0 * dotf(w, s);\n"
"  precise vec3 v = w - wn2 * s;\n"
"  precise float num = mx(r2 - x_w12 * x_w12, 0.0);\n"
"  for (int c = 0; c < 3; c++) {\n"
"    if (g_alpha[ms][c] != 0.0) {\n"
"      float D = g_D[ms][c], de = g_de[ms][c], st = g_sigma_tr[ms][c];\n"
"      precise float floor_d = FLOOR_D_F * D;\n"
"      precise float dr;\n"
"      if (mu0 > 0.0) {\n"
"        precise float cos_beta = -sqrt(num / (r2 + de * de));\n"
"        precise float Dmu0 = D * mu0;\n"
"        dr = sqrt(r2 + Dmu0 * (Dmu0 - (2.0 * de) * cos_beta));\n"
"      } else {\n"
"        dr = sqrt(r2 + g_bd2[ms][c]);\n"
"      }\n"
"      dr = mx(dr, floor_d);\n"
"      precise float ad = g_2ade[ms][c];\n"
"      precise vec3 y = x - ad * s;\n"
"      precise float dv = mx(sqrt(dotf(y, y)), floor_d);\n"
"      precise float sr = spf(st, D, g_misc0[ms].x, g_misc0[ms].y, x, w, dr, no);\n"
"      precise float sv = spf(st, D, g_misc0[ms].x, g_misc0[ms].y, y, v, dv, no);\n"
"      precise float sd = mx(norm_k * (sr - sv), 0.0);\n"
"      o[c] = T * sd;\n"
"    }\n"
"  }\n"
"  return o;\n"
"}\n"
"\n"
"/* ---- the exponential sampler (sss_maps_internal.h sss_i_exp_sample), float ops only ---- */\n"
"#if SAMPLER == 2\n"
"uniform vec4 g_ed0[NMAT]; /* sss_i_exp_disk: sigma*, R, T, q */\n"
"uniform vec4 g_ed1[NMAT]; /* Z, w0 */\n"
"float s_logf(float y) {\n"
"  uint b = floatBitsToUint(y);\n"
"  int e = int(b >> 23) - 127;\n"
"  precise float m = uintBitsToFloat((b & 0x007fffffu) | 0x3f800000u);\n"
"  if (m > CF_SQRT2) { m = m * 0.5; e = e + 1; }\n"
"  precise float s = (m - 1.0) / (m + 1.0);\n"
"  precise float s2 = s * s;\n"
"  precise float p = CF_I9;\n"
"  p = p * s2 + CF_I7;\n"
"  p = p * s2 + CF_I5;\n"
"  p = p * s2 + CF_I3;\n"
"  precise float lnm = (2.0 * s) + (2.0 * s) * (s2 * p);\n"
"  precise float ef = float(e);\n"
"  precise float l = ef * CF_LN2_HI + (ef * CF_LN2_LO + lnm);\n"
"  return l;\n"
"}\n"
"float s_atanh_tail(float s) {\n"
"  precise float s2 = s * s;\n"
"  precise float p = CF_I15;\n"
"  p = p * s2 + CF_I13;\n"
"  p = p * s2 + CF_I11;\n"
"  p = p * s2 + CF_I9;\n"
"  p = p * s2 + CF_I7;\n"
"  p = p * s2 + CF_I5;\n"
"  p = p * s2 + CF_I3;\n"
"  precise float r = (2.0 * s) * (s2 * p);\n"
"  return r;\n"
"}\n"
"float s_exp_g(float t, float w) {\n"
"  if (t < 0.5) {\n"
"    precise float s = t / (2.0 + t);\n"
"    precise float g = ((t * t) / (2.0 + t) - s_atanh_tail(s)) - w;\n"
"    return g;\n"
"  }\n"
"  precise float g2 = (t - s_logf(1.0 + t)) - w;\n"
"  return g2;\n"
"}\n"
"vec3 exp_sample(int ms, float u1, float u2) {\n"
"  float sigma = g_ed0[ms].x, Rf = g_ed0[ms].y, T = g_ed0[ms].z, q = g_ed0[ms].w, Z = g_ed1[ms].x, w0 = g_ed1[ms].y;\n"
"  /* the radius t = sigma rho (sss_i_exp_t) */\n"
"  precise float v = u1 * Z;\n"
"  precise float w;\n"
"  if (v <= 0.5) {\n"
"    precise float s = v / (2.0 - v);\n"
"    w = 2.0 * s + s_atanh_tail(s);\n"
"  } else {\n"
"    precise float a = (1.0 - u1) + u1 * q;\n"
"    w = -s_logf(a);\n"
"  }\n"
"  precise float t = w + sqrt(2.0 * w);\n"
"  for (int it = 0; it < 3; it++) {\n"
"    precise float g = s_exp_g(t, w);\n"
"    t = t - (g * (1.0 + t)) / mx(t, CF_TINY);\n"
"  }\n"
"  t = mn(mx(t, 0.0), T);\n"
"  precise float rho = mn(t / sigma, Rf);\n"
"  /* cos and sin of 2 pi u2 (sss_i_sincos_2pi) */\n"
"  precise float u4 = 4.0 * u2;\n"
"  int k = int(u4);\n"
"  precise float a = (u4 - float(k)) * CF_HALF_PI;\n"
"  precise float a2 = a * a;\n"
"  precise float ps = -CF_F11;\n"
"  ps = ps * a2 + CF_F9;\n"
"  ps = ps * a2 - CF_F7;\n"
"  ps = ps * a2 + CF_F5;\n"
"  ps = ps * a2 - CF_F3;\n"
"  precise float sa = a + a * (a2 * ps);\n"
"  precise float pc = CF_F12;\n"
"  pc = pc * a2 - CF_F10;\n"
"  pc = pc * a2 + CF_F8;\n"
"  pc = pc * a2 - CF_F6;\n"
"  pc = pc * a2 + CF_F4;\n"
"  pc = pc * a2 - 0.5;\n"
"  precise float ca = 1.0 + a2 * pc;\n"
"  float c1 = (k & 1) != 0 ? -sa : ca, s1 = (k & 1) != 0 ? ca : sa;\n"
"  float c = (k & 2) != 0 ? -c1 : c1, sn = (k & 2) != 0 ? -s1 : s1;\n"
"  precise float ox = rho * c;\n"
"  precise float oy = rho * sn;\n"
"  precise float ew = w0 * s_expf(sigma * rho);\n"
"  return vec3(ox, oy, ew);\n"
"}\n"
"#endif\n"
"\n"
"vec4 lpos(int l, ivec2 t) { return l == 0 ? texelFetch(lpos0, t, 0) : texelFetch(lpos1, t, 0); }\n"
"vec4 lnrm(int l, ivec2 t) { return l == 0 ? texelFetch(lnrm0, t, 0) : texelFetch(lnrm1, t, 0); }\n"
"int lsize(int l) { return l == 0 ? textureSize(lpos0, 0).x : textureSize(lpos1, 0).x; }\n"
"\n"
"/* ---- the gather (sss_maps.c build_task and gather_light) ---- */\n"
"void main() {\n"
"  ivec2 P = ivec2(gl_FragCoord.xy);\n"
"  int k = P.x / SIZE, x = P.x - k * SIZE, y = P.y;\n"
"  result = vec4(0.0, 0.0, 0.0, 1.0);\n"
"  vec4 A = texelFetch(viewA, P, 0);\n"
"  vec2 B = texelFetch(viewB, P, 0).xy;\n"
"  if (A.x < 0.0 || B.y < 0.0) return; /* empty, or opaque: no subsurface radiance */\n"
"  int ms = int(B.y);\n"
"  float inst = B.x;\n"
"  /* x_o: sss_i_pixel_world (orthographic view), n_o: sss_i_normal_world, in double */\n"
"  int vb = VB(k);\n"
"  double m[16];\n"
"  for (int i = 0; i < 16; i++) m[i] = dc(vb + i);\n"
"  precise double px = double(x) + 0.5LF;\n"
"  precise double py = double(y) + 0.5LF;\n"
"  precise double ax = (px - dc(vb + 16)) / dc(vb + 18);\n"
"  precise double ay = -(py - dc(vb + 17)) / dc(vb + 19);\n"
"  precise double q0 = ax - m[12];\n"
"  precise double q1 = ay - m[13];\n"
"  precise double q2 = -double(A.x) - m[14];\n"
"  precise dvec3 xo = dvec3((m[0] * q0 + m[1] * q1) + m[2] * q2, (m[4] * q0 + m[5] * q1) + m[6] * q2,\n"
"                           (m[8] * q0 + m[9] * q1) + m[10] * q2);\n"
"  dvec3 nv = dvec3(A.yzw);\n"
"  precise dvec3 no = dvec3((m[0] * nv.x + m[1] * nv.y) + m[2] * nv.z, (m[4] * nv.x + m[5] * nv.y) + m[6] * nv.z,\n"
"                           (m[8] * nv.x + m[9] * nv.y) + m[10] * nv.z);\n"
"  precise double l2 = (no.x * no.x + no.y * no.y) + no.z * no.z;\n"
"  if (l2 > 0.0LF) {\n"
"    precise double inv = 1.0LF / sqrt(l2);\n"
"    no = no * inv;\n"
"  }\n"
"  vec3 xof = vec3(xo), nof = vec3(no);\n"
"  double R = dc(GB), area = dc(GB + 1), two_pi = dc(GB + 2), sig = dc(MB(ms));\n"
"  precise dvec3 acc = dvec3(0.0LF);\n"
"  for (int f = 0; f < FRAMES; f++) {\n"
"    uint state = tea16(tea16(uint(y * SIZE + x), uint(k * FRAMES + f)), uint(seedx));\n"
"    precise double theta = 0.0LF;\n"
"#if SAMPLER == 1\n"
"    theta = two_pi * (double(rnd(state)) + double(f) / double(FRAMES)); /* [DalCorso14] method.tex */\n"
"#endif\n"
"    for (int l = 0; l < NL; l++) {\n"
"      int lb = LB(l);\n"
"      double lm[16];\n"
"      for (int i = 0; i < 16; i++) lm[i] = dc(lb + i);\n"
"      /* sss_i_project of x_o into the light map */\n"
"      precise double v0 = ((lm[0] * xo.x + lm[4] * xo.y) + lm[8] * xo.z) + lm[12];\n"
"      precise double v1 = ((lm[1] * xo.x + lm[5] * xo.y) + lm[9] * xo.z) + lm[13];\n"
"      precise double v2 = ((lm[2] * xo.x + lm[6] * xo.y) + lm[10] * xo.z) + lm[14];\n"
"      precise double d = -v2;\n"
"      double cx = dc(lb + 16), cy = dc(lb + 17), fx = dc(lb + 18), fy = dc(lb + 19);\n"
"      precise double pcx, pcy, ppu;\n"
"      if ((lflags[l] & 1) != 0) {\n"
"        if (!(d > 0.0LF)) continue;\n"
"        pcx = cx + fx * v0 / d;\n"
"        pcy = cy - fy * v1 / d;\n"
"        ppu = fx / d;\n"
"      } else {\n"
"        pcx = cx + fx * v0;\n"
"        pcy = cy - fy * v1;\n"
"        ppu = fx;\n"
"      }\n"
"      bool point = (lflags[l] & 2) != 0;\n"
"      dvec3 lp = dvec3(dc(lb + 23), dc(lb + 24), dc(lb + 25)), tl = dvec3(dc(lb + 20), dc(lb + 21), dc(lb + 22));\n"
"      double ls = double(lsize(l));\n"
"      precise dvec3 sum = dvec3(0.0LF);\n"
"#if SAMPLER == 2\n"
"      /* exponential (sss_maps.c gather_light): the N samples in draw order (u1, u2 each), the\n"
"       * float fetch, the 3 x 3 near-field block whose samples count 0, then the block itself;\n"
"       * four interleaved partial sums (accepted sample q into q mod 4) */\n"
"      precise float fcx = float(pcx);\n"
"      precise float fcy = float(pcy);\n"
"      precise float fppu = float(ppu);\n"
"      float fsize = float(lsize(l));\n"
"      bool block = R * ppu >= 3.0LF && fcx > -4.0 && fcy > -4.0 && fcx < fsize + 4.0 && fcy < fsize + 4.0;\n"
"      int bx = block ? int(floor(fcx)) - 1 : 0, by = block ? int(floor(fcy)) - 1 : 0;\n"
"      precise dvec3 ps0 = dvec3(0.0LF), ps1 = dvec3(0.0LF), ps2 = dvec3(0.0LF), ps3 = dvec3(0.0LF);\n"
"      int n = 0;\n"
"      for (int i = 0; i < N + 9; i++) {\n"
"        ivec2 it;\n"
"        precise double w;\n"
"        if (i < N) {\n"
"          float u1 = rnd(state), u2 = rnd(state);\n"
"          vec3 sm = exp_sample(ms, u1, u2); /* (ox, oy, 1 / (N p)) */\n"
"          precise float tx = fcx + sm.x * fppu;\n"
"          precise float ty = fcy - sm.y * fppu;\n"
"          if (!(tx >= 0.0 && ty >= 0.0 && tx < fsize && ty < fsize)) continue;\n"
"          it = ivec2(int(tx), int(ty)); /* nearest texel */\n"
"          if (block && uint(it.x - bx) < 3u && uint(it.y - by) < 3u) continue; /* counts 0 */\n"
"          w = double(sm.z);\n"
"        } else {\n"
"          /* the block, row by row, weight = the texel's area 1 / ppu^2 */\n"
"          if (!block) break;\n"
"          int b9 = i - N;\n"
"          it = ivec2(bx + b9 % 3, by + b9 / 3);\n"
"          if (it.x < 0 || it.y < 0 || it.x >= lsize(l) || it.y >= lsize(l)) continue;\n"
"          w = 1.0LF / (ppu * ppu);\n"
"        }\n"
"        vec4 pp = lpos(l, it);\n"
"        if (pp.w != inst) continue; /* empty (-1) or another instance */\n"
"        dvec3 x_i = dvec3(pp.xyz);\n"
"        vec3 wlf = vec3(tl);\n"
"        if (point) {\n"
"          precise dvec3 dl = lp - x_i;\n"
"          precise double d2 = (dl.x * dl.x + dl.y * dl.y) + dl.z * dl.z;\n"
"          precise double il = 1.0LF / sqrt(d2);\n"
"          w = w / d2;\n"
"          wlf = vec3(dl * il);\n"
"        }\n"
"        vec3 o = kernel(ms, xof, nof, pp.xyz, lnrm(l, it).xyz, wlf);\n"
"        precise dvec3 c = w * dvec3(o);\n"
"        int q = n & 3;\n"
"        if (q == 0) ps0 = ps0 + c; else if (q == 1) ps1 = ps1 + c; else if (q == 2) ps2 = ps2 + c; else ps3 = ps3 + c;\n"
"        n++;\n"
"      }\n"
"      sum = (ps0 + ps1) + (ps2 + ps3);\n"
"#else\n"
"#if SAMPLER == 0\n"
"      /* Russian roulette ([DalCorso14] final shader): three draws per candidate, always */\n"
"      for (int i = 0; i < N; i++) {\n"
"        float u1 = rnd(state), u2 = rnd(state), zeta = rnd(state);\n"
"        precise double rho = R * sqrt(double(u1));\n"
"        precise double phi = two_pi * double(u2);\n"
"        dvec2 sc = d_sincos(phi);\n"
"        precise double ox = rho * sc.y;\n"
"        precise double oy = rho * sc.x;\n"
"#else\n"
"      /* N of M: visit the sorted candidates, one zeta each, keep the first N accepted */\n"
"      precise double sigma_r = sig * R;\n"
"      dvec2 rot = d_sincos(theta);\n"
"      int nacc = 0;\n"
"      for (int i = 0; i < M && nacc < N; i++) {\n"
"        float zeta = rnd(state);\n"
"        vec2 hd = texelFetch(hdisk, ivec2(i, 0), 0).xy;\n"
"        if (!(d_exp(-sigma_r * double(hd.x)) > double(zeta))) continue;\n"
"        nacc++;\n"
"        precise double rho = R * double(hd.x);\n"
"        dvec2 sc = d_sincos(double(hd.y));\n"
"        precise double ox0 = rho * sc.y;\n"
"        precise double oy0 = rho * sc.x;\n"
"        precise double ox = rot.y * ox0 - rot.x * oy0;\n"
"        precise double oy = rot.x * ox0 + rot.y * oy0;\n"
"#endif\n"
"        precise double tx = pcx + ox * ppu;\n"
"        precise double ty = pcy - oy * ppu;\n"
"        if (!(tx >= 0.0LF && ty >= 0.0LF && tx < ls && ty < ls)) continue;\n"
"        ivec2 it = ivec2(int(tx), int(ty)); /* nearest texel */\n"
"        vec4 pp = lpos(l, it);\n"
"        if (pp.w != inst) continue; /* empty (-1) or another instance */\n"
"        dvec3 x_i = dvec3(pp.xyz);\n"
"#if SAMPLER == 0\n"
"        precise dvec3 dd = xo - x_i;\n"
"        precise double pa = d_exp(-sig * sqrt((dd.x * dd.x + dd.y * dd.y) + dd.z * dd.z));\n"
"        if (!(double(zeta) < pa)) continue;\n"
"        precise double w = area / (double(N) * pa);\n"
"#else\n"
"        precise double w = area / double(N);\n"
"#endif\n"
"        precise dvec3 wl = tl;\n"
"        if (point) {\n"
"          precise dvec3 dl = lp - x_i;\n"
"          precise double d2 = (dl.x * dl.x + dl.y * dl.y) + dl.z * dl.z;\n"
"          precise double il = 1.0LF / sqrt(d2);\n"
"          w = w / d2;\n"
"          wl = dl * il;\n"
"        }\n"
"        vec3 o = kernel(ms, xof, nof, pp.xyz, lnrm(l, it).xyz, vec3(wl));\n"
"        sum = sum + w * dvec3(o);\n"
"      }\n"
"#endif\n"
"      acc = acc + dvec3(dc(lb + 26), dc(lb + 27), dc(lb + 28)) * sum;\n"
"    }\n"
"  }\n"
"  result = vec4(vec3(acc / double(FRAMES)), 1.0);\n"
"}\n";

/* ---- pass 3: the combination (sss_combine.c combine_task), everything in double as ours ---- */
static const char *const fs_combine =
"#version 450\n"
"layout(binding=0) uniform sampler2D camA;     /* (depth or -1, view-space normal) */\n"
"layout(binding=1) uniform sampler2D camB;     /* material slot or -1 */\n"
"layout(binding=2) uniform sampler2D mapDepth; /* the K views' linear depth (+inf empty), side by side */\n"
"layout(binding=3) uniform sampler2D mapRad;   /* our K radiance maps (RGB), side by side */\n"
"uniform int dbits[2 * ND];\n"
"layout(location=0) out vec4 result;\n"
"#define DBL(lo, hi) packDouble2x32(uvec2(lo, hi))\n"
"double dc(int i) { return packDouble2x32(uvec2(uint(dbits[2 * i]), uint(dbits[2 * i + 1]))); }\n"
GLSL_D_EXP
"double d_log(double x) { /* x > 0: frexp, m in [sqrt(1/2), sqrt(2)), 2 atanh((m - 1) / (m + 1)) */\n"
"  int e;\n"
"  precise double m = frexp(x, e);\n"
"  if (m < 0.70710678118654752LF) { m = m * 2.0LF; e = e - 1; }\n"
"  precise double s = (m - 1.0LF) / (m + 1.0LF);\n"
"  precise double s2 = s * s;\n"
"  precise double p = 1.0LF / 23.0LF;\n"
"  p = p * s2 + 1.0LF / 21.0LF;\n"
"  p = p * s2 + 1.0LF / 19.0LF;\n"
"  p = p * s2 + 1.0LF / 17.0LF;\n"
"  p = p * s2 + 1.0LF / 15.0LF;\n"
"  p = p * s2 + 1.0LF / 13.0LF;\n"
"  p = p * s2 + 1.0LF / 11.0LF;\n"
"  p = p * s2 + 1.0LF / 9.0LF;\n"
"  p = p * s2 + 1.0LF / 7.0LF;\n"
"  p = p * s2 + 1.0LF / 5.0LF;\n"
"  p = p * s2 + 1.0LF / 3.0LF;\n"
"  p = p * s2 + 1.0LF;\n"
"  precise double de = double(e);\n"
"  precise double l = de * DBL(0xFEE00000u, 0x3FE62E42u) + (de * DBL(0x35793C76u, 0x3DEA39EFu) + (2.0LF * s) * p);\n"
"  return l;\n"
"}\n"
"/* sss_fresnel_reflectance (sss_dipole.c), double */\n"
"double fresnel_r(double cos_i, double eta) {\n"
"  precise double c = cos_i > 0.0LF ? (cos_i < 1.0LF ? cos_i : 1.0LF) : 0.0LF;\n"
"  if (!(eta > 0.0LF)) return 1.0LF;\n"
"  precise double eta2 = eta * eta;\n"
"  precise double cos2_t = ((eta2 - 1.0LF) + c * c) / eta2;\n"
"  if (cos2_t <= 0.0LF) return 1.0LF;\n"
"  precise double cos_t = sqrt(cos2_t);\n"
"  precise double rs = (c - eta * cos_t) / (c + eta * cos_t);\n"
"  precise double rp = (eta * c - cos_t) / (eta * c + cos_t);\n"
"  precise double F = 0.5LF * (rs * rs + rp * rp);\n"
"  return F;\n"
"}\n"
"#define G0 (36 + NMAT)\n"
"#define LV(k) (G0 + 3 + (k) * 23)\n"
"/* one binary shadow tap of layer k (sss_combine.c shadow_tap): receiver-plane depth at the texel centre */\n"
"double tap(int k, double px, double py, double d0, double px0, double py0, double gx, double gy, double bias) {\n"
"  int ix = clamp(int(floor(px)), 0, SIZE - 1), iy = clamp(int(floor(py)), 0, SIZE - 1);\n"
"  precise double d = (d0 + gx * ((double(ix) + 0.5LF) - px0)) + gy * ((double(iy) + 0.5LF) - py0);\n"
"  float z = texelFetch(mapDepth, ivec2(k * SIZE + ix, iy), 0).x;\n"
"  return d - bias <= double(z) ? 1.0LF : 0.0LF;\n"
"}\n"
"void main() {\n"
"  ivec2 P = ivec2(gl_FragCoord.xy);\n"
"  result = vec4(0.0, 0.0, 0.0, 1.0);\n"
"  vec4 A = texelFetch(camA, P, 0);\n"
"  float msf = texelFetch(camB, P, 0).x;\n"
"  if (A.x < 0.0 || msf < 0.0) return;\n"
"  int ms = int(msf);\n"
"  /* x_o from the camera's pixel ray (rast_pixel_ray) and the linear depth */\n"
"  double w[16], vm[16];\n"
"  for (int i = 0; i < 16; i++) { w[i] = dc(i); vm[i] = dc(16 + i); }\n"
"  precise double ax = ((double(P.x) + 0.5LF) - dc(32)) * (1.0LF / dc(34));\n"
"  precise double ay = -((double(P.y) + 0.5LF) - dc(33)) * (1.0LF / dc(35));\n"
"#if CAM_PERSP\n"
"  precise dvec3 o = dvec3(0.0LF), dd = dvec3(ax, ay, -1.0LF);\n"
"#else\n"
"  precise dvec3 o = dvec3(ax, ay, 0.0LF), dd = dvec3(0.0LF, 0.0LF, -1.0LF);\n"
"#endif\n"
"  precise dvec3 org = dvec3(((w[0] * o.x + w[4] * o.y) + w[8] * o.z) + w[12],\n"
"                            ((w[1] * o.x + w[5] * o.y) + w[9] * o.z) + w[13],\n"
"                            ((w[2] * o.x + w[6] * o.y) + w[10] * o.z) + w[14]);\n"
"  precise dvec3 dir = dvec3((w[0] * dd.x + w[4] * dd.y) + w[8] * dd.z, (w[1] * dd.x + w[5] * dd.y) + w[9] * dd.z,\n"
"                            (w[2] * dd.x + w[6] * dd.y) + w[10] * dd.z);\n"
"  precise dvec3 xo = org + double(A.x) * dir;\n"
"  dvec3 nv = dvec3(A.yzw);\n"
"  precise dvec3 no = dvec3((vm[0] * nv.x + vm[1] * nv.y) + vm[2] * nv.z,\n"
"                           (vm[4] * nv.x + vm[5] * nv.y) + vm[6] * nv.z,\n"
"                           (vm[8] * nv.x + vm[9] * nv.y) + vm[10] * nv.z);\n"
"  precise double l2 = (no.x * no.x + no.y * no.y) + no.z * no.z;\n"
"  if (l2 > 0.0LF) { precise double inv = 1.0LF / sqrt(l2); no = no * inv; }\n"
"  precise double dl = sqrt((dir.x * dir.x + dir.y * dir.y) + dir.z * dir.z);\n"
"  precise dvec3 wo = (-dir) / dl;\n"
"  double eps = dc(G0), bias = dc(G0 + 1), ig = dc(G0 + 2);\n"
"  precise double sumv = 0.0LF;\n"
"  precise dvec3 acc = dvec3(0.0LF);\n"
"  for (int k = 0; k < K; k++) {\n"
"    int b = LV(k);\n"
"    double m[16];\n"
"    for (int i = 0; i < 16; i++) m[i] = dc(b + i);\n"
"    double cx = dc(b + 16), cy = dc(b + 17), fx = dc(b + 18), fy = dc(b + 19);\n"
"    dvec3 wd = dvec3(dc(b + 20), dc(b + 21), dc(b + 22));\n"
"    precise double nd = (no.x * wd.x + no.y * wd.y) + no.z * wd.z;\n"
"    precise dvec3 xs = xo - eps * (no - wd * nd); /* the shrink ([DalCorso14] ss_array_combination.frag) */\n"
"    precise double px = cx + fx * (((m[0] * xs.x + m[4] * xs.y) + m[8] * xs.z) + m[12]);\n"
"    precise double py = cy - fy * (((m[1] * xs.x + m[5] * xs.y) + m[9] * xs.z) + m[13]);\n"
"    if (px < 0.0LF || py < 0.0LF || px >= double(SIZE) || py >= double(SIZE)) continue;\n"
"    precise double nvz = (m[2] * no.x + m[6] * no.y) + m[10] * no.z;\n"
"    if (!(nvz > MIN_FACING)) continue;\n"
"    precise double nvx = (m[0] * no.x + m[4] * no.y) + m[8] * no.z;\n"
"    precise double nvy = (m[1] * no.x + m[5] * no.y) + m[9] * no.z;\n"
"    precise double px0 = cx + fx * (((m[0] * xo.x + m[4] * xo.y) + m[8] * xo.z) + m[12]);\n"
"    precise double py0 = cy - fy * (((m[1] * xo.x + m[5] * xo.y) + m[9] * xo.z) + m[13]);\n"
"    precise double d0 = -(((m[2] * xo.x + m[6] * xo.y) + m[10] * xo.z) + m[14]);\n"
"    precise double gx = nvx / (nvz * fx);\n"
"    precise double gy = -nvy / (nvz * fy);\n"
"    precise double v;\n"
"#if VIS_PCF\n"
"    v = 0.0LF;\n"
"    for (int ty = -1; ty <= 1; ty++)\n"
"      for (int tx = -1; tx <= 1; tx++)\n"
"        v = v + tap(k, px + double(tx), py + double(ty), d0, px0, py0, gx, gy, bias);\n"
"    v = v / 9.0LF;\n"
"#else\n"
"    const dvec2 off[5] = dvec2[](dvec2(0.0LF, 0.0LF), dvec2(0.5LF, 1.5LF), dvec2(-1.5LF, 0.5LF),\n"
"                                 dvec2(-0.5LF, -1.5LF), dvec2(1.5LF, -0.5LF));\n"
"    v = 1.0LF;\n"
"    for (int t = 0; t < 5 && v > 0.0LF; t++)\n"
"      v = v * tap(k, px + off[t].x, py + off[t].y, d0, px0, py0, gx, gy, bias);\n"
"#endif\n"
"    if (!(v > 0.0LF)) continue;\n"
"    /* bilinear lookup in double (sss_combine.c bilinear3) */\n"
"    precise double u = px - 0.5LF, uv = py - 0.5LF;\n"
"    precise double fu = floor(u), fv = floor(uv);\n"
"    precise double a = u - fu, bb = uv - fv;\n"
"    int x0 = clamp(int(fu), 0, SIZE - 1), x1 = clamp(int(fu) + 1, 0, SIZE - 1);\n"
"    int y0 = clamp(int(fv), 0, SIZE - 1), y1 = clamp(int(fv) + 1, 0, SIZE - 1);\n"
"    dvec3 r00 = dvec3(texelFetch(mapRad, ivec2(k * SIZE + x0, y0), 0).rgb);\n"
"    dvec3 r01 = dvec3(texelFetch(mapRad, ivec2(k * SIZE + x1, y0), 0).rgb);\n"
"    dvec3 r10 = dvec3(texelFetch(mapRad, ivec2(k * SIZE + x0, y1), 0).rgb);\n"
"    dvec3 r11 = dvec3(texelFetch(mapRad, ivec2(k * SIZE + x1, y1), 0).rgb);\n"
"    precise dvec3 top = (1.0LF - a) * r00 + a * r01;\n"
"    precise dvec3 bot = (1.0LF - a) * r10 + a * r11;\n"
"    precise dvec3 r = (1.0LF - bb) * top + bb * bot;\n"
"    acc = acc + v * r;\n"
"    sumv = sumv + v;\n"
"  }\n"
"  precise double cos_o = (no.x * wo.x + no.y * wo.y) + no.z * wo.z;\n"
"  precise double T21 = 1.0LF - fresnel_r(min(1.0LF, max(0.0LF, cos_o)), dc(36 + ms));\n"
"  T21 = min(1.0LF, max(0.0LF, T21));\n"
"  precise dvec3 L = dvec3(0.0LF);\n"
"  if (sumv > 0.0LF) L = (T21 * acc) / sumv;\n"
"#if GAMMA\n"
"  for (int c = 0; c < 3; c++)\n"
"    if (L[c] > 0.0LF) L[c] = d_exp(ig * d_log(L[c])); /* L^(1/gamma) */\n"
"#endif\n"
"  result = vec4(vec3(L), 1.0);\n"
"}\n";

static unsigned fbits(float f)
{
    unsigned u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void put_double(int *bits, int i, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    bits[2 * i] = (int)(uint32_t)u;
    bits[2 * i + 1] = (int)(uint32_t)(u >> 32);
}
#endif

int glsl_sss_gather_build(glh *g, obs_context *ctx, const obs_scene *scene, const sss_scene_materials *mats,
                          const sss_light_map *lights, int light_count, const sss_maps *maps, const sss_params *p,
                          glh_run *r)
{
#if !GLH_AVAILABLE
    (void)g, (void)ctx, (void)scene, (void)mats, (void)lights, (void)light_count, (void)maps, (void)p, (void)r;
    printf("  glsl_sss: built without GL headers\n");
    return 0;
#else
    memset(r, 0, sizeof *r);
    if (light_count < 1 || light_count > GLSL_SSS_MAX_LIGHTS) {
        printf("  glsl_sss: %d light maps (the port takes 1..%d)\n", light_count, GLSL_SSS_MAX_LIGHTS);
        return 0;
    }
    if (p->sampler != SSS_SAMPLER_RUSSIAN_ROULETTE && p->sampler != SSS_SAMPLER_NEAREST_N_OF_M &&
        p->sampler != SSS_SAMPLER_EXPONENTIAL) {
        printf("  glsl_sss: sampler %s is not ported\n", sss_sampler_name(p->sampler));
        return 0;
    }
    const int K = maps->K, S = maps->size, NL = light_count;
    for (int k = 0; k < K; k++)
        if (maps->views[k].constants.projection_type != OBS_PROJECTION_ORTHOGRAPHIC || maps->views[k].width != S) {
            printf("  glsl_sss: view %d is not an orthographic %d^2 view\n", k, S);
            return 0;
        }
    double c[3], rad;
    if (sss_i_scene_sphere(ctx, scene, c, &rad) != OBS_STATUS_OK)
        return 0;
    const double R = p->disk_radius > 0.0 ? p->disk_radius : rad; /* as sss_maps_build */

    /* the view atlases and the material slots */
    const sss_constants *slot[GLSL_SSS_MAX_MATERIALS];
    int nmat = 0, ok = 1;
    float *va = (float *)malloc(sizeof(float) * 4 * (size_t)K * (size_t)S * (size_t)S);
    float *vb = (float *)malloc(sizeof(float) * 2 * (size_t)K * (size_t)S * (size_t)S);
    if (!va || !vb) {
        free(va);
        free(vb);
        return 0;
    }
    const size_t row = (size_t)K * (size_t)S;
    for (int k = 0; k < K && ok; k++) {
        const rast_gbuffer *gb = &maps->views[k];
        for (int y = 0; y < S && ok; y++)
            for (int x = 0; x < S; x++) {
                const float depth = obs_image_f32_row(&gb->depth, y)[x];
                const uint32_t inst = obs_image_u32_row(&gb->instance_id, y)[x];
                const sss_constants *mc =
                    depth < INFINITY ? sss_i_material(mats, obs_image_u32_row(&gb->material_id, y)[x]) : NULL;
                int s = -1;
                if (mc) {
                    for (int i = 0; i < nmat; i++)
                        if (slot[i] == mc)
                            s = i;
                    if (s < 0) {
                        if (nmat == GLSL_SSS_MAX_MATERIALS) {
                            printf("  glsl_sss: more than %d translucent materials\n", GLSL_SSS_MAX_MATERIALS);
                            ok = 0;
                            break;
                        }
                        slot[nmat] = mc;
                        s = nmat++;
                    }
                }
                if (inst != RAST_ID_NONE && inst >= (1u << 24)) {
                    printf("  glsl_sss: instance id %u does not fit a float\n", inst);
                    ok = 0;
                    break;
                }
                float *a = va + 4 * ((size_t)y * row + (size_t)k * S + x);
                float *b = vb + 2 * ((size_t)y * row + (size_t)k * S + x);
                a[0] = depth < INFINITY ? depth : -1.0f;
                for (int j = 0; j < 3; j++)
                    a[1 + j] = obs_image_f32_row(&gb->normal[j], y)[x];
                b[0] = inst == RAST_ID_NONE ? -1.0f : (float)inst;
                b[1] = (float)s;
            }
    }
    GLuint tva = 0, tvb = 0;
    if (ok) {
        tva = glh_run_own_texture(r, glh_texture(g, K * S, S, 1, GL_RGBA32F, 4, va, GLH_ROWS_AS_IS, GL_NEAREST,
                                                 GL_CLAMP_TO_EDGE));
        tvb = glh_run_own_texture(r, glh_texture(g, K * S, S, 1, GL_RG32F, 2, vb, GLH_ROWS_AS_IS, GL_NEAREST,
                                                 GL_CLAMP_TO_EDGE));
    }
    free(va);
    free(vb);
    if (!ok || !tva || !tvb)
        return 0;
    if (nmat == 0)
        slot[nmat++] = NULL; /* nothing translucent: the pass writes 0 everywhere */

    /* the light maps: (position, instance) and normal, as GL_NEAREST float textures */
    GLuint tl[2 * GLSL_SSS_MAX_LIGHTS];
    for (int l = 0; l < NL; l++) {
        const sss_light_map *lm = &lights[l];
        const int LS = lm->gb.width;
        float *pos = (float *)malloc(sizeof(float) * 4 * (size_t)LS * (size_t)LS);
        float *nrm = (float *)malloc(sizeof(float) * 4 * (size_t)LS * (size_t)LS);
        if (!pos || !nrm) {
            free(pos);
            free(nrm);
            return 0;
        }
        for (int y = 0; y < LS; y++)
            for (int x = 0; x < LS; x++) {
                const uint32_t inst = obs_image_u32_row(&lm->gb.instance_id, y)[x];
                float *a = pos + 4 * ((size_t)y * LS + x), *b = nrm + 4 * ((size_t)y * LS + x);
                for (int j = 0; j < 3; j++) {
                    a[j] = obs_image_f32_row(&lm->position[j], y)[x];
                    b[j] = obs_image_f32_row(&lm->wnormal[j], y)[x];
                }
                a[3] = inst == RAST_ID_NONE ? -1.0f : (float)inst;
                b[3] = 0.0f;
            }
        tl[2 * l] = glh_run_own_texture(r, glh_texture(g, LS, LS, 1, GL_RGBA32F, 4, pos, GLH_ROWS_AS_IS, GL_NEAREST,
                                                       GL_CLAMP_TO_EDGE));
        tl[2 * l + 1] = glh_run_own_texture(r, glh_texture(g, LS, LS, 1, GL_RGBA32F, 4, nrm, GLH_ROWS_AS_IS,
                                                           GL_NEAREST, GL_CLAMP_TO_EDGE));
        free(pos);
        free(nrm);
        if (!tl[2 * l] || !tl[2 * l + 1])
            return 0;
    }
    /* the N-of-M candidate disk (1 x 1, unused, for Russian roulette) */
    const int M = p->sampler == SSS_SAMPLER_NEAREST_N_OF_M ? p->M : 1;
    GLuint thd = 0;
    {
        float *hdv = (float *)calloc(2 * (size_t)M, sizeof(float));
        if (!hdv)
            return 0;
        if (p->sampler == SSS_SAMPLER_NEAREST_N_OF_M) {
            sss_i_halton_disk hd;
            if (sss_i_halton_disk_make(ctx, M, &hd) != OBS_STATUS_OK) {
                free(hdv);
                return 0;
            }
            for (int i = 0; i < M; i++) {
                hdv[2 * i] = hd.rho[i];
                hdv[2 * i + 1] = hd.phi[i];
            }
            sss_i_halton_disk_free(&hd);
        }
        thd = glh_run_own_texture(r, glh_texture(g, M, 1, 1, GL_RG32F, 2, hdv, GLH_ROWS_AS_IS, GL_NEAREST,
                                                 GL_CLAMP_TO_EDGE));
        free(hdv);
        if (!thd)
            return 0;
    }

    /* the double constants, as bits */
    const int ND = K * 20 + NL * 29 + nmat + 3;
    int *db = (int *)calloc(2 * (size_t)ND, sizeof(int));
    if (!db)
        return 0;
    for (int k = 0; k < K; k++) {
        const rast_view_constants *vc = &maps->views[k].constants;
        for (int i = 0; i < 16; i++)
            put_double(db, k * 20 + i, (double)vc->view.m[i]);
        put_double(db, k * 20 + 16, vc->cx);
        put_double(db, k * 20 + 17, vc->cy);
        put_double(db, k * 20 + 18, vc->fx);
        put_double(db, k * 20 + 19, vc->fy);
    }
    int lflags[GLSL_SSS_MAX_LIGHTS] = {0};
    for (int l = 0; l < NL; l++) {
        const rast_view_constants *vc = &lights[l].gb.constants;
        const obs_light *L = &lights[l].light;
        const int b = K * 20 + l * 29;
        for (int i = 0; i < 16; i++)
            put_double(db, b + i, (double)vc->view.m[i]);
        put_double(db, b + 16, vc->cx);
        put_double(db, b + 17, vc->cy);
        put_double(db, b + 18, vc->fx);
        put_double(db, b + 19, vc->fy);
        /* as sss_maps_build's light_info */
        double dl = sqrt((double)L->direction.x * L->direction.x + (double)L->direction.y * L->direction.y +
                         (double)L->direction.z * L->direction.z);
        double to[3] = {0, 0, 0};
        if (dl > 0.0) {
            to[0] = -L->direction.x / dl;
            to[1] = -L->direction.y / dl;
            to[2] = -L->direction.z / dl;
        }
        for (int a = 0; a < 3; a++)
            put_double(db, b + 20 + a, to[a]);
        put_double(db, b + 23, L->position.x);
        put_double(db, b + 24, L->position.y);
        put_double(db, b + 25, L->position.z);
        put_double(db, b + 26, (double)L->color.x * L->intensity);
        put_double(db, b + 27, (double)L->color.y * L->intensity);
        put_double(db, b + 28, (double)L->color.z * L->intensity);
        lflags[l] = (vc->projection_type == OBS_PROJECTION_PERSPECTIVE ? 1 : 0) | (L->type == OBS_LIGHT_POINT ? 2 : 0);
    }
    sss_gpu_constants gc[GLSL_SSS_MAX_MATERIALS];
    memset(gc, 0, sizeof gc);
    for (int s = 0; s < nmat; s++) {
        const int b = K * 20 + NL * 29 + s;
        put_double(db, b, slot[s] ? slot[s]->min_sigma_tr / p->spread_q : 0.0); /* sigma* (sss.md 3.4) */
        if (slot[s])
            sss_gpu_constants_make(slot[s], p->model, &gc[s]);
    }
    const int gb0 = K * 20 + NL * 29 + nmat;
    put_double(db, gb0, R);
    put_double(db, gb0 + 1, OBS_PI * R * R); /* A_c, as sss_maps_build */
    put_double(db, gb0 + 2, 2.0 * OBS_PI);

    /* the exponential sampler's float constants, as sss_maps_internal.h spells them (C folds them
     * in float), passed as bits so that no GLSL literal is rounded twice */
    const struct {
        const char *name;
        float v;
    } cf[] = {{"CF_SQRT2", 1.41421356f},   {"CF_I3", 1.0f / 3.0f},   {"CF_I5", 1.0f / 5.0f},
              {"CF_I7", 1.0f / 7.0f},      {"CF_I9", 1.0f / 9.0f},   {"CF_I11", 1.0f / 11.0f},
              {"CF_I13", 1.0f / 13.0f},    {"CF_I15", 1.0f / 15.0f}, {"CF_LN2_HI", SSS_I_LN2_HI},
              {"CF_LN2_LO", SSS_I_LN2_LO}, {"CF_TINY", 1e-30f},      {"CF_HALF_PI", 1.57079632679f},
              {"CF_F3", 1.0f / 6.0f},      {"CF_F5", 1.0f / 120.0f}, {"CF_F7", 1.0f / 5040.0f},
              {"CF_F9", 1.0f / 362880.0f}, {"CF_F11", 1.0f / 39916800.0f},
              {"CF_F4", 1.0f / 24.0f},     {"CF_F6", 1.0f / 720.0f}, {"CF_F8", 1.0f / 40320.0f},
              {"CF_F10", 1.0f / 3628800.0f}, {"CF_F12", 1.0f / 479001600.0f}};
    char pre[4096];
    int np = 0;
    for (size_t i = 0; i < sizeof cf / sizeof cf[0]; i++)
        np += snprintf(pre + np, sizeof pre - (size_t)np, "#define %s uintBitsToFloat(0x%08xu)\n", cf[i].name,
                       fbits(cf[i].v));
    snprintf(pre + np, sizeof pre - (size_t)np,
             "#define K %d\n#define SIZE %d\n#define NL %d\n#define N %d\n#define M %d\n#define SAMPLER %d\n"
             "#define FRAMES %d\n#define NMAT %d\n#define ND %d\n"
             "#define EXPF_LOG2E uintBitsToFloat(0x%08xu)\n#define EXPF_MAGIC uintBitsToFloat(0x%08xu)\n"
             "#define EXPF_LN2_HI uintBitsToFloat(0x%08xu)\n#define EXPF_LN2_LO uintBitsToFloat(0x%08xu)\n"
             "#define EXPF_C7 uintBitsToFloat(0x%08xu)\n#define EXPF_C6 uintBitsToFloat(0x%08xu)\n"
             "#define EXPF_C5 uintBitsToFloat(0x%08xu)\n#define EXPF_C4 uintBitsToFloat(0x%08xu)\n"
             "#define EXPF_C3 uintBitsToFloat(0x%08xu)\n#define EXPF_C2 uintBitsToFloat(0x%08xu)\n"
             "#define INV_4PI2F uintBitsToFloat(0x%08xu)\n#define PAR_EPS_F uintBitsToFloat(0x%08xu)\n"
             "#define FLOOR_D_F uintBitsToFloat(0x%08xu)\n",
             K, S, NL, p->N, M, p->sampler == SSS_SAMPLER_NEAREST_N_OF_M ? 1 : p->sampler == SSS_SAMPLER_EXPONENTIAL ? 2 : 0, p->frames, nmat, ND,
             fbits(SSS_I_EXPF_LOG2E), fbits(SSS_I_EXPF_MAGIC), fbits(SSS_I_EXPF_LN2_HI), fbits(SSS_I_EXPF_LN2_LO),
             fbits(SSS_I_EXPF_C7), fbits(SSS_I_EXPF_C6), fbits(SSS_I_EXPF_C5), fbits(SSS_I_EXPF_C4),
             fbits(SSS_I_EXPF_C3), fbits(SSS_I_EXPF_C2), fbits((float)SSS_I_INV_4PI2),
             fbits((float)SSS_I_PARALLEL_EPS), fbits((float)SSS_I_DIST_FLOOR_D));
    GLuint prog = glh_run_own_program(r, glh_program(g, fs_gather, pre));
    GLuint tout = glh_run_own_texture(r, glh_texture(g, K * S, S, 1, GL_RGBA32F, 4, NULL, GLH_ROWS_AS_IS, GL_NEAREST,
                                                     GL_CLAMP_TO_EDGE));
    GLuint fout = tout ? glh_run_own_fbo(r, glh_framebuffer(g, tout, 0)) : 0;
    if (!prog || !fout) {
        free(db);
        return 0;
    }
    g->gl.glProgramUniform1iv(prog, g->gl.glGetUniformLocation(prog, "dbits"), 2 * ND, db);
    g->gl.glProgramUniform1iv(prog, g->gl.glGetUniformLocation(prog, "lflags"), NL, lflags);
    free(db);
    glh_set1i(g, prog, "seedx", (int)((uint32_t)p->seed ^ (uint32_t)(p->seed >> 32)));
    float u[10][4 * GLSL_SSS_MAX_MATERIALS];
    for (int s = 0; s < nmat; s++)
        for (int j = 0; j < 4; j++) {
            u[0][4 * s + j] = gc[s].sigma_tr[j];
            u[1][4 * s + j] = gc[s].D[j];
            u[2][4 * s + j] = gc[s].d_e[j];
            u[3][4 * s + j] = gc[s].two_a_de[j];
            u[4][4 * s + j] = gc[s].backlit_d2[j];
            u[5][4 * s + j] = gc[s].z_r[j];
            u[6][4 * s + j] = gc[s].z_v[j];
            u[7][4 * s + j] = gc[s].alpha_p[j];
            const float m0[4] = {gc[s].c_phi, gc[s].c_e, gc[s].norm_dir, gc[s].eta};
            const float m1[4] = {gc[s].inv_eta, gc[s].model, 0.0f, 0.0f};
            u[8][4 * s + j] = m0[j];
            u[9][4 * s + j] = m1[j];
        }
    static const char *const names[10] = {"g_sigma_tr", "g_D",     "g_de",    "g_2ade",  "g_bd2",
                                          "g_zr",       "g_zv",    "g_alpha", "g_misc0", "g_misc1"};
    for (int i = 0; i < 10; i++)
        glh_setfv(g, prog, names[i], 4, nmat, u[i]);
    if (p->sampler == SSS_SAMPLER_EXPONENTIAL) {
        /* the sampler's per-material constants (sigma*, R, N), made by sss_maps.c's own
         * sss_i_exp_disk_make as a GPU renderer would fill its uniform block on the CPU */
        float e0[4 * GLSL_SSS_MAX_MATERIALS], e1[4 * GLSL_SSS_MAX_MATERIALS];
        memset(e0, 0, sizeof e0);
        memset(e1, 0, sizeof e1);
        for (int s = 0; s < nmat; s++) {
            if (!slot[s])
                continue;
            sss_i_exp_disk ed;
            sss_i_exp_disk_make(slot[s]->min_sigma_tr / p->spread_q, R, p->N, &ed);
            e0[4 * s] = ed.sigma;
            e0[4 * s + 1] = ed.R;
            e0[4 * s + 2] = ed.T;
            e0[4 * s + 3] = ed.q;
            e1[4 * s] = ed.Z;
            e1[4 * s + 1] = ed.w0;
        }
        glh_setfv(g, prog, "g_ed0", 4, nmat, e0);
        glh_setfv(g, prog, "g_ed1", 4, nmat, e1);
    }
    GLuint tex[7] = {tva, tvb, tl[0], tl[1], NL > 1 ? tl[2] : tl[0], NL > 1 ? tl[3] : tl[1], thd};
    glh_run_add(r, "sss gather (K layers)", prog, fout, K * S, S, 7, tex);
    r->nkernel = r->npass;
    r->out_fbo = fout;
    r->out_w = K * S;
    r->out_h = S;
    r->out_rows = GLH_ROWS_AS_IS;
    return 1;
#endif
}

obs_status glsl_sss_gather_read(glh *g, const glh_run *r, obs_context *ctx, int K, int size, obs_image_f32 *planes)
{
#if !GLH_AVAILABLE
    (void)g, (void)r, (void)ctx, (void)K, (void)size, (void)planes;
    return OBS_STATUS_UNSUPPORTED;
#else
    const int W = K * size;
    memset(planes, 0, sizeof(obs_image_f32) * 3 * (size_t)K);
    float *buf = (float *)malloc(sizeof(float) * 4 * (size_t)W * (size_t)size);
    if (!buf)
        return OBS_STATUS_OUT_OF_MEMORY;
    glh_run_draw(g, r, 0, r->npass);
    g->gl.glBindFramebuffer(GL_FRAMEBUFFER, r->out_fbo);
    g->gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
    g->gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
    g->gl.glReadPixels(0, 0, W, size, GL_RGBA, GL_FLOAT, buf);
    g->gl.glFinish();
    obs_status st = OBS_STATUS_OK;
    for (int i = 0; i < 3 * K && st == OBS_STATUS_OK; i++)
        st = obs_image_f32_alloc(ctx, size, size, &planes[i]);
    if (st == OBS_STATUS_OK)
        for (int k = 0; k < K; k++)
            for (int y = 0; y < size; y++)
                for (int x = 0; x < size; x++)
                    for (int c = 0; c < 3; c++)
                        obs_image_f32_row(&planes[3 * k + c], y)[x] =
                            buf[4 * ((size_t)y * W + (size_t)k * size + x) + c];
    free(buf);
    if (st != OBS_STATUS_OK)
        for (int i = 0; i < 3 * K; i++)
            obs_image_f32_free(&planes[i]);
    return st;
#endif
}

int glsl_sss_combine_build(glh *g, obs_context *ctx, const sss_scene_materials *mats, const sss_maps *maps,
                           const rast_gbuffer *camera_gb, const obs_camera *camera, const sss_params *p, glh_run *r)
{
    (void)ctx;
#if !GLH_AVAILABLE
    (void)g, (void)mats, (void)maps, (void)camera_gb, (void)camera, (void)p, (void)r;
    printf("  glsl_sss: built without GL headers\n");
    return 0;
#else
    memset(r, 0, sizeof *r);
    if (p->specular) {
        printf("  glsl_sss: the specular term is not ported\n");
        return 0;
    }
    const int K = maps->K, S = maps->size, W = camera_gb->width, H = camera_gb->height;
    /* the camera G-buffer and its material slots (the slot holds the material's eta) */
    const sss_constants *slot[GLSL_SSS_MAX_MATERIALS];
    int nmat = 0, ok = 1;
    float *ca = (float *)malloc(sizeof(float) * 4 * (size_t)W * (size_t)H);
    float *cb = (float *)malloc(sizeof(float) * (size_t)W * (size_t)H);
    float *md = (float *)malloc(sizeof(float) * (size_t)K * (size_t)S * (size_t)S);
    float *mr = (float *)malloc(sizeof(float) * 4 * (size_t)K * (size_t)S * (size_t)S);
    if (!ca || !cb || !md || !mr)
        ok = 0;
    for (int y = 0; y < H && ok; y++)
        for (int x = 0; x < W; x++) {
            const float depth = obs_image_f32_row(&camera_gb->depth, y)[x];
            const sss_constants *mc =
                depth < INFINITY ? sss_i_material(mats, obs_image_u32_row(&camera_gb->material_id, y)[x]) : NULL;
            int s = -1;
            if (mc) {
                for (int i = 0; i < nmat; i++)
                    if (slot[i] == mc)
                        s = i;
                if (s < 0) {
                    if (nmat == GLSL_SSS_MAX_MATERIALS) {
                        printf("  glsl_sss: more than %d translucent materials\n", GLSL_SSS_MAX_MATERIALS);
                        ok = 0;
                        break;
                    }
                    slot[nmat] = mc;
                    s = nmat++;
                }
            }
            float *a = ca + 4 * ((size_t)y * W + x);
            a[0] = depth < INFINITY ? depth : -1.0f;
            for (int j = 0; j < 3; j++)
                a[1 + j] = obs_image_f32_row(&camera_gb->normal[j], y)[x];
            cb[(size_t)y * W + x] = (float)s;
        }
    const size_t row = (size_t)K * S;
    for (int k = 0; k < K && ok; k++)
        for (int y = 0; y < S; y++)
            for (int x = 0; x < S; x++) {
                const size_t i = (size_t)y * row + (size_t)k * S + x;
                md[i] = obs_image_f32_row(&maps->views[k].depth, y)[x]; /* +inf where empty, as ours */
                for (int c = 0; c < 3; c++)
                    mr[4 * i + c] = obs_image_f32_row(&maps->radiance[3 * k + c], y)[x];
                mr[4 * i + 3] = 0.0f;
            }
    GLuint t[4] = {0, 0, 0, 0};
    if (ok) {
        t[0] = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGBA32F, 4, ca, GLH_ROWS_AS_IS, GL_NEAREST,
                                                  GL_CLAMP_TO_EDGE));
        t[1] = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, cb, GLH_ROWS_AS_IS, GL_NEAREST,
                                                  GL_CLAMP_TO_EDGE));
        t[2] = glh_run_own_texture(r, glh_texture(g, K * S, S, 1, GL_R32F, 1, md, GLH_ROWS_AS_IS, GL_NEAREST,
                                                  GL_CLAMP_TO_EDGE));
        t[3] = glh_run_own_texture(r, glh_texture(g, K * S, S, 1, GL_RGBA32F, 4, mr, GLH_ROWS_AS_IS, GL_NEAREST,
                                                  GL_CLAMP_TO_EDGE));
    }
    free(ca);
    free(cb);
    free(md);
    free(mr);
    if (!ok || !t[0] || !t[1] || !t[2] || !t[3])
        return 0;
    if (nmat == 0)
        slot[nmat++] = NULL;
    const int G0 = 36 + nmat, ND = G0 + 3 + 23 * K;
    int *db = (int *)calloc(2 * (size_t)ND, sizeof(int));
    if (!db)
        return 0;
    for (int i = 0; i < 16; i++) {
        put_double(db, i, (double)camera->world.m[i]);
        put_double(db, 16 + i, (double)camera_gb->constants.view.m[i]);
    }
    put_double(db, 32, camera_gb->constants.cx);
    put_double(db, 33, camera_gb->constants.cy);
    put_double(db, 34, camera_gb->constants.fx);
    put_double(db, 35, camera_gb->constants.fy);
    for (int s = 0; s < nmat; s++)
        put_double(db, 36 + s, slot[s] ? slot[s]->eta : 1.0);
    /* as sss_combine: eps_c in map texture units, the bias in units of the map's depth range */
    const rast_view_constants *vc0 = &maps->views[0].constants;
    put_double(db, G0, p->shrink_eps * (double)maps->views[0].width / vc0->fx);
    put_double(db, G0 + 1, p->shadow_bias * (vc0->zfar - vc0->znear));
    put_double(db, G0 + 2, 1.0 / p->gamma);
    for (int k = 0; k < K; k++) {
        const rast_view_constants *vc = &maps->views[k].constants;
        const int b = G0 + 3 + 23 * k;
        for (int i = 0; i < 16; i++)
            put_double(db, b + i, (double)vc->view.m[i]);
        put_double(db, b + 16, vc->cx);
        put_double(db, b + 17, vc->cy);
        put_double(db, b + 18, vc->fx);
        put_double(db, b + 19, vc->fy);
        for (int a = 0; a < 3; a++)
            put_double(db, b + 20 + a, maps->dirs[3 * k + a]);
    }
    uint64_t mf;
    const double min_facing = SSS_I_MIN_FACING;
    memcpy(&mf, &min_facing, sizeof mf);
    char pre[512];
    snprintf(pre, sizeof pre,
             "#define K %d\n#define SIZE %d\n#define NMAT %d\n#define ND %d\n#define CAM_PERSP %d\n#define VIS_PCF %d\n"
             "#define GAMMA %d\n#define MIN_FACING DBL(0x%08xu, 0x%08xu)\n",
             K, S, nmat, ND, camera_gb->constants.projection_type == OBS_PROJECTION_PERSPECTIVE,
             p->visibility == SSS_VISIBILITY_PCF3X3, p->gamma != 1.0, (unsigned)(uint32_t)mf,
             (unsigned)(uint32_t)(mf >> 32));
    GLuint prog = glh_run_own_program(r, glh_program(g, fs_combine, pre));
    GLuint tout = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGBA32F, 4, NULL, GLH_ROWS_AS_IS, GL_NEAREST,
                                                     GL_CLAMP_TO_EDGE));
    GLuint fout = tout ? glh_run_own_fbo(r, glh_framebuffer(g, tout, 0)) : 0;
    if (!prog || !fout) {
        free(db);
        return 0;
    }
    g->gl.glProgramUniform1iv(prog, g->gl.glGetUniformLocation(prog, "dbits"), 2 * ND, db);
    free(db);
    glh_run_add(r, "sss combination", prog, fout, W, H, 4, t);
    r->nkernel = r->npass;
    r->out_fbo = fout;
    r->out_w = W;
    r->out_h = H;
    r->out_rows = GLH_ROWS_AS_IS;
    return 1;
#endif
}

obs_status glsl_sss_read_rgb(glh *g, const glh_run *r, obs_context *ctx, obs_image_f32 out[3])
{
#if !GLH_AVAILABLE
    (void)g, (void)r, (void)ctx, (void)out;
    return OBS_STATUS_UNSUPPORTED;
#else
    const int W = r->out_w, H = r->out_h;
    memset(out, 0, sizeof(obs_image_f32) * 3);
    float *buf = (float *)malloc(sizeof(float) * 4 * (size_t)W * (size_t)H);
    if (!buf)
        return OBS_STATUS_OUT_OF_MEMORY;
    glh_run_draw(g, r, 0, r->npass);
    g->gl.glBindFramebuffer(GL_FRAMEBUFFER, r->out_fbo);
    g->gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
    g->gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
    g->gl.glReadPixels(0, 0, W, H, GL_RGBA, GL_FLOAT, buf);
    g->gl.glFinish();
    obs_status st = OBS_STATUS_OK;
    for (int c = 0; c < 3 && st == OBS_STATUS_OK; c++)
        st = obs_image_f32_alloc(ctx, W, H, &out[c]);
    if (st == OBS_STATUS_OK)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int c = 0; c < 3; c++)
                    obs_image_f32_row(&out[c], y)[x] = buf[4 * ((size_t)y * W + x) + c];
    else
        for (int c = 0; c < 3; c++)
            obs_image_f32_free(&out[c]);
    free(buf);
    return st;
#endif
}
