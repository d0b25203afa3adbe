#!/usr/bin/env python3
"""Cross-check the engine's custom mechanisms (docs/model.md section 12) against
scripts/reference_custom.py.

    python3 scripts/crosscheck_custom.py --bin PATH [--jobs N] [--seed S] [--keep DIR]
    python3 scripts/crosscheck_custom.py --bin PATH --job FILE      # one given job
    python3 scripts/crosscheck_custom.py --reference-only --jobs N  # generate, run the reference

Each random (seeded) job is drawn from one of five families (a sixth, ``6-RUS``, with
``--families``):

* ``3-RRS``: a wrist with rotary cranks: an actuated R crank at the base (tangent axis),
  an R knee, an S at the platform; symmetric (``repeat = 3``) or written out with uneven
  limb angles; inputs z, psi, theta;
* ``3-PRS/3-RPS``: the two 3-limb layouts of docs/model.md section 10 with random geometry
  (rail angle, limb angles, tilted revolute axes, random names), written as joints;
* ``6-UPS``: random base and platform points, tilted U axes, cylinder and piston bodies;
* ``6-PUS``: six vertical or inclined actuated sliders, U joints on the sliders,
  fixed-length legs, S joints on the platform;
* ``6-RUS``: a rotary hexapod, six motors (actuated R, axes about tangent) turning
  cranks, U joints at the cranks' ends, rods, S joints on the platform: no kind of the
  engine's has rotary actuators on six limbs;

with random masses (explicit centres of mass and inertias or the defaults), point masses,
platform inertia, gravity, external loads, clearance magnitudes (scalars, per-limb lists,
zeros), grids over one to three inputs or trajectories, kinetostatic and dynamic modes,
exact mode.  The home pose is tilted and offset at random (the joints are placed in the
world first, so every description closes at home by construction).  A job is kept only
if the reference finds every sample reachable and well conditioned (kappa below
COND_MAX, CHOICES 7 of the reference) and, in exact mode, the exact error converged on
every ok row; otherwise it is drawn again.

Each job is written as TOML, run as ``BIN run JOB --out DIR --overwrite --quiet
--columns full``, and ``DIR/poses/variant=*/part-*.parquet`` is read with pyarrow and
joined with the reference on (mode, sample).  Every column present in both is compared:

    |a - b| <= tol * S_c,   tol = 1e-9 (kinetostatic rows), 1e-6 (dynamic rows),
    S_c = max(M_c, 1e-2 * M_g, 1e-6 * N_g)

(a column that is zero to round-off, such as the error of a group that cannot move the
platform, is measured against a hundredth of its group's scale; the exact error, p' - p of
positions of a few Lchar solved by chord iterations, against at least 1e-5 Lchar: its
own round-off is some ulps of |p|, 1.1e-15 Lchar seen).
The error and envelope columns are allowed, per row, the round-off of the error system
first: |a - b| - n^2 eps kappa_e F <= tol * S_c (the normwise forward-error bound of
Gaussian elimination with partial pivoting, 3 n^2 rho eps kappa, without its constant and
growth factor), n = 6 L the system's equations, kappa_e its condition number and F the size of its
solution for the column's kind (every kind's for the totals), the platform's error with
the passive motions, in the column's unit (the reference's extra columns kappa_e and
sol_len_<kind>). A play that the passive joints cancel, such as the
radial play of a P joint between a U and an S, moves nothing, yet its error carries the
round-off of passive motions of its own size: 1e-17 rad against errors of 1e-6 rad in
the other kinds, beyond a hundredth of the group's scale times 1e-9.

M_c the largest |reference value| of the column in that job and mode, M_g the largest
over the column's unit group (lengths, angles, time, forces, couples, errors, rotation
errors, envelopes, exact errors), N_g the group's natural magnitude (Lchar the largest
joint distance from P at home, 1 rad, W = moving weight, W Lchar, c_t + Lchar c_a,
c_a + c_t / Lchar with c_t, c_a the sums of the translational and angular magnitudes).
``status`` strings must be equal, the engine's nulls exactly where the reference has
NaN, no NaN stored; ``dominant`` equal, except where the engine's joint ties the
reference's largest |dp| to the row's tolerance (reported as a near tie, not failed).
Reference columns missing from the engine fail; engine-only columns are listed.

``DIR/discontinuities.parquet`` (variant, mode, limb, kind, t, x ... theta, margin,
jump_*) is checked against the reference's loads along the path (the trajectory, or the
grid line through the switch: the input whose value is off the grid nodes):

* every engine switch is confirmed: a scalar load (R axial, U angular, backlash) changes
  sign between the location -+ 1e-6 of the path's range; a vector load has a local
  minimum of |f| there (|f(s)| <= |f(s -+ 1e-6)|) below discontinuity_load_fraction * W
  (times 1 m for couples), and the reported margin equals |f(s)| to 1e-6 W;
* every sign change of a scalar load between consecutive determinate samples of a path
  (a run of solvable samples) is an engine switch (same mode, limb, kind, line, between
  the two samples).

Prints a per-column table of the worst normalised error |a - b| / S_c (kinetostatic,
dynamic), the switch checks, one line per job and ``N passed, M failed``; the exit code
is 1 if any job failed, 2 on a bad command line.
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
import reference_custom as rc  # noqa: E402
import reference_model as rm  # noqa: E402

REPO = os.path.dirname(HERE)
TOL = {"kinetostatic": 1e-9, "dynamic": 1e-6}
GROUP_FLOOR = 1e-2
PHYS_FLOOR = 1e-6
# The exact error is p' - p of positions of a few Lchar, solved by chord iterations that
# stop where they stagnate: its round-off is some ulps of |p| (1.08e-15 Lchar seen on a
# 6-UPS, seed 26003 job 014); 1e-9 of 1e-5 Lchar allows 45 ulps of 1 m.
EXACT_ROUNDOFF = 1e-5
# The round-off allowed an error or envelope value: n^2 * eps * kappa_e * F (n the error
# system's size), the normwise bound of Gaussian elimination (Higham, Accuracy and
# Stability of Numerical Algorithms, §9.4: 3 n^2 rho eps kappa, here without the constant
# and the growth factor rho). With n alone, 4 of 920 random jobs (seeds 2029, 7001-26003)
# failed on round-off zeros, by up to 18 times n eps kappa_e F (a P joint's radial play
# between a U and an S, 6-UPS-like legs: n = 36).
EPS = np.finfo(float).eps
COND_MAX = 1e4
SWITCH_DELTA = 1e-6
# The families drawn by default; `--families` also takes "6-RUS", drawn only when asked
# for, so that the seeds CI runs keep giving the jobs they always gave.
FAMILIES = ("3-RRS", "3-PRS", "3-RPS", "6-UPS", "6-PUS")
I3 = np.eye(3)


# --------------------------------------------------------------------------
# random descriptions
# --------------------------------------------------------------------------
def _r(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _logu(rng, lo_exp, hi_exp):
    return float(10.0 ** rng.uniform(lo_exp, hi_exp))


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _frame(alpha):
    return (np.array([math.cos(alpha), math.sin(alpha), 0.0]),
            np.array([-math.sin(alpha), math.cos(alpha), 0.0]), np.array([0.0, 0.0, 1.0]))


def _rot(axis, ang):
    return rm.rot_exp(np.asarray(axis, float)[None] * ang)[0]


def _lst(v):
    return [float(x) for x in np.asarray(v, float).ravel()]


def _mat(M):
    return [[float(x) for x in row] for row in np.asarray(M, float)]


def _rod_inertia(m, ell, e):
    return m * ell * ell / 12.0 * (I3 - np.outer(e, e))


def _body(rng, m, com=None, inertia=None):
    """A body with mass m; sometimes with explicit com and inertia."""
    b = {"mass": float(m)}
    if com is not None and rng.random() < 0.5:
        b["com"] = _lst(com)
        if inertia is not None:
            b["inertia"] = _mat(inertia)
    return b


def _home_pose(rng, centre):
    """Home coordinates: the joints' centroid offset a little, small tilt."""
    off = rng.normal(0.0, 0.02, 3)
    ang = rng.uniform(-0.12, 0.12, 3) if rng.random() < 0.7 else np.zeros(3)
    return [float(v) for v in (centre + off)] + [float(a) for a in ang]


def _limb_angles(rng, n):
    base = np.arange(n) * 2.0 * math.pi / n + rng.uniform(-math.pi, math.pi)
    if rng.random() < 0.5:
        base = base + rng.uniform(-0.25, 0.25, n)
    return base


def fam_rrs(rng):
    """3-RRS wrist: actuated crank R (tangent axis) - crank - knee R - leg - S."""
    Rb, lc = _r(rng, 0.2, 0.35), _r(rng, 0.15, 0.3)
    beta = _r(rng, -0.5, 0.5)
    ll, rho = _r(rng, 0.35, 0.6), _r(rng, 0.08, 0.22)
    sym = rng.random() < 0.5
    alphas = np.arange(3) * 2 * math.pi / 3 if sym else _limb_angles(rng, 3)
    names = ("crank", "knee", "s") if rng.random() < 0.7 else ("r", "r2", "ball")
    mc, ml = _r(rng, 0.3, 2.0), _r(rng, 0.5, 3.0)
    limbs, A_all = [], []
    for j, al in enumerate(alphas if not sym else alphas[:1]):
        x, y, z = _frame(al)
        B = Rb * x
        K = B + lc * (math.cos(beta) * x + math.sin(beta) * z)
        dx = rho - (Rb + lc * math.cos(beta))
        if ll <= abs(dx) + 0.05:
            return None
        A = rho * x + (K[2] + math.sqrt(ll * ll - dx * dx)) * z
        ecr, eleg = _unit(K - B), _unit(A - K)
        if np.linalg.norm(np.cross(ecr, eleg)) < 0.35:
            return None
        joints = [{"type": "R", "name": names[0], "at": _lst(B), "axis": _lst(y), "actuated": True,
                   "range": [-1.2, 1.2]},
                  {"type": "R", "name": names[1], "at": _lst(K), "axis": _lst(y)},
                  {"type": "S", "name": names[2], "at": _lst(A)}]
        if names[2] == "s" and rng.random() < 0.5:
            del joints[2]["name"]
        bodies = [_body(rng, mc, 0.5 * (B + K), _rod_inertia(mc, lc, ecr) * _r(rng, 0.8, 1.2)),
                  _body(rng, ml, 0.5 * (K + A) + 0.01 * eleg, _rod_inertia(ml, ll, eleg))]
        limb = {"joints": joints, "bodies": bodies}
        if sym:
            limb["repeat"] = 3
            if rng.random() < 0.5:
                limb["rotate_deg"] = 120.0
        limbs.append(limb)
        A_all.append(A)
    if sym:
        A_all = [(_rot([0, 0, 1], k * 2 * math.pi / 3) @ A_all[0]) for k in range(3)]
    return {"limbs": limbs, "centre": np.mean(A_all, 0), "inputs": ["z", "psi", "theta"],
            "names": names, "act": "R", "size": ll}


def _tilted(rng, v, about, amp=0.15):
    return _rot(about, _r(rng, -amp, amp)) @ v if rng.random() < 0.6 else v


def fam_prs(rng):
    """3-PRS-like: actuated slider on a rail (any angle) - slider - R - leg - S."""
    Rb, rho, L = _r(rng, 0.35, 0.6), _r(rng, 0.1, 0.25), _r(rng, 0.5, 1.0)
    beta = float(rng.choice([0.0, _r(rng, -1.0, 1.0), -math.pi / 2 * _r(rng, 0.7, 1.0)]))
    alphas = _limb_angles(rng, 3)
    names = ("p", "r", "s") if rng.random() < 0.5 else ("rail", "hinge", "ball")
    msl, ml = float(rng.choice([0.0, _r(rng, 0.2, 1.0)])), _r(rng, 0.5, 3.0)
    limbs, A_all = [], []
    zb = _r(rng, -0.1, 0.1)
    for al in alphas:
        x, y, z = _frame(al)
        d = math.cos(beta) * z + math.sin(beta) * x
        a = _unit(_tilted(rng, y, x, 0.12))
        B = Rb * x + zb * z + _r(rng, -0.1, 0.1) * d
        target = rho * x + (zb + L * _r(rng, 0.7, 0.9)) * z
        v = target - B
        v = v - (v @ a) * a
        e = _unit(v)
        if abs(e @ d) > 0.95 or abs(e @ d) < 0.1:
            return None
        A = B + L * e
        joints = [{"type": "P", "name": names[0], "at": _lst(B), "axis": _lst(d), "actuated": True,
                   "range": [-0.5, 0.5]},
                  {"type": "R", "name": names[1], "at": _lst(B), "axis": _lst(a)},
                  {"type": "S", "name": names[2], "at": _lst(A)}]
        bodies = [{"mass": msl}, _body(rng, ml, 0.5 * (A + B), _rod_inertia(ml, L, e))]
        limbs.append({"joints": joints, "bodies": bodies})
        A_all.append(A)
    return {"limbs": limbs, "centre": np.mean(A_all, 0), "inputs": ["z", "psi", "theta"],
            "names": names, "act": "P", "size": L}


def fam_rps(rng):
    """3-RPS-like: R at the base - cylinder - actuated P along the leg - piston - S."""
    Rb, rho = _r(rng, 0.2, 0.4), _r(rng, 0.1, 0.3)
    lc, lp = _r(rng, 0.5, 0.8), _r(rng, 0.5, 0.8)
    alphas = _limb_angles(rng, 3)
    names = ("r", "p", "s") if rng.random() < 0.5 else ("pivot", "ram", "s")
    mc, mp = _r(rng, 0.5, 2.5), _r(rng, 0.3, 1.5)
    limbs, A_all = [], []
    h = 0.5 * (max(lc, lp) + lc + lp) * _r(rng, 0.85, 0.95)
    for al in alphas:
        x, y, z = _frame(al)
        a = _unit(_tilted(rng, y, x, 0.12))
        B = Rb * x
        v = rho * x + h * z - B
        v = v - (v @ a) * a
        q = float(np.linalg.norm(v))
        e = v / q
        A = B + q * e
        if not (max(lc, lp) + 0.03 < q < lc + lp - 0.03):
            return None
        joints = [{"type": "R", "name": names[0], "at": _lst(B), "axis": _lst(a)},
                  {"type": "P", "name": names[1], "at": _lst(B + lc * e), "axis": _lst(e),
                   "actuated": True, "range": [max(lc, lp) - q, lc + lp - q]},
                  {"type": "S", "name": names[2], "at": _lst(A)}]
        bodies = [{"mass": mc, "com": _lst(B + 0.5 * lc * e), "inertia": _mat(_rod_inertia(mc, lc, e))},
                  {"mass": mp, "com": _lst(A - 0.5 * lp * e), "inertia": _mat(_rod_inertia(mp, lp, e))}]
        if rng.random() < 0.3:
            bodies = [{"mass": mc}, {"mass": mp}]           # rods between the joints' centres
        limbs.append({"joints": joints, "bodies": bodies})
        A_all.append(A)
    return {"limbs": limbs, "centre": np.mean(A_all, 0), "inputs": ["z", "psi", "theta"],
            "names": names, "act": "P", "size": h}


def _six_points(rng, radius, spread, offset):
    ang = []
    for k in range(3):
        c = offset + k * 2 * math.pi / 3
        ang += [c - spread / 2, c + spread / 2]
    ang = np.array(ang) + rng.uniform(-0.05, 0.05, 6)
    r = radius * rng.uniform(0.93, 1.07, 6)
    return np.stack([r * np.cos(ang), r * np.sin(ang), rng.uniform(-0.02, 0.02, 6)], -1)


def fam_ups(rng):
    """6-UPS-like: U at the base - cylinder - actuated P - piston - S."""
    Rb, rp = _r(rng, 0.4, 0.6), _r(rng, 0.2, 0.35)
    B = _six_points(rng, Rb, _r(rng, 0.3, 0.6), 0.0)
    Ap = _six_points(rng, rp, _r(rng, 0.3, 0.6), math.pi / 3)
    Ap = np.roll(Ap, 1, axis=0)
    lc, lp = _r(rng, 0.45, 0.6), _r(rng, 0.45, 0.6)
    h = None
    for _ in range(20):
        hz = _r(rng, 0.55, 0.85)
        q = np.linalg.norm(Ap + [0, 0, hz] - B, axis=-1)
        if np.all((q > max(lc, lp) + 0.05) & (q < lc + lp - 0.05)):
            h = hz
            break
    if h is None:
        return None
    A = Ap + [0, 0, h]
    mc, mp = _r(rng, 0.5, 2.0), _r(rng, 0.3, 1.0)
    names = ("u", "p", "s") if rng.random() < 0.6 else ("hook", "jack", "s")
    limbs = []
    for i in range(6):
        e = _unit(A[i] - B[i])
        th = math.atan2(B[i, 1], B[i, 0])
        a1 = _unit(_tilted(rng, np.array([-math.sin(th), math.cos(th), 0.0]),
                           [math.cos(th), math.sin(th), 0.0], 0.3))
        if np.linalg.norm(np.cross(a1, e)) < 0.5:
            return None
        a2 = _unit(np.cross(a1, e))
        q = float(np.linalg.norm(A[i] - B[i]))
        joints = [{"type": "U", "name": names[0], "at": _lst(B[i]), "axes": [_lst(a1), _lst(a2)]},
                  {"type": "P", "name": names[1], "at": _lst(B[i] + lc * e), "axis": _lst(e),
                   "actuated": True, "range": [max(lc, lp) - q, lc + lp - q]},
                  {"type": "S", "name": names[2], "at": _lst(A[i])}]
        bodies = [{"mass": mc, "com": _lst(B[i] + 0.5 * lc * e), "inertia": _mat(_rod_inertia(mc, lc, e))},
                  {"mass": mp, "com": _lst(A[i] - 0.5 * lp * e), "inertia": _mat(_rod_inertia(mp, lp, e))}]
        limbs.append({"joints": joints, "bodies": bodies})
    return {"limbs": limbs, "centre": A.mean(0), "inputs": list(rc.COORDS), "names": names,
            "act": "P", "size": 0.5 * (lc + lp)}


def fam_pus(rng):
    """6-PUS: actuated slider (vertical or inclined) - slider - U - leg - S."""
    Rb, rp = _r(rng, 0.45, 0.65), _r(rng, 0.2, 0.35)
    B = _six_points(rng, Rb, _r(rng, 0.25, 0.6), 0.0)
    Ap = np.roll(_six_points(rng, rp, _r(rng, 0.3, 0.6), math.pi / 3), 1, axis=0)
    incl = _r(rng, -0.6, 0.3) if rng.random() < 0.5 else 0.0
    L = _r(rng, 0.5, 0.8)
    ms, ml = float(rng.choice([0.0, _r(rng, 0.2, 1.0)])), _r(rng, 0.5, 2.0)
    names = ("p", "u", "s") if rng.random() < 0.6 else ("slide", "cardan", "s")
    limbs, A_all = [], []
    for i in range(6):
        x, t, _ = _frame(math.atan2(B[i, 1], B[i, 0]))
        d = math.cos(incl) * np.array([0, 0, 1.0]) + math.sin(incl) * x
        horiz = Ap[i, :2] - B[i, :2]
        rad2 = L * L - horiz @ horiz
        if rad2 < 0.05:
            return None
        A = np.array([Ap[i, 0], Ap[i, 1], B[i, 2] + math.sqrt(rad2)])
        e = _unit(A - B[i])
        a1 = _unit(_tilted(rng, t, x, 0.25))
        if np.linalg.norm(np.cross(a1, e)) < 0.5 or abs(e @ d) > 0.97:
            return None
        a2 = _unit(np.cross(a1, e))
        joints = [{"type": "P", "name": names[0], "at": _lst(B[i]), "axis": _lst(d), "actuated": True,
                   "range": [-0.4, 0.4]},
                  {"type": "U", "name": names[1], "at": _lst(B[i]), "axes": [_lst(a1), _lst(a2)]},
                  {"type": "S", "name": names[2], "at": _lst(A)}]
        bodies = [{"mass": ms}, _body(rng, ml, 0.5 * (A + B[i]), _rod_inertia(ml, L, e))]
        limbs.append({"joints": joints, "bodies": bodies})
        A_all.append(A)
    # the platform's points must be rigid: heights differ by the legs, which is fine (the
    # platform is whatever shape closes at home)
    return {"limbs": limbs, "centre": np.mean(A_all, 0), "inputs": list(rc.COORDS),
            "names": names, "act": "P", "size": L}


def fam_rus(rng):
    """6-RUS rotary hexapod: actuated R (a motor, axis about tangent) - crank - U - rod -
    S. No kind of the engine's has rotary actuators and six limbs: a mechanism that is
    not in the repository."""
    Rb, rp = _r(rng, 0.35, 0.55), _r(rng, 0.15, 0.3)
    B = _six_points(rng, Rb, _r(rng, 0.25, 0.6), 0.0)
    A = np.roll(_six_points(rng, rp, _r(rng, 0.3, 0.6), math.pi / 3), 1, axis=0)
    A[:, 2] += _r(rng, 0.35, 0.6)
    lc = _r(rng, 0.1, 0.2)
    mc, ml = _r(rng, 0.2, 1.0), _r(rng, 0.3, 1.5)
    names = ("motor", "u", "s") if rng.random() < 0.6 else ("r", "cardan", "ball")
    limbs, lengths = [], []
    for i in range(6):
        x, t, _ = _frame(math.atan2(B[i, 1], B[i, 0]))
        axis = _unit(_tilted(rng, t, x, 0.2))
        w = _unit(x - (x @ axis) * axis)                 # outward, normal to the axis
        ang = _r(rng, -0.6, 0.6)
        crank = math.cos(ang) * w + math.sin(ang) * _unit(np.cross(axis, w))
        C = B[i] + lc * crank
        e = _unit(A[i] - C)
        # the motor must drive the rod: its torque arm along e, not across it
        if abs(np.cross(crank, e) @ axis) < 0.3:
            return None
        a1 = _unit(_tilted(rng, axis, crank, 0.3))
        if np.linalg.norm(np.cross(a1, e)) < 0.5:
            return None
        a2 = _unit(np.cross(a1, e))
        L = float(np.linalg.norm(A[i] - C))
        joints = [{"type": "R", "name": names[0], "at": _lst(B[i]), "axis": _lst(axis), "actuated": True,
                   "range": [-1.0, 1.0]},
                  {"type": "U", "name": names[1], "at": _lst(C), "axes": [_lst(a1), _lst(a2)]},
                  {"type": "S", "name": names[2], "at": _lst(A[i])}]
        bodies = [_body(rng, mc, B[i] + 0.5 * lc * crank, _rod_inertia(mc, lc, crank)),
                  _body(rng, ml, 0.5 * (C + A[i]), _rod_inertia(ml, L, e))]
        limbs.append({"joints": joints, "bodies": bodies})
        lengths.append(L)
    return {"limbs": limbs, "centre": A.mean(0), "inputs": list(rc.COORDS), "names": names,
            "act": "R", "size": float(np.mean(lengths))}


FAMILY_FN = {"3-RRS": fam_rrs, "3-PRS": fam_prs, "3-RPS": fam_rps, "6-UPS": fam_ups, "6-PUS": fam_pus,
             "6-RUS": fam_rus}


def _clearances(rng, desc, mech_job):
    """Random [clearance] over the description's joint groups."""
    M = rc.normalize_job(mech_job, check=False)
    keys = {}
    for L in M.limbs:
        for J in L.joints:
            for g in J.groups():
                keys.setdefault(f"{J.name}_{g}", []).append(J)
    cl = {}
    for key, holders in keys.items():
        if rng.random() < 0.35:
            continue
        group = key.rsplit("_", 1)[1]
        ang = group == "angular" or (group == "backlash" and holders[0].type == "R")
        lo, hi = (-5.0, -3.0) if ang else (-5.5, -3.7)
        if rng.random() < 0.2:
            cl[key] = [(_logu(rng, lo, hi) if rng.random() > 0.15 else 0.0) for _ in holders]
        else:
            cl[key] = _logu(rng, lo, hi) if rng.random() > 0.08 else 0.0
    if not cl:
        k = next(iter(keys))
        cl[k] = 1e-4
    return cl


def _harmonic(rng, offset, amp, T_lo=0.8, T_hi=3.0):
    k = int(rng.integers(1, 3))
    amps = rng.dirichlet(np.ones(k)) * amp
    return {"offset": float(offset),
            "harmonics": [{"amplitude": float(a), "period": _r(rng, T_lo, T_hi),
                           "phase": _r(rng, -math.pi, math.pi)} for a in amps]}


def random_job(rng, index, families=FAMILIES):
    """(job dict, tag) or None when the draw is rejected."""
    fam = str(rng.choice(list(families)))
    desc = FAMILY_FN[fam](rng)
    if desc is None:
        return None
    home = _home_pose(rng, desc["centre"])
    mech = {"kind": "custom", "inputs": list(desc["inputs"]), "home": home, "limb": desc["limbs"]}
    if rng.random() < 0.5:
        mech["inputs"] = list(rng.permutation(mech["inputs"]))          # any order
    if rng.random() < 0.3:
        mech["gravity"] = [_r(rng, -1.0, 1.0), _r(rng, -1.0, 1.0), _r(rng, -10.5, -9.0)]
    job = {"name": f"custom_{index:03d}", "mechanism": mech}
    mass = {"platform": _r(rng, 2.0, 15.0)}
    if rng.random() < 0.4:
        m = mass["platform"]
        mass["platform_inertia"] = [m * _r(rng, 0.01, 0.04), m * _r(rng, 0.01, 0.04), m * _r(rng, 0.02, 0.08)]
    pts = [{"mass": _r(rng, 0.5, 10.0), "at": [_r(rng, -0.15, 0.15), _r(rng, -0.15, 0.15), _r(rng, -0.4, 0.4)]}
           for _ in range(int(rng.integers(0, 3)))]
    if pts:
        mass["points"] = pts
    job["mass"] = mass
    if rng.random() < 0.6:
        job["load"] = {"force": [float(v) for v in rng.normal(0, 10, 3)],
                       "moment": [float(v) for v in rng.normal(0, 2, 3)],
                       "at": [_r(rng, -0.1, 0.1), _r(rng, -0.1, 0.1), _r(rng, -0.1, 0.2)]}
    job["clearance"] = _clearances(rng, desc, job | {"grid": {}})
    analysis = {}
    traj = rng.random() < 0.45
    inputs = sorted(desc["inputs"], key=rc.COORDS.index)
    span = {"x": 0.03, "y": 0.03, "z": 0.03, "phi": 0.1, "psi": 0.12, "theta": 0.12}
    hv = dict(zip(rc.COORDS, home))
    if traj:
        tr = {"time": {"start": 0.0, "stop": _r(rng, 1.0, 3.0), "n": int(rng.integers(15, 41))}}
        for k in inputs:
            tr[k] = _harmonic(rng, hv[k] + _r(rng, -0.3, 0.3) * span[k], span[k]) \
                if rng.random() < 0.7 else float(hv[k])
        job["trajectory"] = tr
        modes = [["kinetostatic"], ["dynamic"], ["kinetostatic", "dynamic"]][int(rng.integers(0, 3))]
        analysis["modes"] = modes
    else:
        g = {}
        nvar = int(rng.integers(1, 4))
        var = set(rng.choice(inputs, size=min(nvar, len(inputs)), replace=False))
        budget = {1: 25, 2: 9, 3: 5}[len(var)]
        for k in inputs:
            if k in var:
                a, b = sorted(rng.uniform(-1.0, 1.0, 2) * span[k])
                if b - a < 0.3 * span[k]:
                    b = a + 0.3 * span[k]
                g[k] = {"start": float(hv[k] + a), "stop": float(hv[k] + b),
                        "n": int(rng.integers(max(2, budget // 2), budget + 1))}
            else:
                g[k] = float(hv[k] + _r(rng, -0.5, 0.5) * span[k])
        job["grid"] = g
    if rng.random() < 0.4:
        analysis["exact"] = True
    if rng.random() < 0.3:
        analysis["discontinuity_load_fraction"] = _r(rng, 0.01, 0.1)
    if analysis:
        job["analysis"] = analysis
    return job, f"{fam}{' traj' if traj else ' grid'}"


def admissible(job, ref):
    """Why the reference rejects a generated job (None if it is kept)."""
    st = ref["status"].astype(str)
    if np.any((st != "ok") & (st != "indeterminate_contact")):
        return "statuses " + ",".join(sorted(set(st)))
    if np.nanmax(ref["kappa_g"]) > COND_MAX or np.nanmax(ref["kappa_limb"]) > COND_MAX:
        return "ill conditioned"
    if "exact_err_x" in ref and np.any(np.isnan(ref["exact_err_x"]) & (st == "ok")):
        return "exact did not converge"
    return None


def tighten_range(rng, job, M, ref):
    """A copy of an admissible job with one actuated joint's range cut between two of its
    sampled values (limb entry and its repeats alike): some samples become unreachable
    by range while the continuation still converges there.  (job, ref) or None."""
    import copy
    J = M.actuators[int(rng.integers(0, len(M.actuators)))]
    q = np.unique(np.round(ref[f"q{J.act}"][np.isfinite(ref[f"q{J.act}"])], 12))
    if q.size < 3:
        return None
    k = int(rng.integers(1, q.size - 1))
    cut = 0.5 * (q[k - 1] + q[k])
    # the [[mechanism.limb]] entry holding limb J.limb.number
    num = 0
    entry = None
    for e, lb in enumerate(job["mechanism"]["limb"]):
        num += int(lb.get("repeat", 1))
        if num >= J.limb.number:
            entry = e
            break
    out = copy.deepcopy(job)
    js = out["mechanism"]["limb"][entry]["joints"][J.place - 1]
    lo, hi = js.get("range", [-10.0, 10.0])
    js["range"] = [float(cut), float(hi)] if rng.random() < 0.5 else [float(lo), float(cut)]
    out = tomllib.loads(to_toml(out))
    ref2 = rc.compute(rc.normalize_job(out), extras=True)
    st = ref2["status"].astype(str)
    if not np.any(st == "unreachable") or not np.any(st == "ok"):
        return None
    return out, ref2


def make_job(rng, index, families=FAMILIES, tries=60, cut_ranges=True):
    last = None
    for _ in range(tries):
        out = random_job(rng, index, families)
        if out is None:
            continue
        job, tag = out
        job = tomllib.loads(to_toml(job))             # both sides read the very same numbers
        try:
            M = rc.check_description(job)
        except ValueError as exc:
            last = str(exc)
            continue
        ref = rc.compute(M, extras=True)
        why = admissible(job, ref)
        if why is None:
            if cut_ranges and rng.random() < 0.15:
                tight = tighten_range(rng, job, M, ref)
                if tight is not None:
                    return tight[0], tag + " range", tight[1]
            return job, tag, ref
        last = why
    raise RuntimeError(f"no admissible job in {tries} draws (last: {last})")


def refusal_jobs(rng):
    """Descriptions the engine must refuse (exit 2): [(label, job, words its message must
    hold)], built from a random 3-PRS-like and a random 6-UPS-like job."""
    import copy
    out = []
    prs, _, _ = make_job(rng, 0, ("3-PRS",), cut_ranges=False)
    # the counts alone decide: one clearance every variant has (the S joints' play)
    prs["clearance"] = {prs["mechanism"]["limb"][0]["joints"][2].get("name", "s") + "_radial": 1e-5}
    over = copy.deepcopy(prs)
    over["mechanism"]["limb"].append(copy.deepcopy(over["mechanism"]["limb"][0]))
    out.append(("overconstrained", over, ["overconstrained", "56", "54"]))
    loose = copy.deepcopy(prs)
    for lb in loose["mechanism"]["limb"]:
        r = lb["joints"][1]
        a = np.array(r["axis"], float)
        b = _unit(np.cross(a, [0.0, 0.0, 1.0]))
        lb["joints"][1] = {"type": "U", "name": r["name"], "at": r["at"], "axes": [_lst(a), _lst(b)]}
    out.append(("not rigid", loose, ["not rigid", "39", "42"]))
    ups, _, _ = make_job(rng, 0, ("6-UPS",), cut_ranges=False)
    idle = copy.deepcopy(ups)
    j0 = idle["mechanism"]["limb"][2]["joints"][0]
    idle["mechanism"]["limb"][2]["joints"][0] = {"type": "S", "name": "base", "at": j0["at"]}
    idle["clearance"] = {idle["mechanism"]["limb"][0]["joints"][2].get("name", "s") + "_radial": 1e-5}
    out.append(("idle freedom", idle, ["limb 3", "U"]))
    for label, job, words in out:
        try:
            rc.check_description(job)
        except ValueError as exc:
            msg = str(exc)
            assert all(w.lower() in msg.lower() for w in words), (label, msg)
        else:
            raise AssertionError(f"the reference accepts the {label} job")
    return out


# --------------------------------------------------------------------------
# TOML writer (the subset the job format needs, arrays of tables included)
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
    lines = [f"{k} = {_tv(v)}" for k, v in job.items() if not isinstance(v, dict)]
    for k, v in job.items():
        if not isinstance(v, dict):
            continue
        lines += ["", f"[{k}]"]
        arrays = {}
        for kk, vv in v.items():
            if isinstance(vv, list) and vv and all(isinstance(x, dict) for x in vv) and k == "mechanism":
                arrays[kk] = vv
            else:
                lines.append(f"{kk} = {_tv(vv)}")
        for kk, tables in arrays.items():
            for t in tables:
                lines += ["", f"[[{k}.{kk}]]"]
                for a, b in t.items():
                    if isinstance(b, list) and b and all(isinstance(x, dict) for x in b):
                        lines.append(f"{a} = [")
                        lines += [f"  {_tv(x)}," for x in b]
                        lines.append("]")
                    else:
                        lines.append(f"{a} = {_tv(b)}")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------
# reading the engine's output
# --------------------------------------------------------------------------
def read_table(files):
    import pyarrow as pa
    import pyarrow.parquet as pq
    tbl = pa.concat_tables([pq.ParquetFile(f).read() for f in files], promote_options="permissive")
    cols = {}
    for name in tbl.column_names:
        arr = tbl.column(name).combine_chunks()
        null = arr.is_null().to_numpy(zero_copy_only=False)
        if pa.types.is_dictionary(arr.type):
            arr = arr.cast(arr.type.value_type)
        if pa.types.is_string(arr.type) or pa.types.is_large_string(arr.type):
            cols[name] = (np.array(arr.to_pylist(), dtype=object), null, np.zeros(len(null), bool))
        else:
            vals = arr.cast(pa.float64()).to_numpy(zero_copy_only=False).astype(float)
            nan_stored = np.isnan(vals) & ~null
            cols[name] = (np.where(null, np.nan, vals), null, nan_stored)
    return cols


def read_engine(out_dir):
    files = sorted(glob.glob(os.path.join(out_dir, "poses", "variant=0", "part-*.parquet")))
    if not files:
        files = sorted(glob.glob(os.path.join(out_dir, "poses", "variant=0", "*.parquet")))
    if not files:
        raise RuntimeError(f"no parquet files in {out_dir}/poses/variant=0/")
    return read_table(files)


def read_switches(out_dir):
    path = os.path.join(out_dir, "discontinuities.parquet")
    if not os.path.exists(path):
        return None
    cols = read_table([path])
    out = {k: v[0] for k, v in cols.items()}
    if "variant" in out:
        sel = np.asarray(out["variant"], float) == 0
        out = {k: v[sel] for k, v in out.items()}
    return out


# --------------------------------------------------------------------------
# column comparison
# --------------------------------------------------------------------------
def _group_dims(M):
    """group name -> True if its load is a couple (N m)."""
    out = {}
    for g in M.groups:
        out[g.name] = g.group == "angular" or (g.group == "backlash" and g.joint.type == "R")
    return out


def unit_group(M, col):
    if col in ("t",):
        return "time"
    if col in ("x", "y", "z"):
        return "length"
    if col in ("phi", "psi", "theta"):
        return "angle"
    if col.startswith("q") and col[1:].isdigit():
        return "length" if M.actuators[int(col[1:]) - 1].type == "P" else "angle"
    if col.startswith("tau") and col[3:].isdigit():
        return "force" if M.actuators[int(col[3:]) - 1].type == "P" else "couple"
    comp = col.rsplit("_", 1)[-1]
    if col.startswith("exact_err_"):
        return "exact_len" if comp in ("x", "y", "z") else "exact_ang"
    if col.startswith("err_"):
        return "err_len" if comp in ("x", "y", "z") else "err_ang"
    if col.startswith("env_"):
        return "env_len" if comp in ("x", "y", "z", "p") else "env_ang"
    if col.startswith("margin_"):
        return "couple" if _group_dims(M).get(col[7:], False) else "force"
    if col.startswith("f_"):
        return "force"
    if col.startswith("m_"):
        return "couple"
    return None


def natural(M):
    trans = sum(g.mag for g in M.groups if not g.rot)
    ang = sum(g.mag for g in M.groups if g.rot)
    L = M.Lchar
    W = M.W if M.W > 0 else 1.0
    e_len, e_ang = trans + L * ang, ang + trans / L
    return {"time": 1.0, "length": L, "angle": 1.0, "force": W, "couple": W * L,
            "err_len": e_len, "err_ang": e_ang, "exact_len": e_len, "exact_ang": e_ang,
            "env_len": e_len, "env_ang": e_ang}


class Stats:
    def __init__(self):
        self.cols = {}

    def add(self, col, mode, ne, where, n_bad, n_null, n_cmp):
        w = self.cols.setdefault(col, {"kinetostatic": [-1.0, ""], "dynamic": [-1.0, ""],
                                       "bad": 0, "null": 0, "n": 0})
        if n_cmp and ne > w[mode][0]:
            w[mode] = [ne, where]
        w["bad"] += n_bad
        w["null"] += n_null
        w["n"] += n_cmp


SKIP = frozenset(("mode", "sample", "status", "dominant", "variant"))


def roundoff(M, ref, col, group):
    """Per row, the round-off allowed an error or envelope column (None for the others):
    n^2 * eps * kappa_e * F, the normwise forward-error bound of Gaussian elimination on
    the row's error system (n = 6 * limbs equations, kappa_e its condition number), F the
    size of the solution the value comes from (the column's kind's, or every kind's for
    the totals): the platform's error and the passive motions that go with it, in the
    column's unit. A take-up that the passive joints cancel (a P joint's
    radial play in a leg between a U and an S) has a zero error but passive motions of its
    own size: its error carries their round-off, not the error's."""
    if group not in ("err_len", "err_ang", "env_len", "env_ang") or "kappa_e" not in ref:
        return None
    body = col.split("_", 1)[1].rsplit("_", 1)[0] if col.count("_") > 1 else ""
    kinds = [body] if body in M.kinds else list(M.kinds)
    size = sum(np.nan_to_num(np.asarray(ref[f"sol_len_{k}"], float)) for k in kinds)
    if group.endswith("_ang"):
        size = size / M.Lchar
    n = 6 * len(M.limbs)
    return n * n * EPS * np.nan_to_num(np.asarray(ref["kappa_e"], float)) * size


def compare(M, ref, eng, label, stats, notes):
    """Failure strings; notes gets remarks.  ref: rc.compute(M, extras=True)."""
    fails = []
    extras = set(rc.extra_column_names(M))
    expected = [c for c in ref if c not in extras]
    missing = [c for c in expected if c not in eng and c != "variant"]
    if missing:
        fails.append(f"columns missing from the engine: {missing[:12]}{' ...' if len(missing) > 12 else ''}")
    only = sorted(set(eng) - set(ref) - {"variant"})
    if only:
        notes.append(f"engine-only columns (not compared): {only[:10]}{' ...' if len(only) > 10 else ''}")
    if "mode" not in eng or "sample" not in eng:
        return fails + ["engine output lacks mode/sample"]
    ekey = {(m, int(s)): i for i, (m, s) in enumerate(zip(eng["mode"][0], eng["sample"][0]))}
    rkey = [(m, int(s)) for m, s in zip(ref["mode"], ref["sample"])]
    if len(ekey) != len(eng["mode"][0]):
        fails.append("duplicate (mode, sample) rows in the engine output")
    if set(ekey) != set(rkey):
        fails.append(f"row sets differ: {len(set(rkey) - set(ekey))} missing, "
                     f"{len(set(ekey) - set(rkey))} extra")
        return fails
    ei = np.array([ekey[k] for k in rkey])
    modes = np.asarray(ref["mode"], dtype=object)
    samples = ref["sample"]
    # strings
    st_e = eng["status"][0][ei] if "status" in eng else None
    if st_e is not None:
        bad = st_e != ref["status"]
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            fails.append(f"status differs on {int(bad.sum())} rows, first {modes[k]} sample "
                         f"{samples[k]}: engine {st_e[k]!r}, reference {ref['status'][k]!r}")
    # numbers
    nat = natural(M)
    groups = {}
    for c in expected:
        if c in SKIP or c not in eng:
            continue
        groups.setdefault(unit_group(M, c), []).append(c)
    for mode in dict.fromkeys(modes):
        sel = modes == mode
        mg = {}
        for g, cs in groups.items():
            mg[g] = max([np.nanmax(np.abs(np.asarray(ref[c], float)[sel]), initial=0.0) for c in cs])
        tol = TOL[mode]
        for g, cs in groups.items():
            for c in cs:
                r = np.asarray(ref[c], float)[sel]
                vals, null, nan_stored = eng[c]
                e = vals[ei][sel]
                en, es = null[ei][sel], nan_stored[ei][sel]
                rn = np.isnan(r)
                n_null = int(np.sum(rn != en))
                if n_null:
                    k = int(np.flatnonzero(rn != en)[0])
                    fails.append(f"{c} ({mode}): null mismatch on {n_null} rows, first sample "
                                 f"{samples[sel][k]} (reference {'null' if rn[k] else r[k]}, "
                                 f"engine {'null' if en[k] else e[k]})")
                if np.any(es):
                    fails.append(f"{c} ({mode}): NaN stored in {int(es.sum())} rows")
                both = ~rn & ~en
                Mc = np.nanmax(np.abs(r), initial=0.0)
                Sc = max(Mc, GROUP_FLOOR * mg.get(g, 0.0), PHYS_FLOOR * nat.get(g, 1.0))
                if c.startswith("exact_err_"):
                    # p' - p of positions near Lchar: its own round-off is ~1e-15 Lchar.
                    Sc = max(Sc, EXACT_ROUNDOFF * max(1.0, M.Lchar))
                raw = np.abs(e[both] - r[both])
                allow = roundoff(M, ref, c, g)
                if allow is not None:
                    raw = np.maximum(raw - allow[sel][both], 0.0)
                err = raw / Sc if Sc > 0 else raw
                n_bad = int(np.sum(err > tol))
                ne = float(err.max()) if err.size else 0.0
                where = ""
                if err.size:
                    k = int(np.argmax(err))
                    where = f"{label} {mode} sample {samples[sel][both][k]}"
                stats.add(c, mode, ne, where, n_bad, n_null, int(both.sum()))
                if n_bad:
                    fails.append(f"{c} ({mode}): {n_bad} cells beyond {tol:g} of {Sc:.3e}, worst "
                                 f"{ne:.3e} at {where}")
    # dominant
    if "dominant" in eng:
        de = eng["dominant"][0][ei]
        dn = eng["dominant"][1][ei]
        dr = ref["dominant"]
        for k in range(dr.size):
            rv, ev = dr[k], (None if dn[k] else de[k])
            if rv == ev:
                continue
            if rv is None or ev is None:
                fails.append(f"dominant ({modes[k]} sample {samples[k]}): engine {ev!r}, reference {rv!r}")
                continue
            dps = np.array([ref[f"dp_{g.name}"][k] for g in M.groups])
            best = np.nanmax(dps)
            ce = f"dp_{ev}"
            tie = ce in ref and abs(ref[ce][k] - best) <= TOL[modes[k]] * max(best, 1e-300)
            if tie:
                notes.append(f"near tie of dominant at {modes[k]} sample {samples[k]}: engine "
                             f"{ev}, reference {rv}")
            else:
                fails.append(f"dominant ({modes[k]} sample {samples[k]}): engine {ev!r}, "
                             f"reference {rv!r}")
    else:
        fails.append("column dominant missing from the engine")
    return fails


# --------------------------------------------------------------------------
# switches
# --------------------------------------------------------------------------
def _path_points(M, mode, line, s):
    """Coordinates (and rates) at parameters s along a path.  line: ('traj', None) or
    ('grid', (input index, fixed coordinates (6,)))."""
    s = np.atleast_1d(np.asarray(s, float))
    if line[0] == "traj":
        tr = M.job["trajectory"]
        c = np.tile(M.home, (s.size, 1))
        cd, cdd = np.zeros_like(c), np.zeros_like(c)
        for i in M.inputs:
            if rc.COORDS[i] in tr:
                c[:, i], cd[:, i], cdd[:, i] = rm._harmonic(tr[rc.COORDS[i]], s)
        return c, cd, cdd
    i, fixed = line[1]
    c = np.tile(fixed, (s.size, 1))
    c[:, i] = s
    return c, None, None


def _loads_multi(M, mode, items):
    """Reference loads at many (line, s) points of one mode, in one batched evaluation."""
    cs, cds, cdds = [], [], []
    for line, s in items:
        c, cd, cdd = _path_points(M, mode, line, [s])
        cs.append(c)
        cds.append(cd if cd is not None else np.zeros_like(c))
        cdds.append(cdd if cdd is not None else np.zeros_like(c))
    c, cd, cdd = np.concatenate(cs), np.concatenate(cds), np.concatenate(cdds)
    dyn = mode == "dynamic"
    return rc.group_loads(M, c, mode, cd if dyn else None, cdd if dyn else None)


def _pick(ld, gname, k):
    """The loads of group gname at the points k (index array) of a _loads_multi result."""
    gd = ld[gname]
    return {"load": gd["load"][k], "margin": gd["margin"][k], "moves": gd["moves"][k],
            "group": gd["group"], "reach": ld["reach"][k]}


def _grid_axes(M):
    g = M.job["grid"]
    return {i: (rm._grid_axis(g[rc.COORDS[i]]) if rc.COORDS[i] in g else np.array([M.home[i]]))
            for i in M.inputs}


def switch_lines(M, row_coords):
    """Candidate lines through a switch location on a grid: the inputs whose value is off
    the grid nodes (or every swept input when all are on nodes)."""
    axes = _grid_axes(M)
    off = []
    for i, ax in axes.items():
        if ax.size > 1 and np.min(np.abs(ax - row_coords[i])) > 1e-12 * max(1.0, np.abs(ax).max()):
            off.append(i)
    if len(off) > 1:
        return []
    if not off:
        off = [i for i, ax in axes.items() if ax.size > 1]
    return [(i, np.array(row_coords, float)) for i in off]


def confirm_switch(M, g, margin, gd):
    """None if the reference's loads gd at (s - d, s, s + d) confirm a switch of group g
    with the engine's margin, else the reason."""
    if not np.all(gd["reach"]):
        return "the reference cannot solve the location"
    if not gd["moves"][1]:
        return "the group cannot move the platform (never searched)"
    if g.mag == 0.0:
        return "the group has zero clearance there"
    load = gd["load"]
    couple = g.group == "angular" or (g.group == "backlash" and g.joint.type == "R")
    scale = M.W * (M.Lchar if couple else 1.0)
    if g.scalar:
        if not (np.sign(load[0]) * np.sign(load[2]) < 0):
            return f"no sign change of the load across the location (loads {load[0]:.3e}, {load[2]:.3e})"
        if abs(abs(load[1]) - margin) > 1e-6 * max(scale, 1e-300) + 1e-6 * abs(load[1] - load[0]):
            return f"margin {margin:.6e} but |load| {abs(load[1]):.6e}"
        return None
    mags = gd["margin"]
    thr = M.disc_frac * M.W                      # couples: times 1 m (MODEL 8)
    slack = 1e-12 * max(scale, 1.0)
    if not (mags[1] <= mags[0] + slack and mags[1] <= mags[2] + slack):
        return (f"no local minimum of |load| within {SWITCH_DELTA:g} of the path "
                f"({mags[0]:.6e}, {mags[1]:.6e}, {mags[2]:.6e})")
    if not mags[1] < thr + slack:
        return f"|load| {mags[1]:.3e} not below the threshold {thr:.3e}"
    if abs(mags[1] - margin) > 1e-6 * max(scale, 1e-300):
        return f"margin {margin:.6e} but |load| {mags[1]:.6e}"
    return None


def _paths(M, smp):
    """Every path of the job: (line, sample indices along it, parameter values)."""
    n = smp["c"].shape[0]
    if M.trajectory:
        return [(("traj", None), np.arange(n), smp["t"])]
    axes = _grid_axes(M)
    order = list(M.inputs)
    shape = [axes[i].size for i in order]
    idx = np.arange(n).reshape(shape) if shape else np.arange(n)
    out = []
    for ax_pos, i in enumerate(order):
        if shape[ax_pos] < 2:
            continue
        moved = np.moveaxis(idx, ax_pos, -1).reshape(-1, shape[ax_pos])
        for row in moved:
            fixed = smp["c"][row[0]].copy()
            out.append((("grid", (i, fixed)), row, smp["c"][row, i]))
    return out


def check_switches(M, sw, label, info=None):
    """Failure strings for the engine's discontinuities (sw: column dict or None); info
    (a dict, optional) gets the counts: engine switches, sign changes checked."""
    fails = []
    info = {} if info is None else info
    info.update(engine=0, sign_changes=0)
    smp = rc.sample_inputs(M)
    n_eng = 0 if sw is None else len(sw.get("kind", []))
    if sw is None:
        return ["discontinuities.parquet missing"]
    for col in ("mode", "limb", "kind", "margin"):
        if col not in sw:
            return [f"discontinuities.parquet lacks column {col}"]
    # 1. every engine switch is confirmed by the reference's loads
    info["engine"] = n_eng
    groups = {g.name: g for g in M.groups}
    todo = {}                                   # mode -> [(row, group, margin, line, s, d)]
    for r in range(n_eng):
        mode, kind, limb = str(sw["mode"][r]), str(sw["kind"][r]), int(sw["limb"][r])
        name, grp = kind.rsplit("_", 1) if "_" in kind else (kind, "")
        g = groups.get(f"{name}{limb}_{grp}")
        if g is None or mode not in M.modes:
            fails.append(f"switch {r} ({mode} {kind} limb {limb}): no such clearance group or mode")
            continue
        margin = float(sw["margin"][r])
        if M.trajectory:
            tr = M.job["trajectory"]["time"]
            span = float(tr["stop"]) - float(tr["start"]) if isinstance(tr, dict) else 1.0
            lines = [(("traj", None), float(sw["t"][r]), span)]
        else:
            rowc = np.array([float(sw[c][r]) if c in sw else M.home[i] for i, c in enumerate(rc.COORDS)])
            axes = _grid_axes(M)
            lines = [(("grid", ln), rowc[ln[0]], float(np.ptp(axes[ln[0]])))
                     for ln in switch_lines(M, rowc)]
        if not lines:
            fails.append(f"switch {r} ({mode} {kind} limb {limb}): not on a grid line")
            continue
        for ln, s0, span in lines:
            todo.setdefault(mode, []).append((r, g, margin, ln, s0, SWITCH_DELTA * span))
    for mode, items in todo.items():
        pts = []
        for r, g, margin, ln, s0, d in items:
            pts += [(ln, s0 - d), (ln, s0), (ln, s0 + d)]
        ld = _loads_multi(M, mode, pts)
        verdict = {}
        for k, (r, g, margin, ln, s0, d) in enumerate(items):
            why = confirm_switch(M, g, margin, _pick(ld, g.name, np.arange(3 * k, 3 * k + 3)))
            if why is None:
                verdict[r] = None
            else:
                verdict.setdefault(r, why)
        for r, why in verdict.items():
            if why is not None:
                where = f"t={sw['t'][r]}" if M.trajectory else \
                    "(" + ", ".join(f"{c}={sw[c][r]:.6g}" for c in rc.COORDS if c in sw) + ")"
                fails.append(f"switch {r} ({mode} {sw['kind'][r]} limb {int(sw['limb'][r])} at "
                             f"{where}) not confirmed: {why}")
    # 2. every sign change of a scalar load between consecutive determinate samples is a switch
    scal = [g for g in M.groups if g.scalar and g.mag != 0.0]
    if not scal:
        return fails
    floor = M.indet_frac * M.W
    for mode in M.modes:
        ld = rc.group_loads(M, smp["c"], mode, smp["cd"] if mode == "dynamic" else None,
                            smp["cdd"] if mode == "dynamic" else None)
        solvable = ld["reach"] & ~ld["singular"]
        for line, rows, par in _paths(M, smp):
            for g in scal:
                gd = ld[g.name]
                det = solvable[rows] & (gd["margin"][rows] > floor) & gd["moves"][rows]
                seg_break = ~solvable[rows]
                prev = None
                for k in range(rows.size):
                    if seg_break[k]:
                        prev = None
                        continue
                    if not det[k]:
                        continue
                    if prev is not None and np.sign(gd["load"][rows[prev]]) != np.sign(gd["load"][rows[k]]):
                        lo, hi = par[prev], par[k]
                        info["sign_changes"] += 1
                        sign_lo = np.sign(gd["load"][rows[prev]])
                        if not _has_switch(M, sw, mode, g, line, lo, hi) \
                                and not _cut_between(M, mode, g, line, lo, hi, sign_lo):
                            fails.append(f"{mode} {g.kind} limb {g.limb.number}: the load changes sign "
                                         f"between {_line_label(line)} {lo:.6g} and {hi:.6g} "
                                         f"but the engine reports no switch there")
                    prev = k
    return fails


def _sign_roots(M, mode, items, steps=48):
    """Where the scalar loads' sign changes close, bisected all at once: items are
    (group, line, a, b, sign at a), the load's sign differing at a and b. Returns the
    points, the loads there (a _loads_multi result) and, per item, whether the bisection
    met a pose that cannot be solved (out of reach or beyond singular_cond): the path is
    cut there and no switch is located (docs/model.md section 8), as at a pole where the
    load passes through infinity rather than zero (the geometry's singularity between
    two samples)."""
    lo = np.array([x[2] for x in items], float)
    hi = np.array([x[3] for x in items], float)
    sa = np.array([x[4] for x in items], float)
    cut = np.zeros(len(items), bool)

    def at(s):
        lm = _loads_multi(M, mode, [(x[1], v) for x, v in zip(items, s)])
        val = np.array([lm[x[0].name]["load"][k] for k, x in enumerate(items)])
        return lm, val, ~(lm["reach"] & ~lm["singular"])

    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        _, val, unsolvable = at(mid)
        cut |= unsolvable
        same = np.sign(val) == sa
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    s = 0.5 * (lo + hi)
    lm, _, unsolvable = at(s)
    return s, lm, cut | unsolvable


def _cut_between(M, mode, g, line, lo, hi, sign_lo):
    """Whether the sign change of g's scalar load between lo and hi (its sign at lo
    sign_lo) is where the path cannot be solved (_sign_roots): not a switch the
    engine missed."""
    return bool(_sign_roots(M, mode, [(g, line, lo, hi, sign_lo)])[2][0])


def _line_label(line):
    return "t" if line[0] == "traj" else rc.COORDS[line[1][0]]


def _has_switch(M, sw, mode, g, line, lo, hi):
    n = len(sw["kind"])
    for r in range(n):
        if sw["mode"][r] != mode or sw["kind"][r] != g.kind or int(sw["limb"][r]) != g.limb.number:
            continue
        if line[0] == "traj":
            s = float(sw["t"][r])
        else:
            i, fixed = line[1]
            ok = True
            for j in M.inputs:
                if j == i:
                    continue
                c = rc.COORDS[j]
                if c in sw and abs(float(sw[c][r]) - fixed[j]) > 1e-9 * max(1.0, abs(fixed[j])):
                    ok = False
            if not ok:
                continue
            s = float(sw[rc.COORDS[i]][r])
        if min(lo, hi) <= s <= max(lo, hi):
            return True
    return False


# --------------------------------------------------------------------------
# a fake engine output written from the reference (to test this script)
# --------------------------------------------------------------------------
def reference_switches(M, ref=None):
    """Switches the reference finds by itself (scalar loads: sign changes refined by
    bisection; vector loads: sampled minima below the threshold refined by golden
    section; all candidates of a mode refined together), as a column dict like
    discontinuities.parquet (jumps written as 0)."""
    smp = rc.sample_inputs(M)
    rows = {k: [] for k in ("variant", "mode", "limb", "kind", "t", *rc.COORDS, "margin",
                            "jump_x", "jump_y", "jump_z", "jump_rx", "jump_ry", "jump_rz")}
    floor = M.indet_frac * M.W
    thr = M.disc_frac * M.W                      # couples: times 1 m (MODEL 8)

    def add(mode, g, line, s, margin):
        c, _, _ = _path_points(M, mode, line, [s])
        rows["variant"].append(0)
        rows["mode"].append(mode)
        rows["limb"].append(g.limb.number)
        rows["kind"].append(g.kind)
        rows["t"].append(s if line[0] == "traj" else np.nan)
        for i, cn in enumerate(rc.COORDS):
            rows[cn].append(float(c[0, i]))
        rows["margin"].append(float(margin))
        for j in ("x", "y", "z", "rx", "ry", "rz"):
            rows[f"jump_{j}"].append(0.0)

    for mode in M.modes:
        ld = rc.group_loads(M, smp["c"], mode, smp["cd"] if mode == "dynamic" else None,
                            smp["cdd"] if mode == "dynamic" else None)
        solv = ld["reach"] & ~ld["singular"]
        scal, vec = [], []                       # (group, line, a, b, sign at a)
        for line, idx, par in _paths(M, smp):
            for g in M.groups:
                if g.mag == 0.0:
                    continue
                gd = ld[g.name]
                det = solv[idx] & (gd["margin"][idx] > floor) & gd["moves"][idx]
                if g.scalar:
                    ks = np.flatnonzero(det)
                    for a, b in zip(ks, ks[1:]):
                        la, lb = gd["load"][idx[a]], gd["load"][idx[b]]
                        if np.sign(la) != np.sign(lb):
                            scal.append((g, line, par[a], par[b], np.sign(la)))
                else:
                    mg = gd["margin"][idx]
                    for k in range(1, idx.size - 1):
                        if det[k - 1] and det[k] and det[k + 1] and mg[k] < mg[k - 1] and mg[k] < mg[k + 1]:
                            vec.append((g, line, par[k - 1], par[k + 1], 0.0))
        if scal:
            s, lm, cut = _sign_roots(M, mode, scal)
            for k, x in enumerate(scal):
                if not cut[k]:
                    add(mode, x[0], x[1], s[k], abs(lm[x[0].name]["load"][k]))
        if vec:
            a = np.array([x[2] for x in vec])
            b = np.array([x[3] for x in vec])
            gr = (math.sqrt(5) - 1) / 2

            def f(ss):
                lm = _loads_multi(M, mode, [(x[1], v) for x, v in zip(vec, ss)])
                return np.array([lm[x[0].name]["margin"][k] for k, x in enumerate(vec)])
            x1, x2 = b - gr * (b - a), a + gr * (b - a)
            f1, f2 = f(x1), f(x2)
            for _ in range(60):
                left = f1 < f2
                na = np.where(left, a, x1)
                nb = np.where(left, x2, b)
                nx1 = np.where(left, nb - gr * (nb - na), x2)
                nx2 = np.where(left, x1, na + gr * (nb - na))
                fn = f(np.where(left, nx1, nx2))
                f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
                a, b, x1, x2 = na, nb, nx1, nx2
            s = 0.5 * (a + b)
            m = f(s)
            for k, x in enumerate(vec):
                if m[k] < thr:
                    add(mode, x[0], x[1], s[k], m[k])
    out = {}
    for k, v in rows.items():
        dt = object if k in ("mode", "kind") else (np.int64 if k in ("variant", "limb") else float)
        out[k] = np.array(v, dtype=dt)
    return out


def pa_table(cols):
    """A pyarrow table from a column dict (NaN / None as nulls, object arrays as strings)."""
    import pyarrow as pa
    arrays = {}
    for k, v in cols.items():
        v = np.asarray(v)
        if v.dtype == object:
            arrays[k] = pa.array(list(v), type=pa.string())
        elif np.issubdtype(v.dtype, np.floating):
            arrays[k] = pa.array(v, mask=np.isnan(v))
        else:
            arrays[k] = pa.array(v)
    return pa.table(arrays)


def write_fake_output(M, ref, out_dir, switches=None):
    """Write poses/variant=0/part-0.parquet and discontinuities.parquet from reference
    values (NaN / None as nulls)."""
    import pyarrow.parquet as pq
    table = pa_table
    pdir = os.path.join(out_dir, "poses", "variant=0")
    os.makedirs(pdir, exist_ok=True)
    extras = set(rc.extra_column_names(M))
    pq.write_table(table({k: v for k, v in ref.items() if k not in extras}),
                   os.path.join(pdir, "part-0.parquet"))
    sw = reference_switches(M, ref) if switches is None else switches
    pq.write_table(table(sw), os.path.join(out_dir, "discontinuities.parquet"))
    return sw


# --------------------------------------------------------------------------
# driver
# --------------------------------------------------------------------------
def print_table(stats):
    print(f"{'':2}{'column':<34}{'kinetostatic':>13}{'dynamic':>11}{'bad':>6}{'null':>6}{'cells':>9}  worst at")
    for c in sorted(stats.cols):
        w = stats.cols[c]
        k, d = w["kinetostatic"], w["dynamic"]
        flag = "!!" if w["bad"] or w["null"] else "  "
        fk = f"{k[0]:.2e}" if k[0] >= 0 else "-"
        fd = f"{d[0]:.2e}" if d[0] >= 0 else "-"
        where = k[1] if (k[0] / TOL["kinetostatic"]) >= (d[0] / TOL["dynamic"]) else d[1]
        print(f"{flag}{c:<34}{fk:>13}{fd:>11}{w['bad']:>6}{w['null']:>6}{w['n']:>9}  {where}")


def check_job(M, ref, out_dir, label, stats):
    """Compare one finished engine run with the reference: (fails, notes)."""
    notes = []
    eng = read_engine(out_dir)
    fails = compare(M, ref, eng, label, stats, notes)
    info = {}
    fails += check_switches(M, read_switches(out_dir), label, info)
    notes.append(f"switches: {info.get('engine', 0)} from the engine checked against the reference's "
                 f"loads, {info.get('sign_changes', 0)} sign changes of scalar loads looked up")
    return fails, notes


def run_engine(binary, path, out, timeout):
    cmd = [binary, "run", path, "--out", out, "--overwrite", "--quiet", "--columns", "full"]
    try:
        pr = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        return pr.returncode, pr.stderr.strip()
    except subprocess.TimeoutExpired:
        return -1, f"timed out after {timeout}s"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(REPO, "target", "release", "clearance"))
    ap.add_argument("--jobs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--job", default=None, help="cross-check this job file only")
    ap.add_argument("--families", default=",".join(FAMILIES),
                    help=f"comma-separated subset of {', '.join(FAMILY_FN)} (default: all but 6-RUS)")
    ap.add_argument("--keep", default=None, help="keep job files and outputs in this directory")
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--reference-only", action="store_true",
                    help="generate the jobs and run the reference only (no engine)")
    ap.add_argument("--refusals", action="store_true",
                    help="also check that the engine refuses (exit 2, with the counts / limb) an "
                         "overconstrained, a not-rigid and an idle-freedom description")
    ap.add_argument("--fake", action="store_true",
                    help="compare against an output written from the reference itself (self-test)")
    args = ap.parse_args(argv)
    fams = [f.strip() for f in args.families.split(",") if f.strip()]
    bad = [f for f in fams if f not in FAMILY_FN]
    if bad:
        ap.error(f"unknown families {bad}")
    binary = args.bin if os.path.isabs(args.bin) else os.path.join(os.getcwd(), args.bin)
    engine = not (args.reference_only or args.fake)
    if engine and not os.access(binary, os.X_OK):
        print(f"engine binary not found or not executable: {binary}", file=sys.stderr)
        return 2
    work = os.path.abspath(args.keep) if args.keep else tempfile.mkdtemp(prefix="clearance-xcustom-")
    os.makedirs(work, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    stats = Stats()
    passed = failed = 0
    lines = []
    try:
        n_jobs = 1 if args.job else args.jobs
        for i in range(n_jobs):
            t0 = time.time()
            if args.job:
                with open(args.job, "rb") as fh:
                    text = fh.read().decode()
                job = tomllib.loads(text)
                tag = os.path.basename(args.job)
                try:
                    M = rc.check_description(job)
                except ValueError as exc:
                    # both must refuse: the engine with exit 2
                    print(f"{args.job}: the reference refuses the job: {exc}")
                    if not engine:
                        return 0
                    out = os.path.join(work, "out_refused")
                    rc_, err = run_engine(binary, os.path.abspath(args.job), out, args.timeout)
                    print(f"engine exit {rc_}: {err.splitlines()[-1] if err else ''}")
                    print("1 passed, 0 failed" if rc_ == 2 else "0 passed, 1 failed")
                    return 0 if rc_ == 2 else 1
                ref = rc.compute(M, extras=True)
            else:
                job, tag, ref = make_job(rng, i, fams)
                text = to_toml(job)
                M = rc.normalize_job(job)
            t_ref = time.time() - t0
            path = os.path.join(work, f"job_{i:03d}.toml")
            with open(path, "w") as fh:
                fh.write(text)
            nst = {str(s): int((ref["status"] == s).sum()) for s in np.unique(ref["status"].astype(str))}
            label = f"job {i:03d}"
            info = f"{tag}, {ref['sample'].size} rows {nst}"
            if args.reference_only:
                lines.append(f"{label} REF-ONLY ({info}; reference {t_ref:.2f}s)")
                continue
            out = os.path.join(work, f"out_{i:03d}")
            if os.path.exists(out):
                shutil.rmtree(out)
            t0 = time.time()
            if args.fake:
                write_fake_output(M, ref, out)
                rc_, err = 0, ""
            else:
                rc_, err = run_engine(binary, path, out, args.timeout)
            t_eng = time.time() - t0
            if rc_ != 0:
                fails, notes = [f"engine exit {rc_}: {err.splitlines()[-1] if err else ''}"], []
            else:
                try:
                    fails, notes = check_job(M, ref, out, label, stats)
                except Exception as exc:  # report, do not crash the whole run
                    fails, notes = [f"reading/comparing failed: {type(exc).__name__}: {exc}"], []
            if fails:
                failed += 1
                lines.append(f"{label} FAIL ({info}; engine {t_eng:.2f}s)")
                lines += [f"    {f}" for f in fails[:25]]
                if len(fails) > 25:
                    lines.append(f"    ... {len(fails) - 25} more")
            else:
                passed += 1
                lines.append(f"{label} pass ({info}; engine {t_eng:.2f}s, reference {t_ref:.2f}s)")
            lines += [f"    note: {n}" for n in notes[:6]]
        if args.refusals and engine:
            for label, job, words in refusal_jobs(rng):
                path = os.path.join(work, f"refused_{label.replace(' ', '_')}.toml")
                with open(path, "w") as fh:
                    fh.write(to_toml(job))
                rc_, err = run_engine(binary, path, os.path.join(work, "out_refused"), args.timeout)
                missing = [w for w in words if w.lower() not in err.lower()]
                if rc_ == 2 and not missing:
                    passed += 1
                    lines.append(f"refusal {label} pass (exit 2: {err.splitlines()[-1] if err else ''})")
                else:
                    failed += 1
                    lines.append(f"refusal {label} FAIL (exit {rc_}, message lacks {missing}: "
                                 f"{err.splitlines()[-1] if err else ''})")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    if stats.cols:
        print_table(stats)
        print()
    print("\n".join(lines))
    if args.keep:
        print(f"jobs and outputs kept in {work}")
    if args.reference_only:
        print(f"{n_jobs} generated (reference only)")
        return 0
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
