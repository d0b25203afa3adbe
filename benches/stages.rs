//! Per-stage throughput of the engine, in poses per second (`Throughput::Elements`).
//!
//! | group | what one element is |
//! |---|---|
//! | `kinematics/inverse` | closed-form inverse kinematics of one grid pose |
//! | `kinematics/inverse_motion` | the same with exact rates (second-order jets), one trajectory sample |
//! | `pose/<mode>/<solver>` | `solve_pose`: kinematics → A·w = b → take-up → J_P·Δq_P = J_Cl·Δq_Cl, all four kinds, one thread |
//! | `kernel/<solver>/<threads>` | the same kinetostatic kernel as `clearance bench` (blocks of 1024 samples through `solve_poses`: eight poses per call with the fast solver), spread over a rayon pool of 1 and 2 threads |
//! | `parquet/batch_standard` | `PoseSchema::batch`: one solved pose → one row of the standard columns (Arrow, nulls applied; rayon pool) |
//! | `parquet/write_standard` | `write_parquet`: one row of a 65 536-row batch → zstd Parquet on disk (one thread) |
//! | `parquet/pages_standard` | what `clearance run` does instead of the two above, part one: one solved pose → one row of the standard columns' pages, each page of `PAGE_ROWS` rows encoded (zstd) as soon as it is filled (rayon pool) |
//! | `parquet/write_part_standard` | part two, on `clearance run`'s writer thread: one row of the encoded 65 536-row part → its Parquet file on disk (the string and sample columns encoded here) |
//! | `discontinuity/grid_21x21` | `find_discontinuities` on a 21 × 21 grid (element = grid pose; includes the refinement solves) |
//! | `discontinuity/point_if_solvable` | what the search solves at a point between samples: `solve_reactions_if_solvable`, the reactions and the verdict of the conditioning, one pose of a 100 × 100 grid, one thread |
//! | `discontinuity/point_reactions` | the same without the verdict (`solve_reactions`), for comparison |
//!
//! Run: `cargo bench --bench stages` (filters: `cargo bench --bench stages -- pose/`).

mod common;

use std::hint::black_box;

use clearance_discontinuity::{SearchOptions, find_discontinuities};
use clearance_grid::{Sample, SampleSource};
use clearance_kinematics::{Geometry, inverse_kinematics, inverse_kinematics_motion};
use clearance_model::Mode;
use clearance_parquet::{Codec, ColumnSet, PartPages, PoseSchema, WriteOptions, write_parquet, write_part};
use clearance_solver::{Model, Workspace, solve_in_blocks, solve_pose, solve_reactions, solve_reactions_if_solvable};
use common::{Solve, for_each_solver};
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;

/// Poses per iteration of the single-thread stages.
const BATCH_SIDE: u64 = 100; // 100 × 100 = 10 000 grid poses
const TRAJ_SAMPLES: u64 = 10_000;
/// Poses per iteration of the threaded kernel.
const KERNEL_SIDE: u64 = 256; // 65 536 poses

fn kinematics(c: &mut Criterion) {
    let geom = Geometry::prototype();
    let grid = common::samples(&common::grid_job(BATCH_SIDE));
    let traj = common::samples(&common::trajectory_job(TRAJ_SAMPLES));
    let mut g = c.benchmark_group("kinematics");
    g.throughput(Throughput::Elements(grid.len() as u64));
    g.bench_function("inverse", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for s in &grid {
                if let Ok(p) = inverse_kinematics(&geom, black_box(s.z[0]), black_box(s.psi[0]), black_box(s.theta[0]))
                {
                    acc += p.q[0];
                }
            }
            acc
        })
    });
    g.throughput(Throughput::Elements(traj.len() as u64));
    g.bench_function("inverse_motion", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for s in &traj {
                if let Ok((p, m)) =
                    inverse_kinematics_motion(&geom, black_box(s.z), black_box(s.psi), black_box(s.theta))
                {
                    acc += p.q[0] + m.q_ddot[0];
                }
            }
            acc
        })
    });
    g.finish();
}

/// One solver variant, one mode, one thread: every sample of `samples` per
/// iteration through `solve` (a closure, so any pose entry point fits).
fn bench_pose(
    g: &mut BenchmarkGroup<'_, WallTime>,
    solver: &str,
    model: &Model,
    samples: &[Sample],
    mode: Mode,
    solve: impl Solve,
) {
    g.throughput(Throughput::Elements(samples.len() as u64));
    g.bench_function(solver, |b| {
        let mut ws = Workspace::new();
        b.iter(|| {
            let mut acc = 0.0;
            for s in samples {
                let r = solve(model, black_box(s), mode, &mut ws);
                acc += r.total.dp.z + r.errors[3].dalpha.x;
            }
            acc
        })
    });
}

fn pose(c: &mut Criterion) {
    let grid_job = common::grid_job(BATCH_SIDE);
    let grid = common::samples(&grid_job);
    let traj_job = common::trajectory_job(TRAJ_SAMPLES);
    let traj = common::samples(&traj_job);
    for (group, job, samples, mode) in
        [("pose/kinetostatic", &grid_job, &grid, Mode::Kinetostatic), ("pose/dynamic", &traj_job, &traj, Mode::Dynamic)]
    {
        let mut g = c.benchmark_group(group);
        for_each_solver(|name, setup| {
            bench_pose(&mut g, name, &common::model_for(job, setup), samples, mode, solve_pose)
        });
        g.finish();
    }
}

/// `clearance bench`'s kernel (kinetostatic, all kinds, no I/O), on 1 and 2 threads.
fn kernel(c: &mut Criterion) {
    let job = common::grid_job(KERNEL_SIDE);
    let source = SampleSource::new(&job);
    let n = source.len();
    let mut g = c.benchmark_group("kernel");
    g.sampling_mode(SamplingMode::Flat);
    g.throughput(Throughput::Elements(n));
    for_each_solver(|name, setup| {
        let model = common::model_for(&job, setup);
        for threads in [1usize, 2] {
            let pool = common::pool(threads);
            g.bench_function(BenchmarkId::new(name, format!("{threads}_threads")), |b| {
                b.iter(|| {
                    pool.install(|| {
                        solve_in_blocks(&model, &source, 0..n, Mode::Kinetostatic, 1024, |_, results| {
                            results.iter().map(|r| r.errors[0].dp.z + r.errors[3].dalpha.x).sum::<f64>()
                        })
                        .sum::<f64>()
                    })
                })
            });
        }
    });
    g.finish();
}

/// The output stage of `clearance run`: rows → Arrow batch → Parquet file, one chunk.
fn parquet(c: &mut Criterion) {
    let job = common::grid_job(KERNEL_SIDE);
    let model = Model::from_job(&job); // the engine's default solver
    let mut ws = Workspace::new();
    let rows: Vec<_> =
        common::samples(&job).into_iter().map(|s| (s, solve_pose(&model, &s, Mode::Kinetostatic, &mut ws))).collect();
    let schema = PoseSchema::new(ColumnSet::Standard, false);
    let opts = WriteOptions {
        metadata: vec![("clearance.job".into(), job.to_toml_string())],
        row_group_rows: rows.len(),
        ..WriteOptions::default()
    };
    let batch = schema.batch(Mode::Kinetostatic, &rows);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("part-kinetostatic-000000.parquet");
    let mut g = c.benchmark_group("parquet");
    g.sampling_mode(SamplingMode::Flat);
    g.throughput(Throughput::Elements(rows.len() as u64));
    g.bench_function("batch_standard", |b| b.iter(|| schema.batch(Mode::Kinetostatic, black_box(&rows))));
    g.bench_function("write_standard", |b| {
        b.iter(|| write_parquet(&path, schema.schema(), std::slice::from_ref(&batch), &opts, &[]).expect("write"))
    });
    let pages = |rows: &[(Sample, clearance_solver::PoseResult)]| -> PartPages {
        let mut part = schema.part(Mode::Kinetostatic, rows.len());
        // Pages are not all `PAGE_ROWS` long (the last ones are shorter): each takes its own rows.
        part.pages(&schema).into_par_iter().for_each_init(
            || schema.page_buffer(),
            |buf, page| {
                let rows = &rows[page.first()..page.first() + page.rows()];
                page.write(buf, Codec::Zstd, Vec::new(), |sink| {
                    for (i, (s, r)) in rows.iter().enumerate() {
                        sink.put(i, s, r);
                    }
                })
                .expect("encode a page")
            },
        );
        part
    };
    g.bench_function("pages_standard", |b| b.iter(|| pages(black_box(&rows))));
    let part = pages(&rows);
    g.bench_function("write_part_standard", |b| {
        b.iter(|| write_part(&path, &schema, &part, &opts, &[]).expect("write"))
    });
    g.finish();
}

fn discontinuity(c: &mut Criterion) {
    let job = common::grid_job(21);
    let model = Model::from_job(&job); // the engine's default solver
    let source = SampleSource::new(&job);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    let mut g = c.benchmark_group("discontinuity");
    g.throughput(Throughput::Elements(source.len()));
    g.bench_function("grid_21x21", |b| {
        b.iter(|| find_discontinuities(&model, &source, Mode::Kinetostatic, &opts).len())
    });
    let points_job = common::grid_job(BATCH_SIDE);
    let points = common::samples(&points_job);
    let model = Model::from_job(&points_job);
    g.throughput(Throughput::Elements(points.len() as u64));
    for (name, solve) in [
        ("point_if_solvable", solve_reactions_if_solvable as fn(&Model, &Sample, Mode, &mut Workspace) -> _),
        ("point_reactions", solve_reactions),
    ] {
        g.bench_function(name, |b| {
            let mut ws = Workspace::new();
            b.iter(|| {
                let mut acc = 0.0;
                for s in &points {
                    acc += solve(&model, black_box(s), Mode::Kinetostatic, &mut ws).map_or(0.0, |r| r.f_r[0].z);
                }
                acc
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = stages;
    config = common::config();
    targets = kinematics, pose, kernel, parquet, discontinuity
}
criterion_main!(stages);
