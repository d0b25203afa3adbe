#!/usr/bin/env python3
"""Independent NumPy reference of ``[mechanism] kind = "custom"`` (docs/model.md section 12).

Written from docs/model.md sections 1-8 and 12, docs/interface.md (the custom job keys) and
docs/conventions.md (sampling, statuses, nulls), not from the Rust engine.  It is
deliberately the *slow, assembled* formulation: every system is the full dense one,

* kinematics: Newton on the 6 closure equations of every limb at once (product of
  exponentials of the joints' home screws, an S joint as a general rotation matrix),
  unknowns the parasitic coordinates and every joint variable, continued from home
  along the straight segment of the inputs with adaptive steps;
* rates: implicit differentiation of the same closure in twist form (velocities
  ``sum xi_k qdot_k = J_D cdot``; accelerations with the exact bias terms
  ``ad(V) xi`` of the moving screws): exact, no finite differences;
* reactions: the dense Newton-Euler system of every moving body (limb bodies and
  the composite platform), unknowns every joint's transmitted components
  (section 12.4's table), solved as one ``(6 b) x (6 b)`` system per pose;
* error: the assembled system of section 12.6 (unknowns Delta Gamma and every passive
  delta q of every limb, 6 equations per limb);
* exact error: Newton on the nonlinear closure of section 12.7 (take-ups as finite
  rigid motions fixed in the world, composed as ``G = C_n ... C_1 M_1 ... M_n``), in
  perturbation form so that no O(1) numbers are differenced;
* envelope and dominant joint from the unit responses of the assembled error system.

Everything is batched over poses (leading axis N) with ``np.linalg.solve`` stacks.

Usage::

    import tomllib, reference_custom as rc
    job = tomllib.load(open("job.toml", "rb"))      # [mechanism] kind = "custom"
    rc.check_description(job)                       # ValueError: refused (exit 2 in the engine)
    cols = rc.compute(job)                          # dict column -> np.ndarray (NaN / None = null)
    mech = rc.normalize_job(job)                    # the parsed mechanism (Mech)
    res = rc.evaluate(mech, inputs, mode, rates)    # everything at explicit poses (tests)

    rc.preset_description(builtin_job)              # 3-PRS / 3-RPS / 6-UPS job -> custom job

Choices where docs/model.md section 12 leaves room are listed in CHOICES (and in the
report of the branch that added this file); each is a line to revisit if the engine
differs.
"""

from __future__ import annotations

import copy
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_model as rm  # noqa: E402

__all__ = [
    "COORDS", "COMPONENTS", "ENV_COMPONENTS", "CHOICES", "Joint", "Limb", "Group", "Mech",
    "normalize_job", "check_description", "sample_inputs", "solve_kinematics", "chain",
    "platform_jacobian", "kinematic_jacobian", "rates", "equilibrium", "error_matrix",
    "passive_twists", "unit_responses", "take_up", "exact_errors", "evaluate", "compute",
    "column_names", "extra_column_names", "preset_description", "group_loads",
]

COORDS = ("x", "y", "z", "phi", "psi", "theta")
COMPONENTS = rm.COMPONENTS                       # x, y, z, rx, ry, rz, phi, psi, theta
ENV_COMPONENTS = rm.ENV_COMPONENTS               # x, y, z, rx, ry, rz, p, alpha
I3 = np.eye(3)
EPS = np.finfo(float).eps
TYPE_RANK = {"S": 0, "U": 1, "R": 2, "P": 3}
GROUP_RANK = {"radial": 0, "axial": 1, "angular": 2, "backlash": 3}
GROUPS = {"R": ("radial", "axial", "angular"), "P": ("radial", "angular"),
          "U": ("radial", "angular"), "S": ("radial",)}
# a group that cannot move the platform: unit response |dp| below this (12.5)
IMMOBILE = 1e-9
DOMINANT_TIE = 1e-9
# U axes must be perpendicular at home to this (|a1 . a2| after normalising)
U_PERP_TOL = 1e-6
# continuation / Newton
KIN_TOL = 1e-10            # corrector tolerance along the path (m, rad)
KIN_FINAL = 1e-13          # polish at the pose
KIN_ACCEPT = 1e-11         # converged at the pose when the last step is at most this
STEP_CAP = 0.1             # largest predicted change of any unknown in one step
H_MIN = 1e-7

CHOICES = """
1. Joint variables are zero at home (R: angle about a; P: displacement along d; U: the
   angle about a1, then the one about the moved a2; S: a rotation matrix).  `range`
   bounds the variable at the pose only, not along the path.  A violated range gives
   `unreachable` with the parasitic coordinates still reported (the continuation
   converged); a failed continuation nulls them too.
2. Continuation: from home along the straight segment of the inputs, adaptive steps
   (predicted change of any unknown <= 0.1 m or rad, corrector Newton to 1e-10,
   step divided by 4 on a failed corrector, 1e-7 the smallest fraction of the segment),
   then Newton at the pose to 1e-13; converged when its last step is <= 1e-11.
3. Every joint's centre moves with its distal body (a P's centre slides with its distal
   part); R, P axes with either body; U: a1 with the proximal, a2 with the distal body,
   n = a1 x a2 at the current pose.  Axes are normalised; a U is refused when
   |a1 . a2| > 1e-6 at home (no orthogonalisation).
4. Reactions: f, m exerted by the proximal body on the distal one, m about the joint's
   current centre, world axes; f_ and m_ columns for every joint of every limb (an S's m
   is exactly 0).  tau = m . a (R actuated), f . d (P actuated), current axes.
5. Bodies: `bodies` may be omitted (all massless); when given it has n - 1 entries.  An
   inertia given without `com` is about the default com.
6. Platform mass defaults to 0.  The default disc radius is the mean over every limb
   (repeats included) of the distance of the last joint's centre from P, measured in the
   platform's plane (the u-v plane of the platform axes at home).
7. near_singular (the engine defines its own measure; jobs of the cross-check stay far
   from it): the 2-norm condition number of G = [W_1 ... W_L] (W_i an orthonormal basis
   of the wrenches [f; m_P] reciprocal to limb i's passive twists at P, moments in N m)
   above singular_cond, or a limb's passive twists (unit columns [w; v_P]) with a
   condition number above singular_cond.  cond_a / cond_jp are not produced.
8. Clearance keys `<name>_<group>` are split at the last underscore; a key applies to every
   limb having a joint of that name whose type (and actuation, for backlash) has the
   group; a list gives one value per such limb, in limb order.  A zero magnitude makes that
   limb's group rigid: never indeterminate, no switch, not a dominant candidate.
9. Indeterminate: margin <= indeterminate_load_fraction * W (N and N m alike), only for a
   non-zero magnitude and a group that can move the platform.  "Can move": the largest
   |dp| over the group's unit admissible set (sigma_max of the dp rows of its unit
   responses on the set's basis; angular groups per rad, i.e. times 1 m) is >= 1e-9, per
   limb, at the pose.  U angular: rotation -theta sign(mu) n with mu = m . n (0 if mu is 0).
10. Envelope: per group the maximum over its admissible set (disc / ball / segment of
   radius the magnitude) of each |component|, of |dp| and of |dalpha|, summed over the
   kind's groups (env_<kind>_*) and over all groups (env_*); ok and indeterminate rows.
11. Dominant: ok rows only; candidates every (limb, joint, group) with a non-zero magnitude
   that can move the platform; ties within 1e-9 relative go to the first by (type S, U,
   R, P; place in the limb; radial, axial, angular, backlash; limb).  None: no candidate.
12. Exact error: ok rows only; null when Newton does not converge (relative step 1e-10)
   or when it converges further from the linear error than the linear error's size in
   any component, that size at least 1e3 eps (sum of translational magnitudes + angular
   magnitudes times Lchar, the largest joint distance from P at home, at least 1 m).
13. Grids: keys must be inputs; an input with no key stays at its home value; samples are
   row-major over the inputs in the order x, y, z, phi, psi, theta.  Trajectories: an
   input with no key stays at its home value.
14. W = (platform + point masses + every limb body's mass) |g|.
15. Refused besides MODEL 12.3's counts, idle freedoms and rank deficiency at home: inputs
   that do not determine the pose at home (the closure's Jacobian singular there).
16. Nulls as the built-ins: unreachable rows carry identity, inputs (and parasitic, see 1);
   near_singular rows also q<k>; indeterminate rows everything but the totals err_*, the
   exact errors, the indeterminate kinds' err_<kind>_* and dominant; tau<k>, f_, m_,
   margins and env_* are on ok and indeterminate rows.
"""


# --------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------
def _mv(M, v):
    """Batched matrix (N,3,3) times vector (3,) or (N,3)."""
    if v.ndim == 1:
        return np.einsum("nab,b->na", M, v)
    return np.einsum("nab,nb->na", M, v)


def _cx(a, b, axis=-1):
    """Cross product along `axis` (np.cross without its per-call overhead)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if axis != -1:
        return np.moveaxis(_cx(np.moveaxis(a, axis, -1), np.moveaxis(b, axis, -1)), -1, axis)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), -1)


def _unit(v, what="axis"):
    v = np.asarray(v, float).reshape(3)
    n = float(np.linalg.norm(v))
    if not n > 0.0 or not math.isfinite(n):
        raise ValueError(f"{what}: a zero axis")
    return v / n


def _perp_basis(a):
    """Two unit vectors (N,3) spanning the plane perpendicular to the unit vectors a (N,3)."""
    h = np.where((np.abs(a[:, 0]) < 0.9)[:, None], np.array([1.0, 0.0, 0.0]),
                 np.array([0.0, 1.0, 0.0]))
    u1 = _cx(a, h)
    u1 /= np.linalg.norm(u1, axis=-1, keepdims=True)
    u2 = _cx(a, u1)
    return u1, u2


def _rotz_deg(deg):
    t = math.radians(deg)
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ad(V, xi):
    """Lie bracket ad_V xi of twists [w; v] (N,6) (spatial, about one point)."""
    w, v = V[:, 0:3], V[:, 3:6]
    a, b = xi[:, 0:3], xi[:, 3:6]
    return np.concatenate([_cx(w, a), _cx(w, b) + _cx(v, a)], -1)


def _solve(M, rhs):
    return rm._solve_stack(M, rhs)


def _log_small(E):
    """Rotation vector of I + E for E = R - I (N,3,3), no cancellation for tiny angles."""
    s_vec = rm.vee(E)
    s = np.linalg.norm(s_vec, axis=-1)
    c = 1.0 + 0.5 * np.trace(E, axis1=-2, axis2=-1)
    th = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s > 1e-300, th / np.where(s > 1e-300, s, 1.0), 1.0)
    return f[..., None] * s_vec


# --------------------------------------------------------------------------
# the description
# --------------------------------------------------------------------------
class Joint:
    """One joint of one limb, at home, in world coordinates."""

    def __init__(self, type_, name, c, axis=None, a1=None, a2=None, actuated=False, rng=None):
        self.type, self.name, self.c = type_, name, np.asarray(c, float)
        self.a, self.a1, self.a2, self.n = axis, a1, a2, None
        if type_ == "U":
            self.n = _unit(_cx(a1, a2))
        self.actuated, self.range = bool(actuated), rng
        self.limb = self.place = None
        self.qi = self.si = None            # columns in the state (scalar vars / S rotations)
        self.col = None                     # first column among the kinematic unknowns
        self.pcol = None                    # first column among a limb's passive unknowns
        self.act = None                     # actuator number k (1-based) if actuated

    @property
    def nfree(self):                        # kinematic freedoms (actuated included)
        return {"R": 1, "P": 1, "U": 2, "S": 3}[self.type]

    @property
    def npassive(self):
        return 0 if self.actuated else self.nfree

    @property
    def k(self):                            # transmitted components (12.4)
        return 6 - self.npassive

    def groups(self):
        g = GROUPS[self.type]
        return g + ("backlash",) if self.actuated else g

    def copy_rotated(self, Rz):
        def rot(v):
            return None if v is None else Rz @ v
        j = Joint.__new__(Joint)
        j.__dict__.update(self.__dict__)
        j.c, j.a, j.a1, j.a2, j.n = rot(self.c), rot(self.a), rot(self.a1), rot(self.a2), rot(self.n)
        return j


class Limb:
    def __init__(self, number, joints, bodies):
        self.number, self.joints, self.bodies = number, joints, bodies


class Group:
    """One clearance group of one joint of one limb."""

    def __init__(self, kind, joint, group, limb, mag):
        self.kind, self.joint, self.group, self.limb, self.mag = kind, joint, group, limb, float(mag)
        t = joint.type
        self.rot = group == "angular" or (group == "backlash" and t == "R")
        self.scalar = group == "axial" or group == "backlash" or (t == "U" and group == "angular")
        if group == "axial" or group == "backlash" or (t == "U" and group == "angular"):
            self.set = "segment"
        elif (t in ("R",) and group in ("radial", "angular")) or (t == "P" and group == "radial"):
            self.set = "disc"
        else:
            self.set = "ball"
        self.name = f"{joint.name}{limb.number}_{group}"
        self.order = (TYPE_RANK[t], joint.place, GROUP_RANK[group], limb.number)


class Mech:
    """The parsed custom mechanism; see normalize_job."""


def _vec3(v, what):
    a = np.asarray(v, float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: three finite numbers expected")
    return a


def _parse_joint(spec, where):
    allowed = {"type", "name", "at", "axis", "axes", "actuated", "range"}
    bad = set(spec) - allowed
    if bad:
        raise ValueError(f"{where}: unknown key(s) {sorted(bad)}")
    t = spec.get("type")
    if t not in TYPE_RANK:
        raise ValueError(f"{where}.type: one of R, P, U, S expected, got {t!r}")
    name = str(spec.get("name", t.lower()))
    c = _vec3(spec.get("at"), f"{where}.at")
    act = bool(spec.get("actuated", False))
    if act and t not in ("R", "P"):
        raise ValueError(f"{where}.actuated: only R and P joints can be actuated")
    rng = spec.get("range")
    if rng is not None:
        if t not in ("R", "P"):
            raise ValueError(f"{where}.range: only R and P joints have a range")
        rng = (float(rng[0]), float(rng[1]))
    if t in ("R", "P"):
        if "axis" not in spec:
            raise ValueError(f"{where}.axis: required for an {t} joint")
        return Joint(t, name, c, axis=_unit(spec["axis"], f"{where}.axis"), actuated=act, rng=rng)
    if t == "U":
        ax = spec.get("axes")
        if ax is None or len(ax) != 2:
            raise ValueError(f"{where}.axes: two axes [[a1], [a2]] required for a U joint")
        a1, a2 = _unit(ax[0], f"{where}.axes[0]"), _unit(ax[1], f"{where}.axes[1]")
        if abs(float(a1 @ a2)) > U_PERP_TOL:
            raise ValueError(f"{where}.axes: a1 and a2 not perpendicular at home "
                             f"(a1 . a2 = {float(a1 @ a2):.3g})")
        return Joint(t, name, c, a1=a1, a2=a2)
    if "axis" in spec or "axes" in spec:
        raise ValueError(f"{where}: an S joint takes no axis")
    return Joint(t, name, c)


def _rod(m, a, b):
    d = b - a
    ell = float(np.linalg.norm(d))
    if m == 0.0 or ell == 0.0:
        return np.zeros((3, 3))
    e = d / ell
    return m * ell * ell / 12.0 * (I3 - np.outer(e, e))


def _parse_limb(spec, where):
    bad = set(spec) - {"repeat", "rotate_deg", "joints", "bodies"}
    if bad:
        raise ValueError(f"{where}: unknown key(s) {sorted(bad)}")
    jspecs = spec.get("joints") or []
    if len(jspecs) < 1:
        raise ValueError(f"{where}.joints: at least one joint")
    joints = [_parse_joint(j, f"{where}.joints[{k}]") for k, j in enumerate(jspecs)]
    names = [j.name for j in joints]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"{where}.joints: joints of one limb share the name(s) {dup}")
    nb = len(joints) - 1
    bspecs = spec.get("bodies")
    if bspecs is None:
        bspecs = [{} for _ in range(nb)]
    if len(bspecs) != nb:
        raise ValueError(f"{where}.bodies: {nb} bodies expected (one between each two joints), "
                         f"got {len(bspecs)}")
    bodies = []
    for k, b in enumerate(bspecs):
        bad = set(b) - {"mass", "com", "inertia"}
        if bad:
            raise ValueError(f"{where}.bodies[{k}]: unknown key(s) {sorted(bad)}")
        m = float(b.get("mass", 0.0))
        ca, cb = joints[k].c, joints[k + 1].c
        com = _vec3(b["com"], f"{where}.bodies[{k}].com") if "com" in b else 0.5 * (ca + cb)
        if "inertia" in b:
            I = np.asarray(b["inertia"], float)
            if I.shape != (3, 3):
                raise ValueError(f"{where}.bodies[{k}].inertia: a 3x3 matrix expected")
            I = 0.5 * (I + I.T)
        else:
            I = _rod(m, ca, cb)
        bodies.append((m, com, I))
    rep = int(spec.get("repeat", 1))
    if rep < 1:
        raise ValueError(f"{where}.repeat: at least 1")
    rot = float(spec.get("rotate_deg", 360.0 / rep))
    return joints, bodies, rep, rot


def _platform_frame(home):
    x, y, z, phi, psi, theta = (float(v) for v in home)
    R = rm._rotation(np.array([psi]), np.array([theta]), np.array([phi]))[0]
    return np.array([x, y, z]), R


def normalize_job(job: dict, check: bool = True) -> Mech:
    """Parse a custom job dict (tomllib) into a Mech; refusals raise ValueError.

    With check=True (default) the rigidity and count tests of check_description run too."""
    allowed_top = {"name", "mechanism", "mass", "load", "clearance", "analysis", "grid",
                   "trajectory"}
    bad = set(job) - allowed_top
    if bad:
        raise ValueError(f"unknown key(s) {sorted(bad)}")
    mech_s = job.get("mechanism", {})
    if mech_s.get("kind") != "custom":
        raise ValueError("mechanism.kind: 'custom' expected")
    bad = set(mech_s) - {"kind", "inputs", "home", "limb", "gravity"}
    if bad:
        raise ValueError(f"mechanism: unknown key(s) {sorted(bad)} for kind custom")
    M = Mech()
    M.job = job
    inputs = list(mech_s.get("inputs", []))
    for name in inputs:
        if name not in COORDS:
            raise ValueError(f"mechanism.inputs: {name!r} is not a platform coordinate "
                             f"(one of {', '.join(COORDS)})")
    if len(set(inputs)) != len(inputs):
        raise ValueError("mechanism.inputs: a coordinate named twice")
    M.inputs = [i for i, c in enumerate(COORDS) if c in inputs]        # canonical order
    M.par = [i for i in range(6) if i not in M.inputs]
    home = np.asarray(mech_s.get("home", [0.0] * 6), float)
    if home.shape != (6,):
        raise ValueError("mechanism.home: six numbers x, y, z, phi, psi, theta expected")
    M.home = home
    M.p_home, M.R_home = _platform_frame(home)
    M.g = np.asarray(mech_s.get("gravity", [0.0, 0.0, -9.81]), float)
    # limbs
    limbs = []
    specs = mech_s.get("limb") or []
    if not specs:
        raise ValueError("mechanism.limb: at least one [[mechanism.limb]]")
    for li, spec in enumerate(specs):
        joints, bodies, rep, rot = _parse_limb(spec, f"mechanism.limb[{li}]")
        for r in range(rep):
            Rz = _rotz_deg(r * rot) if r else I3
            js = [j.copy_rotated(Rz) for j in joints] if r else joints
            bs = [(m, Rz @ c, Rz @ I @ Rz.T) for m, c, I in bodies] if r else bodies
            limbs.append(Limb(len(limbs) + 1, js, bs))
    M.limbs = limbs
    # index maps
    nq = ns = col = 0
    M.actuators = []
    for L in limbs:
        pcol = 0
        for k, J in enumerate(L.joints):
            J.limb, J.place = L, k + 1
            if J.type == "S":
                J.si = ns
                ns += 1
            else:
                J.qi = nq
                nq += J.nfree
            J.col = col
            col += J.nfree
            if not J.actuated:
                J.pcol = pcol
                pcol += J.npassive
            else:
                M.actuators.append(J)
                J.act = len(M.actuators)
        L.npassive = pcol
    M.nq, M.ns, M.nfree = nq, ns, col
    M.nu = col + len(M.par)
    # bodies and platform
    mass = job.get("mass", {})
    bad = set(mass) - {"platform", "platform_inertia", "points"}
    if bad:
        raise ValueError(f"mass: unknown key(s) {sorted(bad)} for kind custom")
    mp = float(mass.get("platform", 0.0))
    if "platform_inertia" in mass:
        I_own = np.diag(np.asarray(mass["platform_inertia"], float))
    else:
        loc = np.array([M.R_home.T @ (L.joints[-1].c - M.p_home) for L in limbs])
        r = float(np.mean(np.hypot(loc[:, 0], loc[:, 1])))
        I_own = np.diag([mp * r * r / 4.0, mp * r * r / 4.0, mp * r * r / 2.0])
    pts = mass.get("points", [])
    pm = np.array([float(p["mass"]) for p in pts], float)
    pa = np.array([p["at"] for p in pts], float).reshape(-1, 3)
    m_tot = mp + pm.sum()
    c_loc = (pm[:, None] * pa).sum(0) / m_tot if m_tot > 0 else np.zeros(3)
    I_P = I_own.copy()
    for mk, ak in zip(pm, pa):
        I_P += mk * (ak @ ak * I3 - np.outer(ak, ak))
    M.m_plat = m_tot
    M.c_loc = c_loc
    M.I_C_loc = I_P - m_tot * (c_loc @ c_loc * I3 - np.outer(c_loc, c_loc))
    m_bodies = sum(m for L in limbs for m, _, _ in L.bodies)
    M.W = (m_tot + m_bodies) * float(np.linalg.norm(M.g))
    load = job.get("load", {})
    M.f_ext = np.asarray(load.get("force", [0.0] * 3), float)
    M.m_ext = np.asarray(load.get("moment", [0.0] * 3), float)
    M.at_ext = np.asarray(load.get("at", [0.0] * 3), float)
    # analysis
    an = job.get("analysis", {})
    bad = set(an) - {"modes", "exact", "discontinuity_load_fraction", "indeterminate_load_fraction",
                     "singular_cond"}
    if bad:
        raise ValueError(f"analysis: unknown key(s) {sorted(bad)}")
    M.modes = list(an.get("modes", ["kinetostatic"]))
    M.exact = bool(an.get("exact", False))
    M.disc_frac = float(an.get("discontinuity_load_fraction", 0.05))
    M.indet_frac = float(an.get("indeterminate_load_fraction", 1e-9))
    M.singular_cond = float(an.get("singular_cond", 1e8))
    if ("grid" in job) == ("trajectory" in job):
        raise ValueError("exactly one of [grid] or [trajectory] is required")
    M.trajectory = "trajectory" in job
    for m in M.modes:
        if m not in ("kinetostatic", "dynamic"):
            raise ValueError(f"analysis.modes: unknown mode {m!r}")
    if "dynamic" in M.modes and not M.trajectory:
        raise ValueError("analysis.modes: dynamic mode is only valid on trajectories")
    sec = job.get("grid") if "grid" in job else job.get("trajectory")
    for k in sec:
        if k == "time" and M.trajectory:
            continue
        if k not in inputs:
            raise ValueError(f"{'trajectory' if M.trajectory else 'grid'}.{k}: not an input "
                             f"(inputs: {', '.join(inputs)})")
    # clearances
    M.groups, M.kinds = [], []
    for key, val in job.get("clearance", {}).items():
        if "_" not in key:
            raise ValueError(f"clearance.{key}: `<joint name>_<group>` expected")
        name, group = key.rsplit("_", 1)
        holders = []
        for L in limbs:
            for J in L.joints:
                if J.name == name and group in J.groups():
                    holders.append((L, J))
        if not holders:
            raise ValueError(f"clearance.{key}: names no joint group of the mechanism")
        if isinstance(val, (list, tuple)):
            if len(val) != len(holders):
                raise ValueError(f"clearance.{key}: {len(holders)} values expected (one per limb "
                                 f"with the joint), got {len(val)}")
            mags = [float(v) for v in val]
        else:
            mags = [float(val)] * len(holders)
        if any((not math.isfinite(v)) or v < 0 for v in mags):
            raise ValueError(f"clearance.{key}: magnitudes must be finite and >= 0")
        M.kinds.append(key)
        for (L, J), mg in zip(holders, mags):
            M.groups.append(Group(key, J, group, L, mg))
    M.groups.sort(key=lambda g: g.order)
    M.play_joints = []                       # joints with at least one group, in a fixed order
    seen = set()
    for g in M.groups:
        if id(g.joint) not in seen:
            seen.add(id(g.joint))
            M.play_joints.append(g.joint)
    M.jresp = {id(J): i for i, J in enumerate(M.play_joints)}
    M.Lchar = max(1.0, max(float(np.linalg.norm(J.c - M.p_home)) for L in limbs for J in L.joints))
    trans = sum(g.mag for g in M.groups if not g.rot)
    ang = sum(g.mag for g in M.groups if g.rot)
    M.branch_floor = 1e3 * EPS * (trans + ang * M.Lchar)
    if check:
        _check(M)
    return M


def _check(M):
    # an idle freedom first: it also spoils the counts
    for L in M.limbs:
        s_idx = [k for k, J in enumerate(L.joints) if J.type == "S"]
        for a, b in zip(s_idx, s_idx[1:]):
            if all(L.joints[k].actuated for k in range(a + 1, b)):
                raise ValueError(
                    f"limb {L.number}: an idle freedom: the part between S joints "
                    f"'{L.joints[a].name}' and '{L.joints[b].name}' can spin about the line "
                    f"joining their centres with the actuators locked; make one of the two a U joint")
    b = sum(len(L.joints) - 1 for L in M.limbs) + 1
    k = sum(J.k for L in M.limbs for J in L.joints)
    if k > 6 * b:
        raise ValueError(f"the mechanism is overconstrained: its joints transmit {k} components "
                         f"for {b} moving bodies (6 x {b} = {6 * b} equations)")
    if k < 6 * b:
        raise ValueError(f"the mechanism is not rigid: its joints transmit {k} components "
                         f"for {b} moving bodies (6 x {b} = {6 * b} equations)")
    if len(M.inputs) != len(M.actuators):
        raise ValueError(f"mechanism.inputs: {len(M.inputs)} inputs for {len(M.actuators)} "
                         f"actuated joints")
    st = home_state(M, 1)
    geo = chain(M, st)
    A, _, _ = equilibrium(M, geo, st, None)
    sv = np.linalg.svd(A[0], compute_uv=False)
    if not sv[-1] > 1e-10 * sv[0]:
        raise ValueError("the mechanism is not rigid at home: the equilibrium system is rank "
                         f"deficient (smallest/largest singular value {sv[-1] / sv[0]:.2e})")
    Jk = kinematic_jacobian(M, geo, st["c"])
    sv = np.linalg.svd(Jk[0], compute_uv=False)
    if not sv[-1] > 1e-10 * sv[0]:
        raise ValueError("mechanism.inputs: the inputs do not determine the platform's pose at "
                         "home (the closure's Jacobian is singular there)")


def check_description(job: dict) -> Mech:
    """Refuse what docs/model.md 12.3 and docs/interface.md refuse (ValueError with the counts, the
    word overconstrained / not rigid, or the limb and the hint of an idle freedom)."""
    return normalize_job(job, check=True)


# --------------------------------------------------------------------------
# sampling
# --------------------------------------------------------------------------
def sample_inputs(M: Mech) -> dict:
    """{'t': (N,) (NaN on grids), 'c': (N, 6) coordinates with the inputs set (parasitic
    at home), on trajectories 'cd', 'cdd' (N, 6) the inputs' exact rates}."""
    j = M.job
    if not M.trajectory:
        g = j["grid"]
        axes = [rm._grid_axis(g[COORDS[i]]) if COORDS[i] in g else np.array([M.home[i]])
                for i in M.inputs]
        mesh = np.meshgrid(*axes, indexing="ij") if axes else []
        n = mesh[0].size if axes else 1
        c = np.tile(M.home, (n, 1))
        for i, m in zip(M.inputs, mesh):
            c[:, i] = m.ravel()
        return {"t": np.full(n, np.nan), "c": c, "cd": None, "cdd": None}
    tr = j["trajectory"]
    t = rm._grid_axis(tr["time"])
    n = t.size
    c, cd, cdd = np.tile(M.home, (n, 1)), np.zeros((n, 6)), np.zeros((n, 6))
    for i in M.inputs:
        if COORDS[i] in tr:
            c[:, i], cd[:, i], cdd[:, i] = rm._harmonic(tr[COORDS[i]], t)
    return {"t": t, "c": c, "cd": cd, "cdd": cdd}


# --------------------------------------------------------------------------
# kinematics: product of exponentials, closure, continuation
# --------------------------------------------------------------------------
def home_state(M, N):
    return {"q": np.zeros((N, M.nq)), "S": np.broadcast_to(I3, (N, M.ns, 3, 3)).copy(),
            "c": np.tile(M.home, (N, 1))}


def _sub(st, idx):
    return {k: v[idx] for k, v in st.items()}


def chain(M, st):
    """Forward kinematics of every limb from the state st = {q, S, c}.

    Returns a list per limb of a list per joint of dicts: Rp, tp (displacement of the
    proximal body from home: x -> Rp x + tp), R, t (of the distal body), c (current
    centre), the current axes (a, d, a1, a2, n) and scr (N, 6, nfree), the spatial
    screws [w; v_O] (about the world origin) of the joint's freedoms."""
    N = st["q"].shape[0]
    out = []
    for L in M.limbs:
        R = np.broadcast_to(I3, (N, 3, 3))
        t = np.zeros((N, 3))
        jg = []
        for J in L.joints:
            Rp, tp = R, t
            g = {"J": J, "Rp": Rp, "tp": tp}
            if J.type == "R":
                th = st["q"][:, J.qi]
                Re = rm.rot_exp(th[:, None] * J.a)
                R = Rp @ Re
                c = _mv(Rp, J.c) + tp
                t = c - _mv(R, J.c)
                a = _mv(Rp, J.a)
                g.update(c=c, a=a, scr=np.concatenate([a, _cx(c, a)], -1)[..., None])
            elif J.type == "P":
                s = st["q"][:, J.qi]
                d = _mv(Rp, J.a)
                R = Rp
                t = tp + s[:, None] * d
                c = _mv(Rp, J.c) + t
                g.update(c=c, a=d, scr=np.concatenate([np.zeros_like(d), d], -1)[..., None])
            elif J.type == "U":
                t1, t2 = st["q"][:, J.qi], st["q"][:, J.qi + 1]
                Re = rm.rot_exp(t1[:, None] * J.a1) @ rm.rot_exp(t2[:, None] * J.a2)
                R = Rp @ Re
                c = _mv(Rp, J.c) + tp
                t = c - _mv(R, J.c)
                a1, a2 = _mv(Rp, J.a1), _mv(R, J.a2)
                n = _cx(a1, a2)
                scr = np.stack([np.concatenate([a1, _cx(c, a1)], -1),
                                np.concatenate([a2, _cx(c, a2)], -1)], -1)
                g.update(c=c, a1=a1, a2=a2, n=n, scr=scr)
            else:
                Re = st["S"][:, J.si]
                R = Rp @ Re
                c = _mv(Rp, J.c) + tp
                t = c - _mv(R, J.c)
                scr = np.stack([np.concatenate([np.broadcast_to(I3[k], (N, 3)),
                                                _cx(c, I3[k])], -1) for k in range(3)], -1)
                g.update(c=c, scr=scr)
            g.update(R=R, t=t)
            jg.append(g)
        out.append(jg)
    return out


def platform_pose(c):
    """R (N,3,3) = Ry(theta) Rx(psi) Rz(phi) and p (N,3) of coordinates c (N,6)."""
    return rm._rotation(c[:, 4], c[:, 5], c[:, 3]), c[:, 0:3].copy()


def euler_columns(c):
    """(N,3,3): columns dw/dphi, dw/dpsi, dw/dtheta (w the platform's angular velocity)."""
    return rm.euler_matrix(c[:, 4], c[:, 5])[:, :, ::-1]


def platform_jacobian(c):
    """J_D (N,6,6): the spatial twist [w; v_O] of the platform per unit rate of each
    coordinate x, y, z, phi, psi, theta."""
    N = c.shape[0]
    J = np.zeros((N, 6, 6))
    J[:, 3:6, 0:3] = I3
    E = euler_columns(c)
    p = c[:, 0:3]
    for k in range(3):
        J[:, 0:3, 3 + k] = E[:, :, k]
        J[:, 3:6, 3 + k] = _cx(p, E[:, :, k])
    return J


def closure_residual(M, geo, c):
    """(N, 6L): per limb the twist-like residual [log(R_G R_D^T); t_G - R_e t_D] of the
    last body's displacement G against the platform's D = T(pose) T(home)^-1."""
    Rpose, p = platform_pose(c)
    RD = Rpose @ M.R_home.T
    tD = p - _mv(RD, M.p_home)
    res = []
    for jg in geo:
        RG, tG = jg[-1]["R"], jg[-1]["t"]
        Re = RG @ RD.swapaxes(-1, -2)
        res.append(np.concatenate([rm.rot_log(Re), tG - _mv(Re, tD)], -1))
    return np.concatenate(res, -1)


def kinematic_jacobian(M, geo, c):
    """(N, 6L, nu): the closure's derivative, unknowns every joint freedom (S: world
    rotation about its centre) then the parasitic coordinates."""
    N = c.shape[0]
    nl = len(M.limbs)
    Jk = np.zeros((N, 6 * nl, M.nu))
    JD = platform_jacobian(c)
    for i, jg in enumerate(geo):
        for g in jg:
            J = g["J"]
            Jk[:, 6 * i:6 * i + 6, J.col:J.col + J.nfree] = g["scr"]
        Jk[:, 6 * i:6 * i + 6, M.nfree:] = -JD[:, :, M.par]
    return Jk


def _apply(M, st, geo, du):
    """State after the kinematic step du (N, nu)."""
    new = {"q": st["q"].copy(), "S": st["S"].copy(), "c": st["c"].copy()}
    for jg in geo:
        for g in jg:
            J = g["J"]
            if J.type == "S":
                w = du[:, J.col:J.col + 3]
                loc = np.einsum("nba,nb->na", g["Rp"], w)           # Rp^T w
                new["S"][:, J.si] = rm.rot_exp(loc) @ st["S"][:, J.si]
            else:
                new["q"][:, J.qi:J.qi + J.nfree] += du[:, J.col:J.col + J.nfree]
    new["c"][:, M.par] += du[:, M.nfree:]
    return new


def _newton(M, st, iters, tol):
    """Newton on the closure with the inputs fixed: (state, converged, last step)."""
    N = st["q"].shape[0]
    conv = np.zeros(N, bool)
    last = np.full(N, np.inf)
    for _ in range(iters):
        geo = chain(M, st)
        F = closure_residual(M, geo, st["c"])
        Jk = kinematic_jacobian(M, geo, st["c"])
        with np.errstate(all="ignore"):
            du = _solve(Jk, -F[..., None])[..., 0]
        bad = ~np.all(np.isfinite(du), -1)
        du[bad] = 0.0
        st = _apply(M, st, geo, du)
        last = np.where(bad, np.inf, np.abs(du).max(-1))
        conv = last <= tol
        if np.all(conv | bad):
            break
    return st, conv, last


def solve_kinematics(M, target):
    """Continuation from home to the coordinates `target` (N,6) (only the inputs are
    read).  Returns (state, converged (N,))."""
    N = target.shape[0]
    st = home_state(M, N)
    start = np.tile(M.home, (N, 1))
    dc = np.zeros((N, 6))
    dc[:, M.inputs] = target[:, M.inputs] - start[:, M.inputs]
    s = np.zeros(N)
    h = np.full(N, 0.25)
    active = np.ones(N, bool)
    failed = np.zeros(N, bool)
    for _ in range(4000):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        cur = _sub(st, idx)
        geo = chain(M, cur)
        Jk = kinematic_jacobian(M, geo, cur["c"])
        JD = platform_jacobian(cur["c"])
        with np.errstate(all="ignore"):
            rhs = np.tile(np.einsum("nab,nb->na", JD, dc[idx]), (1, len(M.limbs)))
            tan = _solve(Jk, rhs[..., None])[..., 0]
        tmax = np.abs(tan).max(-1)
        tmax = np.where(np.isfinite(tmax), tmax, np.inf)
        hh = np.minimum(np.minimum(h[idx], 1.0 - s[idx]), STEP_CAP / np.maximum(tmax, 1e-300))
        hh = np.where(np.isfinite(tmax), hh, 0.0)
        snew = np.where(hh >= 1.0 - s[idx], 1.0, s[idx] + hh)
        hh = snew - s[idx]
        trial = _apply(M, cur, geo, np.nan_to_num(tan) * hh[:, None])
        trial["c"][:, M.inputs] = start[idx][:, M.inputs] + snew[:, None] * dc[idx][:, M.inputs]
        trial, ok, _ = _newton(M, trial, 8, KIN_TOL)
        ok &= hh > 0
        acc = idx[ok]
        for k in st:
            st[k][acc] = trial[k][ok]
        s[acc] = snew[ok]
        h[acc] = np.minimum(2.0 * h[acc], 1.0)
        rej = idx[~ok]
        h[rej] *= 0.25
        dead = rej[h[rej] < H_MIN]
        failed[dead] = True
        active[dead] = False
        active[acc[s[acc] >= 1.0]] = False
    failed |= active
    done = np.flatnonzero(~failed)
    conv = np.zeros(N, bool)
    if done.size:
        fin, _, last = _newton(M, _sub(st, done), 12, KIN_FINAL)
        for k in st:
            st[k][done] = fin[k]
        conv[done] = last <= KIN_ACCEPT
    return st, conv


def joint_values(M, st):
    """(N, n_actuators): each actuated joint's variable from home (angle or displacement)."""
    return np.stack([st["q"][:, J.qi] for J in M.actuators], -1) if M.actuators else \
        np.zeros((st["q"].shape[0], 0))


def in_range(M, st):
    ok = np.ones(st["q"].shape[0], bool)
    for L in M.limbs:
        for J in L.joints:
            if J.range is not None:
                v = st["q"][:, J.qi]
                ok &= (v >= J.range[0]) & (v <= J.range[1])
    return ok


# --------------------------------------------------------------------------
# rates: implicit differentiation of the closure in twist form
# --------------------------------------------------------------------------
def rates(M, st, geo, cd_in, cdd_in):
    """Velocities and accelerations of every body for input rates cd_in, cdd_in (N,6)
    (only the inputs are read).  Returns dict: cd, cdd (N,6) coordinate rates, ud, udd
    (N,nu) joint rates (S: world relative angular velocity), per limb per body V, A
    ((N,6) spatial twist and its derivative about the origin), platform w, dw, a_C."""
    c = st["c"]
    N = c.shape[0]
    Jk = kinematic_jacobian(M, geo, c)
    JD = platform_jacobian(c)
    cdi = np.zeros((N, 6))
    cdi[:, M.inputs] = cd_in[:, M.inputs]
    rhs = np.tile(np.einsum("nab,nb->na", JD, cdi), (1, len(M.limbs)))
    ud = _solve(Jk, rhs[..., None])[..., 0]
    cd = cdi.copy()
    cd[:, M.par] = ud[:, M.nfree:]
    # platform twist derivative with cdd = 0: [wd_b; -wd_b x p - w x pdot]
    E = euler_columns(c)
    w = np.einsum("nab,nb->na", E, cd[:, 3:6])
    e_th, e_ps, e_ph = E[:, :, 2], E[:, :, 1], E[:, :, 0]
    ph_d, ps_d, th_d = cd[:, 3], cd[:, 4], cd[:, 5]
    wd_b = ps_d[:, None] * _cx(th_d[:, None] * e_th, e_ps) + \
        ph_d[:, None] * _cx(th_d[:, None] * e_th + ps_d[:, None] * e_ps, e_ph)
    p, pd = c[:, 0:3], cd[:, 0:3]
    biasD = np.concatenate([wd_b, -_cx(wd_b, p) - _cx(w, pd)], -1)
    # chain bias sum xi_dot q_dot, and body twists
    bias = []
    Vb = []
    for jg in geo:
        V = np.zeros((N, 6))
        bsum = np.zeros((N, 6))
        vs = []
        for g in jg:
            J = g["J"]
            qd = ud[:, J.col:J.col + J.nfree]
            scr = g["scr"]
            if J.type in ("R", "P"):
                bsum += _ad(V, scr[..., 0]) * qd
                V = V + scr[..., 0] * qd
            elif J.type == "U":
                bsum += _ad(V, scr[..., 0]) * qd[:, 0:1]
                V = V + scr[..., 0] * qd[:, 0:1]
                bsum += _ad(V, scr[..., 1]) * qd[:, 1:2]
                V = V + scr[..., 1] * qd[:, 1:2]
            else:
                cdot = V[:, 3:6] + _cx(V[:, 0:3], g["c"])
                bsum[:, 3:6] += _cx(cdot, qd)
                V = V + np.einsum("nak,nk->na", scr, qd)
            vs.append(V)
        bias.append(bsum)
        Vb.append(vs)
    rhs2 = np.tile(np.einsum("nab,nb->na", JD, np.where(np.isin(np.arange(6), M.inputs), cdd_in, 0.0))
                   + biasD, (1, len(M.limbs))) - np.concatenate(bias, -1)
    udd = _solve(Jk, rhs2[..., None])[..., 0]
    cdd = np.zeros((N, 6))
    cdd[:, M.inputs] = cdd_in[:, M.inputs]
    cdd[:, M.par] = udd[:, M.nfree:]
    # body accelerations
    Ab = []
    for jg, vs in zip(geo, Vb):
        V = np.zeros((N, 6))
        A = np.zeros((N, 6))
        accs = []
        for g, Vafter in zip(jg, vs):
            J = g["J"]
            qd = ud[:, J.col:J.col + J.nfree]
            qdd = udd[:, J.col:J.col + J.nfree]
            scr = g["scr"]
            if J.type in ("R", "P"):
                A = A + scr[..., 0] * qdd + _ad(V, scr[..., 0]) * qd
            elif J.type == "U":
                A = A + scr[..., 0] * qdd[:, 0:1] + _ad(V, scr[..., 0]) * qd[:, 0:1]
                Vm = V + scr[..., 0] * qd[:, 0:1]
                A = A + scr[..., 1] * qdd[:, 1:2] + _ad(Vm, scr[..., 1]) * qd[:, 1:2]
            else:
                cdot = V[:, 3:6] + _cx(V[:, 0:3], g["c"])
                A = A + np.einsum("nak,nk->na", scr, qdd)
                A[:, 3:6] += _cx(cdot, qd)
            V = Vafter
            accs.append(A)
        Ab.append(accs)
    dw = np.einsum("nab,nb->na", E, cdd[:, 3:6]) + wd_b
    Rp, _ = platform_pose(c)
    rc = _mv(Rp, M.c_loc)
    a_C = cdd[:, 0:3] + _cx(dw, rc) + _cx(w, _cx(w, rc))
    return {"cd": cd, "cdd": cdd, "ud": ud, "udd": udd, "V": Vb, "A": Ab, "w": w, "dw": dw,
            "a_C": a_C}


# --------------------------------------------------------------------------
# reactions: the dense Newton-Euler system
# --------------------------------------------------------------------------
def _joint_basis(g, N):
    """(N, 6, k): the joint's transmitted wrench [f; m_c] per unknown (12.4)."""
    J = g["J"]
    if J.actuated:
        return np.broadcast_to(np.eye(6), (N, 6, 6))
    B = np.zeros((N, 6, J.k))
    if J.type == "R":
        B[:, 0:3, 0:3] = I3
        u1, u2 = _perp_basis(g["a"])
        B[:, 3:6, 3], B[:, 3:6, 4] = u1, u2
    elif J.type == "P":
        u1, u2 = _perp_basis(g["a"])
        B[:, 0:3, 0], B[:, 0:3, 1] = u1, u2
        B[:, 3:6, 2:5] = I3
    elif J.type == "U":
        B[:, 0:3, 0:3] = I3
        B[:, 3:6, 3] = g["n"]
    else:
        B[:, 0:3, 0:3] = I3
    return B


def body_frames(M, geo, c):
    """Centres of mass (per limb, per body (N,3)) and world inertias, platform C, E, I_C."""
    com, inert = [], []
    for L, jg in zip(M.limbs, geo):
        cs, Is = [], []
        for k, (m, c0, I0) in enumerate(L.bodies):
            R, t = jg[k]["R"], jg[k]["t"]
            cs.append(_mv(R, c0) + t)
            Is.append(R @ I0 @ R.swapaxes(-1, -2))
        com.append(cs)
        inert.append(Is)
    Rp, p = platform_pose(c)
    C = p + _mv(Rp, M.c_loc)
    E = p + _mv(Rp, M.at_ext)
    IC = Rp @ M.I_C_loc @ Rp.swapaxes(-1, -2)
    return com, inert, C, E, IC


def equilibrium(M, geo, st, rt=None):
    """Dense Newton-Euler system A w = b (N, 6b, 6b), (N, 6b), and the column layout.

    Rows: 6 per moving body (forces; moments about its centre of mass), limb bodies limb
    by limb, the platform last (moments about its composite centre of mass C).  Columns:
    every joint's transmitted components (12.4), limb by limb, joint by joint.  rt: the
    output of rates() for dynamics (None: kinetostatics)."""
    c = st["c"]
    N = c.shape[0]
    com, inert, C, E, IC = body_frames(M, geo, c)
    nb = sum(len(L.bodies) for L in M.limbs) + 1
    ncol = sum(J.k for L in M.limbs for J in L.joints)
    A = np.zeros((N, 6 * nb, ncol))
    b = np.zeros((N, 6 * nb))
    layout = []
    row0 = 0
    col = 0
    plat = nb - 1
    for li, (L, jg) in enumerate(zip(M.limbs, geo)):
        nbl = len(L.bodies)
        for k, g in enumerate(jg):
            J = g["J"]
            B = _joint_basis(g, N)
            layout.append((g, col, B))
            # distal body: body k of the limb, or the platform
            if k < nbl:
                dist, Gd = row0 + k, com[li][k]
            else:
                dist, Gd = plat, C
            blk = np.concatenate([B[:, 0:3], B[:, 3:6] + _cx(
                (g["c"] - Gd)[:, None, :], B[:, 0:3].swapaxes(-1, -2)).swapaxes(-1, -2)], 1)
            A[:, 6 * dist:6 * dist + 6, col:col + J.k] += blk
            if k > 0:
                prox, Gp = row0 + k - 1, com[li][k - 1]
                blk = np.concatenate([B[:, 0:3], B[:, 3:6] + _cx(
                    (g["c"] - Gp)[:, None, :], B[:, 0:3].swapaxes(-1, -2)).swapaxes(-1, -2)], 1)
                A[:, 6 * prox:6 * prox + 6, col:col + J.k] -= blk
            col += J.k
        for k, (m, _, _) in enumerate(L.bodies):
            r = 6 * (row0 + k)
            f = np.broadcast_to(-m * M.g, (N, 3)).copy()
            if rt is not None:
                V, Acc = rt["V"][li][k], rt["A"][li][k]
                w, v, dw, dv = V[:, 0:3], V[:, 3:6], Acc[:, 0:3], Acc[:, 3:6]
                G = com[li][k]
                aG = dv + _cx(dw, G) + _cx(w, v + _cx(w, G))
                f += m * aG
                I = inert[li][k]
                b[:, r + 3:r + 6] = np.einsum("nab,nb->na", I, dw) + \
                    _cx(w, np.einsum("nab,nb->na", I, w))
            b[:, r:r + 3] = f
        row0 += nbl
    r = 6 * plat
    b[:, r:r + 3] = -M.m_plat * M.g - M.f_ext
    b[:, r + 3:r + 6] = -_cx(E - C, M.f_ext) - M.m_ext
    if rt is not None:
        w, dw = rt["w"], rt["dw"]
        b[:, r:r + 3] += M.m_plat * rt["a_C"]
        b[:, r + 3:r + 6] += np.einsum("nab,nb->na", IC, dw) + _cx(w, np.einsum("nab,nb->na", IC, w))
    return A, b, layout


def reactions(M, geo, st, layout, w):
    """Per joint (in layout order) f, m (N,3) each: proximal on distal, m about the
    current centre."""
    out = []
    for g, col, B in layout:
        wr = np.einsum("nak,nk->na", B, w[:, col:col + g["J"].k])
        out.append((wr[:, 0:3], wr[:, 3:6]))
    return out


# --------------------------------------------------------------------------
# error system (12.6), conditioning, unit responses, take-up
# --------------------------------------------------------------------------
def passive_twists(M, geo, p):
    """Per limb (N, 6, f_i): the passive freedoms' unit twists [w; v_P] at P (nominal)."""
    out = []
    N = p.shape[0]
    for L, jg in zip(M.limbs, geo):
        cols = []
        for g in jg:
            J = g["J"]
            if J.actuated:
                continue
            r = p - g["c"]
            if J.type == "R":
                cols.append(np.concatenate([g["a"], _cx(g["a"], r)], -1))
            elif J.type == "P":
                cols.append(np.concatenate([np.zeros((N, 3)), g["a"]], -1))
            elif J.type == "U":
                for ax in (g["a1"], g["a2"]):
                    cols.append(np.concatenate([ax, _cx(ax, r)], -1))
            else:
                for k in range(3):
                    e = np.broadcast_to(I3[k], (N, 3))
                    cols.append(np.concatenate([e, _cx(e, r)], -1))
        out.append(np.stack(cols, -1) if cols else np.zeros((N, 6, 0)))
    return out


def error_matrix(M, T):
    """The assembled error system (N, 6L, 6 + sum f_i): rows per limb
    Delta Gamma - sum_k xi_k dq_k = sum of that limb's clearance twists."""
    N = T[0].shape[0]
    nl = len(M.limbs)
    nf = sum(t.shape[-1] for t in T)
    E = np.zeros((N, 6 * nl, 6 + nf))
    col = 6
    for i, t in enumerate(T):
        E[:, 6 * i:6 * i + 6, 0:6] = np.eye(6)
        E[:, 6 * i:6 * i + 6, col:col + t.shape[-1]] = -t
        col += t.shape[-1]
    return E


def conditioning(M, T):
    """(kappa of G, largest limb kappa): see CHOICES 7."""
    N = T[0].shape[0]
    Ws, lk = [], np.zeros(N)
    for t in T:
        f = t.shape[-1]
        if f == 0:
            Ws.append(np.broadcast_to(np.eye(6), (N, 6, 6)))
            continue
        tn = t / np.linalg.norm(t, axis=1, keepdims=True)
        sv = np.linalg.svd(tn, compute_uv=False)
        with np.errstate(divide="ignore", invalid="ignore"):
            lk = np.maximum(lk, np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf))
        sw = np.concatenate([t[:, 3:6], t[:, 0:3]], 1)          # [v; w]: reciprocal pairing
        _, _, vh = np.linalg.svd(sw.swapaxes(-1, -2), full_matrices=True)
        Ws.append(vh[:, f:, :].swapaxes(-1, -2))
    G = np.concatenate(Ws, -1)
    if G.shape[-1] != 6:
        return np.full(N, np.inf), lk
    sv = np.linalg.svd(G, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        kg = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
    return np.where(np.isfinite(kg), kg, np.inf), np.where(np.isfinite(lk), lk, np.inf)


def unit_responses(M, geo, p, Emat):
    """Per joint with play (M.play_joints order) and limb: H (N, 6, 6), Delta Gamma per
    unit world translation (columns 0-2) and unit world rotation about the joint's
    centre (columns 3-5) of the joint's distal body, everything else rigid."""
    N = p.shape[0]
    nl = len(M.limbs)
    nj = len(M.play_joints)
    if nj == 0:
        return np.zeros((N, 0, 6, 6))
    rhs = np.zeros((N, 6 * nl, 6 * nj))
    cen = {}
    for L, jg in zip(M.limbs, geo):
        for g in jg:
            cen[id(g["J"])] = g["c"]
    for ji, J in enumerate(M.play_joints):
        i = J.limb.number - 1
        r = p - cen[id(J)]
        for k in range(3):
            rhs[:, 6 * i + 3 + k, 6 * ji + k] = 1.0
            rhs[:, 6 * i + k, 6 * ji + 3 + k] = 1.0
            rhs[:, 6 * i + 3:6 * i + 6, 6 * ji + 3 + k] = _cx(I3[k], r)
    sol = _solve(Emat, rhs)[:, 0:6, :]
    return sol.reshape(N, 6, nj, 6).transpose(0, 2, 1, 3)


def _group_axis(g, jgd):
    J = g.joint
    if J.type == "U":
        return jgd["n"]
    if J.type in ("R", "P"):
        return jgd["a"]
    return None


def _set_basis(g, jgd, N):
    """(N, 3, m): orthonormal basis of the group's admissible set."""
    if g.set == "ball":
        return np.broadcast_to(I3, (N, 3, 3))
    ax = _group_axis(g, jgd)
    if g.set == "segment":
        return ax[..., None]
    u1, u2 = _perp_basis(ax)
    return np.stack([u1, u2], -1)


def take_up(M, g, jgd, f, m):
    """(load, margin, displacement (N,3): translation or rotation vector) of group g at
    unit magnitude times g.mag.  load: (N,) for scalar loads, (N,3) for vector loads."""
    J = g.joint
    ax = _group_axis(g, jgd)
    if g.group == "backlash":
        load = np.einsum("na,na->n", m, ax) if J.type == "R" else np.einsum("na,na->n", f, ax)
    elif J.type == "R":
        if g.group == "radial":
            load = f - np.einsum("na,na->n", f, ax)[:, None] * ax
        elif g.group == "axial":
            load = np.einsum("na,na->n", f, ax)
        else:
            load = m - np.einsum("na,na->n", m, ax)[:, None] * ax
    elif J.type == "P":
        load = f - np.einsum("na,na->n", f, ax)[:, None] * ax if g.group == "radial" else m
    elif J.type == "U":
        load = f if g.group == "radial" else np.einsum("na,na->n", m, ax)
    else:
        load = f
    if g.scalar:
        margin = np.abs(load)
        # A load at or below the floor decides nothing: the take-up is then along +axis
        # (the 6-UPS's convention for its U tilt play, whose load is round-off).
        floor = M.indet_frac * M.W
        disp = -g.mag * np.where(np.abs(load) <= floor, -1.0, np.sign(load))[:, None] * ax
    else:
        margin = np.linalg.norm(load, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            disp = np.where((margin > 0)[:, None], -g.mag * load / np.where(margin > 0, margin, 1.0)[:, None],
                            0.0)
    return load, margin, disp


def group_envelope(g, H, U):
    """(N, 8): the group's maxima of |x|,|y|,|z|,|rx|,|ry|,|rz|, |dp|, |dalpha| over its set
    (magnitude g.mag), from the joint's unit responses H (N,6,6) and the set basis U."""
    Hg = (H[:, :, 3:6] if g.rot else H[:, :, 0:3]) @ U                   # (N,6,m)
    comp = np.linalg.norm(Hg, axis=-1)
    rows = [3, 4, 5, 0, 1, 2]
    return g.mag * np.concatenate([comp[:, rows], rm._spectral(Hg[:, 3:6, :])[:, None],
                                   rm._spectral(Hg[:, 0:3, :])[:, None]], -1)


# --------------------------------------------------------------------------
# exact error (12.7)
# --------------------------------------------------------------------------
def _compose(a, b):
    """(E, t) motions about P: a o b."""
    Ea, ta = a
    Eb, tb = b
    return Ea + Eb + Ea @ Eb, ta + tb + np.einsum("nab,nb->na", Ea, tb)


def _inverse(a):
    E, t = a
    Rt = (I3 + E).swapaxes(-1, -2)
    return Rt - I3, -np.einsum("nab,nb->na", Rt, t)


def _rot_about(Erot, c, p):
    return Erot, np.einsum("nab,nb->na", Erot, p - c)


def _adjoint(a, xi):
    """Ad_(E,t) of twists at P, xi (N,6,k)."""
    E, t = a
    R = I3 + E
    w = R @ xi[:, 0:3]
    v = R @ xi[:, 3:6] + _cx(t[:, :, None], w, axis=1)
    return np.concatenate([w, v], 1)


def exact_errors(M, geo, p, play, max_iter=40):
    """Newton on the nonlinear closure of 12.7 in perturbation form.

    play: dict id(joint) -> (r (N,3) rotation vector, u (N,3) translation) of the joint's
    take-up (groups summed).  Returns ((N,6) [w; dp] with NaN where not converged,
    converged (N,))."""
    N = p.shape[0]
    nl = len(M.limbs)
    Z = np.zeros((N, 3, 3))
    z3 = np.zeros((N, 3))
    # C_tot per limb, fixed
    Ctot = []
    for jg in geo:
        C = (Z, z3)
        for g in jg:
            J = g["J"]
            if id(J) in play:
                r, u = play[id(J)]
                Er = rm.exp_minus_identity(r)
                Cj = (Er, np.einsum("nab,nb->na", Er, p - g["c"]) + u)
                C = _compose(Cj, C)
        Ctot.append(C)
    npass = sum(L.npassive for L in M.limbs)
    # passive unknowns: scalars (R angle, P displacement, U angles) or S rotations
    x = np.zeros((N, npass))
    ES = {}
    Dl = (Z.copy(), z3.copy())          # platform displacement from nominal
    offs = []
    o = 0
    for L in M.limbs:
        offs.append(o)
        o += L.npassive
    rel = np.full(N, np.inf)

    for _ in range(max_iter):
        Jrows = np.zeros((N, 6 * nl, 6 + npass))
        F = np.zeros((N, 6 * nl))
        for i, (L, jg) in enumerate(zip(M.limbs, geo)):
            G = Ctot[i]
            for g in jg:
                J = g["J"]
                if J.actuated:
                    continue
                col = 6 + offs[i] + J.pcol
                c = g["c"]
                r = p - c
                if J.type == "R":
                    xi = np.concatenate([g["a"], _cx(g["a"], r)], -1)[..., None]
                    Jrows[:, 6 * i:6 * i + 6, col] = _adjoint(G, xi)[..., 0]
                    Em = rm.exp_minus_identity(x[:, col - 6, None] * g["a"])
                    G = _compose(G, _rot_about(Em, c, p))
                elif J.type == "P":
                    xi = np.concatenate([z3, g["a"]], -1)[..., None]
                    Jrows[:, 6 * i:6 * i + 6, col] = _adjoint(G, xi)[..., 0]
                    G = _compose(G, (Z, x[:, col - 6, None] * g["a"]))
                elif J.type == "U":
                    xi = np.concatenate([g["a1"], _cx(g["a1"], r)], -1)[..., None]
                    Jrows[:, 6 * i:6 * i + 6, col] = _adjoint(G, xi)[..., 0]
                    E1 = rm.exp_minus_identity(x[:, col - 6, None] * g["a1"])
                    G = _compose(G, _rot_about(E1, c, p))
                    xi = np.concatenate([g["a2"], _cx(g["a2"], r)], -1)[..., None]
                    Jrows[:, 6 * i:6 * i + 6, col + 1] = _adjoint(G, xi)[..., 0]
                    E2 = rm.exp_minus_identity(x[:, col - 5, None] * g["a2"])
                    G = _compose(G, _rot_about(E2, c, p))
                else:
                    xi = np.stack([np.concatenate([np.broadcast_to(I3[k], (N, 3)),
                                                   _cx(I3[k], r)], -1) for k in range(3)], -1)
                    Jrows[:, 6 * i:6 * i + 6, col:col + 3] = _adjoint(G, xi)
                    Es = ES.get(id(J), Z)
                    G = _compose(G, _rot_about(Es, c, p))
            Err = _compose(G, _inverse(Dl))
            F[:, 6 * i:6 * i + 6] = np.concatenate([_log_small(Err[0]), Err[1]], -1)
            Jrows[:, 6 * i:6 * i + 6, 0:6] = -_adjoint(Err, np.broadcast_to(np.eye(6), (N, 6, 6)))
        with np.errstate(all="ignore"):
            step = _solve(Jrows, -F[..., None])[..., 0]
        # update
        zeta = step[:, 0:6]
        Ez = rm.exp_minus_identity(zeta[:, 0:3])
        Dl = _compose((Ez, zeta[:, 3:6]), Dl)
        for i, (L, jg) in enumerate(zip(M.limbs, geo)):
            for g in jg:
                J = g["J"]
                if J.actuated:
                    continue
                col = 6 + offs[i] + J.pcol
                if J.type == "S":
                    Ed = rm.exp_minus_identity(step[:, col:col + 3])
                    Es = ES.get(id(J), Z)
                    ES[id(J)] = Ed + Es + Ed @ Es
                else:
                    x[:, col - 6:col - 6 + J.npassive] += step[:, col:col + J.npassive]
        wv = _log_small(Dl[0])
        sz = np.maximum(np.abs(Dl[1]).max(-1), M.Lchar * np.abs(wv).max(-1))
        smax = np.maximum(np.abs(step[:, 3:6]).max(-1), M.Lchar * np.abs(step[:, 0:3]).max(-1))
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.where(sz > 0, smax / np.where(sz > 0, sz, 1.0), np.where(smax == 0, 0.0, np.inf))
        rel = np.where(np.isfinite(rel), rel, np.inf)
        if np.all((rel <= 4.0 * EPS) | ~np.isfinite(step).all(-1)):
            break
    out = np.concatenate([_log_small(Dl[0]), Dl[1]], -1)
    conv = (rel <= 1e-10) & np.isfinite(out).all(-1)
    out[~conv] = np.nan
    return out, conv


# --------------------------------------------------------------------------
# the pipeline
# --------------------------------------------------------------------------
def evaluate(M, c_in, mode="kinetostatic", cd=None, cdd=None):
    """Everything at explicit poses: c_in (N,6) coordinates (inputs read; parasitic
    solved), cd / cdd (N,6) input rates for dynamics.  Returns a dict of arrays (the
    internal quantities: state, converged, reach, geometry, reactions, per-group loads,
    margins, displacements, responses, per-kind errors ...)."""
    c_in = np.atleast_2d(np.asarray(c_in, float))
    N = c_in.shape[0]
    st, conv = solve_kinematics(M, c_in)
    rng_ok = in_range(M, st)
    reach = conv & rng_ok
    # unreachable rows: the home state keeps the stacks solvable (their outputs are null)
    sts = {k: v.copy() for k, v in st.items()}
    hs = home_state(M, N)
    for k in sts:
        m = reach.reshape((N,) + (1,) * (sts[k].ndim - 1))
        sts[k] = np.where(m, sts[k], hs[k])
    geo = chain(M, sts)
    c = sts["c"]
    rt = None
    if mode == "dynamic":
        rt = rates(M, sts, geo, cd, cdd)
    A, b, layout = equilibrium(M, geo, sts, rt)
    with np.errstate(all="ignore"):
        w = _solve(A, b[..., None])[..., 0]
    react = reactions(M, geo, sts, layout, w)
    Rp, p = platform_pose(c)
    T = passive_twists(M, geo, p)
    with np.errstate(all="ignore"):
        kg, kl = conditioning(M, T)
    singular = ~((kg <= M.singular_cond) & (kl <= M.singular_cond))
    Emat = error_matrix(M, T)
    with np.errstate(all="ignore"):
        H = unit_responses(M, geo, p, Emat)
    # per joint geometry lookup and loads
    jgeo, jload = {}, {}
    for (g, col, B), (f, m) in zip(layout, react):
        jgeo[id(g["J"])] = g
        jload[id(g["J"])] = (f, m)
    floor = M.indet_frac * M.W
    G = {}
    for gr in M.groups:
        jgd = jgeo[id(gr.joint)]
        f, m = jload[id(gr.joint)]
        load, margin, disp = take_up(M, gr, jgd, f, m)
        Hj = H[:, M.jresp[id(gr.joint)]]
        U = _set_basis(gr, jgd, N)
        with np.errstate(all="ignore"):
            env = group_envelope(gr, Hj, U) if gr.mag != 0.0 else np.zeros((N, 8))
            unit = rm._spectral(((Hj[:, 3:6, 3:6] if gr.rot else Hj[:, 3:6, 0:3]) @ U))
        moves = unit >= IMMOBILE
        indet = (gr.mag != 0.0) & moves & ~(margin > floor)
        contrib = np.einsum("nak,nk->na", Hj[:, :, 3:6] if gr.rot else Hj[:, :, 0:3], disp)
        G[gr.name] = {"load": load, "margin": margin, "disp": disp, "env": env, "unit": unit,
                      "moves": moves, "indet": indet, "contrib": contrib, "group": gr}
    # per-kind errors: the assembled system with each kind's clearance twists
    nl = len(M.limbs)
    K = len(M.kinds)
    Z = np.zeros((N, 6 * nl, max(K, 1)))
    for gr in M.groups:
        ki = M.kinds.index(gr.kind)
        i = gr.limb.number - 1
        d = G[gr.name]["disp"]
        if gr.rot:
            Z[:, 6 * i:6 * i + 3, ki] += d
            Z[:, 6 * i + 3:6 * i + 6, ki] += _cx(d, p - jgeo[id(gr.joint)]["c"])
        else:
            Z[:, 6 * i + 3:6 * i + 6, ki] += d
    with np.errstate(all="ignore"):
        sol = _solve(Emat, Z)                                    # (N,6+nf,K) [da; dp; dq]
    per = sol[:, 0:6, 0:K]                                                   # (N,6,K) [da; dp]
    # The size of each kind's whole solution in metres: the platform's [da; dp] and the
    # passive motions dq that go with it (rotations times Lchar), which are of the
    # take-up's size even where they cancel it and the error is zero.
    rot = np.concatenate([np.linalg.norm(t[0, 0:3, :], axis=0) > 0 for t in T]) if T else np.zeros(0, bool)
    scale = np.concatenate([np.full(3, M.Lchar), np.ones(3), np.where(rot, M.Lchar, 1.0)])
    with np.errstate(all="ignore"):
        sol_len = np.abs(sol * scale[None, :, None]).max(axis=1)             # (N,K)
    return {"c_in": c_in, "st": st, "sts": sts, "conv": conv, "reach": reach, "c": c, "geo": geo, "rt": rt,
            "A": A, "b": b, "w": w, "layout": layout, "react": react, "jload": jload, "jgeo": jgeo,
            "T": T, "Emat": Emat, "H": H, "kappa_g": kg, "kappa_limb": kl, "singular": singular,
            "groups": G, "per": per, "p": p, "R": Rp, "sol_len": sol_len}


def column_names(M, columns="full"):
    names = ["mode", "sample", "t", "status", "dominant"] + list(COORDS)
    names += [f"q{J.act}" for J in M.actuators] + [f"tau{J.act}" for J in M.actuators]
    names += [f"err_{c}" for c in COMPONENTS]
    names += [f"err_{k}_{c}" for k in M.kinds for c in COMPONENTS]
    names += [f"env_{c}" for c in ENV_COMPONENTS]
    names += [f"env_{k}_{c}" for k in M.kinds for c in ENV_COMPONENTS]
    names += [f"margin_{g.name}" for g in sorted(M.groups, key=lambda g: (g.limb.number, g.joint.place,
                                                                          GROUP_RANK[g.group]))]
    if columns == "full":
        for L in M.limbs:
            for J in L.joints:
                names += [f"f_{J.name}{L.number}_{a}" for a in "xyz"]
                names += [f"m_{J.name}{L.number}_{a}" for a in "xyz"]
    if M.exact:
        names += [f"exact_err_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
    return names


def _rows(M, res, mode, t, sample0, extras=False):
    N = res["c"].shape[0]
    reach, singular = res["reach"], res["singular"]
    G = res["groups"]
    indet_kind = {k: np.zeros(N, bool) for k in M.kinds}
    for gd in G.values():
        indet_kind[gd["group"].kind] |= gd["indet"]
    any_indet = np.zeros(N, bool)
    for k in M.kinds:
        any_indet |= indet_kind[k]
    status = np.where(~reach, "unreachable", np.where(singular, "near_singular",
                      np.where(any_indet, "indeterminate_contact", "ok")))
    ok = status == "ok"
    full = ok | (status == "indeterminate_contact")
    qrow = reach & (singular | full)
    nan = np.nan
    cols = {"mode": np.full(N, mode, dtype=object),
            "sample": np.arange(sample0, sample0 + N, dtype=np.uint64),
            "t": np.asarray(t, float), "status": status.astype(object)}
    c = res["st"]["c"]
    conv = res["conv"]
    for i, name in enumerate(COORDS):
        cols[name] = res["c_in"][:, i] if i in M.inputs else np.where(conv, c[:, i], nan)
    qv = joint_values(M, res["st"])
    for k, J in enumerate(M.actuators):
        cols[f"q{J.act}"] = np.where(qrow, qv[:, k], nan)
        f, m = res["jload"][id(J)]
        ax = res["jgeo"][id(J)]["a"]
        tau = np.einsum("na,na->n", m if J.type == "R" else f, ax)
        cols[f"tau{J.act}"] = np.where(full, tau, nan)
    per = res["per"]                                                        # (N,6,K)
    psi, theta = res["c"][:, 4], res["c"][:, 5]
    K = len(M.kinds)
    if K:
        eul = rm.euler_errors(psi, theta, per[:, 0:3, :])
        per9 = np.concatenate([per[:, 3:6], per[:, 0:3], eul], 1)           # COMPONENTS order
    else:
        per9 = np.zeros((N, 9, 0))
    tot = per9.sum(-1)
    for ci, comp in enumerate(COMPONENTS):
        cols[f"err_{comp}"] = np.where(ok, tot[:, ci], nan)
        for ki, k in enumerate(M.kinds):
            cols[f"err_{k}_{comp}"] = np.where(full & ~indet_kind[k], per9[:, ci, ki], nan)
    envk = {k: np.zeros((N, 8)) for k in M.kinds}
    for gd in G.values():
        envk[gd["group"].kind] += gd["env"]
    envt = np.zeros((N, 8))
    for k in M.kinds:
        envt += envk[k]
        for ci, comp in enumerate(ENV_COMPONENTS):
            cols[f"env_{k}_{comp}"] = np.where(full, envk[k][:, ci], nan)
    for ci, comp in enumerate(ENV_COMPONENTS):
        cols[f"env_{comp}"] = np.where(full, envt[:, ci], nan)
    for name, gd in G.items():
        cols[f"margin_{name}"] = np.where(full, gd["margin"], nan)
    # dominant
    dom = np.full(N, None, dtype=object)
    cands = [gd for gd in G.values() if gd["group"].mag != 0.0]
    cands.sort(key=lambda gd: gd["group"].order)
    if cands:
        dp = np.stack([np.where(gd["moves"], np.linalg.norm(gd["contrib"][:, 3:6], axis=-1), -np.inf)
                       for gd in cands], -1)
        anym = np.isfinite(dp).any(-1)
        with np.errstate(all="ignore"):
            idx = rm.first_within_tie(dp)
        names = np.array([gd["group"].name for gd in cands], dtype=object)
        sel = ok & anym
        dom[sel] = names[idx[sel]]
    cols["dominant"] = dom
    for (g, col, B), (f, m) in zip(res["layout"], res["react"]):
        J = g["J"]
        for a_i, a in enumerate("xyz"):
            cols[f"f_{J.name}{J.limb.number}_{a}"] = np.where(full, f[:, a_i], nan)
            cols[f"m_{J.name}{J.limb.number}_{a}"] = np.where(full, m[:, a_i], nan)
    if extras:
        cols["kappa_g"] = np.where(reach, res["kappa_g"], nan)
        cols["kappa_limb"] = np.where(reach, res["kappa_limb"], nan)
        for name, gd in G.items():
            cols[f"dp_{name}"] = np.where(ok, np.linalg.norm(gd["contrib"][:, 3:6], axis=-1), nan)
        with np.errstate(all="ignore"):
            kappa_e = np.linalg.cond(res["Emat"])
        cols["kappa_e"] = np.where(full, kappa_e, nan)
        for ki, k in enumerate(M.kinds):
            cols[f"sol_len_{k}"] = np.where(full, res["sol_len"][:, ki], nan)
    if M.exact:
        ex = np.full((N, 6), nan)
        if np.any(ok):
            sel = np.flatnonzero(ok)
            play = {}
            for gd in G.values():
                gr = gd["group"]
                r, u = play.get(id(gr.joint), (np.zeros((sel.size, 3)), np.zeros((sel.size, 3))))
                # A vector load at or below the floor on an ok row belongs to a group that
                # cannot move P: its direction is round-off, so it is not displaced here
                # (its second-order effect would be noise); a scalar one is along +axis.
                live = (gr.scalar or gd["margin"][sel] > M.indet_frac * M.W)
                live = np.broadcast_to(np.asarray(live)[..., None] if np.ndim(live) else live, (sel.size, 1))
                if gr.rot:
                    r = r + np.where(live, gd["disp"][sel], 0.0)
                else:
                    u = u + np.where(live, gd["disp"][sel], 0.0)
                play[id(gr.joint)] = (r, u)
            geo_s = [[{k: (v[sel] if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == N else v)
                       for k, v in g.items()} for g in jg] for jg in res["geo"]]
            ex_ok, _ = exact_errors(M, geo_s, res["p"][sel], play)
            lin = tot[sel][:, [3, 4, 5, 0, 1, 2]]
            size = np.maximum(np.abs(lin).max(-1, keepdims=True), M.branch_floor)
            with np.errstate(invalid="ignore"):
                same = np.all(np.abs(ex_ok - lin) <= size, axis=-1)
            ex_ok[~same] = nan
            ex[sel] = ex_ok
        for ci, comp in enumerate(("rx", "ry", "rz", "x", "y", "z")):
            cols[f"exact_err_{comp}"] = ex[:, ci]
    return cols


def extra_column_names(M):
    """Reference-only columns of compute(..., extras=True): kappa_g, kappa_limb (the
    near_singular measures of CHOICES 7, reachable rows), dp_<group> (|dp| of each
    group's own take-up, ok rows: judges near ties of `dominant`), and for the
    round-off of the error system (ok and indeterminate rows): kappa_e, its 2-norm
    condition number, and sol_len_<kind>, the largest entry of that kind's solution
    [da; dp; dq] in metres (rotations times Lchar)."""
    return (["kappa_g", "kappa_limb"] + [f"dp_{g.name}" for g in M.groups] + ["kappa_e"]
            + [f"sol_len_{k}" for k in M.kinds])


def compute(job, columns="full", chunk=512, extras=False) -> dict:
    """All `poses` rows of a custom job (variant 0): dict column -> array, modes
    concatenated in the job's order; NaN / None where the engine writes null.
    extras=True appends extra_column_names(M)."""
    M = job if isinstance(job, Mech) else normalize_job(job)
    smp = sample_inputs(M)
    n = smp["c"].shape[0]
    parts = {m: [] for m in M.modes}
    for s0 in range(0, n, chunk):
        sl = slice(s0, min(n, s0 + chunk))
        for mode in M.modes:
            dyn = mode == "dynamic"
            res = evaluate(M, smp["c"][sl], mode, smp["cd"][sl] if dyn else None,
                           smp["cdd"][sl] if dyn else None)
            parts[mode].append(_rows(M, res, mode, smp["t"][sl], s0, extras))
    names = column_names(M, columns) + (extra_column_names(M) if extras else [])
    return {name: np.concatenate([p[name] for m in M.modes for p in parts[m]]) for name in names}


def group_loads(M, c_in, mode="kinetostatic", cd=None, cdd=None):
    """Deciding loads at explicit poses (discontinuity checks): {group name: dict(load,
    margin, disp, moves, contrib (N,6) [da; dp] of the group's own take-up, group)} plus
    'reach', 'singular' and 'floor'."""
    res = evaluate(M, c_in, mode, cd, cdd)
    out = dict(res["groups"])
    out["reach"], out["singular"] = res["reach"], res["singular"]
    out["floor"] = M.indet_frac * M.W
    return out


# --------------------------------------------------------------------------
# the presets as descriptions (12.9)
# --------------------------------------------------------------------------
def preset_description(job: dict, home_inputs=None) -> dict:
    """The custom job equivalent to a built-in 3-PRS / 3-RPS / 6-UPS job (docs/model.md 12.9).

    home_inputs: the built-in's inputs at which the joints are given (3-limb kinds:
    (z, psi, theta), default (a mid-height level pose); 6-UPS: the six coordinates,
    default level at mid-stroke).  Everything but [mechanism] and [mass] is copied;
    the clearance keys keep their names (joints named p/r/s, r/p/s, u/p/s)."""
    import reference_ups as ru
    kind = job.get("mechanism", {}).get("kind", "3-PRS")
    out = {k: copy.deepcopy(v) for k, v in job.items() if k not in ("mechanism", "mass")}
    if kind == ru.KIND:
        P = ru.normalize_job(job)
        if home_inputs is None:
            home_inputs = (0.0, 0.0, P["z_sub"], 0.0, 0.0, 0.0)
        hv = [np.array([float(v)]) for v in home_inputs]
        kin = ru.kinematics(P, *hv)
        A, B, e = kin["A"][0], kin["B"][0], kin["e"][0]
        q = kin["q"][0]
        limbs = []
        for i in range(6):
            a1 = P["a1"][i]
            a2 = _cx(a1, e[i])
            a2 /= np.linalg.norm(a2)
            lc, lp = P["lc"], P["lp"]
            mc, mpi = P["m_cyl"], P["m_pis"]
            Ic = mc * lc ** 2 / 12.0 * (I3 - np.outer(e[i], e[i]))
            Ip = mpi * lp ** 2 / 12.0 * (I3 - np.outer(e[i], e[i]))
            joints = [
                {"type": "U", "name": "u", "at": list(B[i]), "axes": [list(a1), list(a2)]},
                {"type": "P", "name": "p", "at": list(B[i] + lc * e[i]), "axis": list(e[i]),
                 "actuated": True, "range": [P["qmin"] - q[i], P["qmax"] - q[i]]},
                {"type": "S", "name": "s", "at": list(A[i])},
            ]
            bodies = [{"mass": mc, "com": list(B[i] + 0.5 * lc * e[i]), "inertia": Ic.tolist()},
                      {"mass": mpi, "com": list(A[i] - 0.5 * lp * e[i]), "inertia": Ip.tolist()}]
            limbs.append({"joints": joints, "bodies": bodies})
        mech = {"kind": "custom", "inputs": list(COORDS),
                "home": [float(v) for v in home_inputs], "limb": limbs,
                "gravity": [float(v) for v in P["g"]]}
        rp = float(P["job"]["mechanism"]["platform_radius"])
        mp = P["m_plat"]
        mass = {"platform": mp, "points": copy.deepcopy(P["job"]["mass"]["points"]),
                "platform_inertia": list(P["job"]["mass"].get(
                    "platform_inertia", [mp * rp ** 2 / 4, mp * rp ** 2 / 4, mp * rp ** 2 / 2]))}
        out["mechanism"], out["mass"] = mech, mass
        return out
    P = rm.normalize_job(job)
    if home_inputs is None:
        home_inputs = ((2.0 if kind == "3-PRS" else 1.0) * P["size"], 0.0, 0.0)
    z0, ps0, th0 = (np.array([float(v)]) for v in home_inputs)
    kin = rm.kinematics(P, z0, ps0, th0)
    if not kin["reach"][0]:
        raise ValueError("preset_description: the home pose is unreachable")
    A, B, e = kin["A"][0], kin["B"][0], kin["e"][0]
    home = [float(kin["x"][0]), float(kin["y"][0]), float(z0[0]), float(kin["phi"][0]),
            float(ps0[0]), float(th0[0])]
    limbs = []
    for j in range(3):
        yj = P["YJ"][j]
        if kind == "3-PRS":
            joints = [
                {"type": "P", "name": "p", "at": list(B[j]), "axis": list(P["DJ"][j]), "actuated": True},
                {"type": "R", "name": "r", "at": list(B[j]), "axis": list(yj)},
                {"type": "S", "name": "s", "at": list(A[j])},
            ]
            bodies = [{"mass": 0.0}, {"mass": P["m_leg"]}]
        else:
            q = float(kin["q"][0, j])
            lc, lp = P["lc"], P["lp"]
            mc, mpi = P["m_cyl"], P["m_pis"]
            joints = [
                {"type": "R", "name": "r", "at": list(B[j]), "axis": list(yj)},
                {"type": "P", "name": "p", "at": list(B[j] + lc * e[j]), "axis": list(e[j]),
                 "actuated": True, "range": [P["qmin"] - q, P["qmax"] - q]},
                {"type": "S", "name": "s", "at": list(A[j])},
            ]
            bodies = [{"mass": mc, "com": list(B[j] + 0.5 * lc * e[j]),
                       "inertia": (mc * lc ** 2 / 12.0 * (I3 - np.outer(e[j], e[j]))).tolist()},
                      {"mass": mpi, "com": list(A[j] - 0.5 * lp * e[j]),
                       "inertia": (mpi * lp ** 2 / 12.0 * (I3 - np.outer(e[j], e[j]))).tolist()}]
        limbs.append({"joints": joints, "bodies": bodies})
    mech = {"kind": "custom", "inputs": ["z", "psi", "theta"], "home": home, "limb": limbs,
            "gravity": [float(v) for v in P["g"]]}
    mj = P["job"]["mass"]
    mass = {"platform": P["m_plat"], "points": copy.deepcopy(mj["points"])}
    if "platform_inertia" in mj:
        mass["platform_inertia"] = list(mj["platform_inertia"])
    else:
        rp, mp = P["rp"], P["m_plat"]
        mass["platform_inertia"] = [mp * rp ** 2 / 4, mp * rp ** 2 / 4, mp * rp ** 2 / 2]
    out["mechanism"], out["mass"] = mech, mass
    return out


def main(argv=None):
    import argparse
    import tomllib
    ap = argparse.ArgumentParser(description="custom-mechanism NumPy reference")
    ap.add_argument("job", help="a job file with [mechanism] kind = \"custom\"")
    args = ap.parse_args(argv)
    with open(args.job, "rb") as fh:
        job = tomllib.load(fh)
    try:
        M = check_description(job)
    except ValueError as exc:
        print(f"{args.job}: {exc}", file=sys.stderr)
        return 2
    cols = compute(M)
    st, cnt = np.unique(cols["status"].astype(str), return_counts=True)
    print(f"{cols['sample'].size} rows; statuses " + ", ".join(f"{a}={b}" for a, b in zip(st, cnt)))
    for c in ("err_x", "err_y", "err_z", "err_rx", "err_ry", "err_rz", "env_p"):
        v = cols[c][np.isfinite(cols[c])]
        if v.size:
            print(f"  {c:8s} min {v.min(): .3e}  max {v.max(): .3e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
