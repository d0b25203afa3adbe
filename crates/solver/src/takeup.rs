//! How each clearance is taken up under the joint reactions (docs/model.md §5).
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
use crate::fast::Reactions;
use crate::lanes::{Lane, Mask, V3, lane3, lane3v};

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

/// [`TakeUp`] of one pose or a batch.
#[derive(Clone, Copy)]
pub struct TakeUps<L: Lane> {
    pub s: [V3<L>; 3],
    pub r_radial: [V3<L>; 3],
    pub r_axial: [V3<L>; 3],
    pub r_angular: [V3<L>; 3],
    /// Per kind (order of `KINDS`), per limb.
    pub margins: [[L; 3]; 4],
    pub indeterminate: [L::M; 4],
}

impl<L: Lane> TakeUps<L> {
    /// Lane `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> TakeUp {
        let m = &self.margins;
        let ind = &self.indeterminate;
        TakeUp {
            s: lane3v(&self.s, i),
            r_radial: lane3v(&self.r_radial, i),
            r_axial: lane3v(&self.r_axial, i),
            r_angular: lane3v(&self.r_angular, i),
            margins: Margins {
                s: lane3(&m[0], i),
                r_radial: lane3(&m[1], i),
                r_axial: lane3(&m[2], i),
                r_angular: lane3(&m[3], i),
            },
            indeterminate: [ind[0].get(i), ind[1].get(i), ind[2].get(i), ind[3].get(i)],
        }
    }
}

/// `−mag·v/|v|`, or zero when the load is at or below the floor (direction undefined).
#[inline(always)]
fn against<L: Lane>(v: V3<L>, norm: L, mag: f64, floor: L) -> V3<L> {
    let defined = norm.gt(floor) & norm.gt(L::constant(0.0));
    V3::select(defined, v.times(-(L::constant(mag) / norm)), V3::zero())
}

/// The take-up of every clearance for the given reactions. `clearance` is in the
/// order of `KINDS`; `floor` is the indeterminate-load threshold.
#[inline(always)]
pub fn take_ups<L: Lane>(geom: &Geometry, r: &Reactions<L>, clearance: &[f64; 4], floor: f64) -> TakeUps<L> {
    let floor = L::constant(floor);
    let zero = L::constant(0.0);
    let mut t = TakeUps {
        s: [V3::zero(); 3],
        r_radial: [V3::zero(); 3],
        r_axial: [V3::zero(); 3],
        r_angular: [V3::zero(); 3],
        margins: [[zero; 3]; 4],
        indeterminate: [L::M::splat(false); 4],
    };
    let [s, rr, ra, rang] = *clearance;
    for j in 0..3 {
        let y = V3::splat(&geom.y[j]);
        let (fs, fr, mr) = (r.f_s[j], r.f_r[j], r.m_r[j]);
        let axial = fr.dot(y);
        let perp = fr - y.times(axial);
        let (ns, np, na, nm) = (fs.norm(), perp.norm(), axial.abs(), mr.norm());
        t.margins[0][j] = ns;
        t.margins[1][j] = np;
        t.margins[2][j] = na;
        t.margins[3][j] = nm;
        t.s[j] = against(fs, ns, s, floor);
        t.r_radial[j] = against(perp, np, rr, floor);
        t.r_axial[j] = V3::select(na.gt(floor), y.times(L::constant(-ra) * axial.signum()), V3::zero());
        t.r_angular[j] = against(mr, nm, rang, floor);
    }
    for k in 0..4 {
        if clearance[k] > 0.0 {
            let m = &t.margins[k];
            t.indeterminate[k] = m[0].le(floor) | m[1].le(floor) | m[2].le(floor);
        }
    }
    t
}

/// [`take_ups`] of one pose.
pub fn take_up(geom: &Geometry, r: &JointReactions, clearance: &[f64; 4], floor: f64) -> TakeUp {
    take_ups(geom, &Reactions::from_joint(r), clearance, floor).get(0)
}
