//! A mechanism as limbs (docs/model.md §4–6, §10): the description from which
//! [`assembly`](crate::assembly) builds the equilibrium and the error system, for any
//! number of limbs.
//!
//! A limb is a base joint at `B` (revolute about one axis, or universal with a fixed
//! axis `a1` and a leg axis `a2`), a leg of one or more rigid bodies (a locked prismatic
//! joint inside it, if any, is internal), and a spherical joint at `A` on the platform.
//! The static part ([`LimbModel`]s and [`ClearanceSite`]s, gathered in an
//! [`Assembly`]) is built once per job; the posed part ([`Posed`]: points, axes, bodies
//! and their motion) once per pose. The 3-PRS and 3-RPS are described here
//! ([`three_limb_assembly`], [`three_limb_posed`]), the 6-UPS in [`ups`](crate::ups).

use clearance_kinematics::Posture;
use clearance_model::MechanismKind;
use nalgebra::{Matrix3, Vector3};

use crate::assembly::Assembly;
use crate::bodies::{Inertial, Model, leg_inertia_world};

/// At most this many limbs, clearance kinds and bodies per leg: results are fixed-size.
pub const MAX_LIMBS: usize = 6;
pub const MAX_KINDS: usize = 4;
pub const MAX_BODIES: usize = 2;

/// The joint between the base (or a slider) and the leg.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseJoint {
    /// One rotation about `axes[0]`; transmits a couple `⟂` it.
    Revolute,
    /// Rotations about `axes[0] = a1` (fixed) and `axes[1] = a2` (in the leg, `⟂ a1`);
    /// transmits a couple along `n = a1 × a2`.
    Universal,
}

impl BaseJoint {
    /// Couple components the joint transmits (unknowns beyond its force).
    pub fn moments(self) -> usize {
        match self {
            BaseJoint::Revolute => 2,
            BaseJoint::Universal => 1,
        }
    }

    /// Passive rotations (unknowns of the error system beyond the spherical joint's 3).
    pub fn freedoms(self) -> usize {
        match self {
            BaseJoint::Revolute => 1,
            BaseJoint::Universal => 2,
        }
    }
}

/// Which prismatic joint the actuator drives; locked in the analysis, it adds no
/// passive screw either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Actuated {
    /// A slider carrying the base joint (3-PRS).
    Slider,
    /// The leg's length (3-RPS, 6-UPS).
    Leg,
}

/// One limb's joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimbModel {
    pub base: BaseJoint,
    pub actuated: Actuated,
}

/// Where a clearance sits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Site {
    /// The base joint at `B`: the leg moves relative to the base.
    Base,
    /// The spherical joint at `A`: the platform moves relative to the leg.
    Platform,
}

/// How a clearance is taken up under the load the proximal part exerts on the
/// distal one (docs/model.md §5, §10.3), and which load is its margin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// Translation `−c·f/|f|` (`s_radial`, `u_radial`); margin `|f|`.
    AgainstForce,
    /// Translation `−c·f⊥/|f⊥|`, `f⊥` the force across the joint's first axis
    /// (`r_radial`); margin `|f⊥|`.
    AgainstForceAcrossAxis,
    /// Translation `−c·sign(f·u)·u` along the first axis `u` (`r_axial`); margin `|f·u|`.
    AlongAxis,
    /// Rotation `−c·m/|m|` against the joint's couple (`r_angular`); margin `|m|`.
    AgainstMoment,
    /// Rotation `+c·n` about the axis the universal joint forbids (`u_angular`): no load
    /// decides it, so it is never indeterminate; margin `|m|` (round-off).
    AboutForbidden,
}

impl Rule {
    pub(crate) fn rotation(self) -> bool {
        matches!(self, Rule::AgainstMoment | Rule::AboutForbidden)
    }
}

/// One clearance kind: at the same joint of every limb, with one magnitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClearanceSite {
    pub name: &'static str,
    pub site: Site,
    pub rule: Rule,
    /// Displacement (m) or rotation (rad) at full take-up.
    pub magnitude: f64,
}

/// A rigid body at one pose: world frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Body {
    pub mass: f64,
    pub centre: Vector3<f64>,
    /// Inertia about `centre`, world axes.
    pub inertia: Matrix3<f64>,
    /// Acceleration of `centre`, angular velocity and acceleration (zero in statics).
    pub acc: Vector3<f64>,
    pub omega: Vector3<f64>,
    pub omega_dot: Vector3<f64>,
}

impl Body {
    /// `m·(a − g)`: the force the body's weight and inertia ask of its joints.
    pub(crate) fn demand(&self, g: &Vector3<f64>) -> Vector3<f64> {
        self.mass * (self.acc - g)
    }

    /// `I·ω̇ + ω×(I·ω)`.
    pub(crate) fn spin(&self) -> Vector3<f64> {
        // A body at rest in statics: no inertia formed, no motion. Every product is
        // then +0, so the value is the one computed, +0, without the products.
        let bits = |v: &[f64]| v.iter().fold(0, |a, x| a | x.to_bits());
        if bits(self.omega.as_slice()) | bits(self.omega_dot.as_slice()) | bits(self.inertia.as_slice()) == 0 {
            return Vector3::zeros();
        }
        let (i, w) = (&self.inertia, &self.omega);
        i * self.omega_dot + w.cross(&(i * w))
    }
}

/// One limb at one pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LimbPose {
    /// Base-joint centre `B` and spherical-joint centre `A`.
    pub b: Vector3<f64>,
    pub a: Vector3<f64>,
    /// Unit joint axes: the revolute's in `axes[0]`; the universal joint's `a1`, `a2`.
    pub axes: [Vector3<f64>; 2],
    /// The leg's bodies (unused ones massless).
    pub bodies: [Body; MAX_BODIES],
}

impl LimbPose {
    /// The directions of the couple the base joint transmits: two unit vectors `⟂` the
    /// revolute axis, or `n = a1 × a2`.
    pub(crate) fn moment_basis(&self, joint: BaseJoint) -> [Vector3<f64>; 2] {
        let u = self.axes[0];
        match joint {
            BaseJoint::Revolute => {
                // The world axis least along u: x_j and −z for a horizontal y_j.
                let k = u.iamin();
                let d1 = u.cross(&Vector3::ith(k, 1.0)).normalize();
                [d1, u.cross(&d1)]
            }
            BaseJoint::Universal => [u.cross(&self.axes[1]), Vector3::zeros()],
        }
    }
}

/// A whole mechanism at one pose.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Posed {
    pub limbs: [LimbPose; MAX_LIMBS],
    /// The platform as one composite body (`centre` = C).
    pub platform: Body,
    /// The tool-centre point P, where twists are reduced.
    pub p: Vector3<f64>,
    /// `(Ψ, Θ)`, for the Euler-angle form of the errors.
    pub psi_theta: (f64, f64),
    /// External force (applied at `force_at`, world) and couple on the platform.
    pub force: Vector3<f64>,
    pub force_at: Vector3<f64>,
    pub moment: Vector3<f64>,
}

/// The 3-PRS and 3-RPS as limbs (docs/model.md §1–6, §10.1–10.2): revolute base joints
/// about `y_j`, and the four kinds in the order of `clearance_model::KINDS`.
pub fn three_limb_assembly(model: &Model) -> Assembly {
    let actuated = match model.geometry.kind {
        MechanismKind::Prs3 => Actuated::Slider,
        MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => Actuated::Leg,
    };
    let [s, r, a, th] = model.clearance;
    let kinds = vec![
        ClearanceSite { name: "s_radial", site: Site::Platform, rule: Rule::AgainstForce, magnitude: s },
        ClearanceSite { name: "r_radial", site: Site::Base, rule: Rule::AgainstForceAcrossAxis, magnitude: r },
        ClearanceSite { name: "r_axial", site: Site::Base, rule: Rule::AlongAxis, magnitude: a },
        ClearanceSite { name: "r_angular", site: Site::Base, rule: Rule::AgainstMoment, magnitude: th },
    ];
    let limbs = vec![LimbModel { base: BaseJoint::Revolute, actuated }; 3];
    Assembly::new(limbs, kinds, model.gravity, model.indeterminate_floor, model.singular_cond)
}

/// A 3-limb posture and its motion as [`Posed`]: the 3-PRS leg one slender body about
/// its midpoint, the 3-RPS leg a cylinder from `B_j` and a piston up to `A_j` (§10.2).
pub fn three_limb_posed(model: &Model, pose: &Posture, inertial: &Inertial) -> Posed {
    let mass = &model.mass;
    let mut posed = Posed::default();
    for j in 0..3 {
        let e = pose.e[j];
        let (w, w_dot) = (inertial.leg_omega[j], inertial.leg_omega_dot[j]);
        let body = |mass: f64, centre, inertia, acc| Body { mass, centre, inertia, acc, omega: w, omega_dot: w_dot };
        let bodies = match model.geometry.kind {
            MechanismKind::Prs3 => [
                body(
                    mass.leg_mass,
                    0.5 * (pose.a[j] + pose.b[j]),
                    leg_inertia_world(mass, &e),
                    inertial.leg_com_acc[j],
                ),
                Body::default(),
            ],
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                let (cyl, pis) = (&mass.cylinder, &mass.piston);
                [
                    body(
                        cyl.mass,
                        pose.b[j] + 0.5 * cyl.length * e,
                        cyl.inertia_world(&e),
                        0.5 * cyl.length * inertial.e_ddot[j],
                    ),
                    body(
                        pis.mass,
                        pose.a[j] - 0.5 * pis.length * e,
                        pis.inertia_world(&e),
                        inertial.a_ddot[j] - 0.5 * pis.length * inertial.e_ddot[j],
                    ),
                ]
            }
        };
        posed.limbs[j] = LimbPose { b: pose.b[j], a: pose.a[j], axes: [model.geometry.y[j], Vector3::zeros()], bodies };
    }
    posed.platform = Body {
        mass: mass.platform_mass,
        centre: pose.p + pose.rot * mass.com_local,
        inertia: pose.rot * mass.inertia_local * pose.rot.transpose(),
        acc: inertial.com_acc,
        omega: inertial.omega,
        omega_dot: inertial.omega_dot,
    };
    posed.p = pose.p;
    posed.psi_theta = (pose.psi, pose.theta);
    posed.force = model.load.force;
    posed.force_at = pose.p + pose.rot * model.load.at_local;
    posed.moment = model.load.moment;
    posed
}
