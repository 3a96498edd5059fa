/* glsl_ports.h: GLSL ports of every AO technique's reference shader, run by the GL harness (glh.h).
 * Each port re-types its reference shader in GLSL 4.50 (the file says which source and what had to
 * be translated), takes its uniforms from our own params-to-constants step, and is checked against
 * our kernel in tests/gl/test_gl_<technique>.c; bench/gl_bench.c times it beside our kernel.
 *
 * glsl_<tech>_build(g, ctx, in, params, r): build the passes for input `in` (depth, normals and
 * intrinsics as our kernel sees them) with `params` into r: passes [0, r->nkernel) are the AO
 * kernel (including its own depth preparation, e.g. SAO's CSZ and MIP chain, as the reference
 * renders it), passes [r->nkernel, r->npass) are the technique's blur (none when params disable it).
 * Returns 1, or 0 after printing why. r->out_fbo holds the final result (the blur's when there is one).
 *
 * glsl_port: the benchmark's view of a port at the technique's defaults. */
#ifndef OBS_TESTS_GLSL_PORTS_H
#define OBS_TESTS_GLSL_PORTS_H

#include "ao/ao.h"
#include "gl/glh.h"

typedef struct glsl_port {
    const char *name;    /* technique as the CLI names it: "sao", "hbao", ... */
    const char *variant; /* the configuration timed, in words */
    /* the GLSL passes at this configuration */
    int (*build)(glh *g, obs_context *ctx, const ao_input *in, glh_run *r);
    /* our kernel alone (no blur) at the same configuration */
    obs_status (*ours_kernel)(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out);
    /* our blur alone on the kernel's output (NULL: the technique has no separate blur) */
    obs_status (*ours_blur)(obs_context *ctx, obs_pool *pool, const ao_input *in, const obs_image_f32 *kernel_out,
                            obs_image_f32 *out);
    /* our kernel with its blur, for techniques whose blur cannot run alone on a visibility plane
     * (GTAO's denoiser reads the main pass's edges; mssao-seed blurs each level before the blend):
     * the benchmark times it against all the GLSL passes (NULL: not needed) */
    obs_status (*ours_full)(obs_context *ctx, obs_pool *pool, const ao_input *in, obs_image_f32 *out);
} glsl_port;
/* Output planes: the caller passes `out` allocated at the window's size (in->w x in->h) or zeroed
 * (data == NULL), in which case the function allocates it. */

/* One per technique (and preset where presets differ in their shader), defined in glsl_<tech>.c. */
extern const glsl_port glsl_port_sao, glsl_port_hbao_classic, glsl_port_hbao_plus, glsl_port_crytek,
    glsl_port_alchemy, glsl_port_ue4, glsl_port_gtao, glsl_port_mssao, glsl_port_mssao_seed, glsl_port_mssao_seed_blurred;

int glsl_sao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_sao_params *p, glh_run *r);
int glsl_hbao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_hbao_params *p, glh_run *r);
int glsl_crytek_build(glh *g, obs_context *ctx, const ao_input *in, const ao_crytek_params *p, glh_run *r);
int glsl_alchemy_build(glh *g, obs_context *ctx, const ao_input *in, const ao_alchemy_params *p, glh_run *r);
int glsl_ue4_build(glh *g, obs_context *ctx, const ao_input *in, const ao_ue4_params *p, glh_run *r);
int glsl_gtao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_gtao_params *p, glh_run *r);
int glsl_mssao_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_params *p, glh_run *r);
int glsl_mssao_seed_build(glh *g, obs_context *ctx, const ao_input *in, const ao_mssao_seed_params *p, glh_run *r);

#endif
