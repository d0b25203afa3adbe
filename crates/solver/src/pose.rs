//! One pose through the whole pipeline: kinematics → reactions → take-up → error.

use clearance_grid::Sample;
use clearance_kinematics::{Posture, Unreachable, inverse_kinematics, inverse_kinematics_motion, parasitic};
use clearance_model::Mode;
use faer::Mat;

use crate::bodies::SolverKind;
use crate::bodies::{Inertial, Model};
use crate::equilibrium::{self, JointReactions};
use crate::error_system::{self, PoseError};
use crate::exact::exact_error;
use crate::fast;
use crate::linalg::LuSolver;
use crate::takeup::{Margins, take_up};

/// What became of a pose (docs/conventions.md gives the precedence and what each
/// status leaves null).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Status {
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
}

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

/// The nominal posture of a sample and, in dynamics, its inertial loads.
fn posture(model: &Model, sample: &Sample, mode: Mode) -> Result<(Posture, Inertial), Unreachable> {
    let geom = &model.geometry;
    let (z, psi, theta) = (sample.z[0], sample.psi[0], sample.theta[0]);
    match mode {
        Mode::Kinetostatic => inverse_kinematics(geom, z, psi, theta).map(|p| (p, Inertial::default())),
        Mode::Dynamic => inverse_kinematics_motion(geom, sample.z, sample.psi, sample.theta).map(|(p, m)| {
            let inertial = Inertial::from_motion(&p, &m, &model.mass);
            (p, inertial)
        }),
    }
}

/// The joint reactions alone, for searches that follow loads between poses whose
/// status is already known: the same numbers as [`solve_pose`]'s reactions, without
/// the conditioning, take-up and errors. `None` where `solve_pose` has no reactions.
pub fn solve_reactions(model: &Model, sample: &Sample, mode: Mode, ws: &mut Workspace) -> Option<JointReactions> {
    if model.solver == SolverKind::General {
        let r = solve_pose(model, sample, mode, ws);
        return matches!(r.status, Status::Ok | Status::IndeterminateContact).then_some(r.reactions);
    }
    let (pose, inertial) = posture(model, sample, mode).ok()?;
    let reduced = fast::factor(model, &pose);
    reduced.regular().then(|| reduced.reactions(model, &pose, &inertial))
}

/// Runs one sample in one mode. Never panics on a bad pose: it becomes a status.
pub fn solve_pose(model: &Model, sample: &Sample, mode: Mode, ws: &mut Workspace) -> PoseResult {
    let geom = &model.geometry;
    let (pose, inertial) = match posture(model, sample, mode) {
        Ok(v) => v,
        Err(_) => {
            let (x, y, phi) = parasitic(geom.platform_radius, sample.psi[0], sample.theta[0]);
            return PoseResult::unreachable(x, y, phi);
        }
    };

    // Both paths judge conditioning on the reduced systems (docs/conventions.md).
    let reduced = fast::reduce(model, &pose);
    let (cond_a, cond_jp) = (reduced.cond_g, reduced.cond_m);
    let mut result = PoseResult::unreachable(pose.x, pose.y, pose.phi);
    result.q = pose.q;
    result.cond_a = cond_a;
    result.cond_jp = cond_jp;
    if !(cond_a <= model.singular_cond && cond_jp <= model.singular_cond) {
        result.status = Status::NearSingular;
        return result;
    }

    let reactions = match model.solver {
        SolverKind::Fast => reduced.reactions(model, &pose, &inertial),
        SolverKind::General => {
            equilibrium::assemble(model, &pose, &inertial, ws.a.as_mut(), ws.w.as_mut());
            if !ws.lu_a.solve(ws.a.as_ref(), ws.w.as_mut()) {
                result.status = Status::NearSingular;
                return result;
            }
            equilibrium::reactions_from(model, &ws.w)
        }
    };
    let take = take_up(geom, &reactions, &model.clearance, model.indeterminate_floor);
    let errors = match model.solver {
        SolverKind::Fast => {
            let euler_inv = fast::euler_inverse(&pose);
            reduced.errors(model, &pose, &take).map(|t| fast::pose_error(t, &euler_inv))
        }
        SolverKind::General => {
            error_system::assemble(&pose, &geom.y, &take, ws.jp.as_mut(), ws.dq.as_mut());
            if !ws.lu_jp.solve(ws.jp.as_ref(), ws.dq.as_mut()) {
                result.status = Status::NearSingular;
                return result;
            }
            error_system::errors_from(&pose, &geom.y, &take, &ws.dq)
        }
    };
    let total = error_system::total(&errors);
    let kind_ok = take.indeterminate.map(|i| !i);
    let status = if kind_ok.contains(&false) { Status::IndeterminateContact } else { Status::Ok };
    let exact = (model.exact && status == Status::Ok)
        .then(|| exact_error(geom, &pose, &take))
        .flatten()
        .filter(|e| same_branch(e, &total));
    PoseResult { status, reactions, margins: take.margins, errors, kind_ok, total, exact, ..result }
}
