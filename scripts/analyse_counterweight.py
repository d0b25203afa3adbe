#!/usr/bin/env python3
"""Which counterweight leaves the largest discontinuity-free share of the workspace?

Reads the output of `clearance run jobs/sweep_counterweight.toml --out DIR` with
DuckDB. The Psi-Theta grid has (n-1)^2 cells; a cell is affected when a refined
take-up switch (of any joint and kind) lies inside it. The discontinuity-free share
of a variant is the share of unaffected cells; the summary adds the error sizes.

    python3 scripts/analyse_counterweight.py out/sweep_counterweight
"""
import sys
import tomllib
from pathlib import Path

import duckdb


def main(run: Path) -> None:
    job = tomllib.loads((run / "job.toml").read_text())
    psi, theta = job["grid"]["psi"], job["grid"]["theta"]
    cells = (psi["n"] - 1) * (theta["n"] - 1)
    dpsi = (psi["stop"] - psi["start"]) / (psi["n"] - 1)
    dtheta = (theta["stop"] - theta["start"]) / (theta["n"] - 1)
    param = job["sweep"][0]["param"]
    db = duckdb.connect()
    rows = db.execute(
        f"""
        with affected as (
            select variant,
                   count(distinct (least(floor((psi - {psi['start']}) / {dpsi}), {psi['n'] - 2}),
                                   least(floor((theta - {theta['start']}) / {dtheta}), {theta['n'] - 2}))) as cells
            from read_parquet('{run}/discontinuities.parquet')
            where mode = 'kinetostatic'
            group by variant
        )
        select s."{param}" as counterweight_kg,
               1 - coalesce(a.cells, 0) / {cells}::double as discontinuity_free_share,
               s.switches,
               s.dp_max * 1e6 as max_position_error_um,
               s.dp_p95 * 1e6 as p95_position_error_um
        from read_parquet('{run}/summary.parquet') s
        left join affected a using (variant)
        where s.mode = 'kinetostatic'
        order by counterweight_kg
        """
    ).fetchall()
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
