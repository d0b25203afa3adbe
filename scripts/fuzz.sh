#!/usr/bin/env bash
# Fuzzes the job parser (fuzz/fuzz_targets/job_parser.rs) for N seconds, default 60:
#   bash scripts/fuzz.sh [seconds]
# On the stable toolchain: cargo-fuzz passes nightly-only flags (-Zsanitizer=address),
# which RUSTC_BOOTSTRAP=1 allows on stable. Installs cargo-fuzz if it is missing.
# The corpus starts from jobs/*.toml and the inputs of past crashes in fuzz/regressions/
# (run first, every time), and grows in fuzz/corpus/job_parser (not in git). A crash
# stops the run, fails the script and leaves its input in fuzz/artifacts/job_parser/:
# replay it with `RUSTC_BOOTSTRAP=1 cargo fuzz run job_parser <that file>`, and once
# fixed, add it to fuzz/regressions/ under a name that says what broke.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
export RUSTC_BOOTSTRAP=1

if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install --locked cargo-fuzz
fi

corpus=fuzz/corpus/job_parser
mkdir -p "$corpus"
cp jobs/*.toml fuzz/regressions/*.toml "$corpus/"

cargo fuzz build job_parser
# -timeout: a job the parser takes seconds over (a huge sweep, say) is a failure too.
cargo fuzz run job_parser "$corpus" -- \
    -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -dict=fuzz/job_parser.dict -print_final_stats=1
