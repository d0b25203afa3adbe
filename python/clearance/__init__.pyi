"""Type stubs of ``clearance`` (the docstrings are in ``clearance/__init__.py``).

An argument of the wrong type raises ``TypeError``, a value an argument does not
take ``ValueError``, a job that is not valid ``JobError``: each message names the
argument, and nothing is computed or written.
"""

import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, TypedDict, Union

import numpy.typing as npt
import pyarrow as pa

__version__: str

# A path, TOML text, or a dict of the job's keys (numbers, strings, bools, lists, dicts).
Job = Union[str, os.PathLike[str], Mapping[str, Any]]
Progress = Union[bool, Callable[[int, int], Any], None]
# A real number or a 1-d array of real numbers, all finite.
Floats = Union[float, npt.ArrayLike]

class JobError(ValueError):
    """A job that is not valid; the message is the command line's."""

class RunReport(TypedDict):
    computed: int
    total: int
    seconds: float
    complete: bool

def solve(
    job: Job,
    *,
    x: Optional[Floats] = None,
    y: Optional[Floats] = None,
    z: Optional[Floats] = None,
    phi: Optional[Floats] = None,
    psi: Optional[Floats] = None,
    theta: Optional[Floats] = None,
    columns: str = "standard",
    solver: str = "fast",
    threads: Optional[int] = None,
    progress: Progress = None,
) -> pa.Table:
    """Computes ``job`` in memory: a ``variant`` column, then the columns of a run's poses.

    ``x``, ``y``, ``z``, ``phi``, ``psi``, ``theta``: poses in place of the job's, the
    coordinates it takes (``z``, ``psi``, ``theta`` for the 3-limb kinds, a custom
    mechanism's inputs) or none, arrays of one length (a number is broadcast), finite
    (a NaN or infinity raises ``ValueError`` naming the argument and index). ``columns``: minimal, standard or full; ``solver``: fast or general
    (general for the 3-limb kinds only: a 6-UPS or custom job raises ``ValueError``);
    ``threads``: None (all cores) or an int from 1 to 4096; ``progress``: a bool, None
    or a callable(done, total).
    """

def run(
    job: Job,
    out: Union[str, os.PathLike[str]],
    threads: Optional[int] = None,
    shard: Optional[Tuple[int, int]] = None,
    resume: bool = False,
    *,
    overwrite: bool = False,
    columns: str = "standard",
    compression: str = "zstd",
    chunk_size: int = 65536,
    progress: Progress = None,
    precision: str = "double",
    solver: str = "fast",
    writer: str = "engine",
) -> RunReport:
    """Runs ``job`` into ``out``: the dataset of ``clearance run``.

    ``out``: a folder, not a file; one that is not empty needs ``resume=True`` (the
    same job's run) or ``overwrite=True`` (a run), not both. ``threads``: None (all
    cores) or an int from 1 to 4096; ``shard``: None or ``(i, n)`` with
    ``0 <= i < n``; ``columns``: minimal, standard or full; ``compression``: none,
    lz4 or zstd; ``chunk_size``: a positive int; ``precision``: double, or single
    (the error, envelope and margin columns of the pose files as float32);
    ``solver``: fast or general (the 3-limb kinds only); ``writer``: engine or arrow
    (the part files' encoder, the same table).
    """

def check(job: Job) -> dict[str, Any]:
    """The plan of ``job``, as ``clearance check`` prints it."""

def allocate(
    job: Job,
    max_dp: float,
    *,
    max_dalpha: Optional[float] = None,
    model: str = "takeup",
    per_limb: bool = False,
    threads: Optional[int] = None,
    progress: Progress = None,
) -> dict[str, Any]:
    """The cheapest magnitudes of the job's ``[allocate]`` kinds for the budget, as
    ``allocation.json``. ``model``: takeup or envelope; an infeasible budget raises
    ``ValueError`` with the reason."""

def plot(dir: Union[str, os.PathLike[str]], out: Union[str, os.PathLike[str], None] = None) -> Sequence[str]:
    """The figures of the finished run in ``dir`` (a folder holding one, else
    ``ValueError``) written into the folder ``out``; the paths written."""
