/* study_sss_internal.h: what study_sss.c (options, frames, references, the sweep) shares with
 * study_sss_report.c. Not a public header. */
#ifndef STUDY_SSS_INTERNAL_H
#define STUDY_SSS_INTERNAL_H

#include "study_sss.h"
#include "../raster/raster.h"

typedef struct study_sss_i_combo {
    const char *sampler;            /* the axis' text */
    int K, N, map_size;
    int seed;                       /* 1: a point of the seed's Table 5.3 outside the grid */
} study_sss_i_combo;

struct study_sss {
    study_sss_options o;
    study_axis scenes, lights, resolutions, samplers, Ks, Ns, map_sizes;
    study_sss_i_combo *combos;      /* the (K, N, map size) of each frame's points */
    int ncombos;
    study_table table;
    char csv[4096], json[4096];
    double last_save;
    int dirty;
};

/* A scene with its material and one light (front or behind), and the camera's G-buffer. */
typedef struct study_sss_i_frame {
    obs_scene scene;                /* lights replaced by the one light */
    sss_scene_setup setup;
    obs_camera cam;
    obs_light light;
    rast_params rp;
    rast_gbuffer gb;
    obs_image_f32 mask;
    truth_scene *ts;                /* made when a reference is computed */
    uint64_t file_hash;
    double patch_radius;
    char material[64];
    int width, height;
} study_sss_i_frame;

obs_status study_sss_i_frame_render(obs_context *ctx, obs_pool *pool, const study_sss *s, const char *scene_name,
                                    const char *light, int W, int H, study_sss_i_frame *f);
void study_sss_i_frame_free(study_sss_i_frame *f);

/* A reference (cached or computed), or missing with its reason. */
typedef struct study_sss_i_ref {
    obs_image_f32 rgb[3], se[3], count;
    int missing, cached;
    double seconds;
    char reason[512];
} study_sss_i_ref;
obs_status study_sss_i_ref_get(obs_context *ctx, obs_pool *pool, const study_sss *s, const char *scene,
                               const char *light, study_sss_i_frame *f, truth_sss_estimator e, study_sss_i_ref *r);
void study_sss_i_ref_free(study_sss_i_ref *r);
void study_sss_i_ref_path(const study_sss *s, const char *scene, const char *light, const study_sss_i_frame *f,
                          truth_sss_estimator e, char *path, size_t size);

typedef struct study_sss_i_times {
    study_stats lightmaps, maps, gbuffer, combine, rebuilt, fixed;
    uint64_t bssrdf_evaluations, candidates;
} study_sss_i_times;
/* Run the pipeline `runs` times (light G-buffers, maps, camera G-buffer, combination); out
 * receives the last run's image (3 planes, allocated). */
obs_status study_sss_i_run_point(obs_context *ctx, obs_pool *pool, study_sss_i_frame *f, const sss_params *p,
                                 int runs, obs_image_f32 out[3], study_sss_i_times *t);

typedef struct study_sss_i_err {
    double rmse, rmse_nc, rel_rmse, rel_rmse_nc, mean_ratio, noise_rms, mean, gain;
    study_score score;
    int64_t pixels;
} study_sss_i_err;
/* Luminance errors of ours against r over r's pixels (count > 0). */
study_sss_i_err study_sss_i_error(const obs_image_f32 ours[3], const study_sss_i_ref *r);

#endif
