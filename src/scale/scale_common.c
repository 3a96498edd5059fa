/* scale_common.c: the parts of the MPI adapter that need no MPI (launcher detection, the fault hook). */
#include "scale.h"

#include <signal.h>
#include <stdlib.h>
#include <string.h>

int scale_mpi_launched(void)
{
    const char *no = getenv("OBS_NO_MPI");
    if (no && !strcmp(no, "1"))
        return 0;
    /* OpenMPI's mpirun sets OMPI_COMM_WORLD_SIZE; PMIx launchers (OpenMPI 4+, srun --mpi=pmix)
     * PMIX_RANK; PMI-1/2 launchers (MPICH's hydra, srun --mpi=pmi2) PMI_SIZE. Slurm's own
     * SLURM_PROCID is not used: an array job sets it without MPI. */
    return getenv("OMPI_COMM_WORLD_SIZE") != NULL || getenv("PMIX_RANK") != NULL || getenv("PMI_SIZE") != NULL;
}

obs_status scale_fault_point(obs_context *ctx, const scale_comm *c, obs_status st)
{
    const char *f = getenv("OBS_SCALE_FAULT");
    if (!f || !c)
        return st;
    const int rank = scale_comm_rank(c);
    if (!strncmp(f, "kill:", 5) && atoi(f + 5) == rank)
        raise(SIGKILL);
    if (!strncmp(f, "fail:", 5) && atoi(f + 5) == rank && st == OBS_STATUS_OK)
        return obs_error(ctx, OBS_STATUS_INTERNAL, "injected failure (OBS_SCALE_FAULT=%s)", f);
    return st;
}
