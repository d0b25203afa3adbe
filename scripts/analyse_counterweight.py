#!/usr/bin/env python3
"""Which counterweight leaves the largest discontinuity-free share of the workspace?

Reads the output of `clearance run jobs/sweep_counterweight.toml --out DIR` with
DuckDB (scripts/sweep_table.py says how the share is counted).

    python3 scripts/analyse_counterweight.py out/sweep_counterweight
"""
import sys
from pathlib import Path

from sweep_table import sweep_table


def main(run: Path) -> None:
    rows = sweep_table(run)
    print(f"{'counterweight (kg)':>18} {'discontinuity-free':>19} {'switches':>9} {'max |dp| (um)':>14} {'p95 |dp| (um)':>14}")
    for cw, share, switches, dmax, p95 in rows:
        print(f"{cw:>18.1f} {share:>19.1%} {switches:>9d} {dmax:>14.2f} {p95:>14.2f}")
    # Among the variants with the largest share, the lightest counterweight.
    best = max(rows, key=lambda r: (r[1], -r[0]))
    print(f"\nlargest discontinuity-free share: {best[1]:.1%}, first reached with a {best[0]:g} kg counterweight")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
