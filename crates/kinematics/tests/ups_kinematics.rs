//! 6-UPS inverse kinematics (docs/model.md §10.3): the loops close, against a rotation
//! built independently; the exact rates agree with central finite differences.

use clearance_kinematics::ups::U_SINGULAR;
use clearance_kinematics::{UpsGeometry, UpsParams, ups_inverse_kinematics, ups_inverse_kinematics_motion};
use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The default layout and a random irregular one (points off the plane, tilted axes).
fn geometries(rng: &mut ChaCha8Rng) -> Vec<UpsGeometry> {
    let mut out = vec![UpsGeometry::default()];
    for _ in 0..3 {
        let jitter = |rng: &mut ChaCha8Rng, r: f64| [0, 1, 2].map(|_| rng.random_range(-r..r));
        let params = UpsParams::default();
        let base = UpsGeometry::new(&params);
        let mut p = params.clone();
        p.base_points = Some(std::array::from_fn(|i| {
            let j = jitter(rng, 0.05);
            [base.b[i].x + j[0], base.b[i].y + j[1], j[2]]
        }));
        p.platform_points = Some(std::array::from_fn(|i| {
            let j = jitter(rng, 0.03);
            [base.a_local[i].x + j[0], base.a_local[i].y + j[1], j[2]]
        }));
        p.u_axes = Some(std::array::from_fn(|i| {
            let j = jitter(rng, 0.4);
            [base.a1[i].x + j[0], base.a1[i].y + j[1], 2.0 * j[2]]
        }));
        p.max_length = Some(1.3);
        out.push(UpsGeometry::new(&p));
    }
    out
}

fn random_inputs(rng: &mut ChaCha8Rng) -> [f64; 6] {
    let mut u = [0.0; 6];
    for (k, v) in u.iter_mut().enumerate() {
        *v = match k {
            0 | 1 => rng.random_range(-0.08..0.08),
            2 => rng.random_range(0.6..0.85),
            _ => rng.random_range(-0.25..0.25),
        };
    }
    u
}

/// `p + R·a'_i = B_i + q_i·e_i` with `R` composed from nalgebra's elementary rotations
/// about fixed axes (Φ about z, then Ψ about x, then Θ about y); the axes are unit and
/// orthogonal, `n_i·e_i = −|a1_i × e_i|`.
#[test]
fn inverse_kinematics_closes_every_loop() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let mut checked = 0;
    for geom in geometries(&mut rng) {
        for _ in 0..200 {
            let u = random_inputs(&mut rng);
            let Ok(pose) = ups_inverse_kinematics(&geom, u) else { continue };
            let rot = Rotation3::from_axis_angle(&Vector3::y_axis(), u[5])
                * Rotation3::from_axis_angle(&Vector3::x_axis(), u[4])
                * Rotation3::from_axis_angle(&Vector3::z_axis(), u[3]);
            assert!((rot.matrix() - pose.rot).amax() < 1e-15);
            let p = Vector3::new(u[0], u[1], u[2]);
            for i in 0..6 {
                let a = p + rot * geom.a_local[i];
                let closure = a - geom.b[i] - pose.q[i] * pose.e[i];
                assert!(closure.amax() < 1e-15, "leg {i}: {closure}");
                assert!((pose.e[i].norm() - 1.0).abs() < 1e-15);
                assert!(pose.q[i] >= geom.stroke.0 && pose.q[i] <= geom.stroke.1);
                let (a1, a2, n) = (pose.a1[i], pose.a2[i], pose.n[i]);
                assert!(a1.dot(&a2).abs() < 1e-15 && (a2.norm() - 1.0).abs() < 1e-15);
                assert!((n.dot(&pose.e[i]) + a1.cross(&pose.e[i]).norm()).abs() < 1e-15);
                assert!(pose.u_sine[i] > U_SINGULAR);
            }
            checked += 1;
        }
    }
    assert!(checked > 500, "{checked}");
}

/// A leg along its fixed axis is flagged near-singular.
#[test]
fn leg_along_the_fixed_axis_is_near_singular() {
    let mut p = UpsParams::default();
    let g = UpsGeometry::default();
    let pose = ups_inverse_kinematics(&g, [0.0, 0.0, 0.7, 0.0, 0.0, 0.0]).unwrap();
    let mut axes = g.a1.map(|a| [a.x, a.y, a.z]);
    axes[2] = [pose.e[2].x, pose.e[2].y, pose.e[2].z];
    p.u_axes = Some(axes);
    let pose = ups_inverse_kinematics(&UpsGeometry::new(&p), [0.0, 0.0, 0.7, 0.0, 0.0, 0.0]).unwrap();
    assert!(pose.near_singular && pose.u_sine[2] < 1e-12);
}

/// Along `u_k(t) = c_k + s_k·sin(w_k·t + φ_k)`, every rate against central differences
/// (step 1e-5: truncation ~1e-10, round-off ~1e-11): `ė`, `ë`, `q̇`, `q̈`, `Ȧ`, `Ä`, the
/// platform's `ω`, `ω̇`, the legs' `ω_i`, `ω̇_i`; and `ω_i·n_i = 0`, `ω_i × e_i = ė_i`.
#[test]
fn rates_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    let mut checked = 0;
    for geom in geometries(&mut rng) {
        for _ in 0..40 {
            let c = random_inputs(&mut rng);
            let s: [f64; 6] = std::array::from_fn(|k| rng.random_range(0.0..if k < 3 { 0.05 } else { 0.1 }));
            let w: [f64; 6] = std::array::from_fn(|_| rng.random_range(0.5..4.0));
            let ph: [f64; 6] = std::array::from_fn(|_| rng.random_range(0.0..6.0));
            let at = |t: f64| -> [[f64; 3]; 6] {
                std::array::from_fn(|k| {
                    let (sn, cs) = (w[k] * t + ph[k]).sin_cos();
                    [c[k] + s[k] * sn, s[k] * w[k] * cs, -s[k] * w[k] * w[k] * sn]
                })
            };
            let h = 1e-5;
            let (Ok((p0, m0)), Ok((pp, mp)), Ok((pm, mm))) = (
                ups_inverse_kinematics_motion(&geom, at(0.0)),
                ups_inverse_kinematics_motion(&geom, at(h)),
                ups_inverse_kinematics_motion(&geom, at(-h)),
            ) else {
                continue;
            };
            let fd = |a: Vector3<f64>, b: Vector3<f64>| (a - b) / (2.0 * h);
            let close = |got: Vector3<f64>, want: Vector3<f64>, what: &str| {
                let tol = 1e-7 * (1.0 + want.norm());
                assert!((got - want).amax() < tol, "{what}: {got} vs {want}");
            };
            let omega_fd = {
                let d = (pp.rot - pm.rot) / (2.0 * h) * p0.rot.transpose();
                Vector3::new(d[(2, 1)] - d[(1, 2)], d[(0, 2)] - d[(2, 0)], d[(1, 0)] - d[(0, 1)]) / 2.0
            };
            close(m0.omega, omega_fd, "ω");
            close(m0.omega_dot, fd(mp.omega, mm.omega), "ω̇");
            for i in 0..6 {
                close(m0.e_dot[i], fd(pp.e[i], pm.e[i]), "ė");
                close(m0.e_ddot[i], fd(mp.e_dot[i], mm.e_dot[i]), "ë");
                close(m0.a_dot[i], fd(pp.a[i], pm.a[i]), "Ȧ");
                close(m0.a_ddot[i], fd(mp.a_dot[i], mm.a_dot[i]), "Ä");
                let q = |a: f64, b: f64| Vector3::new((a - b) / (2.0 * h), 0.0, 0.0);
                close(Vector3::new(m0.q_dot[i], 0.0, 0.0), q(pp.q[i], pm.q[i]), "q̇");
                close(Vector3::new(m0.q_ddot[i], 0.0, 0.0), q(mp.q_dot[i], mm.q_dot[i]), "q̈");
                close(m0.leg_omega_dot[i], fd(mp.leg_omega[i], mm.leg_omega[i]), "ω̇_i");
                let wi = m0.leg_omega[i];
                assert!(wi.dot(&p0.n[i]).abs() < 1e-14 * (1.0 + wi.norm()), "ω_i·n_i");
                close(wi.cross(&p0.e[i]), m0.e_dot[i], "ω_i × e_i");
                // The leg's axes turn with it: ȧ2_i = ω_i × a2_i (a2_i is fixed in the leg).
                close(wi.cross(&p0.a2[i]), fd(pp.a2[i], pm.a2[i]), "ȧ2");
            }
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
}

/// A pose's posture does not depend on the poses solved before it on the same thread
/// (the platform's rotation is reused where the angles are the last ones): the same
/// inputs in opposite orders, each order on a fresh thread, give the same numbers, bit
/// for bit. The inputs: positions at a few orientations, each orientation several times
/// in a row and again later, with angles differing in one of the three only, and +0
/// against −0.
#[test]
fn a_posture_does_not_depend_on_the_poses_before_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let geom = UpsGeometry::default();
    let angles = [
        [0.1, -0.05, 0.2],
        [0.1, -0.05, -0.2],
        [0.1, 0.05, 0.2],
        [-0.1, -0.05, 0.2],
        [0.0, 0.0, 0.0],
        [-0.0, 0.0, -0.0],
    ];
    let mut inputs = Vec::new();
    for _ in 0..3 {
        for a in &angles {
            for _ in 0..4 {
                let mut u = random_inputs(&mut rng);
                u[3..].copy_from_slice(a);
                inputs.push(u);
            }
        }
    }
    let solve = |order: Vec<[f64; 6]>| {
        std::thread::spawn(move || {
            let mut out: Vec<(String, String)> = order
                .iter()
                .map(|&u| (format!("{u:?}"), format!("{:?}", ups_inverse_kinematics(&UpsGeometry::default(), u))))
                .collect();
            out.sort();
            out
        })
        .join()
        .unwrap()
    };
    let forward = solve(inputs.clone());
    let backward = solve(inputs.iter().rev().copied().collect());
    assert_eq!(forward.len(), 6 * 4 * 3);
    assert_eq!(forward, backward);
    // And each is the rotation of its own angles.
    for u in &inputs {
        let Ok(pose) = ups_inverse_kinematics(&geom, *u) else { continue };
        let r = clearance_kinematics::rotation(u[3], u[4], u[5]);
        for (i, row) in r.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                assert_eq!(v.to_bits(), pose.rot[(i, k)].to_bits(), "{u:?}");
            }
        }
    }
}
