#!/usr/bin/env python3
"""Which rail angle of a 3-PRS gives the smallest p95 position error, and which the
largest discontinuity-free share of the workspace?

Reads the output of `clearance run jobs/sweep_rail_angle.toml --out DIR` with
DuckDB (scripts/sweep_table.py says how the share is counted).

    python3 scripts/analyse_rail_angle.py out/sweep_rail_angle
"""
import sys
from pathlib import Path

from sweep_table import sweep_table


def main(run: Path) -> None:
    rows = sweep_table(run)
    print(f"{'rail angle (deg)':>16} {'discontinuity-free':>19} {'switches':>9} {'max |dp| (um)':>14} {'p95 |dp| (um)':>14}")
    for beta, share, switches, dmax, p95 in rows:
        print(f"{beta:>16.0f} {share:>19.2%} {switches:>9d} {dmax:>14.2f} {p95:>14.2f}")
    smallest = min(rows, key=lambda r: (r[4], r[0]))
    # Among the angles with the largest share, the one closest to vertical.
    freest = max(rows, key=lambda r: (r[1], -abs(r[0])))
    print(f"\nsmallest p95 position error: {smallest[4]:.2f} um, with the rails at {smallest[0]:g} deg")
    print(f"largest discontinuity-free share: {freest[1]:.2%}, with the rails at {freest[0]:g} deg")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
