//! The four clearance kinds of docs/model.md §5.

/// One kind of joint clearance. Kinds are independent and superpose (docs/model.md §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ClearanceKind {
    /// Radial clearance of the spherical joint S_j (m).
    SRadial,
    /// Radial clearance of the revolute joint R_j (m).
    RRadial,
    /// Axial clearance of the revolute joint R_j (m).
    RAxial,
    /// Angular clearance of the revolute joint R_j (rad).
    RAngular,
}

/// All kinds, in the order used for per-kind arrays everywhere in the engine.
pub const KINDS: [ClearanceKind; 4] =
    [ClearanceKind::SRadial, ClearanceKind::RRadial, ClearanceKind::RAxial, ClearanceKind::RAngular];

impl ClearanceKind {
    /// The name used in job files and output columns (`s_radial`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::SRadial => "s_radial",
            Self::RRadial => "r_radial",
            Self::RAxial => "r_axial",
            Self::RAngular => "r_angular",
        }
    }

    /// Index into per-kind arrays (the order of [`KINDS`]).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Parses a kind name.
    pub fn from_name(name: &str) -> Option<Self> {
        KINDS.into_iter().find(|k| k.name() == name)
    }
}

/// The name of a joint and clearance kind, as the `dominant` column spells it: the
/// kind's name with the limb (`limb` from 0) after the joint's letter (`s1_radial`,
/// `r2_axial`, …). `kind` indexes [`KINDS`].
pub fn joint_name(kind: usize, limb: usize) -> String {
    joint_label(KINDS[kind].name(), limb)
}

/// [`joint_name`] for a kind given by its name (the 6-UPS's `u_radial` gives `u5_radial`
/// for `limb = 4`).
pub fn joint_label(kind: &str, limb: usize) -> String {
    format!("{}{}{}", &kind[..1], limb + 1, &kind[1..])
}
