//! A custom mechanism's samples are solved in aligned runs of 64, each continued from
//! the one before (docs/model.md §12.2), and the switch search takes the samples'
//! loads from the pose pass when this process computed them all. Neither may show:
//! a run in parts of 37 samples (runs cut mid-way), in three shards (the last one
//! solves the search's table itself) and in one part give the same poses and
//! switches, bit for bit, and the same summary (its sums merged part by part) to
//! round-off, on a grid and on a trajectory in both modes. A part is solved a block
//! of 8 192 samples at a time (its columns, statistics and search table built block
//! by block): a part of several blocks gives the same as parts of one.

mod common;

use std::path::Path;

use arrow::array::{Float64Array, RecordBatch};
use clearance_engine::{JobSpec, Layout, RunOptions, run};
use common::{read, read_parts};

const TRAJECTORY: &str = r#"
[analysis]
modes = ["kinetostatic", "dynamic"]

[trajectory]
time = { start = 0.0, stop = 4.0, n = 301 }
z = { offset = 0.6, harmonics = [ { amplitude = 0.03, period = 2.0, phase = 0.0 } ] }
psi = { offset = 0.0, harmonics = [ { amplitude = 0.25, period = 1.7, phase = 0.4 } ] }
theta = { offset = 0.0, harmonics = [ { amplitude = 0.3, period = 2.3, phase = 0.0 } ] }
"#;

/// The 3-RRS wrist of `jobs/`, its grid made smaller, or its grid replaced by `trajectory`.
fn job(trajectory: Option<&str>) -> JobSpec {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml")).unwrap();
    let text = match trajectory {
        None => text.replace("n = 61", "n = 23"),
        Some(t) => format!("{}{t}", &text[..text.find("[grid]").unwrap()]),
    };
    JobSpec::from_toml_str(&text, "job.toml").unwrap()
}

fn options(out: &Path, chunk: u64, shard: Option<(u64, u64)>) -> RunOptions {
    RunOptions { chunk_size: chunk, shard, ..common::options(out) }
}

/// Every mode's part files, in order, one batch per mode.
fn poses(dir: &Path, job: &JobSpec, chunk: u64) -> Vec<RecordBatch> {
    let layout = Layout::new(dir);
    let chunks = job.sample_count().div_ceil(chunk);
    job.analysis.modes.iter().map(|&m| read_parts((0..chunks).map(|c| layout.part(0, m, c)))).collect()
}

/// The summary merges each part's sums: in other parts, the same to round-off (1e-12
/// of each value), every count and every other column equal.
fn summaries_agree(a: &RecordBatch, b: &RecordBatch) {
    assert_eq!(a.schema(), b.schema());
    for (i, field) in a.schema().fields().iter().enumerate() {
        let (x, y) = (a.column(i), b.column(i));
        match (x.as_any().downcast_ref::<Float64Array>(), y.as_any().downcast_ref::<Float64Array>()) {
            (Some(x), Some(y)) => {
                for (u, v) in x.iter().zip(y.iter()) {
                    let (u, v) = (u.unwrap_or(f64::NAN), v.unwrap_or(f64::NAN));
                    let close = (u.is_nan() && v.is_nan()) || u == v || (u - v).abs() <= 1e-12 * u.abs().max(v.abs());
                    assert!(close, "summary column {}: {u} against {v}", field.name());
                }
            }
            _ => assert_eq!(x, y, "summary column {}", field.name()),
        }
    }
}

fn same_every_way(job: &JobSpec) {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole");
    run(job, "job.toml", &options(&whole, 65536, None)).unwrap();
    let expected = poses(&whole, job, 65536);
    let switches = read(&whole.join("discontinuities.parquet"));
    assert!(switches.num_rows() > 0, "no switch to compare");
    let small = dir.path().join("small");
    run(job, "job.toml", &options(&small, 37, None)).unwrap();
    let sharded = dir.path().join("sharded");
    for i in 0..3 {
        run(job, "job.toml", &options(&sharded, 37, Some((i, 3)))).unwrap();
    }
    for other in [&small, &sharded] {
        assert_eq!(poses(other, job, 37), expected, "poses of {}", other.display());
        let file = "discontinuities.parquet";
        assert_eq!(read(&other.join(file)), read(&whole.join(file)), "{file} of {}", other.display());
        summaries_agree(&read(&other.join("summary.parquet")), &read(&whole.join("summary.parquet")));
    }
}

#[test]
fn a_grid_gives_the_same_bits_in_any_parts() {
    same_every_way(&job(None));
}

#[test]
fn a_trajectory_in_both_modes_gives_the_same_bits_in_any_parts() {
    same_every_way(&job(Some(TRAJECTORY)));
}

#[test]
fn a_part_of_several_blocks_gives_the_same_bits_as_parts_of_one() {
    // 2 × 8 192 + 517 samples: whole, one part of three blocks (the last partial);
    // in parts of 4 000, each within one block or across a block's end.
    let long = TRAJECTORY.replace("n = 301", "n = 16901").replace(r#"["kinetostatic", "dynamic"]"#, r#"["dynamic"]"#);
    let job = job(Some(&long));
    assert_eq!(job.sample_count(), 16_901);
    let dir = tempfile::tempdir().unwrap();
    let (whole, parts) = (dir.path().join("whole"), dir.path().join("parts"));
    run(&job, "job.toml", &options(&whole, 65536, None)).unwrap();
    run(&job, "job.toml", &options(&parts, 4000, None)).unwrap();
    assert_eq!(poses(&parts, &job, 4000), poses(&whole, &job, 65536));
    let switches = read(&whole.join("discontinuities.parquet"));
    assert!(switches.num_rows() > 0, "no switch to compare");
    assert_eq!(read(&parts.join("discontinuities.parquet")), switches);
    summaries_agree(&read(&parts.join("summary.parquet")), &read(&whole.join("summary.parquet")));
}
