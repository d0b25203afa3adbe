//! The job file as typed options. Every table is a plain `Default + Deserialize`
//! struct with `deny_unknown_fields`; defaults are the paper's prototype.

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;

use crate::custom::Magnitude;
use crate::error::JobError;
use crate::kinds::{ClearanceKind, KINDS};
use crate::mechanism::{MassSpec, MechanismKind, MechanismSpec};

/// One job: a mechanism, its loads and clearances, what to analyse, and where.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobSpec {
    /// Defaults to the job file's stem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default)]
    pub mechanism: MechanismSpec,
    #[serde(default)]
    pub mass: MassSpec,
    #[serde(default)]
    pub load: LoadSpec,
    #[serde(default)]
    pub clearance: ClearanceSpec,
    #[serde(default)]
    pub analysis: AnalysisSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<GridSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectorySpec>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sweep: Vec<SweepSpec>,
    /// What `clearance allocate` chooses and what it costs; `run` ignores it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub allocate: Option<AllocateSpec>,
}

/// `[allocate]`: the clearance kinds `clearance allocate` chooses, the weight of each
/// in the cost `Σ w_k / c_k`, and bounds on each magnitude (m or rad). Keys name
/// `[clearance]` keys; no `kinds` means every kind the job gives a magnitude.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AllocateSpec {
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub kinds: Vec<String>,
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub weights: std::collections::BTreeMap<String, f64>,
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub min: std::collections::BTreeMap<String, f64>,
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub max: std::collections::BTreeMap<String, f64>,
}

/// External wrench on the platform.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoadSpec {
    /// Force, world frame (N).
    pub force: [f64; 3],
    /// Couple, world frame (N·m).
    pub moment: [f64; 3],
    /// Application point of the force, platform frame (m).
    pub at: [f64; 3],
}

/// Clearance magnitudes at full take-up (docs/model.md §5). 0 (the default) is rigid.
/// The 3-limb kinds take `s_radial` and the `r_*` kinds, the 6-UPS `s_radial` and the
/// `u_*` kinds (docs/model.md §10.3), a custom mechanism `<joint>_<group>` for its
/// joint groups, each a number or a list of one per limb (docs/model.md §12.5).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClearanceSpec {
    /// Spherical joints, radial (m).
    pub s_radial: f64,
    /// Revolute joints, radial (m).
    pub r_radial: f64,
    /// Revolute joints, axial (m).
    pub r_axial: f64,
    /// Revolute joints, angular (rad).
    pub r_angular: f64,
    /// 6-UPS: universal joints, radial (m).
    pub u_radial: f64,
    /// 6-UPS: universal joints, angular play about `n_i` (rad); harmless, its error is zero.
    pub u_angular: f64,
    /// Every key as the file gives it, in file order: a custom mechanism's magnitudes.
    pub given: Vec<(String, Magnitude)>,
    /// Whether the job is a 6-UPS (set by [`JobSpec::fill_defaults`]): the kinds written
    /// out for provenance are that kind's own, so that `job.toml` runs again.
    pub ups: bool,
    /// Whether the job is a custom mechanism: the keys written out are [`Self::given`].
    pub custom: bool,
}

impl<'de> Deserialize<'de> for ClearanceSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ClearanceSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a table of clearance magnitudes")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ClearanceSpec, A::Error> {
                let mut out = ClearanceSpec::default();
                while let Some(key) = map.next_key::<String>()? {
                    let value: Magnitude = map.next_value()?;
                    // A built-in kind's number into its field (not yet marked custom,
                    // `set` adds nothing to `given`: every key is pushed here).
                    out.set(&key, value.clone());
                    out.given.push((key, value));
                }
                Ok(out)
            }
        }
        d.deserialize_map(V)
    }
}

impl Serialize for ClearanceSpec {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::{SerializeMap, SerializeStruct};
        if self.custom {
            let mut m = s.serialize_map(Some(self.given.len()))?;
            for (k, v) in &self.given {
                m.serialize_entry(k, v)?;
            }
            return m.end();
        }
        let mut t = s.serialize_struct("ClearanceSpec", 4)?;
        t.serialize_field("s_radial", &self.s_radial)?;
        if self.ups {
            t.serialize_field("u_radial", &self.u_radial)?;
            t.serialize_field("u_angular", &self.u_angular)?;
        } else {
            t.serialize_field("r_radial", &self.r_radial)?;
            t.serialize_field("r_axial", &self.r_axial)?;
            t.serialize_field("r_angular", &self.r_angular)?;
        }
        t.end()
    }
}

impl ClearanceSpec {
    /// Marks the kind the magnitudes belong to. A built-in kind keeps its numbers in
    /// the named fields: of [`Self::given`] it keeps only per-limb lists, which
    /// validation refuses for it (so a job and its provenance `job.toml` are equal).
    pub fn settle(&mut self, kind: MechanismKind) {
        self.ups = kind == MechanismKind::Ups6;
        self.custom = kind == MechanismKind::Custom;
        if !self.custom {
            self.given.retain(|(_, m)| matches!(m, Magnitude::PerLimb(_)));
        }
    }

    /// The `[clearance]` keys of a job of `kind` that hold a magnitude: a custom
    /// mechanism's given keys, a built-in kind's keys with a non-zero magnitude.
    pub fn keys(&self, kind: MechanismKind) -> Vec<String> {
        if kind == MechanismKind::Custom {
            return self.given.iter().map(|(k, _)| k.clone()).collect();
        }
        kind.clearance_keys()
            .iter()
            .filter(|k| self.magnitude(k).is_some_and(|m| m != Magnitude::All(0.0)))
            .map(|k| k.to_string())
            .collect()
    }

    /// The magnitude `key` holds: a custom group's as given, a built-in kind's
    /// field (`None` for a key the job does not know).
    pub fn magnitude(&self, key: &str) -> Option<Magnitude> {
        if let Some((_, m)) = self.given.iter().find(|(k, _)| k == key) {
            return Some(m.clone());
        }
        if self.custom {
            return None;
        }
        Some(Magnitude::All(match key {
            "s_radial" => self.s_radial,
            "r_radial" => self.r_radial,
            "r_axial" => self.r_axial,
            "r_angular" => self.r_angular,
            "u_radial" => self.u_radial,
            "u_angular" => self.u_angular,
            _ => return None,
        }))
    }

    /// Sets `key`'s magnitude: a built-in kind's field (a number), or a custom
    /// group's entry of [`Self::given`] (added last if the job had none).
    pub fn set(&mut self, key: &str, value: Magnitude) {
        if let Magnitude::All(v) = value {
            match key {
                "s_radial" => self.s_radial = v,
                "r_radial" => self.r_radial = v,
                "r_axial" => self.r_axial = v,
                "r_angular" => self.r_angular = v,
                "u_radial" => self.u_radial = v,
                "u_angular" => self.u_angular = v,
                _ => {}
            }
        }
        match self.given.iter_mut().find(|(k, _)| k == key) {
            Some(entry) => entry.1 = value,
            None if self.custom => self.given.push((key.to_string(), value)),
            None => {}
        }
    }

    /// The magnitude of one kind.
    pub fn get(&self, kind: ClearanceKind) -> f64 {
        match kind {
            ClearanceKind::SRadial => self.s_radial,
            ClearanceKind::RRadial => self.r_radial,
            ClearanceKind::RAxial => self.r_axial,
            ClearanceKind::RAngular => self.r_angular,
        }
    }

    /// Magnitudes in the order of [`KINDS`].
    pub fn as_array(&self) -> [f64; 4] {
        KINDS.map(|k| self.get(k))
    }

    /// 6-UPS magnitudes in the order `s_radial, u_radial, u_angular`.
    pub fn ups_array(&self) -> [f64; 3] {
        [self.s_radial, self.u_radial, self.u_angular]
    }
}

/// Kinetostatics (no inertial terms) or dynamics (trajectories only).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    Kinetostatic,
    Dynamic,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Kinetostatic => "kinetostatic",
            Mode::Dynamic => "dynamic",
        }
    }
}

/// What to compute.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AnalysisSpec {
    /// Default `["kinetostatic"]`.
    pub modes: Vec<Mode>,
    /// Also solve the nonlinear closure (docs/model.md §7). Default false.
    pub exact: bool,
    /// Vector-load switches count only below this fraction of the weight W (docs/model.md §8).
    pub discontinuity_load_fraction: f64,
    /// A deciding load at or below this fraction of W makes the take-up indeterminate.
    pub indeterminate_load_fraction: f64,
    /// Poses whose `cond_a` or `cond_jp` exceeds this are `near_singular`.
    pub singular_cond: f64,
}

impl Default for AnalysisSpec {
    fn default() -> Self {
        Self {
            modes: vec![Mode::Kinetostatic],
            exact: false,
            discontinuity_load_fraction: 0.05,
            indeterminate_load_fraction: 1e-9,
            singular_cond: 1e8,
        }
    }
}

/// A scalar, or an inclusive range of `n` evenly spaced values.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum RangeSpec {
    Value(f64),
    Range { start: f64, stop: f64, n: u64 },
}

impl RangeSpec {
    pub fn len(&self) -> u64 {
        match *self {
            RangeSpec::Value(_) => 1,
            RangeSpec::Range { n, .. } => n,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `i`-th value: `start + (stop − start)·i/(n − 1)` (docs/conventions.md).
    pub fn value(&self, i: u64) -> f64 {
        match *self {
            RangeSpec::Value(v) => v,
            RangeSpec::Range { start, stop, n } => {
                if n <= 1 {
                    start
                } else {
                    start + (stop - start) * (i as f64) / ((n - 1) as f64)
                }
            }
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RangeTable {
    start: f64,
    stop: f64,
    n: u64,
}

impl<'de> Deserialize<'de> for RangeSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RangeSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a table { start, stop, n }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RangeSpec, E> {
                Ok(RangeSpec::Value(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RangeSpec, E> {
                Ok(RangeSpec::Value(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RangeSpec, E> {
                Ok(RangeSpec::Value(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RangeSpec, A::Error> {
                let t = RangeTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(RangeSpec::Range { start: t.start, stop: t.stop, n: t.n })
            }
        }
        d.deserialize_any(V)
    }
}

/// The workspace grid: every combination of the inputs, row-major in the order
/// `x, y, z, phi, psi, theta`. `x, y, phi` are inputs of the 6-UPS only (default 0).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<RangeSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<RangeSpec>,
    pub z: RangeSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi: Option<RangeSpec>,
    pub psi: RangeSpec,
    pub theta: RangeSpec,
}

/// A grid axis left out: one value, 0.
const ZERO_RANGE: RangeSpec = RangeSpec::Value(0.0);

impl GridSpec {
    /// The six axes `x, y, z, phi, psi, theta` (those left out are the value 0).
    pub fn axes6(&self) -> [&RangeSpec; 6] {
        [
            self.x.as_ref().unwrap_or(&ZERO_RANGE),
            self.y.as_ref().unwrap_or(&ZERO_RANGE),
            &self.z,
            self.phi.as_ref().unwrap_or(&ZERO_RANGE),
            &self.psi,
            &self.theta,
        ]
    }
}

/// One term `amplitude·sin(2π·t/period + phase)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Harmonic {
    pub amplitude: f64,
    pub period: f64,
    #[serde(default)]
    pub phase: f64,
}

/// A trajectory input: a constant, or `offset + Σ harmonics`.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum InputSpec {
    Constant(f64),
    Harmonics { offset: f64, harmonics: Vec<Harmonic> },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HarmonicTable {
    #[serde(default)]
    offset: f64,
    #[serde(default)]
    harmonics: Vec<Harmonic>,
}

impl<'de> Deserialize<'de> for InputSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = InputSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a table { offset, harmonics = [{ amplitude, period, phase }] }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<InputSpec, E> {
                Ok(InputSpec::Constant(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<InputSpec, E> {
                Ok(InputSpec::Constant(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<InputSpec, E> {
                Ok(InputSpec::Constant(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<InputSpec, A::Error> {
                let t = HarmonicTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(InputSpec::Harmonics { offset: t.offset, harmonics: t.harmonics })
            }
        }
        d.deserialize_any(V)
    }
}

impl InputSpec {
    /// Value and first two time derivatives at `t`.
    pub fn eval(&self, t: f64) -> [f64; 3] {
        match self {
            InputSpec::Constant(v) => [*v, 0.0, 0.0],
            InputSpec::Harmonics { offset, harmonics } => {
                let mut out = [*offset, 0.0, 0.0];
                for h in harmonics {
                    let w = 2.0 * std::f64::consts::PI / h.period;
                    let (s, c) = (w * t + h.phase).sin_cos();
                    out[0] += h.amplitude * s;
                    out[1] += h.amplitude * w * c;
                    out[2] -= h.amplitude * w * w * s;
                }
                out
            }
        }
    }
}

/// A trajectory `(Z(t), Ψ(t), Θ(t))` sampled at `time`; the 6-UPS also takes
/// `x(t), y(t), Φ(t)` (default 0).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    pub time: RangeSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<InputSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<InputSpec>,
    pub z: InputSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phi: Option<InputSpec>,
    pub psi: InputSpec,
    pub theta: InputSpec,
}

/// A trajectory input left out: the constant 0.
const ZERO_INPUT: InputSpec = InputSpec::Constant(0.0);

impl TrajectorySpec {
    /// The six inputs `x, y, z, phi, psi, theta` (those left out are the constant 0).
    pub fn inputs6(&self) -> [&InputSpec; 6] {
        [
            self.x.as_ref().unwrap_or(&ZERO_INPUT),
            self.y.as_ref().unwrap_or(&ZERO_INPUT),
            &self.z,
            self.phi.as_ref().unwrap_or(&ZERO_INPUT),
            &self.psi,
            &self.theta,
        ]
    }
}

/// One swept parameter: a dotted path into the job and its values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    pub param: String,
    pub values: Vec<f64>,
}

/// The samples of a validated job.
#[derive(Clone, Copy, Debug)]
pub enum SamplesSpec<'a> {
    Grid(&'a GridSpec),
    Trajectory(&'a TrajectorySpec),
}

impl JobSpec {
    /// Parses, defaults and validates a job file's text. `file` names it in errors
    /// and gives the default `name` (its stem).
    pub fn from_toml_str(text: &str, file: &str) -> Result<JobSpec, JobError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| toml_error(file, text, &e))?;
        crate::keys::check_keys(file, &table)?;
        let kind = crate::keys::kind_of(file, &table)?;
        let mut job: JobSpec = if kind == MechanismKind::Custom {
            // A custom mechanism's grid or trajectory gives only its inputs: the
            // coordinates the types require are filled with 0 (never read).
            // An input left out stays at its home value.
            let mut table = table.clone();
            let home: Vec<f64> = match table.get("mechanism").and_then(|m| m.get("home")) {
                Some(toml::Value::Array(a)) => {
                    a.iter().map(|v| v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap_or(0.0)).collect()
                }
                _ => vec![0.0; 6],
            };
            let inputs: Vec<String> = match table.get("mechanism").and_then(|m| m.get("inputs")) {
                Some(toml::Value::Array(a)) => a.iter().filter_map(|v| v.as_str().map(String::from)).collect(),
                _ => Vec::new(),
            };
            for section in ["grid", "trajectory"] {
                if let Some(toml::Value::Table(t)) = table.get_mut(section) {
                    for (k, key) in crate::custom::COORDINATES.iter().enumerate() {
                        if inputs.iter().any(|i| i == key) || ["z", "psi", "theta"].contains(key) {
                            t.entry(*key).or_insert(toml::Value::Float(home.get(k).copied().unwrap_or(0.0)));
                        }
                    }
                }
            }
            table.try_into().map_err(|e: toml::de::Error| toml_error(file, text, &e))?
        } else {
            toml::from_str(text).map_err(|e| toml_error(file, text, &e))?
        };
        // The platform's default mass is the kind's: the typed struct cannot tell a
        // 9.8 left out from one written.
        let platform_given = table.get("mass").and_then(|m| m.get("platform")).is_some();
        if job.mechanism.kind == MechanismKind::Ups6 && !platform_given {
            job.mass.platform = crate::mechanism::UPS_PLATFORM_MASS;
        }
        if job.name.is_none() {
            let stem = std::path::Path::new(file)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "job".to_string());
            job.name = Some(stem);
        }
        job.fill_defaults();
        job.validate(file)?;
        // Sweeps are checked by expanding them: each variant must be a valid job too.
        job.variants(file)?;
        Ok(job)
    }

    /// Reads and parses a job file.
    pub fn from_path(path: &std::path::Path) -> Result<JobSpec, JobError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| JobError::new(&file, "", format!("cannot read the job file: {e}")))?;
        Self::from_toml_str(&text, &file)
    }

    /// The job's name (after defaults).
    pub fn name(&self) -> &str {
        self.name.as_deref().unwrap_or("job")
    }

    /// The samples. Only valid after validation (exactly one of grid or trajectory).
    pub fn samples(&self) -> SamplesSpec<'_> {
        match (&self.grid, &self.trajectory) {
            (Some(g), _) => SamplesSpec::Grid(g),
            (None, Some(t)) => SamplesSpec::Trajectory(t),
            (None, None) => panic!("job has neither [grid] nor [trajectory]; validate it first"),
        }
    }

    /// Number of samples per (variant, mode); `u64::MAX` if that overflows
    /// (validation refuses it).
    pub fn sample_count(&self) -> u64 {
        match self.samples() {
            SamplesSpec::Grid(g) => g.axes6().iter().fold(1u64, |n, r| n.saturating_mul(r.len())),
            SamplesSpec::Trajectory(t) => t.time.len(),
        }
    }

    /// Writes the mechanism kind's defaults into the keys the file left out (see
    /// [`MechanismSpec::fill_defaults`]); the job means the same before and after.
    pub fn fill_defaults(&mut self) {
        self.mechanism.fill_defaults();
        self.mass.fill_defaults(self.mechanism.kind);
        let ups = self.mechanism.kind == MechanismKind::Ups6;
        self.clearance.ups = ups;
        self.clearance.settle(self.mechanism.kind);
        if ups {
            // Written out, so that a sweep can name every input.
            if let Some(g) = &mut self.grid {
                for r in [&mut g.x, &mut g.y, &mut g.phi] {
                    r.get_or_insert(ZERO_RANGE);
                }
            }
            if let Some(t) = &mut self.trajectory {
                for i in [&mut t.x, &mut t.y, &mut t.phi] {
                    i.get_or_insert(ZERO_INPUT);
                }
            }
        }
    }

    /// Total moving mass: platform, point masses and every limb's bodies (kg).
    pub fn total_mass(&self) -> f64 {
        let kind = self.mechanism.kind;
        let limbs = match kind {
            MechanismKind::Custom => {
                crate::custom::limb_mass(&crate::custom::expand(self.mechanism.limb.as_deref().unwrap_or(&[])))
            }
            _ => kind.limbs() as f64 * self.mass.limb(kind),
        };
        self.mass.platform + self.mass.points.iter().map(|p| p.mass).sum::<f64>() + limbs
    }

    /// A custom mechanism's description, expanded and checked (docs/model.md §12);
    /// `None` for the built-in kinds.
    pub fn description(&self, file: &str) -> Option<Result<crate::custom::Description, JobError>> {
        let m = &self.mechanism;
        (m.kind == MechanismKind::Custom)
            .then(|| crate::custom::describe(file, &m.inputs, &m.home, &m.limb, &self.clearance.given))
    }

    /// `W = m_total·|g|`, the natural load scale of docs/model.md §8 (N).
    pub fn weight(&self) -> f64 {
        let g = self.mechanism.gravity;
        self.total_mass() * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
    }

    /// Serialises the job (after defaults) as TOML, for provenance.
    pub fn to_toml_string(&self) -> String {
        let mut table = toml::Table::try_from(self).expect("a job always serialises");
        if self.mechanism.kind == MechanismKind::Custom {
            // Only the inputs: the other coordinates are parasitic.
            let inputs = self.mechanism.inputs.clone().unwrap_or_default();
            for section in ["grid", "trajectory"] {
                if let Some(toml::Value::Table(t)) = table.get_mut(section) {
                    t.retain(|k, _| k == "time" || inputs.iter().any(|i| i == k));
                }
            }
        }
        toml::to_string(&table).expect("a job always serialises")
    }

    /// Checks every value against its physical range. Errors name the dotted key.
    pub fn validate(&self, file: &str) -> Result<(), JobError> {
        let err = |key: &str, reason: String| Err(JobError::new(file, key, reason));
        self.validate_mechanism(file)?;
        let ms = &self.mass;
        for (key, v) in [
            ("mass.platform", Some(ms.platform)),
            ("mass.leg", ms.leg),
            ("mass.cylinder", ms.cylinder),
            ("mass.piston", ms.piston),
        ] {
            if let Some(v) = v {
                non_negative(file, key, v, "kg")?;
            }
        }
        if let Some(inertia) = ms.platform_inertia {
            for (i, v) in inertia.iter().enumerate() {
                non_negative(file, &format!("mass.platform_inertia.{i}"), *v, "kg·m²")?;
            }
        }
        for (i, p) in ms.points.iter().enumerate() {
            non_negative(file, &format!("mass.points.{i}.mass"), p.mass, "kg")?;
            for (k, v) in p.at.iter().enumerate() {
                finite(file, &format!("mass.points.{i}.at.{k}"), *v)?;
            }
        }
        for (name, arr) in [("force", self.load.force), ("moment", self.load.moment), ("at", self.load.at)] {
            for (k, v) in arr.iter().enumerate() {
                finite(file, &format!("load.{name}.{k}"), *v)?;
            }
        }
        if let Some(d) = self.description(file) {
            d?;
        } else if let Some((key, _)) = self.clearance.given.iter().find(|(_, m)| matches!(m, Magnitude::PerLimb(_))) {
            return err(
                &format!("clearance.{key}"),
                "must be a number: one value per limb is for custom mechanisms (kind = \"custom\")".into(),
            );
        }
        for kind in KINDS {
            let unit = if kind == ClearanceKind::RAngular { "rad" } else { "m" };
            non_negative(file, &format!("clearance.{}", kind.name()), self.clearance.get(kind), unit)?;
        }
        non_negative(file, "clearance.u_radial", self.clearance.u_radial, "m")?;
        non_negative(file, "clearance.u_angular", self.clearance.u_angular, "rad")?;
        let a = &self.analysis;
        if a.modes.is_empty() {
            return err("analysis.modes", "must list at least one of \"kinetostatic\", \"dynamic\"".into());
        }
        for (i, mode) in a.modes.iter().enumerate() {
            if a.modes[..i].contains(mode) {
                return err(&format!("analysis.modes.{i}"), format!("\"{}\" is listed twice", mode.name()));
            }
        }
        for (key, v) in [
            ("analysis.discontinuity_load_fraction", a.discontinuity_load_fraction),
            ("analysis.indeterminate_load_fraction", a.indeterminate_load_fraction),
            ("analysis.singular_cond", a.singular_cond),
        ] {
            finite(file, key, v)?;
            if v <= 0.0 {
                return err(key, format!("must be positive, got {v:?}"));
            }
        }
        match (&self.grid, &self.trajectory) {
            (Some(_), Some(_)) => {
                return err("", "has both [grid] and [trajectory]; a job samples exactly one of them".into());
            }
            (None, None) => {
                return err("", "has neither [grid] nor [trajectory]; add one to say which poses to analyse".into());
            }
            (Some(g), None) => {
                if a.modes.contains(&Mode::Dynamic) {
                    return err(
                        "analysis.modes",
                        "\"dynamic\" needs a [trajectory] (a grid has no velocities); use \"kinetostatic\"".into(),
                    );
                }
                for (name, r) in ["x", "y", "z", "phi", "psi", "theta"].into_iter().zip(g.axes6()) {
                    range(file, &format!("grid.{name}"), r)?;
                }
            }
            (None, Some(t)) => {
                range(file, "trajectory.time", &t.time)?;
                let t_max = match t.time {
                    RangeSpec::Value(v) => v.abs(),
                    RangeSpec::Range { start, stop, .. } => start.abs().max(stop.abs()),
                };
                for (name, input) in ["x", "y", "z", "phi", "psi", "theta"].into_iter().zip(t.inputs6()) {
                    let key = &format!("trajectory.{name}");
                    let key = key.as_str();
                    match input {
                        InputSpec::Constant(v) => finite(file, key, *v)?,
                        InputSpec::Harmonics { offset, harmonics } => {
                            finite(file, &format!("{key}.offset"), *offset)?;
                            // Bounds of |value|, |rate| and |acceleration| over the time range.
                            let mut bound = [offset.abs(), 0.0, 0.0];
                            for (i, h) in harmonics.iter().enumerate() {
                                let k = format!("{key}.harmonics.{i}");
                                finite(file, &format!("{k}.amplitude"), h.amplitude)?;
                                finite(file, &format!("{k}.phase"), h.phase)?;
                                finite(file, &format!("{k}.period"), h.period)?;
                                if h.period <= 0.0 {
                                    return err(
                                        &format!("{k}.period"),
                                        format!("must be a positive time in s, got {:?}", h.period),
                                    );
                                }
                                let w = 2.0 * std::f64::consts::PI / h.period;
                                if !(w * t_max + h.phase.abs()).is_finite() {
                                    return err(
                                        &format!("{k}.period"),
                                        format!("{:?} s is too short: the phase 2π·t/period overflows", h.period),
                                    );
                                }
                                let a = h.amplitude.abs();
                                bound = [bound[0] + a, bound[1] + a * w, bound[2] + a * w * w];
                            }
                            if !bound.iter().all(|b| b.is_finite()) {
                                return err(
                                    &format!("{key}.harmonics"),
                                    "the input or its rates overflow: amplitudes too large for the periods".into(),
                                );
                            }
                        }
                    }
                }
            }
        }
        for (i, s) in self.sweep.iter().enumerate() {
            if s.values.is_empty() {
                return err(&format!("sweep.{i}.values"), "must list at least one value".into());
            }
            for (k, v) in s.values.iter().enumerate() {
                finite(file, &format!("sweep.{i}.values.{k}"), *v)?;
            }
        }
        if let Some(a) = &self.allocate {
            self.validate_allocate(file, a)?;
        }
        // Checked before anything is expanded or counted in u64.
        let variants = self.variant_count();
        if variants > crate::sweep::MAX_VARIANTS {
            let count = if variants == u64::MAX { "more than 2^64".to_string() } else { variants.to_string() };
            return err(
                "sweep",
                format!(
                    "{} sweeps make {count} variants, more than the {} a job may have; split the study into several jobs",
                    self.sweep.len(),
                    crate::sweep::MAX_VARIANTS
                ),
            );
        }
        let samples = match self.samples() {
            SamplesSpec::Grid(g) => g.axes6().iter().try_fold(1u64, |n, r| n.checked_mul(r.len())),
            SamplesSpec::Trajectory(t) => Some(t.time.len()),
        };
        if samples.and_then(|n| n.checked_mul(variants)).and_then(|n| n.checked_mul(a.modes.len() as u64)).is_none() {
            return err("", "has more than 2^64 poses (samples × variants × modes); it could never finish".into());
        }
        Ok(())
    }
}

impl JobSpec {
    /// `[allocate]`: kinds the mechanism has (each once), and weights and bounds of
    /// allocated kinds only, each in its range.
    fn validate_allocate(&self, file: &str, a: &AllocateSpec) -> Result<(), JobError> {
        let err = |key: &str, reason: String| Err(JobError::new(file, key, reason));
        let kind = self.mechanism.kind;
        let known: Vec<String> = if kind == MechanismKind::Custom {
            self.clearance.given.iter().map(|(k, _)| k.clone()).collect()
        } else {
            kind.clearance_keys().iter().map(|k| k.to_string()).collect()
        };
        for (i, k) in a.kinds.iter().enumerate() {
            if !known.contains(k) {
                let what = if kind == MechanismKind::Custom { "keys of [clearance]" } else { "clearance kinds" };
                return err(
                    &format!("allocate.kinds.{i}"),
                    format!("{k:?} is not one of the job's {what}: {}", known.join(", ")),
                );
            }
            if a.kinds[..i].contains(k) {
                return err(&format!("allocate.kinds.{i}"), format!("{k:?} is listed twice"));
            }
        }
        let allocated = if a.kinds.is_empty() { self.clearance.keys(kind) } else { a.kinds.clone() };
        for (table, values) in [("weights", &a.weights), ("min", &a.min), ("max", &a.max)] {
            for (k, &v) in values {
                let key = format!("allocate.{table}.{k}");
                if !allocated.contains(k) {
                    return err(&key, format!("names no allocated kind (allocated: {})", allocated.join(", ")));
                }
                let ok = match table {
                    "weights" | "max" => v.is_finite() && v > 0.0,
                    _ => v.is_finite() && v >= 0.0,
                };
                if !ok {
                    let what = if table == "weights" { "a positive cost weight" } else { "a magnitude in m or rad" };
                    let bound = if table == "min" { "non-negative" } else { "positive" };
                    return err(&key, format!("must be {bound}, {what}, got {v:?}"));
                }
            }
        }
        for (k, lo) in &a.min {
            if let Some(hi) = a.max.get(k).filter(|&&hi| hi <= *lo) {
                return err(&format!("allocate.max.{k}"), format!("{hi:?} is not above allocate.min.{k} = {lo:?}"));
            }
        }
        Ok(())
    }

    /// `[mechanism]` and the limb masses: the keys of the job's kind only, each in
    /// its physical range.
    fn validate_mechanism(&self, file: &str) -> Result<(), JobError> {
        let m = &self.mechanism;
        let kind = m.kind;
        let given = [
            ("mechanism.base_radius", m.base_radius.is_some()),
            ("mechanism.platform_radius", m.platform_radius.is_some()),
            ("mechanism.leg_length", m.leg_length.is_some()),
            ("mechanism.rail_angle_deg", m.rail_angle_deg.is_some()),
            ("mechanism.limb_angles_deg", m.limb_angles_deg.is_some()),
            ("mechanism.platform_angles_deg", m.platform_angles_deg.is_some()),
            ("mechanism.base_angles_deg", m.base_angles_deg.is_some()),
            ("mechanism.base_points", m.base_points.is_some()),
            ("mechanism.platform_points", m.platform_points.is_some()),
            ("mechanism.u_axes", m.u_axes.is_some()),
            ("mechanism.cylinder_length", m.cylinder_length.is_some()),
            ("mechanism.piston_length", m.piston_length.is_some()),
            ("mechanism.min_length", m.min_length.is_some()),
            ("mechanism.max_length", m.max_length.is_some()),
            ("mass.leg", self.mass.leg.is_some()),
            ("mass.cylinder", self.mass.cylinder.is_some()),
            ("mass.piston", self.mass.piston.is_some()),
            ("clearance.r_radial", self.clearance.r_radial != 0.0),
            ("clearance.r_axial", self.clearance.r_axial != 0.0),
            ("clearance.r_angular", self.clearance.r_angular != 0.0),
            ("clearance.u_radial", self.clearance.u_radial != 0.0),
            ("clearance.u_angular", self.clearance.u_angular != 0.0),
        ];
        let foreign: Vec<&str> = given
            .iter()
            .filter(|(key, set)| {
                let (table, name) = key.split_once('.').expect("dotted");
                // A custom mechanism's clearance keys are checked against its joints.
                let custom_clearance = kind == MechanismKind::Custom && table == "clearance";
                *set && !custom_clearance && !kind.section_keys(table).contains(&name)
            })
            .map(|(key, _)| *key)
            .collect();
        if let Some(first) = foreign.first() {
            return Err(JobError::new(file, *first, crate::keys::foreign_reason(kind, &foreign)));
        }
        if kind == MechanismKind::Custom {
            for (i, v) in m.gravity.iter().enumerate() {
                finite(file, &format!("mechanism.gravity.{i}"), *v)?;
            }
            return Ok(());
        }
        let lengths = [
            ("mechanism.base_radius", Some(m.base_radius())),
            ("mechanism.platform_radius", Some(m.platform_radius())),
            ("mechanism.leg_length", m.leg_length),
            ("mechanism.cylinder_length", m.cylinder_length),
            ("mechanism.piston_length", m.piston_length),
            ("mechanism.min_length", m.min_length),
            ("mechanism.max_length", m.max_length),
        ];
        for (key, v) in lengths {
            let Some(v) = v else { continue };
            finite(file, key, v)?;
            if v <= 0.0 {
                return Err(JobError::new(file, key, format!("must be a positive length in m, got {v:?}")));
            }
        }
        for (i, v) in m.gravity.iter().enumerate() {
            finite(file, &format!("mechanism.gravity.{i}"), *v)?;
        }
        if let Some(beta) = m.rail_angle_deg {
            finite(file, "mechanism.rail_angle_deg", beta)?;
            if !(-90.0..=90.0).contains(&beta) {
                return Err(JobError::new(
                    file,
                    "mechanism.rail_angle_deg",
                    format!(
                        "must be between -90 (horizontal, pointing inwards) and 90 (horizontal, outwards) degrees, got {beta:?}"
                    ),
                ));
            }
        }
        for (key, angles) in [
            ("mechanism.limb_angles_deg", &m.limb_angles_deg),
            ("mechanism.platform_angles_deg", &m.platform_angles_deg),
            ("mechanism.base_angles_deg", &m.base_angles_deg),
        ] {
            let Some(angles) = angles else { continue };
            if angles.len() != kind.limbs() {
                return Err(JobError::new(
                    file,
                    key,
                    format!(
                        "a {} has {} limbs: give {} angles, got {}",
                        kind.name(),
                        kind.limbs(),
                        kind.limbs(),
                        angles.len()
                    ),
                ));
            }
            for (i, v) in angles.iter().enumerate() {
                finite(file, &format!("{key}.{i}"), *v)?;
                if v.abs() > 3600.0 {
                    return Err(JobError::new(
                        file,
                        format!("{key}.{i}"),
                        format!("{v:?} degrees is more than ten turns"),
                    ));
                }
            }
            for i in 0..angles.len() {
                for k in 0..i {
                    if (angles[i] - angles[k]).rem_euclid(360.0) == 0.0 {
                        return Err(JobError::new(
                            file,
                            key,
                            format!(
                                "entries {k} and {i} are the same direction ({:?} and {:?} degrees)",
                                angles[k], angles[i]
                            ),
                        ));
                    }
                }
            }
        }
        for (key, points) in [
            ("mechanism.base_points", &m.base_points),
            ("mechanism.platform_points", &m.platform_points),
            ("mechanism.u_axes", &m.u_axes),
        ] {
            let Some(points) = points else { continue };
            if points.len() != 6 {
                return Err(JobError::new(
                    file,
                    key,
                    format!("a 6-UPS has 6 limbs: give 6 vectors [x, y, z], got {}", points.len()),
                ));
            }
            for (i, p) in points.iter().enumerate() {
                for (k, v) in p.iter().enumerate() {
                    finite(file, &format!("{key}.{i}.{k}"), *v)?;
                }
                let norm = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                if key == "mechanism.u_axes" && !(norm > 0.0 && norm.is_finite()) {
                    return Err(JobError::new(
                        file,
                        format!("{key}.{i}"),
                        "a universal joint's axis must be a non-zero vector".to_string(),
                    ));
                }
            }
        }
        if matches!(kind, MechanismKind::Rps3 | MechanismKind::Ups6) && m.min_length() >= m.max_length() {
            let key = if m.max_length.is_some() { "mechanism.max_length" } else { "mechanism.min_length" };
            return Err(JobError::new(
                file,
                key,
                format!(
                    "the stroke is empty: min_length = {:?} m is not below max_length = {:?} m",
                    m.min_length(),
                    m.max_length()
                ),
            ));
        }
        Ok(())
    }
}

fn finite(file: &str, key: &str, v: f64) -> Result<(), JobError> {
    if v.is_finite() { Ok(()) } else { Err(JobError::new(file, key, format!("must be a finite number, got {v:?}"))) }
}

fn non_negative(file: &str, key: &str, v: f64, unit: &str) -> Result<(), JobError> {
    finite(file, key, v)?;
    if v < 0.0 {
        return Err(JobError::new(file, key, format!("must be zero or positive ({unit}), got {v:?}")));
    }
    Ok(())
}

fn range(file: &str, key: &str, r: &RangeSpec) -> Result<(), JobError> {
    match *r {
        RangeSpec::Value(v) => finite(file, key, v),
        RangeSpec::Range { start, stop, n } => {
            finite(file, &format!("{key}.start"), start)?;
            finite(file, &format!("{key}.stop"), stop)?;
            if n == 0 {
                return Err(JobError::new(file, format!("{key}.n"), "must be at least 1"));
            }
            // `value` computes (stop − start)·i before dividing by n − 1 (as the NumPy
            // reference does): that product must stay finite up to i = n − 1.
            if n > 1 && !((stop - start) * (n - 1) as f64).is_finite() {
                return Err(JobError::new(
                    file,
                    key,
                    format!(
                        "start = {start:?} and stop = {stop:?} are too far apart: (stop − start)·(n − 1) overflows"
                    ),
                ));
            }
            if n > 1 && start == stop {
                return Err(JobError::new(
                    file,
                    key,
                    format!("has n = {n} but start = stop = {start:?}; give a scalar or distinct ends"),
                ));
            }
            Ok(())
        }
    }
}

/// Turns a TOML parse or type error into a one- or two-line message with the line
/// and, for a value of the wrong type, the dotted key it belongs to.
fn toml_error(file: &str, text: &str, e: &toml::de::Error) -> JobError {
    let message = e.message().trim().to_string();
    let Some(span) = e.span() else { return JobError::new(file, "", message) };
    let at = span.start.min(text.len());
    let line_no = text[..at].matches('\n').count() + 1;
    JobError::new(file, key_at(text, at).unwrap_or_default(), format!("line {line_no}: {message}"))
}

/// The dotted key whose value starts on the line of byte `at`: the last table
/// header above it and the key before `=` on that line (best effort).
fn key_at(text: &str, at: usize) -> Option<String> {
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    let (key, _) = line.split_once('=')?;
    let key = key.trim().trim_matches('"');
    let header = text[..line_start]
        .lines()
        .rev()
        .map(str::trim)
        .find(|l| l.starts_with('['))
        .map(|l| l.trim_matches(|c| c == '[' || c == ']').trim().to_string());
    Some(match header {
        Some(h) if !h.is_empty() => format!("{h}.{key}"),
        _ => key.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::JobSpec;

    fn refuse(text: &str) -> (String, String) {
        let e = JobSpec::from_toml_str(text, "j.toml").unwrap_err();
        (e.key, e.reason)
    }

    #[test]
    fn counts_that_overflow_are_refused() {
        let n = "{ start = 0, stop = 1, n = 4294967296 }";
        let (k, r) = refuse(&format!("[grid]\nz = {n}\npsi = {n}\ntheta = 0\n"));
        assert_eq!(k, "");
        assert!(r.contains("2^64 poses"), "{r}");
    }

    #[test]
    fn inputs_that_overflow_are_refused() {
        let (k, _) = refuse("[grid]\nz = { start = -1e308, stop = 1e308, n = 3 }\npsi = 0\ntheta = 0\n");
        assert_eq!(k, "grid.z");
        // Found by the fuzzer: a finite span whose last value overflowed.
        let (k, _) = refuse("[grid]\nz = { start = -0, stop = 1e308, n = 3 }\npsi = 0\ntheta = 0\n");
        assert_eq!(k, "grid.z");
        let trajectory = "[trajectory]\ntime = { start = 0, stop = 1, n = 3 }\nz = 2\npsi = 0\n";
        let (k, _) =
            refuse(&format!("{trajectory}theta = {{ harmonics = [ {{ amplitude = 1, period = 5e-324 }} ] }}\n"));
        assert_eq!(k, "trajectory.theta.harmonics.0.period");
        let (k, _) =
            refuse(&format!("{trajectory}theta = {{ harmonics = [ {{ amplitude = 1e300, period = 1e-300 }} ] }}\n"));
        assert_eq!(k, "trajectory.theta.harmonics");
    }
}
