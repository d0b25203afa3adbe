#!/usr/bin/env bash
# Allocation against a run, side by side: `clearance allocate` over a job's grid
# against `clearance run --columns minimal` of the same job, each the fastest of
# REPEAT runs, with the peak memory (GNU time). The bound: allocate ≤ 3 × run.
#
#   bash scripts/bench_allocate.sh [BIN] [JOB] [REPEAT]
#
# defaults: target/release/clearance, jobs/fig06_all_kinds.toml (201 × 201), 5.
set -euo pipefail
bin=${1:-target/release/clearance}
job=${2:-jobs/fig06_all_kinds.toml}
repeat=${3:-5}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
best() { sort -g | head -1; }
for i in $(seq "$repeat"); do
  /usr/bin/time -f "%e %M" -o "$tmp/run.$i" "$bin" run "$job" --out "$tmp/run" --overwrite --quiet --columns minimal
  /usr/bin/time -f "%e %M" -o "$tmp/alloc.$i" "$bin" allocate "$job" --max-dp 1e-4 --json --quiet > /dev/null
done
run_s=$(cat "$tmp"/run.* | awk '{print $1}' | best)
alloc_s=$(cat "$tmp"/alloc.* | awk '{print $1}' | best)
run_kb=$(cat "$tmp"/run.* | awk '{print $2}' | sort -g | tail -1)
alloc_kb=$(cat "$tmp"/alloc.* | awk '{print $2}' | sort -g | tail -1)
echo "job $job, fastest of $repeat"
echo "run --columns minimal: ${run_s} s, peak ${run_kb} KB"
echo "allocate --max-dp 1e-4: ${alloc_s} s, peak ${alloc_kb} KB"
awk -v a="$alloc_s" -v r="$run_s" 'BEGIN { printf "ratio allocate / run: %.2f\n", a / r }'
