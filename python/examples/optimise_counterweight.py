"""Which counterweight best cancels a payload's effect on the pose error?

A 30 kg mass sits 1 m above the platform (the paper's Fig. 11) and the revolute
joints have a radial clearance of 1e-4 m. A counterweight of mass m hangs at
(0, 0, -h) in the platform frame. We look for the (m, h) that minimise the 95th
percentile of the position error |Δp| of the tool-centre point over the Ψ–Θ
workspace at Z = 2.05 m, calling `clearance.solve` in a loop: each call computes
the whole workspace in memory, on every core, without writing a file.

Run: python3 python/examples/optimise_counterweight.py
"""

import time

import numpy as np
from scipy.optimize import minimize

import clearance

SIDE = 61  # Ψ, Θ ∈ [−0.5, 0.5] rad on a 61 × 61 grid
PSI, THETA = np.meshgrid(np.linspace(-0.5, 0.5, SIDE), np.linspace(-0.5, 0.5, SIDE), indexing="ij")


def job(mass: float, height: float) -> dict:
    return {
        "name": "counterweight",
        "mass": {
            "points": [
                {"mass": 30.0, "at": [0.0, 0.0, 1.0]},
                {"mass": mass, "at": [0.0, 0.0, -height]},
            ]
        },
        "clearance": {"r_radial": 1e-4},
        "grid": {"z": 2.05, "psi": 0.0, "theta": 0.0},  # replaced by the poses below
    }


def p95(mass: float, height: float) -> float:
    """The 95th percentile of |Δp| (m) over the workspace; poses that are not `ok`
    (none here) are left out, as in summary.parquet."""
    t = clearance.solve(job(mass, height), z=2.05, psi=PSI.ravel(), theta=THETA.ravel(), columns="minimal")
    ok = np.asarray(t.column("status")) == "ok"
    dp = np.sqrt(sum(np.asarray(t.column(c).to_numpy(zero_copy_only=False))[ok] ** 2 for c in ("err_x", "err_y", "err_z")))
    return float(np.percentile(dp, 95))


def objective(x: np.ndarray) -> float:
    mass, height = x
    if not (0.0 <= mass <= 100.0 and 0.0 <= height <= 3.0):
        return 1.0  # outside the design space: worse than any real error
    return p95(mass, height)


def main() -> None:
    start = time.perf_counter()
    none = p95(0.0, 0.0)
    rule = p95(30.0, 1.0)  # the paper's Fig. 12: the same mass 1 m below
    res = minimize(objective, x0=[10.0, 0.5], method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-10})
    secs = time.perf_counter() - start
    calls = res.nfev + 2
    poses = calls * SIDE * SIDE
    mass, height = res.x
    print(f"p95 |dp| without counterweight:          {none * 1e6:8.2f} um")
    print(f"p95 |dp| with 30 kg at 1 m (Fig. 12):    {rule * 1e6:8.2f} um")
    print(f"best counterweight: {mass:6.2f} kg at {height:5.3f} m below P: p95 |dp| = {res.fun * 1e6:8.2f} um")
    print(f"{calls} calls of clearance.solve, {poses} poses in {secs:.1f} s ({poses / secs:,.0f} poses/s)")


if __name__ == "__main__":
    main()
