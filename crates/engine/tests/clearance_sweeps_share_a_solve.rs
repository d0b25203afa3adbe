//! Variants that differ only in their clearance magnitudes are solved once per group
//! and scaled (docs/model.md §§5, 6, 8). Their data must be those of solving every
//! variant alone: the same rows, statuses, dominant joints and switches, and every
//! number to round-off (1e-12 of the largest magnitude of its column). Checked on a
//! 3-PRS grid sweeping masses crossed with clearances (a kind that is zero in some
//! variants, the symmetry plane where `r_axial` is indeterminate), on a 3-RPS
//! trajectory in both modes with unreachable poses, on a 6-UPS grid, on a custom
//! mechanism with exact errors (its members share each pose's kinematics and reactions
//! and take up their own clearances), with both writers, in shards and resumed.

mod common;

use std::path::Path;

use arrow::array::{Array, ArrayRef, Float64Array, RecordBatch, StringArray};
use clearance_engine::{JobSpec, Layout, RunOptions, Writer, run};
use common::{read, read_parts};

/// 3 `r_axial` (one zero) × 2 masses × 2 `s_radial` (one zero): 2 groups of 6 (one
/// per mass), whose members are not consecutive variants.
const GRID: &str = r#"
name = "groups_grid"
[mass]
points = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_angular = 1e-4
[grid]
z = { start = 1.95, stop = 2.1, n = 3 }
psi = { start = -1.4, stop = 1.4, n = 29 }
theta = { start = -1.4, stop = 1.4, n = 21 }
[[sweep]]
param = "clearance.r_axial"
values = [0.0, 5e-5, 2e-4]
[[sweep]]
param = "mass.points.0.mass"
values = [0.0, 30.0]
[[sweep]]
param = "clearance.s_radial"
values = [1e-4, 0.0]
"#;

/// A 3-RPS rising past its longest leg and back (unreachable poses) in kinetostatics
/// and dynamics, where the inertial loads join the reactions.
const TRAJECTORY: &str = r#"
name = "groups_trajectory"
[mechanism]
kind = "3-RPS"
[clearance]
s_radial = 1e-4
r_radial = 1e-4
r_axial = 1e-4
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 0.0, stop = 4.0, n = 2001 }
z = { offset = 1.3, harmonics = [ { amplitude = 0.45, period = 4.0, phase = 0.0 } ] }
psi = 0.1
theta = { offset = 0.0, harmonics = [ { amplitude = 0.3, period = 2.0, phase = 0.0 } ] }
[[sweep]]
param = "mass.platform"
values = [9.8, 30.0]
[[sweep]]
param = "clearance.r_radial"
values = [2e-4, 0.0, 1e-5]
[[sweep]]
param = "clearance.r_angular"
values = [0.0, 1e-3]
"#;

/// A 6-UPS orientation grid reaching past its strokes (unreachable poses), the
/// harmless `u_angular` play in some variants, `s_radial` zero in others.
const UPS: &str = r#"
name = "groups_ups"
[mechanism]
kind = "6-UPS"
[mass]
points = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]
[clearance]
s_radial = 1e-4
u_radial = 1e-4
[grid]
x = 0.02
y = -0.01
z = { start = 0.6, stop = 1.25, n = 4 }
phi = 0.05
psi = { start = -0.4, stop = 0.4, n = 17 }
theta = { start = -0.4, stop = 0.4, n = 17 }
[[sweep]]
param = "clearance.u_radial"
values = [2e-4, 5e-5]
[[sweep]]
param = "mass.points.0.mass"
values = [0.0, 5.0]
[[sweep]]
param = "clearance.s_radial"
values = [0.0, 1e-4]
[[sweep]]
param = "clearance.u_angular"
values = [0.0, 1e-3]
"#;

/// A custom 3-RRS (its magnitudes per joint group, one a per-limb list) sweeping a
/// clearance (one value zero) crossed with the platform's mass, with exact errors, in
/// both modes along a trajectory: its members share each pose's kinematics and
/// reactions and take up their own clearances.
const CUSTOM: &str = r#"
name = "groups_custom"
[mechanism]
kind = "custom"
inputs = ["z", "psi", "theta"]
home = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0]
[[mechanism.limb]]
repeat = 3
joints = [
  { type = "R", name = "crank", at = [0.25, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true, range = [-1.5, 1.5] },
  { type = "R", name = "knee", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0] },
  { type = "S", at = [0.15, 0.0, 0.6] },
]
bodies = [{ mass = 1.2 }, { mass = 2.0 }]
[mass]
platform = 5.0
[clearance]
knee_radial = 5e-5
knee_axial = 5e-5
crank_backlash = [2e-4, 1e-4, 2e-4]
s_radial = 2e-5
[analysis]
modes = ["kinetostatic", "dynamic"]
exact = true
[trajectory]
time = { start = 0.0, stop = 3.0, n = 301 }
z = { offset = 0.6, harmonics = [ { amplitude = 0.03, period = 1.5, phase = 0.0 } ] }
psi = { offset = 0.0, harmonics = [ { amplitude = 0.25, period = 1.7, phase = 0.4 } ] }
theta = { offset = 0.0, harmonics = [ { amplitude = 0.3, period = 2.3, phase = 0.0 } ] }
[[sweep]]
param = "clearance.knee_axial"
values = [0.0, 5e-5, 2e-4]
[[sweep]]
param = "mass.platform"
values = [5.0, 20.0]
"#;

fn options(out: &Path, chunk_size: u64, writer: Writer, shard: Option<(u64, u64)>, resume: bool) -> RunOptions {
    RunOptions { chunk_size, writer, shard, resume, ..common::options(out) }
}

/// The poses of one variant of a run, every part in (mode, chunk) order, as one batch.
fn variant_rows(root: &Path, job: &JobSpec, variant: u64, chunk_size: u64) -> RecordBatch {
    let layout = Layout::new(root);
    let parts = job.sample_count().div_ceil(chunk_size);
    read_parts(
        job.analysis
            .modes
            .iter()
            .flat_map(|&mode| (0..parts).map(move |c| (mode, c)))
            .map(|(mode, chunk)| layout.part(variant, mode, chunk)),
    )
}

/// Rows of `batch` whose `variant` column is `variant`.
fn rows_of(batch: &RecordBatch, variant: u64) -> RecordBatch {
    let v = batch.column_by_name("variant").unwrap();
    let v = arrow::compute::cast(v, &arrow::datatypes::DataType::UInt64).unwrap();
    let v = v.as_any().downcast_ref::<arrow::array::UInt64Array>().unwrap();
    let mask: arrow::array::BooleanArray = v.iter().map(|x| Some(x == Some(variant))).collect();
    arrow::compute::filter_record_batch(batch, &mask).unwrap()
}

/// Every column of `got` equals `expected`'s: the same nulls, non-float values
/// exactly, floats within `REL` of the largest magnitude of that column. The
/// columns named in `skip` are not compared (identity that differs by design).
fn assert_close(what: &str, expected: &RecordBatch, got: &RecordBatch, skip: &[&str]) -> usize {
    const REL: f64 = 1e-12;
    assert_eq!(expected.num_rows(), got.num_rows(), "{what}: rows");
    let names: Vec<String> = expected.schema().fields().iter().map(|f| f.name().clone()).collect();
    let got_names: Vec<String> = got.schema().fields().iter().map(|f| f.name().clone()).collect();
    assert_eq!(names, got_names, "{what}: columns");
    let mut compared = 0;
    for (i, name) in names.iter().enumerate().filter(|(_, n)| !skip.contains(&n.as_str())) {
        let (e, g): (&ArrayRef, &ArrayRef) = (expected.column(i), got.column(i));
        assert_eq!(e.logical_nulls(), g.logical_nulls(), "{what} {name}: nulls");
        match (e.as_any().downcast_ref::<Float64Array>(), g.as_any().downcast_ref::<Float64Array>()) {
            (Some(e), Some(g)) => {
                let valid: Vec<usize> = (0..e.len()).filter(|&k| e.is_valid(k) && e.value(k).is_finite()).collect();
                let scale = valid.iter().map(|&k| e.value(k).abs()).fold(0.0, f64::max);
                for k in valid {
                    let (x, y) = (e.value(k), g.value(k));
                    assert!((x - y).abs() <= REL * scale, "{what} {name}[{k}]: {y} against {x} alone (scale {scale})");
                    compared += 1;
                }
            }
            _ => assert_eq!(e.to_data(), g.to_data(), "{what} {name}"),
        }
    }
    compared
}

/// Runs `text` once, grouped, then each variant as a job of its own, and compares
/// poses, switches and summary rows. Returns the statuses seen and the switches.
fn check(text: &str, chunk_size: u64, writer: Writer) -> (Vec<String>, usize) {
    let job = JobSpec::from_toml_str(text, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let grouped = dir.path().join("grouped");
    run(&job, "t.toml", &options(&grouped, chunk_size, writer, None, false)).unwrap();
    let switches = read(&grouped.join("discontinuities.parquet"));
    let summary = read(&grouped.join("summary.parquet"));
    let mut statuses = Vec::new();
    let mut switch_rows = 0;
    for v in job.variants("t.toml").unwrap() {
        let alone = dir.path().join(format!("alone-{}", v.index));
        run(&v.job, "t.toml", &options(&alone, chunk_size, writer, None, false)).unwrap();
        let what = format!("{} variant {} ({:?})", job.name(), v.index, v.params);
        let e = variant_rows(&alone, &v.job, 0, chunk_size);
        let g = variant_rows(&grouped, &job, v.index, chunk_size);
        assert!(assert_close(&what, &e, &g, &[]) > 0, "{what}: nothing compared");
        let status = e.column_by_name("status").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
        statuses.extend(status.iter().flatten().map(str::to_string));
        // The variant's switches: the same kinds, limbs, places, loads and jumps.
        let (e, g) = (read(&alone.join("discontinuities.parquet")), rows_of(&switches, v.index));
        assert_close(&format!("{what} switches"), &e, &g, &["variant"]);
        switch_rows += g.num_rows();
        // Its summary rows: statistics and switch counts (not its swept values, which
        // a job of its own does not have).
        let (e, g) = (read(&alone.join("summary.parquet")), rows_of(&summary, v.index));
        let columns: Vec<usize> = e.schema().fields().iter().map(|f| g.schema().index_of(f.name()).unwrap()).collect();
        let g = g.project(&columns).unwrap();
        assert_close(&format!("{what} summary"), &e, &g, &["variant"]);
    }
    (statuses, switch_rows)
}

#[test]
fn a_grid_sweeping_masses_and_clearances_equals_each_variant_alone() {
    for (chunk_size, writer) in [(700, Writer::Engine), (1575, Writer::Arrow)] {
        let (statuses, switches) = check(GRID, chunk_size, writer);
        for s in ["ok", "indeterminate_contact"] {
            assert!(statuses.iter().any(|x| x == s), "no {s} row");
        }
        assert!(switches > 100, "{switches} switches");
    }
}

#[test]
fn a_trajectory_in_both_modes_equals_each_variant_alone() {
    let (statuses, switches) = check(TRAJECTORY, 2001, Writer::Engine);
    for s in ["ok", "unreachable"] {
        assert!(statuses.iter().any(|x| x == s), "no {s} row");
    }
    assert!(switches > 10, "{switches} switches");
}

#[test]
fn a_six_ups_grid_sweeping_masses_and_clearances_equals_each_variant_alone() {
    let (statuses, switches) = check(UPS, 500, Writer::Engine);
    for s in ["ok", "unreachable"] {
        assert!(statuses.iter().any(|x| x == s), "no {s} row");
    }
    assert!(switches > 0, "{switches} switches");
}

/// Shards (of work that spans several variants) and a resumed run give the
/// grouped single run's data, bit for bit.
#[test]
fn shards_and_resume_give_the_single_run() {
    let job = JobSpec::from_toml_str(GRID, "t.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (single, sharded) = (dir.path().join("single"), dir.path().join("sharded"));
    run(&job, "t.toml", &options(&single, 700, Writer::Engine, None, false)).unwrap();
    for i in 0..3 {
        run(&job, "t.toml", &options(&sharded, 700, Writer::Engine, Some((i, 3)), false)).unwrap();
    }
    let layout = Layout::new(&sharded);
    // Lose one member's part of a shared work and the run's end: resume recomputes it.
    let mode = job.analysis.modes[0];
    std::fs::remove_file(layout.part(4, mode, 1)).unwrap();
    std::fs::remove_file(layout.success()).unwrap();
    run(&job, "t.toml", &options(&sharded, 700, Writer::Engine, None, true)).unwrap();
    for v in 0..job.variant_count() {
        let (a, b) = (variant_rows(&single, &job, v, 700), variant_rows(&sharded, &job, v, 700));
        assert_eq!(a, b, "variant {v}");
    }
    for file in ["discontinuities.parquet", "summary.parquet"] {
        assert_eq!(read(&single.join(file)), read(&sharded.join(file)), "{file}");
    }
}

#[test]
fn a_custom_mechanism_sweeping_a_clearance_equals_each_variant_alone() {
    let (statuses, switches) = check(CUSTOM, 128, Writer::Engine);
    assert!(statuses.iter().any(|x| x == "ok"), "no ok row");
    assert!(switches > 10, "{switches} switches");
}
