#!/usr/bin/env python3
"""The paper's dynamic switches (its Figs. 16-17), located independently of the engine.

For each trajectory job given, the NumPy reference (scripts/reference_model.py,
written without the engine) computes the revolute joints' radial loads f_perp =
f_R - (f_R.y_j) y_j along the path, densely sampled; a switch is an interior local
minimum of |f_perp| below discontinuity_load_fraction*W across which the load's
direction turns by more than 90 degrees (docs/model.md section 8), refined with
scipy's bounded scalar minimiser on the reference's own loads. The engine's
`discontinuities.parquet` (r_radial rows) must list the same switches, each within
1e-3 rad of Theta (and in practice far closer).

    python3 scripts/check_paper_dynamics.py --bin target/release/clearance jobs/fig16_trajectory_added_mass_w3.toml ...

Prints each switch of both and ends with "N passed, M failed" (one count per job).
"""
import argparse
import copy
import math
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
from scipy.optimize import minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference_model as rm  # noqa: E402

TOL_THETA = 1e-3


def radial_loads(job, mode, times):
    """|f_perp| and f_perp per limb, and Theta, at the given times."""
    j = copy.deepcopy(job)
    j["analysis"]["modes"] = [mode]
    j.pop("sweep", None)
    out = []
    for t in np.atleast_1d(times):
        j["trajectory"]["time"] = float(t)
        out.append(rm.compute(j, columns="full"))
    alpha = np.deg2rad([0.0, 120.0, 240.0])
    ys = np.stack([-np.sin(alpha), np.cos(alpha), np.zeros(3)], axis=-1)
    theta = np.array([c["theta"][0] for c in out])
    perp = np.zeros((len(out), 3, 3))
    for k, c in enumerate(out):
        for limb in range(3):
            f = np.array([c[f"f_r{limb + 1}_{a}"][0] for a in "xyz"])
            perp[k, limb] = f - f.dot(ys[limb]) * ys[limb]
    return theta, perp


def reference_switches(job, mode):
    tr = job["trajectory"]["time"]
    t = np.linspace(tr["start"], tr["stop"], 4001)
    j = copy.deepcopy(job)
    j["analysis"]["modes"] = [mode]
    j["trajectory"]["time"] = {"start": tr["start"], "stop": tr["stop"], "n": t.size}
    cols = rm.compute(j, columns="full")
    g = np.linalg.norm(job.get("mechanism", {}).get("gravity", [0, 0, -9.81]))
    mass = job.get("mass", {})
    m_total = mass.get("platform", 9.8) + 3 * mass.get("leg", 3.0) + sum(p["mass"] for p in mass.get("points", []))
    threshold = job.get("analysis", {}).get("discontinuity_load_fraction", 0.05) * m_total * g
    alpha = np.deg2rad([0.0, 120.0, 240.0])
    found = []
    for limb in range(3):
        y = np.array([-math.sin(alpha[limb]), math.cos(alpha[limb]), 0.0])
        f = np.stack([cols[f"f_r{limb + 1}_{a}"] for a in "xyz"], axis=-1)
        perp = f - (f @ y)[:, None] * y
        mag = np.linalg.norm(perp, axis=1)
        for k in range(1, t.size - 1):
            if not (mag[k] < mag[k - 1] and mag[k] <= mag[k + 1]):
                continue
            res = minimize_scalar(
                lambda s: np.linalg.norm(radial_loads(job, mode, s)[1][0, limb]),
                bounds=(t[k - 1], t[k + 1]), method="bounded", options={"xatol": 1e-10})
            if res.fun >= threshold:
                continue
            # The direction test: where the magnitude is back to twice the minimum.
            lo = next((i for i in range(k, -1, -1) if mag[i] >= 2 * res.fun), 0)
            hi = next((i for i in range(k, t.size) if mag[i] >= 2 * res.fun), t.size - 1)
            if perp[lo].dot(perp[hi]) < 0:
                theta, _ = radial_loads(job, mode, res.x)
                found.append((mode, limb + 1, float(theta[0])))
    return found


def engine_switches(binary, job_path):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([binary, "run", str(job_path), "--out", out, "--overwrite", "--quiet"], check=True)
        rows = pq.read_table(Path(out) / "discontinuities.parquet").to_pylist()
    return sorted((r["mode"], r["limb"], r["theta"]) for r in rows if r["kind"] == "r_radial")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default="target/release/clearance")
    ap.add_argument("jobs", nargs="+")
    args = ap.parse_args()
    passed = failed = 0
    for path in args.jobs:
        job = tomllib.loads(Path(path).read_text())
        ref = sorted(s for mode in job["analysis"]["modes"] for s in reference_switches(job, mode))
        eng = engine_switches(args.bin, path)
        ok = len(ref) == len(eng) and all(
            a[:2] == b[:2] and abs(a[2] - b[2]) <= TOL_THETA for a, b in zip(ref, eng))
        print(f"{Path(path).stem}: {'pass' if ok else 'FAIL'}")
        for label, rows in (("reference", ref), ("engine", eng)):
            print(f"  {label:>9}: " + "; ".join(f"{m} limb {l} at Theta = {th:+.5f}" for m, l, th in rows))
        passed, failed = passed + ok, failed + (not ok)
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
