/* glsl_ue4.c: UE4's SSAO (PostProcessAmbientOcclusion.usf, the 2016 shader docs/ao/ue4.md reads:
 * JimmieKJ/unrealTournament @ 89cfe56) in GLSL, the whole chain our kernel runs, one GLSL pass per
 * shader pass:
 *   levels 2 (the default):  setup (MainSetupPS: level 1 from level 0) -> AO at level 1
 *     (MainPSandCS, USE_AO_SETUP_AS_INPUT 1, sample set 3, AORadiusInShader * MipScale) -> its quad
 *     blur -> AO at level 0 (USE_UPSAMPLE 1: ComputeUpsampleContribution, lerp by MipBlend; the fade
 *     and the user adjustment) -> its quad blur, saturated (UE's UNORM target);
 *   levels 1: AO at level 0 -> its quad blur;
 *   then the seed's 21-tap Gaussian (glsl_gauss21.c) when params->blur.
 * Both variants (OPTIMIZATION_O1 1, the default; 0, our `classic-reconstruction`), normal modes
 * gbuffer (SSAO_NORMAL_MODE 1) and none (0), QUAD_MESSAGE_PASSING_BLUR 0..3, any sample set and
 * SAMPLE_STEPS. Not ported: `--normals depth` (our ao_normals_from_depth, difference 4) and
 * orthographic cameras (our extension).
 *
 * Translation (HLSL -> GLSL) and where the port follows OUR documented behaviour (docs/ao/ue4.md,
 * "Differences"):
 * - D3D rows: the inputs are uploaded as is (GLH_ROWS_AS_IS), so (x, y) = ivec2(gl_FragCoord.xy)
 *   is SV_Position (y down from the top), the random texel is (x % 4, y % 4) and 2x2 quads start at
 *   even x and even y from the top, as in UE.
 * - ddx_fine / ddy_fine of the quad blur: the AO pass writes (ao, SceneDepth, n.xy) of every pixel
 *   of the buffer padded to whole quads (the helper lanes of an odd size included) into an RGBA32F
 *   target; the quad-blur pass reads the pixel's horizontal and vertical quad partners with
 *   texelFetch and forms dX = right - left, dY = bottom - top as ddx_fine/ddy_fine do. (llvmpipe's
 *   derivatives need not be fine; this keeps the HLSL semantics exactly.)
 * - saturate(v) keeps HLSL's NaN -> 0; lerp(a, b, t) = a + t (b - a); rsqrt = 1 / sqrt.
 * - SceneDepth is our depth x 100 (uu), background and depths beyond 100 km read 100 km; taps
 *   point-sample the full-resolution depth (or the level's setup depth) at their texel,
 *   floor((sp.x W/2 + cx) / s), clamped (difference 1, not UE's HZB MIP).
 * - ScreenPos of a texel centre ((x + 0.5) s - cx) 2/W is computed in double (ours), rounded to float.
 * - classic-reconstruction: InvHaloSize = 1 / (2 ActualAORadius) (difference 2).
 * - The setup level keeps float32 (difference 3); its normal is the average of n * 0.5 + 0.5,
 *   decoded rgb * 2 - 1. The coarse AO stays float.
 * - A background pixel is 1 and stays 1 through the quad blur; a zero normal gives 1 (difference 5).
 * - The random texture: ao_ue4_random_texture()'s bytes / 255 (the UNORM8 decode), RG32F. */
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
/* Common to every pass */
#define UE4_COMMON                                                                                          \
    "const float INF = 1.0 / 0.0;\n"                                                                        \
    "float saturate(float v) { return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0; }\n"                          \
    "float lerp(float a, float b, float t) { return a + t * (b - a); }\n"                                  \
    "uniform float U; uniform float zmax;\n"                                                                \
    "bool depthIsBg(float d) { return !(d > 0.0 && d < INF); }\n"                                          \
    "float depthUU(float d) { float v = depthIsBg(d) ? zmax : d * U; return v < zmax ? v : zmax; }\n"      \
    "vec3 normalFrom(vec3 s) { vec3 v = vec3(s.x, s.y, -s.z); float dd = v.x * v.x + v.y * v.y + v.z * v.z;\n" \
    "  if (!(dd > 0.0) || !(dd < INF)) return vec3(0.0); float rs = 1.0 / sqrt(dd); return v * rs; }\n"

/* MainSetupPS (level 1 from level 0): (MaxZ, decoded normal) */
static const char *const fs_setup =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D SceneDepthTexture;\n"
    "layout(binding=1) uniform sampler2D GBufferNormal;\n"
    "layout(location=0) out vec4 o;\n"
    UE4_COMMON
    "uniform float InvThreshold;\n"
    "void main() {\n"
    "  ivec2 p = ivec2(gl_FragCoord.xy); ivec2 sz = textureSize(SceneDepthTexture, 0);\n"
    "  float z[4]; vec3 e[4];\n"
    "  for (int i = 0; i < 4; i++) {\n"
    "    ivec2 s = clamp(ivec2(2 * p.x + (i & 1), 2 * p.y + (i >> 1)), ivec2(0), sz - 1);\n"
    "    z[i] = depthUU(texelFetch(SceneDepthTexture, s, 0).r);\n"
    "#if USE_N\n"
    "    vec3 n0 = normalFrom(texelFetch(GBufferNormal, s, 0).rgb);\n"
    "    e[i] = vec3(n0.x * 0.5 + 0.5, n0.y * 0.5 + 0.5, n0.z * 0.5 + 0.5);\n"
    "#endif\n"
    "  }\n"
    "  float m01 = z[0] > z[1] ? z[0] : z[1], m23 = z[2] > z[3] ? z[2] : z[3];\n"
    "  float MaxZ = m01 > m23 ? m01 : m23;\n"
    "  vec4 acc = vec4(0.0001);\n"
    "#if USE_N\n"
    "  for (int i = 0; i < 4; i++) {\n"
    "    float w = saturate(1.0 - abs(z[i] - MaxZ) * InvThreshold);\n"
    "    acc.x += e[i].x * w; acc.y += e[i].y * w; acc.z += e[i].z * w; acc.w += w;\n"
    "  }\n"
    "#endif\n"
    "  o = vec4(MaxZ, acc.x / acc.w * 2.0 - 1.0, acc.y / acc.w * 2.0 - 1.0, acc.z / acc.w * 2.0 - 1.0);\n"
    "}\n";

/* MainPSandCS at one level, before the quad blur: (OutColor.r, SceneDepth, n.xy) */
static const char *const fs_ao =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D SceneDepthTexture;\n" /* level 0: our depth (m); else the setup */
    "layout(binding=1) uniform sampler2D GBufferNormal;\n"
    "layout(binding=2) uniform sampler2D RandomNormalTexture;\n"
    "layout(binding=3) uniform sampler2D CoarseAO;\n"          /* the coarser level's AO (after its quad blur) */
    "layout(binding=4) uniform sampler2D CoarseSetup;\n"       /* the coarser level's setup (z, decoded normal) */
    "layout(location=0) out vec4 o;\n"
    UE4_COMMON
    "uniform vec2 FovFix; uniform vec3 InvFovFix; uniform float halfW; uniform float halfH; uniform float cx;\n"
    "uniform float cy; uniform float s; uniform float invS; uniform float AORadiusInShader; uniform float BiasOver1000;\n"
    "uniform float ScaleRadiusInWorldSpace; uniform float InvDistance; uniform vec2 OcclusionSamplesOffsets[6];\n"
    "uniform float MipBlend; uniform float FadeMul; uniform float FadeAdd; uniform float Power; uniform float Intensity;\n"
    "ivec2 levelSize() { return textureSize(SceneDepthTexture, 0); }\n"
    "float levelDepth(ivec2 t) {\n"
    "#if LEVEL0\n"
    "  return depthUU(texelFetch(SceneDepthTexture, t, 0).r);\n"
    "#else\n"
    "  return texelFetch(SceneDepthTexture, t, 0).r;\n"
    "#endif\n"
    "}\n"
    "int texelClampFloor(float u, int n) { if (!(u > -1e9)) u = -1e9; if (u > 1e9) u = 1e9;\n"
    "  return clamp(int(floor(u)), 0, n - 1); }\n"
    "float depthAt(vec2 sp) { ivec2 n = levelSize();\n"
    "  return levelDepth(ivec2(texelClampFloor((sp.x * halfW + cx) * invS, n.x), texelClampFloor((cy - sp.y * halfH) * invS, n.y))); }\n"
    "#if UPSAMPLE\n"
    "float upsample(ivec2 p, float SceneDepth, vec3 cn) {\n"
    "  ivec2 F = levelSize(), C = textureSize(CoarseAO, 0);\n"
    "  float cu = (float(p.x) + 0.5) / float(F.x) * float(C.x), cv = (float(p.y) + 0.5) / float(F.y) * float(C.y);\n"
    "  const vec2 offs[4] = vec2[4](vec2(-0.5, 0.5), vec2(0.5, 0.5), vec2(-0.5, -0.5), vec2(0.5, -0.5));\n"
    "  float WeightSum = 0.0001, Ret = 0.0001;\n"
    "  for (int i = 0; i < 4; i++) {\n"
    "    ivec2 t = ivec2(clamp(int(floor(cu + offs[i].x)), 0, C.x - 1), clamp(int(floor(cv + offs[i].y)), 0, C.y - 1));\n"
    "    float SampleValue = texelFetch(CoarseAO, t, 0).r; vec4 su = texelFetch(CoarseSetup, t, 0);\n"
    "    float Weight = saturate(1.0 - abs(su.x - SceneDepth) * 0.003);\n"
    "#if USE_N\n"
    "    Weight *= saturate(su.y * cn.x + su.z * cn.y + su.w * cn.z);\n"
    "#endif\n"
    "    Ret += SampleValue * Weight; WeightSum += Weight;\n"
    "  }\n"
    "  return Ret / WeightSum;\n"
    "}\n"
    "#endif\n"
    "void main() {\n"
    "  ivec2 p = ivec2(gl_FragCoord.xy);\n" /* may be one past the level: a quad's helper lane */
    "  ivec2 t = clamp(p, ivec2(0), levelSize() - 1);\n"
    "  float SceneDepth = levelDepth(t);\n"
    "#if LEVEL0\n"
    "  bool bg = depthIsBg(texelFetch(SceneDepthTexture, t, 0).r);\n"
    "#else\n"
    "  bool bg = SceneDepth >= zmax;\n"
    "#endif\n"
    "  if (bg) { o = vec4(1.0, SceneDepth, 0.0, 0.0); return; }\n"
    "  vec2 ScreenPos = vec2(float(((double(p.x) + 0.5lf) * double(s) - CXD) * 2.0lf / WD),\n"
    "                        float(-((double(p.y) + 0.5lf) * double(s) - CYD) * 2.0lf / HD));\n"
    "  vec3 n = vec3(0.0);\n"
    "#if USE_N\n"
    "#if LEVEL0\n"
    "  n = normalFrom(texelFetch(GBufferNormal, t, 0).rgb);\n"
    "#else\n"
    "  vec3 nv = texelFetch(SceneDepthTexture, t, 0).yzw; float dd = nv.x * nv.x + nv.y * nv.y + nv.z * nv.z;\n"
    "  float rs = dd > 0.0 ? 1.0 / sqrt(dd) : 0.0; n = nv * rs;\n"
    "#endif\n"
    "  if (n.x == 0.0 && n.y == 0.0 && n.z == 0.0) { o = vec4(1.0, SceneDepth, 0.0, 0.0); return; }\n"
    "#endif\n"
    "  vec3 V = vec3(ScreenPos.x * SceneDepth, ScreenPos.y * SceneDepth, SceneDepth);\n"
    "  float ActualAORadius = AORadiusInShader * lerp(SceneDepth, 1.0, ScaleRadiusInWorldSpace);\n"
    "#if USE_N\n"
    "  { float b = BiasOver1000 * SceneDepth * s;\n"
    "    V.x += b * (n.x * FovFix.x); V.y += b * (n.y * FovFix.y); V.z += b * (n.z * 1.0); }\n"
    "#endif\n"
    "  vec2 WeightAccumulator = vec2(0.0001, 0.0001);\n"
    "  vec2 rt = texelFetch(RandomNormalTexture, ivec2(p.x & 3, p.y & 3), 0).rg;\n"
    "  vec2 RandomVec = vec2((rt.x * 2.0 - 1.0) * ActualAORadius, (rt.y * 2.0 - 1.0) * ActualAORadius);\n"
    "  float invz = 1.0 / V.z;\n"
    "  vec2 FovFixXY = vec2(FovFix.x * invz, FovFix.y * invz);\n"
    "  vec4 RandomBase = vec4(RandomVec.x * FovFixXY.x, RandomVec.y * FovFixXY.y, -RandomVec.y * FovFixXY.x, RandomVec.x * FovFixXY.y);\n"
    "  vec2 ScreenSpacePos = vec2(V.x / V.z, V.y / V.z);\n"
    "  float InvHaloSize = 1.0 / (ActualAORadius * 2.0);\n"
    "  vec3 Ns = n;\n"
    "#if O1\n"
    "  { float sc = 0.08 * lerp(SceneDepth, 1000.0, ScaleRadiusInWorldSpace); Ns = vec3(Ns.x * sc, Ns.y * sc, Ns.z * sc); }\n"
    "#endif\n"
    "  float ViewDepthAdd = 1.0 - V.z * InvDistance;\n"
    "  for (int i = 0; i < SAMPLESET_ARRAY_SIZE; i++) {\n"
    "    vec2 u = OcclusionSamplesOffsets[i];\n"
    "    vec2 LocalRandom = vec2(u.x * RandomBase.x + u.y * RandomBase.z, u.x * RandomBase.y + u.y * RandomBase.w);\n"
    "    vec3 acc = vec3(0.0);\n"
    "    for (int step = 0; step < SAMPLE_STEPS; step++) {\n"
    "      float Scale = float(step + 1) / float(SAMPLE_STEPS);\n"
    "      vec2 lr = vec2(Scale * LocalRandom.x, Scale * LocalRandom.y);\n"
    "      vec2 SL = vec2(ScreenSpacePos.x + lr.x, ScreenSpacePos.y + lr.y), SR = vec2(ScreenSpacePos.x - lr.x, ScreenSpacePos.y - lr.y);\n"
    "      float AbsL = depthAt(SL), AbsR = depthAt(SR);\n"
    "      vec3 PL = vec3(SL.x * AbsL, SL.y * AbsL, AbsL), PR = vec3(SR.x * AbsR, SR.y * AbsR, AbsR);\n"
    "      vec3 DL = vec3((PL.x - V.x) * InvFovFix.x, (PL.y - V.y) * InvFovFix.y, (PL.z - V.z) * InvFovFix.z);\n"
    "      vec3 DR = vec3((PR.x - V.x) * InvFovFix.x, (PR.y - V.y) * InvFovFix.y, (PR.z - V.z) * InvFovFix.z);\n"
    "      float LL = DL.x * DL.x + DL.y * DL.y + DL.z * DL.z, RR = DR.x * DR.x + DR.y * DR.y + DR.z * DR.z;\n"
    "#if USE_N\n"
    "      float dl = DL.x * Ns.x + DL.y * Ns.y + DL.z * Ns.z, dr = DR.x * Ns.x + DR.y * Ns.y + DR.z * Ns.z;\n"
    "#if O1\n"
    "      float sL = saturate(dl / LL), sR = saturate(dr / RR), w = 1.0;\n"
    "#else\n"
    "      float sL = saturate(dl * (1.0 / sqrt(LL))), sR = saturate(dr * (1.0 / sqrt(RR)));\n"
    "      float w = saturate(1.0 - sqrt(LL) * InvHaloSize) * saturate(1.0 - sqrt(RR) * InvHaloSize);\n"
    "#endif\n"
    "      acc.x = lerp(acc.x, max(acc.x, sL), w); acc.y = lerp(acc.y, max(acc.y, sR), w); acc.z = lerp(acc.z, 1.0, w);\n"
    "#else\n"
    "      float cosLR = (DL.x * DR.x + DL.y * DR.y + DL.z * DR.z) / sqrt(LL * RR);\n"
    "      float NormAngle = saturate((1.0 - cosLR) * 0.5 * 0.9);\n"
    "      if ((V.z - AbsL) + (V.z - AbsR) < 5.0) NormAngle = 1.0;\n"
    "      float Weight = 1.0; Weight *= saturate(PL.z * InvDistance + ViewDepthAdd); Weight *= saturate(PR.z * InvDistance + ViewDepthAdd);\n"
    "      float sv = (1.0 - NormAngle) / (Weight + 0.001);\n"
    "      acc.x = lerp(acc.x, max(acc.x, sv), Weight); acc.z = lerp(acc.z, 1.0, Weight);\n"
    "#endif\n"
    "    }\n"
    "#if USE_N\n"
    "    WeightAccumulator.x += (1.0 - acc.x) * (1.0 - acc.x) * acc.z; WeightAccumulator.y += acc.z;\n"
    "    WeightAccumulator.x += (1.0 - acc.y) * (1.0 - acc.y) * acc.z; WeightAccumulator.y += acc.z;\n"
    "#else\n"
    "    WeightAccumulator.x += (1.0 - acc.x) * (1.0 - acc.x) * acc.z; WeightAccumulator.y += acc.z;\n"
    "#endif\n"
    "  }\n"
    "  float r = WeightAccumulator.x / WeightAccumulator.y;\n"
    "#if UPSAMPLE\n"
    "  r = lerp(r, upsample(p, SceneDepth, n), MipBlend);\n"
    "#endif\n"
    "#if LEVEL0\n"
    "  r = lerp(r, 1.0, saturate(SceneDepth * FadeMul + FadeAdd));\n"
    "  r = 1.0 - (1.0 - pow(abs(r), Power)) * Intensity;\n"
    "#endif\n"
    "  o = vec4(r, SceneDepth, n.x, n.y);\n"
    "}\n";

/* QUAD_MESSAGE_PASSING_BLUR over the AO pass's padded target */
static const char *const fs_quad =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D AOPass;\n"          /* (ao, SceneDepth, n.xy), padded to quads */
    "layout(binding=1) uniform sampler2D Background;\n"      /* level 0: depth (m); else the setup (z uu) */
    "layout(location=0) out vec4 o;\n"
    UE4_COMMON
    "float reconNz(vec2 v) { return sqrt(1.0 - (v.x * v.x + v.y * v.y)); }\n"
    "void main() {\n"
    "  ivec2 p = ivec2(gl_FragCoord.xy);\n"
    "  float bd = texelFetch(Background, p, 0).r;\n"
    "#if LEVEL0\n"
    "  if (depthIsBg(bd)) { o = vec4(1.0); return; }\n"
    "#else\n"
    "  if (bd >= zmax) { o = vec4(1.0); return; }\n"
    "#endif\n"
    "  vec4 CenterPixel = texelFetch(AOPass, p, 0);\n"
    "#if QUAD_MESSAGE_PASSING_BLUR == 0\n"
    "  float v = CenterPixel.x;\n"
    "#else\n"
    "  ivec2 Mod = p & 1;\n"
    "  vec4 H = texelFetch(AOPass, ivec2(p.x ^ 1, p.y), 0), Vv = texelFetch(AOPass, ivec2(p.x, p.y ^ 1), 0);\n"
    "  vec4 dX = Mod.x != 0 ? CenterPixel - H : H - CenterPixel;\n"  /* ddx_fine: right - left */
    "  vec4 dY = Mod.y != 0 ? CenterPixel - Vv : Vv - CenterPixel;\n" /* ddy_fine: bottom - top */
    "  vec4 PixA = CenterPixel;\n"
    "  vec4 PixB = CenterPixel - dX * float(Mod.x * 2 - 1);\n"
    "  vec4 PixC = CenterPixel - dY * float(Mod.y * 2 - 1);\n"
    "  float WeightA = 1.0, WeightB = 1.0, WeightC = 1.0;\n"
    "#if QUAD_MESSAGE_PASSING_BLUR >= 2\n"
    "  vec3 NormalA = vec3(PixA.zw, reconNz(PixA.zw)), NormalB = vec3(PixB.zw, reconNz(PixB.zw)), NormalC = vec3(PixC.zw, reconNz(PixC.zw));\n"
    "  WeightB *= saturate(pow(saturate(NormalA.x * NormalB.x + NormalA.y * NormalB.y + NormalA.z * NormalB.z), 4.0));\n"
    "  WeightC *= saturate(pow(saturate(NormalA.x * NormalC.x + NormalA.y * NormalC.y + NormalA.z * NormalC.z), 4.0));\n"
    "#endif\n"
    "#if QUAD_MESSAGE_PASSING_BLUR >= 3\n"
    "  float InvDepth = 1.0 / PixA.y;\n"
    "  WeightB *= 1.0 - saturate(abs(1.0 - PixB.y * InvDepth) * 1.0);\n"
    "  WeightC *= 1.0 - saturate(abs(1.0 - PixC.y * InvDepth) * 1.0);\n"
    "#endif\n"
    "  float InvWeightSum = 1.0 / (WeightA + WeightB + WeightC);\n"
    "  WeightA *= InvWeightSum; WeightB *= InvWeightSum; WeightC *= InvWeightSum;\n"
    "  float v = WeightA * PixA.x + WeightB * PixB.x + WeightC * PixC.x;\n"
    "#endif\n"
    "#if SATURATE_OUT\n"
    "  v = saturate(v);\n"
    "#endif\n"
    "  o = vec4(v);\n"
    "}\n";
#endif

#if GLH_AVAILABLE
/* prelude of every pass */
static void prelude(char *buf, size_t n, const ao_ue4_constants *k, const ao_input *in, int level, int levels,
                    int sample_count, int saturate_out)
{
    snprintf(buf, n,
             "#define USE_N %d\n#define O1 %d\n#define LEVEL0 %d\n#define UPSAMPLE %d\n#define SAMPLESET_ARRAY_SIZE %d\n"
             "#define SAMPLE_STEPS %d\n#define QUAD_MESSAGE_PASSING_BLUR %d\n#define SATURATE_OUT %d\n"
             "const double CXD = %.17elf; const double CYD = %.17elf; const double WD = %d.0lf; const double HD = %d.0lf;\n",
             k->normal_mode != AO_UE4_NORMALS_NONE, k->variant == AO_UE4_VARIANT_O1, level == 0, level + 1 < levels,
             sample_count, k->steps, k->quad_blur, saturate_out, in->cx, in->cy, in->width, in->height);
}

static void set_common(glh *g, GLuint p, const ao_ue4_constants *k)
{
    glh_set1f(g, p, "U", k->units_per_metre);
    glh_set1f(g, p, "zmax", k->max_depth);
}
#endif

int glsl_ue4_build(glh *g, obs_context *ctx, const ao_input *in, const ao_ue4_params *p, glh_run *r)
{
    (void)ctx;
#if GLH_AVAILABLE
    memset(r, 0, sizeof *r);
    const ao_ue4_constants k = ao_ue4_constants_from_params(p, in);
    if (k.normal_mode == AO_UE4_NORMALS_DEPTH || k.orthographic || k.levels > 2) {
        printf("  ue4: the GLSL port has G-buffer or no normals, perspective, 1 or 2 levels\n");
        return 0;
    }
    const int W = in->width, H = in->height, use_n = k.normal_mode != AO_UE4_NORMALS_NONE;
    int ok = 1;
    /* ---- inputs: depth (m, +inf as is) and G-buffer normals, D3D rows; the random texture ---- */
    GLuint depth = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_AS_IS, INFINITY, GL_NEAREST,
                                                                 GL_CLAMP_TO_EDGE));
    GLuint nt = 0;
    if (use_n) {
        float *nb = (float *)malloc(sizeof(float) * 3 * (size_t)W * (size_t)H);
        if (!nb)
            return 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++)
                for (int c = 0; c < 3; c++)
                    nb[((size_t)y * W + x) * 3 + c] = obs_image_f32_row(in->normal[c], y)[x];
        nt = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGB32F, 3, nb, GLH_ROWS_AS_IS, GL_NEAREST,
                                                GL_CLAMP_TO_EDGE));
        free(nb);
    } else {
        nt = depth; /* unused */
    }
    unsigned char tex[16][4];
    ao_ue4_random_texture(tex);
    float rg[16][2];
    for (int i = 0; i < 16; i++)
        for (int c = 0; c < 2; c++)
            rg[i][c] = (float)tex[i][c] / 255.0f; /* the UNORM8 decode */
    GLuint rnd = glh_run_own_texture(r, glh_texture(g, 4, 4, 1, GL_RG32F, 2, &rg[0][0], GLH_ROWS_AS_IS, GL_NEAREST,
                                                    GL_REPEAT));
    ok = depth && nt && rnd;
    /* ---- level 1: setup, AO, quad blur ---- */
    const int w1 = (W + 1) / 2, h1 = (H + 1) / 2;
    GLuint setup = 0, ao1 = 0, last = 0;
    char pre[768];
    const float fov2[2] = {k.fov_fix[0], k.fov_fix[1]};
    const float inv_fov[3] = {1.0f / k.fov_fix[0], 1.0f / k.fov_fix[1], 1.0f / 1.0f};
    for (int l = k.levels - 1; l >= 0 && ok; l--) {
        const int lw = l ? w1 : W, lh = l ? h1 : H;
        const int pw = k.quad_blur ? lw + (lw & 1) : lw, ph = k.quad_blur ? lh + (lh & 1) : lh;
        float samples[12];
        const int count = l ? ao_ue4_sample_set(3, samples) : k.sample_count;
        if (!l)
            memcpy(samples, k.samples, sizeof samples);
        if (l) {
            prelude(pre, sizeof pre, &k, in, l, k.levels, count, 0);
            setup = glh_run_own_texture(r, glh_texture(g, w1, h1, 1, GL_RGBA32F, 4, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
            GLuint fs = glh_run_own_fbo(r, glh_framebuffer(g, setup, 0));
            GLuint ps = glh_run_own_program(r, glh_program(g, fs_setup, pre));
            ok = setup && fs && ps;
            if (!ok)
                break;
            set_common(g, ps, &k);
            glh_set1f(g, ps, "InvThreshold", 0.01f / 1.0f); /* AmbientOcclusionMipThreshold / ScaleToFullRes of level 0 */
            const GLuint t[2] = {depth, nt};
            ok = glh_run_add(r, "ue4 setup level 1", ps, fs, w1, h1, 2, t) >= 0;
        }
        /* the AO pass over the level padded to whole quads */
        prelude(pre, sizeof pre, &k, in, l, k.levels, count, 0);
        GLuint at = glh_run_own_texture(r, glh_texture(g, pw, ph, 1, GL_RGBA32F, 4, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
        GLuint fa = glh_run_own_fbo(r, glh_framebuffer(g, at, 0));
        GLuint pa = glh_run_own_program(r, glh_program(g, fs_ao, pre));
        ok = ok && at && fa && pa;
        if (!ok)
            break;
        set_common(g, pa, &k);
        const float s = (float)(1 << l);
        glh_set2f(g, pa, "FovFix", fov2[0], fov2[1]);
        glh_set3f(g, pa, "InvFovFix", inv_fov[0], inv_fov[1], inv_fov[2]);
        glh_set1f(g, pa, "halfW", (float)(0.5 * W));
        glh_set1f(g, pa, "halfH", (float)(0.5 * H));
        glh_set1f(g, pa, "cx", (float)in->cx);
        glh_set1f(g, pa, "cy", (float)in->cy);
        glh_set1f(g, pa, "s", s);
        glh_set1f(g, pa, "invS", 1.0f / s);
        glh_set1f(g, pa, "AORadiusInShader", k.ao_radius_in_shader * powf(k.mip_scale, (float)l));
        glh_set1f(g, pa, "BiasOver1000", k.bias_over_1000);
        glh_set1f(g, pa, "ScaleRadiusInWorldSpace", k.scale_radius_in_ws);
        glh_set1f(g, pa, "InvDistance", k.inv_distance);
        glh_setfv(g, pa, "OcclusionSamplesOffsets", 2, count, samples);
        glh_set1f(g, pa, "MipBlend", k.mip_blend);
        glh_set1f(g, pa, "FadeMul", k.fade_mul);
        glh_set1f(g, pa, "FadeAdd", k.fade_add);
        glh_set1f(g, pa, "Power", k.power);
        glh_set1f(g, pa, "Intensity", k.intensity);
        const GLuint ta[5] = {l ? setup : depth, nt, rnd, ao1 ? ao1 : rnd, setup ? setup : rnd};
        ok = glh_run_add(r, l ? "ue4 AO level 1" : "ue4 AO level 0", pa, fa, pw, ph, 5, ta) >= 0;
        /* its quad blur (every pixel of the level; saturated at level 0) */
        prelude(pre, sizeof pre, &k, in, l, k.levels, count, l == 0);
        GLuint qt = glh_run_own_texture(r, glh_texture(g, lw, lh, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
        GLuint fq = glh_run_own_fbo(r, glh_framebuffer(g, qt, 0));
        GLuint pq = glh_run_own_program(r, glh_program(g, fs_quad, pre));
        ok = ok && qt && fq && pq;
        if (!ok)
            break;
        set_common(g, pq, &k);
        const GLuint tq[2] = {at, l ? setup : depth};
        ok = glh_run_add(r, l ? "ue4 quad blur level 1" : "ue4 quad blur level 0", pq, fq, lw, lh, 2, tq) >= 0;
        if (l)
            ao1 = qt;
        last = qt;
        r->out_fbo = fq;
    }
    r->nkernel = r->npass;
    r->out_w = W;
    r->out_h = H;
    r->out_rows = GLH_ROWS_AS_IS;
    if (ok && k.blur)
        ok = glsl_gauss21_add(g, in, r, last, depth, GLH_ROWS_AS_IS);
    if (!ok)
        printf("  ue4: the GLSL port could not be built\n");
    return ok;
#else
    (void)g, (void)in, (void)p, (void)r;
    return 0;
#endif
}

static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_ue4_params p = ao_ue4_params_default();
    return glsl_ue4_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_ue4_params p = ao_ue4_params_default();
    p.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st == OBS_STATUS_OK ? ao_ue4_compute(ctx, pool, in, &p, out, NULL, NULL) : st;
}

/* the default has no Gaussian (--blur off): the quad blur is part of the kernel's passes */
const glsl_port glsl_port_ue4 = {"ue4", "defaults: OPTIMIZATION_O1, 2 levels, G-buffer normals, set 1 x 2 steps, quad blur 2",
                                 port_build, port_kernel, NULL, NULL};
