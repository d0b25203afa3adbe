"""Pose errors of parallel robots due to joint clearances.

The engine of the ``clearance`` command line, in Python:

- :func:`solve` computes a job in memory and returns a ``pyarrow.Table`` with the
  columns of a run's ``poses`` (docs/interface.md §5), for the job's grid or
  trajectory or for poses given as NumPy arrays;
- :func:`run` writes the same dataset as ``clearance run``;
- :func:`check` returns a job's plan; :func:`plot` draws a finished run.

A job is a path to a TOML file, TOML text, or a dict of the same keys. A job that
is not valid raises :class:`JobError` with the command line's message. Any other
argument that is wrong raises ``TypeError`` (not a type it takes) or
``ValueError`` (not a value it takes) before anything is computed or written,
with a message that names the argument. The GIL is released while the engine
computes, so calls in several threads run at once.
"""

from __future__ import annotations

import json
import math
import operator
import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pyarrow as pa

from . import _clearance
from ._clearance import JobError

__all__ = ["JobError", "solve", "run", "check", "allocate", "plot", "__version__"]
__version__ = _clearance.__version__

Job = Union[str, "os.PathLike[str]", Mapping[str, Any]]

# The command line's environment variables, with the same meaning here.
if os.environ.get("CLEARANCE_ISA"):
    try:
        _clearance.cap_isa(os.environ["CLEARANCE_ISA"])
    except ValueError:
        pass


# The most threads a call takes: more than any machine's cores, fewer than would
# exhaust a process's threads.
_MAX_THREADS = 4096


def _type(value: Any) -> str:
    return type(value).__name__


def _job(job: Job) -> Tuple[str, str]:
    """(kind, value) for the native module: a path, or TOML text (a dict's too)."""
    if isinstance(job, Mapping):
        return "toml", _clearance.dict_toml(job)
    if isinstance(job, os.PathLike):
        return "path", os.fsdecode(os.fspath(job))
    if isinstance(job, str):
        if "\n" not in job and (job.endswith(".toml") or os.path.exists(job)):
            return "path", job
        return "toml", job
    raise TypeError(f"job must be a path (str or os.PathLike), TOML text (str) or a dict, got {_type(job)}")


def _folder(name: str, value: Any) -> str:
    """A folder argument as a str: a path that is not a file."""
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} must be a path (str or os.PathLike), got {_type(value)}")
    path = os.fsdecode(os.fspath(value))
    if not path:
        raise ValueError(f"{name} must name a folder, got ''")
    if os.path.exists(path) and not os.path.isdir(path):
        raise ValueError(f"{name}: {path} is a file, not a folder")
    return path


def _int(name: str, value: Any, accepted: str) -> int:
    """An int argument: an int or a NumPy integer, not a bool."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be {accepted}, got bool")
    try:
        return operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be {accepted}, got {_type(value)}") from None


def _threads(threads: Any) -> Optional[int]:
    """``threads``: None (all cores) or an int from 1 to _MAX_THREADS."""
    if threads is None:
        return None
    accepted = f"None (all cores) or an int from 1 to {_MAX_THREADS}"
    n = _int("threads", threads, accepted)
    if not 1 <= n <= _MAX_THREADS:
        raise ValueError(f"threads must be {accepted}, got {n}")
    return n


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {_type(value)}")
    return bool(value)


def _name(name: str, value: Any, names: Sequence[str]) -> str:
    """A str argument that takes one of ``names`` (the native module checks which)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, one of {', '.join(map(repr, names))}; got {_type(value)}")
    return value


def _progress(progress: Union[bool, Callable[[int, int], Any], None], desc: str):
    """A callback(done, total) and a closer, from ``progress``: True draws a tqdm bar
    if tqdm is installed (else nothing), a callable is called as is."""
    if progress is None or progress is False:
        return None, lambda: None
    if callable(progress):
        return progress, lambda: None
    if progress is not True:
        raise TypeError(f"progress must be True, False, None or a callable(done, total), got {_type(progress)}")
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


_KINDS = {"b": "bools", "c": "complex numbers", "O": "objects", "U": "strings", "S": "bytes", "M": "datetimes"}


def _floats(name: str, values: Any) -> np.ndarray:
    """A pose argument as float64: a real number or a 1-d array of them. Whether an
    array's values are finite is the engine's check (it names the first index that
    is not)."""
    accepted = "a number or a 1-d array of numbers"
    try:
        a = np.asarray(values)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} must be {accepted}: {e}") from None
    if a.dtype.kind not in "iuf":
        got = _type(values) if a.ndim == 0 else f"an array of {_KINDS.get(a.dtype.kind, a.dtype.name)}"
        raise TypeError(f"{name} must be {accepted}, got {got}")
    if a.ndim > 1:
        raise ValueError(f"{name} must be {accepted}, got an array of shape {a.shape}")
    a = a.astype(np.float64, copy=False)
    if a.ndim == 0 and not math.isfinite(a):
        shown = "NaN" if math.isnan(a) else str(float(a))  # as the engine names an array's
        raise ValueError(f"{name} is {shown}: a pose's z, psi and theta must be finite numbers")
    return a


COORDS = ("x", "y", "z", "phi", "psi", "theta")


def _poses(**coords: Any) -> dict:
    """The native module's coordinates (float64 bytes) of the poses given, or nothing
    for the job's own samples. Which coordinates a job takes (``z``, ``psi`` and
    ``theta`` for the 3-limb kinds, its inputs for a custom mechanism) is checked by
    the engine, which knows the job."""
    given = {k: v for k, v in coords.items() if v is not None}
    if not given:
        return {}
    arrays = {k: _floats(k, v) for k, v in given.items()}
    lengths = {k: a.size for k, a in arrays.items() if a.ndim == 1}
    if len(set(lengths.values())) > 1:
        names = [k for k in COORDS if k in given]
        got = ", ".join(f"{k} has {n}" for k, n in lengths.items())
        raise ValueError(f"{_listed(names)} must have the same length: {got}")
    n = next(iter(lengths.values()), 1)
    return {k: (np.full(n, a) if a.ndim == 0 else a).tobytes() for k, a in arrays.items()}


def _listed(names: list) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def solve(
    job: Job,
    *,
    x: Any = None,
    y: Any = None,
    z: Any = None,
    phi: Any = None,
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

    What each argument takes; anything else raises ``TypeError`` (a wrong type)
    or ``ValueError`` (a wrong value) naming the argument, before anything is
    computed:

    - ``job``: a path (``os.PathLike``, or a ``str`` ending in ``.toml`` or naming
      a file), TOML text, or a dict of the job's keys whose values are numbers,
      strings, bools, lists and dicts (NumPy scalars and arrays count as numbers
      and lists). A job that is not valid raises :class:`JobError`.
    - ``x``, ``y``, ``z``, ``phi``, ``psi``, ``theta``: poses (m, rad) in place of
      the job's grid or trajectory: the coordinates the job takes, all of them
      (``z``, ``psi`` and ``theta`` for the 3-limb kinds; a custom mechanism's
      ``inputs``; a 6-UPS all six), each a real number or a 1-d array of them,
      the arrays of equal length, a number broadcast to that length. Every value
      must be finite: a NaN or an infinity raises ``ValueError`` naming the
      argument and the first such index; a coordinate missing or one the job does
      not take raises ``ValueError`` naming it. Such poses have no velocities, so
      the job's modes must be kinetostatic only.
    - ``columns``: ``"minimal"``, ``"standard"`` or ``"full"``.
    - ``solver``: ``"fast"`` or ``"general"``.
    - ``threads``: ``None`` (all cores) or an int from 1 to 4096: the threads that
      compute the call.
    - ``progress``: ``True`` shows a tqdm bar (if tqdm is installed), a callable
      is called with ``(done, total)`` poses, ``None`` or ``False`` shows nothing.
    """
    kind, value = _job(job)
    poses = _poses(x=x, y=y, z=z, phi=phi, psi=psi, theta=theta)
    columns = _name("columns", columns, ("minimal", "standard", "full"))
    solver = _name("solver", solver, ("fast", "general"))
    threads = _threads(threads)
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
    precision: str = "double",
    solver: str = "fast",
    writer: str = "engine",
) -> dict:
    """Runs ``job`` into the directory ``out``: the same dataset as
    ``clearance run JOB --out OUT`` (docs/interface.md §4).

    Returns ``{"computed", "total", "seconds", "complete"}``.

    What each argument takes; anything else raises ``TypeError`` (a wrong type)
    or ``ValueError`` (a wrong value) naming the argument, before anything is
    written:

    - ``job``: as for :func:`solve`.
    - ``out``: the run's folder (``str`` or ``os.PathLike``), created if needed;
      not a file. A folder that is not empty is refused unless ``resume`` or
      ``overwrite`` is given, and then it must hold a run (of this job, to
      resume it).
    - ``threads``: ``None`` (all cores) or an int from 1 to 4096.
    - ``shard``: ``None``, or a pair ``(i, n)`` of ints with ``0 <= i < n``:
      compute shard ``i`` of ``n`` into ``out``.
    - ``resume``: ``True`` finishes an interrupted run in ``out``, keeping its
      complete part files; ``overwrite``: ``True`` replaces the run in ``out``.
      Each ``True`` or ``False``, not both ``True``.
    - ``columns``: ``"minimal"``, ``"standard"`` or ``"full"``; ``"none"`` writes no
      pose files, only ``summary.parquet`` and ``discontinuities.parquet``.
    - ``compression``: ``"none"``, ``"lz4"`` or ``"zstd"``.
    - ``chunk_size``: samples per part file, a positive int.
    - ``progress``: as for :func:`solve`.
    - ``precision``: ``"double"``, or ``"single"``: the error, envelope and margin
      columns of the pose files stored as float32 (each value rounded, a relative
      change of at most 6e-8); inputs, parasitic motions, actuator positions,
      reactions and the summary stay float64.
    - ``solver``: ``"fast"`` (the 6 × 6 reduced systems) or ``"general"`` (the
      assembled 24 × 24 and 12 × 12 systems); ``"general"`` is for the 3-limb kinds, a
      6-UPS or custom job refuses it (``ValueError``, nothing written), as
      ``clearance run`` does.
    - ``writer``: the encoder of the part files, ``"engine"`` (its own pages) or
      ``"arrow"`` (parquet's ``ArrowWriter``): the same table either way.
    """
    kind, value = _job(job)
    out = _folder("out", out)
    threads = _threads(threads)
    if shard is not None:
        pair = "None or a pair (i, n) of ints with 0 <= i < n"
        if isinstance(shard, (str, bytes)) or not isinstance(shard, Sequence) or len(shard) != 2:
            raise TypeError(f"shard must be {pair}, got {shard!r}")
        i, n = (_int("shard", k, pair) for k in shard)
        if not 0 <= i < n:
            raise ValueError(f"shard must be {pair}, got ({i}, {n})")
        shard = (i, n)
    resume = _flag("resume", resume)
    overwrite = _flag("overwrite", overwrite)
    if resume and overwrite:
        raise ValueError(
            "resume=True and overwrite=True: pass one (resume finishes the run in out, overwrite replaces it)"
        )
    columns = _name("columns", columns, ("none", "minimal", "standard", "full"))
    compression = _name("compression", compression, ("none", "lz4", "zstd"))
    precision = _name("precision", precision, ("double", "single"))
    solver = _name("solver", solver, ("fast", "general"))
    writer = _name("writer", writer, ("engine", "arrow"))
    chunk_size = _int("chunk_size", chunk_size, "a positive int")
    if not 1 <= chunk_size < 2**64:
        raise ValueError(f"chunk_size must be a positive int (below 2**64), got {chunk_size}")
    callback, close = _progress(progress, "run")
    try:
        computed, total, seconds, complete = _clearance.run(
            kind,
            value,
            out,
            threads=threads,
            shard=shard,
            resume=resume,
            overwrite=overwrite,
            columns_name=columns,
            compression=compression,
            precision=precision,
            chunk_size=chunk_size,
            direct_io="CLEARANCE_BUFFERED_IO" not in os.environ,
            progress=callback,
            solver_name=solver,
            writer_name=writer,
        )
    finally:
        close()
    return {"computed": computed, "total": total, "seconds": seconds, "complete": complete}


def check(job: Job) -> dict:
    """Validates ``job`` and returns its plan, as ``clearance check`` prints it:
    ``name``, ``mechanism``, ``samples``, ``sample_count``, ``modes``, ``variants``
    (each ``index`` and ``params``), ``rows`` and, per column set, ``columns`` and
    the most ``bytes`` its poses take before compression.

    ``job`` is as for :func:`solve`: a path, TOML text or a dict (else
    ``TypeError``); a job that is not valid raises :class:`JobError`."""
    kind, value = _job(job)
    return json.loads(_clearance.check(kind, value))


def _budget(name: str, value: Any) -> float:
    """A budget: a positive, finite real number (m or rad)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a positive real number, got {_type(value)}")
    value = float(value)
    if not (value > 0.0 and np.isfinite(value)):
        raise ValueError(f"{name} must be a positive real number, got {value!r}")
    return value


def allocate(
    job: Job,
    max_dp: float,
    *,
    max_dalpha: Optional[float] = None,
    model: str = "takeup",
    per_limb: bool = False,
    threads: Optional[int] = None,
    progress: Union[bool, Callable[[int, int], Any], None] = None,
) -> dict:
    """The cheapest clearance magnitudes for an error budget: ``clearance allocate``
    in memory (docs/model.md §13, docs/interface.md "clearance allocate").

    Minimises ``Σ w_k / c_k`` over the kinds of the job's ``[allocate]`` table
    (its weights and bounds) so that ``|Δp| <= max_dp`` (and ``|Δα| <= max_dalpha``)
    at every ``ok`` or ``indeterminate_contact`` pose of every variant and mode.
    Returns the content of ``allocation.json`` as a dict: ``magnitudes``,
    ``fixed``, ``cost``, ``shadow_price_per_um``, ``largest_dp``, ``binding`` (the
    poses where the budget binds, with their dual values), ``clearance`` (the whole
    table at the answer) and the rest.

    - ``job``: as for :func:`solve`.
    - ``max_dp`` (m), ``max_dalpha`` (rad, or ``None``): positive real numbers.
    - ``model``: ``"takeup"`` (the loads decide each take-up) or ``"envelope"``
      (any take-up).
    - ``per_limb``: ``True`` allocates each limb's joint its own magnitude (the
      job gives each allocated kind as a list of one value per limb).
    - ``threads``, ``progress``: as for :func:`solve`.

    A budget no magnitudes can meet (the kinds not allocated already exceed it,
    or the bounds forbid it) raises ``ValueError`` with the reason.
    """
    kind, value = _job(job)
    max_dp = _budget("max_dp", max_dp)
    if max_dalpha is not None:
        max_dalpha = _budget("max_dalpha", max_dalpha)
    model = _name("model", model, ("takeup", "envelope"))
    per_limb = _flag("per_limb", per_limb)
    threads = _threads(threads)
    callback, close = _progress(progress, "allocate")
    try:
        text = _clearance.allocate(
            kind,
            value,
            max_dp,
            max_dalpha=max_dalpha,
            model=model,
            per_limb=per_limb,
            threads=threads,
            progress=callback,
        )
    finally:
        close()
    return json.loads(text)


def plot(dir: Union[str, "os.PathLike[str]"], out: Union[str, "os.PathLike[str]", None] = None) -> Sequence[str]:
    """Draws the figures of the finished run in ``dir`` (``clearance plot``) into
    ``out`` (default ``dir/plots``); returns the paths written.

    ``dir`` and ``out`` are folders (``str`` or ``os.PathLike``, else
    ``TypeError``), not files (else ``ValueError``). A ``dir`` that does not hold a
    finished run raises ``ValueError``; ``out`` is created if needed."""
    dir = _folder("dir", dir)
    if out is not None:
        out = _folder("out", out)
    files = _clearance.plot(dir, out)
    return [os.fspath(f) for f in files]
