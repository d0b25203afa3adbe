//! Recognising a custom description that is a built-in 3-PRS or 6-UPS, so that that
//! kind's kernel solves its poses (docs/model.md §12.10).
//!
//! The built-in kind's numbers are read off the description (3-PRS: the limb angles
//! from the R axes, the rails' angle from the P axes, the radii and the leg length from
//! the joints at home; 6-UPS: the base points and U axes, the platform points, the legs'
//! lengths, stroke and masses), and the built-in job they make is described again with
//! [`describe`]: only if that description is the given one, every number to 1e-12 of
//! its scale (joint names aside), is the kernel used. Angles within 1e-9° of a whole
//! degree are taken as that degree, so that the 3-PRS prototype's layout keeps its
//! closed forms.

use std::sync::Arc;

use clearance_kinematics::custom::placement;
use clearance_model::custom::{JointType, LimbSpec, Magnitude};
use clearance_model::{ClearanceSpec, JobSpec, MechanismKind, MechanismSpec};
use clearance_solver::custom::{CustomModel, Preset, PrsPreset, UpsPreset};
use nalgebra::Vector3;

use crate::describe::describe;

type V3 = Vector3<f64>;

/// Numbers of a description and of its re-description agree to this, relative to the
/// larger of the two and 1.
const SAME: f64 = 1e-12;

/// An angle in degrees, snapped to a whole degree within 1e-9°.
fn snapped(radians: f64) -> f64 {
    let d = radians.to_degrees();
    if (d - d.round()).abs() <= 1e-9 { d.round() } else { d }
}

/// [`snapped`], in `[0, 360)`.
fn degrees(radians: f64) -> f64 {
    let d = snapped(radians);
    if d < 0.0 { d + 360.0 } else { d }
}

/// The built-in job whose description `job` is, if there is one: a 3-PRS's or a 6-UPS's.
fn builtin_of(job: &JobSpec) -> Option<JobSpec> {
    match job.mechanism.limb.as_ref()?.len() {
        3 => prs_of(job),
        6 => ups_of(job),
        _ => None,
    }
}

/// The built-in 6-UPS job whose description `job` is, if there is one: the base points
/// and U axes from the U joints, the platform points from the S joints at home, the
/// cylinder's length from the P joint, the piston's from its centre of mass, the
/// stroke from the P joint's range and the legs' masses from their bodies.
fn ups_of(job: &JobSpec) -> Option<JobSpec> {
    let m = &job.mechanism;
    let (home, limbs) = (m.home?, m.limb.as_ref()?);
    let types = [JointType::U, JointType::P, JointType::S];
    if limbs.iter().any(|l: &LimbSpec| {
        l.repeat != 1
            || l.rotate_deg.is_some()
            || l.bodies.len() != 2
            || l.joints.len() != 3
            || l.joints.iter().zip(types).any(|(j, t)| j.joint != t)
    }) {
        return None;
    }
    let platform = placement(&home);
    let (mut base, mut top, mut axes) = (Vec::new(), Vec::new(), Vec::new());
    let (mut cylinder_length, mut piston_length, mut stroke) = (0.0, 0.0, (0.0, 0.0));
    for l in limbs {
        let (u, p, s) = (&l.joints[0], &l.joints[1], &l.joints[2]);
        let (b, a) = (V3::from(u.at), V3::from(s.at));
        base.push(u.at);
        axes.push(u.axes?[0]);
        let local = platform.r.transpose() * (a - platform.t);
        top.push([local.x, local.y, local.z]);
        cylinder_length = (V3::from(p.at) - b).norm();
        piston_length = 2.0 * (a - V3::from(l.bodies[1].com?)).norm();
        let (q, range) = ((a - b).norm(), p.range?);
        stroke = (range[0] + q, range[1] + q);
    }
    let mut out = job.clone();
    out.sweep.clear();
    out.mechanism = MechanismSpec {
        kind: MechanismKind::Ups6,
        gravity: m.gravity,
        base_points: Some(base),
        platform_points: Some(top),
        u_axes: Some(axes),
        cylinder_length: Some(cylinder_length),
        piston_length: Some(piston_length),
        min_length: Some(stroke.0),
        max_length: Some(stroke.1),
        ..MechanismSpec::of_kind(MechanismKind::Ups6)
    };
    out.mass.cylinder = Some(limbs[0].bodies[0].mass);
    out.mass.piston = Some(limbs[0].bodies[1].mass);
    out.clearance = builtin_clearance(job, &["s_radial", "u_radial", "u_angular"], true)?;
    // Through text, so that it is checked and completed as a job file would be.
    JobSpec::from_toml_str(&out.to_toml_string(), "preset").ok()
}

/// The built-in 3-PRS job whose description `job` is, if there is one.
fn prs_of(job: &JobSpec) -> Option<JobSpec> {
    let m = &job.mechanism;
    let (home, limbs) = (m.home?, m.limb.as_ref()?);
    if limbs.len() != 3 || limbs.iter().any(|l: &LimbSpec| l.repeat != 1 || l.rotate_deg.is_some()) {
        return None;
    }
    let types = [JointType::P, JointType::R, JointType::S];
    if limbs.iter().any(|l| l.joints.len() != 3 || l.joints.iter().zip(types).any(|(j, t)| j.joint != t)) {
        return None;
    }
    let platform = placement(&home);
    let mut limb_deg = Vec::new();
    let mut platform_deg = Vec::new();
    let (mut base_radius, mut platform_radius, mut leg_length, mut rail_deg) = (0.0, 0.0, 0.0, 0.0);
    for l in limbs {
        let (p, r, s) = (&l.joints[0], &l.joints[1], &l.joints[2]);
        let y = V3::from(r.axis?).try_normalize(0.0)?;
        let d = V3::from(p.axis?).try_normalize(0.0)?;
        let alpha = (-y.x).atan2(y.y);
        let x = V3::new(alpha.cos(), alpha.sin(), 0.0);
        let beta = d.dot(&x).atan2(d.z);
        if beta.cos().abs() < 1e-6 {
            return None;
        }
        let (b, a) = (V3::from(r.at), V3::from(s.at));
        let local = platform.r.transpose() * (a - platform.t);
        limb_deg.push(degrees(alpha));
        platform_deg.push(degrees(local.y.atan2(local.x)));
        rail_deg = snapped(beta);
        base_radius = if rail_deg == 0.0 { b.x.hypot(b.y) } else { b.dot(&x) - b.z / beta.cos() * beta.sin() };
        platform_radius = local.x.hypot(local.y);
        leg_length = (a - b).norm();
    }
    let leg = limbs[0].bodies.get(1).map_or(0.0, |b| b.mass);
    let mut out = job.clone();
    out.sweep.clear();
    out.mechanism = MechanismSpec {
        kind: MechanismKind::Prs3,
        gravity: m.gravity,
        base_radius: Some(base_radius),
        platform_radius: Some(platform_radius),
        leg_length: Some(leg_length),
        rail_angle_deg: Some(rail_deg),
        platform_angles_deg: (platform_deg != limb_deg).then(|| platform_deg.clone()),
        limb_angles_deg: Some(limb_deg),
        ..MechanismSpec::of_kind(MechanismKind::Prs3)
    };
    out.mass.leg = Some(leg);
    out.clearance = builtin_clearance(job, &["s_radial", "r_radial", "r_axial", "r_angular"], false)?;
    // Through text, so that it is checked and completed as a job file would be.
    JobSpec::from_toml_str(&out.to_toml_string(), "preset").ok()
}

/// A built-in kind's `[clearance]` (`ups` for the 6-UPS's) from a description's, whose
/// kinds must be among that kind's `keys`, each one number for every limb.
fn builtin_clearance(job: &JobSpec, keys: &[&str], ups: bool) -> Option<ClearanceSpec> {
    let mut clearance = ClearanceSpec { ups, ..ClearanceSpec::default() };
    for (key, magnitude) in &job.clearance.given {
        if !matches!(magnitude, Magnitude::All(_)) || !keys.contains(&key.as_str()) {
            return None;
        }
        clearance.set(key, magnitude.clone());
    }
    Some(clearance)
}

/// Whether two descriptions' values agree, numbers to [`SAME`], joint names aside.
fn same(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap_or(f64::NAN), y.as_f64().unwrap_or(f64::NAN));
            (x - y).abs() <= SAME * x.abs().max(y.abs()).max(1.0)
        }
        (Value::Array(x), Value::Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(x, y)| same(x, y)),
        (Value::Object(x), Value::Object(y)) => {
            let keys = |o: &serde_json::Map<String, Value>| {
                let mut k: Vec<String> = o.keys().filter(|k| *k != "name").cloned().collect();
                k.sort();
                k
            };
            keys(x) == keys(y) && keys(x).iter().all(|k| same(&x[k], &y[k]))
        }
        _ => a == b,
    }
}

/// The clearance magnitudes by key.
fn magnitudes(c: &ClearanceSpec) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> =
        c.given.iter().map(|(k, m)| (k.clone(), if let Magnitude::All(v) = m { *v } else { f64::NAN })).collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The kernel for `model`, the model of `job`, where `job` describes a built-in 3-PRS.
pub(crate) fn preset_of(job: &JobSpec, model: &CustomModel) -> Option<Arc<Preset>> {
    if job.mechanism.kind != MechanismKind::Custom || job.analysis.exact {
        return None;
    }
    let builtin = builtin_of(job)?;
    let again = describe(&builtin, "preset").ok()?;
    let value = |m: &MechanismSpec| serde_json::to_value(m).ok();
    let mass = |j: &JobSpec| serde_json::to_value(&j.mass).ok();
    let equal = same(&value(&again.mechanism)?, &value(&job.mechanism)?)
        && same(&mass(&again)?, &mass(job)?)
        && magnitudes(&again.clearance) == magnitudes(&job.clearance);
    if !equal {
        return None;
    }
    let home = job.mechanism.home?;
    let preset = match builtin.mechanism.kind {
        MechanismKind::Ups6 => UpsPreset::new(model, clearance_solver::ups::UpsModel::from_job(&builtin), &home)
            .map(|p| Preset::Ups6(Box::new(p))),
        _ => {
            PrsPreset::new(model, clearance_solver::Model::from_job(&builtin), &home).map(|p| Preset::Prs3(Box::new(p)))
        }
    };
    preset.map(Arc::new)
}

/// Whether `job`'s poses are solved with a built-in kind's kernel (a custom job that
/// describes a built-in 3-PRS or 6-UPS, every variant of it), or its error.
pub fn uses_kernel(job: &JobSpec, file: &str) -> Result<bool, clearance_model::JobError> {
    if job.mechanism.kind != MechanismKind::Custom {
        return Ok(false);
    }
    for v in job.variants(file)? {
        if crate::custom::model_of(&v.job, file)?.preset.is_none() {
            return Ok(false);
        }
    }
    Ok(true)
}
