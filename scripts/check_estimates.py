#!/usr/bin/env python3
"""How far `clearance check`'s estimated wall time is from the real run.

For each job (default: every job of jobs/ and of benches/suite/), runs
`clearance check JOB` (its calibration runs and estimate), then `clearance run JOB`
timed by the wall clock, the same column set and threads, and prints the ratio
real / estimated. The issue's goal is a factor of 2 either way; the script exits 1
if a job is outside it. A benchmark, not a test: run it on a quiet machine.

    python3 scripts/check_estimates.py [--bin target/release/clearance] [--threads N] [JOB ...]
"""
import argparse
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}


def estimated(binary, job, extra):
    out = subprocess.run([binary, "check", job, *extra], capture_output=True, text=True, check=True).stdout
    m = re.search(r"estimated wall time: ([0-9.]+) (s|min|h) \((.*)\)", out)
    if not m:
        raise SystemExit(f"{job}: no estimate in\n{out}")
    return float(m.group(1)) * UNITS[m.group(2)], m.group(3)


def real(binary, job, extra, scratch):
    out = os.path.join(scratch, "run")
    start = time.perf_counter()
    subprocess.run([binary, "run", job, "--out", out, "--overwrite", "--quiet", *extra], check=True)
    seconds = time.perf_counter() - start
    shutil.rmtree(out, ignore_errors=True)
    return seconds


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("jobs", nargs="*")
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "clearance"))
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--columns", default="standard")
    a = ap.parse_args(argv)
    jobs = a.jobs or sorted(glob.glob(os.path.join(ROOT, "jobs", "*.toml"))) + \
        sorted(glob.glob(os.path.join(ROOT, "benches", "suite", "*.toml")))
    extra = ["--columns", a.columns] + (["--threads", str(a.threads)] if a.threads else [])
    print(f"{'job':<40} {'estimate s':>10} {'real s':>8} {'real/est':>8}  calibration")
    outside = 0
    with tempfile.TemporaryDirectory() as scratch:
        for job in jobs:
            est, how = estimated(a.bin, job, extra)
            secs = real(a.bin, job, extra, scratch)
            ratio = secs / est if est > 0 else float("inf")
            bad = not (0.5 <= ratio <= 2.0)
            outside += bad
            name = os.path.relpath(job, ROOT)
            print(f"{name:<40} {est:>10.2f} {secs:>8.2f} {ratio:>8.2f}{' !' if bad else '  '} {how}")
    print(f"{len(jobs) - outside} of {len(jobs)} within a factor of 2" + (f"; {outside} outside (!)" if outside else ""))
    return 1 if outside else 0


if __name__ == "__main__":
    sys.exit(main())
