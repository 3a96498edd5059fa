/* glsl_hbao.c: GLSL ports of HBAO's two reference shaders and of its blur, on the GL harness (glh.h).
 *
 *   classic  NVIDIA DX10 SDK sample HorizonBasedAOEngine.fx (Bavoil & Sainz), HORIZON_BASED_AO_PS
 *            (useNormal false, qualityMode 1) and AccumulatedHorizonOcclusion, translated from HLSL:
 *            D3D texUV = (x, 1 - y_gl) interpolated (glh_fullscreen_vs), the depth uploaded in D3D
 *            row order (GLH_ROWS_AS_IS), round -> roundEven (D3D round_ne),
 *            tRandom.Load(int3(pos & 63, 0)) -> texelFetch(tRandom, pos & 63) with pos = (x, H - y_gl)
 *            (the SDK's 64 x 64 R16G16B16A16_SNORM texture, uploaded as RGBA16_SNORM shorts; & 3 with
 *            gl_ssao's 4 x 4 when params->noise asks for it), cb0/cb1 as plain uniforms, plus
 *            docs/ao/hbao.md difference 1 (a horizon at or past pi/2 adds 0).
 *   plus     nvpro-samples/gl_ssao hbao.frag.glsl with AO_DEINTERLEAVED 0, as written (its UBO as
 *            plain uniforms; NUM_STEPS and NUM_DIRECTIONS compile-time, as there; round as written).
 *   blur     gl_ssao bilateralblur.frag.glsl (two passes, +x / +y_gl taps first), with HBAO+'s
 *            Blur_Common.hlsl ProcessRadius1 depth slope under SLOPE 1 (the non-adaptive path).
 *
 * Uniforms come from ao_hbao_constants_from_params, the random texture from
 * ao_hbao_noise_texture_sdk / ao_hbao_noise_texture. Background (non-finite or non-positive depth)
 * is given a finite far depth of GLSL_HBAO_FAR metres, so that no +inf arithmetic runs on the GPU
 * (hbao.md difference 3 is not exercised here; the tests give our kernel the same depth). */
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GLSL_HBAO_FAR 500.0f

#if GLH_AVAILABLE
static const char *const fs_plus =
"#version 450\n"
"#define M_PI 3.14159265f\n"
"uniform float RadiusToScreen; uniform float NegInvR2; uniform float NDotVBias; uniform float AOMultiplier;\n"
"uniform float PowExponent; uniform vec2 InvFullResolution; uniform vec4 projInfo; uniform int projOrtho;\n"
"layout(binding=0) uniform sampler2D texLinearDepth; layout(binding=1) uniform sampler2D texRandom;\n"
"in vec2 texCoord; layout(location=0) out vec4 out_Color;\n"
"const float NUM_STEPS = NSTEPS; const float NUM_DIRECTIONS = NDIRS;\n"
"vec3 UVToView(vec2 uv, float eye_z){ return vec3((uv * projInfo.xy + projInfo.zw) * (projOrtho != 0 ? 1. : eye_z), eye_z); }\n"
"vec3 FetchViewPos(vec2 UV){ float ViewDepth = textureLod(texLinearDepth,UV,0).x; return UVToView(UV, ViewDepth); }\n"
"vec3 MinDiff(vec3 P, vec3 Pr, vec3 Pl){ vec3 V1 = Pr - P; vec3 V2 = P - Pl; return (dot(V1,V1) < dot(V2,V2)) ? V1 : V2; }\n"
"vec3 ReconstructNormal(vec2 UV, vec3 P){\n"
"  vec3 Pr = FetchViewPos(UV + vec2(InvFullResolution.x, 0)); vec3 Pl = FetchViewPos(UV + vec2(-InvFullResolution.x, 0));\n"
"  vec3 Pt = FetchViewPos(UV + vec2(0, InvFullResolution.y)); vec3 Pb = FetchViewPos(UV + vec2(0, -InvFullResolution.y));\n"
"  return normalize(cross(MinDiff(P, Pr, Pl), MinDiff(P, Pt, Pb))); }\n"
"float Falloff(float DistanceSquare){ return DistanceSquare * NegInvR2 + 1.0; }\n"
"float ComputeAO(vec3 P, vec3 N, vec3 S){ vec3 V = S - P; float VdotV = dot(V, V); float NdotV = dot(N, V) * 1.0/sqrt(VdotV);\n"
"  return clamp(NdotV - NDotVBias,0,1) * clamp(Falloff(VdotV),0,1); }\n"
"vec2 RotateDirection(vec2 Dir, vec2 CosSin){ return vec2(Dir.x*CosSin.x - Dir.y*CosSin.y, Dir.x*CosSin.y + Dir.y*CosSin.x); }\n"
"vec4 GetJitter(){ return textureLod(texRandom, (gl_FragCoord.xy / AO_RANDOMTEX_SIZE), 0); }\n"
"float ComputeCoarseAO(vec2 FullResUV, float RadiusPixels, vec4 Rand, vec3 ViewPosition, vec3 ViewNormal){\n"
"  float StepSizePixels = RadiusPixels / (NUM_STEPS + 1); const float Alpha = 2.0 * M_PI / NUM_DIRECTIONS; float AO = 0;\n"
"  for (float DirectionIndex = 0; DirectionIndex < NUM_DIRECTIONS; ++DirectionIndex) {\n"
"    float Angle = Alpha * DirectionIndex; vec2 Direction = RotateDirection(vec2(cos(Angle), sin(Angle)), Rand.xy);\n"
"    float RayPixels = (Rand.z * StepSizePixels + 1.0);\n"
"    for (float StepIndex = 0; StepIndex < NUM_STEPS; ++StepIndex) {\n"
"      vec2 SnappedUV = round(RayPixels * Direction) * InvFullResolution + FullResUV; vec3 S = FetchViewPos(SnappedUV);\n"
"      RayPixels += StepSizePixels; AO += ComputeAO(ViewPosition, ViewNormal, S); } }\n"
"  AO *= AOMultiplier / (NUM_DIRECTIONS * NUM_STEPS); return clamp(1.0 - AO * 2.0,0,1); }\n"
"void main(){ vec2 uv = texCoord; vec3 ViewPosition = FetchViewPos(uv); vec3 ViewNormal = -ReconstructNormal(uv, ViewPosition);\n"
"  float RadiusPixels = RadiusToScreen / (projOrtho != 0 ? 1.0 : ViewPosition.z); vec4 Rand = GetJitter();\n"
"  float AO = ComputeCoarseAO(uv, RadiusPixels, Rand, ViewPosition, ViewNormal); out_Color = vec4(pow(AO, PowExponent)); }\n";

static const char *const fs_classic =
"#version 450\n"
"#define M_PI 3.14159265f\n"
"uniform vec2 g_Dirs[32]; uniform float g_NumSteps; uniform float g_NumDir; uniform float g_R; uniform float g_inv_R;\n"
"uniform float g_sqr_R; uniform float g_AngleBias; uniform float g_Attenuation; uniform float g_Contrast;\n"
"uniform vec2 g_FocalLen; uniform vec2 g_InvResolution; uniform vec2 g_Resolution; uniform vec4 uvToView; uniform float g_H;\n"
"layout(binding=0) uniform sampler2D tLinDepth; layout(binding=1) uniform sampler2D tRandom;\n"
"in vec2 texUV; layout(location=0) out vec4 out_Color;\n"
"float tangentPS(vec3 P, vec3 S){ return (P.z - S.z) / length(S.xy - P.xy); }\n"
"vec3 uv_to_eye(vec2 uv, float eye_z){ return vec3((uv * uvToView.xy + uvToView.zw) * eye_z, eye_z); }\n"
"vec3 fetch_eye_pos(vec2 uv){ float z = textureLod(tLinDepth, uv, 0).x; return uv_to_eye(uv, z); }\n"
"float length2(vec3 v){ return dot(v, v); }\n"
"vec3 min_diff(vec3 P, vec3 Pr, vec3 Pl){ vec3 V1 = Pr - P; vec3 V2 = P - Pl; return (length2(V1) < length2(V2)) ? V1 : V2; }\n"
"float falloff(float r){ return 1.0f - g_Attenuation*r*r; }\n"
"vec2 snap_uv_offset(vec2 uv){ return roundEven(uv * g_Resolution) * g_InvResolution; }\n"
"float tangentT(vec3 T){ return -T.z / length(T.xy); }\n"
"float AccumulatedHorizonOcclusion(vec2 deltaUV, vec2 uv0, vec3 P, float numSteps, float randstep, vec3 dPdu, vec3 dPdv){\n"
"  vec2 uv = uv0 + snap_uv_offset( randstep * deltaUV ); deltaUV = snap_uv_offset( deltaUV );\n"
"  vec3 T = deltaUV.x * dPdu + deltaUV.y * dPdv;\n"
"  float phi = atan(tangentT(T)) + g_AngleBias; if (!(phi < M_PI*0.5)) return 0.0; /* hbao.md difference 1 */\n"
"  float tanH = tan(phi); float sinH = tanH / sqrt(1.0f + tanH*tanH); float ao = 0;\n"
"  for(float j = 1; j <= numSteps; ++j) { uv += deltaUV; vec3 S = fetch_eye_pos(uv); float d2 = length2(S - P);\n"
"    if (d2 < g_sqr_R) { float tanS = tangentPS(P, S);\n"
"      if(tanS > tanH) { float sinS = tanS / sqrt(1.0f + tanS*tanS); float r = sqrt(d2) * g_inv_R;\n"
"        ao += falloff(r) * (sinS - sinH); tanH = tanS; sinH = sinS; } } }\n"
"  return ao; }\n"
"void main(){ vec3 P = fetch_eye_pos(texUV);\n"
"  vec2 step_size = 0.5 * g_R * g_FocalLen / P.z;\n"
"  float numSteps = min ( g_NumSteps, min(step_size.x * g_Resolution.x, step_size.y * g_Resolution.y));\n"
"  if( numSteps < 1.0 ) { out_Color = vec4(1.0); return; }\n"
"  step_size = step_size / ( numSteps + 1 );\n"
"  vec3 Pr = fetch_eye_pos(texUV + vec2(g_InvResolution.x, 0)); vec3 Pl = fetch_eye_pos(texUV + vec2(-g_InvResolution.x, 0));\n"
"  vec3 Pt = fetch_eye_pos(texUV + vec2(0, g_InvResolution.y)); vec3 Pb = fetch_eye_pos(texUV + vec2(0, -g_InvResolution.y));\n"
"  vec3 dPdu = min_diff(P, Pr, Pl); vec3 dPdv = min_diff(P, Pt, Pb) * (g_Resolution.y * g_InvResolution.x);\n"
"  ivec2 pos = ivec2(int(gl_FragCoord.x), int(g_H - gl_FragCoord.y)); /* SV_Position, D3D rows */\n"
"  vec3 rand_Dir = texelFetch(tRandom, pos & (RANDOM_SIZE - 1), 0).xyz; float ao = 0; /* Load(int3(pos & 63, 0)) */\n"
"  for (float d = 0; d < g_NumDir; ++d) { vec2 deltaUV = vec2(g_Dirs[int(d)].x*rand_Dir.x - g_Dirs[int(d)].y*rand_Dir.y,\n"
"      g_Dirs[int(d)].x*rand_Dir.y + g_Dirs[int(d)].y*rand_Dir.x) * step_size.xy;\n"
"    ao += AccumulatedHorizonOcclusion(deltaUV, texUV, P, numSteps, rand_Dir.z, dPdu, dPdv); }\n"
"  out_Color = vec4(clamp(1.0 - ao / g_NumDir * g_Contrast, 0.0, 1.0)); }\n";

/* gl_ssao bilateralblur.frag.glsl, with HBAO+'s ProcessRadius1 depth slope under SLOPE 1 */
static const char *const fs_blur =
"#version 450\n"
"uniform float g_Sharpness; uniform vec2 g_InvResolutionDirection; uniform float BlurFalloff;\n"
"layout(binding=0) uniform sampler2D texSource; layout(binding=1) uniform sampler2D texLinearDepth;\n"
"in vec2 texCoord; layout(location=0) out vec4 out_Color;\n"
"float BlurW(float r, float d, float slope, float center_d) { d -= slope * r; float ddiff = (d - center_d) * g_Sharpness;\n"
"  return exp2(-r*r*BlurFalloff - ddiff*ddiff); }\n"
"void main(){ float center_c = texture(texSource, texCoord).x; float center_d = texture(texLinearDepth, texCoord).x;\n"
"  float c_total = center_c; float w_total = 1.0;\n"
"  for (int side = 0; side < 2; side++) { vec2 dir = side == 0 ? g_InvResolutionDirection : -g_InvResolutionDirection;\n"
"    float slope = SLOPE != 0 ? texture(texLinearDepth, texCoord + dir).x - center_d : 0.0;\n"
"    for (float r = 1; r <= KERNEL_RADIUS; ++r) { vec2 uv = texCoord + dir * r; float c = texture(texSource, uv).x;\n"
"      float d = texture(texLinearDepth, uv).x; float w = BlurW(r, d, slope, center_d); w_total += w; c_total += c*w; } }\n"
"  out_Color = vec4(c_total/w_total); }\n";
#endif

int glsl_hbao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_hbao_params *p, glh_run *r)
{
    (void)ctx;
#if !GLH_AVAILABLE
    (void)g;
    (void)in;
    (void)p;
    (void)r;
    printf("  glsl_hbao: built without GL headers\n");
    return 0;
#else
    const int W = in->width, H = in->height;
    const ao_hbao_constants k = ao_hbao_constants_from_params(p, in);
    const int plus = k.variant == AO_HBAO_VARIANT_PLUS;
    memset(r, 0, sizeof *r);
    /* depth: PLUS bottom row first (GL), CLASSIC our rows (D3D v); background -> GLSL_HBAO_FAR */
    GLuint tz = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, plus ? GLH_ROWS_FLIP : GLH_ROWS_AS_IS,
                                                              GLSL_HBAO_FAR, GL_NEAREST, GL_CLAMP_TO_EDGE));
    /* the random texture as RGBA16_SNORM shorts, texel i at (i % n, i / n) in upload order */
    const int n = k.noise_size;
    int16_t *sh = (int16_t *)malloc(sizeof(int16_t) * (size_t)(n * n * 4));
    if (!sh)
        return 0;
    if (k.noise == AO_HBAO_NOISE_SDK)
        ao_hbao_noise_texture_sdk(k.num_dirs, sh, NULL);
    else
        ao_hbao_noise_texture(k.num_dirs, sh, NULL);
    GLuint tr = glh_run_own_texture(r, glh_texture(g, n, n, 1, GL_RGBA16_SNORM, 4, NULL, GLH_ROWS_AS_IS, GL_NEAREST,
                                                   GL_REPEAT));
    if (tr) {
        g->gl.glBindTexture(GL_TEXTURE_2D, tr);
        g->gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        g->gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, n, n, GL_RGBA, GL_SHORT, sh);
        g->gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    }
    free(sh);
    GLuint tao = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fao = glh_run_own_fbo(r, glh_framebuffer(g, tao, 0));
    char pre[160];
    GLuint pr;
    if (plus) {
        snprintf(pre, sizeof pre, "#define NSTEPS %d.0\n#define NDIRS %d.0\n#define AO_RANDOMTEX_SIZE %d.0\n", k.num_steps,
                 k.num_dirs, n);
        pr = glh_run_own_program(r, glh_program(g, fs_plus, pre));
        if (!pr || !tz || !tr || !fao)
            return 0;
        glh_set1f(g, pr, "RadiusToScreen", k.radius_to_screen);
        glh_set1f(g, pr, "NegInvR2", k.neg_inv_R2);
        glh_set1f(g, pr, "NDotVBias", k.ndotv_bias);
        glh_set1f(g, pr, "AOMultiplier", k.ao_multiplier);
        glh_set1f(g, pr, "PowExponent", k.pow_exponent);
        glh_set2f(g, pr, "InvFullResolution", k.inv_resolution[0], k.inv_resolution[1]);
        glh_set4f(g, pr, "projInfo", k.uv_to_view[0], k.uv_to_view[1], k.uv_to_view[2], k.uv_to_view[3]);
        glh_set1i(g, pr, "projOrtho", k.orthographic);
    } else {
        snprintf(pre, sizeof pre, "#define RANDOM_SIZE %d\n", n);
        pr = glh_run_own_program(r, glh_program(g, fs_classic, pre));
        if (!pr || !tz || !tr || !fao)
            return 0;
        glh_setfv(g, pr, "g_Dirs", 2, k.num_dirs, &k.dirs[0][0]);
        glh_set1f(g, pr, "g_NumSteps", (float)k.num_steps);
        glh_set1f(g, pr, "g_NumDir", (float)k.num_dirs);
        glh_set1f(g, pr, "g_R", k.R);
        glh_set1f(g, pr, "g_inv_R", k.inv_R);
        glh_set1f(g, pr, "g_sqr_R", k.sqr_R);
        glh_set1f(g, pr, "g_AngleBias", k.angle_bias);
        glh_set1f(g, pr, "g_Attenuation", k.attenuation);
        glh_set1f(g, pr, "g_Contrast", k.contrast);
        glh_set2f(g, pr, "g_FocalLen", k.focal_len[0], k.focal_len[1]);
        glh_set2f(g, pr, "g_InvResolution", k.inv_resolution[0], k.inv_resolution[1]);
        glh_set2f(g, pr, "g_Resolution", k.resolution[0], k.resolution[1]);
        glh_set4f(g, pr, "uvToView", k.uv_to_view[0], k.uv_to_view[1], k.uv_to_view[2], k.uv_to_view[3]);
        glh_set1f(g, pr, "g_H", (float)H);
    }
    const GLuint kt[2] = {tz, tr};
    glh_run_add(r, plus ? "hbao plus (hbao.frag.glsl)" : "hbao classic (HorizonBasedAOEngine.fx)", pr, fao, W, H, 2, kt);
    r->nkernel = r->npass;
    r->out_fbo = fao;
    r->out_w = W;
    r->out_h = H;
    r->out_rows = GLH_ROWS_FLIP;
    if (!k.blur)
        return 1;
    /* the blur reads AO and depth in GL rows (the kernel's output is in GL rows for both variants) */
    GLuint tzg = plus ? tz
                      : glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, GLSL_HBAO_FAR,
                                                                      GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint th = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint tv = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fh = glh_run_own_fbo(r, glh_framebuffer(g, th, 0)), fv = glh_run_own_fbo(r, glh_framebuffer(g, tv, 0));
    snprintf(pre, sizeof pre, "#define KERNEL_RADIUS %d.0\n#define SLOPE %d\n", k.blur_radius, k.blur_depth_slope);
    GLuint bx = glh_run_own_program(r, glh_program(g, fs_blur, pre));
    GLuint by = glh_run_own_program(r, glh_program(g, fs_blur, pre));
    if (!tzg || !fh || !fv || !bx || !by)
        return 0;
    GLuint progs[2] = {bx, by};
    for (int i = 0; i < 2; i++) {
        glh_set1f(g, progs[i], "g_Sharpness", k.blur_sharpness);
        glh_set1f(g, progs[i], "BlurFalloff", k.blur_falloff);
    }
    glh_set2f(g, bx, "g_InvResolutionDirection", 1.0f / (float)W, 0.0f);
    glh_set2f(g, by, "g_InvResolutionDirection", 0.0f, 1.0f / (float)H);
    const GLuint hx[2] = {tao, tzg}, hy[2] = {th, tzg};
    glh_run_add(r, "hbao blur x", bx, fh, W, H, 2, hx);
    glh_run_add(r, "hbao blur y", by, fv, W, H, 2, hy);
    r->out_fbo = fv;
    return 1;
#endif
}

/* ---- the benchmark's view: each preset at its defaults ---- */

static ao_hbao_params preset(const char *name)
{
    ao_hbao_params p;
    if (!ao_hbao_params_preset(name, &p))
        p = ao_hbao_params_default();
    return p;
}

static obs_status kernel_with(obs_context *ctx, obs_pool *pool, const ao_input *in, ao_hbao_params p,
                              obs_image_f32 *out)
{
    p.blur = 0;
    if (!out->data) {
        obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
        if (st != OBS_STATUS_OK)
            return st;
    }
    return ao_hbao_compute(ctx, pool, in, &p, out, NULL, NULL);
}

static obs_status blur_with(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *a,
                            ao_hbao_params p, obs_image_f32 *out)
{
    if (!out->data) {
        obs_status st = obs_image_f32_alloc(ctx, a->width, a->height, out);
        if (st != OBS_STATUS_OK)
            return st;
    }
    return ao_hbao_blur(ctx, pool, a, in->depth, 0, 0, p.blur_radius, p.blur_sigma, p.blur_sharpness,
                        p.blur_depth_slope, out);
}

static int build_classic(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    ao_hbao_params p = preset("default");
    return glsl_hbao_build(g, ctx, in, &p, r);
}
static int build_plus(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    ao_hbao_params p = preset("plus");
    return glsl_hbao_build(g, ctx, in, &p, r);
}
static obs_status kernel_classic(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    return kernel_with(ctx, pool, in, preset("default"), out);
}
static obs_status kernel_plus(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    return kernel_with(ctx, pool, in, preset("plus"), out);
}
static obs_status blur_classic(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *a,
                               obs_image_f32 *out)
{
    return blur_with(ctx, pool, in, a, preset("default"), out);
}
static obs_status blur_plus(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *a,
                            obs_image_f32 *out)
{
    return blur_with(ctx, pool, in, a, preset("plus"), out);
}

const glsl_port glsl_port_hbao_classic = {"hbao", "classic: DX10 SDK defaults (16 x 8, 64 x 64 jitter), blur radius 4",
                                          build_classic, kernel_classic, blur_classic, NULL};
const glsl_port glsl_port_hbao_plus = {"hbao", "plus: HBAO+ defaults (8 x 4, gl_ssao 4 x 4 jitter), blur radius 4",
                                       build_plus, kernel_plus, blur_plus, NULL};
