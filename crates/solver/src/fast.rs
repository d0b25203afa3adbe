//! The fast path: the same physics as [`equilibrium`](crate::equilibrium) and
//! [`error_system`](crate::error_system), on two 6 × 6 systems instead of
//! 24 × 24 and 12 × 12, written once for one pose (`f64`) and for a batch of poses
//! ([`F8`](crate::lanes::F8)), see [`lanes`](crate::lanes).
//!
//! **Equilibrium.** Eliminating leg j (`f_Rj = f_Sj + c_j`, `c_j = m_leg·(a_Gj − g)`)
//! turns its moment equation into `m_Rj = h_j + L·e_j×f_Sj + L/2·e_j×c_j`; the revolute
//! joint's freedom about `y_j` (`m_Rj·y_j = 0`) then fixes the component of `f_Sj` along
//! `n_j = y_j × e_j`: `f_Sj·n_j = γ_j = −(h_j + L/2·e_j×c_j)·y_j / L`. What is left, the
//! components along `e_j` and `y_j`, solves the platform's six equations (moments about P):
//! `G·u = b` with columns `[e_j; r_j×e_j]`, `[y_j; r_j×y_j]`, `r_j = A_j − P`.
//!
//! **Error.** Forces along `e_j` and `y_j` through `A_j` are reciprocal to every passive
//! screw of limb j (the S rotations about `A_j` and the R rotation about `y_j` through
//! `B_j`), so the platform twist `ΔΓ = [Δα; Δp]` satisfies, for each such force `f`,
//! `f·(Δp + Δα×r_j) = f·(v_j + ω_j×r_j)` with `[ω_j; v_j]` the clearance twist of limb j:
//! six equations `M·ΔΓ = d`, one right-hand side per clearance kind. `M` is `G`
//! transposed with its halves swapped, so one LU of `G` solves both. Both are exactly
//! the 24 × 24 and 12 × 12 systems after elimination; the two paths agree to round-off
//! (tested on random poses).

use clearance_kinematics::{Geometry, Posture, limb, parasitic_of, parasitic_sc, rotation_sc, slider};
use clearance_model::MechanismKind;
use nalgebra::{Matrix3, Vector3};

use crate::bodies::{Inertial, Model, leg_inertia_world};
use crate::equilibrium::JointReactions;
use crate::error_system::PoseError;
use crate::lanes::{LANES, Lane, Mask, V3, each3, each4, each6, lane3, lane3v};
use crate::takeup::TakeUps;

/// A 6 × 6 matrix, row-major.
type A6<L> = [[L; 6]; 6];

#[inline(always)]
fn c<L: Lane>(v: f64) -> L {
    L::constant(v)
}

/// A 6 × 6 LU with partial pivoting (`P·A = L·U`) on plain arrays, so that every
/// loop has fixed bounds and unrolls. Each lane picks its own pivots: rows are
/// exchanged by masks, not branches.
struct Lu6<L: Lane> {
    lu: A6<L>,
    /// Row `i` of `P·A` is row `perm[i]` of `A` (an index held as a number).
    perm: [L; 6],
    /// `1/U[i][i]`: substitutions multiply by it rather than divide (a vector division
    /// costs as much as a dozen multiplications).
    inv: [L; 6],
    /// Every pivot non-zero and finite.
    regular: L::M,
}

impl<L: Lane> Lu6<L> {
    #[inline(always)]
    fn new(mut a: A6<L>) -> Self {
        let mut perm: [L; 6] = each6(|i| c(i as f64));
        let mut regular = L::M::splat(true);
        let mut inv = [c::<L>(0.0); 6];
        for k in 0..6 {
            // The first row with the largest magnitude in column k.
            let mut best = a[k][k].abs();
            let mut p = c::<L>(k as f64);
            for i in k + 1..6 {
                let v = a[i][k].abs();
                let m = v.gt(best);
                best = L::select(m, v, best);
                p = L::select(m, c(i as f64), p);
            }
            for i in k + 1..6 {
                let m = p.eq(c(i as f64));
                for j in 0..6 {
                    let (rk, ri) = (a[k][j], a[i][j]);
                    a[k][j] = L::select(m, ri, rk);
                    a[i][j] = L::select(m, rk, ri);
                }
                let (pk, pi) = (perm[k], perm[i]);
                perm[k] = L::select(m, pi, pk);
                perm[i] = L::select(m, pk, pi);
            }
            let pivot = a[k][k];
            regular = regular & !pivot.eq(c(0.0)) & pivot.finite();
            inv[k] = c::<L>(1.0) / pivot;
            for i in k + 1..6 {
                let l = a[i][k] * inv[k];
                a[i][k] = l;
                for j in k + 1..6 {
                    a[i][j] = a[i][j] - l * a[k][j];
                }
            }
        }
        Self { lu: a, perm, inv, regular }
    }

    /// `A·X = B` for `K` right-hand sides at once (row `i` of `B` holds component `i`
    /// of every right-hand side): `x = P·b`, then `L` forward and `U` backward.
    #[inline(always)]
    fn solve_rows<const K: usize>(&self, b: &[[L; K]; 6]) -> [[L; K]; 6] {
        let lu = &self.lu;
        let mut x = [b[0]; 6];
        for (xi, &p) in x.iter_mut().zip(&self.perm) {
            for (r, br) in b.iter().enumerate().skip(1) {
                let m = p.eq(c(r as f64));
                for (v, &w) in xi.iter_mut().zip(br) {
                    *v = L::select(m, w, *v);
                }
            }
        }
        for i in 1..6 {
            for j in 0..i {
                let (row, l) = (x[j], lu[i][j]);
                for (xi, r) in x[i].iter_mut().zip(row) {
                    *xi = *xi - l * r;
                }
            }
        }
        for i in (0..6).rev() {
            for j in i + 1..6 {
                let (row, u) = (x[j], lu[i][j]);
                for (xi, r) in x[i].iter_mut().zip(row) {
                    *xi = *xi - u * r;
                }
            }
            for xi in &mut x[i] {
                *xi = *xi * self.inv[i];
            }
        }
        x
    }

    /// `Aᵀ·x = d` for `K` right-hand sides at once (row `i` of `d` holds component
    /// `i` of every right-hand side): `Uᵀ·z = d`, `Lᵀ·w = z`, `x = Pᵀ·w`.
    #[inline(always)]
    fn solve_transposed<const K: usize>(&self, d: &[[L; K]; 6]) -> [[L; K]; 6] {
        let lu = &self.lu;
        let mut w = *d;
        for i in 0..6 {
            for k in 0..i {
                let (l, u) = (w[k], lu[k][i]);
                for (wi, lk) in w[i].iter_mut().zip(l) {
                    *wi = *wi - u * lk;
                }
            }
            for wi in &mut w[i] {
                *wi = *wi * self.inv[i];
            }
        }
        for i in (0..5).rev() {
            for k in i + 1..6 {
                let (l, f) = (w[k], lu[k][i]);
                for (wi, lk) in w[i].iter_mut().zip(l) {
                    *wi = *wi - f * lk;
                }
            }
        }
        // x[perm[i]] = w[i]: each row of x takes the one w whose index lands there.
        let mut x = [w[0]; 6];
        for (r, xr) in x.iter_mut().enumerate() {
            for (wi, &p) in w.iter().zip(&self.perm).skip(1) {
                let m = p.eq(c(r as f64));
                for (v, &u) in xr.iter_mut().zip(wi) {
                    *v = L::select(m, u, *v);
                }
            }
        }
        x
    }

    /// `‖A⁻¹‖₁` and `‖A⁻¹‖∞`, from the explicit inverse `(L·U)⁻¹`: `A⁻¹ = (L·U)⁻¹·P`
    /// only reorders its columns, which changes neither norm.
    ///
    /// Also returns `(L·U)⁻¹` itself ([`Lu6::inverse_of`] puts its columns in order).
    #[inline(always)]
    fn inverse_norms(&self) -> (L, L, A6<L>) {
        let lu = &self.lu;
        let zero = c::<L>(0.0);
        // Y = L⁻¹, lower triangular with a unit diagonal: row i is zero past column i.
        let mut x = [[zero; 6]; 6];
        for i in 0..6 {
            x[i][i] = c(1.0);
            for j in 0..i {
                let l = lu[i][j];
                for k in 0..=j {
                    x[i][k] = x[i][k] - l * x[j][k];
                }
            }
        }
        // X = U⁻¹·Y.
        for i in (0..6).rev() {
            for j in i + 1..6 {
                let (row, u) = (x[j], lu[i][j]);
                for (xi, r) in x[i].iter_mut().zip(row) {
                    *xi = *xi - u * r;
                }
            }
            for xi in &mut x[i] {
                *xi = *xi * self.inv[i];
            }
        }
        let mut col_sums = [zero; 6];
        let mut row_max = zero;
        for row in &x {
            let mut sum = zero;
            for (s, v) in col_sums.iter_mut().zip(row) {
                *s = *s + v.abs();
                sum = sum + v.abs();
            }
            row_max = row_max.max(sum);
        }
        (col_sums.iter().fold(zero, |m, &s| m.max(s)), row_max, x)
    }

    /// `A⁻¹` from `(L·U)⁻¹`: column `perm[i]` of `A⁻¹` is column `i` of `(L·U)⁻¹`.
    #[inline(always)]
    fn inverse_of(&self, x: &A6<L>) -> A6<L> {
        let mut inv = [[c::<L>(0.0); 6]; 6];
        for (i, &p) in self.perm.iter().enumerate() {
            for col in 0..6 {
                let m = p.eq(c(col as f64));
                for r in 0..6 {
                    inv[r][col] = L::select(m, x[r][i], inv[r][col]);
                }
            }
        }
        inv
    }
}

/// `‖A‖₁` and `‖A‖∞`.
#[inline(always)]
fn norms<L: Lane>(a: &A6<L>) -> (L, L) {
    let mut one = c::<L>(0.0);
    let mut inf = c::<L>(0.0);
    for k in 0..6 {
        let (mut col, mut row) = (c::<L>(0.0), c::<L>(0.0));
        for i in 0..6 {
            col = col + a[i][k].abs();
            row = row + a[k][i].abs();
        }
        one = one.max(col);
        inf = inf.max(row);
    }
    (one, inf)
}

#[inline(always)]
fn six<L: Lane>(a: V3<L>, b: V3<L>) -> [L; 6] {
    [a.x, a.y, a.z, b.x, b.y, b.z]
}

/// The nominal posture of one pose or of a batch, with what the solver needs of it.
#[derive(Clone, Copy)]
pub struct Pose<L: Lane> {
    pub z: L,
    pub psi: L,
    pub theta: L,
    /// `(sin, cos)` of Ψ and Θ.
    pub sc_psi: (L, L),
    pub sc_theta: (L, L),
    /// Parasitic motions `X, Y, Φ`.
    pub x: L,
    pub y: L,
    pub phi: L,
    pub p: V3<L>,
    /// `R`, row-major.
    pub rot: [[L; 3]; 3],
    pub a: [V3<L>; 3],
    pub b: [V3<L>; 3],
    pub e: [V3<L>; 3],
    pub q: [L; 3],
    /// Leg lengths `|A_j − B_j|`: `L` (3-PRS) or `q_j` (3-RPS).
    pub ell: [L; 3],
    /// Every leg can be assembled (where not, the other fields past the parasitic
    /// motions are meaningless).
    pub reachable: L::M,
    /// Some 3-PRS leg lies across its rail: a singular pose.
    pub across: L::M,
}

/// What a described 3-PRS reads of a posture ([`Pose::points`]): the S joints' centres
/// `A_j`, the R joints' `B_j`, the legs' directions `e_j` and the TCP `p`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Points {
    pub a: [Vector3<f64>; 3],
    pub b: [Vector3<f64>; 3],
    pub e: [Vector3<f64>; 3],
    pub p: Vector3<f64>,
}

impl<L: Lane> Pose<L> {
    /// The inverse kinematics of `inverse_kinematics`, lane by lane: the closed forms,
    /// or Newton one lane at a time where the layout has none.
    #[inline(always)]
    pub fn new(geom: &Geometry, z: L, psi: L, theta: L) -> Self {
        let (sc_psi, sc_theta) = (psi.sin_cos(), theta.sin_cos());
        let (x, y, phi, sc_phi, mut reachable) = if geom.closed_form {
            let (x, y, phi, sc_phi) = parasitic_sc(geom.platform_radius, sc_psi, sc_theta);
            (x, y, phi, sc_phi, L::M::splat(true))
        } else {
            // X, Y, Φ, sin Φ, cos Φ of each lane; NaN where Newton did not converge.
            let solved: [[f64; 5]; LANES] = std::array::from_fn(|i| match i < L::WIDTH {
                true => parasitic_of(geom, psi.get(i), theta.get(i))
                    .map_or([f64::NAN; 5], |(x, y, phi, (s, c))| [x, y, phi, s, c]),
                false => [f64::NAN; 5],
            });
            let part = |k: usize| L::from_fn(|i| solved[i][k]);
            let (x, y, phi) = (part(0), part(1), part(2));
            (x, y, phi, (part(3), part(4)), x.finite())
        };
        let rot = rotation_sc(sc_phi, sc_psi, sc_theta);
        let p = [x, y, z];
        let mut across = L::M::splat(false);
        let (mut a, mut b, mut e, mut q) = ([V3::zero(); 3], [V3::zero(); 3], [V3::zero(); 3], [c(0.0); 3]);
        let mut ell = [c(0.0); 3];
        for j in 0..3 {
            let (aj, disc) = limb(geom, j, p, &rot);
            // Each also false for NaN.
            match geom.kind {
                MechanismKind::Prs3 => {
                    reachable = reachable & c::<L>(0.0).le(disc);
                    across = across | c::<L>(1e-6 * geom.leg_length).gt(disc.sqrt());
                }
                MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                    let len = disc.sqrt();
                    reachable = reachable & c::<L>(geom.stroke.0).le(len) & len.le(c(geom.stroke.1));
                }
            }
            let (qj, bj) = slider(geom, j, aj, disc);
            (a[j], b[j], q[j]) = (V3::from_array(aj), V3::from_array(bj), qj);
            let d = a[j] - b[j];
            ell[j] = match geom.kind {
                MechanismKind::Prs3 => c::<L>(geom.leg_length),
                MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => qj,
            };
            let l = ell[j];
            e[j] = V3::new(d.x / l, d.y / l, d.z / l);
        }
        let p = V3::from_array(p);
        Self { z, psi, theta, sc_psi, sc_theta, x, y, phi, p, rot, a, b, e, q, ell, reachable, across }
    }

    /// Lane `i`'s points (a tenth of [`Pose::posture`]'s cost).
    #[inline(always)]
    pub fn points(&self, i: usize) -> Points {
        Points { a: lane3v(&self.a, i), b: lane3v(&self.b, i), e: lane3v(&self.e, i), p: self.p.get(i) }
    }

    /// Lane `i` as a [`Posture`].
    pub fn posture(&self, i: usize) -> Posture {
        Posture {
            z: self.z.get(i),
            psi: self.psi.get(i),
            theta: self.theta.get(i),
            x: self.x.get(i),
            y: self.y.get(i),
            phi: self.phi.get(i),
            p: self.p.get(i),
            rot: Matrix3::from_fn(|r, k| self.rot[r][k].get(i)),
            a: lane3v(&self.a, i),
            b: lane3v(&self.b, i),
            q: lane3(&self.q, i),
            e: lane3v(&self.e, i),
            ell: lane3(&self.ell, i),
        }
    }
}

impl Pose<f64> {
    /// A posture computed elsewhere (the dynamic path's jets).
    pub fn from_posture(geom: &Geometry, pose: &Posture) -> Self {
        // L·(e_j·d_j) is the square root that `limb` tests in the batched path.
        let across = geom.kind == MechanismKind::Prs3
            && (0..3).any(|j| geom.leg_length * pose.e[j].dot(&geom.rail(j)) < 1e-6 * geom.leg_length);
        let v = V3::splat;
        Self {
            z: pose.z,
            psi: pose.psi,
            theta: pose.theta,
            sc_psi: pose.psi.sin_cos(),
            sc_theta: pose.theta.sin_cos(),
            x: pose.x,
            y: pose.y,
            phi: pose.phi,
            p: v(&pose.p),
            rot: std::array::from_fn(|r| std::array::from_fn(|k| pose.rot[(r, k)])),
            a: pose.a.each_ref().map(v),
            b: pose.b.each_ref().map(v),
            e: pose.e.each_ref().map(v),
            q: pose.q,
            ell: pose.ell,
            reachable: true,
            across,
        }
    }
}

/// The loads on the bodies other than the joint reactions: per leg `c_j` (weight and
/// inertia force) and `h_j` (rate of angular momentum about its centre of mass); on
/// the platform the force to balance and the couple about its centre of mass `C`.
#[derive(Clone, Copy)]
pub struct Loads<L: Lane> {
    c: [V3<L>; 3],
    h: [V3<L>; 3],
    force: V3<L>,
    moment_c: V3<L>,
    /// `C − P`.
    com: V3<L>,
    /// Where `h_j` is taken, as the distance along the leg from `B_j` that `c_j`
    /// acts at: `L/2` (3-PRS: `h_j` about the leg's centre), 0 (3-RPS: `h_j` about `B_j`).
    arm: f64,
}

#[inline(always)]
fn rotate<L: Lane>(rot: &[[L; 3]; 3], v: &Vector3<f64>) -> V3<L> {
    let row = |r: &[L; 3]| r[0].scale(v.x) + r[1].scale(v.y) + r[2].scale(v.z);
    V3::new(row(&rot[0]), row(&rot[1]), row(&rot[2]))
}

impl<L: Lane> Loads<L> {
    /// Kinetostatics: gravity and the external load only.
    #[inline(always)]
    pub fn statics(model: &Model, pose: &Pose<L>) -> Self {
        let mass = &model.mass;
        let com = rotate(&pose.rot, &mass.com_local);
        let force = V3::splat(&(mass.platform_mass * -model.gravity - model.load.force));
        let e_point = rotate(&pose.rot, &model.load.at_local);
        let moment_c = -(e_point - com).cross(V3::splat(&model.load.force)) - V3::splat(&model.load.moment);
        match model.geometry.kind {
            MechanismKind::Prs3 => {
                let leg = V3::splat(&(mass.leg_mass * -model.gravity));
                let arm = 0.5 * model.geometry.leg_length;
                Self { c: [leg; 3], h: [V3::zero(); 3], force, moment_c, com, arm }
            }
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                // The weights' moment about B_j: (ℓ_c/2)·e×(−m_c·g) + (q − ℓ_p/2)·e×(−m_p·g).
                let (cyl, pis) = (&mass.cylinder, &mass.piston);
                let weight = V3::splat(&((cyl.mass + pis.mass) * -model.gravity));
                let down = V3::splat(&-model.gravity);
                let h = each3(|j| {
                    let lever =
                        c::<L>(0.5 * cyl.length * cyl.mass) + (pose.q[j] - c::<L>(0.5 * pis.length)).scale(pis.mass);
                    pose.e[j].cross(down).times(lever)
                });
                Self { c: [weight; 3], h, force, moment_c, com, arm: 0.0 }
            }
        }
    }
}

impl Loads<f64> {
    /// Dynamics: the inertial loads of the motion as well.
    pub fn dynamics(model: &Model, pose: &Posture, inertial: &Inertial) -> Self {
        let mass = &model.mass;
        let v = |w: Vector3<f64>| V3::splat(&w);
        let mut c = [V3::zero(); 3];
        let mut h = [V3::zero(); 3];
        let mut arm = 0.0;
        for j in 0..3 {
            match model.geometry.kind {
                MechanismKind::Prs3 => {
                    arm = 0.5 * model.geometry.leg_length;
                    c[j] = v(mass.leg_mass * (inertial.leg_com_acc[j] - model.gravity));
                    if inertial.moving {
                        let inertia: Matrix3<f64> = leg_inertia_world(mass, &pose.e[j]);
                        let w = inertial.leg_omega[j];
                        h[j] = v(inertia * inertial.leg_omega_dot[j] + w.cross(&(inertia * w)));
                    }
                }
                MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                    let (cj, hj) = mass.rps_limb(pose, inertial, &model.gravity, j);
                    (c[j], h[j]) = (v(cj), v(hj));
                }
            }
        }
        let com = pose.rot * mass.com_local;
        let force = mass.platform_mass * (inertial.com_acc - model.gravity) - model.load.force;
        let e_point = pose.rot * model.load.at_local;
        let mut moment_c = -(e_point - com).cross(&model.load.force) - model.load.moment;
        if inertial.moving {
            let inertia = pose.rot * mass.inertia_local * pose.rot.transpose();
            let w = inertial.omega;
            moment_c += inertia * inertial.omega_dot + w.cross(&(inertia * w));
        }
        Self { c, h, force: v(force), moment_c: v(moment_c), com: v(com), arm }
    }
}

/// Joint reactions of one pose or a batch (see [`JointReactions`]).
#[derive(Clone, Copy)]
pub struct Reactions<L: Lane> {
    pub f_r: [V3<L>; 3],
    pub m_r: [V3<L>; 3],
    pub f_s: [V3<L>; 3],
}

impl<L: Lane> Reactions<L> {
    #[inline(always)]
    pub fn get(&self, i: usize) -> JointReactions {
        JointReactions { f_r: lane3v(&self.f_r, i), m_r: lane3v(&self.m_r, i), f_s: lane3v(&self.f_s, i) }
    }
}

impl Reactions<f64> {
    pub fn from_joint(r: &JointReactions) -> Self {
        let v = V3::splat;
        Self { f_r: r.f_r.each_ref().map(v), m_r: r.m_r.each_ref().map(v), f_s: r.f_s.each_ref().map(v) }
    }
}

impl Reduced<f64> {
    /// [`Reduced::new`] without the envelope's inverse, and whether both condition
    /// numbers are within `limit`, as `new` with conditioning computes them (NaN or
    /// infinite is not): the verdict alone, for the searches that need only it.
    ///
    /// Where a bound puts both at most half the limit, the inverse is not formed (its
    /// condition numbers are left NaN). With singular values `σ₁ ≥ … ≥ σ₆` of `G`,
    /// `‖G⁻¹‖₂ = σ₂⋯σ₆ / |det G| ≤ (‖G‖_F² / 5)^(5/2) / |det G|` (the geometric mean of
    /// `σ₁², …, σ₅²` is at most their mean), and the 1- and ∞-norms are within `√6` of
    /// the 2-norm, so both condition numbers are at most
    /// `6·‖G‖_F⁶ / (5^(5/2)·|det G|)`, `det G = ±∏ U_ii`. The factors give the computed
    /// norms to a relative round-off far inside the factor 2 (at most about 1e-7 where
    /// `κ ≈ 5e7`). Elsewhere the condition numbers are computed as `new` computes them.
    pub fn new_within(model: &Model, pose: &Pose<f64>, limit: f64) -> (Self, bool) {
        let (n, g) = Self::platform(model, pose);
        let frobenius2: f64 = g.iter().flatten().map(|v| v * v).sum();
        let lu = Lu6::new(g);
        let inv_det = lu.inv.iter().fold(1.0f64, |p, v| p * v).abs();
        let bound = 6.0 * frobenius2 * frobenius2 * frobenius2 * inv_det / FIVE_TO_FIVE_HALVES;
        if lu.regular && bound <= 0.5 * limit {
            return (Self { n, g: lu, ginv: None, cond_g: f64::NAN, cond_m: f64::NAN }, true);
        }
        let (cond_g, cond_m, _) = condition_numbers(&g, &lu);
        (Self { n, g: lu, ginv: None, cond_g, cond_m }, cond_g <= limit && cond_m <= limit)
    }
}

/// `κ₁(G)` and `κ₁(M)` (`‖G‖₁·‖G⁻¹‖₁` and `‖G‖∞·‖G⁻¹‖∞`, see [`Reduced`]) from `G` and
/// its LU, infinite where the LU is not regular or the product not finite; and
/// `(L·U)⁻¹`, which gives them.
#[inline(always)]
fn condition_numbers<L: Lane>(g: &A6<L>, lu: &Lu6<L>) -> (L, L, A6<L>) {
    let (norm_one, norm_inf) = norms(g);
    let (inv_one, inv_inf, inv) = lu.inverse_norms();
    let finite = |k: L| L::select(lu.regular & k.finite(), k, c(f64::INFINITY));
    (finite(norm_one * inv_one), finite(norm_inf * inv_inf), inv)
}

/// `5^(5/2)`.
const FIVE_TO_FIVE_HALVES: f64 = 55.901_699_437_494_74;

/// The reduced equilibrium of a posture, factored once, and its conditioning.
///
/// `M = Gᵀ·S` with `S` the swap of the two three-row halves (row k of `M` is column
/// k of `G` with its halves swapped), so one LU of `G` serves both systems and
/// `κ₁(M) = ‖G‖∞·‖G⁻¹‖∞`: the explicit inverse gives both condition numbers.
pub struct Reduced<L: Lane> {
    /// `n_j = y_j × e_j`.
    n: [V3<L>; 3],
    g: Lu6<L>,
    /// `G⁻¹` (with `model.envelope` and the conditioning): row `2j + k` of it, read
    /// as `[Δp; Δα]`, is the pose error per unit of `f·v_j` (`f = e_j`, `y_j`; `v_j` the
    /// velocity at `A_j` of limb j's clearance twist), which the envelope maximises.
    ginv: Option<A6<L>>,
    /// `κ₁(G)` and `κ₁(M)`; infinite when singular, NaN when not asked for.
    pub cond_g: L,
    pub cond_m: L,
}

impl<L: Lane> Reduced<L> {
    /// Builds and factors `G` for the posture (`M` comes with it) and, with
    /// `conditioning`, both condition numbers.
    #[inline(always)]
    pub fn new(model: &Model, pose: &Pose<L>, conditioning: bool) -> Self {
        let (n, g) = Self::platform(model, pose);
        let (mut cond_g, mut cond_m) = (c::<L>(f64::NAN), c::<L>(f64::NAN));
        let mut ginv = None;
        let lu = if conditioning {
            let lu = Lu6::new(g);
            let inv;
            (cond_g, cond_m, inv) = condition_numbers(&g, &lu);
            if model.envelope {
                ginv = Some(lu.inverse_of(&inv));
            }
            lu
        } else {
            Lu6::new(g)
        };
        Self { n, g: lu, ginv, cond_g, cond_m }
    }

    /// `n_j` and `G`.
    #[inline(always)]
    fn platform(model: &Model, pose: &Pose<L>) -> ([V3<L>; 3], A6<L>) {
        let y = each3(|j| V3::<L>::splat(&model.geometry.y[j]));
        let n = each3(|j| y[j].cross(pose.e[j]));
        let mut g = [[c::<L>(0.0); 6]; 6];
        for j in 0..3 {
            let r = pose.a[j] - pose.p;
            for (k, f) in [pose.e[j], y[j]].into_iter().enumerate() {
                let col = six(f, r.cross(f));
                for i in 0..6 {
                    g[i][2 * j + k] = col[i];
                }
            }
        }
        (n, g)
    }

    /// Whether `G` could be factored.
    pub fn regular(&self) -> L::M {
        self.g.regular
    }

    /// Joint reactions from the reduced equilibrium (meaningless where not regular).
    #[inline(always)]
    pub fn reactions(&self, model: &Model, pose: &Pose<L>, loads: &Loads<L>) -> Reactions<L> {
        let geom = &model.geometry;
        let y = each3(|j| V3::<L>::splat(&geom.y[j]));
        let (cl, h, arm) = (&loads.c, &loads.h, loads.arm);
        let mut gamma = [c::<L>(0.0); 3];
        for j in 0..3 {
            gamma[j] = -(h[j] + pose.e[j].cross(cl[j]).scale(arm)).dot(y[j]) / pose.ell[j];
        }
        // About P: Σ r_j×f_Sj = M_C + (C − P)×Σ f_Sj.
        let mut f = loads.force;
        let mut mo = loads.moment_c + loads.com.cross(loads.force);
        for j in 0..3 {
            let known = self.n[j].times(gamma[j]);
            f = f - known;
            mo = mo - (pose.a[j] - pose.p).cross(known);
        }
        let b = six(f, mo);
        let u = self.g.solve_rows(&each6(|i| [b[i]]));
        let (mut f_r, mut m_r, mut f_s) = ([V3::zero(); 3], [V3::zero(); 3], [V3::zero(); 3]);
        for j in 0..3 {
            let fs = pose.e[j].times(u[2 * j][0]) + y[j].times(u[2 * j + 1][0]) + self.n[j].times(gamma[j]);
            let mr = h[j] + pose.e[j].cross(fs).times(pose.ell[j]) + pose.e[j].cross(cl[j]).scale(arm);
            f_s[j] = fs;
            f_r[j] = fs + cl[j];
            // The couple has no component about y_j: keep the exact form μ1·x_j + μ2·z.
            let x = V3::splat(&geom.x[j]);
            m_r[j] = x.times(mr.dot(x)) + V3::splat(&Vector3::z()).times(mr.z);
        }
        Reactions { f_r, m_r, f_s }
    }

    /// Per-kind pose errors `[Δα; Δp]` (order of `KINDS`) from `M·t = d`, that is
    /// `Gᵀ·(S·t) = d`.
    #[inline(always)]
    ///
    /// Also returns each joint's own contribution to `|Δp|`, by kind and limb, when
    /// `model.envelope` is on (else zeros).
    pub fn errors(&self, model: &Model, pose: &Pose<L>, take: &TakeUps<L>) -> ([[L; 6]; 4], [[L; 3]; 4]) {
        let y = each3(|j| V3::<L>::splat(&model.geometry.y[j]));
        // Row i holds component i of every kind's right-hand side.
        let mut rhs = [[c::<L>(0.0); 4]; 6];
        for j in 0..3 {
            let r = pose.a[j] - pose.p;
            let rb = pose.b[j] - pose.p;
            // Velocity at A_j of each kind's clearance twist of limb j.
            let ang = take.r_angular[j];
            let at_a = [take.s[j], take.r_radial[j], take.r_axial[j], rb.cross(ang) + ang.cross(r)];
            for (k, f) in [pose.e[j], y[j]].into_iter().enumerate() {
                rhs[2 * j + k] = each4(|kind| f.dot(at_a[kind]));
            }
        }
        let s = self.g.solve_transposed(&rhs);
        // Joint (j, kind) alone: rows 2j and 2j + 1 of G⁻¹ (its Δp half) times its loads.
        let mut contribution = [[c::<L>(0.0); 3]; 4];
        for j in (0..3).filter(|_| model.envelope) {
            let ginv = self.ginv.as_ref().expect("G⁻¹ is formed with the envelope");
            let (u, v) = (&ginv[2 * j], &ginv[2 * j + 1]);
            for kind in 0..4 {
                let (a, b) = (rhs[2 * j][kind], rhs[2 * j + 1][kind]);
                let dp = each3(|i| u[i] * a + v[i] * b);
                contribution[kind][j] = (dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]).sqrt();
            }
        }
        // t = S·s: the halves swap back.
        (each4(|k| [s[3][k], s[4][k], s[5][k], s[0][k], s[1][k], s[2][k]]), contribution)
    }

    /// The worst case over every admissible take-up (docs/model.md §11):
    /// per kind (order of `KINDS`), the largest `|Δp_x|, |Δp_y|, |Δp_z|, |Δα_x|, |Δα_y|,
    /// |Δα_z|` and bounds on `|Δp|` and `|Δα|`. The error is linear in each joint's
    /// displacement and the joints are independent, so each maximum is a sum over the
    /// limbs of one joint's maximum over its set: a ball (`s_radial`, both rows of the
    /// limb), a disc `⟂ y_j` (`r_radial`: only the row along `e_j` moves the platform), a
    /// segment along `y_j` (`r_axial`), a disc of rotations `⟂ y_j` about `B_j`
    /// (`r_angular`: `A_j` moves by `ℓ_j` times the rotation, along `n_j`, read by the
    /// `y_j` row).
    #[inline(always)]
    pub fn envelope(&self, model: &Model, pose: &Pose<L>) -> [[L; 8]; 4] {
        let [s, r, a, th] = model.clearance;
        let Some(ginv) = &self.ginv else { return [[c(f64::NAN); 8]; 4] };
        let mut env = [[c::<L>(0.0); 8]; 4];
        for j in 0..3 {
            let (u, v) = (&ginv[2 * j], &ginv[2 * j + 1]);
            let ell = pose.ell[j];
            // G⁻¹'s rows hold Δp first, then Δα.
            for i in 0..6 {
                env[0][i] = env[0][i] + (u[i] * u[i] + v[i] * v[i]).sqrt().scale(s);
                env[1][i] = env[1][i] + u[i].abs().scale(r);
                env[2][i] = env[2][i] + v[i].abs().scale(a);
                env[3][i] = env[3][i] + (v[i].abs() * ell).scale(th);
            }
            for (slot, base) in [(6, 0), (7, 3)] {
                let dot =
                    |x: &[L; 6], y: &[L; 6]| x[base] * y[base] + x[base + 1] * y[base + 1] + x[base + 2] * y[base + 2];
                let (uu, vv, uv) = (dot(u, u), dot(v, v), dot(u, v));
                // The larger singular value of the 3 × 2 block [u v].
                let half = (uu - vv).scale(0.5);
                let sigma = ((uu + vv).scale(0.5) + (half * half + uv * uv).sqrt()).sqrt();
                env[0][slot] = env[0][slot] + sigma.scale(s);
                env[1][slot] = env[1][slot] + uu.sqrt().scale(r);
                env[2][slot] = env[2][slot] + vv.sqrt().scale(a);
                env[3][slot] = env[3][slot] + (vv.sqrt() * ell).scale(th);
            }
        }
        env
    }
}

/// A pose error of one pose or a batch (see [`PoseError`]).
#[derive(Clone, Copy)]
pub struct Errors<L: Lane> {
    pub dalpha: V3<L>,
    pub dp: V3<L>,
    /// `(ΔΦ, ΔΨ, ΔΘ)`.
    pub euler: [L; 3],
}

impl<L: Lane> Errors<L> {
    #[inline(always)]
    pub fn get(&self, i: usize) -> PoseError {
        PoseError { dalpha: self.dalpha.get(i), dp: self.dp.get(i), euler: lane3(&self.euler, i) }
    }
}

/// The inverse of `Δα = E·(ΔΘ, ΔΨ, ΔΦ)` (`euler_rates_matrix`), by cofactors; NaN
/// where the Euler rates are singular (cos Ψ = 0), which the writer turns into nulls.
#[inline(always)]
pub fn euler_inverse<L: Lane>(pose: &Pose<L>) -> [[L; 3]; 3] {
    let ((sp, cp), (st, ct)) = (pose.sc_psi, pose.sc_theta);
    let (zero, one) = (c::<L>(0.0), c::<L>(1.0));
    let m = [[zero, ct, cp * st], [one, zero, -sp], [zero, -st, cp * ct]];
    let minor = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r1][c0] * m[r0][c1];
    let cof = [
        [minor(1, 2, 1, 2), -minor(1, 2, 0, 2), minor(1, 2, 0, 1)],
        [-minor(0, 2, 1, 2), minor(0, 2, 0, 2), -minor(0, 2, 0, 1)],
        [minor(0, 1, 1, 2), -minor(0, 1, 0, 2), minor(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    let singular = det.eq(zero);
    // inverse = adjugate / det, the adjugate being the transposed cofactors.
    let mut inv = [[zero; 3]; 3];
    for r in 0..3 {
        for k in 0..3 {
            inv[r][k] = L::select(singular, c(f64::NAN), cof[k][r] / det);
        }
    }
    inv
}

/// `[Δα; Δp]` → [`Errors`] with Euler angles.
#[inline(always)]
pub fn pose_error<L: Lane>(t: [L; 6], euler_inv: &[[L; 3]; 3]) -> Errors<L> {
    let dalpha = V3::new(t[0], t[1], t[2]);
    let mut e = [c::<L>(0.0); 3];
    for r in 0..3 {
        e[r] = V3::from_array(euler_inv[r]).dot(dalpha);
    }
    Errors { dalpha, dp: V3::new(t[3], t[4], t[5]), euler: [e[2], e[1], e[0]] }
}

#[cfg(test)]
mod tests {
    use super::{Pose, Reduced};
    use crate::bodies::Model;
    use clearance_kinematics::Geometry;
    use clearance_model::JobSpec;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `new_within` gives the verdict of `new`'s condition numbers against the limit,
    /// on postures from level to tilted far enough to be near-singular or out of reach,
    /// with limits from 10 to the default 1e8; where its bound decides, both condition
    /// numbers are indeed within half the limit. The bound decides most postures at the
    /// default limit, and the exact numbers the rest.
    #[test]
    fn the_bound_gives_the_verdict_of_the_condition_numbers() {
        let job = JobSpec::from_toml_str("[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n", "job.toml").unwrap();
        let mut model = Model::from_job(&job);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut bounded, mut computed, mut refused) = ([0usize; 8], 0, 0);
        for case in 0..4_000 {
            if case % 1_000 == 0 {
                // A short leg, so that tilted postures come near singular ones.
                let g = &model.geometry;
                let leg = if case == 0 { g.leg_length } else { rng.random_range(0.2..0.5) };
                model.geometry = Geometry::new(g.base_radius, g.platform_radius, leg);
            }
            let (z, psi, theta) =
                (rng.random_range(0.1..2.6), rng.random_range(-1.4..1.4), rng.random_range(-1.4..1.4));
            let pose = Pose::new(&model.geometry, z, psi, theta);
            let full = Reduced::new(&model, &pose, true);
            for k in 1..=8 {
                let limit = 10f64.powi(k);
                let (reduced, within) = Reduced::new_within(&model, &pose, limit);
                let expected = full.cond_g <= limit && full.cond_m <= limit;
                assert_eq!(within, expected, "limit {limit}: κ {} and {}", full.cond_g, full.cond_m);
                if reduced.cond_g.is_nan() {
                    assert!(
                        full.cond_g <= 0.5 * limit && full.cond_m <= 0.5 * limit,
                        "{}, {}",
                        full.cond_g,
                        full.cond_m
                    );
                    bounded[k as usize - 1] += 1;
                } else {
                    assert_eq!((reduced.cond_g, reduced.cond_m), (full.cond_g, full.cond_m));
                    computed += 1;
                    refused += usize::from(!within);
                }
            }
        }
        assert!(bounded[7] > 3_000, "the bound decided {} of 4 000 postures at 1e8", bounded[7]);
        assert!(computed > 4_000 && refused > 100, "{computed} computed, {refused} beyond the limit");
    }
}
