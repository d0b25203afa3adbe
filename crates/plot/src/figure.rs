//! What every figure shares: the six error components, the colours, the fonts,
//! axis ranges and tick labels, the header, line panels and writing the PNG.

use std::path::Path;

use clearance_model::ClearanceSpec;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::PlotError;

/// A drawing that failed; turned into [`PlotError::Draw`] with the file's name.
pub(crate) type DrawResult = Result<(), Box<dyn std::error::Error>>;
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// One of the six pose-error components of the paper's figures.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Component {
    /// Column suffix: `err_<suffix>`, `err_<kind>_<suffix>`.
    pub suffix: &'static str,
    pub symbol: &'static str,
    pub angle: bool,
}

/// X, Y, Z of the tool-centre point, then the Euler angles Ψ, Θ, Φ.
pub(crate) const COMPONENTS: [Component; 6] = [
    Component { suffix: "x", symbol: "X", angle: false },
    Component { suffix: "y", symbol: "Y", angle: false },
    Component { suffix: "z", symbol: "Z", angle: false },
    Component { suffix: "psi", symbol: "Ψ", angle: true },
    Component { suffix: "theta", symbol: "Θ", angle: true },
    Component { suffix: "phi", symbol: "Φ", angle: true },
];

/// The envelope's components (`env_<suffix>`): the largest |Δp_x|, |Δp_y|, |Δp_z|,
/// |Δα_x|, |Δα_y|, |Δα_z| over every admissible take-up.
pub(crate) const ENVELOPE_COMPONENTS: [Component; 6] = [
    Component { suffix: "x", symbol: "X max", angle: false },
    Component { suffix: "y", symbol: "Y max", angle: false },
    Component { suffix: "z", symbol: "Z max", angle: false },
    Component { suffix: "rx", symbol: "αx max", angle: true },
    Component { suffix: "ry", symbol: "αy max", angle: true },
    Component { suffix: "rz", symbol: "αz max", angle: true },
];

/// Errors are drawn in µm and µrad: clearances are tens to hundreds of µm.
pub(crate) const ERROR_SCALE: f64 = 1e6;

impl Component {
    pub fn error_unit(self) -> &'static str {
        if self.angle { "µrad" } else { "µm" }
    }
}

/// Which error a figure shows: all kinds together, or one kind alone, named as in
/// the job's `[clearance]` (`r_axial`, `u_radial`, …; the mechanism's `clearance_keys`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Source {
    Total,
    Kind(&'static str),
}

impl Source {
    pub fn column(self, c: Component) -> String {
        match self {
            Source::Total => format!("err_{}", c.suffix),
            Source::Kind(k) => format!("err_{k}_{}", c.suffix),
        }
    }

    /// The file name stem: `total` or the kind's name.
    pub fn stem(self) -> &'static str {
        match self {
            Source::Total => "total",
            Source::Kind(k) => k,
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            Source::Total => "all clearances",
            Source::Kind("s_radial") => "radial clearance at S joints",
            Source::Kind("r_radial") => "radial clearance at R joints",
            Source::Kind("r_axial") => "axial clearance at R joints",
            Source::Kind("r_angular") => "angular clearance at R joints",
            Source::Kind("u_radial") => "radial clearance at U joints",
            Source::Kind("u_angular") => "angular clearance at U joints",
            Source::Kind(k) => k,
        }
    }

    /// Does a switch of `kind` belong on this figure?
    pub fn shows(self, kind: &str) -> bool {
        match self {
            Source::Total => true,
            Source::Kind(k) => k == kind,
        }
    }
}

/// The magnitude of the clearance kind `name` in a job (0 for a name it has not).
pub(crate) fn clearance_of(c: &ClearanceSpec, name: &str) -> f64 {
    match name {
        "s_radial" => c.s_radial,
        "r_radial" => c.r_radial,
        "r_axial" => c.r_axial,
        "r_angular" => c.r_angular,
        "u_radial" => c.u_radial,
        "u_angular" => c.u_angular,
        _ => 0.0,
    }
}

/// Every pose input, in the grids' row-major order (a 3-limb job's `x, y, phi` are
/// single zeros there).
pub(crate) const INPUTS: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];

/// The symbol and unit of an input (`psi` → Ψ, rad) or of time `t`.
pub(crate) fn input_symbol(name: &str) -> (&'static str, &'static str) {
    match name {
        "x" => ("X", "m"),
        "y" => ("Y", "m"),
        "z" => ("Z", "m"),
        "phi" => ("Φ", "rad"),
        "psi" => ("Ψ", "rad"),
        "theta" => ("Θ", "rad"),
        _ => ("t", "s"),
    }
}

/// An axis label: `Ψ (rad)`.
pub(crate) fn input_desc(name: &str) -> String {
    let (symbol, unit) = input_symbol(name);
    format!("{symbol} ({unit})")
}

pub(crate) const FONT: &str = "sans-serif";
/// Drawn where a pose has no value (a status other than `ok`).
pub(crate) const NULL_GREY: RGBColor = RGBColor(185, 185, 185);
/// The paper's colours: kinetostatics black, dynamics blue.
pub(crate) fn mode_colour(mode: &str) -> RGBColor {
    match mode {
        "kinetostatic" => BLACK,
        "dynamic" => RGBColor(25, 90, 230),
        _ => RGBColor(200, 60, 20),
    }
}

pub(crate) fn font(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// "Turbo" (Mikhailov, 2019), a rainbow map with even lightness steps: blue low,
/// green middle, red high, as in the paper's maps. `t` in [0, 1].
pub(crate) fn turbo(t: f64) -> RGBColor {
    // Turbo's darkest ends are cut off so the black switch dots stay visible on them.
    let t = 0.05 + 0.9 * t.clamp(0.0, 1.0);
    let poly = |c: [f64; 6]| {
        let v = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))));
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    };
    RGBColor(
        poly([0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943]),
        poly([0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604]),
        poly([0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973]),
    )
}

/// The finite range of `values`, at least `min_span` wide (centred on the data),
/// so that round-off noise on an error that is really zero draws as a flat zero
/// rather than as a magnified pattern.
pub(crate) fn value_range(values: impl IntoIterator<Item = f64>, min_span: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.into_iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (-min_span.max(1e-300), min_span.max(1e-300));
    }
    let min_span = min_span.max(1e-300);
    if hi - lo < min_span {
        let mid = 0.5 * (lo + hi);
        return (mid - 0.5 * min_span, mid + 0.5 * min_span);
    }
    (lo, hi)
}

/// `(lo, hi)` widened by `fraction` of its span on each side.
pub(crate) fn padded((lo, hi): (f64, f64), fraction: f64) -> (f64, f64) {
    let pad = (hi - lo) * fraction;
    (lo - pad, hi + pad)
}

/// The largest finite |value|.
pub(crate) fn max_abs(values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().filter(|v| v.is_finite()).fold(0.0, |m, v| m.max(v.abs()))
}

/// A tick label with as many decimals as the tick spacing needs.
pub(crate) fn tick_label(v: f64, span: f64) -> String {
    let step = span / 6.0;
    if step <= 0.0 || !step.is_finite() {
        return format!("{v}");
    }
    if v.abs() < step * 1e-6 {
        return "0".to_string();
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    if decimals > 5 || v.abs() >= 1e6 {
        return format!("{v:.1e}");
    }
    // Ticks at 2.5·10^k need one decimal more than the spacing suggests.
    (decimals..decimals + 3)
        .map(|d| format!("{v:.d$}"))
        .find(|s| s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= step * 1e-3))
        .unwrap_or_else(|| format!("{v:.decimals$}"))
}

/// An SI prefix that shows values up to `max_abs` (in `unit`) as numbers of
/// reasonable size: `(factor, "mm")` to multiply by.
pub(crate) fn si_prefix(max_abs: f64, unit: &str) -> (f64, String) {
    for (factor, prefix) in [(1.0, ""), (1e3, "m"), (1e6, "µ"), (1e9, "n")] {
        if max_abs * factor >= 0.1 {
            return (factor, format!("{prefix}{unit}"));
        }
    }
    (1e9, format!("n{unit}"))
}

/// Draws the title and the subtitle (wrapped at its " · " separators to the
/// figure's width) and returns the area below `height`.
/// A title too long for the figure is cut short with an ellipsis.
pub(crate) fn header<'a>(
    root: &Area<'a>,
    title: &str,
    subtitle: &str,
    height: u32,
) -> Result<Area<'a>, Box<dyn std::error::Error>> {
    let width = root.dim_in_pixel().0.saturating_sub(48);
    let title_style = font(26.0);
    let mut title = title.to_string();
    while !title.is_empty() && root.estimate_text_size(&title, &title_style)?.0 > width {
        title = title.trim_end_matches('…').trim_end().to_string();
        title.pop();
        title = format!("{}…", title.trim_end());
        if title == "…" {
            break;
        }
    }
    root.draw(&Text::new(title, (24, 14), title_style))?;
    let style = font(17.0).color(&RGBColor(60, 60, 60));
    let mut lines: Vec<String> = Vec::new();
    for part in subtitle.split(" · ") {
        match lines.last_mut() {
            Some(line) if root.estimate_text_size(&format!("{line} · {part}"), &style)?.0 <= width => {
                line.push_str(" · ");
                line.push_str(part);
            }
            _ => lines.push(part.to_string()),
        }
    }
    for (k, line) in lines.iter().enumerate() {
        root.draw(&Text::new(line.clone(), (24, 50 + 23 * k as i32), style.clone()))?;
    }
    let (_, body) = root.split_vertically(height);
    Ok(body)
}

/// Draws centred `text` at `(x, y)` (top-anchored).
pub(crate) fn centred_text(area: &Area<'_>, text: &str, (x, y): (i32, i32), size: f64) -> DrawResult {
    let style = font(size).pos(Pos::new(HPos::Center, VPos::Top));
    area.draw(&Text::new(text.to_string(), (x, y), style))?;
    Ok(())
}

/// A curve of a line panel; NaN values break the line (nulls are not joined).
pub(crate) struct Curve {
    pub points: Vec<(f64, f64)>,
    pub colour: RGBColor,
    /// Stroke width in pixels.
    pub width: u32,
}

/// A vertical dashed line (a switch) at `x`.
pub(crate) struct Marker {
    pub x: f64,
    pub colour: RGBColor,
}

/// One panel of curves against a common abscissa.
pub(crate) struct LinePanel<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
    pub curves: Vec<Curve>,
    pub markers: Vec<Marker>,
}

impl LinePanel<'_> {
    pub fn draw(&self, area: &Area<'_>) -> DrawResult {
        let (x0, x1) = self.x_range;
        let (y0, y1) = self.y_range;
        let (xs, ys) = (x1 - x0, y1 - y0);
        let mut chart = ChartBuilder::on(area)
            .caption(self.title, font(20.0))
            .margin(8)
            .margin_right(18)
            .x_label_area_size(48)
            .y_label_area_size(78)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .x_labels(7)
            .y_labels(6)
            .x_label_formatter(&|v| tick_label(*v, xs))
            .y_label_formatter(&|v| tick_label(*v, ys))
            .label_style(font(14.0))
            .axis_desc_style(font(16.0))
            .x_desc(self.x_desc)
            .y_desc(self.y_desc)
            .draw()?;
        for m in &self.markers {
            chart.draw_series(DashedLineSeries::new(
                [(m.x, y0), (m.x, y1)],
                6,
                4,
                m.colour.mix(0.7).stroke_width(1),
            ))?;
        }
        for c in &self.curves {
            for segment in c.points.split(|p| !(p.0.is_finite() && p.1.is_finite())) {
                if segment.len() == 1 {
                    chart.draw_series(std::iter::once(Circle::new(segment[0], 1, c.colour.filled())))?;
                } else if !segment.is_empty() {
                    chart.draw_series(LineSeries::new(segment.iter().copied(), c.colour.stroke_width(c.width)))?;
                }
            }
        }
        Ok(())
    }
}

/// Renders a `size` PNG at `path` via a temporary sibling, so a figure appears
/// under its name only when complete.
pub(crate) fn render(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> DrawResult,
) -> Result<(), PlotError> {
    let name = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    // The encoder picks the format from the extension, so the temporary keeps `.png`.
    let tmp = path.with_file_name(format!(".{name}.tmp-{}.png", std::process::id()));
    let result = (|| -> DrawResult {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(PlotError::draw(path)(e));
    }
    std::fs::rename(&tmp, path).map_err(PlotError::io(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_of_round_off_noise_is_a_flat_band_around_it() {
        let (lo, hi) = value_range([1e-20, -2e-20, f64::NAN], 1e-3);
        assert!((hi - lo - 1e-3).abs() < 1e-15 && lo < 0.0 && hi > 0.0);
        assert_eq!(value_range([1.0, 3.0], 1e-3), (1.0, 3.0));
    }

    #[test]
    fn ticks_have_the_decimals_their_spacing_needs() {
        assert_eq!(tick_label(0.25, 1.0), "0.25");
        assert_eq!(tick_label(120.0, 600.0), "120");
        assert_eq!(tick_label(1e-12, 1.0), "0");
        assert_eq!(si_prefix(0.022, "m"), (1e3, "mm".to_string()));
        assert_eq!(si_prefix(0.5, "rad"), (1.0, "rad".to_string()));
    }

    #[test]
    fn turbo_runs_from_dark_blue_through_green_to_dark_red() {
        let (lo, mid, hi) = (turbo(0.0), turbo(0.5), turbo(1.0));
        assert!(lo.2 > lo.0 && mid.1 > mid.0 && mid.1 > mid.2 && hi.0 > hi.2);
    }
}
