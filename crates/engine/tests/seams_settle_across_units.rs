//! A run that searches its grid lines as it computes them settles the candidates of
//! each unit's first samples with the last samples of the unit before in hand, and
//! those of the unit before again with this one's (`keep_local_minima` across the
//! seam): a Z-line of a 3-D grid, which crosses a seam at every other node or so, then
//! has its candidates settled as if the whole grid were one unit. That spares solves,
//! never a switch: whatever the size of the units (one for the whole grid, units
//! shorter than a Z-plane, units that do not divide it, on any number of threads), the
//! same switches, bit for bit.

mod common;

use clearance_engine::{JobSpec, RunOptions, run};
use common::read;

/// A 3-D grid of the 3-RPS (whose loads change along Z, so its Z-lines are searched)
/// with a point mass off its centre: switches of the vector loads and of the axial
/// one, some along Z. A Z-plane holds 31 × 29 = 899 samples.
const GRID_3D: &str = r#"
[mechanism]
kind = "3-RPS"

[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4

[mass]
points = [ { mass = 30.0, at = [0.2, 0.1, 0.3] } ]

[grid]
z = { start = 0.8, stop = 1.6, n = 9 }
psi = { start = -0.4, stop = 0.4, n = 31 }
theta = { start = -0.4, stop = 0.4, n = 29 }
"#;

#[test]
fn units_of_any_size_give_the_same_switches() {
    let job = JobSpec::from_toml_str(GRID_3D, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut whole = None;
    // On 12 and 24 threads the run writes with three and four writer threads, and the
    // search's batches spread over more threads.
    for (chunk, threads) in [(1 << 16, 2), (2000, 2), (899, 2), (500, 2), (97, 2), (899, 12), (97, 12), (500, 24)] {
        let out = dir.path().join(format!("units_of_{chunk}_on_{threads}"));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| run(&job, "t.toml", &RunOptions { chunk_size: chunk, ..common::options(&out) })).unwrap();
        let found = read(&out.join("discontinuities.parquet"));
        match &whole {
            None => whole = Some(found),
            Some(whole) => assert_eq!(whole, &found, "units of {chunk} samples on {threads} threads"),
        }
    }
    let whole = whole.unwrap();
    let kinds = whole.column_by_name("kind").unwrap();
    let kinds = kinds.as_any().downcast_ref::<arrow::array::StringArray>().unwrap();
    let along = whole.column_by_name("along").unwrap();
    let along = along.as_any().downcast_ref::<arrow::array::StringArray>().unwrap();
    let count = |f: &dyn Fn(usize) -> bool| (0..whole.num_rows()).filter(|&i| f(i)).count();
    assert!(count(&|i| matches!(kinds.value(i), "s_radial" | "r_radial")) > 10, "vector switches to lose");
    assert!(count(&|i| along.value(i) == "z") > 10, "switches along Z to lose");
}
