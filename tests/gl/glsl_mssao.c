/* glsl_mssao.c: MSSAO as Hoang's prototype computes it, re-typed in GLSL 4.50 from his shaders
 * (shaders/downsample.frag, aoFirst.frag, ao.frag, aoLast.frag; GLSL 1.40 with
 * GL_ARB_texture_rectangle, read from public copies of the code, docs/ao/mssao.md) and blur.frag as
 * docs/ao/mssao.md describes it line by line (its text was not among the stored copies). Every pass of
 * the pyramid is a fragment pass: the level-0 G-buffer, the downsampling of each level, the AO of
 * each level coarse to fine (aoFirst, ao, aoLast), and the blur of each coarse level.
 *
 * Translated: sampler2DRect + texture2DRect(t, xy) with NEAREST and CLAMP_TO_EDGE -> sampler2D +
 * texelFetch(t, clamp(ivec2(floor(xy)), 0, size - 1)); `out vec4 AO` and the two outputs of
 * downsample.frag (Pos, Norm) -> one pass per output (the harness draws into one attachment); the
 * uniforms r (per level), dMax, rMax and the Poisson disk come from ao_mssao_constants_from_params.
 * All planes are in GL rows (row 0 = bottom), as Hoang's and our kernel's levels.
 *
 * Where our kernel documents a difference (docs/ao/mssao.md, "Differences"), the port follows ours:
 * the level-0 G-buffer pass stands for Hoang's geometry pass (positions from our depth and pixel model
 * exactly as ao_position, normals from the G-buffer, or ao_normals_from_depth when asked, non-finite
 * ones as 0, w = 1; background and positions beyond 1e18 m cleared to 0), a tap on the pixel itself
 * contributes 0 (3: normalize(0) is NaN), all-zero upsampling weights fall back to bilinear (4), one
 * level skips the upsampling (8), background pixels get visibility 1 (2) and the output is clamped to
 * [0, 1] (10). The `sorted` downsampling rule (preset kool) is fabmax/kool's GbufferDownsamplingPass as
 * docs/ao/mssao.md gives it; the final blur (`blur`, preset thesis: the seed's Gaussian, not Hoang's)
 * is glsl_gauss21.h over level 0 of the whole buffer, then the window with background kept at 1. Not
 * ported: the orthographic extension (glsl_mssao_build refuses it). */
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE

#define MS_COMMON                                                                                        \
    "#version 450\n"                                                                                     \
    "vec4 T(sampler2D t, vec2 xy) { ivec2 s = textureSize(t, 0);\n"                                      \
    "  return texelFetch(t, clamp(ivec2(floor(xy)), ivec2(0), s - 1), 0); } /* texture2DRect, NEAREST, CLAMP */\n"

/* ---- Level 0's G-buffer (Hoang's geometry pass): OUT_NORM 0 writes posTex, 1 normTex ----
 * depth: our depth in GL rows, non-finite as 0; ax, ay: ao_position's (x + 0.5 - cx)/fx and
 * -(y + 0.5 - cy)/fy per column and per GL row, in float as ao_position rounds them. */
static const char *const fs_g0 =
    MS_COMMON
    "layout(binding=0) uniform sampler2D depthTex; layout(binding=1) uniform sampler2D srcNormTex;\n"
    "layout(binding=2) uniform sampler2D axTex; layout(binding=3) uniform sampler2D ayTex;\n"
    "layout(location=0) out vec4 o;\n"
    "void main() {\n"
    "  ivec2 c = ivec2(gl_FragCoord.xy); float d = texelFetch(depthTex, c, 0).x;\n"
    "  vec3 p = d * vec3(texelFetch(axTex, ivec2(c.x, 0), 0).x, texelFetch(ayTex, ivec2(c.y, 0), 0).x, -1.0);\n"
    "  if (!(d > 0.0) || !(abs(p.x) <= 1e18 && abs(p.y) <= 1e18 && abs(p.z) <= 1e18)) { o = vec4(0.0); return; }\n"
    "#if OUT_NORM\n"
    "  vec3 n = texelFetch(srcNormTex, c, 0).xyz;\n"
    "  if (isnan(n.x) || isnan(n.y) || isnan(n.z) || isinf(n.x) || isinf(n.y) || isinf(n.z)) n = vec3(0.0);\n"
    "  o = vec4(n, 1.0); /* normTex.w = 1 where the geometry pass draws */\n"
    "#else\n"
    "  o = vec4(p, 1.0);\n"
    "#endif\n"
    "}\n";

/* ---- downsample.frag (the Hoang rule); OUT_NORM 0 writes Pos, 1 Norm ---- */
static const char *const fs_down =
    MS_COMMON
    "layout(binding=0) uniform sampler2D hiResPosTex; layout(binding=1) uniform sampler2D hiResNormTex;\n"
    "uniform float dThreshold;\n"
    "layout(location=0) out vec4 outv;\n"
    "void main() {\n"
    "  vec2 xy2 = gl_FragCoord.xy * 2.0;\n"
    "  vec4 pos[4]; vec4 norm[4];\n"
    "  pos[0] = T(hiResPosTex, xy2 + vec2(-0.5, 0.5));\n"
    "  pos[1] = T(hiResPosTex, xy2 + vec2(0.5, 0.5));\n"
    "  pos[2] = T(hiResPosTex, xy2 + vec2(0.5, -0.5));\n"
    "  pos[3] = T(hiResPosTex, xy2 + vec2(-0.5, -0.5));\n"
    "  norm[0] = T(hiResNormTex, xy2 + vec2(-0.5, 0.5));\n"
    "  norm[1] = T(hiResNormTex, xy2 + vec2(0.5, 0.5));\n"
    "  norm[2] = T(hiResNormTex, xy2 + vec2(0.5, -0.5));\n"
    "  norm[3] = T(hiResNormTex, xy2 + vec2(-0.5, -0.5));\n"
    "  vec4 Pos, Norm;\n"
    "#if SORTED\n"
    "  /* fabmax/kool GbufferDownsamplingPass (the slides' rule): bubble-sort by linear depth -z,\n"
    "     z4 - z1 < threshold: the average of the 2nd and 3rd, else the 2nd (docs/ao/mssao.md) */\n"
    "  int ord[4] = int[4](0, 1, 2, 3);\n"
    "  for (int i = 0; i < 3; i++) for (int j = i + 1; j < 4; j++)\n"
    "    if (-pos[ord[j]].z < -pos[ord[i]].z) { int t = ord[i]; ord[i] = ord[j]; ord[j] = t; }\n"
    "  float dRange = (-pos[ord[3]].z) - (-pos[ord[0]].z);\n"
    "  if (dRange < dThreshold) { Pos = (pos[ord[1]] + pos[ord[2]]) / 2.0; Norm = (norm[ord[1]] + norm[ord[2]]) / 2.0; }\n"
    "  else { Pos = pos[ord[1]]; Norm = norm[ord[1]]; }\n"
    "#else\n"
    "  float maxZ = max(max(pos[0].z, pos[1].z), max(pos[2].z, pos[3].z));\n"
    "  float minZ = min(min(pos[0].z, pos[1].z), min(pos[2].z, pos[3].z));\n"
    "  int minPos = 0, maxPos = 0;\n"
    "  for (int i = 0; i < 4; ++i) { if (pos[i].z == minZ) minPos = i; if (pos[i].z == maxZ) maxPos = i; }\n"
    "  float d = distance(pos[minPos].xyz, pos[maxPos].xyz);\n"
    "  ivec2 median = ivec2(0, 0); int index = 0;\n"
    "  for (int i = 0; i < 4 && index < 2; ++i) if (i != minPos && i != maxPos) median[index++] = i;\n"
    "  if (d < dThreshold) { Pos = (pos[median.x] + pos[median.y]) / 2.0; Norm = (norm[median.x] + norm[median.y]) / 2.0; }\n"
    "  else { Pos = pos[median.x]; Norm = norm[median.x]; }\n"
    "#endif\n"
    "#if OUT_NORM\n"
    "  outv = Norm;\n"
    "#else\n"
    "  outv = Pos;\n"
    "#endif\n"
    "}\n";

/* ---- aoFirst.frag (STAGE 0), ao.frag (STAGE 1), aoLast.frag (STAGE 2) ---- */
static const char *const fs_ao =
    MS_COMMON
    "layout(binding=0) uniform sampler2D posTex; layout(binding=1) uniform sampler2D normTex;\n"
    "layout(binding=2) uniform sampler2D loResAOTex; layout(binding=3) uniform sampler2D loResPosTex;\n"
    "layout(binding=4) uniform sampler2D loResNormTex; layout(binding=5) uniform sampler2D srcDepth;\n"
    "uniform float dMax; uniform float rMax; uniform float r; uniform float poissonDisk[2 * SAMPLES];\n"
    "uniform ivec2 Origin; /* STAGE 2: the window's corner in level 0 (GL rows) */\n"
    "layout(location=0) out vec4 AO;\n"
    "vec3 n; vec4 p; vec2 fragCoord;\n"
    "float occlusion = 0.0;\n"
    "#if STAGE == 2\n"
    "float sampleCount = 0.0;\n"
    "#else\n"
    "float sampleCount = 0.0001;\n"
    "#endif\n"
    "void ComputeOcclusion(vec2 xy) {\n"
    "  vec4 samplePos = T(posTex, xy);\n"
    "  vec4 sampleNorm = T(normTex, xy);\n"
    "  float d = distance(p.xyz, samplePos.xyz);\n"
    "  float t = min(1.0, (d * d) / (dMax * dMax));\n"
    "  t = 1.0 - t;\n"
    "  vec3 v = samplePos.xyz - p.xyz;\n"
    "  /* a tap on the pixel itself: normalize(0) is NaN, max(NaN, 0) = 0 under maxNum (docs, difference 3) */\n"
    "  float cosTheta = 0.0;\n"
    "  if (dot(v, v) > 0.0) { vec3 diff = normalize(v); cosTheta = max(dot(n, diff), 0.0); }\n"
    "  occlusion += t * cosTheta * sampleNorm.w;\n"
    "  sampleCount += 1.0;\n"
    "}\n"
    "vec3 Upsample() {\n"
    "  vec2 loResCoord[4];\n"
    "  loResCoord[0] = floor((fragCoord + vec2(-1.0, 1.0)) / 2.0) + vec2(0.5, 0.5);\n"
    "  loResCoord[1] = floor((fragCoord + vec2(1.0, 1.0)) / 2.0) + vec2(0.5, 0.5);\n"
    "  loResCoord[2] = floor((fragCoord + vec2(-1.0, -1.0)) / 2.0) + vec2(0.5, 0.5);\n"
    "  loResCoord[3] = floor((fragCoord + vec2(1.0, -1.0)) / 2.0) + vec2(0.5, 0.5);\n"
    "  vec3 loResAO[4]; vec3 loResNorm[4]; float loResDepth[4];\n"
    "  for (int i = 0; i < 4; ++i) {\n"
    "    loResNorm[i] = T(loResNormTex, loResCoord[i]).xyz;\n"
    "    loResDepth[i] = T(loResPosTex, loResCoord[i]).z;\n"
    "    loResAO[i] = T(loResAOTex, loResCoord[i]).xyz; }\n"
    "  float normWeight[4];\n"
    "  for (int i = 0; i < 4; ++i) { normWeight[i] = (dot(loResNorm[i], n) + 1.1) / 2.1; normWeight[i] = pow(normWeight[i], 8.0); }\n"
    "  float depthWeight[4];\n"
    "  for (int i = 0; i < 4; ++i) { depthWeight[i] = 1.0 / (1.0 + abs(p.z - loResDepth[i]) * 0.2); depthWeight[i] = pow(depthWeight[i], 16.0); }\n"
    "  float totalWeight = 0.0; vec3 combinedAO = vec3(0.0);\n"
    "  for (int i = 0; i < 4; ++i) {\n"
    "    float weight = normWeight[i] * depthWeight[i] * (9.0 / 16.0) /\n"
    "      (abs((fragCoord.x - loResCoord[i].x * 2.0) * (fragCoord.y - loResCoord[i].y * 2.0)) * 4.0);\n"
    "    totalWeight += weight; combinedAO += loResAO[i] * weight; }\n"
    "  if (!(totalWeight > 0.0)) { /* all weights underflowed: bilinear (docs, difference 4) */\n"
    "    totalWeight = 0.0; combinedAO = vec3(0.0);\n"
    "    for (int i = 0; i < 4; ++i) { float weight = (9.0 / 16.0) /\n"
    "      (abs((fragCoord.x - loResCoord[i].x * 2.0) * (fragCoord.y - loResCoord[i].y * 2.0)) * 4.0);\n"
    "      totalWeight += weight; combinedAO += loResAO[i] * weight; } }\n"
    "  combinedAO /= totalWeight;\n"
    "  return combinedAO;\n"
    "}\n"
    "void main() {\n"
    "#if STAGE == 2\n"
    "  fragCoord = gl_FragCoord.xy + vec2(Origin);\n"
    "#else\n"
    "  fragCoord = gl_FragCoord.xy;\n"
    "#endif\n"
    "  n = T(normTex, fragCoord).xyz;\n"
    "  p = T(posTex, fragCoord);\n"
    "  float rangeMax = min(r / abs(p.z), rMax);\n"
    "#if STAGE == 2\n"
    "  if (!(T(normTex, fragCoord).w > 0.0)) { AO = vec4(1.0); return; } /* background: 1 (difference 2) */\n"
    "  for (int i = 0; i < 2 * SAMPLES; i += 2)\n"
    "    ComputeOcclusion(fragCoord + vec2(poissonDisk[i], poissonDisk[i + 1]) * rangeMax);\n"
    "#if LEVELS > 1\n"
    "  vec3 upsample = Upsample();\n"
    "  float aoMax = max(upsample.x, occlusion / sampleCount);\n"
    "  float aoAverage = (upsample.y + occlusion) / (upsample.z + sampleCount);\n"
    "#else\n"
    "  float aoMax = occlusion / sampleCount, aoAverage = occlusion / sampleCount; /* one level (difference 8) */\n"
    "#endif\n"
    "  float currentFrameAO = (1.0 - aoMax) * (1.0 - aoAverage);\n"
    "  AO = vec4(clamp(currentFrameAO, 0.0, 1.0)); /* first frame: no history (difference 1); clamp (10) */\n"
    "#else\n"
    "  for (float x = 1.0; x <= rangeMax; x += 2.0)\n"
    "    for (float y = 1.0; y <= rangeMax; y += 2.0) {\n"
    "      ComputeOcclusion(fragCoord + vec2(x, y));\n"
    "      ComputeOcclusion(fragCoord + vec2(-x, y));\n"
    "      ComputeOcclusion(fragCoord + vec2(-x, -y));\n"
    "      ComputeOcclusion(fragCoord + vec2(x, -y));\n"
    "    }\n"
    "#if STAGE == 0\n"
    "  AO = vec4(occlusion / sampleCount, occlusion, sampleCount, 0.0);\n"
    "#else\n"
    "  vec3 upsample = Upsample();\n"
    "  AO = vec4(max(upsample.x, occlusion / sampleCount), upsample.y + occlusion, upsample.z + sampleCount, 0.0);\n"
    "#endif\n"
    "#endif\n"
    "}\n";

/* ---- blur.frag: 3x3 cross-bilateral of a coarse level's (maxAO, sumAO, count) ---- */
static const char *const fs_blur =
    MS_COMMON
    "layout(binding=0) uniform sampler2D aoTex; layout(binding=1) uniform sampler2D normTex;\n"
    "layout(binding=2) uniform sampler2D posTex;\n"
    "layout(location=0) out vec4 AO;\n"
    "void main() {\n"
    "  vec3 n = T(normTex, gl_FragCoord.xy).xyz; float pz = T(posTex, gl_FragCoord.xy).z;\n"
    "  vec3 ss = vec3(0.0); float weight = 0.0;\n"
    "  for (float i = -1.0; i <= 1.0; i += 1.0)\n"
    "    for (float j = -1.0; j <= 1.0; j += 1.0) {\n"
    "      vec2 xy = gl_FragCoord.xy + vec2(i, j);\n"
    "      float normWeight = pow((dot(T(normTex, xy).xyz, n) + 1.2) / 2.2, 8.0);\n"
    "      float depthWeight = pow(1.0 / (1.0 + abs(pz - T(posTex, xy).z) * 0.2), 16.0);\n"
    "      float gaussWeight = 1.0 / ((abs(i) + 1.0) * (abs(j) + 1.0));\n"
    "      weight += normWeight * depthWeight * gaussWeight;\n"
    "      ss += T(aoTex, xy).xyz * normWeight * depthWeight * gaussWeight;\n"
    "    }\n"
    "  AO = vec4(ss / weight, 0.0);\n"
    "}\n";

/* ---- with the final blur: the window of the blurred plane, background kept at 1 (blur.md) ---- */
static const char *const fs_crop =
    MS_COMMON
    "layout(binding=0) uniform sampler2D blurred; layout(binding=1) uniform sampler2D depthTex;\n"
    "uniform ivec2 Origin;\n"
    "layout(location=0) out vec4 o;\n"
    "void main() { ivec2 p = ivec2(gl_FragCoord.xy) + Origin;\n"
    "  o = texelFetch(depthTex, p, 0).x > 0.0 ? texelFetch(blurred, p, 0) : vec4(1.0); }\n";

typedef struct ms_tex {
    GLuint tex, fbo;
} ms_tex;

static int ms_target(glh *g, glh_run *r, int w, int h, ms_tex *t)
{
    t->tex = glh_run_own_texture(r, glh_texture(g, w, h, 1, GL_RGBA32F, 4, NULL, GLH_ROWS_AS_IS, GL_NEAREST,
                                                GL_CLAMP_TO_EDGE));
    t->fbo = t->tex ? glh_run_own_fbo(r, glh_framebuffer(g, t->tex, 0)) : 0;
    return t->fbo != 0;
}

int glsl_mssao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_params *p, glh_run *r)
{
    memset(r, 0, sizeof *r);
    if (ao_input_validate(ctx, in) != OBS_STATUS_OK || ao_mssao_params_validate(ctx, p) != OBS_STATUS_OK) {
        printf("  mssao port: %s\n", obs_context_last_error(ctx));
        return 0;
    }
    const ao_mssao_constants K = ao_mssao_constants_from_params(p, in);
    if (K.orthographic) {
        printf("  mssao port: the orthographic extension is not ported\n");
        return 0;
    }
    const int W = in->width, H = in->height, NL = K.levels;
    /* ---- the inputs of the geometry stage, in GL rows ---- */
    obs_image_f32 nrm[3];
    memset(nrm, 0, sizeof nrm);
    const obs_image_f32 *src_n = in->normal[0];
    if (!in->normal[0] || p->normals == AO_MSSAO_NORMALS_DEPTH) {
        for (int c = 0; c < 3; c++)
            if (obs_image_f32_alloc(ctx, W, H, &nrm[c]) != OBS_STATUS_OK)
                return 0;
        if (ao_normals_from_depth(ctx, NULL, in, nrm) != OBS_STATUS_OK)
            return 0;
        src_n = &nrm[0];
    }
    float *buf = malloc(sizeof(float) * 4 * (size_t)W * (size_t)H);
    if (!buf)
        return 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 4; c++) {
                const obs_image_f32 *pl = src_n == in->normal[0] ? in->normal[c < 3 ? c : 0] : &nrm[c < 3 ? c : 0];
                buf[4 * ((size_t)y * W + x) + c] = c < 3 ? obs_image_f32_row(pl, y)[x] : 0.0f;
            }
    GLuint tn = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGBA32F, 4, buf, GLH_ROWS_FLIP, GL_NEAREST,
                                                   GL_CLAMP_TO_EDGE));
    for (int c = 0; c < 3; c++)
        obs_image_f32_free(&nrm[c]);
    /* ao_position's per-column and per-row factors, rounded to float as it rounds them */
    for (int x = 0; x < W; x++)
        buf[x] = (float)(((double)x + 0.5 - in->cx) / in->fx);
    GLuint tax = glh_run_own_texture(r, glh_texture(g, W, 1, 1, GL_R32F, 1, buf, GLH_ROWS_AS_IS, GL_NEAREST,
                                                    GL_CLAMP_TO_EDGE));
    for (int j = 0; j < H; j++) /* GL row j is our row H - 1 - j */
        buf[j] = (float)(-((double)(H - 1 - j) + 0.5 - in->cy) / in->fy);
    GLuint tay = glh_run_own_texture(r, glh_texture(g, H, 1, 1, GL_R32F, 1, buf, GLH_ROWS_AS_IS, GL_NEAREST,
                                                    GL_CLAMP_TO_EDGE));
    free(buf);
    GLuint td = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, 0.0f, GL_NEAREST,
                                                               GL_CLAMP_TO_EDGE));
    if (!tn || !tax || !tay || !td)
        return 0;

    /* ---- programs ---- */
    char pre[128];
    GLuint pg_pos = glh_run_own_program(r, glh_program(g, fs_g0, "#define OUT_NORM 0\n"));
    GLuint pg_nrm = glh_run_own_program(r, glh_program(g, fs_g0, "#define OUT_NORM 1\n"));
    const int sorted = K.downsample == AO_MSSAO_DOWNSAMPLE_SORTED;
    GLuint pd_pos = glh_run_own_program(r, glh_program(g, fs_down, sorted ? "#define OUT_NORM 0\n#define SORTED 1\n"
                                                                          : "#define OUT_NORM 0\n#define SORTED 0\n"));
    GLuint pd_nrm = glh_run_own_program(r, glh_program(g, fs_down, sorted ? "#define OUT_NORM 1\n#define SORTED 1\n"
                                                                          : "#define OUT_NORM 1\n#define SORTED 0\n"));
    GLuint pblur = glh_run_own_program(r, glh_program(g, fs_blur, NULL));
    snprintf(pre, sizeof pre, "#define STAGE 2\n#define SAMPLES %d\n#define LEVELS %d\n", K.samples, NL);
    GLuint plast = glh_run_own_program(r, glh_program(g, fs_ao, pre));
    if (!pg_pos || !pg_nrm || !pd_pos || !pd_nrm || !pblur || !plast)
        return 0;
    glh_set1f(g, pd_pos, "dThreshold", K.d_threshold);
    glh_set1f(g, pd_nrm, "dThreshold", K.d_threshold);

    /* ---- the pyramid ---- */
    ms_tex pos[AO_MSSAO_MAX_LEVELS], nm[AO_MSSAO_MAX_LEVELS], ao[AO_MSSAO_MAX_LEVELS], bl[AO_MSSAO_MAX_LEVELS], out;
    for (int l = 0; l < NL; l++) {
        const int w = K.level_width[l], h = K.level_height[l];
        if (!ms_target(g, r, w, h, &pos[l]) || !ms_target(g, r, w, h, &nm[l]) ||
            (l > 0 && (!ms_target(g, r, w, h, &ao[l]) || (K.level_blur && !ms_target(g, r, w, h, &bl[l])))))
            return 0;
    }
    {
        const GLuint t[4] = {td, tn, tax, tay};
        glh_run_add(r, "mssao gbuffer pos", pg_pos, pos[0].fbo, W, H, 4, t);
        glh_run_add(r, "mssao gbuffer norm", pg_nrm, nm[0].fbo, W, H, 4, t);
    }
    for (int l = 1; l < NL; l++) {
        const GLuint t[2] = {pos[l - 1].tex, nm[l - 1].tex};
        glh_run_add(r, "mssao downsample pos", pd_pos, pos[l].fbo, K.level_width[l], K.level_height[l], 2, t);
        glh_run_add(r, "mssao downsample norm", pd_nrm, nm[l].fbo, K.level_width[l], K.level_height[l], 2, t);
    }
    /* per-level programs share a stage; r differs per level, so each level gets its own program */
    for (int l = NL - 1; l >= 1; l--) {
        const int stage = l == NL - 1 ? 0 : 1;
        snprintf(pre, sizeof pre, "#define STAGE %d\n#define SAMPLES %d\n#define LEVELS %d\n", stage, K.samples, NL);
        GLuint pr = glh_run_own_program(r, glh_program(g, fs_ao, pre));
        if (!pr)
            return 0;
        glh_set1f(g, pr, "dMax", K.d_max);
        glh_set1f(g, pr, "rMax", K.r_max);
        glh_set1f(g, pr, "r", K.r[l]);
        const GLuint up = l + 1 < NL ? (K.level_blur ? bl[l + 1].tex : ao[l + 1].tex) : 0;
        const GLuint t[5] = {pos[l].tex, nm[l].tex, up ? up : pos[l].tex, l + 1 < NL ? pos[l + 1].tex : pos[l].tex,
                             l + 1 < NL ? nm[l + 1].tex : nm[l].tex};
        glh_run_add(r, stage ? "mssao ao.frag" : "mssao aoFirst.frag", pr, ao[l].fbo, K.level_width[l],
                    K.level_height[l], 5, t);
        if (K.level_blur) {
            const GLuint tb[3] = {ao[l].tex, nm[l].tex, pos[l].tex};
            glh_run_add(r, "mssao blur.frag", pblur, bl[l].fbo, K.level_width[l], K.level_height[l], 3, tb);
        }
    }
    /* level 0: aoLast.frag over the window */
    {
        GLuint pr = plast;
        glh_set1f(g, pr, "dMax", K.d_max);
        glh_set1f(g, pr, "rMax", K.r_max);
        glh_set1f(g, pr, "r", K.r[0]);
        glh_setfv(g, pr, "poissonDisk", 1, 2 * K.samples, K.taps);
        /* with the final blur, level 0 over the whole buffer (the Gaussian reads 10 px around) */
        const int ow = K.blur ? W : in->w, oh = K.blur ? H : in->h;
        glh_set2i(g, pr, "Origin", K.blur ? 0 : in->x0, K.blur ? 0 : H - in->y0 - in->h);
        out.tex = glh_run_own_texture(r, glh_texture(g, ow, oh, 1, GL_R32F, 1, NULL, GLH_ROWS_AS_IS,
                                                     GL_NEAREST, GL_CLAMP_TO_EDGE));
        out.fbo = out.tex ? glh_run_own_fbo(r, glh_framebuffer(g, out.tex, 0)) : 0;
        if (!out.fbo)
            return 0;
        const GLuint up = NL > 1 ? (K.level_blur ? bl[1].tex : ao[1].tex) : pos[0].tex;
        const GLuint t[6] = {pos[0].tex, nm[0].tex, up, NL > 1 ? pos[1].tex : pos[0].tex,
                             NL > 1 ? nm[1].tex : nm[0].tex, td};
        glh_run_add(r, "mssao aoLast.frag", pr, out.fbo, ow, oh, 6, t);
    }
    r->nkernel = r->npass;
    if (K.blur) {
        /* the seed's Gaussian (ao_blur_gaussian21), then the window with background kept at 1 */
        GLuint pgauss[2];
        ms_tex tmp, blr, win;
        GLuint pcrop = glh_run_own_program(r, glh_program(g, fs_crop, NULL));
        if (!glsl_gauss21_programs(g, r, pgauss) || !pcrop || !ms_target(g, r, W, H, &tmp) ||
            !ms_target(g, r, W, H, &blr) || !ms_target(g, r, in->w, in->h, &win))
            return 0;
        glh_set2i(g, pcrop, "Origin", in->x0, H - in->y0 - in->h);
        glh_run_add(r, "gaussian h", pgauss[0], tmp.fbo, W, H, 1, &out.tex);
        glh_run_add(r, "gaussian v", pgauss[1], blr.fbo, W, H, 1, &tmp.tex);
        const GLuint tc[2] = {blr.tex, td};
        glh_run_add(r, "mssao window", pcrop, win.fbo, in->w, in->h, 2, tc);
        out = win;
    }
    r->out_fbo = out.fbo;
    r->out_w = in->w;
    r->out_h = in->h;
    r->out_rows = GLH_ROWS_FLIP;
    return 1;
}

#else
int glsl_mssao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_params *p, glh_run *r)
{
    (void)g, (void)ctx, (void)in, (void)p, (void)r;
    return 0;
}
#endif

/* ---- the benchmark's view: Hoang's defaults (5 levels, 16 taps, level blur, no final blur) ---- */
static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_mssao_params p = ao_mssao_params_default();
    return glsl_mssao_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_mssao_params p = ao_mssao_params_default();
    p.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st != OBS_STATUS_OK ? st : ao_mssao_compute(ctx, pool, in, &p, out, NULL, NULL);
}

/* ours_blur is NULL: Hoang's MSSAO has no final blur (its per-level blur is part of the kernel) */
const glsl_port glsl_port_mssao = {"mssao", "Hoang's defaults: 5 levels, 16 Poisson taps, level blur", port_build,
                                   port_kernel, NULL, NULL};
