"""Tests of scripts/analyse_clearance_tolerance.py.

    python3 -m pytest -q scripts/test_analyse_clearance_tolerance.py

The script's p95 and answers are checked against a direct computation with
pyarrow and NumPy: on a small fake run written here (with rows that are not 'ok'
carrying large errors, which must be left out, and a non-monotone kind), and on a
small version of jobs/sweep_clearance_tolerance.toml run by the binary
(CLEARANCE_BIN, else target/release/clearance; skipped when neither exists).
"""

import itertools
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCRIPT = HERE / "analyse_clearance_tolerance.py"
sys.path.insert(0, str(HERE))
import analyse_clearance_tolerance as act  # noqa: E402


def numpy_p95(run: Path) -> dict[int, float]:
    """p95 of |dp| over the 'ok' kinetostatic rows of each variant, read with pyarrow."""
    t = ds.dataset(run / "poses", format="parquet", partitioning="hive").to_table(
        columns=["variant", "mode", "status", "err_x", "err_y", "err_z"]
    ).to_pydict()
    variant = np.asarray(t["variant"])
    ok = (np.asarray(t["status"]) == "ok") & (np.asarray(t["mode"]) == "kinetostatic")
    dp = np.sqrt(sum(np.asarray([np.nan if e is None else e for e in t[c]], dtype=float) ** 2
                     for c in ("err_x", "err_y", "err_z")))
    return {int(k): float(np.percentile(dp[ok & (variant == k)], 95)) for k in np.unique(variant)}


def direct_answers(kinds, values_by_variant, p95, bound):
    """The script's two answers, brute force: per kind the largest swept value up to which
    every value passes with the others at their smallest; the maximal passing combinations."""
    smallest = [min(v[i] for v in values_by_variant.values()) for i in range(len(kinds))]
    limits = {}
    for i, kind in enumerate(kinds):
        line = sorted((v[i], p95[k]) for k, v in values_by_variant.items()
                      if all(v[j] == smallest[j] for j in range(len(kinds)) if j != i))
        limit = None
        for value, p in line:
            if not p < bound:
                break
            limit = value
        limits[kind] = limit
    passing = {k for k in p95 if p95[k] < bound}
    maximal = {k for k in passing
               if not any(values_by_variant[w] != values_by_variant[k]
                          and all(a >= b for a, b in zip(values_by_variant[w], values_by_variant[k]))
                          for w in passing)}
    largest = {kind: max((values_by_variant[k][i] for k in passing), default=None) for i, kind in enumerate(kinds)}
    return limits, passing, maximal, largest


def check_against_direct(run: Path, bound: float):
    kinds, variants, left_out, total = act.load(run)
    p95 = numpy_p95(run)
    assert [v.variant for v in variants] == sorted(p95)
    for v in variants:
        assert v.p95 == pytest.approx(p95[v.variant], rel=1e-12, abs=0), v.variant
    a = act.answer(kinds, variants, bound)
    values = {v.variant: v.values for v in variants}
    limits, passing, maximal, largest = direct_answers(kinds, values, p95, bound)
    assert {ka.kind: (ka.limit.values[i] if ka.limit else None) for i, ka in enumerate(a.one_at_a_time)} == limits
    assert {v.variant for v in a.passing} == passing
    assert {v.variant for v in a.maximal} == maximal
    assert {kind: (v.values[i] if v else None) for i, (kind, v) in enumerate(a.largest)} == largest
    for kind, v in a.largest:
        if v is not None:
            assert v.variant in maximal
    return kinds, variants, left_out, total, a


def write_fake_run(run: Path) -> dict[int, tuple[float, float]]:
    """A run of 3 x 2 variants (r_radial x r_axial) whose 'ok' rows have |dp| set by
    the clearances, except that r_radial = 20 um is made worse than 40 um (so the
    one-at-a-time limit of r_radial must stop at 10 um), and rows that are not 'ok'
    carry errors of 1 m, which would fail every variant if they were counted."""
    r_values, a_values = [10e-6, 20e-6, 40e-6], [10e-6, 20e-6]
    run.mkdir()
    (run / "job.toml").write_text(
        'name = "fake"\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n'
        f'[[sweep]]\nparam = "clearance.r_radial"\nvalues = {r_values}\n'
        f'[[sweep]]\nparam = "clearance.r_axial"\nvalues = {a_values}\n'
    )
    rng = np.random.default_rng(7)
    values, summary = {}, []
    for k, (r, a) in enumerate(itertools.product(r_values, a_values)):
        values[k] = (r, a)
        scale = (3 * r if r == 20e-6 else r) + 2 * a
        n_ok, n_bad = 200, 30
        mag = scale * rng.uniform(0.5, 1.5, n_ok)
        d = rng.normal(size=(n_ok, 3))
        d = d / np.linalg.norm(d, axis=1)[:, None] * mag[:, None]
        status = ["ok"] * n_ok + ["near_singular"] * (n_bad // 2) + ["indeterminate_contact"] * (n_bad - n_bad // 2)
        cols = {c: list(d[:, i]) + [1.0] * n_bad for i, c in enumerate(("err_x", "err_y", "err_z"))}
        cols["err_z"][n_ok + n_bad - 1] = None  # a null among the left-out rows
        order = rng.permutation(n_ok + n_bad)
        table = pa.table({
            "mode": ["kinetostatic"] * (n_ok + n_bad),
            "sample": pa.array(np.arange(n_ok + n_bad), pa.uint64()),
            "status": [status[i] for i in order],
            **{c: pa.array([cols[c][i] for i in order], pa.float64()) for c in cols},
        })
        (run / "poses" / f"variant={k}").mkdir(parents=True)
        pq.write_table(table, run / "poses" / f"variant={k}" / "part-kinetostatic-000000.parquet")
        summary.append({"variant": k, "mode": "kinetostatic", "clearance.r_radial": r, "clearance.r_axial": a,
                        "dp_p95": float(np.percentile(mag, 95))})
    pq.write_table(pa.Table.from_pylist(summary), run / "summary.parquet")
    (run / "_SUCCESS").write_text("")
    return values


def test_fake_run(tmp_path):
    run = tmp_path / "run"
    values = write_fake_run(run)
    # p95 ~ 1.45 * (r' + 2a), r' = 3r at r = 20 um, else r: variants 0..5 (r, a) = (10, 10),
    # (10, 20), (20, 10), (20, 20), (40, 10), (40, 20) um give about 44, 73, 116, 145, 87, 116 um.
    bound = 100e-6
    kinds, variants, left_out, total, a = check_against_direct(run, bound)
    assert kinds == ["r_radial", "r_axial"]
    assert left_out == {"indeterminate_contact": 6 * 15, "near_singular": 6 * 15}
    assert total == 6 * 230
    # The answers themselves, so that a wrong reference cannot agree with a wrong script.
    limits = {ka.kind: ka.limit.values[i] for i, ka in enumerate(a.one_at_a_time)}
    assert limits == {"r_radial": 10e-6, "r_axial": 20e-6}  # 20 um of r_radial fails, 40 um passes
    assert a.one_at_a_time[0].first_fail.values == (20e-6, 10e-6)
    p = {v.variant: v.p95 for v in variants}
    assert {v.variant for v in a.passing} == {k for k in values if p[k] < bound} == {0, 1, 4}
    assert {v.variant for v in a.maximal} == {1, 4}  # (10, 20) and (40, 10) um
    assert {kind: v.values[i] for i, (kind, v) in enumerate(a.largest)} == {"r_radial": 40e-6, "r_axial": 20e-6}


def test_not_finished_run_fails(tmp_path):
    run = tmp_path / "run"
    write_fake_run(run)
    (run / "_SUCCESS").unlink()
    r = subprocess.run([sys.executable, str(SCRIPT), str(run)], capture_output=True, text=True)
    assert r.returncode != 0
    assert "not a finished run (no _SUCCESS)" in r.stderr
    assert r.stdout == ""


def binary() -> Path:
    for p in (os.environ.get("CLEARANCE_BIN"), ROOT / "target" / "release" / "clearance"):
        if p and Path(p).is_file():
            return Path(p)
    pytest.skip("no clearance binary (set CLEARANCE_BIN or build target/release/clearance)")


def test_small_version_of_the_job(tmp_path):
    """The job of the README on a 9 x 9 grid with the smallest and largest value of each
    kind (16 variants), run by the binary: the script's p95 against NumPy's, its answers
    against brute force, and its printed one-line answers."""
    text = (ROOT / "jobs" / "sweep_clearance_tolerance.toml").read_text()
    small, n = re.subn(r"n = 41", "n = 9", text)
    assert n == 2
    small, n = re.subn(r"values = \[([^,\]]+),[^\]]*,\s*([^,\]]+)\]", r"values = [\1, \2]", small)
    assert n == 4
    job = tmp_path / "small.toml"
    job.write_text(small)
    run = tmp_path / "run"
    subprocess.run([str(binary()), "run", str(job), "--out", str(run), "--quiet"], check=True, timeout=120)

    p95 = numpy_p95(run)
    assert len(p95) == 16
    bound = float(np.median(list(p95.values())))  # some pass, some fail
    kinds, variants, left_out, total, a = check_against_direct(run, bound)
    assert kinds == ["s_radial", "r_radial", "r_axial", "r_angular"]
    assert total == 16 * 81
    assert 0 < len(a.passing) < 16

    r = subprocess.run([sys.executable, str(SCRIPT), str(run), "--bound-um", repr(bound * 1e6)],
                       capture_output=True, text=True, check=True)
    assert f"left out: {sum(left_out.values())} rows not 'ok'" in r.stdout
    assert f"{len(a.passing)} of 16 keep p95 under" in r.stdout
    for i, ka in enumerate(a.one_at_a_time):
        if ka.limit is None:
            expect = f"{ka.kind:<10} none of the swept values"
        else:
            expect = f"{ka.kind:<10} at {'least' if ka.first_fail is None else 'most'} {act.fmt_value(ka.kind, ka.limit.values[i])}"
        assert expect in r.stdout
    # The total error is a sum of kinds' errors, each proportional to its clearance:
    # the largest combination has the largest p95.
    assert max(variants, key=lambda v: v.p95).values == tuple(max(v.values[i] for v in variants) for i in range(4))
