//! Bad custom descriptions (docs/model.md §12.3) are refused by `run`, `check` and
//! `describe` with exit 2, a message that names what is wrong, and nothing written; a
//! good one described again by `clearance describe` runs.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_clearance")).args(args).output().unwrap()
}

/// A 3-RRS whose limb is `joints` (TOML list items), the rest of the job fixed.
fn rrs(joints: &str, inputs: &str, clearance: &str) -> String {
    format!(
        "[mechanism]\nkind = \"custom\"\ninputs = {inputs}\nhome = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0]\n\
         [[mechanism.limb]]\nrepeat = 3\njoints = [\n{joints}\n]\n[mass]\nplatform = 5.0\n[clearance]\n{clearance}\n\
         [grid]\nz = 0.6\npsi = {{ start = -0.1, stop = 0.1, n = 3 }}\ntheta = 0.0\n"
    )
}

const CRANK: &str =
    "{ type = \"R\", name = \"crank\", at = [0.25, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true },";
const KNEE: &str = "{ type = \"R\", name = \"knee\", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0] },";
const S: &str = "{ type = \"S\", at = [0.15, 0.0, 0.6] },";
const ZPT: &str = "[\"z\", \"psi\", \"theta\"]";

fn refused(dir: &Path, name: &str, text: &str, words: &[&str]) {
    let job = dir.join(format!("{name}.toml"));
    std::fs::write(&job, text).unwrap();
    let out = dir.join(format!("{name}_out"));
    for args in [
        vec!["run", job.to_str().unwrap(), "--out", out.to_str().unwrap()],
        vec!["check", job.to_str().unwrap(), "--no-timing"],
        vec!["describe", job.to_str().unwrap()],
    ] {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name} {args:?}: {err}");
        for w in words {
            assert!(err.contains(w), "{name} {args:?}: {err:?} lacks {w:?}");
        }
        assert!(!out.exists(), "{name}: {} was written", out.display());
    }
}

#[test]
fn bad_descriptions_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A third R between knee and sphere: one freedom too many per limb.
    let extra = "{ type = \"R\", name = \"wrist\", at = [0.3, 0.0, 0.3], axis = [1.0, 0.0, 0.0] },";
    refused(d, "not_rigid", &rrs(&format!("{CRANK}\n{KNEE}\n{extra}\n{S}"), ZPT, ""), &["not rigid", "57", "60"]);
    // The knee locked too: one freedom too few.
    let knee_fixed =
        "{ type = \"R\", name = \"knee\", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true },";
    refused(
        d,
        "overconstrained",
        &rrs(&format!("{CRANK}\n{knee_fixed}\n{S}"), ZPT, ""),
        &["overconstrained", "45", "42"],
    );
    // Two S joints with the leg between: it can spin about the line joining them.
    let s_low = "{ type = \"S\", name = \"ankle\", at = [0.45, 0.0, 0.0] },";
    refused(d, "idle", &rrs(&format!("{CRANK}\n{s_low}\n{S}"), ZPT, ""), &["idle freedom", "limb 1", "U joint"]);
    // Two joints of one limb with one name.
    let twin = KNEE.replace("knee", "crank");
    refused(d, "names", &rrs(&format!("{CRANK}\n{twin}\n{S}"), ZPT, ""), &["crank", "named"]);
    // A U whose axes are not perpendicular.
    let bent = "{ type = \"U\", name = \"knee\", at = [0.45, 0.0, 0.0], axes = [[0.0, 1.0, 0.0], [0.0, 1.0, 1.0]] },";
    refused(d, "bent_u", &rrs(&format!("{CRANK}\n{bent}\n{S}"), ZPT, ""), &["perpendicular"]);
    // A zero axis.
    refused(
        d,
        "zero_axis",
        &rrs(&format!("{CRANK}\n{}\n{S}", KNEE.replace("[0.0, 1.0, 0.0] }", "[0.0, 0.0, 0.0] }")), ZPT, ""),
        &["non-zero"],
    );
    // Inputs: not a coordinate; not as many as the actuators.
    refused(
        d,
        "bad_input",
        &rrs(&format!("{CRANK}\n{KNEE}\n{S}"), "[\"z\", \"psi\", \"tilt\"]", ""),
        &["tilt", "platform coordinate"],
    );
    refused(
        d,
        "few_inputs",
        &rrs(&format!("{CRANK}\n{KNEE}\n{S}"), "[\"z\", \"psi\"]", "").replace("theta = 0.0\n", ""),
        &["3 actuated joints", "2 inputs"],
    );
    // A clearance key that names no joint group.
    refused(
        d,
        "bad_key",
        &rrs(&format!("{CRANK}\n{KNEE}\n{S}"), ZPT, "knee_backlash = 1e-4\n"),
        &["clearance.knee_backlash", "names no joint group"],
    );
    // A per-limb list of the wrong length.
    refused(
        d,
        "bad_list",
        &rrs(&format!("{CRANK}\n{KNEE}\n{S}"), ZPT, "knee_radial = [1e-4, 1e-4]\n"),
        &["3 limbs", "got 2"],
    );
}

#[test]
fn a_described_builtin_runs_and_describes_to_itself() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("prs.toml");
    std::fs::write(
        &job,
        "[clearance]\nr_axial = 1e-4\n[grid]\nz = 2.05\npsi = { start = -0.2, stop = 0.2, n = 5 }\ntheta = 0.1\n",
    )
    .unwrap();
    let o = run(&["describe", job.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let described = dir.path().join("described.toml");
    std::fs::write(&described, &o.stdout).unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("kind = \"custom\"") && text.contains("r_axial = 0.0001"), "{text}");
    let again = run(&["describe", described.to_str().unwrap()]);
    assert_eq!(again.stdout, o.stdout, "a description describes to itself");
    let out = dir.path().join("out");
    let r = run(&["run", described.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]);
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(out.join("_SUCCESS").exists() && out.join("discontinuities.parquet").exists());
}

/// `--solver general` assembles the 3-limb kinds' systems: a custom or 6-UPS job, which
/// has its own only, refuses it (exit 2, the kinds named, nothing written) rather than
/// running with another solver; the fast solver runs it.
#[test]
fn the_general_solver_is_refused_where_it_cannot_apply() {
    let dir = tempfile::tempdir().unwrap();
    let custom = dir.path().join("custom.toml");
    std::fs::write(&custom, rrs(&format!("{CRANK}\n{KNEE}\n{S}"), ZPT, "knee_radial = 1e-4")).unwrap();
    let ups = dir.path().join("ups.toml");
    std::fs::write(&ups, "[mechanism]\nkind = \"6-UPS\"\n[clearance]\nu_radial = 1e-4\n[grid]\nx = 0.0\ny = 0.0\nz = 0.7\nphi = 0.0\npsi = 0.0\ntheta = { start = -0.1, stop = 0.1, n = 3 }\n").unwrap();
    for (job, kind) in [(&custom, "custom"), (&ups, "6-UPS")] {
        let out = dir.path().join(format!("{kind}_out"));
        let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "--solver", "general"]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{kind}: {err}");
        assert!(err.contains("3-limb kinds") && err.contains(&format!("a {kind} job")), "{kind}: {err}");
        assert!(!out.exists(), "{kind}: {} was written", out.display());
        let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "--solver", "fast", "-q"]);
        assert!(o.status.success(), "{kind}: {}", String::from_utf8_lossy(&o.stderr));
    }
}
