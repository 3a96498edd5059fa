/* glb_bunny.h: the scene and the comparison the crytek, alchemy and ue4 GLSL port tests share
 * (header-only, static): the Stanford bunny (build/data/bunny.glb, its "default" camera) rendered
 * by our rasterizer with normals, as an ao_input over the whole buffer; and |ours - llvmpipe| over
 * the surface pixels, printed and returned. */
#ifndef OBS_TESTS_GLB_BUNNY_H
#define OBS_TESTS_GLB_BUNNY_H

#include "ao/ao.h"
#include "gl/glh.h"
#include "io/io.h"
#include "raster/raster.h"
#include "test.h"

#include <stdio.h>
#include <string.h>

typedef struct glb_bunny {
    obs_scene scene;
    rast_gbuffer gb;
    ao_input in;
} glb_bunny;

static inline void glb_bunny_load(obs_context *ctx, glb_bunny *b)
{
    memset(b, 0, sizeof *b);
    io_gltf_options opt = io_gltf_options_default();
    CHECK_OK(io_gltf_load(ctx, test_path(test_data_dir(), "bunny.glb"), &opt, &b->scene), ctx);
}

/* Render W x H (no guard band: the window is the buffer, as a GPU pass sees it). */
static inline void glb_bunny_render(obs_context *ctx, glb_bunny *b, int W, int H)
{
    obs_camera cam = b->scene.cameras[0];
    for (uint32_t c = 0; c < b->scene.camera_count; c++)
        if (!strcmp(b->scene.cameras[c].name, "default"))
            cam = b->scene.cameras[c];
    rast_gbuffer_free(&b->gb);
    rast_params p = rast_params_default();
    p.width = W;
    p.height = H;
    p.outputs = RAST_OUT_DEPTH | RAST_OUT_NORMAL;
    CHECK_OK(rast_gbuffer_alloc(ctx, &p, &b->gb), ctx);
    rast_view v = {cam};
    CHECK_OK(rast_render(ctx, NULL, &b->scene, &v, 1, &p, &b->gb, NULL), ctx);
    CHECK_OK(ao_input_from_gbuffer(ctx, &b->gb, 1, &b->in), ctx);
}

static inline void glb_bunny_free(glb_bunny *b)
{
    rast_gbuffer_free(&b->gb);
    obs_scene_free(&b->scene);
}

/* Run r on llvmpipe, read its result, compare with ours over the surface pixels; print one line. */
static inline glh_diff glb_compare_run(glh *g, obs_context *ctx, const glh_run *r, const obs_image_f32 *ours,
                                       const ao_input *in, const char *what)
{
    glh_run_draw(g, r, 0, r->npass);
    obs_image_f32 gl = {0};
    if (glh_run_read(g, r, ctx, &gl) != OBS_STATUS_OK) {
        printf("  %s: the GL result could not be read\n", what);
        const glh_diff none = {0, 0, 1.0, 1.0, 1.0};
        return none;
    }
    const glh_diff d = glh_compare(ours, &gl, in->depth, 1e-3f);
    printf("  %s %dx%d: %d surface px, |ours - llvmpipe| median %.3g p99 %.3g max %.3g, > 1e-3: %d\n", what,
           in->width, in->height, d.n, d.median, d.p99, d.max, d.over);
    fflush(stdout);
    obs_image_f32_free(&gl);
    return d;
}

/* The bounds every port's comparison is held to (each test's comment gives its measured numbers):
 * median <= 1e-7 and p99 <= 1e-6 (float rounding: llvmpipe's pow, cos, sin against libm's), and at
 * most 0.2% of the surface pixels over 1e-3 (another Mesa's transcendentals may move a tap). */
static inline void glb_check_agreement(const glh_diff *d, const char *what)
{
    CHECK(d->n > 2000);
    CHECK_MSG(d->median <= 1e-7 && d->p99 <= 1e-6, "%s: median %g p99 %g", what, d->median, d->p99);
    CHECK_MSG(d->over <= d->n / 500, "%s: %d of %d pixels differ by more than 1e-3", what, d->over, d->n);
}

#endif
