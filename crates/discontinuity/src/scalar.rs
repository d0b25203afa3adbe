//! Switches of a scalar load, `f_Rj·y_j` (docs/model.md §8): its take-up (`r_axial`,
//! and in the 3-limb kinds `r_angular`, whose moment is `|A_j − B_j|·(f_Rj·y_j)·u_j`)
//! flips wherever it changes sign.

use clearance_solver::{JointReactions, Workspace};

use crate::minimise::{interpolated_root_from, inverse_interpolation};
use crate::scalar_load::pair_beside;
use crate::search::{Segment, Side, Solved};
use crate::shortcut::Shortcut;
use crate::trace::{Decider, Trace, min_bit, neg_bit};
use crate::{LOCATE_TOL, axial};

/// One zero of the load, with the points either side that the jump is read between,
/// and the reactions there (for its margin, under each kind it decides).
pub(crate) struct Crossing {
    pub p: f64,
    pub reactions: Option<JointReactions>,
    pub before: Side,
    pub after: Side,
}

/// The zeros of `f_Rj·y_j` along a segment, in order: one between consecutive
/// determinate samples of opposite signs, and two where an interval beside a
/// sampled minimum of its magnitude (with ends of one sign) holds an extremum of
/// the opposite sign, determinate there, as a finer sampling would show.
pub(crate) fn crossings(
    solved: &mut Solved<'_>,
    segment: &Segment<'_, impl Fn(usize) -> Trace>,
    j: usize,
    ws: &mut Workspace,
) -> Vec<Crossing> {
    let ev = solved.ev;
    let (model, floor) = (ev.model, ev.model.indeterminate_floor);
    let f = |solved: &mut Solved<'_>, k: usize, ws: &mut Workspace| axial(solved.forces(k, ws), model, j);
    // An unsolvable point between samples reads zero for the root finder; a zero whose
    // search met one is dropped, as the interval is cut there (docs/model.md §8).
    let f_at = |p: f64, ws: &mut Workspace| ev.reactions_at(p, ws).map_or(0.0, |r| axial(&r, model, j));
    let negative = |k: usize| segment.has(k, neg_bit(j));
    let mut out = Vec::new();
    for (a, b) in segment.pairs() {
        if negative(a) != negative(b) {
            let (fa, fb) = (f(solved, a, ws), f(solved, b, ws));
            // The first step from the samples either side too (the pass has them).
            let mut points = [(0.0, 0.0); 4];
            let mut n = 0;
            for k in segment.before(a).take(1).chain([a, b]).chain(segment.after(b + 1).take(1)) {
                points[n] = (ev.param(k), f(solved, k, ws));
                n += 1;
            }
            let guess = inverse_interpolation(&points[..n]);
            let mark = ev.unsolved_mark();
            let p = interpolated_root_from(ev.param(a), ev.param(b), fa, fb, guess, LOCATE_TOL, |p| f_at(p, ws));
            // Mostly the point the root finder evaluated last, so solved already.
            let reactions = ev.reactions_at(p, ws);
            if ev.cut_since(mark, ev.param(a), ev.param(b)) {
                continue;
            }
            out.push(Crossing { p, reactions, before: Side::Sample(a), after: Side::Sample(b) });
        }
    }
    for (a, k, c) in segment.triples() {
        if !segment.has(k, min_bit(Decider::Axial, j, segment.along)) {
            continue;
        }
        let here = f(solved, k, ws).abs();
        if !(here < f(solved, a, ws).abs() && here <= f(solved, c, ws).abs()) {
            continue;
        }
        // The load's sign at the sample: look for an extremum of the other sign.
        let sign = if negative(k) { -1.0 } else { 1.0 };
        let samples = [a, k, c].map(|i| (ev.param(i), sign * f(solved, i, ws)));
        for (after, lo, hi) in [(false, a, k), (true, k, c)] {
            if negative(lo) != negative(hi) {
                continue;
            }
            let at = |p: f64| ev.reactions_at(p, ws).map(|r| axial(&r, model, j));
            let Some((first, pm, second)) = pair_beside(samples, after, sign, floor, LOCATE_TOL, &MIDPOINT, at) else {
                continue;
            };
            // Mostly points the root finders evaluated last, so solved already.
            let (at_first, at_second) = (ev.reactions_at(first, ws), ev.reactions_at(second, ws));
            out.push(Crossing { p: first, reactions: at_first, before: Side::Sample(lo), after: Side::At(pm) });
            out.push(Crossing { p: second, reactions: at_second, before: Side::At(pm), after: Side::Sample(hi) });
        }
    }
    out.sort_by(|x, y| x.p.total_cmp(&y.p));
    out
}

/// Sparing the minimisation of an interval clear at its midpoint ([`stays_clear`]).
static MIDPOINT: Shortcut = Shortcut::new();

/// How far the load at an interval's midpoint may stray from the parabola through the
/// three samples, as a fraction of the sampled minimum, for the parabola to speak for
/// the interval.
const FIT: f64 = 0.1;

/// The lowest the interval may come, as a fraction of the sampled minimum, for it to be
/// clear of the other sign without a minimisation.
const CLEAR: f64 = 0.5;

/// Whether the interval `(plo, phi)` beside the sampled minimum (the middle of
/// `samples`, three `(param, sign·f)` with the sample's sign, so that the minimum
/// is positive) is clear of the other sign, from the load at its midpoint `mid`:
/// that is the sampling halved, and a finer sampling shows a pair of crossings as a
/// dip towards zero. Clear when the midpoint's load lies on the parabola through the
/// three samples (within [`FIT`] of the minimum) and neither the parabola over the
/// interval nor that load, less their disagreement, comes below [`CLEAR`] of the
/// minimum. Otherwise the interval is minimised (most stay clear: 99 % of the sampled
/// minima of a 3-D grid are more than 8 times as far from zero as their neighbours'
/// second difference).
pub(crate) fn stays_clear(samples: [(f64, f64); 3], (plo, phi): (f64, f64), (mid, y_mid): (f64, f64)) -> bool {
    let [(x0, y0), (x1, y1), (x2, y2)] = samples;
    let d01 = (y1 - y0) / (x1 - x0);
    let d012 = ((y2 - y1) / (x2 - x1) - d01) / (x2 - x0);
    let parabola = |x: f64| y0 + (x - x0) * (d01 + (x - x1) * d012);
    let mut lowest = parabola(plo).min(parabola(phi));
    if d012 > 0.0 {
        let vertex = 0.5 * (x0 + x1) - d01 / (2.0 * d012);
        if vertex > plo && vertex < phi {
            lowest = lowest.min(parabola(vertex));
        }
    }
    let off = (y_mid - parabola(mid)).abs();
    let floor = y1 * CLEAR;
    y1 > 0.0 && off <= FIT * y1 && lowest - off >= floor && y_mid - off >= floor
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The midpoint check changes the work, not the switches: on a 3-D grid of every
    /// kind with an added mass, and on the Θ-line whose axial load crosses zero twice
    /// between two samples (tests/dips_between_samples.rs), every switch of the full
    /// minimisation is found, at the same place, and the grid minimises a tenth of the
    /// intervals or fewer.
    #[test]
    fn the_midpoint_check_loses_no_switch() {
        let grid = "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
            [mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
            [grid]\nz = { start = 1.95, stop = 2.15, n = 5 }\npsi = { start = -0.5, stop = 0.5, n = 41 }\n\
            theta = { start = -0.5, stop = 0.5, n = 37 }\n";
        let [(all, minimised), (quick, fewer)] = MIDPOINT.both_ways(grid);
        let axial = all.iter().filter(|d| d.kind == clearance_model::ClearanceKind::RAxial).count();
        assert!(axial > 10, "{axial} axial switches to lose");
        assert_eq!(all, quick);
        assert!(fewer * 10 <= minimised, "{fewer} of {minimised} intervals minimised");
        let line = "[clearance]\nr_axial = 1e-4\n[grid]\nz = 2.05\npsi = -0.1\n\
            theta = { start = -0.5, stop = 0.5, n = 11 }\n";
        let [(all, _), (quick, _)] = MIDPOINT.both_ways(line);
        assert_eq!(all, quick);
        assert!(all.len() >= 2, "{all:?}");
    }

    /// Three samples of `y` at −1, 0, 1, the interval (0, 1) and its midpoint's value.
    fn clear(y: impl Fn(f64) -> f64) -> bool {
        stays_clear([-1.0, 0.0, 1.0].map(|x| (x, y(x))), (0.0, 1.0), (0.5, y(0.5)))
    }

    #[test]
    fn a_parabola_far_from_zero_is_clear() {
        assert!(clear(|x| 1.0 + 0.3 * x * x));
        // Its vertex inside the interval, at 0.9 of the sampled minimum.
        assert!(clear(|x| 0.9 + 0.4 * (x - 0.5) * (x - 0.5)));
    }

    #[test]
    fn a_dip_the_samples_do_not_show_is_minimised() {
        // The midpoint falls off the samples' parabola: the interval hides a dip.
        assert!(!clear(|x| 1.0 + 0.3 * x * x - if x == 0.5 { 0.5 } else { 0.0 }));
        // A narrower dip, 15 % of the minimum at the midpoint: still more than FIT.
        assert!(!clear(|x| 1.0 + 0.3 * x * x - (-(x - 0.5) * (x - 0.5) / 0.001).exp() * 0.15));
    }

    #[test]
    fn a_parabola_that_comes_near_zero_is_minimised() {
        // The two-crossings case of a Θ-line: the samples' parabola itself reaches zero.
        assert!(!clear(|x| 0.05 + 0.5 * (x - 0.4) * (x - 0.4) - 0.07));
        // Within half of the minimum, though not below zero.
        assert!(!clear(|x| 1.0 + 2.0 * (x - 0.5) * (x - 0.5) - 0.55));
        // A load of the other sign at a neighbour (a sign change beside the sample).
        assert!(!clear(|x| if x < -0.5 { -1.0 } else { 1.0 + x * x }));
    }
}
