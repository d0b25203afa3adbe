//! MODEL.md §9: the parasitic closed forms equal a numerical solution of the
//! constraint equations `A_j·y_j = 0`, and the actuator positions give legs of
//! length L.

use clearance_kinematics::{Geometry, inverse_kinematics, rotation};
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
