//! A mechanism as limbs, and the two linear systems assembled from that description
//! for any number of limbs (docs/model.md §4–6, §10).
//!
//! A limb is a base joint at `B` (revolute about one axis, or universal with a fixed
//! axis `a1` and a leg axis `a2`), a leg of one or more rigid bodies (a locked prismatic
//! joint inside it, if any, is internal), and a spherical joint at `A` on the platform.
//! The static part ([`Assembly`]: joint types, clearance sites and how each is taken
//! up) is built once per job; the posed part ([`Posed`]: points, axes, bodies and their
//! motion) once per pose; the scratch ([`AssemblyData`]) once per worker.
//!
//! **Equilibrium** `A·w = b`, `(6n + 6) × Σ unknowns`, square for these joints. Limb i's
//! unknowns, in order: the force `f_B` of the base on the leg at `B` (world x, y, z), the
//! couple the base joint transmits in its own basis (`μ_1·d_1 + μ_2·d_2 ⟂` the revolute
//! axis; `μ·n` with `n = a1 × a2` for the universal joint), and the force `f_S` of the
//! leg on the platform at `A`. Rows: leg i's forces (`6i..6i+3`),
//!
//! ```text
//! f_B − f_S = Σ_b m_b·(a_b − g),
//! ```
//!
//! its moments about `B` (`6i+3..6i+6`), where `f_B` has no arm,
//!
//! ```text
//! m_B − (A − B)×f_S = Σ_b I_b·ω̇_b + ω_b×(I_b·ω_b) + (G_b − B)×m_b·(a_b − g),
//! ```
//!
//! then the platform's forces and moments about its composite centre of mass `C`
//! (`6n..6n+6`), `Σ f_S = m·(a_C − g) − f_ext`, `Σ (A − C)×f_S = I_C·ω̇ + ω×(I_C·ω) −
//! (E − C)×f_ext − m_ext`.
//!
//! **Error system** `J_P·Δq_P = J_Cl·Δq_Cl`, `6(n − 1)` square. Limb i's passive screws
//! `[axis; (point − P)×axis]`: the revolute's one or the universal joint's two rotations
//! through `B`, then the spherical joint's rotations about world x, y, z through `A`
//! (a locked prismatic joint adds none). Rows `6(l−1)..6l` close limb l against limb 1:
//! `Σ $_l·Δq_l + t_l = Σ $_1·Δq_1 + t_1`, `t` the limb's clearance twist. One right-hand
//! side per clearance kind; the kind's pose error is limb 1's twist.
//!
//! Both are factored by faer's partial-pivoting LU ([`LuSolver`]) with `κ₁` from the
//! explicit inverse; [`Assembly::solve`] allocates nothing.

use clearance_kinematics::{Posture, euler_rates_matrix};
use clearance_model::MechanismKind;
use faer::{Mat, MatMut, MatRef};
use nalgebra::{Matrix3, Vector3, Vector6};

use crate::bodies::{Inertial, Model, leg_inertia_world};
use crate::error_system::PoseError;
use crate::linalg::LuSolver;
use crate::pose::Status;

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
    fn rotation(self) -> bool {
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
    fn demand(&self, g: &Vector3<f64>) -> Vector3<f64> {
        self.mass * (self.acc - g)
    }

    /// `I·ω̇ + ω×(I·ω)`.
    fn spin(&self) -> Vector3<f64> {
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
    fn moment_basis(&self, joint: BaseJoint) -> [Vector3<f64>; 2] {
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

/// A mechanism's limbs and clearances: built once, shared by every worker.
#[derive(Clone, Debug, PartialEq)]
pub struct Assembly {
    pub limbs: Vec<LimbModel>,
    pub kinds: Vec<ClearanceSite>,
    pub gravity: Vector3<f64>,
    /// Loads at or below this leave a take-up indeterminate (N or N·m).
    pub floor: f64,
    /// Above this `κ₁` of `A` or `J_P` a pose is near-singular.
    pub singular_cond: f64,
    /// First column of limb i's reactions in `w`, and of its passive motions in `Δq_P`.
    w_col: Vec<usize>,
    dq_col: Vec<usize>,
}

/// Everything solved at one pose. Arrays are indexed by limb (then kind) up to
/// [`MAX_LIMBS`] and [`MAX_KINDS`]; entries past the mechanism's are zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbsSolution {
    pub status: Status,
    /// Force of the base on the leg at `B`, the couple (world) and its components in the
    /// joint's basis, the force of the leg on the platform at `A`.
    pub f_b: [Vector3<f64>; MAX_LIMBS],
    pub m_b: [Vector3<f64>; MAX_LIMBS],
    pub mu: [[f64; 2]; MAX_LIMBS],
    pub f_s: [Vector3<f64>; MAX_LIMBS],
    /// Per kind and limb: the take-up (translation or rotation vector) and its margin.
    pub take: [[Vector3<f64>; MAX_LIMBS]; MAX_KINDS],
    pub margins: [[f64; MAX_LIMBS]; MAX_KINDS],
    /// Per kind: its take-up is determinate (or its clearance is zero).
    pub kind_ok: [bool; MAX_KINDS],
    pub errors: [PoseError; MAX_KINDS],
    pub total: PoseError,
    /// `κ₁` of `A` and of `J_P` (NaN where not reached).
    pub cond_a: f64,
    pub cond_jp: f64,
}

impl Default for LimbsSolution {
    fn default() -> Self {
        let z = [Vector3::zeros(); MAX_LIMBS];
        Self {
            status: Status::NearSingular,
            f_b: z,
            m_b: z,
            mu: [[0.0; 2]; MAX_LIMBS],
            f_s: z,
            take: [z; MAX_KINDS],
            margins: [[0.0; MAX_LIMBS]; MAX_KINDS],
            kind_ok: [false; MAX_KINDS],
            errors: [PoseError::default(); MAX_KINDS],
            total: PoseError::default(),
            cond_a: f64::NAN,
            cond_jp: f64::NAN,
        }
    }
}

/// Scratch for one worker: sized once for an [`Assembly`], reused for every pose.
pub struct AssemblyData {
    a: Mat<f64>,
    w: Mat<f64>,
    inv_a: Mat<f64>,
    lu_a: LuSolver,
    jp: Mat<f64>,
    dq: Mat<f64>,
    inv_jp: Mat<f64>,
    lu_jp: LuSolver,
}

impl AssemblyData {
    pub fn new(assembly: &Assembly) -> Self {
        let (n, m) = (assembly.unknowns(), assembly.passive());
        let k = assembly.kinds.len();
        Self {
            a: Mat::zeros(n, n),
            w: Mat::zeros(n, 1),
            inv_a: Mat::zeros(n, n),
            lu_a: LuSolver::new(n, n),
            jp: Mat::zeros(m, m),
            dq: Mat::zeros(m, k),
            inv_jp: Mat::zeros(m, m),
            lu_jp: LuSolver::new(m, m.max(k)),
        }
    }

    /// The last assembled `A` and `J_P` (for tests and diagnostics).
    pub fn a(&self) -> MatRef<'_, f64> {
        self.a.as_ref()
    }
    pub fn jp(&self) -> MatRef<'_, f64> {
        self.jp.as_ref()
    }
}

fn put3(a: &mut MatMut<'_, f64>, row: usize, col: usize, m: &Matrix3<f64>) {
    for i in 0..3 {
        for k in 0..3 {
            a[(row + i, col + k)] = m[(i, k)];
        }
    }
}

fn twist(w: Vector3<f64>, v: Vector3<f64>) -> Vector6<f64> {
    Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
}

/// `−mag·v/|v|` when `|v|` is above the floor, else zero (direction undefined).
fn against(v: Vector3<f64>, norm: f64, mag: f64, floor: f64) -> Vector3<f64> {
    if norm > floor && norm > 0.0 { v * -(mag / norm) } else { Vector3::zeros() }
}

/// `[Δα; Δp]` with the Euler-angle form `(ΔΦ, ΔΨ, ΔΘ)` of docs/model.md §6.
pub fn pose_error(t: &Vector6<f64>, (psi, theta): (f64, f64)) -> PoseError {
    let dalpha = Vector3::new(t[0], t[1], t[2]);
    let e = euler_rates_matrix(psi, theta).try_inverse().map_or(Vector3::repeat(f64::NAN), |m| m * dalpha);
    PoseError { dalpha, dp: Vector3::new(t[3], t[4], t[5]), euler: [e[2], e[1], e[0]] }
}

impl Assembly {
    #[track_caller]
    pub fn new(
        limbs: Vec<LimbModel>,
        kinds: Vec<ClearanceSite>,
        gravity: Vector3<f64>,
        floor: f64,
        singular_cond: f64,
    ) -> Self {
        assert!((2..=MAX_LIMBS).contains(&limbs.len()), "2 to {MAX_LIMBS} limbs, not {}", limbs.len());
        assert!(kinds.len() <= MAX_KINDS, "at most {MAX_KINDS} clearance kinds, not {}", kinds.len());
        let (mut w_col, mut dq_col) = (Vec::new(), Vec::new());
        let (mut w, mut dq) = (0, 0);
        for l in &limbs {
            w_col.push(w);
            dq_col.push(dq);
            w += 6 + l.base.moments();
            dq += 3 + l.base.freedoms();
        }
        let out = Self { limbs, kinds, gravity, floor, singular_cond, w_col, dq_col };
        assert_eq!(out.unknowns(), w, "the equilibrium must be square: 6 unknowns per limb + its couple's");
        assert_eq!(out.passive(), dq, "the error system must be square: 6 passive freedoms per limb");
        out
    }

    /// `κ₁` within the limit (NaN is not).
    fn conditioned(&self, cond: f64) -> bool {
        matches!(cond.partial_cmp(&self.singular_cond), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal))
    }

    /// Rows (and unknowns) of `A`: `6n + 6`.
    pub fn unknowns(&self) -> usize {
        6 * self.limbs.len() + 6
    }

    /// Rows (and unknowns) of `J_P`: `6(n − 1)`.
    pub fn passive(&self) -> usize {
        6 * (self.limbs.len() - 1)
    }

    /// Writes `A` and `b` (docs/model.md §4) for the pose; both are overwritten whole.
    pub fn assemble_equilibrium(&self, posed: &Posed, mut a: MatMut<'_, f64>, mut b: MatMut<'_, f64>) {
        a.fill(0.0);
        let g = &self.gravity;
        let eye = Matrix3::identity();
        let n = self.limbs.len();
        let plat = &posed.platform;
        for (i, limb) in self.limbs.iter().enumerate() {
            let lp = &posed.limbs[i];
            let (r, c) = (6 * i, self.w_col[i]);
            let k = limb.base.moments();
            let s = c + 3 + k;
            put3(&mut a, r, c, &eye);
            put3(&mut a, r, s, &(-eye));
            let basis = lp.moment_basis(limb.base);
            for (m, d) in basis.iter().take(k).enumerate() {
                for q in 0..3 {
                    a[(r + 3 + q, c + 3 + m)] = d[q];
                }
            }
            put3(&mut a, r + 3, s, &(-(lp.a - lp.b).cross_matrix()));
            let (mut f_rhs, mut m_rhs) = (Vector3::zeros(), Vector3::zeros());
            for body in &lp.bodies {
                let f = body.demand(g);
                f_rhs += f;
                m_rhs += body.spin() + (body.centre - lp.b).cross(&f);
            }
            put3(&mut a, 6 * n, s, &eye);
            put3(&mut a, 6 * n + 3, s, &(lp.a - plat.centre).cross_matrix());
            for q in 0..3 {
                b[(r + q, 0)] = f_rhs[q];
                b[(r + 3 + q, 0)] = m_rhs[q];
            }
        }
        let f_rhs = plat.demand(g) - posed.force;
        let m_rhs = plat.spin() - (posed.force_at - plat.centre).cross(&posed.force) - posed.moment;
        for q in 0..3 {
            b[(6 * n + q, 0)] = f_rhs[q];
            b[(6 * n + 3 + q, 0)] = m_rhs[q];
        }
    }

    /// Reads the reactions out of `w` into `out`.
    fn reactions_into(&self, posed: &Posed, w: &Mat<f64>, out: &mut LimbsSolution) {
        let v = |k: usize| Vector3::new(w[(k, 0)], w[(k + 1, 0)], w[(k + 2, 0)]);
        for (i, limb) in self.limbs.iter().enumerate() {
            let c = self.w_col[i];
            let k = limb.base.moments();
            let basis = posed.limbs[i].moment_basis(limb.base);
            out.f_b[i] = v(c);
            out.m_b[i] = Vector3::zeros();
            for m in 0..k {
                out.mu[i][m] = w[(c + 3 + m, 0)];
                out.m_b[i] += out.mu[i][m] * basis[m];
            }
            out.f_s[i] = v(c + 3 + k);
        }
    }

    /// Take-ups, margins and which kinds are determinate, from the reactions in `out`.
    pub fn take_up(&self, posed: &Posed, out: &mut LimbsSolution) {
        let floor = self.floor;
        for (k, kind) in self.kinds.iter().enumerate() {
            let mut ok = true;
            for (i, limb) in self.limbs.iter().enumerate() {
                let lp = &posed.limbs[i];
                let f = match kind.site {
                    Site::Base => out.f_b[i],
                    Site::Platform => out.f_s[i],
                };
                let (m, c, u) = (out.m_b[i], kind.magnitude, lp.axes[0]);
                let (take, margin) = match kind.rule {
                    Rule::AgainstForce => {
                        let n = f.norm();
                        (against(f, n, c, floor), n)
                    }
                    Rule::AgainstForceAcrossAxis => {
                        let perp = f - u * f.dot(&u);
                        let n = perp.norm();
                        (against(perp, n, c, floor), n)
                    }
                    Rule::AlongAxis => {
                        let axial = f.dot(&u);
                        let t = if axial.abs() > floor { u * (-c * axial.signum()) } else { Vector3::zeros() };
                        (t, axial.abs())
                    }
                    Rule::AgainstMoment => {
                        let n = m.norm();
                        (against(m, n, c, floor), n)
                    }
                    Rule::AboutForbidden => (c * lp.moment_basis(limb.base)[0], m.norm()),
                };
                out.take[k][i] = take;
                out.margins[k][i] = margin;
                ok &= kind.rule == Rule::AboutForbidden || margin > floor;
            }
            out.kind_ok[k] = ok || kind.magnitude == 0.0;
        }
    }

    /// Limb i's passive screws, in the order of its columns of `J_P`.
    fn screws(&self, posed: &Posed, i: usize) -> ([Vector6<f64>; 5], usize) {
        let lp = &posed.limbs[i];
        let (rb, ra) = (lp.b - posed.p, lp.a - posed.p);
        let s = |axis: Vector3<f64>, r: Vector3<f64>| twist(axis, r.cross(&axis));
        let f = self.limbs[i].base.freedoms();
        let mut out = [Vector6::zeros(); 5];
        for u in 0..f {
            out[u] = s(lp.axes[u], rb);
        }
        for k in 0..3 {
            out[f + k] = s(Vector3::ith(k, 1.0), ra);
        }
        (out, f + 3)
    }

    /// Limb i's clearance twist for kind k: `[θ; (B − P)×θ]` for a rotation about the
    /// joint's centre, `[0; t]` for a translation.
    fn clearance_twist(&self, posed: &Posed, sol: &LimbsSolution, k: usize, i: usize) -> Vector6<f64> {
        let t = sol.take[k][i];
        let kind = &self.kinds[k];
        if !kind.rule.rotation() {
            return twist(Vector3::zeros(), t);
        }
        let centre = match kind.site {
            Site::Base => posed.limbs[i].b,
            Site::Platform => posed.limbs[i].a,
        };
        twist(t, (centre - posed.p).cross(&t))
    }

    /// Writes `J_P` and the right-hand sides (one column per kind) for the take-ups in
    /// `sol` (docs/model.md §6); both are overwritten whole.
    pub fn assemble_error(
        &self,
        posed: &Posed,
        sol: &LimbsSolution,
        mut jp: MatMut<'_, f64>,
        mut rhs: MatMut<'_, f64>,
    ) {
        jp.fill(0.0);
        let (first, m0) = self.screws(posed, 0);
        for l in 1..self.limbs.len() {
            let row = 6 * (l - 1);
            let (other, ml) = self.screws(posed, l);
            for q in 0..6 {
                for u in 0..ml {
                    jp[(row + q, self.dq_col[l] + u)] = other[u][q];
                }
                for u in 0..m0 {
                    jp[(row + q, u)] = -first[u][q];
                }
            }
            for k in 0..self.kinds.len() {
                let d = self.clearance_twist(posed, sol, k, 0) - self.clearance_twist(posed, sol, k, l);
                for q in 0..6 {
                    rhs[(row + q, k)] = d[q];
                }
            }
        }
    }

    /// Reactions, take-up, per-kind and total errors of one pose. A singular or
    /// ill-conditioned `A` or `J_P` gives `near_singular` with what was reached.
    pub fn solve(&self, posed: &Posed, data: &mut AssemblyData) -> LimbsSolution {
        let mut out = LimbsSolution::default();
        self.assemble_equilibrium(posed, data.a.as_mut(), data.w.as_mut());
        if !data.lu_a.factor(data.a.as_ref()) {
            out.cond_a = f64::INFINITY;
            return out;
        }
        out.cond_a = data.lu_a.cond_one(data.a.as_ref(), data.inv_a.as_mut());
        if !self.conditioned(out.cond_a) {
            return out;
        }
        data.lu_a.solve_factored(data.w.as_mut());
        self.reactions_into(posed, &data.w, &mut out);
        self.take_up(posed, &mut out);
        self.assemble_error(posed, &out, data.jp.as_mut(), data.dq.as_mut());
        if !data.lu_jp.factor(data.jp.as_ref()) {
            out.cond_jp = f64::INFINITY;
            return out;
        }
        out.cond_jp = data.lu_jp.cond_one(data.jp.as_ref(), data.inv_jp.as_mut());
        if !self.conditioned(out.cond_jp) {
            return out;
        }
        data.lu_jp.solve_factored(data.dq.as_mut());
        let (first, m0) = self.screws(posed, 0);
        for k in 0..self.kinds.len() {
            let mut t = self.clearance_twist(posed, &out, k, 0);
            for u in 0..m0 {
                t += first[u] * data.dq[(u, k)];
            }
            out.errors[k] = pose_error(&t, posed.psi_theta);
            out.total.dalpha += out.errors[k].dalpha;
            out.total.dp += out.errors[k].dp;
            for q in 0..3 {
                out.total.euler[q] += out.errors[k].euler[q];
            }
        }
        let determinate = out.kind_ok.iter().take(self.kinds.len()).all(|&ok| ok);
        out.status = if determinate { Status::Ok } else { Status::IndeterminateContact };
        out
    }

    /// [`Assembly::solve`] for each pose of a batch, into `out` (same length).
    #[track_caller]
    pub fn solve_batch(&self, posed: &[Posed], data: &mut AssemblyData, out: &mut [LimbsSolution]) {
        assert_eq!(posed.len(), out.len(), "one result per pose");
        for (p, o) in posed.iter().zip(out) {
            *o = self.solve(p, data);
        }
    }
}

/// The 3-PRS and 3-RPS as limbs (docs/model.md §1–6, §10.1–10.2): revolute base joints
/// about `y_j`, and the four kinds in the order of `clearance_model::KINDS`.
pub fn three_limb_assembly(model: &Model) -> Assembly {
    let actuated = match model.geometry.kind {
        MechanismKind::Prs3 => Actuated::Slider,
        MechanismKind::Rps3 => Actuated::Leg,
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
            MechanismKind::Rps3 => {
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
