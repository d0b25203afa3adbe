//! The engine's page encoder (`Writer::Engine`) and `parquet`'s `ArrowWriter`
//! (`Writer::Arrow`) write the same table: read back with the `parquet` crate's
//! Arrow reader, the same schema (names, types, nullability, units, the run's
//! metadata), the same row count and every column's values bit for bit, nulls
//! included, on jobs with unreachable poses, for a grid with a sweep cut into
//! parts with short tail pages and a trajectory in both modes. The files the
//! writer does not choose (`summary.parquet`, `discontinuities.parquet`) are the
//! same bytes.

mod common;

use std::fs::File;
use std::path::Path;

use arrow::array::{Array, ArrayRef, Float64Array, StringArray};
use clearance_engine::{Codec, ColumnSet, JobSpec, Layout, RunOptions, Writer, run};
use common::read;
use parquet::file::reader::{FileReader, SerializedFileReader};

/// The prototype tilted far enough that legs cannot reach their rails.
const GRID: &str = r#"
name = "writers_grid"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4
[grid]
z = { start = 2.0, stop = 2.1, n = 2 }
psi = { start = -1.4, stop = 1.4, n = 37 }
theta = { start = -1.4, stop = 1.4, n = 41 }
[[sweep]]
param = "mass.platform"
values = [9.8, 40.0]
"#;

/// A 3-RPS rising past its longest leg and back, in kinetostatics and dynamics.
const TRAJECTORY: &str = r#"
name = "writers_trajectory"
[mechanism]
kind = "3-RPS"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 0.0, stop = 4.0, n = 5001 }
z = { offset = 1.3, harmonics = [ { amplitude = 0.45, period = 4.0, phase = 0.0 } ] }
psi = 0.1
theta = { offset = 0.0, harmonics = [ { amplitude = 0.3, period = 2.0, phase = 0.0 } ] }
"#;

/// A 6-UPS grid, in parts of 50 samples.
const UPS: &str = r#"
name = "writers_ups"
[mechanism]
kind = "6-UPS"
[clearance]
s_radial = 1e-4
u_radial = 1e-4
[grid]
x = { start = -0.15, stop = 0.15, n = 9 }
y = { start = -0.15, stop = 0.15, n = 9 }
z = 0.7
phi = 0.05
psi = 0.1
theta = -0.1
"#;

fn run_with(job: &JobSpec, out: &Path, columns: ColumnSet, chunk_size: u64, codec: Codec, writer: Writer) {
    let opts = RunOptions { columns, chunk_size, compression: codec, writer, direct_io: true, ..common::options(out) };
    run(job, "t.toml", &opts).unwrap();
}

fn assert_same_column(name: &str, expected: &ArrayRef, got: &ArrayRef) {
    assert_eq!(expected.data_type(), got.data_type(), "{name}");
    assert_eq!(expected.len(), got.len(), "{name}");
    assert_eq!(expected.logical_nulls(), got.logical_nulls(), "{name}: nulls");
    match (expected.as_any().downcast_ref::<Float64Array>(), got.as_any().downcast_ref::<Float64Array>()) {
        (Some(e), Some(g)) => {
            for i in (0..e.len()).filter(|&i| e.is_valid(i)) {
                assert_eq!(e.value(i).to_bits(), g.value(i).to_bits(), "{name}[{i}]");
            }
        }
        _ => assert_eq!(expected.to_data(), got.to_data(), "{name}"),
    }
}

/// Runs `text` with both writers and compares what they wrote; returns the rows
/// compared and how many were not `ok`.
fn check(text: &str, columns: ColumnSet, chunk_size: u64, codec: Codec) -> (usize, usize) {
    let job = JobSpec::from_toml_str(text, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (engine, arrow) = (dir.path().join("engine"), dir.path().join("arrow"));
    run_with(&job, &engine, columns, chunk_size, codec, Writer::Engine);
    run_with(&job, &arrow, columns, chunk_size, codec, Writer::Arrow);
    let (a, b) = (Layout::new(&engine), Layout::new(&arrow));
    let (mut rows, mut not_ok) = (0, 0);
    let parts = job.sample_count().div_ceil(chunk_size);
    for variant in 0..job.variant_count() {
        for &mode in &job.analysis.modes {
            for chunk in 0..parts {
                let (pa, pb) = (a.part(variant, mode, chunk), b.part(variant, mode, chunk));
                let (ea, eb) = (read(&pa), read(&pb));
                let what = format!("{columns:?} {codec:?} variant {variant} {} part {chunk}", mode.name());
                assert_eq!(ea.schema(), eb.schema(), "{what}: schema");
                assert_eq!(ea.num_rows(), eb.num_rows(), "{what}: rows");
                for (i, field) in ea.schema().fields().iter().enumerate() {
                    assert_same_column(&format!("{what} {}", field.name()), ea.column(i), eb.column(i));
                }
                rows += ea.num_rows();
                let status = ea.column_by_name("status").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
                not_ok += status.iter().filter(|s| *s != Some("ok")).count();
                // Both are one row group with the run's key-value metadata.
                let [ma, mb] = [&pa, &pb].map(|p| SerializedFileReader::new(File::open(p).unwrap()).unwrap());
                assert_eq!(ma.metadata().num_row_groups(), 1, "{what}");
                assert_eq!(mb.metadata().num_row_groups(), 1, "{what}");
                let kv = |r: &SerializedFileReader<File>| r.metadata().file_metadata().key_value_metadata().cloned();
                assert_eq!(kv(&ma), kv(&mb), "{what}: key-value metadata");
            }
        }
    }
    for [x, y] in [
        [a.root().join("summary.parquet"), b.root().join("summary.parquet")],
        [a.root().join("discontinuities.parquet"), b.root().join("discontinuities.parquet")],
    ] {
        assert_eq!(std::fs::read(&x).unwrap(), std::fs::read(&y).unwrap(), "{}", x.display());
    }
    (rows, not_ok)
}

#[test]
fn a_grid_with_unreachable_poses_in_parts_of_uneven_length() {
    for (columns, codec) in [(ColumnSet::Full, Codec::Zstd), (ColumnSet::Minimal, Codec::None)] {
        let (rows, not_ok) = check(GRID, columns, 1000, codec);
        assert_eq!(rows, 2 * 2 * 37 * 41);
        assert!(not_ok > 100 && not_ok < rows / 2, "{not_ok} of {rows} rows not ok");
    }
}

#[test]
fn a_trajectory_in_both_modes_past_the_stroke() {
    let (rows, not_ok) = check(TRAJECTORY, ColumnSet::Standard, 4096, Codec::Lz4);
    assert_eq!(rows, 2 * 5001);
    assert!(not_ok > 100 && not_ok < rows / 2, "{not_ok} of {rows} rows not ok");
}

/// A 6-UPS's parts are built as record batches, a custom mechanism's encoded a page at
/// a time as its blocks of rows are solved: `--writer` chooses their encoder too, and
/// both write the same table. The larger custom grid's parts of 10 000 rows hold pages
/// whose rows come from two blocks (blocks are aligned on the samples, pages on the
/// part) and a short last page.
#[test]
fn a_6ups_grid_and_a_custom_mechanism() {
    let (rows, _) = check(UPS, ColumnSet::Full, 50, Codec::Zstd);
    assert_eq!(rows, 81);
    let custom =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml")).unwrap();
    let (rows, _) = check(&custom.replace("n = 61", "n = 11"), ColumnSet::Standard, 40, Codec::Lz4);
    assert_eq!(rows, 121);
    let (rows, _) = check(&custom.replace("n = 61", "n = 151"), ColumnSet::Full, 10_000, Codec::Zstd);
    assert_eq!(rows, 151 * 151);
}
