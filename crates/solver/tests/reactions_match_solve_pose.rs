//! The reactions-only solves agree with `solve_pose`: `solve_reactions_if_solvable`
//! gives reactions exactly where `solve_pose` gives a status with reactions (ok or
//! indeterminate contact), with the same bits, and `solve_reactions` the same bits
//! wherever `solve_pose` has them. The discontinuity search refines switches with
//! them, so its results must not depend on which is called. Kinetostatic and
//! dynamic, both solvers, with thresholds tight enough that near-singular and
//! unreachable poses occur. `solve_errors` gives `solve_pose`'s per-kind errors, with
//! their bits (zero where the pose is not solved), which a switch's jump reads.

mod common;

use clearance_grid::Sample;
use clearance_kinematics::Geometry;
use clearance_model::Mode;
use clearance_solver::{
    Model, SolverKind, Status, Workspace, solve_errors, solve_pose, solve_reactions, solve_reactions_if_solvable,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn reactions_only_solves_give_solve_pose_bits_and_verdict() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut ws = Workspace::new();
    let mut seen = std::collections::BTreeMap::new();
    for case in 0..40 {
        let clearance = [0, 1, 2, 3].map(|_| rng.random_range(1e-5..1e-3));
        let job = common::grid_job(&mut rng, clearance);
        let mut model = Model::from_job(&job);
        model.solver = if case % 2 == 0 { SolverKind::Fast } else { SolverKind::General };
        model.singular_cond = rng.random_range(20.0..400.0);
        // The errors do not depend on what else a result holds.
        (model.exact, model.envelope) = (case % 3 == 1, case % 5 == 2);
        if case % 4 == 1 {
            let g = &model.geometry;
            model.geometry = Geometry::new(g.base_radius, g.platform_radius, rng.random_range(0.15..0.3));
        }
        for _ in 0..30 {
            let mut r3 =
                |lo: f64, hi: f64| [rng.random_range(lo..hi), rng.random_range(-2.0..2.0), rng.random_range(-9.0..9.0)];
            let (z, psi, theta) = (r3(1.2, 2.6), r3(-1.2, 1.2), r3(-1.2, 1.2));
            let s = Sample { index: 0, t: Some(0.0), z, psi, theta };
            for mode in [Mode::Kinetostatic, Mode::Dynamic] {
                let full = solve_pose(&model, &s, mode, &mut ws);
                let solvable = matches!(full.status, Status::Ok | Status::IndeterminateContact);
                *seen.entry(format!("{mode:?} {:?}", full.status)).or_insert(0) += 1;
                let checked = solve_reactions_if_solvable(&model, &s, mode, &mut ws);
                let what = format!("case {case}, {mode:?}, {:?}", full.status);
                assert_eq!(checked.is_some(), solvable, "{what}");
                if let Some(r) = checked {
                    assert_eq!(format!("{r:?}"), format!("{:?}", full.reactions), "{what}");
                }
                let errors = solve_errors(&model, &s, mode, &mut ws);
                assert_eq!(format!("{errors:?}"), format!("{:?}", full.errors), "{what}");
                if solvable {
                    let plain = solve_reactions(&model, &s, mode, &mut ws).expect("reactions where solvable");
                    assert_eq!(format!("{plain:?}"), format!("{:?}", full.reactions), "{what}");
                }
            }
        }
    }
    // Every status met in kinetostatics, and solvable dynamic poses.
    for status in ["Ok", "NearSingular", "Unreachable"] {
        assert!(seen.keys().any(|k| k == &format!("Kinetostatic {status}")), "{seen:?}");
    }
    assert!(seen.keys().any(|k| k == "Dynamic Ok" || k == "Dynamic IndeterminateContact"), "{seen:?}");
}
