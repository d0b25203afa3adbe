//! Every malformed job is refused with the file, the dotted key and the reason.

use clearance_model::JobSpec;

const GRID: &str = "[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n";

/// Parses `text` and returns (key, reason), failing if it was accepted.
fn refuse(text: &str) -> (String, String) {
    match JobSpec::from_toml_str(text, "bad.toml") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            let shown = e.to_string();
            assert!(shown.starts_with("bad.toml: "), "{shown}");
            assert!(shown.lines().count() <= 2, "one or two lines: {shown}");
            (e.key, e.reason)
        }
    }
}

#[test]
fn unknown_keys_get_a_path_and_a_suggestion() {
    let (k, r) = refuse(&format!("[mass]\nplatfrom = 3.0\n{GRID}"));
    assert_eq!(k, "mass.platfrom");
    assert!(r.contains("did you mean `platform`"), "{r}");
    let (k, r) = refuse(&format!("[mas]\nplatform = 3.0\n{GRID}"));
    assert_eq!((k.as_str(), r.contains("`mass`")), ("mas", true));
    let (k, _) = refuse("[grid]\nz = 2.0\npsi = { start = 0.0, stpo = 1.0, n = 3 }\ntheta = 0.0\n");
    assert_eq!(k, "grid.psi.stpo");
}

#[test]
fn wrong_types_name_the_key_and_line() {
    let (k, r) = refuse(&format!("[mechanism]\nleg_length = \"long\"\n{GRID}"));
    assert_eq!(k, "mechanism.leg_length");
    assert!(r.contains("line 2") && r.contains("string"), "{r}");
    let (_, r) = refuse(&format!("[analysis]\nmodes = [\"dynamik\"]\n{GRID}"));
    assert!(r.contains("dynamik"), "{r}");
}

#[test]
fn syntax_errors_give_the_line() {
    let (_, r) = refuse("[clearance]\nr_radial = 1e-4\n[grid\nz = 1.0\n");
    assert!(r.contains("line 3"), "{r}");
}

#[test]
fn values_out_of_their_physical_range() {
    for (text, key) in [
        ("[mechanism]\nleg_length = 0.0\n", "mechanism.leg_length"),
        ("[mechanism]\nbase_radius = -0.1\n", "mechanism.base_radius"),
        ("[mechanism]\nplatform_radius = nan\n", "mechanism.platform_radius"),
        ("[mechanism]\ngravity = [0.0, inf, -9.81]\n", "mechanism.gravity.1"),
        ("[mass]\nleg = -1.0\n", "mass.leg"),
        ("[mass]\npoints = [{ mass = -2.0, at = [0.0, 0.0, 1.0] }]\n", "mass.points.0.mass"),
        ("[clearance]\nr_axial = -1e-4\n", "clearance.r_axial"),
        ("[load]\nforce = [0.0, nan, 0.0]\n", "load.force.1"),
    ] {
        let (k, _) = refuse(&format!("{text}{GRID}"));
        assert_eq!(k, key, "{text}");
    }
    // A zero point mass is a valid sweep value.
    JobSpec::from_toml_str(&format!("[mass]\npoints = [{{ mass = 0.0, at = [0.0, 0.0, 1.0] }}]\n{GRID}"), "ok.toml")
        .unwrap();
}

#[test]
fn ranges_and_samples() {
    let (k, _) = refuse("[grid]\nz = 2.0\npsi = { start = 0.0, stop = 1.0, n = 0 }\ntheta = 0.0\n");
    assert_eq!(k, "grid.psi.n");
    let (k, r) = refuse("[grid]\nz = 2.0\npsi = { start = 0.3, stop = 0.3, n = 5 }\ntheta = 0.0\n");
    assert_eq!(k, "grid.psi");
    assert!(r.contains("start = stop"), "{r}");
    let (_, r) = refuse("[clearance]\nr_radial = 1e-4\n");
    assert!(r.contains("neither [grid] nor [trajectory]"), "{r}");
    let (_, r) = refuse(&format!("{GRID}[trajectory]\ntime = 0.0\nz = 2.0\npsi = 0.0\ntheta = 0.0\n"));
    assert!(r.contains("both [grid] and [trajectory]"), "{r}");
    let (k, r) = refuse(&format!("[analysis]\nmodes = [\"dynamic\"]\n{GRID}"));
    assert_eq!(k, "analysis.modes");
    assert!(r.contains("trajectory"), "{r}");
}

#[test]
fn sweeps_must_point_at_numbers_that_exist() {
    let (k, r) = refuse(&format!("{GRID}[[sweep]]\nparam = \"mass.points.0.mass\"\nvalues = [1.0]\n"));
    assert_eq!(k, "sweep.0.param");
    assert!(r.contains("0 entries"), "{r}");
    let (_, r) = refuse(&format!("{GRID}[[sweep]]\nparam = \"mechanism.leg_lenght\"\nvalues = [1.0]\n"));
    assert!(r.contains("leg_lenght"), "{r}");
    let (_, r) = refuse(&format!("{GRID}[[sweep]]\nparam = \"analysis.modes\"\nvalues = [1.0]\n"));
    assert!(r.contains("not a number"), "{r}");
    // A swept value is validated like a written one.
    let (_, r) = refuse(&format!("{GRID}[[sweep]]\nparam = \"mass.leg\"\nvalues = [1.0, -1.0]\n"));
    assert!(r.contains("variant 1"), "{r}");
}

#[test]
fn missing_file() {
    let e = JobSpec::from_path(std::path::Path::new("/no/such/job.toml")).unwrap_err();
    assert!(e.to_string().contains("/no/such/job.toml") && e.reason.contains("cannot read"));
}

#[test]
fn keys_of_another_mechanism_kind_are_refused() {
    let (k, r) = refuse(&format!("[mechanism]\nkind = \"3-RPS\"\nleg_length = 1.0\n[mass]\nleg = 2.0\n{GRID}"));
    assert_eq!(k, "mechanism.leg_length");
    assert!(r.contains("`mass.leg`") && r.contains("3-RPS"), "both keys are named: {r}");
    let (k, _) = refuse(&format!("[mechanism]\ncylinder_length = 0.5\n{GRID}"));
    assert_eq!(k, "mechanism.cylinder_length", "a 3-RPS key on the default 3-PRS");
    let (k, r) = refuse(&format!("[mechanism]\nkind = \"6-PRS\"\n{GRID}"));
    assert_eq!(k, "mechanism.kind");
    assert!(r.contains("\"3-PRS\""), "{r}");
}

#[test]
fn family_geometry_out_of_range() {
    for (text, key) in [
        ("[mechanism]\nrail_angle_deg = 95.0\n", "mechanism.rail_angle_deg"),
        ("[mechanism]\nlimb_angles_deg = [0.0, 120.0]\n", "mechanism.limb_angles_deg"),
        ("[mechanism]\nlimb_angles_deg = [0.0, 360.0, 240.0]\n", "mechanism.limb_angles_deg"),
        ("[mechanism]\nplatform_angles_deg = [0.0, nan, 240.0]\n", "mechanism.platform_angles_deg.1"),
        ("[mechanism]\nkind = \"3-RPS\"\ncylinder_length = -0.8\n", "mechanism.cylinder_length"),
        ("[mechanism]\nkind = \"3-RPS\"\nmin_length = 1.7\n", "mechanism.min_length"),
        ("[mechanism]\nkind = \"3-RPS\"\n[mass]\npiston = -1.0\n", "mass.piston"),
    ] {
        let (k, _) = refuse(&format!("{text}{GRID}"));
        assert_eq!(k, key, "{text}");
    }
}

/// Defaults follow the kind, are written into the provenance job (which parses back
/// to the same job), and every geometry key can be swept, including those whose
/// default follows another key.
#[test]
fn family_defaults_and_sweeps() {
    let rps = JobSpec::from_toml_str(&format!("[mechanism]\nkind = \"3-RPS\"\n{GRID}"), "rps.toml").unwrap();
    let m = &rps.mechanism;
    assert_eq!((m.base_radius(), m.platform_radius(), m.min_length(), m.max_length()), (0.3, 0.2, 0.8, 1.6));
    assert_eq!((rps.mass.cylinder, rps.mass.piston, rps.mass.leg), (Some(2.0), Some(1.0), None));
    assert_eq!(JobSpec::from_toml_str(&rps.to_toml_string(), "rps.toml").unwrap(), rps);
    assert!((rps.weight() - (9.8 + 3.0 * 3.0) * 9.81).abs() < 1e-12);
    for (param, kind) in [
        ("mechanism.rail_angle_deg", "3-PRS"),
        ("mechanism.limb_angles_deg.1", "3-PRS"),
        ("mechanism.platform_angles_deg.2", "3-PRS"),
        ("mechanism.max_length", "3-RPS"),
        ("mechanism.cylinder_length", "3-RPS"),
        ("mass.piston", "3-RPS"),
    ] {
        let text = format!(
            "[mechanism]\nkind = \"{kind}\"\n{GRID}[[sweep]]\nparam = \"{param}\"\nvalues = [{}]\n",
            if param.ends_with("max_length") { "1.5, 1.55" } else { "0.7, 0.75" }
        );
        let job = JobSpec::from_toml_str(&text, "sweep.toml").unwrap_or_else(|e| panic!("{param}: {e}"));
        let variants = job.variants("sweep.toml").unwrap();
        assert_eq!(variants.len(), 2, "{param}");
        assert_ne!(variants[0].job, variants[1].job, "{param} moves the job");
    }
    // Sweeping the cylinder moves the default stroke with it.
    let text = format!(
        "[mechanism]\nkind = \"3-RPS\"\n{GRID}[[sweep]]\nparam = \"mechanism.cylinder_length\"\nvalues = [0.8, 0.9]\n"
    );
    let v = JobSpec::from_toml_str(&text, "s.toml").unwrap().variants("s.toml").unwrap();
    assert!((v[1].job.mechanism.max_length() - 1.7).abs() < 1e-15);
}
