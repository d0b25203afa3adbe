//! Error kinematics with clearance freedoms: `J_P·Δq_P = J_Cl·Δq_Cl` (docs/model.md §6,
//! paper Eqs. 12–14).
//!
//! Twists are `[ω; v_P]`, `v_P` the velocity of the point coinciding with P. Limb j,
//! from the base: the locked actuator, the R-clearance freedoms (translation `ΔB_j`,
//! rotation `Δθ_j` about `B_j`), the R joint `[y_j; (B_j − P)×y_j]`, the S-clearance
//! translation `ΔA_j`, and three S rotations `[e_k; (A_j − P)×e_k]`. The passive
//! unknowns are column block `4j..4j+4` (R angle, then S rotations about world x, y, z);
//! rows `0..6` close limb 2 against limb 1 and rows `6..12` limb 3 against limb 1.
//! Each clearance kind is one right-hand side, so one factorisation serves all four.

use clearance_kinematics::{Geometry, Posture};
use faer::{Mat, MatMut};
use nalgebra::{Vector3, Vector6};

use crate::fast;
use crate::takeup::TakeUp;

/// A pose error `ΔΓ = [Δα; Δp]` with its Euler-angle form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseError {
    /// Small rotation vector Δα (rad).
    pub dalpha: Vector3<f64>,
    /// Error of P (m).
    pub dp: Vector3<f64>,
    /// `(ΔΦ, ΔΨ, ΔΘ)` (rad).
    pub euler: [f64; 3],
}

fn twist(w: Vector3<f64>, v: Vector3<f64>) -> Vector6<f64> {
    Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
}

/// The four passive screws of limb j.
fn passive_screws(pose: &Posture, y: &Vector3<f64>, j: usize) -> [Vector6<f64>; 4] {
    let rb = pose.b[j] - pose.p;
    let ra = pose.a[j] - pose.p;
    let s = |axis: Vector3<f64>, r: Vector3<f64>| twist(axis, r.cross(&axis));
    [s(*y, rb), s(Vector3::x(), ra), s(Vector3::y(), ra), s(Vector3::z(), ra)]
}

/// The clearance twist `J_Cl·Δq_Cl` of limb j for each kind (order of `KINDS`).
fn clearance_twists(pose: &Posture, t: &TakeUp, j: usize) -> [Vector6<f64>; 4] {
    let rb = pose.b[j] - pose.p;
    let zero = Vector3::zeros();
    [
        twist(zero, t.s[j]),
        twist(zero, t.r_radial[j]),
        twist(zero, t.r_axial[j]),
        twist(t.r_angular[j], rb.cross(&t.r_angular[j])),
    ]
}

/// Writes `J_P` (12 × 12) and the right-hand sides `J_Cl·Δq_Cl` (12 × 4, one column per kind).
pub fn assemble(
    pose: &Posture,
    y: &[Vector3<f64>; 3],
    take: &TakeUp,
    mut jp: MatMut<'_, f64>,
    mut rhs: MatMut<'_, f64>,
) {
    jp.fill(0.0);
    let screws = [0, 1, 2].map(|j| passive_screws(pose, &y[j], j));
    let cl = [0, 1, 2].map(|j| clearance_twists(pose, take, j));
    for (loop_idx, other) in [1usize, 2].into_iter().enumerate() {
        let row = 6 * loop_idx;
        for u in 0..4 {
            for i in 0..6 {
                jp[(row + i, 4 * other + u)] = screws[other][u][i];
                jp[(row + i, u)] = -screws[0][u][i];
            }
        }
        for k in 0..4 {
            let d = cl[0][k] - cl[other][k];
            for i in 0..6 {
                rhs[(row + i, k)] = d[i];
            }
        }
    }
}

/// The per-kind errors from the solved passive motions (`dq`, 12 × 4): the twist
/// of limb 1.
pub fn errors_from(geom: &Geometry, pose: &Posture, take: &TakeUp, dq: &Mat<f64>) -> [PoseError; 4] {
    let screws = passive_screws(pose, &geom.y[0], 0);
    let cl = clearance_twists(pose, take, 0);
    let euler_inv = fast::euler_inverse(&fast::Pose::from_posture(geom, pose));
    [0, 1, 2, 3].map(|k| {
        let mut t = cl[k];
        for (u, s) in screws.iter().enumerate() {
            t += s * dq[(u, k)];
        }
        fast::pose_error([t[0], t[1], t[2], t[3], t[4], t[5]], &euler_inv).get(0)
    })
}

impl PoseError {
    /// This error for `s` times the clearance that gave it (the error is linear in it).
    pub fn scaled(&self, s: f64) -> PoseError {
        PoseError { dalpha: self.dalpha * s, dp: self.dp * s, euler: self.euler.map(|v| v * s) }
    }
}

/// The sum of per-kind errors (the linear theory superposes).
pub fn total(errors: &[PoseError]) -> PoseError {
    let mut out = PoseError::default();
    for e in errors {
        out.dalpha += e.dalpha;
        out.dp += e.dp;
        for i in 0..3 {
            out.euler[i] += e.euler[i];
        }
    }
    out
}
