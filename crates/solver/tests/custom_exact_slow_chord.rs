//! docs/model.md §12.7: the exact error of a custom mechanism is solved to round-off
//! however slowly its chord iterations contract, and it is the pose the clearances
//! make (within the linear error's size of the linear error). Every sample's values are
//! cross-checked against the NumPy reference's Newton by `.ci/run`
//! (`scripts/crosscheck_custom.py --job crates/solver/tests/data/slow_chord.toml`).

use clearance_model::{JobSpec, Mode};
use clearance_solver::Status;
use clearance_solver::custom::{CustomModel, solve_custom};

const JOB: &str = include_str!("data/slow_chord.toml");

#[test]
fn a_slowly_contracting_chord_still_gives_the_exact_error() {
    let job = JobSpec::from_toml_str(JOB, "slow_chord.toml").unwrap();
    let model = CustomModel::from_job(&job, "slow_chord.toml").unwrap();
    // The grid's first sample (its corner) and its neighbour along theta; the inputs in
    // canonical order, z, psi, theta.
    for theta in [-0.16849012515248374, -0.11321466848396793] {
        let r = solve_custom(&model, &[0.5618587665407536, 0.0820540100528341, theta], None, Mode::Kinetostatic);
        assert_eq!(r.status, Status::Ok);
        let linear = r.total.expect("an ok pose has its linear error");
        let exact = r.exact.unwrap_or_else(|| panic!("no exact error at theta = {theta}"));
        // Large here (0.04 rad): what makes the chord slow.
        let size = linear[..6].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(size > 0.03, "linear error {size}");
        let gap = (0..6).map(|i| (exact[i] - linear[i]).powi(2)).sum::<f64>().sqrt();
        assert!(gap < 0.5 * size, "exact {exact:?} against linear {linear:?}");
    }
}
