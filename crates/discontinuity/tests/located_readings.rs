//! The rule for a vector load along a path (`clearance_discontinuity::vector_load`,
//! docs/model.md §8) on synthetic loads whose magnitude and direction are set apart:
//! `f(s) = r(s)·(cos θ(s)·e₁ + sin θ(s)·e₂)` with `r = √(d² + (s − s₀)²)`, a dip to
//! `d` at `s₀` that reaches `2d` at `s₀ ± √3·d`, and a turn `θ` of our choosing. The
//! directions are compared where the magnitude reaches twice the minimum, located
//! between samples: the verdict is the same at every sampling, where the directions
//! at the samples the walks stop on give another at some.

use clearance_discontinuity::vector_load::{
    self, Reading, SampledLoad, Side, VectorRule, VectorSwitch, locate, readings, walk,
};
use nalgebra::Vector3;

/// Where the load dips, and how deep.
const S0: f64 = 0.413_7;
const D: f64 = 0.01;

const RULE: VectorRule = VectorRule { threshold: 0.05, floor: 1e-9 };

/// The plane the load turns in, tilted out of the axes.
fn plane() -> (Vector3<f64>, Vector3<f64>) {
    let e1 = Vector3::new(1.0, 2.0, 2.0) / 3.0;
    let e2 = Vector3::new(2.0, 1.0, -2.0) / 3.0;
    (e1, e2)
}

fn load(theta: fn(f64) -> f64, s: f64) -> [f64; 3] {
    let u = s - S0;
    let r = (D * D + u * u).sqrt();
    let (e1, e2) = plane();
    let f = r * (theta(u).cos() * e1 + theta(u).sin() * e2);
    [f.x, f.y, f.z]
}

/// Half the width of the dip at twice its minimum.
fn half_width() -> f64 {
    3f64.sqrt() * D
}

/// `n` samples over `s ∈ [0, 1]`, and the load at any path parameter (sample steps).
fn sampled(theta: fn(f64) -> f64, n: usize) -> (Vec<SampledLoad>, impl FnMut(f64) -> Option<[f64; 3]>) {
    let h = 1.0 / (n - 1) as f64;
    let loads = (0..n)
        .map(|k| {
            let f = Vector3::from(load(theta, k as f64 * h));
            Some((f.norm(), f))
        })
        .collect();
    (loads, move |p: f64| Some(load(theta, p * h)))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cosine(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(a, b) / (dot(a, a) * dot(b, b)).sqrt()
}

/// The directions where the walks from the dip stop, read at those samples (the
/// rule before the readings were located): whether they turn by more than 90°.
fn turns_at_samples(loads: &[SampledLoad], x: f64, m: f64) -> bool {
    let reach = RULE.reach(m);
    let at = |side| {
        let stop = walk(loads, x, reach, side).expect("determinate samples either side");
        assert!(stop.reached, "the magnitude rises to twice the minimum on either side");
        loads[stop.sample].unwrap().1
    };
    at(Side::Before).dot(&at(Side::After)) < 0.0
}

/// The dip's switches at `n` samples, its location and readings in `s`.
fn switches(theta: fn(f64) -> f64, n: usize) -> Vec<VectorSwitch> {
    let (loads, at) = sampled(theta, n);
    vector_load::switches(&loads, &RULE, at)
}

/// A turn of 2·55°·tanh(u/w) (w the dip's half width at twice its minimum): 84° between
/// the points where the magnitude is twice the minimum, 110° between samples well
/// out of the dip.
fn gentle(u: f64) -> f64 {
    55f64.to_radians() * (u / half_width()).tanh()
}

/// A turn that peaks at ±60° where the magnitude is twice the minimum and comes back
/// to nothing out of the dip: 120° between the located points, none between samples
/// well out of it.
fn there_and_back(u: f64) -> f64 {
    let v = u / half_width();
    60f64.to_radians() * v * (0.5 * (1.0 - v * v)).exp()
}

#[test]
fn a_turn_over_90_degrees_at_the_samples_but_not_at_twice_the_minimum_is_no_switch() {
    // The premise, at 4 samples: the walks stop on samples far out of the dip, whose
    // directions turn by more than 90°.
    let (loads, mut at) = sampled(gentle, 4);
    let x = S0 * 3.0;
    assert!(turns_at_samples(&loads, x, D), "the samples turn by more than 90°");
    // At the located points the load turns by 84°.
    let (before, after) = readings(&loads, x, D, RULE.reach(D), &mut at).unwrap();
    let turn = cosine(before.load, after.load).acos().to_degrees();
    assert!((turn - 2.0 * 55.0 * 1f64.tanh()).abs() < 1e-6, "{turn}°");
    for n in [4, 7, 13, 49] {
        assert_eq!(switches(gentle, n), [], "{n} samples");
    }
}

#[test]
fn a_turn_over_90_degrees_at_twice_the_minimum_is_a_switch_the_samples_do_not_show() {
    // The premise, at 4 samples: the directions where the walks stop agree.
    let (loads, _) = sampled(there_and_back, 4);
    assert!(!turns_at_samples(&loads, S0 * 3.0, D), "the samples do not turn");
    for n in [4, 7, 13, 49] {
        let h = 1.0 / (n - 1) as f64;
        let found = switches(there_and_back, n);
        let [VectorSwitch { at, margin, before, after }] = found[..] else { panic!("{n} samples: {found:?}") };
        assert!((at * h - S0).abs() < 1e-9, "{n} samples: at {}", at * h);
        assert!((margin - D).abs() < 1e-12, "{n} samples: margin {margin}");
        // Read where the magnitude is twice the minimum, between samples, 120° apart.
        for (r, side) in [(before, -1.0), (after, 1.0)] {
            assert!((r.at * h - (S0 + side * half_width())).abs() < 1e-9, "{n} samples: {r:?}");
            assert!((dot(r.load, r.load).sqrt() - 2.0 * D).abs() < 1e-9 * D, "{n} samples: {r:?}");
            assert_eq!(r.sample, None, "{n} samples: {r:?}");
        }
        assert!((cosine(before.load, after.load) + 0.5).abs() < 1e-6, "{n} samples");
    }
}

/// Located, both loads give every sampling's verdict; read at the samples the walks
/// stop on, the verdict at some samplings is the other one.
#[test]
fn the_verdict_does_not_depend_on_the_sampling() {
    for (theta, switch) in [(gentle as fn(f64) -> f64, false), (there_and_back, true)] {
        let mut at_samples = Vec::new();
        for n in [4, 5, 7, 9, 13, 25, 49, 97] {
            assert_eq!(switches(theta, n).len(), usize::from(switch), "{n} samples");
            let (loads, _) = sampled(theta, n);
            at_samples.push(turns_at_samples(&loads, S0 * (n - 1) as f64, D));
        }
        assert!(at_samples.contains(&!switch), "a sampling whose samples give the other verdict: {at_samples:?}");
    }
}

/// `locate` finds the root of `|f| − reach` between a point below it and one above,
/// from either side, to its tolerance; an end at `reach` exactly is that end; ends
/// that do not bracket `reach` give nothing.
#[test]
fn locate_finds_where_the_magnitude_reaches_a_level() {
    let f = |s: f64| Some(load(gentle, s));
    let reach = 2.0 * D;
    for (inner, outer) in [(S0, S0 + 0.1), (S0, S0 - 0.1), (S0 + 0.01, S0 + 0.02)] {
        let m = dot(load(gentle, inner), load(gentle, inner)).sqrt();
        let (p, fp) = locate((inner, m), (outer, load(gentle, outer)), reach, 1e-12, f).unwrap();
        let expected = S0 + (outer - S0).signum() * half_width();
        assert!((p - expected).abs() < 1e-12, "{p} against {expected}");
        assert_eq!(fp, load(gentle, p));
    }
    let exact = S0 + 0.05;
    let at_reach = (exact, load(gentle, exact));
    let level = dot(at_reach.1, at_reach.1).sqrt();
    assert_eq!(locate((S0, D), at_reach, level, 1e-12, f), Some(at_reach));
    assert_eq!(locate((S0, D), (S0 + 0.001, load(gentle, S0 + 0.001)), reach, 1e-12, f), None);
    // The load cannot be solved between: no point.
    assert_eq!(locate((S0, D), (S0 + 0.1, load(gentle, S0 + 0.1)), reach, 1e-12, |_| None), None);
}

/// Where the magnitude falls again before it reaches twice the minimum (a second dip
/// close by), the direction is read at the sampled maximum between the two, a sample;
/// at a path's end, at its last sample.
#[test]
fn a_walk_that_does_not_reach_twice_the_minimum_reads_at_a_sample() {
    // |f| = 0.01, 0.004 (the dip), 0.006, 0.005 (falls again), 0.03.
    let v = |m: f64, x: f64| Some((m, Vector3::new(x, (m * m - x * x).sqrt(), 0.0)));
    let loads = [v(0.01, 0.0), v(0.004, 0.0), v(0.006, 0.001), v(0.005, 0.0), v(0.03, 0.0)];
    let stop = walk(&loads, 1.0, 0.008, Side::After).unwrap();
    assert_eq!((stop.sample, stop.previous, stop.reached), (2, None, false));
    let stop = walk(&loads, 1.0, 0.008, Side::Before).unwrap();
    assert_eq!((stop.sample, stop.previous, stop.reached), (0, None, true));
    let mut no_solve = |_: f64| -> Option<[f64; 3]> { panic!("a sample's reading needs no solve") };
    let r = vector_load::reading(&loads, 1.0, 0.004, 0.008, Side::After, &mut no_solve).unwrap();
    assert_eq!(r, Reading { at: 2.0, load: [0.001, (0.006f64 * 0.006 - 1e-6).sqrt(), 0.0], sample: Some(2) });
    // The end of the path, short of the level: its last sample.
    let stop = walk(&loads, 3.0, 0.1, Side::After).unwrap();
    assert_eq!((stop.sample, stop.previous, stop.reached), (4, None, false));
    // An indeterminate first sample: no reading on that side.
    let gap = [v(0.01, 0.0), None, v(0.004, 0.0), v(0.02, 0.0)];
    assert_eq!(walk(&gap, 2.0, 0.008, Side::Before), None);
}
