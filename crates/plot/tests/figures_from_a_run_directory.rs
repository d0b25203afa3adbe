//! `plot_run` on small run directories written in the test: the expected files,
//! their pixel sizes, real content (not a blank canvas), nulls drawn grey and the
//! switches of discontinuities.parquet drawn where they belong.

mod common;

use clearance_model::Mode;
use clearance_parquet::ColumnSet;
use clearance_plot::{ERROR_SIZE, MAP_SIZE, PlotError, plot_run};
use common::{HEADER, Png, SwitchRow, body_difference, files_under, make_run, write_switches};

const GRID_JOB: &str = r#"
name = "small_grid"
[clearance]
r_radial = 1e-4
r_axial = 1e-4
[grid]
z = { start = 2.05, stop = 2.15, n = 2 }
psi = { start = -0.4, stop = 0.4, n = 9 }
theta = { start = -0.3, stop = 0.3, n = 7 }
"#;

#[test]
fn grid_maps_for_the_total_and_each_enabled_kind() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    make_run(&run, GRID_JOB, ColumnSet::Standard);

    let out = tmp.path().join("plots");
    let written = plot_run(&run, &out).unwrap();
    let expected = [
        "variant=0/dominant_kinetostatic.png",
        "variant=0/envelope_kinetostatic.png",
        "variant=0/r_axial_kinetostatic.png",
        "variant=0/r_radial_kinetostatic.png",
        "variant=0/total_kinetostatic.png",
    ];
    assert_eq!(files_under(&out), expected);
    assert_eq!(written.len(), 5);
    // The envelope exists wherever the pose is solvable, on the symmetry plane too:
    // a full map, unlike the total error's.
    let envelope = Png::open(&out.join("variant=0/envelope_kinetostatic.png"));
    assert_eq!((envelope.width, envelope.height), MAP_SIZE);
    assert!(envelope.distinct_colours() > 200, "{} colours", envelope.distinct_colours());
    assert!(written.iter().all(|p| p.starts_with(&out) && p.is_file()));

    let total = Png::open(&out.join("variant=0/total_kinetostatic.png"));
    let radial = Png::open(&out.join("variant=0/r_radial_kinetostatic.png"));
    for png in [&total, &radial] {
        assert_eq!((png.width, png.height), MAP_SIZE);
        assert!(png.distinct_colours() > 200, "{} colours", png.distinct_colours());
        assert!(png.ink() > 0.4, "ink {}", png.ink());
    }
    // Ψ = 0 is a grid column: limb 1's axial load vanishes there, the total is null
    // (a grey column in each of the six maps), the radial kind alone is not.
    let grey = [185, 185, 185];
    assert!(
        total.count(grey) > radial.count(grey) + 6 * 2000,
        "grey pixels: total {}, r_radial {}",
        total.count(grey),
        radial.count(grey)
    );

    // Switches: drawn at the first z, never from another z.
    let at = |z: f64| SwitchRow {
        variant: 0,
        mode: "kinetostatic",
        kind: "r_axial",
        along: "theta",
        t: None,
        z,
        psi: 0.2,
        theta: 0.05,
    };
    write_switches(&run, &[at(2.15)]);
    let elsewhere = tmp.path().join("elsewhere");
    plot_run(&run, &elsewhere).unwrap();
    let elsewhere = Png::open(&elsewhere.join("variant=0/total_kinetostatic.png"));
    assert_eq!(body_difference(&total, &elsewhere), 0);

    write_switches(&run, &[at(2.05)]);
    let here = tmp.path().join("here");
    plot_run(&run, &here).unwrap();
    let total_here = Png::open(&here.join("variant=0/total_kinetostatic.png"));
    let radial_here = Png::open(&here.join("variant=0/r_radial_kinetostatic.png"));
    // One dot in each of six panels; an r_axial switch is not on the r_radial figure.
    assert!(body_difference(&total, &total_here) >= 6 * 4);
    assert_eq!(body_difference(&radial, &radial_here), 0);
}

const TRAJECTORY_JOB: &str = r#"
name = "small_trajectory"
[mass]
points = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]
[clearance]
r_radial = 1e-4
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 1.25, stop = 3.75, n = 41 }
z = 2.05
psi = 0.0
theta = { harmonics = [ { amplitude = 0.5, period = 5.0 } ] }
[[sweep]]
param = "mass.points.0.mass"
values = [0.0, 30.0]
"#;

#[test]
fn trajectory_figures_for_each_variant_with_both_modes() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    make_run(&run, TRAJECTORY_JOB, ColumnSet::Minimal);

    let out = tmp.path().join("plots");
    let written = plot_run(&run, &out).unwrap();
    // Minimal columns: no per-kind errors, so only the total.
    let per_variant = ["inputs_motion.png", "parasitic_motion.png", "total_trajectory.png"];
    let expected: Vec<String> =
        (0..2).flat_map(|k| per_variant.iter().map(move |f| format!("variant={k}/{f}"))).collect();
    assert_eq!(files_under(&out), expected);
    assert_eq!(written.len(), 6);

    for k in 0..2 {
        let dir = out.join(format!("variant={k}"));
        // Θ alone moves: one row of three panels; X, Y, Φ: three rows.
        for (file, size) in [
            ("inputs_motion.png", (1680, HEADER + 300)),
            ("parasitic_motion.png", (1680, HEADER + 3 * 300)),
            ("total_trajectory.png", ERROR_SIZE),
        ] {
            let png = Png::open(&dir.join(file));
            assert_eq!((png.width, png.height), size, "{file}");
            assert!(png.distinct_colours() > 20, "{file}: {} colours", png.distinct_colours());
            assert!(png.ink() > 0.03, "{file}: ink {}", png.ink());
        }
        // Kinetostatics black, dynamics blue.
        let errors = Png::open(&dir.join("total_trajectory.png"));
        assert!(errors.count([25, 90, 230]) > 1000);
        assert!(errors.count([0, 0, 0]) > 1000);
    }

    // A dynamic switch of variant 1 marks variant 1's figure only.
    let before: Vec<Png> = (0..2).map(|k| Png::open(&out.join(format!("variant={k}/total_trajectory.png")))).collect();
    write_switches(
        &run,
        &[SwitchRow {
            variant: 1,
            mode: "dynamic",
            kind: "r_radial",
            along: "t",
            t: Some(2.3),
            z: 2.05,
            psi: 0.0,
            theta: 0.1,
        }],
    );
    let marked = tmp.path().join("marked");
    plot_run(&run, &marked).unwrap();
    let after: Vec<Png> =
        (0..2).map(|k| Png::open(&marked.join(format!("variant={k}/total_trajectory.png")))).collect();
    assert_eq!(body_difference(&before[0], &after[0]), 0);
    assert!(body_difference(&before[1], &after[1]) > 6 * 100);
}

#[test]
fn an_unfinished_run_is_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    make_run(&run, GRID_JOB, ColumnSet::Minimal);
    std::fs::remove_file(run.join("_SUCCESS")).unwrap();
    let out = tmp.path().join("plots");
    let err = plot_run(&run, &out).unwrap_err();
    assert!(matches!(err, PlotError::NotARun { .. }), "{err}");
    assert!(err.to_string().contains("_SUCCESS"), "{err}");
    assert!(!out.exists());
}

/// The share of a uniform axis's extent nearest to each of its `n` samples: the
/// end samples own half a spacing, the others a whole one.
fn cell_shares(n: usize) -> Vec<f64> {
    (0..n).map(|i| if i == 0 || i == n - 1 { 0.5 } else { 1.0 } / (n - 1) as f64).collect()
}

#[test]
fn dominant_map_colours_each_pose_by_its_joint() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let job = make_run(&run, GRID_JOB, ColumnSet::Standard);
    let out = tmp.path().join("plots");
    plot_run(&run, &out).unwrap();
    let png = Png::open(&out.join("variant=0/dominant_kinetostatic.png"));
    assert_eq!((png.width, png.height), MAP_SIZE);

    // The joint of each pose of the first Z plane (9 Ψ × 7 Θ), solved here, and the
    // share of the map each should cover: the area nearest to its sample.
    let model = clearance_solver::Model::from_job(&job);
    let model = clearance_solver::Model { envelope: true, ..model };
    let source = clearance_grid::SampleSource::new(&job);
    let (n_psi, n_theta) = (9, 7);
    let (w_psi, w_theta) = (cell_shares(n_psi), cell_shares(n_theta));
    let mut expected: std::collections::BTreeMap<[u8; 3], f64> = Default::default();
    let mut ws = clearance_solver::Workspace::new();
    for i in 0..n_psi * n_theta {
        let r = clearance_solver::solve_pose(&model, &source.sample(i as u64), Mode::Kinetostatic, &mut ws);
        let colour = match r.dominant {
            Some((k, j)) => clearance_plot::dominant_colour(&clearance_solver::joint_name(k, j)).unwrap(),
            None => [185, 185, 185],
        };
        *expected.entry(colour).or_default() += w_psi[i / n_theta] * w_theta[i % n_theta];
    }
    assert!(expected.len() >= 3, "a map of one colour tests little: {expected:?}");

    // The map is the figure's left part, below the header, left of the 420-pixel legend.
    let map_pixels: Vec<[u8; 3]> = (HEADER..png.height)
        .flat_map(|y| (0..png.width - 420).map(move |x| (x, y)))
        .map(|(x, y)| png.pixels[(y * png.width + x) as usize])
        .collect();
    let counted: Vec<(&[u8; 3], usize)> =
        expected.keys().map(|c| (c, map_pixels.iter().filter(|p| *p == c).count())).collect();
    let total: usize = counted.iter().map(|(_, n)| n).sum();
    for (colour, n) in counted {
        let share = n as f64 / total as f64;
        assert!(
            (share - expected[colour]).abs() < 0.01,
            "{colour:?}: {share} of the map, expected {}",
            expected[colour]
        );
    }
    // No joint colour that no pose has, except in the legend.
    for k in 0..4 {
        for j in 0..3 {
            let c = clearance_plot::dominant_colour(&clearance_solver::joint_name(k, j)).unwrap();
            if !expected.contains_key(&c) {
                assert_eq!(map_pixels.iter().filter(|p| **p == c).count(), 0, "{c:?}");
            }
        }
    }
}
