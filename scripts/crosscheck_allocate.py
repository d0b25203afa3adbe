#!/usr/bin/env python3
"""Cross-check ``clearance allocate`` (clearance budgeting) against an independent convex
program solved by cvxpy.

    python3 scripts/crosscheck_allocate.py --clearance target/release/clearance --jobs 6 --seed 7
    python3 scripts/crosscheck_allocate.py --clearance PATH --refusals     # also the refusals
    python3 scripts/crosscheck_allocate.py --clearance PATH --fake         # self-test of this script

(``--bin`` is another name for ``--clearance``; ``--keep DIR`` keeps the jobs and outputs.)
Needs numpy, pyarrow and cvxpy (with ECOS; CLARABEL and SCS are fallbacks).

``allocate`` chooses the magnitudes c_k of the kinds of the job's ``[allocate]`` table to
minimise  cost = sum_k w_k / c_k  subject to, at every pose whose status is ``ok`` or
``indeterminate_contact`` (every variant and mode), with B = ``--max-dp``:

* take-up model:  || f_p + sum_{k det. at p} c_k e_k(p) || + sum_{k indet. at p} c_k env_k(p) + g_p <= B
* envelope model: sum_k c_k env_k(p) + sum_{fixed k} env_<k>_p <= B

e_k(p) = err_<k>_{x,y,z} and env_k(p) = env_<k>_p at unit magnitude, f_p and g_p the same
sums over the kinds kept at the job's values ("fixed"); a kind is indeterminate at p when
its err_<k>_x is null. ``--max-dalpha A`` adds the same with err_<k>_{rx,ry,rz},
env_<k>_alpha and A; ``[allocate] min/max`` bound the magnitudes.

Each random (seeded) job is one of: the paper's 3-PRS (kind omitted; random point masses;
sometimes a trajectory in both modes, sometimes a two-variant sweep of a point mass), a
3-RPS (jobs/rps_grid.toml's geometry), a 6-UPS (jobs/ups_position_grid.toml's); a grid of
at most 15 x 15 poses (a trajectory of at most 150 samples); a random subset of the kinds
allocated with random weights (0.5 .. 3, some left at the default 1; ``kinds`` sometimes
left out, i.e. every key of ``[clearance]``), sometimes one kind fixed at a small value,
a budget B log-uniform in [30, 300] um, the take-up or envelope model (``--model`` left
out for some take-up jobs: the default), sometimes ``--max-dalpha`` (set from the data so
that it binds or nearly does), sometimes a ``min`` and/or ``max`` bound (so that it binds
or not).

For each job:

1. a "unit" job (every kind of the job at 1e-4, no ``[allocate]``) runs as
   ``clearance run UNIT --out DIR --overwrite --quiet --columns standard``; its per-kind
   columns divided by 1e-4 are the unit errors (errors are linear in the magnitudes, and
   which rows and kinds are indeterminate does not depend on them while they are
   non-zero), the fixed kinds' contributions are those scaled to their values;
2. the program above is built in cvxpy (``cp.inv_pos`` for the cost, ``cp.norm`` for the
   cones; variables scaled by B) and solved (ECOS, then CLARABEL, then SCS with
   eps 1e-10), at B and at B (1 -+ 1%);
3. ``clearance allocate JOB --max-dp B [--max-dalpha A] [--model M] --out DIR --json``
   runs and ``DIR/allocation.json`` / ``DIR/allocation.toml`` are read.

Checks, one line each (hard: counted in ``N passed, M failed``):

* ``json``: allocate exited 0; allocation.json has model, max_dp, magnitudes, fixed, cost
  and shadow_price_per_um; its magnitudes name exactly the allocated kinds; its model is
  the one asked for;
* ``cost``: |cost_engine - cost_cvxpy| <= 1e-4 cost_cvxpy;
* ``feasible``: the job rerun with allocation.toml's ``[clearance]`` pasted over its own:
  the largest constrained quantity over its ok / indeterminate_contact rows (computed from
  the rerun's own per-kind columns) <= B (1 + 1e-6), and <= A (1 + 1e-6) with --max-dalpha;
  the JSON's magnitudes within the job's min / max (relative 1e-6);
* ``shadow``: shadow_price_per_um against the central difference of cvxpy's optimal cost,
  (cost(B (1 - h)) - cost(B (1 + h))) / (2 h B) * 1e-6 with h = 1%, to 2e-2 relative (plus
  a floor of 1e-3 cost / B * 1e-6 for a budget that does not bind); where a bound becomes
  active within the step (one-sided differences more than 5% apart) it must lie between
  the one-sided differences (widened by 2e-2).

Notes (printed, not counted): the magnitudes against cvxpy's (relative 1e-3), cvxpy's
dual-based shadow price, Sum w/c of the JSON's own magnitudes against its cost,
largest_dp, the binding list (each entry's pose found and its quantity near B), ``poses``.

``--refusals`` adds (exit 2, a line with ``error`` on stderr that is not clap's usage error,
no allocation.json written; first ``clearance allocate --help`` must exit 0):
a budget below what the fixed kinds alone produce (take-up and envelope: half the
smallest worst case any magnitudes >= 0 reach, found by cvxpy), and a ``min`` bound that
makes the take-up problem infeasible (checked by cvxpy: the least worst case with that
bound is above 1.5 B).

``--fake`` replaces ``clearance allocate`` with this script's own cvxpy solution written in
the same files (the binary still runs the jobs): a self-test of the harness;
``--fake-perturb R`` scales the fake's magnitudes by 1 + R, which the checks must catch.

Exit code: 1 if any check failed, 2 on a bad command line or a missing binary / cvxpy.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)

UNIT = 1e-4                       # magnitude of every kind in the unit run
KEEP = ("ok", "indeterminate_contact")
COST_TOL = 1e-4                   # relative, hard
MAG_TOL = 1e-3                    # relative, reported only
FEAS_TOL = 1e-6                   # relative to B (and A)
SHADOW_TOL = 2e-2                 # relative, hard
SHADOW_FLOOR = 1e-3               # of cost / B * 1e-6
FD_STEP = 0.01                    # B (1 -+ h) for the finite difference
KINK = 0.05                       # one-sided differences further apart than this: a kink
B_RANGE = (30e-6, 300e-6)
FAMILIES = ("3-PRS", "3-RPS", "6-UPS")
KINDS = {"3-PRS": ("s_radial", "r_radial", "r_axial", "r_angular"),
         "3-RPS": ("s_radial", "r_radial", "r_axial", "r_angular"),
         # u_angular cannot move the platform (zero error): allocating it is unbounded
         "6-UPS": ("s_radial", "u_radial")}


# --------------------------------------------------------------------------
# TOML writer (the subset the jobs need)
# --------------------------------------------------------------------------
def _tv(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if not math.isfinite(v):
            raise ValueError("non-finite value")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_tv(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_tv(x) for x in v) + "]"
    raise TypeError(type(v))


def to_toml(job):
    """Top-level scalars, then one [table] per dict, then [[array]] per list of dicts."""
    lines = [f"{k} = {_tv(v)}" for k, v in job.items()
             if not isinstance(v, dict) and not _is_tables(v)]
    for k, v in job.items():
        if isinstance(v, dict):
            lines += ["", f"[{k}]"] + [f"{kk} = {_tv(vv)}" for kk, vv in v.items()]
    for k, v in job.items():
        if _is_tables(v):
            for t in v:
                lines += ["", f"[[{k}]]"] + [f"{kk} = {_tv(vv)}" for kk, vv in t.items()]
    return "\n".join(lines) + "\n"


def _is_tables(v):
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


# --------------------------------------------------------------------------
# random jobs
# --------------------------------------------------------------------------
def _r(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _points(rng, n_max, z_range):
    return [{"mass": round(_r(rng, 1.0, 30.0), 3),
             "at": [round(_r(rng, -0.2, 0.2), 4), round(_r(rng, -0.2, 0.2), 4),
                    round(_r(rng, *z_range), 4)]}
            for _ in range(int(rng.integers(0, n_max + 1)))]


def _span(rng, lo, hi, n_lo, n_hi):
    a = round(_r(rng, lo, hi), 4)
    return {"start": -a, "stop": a, "n": int(rng.integers(n_lo, n_hi + 1))}


def job_3prs(rng, name):
    """The paper's 3-PRS (no [mechanism] table), random point masses, a grid or (1 in 4)
    a trajectory in both modes; with points, 1 in 4 a two-variant sweep of a mass."""
    job = {"name": name}
    pts = _points(rng, 2, (-1.0, 1.0))
    if pts:
        job["mass"] = {"points": pts}
    if rng.random() < 0.25:
        job["analysis"] = {"modes": ["kinetostatic", "dynamic"]}
        job["trajectory"] = {
            "time": {"start": 1.25, "stop": 3.75, "n": int(rng.integers(60, 151))},
            "z": 2.05,
            "psi": {"offset": 0.0, "harmonics": [
                {"amplitude": round(_r(rng, 0.05, 0.3), 4), "period": 5.0,
                 "phase": round(_r(rng, 0.0, 6.28), 4)}]},
            "theta": {"offset": 0.0, "harmonics": [
                {"amplitude": round(_r(rng, 0.2, 0.5), 4), "period": 5.0, "phase": 0.0}]},
        }
    else:
        job["grid"] = {"z": 2.05, "psi": _span(rng, 0.3, 0.5, 9, 15),
                       "theta": _span(rng, 0.3, 0.5, 9, 15)}
    if pts and rng.random() < 0.25:
        m0 = pts[0]["mass"]
        job["sweep"] = [{"param": "mass.points.0.mass", "values": [m0, round(m0 * 0.5 + 2.0, 3)]}]
    return job


def job_3rps(rng, name):
    """jobs/rps_grid.toml's 3-RPS on a small grid at one height, random point masses."""
    job = {"name": name, "mechanism": {"kind": "3-RPS"}}
    pts = _points(rng, 1, (0.0, 0.8))
    if pts:
        job["mass"] = {"points": pts}
    job["grid"] = {"z": round(_r(rng, 1.05, 1.35), 3), "psi": _span(rng, 0.2, 0.4, 7, 13),
                   "theta": _span(rng, 0.2, 0.4, 7, 13)}
    return job


def job_6ups(rng, name):
    """jobs/ups_position_grid.toml's 6-UPS (a 5 kg tool) on a small x-y grid."""
    job = {"name": name, "mechanism": {"kind": "6-UPS"},
           "mass": {"points": [{"mass": 5.0, "at": [0.05, 0.0, 0.3]}]}}
    job["grid"] = {"x": _span(rng, 0.05, 0.15, 7, 13), "y": _span(rng, 0.05, 0.15, 7, 13),
                   "z": 0.75, "phi": 0.0, "psi": round(_r(rng, -0.1, 0.1), 4), "theta": 0.0}
    return job


MAKERS = {"3-PRS": job_3prs, "3-RPS": job_3rps, "6-UPS": job_6ups}


class Case:
    """One random allocation problem: the job (without [clearance] / [allocate]), the kinds
    allocated and fixed, weights, bounds, model, budgets."""

    def __init__(self, rng, index, family):
        self.family = family
        self.base = MAKERS[family](rng, f"allocate_{index:03d}")
        pool = list(KINDS[family])
        rng.shuffle(pool)
        n_alloc = int(rng.integers(1, len(pool) + 1))
        self.alloc = pool[:n_alloc]
        # the job's own values of the allocated kinds: anything, allocate ignores them
        self.job_values = {k: float(f"{_r(rng, 1e-5, 2e-4):.3g}") for k in self.alloc}
        self.fixed = {}
        if n_alloc < len(pool) and rng.random() < 0.5:
            self.fixed[pool[n_alloc]] = float(f"{_r(rng, 2e-6, 2e-5):.3g}")
        if family == "6-UPS" and rng.random() < 0.4:
            self.fixed["u_angular"] = 1e-3       # harmless: its error is zero
        self.weights = {k: round(_r(rng, 0.5, 3.0), 3) for k in self.alloc if rng.random() < 0.7}
        # `kinds` is required with fixed kinds; otherwise left out half the time (default:
        # every key of [clearance])
        self.write_kinds = bool(self.fixed) or rng.random() < 0.5
        self.model = "takeup" if rng.random() < 0.5 else "envelope"
        self.model_flag = self.model == "envelope" or rng.random() < 0.7
        self.B = float(f"{math.exp(_r(rng, math.log(B_RANGE[0]), math.log(B_RANGE[1]))):.4g}")
        self.want_A = rng.random() < 0.35
        self.want_min = rng.random() < 0.3
        self.want_max = rng.random() < 0.3
        self.A = None
        self.lo = {}
        self.hi = {}

    def w(self):
        return np.array([self.weights.get(k, 1.0) for k in self.alloc])

    def bounds(self):
        lo = np.array([self.lo.get(k, 0.0) for k in self.alloc])
        hi = np.array([self.hi.get(k, math.inf) for k in self.alloc])
        return lo, hi

    def unit_job(self):
        """Every kind of the job at UNIT, no [allocate]."""
        job = copy.deepcopy(self.base)
        job["clearance"] = {k: UNIT for k in list(self.alloc) + list(self.fixed)}
        return _order(job)

    def job(self):
        """The job given to `allocate`."""
        job = copy.deepcopy(self.base)
        job["clearance"] = {**self.job_values, **self.fixed}
        table = {}
        if self.write_kinds:
            table["kinds"] = list(self.alloc)
        if self.weights:
            table["weights"] = dict(self.weights)
        if self.lo:
            table["min"] = dict(self.lo)
        if self.hi:
            table["max"] = dict(self.hi)
        job["allocate"] = table
        return _order(job)

    def args(self):
        a = ["--max-dp", repr(self.B)]
        if self.A is not None:
            a += ["--max-dalpha", repr(self.A)]
        if self.model_flag:
            a += ["--model", self.model]
        return a

    def describe(self):
        s = f"{self.family}, {self.model}, B={self.B:.4g}"
        if self.A is not None:
            s += f", A={self.A:.4g}"
        s += f", alloc {self.alloc}"
        if self.fixed:
            s += f", fixed {self.fixed}"
        if self.lo:
            s += f", min {self.lo}"
        if self.hi:
            s += f", max {self.hi}"
        return s


def _order(job):
    """Tables in the usual order (name, mechanism, mass, clearance, analysis, samples,
    allocate, sweeps); [allocate] only when present."""
    keys = ("name", "mechanism", "mass", "clearance", "analysis", "grid", "trajectory",
            "allocate", "sweep")
    return {k: job[k] for k in keys if k in job}


def without_allocate(job):
    job = copy.deepcopy(job)
    job.pop("allocate", None)
    return job


# --------------------------------------------------------------------------
# the engine
# --------------------------------------------------------------------------
def run_job(binary, job, path, out, timeout):
    """Write the job and run it (standard columns); (exit code, stderr)."""
    with open(path, "w") as fh:
        fh.write(to_toml(job))
    if os.path.exists(out):
        shutil.rmtree(out)
    cmd = [binary, "run", path, "--out", out, "--overwrite", "--quiet", "--columns", "standard"]
    try:
        pr = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        return pr.returncode, pr.stderr.strip()
    except subprocess.TimeoutExpired:
        return -1, f"timed out after {timeout}s"


def run_allocate(ctx, path, args, out):
    """`clearance allocate PATH ARGS --out OUT --json`: (exit code, stdout, stderr)."""
    if os.path.exists(out):
        shutil.rmtree(out)
    if ctx.fake:
        return fake_allocate(ctx, path, args, out)
    cmd = [ctx.binary, "allocate", path] + args + ["--out", out, "--json"]
    try:
        pr = subprocess.run(cmd, capture_output=True, text=True, timeout=ctx.timeout)
        return pr.returncode, pr.stdout, pr.stderr.strip()
    except subprocess.TimeoutExpired:
        return -1, "", f"timed out after {ctx.timeout}s"


def _number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v):
    return _number(v) and v > 0


def _last(err):
    return err.strip().splitlines()[-1] if err and err.strip() else ""


class Data:
    """The rows of a run whose status is ok or indeterminate_contact, sorted by (variant,
    mode, sample), with each kind's position and rotation errors (NaN where the kind is
    indeterminate) and envelopes, as written (not divided by anything)."""

    def __init__(self, run_dir, kinds):
        import pyarrow.dataset as ds
        tbl = ds.dataset(os.path.join(run_dir, "poses"), format="parquet",
                         partitioning="hive").to_table()
        names = set(tbl.column_names)

        def num(n):
            return np.asarray(tbl.column(n).to_numpy(), dtype=float)   # nulls -> NaN

        status = np.array([str(s) for s in tbl.column("status").to_pylist()], dtype=object)
        variant = (np.asarray(tbl.column("variant").to_numpy(), dtype=np.int64)
                   if "variant" in names else np.zeros(len(status), np.int64))
        mode = np.array([str(s) for s in tbl.column("mode").to_pylist()], dtype=object)
        sample = np.asarray(tbl.column("sample").to_numpy(), dtype=np.int64)
        self.total_rows = len(status)
        self.status_counts = {s: int((status == s).sum()) for s in sorted(set(status))}
        keep = np.isin(status, KEEP)
        order = np.lexsort((sample, mode.astype(str), variant))
        order = order[keep[order]]
        self.n = len(order)
        self.status = status[order]
        self.keys = list(zip(variant[order].tolist(), mode[order].tolist(), sample[order].tolist()))
        self.index = {k: i for i, k in enumerate(self.keys)}
        self.coords = {c: num(c)[order] for c in ("x", "y", "z", "phi", "psi", "theta") if c in names}
        self.E, self.R, self.EP, self.EA, self.det = {}, {}, {}, {}, {}
        for k in kinds:
            need = [f"err_{k}_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")] + \
                   [f"env_{k}_p", f"env_{k}_alpha"]
            missing = [c for c in need if c not in names]
            if missing:
                raise KeyError(f"{run_dir}: no columns {missing}")
            self.E[k] = np.column_stack([num(f"err_{k}_{c}")[order] for c in ("x", "y", "z")])
            self.R[k] = np.column_stack([num(f"err_{k}_{c}")[order] for c in ("rx", "ry", "rz")])
            self.EP[k] = num(f"env_{k}_p")[order]
            self.EA[k] = num(f"env_{k}_alpha")[order]
            self.det[k] = ~np.isnan(self.E[k][:, 0])
            if np.isnan(self.EP[k]).any() or np.isnan(self.EA[k]).any():
                raise ValueError(f"{run_dir}: null env_{k}_p/alpha on an ok/indeterminate row")


def evaluate(data, scale, model, rot=False):
    """The constrained quantity at every row of data, each kind's columns times scale[k]
    (c_k / UNIT for a unit run, 1 for a run at the magnitudes themselves)."""
    env = data.EA if rot else data.EP
    if model == "envelope":
        q = np.zeros(data.n)
        for k, s in scale.items():
            q += s * env[k]
        return q
    vec, ind = np.zeros((data.n, 3)), np.zeros(data.n)
    for k, s in scale.items():
        if s == 0.0:
            continue
        v, det = (data.R if rot else data.E)[k], data.det[k]
        vec[det] += s * v[det]
        ind[~det] += s * env[k][~det]
    return np.linalg.norm(vec, axis=1) + ind


# --------------------------------------------------------------------------
# the convex program
# --------------------------------------------------------------------------
class Terms:
    """The constrained quantity as constant + linear parts in the allocated magnitudes c
    (unit data, magnitudes in the job's units):
    take-up: || F + M c || + G + S c;   envelope: G + S c   (per row)."""

    def __init__(self, data, alloc, fixed, model, rot):
        P = data.n
        vec, env = (data.R if rot else data.E), (data.EA if rot else data.EP)
        self.model = model
        if model == "envelope":
            self.F = None
            self.G = sum((v / UNIT * env[k] for k, v in fixed.items()), np.zeros(P))
            self.M = None
            self.S = np.column_stack([env[k] / UNIT for k in alloc])
            return
        self.F, self.G = np.zeros((P, 3)), np.zeros(P)
        for k, v in fixed.items():
            det = data.det[k]
            self.F[det] += v / UNIT * vec[k][det]
            self.G[~det] += v / UNIT * env[k][~det]
        self.M = np.stack([np.where(data.det[k][:, None], vec[k], 0.0) / UNIT for k in alloc],
                          axis=2)                                           # (P, 3, n)
        self.S = np.column_stack([np.where(data.det[k], 0.0, env[k]) / UNIT for k in alloc])

    def expr(self, x, s, bound):
        """cvxpy expression of quantity / bound with c = s x (one entry per row)."""
        import cvxpy as cp
        lin = self.G / bound + (s / bound) * (self.S @ x)
        if self.model == "envelope":
            return lin
        comps = [self.F[:, j] / bound + (s / bound) * (self.M[:, j, :] @ x) for j in range(3)]
        return cp.norm(cp.vstack(comps), 2, axis=0) + lin

    def value(self, c):
        lin = self.G + self.S @ c
        if self.model == "envelope":
            return lin
        return np.linalg.norm(self.F + self.M @ c, axis=1) + lin


SOLVERS = (("ECOS", {"abstol": 1e-10, "reltol": 1e-10, "feastol": 1e-10, "max_iters": 500}),
           ("CLARABEL", {}),
           ("SCS", {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iters": 200000}))


def _solve(prob):
    """ECOS, else CLARABEL, else SCS: the first that says optimal; "infeasible" (or
    "unbounded") only when no solver finds an optimum and one of them says so."""
    import cvxpy as cp
    verdict, last = None, None
    for name, opts in SOLVERS:
        if name not in cp.installed_solvers():
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")       # "Solution may be inaccurate"
                prob.solve(solver=name, **opts)
        except cp.SolverError as exc:
            last = f"{name}: {exc}"
            continue
        if prob.status == "optimal":
            return name, "optimal"
        if prob.status in ("infeasible", "unbounded") and verdict is None:
            verdict = (name, prob.status)
        last = f"{name}: {prob.status}"
    return verdict if verdict else (None, last)


def solve_allocation(tdp, tda, w, lo, hi, B, A, objective="cost"):
    """Solve the allocation (objective "cost") or the least worst case dp / B
    (objective "minmax": min t s.t. quantity <= t B, c >= lo).  Returns a dict with
    status, cost (job units), c, t, shadow_dual (cost per um of budget, from the duals),
    solver."""
    import cvxpy as cp
    n = len(w)
    s = B
    x = cp.Variable(n)
    cons = []
    if objective == "cost":
        dp = tdp.expr(x, s, B) <= 1.0
        cons.append(dp)
        if A is not None:
            cons.append(tda.expr(x, s, A) <= 1.0)
        obj = cp.Minimize(cp.sum(cp.multiply(w, cp.inv_pos(x))))
    else:
        t = cp.Variable()
        cons.append(tdp.expr(x, s, B) <= t)
        cons.append(x >= 0)
        obj = cp.Minimize(t)
    for i in range(n):
        if lo[i] > 0:
            cons.append(x[i] >= lo[i] / s)
        if math.isfinite(hi[i]):
            cons.append(x[i] <= hi[i] / s)
    prob = cp.Problem(obj, cons)
    solver, status = _solve(prob)
    out = {"status": status, "solver": solver}
    if status != "optimal":
        return out
    out["c"] = np.asarray(x.value, float).reshape(n) * s
    if objective == "cost":
        out["cost"] = float(np.sum(w / out["c"]))
        lam = np.asarray(dp.dual_value, float)
        # Lagrangian of the scaled problem = s (cost + sum lam/(s B) (q - B)): d cost/dB = -sum mu
        out["shadow_dual"] = float(np.sum(lam)) / (s * B) * 1e-6
    else:
        out["t"] = float(t.value) * B
    return out


# --------------------------------------------------------------------------
# a stand-in for `clearance allocate` (--fake)
# --------------------------------------------------------------------------
def fake_allocate(ctx, path, args, out):
    """What `allocate` is specified to do, with this script's own program: the job's
    [allocate] table and the command-line options parsed as the engine would."""
    p = argparse.ArgumentParser(prog="allocate")
    p.add_argument("--max-dp", type=float, required=True)
    p.add_argument("--max-dalpha", type=float, default=None)
    p.add_argument("--model", choices=("takeup", "envelope"), default="takeup")
    a = p.parse_args(args)
    with open(path, "rb") as fh:
        job = tomllib.load(fh)
    table = job.get("allocate", {})
    clearance = job.get("clearance", {})
    alloc = list(table.get("kinds", list(clearance)))
    fixed = {k: float(v) for k, v in clearance.items() if k not in alloc}
    w = np.array([float(table.get("weights", {}).get(k, 1.0)) for k in alloc])
    lo = np.array([float(table.get("min", {}).get(k, 0.0)) for k in alloc])
    hi = np.array([float(table.get("max", {}).get(k, math.inf)) for k in alloc])
    unit = without_allocate(job)
    unit["clearance"] = {k: UNIT for k in list(alloc) + list(fixed)}
    rc_, err = run_job(ctx.binary, unit, os.path.join(ctx.work, "fake_unit.toml"),
                       os.path.join(ctx.work, "fake_unit_out"), ctx.timeout)
    if rc_ != 0:
        return rc_, "", err
    data = Data(os.path.join(ctx.work, "fake_unit_out"), list(alloc) + list(fixed))
    tdp = Terms(data, alloc, fixed, a.model, False)
    tda = Terms(data, alloc, fixed, a.model, True) if a.max_dalpha is not None else None
    sol = solve_allocation(tdp, tda, w, lo, hi, a.max_dp, a.max_dalpha)
    if sol["status"] != "optimal":
        return 2, "", f"error: {path}: no magnitudes meet the budget ({sol['status']})"
    c = sol["c"] * (1.0 + ctx.fake_perturb)
    q = tdp.value(c)
    binding = [{"variant": data.keys[i][0], "mode": data.keys[i][1], "sample": data.keys[i][2],
                "coords": {n: float(v[i]) for n, v in data.coords.items()}, "dp": float(q[i]),
                "dual": None}
               for i in np.flatnonzero(q >= a.max_dp * (1 - 1e-6))]
    res = {"model": a.model, "max_dp": a.max_dp, "max_dalpha": a.max_dalpha, "per_limb": False,
           "magnitudes": {k: float(v) for k, v in zip(alloc, c)}, "fixed": fixed,
           "weights": {k: float(v) for k, v in zip(alloc, w)},
           "cost": float(np.sum(w / c)), "shadow_price_per_um": sol["shadow_dual"],
           "largest_dp": float(q.max()), "poses": data.n, "iterations": 0, "cones": data.n,
           "binding": binding}
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "allocation.json"), "w") as fh:
        json.dump(res, fh, indent=1)
    with open(os.path.join(out, "allocation.toml"), "w") as fh:
        fh.write(to_toml({"clearance": {**fixed, **res["magnitudes"]}}))
    return 0, json.dumps(res), ""


# --------------------------------------------------------------------------
# one job
# --------------------------------------------------------------------------
class Context:
    def __init__(self, args, work):
        self.binary = args.binary
        self.timeout = args.timeout
        self.fake = args.fake
        self.fake_perturb = args.fake_perturb
        self.work = work


def prepare(ctx, rng, index, family):
    """Draw a case, run its unit job, set the data-dependent parts (fixed value, A,
    bounds) and solve it at B and B (1 -+ h).  None when the draw is unusable (redraw);
    raises RuntimeError when the engine fails on the unit job."""
    case = Case(rng, index, family)
    unit_dir = os.path.join(ctx.work, f"unit_{index:03d}")
    rc_, err = run_job(ctx.binary, case.unit_job(), os.path.join(ctx.work, f"unit_{index:03d}.toml"),
                       unit_dir, ctx.timeout)
    if rc_ != 0:
        raise RuntimeError(f"clearance run (unit job) exit {rc_}: {_last(err)}")
    kinds = list(case.alloc) + list(case.fixed)
    data = Data(unit_dir, kinds)
    if data.n == 0:
        return None
    # the fixed kinds take at most 30% of the budget (errors are linear: rescale the value)
    q0 = evaluate(data, {k: v / UNIT for k, v in case.fixed.items()}, case.model).max() \
        if case.fixed else 0.0
    for k in case.fixed:
        if q0 > 0.3 * case.B and k != "u_angular":
            case.fixed[k] = float(f"{case.fixed[k] * 0.3 * case.B / q0:.3g}")
    w = case.w()
    tdp = Terms(data, case.alloc, case.fixed, case.model, False)
    tda = Terms(data, case.alloc, case.fixed, case.model, True)
    free = solve_allocation(tdp, None, w, *case.bounds(), case.B, None)
    if free["status"] != "optimal":
        return None
    c_free = free["c"]
    # --max-dalpha: 0.6 to 1.3 of the rotation the dp-only optimum has (binds or not)
    if case.want_A:
        a_star = float(tda.value(c_free).max())
        if a_star > 0:
            case.A = float(f"{a_star * _r(rng, 0.6, 1.3):.4g}")
            if solve_allocation(tdp, tda, w, *case.bounds(), case.B * (1 - 2 * FD_STEP),
                                case.A)["status"] != "optimal":
                case.A = float(f"{a_star * 1.001:.4g}")
    base = solve_allocation(tdp, tda if case.A is not None else None, w, *case.bounds(), case.B, case.A)
    if base["status"] != "optimal":
        return None
    # bounds: 0.5 to 1.5 of the optimum's magnitude (binding or not), dropped when they
    # make B (1 - 2h) infeasible
    if case.want_min:
        k = case.alloc[int(rng.integers(len(case.alloc)))]
        case.lo[k] = float(f"{base['c'][case.alloc.index(k)] * _r(rng, 0.5, 1.5):.4g}")
    if case.want_max:
        k = case.alloc[int(rng.integers(len(case.alloc)))]
        case.hi[k] = float(f"{base['c'][case.alloc.index(k)] * _r(rng, 0.5, 1.5):.4g}")
        if k in case.lo and case.lo[k] >= case.hi[k]:
            case.hi[k] = float(f"{case.lo[k] * 1.5:.4g}")
    for drop in ("lo", "hi"):
        chk = solve_allocation(tdp, tda if case.A is not None else None, w, *case.bounds(),
                               case.B * (1 - 2 * FD_STEP), case.A)
        if chk["status"] == "optimal":
            break
        getattr(case, drop).clear()
    sols = {}
    for tag, b in (("B", case.B), ("lo", case.B * (1 - FD_STEP)), ("hi", case.B * (1 + FD_STEP))):
        sols[tag] = solve_allocation(tdp, tda if case.A is not None else None, w, *case.bounds(), b, case.A)
        if sols[tag]["status"] != "optimal":
            return None
    if case.A is not None:          # for a note on shadow_price_alpha_per_urad
        for tag, a in (("Alo", case.A * (1 - FD_STEP)), ("Ahi", case.A * (1 + FD_STEP))):
            sols[tag] = solve_allocation(tdp, tda, w, *case.bounds(), case.B, a)
    return case, data, sols


def check_job(ctx, index, case, data, sols, record):
    """Run allocate on the case and record its checks."""
    label = f"job {index:03d}"
    path = os.path.join(ctx.work, f"job_{index:03d}.toml")
    with open(path, "w") as fh:
        fh.write(to_toml(case.job()))
    out = os.path.join(ctx.work, f"alloc_{index:03d}")
    t0 = time.time()
    rc_, stdout, err = run_allocate(ctx, path, case.args(), out)
    t_alloc = time.time() - t0
    sol = sols["B"]
    notes = []
    # ---- json
    jpath = os.path.join(out, "allocation.json")
    if rc_ != 0 or not os.path.exists(jpath):
        record(label, "json", False, f"allocate exit {rc_}, {'no ' if not os.path.exists(jpath) else ''}"
                                     f"allocation.json: {_last(err)}")
        return
    try:
        with open(jpath) as fh:
            res = json.load(fh)
        need = ("model", "max_dp", "magnitudes", "fixed", "cost", "shadow_price_per_um")
        missing = [k for k in need if k not in res]
        bad = []
        if missing:
            bad.append(f"lacks {missing}")
        elif set(res["magnitudes"]) != set(case.alloc):
            bad.append(f"magnitudes name {sorted(res['magnitudes'])}, allocated {sorted(case.alloc)}")
        elif res["model"] != case.model:
            bad.append(f"model {res['model']!r}, asked {case.model!r}")
        elif not all(_positive(res["magnitudes"][k]) for k in case.alloc):
            bad.append(f"magnitudes not all positive numbers: {res['magnitudes']}")
        elif not (_positive(res["cost"]) and _number(res["shadow_price_per_um"])):
            bad.append(f"cost {res['cost']!r} or shadow_price_per_um "
                       f"{res['shadow_price_per_um']!r} not a number")
    except (OSError, ValueError) as exc:
        record(label, "json", False, f"allocation.json unreadable: {exc}")
        return
    record(label, "json", not bad, ("; ".join(bad) if bad else
                                    f"allocate {t_alloc:.2f}s, solver {sol['solver']}")
           + f" ({case.describe()})")
    if bad:
        return
    # ---- cost
    cost_e, cost_c = float(res["cost"]), sol["cost"]
    rel = abs(cost_e - cost_c) / cost_c
    record(label, "cost", rel <= COST_TOL,
           f"engine {cost_e:.9g}, cvxpy {cost_c:.9g}, rel diff {rel:.2e} (tol {COST_TOL:g})")
    mags = np.array([float(res["magnitudes"][k]) for k in case.alloc])
    w = case.w()
    own = float(np.sum(w / mags))
    if abs(own - cost_e) > 1e-6 * cost_e:
        notes.append(f"sum w/c of the JSON's magnitudes {own:.9g} != its cost {cost_e:.9g}")
    mrel = np.abs(mags - sol["c"]) / sol["c"]
    notes.append("magnitudes " + ("agree" if mrel.max() <= MAG_TOL else "DIFFER")
                 + f" (worst rel {mrel.max():.2e}, tol {MAG_TOL:g}): "
                 + ", ".join(f"{k} {m:.5g}/{c:.5g}" for k, m, c in zip(case.alloc, mags, sol["c"])))
    if float(res["max_dp"]) != case.B:
        notes.append(f"max_dp {res['max_dp']} != {case.B}")
    if res.get("max_dalpha") != case.A:
        notes.append(f"max_dalpha {res.get('max_dalpha')} != {case.A}")
    fixed_e = {k: v for k, v in (res.get("fixed") or {}).items() if v}   # the zeros left out
    if fixed_e != case.fixed:
        notes.append(f"fixed (non-zero) {fixed_e}, the job fixes {case.fixed}")
    try:
        sj = json.loads(stdout) if stdout.strip() else None
        if isinstance(sj, dict) and "cost" in sj and float(sj["cost"]) != cost_e:
            notes.append(f"--json printed cost {sj['cost']}, allocation.json {cost_e}")
    except ValueError:
        notes.append("--json's stdout is not one JSON document")
    # ---- shadow price
    hB = FD_STEP * case.B
    c_lo, c_hi = sols["lo"]["cost"], sols["hi"]["cost"]
    central = (c_lo - c_hi) / (2 * hB) * 1e-6
    back, fwd = (c_lo - cost_c) / hB * 1e-6, (cost_c - c_hi) / hB * 1e-6
    floor = SHADOW_FLOOR * cost_c / case.B * 1e-6
    sp = float(res["shadow_price_per_um"])
    rel = abs(sp - central) / max(abs(central), 1e-300)
    ok = abs(sp - central) <= SHADOW_TOL * abs(central) + floor
    how = f"central difference {central:.6g}, rel diff {rel:.2e} (tol {SHADOW_TOL:g}, floor {floor:.2g})"
    if not ok and back - fwd > KINK * max(abs(back), floor):
        # cost(B) is convex: its slope at B lies between the one-sided differences
        ok = fwd * (1 - SHADOW_TOL) - floor <= sp <= back * (1 + SHADOW_TOL) + floor
        how += f"; curved or kinked within -+{FD_STEP:g} B: one-sided {fwd:.6g} .. {back:.6g}"
    record(label, "shadow", ok, f"engine {sp:.6g} per um, {how}")
    notes.append(f"cvxpy's dual shadow price {sol['shadow_dual']:.6g} per um; one-sided "
                 f"differences {fwd:.6g} .. {back:.6g}")
    spa = res.get("shadow_price_alpha_per_urad")
    if case.A is not None and _number(spa) and all(sols[t]["status"] == "optimal" for t in ("Alo", "Ahi")):
        ca = (sols["Alo"]["cost"] - sols["Ahi"]["cost"]) / (2 * FD_STEP * case.A) * 1e-6
        notes.append(f"shadow_price_alpha_per_urad {spa:.6g}, central difference {ca:.6g}")
    # ---- feasibility: rerun with allocation.toml's [clearance]
    try:
        with open(os.path.join(out, "allocation.toml"), "rb") as fh:
            alloc_toml = tomllib.load(fh)
        new_cl = alloc_toml["clearance"]
    except (OSError, ValueError, KeyError) as exc:
        record(label, "feasible", False, f"allocation.toml unreadable or without [clearance]: {exc}")
        new_cl = None
    if new_cl is not None:
        job = without_allocate(case.job())
        job["clearance"].update(new_cl)
        rdir = os.path.join(ctx.work, f"rerun_{index:03d}")
        rc2, err2 = run_job(ctx.binary, job, os.path.join(ctx.work, f"rerun_{index:03d}.toml"),
                            rdir, ctx.timeout)
        if rc2 != 0:
            record(label, "feasible", False, f"rerun exit {rc2}: {_last(err2)}")
        else:
            kinds = [k for k in job["clearance"] if isinstance(job["clearance"][k], (int, float))]
            rd = Data(rdir, kinds)
            one = {k: 1.0 for k in kinds}
            qd = evaluate(rd, one, case.model)
            worst = float(qd.max()) if rd.n else 0.0
            ok = worst <= case.B * (1 + FEAS_TOL)
            msg = f"max dp {worst:.9g} <= B {case.B:.9g} ({worst / case.B - 1:+.2e})"
            if case.A is not None:
                qa = evaluate(rd, one, case.model, rot=True)
                wa = float(qa.max()) if rd.n else 0.0
                ok = ok and wa <= case.A * (1 + FEAS_TOL)
                msg += f", max dalpha {wa:.9g} <= A {case.A:.9g} ({wa / case.A - 1:+.2e})"
            out_of = [f"{k} {m:.6g} outside [{case.lo.get(k, 0.0):.6g}, {case.hi.get(k, math.inf):.6g}]"
                      for k, m in zip(case.alloc, mags)
                      if m < case.lo.get(k, 0.0) * (1 - FEAS_TOL) or m > case.hi.get(k, math.inf) * (1 + FEAS_TOL)]
            if out_of:
                ok = False
                msg += "; " + ", ".join(out_of)
            elif case.lo or case.hi:
                msg += ", within min/max"
            record(label, "feasible", ok, msg + f" over {rd.n} rows")
            if rd.keys != data.keys:
                notes.append(f"the rerun's ok/indeterminate rows ({rd.n}) differ from the unit "
                             f"run's ({data.n})")
            if "largest_dp" in res and abs(float(res["largest_dp"]) - worst) > 1e-6 * case.B:
                notes.append(f"largest_dp {res['largest_dp']:.9g}, the rerun's {worst:.9g}")
            if res.get("poses") is not None and res["poses"] != rd.n:
                notes.append(f"poses {res['poses']}, ok/indeterminate rows {rd.n} "
                             f"(all rows {rd.total_rows})")
            if case.A is not None and _number(res.get("largest_dalpha")) \
                    and abs(res["largest_dalpha"] - wa) > 1e-6 * case.A:
                notes.append(f"largest_dalpha {res['largest_dalpha']:.9g}, the rerun's {wa:.9g}")
            # binding entries: the pose exists and its quantity ("dp" or "dalpha") is near
            # its budget in the rerun
            bind = res.get("binding") or []
            if bind:
                far, lost = 0.0, 0
                for b in bind:
                    i = rd.index.get((int(b.get("variant", 0)), str(b.get("mode")),
                                      int(b.get("sample", -1))))
                    if i is None:
                        lost += 1
                    elif b.get("budget") == "dalpha" and case.A is not None:
                        far = max(far, abs(qa[i] / case.A - 1))
                    else:
                        far = max(far, abs(qd[i] / case.B - 1))
                notes.append(f"binding: {len(bind)} entries, {lost} not found, worst |q/budget - 1| "
                             f"among the found {far:.1e}")
    for n in notes:
        record(label, None, None, n)


# --------------------------------------------------------------------------
# refusals
# --------------------------------------------------------------------------
def refusal_checks(ctx, rng, record):
    """A budget below what the fixed kinds alone give (take-up, envelope), and an
    infeasible `min` bound: allocate must exit 2, say why, write nothing."""
    base = job_3prs(np.random.default_rng(int(rng.integers(1 << 31))), "allocate_refused")
    base.pop("sweep", None)
    base.pop("trajectory", None)
    base.pop("analysis", None)
    base["grid"] = {"z": 2.05, "psi": {"start": -0.4, "stop": 0.4, "n": 11},
                    "theta": {"start": -0.4, "stop": 0.4, "n": 11}}
    alloc, fixed = ["r_radial", "s_radial"], {"r_axial": 2e-5, "r_angular": 1e-5}
    unit = copy.deepcopy(base)
    unit["clearance"] = {k: UNIT for k in alloc + list(fixed)}
    udir = os.path.join(ctx.work, "refused_unit")
    rc_, err = run_job(ctx.binary, unit, os.path.join(ctx.work, "refused_unit.toml"), udir,
                       ctx.timeout)
    if rc_ != 0:
        record("refusal", "unit run", False, f"clearance run exit {rc_}: {_last(err)}")
        return
    data = Data(udir, alloc + list(fixed))
    w, lo0, hi0 = np.ones(2), np.zeros(2), np.full(2, math.inf)
    cases = []
    for model in ("takeup", "envelope"):
        q0 = float(evaluate(data, {k: v / UNIT for k, v in fixed.items()}, model).max())
        mm = solve_allocation(Terms(data, alloc, fixed, model, False), None, w, lo0, hi0,
                              q0, None, objective="minmax")
        least = min(q0, mm["t"]) if mm["status"] == "optimal" else q0
        job = copy.deepcopy(base)
        job["clearance"] = {"r_radial": 1e-4, "s_radial": 1e-4, **fixed}
        job["allocate"] = {"kinds": alloc}
        B = float(f"{0.5 * least:.4g}")
        cases.append((f"budget below the fixed kinds ({model}, B = {B:.4g}, they alone "
                      f"{q0:.4g}, at best {least:.4g})", job, ["--max-dp", repr(B), "--model", model]))
    # an infeasible min bound: no fixed kinds, r_radial >= m
    B = 100e-6
    tdp = Terms(data, alloc, {}, "takeup", False)
    single = float(evaluate(data, {"r_radial": 1.0 / UNIT}, "takeup").max())
    m, least = 2.0 * B / single, 0.0
    for _ in range(8):
        mm = solve_allocation(tdp, None, w, np.array([m, 0.0]), hi0, B, None, objective="minmax")
        least = mm.get("t", math.inf)
        if least > 1.5 * B:
            break
        m *= 3.0
    m = float(f"{m:.4g}")
    job = copy.deepcopy(base)
    job["clearance"] = {"r_radial": 1e-4, "s_radial": 1e-4}
    job["allocate"] = {"min": {"r_radial": m}}
    cases.append((f"min bound r_radial >= {m:.4g} (takeup, B = {B:g}, least worst case "
                  f"{least:.4g})", job, ["--max-dp", repr(B)]))
    if not ctx.fake:
        pr = subprocess.run([ctx.binary, "allocate", "--help"], capture_output=True, text=True,
                            timeout=ctx.timeout)
        if pr.returncode != 0:
            record("refusal", "help", False, f"`clearance allocate --help` exit {pr.returncode}: "
                                             f"{_last(pr.stderr)}")
            return
    for i, (what, job, args) in enumerate(cases):
        path = os.path.join(ctx.work, f"refused_{i}.toml")
        with open(path, "w") as fh:
            fh.write(to_toml(_order(job)))
        out = os.path.join(ctx.work, f"refused_{i}_out")
        rc_, _, err = run_allocate(ctx, path, args, out)
        wrote = os.path.exists(os.path.join(out, "allocation.json"))
        # a refusal of the job, not of the command line (clap's usage errors also exit 2)
        usage = "try '--help'" in err or "usage:" in err.lower()
        ok = rc_ == 2 and "error" in err.lower() and not usage and not wrote
        record("refusal", str(i), ok, f"{what}: exit {rc_}{', wrote allocation.json' if wrote else ''}"
                                      f": {_last(err) or '(nothing on stderr)'}")


# --------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clearance", "--bin", dest="binary",
                    default=os.path.join(REPO, "target", "release", "clearance"),
                    help="the clearance binary (default target/release/clearance)")
    ap.add_argument("--jobs", type=int, default=6)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--families", default=",".join(FAMILIES),
                    help=f"comma-separated subset of {', '.join(FAMILIES)}")
    ap.add_argument("--refusals", action="store_true",
                    help="also check the refusals (exit 2): a budget below the fixed kinds, "
                         "an infeasible min bound")
    ap.add_argument("--keep", default=None, help="keep job files and outputs in this directory")
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--fake", action="store_true",
                    help="stand in for `clearance allocate` with this script's cvxpy solution "
                         "(self-test; the binary still runs the jobs)")
    ap.add_argument("--fake-perturb", type=float, default=0.0,
                    help="with --fake: scale the magnitudes by 1 + this (the checks must "
                         "fail); write a negative value as --fake-perturb=-1e-3")
    args = ap.parse_args(argv)
    fams = [f.strip() for f in args.families.split(",") if f.strip()]
    bad = [f for f in fams if f not in FAMILIES]
    if bad:
        ap.error(f"unknown families {bad}")
    try:
        import cvxpy  # noqa: F401
    except ImportError:
        print("cvxpy is needed (pip install cvxpy ecos)", file=sys.stderr)
        return 2
    args.binary = os.path.abspath(args.binary)
    if not os.access(args.binary, os.X_OK):
        print(f"clearance binary not found or not executable: {args.binary}", file=sys.stderr)
        return 2
    work = os.path.abspath(args.keep) if args.keep else tempfile.mkdtemp(prefix="clearance-xalloc-")
    os.makedirs(work, exist_ok=True)
    ctx = Context(args, work)
    rng = np.random.default_rng(args.seed)
    counts = {"passed": 0, "failed": 0}

    def record(label, check, ok, detail):
        if ok is None:
            print(f"{label}   note: {detail}", flush=True)
            return
        counts["passed" if ok else "failed"] += 1
        print(f"{label} {check:<8} {'pass' if ok else 'FAIL'}  {detail}", flush=True)

    try:
        for i in range(args.jobs):
            family = fams[i % len(fams)]
            prepared = None
            try:
                for _ in range(20):
                    prepared = prepare(ctx, rng, i, family)
                    if prepared is not None:
                        break
            except (RuntimeError, KeyError, ValueError) as exc:
                record(f"job {i:03d}", "unit run", False, f"{family}: {exc}")
                continue
            if prepared is None:
                record(f"job {i:03d}", "draw", False, f"{family}: no usable random job in 20 draws")
                continue
            try:
                check_job(ctx, i, *prepared, record)
            except Exception as exc:  # report, do not stop the other jobs
                record(f"job {i:03d}", "crash", False, f"{type(exc).__name__}: {exc}")
        if args.refusals:
            try:
                refusal_checks(ctx, rng, record)
            except Exception as exc:
                record("refusal", "crash", False, f"{type(exc).__name__}: {exc}")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    if args.keep:
        print(f"jobs and outputs kept in {work}")
    print(f"{counts['passed']} passed, {counts['failed']} failed")
    return 1 if counts["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
