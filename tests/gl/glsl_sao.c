/* glsl_sao.c: the project's own GLSL port of McGuire, Mara and Luebke's SAO reference shaders
 * [McGuire12] (HPG 2012 supplement, BSD licence: SAO_AO.pix, SAO_minify.pix, SAO_blur.pix, and the
 * reconstructCSZ pass), re-typed in GLSL 4.50 from the published sources for the harness (glh.h),
 * following src/ao/ao_sao.c where docs/ao/sao.md lists a difference from the reference:
 *
 *   CSZ      reconstructCSZ: our input is already linear depth d (metres, > 0), so the pass is
 *            z = -d (camera space looks down -z); non-finite depths are uploaded as 0 and any
 *            depth <= 0 gives 0, the background sentinel (sao.md "CSZ", difference 12).
 *   minify   SAO_minify.pix as written: texel clamp(2 p + (p.y & 1, p.x & 1), 0,
 *            textureSize(prev) - 1) of the previous level, rendered into the next level of the same
 *            texture (previousMIPNumber a uniform).
 *   AO       SAO_AO.pix with falloff B ("Recommended"), NUM_SAMPLES / NUM_SPIRAL_TURNS /
 *            LOG_MAX_OFFSET / MAX_MIP_LEVEL compile-time as there (so 1.0 / NUM_SAMPLES and
 *            NUM_SPIRAL_TURNS * 6.28 fold in float, as in ours); alpha and angle in tapLocation
 *            are `precise`, i.e. evaluated in the order SAO_AO.pix writes them (GLSL otherwise lets
 *            the compiler reassociate: Mesa folds (1.0 / NUM_SAMPLES) * (NUM_SPIRAL_TURNS * 6.28)
 *            into one constant, which moves a tap angle by an ulp and, where ssR * cos lands within
 *            1e-3 of an integer, the tap by a texel: sao.md "GLSL port"). Ours where sao.md says so:
 *            the normal is normalize(cross(dFdxFine(C), dFdyFine(C))) (difference 1), the MIP clamp
 *            uses max(textureSize(CSZ, 0) >> mip, 1) - 1 (difference 3: llvmpipe's textureSize with a
 *            per-lane lod is wrong), z == 0 is background with A = 1 (decided after the derivatives,
 *            which need every lane of the quad), the final scale 5 / (r^6 N) comes from our constants
 *            (intensity * finalScale), and the key written for the blur is z itself (difference 9),
 *            in the second channel of an RG32F target.
 *   blur     SAO_blur.pix, R = 4, SCALE = the stride, the HPG12 Gaussian, key = z (0 = background,
 *            passed through), edgeK = EDGE_SHARPNESS * 2000 / FAR from our constants, taps clamped to
 *            the image (the reference's texelFetch out of range is undefined). Two passes, x then y.
 *
 * Uniforms come from ao_sao_constants_from_params. Everything runs in GL window coordinates, as
 * ao_sao.c does internally; the result is read back with our rows. */
#include "gl/glsl_ports.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
static const char *const fs_csz =
"#version 450\n"
"layout(binding=0) uniform sampler2D depthBuffer; /* our linear depth, GL rows, non-finite -> 0 */\n"
"layout(location=0) out float csZ;\n"
"void main() {\n"
"  float d = texelFetch(depthBuffer, ivec2(gl_FragCoord.xy), 0).r;\n"
"  csZ = d > 0.0 ? -d : 0.0;\n"
"}\n";

static const char *const fs_minify =
"#version 450\n"
"layout(binding=0) uniform sampler2D texture0;\n"
"uniform int previousMIPNumber;\n"
"layout(location=0) out float z;\n"
"void main() {\n"
"  ivec2 ssP = ivec2(gl_FragCoord.xy);\n"
"  /* Rotated grid subsampling to avoid XY directional bias or Z precision bias while downsampling */\n"
"  z = texelFetch(texture0, clamp(ssP * 2 + ivec2(ssP.y & 1, ssP.x & 1), ivec2(0),\n"
"                 textureSize(texture0, previousMIPNumber) - ivec2(1)), previousMIPNumber).r;\n"
"}\n";

static const char *const fs_ao =
"#version 450\n"
"layout(binding=0) uniform sampler2D CS_Z_buffer;\n"
"uniform float radius; uniform float radius2; uniform float projScale; uniform float bias;\n"
"uniform float epsilon; uniform float intensity; uniform float finalScale; uniform vec4 projInfo;\n"
"layout(location=0) out vec2 result;\n"
"vec3 reconstructCSPosition(vec2 S, float z) {\n"
"#if ORTHO\n"
"  return vec3(S.xy * projInfo.xy + projInfo.zw, z);\n"
"#else\n"
"  return vec3((S.xy * projInfo.xy + projInfo.zw) * z, z);\n"
"#endif\n"
"}\n"
"vec3 getPosition(ivec2 ssP) {\n"
"  vec3 P;\n"
"  P.z = texelFetch(CS_Z_buffer, ssP, 0).r;\n"
"  P = reconstructCSPosition(vec2(ssP) + vec2(0.5), P.z);\n"
"  return P;\n"
"}\n"
"vec2 tapLocation(int sampleNumber, float spinAngle, out float ssR) {\n"
"  precise float alpha = float(sampleNumber + 0.5) * (1.0 / NUM_SAMPLES);\n"
"  precise float angle = alpha * (NUM_SPIRAL_TURNS * 6.28) + spinAngle;\n"
"  ssR = alpha;\n"
"  return vec2(cos(angle), sin(angle));\n"
"}\n"
"vec3 getOffsetPosition(ivec2 ssC, vec2 unitOffset, float ssR) {\n"
"  int mipLevel = clamp(int(floor(log2(ssR))) - LOG_MAX_OFFSET, 0, MAX_MIP_LEVEL);\n"
"  ivec2 ssP = ivec2(ssR * unitOffset) + ssC;\n"
"  vec3 P;\n"
"  ivec2 mipP = clamp(ssP >> mipLevel, ivec2(0), max(textureSize(CS_Z_buffer, 0) >> mipLevel, ivec2(1)) - ivec2(1));\n"
"  P.z = texelFetch(CS_Z_buffer, mipP, mipLevel).r;\n"
"  P = reconstructCSPosition(vec2(ssP) + vec2(0.5), P.z);\n"
"  return P;\n"
"}\n"
"float sampleAO(ivec2 ssC, vec3 C, vec3 n_C, float ssDiskRadius, int tapIndex, float randomPatternRotationAngle) {\n"
"  float ssR;\n"
"  vec2 unitOffset = tapLocation(tapIndex, randomPatternRotationAngle, ssR);\n"
"  ssR *= ssDiskRadius;\n"
"  vec3 Q = getOffsetPosition(ssC, unitOffset, ssR);\n"
"  vec3 v = Q - C;\n"
"  float vv = dot(v, v);\n"
"  float vn = dot(v, n_C);\n"
"  /* B: Smoother transition to zero (lowers contrast, smoothing out corners). [Recommended] */\n"
"  float f = max(radius2 - vv, 0.0);\n"
"  return f * f * f * max((vn - bias) / (epsilon + vv), 0.0);\n"
"}\n"
"void main() {\n"
"  ivec2 ssC = ivec2(gl_FragCoord.xy);\n"
"  vec3 C = getPosition(ssC);\n"
"  vec3 n_C = normalize(cross(dFdxFine(C), dFdyFine(C))); /* sao.md difference 1 */\n"
"  if (C.z == 0.0) { result = vec2(1.0, 0.0); return; } /* background (after the quad's derivatives) */\n"
"  /* Hash function used in the HPG12 AlchemyAO paper */\n"
"  float randomPatternRotationAngle = float((3 * ssC.x ^ ssC.y + ssC.x * ssC.y) * 10);\n"
"#if ORTHO\n"
"  float ssDiskRadius = projScale * radius;\n"
"#else\n"
"  float ssDiskRadius = -projScale * radius / C.z;\n"
"#endif\n"
"  float sum = 0.0;\n"
"  for (int i = 0; i < NUM_SAMPLES; ++i)\n"
"    sum += sampleAO(ssC, C, n_C, ssDiskRadius, i, randomPatternRotationAngle);\n"
"  float A = max(0.0, 1.0 - sum * intensity * finalScale);\n"
"  result = vec2(A, C.z);\n"
"}\n";

static const char *const fs_blur =
"#version 450\n"
"#define R (4)\n"
"layout(binding=0) uniform sampler2D source; /* (A, key = z) */\n"
"uniform ivec2 axis; uniform float edgeK;\n"
"layout(location=0) out vec2 result;\n"
"void main() {\n"
"  float gaussian[R + 1] = float[](0.153170, 0.144893, 0.122649, 0.092902, 0.062970);\n"
"  ivec2 ssC = ivec2(gl_FragCoord.xy);\n"
"  vec2 temp = texelFetch(source, ssC, 0).rg;\n"
"  float key = temp.g;\n"
"  float sum = temp.r;\n"
"  result.g = key;\n"
"  if (key == 0.0) { result.r = sum; return; } /* background: pass through */\n"
"  float BASE = gaussian[0];\n"
"  float totalWeight = BASE;\n"
"  sum *= totalWeight;\n"
"  ivec2 hi = textureSize(source, 0) - ivec2(1);\n"
"  for (int r = -R; r <= R; ++r) {\n"
"    if (r != 0) {\n"
"      temp = texelFetch(source, clamp(ssC + axis * (r * SCALE), ivec2(0), hi), 0).rg;\n"
"      float tapKey = temp.g;\n"
"      float value = temp.r;\n"
"      float weight = 0.3 + gaussian[abs(r)];\n"
"      weight *= max(0.0, 1.0 - edgeK * abs(tapKey - key));\n"
"      sum += value * weight;\n"
"      totalWeight += weight;\n"
"    }\n"
"  }\n"
"  const float epsilon = 0.0001;\n"
"  result.r = sum / (totalWeight + epsilon);\n"
"}\n";
#endif

int glsl_sao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_sao_params *p, glh_run *r)
{
    (void)ctx;
#if !GLH_AVAILABLE
    (void)g;
    (void)in;
    (void)p;
    (void)r;
    printf("  glsl_sao: built without GL headers\n");
    return 0;
#else
    memset(r, 0, sizeof *r);
    if (p->variant != AO_SAO_VARIANT_HPG12 || p->normals != AO_SAO_NORMALS_FROM_DEPTH) {
        printf("  glsl_sao: only the HPG12 estimator with normals from depth is ported\n");
        return 0;
    }
    const ao_sao_constants k = ao_sao_constants_from_params(p, in);
    const int W = in->width, H = in->height, L = k.max_mip;
    GLuint tdepth = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, 0.0f, GL_NEAREST,
                                                                  GL_CLAMP_TO_EDGE));
    GLuint tcsz = glh_run_own_texture(r, glh_texture(g, W, H, L + 1, GL_R32F, 1, NULL, 0, GL_NEAREST,
                                                     GL_CLAMP_TO_EDGE));
    GLuint fcsz[AO_SAO_MAX_MIP + 1];
    for (int l = 0; l <= L; l++)
        fcsz[l] = glh_run_own_fbo(r, glh_framebuffer(g, tcsz, l));
    GLuint tao = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RG32F, 2, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fao = glh_run_own_fbo(r, glh_framebuffer(g, tao, 0));
    GLuint pcsz = glh_run_own_program(r, glh_program(g, fs_csz, NULL));
    char pre[256];
    snprintf(pre, sizeof pre,
             "#define NUM_SAMPLES (%d)\n#define NUM_SPIRAL_TURNS (%d)\n#define LOG_MAX_OFFSET (%d)\n"
             "#define MAX_MIP_LEVEL (%d)\n#define ORTHO %d\n",
             k.num_samples, k.num_spiral_turns, k.log_max_offset, k.max_mip, k.orthographic);
    GLuint pao = glh_run_own_program(r, glh_program(g, fs_ao, pre));
    if (!tdepth || !tcsz || !tao || !fao || !pcsz || !pao)
        return 0;
    for (int l = 0; l <= L; l++)
        if (!fcsz[l])
            return 0;
    glh_run_add(r, "sao reconstructCSZ", pcsz, fcsz[0], W, H, 1, &tdepth);
    for (int l = 1; l <= L; l++) {
        GLuint pm = glh_run_own_program(r, glh_program(g, fs_minify, NULL));
        if (!pm)
            return 0;
        glh_set1i(g, pm, "previousMIPNumber", l - 1);
        int w = W >> l, h = H >> l;
        glh_run_add(r, "sao minify", pm, fcsz[l], w < 1 ? 1 : w, h < 1 ? 1 : h, 1, &tcsz);
    }
    glh_set1f(g, pao, "radius", k.radius);
    glh_set1f(g, pao, "radius2", k.radius2);
    glh_set1f(g, pao, "projScale", k.proj_scale);
    glh_set1f(g, pao, "bias", k.bias);
    glh_set1f(g, pao, "epsilon", k.epsilon);
    glh_set1f(g, pao, "intensity", k.intensity);
    glh_set1f(g, pao, "finalScale", k.final_scale);
    glh_set4f(g, pao, "projInfo", k.proj_info[0], k.proj_info[1], k.proj_info[2], k.proj_info[3]);
    glh_run_add(r, L > 0 ? "sao AO (MIP chain)" : "sao AO (level 0)", pao, fao, W, H, 1, &tcsz);
    r->nkernel = r->npass;
    r->out_fbo = fao;
    r->out_w = W;
    r->out_h = H;
    r->out_rows = GLH_ROWS_FLIP;
    if (!k.blur)
        return 1;
    GLuint th = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RG32F, 2, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint tv = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RG32F, 2, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fh = glh_run_own_fbo(r, glh_framebuffer(g, th, 0)), fv = glh_run_own_fbo(r, glh_framebuffer(g, tv, 0));
    snprintf(pre, sizeof pre, "#define SCALE (%d)\n", k.blur_stride);
    GLuint bx = glh_run_own_program(r, glh_program(g, fs_blur, pre));
    GLuint by = glh_run_own_program(r, glh_program(g, fs_blur, pre));
    if (!fh || !fv || !bx || !by)
        return 0;
    glh_set2i(g, bx, "axis", 1, 0);
    glh_set2i(g, by, "axis", 0, 1);
    glh_set1f(g, bx, "edgeK", k.edge_k);
    glh_set1f(g, by, "edgeK", k.edge_k);
    glh_run_add(r, "sao blur x", bx, fh, W, H, 1, &tao);
    glh_run_add(r, "sao blur y", by, fv, W, H, 1, &th);
    r->out_fbo = fv;
    return 1;
#endif
}

/* ---- the benchmark's view: SAO at its defaults (11 taps, MIP chain to level 5, blur stride 2) ---- */

static int build_default(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    ao_sao_params p = ao_sao_params_default();
    return glsl_sao_build(g, ctx, in, &p, r);
}

static obs_status kernel_default(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_sao_params p = ao_sao_params_default();
    p.blur = 0;
    if (!out->data) {
        obs_status st = obs_image_f32_alloc(ctx, in->w, in->h, out);
        if (st != OBS_STATUS_OK)
            return st;
    }
    return ao_sao_compute(ctx, pool, in, &p, out, NULL, NULL);
}

/* SAO_blur.pix alone on our kernel's output: ao_sao_blur_gl in GL rows (the key is our CSZ). */
/* Ours: the blur alone, as the GLSL blur passes run it: on the kernel's output and the CSZ buffer the
 * kernel's first pass made. The CSZ and the two GL-row-order planes are kept between calls for the
 * same input (the benchmark calls this repeatedly; the GLSL side has its CSZ texture already), so a
 * timed call is the row flips and ao_sao_blur_gl. Not thread-safe (benchmark and tests only). */
static obs_status blur_default(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *a,
                               obs_image_f32 *out)
{
    static obs_image_f32 csz, ag, bg;
    static const obs_image_f32 *csz_of;
    const ao_sao_params p = ao_sao_params_default();
    const ao_sao_constants k = ao_sao_constants_from_params(&p, in);
    const int W = a->width, H = a->height;
    obs_status st = OBS_STATUS_OK;
    if (csz_of != in->depth || csz.width != in->width || csz.height != in->height || ag.width != W ||
        ag.height != H) {
        obs_image_f32_free(&csz);
        obs_image_f32_free(&ag);
        obs_image_f32_free(&bg);
        csz_of = NULL;
        st = obs_image_f32_alloc(ctx, in->width, in->height, &csz);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &ag);
        if (st == OBS_STATUS_OK)
            st = obs_image_f32_alloc(ctx, W, H, &bg);
        if (st == OBS_STATUS_OK)
            st = ao_sao_csz_from_input(ctx, pool, in, &csz);
        if (st != OBS_STATUS_OK)
            return st;
        csz_of = in->depth;
    }
    if (!out->data)
        st = obs_image_f32_alloc(ctx, W, H, out);
    if (st == OBS_STATUS_OK) {
        for (int y = 0; y < H; y++)
            memcpy(obs_image_f32_row(&ag, H - 1 - y), obs_image_f32_row(a, y), sizeof(float) * (size_t)W);
        st = ao_sao_blur_gl(ctx, pool, &ag, &csz, k.blur_stride, k.edge_k, &bg);
    }
    if (st == OBS_STATUS_OK)
        for (int y = 0; y < H; y++)
            memcpy(obs_image_f32_row(out, y), obs_image_f32_row(&bg, H - 1 - y), sizeof(float) * (size_t)W);
    return st;
}

const glsl_port glsl_port_sao = {"sao", "HPG12, 11 taps, MIP chain to level 5, blur 2 passes (stride 2)", build_default,
                                 kernel_default, blur_default, NULL};
