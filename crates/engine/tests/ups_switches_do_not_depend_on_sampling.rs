//! The 6-UPS switches along a grid line do not depend on how many samples the line has
//! (docs/model.md §8): the directions a dip's verdict compares are read where the load's
//! magnitude is twice the minimum, located between samples, and the jump between
//! those two points.
//!
//! The case is `jobs/ups_orientation_grid.toml` with a 0.2 m platform (the first
//! variant of `jobs/sweep_ups_platform_radius.toml`), along Θ over [−0.3, 0.3] at
//! Ψ = 0.16 and Ψ = 0.25. At Ψ = 0.16 limb 5's `f_S` dips to 3.77 N near Θ = 0.277;
//! with 4 samples along Θ the directions at Θ = 0.1 and 0.3, where the walks from the
//! dip stopped when they were read at samples, turn by 93°, and the search reported a
//! switch there that 7, 13 and 49 samples did not show. Between the points where the
//! magnitude is twice the minimum the load turns by less than 90°: no switch, at any
//! sampling. At Ψ = 0.25 limb 5's dip near Θ = 0.186 is a switch at every sampling,
//! with the same margin and, now, the same jump (read at samples, it changed with them).

mod common;

use common::{column, replaced};

use arrow::array::{Float64Array, StringArray, UInt32Array};
use clearance_engine::{ColumnSet, JobSpec, Layout, SolveOptions, run, solve};

fn job(theta_samples: usize) -> String {
    let text = include_str!("../../../jobs/ups_orientation_grid.toml");
    let text = replaced(text, "kind = \"6-UPS\"", "kind = \"6-UPS\"\nplatform_radius = 0.2");
    let text =
        replaced(&text, "psi = { start = -0.3, stop = 0.3, n = 61 }", "psi = { start = 0.16, stop = 0.25, n = 2 }");
    replaced(
        &text,
        "theta = { start = -0.3, stop = 0.3, n = 61 }",
        &format!("theta = {{ start = -0.3, stop = 0.3, n = {theta_samples} }}"),
    )
}

/// One switch along Θ: limb, kind, Ψ, Θ, margin, jump.
type Switch = (u32, String, f64, f64, f64, [f64; 6]);

fn switches_along_theta(theta_samples: usize) -> Vec<Switch> {
    let job = JobSpec::from_toml_str(&job(theta_samples), "ups.toml").unwrap();
    let dir = tempfile::tempdir().unwrap();
    run(&job, "ups.toml", &common::options(dir.path())).unwrap();
    let d = common::read(&Layout::new(dir.path()).discontinuities());
    let f = |name: &str| column::<Float64Array>(&d, name);
    let (along, kind) = (column::<StringArray>(&d, "along"), column::<StringArray>(&d, "kind"));
    let limb = column::<UInt32Array>(&d, "limb");
    let jump = ["x", "y", "z", "rx", "ry", "rz"].map(|c| f(&format!("jump_{c}")));
    (0..d.num_rows())
        .filter(|&i| along.value(i) == "theta")
        .map(|i| {
            let j = jump.map(|c| c.value(i));
            (limb.value(i), kind.value(i).to_string(), f("psi").value(i), f("theta").value(i), f("margin").value(i), j)
        })
        .collect()
}

/// The premise: with 4 samples along Θ, limb 5's `f_S` at Ψ = 0.16 falls all the way
/// to Θ = 0.3, and its directions at Θ = 0.1 (above twice the dip) and Θ = 0.3 (the
/// path's end, below it) turn by more than 90°: read there, the dip was a switch.
#[test]
fn the_samples_of_the_coarse_line_turn_by_more_than_90_degrees() {
    let job = JobSpec::from_toml_str(&job(4), "ups.toml").unwrap();
    let batches =
        solve(&job, "ups.toml", &SolveOptions { columns: ColumnSet::Full, ..SolveOptions::default() }).unwrap();
    let b = &batches[0];
    let (psi, theta) = (column::<Float64Array>(b, "psi"), column::<Float64Array>(b, "theta"));
    let load = |t: f64| -> [f64; 3] {
        let i = (0..b.num_rows()).find(|&i| (psi.value(i) - 0.16).abs() < 1e-12 && (theta.value(i) - t).abs() < 1e-12);
        let i = i.unwrap_or_else(|| panic!("a sample at Θ = {t}"));
        ["x", "y", "z"].map(|c| column::<Float64Array>(b, &format!("f_s5_{c}")).value(i))
    };
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let (a, c) = (load(0.1), load(0.3));
    assert!(norm(load(-0.1)) > norm(a) && norm(a) > norm(c), "the magnitude falls to the end");
    let cosine = (a[0] * c[0] + a[1] * c[1] + a[2] * c[2]) / (norm(a) * norm(c));
    let turn = cosine.acos().to_degrees();
    assert!(turn > 90.0 && turn < 95.0, "{turn}°");
}

#[test]
fn the_switches_along_theta_are_the_same_at_4_7_13_and_49_samples() {
    let coarse = switches_along_theta(4);
    // One switch: limb 5's `s_radial` at Ψ = 0.25; none at Ψ = 0.16.
    let [(limb, kind, psi, theta, margin, jump)] = &coarse[..] else { panic!("{coarse:?}") };
    assert_eq!((*limb, kind.as_str()), (5, "s_radial"));
    assert!((psi - 0.25).abs() < 1e-12 && (theta - 0.1864).abs() < 1e-4, "{psi} {theta}");
    assert!((margin - 3.871).abs() < 1e-3, "{margin}");
    let size = jump.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(size > 1e-5, "{jump:?}");
    for n in [7, 13, 49] {
        let found = switches_along_theta(n);
        let [(l, k, p, t, m, j)] = &found[..] else { panic!("{n} samples: {found:?}") };
        assert_eq!((l, k, p), (limb, kind, psi), "{n} samples");
        assert!((t - theta).abs() < 1e-9, "{n} samples: Θ {t} against {theta}");
        assert!((m - margin).abs() < 1e-9 * margin, "{n} samples: margin {m} against {margin}");
        for i in 0..6 {
            assert!((j[i] - jump[i]).abs() < 1e-6 * size, "{n} samples: jump {j:?} against {jump:?}");
        }
    }
}
