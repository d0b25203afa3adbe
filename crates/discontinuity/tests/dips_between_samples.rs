//! What the samples alone do not show (docs/model.md §8): a dip below the threshold
//! between samples above it, and two zero crossings of the axial load inside one
//! sample interval. Each is checked against a brute-force dense scan of the load.

mod common;

use clearance_discontinuity::{Along, SearchOptions, find_discontinuities, paths};
use clearance_model::{ClearanceKind, Mode};
use clearance_solver::{Workspace, solve_pose};
use common::job;

fn trajectory(n: u32, fraction: f64) -> String {
    format!(
        "[mass]\npoints = [{{ mass = 30.0, at = [0.0, 0.0, 1.0] }}]\n[clearance]\nr_radial = 1e-4\n\
         [analysis]\ndiscontinuity_load_fraction = {fraction}\n\
         [trajectory]\ntime = {{ start = 1.25, stop = 3.75, n = {n} }}\nz = 2.05\npsi = 0.0\n\
         theta = {{ harmonics = [ {{ amplitude = 0.5, period = 5.0 }} ] }}\n"
    )
}

/// Limb 1's `r_radial` load along the Fig. 16 trajectory dips to about 2.33 N near
/// t = 2.979 s. With a threshold of 3 N and 51 samples, every sample is above it
/// (the nearest read 9.8 N and 7.2 N): the dip is found all the same, where a 4×
/// finer sampling and a dense scan put it.
#[test]
fn shallow_dip_below_the_threshold_between_samples_above_it() {
    let threshold = 3.0;
    let fraction = threshold / job(&trajectory(51, 0.05)).0.weight();
    let (job, model, source) = job(&trajectory(51, fraction));
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    assert!((opts.dip_threshold - threshold).abs() < 1e-9);
    let path = &paths(&source)[0];
    let mut ws = Workspace::new();
    let margin = |p: f64, ws: &mut Workspace| {
        solve_pose(&model, &path.sample_at(&source, p), Mode::Kinetostatic, ws).margins.r_radial[0]
    };
    // The premise: no sample of limb 1 is below the threshold.
    for &p in path.params.iter() {
        assert!(margin(p, &mut ws) > threshold, "the sample at t = {p} is below the threshold");
    }
    let coarse: Vec<_> =
        find_discontinuities(&model, &source, Mode::Kinetostatic, &opts).into_iter().filter(|d| d.limb == 1).collect();
    assert_eq!(coarse.len(), 1, "{coarse:?}");
    let (fine_job, fine_model, fine_source) = common::job(&trajectory(201, fraction));
    let fine_opts = SearchOptions { dip_threshold: fine_job.analysis.discontinuity_load_fraction * fine_job.weight() };
    let fine: Vec<_> = find_discontinuities(&fine_model, &fine_source, Mode::Kinetostatic, &fine_opts)
        .into_iter()
        .filter(|d| d.limb == 1)
        .collect();
    assert_eq!(fine.len(), 1, "{fine:?}");
    assert!((coarse[0].param - fine[0].param).abs() < 1e-6, "{} vs {}", coarse[0].param, fine[0].param);
    // A dense scan of the squared magnitude over the two intervals around the dip,
    // the minimum then from the parabola through its three lowest neighbours.
    let (lo, hi, n) = (2.95, 3.0, 100_000);
    let step = (hi - lo) / n as f64;
    let squared: Vec<f64> = (0..=n).map(|i| margin(lo + i as f64 * step, &mut ws).powi(2)).collect();
    let i = (1..n).min_by(|&a, &b| squared[a].total_cmp(&squared[b])).unwrap();
    let (a, b, c) = (squared[i - 1], squared[i], squared[i + 1]);
    let scanned = lo + (i as f64 + 0.5 * (a - c) / (a - 2.0 * b + c)) * step;
    assert!((coarse[0].param - scanned).abs() < 1e-6, "{} vs the scan's {scanned}", coarse[0].param);
    assert!(coarse[0].margin < threshold && (coarse[0].margin - squared[i].sqrt()).abs() < 1e-6);
}

/// Along the Θ-line at Ψ = −0.1, limb 2's axial load changes sign at Θ ≈ −0.058
/// and −0.0068: with 11 nodes both lie between the nodes −0.1 and 0, whose loads
/// have one sign. Both are switches, where bisection on a dense scan puts them.
#[test]
fn two_axial_crossings_in_one_interval_are_two_switches() {
    let text = "[clearance]\nr_axial = 1e-4\n[grid]\nz = 2.05\npsi = -0.1\n\
        theta = { start = -0.5, stop = 0.5, n = 11 }\n";
    let (job, model, source) = job(text);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    let path = &paths(&source)[0];
    assert_eq!(path.along, Along::Theta);
    let mut ws = Workspace::new();
    let axial = |p: f64, ws: &mut Workspace| {
        let r = solve_pose(&model, &path.sample_at(&source, p), Mode::Kinetostatic, ws);
        r.reactions.f_r[1].dot(&model.geometry.y[1])
    };
    // The premise: the nodes either side have one sign.
    assert!(axial(-0.1, &mut ws) * axial(0.0, &mut ws) > 0.0);
    // Brute force: 1e5 samples over the line, each sign change bisected.
    let n = 100_000;
    let at = |i: usize| -0.5 + i as f64 / n as f64;
    let mut expected = Vec::new();
    let mut previous = axial(at(0), &mut ws);
    for i in 1..=n {
        let here = axial(at(i), &mut ws);
        if (here < 0.0) != (previous < 0.0) {
            let (mut a, mut b) = (at(i - 1), at(i));
            while b - a > 1e-13 {
                let m = 0.5 * (a + b);
                if (axial(m, &mut ws) < 0.0) == (previous < 0.0) {
                    a = m;
                } else {
                    b = m;
                }
            }
            expected.push(0.5 * (a + b));
        }
        previous = here;
    }
    let found: Vec<f64> = find_discontinuities(&model, &source, Mode::Kinetostatic, &opts)
        .into_iter()
        .filter(|d| d.limb == 2 && d.kind == ClearanceKind::RAxial)
        .map(|d| d.param)
        .collect();
    assert_eq!(found.len(), expected.len(), "{found:?} vs {expected:?}");
    assert!(expected.iter().filter(|&&p| (-0.1..0.0).contains(&p)).count() == 2, "{expected:?}");
    for (f, e) in found.iter().zip(&expected) {
        assert!((f - e).abs() < 2e-9, "{f} vs the scan's {e}");
    }
}
