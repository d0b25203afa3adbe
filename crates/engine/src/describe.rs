//! `clearance describe`: any job as a custom description (docs/model.md §12.9). The
//! built-in kinds become limbs of joints at a home pose, with their bodies, and the
//! same masses, loads, clearances, analysis and samples; the description runs as a
//! custom job and gives the built-in kind's values (every column but `q`, which a
//! custom run measures from home).

use clearance_kinematics::ups::{UpsGeometry, ups_inverse_kinematics};
use clearance_kinematics::{Geometry, inverse_kinematics};
use clearance_model::custom::{BodySpec, JointSpec, JointType, LimbSpec};
use clearance_model::{JobError, JobSpec, MechanismKind, MechanismSpec, SamplesSpec};
use nalgebra::Vector3;

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

fn joint(joint: JointType, name: &str, at: &Vector3<f64>) -> JointSpec {
    JointSpec { joint, name: Some(name.into()), at: arr(at), axis: None, axes: None, actuated: false, range: None }
}

/// A slender rod's inertia (world axes) of `mass` and `length` along `e`.
fn rod(mass: f64, length: f64, e: &Vector3<f64>) -> [[f64; 3]; 3] {
    let m = (nalgebra::Matrix3::identity() - e * e.transpose()) * (mass * length * length / 12.0);
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// The home inputs of a built-in job: its first sample.
fn first_sample(job: &JobSpec) -> [f64; 6] {
    match job.samples() {
        SamplesSpec::Grid(g) => g.axes6().map(|r| r.value(0)),
        SamplesSpec::Trajectory(t) => {
            let t0 = t.time.value(0);
            t.inputs6().map(|i| i.eval(t0)[0])
        }
    }
}

/// `job` as a custom description. `file` names it in errors.
pub fn describe(job: &JobSpec, file: &str) -> Result<JobSpec, JobError> {
    let kind = job.mechanism.kind;
    if kind == MechanismKind::Custom {
        return Ok(job.clone());
    }
    for (i, s) in job.sweep.iter().enumerate() {
        let movable = s.param.starts_with("mass.platform")
            || s.param.starts_with("mass.points")
            || s.param.starts_with("load.")
            || s.param.starts_with("clearance.")
            || s.param.starts_with("analysis.")
            || s.param.starts_with("grid.")
            || s.param.starts_with("trajectory.")
            || s.param.starts_with("mechanism.gravity");
        if !movable {
            return Err(JobError::new(
                file,
                format!("sweep.{i}.param"),
                format!(
                    "\"{}\" sweeps the built-in kind's geometry or limb masses, which a description writes out as joints and bodies: describe one variant at a time",
                    s.param
                ),
            ));
        }
    }
    let m = &job.mechanism;
    let first = first_sample(job);
    let (inputs, home, limbs, platform_radius): (Vec<&str>, [f64; 6], Vec<LimbSpec>, f64) = match kind {
        MechanismKind::Prs3 | MechanismKind::Rps3 => {
            let geom = Geometry::from_spec(m);
            let scale = m.length_scale();
            let candidates = [first[2], scale, 0.9 * scale, 0.7 * scale, 1.1 * scale, 0.5 * scale];
            let pose =
                candidates.iter().find_map(|&z| inverse_kinematics(&geom, z, 0.0, 0.0).ok()).ok_or_else(|| {
                    JobError::new(
                        file,
                        "mechanism",
                        "no home pose found (z at psi = theta = 0) to describe the mechanism at",
                    )
                })?;
            let home = [pose.x, pose.y, pose.z, pose.phi, 0.0, 0.0];
            let mut limbs = Vec::new();
            for j in 0..3 {
                let (a, b, e) = (pose.a[j], pose.b[j], pose.e[j]);
                let y = geom.y[j];
                let mut r = joint(JointType::R, "r", &b);
                r.axis = Some(arr(&y));
                let s = joint(JointType::S, "s", &a);
                if kind == MechanismKind::Prs3 {
                    let mut p = joint(JointType::P, "p", &b);
                    p.axis = Some(arr(&geom.rail(j)));
                    p.actuated = true;
                    let leg = job.mass.leg(kind);
                    limbs.push(LimbSpec {
                        repeat: 1,
                        rotate_deg: None,
                        joints: vec![p, r, s],
                        bodies: vec![BodySpec::default(), BodySpec { mass: leg, com: None, inertia: None }],
                    });
                } else {
                    let (lc, lp) = (m.cylinder_length(), m.piston_length());
                    let mut p = joint(JointType::P, "p", &(b + e * lc));
                    p.axis = Some(arr(&e));
                    p.actuated = true;
                    p.range = Some([m.min_length() - pose.q[j], m.max_length() - pose.q[j]]);
                    let (mc, mp) = (job.mass.cylinder(kind), job.mass.piston(kind));
                    limbs.push(LimbSpec {
                        repeat: 1,
                        rotate_deg: None,
                        joints: vec![r, p, s],
                        bodies: vec![
                            BodySpec {
                                mass: mc,
                                com: Some(arr(&(b + e * (lc / 2.0)))),
                                inertia: Some(rod(mc, lc, &e)),
                            },
                            BodySpec {
                                mass: mp,
                                com: Some(arr(&(a - e * (lp / 2.0)))),
                                inertia: Some(rod(mp, lp, &e)),
                            },
                        ],
                    });
                }
            }
            (vec!["z", "psi", "theta"], home, limbs, m.platform_radius())
        }
        MechanismKind::Ups6 => {
            let model = clearance_solver::ups::UpsModel::from_job(job);
            let geom: &UpsGeometry = &model.geometry;
            let pose = ups_inverse_kinematics(geom, first).map_err(|_| {
                JobError::new(file, "grid", "the first sample is not reachable: it is the description's home pose")
            })?;
            let (lc, lp) = (geom.cylinder_length, geom.piston_length);
            let (mc, mp) = (job.mass.cylinder(kind), job.mass.piston(kind));
            let mut limbs = Vec::new();
            for i in 0..6 {
                let (a, b, e) = (pose.a[i], pose.b[i], pose.e[i]);
                let mut u = joint(JointType::U, "u", &b);
                u.axes = Some([arr(&pose.a1[i]), arr(&pose.a2[i])]);
                let mut p = joint(JointType::P, "p", &(b + e * lc));
                p.axis = Some(arr(&e));
                p.actuated = true;
                p.range = Some([geom.stroke.0 - pose.q[i], geom.stroke.1 - pose.q[i]]);
                let s = joint(JointType::S, "s", &a);
                limbs.push(LimbSpec {
                    repeat: 1,
                    rotate_deg: None,
                    joints: vec![u, p, s],
                    bodies: vec![
                        BodySpec { mass: mc, com: Some(arr(&(b + e * (lc / 2.0)))), inertia: Some(rod(mc, lc, &e)) },
                        BodySpec { mass: mp, com: Some(arr(&(a - e * (lp / 2.0)))), inertia: Some(rod(mp, lp, &e)) },
                    ],
                });
            }
            (vec!["x", "y", "z", "phi", "psi", "theta"], first, limbs, geom.platform_radius)
        }
        MechanismKind::Custom => unreachable!("returned above"),
    };
    let mut out = job.clone();
    out.mechanism = MechanismSpec {
        kind: MechanismKind::Custom,
        gravity: m.gravity,
        inputs: Some(inputs.iter().map(|s| s.to_string()).collect()),
        home: Some(home),
        limb: Some(limbs),
        ..MechanismSpec::of_kind(MechanismKind::Custom)
    };
    let mp = job.mass.platform;
    out.mass = clearance_model::MassSpec {
        platform: mp,
        leg: None,
        cylinder: None,
        piston: None,
        platform_inertia: Some(job.mass.platform_inertia.unwrap_or([
            mp * platform_radius * platform_radius / 4.0,
            mp * platform_radius * platform_radius / 4.0,
            mp * platform_radius * platform_radius / 2.0,
        ])),
        points: job.mass.points.clone(),
    };
    let c = &job.clearance;
    let keys: Vec<(&str, f64)> = if kind == MechanismKind::Ups6 {
        vec![("s_radial", c.s_radial), ("u_radial", c.u_radial), ("u_angular", c.u_angular)]
    } else {
        vec![("s_radial", c.s_radial), ("r_radial", c.r_radial), ("r_axial", c.r_axial), ("r_angular", c.r_angular)]
    };
    out.clearance = clearance_model::ClearanceSpec {
        given: keys.into_iter().map(|(k, v)| (k.to_string(), clearance_model::custom::Magnitude::All(v))).collect(),
        custom: true,
        ..Default::default()
    };
    // Through text, so that the description is checked as a job file would be.
    JobSpec::from_toml_str(&out.to_toml_string(), file)
}
