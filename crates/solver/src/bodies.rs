//! The moving bodies (docs/model.md §3) and the loads on them, in the form the
//! equilibrium needs: a composite platform and three slender legs.

use clearance_kinematics::{Geometry, Motion, Posture};
use clearance_model::{JobSpec, MechanismKind};
use nalgebra::{Matrix3, Vector3};

/// The platform with its point masses as one rigid body, and the limbs' bodies.
#[derive(Clone, Debug, PartialEq)]
pub struct MassModel {
    /// Total platform mass `m` (platform plus point masses), kg.
    pub platform_mass: f64,
    /// Composite centre of mass `c'` in platform coordinates (from P).
    pub com_local: Vector3<f64>,
    /// Inertia about the composite centre of mass, platform axes.
    pub inertia_local: Matrix3<f64>,
    /// 3-PRS: mass of each leg, kg (0 for the 3-RPS).
    pub leg_mass: f64,
    /// `m_leg·L²/12`, the leg's inertia across its axis.
    pub leg_inertia: f64,
    /// 3-RPS: the cylinder (from the base joint) and the piston (up to the
    /// spherical joint) of each leg (zero masses for the 3-PRS).
    pub cylinder: Rod,
    pub piston: Rod,
}

/// A slender rod: `mass`, `length`, and `m·ℓ²/12` across its axis (0 along it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rod {
    pub mass: f64,
    pub length: f64,
    pub inertia: f64,
}

impl Rod {
    /// A slender rod of `mass` and `length`.
    pub fn new(mass: f64, length: f64) -> Self {
        Self { mass, length, inertia: mass * length * length / 12.0 }
    }

    /// Inertia about its centre of mass in world axes, along `e`: `m·ℓ²/12·(I − e·eᵀ)`.
    pub fn inertia_world(&self, e: &Vector3<f64>) -> Matrix3<f64> {
        self.inertia * (Matrix3::identity() - e * e.transpose())
    }
}

fn point_inertia(m: f64, d: &Vector3<f64>) -> Matrix3<f64> {
    m * (Matrix3::identity() * d.norm_squared() - d * d.transpose())
}

impl MassModel {
    pub fn from_job(job: &JobSpec) -> Self {
        let ms = &job.mass;
        let kind = job.mechanism.kind;
        let r = job.mechanism.platform_radius();
        let own = match ms.platform_inertia {
            Some(i) => Matrix3::from_diagonal(&Vector3::new(i[0], i[1], i[2])),
            None => {
                let m = ms.platform;
                Matrix3::from_diagonal(&Vector3::new(m * r * r / 4.0, m * r * r / 4.0, m * r * r / 2.0))
            }
        };
        let total = ms.platform + ms.points.iter().map(|p| p.mass).sum::<f64>();
        let moment: Vector3<f64> = ms.points.iter().map(|p| p.mass * Vector3::from(p.at)).sum();
        let com_local = if total > 0.0 { moment / total } else { Vector3::zeros() };
        // Parallel axes: the platform's own inertia is about P, its centre of mass.
        let mut inertia_local = own + point_inertia(ms.platform, &com_local);
        for p in &ms.points {
            inertia_local += point_inertia(p.mass, &(Vector3::from(p.at) - com_local));
        }
        let m = &job.mechanism;
        let (leg_mass, l) = (ms.leg(kind), m.leg_length());
        let leg_inertia = if kind == MechanismKind::Prs3 { leg_mass * l * l / 12.0 } else { 0.0 };
        let (cylinder, piston) = match kind {
            MechanismKind::Prs3 => (Rod::default(), Rod::default()),
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                (Rod::new(ms.cylinder(kind), m.cylinder_length()), Rod::new(ms.piston(kind), m.piston_length()))
            }
        };
        Self { platform_mass: total, com_local, inertia_local, leg_mass, leg_inertia, cylinder, piston }
    }

    /// The loads of leg j's two bodies (3-RPS), other than the joint reactions: `c_j`,
    /// the weight and inertia forces, `Σ m_b·(a_b − g)`, and `H_j`, the rate of angular
    /// momentum and those forces' moment about the base joint `B_j`,
    /// `Σ I_b·ω̇ + ω×(I_b·ω) + (G_b − B_j)×m_b·(a_b − g)`. The cylinder's centre is
    /// `B_j + (ℓ_c/2)·e_j`, the piston's `A_j − (ℓ_p/2)·e_j`; both turn with the leg.
    pub fn rps_limb(
        &self,
        pose: &Posture,
        inertial: &Inertial,
        gravity: &Vector3<f64>,
        j: usize,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let e = pose.e[j];
        let (w, w_dot) = (inertial.leg_omega[j], inertial.leg_omega_dot[j]);
        let (cyl, pis) = (&self.cylinder, &self.piston);
        let arm_c = 0.5 * cyl.length;
        let arm_p = pose.ell[j] - 0.5 * pis.length;
        let acc_c = arm_c * inertial.e_ddot[j];
        let acc_p = inertial.a_ddot[j] - 0.5 * pis.length * inertial.e_ddot[j];
        let (f_c, f_p) = (cyl.mass * (acc_c - gravity), pis.mass * (acc_p - gravity));
        let mut h = (arm_c * e).cross(&f_c) + (arm_p * e).cross(&f_p);
        if inertial.moving {
            for rod in [cyl, pis] {
                let i = rod.inertia_world(&e);
                h += i * w_dot + w.cross(&(i * w));
            }
        }
        (f_c + f_p, h)
    }
}

/// The external wrench on the platform.
#[derive(Clone, Debug, PartialEq)]
pub struct Load {
    pub force: Vector3<f64>,
    pub moment: Vector3<f64>,
    /// Application point of the force, platform coordinates.
    pub at_local: Vector3<f64>,
}

/// Everything about the posture's motion that the equilibrium needs, world frame.
/// Zero in kinetostatics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Inertial {
    pub omega: Vector3<f64>,
    pub omega_dot: Vector3<f64>,
    /// Acceleration of the composite centre of mass C.
    pub com_acc: Vector3<f64>,
    pub leg_omega: [Vector3<f64>; 3],
    pub leg_omega_dot: [Vector3<f64>; 3],
    pub leg_com_acc: [Vector3<f64>; 3],
    /// `ë_j` and `Ä_j`, for the bodies of a 3-RPS leg.
    pub e_ddot: [Vector3<f64>; 3],
    pub a_ddot: [Vector3<f64>; 3],
    /// False in kinetostatics, where every rate above is zero and the inertial
    /// terms can be skipped.
    pub moving: bool,
}

impl Inertial {
    /// From the exact motion of a trajectory sample.
    pub fn from_motion(pose: &Posture, motion: &Motion, mass: &MassModel) -> Self {
        let c = pose.rot * mass.com_local;
        let w = motion.omega;
        let com_acc = motion.p_ddot + motion.omega_dot.cross(&c) + w.cross(&w.cross(&c));
        Self {
            omega: w,
            omega_dot: motion.omega_dot,
            com_acc,
            leg_omega: motion.leg_omega,
            leg_omega_dot: motion.leg_omega_dot,
            leg_com_acc: motion.leg_com_acc,
            e_ddot: motion.e_ddot,
            a_ddot: motion.a_ddot,
            moving: true,
        }
    }
}

/// Leg inertia about its centre of mass in world axes: `m·L²/12·(I − e·eᵀ)`.
pub fn leg_inertia_world(mass: &MassModel, e: &Vector3<f64>) -> Matrix3<f64> {
    mass.leg_inertia * (Matrix3::identity() - e * e.transpose())
}

/// Which solver runs the two linear systems. Both give the same results to
/// round-off; `General` assembles the full 24 × 24 and 12 × 12 systems of docs/model.md
/// and solves them with faer, `Fast` (the default) solves their 6 × 6 reductions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SolverKind {
    General,
    #[default]
    Fast,
}

/// The model of one job that every pose shares.
#[derive(Clone, Debug)]
pub struct Model {
    pub geometry: Geometry,
    pub mass: MassModel,
    pub gravity: Vector3<f64>,
    pub load: Load,
    /// Clearance magnitudes in the order of `clearance_model::KINDS`.
    pub clearance: [f64; 4],
    /// `W`, the weight of all moving bodies (N).
    pub weight: f64,
    /// Loads at or below this make a take-up indeterminate (N or N·m).
    pub indeterminate_floor: f64,
    pub singular_cond: f64,
    pub exact: bool,
    pub solver: SolverKind,
    /// Also compute the worst-case envelope and each joint's contribution
    /// (`PoseResult::envelope`, `contribution`, `dominant`); off (the default), they
    /// are NaN and `None`. A run turns it on for the column sets that write them.
    pub envelope: bool,
    /// Compute, of each solvable pose, only what the totals need: the fast solver
    /// then sets a result's status, `x`, `y`, `phi`, `q`, `kind_ok`, `total`,
    /// `cond_a`, `cond_jp` and `dominant` (`None`) and leaves its other fields as they
    /// were. For callers that read nothing else (the minimal column set, in memory):
    /// building the whole result is about a fifth of a pose's time. Off by default,
    /// and with `exact` (the exact error needs the whole take-up) or `envelope`.
    pub totals_only: bool,
}

impl Model {
    pub fn from_job(job: &JobSpec) -> Self {
        let weight = job.weight();
        Self {
            geometry: Geometry::from_spec(&job.mechanism),
            mass: MassModel::from_job(job),
            gravity: Vector3::from(job.mechanism.gravity),
            load: Load {
                force: Vector3::from(job.load.force),
                moment: Vector3::from(job.load.moment),
                at_local: Vector3::from(job.load.at),
            },
            clearance: job.clearance.as_array(),
            weight,
            indeterminate_floor: job.analysis.indeterminate_load_fraction * weight,
            singular_cond: job.analysis.singular_cond,
            exact: job.analysis.exact,
            solver: SolverKind::default(),
            envelope: false,
            totals_only: false,
        }
    }
}
