//! A path that leaves the workspace between two solvable samples (a joint passes its
//! range and comes back) is cut there, as an unsolvable sample cuts it
//! (`clearance_discontinuity::vector_load::switches`, docs/model.md §8): a dip next to
//! or inside the unsolvable stretch is not a switch. Found by the custom cross-check
//! (seed 18013, a 6-PUS trajectory whose limb 6 slider passed its stop between two
//! samples): the engine reported a switch at the edge of the stretch, where the
//! reference could not solve the pose.
//!
//! The load dips to `D` at `S0` and its direction turns by nearly 180° through the dip:
//! a switch wherever the whole dip can be followed.

use clearance_discontinuity::vector_load::{self, SampledLoad, VectorRule};
use nalgebra::Vector3;

const S0: f64 = 0.413_7;
const D: f64 = 0.01;
/// Samples over `s ∈ [0, 1]`: the dip lies between samples 4 and 5.
const N: usize = 11;

const RULE: VectorRule = VectorRule { threshold: 0.05, floor: 1e-9 };

fn load(s: f64) -> [f64; 3] {
    let u = s - S0;
    let r = (D * D + u * u).sqrt();
    let theta = std::f64::consts::FRAC_PI_2 * (1.0 + (u / (0.5 * D)).tanh());
    let (e1, e2) = (Vector3::new(1.0, 2.0, 2.0) / 3.0, Vector3::new(2.0, 1.0, -2.0) / 3.0);
    let f = r * (theta.cos() * e1 + theta.sin() * e2);
    [f.x, f.y, f.z]
}

/// The switches with the load unsolvable on `gap` (in `s`; samples outside it).
fn switches(gap: Option<(f64, f64)>) -> Vec<f64> {
    let h = 1.0 / (N - 1) as f64;
    let solvable = |s: f64| gap.is_none_or(|(a, b)| !(a..=b).contains(&s));
    let loads: Vec<SampledLoad> = (0..N)
        .map(|k| {
            let s = k as f64 * h;
            assert!(solvable(s), "the gap lies between samples");
            let f = Vector3::from(load(s));
            Some((f.norm(), f))
        })
        .collect();
    vector_load::switches(&loads, &RULE, |p: f64| solvable(p * h).then(|| load(p * h)))
        .into_iter()
        .map(|sw| sw.at * h)
        .collect()
}

#[test]
fn the_whole_dip_followed_is_a_switch() {
    let found = switches(None);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!((found[0] - S0).abs() < 1e-9, "{found:?}");
}

#[test]
fn a_dip_inside_an_unsolvable_stretch_is_not_a_switch() {
    // Least solvable magnitude at the stretch's edge: before the cut, a switch there.
    assert_eq!(switches(Some((S0 - 0.002, S0 + 0.03))), Vec::<f64>::new());
}

#[test]
fn a_dip_beside_an_unsolvable_stretch_is_not_a_switch() {
    // The minimum solvable, the magnitude's rise to twice it on one side not: the piece
    // of path ends beside the minimum, which is no interior minimum of it.
    assert_eq!(switches(Some((S0 + 0.005, S0 + 0.04))), Vec::<f64>::new());
}

#[test]
fn an_unsolvable_stretch_elsewhere_leaves_the_switch() {
    // A stretch in another interval (samples 7 and 8) cuts only that one.
    let found = switches(Some((0.72, 0.76)));
    assert_eq!(found.len(), 1, "{found:?}");
    assert!((found[0] - S0).abs() < 1e-9, "{found:?}");
}
