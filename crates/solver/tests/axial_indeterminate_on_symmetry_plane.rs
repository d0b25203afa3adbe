//! docs/model.md §8: limb 1's axial load is zero on the symmetry plane Ψ = 0 under dead
//! weight, so its axial take-up is indeterminate; the other kinds are still reported,
//! and a rigid kind (clearance 0) never makes a pose indeterminate.

mod common;

use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Status, Workspace, solve_pose};

#[test]
fn limb_one_axial_load_vanishes_at_psi_zero() {
    let job = JobSpec::from_toml_str(
        "[clearance]\nr_axial = 1e-4\nr_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.3\n",
        "sym.toml",
    )
    .unwrap();
    let model = Model::from_job(&job);
    let mut ws = Workspace::new();
    let r = solve_pose(&model, &common::static_sample(2.05, 0.0, 0.3), Mode::Kinetostatic, &mut ws);
    assert!(r.margins.r_axial[0] <= 1e-9 * job.weight());
    assert_eq!(r.status, Status::IndeterminateContact);
    assert_eq!(r.kind_ok, [true, true, false, true]);
    assert!(r.errors[1].dp.norm() > 1e-5, "r_radial error still computed");

    // Off the plane the load is determinate.
    let off = solve_pose(&model, &common::static_sample(2.05, 0.05, 0.3), Mode::Kinetostatic, &mut ws);
    assert_eq!(off.status, Status::Ok);

    // Without axial clearance, the same pose is ok.
    let rigid =
        JobSpec::from_toml_str("[clearance]\nr_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.3\n", "sym.toml")
            .unwrap();
    let r2 = solve_pose(&Model::from_job(&rigid), &common::static_sample(2.05, 0.0, 0.3), Mode::Kinetostatic, &mut ws);
    assert_eq!(r2.status, Status::Ok);
}
