/* glsl_volume.c: the project's own GLSL port of the light-volume propagation of [Ropinski10]
 * (docs/volume/light.md, "GLSL port"), re-typed in GLSL 4.50 after the formulas of
 * src/volume/vol_light.c and docs/volume/light.md, the way the paper's GPU method computes it:
 * slice by slice, one fragment pass per slice into a layer of a 3D texture, each pass reading the
 * previous layer (volume.md 1.2, 1.4-1.5; Voreen's lightvolumegenerator.frag renders the same way).
 *
 * Per light-volume voxel x on slice k of the propagation axis a (the same quantities as
 * vol_light.c's per-tap path; docs/volume/light.md, "The algorithm, step by step"):
 *   sigma_t(x) = kappa (-ln(1 - alpha_TF(s(x)))) / ref_step     (vol.h's convention; alpha clamped
 *                                                                 to 1 - 2^-24)
 *   p          = x - ds D, ds = Delta_a / |D_a|                  (volume.md 1.4)
 *   tau        = exp(-ds (sigma_t(x) + sigma_t(p)) / 2)          (the trapezoid of light.md)
 *   l(x)       = tau l(p)                                         one bilinear fetch
 *   c(x)       = tau cone(c, p) + (1 - tau) c_TF(s(x))            cone: the centre and R rings of
 *                                                                 8j bilinear taps at r j / R,
 *                                                                 r = ds tan(theta), Gaussian
 *                                                                 weights exp(-2 (j/R)^2), normalised
 * with the face slice (half a slab from the face, sigma_t(x) constant, l = c = 1 beyond), and for
 * a light inside the slab range the two seed slices by a straight trapezoid march to the light
 * (step half the smallest data spacing). Texels outside the slice read the border: l = c = 1,
 * sigma_t = 0 (GL's CLAMP_TO_BORDER, done by hand). A last pass merges F0 and F1 with Inviwo's
 * weight w: t + w (c0 - t) (lightvolumeblend.frag, volume.md 1.7).
 *
 * What the port had to translate (as glsl_sss.c did; docs/gl.md):
 *   - Double precision. Our positions, ray directions, fetch coordinates, TF interpolation,
 *     extinction and exponentials are in double. GLSL 4.50 has double + - * / sqrt floor ceil
 *     (llvmpipe implements fp64) but no double exp or log, so the port carries its own: d_exp
 *     (Cody-Waite reduction by ln 2 split in two, a degree-13 Taylor polynomial, ldexp) and d_log
 *     (frexp, then 2 atanh((m - 1) / (m + 1)) as a series to degree 25), a few double ulp from
 *     glibc's; the results are rounded to float as ours are, so they differ from ours only when a
 *     double lies within a few ulp of a float rounding boundary.
 *   - Double constants travel as bit patterns in int uniform arrays (packDouble2x32), so nothing
 *     is rounded through a decimal literal; every temporary is `precise` (no reassociation or
 *     fused multiply-add), and the expressions keep our C operation order.
 *   - Bilinear fetches are texelFetch of the four texels with our weights (float(p - floor(p)))
 *     and our lerp form a + (b - a) t, since llvmpipe's GL_LINEAR quantises weights to 8 bits.
 *   - Reading layer k -/+ 1 while writing layer k of the same 3D texture: disjoint texels, with
 *     glTextureBarrier between the draws (GL 4.5, 9.3.1, "Rendering Feedback Loops").
 *   - The 3D textures of the propagation are in the face's permuted layout (nu, nv, n_a): only
 *     layers along the texture's z can be render targets. The merge pass un-permutes into the
 *     light volume's layout.
 *   - NaN data is not handled (ours gives transparent black); the test volumes have none.
 *   - llvmpipe flushes float subnormals to zero; ours does not. Only values below 1.2e-38 differ.
 *   - Our directional lights take vol_light.c's kernel path (the cone's bilinear weights gathered
 *     into one kernel per pass): the same sums in another order. The port is the per-tap form
 *     (OBS_ISA=scalar), as a GPU does it. */
#include "gl/glsl_volume.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The cone stencils' sizes: R = 1..4 rings, ring j with 8j taps (docs/volume/light.md; vol.h). */
#define GV_MAX_RINGS 4
#define GV_TAPS 160 /* 8 (1 + 3 + 6 + 10): all stencils R = 1..4 side by side */
#define GV_SEED_STEP_FRACTION 0.5 /* the seed march's step, x the smallest data spacing (light.md) */

/* the double constants' slots */
enum { DC_ORG = 0, DC_SP = 3, DC_LO = 6, DC_HI = 9, DC_GORG = 12, DC_GSP = 15, DC_LP = 18, DC_TANT = 21,
       DC_REFSTEP = 22, DC_KAPPA = 23, DC_HMIN = 24, DC_INVLN2 = 25, DC_LN2HI = 26, DC_LN2LO = 27, DC_N = 28 };

#if GLH_AVAILABLE
static const char *const fs_propagate =
"#version 450\n"
"layout(binding=0) uniform sampler3D dataTex; /* the data, R32F, x fastest */\n"
"layout(binding=1) uniform sampler3D lvTex;   /* this face's (l, c.rgb), permuted (u, v, a) */\n"
"layout(binding=2) uniform sampler3D sigTex;  /* this face's sigma_t */\n"
"uniform int dbits[2 * ND];\n"
"uniform int tfbits[2 * NTF];  /* TF values, double bits */\n"
"uniform vec4 tfc[NTF];        /* TF rgba */\n"
"uniform int stu[2 * NST], stv[2 * NST]; /* cone stencil offsets in units of r, double bits */\n"
"uniform float stw[NST];\n"
"uniform float stsum[5];\n"
"uniform int A, U, V, NU, NV;\n"
"uniform int k, kprev, mode;\n"
"layout(location=0) out vec4 oLV;\n"
"layout(location=1) out vec4 oSIG;\n"
"double bd(int lo, int hi) { return packDouble2x32(uvec2(uint(lo), uint(hi))); }\n"
"double DC(int i) { return bd(dbits[2 * i], dbits[2 * i + 1]); }\n"
"double tfval(int i) { return bd(tfbits[2 * i], tfbits[2 * i + 1]); }\n"
"\n"
"/* exp in double: x = n ln2 + r, |r| <= ln2 / 2, Taylor to degree 13, 2^n by ldexp */\n"
"double d_exp(double x) {\n"
"  if (x < -700.0LF) return 0.0LF; /* below 1e-304: 0 once rounded to float, as ours */\n"
"  precise double n = roundEven(x * DC(DC_INVLN2));\n"
"  precise double r = (x - n * DC(DC_LN2HI)) - n * DC(DC_LN2LO);\n"
"  precise double p = 1.0LF / 6227020800.0LF;\n"
"  p = p * r + 1.0LF / 479001600.0LF;\n"
"  p = p * r + 1.0LF / 39916800.0LF;\n"
"  p = p * r + 1.0LF / 3628800.0LF;\n"
"  p = p * r + 1.0LF / 362880.0LF;\n"
"  p = p * r + 1.0LF / 40320.0LF;\n"
"  p = p * r + 1.0LF / 5040.0LF;\n"
"  p = p * r + 1.0LF / 720.0LF;\n"
"  p = p * r + 1.0LF / 120.0LF;\n"
"  p = p * r + 1.0LF / 24.0LF;\n"
"  p = p * r + 1.0LF / 6.0LF;\n"
"  p = p * r + 0.5LF;\n"
"  p = p * r + 1.0LF;\n"
"  p = p * r + 1.0LF;\n"
"  precise double e = ldexp(p, int(n));\n"
"  return e;\n"
"}\n"
"/* log in double for x > 0: x = m 2^e, m in [sqrt(1/2), sqrt(2)), log m = 2 atanh(s), s = (m-1)/(m+1) */\n"
"double d_log(double x) {\n"
"  int e;\n"
"  precise double m = frexp(x, e);\n"
"  if (m < 0.70710678118654752LF) { m = m * 2.0LF; e = e - 1; }\n"
"  precise double s = (m - 1.0LF) / (m + 1.0LF);\n"
"  precise double s2 = s * s;\n"
"  precise double q = 1.0LF / 25.0LF;\n"
"  q = q * s2 + 1.0LF / 23.0LF;\n"
"  q = q * s2 + 1.0LF / 21.0LF;\n"
"  q = q * s2 + 1.0LF / 19.0LF;\n"
"  q = q * s2 + 1.0LF / 17.0LF;\n"
"  q = q * s2 + 1.0LF / 15.0LF;\n"
"  q = q * s2 + 1.0LF / 13.0LF;\n"
"  q = q * s2 + 1.0LF / 11.0LF;\n"
"  q = q * s2 + 1.0LF / 9.0LF;\n"
"  q = q * s2 + 1.0LF / 7.0LF;\n"
"  q = q * s2 + 1.0LF / 5.0LF;\n"
"  q = q * s2 + 1.0LF / 3.0LF;\n"
"  q = q * s2 + 1.0LF;\n"
"  precise double lm = (2.0LF * s) * q;\n"
"  precise double de = double(e);\n"
"  precise double res = de * DC(DC_LN2HI) + (lm + de * DC(DC_LN2LO));\n"
"  return res;\n"
"}\n"
"\n"
"/* vol_tf_eval: piecewise linear in double, rounded to float; constant beyond the ends */\n"
"vec4 tf_eval(double value) {\n"
"  if (value <= tfval(0)) return tfc[0];\n"
"  if (value >= tfval(NTF - 1)) return tfc[NTF - 1];\n"
"  int lo = 0, hi = NTF - 1;\n"
"  while (hi - lo > 1) { int mid = (lo + hi) / 2; if (tfval(mid) <= value) lo = mid; else hi = mid; }\n"
"  precise double t = (value - tfval(lo)) / (tfval(hi) - tfval(lo));\n"
"  vec4 o;\n"
"  for (int c = 0; c < 4; c++) {\n"
"    precise double v = double(tfc[lo][c]) * (1.0LF - t) + double(tfc[hi][c]) * t;\n"
"    o[c] = float(v);\n"
"  }\n"
"  return o;\n"
"}\n"
"/* vol_sigma_from_alpha: -ln(1 - a) / ref_step, a clamped to 1 - 2^-24 (1 - a is exact in double) */\n"
"double sigma_of(float alpha) {\n"
"  if (!(alpha > 0.0) || !(DC(DC_REFSTEP) > 0.0LF)) return 0.0LF;\n"
"  precise double a = alpha < 0.999999940395355224609375 ? double(alpha) : 0.999999940395355224609375LF;\n"
"  precise double sg = (-d_log(1.0LF - a)) / DC(DC_REFSTEP);\n"
"  return sg;\n"
"}\n"
"/* vol_grid_sample: trilinear at a continuous voxel coordinate, clamped to the edge */\n"
"void vsplit(double c, int n, out int i0, out int i1, out float t) {\n"
"  if (!(c > 0.0LF)) { i0 = 0; i1 = 0; t = 0.0; return; }\n"
"  if (c >= double(n - 1)) { i0 = n - 1; i1 = n - 1; t = 0.0; return; }\n"
"  double f = floor(c);\n"
"  i0 = int(f); i1 = i0 + 1;\n"
"  t = float(c - f);\n"
"}\n"
"float dat(int x, int y, int z) { return texelFetch(dataTex, ivec3(x, y, z), 0).r; }\n"
"float gsample(double ci, double cj, double ck) {\n"
"  int x0, x1, y0, y1, z0, z1;\n"
"  float tx, ty, tz;\n"
"  vsplit(ci, GNX, x0, x1, tx);\n"
"  vsplit(cj, GNY, y0, y1, ty);\n"
"  vsplit(ck, GNZ, z0, z1, tz);\n"
"  precise float ux = 1.0 - tx, uy = 1.0 - ty, uz = 1.0 - tz;\n"
"  precise float c00 = dat(x0, y0, z0) * ux + dat(x1, y0, z0) * tx, c10 = dat(x0, y1, z0) * ux + dat(x1, y1, z0) * tx;\n"
"  precise float c01 = dat(x0, y0, z1) * ux + dat(x1, y0, z1) * tx, c11 = dat(x0, y1, z1) * ux + dat(x1, y1, z1) * tx;\n"
"  precise float c0 = c00 * uy + c10 * ty, c1 = c01 * uy + c11 * ty;\n"
"  precise float r = c0 * uz + c1 * tz;\n"
"  return r;\n"
"}\n"
"/* the extinction at a world point: trilinear value, TF, sigma_t; 0 outside the data's bounds */\n"
"double sigma_world(dvec3 y) {\n"
"  for (int c = 0; c < 3; c++)\n"
"    if (y[c] < DC(DC_LO + c) || y[c] > DC(DC_HI + c)) return 0.0LF;\n"
"  precise double ci = (y[0] - DC(DC_GORG)) / DC(DC_GSP);\n"
"  precise double cj = (y[1] - DC(DC_GORG + 1)) / DC(DC_GSP + 1);\n"
"  precise double ck = (y[2] - DC(DC_GORG + 2)) / DC(DC_GSP + 2);\n"
"  float s = gsample(ci, cj, ck);\n"
"  precise double sg = DC(DC_KAPPA) * sigma_of(tf_eval(double(s)).a);\n"
"  return sg;\n"
"}\n"
"/* a seed slice: the transmittance straight to the point light, trapezoid rule */\n"
"double seed_march(dvec3 x) {\n"
"  precise dvec3 d = dvec3(DC(DC_LP) - x[0], DC(DC_LP + 1) - x[1], DC(DC_LP + 2) - x[2]);\n"
"  precise double len = sqrt((d.x * d.x + d.y * d.y) + d.z * d.z);\n"
"  if (!(len > 0.0LF)) return 1.0LF;\n"
"  int steps = int(ceil(len / DC(DC_HMIN)));\n"
"  if (steps < 1) steps = 1;\n"
"  precise double h = len / double(steps);\n"
"  precise double acc = 0.0LF;\n"
"  precise double prev = sigma_world(x);\n"
"  for (int s = 1; s <= steps; s++) {\n"
"    precise double t = double(s) / double(steps);\n"
"    precise dvec3 y = dvec3(x[0] + t * d.x, x[1] + t * d.y, x[2] + t * d.z);\n"
"    precise double cur = sigma_world(y);\n"
"    acc = acc + (0.5LF * (prev + cur)) * h;\n"
"    prev = cur;\n"
"  }\n"
"  return d_exp(-acc);\n"
"}\n"
"/* the previous layer, texels outside the slice reading the border */\n"
"vec4 prevLV(int i, int j, vec4 border) {\n"
"  if (i < 0 || j < 0 || i >= NU || j >= NV) return border;\n"
"  return texelFetch(lvTex, ivec3(i, j, kprev), 0);\n"
"}\n"
"float prevSig(int i, int j) {\n"
"  if (i < 0 || j < 0 || i >= NU || j >= NV) return 0.0;\n"
"  return texelFetch(sigTex, ivec3(i, j, kprev), 0).r;\n"
"}\n"
"/* bilinear (l, c.rgb) at (pu, pv) (texel centres at integers), our lerp form a + (b - a) t */\n"
"vec4 fetchLV(double pu, double pv) {\n"
"  const vec4 border = vec4(1.0);\n"
"  if (pu > double(NU) + 1.0LF || pv > double(NV) + 1.0LF || pu < -2.0LF || pv < -2.0LF) return border;\n"
"  double fu = floor(pu), fv = floor(pv);\n"
"  int i0 = int(fu), j0 = int(fv);\n"
"  precise float tu = float(pu - fu), tv = float(pv - fv);\n"
"  vec4 t00 = prevLV(i0, j0, border), t10 = prevLV(i0 + 1, j0, border);\n"
"  vec4 t01 = prevLV(i0, j0 + 1, border), t11 = prevLV(i0 + 1, j0 + 1, border);\n"
"  precise vec4 a = t00 + (t10 - t00) * tu, b = t01 + (t11 - t01) * tu;\n"
"  precise vec4 r = a + (b - a) * tv;\n"
"  return r;\n"
"}\n"
"float fetchSig(double pu, double pv) {\n"
"  if (pu > double(NU) + 1.0LF || pv > double(NV) + 1.0LF || pu < -2.0LF || pv < -2.0LF) return 0.0;\n"
"  double fu = floor(pu), fv = floor(pv);\n"
"  int i0 = int(fu), j0 = int(fv);\n"
"  precise float tu = float(pu - fu), tv = float(pv - fv);\n"
"  float t00 = prevSig(i0, j0), t10 = prevSig(i0 + 1, j0), t01 = prevSig(i0, j0 + 1), t11 = prevSig(i0 + 1, j0 + 1);\n"
"  precise float a = t00 + (t10 - t00) * tu, b = t01 + (t11 - t01) * tu;\n"
"  precise float r = a + (b - a) * tv;\n"
"  return r;\n"
"}\n"
"\n"
"void main() {\n"
"  int iu = int(gl_FragCoord.x), jv = int(gl_FragCoord.y);\n"
"  ivec3 idx;\n"
"  idx[A] = k; idx[U] = iu; idx[V] = jv;\n"
"  precise dvec3 x;\n"
"  for (int c = 0; c < 3; c++) x[c] = DC(DC_ORG + c) + double(idx[c]) * DC(DC_SP + c);\n"
"  /* classification at the light-volume voxel */\n"
"#if SCALE == 1\n"
"  float s = texelFetch(dataTex, idx, 0).r; /* the data's own voxel */\n"
"#else\n"
"  precise double ci = (x[0] - DC(DC_GORG)) / DC(DC_GSP);\n"
"  precise double cj = (x[1] - DC(DC_GORG + 1)) / DC(DC_GSP + 1);\n"
"  precise double ck = (x[2] - DC(DC_GORG + 2)) / DC(DC_GSP + 2);\n"
"  float s = gsample(ci, cj, ck);\n"
"#endif\n"
"  vec4 rgba = tf_eval(double(s));\n"
"  float sigma = float(DC(DC_KAPPA) * sigma_of(rgba.a));\n"
"  vec3 ctf = rgba.rgb;\n"
"  /* the light's travel direction at x */\n"
"  precise dvec3 D;\n"
"#if POINT\n"
"  precise double dx = x[0] - DC(DC_LP), dy = x[1] - DC(DC_LP + 1), dz = x[2] - DC(DC_LP + 2);\n"
"  precise double len = sqrt((dx * dx + dy * dy) + dz * dz);\n"
"  if (len > 0.0LF) D = dvec3(dx / len, dy / len, dz / len); else D = dvec3(0.0LF, 0.0LF, 1.0LF);\n"
"#else\n"
"  D = dvec3(DC(DC_LP), DC(DC_LP + 1), DC(DC_LP + 2));\n"
"#endif\n"
"  double cos_g = abs(D[A]);\n"
"  precise float l;\n"
"  precise vec3 cc;\n"
"  if (mode == 2) {\n"
"    precise double T = seed_march(x);\n"
"    l = float(T);\n"
"    for (int c = 0; c < 3; c++) { precise double v = T + (1.0LF - T) * double(ctf[c]); cc[c] = float(v); }\n"
"  } else if (mode == 0 || cos_g < 1e-12LF) {\n"
"    precise double ds = cos_g > 0.0LF ? (0.5LF * DC(DC_SP + A)) / cos_g : 0.0LF;\n"
"    precise float tau = float(d_exp((-double(sigma)) * ds));\n"
"    l = tau;\n"
"    cc = tau + (1.0 - tau) * ctf;\n"
"  } else {\n"
"    precise double ds = DC(DC_SP + A) / cos_g;\n"
"    precise double pu = double(iu) - (ds * D[U]) / DC(DC_SP + U);\n"
"    precise double pv = double(jv) - (ds * D[V]) / DC(DC_SP + V);\n"
"    float sigma_p = fetchSig(pu, pv);\n"
"    precise float tau = float(d_exp(((-0.5LF) * (double(sigma) + double(sigma_p))) * ds));\n"
"    vec4 lc = fetchLV(pu, pv);\n"
"    l = tau * lc.x;\n"
"    precise double r = ds * DC(DC_TANT);\n"
"    precise double ru = r / DC(DC_SP + U), rv = r / DC(DC_SP + V);\n"
"    double rmax = ru > rv ? ru : rv;\n"
"    int R = int(ceil(rmax - 1e-9LF));\n"
"    if (R < 1) R = 1;\n"
"    if (R > 4) R = 4;\n"
"    int o = 8 * (R - 1) * R * (R + 1) / 6, cnt = 8 * R * (R + 1) / 2;\n"
"    precise vec3 acc = lc.yzw;\n"
"    for (int m = 0; m < cnt; m++) {\n"
"      precise double qu = pu + ru * bd(stu[2 * (o + m)], stu[2 * (o + m) + 1]);\n"
"      precise double qv = pv + rv * bd(stv[2 * (o + m)], stv[2 * (o + m) + 1]);\n"
"      precise vec3 q = fetchLV(qu, qv).yzw;\n"
"      acc = acc + stw[o + m] * q;\n"
"    }\n"
"    cc = tau * (acc / stsum[R]) + (1.0 - tau) * ctf;\n"
"  }\n"
"  oLV = vec4(l, cc);\n"
"  oSIG = vec4(sigma, 0.0, 0.0, 0.0);\n"
"}\n";

/* Inviwo's merge (lightvolumeblend.frag, volume.md 1.7): t + w (c0 - t), un-permuting each face */
static const char *const fs_merge =
"#version 450\n"
"layout(binding=1) uniform sampler3D f0Tex;\n"
"layout(binding=2) uniform sampler3D f1Tex;\n"
"uniform int A0, U0, V0, A1, U1, V1, z, blend;\n"
"uniform float w;\n"
"layout(location=0) out vec4 o;\n"
"void main() {\n"
"  ivec3 idx = ivec3(int(gl_FragCoord.x), int(gl_FragCoord.y), z);\n"
"  vec4 c0 = texelFetch(f0Tex, ivec3(idx[U0], idx[V0], idx[A0]), 0);\n"
"  if (blend == 0) { o = c0; return; }\n"
"  vec4 t = texelFetch(f1Tex, ivec3(idx[U1], idx[V1], idx[A1]), 0);\n"
"  precise vec4 r = t + w * (c0 - t);\n"
"  o = r;\n"
"}\n";

static void put_double(int *bits, int i, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    bits[2 * i] = (int)(uint32_t)(u & 0xffffffffu);
    bits[2 * i + 1] = (int)(uint32_t)(u >> 32);
}

static GLuint tex3d(glh *g, int w, int h, int d, GLenum ifmt, const float *data)
{
    GLuint t = 0;
    g->gl.glGenTextures(1, &t);
    g->gl.glBindTexture(GL_TEXTURE_3D, t);
    g->gl.glTexStorage3D(GL_TEXTURE_3D, 1, ifmt, w, h, d);
    if (data)
        g->gl.glTexSubImage3D(GL_TEXTURE_3D, 0, 0, 0, 0, w, h, d, GL_RED, GL_FLOAT, data);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
    g->gl.glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAX_LEVEL, 0);
    return t;
}

/* A framebuffer on layer `layer` of t0 (and of t1 as attachment 1 when t1 != 0). */
static GLuint layer_fbo(glh *g, GLuint t0, GLuint t1, int layer)
{
    GLuint f = 0;
    g->gl.glGenFramebuffers(1, &f);
    g->gl.glBindFramebuffer(GL_FRAMEBUFFER, f);
    g->gl.glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, t0, 0, layer);
    if (t1)
        g->gl.glFramebufferTextureLayer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, t1, 0, layer);
    const GLenum db[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    g->gl.glDrawBuffers(t1 ? 2 : 1, db);
    if (g->gl.glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        printf("  GL: framebuffer on layer %d of texture %u is incomplete\n", layer, t0);
        g->gl.glDeleteFramebuffers(1, &f);
        return 0;
    }
    return f;
}

/* The host side: face choice (volume.md 1.3, Inviwo: c_k = n_k . l_hat, F0 = argmax, F1 = argmax
 * over the two other axes, ties to the lower face), Inviwo's weight (1.7), the light volume's grid. */
typedef struct gv_setup {
    int n[3];
    double sp[3], org[3], lo[3], hi[3];
    int point;
    double LP[3];
    int f0, f1;
    float w;
    int need_second;
} gv_setup;

static int gv_setup_make(const vol_grid *grid, const vol_light *light, const vol_lv_params *p, gv_setup *S)
{
    memset(S, 0, sizeof *S);
    vol_grid_bounds(grid, S->lo, S->hi);
    double lhat[3];
    if (light->type == OBS_LIGHT_DIRECTIONAL) {
        const double *d = light->direction;
        double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(len > 0.0))
            return 0;
        for (int c = 0; c < 3; c++) {
            S->LP[c] = d[c] / len;
            lhat[c] = -S->LP[c];
        }
    } else if (light->type == OBS_LIGHT_POINT) {
        S->point = 1;
        double len = 0.0;
        for (int c = 0; c < 3; c++) {
            S->LP[c] = light->position[c];
            lhat[c] = (light->position[c] - S->lo[c]) / (S->hi[c] - S->lo[c]) - 0.5;
            len += lhat[c] * lhat[c];
        }
        len = sqrt(len);
        for (int c = 0; c < 3; c++)
            lhat[c] = len > 0.0 ? lhat[c] / len : (c == 2 ? 1.0 : 0.0);
    } else {
        return 0;
    }
    const int nd[3] = {grid->nx, grid->ny, grid->nz};
    for (int c = 0; c < 3; c++) {
        S->n[c] = (nd[c] + p->scale - 1) / p->scale;
        S->sp[c] = (S->hi[c] - S->lo[c]) / S->n[c];
        S->org[c] = S->lo[c] + 0.5 * S->sp[c];
        if (p->scale == 1) {
            S->sp[c] = grid->spacing[c];
            S->org[c] = grid->origin[c];
        }
    }
    double best = -2.0, second = -2.0;
    S->f0 = S->f1 = -1;
    for (int f = 0; f < 6; f++) {
        double c = (f & 1 ? 1.0 : -1.0) * lhat[f >> 1];
        if (c > best)
            best = c, S->f0 = f;
    }
    for (int f = 0; f < 6; f++) {
        if ((f >> 1) == (S->f0 >> 1))
            continue;
        double c = (f & 1 ? 1.0 : -1.0) * lhat[f >> 1];
        if (c > second)
            second = c, S->f1 = f;
    }
    if (best > 1.0)
        best = 1.0;
    S->w = p->blend_second ? (float)(1.0 - 2.0 * acos(best) / OBS_PI) : 1.0f;
    S->need_second = p->blend_second && S->w < 1.0f;
    if (!p->blend_second)
        S->f1 = -1;
    return 1;
}
#endif /* GLH_AVAILABLE */

int glsl_volume_build(glh *g, obs_context *ctx, const vol_grid *grid, const vol_tf *tf, const vol_light *light,
                      const vol_lv_params *p, glsl_volume *r)
{
    memset(r, 0, sizeof *r);
#if !GLH_AVAILABLE
    (void)g, (void)ctx, (void)grid, (void)tf, (void)light, (void)p;
    return 0;
#else
    if (vol_lv_params_validate(ctx, p) != OBS_STATUS_OK) {
        printf("  glsl_volume: %s\n", obs_context_last_error(ctx));
        return 0;
    }
    if (tf->count < 1 || tf->count > GLSL_VOLUME_MAX_TF) {
        printf("  glsl_volume: %d TF points (1..%d)\n", tf->count, GLSL_VOLUME_MAX_TF);
        return 0;
    }
    gv_setup S;
    if (!gv_setup_make(grid, light, p, &S)) {
        printf("  glsl_volume: the light must be directional (non-zero direction) or point\n");
        return 0;
    }
    for (int c = 0; c < 3; c++)
        r->n[c] = S.n[c];
    r->face0 = S.f0;
    r->face1 = S.f1;
    r->blend_weight = S.w;
    r->nfaces = S.need_second ? 2 : 1;

    /* the double constants */
    int db[2 * DC_N];
    double ref_step = tf->ref_step > 0.0 ? tf->ref_step : fmin(grid->spacing[0], fmin(grid->spacing[1], grid->spacing[2]));
    for (int c = 0; c < 3; c++) {
        put_double(db, DC_ORG + c, S.org[c]);
        put_double(db, DC_SP + c, S.sp[c]);
        put_double(db, DC_LO + c, S.lo[c]);
        put_double(db, DC_HI + c, S.hi[c]);
        put_double(db, DC_GORG + c, grid->origin[c]);
        put_double(db, DC_GSP + c, grid->spacing[c]);
        put_double(db, DC_LP + c, S.LP[c]);
    }
    put_double(db, DC_TANT, tan(p->cone_angle_deg * OBS_PI / 180.0));
    put_double(db, DC_REFSTEP, ref_step);
    put_double(db, DC_KAPPA, p->kappa);
    put_double(db, DC_HMIN, fmin(grid->spacing[0], fmin(grid->spacing[1], grid->spacing[2])) * GV_SEED_STEP_FRACTION);
    put_double(db, DC_INVLN2, 0x1.71547652b82fep+0);  /* 1 / ln 2 */
    put_double(db, DC_LN2HI, 0x1.62e42feep-1);        /* ln 2, high part (fdlibm's split) */
    put_double(db, DC_LN2LO, 0x1.a39ef35793c76p-33);  /* ln 2 - ln2_hi */
    int tfb[2 * GLSL_VOLUME_MAX_TF];
    float tfc[4 * GLSL_VOLUME_MAX_TF];
    for (int i = 0; i < tf->count; i++) {
        put_double(tfb, i, tf->points[i].value);
        memcpy(tfc + 4 * i, tf->points[i].rgba, 4 * sizeof(float));
    }
    /* The cone stencils (light.md step 6: ring j of R at radius j/R, 8j taps at angles 2 pi m / 8j,
     * weight exp(-2 (j/R)^2); the sum with the centre's 1, accumulated in that order in float). */
    int stu[2 * GV_TAPS], stv[2 * GV_TAPS];
    float stw[GV_TAPS];
    float stsum[5] = {0};
    {
        int t = 0;
        for (int R = 1; R <= GV_MAX_RINGS; R++) {
            float wsum = 1.0f;
            for (int j = 1; j <= R; j++) {
                double f = (double)j / R;
                float w = (float)exp(-2.0 * f * f);
                int taps = 8 * j;
                for (int m = 0; m < taps; m++, t++) {
                    double phi = 2.0 * OBS_PI * m / taps;
                    put_double(stu, t, f * cos(phi));
                    put_double(stv, t, f * sin(phi));
                    stw[t] = w;
                    wsum += w;
                }
            }
            stsum[R] = wsum;
        }
    }

    char pre[1024];
    snprintf(pre, sizeof pre, "#define ND %d\n#define NTF %d\n#define NST %d\n#define SCALE %d\n#define POINT %d\n"
             "#define GNX %d\n#define GNY %d\n#define GNZ %d\n#define DC_ORG %d\n#define DC_SP %d\n#define DC_LO %d\n"
             "#define DC_HI %d\n#define DC_GORG %d\n#define DC_GSP %d\n#define DC_LP %d\n#define DC_TANT %d\n",
             DC_N, tf->count, GV_TAPS, p->scale, S.point, grid->nx, grid->ny, grid->nz, DC_ORG, DC_SP, DC_LO, DC_HI,
             DC_GORG, DC_GSP, DC_LP, DC_TANT);
    char pre2[2048];
    snprintf(pre2, sizeof pre2, "%s#define DC_REFSTEP %d\n#define DC_KAPPA %d\n#define DC_HMIN %d\n#define DC_INVLN2 %d\n"
             "#define DC_LN2HI %d\n#define DC_LN2LO %d\n", pre, DC_REFSTEP, DC_KAPPA, DC_HMIN, DC_INVLN2, DC_LN2HI, DC_LN2LO);
    r->prog_prop = glh_program(g, fs_propagate, pre2);
    r->prog_merge = glh_program(g, fs_merge, NULL);
    if (!r->prog_prop || !r->prog_merge) {
        glsl_volume_free(g, r);
        return 0;
    }
    GLuint pp = r->prog_prop;
    g->gl.glProgramUniform1iv(pp, g->gl.glGetUniformLocation(pp, "dbits"), 2 * DC_N, db);
    g->gl.glProgramUniform1iv(pp, g->gl.glGetUniformLocation(pp, "tfbits"), 2 * tf->count, tfb);
    g->gl.glProgramUniform4fv(pp, g->gl.glGetUniformLocation(pp, "tfc"), tf->count, tfc);
    g->gl.glProgramUniform1iv(pp, g->gl.glGetUniformLocation(pp, "stu"), 2 * GV_TAPS, stu);
    g->gl.glProgramUniform1iv(pp, g->gl.glGetUniformLocation(pp, "stv"), 2 * GV_TAPS, stv);
    g->gl.glProgramUniform1fv(pp, g->gl.glGetUniformLocation(pp, "stw"), GV_TAPS, stw);
    g->gl.glProgramUniform1fv(pp, g->gl.glGetUniformLocation(pp, "stsum"), 5, stsum);

    /* the data */
    r->data_tex = tex3d(g, grid->nx, grid->ny, grid->nz, GL_R32F, grid->data);

    /* the slices of each face, in propagation order (light.md step 7) */
    int maxdraws = 0;
    for (int f = 0; f < r->nfaces; f++) {
        int face = f == 0 ? S.f0 : S.f1, a = face >> 1;
        maxdraws += S.n[a];
    }
    maxdraws += S.n[2];
    r->draws = (glsl_volume_draw *)calloc((size_t)maxdraws, sizeof *r->draws);
    if (!r->draws || !r->data_tex) {
        glsl_volume_free(g, r);
        return 0;
    }
    for (int f = 0; f < r->nfaces; f++) {
        int face = f == 0 ? S.f0 : S.f1, a = face >> 1, u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
        int lowside = (face & 1) == 0;
        r->axis[f] = a;
        r->dims[f][0] = S.n[u];
        r->dims[f][1] = S.n[v];
        r->dims[f][2] = S.n[a];
        r->lv_tex[f] = tex3d(g, S.n[u], S.n[v], S.n[a], GL_RGBA32F, NULL);
        r->sig_tex[f] = tex3d(g, S.n[u], S.n[v], S.n[a], GL_R32F, NULL);
        const int na = S.n[a];
        double kL = 0.0;
        int inside = 0;
        if (S.point) {
            kL = (S.LP[a] - S.org[a]) / S.sp[a];
            inside = kL >= -0.5 && kL <= (double)na - 0.5;
        }
#define GV_ADD(K, KP, MODE)                                                                          \
    do {                                                                                             \
        glsl_volume_draw *d_ = &r->draws[r->ndraws++];                                               \
        d_->pass = f, d_->k = (K), d_->kprev = (KP), d_->mode = (MODE);                              \
        d_->fbo = layer_fbo(g, r->lv_tex[f], r->sig_tex[f], (K));                                    \
        if (!d_->fbo) {                                                                              \
            glsl_volume_free(g, r);                                                                  \
            return 0;                                                                                \
        }                                                                                            \
    } while (0)
        if (!inside) {
            int low = S.point ? (kL < -0.5) : lowside;
            if (low) {
                GV_ADD(0, 0, 0);
                for (int k = 1; k < na; k++)
                    GV_ADD(k, k - 1, 1);
            } else {
                GV_ADD(na - 1, na - 1, 0);
                for (int k = na - 2; k >= 0; k--)
                    GV_ADD(k, k + 1, 1);
            }
        } else {
            int kup = (int)ceil(kL), kdn = kup - 1;
            if (kup < na) {
                GV_ADD(kup, kup, 2);
                for (int k = kup + 1; k < na; k++)
                    GV_ADD(k, k - 1, 1);
            }
            if (kdn >= 0) {
                GV_ADD(kdn, kdn, 2);
                for (int k = kdn - 1; k >= 0; k--)
                    GV_ADD(k, k + 1, 1);
            }
        }
    }
    r->nprop_draws = r->ndraws;
    r->out_tex = tex3d(g, S.n[0], S.n[1], S.n[2], GL_RGBA32F, NULL);
    for (int z = 0; z < S.n[2]; z++) {
        glsl_volume_draw *d = &r->draws[r->ndraws++];
        d->pass = 2, d->k = z;
        d->fbo = layer_fbo(g, r->out_tex, 0, z);
        if (!d->fbo) {
            glsl_volume_free(g, r);
            return 0;
        }
    }
#undef GV_ADD
    GLuint pm = r->prog_merge;
    int perm[2][3] = {{0, 0, 0}, {0, 0, 0}};
    for (int f = 0; f < r->nfaces; f++) {
        int a = r->axis[f];
        perm[f][0] = a, perm[f][1] = a == 0 ? 1 : 0, perm[f][2] = a == 2 ? 1 : 2;
    }
    glh_set1i(g, pm, "A0", perm[0][0]);
    glh_set1i(g, pm, "U0", perm[0][1]);
    glh_set1i(g, pm, "V0", perm[0][2]);
    glh_set1i(g, pm, "A1", perm[1][0]);
    glh_set1i(g, pm, "U1", perm[1][1]);
    glh_set1i(g, pm, "V1", perm[1][2]);
    glh_set1i(g, pm, "blend", r->nfaces == 2);
    glh_set1f(g, pm, "w", r->blend_weight);
    return 1;
#endif
}

void glsl_volume_run(glh *g, const glsl_volume *r)
{
#if !GLH_AVAILABLE
    (void)g, (void)r;
#else
    const GLuint pp = r->prog_prop, pm = r->prog_merge;
    g->gl.glActiveTexture(GL_TEXTURE0);
    g->gl.glBindTexture(GL_TEXTURE_3D, r->data_tex);
    int cur_pass = -1;
    for (int i = 0; i < r->ndraws; i++) {
        const glsl_volume_draw *d = &r->draws[i];
        if (d->pass != cur_pass) {
            cur_pass = d->pass;
            if (d->pass < 2) {
                int a = r->axis[d->pass], u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
                g->gl.glUseProgram(pp);
                glh_set1i(g, pp, "A", a);
                glh_set1i(g, pp, "U", u);
                glh_set1i(g, pp, "V", v);
                glh_set1i(g, pp, "NU", r->dims[d->pass][0]);
                glh_set1i(g, pp, "NV", r->dims[d->pass][1]);
                g->gl.glActiveTexture(GL_TEXTURE1);
                g->gl.glBindTexture(GL_TEXTURE_3D, r->lv_tex[d->pass]);
                g->gl.glActiveTexture(GL_TEXTURE2);
                g->gl.glBindTexture(GL_TEXTURE_3D, r->sig_tex[d->pass]);
                g->gl.glViewport(0, 0, r->dims[d->pass][0], r->dims[d->pass][1]);
            } else {
                g->gl.glUseProgram(pm);
                g->gl.glActiveTexture(GL_TEXTURE1);
                g->gl.glBindTexture(GL_TEXTURE_3D, r->lv_tex[0]);
                g->gl.glActiveTexture(GL_TEXTURE2);
                g->gl.glBindTexture(GL_TEXTURE_3D, r->nfaces == 2 ? r->lv_tex[1] : r->lv_tex[0]);
                g->gl.glViewport(0, 0, r->n[0], r->n[1]);
            }
        }
        if (d->pass < 2) {
            glh_set1i(g, pp, "k", d->k);
            glh_set1i(g, pp, "kprev", d->kprev);
            glh_set1i(g, pp, "mode", d->mode);
        } else {
            glh_set1i(g, pm, "z", d->k);
        }
        g->gl.glBindFramebuffer(GL_FRAMEBUFFER, d->fbo);
        g->gl.glDrawArrays(GL_TRIANGLES, 0, 3);
        /* the next draw reads this layer: make the writes visible (GL 4.5, 9.3.1) */
        g->gl.glTextureBarrier();
    }
#endif
}

obs_status glsl_volume_read(glh *g, const glsl_volume *r, obs_context *ctx, vol_light_volume *out)
{
    memset(out, 0, sizeof *out);
#if !GLH_AVAILABLE
    (void)g, (void)r, (void)ctx;
    return OBS_STATUS_UNSUPPORTED;
#else
    const size_t voxels = (size_t)r->n[0] * r->n[1] * r->n[2];
    float *buf = (float *)malloc(voxels * 4 * sizeof(float));
    float *mem = (float *)obs_aligned_alloc(voxels * 4 * sizeof(float));
    if (!buf || !mem) {
        free(buf);
        obs_aligned_free(mem);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "glsl_volume_read: out of memory");
    }
    glsl_volume_run(g, r);
    g->gl.glFinish();
    g->gl.glBindTexture(GL_TEXTURE_3D, r->out_tex);
    g->gl.glPixelStorei(GL_PACK_ALIGNMENT, 4);
    g->gl.glGetTexImage(GL_TEXTURE_3D, 0, GL_RGBA, GL_FLOAT, buf);
    out->nx = r->n[0], out->ny = r->n[1], out->nz = r->n[2];
    out->l = mem;
    for (int c = 0; c < 3; c++)
        out->c[c] = mem + (size_t)(c + 1) * voxels;
    for (size_t i = 0; i < voxels; i++) {
        out->l[i] = buf[4 * i];
        for (int c = 0; c < 3; c++)
            out->c[c][i] = buf[4 * i + 1 + c];
    }
    out->face0 = r->face0;
    out->face1 = r->face1;
    out->blend_weight = r->blend_weight;
    free(buf);
    return OBS_STATUS_OK;
#endif
}

double glsl_volume_time_ms(glh *g, const glsl_volume *r)
{
#if !GLH_AVAILABLE
    (void)g, (void)r;
    return 0.0;
#else
    g->gl.glFinish();
    double t0 = obs_time_now();
    glsl_volume_run(g, r);
    g->gl.glFinish();
    return (obs_time_now() - t0) * 1e3;
#endif
}

void glsl_volume_free(glh *g, glsl_volume *r)
{
#if GLH_AVAILABLE
    if (g && g->lib) {
        for (int i = 0; i < r->ndraws; i++)
            if (r->draws[i].fbo)
                g->gl.glDeleteFramebuffers(1, &r->draws[i].fbo);
        GLuint t[6] = {r->data_tex, r->lv_tex[0], r->lv_tex[1], r->sig_tex[0], r->sig_tex[1], r->out_tex};
        for (int i = 0; i < 6; i++)
            if (t[i])
                g->gl.glDeleteTextures(1, &t[i]);
        if (r->prog_prop)
            g->gl.glDeleteProgram(r->prog_prop);
        if (r->prog_merge)
            g->gl.glDeleteProgram(r->prog_merge);
    }
#else
    (void)g;
#endif
    free(r->draws);
    memset(r, 0, sizeof *r);
}
