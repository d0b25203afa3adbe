#!/usr/bin/env bash
# A Slurm job array that runs one clearance job in N shards into one shared directory.
#
#   sbatch --array=0-15 scripts/slurm_array.sh jobs/sweep_counterweight.toml /shared/runs/counterweight
#
# Each array task computes a deterministic, disjoint 1/N of the work (clearance reads
# SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT). The task that finishes last writes
# summary.parquet, discontinuities.parquet and _SUCCESS. A task that died can simply be
# resubmitted (`sbatch --array=7 ...`): it resumes its own shard.
#SBATCH --job-name=clearance
#SBATCH --cpus-per-task=8
#SBATCH --mem=2G
#SBATCH --time=12:00:00
#SBATCH --output=clearance-%A_%a.log
set -euo pipefail
job=${1:?usage: sbatch --array=0-N scripts/slurm_array.sh JOB.toml OUT_DIR}
out=${2:?usage: sbatch --array=0-N scripts/slurm_array.sh JOB.toml OUT_DIR}
exec clearance run "$job" --out "$out" --threads "${SLURM_CPUS_PER_TASK:-1}" --resume
