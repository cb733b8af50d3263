#!/usr/bin/env bash
# A Slurm array job: task i of 8 runs part i/8 of the dataset (the shards s with s mod 8 == i).
# Every task writes into the same folder on a shared file system; shards are written atomically,
# so a failed or pre-empted task can simply be resubmitted (complete shards are kept).
#   sbatch examples/datasets/slurm-array.sh
#SBATCH --job-name=camsim-dataset
#SBATCH --array=0-7
#SBATCH --cpus-per-task=8
#SBATCH --mem=8G
#SBATCH --time=02:00:00
set -euo pipefail
camsim dataset examples/datasets/colorchecker.toml --out "$SCRATCH/camsim-colorchecker" \
    --shard "${SLURM_ARRAY_TASK_ID}/8" --workers "${SLURM_CPUS_PER_TASK}" --quiet
# After the last task: `camsim dataset SPEC --out DIR` once more verifies every shard and writes
# manifest.jsonl (the task that completes the set writes it too).
