//! `[mechanism] kind = "custom"`: a parallel mechanism described by its joints
//! (docs/model.md §12). Each limb is a serial chain of R, P, U and S joints from the
//! ground to the platform, given in world coordinates at the platform's `home` pose,
//! with a rigid body between each two consecutive joints; a limb may be repeated by
//! rotation about the world `z` axis.
//!
//! This module holds the description as the job file writes it ([`LimbSpec`],
//! [`JointSpec`], [`BodySpec`]), its expansion into limbs ([`Limb`]) and every check
//! that needs no linear algebra: joint names and axes, inputs against actuated joints,
//! idle freedoms, the counts of §12.3 and the clearance keys. The rank at home is
//! checked where the systems are built (clearance-solver).

use serde::{Deserialize, Serialize};

use crate::error::JobError;

/// The six platform coordinates, in the canonical (row-major) order.
pub const COORDINATES: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];

/// A joint's type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum JointType {
    /// Revolute: one rotation about `axis`.
    R,
    /// Prismatic: one translation along `axis`.
    P,
    /// Universal: a rotation about `a1` (proximal) then one about `a2` (distal).
    U,
    /// Spherical: any rotation about its centre.
    S,
}

impl JointType {
    /// The letter of job files and default names.
    pub fn letter(self) -> &'static str {
        match self {
            Self::R => "R",
            Self::P => "P",
            Self::U => "U",
            Self::S => "S",
        }
    }

    /// The components of the load the joint transmits, `k_J` of docs/model.md §12.4.
    pub fn transmitted(self, actuated: bool) -> usize {
        match (self, actuated) {
            (Self::R | Self::P, true) => 6,
            (Self::R | Self::P, false) => 5,
            (Self::U, _) => 4,
            (Self::S, _) => 3,
        }
    }

    /// The clearance groups the joint has (docs/model.md §12.5), in table order.
    pub fn groups(self, actuated: bool) -> &'static [Group] {
        use Group::*;
        match (self, actuated) {
            (Self::R, false) => &[Radial, Axial, Angular],
            (Self::R, true) => &[Radial, Axial, Angular, Backlash],
            (Self::P, false) => &[Radial, Angular],
            (Self::P, true) => &[Radial, Angular, Backlash],
            (Self::U, _) => &[Radial, Angular],
            (Self::S, _) => &[Radial],
        }
    }

    /// The rank of the type in the dominant joint's tie order (S, U, R, P).
    pub fn tie_rank(self) -> usize {
        match self {
            Self::S => 0,
            Self::U => 1,
            Self::R => 2,
            Self::P => 3,
        }
    }
}

/// A clearance group of a joint (docs/model.md §12.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Group {
    Radial,
    Axial,
    Angular,
    Backlash,
}

impl Group {
    pub fn name(self) -> &'static str {
        match self {
            Self::Radial => "radial",
            Self::Axial => "axial",
            Self::Angular => "angular",
            Self::Backlash => "backlash",
        }
    }
}

/// One joint as the job file gives it, at home, in world coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    #[serde(rename = "type")]
    pub joint: JointType,
    /// Unique within its limb; default the type letter in lower case.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The joint's centre (m).
    pub at: [f64; 3],
    /// R: the axis of rotation; P: the direction of travel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// U: `[a1, a2]`, fixed in the proximal and the distal body, perpendicular at home.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<[[f64; 3]; 2]>,
    /// R or P only: driven, hence locked in the analysis.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub actuated: bool,
    /// R or P only: bounds of the joint variable (rad or m from home).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[f64; 2]>,
}

impl JointSpec {
    /// The joint's name (its type letter in lower case when the file gives none).
    pub fn name(&self) -> String {
        self.name.clone().unwrap_or_else(|| self.joint.letter().to_lowercase())
    }
}

/// A rigid body between two consecutive joints of a limb.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// kg; default 0.
    #[serde(default)]
    pub mass: f64,
    /// Centre of mass at home (world, m); default the midpoint of its joints' centres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub com: Option<[f64; 3]>,
    /// Inertia about the centre of mass in world axes at home (kg·m²); default a
    /// slender rod along the segment joining its joints' centres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<[[f64; 3]; 3]>,
}

/// One `[[mechanism.limb]]`: a chain of joints, its bodies, and its repetition.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimbSpec {
    /// This limb and `repeat − 1` copies rotated about `z`. Default 1.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub repeat: usize,
    /// The angle between copies (degrees); default `360 / repeat`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate_deg: Option<f64>,
    pub joints: Vec<JointSpec>,
    /// `joints − 1` bodies, from the ground side; left out: massless.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<BodySpec>,
}

fn one() -> usize {
    1
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

/// A clearance magnitude: one value for every limb that has the joint, or one per such limb.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Magnitude {
    All(f64),
    PerLimb(Vec<f64>),
}

impl Magnitude {
    /// The magnitude of the `k`-th limb (from 0) among those that have the joint.
    pub fn of(&self, k: usize) -> f64 {
        match self {
            Self::All(v) => *v,
            Self::PerLimb(v) => v.get(k).copied().unwrap_or(0.0),
        }
    }

    /// The largest of its values.
    pub fn max(&self) -> f64 {
        match self {
            Self::All(v) => *v,
            Self::PerLimb(v) => v.iter().copied().fold(0.0, f64::max),
        }
    }
}

/// One limb after expansion: its joints and bodies rotated into place.
#[derive(Clone, Debug, PartialEq)]
pub struct Limb {
    /// The `[[mechanism.limb]]` entry it comes from, and which copy (from 0).
    pub entry: usize,
    pub copy: usize,
    pub joints: Vec<JointSpec>,
    /// Exactly `joints − 1`.
    pub bodies: Vec<BodySpec>,
}

/// A clearance kind of a custom mechanism: a joint name and a group (`knee_axial`).
#[derive(Clone, Debug, PartialEq)]
pub struct CustomKind {
    pub joint: String,
    pub group: Group,
    pub key: String,
}

fn rotate(v: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]]
}

/// The most limbs a mechanism may have (after repetition).
pub const MAX_LIMBS: usize = 64;

/// Expands `repeat` and fills the bodies left out. Limbs are numbered in file order,
/// each entry's copies right after it.
pub fn expand(limbs: &[LimbSpec]) -> Vec<Limb> {
    let mut out = Vec::new();
    for (entry, spec) in limbs.iter().enumerate() {
        let step = spec.rotate_deg.unwrap_or(360.0 / spec.repeat.max(1) as f64).to_radians();
        for copy in 0..spec.repeat.clamp(1, MAX_LIMBS) {
            if out.len() >= MAX_LIMBS {
                break;
            }
            let a = step * copy as f64;
            let joints = spec
                .joints
                .iter()
                .map(|j| JointSpec {
                    at: rotate(j.at, a),
                    axis: j.axis.map(|v| rotate(v, a)),
                    axes: j.axes.map(|[a1, a2]| [rotate(a1, a), rotate(a2, a)]),
                    ..j.clone()
                })
                .collect::<Vec<_>>();
            let mut bodies: Vec<BodySpec> = spec
                .bodies
                .iter()
                .map(|b| BodySpec {
                    mass: b.mass,
                    com: b.com.map(|c| rotate(c, a)),
                    inertia: b.inertia.map(|i| {
                        // R·I·Rᵀ for the rotation about z.
                        let (s, c) = a.sin_cos();
                        let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
                        let mut out = [[0.0; 3]; 3];
                        for (p, row) in out.iter_mut().enumerate() {
                            for (q, v) in row.iter_mut().enumerate() {
                                *v = (0..3)
                                    .flat_map(|k| (0..3).map(move |l| (k, l)))
                                    .map(|(k, l)| r[p][k] * i[k][l] * r[q][l])
                                    .sum();
                            }
                        }
                        out
                    }),
                })
                .collect();
            bodies.resize(joints.len().saturating_sub(1), BodySpec::default());
            out.push(Limb { entry, copy, joints, bodies });
        }
    }
    out
}

/// The custom description's parts of `[mechanism]`, after expansion.
#[derive(Clone, Debug, PartialEq)]
pub struct Description {
    /// Indices into [`COORDINATES`] of the inputs, in canonical order.
    pub inputs: Vec<usize>,
    pub home: [f64; 6],
    pub limbs: Vec<Limb>,
    /// The clearance kinds of the job, in the canonical order of docs/model.md §12.7
    /// (joint type S, U, R, P; place in the limb; group), with their magnitudes.
    pub kinds: Vec<(CustomKind, Magnitude)>,
}

/// `limb 4` or `mechanism.limb.1 (limbs 4 to 6)`-style names for messages.
fn limb_label(limbs: &[Limb], l: usize) -> String {
    let entry = limbs[l].entry;
    let copies: Vec<usize> = limbs.iter().enumerate().filter(|(_, x)| x.entry == entry).map(|(i, _)| i + 1).collect();
    if copies.len() == 1 {
        format!("limb {} (mechanism.limb.{entry})", l + 1)
    } else {
        format!("limb {} (mechanism.limb.{entry}, copy {} of {})", l + 1, limbs[l].copy + 1, copies.len())
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn finite3(file: &str, key: &str, v: &[f64]) -> Result<(), JobError> {
    for (i, x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(JobError::new(file, format!("{key}.{i}"), format!("must be a finite number, got {x:?}")));
        }
    }
    Ok(())
}

/// Checks a custom description (docs/model.md §12.1, §12.3) and the clearance keys
/// against its joints; returns it expanded.
pub fn describe(
    file: &str,
    inputs: &Option<Vec<String>>,
    home: &Option<[f64; 6]>,
    limbs: &Option<Vec<LimbSpec>>,
    clearance: &[(String, Magnitude)],
) -> Result<Description, JobError> {
    let err = |key: &str, reason: String| Err(JobError::new(file, key, reason));
    let Some(specs) = limbs.as_ref().filter(|l| !l.is_empty()) else {
        return err("mechanism.limb", "a custom mechanism needs at least one [[mechanism.limb]]".into());
    };
    let Some(inputs) = inputs else {
        return err(
            "mechanism.inputs",
            "list the platform coordinates the grid or trajectory gives, e.g. [\"z\", \"psi\", \"theta\"]".into(),
        );
    };
    let mut idx = Vec::new();
    for (i, name) in inputs.iter().enumerate() {
        let Some(k) = COORDINATES.iter().position(|c| c == name) else {
            return err(
                &format!("mechanism.inputs.{i}"),
                format!("{name:?} is not a platform coordinate; expected one of x, y, z, phi, psi, theta"),
            );
        };
        if idx.contains(&k) {
            return err(&format!("mechanism.inputs.{i}"), format!("{name:?} is listed twice"));
        }
        idx.push(k);
    }
    idx.sort_unstable();
    let home = home.unwrap_or([0.0; 6]);
    finite3(file, "mechanism.home", &home)?;
    for (e, spec) in specs.iter().enumerate() {
        let key = format!("mechanism.limb.{e}");
        if spec.repeat == 0 || spec.repeat > MAX_LIMBS {
            return err(&format!("{key}.repeat"), format!("must be between 1 and {MAX_LIMBS}, got {}", spec.repeat));
        }
        if let Some(r) = spec.rotate_deg
            && !r.is_finite()
        {
            return err(&format!("{key}.rotate_deg"), format!("must be a finite angle in degrees, got {r:?}"));
        }
        if spec.joints.is_empty() {
            return err(&format!("{key}.joints"), "a limb needs at least one joint".into());
        }
        if !spec.bodies.is_empty() && spec.bodies.len() != spec.joints.len() - 1 {
            return err(
                &format!("{key}.bodies"),
                format!(
                    "a limb of {} joints has {} bodies between them; got {}",
                    spec.joints.len(),
                    spec.joints.len() - 1,
                    spec.bodies.len()
                ),
            );
        }
        let mut names: Vec<String> = Vec::new();
        for (j, joint) in spec.joints.iter().enumerate() {
            let jk = format!("{key}.joints.{j}");
            finite3(file, &format!("{jk}.at"), &joint.at)?;
            let name = joint.name();
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return err(
                    &format!("{jk}.name"),
                    format!(
                        "{name:?}: a joint name is letters, digits and '_' (it names columns such as margin_{name}1_radial)"
                    ),
                );
            }
            if names.contains(&name) {
                return err(
                    &format!("{jk}.name"),
                    format!("two joints of this limb are named {name:?}; give them different names"),
                );
            }
            names.push(name);
            let t = joint.joint;
            match t {
                JointType::R | JointType::P => {
                    if joint.axes.is_some() {
                        return err(&format!("{jk}.axes"), format!("a {} joint takes `axis`, not `axes`", t.letter()));
                    }
                    let Some(a) = joint.axis else {
                        return err(&format!("{jk}.axis"), format!("a {} joint needs its `axis`", t.letter()));
                    };
                    finite3(file, &format!("{jk}.axis"), &a)?;
                    if norm(a) == 0.0 {
                        return err(&format!("{jk}.axis"), "must be a non-zero vector".into());
                    }
                }
                JointType::U => {
                    if joint.axis.is_some() {
                        return err(&format!("{jk}.axis"), "a U joint takes `axes = [[a1], [a2]]`, not `axis`".into());
                    }
                    let Some([a1, a2]) = joint.axes else {
                        return err(&format!("{jk}.axes"), "a U joint needs `axes = [[a1], [a2]]`".into());
                    };
                    finite3(file, &format!("{jk}.axes.0"), &a1)?;
                    finite3(file, &format!("{jk}.axes.1"), &a2)?;
                    if norm(a1) == 0.0 || norm(a2) == 0.0 {
                        return err(&format!("{jk}.axes"), "both axes must be non-zero vectors".into());
                    }
                    let cos = (a1[0] * a2[0] + a1[1] * a2[1] + a1[2] * a2[2]) / (norm(a1) * norm(a2));
                    if cos.abs() > 1e-9 {
                        return err(
                            &format!("{jk}.axes"),
                            format!(
                                "a U joint's axes must be perpendicular at home; they make {:.6}°",
                                cos.clamp(-1.0, 1.0).acos().to_degrees()
                            ),
                        );
                    }
                }
                JointType::S => {
                    if joint.axis.is_some() || joint.axes.is_some() {
                        return err(&jk, "an S joint takes only its centre `at`".into());
                    }
                }
            }
            if joint.actuated && matches!(t, JointType::U | JointType::S) {
                return err(
                    &format!("{jk}.actuated"),
                    format!("only R and P joints can be actuated, not {}", t.letter()),
                );
            }
            if let Some([lo, hi]) = joint.range {
                if matches!(t, JointType::U | JointType::S) {
                    return err(
                        &format!("{jk}.range"),
                        format!("only R and P joints take a range, not {}", t.letter()),
                    );
                }
                finite3(file, &format!("{jk}.range"), &[lo, hi])?;
                if lo >= hi {
                    return err(&format!("{jk}.range"), format!("[{lo:?}, {hi:?}]: lo must be below hi"));
                }
            }
        }
        for (b, body) in spec.bodies.iter().enumerate() {
            let bk = format!("{key}.bodies.{b}");
            if !(body.mass.is_finite() && body.mass >= 0.0) {
                return err(&format!("{bk}.mass"), format!("must be zero or positive (kg), got {:?}", body.mass));
            }
            if let Some(c) = body.com {
                finite3(file, &format!("{bk}.com"), &c)?;
            }
            if let Some(i) = body.inertia {
                for (r, row) in i.iter().enumerate() {
                    finite3(file, &format!("{bk}.inertia.{r}"), row)?;
                }
                let asym = (0..3)
                    .flat_map(|p| (0..3).map(move |q| (p, q)))
                    .map(|(p, q)| (i[p][q] - i[q][p]).abs())
                    .fold(0.0, f64::max);
                let scale = (0..3).map(|p| i[p][p].abs()).fold(0.0, f64::max);
                if asym > 1e-12 * scale.max(f64::MIN_POSITIVE) || (0..3).any(|p| i[p][p] < 0.0) {
                    return err(
                        &format!("{bk}.inertia"),
                        "must be a symmetric matrix with a non-negative diagonal".into(),
                    );
                }
            }
        }
    }
    let count: usize = specs.iter().map(|s| s.repeat).sum();
    if count > MAX_LIMBS {
        return err("mechanism.limb", format!("{count} limbs: a mechanism may have at most {MAX_LIMBS}"));
    }
    let limbs = expand(specs);
    // An idle freedom (two S joints with only bodies and locked joints between them)
    // spoils the counts too, so it is named first.
    for (l, limb) in limbs.iter().enumerate() {
        let s: Vec<usize> =
            limb.joints.iter().enumerate().filter(|(_, j)| j.joint == JointType::S).map(|(i, _)| i).collect();
        for w in s.windows(2) {
            if limb.joints[w[0] + 1..w[1]].iter().all(|j| j.actuated) {
                return err(
                    "mechanism.limb",
                    format!(
                        "{}: the part between its S joints {:?} and {:?} can spin about the line joining their centres with the actuators locked (an idle freedom); make one of the two a U joint",
                        limb_label(&limbs, l),
                        limb.joints[w[0]].name(),
                        limb.joints[w[1]].name()
                    ),
                );
            }
        }
    }
    let bodies: usize = 1 + limbs.iter().map(|l| l.joints.len() - 1).sum::<usize>();
    let transmitted: usize = limbs.iter().flat_map(|l| &l.joints).map(|j| j.joint.transmitted(j.actuated)).sum();
    if transmitted != 6 * bodies {
        let word = if transmitted > 6 * bodies {
            "overconstrained: the reactions are not determined by rigid-body statics"
        } else {
            "not rigid: the platform can move with the actuators locked"
        };
        return err(
            "mechanism.limb",
            format!(
                "the mechanism is {word} (its joints transmit {transmitted} load components, its {bodies} moving bodies have 6·{bodies} = {} equations of equilibrium)",
                6 * bodies
            ),
        );
    }
    let actuated: usize = limbs.iter().map(|l| l.joints.iter().filter(|j| j.actuated).count()).sum();
    if actuated != idx.len() {
        return err(
            "mechanism.inputs",
            format!(
                "the mechanism has {actuated} actuated joints but {} inputs; list as many platform coordinates as there are actuators",
                idx.len()
            ),
        );
    }
    let kinds = clearance_kinds(file, &limbs, clearance)?;
    Ok(Description { inputs: idx, home, limbs, kinds })
}

/// Every joint group of the mechanism, in the canonical order of docs/model.md §12.7:
/// by joint type (S, U, R, P), then by the joint's place in its limb, then by group.
/// Joints of one name in different limbs are one kind.
pub fn all_kinds(limbs: &[Limb]) -> Vec<CustomKind> {
    let mut found: Vec<(usize, usize, Group, String)> = Vec::new();
    for limb in limbs {
        for (place, j) in limb.joints.iter().enumerate() {
            for &g in j.joint.groups(j.actuated) {
                let name = j.name();
                if !found.iter().any(|(_, _, fg, fname)| *fg == g && *fname == name) {
                    found.push((j.joint.tie_rank(), place, g, name));
                }
            }
        }
    }
    found.sort_by_key(|a| (a.0, a.1, a.2));
    found
        .into_iter()
        .map(|(_, _, group, joint)| CustomKind { key: format!("{joint}_{}", group.name()), joint, group })
        .collect()
}

/// The limbs (indices) that have a joint named `joint` with group `group`.
pub fn limbs_with(limbs: &[Limb], joint: &str, group: Group) -> Vec<usize> {
    limbs
        .iter()
        .enumerate()
        .filter(|(_, l)| l.joints.iter().any(|j| j.name() == joint && j.joint.groups(j.actuated).contains(&group)))
        .map(|(i, _)| i)
        .collect()
}

fn clearance_kinds(
    file: &str,
    limbs: &[Limb],
    clearance: &[(String, Magnitude)],
) -> Result<Vec<(CustomKind, Magnitude)>, JobError> {
    let all = all_kinds(limbs);
    for (key, m) in clearance {
        let Some(kind) = all.iter().find(|k| &k.key == key) else {
            let names: Vec<&str> = all.iter().map(|k| k.key.as_str()).collect();
            let hint = match crate::keys::suggest(key, &names) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!(
                    "its joint groups are {}",
                    names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
                ),
            };
            return Err(JobError::new(
                file,
                format!("clearance.{key}"),
                format!("names no joint group of the mechanism; {hint}"),
            ));
        };
        let unit = if matches!(kind.group, Group::Angular) { "rad" } else { "m or rad" };
        let with = limbs_with(limbs, &kind.joint, kind.group);
        let values: Vec<f64> = match m {
            Magnitude::All(v) => vec![*v],
            Magnitude::PerLimb(v) => {
                if v.len() != with.len() {
                    return Err(JobError::new(
                        file,
                        format!("clearance.{key}"),
                        format!(
                            "{} limbs have this joint: give one value, or a list of {}; got {}",
                            with.len(),
                            with.len(),
                            v.len()
                        ),
                    ));
                }
                v.clone()
            }
        };
        for (i, v) in values.iter().enumerate() {
            if !(v.is_finite() && *v >= 0.0) {
                let k = if matches!(m, Magnitude::PerLimb(_)) {
                    format!("clearance.{key}.{i}")
                } else {
                    format!("clearance.{key}")
                };
                return Err(JobError::new(file, k, format!("must be zero or positive ({unit}), got {v:?}")));
            }
        }
    }
    Ok(all
        .into_iter()
        .filter_map(|k| clearance.iter().find(|(key, _)| *key == k.key).map(|(_, m)| (k, m.clone())))
        .collect())
}

/// The total mass of the limbs' bodies (kg).
pub fn limb_mass(limbs: &[Limb]) -> f64 {
    limbs.iter().flat_map(|l| &l.bodies).map(|b| b.mass).sum()
}
