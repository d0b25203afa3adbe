//! The paper's Figs. 13–17, along a trajectory.
//!
//! - Figs. 13–14: the inputs and the parasitic motions X, Y, Φ with their velocities
//!   and accelerations against time. The run does not store rates, so they are
//!   recomputed here from the job with the engine's own kinematics (exact jets,
//!   `clearance_kinematics::inverse_kinematics_motion`). A 6-UPS has no parasitic
//!   motion: only its inputs are drawn, up to six, with the rates of their harmonics.
//! - Figs. 15–17: the six error components against Θ (or whichever input moves; on a
//!   6-UPS, against t), kinetostatics in black and dynamics in blue, each switch a
//!   dashed vertical line in its mode's colour.

use std::path::Path;

use clearance_grid::SampleSource;
use clearance_kinematics::{Geometry, inverse_kinematics_motion};
use clearance_model::{JobSpec, MechanismKind};
use plotters::prelude::*;

use crate::PlotError;
use crate::figure::{
    COMPONENTS, Curve, ERROR_SCALE, LinePanel, Marker, font, header, input_symbol, max_abs, mode_colour, padded,
    render, si_prefix, value_range,
};
use crate::run_dir::ModeData;
use crate::switches::Switch;

/// Pixel size of an error-along-the-trajectory figure.
pub const ERROR_SIZE: (u32, u32) = (1680, 1000);
const HEADER: u32 = 100;
/// The legend's strip between the header and the panels.
const LEGEND: u32 = 34;
const MOTION_ROW: u32 = 300;
const MOTION_WIDTH: u32 = 1680;

/// The input the errors are drawn against: Θ as in the paper, else the first
/// input that moves, else time; time on a 6-UPS, whose inputs all move together.
/// `(column name, axis label, values per sample)`.
pub(crate) fn abscissa(
    source: &SampleSource,
    kept: &[u64],
    kind: MechanismKind,
) -> (&'static str, &'static str, Vec<f64>) {
    if kind == MechanismKind::Ups6 {
        return ("t", "t (s)", kept.iter().map(|&i| source.sample6(i).0.unwrap_or(i as f64)).collect());
    }
    let samples: Vec<_> = kept.iter().map(|&i| source.sample(i)).collect();
    let moves = |f: fn(&clearance_grid::Sample) -> f64| {
        let (lo, hi) = value_range(samples.iter().map(f), 0.0);
        hi > lo
    };
    if moves(|s| s.theta[0]) || !(moves(|s| s.psi[0]) || moves(|s| s.z[0])) {
        ("theta", "Θ (rad)", samples.iter().map(|s| s.theta[0]).collect())
    } else if moves(|s| s.psi[0]) {
        ("psi", "Ψ (rad)", samples.iter().map(|s| s.psi[0]).collect())
    } else {
        ("z", "Z (m)", samples.iter().map(|s| s.z[0]).collect())
    }
}

/// Everything one error-along-the-trajectory figure shows.
pub(crate) struct TrajectoryErrors<'a> {
    pub title: String,
    pub subtitle: String,
    pub x_desc: &'a str,
    pub x: &'a [f64],
    /// `(mode, its six error columns in m and rad)`.
    pub modes: Vec<(&'a str, [Option<&'a [f64]>; 6])>,
    /// `(mode, abscissa)` of each switch to mark.
    pub switches: Vec<(String, f64)>,
}

impl TrajectoryErrors<'_> {
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        let x_range = value_range(self.x.iter().copied(), 1e-9);
        let series = |k: usize| {
            self.modes
                .iter()
                .filter_map(move |(mode, cols)| cols[k].map(|c| (*mode, c.iter().map(|v| v * ERROR_SCALE))))
        };
        // As in the maps: an error that is zero up to round-off draws flat.
        let group_max = |angle: bool| {
            (0..6)
                .filter(|&k| COMPONENTS[k].angle == angle)
                .map(|k| max_abs(series(k).flat_map(|(_, v)| v)))
                .fold(0.0, f64::max)
        };
        let min_span = [group_max(false), group_max(true)].map(|m| (1e-3 * m).max(1e-3));
        render(path, ERROR_SIZE, |root| {
            let body = header(root, &self.title, &self.subtitle, HEADER + LEGEND)?;
            self.legend(root)?;
            for (k, area) in body.split_evenly((2, 3)).iter().enumerate() {
                let c = COMPONENTS[k];
                // The first mode (kinetostatics) is drawn wider, under the others: where
                // the curves coincide it shows as a black edge around the blue one.
                let curves: Vec<Curve> = series(k)
                    .enumerate()
                    .map(|(m, (mode, v))| Curve {
                        points: self.x.iter().copied().zip(v).collect(),
                        colour: mode_colour(mode),
                        width: curve_width(m),
                    })
                    .collect();
                let y_range = padded(
                    value_range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)), min_span[c.angle as usize]),
                    0.06,
                );
                let title = format!("Δ{}", c.symbol);
                LinePanel {
                    title: &title,
                    x_desc: self.x_desc,
                    y_desc: c.error_unit(),
                    x_range,
                    y_range,
                    curves,
                    markers: self
                        .switches
                        .iter()
                        .map(|(mode, x)| Marker { x: *x, colour: mode_colour(mode) })
                        .collect(),
                }
                .draw(area)?;
            }
            Ok(())
        })
    }

    /// One legend for all six panels, right-aligned under the header.
    fn legend(&self, root: &crate::figure::Area<'_>) -> crate::figure::DrawResult {
        let mut x = ERROR_SIZE.0 as i32 - 24;
        // (label, colour, line width; 0 = dashed)
        let mut entries: Vec<(String, RGBColor, u32)> = Vec::new();
        for (m, (mode, _)) in self.modes.iter().enumerate() {
            entries.push((mode.to_string(), mode_colour(mode), curve_width(m)));
        }
        for (mode, _) in &self.modes {
            if self.switches.iter().any(|(m, _)| m == mode) {
                entries.push((format!("switch ({mode})"), mode_colour(mode), 0));
            }
        }
        let y = HEADER as i32 + 10;
        for (label, colour, width) in entries.iter().rev() {
            let style = font(18.0);
            let (w, _) = root.estimate_text_size(label, &style)?;
            x -= w as i32;
            root.draw(&Text::new(label.clone(), (x, y - 10), style))?;
            x -= 44;
            if *width == 0 {
                for k in 0..3 {
                    let a = x + k * 13;
                    root.draw(&PathElement::new(vec![(a, y), (a + 7, y)], colour.stroke_width(2)))?;
                }
            } else {
                root.draw(&PathElement::new(vec![(x, y), (x + 36, y)], colour.stroke_width(*width)))?;
            }
            x -= 28;
        }
        Ok(())
    }
}

/// The stroke width of the `m`-th mode's curve.
fn curve_width(m: usize) -> u32 {
    if m == 0 { 4 } else { 2 }
}

/// The switches of one figure on a trajectory, as `(mode, abscissa)`.
pub(crate) fn switch_marks(switches: &[&Switch], along: &str) -> Vec<(String, f64)> {
    switches.iter().filter_map(|s| s.coordinate(along).map(|x| (s.mode.clone(), x))).collect()
}

/// One row of a motion figure: a quantity with its two time derivatives.
struct MotionRow {
    name: &'static str,
    unit: &'static str,
    values: [Vec<f64>; 3],
}

/// Writes the inputs figure (Fig. 13) and, when `parasitic_path` is given (the
/// 3-limb kinds), the parasitic-motion figure (Fig. 14) for `job`'s trajectory, at
/// its samples `kept`.
pub(crate) fn write_motions(
    job: &JobSpec,
    kept: &[u64],
    title: &str,
    subtitle: &str,
    inputs_path: &Path,
    parasitic_path: Option<&Path>,
) -> Result<(), PlotError> {
    let source = SampleSource::new(job);
    let kind = job.mechanism.kind;
    let n = kept.len();
    let mut t = Vec::with_capacity(n);
    let nan3 = || [vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]];
    let names = kind.inputs();
    let mut values: Vec<[Vec<f64>; 3]> = names.iter().map(|_| nan3()).collect();
    let (mut xs, mut ys, mut phis) = (nan3(), nan3(), nan3());
    let geom = parasitic_path.map(|_| Geometry::from_spec(&job.mechanism));
    for (i, &k) in kept.iter().enumerate() {
        // Each input as [value, rate, acceleration], in the order of `names`.
        let (time, inputs) = if kind == MechanismKind::Ups6 {
            let (time, inputs) = source.sample6(k);
            (time, inputs.to_vec())
        } else {
            let s = source.sample(k);
            (s.t, vec![s.z, s.psi, s.theta])
        };
        t.push(time.unwrap_or(k as f64));
        for (row, input) in values.iter_mut().zip(&inputs) {
            for d in 0..3 {
                row[d][i] = input[d];
            }
        }
        // An unreachable pose has no parasitic motion: left NaN, a gap in the curve.
        let Some(geom) = &geom else { continue };
        if let Ok((posture, motion)) = inverse_kinematics_motion(geom, inputs[0], inputs[1], inputs[2]) {
            let value = [posture.x, posture.y, posture.phi];
            for (q, row) in [&mut xs, &mut ys, &mut phis].into_iter().enumerate() {
                row[0][i] = value[q];
                row[1][i] = motion.parasitic_dot[q];
                row[2][i] = motion.parasitic_ddot[q];
            }
        }
    }
    let moving = |v: &[Vec<f64>; 3]| max_abs(v[1].iter().copied()) > 0.0;
    let mut inputs = Vec::new();
    for (&name, v) in names.iter().zip(values) {
        let (name, unit) = input_symbol(name);
        if moving(&v) || name == "Θ" && inputs.is_empty() {
            inputs.push(MotionRow { name, unit, values: v });
        }
    }
    let names = |rows: &[MotionRow]| rows.iter().map(|r| r.name).collect::<Vec<_>>().join(", ");
    write_motion(
        inputs_path,
        &format!("{title} — inputs {} along the trajectory", names(&inputs)),
        subtitle,
        &t,
        &inputs,
    )?;
    let Some(parasitic_path) = parasitic_path else { return Ok(()) };
    let parasitic = vec![
        MotionRow { name: "X", unit: "m", values: xs },
        MotionRow { name: "Y", unit: "m", values: ys },
        MotionRow { name: "Φ", unit: "rad", values: phis },
    ];
    write_motion(
        parasitic_path,
        &format!("{title} — parasitic motions {} along the trajectory", names(&parasitic)),
        subtitle,
        &t,
        &parasitic,
    )
}

fn write_motion(path: &Path, title: &str, subtitle: &str, t: &[f64], rows: &[MotionRow]) -> Result<(), PlotError> {
    let height = HEADER + MOTION_ROW * rows.len() as u32;
    let t_range = value_range(t.iter().copied(), 1e-9);
    render(path, (MOTION_WIDTH, height), |root| {
        let body = header(root, title, subtitle, HEADER)?;
        let areas = body.split_evenly((rows.len(), 3));
        for (r, row) in rows.iter().enumerate() {
            for d in 0..3 {
                let values = &row.values[d];
                let unit = match d {
                    0 => row.unit.to_string(),
                    1 => format!("{}/s", row.unit),
                    _ => format!("{}/s²", row.unit),
                };
                // A motion that is zero (Y and Φ at Ψ = 0) draws as a flat line in nano-units.
                let (factor, unit) = si_prefix(max_abs(values.iter().copied()).max(1e-9), &unit);
                let points: Vec<(f64, f64)> = t.iter().zip(values).map(|(&t, &v)| (t, v * factor)).collect();
                let y_range = padded(value_range(points.iter().map(|p| p.1), 1e-9 * factor), 0.06);
                let n = row.name;
                let panel_title = match d {
                    0 => n.to_string(),
                    1 => format!("velocity d{n}/dt"),
                    _ => format!("acceleration d²{n}/dt²"),
                };
                LinePanel {
                    title: &panel_title,
                    x_desc: "t (s)",
                    y_desc: &unit,
                    x_range: t_range,
                    y_range,
                    curves: vec![Curve { points, colour: BLACK, width: 2 }],
                    markers: Vec::new(),
                }
                .draw(&areas[r * 3 + d])?;
            }
        }
        Ok(())
    })
}

/// The six error columns of `source` in one mode's data.
pub(crate) fn error_columns(data: &ModeData, source: crate::figure::Source) -> [Option<&[f64]>; 6] {
    COMPONENTS.map(|c| data.column(&source.column(c)))
}
