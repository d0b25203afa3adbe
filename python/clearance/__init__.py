"""Pose errors of parallel robots due to joint clearances.

The engine of the ``clearance`` command line, in Python:

- :func:`solve` computes a job in memory and returns a ``pyarrow.Table`` with the
  columns of a run's ``poses`` (docs/interface.md §5), for the job's grid or
  trajectory or for poses given as NumPy arrays;
- :func:`run` writes the same dataset as ``clearance run``;
- :func:`check` returns a job's plan; :func:`plot` draws a finished run.

A job is a path to a TOML file, TOML text, or a dict of the same keys. A job that
is not valid raises :class:`JobError` with the command line's message. The GIL is
released while the engine computes, so calls in several threads run at once.
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pyarrow as pa

from . import _clearance
from ._clearance import JobError

__all__ = ["JobError", "solve", "run", "check", "plot", "__version__"]
__version__ = _clearance.__version__

Job = Union[str, "os.PathLike[str]", Mapping[str, Any]]

# The command line's environment variables, with the same meaning here.
if os.environ.get("CLEARANCE_ISA"):
    try:
        _clearance.cap_isa(os.environ["CLEARANCE_ISA"])
    except ValueError:
        pass


def _job(job: Job) -> Tuple[str, str]:
    """(kind, value) for the native module: a path, or TOML text (a dict's too)."""
    if isinstance(job, Mapping):
        return "toml", _clearance.dict_toml(job)
    if isinstance(job, os.PathLike):
        return "path", os.fspath(job)
    if isinstance(job, str):
        if "\n" not in job and (job.endswith(".toml") or os.path.exists(job)):
            return "path", job
        return "toml", job
    raise TypeError(f"a job is a path, TOML text or a dict, not {type(job).__name__}")


def _progress(progress: Union[bool, Callable[[int, int], Any], None], desc: str):
    """A callback(done, total) and a closer, from ``progress``: True draws a tqdm bar
    if tqdm is installed (else nothing), a callable is called as is."""
    if progress is None or progress is False:
        return None, lambda: None
    if callable(progress):
        return progress, lambda: None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None, lambda: None
    bar = tqdm(total=0, desc=desc, unit="pose", unit_scale=True)

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.update(done - bar.n)

    return update, bar.close


def _f64(name: str, values: Any, n: int) -> bytes:
    a = np.asarray(values, dtype=np.float64)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.ndim != 1:
        raise ValueError(f"{name} must be a scalar or a 1-d array, got shape {a.shape}")
    return np.ascontiguousarray(a).tobytes()


def solve(
    job: Job,
    *,
    z: Any = None,
    psi: Any = None,
    theta: Any = None,
    columns: str = "standard",
    solver: str = "fast",
    threads: Optional[int] = None,
    progress: Union[bool, Callable[[int, int], Any], None] = None,
) -> pa.Table:
    """Computes ``job`` in memory; no file is written.

    Returns a ``pyarrow.Table`` with a ``variant`` column (uint64) followed by the
    columns, values and nulls of a run's ``poses`` part files (``columns``:
    ``minimal``, ``standard`` or ``full``), one block of rows per (variant, mode)
    in the order a run writes them.

    ``z``, ``psi`` and ``theta`` replace the job's grid or trajectory by an explicit
    list of poses (m, rad, rad): arrays of equal length, or scalars broadcast to the
    arrays' length. Such poses have no velocities, so the job's modes must be
    kinetostatic only. ``threads`` bounds the threads (default: all cores);
    ``progress=True`` shows a tqdm bar (if tqdm is installed), or a callable gets
    ``(done, total)`` poses.
    """
    kind, value = _job(job)
    arrays = {"z": z, "psi": psi, "theta": theta}
    given = {k: v for k, v in arrays.items() if v is not None}
    poses: dict = {}
    if given:
        sizes = {np.size(v) for v in given.values() if np.ndim(v) > 0}
        if len(sizes) > 1:
            raise ValueError(f"z, psi and theta must have the same length, got {sizes}")
        if len(given) < 3:
            raise ValueError("give all of z, psi and theta (scalars are broadcast)")
        n = sizes.pop() if sizes else 1
        poses = {k: _f64(k, v, n) for k, v in given.items()}
    callback, close = _progress(progress, "solve")
    try:
        batches = _clearance.solve(
            kind, value, columns, solver, threads=threads, progress=callback, **poses
        )
    finally:
        close()
    return pa.Table.from_batches(batches)


def run(
    job: Job,
    out: Union[str, "os.PathLike[str]"],
    threads: Optional[int] = None,
    shard: Optional[Tuple[int, int]] = None,
    resume: bool = False,
    *,
    overwrite: bool = False,
    columns: str = "standard",
    compression: str = "zstd",
    chunk_size: int = 65536,
    progress: Union[bool, Callable[[int, int], Any], None] = None,
) -> dict:
    """Runs ``job`` into the directory ``out``: the same dataset as
    ``clearance run JOB --out OUT`` (docs/interface.md §4).

    ``shard=(i, n)`` computes shard ``i`` of ``n``; ``resume`` finishes an
    interrupted run; ``overwrite`` replaces an earlier one. Returns
    ``{"computed", "total", "seconds", "complete"}``.
    """
    kind, value = _job(job)
    callback, close = _progress(progress, "run")
    try:
        computed, total, seconds, complete = _clearance.run(
            kind,
            value,
            os.fspath(out),
            threads=threads,
            shard=tuple(shard) if shard is not None else None,
            resume=resume,
            overwrite=overwrite,
            columns_name=columns,
            compression=compression,
            chunk_size=chunk_size,
            direct_io="CLEARANCE_BUFFERED_IO" not in os.environ,
            progress=callback,
        )
    finally:
        close()
    return {"computed": computed, "total": total, "seconds": seconds, "complete": complete}


def check(job: Job) -> dict:
    """Validates ``job`` and returns its plan, as ``clearance check`` prints it:
    ``name``, ``mechanism``, ``samples``, ``sample_count``, ``modes``, ``variants``
    (each ``index`` and ``params``), ``rows`` and, per column set, ``columns`` and
    the most ``bytes`` its poses take before compression."""
    kind, value = _job(job)
    return json.loads(_clearance.check(kind, value))


def plot(dir: Union[str, "os.PathLike[str]"], out: Union[str, "os.PathLike[str]", None] = None) -> Sequence[str]:
    """Draws the figures of the finished run in ``dir`` (``clearance plot``) into
    ``out`` (default ``dir/plots``); returns the paths written."""
    files = _clearance.plot(os.fspath(dir), None if out is None else os.fspath(out))
    return [os.fspath(f) for f in files]
