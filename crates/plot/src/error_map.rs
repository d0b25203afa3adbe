//! The paper's Figs. 6–12: six colour maps of the pose error over the Ψ–Θ
//! workspace at one `z` (a 6-UPS: over its [`Plane`] of two swept inputs), for one
//! clearance kind or all of them, with the switch locus drawn over them.
//!
//! Ψ runs horizontally and Θ vertically, as in the paper (the plane's first input
//! across, its second up). Each sample colours the
//! pixels nearest to it (no interpolation: a discontinuity stays a sharp edge).
//! Each panel has its own colour bar; when a few poses near a singularity would
//! stretch it over the whole map, the bar is clipped to the 1–99 % quantiles
//! and the panel says so.

use std::path::Path;

use plotters::prelude::*;

use crate::PlotError;
use crate::figure::{
    Area, COMPONENTS, Component, DrawResult, ERROR_SCALE, NULL_GREY, font, header, max_abs, render, tick_label, turbo,
    value_range,
};
use crate::run_dir::Plane;

/// Pixel size of an error-map figure.
pub const MAP_SIZE: (u32, u32) = (1680, 1040);
const HEADER: u32 = 100;
const BAR_WIDTH: u32 = 110;

/// One colour map: a component's values in display units, slot `i_across·n_up + i_up`.
pub(crate) struct MapPanel {
    pub component: Component,
    pub values: Vec<f64>,
}

/// Everything one error-map figure shows.
pub(crate) struct ErrorMap<'a> {
    pub title: String,
    pub subtitle: String,
    pub plane: &'a Plane,
    pub panels: Vec<MapPanel>,
    /// Switch locations `(across, up)`.
    pub switches: Vec<(f64, f64)>,
}

/// The six panels of a figure from raw error columns (m, rad), in display units.
pub(crate) fn panels(columns: [Option<&[f64]>; 6], slots: usize) -> Vec<MapPanel> {
    panels_of(&COMPONENTS, columns, slots)
}

/// [`panels`] of other components (the envelope's).
pub(crate) fn panels_of(components: &[Component; 6], columns: [Option<&[f64]>; 6], slots: usize) -> Vec<MapPanel> {
    components
        .iter()
        .zip(columns)
        .map(|(&component, col)| MapPanel {
            component,
            values: match col {
                Some(c) => c.iter().map(|v| v * ERROR_SCALE).collect(),
                None => vec![f64::NAN; slots],
            },
        })
        .collect()
}

/// The colour range of one panel: `(lo, hi, clipped)`.
fn colour_range(values: &[f64], min_span: f64) -> (f64, f64, bool) {
    let (lo, hi) = value_range(values.iter().copied(), min_span);
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.len() < 100 {
        return (lo, hi, false);
    }
    finite.sort_by(f64::total_cmp);
    let q = |p: f64| finite[((finite.len() - 1) as f64 * p).round() as usize];
    let (qlo, qhi) = (q(0.01), q(0.99));
    if hi - lo > 3.0 * (qhi - qlo) && qhi - qlo >= min_span {
        let pad = 0.05 * (qhi - qlo);
        ((qlo - pad).max(lo), (qhi + pad).min(hi), true)
    } else {
        (lo, hi, false)
    }
}

/// The index of the axis value nearest to `v` on a uniform axis.
fn nearest(axis: &[f64], v: f64) -> usize {
    let n = axis.len();
    if n < 2 {
        return 0;
    }
    let step = (axis[n - 1] - axis[0]) / (n - 1) as f64;
    ((v - axis[0]) / step).round().clamp(0.0, (n - 1) as f64) as usize
}

/// The drawn extent of an axis: its end values, or a small band around a single value.
fn extent(axis: &[f64]) -> (f64, f64) {
    match axis {
        [] => (-1.0, 1.0),
        [v] => (v - 0.05 * v.abs().max(1.0), v + 0.05 * v.abs().max(1.0)),
        [first, .., last] => (first.min(*last), first.max(*last)),
    }
}

/// A map over the plane's inputs (Ψ across, Θ up on a 3-limb grid): each pixel takes
/// `colour` of the slot `i_across·len(up) + i_up` of the nearest sample (no
/// interpolation: a discontinuity stays a sharp edge), and the switch locations are
/// drawn over it as black dots.
pub(crate) fn draw_map(
    area: &Area<'_>,
    caption: &str,
    plane: &Plane,
    switches: &[(f64, f64)],
    colour: impl Fn(usize) -> RGBColor,
) -> DrawResult {
    let (psi, theta) = (plane.across.values.as_slice(), plane.up.values.as_slice());
    let (x0, x1) = extent(psi);
    let (y0, y1) = extent(theta);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, font(20.0))
        .margin(8)
        .x_label_area_size(46)
        .y_label_area_size(66)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(5)
        .y_labels(5)
        .x_label_formatter(&|v| tick_label(*v, x1 - x0))
        .y_label_formatter(&|v| tick_label(*v, y1 - y0))
        .label_style(font(14.0))
        .axis_desc_style(font(16.0))
        .x_desc(plane.across.desc())
        .y_desc(plane.up.desc())
        .draw()?;
    let plot = chart.plotting_area().strip_coord_spec();
    let (pw, ph) = plot.dim_in_pixel();
    let n_theta = theta.len();
    let columns: Vec<usize> = (0..pw).map(|px| nearest(psi, x0 + (px as f64 + 0.5) / pw as f64 * (x1 - x0))).collect();
    for py in 0..ph {
        let it = nearest(theta, y1 - (py as f64 + 0.5) / ph as f64 * (y1 - y0));
        for (px, &ip) in columns.iter().enumerate() {
            plot.draw_pixel((px as i32, py as i32), &colour(ip * n_theta + it))?;
        }
    }
    chart.draw_series(
        switches.iter().map(|&p| EmptyElement::at(p) + Rectangle::new([(-1, -1), (1, 1)], BLACK.filled())),
    )?;
    chart.plotting_area().draw(&Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1)))?;
    Ok(())
}

impl ErrorMap<'_> {
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        // A component that is zero up to round-off shows as one flat colour: the
        // minimum span is a thousandth of the largest error of its kind (positions
        // or angles) in the figure, and never below 1e-3 µm or µrad.
        let group_max = |angle: bool| {
            max_abs(self.panels.iter().filter(|p| p.component.angle == angle).flat_map(|p| p.values.iter().copied()))
        };
        let min_span = [group_max(false), group_max(true)].map(|m| (1e-3 * m).max(1e-3));
        let any_clipped = std::cell::Cell::new(false);
        let ranges: Vec<_> = self
            .panels
            .iter()
            .map(|p| {
                let r = colour_range(&p.values, min_span[p.component.angle as usize]);
                any_clipped.set(any_clipped.get() || r.2);
                r
            })
            .collect();
        let mut subtitle = self.subtitle.clone();
        if any_clipped.get() {
            subtitle.push_str(" · *: colour bar clipped to the 1–99 % quantiles (near-singular poses)");
        }
        render(path, MAP_SIZE, |root| {
            let body = header(root, &self.title, &subtitle, HEADER)?;
            for ((area, panel), range) in body.split_evenly((2, 3)).iter().zip(&self.panels).zip(ranges) {
                self.draw_panel(area, panel, range)?;
            }
            Ok(())
        })
    }

    fn draw_panel(&self, area: &Area<'_>, panel: &MapPanel, (lo, hi, clipped): (f64, f64, bool)) -> DrawResult {
        let (w, _) = area.dim_in_pixel();
        let (map_area, bar_area) = area.split_horizontally(w - BAR_WIDTH);
        let c = panel.component;
        let caption = format!("Δ{} ({}){}", c.symbol, c.error_unit(), if clipped { " *" } else { "" });
        let colour = |slot: usize| {
            let v = panel.values[slot];
            if v.is_finite() { turbo((v - lo) / (hi - lo)) } else { NULL_GREY }
        };
        draw_map(&map_area, &caption, self.plane, &self.switches, colour)?;

        // The colour bar, aligned with the map: same caption height and margins.
        let mut bar = ChartBuilder::on(&bar_area)
            .caption(" ", font(20.0))
            .margin(8)
            .margin_left(2)
            .x_label_area_size(46)
            .right_y_label_area_size(72)
            .build_cartesian_2d(0.0..1.0, lo..hi)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(7)
            .y_label_formatter(&|v| format!(" {}", tick_label(*v, hi - lo)))
            .label_style(font(14.0))
            .draw()?;
        const STEPS: usize = 256;
        bar.draw_series((0..STEPS).map(|k| {
            let a = lo + (hi - lo) * k as f64 / STEPS as f64;
            let b = lo + (hi - lo) * (k + 1) as f64 / STEPS as f64;
            Rectangle::new([(0.0, a), (1.0, b)], turbo((k as f64 + 0.5) / STEPS as f64).filled())
        }))?;
        bar.plotting_area().draw(&Rectangle::new([(0.0, lo), (1.0, hi)], BLACK.stroke_width(1)))?;
        // The unit under the bar.
        let (bw, bh) = bar_area.dim_in_pixel();
        crate::figure::centred_text(&bar_area, c.error_unit(), (bw as i32 / 2 - 20, bh as i32 - 38), 16.0)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_sample_on_a_uniform_axis() {
        let axis = [-0.5, -0.25, 0.0, 0.25, 0.5];
        assert_eq!(nearest(&axis, -0.6), 0);
        assert_eq!(nearest(&axis, 0.1), 2);
        assert_eq!(nearest(&axis, 0.13), 3);
        assert_eq!(nearest(&[2.0], 7.0), 0);
    }

    #[test]
    fn a_few_huge_values_clip_the_colour_bar() {
        let mut v: Vec<f64> = (0..1000).map(|i| i as f64 / 1000.0).collect();
        v[3] = 1e6;
        let (lo, hi, clipped) = colour_range(&v, 1e-3);
        assert!(clipped && lo >= 0.0 && hi < 1.1);
        let (_, hi, clipped) = colour_range(&v[4..], 1e-3);
        assert!(!clipped && hi > 0.99);
    }
}
