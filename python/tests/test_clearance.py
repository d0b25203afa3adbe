"""The Python package against the engine's own output and the command line."""

import pathlib
import subprocess
import threading
import time

import numpy as np
import pyarrow as pa
import pyarrow.dataset as ds
import pytest

import clearance
from conftest import REPO, cli_command


GRID = """
name = "grid"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4
[grid]
z = 2.05
psi = { start = -0.5, stop = 0.5, n = 21 }
theta = { start = -0.5, stop = 0.5, n = 23 }
[[sweep]]
param = "mass.platform"
values = [9.8, 40.0]
"""

TRAJECTORY = {
    "name": "trajectory",
    "mass": {"points": [{"mass": 30.0, "at": [0.0, 0.0, 1.0]}]},
    "clearance": {"r_radial": 1e-4},
    "analysis": {"modes": ["kinetostatic", "dynamic"]},
    "trajectory": {
        "time": {"start": 1.25, "stop": 3.75, "n": 401},
        "z": 2.05,
        "psi": 0.0,
        "theta": {"offset": 0.0, "harmonics": [{"amplitude": 0.5, "period": 5.0, "phase": 0.0}]},
    },
}


def plain(table: pa.Table) -> pa.Table:
    """Dictionary columns (the Hive `variant`) cast to their values, `variant` as uint64."""
    cols = []
    for name in table.column_names:
        col = table.column(name)
        if pa.types.is_dictionary(col.type):
            col = col.cast(col.type.value_type)
        if name == "variant":
            col = col.cast(pa.uint64())
        cols.append(col)
    return pa.table(cols, names=table.column_names)


def read_run(out: pathlib.Path) -> pa.Table:
    # Part files in the order a run writes them: variant, then mode as in the job, then chunk.
    t = ds.dataset(out / "poses", format="parquet", partitioning="hive").to_table()
    return plain(t)


ROW_ORDER = [(k, "ascending") for k in ["variant", "mode", "sample"]]


def read_sorted(out: pathlib.Path) -> pa.Table:
    """A run's rows read back in (variant, mode, sample) order, to compare two runs."""
    return read_run(out).sort_by(ROW_ORDER)


# A mechanism described by its joints (a 3-RRS wrist), along a trajectory in both modes.
CUSTOM = """
[mechanism]
kind = "custom"
inputs = ["z", "psi", "theta"]
home = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0]
[[mechanism.limb]]
repeat = 3
joints = [
  { type = "R", name = "crank", at = [0.25, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true },
  { type = "R", name = "knee", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0] },
  { type = "S", at = [0.15, 0.0, 0.6] },
]
bodies = [{ mass = 1.2 }, { mass = 2.0 }]
[mass]
platform = 5.0
[clearance]
knee_axial = 5e-5
crank_backlash = [2e-4, 1e-4, 2e-4]
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 0.0, stop = 2.0, n = 41 }
z = 0.6
psi = { offset = 0.0, harmonics = [{ amplitude = 0.2, period = 2.0 }] }
theta = 0.05
"""


@pytest.mark.parametrize("job", [GRID, TRAJECTORY, CUSTOM], ids=["grid", "trajectory", "custom"])
def test_solve_equals_run_read_back(job, tmp_path):
    out = tmp_path / "run"
    report = clearance.run(job, out, threads=2, chunk_size=100)
    assert report["complete"]
    solved = plain(clearance.solve(job))
    written = read_run(out)
    assert written.num_rows == solved.num_rows
    written = written.sort_by(ROW_ORDER)
    solved = solved.sort_by(ROW_ORDER)
    written_cols = [c for c in written.column_names]
    assert sorted(written_cols) == sorted(solved.column_names)
    for name in solved.column_names:
        a, b = solved.column(name).combine_chunks(), written.column(name).combine_chunks()
        assert a.equals(b), name


@pytest.mark.parametrize("job", [GRID, CUSTOM], ids=["grid", "custom"])
def test_single_precision_stores_the_double_values_rounded(job, tmp_path):
    """precision="single": error, envelope and margin columns float32, each value the
    double run's rounded to float32; every other column the same."""
    clearance.run(job, tmp_path / "double", threads=2, chunk_size=100)
    clearance.run(job, tmp_path / "single", threads=2, chunk_size=100, precision="single")
    double = read_sorted(tmp_path / "double")
    single = read_sorted(tmp_path / "single")
    narrowed = 0
    for name in double.column_names:
        a, b = double.column(name).combine_chunks(), single.column(name).combine_chunks()
        if name.startswith(("err_", "exact_err_", "env_", "margin_")):
            assert b.type == pa.float32(), name
            assert a.cast(pa.float32()).equals(b), name
            narrowed += 1
        else:
            assert a.equals(b), name
    assert narrowed > 30


@pytest.mark.parametrize("job", [GRID, CUSTOM], ids=["grid", "custom"])
def test_the_arrow_writer_writes_the_same_table(job, tmp_path):
    """writer="arrow" (parquet's ArrowWriter) against the default engine encoder: the
    same rows, values and nulls, column for column."""
    clearance.run(job, tmp_path / "engine", threads=2, chunk_size=100)
    clearance.run(job, tmp_path / "arrow", threads=2, chunk_size=100, writer="arrow")
    engine = read_sorted(tmp_path / "engine")
    arrow = read_sorted(tmp_path / "arrow")
    assert engine.column_names == arrow.column_names
    for name in engine.column_names:
        assert engine.column(name).combine_chunks().equals(arrow.column(name).combine_chunks()), name
    # In other bytes: the argument reached the writer.
    parts = [sorted((tmp_path / w / "poses").rglob("*.parquet")) for w in ("engine", "arrow")]
    assert [p.name for p in parts[0]] == [p.name for p in parts[1]]
    assert any(a.read_bytes() != b.read_bytes() for a, b in zip(*parts))


def test_run_with_the_general_solver_agrees_with_the_fast_one(tmp_path):
    """solver="general" (the assembled systems, faer LU) reaches run as it reaches solve:
    the same statuses, errors equal to the fast solver's to round-off; refused, with
    nothing written, where it does not apply."""
    clearance.run(GRID, tmp_path / "fast", threads=2)
    clearance.run(GRID, tmp_path / "general", threads=2, solver="general")
    fast = read_sorted(tmp_path / "fast")
    general = read_sorted(tmp_path / "general")
    assert fast.column("status").equals(general.column("status"))
    for name in ["err_x", "err_y", "err_z", "err_rx", "err_ry", "err_rz"]:
        a = np.asarray(fast.column(name).to_numpy(zero_copy_only=False), float)
        b = np.asarray(general.column(name).to_numpy(zero_copy_only=False), float)
        scale = np.nanmax(np.abs(a))
        assert np.nanmax(np.abs(a - b)) <= 1e-9 * scale, name
    # Not bit for bit: the argument reached the solver.
    assert any(not fast.column(n).equals(general.column(n)) for n in ["err_x", "err_y", "err_z"])
    with pytest.raises(ValueError, match="3-limb kinds.*a custom job"):
        clearance.run(CUSTOM, tmp_path / "custom", solver="general")
    assert not (tmp_path / "custom").exists() or not any((tmp_path / "custom").iterdir())


def test_custom_columns_come_from_the_description():
    t = clearance.solve(CUSTOM)
    for name in ["q1", "tau3", "err_knee_axial_z", "err_crank_backlash_rx", "margin_crank2_backlash", "x", "phi"]:
        assert name in t.column_names, name
    assert set(t.column("status").to_pylist()) <= {"ok", "indeterminate_contact"}


def test_the_general_solver_is_refused_for_a_custom_mechanism():
    # It assembles the 3-limb kinds' systems: refused, not ignored.
    with pytest.raises(ValueError, match="3-limb kinds.*a custom job"):
        clearance.solve(CUSTOM, solver="general")
    assert clearance.solve(CUSTOM, solver="fast").num_rows > 0


# A 6-PUS-like custom mechanism whose inputs are all six coordinates, on a small grid.
SIX = (REPO / "jobs" / "custom_6pus_grid.toml").read_text()


def test_a_custom_mechanisms_explicit_poses_equal_its_grid():
    # The 3-RRS wrist takes z, psi and theta; its grid's rows, given as poses.
    job = CUSTOM.replace('modes = ["kinetostatic", "dynamic"]', 'modes = ["kinetostatic"]')
    grid = clearance.solve(job)
    poses = clearance.solve(
        job, z=grid.column("z").to_numpy(), psi=grid.column("psi").to_numpy(), theta=grid.column("theta").to_numpy()
    )
    assert poses.num_rows == grid.num_rows
    for name in ["status", "x", "phi", "q1", "err_x", "err_knee_axial_rz", "margin_crank2_backlash"]:
        assert poses.column(name).equals(grid.column(name)), name
    # All six inputs of a hexapod: given as a number each, broadcast.
    row = clearance.solve(SIX, x=0.01, y=-0.02, z=0.6, phi=0.05, psi=0.02, theta=-0.03)
    assert row.num_rows == 1 and row.column("status").to_pylist() == ["ok"]


@pytest.mark.parametrize(
    "kwargs, named",
    [
        (dict(z=0.6, psi=0.0), "theta missing"),
        (dict(x=0.0, z=0.6, psi=0.0, theta=0.0), "x is not one of this custom mechanism's inputs"),
    ],
)
def test_a_custom_mechanism_refuses_poses_it_does_not_take(kwargs, named):
    job = CUSTOM.replace('modes = ["kinetostatic", "dynamic"]', 'modes = ["kinetostatic"]')
    with pytest.raises(ValueError, match=named):
        clearance.solve(job, **kwargs)


def test_a_6ups_takes_all_six_coordinates_as_poses():
    job = {
        "mechanism": {"kind": "6-UPS"},
        "clearance": {"s_radial": 1e-4, "u_radial": 1e-4},
        "grid": {"x": {"start": -0.05, "stop": 0.05, "n": 3}, "y": 0.01, "z": 0.8, "phi": 0.05,
                 "psi": {"start": -0.2, "stop": 0.2, "n": 5}, "theta": 0.1},
    }
    grid = clearance.solve(job)
    coords = {n: grid.column(n).to_numpy() for n in ["x", "y", "z", "phi", "psi", "theta"]}
    poses = clearance.solve(job, **coords)
    assert poses.num_rows == grid.num_rows == 15
    for name in grid.column_names:
        assert poses.column(name).equals(grid.column(name)), name
    with pytest.raises(ValueError, match="phi missing: give all of x, y, z, phi, psi and theta"):
        clearance.solve(job, **{n: v for n, v in coords.items() if n != "phi"})


def test_explicit_poses_equal_the_grid():
    job = {
        "clearance": {"r_radial": 1e-4, "r_axial": 1e-4},
        "grid": {"z": 2.05, "psi": 0.2, "theta": {"start": -0.5, "stop": 0.5, "n": 9}},
    }
    grid = clearance.solve(job)
    theta = np.linspace(-0.5, 0.5, 9)
    poses = clearance.solve(job, z=2.05, psi=np.full(9, 0.2), theta=theta)
    for name in ["status", "err_x", "err_z", "err_r_axial_rx", "margin_r1_axial"]:
        assert poses.column(name).equals(grid.column(name)), name


def test_calls_in_a_loop_and_in_threads_equal_one_call():
    """What a loop keeps from call to call (the parsed job, the schema, the pools,
    each thread's buffers) changes nothing: pieces of a pose list solved in turn,
    with every thread count, and from two Python threads at once, equal the list
    solved in one call."""
    job = {
        "clearance": {"s_radial": 1e-4, "r_radial": 1e-4, "r_axial": 1e-4, "r_angular": 1e-4},
        "grid": {"z": 2.05, "psi": 0.0, "theta": 0.0},
    }
    rng = np.random.default_rng(7)
    n = 5000
    psi, theta = rng.uniform(-0.6, 0.6, n), rng.uniform(-0.6, 0.6, n)
    z = rng.uniform(1.95, 2.15, n)
    whole = clearance.solve(job, z=z, psi=psi, theta=theta)
    cuts = [0, 1, 64, 65, 1000, 3721, n]
    for threads in [None, 1, 2, 3]:
        pieces = [
            clearance.solve(job, z=z[a:b], psi=psi[a:b], theta=theta[a:b], threads=threads)
            for a, b in zip(cuts, cuts[1:])
        ]
        assert pa.concat_tables(pieces).drop(["sample"]).equals(whole.drop(["sample"])), threads
        # A job that differs only in a number is not taken for the one before it.
        doubled = {**job, "clearance": {k: 2 * v for k, v in job["clearance"].items()}}
        twice = clearance.solve(doubled, z=z, psi=psi, theta=theta, threads=threads)
        np.testing.assert_allclose(twice.column("err_x"), 2 * whole.column("err_x").to_numpy(), rtol=1e-12)
    results = {}

    def one(k):
        results[k] = [clearance.solve(job, z=z, psi=psi, theta=theta, threads=1) for _ in range(3)]

    threads = [threading.Thread(target=one, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for tables in results.values():
        for t in tables:
            assert t.equals(whole)


def test_check_returns_the_plan():
    plan = clearance.check(GRID)
    assert plan["rows"] == 21 * 23 * 2
    assert len(plan["variants"]) == 2
    assert plan["samples"] == {"kind": "grid", "z": 1, "psi": 21, "theta": 23}


def test_bad_job_raises_the_clis_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[mechanism]\nkind = "4-PRS"\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n')
    with pytest.raises(clearance.JobError) as e:
        clearance.check(str(bad))
    cli = subprocess.run(
        cli_command("check", str(bad), "--no-timing"),
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert cli.returncode == 2
    assert cli.stderr.strip() == f"error: {e.value}"
    with pytest.raises(clearance.JobError, match="unknown mechanism kind"):
        clearance.solve(bad.read_text())


def test_two_solves_in_threads_overlap():
    """The GIL is released while computing: the progress callbacks of two calls,
    made from inside the engine, interleave. (With the GIL held for a whole call,
    the other call could not enter the engine until it returned.)"""

    def square(side):
        return {
            "clearance": {"r_radial": 1e-4, "r_axial": 1e-4, "r_angular": 1e-4, "s_radial": 1e-4},
            "grid": {
                "z": 2.05,
                "psi": {"start": -0.5, "stop": 0.5, "n": side},
                "theta": {"start": -0.5, "stop": 0.5, "n": side},
            },
        }

    # Calls long enough for several progress callbacks (at most one each 0.1 s) on
    # this machine: about 0.8 s each on one thread, between 800² and 1600² poses.
    start = time.perf_counter()
    clearance.solve(square(300), threads=1, columns="minimal")
    rate = 300**2 / (time.perf_counter() - start)
    side = int(min(1600, max(800, (0.8 * rate) ** 0.5)))
    job = square(side)
    events = []

    def one(tag):
        def progress(done, total):
            if 0 < done < total:
                events.append((time.perf_counter(), tag))

        clearance.solve(job, threads=1, columns="minimal", progress=progress)

    start = time.perf_counter()
    threads = [threading.Thread(target=one, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    concurrent = time.perf_counter() - start
    tags = [tag for _, tag in sorted(events)]
    start = time.perf_counter()
    one(0)
    one(1)
    sequential = time.perf_counter() - start
    print(f"two calls of {side}² poses: {concurrent:.2f} s in threads, {sequential:.2f} s one after the other")
    # The spans of the two calls' mid-computation callbacks intersect: either they
    # interleave ([0, 1, 0, 1]) or one call runs wholly inside the other ([1, 0, 0, 1]).
    # With the GIL held for a whole call, one span would end before the other begins.
    assert 0 in tags and 1 in tags, tags
    span = {k: (tags.index(k), len(tags) - 1 - tags[::-1].index(k)) for k in (0, 1)}
    overlap = span[0][0] < span[1][1] and span[1][0] < span[0][1]
    assert overlap, f"the calls did not overlap: {tags}"


def test_allocate_equals_the_cli_and_meets_the_budget(tmp_path):
    """clearance.allocate gives the CLI's allocation.json; the budget holds at every
    ok pose of a solve at the answer; an impossible budget raises ValueError."""
    job = {
        "mass": {"points": [{"mass": 30.0, "at": [0.0, 0.0, 1.0]}]},
        "clearance": {"s_radial": 1e-5, "r_radial": 1e-5, "r_axial": 1e-5, "r_angular": 1e-5},
        "grid": {"z": 2.05, "psi": {"start": -0.5, "stop": 0.5, "n": 11}, "theta": {"start": -0.5, "stop": 0.5, "n": 11}},
        "allocate": {"kinds": ["r_radial", "r_axial"], "weights": {"r_radial": 1.0, "r_axial": 3.0}},
    }
    a = clearance.allocate(job, 1e-4)
    path = tmp_path / "job.toml"
    path.write_text(clearance._clearance.dict_toml(job))
    cli = subprocess.run(
        cli_command("allocate", str(path), "--max-dp", "1e-4", "--json", "-q"),
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert cli.returncode == 0, cli.stderr
    import json

    b = json.loads(cli.stdout)
    assert a["cost"] == b["cost"] and a["magnitudes"] == b["magnitudes"]
    assert (tmp_path / "allocation.toml").exists() and (tmp_path / "allocation.json").exists()
    # At the answer (kept kinds s_radial and r_angular at 1e-5), every ok pose is in budget.
    at = dict(job, clearance=dict(job["clearance"], **a["magnitudes"]))
    del at["allocate"]
    t = clearance.solve(at)
    ok = np.array(t.column("status").to_pylist()) == "ok"
    dp = np.sqrt(sum(t.column(f"err_{c}").to_numpy(zero_copy_only=False) ** 2 for c in "xyz"))[ok]
    assert dp.max() <= 1e-4 * (1 + 1e-9)
    with pytest.raises(ValueError, match="not allocated"):
        clearance.allocate(job, 1e-7)
    with pytest.raises(ValueError, match="model"):
        clearance.allocate(job, 1e-4, model="worst")
