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
//! six equations `M·ΔΓ = d`, one right-hand side per clearance kind. Both are exactly
//! the 24 × 24 and 12 × 12 systems after elimination; the two paths agree to round-off
//! (tested on random poses).

use clearance_kinematics::Posture;
use nalgebra::{Matrix3, SMatrix, Vector3, Vector6};

use crate::bodies::{Inertial, Model, leg_inertia_world};
use crate::equilibrium::JointReactions;
use crate::error_system::PoseError;
use crate::takeup::TakeUp;

type M6 = SMatrix<f64, 6, 6>;

/// A 6 × 6 LU with partial pivoting, in place, and its exact 1-norm condition number.
struct Lu6 {
    lu: M6,
    perm: [usize; 6],
}

impl Lu6 {
    /// `None` when a pivot is zero or not finite.
    fn new(mut a: M6) -> Option<Self> {
        let mut perm = [0, 1, 2, 3, 4, 5];
        for k in 0..6 {
            let mut p = k;
            for i in k + 1..6 {
                if a[(i, k)].abs() > a[(p, k)].abs() {
                    p = i;
                }
            }
            if a[(p, k)] == 0.0 || !a[(p, k)].is_finite() {
                return None;
            }
            if p != k {
                a.swap_rows(p, k);
                perm.swap(p, k);
            }
            let inv = 1.0 / a[(k, k)];
            for i in k + 1..6 {
                let l = a[(i, k)] * inv;
                a[(i, k)] = l;
                for j in k + 1..6 {
                    a[(i, j)] -= l * a[(k, j)];
                }
            }
        }
        Some(Self { lu: a, perm })
    }

    fn solve(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let mut x = Vector6::from_fn(|i, _| b[self.perm[i]]);
        for i in 1..6 {
            for j in 0..i {
                x[i] -= self.lu[(i, j)] * x[j];
            }
        }
        for i in (0..6).rev() {
            for j in i + 1..6 {
                x[i] -= self.lu[(i, j)] * x[j];
            }
            x[i] /= self.lu[(i, i)];
        }
        x
    }

    /// `‖A‖₁·‖A⁻¹‖₁`, with `‖A‖₁` of the matrix that was factored.
    fn cond1(&self, norm_a: f64) -> f64 {
        let mut inv_norm = 0.0f64;
        for k in 0..6 {
            let col = self.solve(&Vector6::from_fn(|i, _| if i == k { 1.0 } else { 0.0 }));
            inv_norm = inv_norm.max(col.abs().sum());
        }
        norm_a * inv_norm
    }
}

fn norm1(a: &M6) -> f64 {
    (0..6).map(|j| a.column(j).abs().sum()).fold(0.0, f64::max)
}

fn six(a: Vector3<f64>, b: Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// The two reduced matrices of a posture and their conditioning.
pub struct Reduced {
    /// `n_j = y_j × e_j`.
    n: [Vector3<f64>; 3],
    g: Option<Lu6>,
    m: Option<Lu6>,
    /// `κ₁(G)` and `κ₁(M)`; infinite when singular.
    pub cond_g: f64,
    pub cond_m: f64,
}

/// Builds and factors `G` (equilibrium) and `M` (error) for the posture.
pub fn reduce(model: &Model, pose: &Posture) -> Reduced {
    let y = &model.geometry.y;
    let n = [0, 1, 2].map(|j| y[j].cross(&pose.e[j]));
    let mut g = M6::zeros();
    let mut m = M6::zeros();
    for j in 0..3 {
        let r = pose.a[j] - pose.p;
        for (c, f) in [pose.e[j], y[j]].into_iter().enumerate() {
            let k = 2 * j + c;
            let moment = r.cross(&f);
            g.set_column(k, &six(f, moment));
            // Row k of M: [(r×f)ᵀ, fᵀ] acting on [Δα; Δp].
            m.set_row(k, &six(moment, f).transpose());
        }
    }
    let (ng, nm) = (norm1(&g), norm1(&m));
    let g = Lu6::new(g);
    let m = Lu6::new(m);
    let cond = |lu: &Option<Lu6>, norm: f64| {
        let c = lu.as_ref().map_or(f64::INFINITY, |lu| lu.cond1(norm));
        if c.is_finite() { c } else { f64::INFINITY }
    };
    Reduced { n, cond_g: cond(&g, ng), cond_m: cond(&m, nm), g, m }
}

impl Reduced {
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
            let inertia: Matrix3<f64> = leg_inertia_world(mass, &pose.e[j]);
            let w = inertial.leg_omega[j];
            h[j] = inertia * inertial.leg_omega_dot[j] + w.cross(&(inertia * w));
            gamma[j] = -(h[j] + 0.5 * l * pose.e[j].cross(&c[j])).dot(&geom.y[j]) / l;
        }
        let m = mass.platform_mass;
        let com = pose.rot * mass.com_local;
        let force = m * (inertial.com_acc - model.gravity) - model.load.force;
        let inertia = pose.rot * mass.inertia_local * pose.rot.transpose();
        let w = inertial.omega;
        let e_point = pose.rot * model.load.at_local;
        let moment_c = inertia * inertial.omega_dot + w.cross(&(inertia * w))
            - (e_point - com).cross(&model.load.force)
            - model.load.moment;
        // About P: Σ r_j×f_Sj = M_C + (C − P)×Σ f_Sj.
        let mut f = force;
        let mut mo = moment_c + com.cross(&force);
        for j in 0..3 {
            let known = gamma[j] * self.n[j];
            f -= known;
            mo -= (pose.a[j] - pose.p).cross(&known);
        }
        let u = self.g.as_ref().expect("solve only regular postures").solve(&six(f, mo));
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

    /// Per-kind pose errors (order of `KINDS`) from the reduced error system.
    pub fn errors(&self, model: &Model, pose: &Posture, take: &TakeUp) -> [[f64; 6]; 4] {
        let y = &model.geometry.y;
        let lu = self.m.as_ref().expect("solve only regular postures");
        let mut rhs = [Vector6::zeros(); 4];
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
                for k in 0..4 {
                    rhs[k][2 * j + c] = f.dot(&at_a[k]);
                }
            }
        }
        rhs.map(|b| {
            let t = lu.solve(&b);
            [t[0], t[1], t[2], t[3], t[4], t[5]]
        })
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
