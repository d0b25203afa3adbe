//! The 3-PRS written as a custom description (docs/model.md §12.9) against the
//! built-in kind's solver: reactions, per-kind errors, envelope, dominant joint and
//! exact error at random poses, in statics and along a trajectory's dynamics.

mod common;

use clearance_grid::Sample;
use clearance_model::{JobSpec, Mode};
use clearance_solver::custom::{CustomModel, solve_custom};
use clearance_solver::{Model, Status, Workspace, solve_pose};

const EXTRA: &str = "[mass]\nplatform = 9.8\npoints = [{ mass = 30.0, at = [0.05, -0.02, 1.0] }]\n\
[load]\nforce = [3.0, -2.0, 5.0]\nmoment = [0.4, 0.1, -0.3]\nat = [0.1, 0.0, 0.2]\n\
[clearance]\ns_radial = 1e-4\nr_radial = 2e-4\nr_axial = 1.5e-4\nr_angular = 1e-4\n\
[analysis]\nexact = true\n";

fn jobs() -> (JobSpec, JobSpec) {
    let z0 = (1.0f64 - 0.18 * 0.18).sqrt();
    let builtin = format!("[mechanism]\nkind = \"3-PRS\"\n{EXTRA}[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n");
    let custom = format!(
        "[mechanism]\nkind = \"custom\"\ninputs = [\"z\", \"psi\", \"theta\"]\nhome = [0.0, 0.0, {z0:?}, 0.0, 0.0, 0.0]\n\
         [[mechanism.limb]]\nrepeat = 3\njoints = [\n\
         {{ type = \"P\", at = [0.18, 0.0, 0.0], axis = [0.0, 0.0, 1.0], actuated = true }},\n\
         {{ type = \"R\", at = [0.18, 0.0, 0.0], axis = [0.0, 1.0, 0.0] }},\n\
         {{ type = \"S\", at = [0.36, 0.0, {z0:?}] }},\n]\nbodies = [{{ mass = 0.0 }}, {{ mass = 3.0 }}]\n\
         {EXTRA}[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n"
    );
    (JobSpec::from_toml_str(&builtin, "b.toml").unwrap(), JobSpec::from_toml_str(&custom, "c.toml").unwrap())
}

fn close(a: f64, b: f64, scale: f64, what: &str) {
    assert!((a - b).abs() <= 1e-10 * scale, "{what}: {a:e} vs {b:e} (scale {scale:e})");
}

fn compare(mode: Mode, sample: &Sample) {
    let (b, c) = jobs();
    let (mut bm, cm) = (Model::from_job(&b), CustomModel::from_job(&c, "c.toml").unwrap());
    bm.envelope = true;
    let mut ws = Workspace::new();
    let r = solve_pose(&bm, sample, mode, &mut ws);
    let inputs = [sample.z[0], sample.psi[0], sample.theta[0]];
    let rates = ([sample.z[1], sample.psi[1], sample.theta[1]], [sample.z[2], sample.psi[2], sample.theta[2]]);
    let x = solve_custom(&cm, &inputs, Some((&rates.0, &rates.1)), mode);
    assert_eq!(r.status, Status::Ok);
    assert_eq!(x.status, Status::Ok);
    let force = 300.0; // N: the loads' scale
    for j in 0..3 {
        for k in 0..3 {
            close(x.reactions[j][1].0[k], r.reactions.f_r[j][k], force, "f_r");
            close(x.reactions[j][1].1[k], r.reactions.m_r[j][k], force, "m_r");
            close(x.reactions[j][2].0[k], r.reactions.f_s[j][k], force, "f_s");
        }
    }
    // Kinds: s_radial, r_radial, r_axial, r_angular in both.
    assert_eq!(cm.kinds, ["s_radial", "r_radial", "r_axial", "r_angular"]);
    for k in 0..4 {
        let e = x.kind_errors[k].unwrap();
        let b = &r.errors[k];
        for i in 0..3 {
            close(e[i], b.dp[i], 1e-3, "dp");
            close(e[3 + i], b.dalpha[i], 1e-3, "dalpha");
            close(e[6 + i], b.euler[i], 1e-3, "euler");
        }
        for i in 0..8 {
            close(x.envelope[k][i], r.envelope[k][i], 1e-3, "envelope");
        }
    }
    let dom = x.dominant.map(|g| cm.groups[g].label.clone());
    let bdom = r.dominant.map(|(k, l)| clearance_solver::joint_name(k, l));
    assert_eq!(dom, bdom);
    let (ex, bx) = (x.exact.unwrap(), r.exact.unwrap());
    // Built-in exact is [Δα; Δp]? Compare both orders' norms component by component.
    for i in 0..3 {
        close(ex[i], bx[3 + i], 1e-3, "exact dp");
        close(ex[3 + i], bx[i], 1e-3, "exact dalpha");
    }
}

#[test]
fn statics_match_the_builtin_3prs() {
    for &(z, psi, theta) in &[(2.05, 0.1, -0.2), (1.9, -0.4, 0.3), (2.2, 0.45, 0.05)] {
        let s = Sample { index: 0, t: None, z: [z, 0.0, 0.0], psi: [psi, 0.0, 0.0], theta: [theta, 0.0, 0.0] };
        compare(Mode::Kinetostatic, &s);
    }
}

#[test]
fn dynamics_match_the_builtin_3prs() {
    let s = Sample { index: 0, t: Some(1.0), z: [2.05, 0.3, -0.5], psi: [0.1, -0.8, 2.0], theta: [-0.2, 1.5, -3.0] };
    compare(Mode::Dynamic, &s);
}
