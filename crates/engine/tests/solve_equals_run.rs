//! `solve` (in memory) gives exactly the rows a run writes: same columns, same
//! values bit for bit, same nulls, for a grid with a sweep and for a trajectory
//! in both modes, and for a 6-UPS run whose part files are megabytes (written to the
//! disk on threads of their own where the file system takes direct writes).

mod common;

use arrow::array::{Array, ArrayRef, Float64Array, RecordBatch};
use arrow::compute::cast;
use arrow::datatypes::DataType;
use clearance_engine::{ColumnSet, JobSpec, Layout, RunOptions, SolveOptions, describe, run, solve};
use clearance_model::Mode;

const GRID: &str = r#"
name = "grid"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4
[grid]
z = { start = 2.0, stop = 2.1, n = 2 }
psi = { start = -0.5, stop = 0.5, n = 9 }
theta = { start = -0.6, stop = 0.6, n = 11 }
[[sweep]]
param = "mass.platform"
values = [9.8, 40.0]
"#;

const TRAJECTORY: &str = r#"
name = "trajectory"
[mass]
points = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]
[clearance]
r_radial = 1e-4
r_axial = 1e-4
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 1.25, stop = 3.75, n = 301 }
z = 2.05
psi = 0.1
theta = { offset = 0.0, harmonics = [ { amplitude = 0.5, period = 5.0, phase = 0.0 } ] }
"#;

/// A 6-UPS position grid of 9 261 poses.
const UPS: &str = r#"
name = "ups"
[mechanism]
kind = "6-UPS"
[clearance]
s_radial = 1e-4
u_radial = 1e-4
[grid]
x = { start = -0.1, stop = 0.1, n = 21 }
y = { start = -0.1, stop = 0.1, n = 21 }
z = { start = 0.7, stop = 0.8, n = 21 }
phi = 0.05
psi = 0.1
theta = -0.1
"#;

/// The poses of (variant, mode) read back from the run in `layout`, parts in order.
fn read_back(layout: &Layout, variant: u64, mode: Mode, parts: u64) -> RecordBatch {
    common::read_parts((0..parts).map(|chunk| layout.part(variant, mode, chunk)))
}

fn plain(a: &ArrayRef) -> ArrayRef {
    match a.data_type() {
        DataType::Dictionary(_, v) => cast(a, v).unwrap(),
        _ => a.clone(),
    }
}

fn assert_same(name: &str, expected: &ArrayRef, got: &ArrayRef) {
    let (expected, got) = (plain(expected), plain(got));
    assert_eq!(expected.data_type(), got.data_type(), "{name}");
    assert_eq!(expected.len(), got.len(), "{name}");
    assert_eq!(expected.logical_nulls(), got.logical_nulls(), "{name}: nulls");
    if let (Some(e), Some(g)) =
        (expected.as_any().downcast_ref::<Float64Array>(), got.as_any().downcast_ref::<Float64Array>())
    {
        for i in 0..e.len() {
            if e.is_valid(i) {
                assert_eq!(e.value(i).to_bits(), g.value(i).to_bits(), "{name}[{i}]");
            }
        }
    } else {
        assert_eq!(expected.to_data(), got.to_data(), "{name}");
    }
}

fn check(text: &str, columns: ColumnSet, chunk_size: u64) {
    check_in(&tempfile::tempdir().unwrap().path().join("run"), text, columns, chunk_size);
}

/// [`check`] with the run in `out`.
fn check_in(out: &std::path::Path, text: &str, columns: ColumnSet, chunk_size: u64) {
    check_job(out, &JobSpec::from_toml_str(text, "t.toml").unwrap(), columns, chunk_size);
}

/// [`check_in`] for a job already read.
fn check_job(out: &std::path::Path, job: &JobSpec, columns: ColumnSet, chunk_size: u64) {
    let opts = RunOptions { columns, chunk_size, direct_io: true, ..common::options(out) };
    run(job, "t.toml", &opts).unwrap();
    let layout = Layout::new(&opts.out);
    let solved = solve(job, "t.toml", &SolveOptions { columns, ..SolveOptions::default() }).unwrap();
    let parts = job.sample_count().div_ceil(chunk_size);
    let mut k = 0;
    for variant in 0..job.variant_count() {
        for &mode in &job.analysis.modes {
            let batch = &solved[k];
            k += 1;
            let written = read_back(&layout, variant, mode, parts);
            let (written_schema, solved_schema) = (written.schema(), batch.schema());
            let names: Vec<&str> = written_schema.fields().iter().map(|f| f.name().as_str()).collect();
            let mut solved_names: Vec<&str> = solved_schema.fields().iter().map(|f| f.name().as_str()).collect();
            assert_eq!(solved_names.remove(0), "variant");
            assert_eq!(solved_names, names, "same columns in the same order");
            let v = batch.column(0).as_any().downcast_ref::<arrow::array::UInt64Array>().unwrap();
            assert!(v.iter().all(|x| x == Some(variant)));
            assert_eq!(batch.num_rows(), written.num_rows());
            for (i, name) in names.iter().enumerate() {
                assert_same(
                    &format!("variant {variant} {} {name}", mode.name()),
                    written.column(i),
                    batch.column(i + 1),
                );
            }
        }
    }
    assert_eq!(k, solved.len());
}

#[test]
fn grid_with_a_sweep_in_parts_of_uneven_length() {
    check(GRID, ColumnSet::Full, 70);
}

#[test]
fn trajectory_in_both_modes() {
    check(TRAJECTORY, ColumnSet::Standard, 128);
}

/// The minimal set, which `solve` computes the totals alone for (and the whole
/// result where the exact error is asked for).
#[test]
fn minimal_columns_with_and_without_exact_errors() {
    check(GRID, ColumnSet::Minimal, 70);
    check(TRAJECTORY, ColumnSet::Minimal, 128);
    check(&format!("{GRID}\n[analysis]\nexact = true\n"), ColumnSet::Minimal, 70);
}

/// The 3-PRS and the 6-UPS as custom descriptions (`clearance describe`), which their
/// kernels solve: a run builds each block's results (8 192 poses) in the vectors of the
/// block's before it (`clearance_solver::custom::recycle`), `solve` builds every result
/// anew. Units of two and three blocks, every column of the full set.
#[test]
fn described_presets_in_units_of_several_blocks() {
    const PRS: &str = r#"
name = "prs"
[mass]
points = [ { mass = 30.0, at = [0.05, -0.02, 1.0] } ]
[clearance]
s_radial = 1e-4
r_radial = 2e-4
r_axial = 1.5e-4
r_angular = 1e-4
[grid]
z = { start = 2.0, stop = 2.1, n = 2 }
psi = { start = -0.5, stop = 0.5, n = 91 }
theta = { start = -0.5, stop = 0.5, n = 91 }
"#;
    for (text, blocks) in [(PRS, 3), (UPS, 2)] {
        let job = describe(&JobSpec::from_toml_str(text, "t.toml").unwrap(), "t.toml").unwrap();
        assert_eq!(job.sample_count().div_ceil(8192), blocks);
        let dir = tempfile::tempdir().unwrap();
        check_job(&dir.path().join("run"), &job, ColumnSet::Full, 65536);
    }
}

/// Parts of several megabytes: past the first full staging buffer (1 MiB), a direct
/// file's bytes go to the disk on a thread of its own, and the run waits for it.
#[test]
fn a_six_ups_run_whose_parts_are_megabytes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    check_in(&out, UPS, ColumnSet::Standard, 4096);
    let part = Layout::new(&out).part(0, Mode::Kinetostatic, 0);
    let bytes = std::fs::metadata(&part).unwrap().len();
    assert!(bytes > 1 << 20, "{bytes} bytes: more than one staging buffer");
}
