/* scale_mpi_stub.c: the MPI adapter of a build without OBS_WITH_MPI: every entry point says so. */
#include "scale.h"

#define NOT_BUILT "MPI support is not built (configure with -DOBS_WITH_MPI=ON and OpenMPI installed: " \
                  "libopenmpi-dev, openmpi-bin; docs/scale.md)"

int scale_mpi_built(void) { return 0; }

obs_status scale_mpi_init(obs_context *ctx, int *argc, char ***argv, scale_comm **out)
{
    (void)argc, (void)argv;
    if (out)
        *out = NULL;
    return obs_error(ctx, OBS_STATUS_UNSUPPORTED, NOT_BUILT);
}

int scale_comm_rank(const scale_comm *c) { (void)c; return 0; }
int scale_comm_size(const scale_comm *c) { (void)c; return 1; }
void scale_mpi_finalize(scale_comm *c) { (void)c; }
void scale_mpi_abort(scale_comm *c, int code) { (void)c, (void)code; }

obs_status scale_mpi_agree(obs_context *ctx, scale_comm *c, obs_status local)
{
    (void)ctx, (void)c;
    return local;
}

obs_status scale_mpi_gather_ao(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                               int tile, truth_ao_result *res, scale_rank_stats *per_rank)
{
    (void)c, (void)owner, (void)cost, (void)ntasks, (void)tile, (void)res, (void)per_rank;
    return obs_error(ctx, OBS_STATUS_UNSUPPORTED, NOT_BUILT);
}

obs_status scale_mpi_gather_sss(obs_context *ctx, scale_comm *c, const int *owner, const double *cost, int64_t ntasks,
                                int tile, truth_sss_result *res, scale_rank_stats *per_rank)
{
    (void)c, (void)owner, (void)cost, (void)ntasks, (void)tile, (void)res, (void)per_rank;
    return obs_error(ctx, OBS_STATUS_UNSUPPORTED, NOT_BUILT);
}

obs_status scale_mpi_gather_volume_slices(obs_context *ctx, scale_comm *c, const int *owner, int nz,
                                          int64_t slice_floats, float *T, float *err, double seconds,
                                          double *per_rank_seconds)
{
    (void)c, (void)owner, (void)nz, (void)slice_floats, (void)T, (void)err, (void)seconds, (void)per_rank_seconds;
    return obs_error(ctx, OBS_STATUS_UNSUPPORTED, NOT_BUILT);
}

obs_status scale_mpi_gather_volume_image(obs_context *ctx, scale_comm *c, const int *owner, const double *cost,
                                         int64_t ntasks, int tile, truth_volume_image *im,
                                         scale_rank_stats *per_rank)
{
    (void)c, (void)owner, (void)cost, (void)ntasks, (void)tile, (void)im, (void)per_rank;
    return obs_error(ctx, OBS_STATUS_UNSUPPORTED, NOT_BUILT);
}
