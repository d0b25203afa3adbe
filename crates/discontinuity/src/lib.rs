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
//!   samples, located by bisection;
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

pub use minimise::{bisect, brent_min};
pub use paths::{Along, Path, paths};

use clearance_grid::{Sample, SampleSource};
use clearance_model::{ClearanceKind, KINDS, Mode};
use clearance_solver::{Model, PoseError, PoseResult, Status, Workspace, solve_pose};
use rayon::prelude::*;

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
    let y = model.geometry.y[j];
    let fr = r.reactions.f_r[j];
    match kind {
        ClearanceKind::RAxial => Load::Scalar(fr.dot(&y)),
        ClearanceKind::RRadial => {
            let p = fr - fr.dot(&y) * y;
            Load::Vector([p.x, p.y, p.z])
        }
        ClearanceKind::SRadial => {
            let f = r.reactions.f_s[j];
            Load::Vector([f.x, f.y, f.z])
        }
        ClearanceKind::RAngular => {
            let m = r.reactions.m_r[j];
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
    fn at(&self, p: f64, ws: &mut Workspace) -> (Sample, PoseResult) {
        let s = self.path.sample_at(self.source, p);
        let r = solve_pose(self.model, &s, self.mode, ws);
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
        let (s, r) = self.at(p, ws);
        let margin = if solvable(&r) { load(&r, self.model, kind, j).magnitude() } else { f64::NAN };
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

/// The switches along one path.
pub fn search_path(
    model: &Model,
    source: &SampleSource,
    path: &Path,
    mode: Mode,
    opts: &SearchOptions,
    ws: &mut Workspace,
) -> Vec<Discontinuity> {
    let ev = Evaluator { model, source, path, mode };
    let results: Vec<PoseResult> =
        (0..path.len()).map(|k| solve_pose(model, &source.sample(path.sample_index(k)), mode, ws)).collect();
    let mut out = Vec::new();
    // Unreachable or near-singular samples cut the path into segments.
    let mut start = 0;
    while start < results.len() {
        if !solvable(&results[start]) {
            start += 1;
            continue;
        }
        let mut end = start;
        while end < results.len() && solvable(&results[end]) {
            end += 1;
        }
        for kind in KINDS {
            if model.clearance[kind.index()] == 0.0 {
                continue;
            }
            for j in 0..3 {
                // Determinate samples of this segment, for this joint and kind.
                let det: Vec<usize> = (start..end)
                    .filter(|&i| load(&results[i], model, kind, j).magnitude() > model.indeterminate_floor)
                    .collect();
                if kind == ClearanceKind::RAxial {
                    axial_switches(&ev, &results, &det, j, ws, &mut out);
                } else {
                    vector_switches(&ev, &results, &det, kind, j, opts, ws, &mut out);
                }
            }
        }
        start = end;
    }
    out
}

fn axial_switches(
    ev: &Evaluator<'_>,
    results: &[PoseResult],
    det: &[usize],
    j: usize,
    ws: &mut Workspace,
    out: &mut Vec<Discontinuity>,
) {
    let kind = ClearanceKind::RAxial;
    let signed = |r: &PoseResult| load(r, ev.model, kind, j).signed();
    for w in det.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (fa, fb) = (signed(&results[a]), signed(&results[b]));
        if fa.signum() == fb.signum() {
            continue;
        }
        let (pa, pb) = (ev.path.params[a], ev.path.params[b]);
        let p = bisect(pa, pb, fa, LOCATE_TOL, |p| {
            let (_, r) = ev.at(p, ws);
            if solvable(&r) { signed(&r) } else { 0.0 }
        });
        out.push(ev.record(kind, j, p, ws, &results[a], &results[b]));
    }
}

#[allow(clippy::too_many_arguments)]
fn vector_switches(
    ev: &Evaluator<'_>,
    results: &[PoseResult],
    det: &[usize],
    kind: ClearanceKind,
    j: usize,
    opts: &SearchOptions,
    ws: &mut Workspace,
    out: &mut Vec<Discontinuity>,
) {
    let mag: Vec<f64> = det.iter().map(|&i| load(&results[i], ev.model, kind, j).magnitude()).collect();
    for k in 1..det.len().saturating_sub(1) {
        // An interior local minimum (the first sample of a flat bottom).
        if !(mag[k] < mag[k - 1] && mag[k] <= mag[k + 1]) || mag[k] >= opts.dip_threshold {
            continue;
        }
        let (lo, hi) = (ev.path.params[det[k - 1]], ev.path.params[det[k + 1]]);
        let (p, m) = brent_min(lo, hi, LOCATE_TOL / 10.0, |p| {
            let (_, r) = ev.at(p, ws);
            if solvable(&r) { load(&r, ev.model, kind, j).magnitude() } else { f64::INFINITY }
        });
        // Where the magnitude has risen back to twice the minimum, on either side.
        let left = (0..k).rev().find(|&i| mag[i] >= 2.0 * m).unwrap_or(0);
        let right = (k + 1..det.len()).find(|&i| mag[i] >= 2.0 * m).unwrap_or(det.len() - 1);
        let (rl, rr) = (&results[det[left]], &results[det[right]]);
        let turn = load(rl, ev.model, kind, j).dot(load(rr, ev.model, kind, j));
        if turn < 0.0 {
            out.push(ev.record(kind, j, p, ws, rl, rr));
        }
    }
}

/// All switches of one (variant, mode), paths searched in parallel; the order is
/// that of [`paths`], then of the search, whatever the thread count.
pub fn find_discontinuities(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
) -> Vec<Discontinuity> {
    paths(source)
        .par_iter()
        .map_init(Workspace::new, |ws, path| search_path(model, source, path, mode, opts, ws))
        .flatten_iter()
        .collect()
}
