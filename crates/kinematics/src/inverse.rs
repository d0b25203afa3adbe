//! Closed-form inverse kinematics, generic over plain numbers and jets.

use nalgebra::{Matrix3, Vector3};

use crate::jet::{Elementary, Jet, Real};
use clearance_model::{LIMB_ANGLES, MechanismSpec};

/// The robot's geometry with the limb frames precomputed.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    /// `R_b` (m).
    pub base_radius: f64,
    /// `r_p` (m).
    pub platform_radius: f64,
    /// `L` (m).
    pub leg_length: f64,
    /// Radial unit vectors `x_j`.
    pub x: [Vector3<f64>; 3],
    /// Revolute axes `y_j` (normals of the limb planes).
    pub y: [Vector3<f64>; 3],
    /// Platform vertices in platform coordinates, `a'_j = r_p·(cos α_j, sin α_j, 0)`.
    pub a_local: [Vector3<f64>; 3],
}

impl Geometry {
    pub fn new(base_radius: f64, platform_radius: f64, leg_length: f64) -> Self {
        let x = LIMB_ANGLES.map(|a| Vector3::new(a.cos(), a.sin(), 0.0));
        let y = LIMB_ANGLES.map(|a| Vector3::new(-a.sin(), a.cos(), 0.0));
        let a_local = LIMB_ANGLES.map(|a| Vector3::new(platform_radius * a.cos(), platform_radius * a.sin(), 0.0));
        Self { base_radius, platform_radius, leg_length, x, y, a_local }
    }

    /// The paper's prototype: `R_b = 0.18`, `r_p = 0.36`, `L = 1`.
    pub fn prototype() -> Self {
        Self::from_spec(&MechanismSpec::default())
    }

    pub fn from_spec(m: &MechanismSpec) -> Self {
        Self::new(m.base_radius, m.platform_radius, m.leg_length)
    }
}

/// Leg `leg` (0-based) cannot reach its slider line: `L² < (ρ_j − R_b)²`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unreachable {
    pub leg: usize,
}

/// The nominal posture of every body at one sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Posture {
    pub z: f64,
    pub psi: f64,
    pub theta: f64,
    /// Parasitic motions `X, Y, Φ`.
    pub x: f64,
    pub y: f64,
    pub phi: f64,
    /// TCP position `p = (X, Y, Z)`.
    pub p: Vector3<f64>,
    /// Platform orientation `R = R_y(Θ)·R_x(Ψ)·R_z(Φ)`.
    pub rot: Matrix3<f64>,
    /// Spherical joint centres `A_j`.
    pub a: [Vector3<f64>; 3],
    /// Revolute joint centres `B_j`.
    pub b: [Vector3<f64>; 3],
    /// Actuator positions `q_j`.
    pub q: [f64; 3],
    /// Leg directions `e_j = (A_j − B_j)/L`.
    pub e: [Vector3<f64>; 3],
}

/// Exact first and second time derivatives along a trajectory.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Rates of `(X, Y, Φ)` and their second derivatives.
    pub parasitic_dot: [f64; 3],
    pub parasitic_ddot: [f64; 3],
    pub p_dot: Vector3<f64>,
    pub p_ddot: Vector3<f64>,
    /// Platform angular velocity and acceleration (world frame).
    pub omega: Vector3<f64>,
    pub omega_dot: Vector3<f64>,
    pub rot_dot: Matrix3<f64>,
    pub rot_ddot: Matrix3<f64>,
    pub a_ddot: [Vector3<f64>; 3],
    pub q_dot: [f64; 3],
    pub q_ddot: [f64; 3],
    /// Leg angular velocity `ω_j = e_j × ė_j` and acceleration `e_j × ë_j`.
    pub leg_omega: [Vector3<f64>; 3],
    pub leg_omega_dot: [Vector3<f64>; 3],
    /// Acceleration of each leg's centre of mass (its midpoint).
    pub leg_com_acc: [Vector3<f64>; 3],
}

/// The parasitic motions `(X, Y, Φ)` for `(Ψ, Θ)` and platform radius `r_p`.
#[inline(always)]
pub fn parasitic<T: Elementary>(r_p: f64, psi: T, theta: T) -> (T, T, T) {
    let (x, y, phi, _) = parasitic_sc(r_p, psi.sin_cos(), theta.sin_cos());
    (x, y, phi)
}

/// [`parasitic`] from `(sin Ψ, cos Ψ)` and `(sin Θ, cos Θ)`; also returns `(sin Φ, cos Φ)`.
#[inline(always)]
pub fn parasitic_sc<T: Elementary>(r_p: f64, (sps, cps): (T, T), (sth, cth): (T, T)) -> (T, T, T, (T, T)) {
    let phi = (sps * sth).atan2(cps + cth);
    let (sph, cph) = phi.sin_cos();
    let y = -(cps * sph).scale(r_p);
    let x = (cth * cph - cph * cps + sps * sth * sph).scale(0.5 * r_p);
    (x, y, phi, (sph, cph))
}

/// `R = R_y(Θ)·R_x(Ψ)·R_z(Φ)`, row-major.
#[inline(always)]
pub fn rotation<T: Elementary>(phi: T, psi: T, theta: T) -> [[T; 3]; 3] {
    rotation_sc(phi.sin_cos(), psi.sin_cos(), theta.sin_cos())
}

/// [`rotation`] from the sine and cosine of each angle.
#[inline(always)]
pub fn rotation_sc<T: Elementary>((sf, cf): (T, T), (sp, cp): (T, T), (st, ct): (T, T)) -> [[T; 3]; 3] {
    let zero = T::constant(0.0);
    // R_x(Ψ)·R_z(Φ)
    let m = [[cf, -sf, zero], [cp * sf, cp * cf, -sp], [sp * sf, sp * cf, cp]];
    // R_y(Θ)·m, with R_y = [[cΘ,0,sΘ],[0,1,0],[−sΘ,0,cΘ]]
    [
        [ct * m[0][0] + st * m[2][0], ct * m[0][1] + st * m[2][1], ct * m[0][2] + st * m[2][2]],
        m[1],
        [ct * m[2][0] - st * m[0][0], ct * m[2][1] - st * m[0][1], ct * m[2][2] - st * m[0][2]],
    ]
}

/// Columns `[ŷ, R_y(Θ)x̂, R_y(Θ)R_x(Ψ)ẑ]`: `Δα = M·(ΔΘ, ΔΨ, ΔΦ)` (MODEL.md §6).
pub fn euler_rates_matrix(psi: f64, theta: f64) -> Matrix3<f64> {
    let (sp, cp) = psi.sin_cos();
    let (st, ct) = theta.sin_cos();
    Matrix3::new(0.0, ct, cp * st, 1.0, 0.0, -sp, 0.0, -st, cp * ct)
}

struct Generic<T> {
    x: T,
    y: T,
    phi: T,
    rot: [[T; 3]; 3],
    a: [[T; 3]; 3],
    b: [[T; 3]; 3],
    q: [T; 3],
}

#[inline(always)]
fn solve<T: Real>(geom: &Geometry, z: T, psi: T, theta: T) -> Result<Generic<T>, Unreachable> {
    let (sc_psi, sc_theta) = (psi.sin_cos(), theta.sin_cos());
    let (x, y, phi, sc_phi) = parasitic_sc(geom.platform_radius, sc_psi, sc_theta);
    let rot = rotation_sc(sc_phi, sc_psi, sc_theta);
    let p = [x, y, z];
    let zero = T::constant(0.0);
    let mut a = [[zero; 3]; 3];
    let mut b = [[zero; 3]; 3];
    let mut q = [zero; 3];
    for j in 0..3 {
        let disc;
        (a[j], disc) = limb(geom, j, p, &rot);
        if disc.value() < 0.0 || disc.value().is_nan() {
            return Err(Unreachable { leg: j });
        }
        (q[j], b[j]) = slider(geom, j, a[j], disc);
    }
    Ok(Generic { x, y, phi, rot, a, b, q })
}

/// Limb `j` at platform position `p` and orientation `rot`: the spherical joint
/// centre `A_j` and `L² − (ρ_j − R_b)²`, negative when the leg cannot reach.
#[inline(always)]
pub fn limb<T: Elementary>(geom: &Geometry, j: usize, p: [T; 3], rot: &[[T; 3]; 3]) -> ([T; 3], T) {
    let al = geom.a_local[j];
    let at = |k: usize| p[k] + rot[k][0].scale(al.x) + rot[k][1].scale(al.y);
    let a = [at(0), at(1), at(2)];
    let xj = geom.x[j];
    let rho = a[0].scale(xj.x) + a[1].scale(xj.y);
    let d = rho - T::constant(geom.base_radius);
    (a, T::constant(geom.leg_length * geom.leg_length) - d * d)
}

/// The actuator position `q_j` and revolute centre `B_j` of a reachable limb.
#[inline(always)]
pub fn slider<T: Elementary>(geom: &Geometry, j: usize, a: [T; 3], disc: T) -> (T, [T; 3]) {
    let xj = geom.x[j];
    let q = a[2] - disc.sqrt();
    (q, [T::constant(geom.base_radius * xj.x), T::constant(geom.base_radius * xj.y), q])
}

fn vec_of(v: [f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

fn posture_of<T: Real>(geom: &Geometry, z: f64, psi: f64, theta: f64, g: &Generic<T>) -> Posture {
    let val = |v: [T; 3]| vec_of(v.map(|c| c.value()));
    let a = g.a.map(val);
    let b = g.b.map(val);
    let e = [0, 1, 2].map(|j| (a[j] - b[j]) / geom.leg_length);
    let r = g.rot;
    Posture {
        z,
        psi,
        theta,
        x: g.x.value(),
        y: g.y.value(),
        phi: g.phi.value(),
        p: Vector3::new(g.x.value(), g.y.value(), z),
        rot: Matrix3::from_fn(|i, k| r[i][k].value()),
        a,
        b,
        q: g.q.map(|c| c.value()),
        e,
    }
}

/// The posture at `(Z, Ψ, Θ)`, or the first leg that cannot reach.
pub fn inverse_kinematics(geom: &Geometry, z: f64, psi: f64, theta: f64) -> Result<Posture, Unreachable> {
    let g = solve(geom, z, psi, theta)?;
    Ok(posture_of(geom, z, psi, theta, &g))
}

fn vee_skew(m: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)])
}

/// The posture and its exact time derivatives, from each input's
/// `[value, rate, acceleration]`.
pub fn inverse_kinematics_motion(
    geom: &Geometry,
    z: [f64; 3],
    psi: [f64; 3],
    theta: [f64; 3],
) -> Result<(Posture, Motion), Unreachable> {
    let g = solve(geom, Jet::from_array(z), Jet::from_array(psi), Jet::from_array(theta))?;
    let posture = posture_of(geom, z[0], psi[0], theta[0], &g);
    let d = |v: [Jet; 3]| vec_of(v.map(|c| c.d));
    let dd = |v: [Jet; 3]| vec_of(v.map(|c| c.dd));
    let r = g.rot;
    let rot_dot = Matrix3::from_fn(|i, k| r[i][k].d);
    let rot_ddot = Matrix3::from_fn(|i, k| r[i][k].dd);
    let rt = posture.rot.transpose();
    // [ω]× = Ṙ·Rᵀ and [ω̇]× = R̈·Rᵀ + Ṙ·Ṙᵀ (the second term is symmetric).
    let omega = vee_skew(&(rot_dot * rt));
    let omega_dot = vee_skew(&(rot_ddot * rt));
    let l = geom.leg_length;
    let mut leg_omega = [Vector3::zeros(); 3];
    let mut leg_omega_dot = [Vector3::zeros(); 3];
    let mut leg_com_acc = [Vector3::zeros(); 3];
    let mut a_ddot = [Vector3::zeros(); 3];
    for j in 0..3 {
        let e_dot = (d(g.a[j]) - d(g.b[j])) / l;
        let e_ddot = (dd(g.a[j]) - dd(g.b[j])) / l;
        leg_omega[j] = posture.e[j].cross(&e_dot);
        leg_omega_dot[j] = posture.e[j].cross(&e_ddot);
        a_ddot[j] = dd(g.a[j]);
        leg_com_acc[j] = 0.5 * (dd(g.a[j]) + dd(g.b[j]));
    }
    let motion = Motion {
        parasitic_dot: [g.x.d, g.y.d, g.phi.d],
        parasitic_ddot: [g.x.dd, g.y.dd, g.phi.dd],
        p_dot: Vector3::new(g.x.d, g.y.d, z[1]),
        p_ddot: Vector3::new(g.x.dd, g.y.dd, z[2]),
        omega,
        omega_dot,
        rot_dot,
        rot_ddot,
        a_ddot,
        q_dot: g.q.map(|c| c.d),
        q_ddot: g.q.map(|c| c.dd),
        leg_omega,
        leg_omega_dot,
        leg_com_acc,
    };
    Ok((posture, motion))
}
