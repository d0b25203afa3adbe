#!/usr/bin/env python3
"""Stress the engine with random custom mechanisms that are meant to go wrong.

    python3 scripts/fuzz_custom.py --bin PATH [--jobs N | --seconds S] [--seed K] [--keep DIR]

scripts/crosscheck_custom.py checks the numbers of well-behaved random mechanisms against
the reference; this checks what a designer's first drafts meet: each job starts from one
of its random families (3-RRS, 3-PRS, 3-RPS, 6-UPS, 6-PUS), or one time in four from a
built-in job of jobs/ (3-PRS, 3-RPS, 6-UPS; without its sweep), and is then bent at random:

* grids and trajectories many times wider than the workspace (poses out of reach, out of a
  joint's range, through singularities, continuation that must give up);
* (custom only) a joint moved, joint types swapped, a joint or a limb dropped,
  axes made parallel, another subset of the six coordinates as inputs (descriptions that
  are overconstrained, not rigid, idle or do not close);
* no weight at all (every load zero), masses and loads a million times larger, every
  clearance zero or all the same from 1e-12 to 0.3 m, exact mode, `[analysis]` thresholds
  at their extremes, a single pose, dynamics along a trajectory that leaves the
  workspace or runs up to a thousand times faster.

Most jobs are bent only in ways that still run (their poses are the stress); a third
also get a broken description, which must be refused.

Each job runs as ``BIN run JOB --out DIR --quiet --columns full`` (at most 120 s). What
must hold, whatever the job (README "Bad input", docs/interface.md "Statuses and nulls"):

* the exit status is 0, or 2 with a message on stderr and nothing written in DIR; never
  a panic, a signal or a time-out;
* after exit 0: `_SUCCESS`, `summary.parquet` and `discontinuities.parquet` are there and
  readable; every row has a known status and finite inputs; no column stores NaN; an
  `ok` row has no null; a `near_singular` or `indeterminate_contact` row has its actuator
  positions; a switch has finite coordinates and a margin.

Prints one line per failing job (its TOML is kept under --keep, default a temporary
directory) and ``N jobs: A accepted, R refused, F failed``; exit 1 if any failed.
"""

from __future__ import annotations

import argparse
import copy
import glob
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
_spec = importlib.util.spec_from_file_location("crosscheck_custom", os.path.join(HERE, "crosscheck_custom.py"))
cc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cc)

COORDS = ("x", "y", "z", "phi", "psi", "theta")
STATUSES = {"ok", "near_singular", "indeterminate_contact", "unreachable"}
# Beyond these a run is not a robustness check but a benchmark.
MAX_SAMPLES = 400


def _widen(rng, job):
    """Spreads the grid or trajectory far past the workspace."""
    factor = float(10.0 ** rng.uniform(0.5, 2.0))
    if "grid" in job:
        for k, v in job["grid"].items():
            if isinstance(v, dict):
                mid, half = 0.5 * (v["start"] + v["stop"]), 0.5 * (v["stop"] - v["start"]) * factor
                v["start"], v["stop"] = mid - half, mid + half
    else:
        for k, v in job["trajectory"].items():
            if k != "time" and isinstance(v, dict):
                for h in v["harmonics"]:
                    h["amplitude"] *= factor


def _joints(job):
    return [j for limb in job["mechanism"]["limb"] for j in limb["joints"]]


def _move_joint(rng, job):
    j = _joints(job)[int(rng.integers(len(_joints(job))))]
    j["at"] = [a + float(rng.normal(0.0, 0.02)) for a in j["at"]]


def _swap_type(rng, job):
    j = _joints(job)[int(rng.integers(len(_joints(job))))]
    new = str(rng.choice(["R", "P", "U", "S"]))
    if new == j["type"]:
        return
    j["type"] = new
    axis = j.pop("axis", None) or (j.pop("axes", None) or [[0.0, 0.0, 1.0]])[0]
    j.pop("axes", None)
    if new in ("R", "P"):
        j["axis"] = axis
    elif new == "U":
        other = np.cross(axis, [1.0, 0.0, 0.0])
        if np.linalg.norm(other) < 1e-6:
            other = np.cross(axis, [0.0, 1.0, 0.0])
        j["axes"] = [list(axis), [float(v) for v in other / np.linalg.norm(other)]]
    if new not in ("R", "P"):
        j.pop("actuated", None)
        j.pop("range", None)


def _drop_joint(rng, job):
    limb = job["mechanism"]["limb"][int(rng.integers(len(job["mechanism"]["limb"])))]
    if len(limb["joints"]) > 1:
        k = int(rng.integers(len(limb["joints"])))
        del limb["joints"][k]
        if len(limb.get("bodies", [])) >= len(limb["joints"]) + 1:
            del limb["bodies"][min(k, len(limb["bodies"]) - 1)]


def _drop_limb(rng, job):
    limbs = job["mechanism"]["limb"]
    if len(limbs) > 1:
        del limbs[int(rng.integers(len(limbs)))]


def _parallel_axes(rng, job):
    for j in _joints(job):
        if "axes" in j:
            j["axes"][1] = list(j["axes"][0])
            return
        if "axis" in j and rng.random() < 0.5:
            j["axis"] = [0.0, 0.0, 1.0]


def _other_inputs(rng, job):
    n = int(rng.integers(1, 7))
    inputs = [str(c) for c in rng.choice(COORDS, size=n, replace=False)]
    mech = job["mechanism"]
    home = dict(zip(COORDS, mech["home"]))
    mech["inputs"] = inputs
    span = {"x": 0.05, "y": 0.05, "z": 0.05, "phi": 0.2, "psi": 0.2, "theta": 0.2}
    job.pop("trajectory", None)
    job["analysis"] = {k: v for k, v in job.get("analysis", {}).items() if k != "modes"}
    grid = {}
    for k in inputs:
        if rng.random() < 0.5:
            grid[k] = {"start": home[k] - span[k], "stop": home[k] + span[k], "n": int(rng.integers(2, 5))}
        else:
            grid[k] = home[k]
    job["grid"] = grid


def _weightless(rng, job):
    job["mass"] = {"platform": 0.0}
    job.pop("load", None)
    if job.get("mechanism", {}).get("kind", "3-PRS") == "3-PRS":
        job["mass"]["leg"] = 0.0
    for limb in job.get("mechanism", {}).get("limb", []):
        for b in limb.get("bodies", []):
            b["mass"] = 0.0
            b.pop("inertia", None)
    if rng.random() < 0.5:
        job.setdefault("mechanism", {})["gravity"] = [0.0, 0.0, 0.0]


def _heavy(rng, job):
    f = 1e6
    mass = job.setdefault("mass", {})
    mass["platform"] = mass.get("platform", 10.0) * f
    mass.pop("platform_inertia", None)
    for p in mass.get("points", []):
        p["mass"] *= f
    if "load" in job:
        job["load"]["force"] = [v * f for v in job["load"]["force"]]
        job["load"]["moment"] = [v * f for v in job["load"]["moment"]]


def _no_play(rng, job):
    job["clearance"] = {k: (0.0 if not isinstance(v, list) else [0.0] * len(v)) for k, v in job["clearance"].items()}


def _extreme_analysis(rng, job):
    a = job.setdefault("analysis", {})
    key = str(rng.choice(["singular_cond", "discontinuity_load_fraction", "indeterminate_load_fraction"]))
    a[key] = {
        "singular_cond": float(rng.choice([1.0, 2.0, 1e300])),
        "discontinuity_load_fraction": float(rng.choice([0.0, 1.0, 1e6])),
        "indeterminate_load_fraction": float(rng.choice([0.0, 0.5, 1.0])),
    }[key]


def _big_play(rng, job):
    size = float(10.0 ** rng.uniform(-12, -0.5))
    job["clearance"] = {k: (size if not isinstance(v, list) else [size] * len(v)) for k, v in job["clearance"].items()}


def _fast_trajectory(rng, job):
    if "trajectory" not in job:
        return
    for k, v in job["trajectory"].items():
        if k != "time" and isinstance(v, dict):
            for h in v["harmonics"]:
                h["period"] = float(10.0 ** rng.uniform(-3, -1))
    job.setdefault("analysis", {})["modes"] = ["kinetostatic", "dynamic"]


def _single_pose(rng, job):
    if "grid" in job:
        for k, v in job["grid"].items():
            if isinstance(v, dict):
                v["n"] = 1


def _exact(rng, job):
    job.setdefault("analysis", {})["exact"] = True


MUTATIONS = {
    "widen": _widen,
    "move_joint": _move_joint,
    "swap_type": _swap_type,
    "drop_joint": _drop_joint,
    "drop_limb": _drop_limb,
    "parallel_axes": _parallel_axes,
    "other_inputs": _other_inputs,
    "weightless": _weightless,
    "heavy": _heavy,
    "no_play": _no_play,
    "exact": _exact,
    "extreme_analysis": _extreme_analysis,
    "big_play": _big_play,
    "fast_trajectory": _fast_trajectory,
    "single_pose": _single_pose,
}


RUNNABLE = (
    "widen",
    "weightless",
    "heavy",
    "no_play",
    "exact",
    "extreme_analysis",
    "big_play",
    "fast_trajectory",
    "single_pose",
)
BREAKING = ("move_joint", "swap_type", "drop_joint", "drop_limb", "parallel_axes", "other_inputs")


def _samples(job):
    if "grid" in job:
        n = 1
        for v in job["grid"].values():
            if isinstance(v, dict):
                n *= v["n"]
        return n
    return job["trajectory"]["time"]["n"]


def builtin_jobs():
    """The jobs of jobs/ of the built-in kinds (3-PRS, 3-RPS, 6-UPS)."""
    out = []
    for path in sorted(glob.glob(os.path.join(os.path.dirname(HERE), "jobs", "*.toml"))):
        with open(path, "rb") as f:
            job = tomllib.load(f)
        if job.get("mechanism", {}).get("kind", "3-PRS") != "custom":
            out.append((os.path.basename(path), job))
    return out


BUILTIN = builtin_jobs()


def inputs_of(job):
    """The input columns of a job's pose files."""
    kind = job.get("mechanism", {}).get("kind", "3-PRS")
    if kind == "custom":
        return job["mechanism"]["inputs"]
    return list(COORDS) if kind == "6-UPS" else ["z", "psi", "theta"]


def draw(rng, index):
    """A random stressed job and the names of the mutations applied: one of
    crosscheck_custom.py's random mechanisms, or (one in four) a built-in job of jobs/."""
    builtin = rng.random() < 0.25
    if builtin:
        tag, job = BUILTIN[int(rng.integers(len(BUILTIN)))]
    else:
        got = None
        while got is None:
            got = cc.random_job(rng, index)
        job, tag = got
    job = copy.deepcopy(job)
    # Mostly jobs that still run (their poses are the stress); a third of the custom
    # ones broken as well (the built-in kinds have no joints to break).
    chosen = [str(m) for m in rng.choice(RUNNABLE, size=int(rng.integers(1, 4)), replace=False)]
    if not builtin and rng.random() < 0.35:
        chosen.append(str(rng.choice(BREAKING)))
    for m in chosen:
        MUTATIONS[m](rng, job)
    return _bounded(job), f"{tag} + {', '.join(chosen)}"


def _bounded(job):
    """`job` with at most MAX_SAMPLES samples and one variant."""
    if "trajectory" in job:
        job["trajectory"]["time"]["n"] = min(job["trajectory"]["time"]["n"], MAX_SAMPLES)
    while _samples(job) > MAX_SAMPLES:
        for v in job["grid"].values():
            if isinstance(v, dict) and v["n"] > 2:
                v["n"] = max(2, v["n"] // 2)
    # Sweeps are the parser's business (fuzz/): one variant here.
    job.pop("sweep", None)
    return job


def check_output(out, inputs):
    """Problems with a finished run's directory (empty list if none)."""
    bad = []
    for name in ("_SUCCESS", "summary.parquet", "discontinuities.parquet"):
        if not os.path.exists(os.path.join(out, name)):
            bad.append(f"no {name}")
    if bad:
        return bad
    try:
        pq.read_table(os.path.join(out, "summary.parquet"))
        sw = pq.read_table(os.path.join(out, "discontinuities.parquet"))
    except Exception as e:  # noqa: BLE001 - any unreadable file is the finding
        return [f"unreadable table: {e}"]
    files = sorted(glob.glob(os.path.join(out, "poses", "**", "*.parquet"), recursive=True))
    if not files:
        return ["no pose files"]
    for f in files:
        t = pq.read_table(f)
        status = t.column("status").to_pylist()
        unknown = set(status) - STATUSES
        if unknown or None in status:
            bad.append(f"{os.path.basename(f)}: statuses {sorted(map(str, unknown))}")
        ok = [i for i, s in enumerate(status) if s == "ok"]
        solved = [i for i, s in enumerate(status) if s in ("ok", "indeterminate_contact", "near_singular")]
        for name in t.column_names:
            column = t.column(name)
            if str(column.type) in ("double", "float"):
                nan = pc.sum(pc.is_nan(column)).as_py() or 0
                if nan:
                    bad.append(f"{name}: {nan} NaN stored")
            col = column.to_pylist()
            if name in inputs and any(v is None or not math.isfinite(v) for v in col):
                bad.append(f"input {name} not finite on every row")
            # The exact error is null where its Newton does not converge or lands on
            # another branch, whatever the status (docs/model.md §12, conventions.md).
            if name in ("t", "dominant") or name.startswith("exact_err_"):
                continue
            nulls_ok = [i for i in ok if col[i] is None]
            if nulls_ok:
                bad.append(f"{name}: null on {len(nulls_ok)} ok rows")
            if name.startswith("q") and name[1:].isdigit():
                missing = [i for i in solved if col[i] is None]
                if missing:
                    bad.append(f"{name}: null on {len(missing)} solved rows")
    for name in ("x", "y", "z", "phi", "psi", "theta", "margin"):
        if name in sw.column_names and sw.num_rows:
            col = sw.column(name)
            if col.null_count or not all(math.isfinite(v) for v in col.to_pylist()):
                bad.append(f"switch column {name} not finite")
    return bad


def run_one(binary, job, work, timeout):
    """(verdict, detail): verdict is 'accepted', 'refused' or 'failed'."""
    path = os.path.join(work, "job.toml")
    with open(path, "w") as f:
        f.write(cc.to_toml(job))
    out = os.path.join(work, "out")
    shutil.rmtree(out, ignore_errors=True)
    cmd = [binary, "run", path, "--out", out, "--quiet", "--columns", "full"]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "failed", f"no answer in {timeout} s"
    if p.returncode == 2:
        written = os.path.isdir(out) and os.listdir(out)
        if not p.stderr.strip():
            return "failed", "exit 2 without a message"
        if written:
            return "failed", f"exit 2 but {out} holds {sorted(os.listdir(out))}: {p.stderr.strip()}"
        return "refused", p.stderr.strip().splitlines()[0]
    if p.returncode != 0:
        return "failed", f"exit {p.returncode}: {p.stderr.strip()[-2000:]}"
    bad = check_output(out, inputs_of(job))
    return ("failed", "; ".join(bad)) if bad else ("accepted", "")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--jobs", type=int, default=50)
    ap.add_argument("--seconds", type=float, default=None, help="run until this many seconds have passed")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", default=None, help="where failing jobs are kept")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--verbose", action="store_true", help="a line for every job")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    keep = args.keep  # made on the first failure: a clean run leaves nothing behind
    work = tempfile.mkdtemp(prefix="fuzz_custom_run_")
    counts = {"accepted": 0, "refused": 0, "failed": 0}
    start = time.time()
    i = 0
    while (i < args.jobs) if args.seconds is None else (time.time() - start < args.seconds):
        job, tag = draw(rng, i)
        verdict, detail = run_one(args.bin, job, work, args.timeout)
        counts[verdict] += 1
        if args.verbose and verdict != "failed":
            print(f"job {i} ({tag}): {verdict} {detail[:200]}", flush=True)
        if verdict == "failed":
            if keep is None:
                keep = tempfile.mkdtemp(prefix="fuzz_custom_")
            os.makedirs(keep, exist_ok=True)
            kept = os.path.join(keep, f"failed_{args.seed}_{i:04d}.toml")
            with open(kept, "w") as f:
                f.write(f"# {tag}\n# {detail[:500]}\n" + cc.to_toml(job))
            print(f"job {i} ({tag}): {detail[:300]} -> {kept}", flush=True)
        i += 1
    shutil.rmtree(work, ignore_errors=True)
    print(f"{i} jobs: {counts['accepted']} accepted, {counts['refused']} refused, {counts['failed']} failed")
    return 1 if counts["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
