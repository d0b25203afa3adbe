//! docs/model.md, "Validation": statics satisfy virtual work. With the actuator forces
//! `τ_j = f_Rj·d_j` (massless sliders on rails `d_j`; the 3-RPS: the axial force inside
//! the leg), `Σ τ_j·δq_j + δW_gravity + δW_external = 0`
//! for every virtual motion the inverse kinematics allows. The virtual motions are
//! central differences of the inverse kinematics in Z, Ψ and Θ, independent of the
//! equilibrium code.

mod common;

use clearance_kinematics::inverse_kinematics;
use clearance_model::{MechanismKind, Mode};
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
    let (cyl, pis) = (model.mass.cylinder, model.mass.piston);
    for j in 0..3 {
        match model.geometry.kind {
            MechanismKind::Prs3 => com_points.push((model.mass.leg_mass, 0.5 * (pose.a[j] + pose.b[j]))),
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                com_points.push((cyl.mass, pose.b[j] + 0.5 * cyl.length * pose.e[j]));
                com_points.push((pis.mass, pose.a[j] - 0.5 * pis.length * pose.e[j]));
            }
        }
    }
    Loaded { q: pose.q, com_points, force_point: pose.p + pose.rot * model.load.at_local, rot: pose.rot }
}

/// The actuator forces of a solved static pose: the slider's force along its rail
/// (3-PRS, massless sliders), or the prismatic joint's axial force, from the
/// piston's balance along the leg (3-RPS).
fn actuator_forces(model: &Model, z: f64, psi: f64, theta: f64, r: &clearance_solver::PoseResult) -> [f64; 3] {
    let pose = inverse_kinematics(&model.geometry, z, psi, theta).unwrap();
    std::array::from_fn(|j| match model.geometry.kind {
        MechanismKind::Prs3 => r.reactions.f_r[j].dot(&model.geometry.rail(j)),
        MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
            pose.e[j].dot(&(r.reactions.f_s[j] - model.mass.piston.mass * model.gravity))
        }
    })
}

/// `Σ τ_j·δq_j + δW_gravity + δW_external` over central differences in each input,
/// relative to the load scale; it must vanish.
fn check_virtual_work(model: &Model, scale: f64, (z, psi, theta): (f64, f64, f64), ws: &mut Workspace) {
    let r = solve_pose(model, &common::static_sample(z, psi, theta), Mode::Kinetostatic, ws);
    assert!(matches!(r.status, Status::Ok | Status::IndeterminateContact), "{:?}", r.status);
    let tau = actuator_forces(model, z, psi, theta, &r);
    let h = 1e-6;
    for dir in 0..3 {
        let mut u = [z, psi, theta];
        u[dir] += h;
        let plus = loaded(model, u[0], u[1], u[2]);
        u[dir] -= 2.0 * h;
        let minus = loaded(model, u[0], u[1], u[2]);
        let mut work: f64 = (0..3).map(|j| tau[j] * (plus.q[j] - minus.q[j])).sum();
        for (k, (m, p)) in plus.com_points.iter().enumerate() {
            work += m * model.gravity.dot(&(p - minus.com_points[k].1));
        }
        work += model.load.force.dot(&(plus.force_point - minus.force_point));
        // δα from δR·Rᵀ (skew part).
        let dr = (plus.rot - minus.rot) * plus.rot.transpose();
        let dalpha = 0.5 * Vector3::new(dr[(2, 1)] - dr[(1, 2)], dr[(0, 2)] - dr[(2, 0)], dr[(1, 0)] - dr[(0, 1)]);
        work += model.load.moment.dot(&dalpha);
        // Central differences: O(h²) truncation ≈ 1e-12 of the load·length scale.
        assert!(work.abs() / (2.0 * h) < 1e-7 * scale, "virtual work {} in direction {dir}", work / (2.0 * h));
    }
}

#[test]
fn virtual_work_vanishes_in_statics() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut ws = Workspace::new();
    for _ in 0..60 {
        let job = common::grid_job(&mut rng, [1e-4; 4]);
        let model = Model::from_job(&job);
        let pose = (rng.random_range(1.9..2.2), rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4));
        let scale = job.weight() + model.load.force.norm() + model.load.moment.norm();
        check_virtual_work(&model, scale, pose, &mut ws);
    }
}

/// Inclined and horizontal rails (the actuator force along the rail), uneven limbs,
/// and the 3-RPS (the force inside the leg, cylinder and piston weighed apart).
#[test]
fn virtual_work_vanishes_across_the_family() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let mut ws = Workspace::new();
    for case in 0..common::FAMILY.len() {
        for _ in 0..12 {
            let (job, z) = common::family_job(&mut rng, case, [1e-4; 4]);
            let model = Model::from_job(&job);
            let pose =
                (z + rng.random_range(-0.05..0.05), rng.random_range(-0.25..0.25), rng.random_range(-0.25..0.25));
            let scale = job.weight() + model.load.force.norm() + model.load.moment.norm();
            check_virtual_work(&model, scale, pose, &mut ws);
        }
    }
}
