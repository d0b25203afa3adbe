//! Sharded runs without a serial tail: each shard searches the grid lines it owns
//! and writes their switches; the step that finishes the run only merges them.
//! The switches (and every other file) equal a single run's, bit for bit, and the
//! finishing step reads no other shard's traces.

mod common;

use std::path::Path;

use clearance_engine::{JobSpec, Layout, RunOptions, run};
use common::read;

/// A 3-D grid of the prototype with a point mass, all four kinds: switches of every
/// kind along Z, Ψ and Θ lines, in parts of 500 samples, so that lines of every
/// axis cross parts (and shards).
const GRID_3D: &str = r#"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
r_angular = 1e-4

[mass]
points = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]

[grid]
z = { start = 1.95, stop = 2.15, n = 4 }
psi = { start = -0.5, stop = 0.5, n = 31 }
theta = { start = -0.5, stop = 0.5, n = 29 }
"#;

/// A trajectory in both modes: one path across every part.
const TRAJECTORY: &str = r#"
[clearance]
r_radial = 1e-4
r_axial = 1e-4

[mass]
points = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]

[analysis]
modes = ["kinetostatic", "dynamic"]

[trajectory]
time = { start = 0.0, stop = 10.0, n = 2001 }
z = { offset = 2.05, harmonics = [ { amplitude = 0.05, period = 2.5, phase = 0.0 } ] }
psi = { offset = 0.0, harmonics = [ { amplitude = 0.3, period = 3.3, phase = 0.5 } ] }
theta = { offset = 0.0, harmonics = [ { amplitude = 0.5, period = 2.1, phase = 0.0 } ] }
"#;

const CHUNK: u64 = 500;

fn options(out: &Path, shard: Option<(u64, u64)>, resume: bool) -> RunOptions {
    RunOptions { chunk_size: CHUNK, shard, resume, ..common::options(out) }
}

/// `text`'s job, run alone into `single` under a fresh directory (kept while the
/// directory lives), and the path `sharded` beside it for its shards.
fn single_run(text: &str) -> (JobSpec, tempfile::TempDir, std::path::PathBuf, std::path::PathBuf) {
    let job = JobSpec::from_toml_str(text, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (single, sharded) = (dir.path().join("single"), dir.path().join("sharded"));
    run(&job, "t.toml", &options(&single, None, false)).unwrap();
    (job, dir, single, sharded)
}

fn same_finals(a: &Path, b: &Path) {
    for file in ["discontinuities.parquet", "summary.parquet"] {
        assert_eq!(read(&a.join(file)), read(&b.join(file)), "{file}");
    }
}

/// Every trace file of the run's parts.
fn trace_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for v in std::fs::read_dir(dir.join("_stats")).unwrap() {
        let v = v.unwrap().path();
        if v.is_dir() {
            for f in std::fs::read_dir(&v).unwrap() {
                let f = f.unwrap().path();
                if f.extension().is_some_and(|e| e == "trace4") {
                    out.push(f);
                }
            }
        }
    }
    out
}

/// Runs `text` alone and in `n` shards one after another, removing every trace file
/// before the last shard: its finishing step must merge, not search (a search from
/// traces would solve the lost ones again and write them back).
fn sharded_equals_single(text: &str, n: u64) {
    let (job, _dir, single, sharded) = single_run(text);
    for i in 0..n - 1 {
        let report = run(&job, "t.toml", &options(&sharded, Some((i, n)), false)).unwrap();
        assert!(!report.complete);
        assert!(Layout::new(&sharded).shard_switches(i, n).exists(), "shard {i} wrote its switches");
    }
    let before = trace_files(&sharded);
    assert!(!before.is_empty());
    for f in &before {
        std::fs::remove_file(f).unwrap();
    }
    let report = run(&job, "t.toml", &options(&sharded, Some((n - 1, n)), false)).unwrap();
    assert!(report.complete);
    let rebuilt: Vec<_> = trace_files(&sharded).into_iter().filter(|f| before.contains(f)).collect();
    assert!(rebuilt.is_empty(), "the finishing step searched again from traces: {rebuilt:?}");
    same_finals(&single, &sharded);
    let switches = read(&single.join("discontinuities.parquet")).num_rows();
    assert!(switches > 0, "no switch to compare");
}

#[test]
fn a_3d_grid_in_8_shards_gives_the_single_runs_switches() {
    sharded_equals_single(GRID_3D, 8);
}

#[test]
fn a_trajectory_in_3_shards_gives_the_single_runs_switches() {
    sharded_equals_single(TRAJECTORY, 3);
}

/// Shards run in any order, as a cluster's do: more shards than parts, so that some
/// own none, started last first into a fresh directory. A shard that owns nothing
/// still writes its (empty) switches, into a directory no other shard has made yet;
/// the one that finishes the run gives the single run's files.
#[test]
fn shards_without_parts_run_first_and_the_run_is_the_single_one() {
    let (job, _dir, single, sharded) = single_run(GRID_3D);
    let parts = job.sample_count().div_ceil(CHUNK);
    let n = parts + 3;
    let mut complete = Vec::new();
    for i in (0..n).rev() {
        let report = run(&job, "t.toml", &options(&sharded, Some((i, n)), false))
            .unwrap_or_else(|e| panic!("shard {i} of {n} ({parts} parts): {e}"));
        assert!(Layout::new(&sharded).shard_switches(i, n).exists(), "shard {i} wrote its switches");
        complete.push(report.complete);
    }
    assert_eq!(complete.iter().filter(|&&c| c).count(), 1, "one shard finishes the run: {complete:?}");
    assert!(complete[complete.len() - 1], "the last shard to run finishes it");
    same_finals(&single, &sharded);
}

/// A shard that starts while another is writing the job file into the fresh
/// directory (its temporary sibling there, nothing else) takes the run as its own,
/// as the cluster's shards all start together; a run without `--shard` still refuses
/// a directory that holds anything but a run.
#[test]
fn a_shard_takes_a_directory_whose_job_file_another_shard_is_writing() {
    let (job, _dir, single, sharded) = single_run(TRAJECTORY);
    std::fs::create_dir_all(&sharded).unwrap();
    let in_flight = sharded.join(".job.toml.tmp-4000000");
    std::fs::write(&in_flight, "name = \"t").unwrap();
    let alone = run(&job, "t.toml", &options(&sharded, None, false)).expect_err("a run alone refuses the directory");
    assert!(alone.to_string().contains("is not empty"), "{alone}");
    for i in 0..3 {
        run(&job, "t.toml", &options(&sharded, Some((i, 3)), false))
            .unwrap_or_else(|e| panic!("shard {i} beside another's job file: {e}"));
        // The other shard's write lands (a rename over the same file): the run goes on.
        if i == 0 {
            std::fs::remove_file(&in_flight).unwrap();
        }
    }
    same_finals(&single, &sharded);
}

/// Parts are named by their chunk's number, so a shard or a resumed run cut with
/// another `--chunk-size` than the run's first would keep or merge files of other
/// samples under those names: it is refused (exit 2's kind of error, naming the
/// part and both lengths), and the run goes on with its own size to the single run's
/// files. A job whose samples fit in one chunk either way is cut the same.
#[test]
fn another_chunk_size_is_refused_where_it_would_cut_other_parts() {
    let (job, dir, single, sharded) = single_run(GRID_3D);
    let cut = |out: &Path, chunk: u64, shard: Option<(u64, u64)>, resume: bool| RunOptions {
        chunk_size: chunk,
        ..options(out, shard, resume)
    };
    run(&job, "t.toml", &options(&sharded, Some((0, 2)), false)).unwrap();
    for (shard, resume) in [(Some((1, 2)), false), (None, true)] {
        let e = run(&job, "t.toml", &cut(&sharded, CHUNK + 200, shard, resume))
            .expect_err("another chunk size cuts other parts");
        assert!(e.is_usage(), "{e}");
        let text = e.to_string();
        assert!(text.contains("--chunk-size 700") && text.contains("has 500 samples"), "{text}");
    }
    let report = run(&job, "t.toml", &options(&sharded, Some((1, 2)), false)).unwrap();
    assert!(report.complete);
    same_finals(&single, &sharded);
    // Within one chunk either way: the same cutting.
    let (alone, whole) = (dir.path().join("alone"), dir.path().join("whole"));
    let n = job.sample_count();
    run(&job, "t.toml", &cut(&alone, n, None, false)).unwrap();
    run(&job, "t.toml", &cut(&whole, n, Some((0, 1)), false)).unwrap();
    assert!(run(&job, "t.toml", &cut(&whole, 2 * n, None, true)).unwrap().complete);
    same_finals(&alone, &whole);
}

/// A shard re-run with `--resume` searches its lines again; a shard file lost after
/// every shard is done, or a sharded run finished by a resumed run without shards,
/// falls back to the search from the traces: the same switches every way.
#[test]
fn resumed_and_lost_shard_files_give_the_same_switches() {
    let (job, _dir, single, sharded) = single_run(GRID_3D);
    let layout = Layout::new(&sharded);
    for i in 0..4 {
        run(&job, "t.toml", &options(&sharded, Some((i, 4)), false)).unwrap();
    }
    same_finals(&single, &sharded);

    // Shard 1 loses a part and its switches; re-run with --resume, it finishes the run.
    std::fs::remove_file(layout.shard_switches(1, 4)).unwrap();
    std::fs::remove_file(layout.shard_marker(1, 4)).unwrap();
    std::fs::remove_file(layout.success()).unwrap();
    let mode = job.analysis.modes[0];
    std::fs::remove_file(layout.part(0, mode, 1)).unwrap();
    std::fs::remove_file(layout.discontinuities()).unwrap();
    run(&job, "t.toml", &options(&sharded, Some((1, 4)), true)).unwrap();
    assert!(layout.success().exists());
    same_finals(&single, &sharded);

    // A shard file lost after the fact: the last shard re-run searches from traces.
    std::fs::remove_file(layout.shard_switches(2, 4)).unwrap();
    std::fs::remove_file(layout.success()).unwrap();
    std::fs::remove_file(layout.discontinuities()).unwrap();
    run(&job, "t.toml", &options(&sharded, Some((3, 4)), true)).unwrap();
    same_finals(&single, &sharded);

    // Finished by a resumed run without shards.
    std::fs::remove_file(layout.success()).unwrap();
    std::fs::remove_file(layout.discontinuities()).unwrap();
    run(&job, "t.toml", &options(&sharded, None, true)).unwrap();
    same_finals(&single, &sharded);
}
