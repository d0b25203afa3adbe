//! One pose through the whole pipeline: kinematics → reactions → take-up → error.

use clearance_grid::{Sample, SampleSource};
use clearance_kinematics::inverse_kinematics_motion;
use clearance_model::Mode;
use faer::Mat;
use rayon::prelude::*;

use crate::bodies::SolverKind;
use crate::bodies::{Inertial, Model};
use crate::equilibrium::{self, JointReactions};
use crate::error_system::{self, PoseError};
use crate::exact::exact_error;
use crate::fast::{Errors, Loads, Points, Pose, Reactions, Reduced, euler_inverse, pose_error};
use crate::lanes::{F8, LANES, Lane, Mask, lane3};
use crate::linalg::LuSolver;
use crate::takeup::{Margins, TakeUp, TakeUps, take_ups};

/// What became of a pose (docs/conventions.md gives the precedence and what each
/// status leaves null).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Status {
    #[default]
    Ok,
    Unreachable,
    NearSingular,
    IndeterminateContact,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Unreachable => "unreachable",
            Status::NearSingular => "near_singular",
            Status::IndeterminateContact => "indeterminate_contact",
        }
    }

    pub const ALL: [Status; 4] = [Status::Ok, Status::Unreachable, Status::NearSingular, Status::IndeterminateContact];

    /// The place of this status in [`Status::ALL`].
    pub fn index(self) -> usize {
        Status::ALL.iter().position(|s| *s == self).expect("every status is in ALL")
    }
}

/// Contributions to `|Δp|` within this fraction of the largest tie for the dominant joint.
pub const DOMINANT_TIE: f64 = 1e-9;

/// Everything the engine computes for one (sample, mode).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseResult {
    pub status: Status,
    /// Parasitic motions `X, Y, Φ` (always filled).
    pub x: f64,
    pub y: f64,
    pub phi: f64,
    /// Actuator positions (not for `unreachable`).
    pub q: [f64; 3],
    pub reactions: JointReactions,
    pub margins: Margins,
    /// Per-kind errors in the order of `KINDS`; `kind_ok[k]` says whether kind k's
    /// take-up was determinate.
    pub errors: [PoseError; 4],
    pub kind_ok: [bool; 4],
    /// All kinds together.
    pub total: PoseError,
    pub cond_a: f64,
    pub cond_jp: f64,
    /// Exact error `[Δα; Δp]` (only with `analysis.exact` on an `ok` pose).
    pub exact: Option<[f64; 6]>,
    /// The worst case over every admissible take-up, per kind (order of `KINDS`):
    /// the largest `|Δp_x|, |Δp_y|, |Δp_z|, |Δα_x|, |Δα_y|, |Δα_z|`, and bounds on `|Δp|`
    /// and `|Δα|` (ok and indeterminate poses; NaN when `Model::envelope` is off).
    pub envelope: [[f64; 8]; 4],
    /// Each joint's own contribution to `|Δp|` of the deterministic error, by kind and
    /// limb (ok poses; NaN when `Model::envelope` is off).
    pub contribution: [[f64; 3]; 4],
    /// The joint whose own take-up moves P most, `(kind index, limb index)`: see
    /// [`PoseResult::dominant_of`].
    pub dominant: Option<(usize, usize)>,
}

impl PoseResult {
    /// Sets the envelope and the joints' contributions, and the dominant joint they give.
    fn set_envelope(&mut self, clearance: &[f64; 4], envelope: [[f64; 8]; 4], contribution: [[f64; 3]; 4]) {
        (self.envelope, self.contribution) = (envelope, contribution);
        self.dominant = self.dominant_of(clearance);
    }

    /// This result as if solved with each kind's clearance magnitude multiplied by
    /// `scale` (order of `KINDS`).
    ///
    /// The reactions, margins and conditioning do not depend on the magnitudes
    /// (docs/model.md §§4–5); each kind's error (§6), its envelope and its joints'
    /// contributions are proportional to its own magnitude; a kind scaled to zero is
    /// determinate and moves nothing, as a zero clearance is. So the status and the
    /// dominant joint follow from the scaled parts. A variant of a sweep that changes
    /// only `[clearance]` is its group's solve, scaled: the same numbers as solving it
    /// alone, to round-off. The exact error (§7) is not linear in the magnitudes: a
    /// result that carries one is not to be scaled.
    #[track_caller]
    pub fn scaled(&self, scale: &[f64; 4]) -> PoseResult {
        assert!(self.exact.is_none(), "an exact error does not scale with the clearances");
        let mut r = *self;
        if !matches!(self.status, Status::Ok | Status::IndeterminateContact) {
            return r;
        }
        r.status = scale_kinds(scale, &mut r.errors, &mut r.envelope, &mut r.contribution, &mut r.kind_ok);
        r.total = crate::error_system::total(&r.errors);
        // Only which kinds have a clearance matters: those the scale keeps.
        r.dominant = r.dominant_of(scale);
        r
    }

    /// The envelope of all kinds together: each kind's bound summed.
    pub fn envelope_total(&self) -> [f64; 8] {
        std::array::from_fn(|c| self.envelope.iter().map(|k| k[c]).sum())
    }

    /// The joint whose take-up moves P most, as `(kind index, limb index)`: among the
    /// kinds with a clearance, the largest contribution. Contributions within
    /// [`DOMINANT_TIE`] (relative) of the largest are ties, and ties go to the first in
    /// kind, then limb order: equal contributions (a symmetric pose, or `r_axial` and
    /// `r_angular` when `a = θ·ℓ`) differ by round-off, which must not decide.
    /// `None` unless the pose is `ok` and some clearance is non-zero.
    pub fn dominant_of(&self, clearance: &[f64; 4]) -> Option<(usize, usize)> {
        if self.status != Status::Ok {
            return None;
        }
        dominant_joint(
            self.contribution
                .iter()
                .enumerate()
                .filter(|(k, _)| clearance[*k] != 0.0)
                .flat_map(|(k, limbs)| limbs.iter().enumerate().map(move |(j, &v)| ((k, j), v))),
        )
    }
}

/// Scales each kind's error, envelope and joint contributions by its factor in
/// `scale`, marks a kind scaled to zero determinate, and gives the status of a
/// solvable pose that follows: what `PoseResult::scaled` and `UpsResult::scaled`
/// share, for `K` kinds of `L` limbs.
pub(crate) fn scale_kinds<const K: usize, const L: usize>(
    scale: &[f64; K],
    errors: &mut [PoseError; K],
    envelope: &mut [[f64; 8]; K],
    contribution: &mut [[f64; L]; K],
    kind_ok: &mut [bool; K],
) -> Status {
    for (k, &s) in scale.iter().enumerate() {
        errors[k] = errors[k].scaled(s);
        envelope[k] = envelope[k].map(|v| v * s);
        contribution[k] = contribution[k].map(|v| v * s);
        if s == 0.0 {
            kind_ok[k] = true;
        }
    }
    if kind_ok.contains(&false) { Status::IndeterminateContact } else { Status::Ok }
}

/// The first `(kind, limb)` whose contribution is within [`DOMINANT_TIE`] (relative) of
/// the largest finite one, candidates in tie order (kind, then limb); `None` when there
/// is no finite candidate.
pub fn dominant_joint(candidates: impl Iterator<Item = ((usize, usize), f64)> + Clone) -> Option<(usize, usize)> {
    let finite = candidates.filter(|(_, v)| v.is_finite());
    let best = finite.clone().map(|(_, v)| v).fold(f64::NEG_INFINITY, f64::max);
    finite.into_iter().find(|(_, v)| *v >= best - DOMINANT_TIE * best.abs()).map(|(at, _)| at)
}

impl Default for PoseResult {
    /// An unreachable pose at NaN parasitic motions: a placeholder to be overwritten.
    fn default() -> Self {
        Self::unreachable(f64::NAN, f64::NAN, f64::NAN)
    }
}

impl PoseResult {
    fn unreachable(x: f64, y: f64, phi: f64) -> Self {
        Self {
            status: Status::Unreachable,
            x,
            y,
            phi,
            q: [f64::NAN; 3],
            reactions: JointReactions::default(),
            margins: Margins::default(),
            errors: [PoseError::default(); 4],
            kind_ok: [false; 4],
            total: PoseError::default(),
            cond_a: f64::NAN,
            cond_jp: f64::NAN,
            exact: None,
            envelope: [[f64::NAN; 8]; 4],
            contribution: [[f64::NAN; 3]; 4],
            dominant: None,
        }
    }
}

/// Scratch for one worker thread: sized once, reused for every pose.
pub struct Workspace {
    a: Mat<f64>,
    w: Mat<f64>,
    lu_a: LuSolver,
    jp: Mat<f64>,
    dq: Mat<f64>,
    lu_jp: LuSolver,
}

impl Default for Workspace {
    fn default() -> Self {
        Self::new()
    }
}

impl Workspace {
    pub fn new() -> Self {
        Self {
            a: Mat::zeros(24, 24),
            w: Mat::zeros(24, 1),
            lu_a: LuSolver::new(24, 1),
            jp: Mat::zeros(12, 12),
            dq: Mat::zeros(12, 4),
            lu_jp: LuSolver::new(12, 4),
        }
    }

    /// The last assembled `A` (for tests and diagnostics).
    pub fn a(&self) -> &Mat<f64> {
        &self.a
    }

    /// The last assembled `J_P`.
    pub fn jp(&self) -> &Mat<f64> {
        &self.jp
    }
}

/// Newton started at the nominal pose can land on another assembly of the
/// mechanism near a singularity. The exact error agrees with the linear one to
/// second order, so a solution further from it than the linear error's own size is
/// not the pose the clearances produce: it is reported as null.
fn same_branch(exact: &[f64; 6], linear: &PoseError) -> bool {
    let lin = [linear.dalpha.x, linear.dalpha.y, linear.dalpha.z, linear.dp.x, linear.dp.y, linear.dp.z];
    let size = lin.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    exact.iter().zip(lin).all(|(e, l)| (e - l).abs() <= size)
}

/// The nominal posture of a sample, the loads on its bodies and their motion;
/// `None` where a leg cannot reach.
fn posture(model: &Model, sample: &Sample, mode: Mode) -> Option<(Pose<f64>, Loads<f64>, Inertial)> {
    let geom = &model.geometry;
    match mode {
        Mode::Kinetostatic => {
            let pose = Pose::new(geom, sample.z[0], sample.psi[0], sample.theta[0]);
            pose.reachable.then(|| (pose, Loads::statics(model, &pose), Inertial::default()))
        }
        Mode::Dynamic => inverse_kinematics_motion(geom, sample.z, sample.psi, sample.theta).ok().map(|(p, m)| {
            let inertial = Inertial::from_motion(&p, &m, &model.mass);
            (Pose::from_posture(geom, &p), Loads::dynamics(model, &p, &inertial), inertial)
        }),
    }
}

/// The joint reactions alone, for searches that follow loads between poses whose
/// status is already known: the same numbers as [`solve_pose`]'s reactions, without
/// the conditioning, take-up and errors. `None` where `solve_pose` has no reactions.
pub fn solve_reactions(model: &Model, sample: &Sample, mode: Mode, ws: &mut Workspace) -> Option<JointReactions> {
    reactions_only(model, sample, mode, ws, false, None)
}

/// The joint reactions of a pose that [`solve_pose`] solves (status ok or
/// indeterminate contact), else `None`: the same numbers and the same verdict,
/// without the take-up and the errors. For searches that evaluate loads at poses
/// whose status is not known, such as a refinement between two samples.
pub fn solve_reactions_if_solvable(
    model: &Model,
    sample: &Sample,
    mode: Mode,
    ws: &mut Workspace,
) -> Option<JointReactions> {
    reactions_only(model, sample, mode, ws, true, None)
}

/// [`solve_reactions_if_solvable`], also setting `posed` to the points as
/// [`solve_poses_posed`] gives them, where the solve has it at hand (statics and the
/// fast solver; elsewhere `posed` is left as it is).
pub fn solve_reactions_posed(
    model: &Model,
    sample: &Sample,
    mode: Mode,
    ws: &mut Workspace,
    posed: &mut Option<Points>,
) -> Option<JointReactions> {
    reactions_only(model, sample, mode, ws, true, Some(posed))
}

fn reactions_only(
    model: &Model,
    sample: &Sample,
    mode: Mode,
    ws: &mut Workspace,
    conditioned: bool,
    posed: Option<&mut Option<Points>>,
) -> Option<JointReactions> {
    if model.solver == SolverKind::General {
        let r = solve_pose(model, sample, mode, ws);
        return matches!(r.status, Status::Ok | Status::IndeterminateContact).then_some(r.reactions);
    }
    let (pose, loads, _) = posture(model, sample, mode)?;
    if let Some(posed) = posed
        && mode == Mode::Kinetostatic
    {
        *posed = Some(pose.points(0));
    }
    // As `solve_fast` decides: both condition numbers within the limit (NaN is not),
    // shown by a bound where it can be.
    let (reduced, solvable) = if conditioned {
        let (reduced, within) = Reduced::new_within(model, &pose, model.singular_cond);
        (reduced, !pose.across && within)
    } else {
        let reduced = Reduced::new(model, &pose, false);
        let solvable = !pose.across && reduced.regular();
        (reduced, solvable)
    };
    solvable.then(|| reduced.reactions(model, &pose, &loads).get(0))
}

/// The per-kind pose errors of [`solve_pose`]'s result, with the same bits (zero where
/// it does not solve the pose), without the rest of it: what a discontinuity's jump
/// reads either side of a switch. The fast solver builds neither the result (over a
/// kilobyte) nor the exact error; the general one is `solve_pose`.
pub fn solve_errors(model: &Model, sample: &Sample, mode: Mode, ws: &mut Workspace) -> [PoseError; 4] {
    if model.solver == SolverKind::General {
        return solve_pose(model, sample, mode, ws).errors;
    }
    let Some((pose, loads, _)) = posture(model, sample, mode) else {
        return [PoseError::default(); 4];
    };
    // As `solve_fast` decides and computes them, pose by pose.
    let reduced = Reduced::new(model, &pose, true);
    if !pose.reachable || !solved_posture(model, &pose, &reduced) {
        return [PoseError::default(); 4];
    }
    solution(model, &pose, &loads, &reduced).errors.map(|e| e.get(0))
}

/// What the fast solver computes of a solvable posture (every lane's, whatever it is).
struct Solution<L: Lane> {
    reactions: Reactions<L>,
    take: TakeUps<L>,
    errors: [Errors<L>; 4],
    /// Each joint's share of `|Δp|`, with `model.envelope` (else zeros).
    contribution: [[L; 3]; 4],
}

/// Reactions, take-up and per-kind errors from the factored reduction: the one
/// sequence of operations [`solve_fast`] and [`solve_errors`] share, so that their
/// bits agree.
#[inline(always)]
fn solution<L: Lane>(model: &Model, pose: &Pose<L>, loads: &Loads<L>, reduced: &Reduced<L>) -> Solution<L> {
    let reactions = reduced.reactions(model, pose, loads);
    let take = take_ups(&model.geometry, &reactions, &model.clearance, model.indeterminate_floor);
    let inv = euler_inverse(pose);
    let (t, contribution) = reduced.errors(model, pose, &take);
    let errors = [pose_error(t[0], &inv), pose_error(t[1], &inv), pose_error(t[2], &inv), pose_error(t[3], &inv)];
    Solution { reactions, take, errors, contribution }
}

/// Whether a reachable posture is solved: no leg across its rail, and both condition
/// numbers within `singular_cond` (NaN is not). Pose by pose; [`solve_fast`] decides
/// the same lane by lane.
fn solved_posture(model: &Model, pose: &Pose<f64>, reduced: &Reduced<f64>) -> bool {
    let limit = model.singular_cond;
    !pose.across && reduced.cond_g <= limit && reduced.cond_m <= limit
}

/// Runs one sample in one mode. Never panics on a bad pose: it becomes a status.
pub fn solve_pose(model: &Model, sample: &Sample, mode: Mode, ws: &mut Workspace) -> PoseResult {
    let Some((pose, loads, inertial)) = posture(model, sample, mode) else {
        let (x, y, phi) = model.geometry.parasitic(sample.psi[0], sample.theta[0]);
        return PoseResult::unreachable(x, y, phi);
    };
    match model.solver {
        SolverKind::Fast => {
            let mut out = [PoseResult::default()];
            solve_fast(model, &pose, &loads, &mut out);
            out[0]
        }
        SolverKind::General => solve_general(model, &pose, &inertial, ws),
    }
}

/// Solves the kinetostatic poses of `samples` into `out` (same length) with the fast
/// solver, [`LANES`] at a time on the CPU's vector units: the same results, bit for
/// bit, as [`solve_pose`] on each sample (the general solver and dynamics go pose by
/// pose).
pub fn solve_poses(model: &Model, samples: &[Sample], mode: Mode, ws: &mut Workspace, out: &mut [PoseResult]) {
    assert_eq!(samples.len(), out.len(), "one result per sample");
    if model.solver != SolverKind::Fast || mode != Mode::Kinetostatic {
        for (s, o) in samples.iter().zip(out) {
            *o = solve_pose(model, s, mode, ws);
        }
        return;
    }
    solve_batches(model, samples, out, Isa::best());
}

/// [`solve_poses`], with each sample's points as [`Pose::new`] gives them from the
/// sample's `z`, `ψ`, `θ` (the kinetostatic posture's, in either mode), bit for bit:
/// in statics, the batched kernel's own lanes, which it has computed anyway.
pub fn solve_poses_posed(
    model: &Model,
    samples: &[Sample],
    mode: Mode,
    ws: &mut Workspace,
    out: &mut [PoseResult],
    points: &mut [Points],
) {
    assert_eq!(samples.len(), points.len(), "points per sample");
    if model.solver != SolverKind::Fast || mode != Mode::Kinetostatic {
        solve_poses(model, samples, mode, ws, out);
        for (s, p) in samples.iter().zip(points) {
            *p = Pose::new(&model.geometry, s.z[0], s.psi[0], s.theta[0]).points(0);
        }
        return;
    }
    batches(model, samples, out, Some(points), Isa::best());
}

/// Scratch for solving runs of consecutive samples with [`solve_poses`], one per
/// worker thread: the samples and results are reused from run to run.
#[derive(Default)]
pub struct Blocks {
    ws: Workspace,
    samples: Vec<Sample>,
    results: Vec<PoseResult>,
}

impl Blocks {
    /// Samples `range` of `source`, solved in `mode`: each sample beside its result.
    pub fn solve(
        &mut self,
        model: &Model,
        source: &SampleSource,
        range: std::ops::Range<u64>,
        mode: Mode,
    ) -> (&[Sample], &[PoseResult]) {
        self.solve_samples(model, range.map(|i| source.sample(i)), mode)
    }

    /// `samples`, solved in `mode`: each sample beside its result.
    pub fn solve_samples(
        &mut self,
        model: &Model,
        samples: impl IntoIterator<Item = Sample>,
        mode: Mode,
    ) -> (&[Sample], &[PoseResult]) {
        self.samples.clear();
        self.samples.extend(samples);
        self.results.resize(self.samples.len(), PoseResult::default());
        solve_poses(model, &self.samples, mode, &mut self.ws, &mut self.results);
        (&self.samples, &self.results)
    }
}

/// Samples `range` of `source` solved in `mode`, in runs of `block` consecutive
/// samples spread over the rayon pool (one [`Blocks`] per worker); `f` maps each run,
/// its samples beside their results (collecting the outputs keeps the runs in order).
pub fn solve_in_blocks<'a, T: Send>(
    model: &'a Model,
    source: &'a SampleSource,
    range: std::ops::Range<u64>,
    mode: Mode,
    block: u64,
    f: impl Fn(&[Sample], &[PoseResult]) -> T + Sync + Send + 'a,
) -> impl ParallelIterator<Item = T> + 'a {
    let (start, end) = (range.start, range.end);
    (0..(end - start).div_ceil(block)).into_par_iter().map_init(Blocks::default, move |blocks, b| {
        let first = start + b * block;
        let (samples, results) = blocks.solve(model, source, first..end.min(first + block), mode);
        f(samples, results)
    })
}

/// The instruction sets the batched kernel is compiled for; [`Isa::best`] is the
/// widest this CPU has. Every choice gives the same bits (tested).
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    Portable,
    Avx2,
    Avx512,
}

/// The widest instruction set [`Isa::best`] may choose, as an index into `Isa::ALL`.
static ISA_CAP: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(Isa::Avx512 as u8);

/// Caps the instruction set of the batched kernel and of the page encoder for the
/// whole process (every choice gives the same bits; a cap serves nodes where
/// AVX-512 lowers the clock). The binary sets it from `CLEARANCE_ISA`; a library
/// never reads the environment.
pub fn cap_isa(cap: Isa) {
    ISA_CAP.store(cap as u8, std::sync::atomic::Ordering::Relaxed);
}

impl Isa {
    /// Every instruction set, narrowest first.
    const ALL: [Isa; 3] = [Isa::Portable, Isa::Avx2, Isa::Avx512];

    /// The widest this CPU has, capped by [`cap_isa`].
    pub fn best() -> Self {
        let cap = Isa::ALL[ISA_CAP.load(std::sync::atomic::Ordering::Relaxed) as usize];
        Self::detected().min(cap)
    }

    /// The instruction set named `portable`, `avx2` or `avx512`.
    pub fn parse(name: &str) -> Option<Self> {
        Isa::ALL.into_iter().find(|i| i.name() == name)
    }

    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    fn detected() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Isa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Portable
    }

    /// Those this CPU can run.
    pub fn available() -> Vec<Self> {
        Isa::ALL.into_iter().filter(|&i| i <= Isa::detected()).collect()
    }
}

/// [`solve_poses`] for kinetostatic samples and the fast solver, with a chosen
/// instruction set (falls back to the portable code for one this CPU lacks).
#[doc(hidden)]
pub fn solve_batches(model: &Model, samples: &[Sample], out: &mut [PoseResult], isa: Isa) {
    batches(model, samples, out, None, isa);
}

/// [`solve_batches`], with each sample's points where `points` is given.
fn batches(model: &Model, samples: &[Sample], out: &mut [PoseResult], mut points: Option<&mut [Points]>, isa: Isa) {
    assert_eq!(samples.len(), out.len(), "one result per sample");
    let isa = if isa <= Isa::detected() { isa } else { Isa::Portable };
    for (k, (s, o)) in samples.chunks(LANES).zip(out.chunks_mut(LANES)).enumerate() {
        let p = points.as_deref_mut().map(|p| &mut p[k * LANES..k * LANES + s.len()]);
        match isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has AVX-512F (`isa <= Isa::detected()`).
            Isa::Avx512 => unsafe { solve_batch_avx512(model, s, o, p) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has AVX2 (`isa <= Isa::detected()`).
            Isa::Avx2 => unsafe { solve_batch_avx2(model, s, o, p) },
            _ => solve_batch_lanes(model, s, o, p),
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn solve_batch_avx512(model: &Model, samples: &[Sample], out: &mut [PoseResult], points: Option<&mut [Points]>) {
    solve_batch_lanes(model, samples, out, points)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve_batch_avx2(model: &Model, samples: &[Sample], out: &mut [PoseResult], points: Option<&mut [Points]>) {
    solve_batch_lanes(model, samples, out, points)
}

/// Up to [`LANES`] kinetostatic samples; a short batch repeats its last sample. Each
/// lane's points into `points`, where given.
#[inline(always)]
fn solve_batch_lanes(model: &Model, samples: &[Sample], out: &mut [PoseResult], points: Option<&mut [Points]>) {
    let last = samples.len() - 1;
    let input = |f: fn(&Sample) -> f64| {
        let mut v = [0.0; LANES];
        for (i, x) in v.iter_mut().enumerate() {
            *x = f(&samples[i.min(last)]);
        }
        F8(v)
    };
    let pose = Pose::new(&model.geometry, input(|s| s.z[0]), input(|s| s.psi[0]), input(|s| s.theta[0]));
    if let Some(points) = points {
        // Lane by lane from the arrays, as one transposition: `Pose::points` reads each
        // value through `Lane::get`, which takes the eight lanes by value (five times
        // the instructions here).
        let v = |v: &crate::lanes::V3<F8>, i: usize| nalgebra::Vector3::new(v.x.0[i], v.y.0[i], v.z.0[i]);
        for (i, p) in points.iter_mut().enumerate().take(LANES) {
            *p = Points {
                a: pose.a.each_ref().map(|a| v(a, i)),
                b: pose.b.each_ref().map(|b| v(b, i)),
                e: pose.e.each_ref().map(|e| v(e, i)),
                p: v(&pose.p, i),
            };
        }
    }
    solve_fast(model, &pose, &Loads::statics(model, &pose), out);
}

/// The fast solver on one pose or a batch, into one result per lane of `out`.
#[inline(always)]
fn solve_fast<L: Lane>(model: &Model, pose: &Pose<L>, loads: &Loads<L>, out: &mut [PoseResult]) {
    let any = |m: L::M| (0..out.len()).any(|i| m.get(i));
    if !any(pose.reachable) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = PoseResult::unreachable(pose.x.get(i), pose.y.get(i), pose.phi.get(i));
        }
        return;
    }
    let reduced = Reduced::new(model, pose, true);
    let conditioned = |k: L| k.le(L::constant(model.singular_cond));
    let solvable = pose.reachable & !pose.across & conditioned(reduced.cond_g) & conditioned(reduced.cond_m);
    if !any(solvable) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = unsolved(pose, &reduced, i);
        }
        return;
    }
    let Solution { reactions, take, errors, contribution } = solution(model, pose, loads, &reduced);
    let envelope = model.envelope.then(|| reduced.envelope(model, pose));
    let totals_only = model.totals_only && !model.exact && envelope.is_none();
    for (i, o) in out.iter_mut().enumerate() {
        if !solvable.get(i) {
            *o = unsolved(pose, &reduced, i);
            continue;
        }
        let cond = (reduced.cond_g.get(i), reduced.cond_m.get(i));
        let e = [errors[0].get(i), errors[1].get(i), errors[2].get(i), errors[3].get(i)];
        if totals_only {
            finish_totals(o, pose, i, cond, take.indeterminate.map(|d| !d.get(i)), &e);
            continue;
        }
        *o = finish(model, pose, i, cond, reactions.get(i), &take.get(i), e);
        if let Some(env) = &envelope {
            // Lane `i` read in place: `map` on the arrays would copy all lanes' 2.8 kB
            // for each lane first.
            let lane = |k: usize, c: usize| env[k][c].get(i);
            let env = std::array::from_fn(|k| std::array::from_fn(|c| lane(k, c)));
            let share = std::array::from_fn(|k| std::array::from_fn(|j| contribution[k][j].get(i)));
            o.set_envelope(&model.clearance, env, share);
        }
    }
}

/// Lane `i`'s result up to its conditioning: unreachable, or near-singular until
/// [`finish`]ed.
#[inline(always)]
fn unsolved<L: Lane>(pose: &Pose<L>, reduced: &Reduced<L>, i: usize) -> PoseResult {
    let mut r = PoseResult::unreachable(pose.x.get(i), pose.y.get(i), pose.phi.get(i));
    if pose.reachable.get(i) {
        r.q = lane3(&pose.q, i);
        r.cond_a = reduced.cond_g.get(i);
        r.cond_jp = reduced.cond_m.get(i);
        r.status = Status::NearSingular;
    }
    r
}

/// The general path: conditioning from the reduction, then the assembled 24 × 24
/// and 12 × 12 systems solved by faer.
fn solve_general(model: &Model, pose: &Pose<f64>, inertial: &Inertial, ws: &mut Workspace) -> PoseResult {
    let geom = &model.geometry;
    let reduced = Reduced::new(model, pose, true);
    let posture = pose.posture(0);
    let mut result = PoseResult::unreachable(pose.x, pose.y, pose.phi);
    result.q = pose.q;
    result.cond_a = reduced.cond_g;
    result.cond_jp = reduced.cond_m;
    result.status = Status::NearSingular;
    if !solved_posture(model, pose, &reduced) {
        return result;
    }
    equilibrium::assemble(model, &posture, inertial, ws.a.as_mut(), ws.w.as_mut());
    if !ws.lu_a.solve(ws.a.as_ref(), ws.w.as_mut()) {
        return result;
    }
    let reactions = equilibrium::reactions_from(model, &ws.w);
    let takes = take_ups(geom, &Reactions::from_joint(&reactions), &model.clearance, model.indeterminate_floor);
    let take = takes.get(0);
    error_system::assemble(&posture, &geom.y, &take, ws.jp.as_mut(), ws.dq.as_mut());
    if !ws.lu_jp.solve(ws.jp.as_ref(), ws.dq.as_mut()) {
        return result;
    }
    let errors = error_system::errors_from(geom, &posture, &take, &ws.dq);
    let mut r = finish(model, pose, 0, (reduced.cond_g, reduced.cond_m), reactions, &take, errors);
    if model.envelope {
        // Both come from the reduction, which the general path factors for its conditioning.
        r.set_envelope(&model.clearance, reduced.envelope(model, pose), reduced.errors(model, pose, &takes).1);
    }
    r
}

/// A solvable pose's status: ok unless some kind's take-up is indeterminate.
#[inline(always)]
fn solved_status(kind_ok: &[bool; 4]) -> Status {
    if kind_ok.contains(&false) { Status::IndeterminateContact } else { Status::Ok }
}

/// What [`finish`] gives of lane `i` for [`Model::totals_only`], set in `o`: the
/// same values, and the other fields left as they were (writing all of a result
/// cost more than solving for the totals).
#[inline(always)]
fn finish_totals<L: Lane>(
    o: &mut PoseResult,
    pose: &Pose<L>,
    i: usize,
    cond: (f64, f64),
    kind_ok: [bool; 4],
    errors: &[PoseError; 4],
) {
    o.status = solved_status(&kind_ok);
    (o.x, o.y, o.phi) = (pose.x.get(i), pose.y.get(i), pose.phi.get(i));
    o.q = lane3(&pose.q, i);
    o.kind_ok = kind_ok;
    o.total = error_system::total(errors);
    (o.cond_a, o.cond_jp) = cond;
    o.dominant = None;
}

/// A solvable pose's result from its reactions, take-up and per-kind errors.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn finish<L: Lane>(
    model: &Model,
    pose: &Pose<L>,
    i: usize,
    cond: (f64, f64),
    reactions: JointReactions,
    take: &TakeUp,
    errors: [PoseError; 4],
) -> PoseResult {
    let total = error_system::total(&errors);
    let kind_ok = take.indeterminate.map(|i| !i);
    let status = solved_status(&kind_ok);
    let exact = (model.exact && status == Status::Ok)
        .then(|| exact_error(&model.geometry, &pose.posture(i), take))
        .flatten()
        .filter(|e| same_branch(e, &total));
    PoseResult {
        status,
        x: pose.x.get(i),
        y: pose.y.get(i),
        phi: pose.phi.get(i),
        q: lane3(&pose.q, i),
        reactions,
        margins: take.margins,
        errors,
        kind_ok,
        total,
        cond_a: cond.0,
        cond_jp: cond.1,
        exact,
        envelope: [[f64::NAN; 8]; 4],
        contribution: [[f64::NAN; 3]; 4],
        dominant: None,
    }
}
