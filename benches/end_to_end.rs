//! End-to-end throughput, grid → Parquet on disk with the standard columns, in poses
//! per second (`Throughput::Elements`).
//!
//! | bench | what is timed |
//! |---|---|
//! | `end_to_end/library/<solver>` | `clearance_engine::run` in process: chunks of 65 536 samples solved on the rayon pool a page at a time, each page's standard columns encoded as soon as it is filled, part files on a writer thread, the discontinuity search along every grid line, `summary.parquet` and `_SUCCESS` |
//! | `end_to_end/cli_run` | `target/release/clearance run JOB --out DIR --quiet` as a child process: the above plus process start — what `clearance bench` calls end to end |
//!
//! Output goes to a fresh temporary directory per iteration, removed outside the timing.
//! `cli_run` uses the release binary as it is on disk: build it first with
//! `cargo build --release -p clearance-cli` (it is skipped, with a note, when missing).
//!
//! Run: `cargo bench --bench end_to_end`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use clearance_engine::{Codec, ColumnSet, JobSpec, Reporter, RunOptions, SolverKind, Writer, run};
use criterion::{BatchSize, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};

/// Poses per iteration: 362² = 131 044, two part files of `CHUNK`.
const LIB_SIDE: u64 = 362;
const CHUNK: u64 = 65_536;
/// Poses per iteration of the child-process run: 200² = 40 000.
const CLI_SIDE: u64 = 200;

/// The job run into `out` by the engine, in process, as `clearance run` does.
fn run_job(job: &JobSpec, solver: SolverKind, out: &Path) {
    let opts = RunOptions {
        out: out.join("out"),
        columns: ColumnSet::Standard,
        shard: None,
        resume: false,
        overwrite: false,
        chunk_size: CHUNK,
        solver,
        compression: Codec::Zstd,
        writer: Writer::Engine,
        precision: clearance_engine::Precision::Double,
        progress: Reporter::default(),
        direct_io: true,
        search: true,
        poses: true,
    };
    let report = run(job, "bench.toml", &opts).expect("the run succeeds");
    std::hint::black_box(report);
}

fn library(c: &mut Criterion) {
    let job = common::grid_job(LIB_SIDE);
    let mut g = c.benchmark_group("end_to_end/library");
    g.sampling_mode(SamplingMode::Flat);
    g.throughput(Throughput::Elements(job.sample_count()));
    for (name, solver) in [("general", SolverKind::General), ("fast", SolverKind::Fast)] {
        g.bench_function(name, |b| {
            b.iter_batched(
                || tempfile::tempdir().expect("a temporary directory"),
                |tmp| {
                    run_job(&job, solver, tmp.path());
                    tmp // removed after the timing
                },
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

fn release_binary() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target"));
    target.join("release").join("clearance")
}

fn cli_run(c: &mut Criterion) {
    let bin = release_binary();
    if !bin.exists() {
        eprintln!("end_to_end/cli_run: skipped, {} is missing (cargo build --release -p clearance-cli)", bin.display());
        return;
    }
    let job = common::grid_job(CLI_SIDE);
    let jobdir = tempfile::tempdir().expect("a temporary directory");
    let job_path = jobdir.path().join("bench.toml");
    std::fs::write(&job_path, job.to_toml_string()).expect("write the job");
    let mut g = c.benchmark_group("end_to_end");
    g.sampling_mode(SamplingMode::Flat);
    g.throughput(Throughput::Elements(job.sample_count()));
    g.bench_function("cli_run", |b| {
        b.iter_batched(
            || tempfile::tempdir().expect("a temporary directory"),
            |tmp| {
                let out = tmp.path().join("out");
                let status = Command::new(&bin)
                    .arg("run")
                    .arg(&job_path)
                    .arg("--out")
                    .arg(&out)
                    .arg("--quiet")
                    .status()
                    .expect("start clearance");
                assert!(status.success(), "clearance run failed: {status}");
                tmp
            },
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group! {
    name = end_to_end;
    config = common::config();
    targets = library, cli_run
}
criterion_main!(end_to_end);
