//! MODEL.md §2: velocities and accelerations are exact. Compared with
//! fourth-order central differences of the posture along random trajectories.

use clearance_kinematics::{Geometry, Posture, inverse_kinematics, inverse_kinematics_motion};
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
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let geom = Geometry::prototype();
    for _ in 0..40 {
        let traj = Traj {
            c: [
                [
                    rng.random_range(1.9..2.2),
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
            let e = |t: f64| traj.pose(&geom, t).e[j];
            let e_dot = d1(&e, t, h);
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
