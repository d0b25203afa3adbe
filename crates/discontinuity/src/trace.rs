//! What the search needs to know of each sample, recorded while a run solves it,
//! so that the search afterwards solves only the few samples around a switch.

use clearance_grid::SampleSource;
use clearance_model::{ClearanceKind, KINDS, Mode};
use clearance_solver::{Model, PoseResult, solve_in_blocks};
use rayon::prelude::*;

use crate::paths::{Along, Axis, axes};
use crate::{SearchOptions, axial, norm, solvable, vector};

/// One sample's [`Trace`], as bits. Bit 0: the sample is solvable. Per kind `k`
/// (order of `KINDS`) and limb `j`, bit `1 + 3k + j`: the deciding load is above
/// the noise floor (determinate). Bits `13 + j`: `f_Rj·y_j` is negative (a sign
/// change lies between samples of opposite signs). Then, per input a path may follow
/// (slot `x`: 0 for time or Z, 1 for Ψ, 2 for Θ), the candidates of the
/// search along that input (docs/model.md §8), each a pre-filter that the search
/// checks exactly:
///
/// - bits `16 + 9x + 3d + j`, for the magnitude of `f_Sj` (d = 0), `f⊥j` (1) and
///   `f_Rj·y_j` (2, the scalar load of `r_axial` and `r_angular`): as far as the
///   samples in hand show ([`keep_local_minima`]), an interior local minimum of the
///   magnitude along the line through the sample, whatever its value (a dip below the
///   threshold can hide between samples above it, so only the refined minimum
///   decides);
/// - bits `43 + 6x + 3d + j` (`f_Sj`, `f⊥j`): the load's direction may turn by more
///   than 90° to the next sample along the line (or that sample is indeterminate, or
///   not in hand), so a dip may hide between monotone samples.
pub type Trace = u64;

pub(crate) const SOLVABLE: Trace = 1;

pub(crate) fn det_bit(kind: ClearanceKind, j: usize) -> Trace {
    1 << (1 + 3 * kind.index() + j)
}

/// The loads a trace follows the magnitude of: `f_Sj`, `f⊥j`, and `f_Rj·y_j`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Decider {
    SRadial = 0,
    RRadial = 1,
    Axial = 2,
}

impl Decider {
    pub(crate) const ALL: [Decider; 3] = [Decider::SRadial, Decider::RRadial, Decider::Axial];

    /// The clearance kind whose determinate bit the search follows.
    pub(crate) fn kind(self) -> ClearanceKind {
        match self {
            Decider::SRadial => ClearanceKind::SRadial,
            Decider::RRadial => ClearanceKind::RRadial,
            Decider::Axial => ClearanceKind::RAxial,
        }
    }

    /// Index of its magnitude in [`Loads`].
    fn slot(self, j: usize) -> usize {
        3 * self as usize + j
    }
}

/// The slot of an input's candidate bits: time and Z share one (a trajectory has no
/// other input, a grid no time).
pub(crate) fn slot(along: Along) -> usize {
    match along {
        Along::T | Along::Z => 0,
        Along::Psi => 1,
        Along::Theta => 2,
    }
}

/// Candidate bit: an interior local minimum of the magnitude along the line.
pub(crate) fn min_bit(d: Decider, j: usize, along: Along) -> Trace {
    1 << (16 + 9 * slot(along) + 3 * d as usize + j)
}

/// `f_Rj·y_j < 0`.
pub(crate) fn neg_bit(j: usize) -> Trace {
    1 << (13 + j)
}

/// Candidate bit of a vector load: its direction may turn by more than 90° to the
/// next sample along the line.
pub(crate) fn turn_bit(d: Decider, j: usize, along: Along) -> Trace {
    debug_assert!(d != Decider::Axial, "a scalar load has no direction");
    1 << (43 + 6 * slot(along) + 3 * d as usize + j)
}

/// One input of each slot: the inputs whose candidate bits a trace holds.
const INPUTS: [Along; 3] = [Along::Z, Along::Psi, Along::Theta];

/// Every candidate bit of one slot's input, or of all three.
pub(crate) fn settled_bits(along: Option<Along>) -> Trace {
    let mut m = 0;
    for a in INPUTS {
        if along.is_some_and(|x| slot(x) != slot(a)) {
            continue;
        }
        for j in 0..3 {
            for d in Decider::ALL {
                m |= min_bit(d, j, a);
                if d != Decider::Axial {
                    m |= turn_bit(d, j, a);
                }
            }
        }
    }
    m
}

/// What [`keep_local_minima`] needs of one sample beside its trace: the magnitudes
/// of `f_Sj`, `f⊥j` and `f_Rj·y_j`, and the directions of `f_Sj` and `f⊥j`. The
/// directions are single precision: they only decide which intervals the search
/// looks at, with a slack (`TURN_SLACK`), and the search checks those in full.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Loads {
    magnitude: [f64; 9],
    direction: [[f32; 3]; 6],
}

/// The [`Trace`] of one solved sample, before [`keep_local_minima`], with its loads.
pub fn trace_loads(r: &PoseResult, model: &Model) -> (Trace, Loads) {
    let mut loads = Loads::default();
    let t = trace_into(r, model, &mut loads);
    (t, loads)
}

/// [`trace_loads`] with the loads written into `loads` (a run's buffer), which
/// spares a copy per pose. Every candidate bit of a determinate load is set.
#[inline]
pub fn trace_into(r: &PoseResult, model: &Model, loads: &mut Loads) -> Trace {
    *loads = Loads::default();
    if !solvable(r) {
        return 0;
    }
    let reactions = &r.reactions;
    let mut t = SOLVABLE;
    // Every candidate bit of one load, along each input.
    let mins = |d: Decider, j: usize| INPUTS.iter().fold(0, |m, &a| m | min_bit(d, j, a));
    let turns = |d: Decider, j: usize| INPUTS.iter().fold(0, |m, &a| m | turn_bit(d, j, a));
    for j in 0..3 {
        // Each deciding load once: its magnitude is the kind's margin (`margin`).
        let s = axial(reactions, model, j);
        let vectors = [Decider::SRadial, Decider::RRadial].map(|d| {
            let v = vector(reactions, model, d.kind(), j);
            (d, v, norm(v))
        });
        let m = reactions.m_r[j];
        let margins = [vectors[0].2, vectors[1].2, s.abs(), norm([m.x, m.y, m.z])];
        for (kind, margin) in KINDS.into_iter().zip(margins) {
            if margin > model.indeterminate_floor {
                t |= det_bit(kind, j);
            }
        }
        if s.is_sign_negative() {
            t |= neg_bit(j);
        }
        for (d, v, n) in vectors {
            if n > 0.0 {
                loads.direction[d.slot(j)] = v.map(|x| (x / n) as f32);
            }
            loads.magnitude[d.slot(j)] = n;
            if t & det_bit(d.kind(), j) != 0 {
                t |= turns(d, j) | mins(d, j);
            }
        }
        loads.magnitude[Decider::Axial.slot(j)] = s.abs();
        if t & det_bit(Decider::Axial.kind(), j) != 0 {
            t |= mins(Decider::Axial, j);
        }
    }
    t
}

/// The [`Trace`] of one solved sample, with every candidate bit still set.
pub fn trace(r: &PoseResult, model: &Model) -> Trace {
    trace_loads(r, model).0
}

/// Relative slack of the comparisons in [`keep_local_minima`]: the search solves
/// the samples again (reactions only), and a round-off difference must not hide a
/// minimum it would find.
const SLACK: f64 = 1e-9;

/// Two single-precision unit directions whose dot product is below this may turn
/// by more than 90° (the rounding of each is about 1e-7).
const TURN_SLACK: f32 = 1e-4;

/// The traces of the samples `first..first + traces.len()` with the candidate bits
/// cleared where the samples in hand rule them out, input by input: a minimum bit
/// where the sample is not an interior local minimum of that magnitude along the
/// line of that input, a turn bit where the direction turns by less than 90° to the
/// next sample along it (and every bit of an input that does not vary).
/// A neighbour outside the range, or indeterminate, leaves the bit set (the search
/// decides), so the result never depends on where a range starts or ends; only the
/// work does. No minimum bit is cleared for the directions at the samples: the
/// search compares directions at points between samples, which those do not tell.
/// Samples are settled in parallel.
pub fn keep_local_minima(axes: &[Axis], first: u64, traces: &[Trace], loads: &[Loads]) -> Vec<Trace> {
    keep_local_minima_of(axes, first, traces, loads, 0..traces.len())
}

/// [`keep_local_minima`] of the samples `which` (indices into `traces`) alone, the
/// others only in hand as their neighbours.
pub fn keep_local_minima_of(
    axes: &[Axis],
    first: u64,
    traces: &[Trace],
    loads: &[Loads],
    which: std::ops::Range<usize>,
) -> Vec<Trace> {
    assert_eq!(traces.len(), loads.len(), "one load set per trace");
    assert!(axes.len() <= 3, "at most three inputs vary");
    assert!(which.end <= traces.len(), "samples to settle within those in hand");
    let n = traces.len();
    let settled = settled_bits(None);
    // The bits of inputs that do not vary: no path follows them.
    let unused = axes.iter().fold(settled, |m, a| m & !settled_bits(Some(a.along)));
    // Per load `q = 3d + j` (the slot of `Decider::ALL[d]`, limb `j`) a bit `q`:
    // its determinate bit is bit `1 + q` of a trace (the deciders' kinds are the
    // first three of `KINDS`), its candidate bits along an input `mins + q` and
    // `turns + q` (the vector loads, `q < 6`).
    debug_assert!((0..9).all(|q| det_bit(Decider::ALL[q / 3].kind(), q % 3) == 1 << (1 + q)));
    // The loads whose minimum at magnitudes `here` the neighbour `k` does not rule
    // out: every one where it is not in hand or unsolvable; else those indeterminate
    // there and those whose magnitude there is not below.
    let allowed = |k: Option<usize>, here: &[f64; 9]| -> Trace {
        let Some(k) = k.filter(|&k| k < n) else { return LOADS };
        let tk = traces[k];
        if tk & SOLVABLE == 0 {
            return LOADS;
        }
        let there = &loads[k].magnitude;
        let mut not_below = 0;
        for q in 0..9 {
            not_below |= Trace::from(here[q] <= there[q] * (1.0 + SLACK)) << q;
        }
        (!(tk >> 1) | not_below) & LOADS
    };
    // The vector loads whose direction may turn on the interval to the next sample
    // `k` from directions `here`: every one past the path's end; none where `k` is
    // unsolvable (no interval); else those indeterminate there (the interval skips
    // it) and those turning by about 90° or more.
    let turning = |k: usize, here: &[[f32; 3]; 6]| -> Trace {
        if k >= n {
            return VECTORS;
        }
        let tk = traces[k];
        if tk & SOLVABLE == 0 {
            return 0;
        }
        let there = &loads[k].direction;
        let mut turn = 0;
        for q in 0..6 {
            let (u, v) = (here[q], there[q]);
            turn |= Trace::from(u[0] * v[0] + u[1] * v[1] + u[2] * v[2] < TURN_SLACK) << q;
        }
        (!(tk >> 1) | turn) & VECTORS
    };
    which
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let mut t = traces[i];
            if t & settled == 0 {
                return t;
            }
            t &= !unused;
            let global = first + i as u64;
            let here = &loads[i];
            for a in axes {
                let x = slot(a.along);
                let (mins, turns) = (16 + 9 * x, 43 + 6 * x);
                let s = a.stride as usize;
                if t & (LOADS << mins) != 0 {
                    // A minimum only at an interior sample that neither neighbour along
                    // this axis rules out.
                    let keep = if a.is_end(global) {
                        0
                    } else {
                        allowed(i.checked_sub(s), &here.magnitude) & allowed(Some(i + s), &here.magnitude)
                    };
                    t &= !((LOADS & !keep) << mins);
                }
                if t & (VECTORS << turns) != 0 {
                    // A turn only towards a next node.
                    let ahead = (global / a.stride) % a.n + 1 < a.n;
                    let keep = if ahead { turning(i + s, &here.direction) } else { 0 };
                    t &= !((VECTORS & !keep) << turns);
                }
            }
            t
        })
        .collect()
}

/// The bits of the nine loads a trace follows the magnitude of, and of the six
/// vector loads among them, as [`keep_local_minima_of`] sets them out.
const LOADS: Trace = 0x1ff;
const VECTORS: Trace = 0x3f;

/// Samples whose traces [`traces`] settles together: bounds the memory of their loads.
const TRACE_CHUNK: u64 = 1 << 16;
/// Samples solved together by one worker.
const BLOCK: u64 = 1024;

/// The [`Trace`] of the samples in `range` of a (variant, mode), solving each once.
/// `opts` are the search's settings (no bit depends on them since the traces stopped
/// clearing the minima the search set aside for their sample directions).
pub fn traces(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    range: std::ops::Range<u64>,
    opts: &SearchOptions,
) -> Vec<Trace> {
    let _ = opts;
    let axes = axes(source);
    let mut out = Vec::with_capacity((range.end - range.start) as usize);
    for chunk in clearance_grid::chunks(range.end - range.start, TRACE_CHUNK) {
        let first = range.start + chunk.start;
        let last = range.start + chunk.end;
        let (t, loads): (Vec<Trace>, Vec<Loads>) = solve_in_blocks(model, source, first..last, mode, BLOCK, |_, rs| {
            rs.iter().map(|r| trace_loads(r, model)).collect::<Vec<_>>()
        })
        .flatten_iter()
        .unzip();
        out.extend(keep_local_minima(&axes, first, &t, &loads));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::margin;
    use std::sync::Arc;

    /// [`keep_local_minima_of`] as it was first written, a candidate bit at a time
    /// through `min_bit` and `turn_bit`: the reference the table-driven loops must
    /// equal.
    fn reference(
        axes: &[Axis],
        first: u64,
        traces: &[Trace],
        loads: &[Loads],
        which: std::ops::Range<usize>,
    ) -> Vec<Trace> {
        let n = traces.len();
        let settled = settled_bits(None);
        let unused = axes.iter().fold(settled, |m, a| m & !settled_bits(Some(a.along)));
        which
            .into_iter()
            .map(|i| {
                let mut t = traces[i];
                if t & settled == 0 {
                    return t;
                }
                t &= !unused;
                let global = first + i as u64;
                for a in axes {
                    let s = a.stride as usize;
                    // The neighbours along this axis (in hand or not) where the sample is
                    // interior, and whether there is a next node.
                    let interior = !a.is_end(global);
                    let (before, after) = (i.checked_sub(s), i + s);
                    let ahead = (global / a.stride) % a.n + 1 < a.n;
                    for j in 0..3 {
                        for d in Decider::ALL {
                            let det = det_bit(d.kind(), j);
                            let slot = d.slot(j);
                            let bit = min_bit(d, j, a.along);
                            if t & bit != 0 {
                                let here = loads[i].magnitude[slot];
                                // Whether the sample `k` (if in hand) does not rule out a minimum here.
                                let allows = |k: Option<usize>| match k.filter(|&k| k < n) {
                                    Some(k) => {
                                        traces[k] & SOLVABLE == 0
                                            || traces[k] & det == 0
                                            || here <= loads[k].magnitude[slot] * (1.0 + SLACK)
                                    }
                                    None => true,
                                };
                                if !(interior && allows(before) && allows(Some(after))) {
                                    t &= !bit;
                                }
                            }
                            if d == Decider::Axial || t & turn_bit(d, j, a.along) == 0 {
                                continue;
                            }
                            let u = loads[i].direction[slot];
                            // Whether the interval to the next sample may turn: an
                            // unsolvable one ends the segment (no interval), an
                            // indeterminate one is skipped by it.
                            let turns = |k: usize| {
                                if k >= n {
                                    return true;
                                }
                                if traces[k] & SOLVABLE == 0 {
                                    return false;
                                }
                                if traces[k] & det == 0 {
                                    return true;
                                }
                                let v = loads[k].direction[slot];
                                u[0] * v[0] + u[1] * v[1] + u[2] * v[2] < TURN_SLACK
                            };
                            if !(ahead && turns(after)) {
                                t &= !turn_bit(d, j, a.along);
                            }
                        }
                    }
                }
                t
            })
            .collect()
    }

    /// [`trace_into`] as it was first written, each kind's margin and each load
    /// computed on its own: the reference the one-pass form must equal.
    fn trace_reference(r: &PoseResult, model: &Model, loads: &mut Loads) -> Trace {
        *loads = Loads::default();
        if !solvable(r) {
            return 0;
        }
        let reactions = &r.reactions;
        let mut t = SOLVABLE;
        for kind in KINDS {
            for j in 0..3 {
                if margin(reactions, model, kind, j) > model.indeterminate_floor {
                    t |= det_bit(kind, j);
                }
            }
        }
        for j in 0..3 {
            for d in Decider::ALL {
                let determinate = t & det_bit(d.kind(), j) != 0;
                let magnitude = if d == Decider::Axial {
                    let s = axial(reactions, model, j);
                    if s.is_sign_negative() {
                        t |= neg_bit(j);
                    }
                    s.abs()
                } else {
                    let v = vector(reactions, model, d.kind(), j);
                    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    if n > 0.0 {
                        loads.direction[d.slot(j)] = v.map(|x| (x / n) as f32);
                    }
                    if determinate {
                        t |= INPUTS.iter().fold(0, |m, &a| m | turn_bit(d, j, a));
                    }
                    n
                };
                loads.magnitude[d.slot(j)] = magnitude;
                if determinate {
                    t |= INPUTS.iter().fold(0, |m, &a| m | min_bit(d, j, a));
                }
            }
        }
        t
    }

    /// Bit for bit the reference, traces and loads, on a grid of poses with
    /// indeterminate take-ups (a floor at the loads' own scale), negative axial loads
    /// and unsolvable poses beyond reach.
    #[test]
    fn a_trace_is_the_reference_trace() {
        use clearance_grid::SampleSource;
        use clearance_model::JobSpec;
        use clearance_solver::{Workspace, solve_pose};
        let text = "[mass]\npoints = [{ mass = 30.0, at = [0.1, 0.0, 1.0] }]\n\
            [clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
            [analysis]\nindeterminate_load_fraction = 0.05\nsingular_cond = 40.0\n\
            [grid]\nz = { start = 1.2, stop = 3.2, n = 4 }\n\
            psi = { start = -1.5, stop = 1.5, n = 31 }\ntheta = { start = -1.5, stop = 1.5, n = 31 }\n";
        let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
        let model = Model::from_job(&job);
        let source = SampleSource::new(&job);
        let mut ws = Workspace::new();
        let (mut unsolvable, mut indeterminate, mut negative) = (0, 0, 0);
        for i in 0..source.len() {
            let r = solve_pose(&model, &source.sample(i), Mode::Kinetostatic, &mut ws);
            let mut ours = Loads::default();
            let mut theirs = Loads { magnitude: [1.0; 9], direction: [[1.0; 3]; 6] };
            let t = trace_into(&r, &model, &mut ours);
            assert_eq!(t, trace_reference(&r, &model, &mut theirs), "sample {i}");
            let bits = |l: &Loads| (l.magnitude.map(f64::to_bits), l.direction.map(|d| d.map(f32::to_bits)));
            assert_eq!(bits(&ours), bits(&theirs), "sample {i}");
            unsolvable += usize::from(t == 0);
            indeterminate += usize::from(t != 0 && (t >> 1) & 0xfff != 0xfff);
            negative += usize::from(t & (0b111 << 13) != 0);
        }
        assert!(unsolvable > 0 && indeterminate > 0 && negative > 0, "{unsolvable} {indeterminate} {negative}");
    }

    /// A small generator (the crate takes no random-number dependency).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            self.0 >> 11
        }

        fn pick<T: Copy>(&mut self, from: &[T]) -> T {
            from[(self.next() % from.len() as u64) as usize]
        }
    }

    /// Bit for bit the reference, on grids of one to three varying inputs with
    /// samples that are unsolvable, indeterminate, tied (within the slack or not),
    /// NaN, turning by about 90° or exactly opposite, settled whole or in part.
    #[test]
    fn the_settled_bits_are_the_reference_bits() {
        let mut rng = Lcg(7);
        let magnitudes = [0.0, 1.0, 1.0 + 5e-10, 1.0 + 2e-9, 2.0, 3.0, f64::NAN];
        let components: [f32; 5] = [-1.0, -0.01, 0.0, 0.01, 1.0];
        let grids: [&[(Along, u64)]; 4] = [
            &[(Along::Psi, 7)],
            &[(Along::T, 9)],
            &[(Along::Psi, 5), (Along::Theta, 6)],
            &[(Along::Z, 3), (Along::Psi, 4), (Along::Theta, 5)],
        ];
        let mut cleared = 0;
        for grid in grids {
            let mut stride = 1;
            let mut axes: Vec<Axis> = grid
                .iter()
                .rev()
                .map(|&(along, n)| {
                    let a = Axis { along, stride, n, params: Arc::from((0..n).map(|k| k as f64).collect::<Vec<_>>()) };
                    stride *= n;
                    a
                })
                .collect();
            axes.reverse();
            let total = stride as usize;
            for round in 0..200 {
                let traces: Vec<Trace> = (0..total)
                    .map(|_| {
                        let bits = rng.next() | rng.next() << 53;
                        match rng.next() % 8 {
                            0 => bits & !SOLVABLE,
                            1 => 0,
                            _ => bits | SOLVABLE,
                        }
                    })
                    .collect();
                let loads: Vec<Loads> = (0..total)
                    .map(|_| Loads {
                        magnitude: std::array::from_fn(|_| rng.pick(&magnitudes)),
                        direction: std::array::from_fn(|_| std::array::from_fn(|_| rng.pick(&components))),
                    })
                    .collect();
                // The whole grid in hand from its first sample, or a part of it
                // settled with a later first sample.
                let (first, which) = if round % 2 == 0 {
                    (0, 0..total)
                } else {
                    let lo = (rng.next() % total as u64) as usize;
                    let hi = lo + (rng.next() % (total - lo) as u64) as usize;
                    (rng.next() % (3 * stride), lo..hi)
                };
                let ours = keep_local_minima_of(&axes, first, &traces, &loads, which.clone());
                let theirs = reference(&axes, first, &traces, &loads, which.clone());
                assert_eq!(ours, theirs, "grid {grid:?}, round {round}");
                cleared += which.zip(&ours).map(|(i, t)| (traces[i] & !t).count_ones()).sum::<u32>();
            }
        }
        // The cases clear bits, not only keep them.
        assert!(cleared > 10_000, "{cleared} bits cleared");
    }
}
