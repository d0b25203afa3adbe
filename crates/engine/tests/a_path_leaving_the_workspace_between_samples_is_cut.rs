//! A path that leaves the workspace between two reachable samples is cut there, as by
//! an unreachable sample (docs/model.md §8), on the 3-limb kinds as on the others: no
//! switch is located in that interval. Before, the 3-limb search read a point it could
//! not solve as a zero of a scalar load (a root at the edge of the unreachable stretch,
//! with no margin) and as an infinite magnitude of a vector one.
//!
//! The case is `jobs/rps_trajectory.toml` with 6 samples (t = 0, 0.8, … 4.0) and the
//! legs' stroke ending at 1.35 m: leg 2 is 1.24 m long at t = 0 and 1.29 m at t = 0.8, and
//! longer than 1.35 m between (its longest, 1.363 m, near t = 0.47), where the same job
//! without the limit has an `r_axial` and an `s_radial` switch of limb 2.

mod common;

use common::{column, replaced};

use arrow::array::{Float64Array, StringArray, UInt32Array};
use clearance_engine::{JobSpec, Layout, SolveOptions, run, solve};

/// The cut interval of `t`, between the samples 0 and 0.8.
const CUT: (f64, f64) = (0.0, 0.8);

/// The job with its times, with or without the limit.
fn job_at(stroke_limit: bool, time: &str) -> String {
    let text = include_str!("../../../jobs/rps_trajectory.toml");
    let text = replaced(text, "time = { start = 0.0, stop = 4.0, n = 4001 }", &format!("time = {time}"));
    if stroke_limit { replaced(&text, "kind = \"3-RPS\"", "kind = \"3-RPS\"\nmax_length = 1.35") } else { text }
}

fn job(stroke_limit: bool) -> String {
    job_at(stroke_limit, "{ start = 0.0, stop = 4.0, n = 6 }")
}

/// One switch: mode, limb, kind, t, margin.
type Switch = (String, u32, String, f64, f64);

fn switches(stroke_limit: bool) -> Vec<Switch> {
    let job = JobSpec::from_toml_str(&job(stroke_limit), "rps.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    run(&job, "rps.toml", &common::options(dir.path())).unwrap();
    let d = common::read(&Layout::new(dir.path()).discontinuities());
    let (mode, kind) = (column::<StringArray>(&d, "mode"), column::<StringArray>(&d, "kind"));
    let (limb, t, margin) =
        (column::<UInt32Array>(&d, "limb"), column::<Float64Array>(&d, "t"), column::<Float64Array>(&d, "margin"));
    (0..d.num_rows())
        .map(|i| (mode.value(i).to_string(), limb.value(i), kind.value(i).to_string(), t.value(i), margin.value(i)))
        .collect()
}

fn within(s: &Switch, (a, b): (f64, f64)) -> bool {
    s.3 > a && s.3 < b
}

#[test]
fn the_samples_either_side_are_reachable_and_the_leg_passes_its_stroke_between() {
    let job = JobSpec::from_toml_str(&job(true), "rps.toml").unwrap();
    let batches = solve(&job, "rps.toml", &SolveOptions::default()).unwrap();
    let mut seen = 0;
    for b in &batches {
        let (t, status) = (column::<Float64Array>(b, "t"), column::<StringArray>(b, "status"));
        for r in 0..b.num_rows() {
            if t.value(r) == CUT.0 || t.value(r) == CUT.1 {
                assert_eq!(status.value(r), "ok", "t = {}", t.value(r));
                seen += 1;
            }
        }
    }
    assert_eq!(seen, 4, "both samples in both modes");
    // Halfway between them the leg is past its stroke: the pose cannot be reached.
    let mid = JobSpec::from_toml_str(&job_at(true, "{ start = 0.4, stop = 0.4, n = 1 }"), "rps.toml").unwrap();
    let b = &solve(&mid, "rps.toml", &SolveOptions::default()).unwrap()[0];
    assert_eq!(column::<StringArray>(b, "status").value(0), "unreachable");
}

#[test]
fn no_switch_lies_where_the_path_is_cut() {
    let (open, cut) = (switches(false), switches(true));
    // Without the limit, the interval holds switches of both rules.
    for kind in ["r_axial", "s_radial"] {
        assert!(
            open.iter().any(|s| s.2 == kind && within(s, CUT)),
            "the job without the limit has an {kind} switch between t = 0 and 0.8: {open:?}"
        );
    }
    // With it, none; and every switch has its margin.
    assert!(cut.iter().all(|s| !within(s, CUT)), "{cut:?}");
    assert!(cut.iter().all(|s| s.4.is_finite()), "{cut:?}");
    // Between the next two samples, reachable in both runs and with no stretch between
    // them that is not, the same switches: the cut touches only its interval.
    // (The limit makes the sample at t = 2.4 unreachable too, and a piece of path that
    // starts there reads its directions differently.)
    let piece = (0.8, 1.6);
    let a: Vec<_> = open.iter().filter(|s| within(s, piece)).collect();
    let b: Vec<_> = cut.iter().filter(|s| within(s, piece)).collect();
    assert!(!a.is_empty());
    // The same to the location tolerance: a root's first step reads a sample beyond
    // the interval, which the unreachable sample at t = 2.4 changes.
    let same = |x: &Switch, y: &Switch| {
        (&x.0, x.1, &x.2) == (&y.0, y.1, &y.2) && (x.3 - y.3).abs() < 1e-9 && (x.4 - y.4).abs() < 1e-9
    };
    assert!(
        a.len() == b.len() && a.iter().zip(&b).all(|(x, y)| same(x, y)),
        "between t = {} and {}: {a:?} against {b:?}",
        piece.0,
        piece.1
    );
}
