//! The 3-PRS and 3-RPS described as limbs (`limbs::three_limb_assembly`) give the
//! reactions, take-ups and per-kind errors of the existing assembled path
//! (`equilibrium::assemble` + `error_system`) and of the fast 6 × 6 path, to round-off,
//! on random jobs and poses of the whole family, in statics and dynamics.

mod common;

use clearance_grid::Sample;
use clearance_kinematics::{inverse_kinematics, inverse_kinematics_motion};
use clearance_model::{JobSpec, Mode};
use clearance_solver::assembly::AssemblyData;
use clearance_solver::limbs::{three_limb_assembly, three_limb_posed};
use clearance_solver::{
    Inertial, LuSolver, Model, SolverKind, Status, Workspace, equilibrium, error_system, solve_pose, takeup,
};
use faer::Mat;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `|x − y| ≤ 1e-10·scale` for every component.
fn agree(x: &Vector3<f64>, y: &Vector3<f64>, scale: f64, what: &str) {
    let d = (x - y).amax();
    assert!(d <= 1e-10 * scale, "{what}: {x} vs {y} (|Δ| = {d:e}, scale {scale:e})");
}

fn check(job: &JobSpec, z0: f64, rng: &mut ChaCha8Rng, ws: &mut Workspace) -> usize {
    let mut fast_model = Model::from_job(job);
    fast_model.solver = SolverKind::Fast;
    let model = &fast_model;
    let assembly = three_limb_assembly(model);
    let mut data = AssemblyData::new(&assembly);
    let w = job.weight() + model.load.force.norm() + model.load.moment.norm();
    let clearance = model.clearance.iter().fold(0.0f64, |m, &c| m.max(c));
    let mut compared = 0;
    for mode in [Mode::Kinetostatic, Mode::Dynamic] {
        let r = |rng: &mut ChaCha8Rng, a: f64| {
            let rates = mode == Mode::Dynamic;
            let k = if rates { 1.0 } else { 0.0 };
            [rng.random_range(-a..a), k * rng.random_range(-1.0..1.0), k * rng.random_range(-5.0..5.0)]
        };
        let mut z = r(rng, 0.1);
        z[0] += z0;
        let s = Sample { index: 0, t: Some(0.0), z, psi: r(rng, 0.3), theta: r(rng, 0.3) };
        let geom = &model.geometry;
        let (pose, inertial) = match mode {
            Mode::Kinetostatic => match inverse_kinematics(geom, z[0], s.psi[0], s.theta[0]) {
                Ok(p) => (p, Inertial::default()),
                Err(_) => continue,
            },
            Mode::Dynamic => match inverse_kinematics_motion(geom, s.z, s.psi, s.theta) {
                Ok((p, m)) => {
                    let i = Inertial::from_motion(&p, &m, &model.mass);
                    (p, i)
                }
                Err(_) => continue,
            },
        };
        let fast = solve_pose(model, &s, mode, ws);
        if fast.status != Status::Ok {
            continue;
        }
        // The existing assembled path, step by step.
        let (mut a, mut b) = (Mat::zeros(24, 24), Mat::zeros(24, 1));
        equilibrium::assemble(model, &pose, &inertial, a.as_mut(), b.as_mut());
        assert!(LuSolver::new(24, 1).solve(a.as_ref(), b.as_mut()));
        let reactions = equilibrium::reactions_from(model, &b);
        let take = takeup::take_up(geom, &reactions, &model.clearance, model.indeterminate_floor);
        let (mut jp, mut dq) = (Mat::zeros(12, 12), Mat::zeros(12, 4));
        error_system::assemble(&pose, &geom.y, &take, jp.as_mut(), dq.as_mut());
        assert!(LuSolver::new(12, 4).solve(jp.as_ref(), dq.as_mut()));
        let errors = error_system::errors_from(geom, &pose, &take, &dq);

        let posed = three_limb_posed(model, &pose, &inertial);
        let sol = assembly.solve(&posed, &mut data);
        assert_eq!(sol.status, Status::Ok, "cond {} / {}", sol.cond_a, sol.cond_jp);
        let what = format!("{:?} {mode:?}", geom.kind);
        for j in 0..3 {
            for (got, general, fast, name) in [
                (sol.f_b[j], reactions.f_r[j], fast.reactions.f_r[j], "f_R"),
                (sol.m_b[j], reactions.m_r[j], fast.reactions.m_r[j], "m_R"),
                (sol.f_s[j], reactions.f_s[j], fast.reactions.f_s[j], "f_S"),
            ] {
                agree(&got, &general, w, &format!("{name}{j} general, {what}"));
                agree(&got, &fast, w, &format!("{name}{j} fast, {what}"));
            }
            for (k, margins) in take.margins.by_kind().iter().enumerate() {
                let (x, y) = (Vector3::new(sol.margins[k][j], 0.0, 0.0), Vector3::new(margins[j], 0.0, 0.0));
                agree(&x, &y, w, &format!("margin {k}, limb {j}, {what}"));
            }
        }
        for (k, e) in sol.errors.iter().take(4).enumerate() {
            for (other, path) in [(&errors[k], "general"), (&fast.errors[k], "fast")] {
                agree(&e.dp, &other.dp, clearance, &format!("Δp kind {k} {path}, {what}"));
                agree(&e.dalpha, &other.dalpha, clearance, &format!("Δα kind {k} {path}, {what}"));
                let (x, y) = (Vector3::from(e.euler), Vector3::from(other.euler));
                agree(&x, &y, clearance, &format!("Euler kind {k} {path}, {what}"));
            }
        }
        agree(&sol.total.dp, &fast.total.dp, clearance, &format!("total Δp, {what}"));
        compared += 1;
    }
    compared
}

/// Vertical rails (the prototype's family), 30° rails, uneven limbs, horizontal rails,
/// and two 3-RPS: statics and dynamics.
#[test]
fn limbs_agree_with_the_general_and_fast_paths() {
    let mut rng = ChaCha8Rng::seed_from_u64(2020);
    let mut ws = Workspace::new();
    let mut compared = 0;
    for _ in 0..40 {
        let job = common::grid_job(&mut rng, [1e-4, 2e-4, 3e-4, 4e-4]);
        compared += check(&job, 2.0, &mut rng, &mut ws);
    }
    for case in 0..common::FAMILY.len() {
        for _ in 0..25 {
            let (job, z0) = common::family_job(&mut rng, case, [1e-4, 2e-4, 3e-4, 4e-4]);
            compared += check(&job, z0, &mut rng, &mut ws);
        }
    }
    assert!(compared > 250, "{compared}");
}
