//! `clearance describe` writes each built-in kind as a custom description
//! (docs/model.md §12.9); run as a custom job it must give the built-in kind's values,
//! column by column, to 1e-12 of each column's scale, on grids and trajectories, in
//! kinetostatics and dynamics. Not compared: `q` (a custom run measures it from home),
//! the condition numbers (another reduction), the 6-UPS's scalar `m_u<i>`. A column's
//! scale is its largest value, or a hundredth of its family's (loads: reactions and
//! margins; errors: errors and envelopes) where that is larger: a column that is zero
//! to round-off (a couple along an axis that transmits none, the harmless U tilt play's
//! error) is measured against the loads or errors of its run. The exact error is
//! compared to 1e-10: it is `p' − p` of positions near 2 m for errors near 1e-4 m, so its
//! own round-off is some 1e-12 of its scale in either solver.

mod common;

use arrow::record_batch::RecordBatch;
use clearance_engine::{ColumnSet, JobSpec, MechanismKind, SolveOptions, describe, solve};
use common::ColumnScales;

fn column_of_custom(name: &str) -> String {
    // margin_s1 -> margin_s1_radial; everything else keeps its name.
    if let Some(rest) = name.strip_prefix("margin_s")
        && rest.chars().all(|c| c.is_ascii_digit())
    {
        return format!("{name}_radial");
    }
    name.to_string()
}

fn compared(name: &str) -> bool {
    let actuator = name.starts_with('q') && name[1..].chars().all(|c| c.is_ascii_digit());
    // The 6-UPS's scalar μ_i (`m_u1`): a custom run writes the couple's components.
    let scalar_couple = name.starts_with("m_u") && name.matches('_').count() == 1;
    !(actuator || scalar_couple || name.starts_with("cond_") || name == "variant")
}

fn check(text: &str) {
    let job = JobSpec::from_toml_str(text, "builtin.toml").unwrap();
    let described = describe(&job, "builtin.toml").unwrap();
    let opts = SolveOptions { columns: ColumnSet::Full, ..SolveOptions::default() };
    let b = solve(&job, "builtin.toml", &opts).unwrap();
    // The description's own (general) path: a 3-PRS's or 6-UPS's description as
    // `describe` writes it goes through the built-in kernel (tested against the general
    // path in custom_preset_kernel_is_the_general_path.rs).
    let described = if matches!(job.mechanism.kind, MechanismKind::Prs3 | MechanismKind::Ups6) {
        common::general_path(&described)
    } else {
        described
    };
    let c = solve(&described, "described.toml", &opts).unwrap();
    assert_eq!(b.len(), c.len());
    let mut compared_columns = 0;
    for (bb, cb) in b.iter().zip(&c) {
        compare_batches(bb, cb, &mut compared_columns);
    }
    assert!(compared_columns > 40, "only {compared_columns} columns compared");
}

fn compare_batches(b: &RecordBatch, c: &RecordBatch, count: &mut usize) {
    assert_eq!(b.num_rows(), c.num_rows());
    let scales = ColumnScales::of(b);
    for (i, field) in b.schema().fields().iter().enumerate() {
        let name = field.name();
        if !compared(name) {
            continue;
        }
        let Ok(j) = c.schema().index_of(&column_of_custom(name)) else {
            panic!("the description's run has no column {}", column_of_custom(name));
        };
        *count += 1;
        let tol = if name.starts_with("exact_err_") { 1e-10 } else { 1e-12 };
        scales.assert_close(name, b.column(i), c.column(j), tol);
    }
}

const KINDS_3: &str = "[clearance]\ns_radial = 1e-4\nr_radial = 2e-4\nr_axial = 1.5e-4\nr_angular = 1e-4\n\
[mass]\npoints = [{ mass = 30.0, at = [0.05, -0.02, 1.0] }]\n[load]\nforce = [3.0, -2.0, 5.0]\nmoment = [0.4, 0.1, -0.3]\n";

#[test]
fn the_3prs_described_is_the_3prs() {
    check(&format!(
        "{KINDS_3}[analysis]\nexact = true\n[grid]\nz = 2.05\npsi = {{ start = -0.4, stop = 0.4, n = 7 }}\ntheta = {{ start = -0.4, stop = 0.4, n = 7 }}\n"
    ));
}

#[test]
fn a_3prs_with_inclined_rails_in_dynamics_is_the_same() {
    check(&format!(
        "[mechanism]\nrail_angle_deg = 30.0\nlimb_angles_deg = [0.0, 100.0, 230.0]\n{KINDS_3}[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = {{ start = 0.0, stop = 2.0, n = 21 }}\nz = 1.6\npsi = 0.1\ntheta = {{ offset = 0.0, harmonics = [{{ amplitude = 0.3, period = 2.0 }}] }}\n"
    ));
}

#[test]
fn the_3rps_described_is_the_3rps() {
    check(&format!(
        "[mechanism]\nkind = \"3-RPS\"\n{KINDS_3}[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\nexact = true\n\
         [trajectory]\ntime = {{ start = 0.0, stop = 2.0, n = 21 }}\nz = 1.2\npsi = {{ offset = 0.0, harmonics = [{{ amplitude = 0.2, period = 3.0 }}] }}\ntheta = {{ offset = 0.1, harmonics = [{{ amplitude = 0.3, period = 2.0 }}] }}\n"
    ));
}

#[test]
fn the_6ups_described_is_the_6ups() {
    let clear = "[clearance]\ns_radial = 1e-4\nu_radial = 2e-4\nu_angular = 1e-4\n[load]\nforce = [3.0, -2.0, 5.0]\n";
    check(&format!(
        "[mechanism]\nkind = \"6-UPS\"\n{clear}[analysis]\nexact = true\n[grid]\nx = 0.02\ny = {{ start = -0.05, stop = 0.05, n = 3 }}\nz = 0.75\nphi = 0.05\npsi = {{ start = -0.1, stop = 0.1, n = 3 }}\ntheta = {{ start = -0.1, stop = 0.1, n = 3 }}\n"
    ));
    check(&format!(
        "[mechanism]\nkind = \"6-UPS\"\n{clear}[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = {{ start = 0.0, stop = 1.0, n = 11 }}\nx = 0.01\ny = 0.0\nz = 0.75\nphi = 0.0\npsi = {{ offset = 0.0, harmonics = [{{ amplitude = 0.1, period = 1.0 }}] }}\ntheta = 0.05\n"
    ));
}
