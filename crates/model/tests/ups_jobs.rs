//! `kind = "6-UPS"` job files: the kind's keys and defaults, six inputs, keys of
//! another kind refused (and the 6-UPS's refused by the 3-limb kinds), sweeps.

use clearance_model::{JobSpec, MechanismKind, UPS_BASE_ANGLES_DEG};

const UPS: &str = "[mechanism]\nkind = \"6-UPS\"\n";
const GRID6: &str = "[grid]\nx = { start = -0.1, stop = 0.1, n = 3 }\ny = 0.0\nz = 0.75\nphi = 0.1\n\
                     psi = { start = -0.2, stop = 0.2, n = 5 }\ntheta = 0.0\n";

fn refuse(text: &str) -> (String, String) {
    match JobSpec::from_toml_str(text, "bad.toml") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => (e.key, e.reason),
    }
}

#[test]
fn defaults_are_those_of_the_model() {
    let job = JobSpec::from_toml_str(&format!("{UPS}{GRID6}"), "u.toml").unwrap();
    let m = &job.mechanism;
    assert_eq!(m.kind, MechanismKind::Ups6);
    assert_eq!((m.base_radius(), m.platform_radius()), (0.5, 0.3));
    assert_eq!(m.base_angles_deg(), UPS_BASE_ANGLES_DEG.to_vec());
    assert_eq!((m.cylinder_length(), m.piston_length(), m.min_length(), m.max_length()), (0.5, 0.5, 0.5, 1.0));
    assert_eq!(job.mass.platform, 10.0);
    assert_eq!((job.mass.cylinder(m.kind), job.mass.piston(m.kind)), (1.5, 0.75));
    assert_eq!(job.sample_count(), 15);
    // W = (10 + 6·2.25)·9.81
    assert!((job.weight() - 23.5 * 9.81).abs() < 1e-12);
    // A given platform mass is kept.
    let job = JobSpec::from_toml_str(&format!("{UPS}[mass]\nplatform = 9.8\n{GRID6}"), "u.toml").unwrap();
    assert_eq!(job.mass.platform, 9.8);
}

#[test]
fn the_provenance_job_runs_again_and_means_the_same() {
    let text = format!(
        "{UPS}u_axes = [[0,1,0],[0,1,0],[1,0,0],[1,0,0],[0,1,0.2],[0,1,0]]\n\
         [clearance]\ns_radial = 1e-4\nu_radial = 2e-4\nu_angular = 1e-3\n{GRID6}"
    );
    let job = JobSpec::from_toml_str(&text, "u.toml").unwrap();
    let again = JobSpec::from_toml_str(&job.to_toml_string(), "u.toml").unwrap();
    assert_eq!(again, job);
    let toml = job.to_toml_string();
    assert!(!toml.contains("r_radial") && toml.contains("u_angular"), "{toml}");
    assert_eq!(job.clearance.ups_array(), [1e-4, 2e-4, 1e-3]);
    // A 3-limb job writes its own kinds only, as before.
    let prs = JobSpec::from_toml_str("[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n", "p.toml").unwrap();
    let toml = prs.to_toml_string();
    assert!(toml.contains("r_axial") && !toml.contains("u_radial") && !toml.contains("phi"), "{toml}");
}

#[test]
fn keys_of_another_kind_are_refused_by_name() {
    let (k, r) = refuse(&format!("{UPS}leg_length = 1.0\n{GRID6}"));
    assert_eq!(k, "mechanism.leg_length");
    assert!(r.contains("3-PRS") && r.contains("6-UPS"), "{r}");
    let (k, r) = refuse(&format!("{UPS}[clearance]\nr_radial = 1e-4\nr_axial = 1e-4\n{GRID6}"));
    assert!(k.starts_with("clearance.r_"), "{k}");
    assert!(r.contains("`clearance.r_axial`") && r.contains("`clearance.r_radial`"), "{r}");
    let (k, r) = refuse("[clearance]\nu_radial = 1e-4\n[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    assert_eq!(k, "clearance.u_radial");
    assert!(r.contains("(a key of 6-UPS)") && r.contains("3-PRS"), "{r}");
    let (k, r) = refuse("[mechanism]\nkind = \"3-RPS\"\nu_axes = [[0,1,0]]\n[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    assert_eq!(k, "mechanism.u_axes");
    assert!(r.contains("6-UPS"), "{r}");
    // x, y, phi are parasitic motions of the 3-limb kinds, not inputs.
    let (k, r) = refuse("[grid]\nx = 0.1\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    assert_eq!(k, "grid.x");
    assert!(r.contains("z, psi, theta"), "{r}");
    let (k, _) =
        refuse("[trajectory]\ntime = { start = 0, stop = 1, n = 3 }\nphi = 0.1\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    assert_eq!(k, "trajectory.phi");
}

#[test]
fn bad_values_are_refused() {
    let (k, _) = refuse(&format!("{UPS}base_angles_deg = [0, 60, 120]\n{GRID6}"));
    assert_eq!(k, "mechanism.base_angles_deg");
    let (k, _) = refuse(&format!("{UPS}base_points = [[0,0,0]]\n{GRID6}"));
    assert_eq!(k, "mechanism.base_points");
    let (k, _) = refuse(&format!("{UPS}u_axes = [[0,1,0],[0,1,0],[0,0,0],[1,0,0],[0,1,0],[0,1,0]]\n{GRID6}"));
    assert_eq!(k, "mechanism.u_axes.2");
    let (k, _) = refuse(&format!("{UPS}min_length = 1.2\n{GRID6}"));
    assert_eq!(k, "mechanism.min_length");
    let (k, _) = refuse(&format!("{UPS}[clearance]\nu_angular = -1e-3\n{GRID6}"));
    assert_eq!(k, "clearance.u_angular");
    let (k, _) = refuse(&format!("{UPS}[grid]\nx = {{ start = 0, stop = 0, n = 3 }}\nz = 0.7\npsi = 0\ntheta = 0\n"));
    assert_eq!(k, "grid.x");
}

#[test]
fn every_new_scalar_key_is_sweepable() {
    for (param, value) in [
        ("mechanism.platform_radius", 0.25),
        ("mechanism.base_radius", 0.45),
        ("mechanism.base_angles_deg.2", 100.0),
        ("mechanism.platform_angles_deg.0", -40.0),
        ("mechanism.cylinder_length", 0.55),
        ("mechanism.min_length", 0.52),
        ("mechanism.max_length", 0.98),
        ("mass.cylinder", 2.0),
        ("mass.platform", 12.0),
        ("clearance.u_radial", 3e-4),
        ("clearance.u_angular", 2e-3),
        ("grid.x", 0.05),
        ("grid.phi", 0.2),
    ] {
        let text = format!(
            "{UPS}{}\n[[sweep]]\nparam = \"{param}\"\nvalues = [{value}]\n",
            GRID6.replace("x = { start = -0.1, stop = 0.1, n = 3 }", "x = 0.0")
        );
        let job = JobSpec::from_toml_str(&text, "s.toml").unwrap_or_else(|e| panic!("{param}: {e}"));
        let v = &job.variants("s.toml").unwrap()[0].job;
        let got = match param {
            "mechanism.platform_radius" => v.mechanism.platform_radius(),
            "mechanism.base_radius" => v.mechanism.base_radius(),
            "mechanism.base_angles_deg.2" => v.mechanism.base_angles_deg()[2],
            "mechanism.platform_angles_deg.0" => v.mechanism.platform_angles_deg()[0],
            "mechanism.cylinder_length" => v.mechanism.cylinder_length(),
            "mechanism.min_length" => v.mechanism.min_length(),
            "mechanism.max_length" => v.mechanism.max_length(),
            "mass.cylinder" => v.mass.cylinder(MechanismKind::Ups6),
            "mass.platform" => v.mass.platform,
            "clearance.u_radial" => v.clearance.u_radial,
            "clearance.u_angular" => v.clearance.u_angular,
            "grid.x" => v.grid.as_ref().unwrap().axes6()[0].value(0),
            "grid.phi" => v.grid.as_ref().unwrap().axes6()[3].value(0),
            _ => unreachable!(),
        };
        assert_eq!(got, value, "{param}");
        assert!(v.clearance.ups, "{param}: the variant is a 6-UPS");
    }
}
