//! Helpers shared by the solver's integration tests.
#![allow(dead_code)]

use clearance_grid::Sample;
use clearance_model::JobSpec;
use rand::Rng;

/// A random but sane job around the paper's prototype, as TOML.
pub fn random_job_toml(rng: &mut impl Rng, clearance: [f64; 4], extra: &str) -> String {
    let mut points = String::new();
    for _ in 0..rng.random_range(0..3) {
        points.push_str(&format!(
            "{{ mass = {}, at = [{}, {}, {}] }},",
            rng.random_range(0.0..20.0),
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
            rng.random_range(-1.0..1.0)
        ));
    }
    format!(
        "[mechanism]\nbase_radius = {}\nplatform_radius = {}\nleg_length = {}\ngravity = [{}, {}, -9.81]\n\
         [mass]\nplatform = {}\nleg = {}\npoints = [{points}]\n\
         [load]\nforce = [{}, {}, {}]\nmoment = [{}, {}, {}]\nat = [{}, {}, {}]\n\
         [clearance]\ns_radial = {}\nr_radial = {}\nr_axial = {}\nr_angular = {}\n{extra}",
        rng.random_range(0.1..0.3),
        rng.random_range(0.25..0.45),
        rng.random_range(0.9..1.3),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(5.0..15.0),
        rng.random_range(1.0..5.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(-5.0..5.0),
        rng.random_range(-5.0..5.0),
        rng.random_range(-5.0..5.0),
        rng.random_range(-0.2..0.2),
        rng.random_range(-0.2..0.2),
        rng.random_range(-0.2..0.2),
        clearance[0],
        clearance[1],
        clearance[2],
        clearance[3],
    )
}

pub fn grid_job(rng: &mut impl Rng, clearance: [f64; 4]) -> JobSpec {
    let text = random_job_toml(rng, clearance, "[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    JobSpec::from_toml_str(&text, "random.toml").unwrap()
}

pub fn static_sample(z: f64, psi: f64, theta: f64) -> Sample {
    Sample { index: 0, t: None, z: [z, 0.0, 0.0], psi: [psi, 0.0, 0.0], theta: [theta, 0.0, 0.0] }
}
