//! `--precision single` (`RunOptions::precision`): the part files of a run hold its
//! error (`err_*`, `exact_err_*`), envelope (`env_*`) and margin (`margin_*`) columns
//! as `float32`, each value the double run's rounded to the nearest `f32` (`v as f32`,
//! compared bit for bit), nulls at the same rows; every other column (inputs, motions,
//! actuators, reactions, condition numbers, labels) is the double run's, bit for bit;
//! `summary.parquet` and `discontinuities.parquet` hold the same values (their
//! metadata says the precision); on a 3-PRS grid with the exact error and unreachable
//! poses (both writers), a 6-UPS grid and a custom 3-RRS grid, full columns.

mod common;

use std::path::Path;

use arrow::array::{Array, Float32Array, Float64Array};
use arrow::datatypes::DataType;
use clearance_engine::{JobSpec, Layout, Precision, RunOptions, Writer, run};
use common::read;

const GRID: &str = r#"
name = "single_grid"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4
[analysis]
exact = true
[grid]
z = 2.05
psi = { start = -1.4, stop = 1.4, n = 21 }
theta = { start = -1.4, stop = 1.4, n = 23 }
"#;

const UPS: &str = r#"
name = "single_ups"
[mechanism]
kind = "6-UPS"
[clearance]
s_radial = 1e-4
u_radial = 1e-4
u_angular = 1e-3
[grid]
x = { start = -0.15, stop = 0.15, n = 9 }
y = { start = -0.15, stop = 0.15, n = 9 }
z = 0.7
phi = 0.05
psi = 0.1
theta = -0.1
"#;

const CUSTOM: &str = r#"
name = "single_custom"
[mechanism]
kind = "custom"
inputs = ["z", "psi", "theta"]
home = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0]
[[mechanism.limb]]
repeat = 3
joints = [
  { type = "R", name = "crank", at = [0.25, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true, range = [-1.5, 1.5] },
  { type = "R", name = "knee", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0] },
  { type = "S", at = [0.15, 0.0, 0.6] },
]
bodies = [ { mass = 1.2 }, { mass = 2.0 } ]
[mass]
platform = 5.0
[clearance]
knee_radial = 5e-5
knee_axial = 5e-5
crank_backlash = 2e-4
s_radial = 2e-5
[grid]
z = 0.6
psi = { start = -0.3, stop = 0.3, n = 9 }
theta = { start = -0.3, stop = 0.3, n = 9 }
"#;

fn single(name: &str) -> bool {
    ["err_", "exact_err_", "env_", "margin_"].iter().any(|p| name.starts_with(p))
}

/// Runs `text` in double and in single precision with `writer`; returns how many
/// float32 columns and values were compared.
fn check(text: &str, writer: Writer) -> (usize, usize) {
    let job = JobSpec::from_toml_str(text, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (double, narrow) = (dir.path().join("double"), dir.path().join("single"));
    let opts = |out: &Path, precision| RunOptions { chunk_size: 50, writer, precision, ..common::options(out) };
    run(&job, "t.toml", &opts(&double, Precision::Double)).unwrap();
    run(&job, "t.toml", &opts(&narrow, Precision::Single)).unwrap();
    let (a, b) = (Layout::new(&double), Layout::new(&narrow));
    let (mut columns, mut values) = (0, 0);
    for variant in 0..job.variant_count() {
        for &mode in &job.analysis.modes {
            for chunk in 0..job.sample_count().div_ceil(50) {
                let (x, y) = (read(&a.part(variant, mode, chunk)), read(&b.part(variant, mode, chunk)));
                assert_eq!(x.num_rows(), y.num_rows());
                assert_eq!(y.schema().metadata()["clearance.precision"], "single");
                for (i, field) in x.schema().fields().iter().enumerate() {
                    let (name, got) = (field.name(), y.column(i));
                    assert_eq!(y.schema().field(i).name(), name);
                    assert_eq!(y.schema().field(i).metadata(), field.metadata(), "{name}: unit");
                    if !(single(name) && field.data_type() == &DataType::Float64) {
                        assert_eq!(x.column(i).to_data(), got.to_data(), "{name}");
                        continue;
                    }
                    assert_eq!(got.data_type(), &DataType::Float32, "{name}");
                    let (d, s) = (
                        x.column(i).as_any().downcast_ref::<Float64Array>().unwrap(),
                        got.as_any().downcast_ref::<Float32Array>().unwrap(),
                    );
                    assert_eq!(d.logical_nulls(), s.logical_nulls(), "{name}: nulls");
                    for r in (0..d.len()).filter(|&r| d.is_valid(r)) {
                        assert_eq!((d.value(r) as f32).to_bits(), s.value(r).to_bits(), "{name}[{r}]");
                        values += 1;
                    }
                    columns += 1;
                }
            }
        }
    }
    for file in ["summary.parquet", "discontinuities.parquet"] {
        let (x, y) = (read(&a.root().join(file)), read(&b.root().join(file)));
        assert_eq!(x.columns(), y.columns(), "{file}");
        assert_eq!(y.schema().metadata()["clearance.precision"], "single");
    }
    (columns, values)
}

#[test]
fn three_prs_grid_with_both_writers() {
    for writer in [Writer::Engine, Writer::Arrow] {
        let (columns, values) = check(GRID, writer);
        // 11 parts, each with the per-kind, total, exact, envelope and margin columns.
        assert!(columns > 11 * 60, "{columns}");
        assert!(values > 10_000, "{values}");
    }
}

#[test]
fn six_ups_grid() {
    let (columns, values) = check(UPS, Writer::Engine);
    assert!(columns > 2 * 50 && values > 5_000, "{columns} {values}");
}

#[test]
fn custom_grid() {
    let (columns, values) = check(CUSTOM, Writer::Engine);
    assert!(columns > 2 * 30 && values > 2_000, "{columns} {values}");
}

/// `clearance check`'s size with `--precision single` counts 4 bytes for each column
/// the run writes as `float32` (8 for the others, as without it), for each kind.
#[test]
fn the_plan_counts_the_float32_columns_written() {
    for text in [GRID, UPS, CUSTOM] {
        let job = JobSpec::from_toml_str(text, "t.toml").unwrap();
        let plan = clearance_engine::plan(&job, "t.toml").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let opts = RunOptions {
            columns: clearance_engine::ColumnSet::Standard,
            precision: Precision::Single,
            ..common::options(dir.path())
        };
        run(&job, "t.toml", &opts).unwrap();
        let mode = job.analysis.modes[0];
        let part = read(&Layout::new(dir.path()).part(0, mode, 0));
        let fields = part.schema().fields().len() as u64;
        let narrow = part.schema().fields().iter().filter(|f| f.data_type() == &DataType::Float32).count() as u64;
        assert!(narrow > 30, "{narrow}");
        let standard = plan.columns.iter().find(|c| c.set == "standard").unwrap();
        assert_eq!(standard.columns as u64, fields);
        assert_eq!(standard.bytes, plan.rows * fields * 8);
        assert_eq!(standard.bytes_single, plan.rows * (fields * 8 - narrow * 4));
    }
}
