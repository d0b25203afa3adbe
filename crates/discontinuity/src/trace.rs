//! What the search needs to know of each sample, recorded while a run solves it,
//! so that the search afterwards solves only the few samples around a switch.

use clearance_grid::SampleSource;
use clearance_model::{ClearanceKind, KINDS, Mode};
use clearance_solver::{Model, PoseResult, solve_in_blocks};
use rayon::prelude::*;

use crate::paths::{Axis, axes};
use crate::{Load, SearchOptions, load, solvable};

/// One sample's [`Trace`], as bits: whether it is solvable, and per (kind, limb)
/// whether the deciding load is determinate and whether the sample is a candidate
/// for the search:
///
/// - `r_axial`: the load is negative (a switch lies between samples of opposite sign);
/// - vector loads: the magnitude is below the dip threshold and, as far as the
///   samples in hand show ([`keep_local_minima`]), an interior local minimum along
///   some path. Only those can be switches; the search checks them exactly.
pub type Trace = u32;

pub(crate) const SOLVABLE: Trace = 1;

pub(crate) fn det_bit(kind: ClearanceKind, j: usize) -> Trace {
    1 << (1 + 3 * kind.index() + j)
}

pub(crate) fn low_bit(kind: ClearanceKind, j: usize) -> Trace {
    det_bit(kind, j) << LOW_SHIFT
}

/// How far a (kind, limb)'s low bit lies above its determinate bit.
pub(crate) const LOW_SHIFT: u32 = 12;

/// The deciding load magnitudes of one sample, by `3·kind.index() + limb`
/// (zero where it is not solvable).
pub type Loads = [f64; 12];

/// The [`Trace`] of one solved sample, before [`keep_local_minima`], with its load
/// magnitudes.
pub fn trace_loads(r: &PoseResult, model: &Model, opts: &SearchOptions) -> (Trace, Loads) {
    let mut loads = [0.0; 12];
    let t = trace_into(r, model, opts, &mut loads);
    (t, loads)
}

/// [`trace_loads`] with the magnitudes written into `loads` (a run's buffer), which
/// spares a copy per pose.
#[inline]
pub fn trace_into(r: &PoseResult, model: &Model, opts: &SearchOptions, loads: &mut Loads) -> Trace {
    *loads = [0.0; 12];
    if !solvable(r) {
        return 0;
    }
    let mut t = SOLVABLE;
    for kind in KINDS {
        for j in 0..3 {
            let l = load(r, model, kind, j);
            let magnitude = l.magnitude();
            loads[3 * kind.index() + j] = magnitude;
            if magnitude > model.indeterminate_floor {
                t |= det_bit(kind, j);
            }
            let low = match l {
                Load::Scalar(s) => s.is_sign_negative(),
                Load::Vector(_) => magnitude < opts.dip_threshold,
            };
            if low {
                t |= low_bit(kind, j);
            }
        }
    }
    t
}

/// The [`Trace`] of one solved sample, with every low vector load still a candidate.
pub fn trace(r: &PoseResult, model: &Model, opts: &SearchOptions) -> Trace {
    trace_loads(r, model, opts).0
}

/// Relative slack of the comparisons in [`keep_local_minima`]: the search solves
/// the samples again (reactions only), and a round-off difference must not hide a
/// minimum it would find.
const SLACK: f64 = 1e-9;

/// The traces of the samples `first..first + traces.len()` with the vector-load
/// candidate bits cleared where the sample cannot be an interior local minimum
/// along any path: the search then never solves it. A neighbour outside the range,
/// not solvable or indeterminate leaves the sample a candidate (the search
/// decides), so the result never depends on where a range starts or ends; only the
/// work does. Samples are settled in parallel.
pub fn keep_local_minima(axes: &[Axis], first: u64, traces: &[Trace], loads: &[Loads]) -> Vec<Trace> {
    assert_eq!(traces.len(), loads.len(), "one load set per trace");
    assert!(axes.len() <= 3, "at most three inputs vary");
    let n = traces.len();
    let vector_low: Trace = KINDS
        .iter()
        .filter(|&&k| k != ClearanceKind::RAxial)
        .flat_map(|&k| (0..3).map(move |j| low_bit(k, j)))
        .fold(0, |m, b| m | b);
    (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let mut t = traces[i];
            if t & vector_low == 0 {
                return t;
            }
            // The neighbours along each axis on which the sample is not a path's end.
            let mut along = [(None, None); 3];
            let mut interior = 0;
            for a in axes.iter().filter(|a| !a.is_end(first + i as u64)) {
                let s = a.stride as usize;
                along[interior] = (i.checked_sub(s), i.checked_add(s));
                interior += 1;
            }
            for kind in KINDS {
                if kind == ClearanceKind::RAxial {
                    continue;
                }
                for j in 0..3 {
                    let (low, det) = (low_bit(kind, j), det_bit(kind, j));
                    if t & low == 0 {
                        continue;
                    }
                    let slot = 3 * kind.index() + j;
                    let here = loads[i][slot];
                    // Whether the sample `k` (if in hand) does not rule out a minimum here.
                    let allows = |k: Option<usize>| match k.filter(|&k| k < n) {
                        Some(k) => {
                            traces[k] & SOLVABLE == 0 || traces[k] & det == 0 || here <= loads[k][slot] * (1.0 + SLACK)
                        }
                        None => true,
                    };
                    let candidate = along[..interior].iter().any(|&(before, after)| allows(before) && allows(after));
                    if !candidate {
                        t &= !low;
                    }
                }
            }
            t
        })
        .collect()
}

/// Samples whose traces [`traces`] settles together: bounds the memory of their
/// load magnitudes.
const TRACE_CHUNK: u64 = 1 << 16;
/// Samples solved together by one worker.
const BLOCK: u64 = 1024;

/// The [`Trace`] of the samples in `range` of a (variant, mode), solving each once.
pub fn traces(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
    range: std::ops::Range<u64>,
) -> Vec<Trace> {
    let axes = axes(source);
    let mut out = Vec::with_capacity((range.end - range.start) as usize);
    for chunk in clearance_grid::chunks(range.end - range.start, TRACE_CHUNK) {
        let first = range.start + chunk.start;
        let last = range.start + chunk.end;
        let (t, loads): (Vec<Trace>, Vec<Loads>) = solve_in_blocks(model, source, first..last, mode, BLOCK, |_, rs| {
            rs.iter().map(|r| trace_loads(r, model, opts)).collect::<Vec<_>>()
        })
        .flatten_iter()
        .unzip();
        out.extend(keep_local_minima(&axes, first, &t, &loads));
    }
    out
}
