//! Exact error (MODEL.md §7): the take-up displacements applied as finite offsets,
//! solving the nonlinear loop closure instead of the velocity approximation.
//!
//! Unknowns: the platform pose `(p', R')` and the leg angles `φ_j` (9). For each limb
//!
//! ```text
//! p' + R'·a'_j = B_j + ΔB_j + L·Rot(Δθ_j)·Rot(y_j, φ_j)·e_j + ΔA_j
//! ```
//!
//! solved by Newton from the nominal pose (`R' ← Exp(δ)·R'`, so the Jacobian of
//! `R'·a'_j` in `δ` is `−[R'·a'_j]×`). The error is `(log(R'·Rᵀ), p' − p)`.

use clearance_kinematics::{Geometry, Posture};
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};

use crate::takeup::TakeUp;

/// The exact pose error `[Δα; Δp]`, or `None` when Newton does not converge.
pub fn exact_error(geom: &Geometry, pose: &Posture, take: &TakeUp) -> Option<[f64; 6]> {
    let l = geom.leg_length;
    let mut dp = Vector3::zeros();
    let mut rot = pose.rot;
    let mut phi = [0.0f64; 3];
    let target_base: [Vector3<f64>; 3] =
        [0, 1, 2].map(|j| pose.b[j] + take.r_radial[j] + take.r_axial[j] + take.s[j]);
    let leg_rot: [Matrix3<f64>; 3] = [0, 1, 2].map(|j| Rotation3::new(take.r_angular[j]).into_inner());
    let scale = l.max(geom.platform_radius);
    // Once a step is small, one more quadratic step reaches round-off.
    let mut polished = false;
    for _ in 0..50 {
        let mut res = SVector::<f64, 9>::zeros();
        let mut jac = SMatrix::<f64, 9, 9>::zeros();
        for j in 0..3 {
            let ra = rot * geom.a_local[j];
            let leg_dir = Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(geom.y[j]), phi[j]) * pose.e[j];
            let tip = target_base[j] + l * (leg_rot[j] * leg_dir);
            let r = pose.p + dp + ra - tip;
            let d_phi = -l * (leg_rot[j] * geom.y[j].cross(&leg_dir));
            let skew = -ra.cross_matrix();
            for i in 0..3 {
                res[3 * j + i] = r[i];
                jac[(3 * j + i, i)] = 1.0;
                for k in 0..3 {
                    jac[(3 * j + i, 3 + k)] = skew[(i, k)];
                }
                jac[(3 * j + i, 6 + j)] = d_phi[i];
            }
        }
        let step = jac.lu().solve(&(-res))?;
        dp += Vector3::new(step[0], step[1], step[2]);
        rot = Rotation3::new(Vector3::new(step[3], step[4], step[5])).into_inner() * rot;
        for j in 0..3 {
            phi[j] += step[6 + j];
        }
        if polished {
            let dalpha = Rotation3::from_matrix_unchecked(rot * pose.rot.transpose()).scaled_axis();
            let out = [dalpha.x, dalpha.y, dalpha.z, dp.x, dp.y, dp.z];
            return out.iter().all(|v| v.is_finite()).then_some(out);
        }
        polished = step.amax() <= 1e-9 * scale;
    }
    None
}
