#!/usr/bin/env python3
"""An allocation beside brute force: `clearance allocate` against the best of the
256 combinations of jobs/sweep_clearance_tolerance.toml.

    clearance run jobs/sweep_clearance_tolerance.toml --out out/sweep_clearance_tolerance
    clearance allocate jobs/allocate_paper_100um.toml --max-dp 1e-4 --out out/allocate_paper_100um
    python3 scripts/compare_allocation.py out/sweep_clearance_tolerance out/allocate_paper_100um/allocation.json

Both jobs are the same robot on the same grid. For each variant of the sweep (four
values per kind), the largest bounded |Δp| over its poses, as allocate bounds it:
at an `ok` pose |Δp| itself; at an `indeterminate_contact` pose |Σ err_<kind>| over
the kinds whose take-up is decided plus env_<kind>_p of those whose take-up is not.
A combination meets the budget when that largest value does; its cost is
Σ w_k / c_k with the allocation's weights. The allocation is the optimum over every
magnitude, not four per kind, so it must cost no more than the best combination that
meets the budget (exit 1 if it does), and it meets the budget itself (its
largest_dp). Prints both and how many combinations meet the budget.
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pyarrow.dataset as ds
import pyarrow.parquet as pq

KINDS = ["s_radial", "r_radial", "r_axial", "r_angular"]


def largest_bounded_dp(run: Path) -> dict[int, float]:
    """Per variant, the largest bounded |Δp| (m) over its ok and indeterminate poses."""
    cols = ["variant", "status"] + [f"err_{k}_{c}" for k in KINDS for c in "xyz"] + [f"env_{k}_p" for k in KINDS]
    t = ds.dataset(run / "poses", format="parquet", partitioning="hive").to_table(columns=cols)
    variant = t.column("variant").to_numpy()
    status = np.array(t.column("status").to_pylist())
    keep = (status == "ok") | (status == "indeterminate_contact")
    vec = np.zeros((t.num_rows, 3))
    env = np.zeros(t.num_rows)
    for k in KINDS:
        e = np.stack([t.column(f"err_{k}_{c}").to_numpy(zero_copy_only=False) for c in "xyz"], axis=1)
        decided = ~np.isnan(e[:, 0])
        vec[decided] += e[decided]
        env[~decided] += t.column(f"env_{k}_p").to_numpy(zero_copy_only=False)[~decided]
    bound = np.linalg.norm(vec, axis=1) + env
    out: dict[int, float] = {}
    for v in np.unique(variant[keep]):
        out[int(v)] = float(bound[keep & (variant == v)].max())
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path, help="the run of jobs/sweep_clearance_tolerance.toml")
    ap.add_argument("allocation", type=Path, help="allocation.json of clearance allocate")
    args = ap.parse_args()
    if not (args.run / "_SUCCESS").exists():
        sys.exit(f"{args.run} is not a finished run (no _SUCCESS)")
    alloc = json.loads(args.allocation.read_text())
    budget = alloc["max_dp"]
    weights = alloc["weights"]
    if sorted(weights) != sorted(KINDS):
        sys.exit(f"{args.allocation}: allocates {sorted(weights)}, not the four kinds of the sweep")
    summary = pq.read_table(args.run / "summary.parquet")
    values = {
        int(v): [summary.column(f"clearance.{k}")[i].as_py() for k in KINDS]
        for i, v in enumerate(summary.column("variant").to_pylist())
        if summary.column("mode")[i].as_py() == "kinetostatic"
    }
    largest = largest_bounded_dp(args.run)
    rows = []
    for v, dp in largest.items():
        cost = sum(weights[k] / c for k, c in zip(KINDS, values[v]))
        rows.append((cost, dp, v))
    meeting = sorted(r for r in rows if r[1] <= budget)
    print(f"budget max |dp| <= {budget * 1e6:g} um over every pose of the workspace")
    print(f"brute force: {len(meeting)} of {len(rows)} combinations meet it")
    if meeting:
        cost, dp, v = meeting[0]
        mags = ", ".join(f"{k} {c * 1e6:g}" for k, c in zip(KINDS, values[v]))
        print(f"  the cheapest: variant {v} ({mags} um or urad), cost {cost:.6g}, largest |dp| {dp * 1e6:.2f} um")
    mags = ", ".join(f"{k} {alloc['magnitudes'][k] * 1e6:.3f}" for k in KINDS)
    print(f"allocation: {mags} (um or urad), cost {alloc['cost']:.6g}, largest |dp| {alloc['largest_dp'] * 1e6:.2f} um")
    if alloc["largest_dp"] > budget * (1 + 1e-9):
        print("FAIL: the allocation exceeds the budget")
        return 1
    if meeting:
        saving = 1 - alloc["cost"] / meeting[0][0]
        print(f"the allocation costs {saving:.1%} less than the best combination of the sweep")
        if alloc["cost"] > meeting[0][0] * (1 + 1e-9):
            print("FAIL: the allocation costs more than a combination that meets the budget")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
