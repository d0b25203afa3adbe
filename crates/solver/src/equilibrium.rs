//! Newton-Euler joint reactions: the 24 × 24 system `A·w = b` (docs/model.md §4,
//! paper Eqs. 5–7).
//!
//! Unknowns, limb by limb (`w[8j..8j+8]`): `f_Rj` (world x, y, z), `μ1, μ2` with
//! `m_Rj = μ1·x_j + μ2·z` (the revolute joint carries no couple about `y_j`), and
//! `f_Sj` (world x, y, z). Rows: leg j forces `6j..6j+3`, leg j moments about its
//! centre of mass `6j+3..6j+6`, platform forces `18..21`, platform moments about
//! the composite centre of mass C `21..24`.

use clearance_kinematics::Posture;
use clearance_model::MechanismKind;
use faer::{Mat, MatMut};
use nalgebra::{Matrix3, Vector3};

use crate::bodies::{Inertial, Model, leg_inertia_world};

/// Joint reactions of one pose, world frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointReactions {
    /// Force of the slider on leg j at `B_j`.
    pub f_r: [Vector3<f64>; 3],
    /// Couple of the slider on leg j (perpendicular to `y_j`).
    pub m_r: [Vector3<f64>; 3],
    /// Force of leg j on the platform at `A_j`.
    pub f_s: [Vector3<f64>; 3],
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

fn put3(a: &mut MatMut<'_, f64>, row: usize, col: usize, m: &Matrix3<f64>) {
    for i in 0..3 {
        for k in 0..3 {
            a[(row + i, col + k)] = m[(i, k)];
        }
    }
}

/// Writes `A` (24 × 24) and `b` (24 × 1) for the posture. `a` is overwritten whole.
pub fn assemble(model: &Model, pose: &Posture, inertial: &Inertial, mut a: MatMut<'_, f64>, mut b: MatMut<'_, f64>) {
    a.fill(0.0);
    let geom = &model.geometry;
    let mass = &model.mass;
    let g = model.gravity;
    let z = Vector3::z();
    let eye = Matrix3::identity();
    let com = pose.p + pose.rot * mass.com_local;
    for j in 0..3 {
        let (r, c) = (6 * j, 8 * j);
        put3(&mut a, r, c, &eye);
        put3(&mut a, r, c + 5, &(-eye));
        for k in 0..3 {
            a[(r + 3 + k, c + 3)] = geom.x[j][k];
            a[(r + 3 + k, c + 4)] = z[k];
        }
        let (f_rhs, m_rhs) = match geom.kind {
            MechanismKind::Prs3 => {
                let gj = 0.5 * (pose.a[j] + pose.b[j]);
                // Leg forces: f_Rj − f_Sj + m_leg·g = m_leg·a_Gj.
                let f_rhs = mass.leg_mass * (inertial.leg_com_acc[j] - g);
                // Leg moments about G_j: m_Rj + (B_j − G_j)×f_Rj − (A_j − G_j)×f_Sj = I·ω̇ + ω×I·ω.
                put3(&mut a, r + 3, c, &skew(&(pose.b[j] - gj)));
                put3(&mut a, r + 3, c + 5, &(-skew(&(pose.a[j] - gj))));
                let inertia = leg_inertia_world(mass, &pose.e[j]);
                let w = inertial.leg_omega[j];
                (f_rhs, inertia * inertial.leg_omega_dot[j] + w.cross(&(inertia * w)))
            }
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                // Cylinder and piston summed; moments about B_j, where f_Rj acts:
                // m_Rj − (A_j − B_j)×f_Sj = H_j.
                put3(&mut a, r + 3, c + 5, &(-skew(&(pose.a[j] - pose.b[j]))));
                mass.rps_limb(pose, inertial, &g, j)
            }
        };
        // Platform: Σ f_Sj and Σ (A_j − C)×f_Sj.
        put3(&mut a, 18, c + 5, &eye);
        put3(&mut a, 21, c + 5, &skew(&(pose.a[j] - com)));
        for k in 0..3 {
            b[(r + k, 0)] = f_rhs[k];
            b[(r + 3 + k, 0)] = m_rhs[k];
        }
    }
    let m = mass.platform_mass;
    let f_rhs = m * (inertial.com_acc - g) - model.load.force;
    let inertia = pose.rot * mass.inertia_local * pose.rot.transpose();
    let w = inertial.omega;
    let e_point = pose.p + pose.rot * model.load.at_local;
    let m_rhs = inertia * inertial.omega_dot + w.cross(&(inertia * w))
        - (e_point - com).cross(&model.load.force)
        - model.load.moment;
    for k in 0..3 {
        b[(18 + k, 0)] = f_rhs[k];
        b[(21 + k, 0)] = m_rhs[k];
    }
}

/// Reads the reactions out of the solution vector `w`.
pub fn reactions_from(model: &Model, w: &Mat<f64>) -> JointReactions {
    let mut out = JointReactions::default();
    for j in 0..3 {
        let c = 8 * j;
        let v = |k: usize| Vector3::new(w[(k, 0)], w[(k + 1, 0)], w[(k + 2, 0)]);
        out.f_r[j] = v(c);
        out.m_r[j] = w[(c + 3, 0)] * model.geometry.x[j] + w[(c + 4, 0)] * Vector3::z();
        out.f_s[j] = v(c + 5);
    }
    out
}
