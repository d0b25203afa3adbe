#!/usr/bin/env python3
"""Independent, vectorised NumPy reference of the 6-UPS (Gough-Stewart) pipeline.

Follows docs/model.md (the paper's method, sections 4-7, applied to the six-limb
kind of its section 10), docs/interface.md (job keys, `poses` columns) and
docs/conventions.md (sampling, statuses, nulls, condition numbers).  Written from
those documents, not from the Rust engine.  The conventions, the column naming and
the batching follow the 3-limb reference ``reference_model.py``, whose helpers
(Jet arithmetic, rotations, grid ranges, harmonics, the SO(3) maps of the exact
mode, condition numbers, Euler-angle errors) are imported, not copied.

The mechanism (``[mechanism] kind = "6-UPS"``), limbs i = 1..6:

* a universal joint U_i at the base point ``B_i``: a rotation about ``a1_i`` (fixed in
  the base, default horizontal and tangent to the base circle) and one about
  ``a2_i = (a1_i x e_i)/|a1_i x e_i|`` (fixed in the leg); ``n_i = a1_i x a2_i`` is the
  one rotation it forbids, so the couple the base exerts on the leg is ``mu_i n_i``;
* an actuated prismatic joint along the leg: cylinder (mass m_cyl, length l_c, centre
  ``B_i + l_c/2 e_i``) and piston (m_pis, l_p, centre ``A_i - l_p/2 e_i``), slender rods;
* a spherical joint S_i at ``A_i = p + R a'_i``, ``R = R_y(theta) R_x(psi) R_z(phi)``.

Inputs are the six pose coordinates ``x, y, z, phi, psi, theta`` (no parasitic
motions); a grid is row-major in that order.  ``q_i = |A_i - B_i|``.

Pipeline per sample and mode (kinetostatic, dynamic):

1. inverse kinematics (q_i, e_i), leg angular velocity
   ``omega_i = e_i x e_i' + sigma_i e_i`` with ``omega_i . n_i = 0`` and its derivative
   (exact Taylor jets, :class:`reference_model.Jet`);
2. reactions from the 42 x 42 equilibrium ``A w = b``: per limb ``f_U`` (3, base on leg
   at B_i), ``mu`` (1), ``f_S`` (3, leg on platform at A_i); rows: per leg the forces and
   the moments about B_i of cylinder + piston summed, then the platform's forces and
   moments about its composite centre of mass C;
3. take-up: ``u_radial`` the leg relative to the base by ``-u f_U/|f_U|``, ``s_radial``
   the platform relative to the leg by ``-s f_S/|f_S|``, ``u_angular`` a rotation
   ``+theta n_i`` of the leg about B_i (never indeterminate: mu_i is round-off);
4. the 30 x 30 error system ``J_P dq_P = J_Cl dq_Cl`` (per limb: rotations about a1_i and
   a2_i through B_i, the locked prismatic joint, three rotations through A_i; loops
   limb i - limb 1), per-kind and total errors, Euler-angle errors;
5. the exact error: the take-up as finite offsets on the nonlinear closure, Newton on
   18 unknowns (platform pose and both U angles of every leg).

Statuses (precedence as docs/conventions.md): ``unreachable`` (a leg outside
``[min_length, max_length]``), ``near_singular`` (``|a1_i x e_i| < 1e-6``, or cond_a /
cond_jp above ``analysis.singular_cond``), ``indeterminate_contact`` (u_radial or
s_radial with a non-zero clearance and a deciding load at most
``indeterminate_load_fraction * W``), ``ok``.

The standard column set also carries the worst-case envelope and the dominant joint
(docs/model.md section 11, by analogy: the admissible sets are the balls of s_radial and
u_radial and the segment of u_angular about n_i; joints are named s<i>_radial,
u<i>_radial, u<i>_angular).

Condition numbers (the rule of docs/conventions.md, for this kind): the equilibrium
with the legs eliminated leaves the six axial components of f_S, so ``cond_a`` is the
1-norm condition number of ``G`` with columns ``[e_i; r_i x e_i]`` (``r_i = A_i - P``);
each limb's passive freedoms have one reciprocal screw, the force along the leg, so
``cond_jp`` is that of ``M`` with rows ``[(r_i x e_i)^T, e_i^T]`` (``= G^T`` with its
halves swapped: kappa_1(M) = kappa_inf(G)).

Choices where docs/model.md leaves room (each a line to revisit if the engine differs):

* W = (m_platform + point masses + 6 (m_cyl + m_pis)) |g|, the conventions' weight of
  all moving bodies with six legs; it scales the indeterminate floor.
* Default U axes with ``base_points`` given and no ``u_axes``: tangent to the circle
  through B_i about z, ``(-sin t_i, cos t_i, 0)`` with ``t_i = atan2(B_iy, B_ix)``.
* The platform disc has radius ``platform_radius`` (default 0.3) even when
  ``platform_points`` place the joints elsewhere.
* sigma_i does not reach the reactions: with slender rods (no axial inertia)
  ``I w' + w x I w`` equals ``I (e x e'')`` for any spin sigma about the leg; it is
  computed, tested (omega . n = 0, the U angles' rates) and used all the same.
* Exact mode: the u_angular rotation comes first from the base (it also turns a1_i);
  the branch test of docs/conventions.md gets a round-off floor (see same_branch).
* Dominant joint: the rule of docs/model.md section 11 with the order s_radial,
  u_radial, u_angular, then limbs 1..6.

Usage::

    import tomllib, reference_ups as ru
    job = tomllib.load(open("job.toml", "rb"))          # [mechanism] kind = "6-UPS"
    cols = ru.compute(job)            # dict: column name -> np.ndarray (NaN / None = null)
    cols["err_x"], cols["f_u1_x"], cols["status"]

    python3 scripts/reference_ups.py --throughput 20000   # poses/s of the NumPy pipeline

Importing this module puts scripts/ on sys.path (for reference_model) and does
nothing else.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_model as rm  # noqa: E402
from reference_model import Jet, jsqrt  # noqa: E402

__all__ = [
    "KIND", "KINDS", "COMPONENTS", "INPUTS", "DEFAULTS", "normalize_job", "sample_inputs",
    "kinematics", "leg_rates", "motion", "equilibrium_matrix", "equilibrium_rhs",
    "unpack_reactions", "take_up", "passive_screws", "loop_matrix", "clearance_twists",
    "loop_system", "pose_error", "reduced_matrix", "exact_errors", "column_names",
    "compute", "pose_arrays", "pipeline", "throughput", "same_branch", "condition_numbers",
    "ENV_COMPONENTS", "JOINTS", "JOINT_NAMES", "joint_name", "env_column_names", "joint_maps",
    "joint_envelopes", "joint_contributions", "dominant_joint",
]

KIND = "6-UPS"
KINDS = ("s_radial", "u_radial", "u_angular")
COMPONENTS = rm.COMPONENTS                     # x, y, z, rx, ry, rz, phi, psi, theta
INPUTS = ("x", "y", "z", "phi", "psi", "theta")
NL = 6                                         # limbs
I3 = np.eye(3)
EPS = np.finfo(float).eps
# A leg along its fixed U axis: |a1 x e| below this is near_singular (docs/model.md 10.3).
AXIS_SINGULAR = 1e-6

DEFAULTS = {
    "mechanism": {"base_radius": 0.5, "base_angles_deg": [-15.0, 15.0, 105.0, 135.0, 225.0, 255.0],
                  "platform_radius": 0.3,
                  "platform_angles_deg": [-45.0, 45.0, 75.0, 165.0, 195.0, 285.0],
                  "cylinder_length": 0.5, "piston_length": 0.5, "gravity": [0.0, 0.0, -9.81]},
    "mass": {"platform": 10.0, "cylinder": 1.5, "piston": 0.75, "points": []},
    "load": {"force": [0.0, 0.0, 0.0], "moment": [0.0, 0.0, 0.0], "at": [0.0, 0.0, 0.0]},
    "clearance": {"s_radial": 0.0, "u_radial": 0.0, "u_angular": 0.0},
    "analysis": {"modes": ["kinetostatic"], "exact": False,
                 "discontinuity_load_fraction": 0.05, "singular_cond": 1e8,
                 "indeterminate_load_fraction": 1e-9},
}
KEYS = {
    "mechanism": {"kind", "base_radius", "base_angles_deg", "platform_radius",
                  "platform_angles_deg", "cylinder_length", "piston_length", "min_length",
                  "max_length", "gravity", "base_points", "platform_points", "u_axes"},
    "mass": {"platform", "cylinder", "piston", "platform_inertia", "points"},
    "clearance": set(KINDS),
}


# --------------------------------------------------------------------------
# Job handling and sampling
# --------------------------------------------------------------------------
def _six_points(pts, name):
    a = np.array(pts, float)
    if a.shape != (NL, 3):
        raise ValueError(f"mechanism.{name}: six [x, y, z] points expected, got shape {a.shape}")
    return a


def _circle(radius, deg, name):
    vals = [float(d) for d in deg]
    if len(vals) != NL:
        raise ValueError(f"mechanism.{name}: six angles expected, got {len(vals)}")
    ang = np.array([d * math.pi / 180.0 for d in vals])
    return radius * np.stack([np.cos(ang), np.sin(ang), np.zeros(NL)], -1)


def normalize_job(job: dict) -> dict:
    """Job dict (from tomllib) of kind 6-UPS -> parameter dict P (defaults filled in)."""
    kind = job.get("mechanism", {}).get("kind")
    if kind != KIND:
        raise ValueError(f"mechanism.kind: {KIND!r} expected, got {kind!r}")
    for sec, allowed in KEYS.items():
        bad = set(job.get(sec, {})) - allowed
        if bad:
            raise ValueError(f"{sec}: key(s) {sorted(bad)} not valid for kind {KIND}")
    j = rm._merge(DEFAULTS, job)
    if ("grid" in j) == ("trajectory" in j):
        raise ValueError("exactly one of [grid] or [trajectory] is required")
    for sec in ("grid", "trajectory"):
        bad = set(j.get(sec, {})) - set(INPUTS) - ({"time"} if sec == "trajectory" else set())
        if bad:
            raise ValueError(f"{sec}: key(s) {sorted(bad)} not valid for kind {KIND}")
    mech, mass, load = j["mechanism"], j["mass"], j["load"]
    Rb, rp = float(mech["base_radius"]), float(mech["platform_radius"])
    B = _six_points(mech["base_points"], "base_points") if "base_points" in mech else \
        _circle(Rb, mech["base_angles_deg"], "base_angles_deg")
    AP = _six_points(mech["platform_points"], "platform_points") if "platform_points" in mech \
        else _circle(rp, mech["platform_angles_deg"], "platform_angles_deg")
    if "u_axes" in mech:
        a1 = _six_points(mech["u_axes"], "u_axes")
    else:                                    # tangent to the base circle at B_i's polar angle
        th = np.arctan2(B[:, 1], B[:, 0])
        a1 = np.stack([-np.sin(th), np.cos(th), np.zeros(NL)], -1)
    n1 = np.linalg.norm(a1, axis=-1)
    if np.any(n1 == 0.0):
        raise ValueError("mechanism.u_axes: a zero axis")
    a1 = a1 / n1[:, None]                    # normalised first, user-given axes included
    lc, lp = float(mech["cylinder_length"]), float(mech["piston_length"])
    P = {
        "kind": KIND, "B": B, "AP": AP, "a1": a1, "lc": lc, "lp": lp,
        "qmin": float(mech.get("min_length", max(lc, lp))),
        "qmax": float(mech.get("max_length", lc + lp)),
        "g": np.array(mech["gravity"], float),
        "m_plat": float(mass["platform"]), "m_cyl": float(mass["cylinder"]),
        "m_pis": float(mass["piston"]),
        "f_ext": np.array(load["force"], float), "m_ext": np.array(load["moment"], float),
        "at_ext": np.array(load["at"], float),
        "clear": {k: float(j["clearance"].get(k, 0.0)) for k in KINDS},
        "modes": list(j["analysis"]["modes"]), "exact": bool(j["analysis"]["exact"]),
        "singular_cond": float(j["analysis"]["singular_cond"]),
        "indet_frac": float(j["analysis"]["indeterminate_load_fraction"]),
        "trajectory": "trajectory" in j,
    }
    for m in P["modes"]:
        if m not in ("kinetostatic", "dynamic"):
            raise ValueError(f"unknown mode {m!r}")
    if not P["trajectory"] and "dynamic" in P["modes"]:
        raise ValueError("dynamic mode is only valid on trajectories")
    P["m_limb"] = P["m_cyl"] + P["m_pis"]
    P["size"] = 0.5 * (P["qmin"] + P["qmax"])          # the legs' typical length
    # platform: thin disc of radius platform_radius unless platform_inertia is given
    mp = P["m_plat"]
    I_own = np.diag(np.array(mass["platform_inertia"], float)) if "platform_inertia" in mass \
        else np.diag([mp * rp ** 2 / 4.0, mp * rp ** 2 / 4.0, mp * rp ** 2 / 2.0])
    pm = np.array([float(pt["mass"]) for pt in mass["points"]], float)
    pa = np.array([pt["at"] for pt in mass["points"]], float).reshape(-1, 3)
    m_tot = mp + pm.sum()
    c_loc = (pm[:, None] * pa).sum(0) / m_tot
    I_P = I_own.copy()
    for mk, ak in zip(pm, pa):
        I_P += mk * (ak @ ak * I3 - np.outer(ak, ak))
    I_C = I_P - m_tot * (c_loc @ c_loc * I3 - np.outer(c_loc, c_loc))
    P.update(m_body=m_tot, c_loc=c_loc, I_C_loc=I_C,
             W=(m_tot + NL * P["m_limb"]) * float(np.linalg.norm(P["g"])))
    # level pose with mid-stroke legs: the substitute posture of unreachable rows
    dxy = AP[:, :2] - B[:, :2]
    h2 = P["size"] ** 2 - (dxy * dxy).sum(-1).mean()
    P["z_sub"] = math.sqrt(h2) - float((AP[:, 2] - B[:, 2]).mean()) if h2 > 0 else P["size"]
    P["job"] = j
    return P


def _P(job_or_P):
    return job_or_P if "job" in job_or_P else normalize_job(job_or_P)


def sample_inputs(P_or_job) -> dict:
    """Samples: t (NaN on grids) and the six inputs (N,); on trajectories also Jets
    ``<input>j`` with the exact time derivatives of the harmonics."""
    P = _P(P_or_job)
    j = P["job"]
    if "grid" in j:
        axes = [rm._grid_axis(j["grid"].get(k, 0.0)) for k in INPUTS]
        mesh = np.meshgrid(*axes, indexing="ij")               # row-major x, y, z, phi, psi, theta
        out = {k: m.ravel() for k, m in zip(INPUTS, mesh)}
        out["t"] = np.full(out["x"].size, np.nan)
        return out
    tr = j["trajectory"]
    t = rm._grid_axis(tr["time"])
    out = {"t": t}
    for key in INPUTS:
        v, d, dd = rm._harmonic(tr.get(key, 0.0), t)
        out[key] = v
        out[key + "j"] = Jet(v, d, dd)
    return out


# --------------------------------------------------------------------------
# Kinematics (docs/model.md 10.3)
# --------------------------------------------------------------------------
def _ex(a, axis=-1):
    return a.expand(axis) if isinstance(a, Jet) else np.expand_dims(a, axis)


def kinematics(P, x, y, z, phi, psi, theta):
    """Nominal pose of every body; inputs arrays (N,) or Jets (N,) -> dict of arrays
    or Jets: p (N,3), R (N,3,3), A, B, e (N,6,3), q (N,6), Gc, Gp (cylinder, piston
    centres), C, E (N,3); plus values reach, s = |a1 x e| (N,6), a2, n (N,6,3)."""
    Rm = rm._rotation(psi, theta, phi)                                   # (N,3,3)
    p = rm.jstack([x, y, z], -1)                                         # (N,3)
    N = np.shape(rm._val(x))[0]
    A = (Rm @ P["AP"].T).swapaxes(-1, -2) + _ex(p, -2)                   # (N,6,3)
    B = np.broadcast_to(P["B"], (N, NL, 3))
    D = A - B
    with np.errstate(invalid="ignore", divide="ignore"):
        q = jsqrt((D * D).sum(-1))
        e = D / _ex(q)
    qv, ev = rm._val(q), rm._val(e)
    with np.errstate(invalid="ignore"):
        reach = np.all((qv >= P["qmin"]) & (qv <= P["qmax"]), axis=-1)
    a1 = P["a1"]
    c = np.cross(a1, ev)                                                 # a1 x e
    s = np.linalg.norm(c, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        a2 = c / s[..., None]
    n = np.cross(a1, a2)
    C = p + Rm @ P["c_loc"]
    E = p + Rm @ P["at_ext"]
    return {"x": x, "y": y, "z": z, "phi": phi, "psi": psi, "theta": theta, "R": Rm, "p": p,
            "A": A, "B": B, "q": q, "e": e, "Gc": B + 0.5 * P["lc"] * e,
            "Gp": A - 0.5 * P["lp"] * e, "C": C, "E": E, "reach": reach, "s": s, "a2": a2,
            "n": n, "axis_singular": np.any(~(s >= AXIS_SINGULAR), axis=-1)}


def leg_rates(P, ej):
    """Leg angular velocity and acceleration from the leg-direction jet ej (N,6,3):
    omega = e x e' + sigma e with sigma fixed by omega . n = 0, n = a1 x a2,
    a2 = (a1 x e)/|a1 x e|; n . e = -|a1 x e|.  Returns (omega, domega, sigma)."""
    a1 = P["a1"]
    ca = (ej * a1).sum(-1)                                               # a1 . e (jet)
    s = jsqrt(1.0 - ca * ca)                                             # |a1 x e|
    n = (a1 * _ex(ca) - ej) / _ex(s)                                     # a1 x (a1 x e)/s
    ed, edd = ej.d, ej.dd
    c1 = Jet(np.cross(ej.v, ed), np.cross(ej.v, edd))                    # e x e', its rate
    # omega . n = 0:  (e x e') . n + sigma (e . n) = 0,  e . n = -s
    sigma = (c1 * n).sum(-1) / s
    omega = c1.v + sigma.v[..., None] * ej.v
    domega = np.cross(ej.v, edd) + sigma.d[..., None] * ej.v + sigma.v[..., None] * ed
    return omega, domega, sigma.v


def motion(kj, P):
    """Velocities and accelerations for Newton-Euler, from the Jets in kj."""
    Rj = kj["R"]
    Rt = Rj.v.swapaxes(-1, -2)
    w_leg, dw_leg, sigma = leg_rates(P, kj["e"])
    return {"omega": rm.vee(Rj.d @ Rt), "domega": rm.vee(Rj.dd @ Rt), "a_C": kj["C"].dd,
            "a_cyl": kj["Gc"].dd, "a_pis": kj["Gp"].dd, "w_leg": w_leg, "dw_leg": dw_leg,
            "sigma": sigma}


# --------------------------------------------------------------------------
# Equilibrium A w = b, 42 x 42 (docs/model.md sections 4 and 10.3)
# unknowns per limb i (offset 7i): f_U (3), mu (1), f_S (3)
# rows: leg i forces 6i..6i+2, moments about B_i 6i+3..6i+5 (cylinder + piston),
#       platform forces 36..38, platform moments about C 39..41
# --------------------------------------------------------------------------
def equilibrium_matrix(P, kin):
    A, B, C, n = kin["A"], kin["B"], kin["C"], kin["n"]
    N = A.shape[0]
    M = np.zeros((N, 42, 42))
    SAB = rm.skew(A - B)
    SAC = rm.skew(A - C[:, None, :])
    for i in range(NL):
        r, c = 6 * i, 7 * i
        M[:, r:r + 3, c:c + 3] = I3
        M[:, r:r + 3, c + 4:c + 7] = -I3
        M[:, r + 3:r + 6, c + 3] = n[:, i]
        M[:, r + 3:r + 6, c + 4:c + 7] = -SAB[:, i]
        M[:, 36:39, c + 4:c + 7] = I3
        M[:, 39:42, c + 4:c + 7] = SAC[:, i]
    return M


def leg_bodies(P, kin):
    """[(mass, centre (N,6,3), inertia about it (N,6,3,3), key of its acceleration)]."""
    e = kin["e"]
    return [(P["m_cyl"], kin["Gc"], rm._rod_inertia(P["m_cyl"], P["lc"], e), "a_cyl"),
            (P["m_pis"], kin["Gp"], rm._rod_inertia(P["m_pis"], P["lp"], e), "a_pis")]


def equilibrium_rhs(P, kin, mot=None):
    """b for kinetostatics (mot None) or dynamics (N,42)."""
    B, C, E, Rm = kin["B"], kin["C"], kin["E"], kin["R"]
    N = B.shape[0]
    g, m = P["g"], P["m_body"]
    bl = np.zeros((N, NL, 6))
    # leg i, cylinder + piston: f_U - f_S = sum m_b (a_b - g); about B_i:
    # mu n - (A - B) x f_S = sum [(G_b - B) x m_b (a_b - g) + I_b w' + w x I_b w]
    for mb, Gb, Ib, acc in leg_bodies(P, kin):
        fb = np.broadcast_to(-mb * g, (N, NL, 3))
        if mot is not None:
            fb = fb + mb * mot[acc]
            Iw = np.einsum("niab,nib->nia", Ib, mot["w_leg"])
            bl[..., 3:6] += np.einsum("niab,nib->nia", Ib, mot["dw_leg"]) + \
                np.cross(mot["w_leg"], Iw)
        bl[..., 0:3] += fb
        bl[..., 3:6] += np.cross(Gb - B, fb)
    b = np.zeros((N, 42))
    b[:, 0:36] = bl.reshape(N, 36)
    b[:, 36:39] = -m * g - P["f_ext"]
    b[:, 39:42] = -np.cross(E - C, P["f_ext"]) - P["m_ext"]
    if mot is not None:
        b[:, 36:39] += m * mot["a_C"]
        I_w = Rm @ P["I_C_loc"] @ Rm.swapaxes(-1, -2)
        w, dw = mot["omega"], mot["domega"]
        b[:, 39:42] += np.einsum("nab,nb->na", I_w, dw) + \
            np.cross(w, np.einsum("nab,nb->na", I_w, w))
    return b


def unpack_reactions(w):
    """w (N,42) -> f_U (N,6,3), mu (N,6), f_S (N,6,3)."""
    W = w.reshape(w.shape[0], NL, 7)
    return W[..., 0:3], W[..., 3], W[..., 4:7]


# --------------------------------------------------------------------------
# Take-up (docs/model.md sections 5 and 10.3)
# --------------------------------------------------------------------------
def take_up(P, fU, mu, fS, n):
    """Per kind: displacement (N,6,3) (u_radial: leg translation at B_i relative to the
    base; s_radial: platform translation at A_i relative to the leg; u_angular: the
    leg's rotation vector about B_i), margins (N,6) and indeterminate flags (N,)."""
    margins = {"s_radial": np.linalg.norm(fS, axis=-1),
               "u_radial": np.linalg.norm(fU, axis=-1),
               "u_angular": np.abs(mu)}
    floor = P["indet_frac"] * P["W"]
    disp, indet = {}, {}
    N = fU.shape[0]
    for k in KINDS:
        c = P["clear"][k]
        indet[k] = np.zeros(N, bool)
        if c == 0.0:
            disp[k] = np.zeros_like(fU)
            continue
        if k == "u_angular":
            # mu_i is round-off: no load decides it, and any sign gives the same (zero)
            disp[k] = c * np.broadcast_to(n, fU.shape).copy()
            continue
        f = fS if k == "s_radial" else fU
        mg = margins[k]
        bad = ~(mg > floor)
        with np.errstate(invalid="ignore", divide="ignore"):
            d = -c * f / np.where(bad, 1.0, mg)[..., None]
        disp[k] = np.where(bad[..., None], 0.0, d)
        indet[k] = np.any(bad, axis=-1)
    return disp, margins, indet


# --------------------------------------------------------------------------
# Error kinematics: J_P dq_P = J_Cl dq_Cl, 30 x 30 (docs/model.md sections 6, 10.3)
# passive unknowns per limb i (offset 5i): U about a1_i, U about a2_i (through B_i),
# S about world x, y, z (through A_i); the actuated prismatic joint is locked.
# Rows: twist of limb i - limb 1, i = 2..6.  Screws [w; v_P].
# --------------------------------------------------------------------------
def passive_screws(p, A, B, a1, a2):
    N = p.shape[0]
    S = np.zeros((N, NL, 6, 5))
    rB = B - p[:, None, :]
    rA = A - p[:, None, :]
    a1b = np.broadcast_to(a1, (N, NL, 3))
    S[..., 0:3, 0] = a1b
    S[..., 3:6, 0] = np.cross(rB, a1b)
    S[..., 0:3, 1] = a2
    S[..., 3:6, 1] = np.cross(rB, a2)
    for k in range(3):
        S[..., k, 2 + k] = 1.0
        S[..., 3:6, 2 + k] = np.cross(rA, I3[k])
    return S


def loop_matrix(S):
    N = S.shape[0]
    J = np.zeros((N, 30, 30))
    for l in range(NL - 1):
        J[:, 6 * l:6 * l + 6, 5 * (l + 1):5 * (l + 1) + 5] = S[:, l + 1]
        J[:, 6 * l:6 * l + 6, 0:5] = -S[:, 0]
    return J


def clearance_twists(kind, d, p, B):
    """Twist [w; v_P] (N,6,6) of each limb's clearance freedoms for one kind."""
    T = np.zeros(d.shape[:-1] + (6,))
    if kind == "u_angular":
        T[..., 0:3] = d
        T[..., 3:6] = np.cross(B - p[:, None, :], d)
    else:
        T[..., 3:6] = d
    return T


def loop_system(S, Tcl):
    """J_P and right-hand sides for clearance twists Tcl (N,6,6,K)."""
    rhs = np.concatenate([Tcl[:, 0] - Tcl[:, i] for i in range(1, NL)], axis=1)   # (N,30,K)
    return loop_matrix(S), rhs


def pose_error(S, Tcl, dqP):
    """Delta Gamma = [d_alpha; d_p] (N,6,K): limb 1's passive plus clearance twists."""
    return np.einsum("nak,nkc->nac", S[:, 0], dqP[:, 0:5]) + Tcl[:, 0]


def reduced_matrix(p, A, e):
    """G (N,6,6), columns [e_i; (A_i - P) x e_i]: the equilibrium with the legs
    eliminated (and, transposed with its halves swapped, the reciprocal-screw form of
    the error system)."""
    G = np.empty(p.shape[:1] + (6, 6))
    G[:, 0:3, :] = e.swapaxes(-1, -2)
    G[:, 3:6, :] = np.cross(A - p[:, None, :], e).swapaxes(-1, -2)
    return G


def condition_numbers(kin):
    """(cond_a, cond_jp): kappa_1 of G and of M = [(r x e)^T, e^T] (docs/conventions.md)."""
    G = reduced_matrix(kin["p"], kin["A"], kin["e"])
    M = np.concatenate([G[:, 3:6, :], G[:, 0:3, :]], axis=1).swapaxes(-1, -2)
    ca, cj = rm.kappa1(G), rm.kappa1(M)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(ca), ca, np.inf), np.where(np.isfinite(cj), cj, np.inf)


# --------------------------------------------------------------------------
# Worst-case envelope and dominant joint (docs/model.md section 11, for this kind)
#
# As in reference_model.py, derived from the assembled loop system: each joint's
# linear map is the pose error of unit take-ups of that joint alone (three world
# translations of limb i's clearance, three world rotation vectors of its leg about
# B_i), and the maximum over the joint's admissible set {U w : |w| <= c} is
# c |U^T g| for a component g and c sigma_max(H U) for |Delta p| or |Delta alpha|.
# The sets: s_radial the ball at A_i (U = I3), u_radial the ball at B_i (U = I3),
# u_angular the segment of rotations about n_i (U = n_i, which moves with the leg),
# whose envelope is zero like its error.
# --------------------------------------------------------------------------
ENV_COMPONENTS = rm.ENV_COMPONENTS                 # x, y, z, rx, ry, rz, p, alpha
_ENV_ROWS = (3, 4, 5, 0, 1, 2)                     # rows of [d_alpha; d_p]


def joint_name(kind, i):
    """`s<i>_radial`, `u<i>_radial`, `u<i>_angular` (i = 1..6)."""
    return f"{kind[0]}{i}_{kind.split('_', 1)[1]}"


JOINTS = tuple((k, i) for k in KINDS for i in range(1, NL + 1))      # the tie order
JOINT_NAMES = tuple(joint_name(k, i) for k, i in JOINTS)


def env_column_names():
    return [f"env_{c}" for c in ENV_COMPONENTS] + \
        [f"env_{k}_{c}" for k in KINDS for c in ENV_COMPONENTS] + ["dominant"]


def joint_maps(S, JP, p, B):
    """(Gt, Gr), each (N, 6 limbs, 6, 3): Delta Gamma = [d_alpha; d_p] per unit world
    translation of limb i's clearance (the U and S translations have the same twist)
    and per unit world rotation vector of leg i about B_i, all other joints rigid."""
    N = p.shape[0]
    Tcl = np.zeros((N, NL, 6, 6 * NL))
    rB = B - p[:, None, :]
    for i in range(NL):
        for k in range(3):
            Tcl[:, i, 3:6, 6 * i + k] = I3[k]
            Tcl[:, i, 0:3, 6 * i + 3 + k] = I3[k]
            Tcl[:, i, 3:6, 6 * i + 3 + k] = np.cross(rB[:, i], I3[k])
    _, rhs = loop_system(S, Tcl)
    G = pose_error(S, Tcl, rm._solve_stack(JP, rhs)).reshape(N, 6, NL, 2, 3)
    return G[:, :, :, 0, :].transpose(0, 2, 1, 3), G[:, :, :, 1, :].transpose(0, 2, 1, 3)


def joint_envelopes(P, Gt, Gr, n):
    """kind -> (N, 6 limbs, 8): per joint the maximum over its admissible set of
    |Delta Gamma_c| (x, y, z, rx, ry, rz) and of |Delta p|, |Delta alpha|."""
    out = {}
    N = Gt.shape[0]
    for kind in KINDS:
        c = P["clear"][kind]
        if c == 0.0:
            out[kind] = np.zeros((N, NL, 8))
            continue
        H = Gr @ n[..., None] if kind == "u_angular" else Gt                 # (N,6,6,m)
        comp = np.linalg.norm(H, axis=-1)
        with np.errstate(all="ignore"):
            out[kind] = c * np.concatenate([comp[..., list(_ENV_ROWS)],
                                            rm._spectral(H[..., 3:6, :])[..., None],
                                            rm._spectral(H[..., 0:3, :])[..., None]], -1)
    return out


def joint_contributions(Gt, Gr, disp):
    """(N, 18, 6): each joint's own Delta Gamma for the take-up `disp`, JOINTS order."""
    return np.stack([np.einsum("nrk,nk->nr", (Gr if kind == "u_angular" else Gt)[:, i],
                               disp[kind][:, i]) for kind in KINDS for i in range(NL)], 1)


def dominant_joint(P, contrib, rows):
    """Object array of joint names (None outside `rows` or with no candidate): the joint
    of non-zero clearance whose own contribution has the largest |Delta p|, the first in
    JOINTS order among those within reference_model.DOMINANT_TIE of it.  u_angular is
    never a candidate: it cannot move the platform (its contribution is round-off), so
    a job whose only clearance is u_angular has no dominant joint."""
    out = np.full(contrib.shape[0], None, dtype=object)
    cand = np.array([P["clear"][k] != 0.0 and k != "u_angular" for k, _ in JOINTS])
    if not cand.any():
        return out
    dp = np.where(cand, np.linalg.norm(contrib[..., 3:6], axis=-1), -np.inf)
    idx = rm.first_within_tie(dp)
    out[rows] = np.array(JOINT_NAMES, dtype=object)[idx[rows]]
    return out


# --------------------------------------------------------------------------
# Exact error (docs/model.md section 7)
# --------------------------------------------------------------------------
def exact_errors(P, kin, dB, dth, dA, max_iter=30):
    """Newton on the closure in perturbation form, all poses at once.

    Unknowns (18): dp = p' - p, w with R' = Exp(w) R, and per leg the U angles
    (phi1_i about a1_i, phi2_i about a2_i, a2_i carried by the first).  Leg i's tip,
    its actuator locked at the nominal q_i:

        A_i(leg) = B_i + dB_i + q_i Rot(dth_i) Rot(a1_i, phi1_i) Rot(a2_i, phi2_i) e_i

    (the clearance freedoms come first from the base, so Rot(dth_i) also turns the U
    axes), and the closure p' + R' a'_i = A_i(leg) + dA_i, with the nominal closure
    subtracted so that every term is of the size of the clearances:

        dp + (Exp(w) - I) R a'_i - dB_i - dA_i - q_i (Rot(dth) Rot1 Rot2 - I) e_i = 0.

    Returns (N,6) [w; dp] (NaN where Newton does not converge) and the converged mask."""
    Rm, e, q, a2 = kin["R"], kin["e"], kin["q"], kin["a2"]
    a1 = np.broadcast_to(P["a1"], e.shape)
    N = Rm.shape[0]
    ql = q[..., None]
    ra0 = np.einsum("nab,nib->nia", Rm, np.broadcast_to(P["AP"], (N, NL, 3)))
    off = dB + dA
    tilt = rm.exp_minus_identity(dth)                                  # Rot(dth) - I (N,6,3,3)
    rot_th = I3 + tilt
    dp, w, ph = np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, NL, 2))
    Ls = q.max(-1)

    def residual(dp, w, ph):
        Ew = rm.exp_minus_identity(w)
        M1 = rm.exp_minus_identity(ph[..., 0:1] * a1)                  # Rot(a1, phi1) - I
        M2 = rm.exp_minus_identity(ph[..., 1:2] * a2)
        U = M1 + M2 + M1 @ M2                                          # Rot1 Rot2 - I
        turn = tilt + U + tilt @ U
        F = dp[:, None, :] + np.einsum("nab,nib->nia", Ew, ra0) - off \
            - ql * np.einsum("niab,nib->nia", turn, e)
        return F, Ew, M1, M2

    rel_step = np.full(N, np.inf)
    for _ in range(max_iter):
        F, Ew, M1, M2 = residual(dp, w, ph)
        ra = ra0 + np.einsum("nab,nib->nia", Ew, ra0)                  # R' a'_i
        e2 = e + np.einsum("niab,nib->nia", M2, e)                     # Rot2 e
        e12 = e2 + np.einsum("niab,nib->nia", M1, e2)                  # Rot1 Rot2 e
        r1 = I3 + M1
        d1 = -ql * np.einsum("niab,nib->nia", rot_th, np.cross(a1, e12))
        d2 = -ql * np.einsum("niab,nib->nia", rot_th @ r1, np.cross(a2, e2))
        J = np.zeros((N, NL, 3, 18))
        J[..., 0:3] = I3
        J[..., 3:6] = -rm.skew(ra) @ rm.left_jacobian(w)[:, None]
        for i in range(NL):
            J[:, i, :, 6 + 2 * i] = d1[:, i]
            J[:, i, :, 7 + 2 * i] = d2[:, i]
        step = rm._solve_stack(J.reshape(N, 18, 18), -F.reshape(N, 18, 1))[..., 0]
        dp, w = dp + step[:, 0:3], w + step[:, 3:6]
        ph = ph + step[:, 6:18].reshape(N, NL, 2)
        sz = np.maximum(np.abs(dp).max(-1), Ls * np.maximum(np.abs(w).max(-1),
                                                             np.abs(ph).max((-1, -2))))
        smax = np.maximum(np.abs(step[:, 0:3]).max(-1), Ls * np.abs(step[:, 3:18]).max(-1))
        with np.errstate(invalid="ignore", divide="ignore"):
            rel_step = np.where(sz > 0, smax / np.where(sz > 0, sz, 1.0),
                                np.where(smax == 0, 0.0, np.inf))
        rel_step = np.where(np.isfinite(rel_step), rel_step, np.inf)
        if np.all((rel_step <= 4.0 * EPS) | ~np.isfinite(step).all(-1)):
            break
    out = np.concatenate([w, dp], axis=-1)
    conv = (rel_step <= 1e-10) & np.isfinite(out).all(-1)
    out[~conv] = np.nan
    return out, conv


def same_branch(P, exact, linear):
    """docs/conventions.md's branch test (an exact solution further from the linear error
    than the linear error's own size is another assembly branch), with a round-off floor:
    the u_angular error is zero, so a job with only that clearance has a linear error of
    round-off size (~1e-20) and an exact error of round-off size, which the bare test would
    call another branch at random.  The floor, 1e3 eps times the largest displacement the
    clearances can cause (s + u + theta * legs' length), is far below any real branch jump."""
    c = P["clear"]
    floor = 1e3 * EPS * (c["s_radial"] + c["u_radial"] + c["u_angular"] * P["qmax"])
    size = np.maximum(np.abs(linear).max(-1, keepdims=True), floor)
    with np.errstate(invalid="ignore"):
        return np.all(np.abs(exact - linear) <= size, axis=-1)


# --------------------------------------------------------------------------
# Full pipeline
# --------------------------------------------------------------------------
def column_names(job_or_P, columns="full") -> list:
    """The `poses` columns of a 6-UPS job, in order (docs/interface.md, model.md 10.3)."""
    P = _P(job_or_P)
    names = ["variant", "mode", "sample", "t"] + list(INPUTS) + ["status"]
    names += [f"err_{c}" for c in COMPONENTS]
    if columns in ("standard", "full"):
        names += [f"err_{k}_{c}" for k in KINDS for c in COMPONENTS]
        names += [f"q{i}" for i in range(1, NL + 1)]
        for i in range(1, NL + 1):
            names += [f"margin_u{i}_radial", f"margin_u{i}_angular", f"margin_s{i}"]
        names += env_column_names()
    if columns == "full":
        for i in range(1, NL + 1):
            names += [f"f_u{i}_{a}" for a in "xyz"] + [f"m_u{i}"] + [f"f_s{i}_{a}" for a in "xyz"]
        names += ["cond_a", "cond_jp"]
    if P["exact"]:
        names += [f"exact_err_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
    return names


_POSTURE = ("A", "B", "C", "E", "R", "e", "p", "q", "Gc", "Gp", "a2", "n", "s")


def _substitute(P, kin, good):
    """Finite posture for the rows that cannot be solved (outputs null there)."""
    N = good.size
    if np.all(good):
        return dict(kin)
    zero = np.zeros(N)
    ref = kinematics(P, zero, zero, np.full(N, P["z_sub"]), zero, zero, zero)
    out = dict(kin)
    for k in _POSTURE:
        m = good.reshape((N,) + (1,) * (kin[k].ndim - 1))
        out[k] = np.where(m, kin[k], ref[k])
    return out


def _solve_pose(P, kin_s, bs):
    """Reactions for the right-hand sides bs (N,42,M) and the error system's pieces."""
    wsol = rm._solve_stack(equilibrium_matrix(P, kin_s), bs)
    S = passive_screws(kin_s["p"], kin_s["A"], kin_s["B"], P["a1"], kin_s["a2"])
    return wsol, S, loop_matrix(S)


def _errors(P, kin_s, S, JP, disp):
    Tcl = np.stack([clearance_twists(k, disp[k], kin_s["p"], kin_s["B"]) for k in KINDS], -1)
    _, rhs = loop_system(S, Tcl)
    dqP = rm._solve_stack(JP, rhs)
    return pose_error(S, Tcl, dqP)                                     # (N,6,3)


def _compute_chunk(P, inp, sl, modes):
    vals = {k: inp[k][sl] for k in INPUTS}
    N = vals["x"].size
    mot = None
    if "dynamic" in modes:
        kj = kinematics(P, *[inp[k + "j"][sl] for k in INPUTS])
        kin = {k: (v.v if isinstance(v, Jet) else v) for k, v in kj.items()}
        with np.errstate(all="ignore"):          # legs along their U axis: flagged below
            mot = motion(kj, P)
    else:
        kin = kinematics(P, *[vals[k] for k in INPUTS])
    reach = kin["reach"]
    # G needs no U axis: a leg along its axis still has its own condition numbers
    cond_a, cond_jp = condition_numbers(_substitute(P, kin, reach))
    kin_s = _substitute(P, kin, reach & ~kin["axis_singular"])
    singular = ~((cond_a <= P["singular_cond"]) & (cond_jp <= P["singular_cond"])) | \
        kin["axis_singular"]
    bs = np.stack([equilibrium_rhs(P, kin_s, mot if m == "dynamic" else None) for m in modes], -1)
    with np.errstate(all="ignore"):
        wsol, S, JP = _solve_pose(P, kin_s, bs)
    out = {}
    for mi, mode in enumerate(modes):
        fU, mu, fS = unpack_reactions(wsol[..., mi])
        disp, margins, indet = take_up(P, fU, mu, fS, kin_s["n"])
        with np.errstate(all="ignore"):
            G = _errors(P, kin_s, S, JP, disp)
        eul = rm.euler_errors(vals["psi"], vals["theta"], G[:, 0:3])
        per = np.concatenate([G[:, 3:6], G[:, 0:3], eul], axis=1)      # (N,9,3), COMPONENTS
        if mi == 0:                  # geometry only: the same maps for every mode
            with np.errstate(all="ignore"):
                Gt, Gr = joint_maps(S, JP, kin_s["p"], kin_s["B"])
                jenv = joint_envelopes(P, Gt, Gr, kin_s["n"])
        any_indet = np.zeros(N, bool)
        for k in KINDS:
            any_indet |= indet[k]
        status = np.where(~reach, "unreachable",
                          np.where(singular, "near_singular",
                                   np.where(any_indet, "indeterminate_contact", "ok")))
        ok = status == "ok"
        full_rows = ok | (status == "indeterminate_contact")
        qrow = reach & (singular | full_rows)
        cols = {"mode": np.full(N, mode, dtype=object),
                "sample": np.arange(sl.start, sl.start + N, dtype=np.uint64),
                "t": inp["t"][sl], "status": status.astype(object)}
        cols.update(vals)
        for i in range(NL):
            cols[f"q{i + 1}"] = np.where(qrow, kin["q"][:, i], np.nan)
        cols["cond_a"] = np.where(qrow, cond_a, np.nan)
        cols["cond_jp"] = np.where(qrow, cond_jp, np.nan)
        tot = per.sum(-1)
        for ci, c in enumerate(COMPONENTS):
            cols[f"err_{c}"] = np.where(ok, tot[:, ci], np.nan)
            for ki, k in enumerate(KINDS):
                cols[f"err_{k}_{c}"] = np.where(full_rows & ~indet[k], per[:, ci, ki], np.nan)
        for ki, k in enumerate(KINDS):
            ek = jenv[k].sum(1)
            for ci, c in enumerate(ENV_COMPONENTS):
                cols[f"env_{k}_{c}"] = np.where(full_rows, ek[:, ci], np.nan)
        for c in ENV_COMPONENTS:
            cols[f"env_{c}"] = sum(cols[f"env_{k}_{c}"] for k in KINDS)
        cols["dominant"] = dominant_joint(P, joint_contributions(Gt, Gr, disp), ok)
        for i in range(NL):
            for a_i, a in enumerate("xyz"):
                cols[f"f_u{i + 1}_{a}"] = np.where(full_rows, fU[:, i, a_i], np.nan)
                cols[f"f_s{i + 1}_{a}"] = np.where(full_rows, fS[:, i, a_i], np.nan)
            cols[f"m_u{i + 1}"] = np.where(full_rows, mu[:, i], np.nan)
            cols[f"margin_u{i + 1}_radial"] = np.where(full_rows, margins["u_radial"][:, i], np.nan)
            cols[f"margin_u{i + 1}_angular"] = np.where(full_rows, margins["u_angular"][:, i], np.nan)
            cols[f"margin_s{i + 1}"] = np.where(full_rows, margins["s_radial"][:, i], np.nan)
        if P["exact"]:
            ex = np.full((N, 6), np.nan)
            if np.any(ok):
                ex_ok, _ = exact_errors(P, {k: kin_s[k][ok] for k in _POSTURE},
                                        disp["u_radial"][ok], disp["u_angular"][ok],
                                        disp["s_radial"][ok])
                ex[ok] = ex_ok
                lin = tot[:, [3, 4, 5, 0, 1, 2]]                       # [d_alpha; d_p]
                ex[~same_branch(P, ex, lin)] = np.nan
            for ci, c in enumerate(("rx", "ry", "rz", "x", "y", "z")):
                cols[f"exact_err_{c}"] = ex[:, ci]
        out[mode] = cols
    return out


def compute(job: dict, columns: str = "full", chunk: int = 2048) -> dict:
    """All `poses` rows of variant 0 of a 6-UPS job: dict column -> array (modes
    concatenated in the job's order; NaN / None where the engine writes null)."""
    P = _P(job)
    inp = sample_inputs(P)
    n = inp["x"].size
    modes = P["modes"]
    parts = {m: [] for m in modes}
    for s0 in range(0, n, chunk):
        res = _compute_chunk(P, inp, slice(s0, min(n, s0 + chunk)), modes)
        for m in modes:
            parts[m].append(res[m])
    names = column_names(P, columns)
    out = {name: np.concatenate([c[name] for m in modes for c in parts[m]])
           for name in names if name != "variant"}
    out["variant"] = np.zeros(out["sample"].size, dtype=np.int64)
    return {k: out[k] for k in names}


def pose_arrays(job, x, y, z, phi, psi, theta, mode="kinetostatic", jets=None):
    """Every column for explicit input arrays (tests); dynamic mode needs `jets`, a
    dict input -> Jet with the inputs' time derivatives."""
    P = _P(job)
    vals = dict(zip(INPUTS, (np.atleast_1d(np.asarray(a, float)) for a in
                             np.broadcast_arrays(x, y, z, phi, psi, theta))))
    inp = dict(vals, t=np.full(vals["x"].size, np.nan))
    if mode == "dynamic":
        inp.update({k + "j": jets[k] for k in INPUTS})
    return _compute_chunk(P, inp, slice(0, vals["x"].size), [mode])[mode]


# --------------------------------------------------------------------------
# Throughput: the kinetostatic pipeline, all kinds, batched, no I/O
# --------------------------------------------------------------------------
def pipeline(P, x, y, z, phi, psi, theta):
    """Batched kinetostatic kernel: pose -> reactions -> take-up -> per-kind and total
    errors (+ Euler errors), condition numbers and status, for arrays (N,).
    Returns (per (N,9,3), status (N,) as small ints 0 ok, 1 indeterminate, 2 near
    singular, 3 unreachable)."""
    kin = kinematics(P, x, y, z, phi, psi, theta)
    reach = kin["reach"]
    cond_a, cond_jp = condition_numbers(_substitute(P, kin, reach))
    kin_s = _substitute(P, kin, reach & ~kin["axis_singular"])
    singular = ~((cond_a <= P["singular_cond"]) & (cond_jp <= P["singular_cond"])) | \
        kin["axis_singular"]
    with np.errstate(all="ignore"):
        wsol, S, JP = _solve_pose(P, kin_s, equilibrium_rhs(P, kin_s)[..., None])
        fU, mu, fS = unpack_reactions(wsol[..., 0])
        disp, _, indet = take_up(P, fU, mu, fS, kin_s["n"])
        G = _errors(P, kin_s, S, JP, disp)
    eul = rm.euler_errors(psi, theta, G[:, 0:3])
    per = np.concatenate([G[:, 3:6], G[:, 0:3], eul], axis=1)
    any_indet = indet["s_radial"] | indet["u_radial"] | indet["u_angular"]
    status = np.where(~reach, 3, np.where(singular, 2, np.where(any_indet, 1, 0)))
    return per, status


THROUGHPUT_JOB = {
    "name": "ups_throughput",
    "mechanism": {"kind": "6-UPS"},
    "clearance": {"s_radial": 1e-4, "u_radial": 1e-4, "u_angular": 1e-4},
    "grid": {"x": {"start": -0.05, "stop": 0.05, "n": 5}, "y": {"start": -0.05, "stop": 0.05, "n": 5},
             "z": {"start": 0.6, "stop": 0.8, "n": 5}, "phi": {"start": -0.1, "stop": 0.1, "n": 5},
             "psi": {"start": -0.1, "stop": 0.1, "n": 5}, "theta": {"start": -0.1, "stop": 0.1, "n": 5}},
}


def throughput(n_poses=20000, chunk=2048, job=None):
    """Poses/s of :func:`pipeline` on the first n_poses samples of a 6-UPS grid job
    (default THROUGHPUT_JOB: the default geometry, all three clearances 1e-4),
    cycling the grid if it is shorter.  Returns (poses_per_s, status counts)."""
    P = normalize_job(job or THROUGHPUT_JOB)
    inp = sample_inputs(P)
    idx = np.arange(n_poses) % inp["x"].size
    arr = {k: inp[k][idx] for k in INPUTS}
    counts = np.zeros(4, int)
    t0 = time.perf_counter()
    for s0 in range(0, n_poses, chunk):
        sl = slice(s0, min(n_poses, s0 + chunk))
        _, st = pipeline(P, *[arr[k][sl] for k in INPUTS])
        counts += np.bincount(st, minlength=4)
    dt = time.perf_counter() - t0
    return n_poses / dt, dict(zip(("ok", "indeterminate_contact", "near_singular", "unreachable"),
                                  counts.tolist()))


def main(argv=None):
    import argparse
    ap = argparse.ArgumentParser(description="6-UPS NumPy reference")
    ap.add_argument("--throughput", type=int, metavar="N", default=None,
                    help="time the batched kinetostatic pipeline on N poses")
    ap.add_argument("--chunk", type=int, default=2048)
    ap.add_argument("job", nargs="?", help="a 6-UPS job file: print a summary of its columns")
    args = ap.parse_args(argv)
    if args.throughput:
        rate, counts = throughput(args.throughput, args.chunk)
        print(f"numpy 6-UPS kinetostatic pipeline: {args.throughput} poses, {rate:.0f} poses/s "
              f"(chunk {args.chunk}, one process); statuses {counts}")
        return 0
    if args.job:
        import tomllib
        with open(args.job, "rb") as fh:
            cols = compute(tomllib.load(fh))
        st, cnt = np.unique(cols["status"].astype(str), return_counts=True)
        print(f"{cols['sample'].size} rows; statuses " + ", ".join(f"{a}={b}" for a, b in zip(st, cnt)))
        for c in ("err_x", "err_y", "err_z", "err_rx", "err_ry", "err_rz"):
            v = cols[c][np.isfinite(cols[c])]
            if v.size:
                print(f"  {c:8s} min {v.min(): .3e}  max {v.max(): .3e}")
        return 0
    ap.print_help()
    return 2


if __name__ == "__main__":
    sys.exit(main())
