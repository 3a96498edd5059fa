/* study_volume.h: the volume-lighting study (prefix study_volume_): what Ropinski's light volume
 * [Ropinski10] and the ray caster cost in time and how far they are from two references (issue 15,
 * item 10). The shape of docs/study.md, "The shape of a study":
 *
 *   1. axes: dataset (bucky synthetic 32^3, the head CT "cranium", the MRI "mri"; a dataset whose
 *      file is absent under volume_dir is skipped and the report says so), light-volume scale
 *      (1, 1/2, 1/4 of the data), cone angle, dir_blend on/off, ray-caster step (a fraction of the
 *      smallest spacing);
 *   2. the run function: the light-volume build and the ray casting (light-volume mode), each timed
 *      (median, min, max of `runs` runs): "scene change" = build + cast, "fixed scene" = cast (the
 *      seed's Table 5.4 layout); per dataset also the emission-absorption and gradient-Phong casts;
 *   3. the error functions: the light volume's l against the exact transmittance
 *      (truth_volume_transmittance_at, on a lattice of at most l_voxels voxels), and the final image
 *      against the Monte Carlo single-scattering reference (truth_volume_mc_render): RMSE over the
 *      pixels either image covers, the reference's noise taken out (study_noise_corrected, its
 *      replicate s^2), the bias, the relative RMSE; and the same for the image cast with c forced to
 *      1 (the part of the light volume that has a ground truth: docs/volume/truth.md);
 *   4. the references, computed once per dataset (fixed count, 8 replicates, seed 0);
 *   5. the report: README.md with the tables, an SVG of error against time, results.csv.
 *
 * Threads: an optional obs_pool (NULL = the caller's thread); times depend on it, errors do not. */
#ifndef STUDY_VOLUME_H
#define STUDY_VOLUME_H

#include "study.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Defaults (issue 15 item 10; the values are ours). */
#define STUDY_VOLUME_DEFAULT_DATASETS "bucky,cranium,mri"
#define STUDY_VOLUME_DEFAULT_SCALES "1,2,4"
#define STUDY_VOLUME_DEFAULT_CONES "22.5,45,67.5"
#define STUDY_VOLUME_DEFAULT_BLENDS "0,1"
#define STUDY_VOLUME_DEFAULT_STEPS "0.25,0.5,1"
#define STUDY_VOLUME_DEFAULT_SIZE "256x256"
#define STUDY_VOLUME_DEFAULT_RUNS 3
#define STUDY_VOLUME_DEFAULT_REF_SAMPLES 256
#define STUDY_VOLUME_DEFAULT_L_VOXELS 32768
#define STUDY_VOLUME_DEFAULT_T_STEP 0.0625      /* truth_volume_params_default's step fraction */
/* --quick (CI, seconds): bucky, the three scales, one cone, blend on and off, one step, 64x64 */
#define STUDY_VOLUME_QUICK_DATASETS "bucky"
#define STUDY_VOLUME_QUICK_CONES "45"
#define STUDY_VOLUME_QUICK_STEPS "0.5"
#define STUDY_VOLUME_QUICK_SIZE "64x64"
#define STUDY_VOLUME_QUICK_RUNS 1
#define STUDY_VOLUME_QUICK_REF_SAMPLES 128
#define STUDY_VOLUME_QUICK_T_STEP 0.25

typedef struct study_volume_options {
    const char *out_dir;            /* results.csv, results.json */
    const char *report_dir;         /* NULL: no report */
    const char *volume_dir;         /* cranium.nrrd, ch2better.nii.gz (scripts/fetch_volumes.sh);
                                       default "data/cache/volumes" */
    const char *datasets;           /* bucky, cranium, mri */
    const char *scales;             /* 1, 2, 4 */
    const char *cones;              /* degrees, (0, 80] */
    const char *blends;             /* 0, 1 */
    const char *steps;              /* ray-caster step / smallest spacing, (0, 4] */
    const char *size;               /* image "WxH" */
    int runs;                       /* timed runs per stage, [1, 64] */
    long long ref_samples;          /* MC samples per pixel, a multiple of 8 in [8, 2^20] */
    long long l_voxels;             /* most light-volume voxels scored against the exact
                                       transmittance (a regular lattice beyond), >= 1 */
    double t_step;                  /* exact transmittance march step / smallest spacing, (0, 1] */
    int quick;                      /* the options came from _quick (the report says so) */
    const char *command_line;       /* the command that ran, quoted in the report; NULL = omitted */
    FILE *log;                      /* progress; NULL = silent */
    /* The hybrid stage (the seed's Table 5.5; docs/volume/truth.md, "The study"): the bundled scene
     * cornell_hybrid.glb rendered through a render_session for (bucky | cranium) x (dragon | bunny),
     * written to OUT/hybrid.csv (its own table: results.csv keeps its columns and keys). */
    const char *data_dir;           /* cornell_hybrid.glb, dragon.glb (mkdata); default the build's data */
    int no_hybrid;                  /* 1: skip the hybrid stage; default 0 (on) */
} study_volume_options;

study_volume_options study_volume_options_default(void);
study_volume_options study_volume_options_quick(void);

typedef struct study_volume study_volume;

/* Validate o, split its axes, read OUT/results.csv (resume). INVALID_ARGUMENT names a bad option;
 * PARSE_ERROR, IO_ERROR, OUT_OF_MEMORY. */
obs_status study_volume_open(obs_context *ctx, const study_volume_options *o, study_volume **out);
void study_volume_close(study_volume *s);
const study_table *study_volume_table(const study_volume *s);

/* Points of the grid (light-volume points + 2 per dataset for ea and phong) and how many datasets
 * are present. */
int64_t study_volume_points(const study_volume *s, int *datasets_present);

/* Measure every point not yet in the table (a dataset whose points are all there is not even
 * loaded); the table is written after each dataset and at the end (even after an error). */
obs_status study_volume_sweep(obs_context *ctx, obs_pool *pool, study_volume *s);
/* REPORT/README.md, REPORT/error_vs_time.svg, REPORT/results.csv. INVALID_ARGUMENT without report_dir. */
obs_status study_volume_report(obs_context *ctx, study_volume *s);

/* The hybrid stage's table (OUT/hybrid.csv, REPORT/hybrid.csv): key volume, mesh. */
const study_table *study_volume_hybrid_table(const study_volume *s);
extern const char *const study_volume_hybrid_columns[];
extern const int study_volume_hybrid_column_count;

extern const char *const study_volume_columns[];
extern const int study_volume_column_count;
#define STUDY_VOLUME_KEY_COLUMNS 6  /* dataset, method, scale, cone, blend, step */

#ifdef __cplusplus
}
#endif

#endif
