//! A load that is the same at every sample of a path to round-off (the legs of a
//! custom 6-PUS along its Z-lines: the sliders carry them unchanged) has no sampled
//! minimum, however its round-off falls: the rule of docs/model.md §8 refines nothing
//! and solves nothing there. A minimum a billionth deep is still one.

use clearance_discontinuity::vector_load::{self, SampledLoad, VectorRule};
use nalgebra::Vector3;

const RULE: VectorRule = VectorRule { threshold: 0.05 * 98.0, floor: 1e-9 * 98.0 };

/// `n` samples of `f` (sample steps), with a round-off of a few ulps that makes
/// every other sample a minimum of the magnitude.
fn sampled(n: usize, f: impl Fn(f64) -> Vector3<f64>) -> Vec<SampledLoad> {
    (0..n)
        .map(|k| {
            let noise = if k % 2 == 1 { -4e-15 } else { 3e-15 };
            let v = f(k as f64) * (1.0 + noise);
            Some((v.norm(), v))
        })
        .collect()
}

#[test]
fn a_load_flat_to_round_off_is_searched_without_a_solve() {
    let flat = |_s: f64| Vector3::new(2.855, -11.49, 32.23);
    for n in [3, 41] {
        let loads = sampled(n, flat);
        assert!((1..n - 1).any(|k| loads[k].unwrap().0 < loads[k - 1].unwrap().0), "the round-off dips");
        assert!(vector_load::candidates(&loads).is_empty(), "{n} samples");
        let mut solves = 0;
        let found = vector_load::switches(&loads, &RULE, |s| {
            solves += 1;
            let v = flat(s);
            Some([v.x, v.y, v.z])
        });
        assert!(found.is_empty());
        assert_eq!(solves, 0, "{n} samples");
    }
}

#[test]
fn a_shallow_minimum_is_still_a_minimum() {
    // |f| = 34·(1 + 1e-9·(s − 20.3)²): its sampled minimum at s = 20 lies 3e-8 N below
    // its neighbours, far above the round-off.
    let shallow = |s: f64| Vector3::new(34.0 * (1.0 + 1e-9 * (s - 20.3) * (s - 20.3)), 0.0, 0.0);
    let loads: Vec<SampledLoad> = (0..41).map(|k| Some((shallow(k as f64).norm(), shallow(k as f64)))).collect();
    assert!(vector_load::is_min(&loads, 20));
    assert_eq!(vector_load::candidates(&loads), vec![19, 20]);
}
