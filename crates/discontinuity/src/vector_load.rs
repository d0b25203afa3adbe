//! The switches of one vector load along one path (docs/model.md §8), whatever the
//! mechanism: the load's samples in path order and a way to evaluate it between them
//! are all it needs.
//!
//! A path is read as the load at its samples, `&[`[`SampledLoad`]`]` (the magnitude
//! and the vector; `None` where the load is indeterminate, within the noise floor, or
//! the pose unsolvable: such a sample is a gap that a walk does not cross), and a
//! closure `FnMut(f64) -> Option<[f64; 3]>` that solves the load at any path
//! parameter, in sample steps (sample `k` at `k as f64`; `None` where the pose there
//! is unsolvable). A 2-D load (a force in a plane, or a couple about a fixed axis
//! written as a vector) is a 3-D one with zeros.
//!
//! The rule, step by step, each step a public function so that a search can take
//! over any of them:
//!
//! 1. [`candidates`]: the intervals `(k, k + 1)` to refine: both beside each interior
//!    sampled minimum of the magnitude ([`is_min`]: not a flat load's round-off), each
//!    on its own (two dips either side of one sample are two switches, as a finer
//!    sampling would show), and every
//!    interval whose end directions differ by more than 90° (a dip between monotone
//!    samples);
//! 2. [`refine`]: each interval's least magnitude, from the load vectors
//!    ([`vector_min`], Brent's minimiser of the magnitude where that does not settle);
//! 3. [`select`]: the distinct interior minima among them;
//! 4. [`polish`]: each minimum as the root of `f·df/ds` ([`vector_polish`]); one at or
//!    above the threshold is not a switch (one refined to 1.1 times the threshold or
//!    more is not polished: the polish moves its value by round-off only);
//! 5. [`readings`]: where the take-up directions are compared. On each side a walk
//!    ([`walk`]) goes out from the minimum `m` over samples whose magnitude does not
//!    fall, to the first whose magnitude has risen to `reach = 2·max(m, floor)`; the
//!    point where the magnitude reaches `reach` is then *located* between that sample
//!    and the walk's point before it (the previous sample, or the minimum itself), as
//!    a root of `|f| − reach` ([`locate`]). Where the walk does not get there, the
//!    direction is read at the sample it stops on: the sampled maximum where the
//!    magnitude falls again (a direction read beyond it belongs to the next dip), or
//!    the last determinate sample before a gap or the path's end;
//! 6. [`turns`]: a switch where the two directions differ by more than 90°.
//!
//! [`switches`] runs them all; [`path_switches`] runs them on a path whose samples tell
//! an indeterminate load (within the floor: left out, its neighbours consecutive) from
//! a gap. Read at a sample rather than located, the verdict of step 6 changes with the
//! sampling (a 6-UPS grid line gave a switch at 4 and 13 samples, none at 7 and 49);
//! located, it is a property of the load.
//!
//! No step skips an interval on the strength of the sample directions: the points
//! where the directions are compared lie between samples, so agreeing sample
//! directions do not rule a switch out.

use nalgebra::Vector3;

use crate::minimise::FLAT;
use crate::{brent_min, interpolated_root, vector_min, vector_polish};

/// The load at one sample of a path: its magnitude and its vector, `None` where it is
/// indeterminate (within the noise floor) or the pose unsolvable.
pub type SampledLoad = Option<(f64, Vector3<f64>)>;

/// The thresholds of the rule for one load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VectorRule {
    /// `discontinuity_load_fraction·W` (N; for a couple, times 1 m): a refined minimum
    /// at or above it is not a switch.
    pub threshold: f64,
    /// The noise floor below which the load is indeterminate: "twice the minimum" is
    /// never less than twice this (a load through zero has its minimum at round-off,
    /// where its direction is noise).
    pub floor: f64,
}

impl VectorRule {
    /// The magnitude at which the directions of a minimum `m` are read:
    /// `2·max(m, floor)`.
    pub fn reach(&self, m: f64) -> f64 {
        2.0 * m.max(self.floor)
    }
}

/// Where a switch's direction is read on one side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// The path parameter, in sample steps.
    pub at: f64,
    /// The load there.
    pub load: [f64; 3],
    /// The sample the reading is at, where it is at one (a walk that stopped short of
    /// `reach`, or a located point that fell on its sample): a caller may read that
    /// sample's stored values rather than solve the point again.
    pub sample: Option<usize>,
}

impl Reading {
    fn at_sample(k: usize, load: Vector3<f64>) -> Self {
        Reading { at: k as f64, load: [load.x, load.y, load.z], sample: Some(k) }
    }
}

/// One switch of a vector load along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VectorSwitch {
    /// The path parameter of the minimum, in sample steps, to round-off.
    pub at: f64,
    /// The load's magnitude there (the contact margin).
    pub margin: f64,
    /// Where the direction is read before the minimum (lower parameter) and after it:
    /// the jump of the take-up's error is read between these two points.
    pub before: Reading,
    pub after: Reading,
}

/// A minimum of the magnitude found by refining the interval `(interval, interval + 1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dip {
    /// The interval's first sample.
    pub interval: usize,
    /// Where the magnitude is least (sample steps).
    pub at: f64,
    /// The magnitude there.
    pub margin: f64,
    /// The load at `at`, where the refinement evaluated it.
    pub load: Option<[f64; 3]>,
}

/// Which way a walk goes from a minimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Towards lower parameters.
    Before,
    /// Towards higher parameters.
    After,
}

/// The sample a [`walk`] stops on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stop {
    pub sample: usize,
    /// The walk's sample before it (`None`: the walk stopped on its first sample, so
    /// the point before it is the minimum itself).
    pub previous: Option<usize>,
    /// Whether its magnitude has risen to `reach` (else it is a sampled maximum, or
    /// the last determinate sample before a gap or the path's end).
    pub reached: bool,
}

/// Path parameters closer than this (in sample steps) are one minimum.
const SAME: f64 = 1e-6;

/// The location tolerance in the path parameter (sample steps) of a point where the
/// magnitude reaches twice the minimum, and of the fallback minimiser.
const LOCATE_STEPS: f64 = 1e-10;

/// The half-width (in samples) of the stencil that polishes a minimum
/// ([`vector_polish`]).
const POLISH_WIDTH: f64 = 1e-3;

/// The tolerance (in samples) of the first location of a minimum ([`vector_min`]),
/// which [`vector_polish`] takes to round-off.
const SCAN_TOL: f64 = 1e-6;

/// A refined minimum within this of an interval's end sits on that sample.
const END: f64 = 1e-7;

/// A refined minimum at this many times the threshold or more is not a switch, and
/// is not polished: the polish moves the point by about `√ε` of the dip's width
/// ([`vector_polish`]) and the magnitude by far less than a tenth (the refined point
/// is an evaluated one within [`SCAN_TOL`] of the model's minimum).
const UNPOLISHED: f64 = 1.1;

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The switches of one load along one path: every step of the rule (module
/// documentation), in order of the refined intervals. `at` evaluates the load at any
/// path parameter (sample steps); `loads` are its samples.
///
/// An interval between two solvable samples where the load cannot be solved at some
/// point (the path leaves the workspace between the samples: a joint passes its range
/// and comes back) is cut there, as an unsolvable sample cuts the path: no dip refined,
/// polished or read in it is a switch. Its least magnitude would lie at the edge of the
/// unsolvable stretch, a minimum of where the path can be followed, not of the load.
pub fn switches(
    loads: &[SampledLoad],
    rule: &VectorRule,
    mut at: impl FnMut(f64) -> Option<[f64; 3]>,
) -> Vec<VectorSwitch> {
    // The points where the load could not be solved, to cut their intervals.
    let unsolved = std::cell::RefCell::new(Vec::new());
    let mut at = |p: f64| {
        let f = at(p);
        if f.is_none() {
            unsolved.borrow_mut().push(p);
        }
        f
    };
    let cut = |k: usize| unsolved.borrow().iter().any(|&p| p > k as f64 && p < (k + 1) as f64);
    // A dip in a cut interval, or at a sample beside one (the end of a piece, as a sample
    // beside an unsolvable one is: not an interior minimum).
    let touches_cut = |d: &Dip| {
        let e = d.at.round();
        cut(d.interval) || ((d.at - e).abs() < END && ((e >= 1.0 && cut(e as usize - 1)) || cut(e as usize)))
    };
    let mut refined: Vec<Dip> = candidates(loads).into_iter().map(|k| refine(loads, k, &mut at)).collect();
    refined.retain(|d| !touches_cut(d));
    let mut out = Vec::new();
    for dip in select(&refined, loads) {
        if dip.margin >= UNPOLISHED * rule.threshold {
            continue;
        }
        let (x, m) = polish(&dip, &mut at);
        if m >= rule.threshold {
            continue;
        }
        let Some((before, after)) = readings(loads, x, m, rule.reach(m), &mut at) else { continue };
        // The polish and the readings may have met a cut too, solving in the interval.
        if turns(&before, &after) && !touches_cut(&dip) {
            out.push(VectorSwitch { at: x, margin: m, before, after });
        }
    }
    out
}

/// [`switches`] on a path's samples as solved: `None` a gap (the pose cannot be solved,
/// or the load is not the search's there), which no walk crosses; a load whose
/// magnitude is at or below `rule.floor` indeterminate: its direction is undefined, so
/// the sample is left out and its neighbours are consecutive (docs/model.md §8: a load
/// through zero on a sample, such as an axial load on a symmetry plane, still switches
/// there). The rule runs on the samples kept, in order; a point between two kept
/// samples is the path parameter in linear proportion between theirs. The switches are
/// in the path's parameter and its samples' indices. Without an indeterminate sample,
/// [`switches`] itself.
pub fn path_switches(
    loads: &[SampledLoad],
    rule: &VectorRule,
    mut at: impl FnMut(f64) -> Option<[f64; 3]>,
) -> Vec<VectorSwitch> {
    let indeterminate = |l: &SampledLoad| l.is_some_and(|(m, _)| m <= rule.floor);
    if !loads.iter().any(indeterminate) {
        return switches(loads, rule, at);
    }
    let kept: Vec<usize> = (0..loads.len()).filter(|&k| !indeterminate(&loads[k])).collect();
    if kept.len() < 2 {
        return Vec::new();
    }
    let loads: Vec<SampledLoad> = kept.iter().map(|&k| loads[k]).collect();
    // `x − i` is exact for `x` in `[i, i + 1]`: with unit spacing this is `x`.
    let param = |x: f64| {
        let i = (x.floor().max(0.0) as usize).min(kept.len() - 2);
        let (a, b) = (kept[i] as f64, kept[i + 1] as f64);
        a + (x - i as f64) * (b - a)
    };
    let on_path = |r: Reading| Reading { at: param(r.at), sample: r.sample.map(|k| kept[k]), ..r };
    switches(&loads, rule, |x| at(param(x)))
        .into_iter()
        .map(|s| VectorSwitch { at: param(s.at), before: on_path(s.before), after: on_path(s.after), ..s })
        .collect()
}

/// Whether sample `k` is an interior local minimum of the magnitude among
/// determinate neighbours (strictly below the one before, so that a flat stretch is
/// not a minimum at every sample), and not by round-off alone: where both neighbours
/// are within 1e-12 of its magnitude the load is flat there (a leg that an actuated
/// translation carries unchanged has the same load, to round-off, at every sample of
/// the line), which is no more a minimum than a monotone stretch is.
pub fn is_min(loads: &[SampledLoad], k: usize) -> bool {
    if k == 0 || k + 1 >= loads.len() {
        return false;
    }
    match (loads[k - 1], loads[k], loads[k + 1]) {
        (Some((a, _)), Some((m, _)), Some((b, _))) => m < a && m <= b && !(a - m <= FLAT * a && b - m <= FLAT * b),
        _ => false,
    }
}

/// The intervals `(k, k + 1)` to refine, by their first sample: both beside each
/// interior sampled minimum, and every interval whose end directions differ by more
/// than 90° although neither end is a sampled minimum (a dip between monotone samples).
pub fn candidates(loads: &[SampledLoad]) -> Vec<usize> {
    let mut out = Vec::new();
    for k in 0..loads.len().saturating_sub(1) {
        let (Some((_, a)), Some((_, b))) = (loads[k], loads[k + 1]) else { continue };
        if is_min(loads, k) || is_min(loads, k + 1) || a.dot(&b) < 0.0 {
            out.push(k);
        }
    }
    out
}

/// The least magnitude on the interval `(k, k + 1)` (both ends determinate): by
/// [`vector_min`] from the loads at its ends and at the sample beyond the sampled
/// minimum it borders (else at its middle), else, where that does not settle, by
/// Brent's minimiser of the magnitude (an unsolvable point reads `f64::MAX`).
pub fn refine(loads: &[SampledLoad], k: usize, at: &mut impl FnMut(f64) -> Option<[f64; 3]>) -> Dip {
    match refine_vector(loads, k, at) {
        Some((x, f)) => Dip { interval: k, at: x, margin: norm(f), load: Some(f) },
        None => {
            let (x, m) = brent_min(k as f64, (k + 1) as f64, LOCATE_STEPS, |p| at(p).map_or(f64::MAX, norm));
            Dip { interval: k, at: x, margin: m, load: None }
        }
    }
}

fn refine_vector(
    loads: &[SampledLoad],
    k: usize,
    at: &mut impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<(f64, [f64; 3])> {
    let known = |i: usize| loads.get(i).copied().flatten().map(|(_, v)| (i as f64, [v.x, v.y, v.z]));
    let (a, b) = (known(k)?, known(k + 1)?);
    let beyond = if is_min(loads, k + 1) {
        known(k + 2)
    } else if is_min(loads, k) {
        k.checked_sub(1).and_then(known)
    } else {
        None
    };
    let third = match beyond {
        Some(third) => third,
        None => (k as f64 + 0.5, at(k as f64 + 0.5)?),
    };
    vector_min(a, b, third, SCAN_TOL, at)
}

/// The distinct interior minima among the refined intervals: a minimum found at an
/// interval's end is the interval's lowest point, not a dip of it, so it is kept only
/// when that end is a sampled minimum and the interval on its other side found no dip
/// of its own (then the dip is at the sample itself); minima closer than a millionth
/// of a sample step are one.
pub fn select(refined: &[Dip], loads: &[SampledLoad]) -> Vec<Dip> {
    let ends = |d: &Dip| [d.interval as f64, (d.interval + 1) as f64];
    let at_end = |d: &Dip| ends(d).into_iter().find(|e| (d.at - e).abs() < END);
    let mut out: Vec<Dip> = Vec::new();
    for d in refined {
        if let Some(end) = at_end(d) {
            let inner_beside = refined.iter().any(|o| ends(o).contains(&end) && at_end(o).is_none());
            if !is_min(loads, end as usize) || inner_beside {
                continue;
            }
        }
        if out.iter().all(|o| (o.at - d.at).abs() >= SAME) {
            out.push(*d);
        }
    }
    out
}

/// A minimum inside its interval polished to round-off as the root of `f·df/ds`
/// ([`vector_polish`]), with the magnitude there; one at a sample, or where the
/// polish does not settle, as it is.
pub fn polish(dip: &Dip, at: &mut impl FnMut(f64) -> Option<[f64; 3]>) -> (f64, f64) {
    let (x, m) = (dip.at, dip.margin);
    match (x.fract() != 0.0).then(|| dip.load.or_else(|| at(x))).flatten() {
        Some(fx) => {
            vector_polish(x, fx, POLISH_WIDTH, (x.floor(), x.ceil()), &mut *at).map_or((x, m), |(p, fp)| (p, norm(fp)))
        }
        None => (x, m),
    }
}

/// The samples a walk from `start` by `step` passes: the start, then on while the
/// magnitude does not fall (the next dip's begins where it falls), up to a gap or the
/// path's end; nothing from an indeterminate start.
fn rising(loads: &[SampledLoad], start: usize, step: isize) -> impl Iterator<Item = usize> + '_ {
    std::iter::successors(loads[start].map(|_| start), move |&k| {
        let m = loads[k]?.0;
        let next = usize::try_from(k as isize + step).ok()?;
        match loads.get(next).copied().flatten() {
            Some((n, _)) if n >= m => Some(next),
            _ => None,
        }
    })
}

/// The walk from a minimum at `x` (sample steps) towards `side`: from the first
/// sample beyond `x` (beyond the sample `x` is on, where it is on one), over samples
/// whose magnitude does not fall, to the first whose magnitude has risen to `reach`,
/// else the sampled maximum where the magnitude falls again, else the last
/// determinate sample before a gap or the path's end. `None` where the first sample
/// is indeterminate (or there is none).
pub fn walk(loads: &[SampledLoad], x: f64, reach: f64, side: Side) -> Option<Stop> {
    let last = loads.len().checked_sub(1)?;
    let below = (x.floor().max(0.0) as usize).min(last);
    let above = (x.ceil().max(0.0) as usize).min(last);
    let (start, step) = match side {
        Side::Before => (if (x - below as f64) < SAME && below > 0 { below - 1 } else { below }, -1),
        Side::After => (if (above as f64 - x) < SAME && above < last { above + 1 } else { above }, 1),
    };
    let mut stop: Option<Stop> = None;
    for k in rising(loads, start, step) {
        let reached = loads[k].is_some_and(|(m, _)| m >= reach);
        stop = Some(Stop { sample: k, previous: stop.map(|s| s.sample), reached });
        if reached {
            break;
        }
    }
    stop
}

/// Where between `inner` (a point `(parameter, magnitude)` whose magnitude is below
/// `reach`) and `outer` (a point `(parameter, load)` whose magnitude is at least
/// `reach`) the magnitude of the load reaches `reach`: a root of `|f| − reach`, to
/// `tol` in the parameter (whatever its unit), by interpolation steps from the bracket
/// ([`interpolated_root`], Brent's bracketing method where those leave it). Returns
/// the point and the load there (`outer` itself where its magnitude is `reach`).
/// `None` where the ends do not bracket `reach` or the load cannot be evaluated at a
/// point the root finder asks for.
pub fn locate(
    inner: (f64, f64),
    outer: (f64, [f64; 3]),
    reach: f64,
    tol: f64,
    mut at: impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<(f64, [f64; 3])> {
    let (g_in, g_out) = (inner.1 - reach, norm(outer.1) - reach);
    if !(g_in < 0.0 && g_out >= 0.0) {
        return None;
    }
    if g_out == 0.0 {
        return Some(outer);
    }
    // The root finder ends at a point it evaluated: the latest few, to read its load.
    let mut seen: [Option<(f64, [f64; 3])>; 4] = [None; 4];
    let mut failed = false;
    let mut count = 0;
    let p = interpolated_root(inner.0, outer.0, g_in, g_out, tol, |p| match at(p) {
        Some(f) => {
            seen[count % seen.len()] = Some((p, f));
            count += 1;
            norm(f) - reach
        }
        None => {
            failed = true;
            0.0
        }
    });
    if failed {
        return None;
    }
    if p == outer.0 {
        return Some(outer);
    }
    match seen.iter().flatten().find(|(q, _)| *q == p) {
        Some(&found) => Some(found),
        None => at(p).map(|f| (p, f)),
    }
}

/// The reading on one side of a minimum `m` at `x` (sample steps): the located point
/// where the magnitude reaches `reach` ([`walk`], then [`locate`] between the sample it
/// stops on and the point before it), else the sample the walk stops on. Where the
/// located point cannot be solved, the sample the walk stops on. `None` where the
/// walk has no determinate start.
pub fn reading(
    loads: &[SampledLoad],
    x: f64,
    m: f64,
    reach: f64,
    side: Side,
    at: &mut impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<Reading> {
    let stop = walk(loads, x, reach, side)?;
    let (_, f) = loads[stop.sample]?;
    let sampled = Reading::at_sample(stop.sample, f);
    if !stop.reached {
        return Some(sampled);
    }
    let inner = match stop.previous {
        Some(i) => (i as f64, loads[i]?.0),
        None => (x, m),
    };
    Some(match locate(inner, (sampled.at, sampled.load), reach, LOCATE_STEPS, &mut *at) {
        Some((p, _)) if p == sampled.at => sampled,
        Some((p, load)) => Reading { at: p, load, sample: None },
        None => sampled,
    })
}

/// The readings either side of a minimum `m` at `x` ([`reading`]); `None` where a side
/// has no determinate sample to start from.
pub fn readings(
    loads: &[SampledLoad],
    x: f64,
    m: f64,
    reach: f64,
    at: &mut impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<(Reading, Reading)> {
    let before = reading(loads, x, m, reach, Side::Before, at)?;
    let after = reading(loads, x, m, reach, Side::After, at)?;
    Some((before, after))
}

/// Whether the take-up directions of two readings differ by more than 90°.
pub fn turns(before: &Reading, after: &Reading) -> bool {
    let (b, a) = (before.load, after.load);
    b[0] * a[0] + b[1] * a[1] + b[2] * a[2] < 0.0
}
