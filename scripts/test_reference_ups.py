"""Self-tests of scripts/reference_ups.py (the 6-UPS reference) that need no engine.

    python3 -m pytest scripts/test_reference_ups.py -q

Each test checks the reference against something computed another way, with the
tolerance stated in its docstring: an inverse kinematics written here from
docs/model.md section 10.3 (loop closure, finite differences of positions along a
trajectory), the U-joint angles of each leg (its angular velocity), virtual work by
complex-step derivatives, Pinocchio (scripts/pinocchio_check.py's 6-UPS tree with five
loop closures, statics and dynamics), the reciprocal-screw form of the error system,
and the exact nonlinear closure (second-order agreement; the u_angular play leaves the
platform where it is in both analyses).
"""

import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_ups as ru  # noqa: E402

RNG = np.random.default_rng(20261124)
INPUTS = ("x", "y", "z", "phi", "psi", "theta")
ALL3 = {"s_radial": 1e-4, "u_radial": 1e-4, "u_angular": 1e-3}

DEFAULT = {"mechanism": {"kind": "6-UPS"}, "clearance": dict(ALL3),
           "grid": {"z": 0.7}}
# Perturbed geometry, tilted U axes, off-plane joints, point masses, load, tilted gravity.
LOADED = {
    "mechanism": {"kind": "6-UPS", "gravity": [0.4, -0.3, -9.7],
                  "base_points": [[0.48, -0.13, 0.01], [0.47, 0.14, -0.02], [-0.11, 0.50, 0.0],
                                  [-0.36, 0.34, 0.03], [-0.37, -0.33, -0.01], [-0.14, -0.47, 0.02]],
                  "platform_points": [[0.21, -0.22, -0.02], [0.22, 0.20, 0.0], [0.08, 0.30, 0.03],
                                      [-0.29, 0.07, 0.0], [-0.28, -0.08, -0.03], [0.06, -0.29, 0.01]],
                  "u_axes": [[0.2, 1.0, 0.1], [-0.3, 1.0, -0.2], [-1.0, -0.1, 0.3],
                             [-0.7, -0.7, 0.0], [0.7, -0.8, 0.1], [1.0, -0.2, -0.2]],
                  "cylinder_length": 0.55, "piston_length": 0.5},
    "mass": {"platform": 12.0, "cylinder": 2.0, "piston": 0.9, "platform_inertia": [0.3, 0.35, 0.6],
             "points": [{"mass": 5.0, "at": [0.05, -0.1, 0.4]}, {"mass": 2.0, "at": [-0.1, 0.1, -0.2]}]},
    "load": {"force": [15.0, -8.0, -30.0], "moment": [2.0, 3.0, -1.5], "at": [0.1, 0.05, 0.2]},
    "clearance": {"s_radial": 2e-4, "u_radial": 5e-5, "u_angular": 3e-4},
    "grid": {"z": 0.7},
}


def with_job(base, **sections):
    job = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    job.update(sections)
    if "trajectory" in sections:
        job.pop("grid", None)
    return job


def random_poses(n, span=1.0):
    return (RNG.uniform(-0.04, 0.04, n) * span, RNG.uniform(-0.04, 0.04, n) * span,
            RNG.uniform(0.62, 0.78, n), RNG.uniform(-0.15, 0.15, n) * span,
            RNG.uniform(-0.12, 0.12, n) * span, RNG.uniform(-0.12, 0.12, n) * span)


# ---- an inverse kinematics of our own (docs/model.md 10.3), complex-safe ----------
def rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(c), np.zeros_like(c)
    rows = {"x": [[o, z, z], [z, c, -s], [z, s, c]],
            "y": [[c, z, s], [z, o, z], [-s, z, c]],
            "z": [[c, -s, z], [s, c, z], [z, z, o]]}[axis]
    return np.moveaxis(np.array(rows), (0, 1), (-2, -1))


def geometry(job):
    """B (6,3), a' (6,3), unit a1 (6,3) from the job, independently of the reference."""
    mech = job["mechanism"]
    if "base_points" in mech:
        B = np.array(mech["base_points"], float)
    else:
        ang = np.radians(mech.get("base_angles_deg", [-15, 15, 105, 135, 225, 255]))
        B = mech.get("base_radius", 0.5) * np.stack([np.cos(ang), np.sin(ang), 0 * ang], -1)
    if "platform_points" in mech:
        AP = np.array(mech["platform_points"], float)
    else:
        ang = np.radians(mech.get("platform_angles_deg", [-45, 45, 75, 165, 195, 285]))
        AP = mech.get("platform_radius", 0.3) * np.stack([np.cos(ang), np.sin(ang), 0 * ang], -1)
    if "u_axes" in mech:
        a1 = np.array(mech["u_axes"], float)
    else:
        th = np.arctan2(B[:, 1], B[:, 0])
        a1 = np.stack([-np.sin(th), np.cos(th), 0 * th], -1)
    return B, AP, a1 / np.linalg.norm(a1, axis=1)[:, None]


def ik(job, x, y, z, phi, psi, theta):
    """p (N,3), R (N,3,3), A (N,6,3), q (N,6), e (N,6,3)."""
    B, AP, _ = geometry(job)
    R = rot("y", theta) @ rot("x", psi) @ rot("z", phi)
    p = np.stack(np.broadcast_arrays(x, y, z), -1)
    A = p[:, None, :] + np.einsum("nab,ib->nia", R, AP)
    D = A - B
    q = np.sqrt((D * D).sum(-1))
    return p, R, A, q, D / q[..., None]


def traj_job(base, n=41, t0=0.3, t1=2.3, modes=("kinetostatic", "dynamic")):
    def harm(off, amp, T, ph):
        return {"offset": off, "harmonics": [{"amplitude": amp, "period": T, "phase": ph},
                                             {"amplitude": 0.3 * amp, "period": 0.6 * T, "phase": -ph}]}
    tr = {"time": {"start": t0, "stop": t1, "n": n},
          "x": harm(0.0, 0.03, 1.7, 0.2), "y": harm(0.01, 0.03, 1.3, 1.0),
          "z": harm(0.7, 0.05, 1.1, -0.4), "phi": harm(0.02, 0.12, 1.9, 0.7),
          "psi": harm(-0.01, 0.1, 1.2, 2.0), "theta": harm(0.0, 0.1, 1.5, -1.2)}
    return with_job(base, trajectory=tr, analysis={"modes": list(modes)})


def inputs_at(job, t):
    """The six inputs at times t, written here from docs/interface.md."""
    out = []
    for k in INPUTS:
        s = job["trajectory"][k]
        v = np.full_like(t, s["offset"])
        for h in s["harmonics"]:
            v = v + h["amplitude"] * np.sin(2 * np.pi * t / h["period"] + h["phase"])
        out.append(v)
    return out


def richardson(f, h):
    """f'(0) by central differences with one Richardson step (O(h^4))."""
    d1 = (f(h) - f(-h)) / (2 * h)
    d2 = (f(h / 2) - f(-h / 2)) / h
    return (4 * d2 - d1) / 3


def richardson2(f, h):
    """f''(0), O(h^4)."""
    s1 = (f(h) - 2 * f(0.0) + f(-h)) / h ** 2
    s2 = (f(h / 2) - 2 * f(0.0) + f(-h / 2)) / (h / 2) ** 2
    return (4 * s2 - s1) / 3


# --------------------------------------------------------------------------
# inverse kinematics and rates
# --------------------------------------------------------------------------
@pytest.mark.parametrize("job", [DEFAULT, LOADED], ids=["default", "loaded"])
def test_leg_lengths_close_the_loops(job):
    """|A_i - B_i| = q_i and e_i = (A_i - B_i)/q_i from our own IK: 1e-15 m; the
    reference's A_i = p + R a'_i: 1e-15 m; the default U axes are tangent to the base
    circle and a2_i, n_i form a right-handed frame with a1_i: 1e-15."""
    P = ru.normalize_job(job)
    x = random_poses(200)
    kin = ru.kinematics(P, *x)
    p, R, A, q, e = ik(job, *x)
    np.testing.assert_allclose(kin["A"], A, rtol=0, atol=1e-15)
    np.testing.assert_allclose(kin["q"], q, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(kin["A"] - kin["B"], axis=-1), kin["q"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(kin["e"], e, rtol=0, atol=1e-15)
    a1 = P["a1"]
    np.testing.assert_allclose(np.cross(a1, kin["a2"]), kin["n"], atol=1e-15)
    np.testing.assert_allclose((kin["a2"] * kin["e"]).sum(-1), 0.0, atol=1e-15)
    np.testing.assert_allclose((kin["n"] * kin["e"]).sum(-1), -kin["s"], atol=1e-15)
    if "u_axes" not in job["mechanism"]:
        np.testing.assert_allclose((a1 * P["B"]).sum(-1), 0.0, atol=1e-15)
        np.testing.assert_allclose(a1[:, 2], 0.0, atol=0)


def test_default_geometry_and_masses():
    """docs/model.md 10.3's defaults, exactly (1e-15)."""
    P = ru.normalize_job(DEFAULT)
    B, AP, a1 = geometry(DEFAULT)
    np.testing.assert_allclose(P["B"], B, atol=1e-15)
    np.testing.assert_allclose(P["AP"], AP, atol=1e-15)
    np.testing.assert_allclose(P["a1"], a1, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(P["B"], axis=1), 0.5, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(P["AP"], axis=1), 0.3, rtol=1e-15)
    assert (P["qmin"], P["qmax"], P["lc"], P["lp"]) == (0.5, 1.0, 0.5, 0.5)
    assert (P["m_plat"], P["m_cyl"], P["m_pis"]) == (10.0, 1.5, 0.75)
    np.testing.assert_allclose(np.diag(P["I_C_loc"]), [10 * 0.09 / 4, 10 * 0.09 / 4, 10 * 0.09 / 2],
                               rtol=1e-15)
    np.testing.assert_allclose(P["W"], (10 + 6 * 2.25) * 9.81, rtol=1e-15)
    with pytest.raises(ValueError):
        ru.normalize_job(with_job(DEFAULT, clearance={"r_axial": 1e-4}))
    with pytest.raises(ValueError):
        ru.normalize_job(with_job(DEFAULT, mechanism={"kind": "6-UPS", "leg_length": 1.0}))


def test_rates_match_finite_differences_of_positions():
    """Jet rates of q, e, A, platform centre and the leg bodies' centres along a
    trajectory against O(h^4) central differences of our own IK (h = 1e-3 s):
    first derivatives 1e-9, second 1e-7 (of the quantity's scale, m or 1)."""
    job = traj_job(LOADED)
    P = ru.normalize_job(job)
    smp = ru.sample_inputs(P)
    t = smp["t"]
    kj = ru.kinematics(P, *[smp[k + "j"] for k in INPUTS])
    lc, lp = P["lc"], P["lp"]
    B = P["B"]

    def geo(h):
        p, R, A, q, e = ik(job, *inputs_at(job, t + h))
        return np.concatenate([q, A.reshape(-1, 18), e.reshape(-1, 18), p,
                               (B + lc / 2 * e).reshape(-1, 18), (A - lp / 2 * e).reshape(-1, 18)], -1)

    ours = [np.concatenate([getattr(kj["q"], a), getattr(kj["A"], a).reshape(-1, 18),
                            getattr(kj["e"], a).reshape(-1, 18), getattr(kj["p"], a),
                            getattr(kj["Gc"], a).reshape(-1, 18), getattr(kj["Gp"], a).reshape(-1, 18)], -1)
            for a in ("v", "d", "dd")]
    np.testing.assert_allclose(ours[0], geo(0.0), rtol=0, atol=1e-15)
    np.testing.assert_allclose(ours[1], richardson(geo, 1e-3), rtol=0, atol=1e-9)
    np.testing.assert_allclose(ours[2], richardson2(geo, 1e-3), rtol=0, atol=1e-7)


def _u_angles(a1, e):
    """The two U-joint angles of a leg direction e, in a frame whose x is a1:
    e = F R_x(al) R_y(be) z  (independent of the reference)."""
    t = np.where(np.abs(a1[..., 2:3]) < 0.9, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    b = np.cross(t, a1)
    b /= np.linalg.norm(b, axis=-1)[..., None]
    F = np.stack([a1, b, np.cross(a1, b)], -1)
    v = np.einsum("...ba,...b->...a", F, e)
    return F, np.arctan2(-v[..., 1], v[..., 2]), np.arcsin(v[..., 0])


def test_leg_angular_velocity():
    """omega_i = e x e' + sigma e with omega . n = 0: (1) omega . n = 0 to 1e-14 rad/s;
    (2) equal to the angular velocity of the leg's frame F R_x(al(t)) R_y(be(t)) from the
    U-joint angles (vee(R' R^T) by O(h^4) differences, h = 1e-3): 1e-8 rad/s;
    (3) e x e' from differences of e: 1e-9; (4) omega' against differences of omega
    from (2): 1e-6 rad/s^2."""
    job = traj_job(LOADED)
    P = ru.normalize_job(job)
    smp = ru.sample_inputs(P)
    t = smp["t"]
    kj = ru.kinematics(P, *[smp[k + "j"] for k in INPUTS])
    mot = ru.motion(kj, P)
    w, dw = mot["w_leg"], mot["dw_leg"]
    n = kj["n"] if not isinstance(kj["n"], ru.Jet) else kj["n"].v
    assert np.abs((w * n).sum(-1)).max() < 1e-14
    a1 = P["a1"]

    def leg_R(tt):
        _, _, _, _, e = ik(job, *inputs_at(job, tt))
        F, al, be = _u_angles(np.broadcast_to(a1, e.shape), e)
        return F @ rot("x", al) @ rot("y", be)

    def omega_fd(tt, h=1e-3):
        Rd = richardson(lambda s: leg_R(tt + s), h)
        S = Rd @ leg_R(tt).swapaxes(-1, -2)
        return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0],
                               S[..., 1, 0] - S[..., 0, 1]], -1)

    np.testing.assert_allclose(w, omega_fd(t), rtol=0, atol=1e-8)
    e = kj["e"].v
    ed = richardson(lambda s: ik(job, *inputs_at(job, t + s))[4], 1e-3)
    np.testing.assert_allclose(np.cross(e, ed), w - (w * e).sum(-1)[..., None] * e, rtol=0, atol=1e-9)
    dw_fd = richardson(lambda s: omega_fd(t + s, 1e-4), 2e-3)
    np.testing.assert_allclose(dw, dw_fd, rtol=0, atol=1e-6)
    assert np.abs(mot["sigma"]).max() > 1e-3          # the spin term is not idle here


# --------------------------------------------------------------------------
# reactions
# --------------------------------------------------------------------------
def _complex_ik(job, x, y, z, phi, psi, theta, dp, dal, h):
    """Positions after the virtual twist (dp, dal) by a complex step h (exact first order)."""
    B, AP, _ = geometry(job)
    p, R, _, _, _ = ik(job, x, y, z, phi, psi, theta)
    S = np.array([[0, -dal[2], dal[1]], [dal[2], 0, -dal[0]], [-dal[1], dal[0], 0]])
    p = p + 1j * h * dp
    R = R + 1j * h * (S @ R)
    A = p[:, None, :] + np.einsum("nab,ib->nia", R, AP)
    D = A - B
    q = np.sqrt((D * D).sum(-1))
    return p, R, A, q, D / q[..., None]


def test_statics_satisfy_virtual_work():
    """sum tau_i dq_i + dW_gravity (platform, points, cylinders, pistons) + dW_ext = 0 for
    six independent virtual platform twists, tau_i = e_i . (f_Si - m_pis g) the actuator
    force on the piston; derivatives by complex step. Tolerance 1e-11 of the sum of the
    magnitudes of the terms."""
    job = LOADED
    x = random_poses(60)
    c = ru.pose_arrays(job, *x)
    assert (c["status"] == "ok").all()
    fS = np.stack([np.stack([c[f"f_s{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    _, _, _, _, e0 = ik(job, *x)
    g = np.array(job["mechanism"]["gravity"])
    mc, mp_ = job["mass"]["cylinder"], job["mass"]["piston"]
    tau = (e0 * (fS - mp_ * g)).sum(-1)
    mass = job["mass"]
    lc, lp = job["mechanism"]["cylinder_length"], job["mechanism"]["piston_length"]
    B, _, _ = geometry(job)
    f_ext, m_ext = np.array(job["load"]["force"]), np.array(job["load"]["moment"])
    at = np.array(job["load"]["at"])
    h = 1e-30
    for k in range(6):
        dp, dal = np.zeros(3), np.zeros(3)
        (dp if k < 3 else dal)[k % 3] = 1.0
        p, R, A, q, e = _complex_ik(job, *x, dp, dal, h)
        dq = q.imag / h
        d = lambda v: v.imag / h
        terms = [tau * dq,
                 mc * d(B + lc / 2 * e) @ g, mp_ * d(A - lp / 2 * e) @ g,
                 (mass["platform"] * d(p) @ g)[:, None],
                 (d(p + R @ at) @ f_ext)[:, None], np.full((len(x[0]), 1), dal @ m_ext)]
        for pt in mass["points"]:
            terms.append((pt["mass"] * d(p + R @ np.array(pt["at"])) @ g)[:, None])
        terms = np.concatenate(terms, -1)
        assert np.all(np.abs(terms.sum(-1)) <= 1e-11 * np.abs(terms).sum(-1)), k


def test_reduced_condition_matrices_and_cond():
    """cond_a = kappa_1 of G = [e_i; r_i x e_i] (6 x 6), cond_jp = kappa_1 of M =
    [(r_i x e_i)^T, e_i^T]: against numpy's own 1-norm condition number (1e-10 relative);
    the full 42 x 42 A is invertible and its solution satisfies A w = b to 1e-13 W."""
    P = ru.normalize_job(LOADED)
    x = random_poses(20)
    c = ru.pose_arrays(LOADED, *x)
    _, _, A, q, e = ik(LOADED, *x)
    p = np.stack(x[0:3], -1)
    G = np.concatenate([e.swapaxes(-1, -2), np.cross(A - p[:, None], e).swapaxes(-1, -2)], 1)
    M = np.concatenate([np.cross(A - p[:, None], e), e], -1)
    np.testing.assert_allclose(c["cond_a"], np.linalg.cond(G, 1), rtol=1e-10)
    np.testing.assert_allclose(c["cond_jp"], np.linalg.cond(M, 1), rtol=1e-10)
    kin = ru.kinematics(P, *x)
    Am, b = ru.equilibrium_matrix(P, kin), ru.equilibrium_rhs(P, kin)
    w = np.linalg.solve(Am, b[..., None])[..., 0]
    assert np.abs(np.einsum("nab,nb->na", Am, w) - b).max() < 1e-13 * P["W"]


def _pc():
    pytest.importorskip("pinocchio")
    import pinocchio_check as pc
    return pc


def _compare_with_pinocchio(job, mode):
    pc = _pc()
    ref = pc.ups_reference(job, mode)
    cols = ru.compute(job)
    sel = cols["mode"] == mode
    P = ru.normalize_job(job)
    W, WL = P["W"], P["W"] * (P["lc"] + P["lp"])
    worst_f = worst_m = 0.0
    n = 0
    for row in np.flatnonzero(sel):
        s = int(cols["sample"][row])
        if cols["status"][row] != "ok":
            continue
        assert s in ref, s
        r = ref[s]["r"]
        n += 1
        for i in range(6):
            fu = np.array([cols[f"f_u{i + 1}_{a}"][row] for a in "xyz"])
            fs = np.array([cols[f"f_s{i + 1}_{a}"][row] for a in "xyz"])
            worst_f = max(worst_f, np.abs(fu - r["fU"][i]).max() / W, np.abs(fs - r["fS"][i]).max() / W)
            worst_m = max(worst_m, abs(cols[f"m_u{i + 1}"][row] - r["mu"][i]) / WL)
    assert n >= 0.8 * sel.sum()
    return worst_f, worst_m


@pytest.mark.parametrize("job", [LOADED, with_job(DEFAULT, mass={"points": [{"mass": 20.0, "at": [0, 0, 0.8]}]})],
                         ids=["loaded", "default+point"])
def test_statics_match_pinocchio(job):
    """Kinetostatic f_U, mu, f_S against Pinocchio (a U-P tree per leg, the platform on leg
    1, five 3-D loop closures; scripts/pinocchio_check.py): 1e-9 of W (forces) and of
    W (l_c + l_p) (mu), on a grid of 3^3 x 2^3 poses."""
    job = with_job(job, grid={"x": {"start": -0.03, "stop": 0.03, "n": 2}, "y": 0.01,
                              "z": {"start": 0.62, "stop": 0.78, "n": 3},
                              "phi": {"start": -0.1, "stop": 0.12, "n": 3},
                              "psi": {"start": -0.1, "stop": 0.05, "n": 2},
                              "theta": {"start": -0.08, "stop": 0.1, "n": 3}})
    wf, wm = _compare_with_pinocchio(job, "kinetostatic")
    assert wf < 1e-9 and wm < 1e-9, (wf, wm)


def test_dynamics_match_pinocchio():
    """Dynamic f_U, mu, f_S along a six-input trajectory against Pinocchio, whose
    velocities and accelerations come from its own Jacobians and drift terms:
    1e-6 of W and W (l_c + l_p); kinetostatics differ from dynamics by more than 1 N."""
    job = traj_job(LOADED, n=31)
    wf, wm = _compare_with_pinocchio(job, "dynamic")
    assert wf < 1e-6 and wm < 1e-6, (wf, wm)
    c = ru.compute(job)
    k, d = c["mode"] == "kinetostatic", c["mode"] == "dynamic"
    assert np.abs(c["f_u1_z"][k] - c["f_u1_z"][d]).max() > 1.0


@pytest.mark.parametrize("mode", ["kinetostatic", "dynamic"])
def test_mu_is_round_off(mode):
    """The U joint's couple mu_i n_i vanishes (slender legs): |mu_i| < 1e-12 W (l_c + l_p),
    in statics and dynamics; margin_u<i>_angular = |mu_i|; u_angular never makes a
    sample indeterminate."""
    job = traj_job(LOADED, n=21, modes=(mode,))
    P = ru.normalize_job(job)
    c = ru.compute(job)
    assert (c["status"] == "ok").all()
    for i in range(1, 7):
        assert np.abs(c[f"m_u{i}"]).max() < 1e-12 * P["W"] * (P["lc"] + P["lp"])
        np.testing.assert_array_equal(c[f"margin_u{i}_angular"], np.abs(c[f"m_u{i}"]))


# --------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------
def test_error_system_matches_reciprocal_screws():
    """The 30 x 30 loop system against the 6 x 6 reciprocal-screw form: the force along
    leg i is reciprocal to its passive joints, so (r_i x e_i) . d_alpha + e_i . d_p =
    e_i . (take-up translation of limb i) for each kind (u_angular: 0).  Tolerance 1e-12
    of the error's size; the total is the sum of the kinds (1e-20 m)."""
    c = ru.pose_arrays(LOADED, *random_poses(50))
    x = [c[k] for k in INPUTS]
    P = ru.normalize_job(LOADED)
    _, _, A, q, e = ik(LOADED, *x)
    p = np.stack(x[0:3], -1)
    M = np.concatenate([np.cross(A - p[:, None], e), e], -1)                    # (N,6,6)
    fU = np.stack([np.stack([c[f"f_u{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    fS = np.stack([np.stack([c[f"f_s{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    disp = {"u_radial": -P["clear"]["u_radial"] * fU / np.linalg.norm(fU, axis=-1)[..., None],
            "s_radial": -P["clear"]["s_radial"] * fS / np.linalg.norm(fS, axis=-1)[..., None],
            "u_angular": None}
    for kind in ru.KINDS:
        dG = np.stack([c[f"err_{kind}_{k}"] for k in ("rx", "ry", "rz", "x", "y", "z")], -1)
        d = np.zeros(q.shape) if disp[kind] is None else (e * disp[kind]).sum(-1)
        size = max(np.abs(dG).max(), 1e-4)
        np.testing.assert_allclose(np.einsum("nab,nb->na", M, dG), d, rtol=0, atol=1e-12 * size,
                                   err_msg=kind)
    for k in ("x", "y", "z", "rx", "ry", "rz"):
        np.testing.assert_allclose(c[f"err_{k}"], sum(c[f"err_{kd}_{k}"] for kd in ru.KINDS),
                                   rtol=0, atol=1e-20)
    # Euler errors reconstruct d_alpha (docs/model.md section 6)
    th, ps = c["theta"], c["psi"]
    ey = np.array([0.0, 1.0, 0.0])
    col_x = np.stack([np.cos(th), 0 * th, -np.sin(th)], -1)
    col_z = np.einsum("nab,b->na", rot("y", th) @ rot("x", ps), [0.0, 0.0, 1.0])
    rec = c["err_theta"][:, None] * ey + c["err_psi"][:, None] * col_x + c["err_phi"][:, None] * col_z
    np.testing.assert_allclose(rec, np.stack([c["err_rx"], c["err_ry"], c["err_rz"]], -1),
                               rtol=0, atol=1e-18)


@pytest.mark.parametrize("kind", ["s_radial", "u_radial"])
def test_sag_under_gravity(kind):
    """With s_radial or u_radial alone and gravity only, the platform sags: err_z < 0 at
    every pose; its size is about the clearance (between 0.2 c and 5 c)."""
    job = with_job(DEFAULT, clearance={kind: 1e-4})
    c = ru.pose_arrays(job, *random_poses(50))
    assert (c["status"] == "ok").all()
    assert (c["err_z"] < 0).all()
    assert (np.abs(c["err_z"]) > 2e-5).all() and (np.abs(c["err_z"]) < 5e-4).all()


def test_linear_error_equals_exact_to_second_order():
    """All three kinds: |exact - linear| shrinks by about 4 (between 3.6 and 4.4, every
    pose) when every clearance is halved, and stays below 50 clearance/size of the error."""
    x = random_poses(40)
    diffs = []
    for eps in (4e-4, 2e-4, 1e-4):
        job = with_job(LOADED, clearance={k: v / 1e-4 * eps for k, v in
                                          {"s_radial": 1e-4, "u_radial": 0.5e-4, "u_angular": 1e-4}.items()},
                       analysis={"exact": True})
        c = ru.pose_arrays(job, *x)
        assert (c["status"] == "ok").all()
        lin = np.stack([c[f"err_{k}"] for k in ("x", "y", "z", "rx", "ry", "rz")], -1)
        ex = np.stack([c[f"exact_err_{k}"] for k in ("x", "y", "z", "rx", "ry", "rz")], -1)
        assert np.isfinite(ex).all()
        d = np.abs(ex - lin).max(-1)
        assert np.all(d <= 50 * eps * np.abs(lin).max(-1))
        diffs.append(d)
    for a, b in ((0, 1), (1, 2)):
        r = diffs[a] / diffs[b]
        assert np.all((r > 3.6) & (r < 4.4)), (r.min(), r.max())


def test_exact_error_solves_the_closure():
    """The exact error is a pose at which every leg, offset by its take-up, has its
    nominal length: | |p' + R' a'_i - dA_i - B_i - dB_i| - q_i | < 1e-15 m, with the
    take-up recomputed here from the reactions (u_angular: no effect on a leg's reach)."""
    job = with_job(LOADED, clearance={"s_radial": 1e-3, "u_radial": 5e-4, "u_angular": 2e-3},
                   analysis={"exact": True})
    x = random_poses(30)
    c = ru.pose_arrays(job, *x)
    assert (c["status"] == "ok").all()
    B, AP, _ = geometry(job)
    p, R, _, q, _ = ik(job, *x)
    w = np.stack([c[f"exact_err_r{a}"] for a in "xyz"], -1)
    th = np.linalg.norm(w, axis=-1)[:, None, None]
    z0 = 0 * w[:, 0]
    K = np.stack([np.stack([z0, -w[:, 2], w[:, 1]], -1), np.stack([w[:, 2], z0, -w[:, 0]], -1),
                  np.stack([-w[:, 1], w[:, 0], z0], -1)], -2)                # [w]x
    Rw = np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th ** 2 * (K @ K)
    p2 = p + np.stack([c[f"exact_err_{a}"] for a in "xyz"], -1)
    A2 = p2[:, None, :] + np.einsum("nab,ib->nia", Rw @ R, AP)
    fU = np.stack([np.stack([c[f"f_u{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    fS = np.stack([np.stack([c[f"f_s{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    dB = -5e-4 * fU / np.linalg.norm(fU, axis=-1)[..., None]
    dA = -1e-3 * fS / np.linalg.norm(fS, axis=-1)[..., None]
    qq = np.linalg.norm(A2 - dA - B - dB, axis=-1)
    assert np.abs(qq - q).max() < 1e-15


def test_u_angular_error_is_zero_linear_and_exact():
    """u_angular = 1e-3 rad alone: the linear error (computed through the 30 x 30 system)
    and the exact error (Newton on the 18 closure unknowns) are zero to round-off:
    < 1e-15 m and < 1e-15 rad at every pose, in statics and dynamics; the status is ok
    (u_angular is never indeterminate although mu_i is round-off)."""
    for job in (with_job(LOADED, clearance={"u_angular": 1e-3}, analysis={"exact": True},
                         grid={"x": {"start": -0.03, "stop": 0.03, "n": 3}, "z": {"start": 0.62, "stop": 0.78, "n": 4},
                               "phi": {"start": -0.1, "stop": 0.1, "n": 3},
                               "theta": {"start": -0.1, "stop": 0.1, "n": 3}}),
                with_job(traj_job(LOADED, n=21), clearance={"u_angular": 1e-3})):
        job = with_job(job, analysis=dict(job.get("analysis", {}), exact=True))
        c = ru.compute(job)
        assert (c["status"] == "ok").all()
        for k in ("x", "y", "z", "rx", "ry", "rz", "phi", "psi", "theta"):
            assert np.abs(c[f"err_u_angular_{k}"]).max() < 1e-15, k
            assert np.abs(c[f"err_{k}"]).max() < 1e-15, k
        for k in ("x", "y", "z", "rx", "ry", "rz"):
            assert np.isfinite(c[f"exact_err_{k}"]).all()
            assert np.abs(c[f"exact_err_{k}"]).max() < 1e-15, k


# --------------------------------------------------------------------------
# statuses, nulls, columns
# --------------------------------------------------------------------------
def test_statuses_and_nulls():
    """unreachable where a leg leaves [min_length, max_length] (our own IK decides),
    near_singular where a leg lies along its fixed U axis, indeterminate_contact where
    u_radial's load vanishes; nulls as docs/conventions.md."""
    job = with_job(DEFAULT, grid={"z": {"start": 0.3, "stop": 1.1, "n": 17}, "theta": {"start": -0.2, "stop": 0.2, "n": 3}})
    c = ru.compute(job)
    x = [c[k] for k in INPUTS]
    _, _, _, q, _ = ik(job, *x)
    out = np.any((q < 0.5) | (q > 1.0), -1)
    assert out.any() and (~out).any()
    np.testing.assert_array_equal(c["status"] == "unreachable", out)
    assert np.isnan(c["q1"][out]).all() and np.isnan(c["err_x"][out]).all()
    assert np.isfinite(c["q1"][~out]).all() and np.isfinite(c["err_x"][~out]).all()
    # a U axis along leg 1 at the home pose: near_singular, q and cond kept, the rest null
    P = ru.normalize_job(DEFAULT)
    e1 = ru.kinematics(P, *[np.array([v]) for v in (0, 0, 0.7, 0, 0, 0)])["e"][0, 0]
    axes = P["a1"].tolist()
    axes[0] = e1.tolist()
    c = ru.pose_arrays(with_job(DEFAULT, mechanism={"kind": "6-UPS", "u_axes": axes}), 0, 0, 0.7, 0, 0, 0)
    assert c["status"][0] == "near_singular"
    c_ok = ru.pose_arrays(DEFAULT, 0, 0, 0.7, 0, 0, 0)
    assert c_ok["status"][0] == "ok"
    assert c["q1"][0] == c_ok["q1"][0] and c["cond_a"][0] == c_ok["cond_a"][0]   # G has no U axis
    assert np.isnan(c["err_x"][0]) and np.isnan(c["f_u1_x"][0]) and np.isnan(c["margin_s1"][0])
    # no gravity, no load: every load vanishes -> indeterminate_contact for u_radial only
    job0 = with_job(DEFAULT, mechanism={"kind": "6-UPS", "gravity": [0.0, 0.0, 0.0]},
                    clearance={"u_radial": 1e-4, "u_angular": 1e-3})
    job0["mass"] = {"points": []}
    P0 = ru.normalize_job(job0)
    assert P0["W"] == 0.0
    c = ru.pose_arrays(job0, 0.0, 0.0, 0.7, 0.0, 0.0, 0.0)
    assert c["status"][0] == "indeterminate_contact"
    assert np.isnan(c["err_x"][0]) and np.isnan(c["err_u_radial_x"][0])
    # u_angular's error is computed (zero up to round-off, as test_u_angular_error_is_zero_
    # linear_and_exact bounds it): exactly 0.0 on one OpenBLAS kernel, 8e-20 on another.
    assert abs(c["err_u_angular_x"][0]) < 1e-15 and np.isfinite(c["f_u1_x"][0])


def test_columns_and_sampling():
    """Column names of docs/model.md 10.3 / docs/interface.md; a grid is row-major in
    x, y, z, phi, psi, theta."""
    job = with_job(DEFAULT, grid={"x": {"start": -0.01, "stop": 0.01, "n": 2}, "y": 0.0,
                                  "z": {"start": 0.65, "stop": 0.75, "n": 3}, "phi": 0.0,
                                  "psi": 0.0, "theta": {"start": -0.1, "stop": 0.1, "n": 2}},
                   analysis={"exact": True})
    c = ru.compute(job)
    names = list(c)
    for i in range(1, 7):
        for n in (f"q{i}", f"f_u{i}_x", f"f_u{i}_y", f"f_u{i}_z", f"m_u{i}", f"f_s{i}_x",
                  f"margin_u{i}_radial", f"margin_u{i}_angular", f"margin_s{i}"):
            assert n in names, n
    for k in ru.KINDS:
        for comp in ("x", "y", "z", "rx", "ry", "rz", "phi", "psi", "theta"):
            assert f"err_{k}_{comp}" in names
    assert "q7" not in names and "f_r1_x" not in names and "exact_err_rz" in names
    assert names[:11] == ["variant", "mode", "sample", "t", "x", "y", "z", "phi", "psi", "theta", "status"]
    np.testing.assert_array_equal(c["sample"], np.arange(12))
    np.testing.assert_array_equal(c["x"], np.repeat([-0.01, 0.01], 6))
    np.testing.assert_allclose(c["z"], np.tile(np.repeat([0.65, 0.7, 0.75], 2), 2), rtol=1e-15)
    np.testing.assert_array_equal(c["theta"], np.tile([-0.1, 0.1], 6))
    assert set(ru.column_names(DEFAULT, "minimal")) < set(ru.column_names(DEFAULT, "standard")) \
        < set(ru.column_names(DEFAULT, "full"))


def test_throughput_pipeline_agrees_with_compute():
    """pipeline() (the timed kernel) gives compute()'s per-kind errors bitwise."""
    P = ru.normalize_job(ru.THROUGHPUT_JOB)
    smp = ru.sample_inputs(P)
    sl = slice(0, 300)
    per, st = ru.pipeline(P, *[smp[k][sl] for k in INPUTS])
    c = ru.compute(ru.THROUGHPUT_JOB)
    assert (st == 0).all()
    for ki, k in enumerate(ru.KINDS):
        for ci, comp in enumerate(ru.COMPONENTS):
            np.testing.assert_array_equal(per[:, ci, ki], c[f"err_{k}_{comp}"][sl])


def _rows(cols):
    names = list(cols)
    out = []
    for r in range(cols["sample"].size):
        row = {}
        for n in names:
            v = cols[n][r]
            row[n] = None if (isinstance(v, float) and v != v) else v
        out.append(row)
    return out


@pytest.mark.parametrize("idx,traj", [(0, False), (1, True), (2, False)])
def test_pinocchio_check_ups_jobs_and_compare_path(idx, traj):
    """scripts/pinocchio_check.py's random 6-UPS jobs are valid for this reference (they
    survive TOML), and its engine comparison, fed with this reference's rows as if they
    were the engine's, passes every mode (reactions within 1e-9 W); a row with one force
    off by 1e-6 W fails it."""
    import tomllib
    pc = _pc()
    job = tomllib.loads(pc.to_toml(pc.random_ups_job(7, idx, traj, idx)))
    cols = ru.compute(job)
    rows = _rows(cols)
    res = pc.compare_ups_job(job, rows, {}, "t")
    assert res and all(ok for ok, _ in res.values()), res
    P = ru.normalize_job(job)
    k = next(i for i, r in enumerate(rows) if r["status"] == "ok")
    rows[k]["f_u3_y"] += 1e-6 * P["W"]
    res = pc.compare_ups_job(job, rows, {}, "t")
    assert not res[rows[k]["mode"]][0]


def test_envelope_and_dominant_against_reciprocal_screws():
    """The envelope from the 30 x 30 system against the closed form of the 6 x 6
    reciprocal-screw form (n_i = column i of M^-1; a translation u of limb i's U or S
    clearance gives Delta Gamma = n_i (e_i . u)): env_<kind>_c = c sum_i |n_ic| and
    env_<kind>_p = c sum_i |n_i,p| for s_radial and u_radial, 1e-10 relative; u_angular's
    envelope < 1e-15; the actual error lies inside the envelope (1e-12 relative); the
    dominant joint is the argmax of |n_i,p (e_i . d_i)| (where the top two differ by 1e-9)."""
    job = with_job(LOADED, clearance={"s_radial": 2e-4, "u_radial": 1e-4, "u_angular": 1e-3})
    P = ru.normalize_job(job)
    c = ru.pose_arrays(job, *random_poses(40))
    assert (c["status"] == "ok").all()
    x = [c[k] for k in INPUTS]
    _, _, A, q, e = ik(job, *x)
    p = np.stack(x[0:3], -1)
    Ninv = np.linalg.inv(np.concatenate([np.cross(A - p[:, None], e), e], -1))   # (N,6 rows,6 limbs)
    rows = {"x": 3, "y": 4, "z": 5, "rx": 0, "ry": 1, "rz": 2}
    for kind in ("s_radial", "u_radial"):
        cl = P["clear"][kind]
        for comp, r in rows.items():
            np.testing.assert_allclose(c[f"env_{kind}_{comp}"], cl * np.abs(Ninv[:, r]).sum(-1), rtol=1e-10)
        np.testing.assert_allclose(c[f"env_{kind}_p"], cl * np.linalg.norm(Ninv[:, 3:6], axis=1).sum(-1), rtol=1e-10)
        np.testing.assert_allclose(c[f"env_{kind}_alpha"], cl * np.linalg.norm(Ninv[:, 0:3], axis=1).sum(-1),
                                   rtol=1e-10)
    for comp in list(rows) + ["p", "alpha"]:
        assert np.abs(c[f"env_u_angular_{comp}"]).max() < 1e-15
    for comp in rows:
        assert np.all(np.abs(c[f"err_{comp}"]) <= c[f"env_{comp}"] * (1 + 1e-12))
    dp = np.linalg.norm(np.stack([c[f"err_{a}"] for a in "xyz"], -1), axis=-1)
    assert np.all(dp <= c["env_p"] * (1 + 1e-12))
    fU = np.stack([np.stack([c[f"f_u{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    fS = np.stack([np.stack([c[f"f_s{i}_{a}"] for a in "xyz"], -1) for i in range(1, 7)], 1)
    contrib = []
    for f, cl in ((fS, 2e-4), (fU, 1e-4)):
        d = (e * (-cl * f / np.linalg.norm(f, axis=-1)[..., None])).sum(-1)        # (N,6)
        contrib.append(np.linalg.norm(Ninv[:, 3:6] * d[:, None, :], axis=1))       # |Delta p| per limb
    contrib = np.concatenate(contrib, -1)                                           # s1..s6, u1..u6
    names = [f"s{i}_radial" for i in range(1, 7)] + [f"u{i}_radial" for i in range(1, 7)]
    top2 = np.sort(contrib, -1)[:, -2:]
    clear = top2[:, 1] - top2[:, 0] > 1e-9 * top2[:, 1]
    assert clear.sum() >= 30
    expect = np.array(names, dtype=object)[np.argmax(contrib, -1)]
    np.testing.assert_array_equal(c["dominant"][clear], expect[clear])


def test_tilt_play_alone_has_no_dominant_joint():
    """u_angular cannot move the platform, so with no other clearance no joint dominates
    (round-off must not name one), and its envelope is round-off."""
    job = with_job(LOADED, clearance={"s_radial": 0.0, "u_radial": 0.0, "u_angular": 1e-3})
    c = ru.pose_arrays(job, *random_poses(20))
    assert (c["status"] == "ok").all()
    assert all(d is None for d in c["dominant"])
    assert np.abs(c["env_p"]).max() < 1e-15


def test_leg_spin_does_not_reach_the_reactions():
    """Slender legs have no axial inertia, so the spin sigma_i e_i of omega_i leaves
    I w' + w x I w unchanged: the dynamic right-hand side with sigma = 0 (omega = e x e',
    omega' = e x e'') equals the reference's to 1e-12 of W (l_c + l_p)."""
    job = traj_job(LOADED, n=21, modes=("dynamic",))
    P = ru.normalize_job(job)
    smp = ru.sample_inputs(P)
    kj = ru.kinematics(P, *[smp[k + "j"] for k in INPUTS])
    kin = {k: (v.v if isinstance(v, ru.Jet) else v) for k, v in kj.items()}
    mot = ru.motion(kj, P)
    e, ed, edd = kj["e"].v, kj["e"].d, kj["e"].dd
    mot0 = dict(mot, w_leg=np.cross(e, ed), dw_leg=np.cross(e, edd))
    assert np.abs(mot["w_leg"] - mot0["w_leg"]).max() > 1e-3
    b, b0 = ru.equilibrium_rhs(P, kin, mot), ru.equilibrium_rhs(P, kin, mot0)
    assert np.abs(b - b0).max() < 1e-12 * P["W"] * (P["lc"] + P["lp"])
