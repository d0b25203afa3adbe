//! Prints every quantity for one pose: `cargo run -p clearance-solver --example one_pose -- Z PSI THETA`.
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Workspace, solve_pose};

fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().expect("numbers")).collect();
    let (z, psi, theta) = match args.as_slice() {
        [z, p, t] => (*z, *p, *t),
        _ => (2.05, 0.1, -0.2),
    };
    let text = format!(
        "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n[analysis]\nexact = true\n[grid]\nz = {z}\npsi = {psi}\ntheta = {theta}\n"
    );
    let job = JobSpec::from_toml_str(&text, "one_pose.toml").unwrap();
    let model = Model::from_job(&job);
    let s = SampleSource::new(&job).sample(0);
    let r = solve_pose(&model, &s, Mode::Kinetostatic, &mut Workspace::new());
    println!("{r:#?}");
}
