//! `plot_run` on 6-UPS runs made in the test with the engine's `solve`: maps over the
//! first two swept inputs at the first value of the others, each pose coloured by its
//! value on the panel's colour bar, the switches of discontinuities.parquet drawn where
//! the file puts them and only on the plotted plane, the envelope and dominant-joint
//! maps exactly when their columns are there, trajectories against t, and a clear
//! refusal of a grid with one swept input.

mod common;

use std::sync::Arc;

use arrow::array::{Array, ArrayRef, Float64Array, StringArray};
use arrow::datatypes::{Field, Schema};
use arrow::record_batch::RecordBatch;
use clearance_model::Mode;
use clearance_plot::{ERROR_SIZE, MAP_SIZE, PlotError, dominant_colour, plot_run};
use common::{HEADER, Png, body_difference, files_under, floats, make_ups_run, strings, write_ups_switches};

/// An error figure's panels are 560 × 470 pixels below the header, the last 110
/// pixels of each its colour bar.
const PANEL: (u32, u32) = (560, 470);
const BAR_WIDTH: u32 = 110;
const WHITE: [u8; 3] = [255, 255, 255];
const BLACK: [u8; 3] = [0, 0, 0];
const GREY: [u8; 3] = [185, 185, 185];

/// x (9 lines) across, ψ (7) up: the first two swept inputs, at the first of two Θ;
/// y, z, Φ fixed. Switch-free until a test writes discontinuities.parquet.
const GRID_JOB: &str = r#"
name = "ups_small_grid"
[mechanism]
kind = "6-UPS"
[mass]
points = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]
[clearance]
s_radial = 1e-4
u_radial = 1e-4
u_angular = 1e-3
[grid]
x = { start = -0.12, stop = 0.12, n = 9 }
y = 0.02
z = 0.75
phi = 0.0
psi = { start = -0.15, stop = 0.15, n = 7 }
theta = { start = 0.05, stop = 0.1, n = 2 }
"#;
const N_X: usize = 9;
const N_PSI: usize = 7;
const X: (f64, f64) = (-0.12, 0.12);
const PSI: (f64, f64) = (-0.15, 0.15);

/// The envelope and dominant-joint columns (which the 6-UPS engine may or may not
/// write): dropped, so that each test decides whether the run has them.
fn is_envelope_or_dominant(name: &str) -> bool {
    name.starts_with("env_") || name == "dominant"
}

fn without_envelope(batch: RecordBatch) -> RecordBatch {
    let keep: Vec<usize> =
        (0..batch.num_columns()).filter(|&i| !is_envelope_or_dominant(batch.schema().field(i).name())).collect();
    batch.project(&keep).unwrap()
}

/// `batch` with `columns` added at the end.
fn with_columns(batch: RecordBatch, columns: Vec<(&str, ArrayRef)>) -> RecordBatch {
    let mut fields: Vec<Field> = batch.schema().fields().iter().map(|f| f.as_ref().clone()).collect();
    let mut arrays = batch.columns().to_vec();
    for (name, array) in columns {
        fields.push(Field::new(name, array.data_type().clone(), true));
        arrays.push(array);
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays).unwrap()
}

/// The pixel rectangle `[left, right] × [top, bottom]` of a map's frame inside the
/// area `(x0, y0, w, h)`: where the rows and columns of coloured pixels run longest.
/// Two rows and two columns, so that a tick mark on one cannot widen it.
fn map_frame(png: &Png, (x0, y0, w, h): (u32, u32, u32, u32)) -> [u32; 4] {
    let longest = |points: Vec<(u32, u32)>, along_x: bool| {
        let (mut best, mut start, mut run) = ((0, 0), 0, 0);
        for (k, &(x, y)) in points.iter().enumerate() {
            if png.at(x, y) == WHITE {
                run = 0;
                continue;
            }
            if run == 0 {
                start = k;
            }
            run += 1;
            if run > best.1 - best.0 {
                best = (start, k + 1);
            }
        }
        let at = |k: usize| if along_x { points[k].0 } else { points[k].1 };
        (at(best.0), at(best.1 - 1))
    };
    let row = |f: f64| longest((x0..x0 + w).map(|x| (x, y0 + (f * h as f64) as u32)).collect(), true);
    let col = |f: f64| longest((y0..y0 + h).map(|y| (x0 + (f * w as f64) as u32, y)).collect(), false);
    let (r1, r2, c1, c2) = (row(0.37), row(0.61), col(0.41), col(0.67));
    [r1.0.max(r2.0), r1.1.min(r2.1), c1.0.max(c2.0), c1.1.min(c2.1)]
}

/// The pixel of `(across, up)` in a map of `frame` over the extents `a` and `u`.
fn pixel_of([left, right, top, bottom]: [u32; 4], a: (f64, f64), u: (f64, f64), (va, vu): (f64, f64)) -> (u32, u32) {
    let x = left as f64 + (right - left) as f64 * (va - a.0) / (a.1 - a.0);
    let y = bottom as f64 - (bottom - top) as f64 * (vu - u.0) / (u.1 - u.0);
    (x.round() as u32, y.round() as u32)
}

/// The centre of the cell of grid pose `(i, j)` of an `n_a × n_u` map: the sample's
/// own pixel, moved a quarter cell inwards at the edges so that the frame is missed.
fn cell_centre(frame: [u32; 4], (i, j): (usize, usize), (n_a, n_u): (usize, usize)) -> (u32, u32) {
    let inward = |k: usize, n: usize| {
        let f = k as f64 / (n - 1) as f64;
        f.clamp(0.25 / (n - 1) as f64, 1.0 - 0.25 / (n - 1) as f64)
    };
    pixel_of(frame, (0.0, 1.0), (0.0, 1.0), (inward(i, n_a), inward(j, n_u)))
}

/// A colour bar's gradient, top to bottom: the column of the bar area with the most
/// distinct colours, its non-white, non-black pixels.
fn colour_bar(png: &Png, (x0, y0, w, h): (u32, u32, u32, u32)) -> Vec<[u8; 3]> {
    let column =
        |x: u32| -> Vec<[u8; 3]> { (y0..y0 + h).map(|y| png.at(x, y)).filter(|&p| p != WHITE && p != BLACK).collect() };
    let distinct = |x: u32| {
        let mut c = column(x);
        c.sort_unstable();
        c.dedup();
        c.len()
    };
    let x = (x0..x0 + w).max_by_key(|&x| distinct(x)).unwrap();
    column(x)
}

/// Where `colour` lies on a gradient, from 0 (bottom) to 1 (top): its nearest colour.
fn place_on_bar(bar: &[[u8; 3]], colour: [u8; 3]) -> f64 {
    let distance = |p: &[u8; 3]| (0..3).map(|c| (p[c] as i32 - colour[c] as i32).abs()).sum::<i32>();
    let k = (0..bar.len()).min_by_key(|&k| distance(&bar[k])).unwrap();
    assert!(distance(&bar[k]) <= 12, "{colour:?} is not on the colour bar (nearest {:?})", bar[k]);
    1.0 - k as f64 / (bar.len() - 1) as f64
}

/// The rows of the first Θ plane (ok poses): `(i_x, i_ψ, row)`.
fn first_plane(batch: &RecordBatch) -> Vec<(usize, usize, usize)> {
    let (x, psi, theta) = (floats(batch, "x"), floats(batch, "psi"), floats(batch, "theta"));
    let status = strings(batch, "status");
    let index = |v: f64, (lo, hi): (f64, f64), n: usize| ((v - lo) / (hi - lo) * (n - 1) as f64).round() as usize;
    (0..batch.num_rows())
        .filter(|&r| theta.value(r) == 0.05 && status.value(r) == "ok")
        .map(|r| (index(x.value(r), X, N_X), index(psi.value(r), PSI, N_PSI), r))
        .collect()
}

#[test]
fn grid_maps_colour_each_pose_by_its_value_on_the_first_two_swept_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let (_, batches) = make_ups_run(&run, GRID_JOB, without_envelope);
    let out = tmp.path().join("plots");
    let written = plot_run(&run, &out).unwrap();
    let expected = [
        "variant=0/s_radial_kinetostatic.png",
        "variant=0/total_kinetostatic.png",
        "variant=0/u_angular_kinetostatic.png",
        "variant=0/u_radial_kinetostatic.png",
    ];
    assert_eq!(files_under(&out), expected, "no envelope or dominant map without their columns");
    assert_eq!(written.len(), 4);

    let batch = &batches[0];
    let plane = first_plane(batch);
    assert_eq!(plane.len(), N_X * N_PSI, "every pose of the plane is ok");
    for (file, column, panel) in [
        ("total_kinetostatic.png", "err_x", 0),
        ("total_kinetostatic.png", "err_phi", 5),
        ("u_radial_kinetostatic.png", "err_u_radial_z", 2),
    ] {
        let png = Png::open(&out.join("variant=0").join(file));
        assert_eq!((png.width, png.height), MAP_SIZE);
        let (px, py) = (PANEL.0 * (panel % 3), HEADER + PANEL.1 * (panel / 3));
        let frame = map_frame(&png, (px, py, PANEL.0 - BAR_WIDTH, PANEL.1));
        let bar = colour_bar(&png, (px + PANEL.0 - BAR_WIDTH, py, BAR_WIDTH, PANEL.1));
        assert!(bar.len() > 200, "{file} {column}: a bar of {} pixels", bar.len());
        let values = floats(batch, column);
        let (lo, hi) = plane
            .iter()
            .map(|&(_, _, r)| values.value(r))
            .fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
        assert!(hi - lo > 1e-6, "{column} varies over the plane: a flat map tests little");
        for &(i, j, r) in &plane {
            let (x, y) = cell_centre(frame, (i, j), (N_X, N_PSI));
            let on_bar = place_on_bar(&bar, png.at(x, y));
            let expected = (values.value(r) - lo) / (hi - lo);
            assert!(
                (on_bar - expected).abs() < 0.03,
                "{file} {column}: pose x {i}, ψ {j} at pixel ({x}, {y}) shows {on_bar:.3} of the bar, its value {expected:.3}"
            );
        }
    }
}

#[test]
fn switches_are_drawn_where_the_file_puts_them_and_only_on_the_plane() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    make_ups_run(&run, GRID_JOB, without_envelope);
    let plot = |name: &str, file: &str| {
        let out = tmp.path().join(name);
        plot_run(&run, &out).unwrap();
        Png::open(&out.join("variant=0").join(file))
    };
    let before = plot("before", "total_kinetostatic.png");
    let radial_before = plot("before", "u_radial_kinetostatic.png");

    // Between grid poses, at the other Θ: not on the plane drawn.
    let (x, psi) = (0.015, 0.0125);
    let at = |theta: f64| [x, 0.02, 0.75, 0.0, psi, theta];
    write_ups_switches(&run, &[(Mode::Kinetostatic, 0, None, at(0.1))]);
    let elsewhere = plot("elsewhere", "total_kinetostatic.png");
    assert_eq!(body_difference(&before, &elsewhere), 0);

    write_ups_switches(&run, &[(Mode::Kinetostatic, 0, None, at(0.05))]);
    let here = plot("here", "total_kinetostatic.png");
    let radial_here = plot("here", "u_radial_kinetostatic.png");
    // An s_radial switch is not on the u_radial map.
    assert_eq!(body_difference(&radial_before, &radial_here), 0);
    for panel in 0..6 {
        let (px, py) = (PANEL.0 * (panel % 3), HEADER + PANEL.1 * (panel / 3));
        let frame = map_frame(&here, (px, py, PANEL.0 - BAR_WIDTH, PANEL.1));
        let (sx, sy) = pixel_of(frame, X, PSI, (x, psi));
        let black_near = |png: &Png| {
            (sx - 2..=sx + 2).flat_map(|x| (sy - 2..=sy + 2).map(move |y| (x, y))).any(|(x, y)| png.at(x, y) == BLACK)
        };
        assert!(black_near(&here) && !black_near(&before), "panel {panel}: no dot at ({sx}, {sy})");
    }
}

#[test]
fn envelope_and_dominant_maps_are_drawn_when_the_run_has_their_columns() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    // A joint per x line, limbs 1 to 6 and all three kinds; the pose at x line 4, ψ
    // line 3 has none.
    let joints = ["u5_radial", "s1_radial", "s4_radial", "u2_radial", "s6_radial", "u6_angular", "u1_radial"];
    let line = |v: f64, (lo, hi): (f64, f64), n: usize| ((v - lo) / (hi - lo) * (n - 1) as f64).round() as usize;
    let x_line = |x: f64| line(x, X, N_X);
    let add = |batch: RecordBatch| {
        let batch = without_envelope(batch);
        let (x, psi) = (floats(&batch, "x").clone(), floats(&batch, "psi").clone());
        let dominant: StringArray = (0..batch.num_rows())
            .map(|r| {
                ((x_line(x.value(r)), line(psi.value(r), PSI, N_PSI)) != (4, 3))
                    .then(|| joints[x_line(x.value(r)) % joints.len()])
            })
            .collect();
        let mut columns: Vec<(&str, ArrayRef)> = Vec::new();
        for (k, name) in
            ["env_x", "env_y", "env_z", "env_rx", "env_ry", "env_rz", "env_p", "env_alpha"].iter().enumerate()
        {
            let values: Float64Array =
                (0..batch.num_rows()).map(|r| Some(1e-4 * (k + 1) as f64 + x.value(r).abs())).collect();
            columns.push((name, Arc::new(values)));
        }
        columns.push(("dominant", Arc::new(dominant)));
        with_columns(batch, columns)
    };
    make_ups_run(&run, GRID_JOB, add);
    let out = tmp.path().join("plots");
    plot_run(&run, &out).unwrap();
    let files = files_under(&out);
    assert!(files.contains(&"variant=0/envelope_kinetostatic.png".to_string()), "{files:?}");
    assert!(files.contains(&"variant=0/dominant_kinetostatic.png".to_string()), "{files:?}");

    let envelope = Png::open(&out.join("variant=0/envelope_kinetostatic.png"));
    assert_eq!((envelope.width, envelope.height), MAP_SIZE);
    assert!(envelope.distinct_colours() > 100, "{} colours", envelope.distinct_colours());

    // The dominant map is the figure's left part, left of the 420-pixel legend.
    let png = Png::open(&out.join("variant=0/dominant_kinetostatic.png"));
    assert_eq!((png.width, png.height), MAP_SIZE);
    let frame = map_frame(&png, (0, HEADER, png.width - 420, png.height - HEADER));
    for i in 0..N_X {
        for j in 0..N_PSI {
            let (x, y) = cell_centre(frame, (i, j), (N_X, N_PSI));
            let expected = if (i, j) == (4, 3) { GREY } else { dominant_colour(joints[i % joints.len()]).unwrap() };
            assert_eq!(png.at(x, y), expected, "pose x {i}, ψ {j} at pixel ({x}, {y})");
        }
    }
    // Six limbs, three kinds: seven joints, seven colours, all different.
    let mut colours: Vec<[u8; 3]> = joints.iter().map(|j| dominant_colour(j).unwrap()).collect();
    colours.sort_unstable();
    colours.dedup();
    assert_eq!(colours.len(), joints.len());
}

const TRAJECTORY_JOB: &str = r#"
name = "ups_small_trajectory"
[mechanism]
kind = "6-UPS"
[mass]
points = [ { mass = 10.0, at = [0.0, 0.0, 0.4] } ]
[clearance]
s_radial = 1e-4
u_radial = 1e-4
[analysis]
modes = ["kinetostatic", "dynamic"]
[trajectory]
time = { start = 0.0, stop = 2.0, n = 41 }
x = { harmonics = [ { amplitude = 0.08, period = 2.0 } ] }
z = 0.75
psi = 0.0
theta = { harmonics = [ { amplitude = 0.15, period = 2.0, phase = 1.5 } ] }
"#;

#[test]
fn trajectory_figures_against_time_with_the_moving_inputs_and_no_parasitic_motion() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    make_ups_run(&run, TRAJECTORY_JOB, |b| b);
    let out = tmp.path().join("plots");
    plot_run(&run, &out).unwrap();
    let expected = [
        "variant=0/inputs_motion.png",
        "variant=0/s_radial_trajectory.png",
        "variant=0/total_trajectory.png",
        "variant=0/u_radial_trajectory.png",
    ];
    assert_eq!(files_under(&out), expected);
    // X and Θ move: two rows of value, velocity, acceleration.
    let inputs = Png::open(&out.join("variant=0/inputs_motion.png"));
    assert_eq!((inputs.width, inputs.height), (1680, HEADER + 2 * 300));
    assert!(inputs.ink() > 0.03);
    let total = Png::open(&out.join("variant=0/total_trajectory.png"));
    assert_eq!((total.width, total.height), ERROR_SIZE);
    // Kinetostatics black, dynamics blue.
    assert!(total.count([25, 90, 230]) > 1000 && total.count(BLACK) > 1000);

    // A dynamic switch at t = 1.3 s: a dashed line in each of the six panels, at the
    // same place (t runs along each panel's width).
    write_ups_switches(&run, &[(Mode::Dynamic, 1, Some(1.3), [0.0; 6])]);
    let marked = tmp.path().join("marked");
    plot_run(&run, &marked).unwrap();
    let after = Png::open(&marked.join("variant=0/total_trajectory.png"));
    let s_radial = Png::open(&marked.join("variant=0/s_radial_trajectory.png"));
    assert_eq!(body_difference(&s_radial, &Png::open(&out.join("variant=0/s_radial_trajectory.png"))), 0);
    let below_legend = 140;
    let changed: Vec<u32> = (below_legend..total.height)
        .flat_map(|y| (0..total.width).map(move |x| (x, y)))
        .filter(|&(x, y)| total.at(x, y) != after.at(x, y))
        .map(|(x, _)| x % PANEL.0)
        .collect();
    assert!(changed.len() > 6 * 100, "{} pixels changed", changed.len());
    let (lo, hi) = (changed.iter().min().unwrap(), changed.iter().max().unwrap());
    assert!(hi - lo <= 3, "the line spreads over x {lo}..{hi} within the panels");
}

#[test]
fn a_grid_with_one_swept_input_is_refused_with_a_message() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let job = GRID_JOB
        .replace("theta = { start = 0.05, stop = 0.1, n = 2 }", "theta = 0.05")
        .replace("psi = { start = -0.15, stop = 0.15, n = 7 }", "psi = 0.0");
    make_ups_run(&run, &job, |b| b);
    let out = tmp.path().join("plots");
    let err = plot_run(&run, &out).unwrap_err();
    assert!(matches!(err, PlotError::Unsupported { .. }), "{err}");
    let message = err.to_string();
    assert!(message.contains("two swept inputs") && message.contains("only `x`"), "{message}");
    assert!(!out.exists(), "nothing is written");
}
