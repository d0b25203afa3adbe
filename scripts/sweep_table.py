"""One row per variant of a swept Psi-Theta grid run: the swept value, the
discontinuity-free share of the workspace, the switch count and the position error.

The Psi-Theta grid has (n-1)^2 cells; a cell is affected when a refined take-up
switch (of any joint and kind, kinetostatic) lies inside it. The discontinuity-free
share of a variant is the share of unaffected cells. Read with DuckDB from the run's
`discontinuities.parquet` and `summary.parquet` (see docs/interface.md).
"""
import tomllib
from pathlib import Path

import duckdb


def sweep_table(run: Path) -> list[tuple[float, float, int, float, float]]:
    """(swept value, discontinuity-free share, switches, max |dp| um, p95 |dp| um), by swept value."""
    job = tomllib.loads((run / "job.toml").read_text())
    psi, theta = job["grid"]["psi"], job["grid"]["theta"]
    cells = (psi["n"] - 1) * (theta["n"] - 1)
    dpsi = (psi["stop"] - psi["start"]) / (psi["n"] - 1)
    dtheta = (theta["stop"] - theta["start"]) / (theta["n"] - 1)
    param = job["sweep"][0]["param"]
    return duckdb.connect().execute(
        f"""
        with affected as (
            select variant,
                   count(distinct (least(floor((psi - {psi['start']}) / {dpsi}), {psi['n'] - 2}),
                                   least(floor((theta - {theta['start']}) / {dtheta}), {theta['n'] - 2}))) as cells
            from read_parquet('{run}/discontinuities.parquet')
            where mode = 'kinetostatic'
            group by variant
        )
        select s."{param}" as value,
               1 - coalesce(a.cells, 0) / {cells}::double as discontinuity_free_share,
               s.switches,
               s.dp_max * 1e6 as max_position_error_um,
               s.dp_p95 * 1e6 as p95_position_error_um
        from read_parquet('{run}/summary.parquet') s
        left join affected a using (variant)
        where s.mode = 'kinetostatic'
        order by value
        """
    ).fetchall()
