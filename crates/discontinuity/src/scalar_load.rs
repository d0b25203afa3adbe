//! The switches of one scalar load along one path (docs/model.md §8), whatever the
//! mechanism: the load's samples in path order and a way to evaluate it between them
//! are all it needs. It is the scalar rule of the 3-limb search (`scalar.rs`, which
//! reads traces and its own cache of reactions) apart from any mechanism; the custom
//! search calls it, and both look for a pair of zeros between samples with
//! `pair_beside`.
//!
//! A path is read as the load at its samples, `&[Option<f64>]` (`None` where the pose
//! cannot be solved, or the load is not the search's there: a gap that cuts the path),
//! with a noise floor (a sample at or below it is indeterminate and left out, so its
//! neighbours are consecutive: a load through zero on a sample, such as an axial load
//! on a symmetry plane, still switches there), and a closure `FnMut(f64) ->
//! Option<f64>` that solves the load at any path parameter, in sample steps (sample
//! `k` at `k as f64`; `None` where the pose there is unsolvable).
//!
//! The load switches where it changes sign ([`crossings`]):
//!
//! - once between consecutive determinate samples of opposite signs, the root located
//!   by Brent's method;
//! - twice where an interval beside a sampled minimum of the magnitude, with ends of
//!   one sign, holds a point of the other sign (two crossings between samples, as a
//!   finer sampling would show), found by minimising the signed load on the interval
//!   (spared where the load at the interval's midpoint shows it clear) and located
//!   either side of that point. A load flat to round-off has no sampled minimum.
//!
//! An interval in which the load cannot be solved at some point is cut there: no
//! crossing is kept in it.

use crate::minimise::{FLAT, brent_min_below, parabolic_min_below};
use crate::scalar::stays_clear;
use crate::shortcut::Shortcut;
use crate::{SCAN_TOL, brent_root, interpolated_root};

/// Where a switch's jump is read on one side of it (this rule's crossings, the 3-limb
/// search's switches, the custom search's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Side {
    /// A sample of the path (its index).
    Sample(usize),
    /// A point between samples (the path parameter, in sample steps), such as the point
    /// of the other sign between a pair of crossings.
    At(f64),
}

/// One zero of a scalar load along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// The path parameter of the zero, in sample steps.
    pub at: f64,
    /// Where the take-up is read before the zero and after it.
    pub before: Side,
    pub after: Side,
}

/// The zeros of the load along the path, in order (module documentation), each
/// located to `tol` in the path parameter.
pub fn crossings(loads: &[Option<f64>], floor: f64, tol: f64, mut at: impl FnMut(f64) -> Option<f64>) -> Vec<Crossing> {
    let mut out = Vec::new();
    // The determinate samples of each stretch between gaps, in order.
    let mut stretch: Vec<(usize, f64)> = Vec::new();
    for (k, load) in loads.iter().enumerate() {
        match load {
            None => {
                stretch_crossings(&stretch, floor, tol, &mut at, &mut out);
                stretch.clear();
            }
            Some(v) if v.abs() > floor => stretch.push((k, *v)),
            Some(_) => {}
        }
    }
    stretch_crossings(&stretch, floor, tol, &mut at, &mut out);
    out.sort_by(|x, y| x.at.total_cmp(&y.at));
    out
}

/// The crossings of one stretch of determinate samples `(index, load)` with no gap
/// between them, into `out`.
fn stretch_crossings(
    samples: &[(usize, f64)],
    floor: f64,
    tol: f64,
    at: &mut impl FnMut(f64) -> Option<f64>,
    out: &mut Vec<Crossing>,
) {
    for w in samples.windows(2) {
        let [(a, fa), (b, fb)] = [w[0], w[1]];
        if fa.signum() == fb.signum() {
            continue;
        }
        // A point that cannot be solved reads zero for the root finder, and cuts the
        // interval.
        let mut unsolved = false;
        let x = brent_root(a as f64, b as f64, fa, fb, tol, |p| read(&mut *at, p, &mut unsolved, 0.0));
        if !unsolved {
            out.push(Crossing { at: x, before: Side::Sample(a), after: Side::Sample(b) });
        }
    }
    for w in samples.windows(3) {
        let [(a, fa), (k, fk), (c, fc)] = [w[0], w[1], w[2]];
        // A sampled minimum of the magnitude, not a flat load's round-off (a slider's
        // force that a translation of the whole mechanism carries unchanged), which is
        // no more a minimum than a monotone stretch is (as the vector rule's).
        let (a_, m, c_) = (fa.abs(), fk.abs(), fc.abs());
        if !(m < a_ && m <= c_) || (a_ - m <= FLAT * a_ && c_ - m <= FLAT * c_) {
            continue;
        }
        // The load's sign at the sample: look for a point of the other sign.
        let sign = fk.signum();
        let three = [(a as f64, sign * fa), (k as f64, sign * fk), (c as f64, sign * fc)];
        for (after, (lo, flo), (hi, fhi)) in [(false, (a, fa), (k, fk)), (true, (k, fk), (c, fc))] {
            if flo.signum() != fhi.signum() {
                continue;
            }
            if let Some((first, pm, second)) = pair_beside(three, after, sign, floor, tol, &MIDPOINT, &mut *at) {
                out.push(Crossing { at: first, before: Side::Sample(lo), after: Side::At(pm) });
                out.push(Crossing { at: second, before: Side::At(pm), after: Side::Sample(hi) });
            }
        }
    }
}

/// Sparing the minimisation of an interval clear at its midpoint, in this rule (the
/// 3-limb search has its own, which its tests turn off and count).
static MIDPOINT: Shortcut = Shortcut::new();

/// The two zeros of a load inside one of the two intervals beside a sampled minimum
/// (the one after it where `after`), whose ends have the sign `sign` (±1) of the load
/// at that minimum; `three` is the minimum and its neighbours, `(parameter, sign·f)`.
/// The interval is clear where the load at its midpoint shows it ([`stays_clear`], while
/// `midpoint` is on); else the signed load is minimised over it (a few parabolic steps
/// from the samples and the midpoint, then Brent's method, to `SCAN_TOL` of the
/// interval) until a point of the other sign (below `−floor`) is found or none is, and
/// the zeros are located either side of that point to `tol`. Returns `(first, point of
/// the other sign, second)`; `None` where the interval stays clear, or where the load
/// cannot be solved at some point of it (the interval is cut there). The one rule of
/// the 3-limb search and of [`crossings`].
pub(crate) fn pair_beside(
    three: [(f64, f64); 3],
    after: bool,
    sign: f64,
    floor: f64,
    tol: f64,
    midpoint: &Shortcut,
    mut at: impl FnMut(f64) -> Option<f64>,
) -> Option<(f64, f64, f64)> {
    let ((plo, slo), (phi, shi)) = if after { (three[1], three[2]) } else { (three[0], three[1]) };
    // The load itself at the ends (`sign` is ±1: exact).
    let (flo, fhi) = (sign * slo, sign * shi);
    let mid = 0.5 * (plo + phi);
    let y_mid = at(mid).map(|y| sign * y);
    if midpoint.on() && y_mid.is_some_and(|y| stays_clear(three, (plo, phi), (mid, y))) {
        return None;
    }
    midpoint.minimising();
    // An unsolvable midpoint cuts the interval.
    let y_mid = y_mid?;
    // One point of the other sign is enough; narrower excursions than the tolerance
    // are too narrow for any sampling.
    let xtol = SCAN_TOL * (phi - plo);
    let mut unsolved = false;
    let mut g = |p: f64| sign * read(&mut at, p, &mut unsolved, sign * f64::INFINITY);
    // Whether the load takes the other sign, from the three samples and the midpoint
    // in a few parabolic steps (most of these intervals stay clear).
    let known = [three[0], three[1], three[2], (mid, y_mid)];
    if parabolic_min_below(&known, plo, phi, xtol, -floor, &mut g).1 >= -floor {
        return None;
    }
    // Where it does, the point of the other sign the crossings are read from (and the
    // jumps read at) is Brent's.
    let (pm, least) = brent_min_below(plo, phi, xtol, -floor, &mut g);
    if least >= -floor || unsolved {
        return None;
    }
    let fm = sign * least;
    let first = interpolated_root(plo, pm, flo, fm, tol, |p| read(&mut at, p, &mut unsolved, 0.0));
    let second = interpolated_root(pm, phi, fm, fhi, tol, |p| read(&mut at, p, &mut unsolved, 0.0));
    (!unsolved).then_some((first, pm, second))
}

/// The load at `p`, else `missing`, marking the interval `unsolved`.
fn read(at: &mut impl FnMut(f64) -> Option<f64>, p: f64, unsolved: &mut bool, missing: f64) -> f64 {
    at(p).unwrap_or_else(|| {
        *unsolved = true;
        missing
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOL: f64 = 1e-12;

    /// `f(s)` sampled at `0, 1, …, n − 1`.
    fn sampled(n: usize, f: impl Fn(f64) -> f64) -> Vec<Option<f64>> {
        (0..n).map(|k| Some(f(k as f64))).collect()
    }

    #[test]
    fn a_sign_change_between_samples_is_one_crossing_at_the_root() {
        let f = |s: f64| s - 2.3;
        let found = crossings(&sampled(6, f), 1e-9, TOL, |s| Some(f(s)));
        let [c] = &found[..] else { panic!("{found:?}") };
        assert!((c.at - 2.3).abs() < 1e-10, "{c:?}");
        assert_eq!((c.before, c.after), (Side::Sample(2), Side::Sample(3)));
    }

    /// A load through zero on a sample (indeterminate there) changes sign between the
    /// samples either side of it: one crossing, at the sample, as where the zero lies
    /// between samples.
    #[test]
    fn a_zero_on_a_sample_is_a_crossing_between_its_neighbours() {
        let f = |s: f64| 0.5 * (s - 3.0);
        let loads = sampled(7, f);
        assert_eq!(loads[3], Some(0.0));
        let found = crossings(&loads, 1e-9, TOL, |s| Some(f(s)));
        let [c] = &found[..] else { panic!("{found:?}") };
        assert!((c.at - 3.0).abs() < 1e-10, "{c:?}");
        assert_eq!((c.before, c.after), (Side::Sample(2), Side::Sample(4)));
        // Shifted off the sample, the same crossing.
        let g = |s: f64| 0.5 * (s - 3.4);
        let found = crossings(&sampled(7, g), 1e-9, TOL, |s| Some(g(s)));
        assert_eq!(found.len(), 1);
        assert!((found[0].at - 3.4).abs() < 1e-10);
    }

    /// Two zeros between two samples of one sign, beside the sampled minimum of the
    /// magnitude: two crossings, the jump read at the point of the other sign between.
    #[test]
    fn two_zeros_between_samples_are_two_crossings() {
        let f = |s: f64| (s - 3.3) * (s - 3.6);
        let loads = sampled(8, f);
        assert!(loads[3].unwrap() > 0.0 && loads[4].unwrap() > 0.0);
        let found = crossings(&loads, 1e-9, TOL, |s| Some(f(s)));
        let [a, b] = &found[..] else { panic!("{found:?}") };
        assert!((a.at - 3.3).abs() < 1e-10 && (b.at - 3.6).abs() < 1e-10, "{found:?}");
        let Side::At(pm) = a.after else { panic!("{a:?}") };
        assert!(pm > 3.3 && pm < 3.6 && f(pm) < 0.0);
        assert_eq!((a.before, b.before, b.after), (Side::Sample(3), Side::At(pm), Side::Sample(4)));
    }

    /// An unsolvable sample cuts the path: opposite signs across it are no crossing;
    /// and an interval the load cannot be solved in at some point keeps none.
    #[test]
    fn a_gap_cuts_the_path() {
        let f = |s: f64| s - 3.0;
        let mut loads = sampled(7, f);
        loads[3] = None;
        assert!(crossings(&loads, 1e-9, TOL, |s| Some(f(s))).is_empty());
        let g = |s: f64| s - 2.5;
        let found = crossings(&sampled(6, g), 1e-9, TOL, |s| (!(2.45..=2.55).contains(&s)).then(|| g(s)));
        assert!(found.is_empty(), "{found:?}");
    }

    /// A load the same at every sample but for round-off (a slider's force along a
    /// translation that carries the whole mechanism) has no sampled minimum to look
    /// beside: nothing is solved between its samples.
    #[test]
    fn a_flat_load_is_not_searched_between_samples() {
        let loads: Vec<Option<f64>> = [2.0, 2.0 - 4e-16, 2.0, 2.0 + 4e-16, 2.0 - 4e-16].map(Some).to_vec();
        let mut solved = 0;
        assert!(
            crossings(&loads, 1e-9, TOL, |_| {
                solved += 1;
                Some(2.0)
            })
            .is_empty()
        );
        assert_eq!(solved, 0);
        // A true minimum is looked beside, on both sides.
        let loads: Vec<Option<f64>> = [2.0, 1.5, 2.0].map(Some).to_vec();
        let mut solved = 0;
        crossings(&loads, 1e-9, TOL, |s| {
            solved += 1;
            Some(1.5 + 0.5 * (s - 1.0) * (s - 1.0))
        });
        assert!(solved >= 2, "{solved}");
    }

    /// A load that stays clear of zero, dipping between samples, has no crossing.
    #[test]
    fn a_dip_that_keeps_its_sign_is_no_crossing() {
        let f = |s: f64| 0.2 + (s - 3.4) * (s - 3.4);
        assert!(crossings(&sampled(8, f), 1e-9, TOL, |s| Some(f(s))).is_empty());
    }
}
