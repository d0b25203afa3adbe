//! docs/model.md, "Validation": the parasitic closed forms, and the Newton solve of
//! layouts that have none, equal a numerical solution of the constraint equations
//! `A_j·y_j = 0`, and the actuator positions give legs of the right length on their
//! rails.

use clearance_kinematics::{Geometry, inverse_kinematics, rotation};
use clearance_model::{MechanismKind, MechanismSpec};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Newton on (X, Y, Φ) with a central-difference Jacobian, from zero: knows
/// nothing of the closed forms.
fn solve_constraints(geom: &Geometry, psi: f64, theta: f64) -> Vector3<f64> {
    let residual = |u: &Vector3<f64>| -> Vector3<f64> {
        let r = rotation(u.z, psi, theta);
        let rot = Matrix3::from_fn(|i, k| r[i][k]);
        let p = Vector3::new(u.x, u.y, 2.0);
        Vector3::from_fn(|j, _| (p + rot * geom.a_local[j]).dot(&geom.y[j]))
    };
    let mut u = Vector3::zeros();
    for _ in 0..50 {
        let f = residual(&u);
        let h = 1e-7;
        let jac = Matrix3::from_fn(|i, k| {
            let mut up = u;
            let mut dn = u;
            up[k] += h;
            dn[k] -= h;
            (residual(&up)[i] - residual(&dn)[i]) / (2.0 * h)
        });
        let step = jac.lu().solve(&(-f)).expect("constraint Jacobian is regular");
        u += step;
        if step.amax() < 1e-15 {
            break;
        }
    }
    u
}

#[test]
fn closed_forms_match_numerical_solution() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for _ in 0..300 {
        let rp = rng.random_range(0.1..0.6);
        let geom = Geometry::new(rng.random_range(0.05..0.4), rp, rng.random_range(0.8..1.5));
        let (psi, theta) = (rng.random_range(-0.7..0.7), rng.random_range(-0.7..0.7));
        let z = rng.random_range(1.5..2.5);
        let Ok(pose) = inverse_kinematics(&geom, z, psi, theta) else {
            continue;
        };
        let num = solve_constraints(&geom, psi, theta);
        // Tolerance: round-off of the constraint residual, scaled by r_p.
        assert!((pose.x - num.x).abs() < 1e-13 * rp.max(1.0), "X at ({psi}, {theta})");
        assert!((pose.y - num.y).abs() < 1e-13 * rp.max(1.0), "Y at ({psi}, {theta})");
        assert!((pose.phi - num.z).abs() < 1e-12, "Φ at ({psi}, {theta})");
        for j in 0..3 {
            let leg = (pose.a[j] - pose.b[j]).norm();
            assert!((leg - geom.leg_length).abs() < 1e-13, "leg {j} length {leg}");
            assert!(pose.b[j].z < pose.a[j].z, "slider below the platform");
        }
    }
}

#[test]
fn unreachable_when_a_leg_is_too_short() {
    let geom = Geometry::new(0.18, 0.36, 0.1);
    let err = inverse_kinematics(&geom, 2.0, 0.0, 0.5).unwrap_err();
    assert!(err.leg < 3);
}

/// A 3-PRS or 3-RPS with the given layout.
fn family(kind: MechanismKind, beta: f64, limbs: [f64; 3], platform: [f64; 3]) -> Geometry {
    let mut m = MechanismSpec::of_kind(kind);
    if kind == MechanismKind::Prs3 {
        m.rail_angle_deg = Some(beta);
    }
    (m.limb_angles_deg, m.platform_angles_deg) = (Some(limbs.to_vec()), Some(platform.to_vec()));
    Geometry::from_spec(&m)
}

/// Layouts without closed forms (a rotated 120° set among them): Newton's solution
/// satisfies the plane constraints to round-off and is the root a generic solver
/// (central-difference Jacobian, started from zero) finds; the legs have their
/// length, sit on their rails behind `A_j` (3-PRS) or within their stroke (3-RPS).
#[test]
fn newton_solves_layouts_without_closed_forms() {
    let mut rng = ChaCha8Rng::seed_from_u64(19);
    let mut solved = 0;
    for case in 0..120 {
        let kind = if case % 3 == 2 { MechanismKind::Rps3 } else { MechanismKind::Prs3 };
        let limbs = if case % 5 == 0 {
            [90.0, 210.0, 330.0]
        } else {
            [0.0, 120.0, 240.0].map(|a: f64| a + rng.random_range(-25.0..25.0))
        };
        let platform = if case % 2 == 0 { limbs } else { limbs.map(|a| a + rng.random_range(-15.0..15.0)) };
        let beta = [0.0, 30.0, -90.0, 90.0, rng.random_range(-60.0..60.0)][case % 5];
        let geom = family(kind, beta, limbs, platform);
        assert!(!geom.closed_form);
        let (psi, theta) = (rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4));
        let z = match kind {
            MechanismKind::Rps3 | MechanismKind::Ups6 => rng.random_range(1.0..1.4),
            _ if beta.abs() > 45.0 => rng.random_range(0.3..0.6),
            _ => rng.random_range(0.8..1.2),
        };
        let Ok(pose) = inverse_kinematics(&geom, z, psi, theta) else { continue };
        solved += 1;
        for j in 0..3 {
            assert!(pose.a[j].dot(&geom.y[j]).abs() < 1e-15, "A_{j}·y_{j} = {}", pose.a[j].dot(&geom.y[j]));
        }
        let num = solve_constraints(&geom, psi, theta);
        assert!((pose.x - num.x).abs() < 1e-13 && (pose.y - num.y).abs() < 1e-13, "X, Y at case {case}");
        assert!((pose.phi - num.z).abs() < 1e-12, "Φ at case {case}");
        for j in 0..3 {
            let leg = (pose.a[j] - pose.b[j]).norm();
            match kind {
                MechanismKind::Prs3 => {
                    assert!((leg - geom.leg_length).abs() < 1e-13, "leg {j} length {leg}");
                    let along = pose.b[j] - geom.base_radius * geom.x[j];
                    assert!(along.cross(&geom.rail(j)).amax() < 1e-13, "B_{j} off its rail");
                    assert!((along.dot(&geom.rail(j)) - pose.q[j]).abs() < 1e-13, "q_{j} is the slider's travel");
                    assert!((pose.a[j] - pose.b[j]).dot(&geom.rail(j)) > 0.0, "slider behind A_{j}");
                }
                MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => {
                    assert!((leg - pose.q[j]).abs() < 1e-13, "leg {j} length {leg} against q {}", pose.q[j]);
                    assert!(pose.q[j] >= geom.stroke.0 && pose.q[j] <= geom.stroke.1, "stroke");
                }
            }
        }
    }
    assert!(solved > 80, "{solved}");
}

/// The symmetric layout at any rail angle: the closed forms and Newton (forced)
/// give the same posture.
#[test]
fn closed_forms_equal_newton_at_any_rail_angle() {
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    for &beta in &[-90.0, -40.0, 0.0, 30.0, 90.0] {
        let closed = family(MechanismKind::Prs3, beta, [0.0, 120.0, 240.0], [0.0, 120.0, 240.0]);
        assert!(closed.closed_form);
        let newton = Geometry { closed_form: false, ..closed.clone() };
        for _ in 0..30 {
            let (psi, theta) = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
            let z = if beta.abs() > 45.0 { 0.5 } else { 1.0 };
            let (Ok(a), Ok(b)) =
                (inverse_kinematics(&closed, z, psi, theta), inverse_kinematics(&newton, z, psi, theta))
            else {
                panic!("β = {beta}: unreachable at ({psi}, {theta})")
            };
            assert!((a.x - b.x).abs() < 1e-15 && (a.y - b.y).abs() < 1e-15 && (a.phi - b.phi).abs() < 1e-15);
            for j in 0..3 {
                assert!((a.q[j] - b.q[j]).abs() < 1e-14, "β = {beta}, q_{j}");
            }
        }
    }
}

#[test]
fn three_rps_legs_outside_their_stroke_are_unreachable() {
    let geom = family(MechanismKind::Rps3, 0.0, [0.0, 120.0, 240.0], [0.0, 120.0, 240.0]);
    assert_eq!(geom.stroke, (0.8, 1.6));
    assert!(inverse_kinematics(&geom, 1.2, 0.0, 0.0).is_ok());
    assert!(inverse_kinematics(&geom, 0.5, 0.0, 0.0).is_err(), "shorter than the retracted leg");
    assert!(inverse_kinematics(&geom, 1.7, 0.0, 0.0).is_err(), "longer than the extended leg");
}
