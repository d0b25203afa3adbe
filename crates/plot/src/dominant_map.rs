//! The joint to tighten: a categorical map over the Ψ–Θ workspace at one `z` of the
//! joint whose own take-up moves P most (the `dominant` column), with each joint's
//! share of the poses in the legend and the switch locus drawn over it.
//!
//! A joint keeps its colour in every figure: one hue per clearance kind, darker to
//! lighter from limb 1 to limb 3.

use std::path::Path;

use plotters::prelude::*;

use crate::PlotError;
use crate::error_map::{MAP_SIZE, draw_map};
use crate::figure::{Area, DrawResult, NULL_GREY, font, header, render};

const HEADER: u32 = 100;
const LEGEND_WIDTH: u32 = 420;

/// Three shades per kind, in the order of the joints (`run_dir::joints`): purples for
/// `s_radial`, blues for `r_radial`, greens for `r_axial`, oranges for `r_angular`.
const PALETTE: [RGBColor; 12] = [
    RGBColor(84, 39, 143),
    RGBColor(128, 125, 186),
    RGBColor(188, 189, 220),
    RGBColor(8, 81, 156),
    RGBColor(49, 130, 189),
    RGBColor(132, 186, 222),
    RGBColor(0, 109, 44),
    RGBColor(49, 163, 84),
    RGBColor(150, 210, 140),
    RGBColor(166, 54, 3),
    RGBColor(230, 85, 13),
    RGBColor(253, 160, 90),
];

/// The colour of joint category `k` (its place in `run_dir::joints`).
fn joint_colour(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// The colour (RGB) the dominant-joint maps give a joint named as in the `dominant`
/// column (`r2_radial`); `None` for a name the engine does not write.
pub fn dominant_colour(joint: &str) -> Option<[u8; 3]> {
    let k = crate::run_dir::joints().iter().position(|j| j == joint)?;
    let RGBColor(r, g, b) = joint_colour(k);
    Some([r, g, b])
}

/// The categories present in `values` (category numbers, NaN for none) with their
/// share of the slots that have one, in category order.
pub(crate) fn shares(values: &[f64], categories: usize) -> Vec<(usize, f64)> {
    let mut count = vec![0usize; categories];
    for v in values.iter().filter(|v| v.is_finite()) {
        if let Some(c) = count.get_mut(*v as usize) {
            *c += 1;
        }
    }
    let total: usize = count.iter().sum();
    count.iter().enumerate().filter(|(_, n)| **n > 0).map(|(k, n)| (k, *n as f64 / total as f64)).collect()
}

/// Everything one dominant-joint figure shows.
pub(crate) struct DominantMap<'a> {
    pub title: String,
    pub subtitle: String,
    pub psi: &'a [f64],
    pub theta: &'a [f64],
    /// The category of each slot `i_ψ·len(θ) + i_θ`, NaN where the pose has none.
    pub values: &'a [f64],
    /// The joints' names, by category.
    pub names: &'a [String],
    /// Switch locations `(ψ, θ)`.
    pub switches: Vec<(f64, f64)>,
}

impl DominantMap<'_> {
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        render(path, MAP_SIZE, |root| {
            let body = header(root, &self.title, &self.subtitle, HEADER)?;
            let (w, _) = body.dim_in_pixel();
            let (map_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);
            let colour = |slot: usize| {
                let v = self.values[slot];
                if v.is_finite() { joint_colour(v as usize) } else { NULL_GREY }
            };
            let caption = "joint whose own take-up moves P most";
            draw_map(&map_area, caption, (self.psi, self.theta), &self.switches, colour)?;
            self.draw_legend(&legend_area)
        })
    }

    /// A swatch, the joint's name and its share of the poses with a dominant joint,
    /// one line per joint present; then grey for the poses without one.
    fn draw_legend(&self, area: &Area<'_>) -> DrawResult {
        let shares = shares(self.values, self.names.len());
        let swatch = |row: usize, colour: RGBColor, text: String| -> DrawResult {
            let y = 60 + 36 * row as i32;
            area.draw(&Rectangle::new([(16, y), (44, y + 28)], colour.filled()))?;
            area.draw(&Rectangle::new([(16, y), (44, y + 28)], BLACK.stroke_width(1)))?;
            area.draw(&Text::new(text, (56, y + 4), font(18.0)))?;
            Ok(())
        };
        area.draw(&Text::new("share of the poses", (16, 24), font(18.0)))?;
        for (row, &(k, share)) in shares.iter().enumerate() {
            swatch(row, joint_colour(k), format!("{}   {:.1} %", self.names[k], 100.0 * share))?;
        }
        if self.values.iter().any(|v| !v.is_finite()) {
            swatch(shares.len(), NULL_GREY, "none (status ≠ ok)".to_string())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_count_each_category_among_the_poses_that_have_one() {
        let values = [2.0, 2.0, f64::NAN, 5.0, 2.0, 11.0, 42.0];
        // 42 is no category: it is not counted, like the null.
        assert_eq!(shares(&values, 12), vec![(2, 0.6), (5, 0.2), (11, 0.2)]);
        assert!(shares(&[f64::NAN], 12).is_empty());
    }

    #[test]
    fn every_joint_has_its_own_colour_and_none_is_the_null_grey() {
        for (k, c) in PALETTE.iter().enumerate() {
            assert_ne!(*c, NULL_GREY);
            assert!(PALETTE[k + 1..].iter().all(|d| d != c), "colour {k} repeats");
        }
    }
}
