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
    let mut model = Model::from_job(job);
    model.solver = solver;
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

/// Kinetostatic 6-UPS poses per second on the current rayon pool: the default
/// platform over a small box of positions and orientations, all three kinds, the
/// estimate `clearance check` gives for a 6-UPS job.
pub fn ups_kernel_rate(poses: usize) -> f64 {
    use clearance_solver::ups::{UpsModel, UpsResult, solve_ups_par, statics_sample};
    let mut model = UpsModel::default();
    model.set_clearance([1e-4, 1e-4, 1e-4]);
    let samples: Vec<_> = (0..poses.max(1))
        .map(|i| {
            let f = i as f64 / poses.max(1) as f64;
            statics_sample([0.02 * f, -0.01 * f, 0.7 + 0.05 * f, 0.1 * f, 0.05 * f, -0.05 * f])
        })
        .collect();
    let mut out = vec![UpsResult::default(); samples.len()];
    let start = Instant::now();
    solve_ups_par(&model, &samples, Mode::Kinetostatic, 64, &mut out);
    let secs = start.elapsed().as_secs_f64();
    std::hint::black_box(&out);
    samples.len() as f64 / secs
}
