//! # clearance-discontinuity
//!
//! Where the pose error jumps (docs/model.md §8). Take-up directions follow the joint
//! loads; where a deciding load changes sign (`r_axial`: `f_Rj·y_j`) or passes
//! through or near zero and swings round (`s_radial`: `f_Sj`, `r_radial`: `f⊥`),
//! the distal part of the joint jumps to the opposite wall and the error steps.
//!
//! Every [`Path`] (a trajectory, or each grid line along each input) is searched:
//!
//! - scalar loads, `f_Rj·y_j` for both `r_axial` and `r_angular` (in the 3-limb
//!   kinds `m_Rj = |A_j − B_j|·(f_Rj·y_j)·u_j`, so the angular take-up flips exactly
//!   where the axial load changes sign; its margin is `|m_Rj|`): a switch wherever
//!   the sign differs between consecutive determinate samples, located by
//!   interpolation ([`interpolated_root`]), and two where an interval beside a sampled minimum of `|f_Rj·y_j|`
//!   holds an extremum of the opposite sign (two crossings between samples of one
//!   sign);
//! - vector loads: every interior sampled minimum of the magnitude is refined on
//!   each of the two intervals beside it on its own (from the load vectors,
//!   [`vector_min`]), and so is every interval whose end directions differ by more than
//!   90°; a refined minimum below `discontinuity_load_fraction·W` is a switch if the
//!   take-up directions where the magnitude has risen back to twice that minimum
//!   (never less than twice the noise floor; the point located between the samples
//!   that bracket it, [`vector_load::locate`]), at the sampled maximum before another
//!   dip, or at the path's ends, differ by more than 90°. A switch is then polished
//!   as the root of `f·df/ds` ([`vector_polish`]). Brent's methods
//!   ([`brent_root`], [`brent_min`]) take over where a pose between samples is
//!   unsolvable or the interpolation does not settle.
//!
//! Samples whose deciding load is within the noise floor are indeterminate and left
//! out; unreachable and near-singular samples cut a path into separate segments. So
//! does a point between two samples that the search finds it cannot solve: no switch
//! is kept in that interval (nor, for a minimum at a sample, beside it).
//! The Z-lines of a 3-PRS with vertical rails carry the same loads at every height
//! and are not searched.
//! Locations are refined to [`LOCATE_TOL`] in the path parameter, so the result does
//! not depend on the sample spacing, short of dips too narrow for it to show.
//! Which samples the search looks at comes from each sample's [`Trace`], recorded
//! while a run solves it.
//!
//! [`vector_load`] and [`scalar_load`] hold the rules for one vector or scalar load
//! along one path apart from any mechanism (the 6-UPS and custom searches call them,
//! and so can any search that has a path's sampled loads and a way to solve the load
//! between samples); they too leave indeterminate samples out and stop at gaps.

mod dips;
mod minimise;
mod paths;
mod scalar;
pub mod scalar_load;
mod search;
mod shortcut;
mod trace;
pub mod vector_load;

pub use minimise::{brent_min, brent_root, interpolated_root, vector_min, vector_polish};
pub use paths::{Along, Axis, Path, axes, paths};
use search::{Known, search_path_known};
pub use search::{Sampled, search_path};
pub use trace::{Loads, Trace, keep_local_minima, keep_local_minima_of, trace, trace_into, trace_loads, traces};

use clearance_grid::SampleSource;
use clearance_model::{ClearanceKind, Mode};
use clearance_solver::{JointReactions, Model, PoseResult, Status, Workspace};
use nalgebra::Vector3;
use rayon::prelude::*;

/// Locations are refined to this absolute tolerance in the path parameter (rad, m or s).
pub const LOCATE_TOL: f64 = 1e-9;

/// Relative tolerance (of the sample interval) of the minimisations that look for a
/// dip or an extremum of the other sign, before a switch is located to
/// [`LOCATE_TOL`]: the minimum's value is then good to `1e-8` of the dip's depth,
/// and every sampled minimum takes a third of the evaluations it took to 1e-9.
const SCAN_TOL: f64 = 1e-4;

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
    /// `discontinuity_load_fraction·W`: refined vector-load minima at or above this
    /// are not switches.
    pub dip_threshold: f64,
}

/// Whether the search looks at the lines along `along` at all: not those along which
/// no load changes (the Z-lines of a 3-PRS with vertical rails, docs/model.md §8).
pub fn searched_along(model: &Model, along: Along) -> bool {
    !search::loads_invariant(model, along)
}

/// The forces that decide the take-ups of the forces' kinds: those of
/// [`JointReactions`], or of a sample the search reads ([`Sampled`]).
trait Forces {
    /// `f_Rj`.
    fn f_r(&self, j: usize) -> Vector3<f64>;
    /// `f_Sj`.
    fn f_s(&self, j: usize) -> Vector3<f64>;
}

impl Forces for JointReactions {
    fn f_r(&self, j: usize) -> Vector3<f64> {
        self.f_r[j]
    }
    fn f_s(&self, j: usize) -> Vector3<f64> {
        self.f_s[j]
    }
}

/// `f_Rj·y_j`: the scalar load that decides `r_axial` and `r_angular`.
fn axial(reactions: &impl Forces, model: &Model, j: usize) -> f64 {
    reactions.f_r(j).dot(&model.geometry.y[j])
}

/// The vector load deciding `s_radial` (`f_Sj`) or `r_radial` (`f⊥`).
fn vector(reactions: &impl Forces, model: &Model, kind: ClearanceKind, j: usize) -> [f64; 3] {
    let v = match kind {
        ClearanceKind::SRadial => reactions.f_s(j),
        ClearanceKind::RRadial => {
            let (fr, y) = (reactions.f_r(j), model.geometry.y[j]);
            fr - fr.dot(&y) * y
        }
        _ => unreachable!("{kind:?} is searched as a scalar"),
    };
    [v.x, v.y, v.z]
}

/// The magnitude of the load deciding a take-up (its contact margin), as the
/// solver's take-up reports it: `|f_Sj|`, `|f⊥|`, `|f_Rj·y_j|`, `|m_Rj|`.
fn margin(reactions: &JointReactions, model: &Model, kind: ClearanceKind, j: usize) -> f64 {
    match kind {
        ClearanceKind::RAxial => axial(reactions, model, j).abs(),
        ClearanceKind::RAngular => {
            let m = reactions.m_r[j];
            norm([m.x, m.y, m.z])
        }
        _ => norm(vector(reactions, model, kind, j)),
    }
}

fn norm(v: [f64; 3]) -> f64 {
    dot(v, v).sqrt()
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn solvable(r: &PoseResult) -> bool {
    matches!(r.status, Status::Ok | Status::IndeterminateContact)
}

/// All switches of one (variant, mode) from the traces of its samples (indexed by
/// sample), paths searched in parallel; the order is that of [`paths`], then of the
/// search, whatever the thread count.
pub fn find_discontinuities_traced(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
    traces: &[Trace],
) -> Vec<Discontinuity> {
    let mut search = Search::new(model, source, mode, opts);
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
    opts: &SearchOptions,
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
                .map_init(Workspace::new, |ws, path| search_path(model, source, path, mode, opts, |i| buf[at(i)], ws))
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
    opts: SearchOptions,
    /// The traces received so far, from sample 0.
    traces: Vec<Trace>,
    /// The paths of each axis, in [`paths`] order, with the switches found on the
    /// paths searched so far (the first ones: a path's last sample grows with its
    /// position within its axis).
    axes: Vec<(Vec<Path>, Vec<Discontinuity>, usize)>,
    /// The values the run's pass solved at the last samples received, where it gave
    /// them ([`Search::extend_known`]).
    known: Known,
}

impl<'a> Search<'a> {
    pub fn new(model: &'a Model, source: &'a SampleSource, mode: Mode, opts: &SearchOptions) -> Self {
        let mut axes: Vec<(Vec<Path>, Vec<Discontinuity>, usize)> = Vec::new();
        for path in paths(source) {
            match axes.last_mut() {
                Some((group, _, _)) if group[0].along == path.along => group.push(path),
                _ => axes.push((vec![path], Vec::new(), 0)),
            }
        }
        // Every sample's trace comes in, unit by unit: grown as they came, the traces
        // of a 3-D grid were copied and faulted in again at each doubling.
        let traces = Vec::with_capacity(source.len() as usize);
        Self { model, source, mode, opts: *opts, traces, axes, known: Known::default() }
    }

    /// [`Search::extend`] with the values the pass solved at those samples
    /// (`values`, empty or one per trace): the paths read them rather than solve the
    /// samples again (the same switches, fewer solves). Holds on to the values of the
    /// last `keep` samples received, for the paths the next samples complete; returns
    /// the buffers of values it no longer holds, to reuse.
    pub fn extend_known(&mut self, traces: &[Trace], values: Vec<Sampled>, keep: u64) -> Vec<Vec<Sampled>> {
        let mut spare = self.receive(traces, values);
        spare.extend(self.search_ready(keep).1);
        spare
    }

    /// How many values handed to [`Search::extend_known`] its paths have read since
    /// the last call: whether storing them is worth it.
    pub fn known_reads(&self) -> u64 {
        self.known.take_reads()
    }

    /// Lets go of the values held ([`Search::extend_known`]): the buffers, to reuse.
    pub fn let_go_known(&mut self) -> Vec<Vec<Sampled>> {
        self.known.let_go()
    }

    /// Adds the traces of the next samples and searches the paths they complete;
    /// returns how many that was.
    pub fn extend(&mut self, traces: &[Trace]) -> usize {
        self.receive(traces, Vec::new());
        self.search_ready(self.source.len()).0
    }

    /// Adds the traces of the next samples, with the values the pass solved there
    /// (`values`, empty or one per trace), without searching the paths they complete:
    /// those are the next [`Search::batches`]. Returns the buffers of values let go of
    /// (the values held must be of the samples just before these, else they go).
    pub fn receive(&mut self, traces: &[Trace], values: Vec<Sampled>) -> Vec<Vec<Sampled>> {
        let spare = self.known.push(self.traces.len() as u64, values);
        self.traces.extend_from_slice(traces);
        assert!(self.traces.len() as u64 <= self.source.len(), "more traces than samples");
        spare
    }

    /// The paths whose traces are all in and that are not searched yet, in path
    /// order, as about `most` batches of consecutive paths of one axis (a batch
    /// a path at most): tasks that [`Search::search_batch`] runs on any thread.
    pub fn batches(&self, most: usize) -> Vec<Batch> {
        let have = self.traces.len() as u64;
        let ready: Vec<(usize, std::ops::Range<usize>)> = self
            .axes
            .iter()
            .enumerate()
            .map(|(axis, (paths, _, searched))| {
                let n = paths[*searched..].partition_point(|p| p.is_empty() || p.sample_index(p.len() - 1) < have);
                (axis, *searched..*searched + n)
            })
            .collect();
        let size = ready.iter().map(|(_, r)| r.len()).sum::<usize>().div_ceil(most.max(1)).max(1);
        let mut out = Vec::new();
        for (axis, range) in ready {
            for first in range.clone().step_by(size) {
                out.push(Batch { axis, paths: first..(first + size).min(range.end) });
            }
        }
        out
    }

    /// The switches on the paths of `batch` (one of [`Search::batches`]), in path
    /// order: for [`Search::searched`].
    pub fn search_batch(&self, batch: &Batch) -> Vec<Discontinuity> {
        let (model, source, mode, opts) = (self.model, self.source, self.mode, &self.opts);
        let (traces, known) = (&self.traces, &self.known);
        // A batch is a few lines: a fresh workspace (its matrices) for each was a
        // few percent of a sweep's search.
        let mut ws = SPARE_WORKSPACE.take().unwrap_or_default();
        let mut out = Vec::new();
        for path in &self.axes[batch.axis].0[batch.paths.clone()] {
            out.extend(search_path_known(
                model,
                source,
                path,
                mode,
                opts,
                |i| traces[i as usize],
                Some(known),
                &mut ws,
            ));
        }
        SPARE_WORKSPACE.set(Some(ws));
        out
    }

    /// Takes the switches of `batches` (all of the last [`Search::batches`], in their
    /// order), `found` one vector per batch: their paths are searched. Lets go of the
    /// values of all but the last `keep` samples received; returns their buffers.
    pub fn searched(&mut self, batches: &[Batch], found: Vec<Vec<Discontinuity>>, keep: u64) -> Vec<Vec<Sampled>> {
        assert_eq!(batches.len(), found.len(), "the switches of every batch");
        for (batch, switches) in batches.iter().zip(found) {
            let (_, all, searched) = &mut self.axes[batch.axis];
            assert_eq!(*searched, batch.paths.start, "batches taken in order");
            all.extend(switches);
            *searched = batch.paths.end;
        }
        self.known.trim(self.traces.len() as u64, keep)
    }

    /// The paths ready ([`Search::batches`]) searched in parallel on the rayon pool;
    /// how many that was, and the buffers of values let go of.
    fn search_ready(&mut self, keep: u64) -> (usize, Vec<Vec<Sampled>>) {
        let batches = self.batches(BATCHES_PER_THREAD * rayon::current_num_threads());
        let found: Vec<Vec<Discontinuity>> = batches.par_iter().map(|b| self.search_batch(b)).collect();
        let count = batches.iter().map(|b| b.paths.len()).sum();
        (count, self.searched(&batches, found, keep))
    }

    /// Clears in the traces received from sample `first` on the bits that `traces`
    /// (theirs, settled again with more samples in hand: [`keep_local_minima`] over a
    /// range that reaches into the next samples) does not have. The paths not yet
    /// searched then look at fewer candidates; the switches are the same.
    #[track_caller]
    pub fn refine(&mut self, first: u64, traces: &[Trace]) {
        let first = first as usize;
        let mine = &mut self.traces[first..first + traces.len()];
        for (t, settled) in mine.iter_mut().zip(traces) {
            *t &= settled;
        }
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

thread_local! {
    /// Each thread's workspace for [`Search::search_batch`], kept from batch to batch.
    static SPARE_WORKSPACE: std::cell::Cell<Option<Workspace>> = const { std::cell::Cell::new(None) };
}

/// Batches of paths a search splits its ready paths into, per thread of the pool
/// ([`Search::batches`]): enough that no thread waits long on another's last one.
pub const BATCHES_PER_THREAD: usize = 16;

/// Consecutive paths of one axis of a [`Search`], completed and not searched yet.
#[derive(Clone, Debug)]
pub struct Batch {
    axis: usize,
    paths: std::ops::Range<usize>,
}

/// The switches along one path whose samples' traces are not at hand (a grid line
/// that crosses parts another shard computed): its samples are solved here and
/// traced along this path alone. The candidate bits of a trace only spare the search
/// work, each is checked exactly, so the switches are those [`search_path`] finds
/// with the run's traces.
pub fn search_untraced(
    model: &Model,
    source: &SampleSource,
    path: &Path,
    mode: Mode,
    opts: &SearchOptions,
    ws: &mut Workspace,
) -> Vec<Discontinuity> {
    if search::left_out(model, path.along) {
        // Not a sample solved for a line that holds no switch.
        return Vec::new();
    }
    let n = path.len();
    let traces = if path.is_consecutive() {
        // Consecutive samples (a trajectory, or a line of the fastest input): traced
        // as a run traces them, a block at a time, 8 bytes a sample in memory.
        let origin = path.sample_index(0);
        traces(model, source, mode, origin..origin + n as u64, opts)
    } else {
        // A line across the faster inputs (a grid dimension long), traced along itself
        // alone: the path as the one axis of a source of its own samples.
        let samples: Vec<_> = (0..n).map(|k| source.sample(path.sample_index(k))).collect();
        let mut results = vec![PoseResult::default(); n];
        clearance_solver::solve_poses(model, &samples, mode, ws, &mut results);
        let (traces, loads): (Vec<Trace>, Vec<Loads>) = results.iter().map(|r| trace_loads(r, model)).unzip();
        let axis = Axis { along: path.along, stride: 1, n: n as u64, params: path.params.clone() };
        keep_local_minima(&[axis], 0, &traces, &loads)
    };
    search_path(model, source, path, mode, opts, |i| traces[path.position(i)], ws)
}

/// All switches of one (variant, mode), every sample solved here.
pub fn find_discontinuities(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
) -> Vec<Discontinuity> {
    find_discontinuities_traced(model, source, mode, opts, &traces(model, source, mode, 0..source.len(), opts))
}
