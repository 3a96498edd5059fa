/* glsl_crytek.c: Crytek SSAO [Kajalin09] in GLSL, the port of the ShaderX7 §6.1 listing as
 * docs/ao/crytek.md reads it (the D3D9 effect copy 18810930753, PS_AO, and the DirectCompute port
 * 11093304203 for the `compute-port` preset; ../shared/reference/ao.md §1.1), then the seed's
 * 21-tap Gaussian (glsl_gauss21.c) when params->blur.
 *
 * The listing, re-typed (HLSL -> GLSL):
 *   float3 vRotation = 2 * tex2D(g_RotSampler4x4, screenTC * screenSize / 4) - 1;
 *   float h = 1 / (1 + vRotation.z); rotMat._m00 = h * vRotation.y * vRotation.y + vRotation.z; ...
 *   for (i < nSamplesNum / 8) for (x, y, z in -1, +1): vOffset = normalize(float3(x, y, z)) * (offsetScale *= offsetScaleStep);
 *     float3 vRotatedOffset = mul(vOffset, rotMat);
 *     float3 vSamplePos = float3(screenTC, fSceneDepthP) + float3(vRotatedOffset.xy, vRotatedOffset.z * fSceneDepthP * 2);
 *     float fSceneDepthS = tex2D(g_SceneDepthSampler, vSamplePos.xy);
 *     float fRangeIsInvalid = saturate((fSceneDepthP - fSceneDepthS) / fSceneDepthS);
 *     Accessibility += lerp(fSceneDepthS > vSamplePos.z, 0.5, fRangeIsInvalid);
 *   Accessibility = Accessibility / nSamplesNum; return saturate(Accessibility * Accessibility + Accessibility);
 *
 * Translation and where the port follows OUR documented behaviour (docs/ao/crytek.md "Differences"):
 * - Coordinates are GL's (the kernel is written in GL pixel coordinates: y_gl = H - 1 - y), so the
 *   depth is uploaded with rows flipped (GLH_ROWS_FLIP) and screenTC = gl_FragCoord.xy * invSize
 *   (the interpolated texcoord's value at the pixel centre, without the interpolator's rounding).
 * - The rotation texture is our documented generator (ao_crytek_rotation), RGB32F (no 2t - 1 decode),
 *   4x4, GL_NEAREST + GL_REPEAT, row j = y_gl & 3 (uploaded as is).
 * - The unrolled loop's compile-time offsets vOffset_t are uniforms, from our constants step
 *   (ao_crytek_constants_from_params: the correctly rounded 1/sqrt(3), offsetScale *= step in float).
 * - mul(vOffset, rotMat) is written out component by component in our (and HLSL's) order.
 * - Depth sampler: CLAMP_TO_EDGE, not the listing's border addressing (an off-screen tap there reads
 *   border 0 and adds 0.5 through the range check): ours clamps, and so does the port. Linear
 *   (the effect's MinFilter = Linear) or nearest (the compute port's integer fetch; ours floors
 *   and clamps, as GL_NEAREST does). Our deviation: a linear footprint touching background (+inf,
 *   uploaded as is) falls back to the nearest texel (textureGather tests the footprint).
 * - Sky: a background centre is visibility 1; a background tap adds 1 (sky visible) or 0 (skip).
 * - Space world (our default): S.z = dP + R.z kz, S.xy = uv + kxy (R.xy - a R.z) / S.z with the
 *   pixel's ray slopes a (the constant block's `ray`); a tap behind the eye adds 1. Space screen:
 *   the listing (kz = 2, times dP).
 * - Output: saturate(A^2 + A) (remap) or A (accessibility). */
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
static const char *const fs_crytek =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D g_SceneDepthSampler;\n"
    "layout(binding=1) uniform sampler2D g_RotSampler4x4;\n"
    "uniform vec2 invSize; uniform vec2 screenSize; uniform vec2 kxy; uniform float kz; uniform vec4 ray;\n"
    "uniform float nSamplesNum; uniform vec3 vOffsets[NSAMPLES];\n"
    "layout(location=0) out vec4 o;\n"
    "const float INF = 1.0 / 0.0;\n"
    "bool isSurface(float d) { return d > 0.0 && d < INF; }\n"
    "float sceneDepth(vec2 S) {\n"
    "#if LINEAR\n"
    "  vec4 q = textureGather(g_SceneDepthSampler, S, 0);\n"
    "  if (isSurface(q.x) && isSurface(q.y) && isSurface(q.z) && isSurface(q.w))\n"
    "    return texture(g_SceneDepthSampler, S).r;\n"
    "  ivec2 sz = textureSize(g_SceneDepthSampler, 0);\n"
    "  return texelFetch(g_SceneDepthSampler, clamp(ivec2(floor(S * vec2(sz))), ivec2(0), sz - 1), 0).r;\n"
    "#else\n"
    "  return texture(g_SceneDepthSampler, S).r;\n"
    "#endif\n"
    "}\n"
    "void main() {\n"
    "  float fSceneDepthP = texelFetch(g_SceneDepthSampler, ivec2(gl_FragCoord.xy), 0).r;\n"
    "  if (!isSurface(fSceneDepthP)) { o = vec4(1.0); return; }\n"
    "  vec2 screenTC = gl_FragCoord.xy * invSize;\n"
    "  vec3 vRotation = texture(g_RotSampler4x4, screenTC * screenSize / 4.0).rgb;\n"
    "  float h = 1.0 / (1.0 + vRotation.z);\n"
    "  float m00 = h * vRotation.y * vRotation.y + vRotation.z, m01 = -h * vRotation.y * vRotation.x, m02 = -vRotation.x;\n"
    "  float m10 = -h * vRotation.y * vRotation.x, m11 = h * vRotation.x * vRotation.x + vRotation.z, m12 = -vRotation.y;\n"
    "  float m20 = vRotation.x, m21 = vRotation.y, m22 = vRotation.z;\n"
    "#if SPACE_SCREEN\n"
    "  float kzP = kz * fSceneDepthP;\n"
    "#else\n"
    "  float kzP = kz;\n"
    "#endif\n"
    "  vec2 a = vec2(ray.x + floor(gl_FragCoord.x) * ray.z, ray.y + floor(gl_FragCoord.y) * ray.w);\n"
    "  float Accessibility = 0.0;\n"
    "  for (int t = 0; t < NSAMPLES; t++) {\n"
    "    vec3 vOffset = vOffsets[t];\n"
    "    vec3 R = vec3(vOffset.x * m00 + vOffset.y * m10 + vOffset.z * m20,\n"
    "                  vOffset.x * m01 + vOffset.y * m11 + vOffset.z * m21,\n"
    "                  vOffset.x * m02 + vOffset.y * m12 + vOffset.z * m22);\n"
    "    float Sz = fSceneDepthP + R.z * kzP;\n"
    "#if PERSPECTIVE_WORLD\n"
    "    if (!(Sz > 0.0)) { Accessibility += 1.0; continue; }\n"
    "    vec2 S = vec2(screenTC.x + kxy.x * (R.x - a.x * R.z) / Sz, screenTC.y + kxy.y * (R.y - a.y * R.z) / Sz);\n"
    "#else\n"
    "    vec2 S = vec2(screenTC.x + R.x * kxy.x, screenTC.y + R.y * kxy.y);\n"
    "#endif\n"
    "    float fSceneDepthS = sceneDepth(S);\n"
    "    if (!isSurface(fSceneDepthS)) { Accessibility += SKY_VALUE; continue; }\n"
    "    float fRangeIsInvalid = clamp((fSceneDepthP - fSceneDepthS) / fSceneDepthS, 0.0, 1.0);\n"
    "    float s = fSceneDepthS > Sz ? 1.0 : 0.0;\n"
    "    Accessibility += s + fRangeIsInvalid * (0.5 - s);\n"
    "  }\n"
    "  Accessibility = Accessibility / nSamplesNum;\n"
    "#if REMAP\n"
    "  o = vec4(clamp(Accessibility * Accessibility + Accessibility, 0.0, 1.0));\n"
    "#else\n"
    "  o = vec4(clamp(Accessibility, 0.0, 1.0));\n"
    "#endif\n"
    "}\n";
#endif

int glsl_crytek_build(glh *g, obs_context *ctx, const ao_input *in, const ao_crytek_params *p, glh_run *r)
{
    (void)ctx;
#if GLH_AVAILABLE
    memset(r, 0, sizeof *r);
    ao_crytek_constants *k = (ao_crytek_constants *)malloc(sizeof *k);
    if (!k)
        return 0;
    ao_crytek_constants_from_params(p, in, k);
    const int W = in->width, H = in->height;
    char pre[256];
    snprintf(pre, sizeof pre, "#define NSAMPLES %d\n#define LINEAR %d\n#define SPACE_SCREEN %d\n"
             "#define PERSPECTIVE_WORLD %d\n#define SKY_VALUE %s\n#define REMAP %d\n",
             k->num_samples, k->filter == AO_CRYTEK_FILTER_LINEAR, k->space == AO_CRYTEK_SPACE_SCREEN,
             k->space == AO_CRYTEK_SPACE_WORLD && !k->orthographic, k->sky == AO_CRYTEK_SKY_VISIBLE ? "1.0" : "0.0",
             k->output == AO_CRYTEK_OUTPUT_REMAP);
    const GLenum filt = k->filter == AO_CRYTEK_FILTER_LINEAR ? GL_LINEAR : GL_NEAREST;
    GLuint depth = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, INFINITY, filt,
                                                                 GL_CLAMP_TO_EDGE));
    GLuint depth_n = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, INFINITY, GL_NEAREST,
                                                                   GL_CLAMP_TO_EDGE));
    GLuint rot = glh_run_own_texture(r, glh_texture(g, 4, 4, 1, GL_RGB32F, 3, &ao_crytek_rotation[0][0],
                                                    GLH_ROWS_AS_IS, GL_NEAREST, GL_REPEAT));
    GLuint ao = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fb = glh_run_own_fbo(r, glh_framebuffer(g, ao, 0));
    GLuint prog = glh_run_own_program(r, glh_program(g, fs_crytek, pre));
    int ok = depth && depth_n && rot && ao && fb && prog;
    if (ok) {
        glh_set2f(g, prog, "invSize", k->inv_size[0], k->inv_size[1]);
        glh_set2f(g, prog, "screenSize", k->size[0], k->size[1]);
        glh_set2f(g, prog, "kxy", k->kxy[0], k->kxy[1]);
        glh_set1f(g, prog, "kz", k->kz);
        glh_set4f(g, prog, "ray", k->ray[0], k->ray[1], k->ray[2], k->ray[3]);
        glh_set1f(g, prog, "nSamplesNum", k->num_samples_f);
        glh_setfv(g, prog, "vOffsets", 3, k->num_samples, &k->offsets[0][0]);
        const GLuint t[2] = {depth, rot};
        ok = glh_run_add(r, "crytek AO", prog, fb, W, H, 2, t) >= 0;
        r->nkernel = r->npass;
        r->out_fbo = fb;
        r->out_w = W;
        r->out_h = H;
        r->out_rows = GLH_ROWS_FLIP;
        if (ok && k->blur)
            ok = glsl_gauss21_add(g, in, r, ao, depth_n, GLH_ROWS_FLIP);
    }
    free(k);
    if (!ok)
        printf("  crytek: the GLSL port could not be built\n");
    return ok;
#else
    (void)g, (void)in, (void)p, (void)r;
    return 0;
#endif
}

/* ---- the benchmark's view: the defaults (world ball, linear, 16 taps, the Gaussian) ---- */
static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_crytek_params p = ao_crytek_params_default();
    return glsl_crytek_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_crytek_params p = ao_crytek_params_default();
    p.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st == OBS_STATUS_OK ? ao_crytek_compute(ctx, pool, in, &p, out, NULL, NULL) : st;
}

const glsl_port glsl_port_crytek = {"crytek", "defaults: world ball r 0.5 m, 16 taps, linear depth, 21-tap Gaussian",
                                    port_build, port_kernel, glsl_gauss21_ours, NULL};
