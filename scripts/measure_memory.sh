#!/usr/bin/env bash
# Peak resident memory of `clearance run` on a grid of N poses.
#
#   scripts/measure_memory.sh [N] [extra `clearance run` flags...]
#
# N defaults to 50 000 000 (the "Throughput" target: <= 1 GiB RSS for a 50M-pose run).
# The job is `clearance bench`'s: Z = 2.05, Psi, Theta in [-0.5, 0.5] on a square grid
# of ceil(sqrt(N))^2 poses, all four clearances 1e-4, kinetostatics. The run writes
# `--columns minimal` (override: CLEARANCE_COLUMNS=standard) into a temporary
# directory under /tmp that is deleted afterwards, and is measured with
# `/usr/bin/time -v` ("Maximum resident set size"). The binary is
# target/release/clearance (override: CLEARANCE_BIN=...).
# Prints: poses, seconds, poses/s, CPU seconds (user + system, all threads) and CPU
# microseconds a pose (steadier than wall time on a shared machine), peak RSS in MiB,
# output size in MiB.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
n=${1:-50000000}
shift || true
bin=${CLEARANCE_BIN:-$root/target/release/clearance}
columns=${CLEARANCE_COLUMNS:-minimal}

[[ $n =~ ^[0-9]+$ && $n -ge 4 ]] || { echo "usage: $0 [N >= 4] [clearance run flags...]" >&2; exit 2; }
[[ -x $bin ]] || { echo "$bin is missing: cargo build --release -p clearance-cli" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "/usr/bin/time is missing (apt-get install time)" >&2; exit 1; }

side=$(awk -v n="$n" 'BEGIN { s = int(sqrt(n)); while (s * s < n) s++; print s }')
poses=$((side * side))

tmp=$(mktemp -d /tmp/clearance-memory.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

cat >"$tmp/job.toml" <<JOB
name = "memory"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4
[grid]
z = 2.05
psi = { start = -0.5, stop = 0.5, n = $side }
theta = { start = -0.5, stop = 0.5, n = $side }
JOB

start=$(date +%s.%N)
/usr/bin/time -v -o "$tmp/time.txt" \
    "$bin" run "$tmp/job.toml" --out "$tmp/out" --columns "$columns" --quiet "$@"
end=$(date +%s.%N)

rss_kb=$(awk -F: '/Maximum resident set size/ { gsub(/ /, "", $2); print $2 }' "$tmp/time.txt")
cpu=$(awk -F: '/(User|System) time \(seconds\)/ { s += $2 } END { print s }' "$tmp/time.txt")
out_bytes=$(du -sb "$tmp/out" | cut -f1)
awk -v p="$poses" -v s="$side" -v t0="$start" -v t1="$end" -v kb="$rss_kb" -v ob="$out_bytes" -v c="$columns" -v cpu="$cpu" 'BEGIN {
    secs = t1 - t0
    printf "poses:         %d (%d x %d grid, --columns %s)\n", p, s, s, c
    printf "seconds:       %.1f\n", secs
    printf "poses/s:       %.0f\n", p / secs
    printf "CPU seconds:   %.2f (%.2f us a pose)\n", cpu, cpu / p * 1e6
    printf "peak RSS:      %.1f MiB\n", kb / 1024
    printf "output size:   %.1f MiB\n", ob / 1048576
}'
