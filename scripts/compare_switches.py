#!/usr/bin/env python3
"""Compare two sets of run directories of the same jobs, an engine before and after a change.

    python3 scripts/compare_switches.py OLD NEW [--tol 1e-7] [--jump-rtol 1e-9]

OLD and NEW are either two run directories (each with `poses/` and
`discontinuities.parquet`), or two directories holding one run directory per job,
paired by name. For each job:

- the poses: every part file under `poses/`, read as one table with its `variant`
  (from the `variant=K` directory), rows sorted by (variant, mode, sample), must be
  equal (`pyarrow.Table.equals`): a change to the search must not touch them;
- the switches of `discontinuities.parquet`, matched line by line: a switch is keyed
  by (variant, mode, limb, kind, along) and the other inputs' values (the grid line
  it lies on; nothing else on a trajectory), and located by the input it varies
  (or `t`). On each line the switches of the two runs are paired in order of
  location within `--tol`; those left over appear (new only) or disappear (old
  only). A pair whose location or margin differs by more than `--tol` (relative
  to the margin for the margin) has moved. The jump is compared too: the number of
  pairs whose jump differs by more than `--jump-rtol` of its size is counted per job,
  with the largest difference (a change of where the jump is read moves every jump a
  little; it is not listed switch by switch).

Prints one line per switch that appears, disappears or moves, and a summary per job;
exits 1 if any job's poses differ or a job is missing on one side, else 0.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import defaultdict
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

IDENTITY = ("variant", "mode", "limb", "kind", "along")
INPUTS = ("t", "x", "y", "z", "phi", "psi", "theta")


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
    keys = [(k, "ascending") for k in ("variant", "mode", "sample") if k in t.column_names]
    return t.sort_by(keys)


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


def compare(name: str, old: Path, new: Path, tol: float, jump_rtol: float) -> tuple[bool, list[str]]:
    lines = []
    ok = True
    po, pn = poses(old), poses(new)
    if po is None or pn is None:
        same = po is None and pn is None
    else:
        same = po.schema.equals(pn.schema) and po.equals(pn)
    if not same:
        ok = False
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
                    finite(ma) and abs(ma - mb) > tol * max(abs(ma), abs(mb), 1e-300)
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
        f"{name}: poses {'identical' if same else 'DIFFER'}; switches {total_old} -> {total_new}: "
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
        good, lines = compare(name, old[name], new[name], args.tol, args.jump_rtol)
        ok &= good
        print("\n".join(lines), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
