"""Each argument of `solve`, `run`, `check` and `plot` that can be wrong: the
exception's type, a message that names the argument in Python's terms (never a
command line flag), and nothing computed or written."""

import math
import pathlib
import re
import subprocess

import numpy as np
import pytest

import clearance
from conftest import REPO, cli_command


JOB = {
    "clearance": {"r_radial": 1e-4, "r_axial": 1e-4},
    "grid": {"z": 2.05, "psi": {"start": -0.2, "stop": 0.2, "n": 3}, "theta": {"start": -0.2, "stop": 0.2, "n": 3}},
}

OTHER_JOB = {**JOB, "clearance": {"r_radial": 2e-4}}

NAN, INF = math.nan, math.inf


def names(message: str, argument: str) -> bool:
    """Whether `message` names `argument` as a word (`z`, not the z of `size`)."""
    return re.search(rf"(?<![\w-]){re.escape(argument)}(?![\w])", message) is not None


def contents(folder: pathlib.Path):
    """What `folder` holds, to tell that nothing was written: None if it does not exist."""
    if not folder.exists():
        return None
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None for p in sorted(folder.rglob("*"))}


def refused(exc, argument, call, *folders):
    """`call()` raises `exc` naming `argument`, with no command line flag in the
    message, and leaves `folders` as they were."""
    before = [contents(f) for f in folders]
    with pytest.raises(exc) as e:
        call()
    message = str(e.value)
    assert names(message, argument), message
    assert "--" not in message, message
    assert [contents(f) for f in folders] == before
    return message


# solve: (id, exception, the argument named, keywords).
POSES = dict(z=[2.0, 2.05, 2.1], psi=0.0, theta=0.0)
SOLVE_CASES = [
    ("z-nan", ValueError, "z[1]", dict(z=[2.0, NAN, INF], psi=0.0, theta=0.0)),
    ("psi-inf", ValueError, "psi[2]", dict(z=2.05, psi=[0.0, 0.1, -INF], theta=0.0)),
    ("theta-nan-number", ValueError, "theta", dict(z=2.05, psi=0.0, theta=NAN)),
    ("z-inf-numpy", ValueError, "z[0]", dict(z=np.array([np.inf, 2.0]), psi=np.zeros(2), theta=np.zeros(2))),
    ("lengths", ValueError, "psi", dict(z=[2.0, 2.05, 2.1], psi=[0.0, 0.1], theta=0.0)),
    ("theta-missing", ValueError, "theta", dict(z=[2.0, 2.05], psi=[0.0, 0.1])),
    ("z-2d", ValueError, "z", dict(z=np.zeros((2, 2)), psi=0.0, theta=0.0)),
    ("z-ragged", ValueError, "z", dict(z=[[2.0], [2.0, 2.1]], psi=0.0, theta=0.0)),
    ("z-strings", TypeError, "z", dict(z=["2.0", "2.1"], psi=0.0, theta=0.0)),
    ("psi-string", TypeError, "psi", dict(z=2.05, psi="0.1", theta=0.0)),
    ("theta-none-inside", TypeError, "theta", dict(z=[2.0, 2.1], psi=0.0, theta=[0.0, None])),
    ("z-complex", TypeError, "z", dict(z=[2.0 + 1j], psi=0.0, theta=0.0)),
    ("z-bools", TypeError, "z", dict(z=[True, False], psi=0.0, theta=0.0)),
    ("columns-name", ValueError, "columns", dict(columns="most")),
    ("columns-type", TypeError, "columns", dict(columns=2)),
    ("solver-name", ValueError, "solver", dict(solver="slow")),
    ("solver-type", TypeError, "solver", dict(solver=None)),
    ("threads-negative", ValueError, "threads", dict(threads=-1)),
    ("threads-zero", ValueError, "threads", dict(threads=0)),
    ("threads-too-many", ValueError, "threads", dict(threads=10**6)),
    ("threads-huge", ValueError, "threads", dict(threads=2**70)),
    ("threads-float", TypeError, "threads", dict(threads=2.0)),
    ("threads-str", TypeError, "threads", dict(threads="2")),
    ("threads-bool", TypeError, "threads", dict(threads=True)),
    ("progress", TypeError, "progress", dict(progress="yes")),
    ("unknown-keyword", TypeError, "alpha", dict(alpha=[0.0], **POSES)),
    ("x-for-a-3-limb-job", ValueError, "x", dict(x=[0.0, 0.0, 0.0], **POSES)),
]


@pytest.mark.parametrize("exc, argument, kwargs", [c[1:] for c in SOLVE_CASES], ids=[c[0] for c in SOLVE_CASES])
def test_solve_refuses(exc, argument, kwargs):
    progress = []
    kwargs.setdefault("progress", lambda done, total: progress.append(done))
    refused(exc, argument, lambda: clearance.solve(JOB, **kwargs))
    assert progress == [], "nothing was computed"


def test_solve_refuses_poses_for_a_dynamic_job():
    job = {
        "clearance": {"r_radial": 1e-4},
        "analysis": {"modes": ["kinetostatic", "dynamic"]},
        "trajectory": {"time": {"start": 0.0, "stop": 1.0, "n": 3}, "z": 2.05, "psi": 0.0, "theta": 0.0},
    }
    message = refused(ValueError, "z", lambda: clearance.solve(job, **POSES))
    assert names(message, "psi") and names(message, "theta"), message


def test_a_nan_pose_computes_nothing_and_finite_ones_still_do():
    """The issue's call: a NaN or infinity is an error naming the first bad index,
    not rows of status near_singular."""
    with pytest.raises(ValueError, match=r"z\[1\] is NaN"):
        clearance.solve(JOB, z=[2.0, NAN, INF], psi=0.0, theta=0.0)
    t = clearance.solve(JOB, z=[2.0, 2.05], psi=0.0, theta=0.0)
    assert t.num_rows == 2


def test_accepted_forms():
    """What the docstrings say is accepted: NumPy integers for threads, NumPy
    scalars and arrays in a dict job, tuples and NumPy arrays as poses."""
    theta = np.linspace(-0.2, 0.2, 3)
    plain = clearance.solve(JOB, z=2.05, psi=0.1, theta=list(theta), threads=1)
    numpy_job = {
        "clearance": {"r_radial": np.float32(1e-4), "r_axial": np.float64(1e-4)},
        "grid": {"z": 2.05, "psi": {"start": -0.2, "stop": 0.2, "n": np.int64(3)}, "theta": 0.0},
        "sweep": [{"param": "mass.platform", "values": np.array([9.8, 40.0])}],
    }
    assert clearance.check(numpy_job)["rows"] == 3 * 2
    same = clearance.solve(JOB, z=np.float64(2.05), psi=(0.1, 0.1, 0.1), theta=theta, threads=np.int64(1))
    assert same.equals(plain)


# A job: (id, exception, what the message names, the job).
JOB_CASES = [
    ("type", TypeError, "job", 3),
    ("bytes", TypeError, "job", b"[grid]\nz = 2.05\n"),
    ("none-value", TypeError, "job['grid']['z']", {"grid": {"z": None, "psi": 0.0, "theta": 0.0}}),
    ("object-value", TypeError, "job['name']", {"name": object(), "grid": {"z": 2.05, "psi": 0.0, "theta": 0.0}}),
    ("list-item", TypeError, "job['sweep'][0]['values'][1]",
     {"grid": {"z": 2.05, "psi": 0.0, "theta": 0.0}, "sweep": [{"param": "mass.platform", "values": [1.0, {1}]}]}),
    ("key-type", TypeError, "job['grid']", {"grid": {1: 2.05}}),
    ("nan-value", clearance.JobError, "job", {"grid": {"z": NAN, "psi": 0.0, "theta": 0.0}}),
    ("unknown-key", clearance.JobError, "job", {"grid": {"z": 2.05, "psi": 0.0, "theta": 0.0}, "gird": {}}),
    ("missing-file", clearance.JobError, "no/such/job.toml", "no/such/job.toml"),
]


@pytest.mark.parametrize("function", ["solve", "check", "run"])
@pytest.mark.parametrize("exc, argument, job", [c[1:] for c in JOB_CASES], ids=[c[0] for c in JOB_CASES])
def test_a_bad_job_is_refused(function, exc, argument, job, tmp_path):
    out = tmp_path / "run"
    call = {
        "solve": lambda: clearance.solve(job),
        "check": lambda: clearance.check(job),
        "run": lambda: clearance.run(job, out),
    }[function]
    message = refused(exc, argument, call, out)
    if argument == "job['grid']['z']":
        assert "None" in message


def test_a_nan_in_a_dict_job_is_refused_as_in_a_job_file(tmp_path):
    """A NaN in a dict reaches the job's own check, with the command line's reason."""
    with pytest.raises(clearance.JobError) as e:
        clearance.check({"grid": {"z": NAN, "psi": 0.0, "theta": 0.0}})
    assert str(e.value) == "job: `grid.z`: must be a finite number, got NaN"
    job = tmp_path / "nan.toml"
    job.write_text("[grid]\nz = nan\npsi = 0.0\ntheta = 0.0\n")
    cli = subprocess.run(
        cli_command("check", str(job), "--no-timing"),
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert cli.returncode == 2
    assert cli.stderr.strip() == f"error: {job}: `grid.z`: must be a finite number, got NaN"


# run: (id, exception, the argument named, keywords besides job and out).
RUN_CASES = [
    ("threads-negative", ValueError, "threads", dict(threads=-1)),
    ("threads-zero", ValueError, "threads", dict(threads=0)),
    ("threads-type", TypeError, "threads", dict(threads="all")),
    ("shard-range", ValueError, "shard", dict(shard=(2, 2))),
    ("shard-negative", ValueError, "shard", dict(shard=(-1, 2))),
    ("shard-zero-count", ValueError, "shard", dict(shard=(0, 0))),
    ("shard-text", TypeError, "shard", dict(shard="0/2")),
    ("shard-three", TypeError, "shard", dict(shard=(0, 2, 4))),
    ("shard-floats", TypeError, "shard", dict(shard=(0.0, 2.0))),
    ("resume-type", TypeError, "resume", dict(resume="yes")),
    ("overwrite-type", TypeError, "overwrite", dict(overwrite=1)),
    ("resume-and-overwrite", ValueError, "overwrite=True", dict(resume=True, overwrite=True)),
    ("columns", ValueError, "columns", dict(columns="all")),
    ("compression-name", ValueError, "compression", dict(compression="gzip")),
    ("compression-type", TypeError, "compression", dict(compression=None)),
    ("precision-name", ValueError, "precision", dict(precision="half")),
    ("precision-type", TypeError, "precision", dict(precision=32)),
    ("chunk-size-zero", ValueError, "chunk_size", dict(chunk_size=0)),
    ("chunk-size-negative", ValueError, "chunk_size", dict(chunk_size=-5)),
    ("chunk-size-type", TypeError, "chunk_size", dict(chunk_size=1.5)),
    ("progress", TypeError, "progress", dict(progress=1)),
    ("solver-name", ValueError, "solver", dict(solver="dense")),
    ("solver-type", TypeError, "solver", dict(solver=None)),
    ("writer-name", ValueError, "writer", dict(writer="stock")),
    ("writer-type", TypeError, "writer", dict(writer=1)),
]


@pytest.mark.parametrize("exc, argument, kwargs", [c[1:] for c in RUN_CASES], ids=[c[0] for c in RUN_CASES])
def test_run_refuses(exc, argument, kwargs, tmp_path):
    out = tmp_path / "run"
    refused(exc, argument, lambda: clearance.run(JOB, out, **kwargs), out)


def test_run_refuses_an_out_of_the_wrong_type():
    refused(TypeError, "out", lambda: clearance.run(JOB, 3))


def test_run_refuses_an_empty_out(tmp_path):
    refused(ValueError, "out", lambda: clearance.run(JOB, ""), tmp_path)


def test_run_refuses_an_out_that_is_a_file(tmp_path):
    out = tmp_path / "run"
    out.write_text("notes")
    refused(ValueError, "out", lambda: clearance.run(JOB, out), tmp_path)


def test_run_into_a_run_names_resume_and_overwrite(tmp_path):
    """The issue's message: the Python arguments, not the command line's flags."""
    out = tmp_path / "run"
    clearance.run(JOB, out)
    message = refused(ValueError, "out", lambda: clearance.run(JOB, out), out)
    assert "resume=True" in message and "overwrite=True" in message, message
    assert clearance.run(JOB, out, resume=True)["computed"] == 0
    assert clearance.run(JOB, out, overwrite=True)["complete"]


def test_resume_into_another_jobs_run_names_overwrite(tmp_path):
    out = tmp_path / "run"
    clearance.run(JOB, out)
    message = refused(ValueError, "out", lambda: clearance.run(OTHER_JOB, out, resume=True), out)
    assert "overwrite=True" in message, message
    message = refused(ValueError, "out", lambda: clearance.run(OTHER_JOB, out, shard=(0, 2)), out)
    assert "overwrite=True" in message, message


def test_resume_with_another_precision_or_columns_names_the_argument(tmp_path):
    """The parts of a run share a schema: resuming with another precision or column
    set is refused in Python's terms, and with the run's own it goes on."""
    out = tmp_path / "run"
    clearance.run(JOB, out, precision="single")
    message = refused(ValueError, "out", lambda: clearance.run(JOB, out, resume=True), out)
    assert "precision='single'" in message and "precision='double'" in message, message
    message = refused(
        ValueError, "out", lambda: clearance.run(JOB, out, resume=True, precision="single", columns="full"), out
    )
    assert "columns='standard'" in message and "columns='full'" in message, message
    assert clearance.run(JOB, out, resume=True, precision="single")["computed"] == 0


def test_resume_or_shard_with_another_chunk_size_names_the_argument(tmp_path):
    """A part's name is its chunk's number: resuming (or adding a shard) with another
    chunk_size would cut other parts under the same names, and is refused in Python's
    terms; with the run's own it goes on."""
    out = tmp_path / "run"
    clearance.run(JOB, out, chunk_size=4)
    for asked in (dict(resume=True), dict(shard=(1, 2))):
        message = refused(ValueError, "out", lambda: clearance.run(JOB, out, chunk_size=5, **asked), out)
        assert "chunk_size=5" in message and "has 4 samples" in message, message
    assert clearance.run(JOB, out, resume=True, chunk_size=4)["computed"] == 0


@pytest.mark.parametrize("asked", [dict(resume=True), dict(overwrite=True), dict(shard=(1, 2))])
def test_a_folder_that_holds_no_run_is_kept(asked, tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("\\begin{document}")
    message = refused(ValueError, "out", lambda: clearance.run(JOB, out, **asked), out)
    assert "not a clearance run" in message, message


def test_check_refuses_a_job_of_the_wrong_type():
    refused(TypeError, "job", lambda: clearance.check(["grid"]))


def test_plot_refuses_a_dir_of_the_wrong_type():
    refused(TypeError, "dir", lambda: clearance.plot(None))


@pytest.mark.parametrize("what", ["missing", "empty", "file", "unfinished"])
def test_plot_refuses_a_dir_that_holds_no_finished_run(what, tmp_path):
    dir = tmp_path / "run"
    if what == "empty":
        dir.mkdir()
    elif what == "file":
        dir.write_text("")
    elif what == "unfinished":
        clearance.run(JOB, dir)
        (dir / "_SUCCESS").unlink()
    plots = tmp_path / "plots"
    refused(ValueError, "dir", lambda: clearance.plot(dir, plots), dir, plots)


@pytest.mark.parametrize("what", ["type", "file"])
def test_plot_refuses_an_out_that_is_no_folder(what, tmp_path):
    dir = tmp_path / "run"
    clearance.run(JOB, dir)
    plots = tmp_path / "plots.png"
    plots.write_bytes(b"\x89PNG")
    out = 3 if what == "type" else plots
    refused(TypeError if what == "type" else ValueError, "out", lambda: clearance.plot(dir, out), dir, plots)
