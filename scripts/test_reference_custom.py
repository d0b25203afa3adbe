"""Self-tests of scripts/reference_custom.py (kind = "custom", docs/model.md section 12).

    python3 -m pytest scripts/test_reference_custom.py -q

Each test checks the reference against something computed another way, with the
tolerance in its docstring: the geometry of the solved configuration (rigid bodies,
the platform's points), finite differences of positions along trajectories, virtual
work from finite-difference virtual motions, the exact nonlinear closure (second-order
agreement), the reciprocal 6 x 6 form of the error system, and the built-in references
(reference_model.py for the 3-PRS and 3-RPS, reference_ups.py for the 6-UPS) through
the presets' custom descriptions (docs/model.md 12.9).  The refusals of 12.3 and the
cross-check script's comparison (on an output written from the reference itself) are
tested too.
"""

import math
import os
import sys
import tempfile
import tomllib

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import crosscheck_custom as xc  # noqa: E402
import reference_custom as rc  # noqa: E402
import reference_model as rm  # noqa: E402
import reference_ups as ru  # noqa: E402

RNG = np.random.default_rng(20260512)
I3 = np.eye(3)


# --------------------------------------------------------------------------
# jobs
# --------------------------------------------------------------------------
def rrs_job(**over):
    """A symmetric 3-RRS wrist: actuated crank, knee, ball; one limb repeated."""
    Rb, lc, beta, ll, rho = 0.3, 0.22, 0.2, 0.5, 0.15
    B = np.array([Rb, 0.0, 0.0])
    K = B + lc * np.array([math.cos(beta), 0.0, math.sin(beta)])
    hA = K[2] + math.sqrt(ll ** 2 - (rho - K[0]) ** 2)
    A = np.array([rho, 0.0, hA])
    job = {
        "mechanism": {
            "kind": "custom", "inputs": ["z", "psi", "theta"], "home": [0.0, 0.0, hA, 0.0, 0.0, 0.0],
            "limb": [{"repeat": 3, "joints": [
                {"type": "R", "name": "crank", "at": list(B), "axis": [0.0, 1.0, 0.0],
                 "actuated": True, "range": [-1.2, 1.2]},
                {"type": "R", "name": "knee", "at": list(K), "axis": [0.0, 1.0, 0.0]},
                {"type": "S", "at": list(A)}],
                "bodies": [{"mass": 1.0}, {"mass": 2.0, "com": list(0.5 * (K + A) + [0.0, 0.0, 0.01])}]}]},
        "mass": {"platform": 6.0, "points": [{"mass": 2.0, "at": [0.03, -0.02, 0.2]}]},
        "load": {"force": [4.0, -3.0, -6.0], "moment": [0.3, -0.2, 0.5], "at": [0.02, 0.01, 0.05]},
        "clearance": {"crank_backlash": 2e-4, "crank_radial": 3e-5, "crank_axial": 1e-5,
                      "crank_angular": 1e-4, "knee_radial": 2e-5, "knee_axial": [1e-5, 2e-5, 3e-5],
                      "knee_angular": 1e-4, "s_radial": 5e-5},
        "grid": {"z": hA, "psi": {"start": -0.1, "stop": 0.12, "n": 3}, "theta": 0.05},
    }
    for k, v in over.items():
        job[k] = v
    if "trajectory" in over:
        job.pop("grid", None)
    return job


def pus_job(**over):
    """A 6-PUS: vertical actuated sliders, U on the sliders, legs, S on the platform."""
    ang_b = np.radians([-15, 15, 105, 135, 225, 255])
    ang_p = np.radians([-45, 45, 75, 165, 195, 285])
    L = 0.6
    limbs = []
    Ah = []
    for i in range(6):
        B = 0.5 * np.array([math.cos(ang_b[i]), math.sin(ang_b[i]), 0.0])
        a = 0.25 * np.array([math.cos(ang_p[i]), math.sin(ang_p[i]), 0.0])
        hz = math.sqrt(L ** 2 - np.sum((a - B)[:2] ** 2))
        A = np.array([a[0], a[1], hz])
        e = (A - B) / L
        a1 = np.array([-math.sin(ang_b[i]), math.cos(ang_b[i]), 0.0])
        a2 = np.cross(a1, e)
        a2 /= np.linalg.norm(a2)
        limbs.append({"joints": [
            {"type": "P", "at": list(B), "axis": [0.0, 0.0, 1.0], "actuated": True, "range": [-0.3, 0.3]},
            {"type": "U", "at": list(B), "axes": [list(a1), list(a2)]},
            {"type": "S", "at": list(A)}],
            "bodies": [{"mass": 0.5}, {"mass": 1.2}]})
        Ah.append(hz)
    h = float(np.mean(Ah))
    job = {
        "mechanism": {"kind": "custom", "inputs": ["x", "y", "z", "phi", "psi", "theta"],
                      "home": [0.0, 0.0, h, 0.0, 0.0, 0.0], "limb": limbs},
        "mass": {"platform": 8.0, "platform_inertia": [0.12, 0.14, 0.25],
                 "points": [{"mass": 1.5, "at": [0.05, 0.0, 0.15]}]},
        "load": {"force": [2.0, 5.0, -10.0], "moment": [0.4, 0.1, -0.2], "at": [0.0, 0.03, 0.02]},
        "clearance": {"p_backlash": 1e-5, "p_radial": 2e-5, "p_angular": 5e-5, "u_radial": 3e-5,
                      "u_angular": 2e-4, "s_radial": 4e-5},
        "grid": {"x": 0.01, "y": -0.01, "z": {"start": h - 0.03, "stop": h + 0.02, "n": 2},
                 "phi": 0.03, "psi": {"start": -0.05, "stop": 0.06, "n": 2}, "theta": 0.04},
    }
    for k, v in over.items():
        job[k] = v
    if "trajectory" in over:
        job.pop("grid", None)
    return job


def generated(seed, families=xc.FAMILIES):
    job, tag, ref = xc.make_job(np.random.default_rng(seed), 0, families, cut_ranges=False)
    return job


JOBS = {"rrs": rrs_job, "pus": pus_job}


def random_inputs(M, n, span=1.0):
    """n poses around home: inputs perturbed, parasitic at home (solved)."""
    c = np.tile(M.home, (n, 1))
    amp = {0: 0.02, 1: 0.02, 2: 0.02, 3: 0.06, 4: 0.08, 5: 0.08}
    for i in M.inputs:
        c[:, i] += RNG.uniform(-1.0, 1.0, n) * amp[i] * span
    return c


def traj_points(M, t):
    tr = M.job["trajectory"]
    c = np.tile(M.home, (t.size, 1))
    cd, cdd = np.zeros_like(c), np.zeros_like(c)
    for i in M.inputs:
        if rc.COORDS[i] in tr:
            c[:, i], cd[:, i], cdd[:, i] = rm._harmonic(tr[rc.COORDS[i]], t)
    return c, cd, cdd


def body_positions(M, res):
    """Per body (limb bodies in order, then the platform): centre of mass (N,3) and the
    rotation from home (N,3,3), read off the solved configuration."""
    out = []
    for L, jg in zip(M.limbs, res["geo"]):
        for k, (m, c0, I0) in enumerate(L.bodies):
            R, t = jg[k]["R"], jg[k]["t"]
            out.append((m, np.einsum("nab,b->na", R, c0) + t, R))
    Rp, p = rc.platform_pose(res["c"])
    out.append((M.m_plat, p + np.einsum("nab,b->na", Rp, M.c_loc), Rp @ M.R_home.T))
    return out


# --------------------------------------------------------------------------
# kinematics
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rrs", "pus", "gen-prs", "gen-rps", "gen-ups", "gen-rus"])
def test_closure_at_the_solved_configuration(name):
    """The closure residual is below 1e-12; independently, every body keeps the distances
    between its joints' centres (1e-12 m), every last joint's centre is the platform point
    p + R a' with a' its home position in platform axes (1e-12 m), and each
    P joint's centre is its home point on the proximal body moved by q along the axis."""
    if name.startswith("gen"):
        fam = {"gen-prs": "3-PRS", "gen-rps": "3-RPS", "gen-ups": "6-UPS", "gen-rus": "6-RUS"}[name]
        job = generated(11, (fam,))
    else:
        job = JOBS[name]()
    M = rc.normalize_job(job)
    c = random_inputs(M, 12)
    st, conv = rc.solve_kinematics(M, c)
    assert conv.all()
    geo = rc.chain(M, st)
    F = rc.closure_residual(M, geo, st["c"])
    assert np.abs(F).max() < 1e-12
    Rp, p = rc.platform_pose(st["c"])
    for L, jg in zip(M.limbs, geo):
        for k in range(len(L.joints) - 1):
            # body k carries joint k's centre and, unless joint k+1 is a P (whose centre
            # travels with its distal body), joint k+1's centre
            d0 = np.linalg.norm(L.joints[k + 1].c - L.joints[k].c)
            nxt = jg[k + 1]["c"]
            if L.joints[k + 1].type == "P":
                nxt = nxt - st["q"][:, L.joints[k + 1].qi, None] * jg[k + 1]["a"]
            d = np.linalg.norm(nxt - jg[k]["c"], axis=-1)
            assert np.abs(d - d0).max() < 1e-12
        a_loc = M.R_home.T @ (L.joints[-1].c - M.p_home)
        assert np.abs(jg[-1]["c"] - (p + np.einsum("nab,b->na", Rp, a_loc))).max() < 1e-12
    # inputs reached, parasitic solved
    assert np.array_equal(st["c"][:, M.inputs], c[:, M.inputs])


def test_continuation_does_not_depend_on_the_batch():
    """The same pose solved alone, in a batch, or after other poses gives the same
    configuration to 1e-13 (no order or sharding dependence)."""
    M = rc.normalize_job(rrs_job())
    c = random_inputs(M, 7)
    st_all, _ = rc.solve_kinematics(M, c)
    st_one, _ = rc.solve_kinematics(M, c[3:4])
    st_rev, _ = rc.solve_kinematics(M, c[::-1])
    assert np.abs(st_all["q"][3] - st_one["q"][0]).max() < 1e-13
    assert np.abs(st_all["q"] - st_rev["q"][::-1]).max() < 1e-13


def test_preset_3prs_parasitic_equals_closed_forms():
    """On the prototype's description the solved parasitic motions equal docs/model.md
    section 2's closed forms (written here again) to 1e-13."""
    job = rc.preset_description({"mechanism": {}, "grid": {"z": 2.0}})
    M = rc.normalize_job(job)
    c = random_inputs(M, 20, 4.0)
    st, conv = rc.solve_kinematics(M, c)
    assert conv.all()
    psi, th, rp = c[:, 4], c[:, 5], 0.36
    phi = np.arctan2(np.sin(psi) * np.sin(th), np.cos(psi) + np.cos(th))
    y = -rp * np.cos(psi) * np.sin(phi)
    x = rp / 2 * (np.cos(th) * np.cos(phi) - np.cos(phi) * np.cos(psi)
                  + np.sin(psi) * np.sin(th) * np.sin(phi))
    assert np.abs(st["c"][:, 0] - x).max() < 1e-13
    assert np.abs(st["c"][:, 1] - y).max() < 1e-13
    assert np.abs(st["c"][:, 3] - phi).max() < 1e-13


@pytest.mark.parametrize("name", ["rrs", "pus", "gen-rps"])
def test_rates_match_finite_differences(name):
    """Along a trajectory, every body's centre-of-mass velocity and acceleration and its
    angular velocity (from the implicit differentiation) equal fourth-order central
    differences of the solved positions (h = 1e-3 s) to 1e-7 of their scale; the
    parasitic coordinates' rates likewise."""
    if name == "gen-rps":
        base = generated(5, ("3-RPS",))
        M0 = rc.normalize_job(base)
        hv = dict(zip(rc.COORDS, M0.home))
        tr = {"time": {"start": 0.0, "stop": 1.0, "n": 3},
              "z": {"offset": hv["z"], "harmonics": [{"amplitude": 0.02, "period": 1.3}]},
              "psi": {"offset": hv["psi"], "harmonics": [{"amplitude": 0.06, "period": 0.9, "phase": 0.4}]},
              "theta": {"offset": hv["theta"], "harmonics": [{"amplitude": 0.05, "period": 1.7}]}}
        job = dict(base, trajectory=tr)
        job.pop("grid", None)
    elif name == "rrs":
        job = rrs_job(trajectory={"time": {"start": 0.0, "stop": 1.0, "n": 3},
                                  "z": {"offset": rrs_job()["mechanism"]["home"][2],
                                        "harmonics": [{"amplitude": 0.02, "period": 1.1}]},
                                  "psi": {"offset": 0.01, "harmonics": [{"amplitude": 0.08, "period": 0.8}]},
                                  "theta": {"offset": 0.0, "harmonics": [{"amplitude": 0.07, "period": 1.4,
                                                                          "phase": 1.0}]}})
    else:
        h0 = pus_job()["mechanism"]["home"][2]
        tr = {"time": {"start": 0.0, "stop": 1.0, "n": 3},
              "x": {"offset": 0.0, "harmonics": [{"amplitude": 0.02, "period": 1.2}]},
              "y": {"offset": 0.01, "harmonics": [{"amplitude": 0.015, "period": 0.9}]},
              "z": {"offset": h0, "harmonics": [{"amplitude": 0.02, "period": 1.5}]},
              "phi": {"offset": 0.0, "harmonics": [{"amplitude": 0.05, "period": 1.1}]},
              "psi": {"offset": 0.0, "harmonics": [{"amplitude": 0.06, "period": 0.7, "phase": 0.5}]},
              "theta": 0.02}
        job = pus_job(trajectory=tr)
    M = rc.normalize_job(job)
    t = np.array([0.13, 0.41, 0.77])
    h = 1e-3
    offs = np.array([-2, -1, 0, 1, 2]) * h
    tt = (t[:, None] + offs[None, :]).ravel()
    c, cd, cdd = traj_points(M, tt)
    res = rc.evaluate(M, c, "dynamic", cd, cdd)
    assert res["reach"].all()
    n = t.size

    def fd(x):                                   # x (n*5, ...) -> first, second derivative
        x = x.reshape((n, 5) + x.shape[1:])
        d1 = (x[:, 0] - 8 * x[:, 1] + 8 * x[:, 3] - x[:, 4]) / (12 * h)
        d2 = (-x[:, 0] + 16 * x[:, 1] - 30 * x[:, 2] + 16 * x[:, 3] - x[:, 4]) / (12 * h * h)
        return d1, d2

    mid = np.arange(n) * 5 + 2
    rt = res["rt"]
    d1, d2 = fd(res["st"]["c"])
    assert np.abs(d1 - rt["cd"][mid]).max() < 1e-7 * max(1.0, np.abs(d1).max())
    assert np.abs(d2 - rt["cdd"][mid]).max() < 1e-5 * max(1.0, np.abs(d2).max())
    bodies = body_positions(M, res)
    k = 0
    for L in M.limbs:
        for b in range(len(L.bodies)):
            _, G, R = bodies[k]
            k += 1
            V, A = rt["V"][L.number - 1][b][mid], rt["A"][L.number - 1][b][mid]
            w, v, dw, dv = V[:, 0:3], V[:, 3:6], A[:, 0:3], A[:, 3:6]
            Gm = G[mid]
            vG = v + np.cross(w, Gm)
            aG = dv + np.cross(dw, Gm) + np.cross(w, v + np.cross(w, Gm))
            g1, g2 = fd(G)
            sc = max(1e-3, np.abs(g1).max())
            assert np.abs(g1 - vG).max() < 1e-7 * sc
            assert np.abs(g2 - aG).max() < 1e-5 * max(1e-2, np.abs(g2).max())
            R1, _ = fd(R)
            wfd = rm.vee(R1 @ R[mid].swapaxes(-1, -2))
            assert np.abs(wfd - w).max() < 1e-7 * max(1e-2, np.abs(w).max())
    # platform: composite centre acceleration and angular velocity
    _, C, Rp = bodies[-1]
    c1, c2 = fd(C)
    assert np.abs(c2 - rt["a_C"][mid]).max() < 1e-5 * max(1e-2, np.abs(c2).max())
    R1, R2 = fd(Rp)
    wfd = rm.vee(R1 @ Rp[mid].swapaxes(-1, -2))
    assert np.abs(wfd - rt["w"][mid]).max() < 1e-7 * max(1e-2, np.abs(wfd).max())


# --------------------------------------------------------------------------
# reactions
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rrs", "pus", "gen-prs", "gen-ups", "gen-rus"])
def test_statics_satisfy_virtual_work(name):
    """sum tau_k dq_k + dW_gravity + dW_external = 0 for motions the closure allows: the
    virtual motion is a fourth-order central difference of solved configurations along a
    random direction of the inputs; the sum is below 1e-8 of the sum of the terms'
    magnitudes."""
    if name.startswith("gen"):
        job = generated(23, ({"gen-prs": "3-PRS", "gen-ups": "6-UPS", "gen-rus": "6-RUS"}[name],))
    else:
        job = JOBS[name]()
    M = rc.normalize_job(job)
    n = 4
    c0 = random_inputs(M, n)
    dirn = np.zeros((n, 6))
    dirn[:, M.inputs] = RNG.normal(size=(n, len(M.inputs)))
    h = 1e-4
    offs = np.array([-2, -1, 1, 2]) * h
    pts = np.concatenate([c0] + [c0 + o * dirn for o in offs])
    res = rc.evaluate(M, pts, "kinetostatic")
    assert res["reach"].all()
    N = n
    base = rc.evaluate(M, c0, "kinetostatic")
    w4 = np.array([1.0, -8.0, 8.0, -1.0]) / (12 * h)

    def delta(x):                               # x (5n, ...) -> derivative along dirn (n, ...)
        xs = x.reshape((5, N) + x.shape[1:])
        return sum(wk * xs[1 + k] for k, wk in enumerate(w4))

    q = rc.joint_values(M, res["st"])
    dq = delta(q)
    tau = np.stack([np.einsum("na,na->n", base["jload"][id(J)][1] if J.type == "R" else base["jload"][id(J)][0],
                              base["jgeo"][id(J)]["a"]) for J in M.actuators], -1)
    terms = [tau * dq]
    bodies = body_positions(M, res)
    for m, G, R in bodies:
        terms.append((m * np.einsum("a,na->n", M.g, delta(G)))[:, None])
    Rp, p = rc.platform_pose(res["c"])
    E = p + np.einsum("nab,b->na", Rp, M.at_ext)
    dR = delta(Rp)
    dalpha = rm.vee(dR @ Rp[:N].swapaxes(-1, -2))
    terms.append((np.einsum("a,na->n", M.f_ext, delta(E)) + np.einsum("a,na->n", M.m_ext, dalpha))[:, None])
    T = np.concatenate(terms, -1)
    assert np.all(np.abs(T.sum(-1)) < 1e-8 * np.abs(T).sum(-1))


def test_reactions_satisfy_each_body_and_the_joint_restrictions():
    """Independent of the assembled matrix: with the solved joint wrenches, every moving
    body's forces and moments (about the origin) balance gravity and the external load to
    1e-10 of the weight, and each joint's wrench lies in its table row of 12.4
    (R: m . a = 0; P: f . d = 0; U: m parallel to n; S: m = 0) to 1e-12."""
    M = rc.normalize_job(pus_job())
    c = random_inputs(M, 5)
    res = rc.evaluate(M, c, "kinetostatic")
    W = M.W
    for L, jg in zip(M.limbs, res["geo"]):
        for k, g in enumerate(jg):
            J = g["J"]
            f, m = res["jload"][id(J)]
            if J.type == "R" and not J.actuated:
                assert np.abs(np.einsum("na,na->n", m, g["a"])).max() < 1e-12 * W
            if J.type == "P" and not J.actuated:
                assert np.abs(np.einsum("na,na->n", f, g["a"])).max() < 1e-12 * W
            if J.type == "U":
                assert np.abs(np.cross(m, g["n"])).max() < 1e-12 * W
            if J.type == "S":
                assert np.abs(m).max() == 0.0
    # balance of each limb body and of the platform, moments about the origin
    net = {}
    for L, jg in zip(M.limbs, res["geo"]):
        for k, g in enumerate(jg):
            f, m = res["jload"][id(g["J"])]
            wr = np.concatenate([f, m + np.cross(g["c"], f)], -1)
            dist = (L.number, k) if k < len(L.bodies) else "platform"
            net[dist] = net.get(dist, 0.0) + wr
            if k > 0:
                net[(L.number, k - 1)] = net[(L.number, k - 1)] - wr
    bodies = body_positions(M, res)
    i = 0
    for L in M.limbs:
        for k in range(len(L.bodies)):
            m, G, _ = bodies[i]
            i += 1
            grav = np.concatenate([np.broadcast_to(m * M.g, G.shape), np.cross(G, m * M.g)], -1)
            assert np.abs(net[(L.number, k)] + grav).max() < 1e-10 * W
    m, C, Rp = bodies[-1]
    _, p = rc.platform_pose(res["c"])
    E = p + np.einsum("nab,b->na", rc.platform_pose(res["c"])[0], M.at_ext)
    ext = np.concatenate([np.broadcast_to(m * M.g + M.f_ext, C.shape),
                          np.cross(C, m * M.g) + np.cross(E, M.f_ext) + M.m_ext], -1)
    assert np.abs(net["platform"] + ext).max() < 1e-10 * W


# --------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rrs", "pus"])
def test_linear_error_equals_exact_to_second_order(name):
    """|exact - linear| shrinks like the clearance squared: scaling every clearance by
    1/10 divides it by 100 (between 40 and 250), and at the job's clearances it is
    below 2 % of |linear|."""
    base = JOBS[name]()
    d = {}
    for s in (1.0, 0.1):
        job = dict(base)
        job["clearance"] = {k: ([x * s for x in v] if isinstance(v, list) else v * s)
                            for k, v in base["clearance"].items()}
        job["analysis"] = {"exact": True}
        cols = rc.compute(job)
        ok = cols["status"] == "ok"
        assert ok.sum() >= 2
        lin = np.stack([cols[f"err_{c}"] for c in ("x", "y", "z", "rx", "ry", "rz")], -1)[ok]
        ex = np.stack([cols[f"exact_err_{c}"] for c in ("x", "y", "z", "rx", "ry", "rz")], -1)[ok]
        assert np.isfinite(ex).all()
        d[s] = (np.abs(ex - lin).max(-1), np.abs(lin).max(-1))
    ratio = d[1.0][0] / d[0.1][0]
    assert np.all((ratio > 40) & (ratio < 250)), ratio
    assert np.all(d[1.0][0] < 0.02 * d[1.0][1])


@pytest.mark.parametrize("name", ["rrs", "pus", "gen-rps"])
def test_reciprocal_form_agrees_with_the_assembled_system(name):
    """MODEL 12.6: with W_i a basis of the wrenches reciprocal to limb i's passive twists,
    W_i^T Delta Gamma = W_i^T sum zeta (stacked, 6 x 6) gives the assembled system's
    Delta Gamma of every kind to 1e-12 of the kind's largest component (at least its
    magnitude, angular ones times Lchar)."""
    job = generated(8, ("3-RPS",)) if name.startswith("gen") else JOBS[name]()
    M = rc.normalize_job(job)
    c = random_inputs(M, 6)
    res = rc.evaluate(M, c, "kinetostatic")
    p = res["p"]
    N = p.shape[0]
    rows, rhs = [], []
    for i, t in enumerate(res["T"]):
        f = t.shape[-1]
        sw = np.concatenate([t[:, 3:6], t[:, 0:3]], 1)
        _, _, vh = np.linalg.svd(sw.swapaxes(-1, -2), full_matrices=True)
        Wi = vh[:, f:, :]                                           # (N, 6-f, 6): [f; m_P]
        # pairing with a twist [w; v]: f . v + m . w
        rows.append(np.concatenate([Wi[:, :, 3:6], Wi[:, :, 0:3]], -1))
        z = np.zeros((N, 6, len(M.kinds)))
        for g in M.groups:
            if g.limb.number != i + 1:
                continue
            d = res["groups"][g.name]["disp"]
            ki = M.kinds.index(g.kind)
            if g.rot:
                z[:, 0:3, ki] += d
                z[:, 3:6, ki] += np.cross(d, p - res["jgeo"][id(g.joint)]["c"])
            else:
                z[:, 3:6, ki] += d
        rhs.append(np.einsum("nrk,nkc->nrc", rows[-1], z))
    A6 = np.concatenate(rows, 1)
    dG = np.linalg.solve(A6, np.concatenate(rhs, 1))
    per = res["per"]
    for ki, kind in enumerate(M.kinds):
        # a kind whose error is zero (the PUS's U tilt play) is round-off of its own size
        nat = sum(g.mag * (M.Lchar if g.rot else 1.0) for g in M.groups if g.kind == kind)
        sc = max(np.abs(per[:, :, ki]).max(), nat)
        assert np.abs(dG[:, :, ki] - per[:, :, ki]).max() <= 1e-12 * sc


def test_u_angular_play_cannot_move_the_pus_platform():
    """The U tilt play of a PUS leg gives a zero error (below 1e-12 of the play times the
    leg), its unit response is below 1e-9, it never makes a row indeterminate (its load
    mu is round-off) and is never dominant."""
    job = pus_job()
    job["clearance"] = {"u_angular": 1e-3, "s_radial": 1e-5}
    M = rc.normalize_job(job)
    cols = rc.compute(M, extras=True)
    assert np.all(cols["status"] == "ok")
    for comp in ("x", "y", "z", "rx", "ry", "rz"):
        assert np.abs(cols[f"err_u_angular_{comp}"]).max() < 1e-12 * 1e-3 * 0.6
    assert np.abs(cols["env_u_angular_p"]).max() < 1e-12
    assert all(str(d).startswith("s") for d in cols["dominant"])
    res = rc.evaluate(M, random_inputs(M, 3), "kinetostatic")
    for L in M.limbs:
        gd = res["groups"][f"u{L.number}_angular"]
        assert not gd["moves"].any() and np.all(gd["unit"] < 1e-9)
        assert np.all(gd["margin"] < 1e-9 * M.W)           # mu is round-off


def test_sag_under_gravity():
    """With only S radial play and gravity alone, the 3-RRS platform sags (err_z < 0)."""
    job = rrs_job()
    job["clearance"] = {"s_radial": 1e-4}
    job.pop("load")
    cols = rc.compute(job)
    assert np.all(cols["err_z"] < 0)


# --------------------------------------------------------------------------
# presets against the built-in references
# --------------------------------------------------------------------------
CL3 = {"s_radial": 1e-4, "r_radial": 2e-4, "r_axial": 5e-5, "r_angular": 3e-4}
LOAD = {"force": [3.0, -2.0, -10.0], "moment": [0.5, 0.2, -0.3], "at": [0.05, 0.0, 0.1]}
PRESETS = {
    "prototype-grid": ({"clearance": CL3, "mass": {"points": [{"mass": 30.0, "at": [0.0, 0.0, 1.0]}]},
                        "grid": {"z": 2.05, "psi": {"start": -0.4, "stop": 0.4, "n": 5},
                                 "theta": {"start": -0.4, "stop": 0.4, "n": 5}},
                        "analysis": {"exact": True}}, None),
    "3prs-rail-traj": ({"mechanism": {"kind": "3-PRS", "rail_angle_deg": -60.0,
                                      "limb_angles_deg": [0.0, 110.0, 250.0], "leg_length": 0.9},
                        "clearance": CL3, "load": LOAD,
                        "mass": {"leg": 2.0, "points": [{"mass": 5.0, "at": [0.1, 0.0, 0.3]}]},
                        "trajectory": {"time": {"start": 0.0, "stop": 2.0, "n": 9},
                                       "z": {"offset": 0.75, "harmonics": [{"amplitude": 0.05, "period": 1.7}]},
                                       "psi": {"offset": 0.0, "harmonics": [{"amplitude": 0.2, "period": 2.1,
                                                                             "phase": 0.3}]},
                                       "theta": {"offset": 0.05, "harmonics": [{"amplitude": 0.2, "period": 1.3}]}},
                        "analysis": {"exact": True, "modes": ["kinetostatic", "dynamic"]}}, (0.75, 0.0, 0.0)),
    "3rps-traj": ({"mechanism": {"kind": "3-RPS", "platform_angles_deg": [10.0, 130.0, 250.0]},
                   "clearance": CL3, "load": LOAD, "mass": {"points": [{"mass": 5.0, "at": [0.1, 0.0, 0.3]}]},
                   "trajectory": {"time": {"start": 0.0, "stop": 2.0, "n": 9},
                                  "z": {"offset": 0.9, "harmonics": [{"amplitude": 0.1, "period": 1.7}]},
                                  "psi": {"offset": 0.0, "harmonics": [{"amplitude": 0.2, "period": 2.1}]},
                                  "theta": {"offset": 0.05, "harmonics": [{"amplitude": 0.25, "period": 1.3}]}},
                   "analysis": {"exact": True, "modes": ["kinetostatic", "dynamic"]}}, None),
    "6ups-grid": ({"mechanism": {"kind": "6-UPS"}, "clearance": {"s_radial": 1e-4, "u_radial": 2e-4,
                                                                  "u_angular": 1e-3},
                   "load": LOAD, "grid": {"x": 0.01, "z": {"start": 0.62, "stop": 0.75, "n": 3},
                                          "psi": {"start": -0.1, "stop": 0.1, "n": 3}, "theta": 0.05},
                   "analysis": {"exact": True}}, None),
    "6ups-traj": ({"mechanism": {"kind": "6-UPS", "u_axes": [[0.2, 1.0, 0.1], [-0.3, 1.0, -0.2],
                                                               [-1.0, -0.1, 0.3], [-0.7, -0.7, 0.0],
                                                               [0.7, -0.8, 0.1], [1.0, -0.2, -0.2]]},
                   "mass": {"points": [{"mass": 3.0, "at": [0.05, 0.0, 0.2]}], "platform_inertia": [0.3, 0.35, 0.6]},
                   "clearance": {"s_radial": 1e-4, "u_radial": 2e-4, "u_angular": 1e-3}, "load": LOAD,
                   "trajectory": {"time": {"start": 0.0, "stop": 2.0, "n": 7},
                                  "x": {"offset": 0.01, "harmonics": [{"amplitude": 0.03, "period": 1.5}]},
                                  "z": {"offset": 0.7, "harmonics": [{"amplitude": 0.05, "period": 1.1}]},
                                  "phi": {"offset": 0.0, "harmonics": [{"amplitude": 0.1, "period": 1.9}]},
                                  "theta": {"offset": 0.02, "harmonics": [{"amplitude": 0.1, "period": 1.3}]}},
                   "analysis": {"exact": True, "modes": ["kinetostatic", "dynamic"]}}, None),
}


def _builtin_name(col, ups):
    """custom column -> built-in column (None: no counterpart)."""
    if col.startswith("margin_s"):
        return col[:-len("_radial")]
    return col


def _scale_group(col):
    if col.startswith(("f_", "margin_")) and not col.endswith("_angular"):
        return "force"
    if col.startswith("m_") or col.endswith("_angular"):
        return "couple"
    if col.startswith(("err_", "env_", "exact_")):
        return "len" if col.rsplit("_", 1)[1] in ("x", "y", "z", "p") else "ang"
    return col


@pytest.mark.parametrize("case", list(PRESETS))
def test_presets_give_the_builtin_values(case):
    """The presets' custom descriptions (12.9) give the built-in references' values for
    every column but q, to 1e-9 of each column's scale (its largest value, at least 1e-3
    of its unit group's and 1e-6 of the natural magnitude: W for forces, W L for
    couples, the clearances for errors), in kinetostatics and dynamics; statuses, nulls
    and the dominant joint are equal; tau of the 3-PRS equals f_r . d_j (massless
    sliders); m_u of the 6-UPS equals mu n."""
    job, home = PRESETS[case]
    ups = job.get("mechanism", {}).get("kind") == "6-UPS"
    cj = tomllib.loads(xc.to_toml(rc.preset_description(job, home)))
    M = rc.check_description(cj)
    cols = rc.compute(M)
    ref = ru.compute(job, "full") if ups else rm.compute(job)
    P = ru.normalize_job(job) if ups else rm.normalize_job(job)
    assert np.array_equal(cols["status"], ref["status"])
    assert np.array_equal(cols["dominant"], ref["dominant"])
    W, L = P["W"], P["size"]
    clear = P["clear"]
    trans = max(v for k, v in clear.items() if not k.endswith("angular"))
    ang = max(v for k, v in clear.items() if k.endswith("angular"))
    nat = {"force": W, "couple": W * L, "len": trans + L * ang, "ang": ang + trans / L}
    for mode in M.modes:
        sel = ref["mode"] == mode
        pairs = []
        for c in ref:
            if c in ("variant", "mode", "sample", "status", "dominant", "cond_a", "cond_jp") \
                    or c.startswith("q") or c.startswith("m_u"):
                continue
            cc = c + "_radial" if c.startswith("margin_s") else c
            assert cc in cols, cc
            pairs.append((cc, np.asarray(ref[c], float)[sel], np.asarray(cols[cc], float)[sel]))
        if ups:
            n = ru.kinematics(P, *[ref[k][sel] for k in ru.INPUTS])["n"]
            for i in range(6):
                mvec = ref[f"m_u{i + 1}"][sel][:, None] * n[:, i]
                for a_i, a in enumerate("xyz"):
                    pairs.append((f"m_u{i + 1}_{a}", mvec[:, a_i], np.asarray(cols[f"m_u{i + 1}_{a}"])[sel]))
        elif P["kind"] == "3-PRS":
            for j in range(3):
                f = np.stack([ref[f"f_r{j + 1}_{a}"][sel] for a in "xyz"], -1)
                pairs.append((f"tau{j + 1}", f @ P["DJ"][j], np.asarray(cols[f"tau{j + 1}"])[sel]))
        gmax = {}
        for cc, r, cu in pairs:
            g = _scale_group(cc)
            gmax[g] = max(gmax.get(g, 0.0), np.nanmax(np.abs(r), initial=0.0))
        tol = 1e-9
        for cc, r, cu in pairs:
            assert np.array_equal(np.isnan(r), np.isnan(cu)), cc
            g = _scale_group(cc)
            sc = max(np.nanmax(np.abs(r), initial=0.0), 1e-3 * gmax.get(g, 0.0), 1e-6 * nat.get(g, 1.0))
            err = np.nanmax(np.abs(r - cu), initial=0.0)
            assert err <= tol * sc, (mode, cc, err, sc)


def test_preset_q_is_measured_from_home():
    """q<k> of a preset is the built-in q minus its home value (1e-12)."""
    job = {"mechanism": {"kind": "3-RPS"}, "clearance": CL3,
           "grid": {"z": 0.85, "psi": {"start": -0.2, "stop": 0.2, "n": 3}, "theta": 0.1}}
    cj = rc.preset_description(job)
    cols = rc.compute(cj)
    ref = rm.compute(job)
    P = rm.normalize_job(job)
    h = cj["mechanism"]["home"]
    qh = rm.kinematics(P, np.array([h[2]]), np.array([h[4]]), np.array([h[5]]))["q"][0]
    for j in range(3):
        assert np.abs(cols[f"q{j + 1}"] - (ref[f"q{j + 1}"] - qh[j])).max() < 1e-12


# --------------------------------------------------------------------------
# description, sampling, statuses
# --------------------------------------------------------------------------
def _prs_like(n_limbs=3, replace=None, extra_limb=None):
    job = rc.preset_description({"mechanism": {}, "grid": {"z": 2.0}})
    if replace:
        for lb in job["mechanism"]["limb"]:
            lb["joints"] = replace(lb["joints"])
    if extra_limb:
        job["mechanism"]["limb"].append(extra_limb(job["mechanism"]["limb"][0]))
    return job


def test_refusals():
    """check_description refuses (ValueError) an overconstrained description, a not-rigid
    one (both with the counts), an idle freedom (the limb and the U hint), duplicate
    names, a zero axis, U axes not perpendicular, inputs not coordinates or not as many as
    the actuators, a clearance key naming no joint group or with a list of the wrong
    length, and a description with correct counts that is rank deficient at home."""
    import copy
    # four PRS limbs: 4 * 14 = 56 components for 9 bodies (54)
    job = _prs_like(extra_limb=lambda lb: copy.deepcopy(lb))
    with pytest.raises(ValueError, match=r"overconstrained.*56.*54"):
        rc.check_description(job)
    # R replaced by a U: 3 * 13 = 39 components for 7 bodies (42)
    def r_to_u(joints):
        js = copy.deepcopy(joints)
        a = np.array(js[1]["axis"])
        b = np.cross(a, [0.0, 0.0, 1.0])
        js[1] = {"type": "U", "name": "r", "at": js[1]["at"], "axes": [list(a), list(b / np.linalg.norm(b))]}
        return js
    with pytest.raises(ValueError, match=r"not rigid.*39.*42"):
        rc.check_description(_prs_like(replace=r_to_u))
    # an SPS leg: two S joints with only an actuated P between them
    ups = rc.preset_description({"mechanism": {"kind": "6-UPS"}, "grid": {"z": 0.7}})
    sps = copy.deepcopy(ups)
    at = ups["mechanism"]["limb"][2]["joints"][0]["at"]
    sps["mechanism"]["limb"][2]["joints"][0] = {"type": "S", "name": "b", "at": at}
    with pytest.raises(ValueError, match=r"limb 3.*idle freedom.*U joint"):
        rc.check_description(sps)
    # every limb an SPS: the counts are wrong too (72 for 78), the idle freedom comes first
    sps6 = copy.deepcopy(ups)
    for lb in sps6["mechanism"]["limb"]:
        lb["joints"][0] = {"type": "S", "name": "b", "at": lb["joints"][0]["at"]}
    with pytest.raises(ValueError, match=r"limb 1.*idle freedom"):
        rc.check_description(sps6)
    # correct counts, rank deficient at home: six vertical legs cannot hold a side load
    B = np.array([j["joints"][0]["at"] for j in ups["mechanism"]["limb"]])
    vert = rc.preset_description({"mechanism": {"kind": "6-UPS", "base_points": B.tolist(),
                                                "platform_points": (B - [0.0, 0.0, 0.0]).tolist()},
                                  "grid": {"z": 0.7}}, (0.0, 0.0, 0.7, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="rank deficient"):
        rc.check_description(vert)
    bad = copy.deepcopy(ups)
    bad["mechanism"]["limb"][0]["joints"][1]["name"] = "u"
    with pytest.raises(ValueError, match="share the name"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["mechanism"]["limb"][0]["joints"][1]["axis"] = [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="zero axis"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["mechanism"]["limb"][0]["joints"][0]["axes"][1] = [0.3, 0.3, 0.9]
    with pytest.raises(ValueError, match="not perpendicular"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["mechanism"]["inputs"] = ["x", "y", "z", "phi", "psi", "tilt"]
    with pytest.raises(ValueError, match="not a platform coordinate"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["mechanism"]["inputs"] = ["x", "y", "z", "phi", "psi"]
    bad["grid"] = {"z": 0.7}
    with pytest.raises(ValueError, match="5 inputs for 6 actuated"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["clearance"] = {"u_axial": 1e-4}
    with pytest.raises(ValueError, match="names no joint group"):
        rc.check_description(bad)
    bad = copy.deepcopy(ups)
    bad["clearance"] = {"u_radial": [1e-4, 1e-4]}
    with pytest.raises(ValueError, match="6 values expected"):
        rc.check_description(bad)


def test_repeat_rotates_copies_and_numbers_them_after_the_original():
    """repeat = 3 gives limbs 1, 2, 3: the original and copies rotated about z by 120 and
    240 degrees (1e-15), and the same reactions as the limbs written out."""
    import copy
    job = rrs_job()
    M = rc.normalize_job(job)
    assert [L.number for L in M.limbs] == [1, 2, 3]
    for k, L in enumerate(M.limbs):
        Rz = rm.rot_exp(np.array([[0.0, 0.0, k * 2 * math.pi / 3]]))[0]
        for J, J0 in zip(L.joints, M.limbs[0].joints):
            assert np.abs(J.c - Rz @ J0.c).max() < 1e-15
            if J.a is not None:
                assert np.abs(J.a - Rz @ J0.a).max() < 1e-15
    out = copy.deepcopy(job)
    lb = out["mechanism"]["limb"][0]
    del lb["repeat"]
    limbs = []
    for k in range(3):
        Rz = rm.rot_exp(np.array([[0.0, 0.0, math.radians(120.0 * k)]]))[0]
        limbs.append({"joints": [dict(j, at=list(Rz @ np.array(j["at"])),
                                      **({"axis": list(Rz @ np.array(j["axis"]))} if "axis" in j else {}))
                                 for j in lb["joints"]],
                      "bodies": [dict(b, **({"com": list(Rz @ np.array(b["com"]))} if "com" in b else {}))
                                 for b in lb["bodies"]]})
    out["mechanism"]["limb"] = limbs
    a, b = rc.compute(job), rc.compute(out)
    for c in a:
        if c.startswith("f_") or c.startswith("err_"):
            assert np.allclose(a[c], b[c], rtol=1e-12, atol=1e-12 * (1.0 if c.startswith("f_") else 1e-4))


def test_grid_is_row_major_in_canonical_order():
    """The inputs listed in any order give the same rows: row-major over x, y, z, phi,
    psi, theta; a non-input grid key is refused."""
    job = pus_job()
    job2 = dict(job, mechanism=dict(job["mechanism"], inputs=["theta", "z", "psi", "x", "phi", "y"]))
    a, b = rc.compute(job), rc.compute(job2)
    assert np.array_equal(a["z"], b["z"]) and np.array_equal(a["psi"], b["psi"])
    z = job["grid"]["z"]
    assert np.array_equal(a["z"], np.repeat([z["start"], z["stop"]], 2))
    assert np.array_equal(a["psi"], np.tile([-0.05, 0.06], 2))
    bad = rrs_job()
    bad["grid"] = dict(bad["grid"], x=0.0)
    with pytest.raises(ValueError, match="not an input"):
        rc.normalize_job(bad)


def test_statuses_and_nulls():
    """A crank leaving its range is unreachable with the parasitic motions still
    reported; a pose beyond reach (continuation fails) has them null; the symmetric
    3-RRS on psi = 0 has limb 1's knee axial load at round-off: indeterminate_contact,
    with that kind's errors null and the others' reported, totals and exact null."""
    job = rrs_job()
    job["mechanism"]["limb"][0]["joints"][0]["range"] = [-0.05, 0.05]
    z0 = job["mechanism"]["home"][2]
    job["grid"] = {"z": {"start": z0 - 0.06, "stop": z0 + 0.06, "n": 3}, "psi": 0.0, "theta": 0.0}
    cols = rc.compute(job)
    assert list(cols["status"]) == ["unreachable", "ok", "unreachable"]     # the middle is home
    assert np.isfinite(cols["x"][0]) and np.isfinite(cols["phi"][2])
    job["grid"]["z"] = z0 + 0.5                                              # beyond reach
    far = rc.compute(job)
    assert far["status"][0] == "unreachable" and np.isnan(far["x"][0]) and far["z"][0] == z0 + 0.5
    assert np.isnan(cols["q1"][0]) and np.isnan(cols["err_x"][0]) and np.isnan(cols["f_crank1_x"][0])
    job = rrs_job()
    job.pop("load")                                   # loads symmetric about the x-z plane
    job["mass"]["points"][0]["at"][1] = 0.0
    job["analysis"] = {"exact": True}
    job["grid"] = {"z": z0, "psi": 0.0, "theta": 0.1}
    cols = rc.compute(job)
    assert cols["status"][0] == "indeterminate_contact"
    assert cols["margin_knee1_axial"][0] < 1e-9 * rc.normalize_job(job).W
    assert np.isnan(cols["err_knee_axial_x"][0]) and np.isnan(cols["err_x"][0])
    assert np.isnan(cols["exact_err_x"][0]) and cols["dominant"][0] is None
    assert np.isfinite(cols["err_knee_radial_x"][0]) and np.isfinite(cols["env_p"][0])
    assert np.isfinite(cols["q1"][0]) and np.isfinite(cols["tau1"][0])


def test_dominant_tie_order():
    """Two groups of equal effect tie and go to the first in the order S, U, R, P; place;
    radial, axial, angular, backlash; limb: on the symmetric level 3-RRS with equal S
    radial plays the three limbs tie (to round-off) and limb 1 is named."""
    job = rrs_job()
    job.pop("load")
    job["mass"] = {"platform": 6.0}
    job["clearance"] = {"s_radial": 1e-4, "knee_radial": 1e-6}
    job["grid"] = {"z": job["mechanism"]["home"][2], "psi": 0.0, "theta": 0.0}
    cols = rc.compute(job)
    assert cols["dominant"][0] == "s1_radial"


# --------------------------------------------------------------------------
# the cross-check script itself
# --------------------------------------------------------------------------
def knee_trajectory_job():
    """The 3-RRS along a trajectory whose knees' axial loads change sign between samples,
    with the knees' axial and the S joints' radial play, as read back from TOML."""
    z0 = rrs_job()["mechanism"]["home"][2]
    job = rrs_job(trajectory={"time": {"start": 0.0, "stop": 2.0, "n": 9}, "z": z0,
                              "psi": {"offset": 0.0, "harmonics": [{"amplitude": 0.1, "period": 2.0,
                                                                    "phase": 0.3}]},
                              "theta": 0.05})
    job["clearance"] = {"knee_axial": 1e-5, "s_radial": 1e-5}
    return tomllib.loads(xc.to_toml(job))


def test_crosscheck_accepts_the_reference_and_catches_changes():
    """crosscheck_custom.check_job passes an output written from the reference (poses and
    its own switches), and fails a changed value, a null where the reference has one, a
    changed status, a moved switch and a dropped scalar switch."""
    import pyarrow.parquet as pq
    M = rc.check_description(knee_trajectory_job())
    ref = rc.compute(M, extras=True)
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out")
        sw = xc.write_fake_output(M, ref, out)
        assert any(k == "knee_axial" for k in sw["kind"])
        fails, _ = xc.check_job(M, ref, out, "t", xc.Stats())
        assert fails == []
        poses = os.path.join(out, "poses", "variant=0", "part-0.parquet")

        def rewrite(change):
            r2 = {k: np.array(v, copy=True) for k, v in ref.items()}
            change(r2)
            extras = set(rc.extra_column_names(M))
            pq.write_table(xc.pa_table({k: v for k, v in r2.items() if k not in extras}), poses)
            return xc.check_job(M, ref, out, "t", xc.Stats())[0]

        def bump(r):
            r["err_z"][3] *= 1 + 1e-7
        assert any("err_z" in f for f in rewrite(bump))

        def null(r):
            r["f_knee2_y"][1] = np.nan
        assert any("f_knee2_y" in f and "null" in f for f in rewrite(null))

        def status(r):
            r["status"][2] = "near_singular"
        assert any("status" in f for f in rewrite(status))
        rewrite(lambda r: None)
        # switches: move one, drop one
        k = int(np.flatnonzero(sw["kind"] == "knee_axial")[0])
        moved = {c: np.array(v, copy=True) for c, v in sw.items()}
        moved["t"][k] += 0.05
        pq.write_table(xc.pa_table(moved), os.path.join(out, "discontinuities.parquet"))
        fails, _ = xc.check_job(M, ref, out, "t", xc.Stats())
        assert any("not confirmed" in f for f in fails)
        dropped = {c: np.delete(v, k) for c, v in sw.items()}
        pq.write_table(xc.pa_table(dropped), os.path.join(out, "discontinuities.parquet"))
        fails, _ = xc.check_job(M, ref, out, "t", xc.Stats())
        assert any("no switch there" in f for f in fails)


# A generated 3-PRS trajectory (crosscheck_custom.py --seed 4242, job 043) whose path
# crosses a singular pose between samples: every scalar load passes through infinity
# there and comes back with the other sign.
POLE_JOB = """
name = "custom_043"

[mechanism]
kind = "custom"
inputs = ["z", "psi", "theta"]
home = [0.04549072133506664, -0.031939841436336484, 0.6933075241774139, -0.030958821243627463, -0.056359301102549095, 0.0495058238531256]

[[mechanism.limb]]
joints = [
  { type = "P", name = "rail", at = [-0.014146753846238666, 0.5975262163403453, 0.1036675889558885], axis = [0.0, 0.0, 1.0], actuated = true, range = [-0.5, 0.5] },
  { type = "R", name = "hinge", at = [-0.014146753846238666, 0.5975262163403453, 0.1036675889558885], axis = [-0.9958126103058492, -0.023576397971722, 0.08832552640392251] },
  { type = "S", name = "ball", at = [0.0551725780754836, 0.06812459987805008, 0.7438866057148824] },
]
bodies = [
  { mass = 0.0 },
  { mass = 2.256107813040529, com = [0.020512912114622465, 0.3328254081091977, 0.42377709733538543], inertia = [[0.12975373522105288, 0.006899509785979638, -0.008343754975318515], [0.006899509785979638, 0.07796461083846035, 0.06372244580035752], [-0.008343754975318515, 0.06372244580035752, 0.0535959545624757]] },
]

[[mechanism.limb]]
joints = [
  { type = "P", name = "rail", at = [-0.5103995058548162, -0.31101455638210046, 0.08771587388830347], axis = [0.0, 0.0, 1.0], actuated = true, range = [-0.5, 0.5] },
  { type = "R", name = "hinge", at = [-0.5103995058548162, -0.31101455638210046, 0.08771587388830347], axis = [0.5203577982873931, -0.8539483367051526, 0.0] },
  { type = "S", name = "ball", at = [-0.05397473707339434, -0.03288978283512939, 0.7274616605044326] },
]
bodies = [
  { mass = 0.0 },
  { mass = 2.256107813040529 },
]

[[mechanism.limb]]
joints = [
  { type = "P", name = "rail", at = [0.5245462597010546, -0.286511659958245, 0.018548213994166937], axis = [0.0, 0.0, 1.0], actuated = true, range = [-0.5, 0.5] },
  { type = "R", name = "hinge", at = [0.5245462597010546, -0.286511659958245, 0.018548213994166937], axis = [0.47936205396243314, 0.8776172407267974, 0.0] },
  { type = "S", name = "ball", at = [0.05577977257853345, -0.030467389554311386, 0.6585880118621952] },
]
bodies = [
  { mass = 0.0 },
  { mass = 2.256107813040529 },
]

[mass]
platform = 5.19429649068362
platform_inertia = [0.15791559654212778, 0.08752529242274491, 0.29254690425667185]

[load]
force = [-0.2969177514847909, 8.372759933289183, -9.64630653100235]
moment = [3.4339283517208425, 2.8488393763463877, 1.5628501633011433]
at = [0.07379422448649839, -0.07230459196361905, -0.005176460789440382]

[clearance]
rail_radial = 7.540567681382962e-05
rail_angular = [0.0003187040779377279, 1.2280908762376756e-05, 0.00014399911566438377]
rail_backlash = 0.00011839328509771264
hinge_radial = 2.6829784353632333e-05
hinge_axial = [3.945785766950462e-06, 0.00012889907699408735, 0.00014966798562941088]
ball_radial = 4.036310479482229e-05

[trajectory]
time = { start = 0.0, stop = 2.3145850407718953, n = 30 }
z = { offset = 0.6849153431739844, harmonics = [{ amplitude = 0.03, period = 2.01288073199004, phase = -1.021343493661388 }] }
psi = { offset = -0.03708723290955688, harmonics = [{ amplitude = 0.12, period = 0.8766201301560267, phase = 1.7685520967207404 }] }
theta = { offset = 0.04956852500991685, harmonics = [{ amplitude = 0.060676422828454535, period = 2.3142334438664154, phase = -0.3686870720271136 }, { amplitude = 0.059323577171545454, period = 2.490110416854341, phase = 0.8691526907468266 }] }

[analysis]
modes = ["dynamic"]
"""


def test_crosscheck_tells_a_pole_from_a_missed_switch():
    """A scalar load's sign change through a singular pose between two samples is where
    the path is cut (docs/model.md section 8), not a switch the engine missed: the
    cross-check accepts an output without it, while a sign change through zero still
    needs its switch."""
    job = tomllib.loads(POLE_JOB)
    M = rc.check_description(job)
    ref = rc.compute(M, extras=True)
    line = ("traj", None)
    t = rc.sample_inputs(M)["t"]
    c, cd, cdd = xc._path_points(M, "dynamic", line, t)
    ld = rc.group_loads(M, c, "dynamic", cd, cdd)
    g = next(g for g in M.groups if g.name == "hinge1_axial")
    load = ld[g.name]["load"]
    assert np.all(ld["reach"] & ~ld["singular"])
    flips = np.flatnonzero(np.sign(load[1:]) != np.sign(load[:-1]))
    assert flips.size >= 2
    for k in flips:
        assert xc._cut_between(M, "dynamic", g, line, t[k], t[k + 1], np.sign(load[k]))
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out")
        sw = xc.write_fake_output(M, ref, out)
        assert len(sw["kind"]) == 0
        fails, notes = xc.check_job(M, ref, out, "t", xc.Stats())
        assert fails == [], fails
    # A load through zero between samples is no cut: the 3-RRS trajectory's knee.
    M = rc.check_description(knee_trajectory_job())
    t = rc.sample_inputs(M)["t"]
    ld = rc.group_loads(M, rc.sample_inputs(M)["c"])
    g = next(g for g in M.groups if g.kind == "knee_axial")
    load = ld[g.name]["load"]
    flips = np.flatnonzero(np.sign(load[1:]) != np.sign(load[:-1]))
    assert flips.size >= 1
    for k in flips:
        assert not xc._cut_between(M, "kinetostatic", g, line, t[k], t[k + 1], np.sign(load[k]))


def test_generated_jobs_round_trip_through_toml():
    """Generated jobs of every family survive TOML (the text parses back to the same
    job) and the reference accepts them; 6-RUS, drawn only when asked for, too."""
    rng = np.random.default_rng(4)
    seen = set()
    for i in range(40):
        job, tag, ref = xc.make_job(rng, i)
        seen.add(tag.split()[0])
        assert tomllib.loads(xc.to_toml(job)) == job
        if len(seen) == len(xc.FAMILIES):
            break
    assert seen == set(xc.FAMILIES)
    job, tag, ref = xc.make_job(rng, 0, ("6-RUS",))
    assert tag.startswith("6-RUS") and tomllib.loads(xc.to_toml(job)) == job


def test_crosscheck_refusal_jobs():
    """The cross-check's refusal jobs (for --refusals) are refused by the reference with
    the words the engine's message must hold: overconstrained 56/54, not rigid 39/42,
    an idle freedom in limb 3."""
    jobs = xc.refusal_jobs(np.random.default_rng(2))
    assert [j[0] for j in jobs] == ["overconstrained", "not rigid", "idle freedom"]
    for label, job, words in jobs:
        assert tomllib.loads(xc.to_toml(job)) == job
        with pytest.raises(ValueError):
            rc.check_description(job)
