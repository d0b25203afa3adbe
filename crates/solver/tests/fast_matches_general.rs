//! The fast 6 × 6 path and the assembled 24 × 24 / 12 × 12 faer path agree to
//! round-off on random jobs and poses, in statics and dynamics.

mod common;

use clearance_grid::Sample;
use clearance_model::Mode;
use clearance_solver::{Model, PoseResult, SolverKind, Status, Workspace, solve_pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn flatten(r: &PoseResult) -> Vec<(String, f64)> {
    let mut v = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            v.push((format!("f_r{j}{i}"), r.reactions.f_r[j][i]));
            v.push((format!("m_r{j}{i}"), r.reactions.m_r[j][i]));
            v.push((format!("f_s{j}{i}"), r.reactions.f_s[j][i]));
        }
    }
    for (k, e) in r.errors.iter().chain([&r.total]).enumerate() {
        for i in 0..3 {
            v.push((format!("dp{k}{i}"), e.dp[i]));
            v.push((format!("da{k}{i}"), e.dalpha[i]));
            v.push((format!("eu{k}{i}"), e.euler[i]));
        }
    }
    v
}

/// `a` and `b` agree to round-off amplified by the conditioning.
fn assert_agree(a: &PoseResult, b: &PoseResult, w: f64, what: &str) {
    for ((name, x), (_, y)) in flatten(a).iter().zip(flatten(b)) {
        // Loads relative to the load scale, errors to the clearance scale (4e-4),
        // both within round-off amplified by the conditioning.
        let scale = if name.starts_with('f') || name.starts_with('m') { w } else { 4e-4 };
        let tol = 1e-13 * a.cond_a.max(a.cond_jp) * scale;
        assert!((x - y).abs() <= tol, "{name}: {x} vs {y} ({what}, cond {})", a.cond_a);
    }
}

/// Inclined and horizontal rails, uneven limbs (Newton), the 3-RPS: the batched
/// fast path, the scalar fast path and the assembled path agree.
#[test]
fn fast_and_general_paths_agree_across_the_family() {
    let mut rng = ChaCha8Rng::seed_from_u64(19);
    let mut ws = Workspace::new();
    let mut compared = 0;
    for case in 0..common::FAMILY.len() {
        for _ in 0..25 {
            let (job, z0) = common::family_job(&mut rng, case, [1e-4, 2e-4, 3e-4, 4e-4]);
            let mut general = Model::from_job(&job);
            general.solver = SolverKind::General;
            let mut fast = general.clone();
            fast.solver = SolverKind::Fast;
            let w = job.weight() + general.load.force.norm() + general.load.moment.norm();
            for mode in [Mode::Kinetostatic, Mode::Dynamic] {
                let r = |rng: &mut ChaCha8Rng, a: f64| {
                    [rng.random_range(-a..a), rng.random_range(-1.0..1.0), rng.random_range(-5.0..5.0)]
                };
                let mut z = r(&mut rng, 0.1);
                z[0] += z0;
                let s = Sample { index: 0, t: Some(0.0), z, psi: r(&mut rng, 0.3), theta: r(&mut rng, 0.3) };
                let (a, b) = (solve_pose(&general, &s, mode, &mut ws), solve_pose(&fast, &s, mode, &mut ws));
                assert_eq!(a.status, b.status, "case {case}");
                if a.status != Status::Ok {
                    continue;
                }
                assert_agree(&a, &b, w, &format!("case {case}, {mode:?}"));
                compared += 1;
            }
        }
    }
    assert!(compared > 250, "{compared}");
}

#[test]
fn fast_and_general_paths_agree() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut ws = Workspace::new();
    let mut compared = 0;
    for _ in 0..200 {
        let job = common::grid_job(&mut rng, [1e-4, 2e-4, 3e-4, 4e-4]);
        let mut general = Model::from_job(&job);
        general.solver = SolverKind::General;
        let mut fast = general.clone();
        fast.solver = SolverKind::Fast;
        let w = job.weight() + general.load.force.norm() + general.load.moment.norm();
        for mode in [Mode::Kinetostatic, Mode::Dynamic] {
            let r = |rng: &mut ChaCha8Rng, a: f64| {
                [rng.random_range(-a..a), rng.random_range(-1.0..1.0), rng.random_range(-5.0..5.0)]
            };
            let mut z = r(&mut rng, 0.2);
            z[0] += 2.0;
            let s = Sample { index: 0, t: Some(0.0), z, psi: r(&mut rng, 0.5), theta: r(&mut rng, 0.5) };
            let (a, b) = (solve_pose(&general, &s, mode, &mut ws), solve_pose(&fast, &s, mode, &mut ws));
            assert_eq!(a.status, b.status);
            assert_eq!((a.cond_a, a.cond_jp), (b.cond_a, b.cond_jp), "conditioning is judged the same way");
            if a.status != Status::Ok {
                continue;
            }
            assert_agree(&a, &b, w, &format!("{mode:?}"));
            compared += 1;
        }
    }
    assert!(compared > 300, "{compared}");
}
