//! The 6-UPS Gough–Stewart platform (docs/model.md §10.3) as a description for
//! [`limbs`](crate::limbs): six limbs with a universal joint at the base, an actuated
//! leg of two slender bodies (cylinder and piston, §10.2) and a spherical joint.
//!
//! Reactions: 7 unknowns per limb, `f_Ui` (base on leg at `B_i`), `m_Ui = μ_i·n_i` and
//! `f_Si` (leg on platform at `A_i`): the 42 × 42 `A·w = b`, solved with the legs
//! eliminated (one force along each leg, a 6 × 6 system). Clearances, in the order of
//! [`UPS_KINDS`]: `s_radial` (platform relative to leg, `−s·f_Si/|f_Si|`), `u_radial`
//! (leg relative to base, `−u·f_Ui/|f_Ui|`) and `u_angular` (a rotation `+θ·n_i` of the
//! leg about `B_i`, which no load decides). Error system: five passive rotations per
//! limb (about `a1_i`, `a2_i` through `B_i`, about x, y, z through `A_i`), the 30 × 30
//! `J_P`, solved in its 6 × 6 form `Gᵀ·[Δp; Δα] = d` (the assembled systems remain as
//! [`solve_ups_pose_assembled`], the general path). `u_angular` moves `A_i` across the
//! leg only, which the universal joint's own freedoms absorb: its error comes out zero
//! (computed, not written in), and the slender legs carry no couple along their axis,
//! so `μ_i` is round-off.
//!
//! ```
//! use clearance_model::Mode;
//! use clearance_solver::Status;
//! use clearance_solver::ups::{UpsModel, UpsWorkspace, solve_ups_poses, statics_sample};
//! let mut model = UpsModel::default();
//! model.set_clearance([1e-4, 1e-4, 1e-3]);
//! let samples = [statics_sample([0.0, 0.0, 0.7, 0.0, 0.05, -0.05]), statics_sample([0.02, 0.0, 0.75, 0.1, 0.0, 0.0])];
//! let mut out = [Default::default(); 2];
//! solve_ups_poses(&model, &samples, Mode::Kinetostatic, &mut UpsWorkspace::new(&model), &mut out);
//! assert!(out.iter().all(|r| r.status == Status::Ok));
//! assert!(out[0].errors[2].dp.norm() < 1e-18); // U-joint tilt play is harmless
//! ```

use clearance_kinematics::{
    UpsGeometry, UpsMotion, UpsPosture, ups_inverse_kinematics_into, ups_inverse_kinematics_motion,
};
use clearance_model::Mode;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use rayon::prelude::*;

use crate::assembly::{Assembly, AssemblyData, LimbsSolution};
use crate::bodies::{Load, Rod};
use crate::error_system::PoseError;
use crate::exact::{exp_minus_identity, left_jacobian};
use crate::limbs::{Actuated, BaseJoint, Body, ClearanceSite, LimbModel, LimbPose, Posed, Rule, Site};
use crate::pose::Status;
use crate::pose::scale_kinds;

/// The clearance kinds of the 6-UPS, in the order of every per-kind array here.
pub const UPS_KINDS: [&str; 3] = ["s_radial", "u_radial", "u_angular"];

/// The index of `u_angular` in [`UPS_KINDS`]: the play that cannot move the platform.
const U_ANGULAR: usize = 2;

/// The moving bodies of a 6-UPS: the platform as one composite body, and each leg's
/// cylinder (centre `B_i + (ℓ_c/2)·e_i`) and piston (centre `A_i − (ℓ_p/2)·e_i`).
#[derive(Clone, Debug, PartialEq)]
pub struct UpsMass {
    /// Total platform mass (kg), composite centre of mass (platform coordinates, from
    /// P) and inertia about it (platform axes).
    pub platform: f64,
    pub com_local: Vector3<f64>,
    pub inertia_local: Matrix3<f64>,
    pub cylinder: Rod,
    pub piston: Rod,
}

impl UpsMass {
    /// A platform of `platform` kg, a thin uniform disc of the geometry's platform
    /// radius centred at P, and legs of the given masses and the geometry's lengths.
    pub fn new(geom: &UpsGeometry, platform: f64, cylinder: f64, piston: f64) -> Self {
        let r2 = geom.platform_radius * geom.platform_radius;
        Self {
            platform,
            com_local: Vector3::zeros(),
            inertia_local: Matrix3::from_diagonal(&Vector3::new(
                platform * r2 / 4.0,
                platform * r2 / 4.0,
                platform * r2 / 2.0,
            )),
            cylinder: Rod::new(cylinder, geom.cylinder_length),
            piston: Rod::new(piston, geom.piston_length),
        }
    }

    /// The defaults of docs/model.md §10.3: platform 10 kg, cylinder 1.5 kg, piston 0.75 kg.
    pub fn defaults(geom: &UpsGeometry) -> Self {
        Self::new(geom, 10.0, 1.5, 0.75)
    }

    /// Attaches a point mass at `at` (platform coordinates): the composite centre of mass
    /// moves, the inertia follows by the parallel-axis theorem.
    pub fn add_point(&mut self, mass: f64, at: Vector3<f64>) {
        let point = |m: f64, d: &Vector3<f64>| m * (Matrix3::identity() * d.norm_squared() - d * d.transpose());
        let total = self.platform + mass;
        if total <= 0.0 {
            return;
        }
        let com = (self.platform * self.com_local + mass * at) / total;
        self.inertia_local += point(self.platform, &(self.com_local - com)) + point(mass, &(at - com));
        (self.platform, self.com_local) = (total, com);
    }

    /// Mass of every moving body (kg).
    pub fn total(&self) -> f64 {
        self.platform + 6.0 * (self.cylinder.mass + self.piston.mass)
    }
}

/// A 6-UPS job's model: built once, shared by every worker.
#[derive(Clone, Debug)]
pub struct UpsModel {
    pub geometry: UpsGeometry,
    pub mass: UpsMass,
    pub load: Load,
    /// Also solve the exact error (docs/model.md §7) of `ok` poses.
    pub exact: bool,
    /// Above this `cond_a` or `cond_jp` (the reduced 6 × 6 condition numbers of
    /// docs/conventions.md) a pose is `near_singular`.
    pub singular_cond: f64,
    /// The limbs, the clearance kinds with their magnitudes, gravity, the
    /// indeterminate-load floor and the conditioning limit.
    pub assembly: Assembly,
}

impl Default for UpsModel {
    /// The defaults of §10.3 under `g = (0, 0, −9.81)`, no load, no clearance.
    fn default() -> Self {
        let geometry = UpsGeometry::default();
        let mass = UpsMass::defaults(&geometry);
        Self::new(geometry, mass, Vector3::new(0.0, 0.0, -9.81), [0.0; 3])
    }
}

impl UpsModel {
    /// A model with no external load, the indeterminate floor `1e-9·W` and `κ₁` limit 1e8
    /// (the job file's defaults); `clearance` in the order of [`UPS_KINDS`].
    pub fn new(geometry: UpsGeometry, mass: UpsMass, gravity: Vector3<f64>, clearance: [f64; 3]) -> Self {
        let limbs = vec![LimbModel { base: BaseJoint::Universal, actuated: Actuated::Leg }; 6];
        let site = |name, site, rule, magnitude| ClearanceSite { name, site, rule, magnitude };
        let kinds = vec![
            site(UPS_KINDS[0], Site::Platform, Rule::AgainstForce, clearance[0]),
            site(UPS_KINDS[1], Site::Base, Rule::AgainstForce, clearance[1]),
            site(UPS_KINDS[2], Site::Base, Rule::AboutForbidden, clearance[2]),
        ];
        let weight = mass.total() * gravity.norm();
        let load = Load { force: Vector3::zeros(), moment: Vector3::zeros(), at_local: Vector3::zeros() };
        // The reduced condition numbers decide `near_singular` (`singular_cond`); the
        // assembled systems only refuse a failed factorisation.
        let assembly = Assembly::new(limbs, kinds, gravity, 1e-9 * weight, f64::INFINITY);
        Self { geometry, mass, load, exact: false, singular_cond: 1e8, assembly }
    }

    /// The model of a validated 6-UPS job: geometry, bodies (point masses and a given
    /// platform inertia included), external load, clearances and analysis limits.
    pub fn from_job(job: &clearance_model::JobSpec) -> Self {
        let m = &job.mechanism;
        let six = |v: Vec<f64>| -> [f64; 6] { std::array::from_fn(|i| v.get(i).copied().unwrap_or(f64::NAN)) };
        let points = |v: &Option<Vec<[f64; 3]>>| -> Option<[[f64; 3]; 6]> {
            v.as_ref().map(|p| std::array::from_fn(|i| p.get(i).copied().unwrap_or([f64::NAN; 3])))
        };
        let params = clearance_kinematics::UpsParams {
            base_radius: m.base_radius(),
            base_angles_deg: six(m.base_angles_deg()),
            platform_radius: m.platform_radius(),
            platform_angles_deg: six(m.platform_angles_deg()),
            cylinder_length: m.cylinder_length(),
            piston_length: m.piston_length(),
            min_length: Some(m.min_length()),
            max_length: Some(m.max_length()),
            base_points: points(&m.base_points),
            platform_points: points(&m.platform_points),
            u_axes: points(&m.u_axes),
        };
        let geometry = UpsGeometry::new(&params);
        let kind = m.kind;
        let ms = &job.mass;
        let mut mass = UpsMass::new(&geometry, ms.platform, ms.cylinder(kind), ms.piston(kind));
        if let Some(i) = ms.platform_inertia {
            mass.inertia_local = Matrix3::from_diagonal(&Vector3::new(i[0], i[1], i[2]));
        }
        for p in &ms.points {
            mass.add_point(p.mass, Vector3::from(p.at));
        }
        let mut model = Self::new(geometry, mass, Vector3::from(m.gravity), job.clearance.ups_array());
        model.load = Load {
            force: Vector3::from(job.load.force),
            moment: Vector3::from(job.load.moment),
            at_local: Vector3::from(job.load.at),
        };
        model.exact = job.analysis.exact;
        model.singular_cond = job.analysis.singular_cond;
        model.assembly.floor = job.analysis.indeterminate_load_fraction * model.weight();
        model
    }

    /// `W`, the weight of all moving bodies (N).
    pub fn weight(&self) -> f64 {
        self.mass.total() * self.assembly.gravity.norm()
    }

    /// Clearance magnitudes in the order of [`UPS_KINDS`].
    pub fn clearance(&self) -> [f64; 3] {
        std::array::from_fn(|k| self.assembly.kinds()[k].magnitude)
    }

    pub fn set_clearance(&mut self, clearance: [f64; 3]) {
        self.assembly.set_magnitudes(&clearance);
    }
}

/// Each input `x, y, z, Φ, Ψ, Θ` as `[value, rate, acceleration]`.
pub type UpsSample = [[f64; 3]; 6];

/// A sample at rest at `inputs`.
pub fn statics_sample(inputs: [f64; 6]) -> UpsSample {
    inputs.map(|v| [v, 0.0, 0.0])
}

/// Everything computed for one 6-UPS sample. Arrays are by limb, or by kind (order of
/// [`UPS_KINDS`]) then limb.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsResult {
    pub status: Status,
    /// Actuator lengths (NaN for `unreachable`).
    pub q: [f64; 6],
    /// `f_Ui`, `μ_i` (`m_Ui = μ_i·n_i`), `f_Si`.
    pub f_u: [Vector3<f64>; 6],
    pub mu: [f64; 6],
    pub f_s: [Vector3<f64>; 6],
    /// `|f_Si|`, `|f_Ui|`, `|μ_i|`.
    pub margins: [[f64; 6]; 3],
    pub errors: [PoseError; 3],
    pub kind_ok: [bool; 3],
    pub total: PoseError,
    pub cond_a: f64,
    pub cond_jp: f64,
    /// Exact error `[Δα; Δp]` (with `UpsModel::exact`, on `ok` poses that converge).
    pub exact: Option<[f64; 6]>,
    /// The worst case over every admissible take-up, per kind (docs/model.md §11): the
    /// largest `|Δp_x|, |Δp_y|, |Δp_z|, |Δα_x|, |Δα_y|, |Δα_z|`, and bounds on `|Δp|`
    /// and `|Δα|` (ok and indeterminate poses; NaN otherwise).
    pub envelope: [[f64; 8]; 3],
    /// Each joint's own contribution to `|Δp|` of the deterministic error, by kind and
    /// limb (ok poses; NaN otherwise).
    pub contribution: [[f64; 6]; 3],
    /// The joint whose own take-up moves P most, `(kind index, limb index)`
    /// ([`dominant_joint`](crate::dominant_joint)); `u_angular` never is one.
    pub dominant: Option<(usize, usize)>,
}

impl UpsResult {
    /// The joint whose own take-up moves P most among the kinds with a magnitude
    /// (order of [`UPS_KINDS`]), on an ok pose: see `PoseResult::dominant_of`.
    /// `u_angular` cannot move the platform: its round-off must not name a joint.
    pub fn dominant_of(&self, magnitudes: &[f64; 3]) -> Option<(usize, usize)> {
        if self.status != Status::Ok {
            return None;
        }
        let moving = |k: &usize| magnitudes[*k] != 0.0 && *k != U_ANGULAR;
        let contribution = &self.contribution;
        crate::dominant_joint((0..3).filter(moving).flat_map(|k| (0..6).map(move |i| ((k, i), contribution[k][i]))))
    }

    /// This result as if solved with each kind's magnitude (order of [`UPS_KINDS`])
    /// multiplied by `scale`: the reactions, margins and conditioning stay, each
    /// kind's error, envelope and contributions scale with it, and a kind scaled to
    /// zero is determinate (as `PoseResult::scaled`). Not for a result with an exact
    /// error.
    #[track_caller]
    pub fn scaled(&self, scale: &[f64; 3]) -> UpsResult {
        assert!(self.exact.is_none(), "an exact error does not scale with the clearances");
        let mut r = *self;
        if !matches!(self.status, Status::Ok | Status::IndeterminateContact) {
            return r;
        }
        r.status = scale_kinds(scale, &mut r.errors, &mut r.envelope, &mut r.contribution, &mut r.kind_ok);
        r.total = crate::error_system::total(&r.errors);
        // Only which kinds have a magnitude matters: those the scale keeps.
        r.dominant = r.dominant_of(scale);
        r
    }

    /// The envelope of all kinds together: each kind's bound summed.
    pub fn envelope_total(&self) -> [f64; 8] {
        std::array::from_fn(|c| self.envelope.iter().map(|k| k[c]).sum())
    }
}

impl Default for UpsResult {
    fn default() -> Self {
        Self {
            status: Status::Unreachable,
            q: [f64::NAN; 6],
            f_u: [Vector3::zeros(); 6],
            mu: [0.0; 6],
            f_s: [Vector3::zeros(); 6],
            margins: [[0.0; 6]; 3],
            errors: [PoseError::default(); 3],
            kind_ok: [false; 3],
            total: PoseError::default(),
            cond_a: f64::NAN,
            cond_jp: f64::NAN,
            exact: None,
            envelope: [[f64::NAN; 8]; 3],
            contribution: [[f64::NAN; 6]; 3],
            dominant: None,
        }
    }
}

/// Scratch for one worker thread.
pub struct UpsWorkspace {
    pub data: AssemblyData,
    /// The posture and bodies of the pose being solved, and its loads ([`solve_ups_leg_loads`]).
    pub(crate) pose: UpsPosture,
    pub(crate) posed: Posed,
    pub(crate) sol: LimbsSolution,
}

impl UpsWorkspace {
    pub fn new(model: &UpsModel) -> Self {
        Self {
            data: AssemblyData::new(&model.assembly),
            pose: UpsPosture::default(),
            posed: Posed::default(),
            sol: LimbsSolution::default(),
        }
    }
}

/// The posture and, in dynamics, its motion as the limbs' [`Posed`].
pub fn ups_posed(model: &UpsModel, pose: &UpsPosture, motion: Option<&UpsMotion>) -> Posed {
    let mut posed = Posed::default();
    ups_posed_into(model, pose, motion, &mut posed);
    posed
}

/// [`ups_posed`] into `posed`, every field written. In statics (`motion` `None`) the
/// bodies neither turn nor accelerate, so their inertia is not formed (zero: it
/// multiplies zero velocities).
fn ups_posed_into(model: &UpsModel, pose: &UpsPosture, motion: Option<&UpsMotion>, posed: &mut Posed) {
    let mass = &model.mass;
    let (cyl, pis) = (&mass.cylinder, &mass.piston);
    let moving = motion.is_some();
    for i in 0..6 {
        let e = pose.e[i];
        let (w, w_dot, e_ddot, a_ddot) = match motion {
            Some(m) => (m.leg_omega[i], m.leg_omega_dot[i], m.e_ddot[i], m.a_ddot[i]),
            None => Default::default(),
        };
        let rod = |r: &Rod, centre, acc| Body {
            mass: r.mass,
            centre,
            inertia: if moving { r.inertia_world(&e) } else { Matrix3::zeros() },
            acc,
            omega: w,
            omega_dot: w_dot,
        };
        posed.limbs[i] = LimbPose {
            b: pose.b[i],
            a: pose.a[i],
            axes: [pose.a1[i], pose.a2[i]],
            bodies: [
                rod(cyl, pose.b[i] + 0.5 * cyl.length * e, 0.5 * cyl.length * e_ddot),
                rod(pis, pose.a[i] - 0.5 * pis.length * e, a_ddot - 0.5 * pis.length * e_ddot),
            ],
        };
    }
    let c = pose.rot * mass.com_local;
    let (omega, omega_dot, com_acc) = match motion {
        Some(m) => (m.omega, m.omega_dot, m.p_ddot + m.omega_dot.cross(&c) + m.omega.cross(&m.omega.cross(&c))),
        None => Default::default(),
    };
    posed.platform = Body {
        mass: mass.platform,
        centre: pose.p + c,
        inertia: if moving { pose.rot * mass.inertia_local * pose.rot.transpose() } else { Matrix3::zeros() },
        acc: com_acc,
        omega,
        omega_dot,
    };
    posed.p = pose.p;
    posed.psi_theta = (pose.inputs[4], pose.inputs[5]);
    posed.force = model.load.force;
    posed.force_at = pose.p + pose.rot * model.load.at_local;
    posed.moment = model.load.moment;
}

/// The nominal posture of a sample and its bodies, or `None` where a leg is outside
/// its stroke.
pub fn ups_posture(model: &UpsModel, sample: &UpsSample, mode: Mode) -> Option<(UpsPosture, Posed)> {
    let (mut pose, mut posed) = (UpsPosture::default(), Posed::default());
    ups_posture_into(model, sample, mode, &mut pose, &mut posed).then_some((pose, posed))
}

/// [`ups_posture`] into `pose` and `posed` (a worker's, reused: a [`Posed`] is some
/// 3 kB and a posture 1.2 kB, and moving them out of each call was a tenth of a run);
/// `false` where the pose is out of reach.
fn ups_posture_into(
    model: &UpsModel,
    sample: &UpsSample,
    mode: Mode,
    pose: &mut UpsPosture,
    posed: &mut Posed,
) -> bool {
    match mode {
        Mode::Kinetostatic => {
            if ups_inverse_kinematics_into(&model.geometry, sample.map(|v| v[0]), pose).is_err() {
                return false;
            }
            ups_posed_into(model, pose, None, posed);
        }
        Mode::Dynamic => {
            let Ok((solved, motion)) = ups_inverse_kinematics_motion(&model.geometry, *sample) else { return false };
            *pose = solved;
            ups_posed_into(model, pose, Some(&motion), posed);
        }
    }
    true
}

/// One sample in one mode. Never panics on a bad pose: it becomes a status.
pub fn solve_ups_pose(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsResult {
    solve_ups(model, sample, mode, ws, Solve::All)
}

/// [`solve_ups_pose`] without the envelope, the joints' contributions and the exact
/// error: the status, reactions, margins, each kind's error and the total, bit for
/// bit. What the switch search reads a jump from, at the two points of each switch.
pub fn solve_ups_errors(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsResult {
    solve_ups(model, sample, mode, ws, Solve::Errors)
}

/// The status, reactions, margins and take-up determinacy of a sample as
/// [`solve_ups_pose`] gives them, without the error system, the envelope or the exact
/// error: what the switch search evaluates between samples ([`Assembly::solve_loads`]).
pub fn solve_ups_loads(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsResult {
    solve_ups(model, sample, mode, ws, Solve::Loads)
}

/// [`solve_ups_loads`] with the legs eliminated in closed form and the platform's
/// 6 × 6 system solved ([`Assembly::solve_loads_reduced`](crate::assembly::Assembly::solve_loads_reduced))
/// instead of the 42 × 42 factorisation: the same reactions to round-off, not to the
/// bit, in about a fifth of the time. What the switch search evaluates between
/// samples (at samples it reads the pass's values, or [`solve_ups_loads`]'s).
pub fn solve_ups_loads_reduced(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsResult {
    solve_ups(model, sample, mode, ws, Solve::Reduced)
}

/// [`solve_ups_pose`] with the 42 × 42 equilibrium and the 30 × 30 error system
/// assembled and factored instead of the legs eliminated: the general path the
/// reduced one is tested against (the same values to round-off, not to the bit).
pub fn solve_ups_pose_assembled(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsResult {
    solve_ups(model, sample, mode, ws, Solve::Assembled)
}

/// What [`solve_ups`] solves.
#[derive(Clone, Copy, PartialEq)]
enum Solve {
    /// Everything: reactions, errors, envelope, exact error; the legs eliminated
    /// (reactions as [`Solve::Reduced`], errors through `G⁻ᵀ`) where that applies.
    All,
    /// [`Solve::All`] up to the errors and their total.
    Errors,
    /// Everything, from the assembled 42 × 42 and 30 × 30 systems.
    Assembled,
    /// The reactions and take-ups, from the 42 × 42 factorisation.
    Loads,
    /// The reactions and take-ups, from the reduced system where it applies.
    Reduced,
}

/// The reactions of the legs of one sample: what the switch search evaluates between
/// samples, bit for bit [`solve_ups_loads_reduced`]'s `f_s` and `f_u` without the rest
/// of a [`UpsResult`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsLoads {
    /// `unreachable`, `near_singular`, or `ok` where the legs have reactions (whether
    /// each take-up is determinate is not decided: the search reads the loads alone).
    pub status: Status,
    pub f_s: [Vector3<f64>; 6],
    pub f_u: [Vector3<f64>; 6],
}

/// [`UpsLoads`] of one sample, with the legs eliminated where that applies.
pub fn solve_ups_leg_loads(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace) -> UpsLoads {
    let mut out = UpsLoads { status: Status::Unreachable, f_s: [Vector3::zeros(); 6], f_u: [Vector3::zeros(); 6] };
    match ups_reactions_into(model, sample, mode, ws) {
        Ok(_) => {
            out.status = Status::Ok;
            out.f_s = std::array::from_fn(|i| ws.sol.f_s[i]);
            out.f_u = std::array::from_fn(|i| ws.sol.f_b[i]);
        }
        Err(status) => out.status = status,
    }
    out
}

/// The posture of one sample (in `ws.pose`) with its bodies (in `ws.posed`) and the
/// legs' reactions (`f_s`, `f_b`, `mu`, `m_b` in `ws.sol`), with the legs eliminated
/// where that applies, `G⁻¹` of the legs' screws about P ([`ups_condition`]) and
/// `(κ₁(G), κ∞(G))`, each within the model's limit; else the status, `unreachable` or
/// `near_singular`. What the switch search evaluates between samples
/// ([`solve_ups_leg_loads`]), and what a custom description of a 6-UPS takes from this
/// kind's kernel (docs/model.md §12.10).
pub(crate) fn ups_reactions_into(
    model: &UpsModel,
    sample: &UpsSample,
    mode: Mode,
    ws: &mut UpsWorkspace,
) -> Result<(SMatrix<f64, 6, 6>, (f64, f64)), Status> {
    if !ups_posture_into(model, sample, mode, &mut ws.pose, &mut ws.posed) {
        return Err(Status::Unreachable);
    }
    let (cond_1, cond_inf, inverse, conditioned) = conditioning(model, &ws.pose);
    let Some(inverse) = inverse.filter(|_| conditioned) else { return Err(Status::NearSingular) };
    let loaded = model.assembly.reduced_reactions_into(&ws.posed, Some(&inverse), &mut ws.sol) || {
        ws.sol = model.assembly.solve_loads(&ws.posed, &mut ws.data);
        ws.sol.status != Status::NearSingular
    };
    if loaded { Ok((inverse, (cond_1, cond_inf))) } else { Err(Status::NearSingular) }
}

/// `(cond_a, cond_jp, G⁻¹)` of a posture, and whether it is regular and within the
/// model's limit (not `near_singular`).
fn conditioning(model: &UpsModel, pose: &UpsPosture) -> (f64, f64, Option<SMatrix<f64, 6, 6>>, bool) {
    let (cond_a, cond_jp, inverse) = condition_of(&leg_screws(pose));
    // NaN is not within the limit.
    let within = |c: f64| c <= model.singular_cond;
    (cond_a, cond_jp, inverse, !pose.near_singular && within(cond_a) && within(cond_jp))
}

fn solve_ups(model: &UpsModel, sample: &UpsSample, mode: Mode, ws: &mut UpsWorkspace, how: Solve) -> UpsResult {
    let mut out = UpsResult::default();
    if !ups_posture_into(model, sample, mode, &mut ws.pose, &mut ws.posed) {
        return out;
    }
    let (pose, posed) = (&ws.pose, &ws.posed);
    out.q = pose.q;
    out.status = Status::NearSingular;
    let (inverse, conditioned);
    (out.cond_a, out.cond_jp, inverse, conditioned) = conditioning(model, pose);
    if !conditioned {
        return out;
    }
    // The reduced form solves into the worker's solution, reset (some 2 kB): a fresh
    // one a pose, returned by value, was copied several times over.
    let sol = &mut ws.sol;
    let reduced = |sol: &mut LimbsSolution, inverse: Option<&SMatrix<f64, 6, 6>>| {
        *sol = LimbsSolution::default();
        model.assembly.solve_loads_reduced_into(posed, inverse, sol)
    };
    match how {
        Solve::All | Solve::Errors => match &inverse {
            Some(inverse) if reduced(sol, Some(inverse)) => leg_errors(&model.assembly, pose, inverse, sol),
            _ => *sol = model.assembly.solve(posed, &mut ws.data),
        },
        Solve::Assembled => *sol = model.assembly.solve(posed, &mut ws.data),
        Solve::Loads => *sol = model.assembly.solve_loads(posed, &mut ws.data),
        Solve::Reduced => {
            if !reduced(sol, inverse.as_ref()) {
                *sol = model.assembly.solve_loads(posed, &mut ws.data);
            }
        }
    }
    let sol = &*sol;
    if sol.status == Status::NearSingular {
        return out;
    }
    out.status = sol.status;
    for i in 0..6 {
        (out.f_u[i], out.mu[i], out.f_s[i]) = (sol.f_b[i], sol.mu[i][0], sol.f_s[i]);
    }
    for k in 0..3 {
        out.margins[k] = std::array::from_fn(|i| sol.margins[k][i]);
        out.errors[k] = sol.errors[k];
        out.kind_ok[k] = sol.kind_ok[k];
    }
    if !matches!(how, Solve::All | Solve::Errors | Solve::Assembled) {
        return out;
    }
    out.total = sol.total;
    if how == Solve::Errors {
        return out;
    }
    if let Some(inverse) = &inverse {
        set_envelope(model, pose, inverse, sol, &mut out);
    }
    if model.exact && out.status == Status::Ok {
        out.exact = ups_exact_error(model, pose, sol).filter(|e| same_branch(e, &out.total, &model.clearance()));
    }
    out
}

/// `(cond_a, cond_jp)` of a posture (docs/conventions.md, "Condition numbers", for six
/// limbs): with the legs eliminated the equilibrium leaves the six axial components of
/// `f_Si`, so `cond_a` is `κ₁(G)` with columns `[e_i; r_i × e_i]`, `r_i = A_i − P`; the
/// force along each leg is the one screw reciprocal to its passive freedoms, so
/// `cond_jp` is `κ₁` of the rows `[(r_i × e_i)ᵀ, e_iᵀ]`, which is `κ∞(G)`. Infinite where
/// `G` is singular. Both are exact and need no U axis: a leg along its fixed axis still
/// has them.
pub fn ups_condition(pose: &UpsPosture) -> (f64, f64) {
    let (cond_a, cond_jp, _) = condition_of(&leg_screws(pose));
    (cond_a, cond_jp)
}

/// Each kind's error and the total from the take-ups in `sol`, through the legs'
/// screws instead of the 30 × 30 loop system (docs/model.md §12.6, the 6 × 6 form): a
/// leg keeps its length, so `Gᵀ·[Δp; Δα] = d` with `d_i = e_i·u` for the translations
/// `u` of the leg at `B_i` and of the platform at `A_i`, and `d_i = e_i·(ω × (A_i − B_i))`
/// for a rotation `ω` of the leg about `B_i` (`set_envelope` reads the same rows);
/// `inverse` is `G⁻¹`. `u_angular`'s `d_i` is round-off: computed, not written in.
fn leg_errors(assembly: &Assembly, pose: &UpsPosture, inverse: &SMatrix<f64, 6, 6>, sol: &mut LimbsSolution) {
    sol.total = PoseError::default();
    for (k, kind) in assembly.kinds().iter().enumerate() {
        let d: [f64; 6] = std::array::from_fn(|i| {
            let t = sol.take[k][i];
            let moved = if kind.rule.rotation() { t.cross(&(pose.a[i] - pose.b[i])) } else { t };
            pose.e[i].dot(&moved)
        });
        // [Δp; Δα] = G⁻ᵀ·d, then the twist [Δα; Δp].
        let x: [f64; 6] = std::array::from_fn(|c| (0..6).map(|i| inverse[(i, c)] * d[i]).sum());
        let twist = nalgebra::Vector6::new(x[3], x[4], x[5], x[0], x[1], x[2]);
        let e = crate::assembly::pose_error(&twist, (pose.inputs[4], pose.inputs[5]));
        sol.errors[k] = e;
        sol.total.dalpha += e.dalpha;
        sol.total.dp += e.dp;
        for q in 0..3 {
            sol.total.euler[q] += e.euler[q];
        }
    }
}

/// `G`, whose column i is leg i's screw `[e_i; r_i × e_i]`, `r_i = A_i − P`.
fn leg_screws(pose: &UpsPosture) -> SMatrix<f64, 6, 6> {
    let mut g = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..6 {
        let e = pose.e[i];
        let m = (pose.a[i] - pose.p).cross(&e);
        for k in 0..3 {
            g[(k, i)] = e[k];
            g[(3 + k, i)] = m[k];
        }
    }
    g
}

/// `(κ₁(G), κ∞(G))` ([`ups_condition`]) and `G⁻¹`, which the envelope uses too.
fn condition_of(g: &SMatrix<f64, 6, 6>) -> (f64, f64, Option<SMatrix<f64, 6, 6>>) {
    let inverse = inverse6(g);
    match &inverse {
        Some(gi) if gi.as_slice().iter().all(|v| v.is_finite()) => {
            let ((g1, g_inf), (i1, i_inf)) = (norms(g), norms(gi));
            (g1 * i1, g_inf * i_inf, inverse)
        }
        _ => (f64::INFINITY, f64::INFINITY, inverse),
    }
}

/// `(‖m‖₁, ‖m‖∞)`: the largest column and row sums of `|m|`, each sum from zero in
/// index order. Written out: nalgebra's strided views summed through their iterators
/// took more than the inverse itself.
fn norms(m: &SMatrix<f64, 6, 6>) -> (f64, f64) {
    let (mut cols, mut rows) = ([0.0f64; 6], [0.0f64; 6]);
    let m = m.as_slice(); // column-major
    for c in 0..6 {
        for r in 0..6 {
            let v = m[6 * c + r].abs();
            cols[c] += v;
            rows[r] += v;
        }
    }
    let largest = |sums: [f64; 6]| sums.into_iter().fold(0.0, f64::max);
    (largest(cols), largest(rows))
}

/// `g⁻¹` by Gauss–Jordan elimination with partial pivoting, `None` where a pivot is
/// zero or not finite. Written out for 6 × 6: nalgebra's generic `try_inverse` was a
/// ninth of a 6-UPS run (`perf`), this is about a third of it. The rows are exchanged
/// through `order` rather than moved, and each step updates only the columns right of
/// its pivot: those left of it are never read again (the pivots to come are further
/// right, the inverse is the right half), so every value read is the one updating the
/// whole rows in place would give.
pub(crate) fn inverse6(g: &SMatrix<f64, 6, 6>) -> Option<SMatrix<f64, 6, 6>> {
    // Rows [g | I], eliminated in place; `order[k]` is the row in position k.
    let mut m = [[0.0f64; 12]; 6];
    for (r, row) in m.iter_mut().enumerate() {
        for c in 0..6 {
            row[c] = g[(r, c)];
        }
        row[6 + r] = 1.0;
    }
    let mut order = [0, 1, 2, 3, 4, 5];
    eliminate::<0>(&mut m, &mut order)?;
    eliminate::<1>(&mut m, &mut order)?;
    eliminate::<2>(&mut m, &mut order)?;
    eliminate::<3>(&mut m, &mut order)?;
    eliminate::<4>(&mut m, &mut order)?;
    eliminate::<5>(&mut m, &mut order)?;
    Some(SMatrix::from_fn(|r, c| m[order[r]][6 + c]))
}

/// Step `COL` of [`inverse6`]: the pivot of column `COL`, its row scaled, the column
/// eliminated from the other rows (a constant `COL`, so that each row's update is a
/// fixed-length loop). `None` where the pivot is zero or not finite.
#[inline(always)]
fn eliminate<const COL: usize>(m: &mut [[f64; 12]; 6], order: &mut [usize; 6]) -> Option<()> {
    let at = |k: usize| m[order[k]][COL].abs();
    let pivot = (COL..6).max_by(|&a, &b| at(a).total_cmp(&at(b)))?;
    order.swap(COL, pivot);
    let pr = order[COL];
    let p = m[pr][COL];
    if p == 0.0 || !p.is_finite() {
        return None;
    }
    let inv = 1.0 / p;
    let mut pivot_row = [0.0; 12];
    for c in COL + 1..12 {
        pivot_row[c] = m[pr][c] * inv;
    }
    m[pr] = pivot_row;
    for (r, row) in m.iter_mut().enumerate() {
        let f = row[COL];
        if r != pr && f != 0.0 {
            for c in COL + 1..12 {
                row[c] -= f * pivot_row[c];
            }
        }
    }
    Some(())
}

/// The envelope, the joints' contributions and the dominant joint of a solved pose
/// (docs/model.md §11 for this kind). A leg keeps its length, so only the part of a
/// joint's displacement of `A_i` along `e_i` moves the platform: `Gᵀ·[Δp; Δα] = d` with
/// `d_i = e_i·u` for a translation `u` of the leg at `B_i` or of the platform at `A_i`,
/// and `d_i = ω·((A_i − B_i) × e_i)` for a rotation `ω` of the leg about `B_i`. So
/// joint (k, i) moves the platform by `ν_i·d_i`, `ν_i` the column i of `G⁻ᵀ` (the row i
/// of `inverse`), and its admissible set (a ball of translations, or the rotations
/// about `n_i` for `u_angular`) bounds `|d_i|` by `c_k·|g|` (`c_k·|n_i·g|`), `g` the
/// vector above. For `u_angular`, `n_i·((A_i − B_i) × e_i) = q_i·n_i·(e_i × e_i)` is
/// zero up to round-off: computed, not written in.
fn set_envelope(
    model: &UpsModel,
    pose: &UpsPosture,
    inverse: &SMatrix<f64, 6, 6>,
    sol: &LimbsSolution,
    out: &mut UpsResult,
) {
    let kinds = model.assembly.kinds();
    let mut envelope = [[0.0; 8]; 3];
    let mut contribution = [[0.0; 6]; 3];
    for i in 0..6 {
        let nu = inverse.row(i);
        let (np, na) = (nu.columns(0, 3).norm(), nu.columns(3, 3).norm());
        for (k, kind) in kinds.iter().enumerate() {
            let (g, reach) = if kind.rule.rotation() {
                let g = (pose.a[i] - pose.b[i]).cross(&pose.e[i]);
                (g, pose.n[i].dot(&g).abs())
            } else {
                (pose.e[i], pose.e[i].norm())
            };
            let bound = kind.magnitude * reach;
            for c in 0..6 {
                envelope[k][c] += bound * nu[c].abs();
            }
            envelope[k][6] += bound * np;
            envelope[k][7] += bound * na;
            contribution[k][i] = g.dot(&sol.take[k][i]).abs() * np;
        }
    }
    out.envelope = envelope;
    // Kept on indeterminate poses too: the summary reads them on ok poses only, and a
    // variant whose indeterminate kind is zero ([`UpsResult::scaled`]) is ok.
    out.contribution = contribution;
    let magnitudes: [f64; 3] = std::array::from_fn(|k| kinds[k].magnitude);
    out.dominant = out.dominant_of(&magnitudes);
}

/// [`solve_ups_pose`] for each sample of a batch, into `out` (same length).
#[track_caller]
pub fn solve_ups_poses(
    model: &UpsModel,
    samples: &[UpsSample],
    mode: Mode,
    ws: &mut UpsWorkspace,
    out: &mut [UpsResult],
) {
    assert_eq!(samples.len(), out.len(), "one result per sample");
    for (s, o) in samples.iter().zip(out) {
        *o = solve_ups_pose(model, s, mode, ws);
    }
}

/// [`solve_ups_poses`] over the rayon pool, into `out` (cleared first; its memory
/// reused), in runs of at least `block` samples, one [`UpsWorkspace`] per run: the
/// same results as one thread, in order. Each result is written once, in place, on
/// the pool: initialising a run's results first (80 MB for 65 536 poses) took one
/// thread while the others waited.
#[track_caller]
pub fn solve_ups_par(model: &UpsModel, samples: &[UpsSample], mode: Mode, block: usize, out: &mut Vec<UpsResult>) {
    assert!(block > 0, "block must be positive");
    out.clear();
    out.par_extend(
        samples
            .par_iter()
            .with_min_len(block)
            .map_init(|| UpsWorkspace::new(model), |ws, s| solve_ups_pose(model, s, mode, ws)),
    );
}

/// The exact error is the linear one to second order; further from it than the linear
/// error's size (or, where that is round-off, a millionth of the clearance) is another
/// assembly of the mechanism, reported as null.
fn same_branch(exact: &[f64; 6], linear: &PoseError, clearance: &[f64; 3]) -> bool {
    let lin = [linear.dalpha.x, linear.dalpha.y, linear.dalpha.z, linear.dp.x, linear.dp.y, linear.dp.z];
    let floor = 1e-6 * clearance.iter().fold(0.0f64, |m, &c| m.max(c));
    let size = lin.iter().fold(floor, |m, v| m.max(v.abs()));
    exact.iter().zip(lin).all(|(e, l)| (e - l).abs() <= size)
}

/// The exact error of a 6-UPS (docs/model.md §7 with two joint angles per leg): the
/// take-ups of `sol` applied as finite offsets, the nonlinear closure solved by Newton
/// from the nominal pose. Unknowns: the platform's `(Δp, w)`, `R' = Exp(w)·R`, and the
/// universal joint's angles `φ1_i` (about `a1_i`) and `φ2_i` (about `a2_i`, carried by the
/// first), 18 in all:
///
/// ```text
/// p' + R'·a'_i = B_i + ΔB_i + q_i·Rot(Δθ_i)·Rot(a1_i, φ1_i)·Rot(a2_i, φ2_i)·e_i + ΔA_i
/// ```
///
/// in perturbation form (the nominal closure subtracted), so the error keeps full
/// relative precision. `None` when Newton does not converge.
pub fn ups_exact_error(model: &UpsModel, pose: &UpsPosture, sol: &LimbsSolution) -> Option<[f64; 6]> {
    let kinds = model.assembly.kinds();
    let mut offset = [Vector3::zeros(); 6];
    let mut tilt = [Vector3::zeros(); 6];
    for (k, kind) in kinds.iter().enumerate() {
        for i in 0..6 {
            match (kind.rule, kind.site) {
                (Rule::AgainstMoment | Rule::AboutForbidden, Site::Base) => tilt[i] += sol.take[k][i],
                (Rule::AgainstMoment | Rule::AboutForbidden, Site::Platform) => return None,
                _ => offset[i] += sol.take[k][i],
            }
        }
    }
    let tilt = tilt.map(|t| exp_minus_identity(&t));
    let ra0: [Vector3<f64>; 6] = std::array::from_fn(|i| pose.rot * model.geometry.a_local[i]);
    let l = pose.q.iter().fold(0.0f64, |m, &v| m.max(v));
    let eye = Matrix3::identity();
    let (mut dp, mut w) = (Vector3::zeros(), Vector3::zeros());
    let mut phi = [[0.0f64; 2]; 6];
    let mut last_step = f64::INFINITY;
    for _ in 0..30 {
        let mut res = SVector::<f64, 18>::zeros();
        let mut jac = SMatrix::<f64, 18, 18>::zeros();
        let e_w = exp_minus_identity(&w);
        let jl = left_jacobian(&w);
        for i in 0..6 {
            let (a1, a2, e, q) = (pose.a1[i], pose.a2[i], pose.e[i], pose.q[i]);
            let m1 = exp_minus_identity(&(phi[i][0] * a1));
            let m2 = exp_minus_identity(&(phi[i][1] * a2));
            // Rot1·Rot2 − I and T − I = Rot(Δθ)·Rot1·Rot2 − I, with no cancellation.
            let m12 = m1 + m2 + m1 * m2;
            let turn = tilt[i] + m12 + tilt[i] * m12;
            let r = dp + e_w * ra0[i] - offset[i] - q * (turn * e);
            let front = eye + tilt[i];
            let d_phi1 = -q * (front * a1.cross(&(e + m12 * e)));
            let d_phi2 = -q * (front * (eye + m1) * a2.cross(&(e + m2 * e)));
            let d_w = -(ra0[i] + e_w * ra0[i]).cross_matrix() * jl;
            for k in 0..3 {
                let row = 3 * i + k;
                res[row] = r[k];
                jac[(row, k)] = 1.0;
                for c in 0..3 {
                    jac[(row, 3 + c)] = d_w[(k, c)];
                }
                jac[(row, 6 + 2 * i)] = d_phi1[k];
                jac[(row, 7 + 2 * i)] = d_phi2[k];
            }
        }
        let step = jac.lu().solve(&(-res))?;
        dp += Vector3::new(step[0], step[1], step[2]);
        w += Vector3::new(step[3], step[4], step[5]);
        for i in 0..6 {
            phi[i][0] += step[6 + 2 * i];
            phi[i][1] += step[7 + 2 * i];
        }
        let angles = phi.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let size = dp.amax().max(w.amax() * l).max(angles * l);
        last_step = step.amax() / size.max(f64::MIN_POSITIVE);
        if last_step <= 4.0 * f64::EPSILON {
            break;
        }
    }
    let out = [w.x, w.y, w.z, dp.x, dp.y, dp.z];
    (last_step <= 1e-10 && out.iter().all(|v| v.is_finite())).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The written-out norms are nalgebra's column and row sums of `|m|`, bit for bit
    /// (the condition numbers of every 6-UPS job keep their values), on matrices with
    /// entries over many magnitudes and signs, zeros included.
    #[test]
    fn norms_are_nalgebras_sums_bit_for_bit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..2000 {
            let m = SMatrix::<f64, 6, 6>::from_fn(|_, _| {
                if rng.random_bool(0.1) {
                    0.0
                } else {
                    rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-8..8))
                }
            });
            let one = (0..6).map(|c| m.column(c).abs().sum()).fold(0.0, f64::max);
            let inf = (0..6).map(|r| m.row(r).abs().sum()).fold(0.0, f64::max);
            let (n1, n_inf) = norms(&m);
            assert_eq!((n1.to_bits(), n_inf.to_bits()), (one.to_bits(), inf.to_bits()), "{m}");
        }
    }

    /// The inverse against nalgebra's LU inverse, to 1e-12 of the largest entry
    /// relative to the condition number, on well- and ill-conditioned matrices (rows
    /// scaled over six orders of magnitude, so that pivoting matters); one with a zero
    /// column has none.
    #[test]
    fn inverse_agrees_with_an_lu_inverse() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..2000 {
            let scale: [f64; 6] = std::array::from_fn(|_| 10f64.powi(rng.random_range(-3..4)));
            let g = SMatrix::<f64, 6, 6>::from_fn(|r, _| scale[r] * rng.random_range(-1.0..1.0));
            let ours = inverse6(&g).expect("a random matrix is regular");
            let theirs = g.try_inverse().expect("a random matrix is regular");
            let kappa = g.norm() * theirs.norm();
            let tol = 1e-12 * kappa * theirs.amax();
            assert!((ours - theirs).amax() <= tol, "{g}: {}", (ours - theirs).amax());
            assert!((ours * g - SMatrix::<f64, 6, 6>::identity()).amax() < 1e-12 * kappa);
        }
        // A column of zeros leaves no pivot in it, whatever the elimination before.
        let mut singular = SMatrix::<f64, 6, 6>::from_fn(|r, c| 1.0 + (r * 6 + c) as f64 * 0.37);
        singular.set_column(3, &nalgebra::Vector6::zeros());
        assert_eq!(inverse6(&singular), None);
    }
}
