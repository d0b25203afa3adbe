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

/// Members of the mechanism family beyond the prototype, each with a height at which
/// its workspace around the level pose is reachable: `(mechanism table, z)`.
pub const FAMILY: [(&str, f64); 6] = [
    ("kind = \"3-PRS\"\nrail_angle_deg = 30.0\n", 1.2),
    ("kind = \"3-PRS\"\nrail_angle_deg = -90.0\nbase_radius = 1.2\n", 0.7),
    ("kind = \"3-PRS\"\nrail_angle_deg = 55.0\nlimb_angles_deg = [10.0, 100.0, 230.0]\n", 0.9),
    ("kind = \"3-PRS\"\nlimb_angles_deg = [0.0, 100.0, 230.0]\nplatform_angles_deg = [-10.0, 110.0, 225.0]\n", 2.0),
    ("kind = \"3-RPS\"\n", 1.2),
    ("kind = \"3-RPS\"\nlimb_angles_deg = [0.0, 100.0, 230.0]\nbase_radius = 0.35\ncylinder_length = 0.7\n", 1.1),
];

/// A random job of member `case` of [`FAMILY`]: random masses, loads, gravity tilt and
/// clearances as in [`random_job_toml`], the member's geometry.
pub fn family_job(rng: &mut impl Rng, case: usize, clearance: [f64; 4]) -> (JobSpec, f64) {
    let (mechanism, z) = FAMILY[case];
    let rps = mechanism.contains("3-RPS");
    let text = random_job_toml(rng, clearance, "[grid]\nz = 1.0\npsi = 0.0\ntheta = 0.0\n");
    // Keep the random masses, loads and gravity; swap in the member's geometry.
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    let gravity = table["mechanism"]["gravity"].clone();
    let mut m: toml::Table = toml::from_str(mechanism).unwrap();
    m.insert("gravity".into(), gravity);
    table.insert("mechanism".into(), toml::Value::Table(m));
    if rps {
        let mass = table["mass"].as_table_mut().unwrap();
        mass.remove("leg");
        mass.insert("cylinder".into(), toml::Value::Float(rng.random_range(0.5..3.0)));
        mass.insert("piston".into(), toml::Value::Float(rng.random_range(0.5..2.0)));
    }
    (JobSpec::from_toml_str(&toml::to_string(&table).unwrap(), "family.toml").unwrap(), z)
}

/// Unit vectors spread over a sphere (Fibonacci lattice).
pub fn sphere(n: usize) -> Vec<nalgebra::Vector3<f64>> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            nalgebra::Vector3::new(r * (golden * i as f64).cos(), r * (golden * i as f64).sin(), z)
        })
        .collect()
}
