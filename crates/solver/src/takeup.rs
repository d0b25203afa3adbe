//! How each clearance is taken up under the joint reactions (MODEL.md §5).
//!
//! The distal part of a joint is pushed against the wall opposite to the load the
//! proximal part exerts on it:
//!
//! | kind | displacement of the distal part | deciding load (margin) |
//! |---|---|---|
//! | `s_radial` | `ΔA_j = −s·f_Sj/|f_Sj|` (platform relative to leg) | `|f_Sj|` |
//! | `r_radial` | `ΔB_j = −r·f⊥/|f⊥|`, `f⊥ = f_Rj − (f_Rj·y_j)·y_j` | `|f⊥|` |
//! | `r_axial` | `ΔB_j = −a·sign(f_Rj·y_j)·y_j` | `|f_Rj·y_j|` |
//! | `r_angular` | `Δθ_j = −θ·m_Rj/|m_Rj|` (rotation vector of the leg) | `|m_Rj|` |

use clearance_kinematics::Geometry;
use nalgebra::Vector3;

use crate::equilibrium::JointReactions;

/// The loads that decide each take-up, per limb (N or N·m).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Margins {
    pub s: [f64; 3],
    pub r_radial: [f64; 3],
    pub r_axial: [f64; 3],
    pub r_angular: [f64; 3],
}

impl Margins {
    /// Margins in the order of `clearance_model::KINDS`.
    pub fn by_kind(&self) -> [[f64; 3]; 4] {
        [self.s, self.r_radial, self.r_axial, self.r_angular]
    }
}

/// Clearance displacements at full take-up, per kind and limb, and whether each
/// kind's take-up is determinate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TakeUp {
    /// S translation of the platform relative to leg j (`s_radial`).
    pub s: [Vector3<f64>; 3],
    /// R translation of leg j relative to its slider (`r_radial`).
    pub r_radial: [Vector3<f64>; 3],
    /// R translation along `y_j` (`r_axial`).
    pub r_axial: [Vector3<f64>; 3],
    /// R rotation vector of leg j relative to its slider (`r_angular`).
    pub r_angular: [Vector3<f64>; 3],
    pub margins: Margins,
    /// Per kind: some limb's deciding load is at or below the noise floor while
    /// the kind's clearance is non-zero.
    pub indeterminate: [bool; 4],
}

/// `−mag·v/|v|`, or zero when the load is at or below the floor (direction undefined).
fn against(v: Vector3<f64>, norm: f64, mag: f64, floor: f64) -> Vector3<f64> {
    if norm > floor && norm > 0.0 { -(mag / norm) * v } else { Vector3::zeros() }
}

/// The take-up of every clearance for the given reactions. `clearance` is in the
/// order of `KINDS`; `floor` is the indeterminate-load threshold.
pub fn take_up(geom: &Geometry, r: &JointReactions, clearance: &[f64; 4], floor: f64) -> TakeUp {
    let mut t = TakeUp::default();
    let [s, rr, ra, rang] = *clearance;
    for j in 0..3 {
        let y = geom.y[j];
        let fs = r.f_s[j];
        let fr = r.f_r[j];
        let axial = fr.dot(&y);
        let perp = fr - axial * y;
        let (ns, np, na, nm) = (fs.norm(), perp.norm(), axial.abs(), r.m_r[j].norm());
        t.margins.s[j] = ns;
        t.margins.r_radial[j] = np;
        t.margins.r_axial[j] = na;
        t.margins.r_angular[j] = nm;
        t.s[j] = against(fs, ns, s, floor);
        t.r_radial[j] = against(perp, np, rr, floor);
        t.r_axial[j] = if na > floor { -ra * axial.signum() * y } else { Vector3::zeros() };
        t.r_angular[j] = against(r.m_r[j], nm, rang, floor);
        for (k, (&mag, margin)) in clearance.iter().zip([ns, np, na, nm]).enumerate() {
            if mag > 0.0 && margin <= floor {
                t.indeterminate[k] = true;
            }
        }
    }
    t
}
