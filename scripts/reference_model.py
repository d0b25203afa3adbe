"""Independent, vectorised NumPy reference of the clearance pose pipeline.

Follows docs/model.md (physics, including the mechanism family of its section 10),
docs/interface.md (job keys and `poses` column names) and docs/conventions.md
(sampling, status, nulls, condition numbers).  Written without looking at the
Rust engine.

Mechanism kinds (``[mechanism] kind``):

* ``"3-PRS"`` (the default): sliders on rails ``d_j = cos(beta) z + sin(beta) x_j``
  (``rail_angle_deg``, default 0 = the paper's vertical rails), limbs at
  ``limb_angles_deg`` (default 0/120/240), platform vertices at
  ``platform_angles_deg`` (default: the limb angles), rigid legs of length L.
  The paper's prototype is this kind with every default.
* ``"3-RPS"``: revolute joints fixed at ``B_j = R_b x_j``, actuated legs of a
  cylinder and a piston (two slender rods), leg length ``q_j = |A_j - B_j|``
  within ``[min_length, max_length]``.

The parasitic motions (X, Y, Phi) come from the closed forms of docs/model.md
section 2 for the symmetric layout (limbs exactly at 0/120/240 deg, platform
vertices at the same angles), otherwise from Newton on the three plane
constraints ``A_j . y_j = 0`` started at the closed forms (to 1e-14, at most
50 iterations; no convergence -> ``unreachable``).

Everything is batched over poses: arrays have a leading sample axis N; the
24x24 equilibrium systems, the 12x12 loop-closure systems and the 9x9 Newton
steps of the exact mode are solved as stacks with ``np.linalg.solve``.

Time derivatives (dynamic mode) use forward-mode automatic differentiation
with second-order Taylor jets (:class:`Jet`): every kinematic quantity carries
its value, first and second time derivative, propagated exactly (round-off
only) from the analytic derivatives of the harmonic inputs.  Where the
parasitic motions are solved by Newton their rates come from implicit
differentiation: two chord iterations in jet arithmetic with the Jacobian of
the converged solution (each fixes one more derivative order exactly).

Usage::

    import tomllib, reference_model as rm
    job = tomllib.load(open("job.toml", "rb"))
    cols = rm.compute(job)          # dict: column name -> np.ndarray
    cols["err_x"], cols["status"], cols["mode"], cols["sample"]

NaN marks the cells the engine writes as null (string columns use None).
Importing this module has no side effects.

Worst-case envelope and dominant joint (docs/model.md section 11): the
``standard`` and ``full`` sets carry ``env_<c>`` and ``env_<kind>_<c>`` (c = x, y,
z, rx, ry, rz, p, alpha) and ``dominant``.  They are derived from this module's
own 12x12 loop system, not from the spec's 6x6 N-columns: :func:`joint_maps`
solves it for unit take-ups of one joint at a time (its linear map, six
columns per limb), and :func:`joint_envelopes` maximises over each joint's
admissible set (ball, disc normal to y_j, segment along y_j, rotation disc
normal to y_j) in closed form through an orthonormal basis of the set.
:func:`envelope_summary` gives the summary quantities (env_p_max, env_p_p95,
dominant_share_*, rms_dp_*), the p95 by :func:`hist_quantile`, the engine's
histogram quantile.  ``compute(job, extras=True)`` adds reference-only
per-joint columns (``dp_joint_<joint>``, ``joint_<joint>_<c>``).
"""

from __future__ import annotations

import copy
import math

import numpy as np

__all__ = [
    "Jet", "KINDS", "COMPONENTS", "DEFAULTS", "DEFAULTS_RPS", "MECHANISMS", "normalize_job",
    "sample_inputs", "parasitic", "parasitic_newton", "plane_residual", "kinematics",
    "equilibrium_system", "take_up", "loop_system", "euler_errors", "exact_errors",
    "exp_minus_identity", "same_branch", "compute", "column_names", "kappa1",
    "ENV_COMPONENTS", "JOINTS", "JOINT_NAMES", "joint_name", "env_column_names", "joint_maps",
    "admissible_bases", "joint_envelopes", "joint_contributions", "dominant_joint",
    "hist_quantile", "nearest_rank", "envelope_summary", "extra_column_names",
]

KINDS = ("s_radial", "r_radial", "r_axial", "r_angular")
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz", "phi", "psi", "theta")

ALPHA = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
XJ = np.stack([np.cos(ALPHA), np.sin(ALPHA), np.zeros(3)], axis=-1)   # (3 limbs, xyz)
YJ = np.stack([-np.sin(ALPHA), np.cos(ALPHA), np.zeros(3)], axis=-1)
EZ = np.array([0.0, 0.0, 1.0])
I3 = np.eye(3)
EPS = np.finfo(float).eps

MECHANISMS = ("3-PRS", "3-RPS")
# Parasitic-motion Newton (docs/model.md section 10.1): step tolerance, iteration cap.
NEWTON_TOL = 1e-14
NEWTON_MAX_ITER = 50
# A 3-PRS leg lies across its rail when sqrt(radicand) = L (e_j . d_j) < ACROSS_RAIL * L.
ACROSS_RAIL = 1e-6

# Defaults of the default kind, 3-PRS = the paper's prototype.
DEFAULTS = {
    "mechanism": {"base_radius": 0.18, "platform_radius": 0.36, "leg_length": 1.0,
                  "gravity": [0.0, 0.0, -9.81]},
    "mass": {"platform": 9.8, "leg": 3.0, "points": []},
    "load": {"force": [0.0, 0.0, 0.0], "moment": [0.0, 0.0, 0.0], "at": [0.0, 0.0, 0.0]},
    # The paper gives no clearance values; a missing clearance is rigid (0).
    "clearance": {"s_radial": 0.0, "r_radial": 0.0, "r_axial": 0.0, "r_angular": 0.0},
    "analysis": {"modes": ["kinetostatic"], "exact": False,
                 "discontinuity_load_fraction": 0.05, "singular_cond": 1e8,
                 "indeterminate_load_fraction": 1e-9},
}
# 3-RPS: the sections that differ from DEFAULTS (min/max_length default from the lengths).
DEFAULTS_RPS = {
    "mechanism": {"base_radius": 0.3, "platform_radius": 0.2, "gravity": [0.0, 0.0, -9.81],
                  "cylinder_length": 0.8, "piston_length": 0.8},
    "mass": {"platform": 9.8, "cylinder": 2.0, "piston": 1.0, "points": []},
}
# Keys each kind accepts; a key of the other kind is an error (docs/interface.md).
KIND_KEYS = {
    "3-PRS": {"mechanism": {"kind", "base_radius", "platform_radius", "leg_length", "gravity",
                            "rail_angle_deg", "limb_angles_deg", "platform_angles_deg"},
              "mass": {"platform", "leg", "platform_inertia", "points"}},
    "3-RPS": {"mechanism": {"kind", "base_radius", "platform_radius", "gravity",
                            "limb_angles_deg", "platform_angles_deg", "cylinder_length",
                            "piston_length", "min_length", "max_length"},
              "mass": {"platform", "cylinder", "piston", "platform_inertia", "points"}},
}


# --------------------------------------------------------------------------
# Second-order forward-mode AD: value, d/dt, d2/dt2
# --------------------------------------------------------------------------
class Jet:
    """Truncated Taylor jet (v, v', v'') of an array-valued function of time."""

    __slots__ = ("v", "d", "dd")
    __array_priority__ = 1000.0

    def __init__(self, v, d=None, dd=None):
        self.v = np.asarray(v, dtype=float)
        self.d = np.zeros_like(self.v) if d is None else np.asarray(d, dtype=float)
        self.dd = np.zeros_like(self.v) if dd is None else np.asarray(dd, dtype=float)

    # bilinear operations: (ab)' = a'b + ab', (ab)'' = a''b + 2a'b' + ab''
    @staticmethod
    def _bilinear(f, a, b):
        if not isinstance(a, Jet):
            return Jet(f(a, b.v), f(a, b.d), f(a, b.dd))
        if not isinstance(b, Jet):
            return Jet(f(a.v, b), f(a.d, b), f(a.dd, b))
        return Jet(f(a.v, b.v), f(a.d, b.v) + f(a.v, b.d),
                   f(a.dd, b.v) + 2.0 * f(a.d, b.d) + f(a.v, b.dd))

    def __add__(self, o):
        if isinstance(o, Jet):
            return Jet(self.v + o.v, self.d + o.d, self.dd + o.dd)
        v = self.v + o
        return Jet(v, np.broadcast_to(self.d, v.shape), np.broadcast_to(self.dd, v.shape))

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.v, -self.d, -self.dd)

    def __sub__(self, o):
        return self + (-o)

    def __rsub__(self, o):
        return (-self) + o

    def __mul__(self, o):
        return Jet._bilinear(np.multiply, self, o)

    def __rmul__(self, o):
        return Jet._bilinear(np.multiply, o, self)

    def __matmul__(self, o):
        return Jet._bilinear(np.matmul, self, o)

    def __rmatmul__(self, o):
        return Jet._bilinear(np.matmul, o, self)

    def __truediv__(self, o):
        if isinstance(o, Jet):
            return self * _chain(o, 1.0 / o.v, -1.0 / o.v ** 2, 2.0 / o.v ** 3)
        return Jet(self.v / o, self.d / o, self.dd / o)

    def __rtruediv__(self, o):
        return o * _chain(self, 1.0 / self.v, -1.0 / self.v ** 2, 2.0 / self.v ** 3)

    def __getitem__(self, idx):
        return Jet(self.v[idx], self.d[idx], self.dd[idx])

    def sum(self, axis):
        return Jet(self.v.sum(axis), self.d.sum(axis), self.dd.sum(axis))

    def swapaxes(self, a, b):
        return Jet(self.v.swapaxes(a, b), self.d.swapaxes(a, b), self.dd.swapaxes(a, b))

    def expand(self, axis):
        return Jet(np.expand_dims(self.v, axis), np.expand_dims(self.d, axis),
                   np.expand_dims(self.dd, axis))


def _chain(x: Jet, f0, f1, f2) -> Jet:
    """g(x) with g, g', g'' evaluated at x.v."""
    return Jet(f0, f1 * x.d, f2 * x.d ** 2 + f1 * x.dd)


def _val(x):
    return x.v if isinstance(x, Jet) else x


def jsin(x):
    if isinstance(x, Jet):
        s, c = np.sin(x.v), np.cos(x.v)
        return _chain(x, s, c, -s)
    return np.sin(x)


def jcos(x):
    if isinstance(x, Jet):
        s, c = np.sin(x.v), np.cos(x.v)
        return _chain(x, c, -s, -c)
    return np.cos(x)


def jsqrt(x):
    if isinstance(x, Jet):
        r = np.sqrt(x.v)
        return _chain(x, r, 0.5 / r, -0.25 / (r * x.v))
    return np.sqrt(x)


def jatan2(y, x):
    if not (isinstance(y, Jet) or isinstance(x, Jet)):
        return np.arctan2(y, x)
    y = y if isinstance(y, Jet) else Jet(y)
    x = x if isinstance(x, Jet) else Jet(x)
    den = x.v ** 2 + y.v ** 2
    num = x.v * y.d - y.v * x.d
    num_d = x.v * y.dd - y.v * x.dd
    den_d = 2.0 * (x.v * x.d + y.v * y.d)
    return Jet(np.arctan2(y.v, x.v), num / den, (num_d * den - num * den_d) / den ** 2)


def jstack(items, axis):
    if not any(isinstance(i, Jet) for i in items):
        return np.stack(np.broadcast_arrays(*items), axis=axis)
    shape = np.broadcast_shapes(*[np.shape(_val(i)) for i in items])
    vs, ds, dds = [], [], []
    for i in items:
        if isinstance(i, Jet):
            vs.append(np.broadcast_to(i.v, shape)); ds.append(np.broadcast_to(i.d, shape))
            dds.append(np.broadcast_to(i.dd, shape))
        else:
            vs.append(np.broadcast_to(np.asarray(i, float), shape))
            ds.append(np.zeros(shape)); dds.append(np.zeros(shape))
    return Jet(np.stack(vs, axis), np.stack(ds, axis), np.stack(dds, axis))


def jcross(a, b):
    if isinstance(a, Jet) or isinstance(b, Jet):
        return Jet._bilinear(np.cross, a, b)
    return np.cross(a, b)


# --------------------------------------------------------------------------
# Small linear-algebra helpers
# --------------------------------------------------------------------------
def skew(r):
    """skew(r) @ f == r x f; r (...,3) -> (...,3,3)."""
    z = np.zeros(r.shape[:-1])
    return np.stack([np.stack([z, -r[..., 2], r[..., 1]], -1),
                     np.stack([r[..., 2], z, -r[..., 0]], -1),
                     np.stack([-r[..., 1], r[..., 0], z], -1)], -2)


def vee(S):
    """Axial vector of the skew part of S (...,3,3)."""
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0],
                           S[..., 1, 0] - S[..., 0, 1]], -1)


def norm1(M):
    """Matrix 1-norm (max column abs sum) of a stack (...,n,n)."""
    return np.abs(M).sum(axis=-2).max(axis=-1)


def _inv_stack(M):
    """Batched inverse; exactly singular members get +inf."""
    try:
        return np.linalg.inv(M)
    except np.linalg.LinAlgError:
        out = np.empty_like(M)
        for k in range(M.shape[0]):   # rare fallback only
            try:
                out[k] = np.linalg.inv(M[k])
            except np.linalg.LinAlgError:
                out[k] = np.inf
        return out


def kappa1(M):
    """Exact 1-norm condition number ||M||_1 * ||M^-1||_1 of a stack."""
    with np.errstate(all="ignore"):
        return norm1(M) * norm1(_inv_stack(M))


def reduced_matrices(p, A, e, yj=None):
    """The 6x6 reductions that docs/conventions.md uses to judge conditioning.

    G (equilibrium, legs eliminated): columns [f; r_j x f] for f = e_j, y_j;
    M (error, reciprocal screws):     rows    [(r_j x f)^T, f^T] for the same forces,
    with r_j = A_j - P.  Written from the convention's text, not from the engine.
    yj: the limbs' y_j (3,3), default the prototype's."""
    YJ_ = YJ if yj is None else yj
    N = p.shape[0]
    G = np.zeros((N, 6, 6))
    M = np.zeros((N, 6, 6))
    for j in range(3):
        r = A[:, j] - p
        for c, f in enumerate((e[:, j], np.broadcast_to(YJ_[j], (N, 3)))):
            k = 2 * j + c
            mom = np.cross(r, f)
            G[:, 0:3, k], G[:, 3:6, k] = f, mom
            M[:, k, 0:3], M[:, k, 3:6] = mom, f
    return G, M


def _solve_stack(M, rhs):
    try:
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        out = np.full(rhs.shape, np.nan)
        for k in range(M.shape[0]):   # rare fallback only
            try:
                out[k] = np.linalg.solve(M[k], rhs[k])
            except np.linalg.LinAlgError:
                pass
        return out


def rot_exp(v):
    """Rodrigues: rotation matrices exp([v]x) for v (...,3), accurate for tiny |v|."""
    th = np.linalg.norm(v, axis=-1)
    small = th < 1e-4
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th ** 2 / 6.0 + th ** 4 / 120.0, np.sin(ths) / ths)
    b = np.where(small, 0.5 - th ** 2 / 24.0 + th ** 4 / 720.0,
                 2.0 * np.sin(0.5 * ths) ** 2 / ths ** 2)
    K = skew(v)
    return I3 + a[..., None, None] * K + b[..., None, None] * (K @ K)


def rot_log(Rm):
    """Rotation vector of R (...,3,3) (angle < pi), accurate for tiny angles."""
    s_vec = vee(Rm)                                  # sin(th) * axis
    s = np.linalg.norm(s_vec, axis=-1)
    c = 0.5 * (np.trace(Rm, axis1=-2, axis2=-1) - 1.0)
    th = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(s > 1e-300, th / np.where(s > 1e-300, s, 1.0), 1.0)
    return f[..., None] * s_vec


# --------------------------------------------------------------------------
# Job handling and sampling
# --------------------------------------------------------------------------
def _merge(base, over):
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _angles(deg, name):
    """Limb or platform angles in radians: the prototype's exact 0, 2 pi/3, 4 pi/3
    when the list is exactly [0, 120, 240] deg, deg * pi / 180 otherwise."""
    vals = [float(d) for d in deg]
    if len(vals) != 3:
        raise ValueError(f"mechanism.{name}: three angles expected, got {len(vals)}")
    if vals == [0.0, 120.0, 240.0]:
        return ALPHA.copy(), vals
    return np.array([d * math.pi / 180.0 for d in vals]), vals


def normalize_job(job: dict) -> dict:
    """Job dict (from tomllib) with defaults filled in and derived quantities."""
    kind = job.get("mechanism", {}).get("kind", "3-PRS")
    if kind not in MECHANISMS:
        raise ValueError(f"mechanism.kind: unknown kind {kind!r}")
    for sec in ("mechanism", "mass"):
        bad = set(job.get(sec, {})) - KIND_KEYS[kind][sec]
        if bad:
            raise ValueError(f"{sec}: key(s) {sorted(bad)} not valid for kind {kind}")
    if kind == "3-PRS":
        j = _merge(DEFAULTS, job)
    else:
        base = {k: v for k, v in DEFAULTS.items() if k not in ("mechanism", "mass")}
        j = _merge(_merge(base, DEFAULTS_RPS), job)
    if ("grid" in j) == ("trajectory" in j):
        raise ValueError("exactly one of [grid] or [trajectory] is required")
    mech, mass, load = j["mechanism"], j["mass"], j["load"]
    P = {
        "kind": kind,
        "Rb": float(mech["base_radius"]), "rp": float(mech["platform_radius"]),
        "g": np.array(mech["gravity"], float),
        "m_plat": float(mass["platform"]),
        "f_ext": np.array(load["force"], float), "m_ext": np.array(load["moment"], float),
        "at_ext": np.array(load["at"], float),
        "clear": {k: float(j["clearance"][k]) for k in KINDS},
        "modes": list(j["analysis"]["modes"]), "exact": bool(j["analysis"]["exact"]),
        "singular_cond": float(j["analysis"]["singular_cond"]),
        "indet_frac": float(j["analysis"]["indeterminate_load_fraction"]),
        "trajectory": "trajectory" in j,
    }
    if not P["trajectory"] and "dynamic" in P["modes"]:
        raise ValueError("dynamic mode is only valid on trajectories")
    for m in P["modes"]:
        if m not in ("kinetostatic", "dynamic"):
            raise ValueError(f"unknown mode {m!r}")
    # layout: limb frames x_j, y_j and platform vertices a'_j
    alpha, a_deg = _angles(mech.get("limb_angles_deg", [0.0, 120.0, 240.0]), "limb_angles_deg")
    gamma, g_deg = _angles(mech.get("platform_angles_deg", a_deg), "platform_angles_deg")
    if a_deg == [0.0, 120.0, 240.0]:
        xj, yj = XJ, YJ
    else:
        xj = np.stack([np.cos(alpha), np.sin(alpha), np.zeros(3)], axis=-1)
        yj = np.stack([-np.sin(alpha), np.cos(alpha), np.zeros(3)], axis=-1)
    ux = XJ if g_deg == [0.0, 120.0, 240.0] else \
        np.stack([np.cos(gamma), np.sin(gamma), np.zeros(3)], axis=-1)
    P.update(XJ=xj, YJ=yj, AP=P["rp"] * ux, alpha=alpha, gamma=gamma,
             closed=(a_deg == [0.0, 120.0, 240.0] and g_deg == a_deg))
    if kind == "3-PRS":
        beta = float(mech.get("rail_angle_deg", 0.0)) * math.pi / 180.0
        cb, sb = math.cos(beta), math.sin(beta)
        P.update(L=float(mech["leg_length"]), m_leg=float(mass["leg"]), cb=cb, sb=sb,
                 DJ=cb * EZ + sb * xj)
        P["m_limb"] = P["m_leg"]
        P["size"] = P["L"]
    else:
        lc, lp = float(mech["cylinder_length"]), float(mech["piston_length"])
        P.update(lc=lc, lp=lp, m_cyl=float(mass["cylinder"]), m_pis=float(mass["piston"]),
                 qmin=float(mech.get("min_length", max(lc, lp))),
                 qmax=float(mech.get("max_length", lc + lp)))
        P["m_limb"] = P["m_cyl"] + P["m_pis"]
        P["size"] = 0.5 * (P["qmin"] + P["qmax"])     # the legs' typical length
    rp, mp = P["rp"], P["m_plat"]
    if "platform_inertia" in mass:
        I_own = np.diag(np.array(mass["platform_inertia"], float))
    else:
        I_own = np.diag([mp * rp ** 2 / 4.0, mp * rp ** 2 / 4.0, mp * rp ** 2 / 2.0])
    pm = np.array([float(pt["mass"]) for pt in mass["points"]], float)
    pa = np.array([pt["at"] for pt in mass["points"]], float).reshape(-1, 3)
    m_tot = mp + pm.sum()
    c_loc = (pm[:, None] * pa).sum(0) / m_tot            # platform's own CoM is at P
    I_P = I_own.copy()
    for mk, ak in zip(pm, pa):                            # parallel axis, about P
        I_P += mk * (ak @ ak * I3 - np.outer(ak, ak))
    I_C = I_P - m_tot * (c_loc @ c_loc * I3 - np.outer(c_loc, c_loc))
    P.update(m_body=m_tot, c_loc=c_loc, I_C_loc=I_C,
             W=(m_tot + 3.0 * P["m_limb"]) * float(np.linalg.norm(P["g"])))
    P["job"] = j
    return P


def _grid_axis(spec):
    if isinstance(spec, dict):
        start, stop, n = float(spec["start"]), float(spec["stop"]), int(spec["n"])
        if n == 1:
            return np.array([start])
        i = np.arange(n, dtype=float)
        return start + (stop - start) * i / (n - 1)
    return np.array([float(spec)])


def _harmonic(spec, t):
    """value, 1st and 2nd time derivative of offset + sum A sin(2 pi t / T + phase)."""
    if not isinstance(spec, dict):
        c = float(spec)
        return np.full_like(t, c), np.zeros_like(t), np.zeros_like(t)
    v = np.full_like(t, float(spec.get("offset", 0.0)))
    d = np.zeros_like(t)
    dd = np.zeros_like(t)
    for h in spec.get("harmonics", []):
        A, T, ph = float(h["amplitude"]), float(h["period"]), float(h.get("phase", 0.0))
        w = 2.0 * np.pi / T
        arg = 2.0 * np.pi * t / T + ph
        v = v + A * np.sin(arg)
        d = d + A * w * np.cos(arg)
        dd = dd - A * w * w * np.sin(arg)
    return v, d, dd


def sample_inputs(P_or_job) -> dict:
    """Samples of the job: dict with t (NaN on grids), z, psi, theta and, on
    trajectories, Jets zj, psij, thetaj carrying exact time derivatives."""
    P = P_or_job if "job" in P_or_job else normalize_job(P_or_job)
    j = P["job"]
    if "grid" in j:
        g = j["grid"]
        zs, ps, ts = _grid_axis(g.get("z", 0.0)), _grid_axis(g.get("psi", 0.0)), \
            _grid_axis(g.get("theta", 0.0))
        Z, PS, TH = np.meshgrid(zs, ps, ts, indexing="ij")     # row-major (z, psi, theta)
        n = Z.size
        return {"t": np.full(n, np.nan), "z": Z.ravel(), "psi": PS.ravel(),
                "theta": TH.ravel()}
    tr = j["trajectory"]
    t = _grid_axis(tr["time"])
    out = {"t": t}
    for key in ("z", "psi", "theta"):
        v, d, dd = _harmonic(tr.get(key, 0.0), t)
        out[key] = v
        out[key + "j"] = Jet(v, d, dd)
    return out


# --------------------------------------------------------------------------
# Nominal kinematics (docs/model.md sections 2 and 10)
# --------------------------------------------------------------------------
def parasitic(z, psi, theta, rp):
    """Closed forms: returns x, y, phi (works on arrays or Jets)."""
    sps, cps, sth, cth = jsin(psi), jcos(psi), jsin(theta), jcos(theta)
    phi = jatan2(sps * sth, cps + cth)
    sph, cph = jsin(phi), jcos(phi)
    y = -rp * cps * sph
    x = 0.5 * rp * (cth * cph - cph * cps + sps * sth * sph)
    return x, y, phi


def _rot(axis, c, s):
    one, zero = 1.0, 0.0
    if axis == "x":
        rows = [[one, zero, zero], [zero, c, -s], [zero, s, c]]
    elif axis == "y":
        rows = [[c, zero, s], [zero, one, zero], [-s, zero, c]]
    else:
        rows = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
    return jstack([jstack(r, -1) for r in rows], -2)


def _rotation(psi, theta, phi):
    """R = Ry(theta) Rx(psi) Rz(phi) (arrays or Jets)."""
    return (_rot("y", jcos(theta), jsin(theta)) @ _rot("x", jcos(psi), jsin(psi))) \
        @ _rot("z", jcos(phi), jsin(phi))


def plane_residual(P, x, y, phi, psi, theta):
    """F_j = A_j . y_j (j = 1..3) with A_j = p + R a'_j, p = (x, y, z): the plane
    constraints of the parasitic motions (z drops out, y_j being horizontal).
    Arrays (N,) or Jets -> (N, 3)."""
    YJ_, AP = P["YJ"], P["AP"]
    RA = (_rotation(psi, theta, phi) @ AP.T).swapaxes(-1, -2)           # R a'_j (N,3,3)
    xe = x.expand(-1) if isinstance(x, Jet) else x[..., None]
    ye = y.expand(-1) if isinstance(y, Jet) else y[..., None]
    return (RA * YJ_).sum(-1) + xe * YJ_[:, 0] + ye * YJ_[:, 1]


def _plane_jacobian(P, phi, psi, theta):
    """d F / d (x, y, phi), (N, 3, 3), at values."""
    YJ_, AP = P["YJ"], P["AP"]
    N = phi.shape[0]
    sph, cph = np.sin(phi), np.cos(phi)
    z0 = np.zeros(N)
    dRz = np.stack([np.stack([-sph, -cph, z0], -1), np.stack([cph, -sph, z0], -1),
                    np.stack([z0, z0, z0], -1)], -2)                  # d Rz / d phi
    RyRx = _rot("y", np.cos(theta), np.sin(theta)) @ _rot("x", np.cos(psi), np.sin(psi))
    dRA = (RyRx @ dRz @ AP.T).swapaxes(-1, -2)                           # (N,3,3)
    J = np.empty((N, 3, 3))
    J[:, :, 0] = YJ_[:, 0]
    J[:, :, 1] = YJ_[:, 1]
    J[:, :, 2] = (dRA * YJ_).sum(-1)
    return J


def parasitic_newton(P, z, psi, theta, max_iter=None, tol=None):
    """(x, y, phi, converged) solving A_j . y_j = 0 by Newton from the closed forms.

    A row has converged when its Newton step is at most `tol` (default NEWTON_TOL,
    m and rad, max over the three unknowns; converged rows are frozen); rows that
    have not after `max_iter` (default NEWTON_MAX_ITER) iterations get NaN and
    converged = False.

    With Jet inputs the rates follow by implicit differentiation of F(u(t), t) = 0:
    with J0 the Jacobian at the solution, u <- u - J0^-1 F(u, t) in jet arithmetic,
    twice from zero rates, the value held at the Newton solution.  The error of a
    chord iterate is J0^-1 (J0 - J(t)) times the previous one, and J(t) - J0 = O(t):
    the first iteration makes u' exact, the second u''."""
    max_iter = NEWTON_MAX_ITER if max_iter is None else max_iter
    tol = NEWTON_TOL if tol is None else tol
    zv, psv, thv = _val(z), _val(psi), _val(theta)
    x0, y0, f0 = parasitic(zv, psv, thv, P["rp"])
    u = np.stack([x0, y0, f0], -1)
    N = u.shape[0]
    active = np.ones(N, bool)
    conv = np.zeros(N, bool)
    with np.errstate(all="ignore"):
        for _ in range(max_iter):
            if not active.any():
                break
            ia = np.flatnonzero(active)
            ua = u[ia]
            F = plane_residual(P, ua[:, 0], ua[:, 1], ua[:, 2], psv[ia], thv[ia])
            J = _plane_jacobian(P, ua[:, 2], psv[ia], thv[ia])
            du = _solve_stack(J, -F[..., None])[..., 0]
            u[ia] = ua + du
            done = np.abs(du).max(-1) <= tol           # False for NaN steps
            conv[ia[done]] = True
            active[ia[done]] = False
    u[~conv] = np.nan
    if not any(isinstance(a, Jet) for a in (z, psi, theta)):
        return u[:, 0], u[:, 1], u[:, 2], conv
    psj = psi if isinstance(psi, Jet) else Jet(psi)
    thj = theta if isinstance(theta, Jet) else Jet(theta)
    with np.errstate(all="ignore"):
        J0inv = _inv_stack(np.where(conv[:, None, None],
                                    _plane_jacobian(P, np.nan_to_num(u[:, 2]), psv, thv), np.eye(3)))
        U = Jet(u)
        for _ in range(2):
            F = plane_residual(P, U[:, 0], U[:, 1], U[:, 2], psj, thj)
            corr = J0inv @ F.expand(-1)
            U = Jet(u, U.d - corr.d[..., 0], U.dd - corr.dd[..., 0])
    return U[:, 0], U[:, 1], U[:, 2], conv


def kinematics(P, z, psi, theta):
    """Nominal pose of every body; inputs arrays (N,) or Jets of shape (N,).

    Returns a dict; entries are Jets when the inputs are Jets.  `reach` is False
    where a leg cannot reach its pose (3-PRS), a leg length is outside its stroke
    (3-RPS) or the parasitic Newton did not converge; `across` (3-PRS) is True
    where a leg lies across its rail (docs/model.md section 10.1)."""
    rp, Rb = P["rp"], P["Rb"]
    XJ_, AP = P["XJ"], P["AP"]
    N = np.shape(_val(z))[0]
    if P["closed"]:
        x, y, phi = parasitic(z, psi, theta, rp)
        conv = np.ones(N, bool)
    else:
        x, y, phi, conv = parasitic_newton(P, z, psi, theta)
    Rm = _rotation(psi, theta, phi)                                        # (N,3,3)
    p = jstack([x, y, z], -1)                                              # (N,3)
    A = (Rm @ AP.T).swapaxes(-1, -2) + p.expand(-2) if isinstance(p, Jet) \
        else (Rm @ AP.T).swapaxes(-1, -2) + p[:, None, :]                  # (N,3 limbs,3)
    out = {"x": x, "y": y, "phi": phi, "R": Rm, "p": p, "A": A}
    if P["kind"] == "3-PRS":
        L, cb, sb = P["L"], P["cb"], P["sb"]
        rho = (A * XJ_).sum(-1)
        h = A[..., 2]
        # A_j - b0_j = (rho - Rb) x_j + h z in the limb plane; d_j = cb z + sb x_j;
        # t: its component across the rail, s: along it (family spec)
        t = cb * (rho - Rb) - sb * h
        s = cb * h + sb * (rho - Rb)
        with np.errstate(invalid="ignore", divide="ignore"):
            rad = L * L - t * t
            root = jsqrt(rad)
            q = s - root
        reach = np.all(_val(rad) >= 0.0, axis=-1) & conv
        with np.errstate(invalid="ignore"):
            across = reach & np.any(_val(root) < ACROSS_RAIL * L, axis=-1)
        qe = q.expand(-1) if isinstance(q, Jet) else q[..., None]
        B = Rb * XJ_ + qe * P["DJ"]
        e = (A - B) / L
        out["across"] = across
    else:
        B = np.broadcast_to(Rb * XJ_, (N, 3, 3))
        D = A - B
        with np.errstate(invalid="ignore", divide="ignore"):
            q = jsqrt((D * D).sum(-1))
            e = D / (q.expand(-1) if isinstance(q, Jet) else q[..., None])
            qv = _val(q)
            reach = np.all((qv >= P["qmin"]) & (qv <= P["qmax"]), axis=-1) & conv
        out["across"] = np.zeros(N, bool)
        out["Gc"] = B + 0.5 * P["lc"] * e                                  # cylinder CoM
        out["Gp"] = A - 0.5 * P["lp"] * e                                  # piston CoM
    C = p + Rm @ P["c_loc"]
    E = p + Rm @ P["at_ext"]
    out.update(B=B, q=q, e=e, C=C, E=E, reach=reach)
    return out


def motion(kin, P):
    """Velocities/accelerations needed by Newton-Euler, from the Jets in kin.

    Every leg turns about y_j with omega_j = e_j x e_j' (3-RPS: cylinder and
    piston alike)."""
    Rj, ej = kin["R"], kin["e"]
    Rt = Rj.v.swapaxes(-1, -2)
    omega = vee(Rj.d @ Rt)                      # R' R^T = [w]x
    domega = vee(Rj.dd @ Rt)                    # skew part of R'' R^T = [w']x
    w_leg = np.cross(ej.v, ej.d)                # e x e'
    dw_leg = np.cross(ej.v, ej.dd)              # e x e''
    out = {"omega": omega, "domega": domega, "w_leg": w_leg, "dw_leg": dw_leg,
           "a_C": kin["C"].dd}
    if P["kind"] == "3-PRS":
        out["a_G"] = 0.5 * (kin["A"].dd + kin["B"].dd)
    else:
        out["a_cyl"], out["a_pis"] = kin["Gc"].dd, kin["Gp"].dd
    return out


# --------------------------------------------------------------------------
# Equilibrium A w = b (docs/model.md section 4)
# unknowns per limb j (offset 8j): f_R (3), mu1, mu2, f_S (3)
# rows: leg j forces 6j..6j+2, leg j moments 6j+3..6j+5, platform forces 18..20,
#       platform moments about C 21..23
# Leg moments are taken about the leg's centre of mass G_j (3-PRS) or about the
# base joint B_j (3-RPS, the cylinder and the piston summed).
# --------------------------------------------------------------------------
def equilibrium_matrix(P, A, B, C):
    N = A.shape[0]
    XJ_ = P["XJ"]
    M = np.zeros((N, 24, 24))
    O = 0.5 * (A + B) if P["kind"] == "3-PRS" else B          # moment point of each leg
    for j in range(3):
        r, c = 6 * j, 8 * j
        M[:, r:r + 3, c:c + 3] = I3
        M[:, r:r + 3, c + 5:c + 8] = -I3
        M[:, r + 3:r + 6, c + 3] = XJ_[j]
        M[:, r + 3:r + 6, c + 4] = EZ
        M[:, r + 3:r + 6, c:c + 3] = skew(B[:, j] - O[:, j])
        M[:, r + 3:r + 6, c + 5:c + 8] = -skew(A[:, j] - O[:, j])
        M[:, 18:21, c + 5:c + 8] = I3
        M[:, 21:24, c + 5:c + 8] = skew(A[:, j] - C)
    return M


def _rod_inertia(m, length, e):
    """Slender rod about its centre: m l^2/12 across the axis e, 0 along it."""
    return m * length ** 2 / 12.0 * (I3 - e[..., :, None] * e[..., None, :])


def leg_bodies(P, kin_v):
    """The leg bodies of each limb: list of (mass, centre of mass (N,3,3), inertia
    about it (N,3,3,3), key of its acceleration in motion())."""
    A, B, e = kin_v["A"], kin_v["B"], kin_v["e"]
    if P["kind"] == "3-PRS":
        return [(P["m_leg"], 0.5 * (A + B), _rod_inertia(P["m_leg"], P["L"], e), "a_G")]
    return [(P["m_cyl"], B + 0.5 * P["lc"] * e, _rod_inertia(P["m_cyl"], P["lc"], e), "a_cyl"),
            (P["m_pis"], A - 0.5 * P["lp"] * e, _rod_inertia(P["m_pis"], P["lp"], e), "a_pis")]


def equilibrium_rhs(P, kin_v, mot=None):
    """b for kinetostatics (mot None) or dynamics."""
    A, B, C, E, Rm, e = (kin_v[k] for k in ("A", "B", "C", "E", "R", "e"))
    N = A.shape[0]
    g, m = P["g"], P["m_body"]
    b = np.zeros((N, 24))
    if P["kind"] == "3-PRS":
        ml = P["m_leg"]
        Ileg = ml * P["L"] ** 2 / 12.0 * (I3 - e[..., :, None] * e[..., None, :])  # (N,3,3,3)
        for j in range(3):
            r = 6 * j
            b[:, r:r + 3] = -ml * g
            if mot is not None:
                b[:, r:r + 3] += ml * mot["a_G"][:, j]
                wj, dwj = mot["w_leg"][:, j], mot["dw_leg"][:, j]
                Iw = np.einsum("nab,nb->na", Ileg[:, j], wj)
                b[:, r + 3:r + 6] = np.einsum("nab,nb->na", Ileg[:, j], dwj) + np.cross(wj, Iw)
    else:
        # forces: f_R - f_S = sum_b m_b (a_b - g); moments about B_j:
        # m_R - (A - B) x f_S = sum_b [(G_b - B) x m_b (a_b - g) + I_b w' + w x I_b w]
        for mb, Gb, Ib, acc in leg_bodies(P, kin_v):
            for j in range(3):
                r = 6 * j
                fb = np.broadcast_to(-mb * g, (N, 3)).copy()
                if mot is not None:
                    fb += mb * mot[acc][:, j]
                    wj, dwj = mot["w_leg"][:, j], mot["dw_leg"][:, j]
                    Iw = np.einsum("nab,nb->na", Ib[:, j], wj)
                    b[:, r + 3:r + 6] += np.einsum("nab,nb->na", Ib[:, j], dwj) + np.cross(wj, Iw)
                b[:, r:r + 3] += fb
                b[:, r + 3:r + 6] += np.cross(Gb[:, j] - B[:, j], fb)
    b[:, 18:21] = -m * g - P["f_ext"]
    b[:, 21:24] = -np.cross(E - C, P["f_ext"]) - P["m_ext"]
    if mot is not None:
        b[:, 18:21] += m * mot["a_C"]
        I_w = Rm @ P["I_C_loc"] @ Rm.swapaxes(-1, -2)
        w, dw = mot["omega"], mot["domega"]
        b[:, 21:24] += np.einsum("nab,nb->na", I_w, dw) + \
            np.cross(w, np.einsum("nab,nb->na", I_w, w))
    return b


def equilibrium_system(P, kin_v, mot=None):
    return equilibrium_matrix(P, kin_v["A"], kin_v["B"], kin_v["C"]), \
        equilibrium_rhs(P, kin_v, mot)


def unpack_reactions(w, P=None):
    """w (N,24) -> f_R (N,3,3), m_R (N,3,3), f_S (N,3,3), indexed [n, limb, xyz]."""
    XJ_ = XJ if P is None else P["XJ"]
    W = w.reshape(w.shape[0], 3, 8)
    fR, mu1, mu2, fS = W[..., 0:3], W[..., 3], W[..., 4], W[..., 5:8]
    mR = mu1[..., None] * XJ_ + mu2[..., None] * EZ
    return fR, mR, fS


# --------------------------------------------------------------------------
# Take-up (docs/model.md section 5)
# --------------------------------------------------------------------------
def take_up(P, fR, mR, fS):
    """Per kind: displacement (N,3,3) and margin (N,3), plus the floor.

    Displacements are world vectors: s_radial -> S translation of the platform
    relative to the leg, r_radial / r_axial -> R translation of the leg
    relative to the slider (3-RPS: to the ground), r_angular -> R rotation vector."""
    YJ_ = P["YJ"]
    fy = (fR * YJ_).sum(-1)
    fperp = fR - fy[..., None] * YJ_
    margins = {"s_radial": np.linalg.norm(fS, axis=-1),
               "r_radial": np.linalg.norm(fperp, axis=-1),
               "r_axial": np.abs(fy),
               "r_angular": np.linalg.norm(mR, axis=-1)}
    floor = P["indet_frac"] * P["W"]
    disp, indet = {}, {}
    with np.errstate(invalid="ignore", divide="ignore"):
        for k in KINDS:
            c = P["clear"][k]
            mg = margins[k]
            bad = mg <= floor
            if c == 0.0:
                disp[k] = np.zeros_like(fR)
                indet[k] = np.zeros(fR.shape[0], bool)
                continue
            safe = np.where(bad, 1.0, mg)[..., None]
            if k == "s_radial":
                d = -c * fS / safe
            elif k == "r_radial":
                d = -c * fperp / safe
            elif k == "r_axial":
                d = -c * np.sign(fy)[..., None] * YJ_
            else:
                d = -c * mR / safe
            disp[k] = np.where(bad[..., None], 0.0, d)
            indet[k] = np.any(bad, axis=-1)
    return disp, margins, indet


# --------------------------------------------------------------------------
# Error kinematics (docs/model.md section 6): J_P dq_P = J_Cl dq_Cl, 12 x 12
# passive unknowns per limb (offset 4j): R rotation about y_j, S rotations about
# world x, y, z through A_j.  Rows: twist of limb 2 - limb 1, limb 3 - limb 1.
# --------------------------------------------------------------------------
def passive_screws(p, A, B, yj=None):
    """(N, 3 limbs, 6, 4) screws [w; v_P] of the passive joints of each limb
    (the actuated joint, slider or leg length, is locked: no column)."""
    YJ_ = YJ if yj is None else yj
    N = p.shape[0]
    S = np.zeros((N, 3, 6, 4))
    for j in range(3):
        S[:, j, 0:3, 0] = YJ_[j]
        S[:, j, 3:6, 0] = np.cross(B[:, j] - p, YJ_[j])
        for k in range(3):
            S[:, j, k, 1 + k] = 1.0
            S[:, j, 3:6, 1 + k] = np.cross(A[:, j] - p, I3[k])
    return S


def loop_matrix(S):
    N = S.shape[0]
    J = np.zeros((N, 12, 12))
    for l in range(2):
        J[:, 6 * l:6 * l + 6, 4 * (l + 1):4 * (l + 1) + 4] = S[:, l + 1]
        J[:, 6 * l:6 * l + 6, 0:4] = -S[:, 0]
    return J


def clearance_twists(kind, d, p, B):
    """Twist [w; v_P] (N,3,6) of the clearance freedoms of each limb for one kind."""
    T = np.zeros(d.shape[:-1] + (6,))
    if kind == "r_angular":
        T[..., 0:3] = d
        T[..., 3:6] = np.cross(B - p[:, None, :], d)
    else:
        T[..., 3:6] = d
    return T


def loop_system(S, Tcl):
    """J_P and right-hand sides J_Cl dq_Cl for clearance twists Tcl (N,3,6,K)."""
    J = loop_matrix(S)
    rhs = np.concatenate([Tcl[:, 0] - Tcl[:, 1], Tcl[:, 0] - Tcl[:, 2]], axis=1)  # (N,12,K)
    return J, rhs


def pose_error(S, Tcl, dqP):
    """Delta Gamma = [d_alpha; d_p] from limb 1: passive + clearance twists."""
    return np.einsum("nak,nkc->nac", S[:, 0], dqP[:, 0:4]) + Tcl[:, 0]


def euler_matrix(psi, theta):
    """Columns [y, Ry(theta) x, Ry(theta) Rx(psi) z] -> unknowns (dTheta, dPsi, dPhi)."""
    sps, cps, sth, cth = np.sin(psi), np.cos(psi), np.sin(theta), np.cos(theta)
    z0 = np.zeros_like(psi)
    c_y = np.stack([z0, z0 + 1.0, z0], -1)
    c_x = np.stack([cth, z0, -sth], -1)
    c_z = np.stack([cps * sth, -sps, cps * cth], -1)
    return np.stack([c_y, c_x, c_z], -1)


def euler_errors(psi, theta, dalpha):
    """(dPhi, dPsi, dTheta) for dalpha (N,3,K) -> (N,3,K) ordered phi, psi, theta."""
    sol = np.linalg.solve(euler_matrix(psi, theta), dalpha)      # rows: dTheta, dPsi, dPhi
    return sol[:, ::-1]


# --------------------------------------------------------------------------
# Worst-case envelope and dominant joint (docs/model.md section 11)
#
# Derived here from the 12x12 loop system itself, not from the spec's 6x6
# N = M^-1 columns: each joint's linear map is the pose error of unit take-up
# displacements of that joint alone (three world translations of limb j's
# clearance, three world rotation vectors about B_j), and the maximum over the
# joint's admissible set follows from the set's orthonormal basis U (3 x m) and
# radius c: over {U w : |w| <= c} the maximum of |g . d| is c |U^T g| and of
# |H d| is c sigma_max(H U).  The sets: s_radial the ball (U = I3), r_radial
# the disc normal to y_j (U = [x_j, z]), r_axial the segment along y_j
# (U = y_j), r_angular the rotation disc normal to y_j (U = [x_j, z]).
# --------------------------------------------------------------------------
ENV_COMPONENTS = ("x", "y", "z", "rx", "ry", "rz", "p", "alpha")
# row of Delta Gamma = [d_alpha; d_p] for x, y, z, rx, ry, rz
_ENV_ROWS = (3, 4, 5, 0, 1, 2)


def joint_name(kind, j):
    """`s<j>_radial`, `r<j>_radial`, `r<j>_axial`, `r<j>_angular` (j = 1..3)."""
    return f"s{j}_radial" if kind == "s_radial" else f"r{j}_{kind.split('_', 1)[1]}"


# the (kind, limb) order of the tie rule: kinds first, then limbs
JOINTS = tuple((k, j) for k in KINDS for j in (1, 2, 3))
JOINT_NAMES = tuple(joint_name(k, j) for k, j in JOINTS)


def env_column_names():
    names = [f"env_{c}" for c in ENV_COMPONENTS]
    names += [f"env_{k}_{c}" for k in KINDS for c in ENV_COMPONENTS]
    return names + ["dominant"]


def joint_maps(S, JP, p, B):
    """Linear maps of every joint, from the 12x12 loop system J_P dq_P = J_Cl dq_Cl.

    Returns (Gt, Gr), each (N, 3 limbs, 6, 3): Delta Gamma = [d_alpha; d_p] per unit
    world translation of limb j's clearance (Gt; the S and R translations have the
    same twist, a pure translation) and per unit world rotation vector of limb j's
    leg about B_j (Gr), all other joints rigid."""
    N = p.shape[0]
    Tcl = np.zeros((N, 3, 6, 18))
    for j in range(3):
        for k in range(3):
            Tcl[:, j, 3:6, 6 * j + k] = I3[k]                                   # translation
            Tcl[:, j, 0:3, 6 * j + 3 + k] = I3[k]                               # rotation about B_j
            Tcl[:, j, 3:6, 6 * j + 3 + k] = np.cross(B[:, j] - p, I3[k])
    _, rhs = loop_system(S, Tcl)
    dqP = _solve_stack(JP, rhs)
    G = pose_error(S, Tcl, dqP).reshape(N, 6, 3, 2, 3)                          # (n, row, j, t/r, k)
    return G[:, :, :, 0, :].transpose(0, 2, 1, 3), G[:, :, :, 1, :].transpose(0, 2, 1, 3)


def admissible_bases(P):
    """kind -> (orthonormal basis U (3 limbs, 3, m) of the admissible set, rotation?)."""
    disc = np.stack([P["XJ"], np.broadcast_to(EZ, (3, 3))], -1)                # x_j, z: normal to y_j
    return {"s_radial": (np.broadcast_to(I3, (3, 3, 3)), False),
            "r_radial": (disc, False),
            "r_axial": (P["YJ"][..., None], False),
            "r_angular": (disc, True)}


def _spectral(H):
    """Largest singular value of a stack (..., r, m)."""
    if H.shape[-1] == 1:
        return np.linalg.norm(H[..., 0], axis=-1)
    return np.linalg.svd(H, compute_uv=False)[..., 0]


def joint_envelopes(P, Gt, Gr):
    """kind -> (N, 3 limbs, 8): per joint, the maximum over its admissible set of
    |Delta Gamma_c| (c = x, y, z, rx, ry, rz) and of |Delta p|, |Delta alpha|
    (ENV_COMPONENTS order).  Exactly 0 for a kind with zero clearance."""
    out = {}
    bases = admissible_bases(P)
    N = Gt.shape[0]
    for kind in KINDS:
        c = P["clear"][kind]
        if c == 0.0:
            out[kind] = np.zeros((N, 3, 8))
            continue
        U, is_rot = bases[kind]
        H = np.einsum("njrk,jkm->njrm", Gr if is_rot else Gt, U)              # (N,3,6,m)
        comp = np.linalg.norm(H, axis=-1)                                      # (N,3,6)
        with np.errstate(all="ignore"):
            e = np.concatenate([comp[..., list(_ENV_ROWS)], _spectral(H[..., 3:6, :])[..., None],
                                _spectral(H[..., 0:3, :])[..., None]], -1)
        out[kind] = c * e
    return out


def joint_contributions(P, Gt, Gr, disp):
    """(N, 12, 6): each joint's own Delta Gamma = [d_alpha; d_p] for the take-up
    displacements `disp` (take_up's), joints in JOINTS order."""
    out = []
    for kind in KINDS:
        G = Gr if kind == "r_angular" else Gt
        for j in range(3):
            out.append(np.einsum("nrk,nk->nr", G[:, j], disp[kind][:, j]))
    return np.stack(out, 1)


def dominant_joint(P, contrib, rows):
    """Object array of joint names (None where not `rows` or every clearance is 0):
    the joint of non-zero clearance whose own contribution has the largest |Delta p|,
    the first in JOINTS order among those within DOMINANT_TIE of it."""
    N = contrib.shape[0]
    out = np.full(N, None, dtype=object)
    cand = np.array([P["clear"][k] != 0.0 for k, _ in JOINTS])
    if not cand.any():
        return out
    dp = np.linalg.norm(contrib[..., 3:6], axis=-1)                            # (N,12)
    idx = first_within_tie(np.where(cand, dp, -np.inf))
    names = np.array(JOINT_NAMES, dtype=object)
    out[rows] = names[idx[rows]]
    return out


DOMINANT_TIE = 1e-9


def first_within_tie(values):
    """Index along the last axis of the first value within DOMINANT_TIE (relative) of
    the row's largest: contributions equal up to round-off (symmetric poses, or
    r_axial and r_angular when a = theta * l) go to the first in order."""
    v = np.nan_to_num(values, nan=-np.inf)
    best = v.max(axis=-1, keepdims=True)
    with np.errstate(invalid="ignore"):
        return np.argmax(v >= best - DOMINANT_TIE * np.abs(best), axis=-1)


def hist_quantile(values, q):
    """The engine's summary quantile (crates/parquet/src/summary.rs, Series::quantile):
    nearest rank, rank = clamp(ceil(q n), 1, n); values <= 1e-18 count as zeros (-> 0);
    otherwise the log-spaced bin (a double's bits >> 41: 2^11 bins per octave) where
    the rank falls, reported at the bin's geometric centre, at most the maximum.
    None for no values."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    n = v.size
    if n == 0:
        return None
    rank = min(max(int(math.ceil(q * n)), 1), n)
    zeros = int((v <= 1e-18).sum())
    if rank <= zeros:
        return 0.0
    bins = np.sort(v[v > 1e-18].view(np.uint64) >> np.uint64(41))
    b = bins[rank - zeros - 1]
    lo = np.array([b << np.uint64(41)], np.uint64).view(np.float64)[0]
    hi = np.array([(b + np.uint64(1)) << np.uint64(41)], np.uint64).view(np.float64)[0]
    return float(min(math.sqrt(lo * hi), v.max()))


def nearest_rank(values, q):
    """The exact nearest-rank q-quantile (the order statistic hist_quantile bins)."""
    v = np.sort(np.asarray(values, float)[np.isfinite(values)])
    if v.size == 0:
        return None
    return float(v[min(max(int(math.ceil(q * v.size)), 1), v.size) - 1])


def envelope_summary(cols):
    """Summary quantities of the envelope spec per mode, from compute(..., extras=True):
    env_p_max, env_p_p95, env_alpha_max, env_alpha_p95 (rows where env is filled),
    dominant_share_<joint> (share of ok rows the joint dominates) and rms_dp_<joint>
    (RMS over ok rows of |Delta p| contributed by the joint).  None for a statistic
    over no row.  Returns {mode: {name: value}}."""
    if "dp_joint_s1_radial" not in cols:
        raise ValueError("envelope_summary needs compute(..., extras=True)")
    out = {}
    for mode in dict.fromkeys(cols["mode"]):
        sel = cols["mode"] == mode
        res = {}
        for c in ("p", "alpha"):
            v = cols[f"env_{c}"][sel]
            v = v[np.isfinite(v)]
            res[f"env_{c}_max"] = float(v.max()) if v.size else None
            res[f"env_{c}_p95"] = hist_quantile(v, 0.95)
        ok = sel & (cols["status"] == "ok")
        n_ok = int(ok.sum())
        dom = cols["dominant"][ok]
        for name in JOINT_NAMES:
            res[f"dominant_share_{name}"] = (float(np.sum(dom == name)) / n_ok) if n_ok else None
        for name in JOINT_NAMES:
            v = cols[f"dp_joint_{name}"][ok]
            res[f"rms_dp_{name}"] = float(np.sqrt(np.mean(v * v))) if n_ok else None
        out[mode] = res
    return out


# --------------------------------------------------------------------------
# Exact error (docs/model.md section 7)
# --------------------------------------------------------------------------
def exp_minus_identity(v):
    """Exp([v]x) - I for v (...,3), free of cancellation: a [v]x + b [v]x^2 with
    a = sin t / t and b = (1 - cos t) / t^2 = 2 sin^2(t/2) / t^2 (series when tiny)."""
    th2 = (v * v).sum(-1)
    th = np.sqrt(th2)
    small = th < 1e-4
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th2 / 6.0 + th2 * th2 / 120.0, np.sin(ths) / ths)
    h = np.where(small, 1.0, 0.5 * ths)
    b = np.where(small, 0.5 - th2 / 24.0 + th2 * th2 / 720.0, 0.5 * (np.sin(h) / h) ** 2)
    K = skew(v)
    return a[..., None, None] * K + b[..., None, None] * (K @ K)


def left_jacobian(v):
    """J_l(v) of SO(3): d/dv Exp(v) u = -[Exp(v) u]x J_l(v)."""
    th2 = (v * v).sum(-1)
    th = np.sqrt(th2)
    small = th < 1e-2
    ths = np.where(small, 1.0, th)
    b = np.where(small, 0.5 - th2 / 24.0 + th2 * th2 / 720.0,
                 2.0 * np.sin(0.5 * ths) ** 2 / ths ** 2)
    c = np.where(small, 1.0 / 6.0 - th2 / 120.0 + th2 * th2 / 5040.0,
                 (ths - np.sin(ths)) / ths ** 3)
    K = skew(v)
    return I3 + b[..., None, None] * K + c[..., None, None] * (K @ K)


def exact_errors(P, kin_v, dB, dth, dA, max_iter=30):
    """Newton on the closure in perturbation form, all poses at once.

    Unknowns: dp = p' - p, w with R' = Exp(w) R, and the leg angles phi_j.  With
    the nominal closure p + R a'_j = B_j + l_j e_j subtracted, every term of

        dp + (Exp(w) - I) R a'_j - dB_j - dA_j - l_j (Rot(dth_j) Rot(y_j, phi_j) - I) e_j = 0

    is of the size of the clearances (no O(|p|) numbers are ever differenced), so
    the result keeps full relative precision; the exact error is (w, dp).  The leg
    length l_j is L (3-PRS) or the nominal leg length q_j (3-RPS, its actuator
    locked).

    dB, dth, dA: (N,3,3) R translation, R rotation vector, S translation.
    Returns (N,6) [w; dp] (NaN where Newton does not converge) and the converged mask."""
    Rm, e = kin_v["R"], kin_v["e"]
    YJ_ = P["YJ"]
    if P["kind"] == "3-PRS":
        L = Ls = P["L"]                                               # scalar leg length
    else:
        L = kin_v["q"][..., None]                                     # (N,3,1) leg lengths
        Ls = kin_v["q"].max(-1)                                       # (N,) size of the legs
    N = Rm.shape[0]
    ra0 = np.einsum("nab,jb->nja", Rm, P["AP"])                       # R a'_j (N,3,3)
    off = dB + dA                                                     # (N,3,3)
    tilt = exp_minus_identity(dth)                                    # Rot(dth_j) - I (N,3,3,3)
    ytil = I3 + tilt                                                  # Rot(dth_j)
    dp, w, phi = np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 3))

    def residual(dp, w, phi):
        Ew = exp_minus_identity(w)                                    # (N,3,3)
        M2 = exp_minus_identity(phi[..., None] * YJ_)                 # (N,3,3,3)
        turn = tilt + M2 + tilt @ M2                                  # Rot(dth)Rot(y,phi) - I
        F = dp[:, None, :] + np.einsum("nab,njb->nja", Ew, ra0) - off \
            - L * np.einsum("njab,njb->nja", turn, e)
        return F, Ew, M2

    # size of the unknowns, for the relative step test (0 on a rigid job)
    def size(dp, w, phi):
        return np.maximum(np.abs(dp).max(-1), Ls * np.maximum(np.abs(w).max(-1),
                                                              np.abs(phi).max(-1)))

    rel_step = np.full(N, np.inf)
    for _ in range(max_iter):
        F, Ew, M2 = residual(dp, w, phi)
        ra = ra0 + np.einsum("nab,njb->nja", Ew, ra0)                 # R' a'_j
        legdir = e + np.einsum("njab,njb->nja", M2, e)                # Rot(y_j, phi_j) e_j
        dphi = -L * np.einsum("njab,njb->nja", ytil, np.cross(YJ_, legdir))
        dw = -skew(ra) @ left_jacobian(w)[:, None]                    # (N,3,3,3)
        J = np.zeros((N, 3, 3, 9))
        J[..., 0:3] = I3
        J[..., 3:6] = dw
        for j in range(3):
            J[:, j, :, 6 + j] = dphi[:, j]
        step = _solve_stack(J.reshape(N, 9, 9), -F.reshape(N, 9, 1))[..., 0]
        dp, w, phi = dp + step[:, 0:3], w + step[:, 3:6], phi + step[:, 6:9]
        sz = size(dp, w, phi)
        smax = np.maximum(np.abs(step[:, 0:3]).max(-1), Ls * np.abs(step[:, 3:9]).max(-1))
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


def same_branch(exact, linear):
    """docs/conventions.md: an exact solution further from the linear error than the
    linear error's own size (any of the six components) is another assembly branch."""
    size = np.abs(linear).max(-1, keepdims=True)
    with np.errstate(invalid="ignore"):
        return np.all(np.abs(exact - linear) <= size, axis=-1)


# --------------------------------------------------------------------------
# Full pipeline
# --------------------------------------------------------------------------
def column_names(job_or_P, columns="full") -> list:
    P = job_or_P if "job" in job_or_P else normalize_job(job_or_P)
    names = ["variant", "mode", "sample", "t", "z", "psi", "theta", "status"]
    names += [f"err_{c}" for c in COMPONENTS]
    if columns in ("standard", "full"):
        names += [f"err_{k}_{c}" for k in KINDS for c in COMPONENTS]
        names += ["x", "y", "phi", "q1", "q2", "q3"]
        for j in (1, 2, 3):
            names += [f"margin_r{j}_radial", f"margin_r{j}_axial",
                      f"margin_r{j}_angular", f"margin_s{j}"]
        names += env_column_names()
    if columns == "full":
        for j in (1, 2, 3):
            names += [f"f_r{j}_{a}" for a in "xyz"] + [f"m_r{j}_{a}" for a in "xyz"] + \
                [f"f_s{j}_{a}" for a in "xyz"]
        names += ["cond_a", "cond_jp"]
    if P["exact"]:
        names += [f"exact_err_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
    return names


def _substitute_posture(P, N):
    """A finite posture for the rows that are unreachable (their outputs are null):
    the level pose at Z = 2 L (3-PRS; the prototype's choice) or Z = the legs'
    typical length (3-RPS), else the bare level layout."""
    zero = np.zeros(N)
    with np.errstate(all="ignore"):
        ref = kinematics(P, np.full(N, (2.0 if P["kind"] == "3-PRS" else 1.0) * P["size"]),
                         zero, zero)
    if all(np.isfinite(ref[k]).all() for k in ("A", "B", "C", "E", "R", "e", "p")):
        return ref
    p = np.zeros((N, 3))
    p[:, 2] = P["size"]
    A = p[:, None, :] + P["AP"]
    B = np.broadcast_to(P["Rb"] * P["XJ"], (N, 3, 3))
    e = (A - B) / np.linalg.norm(A - B, axis=-1)[..., None]
    return {"A": A, "B": B, "e": e, "p": p, "R": np.broadcast_to(I3, (N, 3, 3)),
            "C": p + P["c_loc"], "E": p + P["at_ext"]}


def _compute_chunk(P, smp, sl, modes):
    z, psi, theta = smp["z"][sl], smp["psi"][sl], smp["theta"][sl]
    N = z.size
    dyn = "dynamic" in modes
    if dyn:
        kj = kinematics(P, smp["zj"][sl], smp["psij"][sl], smp["thetaj"][sl])
        kin = {k: (v.v if isinstance(v, Jet) else v) for k, v in kj.items()}
        mot = motion(kj, P)
    else:
        kin = kinematics(P, z, psi, theta)
    reach = kin["reach"]
    # unreachable poses: substitute a harmless posture so the stacks stay solvable
    good = reach
    kin_s = dict(kin)
    if not np.all(good):
        ref = _substitute_posture(P, N)
        for k in ("A", "B", "C", "E", "R", "e", "p"):
            m = good.reshape((N,) + (1,) * (kin[k].ndim - 1))
            kin_s[k] = np.where(m, kin[k], ref[k])
    Amat = equilibrium_matrix(P, kin_s["A"], kin_s["B"], kin_s["C"])
    bs = [equilibrium_rhs(P, kin_s, mot if m == "dynamic" else None) for m in modes]
    wsol = _solve_stack(Amat, np.stack(bs, -1))                  # (N,24,M)
    S = passive_screws(kin_s["p"], kin_s["A"], kin_s["B"], P["YJ"])
    JP = loop_matrix(S)
    Gred, Mred = reduced_matrices(kin_s["p"], kin_s["A"], kin_s["e"], P["YJ"])
    cond_a, cond_jp = kappa1(Gred), kappa1(Mred)
    with np.errstate(all="ignore"):
        cond_a = np.where(np.isfinite(cond_a), cond_a, np.inf)
        cond_jp = np.where(np.isfinite(cond_jp), cond_jp, np.inf)
    # near_singular: an ill-conditioned A or J_P, or a 3-PRS leg across its rail
    singular = ~((cond_a <= P["singular_cond"]) & (cond_jp <= P["singular_cond"])) | \
        kin["across"]

    out = {}
    for mi, mode in enumerate(modes):
        fR, mR, fS = unpack_reactions(wsol[..., mi], P)
        disp, margins, indet = take_up(P, fR, mR, fS)
        Tcl = np.stack([clearance_twists(k, disp[k], kin_s["p"], kin_s["B"]) for k in KINDS],
                       -1)                                                 # (N,3,6,4)
        _, rhs = loop_system(S, Tcl)
        dqP = _solve_stack(JP, rhs)
        G = pose_error(S, Tcl, dqP)                                        # (N,6,4)
        eul = euler_errors(psi, theta, G[:, 0:3])                          # (N,3,4)
        if mi == 0:                  # geometry only: the same maps for every mode
            Gt, Gr = joint_maps(S, JP, kin_s["p"], kin_s["B"])
            jenv = joint_envelopes(P, Gt, Gr)
        per = np.concatenate([G[:, 3:6], G[:, 0:3], eul], axis=1)          # (N,9,4) in COMPONENTS order
        any_indet = np.zeros(N, bool)
        for k in KINDS:
            any_indet |= indet[k]
        status = np.where(~reach, "unreachable",
                          np.where(singular, "near_singular",
                                   np.where(any_indet, "indeterminate_contact", "ok")))
        ok = status == "ok"
        full_rows = ok | (status == "indeterminate_contact")
        cols = {"mode": np.full(N, mode, dtype=object),
                "sample": np.arange(sl.start, sl.start + N, dtype=np.uint64)}
        cols["t"], cols["z"], cols["psi"], cols["theta"] = smp["t"][sl], z, psi, theta
        cols["x"], cols["y"], cols["phi"] = kin["x"], kin["y"], kin["phi"]
        cols["status"] = status.astype(object)
        qrow = reach & (singular | full_rows)
        for j in range(3):
            cols[f"q{j + 1}"] = np.where(qrow, kin["q"][:, j], np.nan)
        cols["cond_a"] = np.where(qrow, cond_a, np.nan)
        cols["cond_jp"] = np.where(qrow, cond_jp, np.nan)
        tot = per.sum(-1)
        for ci, c in enumerate(COMPONENTS):
            cols[f"err_{c}"] = np.where(ok, tot[:, ci], np.nan)
            for ki, k in enumerate(KINDS):
                cols[f"err_{k}_{c}"] = np.where(full_rows & ~indet[k], per[:, ci, ki], np.nan)
        # envelope (geometry only): ok and indeterminate_contact rows
        for ki, k in enumerate(KINDS):
            ek = jenv[k].sum(1)                                            # (N,8)
            for ci, c in enumerate(ENV_COMPONENTS):
                cols[f"env_{k}_{c}"] = np.where(full_rows, ek[:, ci], np.nan)
        for ci, c in enumerate(ENV_COMPONENTS):
            cols[f"env_{c}"] = sum(cols[f"env_{k}_{c}"] for k in KINDS)
        contrib = joint_contributions(P, Gt, Gr, disp)                     # (N,12,6)
        cols["dominant"] = dominant_joint(P, contrib, ok)
        dpj = np.linalg.norm(contrib[..., 3:6], axis=-1)
        for i, name in enumerate(JOINT_NAMES):
            cols[f"dp_joint_{name}"] = np.where(ok, dpj[:, i], np.nan)
            for r, c in enumerate(("rx", "ry", "rz", "x", "y", "z")):
                cols[f"joint_{name}_{c}"] = np.where(ok, contrib[:, i, r], np.nan)
        for j in range(3):
            for a_i, a in enumerate("xyz"):
                cols[f"f_r{j + 1}_{a}"] = np.where(full_rows, fR[:, j, a_i], np.nan)
                cols[f"m_r{j + 1}_{a}"] = np.where(full_rows, mR[:, j, a_i], np.nan)
                cols[f"f_s{j + 1}_{a}"] = np.where(full_rows, fS[:, j, a_i], np.nan)
            cols[f"margin_r{j + 1}_radial"] = np.where(full_rows, margins["r_radial"][:, j], np.nan)
            cols[f"margin_r{j + 1}_axial"] = np.where(full_rows, margins["r_axial"][:, j], np.nan)
            cols[f"margin_r{j + 1}_angular"] = np.where(full_rows, margins["r_angular"][:, j], np.nan)
            cols[f"margin_s{j + 1}"] = np.where(full_rows, margins["s_radial"][:, j], np.nan)
        if P["exact"]:
            ex = np.full((N, 6), np.nan)
            if np.any(ok):
                dB = disp["r_radial"] + disp["r_axial"]
                ex_ok, _ = exact_errors(P, {k: kin_s[k][ok] for k in kin_s},
                                        dB[ok], disp["r_angular"][ok], disp["s_radial"][ok])
                ex[ok] = ex_ok
                lin = tot[:, [3, 4, 5, 0, 1, 2]]                # [d_alpha; d_p]
                ex[~same_branch(ex, lin)] = np.nan
            for ci, c in enumerate(("rx", "ry", "rz", "x", "y", "z")):
                cols[f"exact_err_{c}"] = ex[:, ci]
        out[mode] = cols
    return out


def extra_column_names() -> list:
    """Reference-only columns that compute(..., extras=True) appends (ok rows, NaN
    elsewhere): dp_joint_<joint> = |Delta p| of each joint's own contribution to the
    deterministic error, joint_<joint>_<c> its components (c = x, y, z, rx, ry, rz)."""
    names = [f"dp_joint_{n}" for n in JOINT_NAMES]
    names += [f"joint_{n}_{c}" for n in JOINT_NAMES for c in ("x", "y", "z", "rx", "ry", "rz")]
    return names


def compute(job: dict, columns: str = "full", chunk: int = 4096, extras: bool = False) -> dict:
    """All `poses` rows of variant 0: dict column -> array (modes concatenated
    in the job's order; NaN/None where the engine writes null).  extras=True adds
    the reference-only per-joint columns of extra_column_names()."""
    P = job if "job" in job else normalize_job(job)
    smp = sample_inputs(P)
    n = smp["z"].size
    modes = P["modes"]
    parts = {m: [] for m in modes}
    for s0 in range(0, n, chunk):
        sl = slice(s0, min(n, s0 + chunk))
        res = _compute_chunk(P, smp, sl, modes)
        for m in modes:
            res[m]["sample"] = np.arange(sl.start, sl.stop, dtype=np.uint64)
            parts[m].append(res[m])
    names = column_names(P, columns) + (extra_column_names() if extras else [])
    out = {}
    for name in names:
        if name == "variant":
            continue
        out[name] = np.concatenate([c[name] for m in modes for c in parts[m]])
    out["variant"] = np.zeros(out["sample"].size, dtype=np.int64)
    return {k: out[k] for k in names}


def pose_arrays(job: dict, z, psi, theta, mode="kinetostatic", zj=None, psij=None,
                thetaj=None):
    """Low-level access for tests: everything for explicit input arrays."""
    P = job if "job" in job else normalize_job(job)
    z, psi, theta = (np.atleast_1d(np.asarray(a, float)) for a in (z, psi, theta))
    smp = {"t": np.full(z.size, np.nan), "z": z, "psi": psi, "theta": theta}
    if mode == "dynamic":
        smp.update(zj=zj, psij=psij, thetaj=thetaj)
    return _compute_chunk(P, smp, slice(0, z.size), [mode])[mode]
