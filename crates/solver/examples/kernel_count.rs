//! The kernel on one thread, for instruction counts that a busy machine cannot
//! disturb: `valgrind --tool=callgrind target/release/examples/kernel_count [N]`
//! and divide `solve_poses`'s inclusive count by N (`benches/README.md`);
//! `KERNEL_ONE_BY_ONE=1` runs `solve_pose` pose by pose instead.
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, PoseResult, Workspace, solve_pose, solve_poses};

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
    let mut samples = Vec::new();
    let mut out = vec![PoseResult::default(); 1024];
    let one_by_one = std::env::var_os("KERNEL_ONE_BY_ONE").is_some();
    for start in (0..source.len()).step_by(1024) {
        samples.clear();
        samples.extend((start..source.len().min(start + 1024)).map(|i| source.sample(i)));
        let out = &mut out[..samples.len()];
        if one_by_one {
            for (s, r) in samples.iter().zip(out.iter_mut()) {
                *r = solve_pose(&model, s, Mode::Kinetostatic, &mut ws);
            }
        } else {
            solve_poses(&model, &samples, Mode::Kinetostatic, &mut ws, out);
        }
        checksum += out.iter().map(|r| r.errors[0].dp.z + r.errors[3].dalpha.x).sum::<f64>();
    }
    println!("{} poses, checksum {checksum:e}", source.len());
}
