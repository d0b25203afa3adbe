//! Closed-form inverse kinematics, generic over plain numbers and jets.

use nalgebra::{Matrix3, Vector3};

use crate::jet::{Elementary, Jet, Real};
use clearance_model::{LIMB_ANGLES, MechanismKind, MechanismSpec, PROTOTYPE_LIMB_ANGLES_DEG};

/// The robot's geometry with the limb frames precomputed.
#[derive(Clone, Debug, PartialEq)]
pub struct Geometry {
    /// Which robot: the limbs' base joints and actuators differ.
    pub kind: MechanismKind,
    /// `R_b` (m).
    pub base_radius: f64,
    /// `r_p` (m).
    pub platform_radius: f64,
    /// 3-PRS: `L` (m); NaN for the 3-RPS, whose legs change length.
    pub leg_length: f64,
    /// Radial unit vectors `x_j`.
    pub x: [Vector3<f64>; 3],
    /// Revolute axes `y_j` (normals of the limb planes).
    pub y: [Vector3<f64>; 3],
    /// Platform vertices in platform coordinates, `a'_j = r_p·(cos γ_j, sin γ_j, 0)`.
    pub a_local: [Vector3<f64>; 3],
    /// 3-PRS: `(cos β, sin β)` of the rail angle; the rail of limb j is
    /// `d_j = cos β·z + sin β·x_j`.
    pub rail_cs: (f64, f64),
    /// 3-PRS: `β = 0` exactly, where the prototype's formulas apply as written.
    pub vertical_rails: bool,
    /// The limbs at 0°, 120°, 240° with the platform's vertices on them, where the
    /// parasitic motions have closed forms (otherwise Newton).
    pub closed_form: bool,
    /// 3-RPS: the leg's stroke `[min_length, max_length]` (m).
    pub stroke: (f64, f64),
}

/// Angles in degrees to radians; the prototype's 0°, 120°, 240° as the radians the
/// engine has always used (`2π/3` is not `120·π/180` to the last bit).
fn radians(deg: &[f64]) -> Option<[f64; 3]> {
    if deg == PROTOTYPE_LIMB_ANGLES_DEG {
        return Some(LIMB_ANGLES);
    }
    <[f64; 3]>::try_from(deg).ok().map(|a| a.map(f64::to_radians))
}

impl Geometry {
    /// The prototype's layout (vertical rails, limbs at 0°, 120°, 240°) with other sizes.
    pub fn new(base_radius: f64, platform_radius: f64, leg_length: f64) -> Self {
        let mut spec = MechanismSpec::default();
        (spec.base_radius, spec.platform_radius, spec.leg_length) =
            (Some(base_radius), Some(platform_radius), Some(leg_length));
        Self::from_spec(&spec)
    }

    /// The paper's prototype: `R_b = 0.18`, `r_p = 0.36`, `L = 1`.
    pub fn prototype() -> Self {
        Self::from_spec(&MechanismSpec::default())
    }

    /// The geometry of a validated `[mechanism]` (three limbs).
    pub fn from_spec(m: &MechanismSpec) -> Self {
        let limbs = radians(&m.limb_angles_deg()).expect("a validated mechanism has three limb angles");
        let platform = radians(&m.platform_angles_deg()).expect("a validated mechanism has three platform angles");
        let r_p = m.platform_radius();
        let x = limbs.map(|a| Vector3::new(a.cos(), a.sin(), 0.0));
        let y = limbs.map(|a| Vector3::new(-a.sin(), a.cos(), 0.0));
        let a_local = platform.map(|a| Vector3::new(r_p * a.cos(), r_p * a.sin(), 0.0));
        let beta = m.rail_angle_deg();
        let rail_cs = if m.kind == MechanismKind::Prs3 { beta.to_radians().sin_cos() } else { (0.0, 1.0) };
        Self {
            kind: m.kind,
            base_radius: m.base_radius(),
            platform_radius: r_p,
            leg_length: m.leg_length(),
            x,
            y,
            a_local,
            rail_cs: (rail_cs.1, rail_cs.0),
            vertical_rails: m.kind != MechanismKind::Prs3 || beta == 0.0,
            closed_form: limbs == LIMB_ANGLES && platform == limbs,
            stroke: (m.min_length(), m.max_length()),
        }
    }

    /// The rail direction `d_j` of limb `j` (3-PRS).
    pub fn rail(&self, j: usize) -> Vector3<f64> {
        let (c, s) = self.rail_cs;
        Vector3::new(s * self.x[j].x, s * self.x[j].y, c)
    }

    /// The parasitic motions `(X, Y, Φ)` at `(Ψ, Θ)`: closed forms or Newton; NaN where
    /// Newton does not converge.
    pub fn parasitic(&self, psi: f64, theta: f64) -> (f64, f64, f64) {
        match parasitic_of(self, psi, theta) {
            Some((x, y, phi, _)) => (x, y, phi),
            None => (f64::NAN, f64::NAN, f64::NAN),
        }
    }

    /// Whether a leg whose `limb` returned `disc` can be assembled: the slider
    /// reaches it (3-PRS) or its length is within the stroke (3-RPS). False for NaN.
    #[inline(always)]
    pub fn reaches(&self, disc: f64) -> bool {
        match self.kind {
            MechanismKind::Prs3 => disc >= 0.0,
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                let q = disc.sqrt();
                q >= self.stroke.0 && q <= self.stroke.1
            }
        }
    }
}

/// Leg `leg` (0-based) cannot be assembled: the slider cannot reach it (3-PRS), its
/// length is outside the stroke (3-RPS), or (`leg` 0) the parasitic motions have no
/// solution.
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
    /// Leg directions `e_j = (A_j − B_j)/ℓ_j`.
    pub e: [Vector3<f64>; 3],
    /// Leg lengths `ℓ_j = |A_j − B_j|`: `L` for the 3-PRS, `q_j` for the 3-RPS.
    pub ell: [f64; 3],
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
    /// Acceleration of each leg's centre of mass (its midpoint; 3-PRS).
    pub leg_com_acc: [Vector3<f64>; 3],
    /// Rates of the leg directions `ė_j`, `ë_j`.
    pub e_dot: [Vector3<f64>; 3],
    pub e_ddot: [Vector3<f64>; 3],
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

/// Columns `[ŷ, R_y(Θ)x̂, R_y(Θ)R_x(Ψ)ẑ]`: `Δα = M·(ΔΘ, ΔΨ, ΔΦ)` (docs/model.md §6).
pub fn euler_rates_matrix(psi: f64, theta: f64) -> Matrix3<f64> {
    let (sp, cp) = psi.sin_cos();
    let (st, ct) = theta.sin_cos();
    Matrix3::new(0.0, ct, cp * st, 1.0, 0.0, -sp, 0.0, -st, cp * ct)
}

/// The three constraints `A_j·y_j = 0` at `(X, Y, Φ)` (the height does not enter:
/// `y_j` is horizontal).
#[inline(always)]
fn constraints<T: Elementary>(geom: &Geometry, u: [T; 3], sc_psi: (T, T), sc_theta: (T, T)) -> [T; 3] {
    let rot = rotation_sc(u[2].sin_cos(), sc_psi, sc_theta);
    std::array::from_fn(|j| {
        let (al, y) = (geom.a_local[j], geom.y[j]);
        let at = |k: usize| rot[k][0].scale(al.x) + rot[k][1].scale(al.y);
        (u[0] + at(0)).scale(y.x) + (u[1] + at(1)).scale(y.y)
    })
}

/// The inverse of the constraints' Jacobian in `(X, Y, Φ)`; `None` where singular.
fn constraint_jacobian_inverse(geom: &Geometry, u: [f64; 3], psi: f64, theta: f64) -> Option<Matrix3<f64>> {
    let r = rotation(u[2], psi, theta);
    let rot = Matrix3::from_fn(|i, k| r[i][k]);
    let jac = Matrix3::from_fn(|j, k| {
        let y = geom.y[j];
        match k {
            0 => y.x,
            1 => y.y,
            // ∂R/∂Φ = R·[ẑ]×.
            _ => y.dot(&(rot * Vector3::z().cross(&geom.a_local[j]))),
        }
    });
    jac.try_inverse()
}

/// Newton's iterations at most, and the step (m and rad) at which it has converged.
const NEWTON_ITERATIONS: usize = 50;
const NEWTON_TOL: f64 = 1e-14;

/// The parasitic motions `(X, Y, Φ)` and `(sin Φ, cos Φ)`: the closed forms where the
/// layout has them, otherwise Newton on the constraints from the closed-form values.
/// For a [`Jet`], the rates follow by implicit differentiation: chord steps with the
/// converged Jacobian, each of which makes one more derivative exact. `None` where
/// Newton does not converge in 50 iterations.
#[inline(always)]
pub fn parasitic_of<T: Real>(geom: &Geometry, psi: T, theta: T) -> Option<(T, T, T, (T, T))> {
    let (sc_psi, sc_theta) = (psi.sin_cos(), theta.sin_cos());
    let closed = parasitic_sc(geom.platform_radius, sc_psi, sc_theta);
    if geom.closed_form {
        return Some(closed);
    }
    let (ps, th) = (psi.value(), theta.value());
    let sc = |v: f64| v.sin_cos();
    let mut u = [closed.0.value(), closed.1.value(), closed.2.value()];
    let mut converged = false;
    for _ in 0..NEWTON_ITERATIONS {
        let f = constraints(geom, u, sc(ps), sc(th));
        let inv = constraint_jacobian_inverse(geom, u, ps, th)?;
        let step = -(inv * Vector3::from(f));
        if !step.iter().all(|v| v.is_finite()) {
            return None;
        }
        for k in 0..3 {
            u[k] += step[k];
        }
        if step.amax() <= NEWTON_TOL {
            converged = true;
            break;
        }
    }
    if !converged {
        return None;
    }
    let inv = constraint_jacobian_inverse(geom, u, ps, th)?;
    let mut w = u.map(T::constant);
    // Two chord steps make the first and second derivatives exact; a third polishes.
    for _ in 0..3 {
        let f = constraints(geom, w, sc_psi, sc_theta);
        w = std::array::from_fn(|r| {
            w[r] - (f[0].scale(inv[(r, 0)]) + f[1].scale(inv[(r, 1)]) + f[2].scale(inv[(r, 2)]))
        });
    }
    Some((w[0], w[1], w[2], w[2].sin_cos()))
}

struct Generic<T> {
    x: T,
    y: T,
    phi: T,
    rot: [[T; 3]; 3],
    a: [[T; 3]; 3],
    b: [[T; 3]; 3],
    q: [T; 3],
    /// `|A_j − B_j|`.
    ell: [T; 3],
}

#[inline(always)]
fn solve<T: Real>(geom: &Geometry, z: T, psi: T, theta: T) -> Result<Generic<T>, Unreachable> {
    let (sc_psi, sc_theta) = (psi.sin_cos(), theta.sin_cos());
    let (x, y, phi, sc_phi) = parasitic_of(geom, psi, theta).ok_or(Unreachable { leg: 0 })?;
    let rot = rotation_sc(sc_phi, sc_psi, sc_theta);
    let p = [x, y, z];
    let zero = T::constant(0.0);
    let mut a = [[zero; 3]; 3];
    let mut b = [[zero; 3]; 3];
    let mut q = [zero; 3];
    let mut ell = [zero; 3];
    for j in 0..3 {
        let disc;
        (a[j], disc) = limb(geom, j, p, &rot);
        if !geom.reaches(disc.value()) {
            return Err(Unreachable { leg: j });
        }
        (q[j], b[j]) = slider(geom, j, a[j], disc);
        ell[j] = match geom.kind {
            MechanismKind::Prs3 => T::constant(geom.leg_length),
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => q[j],
        };
    }
    Ok(Generic { x, y, phi, rot, a, b, q, ell })
}

/// Limb `j` at platform position `p` and orientation `rot`: the spherical joint
/// centre `A_j` and what decides the leg's assembly: for the 3-PRS the radicand
/// `L² − t_j²` (negative when the leg cannot reach its rail), with
/// `t_j = cos β·(ρ_j − R_b) − sin β·h_j` the distance of `A_j` from the rail's line
/// (`ρ_j − R_b` for vertical rails); for the 3-RPS the squared leg length `|A_j − B_j|²`.
#[inline(always)]
pub fn limb<T: Elementary>(geom: &Geometry, j: usize, p: [T; 3], rot: &[[T; 3]; 3]) -> ([T; 3], T) {
    let al = geom.a_local[j];
    let at = |k: usize| p[k] + rot[k][0].scale(al.x) + rot[k][1].scale(al.y);
    let a = [at(0), at(1), at(2)];
    let xj = geom.x[j];
    let rho = a[0].scale(xj.x) + a[1].scale(xj.y);
    let d = rho - T::constant(geom.base_radius);
    match geom.kind {
        MechanismKind::Prs3 if geom.vertical_rails => (a, T::constant(geom.leg_length * geom.leg_length) - d * d),
        MechanismKind::Prs3 => {
            let (c, s) = geom.rail_cs;
            let t = d.scale(c) - a[2].scale(s);
            (a, T::constant(geom.leg_length * geom.leg_length) - t * t)
        }
        MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
            let b = [T::constant(geom.base_radius * xj.x), T::constant(geom.base_radius * xj.y)];
            let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
            (a, dx * dx + dy * dy + a[2] * a[2])
        }
    }
}

/// The actuator position `q_j` and revolute centre `B_j` of a reachable limb: the
/// slider behind `A_j` along its rail, `q_j = s_j − sqrt(L² − t_j²)` with
/// `s_j = d_j·(A_j − R_b·x_j)` (3-PRS), or the leg length with `B_j` fixed (3-RPS).
#[inline(always)]
pub fn slider<T: Elementary>(geom: &Geometry, j: usize, a: [T; 3], disc: T) -> (T, [T; 3]) {
    let xj = geom.x[j];
    let b0 = [T::constant(geom.base_radius * xj.x), T::constant(geom.base_radius * xj.y)];
    match geom.kind {
        MechanismKind::Prs3 if geom.vertical_rails => {
            let q = a[2] - disc.sqrt();
            (q, [b0[0], b0[1], q])
        }
        MechanismKind::Prs3 => {
            let (c, s) = geom.rail_cs;
            let rho = a[0].scale(xj.x) + a[1].scale(xj.y);
            let d = rho - T::constant(geom.base_radius);
            let q = a[2].scale(c) + d.scale(s) - disc.sqrt();
            let along = q.scale(s);
            (q, [b0[0] + along.scale(xj.x), b0[1] + along.scale(xj.y), q.scale(c)])
        }
        MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
            (disc.sqrt(), [b0[0], b0[1], T::constant(0.0)])
        }
    }
}

fn vec_of(v: [f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

fn posture_of<T: Real>(z: f64, psi: f64, theta: f64, g: &Generic<T>) -> Posture {
    let val = |v: [T; 3]| vec_of(v.map(|c| c.value()));
    let a = g.a.map(val);
    let b = g.b.map(val);
    let ell = g.ell.map(|l| l.value());
    let e = [0, 1, 2].map(|j| (a[j] - b[j]) / ell[j]);
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
        ell,
    }
}

/// The posture at `(Z, Ψ, Θ)`, or the first leg that cannot reach.
pub fn inverse_kinematics(geom: &Geometry, z: f64, psi: f64, theta: f64) -> Result<Posture, Unreachable> {
    let g = solve(geom, z, psi, theta)?;
    Ok(posture_of(z, psi, theta, &g))
}

pub(crate) fn vee_skew(m: &Matrix3<f64>) -> Vector3<f64> {
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
    let posture = posture_of(z[0], psi[0], theta[0], &g);
    let d = |v: [Jet; 3]| vec_of(v.map(|c| c.d));
    let dd = |v: [Jet; 3]| vec_of(v.map(|c| c.dd));
    let r = g.rot;
    let rot_dot = Matrix3::from_fn(|i, k| r[i][k].d);
    let rot_ddot = Matrix3::from_fn(|i, k| r[i][k].dd);
    let rt = posture.rot.transpose();
    // [ω]× = Ṙ·Rᵀ and [ω̇]× = R̈·Rᵀ + Ṙ·Ṙᵀ (the second term is symmetric).
    let omega = vee_skew(&(rot_dot * rt));
    let omega_dot = vee_skew(&(rot_ddot * rt));
    let mut leg_omega = [Vector3::zeros(); 3];
    let mut leg_omega_dot = [Vector3::zeros(); 3];
    let mut leg_com_acc = [Vector3::zeros(); 3];
    let mut a_ddot = [Vector3::zeros(); 3];
    let mut e_dot = [Vector3::zeros(); 3];
    let mut e_ddot = [Vector3::zeros(); 3];
    for j in 0..3 {
        (e_dot[j], e_ddot[j]) = match geom.kind {
            MechanismKind::Prs3 => {
                let l = geom.leg_length;
                ((d(g.a[j]) - d(g.b[j])) / l, (dd(g.a[j]) - dd(g.b[j])) / l)
            }
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                // e = (A − B)/q with a varying q: the quotient's jet.
                let e: [Jet; 3] = std::array::from_fn(|k| (g.a[j][k] - g.b[j][k]) / g.ell[j]);
                (d(e), dd(e))
            }
        };
        leg_omega[j] = posture.e[j].cross(&e_dot[j]);
        leg_omega_dot[j] = posture.e[j].cross(&e_ddot[j]);
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
        e_dot,
        e_ddot,
    };
    Ok((posture, motion))
}
