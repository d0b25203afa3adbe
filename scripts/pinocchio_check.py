#!/usr/bin/env python3
"""Cross-check the engine's joint reactions against Pinocchio (MODEL.md section 9).

The 3-PRS mechanism is rebuilt in Pinocchio from a job's geometry, independently
of the engine:

  * per limb j (alpha_j = 0, 120, 240 deg): a prismatic joint along world z placed at
    R_b*x_j (the slider, massless), then a revolute joint about y_j (the leg: mass
    m_leg, centre of mass at mid-leg, slender-rod inertia m L^2/12 across, 0 along);
  * the platform (composite body: disc or given inertia about P plus rigidly attached
    point masses) hangs on leg 1's tip through a spherical joint;
  * legs 2 and 3 close on the platform with 3-D point constraints at A_2, A_3.

For a pose, the actuator forces tau (3) and constraint multipliers lambda (6) solve
M a + h - J_ext^T w_ext = S^T tau + J_c^T lambda (9 equations); lambda is then applied
as a pair of external forces and a second RNEA gives the transmitted joint forces:
data.f[i] is the spatial force exerted by the parent on joint i's body, in joint i's
frame, about joint i's origin.  Hence
  f_Rj, m_Rj = oR_{R_j} * data.f[R_j].(linear, angular)   (slider on leg j, at B_j)
  f_S1       = oR_{S_1} * data.f[S_1].linear               (leg 1 on the platform, at A_1)
  f_Sj       = -lambda_j, j = 2, 3                         (lambda_j acts on leg j's tip)

Velocities and accelerations (dynamic mode) are not taken from the engine: the
9 generalized velocities solve [J_c; rows of the platform twist giving dZ, dPsi,
dTheta] v = [0; dZ, dPsi, dTheta] with Pinocchio's Jacobians, and the accelerations
solve the differentiated system with Pinocchio's drift (classical) accelerations,
the input derivatives being the analytic derivatives of the harmonics.  They are
exact to round-off; --selftest verifies them against 8th-order finite differences
of the configuration along the trajectory.

Tolerances against the engine (rows with status ok): reactions 1e-9 of W (forces) and
of W*L (couples) in both modes, since the Pinocchio side is exact to round-off in
both; x, y, phi, q1..q3 1e-10 absolute; inputs z, psi, theta, t 1e-12.

--selftest needs no engine: on the same random jobs it checks the loop closure with
Pinocchio's forward kinematics, the parasitic closed forms against a Newton solution,
each body's Newton-Euler balance (MODEL.md section 4) by hand in numpy (statics; and
dynamics with inertia terms from finite differences and from Pinocchio), virtual work
with complex-step derivatives of the inverse kinematics, tau_j = f_Rj.z, zero moment
in the spherical joint, J_c against pin.getConstraintJacobian, and Pinocchio's
constrained forward dynamics (constraintDynamics) fed with our tau returning our
accelerations and multipliers.

Usage:
  python3 scripts/pinocchio_check.py [--jobs N] [--seed S] [--bin PATH] [--keep DIR]
  python3 scripts/pinocchio_check.py --selftest [--jobs N] [--seed S]

Ends with "N passed, M failed" (counts of job x mode); exit status 1 on any failure.
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
import tomllib
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ALPHA = np.deg2rad([0.0, 120.0, 240.0])
EZ = np.array([0.0, 0.0, 1.0])
EY = np.array([0.0, 1.0, 0.0])
EX = np.array([1.0, 0.0, 0.0])

# Tolerances, relative to the load scale W (forces) and W*L (couples).
TOL_STATIC = 1e-9
TOL_DYNAMIC = 1e-9     # derivatives are exact to round-off (see module docstring)
TOL_KIN = 1e-10        # x, y, phi (rad), q (m) against the engine
TOL_INPUT = 1e-12      # z, psi, theta, t against the sampling rules


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


def euler_R(phi, psi, theta):
    """R = R_y(Theta) R_x(Psi) R_z(Phi) (MODEL.md section 1)."""
    return ry(theta) @ rx(psi) @ rz(phi)


def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def vee(S):
    return np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2.0


def limb_axes(j):
    a = ALPHA[j]
    xj = np.array([math.cos(a), math.sin(a), 0.0])
    yj = np.array([-math.sin(a), math.cos(a), 0.0])
    return xj, yj


# --------------------------------------------------------------------------- #
# Job description
# --------------------------------------------------------------------------- #
@dataclass
class Params:
    Rb: float = 0.18
    rp: float = 0.36
    L: float = 1.0
    g: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    m_plat: float = 9.8
    m_leg: float = 3.0
    I_plat: np.ndarray | None = None       # diag about P, platform axes
    points: list = field(default_factory=list)   # [(mass, offset(3))]
    f_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    m_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))
    at_ext: np.ndarray = field(default_factory=lambda: np.zeros(3))

    # derived -------------------------------------------------------------
    def a_prime(self, j):
        return self.rp * np.array([math.cos(ALPHA[j]), math.sin(ALPHA[j]), 0.0])

    @property
    def m_comp(self):
        return self.m_plat + sum(m for m, _ in self.points)

    @property
    def W(self):
        return (self.m_comp + 3 * self.m_leg) * float(np.linalg.norm(self.g))

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


def params_from_job(job: dict) -> Params:
    mech = job.get("mechanism", {})
    mass = job.get("mass", {})
    load = job.get("load", {})
    P = Params()
    P.Rb = float(mech.get("base_radius", P.Rb))
    P.rp = float(mech.get("platform_radius", P.rp))
    P.L = float(mech.get("leg_length", P.L))
    P.g = _vec(mech.get("gravity"), [0.0, 0.0, -9.81])
    P.m_plat = float(mass.get("platform", P.m_plat))
    P.m_leg = float(mass.get("leg", P.m_leg))
    if "platform_inertia" in mass:
        P.I_plat = _vec(mass["platform_inertia"], None)
    P.points = [(float(pm["mass"]), _vec(pm["at"], None)) for pm in mass.get("points", [])]
    P.f_ext = _vec(load.get("force"), [0, 0, 0])
    P.m_ext = _vec(load.get("moment"), [0, 0, 0])
    P.at_ext = _vec(load.get("at"), [0, 0, 0])
    return P


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


def parasitic_newton(z, psi, theta, rp):
    """Solve A_j . y_j = 0 (j = 1..3) for (x, y, phi) numerically (independent of the closed form)."""
    P = Params(rp=rp)

    def res(u):
        x, y, phi = u
        R = euler_R(phi, psi, theta)
        p = np.array([x, y, z])
        return np.array([(p + R @ P.a_prime(j)) @ limb_axes(j)[1] for j in range(3)])

    u = np.zeros(3)
    for _ in range(50):
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


def pose(P: Params, z, psi, theta):
    """Platform pose, joint points, actuators and leg angles. Complex-safe except leg angles."""
    x, y, phi = parasitic_closed(psi, theta, P.rp)
    R = euler_R(phi, psi, theta)
    p = np.array([x, y, z])
    A, B, q, e, rho_rb = [], [], [], [], []
    for j in range(3):
        xj, _ = limb_axes(j)
        Aj = p + R @ P.a_prime(j)
        rho, h = Aj @ xj, Aj @ EZ
        d2 = P.L ** 2 - (rho - P.Rb) ** 2
        qj = h - np.sqrt(d2)
        Bj = P.Rb * xj + qj * EZ
        A.append(Aj)
        B.append(Bj)
        q.append(qj)
        e.append((Aj - Bj) / P.L)
        rho_rb.append(rho - P.Rb)
    return dict(x=x, y=y, phi=phi, R=R, p=p, A=A, B=B, q=np.array(q), e=e, rho_rb=rho_rb)


def reachable(P: Params, z, psi, theta):
    k = pose(P, z, psi, theta)
    return all(P.L ** 2 - r ** 2 > 0 for r in k["rho_rb"])


# --------------------------------------------------------------------------- #
# Pinocchio model
# --------------------------------------------------------------------------- #
class PinPRS:
    def __init__(self, P: Params):
        self.P = P
        m = pin.Model()
        m.gravity = pin.Motion(np.asarray(P.g, float), np.zeros(3))
        self.jP, self.jR, self.tip = [], [], []
        L = P.L
        leg_I = pin.Inertia(P.m_leg, np.array([0.0, 0.0, L / 2]),
                            np.diag([P.m_leg * L * L / 12, P.m_leg * L * L / 12, 0.0]))
        for j in range(3):
            xj, _ = limb_axes(j)
            jp = m.addJoint(0, pin.JointModelPZ(), pin.SE3(rz(ALPHA[j]), P.Rb * xj), f"slider{j+1}")
            jr = m.addJoint(jp, pin.JointModelRY(), pin.SE3.Identity(), f"leg{j+1}")
            m.appendBodyToJoint(jr, leg_I, pin.SE3.Identity())
            self.jP.append(jp)
            self.jR.append(jr)
            if j == 0:
                # platform joint frame: origin A_1, axes = platform axes
                self.jS = m.addJoint(jr, pin.JointModelSpherical(),
                                     pin.SE3(np.eye(3), np.array([0.0, 0.0, L])), "sph1")
                mt, c, I_C = P.composite()
                Y = pin.Inertia(mt, c - P.a_prime(0), I_C)
                m.appendBodyToJoint(self.jS, Y, pin.SE3.Identity())
        for j in range(3):
            self.tip.append(m.addFrame(pin.Frame(f"tip{j+1}", self.jR[j],
                                                 pin.SE3(np.eye(3), np.array([0.0, 0.0, L])),
                                                 pin.FrameType.OP_FRAME), False))
        a1 = P.a_prime(0)
        self.fA = [m.addFrame(pin.Frame(f"A{j+1}", self.jS, pin.SE3(np.eye(3), P.a_prime(j) - a1),
                                        pin.FrameType.OP_FRAME), False) for j in range(3)]
        self.fP = m.addFrame(pin.Frame("P", self.jS, pin.SE3(np.eye(3), -a1),
                                       pin.FrameType.OP_FRAME), False)
        self.model = m
        self.data = m.createData()
        self.iv_act = [m.joints[jp].idx_v for jp in self.jP]
        assert m.nv == 9 and m.nq == 10

    # configuration ---------------------------------------------------------
    def config(self, z, psi, theta):
        P, m = self.P, self.model
        k = pose(P, z, psi, theta)
        q = np.zeros(m.nq)
        legR = []
        for j in range(3):
            # leg direction in the limb frame is R_y(phi_j) z = (sin, 0, cos)
            ang = math.atan2(k["rho_rb"][j], k["A"][j][2] - k["q"][j])
            q[m.joints[self.jP[j]].idx_q] = k["q"][j]
            q[m.joints[self.jR[j]].idx_q] = ang
            legR.append(rz(ALPHA[j]) @ ry(ang))
        Rs = legR[0].T @ k["R"]
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
        """omega = E (dPhi, dPsi, dTheta); columns a3, a2, a1 of MODEL.md section 6."""
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
                Rl = d.oMi[self.jR[j]].rotation
                fl = Rl.T @ lj                         # lambda_j on leg j at its tip
                fext[self.jR[j]] = fext[self.jR[j]] + pin.Force(fl, np.cross([0, 0, P.L], fl))
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
        fR, mR, fS = [], [], []
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

    def cfg(tt):
        z, ps, th = inputs_of_t(tt)
        k = pose(P, z, ps, th)
        return k

    k0 = cfg(t)
    ks = {i: cfg(t + i * h) for i in (-4, -3, -2, -1, 1, 2, 3, 4)}
    ks[0] = k0

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
        out[f"aG{j}"] = d2(lambda k: (k["A"][j] + k["B"][j]) / 2)
        out[f"dq{j}"] = d1(lambda k: k["q"][j])
        out[f"ddq{j}"] = d2(lambda k: k["q"][j])
    return out


def equilibrium_residual(P, k, r, kin=None):
    """Max residual of MODEL.md section 4 (24 equations) relative to W, W*L."""
    mt, c, I_Cp = P.composite()
    g = P.g
    R = k["R"]
    C = k["p"] + R @ c
    E = k["p"] + R @ P.at_ext
    I_C = R @ I_Cp @ R.T
    res_f, res_m = [], []
    for j in range(3):
        B, A = k["B"][j], k["A"][j]
        G = (A + B) / 2
        fR, mR, fS = r["fR"][j], r["mR"][j], r["fS"][j]
        e = k["e"][j]
        Il = P.m_leg * P.L ** 2 / 12 * (np.eye(3) - np.outer(e, e))
        aG = wj = dwj = np.zeros(3)
        if kin is not None:
            aG, wj, dwj = kin[f"aG{j}"], kin[f"w{j}"], kin[f"dw{j}"]
        res_f.append(fR - fS + P.m_leg * g - P.m_leg * aG)
        res_m.append(mR + np.cross(B - G, fR) - np.cross(A - G, fS)
                     - Il @ dwj - np.cross(wj, Il @ wj))
        res_m.append(np.array([mR @ limb_axes(j)[1]]))     # no couple about y_j
    aC = w = dw = np.zeros(3)
    if kin is not None:
        aC, w, dw = kin["aC"], kin["omega"], kin["domega"]
    res_f.append(sum(r["fS"]) + mt * g + P.f_ext - mt * aC)
    res_m.append(sum(np.cross(k["A"][j] - C, r["fS"][j]) for j in range(3))
                 + np.cross(E - C, P.f_ext) + P.m_ext - I_C @ dw - np.cross(w, I_C @ w))
    return max(np.max(np.abs(np.concatenate(res_f))) / P.W,
               np.max(np.abs(np.concatenate(res_m))) / (P.W * P.L))


def virtual_work_residual(P, z, psi, theta, tau):
    """Sum tau_j dq_j + dW_gravity + dW_ext for the 3 input directions (complex step)."""
    mt, c, _ = P.composite()
    h = 1e-30
    worst, scale = 0.0, P.W * P.L
    k0 = pose(P, z, psi, theta)
    for n in range(3):
        u = np.array([z, psi, theta], dtype=complex)
        u[n] += 1j * h
        k = pose(P, *u)
        dq = np.imag(k["q"]) / h
        dG = [np.imag((k["A"][j] + k["B"][j]) / 2) / h for j in range(3)]
        dC = np.imag(k["p"] + k["R"] @ c) / h
        dE = np.imag(k["p"] + k["R"] @ P.at_ext) / h
        dalpha = vee((np.imag(k["R"]) / h) @ k0["R"].T)
        vw = (tau @ dq + sum(P.m_leg * P.g @ dGj for dGj in dG) + mt * P.g @ dC
              + P.f_ext @ dE + P.m_ext @ dalpha)
        worst = max(worst, abs(vw) / scale)
    return worst


# --------------------------------------------------------------------------- #
# Random jobs
# --------------------------------------------------------------------------- #
def u(rng, a, b):
    return float(rng.uniform(a, b))


def random_job(rng, idx, trajectory):
    L = u(rng, 0.9, 1.1)
    g = [u(rng, -0.6, 0.6), u(rng, -0.6, 0.6), -9.81 * u(rng, 0.95, 1.05)]
    job = {
        "name": f"pincheck_{idx:03d}_{'traj' if trajectory else 'grid'}",
        "mechanism": {"base_radius": 0.18 * u(rng, 0.8, 1.2),
                      "platform_radius": 0.36 * u(rng, 0.8, 1.2),
                      "leg_length": L, "gravity": g},
        "mass": {"platform": u(rng, 5.0, 15.0), "leg": u(rng, 1.0, 5.0)},
    }
    if rng.random() < 0.5:
        job["mass"]["platform_inertia"] = [u(rng, 0.1, 0.5), u(rng, 0.1, 0.5), u(rng, 0.2, 1.0)]
    npts = int(rng.integers(0, 3))
    job["mass"]["points"] = [{"mass": u(rng, 1.0, 30.0),
                              "at": [u(rng, -0.3, 0.3), u(rng, -0.3, 0.3), u(rng, -1.0, 1.0)]}
                             for _ in range(npts)]
    P = params_from_job(job)
    W = P.W
    job["load"] = {"force": list(rng.normal(0, 0.2 * W, 3)),
                   "moment": list(rng.normal(0, 0.05 * W, 3)),
                   "at": [u(rng, -0.3, 0.3), u(rng, -0.3, 0.3), u(rng, -0.5, 0.5)]}
    job["clearance"] = {k: (1e-4 if rng.random() < 0.5 else 0.0)
                        for k in ("s_radial", "r_radial", "r_axial", "r_angular")}
    z0 = 2.05 * L + u(rng, -0.1, 0.1)
    if not trajectory:
        a, b = u(rng, 0.25, 0.45), u(rng, 0.25, 0.45)
        job["grid"] = {"z": {"start": z0 - 0.1, "stop": z0 + 0.1, "n": 3},
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
                             "z": harm(z0, 0.1), "psi": harm(u(rng, -0.05, 0.05), 0.2),
                             "theta": harm(u(rng, -0.05, 0.05), 0.25)}
    return job


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
    """{sample: dict(t, inputs, kin, reactions)} for the reachable samples."""
    P = params_from_job(job)
    M = model or PinPRS(P)
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
def selftest(n_jobs, seed):
    rng = np.random.default_rng(seed)
    worst = {}
    bad = set()
    cur = [None]

    def note(key, val, tol):
        val = float(val) if val == val else float("inf")
        w = worst.setdefault(key, [0.0, tol, ""])
        if val >= w[0]:
            w[0], w[2] = val, cur[0]
        if val > tol:
            bad.add(cur[0])

    # The J_c and constraintDynamics checks use Pinocchio's own constraint machinery
    # (RigidConstraintModel), independent of the hand-built J_c and 9 x 9 solve.
    jm = []
    for ij in range(n_jobs):
        traj = ij % 2 == 1
        job = tomllib.loads(to_toml(random_job(rng, ij, traj)))   # round-trip the TOML
        P = params_from_job(job)
        M = PinPRS(P)
        for mode in job_modes(job):
            cur[0] = f"{job['name']} {mode}"
            jm.append(cur[0])
            ref = reference(job, mode, M)
            samples = {s: (t, x0) for s, t, x0, _, _ in job_samples(job)}
            if not ref:
                bad.add(cur[0])
            for s, e in ref.items():
                r, k = e["r"], e["k"]
                z, psi, theta = e["inputs"]
                note("closure residual (FK, m / rad)", r["closure"], 1e-12)
                xn = parasitic_newton(z, psi, theta, P.rp)
                note("parasitic closed form vs Newton", np.max(np.abs(xn - [k["x"], k["y"], k["phi"]])), 1e-12)
                note("RNEA residual on passive dofs / W", r["rnea_res"] / P.W, 1e-12)
                note("spherical joint moment / (W L)", r["sph_moment"] / (P.W * P.L), 1e-12)
                note("tau_j - f_Rj.z / W", max(abs(r["tau"][j] - r["fR"][j][2]) for j in range(3)) / P.W, 1e-12)
                if mode == "kinetostatic":
                    note("statics: body equilibrium (MODEL 4) / W", equilibrium_residual(P, k, r), 1e-12)
                    note("statics: virtual work / (W L)", virtual_work_residual(P, z, psi, theta, r["tau"]), 1e-12)
                else:
                    tr = job["trajectory"]
                    f = lambda tt: tuple(harmonic(tr[n], tt)[0] for n in ("z", "psi", "theta"))
                    kin = fd_kinematics(P, f, e["t"])
                    # compare Pinocchio's solved motion with finite differences
                    m, d = M.model, M.data
                    pin.forwardKinematics(m, d, e["q"], e["v"], e["a"])
                    pin.updateFramePlacements(m, d)
                    Wf = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
                    vP = pin.getFrameVelocity(m, d, M.fP, Wf)
                    aP = pin.getFrameClassicalAcceleration(m, d, M.fP, Wf)
                    mt, c, _ = P.composite()
                    aC = aP.linear + np.cross(aP.angular, k["R"] @ c) + np.cross(
                        vP.angular, np.cross(vP.angular, k["R"] @ c))
                    dv = [vP.angular - kin["omega"], vP.linear - kin["vP"]]
                    da = [aP.angular - kin["domega"], aC - kin["aC"]]
                    for j in range(3):
                        dv.append([e["v"][M.iv_act[j]] - kin[f"dq{j}"]])
                        da.append([e["a"][M.iv_act[j]] - kin[f"ddq{j}"]])
                        wl = d.oMi[M.jR[j]].rotation @ d.v[M.jR[j]].angular
                        dv.append(wl - kin[f"w{j}"])
                        al = d.oMi[M.jR[j]].rotation @ d.a[M.jR[j]].angular
                        da.append(al - kin[f"dw{j}"])
                    note("dynamics: velocity vs 8th-order FD", np.max(np.abs(np.concatenate(dv))), 1e-8)
                    note("dynamics: acceleration vs 8th-order FD", np.max(np.abs(np.concatenate(da))), 1e-6)
                    note("dynamics: body equilibrium with FD inertia / W",
                         equilibrium_residual(P, k, r, kin), 1e-7)
                    # exact inertia terms from Pinocchio's own kinematics
                    kin_ex = dict(omega=vP.angular, domega=aP.angular, aC=aC)
                    for j in range(3):
                        wl = d.oMi[M.jR[j]].rotation @ d.v[M.jR[j]].angular
                        al = d.oMi[M.jR[j]].rotation @ d.a[M.jR[j]].angular
                        G = pin.SE3(np.eye(3), np.array([0, 0, P.L / 2]))
                        aG = pin.getFrameClassicalAcceleration(m, d, M.jR[j], G, Wf).linear
                        kin_ex.update({f"w{j}": wl, f"dw{j}": al, f"aG{j}": aG})
                    note("dynamics: body equilibrium, exact inertia / W",
                         equilibrium_residual(P, k, r, kin_ex), 1e-11)
                    # Pinocchio's constrained forward dynamics with our tau gives our a
                    ea, el = forward_check(M, e["q"], e["v"], e["a"], r)
                    note("dynamics: pin.constraintDynamics(tau): accel, relative", ea, 1e-9)
                    note("dynamics: pin.constraintDynamics(tau): lambda / W", el, 1e-9)
                if s % 7 == 0:
                    note("J_c vs pin.getConstraintJacobian", jacobian_check(M, e["q"]), 1e-12)
                assert samples[s][1] == e["inputs"]
    print(f"{'self-test check':58s} {'worst':>9s} {'tol':>6s}       where")
    for key, (val, tol, where) in worst.items():
        print(f"{key:58s} {val:9.2e} {tol:6.0e} {'ok  ' if val <= tol else 'FAIL'}  {where}")
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
            pin.ContactType.CONTACT_3D, m, M.jR[j], pin.SE3(np.eye(3), np.array([0, 0, P.L])),
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


def compare_job(job, rows, stats, label):
    """Compare engine rows with the Pinocchio reference. Returns {mode: (ok, message)}."""
    P = params_from_job(job)
    M = PinPRS(P)
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
                msgs.append(f"sample {s}: status ok but unreachable here")
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
                    diffs["m_r"] = max(diffs["m_r"], abs(row[f"m_r{j+1}_{comp}"] - r["mR"][j][c]) / (P.W * P.L))
                    diffs["f_s"] = max(diffs["f_s"], abs(row[f"f_s{j+1}_{comp}"] - r["fS"][j][c]) / P.W)
            for qn, dv in diffs.items():
                dv = float(dv) if dv == dv else float("inf")      # NaN -> inf
                key = (mode, qn)
                cur = stats.get(key)
                if cur is None or dv > cur[0]:
                    stats[key] = (dv, f"{label} sample {s}")
                tol = {"input": TOL_INPUT, "kin": TOL_KIN}.get(qn, tol_r)
                if dv > tol:
                    bad = True
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


def run_compare(args):
    binary = args.bin or os.path.join(REPO, "target", "release", "clearance")
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        print(f"engine binary not found: {binary} (use --bin; --selftest runs without it)")
        print("0 passed, 0 failed")
        return 1
    rng = np.random.default_rng(args.seed)
    work = args.keep or tempfile.mkdtemp(prefix="pincheck_")
    os.makedirs(work, exist_ok=True)
    stats, passed, failed = {}, 0, 0
    for ij in range(args.jobs):
        traj = ij % 2 == 1
        job = random_job(rng, ij, traj)
        path = os.path.join(work, job["name"] + ".toml")
        with open(path, "w") as fh:
            fh.write(to_toml(job))
        job = tomllib.loads(open(path).read())
        out = os.path.join(work, job["name"] + "_out")
        if os.path.exists(out):
            shutil.rmtree(out)
        cmd = [binary, "run", path, "--out", out, "--columns", "full"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        modes = job_modes(job)
        if p.returncode != 0:
            tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
            for mode in modes:
                print(f"FAIL {job['name']} {mode}: engine exit {p.returncode}: {' | '.join(tail)}")
            failed += len(modes)
            continue
        try:
            rows = read_engine(out)
            res = compare_job(job, rows, stats, job["name"])
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
    print(f"{'mode':13s} {'quantity':8s} {'worst diff':>11s} {'tol':>8s}  where")
    scale = {"input": "abs", "kin": "abs", "f_r": "/W", "m_r": "/(W L)", "f_s": "/W"}
    for (mode, qn), (dv, where) in sorted(stats.items(), key=lambda kv: (kv[0][0], QUANTS.index(kv[0][1]))):
        tol = {"input": TOL_INPUT, "kin": TOL_KIN}.get(qn, TOL_STATIC if mode == "kinetostatic" else TOL_DYNAMIC)
        print(f"{mode:13s} {qn:8s} {dv:11.2e} {tol:8.0e}  {scale[qn]:7s} {where}")
    if args.keep or failed:
        print(f"(jobs and outputs in {work})")
    else:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=6, help="random job files (alternately grid / trajectory)")
    ap.add_argument("--seed", type=int, default=12345)
    ap.add_argument("--bin", default=None, help="engine binary (default target/release/clearance)")
    ap.add_argument("--keep", default=None, help="directory for the job files and outputs")
    ap.add_argument("--selftest", action="store_true", help="validate the Pinocchio side alone")
    args = ap.parse_args()
    np.set_printoptions(precision=4)
    if args.selftest:
        sys.exit(0 if selftest(args.jobs, args.seed) else 1)
    sys.exit(run_compare(args))


if __name__ == "__main__":
    main()
