//! docs/model.md §2: velocities and accelerations are exact. Compared with
//! fourth-order central differences of the posture along random trajectories.

use clearance_kinematics::{Geometry, Posture, inverse_kinematics, inverse_kinematics_motion};
use clearance_model::{MechanismKind, MechanismSpec};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

struct Traj {
    c: [[f64; 4]; 3], // per input: offset, amplitude, ω, phase
}

impl Traj {
    fn at(&self, k: usize, t: f64) -> [f64; 3] {
        let [o, a, w, ph] = self.c[k];
        let s = (w * t + ph).sin();
        [o + a * s, a * w * (w * t + ph).cos(), -a * w * w * s]
    }
    fn pose(&self, geom: &Geometry, t: f64) -> Posture {
        inverse_kinematics(geom, self.at(0, t)[0], self.at(1, t)[0], self.at(2, t)[0]).unwrap()
    }
}

fn d1<T>(f: &dyn Fn(f64) -> T, t: f64, h: f64) -> T
where
    T: std::ops::Sub<Output = T> + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T> + Copy,
{
    (f(t - 2.0 * h) - f(t + 2.0 * h) + (f(t + h) - f(t - h)) * 8.0) * (1.0 / (12.0 * h))
}

fn d2<T>(f: &dyn Fn(f64) -> T, t: f64, h: f64) -> T
where
    T: std::ops::Sub<Output = T> + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T> + Copy,
{
    ((f(t + h) + f(t - h)) * 16.0 - (f(t + 2.0 * h) + f(t - 2.0 * h)) - f(t) * 30.0) * (1.0 / (12.0 * h * h))
}

fn vee(m: Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)])
}

#[test]
fn motion_matches_finite_differences() {
    motion_matches(&Geometry::prototype(), 2.05, 2, 40);
}

/// Inclined and horizontal rails, uneven limbs (rates of Newton's solution by
/// implicit differentiation) and the 3-RPS, whose legs change length.
#[test]
fn family_motion_matches_finite_differences() {
    let member = |kind, beta: f64, limbs: [f64; 3], platform: [f64; 3]| {
        let mut m = MechanismSpec::of_kind(kind);
        if kind == MechanismKind::Prs3 {
            m.rail_angle_deg = Some(beta);
        }
        (m.limb_angles_deg, m.platform_angles_deg) = (Some(limbs.to_vec()), Some(platform.to_vec()));
        Geometry::from_spec(&m)
    };
    let cases = [
        (member(MechanismKind::Prs3, 30.0, [0.0, 120.0, 240.0], [0.0, 120.0, 240.0]), 1.0),
        (member(MechanismKind::Prs3, -90.0, [0.0, 100.0, 230.0], [5.0, 95.0, 240.0]), 0.5),
        (member(MechanismKind::Prs3, 0.0, [0.0, 100.0, 230.0], [0.0, 100.0, 230.0]), 2.05),
        (member(MechanismKind::Rps3, 0.0, [0.0, 120.0, 240.0], [0.0, 120.0, 240.0]), 1.2),
        (member(MechanismKind::Rps3, 0.0, [0.0, 110.0, 250.0], [-10.0, 120.0, 240.0]), 1.2),
    ];
    for (k, (geom, z)) in cases.iter().enumerate() {
        motion_matches(geom, *z, 100 + k as u64, 15);
    }
}

fn motion_matches(geom: &Geometry, z0: f64, seed: u64, count: usize) {
    let geom = geom.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..count {
        let traj = Traj {
            c: [
                [
                    z0 + rng.random_range(-0.15..0.15),
                    rng.random_range(0.0..0.1),
                    rng.random_range(0.5..3.0),
                    rng.random_range(0.0..6.0),
                ],
                [
                    rng.random_range(-0.2..0.2),
                    rng.random_range(0.0..0.3),
                    rng.random_range(0.5..3.0),
                    rng.random_range(0.0..6.0),
                ],
                [
                    rng.random_range(-0.2..0.2),
                    rng.random_range(0.0..0.3),
                    rng.random_range(0.5..3.0),
                    rng.random_range(0.0..6.0),
                ],
            ],
        };
        let t = rng.random_range(0.0..5.0);
        let (pose, m) = inverse_kinematics_motion(&geom, traj.at(0, t), traj.at(1, t), traj.at(2, t)).unwrap();
        let h = 1e-3;
        // Truncation O(h⁴·f⁽⁵⁾) ≈ 1e-12 times rates of order 10; round-off ε/h² ≈ 2e-10.
        let tol = 1e-7;
        let p = |t: f64| traj.pose(&geom, t).p;
        assert!((d1(&p, t, h) - m.p_dot).amax() < tol, "ṗ");
        assert!((d2(&p, t, h) - m.p_ddot).amax() < tol, "p̈");
        let rot = |t: f64| traj.pose(&geom, t).rot;
        let rdot = d1(&rot, t, h);
        assert!((vee(rdot * pose.rot.transpose()) - m.omega).amax() < tol, "ω");
        let omega = |t: f64| {
            let (_, mm) = inverse_kinematics_motion(&geom, traj.at(0, t), traj.at(1, t), traj.at(2, t)).unwrap();
            mm.omega
        };
        assert!((d1(&omega, t, h) - m.omega_dot).amax() < tol, "ω̇");
        for j in 0..3 {
            let q = |t: f64| traj.pose(&geom, t).q[j];
            assert!((d1(&q, t, h) - m.q_dot[j]).abs() < tol, "q̇{j}");
            assert!((d2(&q, t, h) - m.q_ddot[j]).abs() < tol, "q̈{j}");
            let g = |t: f64| {
                let p = traj.pose(&geom, t);
                0.5 * (p.a[j] + p.b[j])
            };
            assert!((d2(&g, t, h) - m.leg_com_acc[j]).amax() < tol, "leg {j} centre acceleration");
            let a = |t: f64| traj.pose(&geom, t).a[j];
            assert!((d2(&a, t, h) - m.a_ddot[j]).amax() < tol, "Ä_{j}");
            let e = |t: f64| traj.pose(&geom, t).e[j];
            let e_dot = d1(&e, t, h);
            assert!((e_dot - m.e_dot[j]).amax() < tol, "ė_{j}");
            assert!((d2(&e, t, h) - m.e_ddot[j]).amax() < tol, "ë_{j}");
            assert!((pose.e[j].cross(&e_dot) - m.leg_omega[j]).amax() < tol, "leg {j} ω");
            // The leg only turns about y_j.
            assert!(m.leg_omega[j].cross(&geom.y[j]).amax() < 1e-12, "leg {j} ω along y_j");
            let w = |t: f64| {
                let (_, mm) = inverse_kinematics_motion(&geom, traj.at(0, t), traj.at(1, t), traj.at(2, t)).unwrap();
                mm.leg_omega[j]
            };
            assert!((d1(&w, t, h) - m.leg_omega_dot[j]).amax() < tol, "leg {j} ω̇");
        }
    }
}
