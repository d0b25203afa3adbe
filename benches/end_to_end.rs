//! End-to-end throughput, grid → Parquet on disk with the standard columns, in poses
//! per second (`Throughput::Elements`).
//!
//! | bench | what is timed |
//! |---|---|
//! | `end_to_end/library/<solver>` | the pose loop of `clearance run` rebuilt from the library crates: chunks of 65 536 samples solved on the rayon pool a page (`PAGE_ROWS` samples) at a time, each page's standard columns encoded as soon as it is filled, summary statistics, `write_part` on a writer thread overlapping the next chunk |
//! | `end_to_end/cli_run` | `target/release/clearance run JOB --out DIR --quiet` as a child process: the above plus process start, `job.toml`, the discontinuity search along every grid line, `summary.parquet` and `_SUCCESS` — what `clearance bench` calls end to end |
//!
//! Output goes to a fresh temporary directory per iteration, removed outside the timing.
//! `cli_run` uses the release binary as it is on disk: build it first with
//! `cargo build --release -p clearance-cli` (it is skipped, with a note, when missing).
//!
//! Run: `cargo bench --bench end_to_end`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::mpsc::sync_channel;

use clearance_grid::{SampleSource, chunks};
use clearance_model::{JobSpec, Mode};
use clearance_parquet::{Codec, ColumnSet, PAGE_ROWS, PartPages, PoseSchema, SummaryStats, WriteOptions, write_part};
use clearance_solver::{Blocks, Model};
use common::for_each_solver;
use criterion::{BatchSize, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;

/// Poses per iteration: 362² = 131 044, two part files of `CHUNK`.
const LIB_SIDE: u64 = 362;
const CHUNK: u64 = 65_536;
/// Poses per iteration of the child-process run: 200² = 40 000.
const CLI_SIDE: u64 = 200;

/// Grid → poses part files (standard columns) in `out`, as `clearance run` does.
fn run_poses(job: &JobSpec, model: &Model, source: &SampleSource, schema: &PoseSchema, out: &Path) {
    let opts = WriteOptions {
        metadata: vec![("clearance.job".into(), job.to_toml_string())],
        row_group_rows: CHUNK as usize,
        ..WriteOptions::default()
    };
    let dir = out.join("poses").join("variant=0");
    std::fs::create_dir_all(&dir).expect("create the output directory");
    let mut total = SummaryStats::default();
    std::thread::scope(|scope| {
        let (tx, rx) = sync_channel::<(PathBuf, PartPages)>(1);
        let opts = &opts;
        let writer = scope.spawn(move || {
            for (path, part) in rx {
                write_part(&path, schema, &part, opts, &[]).expect("write a part file");
            }
        });
        for (k, range) in chunks(source.len(), CHUNK).enumerate() {
            let mut part = schema.part(Mode::Kinetostatic, (range.end - range.start) as usize);
            let stats: Vec<SummaryStats> = part
                .pages(schema)
                .into_par_iter()
                .enumerate()
                .map_init(
                    || (Blocks::default(), schema.page_buffer()),
                    |(blocks, buf), (p, page)| {
                        let first = range.start + (p * PAGE_ROWS) as u64;
                        let len = page.rows() as u64;
                        page.write(buf, Codec::Zstd, Vec::new(), |sink| {
                            let (samples, results) =
                                blocks.solve(model, source, first..first + len, Mode::Kinetostatic);
                            let mut stats = SummaryStats::with_capacity(samples.len());
                            for (i, (s, r)) in samples.iter().zip(results).enumerate() {
                                sink.put(i, s, r);
                                stats.push(r);
                            }
                            stats
                        })
                        .expect("encode a page")
                    },
                )
                .collect();
            for s in &stats {
                total.merge(s);
            }
            tx.send((dir.join(format!("part-kinetostatic-{k:06}.parquet")), part)).expect("the writer is alive");
        }
        drop(tx);
        writer.join().expect("the writer does not panic");
    });
    std::hint::black_box(total);
}

fn library(c: &mut Criterion) {
    let job = common::grid_job(LIB_SIDE);
    let source = SampleSource::new(&job);
    let schema = PoseSchema::new(ColumnSet::Standard, false);
    let mut g = c.benchmark_group("end_to_end/library");
    g.sampling_mode(SamplingMode::Flat);
    g.throughput(Throughput::Elements(source.len()));
    for_each_solver(|name, setup| {
        let model = common::model_for(&job, setup);
        g.bench_function(name, |b| {
            b.iter_batched(
                || tempfile::tempdir().expect("a temporary directory"),
                |tmp| {
                    run_poses(&job, &model, &source, &schema, tmp.path());
                    tmp // removed after the timing
                },
                BatchSize::PerIteration,
            )
        });
    });
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
