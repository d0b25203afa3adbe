#!/usr/bin/env python3
"""Compare two sets of run directories of the same jobs, an engine before and after a change.

    python3 scripts/compare_switches.py OLD NEW [--tol 1e-7] [--jump-rtol 1e-9] [--pose-rtol R] [--margin-atol A]

OLD and NEW are either two run directories (each with `poses/` and
`discontinuities.parquet`), or two directories holding one run directory per job,
paired by name. For each job:

- the poses: every part file under `poses/`, read as one table with its `variant`
  (from the `variant=K` directory), rows sorted by (variant, mode, sample), must be
  equal (`pyarrow.Table.equals`): a change to the search must not touch them.
  With `--pose-rtol R` (for a change that may move the last bits, e.g. of the
  arithmetic) they are compared column by column instead: the same column names and
  row count; a column that is not of floats equal exactly (nulls included); a column
  of floats with its NaNs and nulls at the same rows (NaN equals NaN) and every
  other value within R * scale of the old one, the scale being the column's largest
  finite |value| in OLD (1e-300 if all are zero). The largest difference relative to
  its column's scale is printed per job with its column; a column beyond it is
  printed with the number of rows over and its worst row's values;
- the switches of `discontinuities.parquet`, matched line by line: a switch is keyed
  by (variant, mode, limb, kind, along) and the other inputs' values (the grid line
  it lies on; nothing else on a trajectory), and located by the input it varies
  (or `t`). On each line the switches of the two runs are paired in order of
  location within `--tol`; those left over appear (new only) or disappear (old
  only). A pair whose location or margin differs by more than `--tol` (relative
  to the margin for the margin, or `--margin-atol` if larger) has moved. The jump is compared too: the number of
  pairs whose jump differs by more than `--jump-rtol` of its size is counted per job,
  with the largest difference (a change of where the jump is read moves every jump a
  little; it is not listed switch by switch).

Prints one line per switch that appears, disappears or moves, and a summary per job;
exits 1 if any job's poses differ (beyond `--pose-rtol` if given) or a job is missing
on one side, else 0.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import defaultdict
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

IDENTITY = ("variant", "mode", "limb", "kind", "along")
INPUTS = ("t", "x", "y", "z", "phi", "psi", "theta")
POSE_KEYS = ("variant", "mode", "sample")


def runs(root: Path) -> dict[str, Path]:
    """The run directories under `root` by name (`root` itself if it is one)."""
    if (root / "poses").is_dir() or (root / "discontinuities.parquet").exists():
        return {root.name: root}
    return {d.name: d for d in sorted(root.iterdir()) if (d / "poses").is_dir()}


def poses(run: Path) -> pa.Table | None:
    """Every pose row of a run, with its variant, sorted by (variant, mode, sample)."""
    tables = []
    for part in sorted((run / "poses").glob("variant=*/*.parquet")):
        t = pq.read_table(part)
        variant = int(part.parent.name.split("=", 1)[1])
        if "variant" not in t.column_names:
            t = t.append_column("variant", pa.array([variant] * t.num_rows, pa.uint64()))
        tables.append(t)
    if not tables:
        return None
    t = pa.concat_tables(tables, promote_options="default")
    keys = [(k, "ascending") for k in POSE_KEYS if k in t.column_names]
    return t.sort_by(keys)


def row_key(t: pa.Table, row: int) -> str:
    """A pose row by its index and its (variant, mode, sample)."""
    keys = ", ".join(f"{k} {t.column(k)[row].as_py()}" for k in POSE_KEYS if k in t.column_names)
    return f"row {row} ({keys})"


def is_float(t: pa.DataType) -> bool:
    return pa.types.is_floating(t)


def column_scale(col: pa.Array) -> float:
    """The largest finite |value| of a column of floats, 1e-300 if there is none but zero."""
    largest = pc.max(pc.abs(pc.filter(col, pc.is_finite(col)))).as_py()
    return largest if largest else 1e-300


def first_true(mask: pa.Array) -> int:
    return pc.index(mask, True).as_py()


def compare_other_column(name: str, old: pa.Table, a: pa.Array, b: pa.Array) -> list[str]:
    """A column not of floats on both sides: equal exactly, nulls included."""
    if a.type != b.type:
        return [f"column {name}: type {a.type} -> {b.type}"]
    if a.equals(b):
        return []
    null_a, null_b = pc.is_null(a), pc.is_null(b)
    differ = pc.or_(pc.xor(null_a, null_b), pc.fill_null(pc.not_equal(a, b), False))
    row = first_true(differ)
    return [
        f"column {name}: {pc.sum(differ).as_py()} rows differ; first {row_key(old, row)}: "
        f"{a[row].as_py()!r} -> {b[row].as_py()!r}"
    ]


def compare_float_column(
    name: str, old: pa.Table, a: pa.Array, b: pa.Array, rtol: float
) -> tuple[float, list[str]]:
    """A column of floats: its NaNs and nulls at the same rows, the other values within
    `rtol` of its scale. The largest difference relative to the scale, and what is beyond."""
    a, b = pc.cast(a, pa.float64()), pc.cast(b, pa.float64())
    scale = column_scale(a)
    null_a, null_b = pc.is_null(a), pc.is_null(b)
    nan_a, nan_b = pc.fill_null(pc.is_nan(a), False), pc.fill_null(pc.is_nan(b), False)
    out = []
    misplaced = pc.or_(pc.xor(null_a, null_b), pc.xor(nan_a, nan_b))
    if pc.any(misplaced).as_py():
        row = first_true(misplaced)
        out.append(
            f"column {name}: NaN or null on one side only at {pc.sum(misplaced).as_py()} rows; "
            f"first {row_key(old, row)}: {a[row].as_py()!r} -> {b[row].as_py()!r}"
        )
    valid = pc.invert(pc.or_(pc.or_(null_a, null_b), pc.or_(nan_a, nan_b)))
    # equal values differ by 0, infinities included; a finite one against an infinity by inf
    diff = pc.if_else(pc.equal(a, b), 0.0, pc.abs(pc.subtract(a, b)))
    diff = pc.if_else(valid, diff, pa.scalar(None, pa.float64()))
    largest = pc.max(diff).as_py() or 0.0
    over = pc.sum(pc.greater(diff, rtol * scale)).as_py() or 0
    if over:
        row = pc.index(diff, largest).as_py()
        out.append(
            f"column {name}: {over} rows beyond {rtol:g} of its scale {scale:.6g}; worst "
            f"{row_key(old, row)}: {a[row].as_py()!r} -> {b[row].as_py()!r} "
            f"({largest / scale:.2g} of scale)"
        )
    return largest / scale, out


def compare_poses_close(old: pa.Table, new: pa.Table, rtol: float) -> tuple[bool, list[str]]:
    """Two pose tables compared column by column within `rtol` (see the module's text):
    whether they agree, and the lines that say how."""
    if old.column_names != new.column_names:
        return False, [f"POSES DIFFER: columns {old.column_names} -> {new.column_names}"]
    if old.num_rows != new.num_rows:
        return False, [f"POSES DIFFER: rows {old.num_rows} -> {new.num_rows}"]
    worst, worst_column = 0.0, None
    failures = []
    for name in old.column_names:
        a, b = old.column(name).combine_chunks(), new.column(name).combine_chunks()
        if is_float(a.type) and is_float(b.type):
            rel, lines = compare_float_column(name, old, a, b, rtol)
            if rel > worst:
                worst, worst_column = rel, name
        else:
            lines = compare_other_column(name, old, a, b)
        failures += lines
    where = f" in column {worst_column}" if worst_column is not None else ""
    verdict = "beyond" if failures else "within"
    return not failures, [f"poses {verdict} {rtol:g}: largest {worst:.2g} of scale{where}"] + failures


def switches(run: Path) -> list[dict]:
    path = run / "discontinuities.parquet"
    if not path.exists():
        return []
    return pq.read_table(path).to_pylist()


def line_of(s: dict) -> tuple:
    """The line a switch lies on and its joint."""
    along = s["along"]
    others = tuple(
        (name, round(s[name], 9))
        for name in INPUTS
        if name in s and name != along and name != "t" and s[name] is not None and along != "t"
    )
    return tuple(s[k] for k in IDENTITY) + others


def location(s: dict) -> float:
    return s[s["along"]]


def jump(s: dict) -> list[float]:
    return [s[k] for k in sorted(s) if k.startswith("jump_")]


def describe(s: dict) -> str:
    where = ", ".join(f"{n}={s[n]:.6g}" for n in INPUTS if n in s and s[n] is not None)
    return f"variant {s['variant']} {s['mode']} limb {s['limb']} {s['kind']} along {s['along']} ({where})"


def pair(old: list[dict], new: list[dict], tol: float):
    """Pairs the switches of one line by location, in order: (old, new) with None for
    one left over."""
    old = sorted(old, key=location)
    new = sorted(new, key=location)
    out = []
    i = j = 0
    while i < len(old) or j < len(new):
        if i < len(old) and j < len(new):
            a, b = location(old[i]), location(new[j])
            if abs(a - b) <= max(tol, 1e-3):
                out.append((old[i], new[j]))
                i += 1
                j += 1
            elif a < b:
                out.append((old[i], None))
                i += 1
            else:
                out.append((None, new[j]))
                j += 1
        elif i < len(old):
            out.append((old[i], None))
            i += 1
        else:
            out.append((None, new[j]))
            j += 1
    return out


def finite(x) -> bool:
    return x is not None and not (isinstance(x, float) and math.isnan(x))


def compare(
    name: str,
    old: Path,
    new: Path,
    tol: float,
    jump_rtol: float,
    pose_rtol: float | None = None,
    margin_atol: float = 0.0,
) -> tuple[bool, list[str]]:
    lines = []
    ok = True
    po, pn = poses(old), poses(new)
    agree = "identical"
    if po is None or pn is None:
        same = po is None and pn is None
    elif pose_rtol is None:
        same = po.schema.equals(pn.schema) and po.equals(pn)
    else:
        same, pose_lines = compare_poses_close(po, pn, pose_rtol)
        agree = f"within {pose_rtol:g}"
        lines.append(f"{name}: {pose_lines[0]}")
        lines += [f"{name}: POSES DIFFER: {line}" for line in pose_lines[1:]]
    if not same:
        ok = False
        if pose_rtol is None or po is None or pn is None:
            lines.append(f"{name}: POSES DIFFER")
    by_line = defaultdict(lambda: ([], []))
    for side, ss in enumerate((switches(old), switches(new))):
        for s in ss:
            by_line[line_of(s)][side].append(s)
    counts = defaultdict(int)
    worst_jump = 0.0
    jumps_changed = 0
    for key in sorted(by_line, key=repr):
        o, n = by_line[key]
        for a, b in pair(o, n, tol):
            if b is None:
                counts["disappear"] += 1
                lines.append(f"{name}: DISAPPEARS {describe(a)} at {location(a):.9g}, margin {a['margin']:.6g}")
            elif a is None:
                counts["appear"] += 1
                lines.append(f"{name}: APPEARS {describe(b)} at {location(b):.9g}, margin {b['margin']:.6g}")
            else:
                moved = abs(location(a) - location(b)) > tol
                ma, mb = a["margin"], b["margin"]
                margin_moved = finite(ma) != finite(mb) or (
                    finite(ma) and abs(ma - mb) > max(tol * max(abs(ma), abs(mb), 1e-300), margin_atol)
                )
                if moved or margin_moved:
                    counts["move"] += 1
                    lines.append(
                        f"{name}: MOVES {describe(a)} from {location(a):.12g} to {location(b):.12g}, "
                        f"margin {ma:.9g} -> {mb:.9g}"
                    )
                else:
                    counts["same"] += 1
                ja, jb = jump(a), jump(b)
                size = max([abs(x) for x in ja + jb if finite(x)] + [1e-300])
                diff = max(
                    [abs(x - y) for x, y in zip(ja, jb) if finite(x) and finite(y)]
                    + [math.inf if any(finite(x) != finite(y) for x, y in zip(ja, jb)) else 0.0]
                )
                if diff > jump_rtol * size:
                    jumps_changed += 1
                    worst_jump = max(worst_jump, diff / size)
    total_old = sum(len(o) for o, _ in by_line.values())
    total_new = sum(len(n) for _, n in by_line.values())
    lines.append(
        f"{name}: poses {agree if same else 'DIFFER'}; switches {total_old} -> {total_new}: "
        f"{counts['same']} same, {counts['move']} moved, {counts['appear']} appeared, "
        f"{counts['disappear']} disappeared; jumps changed on {jumps_changed} "
        f"(largest {worst_jump:.3g} of the jump's size)"
    )
    return ok, lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--tol", type=float, default=1e-7, help="location (and relative margin) tolerance")
    ap.add_argument("--jump-rtol", type=float, default=1e-9, help="relative jump tolerance")
    ap.add_argument(
        "--margin-atol",
        type=float,
        default=0.0,
        help="absolute margin tolerance (N or N*m): a scalar switch's margin is its load at the zero "
        "crossing, round-off of 1e-15..1e-12, which --tol alone (relative) calls moved",
    )
    ap.add_argument(
        "--pose-rtol",
        type=float,
        default=None,
        help="compare the poses column by column within this fraction of each column's scale "
        "instead of exactly",
    )
    args = ap.parse_args()
    old, new = runs(args.old), runs(args.new)
    if len(old) == 1 and len(new) == 1:
        old, new = {"run": next(iter(old.values()))}, {"run": next(iter(new.values()))}
    ok = True
    for name in sorted(set(old) | set(new)):
        if name not in old or name not in new:
            print(f"{name}: only in {'NEW' if name in new else 'OLD'}")
            ok = False
            continue
        good, lines = compare(name, old[name], new[name], args.tol, args.jump_rtol, args.pose_rtol, args.margin_atol)
        ok &= good
        print("\n".join(lines), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
