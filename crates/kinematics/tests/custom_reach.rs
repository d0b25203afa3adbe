//! Where a mechanism described by its joints stops reaching (docs/model.md §12.2).
//! A 3-RRS (a crank at the base, a knee parallel to it, a leg, a spherical joint at
//! the platform; the `jobs/custom_3rrs_grid.toml` wrist without its crank range) is
//! solved by continuation from home; its reach is checked against an independent
//! computation on rays from home that cross the edge of its workspace. Each leg moves
//! in its limb's vertical plane, so the parasitic `x, y, φ` put the three spherical
//! centres in their planes (three equations, solved here by Newton with a
//! finite-difference Jacobian), and a limb reaches where its centre lies between
//! `L₂ − L₁` and `L₂ + L₁` of its crank's pivot.

use clearance_kinematics::custom::{CustomGeometry, custom_posture};
use clearance_model::JobSpec;
use nalgebra::{Matrix3, Vector3};

const Z: f64 = 0.6;
const CRANK: f64 = 0.2;

fn geometry() -> CustomGeometry {
    let text = format!(
        "[mechanism]\nkind = \"custom\"\ninputs = [\"z\", \"psi\", \"theta\"]\nhome = [0.0, 0.0, {Z:?}, 0.0, 0.0, 0.0]\n\
         [[mechanism.limb]]\nrepeat = 3\njoints = [\n\
         {{ type = \"R\", name = \"crank\", at = [0.25, 0.0, 0.0], axis = [0.0, 1.0, 0.0], actuated = true }},\n\
         {{ type = \"R\", name = \"knee\", at = [0.45, 0.0, 0.0], axis = [0.0, 1.0, 0.0] }},\n\
         {{ type = \"S\", at = [0.15, 0.0, {Z:?}] }},\n]\nbodies = [{{ mass = 1.2 }}, {{ mass = 2.0 }}]\n\
         [grid]\nz = {Z:?}\npsi = 0.0\ntheta = 0.0\n"
    );
    let job = JobSpec::from_toml_str(&text, "rrs.toml").unwrap();
    let d = job.description("rrs.toml").unwrap().unwrap();
    CustomGeometry::new(&d.inputs, d.home, &d.limbs)
}

/// `R_z(a)`.
fn about_z(a: f64) -> Matrix3<f64> {
    Matrix3::new(a.cos(), -a.sin(), 0.0, a.sin(), a.cos(), 0.0, 0.0, 0.0, 1.0)
}

/// The platform's orientation `R_y(θ)·R_x(ψ)·R_z(φ)` (docs/model.md §1).
fn rotation(phi: f64, psi: f64, theta: f64) -> Matrix3<f64> {
    let ry = Matrix3::new(theta.cos(), 0.0, theta.sin(), 0.0, 1.0, 0.0, -theta.sin(), 0.0, theta.cos());
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, psi.cos(), -psi.sin(), 0.0, psi.sin(), psi.cos());
    ry * rx * about_z(phi)
}

/// Limb i's spherical centre less its crank's pivot, at `x, y, φ` and the inputs.
fn reach_of(i: usize, [x, y, phi]: [f64; 3], [z, psi, theta]: [f64; 3]) -> Vector3<f64> {
    let r = about_z(i as f64 * 2.0 * std::f64::consts::PI / 3.0);
    let centre = Vector3::new(x, y, z) + rotation(phi, psi, theta) * r * Vector3::new(0.15, 0.0, 0.0);
    centre - r * Vector3::new(0.25, 0.0, 0.0)
}

/// The parasitic `x, y, φ` that put every spherical centre in its limb's plane (from
/// zero, as home has them), and whether every limb reaches; `None` where Newton does
/// not settle.
fn independent(inputs: [f64; 3]) -> Option<([f64; 3], bool)> {
    let planes = |u: [f64; 3]| {
        Vector3::from_fn(|i, _| {
            let normal = about_z(i as f64 * 2.0 * std::f64::consts::PI / 3.0) * Vector3::y();
            reach_of(i, u, inputs).dot(&normal)
        })
    };
    let mut u = [0.0; 3];
    for _ in 0..50 {
        let f = planes(u);
        if f.norm() < 1e-15 {
            let leg = (0.3f64 * 0.3 + 0.6 * 0.6).sqrt();
            let reaches = (0..3).all(|i| {
                let d = reach_of(i, u, inputs).norm();
                d > leg - CRANK && d < leg + CRANK
            });
            return Some((u, reaches));
        }
        let h = 1e-7;
        let jac = Matrix3::from_fn(|r, c| {
            let mut v = u;
            v[c] += h;
            (planes(v)[r] - f[r]) / h
        });
        let step = jac.lu().solve(&-f)?;
        for k in 0..3 {
            u[k] += step[k];
        }
    }
    None
}

#[test]
fn the_3rrs_reaches_where_its_legs_do() {
    let geom = geometry();
    let (mut inside, mut outside) = (0, 0);
    // Rays from home through (z, ψ, θ), up and down, tilting as they go.
    for ray in 0..8 {
        let angle = ray as f64 * std::f64::consts::PI / 4.0 + 0.2;
        let dir = [if ray % 2 == 0 { 0.5 } else { -0.3 }, 0.8 * angle.cos(), 0.8 * angle.sin()];
        let at = |t: f64| [Z + t * dir[0], t * dir[1], t * dir[2]];
        let reaches = |t: f64| independent(at(t)).is_some_and(|(_, r)| r);
        // The edge along the ray, by bisection of the independent verdict.
        let (mut lo, mut hi) = (0.0, 1.0);
        assert!(reaches(lo) && !reaches(hi), "ray {ray} crosses the edge");
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if reaches(mid) { lo = mid } else { hi = mid }
        }
        for k in 1..=24 {
            let t = k as f64 / 24.0;
            // Near the edge the verdict is not compared: the continuation gives up
            // where its step falls below 1e-6 of the way from home.
            if (t - lo).abs() < 1e-3 {
                continue;
            }
            let custom = custom_posture(&geom, &at(t), None);
            if t < lo {
                let p = custom.unwrap_or_else(|e| panic!("ray {ray}, t = {t}: {e:?} inside the edge at {lo}"));
                let (u, _) = independent(at(t)).expect("solved inside");
                // The same x, y and φ, within 1e-10 m or rad (the finite-difference
                // Newton settles to round-off).
                for (k, &coord) in [0, 1, 3].iter().enumerate() {
                    assert!((p.coords[coord] - u[k]).abs() < 1e-10, "ray {ray}, t = {t}: {:?} vs {u:?}", p.coords);
                }
                inside += 1;
            } else {
                assert!(custom.is_err(), "ray {ray}, t = {t}: solved beyond the edge at {lo}");
                outside += 1;
            }
        }
    }
    assert!(inside > 40 && outside > 40, "both sides of the edge tested: {inside} inside, {outside} outside");
}
