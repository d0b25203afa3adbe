#!/usr/bin/env python3
"""Which crank length is best for the 3-RRS wrist of jobs/sweep_custom_crank_length.toml?

Reads the run's summary.parquet (one row per variant) and prints, per crank length, the
share of the workspace the wrist reaches without a singularity, the pose error of P
(largest, RMS, 95th percentile over the ok poses), the worst-case envelope, how many
take-up switches the search found and which joint dominates most often. The best
length is the one with the smallest 95th-percentile error among those that reach every
pose of the grid; ties go to fewer switches.

    clearance run jobs/sweep_custom_crank_length.toml --out out/sweep_custom_crank_length
    python3 scripts/analyse_custom_sweep.py out/sweep_custom_crank_length
"""

import sys

import pyarrow.parquet as pq

PARAM = "mechanism.limb.0.joints.1.at.0"
CRANK_AXIS = 0.25  # the crank's motor axis, m from the centre


def main(argv):
    if len(argv) != 2:
        print(__doc__)
        return 2
    s = pq.read_table(f"{argv[1]}/summary.parquet").to_pylist()
    dom_cols = [c for c in s[0] if c.startswith("dominant_share_")]
    rows = []
    for r in s:
        crank = r[PARAM] - CRANK_AXIS
        dom = max(dom_cols, key=lambda c: r[c] or 0.0)
        rows.append(
            dict(
                crank=crank,
                ok=r["share_ok"],
                reach=1.0 - r["share_unreachable"] - r["share_near_singular"],
                dp_max=r["dp_max"],
                dp_rms=r["dp_rms"],
                dp_p95=r["dp_p95"],
                env=r["env_p_p95"],
                switches=r["switches"],
                dominant=dom[len("dominant_share_"):],
                dom_share=r[dom],
            )
        )
    um = lambda v: "-" if v is None else f"{v * 1e6:7.1f}"
    print("crank (m)  reached  ok     |dp| max   rms    p95 (um)  envelope p95  switches  dominant joint")
    for r in rows:
        print(
            f"{r['crank']:8.3f}  {r['reach']:6.1%}  {r['ok']:6.1%}  {um(r['dp_max'])} {um(r['dp_rms'])} {um(r['dp_p95'])}"
            f"      {um(r['env'])}     {r['switches']:5d}    {r['dominant']} ({r['dom_share']:.0%})"
        )
    full = [r for r in rows if r["reach"] >= 1.0 and r["dp_p95"] is not None] or rows
    best = min(full, key=lambda r: (r["dp_p95"], r["switches"]))
    print(
        f"best: crank {best['crank']:.3f} m: 95 % of the poses within {best['dp_p95'] * 1e6:.1f} um, "
        f"{best['switches']} switches, {best['dominant']} dominant at {best['dom_share']:.0%} of the poses"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
