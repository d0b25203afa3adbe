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
