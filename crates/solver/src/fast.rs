//! The fast path: the same physics as [`equilibrium`](crate::equilibrium) and
//! [`error_system`](crate::error_system), on two 6 × 6 systems instead of
//! 24 × 24 and 12 × 12.
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

use clearance_kinematics::Posture;
use nalgebra::{Matrix3, Vector3};

use crate::bodies::{Inertial, Model, leg_inertia_world};
use crate::equilibrium::JointReactions;
use crate::error_system::PoseError;
use crate::takeup::TakeUp;

/// A 6 × 6 matrix, row-major.
type A6 = [[f64; 6]; 6];

/// A 6 × 6 LU with partial pivoting (`P·A = L·U`), in place on plain arrays so
/// that every loop has fixed bounds and unrolls.
struct Lu6 {
    lu: A6,
    /// Row `i` of `P·A` is row `perm[i]` of `A`.
    perm: [usize; 6],
}

impl Lu6 {
    /// `None` when a pivot is zero or not finite.
    fn new(mut a: A6) -> Option<Self> {
        let mut perm = [0, 1, 2, 3, 4, 5];
        for k in 0..6 {
            let mut p = k;
            for i in k + 1..6 {
                if a[i][k].abs() > a[p][k].abs() {
                    p = i;
                }
            }
            if a[p][k] == 0.0 || !a[p][k].is_finite() {
                return None;
            }
            if p != k {
                a.swap(p, k);
                perm.swap(p, k);
            }
            let inv = 1.0 / a[k][k];
            let pivot_row = a[k];
            for row in a.iter_mut().skip(k + 1) {
                let l = row[k] * inv;
                row[k] = l;
                for j in k + 1..6 {
                    row[j] -= l * pivot_row[j];
                }
            }
        }
        Some(Self { lu: a, perm })
    }

    /// `A·X = B` for `K` right-hand sides at once (row `i` of `B` holds component `i`
    /// of every right-hand side): `x = P·b`, then `L` forward and `U` backward, a whole
    /// row at a time so the compiler vectorises across right-hand sides.
    fn solve_rows<const K: usize>(&self, b: &[[f64; K]; 6]) -> [[f64; K]; 6] {
        let lu = &self.lu;
        let mut x = self.perm.map(|p| b[p]);
        for i in 1..6 {
            for j in 0..i {
                let (row, l) = (x[j], lu[i][j]);
                for (xi, r) in x[i].iter_mut().zip(row) {
                    *xi -= l * r;
                }
            }
        }
        for i in (0..6).rev() {
            for j in i + 1..6 {
                let (row, u) = (x[j], lu[i][j]);
                for (xi, r) in x[i].iter_mut().zip(row) {
                    *xi -= u * r;
                }
            }
            let pivot = lu[i][i];
            for xi in &mut x[i] {
                *xi /= pivot;
            }
        }
        x
    }

    /// `A·x = b`.
    fn solve(&self, b: &[f64; 6]) -> [f64; 6] {
        self.solve_rows(&b.map(|v| [v])).map(|[v]| v)
    }

    /// `Aᵀ·x = d` for `K` right-hand sides at once (row `i` of `d` holds component
    /// `i` of every right-hand side): `Uᵀ·z = d`, `Lᵀ·w = z`, `x = Pᵀ·w`. Rows are
    /// updated whole, so the compiler vectorises across right-hand sides.
    fn solve_transposed<const K: usize>(&self, d: &[[f64; K]; 6]) -> [[f64; K]; 6] {
        let lu = &self.lu;
        let mut w = *d;
        for i in 0..6 {
            for k in 0..i {
                let (l, u) = (w[k], lu[k][i]);
                for (wi, lk) in w[i].iter_mut().zip(l) {
                    *wi -= u * lk;
                }
            }
            let pivot = lu[i][i];
            for wi in &mut w[i] {
                *wi /= pivot;
            }
        }
        for i in (0..5).rev() {
            for k in i + 1..6 {
                let (l, f) = (w[k], lu[k][i]);
                for (wi, lk) in w[i].iter_mut().zip(l) {
                    *wi -= f * lk;
                }
            }
        }
        let mut x = [[0.0; K]; 6];
        for i in 0..6 {
            x[self.perm[i]] = w[i];
        }
        x
    }

    /// `‖A⁻¹‖₁` and `‖A⁻¹‖∞`, from the explicit inverse.
    fn inverse_norms(&self) -> (f64, f64) {
        let mut identity = [[0.0; 6]; 6];
        for (i, row) in identity.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        let x = self.solve_rows(&identity);
        let mut col_sums = [0.0f64; 6];
        let mut row_max = 0.0f64;
        for row in &x {
            let mut sum = 0.0;
            for (c, v) in col_sums.iter_mut().zip(row) {
                *c += v.abs();
                sum += v.abs();
            }
            row_max = row_max.max(sum);
        }
        (col_sums.iter().fold(0.0f64, |m, &s| m.max(s)), row_max)
    }
}

fn norms(a: &A6) -> (f64, f64) {
    let mut one = 0.0f64;
    let mut inf = 0.0f64;
    for k in 0..6 {
        let (mut col, mut row) = (0.0, 0.0);
        for i in 0..6 {
            col += a[i][k].abs();
            row += a[k][i].abs();
        }
        one = one.max(col);
        inf = inf.max(row);
    }
    (one, inf)
}

fn six(a: Vector3<f64>, b: Vector3<f64>) -> [f64; 6] {
    [a.x, a.y, a.z, b.x, b.y, b.z]
}

/// The reduced equilibrium of a posture, factored once, and its conditioning.
///
/// `M = Gᵀ·S` with `S` the swap of the two three-row halves (row k of `M` is column
/// k of `G` with its halves swapped), so one LU of `G` serves both systems and
/// `κ₁(M) = ‖G‖∞·‖G⁻¹‖∞`: the explicit inverse gives both condition numbers.
pub struct Reduced {
    /// `n_j = y_j × e_j`.
    n: [Vector3<f64>; 3],
    g: Option<Lu6>,
    /// `κ₁(G)` and `κ₁(M)`; infinite when singular.
    pub cond_g: f64,
    pub cond_m: f64,
}

/// `n_j` and `G` of the posture.
fn build(model: &Model, pose: &Posture) -> ([Vector3<f64>; 3], A6) {
    let y = &model.geometry.y;
    let n = [0, 1, 2].map(|j| y[j].cross(&pose.e[j]));
    let mut g = [[0.0; 6]; 6];
    for j in 0..3 {
        let r = pose.a[j] - pose.p;
        for (c, f) in [pose.e[j], y[j]].into_iter().enumerate() {
            let col = six(f, r.cross(&f));
            for i in 0..6 {
                g[i][2 * j + c] = col[i];
            }
        }
    }
    (n, g)
}

/// Builds and factors `G` for the posture, without its conditioning (NaN): enough
/// for the reactions of a posture already known to be regular.
pub fn factor(model: &Model, pose: &Posture) -> Reduced {
    let (n, g) = build(model, pose);
    Reduced { n, g: Lu6::new(g), cond_g: f64::NAN, cond_m: f64::NAN }
}

/// Builds and factors `G` for the posture (`M` comes with it) and both
/// condition numbers.
pub fn reduce(model: &Model, pose: &Posture) -> Reduced {
    let (n, g) = build(model, pose);
    let (norm_one, norm_inf) = norms(&g);
    let g = Lu6::new(g);
    let finite = |c: f64| if c.is_finite() { c } else { f64::INFINITY };
    let (cond_g, cond_m) = match &g {
        Some(lu) => {
            let (inv_one, inv_inf) = lu.inverse_norms();
            (finite(norm_one * inv_one), finite(norm_inf * inv_inf))
        }
        None => (f64::INFINITY, f64::INFINITY),
    };
    Reduced { n, g, cond_g, cond_m }
}

impl Reduced {
    /// Whether `G` could be factored.
    pub fn regular(&self) -> bool {
        self.g.is_some()
    }

    fn lu(&self) -> &Lu6 {
        self.g.as_ref().expect("solve only regular postures")
    }

    /// Joint reactions from the reduced equilibrium.
    pub fn reactions(&self, model: &Model, pose: &Posture, inertial: &Inertial) -> JointReactions {
        let geom = &model.geometry;
        let mass = &model.mass;
        let l = geom.leg_length;
        let mut c = [Vector3::zeros(); 3];
        let mut h = [Vector3::zeros(); 3];
        let mut gamma = [0.0; 3];
        for j in 0..3 {
            c[j] = mass.leg_mass * (inertial.leg_com_acc[j] - model.gravity);
            if inertial.moving {
                let inertia: Matrix3<f64> = leg_inertia_world(mass, &pose.e[j]);
                let w = inertial.leg_omega[j];
                h[j] = inertia * inertial.leg_omega_dot[j] + w.cross(&(inertia * w));
            }
            gamma[j] = -(h[j] + 0.5 * l * pose.e[j].cross(&c[j])).dot(&geom.y[j]) / l;
        }
        let m = mass.platform_mass;
        let com = pose.rot * mass.com_local;
        let force = m * (inertial.com_acc - model.gravity) - model.load.force;
        let e_point = pose.rot * model.load.at_local;
        let mut moment_c = -(e_point - com).cross(&model.load.force) - model.load.moment;
        if inertial.moving {
            let inertia = pose.rot * mass.inertia_local * pose.rot.transpose();
            let w = inertial.omega;
            moment_c += inertia * inertial.omega_dot + w.cross(&(inertia * w));
        }
        // About P: Σ r_j×f_Sj = M_C + (C − P)×Σ f_Sj.
        let mut f = force;
        let mut mo = moment_c + com.cross(&force);
        for j in 0..3 {
            let known = gamma[j] * self.n[j];
            f -= known;
            mo -= (pose.a[j] - pose.p).cross(&known);
        }
        let u = self.lu().solve(&six(f, mo));
        let mut out = JointReactions::default();
        for j in 0..3 {
            let fs = u[2 * j] * pose.e[j] + u[2 * j + 1] * geom.y[j] + gamma[j] * self.n[j];
            let mr = h[j] + l * pose.e[j].cross(&fs) + 0.5 * l * pose.e[j].cross(&c[j]);
            out.f_s[j] = fs;
            out.f_r[j] = fs + c[j];
            // The couple has no component about y_j: keep the exact form μ1·x_j + μ2·z.
            out.m_r[j] = mr.dot(&geom.x[j]) * geom.x[j] + mr.z * Vector3::z();
        }
        out
    }

    /// Per-kind pose errors `[Δα; Δp]` (order of `KINDS`) from `M·t = d`, that is
    /// `Gᵀ·(S·t) = d`.
    pub fn errors(&self, model: &Model, pose: &Posture, take: &TakeUp) -> [[f64; 6]; 4] {
        let y = &model.geometry.y;
        let lu = self.lu();
        // Row i holds component i of every kind's right-hand side.
        let mut rhs = [[0.0; 4]; 6];
        for j in 0..3 {
            let r = pose.a[j] - pose.p;
            let rb = pose.b[j] - pose.p;
            // Velocity at A_j of each kind's clearance twist of limb j.
            let at_a = [
                take.s[j],
                take.r_radial[j],
                take.r_axial[j],
                rb.cross(&take.r_angular[j]) + take.r_angular[j].cross(&r),
            ];
            for (c, f) in [pose.e[j], y[j]].into_iter().enumerate() {
                rhs[2 * j + c] = at_a.map(|v| f.dot(&v));
            }
        }
        let s = lu.solve_transposed(&rhs);
        // t = S·s: the halves swap back.
        [0, 1, 2, 3].map(|k| [s[3][k], s[4][k], s[5][k], s[0][k], s[1][k], s[2][k]])
    }
}

/// Maps `Δα` to `(ΔΘ, ΔΨ, ΔΦ)`; NaN where the Euler rates are singular (cos Ψ = 0),
/// which the writer turns into nulls.
pub fn euler_inverse(pose: &Posture) -> Matrix3<f64> {
    clearance_kinematics::euler_rates_matrix(pose.psi, pose.theta)
        .try_inverse()
        .unwrap_or_else(|| Matrix3::from_element(f64::NAN))
}

/// `[Δα; Δp]` → a [`PoseError`] with Euler angles.
pub fn pose_error(t: [f64; 6], euler_inv: &Matrix3<f64>) -> PoseError {
    let dalpha = Vector3::new(t[0], t[1], t[2]);
    let e = euler_inv * dalpha;
    PoseError { dalpha, dp: Vector3::new(t[3], t[4], t[5]), euler: [e[2], e[1], e[0]] }
}
