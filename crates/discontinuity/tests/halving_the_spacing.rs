//! docs/model.md §8: halving the sample spacing neither adds nor moves switches. On the
//! geometry and loads of jobs/fig10_r_angular.toml, jobs/fig11_r_radial_added_mass.toml
//! and jobs/fig16_trajectory_added_mass.toml, with smaller grids for test time: the
//! lines of the coarse grid are lines of the fine one, and carry the same switches
//! (count, and locations within 1e-6); and one line sampled from 5 to 201 times gives
//! the same switches with the same jumps.

mod common;

use clearance_discontinuity::Along;
use clearance_model::Mode;
use common::{assert_same_switches, is_node, run};

fn grid(clearance: &str, masses: &str, n: u32) -> String {
    format!(
        "[mass]\npoints = [{masses}]\n[clearance]\n{clearance} = 1e-4\n[grid]\nz = 2.05\n\
         psi = {{ start = -0.5, stop = 0.5, n = {n} }}\ntheta = {{ start = -0.5, stop = 0.5, n = {n} }}\n"
    )
}

fn check_grid(clearance: &str, masses: &str, n: u32) {
    let coarse = run(&grid(clearance, masses, n), Mode::Kinetostatic);
    let fine = run(&grid(clearance, masses, 2 * n - 1), Mode::Kinetostatic);
    let on_coarse_line = |d: &clearance_discontinuity::Discontinuity| match d.along {
        Along::Psi => is_node(d.theta, n),
        Along::Theta => is_node(d.psi, n),
        _ => unreachable!("a Ψ–Θ grid"),
    };
    assert_same_switches(&coarse, &fine, on_coarse_line, 1e-6, clearance);
}

#[test]
fn fig10_angular_switches_do_not_depend_on_the_spacing() {
    check_grid("r_angular", "", 41);
}

#[test]
fn fig11_radial_switches_with_added_mass_do_not_depend_on_the_spacing() {
    check_grid("r_radial", "{ mass = 30.0, at = [0.0, 0.0, 1.0] }", 41);
}

#[test]
fn fig16_trajectory_switches_do_not_depend_on_the_spacing() {
    let text = |n: u32| {
        format!(
            "[mass]\npoints = [ {{ mass = 30.0, at = [0.0, 0.0, 1.0] }} ]\n[clearance]\nr_radial = 1e-4\n\
             [analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
             [trajectory]\ntime = {{ start = 1.25, stop = 3.75, n = {n} }}\nz = 2.05\npsi = 0.0\n\
             theta = {{ offset = 0.0, harmonics = [ {{ amplitude = 0.5, period = 5.0, phase = 0.0 }} ] }}\n"
        )
    };
    for mode in [Mode::Kinetostatic, Mode::Dynamic] {
        for n in [251, 2001] {
            let coarse = run(&text(n), mode);
            let fine = run(&text(2 * n - 1), mode);
            assert_same_switches(&coarse, &fine, |_| true, 1e-6, &format!("{mode:?}, {n} samples"));
        }
    }
}

/// The Θ-line at Ψ = 0.04 of jobs/fig11_r_radial_added_mass.toml sampled 5 to 201
/// times: one switch, limb 1's, at the same place with the same margin and jump. Limb
/// 2's `f⊥` dips below the threshold near Θ = 0.497, and read at the samples where the
/// magnitude had risen past twice the minimum its directions turned by more than 90°
/// with up to 33 samples and not with 65 or more: the search reported a switch there
/// at the coarse samplings. Read where the magnitude is twice the minimum, located
/// between samples, they do not turn that far at any sampling.
#[test]
fn fig11_radial_verdicts_and_jumps_do_not_depend_on_the_sampling() {
    let line = |n: u32| {
        let text = format!(
            "[mass]\npoints = [{{ mass = 30.0, at = [0.0, 0.0, 1.0] }}]\n[clearance]\nr_radial = 1e-4\n\
             [grid]\nz = 2.05\npsi = 0.04\ntheta = {{ start = -0.5, stop = 0.5, n = {n} }}\n"
        );
        run(&text, Mode::Kinetostatic)
    };
    let fine = line(201);
    let [one] = &fine[..] else { panic!("{fine:?}") };
    assert_eq!((one.limb, one.along), (1, Along::Theta));
    assert!((one.theta + 0.2833).abs() < 1e-4, "{}", one.theta);
    let size = one.jump.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for n in [5, 9, 17, 33, 65] {
        let found = line(n);
        let [d] = &found[..] else { panic!("{n} samples: {found:?}") };
        assert_eq!((d.limb, d.kind), (one.limb, one.kind), "{n} samples");
        assert!((d.theta - one.theta).abs() < 1e-9, "{n} samples: {} against {}", d.theta, one.theta);
        assert!((d.margin - one.margin).abs() < 1e-9 * one.margin, "{n} samples");
        // The jump between the located points: the same to the location's tolerance
        // (the take-up turns fast there, 1e-9 in Θ is about 1e-6 of the jump).
        for i in 0..6 {
            assert!((d.jump[i] - one.jump[i]).abs() < 1e-5 * size, "{n} samples: {:?} against {:?}", d.jump, one.jump);
        }
    }
}
