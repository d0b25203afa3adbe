"""`clearance.solve` in a loop against the engine's kernel, side by side in one run.

The loop is what an optimiser does (python/examples/optimise_counterweight.py):
many calls of one workspace each, every result a `pyarrow.Table`. The kernel is
`clearance bench`'s: the same poses solved with no columns built and no Python.
Both solve the bench job (the prototype at Z = 2.05 m, Ψ, Θ ∈ [−0.5, 0.5], all
four clearance kinds, kinetostatics) on every core; rounds alternate and the best
of each is kept, since the machines are shared.

Run: python3 scripts/solve_throughput.py --bin target/release/clearance
"""

import argparse
import json
import platform
import subprocess
import sys
import time

import numpy as np

import clearance

JOB = {
    "name": "bench",
    "clearance": {"s_radial": 1e-4, "r_radial": 1e-4, "r_axial": 1e-4, "r_angular": 1e-4},
    "grid": {"z": 2.05, "psi": 0.0, "theta": 0.0},  # replaced by the poses of each call
}


def grid(side: int):
    psi, theta = np.meshgrid(np.linspace(-0.5, 0.5, side), np.linspace(-0.5, 0.5, side), indexing="ij")
    return psi.ravel(), theta.ravel()


def loop_rate(side: int, poses: int, columns: str) -> float:
    """Poses/s of `solve` called on side × side poses until `poses` are done."""
    psi, theta = grid(side)
    calls = max(1, poses // psi.size)
    # Warm up for 0.1 s, as `clearance bench` warms its kernel: the job and pool are
    # made on the first call, and for the next ~25 ms after the machine was busy (the
    # kernel's subprocess, say) calls ran at one thread's speed (measured: ~1 000 µs
    # a call, then ~570 µs) until the OS had the pool's threads on separate cores.
    warm = time.perf_counter()
    while time.perf_counter() - warm < 0.1:
        clearance.solve(JOB, z=2.05, psi=psi, theta=theta, columns=columns)
    start = time.perf_counter()
    for _ in range(calls):
        table = clearance.solve(JOB, z=2.05, psi=psi, theta=theta, columns=columns)
    secs = time.perf_counter() - start
    assert table.num_rows == psi.size
    return calls * psi.size / secs


def kernel_rate(binary: str) -> float:
    out = subprocess.run([binary, "bench", "--json", "--repeat", "1"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)["kernel_poses_per_s"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default="target/release/clearance")
    ap.add_argument("--side", type=int, default=61, help="poses per call: side × side (default 61: 3 721)")
    ap.add_argument("--poses", type=int, default=400_000, help="poses per timed loop")
    ap.add_argument("--columns", default="minimal")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    best = {"kernel": 0.0, "loop": 0.0, "one_call": 0.0}
    one_side = int(np.ceil(np.sqrt(args.poses)))
    for _ in range(args.rounds):
        best["kernel"] = max(best["kernel"], kernel_rate(args.bin))
        best["loop"] = max(best["loop"], loop_rate(args.side, args.poses, args.columns))
        best["one_call"] = max(best["one_call"], loop_rate(one_side, 1, args.columns))
    result = {
        "machine": platform.processor() or platform.machine(),
        "columns": args.columns,
        "poses_per_call": args.side * args.side,
        "kernel_poses_per_s": best["kernel"],
        "loop_poses_per_s": best["loop"],
        "one_call_poses_per_s": best["one_call"],
        "loop_over_kernel": best["loop"] / best["kernel"],
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"kernel (clearance bench):                 {best['kernel'] / 1e6:6.2f} M poses/s")
        print(f"solve in a loop, {args.side * args.side} poses a call:   {best['loop'] / 1e6:6.2f} M poses/s")
        print(f"solve, one call of {one_side * one_side} poses:     {best['one_call'] / 1e6:6.2f} M poses/s")
        print(f"loop / kernel: {best['loop'] / best['kernel']:.2f}  ({args.columns} columns, best of {args.rounds})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
