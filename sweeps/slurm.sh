#!/usr/bin/env bash
# The example sweep (sweeps/example.toml, 36 runs) as a SLURM job array: 4 tasks, each runs one
# shard of the matrix on the CPUs it was given and writes its own directory; a second job, which
# waits for the array, merges the shards. From the repository root, drive-sim on PATH:
#
#   jid=$(sbatch --parsable sweeps/slurm.sh)
#   sbatch --dependency=afterok:$jid --wrap 'drive-sim sweep-merge runs/example/shard-* --out runs/example/merged'
#
#   MATRIX=my.toml OUT=/scratch/me/sweep KEEP_LOGS=1 sbatch --array=0-9 sweeps/slurm.sh
#
# drive-sim reads its shard from SLURM_ARRAY_TASK_ID / _MIN / _STEP / _COUNT (any --array range
# works, e.g. 1-8 or 0-15:2) and prints which it used. A task that is requeued resumes: runs
# already complete in its directory are skipped. The merge reports runs missing (e.g. of a
# failed task) and runs done twice.
#
#SBATCH --job-name=drive-sim-sweep
#SBATCH --array=0-3
#SBATCH --cpus-per-task=4
#SBATCH --mem-per-cpu=500M
#SBATCH --time=01:00:00
#SBATCH --output=drive-sim-sweep-%A_%a.out
set -euo pipefail

MATRIX=${MATRIX:-sweeps/example.toml}
OUT=${OUT:-runs/example}
DRIVE_SIM=${DRIVE_SIM:-drive-sim}

if [[ -z "${SLURM_ARRAY_TASK_ID:-}" ]]; then
    echo "slurm.sh: not in a SLURM job array (SLURM_ARRAY_TASK_ID unset); submit it with sbatch" >&2
    exit 2
fi

# One directory per task: shards never write the same files.
"$DRIVE_SIM" sweep "$MATRIX" --out "$OUT/shard-$SLURM_ARRAY_TASK_ID" \
    --threads "${SLURM_CPUS_PER_TASK:-1}" ${KEEP_LOGS:+--keep-logs}
