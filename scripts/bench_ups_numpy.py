#!/usr/bin/env python3
"""The engine against the vectorised NumPy reference on one 6-UPS job, side by side.

For one 6-UPS job (default benches/suite/ups_grid.toml, the suite's `ups_grid`), in
one process and in alternated rounds (NumPy, engine 1 thread, engine 2 threads,
NumPy, ...) so that load on a shared machine hits all of them alike:

* NumPy: ``reference_ups.compute(job, columns=C)`` for each column set C (poses/s of
  the call: sampling, inverse kinematics, the 42 x 42 reactions, take-up, the 30 x 30
  error system, every output column as arrays; no file written). ``compute`` works
  out every column whatever C is, the worst-case envelope and the dominant joint
  included, which the engine does not compute for this kind, so the script also times
  ``reference_ups.pipeline`` on the same poses ("numpy kernel": the kinetostatic
  pipeline alone, all three kinds, no envelope, no column assembly) as NumPy's best
  case;
* the engine: ``clearance run JOB --out DIR --threads N --columns C`` for N = 1 and 2, timed by wall clock (process start, the pose pass, the
  discontinuity search, Parquet written and synced: everything), and, from the
  engine's own last progress line (``progress: N/N poses (100.0%), R poses/s``), the
  rate of its pose pass alone (solving and writing the parts, before the search): the
  figure to set beside NumPy's, which searches nothing and writes nothing. The 6-UPS
  has one solver (each leg reduced to its force along it, two 6 × 6 systems a pose);
  ``--solver general`` is refused for it.

Each figure is the best of ``--rounds``. Before the table, once, the engine's first
run (the richest column set, 1 thread) is checked against NumPy's first result for
the same set: statuses equal, nulls in the same places, and q1..q6, err_* (and
per-kind errors and margins where the set has them) within 1e-9 of the column's
largest magnitude, so that the two compute the same thing. A mismatch exits 1.

NumPy's LAPACK is held to one thread (``--numpy-threads``, set before numpy is
imported); batched ``np.linalg.solve`` calls LAPACK once per small matrix, so one
core is all it uses either way, and the 1-thread engine figure is the like-for-like
one.

    python3 scripts/bench_ups_numpy.py [JOB] [--scale F] [--rounds 3] [--bin target/release/clearance]
                                       [--columns minimal,standard] [--json]

``--scale F`` runs about F times the job's samples (each grid range scaled by the
same factor, as ``clearance bench --suite --scale``); the scaled job is written to a
temporary file that both sides read. Exit 0 when the check passes, 1 when it fails
or a run fails, 2 on a bad command line or job.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_JOB = ROOT / "benches" / "suite" / "ups_grid.toml"
INPUTS = ("x", "y", "z", "phi", "psi", "theta")
RTOL = 1e-9


# --------------------------------------------------------------------------
# The job: scaled as `clearance bench --suite --scale` scales it, written back as TOML
# --------------------------------------------------------------------------
def _round_half_away(v: float) -> int:
    return int(math.floor(v + 0.5))


def scale_job(job: dict, scale: float) -> dict:
    """`job` with about `scale` times its samples (crates/cli/src/bench.rs, `scaled`):
    each grid range `scale^(1/d)` times its values, the shortest ranges first, at least 2
    values each; a trajectory `scale` times its times."""
    job = json.loads(json.dumps(job))            # deep copy
    if scale == 1.0:
        return job
    resize = lambda n, f: max(2, _round_half_away(n * f))  # noqa: E731
    if "grid" in job:
        g = job["grid"]
        ranges = [k for k in INPUTS if isinstance(g.get(k), dict)]
        ranges.sort(key=lambda k: g[k]["n"])     # stable, as Rust's sort_by_key
        left, d = scale, len(ranges)
        for i, k in enumerate(ranges):
            before = g[k]["n"]
            g[k]["n"] = resize(before, left ** (1.0 / (d - i)))
            left /= g[k]["n"] / before
    if "trajectory" in job and isinstance(job["trajectory"].get("time"), dict):
        t = job["trajectory"]["time"]
        t["n"] = resize(t["n"], scale)
    return job


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(job: dict) -> str:
    """A job dict as TOML: top-level keys, then one table per section (values inline)."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in job.items() if not isinstance(v, dict)]
    for sec, body in job.items():
        if isinstance(body, dict):
            lines += ["", f"[{sec}]"] + [f"{k} = {_toml_value(v)}" for k, v in body.items()]
    return "\n".join(lines) + "\n"


def samples_of(job: dict) -> int:
    if "grid" in job:
        return math.prod(job["grid"][k]["n"] if isinstance(job["grid"].get(k), dict) else 1 for k in INPUTS)
    return job["trajectory"]["time"]["n"]


# --------------------------------------------------------------------------
# The two sides
# --------------------------------------------------------------------------
def time_numpy(ru, job, columns, chunk):
    t0, c0 = time.perf_counter(), time.process_time()
    cols = ru.compute(job, columns=columns, chunk=chunk)
    return time.perf_counter() - t0, time.process_time() - c0, cols


def time_numpy_kernel(ru, np, job, chunk):
    """reference_ups.pipeline (kinetostatic, no envelope, no columns) over the job's poses."""
    P = ru.normalize_job(job)
    inp = ru.sample_inputs(P)
    n = inp["x"].size
    t0, c0 = time.perf_counter(), time.process_time()
    counts = np.zeros(4, int)
    for s0 in range(0, n, chunk):
        sl = slice(s0, min(n, s0 + chunk))
        _, st = ru.pipeline(P, *[inp[k][sl] for k in ru.INPUTS])
        counts += np.bincount(st, minlength=4)
    return time.perf_counter() - t0, time.process_time() - c0, n


PROGRESS = re.compile(r"progress: (\d+)/(\d+) poses \(100\.0%\), (\d+) poses/s")


def run_engine(binary, job_path, out, threads, columns):
    """Wall seconds of one `clearance run`, and the pose pass's poses/s from the engine's
    own last progress line (None if it printed none): the run without `--quiet`, its
    stderr (plain progress lines, not a terminal) captured."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [str(binary), "run", str(job_path), "--out", str(out), "--threads", str(threads),
           "--columns", columns]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    secs = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {proc.stderr.strip()}")
    found = PROGRESS.findall(proc.stderr)
    return secs, (float(found[-1][2]) if found else None)


# --------------------------------------------------------------------------
# The check: the engine's output against NumPy's, same job, same columns
# --------------------------------------------------------------------------
def check(np, out_dir, ref, columns):
    """Returns (ok, message lines). `ref` is compute()'s dict for the same column set."""
    import pyarrow.dataset as ds

    t = ds.dataset(Path(out_dir) / "poses", format="parquet", partitioning="hive").to_table()
    t = t.sort_by([("mode", "ascending"), ("sample", "ascending")])
    eng = {name: t.column(name).to_numpy(zero_copy_only=False) for name in t.column_names}
    msgs, ok = [], True
    n = len(ref["sample"])
    if t.num_rows != n:
        return False, [f"row count: engine {t.num_rows}, numpy {n}"]
    # NumPy's modes are concatenated in the job's order; sort it the same way.
    order = np.lexsort((ref["sample"].astype(np.uint64), ref["mode"].astype(str)))
    r = {k: np.asarray(v)[order] for k, v in ref.items()}
    if not np.array_equal(eng["sample"].astype(np.uint64), r["sample"].astype(np.uint64)):
        return False, ["sample numbers differ"]
    st_e, st_r = eng["status"].astype(str), r["status"].astype(str)
    if not np.array_equal(st_e, st_r):
        bad = np.flatnonzero(st_e != st_r)
        msgs.append(f"status differs at {bad.size} rows, first sample {int(r['sample'][bad[0]])}: "
                    f"engine {st_e[bad[0]]}, numpy {st_r[bad[0]]}")
        ok = False
    counts = dict(zip(*np.unique(st_e, return_counts=True)))
    msgs.append("statuses: " + ", ".join(f"{k} {int(v)}" for k, v in counts.items()))
    # mu_i (and so margin_u<i>_angular, m_u<i>) is round-off (docs/model.md 10.3): not compared.
    skip = lambda c: c.startswith("margin_u") and c.endswith("_angular") or c.startswith("m_u")  # noqa: E731
    names = [c for c in ref if c in eng and c not in ("variant", "mode", "sample", "status")
             and not skip(c) and r[c].dtype != object]
    worst, worst_col, compared = 0.0, "", 0
    for c in names:
        e = np.asarray(eng[c], float)
        m = np.asarray(r[c], float)
        ne, nm = np.isnan(e), np.isnan(m)
        if not np.array_equal(ne, nm):
            msgs.append(f"{c}: nulls differ at {int((ne != nm).sum())} rows")
            ok = False
            continue
        if (~nm).any():
            scale = float(np.abs(m[~nm]).max())
            dev = float(np.abs(e[~nm] - m[~nm]).max())
            rel = dev / scale if scale > 0 else (0.0 if dev == 0 else math.inf)
            if rel > worst:
                worst, worst_col = rel, c
            if not rel <= RTOL:
                msgs.append(f"{c}: differs by {rel:.3e} of its largest magnitude {scale:.3e}")
                ok = False
        compared += 1
    wanted = [f"q{i}" for i in range(1, 7)] + ["err_x", "err_y", "err_z", "err_rx", "err_ry", "err_rz"]
    missing = [c for c in wanted if c not in names]
    msgs.append(f"{compared} columns ({columns}) compared on {n} rows, worst {worst:.2e} of the column's "
                f"largest magnitude ({worst_col or '-'}), tolerance {RTOL:g}"
                + (f"; not in this column set: {', '.join(missing)}" if missing else ""))
    return ok, msgs


# --------------------------------------------------------------------------
def host_info():
    info = {"python": platform.python_version(), "cpus": os.cpu_count()}
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        for line in text.splitlines():
            key, _, val = line.partition(":")
            if key.strip() == "Model name":
                info["cpu"] = val.strip()
            if key.strip() == "Flags":
                flags = set(val.split())
                info["avx2"] = "avx2" in flags
                info["avx512f"] = "avx512f" in flags
    except OSError:
        pass
    try:
        info["loadavg"] = [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]
    except OSError:
        pass
    return info


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("job", nargs="?", default=str(DEFAULT_JOB), help="a 6-UPS job file (default: %(default)s)")
    ap.add_argument("--scale", type=float, default=1.0, help="about this many times the job's samples")
    ap.add_argument("--rounds", type=int, default=3, help="alternated rounds; each figure is the best")
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "clearance"), help="the clearance binary")
    ap.add_argument("--columns", default="minimal,standard",
                    help="column sets, comma-separated (minimal, standard, full); default %(default)s")
    ap.add_argument("--threads", default="1,2", help="engine thread counts, comma-separated")
    ap.add_argument("--chunk", type=int, default=2048, help="poses per NumPy batch")
    ap.add_argument("--numpy-threads", type=int, default=1, help="BLAS/LAPACK threads for NumPy")
    ap.add_argument("--no-kernel", action="store_true", help="leave out the NumPy kernel (pipeline) timing")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    a = ap.parse_args(argv)

    sets = [c.strip() for c in a.columns.split(",") if c.strip()]
    threads = [int(t) for t in a.threads.split(",") if t.strip()]
    if any(c not in ("minimal", "standard", "full") for c in sets) or not sets or not threads \
            or a.rounds < 1 or not a.scale > 0:
        ap.error("bad --columns, --threads, --rounds or --scale")
    binary = Path(a.bin)
    if not binary.is_file():
        ap.error(f"no clearance binary at {binary} (cargo build --release -p clearance-cli, or --bin)")

    # Before numpy is imported: one BLAS/LAPACK thread unless asked otherwise.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = str(a.numpy_threads)
    import tomllib

    import numpy as np
    sys.path.insert(0, str(ROOT / "scripts"))
    import reference_ups as ru

    with open(a.job, "rb") as fh:
        raw = tomllib.load(fh)
    if raw.get("mechanism", {}).get("kind") != "6-UPS":
        print(f"{a.job}: not a 6-UPS job ([mechanism] kind)", file=sys.stderr)
        return 2
    if "sweep" in raw:
        print(f"{a.job}: a sweep; the NumPy reference computes one variant, give a job without [[sweep]]",
              file=sys.stderr)
        return 2
    job = scale_job(raw, a.scale)
    modes = len(job.get("analysis", {}).get("modes", ["kinetostatic"]))
    rows = samples_of(job) * modes
    host = host_info()
    host["loadavg_start"] = host.pop("loadavg", None)

    tmp = Path(tempfile.mkdtemp(prefix="clearance-ups-numpy-"))
    try:
        job_path = tmp / "job.toml"
        job_path.write_text(to_toml(job))
        # Both sides read the same file: NumPy reads what the engine reads.
        with open(job_path, "rb") as fh:
            job = tomllib.load(fh)
        numpy_t = {c: [] for c in sets}
        numpy_cpu = {c: [] for c in sets}
        kernel_t, kernel_cpu = [], []
        engine_t = {(c, n): [] for c in sets for n in threads}
        engine_pass = {(c, n): [] for c in sets for n in threads}
        check_set = max(sets, key=("minimal", "standard", "full").index)
        verdict = None
        for r in range(a.rounds):
            for c in sets:
                secs, cpu, cols = time_numpy(ru, job, c, a.chunk)
                numpy_t[c].append(secs)
                numpy_cpu[c].append(cpu)
                print(f"round {r + 1}: numpy {c}: {secs:.2f} s", file=sys.stderr)
                for n in threads:
                    out = tmp / f"out-{c}-{n}"
                    secs, pass_rate = run_engine(binary, job_path, out, n, c)
                    engine_t[(c, n)].append(secs)
                    if pass_rate is not None:
                        engine_pass[(c, n)].append(pass_rate)
                    print(f"round {r + 1}: engine {c} {n} thread(s): {secs:.2f} s (pose pass {pass_rate} poses/s)",
                          file=sys.stderr)
                    if verdict is None and c == check_set:
                        verdict = check(np, out, cols, c)
                        for line in verdict[1]:
                            print(f"check: {line}", file=sys.stderr)
                        if not verdict[0]:
                            print("check FAILED: the engine and the NumPy reference disagree; no timings reported",
                                  file=sys.stderr)
                            return 1
                    shutil.rmtree(out, ignore_errors=True)
                del cols
            if not a.no_kernel:
                secs, cpu, _ = time_numpy_kernel(ru, np, job, a.chunk)
                kernel_t.append(secs)
                kernel_cpu.append(cpu)
                print(f"round {r + 1}: numpy kernel: {secs:.2f} s", file=sys.stderr)
    except RuntimeError as e:
        print(e, file=sys.stderr)
        return 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    host["loadavg_end"] = host_info().get("loadavg")
    rate = lambda ts, k=rows: k / min(ts)  # noqa: E731
    result = {
        "job": job.get("name", Path(a.job).stem), "file": a.job, "scale": a.scale, "poses": rows,
        "rounds": a.rounds, "numpy": np.__version__, "host": host,
        "check": {"passed": verdict[0], "columns": check_set, "lines": verdict[1]},
        "sets": {},
    }
    for c in sets:
        d = {"numpy_poses_per_s": rate(numpy_t[c]), "numpy_cpu_per_wall": min(numpy_cpu[c]) / min(numpy_t[c]),
             "numpy_seconds": numpy_t[c]}
        for n in threads:
            d[f"engine_{n}t_poses_per_s"] = rate(engine_t[(c, n)])
            d[f"engine_{n}t_seconds"] = engine_t[(c, n)]
            d[f"ratio_{n}t"] = d[f"engine_{n}t_poses_per_s"] / d["numpy_poses_per_s"]
            p = engine_pass[(c, n)]
            d[f"engine_{n}t_pose_pass_poses_per_s"] = max(p) if p else None
            d[f"pose_pass_ratio_{n}t"] = max(p) / d["numpy_poses_per_s"] if p else None
        result["sets"][c] = d
    if kernel_t:
        result["numpy_kernel_poses_per_s"] = rate(kernel_t)
        result["numpy_kernel_seconds"] = kernel_t
    if a.json:
        print(json.dumps(result))
        return 0
    print(f"6-UPS {result['job']} ({a.job}, scale {a.scale}): {rows} poses; best of {a.rounds} alternated rounds")
    print(f"host: {host.get('cpu', '?')}, {host.get('cpus')} cpus, avx2 {host.get('avx2')}, "
          f"avx512f {host.get('avx512f')}; load average {host.get('loadavg_start')} at the start, "
          f"{host.get('loadavg_end')} at the end; "
          f"numpy {np.__version__} ({a.numpy_threads} BLAS thread)")
    print(f"check ({check_set} columns, engine 1st run vs numpy): passed")
    fmt = lambda v: f"{v:,.0f}" if v is not None else "-"  # noqa: E731
    ratio = lambda v: f"{v:.2f}x" if v is not None else "-"  # noqa: E731
    print(f"{'columns':<9} {'numpy':>8}" + "".join(f" {f'engine {n}t':>10} {'ratio':>6}" for n in threads)
          + " |" + "".join(f" {f'pass {n}t':>10} {'ratio':>6}" for n in threads) + "   (poses/s)")
    for c in sets:
        d = result["sets"][c]
        print(f"{c:<9} {fmt(d['numpy_poses_per_s']):>8}"
              + "".join(f" {fmt(d[f'engine_{n}t_poses_per_s']):>10} {ratio(d[f'ratio_{n}t']):>6}" for n in threads)
              + " |" + "".join(f" {fmt(d[f'engine_{n}t_pose_pass_poses_per_s']):>10} "
                               f"{ratio(d[f'pose_pass_ratio_{n}t']):>6}" for n in threads))
    if kernel_t:
        k = result["numpy_kernel_poses_per_s"]
        c = sets[-1]
        d = result["sets"][c]
        print(f"numpy kernel (reference_ups.pipeline: no envelope, no columns): {k:,.0f} poses/s; against it, "
              + ", ".join(f"engine {n}t ({c}) {d[f'engine_{n}t_poses_per_s'] / k:.2f}x end to end"
                          + (f", {d[f'engine_{n}t_pose_pass_poses_per_s'] / k:.2f}x pose pass"
                             if d[f'engine_{n}t_pose_pass_poses_per_s'] else "")
                          for n in threads))
    print("numpy: compute() in process, every column, no file; engine: `clearance run` wall clock (process start, "
          "pose pass, discontinuity search, Parquet written); pass: the engine's pose pass alone (its progress line)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
