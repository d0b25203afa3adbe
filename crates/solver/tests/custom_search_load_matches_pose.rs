//! What the switch search reads of a custom mechanism at a point between samples
//! (`group_load_near`: one group's deciding load, without the condition number's
//! singular values where a bound decides) is what the whole pose's solve gives there:
//! the same bits of the load, and no load exactly where the pose is near-singular,
//! with `singular_cond` set among the poses' own condition numbers so that both
//! verdicts occur.

use clearance_model::{JobSpec, Mode};
use clearance_solver::custom::{CustomModel, group_load_near, solve_custom};

/// The 3-RRS of `jobs/custom_3rrs_grid.toml` (cranks, knees, spherical joints).
fn model() -> CustomModel {
    let text = include_str!("../../../jobs/custom_3rrs_grid.toml");
    CustomModel::from_job(&JobSpec::from_toml_str(text, "custom_3rrs_grid.toml").unwrap(), "c.toml").unwrap()
}

#[test]
fn the_search_reads_the_poses_own_load_and_verdict() {
    let mut model = model();
    let poses: Vec<[f64; 3]> =
        (0..41).flat_map(|i| [-0.3, 0.1, 0.45].map(|t| [0.6, -0.8 + 0.04 * i as f64, t])).collect();
    let mut conds: Vec<f64> = poses
        .iter()
        .map(|x| solve_custom(&model, x, None, Mode::Kinetostatic).cond)
        .filter(|c| c.is_finite())
        .collect();
    conds.sort_by(f64::total_cmp);
    assert!(conds.len() > 100 && conds[0] < conds[conds.len() - 1], "{conds:?}");
    model.singular_cond = conds[conds.len() / 2];
    let (mut singular, mut loaded) = (0, 0);
    for x in &poses {
        let pose = solve_custom(&model, x, None, Mode::Kinetostatic);
        singular += usize::from(!pose.loaded());
        for g in 0..model.groups.len() {
            let (load, _) = group_load_near(&model, x, None, Mode::Kinetostatic, None, g);
            let expected = (pose.loaded() && pose.takes[g].mobile).then(|| pose.takes[g].load);
            assert_eq!(
                load.map(|l| l.map(f64::to_bits)),
                expected.map(|l| l.map(f64::to_bits)),
                "group {g} at {x:?} (cond {:e}, singular_cond {:e})",
                pose.cond,
                model.singular_cond
            );
            loaded += usize::from(load.is_some());
        }
    }
    assert!(singular > 20 && loaded > 100, "{singular} near-singular poses, {loaded} loads read");
}
