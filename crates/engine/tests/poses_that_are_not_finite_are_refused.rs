//! Poses given in place of the job's that are NaN or infinite: refused before
//! anything is computed, naming the first one, instead of rows whose status blames
//! the mechanism (the Python package's `solve(job, z=[2.0, nan, inf], ...)`).

use clearance_engine::{EngineError, JobSpec, Poses, SolveOptions, solve};

fn job() -> JobSpec {
    JobSpec::from_toml_str("[clearance]\nr_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n", "t.toml")
        .expect("a valid job")
}

fn solved(z: &[f64], psi: &[f64], theta: &[f64]) -> Result<usize, EngineError> {
    let poses = Poses::new(z.to_vec(), psi.to_vec(), theta.to_vec());
    let opts = SolveOptions { poses: Some(poses), ..SolveOptions::default() };
    Ok(solve(&job(), "t.toml", &opts)?.iter().map(|b| b.num_rows()).sum())
}

#[test]
fn the_first_value_that_is_not_finite_is_named() {
    for (z, psi, theta, named) in [
        (vec![2.0, f64::NAN, f64::INFINITY], vec![0.0; 3], vec![0.0; 3], "z[1] is NaN"),
        (vec![2.0; 3], vec![0.0, 0.1, f64::NEG_INFINITY], vec![0.0; 3], "psi[2] is -inf"),
        (vec![2.0; 2], vec![0.0; 2], vec![f64::INFINITY, f64::NAN], "theta[0] is inf"),
    ] {
        let e = solved(&z, &psi, &theta).expect_err("refused");
        assert!(matches!(e, EngineError::Samples(_)), "{e:?}");
        assert!(e.is_usage());
        assert!(e.to_string().starts_with(named), "{e}");
    }
}

#[test]
fn finite_poses_are_solved() {
    assert_eq!(solved(&[2.0, 2.05], &[0.0, 0.1], &[0.0, -0.1]).expect("solved"), 2);
}
