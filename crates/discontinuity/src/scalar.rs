//! Switches of a scalar load, `f_Rj·y_j` (docs/model.md §8): its take-up (`r_axial`,
//! and in the 3-limb kinds `r_angular`, whose moment is `|A_j − B_j|·(f_Rj·y_j)·u_j`)
//! flips wherever it changes sign.

use clearance_solver::Workspace;

use crate::minimise::brent_min_below;
use crate::search::{Segment, Side, Solved};
use crate::trace::{Decider, min_bit, neg_bit};
use crate::{LOCATE_TOL, SCAN_TOL, axial, brent_root};

/// One zero of the load, with the points either side that the jump is read between.
pub(crate) struct Crossing {
    pub p: f64,
    pub before: Side,
    pub after: Side,
}

/// The zeros of `f_Rj·y_j` along a segment, in order: one between consecutive
/// determinate samples of opposite signs, and two where an interval beside a
/// sampled minimum of its magnitude (with ends of one sign) holds an extremum of
/// the opposite sign, determinate there, as a finer sampling would show.
pub(crate) fn crossings(solved: &mut Solved<'_>, segment: &Segment<'_>, j: usize, ws: &mut Workspace) -> Vec<Crossing> {
    let ev = solved.ev;
    let (model, floor) = (ev.model, ev.model.indeterminate_floor);
    let f = |solved: &mut Solved<'_>, k: usize, ws: &mut Workspace| axial(&solved.reactions(k, ws), model, j);
    // An unsolvable point between samples reads zero: the root is where it starts.
    let f_at = |p: f64, ws: &mut Workspace| ev.reactions_at(p, ws).map_or(0.0, |r| axial(&r, model, j));
    let negative = |k: usize| segment.has(k, neg_bit(j));
    let mut out = Vec::new();
    for (a, b) in segment.pairs() {
        if negative(a) != negative(b) {
            let (fa, fb) = (f(solved, a, ws), f(solved, b, ws));
            let p = brent_root(ev.param(a), ev.param(b), fa, fb, LOCATE_TOL, |p| f_at(p, ws));
            out.push(Crossing { p, before: Side::Sample(a), after: Side::Sample(b) });
        }
    }
    for (a, k, c) in segment.triples() {
        if !segment.has(k, min_bit(Decider::Axial, j)) {
            continue;
        }
        let here = f(solved, k, ws).abs();
        if !(here < f(solved, a, ws).abs() && here <= f(solved, c, ws).abs()) {
            continue;
        }
        for (lo, hi) in [(a, k), (k, c)] {
            if negative(lo) != negative(hi) {
                continue;
            }
            // The load's sign at both ends: look for the extremum of the other sign.
            let sign = if negative(k) { -1.0 } else { 1.0 };
            let (plo, phi) = (ev.param(lo), ev.param(hi));
            // One point of the other sign is enough; narrower excursions than the
            // tolerance are too narrow for any sampling.
            let (pm, least) = brent_min_below(plo, phi, SCAN_TOL * (phi - plo), -floor, |p| {
                ev.reactions_at(p, ws).map_or(f64::INFINITY, |r| sign * axial(&r, model, j))
            });
            if least >= -floor {
                continue;
            }
            let fm = sign * least;
            let (flo, fhi) = (f(solved, lo, ws), f(solved, hi, ws));
            let first = brent_root(plo, pm, flo, fm, LOCATE_TOL, |p| f_at(p, ws));
            let second = brent_root(pm, phi, fm, fhi, LOCATE_TOL, |p| f_at(p, ws));
            out.push(Crossing { p: first, before: Side::Sample(lo), after: Side::At(pm) });
            out.push(Crossing { p: second, before: Side::At(pm), after: Side::Sample(hi) });
        }
    }
    out.sort_by(|x, y| x.p.total_cmp(&y.p));
    out
}
