//! The joint to tighten: a categorical map over the Ψ–Θ workspace at one `z` of the
//! joint whose own take-up moves P most (the `dominant` column), with each joint's
//! share of the poses in the legend and the switch locus drawn over it.
//!
//! A joint keeps its colour in every figure: one hue per clearance kind, darker to
//! lighter from limb 1 to limb 3 (the 6-UPS's `s4..s6_radial` in magentas beside the
//! purples of `s1..s3_radial`; `u_radial` in teals and `u_angular` in browns, darker to
//! lighter from limb 1 to limb 6).

use std::path::Path;

use clearance_model::MechanismKind;
use plotters::prelude::*;

use crate::PlotError;
use crate::error_map::{MAP_SIZE, draw_map};
use crate::figure::{Area, DrawResult, NULL_GREY, font, header, render};
use crate::run_dir::{Plane, joints};

const HEADER: u32 = 100;
const LEGEND_WIDTH: u32 = 420;

/// One colour per joint, in the order of [`all_joints`]. The 3-limb joints first,
/// three shades per kind: purples for `s_radial`, blues for `r_radial`, greens for
/// `r_axial`, oranges for `r_angular`. Then the 6-UPS joints they do not name:
/// magentas for `s4..s6_radial`, six teals for `u_radial`, six browns for `u_angular`.
const PALETTE: [RGBColor; 27] = [
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
    // 6-UPS: s4..s6_radial.
    RGBColor(174, 1, 126),
    RGBColor(221, 52, 151),
    RGBColor(250, 159, 181),
    // u1..u6_radial.
    RGBColor(0, 64, 59),
    RGBColor(0, 96, 88),
    RGBColor(0, 128, 118),
    RGBColor(64, 160, 151),
    RGBColor(128, 192, 186),
    RGBColor(178, 226, 216),
    // u1..u6_angular.
    RGBColor(83, 48, 13),
    RGBColor(124, 73, 20),
    RGBColor(166, 97, 26),
    RGBColor(188, 136, 83),
    RGBColor(210, 176, 140),
    RGBColor(233, 216, 198),
];

/// Every joint any mechanism's `dominant` column can name: the 3-limb joints, then
/// the 6-UPS joints not among them. A joint's place here is its colour's in [`PALETTE`].
fn all_joints() -> Vec<String> {
    let mut all = joints(MechanismKind::Prs3);
    for joint in joints(MechanismKind::Ups6) {
        if !all.contains(&joint) {
            all.push(joint);
        }
    }
    all
}

/// The colour of the joint named `joint`.
fn joint_colour(joint: &str) -> Option<RGBColor> {
    all_joints().iter().position(|j| j == joint).map(|k| PALETTE[k])
}

/// The colour (RGB) the dominant-joint maps give a joint named as in the `dominant`
/// column (`r2_radial`, `u5_radial`); `None` for a name the engine does not write.
pub fn dominant_colour(joint: &str) -> Option<[u8; 3]> {
    let RGBColor(r, g, b) = joint_colour(joint)?;
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
    pub plane: &'a Plane,
    /// The category of each slot `i_across·len(up) + i_up`, NaN where the pose has none.
    pub values: &'a [f64],
    /// The joints' names, by category.
    pub names: &'a [String],
    /// Switch locations `(across, up)`.
    pub switches: Vec<(f64, f64)>,
}

impl DominantMap<'_> {
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        // Each category's colour, looked up once rather than per pixel.
        let colours: Vec<RGBColor> = self.names.iter().map(|n| joint_colour(n).unwrap_or(NULL_GREY)).collect();
        render(path, MAP_SIZE, |root| {
            let body = header(root, &self.title, &self.subtitle, HEADER)?;
            let (w, _) = body.dim_in_pixel();
            let (map_area, legend_area) = body.split_horizontally(w - LEGEND_WIDTH);
            let colour = |slot: usize| {
                let v = self.values[slot];
                if v.is_finite() { colours[v as usize] } else { NULL_GREY }
            };
            let caption = "joint whose own take-up moves P most";
            draw_map(&map_area, caption, self.plane, &self.switches, colour)?;
            self.draw_legend(&legend_area, &colours)
        })
    }

    /// A swatch, the joint's name and its share of the poses with a dominant joint,
    /// one line per joint present; then grey for the poses without one.
    fn draw_legend(&self, area: &Area<'_>, colours: &[RGBColor]) -> DrawResult {
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
            swatch(row, colours[k], format!("{}   {:.1} %", self.names[k], 100.0 * share))?;
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
        let all = all_joints();
        assert_eq!(all.len(), PALETTE.len(), "{all:?}");
        // Visibly apart: no two joints (nor a joint and the null grey) closer than 40 in
        // the sum of their channel differences.
        let distance = |a: RGBColor, b: RGBColor| {
            [(a.0, b.0), (a.1, b.1), (a.2, b.2)].map(|(x, y)| u32::from(x.abs_diff(y))).iter().sum::<u32>()
        };
        for (k, &c) in PALETTE.iter().enumerate() {
            assert!(distance(c, NULL_GREY) >= 40, "{} is near the null grey", all[k]);
            for (l, &d) in PALETTE.iter().enumerate().skip(k + 1) {
                assert!(distance(c, d) >= 40, "{} and {} look alike", all[k], all[l]);
            }
        }
        // Every joint of every mechanism has one, and a joint keeps it across kinds.
        for kind in [MechanismKind::Prs3, MechanismKind::Rps3, MechanismKind::Ups6] {
            for joint in joints(kind) {
                assert!(dominant_colour(&joint).is_some(), "{joint}");
            }
        }
        assert_eq!(dominant_colour("s1_radial"), Some([84, 39, 143]));
        assert_eq!(dominant_colour("u6_angular"), Some([233, 216, 198]));
        assert_eq!(dominant_colour("u7_radial"), None);
    }
}
