//! The trade-off curve of `clearance allocate --budgets`: the least cost of the
//! joints' clearances against the error budget.

use std::path::Path;

use plotters::prelude::*;

use crate::PlotError;
use crate::figure::{Curve, LinePanel, padded, render, value_range};

/// Pixel size of the trade-off figure.
pub const TRADEOFF_SIZE: (u32, u32) = (1000, 700);

/// Draws cost against budget (`budgets_um` in µm, `costs` as `Σ w/c`) at `path`, a
/// point per budget joined by a line; budgets without an answer (infeasible) are
/// left out. `title` names the job and the model.
pub fn plot_tradeoff(path: &Path, title: &str, budgets_um: &[f64], costs: &[Option<f64>]) -> Result<(), PlotError> {
    crate::register_font()?;
    let points: Vec<(f64, f64)> = budgets_um.iter().zip(costs).filter_map(|(&b, c)| c.map(|c| (b, c))).collect();
    let x_range = padded(value_range(points.iter().map(|p| p.0), 1.0), 0.05);
    let y_range = padded(value_range(points.iter().map(|p| p.1), 1e-9), 0.08);
    let panel = LinePanel {
        title,
        x_desc: "budget max |Δp| (µm)",
        y_desc: "least cost Σ w/c",
        x_range,
        y_range,
        curves: vec![Curve { points: points.clone(), colour: RGBColor(31, 119, 180), width: 2 }],
        markers: Vec::new(),
    };
    render(path, TRADEOFF_SIZE, |area| {
        let area = area.margin(10, 10, 10, 10);
        panel.draw(&area)?;
        Ok(())
    })
}
