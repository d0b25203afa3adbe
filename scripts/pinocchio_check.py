#!/usr/bin/env python3
"""Cross-check the engine's joint reactions against Pinocchio (docs/model.md sections 9, 10).

Kinds of random job (--kinds, default all):
  prototype  3-PRS with the paper's layout, written with the original job keys only
             (no `kind`, no angles): runs on an engine that predates the family;
  3-PRS      any rail angle beta (rails d_j = cos(beta) z + sin(beta) x_j, incl. the
             horizontal -90 and +90), rotated or uneven limb angles alpha_j, platform
             angles gamma_j (default alpha_j);
  3-RPS      a revolute joint at the base, an actuated leg length (cylinder + piston);
  6-UPS      (only when --kinds names it; "all" is the three above) the Gough-Stewart
             platform of docs/model.md section 10.3: per limb a universal joint at B_i
             (a revolute about the fixed axis a1_i, then one about the cross's second
             axis a2_i, carrying the cylinder), a prismatic joint along the leg (the
             piston), the platform on piston 1 through a spherical joint at A_1 and five
             3-D point constraints at A_2..A_6 (nv = 21 = 6 actuators + 15 multipliers).
             f_Ui, m_Ui = the wrench transmitted by joint u<i>a (the cross is massless),
             mu_i = m_Ui . n_i; f_S1 from the spherical joint, f_Si = -lambda_i.  The
             platform twist [p'; E (phi', psi', theta')] fixes the velocities (all six
             inputs, no parasitic motions); the self-test checks closure, the RNEA
             residual, the U couple along n_i and mu_i = 0, each leg's and the platform's
             balance by hand, virtual work (complex step over six platform twists) and
             pin.constraintDynamics; compare mode reads q1..q6, f_u<i>_*, m_u<i>, f_s<i>_*.

Each job's mechanism is rebuilt in Pinocchio from its geometry, independently of the
engine.  Per limb j, with x_j = (cos alpha_j, sin alpha_j, 0), y_j = z x x_j:
  * 3-PRS: a prismatic joint along d_j placed at R_b*x_j (the slider, massless), then
    a revolute joint about y_j (the leg: mass m_leg, centre of mass at mid-leg,
    slender-rod inertia m L^2/12 across, 0 along);
  * 3-RPS: a revolute joint about y_j at B_j = R_b*x_j carrying the cylinder (mass m_cyl,
    centre l_c/2 from B_j along the leg), then a prismatic joint along the leg carrying
    the piston (mass m_pis, centre l_p/2 behind A_j); slender rods about their centres;
  * the platform (composite body: disc or given inertia about P plus rigidly attached
    point masses) hangs on limb 1's distal body (leg / piston) through a spherical joint
    at A_1; limbs 2 and 3 close on it with 3-D point constraints at A_2, A_3.

Parasitic motions (X, Y, Phi): the closed forms of docs/model.md section 2 when the limb
angles are exactly (0, 120, 240) deg and the platform angles equal them; otherwise
Newton (analytic Jacobian, from the closed-form values) on A_j . y_j = 0, as the engine
does.  Actuators: 3-PRS q_j = s_j - sqrt(L^2 - t_j^2) (slider behind A_j along its rail),
3-RPS q_j = |A_j - B_j| (leg length).  Status: unreachable (no root, stroke, Newton
failed), near_singular (3-PRS leg across its rail); only `ok` rows are compared.

For a pose, the actuator forces tau (3) and constraint multipliers lambda (6) solve
M a + h - J_ext^T w_ext = S^T tau + J_c^T lambda (9 equations); lambda is then applied
as a pair of external forces and a second RNEA gives the transmitted joint forces:
data.f[i] is the spatial force exerted by the parent on joint i's body, in joint i's
frame, about joint i's origin.  Hence
  f_Rj, m_Rj = oR_{R_j} * data.f[R_j].(linear, angular)   at B_j: the slider on leg j
               (3-PRS), the ground on cylinder j (3-RPS)
  f_S1       = oR_{S_1} * data.f[S_1].linear               (leg 1 on the platform, at A_1)
  f_Sj       = -lambda_j, j = 2, 3                         (lambda_j acts on leg j's tip)
  tau_j      = the actuated prismatic joint's force (slider along d_j / piston along e_j)

Velocities and accelerations (dynamic mode) are not taken from the engine: the
9 generalized velocities solve [J_c; rows of the platform twist giving dZ, dPsi,
dTheta] v = [0; dZ, dPsi, dTheta] with Pinocchio's Jacobians, and the accelerations
solve the differentiated system with Pinocchio's drift (classical) accelerations,
the input derivatives being the analytic derivatives of the harmonics.  They are
exact to round-off (parasitic rates included, whatever the layout); --selftest
verifies them against 8th-order finite differences of the configuration in time.

Tolerances against the engine (rows with status ok): reactions 1e-9 of W (forces) and
of W*L (couples; L = leg length for 3-PRS, cylinder + piston length for 3-RPS) in both
modes, since the Pinocchio side is exact to round-off in both; x, y, phi, q1..q3 1e-10
absolute; inputs z, psi, theta, t 1e-12.  W is the weight of all moving bodies
(docs/conventions.md; 3-RPS: platform, points, 3 cylinders and 3 pistons).

--selftest needs no engine: on random jobs of every selected kind it checks the loop
closure with Pinocchio's forward kinematics, the parasitic motions against a separate
Newton solution (finite-difference Jacobian, from zero) and against the constraints,
the actuator formula against docs/model.md's form (3-PRS), each body's Newton-Euler
balance (docs/model.md section 4; 3-RPS: cylinder + piston summed, moments about B_j)
by hand in numpy (statics; and dynamics with inertia terms from finite differences and
from Pinocchio), virtual work with complex-step derivatives of the inverse kinematics
(through the Newton solve), the actuator force (3-PRS: tau_j = f_Rj . d_j; 3-RPS: the
piston's balance along e_j), zero moment in the spherical joint, J_c against
pin.getConstraintJacobian, and Pinocchio's constrained forward dynamics
(constraintDynamics) fed with our tau returning our accelerations and multipliers.

Compare mode probes the engine first (`clearance check` on a tiny job of each new
kind): if it rejects the kind's keys as a bad job (exit 2), that kind's jobs are
reported SKIP when --kinds was left at its default, and FAIL when --kinds names it.

Usage:
  python3 scripts/pinocchio_check.py [--jobs N] [--seed S] [--kinds K,..] [--bin PATH] [--keep DIR]
  python3 scripts/pinocchio_check.py --selftest [--jobs N] [--seed S] [--kinds K,..]

Job i (0-based) is of kind i mod k among the k selected kinds, alternately grid and
trajectory, and is drawn from its own generator seeded by (S, i).
Ends with "N passed, M failed" (counts of job x mode; ", K skipped" when some were);
exit status 1 on any failure.
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import math
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KINDS = ("prototype", "3-PRS", "3-RPS")
# Opt-in kinds (--kinds names them): not in the default set, so that the default run keeps
# drawing the same random jobs for the kinds above (job i is of kind i mod k).
EXTRA_KINDS = ("6-UPS",)
SYM_DEG = [0.0, 120.0, 240.0]
SYM_RAD = np.array([0.0, 2 * math.pi / 3, 4 * math.pi / 3])
EZ = np.array([0.0, 0.0, 1.0])
EY = np.array([0.0, 1.0, 0.0])
EX = np.array([1.0, 0.0, 0.0])

# Tolerances, relative to the load scale W (forces) and W*L (couples).
TOL_STATIC = 1e-9
TOL_DYNAMIC = 1e-9     # derivatives are exact to round-off (see module docstring)
TOL_KIN = 1e-10        # x, y, phi (rad), q (m) against the engine
TOL_INPUT = 1e-12      # z, psi, theta, t against the sampling rules
NEWTON_TOL = 1e-14     # parasitic Newton: converged when the step is below this
NEWTON_MAXIT = 50


# --------------------------------------------------------------------------- #
# Small rotation helpers (work for complex arguments: used for complex step)
# --------------------------------------------------------------------------- #
def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=np.result_type(a, float))


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=np.result_type(a, float))


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.result_type(a, float))


def drz(a):
    """d R_z(a) / da."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[-s, -c, 0], [c, -s, 0], [0, 0, 0]], dtype=np.result_type(a, float))


def euler_R(phi, psi, theta):
    """R = R_y(Theta) R_x(Psi) R_z(Phi) (docs/model.md section 1)."""
    return ry(theta) @ rx(psi) @ rz(phi)


def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def vee(S):
    return np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2.0


def norm_c(v):
    """Euclidean norm, complex-safe (analytic: sqrt(v.v), not |v|)."""
    return np.sqrt(v @ v)


# --------------------------------------------------------------------------- #
# Job description
# --------------------------------------------------------------------------- #
@dataclass
class Params:
    kind: str = "3-PRS"
    Rb: float = 0.18
    rp: float = 0.36
    L: float = 1.0                       # 3-PRS leg length
    beta: float = 0.0                    # 3-PRS rail angle (rad)
    alpha: np.ndarray = field(default_factory=lambda: SYM_RAD.copy())   # limb angles (rad)
    gamma: np.ndarray = field(default_factory=lambda: SYM_RAD.copy())   # platform angles (rad)
    symmetric: bool = True               # closed-form parasitic motions apply
    lc: float = 0.8                      # 3-RPS cylinder length
    lp: float = 0.8                      # 3-RPS piston length
    qmin: float = 0.8
    qmax: float = 1.6
    g: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    m_plat: float = 9.8
    m_leg: float = 3.0
    m_cyl: float = 2.0
    m_pis: float = 1.0
    I_plat: np.ndarray | None = None       # diag about P, platform axes
    points: list = field(default_factory=list)   # [(mass, offset(3))]
    f_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    m_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    at_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))

    # derived -------------------------------------------------------------
    @property
    def rps(self):
        return self.kind == "3-RPS"

    def xj(self, j):
        return np.array([math.cos(self.alpha[j]), math.sin(self.alpha[j]), 0.0])

    def yj(self, j):
        return np.array([-math.sin(self.alpha[j]), math.cos(self.alpha[j]), 0.0])

    def rail(self, j):
        return math.cos(self.beta) * EZ + math.sin(self.beta) * self.xj(j)

    def a_prime(self, j):
        return self.rp * np.array([math.cos(self.gamma[j]), math.sin(self.gamma[j]), 0.0])

    @property
    def m_comp(self):
        return self.m_plat + sum(m for m, _ in self.points)

    @property
    def m_limb(self):
        return self.m_cyl + self.m_pis if self.rps else self.m_leg

    @property
    def W(self):
        return (self.m_comp + 3 * self.m_limb) * float(np.linalg.norm(self.g))

    @property
    def Lc(self):
        """Length scale of the couples."""
        return self.lc + self.lp if self.rps else self.L

    def composite(self):
        """Composite platform: mass, CoM c' (platform coords), inertia about C (platform axes)."""
        if self.I_plat is None:
            m, r = self.m_plat, self.rp
            I_P = np.diag([m * r * r / 4, m * r * r / 4, m * r * r / 2])
        else:
            I_P = np.diag(self.I_plat)
        I_P = I_P.astype(float).copy()
        mt = self.m_plat
        mc = np.zeros(3)
        for m, d in self.points:
            d = np.asarray(d, float)
            I_P += m * (d @ d * np.eye(3) - np.outer(d, d))
            mt += m
            mc += m * d
        c = mc / mt
        I_C = I_P - mt * (c @ c * np.eye(3) - np.outer(c, c))
        return mt, c, I_C


def _vec(x, default):
    return np.array(default if x is None else x, dtype=float)


def _angles(deg):
    """Angles in degrees -> radians; exactly (0, 120, 240) -> 0, 2 pi/3, 4 pi/3."""
    vals = [float(a) for a in deg]
    if len(vals) != 3:
        raise ValueError(f"three angles expected, got {deg}")
    if vals == SYM_DEG:
        return SYM_RAD.copy()
    return np.array([a * math.pi / 180.0 for a in vals])


def params_from_job(job: dict) -> Params:
    mech = job.get("mechanism", {})
    mass = job.get("mass", {})
    load = job.get("load", {})
    kind = mech.get("kind", "3-PRS")
    P = Params(kind=kind)
    if kind == "3-PRS":
        P.Rb = float(mech.get("base_radius", 0.18))
        P.rp = float(mech.get("platform_radius", 0.36))
        P.L = float(mech.get("leg_length", 1.0))
        P.beta = float(mech.get("rail_angle_deg", 0.0)) * math.pi / 180.0
        P.m_leg = float(mass.get("leg", 3.0))
    elif kind == "3-RPS":
        P.Rb = float(mech.get("base_radius", 0.3))
        P.rp = float(mech.get("platform_radius", 0.2))
        P.lc = float(mech.get("cylinder_length", 0.8))
        P.lp = float(mech.get("piston_length", 0.8))
        P.qmin = float(mech.get("min_length", max(P.lc, P.lp)))
        P.qmax = float(mech.get("max_length", P.lc + P.lp))
        P.m_cyl = float(mass.get("cylinder", 2.0))
        P.m_pis = float(mass.get("piston", 1.0))
    else:
        raise ValueError(f"unsupported mechanism kind {kind!r}")
    la = mech.get("limb_angles_deg", SYM_DEG)
    pa = mech.get("platform_angles_deg", la)
    P.alpha, P.gamma = _angles(la), _angles(pa)
    P.symmetric = [float(a) for a in la] == SYM_DEG and [float(a) for a in pa] == SYM_DEG
    P.g = _vec(mech.get("gravity"), [0.0, 0.0, -9.81])
    P.m_plat = float(mass.get("platform", 9.8))
    if "platform_inertia" in mass:
        P.I_plat = _vec(mass["platform_inertia"], None)
    P.points = [(float(pm["mass"]), _vec(pm["at"], None)) for pm in mass.get("points", [])]
    P.f_ext = _vec(load.get("force"), [0, 0, 0])
    P.m_ext = _vec(load.get("moment"), [0, 0, 0])
    P.at_ext = _vec(load.get("at"), [0, 0, 0])
    return P


def job_kind(job):
    """prototype / 3-PRS / 3-RPS, from the keys present."""
    mech = job.get("mechanism", {})
    if "kind" not in mech:
        return "prototype"
    return mech["kind"]


def lin_range(spec):
    """Scalar or {start, stop, n} (conventions.md: start + (stop-start)*i/(n-1))."""
    if isinstance(spec, dict):
        s, e, n = float(spec["start"]), float(spec["stop"]), int(spec["n"])
        if n == 1:
            return np.array([s])
        return np.array([s + (e - s) * i / (n - 1) for i in range(n)])
    return np.array([float(spec)])


def harmonic(spec, t):
    """value, first and second time derivatives of a trajectory input."""
    if not isinstance(spec, dict):
        return float(spec), 0.0, 0.0
    v, d, dd = float(spec.get("offset", 0.0)), 0.0, 0.0
    for h in spec.get("harmonics", []):
        A, T, ph = float(h["amplitude"]), float(h["period"]), float(h.get("phase", 0.0))
        w = 2 * math.pi / T
        v += A * math.sin(w * t + ph)
        d += A * w * math.cos(w * t + ph)
        dd += -A * w * w * math.sin(w * t + ph)
    return v, d, dd


def job_samples(job):
    """[(sample, t or None, (z, psi, theta), (dz, dpsi, dtheta), (ddz, ddpsi, ddtheta))]."""
    out = []
    if "grid" in job:
        gz, gp, gt = (lin_range(job["grid"][k]) for k in ("z", "psi", "theta"))
        s = 0
        for z in gz:
            for p in gp:
                for t in gt:
                    out.append((s, None, (z, p, t), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
                    s += 1
    else:
        tr = job["trajectory"]
        for s, t in enumerate(lin_range(tr["time"])):
            vals = [harmonic(tr[k], t) for k in ("z", "psi", "theta")]
            out.append((s, t, tuple(v[0] for v in vals), tuple(v[1] for v in vals),
                        tuple(v[2] for v in vals)))
    return out


def job_modes(job):
    return list(job.get("analysis", {}).get("modes", ["kinetostatic"]))


# --------------------------------------------------------------------------- #
# Nominal inverse kinematics (numpy; complex-safe for complex-step derivatives)
# --------------------------------------------------------------------------- #
def parasitic_closed(psi, theta, rp):
    cps, sps, cth, sth = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
    # atan2(s_psi s_theta, c_psi + c_theta) with c_psi + c_theta > 0 on the workspace;
    # written with arctan so that it also accepts complex arguments.
    phi = np.arctan(sps * sth / (cps + cth))
    y = -rp * cps * np.sin(phi)
    x = rp / 2 * (cth * np.cos(phi) - np.cos(phi) * cps + sps * sth * np.sin(phi))
    return x, y, phi


def parasitic_newton(P: Params, z, psi, theta):
    """A_j . y_j = 0 for (X, Y, Phi) by Newton with the analytic Jacobian, started from the
    closed-form values (the family's rule); complex-safe.  None: no convergence."""
    u = np.array(parasitic_closed(psi, theta, P.rp), dtype=np.result_type(z, psi, theta, float))
    Rpre = ry(theta) @ rx(psi)
    ys = [P.yj(j) for j in range(3)]
    ap = [P.a_prime(j) for j in range(3)]
    polish = False
    for _ in range(NEWTON_MAXIT):
        x, y, phi = u
        p = np.array([x, y, z])
        R, dR = Rpre @ rz(phi), Rpre @ drz(phi)
        res = np.array([(p + R @ ap[j]) @ ys[j] for j in range(3)])
        J = np.array([[ys[j][0], ys[j][1], (dR @ ap[j]) @ ys[j]] for j in range(3)])
        step = np.linalg.solve(J, -res)
        u = u + step
        if polish:
            return u
        if np.max(np.abs(step.real)) <= NEWTON_TOL:
            polish = True        # one more step: round-off level, settles a complex step
    return u if polish else None


def parasitic_newton_fd(P: Params, z, psi, theta):
    """The same constraints solved from zero with a finite-difference Jacobian (real only):
    an independent check of the closed forms and of parasitic_newton."""
    def res(u):
        x, y, phi = u
        R = euler_R(phi, psi, theta)
        p = np.array([x, y, z])
        return np.array([(p + R @ P.a_prime(j)) @ P.yj(j) for j in range(3)])

    u = np.zeros(3)
    for _ in range(60):
        r = res(u)
        J = np.empty((3, 3))
        for k in range(3):
            du = np.zeros(3)
            du[k] = 1e-7
            J[:, k] = (res(u + du) - res(u - du)) / 2e-7
        step = np.linalg.solve(J, -r)
        u = u + step
        if np.max(np.abs(step)) < 1e-15:
            break
    return u


def parasitic(P: Params, z, psi, theta):
    if P.symmetric:
        return parasitic_closed(psi, theta, P.rp)
    return parasitic_newton(P, z, psi, theta)


def pose(P: Params, z, psi, theta):
    """Platform pose, joint points, actuators, leg directions and leg bodies
    [(mass, centre, length)] per limb.  Complex-safe (status from the real parts)."""
    sol = parasitic(P, z, psi, theta)
    if sol is None:
        return dict(status="unreachable", why="Newton")
    x, y, phi = sol
    R = euler_R(phi, psi, theta)
    p = np.array([x, y, z])
    A, B, q, e, bodies, roots, rad2 = [], [], [], [], [], [], []
    status = "ok"
    for j in range(3):
        xj = P.xj(j)
        Aj = p + R @ P.a_prime(j)
        if not P.rps:
            cb, sb = math.cos(P.beta), math.sin(P.beta)
            rho, h = Aj @ xj, Aj @ EZ
            t = cb * (rho - P.Rb) - sb * h
            s = cb * h + sb * (rho - P.Rb)
            rad = P.L ** 2 - t * t
            if np.real(rad) < 0:
                return dict(status="unreachable", why="radicand", x=x, y=y, phi=phi)
            root = np.sqrt(rad)
            if np.real(root) < 1e-6 * P.L:
                status = "near_singular"
            qj = s - root
            b0 = P.Rb * xj
            Bj = b0 + qj * P.rail(j)
            ej = (Aj - Bj) / P.L
            bod = [(P.m_leg, (Aj + Bj) / 2, P.L)]
            # docs/model.md 10.1's form of the radicand, for the self-test
            rel = Aj - b0
            sd = P.rail(j) @ rel
            rad2.append(sd * sd - rel @ rel + P.L ** 2)
            roots.append(root)
        else:
            Bj = P.Rb * xj
            v = Aj - Bj
            qj = norm_c(v)
            if not (P.qmin <= np.real(qj) <= P.qmax):
                return dict(status="unreachable", why="stroke", x=x, y=y, phi=phi)
            ej = v / qj
            bod = [(P.m_cyl, Bj + P.lc / 2 * ej, P.lc), (P.m_pis, Aj - P.lp / 2 * ej, P.lp)]
        A.append(Aj)
        B.append(Bj)
        q.append(qj)
        e.append(ej)
        bodies.append(bod)
    return dict(status=status, x=x, y=y, phi=phi, R=R, p=p, A=A, B=B, q=np.array(q), e=e,
                bodies=bodies, roots=roots, rad2=rad2)


def reachable(P: Params, z, psi, theta):
    return pose(P, z, psi, theta)["status"] == "ok"


# --------------------------------------------------------------------------- #
# Pinocchio model
# --------------------------------------------------------------------------- #
def _rod(m, l, com_z):
    return pin.Inertia(m, np.array([0.0, 0.0, com_z]), np.diag([m * l * l / 12, m * l * l / 12, 0.0]))


class PinMech:
    """The 3-PRS or 3-RPS as a Pinocchio tree plus two 3-D loop closures."""

    def __init__(self, P: Params):
        self.P = P
        m = pin.Model()
        m.gravity = pin.Motion(np.asarray(P.g, float), np.zeros(3))
        self.jR, self.jAct, self.tipJ, self.tipOff, self.Rpre, self.tip = [], [], [], [], [], []
        self.bodyJ = []       # per limb: [(joint, com offset in its frame)] = bodies of k["bodies"]
        for j in range(3):
            xj = P.xj(j)
            Rl = rz(P.alpha[j])
            if not P.rps:
                Rpre = Rl @ ry(P.beta)        # local z = d_j, local y = y_j
                jp = m.addJoint(0, pin.JointModelPZ(), pin.SE3(Rpre, P.Rb * xj), f"slider{j+1}")
                jr = m.addJoint(jp, pin.JointModelRY(), pin.SE3.Identity(), f"leg{j+1}")
                m.appendBodyToJoint(jr, _rod(P.m_leg, P.L, P.L / 2), pin.SE3.Identity())
                act, tipj, off = jp, jr, np.array([0.0, 0.0, P.L])
                self.bodyJ.append([(jr, np.array([0.0, 0.0, P.L / 2]))])
            else:
                Rpre = Rl                         # local y = y_j
                jr = m.addJoint(0, pin.JointModelRY(), pin.SE3(Rpre, P.Rb * xj), f"cyl{j+1}")
                m.appendBodyToJoint(jr, _rod(P.m_cyl, P.lc, P.lc / 2), pin.SE3.Identity())
                jp = m.addJoint(jr, pin.JointModelPZ(), pin.SE3.Identity(), f"piston{j+1}")
                m.appendBodyToJoint(jp, _rod(P.m_pis, P.lp, -P.lp / 2), pin.SE3.Identity())
                act, tipj, off = jp, jp, np.zeros(3)
                self.bodyJ.append([(jr, np.array([0.0, 0.0, P.lc / 2])),
                                   (jp, np.array([0.0, 0.0, -P.lp / 2]))])
            self.jR.append(jr)
            self.jAct.append(act)
            self.tipJ.append(tipj)
            self.tipOff.append(off)
            self.Rpre.append(Rpre)
            if j == 0:
                # platform joint frame: origin A_1, axes = platform axes
                self.jS = m.addJoint(tipj, pin.JointModelSpherical(), pin.SE3(np.eye(3), off), "sph1")
                mt, c, I_C = P.composite()
                Y = pin.Inertia(mt, c - P.a_prime(0), I_C)
                m.appendBodyToJoint(self.jS, Y, pin.SE3.Identity())
        for j in range(3):
            self.tip.append(m.addFrame(pin.Frame(f"tip{j+1}", self.tipJ[j],
                                                 pin.SE3(np.eye(3), self.tipOff[j]),
                                                 pin.FrameType.OP_FRAME), False))
        a1 = P.a_prime(0)
        self.fA = [m.addFrame(pin.Frame(f"A{j+1}", self.jS, pin.SE3(np.eye(3), P.a_prime(j) - a1),
                                        pin.FrameType.OP_FRAME), False) for j in range(3)]
        self.fP = m.addFrame(pin.Frame("P", self.jS, pin.SE3(np.eye(3), -a1),
                                       pin.FrameType.OP_FRAME), False)
        self.model = m
        self.data = m.createData()
        self.iv_act = [m.joints[ja].idx_v for ja in self.jAct]
        assert m.nv == 9 and m.nq == 10

    # configuration ---------------------------------------------------------
    def config(self, z, psi, theta):
        P, m = self.P, self.model
        k = pose(P, z, psi, theta)
        q = np.zeros(m.nq)
        distR = []
        for j in range(3):
            # leg direction in the revolute's parent frame is R_y(ang) z = (sin, 0, cos)
            v = self.Rpre[j].T @ k["e"][j]
            ang = math.atan2(v[0], v[2])
            q[m.joints[self.jAct[j]].idx_q] = k["q"][j]
            q[m.joints[self.jR[j]].idx_q] = ang
            distR.append(self.Rpre[j] @ ry(ang))
        Rs = distR[0].T @ k["R"]
        iq = m.joints[self.jS].idx_q
        q[iq:iq + 4] = pin.Quaternion(Rs).normalized().coeffs()
        return q, k

    def closure_residual(self, q, k=None):
        """Loop-closure and pose residuals from Pinocchio's own forward kinematics."""
        m, d = self.model, self.data
        pin.framesForwardKinematics(m, d, q)
        r = max(np.max(np.abs(d.oMf[self.tip[j]].translation - d.oMf[self.fA[j]].translation))
                for j in range(3))
        if k is not None:
            r = max(r, np.max(np.abs(d.oMf[self.fP].translation - k["p"])),
                    np.max(np.abs(d.oMf[self.fP].rotation - k["R"])))
            for j in range(3):
                r = max(r, np.max(np.abs(d.oMi[self.jR[j]].translation - k["B"][j])))
        return r

    # Jacobians -------------------------------------------------------------
    def _jacobians(self, q):
        m, d = self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        W = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        Jc = np.vstack([pin.getFrameJacobian(m, d, self.tip[j], W)[:3]
                        - pin.getFrameJacobian(m, d, self.fA[j], W)[:3] for j in (1, 2)])
        JP = pin.getFrameJacobian(m, d, self.fP, W)
        return Jc, JP

    @staticmethod
    def euler_E(phi, psi, theta):
        """omega = E (dPhi, dPsi, dTheta); columns a3, a2, a1 of docs/model.md section 6."""
        a1 = EY
        a2 = ry(theta) @ EX
        a3 = ry(theta) @ rx(psi) @ EZ
        return np.column_stack([a3, a2, a1]), a1, a2, a3

    def motion(self, q, k, psi, theta, d1, d2):
        """Generalized velocity and acceleration from the inputs' derivatives."""
        m, d = self.model, self.data
        Jc, JP = self._jacobians(q)
        E, a1, a2, a3 = self.euler_E(k["phi"], psi, theta)
        Ei = np.linalg.inv(E)
        Jang = Ei @ JP[3:]                       # rows: dPhi, dPsi, dTheta
        K = np.vstack([Jc, JP[2:3], Jang[1:3]])
        v = np.linalg.solve(K, np.r_[np.zeros(6), d1[0], d1[1], d1[2]])
        dphi = Jang[0] @ v
        # drift terms: classical accelerations with zero joint acceleration
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        W = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        acc = lambda f: pin.getFrameClassicalAcceleration(m, d, f, W)
        drift_c = np.concatenate([acc(self.tip[j]).linear - acc(self.fA[j]).linear for j in (1, 2)])
        aP = acc(self.fP)
        dpsi, dth = d1[1], d1[2]
        Edot_eta = dpsi * np.cross(dth * a1, a2) + dphi * np.cross(dth * a1 + dpsi * a2, a3)
        rhs_ang = Ei @ (-aP.angular + Edot_eta)
        rhs = np.r_[-drift_c, d2[0] - aP.linear[2], d2[1] + rhs_ang[1], d2[2] + rhs_ang[2]]
        a = np.linalg.solve(K, rhs)
        return v, a

    # reactions ---------------------------------------------------------------
    def _ext_forces(self, q, lam=None):
        """External forces (local joint frames, about joint origins): load, and lambda."""
        m, d, P = self.model, self.data, self.P
        pin.forwardKinematics(m, d, q)
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        Rp = d.oMi[self.jS].rotation
        a1 = P.a_prime(0)
        fl = Rp.T @ P.f_ext
        fext[self.jS] = pin.Force(fl, np.cross(P.at_ext - a1, fl) + Rp.T @ P.m_ext)
        if lam is not None:
            for n, j in enumerate((1, 2)):
                lj = lam[3 * n:3 * n + 3]
                jt = self.tipJ[j]
                Rl = d.oMi[jt].rotation
                fl = Rl.T @ lj                         # lambda_j on leg j at its tip
                fext[jt] = fext[jt] + pin.Force(fl, np.cross(self.tipOff[j], fl))
                fp = Rp.T @ (-lj)                      # -lambda_j on the platform at A_j
                fext[self.jS] = fext[self.jS] + pin.Force(fp, np.cross(P.a_prime(j) - a1, fp))
        return fext

    def reactions(self, q, v=None, a=None):
        m, d = self.model, self.data
        v = np.zeros(m.nv) if v is None else v
        a = np.zeros(m.nv) if a is None else a
        Jc, _ = self._jacobians(q)
        rhs = pin.rnea(m, d, q, v, a, self._ext_forces(q)).copy()
        S = np.zeros((m.nv, 3))
        for j, iv in enumerate(self.iv_act):
            S[iv, j] = 1.0
        sol = np.linalg.solve(np.hstack([S, Jc.T]), rhs)
        tau, lam = sol[:3], sol[3:]
        res = pin.rnea(m, d, q, v, a, self._ext_forces(q, lam)).copy()
        res[self.iv_act] -= tau                                # should vanish
        out = dict(tau=tau, lam=lam, rnea_res=float(np.max(np.abs(res))))
        fR, mR = [], []
        for j in range(3):
            Rl = d.oMi[self.jR[j]].rotation
            fj = d.f[self.jR[j]]
            fR.append(Rl @ fj.linear)
            mR.append(Rl @ fj.angular)
        fs1 = d.f[self.jS]
        fS = [d.oMi[self.jS].rotation @ fs1.linear, -lam[0:3], -lam[3:6]]
        out.update(fR=fR, mR=mR, fS=fS, sph_moment=float(np.max(np.abs(fs1.angular))))
        return out


# --------------------------------------------------------------------------- #
# Independent hand checks (numpy only)
# --------------------------------------------------------------------------- #
def fd_kinematics(P, inputs_of_t, t, h=2e-3):
    """Body kinematics by 8th-order central differences of the configuration in time."""
    c1 = np.array([4 / 5, -1 / 5, 4 / 105, -1 / 280])
    c2 = np.array([8 / 5, -1 / 5, 8 / 315, -1 / 560])
    mt, c, _ = P.composite()
    P = dataclasses.replace(P, qmin=-math.inf, qmax=math.inf)   # the stencil may leave the stroke

    def cfg(tt):
        z, ps, th = inputs_of_t(tt)
        return pose(P, z, ps, th)

    k0 = cfg(t)
    ks = {i: cfg(t + i * h) for i in (-4, -3, -2, -1, 1, 2, 3, 4)}
    ks[0] = k0
    if any("R" not in k for k in ks.values()):
        return None                   # the stencil leaves the workspace

    def d1(f):
        return sum(c1[i - 1] * (f(ks[i]) - f(ks[-i])) for i in range(1, 5)) / h

    def d2(f):
        return (sum(c2[i - 1] * (f(ks[i]) + f(ks[-i])) for i in range(1, 5)) - 205 / 72 * f(k0)) / h ** 2

    out = {}
    R0 = k0["R"]
    Rd, Rdd = d1(lambda k: k["R"]), d2(lambda k: k["R"])
    w = vee(Rd @ R0.T)
    out["omega"] = w
    out["domega"] = vee(Rdd @ R0.T - skew(w) @ skew(w))
    out["aC"] = d2(lambda k: k["p"] + k["R"] @ c)
    out["vP"] = d1(lambda k: k["p"])
    for j in range(3):
        e, ed, edd = k0["e"][j], d1(lambda k: k["e"][j]), d2(lambda k: k["e"][j])
        out[f"w{j}"] = np.cross(e, ed)
        out[f"dw{j}"] = np.cross(e, edd)
        for b in range(len(k0["bodies"][j])):
            out[f"a{j}_{b}"] = d2(lambda k: k["bodies"][j][b][1])
        out[f"dq{j}"] = d1(lambda k: k["q"][j])
        out[f"ddq{j}"] = d2(lambda k: k["q"][j])
    return out


def equilibrium_residual(P, k, r, kin=None):
    """Max residual of docs/model.md section 4 (24 equations) relative to W, W*L.

    Leg j (one body for 3-PRS; cylinder + piston summed for 3-RPS), moments about B_j:
      f_Rj - f_Sj + sum m_b g = sum m_b a_b
      m_Rj - (A_j - B_j) x f_Sj = sum [I_b dw_j + w_j x I_b w_j + (G_b - B_j) x m_b (a_b - g)]
      m_Rj . y_j = 0 (no couple about the revolute axis)."""
    mt, c, I_Cp = P.composite()
    g = P.g
    R = k["R"]
    C = k["p"] + R @ c
    E = k["p"] + R @ P.at_ext
    I_C = R @ I_Cp @ R.T
    res_f, res_m = [], []
    for j in range(3):
        B, A = k["B"][j], k["A"][j]
        fR, mR, fS = r["fR"][j], r["mR"][j], r["fS"][j]
        e = k["e"][j]
        wj = dwj = np.zeros(3)
        if kin is not None:
            wj, dwj = kin[f"w{j}"], kin[f"dw{j}"]
        rf = fR - fS
        rm = mR - np.cross(A - B, fS)
        for b, (mb, G, lb) in enumerate(k["bodies"][j]):
            ab = np.zeros(3) if kin is None else kin[f"a{j}_{b}"]
            Ib = mb * lb ** 2 / 12 * (np.eye(3) - np.outer(e, e))
            rf = rf + mb * g - mb * ab
            rm = rm - Ib @ dwj - np.cross(wj, Ib @ wj) - np.cross(G - B, mb * (ab - g))
        res_f.append(rf)
        res_m.append(rm)
        res_m.append(np.array([mR @ P.yj(j)]))
    aC = w = dw = np.zeros(3)
    if kin is not None:
        aC, w, dw = kin["aC"], kin["omega"], kin["domega"]
    res_f.append(sum(r["fS"]) + mt * g + P.f_ext - mt * aC)
    res_m.append(sum(np.cross(k["A"][j] - C, r["fS"][j]) for j in range(3))
                 + np.cross(E - C, P.f_ext) + P.m_ext - I_C @ dw - np.cross(w, I_C @ w))
    return max(np.max(np.abs(np.concatenate(res_f))) / P.W,
               np.max(np.abs(np.concatenate(res_m))) / (P.W * P.Lc))


def actuator_residual(P, k, r, kin=None):
    """3-PRS: tau_j = f_Rj . d_j (massless slider).  3-RPS: the piston's balance along e_j,
    tau_j = e_j . (f_Sj - m_pis (g - a_pis)).  Relative to W."""
    worst = 0.0
    for j in range(3):
        if not P.rps:
            ref = r["fR"][j] @ P.rail(j)
        else:
            ap = np.zeros(3) if kin is None else kin[f"a{j}_1"]
            ref = k["e"][j] @ (r["fS"][j] - P.m_pis * (P.g - ap))
        worst = max(worst, abs(r["tau"][j] - ref))
    return worst / P.W


def virtual_work_residual(P, z, psi, theta, tau):
    """Sum tau_j dq_j + dW_gravity + dW_ext for the 3 input directions (complex step)."""
    mt, c, _ = P.composite()
    h = 1e-30
    worst, scale = 0.0, P.W * P.Lc
    k0 = pose(P, z, psi, theta)
    for n in range(3):
        u = np.array([z, psi, theta], dtype=complex)
        u[n] += 1j * h
        k = pose(P, *u)
        dq = np.imag(k["q"]) / h
        dW = 0.0
        for bods in k["bodies"]:
            for mb, G, _ in bods:
                dW += mb * P.g @ (np.imag(G) / h)
        dC = np.imag(k["p"] + k["R"] @ c) / h
        dE = np.imag(k["p"] + k["R"] @ P.at_ext) / h
        dalpha = vee((np.imag(k["R"]) / h) @ k0["R"].T)
        vw = tau @ dq + dW + mt * P.g @ dC + P.f_ext @ dE + P.m_ext @ dalpha
        worst = max(worst, abs(vw) / scale)
    return worst


# --------------------------------------------------------------------------- #
# Random jobs
# --------------------------------------------------------------------------- #
def u(rng, a, b):
    return float(rng.uniform(a, b))


def _masses_loads(rng, job, pt_height):
    """Optional platform inertia, point masses, external load, clearances (in place)."""
    if rng.random() < 0.5:
        job["mass"]["platform_inertia"] = [u(rng, 0.1, 0.5), u(rng, 0.1, 0.5), u(rng, 0.2, 1.0)]
    npts = int(rng.integers(0, 3))
    job["mass"]["points"] = [{"mass": u(rng, 1.0, 30.0),
                              "at": [u(rng, -0.3, 0.3), u(rng, -0.3, 0.3), u(rng, -pt_height, pt_height)]}
                             for _ in range(npts)]
    P = params_from_job(job)
    W = P.W
    job["load"] = {"force": list(rng.normal(0, 0.2 * W, 3)),
                   "moment": list(rng.normal(0, 0.05 * W, 3)),
                   "at": [u(rng, -0.3, 0.3), u(rng, -0.3, 0.3), u(rng, -0.5, 0.5)]}
    job["clearance"] = {k: (1e-4 if rng.random() < 0.5 else 0.0)
                        for k in ("s_radial", "r_radial", "r_axial", "r_angular")}


def _inputs(rng, job, trajectory, z0, dz, ang, ang_traj):
    """[grid] (z0 +- dz, psi/theta in about +-ang) or [trajectory] (amplitudes dz, ang_traj)."""
    if not trajectory:
        a, b = u(rng, 0.6, 1.0) * ang, u(rng, 0.6, 1.0) * ang
        job["grid"] = {"z": {"start": z0 - dz, "stop": z0 + dz, "n": 3},
                       "psi": {"start": -a, "stop": a + u(rng, -0.05, 0.05), "n": 5},
                       "theta": {"start": -b + u(rng, -0.05, 0.05), "stop": b, "n": 5}}
    else:
        job["analysis"] = {"modes": ["kinetostatic", "dynamic"]}

        def harm(off, amp):
            return {"offset": off, "harmonics": [
                {"amplitude": amp * u(rng, 0.3, 1.0), "period": u(rng, 1.5, 5.0),
                 "phase": u(rng, -math.pi, math.pi)} for _ in range(int(rng.integers(1, 3)))]}
        t0 = u(rng, 0.0, 2.0)
        job["trajectory"] = {"time": {"start": t0, "stop": t0 + u(rng, 2.0, 5.0), "n": 41},
                             "z": harm(z0, dz), "psi": harm(u(rng, -0.05, 0.05), ang_traj[0]),
                             "theta": harm(u(rng, -0.05, 0.05), ang_traj[1])}


def _gravity(rng):
    return [u(rng, -0.6, 0.6), u(rng, -0.6, 0.6), -9.81 * u(rng, 0.95, 1.05)]


def random_prototype(rng, idx, trajectory):
    """The paper's 3-PRS layout, original keys only."""
    L = u(rng, 0.9, 1.1)
    job = {
        "name": f"pincheck_{idx:03d}_proto_{'traj' if trajectory else 'grid'}",
        "mechanism": {"base_radius": 0.18 * u(rng, 0.8, 1.2),
                      "platform_radius": 0.36 * u(rng, 0.8, 1.2),
                      "leg_length": L, "gravity": _gravity(rng)},
        "mass": {"platform": u(rng, 5.0, 15.0), "leg": u(rng, 1.0, 5.0)},
    }
    _masses_loads(rng, job, 1.0)
    z0 = 2.05 * L + u(rng, -0.1, 0.1)
    _inputs(rng, job, trajectory, z0, 0.1, 0.45, (0.2, 0.25))
    return job


def _uneven(rng, spread):
    return [a + u(rng, -spread, spread) for a in SYM_DEG]


def random_prs(rng, idx, trajectory, n):
    """3-PRS of the family.  Variant n % 4: horizontal rails pointing inwards (beta = -90)
    on the symmetric layout (closed forms); an inclined rail with a rotated 120-degree limb
    set (Newton); vertical rails with uneven limbs and uneven platform angles; horizontal
    rails pointing outwards (beta = +90) with uneven limbs.  Further jobs mix them."""
    v = n % 4 if n < 4 else int(rng.integers(0, 4))
    beta_deg = [-90.0, u(rng, -60.0, 60.0), 0.0, 90.0][v]
    mech = {"kind": "3-PRS"}
    if v == 0:
        if rng.random() < 0.5:
            mech["limb_angles_deg"] = list(SYM_DEG)
    elif v == 1:
        off = u(rng, 20.0, 100.0)
        mech["limb_angles_deg"] = [off, off + 120.0, off + 240.0]
    elif v == 2:
        mech["limb_angles_deg"] = _uneven(rng, 20.0)
        mech["platform_angles_deg"] = [a + u(rng, -12.0, 12.0) for a in mech["limb_angles_deg"]]
    else:
        mech["limb_angles_deg"] = _uneven(rng, 15.0)
    if n >= 4 and rng.random() < 0.5 and "platform_angles_deg" not in mech:
        mech["platform_angles_deg"] = [a + u(rng, -10.0, 10.0)
                                       for a in mech.get("limb_angles_deg", SYM_DEG)]
    L = u(rng, 0.8, 1.2)
    rp = u(rng, 0.2, 0.45)
    b = math.radians(beta_deg)
    # nominal leg: tilt lam from z towards x_j, slider coordinate q0; then R_b and the
    # height z0 follow from B = A - L e on the rail (A ~ rp x_j + z0 z at psi = theta = 0).
    # The leg stays within 50 deg of its rail (e_j.d_j > 0.64: far from the leg across
    # its rail) and within 60 deg of the vertical (nearly horizontal legs approach a
    # singularity of the platform's vertical support).
    for _ in range(10000):
        lam = b + math.radians(u(rng, -50.0, 50.0))
        q0 = (u(rng, 0.1, 1.0) if abs(math.sin(b)) < 0.2 else u(rng, -1.0, 1.0)) * L
        Rb = rp - L * math.sin(lam) - q0 * math.sin(b)
        z0 = L * math.cos(lam) + q0 * math.cos(b)
        if math.cos(lam) >= 0.5 and 0.05 <= Rb <= 1.5 and 0.4 * L <= z0 <= 3.0 * L:
            break
    mech.update({"rail_angle_deg": beta_deg, "base_radius": Rb, "platform_radius": rp,
                 "leg_length": L, "gravity": _gravity(rng)})
    if beta_deg == 0.0 and rng.random() < 0.5:
        del mech["rail_angle_deg"]           # the default
    # keys in a fixed order (kind first)
    order = ["kind", "base_radius", "platform_radius", "leg_length", "gravity", "rail_angle_deg",
             "limb_angles_deg", "platform_angles_deg"]
    job = {"name": f"pincheck_{idx:03d}_prs_{'traj' if trajectory else 'grid'}",
           "mechanism": {kk: mech[kk] for kk in order if kk in mech},
           "mass": {"platform": u(rng, 5.0, 15.0), "leg": u(rng, 1.0, 5.0)}}
    _masses_loads(rng, job, 1.0)
    _inputs(rng, job, trajectory, z0, 0.05 * L, 0.3, (0.15, 0.2))
    return job


def random_rps(rng, idx, trajectory, n):
    """3-RPS.  Variant n % 3: symmetric layout (closed forms; half the time with the default
    geometry and leg masses, keys omitted); uneven limbs; uneven limbs and platform angles."""
    v = n % 3
    defaults = v == 0 and rng.random() < 0.5
    mech = {"kind": "3-RPS", "base_radius": u(rng, 0.2, 0.45), "platform_radius": u(rng, 0.12, 0.3),
            "gravity": _gravity(rng)}
    if v == 0 and rng.random() < 0.5:
        mech["limb_angles_deg"] = list(SYM_DEG)
    elif v == 1:
        mech["limb_angles_deg"] = _uneven(rng, 20.0)
    elif v == 2:
        mech["limb_angles_deg"] = _uneven(rng, 20.0)
        mech["platform_angles_deg"] = [a + u(rng, -12.0, 12.0) for a in mech["limb_angles_deg"]]
    lc, lp = u(rng, 0.5, 0.9), u(rng, 0.5, 0.9)
    mech["cylinder_length"], mech["piston_length"] = lc, lp
    if defaults:
        for kk in ("base_radius", "platform_radius", "cylinder_length", "piston_length"):
            del mech[kk]
        lc = lp = 0.8
    P0 = params_from_job({"mechanism": mech})
    qmin, qmax = max(lc, lp), lc + lp
    if not defaults and rng.random() < 0.5:
        qmin += u(rng, 0.0, 0.05)
        qmax -= u(rng, 0.0, 0.05)
        mech["min_length"], mech["max_length"] = qmin, qmax
    qmid = (qmin + qmax) / 2
    z0 = math.sqrt(qmid ** 2 - (P0.rp - P0.Rb) ** 2)
    job = {"name": f"pincheck_{idx:03d}_rps_{'traj' if trajectory else 'grid'}",
           "mechanism": mech,
           "mass": {"platform": u(rng, 5.0, 15.0), "cylinder": u(rng, 1.0, 4.0),
                    "piston": u(rng, 0.5, 2.5)}}
    if defaults:
        del job["mass"]["cylinder"], job["mass"]["piston"]
    _masses_loads(rng, job, 0.5)
    _inputs(rng, job, trajectory, z0, 0.05, 0.3, (0.15, 0.2))
    if "max_length" in mech and rng.random() < 0.5:
        # a stroke that cuts the sampled range: about 10 % of the samples out of reach
        P = params_from_job(job)
        P.qmax = math.inf
        qs = [np.max(k["q"]) for k in (pose(P, *x0) for _, _, x0, _, _ in job_samples(job))
              if k["status"] == "ok"]
        mech["max_length"] = float(np.quantile(qs, u(rng, 0.85, 0.95)))
    return job


def random_job(seed, idx, kind, trajectory, n):
    """Job idx of the given kind (n-th of its kind), from its own generator; redrawn until
    at least 80 % of its samples are reachable (grid edges may fall outside)."""
    rng = np.random.default_rng([seed, idx])
    for _ in range(50):
        if kind == "prototype":
            job = random_prototype(rng, idx, trajectory)
        elif kind == "3-PRS":
            job = random_prs(rng, idx, trajectory, n)
        else:
            job = random_rps(rng, idx, trajectory, n)
        P = params_from_job(job)
        smp = job_samples(job)
        if sum(reachable(P, *x0) for _, _, x0, _, _ in smp) >= 0.8 * len(smp):
            return job
    raise RuntimeError(f"no reachable random job for {kind} #{idx}")


def job_plan(n_jobs, kinds):
    """[(idx, kind, trajectory, n)]: job idx is of kind idx mod k, alternately grid / trajectory."""
    nk = len(kinds)
    return [(i, kinds[i % nk], (i // nk) % 2 == 1, i // nk) for i in range(n_jobs)]


def _toml_val(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_val(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_val(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def to_toml(job):
    lines = []
    for k, v in job.items():
        if not isinstance(v, dict):
            lines.append(f"{k} = {_toml_val(v)}")
    for k, v in job.items():
        if isinstance(v, dict):
            lines.append(f"\n[{k}]")
            for kk, vv in v.items():
                lines.append(f"{kk} = {_toml_val(vv)}")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- #
# Reference computation for one job
# --------------------------------------------------------------------------- #
def reference(job, mode, model=None):
    """{sample: dict(t, inputs, kin, reactions)} for the samples whose status is ok."""
    P = params_from_job(job)
    M = model or PinMech(P)
    out = {}
    for s, t, x0, x1, x2 in job_samples(job):
        z, psi, theta = x0
        if not reachable(P, z, psi, theta):
            continue
        q, k = M.config(z, psi, theta)
        if mode == "dynamic":
            v, a = M.motion(q, k, psi, theta, x1, x2)
        else:
            v = a = None
        r = M.reactions(q, v, a)
        r["closure"] = M.closure_residual(q, k)
        out[s] = dict(t=t, inputs=x0, k=k, r=r, q=q, v=v, a=a)
    return out


# --------------------------------------------------------------------------- #
# Self-test
# --------------------------------------------------------------------------- #
def selftest(n_jobs, seed, kinds):
    worst = {}
    bad = set()
    cur = [None, None]          # job x mode label, kind

    def note(key, val, tol):
        val = float(val) if val == val else float("inf")
        w = worst.setdefault((cur[1], key), [0.0, tol, ""])
        if val >= w[0]:
            w[0], w[2] = val, cur[0]
        if val > tol:
            bad.add(cur[0])

    # The J_c and constraintDynamics checks use Pinocchio's own constraint machinery
    # (RigidConstraintModel), independent of the hand-built J_c and 9 x 9 solve.
    jm = []
    no_stencil = {}
    for ij, kind, traj, n in job_plan(n_jobs, kinds):
        if kind == "6-UPS":
            job = tomllib.loads(to_toml(random_ups_job(seed, ij, traj, n)))

            def begin(mode, job=job):
                cur[0], cur[1] = f"{job['name']} {mode}", "6-UPS"
                jm.append(cur[0])
            ups_selftest_job(job, note, begin)
            continue
        job = tomllib.loads(to_toml(random_job(seed, ij, kind, traj, n)))   # round-trip the TOML
        assert job_kind(job) == kind
        P = params_from_job(job)
        M = PinMech(P)
        WL = P.W * P.Lc
        for mode in job_modes(job):
            cur[0], cur[1] = f"{job['name']} {mode}", kind
            jm.append(cur[0])
            ref = reference(job, mode, M)
            samples = {s: (t, x0) for s, t, x0, _, _ in job_samples(job)}
            if not ref:
                bad.add(cur[0])
            for s, e in ref.items():
                r, k = e["r"], e["k"]
                z, psi, theta = e["inputs"]
                xk = np.array([k["x"], k["y"], k["phi"]])
                note("closure residual (FK, m / rad)", r["closure"], 1e-12)
                xn = parasitic_newton_fd(P, z, psi, theta)
                if P.symmetric:
                    note("parasitic closed form vs Newton", np.max(np.abs(xn - xk)), 1e-12)
                else:
                    note("parasitic Newton vs FD-Newton from zero", np.max(np.abs(xn - xk)), 1e-12)
                note("parasitic: max |A_j . y_j| (m)",
                     max(abs(k["A"][j] @ P.yj(j)) for j in range(3)), 1e-14)
                if not P.rps:
                    note("actuator: radicand, t_j form vs model 10.1 form / L^2",
                         max(abs(k["roots"][j] ** 2 - k["rad2"][j]) for j in range(3)) / P.L ** 2, 1e-12)
                    note("actuator: sqrt(radicand) - L e_j.d_j / L",
                         max(abs(k["roots"][j] - P.L * k["e"][j] @ P.rail(j)) for j in range(3)) / P.L,
                         1e-12)
                else:
                    note("actuator: |q_j - |A_j - B_j|| (m)",
                         max(abs(k["q"][j] - np.linalg.norm(k["A"][j] - k["B"][j])) for j in range(3)),
                         1e-14)
                note("RNEA residual on passive dofs / W", r["rnea_res"] / P.W, 1e-12)
                note("spherical joint moment / (W L)", r["sph_moment"] / WL, 1e-12)
                act_name = ("tau_j - f_Rj.d_j / W" if not P.rps
                            else "tau_j - e_j.(f_Sj - m_pis (g - a_pis)) / W")
                if mode == "kinetostatic":
                    note(act_name, actuator_residual(P, k, r), 1e-12)
                    note("statics: body equilibrium (model 4) / W", equilibrium_residual(P, k, r), 1e-12)
                    note("statics: virtual work / (W L)", virtual_work_residual(P, z, psi, theta, r["tau"]),
                         1e-12)
                else:
                    tr = job["trajectory"]
                    f = lambda tt: tuple(harmonic(tr[nm], tt)[0] for nm in ("z", "psi", "theta"))
                    kin = fd_kinematics(P, f, e["t"])
                    if kin is None:
                        no_stencil[kind] = no_stencil.get(kind, 0) + 1
                    # Pinocchio's solved motion, to compare with finite differences
                    m, d = M.model, M.data
                    pin.forwardKinematics(m, d, e["q"], e["v"], e["a"])
                    pin.updateFramePlacements(m, d)
                    Wf = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                    vP = pin.getFrameVelocity(m, d, M.fP, Wf)
                    aP = pin.getFrameClassicalAcceleration(m, d, M.fP, Wf)
                    mt, c, _ = P.composite()
                    aC = aP.linear + np.cross(aP.angular, k["R"] @ c) + np.cross(
                        vP.angular, np.cross(vP.angular, k["R"] @ c))
                    # exact inertia terms from Pinocchio's own kinematics
                    kin_ex = dict(omega=vP.angular, domega=aP.angular, aC=aC)
                    pv = [(vP.angular, "omega"), (vP.linear, "vP")]      # (Pinocchio, FD key)
                    pa = [(aP.angular, "domega"), (aC, "aC")]
                    for j in range(3):
                        pv.append((e["v"][M.iv_act[j]], f"dq{j}"))
                        pa.append((e["a"][M.iv_act[j]], f"ddq{j}"))
                        for b, (jb, off) in enumerate(M.bodyJ[j]):
                            wl = d.oMi[jb].rotation @ d.v[jb].angular
                            al = d.oMi[jb].rotation @ d.a[jb].angular
                            aG = pin.getFrameClassicalAcceleration(
                                m, d, jb, pin.SE3(np.eye(3), off), Wf).linear
                            pv.append((wl, f"w{j}"))
                            pa += [(al, f"dw{j}"), (aG, f"a{j}_{b}")]
                            kin_ex[f"a{j}_{b}"] = aG
                            if b == 0:
                                kin_ex.update({f"w{j}": wl, f"dw{j}": al})
                    if kin is not None:
                        dv = max(np.max(np.abs(x - kin[key])) for x, key in pv)
                        da = max(np.max(np.abs(x - kin[key])) for x, key in pa)
                        note("dynamics: velocity vs 8th-order FD", dv, 1e-8)
                        note("dynamics: acceleration vs 8th-order FD", da, 1e-6)
                        note("dynamics: body equilibrium with FD inertia / W",
                             equilibrium_residual(P, k, r, kin), 1e-7)
                    note("dynamics: body equilibrium, exact inertia / W",
                         equilibrium_residual(P, k, r, kin_ex), 1e-11)
                    note(act_name, actuator_residual(P, k, r, kin_ex), 1e-12)
                    # Pinocchio's constrained forward dynamics with our tau gives our a
                    ea, el = forward_check(M, e["q"], e["v"], e["a"], r)
                    note("dynamics: pin.constraintDynamics(tau): accel, relative", ea, 1e-9)
                    note("dynamics: pin.constraintDynamics(tau): lambda / W", el, 1e-9)
                if s % 7 == 0:
                    note("J_c vs pin.getConstraintJacobian", jacobian_check(M, e["q"]), 1e-12)
                assert samples[s][1] == e["inputs"]
    for kind in kinds:
        print(f"{kind + ' self-test check':62s} {'worst':>9s} {'tol':>6s}       where")
        for (kd, key), (val, tol, where) in worst.items():
            if kd == kind:
                print(f"  {key:60s} {val:9.2e} {tol:6.0e} {'ok  ' if val <= tol else 'FAIL'}  {where}")
        if no_stencil.get(kind):
            print(f"  ({no_stencil[kind]} dynamic samples near the workspace's edge: no FD stencil)")
    for name in jm:
        if name in bad:
            print(f"FAIL {name}")
    print(f"{len(jm) - len(bad)} passed, {len(bad)} failed")
    return not bad


def _constraint_models(M):
    m, P = M.model, M.P
    cms = []
    for j in (1, 2):
        cms.append(pin.RigidConstraintModel(
            pin.ContactType.CONTACT_3D, m, M.tipJ[j], pin.SE3(np.eye(3), M.tipOff[j]),
            M.jS, pin.SE3(np.eye(3), P.a_prime(j) - P.a_prime(0)),
            pin.ReferenceFrame.LOCAL_WORLD_ALIGNED))
    return cms


def jacobian_check(M, q):
    m, d = M.model, M.data
    Jc, _ = M._jacobians(q)
    pin.computeJointJacobians(m, d, q)
    pin.forwardKinematics(m, d, q)
    cms = _constraint_models(M)
    Jp = []
    for cm in cms:
        cd = cm.createData()
        cm.calc(m, d, cd)
        Jp.append(pin.getConstraintJacobian(m, d, cm, cd))
    return np.max(np.abs(np.vstack(Jp) - Jc))


def forward_check(M, q, v, a, r):
    m = M.model
    d = m.createData()
    cms = _constraint_models(M)
    cds = [cm.createData() for cm in cms]
    pin.initConstraintDynamics(m, d, cms, cds)
    tau = np.zeros(m.nv)
    tau[M.iv_act] = r["tau"]
    # external load as an equivalent generalized force, evaluated with Pinocchio
    d2 = m.createData()
    load = pin.rnea(m, d2, q, np.zeros(m.nv), np.zeros(m.nv), M._ext_forces(q)) \
        - pin.rnea(m, d2, q, np.zeros(m.nv), np.zeros(m.nv))
    prox = pin.ProximalSettings(1e-14, 0.0, 1)
    acc = pin.constraintDynamics(m, d, q, v, tau - load, cms, cds, prox)
    return (np.max(np.abs(acc - a)) / max(1.0, np.max(np.abs(a))),
            np.max(np.abs(d.lambda_c - r["lam"])) / M.P.W)


# --------------------------------------------------------------------------- #
# 6-UPS (docs/model.md section 10.3): six U-P-S limbs, all six pose inputs
# --------------------------------------------------------------------------- #
UPS_INPUTS = ("x", "y", "z", "phi", "psi", "theta")


@dataclass
class UpsParams:
    B: np.ndarray                        # (6,3) base points (world)
    AP: np.ndarray                       # (6,3) platform points (platform frame)
    a1: np.ndarray                       # (6,3) fixed U axes, unit
    lc: float = 0.5
    lp: float = 0.5
    qmin: float = 0.5
    qmax: float = 1.0
    rp: float = 0.3
    g: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    m_plat: float = 10.0
    m_cyl: float = 1.5
    m_pis: float = 0.75
    I_plat: np.ndarray | None = None
    points: list = field(default_factory=list)
    f_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    m_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    at_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def m_limb(self):
        return self.m_cyl + self.m_pis

    @property
    def W(self):
        return (self.m_plat + sum(m for m, _ in self.points) + 6 * self.m_limb) * float(np.linalg.norm(self.g))

    @property
    def Lc(self):
        return self.lc + self.lp

    composite = Params.composite


def _circle6(radius, deg):
    ang = [float(a) * math.pi / 180.0 for a in deg]
    if len(ang) != 6:
        raise ValueError(f"six angles expected, got {deg}")
    return np.array([[radius * math.cos(a), radius * math.sin(a), 0.0] for a in ang])


def ups_params_from_job(job: dict) -> UpsParams:
    """docs/model.md 10.3's keys and defaults (base 0.5 m at -15/15/105/135/225/255 deg,
    platform 0.3 m at -45/45/75/165/195/285 deg, legs 0.5 + 0.5 m, masses 10/1.5/0.75 kg)."""
    mech, mass, load = job.get("mechanism", {}), job.get("mass", {}), job.get("load", {})
    rb, rp = float(mech.get("base_radius", 0.5)), float(mech.get("platform_radius", 0.3))
    B = np.array(mech["base_points"], float) if "base_points" in mech else \
        _circle6(rb, mech.get("base_angles_deg", [-15, 15, 105, 135, 225, 255]))
    AP = np.array(mech["platform_points"], float) if "platform_points" in mech else \
        _circle6(rp, mech.get("platform_angles_deg", [-45, 45, 75, 165, 195, 285]))
    if "u_axes" in mech:
        a1 = np.array(mech["u_axes"], float)
    else:
        a1 = np.array([[-b[1], b[0], 0.0] for b in B])     # tangent: (-sin, cos, 0) |B_xy|
    a1 = a1 / np.linalg.norm(a1, axis=1)[:, None]
    lc, lp = float(mech.get("cylinder_length", 0.5)), float(mech.get("piston_length", 0.5))
    U = UpsParams(B=B, AP=AP, a1=a1, lc=lc, lp=lp, rp=rp,
                  qmin=float(mech.get("min_length", max(lc, lp))),
                  qmax=float(mech.get("max_length", lc + lp)))
    U.g = _vec(mech.get("gravity"), [0.0, 0.0, -9.81])
    U.m_plat = float(mass.get("platform", 10.0))
    U.m_cyl = float(mass.get("cylinder", 1.5))
    U.m_pis = float(mass.get("piston", 0.75))
    if "platform_inertia" in mass:
        U.I_plat = _vec(mass["platform_inertia"], None)
    U.points = [(float(pm["mass"]), _vec(pm["at"], None)) for pm in mass.get("points", [])]
    U.f_ext = _vec(load.get("force"), [0, 0, 0])
    U.m_ext = _vec(load.get("moment"), [0, 0, 0])
    U.at_ext = _vec(load.get("at"), [0, 0, 0])
    return U


def ups_samples(job):
    """[(sample, t or None, inputs (6), d/dt (6), d2/dt2 (6))], row-major x, y, z, phi, psi, theta."""
    out = []
    if "grid" in job:
        axes = [lin_range(job["grid"].get(k, 0.0)) for k in UPS_INPUTS]
        for s, x0 in enumerate(np.array(np.meshgrid(*axes, indexing="ij")).reshape(6, -1).T):
            out.append((s, None, tuple(float(v) for v in x0), (0.0,) * 6, (0.0,) * 6))
    else:
        tr = job["trajectory"]
        for s, t in enumerate(lin_range(tr["time"])):
            vals = [harmonic(tr.get(k, 0.0), t) for k in UPS_INPUTS]
            out.append((s, t, tuple(v[0] for v in vals), tuple(v[1] for v in vals),
                        tuple(v[2] for v in vals)))
    return out


def ups_pose(U: UpsParams, x, y, z, phi, psi, theta):
    """Platform pose, joint points, leg lengths and directions, U axes, leg bodies."""
    R = euler_R(phi, psi, theta)
    p = np.array([x, y, z])
    A = p + U.AP @ R.T
    D = A - U.B
    q = np.linalg.norm(D, axis=1)
    e = D / q[:, None]
    c = np.cross(U.a1, e)
    s = np.linalg.norm(c, axis=1)
    a2 = c / s[:, None]
    n = np.cross(U.a1, a2)
    status = "ok"
    if np.any((q < U.qmin) | (q > U.qmax)):
        status = "unreachable"
    elif np.any(s < 1e-6):
        status = "near_singular"
    bodies = [[(U.m_cyl, U.B[i] + U.lc / 2 * e[i], U.lc), (U.m_pis, A[i] - U.lp / 2 * e[i], U.lp)]
              for i in range(6)]
    return dict(status=status, R=R, p=p, A=A, B=U.B, q=q, e=e, a2=a2, n=n, s=s, bodies=bodies)


def _frame_with_x(a):
    """Rotation whose first column is the unit vector a."""
    t = EZ if abs(a[2]) < 0.9 else EX
    b = np.cross(t, a)
    b /= np.linalg.norm(b)
    return np.column_stack([a, b, np.cross(a, b)])


class PinUPS:
    """The 6-UPS as a Pinocchio tree plus five 3-D loop closures.

    Limb i: a revolute joint about a1_i at B_i (the U joint's cross, massless), a revolute
    about the cross's second axis (a2_i, perpendicular to a1_i and to the leg) carrying the
    cylinder, a prismatic joint along the leg carrying the piston; the platform hangs on
    piston 1 through a spherical joint at A_1; pistons 2..6 close on it at A_2..A_6.
    nv = 6 * 3 + 3 = 21 = 6 actuators + 15 constraints."""

    def __init__(self, U: UpsParams):
        self.P = U
        m = pin.Model()
        m.gravity = pin.Motion(np.asarray(U.g, float), np.zeros(3))
        self.j1, self.j2, self.jp, self.Rpre = [], [], [], []
        for i in range(6):
            Rpre = _frame_with_x(U.a1[i])                 # local x = a1_i
            j1 = m.addJoint(0, pin.JointModelRX(), pin.SE3(Rpre, U.B[i]), f"u{i+1}a")
            j2 = m.addJoint(j1, pin.JointModelRY(), pin.SE3.Identity(), f"u{i+1}b")
            m.appendBodyToJoint(j2, _rod(U.m_cyl, U.lc, U.lc / 2), pin.SE3.Identity())
            jp = m.addJoint(j2, pin.JointModelPZ(), pin.SE3.Identity(), f"piston{i+1}")
            m.appendBodyToJoint(jp, _rod(U.m_pis, U.lp, -U.lp / 2), pin.SE3.Identity())
            self.j1.append(j1)
            self.j2.append(j2)
            self.jp.append(jp)
            self.Rpre.append(Rpre)
            if i == 0:
                self.jS = m.addJoint(jp, pin.JointModelSpherical(), pin.SE3.Identity(), "sph1")
                mt, c, I_C = U.composite()
                m.appendBodyToJoint(self.jS, pin.Inertia(mt, c - U.AP[0], I_C), pin.SE3.Identity())
        self.tip = [m.addFrame(pin.Frame(f"tip{i+1}", self.jp[i], pin.SE3.Identity(),
                                         pin.FrameType.OP_FRAME), False) for i in range(6)]
        self.fA = [m.addFrame(pin.Frame(f"A{i+1}", self.jS, pin.SE3(np.eye(3), U.AP[i] - U.AP[0]),
                                        pin.FrameType.OP_FRAME), False) for i in range(6)]
        self.fP = m.addFrame(pin.Frame("P", self.jS, pin.SE3(np.eye(3), -U.AP[0]),
                                       pin.FrameType.OP_FRAME), False)
        self.model, self.data = m, m.createData()
        self.iv_act = [m.joints[j].idx_v for j in self.jp]
        assert m.nv == 21 and m.nq == 22

    def config(self, inputs):
        U, m = self.P, self.model
        k = ups_pose(U, *inputs)
        q = np.zeros(m.nq)
        for i in range(6):
            # leg direction in the U's base frame: R_x(a) R_y(b) z = (sin b, -sin a cos b, cos a cos b)
            v = self.Rpre[i].T @ k["e"][i]
            b = math.asin(max(-1.0, min(1.0, v[0])))
            a = math.atan2(-v[1], v[2])
            q[m.joints[self.j1[i]].idx_q] = a
            q[m.joints[self.j2[i]].idx_q] = b
            q[m.joints[self.jp[i]].idx_q] = k["q"][i]
            if i == 0:
                Rleg1 = self.Rpre[0] @ rx(a) @ ry(b)
        iq = m.joints[self.jS].idx_q
        q[iq:iq + 4] = pin.Quaternion(Rleg1.T @ k["R"]).normalized().coeffs()
        return q, k

    def closure_residual(self, q, k):
        m, d = self.model, self.data
        pin.framesForwardKinematics(m, d, q)
        r = max(np.max(np.abs(d.oMf[self.tip[i]].translation - d.oMf[self.fA[i]].translation))
                for i in range(6))
        r = max(r, np.max(np.abs(d.oMf[self.fP].translation - k["p"])),
                np.max(np.abs(d.oMf[self.fP].rotation - k["R"])))
        return r

    def _jacobians(self, q):
        m, d = self.model, self.data
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        W = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        Jc = np.vstack([pin.getFrameJacobian(m, d, self.tip[i], W)[:3]
                        - pin.getFrameJacobian(m, d, self.fA[i], W)[:3] for i in range(1, 6)])
        return Jc, pin.getFrameJacobian(m, d, self.fP, W)

    def motion(self, q, k, inputs, d1, d2):
        """Generalized velocity and acceleration: [J_c; J_P] v = [0; p'; omega], omega =
        E (phi', psi', theta'), and the same differentiated with Pinocchio's drift."""
        m, d = self.model, self.data
        Jc, JP = self._jacobians(q)
        phi, psi, theta = inputs[3], inputs[4], inputs[5]
        E, a1, a2, a3 = PinMech.euler_E(phi, psi, theta)
        eta1, eta2 = np.array(d1[3:6]), np.array(d2[3:6])
        K = np.vstack([Jc, JP])
        v = np.linalg.solve(K, np.r_[np.zeros(15), d1[0:3], E @ eta1])
        pin.forwardKinematics(m, d, q, v, np.zeros(m.nv))
        W = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        acc = lambda f: pin.getFrameClassicalAcceleration(m, d, f, W)
        drift_c = np.concatenate([acc(self.tip[i]).linear - acc(self.fA[i]).linear for i in range(1, 6)])
        aP = acc(self.fP)
        dphi, dpsi, dth = eta1
        Edot_eta = dpsi * np.cross(dth * a1, a2) + dphi * np.cross(dth * a1 + dpsi * a2, a3)
        rhs = np.r_[-drift_c, np.array(d2[0:3]) - aP.linear, E @ eta2 + Edot_eta - aP.angular]
        return v, np.linalg.solve(K, rhs)

    def _ext_forces(self, q, lam=None):
        m, d, U = self.model, self.data, self.P
        pin.forwardKinematics(m, d, q)
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        Rp = d.oMi[self.jS].rotation
        fl = Rp.T @ U.f_ext
        fext[self.jS] = pin.Force(fl, np.cross(U.at_ext - U.AP[0], fl) + Rp.T @ U.m_ext)
        if lam is not None:
            for n, i in enumerate(range(1, 6)):
                li = lam[3 * n:3 * n + 3]
                jt = self.jp[i]
                fext[jt] = fext[jt] + pin.Force(d.oMi[jt].rotation.T @ li, np.zeros(3))
                fp = Rp.T @ (-li)                      # -lambda_i on the platform at A_i
                fext[self.jS] = fext[self.jS] + pin.Force(fp, np.cross(U.AP[i] - U.AP[0], fp))
        return fext

    def reactions(self, q, k, v=None, a=None):
        """Actuator forces, multipliers and the joint reactions of docs/model.md 10.3:
        f_U, m_U = the base's force and couple on leg i at B_i (joint u<i>a's transmitted
        wrench: the cross is massless), mu = m_U . n_i, f_S (leg on platform)."""
        m, d = self.model, self.data
        v = np.zeros(m.nv) if v is None else v
        a = np.zeros(m.nv) if a is None else a
        Jc, _ = self._jacobians(q)
        rhs = pin.rnea(m, d, q, v, a, self._ext_forces(q)).copy()
        S = np.zeros((m.nv, 6))
        for i, iv in enumerate(self.iv_act):
            S[iv, i] = 1.0
        sol = np.linalg.solve(np.hstack([S, Jc.T]), rhs)
        tau, lam = sol[:6], sol[6:]
        res = pin.rnea(m, d, q, v, a, self._ext_forces(q, lam)).copy()
        res[self.iv_act] -= tau
        fU, mU = [], []
        for i in range(6):
            Rl = d.oMi[self.j1[i]].rotation
            fU.append(Rl @ d.f[self.j1[i]].linear)
            mU.append(Rl @ d.f[self.j1[i]].angular)
        mu = np.array([mU[i] @ k["n"][i] for i in range(6)])
        fS = [d.oMi[self.jS].rotation @ d.f[self.jS].linear] + [-lam[3 * n:3 * n + 3] for n in range(5)]
        return dict(tau=tau, lam=lam, rnea_res=float(np.max(np.abs(res))), fU=np.array(fU),
                    mU=np.array(mU), mu=mu, fS=np.array(fS),
                    sph_moment=float(np.max(np.abs(d.f[self.jS].angular))))

    def leg_velocities(self, q, v):
        """World angular velocity of each leg (the cylinder), from Pinocchio."""
        m, d = self.model, self.data
        pin.forwardKinematics(m, d, q, v)
        return np.array([d.oMi[j].rotation @ d.v[j].angular for j in self.j2])


def ups_reference(job, mode, model=None):
    """{sample: dict(t, inputs, k, r, q, v, a)} for the samples with status ok."""
    U = ups_params_from_job(job)
    M = model or PinUPS(U)
    out = {}
    for s, t, x0, x1, x2 in ups_samples(job):
        if ups_pose(U, *x0)["status"] != "ok":
            continue
        q, k = M.config(x0)
        v = a = None
        if mode == "dynamic":
            v, a = M.motion(q, k, x0, x1, x2)
        r = M.reactions(q, k, v, a)
        r["closure"] = M.closure_residual(q, k)
        out[s] = dict(t=t, inputs=x0, k=k, r=r, q=q, v=v, a=a, d1=x1, d2=x2)
    return out


def ups_equilibrium_residual(U, k, r, kin=None):
    """docs/model.md 10.3 by hand, per leg (cylinder + piston, moments about B_i, the couple
    mu_i n_i) and for the platform; relative to W and W L.  kin: Pinocchio's exact
    motion (omega, domega, aC, w<i>, dw<i>, a<i>_<b>) or None (statics)."""
    mt, c, I_Cp = U.composite()
    R = k["R"]
    C = k["p"] + R @ c
    E = k["p"] + R @ U.at_ext
    I_C = R @ I_Cp @ R.T
    rf, rm_ = [], []
    for i in range(6):
        A, B, e = k["A"][i], k["B"][i], k["e"][i]
        wi = dwi = np.zeros(3)
        if kin is not None:
            wi, dwi = kin[f"w{i}"], kin[f"dw{i}"]
        f = r["fU"][i] - r["fS"][i]
        mo = r["mu"][i] * k["n"][i] - np.cross(A - B, r["fS"][i])
        for b, (mb, G, lb) in enumerate(k["bodies"][i]):
            ab = np.zeros(3) if kin is None else kin[f"a{i}_{b}"]
            Ib = mb * lb ** 2 / 12 * (np.eye(3) - np.outer(e, e))
            f = f + mb * U.g - mb * ab
            mo = mo - Ib @ dwi - np.cross(wi, Ib @ wi) - np.cross(G - B, mb * (ab - U.g))
        rf.append(f)
        rm_.append(mo)
        rm_.append(r["mU"][i] - r["mu"][i] * k["n"][i])      # the U joint's couple is along n_i
    aC = w = dw = np.zeros(3)
    if kin is not None:
        aC, w, dw = kin["aC"], kin["omega"], kin["domega"]
    rf.append(r["fS"].sum(0) + mt * U.g + U.f_ext - mt * aC)
    rm_.append(sum(np.cross(k["A"][i] - C, r["fS"][i]) for i in range(6))
               + np.cross(E - C, U.f_ext) + U.m_ext - I_C @ dw - np.cross(w, I_C @ w))
    return max(np.max(np.abs(np.concatenate(rf))) / U.W,
               np.max(np.abs(np.concatenate(rm_))) / (U.W * U.Lc))


def ups_exact_motion(M, q, v, a, k):
    """Platform and leg motion from Pinocchio's forward kinematics (exact)."""
    m, d = M.model, M.data
    U = M.P
    pin.forwardKinematics(m, d, q, v, a)
    pin.updateFramePlacements(m, d)
    Wf = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    vP = pin.getFrameVelocity(m, d, M.fP, Wf)
    aP = pin.getFrameClassicalAcceleration(m, d, M.fP, Wf)
    mt, c, _ = U.composite()
    rc = k["R"] @ c
    out = dict(omega=vP.angular, domega=aP.angular,
               aC=aP.linear + np.cross(aP.angular, rc) + np.cross(vP.angular, np.cross(vP.angular, rc)))
    for i in range(6):
        for b, (jb, off) in enumerate(((M.j2[i], np.array([0.0, 0.0, U.lc / 2])),
                                       (M.jp[i], np.array([0.0, 0.0, -U.lp / 2])))):
            out[f"a{i}_{b}"] = pin.getFrameClassicalAcceleration(m, d, jb, pin.SE3(np.eye(3), off), Wf).linear
        out[f"w{i}"] = d.oMi[M.j2[i]].rotation @ d.v[M.j2[i]].angular
        out[f"dw{i}"] = d.oMi[M.j2[i]].rotation @ d.a[M.j2[i]].angular
    return out


def ups_virtual_work_residual(U, inputs, tau):
    """sum tau_i dq_i + dW_gravity + dW_ext over six virtual platform motions (complex
    step), relative to W L; tau_i is the actuator force along leg i (on the piston)."""
    mt, c, _ = U.composite()
    h = 1e-30
    k0 = ups_pose(U, *inputs)
    worst = 0.0
    for n in range(6):
        dp, dal = np.zeros(3), np.zeros(3)
        (dp if n < 3 else dal)[n % 3] = 1.0
        p = k0["p"] + 1j * h * dp
        R = k0["R"] + 1j * h * skew(dal) @ k0["R"]
        A = p + U.AP @ R.T
        D = A - U.B
        q = np.sqrt((D * D).sum(1))
        e = D / q[:, None]
        dq = np.imag(q) / h
        dW = 0.0
        for i in range(6):
            dW += U.m_cyl * U.g @ (np.imag(U.B[i] + U.lc / 2 * e[i]) / h)
            dW += U.m_pis * U.g @ (np.imag(A[i] - U.lp / 2 * e[i]) / h)
        dW += mt * U.g @ (np.imag(p + R @ c) / h)
        dW += U.f_ext @ (np.imag(p + R @ U.at_ext) / h) + U.m_ext @ dal
        worst = max(worst, abs(tau @ dq + dW) / (U.W * U.Lc))
    return worst


def ups_forward_check(M, q, v, a, r):
    """Pinocchio's constrained forward dynamics fed with our tau gives our a and lambda."""
    m = M.model
    d = m.createData()
    cms = [pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, m, M.jp[i], pin.SE3.Identity(),
                                    M.jS, pin.SE3(np.eye(3), M.P.AP[i] - M.P.AP[0]),
                                    pin.ReferenceFrame.LOCAL_WORLD_ALIGNED) for i in range(1, 6)]
    cds = [cm.createData() for cm in cms]
    pin.initConstraintDynamics(m, d, cms, cds)
    tau = np.zeros(m.nv)
    tau[M.iv_act] = r["tau"]
    d2 = m.createData()
    load = pin.rnea(m, d2, q, np.zeros(m.nv), np.zeros(m.nv), M._ext_forces(q)) \
        - pin.rnea(m, d2, q, np.zeros(m.nv), np.zeros(m.nv))
    acc = pin.constraintDynamics(m, d, q, v, tau - load, cms, cds, pin.ProximalSettings(1e-14, 0.0, 1))
    return (np.max(np.abs(acc - a)) / max(1.0, np.max(np.abs(a))),
            np.max(np.abs(d.lambda_c - r["lam"])) / M.P.W)


def _ups_masses_loads(rng, job):
    """_masses_loads for the 6-UPS: inertia, point masses, load, clearances (in place)."""
    if rng.random() < 0.5:
        job["mass"]["platform_inertia"] = [u(rng, 0.1, 0.5), u(rng, 0.1, 0.5), u(rng, 0.2, 1.0)]
    job["mass"]["points"] = [{"mass": u(rng, 1.0, 20.0),
                              "at": [u(rng, -0.2, 0.2), u(rng, -0.2, 0.2), u(rng, -0.5, 0.5)]}
                             for _ in range(int(rng.integers(0, 3)))]
    W = ups_params_from_job(job).W
    job["load"] = {"force": list(rng.normal(0, 0.2 * W, 3)), "moment": list(rng.normal(0, 0.05 * W, 3)),
                   "at": [u(rng, -0.2, 0.2), u(rng, -0.2, 0.2), u(rng, -0.3, 0.3)]}
    job["clearance"] = {k: (1e-4 if rng.random() < 0.5 else 0.0) for k in ("s_radial", "u_radial", "u_angular")}


def random_ups(rng, idx, trajectory, n):
    """6-UPS.  Variant n % 3: the default geometry (keys omitted); perturbed circle angles
    and radii with tilted U axes; explicit base/platform points off the planes."""
    v = n % 3
    mech = {"kind": "6-UPS", "gravity": _gravity(rng)}
    if v >= 1:
        mech["base_radius"] = u(rng, 0.4, 0.6)
        mech["platform_radius"] = u(rng, 0.2, 0.35)
        mech["base_angles_deg"] = [a + u(rng, -5, 5) for a in (-15, 15, 105, 135, 225, 255)]
        mech["platform_angles_deg"] = [a + u(rng, -5, 5) for a in (-45, 45, 75, 165, 195, 285)]
    if v == 1:
        mech["u_axes"] = [[-math.sin(t) + u(rng, -0.2, 0.2), math.cos(t), u(rng, -0.3, 0.3)]
                          for t in np.radians(mech["base_angles_deg"])]
    if v == 2:
        Up = ups_params_from_job({"mechanism": mech})
        mech["base_points"] = [[b[0], b[1], u(rng, -0.05, 0.05)] for b in Up.B]
        mech["platform_points"] = [[a[0], a[1], u(rng, -0.05, 0.05)] for a in Up.AP]
        for kk in ("base_radius", "base_angles_deg", "platform_angles_deg"):
            del mech[kk]
    job = {"name": f"pincheck_{idx:03d}_ups_{'traj' if trajectory else 'grid'}", "mechanism": mech,
           "mass": {"platform": u(rng, 5.0, 15.0), "cylinder": u(rng, 0.5, 3.0), "piston": u(rng, 0.3, 2.0)}}
    if v == 0:
        job["mass"] = {}
    _ups_masses_loads(rng, job)
    Up = ups_params_from_job(job)
    dxy = Up.AP[:, :2] - Up.B[:, :2]
    z0 = math.sqrt(((Up.qmin + Up.qmax) / 2) ** 2 - float((dxy * dxy).sum(1).mean()))
    if not trajectory:
        job["grid"] = {"x": {"start": -0.04, "stop": 0.04, "n": 2}, "y": u(rng, -0.03, 0.03),
                       "z": {"start": z0 - 0.05, "stop": z0 + 0.05, "n": 3},
                       "phi": {"start": -0.15, "stop": 0.1, "n": 2}, "psi": u(rng, -0.1, 0.1),
                       "theta": {"start": -0.1, "stop": 0.12, "n": 3}}
    else:
        job["analysis"] = {"modes": ["kinetostatic", "dynamic"]}

        def harm(off, amp):
            return {"offset": off, "harmonics": [
                {"amplitude": amp * u(rng, 0.3, 1.0), "period": u(rng, 1.0, 4.0),
                 "phase": u(rng, -math.pi, math.pi)} for _ in range(int(rng.integers(1, 3)))]}
        t0 = u(rng, 0.0, 2.0)
        job["trajectory"] = {"time": {"start": t0, "stop": t0 + u(rng, 2.0, 4.0), "n": 21},
                             "x": harm(0.0, 0.04), "y": harm(0.0, 0.04), "z": harm(z0, 0.05),
                             "phi": harm(0.0, 0.15), "psi": harm(0.0, 0.12), "theta": harm(0.0, 0.12)}
    return job


def random_ups_job(seed, idx, trajectory, n):
    """Like random_job, for the 6-UPS (at least 80 % of the samples ok)."""
    rng = np.random.default_rng([seed, idx])
    for _ in range(50):
        job = random_ups(rng, idx, trajectory, n)
        U = ups_params_from_job(job)
        smp = ups_samples(job)
        if sum(ups_pose(U, *x0)["status"] == "ok" for _, _, x0, _, _ in smp) >= 0.8 * len(smp):
            return job
    raise RuntimeError(f"no reachable random 6-UPS job #{idx}")


def ups_selftest_job(job, note, begin):
    """The self-test checks of one 6-UPS job: begin(mode) opens each mode, note(key,
    value, tol) records a check."""
    U = ups_params_from_job(job)
    M = PinUPS(U)
    WL = U.W * U.Lc
    for mode in job_modes(job):
        begin(mode)
        ref = ups_reference(job, mode, M)
        if not ref:
            note("no ok sample", float("inf"), 0.0)
        for s, e in ref.items():
            r, k = e["r"], e["k"]
            note("closure residual (FK, m / rad)", r["closure"], 1e-12)
            note("RNEA residual on passive dofs / W", r["rnea_res"] / U.W, 1e-12)
            note("spherical joint moment / (W L)", r["sph_moment"] / WL, 1e-12)
            note("U couple along n_i, |mu_i| / (W L) (round-off)", np.max(np.abs(r["mu"])) / WL, 1e-12)
            if mode == "kinetostatic":
                note("statics: body equilibrium (model 10.3) / W", ups_equilibrium_residual(U, k, r), 1e-12)
                note("statics: virtual work / (W L)", ups_virtual_work_residual(U, e["inputs"], r["tau"]), 1e-12)
                act = max(abs(r["tau"][i] - k["e"][i] @ (r["fS"][i] - U.m_pis * U.g)) for i in range(6))
                note("tau_i - e_i.(f_Si - m_pis g) / W", act / U.W, 1e-12)
            else:
                kin = ups_exact_motion(M, e["q"], e["v"], e["a"], k)
                # the solved motion reproduces the inputs' analytic derivatives
                m_, d_ = M.model, M.data
                Wf = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                vP = pin.getFrameVelocity(m_, d_, M.fP, Wf)
                aP = pin.getFrameClassicalAcceleration(m_, d_, M.fP, Wf)
                Em, a1_, a2_, a3_ = PinMech.euler_E(*e["inputs"][3:6])
                eta1, eta2 = np.array(e["d1"][3:6]), np.array(e["d2"][3:6])
                dphi, dpsi, dth = eta1
                Ed = dpsi * np.cross(dth * a1_, a2_) + dphi * np.cross(dth * a1_ + dpsi * a2_, a3_)
                dv = max(np.max(np.abs(vP.linear - e["d1"][0:3])), np.max(np.abs(vP.angular - Em @ eta1)))
                da = max(np.max(np.abs(aP.linear - e["d2"][0:3])),
                         np.max(np.abs(aP.angular - Em @ eta2 - Ed)))
                note("dynamics: platform twist and its rate vs the inputs'", max(dv, da), 1e-12)
                note("dynamics: body equilibrium, exact inertia / W", ups_equilibrium_residual(U, k, r, kin), 1e-11)
                wl = np.array([kin[f"w{i}"] for i in range(6)])
                note("leg omega_i . n_i (rad/s)", np.max(np.abs((wl * k["n"]).sum(1))), 1e-12)
                ea, el = ups_forward_check(M, e["q"], e["v"], e["a"], r)
                note("dynamics: pin.constraintDynamics(tau): accel, relative", ea, 1e-9)
                note("dynamics: pin.constraintDynamics(tau): lambda / W", el, 1e-9)


def compare_ups_job(job, rows, stats, label):
    """Engine rows of a 6-UPS job against Pinocchio. Returns {mode: (ok, message)}."""
    U = ups_params_from_job(job)
    M = PinUPS(U)
    results = {}
    for mode in job_modes(job):
        ref = ups_reference(job, mode, M)
        samples = {s: (t, x0) for s, t, x0, _, _ in ups_samples(job)}
        mrows = [r for r in rows if r.get("mode") == mode]
        msgs, over, bad, n_ok = [], {}, False, 0
        if len(mrows) != len(samples):
            msgs.append(f"{len(mrows)} rows for {len(samples)} samples")
        tol_r = TOL_STATIC if mode == "kinetostatic" else TOL_DYNAMIC
        for row in mrows:
            s = int(row["sample"])
            if row["status"] != "ok":
                continue
            if s not in ref:
                msgs.append(f"sample {s}: status ok but not ok here")
                bad = True
                continue
            n_ok += 1
            k, r = ref[s]["k"], ref[s]["r"]
            t_ref, x0 = samples[s]
            diffs = {"input": max(abs(row[c] - v) for c, v in zip(UPS_INPUTS, x0)),
                     "kin": max(abs(row[f"q{i+1}"] - k["q"][i]) for i in range(6)),
                     "f_u": 0.0, "m_u": 0.0, "f_s": 0.0}
            for i in range(6):
                diffs["m_u"] = max(diffs["m_u"], abs(row[f"m_u{i+1}"] - r["mu"][i]) / (U.W * U.Lc))
                for c, comp in enumerate("xyz"):
                    diffs["f_u"] = max(diffs["f_u"], abs(row[f"f_u{i+1}_{comp}"] - r["fU"][i][c]) / U.W)
                    diffs["f_s"] = max(diffs["f_s"], abs(row[f"f_s{i+1}_{comp}"] - r["fS"][i][c]) / U.W)
            for qn, dv in diffs.items():
                dv = float(dv) if dv == dv else float("inf")
                key = ("6-UPS", mode, qn)
                if key not in stats or dv > stats[key][0]:
                    stats[key] = (dv, f"{label} sample {s}")
                tol = {"input": TOL_INPUT, "kin": TOL_KIN}.get(qn, tol_r)
                if dv > tol:
                    over.setdefault(qn, f"{qn} off by {dv:.2e} (> {tol:.0e}) at sample {s}")
                    bad = True
        msgs.extend(over.values())
        if n_ok == 0:
            msgs.append("no ok rows to compare")
            bad = True
        results[mode] = (not bad and len(mrows) == len(samples), "; ".join(msgs))
    return results


# --------------------------------------------------------------------------- #
# Comparison with the engine
# --------------------------------------------------------------------------- #
def read_engine(out_dir):
    import pyarrow as pa
    import pyarrow.parquet as pq
    files = sorted(glob.glob(os.path.join(out_dir, "poses", "variant=0", "*.parquet")))
    if not files:
        raise RuntimeError(f"no parquet files under {out_dir}/poses/variant=0")
    tab = pa.concat_tables([pq.read_table(f) for f in files], promote_options="permissive")
    return tab.to_pylist()


QUANTS = ["input", "kin", "f_r", "m_r", "f_s"]
QUANTS_UPS = ["f_u", "m_u"]          # 6-UPS: f_u<i>_*, m_u<i> (the scalar mu_i); f_s as above


def compare_job(job, rows, stats, label):
    """Compare engine rows with the Pinocchio reference. Returns {mode: (ok, message)}."""
    P = params_from_job(job)
    kind = job_kind(job)
    M = PinMech(P)
    results = {}
    for mode in job_modes(job):
        ref = reference(job, mode, M)
        samples = {s: (t, x0) for s, t, x0, _, _ in job_samples(job)}
        mrows = [r for r in rows if r.get("mode") == mode]
        msgs = []
        if len(mrows) != len(samples):
            msgs.append(f"{len(mrows)} rows for {len(samples)} samples")
        n_ok = n_reach = 0
        bad = False
        over = {}
        tol_r = TOL_STATIC if mode == "kinetostatic" else TOL_DYNAMIC
        for row in mrows:
            s = int(row["sample"])
            if s not in samples:
                msgs.append(f"unknown sample {s}")
                bad = True
                continue
            if row["status"] != "ok":
                if row["status"] == "unreachable" and s in ref:
                    n_reach += 1
                continue
            if s not in ref:
                msgs.append(f"sample {s}: status ok but not ok here")
                bad = True
                continue
            n_ok += 1
            e = ref[s]
            k, r = e["k"], e["r"]
            diffs = {q: 0.0 for q in QUANTS}
            t_ref, x0 = samples[s]
            di = [abs(row[c] - v) for c, v in zip(("z", "psi", "theta"), x0)]
            if t_ref is not None:
                di.append(abs((row["t"] if row["t"] is not None else np.nan) - t_ref))
            diffs["input"] = max(di)
            diffs["kin"] = max([abs(row["x"] - k["x"]), abs(row["y"] - k["y"]), abs(row["phi"] - k["phi"])]
                               + [abs(row[f"q{j+1}"] - k["q"][j]) for j in range(3)])
            for j in range(3):
                for c, comp in enumerate("xyz"):
                    diffs["f_r"] = max(diffs["f_r"], abs(row[f"f_r{j+1}_{comp}"] - r["fR"][j][c]) / P.W)
                    diffs["m_r"] = max(diffs["m_r"], abs(row[f"m_r{j+1}_{comp}"] - r["mR"][j][c]) / (P.W * P.Lc))
                    diffs["f_s"] = max(diffs["f_s"], abs(row[f"f_s{j+1}_{comp}"] - r["fS"][j][c]) / P.W)
            for qn, dv in diffs.items():
                dv = float(dv) if dv == dv else float("inf")      # NaN -> inf
                key = (kind, mode, qn)
                cur = stats.get(key)
                if cur is None or dv > cur[0]:
                    stats[key] = (dv, f"{label} sample {s}")
                tol = {"input": TOL_INPUT, "kin": TOL_KIN}.get(qn, tol_r)
                if dv > tol:
                    if qn not in over:
                        over[qn] = f"{qn} off by {dv:.2e} (> {tol:.0e}) at sample {s}"
                    bad = True
        msgs.extend(over.values())
        nstat = {}
        for row in mrows:
            nstat[row["status"]] = nstat.get(row["status"], 0) + 1
        if n_ok == 0:
            msgs.append("no ok rows to compare")
            bad = True
        if n_reach:
            msgs.append(f"note: {n_reach} rows unreachable in the engine but reachable here")
        msgs.append("statuses " + ", ".join(f"{k}={v}" for k, v in sorted(nstat.items())))
        results[mode] = (not bad and len(mrows) == len(samples), "; ".join(msgs))
    return results


PROBES = {
    "3-PRS": {"name": "pincheck_probe_prs",
              "mechanism": {"kind": "3-PRS", "rail_angle_deg": 30.0,
                            "limb_angles_deg": [0.0, 120.0, 240.0],
                            "platform_angles_deg": [0.0, 120.0, 240.0]},
              "grid": {"z": 1.5, "psi": 0.0, "theta": 0.0}},
    "3-RPS": {"name": "pincheck_probe_rps",
              "mechanism": {"kind": "3-RPS", "cylinder_length": 0.8, "piston_length": 0.8},
              "mass": {"cylinder": 2.0, "piston": 1.0},
              "grid": {"z": 1.2, "psi": 0.0, "theta": 0.0}},
    "6-UPS": {"name": "pincheck_probe_ups", "mechanism": {"kind": "6-UPS"},
              "grid": {"x": 0.0, "y": 0.0, "z": 0.7, "phi": 0.0, "psi": 0.0, "theta": 0.0}},
}


def engine_supports(binary, kind, work):
    """(True, '') if `clearance check` accepts a tiny job of this kind, else (False, reason).
    Only a bad-job verdict (exit 2) counts as 'not supported'."""
    if kind not in PROBES:
        return True, ""
    path = os.path.join(work, PROBES[kind]["name"] + ".toml")
    with open(path, "w") as fh:
        fh.write(to_toml(PROBES[kind]))
    p = subprocess.run([binary, "check", path], capture_output=True, text=True)
    if p.returncode == 2:
        msg = " | ".join((p.stderr or p.stdout).strip().splitlines()[-2:])
        return False, msg
    return True, ""


def run_compare(args, kinds, explicit):
    binary = args.bin or os.path.join(REPO, "target", "release", "clearance")
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        print(f"engine binary not found: {binary} (use --bin; --selftest runs without it)")
        print("0 passed, 0 failed")
        return 1
    work = args.keep or tempfile.mkdtemp(prefix="pincheck_")
    os.makedirs(work, exist_ok=True)
    support = {kd: engine_supports(binary, kd, work) for kd in kinds}
    for kd, (ok, why) in support.items():
        if not ok:
            print(f"{'FAIL' if explicit else 'SKIP'} kind {kd}: the engine rejects it as a bad job: {why}")
    stats, passed, failed, skipped = {}, 0, 0, 0
    for ij, kind, traj, n in job_plan(args.jobs, kinds):
        job = random_ups_job(args.seed, ij, traj, n) if kind == "6-UPS" else \
            random_job(args.seed, ij, kind, traj, n)
        modes = job_modes(job)
        if not support[kind][0]:
            if explicit:
                failed += len(modes)
            else:
                skipped += len(modes)
            print(f"{'FAIL' if explicit else 'SKIP'} {job['name']} ({', '.join(modes)}): "
                  f"kind {kind} not supported by the engine")
            continue
        path = os.path.join(work, job["name"] + ".toml")
        with open(path, "w") as fh:
            fh.write(to_toml(job))
        job = tomllib.loads(open(path).read())
        out = os.path.join(work, job["name"] + "_out")
        if os.path.exists(out):
            shutil.rmtree(out)
        cmd = [binary, "run", path, "--out", out, "--columns", "full"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
            for mode in modes:
                print(f"FAIL {job['name']} {mode}: engine exit {p.returncode}: {' | '.join(tail)}")
            failed += len(modes)
            continue
        try:
            rows = read_engine(out)
            res = (compare_ups_job if kind == "6-UPS" else compare_job)(job, rows, stats, job["name"])
        except Exception as exc:     # missing column, etc.: a failure, reported
            for mode in modes:
                print(f"FAIL {job['name']} {mode}: {type(exc).__name__}: {exc}")
            failed += len(modes)
            continue
        for mode, (ok, msg) in res.items():
            print(f"{'ok  ' if ok else 'FAIL'} {job['name']} {mode}: {msg}")
            passed += ok
            failed += not ok
    print()
    print(f"{'kind':9s} {'mode':13s} {'quantity':8s} {'worst diff':>11s} {'tol':>8s}  where")
    scale = {"input": "abs", "kin": "abs", "f_r": "/W", "m_r": "/(W L)", "f_s": "/W",
             "f_u": "/W", "m_u": "/(W L)"}
    for (kind, mode, qn), (dv, where) in sorted(
            stats.items(), key=lambda kv: ((KINDS + EXTRA_KINDS).index(kv[0][0]), kv[0][1],
                                           (QUANTS + QUANTS_UPS).index(kv[0][2]))):
        tol = {"input": TOL_INPUT, "kin": TOL_KIN}.get(qn, TOL_STATIC if mode == "kinetostatic" else TOL_DYNAMIC)
        print(f"{kind:9s} {mode:13s} {qn:8s} {dv:11.2e} {tol:8.0e}  {scale[qn]:7s} {where}")
    if args.keep or failed:
        print(f"(jobs and outputs in {work})")
    else:
        shutil.rmtree(work, ignore_errors=True)
    tail = f", {skipped} skipped" if skipped else ""
    print(f"{passed} passed, {failed} failed{tail}")
    return 0 if failed == 0 else 1


def parse_kinds(spec):
    if spec is None or spec.strip().lower() == "all":
        return list(KINDS)
    kinds = []
    for k in spec.split(","):
        k = k.strip()
        match = [kk for kk in KINDS + EXTRA_KINDS if kk.lower() == k.lower()]
        if not match:
            raise SystemExit(f"--kinds: unknown kind {k!r} (choose from "
                             f"{', '.join(KINDS + EXTRA_KINDS)}, or all = {', '.join(KINDS)})")
        if match[0] not in kinds:
            kinds.append(match[0])
    return kinds


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=None,
                    help="random job files, cycling over the kinds (default 6; --selftest 12)")
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--kinds", default=None,
                    help=f"comma-separated among {', '.join(KINDS + EXTRA_KINDS)} "
                         f"(default: all = {', '.join(KINDS)})")
    ap.add_argument("--bin", default=None, help="engine binary (default target/release/clearance)")
    ap.add_argument("--keep", default=None, help="directory for the job files and outputs")
    ap.add_argument("--selftest", action="store_true", help="validate the Pinocchio side alone")
    args = ap.parse_args()
    np.set_printoptions(precision=4)
    kinds = parse_kinds(args.kinds)
    explicit = args.kinds is not None and args.kinds.strip().lower() != "all"
    if args.selftest:
        sys.exit(0 if selftest(12 if args.jobs is None else args.jobs, args.seed, kinds) else 1)
    if args.jobs is None:
        args.jobs = 6
    sys.exit(run_compare(args, kinds, explicit))


if __name__ == "__main__":
    main()
