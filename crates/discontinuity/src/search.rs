//! The search along one path: its segments, the samples solved on demand, and how
//! a switch is recorded. The rules themselves are in [`crate::scalar`] and
//! [`crate::dips`].

use clearance_grid::{Sample, SampleSource};
use clearance_model::{ClearanceKind, KINDS, MechanismKind, Mode};
use clearance_solver::{
    JointReactions, Model, PoseError, Workspace, solve_errors, solve_reactions, solve_reactions_if_solvable,
};
use std::cell::RefCell;
use std::collections::HashMap;

use crate::shortcut::Shortcut;
use crate::trace::{Decider, SOLVABLE, Trace, det_bit, min_bit, neg_bit, turn_bit};
use crate::{Along, Discontinuity, Path, SearchOptions, dips, margin, scalar};

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

fn error_of(errors: &[PoseError; 4], kind: ClearanceKind) -> [f64; 6] {
    let e = &errors[kind.index()];
    [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z]
}

pub(crate) struct Evaluator<'a> {
    pub model: &'a Model,
    pub source: &'a SampleSource,
    pub path: &'a Path,
    pub mode: Mode,
    pub opts: &'a SearchOptions,
    /// The reactions at the last few points between samples, by the bits of their
    /// parameter: a root finder returns a point it has evaluated, and the switch it
    /// locates is recorded there once for each kind it decides (`r_axial` and
    /// `r_angular` share theirs).
    recent: RefCell<Recent>,
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
        Self { model, source, path, mode, opts, recent: RefCell::default() }
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
        if let Some((_, r)) = recent.at.iter().flatten().find(|(k, _)| *k == key) {
            return *r;
        }
        let s = self.path.sample_at(self.source, p);
        let r = solve_reactions_if_solvable(self.model, &s, self.mode, ws);
        let next = recent.next;
        recent.at[next] = Some((key, r));
        recent.next = (next + 1) % RECENT;
        r
    }

    /// The per-kind errors at path parameter `p` (for the jump across a switch).
    pub fn errors_at(&self, p: f64, ws: &mut Workspace) -> [PoseError; 4] {
        solve_errors(self.model, &self.path.sample_at(self.source, p), self.mode, ws)
    }

    pub fn record(
        &self,
        kind: ClearanceKind,
        j: usize,
        p: f64,
        ws: &mut Workspace,
        before: &[PoseError; 4],
        after: &[PoseError; 4],
    ) -> Discontinuity {
        let s = self.path.sample_at(self.source, p);
        let r = self.reactions_at(p, ws);
        let margin = r.map_or(f64::NAN, |r| margin(&r, self.model, kind, j));
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
pub(crate) struct Solved<'a> {
    pub ev: &'a Evaluator<'a>,
    maps: Maps,
}

/// The solved samples of a path by index: per-kind errors (for the jump across a
/// switch), and reactions only, for following loads, of the few samples near a
/// candidate (a slot per sample of the path was a quarter of the search's time).
#[derive(Default)]
struct Maps {
    cache: HashMap<usize, [PoseError; 4]>,
    reactions: HashMap<usize, JointReactions>,
}

thread_local! {
    /// Each thread's [`Maps`], emptied after each path: a 3-D grid has tens of
    /// thousands of short paths, and growing two maps afresh for each made the
    /// search's threads wait on the allocator's locks (a third of the search's
    /// samples on `grid_3d`, `perf`).
    static SPARE_MAPS: std::cell::Cell<Option<Maps>> = const { std::cell::Cell::new(None) };
}

/// Maps that grew past this many entries (a long trajectory's) are dropped, not kept.
const KEPT_ENTRIES: usize = 1 << 12;

impl Drop for Solved<'_> {
    fn drop(&mut self) {
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
    fn new(ev: &'a Evaluator<'a>) -> Self {
        Self { ev, maps: SPARE_MAPS.take().unwrap_or_default() }
    }

    /// The reactions at the `k`-th sample (a solvable one).
    pub fn reactions(&mut self, k: usize, ws: &mut Workspace) -> &JointReactions {
        let ev = self.ev;
        self.maps
            .reactions
            .entry(k)
            .or_insert_with(|| solve_reactions(ev.model, &ev.node(k), ev.mode, ws).unwrap_or_default())
    }

    /// The per-kind errors at the `k`-th sample of the path.
    pub fn errors(&mut self, k: usize, ws: &mut Workspace) -> [PoseError; 4] {
        let ev = self.ev;
        *self.maps.cache.entry(k).or_insert_with(|| solve_errors(ev.model, &ev.node(k), ev.mode, ws))
    }
}

/// The samples `start..end` of a path (one segment: all solvable) whose deciding
/// load of one limb is determinate, found from their traces as needed.
pub(crate) struct Segment<'a> {
    pub trace: &'a dyn Fn(usize) -> Trace,
    pub start: usize,
    pub end: usize,
    pub det: Trace,
    /// The input the path follows: which candidate bits are its.
    pub along: Along,
}

impl Segment<'_> {
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
    if skipped(model, path.along) {
        return Vec::new();
    }
    let ev = Evaluator::new(model, source, path, mode, opts);
    let trace = |k: usize| trace_of(path.sample_index(k));
    let mut solved = Solved::new(&ev);
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
                        out.push(ev.record(kind, j, c.p, ws, &before, &after));
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
    out
}

/// One side of a switch, for the jump across it: a sample of the path, or a point
/// between samples.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Side {
    Sample(usize),
    At(f64),
}

impl Side {
    pub fn errors(self, solved: &mut Solved<'_>, ws: &mut Workspace) -> [PoseError; 4] {
        match self {
            Side::Sample(k) => solved.errors(k, ws),
            Side::At(p) => solved.ev.errors_at(p, ws),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::RIGID;

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
