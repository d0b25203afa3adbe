//! Every switch of a custom run lies at a pose the search solved: its margin and all
//! six coordinates are numbers (docs/model.md §12.8). The case is a job the fuzzer
//! (`scripts/fuzz_custom.py`) found, `data/wide_fast_prs_trajectory.toml`: a crossing
//! located between two samples whose point the continuation did not reach again, which
//! was reported with a null margin and zeros for its parasitic coordinates.

mod common;

use arrow::array::{Array, Float64Array, StringArray};
use clearance_engine::{JobSpec, Layout, run};

const JOB: &str = include_str!("data/wide_fast_prs_trajectory.toml");
const COORDS: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];

#[test]
fn every_switch_has_a_margin_and_its_coordinates() {
    let job = JobSpec::from_toml_str(JOB, "wide.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    run(&job, "wide.toml", &common::options(dir.path())).unwrap();
    let d = common::read(&Layout::new(dir.path()).discontinuities());
    assert!(d.num_rows() >= 40, "the job has its switches ({})", d.num_rows());
    let margin = common::column::<Float64Array>(&d, "margin");
    let kind = common::column::<StringArray>(&d, "kind");
    for r in 0..d.num_rows() {
        assert!(margin.is_valid(r) && margin.value(r).is_finite(), "switch {r} ({}) has no margin", kind.value(r));
        for name in COORDS {
            let c = common::column::<Float64Array>(&d, name);
            assert!(c.is_valid(r) && c.value(r).is_finite(), "switch {r}: {name}");
        }
        // The unsolved fallback wrote the parasitic coordinates as exact zeros; a
        // solved pose of this swinging platform has none.
        let parasitic = ["x", "y", "phi"].map(|n| common::column::<Float64Array>(&d, n).value(r));
        assert!(parasitic.iter().all(|v| *v != 0.0), "switch {r}: parasitic coordinates {parasitic:?}");
    }
}
