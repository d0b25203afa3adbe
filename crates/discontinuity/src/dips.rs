//! Switches of a vector load, `f_Sj` or `f⊥j` (docs/model.md §8): where its magnitude
//! dips below `discontinuity_load_fraction·W` and its direction swings round by more
//! than 90° across the dip, read where the magnitude has risen back to twice the
//! minimum, located between samples ([`crate::vector_load::locate`]).

use clearance_solver::Workspace;

use crate::search::{Segment, Side, Solved};
use crate::trace::{Decider, Trace, min_bit, turn_bit};
use crate::vector_load::locate;
use crate::{Discontinuity, LOCATE_TOL, SCAN_TOL, brent_min, brent_root, dot, vector, vector_min, vector_polish};

/// A refined minimum of the magnitude lying between samples `lo` and `hi` (the
/// determinate samples either side of it; for a minimum at a sample, its neighbours).
#[derive(Clone, Copy, Debug)]
struct Dip {
    p: f64,
    /// The magnitude there.
    m: f64,
    lo: usize,
    hi: usize,
}

/// A refined minimum closer than this (relative to its interval) to an end of its
/// interval is that end's: the magnitude falls all the way to it (ten times the
/// minimiser's tolerance).
const EDGE: f64 = 10.0 * SCAN_TOL;

/// The least half-width of [`vector_polish`]'s stencil, and the step of the
/// five-point difference of `|f|²` that polishes a minimum where it cannot: wide
/// enough that the round-off of the loads (`ε·|f|/h` in the slope) moves the point
/// by less than 1e-10 on the shallowest dips of the suite, narrow enough that the
/// model's truncation (`h²`) does not.
const DIFF_STEP: f64 = 1e-5;

pub(crate) fn switches(
    solved: &mut Solved<'_>,
    segment: &Segment<'_, impl Fn(usize) -> Trace>,
    d: Decider,
    j: usize,
    ws: &mut Workspace,
    out: &mut Vec<Discontinuity>,
) {
    let ev = solved.ev;
    let (model, kind) = (ev.model, d.kind());
    let mark = ev.unsolved_mark();
    let load = |solved: &mut Solved<'_>, k: usize, ws: &mut Workspace| vector(solved.forces(k, ws), model, kind, j);
    let mag = |solved: &mut Solved<'_>, k: usize, ws: &mut Workspace| crate::norm(load(solved, k, ws));
    let at = |p: f64, ws: &mut Workspace| ev.reactions_at(p, ws).map(|r| vector(&r, model, kind, j));
    let squared = |p: f64, ws: &mut Workspace| at(p, ws).map(|v| dot(v, v));
    // The least magnitude on the interval between samples `lo` and `hi`, from the
    // loads there and at `third` (a sample beyond it, or else the interval's middle).
    let min_on = |solved: &mut Solved<'_>, lo: usize, hi: usize, third: Option<usize>, ws: &mut Workspace| {
        let (plo, phi) = (ev.param(lo), ev.param(hi));
        let third = match third {
            Some(k) => Some((ev.param(k), load(solved, k, ws))),
            None => at(0.5 * (plo + phi), ws).map(|v| (0.5 * (plo + phi), v)),
        };
        let ends = ((plo, load(solved, lo, ws)), (phi, load(solved, hi, ws)));
        let xtol = SCAN_TOL * (phi - plo);
        if let Some((p, fp)) = third.and_then(|third| vector_min(ends.0, ends.1, third, xtol, |p| at(p, ws))) {
            return (p, dot(fp, fp));
        }
        // The squared magnitude has the same minimum and is smooth there (the
        // magnitude itself is a V when the load passes near zero).
        brent_min(plo, phi, xtol, |p| squared(p, ws).unwrap_or(f64::INFINITY))
    };
    let edge = |lo: usize, hi: usize| EDGE * (ev.param(hi) - ev.param(lo));
    let inside = |p: f64, lo: usize, hi: usize| p > ev.param(lo) + edge(lo, hi) && p < ev.param(hi) - edge(lo, hi);

    // Every interior sampled minimum, refined on each side on its own. No minimum is
    // set aside for the directions at its samples: a switch's directions are read at
    // points located between samples, which the sample directions do not tell.
    let mut minima = Vec::new();
    let mut dips = Vec::new();
    for (a, k, c) in segment.triples() {
        if !segment.has(k, min_bit(d, j, segment.along)) {
            continue;
        }
        let here = mag(solved, k, ws);
        if !(here < mag(solved, a, ws) && here <= mag(solved, c, ws)) {
            continue;
        }
        minima.push(k);
        let (left, right) = (min_on(solved, a, k, Some(c), ws), min_on(solved, k, c, Some(a), ws));
        let (in_left, in_right) = (inside(left.0, a, k), inside(right.0, k, c));
        if in_left {
            dips.push(Dip { p: left.0, m: left.1.sqrt(), lo: a, hi: k });
        }
        if in_right {
            dips.push(Dip { p: right.0, m: right.1.sqrt(), lo: k, hi: c });
        }
        if !in_left && !in_right {
            // Both sides fall towards the sample: the minimum is there.
            let (p, m2) = if left.1 <= right.1 { left } else { right };
            if (p - ev.param(k)).abs() <= edge(a, k).max(edge(k, c)) {
                dips.push(Dip { p, m: m2.sqrt(), lo: a, hi: c });
            }
        }
    }
    // Every other interval whose end directions differ by more than 90°: a dip
    // between monotone samples.
    for (a, b) in segment.pairs() {
        if !segment.has(a, turn_bit(d, j, segment.along))
            || minima.binary_search(&a).is_ok()
            || minima.binary_search(&b).is_ok()
        {
            continue;
        }
        if dot(load(solved, a, ws), load(solved, b, ws)) >= 0.0 {
            continue;
        }
        let (p, m2) = min_on(solved, a, b, None, ws);
        if inside(p, a, b) {
            dips.push(Dip { p, m: m2.sqrt(), lo: a, hi: b });
        }
    }
    dips.sort_by(|x, y| x.p.total_cmp(&y.p));

    let floor = model.indeterminate_floor;
    let mut found = Vec::new();
    for dip in &dips {
        if dip.m >= ev.opts.dip_threshold {
            continue;
        }
        // Where the magnitude has risen back to twice the minimum (never less than
        // twice the noise floor: at a load through zero the minimum is round-off),
        // located between the sample where the walk gets there and the point before
        // it; else at the sampled maximum before it falls again (beyond, a direction
        // belongs to the next dip), else at the segment's end.
        let twice = 2.0 * dip.m.max(floor);
        let stop = |from: usize, next: Option<usize>, solved: &mut Solved<'_>, ws: &mut Workspace| {
            let here = mag(solved, from, ws);
            if here >= twice {
                return true;
            }
            let Some(next) = next else { return true };
            let (p, q) = (ev.param(from), ev.param(next));
            let (lo, hi) = (p.min(q), p.max(q));
            // `dips` is sorted: the first one beyond `lo`.
            let beyond = dips.partition_point(|other| other.p <= lo);
            here > mag(solved, next, ws) || dips.get(beyond).is_some_and(|other| other.p < hi)
        };
        // The point a walk's stop gives: the located one where the magnitude reaches
        // `twice` (the sample itself where that point cannot be solved), else the sample.
        let read = |(k, previous): (usize, Option<usize>), solved: &mut Solved<'_>, ws: &mut Workspace| {
            let here = load(solved, k, ws);
            if crate::norm(here) < twice {
                return (Side::Sample(k), here);
            }
            let inner = match previous {
                Some(i) => (ev.param(i), mag(solved, i, ws)),
                None => (dip.p, dip.m),
            };
            match locate(inner, (ev.param(k), here), twice, LOCATE_TOL, |p| at(p, ws)) {
                Some((p, fp)) if p != ev.param(k) => (Side::At(p), fp),
                _ => (Side::Sample(k), here),
            }
        };
        let left = walk(segment.before(dip.lo + 1), |i, next| stop(i, next, solved, ws));
        let right = walk(segment.after(dip.hi), |i, next| stop(i, next, solved, ws));
        let ((left, at_left), (right, at_right)) = (read(left, solved, ws), read(right, solved, ws));
        if dot(at_left, at_right) >= 0.0 {
            continue;
        }
        let (lo, hi) = (ev.param(dip.lo), ev.param(dip.hi));
        let width = 2.0 * SCAN_TOL * (hi - lo);
        let vector =
            at(dip.p, ws).and_then(|fp| vector_polish(dip.p, fp, width.max(DIFF_STEP), (lo, hi), |p| at(p, ws)));
        let (before, after) = (left.errors(solved, ws), right.errors(solved, ws));
        found.push((
            dip,
            match vector {
                // The load at the point from the polish's model: no solve of its own.
                Some((p, fp)) => ev.record_margin(kind, j, p, crate::norm(fp), &before, &after),
                None => {
                    let p = polish(dip.p, lo, hi, width, |p| squared(p, ws));
                    ev.record(kind, j, p, ev.reactions_at(p, ws), &before, &after)
                }
            },
        ));
    }
    // A dip between samples where any step of the rule met a point it could not solve
    // (a dip at a sample: on either side of it) is no switch: the path is cut there, as
    // by an unsolvable sample (docs/model.md §8). Its least magnitude may be the edge of
    // the stretch the robot cannot follow, not a minimum of the load.
    let cut = |dip: &Dip| ev.cut_since(mark, ev.param(dip.lo), ev.param(dip.hi));
    out.extend(found.into_iter().filter(|(dip, _)| !cut(dip)).map(|(_, s)| s));
}

/// The first of `side` (not empty) where `stops(i, the one after i)`, and the one
/// before it (`None`: the first).
fn walk(
    mut side: impl Iterator<Item = usize>,
    mut stops: impl FnMut(usize, Option<usize>) -> bool,
) -> (usize, Option<usize>) {
    let mut here = side.next().expect("a determinate sample on either side");
    let mut previous = None;
    loop {
        let next = side.next();
        if stops(here, next) {
            return (here, previous);
        }
        previous = Some(here);
        here = next.expect("the last sample stops");
    }
}

/// The minimum near `p` (in `[lo, hi]`) as the root of `d|f|²/ds`: Brent's
/// minimiser resolves it only to about `√ε` of the dip's width where the dip is
/// shallow. `p` itself where no sign change of the derivative brackets it.
fn polish(p: f64, lo: f64, hi: f64, width: f64, mut squared: impl FnMut(f64) -> Option<f64>) -> f64 {
    let h = DIFF_STEP;
    let mut slope = |s: f64| -> Option<f64> {
        let (f2, f1) = (squared(s + 2.0 * h)?, squared(s + h)?);
        let (b1, b2) = (squared(s - h)?, squared(s - 2.0 * h)?);
        Some((8.0 * (f1 - b1) - (f2 - b2)) / (12.0 * h))
    };
    let mut width = width.max(1e-7);
    loop {
        let (a, b) = ((p - width).max(lo), (p + width).min(hi));
        let (Some(ga), Some(gb)) = (slope(a), slope(b)) else { return p };
        if ga <= 0.0 && gb >= 0.0 {
            let mut failed = false;
            let root = brent_root(a, b, ga, gb, LOCATE_TOL, |s| {
                slope(s).unwrap_or_else(|| {
                    failed = true;
                    0.0
                })
            });
            return if failed { p } else { root };
        }
        if a <= lo && b >= hi {
            return p;
        }
        width *= 16.0;
    }
}
