//! A custom mechanism takes poses in place of its grid: the values of its inputs (any
//! of `x, y, z, φ, ψ, θ`), each pose solved as the grid's own is. Given the grid's
//! inputs back, `solve` returns the grid's rows bit for bit; a coordinate missing, one
//! that is not an input, or a 3-limb job given `x` is refused before anything is
//! computed.

use arrow::array::{Array, Float64Array};
use clearance_engine::{EngineError, JobSpec, Poses, SolveOptions, solve};

fn wrist() -> JobSpec {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml"))
        .unwrap()
        .replace("n = 61", "n = 13");
    JobSpec::from_toml_str(&text, "job.toml").unwrap()
}

fn column(batch: &arrow::array::RecordBatch, name: &str) -> Vec<f64> {
    let c = batch.column_by_name(name).unwrap();
    c.as_any().downcast_ref::<Float64Array>().unwrap().values().to_vec()
}

fn given(coords: [Option<Vec<f64>>; 6]) -> SolveOptions {
    SolveOptions { poses: Some(Poses { coords }), ..SolveOptions::default() }
}

#[test]
fn the_grids_inputs_given_back_give_its_rows() {
    let job = wrist();
    let grid = solve(&job, "job.toml", &SolveOptions::default()).unwrap().remove(0);
    assert_eq!(grid.num_rows(), 169);
    let [z, psi, theta] = ["z", "psi", "theta"].map(|n| Some(column(&grid, n)));
    let poses = solve(&job, "job.toml", &given([None, None, z, None, psi, theta])).unwrap().remove(0);
    assert_eq!(poses.schema(), grid.schema());
    for (i, field) in grid.schema().fields().iter().enumerate() {
        assert_eq!(poses.column(i).to_data(), grid.column(i).to_data(), "{}", field.name());
    }
}

#[test]
fn coordinates_the_job_does_not_take_are_refused() {
    let job = wrist();
    let one = || Some(vec![0.0]);
    let prs =
        JobSpec::from_toml_str("[clearance]\nr_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n", "t.toml")
            .unwrap();
    for (job, coords, words) in [
        (&job, [None, None, Some(vec![0.6]), None, one(), None], "theta missing: give all of z, psi and theta"),
        (&job, [one(), None, Some(vec![0.6]), None, one(), one()], "x is not one of this custom mechanism's inputs"),
        (&prs, [None, None, Some(vec![2.05]), one(), one(), one()], "phi is not one of the poses of a 3-limb kind"),
        (&job, [None, None, Some(vec![0.6, 0.6]), None, one(), one()], "z, psi and theta must have the same length"),
    ] {
        let e = solve(job, "job.toml", &given(coords)).expect_err("refused");
        assert!(matches!(e, EngineError::Samples(_)), "{e:?}");
        assert!(e.to_string().starts_with(words), "{e}");
    }
}
