//! Jobs and helpers shared by the criterion benches (`stages`, `end_to_end`).

#![allow(dead_code)]

use std::time::Duration;

use clearance_grid::{Sample, SampleSource};
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, PoseResult, SolverKind, Workspace};
use criterion::Criterion;

/// One pose through a solver: the signature of `clearance_solver::solve_pose`.
pub trait Solve: Fn(&Model, &Sample, Mode, &mut Workspace) -> PoseResult + Sync {}
impl<F: Fn(&Model, &Sample, Mode, &mut Workspace) -> PoseResult + Sync> Solve for F {}

/// The solver variants every pose bench runs: a name and a closure that sets the
/// variant up on the job's `Model`. Another variant is one more line here.
pub fn for_each_solver(mut f: impl FnMut(&'static str, &dyn Fn(&mut Model))) {
    f("general", &|m| m.solver = SolverKind::General);
    f("fast", &|m| m.solver = SolverKind::Fast);
}

/// The job's model set up for one solver variant.
pub fn model_for(job: &JobSpec, setup: &dyn Fn(&mut Model)) -> Model {
    let mut model = Model::from_job(job);
    setup(&mut model);
    model
}

/// Short runs: the whole `cargo bench` stays within a few minutes on 2 cores.
/// Command-line flags (`--measurement-time`, `--sample-size`...) still override.
pub fn config() -> Criterion {
    Criterion::default().sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3))
}

/// `clearance bench`'s job: the prototype at Z = 2.05 over Ψ, Θ ∈ [−0.5, 0.5] on a
/// `side × side` grid, all four clearance kinds at 1e-4, kinetostatics.
pub fn grid_job(side: u64) -> JobSpec {
    let text = format!(
        "name = \"bench\"\n[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
         [grid]\nz = 2.05\npsi = {{ start = -0.5, stop = 0.5, n = {side} }}\ntheta = {{ start = -0.5, stop = 0.5, n = {side} }}\n"
    );
    JobSpec::from_toml_str(&text, "bench.toml").expect("the bench job is valid")
}

/// A trajectory with rates in every input (Fig. 13's Θ(t) plus a Ψ and a Z swing),
/// all four clearance kinds, dynamics.
pub fn trajectory_job(n: u64) -> JobSpec {
    let text = format!(
        "name = \"bench_dyn\"\n[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
         [analysis]\nmodes = [\"dynamic\"]\n\
         [trajectory]\ntime = {{ start = 0.0, stop = 10.0, n = {n} }}\n\
         z = {{ offset = 2.05, harmonics = [ {{ amplitude = 0.05, period = 4.0, phase = 0.0 }} ] }}\n\
         psi = {{ offset = 0.0, harmonics = [ {{ amplitude = 0.3, period = 3.0, phase = 0.5 }} ] }}\n\
         theta = {{ offset = 0.0, harmonics = [ {{ amplitude = 0.5, period = 5.0, phase = 0.0 }} ] }}\n"
    );
    JobSpec::from_toml_str(&text, "bench_dyn.toml").expect("the trajectory job is valid")
}

/// Every sample of a job, materialised once outside the timed loop.
pub fn samples(job: &JobSpec) -> Vec<Sample> {
    let source = SampleSource::new(job);
    (0..source.len()).map(|i| source.sample(i)).collect()
}

/// A rayon pool of exactly `n` threads (scaling benches).
pub fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().expect("a rayon pool")
}
