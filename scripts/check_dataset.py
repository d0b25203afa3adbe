#!/usr/bin/env python3
"""Reads a finished run back the way users do (pyarrow, DuckDB, Polars) and checks
that every reader sees the same Hive-partitioned dataset, the units, the provenance
and the swept parameters.

    python3 scripts/check_dataset.py out/sweep_counterweight
"""
import sys
import tomllib
from pathlib import Path

import duckdb
import polars as pl
import pyarrow.dataset as ds
import pyarrow.parquet as pq


def main(run: Path) -> int:
    failures, passed = [], []

    def check(ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        (passed if ok else failures).append(what)

    job = tomllib.loads((run / "job.toml").read_text())
    variants = 1
    for s in job.get("sweep", []):
        variants *= len(s["values"])
    modes = job.get("analysis", {}).get("modes", ["kinetostatic"])
    if "grid" in job:
        n = 1
        for k in ("z", "psi", "theta"):
            v = job["grid"][k]
            n *= v["n"] if isinstance(v, dict) else 1
    else:
        n = job["trajectory"]["time"]["n"]
    rows = n * variants * len(modes)

    table = ds.dataset(run / "poses", format="parquet", partitioning="hive").to_table()
    check(table.num_rows == rows, f"pyarrow reads {table.num_rows} rows (expected {rows})")
    check(sorted(set(table["variant"].to_pylist())) == list(range(variants)), "pyarrow sees variant=0..K-1 from the paths")
    glob = f"{run}/poses/*/*.parquet"
    (count, nvar), = duckdb.sql(f"select count(*), count(distinct variant) from read_parquet('{glob}', hive_partitioning=true)").fetchall()
    check(count == rows and nvar == variants, f"DuckDB reads {count} rows in {nvar} variants")
    df = pl.scan_parquet(f"{run}/poses/**/*.parquet", hive_partitioning=True).select(pl.len(), pl.col("variant").n_unique()).collect()
    check(df.row(0) == (rows, variants), f"Polars reads {df.row(0)}")

    part = next((run / "poses" / "variant=0").glob("*.parquet"))
    meta = pq.read_metadata(part).metadata
    check(b"clearance.job" in meta and b"clearance.version" in meta, "job and engine version in the key-value metadata")
    check(b"clearance.git_commit" in meta, "git commit in the key-value metadata")
    schema = pq.read_schema(part)
    check(schema.field("err_z").metadata.get(b"unit") == b"m", "units in the field metadata")
    check("variant" not in schema.names, "variant is not repeated inside the files")
    nan = duckdb.sql(f"select count(*) from read_parquet('{glob}') where isnan(err_x) or isnan(err_z)").fetchall()[0][0]
    check(nan == 0, "no NaN in the error columns")

    summary = pq.read_table(run / "summary.parquet")
    check(summary.num_rows == variants * len(modes), f"summary has {summary.num_rows} rows")
    for s in job.get("sweep", []):
        check(s["param"] in summary.column_names, f"summary carries the swept parameter {s['param']}")
        check(sorted(set(summary[s["param"]].to_pylist())) == sorted(set(s["values"])), "with its values")
    disc = pq.read_table(run / "discontinuities.parquet")
    check(set(disc.column_names) >= {"variant", "mode", "limb", "kind", "t", "z", "psi", "theta", "margin", "jump_x", "jump_rz"}, "discontinuities columns")
    print(f"{len(passed)} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(Path(sys.argv[1])))
