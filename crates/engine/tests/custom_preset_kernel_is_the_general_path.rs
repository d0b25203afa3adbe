//! A custom description of a built-in 3-PRS or 6-UPS (as `clearance describe` writes
//! it) is solved by that kind's kernel (docs/model.md §12.10); the same mechanism
//! written so that it is not recognised (a body written another way,
//! `common::general_path`) goes the description's general way. The two must agree:
//! every column to 1e-12 of its scale (a column's scale is its largest value, or a
//! hundredth of its family's, loads or errors, where that is larger), the statuses and
//! the dominant joints exactly, and the same switches, at the same places (within
//! 2.5e-9 of the path parameter: both bracket a root to 1e-10 of a step) with the same
//! jumps (1e-12 of their scale). Kinetostatics on a grid and dynamics on a trajectory:
//! the 3-PRS on the prototype's layout (closed forms) and on one with inclined rails and
//! uneven limbs (Newton for the parasitic motions), the 6-UPS with its default legs and
//! with its own base points, U axes and masses. A description that is not a built-in's
//! is not given the kernel.

mod common;

use common::{ColumnScales, column};

use arrow::array::{Array, Float64Array, StringArray, UInt32Array};
use arrow::record_batch::RecordBatch;
use clearance_engine::{JobSpec, Layout, describe, run, uses_kernel};

const KINDS: &str = "[clearance]\ns_radial = 1e-4\nr_radial = 2e-4\nr_axial = 1.5e-4\nr_angular = 1e-4\n\
[mass]\npoints = [{ mass = 30.0, at = [0.05, -0.02, 1.0] }]\n[load]\nforce = [3.0, -2.0, 5.0]\nmoment = [0.4, 0.1, -0.3]\n";

fn described(text: &str) -> JobSpec {
    let job = JobSpec::from_toml_str(text, "builtin.toml").unwrap();
    describe(&job, "builtin.toml").unwrap()
}

/// The poses (concatenated) and the switches of a run of `job`.
fn run_of(job: &JobSpec) -> (RecordBatch, RecordBatch) {
    let dir = tempfile::tempdir().unwrap();
    run(job, "described.toml", &common::options(dir.path())).unwrap();
    let layout = Layout::new(dir.path());
    let mut parts: Vec<_> = walk(&dir.path().join("poses"));
    parts.sort();
    (common::read_parts(parts), common::read(&layout.discontinuities()))
}

fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else if p.extension().is_some_and(|x| x == "parquet") {
            out.push(p);
        }
    }
    out
}

/// Every column of `fast` against `general`; returns how many float columns were
/// compared, and how many values differ in their bits.
fn compare_poses(fast: &RecordBatch, general: &RecordBatch) -> (usize, usize) {
    assert_eq!(fast.schema().fields(), general.schema().fields());
    assert_eq!(fast.num_rows(), general.num_rows());
    let scales = ColumnScales::of(general);
    let (mut compared, mut differing) = (0, 0);
    for (i, field) in general.schema().fields().iter().enumerate() {
        let (x, y) = (general.column(i), fast.column(i));
        if let Some(d) = scales.assert_close(field.name(), x, y, 1e-12) {
            compared += usize::from(x.as_any().is::<Float64Array>());
            differing += d;
        }
    }
    (compared, differing)
}

/// One switch: mode, joint group, along, the inputs where it is, and its jump.
type Switch = (String, String, u32, String, Vec<f64>, Vec<Option<f64>>);

fn switches(d: &RecordBatch, inputs: &[&str]) -> Vec<Switch> {
    let s = |n: &str| column::<StringArray>(d, n);
    let f = |n: &str| column::<Float64Array>(d, n);
    let limb = column::<UInt32Array>(d, "limb");
    let mut out: Vec<Switch> = (0..d.num_rows())
        .map(|i| {
            let at = inputs.iter().map(|c| f(c).value(i)).collect();
            let jump = ["x", "y", "z", "rx", "ry", "rz"]
                .iter()
                .map(|c| {
                    let a = f(&format!("jump_{c}"));
                    a.is_valid(i).then(|| a.value(i))
                })
                .collect();
            (s("mode").value(i).into(), s("kind").value(i).into(), limb.value(i), s("along").value(i).into(), at, jump)
        })
        .collect();
    out.sort_by(|a, b| (&a.0, &a.1, a.2, &a.3, &a.4).partial_cmp(&(&b.0, &b.1, b.2, &b.3, &b.4)).unwrap());
    out
}

fn compare_switches(fast: &RecordBatch, general: &RecordBatch, inputs: &[&str]) -> usize {
    let (f, g) = (switches(fast, inputs), switches(general, inputs));
    assert_eq!(f.len(), g.len(), "{} switches by the kernel, {} by the general path", f.len(), g.len());
    let scale = g.iter().flat_map(|s| s.5.iter().flatten()).fold(0.0f64, |m, v| m.max(v.abs()));
    for (a, b) in f.iter().zip(&g) {
        assert_eq!((&a.0, &a.1, a.2, &a.3), (&b.0, &b.1, b.2, &b.3));
        for (x, y) in a.4.iter().zip(&b.4) {
            assert!((x - y).abs() <= 2.5e-9, "{a:?} against {b:?}");
        }
        for (x, y) in a.5.iter().zip(&b.5) {
            match (x, y) {
                (Some(x), Some(y)) => assert!((x - y).abs() <= 1e-12 * scale, "{a:?} against {b:?}"),
                (x, y) => assert_eq!(x.is_some(), y.is_some(), "{a:?} against {b:?}"),
            }
        }
    }
    f.len()
}

fn check(job: &JobSpec, inputs: &[&str], min_switches: usize) {
    assert!(uses_kernel(job, "described.toml").unwrap(), "the description is a built-in kind's");
    let (fast_poses, fast_switches) = run_of(job);
    let (general_poses, general_switches) = run_of(&common::general_path(job));
    let (compared, differing) = compare_poses(&fast_poses, &general_poses);
    assert!(compared > 100, "only {compared} columns");
    // Values of another computation differ in their last bits somewhere: the kernel did
    // solve these poses (a pose it does not solve is the general path's, bit for bit).
    assert!(differing > 0, "every value is the general path's: the kernel solved nothing");
    let n = compare_switches(&fast_switches, &general_switches, inputs);
    assert!(n >= min_switches, "only {n} switches");
}

#[test]
fn the_kernel_gives_the_general_path_on_the_prototype_grid() {
    let job = described(&format!(
        "{KINDS}[grid]\nz = 2.05\npsi = {{ start = -0.3, stop = 0.3, n = 13 }}\ntheta = {{ start = -0.4, stop = 0.4, n = 17 }}\n"
    ));
    check(&job, &["psi", "theta"], 20);
}

#[test]
fn the_kernel_gives_the_general_path_with_inclined_rails_in_dynamics() {
    let job = described(&format!(
        "[mechanism]\nrail_angle_deg = 30.0\nlimb_angles_deg = [0.0, 100.0, 230.0]\n{KINDS}[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = {{ start = 0.0, stop = 2.0, n = 41 }}\nz = 1.6\npsi = 0.1\ntheta = {{ offset = 0.0, harmonics = [{{ amplitude = 0.3, period = 2.0 }}] }}\n"
    ));
    check(&job, &["t"], 1);
}

#[test]
fn the_kernel_gives_the_general_path_with_one_kind_of_play() {
    // Three kinds without play: their groups' mobility comes from `G⁻¹`.
    let job = described(
        "[clearance]\nr_radial = 1e-4\n[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = { start = 0.0, stop = 2.0, n = 41 }\nz = 2.0\npsi = { offset = 0.0, harmonics = [{ amplitude = 0.3, period = 2.0 }] }\ntheta = 0.1\n",
    );
    check(&job, &["t"], 0);
}

#[test]
fn only_a_builtin_description_is_given_the_kernel() {
    let text = format!("{KINDS}[grid]\nz = 2.05\npsi = 0.1\ntheta = 0.2\n");
    let job = described(&text);
    assert!(uses_kernel(&job, "d.toml").unwrap());
    // Each of these makes it another mechanism, or asks for what the kernel does not do.
    let mut moved = job.clone();
    moved.mechanism.limb.as_mut().unwrap()[1].joints[2].at[0] += 1e-3;
    let mut exact = job.clone();
    exact.analysis.exact = true;
    let mut heavier = job.clone();
    heavier.mechanism.limb.as_mut().unwrap()[2].bodies[1].mass += 0.5;
    for other in [moved, exact, heavier] {
        assert!(!uses_kernel(&other, "d.toml").unwrap());
    }
    let builtin = JobSpec::from_toml_str(&text, "b.toml").unwrap();
    assert!(!uses_kernel(&builtin, "b.toml").unwrap(), "a built-in job has no description");
}

const UPS_KINDS: &str = "[clearance]\ns_radial = 1e-4\nu_radial = 2e-4\nu_angular = 1e-4\n\
[mass]\npoints = [{ mass = 5.0, at = [0.05, 0.0, 0.3] }]\n[load]\nforce = [3.0, -2.0, 5.0]\nmoment = [0.4, 0.1, -0.3]\n";

#[test]
fn the_6ups_kernel_gives_the_general_path_on_a_grid() {
    let job = described(&format!(
        "[mechanism]\nkind = \"6-UPS\"\n{UPS_KINDS}[grid]\nx = {{ start = -0.15, stop = 0.15, n = 13 }}\ny = 0.02\nz = 0.7\nphi = 0.05\n\
         psi = {{ start = -0.2, stop = 0.2, n = 11 }}\ntheta = -0.1\n"
    ));
    check(&job, &["x", "psi"], 20);
}

#[test]
fn a_6ups_of_its_own_layout_in_dynamics_is_the_general_path() {
    // Base points, platform points and U axes of its own, other legs, one kind of play.
    let job = described(
        "[mechanism]\nkind = \"6-UPS\"\nbase_points = [[0.5, -0.1, 0.0], [0.45, 0.15, 0.02], [-0.1, 0.5, 0.0], [-0.3, 0.38, -0.01], [-0.35, -0.35, 0.0], [-0.1, -0.5, 0.03]]\n\
         platform_angles_deg = [-40.0, 40.0, 80.0, 160.0, 200.0, 280.0]\nplatform_radius = 0.25\n\
         u_axes = [[0.2, 1.0, 0.1], [-0.3, 1.0, 0.0], [-1.0, -0.2, 0.0], [-0.8, -0.6, 0.1], [0.7, -0.7, 0.0], [1.0, 0.1, -0.1]]\n\
         cylinder_length = 0.45\npiston_length = 0.55\n[mass]\ncylinder = 2.0\npiston = 0.5\nplatform = 8.0\n\
         [clearance]\nu_radial = 1e-4\n[analysis]\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = { start = 0.0, stop = 1.0, n = 41 }\nx = { offset = 0.0, harmonics = [{ amplitude = 0.05, period = 1.0 }] }\n\
         y = 0.01\nz = 0.7\nphi = 0.02\npsi = { offset = 0.0, harmonics = [{ amplitude = 0.15, period = 0.5 }] }\ntheta = 0.05\n",
    );
    check(&job, &["t"], 0);
}

#[test]
fn only_a_builtin_6ups_description_is_given_the_kernel() {
    let text = format!(
        "[mechanism]\nkind = \"6-UPS\"\n{UPS_KINDS}[grid]\nx = 0.01\ny = 0.0\nz = 0.75\nphi = 0.0\npsi = 0.1\ntheta = 0.0\n"
    );
    let job = described(&text);
    assert!(uses_kernel(&job, "d.toml").unwrap());
    let mut moved = job.clone();
    limbs(&mut moved)[4].joints[2].at[1] += 1e-3;
    let mut exact = job.clone();
    exact.analysis.exact = true;
    let mut heavier = job.clone();
    limbs(&mut heavier)[2].bodies[1].mass += 0.5;
    let mut turned = job.clone();
    // The U joint's axes exchanged: the one fixed in the base is the other.
    limbs(&mut turned)[0].joints[0].axes.as_mut().unwrap().swap(0, 1);
    for other in [moved, exact, heavier, turned] {
        assert!(!uses_kernel(&other, "d.toml").unwrap());
    }
}

/// The limbs of a description.
fn limbs(job: &mut JobSpec) -> &mut Vec<clearance_model::custom::LimbSpec> {
    job.mechanism.limb.as_mut().unwrap()
}
