//! docs/model.md §8 on the paper's cases, and independence from the sample spacing.

use clearance_discontinuity::{Along, Discontinuity, SearchOptions, find_discontinuities};
use clearance_grid::SampleSource;
use clearance_model::{ClearanceKind, JobSpec, Mode};
use clearance_solver::Model;

fn run(text: &str, mode: Mode) -> Vec<Discontinuity> {
    let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
    let model = Model::from_job(&job);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    find_discontinuities(&model, &SampleSource::new(&job), mode, &opts)
}

fn grid(clearance: &str, masses: &str, n: u32) -> String {
    format!(
        "[mass]\npoints = [{masses}]\n[clearance]\n{clearance} = 1e-4\n[grid]\nz = 2.05\n\
         psi = {{ start = -0.5, stop = 0.5, n = {n} }}\ntheta = {{ start = -0.5, stop = 0.5, n = {n} }}\n"
    )
}

fn trajectory(masses: &str, n: u32) -> String {
    format!(
        "[mass]\npoints = [{masses}]\n[clearance]\nr_radial = 1e-4\n[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = {{ start = 1.25, stop = 3.75, n = {n} }}\nz = 2.05\npsi = 0.0\n\
         theta = {{ harmonics = [ {{ amplitude = 0.5, period = 5.0 }} ] }}\n"
    )
}

const ABOVE: &str = "{ mass = 30.0, at = [0.0, 0.0, 1.0] }";
const BOTH: &str = "{ mass = 30.0, at = [0.0, 0.0, 1.0] }, { mass = 30.0, at = [0.0, 0.0, -1.0] }";

#[test]
fn dead_weight_radial_clearances_never_switch() {
    // Figs. 7–8: the deciding loads stay far from zero over the workspace.
    assert!(run(&grid("s_radial", "", 41), Mode::Kinetostatic).is_empty());
    assert!(run(&grid("r_radial", "", 41), Mode::Kinetostatic).is_empty());
}

#[test]
fn axial_and_angular_clearances_switch_at_the_axial_sign_change() {
    // Figs. 9–10. Every axial switch sits where the refined axial load vanishes.
    let axial = run(&grid("r_axial", "", 41), Mode::Kinetostatic);
    assert!(!axial.is_empty());
    for d in &axial {
        assert_eq!(d.kind, ClearanceKind::RAxial);
        assert!(d.margin < 1e-6, "axial load at the switch {}", d.margin);
        // Taking up the other wall moves the platform by about twice the clearance.
        let jump = (d.jump[0].powi(2) + d.jump[1].powi(2) + d.jump[2].powi(2)).sqrt();
        assert!(jump > 1e-6, "a switch is a step in the error");
    }
    assert!(!run(&grid("r_angular", "", 41), Mode::Kinetostatic).is_empty());
}

#[test]
fn added_mass_brings_radial_switches_and_the_counterweight_removes_them() {
    // Figs. 11–12.
    let with_mass = run(&grid("r_radial", ABOVE, 41), Mode::Kinetostatic);
    assert!(!with_mass.is_empty());
    assert!(with_mass.iter().all(|d| d.kind == ClearanceKind::RRadial));
    assert!(run(&grid("r_radial", BOTH, 41), Mode::Kinetostatic).is_empty());
}

#[test]
fn trajectory_switch_of_limb_one_near_the_papers_theta() {
    // docs/model.md §8: 30 kg puts the kinetostatic r_radial switch of limb 1 near Θ = −0.28.
    let k = run(&trajectory(ABOVE, 501), Mode::Kinetostatic);
    let limb1: Vec<_> = k.iter().filter(|d| d.limb == 1).collect();
    assert_eq!(limb1.len(), 1, "{k:?}");
    assert!((limb1[0].theta + 0.28).abs() < 0.01, "Θ = {}", limb1[0].theta);
    assert_eq!(limb1[0].along, Along::T);
    // Inertial loads move it (the paper: "inertial loads move the switches").
    let d = run(&trajectory(ABOVE, 501), Mode::Dynamic);
    let moved = d.iter().find(|x| x.limb == 1).expect("a dynamic switch of limb 1");
    assert!((moved.theta - limb1[0].theta).abs() > 0.01);
    // The counterweight removes it in kinetostatics.
    assert!(run(&trajectory(BOTH, 501), Mode::Kinetostatic).is_empty());
}

/// Halving the spacing neither adds nor moves switches.
#[test]
fn switches_do_not_depend_on_the_sample_spacing() {
    for mode in [Mode::Kinetostatic, Mode::Dynamic] {
        let coarse = run(&trajectory(ABOVE, 251), mode);
        let fine = run(&trajectory(ABOVE, 501), mode);
        assert_eq!(coarse.len(), fine.len(), "{mode:?}");
        for (a, b) in coarse.iter().zip(&fine) {
            assert_eq!((a.limb, a.kind), (b.limb, b.kind));
            assert!((a.param - b.param).abs() < 1e-8, "{} vs {}", a.param, b.param);
        }
    }
    // Grids: the Θ-lines at the coarse grid's Ψ nodes exist in both (Ψ·40 is an
    // even whole number on the coarse grid, any whole number on the fine one).
    let coarse = run(&grid("r_axial", ABOVE, 21), Mode::Kinetostatic);
    let fine = run(&grid("r_axial", ABOVE, 41), Mode::Kinetostatic);
    let on_common = |v: &[Discontinuity]| -> Vec<(i64, usize, f64)> {
        let mut out: Vec<_> = v
            .iter()
            .filter(|d| d.along == Along::Theta)
            .map(|d| ((d.psi * 40.0).round() as i64, d.limb, d.theta))
            .collect();
        out.sort_by(|a, b| a.partial_cmp(b).unwrap());
        out
    };
    let (c, f) = (on_common(&coarse), on_common(&fine));
    let f: Vec<_> = f.into_iter().filter(|x| c.iter().any(|y| y.0 == x.0)).collect();
    assert!(!c.is_empty());
    assert_eq!(c.len(), f.len());
    for (a, b) in c.iter().zip(&f) {
        assert_eq!((a.0, a.1), (b.0, b.1));
        assert!((a.2 - b.2).abs() < 1e-8);
    }
}

/// By mirror symmetry about limb 1's plane, limb 1's axial load changes sign exactly
/// at Ψ = 0: every Ψ-line switch of limb 1 must be located there to the tolerance.
#[test]
fn known_sign_change_is_located_to_the_tolerance() {
    // An even n puts no grid node on Ψ = 0, so the search must bisect to it.
    let found = run(&grid("r_axial", "", 40), Mode::Kinetostatic);
    let at_zero: Vec<_> = found
        .iter()
        .filter(|d| d.limb == 1 && d.along == Along::Psi)
        .filter(|d| d.psi.abs() <= clearance_discontinuity::LOCATE_TOL)
        .collect();
    // Every Ψ-line (one per Θ node) crosses the plane once; other switches of limb 1,
    // elsewhere on some lines, are real sign changes too.
    let mut thetas: Vec<f64> = at_zero.iter().map(|d| d.theta).collect();
    thetas.dedup();
    assert_eq!((at_zero.len(), thetas.len()), (40, 40), "one switch at Ψ = 0 on each Ψ-line");
}
