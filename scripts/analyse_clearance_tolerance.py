#!/usr/bin/env python3
"""How tight must the joints be? For a run that sweeps clearance magnitudes
(`[[sweep]]` over `clearance.<kind>` only), which clearances keep the 95th
percentile of the position error over the workspace under a bound?

Reads the output of `clearance run jobs/sweep_clearance_tolerance.toml --out DIR`
with DuckDB: the `poses` dataset (Hive partitions `variant=K`) for the errors and
`summary.parquet` for each variant's swept values (columns `clearance.<kind>`).

    python3 scripts/analyse_clearance_tolerance.py out/sweep_clearance_tolerance [--bound-um 100]

Per variant (kinetostatic rows), the p95 of |dp| = sqrt(err_x^2 + err_y^2 + err_z^2)
over the rows whose status is 'ok' (the others carry no total error and are left
out; the script says how many), by linear interpolation between order statistics
(DuckDB's quantile_cont, NumPy's default percentile). A variant passes when that
p95 is below the bound. Then:

1. One kind at a time: the other kinds at their smallest swept values, the largest
   swept value of the kind up to which every swept value passes (a tolerance: any
   clearance up to it keeps the error under the bound).
2. Combinations: the passing variants, and among them the largest ones (maximal:
   no other passing variant is at least as large in every kind); per kind, the
   largest value it has in any passing combination, with an example combination.

Exits non-zero with a message when DIR is not a finished run (no _SUCCESS) or does
not sweep clearances.
"""
import argparse
import math
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import duckdb

MODE = "kinetostatic"


@dataclass
class Variant:
    variant: int
    values: tuple[float, ...]  # the swept clearances, in the order of `kinds`
    p95: float | None  # m; None when the variant has no 'ok' pose
    summary_p95: float | None = None  # summary.parquet's dp_p95 (from its histogram), m


def unit(kind: str) -> tuple[float, str]:
    """Scale and unit to print a clearance of this kind: urad for angular plays, else um."""
    return (1e6, "urad") if kind.endswith("angular") else (1e6, "um")


def fmt_value(kind: str, v: float) -> str:
    scale, u = unit(kind)
    return f"{v * scale:g} {u}"


def fmt_um(p95: float | None) -> str:
    return "n/a" if p95 is None else f"{p95 * 1e6:.2f}"


def load(run: Path) -> tuple[list[str], list[Variant], dict[str, int], int]:
    """(kinds swept, variants by number, left-out rows by status, rows in all)."""
    if not (run / "_SUCCESS").is_file():
        raise SystemExit(
            f"error: {run} is not a finished run (no _SUCCESS): run it to the end, "
            "or finish it with `clearance run JOB --out DIR --resume`"
        )
    job = tomllib.loads((run / "job.toml").read_text())
    params = [s["param"] for s in job.get("sweep", [])]
    kinds = [p.removeprefix("clearance.") for p in params if p.startswith("clearance.")]
    if not kinds or len(kinds) != len(params):
        raise SystemExit(
            f"error: {run}: the job must sweep clearance magnitudes only "
            f"(`[[sweep]] param = \"clearance.<kind>\"`), it sweeps {params or 'nothing'}"
        )
    con = duckdb.connect()
    poses = f"read_parquet('{run}/poses/*/*.parquet', hive_partitioning = true)"
    summary = f"read_parquet('{run}/summary.parquet')"
    cols = ", ".join(f's."clearance.{k}"' for k in kinds)
    rows = con.execute(
        f"""
        with p95 as (
            select variant,
                   quantile_cont(sqrt(err_x * err_x + err_y * err_y + err_z * err_z), 0.95)
                       filter (where status = 'ok') as p95
            from {poses}
            where mode = '{MODE}'
            group by variant
        )
        select s.variant, {cols}, p95.p95, s.dp_p95
        from {summary} s left join p95 on p95.variant = s.variant
        where s.mode = '{MODE}'
        order by s.variant
        """
    ).fetchall()
    if not rows:
        raise SystemExit(f"error: {run}: no {MODE} rows in summary.parquet")
    variants = [Variant(int(r[0]), tuple(float(v) for v in r[1:-2]), r[-2], r[-1]) for r in rows]
    left_out = dict(
        con.execute(
            f"select status, count(*) from {poses} where mode = '{MODE}' and status <> 'ok' "
            "group by status order by status"
        ).fetchall()
    )
    (total,) = con.execute(f"select count(*) from {poses} where mode = '{MODE}'").fetchone()
    return kinds, variants, left_out, total


def passes(v: Variant, bound: float) -> bool:
    return v.p95 is not None and v.p95 < bound


@dataclass
class KindAnswer:
    kind: str
    curve: list[tuple[float, Variant]]  # (value of the kind, its variant), others smallest
    limit: Variant | None  # the largest value up to which every swept value passes
    first_fail: Variant | None  # the smallest swept value that fails


@dataclass
class Answer:
    kinds: list[str]
    bound: float
    one_at_a_time: list[KindAnswer]
    passing: list[Variant]
    maximal: list[Variant]  # passing, and no other passing variant is >= in every kind
    largest: list[tuple[str, Variant | None]]  # per kind: an example passing combination with its largest value


def answer(kinds: list[str], variants: list[Variant], bound: float) -> Answer:
    """The two answers (see the module's docstring) from the variants' swept values and p95."""
    smallest = tuple(min(v.values[i] for v in variants) for i in range(len(kinds)))
    one = []
    for i, kind in enumerate(kinds):
        others_smallest = [
            v for v in variants
            if all(v.values[j] == smallest[j] for j in range(len(kinds)) if j != i)
        ]
        curve = sorted(((v.values[i], v) for v in others_smallest), key=lambda c: c[0])
        limit = first_fail = None
        for _, v in curve:
            if not passes(v, bound):
                first_fail = v
                break
            limit = v
        one.append(KindAnswer(kind, curve, limit, first_fail))

    passing = [v for v in variants if passes(v, bound)]

    def dominates(a: Variant, b: Variant) -> bool:
        return a.values != b.values and all(x >= y for x, y in zip(a.values, b.values))

    maximal = [v for v in passing if not any(dominates(w, v) for w in passing)]

    largest = []
    for i, kind in enumerate(kinds):
        if not passing:
            largest.append((kind, None))
            continue
        top = max(v.values[i] for v in passing)
        # Among the largest combinations with that value, the one whose other
        # clearances are largest (sum of log2 of each over its smallest swept value),
        # then the smallest p95, then the lowest variant number.
        candidates = [v for v in maximal if v.values[i] == top]

        def looseness(v: Variant) -> float:
            return sum(math.log2(x / s) for j, (x, s) in enumerate(zip(v.values, smallest)) if j != i and s > 0)

        largest.append((kind, min(candidates, key=lambda v: (-looseness(v), v.p95, v.variant))))
    return Answer(kinds, bound, one, passing, maximal, largest)


def report(run: Path, kinds, variants, left_out, total, a: Answer) -> None:
    bound_um = a.bound * 1e6
    n_left = sum(left_out.values())
    print(f"run: {run}, {len(variants)} variants, {total} {MODE} rows")
    print(f"p95 of |dp| = sqrt(err_x^2 + err_y^2 + err_z^2) over the 'ok' rows of each variant; bound {bound_um:g} um")
    by_status = ", ".join(f"{s} {n}" for s, n in left_out.items())
    print(f"left out: {n_left} rows not 'ok'" + (f" ({by_status})" if by_status else ""))
    both = [(v.p95, v.summary_p95) for v in variants if v.p95 and v.summary_p95]
    if both:
        worst = max(abs(x - y) / y for x, y in both)
        print(f"summary.parquet's dp_p95 (a histogram's) agrees with these to {worst:.3%} at worst")

    smallest = ", ".join(f"{k} {fmt_value(k, min(v.values[i] for v in variants))}" for i, k in enumerate(kinds))
    print(f"\n1. One kind at a time, the others at their smallest swept values ({smallest}):")
    print(f"{'kind':<10} {'clearance':>11} {'p95 |dp| (um)':>14} {'under ' + format(bound_um, 'g') + ' um':>13}")
    for ka in a.one_at_a_time:
        for value, v in ka.curve:
            ok = "yes" if passes(v, a.bound) else "no"
            print(f"{ka.kind:<10} {fmt_value(ka.kind, value):>11} {fmt_um(v.p95):>14} {ok:>13}")
    print()
    for i, ka in enumerate(a.one_at_a_time):
        head = f"{ka.kind:<10}"
        if ka.limit is None:
            v = ka.curve[0][1]
            print(f"{head} none of the swept values: even {fmt_value(ka.kind, ka.curve[0][0])} gives p95 {fmt_um(v.p95)} um")
        elif ka.first_fail is None:
            print(
                f"{head} at least {fmt_value(ka.kind, ka.limit.values[i])} (p95 {fmt_um(ka.limit.p95)} um), "
                "the largest swept: the bound is not reached"
            )
        else:
            print(
                f"{head} at most {fmt_value(ka.kind, ka.limit.values[i])} (p95 {fmt_um(ka.limit.p95)} um; "
                f"{fmt_value(ka.kind, ka.first_fail.values[i])} gives {fmt_um(ka.first_fail.p95)} um)"
            )

    if not a.passing:
        print(f"\n2. Combinations: none of the {len(variants)} keeps p95 under {bound_um:g} um")
        return
    print(f"\n2. Combinations: {len(a.passing)} of {len(variants)} keep p95 under {bound_um:g} um; the largest of them")
    print("   (no other passing combination is at least as large in every kind):")
    print(f"{'variant':>7} " + " ".join(f"{k:>10}" for k in kinds) + f" {'p95 |dp| (um)':>14}")
    for v in a.maximal:
        print(f"{v.variant:>7} " + " ".join(f"{fmt_value(k, x):>10}" for k, x in zip(kinds, v.values)) + f" {fmt_um(v.p95):>14}")
    print()
    for i, (kind, v) in enumerate(a.largest):
        head = f"{kind:<10}"
        if v is None:
            print(f"{head} no combination passes")
            continue
        others = ", ".join(f"{k} {fmt_value(k, x)}" for j, (k, x) in enumerate(zip(kinds, v.values)) if j != i)
        print(f"{head} up to {fmt_value(kind, v.values[i])} in a passing combination, e.g. with {others} (variant {v.variant}, p95 {fmt_um(v.p95)} um)")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="the output directory of a finished clearance run")
    parser.add_argument("--bound-um", type=float, default=100.0, help="bound on the p95 position error, um (default 100)")
    args = parser.parse_args(argv)
    if not args.bound_um > 0:
        parser.error("--bound-um must be positive")
    kinds, variants, left_out, total = load(args.run)
    report(args.run, kinds, variants, left_out, total, answer(kinds, variants, args.bound_um * 1e-6))


if __name__ == "__main__":
    main()
