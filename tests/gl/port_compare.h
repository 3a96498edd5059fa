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

/* The whole check of one case: the port was built (built), its result agrees with ours over the
 * mask within the bounds (median, p99, pixels over 1e-3). Frees r and ours. */
static inline void pc_check_port(glh *g, obs_context *ctx, int built, glh_run *r, obs_image_f32 *ours,
                                 const obs_image_f32 *mask, const char *label, double med_max, double p99_max,
                                 int over_max)
{
    CHECK_MSG(built, "%s: the port was not built", label);
    if (built) {
        const glh_diff d = pc_compare_run(g, ctx, r, ours, mask, label);
        CHECK(d.n > 1000);
        CHECK_MSG(d.median <= med_max && d.p99 <= p99_max, "%s: median %.3g / p99 %.3g too large", label, d.median,
                  d.p99);
        CHECK_MSG(d.over >= 0 && d.over <= over_max, "%s: %d pixels differ by more than 1e-3", label, d.over);
    }
    glh_run_free(g, r);
    obs_image_f32_free(ours);
}

/* The test sizes: 160 x 120 without a guard band, and an odd 161 x 91 with a 3 px guard band (the
 * window is not the buffer). cases(g, ctx, sc, first) runs one size's cases (first: 160 x 120). */
typedef void (*pc_cases_fn)(glh *g, obs_context *ctx, const pc_scene *sc, int first);
static inline void pc_run_sizes(glh *g, pc_cases_fn cases)
{
    obs_context *ctx = obs_context_create();
    const int sizes[2][3] = {{160, 120, 0}, {161, 91, 3}};
    for (int si = 0; si < 2; si++) {
        pc_scene sc;
        pc_scene_make(ctx, sizes[si][0], sizes[si][1], sizes[si][2], 1, &sc);
        cases(g, ctx, &sc, si == 0);
        pc_scene_free(&sc);
    }
    glh_close(g);
    obs_context_destroy(ctx);
}

#endif
