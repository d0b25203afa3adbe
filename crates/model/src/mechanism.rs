//! `[mechanism]` and `[mass]`: which robot of the family, its geometry and its
//! bodies (docs/model.md, "Mechanisms").
//!
//! Kind-dependent keys are optional in the file; [`MechanismSpec::fill_defaults`]
//! writes the kind's defaults into those a user left out, so that the provenance
//! `job.toml` shows them and a sweep can name them. Keys whose default follows
//! another key (`platform_angles_deg` follows `limb_angles_deg`, the stroke limits
//! follow the cylinder and piston lengths) stay unset until asked for, so that a
//! sweep of the key they follow moves them too.

use serde::{Deserialize, Serialize};

/// The robots the engine analyses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MechanismKind {
    /// Actuated prismatic joint on a rail, revolute, spherical: the paper's robot.
    #[default]
    #[serde(rename = "3-PRS")]
    Prs3,
    /// Revolute at the base, actuated leg (cylinder and piston), spherical.
    #[serde(rename = "3-RPS")]
    Rps3,
}

/// Every kind, in the order error messages list them.
pub const MECHANISM_KINDS: [MechanismKind; 2] = [MechanismKind::Prs3, MechanismKind::Rps3];

impl MechanismKind {
    /// The name used in job files (`3-PRS`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Prs3 => "3-PRS",
            Self::Rps3 => "3-RPS",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        MECHANISM_KINDS.into_iter().find(|k| k.name() == name)
    }

    /// Number of limbs.
    pub fn limbs(self) -> usize {
        3
    }

    /// The keys of `[mechanism]` this kind takes.
    pub fn mechanism_keys(self) -> &'static [&'static str] {
        match self {
            Self::Prs3 => &[
                "kind",
                "base_radius",
                "platform_radius",
                "leg_length",
                "gravity",
                "rail_angle_deg",
                "limb_angles_deg",
                "platform_angles_deg",
            ],
            Self::Rps3 => &[
                "kind",
                "base_radius",
                "platform_radius",
                "gravity",
                "limb_angles_deg",
                "platform_angles_deg",
                "cylinder_length",
                "piston_length",
                "min_length",
                "max_length",
            ],
        }
    }

    /// The keys of `[mass]` this kind takes.
    pub fn mass_keys(self) -> &'static [&'static str] {
        match self {
            Self::Prs3 => &["platform", "leg", "platform_inertia", "points"],
            Self::Rps3 => &["platform", "cylinder", "piston", "platform_inertia", "points"],
        }
    }
}

/// The limb angles of the paper's prototype (degrees).
pub const PROTOTYPE_LIMB_ANGLES_DEG: [f64; 3] = [0.0, 120.0, 240.0];

/// Geometry of the robot (docs/model.md). Lengths in m, angles of the geometry in
/// degrees; every optional key has its kind's default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MechanismSpec {
    /// Which robot. Default `"3-PRS"`.
    pub kind: MechanismKind,
    /// `R_b`, radius of the circle of the base joints. Default 0.18 (3-PRS), 0.3 (3-RPS).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_radius: Option<f64>,
    /// `r_p`, distance from P to each spherical joint. Default 0.36 (3-PRS), 0.2 (3-RPS).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platform_radius: Option<f64>,
    /// 3-PRS: `L`, length of each leg `B_j A_j`. Default 1.0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leg_length: Option<f64>,
    /// Gravity in the fixed frame (m/s²). Default `(0, 0, -9.81)`.
    pub gravity: [f64; 3],
    /// 3-PRS: `β`, the rails' angle from vertical towards `x_j` (0 vertical, 90
    /// horizontal outwards, −90 inwards). Default 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rail_angle_deg: Option<f64>,
    /// `α_j`, the limbs' angles about `z`. Default `[0, 120, 240]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limb_angles_deg: Option<Vec<f64>>,
    /// `γ_j`, the polar angles of the spherical joints on the platform. Default: the limb angles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platform_angles_deg: Option<Vec<f64>>,
    /// 3-RPS: length of the cylinder, from the base revolute. Default 0.8.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cylinder_length: Option<f64>,
    /// 3-RPS: length of the piston, up to the spherical joint. Default 0.8.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub piston_length: Option<f64>,
    /// 3-RPS: shortest leg. Default `max(cylinder_length, piston_length)` (fully retracted).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_length: Option<f64>,
    /// 3-RPS: longest leg. Default `cylinder_length + piston_length` (fully extended).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_length: Option<f64>,
}

impl Default for MechanismSpec {
    fn default() -> Self {
        Self {
            kind: MechanismKind::Prs3,
            base_radius: None,
            platform_radius: None,
            leg_length: None,
            gravity: [0.0, 0.0, -9.81],
            rail_angle_deg: None,
            limb_angles_deg: None,
            platform_angles_deg: None,
            cylinder_length: None,
            piston_length: None,
            min_length: None,
            max_length: None,
        }
    }
}

impl MechanismSpec {
    /// A mechanism of `kind` with every default.
    pub fn of_kind(kind: MechanismKind) -> Self {
        Self { kind, ..Self::default() }
    }

    pub fn base_radius(&self) -> f64 {
        self.base_radius.unwrap_or(match self.kind {
            MechanismKind::Prs3 => 0.18,
            MechanismKind::Rps3 => 0.3,
        })
    }

    pub fn platform_radius(&self) -> f64 {
        self.platform_radius.unwrap_or(match self.kind {
            MechanismKind::Prs3 => 0.36,
            MechanismKind::Rps3 => 0.2,
        })
    }

    /// 3-PRS: the leg length `L` (NaN for other kinds).
    pub fn leg_length(&self) -> f64 {
        match self.kind {
            MechanismKind::Prs3 => self.leg_length.unwrap_or(1.0),
            MechanismKind::Rps3 => f64::NAN,
        }
    }

    /// 3-PRS: `β` in degrees (0 for other kinds, whose base joints do not move).
    pub fn rail_angle_deg(&self) -> f64 {
        self.rail_angle_deg.unwrap_or(0.0)
    }

    pub fn limb_angles_deg(&self) -> Vec<f64> {
        self.limb_angles_deg.clone().unwrap_or_else(|| PROTOTYPE_LIMB_ANGLES_DEG.to_vec())
    }

    pub fn platform_angles_deg(&self) -> Vec<f64> {
        self.platform_angles_deg.clone().unwrap_or_else(|| self.limb_angles_deg())
    }

    pub fn cylinder_length(&self) -> f64 {
        self.cylinder_length.unwrap_or(0.8)
    }

    pub fn piston_length(&self) -> f64 {
        self.piston_length.unwrap_or(0.8)
    }

    pub fn min_length(&self) -> f64 {
        self.min_length.unwrap_or_else(|| self.cylinder_length().max(self.piston_length()))
    }

    pub fn max_length(&self) -> f64 {
        self.max_length.unwrap_or_else(|| self.cylinder_length() + self.piston_length())
    }

    /// A length scale of the mechanism: the leg (3-PRS) or the extended leg (3-RPS).
    pub fn length_scale(&self) -> f64 {
        match self.kind {
            MechanismKind::Prs3 => self.leg_length(),
            MechanismKind::Rps3 => self.max_length(),
        }
    }

    /// Writes the kind's defaults into the keys left out that follow no other key.
    pub fn fill_defaults(&mut self) {
        self.base_radius = Some(self.base_radius());
        self.platform_radius = Some(self.platform_radius());
        self.limb_angles_deg = Some(self.limb_angles_deg());
        match self.kind {
            MechanismKind::Prs3 => {
                self.leg_length = Some(self.leg_length());
                self.rail_angle_deg = Some(self.rail_angle_deg());
            }
            MechanismKind::Rps3 => {
                self.cylinder_length = Some(self.cylinder_length());
                self.piston_length = Some(self.piston_length());
            }
        }
    }

    /// The value of a key whose default follows another one, for a sweep that
    /// names it while the file leaves it out.
    pub fn implied(&self, key: &str) -> Option<toml::Value> {
        let list = |v: Vec<f64>| toml::Value::Array(v.into_iter().map(toml::Value::Float).collect());
        match (self.kind, key) {
            (_, "platform_angles_deg") => Some(list(self.platform_angles_deg())),
            (MechanismKind::Rps3, "min_length") => Some(toml::Value::Float(self.min_length())),
            (MechanismKind::Rps3, "max_length") => Some(toml::Value::Float(self.max_length())),
            _ => None,
        }
    }
}

/// Masses and inertias (docs/model.md, "Bodies").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MassSpec {
    /// Platform mass (kg), centre of mass at P. Default 9.8.
    pub platform: f64,
    /// 3-PRS: mass of each leg (kg), a slender rod. Default 3.0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub leg: Option<f64>,
    /// 3-RPS: mass of each cylinder (kg). Default 2.0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cylinder: Option<f64>,
    /// 3-RPS: mass of each piston (kg). Default 1.0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub piston: Option<f64>,
    /// Platform inertia about P in platform axes `[Ixx, Iyy, Izz]` (kg·m²);
    /// default a thin uniform disc of radius `platform_radius`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platform_inertia: Option<[f64; 3]>,
    /// Point masses rigidly attached to the platform.
    pub points: Vec<PointMass>,
}

impl Default for MassSpec {
    fn default() -> Self {
        Self { platform: 9.8, leg: None, cylinder: None, piston: None, platform_inertia: None, points: Vec::new() }
    }
}

impl MassSpec {
    /// 3-PRS: each leg's mass (0 for other kinds).
    pub fn leg(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Prs3 => self.leg.unwrap_or(3.0),
            MechanismKind::Rps3 => 0.0,
        }
    }

    /// 3-RPS: each cylinder's mass (0 for other kinds).
    pub fn cylinder(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Rps3 => self.cylinder.unwrap_or(2.0),
            MechanismKind::Prs3 => 0.0,
        }
    }

    /// 3-RPS: each piston's mass (0 for other kinds).
    pub fn piston(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Rps3 => self.piston.unwrap_or(1.0),
            MechanismKind::Prs3 => 0.0,
        }
    }

    /// The mass of one limb's moving bodies.
    pub fn limb(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Prs3 => self.leg(kind),
            MechanismKind::Rps3 => self.cylinder(kind) + self.piston(kind),
        }
    }

    /// Writes the kind's defaults into the masses left out.
    pub fn fill_defaults(&mut self, kind: MechanismKind) {
        match kind {
            MechanismKind::Prs3 => self.leg = Some(self.leg(kind)),
            MechanismKind::Rps3 => {
                self.cylinder = Some(self.cylinder(kind));
                self.piston = Some(self.piston(kind));
            }
        }
    }
}

/// A point mass on the platform: `mass` (kg) at `at` (m, platform frame).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointMass {
    pub mass: f64,
    pub at: [f64; 3],
}
