//! The kernel's throughput on this machine: what `clearance bench` and the time
//! estimate of `clearance check` measure.

use std::time::Instant;

use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, SolverKind, solve_in_blocks};
use rayon::prelude::*;

/// The benchmark job: the paper's prototype at Z = 2.05 over Ψ, Θ ∈ [−0.5, 0.5]
/// on a square grid of at least `poses` poses, all four clearance kinds,
/// kinetostatics.
pub fn bench_job(poses: u64) -> JobSpec {
    let side = ((poses as f64).sqrt().ceil() as u64).max(2);
    let text = format!(
        "name = \"bench\"\n[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
         [grid]\nz = 2.05\npsi = {{ start = -0.5, stop = 0.5, n = {side} }}\ntheta = {{ start = -0.5, stop = 0.5, n = {side} }}\n"
    );
    JobSpec::from_toml_str(&text, "bench.toml").expect("the bench job is valid")
}

/// Kinetostatic pose → reactions → take-up → error, all kinds, no I/O, over the
/// job's samples (as written, before sweeps) on the current rayon pool. Poses/s.
pub fn kernel_rate(job: &JobSpec, solver: SolverKind) -> f64 {
    kernel_rate_with(job, solver, false)
}

/// [`kernel_rate`], with the worst-case envelope and the dominant joint as well when
/// `envelope` (what the standard columns and the summary need): the work a run with
/// those columns does per pose, without its I/O.
pub fn kernel_rate_with(job: &JobSpec, solver: SolverKind, envelope: bool) -> f64 {
    let mut model = Model::from_job(job);
    model.solver = solver;
    model.envelope = envelope;
    let source = SampleSource::new(job);
    let n = source.len();
    let start = Instant::now();
    let checksum: f64 = solve_in_blocks(&model, &source, 0..n, Mode::Kinetostatic, 1024, |_, results| {
        results.iter().map(|r| r.errors[0].dp.z + r.errors[3].dalpha.x).sum::<f64>()
    })
    .sum();
    let secs = start.elapsed().as_secs_f64();
    std::hint::black_box(checksum);
    n as f64 / secs
}
