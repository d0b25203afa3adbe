"""Type stubs of ``clearance`` (the docstrings are in ``clearance/__init__.py``)."""

import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, TypedDict, Union

import numpy.typing as npt
import pyarrow as pa

__version__: str

Job = Union[str, os.PathLike[str], Mapping[str, Any]]
Progress = Union[bool, Callable[[int, int], Any], None]
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
    z: Optional[Floats] = None,
    psi: Optional[Floats] = None,
    theta: Optional[Floats] = None,
    columns: str = "standard",
    solver: str = "fast",
    threads: Optional[int] = None,
    progress: Progress = None,
) -> pa.Table:
    """Computes ``job`` in memory: a ``variant`` column, then the columns of a run's poses."""

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
) -> RunReport:
    """Runs ``job`` into ``out``: the dataset of ``clearance run``."""

def check(job: Job) -> dict[str, Any]:
    """The plan of ``job``, as ``clearance check`` prints it."""

def plot(dir: Union[str, os.PathLike[str]], out: Union[str, os.PathLike[str], None] = None) -> Sequence[str]:
    """The figures of the finished run in ``dir``; the paths written."""
