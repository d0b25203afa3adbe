//! The kernel on one thread, for instruction counts that a busy machine cannot
//! disturb: `valgrind --tool=callgrind target/release/examples/kernel_count [N]`
//! and divide `solve_pose`'s inclusive count by N (`benches/README.md`).
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Workspace, solve_pose};

fn main() {
    let n: u64 = std::env::args().nth(1).map_or(10_000, |a| a.parse().expect("a pose count"));
    let side = (n as f64).sqrt().ceil() as u64;
    let text = format!(
        "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
         [grid]\nz = 2.05\npsi = {{ start = -0.5, stop = 0.5, n = {side} }}\ntheta = {{ start = -0.5, stop = 0.5, n = {side} }}\n"
    );
    let job = JobSpec::from_toml_str(&text, "kernel_count.toml").expect("a valid job");
    let model = Model::from_job(&job);
    let source = SampleSource::new(&job);
    let mut ws = Workspace::new();
    let mut checksum = 0.0;
    for i in 0..source.len() {
        let r = solve_pose(&model, &source.sample(i), Mode::Kinetostatic, &mut ws);
        checksum += r.errors[0].dp.z + r.errors[3].dalpha.x;
    }
    println!("{} poses, checksum {checksum:e}", source.len());
}
