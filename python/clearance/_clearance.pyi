"""The native module behind ``clearance`` (use the functions of ``clearance``)."""

import os
from typing import Any, Callable, Mapping, Optional, Tuple

import pyarrow as pa

__version__: str

class JobError(ValueError): ...

def solve(
    kind: str,
    value: str,
    columns_name: str,
    solver_name: str,
    x: Optional[bytes] = None,
    y: Optional[bytes] = None,
    z: Optional[bytes] = None,
    phi: Optional[bytes] = None,
    psi: Optional[bytes] = None,
    theta: Optional[bytes] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> list[pa.RecordBatch]: ...
def run(
    kind: str,
    value: str,
    out: str,
    threads: Optional[int] = None,
    shard: Optional[Tuple[int, int]] = None,
    resume: bool = False,
    overwrite: bool = False,
    columns_name: str = "standard",
    compression: str = "zstd",
    precision: str = "double",
    chunk_size: int = 65536,
    direct_io: bool = True,
    progress: Optional[Callable[[int, int], Any]] = None,
    solver_name: str = "fast",
    writer_name: str = "engine",
) -> Tuple[int, int, float, bool]: ...
def check(kind: str, value: str) -> str: ...
def allocate(
    kind: str,
    value: str,
    max_dp: float,
    max_dalpha: Optional[float] = None,
    model: str = "takeup",
    per_limb: bool = False,
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
) -> str: ...
def plot(dir: str, out: Optional[str] = None) -> list[os.PathLike[str]]: ...
def cap_isa(name: str) -> None: ...
def dict_toml(job: Mapping[str, Any]) -> str: ...
