//! A vector load that passes through zero on a sample (a couple on a symmetry plane):
//! the sample is indeterminate (its direction is undefined), and the search leaves it
//! out rather than stopping there (`vector_load::path_switches`, docs/model.md §8).
//! Its neighbours are consecutive: their directions are opposed, the interval between
//! them is refined, and the switch is at the zero, as where the zero lies between
//! samples. Read as a gap, the sample hid the switch (the custom search missed the R
//! angular switches of the described 3-PRS on Ψ = 0 where the built-in kind finds them).

use clearance_discontinuity::vector_load::{self, SampledLoad, VectorRule};
use nalgebra::Vector3;

const RULE: VectorRule = VectorRule { threshold: 0.05, floor: 1e-9 };

/// A couple through zero at `s0`, turning by 180° there, samples at `0, 1, …, 8`.
fn load(s: f64, s0: f64) -> [f64; 3] {
    let u = 0.1 * (s - s0);
    [u, 0.5 * u, 0.2 * u * u]
}

/// The samples as solved: the magnitude and the vector at each.
fn samples(s0: f64) -> Vec<SampledLoad> {
    (0..9)
        .map(|k| {
            let f = Vector3::from(load(k as f64, s0));
            Some((f.norm(), f))
        })
        .collect()
}

/// Read as [`vector_load::switches`] reads a path: an indeterminate sample a gap.
fn as_gaps(loads: &[SampledLoad]) -> Vec<SampledLoad> {
    loads.iter().map(|l| l.filter(|(m, _)| *m > RULE.floor)).collect()
}

#[test]
fn a_zero_on_a_sample_is_a_switch_as_between_samples() {
    let on = samples(4.0);
    assert!(on[4].is_some_and(|(m, _)| m <= RULE.floor));
    let found = vector_load::path_switches(&on, &RULE, |s| Some(load(s, 4.0)));
    let [sw] = &found[..] else { panic!("{found:?}") };
    assert!((sw.at - 4.0).abs() < 1e-6 && sw.margin < 1e-9, "{sw:?}");
    // Read either side of the zero, between the samples 3 and 5, not at sample 4.
    assert!(sw.before.at > 3.0 && sw.before.at < 4.0 && sw.after.at > 4.0 && sw.after.at < 5.0, "{sw:?}");
    assert!(sw.before.sample != Some(4) && sw.after.sample != Some(4));
    // Off the sample, the same switch.
    let off = samples(4.3);
    let found = vector_load::path_switches(&off, &RULE, |s| Some(load(s, 4.3)));
    let [sw] = &found[..] else { panic!("{found:?}") };
    assert!((sw.at - 4.3).abs() < 1e-6, "{sw:?}");
}

/// The premise: read as a gap, the indeterminate sample hides the switch.
#[test]
fn read_as_a_gap_the_sample_hid_it() {
    assert!(vector_load::switches(&as_gaps(&samples(4.0)), &RULE, |s| Some(load(s, 4.0))).is_empty());
}

/// Without an indeterminate sample the path's switches are [`vector_load::switches`]'s;
/// a gap still cuts the path.
#[test]
fn without_one_the_switches_are_the_rules_and_a_gap_still_cuts() {
    let s0 = 4.37;
    let all = samples(s0);
    let at = |s: f64| Some(load(s, s0));
    let found = vector_load::path_switches(&all, &RULE, at);
    assert_eq!(found.len(), 1);
    assert_eq!(found, vector_load::switches(&as_gaps(&all), &RULE, at));
    let mut cut = all.clone();
    cut[4] = None;
    assert!(vector_load::path_switches(&cut, &RULE, at).is_empty());
}

/// The linear map between kept samples: with a sample left out early on the path, a
/// switch further along is where it is without one, to round-off.
#[test]
fn a_sample_left_out_moves_nothing_else() {
    let s0 = 6.37;
    let at = |s: f64| Some(load(s, s0));
    let all = samples(s0);
    let mut one_out = all.clone();
    let f = Vector3::new(1e-12, 0.0, 0.0);
    one_out[1] = Some((f.norm(), f));
    let (a, b) = (vector_load::path_switches(&all, &RULE, at), vector_load::path_switches(&one_out, &RULE, at));
    assert_eq!((a.len(), b.len()), (1, 1));
    assert!((a[0].at - b[0].at).abs() < 1e-12 && (a[0].margin - b[0].margin).abs() < 1e-15, "{a:?} {b:?}");
    assert_eq!((a[0].before.sample, a[0].after.sample), (b[0].before.sample, b[0].after.sample));
}
