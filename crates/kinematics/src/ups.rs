//! Inverse kinematics of the 6-UPS (Gough–Stewart) platform (docs/model.md §10.3).
//!
//! Leg i joins a universal joint at the base point `B_i` to a spherical joint at
//! `A_i = p + R·a'_i`, with `R = R_y(Θ)·R_x(Ψ)·R_z(Φ)` as for the 3-limb kinds (§1). All six
//! inputs `(x, y, z, Φ, Ψ, Θ)` are free: there are no parasitic motions, and each leg is
//! a closed form, `q_i = |A_i − B_i|`, `e_i = (A_i − B_i)/q_i`.
//!
//! The universal joint's first axis `a1_i` is fixed in the base, its second
//! `a2_i = (a1_i × e_i)/|a1_i × e_i|` turns with the leg, and `n_i = a1_i × a2_i` is the one
//! rotation it forbids. The leg turns as `ω_i = e_i × ė_i + σ_i·e_i`: the first term moves
//! its axis, the spin `σ_i` is whatever keeps `ω_i·n_i = 0`. With `c = a1_i·e_i`,
//! `n_i ∝ c·a1_i − e_i`, so `σ_i = c·a1_i·(e_i × ė_i)/(1 − c²)`, singular where the leg lies
//! along `a1_i` (`|a1_i × e_i| = sqrt(1 − c²)` below `1e-6`: near-singular).
//!
//! Rates are exact: the inputs' `[value, rate, acceleration]` travel through the same
//! closed forms as [`Jet`]s, and `σ̇_i` through the jet of `(e_i, ė_i)`.

use nalgebra::{Matrix3, Vector3};

use crate::Unreachable;
use crate::inverse::{rotation, vee_skew};
use crate::jet::{Elementary, Jet, Real};

/// Below this `|a1_i × e_i|` a leg lies along its universal joint's fixed axis.
pub const U_SINGULAR: f64 = 1e-6;

/// The 6-UPS layout as plain data, with the defaults of docs/model.md §10.3 (a 6-6
/// platform with crossing legs). `base_points`, `platform_points` and `u_axes`, when
/// given, replace what the radii and angles would place.
#[derive(Clone, Debug, PartialEq)]
pub struct UpsParams {
    /// Radius of the base circle (m); default 0.5.
    pub base_radius: f64,
    /// Polar angles of the base points (degrees); default `[-15, 15, 105, 135, 225, 255]`.
    pub base_angles_deg: [f64; 6],
    /// Radius of the platform circle (m); default 0.3.
    pub platform_radius: f64,
    /// Polar angles of the platform points in platform axes (degrees); default
    /// `[-45, 45, 75, 165, 195, 285]`. Leg i joins base point i to platform point i.
    pub platform_angles_deg: [f64; 6],
    /// Cylinder and piston lengths (m); default 0.5 each.
    pub cylinder_length: f64,
    pub piston_length: f64,
    /// Stroke (m); default `max(cylinder, piston)` and `cylinder + piston` (§10.2).
    pub min_length: Option<f64>,
    pub max_length: Option<f64>,
    /// Base points `B_i` (world, m).
    pub base_points: Option<[[f64; 3]; 6]>,
    /// Platform points `a'_i` (platform coordinates, m).
    pub platform_points: Option<[[f64; 3]; 6]>,
    /// Fixed universal-joint axes `a1_i` (normalised here); default horizontal and
    /// tangent to the base circle, `(−sin θ_i, cos θ_i, 0)`.
    pub u_axes: Option<[[f64; 3]; 6]>,
}

impl Default for UpsParams {
    fn default() -> Self {
        Self {
            base_radius: 0.5,
            base_angles_deg: [-15.0, 15.0, 105.0, 135.0, 225.0, 255.0],
            platform_radius: 0.3,
            platform_angles_deg: [-45.0, 45.0, 75.0, 165.0, 195.0, 285.0],
            cylinder_length: 0.5,
            piston_length: 0.5,
            min_length: None,
            max_length: None,
            base_points: None,
            platform_points: None,
            u_axes: None,
        }
    }
}

/// The 6-UPS geometry, every point and axis placed.
#[derive(Clone, Debug, PartialEq)]
pub struct UpsGeometry {
    /// Universal-joint centres `B_i` (world).
    pub b: [Vector3<f64>; 6],
    /// Spherical-joint centres `a'_i` (platform coordinates).
    pub a_local: [Vector3<f64>; 6],
    /// Unit fixed axes `a1_i` of the universal joints.
    pub a1: [Vector3<f64>; 6],
    /// Platform radius (m), for the platform's default inertia.
    pub platform_radius: f64,
    pub cylinder_length: f64,
    pub piston_length: f64,
    /// `[min_length, max_length]` (m).
    pub stroke: (f64, f64),
}

impl UpsGeometry {
    pub fn new(p: &UpsParams) -> Self {
        let on_circle = |r: f64, deg: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            Vector3::new(r * c, r * s, 0.0)
        };
        let b = match p.base_points {
            Some(pts) => pts.map(Vector3::from),
            None => p.base_angles_deg.map(|a| on_circle(p.base_radius, a)),
        };
        let a_local = match p.platform_points {
            Some(pts) => pts.map(Vector3::from),
            None => p.platform_angles_deg.map(|a| on_circle(p.platform_radius, a)),
        };
        let a1 = match p.u_axes {
            Some(axes) => axes.map(|v| Vector3::from(v).normalize()),
            None => {
                // Tangent to the base circle at B_i's polar angle.
                let angle = |i: usize| match p.base_points {
                    Some(_) => b[i].y.atan2(b[i].x),
                    None => p.base_angles_deg[i].to_radians(),
                };
                std::array::from_fn(|i| {
                    let (s, c) = angle(i).sin_cos();
                    Vector3::new(-s, c, 0.0)
                })
            }
        };
        let (lc, lp) = (p.cylinder_length, p.piston_length);
        Self {
            b,
            a_local,
            a1,
            platform_radius: p.platform_radius,
            cylinder_length: lc,
            piston_length: lp,
            stroke: (p.min_length.unwrap_or(lc.max(lp)), p.max_length.unwrap_or(lc + lp)),
        }
    }
}

impl Default for UpsGeometry {
    fn default() -> Self {
        Self::new(&UpsParams::default())
    }
}

/// The nominal posture of a 6-UPS at one sample.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UpsPosture {
    /// `(x, y, z, Φ, Ψ, Θ)`.
    pub inputs: [f64; 6],
    pub p: Vector3<f64>,
    /// `R = R_y(Θ)·R_x(Ψ)·R_z(Φ)`.
    pub rot: Matrix3<f64>,
    /// Spherical-joint centres `A_i` and universal-joint centres `B_i`.
    pub a: [Vector3<f64>; 6],
    pub b: [Vector3<f64>; 6],
    /// Leg lengths `q_i = |A_i − B_i|` (the actuators) and directions `e_i`.
    pub q: [f64; 6],
    pub e: [Vector3<f64>; 6],
    /// Universal-joint axes: `a1_i` (fixed), `a2_i` (in the leg), `n_i = a1_i × a2_i`.
    pub a1: [Vector3<f64>; 6],
    pub a2: [Vector3<f64>; 6],
    pub n: [Vector3<f64>; 6],
    /// `|a1_i × e_i|`, the sine of the leg's angle to `a1_i`.
    pub u_sine: [f64; 6],
    /// Some `u_sine` is below [`U_SINGULAR`].
    pub near_singular: bool,
}

/// Exact first and second time derivatives of a 6-UPS posture.
#[derive(Clone, Debug, PartialEq)]
pub struct UpsMotion {
    pub p_dot: Vector3<f64>,
    pub p_ddot: Vector3<f64>,
    /// Platform angular velocity and acceleration (world).
    pub omega: Vector3<f64>,
    pub omega_dot: Vector3<f64>,
    pub a_dot: [Vector3<f64>; 6],
    pub a_ddot: [Vector3<f64>; 6],
    pub q_dot: [f64; 6],
    pub q_ddot: [f64; 6],
    pub e_dot: [Vector3<f64>; 6],
    pub e_ddot: [Vector3<f64>; 6],
    /// The leg's spin `σ_i` about `e_i` and its rate.
    pub spin: [f64; 6],
    pub spin_dot: [f64; 6],
    /// `ω_i = e_i × ė_i + σ_i·e_i` and `ω̇_i = e_i × ë_i + σ̇_i·e_i + σ_i·ė_i`.
    pub leg_omega: [Vector3<f64>; 6],
    pub leg_omega_dot: [Vector3<f64>; 6],
}

type V<T> = [T; 3];

fn dot<T: Elementary>(a: V<T>, b: V<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross<T: Elementary>(a: V<T>, b: V<T>) -> V<T> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn konst<T: Elementary>(v: &Vector3<f64>) -> V<T> {
    [T::constant(v.x), T::constant(v.y), T::constant(v.z)]
}

struct Legs<T> {
    rot: [[T; 3]; 3],
    a: [V<T>; 6],
    q: [T; 6],
    e: [V<T>; 6],
}

fn legs<T: Real>(geom: &UpsGeometry, inputs: [T; 6]) -> Result<Legs<T>, Unreachable> {
    let [_, _, _, phi, psi, theta] = inputs;
    legs_turned(geom, inputs, rotation(phi, psi, theta))
}

/// [`legs`] with the platform's rotation `rot` given.
fn legs_turned<T: Real>(geom: &UpsGeometry, inputs: [T; 6], rot: [[T; 3]; 3]) -> Result<Legs<T>, Unreachable> {
    let [x, y, z, ..] = inputs;
    let p = [x, y, z];
    let zero = T::constant(0.0);
    let (mut a, mut q, mut e) = ([[zero; 3]; 6], [zero; 6], [[zero; 3]; 6]);
    for i in 0..6 {
        let al = geom.a_local[i];
        a[i] = std::array::from_fn(|k| p[k] + rot[k][0].scale(al.x) + rot[k][1].scale(al.y) + rot[k][2].scale(al.z));
        let d: V<T> = std::array::from_fn(|k| a[i][k] - T::constant(geom.b[i][k]));
        q[i] = dot(d, d).sqrt();
        let len = q[i].value();
        // `!(inside)` also rejects NaN.
        if !(len >= geom.stroke.0 && len <= geom.stroke.1) {
            return Err(Unreachable { leg: i });
        }
        e[i] = d.map(|c| c / q[i]);
    }
    Ok(Legs { rot, a, q, e })
}

fn posture_of<T: Real>(geom: &UpsGeometry, inputs: [f64; 6], l: &Legs<T>) -> UpsPosture {
    let mut out = UpsPosture::default();
    posture_into(geom, inputs, l, &mut out);
    out
}

/// [`posture_of`] into `out`, every field written: built in place, not moved there
/// (a posture is some 1.2 kB, and the search solves hundreds of thousands).
fn posture_into<T: Real>(geom: &UpsGeometry, inputs: [f64; 6], l: &Legs<T>, out: &mut UpsPosture) {
    let val = |v: V<T>| Vector3::new(v[0].value(), v[1].value(), v[2].value());
    out.e = l.e.map(val);
    out.a1 = geom.a1;
    for i in 0..6 {
        let c = out.a1[i].cross(&out.e[i]);
        out.u_sine[i] = c.norm();
        out.a2[i] = c / out.u_sine[i];
        out.n[i] = out.a1[i].cross(&out.a2[i]);
    }
    out.inputs = inputs;
    out.p = Vector3::new(inputs[0], inputs[1], inputs[2]);
    out.rot = Matrix3::from_fn(|i, k| l.rot[i][k].value());
    out.a = l.a.map(val);
    out.b = geom.b;
    out.q = l.q.map(|v| v.value());
    // NaN (a leg of zero length) is singular too.
    out.near_singular = out.u_sine.iter().any(|&s| s.is_nan() || s < U_SINGULAR);
}

/// The posture at `(x, y, z, Φ, Ψ, Θ)`, or the first leg outside its stroke.
pub fn ups_inverse_kinematics(geom: &UpsGeometry, inputs: [f64; 6]) -> Result<UpsPosture, Unreachable> {
    let mut out = UpsPosture::default();
    ups_inverse_kinematics_into(geom, inputs, &mut out)?;
    Ok(out)
}

/// [`ups_inverse_kinematics`] into `out` (left as it was where a leg is outside its
/// stroke).
pub fn ups_inverse_kinematics_into(
    geom: &UpsGeometry,
    inputs: [f64; 6],
    out: &mut UpsPosture,
) -> Result<(), Unreachable> {
    let rot = same_rotation(inputs[3], inputs[4], inputs[5]);
    posture_into(geom, inputs, &legs_turned(geom, inputs, rot)?, out);
    Ok(())
}

/// Three angles (as bits) and their rotation.
type Turned = ([u64; 3], [[f64; 3]; 3]);

thread_local! {
    /// The angles and the rotation [`same_rotation`] computed last.
    static LAST_ROTATION: std::cell::Cell<Option<Turned>> = const { std::cell::Cell::new(None) };
}

/// [`rotation`] of the angles, the last one again where the angles are the last ones,
/// bit for bit: a position grid at a fixed orientation, and the search along its lines,
/// solve every pose at the same angles, whose three sines and cosines took a few
/// per cent of a 6-UPS run.
fn same_rotation(phi: f64, psi: f64, theta: f64) -> [[f64; 3]; 3] {
    let key = [phi.to_bits(), psi.to_bits(), theta.to_bits()];
    LAST_ROTATION.with(|last| match last.get() {
        Some((k, rot)) if k == key => rot,
        _ => {
            let rot = rotation(phi, psi, theta);
            last.set(Some((key, rot)));
            rot
        }
    })
}

/// The posture and its exact rates, from each input's `[value, rate, acceleration]`
/// (order `x, y, z, Φ, Ψ, Θ`).
pub fn ups_inverse_kinematics_motion(
    geom: &UpsGeometry,
    inputs: [[f64; 3]; 6],
) -> Result<(UpsPosture, UpsMotion), Unreachable> {
    let l = legs(geom, inputs.map(Jet::from_array))?;
    let posture = posture_of(geom, inputs.map(|v| v[0]), &l);
    let d = |v: V<Jet>| Vector3::new(v[0].d, v[1].d, v[2].d);
    let dd = |v: V<Jet>| Vector3::new(v[0].dd, v[1].dd, v[2].dd);
    let rot_dot = Matrix3::from_fn(|i, k| l.rot[i][k].d);
    let rot_ddot = Matrix3::from_fn(|i, k| l.rot[i][k].dd);
    let rt = posture.rot.transpose();
    // [ω]× = Ṙ·Rᵀ and [ω̇]× = R̈·Rᵀ + Ṙ·Ṙᵀ (the second term is symmetric).
    let omega = vee_skew(&(rot_dot * rt));
    let omega_dot = vee_skew(&(rot_ddot * rt));
    let zero = [Vector3::zeros(); 6];
    let mut m = UpsMotion {
        p_dot: Vector3::new(inputs[0][1], inputs[1][1], inputs[2][1]),
        p_ddot: Vector3::new(inputs[0][2], inputs[1][2], inputs[2][2]),
        omega,
        omega_dot,
        a_dot: l.a.map(d),
        a_ddot: l.a.map(dd),
        q_dot: l.q.map(|v| v.d),
        q_ddot: l.q.map(|v| v.dd),
        e_dot: l.e.map(d),
        e_ddot: l.e.map(dd),
        spin: [0.0; 6],
        spin_dot: [0.0; 6],
        leg_omega: zero,
        leg_omega_dot: zero,
    };
    for i in 0..6 {
        // The jet of (e, ė): its first derivative is exact, which is all σ̇ needs.
        let e = l.e[i];
        let e_rate: V<Jet> = std::array::from_fn(|k| Jet::new(e[k].d, e[k].dd, 0.0));
        let a1 = konst::<Jet>(&geom.a1[i]);
        let c = dot(a1, e);
        let sigma = c * dot(a1, cross(e, e_rate)) / (Jet::constant(1.0) - c * c);
        let (ev, ed, edd) = (posture.e[i], m.e_dot[i], m.e_ddot[i]);
        m.spin[i] = sigma.v;
        m.spin_dot[i] = sigma.d;
        m.leg_omega[i] = ev.cross(&ed) + sigma.v * ev;
        m.leg_omega_dot[i] = ev.cross(&edd) + sigma.d * ev + sigma.v * ed;
    }
    Ok((posture, m))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The defaults of docs/model.md §10.3: every leg mid-stroke at the level pose 0.7 m up.
    #[test]
    fn default_platform_reaches_its_home_pose() {
        let geom = UpsGeometry::default();
        assert_eq!(geom.stroke, (0.5, 1.0));
        let pose = ups_inverse_kinematics(&geom, [0.0, 0.0, 0.7, 0.0, 0.0, 0.0]).unwrap();
        for i in 0..6 {
            assert!((0.7..0.8).contains(&pose.q[i]), "leg {i}: {}", pose.q[i]);
            assert!((pose.a1[i].norm() - 1.0).abs() < 1e-15 && pose.a1[i].z == 0.0);
            assert!(pose.n[i].dot(&pose.e[i]) < 0.0);
        }
        assert!(!pose.near_singular);
        assert_eq!(ups_inverse_kinematics(&geom, [0.0, 0.0, 1.5, 0.0, 0.0, 0.0]), Err(Unreachable { leg: 0 }));
    }
}
