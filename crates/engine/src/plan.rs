//! What a job will compute, before computing it (`clearance check`).

use clearance_model::{JobSpec, MechanismKind, MechanismSpec, PROTOTYPE_LIMB_ANGLES_DEG, SamplesSpec};
use clearance_parquet::{ColumnSet, PoseSchema, UpsSchema};
use clearance_solver::custom::CustomModel;
use serde::Serialize;

use crate::error::EngineError;

/// A job's plan: variants, samples, rows and the size of its output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plan {
    /// The job's name.
    pub name: String,
    /// One line on the robot: its kind and what sets its layout apart.
    pub mechanism: String,
    pub samples: Samples,
    /// Samples of one (variant, mode).
    pub sample_count: u64,
    pub modes: Vec<&'static str>,
    pub variants: Vec<PlannedVariant>,
    /// Rows of `poses`: samples × variants × modes.
    pub rows: u64,
    /// Per column set, its columns and the most its poses take before compression.
    pub columns: Vec<ColumnSize>,
}

/// The samples of a job.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Samples {
    /// Values of z, psi and theta; the grid is their product, row-major.
    Grid {
        z: u64,
        psi: u64,
        theta: u64,
    },
    Trajectory {
        times: u64,
    },
    /// A 6-UPS grid: values of each of its six inputs, row-major in this order.
    Grid6 {
        x: u64,
        y: u64,
        z: u64,
        phi: u64,
        psi: u64,
        theta: u64,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlannedVariant {
    pub index: u64,
    /// The swept values, by dotted path (empty: the job as written).
    pub params: Vec<(String, f64)>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ColumnSize {
    pub set: &'static str,
    pub columns: usize,
    /// 8 bytes a value before compression (the default zstd makes it about 30 % less).
    pub bytes: u64,
    /// The same with `--precision single`: 4 bytes a value of the error, envelope and
    /// margin columns.
    pub bytes_single: u64,
}

/// The plan of `job` (read from `file`, named in messages); validates every variant.
pub fn plan(job: &JobSpec, file: &str) -> Result<Plan, EngineError> {
    let variants = job.variants(file)?;
    let sample_count = job.sample_count();
    let modes: Vec<&'static str> = job.analysis.modes.iter().map(|m| m.name()).collect();
    let ups = job.mechanism.kind == MechanismKind::Ups6;
    let custom = job.mechanism.kind == MechanismKind::Custom;
    // A custom description is checked whole (its rank at home too) for every variant
    // (whether the 3-PRS kernel solves it is the run's business, not the plan's).
    let models = if custom {
        variants.iter().map(|v| CustomModel::from_job(&v.job, file)).collect::<Result<Vec<_>, _>>()?
    } else {
        Vec::new()
    };
    let samples = match job.samples() {
        SamplesSpec::Grid(g) if ups || custom => {
            let [x, y, z, phi, psi, theta] = g.axes6().map(|r| r.len());
            Samples::Grid6 { x, y, z, phi, psi, theta }
        }
        SamplesSpec::Grid(g) => Samples::Grid { z: g.z.len(), psi: g.psi.len(), theta: g.theta.len() },
        SamplesSpec::Trajectory(t) => Samples::Trajectory { times: t.time.len() },
    };
    let rows = sample_count * variants.len() as u64 * modes.len() as u64;
    let columns = [ColumnSet::Minimal, ColumnSet::Standard, ColumnSet::Full]
        .into_iter()
        .map(|set| {
            let names: Vec<String> = if let Some(model) = models.first() {
                let schema = clearance_parquet::CustomSchema::new(model, set, job.analysis.exact).schema();
                schema.fields().iter().map(|f| f.name().clone()).collect()
            } else if ups {
                UpsSchema::new(set, job.analysis.exact).names().map(str::to_string).collect()
            } else {
                PoseSchema::new(set, job.analysis.exact).names().map(str::to_string).collect()
            };
            let columns = names.len();
            let single = names.iter().filter(|n| clearance_parquet::stored_single(n)).count() as u64;
            let (bytes, bytes_single) = (rows * columns as u64 * 8, rows * (columns as u64 * 8 - single * 4));
            ColumnSize { set: set.name(), columns, bytes, bytes_single }
        })
        .collect();
    Ok(Plan {
        name: job.name().to_string(),
        mechanism: describe(&job.mechanism),
        samples,
        sample_count,
        modes,
        variants: variants.into_iter().map(|v| PlannedVariant { index: v.index, params: v.params }).collect(),
        rows,
        columns,
    })
}

fn describe(m: &MechanismSpec) -> String {
    let mut out = m.kind.name().to_string();
    if m.kind == MechanismKind::Custom {
        let limbs = clearance_model::custom::expand(m.limb.as_deref().unwrap_or(&[]));
        let chains: Vec<String> = limbs
            .iter()
            .map(|l| {
                l.joints.iter().map(|j| format!("{}{}", j.joint.letter(), if j.actuated { "*" } else { "" })).collect()
            })
            .collect();
        out.push_str(&format!(
            ", {} limbs ({}), inputs {}",
            limbs.len(),
            chains.join(", "),
            m.inputs.as_deref().unwrap_or(&[]).join(", ")
        ));
        return out;
    }
    if m.kind == MechanismKind::Ups6 {
        let base = if m.base_points.is_some() {
            "base points as given".to_string()
        } else {
            format!("base radius {} m at {:?}°", m.base_radius(), m.base_angles_deg())
        };
        let platform = if m.platform_points.is_some() {
            "platform points as given".to_string()
        } else {
            format!("platform radius {} m at {:?}°", m.platform_radius(), m.platform_angles_deg())
        };
        let axes = if m.u_axes.is_some() { ", U axes as given" } else { "" };
        out.push_str(&format!(", {base}, {platform}{axes}, leg stroke {} to {} m", m.min_length(), m.max_length()));
        return out;
    }
    if m.kind == MechanismKind::Prs3 {
        out.push_str(&format!(", rails at {}° from vertical", m.rail_angle_deg()));
    }
    let (limbs, platform) = (m.limb_angles_deg(), m.platform_angles_deg());
    if limbs != PROTOTYPE_LIMB_ANGLES_DEG || platform != limbs {
        out.push_str(&format!(", limbs at {limbs:?}°, platform joints at {platform:?}° (parasitic motions by Newton)"));
    }
    if m.kind == MechanismKind::Rps3 {
        out.push_str(&format!(", leg stroke {} to {} m", m.min_length(), m.max_length()));
    }
    out
}
