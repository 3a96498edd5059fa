/* glsl_alchemy.c: Alchemy AO [McGuire11] in GLSL, then the seed's 21-tap Gaussian (glsl_gauss21.c)
 * when params->blur. docs/ao/alchemy.md, "GLSL port".
 *
 * Sources re-typed: the estimator of [McGuire11] §3,
 *     A = max(0, 1 - (2 sigma / s) * sum_i max(0, v_i.n + z_C beta) / (v_i.v_i + epsilon))^k,
 * laid out as the authors' HPG12 reference shader (SAO_AO.pix, [McGuire12], BSD) lays out the
 * same loop: reconstructCSPosition with projInfo, the per-pixel hash "used in the HPG12 AlchemyAO
 * paper" `(3 * ssC.x ^ ssC.y + ssC.x * ssC.y) * 10`, tapLocation (alpha = (i + 0.5) / s,
 * angle = alpha * (NUM_SPIRAL_TURNS * 6.28) + spin, ssR = alpha * ssDiskRadius,
 * ssP = ivec2(ssR * unitOffset) + ssC), and its falloff A ("From the HPG12 paper":
 * float(vv < radius2) * max((vn - bias) / (epsilon + vv), 0)) with the Alchemy bias term z_C beta.
 * The third-party "AlchemyHPG11" GLSL ports have the same body.
 *
 * Where the port follows OUR documented behaviour (docs/ao/alchemy.md):
 * - GL pixel coordinates: the depth and the G-buffer normals are uploaded with rows flipped, so
 *   ssC = ivec2(gl_FragCoord.xy) is our (x, H - 1 - y).
 * - The tap reads the depth at the texel clamped to the buffer (CLAMP_TO_EDGE) and Q is that
 *   texel's own point (the paper's position buffer), not SAO's reconstruction at the unclamped ssP.
 * - Background (+inf, uploaded as is): a background centre is visibility 1; a background tap
 *   contributes 0. A zero or non-finite normal is visibility 1.
 * - The range check [vv < r^2] is a define (our --range-check); 1/s and tau * 6.28 are the float
 *   constants of our constants step, as GLSL folds them.
 * - Normals: the G-buffer's (the paper's normal buffer); normalize as n * inversesqrt(n.n).
 * Not ported: `--normals depth` (our ao_normals_from_depth, not part of the paper). */
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE
static const char *const fs_alchemy =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D CS_Z_buffer;\n"
    "layout(binding=1) uniform sampler2D normal_buffer;\n"
    "uniform vec4 projInfo; uniform float projScale; uniform float radius; uniform float radius2;\n"
    "uniform float bias; uniform float epsilon; uniform float intensityScale; uniform float contrast;\n"
    "uniform float invNumSamples; uniform float turnsAngle;\n"
    "layout(location=0) out vec4 o;\n"
    "const float INF = 1.0 / 0.0;\n"
    "vec3 reconstructCSPosition(vec2 S, float z) {\n"
    "#if ORTHO\n"
    "  return vec3((S + vec2(0.5)) * projInfo.xy + projInfo.zw, z);\n"
    "#else\n"
    "  return vec3(((S + vec2(0.5)) * projInfo.xy + projInfo.zw) * z, z);\n"
    "#endif\n"
    "}\n"
    "void main() {\n"
    "  ivec2 ssC = ivec2(gl_FragCoord.xy);\n"
    "  ivec2 size = textureSize(CS_Z_buffer, 0);\n"
    "  float d = texelFetch(CS_Z_buffer, ssC, 0).r;\n"
    "  if (!(d > 0.0 && d < INF)) { o = vec4(1.0); return; }\n"
    "  float z_C = -d;\n"
    "  vec3 C = reconstructCSPosition(vec2(ssC), z_C);\n"
    "  vec3 nb = texelFetch(normal_buffer, ssC, 0).rgb;\n"
    "  float l2 = nb.x * nb.x + nb.y * nb.y + nb.z * nb.z;\n"
    "  if (!(l2 > 0.0) || !(l2 < INF)) { o = vec4(1.0); return; }\n"
    "  vec3 n = nb * inversesqrt(l2);\n"
    "  float randomPatternRotationAngle = float((3 * ssC.x ^ ssC.y + ssC.x * ssC.y) * 10);\n"
    "#if ORTHO\n"
    "  float ssDiskRadius = projScale * radius;\n"
    "#else\n"
    "  float ssDiskRadius = (-projScale * radius) / z_C;\n"
    "#endif\n"
    "  float zb = z_C * bias;\n"
    "  float sum = 0.0;\n"
    "  for (int i = 0; i < NUM_SAMPLES; ++i) {\n"
    "    float alpha = (float(i) + 0.5) * invNumSamples;\n"
    "    float angle = alpha * turnsAngle + randomPatternRotationAngle;\n"
    "    float ssR = alpha * ssDiskRadius;\n"
    "    vec2 unitOffset = vec2(cos(angle), sin(angle));\n"
    "    ivec2 ssP = ivec2(ssR * unitOffset) + ssC;\n"
    "    ivec2 t = clamp(ssP, ivec2(0), size - 1);\n"
    "    float dq = texelFetch(CS_Z_buffer, t, 0).r;\n"
    "    if (!(dq > 0.0 && dq < INF)) continue;\n"
    "    vec3 Q = reconstructCSPosition(vec2(t), -dq);\n"
    "    vec3 v = Q - C;\n"
    "    float vv = v.x * v.x + v.y * v.y + v.z * v.z;\n"
    "    float vn = v.x * n.x + v.y * n.y + v.z * n.z;\n"
    "#if RANGE_CHECK\n"
    "    if (!(vv < radius2)) continue;\n"
    "#endif\n"
    "    sum += max(0.0, vn + zb) / (vv + epsilon);\n"
    "  }\n"
    "  float A = max(0.0, 1.0 - intensityScale * sum);\n"
    "#if CONTRAST_ONE\n"
    "  o = vec4(A);\n"
    "#else\n"
    "  o = vec4(clamp(pow(A, contrast), 0.0, 1.0));\n"
    "#endif\n"
    "}\n";
#endif

int glsl_alchemy_build(glh *g, obs_context *ctx, const ao_input *in, const ao_alchemy_params *p, glh_run *r)
{
    (void)ctx;
#if GLH_AVAILABLE
    memset(r, 0, sizeof *r);
    if (!in->normal[0]) {
        printf("  alchemy: the GLSL port reads the G-buffer's normals; the input has none\n");
        return 0;
    }
    const ao_alchemy_constants k = ao_alchemy_constants_from_params(p, in);
    const int W = in->width, H = in->height;
    char pre[256];
    snprintf(pre, sizeof pre, "#define NUM_SAMPLES %d\n#define ORTHO %d\n#define RANGE_CHECK %d\n#define CONTRAST_ONE %d\n",
             k.num_samples, k.orthographic, k.range_check, k.contrast == 1.0f);
    float *nb = (float *)malloc(sizeof(float) * 3 * (size_t)W * (size_t)H);
    if (!nb)
        return 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++)
                nb[((size_t)y * W + x) * 3 + c] = obs_image_f32_row(in->normal[c], y)[x];
    GLuint depth = glh_run_own_texture(r, glh_texture_from_image(g, in->depth, GLH_ROWS_FLIP, INFINITY, GL_NEAREST,
                                                                 GL_CLAMP_TO_EDGE));
    GLuint nt = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGB32F, 3, nb, GLH_ROWS_FLIP, GL_NEAREST,
                                                   GL_CLAMP_TO_EDGE));
    free(nb);
    GLuint ao = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_R32F, 1, NULL, 0, GL_NEAREST, GL_CLAMP_TO_EDGE));
    GLuint fb = glh_run_own_fbo(r, glh_framebuffer(g, ao, 0));
    GLuint prog = glh_run_own_program(r, glh_program(g, fs_alchemy, pre));
    int ok = depth && nt && ao && fb && prog;
    if (ok) {
        glh_set4f(g, prog, "projInfo", k.proj_info[0], k.proj_info[1], k.proj_info[2], k.proj_info[3]);
        glh_set1f(g, prog, "projScale", k.proj_scale);
        glh_set1f(g, prog, "radius", k.radius);
        glh_set1f(g, prog, "radius2", k.radius2);
        glh_set1f(g, prog, "bias", k.bias);
        glh_set1f(g, prog, "epsilon", k.epsilon);
        glh_set1f(g, prog, "intensityScale", k.intensity_scale);
        glh_set1f(g, prog, "contrast", k.contrast);
        glh_set1f(g, prog, "invNumSamples", k.inv_num_samples);
        glh_set1f(g, prog, "turnsAngle", k.turns_angle);
        const GLuint t[2] = {depth, nt};
        ok = glh_run_add(r, "alchemy AO", prog, fb, W, H, 2, t) >= 0;
        r->nkernel = r->npass;
        r->out_fbo = fb;
        r->out_w = W;
        r->out_h = H;
        r->out_rows = GLH_ROWS_FLIP;
        if (ok && k.blur)
            ok = glsl_gauss21_add(g, in, r, ao, depth, GLH_ROWS_FLIP);
    }
    if (!ok)
        printf("  alchemy: the GLSL port could not be built\n");
    return ok;
#else
    (void)g, (void)in, (void)p, (void)r;
    return 0;
#endif
}

static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_alchemy_params p = ao_alchemy_params_default();
    return glsl_alchemy_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_alchemy_params p = ao_alchemy_params_default();
    p.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st == OBS_STATUS_OK ? ao_alchemy_compute(ctx, pool, in, &p, out, NULL, NULL) : st;
}

const glsl_port glsl_port_alchemy = {"alchemy", "defaults: r 0.5 m, 12 taps, 7 turns, G-buffer normals, range check, "
                                                "21-tap Gaussian",
                                     port_build, port_kernel, glsl_gauss21_ours, NULL};
