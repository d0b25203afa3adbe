#!/usr/bin/env python3
"""Cross-check the engine's `poses` output against scripts/reference_model.py.

    python3 scripts/crosscheck_reference.py [--jobs N] [--seed S] [--bin PATH] [--keep DIR]
                                            [--kinds prototype,3-PRS,3-RPS | all]

For each of N random (seeded) jobs this writes the job as TOML, runs
``clearance run JOB --out DIR --columns full``, reads
``DIR/poses/variant=0/*.parquet`` (``variant`` comes from the Hive path),
joins engine and reference rows on (mode, sample) and compares every column
the reference knows.

Job families (``--kinds``, comma-separated; ``all`` = every one; default
``prototype``, whose jobs for a given seed are the same as before the family
existed):

* ``prototype``: jobs around the paper's 3-PRS prototype (vertical rails, limbs
  at 0/120/240 deg), no ``kind`` key;
* ``3-PRS``: ``kind = "3-PRS"`` with rail angles in [-90, 90] deg (often exactly
  -90, 0, 30 or 90), limb angles that are the symmetric set or perturbations of
  0/120/240 by up to +-25 deg, platform angles equal to them or perturbed
  independently;
* ``3-RPS``: ``kind = "3-RPS"`` with varied radii, cylinder/piston lengths and
  masses, default or explicit strokes, symmetric or uneven layouts.
* ``6-UPS``: ``kind = "6-UPS"`` against scripts/reference_ups.py: the default
  geometry, perturbed circles with tilted U axes, or explicit points; varied legs,
  strokes, masses, point masses, inertia, gravity and loads; each of s_radial,
  u_radial, u_angular on or off; grids over one to three of the six inputs and
  trajectories of all six, kinetostatic and dynamic; exact mode.

With several families each job draws its family first.  Heights are chosen from
the reference's own kinematics so that the poses are mostly reachable and well
conditioned; "edge" jobs sit at the border of the workspace (a share of
unreachable rows).  Grids and trajectories, kinetostatic and dynamic modes, and
exact mode (not on edge jobs) all occur.

Comparison rule (per cell, both sides non-null):

    |a - b| <= tol * max(|a|, |b|, S_c) + 10 * eps * kappa_row * F_c

  tol = 1e-9 for kinetostatic rows, 1e-6 for dynamic rows.
  S_c = max(M_c, 1e-3 * M_g, 1e-6 * N_g): M_c is the largest |reference value|
      of column c in that job and mode, M_g the largest M_c over the column's
      unit group (lengths, angles, time, position errors, rotation errors,
      exact position errors, exact rotation errors, forces, couples; cond_a
      and cond_jp are their own groups), N_g the group's natural magnitude:
      L (lengths), 1 rad (angles), W = m_total*|g| (forces), W*L (couples),
      c_t + L*c_a (position errors, linear and exact), c_a + c_t/L (rotation
      errors, linear and exact; both sides solve the exact closure in
      perturbation form, so exact errors carry full relative precision too),
      c_t the largest translational and c_a the angular clearance; L is the leg
      length (3-RPS: the mean of min_length and max_length).  Each column is
      judged relative to its own magnitude; a column that is essentially zero
      throughout (y on a Psi = 0 path, the R couples of a symmetric level pose)
      is judged against 1e-3 of its group's
      magnitude, or 1e-6 of the physical scale, not by the relative error of
      round-off noise.
  The last term is the round-off of a linear solve: eps = 2.2e-16, kappa_row =
      max(cond_a, cond_jp) of the row (reference; 0 where null), F_c the
      magnitude of the solution vector the value comes from, in c's unit
      (forces: max(M_force, M_couple/L), couples: L times that; position
      errors: max(M_err_len, L*M_err_ang), rotation errors: that over L;
      likewise for exact errors; other groups: M_g).  With kappa ~ 50 it is
      ~1e-13 of F_c; it matters only for ill-conditioned rows.  For the 6-UPS,
      F_c of the error groups is at least their natural magnitude N_g: the
      u_angular take-up is cancelled by passive motions of its own size, so its
      (zero) error carries round-off of that size, not of the error's.

  The table prints, per column, the worst raw normalised error
  |a-b| / max(|a|, |b|, S_c) (before the round-off term) and the number of
  cells that violate the rule.

Exact requirements: the same set of (mode, sample) rows, identical `status`
strings, a null exactly where the reference has NaN (and nowhere else), no NaN
stored in the engine's files, every expected column present.  A job fails on
any violation or on a non-zero exit code of the engine.

Worst-case envelope (docs/model.md section 11): ``env_<c>``,
``env_<kind>_<c>`` (c = x, y, z, rx, ry, rz, p, alpha) and ``dominant``.  If the
engine's output has none of them (an engine from before issue 22), they are
skipped with a note, not failed; if it has some, all are required.  The env_*
columns follow the rule above, in their own unit groups (env_len: x, y, z, p;
env_ang: rx, ry, rz, alpha) with the error columns' natural magnitudes, so they
neither loosen nor tighten the error columns' floors.  ``dominant`` is compared
exactly (same nulls, same string), with one allowance: where the engine names
another joint whose |dp| contribution (reference) equals the reference's
maximum to the row's tolerance, the two joints tie to round-off (a symmetric
pose: the spec's tie rule is for exact ties, and which of two mirror limbs
wins is decided by round-off), so it is counted as a near tie and reported,
not failed (``--strict-dominant`` fails them too).  The summary quantities of
the spec (env_p_max, env_p_p95, env_alpha_max, env_alpha_p95,
dominant_share_<joint>, rms_dp_<joint>) are compared with
``summary.parquet``'s row of variant 0 and each mode when the engine writes
them (skipped with a note otherwise): maxima and RMS by the rule above,
p95 within 5e-4 relative (one histogram bin, 2^(1/2048) - 1 = 3.4e-4, for a
value on a bin edge), shares within (near ties of the mode)/(ok rows) + 1e-12.

Prints the per-column worst-error table (over all jobs, with where it
happened), one line per job and finally
``N passed, M failed``; the exit code is 1 if any job failed.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import reference_model as rm  # noqa: E402
import reference_ups as ru  # noqa: E402

REPO = os.path.dirname(HERE)
EPS = np.finfo(float).eps
TOL = {"kinetostatic": 1e-9, "dynamic": 1e-6}
GROUP_FLOOR = 1e-3
PHYS_FLOOR = 1e-6
COND_ALLOWANCE = 10.0


# --------------------------------------------------------------------------
# random jobs
# --------------------------------------------------------------------------
def _r(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _logu(rng, lo_exp, hi_exp):
    return float(10.0 ** rng.uniform(lo_exp, hi_exp))


def _range(rng, span, n_lo, n_hi, centred_odd=False):
    if centred_odd:                      # symmetric range with an odd count: hits exactly 0
        a = _r(rng, 0.1, span)
        n = int(rng.integers(n_lo // 2, n_hi // 2 + 1)) * 2 + 1
        return {"start": -a, "stop": a, "n": n}
    a, b = sorted(rng.uniform(-span, span, 2))
    if b - a < 0.05:
        b = a + 0.05
    return {"start": float(a), "stop": float(b), "n": int(rng.integers(n_lo, n_hi + 1))}


def _harmonics(rng, offset_span, amp_total, T_lo, T_hi):
    k = int(rng.integers(1, 3))
    amps = rng.dirichlet(np.ones(k)) * _r(rng, 0.3, 1.0) * amp_total
    return {"offset": _r(rng, -offset_span, offset_span),
            "harmonics": [{"amplitude": float(a), "period": _r(rng, T_lo, T_hi),
                           "phase": _r(rng, -math.pi, math.pi)} for a in amps]}


def random_job(rng, index):
    """A sane job around the prototype; returns (job dict, tag)."""
    edge = rng.random() < 0.12          # geometry with an unreachable region
    job = {"name": f"xcheck_{index:03d}"}
    if edge:
        Rb = _r(rng, 0.45, 0.55)
        rp = _r(rng, 0.10, 0.15)
        L = (Rb - rp) * _r(rng, 1.03, 1.06)
    else:
        Rb, rp, L = _r(rng, 0.12, 0.26), _r(rng, 0.28, 0.45), _r(rng, 0.8, 1.3)
    mech = {"base_radius": Rb, "platform_radius": rp, "leg_length": L}
    if rng.random() < 0.3:
        mech["gravity"] = [_r(rng, -1.0, 1.0), _r(rng, -1.0, 1.0), _r(rng, -10.5, -9.0)]
    job["mechanism"] = mech
    mass = {"platform": _r(rng, 5.0, 15.0), "leg": _r(rng, 1.5, 4.5)}
    if rng.random() < 0.4:
        m = mass["platform"]
        mass["platform_inertia"] = [m * rp ** 2 / 4 * _r(rng, 0.5, 1.5),
                                    m * rp ** 2 / 4 * _r(rng, 0.5, 1.5),
                                    m * rp ** 2 / 2 * _r(rng, 0.5, 1.5)]
    npts = int(rng.integers(0, 3))
    pts = []
    for _ in range(npts):
        pts.append({"mass": _r(rng, 0.5, 30.0),
                    "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -1.0, 1.0)]})
    if rng.random() < 0.15:               # the paper's mass + counterweight
        m = _r(rng, 5.0, 30.0)
        pts = [{"mass": m, "at": [0.0, 0.0, 1.0]}, {"mass": m, "at": [0.0, 0.0, -1.0]}]
    mass["points"] = pts
    job["mass"] = mass
    if rng.random() < 0.6:
        job["load"] = {"force": [float(v) for v in rng.normal(0, 15, 3)],
                       "moment": [float(v) for v in rng.normal(0, 3, 3)],
                       "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -0.2, 0.3)]}
    cl = {"s_radial": _logu(rng, -5.0, -3.5), "r_radial": _logu(rng, -5.5, -4.0),
          "r_axial": _logu(rng, -6.0, -4.0), "r_angular": _logu(rng, -5.0, -3.0)}
    for k in list(cl):
        if rng.random() < 0.15:
            cl[k] = 0.0
    job["clearance"] = cl
    # no exact mode on edge geometry: near the reach boundary the postures are close to
    # singular and the nonlinear closure has several nearby solutions (ill-posed)
    analysis = {"exact": bool(rng.random() < 0.5) and not edge}
    if rng.random() < 0.2:
        analysis["discontinuity_load_fraction"] = _r(rng, 0.01, 0.1)
    traj = rng.random() < 0.5
    span = 0.6 if edge else 0.45
    if traj:
        analysis["modes"] = [["kinetostatic", "dynamic"], ["dynamic"], ["kinetostatic"]][
            int(rng.choice(3, p=[0.7, 0.15, 0.15]))]
        t0 = _r(rng, 0.0, 2.0)
        tr = {"time": {"start": t0, "stop": t0 + _r(rng, 1.0, 5.0), "n": int(rng.integers(101, 601))}}
        zc = _r(rng, 1.4, 2.5) * L
        tr["z"] = zc if rng.random() < 0.5 else \
            dict(_harmonics(rng, 0.0, 0.15 * L, 1.5, 6.0), offset=zc)
        for key in ("psi", "theta"):
            c = rng.random()
            if c < 0.15:
                tr[key] = 0.0
            else:
                tr[key] = _harmonics(rng, 0.1, span - 0.1, 1.5, 6.0)
        job["trajectory"] = tr
    else:
        analysis["modes"] = ["kinetostatic"]
        g = {"z": _r(rng, 1.4, 2.5) * L}
        if rng.random() < 0.2:
            z0 = g["z"]
            g["z"] = {"start": z0, "stop": z0 + _r(rng, 0.05, 0.3), "n": int(rng.integers(2, 4))}
        g["psi"] = _range(rng, span, 5, 21, centred_odd=rng.random() < 0.5)
        g["theta"] = _range(rng, span, 5, 21, centred_odd=rng.random() < 0.2)
        job["grid"] = g
    sym = rng.random() < 0.35
    if sym:
        # mirror-symmetric about the x-z plane (limb 1's plane): on Psi = 0 limb 1's
        # axial load and R couple vanish -> indeterminate_contact rows
        job["mechanism"].pop("gravity", None)
        for pt in job["mass"]["points"]:
            pt["at"][1] = 0.0
        if "load" in job:
            job["load"]["force"][1] = 0.0
            job["load"]["moment"][0] = job["load"]["moment"][2] = 0.0
            job["load"]["at"][1] = 0.0
        if traj and rng.random() < 0.5:
            job["trajectory"]["psi"] = 0.0
        if not traj:
            job["grid"]["psi"] = _range(rng, span, 5, 21, centred_odd=True)
    job["analysis"] = analysis
    tag = ("edge " if edge else "") + ("sym " if sym else "") + ("trajectory " + "+".join(analysis["modes"]) if traj else "grid")
    if analysis["exact"]:
        tag += " exact"
    return job, tag


# --------------------------------------------------------------------------
# random jobs of the mechanism family (docs/model.md section 10)
# --------------------------------------------------------------------------
FAMILIES_OF_JOBS = ("prototype", "3-PRS", "3-RPS", "6-UPS")
RAIL_ANGLES_EXACT = (-90.0, 0.0, 30.0, 90.0)


def _layout(rng):
    """(limb_angles_deg or None, platform_angles_deg or None, tag)."""
    c = rng.random()
    if c < 0.3:
        limbs = None                                      # default 0/120/240
    elif c < 0.4:
        limbs = [0.0, 120.0, 240.0] if rng.random() < 0.5 else [90.0, 210.0, 330.0]
    else:
        limbs = [round(b + _r(rng, -25.0, 25.0), 3) for b in (0.0, 120.0, 240.0)]
    plat = None
    if rng.random() < 0.4:
        plat = [round(b + _r(rng, -25.0, 25.0), 3) for b in (0.0, 120.0, 240.0)]
    tag = "sym" if limbs in (None, [0.0, 120.0, 240.0]) and plat is None else "uneven"
    if limbs == [90.0, 210.0, 330.0] and plat is None:
        tag = "rot90"
    return limbs, plat, tag


def _family_masses(rng, kind, rp):
    mass = {"platform": _r(rng, 5.0, 15.0)}
    if kind == "3-PRS":
        mass["leg"] = _r(rng, 1.5, 4.5)
    else:
        mass["cylinder"], mass["piston"] = _r(rng, 1.0, 4.0), _r(rng, 0.4, 2.0)
    if rng.random() < 0.3:
        m = mass["platform"]
        mass["platform_inertia"] = [m * rp ** 2 / 4 * _r(rng, 0.5, 1.5),
                                    m * rp ** 2 / 4 * _r(rng, 0.5, 1.5),
                                    m * rp ** 2 / 2 * _r(rng, 0.5, 1.5)]
    pts = []
    for _ in range(int(rng.integers(0, 3))):
        pts.append({"mass": _r(rng, 0.5, 20.0),
                    "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -0.6, 0.6)]})
    mass["points"] = pts
    return mass


def _pose_box(z, span_psi, span_th):
    """Centre, edges and corners of the (psi, theta) box at each height z (n_z * 9 poses)."""
    o = np.array([-1.0, 0.0, 1.0])
    ps, th = np.meshgrid(o * span_psi, o * span_th, indexing="ij")
    Z = np.repeat(np.asarray(z, float), 9)
    return Z, np.tile(ps.ravel(), len(z)), np.tile(th.ravel(), len(z))


def _admissible(P, zs, span_psi, span_th, cond_max=300.0, rail_margin=0.25):
    """Per candidate height: (every pose of the box reachable and well conditioned,
    the level pose reachable).  Well conditioned: cond_a, cond_jp <= cond_max and,
    for 3-PRS, the leg at least `rail_margin` away from lying across its rail."""
    Z, ps, th = _pose_box(zs, span_psi, span_th)
    with np.errstate(all="ignore"):
        kin = rm.kinematics(P, Z, ps, th)
        good = kin["reach"].copy()
        G, M = rm.reduced_matrices(kin["p"], kin["A"], kin["e"], P["YJ"])
        kap = np.fmax(rm.kappa1(G), rm.kappa1(M))
        good &= np.nan_to_num(kap, nan=np.inf) <= cond_max
        if P["kind"] == "3-PRS":
            good &= np.all((kin["e"] * P["DJ"]).sum(-1) >= rail_margin, axis=-1)
    good = good.reshape(-1, 9)
    centre = kin["reach"].reshape(-1, 9)[:, 4]
    return good.all(-1), centre


def _family_inputs(rng, job, P, edge, span):
    """Fill job['grid'] or job['trajectory'] and the modes; returns (traj, ok)."""
    size = P["size"]
    if P["kind"] == "3-PRS":
        zs = np.linspace(0.15, 2.6, 246) * size
    else:
        zs = np.linspace(0.05, 1.0, 191) * P["qmax"]
    traj = rng.random() < 0.5
    zvar = rng.random() < (0.5 if traj else 0.2) and not edge
    zamp = _r(rng, 0.02, 0.08) * size if zvar else 0.0
    allok, centre = _admissible(P, zs, span, span)
    if edge:
        # the level pose reachable, some poses of the (wider) box not
        wide, _ = _admissible(P, zs, 1.6 * span, 1.6 * span, cond_max=np.inf, rail_margin=0.0)
        cand = np.flatnonzero(centre & ~wide)
    else:
        dz = zs[1] - zs[0]
        k = int(np.ceil(zamp / dz)) + 1
        ok = allok.copy()
        for sh in range(1, k + 1):                # the whole z band admissible
            ok[sh:] &= allok[:-sh]
            ok[:-sh] &= allok[sh:]
            ok[:sh] = ok[-sh:] = False
        cand = np.flatnonzero(ok)
    if cand.size == 0:
        return traj, False
    zc = float(zs[int(rng.choice(cand))] + _r(rng, -0.4, 0.4) * (zs[1] - zs[0]))
    analysis = job["analysis"]
    if traj:
        analysis["modes"] = [["kinetostatic", "dynamic"], ["dynamic"], ["kinetostatic"]][
            int(rng.choice(3, p=[0.7, 0.15, 0.15]))]
        t0 = _r(rng, 0.0, 2.0)
        tr = {"time": {"start": t0, "stop": t0 + _r(rng, 1.0, 4.0), "n": int(rng.integers(81, 401))}}
        tr["z"] = zc if zamp == 0.0 else dict(_harmonics(rng, 0.0, zamp, 1.5, 6.0), offset=zc)
        for key in ("psi", "theta"):
            tr[key] = 0.0 if rng.random() < 0.1 else _harmonics(rng, 0.05, span - 0.05, 1.5, 6.0)
        job["trajectory"] = tr
    else:
        analysis["modes"] = ["kinetostatic"]
        g = {"z": zc}
        if zamp > 0.0:
            g["z"] = {"start": zc - zamp, "stop": zc + zamp, "n": int(rng.integers(2, 4))}
        if edge:                          # centred on the reachable level pose
            g["psi"] = _range(rng, 1.5 * span, 5, 17, centred_odd=True)
            g["theta"] = _range(rng, 1.5 * span, 5, 17, centred_odd=True)
        else:
            g["psi"] = _range(rng, span, 5, 17, centred_odd=rng.random() < 0.4)
            g["theta"] = _range(rng, span, 5, 17, centred_odd=rng.random() < 0.2)
        job["grid"] = g
    return traj, True


def random_family_job(rng, index, kind):
    """A sane job of the mechanism family: kind '3-PRS' or '3-RPS'; (job, tag)."""
    for _attempt in range(50):
        edge = rng.random() < 0.12
        job = {"name": f"xcheck_{index:03d}"}
        mech = {"kind": kind}
        limbs, plat, ltag = _layout(rng)
        if kind == "3-PRS":
            Rb, rp, L = _r(rng, 0.12, 0.3), _r(rng, 0.2, 0.45), _r(rng, 0.6, 1.3)
            mech.update(base_radius=Rb, platform_radius=rp, leg_length=L)
            beta = float(rng.choice(RAIL_ANGLES_EXACT)) if rng.random() < 0.5 \
                else round(_r(rng, -90.0, 90.0), 2)
            if beta != 0.0 or rng.random() < 0.5:
                mech["rail_angle_deg"] = beta
            ktag = f"3-PRS beta={beta:g}"
        else:
            Rb, rp = _r(rng, 0.15, 0.45), _r(rng, 0.1, 0.3)
            lc, lp = _r(rng, 0.4, 1.0), _r(rng, 0.3, 0.9)
            mech.update(base_radius=Rb, platform_radius=rp, cylinder_length=lc, piston_length=lp)
            if rng.random() < 0.5:
                mech["min_length"] = max(lc, lp) + _r(rng, 0.0, 0.1)
                mech["max_length"] = lc + lp - _r(rng, 0.0, 0.1)
            ktag = "3-RPS" + (" stroke" if "min_length" in mech else "")
        if limbs is not None:
            mech["limb_angles_deg"] = limbs
        if plat is not None:
            mech["platform_angles_deg"] = plat
        if rng.random() < 0.3:
            mech["gravity"] = [_r(rng, -1.0, 1.0), _r(rng, -1.0, 1.0), _r(rng, -10.5, -9.0)]
        job["mechanism"] = mech
        job["mass"] = _family_masses(rng, kind, rp)
        if rng.random() < 0.5:
            job["load"] = {"force": [float(v) for v in rng.normal(0, 10, 3)],
                           "moment": [float(v) for v in rng.normal(0, 2, 3)],
                           "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -0.2, 0.3)]}
        cl = {"s_radial": _logu(rng, -5.0, -3.5), "r_radial": _logu(rng, -5.5, -4.0),
              "r_axial": _logu(rng, -6.0, -4.0), "r_angular": _logu(rng, -5.0, -3.0)}
        for k in list(cl):
            if rng.random() < 0.15:
                cl[k] = 0.0
        job["clearance"] = cl
        job["analysis"] = {"exact": bool(rng.random() < 0.5) and not edge}
        if rng.random() < 0.2:
            job["analysis"]["discontinuity_load_fraction"] = _r(rng, 0.01, 0.1)
        sym = ltag == "sym" and rng.random() < 0.35
        if sym:
            # mirror-symmetric about limb 1's plane: indeterminate rows on Psi = 0
            mech.pop("gravity", None)
            for pt in job["mass"]["points"]:
                pt["at"][1] = 0.0
            job["mass"].pop("platform_inertia", None)
            if "load" in job:
                job["load"]["force"][1] = 0.0
                job["load"]["moment"][0] = job["load"]["moment"][2] = 0.0
                job["load"]["at"][1] = 0.0
        span = _r(rng, 0.15, 0.4)
        try:
            P = rm.normalize_job(dict(job, grid={"z": 1.0}))
        except ValueError:
            continue
        traj, ok = _family_inputs(rng, job, P, edge, span)
        if not ok:
            continue
        if sym:
            if traj and rng.random() < 0.5:
                job["trajectory"]["psi"] = 0.0
            if not traj:
                job["grid"]["psi"] = _range(rng, span, 5, 17, centred_odd=True)
        modes = job["analysis"]["modes"]
        tag = ktag + f" {ltag}" + (" edge" if edge else "") + (" mirror" if sym else "") + \
            (" trajectory " + "+".join(modes) if traj else " grid")
        if job["analysis"]["exact"]:
            tag += " exact"
        # keep the key order of the prototype's jobs: analysis after the inputs
        job["analysis"] = job.pop("analysis")
        return job, tag
    raise RuntimeError(f"no admissible {kind} job found in 50 draws")


def _ups_harmonics(rng, offset, amp):
    k = int(rng.integers(1, 3))
    return {"offset": offset, "harmonics": [
        {"amplitude": amp * _r(rng, 0.3, 1.0) / k, "period": _r(rng, 1.0, 4.0),
         "phase": _r(rng, -math.pi, math.pi)} for _ in range(k)]}


def random_ups_job(rng, index):
    """A 6-UPS job (docs/model.md 10.3); (job, tag).  Geometry: the defaults (keys
    left out), perturbed circles with tilted U axes, or explicit points off the planes;
    random masses, point masses, platform inertia, gravity and external load; each of
    s_radial, u_radial, u_angular on or off; a grid over some of the six inputs or a
    trajectory in one or both modes; exact mode on some ok-dominated jobs; "edge" jobs
    reach past the stroke (unreachable rows)."""
    for _attempt in range(50):
        edge = rng.random() < 0.15
        job = {"name": f"xcheck_{index:03d}"}
        mech = {"kind": "6-UPS"}
        v = int(rng.integers(0, 3))
        if v >= 1:
            mech["base_radius"] = _r(rng, 0.4, 0.6)
            mech["platform_radius"] = _r(rng, 0.2, 0.35)
            mech["base_angles_deg"] = [a + _r(rng, -5, 5) for a in (-15, 15, 105, 135, 225, 255)]
            mech["platform_angles_deg"] = [a + _r(rng, -5, 5) for a in (-45, 45, 75, 165, 195, 285)]
        if v == 1 and rng.random() < 0.6:
            mech["u_axes"] = [[-math.sin(t) + _r(rng, -0.2, 0.2), math.cos(t), _r(rng, -0.3, 0.3)]
                              for t in np.radians(mech["base_angles_deg"])]
        if v == 2:
            P0 = ru.normalize_job({"mechanism": dict(mech), "grid": {"z": 0.7}})
            mech["base_points"] = [[float(b[0]), float(b[1]), _r(rng, -0.05, 0.05)] for b in P0["B"]]
            mech["platform_points"] = [[float(a[0]), float(a[1]), _r(rng, -0.05, 0.05)] for a in P0["AP"]]
            for kk in ("base_radius", "base_angles_deg", "platform_angles_deg"):
                mech.pop(kk, None)
        if rng.random() < 0.5:
            lc, lp = _r(rng, 0.4, 0.7), _r(rng, 0.4, 0.7)
            mech.update(cylinder_length=lc, piston_length=lp)
            if rng.random() < 0.5:
                mech["min_length"] = max(lc, lp) + _r(rng, 0.0, 0.05)
                mech["max_length"] = lc + lp - _r(rng, 0.0, 0.05)
        weightless = rng.random() < 0.08     # no gravity, no load: every take-up indeterminate
        if weightless:
            mech["gravity"] = [0.0, 0.0, 0.0]
        elif rng.random() < 0.3:
            mech["gravity"] = [_r(rng, -1.0, 1.0), _r(rng, -1.0, 1.0), _r(rng, -10.5, -9.0)]
        job["mechanism"] = mech
        mass = {}
        if rng.random() < 0.6:
            mass.update(platform=_r(rng, 5.0, 15.0), cylinder=_r(rng, 0.5, 3.0), piston=_r(rng, 0.3, 2.0))
        if rng.random() < 0.3:
            mass["platform_inertia"] = [_r(rng, 0.1, 0.5), _r(rng, 0.1, 0.5), _r(rng, 0.2, 0.8)]
        if rng.random() < 0.5:
            mass["points"] = [{"mass": _r(rng, 1.0, 20.0),
                               "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -0.5, 0.8)]}
                              for _ in range(int(rng.integers(1, 3)))]
        if mass:
            job["mass"] = mass
        if rng.random() < 0.5 and not weightless:
            job["load"] = {"force": [float(x) for x in rng.normal(0, 20, 3)],
                           "moment": [float(x) for x in rng.normal(0, 3, 3)],
                           "at": [_r(rng, -0.2, 0.2), _r(rng, -0.2, 0.2), _r(rng, -0.2, 0.3)]}
        cl = {"s_radial": _logu(rng, -5.0, -3.5), "u_radial": _logu(rng, -5.5, -4.0),
              "u_angular": _logu(rng, -5.0, -2.5)}
        for k in list(cl):
            if rng.random() < 0.2:
                cl[k] = 0.0
        job["clearance"] = cl
        P = ru.normalize_job(dict(job, grid={"z": 0.7}))
        dxy = P["AP"][:, :2] - P["B"][:, :2]
        h2 = P["size"] ** 2 - float((dxy * dxy).sum(1).mean())
        if h2 <= 0:
            continue
        z0 = math.sqrt(h2) - float((P["AP"][:, 2] - P["B"][:, 2]).mean())
        span = 2.5 if edge else 1.0
        if edge:                  # towards the end of the stroke: some legs out of it
            z0 += 0.2 * P["size"]
        traj = rng.random() < 0.4
        analysis = {"exact": bool(rng.random() < 0.5) and not edge}
        if traj:
            modes = [["kinetostatic"], ["dynamic"], ["kinetostatic", "dynamic"]][int(rng.integers(0, 3))]
            t0 = _r(rng, 0.0, 2.0)
            job["trajectory"] = {"time": {"start": t0, "stop": t0 + _r(rng, 1.0, 4.0),
                                          "n": int(rng.integers(15, 60))},
                                 "x": _ups_harmonics(rng, _r(rng, -0.02, 0.02), 0.05 * span),
                                 "y": _ups_harmonics(rng, _r(rng, -0.02, 0.02), 0.05 * span),
                                 "z": _ups_harmonics(rng, z0, 0.05 * span),
                                 "phi": _ups_harmonics(rng, 0.0, 0.15 * span),
                                 "psi": _ups_harmonics(rng, 0.0, 0.12 * span),
                                 "theta": _ups_harmonics(rng, 0.0, 0.12 * span)}
            for k in ("x", "y", "phi"):
                if rng.random() < 0.25:
                    del job["trajectory"][k]          # left out: the constant 0
            analysis["modes"] = modes
        else:
            spans = {"x": 0.06, "y": 0.06, "z": 0.06, "phi": 0.2, "psi": 0.15, "theta": 0.15}
            grid = {}
            swept = rng.choice(list(spans), size=int(rng.integers(1, 4)), replace=False)
            for k, w in spans.items():
                c = z0 if k == "z" else 0.0
                if k in swept:
                    a, b = sorted(rng.uniform(-w * span, w * span, 2))
                    b = max(b, a + 0.2 * w)
                    grid[k] = {"start": c + float(a), "stop": c + float(b), "n": int(rng.integers(2, 9))}
                elif k in ("z", "psi", "theta") or rng.random() < 0.6:
                    grid[k] = c + _r(rng, -0.3 * w, 0.3 * w)
            job["grid"] = grid
            modes = ["kinetostatic"]
        if rng.random() < 0.2:
            analysis["discontinuity_load_fraction"] = _r(rng, 0.01, 0.1)
        job["analysis"] = analysis
        ref = ru.compute(tomllib.loads(to_toml(job)), "minimal")
        ok = float(np.mean(np.isin(ref["status"], ["ok", "indeterminate_contact"])))
        if ok < (0.3 if edge else 0.8):
            continue
        tag = f"6-UPS geom{v}" + (" edge" if edge else "") + (" weightless" if weightless else "") + \
            (" trajectory " + "+".join(modes) if traj else " grid " + "/".join(sorted(swept))) + \
            (" exact" if analysis["exact"] else "")
        return job, tag
    raise RuntimeError(f"no admissible 6-UPS job found in 50 draws (job {index})")


def parse_kinds(text):
    kinds = list(FAMILIES_OF_JOBS) if text.strip() == "all" else \
        [k.strip() for k in text.split(",") if k.strip()]
    bad = [k for k in kinds if k not in FAMILIES_OF_JOBS]
    if bad or not kinds:
        raise ValueError(f"--kinds: unknown {bad} (choose from {', '.join(FAMILIES_OF_JOBS)} or all)")
    return kinds


def make_job(rng, index, kinds):
    """The index-th job for the chosen families: (job, tag).  With the prototype
    alone no draw is spent on the family (the same jobs as before)."""
    kind = kinds[0] if len(kinds) == 1 else kinds[int(rng.integers(len(kinds)))]
    if kind == "prototype":
        job, tag = random_job(rng, index)
        return job, ("prototype " + tag) if len(kinds) > 1 else tag
    if kind == "6-UPS":
        return random_ups_job(rng, index)
    return random_family_job(rng, index, kind)


def maybe_add_thresholds(rng, job, ref_cols):
    """Sometimes set analysis.singular_cond between the job's condition numbers so
    that near_singular rows occur (docs/conventions.md)."""
    if rng.random() >= 0.15:
        return False
    kap = np.fmax(ref_cols["cond_a"], ref_cols["cond_jp"])
    kap = np.unique(kap[np.isfinite(kap)])
    # put the threshold in the middle of a clear gap between two condition numbers
    # of the job, never within round-off of one of them
    gaps = np.flatnonzero(kap[1:] > kap[:-1] * (1 + 1e-6))
    if gaps.size < 2:
        return False
    k = gaps[int(0.7 * (gaps.size - 1))]
    job["analysis"]["singular_cond"] = float(np.sqrt(kap[k] * kap[k + 1]))
    return True


# --------------------------------------------------------------------------
# TOML writer (the subset the job format needs)
# --------------------------------------------------------------------------
def _tv(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError("non-finite value")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_tv(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_tv(x) for x in v) + "]"
    raise TypeError(type(v))


def to_toml(job):
    lines = []
    for k, v in job.items():
        if not isinstance(v, dict):
            lines.append(f"{k} = {_tv(v)}")
    for k, v in job.items():
        if isinstance(v, dict):
            lines.append("")
            lines.append(f"[{k}]")
            for kk, vv in v.items():
                lines.append(f"{kk} = {_tv(vv)}")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# comparison
# --------------------------------------------------------------------------
ENV_COLUMNS = tuple(rm.env_column_names())          # env_* and dominant
EXTRA_COLUMNS = frozenset(rm.extra_column_names())  # reference-only, never compared


def group_of(col):
    if col in ("cond_a", "cond_jp", "t"):
        return col
    if col.startswith("env_"):
        return "env_len" if col.rsplit("_", 1)[1] in ("x", "y", "z", "p") else "env_ang"
    if col in ("z", "x", "y", "q1", "q2", "q3", "q4", "q5", "q6"):
        return "length"
    if col in ("psi", "theta", "phi"):
        return "angle"
    if col.startswith("exact_err_"):
        return "exact_len" if col.rsplit("_", 1)[1] in ("x", "y", "z") else "exact_ang"
    if col.startswith("err_"):
        comp = col.rsplit("_", 1)[1]
        return "err_len" if comp in ("x", "y", "z") else "err_ang"
    if col.startswith(("m_r", "m_u")) or col.endswith("_angular"):
        return "couple"
    if col.startswith(("f_r", "f_s", "f_u", "margin_")):
        return "force"
    return None


def physical_scale(P):
    """Natural magnitude of each unit group for the job (see the module doc); for the
    6-UPS the translations are s_radial and u_radial and the angle u_angular."""
    c = P["clear"]
    if P.get("kind") == ru.KIND:
        trans, ang = max(c["s_radial"], c["u_radial"]), c["u_angular"]
    else:
        trans, ang = max(c["s_radial"], c["r_radial"], c["r_axial"]), c["r_angular"]
    L = P["size"]
    return {"length": L, "angle": 1.0, "err_len": trans + L * ang,
            "err_ang": ang + trans / L, "force": P["W"], "couple": P["W"] * L,
            "exact_len": trans + L * ang, "exact_ang": ang + trans / L,
            "env_len": trans + L * ang, "env_ang": ang + trans / L}


# groups whose values come out of one linear solve together: (length-like, angle-like)
FAMILIES = {"force": ("force", "couple"), "couple": ("force", "couple"),
            "err_len": ("err_len", "err_ang"), "err_ang": ("err_len", "err_ang"),
            "exact_len": ("exact_len", "exact_ang"), "exact_ang": ("exact_len", "exact_ang"),
            "env_len": ("env_len", "env_ang"), "env_ang": ("env_len", "env_ang")}


def family_magnitude(g, mg, L):
    """Size of the solution vector a value of group g comes from, in g's unit."""
    if g not in FAMILIES:
        return mg.get(g, 0.0)
    lin, ang = FAMILIES[g]
    # force/couple: couple = force * length; err_len/err_ang: length = angle * length
    if g in ("force", "couple"):
        n = max(mg.get("force", 0.0), mg.get("couple", 0.0) / L)
        return n if g == "force" else n * L
    n = max(mg.get(lin, 0.0), mg.get(ang, 0.0) * L)
    return n if g == lin else n / L


def read_engine(out_dir):
    import pyarrow as pa
    import pyarrow.parquet as pq
    files = sorted(glob.glob(os.path.join(out_dir, "poses", "variant=0", "*.parquet")))
    if not files:
        raise RuntimeError(f"no parquet files in {out_dir}/poses/variant=0/")
    tables = [pq.ParquetFile(f).read() for f in files]
    tbl = pa.concat_tables(tables, promote_options="permissive")
    cols = {}
    for name in tbl.column_names:
        arr = tbl.column(name).combine_chunks()
        null = arr.is_null().to_numpy(zero_copy_only=False)
        if pa.types.is_string(arr.type) or pa.types.is_large_string(arr.type) or \
                pa.types.is_dictionary(arr.type):
            cols[name] = (np.array(arr.to_pylist(), dtype=object), null, False)
        else:
            vals = arr.cast(pa.float64()).to_numpy(zero_copy_only=False).astype(float)
            nan_stored = np.isnan(vals) & ~null
            vals = np.where(null, np.nan, vals)
            cols[name] = (vals, null, nan_stored)
    return cols, len(files)


class Stats:
    """Worst normalised error per column, separately for kinetostatic and dynamic rows."""

    def __init__(self):
        self.cols = {}

    def add(self, col, mode, ne, tol, where, n_bad, n_null, n_cmp):
        w = self.cols.setdefault(col, {"kinetostatic": [-1.0, 0.0, ""], "dynamic": [-1.0, 0.0, ""],
                                       "bad": 0, "null": 0, "n": 0})
        cur = w[mode]
        if n_cmp and (cur[0] < 0 or ne / tol > cur[0] / cur[1]):
            w[mode] = [ne, tol, where]
        w["bad"] += n_bad
        w["null"] += n_null
        w["n"] += n_cmp

def compare(ref, eng, job_label, stats, P, notes=None, strict_dominant=False, near_ties=None):
    """Returns a list of failure strings; appends remarks (skipped envelope columns,
    near ties of `dominant`) to `notes` and counts the near ties per mode in
    `near_ties`.  `ref` is rm.compute(job, extras=True) (the per-joint |dp| columns
    judge the near ties; compute() without extras works when the engine writes no
    `dominant`)."""
    fails = []
    notes = [] if notes is None else notes
    near_ties = {} if near_ties is None else near_ties
    expected = [c for c in ref if c != "variant" and c not in EXTRA_COLUMNS]
    is_env = [c for c in expected if c.startswith("env_") or c == "dominant"]
    if not any(c in eng for c in is_env):
        expected = [c for c in expected if c not in is_env]
        notes.append("engine output has no envelope columns (env_*, dominant): not compared")
    missing = [c for c in expected if c not in eng]
    if missing:
        fails.append(f"missing columns: {', '.join(missing[:8])}" + (" ..." if len(missing) > 8 else ""))
    if "variant" in eng:
        fails.append("a `variant` column is stored inside the files (must come from the Hive path)")
    for c, (_, _, nan_stored) in eng.items():
        if nan_stored is not False and nan_stored.any():
            fails.append(f"{c}: {int(nan_stored.sum())} NaN values stored (must be null)")
    if "mode" not in eng or "sample" not in eng:
        return fails + ["no mode/sample columns; cannot join"]
    ekey = {(m, int(s)): i for i, (m, s) in enumerate(zip(eng["mode"][0], eng["sample"][0]))}
    rkeys = list(zip(ref["mode"], ref["sample"].astype(np.int64)))
    ri = np.array([i for i, k in enumerate(rkeys) if (k[0], int(k[1])) in ekey], dtype=int)
    ei = np.array([ekey[(rkeys[i][0], int(rkeys[i][1]))] for i in ri], dtype=int)
    if ri.size != len(rkeys) or len(ekey) != len(rkeys):
        fails.append(f"rows: reference {len(rkeys)}, engine {len(ekey)}, matched {ri.size}")
    if ri.size == 0:
        return fails
    rs, es = ref["status"][ri], eng["status"][0][ei] if "status" in eng else None
    if es is not None:
        bad = rs != es
        if bad.any():
            pairs = {}
            for a, b in zip(rs[bad], es[bad]):
                pairs[(a, b)] = pairs.get((a, b), 0) + 1
            fails.append("status mismatches (reference -> engine): " +
                         ", ".join(f"{a}->{b} x{n}" for (a, b), n in pairs.items()))
    modes = ref["mode"][ri]
    samples = ref["sample"][ri]
    tol = np.where(modes == "dynamic", TOL["dynamic"], TOL["kinetostatic"])
    kap = np.fmax(np.nan_to_num(ref["cond_a"][ri]), np.nan_to_num(ref["cond_jp"][ri]))
    # column scales per mode
    num_cols = [c for c in expected if c in eng and c not in ("mode", "status", "sample", "dominant")]
    scale, fam = {}, {}
    for m in np.unique(modes):
        sel = modes == m
        mc = {c: (np.nanmax(np.abs(ref[c][ri][sel])) if np.isfinite(ref[c][ri][sel]).any() else 0.0)
              for c in num_cols}
        mg = {}
        for c, v in mc.items():
            mg[group_of(c)] = max(mg.get(group_of(c), 0.0), v)
        phys = physical_scale(P)
        for c in num_cols:
            scale[(m, c)] = max(mc[c], GROUP_FLOOR * mg[group_of(c)],
                                PHYS_FLOOR * phys.get(group_of(c), 0.0))
            fam[(m, c)] = family_magnitude(group_of(c), mg, P["size"])
            if P.get("kind") == ru.KIND and group_of(c) in FAMILIES:
                # u_angular's error and envelope are zero, but the passive motions that
                # cancel its take-up are of its size: that is the solution vector's
                # magnitude, and the reference's round-off on them.
                fam[(m, c)] = max(fam[(m, c)], phys[group_of(c)])
    S_all = {c: np.array([scale[(m, c)] for m in modes]) for c in num_cols}
    R_all = {c: COND_ALLOWANCE * EPS * kap * np.array([fam[(m, c)] for m in modes])
             for c in num_cols}
    if "sample" in eng:
        if not np.array_equal(eng["sample"][0][ei].astype(np.int64), samples.astype(np.int64)):
            fails.append("sample join error")
    for c in num_cols:
        a = ref[c][ri]
        b, bnull, _ = eng[c]
        b, bnull = b[ei], bnull[ei]
        anull = np.isnan(a)
        nullmis = anull != bnull
        both = ~anull & ~bnull
        raw = np.abs(a - b)
        d = np.maximum(raw - R_all[c], 0.0)
        den = np.maximum(np.maximum(np.abs(a), np.abs(b)), S_all[c])
        with np.errstate(invalid="ignore", divide="ignore"):
            ne = np.where(both, np.where(den > 0, d / den, np.where(d > 0, np.inf, 0.0)), 0.0)
            ne_raw = np.where(both, np.where(den > 0, raw / den, np.where(raw > 0, np.inf, 0.0)), 0.0)
        badv = both & ~(ne <= tol)
        for m in ("kinetostatic", "dynamic"):
            sel = both & (modes == m)
            if not sel.any():
                stats.add(c, m, 0.0, 1.0, "", 0, 0, 0)
                continue
            k = int(np.argmax(np.where(sel, ne_raw / tol, -1.0)))
            stats.add(c, m, float(ne_raw[k]), float(tol[k]), f"{job_label} {m[:3]} #{int(samples[k])}",
                      int((badv & sel).sum()), int((nullmis & (modes == m)).sum()), int(sel.sum()))
        if badv.any():
            k = int(np.flatnonzero(badv)[np.argmax(ne[badv] / tol[badv])])
            fails.append(f"{c}: {int(badv.sum())} values off, worst {ne[k]:.2e} > {tol[k]:.1e} "
                         f"({modes[k]} #{int(samples[k])}: ref {a[k]:.17g} engine {b[k]:.17g})")
        if nullmis.any():
            k = int(np.flatnonzero(nullmis)[0])
            fails.append(f"{c}: {int(nullmis.sum())} null mismatches (first {modes[k]} #{int(samples[k])}: "
                         f"ref {'null' if anull[k] else a[k]}, engine {'null' if bnull[k] else b[k]}, "
                         f"status {rs[k]}/{es[k] if es is not None else '?'})")
    if "dominant" in expected and "dominant" in eng:
        fails += compare_dominant(ref, eng, ri, ei, modes, samples, tol, stats, P, notes,
                                  strict_dominant, near_ties)
    return fails


def compare_dominant(ref, eng, ri, ei, modes, samples, tol, stats, P, notes, strict, near_ties):
    """`dominant`: same nulls, same joint; a different joint of non-zero clearance
    whose reference |dp| contribution equals the reference maximum to the row's
    tolerance is a near tie (counted per mode in `near_ties`, noted, not failed
    unless `strict`)."""
    fails = []
    kind_of = dict(zip(rm.JOINT_NAMES, (k for k, _ in rm.JOINTS)))
    a = ref["dominant"][ri]
    b, bnull, _ = eng["dominant"]
    b, bnull = b[ei], bnull[ei]
    anull = np.array([v is None for v in a], dtype=bool)
    nullmis = anull != bnull
    both = ~anull & ~bnull
    diff = both & (a != b)
    near = np.zeros(diff.shape, dtype=bool)
    for k in np.flatnonzero(diff):
        if b[k] not in kind_of or P["clear"][kind_of[b[k]]] == 0.0:
            continue                                      # not a joint, or a rigid one
        best = ref[f"dp_joint_{a[k]}"][ri[k]]
        theirs = ref[f"dp_joint_{b[k]}"][ri[k]]
        near[k] = abs(best - theirs) <= tol[k] * best
    bad = diff if strict else diff & ~near
    for m in ("kinetostatic", "dynamic"):
        sel = both & (modes == m)
        nb = int((bad & sel).sum())
        where = f"{m[:3]} #{int(samples[np.flatnonzero(bad & sel)[0]])}" if nb else ""
        stats.add("dominant", m, np.inf if nb else 0.0, 1.0, where, nb,
                  int((nullmis & (modes == m)).sum()), int(sel.sum()))
        near_ties[m] = near_ties.get(m, 0) + int((near & (modes == m)).sum())
    if near.any():
        k = int(np.flatnonzero(near)[0])
        notes.append(f"dominant: {int(near.sum())} near tie(s) accepted (first {modes[k]} "
                     f"#{int(samples[k])}: ref {a[k]}, engine {b[k]})")
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        fails.append(f"dominant: {int(bad.sum())} mismatches (first {modes[k]} #{int(samples[k])}: "
                     f"ref {a[k]}, engine {b[k]})")
    if nullmis.any():
        k = int(np.flatnonzero(nullmis)[0])
        fails.append(f"dominant: {int(nullmis.sum())} null mismatches (first {modes[k]} "
                     f"#{int(samples[k])}: ref {a[k]}, engine {'null' if bnull[k] else b[k]}, "
                     f"status {ref['status'][ri[k]]})")
    return fails


SUMMARY_P95_RTOL = 5e-4


def compare_summary(ref, out_dir, P, notes, near_ties):
    """The spec's summary quantities against summary.parquet (variant 0, each mode);
    skipped with a note when the engine does not write them."""
    import pyarrow.parquet as pq
    path = os.path.join(out_dir, "summary.parquet")
    if not os.path.exists(path):
        notes.append("no summary.parquet: envelope summary not compared")
        return []
    rows = [r for r in pq.read_table(path).to_pylist() if r.get("variant") == 0]
    ours = rm.envelope_summary(ref)
    names = list(next(iter(ours.values())))
    if not rows or not any(n in rows[0] for n in names):
        notes.append("summary.parquet has no envelope statistics: not compared")
        return []
    fails = []
    phys = physical_scale(P)
    for mode, res in ours.items():
        row = next((r for r in rows if r.get("mode") == mode), None)
        if row is None:
            fails.append(f"summary: no row for mode {mode}")
            continue
        tol = TOL[mode]
        n_ok = int(((ref["mode"] == mode) & (ref["status"] == "ok")).sum())
        for n in names:
            if n not in row:
                fails.append(f"summary {mode}: missing {n}")
                continue
            a, b = res[n], row[n]
            if a is None or b is None:
                if (a is None) != (b is None):
                    fails.append(f"summary {mode} {n}: ref {a}, engine {b}")
                continue
            if n.startswith("dominant_share_"):
                lim = near_ties.get(mode, 0) / max(n_ok, 1) + 1e-12
            elif n.endswith("_p95"):
                lim = SUMMARY_P95_RTOL * max(abs(a), abs(b))
            else:
                unit = "env_ang" if n.startswith("env_alpha") else "env_len"
                floor = PHYS_FLOOR * phys[unit]
                lim = tol * max(abs(a), abs(b), floor)
            if not abs(a - b) <= lim:
                fails.append(f"summary {mode} {n}: ref {a:.17g}, engine {b:.17g} (allowed {lim:.2e})")
    return fails


def print_table(stats):
    """Worst |a-b|/max(|a|,|b|,S_c) per column; tolerance 1e-9 (kin) / 1e-6 (dyn)."""
    print("worst raw normalised error |a-b|/max(|a|,|b|,S_c) per column "
          f"(tolerance {TOL['kinetostatic']:.0e} kinetostatic, {TOL['dynamic']:.0e} dynamic, plus the "
          "round-off term 10 eps kappa F_c; 'bad' counts cells beyond both; '!' = column with failures)")
    print(f"  {'column':<24}{'kinetostatic':>13}{'dynamic':>11}{'bad':>6}{'null!=':>8}{'compared':>10}"
          "  worst (err/tol) at")
    for c, w in stats.cols.items():
        flag = "!" if (w["bad"] or w["null"]) else " "
        k, d = w["kinetostatic"], w["dynamic"]
        fk = f"{k[0]:.2e}" if k[0] >= 0 else "-"
        fd = f"{d[0]:.2e}" if d[0] >= 0 else "-"
        rk = k[0] / k[1] if k[0] >= 0 else -1
        rd = d[0] / d[1] if d[0] >= 0 else -1
        where = k[2] if rk >= rd else d[2]
        print(f"{flag} {c:<24}{fk:>13}{fd:>11}{w['bad']:>6}{w['null']:>8}{w['n']:>10}  {where}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "clearance"))
    ap.add_argument("--keep", default=None, help="keep job files and outputs in this directory")
    ap.add_argument("--threads", type=int, default=None, help="pass --threads N to the engine")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per engine run")
    ap.add_argument("--reference-only", action="store_true",
                    help="generate the jobs and run only the reference (no engine)")
    ap.add_argument("--strict-dominant", action="store_true",
                    help="fail on near ties of `dominant` too (see the module doc)")
    ap.add_argument("--kinds", default="prototype",
                    help="comma-separated job families: prototype, 3-PRS, 3-RPS, 6-UPS, or all "
                         "(default prototype)")
    args = ap.parse_args(argv)
    try:
        kinds = parse_kinds(args.kinds)
    except ValueError as exc:
        ap.error(str(exc))

    binary = args.bin if os.path.isabs(args.bin) else os.path.join(REPO, args.bin)
    if not args.reference_only and not os.access(binary, os.X_OK):
        print(f"engine binary not found or not executable: {binary}", file=sys.stderr)
        return 2
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
        work = os.path.abspath(args.keep)
    else:
        work = tempfile.mkdtemp(prefix="clearance-xcheck-")
    rng = np.random.default_rng(args.seed)
    stats = Stats()
    passed = failed = 0
    lines = []
    all_notes = {}
    try:
        for i in range(args.jobs):
            job, tag = make_job(rng, i, kinds)
            # round-trip through TOML so both sides read the very same numbers
            job = tomllib.loads(to_toml(job))
            t0 = time.time()
            ups = job.get("mechanism", {}).get("kind") == ru.KIND
            reference = (lambda j: ru.compute(j, "full")) if ups else (lambda j: rm.compute(j, extras=True))
            ref = reference(job)
            if maybe_add_thresholds(rng, job, ref):
                tag += " singular_cond"
                ref = reference(job)
            t_ref = time.time() - t0
            text = to_toml(job)
            job = tomllib.loads(text)
            path = os.path.join(work, f"job_{i:03d}.toml")
            with open(path, "w") as f:
                f.write(text)
            nst = {s: int((ref["status"] == s).sum()) for s in np.unique(ref["status"])}
            label = f"job {i:03d}"
            info = f"{tag}, {ref['sample'].size} rows {nst}"
            if args.reference_only:
                lines.append(f"{label} REF-ONLY ({info}; reference {t_ref:.2f}s)")
                continue
            out = os.path.join(work, f"out_{i:03d}")
            if os.path.exists(out):
                shutil.rmtree(out)
            cmd = [binary, "run", path, "--out", out, "--columns", "full"]
            if args.threads:
                cmd += ["--threads", str(args.threads)]
            t0 = time.time()
            try:
                pr = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
                rc, err = pr.returncode, pr.stderr.strip()
            except subprocess.TimeoutExpired:
                rc, err = -1, f"timed out after {args.timeout}s"
            t_eng = time.time() - t0
            fails, notes, near_ties = [], [], {}
            if rc != 0:
                fails.append(f"engine exit {rc}: {err.splitlines()[-1] if err else ''}")
            else:
                try:
                    eng, nfiles = read_engine(out)
                    Pj = ru.normalize_job(job) if ups else rm.normalize_job(job)
                    fails += compare(ref, eng, label, stats, Pj, notes, args.strict_dominant, near_ties)
                    if not ups and any(c in eng for c in ENV_COLUMNS):
                        fails += compare_summary(ref, out, Pj, notes, near_ties)
                except Exception as exc:  # report, do not crash the whole run
                    fails.append(f"reading/comparing failed: {type(exc).__name__}: {exc}")
            if fails:
                failed += 1
                lines.append(f"{label} FAIL ({info}; engine {t_eng:.2f}s)")
                lines += [f"    {f}" for f in fails[:25]]
                if len(fails) > 25:
                    lines.append(f"    ... {len(fails) - 25} more")
            else:
                passed += 1
                lines.append(f"{label} pass ({info}; engine {t_eng:.2f}s, reference {t_ref:.2f}s)")
            for n in notes:
                if "near tie" in n:
                    lines.append(f"    note: {n}")
                else:
                    all_notes[n] = all_notes.get(n, 0) + 1
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    if stats.cols:
        print_table(stats)
        print()
    print("\n".join(lines))
    for n, k in all_notes.items():
        print(f"note ({k} job(s)): {n}")
    if args.keep:
        print(f"jobs and outputs kept in {work}")
    if args.reference_only:
        print(f"{args.jobs} generated (reference only)")
        return 0
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
