//! A custom posture is put together from the crossings of the closure's last Newton
//! iteration instead of crossing every joint again: it must be the posture that
//! `posture_at` builds from the same configuration by crossing the joints afresh, bit
//! for bit, in statics and with rates, solved from home or continued from a
//! neighbouring configuration. The mechanisms: the 3-RRS and the 6-PUS of `jobs/`
//! (R, P, U and S joints, all six coordinates as inputs for the 6-PUS) and the 3-PRS
//! (a parasitic `x, y, φ`).

use clearance_kinematics::custom::{CustomGeometry, CustomPosture, custom_posture_near, posture_at};
use clearance_model::JobSpec;

fn geometry(text: &str) -> CustomGeometry {
    let job = JobSpec::from_toml_str(text, "job.toml").unwrap();
    let d = job.description("job.toml").unwrap().unwrap();
    CustomGeometry::new(&d.inputs, d.home, &d.limbs)
}

fn prs() -> String {
    let z0 = (1.0f64 - 0.18 * 0.18).sqrt();
    format!(
        "[mechanism]\nkind = \"custom\"\ninputs = [\"z\", \"psi\", \"theta\"]\nhome = [0.0, 0.0, {z0:?}, 0.0, 0.0, 0.0]\n\
         [[mechanism.limb]]\nrepeat = 3\njoints = [\n\
         {{ type = \"P\", at = [0.18, 0.0, 0.0], axis = [0.0, 0.0, 1.0], actuated = true }},\n\
         {{ type = \"R\", at = [0.18, 0.0, 0.0], axis = [0.0, 1.0, 0.0] }},\n\
         {{ type = \"S\", at = [0.36, 0.0, {z0:?}] }},\n]\nbodies = [{{ mass = 0.0 }}, {{ mass = 3.0 }}]\n\
         [grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n"
    )
}

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
    let mechanisms = [
        ("3-RRS", include_str!("../../../jobs/custom_3rrs_grid.toml").to_string()),
        ("6-PUS", include_str!("../../../jobs/custom_6pus_grid.toml").to_string()),
        ("3-PRS", prs()),
    ];
    let mut checked = 0;
    for (name, text) in &mechanisms {
        let geom = geometry(text);
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
