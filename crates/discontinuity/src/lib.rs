//! # clearance-discontinuity
//!
//! Where the pose error jumps (MODEL.md §8). Take-up directions follow the joint
//! loads; where a deciding load changes sign (`r_axial`: `f_Rj·y_j`) or passes
//! through or near zero and swings round (`s_radial`: `f_Sj`, `r_radial`: `f⊥`,
//! `r_angular`: `m_Rj`), the distal part of the joint jumps to the opposite wall and
//! the error steps.
//!
//! Every [`Path`] (a trajectory, or each grid line along each input) is searched:
//!
//! - `r_axial`: a switch wherever the sign differs between consecutive determinate
//!   samples, located by Brent's root finder;
//! - vector loads: a switch at each interior local minimum of the load magnitude
//!   below `discontinuity_load_fraction·W`, located by Brent minimisation between the
//!   neighbouring samples, provided the take-up directions where the magnitude has
//!   risen back to twice that minimum (or at the path's ends) differ by more than 90°.
//!
//! Samples whose deciding load is within the noise floor are indeterminate and left
//! out; unreachable and near-singular samples cut a path into separate segments.
//! Locations are refined to [`LOCATE_TOL`] in the path parameter, so the result does
//! not depend on the sample spacing.

mod minimise;
mod paths;
mod trace;

pub use minimise::{brent_min, brent_root};
pub use paths::{Along, Axis, Path, axes, paths};
pub use trace::{Loads, Trace, keep_local_minima, trace, trace_into, trace_loads, traces};

use trace::{LOW_SHIFT, SOLVABLE, det_bit, low_bit};

use clearance_grid::{Sample, SampleSource};
use clearance_model::{ClearanceKind, KINDS, Mode};
use clearance_solver::{
    JointReactions, Model, PoseError, PoseResult, Status, Workspace, solve_pose, solve_reactions,
    solve_reactions_if_solvable,
};
use rayon::prelude::*;
use std::collections::HashMap;

/// Locations are refined to this absolute tolerance in the path parameter (rad, m or s).
pub const LOCATE_TOL: f64 = 1e-9;

/// One refined switch of one joint's take-up.
#[derive(Clone, Debug, PartialEq)]
pub struct Discontinuity {
    pub mode: Mode,
    /// 1..3.
    pub limb: usize,
    pub kind: ClearanceKind,
    pub along: Along,
    /// The path parameter at the switch.
    pub param: f64,
    /// The refined location.
    pub t: Option<f64>,
    pub z: f64,
    pub psi: f64,
    pub theta: f64,
    /// The deciding load there (N or N·m).
    pub margin: f64,
    /// That kind's ΔΓ after minus before, as `[Δp; Δα]`.
    pub jump: [f64; 6],
}

/// Search settings shared by every path of a (variant, mode).
#[derive(Clone, Copy, Debug)]
pub struct SearchOptions {
    /// `discontinuity_load_fraction·W`: vector-load minima above this are not switches.
    pub dip_threshold: f64,
}

/// The load deciding a take-up: signed along `y_j` (axial) or a vector.
#[derive(Clone, Copy, Debug)]
enum Load {
    Scalar(f64),
    Vector([f64; 3]),
}

impl Load {
    pub fn magnitude(self) -> f64 {
        match self {
            Load::Scalar(s) => s.abs(),
            Load::Vector(v) => (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
        }
    }

    pub fn signed(self) -> f64 {
        match self {
            Load::Scalar(s) => s,
            Load::Vector(_) => unreachable!("vector loads have no sign"),
        }
    }

    pub fn dot(self, other: Load) -> f64 {
        match (self, other) {
            (Load::Vector(a), Load::Vector(b)) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
            _ => unreachable!("directions of vector loads only"),
        }
    }
}

/// The load deciding one kind's take-up at one limb: a signed scalar or a vector.
fn load(r: &PoseResult, model: &Model, kind: ClearanceKind, j: usize) -> Load {
    load_of(&r.reactions, model, kind, j)
}

fn load_of(reactions: &JointReactions, model: &Model, kind: ClearanceKind, j: usize) -> Load {
    let y = model.geometry.y[j];
    let fr = reactions.f_r[j];
    match kind {
        ClearanceKind::RAxial => Load::Scalar(fr.dot(&y)),
        ClearanceKind::RRadial => {
            let p = fr - fr.dot(&y) * y;
            Load::Vector([p.x, p.y, p.z])
        }
        ClearanceKind::SRadial => {
            let f = reactions.f_s[j];
            Load::Vector([f.x, f.y, f.z])
        }
        ClearanceKind::RAngular => {
            let m = reactions.m_r[j];
            Load::Vector([m.x, m.y, m.z])
        }
    }
}

fn solvable(r: &PoseResult) -> bool {
    matches!(r.status, Status::Ok | Status::IndeterminateContact)
}

fn error_of(r: &PoseResult, kind: ClearanceKind) -> [f64; 6] {
    let e: &PoseError = &r.errors[kind.index()];
    [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z]
}

struct Evaluator<'a> {
    model: &'a Model,
    source: &'a SampleSource,
    path: &'a Path,
    mode: Mode,
}

impl Evaluator<'_> {
    /// The `k`-th sample of the path.
    fn node(&self, k: usize) -> Sample {
        self.source.sample(self.path.sample_index(k))
    }

    /// The reactions at path parameter `p`, where the pose is solvable: a
    /// refinement follows the deciding load alone, so it needs neither take-up nor
    /// errors (the same reactions and verdict as `solve_pose`, for a third of the
    /// work).
    fn reactions_at(&self, p: f64, ws: &mut Workspace) -> (Sample, Option<JointReactions>) {
        let s = self.path.sample_at(self.source, p);
        let r = solve_reactions_if_solvable(self.model, &s, self.mode, ws);
        (s, r)
    }

    fn record(
        &self,
        kind: ClearanceKind,
        j: usize,
        p: f64,
        ws: &mut Workspace,
        before: &PoseResult,
        after: &PoseResult,
    ) -> Discontinuity {
        let (s, r) = self.reactions_at(p, ws);
        let margin = r.map_or(f64::NAN, |r| load_of(&r, self.model, kind, j).magnitude());
        let (b, a) = (error_of(before, kind), error_of(after, kind));
        Discontinuity {
            mode: self.mode,
            limb: j + 1,
            kind,
            along: self.path.along,
            param: p,
            t: s.t,
            z: s.z[0],
            psi: s.psi[0],
            theta: s.theta[0],
            margin,
            jump: [0, 1, 2, 3, 4, 5].map(|i| a[i] - b[i]),
        }
    }
}

/// The samples of one path, solved when first asked for.
struct Solved<'a> {
    ev: &'a Evaluator<'a>,
    cache: HashMap<usize, PoseResult>,
    /// Reactions only, for following load magnitudes: of the few samples near a
    /// candidate (a slot per sample of the path was a quarter of the search's time).
    reactions: HashMap<usize, JointReactions>,
}

impl Solved<'_> {
    /// The reactions at the `k`-th sample (a solvable one).
    fn reactions(&mut self, k: usize, ws: &mut Workspace) -> JointReactions {
        let ev = self.ev;
        *self
            .reactions
            .entry(k)
            .or_insert_with(|| solve_reactions(ev.model, &ev.node(k), ev.mode, ws).unwrap_or_default())
    }

    /// The `k`-th sample of the path, solved.
    fn get(&mut self, k: usize, ws: &mut Workspace) -> PoseResult {
        let ev = self.ev;
        *self.cache.entry(k).or_insert_with(|| solve_pose(ev.model, &ev.node(k), ev.mode, ws))
    }
}

/// The switches along one path, given the [`Trace`] of each of its samples (by
/// sample index, made with the same [`SearchOptions`]). The traces are read where
/// they lie, never copied: a path (a whole trajectory) takes no memory per sample.
pub fn search_path(
    model: &Model,
    source: &SampleSource,
    path: &Path,
    mode: Mode,
    trace_of: impl Fn(u64) -> Trace,
    ws: &mut Workspace,
) -> Vec<Discontinuity> {
    let ev = Evaluator { model, source, path, mode };
    let trace = |k: usize| trace_of(path.sample_index(k));
    let mut solved = Solved { ev: &ev, cache: HashMap::new(), reactions: HashMap::new() };
    let mut out = Vec::new();
    // Unreachable or near-singular samples cut the path into segments.
    let mut start = 0;
    while start < path.len() {
        if trace(start) & SOLVABLE == 0 {
            start += 1;
            continue;
        }
        let mut end = start;
        // In det-bit positions: the (kind, limb)s with a determinate low sample, and
        // with a determinate sample that is not low, somewhere in the segment.
        let (mut low_det, mut high_det) = (0, 0);
        while end < path.len() {
            let t = trace(end);
            if t & SOLVABLE == 0 {
                break;
            }
            low_det |= t & (t >> LOW_SHIFT);
            high_det |= t & !(t >> LOW_SHIFT);
            end += 1;
        }
        for kind in KINDS {
            if model.clearance[kind.index()] == 0.0 {
                continue;
            }
            for j in 0..3 {
                let d = det_bit(kind, j);
                // Nothing to find: no candidate among the vector loads, or an axial
                // load of one sign throughout.
                if low_det & d == 0 || (kind == ClearanceKind::RAxial && high_det & d == 0) {
                    continue;
                }
                let segment = Segment { trace: &trace, start, end, det: d, low: low_bit(kind, j) };
                if kind == ClearanceKind::RAxial {
                    axial_switches(&ev, &mut solved, &segment, j, ws, &mut out);
                } else {
                    vector_switches(&ev, &mut solved, &segment, kind, j, ws, &mut out);
                }
            }
        }
        start = end;
    }
    out
}

/// The samples `start..end` of a path (one segment: all solvable) whose deciding
/// load of one (kind, limb) is determinate, found from their traces as needed.
struct Segment<'a> {
    trace: &'a dyn Fn(usize) -> Trace,
    start: usize,
    end: usize,
    det: Trace,
    low: Trace,
}

impl Segment<'_> {
    /// The determinate samples from `from` on, in order.
    fn after(&self, from: usize) -> impl Iterator<Item = usize> + '_ {
        (from..self.end).filter(|&k| (self.trace)(k) & self.det != 0)
    }

    /// The determinate samples before `to`, nearest first.
    fn before(&self, to: usize) -> impl Iterator<Item = usize> + '_ {
        (self.start..to).rev().filter(|&k| (self.trace)(k) & self.det != 0)
    }

    /// Whether the sample is low (a negative axial load, or a candidate vector minimum).
    fn is_low(&self, k: usize) -> bool {
        (self.trace)(k) & self.low != 0
    }
}

fn axial_switches(
    ev: &Evaluator<'_>,
    solved: &mut Solved<'_>,
    segment: &Segment<'_>,
    j: usize,
    ws: &mut Workspace,
    out: &mut Vec<Discontinuity>,
) {
    let kind = ClearanceKind::RAxial;
    let signed = |r: &PoseResult| load(r, ev.model, kind, j).signed();
    let mut previous: Option<usize> = None;
    for b in segment.after(segment.start) {
        let Some(a) = previous.replace(b) else { continue };
        if segment.is_low(a) == segment.is_low(b) {
            continue;
        }
        let (ra, rb) = (solved.get(a, ws), solved.get(b, ws));
        let (pa, pb) = (ev.path.params[a], ev.path.params[b]);
        let p = brent_root(pa, pb, signed(&ra), signed(&rb), LOCATE_TOL, |p| {
            let (_, r) = ev.reactions_at(p, ws);
            r.map_or(0.0, |r| load_of(&r, ev.model, kind, j).signed())
        });
        out.push(ev.record(kind, j, p, ws, &ra, &rb));
    }
}

fn vector_switches(
    ev: &Evaluator<'_>,
    solved: &mut Solved<'_>,
    segment: &Segment<'_>,
    kind: ClearanceKind,
    j: usize,
    ws: &mut Workspace,
    out: &mut Vec<Discontinuity>,
) {
    let mag = |solved: &mut Solved<'_>, k: usize, ws: &mut Workspace| {
        load_of(&solved.reactions(k, ws), ev.model, kind, j).magnitude()
    };
    // Consecutive determinate samples `a`, `k`, `c`: `k` is an interior one.
    let (mut a, mut k): (Option<usize>, Option<usize>) = (None, None);
    for c in segment.after(segment.start) {
        let triple = a.zip(k);
        (a, k) = (k, Some(c));
        let Some((a, k)) = triple else { continue };
        // An interior local minimum (the first sample of a flat bottom) below the
        // dip threshold; the trace has ruled out most other samples already.
        if !segment.is_low(k) {
            continue;
        }
        let here = mag(solved, k, ws);
        if !(here < mag(solved, a, ws) && here <= mag(solved, c, ws)) {
            continue;
        }
        let (lo, hi) = (ev.path.params[a], ev.path.params[c]);
        // The squared magnitude has the same minimum and is smooth there (the
        // magnitude itself is a V when the load passes near zero), so Brent's
        // parabolic steps converge in a few evaluations.
        let (p, m2) = brent_min(lo, hi, LOCATE_TOL / 10.0, |p| {
            let (_, r) = ev.reactions_at(p, ws);
            r.map_or(f64::INFINITY, |r| load_of(&r, ev.model, kind, j).magnitude().powi(2))
        });
        let m = m2.sqrt();
        // Where the magnitude has risen back to twice the minimum, on either side,
        // else the segment's first or last determinate sample.
        let left = first_or_last(segment.before(k), |i| mag(solved, i, ws) >= 2.0 * m);
        let right = first_or_last(segment.after(k + 1), |i| mag(solved, i, ws) >= 2.0 * m);
        let (rl, rr) = (solved.get(left, ws), solved.get(right, ws));
        let turn = load(&rl, ev.model, kind, j).dot(load(&rr, ev.model, kind, j));
        if turn < 0.0 {
            out.push(ev.record(kind, j, p, ws, &rl, &rr));
        }
    }
}

/// The first of `side` where `rises`, else its last (`side` is not empty).
fn first_or_last(side: impl Iterator<Item = usize>, mut rises: impl FnMut(usize) -> bool) -> usize {
    let mut last = None;
    for i in side {
        if rises(i) {
            return i;
        }
        last = Some(i);
    }
    last.expect("a determinate sample on either side")
}

/// All switches of one (variant, mode) from the traces of its samples (indexed by
/// sample), paths searched in parallel; the order is that of [`paths`], then of the
/// search, whatever the thread count.
pub fn find_discontinuities_traced(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    traces: &[Trace],
) -> Vec<Discontinuity> {
    let mut search = Search::new(model, source, mode);
    search.extend(traces);
    search.finish()
}

/// [`find_discontinuities_traced`] with the traces read through `read` (which fills
/// its buffer with the traces of a range of samples) a batch of paths at a time, so
/// that at most `budget` traces are in memory, or one path's if that is more: a
/// run's search then takes the same memory for 50 million samples as for 5. The
/// result is the same, in the same order.
///
/// Paths along an axis are batched in [`paths`] order: whole lines of the outer
/// inputs while they fit, which is one range of samples; otherwise neighbouring
/// lines of one outer node, which is one range of samples per node along the axis.
pub fn find_discontinuities_read<E>(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    budget: usize,
    mut read: impl FnMut(std::ops::Range<u64>, &mut [Trace]) -> Result<(), E>,
) -> Result<Vec<Discontinuity>, E> {
    let len = source.len();
    let budget = budget.max(1) as u64;
    let mut buf: Vec<Trace> = Vec::new();
    let mut out = Vec::new();
    let mut search = |batch: Vec<Path>, buf: &[Trace], at: &(dyn Fn(u64) -> usize + Sync)| {
        out.par_extend(
            batch
                .par_iter()
                .map_init(Workspace::new, |ws, path| search_path(model, source, path, mode, |i| buf[at(i)], ws))
                .flatten_iter(),
        );
    };
    for axis in axes(source).into_iter().rev() {
        let (stride, n) = (axis.stride, axis.n);
        let span = stride * n;
        if span <= budget {
            // Whole blocks of `span` samples: every line through them, one range.
            let per = budget / span;
            for first in (0..len / span).step_by(per as usize) {
                let last = (first + per).min(len / span);
                let range = first * span..last * span;
                buf.resize((range.end - range.start) as usize, 0);
                read(range.clone(), &mut buf)?;
                let batch = range.clone().step_by(span as usize).flat_map(|o| (0..stride).map(move |i| o + i));
                let batch = batch.map(|origin| axis.path(origin)).collect();
                search(batch, &buf, &|i| (i - range.start) as usize);
            }
        } else {
            // Lines `inner..inner + width` of one outer node: `width` samples at each node.
            let width = (budget / n).clamp(1, stride);
            for outer in (0..len).step_by(span as usize) {
                for inner in (0..stride).step_by(width as usize) {
                    let w = width.min(stride - inner);
                    buf.resize((n * w) as usize, 0);
                    if w == stride {
                        // Every line of the node (a whole trajectory, say): one range.
                        read(outer..outer + span, &mut buf)?;
                    } else {
                        for (k, dst) in buf.chunks_exact_mut(w as usize).enumerate() {
                            let start = outer + k as u64 * stride + inner;
                            read(start..start + w, dst)?;
                        }
                    }
                    let batch = (inner..inner + w).map(|i| axis.path(outer + i)).collect();
                    search(batch, &buf, &|i| {
                        let (node, line) = ((i - outer) / stride, (i - outer) % stride - inner);
                        (node * w + line) as usize
                    });
                }
            }
        }
    }
    Ok(out)
}

/// The search of one (variant, mode) whose traces arrive a range of samples at a
/// time, in sample order: each path is searched as soon as its last sample is in,
/// so a run searches the lines of its first parts while it computes the next. The
/// result is that of [`find_discontinuities_traced`] on all the traces at once.
pub struct Search<'a> {
    model: &'a Model,
    source: &'a SampleSource,
    mode: Mode,
    /// The traces received so far, from sample 0.
    traces: Vec<Trace>,
    /// The paths of each axis, in [`paths`] order, with the switches found on the
    /// paths searched so far (the first ones: a path's last sample grows with its
    /// position within its axis).
    axes: Vec<(Vec<Path>, Vec<Discontinuity>, usize)>,
}

impl<'a> Search<'a> {
    pub fn new(model: &'a Model, source: &'a SampleSource, mode: Mode) -> Self {
        let mut axes: Vec<(Vec<Path>, Vec<Discontinuity>, usize)> = Vec::new();
        for path in paths(source) {
            match axes.last_mut() {
                Some((group, _, _)) if group[0].along == path.along => group.push(path),
                _ => axes.push((vec![path], Vec::new(), 0)),
            }
        }
        Self { model, source, mode, traces: Vec::new(), axes }
    }

    /// Adds the traces of the next samples and searches the paths they complete;
    /// returns how many that was.
    pub fn extend(&mut self, traces: &[Trace]) -> usize {
        self.traces.extend_from_slice(traces);
        assert!(self.traces.len() as u64 <= self.source.len(), "more traces than samples");
        let have = self.traces.len() as u64;
        let mut count = 0;
        let Self { model, source, mode, traces, .. } = self;
        for (paths, found, searched) in &mut self.axes {
            let ready = paths[*searched..].partition_point(|p| p.is_empty() || p.sample_index(p.len() - 1) < have);
            let batch = &paths[*searched..*searched + ready];
            found.par_extend(
                batch
                    .par_iter()
                    .map_init(Workspace::new, |ws, path| {
                        search_path(model, source, path, *mode, |i| traces[i as usize], ws)
                    })
                    .flatten_iter(),
            );
            *searched += ready;
            count += ready;
        }
        count
    }

    /// Whether every sample's trace is in (and so every path searched).
    pub fn is_complete(&self) -> bool {
        self.traces.len() as u64 == self.source.len()
    }

    /// The switches of every path, in [`paths`] order; every trace must be in.
    pub fn finish(self) -> Vec<Discontinuity> {
        assert!(self.is_complete(), "the search ends with every sample traced");
        self.axes.into_iter().flat_map(|(_, found, _)| found).collect()
    }
}

/// All switches of one (variant, mode), every sample solved here.
pub fn find_discontinuities(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
) -> Vec<Discontinuity> {
    find_discontinuities_traced(model, source, mode, &traces(model, source, mode, opts, 0..source.len()))
}
