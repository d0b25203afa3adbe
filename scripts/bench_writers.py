#!/usr/bin/env python3
"""The engine's page encoder against parquet's ArrowWriter, side by side.

Runs `clearance bench --suite --json --repeat 1` with `--writer engine` and with
`--writer arrow`, alternated ROUNDS times (engine, arrow, engine, arrow, ...), so that
both meet the same load on a shared machine, and prints for each suite job the best of
the rounds of each writer: poses/s end to end, the shares of pose pass / search /
writing of that best run, and bytes a pose. Standard library only.

    python3 scripts/bench_writers.py [--rounds 3] [--bin target/release/clearance] [-- EXTRA BENCH FLAGS]
"""

import argparse
import json
import os
import subprocess
import sys


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--bin", default=os.path.join("target", "release", "clearance"))
    p.add_argument("--json", action="store_true", help="print every run's JSON as well")
    p.add_argument("extra", nargs="*", help="more flags for `clearance bench` (after --)")
    a = p.parse_args()
    writers = ["engine", "arrow"]
    runs = {w: [] for w in writers}
    for r in range(a.rounds):
        for w in writers:
            cmd = [a.bin, "bench", "--suite", "--json", "--repeat", "1", "--writer", w] + a.extra
            out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
            runs[w].append(json.loads(out))
            print(f"round {r + 1}, {w}: done", file=sys.stderr)
            if a.json:
                print(out.strip())
    first = runs["engine"][0]
    print(f"threads {first['threads']}, isa {first['isa']}, compression {first['compression']}, "
          f"scale {first['scale']}, best of {a.rounds} alternated rounds")
    print(f"{'job':<20} {'columns':<9} {'poses':>8} | {'engine poses/s':>14} {'pass':>5} {'search':>6} {'write':>5} "
          f"{'B/pose':>6} | {'arrow poses/s':>13} {'pass':>5} {'search':>6} {'write':>5} {'B/pose':>6} | {'ratio':>5}")
    for i, job in enumerate(first["suite"]):
        cells = []
        rates = {}
        for w in writers:
            best = max((run["suite"][i] for run in runs[w]), key=lambda j: j["poses_per_s"])
            rates[w] = best["poses_per_s"]
            cells.append(f"{best['poses_per_s']:>14,.0f} {100 * best['share_pose_pass']:>4.0f}% "
                         f"{100 * best['share_search']:>5.0f}% {100 * best['share_writing']:>4.0f}% "
                         f"{best['bytes_per_pose']:>6.1f}")
        print(f"{job['job']:<20} {job['columns']:<9} {job['poses']:>8} | {cells[0]} | {cells[1][1:]} | "
              f"{rates['engine'] / rates['arrow']:>5.2f}")
    for w in writers:
        kernel = max(run["kernel"]["poses_per_s"] for run in runs[w])
        print(f"kernel in the {w} invocations: {kernel:,.0f} poses/s")


if __name__ == "__main__":
    main()
