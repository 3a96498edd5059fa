/* scale.h: the public header of obscura's scale-out module (prefix scale_; docs/scale.md).
 *
 * Two parts:
 *   - dealing an image's tasks over ranks, and combining statistics (scale_deal.c; plain C, always
 *     built, no MPI): used by the MPI adapter and testable without it;
 *   - the MPI adapter (scale_mpi.c, built with OBS_WITH_MPI; scale_mpi_stub.c otherwise, whose
 *     functions return OBS_STATUS_UNSUPPORTED "MPI support is not built"). MPI stays out of
 *     libobscura: only this module (library obscura_scale) links it, and the command calls it.
 *
 * Determinism: a truth_ao pixel depends on (inputs, params, seed) only, never on which rank or
 * thread computes it (truth.h, truth_ao_render_tasks), so rank 0's gathered image is the single
 * process's bit for bit, for any number of ranks and any dealing. */
#ifndef SCALE_H
#define SCALE_H

#include "../core/obs.h"
#include "../truth/truth.h"

#ifdef __cplusplus
extern "C" {
#endif

struct rast_gbuffer; /* raster/raster.h */

/* ---- dealing (scale_deal.c) ------------------------------------------------------------------ */

/* Relative cost of a background pixel against a surface pixel in the task cost estimate: a
 * background pixel only has its output written, a surface pixel traces at least min_samples rays
 * (64 by default, in batches of 16). 1/64 is a rough figure, not measured: it only breaks ties
 * between background tasks, which the balance does not depend on (docs/scale.md, "Balance"). */
#define SCALE_BACKGROUND_COST (1.0 / 64.0)

/* The estimated cost of each of the ntasks = truth_ao_task_count(W, H, tile) tasks of gb's inner
 * image: its surface pixels (finite depth > 0) + SCALE_BACKGROUND_COST per other pixel. For an
 * Embree origin (no G-buffer depth trusted) pass gb anyway: its depth is the rasterizer's.
 * cost[] holds ntasks doubles. Returns OK or INVALID_ARGUMENT (NULL, gb without depth, a size
 * mismatch). */
obs_status scale_ao_task_costs(obs_context *ctx, const struct rast_gbuffer *gb, int tile, double *cost,
                               int64_t ntasks);

/* The estimated cost of each of the ntasks = truth_sss_task_count(W, H, tile) tasks of gb's inner
 * image for truth_sss: its translucent surface pixels (finite depth, an instance of `scene` whose
 * material is translucent in mats: the pixels truth_sss estimates, less the few it skips as seen
 * from inside) + SCALE_BACKGROUND_COST per other pixel (background, opaque: written, not
 * estimated). gb needs depth and instance ids. Returns OK or INVALID_ARGUMENT (NULL, a missing
 * plane, a size mismatch). */
obs_status scale_sss_task_costs(obs_context *ctx, const struct rast_gbuffer *gb, const obs_scene *scene,
                                const sss_scene_materials *mats, int tile, double *cost, int64_t ntasks);

/* Deal ntasks tasks over nranks ranks: tasks taken in index order, each to the rank with the least
 * estimated cost so far (ties to the lowest rank): neighbouring tasks, whose true costs are alike,
 * go to different ranks, and every rank's total estimate is within one task's cost of the others'.
 * Deterministic (a function of cost[] and nranks only). owner[] holds ntasks ints.
 * Returns OK or INVALID_ARGUMENT (NULL, nranks < 1, ntasks < 0, a cost < 0 or not finite). */
obs_status scale_deal_tasks(obs_context *ctx, const double *cost, int64_t ntasks, int nranks, int *owner);

/* max(v) / mean(v) - 1 over n >= 1 values (0 when the mean is 0): how much longer the slowest
 * rank is than the mean. */
double scale_imbalance(const double *v, int n);

/* Floats of task rectangles owned by `rank`, per plane (mean, std_error, count each this many). */
int64_t scale_ao_rank_pixels(int width, int height, int tile, const int *owner, int64_t ntasks, int rank);

/* ---- MPI (scale_mpi.c, or the stub) ------------------------------------------------------------ */

typedef struct scale_comm scale_comm;

/* 1 when this build has MPI (OBS_WITH_MPI), else 0. */
int scale_mpi_built(void);
/* 1 when the environment says the process was started by an MPI launcher (OpenMPI's mpirun:
 * OMPI_COMM_WORLD_SIZE; PMIx/PMI launchers such as srun --mpi: PMIX_RANK, PMI_SIZE), unless
 * OBS_NO_MPI=1 is set. Needs no MPI library. */
int scale_mpi_launched(void);

/* Initialise MPI (MPI_Init_thread, MPI_THREAD_FUNNELED: only the calling thread talks to MPI;
 * the worker pool does not). *out allocated here; scale_mpi_finalize ends MPI and frees it.
 * Returns OK; UNSUPPORTED "MPI support is not built" in a build without OBS_WITH_MPI; INTERNAL when
 * MPI fails to start. */
obs_status scale_mpi_init(obs_context *ctx, int *argc, char ***argv, scale_comm **out);
int scale_comm_rank(const scale_comm *c);
int scale_comm_size(const scale_comm *c);
void scale_mpi_finalize(scale_comm *c); /* NULL-safe */
/* End the whole job now (MPI_Abort) with exit code `code`, for a failure the other ranks cannot
 * hear of through scale_mpi_agree. NULL-safe: does nothing without a communicator. */
void scale_mpi_abort(scale_comm *c, int code);

/* Collective: every rank passes its own status (and on failure its context's message). Returns OK
 * on every rank when every rank is OK; otherwise, on every rank, the status of the lowest failing
 * rank, with ctx's error replaced by "rank K of N failed: <its message>" (the other failures are
 * counted in it). */
obs_status scale_mpi_agree(obs_context *ctx, scale_comm *c, obs_status local);

/* Test hook (docs/scale.md, "Testing failures"): with OBS_SCALE_FAULT=kill:K in the environment,
 * rank K kills itself with SIGKILL here; with fail:K, rank K returns INTERNAL "injected failure".
 * Otherwise returns `st`. */
obs_status scale_fault_point(obs_context *ctx, const scale_comm *c, obs_status st);

/* Per-rank figures gathered on rank 0 (for the sidecar), arrays of scale_comm_size entries. */
typedef struct scale_rank_stats {
    uint64_t rays;          /* AO rays the rank traced */
    int64_t tasks;          /* tasks dealt to it */
    double cost_estimate;   /* their estimated cost (scale_ao_task_costs) */
    double seconds_work;    /* its truth_ao stats' seconds_work */
} scale_rank_stats;

/* Collective: put the ranks' truth_ao_render_tasks results (res, each rank's own tasks as dealt by
 * owner[]) together on rank 0: rank 0's res then holds every pixel and the combined stats (sums of
 * the counters, maxima of max_std_error, max_offset and seconds_work; seconds the rank 0 call's).
 * cost[] the estimates (for the per-rank figures); per_rank (rank 0 only, may be NULL) receives
 * scale_comm_size entries. Other ranks' res is left as it was. Returns OK, OUT_OF_MEMORY, INTERNAL
 * (an MPI error; MPI's default handler aborts the job first). */
obs_status scale_mpi_gather_ao(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                               int tile, truth_ao_result *res, scale_rank_stats *per_rank);

/* Collective, as scale_mpi_gather_ao for a truth_sss_render_tasks result (tasks
 * truth_sss_task_rect of `tile`): rank 0's res then holds every pixel of the seven planes
 * (radiance, std_error, count) and the summed stats (seconds: the maximum over the ranks).
 * per_rank's rays are Embree rays, seconds_work each rank's stats.seconds. Returns as
 * scale_mpi_gather_ao. */
obs_status scale_mpi_gather_sss(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                                int tile, truth_sss_result *res, scale_rank_stats *per_rank);

/* Collective, for truth volume's light-volume error (truth_volume_light_error_slices): slice k
 * (slice_floats = nx*ny floats of T and of err, x fastest) was computed by rank owner[k]; rank 0's
 * T and err then hold every slice. Other ranks' arrays are left as they were. `seconds` is this
 * rank's time for its slices; per_rank_seconds (rank 0 only, may be NULL) receives every rank's
 * (scale_comm_size entries). nz 0 gathers the seconds only. Returns OK or INTERNAL (an MPI error). */
obs_status scale_mpi_gather_volume_slices(obs_context *ctx, scale_comm *c, const int *owner, int nz,
                                          int64_t slice_floats, float *T, float *err, double seconds,
                                          double *per_rank_seconds);

/* Collective, as scale_mpi_gather_ao for a truth_volume_mc_render_tasks image (tasks
 * truth_volume_mc_task_rect of `tile`): rank 0's im then holds every pixel of the eight planes and
 * the combined stats (sums of the counters, maximum of max_std_error; seconds: the maximum over the
 * ranks). per_rank's rays are real collisions (shadow rays), seconds_work each rank's
 * stats.seconds. Returns as scale_mpi_gather_ao. */
obs_status scale_mpi_gather_volume_image(obs_context *ctx, scale_comm *c, const int *owner, const double *cost,
                                         int64_t ntasks, int tile, truth_volume_image *im,
                                         scale_rank_stats *per_rank);

#ifdef __cplusplus
}
#endif

#endif
