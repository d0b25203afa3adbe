//! MODEL.md §9: statics satisfy virtual work. With the actuator forces
//! `τ_j = f_Rj·z` (massless sliders), `Σ τ_j·δq_j + δW_gravity + δW_external = 0`
//! for every virtual motion the inverse kinematics allows. The virtual motions are
//! central differences of the inverse kinematics in Z, Ψ and Θ, independent of the
//! equilibrium code.

mod common;

use clearance_kinematics::inverse_kinematics;
use clearance_model::Mode;
use clearance_solver::{Model, Status, Workspace, solve_pose};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Work of gravity and the external wrench on the posture at `(z, ψ, θ)`, as a
/// potential-like function whose differences give the virtual work: positions of
/// the loaded points and the platform orientation.
struct Loaded {
    q: [f64; 3],
    com_points: Vec<(f64, Vector3<f64>)>,
    force_point: Vector3<f64>,
    rot: nalgebra::Matrix3<f64>,
}

fn loaded(model: &Model, z: f64, psi: f64, theta: f64) -> Loaded {
    let pose = inverse_kinematics(&model.geometry, z, psi, theta).unwrap();
    let mut com_points = vec![(model.mass.platform_mass, pose.p + pose.rot * model.mass.com_local)];
    for j in 0..3 {
        com_points.push((model.mass.leg_mass, 0.5 * (pose.a[j] + pose.b[j])));
    }
    Loaded { q: pose.q, com_points, force_point: pose.p + pose.rot * model.load.at_local, rot: pose.rot }
}

#[test]
fn virtual_work_vanishes_in_statics() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut ws = Workspace::new();
    for _ in 0..60 {
        let job = common::grid_job(&mut rng, [1e-4; 4]);
        let model = Model::from_job(&job);
        let (z, psi, theta) = (rng.random_range(1.9..2.2), rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4));
        let r = solve_pose(&model, &common::static_sample(z, psi, theta), Mode::Kinetostatic, &mut ws);
        assert!(matches!(r.status, Status::Ok | Status::IndeterminateContact));
        let h = 1e-6;
        for dir in 0..3 {
            let mut u = [z, psi, theta];
            u[dir] += h;
            let plus = loaded(&model, u[0], u[1], u[2]);
            u[dir] -= 2.0 * h;
            let minus = loaded(&model, u[0], u[1], u[2]);
            let mut work = 0.0;
            for j in 0..3 {
                work += r.reactions.f_r[j].z * (plus.q[j] - minus.q[j]);
            }
            for (k, (m, p)) in plus.com_points.iter().enumerate() {
                work += m * model.gravity.dot(&(p - minus.com_points[k].1));
            }
            work += model.load.force.dot(&(plus.force_point - minus.force_point));
            // δα from δR·Rᵀ (skew part).
            let dr = (plus.rot - minus.rot) * plus.rot.transpose();
            let dalpha = 0.5 * Vector3::new(dr[(2, 1)] - dr[(1, 2)], dr[(0, 2)] - dr[(2, 0)], dr[(1, 0)] - dr[(0, 1)]);
            work += model.load.moment.dot(&dalpha);
            // Central differences: O(h²) truncation ≈ 1e-12 of the load·length scale.
            let scale = job.weight() + model.load.force.norm() + model.load.moment.norm();
            assert!(work.abs() / (2.0 * h) < 1e-7 * scale, "virtual work {} in direction {dir}", work / (2.0 * h));
        }
    }
}
