/* port_compare.h: what the GLSL port tests share: the scene at a test size, and one comparison of
 * our kernel's output with a port's over the surface pixels of the window (glh_compare). */
#ifndef OBS_TESTS_GL_PORT_COMPARE_H
#define OBS_TESTS_GL_PORT_COMPARE_H

#include "ao_test_util.h"
#include "gl/glsl_ports.h"
#include "test.h"

#include <stdio.h>

/* The AO tests' scene (the bumpy sphere over the ground plane, tu_ao_scene / tu_ao_camera) at
 * W x H with a guard band, its input (G-buffer normals when use_normals) and the window's surface
 * mask (the window's depth: background is not finite). */
typedef struct pc_scene {
    obs_scene s;
    rast_gbuffer gb;
    ao_input in;
    obs_image_f32 mask;
} pc_scene;

static inline void pc_scene_make(obs_context *ctx, int W, int H, int guard, int use_normals, pc_scene *sc)
{
    tu_ao_scene(&sc->s);
    CHECK_OK(tu_render_depth_normal(ctx, &sc->s, tu_ao_camera(), W, H, guard, &sc->gb), ctx);
    CHECK_OK(ao_input_from_gbuffer(ctx, &sc->gb, use_normals, &sc->in), ctx);
    CHECK_OK(obs_image_f32_alloc(ctx, sc->in.w, sc->in.h, &sc->mask), ctx);
    for (int y = 0; y < sc->in.h; y++)
        for (int x = 0; x < sc->in.w; x++)
            obs_image_f32_row(&sc->mask, y)[x] = obs_image_f32_row(sc->in.depth, sc->in.y0 + y)[sc->in.x0 + x];
}

static inline void pc_scene_free(pc_scene *sc)
{
    obs_image_f32_free(&sc->mask);
    rast_gbuffer_free(&sc->gb);
    obs_scene_free(&sc->s);
}

/* Draw r, read it, compare with ours over the mask; prints the numbers under label. */
static inline glh_diff pc_compare_run(glh *g, obs_context *ctx, glh_run *r, const obs_image_f32 *ours,
                                      const obs_image_f32 *mask, const char *label)
{
    glh_diff d = {0, 0, 0.0, 0.0, 0.0};
    glh_run_draw(g, r, 0, r->npass);
    obs_image_f32 gl;
    if (glh_run_read(g, r, ctx, &gl) != OBS_STATUS_OK) {
        d.over = -1;
        return d;
    }
    d = glh_compare(ours, &gl, mask, 1e-3f);
    printf("  %s: %d surface px, |ours - llvmpipe| median %.3g, p99 %.3g, max %.3g, > 1e-3: %d\n", label, d.n,
           d.median, d.p99, d.max, d.over);
    fflush(stdout);
    obs_image_f32_free(&gl);
    return d;
}

#endif
