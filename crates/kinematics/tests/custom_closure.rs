//! The kinematics of a mechanism described by its joints (docs/model.md §12.2)
//! against the built-in 3-PRS's closed forms, against its own closure, and its rates
//! against finite differences of the configuration; a posture built from the closure's
//! last Newton iteration against the posture crossed afresh.

use clearance_kinematics::custom::{
    CustomGeometry, CustomPosture, custom_posture, custom_posture_near, placement, posture_at,
};
use clearance_kinematics::{Geometry, inverse_kinematics};
use clearance_model::JobSpec;

/// The paper's 3-PRS as a custom description, at home with the sliders at 0.
fn prs_job() -> JobSpec {
    let z0 = (1.0f64 - 0.18 * 0.18).sqrt();
    let text = format!(
        "[mechanism]\nkind = \"custom\"\ninputs = [\"z\", \"psi\", \"theta\"]\nhome = [0.0, 0.0, {z0:?}, 0.0, 0.0, 0.0]\n\
         [[mechanism.limb]]\nrepeat = 3\njoints = [\n\
         {{ type = \"P\", at = [0.18, 0.0, 0.0], axis = [0.0, 0.0, 1.0], actuated = true }},\n\
         {{ type = \"R\", at = [0.18, 0.0, 0.0], axis = [0.0, 1.0, 0.0] }},\n\
         {{ type = \"S\", at = [0.36, 0.0, {z0:?}] }},\n]\nbodies = [{{ mass = 0.0 }}, {{ mass = 3.0 }}]\n\
         [grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n"
    );
    JobSpec::from_toml_str(&text, "prs.toml").unwrap()
}

fn geometry(job: &JobSpec) -> CustomGeometry {
    let d = job.description("prs.toml").unwrap().unwrap();
    CustomGeometry::new(&d.inputs, d.home, &d.limbs)
}

#[test]
fn the_3prs_description_gives_the_closed_forms() {
    let geom = geometry(&prs_job());
    let builtin = Geometry::prototype();
    for &(z, psi, theta) in &[(2.05, 0.1, -0.2), (1.9, -0.4, 0.3), (2.2, 0.5, 0.5), (0.98, 0.0, 0.0)] {
        let p = custom_posture(&geom, &[z, psi, theta], None).unwrap();
        let b = inverse_kinematics(&builtin, z, psi, theta).unwrap();
        // x, y, φ within round-off of the closed forms (tolerance: 1e-12 m or rad).
        assert!((p.coords[0] - b.x).abs() < 1e-12, "x {} vs {}", p.coords[0], b.x);
        assert!((p.coords[1] - b.y).abs() < 1e-12, "y {} vs {}", p.coords[1], b.y);
        assert!((p.coords[3] - b.phi).abs() < 1e-12, "phi {} vs {}", p.coords[3], b.phi);
        // Sliders measured from home (0 here): the built-in slider positions.
        for (j, q) in p.actuators(&geom).iter().enumerate() {
            assert!((q - b.q[j]).abs() < 1e-12, "q{j} {q} vs {}", b.q[j]);
        }
        // Every limb closes on the platform: its S centre is the platform's vertex.
        for (l, joints) in p.joints.iter().enumerate() {
            let a = placement(&p.coords).apply(&nalgebra::Vector3::new(
                0.36 * (l as f64 * 2.0 * std::f64::consts::PI / 3.0).cos(),
                0.36 * (l as f64 * 2.0 * std::f64::consts::PI / 3.0).sin(),
                0.0,
            ));
            assert!((joints[2].centre - a).norm() < 1e-12);
        }
    }
}

#[test]
fn rates_agree_with_finite_differences() {
    let geom = geometry(&prs_job());
    // A path x(t) = x0 + v t + a t²/2 through the inputs.
    let (x0, v, a) = ([2.0, 0.2, -0.1], [0.3, -0.5, 0.7], [0.2, 0.4, -0.3]);
    let at = |t: f64| -> [f64; 3] { std::array::from_fn(|i| x0[i] + v[i] * t + a[i] * t * t / 2.0) };
    let p = custom_posture(&geom, &at(0.0), Some((&v, &a))).unwrap();
    let h = 1e-4;
    let (pp, pm) = (custom_posture(&geom, &at(h), None).unwrap(), custom_posture(&geom, &at(-h), None).unwrap());
    // Parasitic rates: central differences, error O(h²) ~ 1e-8.
    for k in [0, 1, 3] {
        let fd = (pp.coords[k] - pm.coords[k]) / (2.0 * h);
        let fdd = (pp.coords[k] - 2.0 * p.coords[k] + pm.coords[k]) / (h * h);
        let rate = if k < 3 {
            p.twist[3 + k]
                + p.twist.fixed_rows::<3>(0).cross(&nalgebra::Vector3::new(p.coords[0], p.coords[1], p.coords[2]))[k]
        } else {
            f64::NAN
        };
        if k < 3 {
            assert!((rate - fd).abs() < 1e-7, "coordinate {k}: rate {rate} vs {fd}");
        }
        let _ = fdd;
    }
    // The leg's centre of mass: velocity and acceleration by central differences.
    for l in 0..3 {
        let (g0, gp, gm) = (p.bodies[l][1].com, pp.bodies[l][1].com, pm.bodies[l][1].com);
        let tw = p.bodies[l][1].twist;
        let ac = p.bodies[l][1].accel;
        let w = tw.fixed_rows::<3>(0).into_owned();
        let vo = tw.fixed_rows::<3>(3).into_owned();
        let vel = vo + w.cross(&g0);
        let acc = ac.fixed_rows::<3>(3) + ac.fixed_rows::<3>(0).cross(&g0) + w.cross(&vel);
        let fd = (gp - gm) / (2.0 * h);
        let fdd = (gp - 2.0 * g0 + gm) / (h * h);
        assert!((vel - fd).norm() < 1e-7, "limb {l}: v {vel} vs {fd}");
        assert!((acc - fdd).norm() < 1e-5, "limb {l}: a {acc} vs {fdd}");
    }
}

// A custom posture is put together from the crossings of the closure's last Newton
// iteration instead of crossing every joint again: it must be the posture that
// `posture_at` builds from the same configuration by crossing the joints afresh, bit
// for bit, in statics and with rates, solved from home or continued from a
// neighbouring configuration. The mechanisms: the 3-RRS and the 6-PUS of `jobs/`
// (R, P, U and S joints, all six coordinates as inputs for the 6-PUS) and the 3-PRS
// (a parasitic `x, y, φ`).

/// Every number of a posture, as text (`{:?}` of an `f64` tells apart every two
/// finite values, and +0 from −0).
fn numbers(p: &CustomPosture) -> String {
    let joints: Vec<String> = p
        .joints
        .iter()
        .flatten()
        .map(|j| format!("{:?} {:?} {:?} {:?} {:?}", j.centre, j.axis, j.axis2, j.normal, &j.columns[..]))
        .collect();
    let bodies: Vec<String> = p
        .bodies
        .iter()
        .flatten()
        .map(|b| format!("{:?} {:?} {:?} {:?} {:?}", b.motion, b.com, b.inertia, b.twist, b.accel))
        .collect();
    format!("{:?} {:?} {:?} {:?} {:?} {:?} {:?}", p.coords, p.platform, p.twist, p.accel, joints, bodies, p.states)
}

/// Inputs a step `k` away from home: lengths by 4 mm, angles by 0.02 rad a step.
fn inputs(geom: &CustomGeometry, k: f64) -> Vec<f64> {
    geom.inputs
        .iter()
        .enumerate()
        .map(|(i, &c)| geom.home[c] + k * if c < 3 { 0.004 } else { 0.02 } * (1.0 + 0.3 * i as f64))
        .collect()
}

#[test]
fn the_posture_from_the_closure_is_the_posture_crossed_again() {
    let text = |t: &str| JobSpec::from_toml_str(t, "job.toml").unwrap();
    let mechanisms = [
        ("3-RRS", text(include_str!("../../../jobs/custom_3rrs_grid.toml"))),
        ("6-PUS", text(include_str!("../../../jobs/custom_6pus_grid.toml"))),
        ("3-PRS", prs_job()),
    ];
    let mut checked = 0;
    for (name, job) in &mechanisms {
        let geom = geometry(job);
        let n = geom.inputs.len();
        let (vel, acc): (Vec<f64>, Vec<f64>) = (0..n).map(|i| (0.3 - 0.1 * i as f64, 0.2 * i as f64 - 0.4)).unzip();
        let mut near = None;
        for k in [1.0, 2.0, 3.5, -1.5, -3.0] {
            let target = inputs(&geom, k);
            for rates in [None, Some((&vel[..], &acc[..]))] {
                // From home, then continued from the configuration of the step before.
                for from in [None, near.as_ref()] {
                    let p = custom_posture_near(&geom, &target, rates, from)
                        .unwrap_or_else(|e| panic!("{name} at {target:?}: {e:?}"));
                    let again = posture_at(&geom, p.coords, p.states.clone(), rates);
                    assert_eq!(numbers(&p), numbers(&again), "{name} at {target:?}, rates {rates:?}");
                    checked += 1;
                }
            }
            near = custom_posture_near(&geom, &target, None, None).ok().map(|p| (p.coords, p.states));
        }
    }
    assert_eq!(checked, 3 * 5 * 2 * 2);
}
