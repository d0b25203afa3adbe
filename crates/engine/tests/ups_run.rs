//! A 6-UPS run end to end: the directory of a run, `solve` equal to the parts bit
//! for bit, shards whose union is the single run, unreachable poses as a status (no
//! NaN, no panic), `u_angular`'s error zero, and the tables' 6-UPS columns.

mod common;

use arrow::array::{Array, Float64Array, RecordBatch, StringArray};
use clearance_engine::{ColumnSet, JobSpec, Layout, RunOptions, SolveOptions, run, solve};
use clearance_model::Mode;
use common::{read, read_parts};

const JOB: &str = r#"
name = "ups"
[mechanism]
kind = "6-UPS"
[mass]
points = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]
[clearance]
s_radial = 1e-4
u_radial = 1e-4
u_angular = 1e-3
[analysis]
exact = true
[grid]
x = { start = -0.05, stop = 0.05, n = 3 }
y = 0.01
z = { start = 0.75, stop = 1.2, n = 2 }
phi = 0.05
psi = { start = -0.2, stop = 0.2, n = 5 }
theta = 0.1
"#;

fn options(out: &std::path::Path, shard: Option<(u64, u64)>) -> RunOptions {
    RunOptions { shard, chunk_size: 7, ..common::options(out) }
}

/// The job run once, and again in three shards one after another, `chunk_size`
/// samples a part: the two directories.
fn one_run_and_shards(text: &str, chunk_size: u64) -> (tempfile::TempDir, tempfile::TempDir) {
    let job = JobSpec::from_toml_str(text, "ups.toml").unwrap();
    let (one, many) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for (dir, shards) in [(&one, 1), (&many, 3)] {
        for i in 0..shards {
            let shard = (shards > 1).then_some((i, shards));
            run(&job, "ups.toml", &RunOptions { shard, chunk_size, ..common::options(dir.path()) }).unwrap();
        }
    }
    (one, many)
}

fn poses(layout: &Layout, parts: u64) -> RecordBatch {
    read_parts((0..parts).map(|c| layout.part(0, Mode::Kinetostatic, c)))
}

fn column<'a>(b: &'a RecordBatch, name: &str) -> &'a Float64Array {
    b.column_by_name(name).unwrap_or_else(|| panic!("no {name}")).as_any().downcast_ref().unwrap()
}

#[test]
fn a_run_writes_the_kinds_columns_and_solve_gives_the_same_rows() {
    let job = JobSpec::from_toml_str(JOB, "ups.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let report = run(&job, "ups.toml", &options(dir.path(), None)).unwrap();
    assert!(report.complete);
    assert_eq!(report.total, 30);
    let layout = Layout::new(dir.path());
    assert!(layout.success().exists() && layout.summary().exists() && layout.discontinuities().exists());
    let b = poses(&layout, 5);
    assert_eq!(b.num_rows(), 30);
    for name in ["x", "phi", "q6", "f_u6_z", "m_u6", "f_s6_x", "margin_u6_angular", "err_u_angular_x", "exact_err_z"] {
        assert!(b.column_by_name(name).is_some(), "{name}");
    }
    assert!(b.column_by_name("q7").is_none() && b.column_by_name("err_r_radial_x").is_none());
    // The legs cannot reach z = 1.2: those rows are unreachable, their errors null.
    let status: &StringArray = b.column_by_name("status").unwrap().as_any().downcast_ref().unwrap();
    let (mut ok, mut unreachable) = (0, 0);
    for i in 0..b.num_rows() {
        match status.value(i) {
            "ok" => ok += 1,
            "unreachable" => {
                unreachable += 1;
                assert!(column(&b, "err_x").is_null(i) && column(&b, "q1").is_null(i));
                assert!(!column(&b, "x").is_null(i));
            }
            s => panic!("status {s}"),
        }
    }
    assert_eq!((ok, unreachable), (15, 15));
    for f in b.columns() {
        if let Some(f) = f.as_any().downcast_ref::<Float64Array>() {
            assert!(f.iter().flatten().all(f64::is_finite), "no NaN is ever stored");
        }
    }
    // U-joint tilt play is harmless: its error is zero, computed.
    let total = column(&b, "err_x");
    for i in 0..b.num_rows() {
        if status.value(i) == "ok" {
            assert!(column(&b, "err_u_angular_x").value(i).abs() < 1e-17);
            assert!(column(&b, "err_u_angular_rz").value(i).abs() < 1e-16);
            let size: f64 = ["err_x", "err_y", "err_z"].iter().map(|c| column(&b, c).value(i).abs()).sum();
            assert!(size > 1e-6 && !total.is_null(i));
        }
    }
    // `solve` gives the same rows, bit for bit, after its `variant` column.
    let opts = SolveOptions { columns: ColumnSet::Full, ..SolveOptions::default() };
    let solved = solve(&job, "ups.toml", &opts).unwrap();
    assert_eq!(solved.len(), 1);
    let s = solved[0].project(&(1..solved[0].num_columns()).collect::<Vec<_>>()).unwrap();
    assert_eq!(s.schema().fields(), b.schema().fields());
    for (x, y) in s.columns().iter().zip(b.columns()) {
        assert_eq!(x.to_data(), y.to_data());
    }
    let summary = read(&layout.summary());
    assert_eq!(summary.num_rows(), 1);
    assert!(summary.column_by_name("dp_u_angular_max").is_some());
    assert!(summary.column_by_name("switches_u_radial").is_some());
    let switches = read(&layout.discontinuities());
    for name in ["x", "y", "z", "phi", "psi", "theta", "limb", "kind"] {
        assert!(switches.column_by_name(name).is_some(), "{name}");
    }
}

#[test]
fn shards_make_the_same_run() {
    let (one, many) = one_run_and_shards(JOB, 7);
    let (a, b) = (Layout::new(one.path()), Layout::new(many.path()));
    assert!(b.success().exists());
    assert_eq!(poses(&a, 5), poses(&b, 5));
    assert_eq!(read(&a.summary()), read(&b.summary()));
    assert_eq!(read(&a.discontinuities()), read(&b.discontinuities()));
}

/// A grid with switches on every kind of line: a single run, whose search reads
/// every sample's loads and errors from its pass, and shards, whose last one reads
/// its own units and solves the others' samples again, find the same switches, bit
/// for bit.
#[test]
fn shards_find_the_switches_of_one_run() {
    let text = r#"
name = "ups_switches"
[mechanism]
kind = "6-UPS"
[mass]
points = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]
[clearance]
s_radial = 1e-4
u_radial = 1e-4
[grid]
x = { start = -0.15, stop = 0.15, n = 13 }
y = { start = -0.15, stop = 0.15, n = 11 }
z = { start = 0.6, stop = 0.85, n = 3 }
phi = 0.05
psi = 0.1
theta = -0.1
"#;
    let (one, many) = one_run_and_shards(text, 64);
    let (a, b) = (Layout::new(one.path()), Layout::new(many.path()));
    let switches = read(&a.discontinuities());
    assert!(switches.num_rows() > 100, "{} switches", switches.num_rows());
    assert_eq!(switches, read(&b.discontinuities()));
    assert_eq!(read(&a.summary()), read(&b.summary()));
}

/// A 6-UPS takes poses in place of its grid, all six coordinates: given the grid's own
/// inputs back, `solve` returns the grid's rows bit for bit (the exact errors too); five
/// of the six are refused, naming the one missing.
#[test]
fn the_grids_poses_given_back_give_its_rows() {
    use clearance_engine::{EngineError, Poses};
    let job = JobSpec::from_toml_str(JOB, "ups.toml").unwrap();
    let grid = solve(&job, "ups.toml", &SolveOptions::default()).unwrap().remove(0);
    assert_eq!(grid.num_rows(), 30);
    let coords = ["x", "y", "z", "phi", "psi", "theta"].map(|n| Some(column(&grid, n).values().to_vec()));
    let given = SolveOptions { poses: Some(Poses { coords: coords.clone() }), ..SolveOptions::default() };
    let poses = solve(&job, "ups.toml", &given).unwrap().remove(0);
    assert_eq!(poses.schema(), grid.schema());
    for (i, field) in grid.schema().fields().iter().enumerate() {
        assert_eq!(poses.column(i).to_data(), grid.column(i).to_data(), "{}", field.name());
    }
    let mut five = coords;
    five[3] = None;
    let e = solve(&job, "ups.toml", &SolveOptions { poses: Some(Poses { coords: five }), ..SolveOptions::default() })
        .expect_err("phi missing");
    assert!(matches!(e, EngineError::Samples(_)), "{e:?}");
    assert!(e.to_string().starts_with("phi missing: give all of x, y, z, phi, psi and theta"), "{e}");
}
