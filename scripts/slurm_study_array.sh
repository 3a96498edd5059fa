#!/usr/bin/env bash
# slurm_study_array.sh: the AO study as a Slurm array job (docs/scale.md, "A study as an array job").
#   sbatch --array=1-16 scripts/slurm_study_array.sh            # 16 shards; any number works
#   ...when all are done:
#   build/obscura study merge $OUT/shard-*-of-16 -o $OUT/merged --report $OUT/merged/report
# Each task runs shard K of N (K and N from SLURM_ARRAY_TASK_ID, _MIN and _COUNT: obscura reads them
# itself) into $OUT/shard-K-of-N, and shares the ground-truth cache $OUT/gt with the other tasks
# (a lock per frame: each ground truth is computed once). $OUT must be on a file system every node
# sees (NFS, Lustre, GPFS). A task that fails can be resubmitted alone (sbatch --array=7 ...): it
# resumes from its table.
#SBATCH --job-name=obscura-study-ao
#SBATCH --nodes=1
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=8          # the thread pool of one shard (obscura --threads)
#SBATCH --mem=8G                   # docs/scale.md, "Memory": 4K frames of the dragon need about 3 GiB
#SBATCH --exclusive                # the study times its points: do not share the node
#SBATCH --time=04:00:00
#SBATCH --output=obscura-study-%A_%a.log
set -euo pipefail

OBSCURA=${OBSCURA:-build/obscura}
OUT=${OUT:-out/study-ao}
# the axes: every shard must get the same ones (the merge refuses other configurations)
AXES=${AXES:-}

exec "$OBSCURA" --threads "${SLURM_CPUS_PER_TASK:-0}" study ao -o "$OUT" $AXES
