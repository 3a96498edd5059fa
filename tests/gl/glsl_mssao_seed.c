/* glsl_mssao_seed.c: the seed thesis' multi-resolution Alchemy AO (ssao-thesis-2017 section 4.2.2.3,
 * docs/ao/mssao-seed.md) as fragment passes: per level l = 0..4 (sizes max(1, W >> l), Figura 30's
 * glViewport), the level's G-buffer (point-sampled from the full one, as our kernel documents in place
 * of the thesis' re-render), the Alchemy AO pass at the level, the seed's 21-tap separable Gaussian
 * (Figura 31; horizontal then vertical), and the blend of Figura 33 over the window:
 * V = clamp(1 - sum_l I_l (1 - texture(level_l, vUV)), 0, 1) with GL_LINEAR, CLAMP_TO_EDGE.
 *
 * The Alchemy pass is our kernel's estimator as docs/ao/alchemy.md states it ([McGuire11] section 3,
 * with the HPG12 SAO_AO.pix hash, spiral tapLocation and falloff-A range check), the Gaussian the
 * Movania/seed loop c += kernel[10 - i] * tap(i) (docs/ao/blur.md, glsl_gauss21.h), both written here from those
 * pages for the level textures (the same text as an Alchemy port would carry; kept local so that the
 * levels read the pyramid's textures). Uniforms: ao_alchemy_constants_from_params for each level's
 * input (the pixel model scaled by w_l / W, h_l / H as level_make does), ao_gauss21_kernel, the
 * params' level intensities. All level planes are in GL rows (row 0 = bottom).
 *
 * Our documented choices followed: the level G-buffer by point sampling
 * (ao_mssao_seed_level_source's integer rule), background (depth not > 0; non-finite uploaded as 0)
 * gives visibility 1 and taps on it are skipped, a degenerate normal gives 1, the blend's meaning
 * (obscurance as alpha) and its clamp. Not ported: normals from depth (the levels would need
 * ao_normals_from_depth as a pass) and orthographic cameras: glsl_mssao_seed_build refuses them. */
#include "gl/glsl_gauss21.h"
#include "gl/glsl_ports.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if GLH_AVAILABLE

/* ---- a level's G-buffer: (depth, normal) of the full GL pixel holding the level pixel's centre ---- */
static const char *const fs_level_gbuffer =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D fullGbuf; uniform ivec2 FullSize;\n"
    "layout(location=0) out vec4 o;\n"
    "void main() {\n"
    "  ivec2 s = ivec2(gl_FragCoord.xy), lsz = ivec2(textureSize(fullGbuf, 0)); /* unused */\n"
    "  ivec2 wh = ivec2(LEVEL_W, LEVEL_H);\n"
    "  ivec2 f = ((2 * s + 1) * FullSize) / (2 * wh); /* the centre (i + 0.5) W / w, floored, exactly */\n"
    "  o = texelFetch(fullGbuf, min(f, FullSize - 1), 0);\n"
    "}\n";

/* ---- Alchemy AO at a level ([McGuire11] estimator; SAO_AO.pix hash, tapLocation, range check) ---- */
static const char *const fs_alchemy =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D gbuf; /* (depth, normal), GL rows */\n"
    "uniform vec4 projInfo; uniform float projScale; uniform float radius; uniform float radius2;\n"
    "uniform float bias; uniform float intensityScale; uniform float contrast; uniform float epsilon;\n"
    "uniform float invNumSamples; uniform float turnsAngle; uniform int rangeCheck;\n"
    "layout(location=0) out vec4 o;\n"
    "vec3 csPos(ivec2 s, float z) { return vec3((vec2(s) + vec2(0.5)) * projInfo.xy + projInfo.zw, 1.0) * z; }\n"
    "void main() {\n"
    "  ivec2 ssC = ivec2(gl_FragCoord.xy); ivec2 last = textureSize(gbuf, 0) - 1;\n"
    "  vec4 g = texelFetch(gbuf, ssC, 0);\n"
    "  if (!(g.x > 0.0)) { o = vec4(1.0); return; } /* background */\n"
    "  float zC = -g.x; vec3 C = csPos(ssC, zC);\n"
    "  float l2 = dot(g.yzw, g.yzw);\n"
    "  if (!(l2 > 0.0) || isinf(l2)) { o = vec4(1.0); return; } /* degenerate normal */\n"
    "  vec3 n = g.yzw * (1.0 / sqrt(l2));\n"
    "  float randomPatternRotationAngle = float((3 * ssC.x ^ ssC.y + ssC.x * ssC.y) * 10);\n"
    "  float ssDiskRadius = (-projScale * radius) / zC;\n"
    "  float zb = zC * bias;\n"
    "  float sum = 0.0;\n"
    "  for (int i = 0; i < NUM_SAMPLES; ++i) {\n"
    "    float alpha = (float(i) + 0.5) * invNumSamples;\n"
    "    float angle = alpha * turnsAngle + randomPatternRotationAngle;\n"
    "    float ssR = alpha * ssDiskRadius;\n"
    "    ivec2 ssP = clamp(ivec2(ssR * vec2(cos(angle), sin(angle))) + ssC, ivec2(0), last);\n"
    "    float dq = texelFetch(gbuf, ssP, 0).x;\n"
    "    if (!(dq > 0.0)) continue; /* background tap: a point at infinity (docs/ao/alchemy.md) */\n"
    "    vec3 v = csPos(ssP, -dq) - C;\n"
    "    float vv = dot(v, v); float vn = dot(v, n);\n"
    "    if (rangeCheck != 0 && !(vv < radius2)) continue;\n"
    "    sum += max(0.0, vn + zb) / (vv + epsilon);\n"
    "  }\n"
    "  float A = max(0.0, 1.0 - intensityScale * sum);\n"
    "  if (contrast != 1.0) A = pow(A, contrast);\n"
    "  o = vec4(clamp(A, 0.0, 1.0));\n"
    "}\n";

/* ---- Figura 33's blend over the window (vUV of the full-screen quad over the full buffer) ---- */
static const char *const fs_blend =
    "#version 450\n"
    "layout(binding=0) uniform sampler2D tex1; layout(binding=1) uniform sampler2D tex2;\n"
    "layout(binding=2) uniform sampler2D tex3; layout(binding=3) uniform sampler2D tex4;\n"
    "layout(binding=4) uniform sampler2D tex5; layout(binding=5) uniform sampler2D fullGbuf;\n"
    "uniform float intensidadTex[5]; uniform ivec2 Origin; uniform vec2 FullSize;\n"
    "layout(location=0) out vec4 o;\n"
    "void main() {\n"
    "  ivec2 p = ivec2(gl_FragCoord.xy) + Origin;\n"
    "  if (!(texelFetch(fullGbuf, p, 0).x > 0.0)) { o = vec4(1.0); return; } /* background keeps 1 */\n"
    "  vec2 vUV = (vec2(p) + 0.5) / FullSize;\n"
    "  float mixText = intensidadTex[0] * (1.0 - texture(tex1, vUV).x);\n"
    "  mixText += intensidadTex[1] * (1.0 - texture(tex2, vUV).x);\n"
    "  mixText += intensidadTex[2] * (1.0 - texture(tex3, vUV).x);\n"
    "  mixText += intensidadTex[3] * (1.0 - texture(tex4, vUV).x);\n"
    "  mixText += intensidadTex[4] * (1.0 - texture(tex5, vUV).x);\n"
    "  o = vec4(clamp(1.0 - mixText, 0.0, 1.0)); /* obscurance as alpha, saturating (our reading) */\n"
    "}\n";

static GLuint seed_target(glh *g, glh_run *r, int w, int h, GLenum fmt, GLenum filter, GLuint *fbo)
{
    GLuint t = glh_run_own_texture(r, glh_texture(g, w, h, 1, fmt, fmt == GL_R32F ? 1 : 4, NULL, GLH_ROWS_AS_IS,
                                                  filter, GL_CLAMP_TO_EDGE));
    *fbo = t ? glh_run_own_fbo(r, glh_framebuffer(g, t, 0)) : 0;
    return *fbo ? t : 0;
}

int glsl_mssao_seed_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_seed_params *p, glh_run *r)
{
    memset(r, 0, sizeof *r);
    if (ao_input_validate(ctx, in) != OBS_STATUS_OK || ao_mssao_seed_params_validate(ctx, p) != OBS_STATUS_OK) {
        printf("  mssao-seed port: %s\n", obs_context_last_error(ctx));
        return 0;
    }
    const ao_alchemy_params *ap = &p->alchemy;
    if (in->projection != OBS_PROJECTION_PERSPECTIVE || !in->normal[0] || ap->normals == AO_ALCHEMY_NORMALS_DEPTH) {
        printf("  mssao-seed port: orthographic cameras and normals from depth are not ported\n");
        return 0;
    }
    const int W = in->width, H = in->height, NL = AO_MSSAO_SEED_LEVELS;
    /* ---- the full G-buffer, (depth, normal) in GL rows, non-finite depth as 0 ---- */
    float *buf = malloc(sizeof(float) * 4 * (size_t)W * (size_t)H);
    if (!buf)
        return 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float *t = buf + 4 * ((size_t)y * W + x);
            const float d = obs_image_f32_row(in->depth, y)[x];
            t[0] = d > 0.0f && d < INFINITY ? d : 0.0f;
            for (int c = 0; c < 3; c++)
                t[1 + c] = obs_image_f32_row(in->normal[c], y)[x];
        }
    GLuint tg0 = glh_run_own_texture(r, glh_texture(g, W, H, 1, GL_RGBA32F, 4, buf, GLH_ROWS_FLIP, GL_NEAREST,
                                                    GL_CLAMP_TO_EDGE));
    free(buf);
    GLuint pgauss[2], pgb = 0, pblend;
    pblend = glh_run_own_program(r, glh_program(g, fs_blend, NULL));
    if (!tg0 || !pblend || !glsl_gauss21_programs(g, r, pgauss))
        return 0;

    GLuint gb[AO_MSSAO_SEED_LEVELS], raw[AO_MSSAO_SEED_LEVELS], tmp[AO_MSSAO_SEED_LEVELS], blr[AO_MSSAO_SEED_LEVELS];
    GLuint gbf[AO_MSSAO_SEED_LEVELS], rawf[AO_MSSAO_SEED_LEVELS], tmpf[AO_MSSAO_SEED_LEVELS], blrf[AO_MSSAO_SEED_LEVELS];
    int lw[AO_MSSAO_SEED_LEVELS], lh[AO_MSSAO_SEED_LEVELS];
    char pre[128];
    /* kernel passes: every level's G-buffer and Alchemy pass */
    for (int l = 0; l < NL; l++) {
        ao_mssao_seed_level_size(W, H, l, &lw[l], &lh[l]);
        if (l == 0) {
            gb[0] = tg0;
        } else {
            snprintf(pre, sizeof pre, "#define LEVEL_W %d\n#define LEVEL_H %d\n", lw[l], lh[l]);
            pgb = glh_run_own_program(r, glh_program(g, fs_level_gbuffer, pre));
            gb[l] = seed_target(g, r, lw[l], lh[l], GL_RGBA32F, GL_NEAREST, &gbf[l]);
            if (!pgb || !gb[l])
                return 0;
            glh_set2i(g, pgb, "FullSize", W, H);
            glh_run_add(r, "mssao-seed level gbuffer", pgb, gbf[l], lw[l], lh[l], 1, &tg0);
        }
        /* the level's input as level_make builds it: the pixel model scaled by w_l / W, h_l / H */
        ao_input li = *in;
        li.width = li.w = lw[l];
        li.height = li.h = lh[l];
        li.x0 = li.y0 = 0;
        const double sx = (double)lw[l] / W, sy = (double)lh[l] / H;
        li.fx = in->fx * sx;
        li.cx = in->cx * sx;
        li.fy = in->fy * sy;
        li.cy = in->cy * sy;
        const ao_alchemy_constants k = ao_alchemy_constants_from_params(ap, &li);
        snprintf(pre, sizeof pre, "#define NUM_SAMPLES %d\n", k.num_samples);
        GLuint pa = glh_run_own_program(r, glh_program(g, fs_alchemy, pre));
        raw[l] = seed_target(g, r, lw[l], lh[l], GL_R32F, GL_LINEAR, &rawf[l]);
        if (!pa || !raw[l])
            return 0;
        glh_set4f(g, pa, "projInfo", k.proj_info[0], k.proj_info[1], k.proj_info[2], k.proj_info[3]);
        glh_set1f(g, pa, "projScale", k.proj_scale);
        glh_set1f(g, pa, "radius", k.radius);
        glh_set1f(g, pa, "radius2", k.radius2);
        glh_set1f(g, pa, "bias", k.bias);
        glh_set1f(g, pa, "intensityScale", k.intensity_scale);
        glh_set1f(g, pa, "contrast", k.contrast);
        glh_set1f(g, pa, "epsilon", k.epsilon);
        glh_set1f(g, pa, "invNumSamples", k.inv_num_samples);
        glh_set1f(g, pa, "turnsAngle", k.turns_angle);
        glh_set1i(g, pa, "rangeCheck", k.range_check);
        glh_run_add(r, "mssao-seed alchemy", pa, rawf[l], lw[l], lh[l], 1, &gb[l]);
    }
    r->nkernel = r->npass;
    /* blur passes: each level's Gaussian, then the blend */
    for (int l = 0; l < NL && ap->blur; l++) {
        tmp[l] = seed_target(g, r, lw[l], lh[l], GL_R32F, GL_NEAREST, &tmpf[l]);
        blr[l] = seed_target(g, r, lw[l], lh[l], GL_R32F, GL_LINEAR, &blrf[l]);
        if (!tmp[l] || !blr[l])
            return 0;
        glh_run_add(r, "mssao-seed gaussian h", pgauss[0], tmpf[l], lw[l], lh[l], 1, &raw[l]);
        glh_run_add(r, "mssao-seed gaussian v", pgauss[1], blrf[l], lw[l], lh[l], 1, &tmp[l]);
    }
    GLuint fout;
    GLuint tout = seed_target(g, r, in->w, in->h, GL_R32F, GL_NEAREST, &fout);
    if (!tout)
        return 0;
    glh_setfv(g, pblend, "intensidadTex", 1, NL, p->level_intensity);
    glh_set2i(g, pblend, "Origin", in->x0, H - in->y0 - in->h);
    glh_set2f(g, pblend, "FullSize", (float)W, (float)H);
    const GLuint bt[6] = {ap->blur ? blr[0] : raw[0], ap->blur ? blr[1] : raw[1], ap->blur ? blr[2] : raw[2],
                          ap->blur ? blr[3] : raw[3], ap->blur ? blr[4] : raw[4], tg0};
    glh_run_add(r, "mssao-seed blend", pblend, fout, in->w, in->h, 6, bt);
    if (!ap->blur)
        r->nkernel = r->npass;
    r->out_fbo = fout;
    r->out_w = in->w;
    r->out_h = in->h;
    r->out_rows = GLH_ROWS_FLIP;
    return 1;
}

#else
int glsl_mssao_seed_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_seed_params *p, glh_run *r)
{
    (void)g, (void)ctx, (void)in, (void)p, (void)r;
    return 0;
}
#endif

/* ---- the benchmark's view: the thesis' defaults (Tablas 3 and 25) ----
 * Two entries, because our per-level Gaussians run inside ao_mssao_seed_compute and cannot be timed
 * alone: "mssao-seed" has the levels' blurs off on both sides (five G-buffers, five Alchemy passes
 * and the blend, all kernel passes), "mssao-seed-blurred" is the thesis' default with them on (the
 * whole chain on both sides). */
static int port_build(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    ao_mssao_seed_params p = ao_mssao_seed_params_default();
    p.alchemy.blur = 0;
    return glsl_mssao_seed_build(g, ctx, in, &p, r);
}

static obs_status port_kernel(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    ao_mssao_seed_params p = ao_mssao_seed_params_default();
    p.alchemy.blur = 0;
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st != OBS_STATUS_OK ? st : ao_mssao_seed_compute(ctx, pool, in, &p, out, NULL, NULL);
}

static int port_build_blurred(glh *g, obs_context *ctx, const ao_input *in, glh_run *r)
{
    const ao_mssao_seed_params p = ao_mssao_seed_params_default();
    if (!glsl_mssao_seed_build(g, ctx, in, &p, r))
        return 0;
    r->nkernel = r->npass; /* the whole chain is this entry's "kernel" */
    return 1;
}

static obs_status port_full(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out)
{
    const ao_mssao_seed_params p = ao_mssao_seed_params_default();
    obs_status st = out->data ? OBS_STATUS_OK : obs_image_f32_alloc(ctx, in->w, in->h, out);
    return st != OBS_STATUS_OK ? st : ao_mssao_seed_compute(ctx, pool, in, &p, out, NULL, NULL);
}

const glsl_port glsl_port_mssao_seed = {"mssao-seed", "the thesis: r 2 m, 16 samples, 5 levels blended, level blurs off",
                                        port_build, port_kernel, NULL, NULL};
/* ours_blur is NULL: the Gaussians run per level before the blend, inside ao_mssao_seed_compute;
 * this entry's kernel is the whole chain on both sides */
const glsl_port glsl_port_mssao_seed_blurred = {"mssao-seed-blurred",
                                                "the thesis' default: 5 levels, each blurred, blended", port_build_blurred,
                                                port_full, NULL, NULL};
