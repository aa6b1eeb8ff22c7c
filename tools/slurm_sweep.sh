#!/usr/bin/env bash
# A locsim sweep as a Slurm job array: each array task runs one deterministic shard; merge after.
#
#   sbatch --array=1-16 tools/slurm_sweep.sh worlds/demo/experiments/odometry_vs_ekf.yaml runs/exp
#   # when all tasks are done:
#   build/locsim merge runs/exp/merged runs/exp/shard-*
#
#SBATCH --job-name=locsim-sweep
#SBATCH --cpus-per-task=4
#SBATCH --time=02:00:00
#SBATCH --output=locsim-sweep-%A_%a.log
set -euo pipefail
experiment=$1
out=$2
locsim=${LOCSIM:-build/locsim}
k=${SLURM_ARRAY_TASK_ID:?run me with sbatch --array=1-N}
n=${SLURM_ARRAY_TASK_COUNT:?run me with sbatch --array=1-N}
# --resume makes a requeued task finish its shard instead of starting over.
resume=""
[ -f "$out/shard-$k/sweep.json" ] && resume="--resume"
exec "$locsim" sweep "$experiment" --shard "$k/$n" --jobs "${SLURM_CPUS_PER_TASK:-1}" \
  --out "$out/shard-$k" $resume
