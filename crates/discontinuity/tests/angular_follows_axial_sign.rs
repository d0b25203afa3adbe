//! In the 3-limb kinds `m_Rj = |A_j − B_j|·(f_Rj·y_j)·u_j`: the `r_angular`
//! take-up flips exactly where the axial load changes sign (docs/model.md §8). Its
//! switches are `r_axial`'s, and its margin is `|m_Rj|` there, as a solve at the
//! switch reads it.

mod common;

use clearance_discontinuity::{Discontinuity, paths};
use clearance_model::{ClearanceKind, Mode};
use clearance_solver::{Workspace, solve_pose};
use common::{by_line, job, run};

const GRID: &str = "[grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 41 }\n\
    theta = { start = -0.5, stop = 0.5, n = 41 }\n";

fn trajectory(mode: &str) -> String {
    format!(
        "[mass]\npoints = [{{ mass = 30.0, at = [0.0, 0.0, 1.0] }}]\n[analysis]\nmodes = [\"{mode}\"]\n\
         [trajectory]\ntime = {{ start = 1.25, stop = 3.75, n = 501 }}\nz = 2.05\npsi = 0.1\n\
         theta = {{ harmonics = [ {{ amplitude = 0.5, period = 5.0 }} ] }}\n"
    )
}

/// Each kind alone (Figs. 9 and 10), and both in one job: the same locations.
fn check(rest: &str, mode: Mode) {
    let axial = run(&format!("[clearance]\nr_axial = 1e-4\n{rest}"), mode);
    let angular_text = format!("[clearance]\nr_angular = 1e-4\n{rest}");
    let angular = run(&angular_text, mode);
    let both = run(&format!("[clearance]\nr_axial = 1e-4\nr_angular = 1e-4\n{rest}"), mode);
    assert!(!axial.is_empty());
    assert!(angular.iter().all(|d| d.kind == ClearanceKind::RAngular));
    let kind_of = |v: &[Discontinuity], k: ClearanceKind| -> Vec<Discontinuity> {
        v.iter().filter(|d| d.kind == k).cloned().collect()
    };
    let key = |v: &[Discontinuity]| -> Vec<_> {
        by_line(v).into_iter().map(|((a, b, c, limb, _), p)| ((a, b, c, limb), p)).collect()
    };
    for (x, y) in [
        (&axial, &angular),
        (&kind_of(&both, ClearanceKind::RAxial), &kind_of(&both, ClearanceKind::RAngular)),
        (&axial, &kind_of(&both, ClearanceKind::RAxial)),
    ] {
        let (x, y) = (key(x), key(y));
        assert_eq!(x.len(), y.len());
        for (a, b) in x.iter().zip(&y) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).abs() <= 1e-9, "{a:?} vs {b:?}");
        }
    }
    let (_, model, source) = job(&angular_text);
    let path = &paths(&source);
    let mut ws = Workspace::new();
    for d in &angular {
        // The switch's pose, solved from its reported inputs.
        let on = path.iter().find(|p| {
            p.along == d.along && {
                let s = p.sample_at(&source, d.param);
                (s.z[0] - d.z).abs() + (s.psi[0] - d.psi).abs() + (s.theta[0] - d.theta).abs() < 1e-12
            }
        });
        let path = on.expect("a path through the switch");
        let r = solve_pose(&model, &path.sample_at(&source, d.param), mode, &mut ws);
        let m = r.reactions.m_r[d.limb - 1];
        let expected = (m.x * m.x + m.y * m.y + m.z * m.z).sqrt();
        assert_eq!(d.margin, expected, "{d:?}");
        // And it is small: the moment vanishes with the axial load.
        assert!(d.margin < 1e-6 * model.weight, "{d:?}");
    }
}

#[test]
fn angular_switches_are_the_axial_ones_on_the_paper_grid() {
    check(GRID, Mode::Kinetostatic);
}

#[test]
fn angular_switches_are_the_axial_ones_along_a_trajectory() {
    check(&trajectory("kinetostatic"), Mode::Kinetostatic);
    check(&trajectory("dynamic"), Mode::Dynamic);
}
