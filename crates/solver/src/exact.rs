//! Exact error (docs/model.md §7): the take-up displacements applied as finite offsets,
//! solving the nonlinear loop closure instead of the velocity approximation.
//!
//! Unknowns: the platform pose `(p', R')` and the leg angles `φ_j` (9). For each limb
//!
//! ```text
//! p' + R'·a'_j = B_j + ΔB_j + ℓ_j·Rot(Δθ_j)·Rot(y_j, φ_j)·e_j + ΔA_j
//! ```
//!
//! solved by Newton from the nominal pose, with `R' = Exp(w)·R` (the Jacobian of
//! `R'·a'_j` in `w` is `−[R'·a'_j]×·J_l(w)`). The error is `(log(R'·Rᵀ), p' − p) = (w, Δp)`.

use clearance_kinematics::{Geometry, Posture};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::takeup::TakeUp;

/// `Exp(w) − I`, with no cancellation for small `w`.
pub(crate) fn exp_minus_identity(w: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = w.norm_squared();
    let t = t2.sqrt();
    // sin θ/θ and (1 − cos θ)/θ², by their series where the closed forms cancel.
    let (a, b) = if t < 1e-4 {
        (1.0 - t2 / 6.0, 0.5 - t2 / 24.0)
    } else {
        // 1 − cos θ = 2·sin²(θ/2): no cancellation at any angle.
        let h = (0.5 * t).sin() / (0.5 * t);
        (t.sin() / t, 0.5 * h * h)
    };
    let k = w.cross_matrix();
    a * k + b * k * k
}

/// The left Jacobian of SO(3): `d/dw Exp(w)·v = −[Exp(w)·v]×·J_l(w)`.
pub(crate) fn left_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = w.norm_squared();
    let t = t2.sqrt();
    let (b, c) = if t < 1e-4 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    let k = w.cross_matrix();
    Matrix3::identity() + b * k + c * k * k
}

/// The exact pose error `[Δα; Δp]`, or `None` when Newton does not converge.
///
/// The closure is solved in perturbation form: with `R' = Exp(w)·R`, `p' = p + Δp`
/// and the nominal closure `p + R·a'_j = B_j + L·e_j` subtracted, every term of
///
/// ```text
/// Δp + (Exp(w) − I)·R·a'_j − ΔB_j − ΔA_j − L·(Rot(Δθ_j)·Rot(y_j, φ_j) − I)·e_j = 0
/// ```
///
/// is of the size of the clearances, so the error keeps full relative precision.
pub fn exact_error(geom: &Geometry, pose: &Posture, take: &TakeUp) -> Option<[f64; 6]> {
    // The leg's length from B_j to A_j: L, or the 3-RPS leg locked at its nominal q_j.
    let ell = pose.ell;
    let l = ell.iter().fold(0.0f64, |m, &v| m.max(v));
    let mut dp = Vector3::zeros();
    let mut w = Vector3::zeros();
    let mut phi = [0.0f64; 3];
    let offset: [Vector3<f64>; 3] = [0, 1, 2].map(|j| take.r_radial[j] + take.r_axial[j] + take.s[j]);
    let leg_tilt: [Matrix3<f64>; 3] = [0, 1, 2].map(|j| exp_minus_identity(&take.r_angular[j]));
    let ra0: [Vector3<f64>; 3] = [0, 1, 2].map(|j| pose.rot * geom.a_local[j]);
    let mut last_step = f64::INFINITY;
    for _ in 0..30 {
        let mut res = SVector::<f64, 9>::zeros();
        let mut jac = SMatrix::<f64, 9, 9>::zeros();
        let e_w = exp_minus_identity(&w);
        let jl = left_jacobian(&w);
        for j in 0..3 {
            let ra = ra0[j] + e_w * ra0[j];
            let m2 = exp_minus_identity(&(phi[j] * geom.y[j]));
            let turn = leg_tilt[j] + m2 + leg_tilt[j] * m2;
            let r = dp + e_w * ra0[j] - offset[j] - ell[j] * (turn * pose.e[j]);
            let leg_dir = pose.e[j] + m2 * pose.e[j];
            let d_phi = -ell[j] * ((Matrix3::identity() + leg_tilt[j]) * geom.y[j].cross(&leg_dir));
            let d_w = -ra.cross_matrix() * jl;
            for i in 0..3 {
                res[3 * j + i] = r[i];
                jac[(3 * j + i, i)] = 1.0;
                for k in 0..3 {
                    jac[(3 * j + i, 3 + k)] = d_w[(i, k)];
                }
                jac[(3 * j + i, 6 + j)] = d_phi[i];
            }
        }
        let step = jac.lu().solve(&(-res))?;
        dp += Vector3::new(step[0], step[1], step[2]);
        w += Vector3::new(step[3], step[4], step[5]);
        for j in 0..3 {
            phi[j] += step[6 + j];
        }
        let size = dp.amax().max(w.amax() * l).max(phi.iter().fold(0.0f64, |m, v| m.max(v.abs())) * l);
        last_step = step.amax() / size.max(f64::MIN_POSITIVE);
        if last_step <= 4.0 * f64::EPSILON {
            break;
        }
    }
    let out = [w.x, w.y, w.z, dp.x, dp.y, dp.z];
    (last_step <= 1e-10 && out.iter().all(|v| v.is_finite())).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// `Exp(w) − I` against nalgebra's rotation at moderate angles, and its
    /// off-diagonal entries against `[w]×` to full relative precision at tiny ones.
    #[test]
    fn exp_minus_identity_keeps_relative_precision() {
        let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
        for &angle in &[0.01, 0.5, 3.0] {
            let w = angle * axis;
            let want = Rotation3::new(w).into_inner() - Matrix3::identity();
            assert!((exp_minus_identity(&w) - want).amax() < 1e-15);
        }
        for &angle in &[1e-12, 1e-8, 3e-6, 9e-5, 1.1e-4] {
            let w = angle * axis;
            let got = exp_minus_identity(&w);
            let k = w.cross_matrix();
            let rel = (got - k - 0.5 * k * k).amax() / angle;
            assert!(rel < angle * angle + 4.0 * f64::EPSILON, "angle {angle}: {rel}");
        }
    }

    /// The left Jacobian is the derivative of `Exp(w)·v` (central differences).
    #[test]
    fn left_jacobian_is_the_derivative() {
        let w = Vector3::new(0.2, -0.4, 0.3);
        let v = Vector3::new(0.1, 0.7, -0.2);
        let f = |w: Vector3<f64>| Rotation3::new(w) * v;
        let analytic = -(f(w)).cross_matrix() * left_jacobian(&w);
        let h = 1e-6;
        for k in 0..3 {
            let mut dw = Vector3::zeros();
            dw[k] = h;
            let fd = (f(w + dw) - f(w - dw)) / (2.0 * h);
            assert!((fd - analytic.column(k)).amax() < 1e-9, "column {k}");
        }
    }
}
