#!/usr/bin/env python3
"""Throughput of the kinetostatic pipeline in vectorised NumPy against the engine.

A lean NumPy implementation of what `clearance bench` calls the kernel, written as a
Python user would: every step is an array operation over a chunk of N poses, and
the two linear systems are solved as stacks with ``np.linalg.solve``
(N x 24 x 24 equilibrium matrices A, N x 12 x 12 loop matrices J_P with the four
clearance kinds as four right-hand sides). Per pose it gives the parasitic motions,
the actuator positions, the joint reactions, the take-up of all four clearance
kinds with their margins, the per-kind and total pose errors (Delta p, Delta alpha,
Euler-angle errors) and the status (unreachable / indeterminate_contact / ok).
The engine also computes condition numbers for `near_singular` (nothing on this grid
is near singular); the default NumPy timing leaves them out, which favours NumPy.
``--with-cond`` adds the 1-norm condition numbers of A and J_P themselves (a batched
inverse of each), as the engine did before its 6 x 6 reductions.

In one run it

1. checks the NumPy results against ``clearance run`` on a small grid (same
   job, standard columns): statuses equal, values to 1e-9 relative, so the
   comparison below is apples to apples;
2. times NumPy on the grid of ``clearance bench --poses N`` (Z = 2.05,
   Psi, Theta in [-0.5, 0.5], all four clearances 1e-4, kinetostatics);
3. runs ``clearance bench --json --poses N`` with 2 threads and with 1 thread;
4. prints poses/s for each and the ratios.

NumPy runs on one core here (LAPACK is called once per small matrix; there is
nothing for a threaded BLAS to split), so the 1-thread engine figure is the
like-for-like one.

Usage: python3 scripts/numpy_throughput.py [--poses 200000] [--binary target/release/clearance]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
KINDS = ("s_radial", "r_radial", "r_axial", "r_angular")
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz", "phi", "psi", "theta")

# The paper's prototype (docs/interface.md defaults): no point masses, no external load.
RB, RP, L = 0.18, 0.36, 1.0
G = np.array([0.0, 0.0, -9.81])
M_PLAT, M_LEG = 9.8, 3.0
W = (M_PLAT + 3.0 * M_LEG) * 9.81          # weight of all moving bodies
INDET_FLOOR = 1e-9 * W                      # analysis.indeterminate_load_fraction * W
SINGULAR_COND = 1e8

ALPHA = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
XJ = np.stack([np.cos(ALPHA), np.sin(ALPHA), np.zeros(3)], -1)      # (limb, xyz)
YJ = np.stack([-np.sin(ALPHA), np.cos(ALPHA), np.zeros(3)], -1)
EZ = np.array([0.0, 0.0, 1.0])
I3 = np.eye(3)


def skew(v):
    """[v]x for v (..., 3)."""
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


def kappa1(M):
    """1-norm condition number of a stack of matrices."""
    with np.errstate(all="ignore"):
        return np.abs(M).sum(-2).max(-1) * np.abs(np.linalg.inv(M)).sum(-2).max(-1)


def solve_stack(M, rhs):
    """np.linalg.solve on a stack; a singular member leaves NaN (the rest is kept)."""
    try:
        return np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        out = np.full(rhs.shape, np.nan)
        for k in range(M.shape[0]):
            try:
                out[k] = np.linalg.solve(M[k], rhs[k])
            except np.linalg.LinAlgError:
                pass
        return out


def kinetostatic(z, psi, theta, clearance, with_cond=False):
    """The pipeline for arrays of poses (N,). Returns a dict of (N,...) arrays."""
    N = z.size
    sps, cps, sth, cth = np.sin(psi), np.cos(psi), np.sin(theta), np.cos(theta)
    # 1. nominal kinematics: parasitic motions in closed form, R = Ry(Theta) Rx(Psi) Rz(Phi)
    phi = np.arctan2(sps * sth, cps + cth)
    sph, cph = np.sin(phi), np.cos(phi)
    y = -RP * cps * sph
    x = 0.5 * RP * (cth * cph - cph * cps + sps * sth * sph)
    R = np.empty((N, 3, 3))
    R[:, 0, 0] = cth * cph + sth * sps * sph
    R[:, 0, 1] = -cth * sph + sth * sps * cph
    R[:, 0, 2] = sth * cps
    R[:, 1, 0] = cps * sph
    R[:, 1, 1] = cps * cph
    R[:, 1, 2] = -sps
    R[:, 2, 0] = -sth * cph + cth * sps * sph
    R[:, 2, 1] = sth * sph + cth * sps * cph
    R[:, 2, 2] = cth * cps
    p = np.stack([x, y, z], -1)                                        # (N,3)
    A = p[:, None, :] + np.einsum("nab,jb->nja", R, RP * XJ)           # platform vertices (N,3,3)
    rho = (A * XJ).sum(-1)
    disc = L * L - (rho - RB) ** 2
    reach = np.all(disc >= 0.0, -1)
    q = A[..., 2] - np.sqrt(np.where(reach[:, None], disc, 1.0))
    B = q[..., None] * EZ + RB * XJ                                    # slider joints
    C = p                                                              # platform CoM (no point masses)

    # 2. equilibrium A w = b: unknowns per limb f_R (3), mu1, mu2, f_S (3)
    Am = np.zeros((N, 24, 24))
    Gc = 0.5 * (A + B)
    for j in range(3):
        r, c = 6 * j, 8 * j
        Am[:, r:r + 3, c:c + 3] = I3
        Am[:, r:r + 3, c + 5:c + 8] = -I3
        Am[:, r + 3:r + 6, c + 3] = XJ[j]
        Am[:, r + 3:r + 6, c + 4] = EZ
        Am[:, r + 3:r + 6, c:c + 3] = skew(B[:, j] - Gc[:, j])
        Am[:, r + 3:r + 6, c + 5:c + 8] = -skew(A[:, j] - Gc[:, j])
        Am[:, 18:21, c + 5:c + 8] = I3
        Am[:, 21:24, c + 5:c + 8] = skew(A[:, j] - C)
    b = np.zeros((N, 24, 1))
    for j in range(3):
        b[:, 6 * j:6 * j + 3, 0] = -M_LEG * G
    b[:, 18:21, 0] = -M_PLAT * G
    w = solve_stack(Am, b)[..., 0].reshape(N, 3, 8)
    fR, fS = w[..., 0:3], w[..., 5:8]
    mR = w[..., 3, None] * XJ + w[..., 4, None] * EZ

    # 3. take-up of each clearance against the load that decides it
    fy = (fR * YJ).sum(-1)
    fperp = fR - fy[..., None] * YJ
    margins = {"s_radial": np.linalg.norm(fS, axis=-1), "r_radial": np.linalg.norm(fperp, axis=-1),
               "r_axial": np.abs(fy), "r_angular": np.linalg.norm(mR, axis=-1)}
    direction = {"s_radial": fS, "r_radial": fperp, "r_angular": mR}
    disp, indet = {}, {}
    for k in KINDS:
        mg = margins[k]
        bad = mg <= INDET_FLOOR
        indet[k] = np.any(bad, -1) if clearance[k] > 0.0 else np.zeros(N, bool)
        if k == "r_axial":
            d = -clearance[k] * np.sign(fy)[..., None] * YJ
        else:
            d = -clearance[k] * direction[k] / np.where(bad, 1.0, mg)[..., None]
        disp[k] = np.where(bad[..., None], 0.0, d)

    # 4. error system J_P dq_P = J_Cl dq_Cl, 12 x 12, one right-hand side per kind
    S = np.zeros((N, 3, 6, 4))                  # passive screws [w; v_P] per limb
    for j in range(3):
        S[:, j, 0:3, 0] = YJ[j]
        S[:, j, 3:6, 0] = np.cross(B[:, j] - p, YJ[j])
        for k in range(3):
            S[:, j, k, 1 + k] = 1.0
            S[:, j, 3:6, 1 + k] = np.cross(A[:, j] - p, I3[k])
    JP = np.zeros((N, 12, 12))
    for l in range(2):
        JP[:, 6 * l:6 * l + 6, 4 * (l + 1):4 * (l + 2)] = S[:, l + 1]
        JP[:, 6 * l:6 * l + 6, 0:4] = -S[:, 0]
    T = np.zeros((N, 3, 6, 4))                  # clearance twists per limb and kind
    for ki, k in enumerate(KINDS):
        if k == "r_angular":
            T[:, :, 0:3, ki] = disp[k]
            T[:, :, 3:6, ki] = np.cross(B - p[:, None, :], disp[k])
        else:
            T[:, :, 3:6, ki] = disp[k]
    rhs = np.concatenate([T[:, 0] - T[:, 1], T[:, 0] - T[:, 2]], axis=1)   # (N,12,4)
    dq = solve_stack(JP, rhs)
    Gam = np.einsum("nak,nkc->nac", S[:, 0], dq[:, 0:4]) + T[:, 0]       # (N,6,4) [d_alpha; d_p]
    # Euler-angle errors: d_alpha = [y, Ry x, Ry Rx z] [dTheta, dPsi, dPhi]
    E = np.zeros((N, 3, 3))
    E[:, 1, 0] = 1.0
    E[:, 0, 1], E[:, 2, 1] = cth, -sth
    E[:, 0, 2], E[:, 1, 2], E[:, 2, 2] = cps * sth, -sps, cps * cth
    eul = np.linalg.solve(E, Gam[:, 0:3])[:, ::-1]                        # phi, psi, theta
    per = np.concatenate([Gam[:, 3:6], Gam[:, 0:3], eul], axis=1)         # (N,9,4) COMPONENTS order

    any_indet = indet["s_radial"] | indet["r_radial"] | indet["r_axial"] | indet["r_angular"]
    status = np.where(~reach, 3, np.where(any_indet, 2, 0))   # 0 ok, 1 near_singular, 2 indeterminate, 3 unreachable
    out = {"x": x, "y": y, "phi": phi, "q": q, "status": status, "per": per, "total": per.sum(-1),
           "margins": margins, "indet": indet}
    if with_cond:
        ca, cj = kappa1(Am), kappa1(JP)
        out["cond_a"], out["cond_jp"] = ca, cj
        out["status"] = np.where(reach & ~((ca <= SINGULAR_COND) & (cj <= SINGULAR_COND)), 1, status)
    return out


def grid(side):
    """`clearance bench`'s grid: Z = 2.05, Psi, Theta in [-0.5, 0.5], row-major (psi, theta)."""
    ax = -0.5 + (0.5 - -0.5) * np.arange(side, dtype=float) / (side - 1)
    psi, theta = np.meshgrid(ax, ax, indexing="ij")
    return np.full(side * side, 2.05), psi.ravel(), theta.ravel()


def run_numpy(side, clearance, chunk, with_cond):
    z, psi, theta = grid(side)
    n = z.size
    kinetostatic(z[:chunk], psi[:chunk], theta[:chunk], clearance, with_cond)  # warm up
    checksum = 0.0
    start = time.perf_counter()
    for s0 in range(0, n, chunk):
        sl = slice(s0, s0 + chunk)
        r = kinetostatic(z[sl], psi[sl], theta[sl], clearance, with_cond)
        checksum += float(np.nansum(r["total"][:, 2]))
    secs = time.perf_counter() - start
    return n, secs, checksum


def job_toml(side, clearance):
    c = "\n".join(f"{k} = {v!r}" for k, v in clearance.items())
    return (f'name = "numpy_check"\n[clearance]\n{c}\n[grid]\nz = 2.05\n'
            f"psi = {{ start = -0.5, stop = 0.5, n = {side} }}\n"
            f"theta = {{ start = -0.5, stop = 0.5, n = {side} }}\n")


def verify(binary, side, clearance):
    """NumPy against `clearance run` (standard columns) on a side x side grid."""
    import pyarrow.dataset as ds

    tmp = Path(tempfile.mkdtemp(prefix="clearance-numpy-check-"))
    try:
        (tmp / "job.toml").write_text(job_toml(side, clearance))
        subprocess.run([str(binary), "run", str(tmp / "job.toml"), "--out", str(tmp / "out"), "--quiet"],
                       check=True)
        t = ds.dataset(tmp / "out" / "poses", format="parquet", partitioning="hive").to_table()
        t = t.sort_by("sample")
        col = {name: t.column(name).to_numpy(zero_copy_only=False) for name in t.column_names}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    z, psi, theta = grid(side)
    r = kinetostatic(z, psi, theta, clearance, with_cond=True)
    names = np.array(["ok", "near_singular", "indeterminate_contact", "unreachable"])
    status_ok = bool(np.all(names[r["status"]] == col["status"].astype(str)))
    ok = r["status"] == 0
    solved = (r["status"] == 0) | (r["status"] == 2)

    worst = 0.0

    def cmp(name, mine, mask):
        nonlocal worst
        eng = np.asarray(col[name], float)
        if mask.any():
            scale = max(np.nanmax(np.abs(eng[mask])), 1e-300)
            worst = max(worst, float(np.nanmax(np.abs(mine[mask] - eng[mask]))) / scale)
        # nulls exactly where the engine leaves them
        assert np.all(np.isnan(eng[~mask])), f"{name}: engine value where NumPy has none"

    everywhere = np.ones(z.size, bool)
    for c in ("x", "y", "phi"):
        cmp(c, r[c], everywhere)
    for j in range(3):
        cmp(f"q{j + 1}", r["q"][:, j], r["status"] != 3)
    for ci, c in enumerate(COMPONENTS):
        cmp(f"err_{c}", r["total"][:, ci], ok)
        for ki, k in enumerate(KINDS):
            cmp(f"err_{k}_{c}", r["per"][:, ci, ki], solved & ~r["indet"][k])
    for j in range(3):
        for k, name in (("r_radial", f"margin_r{j + 1}_radial"), ("r_axial", f"margin_r{j + 1}_axial"),
                        ("r_angular", f"margin_r{j + 1}_angular"), ("s_radial", f"margin_s{j + 1}")):
            cmp(name, r["margins"][k][:, j], solved)
    counts = {str(s): int(n) for s, n in zip(*np.unique(col["status"].astype(str), return_counts=True))}
    return status_ok, worst, counts


def engine_bench(binary, poses, threads):
    out = subprocess.run([str(binary), "bench", "--json", "--poses", str(poses), "--threads", str(threads)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--poses", type=int, default=200_000, help="poses per measurement (a square grid, as clearance bench)")
    ap.add_argument("--binary", default=str(ROOT / "target" / "release" / "clearance"))
    ap.add_argument("--chunk", type=int, default=4096, help="poses per NumPy batch")
    ap.add_argument("--with-cond", action="store_true",
                    help="also time the condition numbers of A and J_P (batched inverses) for near_singular")
    ap.add_argument("--check-side", type=int, default=41, help="grid side of the agreement check")
    ap.add_argument("--no-engine", action="store_true", help="only time NumPy")
    args = ap.parse_args()

    clearance = {k: 1e-4 for k in KINDS}
    side = max(2, math.ceil(math.sqrt(args.poses)))
    binary = Path(args.binary)
    print(f"numpy {np.__version__}, python {sys.version.split()[0]}, {os.cpu_count()} cpus")

    if not args.no_engine:
        if not binary.exists():
            sys.exit(f"{binary} is missing: cargo build --release -p clearance-cli")
        status_ok, worst, counts = verify(binary, args.check_side, clearance)
        print(f"agreement with `clearance run` on {args.check_side}x{args.check_side} poses {counts}: "
              f"statuses {'equal' if status_ok else 'DIFFER'}, "
              f"largest difference {worst:.1e} of each column's largest value")
        if not status_ok or worst > 1e-9:
            sys.exit("NumPy and the engine disagree: the comparison would not be like for like")

    n, secs, _ = run_numpy(side, clearance, args.chunk, args.with_cond)
    numpy_rate = n / secs
    what = "with condition numbers" if args.with_cond else "without condition numbers"
    print(f"numpy kinetostatic pipeline ({what}, chunks of {args.chunk}, 1 core): "
          f"{n} poses in {secs:.2f} s = {numpy_rate:,.0f} poses/s")
    if args.no_engine:
        return
    rows = []
    for threads in (2, 1):
        b = engine_bench(binary, args.poses, threads)
        rows.append((threads, b))
        print(f"clearance bench --json --poses {args.poses} --threads {threads}: {json.dumps(b)}")
    print()
    print(f"{'measure':44s} {'poses/s':>12s} {'x NumPy':>8s}")
    print(f"{'numpy (vectorised, ' + what + ')':44s} {numpy_rate:12,.0f} {1.0:8.1f}")
    for threads, b in rows:
        for key, label in (("kernel_poses_per_s", "engine kernel"),
                           ("kernel_general_poses_per_s", "engine kernel, general solver"),
                           ("end_to_end_poses_per_s", "engine end to end (Parquet)")):
            if key in b:
                name = f"{label}, {threads} thread{'s' if threads > 1 else ''}"
                print(f"{name:44s} {b[key]:12,.0f} {b[key] / numpy_rate:8.1f}")
    k2, k1 = rows[0][1]["kernel_poses_per_s"], rows[1][1]["kernel_poses_per_s"]
    print(f"\nengine kernel 2 threads / 1 thread: {k2 / k1:.2f}x")


if __name__ == "__main__":
    main()
