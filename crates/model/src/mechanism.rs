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
    /// The Gough–Stewart platform: universal joint at the base, actuated leg,
    /// spherical joint; six limbs and six inputs.
    #[serde(rename = "6-UPS")]
    Ups6,
    /// Any parallel mechanism described by its joints (docs/model.md §12).
    #[serde(rename = "custom")]
    Custom,
}

/// Every kind, in the order error messages list them.
pub const MECHANISM_KINDS: [MechanismKind; 4] =
    [MechanismKind::Prs3, MechanismKind::Rps3, MechanismKind::Ups6, MechanismKind::Custom];

impl MechanismKind {
    /// The name used in job files (`3-PRS`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Prs3 => "3-PRS",
            Self::Rps3 => "3-RPS",
            Self::Ups6 => "6-UPS",
            Self::Custom => "custom",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        MECHANISM_KINDS.into_iter().find(|k| k.name() == name)
    }

    /// Whether the kind has the general solver (the assembled 24 × 24 and 12 × 12
    /// systems of the 3-limb kinds); a 6-UPS or custom mechanism has its own only.
    pub fn has_general_solver(self) -> bool {
        matches!(self, Self::Prs3 | Self::Rps3)
    }

    /// Number of limbs of a built-in kind (a custom mechanism's are its description's: 0 here).
    pub fn limbs(self) -> usize {
        match self {
            Self::Prs3 | Self::Rps3 => 3,
            Self::Ups6 => 6,
            Self::Custom => 0,
        }
    }

    /// The pose inputs of a grid or trajectory, in row-major order: `z, psi, theta`
    /// for the 3-limb kinds (the rest are parasitic motions), all six for the 6-UPS.
    pub fn inputs(self) -> &'static [&'static str] {
        match self {
            Self::Prs3 | Self::Rps3 => &["z", "psi", "theta"],
            Self::Ups6 | Self::Custom => &["x", "y", "z", "phi", "psi", "theta"],
        }
    }

    /// The keys of `[clearance]` this kind takes (a custom mechanism's are its joint
    /// groups, checked against its description).
    pub fn clearance_keys(self) -> &'static [&'static str] {
        match self {
            Self::Prs3 | Self::Rps3 => &["s_radial", "r_radial", "r_axial", "r_angular"],
            Self::Ups6 => &["s_radial", "u_radial", "u_angular"],
            Self::Custom => &[],
        }
    }

    /// The keys a section takes for this kind: `[mechanism]`, `[mass]`,
    /// `[clearance]`, or the inputs of `[grid]` and `[trajectory]`.
    pub fn section_keys(self, section: &str) -> &'static [&'static str] {
        match section {
            "mass" => self.mass_keys(),
            "clearance" => self.clearance_keys(),
            "grid" => self.inputs(),
            "trajectory" => match self {
                Self::Prs3 | Self::Rps3 => &["time", "z", "psi", "theta"],
                Self::Ups6 | Self::Custom => &["time", "x", "y", "z", "phi", "psi", "theta"],
            },
            _ => self.mechanism_keys(),
        }
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
            Self::Ups6 => &[
                "kind",
                "base_radius",
                "base_angles_deg",
                "platform_radius",
                "platform_angles_deg",
                "gravity",
                "cylinder_length",
                "piston_length",
                "min_length",
                "max_length",
                "base_points",
                "platform_points",
                "u_axes",
            ],
            Self::Custom => &["kind", "gravity", "inputs", "home", "limb"],
        }
    }

    /// The keys of `[mass]` this kind takes.
    pub fn mass_keys(self) -> &'static [&'static str] {
        match self {
            Self::Prs3 => &["platform", "leg", "platform_inertia", "points"],
            Self::Rps3 | Self::Ups6 => &["platform", "cylinder", "piston", "platform_inertia", "points"],
            Self::Custom => &["platform", "platform_inertia", "points"],
        }
    }
}

/// 6-UPS defaults (docs/model.md §10.3): the base points' polar angles (degrees).
pub const UPS_BASE_ANGLES_DEG: [f64; 6] = [-15.0, 15.0, 105.0, 135.0, 225.0, 255.0];
/// 6-UPS defaults: the platform points' polar angles in platform axes (degrees).
pub const UPS_PLATFORM_ANGLES_DEG: [f64; 6] = [-45.0, 45.0, 75.0, 165.0, 195.0, 285.0];
/// 6-UPS default platform mass (kg); the 3-limb kinds' is 9.8.
pub const UPS_PLATFORM_MASS: f64 = 10.0;

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
    /// 6-UPS: polar angles of the base points `B_i` on the circle of `base_radius`.
    /// Default `[-15, 15, 105, 135, 225, 255]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_angles_deg: Option<Vec<f64>>,
    /// 6-UPS: the six base points `[x, y, z]` (world, m), instead of the circle.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_points: Option<Vec<[f64; 3]>>,
    /// 6-UPS: the six platform points `[x, y, z]` (platform frame, m), instead of the circle.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub platform_points: Option<Vec<[f64; 3]>>,
    /// 6-UPS: the six fixed universal-joint axes `a1_i` (world; normalised). Default
    /// horizontal, tangent to the base circle at `B_i`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub u_axes: Option<Vec<[f64; 3]>>,
    /// 3-RPS, 6-UPS: length of the cylinder, from the base joint. Default 0.8 (0.5).
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
    /// Custom: the platform coordinates the grid or trajectory gives; the others are parasitic.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inputs: Option<Vec<String>>,
    /// Custom: the platform pose `x, y, z, phi, psi, theta` at which the joints are given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub home: Option<[f64; 6]>,
    /// Custom: the limbs, each a chain of joints from the ground to the platform.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limb: Option<Vec<crate::custom::LimbSpec>>,
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
            base_angles_deg: None,
            base_points: None,
            platform_points: None,
            u_axes: None,
            cylinder_length: None,
            piston_length: None,
            min_length: None,
            max_length: None,
            inputs: None,
            home: None,
            limb: None,
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
            MechanismKind::Ups6 => 0.5,
            MechanismKind::Custom => f64::NAN,
        })
    }

    pub fn platform_radius(&self) -> f64 {
        self.platform_radius.unwrap_or(match self.kind {
            MechanismKind::Prs3 => 0.36,
            MechanismKind::Rps3 => 0.2,
            MechanismKind::Ups6 => 0.3,
            MechanismKind::Custom => f64::NAN,
        })
    }

    /// 3-PRS: the leg length `L` (NaN for other kinds).
    pub fn leg_length(&self) -> f64 {
        match self.kind {
            MechanismKind::Prs3 => self.leg_length.unwrap_or(1.0),
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => f64::NAN,
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
        self.platform_angles_deg.clone().unwrap_or_else(|| match self.kind {
            MechanismKind::Ups6 => UPS_PLATFORM_ANGLES_DEG.to_vec(),
            _ => self.limb_angles_deg(),
        })
    }

    /// 6-UPS: the base points' polar angles (degrees).
    pub fn base_angles_deg(&self) -> Vec<f64> {
        self.base_angles_deg.clone().unwrap_or_else(|| UPS_BASE_ANGLES_DEG.to_vec())
    }

    pub fn cylinder_length(&self) -> f64 {
        self.cylinder_length.unwrap_or(if self.kind == MechanismKind::Ups6 { 0.5 } else { 0.8 })
    }

    pub fn piston_length(&self) -> f64 {
        self.piston_length.unwrap_or(if self.kind == MechanismKind::Ups6 { 0.5 } else { 0.8 })
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
            MechanismKind::Rps3 | MechanismKind::Ups6 => self.max_length(),
            MechanismKind::Custom => self.custom_length_scale(),
        }
    }

    /// A custom mechanism's length scale: the largest distance of a joint's centre from
    /// the home position of P (1 m if there is none).
    fn custom_length_scale(&self) -> f64 {
        let home = self.home.unwrap_or([0.0; 6]);
        let far = self
            .limb
            .iter()
            .flatten()
            .flat_map(|l| &l.joints)
            .map(|j| {
                let d = [j.at[0] - home[0], j.at[1] - home[1], j.at[2] - home[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            })
            .fold(0.0, f64::max);
        if far > 0.0 { far } else { 1.0 }
    }

    /// Writes the kind's defaults into the keys left out that follow no other key.
    pub fn fill_defaults(&mut self) {
        if self.kind == MechanismKind::Custom {
            self.home.get_or_insert([0.0; 6]);
            return;
        }
        self.base_radius = Some(self.base_radius());
        self.platform_radius = Some(self.platform_radius());
        if self.kind != MechanismKind::Ups6 {
            self.limb_angles_deg = Some(self.limb_angles_deg());
        }
        match self.kind {
            MechanismKind::Prs3 => {
                self.leg_length = Some(self.leg_length());
                self.rail_angle_deg = Some(self.rail_angle_deg());
            }
            MechanismKind::Rps3 => {
                self.cylinder_length = Some(self.cylinder_length());
                self.piston_length = Some(self.piston_length());
            }
            MechanismKind::Custom => {}
            MechanismKind::Ups6 => {
                self.cylinder_length = Some(self.cylinder_length());
                self.piston_length = Some(self.piston_length());
                self.base_angles_deg = Some(self.base_angles_deg());
                self.platform_angles_deg = Some(self.platform_angles_deg());
            }
        }
    }

    /// The value of a key whose default follows another one, for a sweep that
    /// names it while the file leaves it out.
    pub fn implied(&self, key: &str) -> Option<toml::Value> {
        let list = |v: Vec<f64>| toml::Value::Array(v.into_iter().map(toml::Value::Float).collect());
        match (self.kind, key) {
            (_, "platform_angles_deg") => Some(list(self.platform_angles_deg())),
            (MechanismKind::Rps3 | MechanismKind::Ups6, "min_length") => Some(toml::Value::Float(self.min_length())),
            (MechanismKind::Rps3 | MechanismKind::Ups6, "max_length") => Some(toml::Value::Float(self.max_length())),
            _ => None,
        }
    }
}

/// Masses and inertias (docs/model.md, "Bodies").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MassSpec {
    /// Platform mass (kg), centre of mass at P. Default 9.8 (6-UPS: 10).
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
            MechanismKind::Rps3 | MechanismKind::Ups6 | MechanismKind::Custom => 0.0,
        }
    }

    /// 3-RPS, 6-UPS: each cylinder's mass (0 for the 3-PRS).
    pub fn cylinder(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Rps3 => self.cylinder.unwrap_or(2.0),
            MechanismKind::Ups6 => self.cylinder.unwrap_or(1.5),
            MechanismKind::Prs3 | MechanismKind::Custom => 0.0,
        }
    }

    /// 3-RPS, 6-UPS: each piston's mass (0 for the 3-PRS).
    pub fn piston(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Rps3 => self.piston.unwrap_or(1.0),
            MechanismKind::Ups6 => self.piston.unwrap_or(0.75),
            MechanismKind::Prs3 | MechanismKind::Custom => 0.0,
        }
    }

    /// The mass of one limb's moving bodies (a custom mechanism's bodies are in its limbs: 0 here).
    pub fn limb(&self, kind: MechanismKind) -> f64 {
        match kind {
            MechanismKind::Prs3 => self.leg(kind),
            MechanismKind::Rps3 | MechanismKind::Ups6 => self.cylinder(kind) + self.piston(kind),
            MechanismKind::Custom => 0.0,
        }
    }

    /// Writes the kind's defaults into the masses left out.
    pub fn fill_defaults(&mut self, kind: MechanismKind) {
        match kind {
            MechanismKind::Prs3 => self.leg = Some(self.leg(kind)),
            MechanismKind::Custom => {}
            MechanismKind::Rps3 | MechanismKind::Ups6 => {
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
