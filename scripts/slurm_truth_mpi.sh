#!/usr/bin/env bash
# slurm_truth_mpi.sh: one large AO ground truth over MPI ranks (docs/scale.md, "One reference over MPI").
#   sbatch --nodes=4 scripts/slurm_truth_mpi.sh data/scene.glb --size 7680x4320 -o out/ref8k
# One rank per node, each with all of the node's cores as its thread pool; the ranks share the
# image's tiles (dealt by estimated cost), rank 0 gathers and writes out/ref8k.exr, .png, .json:
# byte for byte what one process would write. A failed rank fails the job; nothing is written then.
#SBATCH --job-name=obscura-truth-mpi
#SBATCH --nodes=4
#SBATCH --ntasks-per-node=1
#SBATCH --cpus-per-task=32
#SBATCH --mem=16G                  # docs/scale.md, "Memory": every rank holds the scene, its BVH,
                                   # the full G-buffer and the full result planes
#SBATCH --time=02:00:00
#SBATCH --output=obscura-truth-%j.log
set -euo pipefail

OBSCURA=${OBSCURA:-build/obscura}
# OpenMPI's mpirun takes the node list from Slurm. --bind-to none: the rank's worker threads may use
# every core Slurm gave it (the default binds a rank to one core). As root (containers) add
# --allow-run-as-root.
exec mpirun --bind-to none -np "${SLURM_NTASKS:-1}" \
  "$OBSCURA" --threads "${SLURM_CPUS_PER_TASK:-0}" truth ao "$@"
