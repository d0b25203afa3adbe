//! The search along one path: its segments, the samples solved on demand, and how
//! a switch is recorded. The rules themselves are in [`crate::scalar`] and
//! [`crate::dips`].

use clearance_grid::{Sample, SampleSource};
use clearance_model::{ClearanceKind, KINDS, MechanismKind, Mode};
use clearance_solver::{
    JointReactions, Model, PoseError, PoseResult, Workspace, solve_errors, solve_reactions, solve_reactions_if_solvable,
};
use std::cell::RefCell;
use std::collections::HashMap;

use crate::shortcut::Shortcut;
use crate::trace::{Decider, SOLVABLE, Trace, det_bit, min_bit, neg_bit, settled_bits, turn_bit};
use crate::{Along, Discontinuity, Forces, Path, SearchOptions, dips, margin, scalar};
use nalgebra::Vector3;

/// Leaving out the lines along which no load changes ([`loads_invariant`]).
pub(crate) static RIGID: Shortcut = Shortcut::new();

/// Whether every load is the same at every point of a line along `along`, so that
/// no take-up can switch on it: a Z-line of a 3-PRS with vertical rails. Moving Z
/// alone slides the three sliders by the same amount (`q_j = h_j − √(L² − (ρ_j −
/// R_b)²)`, and the parasitic motions do not depend on Z, the limb planes being
/// vertical), so every body translates rigidly along `z`: the geometry of A·w = b,
/// the weights and the external wrench are those at any other height. A grid has no
/// velocities, so its loads are kinetostatic. The samples of such a line differ in
/// round-off alone; searching it (a 3-D grid's Z-lines were two thirds of its
/// search) finds nothing.
pub(crate) fn loads_invariant(model: &Model, along: Along) -> bool {
    along == Along::Z && model.geometry.kind == MechanismKind::Prs3 && model.geometry.vertical_rails
}

/// Whether a path along `along` is left out ([`loads_invariant`], unless a test has
/// turned [`RIGID`] off).
pub(crate) fn left_out(model: &Model, along: Along) -> bool {
    loads_invariant(model, along) && RIGID.on()
}

/// [`left_out`], counting the lines a test searches that the shortcut would leave out.
pub(crate) fn skipped(model: &Model, along: Along) -> bool {
    if left_out(model, along) {
        return true;
    }
    if loads_invariant(model, along) {
        RIGID.minimising();
    }
    false
}

/// Each kind's error `[Δp; Δα]` (order of `KINDS`): what a switch's jump is the
/// difference of.
pub(crate) type KindErrors = [[f64; 6]; 4];

fn kind_errors(errors: &[PoseError; 4]) -> KindErrors {
    errors.map(|e| [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z])
}

pub(crate) struct Evaluator<'a> {
    pub model: &'a Model,
    pub source: &'a SampleSource,
    pub path: &'a Path,
    pub mode: Mode,
    pub opts: &'a SearchOptions,
    /// The reactions at the last few points between samples, by the bits of their
    /// parameter: a root finder returns a point it has evaluated, whose reactions the
    /// switch it locates then carries (for its margin, under each kind it decides:
    /// `r_axial` and `r_angular` share theirs).
    recent: RefCell<Recent>,
    /// Every point between samples found unsolvable, in the order met (repeats too):
    /// an interval holding one is cut (docs/model.md §8).
    unsolved: RefCell<Vec<f64>>,
}

/// A ring of the last [`RECENT`] points [`Evaluator::reactions_at`] solved.
#[derive(Default)]
struct Recent {
    at: [Option<(u64, Option<JointReactions>)>; RECENT],
    next: usize,
}

const RECENT: usize = 4;

impl<'a> Evaluator<'a> {
    pub fn new(
        model: &'a Model,
        source: &'a SampleSource,
        path: &'a Path,
        mode: Mode,
        opts: &'a SearchOptions,
    ) -> Self {
        Self { model, source, path, mode, opts, recent: RefCell::default(), unsolved: RefCell::default() }
    }

    /// The `k`-th sample of the path.
    fn node(&self, k: usize) -> Sample {
        self.source.sample(self.path.sample_index(k))
    }

    /// The path parameter of the `k`-th sample.
    pub fn param(&self, k: usize) -> f64 {
        self.path.params[k]
    }

    /// The reactions at path parameter `p`, where the pose is solvable: a
    /// refinement follows the deciding load alone, so it needs neither take-up nor
    /// errors (the same reactions and verdict as `solve_pose`, for a third of the
    /// work).
    pub fn reactions_at(&self, p: f64, ws: &mut Workspace) -> Option<JointReactions> {
        let key = p.to_bits();
        let mut recent = self.recent.borrow_mut();
        let r = match recent.at.iter().flatten().find(|(k, _)| *k == key) {
            Some((_, r)) => *r,
            None => {
                let s = self.path.sample_at(self.source, p);
                let r = solve_reactions_if_solvable(self.model, &s, self.mode, ws);
                let next = recent.next;
                recent.at[next] = Some((key, r));
                recent.next = (next + 1) % RECENT;
                r
            }
        };
        if r.is_none() {
            self.unsolved.borrow_mut().push(p);
        }
        r
    }

    /// A mark of the unsolvable points met so far, for [`Evaluator::cut_since`].
    pub fn unsolved_mark(&self) -> usize {
        self.unsolved.borrow().len()
    }

    /// Whether a point met since `mark` ([`Evaluator::unsolved_mark`]) that could not
    /// be solved lies strictly between path parameters `a` and `b`: the path leaves the
    /// workspace there and comes back, which cuts it as an unsolvable sample does
    /// (docs/model.md §8).
    pub fn cut_since(&self, mark: usize, a: f64, b: f64) -> bool {
        let (lo, hi) = (a.min(b), a.max(b));
        self.unsolved.borrow()[mark..].iter().any(|&p| p > lo && p < hi)
    }

    /// The per-kind errors at path parameter `p` (for the jump across a switch).
    pub fn errors_at(&self, p: f64, ws: &mut Workspace) -> KindErrors {
        kind_errors(&solve_errors(self.model, &self.path.sample_at(self.source, p), self.mode, ws))
    }

    /// The switch of `kind` at `p`, where the reactions are `r` (as
    /// [`Evaluator::reactions_at`] gives them), its jump from the errors either side.
    pub fn record(
        &self,
        kind: ClearanceKind,
        j: usize,
        p: f64,
        r: Option<JointReactions>,
        before: &KindErrors,
        after: &KindErrors,
    ) -> Discontinuity {
        let margin = r.map_or(f64::NAN, |r| margin(&r, self.model, kind, j));
        self.record_margin(kind, j, p, margin, before, after)
    }

    /// [`Evaluator::record`] with the deciding load's magnitude there, `margin`.
    pub fn record_margin(
        &self,
        kind: ClearanceKind,
        j: usize,
        p: f64,
        margin: f64,
        before: &KindErrors,
        after: &KindErrors,
    ) -> Discontinuity {
        let s = self.path.sample_at(self.source, p);
        let (b, a) = (before[kind.index()], after[kind.index()]);
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

/// The samples of one path, solved when first asked for, unless the run that
/// traced them still has their values ([`Known`]).
pub(crate) struct Solved<'a> {
    pub ev: &'a Evaluator<'a>,
    known: Option<&'a Known>,
    maps: Maps,
    /// How many values `known` gave.
    reads: u64,
}

/// Brings the cache lines of `value` towards the core, without waiting for them.
#[inline(always)]
fn prefetch_lines<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let at = (value as *const T).cast::<i8>();
        for line in (0..size_of::<T>()).step_by(64) {
            // SAFETY: SSE is part of x86_64; a prefetch reads nothing and cannot
            // fault, and the address is within `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(at.wrapping_add(line)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// The values a run's pass solved at consecutive samples, where it still has them:
/// the same bits as solving the samples again ([`Sampled`]). Held in the buffers the
/// run solved them into, never copied.
#[derive(Debug, Default)]
pub(crate) struct Known {
    /// Buffers of consecutive samples, oldest first, each with its first sample's index.
    chunks: std::collections::VecDeque<(u64, Vec<Sampled>)>,
    /// How many values were read ([`Known::get`] found them, [`Known::count_reads`]).
    reads: std::sync::atomic::AtomicU64,
}

impl Known {
    /// The values of sample `i`, if held.
    pub fn get(&self, i: u64) -> Option<&Sampled> {
        // Newest first: a path's samples are mostly in the buffer that completes it.
        self.chunks.iter().rev().find(|(first, _)| *first <= i).and_then(|(first, v)| v.get((i - first) as usize))
    }

    /// Counts `n` values read (by a path's search, once it is done: one count per
    /// read, shared by the threads, kept their caches busy).
    fn count_reads(&self, n: u64) {
        if n > 0 {
            self.reads.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
    }

    /// How many values were read since the last call.
    pub fn take_reads(&self) -> u64 {
        self.reads.swap(0, std::sync::atomic::Ordering::Relaxed)
    }

    /// Lets go of every buffer held; returns them, to reuse.
    pub fn let_go(&mut self) -> Vec<Vec<Sampled>> {
        self.chunks.drain(..).map(|(_, v)| v).collect()
    }

    /// Holds the values of the samples from `first` on, which must follow those held
    /// (else the held ones are let go: returned, to reuse).
    pub fn push(&mut self, first: u64, values: Vec<Sampled>) -> Vec<Vec<Sampled>> {
        let spare = if self.chunks.back().is_some_and(|(f, v)| f + v.len() as u64 != first) {
            self.let_go()
        } else {
            Vec::new()
        };
        if !values.is_empty() {
            self.chunks.push_back((first, values));
        }
        spare
    }

    /// Lets go of the buffers that hold none of the `keep` samples before `end`;
    /// returns them, to reuse.
    pub fn trim(&mut self, end: u64, keep: u64) -> Vec<Vec<Sampled>> {
        let from = end.saturating_sub(keep);
        let mut spare = Vec::new();
        while self.chunks.front().is_some_and(|(f, v)| f + (v.len() as u64) <= from) {
            spare.extend(self.chunks.pop_front().map(|(_, v)| v));
        }
        spare
    }
}

/// What the search reads at a sample, as the pass solved it: the forces that decide
/// the take-ups, 144 bytes against a result's kilobyte (the pass stores them for every
/// pose of a run that searches as it computes). `solve_reactions` gives a solvable
/// sample the same bits as its [`PoseResult`] (tested in the solver crate), so a search
/// that reads them here finds the switches it finds by solving the sample again. The
/// per-kind errors, which only the jumps read (a few samples a switch), are solved
/// where they are read (`solve_errors`, the same bits too): stored for every pose they
/// were 192 bytes more, written once and most never read, and fresh memory to fault
/// in (`grid_2d`'s page faults, `perf`: the stored values a third of them).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sampled {
    forces: SampleForces,
}

impl Sampled {
    #[inline]
    pub fn of(r: &PoseResult) -> Self {
        Self { forces: SampleForces::of(&r.reactions) }
    }
}

/// `f_Rj` and `f_Sj` of a sample.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SampleForces {
    f_r: [Vector3<f64>; 3],
    f_s: [Vector3<f64>; 3],
}

impl SampleForces {
    fn of(r: &JointReactions) -> Self {
        Self { f_r: r.f_r, f_s: r.f_s }
    }
}

impl Forces for SampleForces {
    fn f_r(&self, j: usize) -> Vector3<f64> {
        self.f_r[j]
    }
    fn f_s(&self, j: usize) -> Vector3<f64> {
        self.f_s[j]
    }
}

/// The solved samples of a path by index: per-kind errors (for the jump across a
/// switch), and reactions only, for following loads, of the few samples near a
/// candidate (a slot per sample of the path was a quarter of the search's time).
#[derive(Default)]
struct Maps {
    cache: HashMap<usize, KindErrors>,
    reactions: HashMap<usize, SampleForces>,
}

thread_local! {
    /// Each thread's [`Maps`], emptied after each path: a 3-D grid has tens of
    /// thousands of short paths, and growing two maps afresh for each made the
    /// search's threads wait on the allocator's locks (a third of the search's
    /// samples on `grid_3d`, `perf`).
    static SPARE_MAPS: std::cell::Cell<Option<Maps>> = const { std::cell::Cell::new(None) };
    /// Each thread's buffer of a path's traces ([`search_path_known`]).
    static SPARE_TRACES: std::cell::Cell<Vec<Trace>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Paths of up to this many samples (every grid line) have their traces gathered
/// before the search reads them; longer ones (a trajectory) are read where they lie,
/// so that a path takes no memory per sample.
const GATHERED: usize = 1 << 16;

/// Maps that grew past this many entries (a long trajectory's) are dropped, not kept.
const KEPT_ENTRIES: usize = 1 << 12;

impl Drop for Solved<'_> {
    fn drop(&mut self) {
        if let Some(known) = self.known {
            known.count_reads(self.reads);
        }
        let mut maps = std::mem::take(&mut self.maps);
        if maps.cache.capacity() <= KEPT_ENTRIES && maps.reactions.capacity() <= KEPT_ENTRIES {
            maps.cache.clear();
            maps.reactions.clear();
            SPARE_MAPS.set(Some(maps));
        }
    }
}

impl<'a> Solved<'a> {
    /// None of the path's samples solved yet.
    fn new(ev: &'a Evaluator<'a>, known: Option<&'a Known>) -> Self {
        Self { ev, known, maps: SPARE_MAPS.take().unwrap_or_default(), reads: 0 }
    }

    /// What the pass solved at the `k`-th sample, where the run still holds it.
    fn known(&mut self, k: usize) -> Option<&'a Sampled> {
        let found = self.known.and_then(|known| known.get(self.ev.path.sample_index(k)));
        self.reads += u64::from(found.is_some());
        found
    }

    /// Asks the memory for the forces of the samples the rules will read, from the
    /// path's `traces`: either side of a sign change of an axial load, and around a
    /// candidate minimum or turn (with the errors nearest it). The pass's values of
    /// a 3-D grid are far more than the caches hold and a grid line reads them a
    /// stride apart: read one by one, each waited on the memory (a fifth of
    /// `grid_3d`'s search).
    fn prefetch(&self, traces: &[Trace], along: Along) {
        let Some(known) = self.known else { return };
        let candidates = settled_bits(Some(along));
        let signs = (0..3).fold(0, |m, j| m | neg_bit(j));
        let sampled = |k: usize| traces.get(k).and_then(|_| known.get(self.ev.path.sample_index(k)));
        for (k, t) in traces.iter().enumerate() {
            if k > 0 && (t ^ traces[k - 1]) & signs != 0 {
                // A crossing: its first step reads the forces either side and a
                // sample beyond each.
                (k.saturating_sub(2)..=k + 1).filter_map(sampled).for_each(|s| prefetch_lines(&s.forces));
            } else if t & candidates != 0 {
                // A dip's walks read the forces a few samples out (a sweep's search
                // took 4 % less time with these than with the candidate and its
                // neighbours alone).
                (k.saturating_sub(3)..=k + 3).filter_map(sampled).for_each(|s| prefetch_lines(&s.forces));
            }
        }
    }

    /// The forces at the `k`-th sample (a solvable one).
    pub fn forces(&mut self, k: usize, ws: &mut Workspace) -> &impl Forces {
        let ev = self.ev;
        if let Some(s) = self.known(k) {
            return &s.forces;
        }
        self.maps.reactions.entry(k).or_insert_with(|| {
            SampleForces::of(&solve_reactions(ev.model, &ev.node(k), ev.mode, ws).unwrap_or_default())
        })
    }

    /// The per-kind errors at the `k`-th sample of the path (solved: the pass keeps
    /// none, see [`Sampled`]).
    pub fn errors(&mut self, k: usize, ws: &mut Workspace) -> KindErrors {
        let ev = self.ev;
        *self.maps.cache.entry(k).or_insert_with(|| kind_errors(&solve_errors(ev.model, &ev.node(k), ev.mode, ws)))
    }
}

/// The samples `start..end` of a path (one segment: all solvable) whose deciding
/// load of one limb is determinate, found from their traces as needed.
pub(crate) struct Segment<'a, F: Fn(usize) -> Trace> {
    pub trace: &'a F,
    pub start: usize,
    pub end: usize,
    pub det: Trace,
    /// The input the path follows: which candidate bits are its.
    pub along: Along,
}

impl<F: Fn(usize) -> Trace> Segment<'_, F> {
    /// The determinate samples from `from` on, in order.
    pub fn after(&self, from: usize) -> impl Iterator<Item = usize> + '_ {
        (from..self.end).filter(|&k| (self.trace)(k) & self.det != 0)
    }

    /// The determinate samples before `to`, nearest first.
    pub fn before(&self, to: usize) -> impl Iterator<Item = usize> + '_ {
        (self.start..to).rev().filter(|&k| (self.trace)(k) & self.det != 0)
    }

    /// Whether the sample has the bit set.
    pub fn has(&self, k: usize, bit: Trace) -> bool {
        (self.trace)(k) & bit != 0
    }

    /// Consecutive determinate samples `(a, k, c)`: `k` runs over the interior ones.
    pub fn triples(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        let mut it = self.after(self.start);
        let (mut a, mut k) = (it.next(), it.next());
        it.filter_map(move |c| {
            let triple = a.zip(k).map(|(a, k)| (a, k, c));
            (a, k) = (k, Some(c));
            triple
        })
    }

    /// Consecutive determinate samples `(a, b)`.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let mut previous = None;
        self.after(self.start).filter_map(move |b| previous.replace(b).map(|a| (a, b)))
    }
}

/// The switches along one path, given the [`Trace`] of each of its samples (by
/// sample index). The traces are read where they lie, never copied: a path (a whole
/// trajectory) takes no memory per sample.
pub fn search_path(
    model: &Model,
    source: &SampleSource,
    path: &Path,
    mode: Mode,
    opts: &SearchOptions,
    trace_of: impl Fn(u64) -> Trace,
    ws: &mut Workspace,
) -> Vec<Discontinuity> {
    search_path_known(model, source, path, mode, opts, trace_of, None, ws)
}

/// [`search_path`] that reads the samples' values from `known` where it has them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn search_path_known(
    model: &Model,
    source: &SampleSource,
    path: &Path,
    mode: Mode,
    opts: &SearchOptions,
    trace_of: impl Fn(u64) -> Trace,
    known: Option<&Known>,
    ws: &mut Workspace,
) -> Vec<Discontinuity> {
    if skipped(model, path.along) {
        return Vec::new();
    }
    let ev = Evaluator::new(model, source, path, mode, opts);
    // The path's traces side by side: a segment's rules read each a dozen times
    // (every limb and kind), and a grid line's lie a stride apart in the run's.
    let mut gathered = SPARE_TRACES.take();
    gathered.clear();
    if path.len() <= GATHERED {
        gathered.extend((0..path.len()).map(|k| trace_of(path.sample_index(k))));
    }
    let in_place = gathered.is_empty();
    let trace = |k: usize| if in_place { trace_of(path.sample_index(k)) } else { gathered[k] };
    let mut solved = Solved::new(&ev, known);
    solved.prefetch(&gathered, path.along);
    let mut out = Vec::new();
    // Unreachable or near-singular samples cut the path into segments.
    let mut start = 0;
    while start < path.len() {
        if trace(start) & SOLVABLE == 0 {
            start += 1;
            continue;
        }
        let mut end = start;
        // Every bit set somewhere in the segment, and the limbs with a determinate
        // negative and a determinate positive axial load.
        let (mut seen, mut negative, mut positive) = (0, 0, 0);
        while end < path.len() {
            let t = trace(end);
            if t & SOLVABLE == 0 {
                break;
            }
            seen |= t;
            for j in 0..3 {
                if t & det_bit(ClearanceKind::RAxial, j) != 0 {
                    if t & neg_bit(j) != 0 {
                        negative |= 1 << j;
                    } else {
                        positive |= 1 << j;
                    }
                }
            }
            end += 1;
        }
        // The crossings of `f_Rj·y_j`, shared by r_axial and r_angular.
        let mut crossings: [Option<Vec<scalar::Crossing>>; 3] = Default::default();
        for kind in KINDS {
            if model.clearance[kind.index()] == 0.0 {
                continue;
            }
            for (j, crossings) in crossings.iter_mut().enumerate() {
                if matches!(kind, ClearanceKind::RAxial | ClearanceKind::RAngular) {
                    // Nothing to find: one sign throughout and no sampled minimum.
                    let changes = negative & positive & (1 << j) != 0;
                    if !changes && seen & min_bit(Decider::Axial, j, path.along) == 0 {
                        continue;
                    }
                    let segment = Segment {
                        trace: &trace,
                        start,
                        end,
                        det: det_bit(ClearanceKind::RAxial, j),
                        along: path.along,
                    };
                    let found = crossings.get_or_insert_with(|| scalar::crossings(&mut solved, &segment, j, ws));
                    for c in found.iter() {
                        let before = c.before.errors(&mut solved, ws);
                        let after = c.after.errors(&mut solved, ws);
                        out.push(ev.record(kind, j, c.p, c.reactions, &before, &after));
                    }
                } else {
                    let d = if kind == ClearanceKind::SRadial { Decider::SRadial } else { Decider::RRadial };
                    if seen & (min_bit(d, j, path.along) | turn_bit(d, j, path.along)) == 0 {
                        continue;
                    }
                    let segment = Segment { trace: &trace, start, end, det: det_bit(kind, j), along: path.along };
                    dips::switches(&mut solved, &segment, d, j, ws, &mut out);
                }
            }
        }
        start = end;
    }
    SPARE_TRACES.set(gathered);
    out
}

// One side of a switch, for the jump across it: a sample of the path, or a point
// between samples (the scalar rule's type, shared).
pub(crate) use crate::scalar_load::Side;

impl Side {
    pub(crate) fn errors(self, solved: &mut Solved<'_>, ws: &mut Workspace) -> KindErrors {
        match self {
            Side::Sample(k) => solved.errors(k, ws),
            Side::At(p) => solved.ev.errors_at(p, ws),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Known, RIGID, Sampled};

    /// `Known` holds consecutive buffers, reads sample `i` from the one that holds it,
    /// lets go of those that hold none of the last `keep` samples, and of all it holds
    /// when the next buffer does not follow them.
    #[test]
    fn known_values_are_held_while_within_reach() {
        let buffer = |n: usize| vec![Sampled::default(); n];
        let mut known = Known::default();
        assert!(known.push(0, buffer(10)).is_empty());
        assert!(known.push(10, buffer(5)).is_empty());
        assert!(known.get(0).is_some() && known.get(14).is_some() && known.get(15).is_none());
        // The 6 samples before 15 reach into the first buffer: both kept.
        assert!(known.trim(15, 6).is_empty());
        let spare = known.trim(15, 5);
        assert_eq!(spare.iter().map(Vec::len).collect::<Vec<_>>(), [10]);
        assert!(known.get(9).is_none() && known.get(10).is_some());
        // Not the next samples: everything held is let go.
        let spare = known.push(40, buffer(3));
        assert_eq!(spare.iter().map(Vec::len).collect::<Vec<_>>(), [5]);
        assert!(known.get(12).is_none() && known.get(41).is_some() && known.get(43).is_none());
        assert_eq!(known.let_go().len(), 1);
        assert!(known.get(41).is_none());
    }

    /// Z-lines of vertical rails hold no switch: on a 3-D grid of every kind, with an
    /// uneven limb layout (parasitic motions by Newton), a point mass and an external
    /// wrench off the centre, searching them finds nothing the search without them
    /// does not, and their Ψ- and Θ-lines hold switches. Rails leaning 30° move the
    /// legs with Z: their Z-lines are searched.
    #[test]
    fn z_lines_of_vertical_rails_lose_no_switch() {
        let grid = "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
            [grid]\nz = { start = 1.9, stop = 2.2, n = 6 }\npsi = { start = -0.5, stop = 0.5, n = 21 }\n\
            theta = { start = -0.5, stop = 0.5, n = 19 }\n";
        let vertical = format!(
            "[mechanism]\nlimb_angles_deg = [0.0, 100.0, 230.0]\n\
             [mass]\npoints = [ {{ mass = 25.0, at = [0.1, 0.0, 1.0] }} ]\n\
             [load]\nforce = [5.0, -3.0, -40.0]\nmoment = [1.0, 2.0, 0.5]\nat = [0.2, 0.1, 0.0]\n{grid}"
        );
        let [(all, searched), (quick, left_out)] = RIGID.both_ways(&vertical);
        assert!(all.len() > 20, "{} switches to lose", all.len());
        assert!(all.iter().all(|d| d.along != crate::Along::Z), "a switch along Z: {all:?}");
        assert_eq!(all, quick);
        // Every Z-line (21 × 19 nodes) searched without the shortcut, none with it.
        assert_eq!((searched, left_out), (21 * 19, 0));
        let inclined = format!("[mechanism]\nrail_angle_deg = 30.0\n{grid}");
        let [(all, none), (quick, _)] = RIGID.both_ways(&inclined);
        assert!(all.iter().any(|d| d.along == crate::Along::Z), "inclined rails switch along Z too");
        assert_eq!(all, quick);
        assert_eq!(none, 0, "inclined rails' Z-lines are not left out");
    }
}
