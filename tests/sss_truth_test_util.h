/* sss_truth_test_util.h: the small SSS ground-truth scenes of test_truth_sss.c and
 * test_truth_sss_batch.c: one opaque material slot, translucent meshes of material -1, an
 * orthographic camera looking down, the G-buffer and the Embree scene (header-only, static). */
#ifndef OBS_TEST_SSS_TRUTH_UTIL_H
#define OBS_TEST_SSS_TRUTH_UTIL_H

#include "core/obs.h"
#include "raster/raster.h"
#include "sss/sss.h"
#include "truth/truth.h"

#include <stdio.h>
#include <stdlib.h>

typedef struct stu_run {
    obs_context *ctx;
    obs_scene scene;
    truth_scene *ts;
    obs_camera cam;
    rast_gbuffer gb;
    sss_constants c;
    uint8_t translucent[1];
    sss_scene_materials mats;
} stu_run;

/* A scene of `scene` (already filled), one opaque material slot 0, translucent meshes have
 * material -1 (mats.none = c); an orthographic camera at (0, 0, h) looking down, half size mag. */
static inline int stu_run_setup(stu_run *R, const sss_material *m, double mm_per_unit, double h, float mag, int W)
{
    R->ctx = obs_context_create();
    if (sss_constants_make(R->ctx, m, mm_per_unit, &R->c) != OBS_STATUS_OK)
        return 0;
    R->scene.materials = (obs_material *)calloc(1, sizeof(obs_material));
    R->scene.material_count = 1;
    snprintf(R->scene.materials[0].name, OBS_NAME_MAX, "opaque");
    R->translucent[0] = 0;
    R->mats.count = 1;
    R->mats.constants = &R->c; /* slot 0 is opaque: its constants are not read */
    R->mats.translucent = R->translucent;
    R->mats.none = &R->c;
    R->cam = obs_camera_look_at(obs_v3(0, 0, (float)h), obs_v3(0, 0, 0), obs_v3(0, 1, 0), 0.6f, 0.0f, 1e4f);
    R->cam.projection = OBS_PROJECTION_ORTHOGRAPHIC;
    R->cam.xmag = R->cam.ymag = mag;
    R->cam.znear = 0.0f;
    rast_params rp = rast_params_default();
    rp.width = rp.height = W;
    if (rast_gbuffer_alloc(R->ctx, &rp, &R->gb) != OBS_STATUS_OK)
        return 0;
    rast_view v = {R->cam};
    if (rast_render(R->ctx, NULL, &R->scene, &v, 1, &rp, &R->gb, NULL) != OBS_STATUS_OK)
        return 0;
    return truth_scene_create(R->ctx, &R->scene, TRUTH_BUILD_MEDIUM, &R->ts) == OBS_STATUS_OK;
}

static inline void stu_run_free(stu_run *R)
{
    truth_scene_destroy(R->ts);
    rast_gbuffer_free(&R->gb);
    obs_scene_free(&R->scene);
    obs_context_destroy(R->ctx);
}

#endif
