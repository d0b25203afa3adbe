//! The 6-UPS physics (docs/model.md §10.3), each against an independent computation:
//! statics against virtual work, dynamics against every body's Newton–Euler balance
//! recomputed here, the linear error against the exact one to second order, the
//! `u_angular` error and the couples `μ_i` at round-off, and the batch over threads
//! against one thread.

mod common;

use clearance_kinematics::{UpsGeometry, UpsMotion, UpsParams, UpsPosture, ups_inverse_kinematics_motion};
use clearance_model::Mode;
use clearance_solver::limbs::Posed;
use clearance_solver::ups::{
    UpsMass, UpsModel, UpsResult, UpsSample, UpsWorkspace, solve_ups_loads, solve_ups_loads_reduced, solve_ups_par,
    solve_ups_pose, solve_ups_pose_assembled, solve_ups_poses, statics_sample, ups_exact_error, ups_posture,
};
use clearance_solver::{LimbsSolution, PoseError, Status};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random model: the default layout or a jittered one (points off their planes,
/// tilted U axes), random masses with a point mass, gravity tilt and external wrench.
fn random_model(rng: &mut ChaCha8Rng, clearance: [f64; 3]) -> UpsModel {
    let mut params = UpsParams::default();
    if rng.random_bool(0.7) {
        let base = UpsGeometry::default();
        let mut j = |r: f64| rng.random_range(-r..r);
        params.base_points = Some(std::array::from_fn(|i| [base.b[i].x + j(0.05), base.b[i].y + j(0.05), j(0.02)]));
        params.platform_points =
            Some(std::array::from_fn(|i| [base.a_local[i].x + j(0.03), base.a_local[i].y + j(0.03), j(0.02)]));
        params.u_axes = Some(std::array::from_fn(|i| [base.a1[i].x + j(0.3), base.a1[i].y + j(0.3), j(0.5)]));
        params.max_length = Some(1.3);
    }
    let geometry = UpsGeometry::new(&params);
    let mut mass =
        UpsMass::new(&geometry, rng.random_range(5.0..15.0), rng.random_range(0.5..3.0), rng.random_range(0.3..2.0));
    mass.add_point(
        rng.random_range(0.0..10.0),
        Vector3::new(rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2), rng.random_range(-0.5..0.5)),
    );
    let gravity = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), -9.81);
    let mut model = UpsModel::new(geometry, mass, gravity, clearance);
    let mut v = |r: f64| Vector3::new(rng.random_range(-r..r), rng.random_range(-r..r), rng.random_range(-r..r));
    model.load.force = v(20.0);
    model.load.moment = v(5.0);
    model.load.at_local = v(0.2);
    model
}

fn random_sample(rng: &mut ChaCha8Rng, moving: bool) -> UpsSample {
    let k = if moving { 1.0 } else { 0.0 };
    std::array::from_fn(|i| {
        let (centre, span) = match i {
            0 | 1 => (0.0, 0.08),
            2 => (0.72, 0.1),
            _ => (0.0, 0.25),
        };
        [centre + rng.random_range(-span..span), k * rng.random_range(-0.5..0.5), k * rng.random_range(-3.0..3.0)]
    })
}

/// Rod inertia about its centre, world axes, computed here: `m·ℓ²/12·(I − e·eᵀ)`.
fn rod(m: f64, l: f64, e: &Vector3<f64>) -> Matrix3<f64> {
    m * l * l / 12.0 * (Matrix3::identity() - e * e.transpose())
}

/// A body as `(mass, centre, velocity, acceleration, inertia)`.
type Rigid = (f64, Vector3<f64>, Vector3<f64>, Vector3<f64>, Matrix3<f64>);

/// The leg's cylinder and piston.
fn leg_bodies(model: &UpsModel, pose: &UpsPosture, m: &UpsMotion, i: usize) -> [Rigid; 2] {
    let (cyl, pis) = (&model.mass.cylinder, &model.mass.piston);
    let (hc, hp) = (0.5 * cyl.length, 0.5 * pis.length);
    let e = pose.e[i];
    [
        (cyl.mass, pose.b[i] + hc * e, hc * m.e_dot[i], hc * m.e_ddot[i], rod(cyl.mass, cyl.length, &e)),
        (
            pis.mass,
            pose.a[i] - hp * e,
            m.a_dot[i] - hp * m.e_dot[i],
            m.a_ddot[i] - hp * m.e_ddot[i],
            rod(pis.mass, pis.length, &e),
        ),
    ]
}

/// Kinetostatics: with the actuator forces `τ_i` (the cylinder's push on the piston
/// along `e_i`, from the piston's own balance), `Σ τ_i·q̇_i + Σ m·g·Ġ + f_ext·Ė + m_ext·ω = 0`
/// for every virtual motion of the six inputs (velocities by the kinematics' jets).
#[test]
fn statics_satisfy_virtual_work() {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut checked = 0;
    for _ in 0..60 {
        let model = random_model(&mut rng, [1e-4, 1e-4, 1e-3]);
        let mut ws = UpsWorkspace::new(&model);
        let s = random_sample(&mut rng, false);
        let r = solve_ups_pose(&model, &s, Mode::Kinetostatic, &mut ws);
        if r.status != Status::Ok {
            continue;
        }
        let g = model.assembly.gravity;
        let pis = &model.mass.piston;
        for _ in 0..6 {
            let delta: [f64; 6] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
            let moving: UpsSample = std::array::from_fn(|k| [s[k][0], delta[k], 0.0]);
            let (pose, m) = ups_inverse_kinematics_motion(&model.geometry, moving).unwrap();
            let (mut power, mut scale) = (0.0, 0.0);
            let mut add = |p: f64| {
                power += p;
                scale += p.abs();
            };
            for i in 0..6 {
                let tau = (r.f_s[i] - pis.mass * g).dot(&pose.e[i]);
                add(tau * m.q_dot[i]);
                for (mass, _, v, _, _) in leg_bodies(&model, &pose, &m, i) {
                    add(mass * g.dot(&v));
                }
            }
            let c = pose.rot * model.mass.com_local;
            add(model.mass.platform * g.dot(&(m.p_dot + m.omega.cross(&c))));
            let arm = pose.rot * model.load.at_local;
            add(model.load.force.dot(&(m.p_dot + m.omega.cross(&arm))));
            add(model.load.moment.dot(&m.omega));
            assert!(power.abs() <= 1e-11 * scale, "virtual power {power:e} of {scale:e}");
        }
        checked += 1;
    }
    assert!(checked > 40, "{checked}");
}

/// Dynamics: every leg (cylinder and piston) and the platform balance their forces and
/// their moments about the origin, with the inertial terms recomputed here from the
/// kinematics' rates and the residual scaled by the loads involved.
#[test]
fn reactions_satisfy_each_bodys_newton_euler_balance() {
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let mut checked = 0;
    for _ in 0..60 {
        let model = random_model(&mut rng, [1e-4, 1e-4, 1e-3]);
        let mut ws = UpsWorkspace::new(&model);
        for moving in [false, true] {
            let s = random_sample(&mut rng, moving);
            let r = solve_ups_pose(&model, &s, Mode::Dynamic, &mut ws);
            if r.status != Status::Ok {
                continue;
            }
            let (pose, m) = ups_inverse_kinematics_motion(&model.geometry, s).unwrap();
            let g = model.assembly.gravity;
            let scale = model.weight() + model.load.force.norm() + model.load.moment.norm() + r.f_u[0].norm();
            let tol = 1e-11 * scale;
            for i in 0..6 {
                let (a, b) = (pose.a[i], pose.b[i]);
                let mut force = r.f_u[i] - r.f_s[i];
                let mut moment = r.mu[i] * pose.n[i] + b.cross(&r.f_u[i]) - a.cross(&r.f_s[i]);
                for (mass, centre, _, acc, inertia) in leg_bodies(&model, &pose, &m, i) {
                    let (w, wd) = (m.leg_omega[i], m.leg_omega_dot[i]);
                    let net = mass * (g - acc);
                    force += net;
                    moment += centre.cross(&net) - (inertia * wd + w.cross(&(inertia * w)));
                }
                assert!(force.amax() <= tol && moment.amax() <= tol, "leg {i}: {force} {moment}");
            }
            let mass = &model.mass;
            let cl = pose.rot * mass.com_local;
            let c = pose.p + cl;
            let acc = m.p_ddot + m.omega_dot.cross(&cl) + m.omega.cross(&m.omega.cross(&cl));
            let inertia = pose.rot * mass.inertia_local * pose.rot.transpose();
            let net = mass.platform * (g - acc);
            let e_point = pose.p + pose.rot * model.load.at_local;
            let mut force = net + model.load.force;
            let mut moment = c.cross(&net) + e_point.cross(&model.load.force) + model.load.moment
                - (inertia * m.omega_dot + m.omega.cross(&(inertia * m.omega)));
            for i in 0..6 {
                force += r.f_s[i];
                moment += pose.a[i].cross(&r.f_s[i]);
            }
            assert!(force.amax() <= tol && moment.amax() <= tol, "platform: {force} {moment}");
            checked += 1;
        }
    }
    assert!(checked > 80, "{checked}");
}

/// The 30 × 30 loop system against the platform's 6 × 6 leg-length Jacobian: with
/// every leg's length locked and its ends free to turn, a take-up moves the platform
/// only through the leg's axis, `e_i·(Δp + Δα×r_i) = e_i·(ΔA_i + ΔB_i + θ_i×(A_i − B_i))`
/// with `r_i = A_i − P`. Solved here with nalgebra, to 1e-10 of the clearance scale.
#[test]
fn error_system_matches_the_leg_jacobian() {
    use nalgebra::{Matrix6, Vector6};
    let mut rng = ChaCha8Rng::seed_from_u64(66);
    let mut checked = 0;
    for _ in 0..80 {
        let c = [rng.random_range(1e-5..1e-3), rng.random_range(1e-5..1e-3), rng.random_range(1e-4..1e-2)];
        let model = random_model(&mut rng, c);
        let mut ws = UpsWorkspace::new(&model);
        let moving = rng.random_bool(0.5);
        let s = random_sample(&mut rng, moving);
        let r = solve_ups_pose(&model, &s, Mode::Dynamic, &mut ws);
        if r.status != Status::Ok {
            continue;
        }
        let (pose, posed) = ups_posture(&model, &s, Mode::Dynamic).unwrap();
        let sol = model.assembly.solve(&posed, &mut ws.data);
        let mut jac = Matrix6::zeros();
        for i in 0..6 {
            let (e, ri) = (pose.e[i], pose.a[i] - pose.p);
            let row = ri.cross(&e);
            for k in 0..3 {
                jac[(i, k)] = row[k];
                jac[(i, 3 + k)] = e[k];
            }
        }
        let lu = jac.lu();
        for k in 0..3 {
            let d = Vector6::from_fn(|i, _| {
                let t = sol.take[k][i];
                let moved = if k == 2 { t.cross(&(pose.a[i] - pose.b[i])) } else { t };
                pose.e[i].dot(&moved)
            });
            let want = lu.solve(&d).expect("regular Jacobian");
            let got = &r.errors[k];
            let tol = 1e-10 * c[0].max(c[1]);
            let (da, dp) = (want.fixed_rows::<3>(0), want.fixed_rows::<3>(3));
            assert!((got.dalpha - da).amax() <= tol && (got.dp - dp).amax() <= tol, "kind {k}: {got:?} vs {want}");
        }
        checked += 1;
    }
    assert!(checked > 50, "{checked}");
}

/// `|exact − linear|` (max over the six components) of one sample.
fn gap(r: &UpsResult) -> f64 {
    let e = r.exact.expect("exact error");
    let t = &r.total;
    let lin = [t.dalpha.x, t.dalpha.y, t.dalpha.z, t.dp.x, t.dp.y, t.dp.z];
    e.iter().zip(lin).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
}

/// The linear error is the exact one to second order: halving every clearance
/// quarters their difference (ratio within [3.6, 4.4]).
#[test]
fn linear_error_is_exact_to_second_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(63);
    let mut checked = 0;
    for _ in 0..40 {
        let c = [rng.random_range(1e-4..1e-3), rng.random_range(1e-4..1e-3), rng.random_range(1e-3..1e-2)];
        let mut model = random_model(&mut rng, c);
        model.exact = true;
        let mut ws = UpsWorkspace::new(&model);
        let moving = rng.random_bool(0.5);
        let s = random_sample(&mut rng, moving);
        let full = solve_ups_pose(&model, &s, Mode::Dynamic, &mut ws);
        if full.status != Status::Ok {
            continue;
        }
        model.set_clearance(c.map(|v| v / 2.0));
        let half = solve_ups_pose(&model, &s, Mode::Dynamic, &mut ws);
        let ratio = gap(&full) / gap(&half);
        assert!((3.6..=4.4).contains(&ratio), "ratio {ratio} ({:e} vs {:e})", gap(&full), gap(&half));
        // And the difference is of second order: far below the error itself.
        assert!(gap(&full) < 0.05 * full.total.dp.norm().max(full.total.dalpha.norm()));
        checked += 1;
    }
    assert!(checked > 25, "{checked}");
}

/// `u_angular` alone moves nothing, linear or exact, and the legs' couples `μ_i` are
/// round-off; it never makes a pose indeterminate though `|μ_i|` is below the floor.
#[test]
fn u_joint_tilt_play_is_harmless() {
    let mut rng = ChaCha8Rng::seed_from_u64(64);
    let mut checked = 0;
    for _ in 0..60 {
        let theta = 1e-3;
        let model = random_model(&mut rng, [0.0, 0.0, theta]);
        let mut ws = UpsWorkspace::new(&model);
        let moving = rng.random_bool(0.5);
        let s = random_sample(&mut rng, moving);
        let r = solve_ups_pose(&model, &s, Mode::Dynamic, &mut ws);
        if r.status == Status::Unreachable || r.status == Status::NearSingular {
            continue;
        }
        assert_eq!(r.status, Status::Ok, "u_angular decides no status");
        let scale = model.weight() + model.load.force.norm() + model.load.moment.norm();
        for i in 0..6 {
            assert!(r.mu[i].abs() <= 1e-12 * scale, "μ_{i} = {:e}", r.mu[i]);
            // The margin is |μ_i·n_i|, |n_i| = 1 to round-off.
            assert!((r.margins[2][i] - r.mu[i].abs()).abs() <= 4.0 * f64::EPSILON * r.mu[i].abs());
        }
        let e = &r.errors[2];
        assert!(e.dp.amax() <= 1e-14 * theta && e.dalpha.amax() <= 1e-14 * theta, "{e:?}");
        // The exact closure with every leg tilted by θ·n_i about B_i: the U joints absorb it.
        let (pose, posed): (UpsPosture, _) = ups_posture(&model, &s, Mode::Dynamic).unwrap();
        let sol = model.assembly.solve(&posed, &mut ws.data);
        assert!(sol.take[2][..6].iter().all(|t| (t.norm() - theta).abs() < 1e-15));
        let exact = ups_exact_error(&model, &pose, &sol).expect("converges");
        assert!(exact.iter().all(|v| v.abs() <= 1e-14 * theta), "{exact:?}");
        // Beside the other kinds, in either direction, it changes neither error.
        let mut with = |tilt: f64| {
            let mut m = model.clone();
            m.set_clearance([2e-4, 1e-4, tilt]);
            m.exact = true;
            solve_ups_pose(&m, &s, Mode::Dynamic, &mut ws)
        };
        let (none, plus, minus) = (with(0.0), with(theta), with(-theta));
        for other in [&plus, &minus] {
            assert_eq!(other.status, none.status);
            assert!((other.total.dp - none.total.dp).amax() <= 1e-18, "{:?}", other.total.dp);
            if let (Some(a), Some(b)) = (other.exact, none.exact) {
                assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-12 * 2e-4), "{a:?} vs {b:?}");
            }
        }
        checked += 1;
    }
    assert!(checked > 40, "{checked}");
}

/// Under its own weight with only `s_radial`, the platform sags; a leg along its fixed
/// U axis is near-singular; a leg beyond its stroke is unreachable.
#[test]
fn statuses_and_sag() {
    let mut model = UpsModel::default();
    model.set_clearance([1e-4, 0.0, 0.0]);
    let mut ws = UpsWorkspace::new(&model);
    let r = solve_ups_pose(&model, &statics_sample([0.0, 0.0, 0.7, 0.0, 0.0, 0.0]), Mode::Kinetostatic, &mut ws);
    assert_eq!(r.status, Status::Ok);
    assert!(r.total.dp.z < 0.0 && r.total.dp.z > -1e-3, "{:?}", r.total.dp);
    let far = solve_ups_pose(&model, &statics_sample([0.0, 0.0, 1.5, 0.0, 0.0, 0.0]), Mode::Kinetostatic, &mut ws);
    assert_eq!(far.status, Status::Unreachable);
    let pose = clearance_kinematics::ups_inverse_kinematics(&model.geometry, [0.0, 0.0, 0.7, 0.0, 0.0, 0.0]).unwrap();
    let params = UpsParams {
        u_axes: Some(std::array::from_fn(|i| {
            let a = if i == 4 { pose.e[i] } else { model.geometry.a1[i] };
            [a.x, a.y, a.z]
        })),
        ..Default::default()
    };
    let bad = UpsModel { geometry: UpsGeometry::new(&params), ..Default::default() };
    let r = solve_ups_pose(&bad, &statics_sample([0.0, 0.0, 0.7, 0.0, 0.0, 0.0]), Mode::Kinetostatic, &mut ws);
    assert_eq!(r.status, Status::NearSingular);
}

/// The batch over the rayon pool gives the bits of one thread, for any block size.
#[test]
fn parallel_batch_matches_serial() {
    let mut rng = ChaCha8Rng::seed_from_u64(65);
    let model = random_model(&mut rng, [1e-4, 2e-4, 1e-3]);
    let samples: Vec<UpsSample> = (0..101).map(|_| random_sample(&mut rng, true)).collect();
    for mode in [Mode::Kinetostatic, Mode::Dynamic] {
        let mut serial = vec![UpsResult::default(); samples.len()];
        solve_ups_poses(&model, &samples, mode, &mut UpsWorkspace::new(&model), &mut serial);
        assert!(serial.iter().filter(|r| r.status == Status::Ok).count() > 50);
        for block in [1, 7, 64] {
            let mut par = vec![UpsResult::default(); samples.len()];
            solve_ups_par(&model, &samples, mode, block, &mut par);
            assert_eq!(serial, par, "block {block}");
        }
    }
}

/// `[Δp; Δα]` of kind `k` for a displacement `d` of limb `i`'s joint alone, through the
/// assembled 30 × 30 error system (not the leg Jacobian the envelope is built from).
fn joint_response(
    model: &UpsModel,
    posed: &Posed,
    ws: &mut UpsWorkspace,
    k: usize,
    i: usize,
    d: Vector3<f64>,
) -> [f64; 6] {
    let mut sol = LimbsSolution::default();
    sol.take[k][i] = d;
    assert!(model.assembly.solve_errors(posed, &mut sol, &mut ws.data));
    let e = sol.errors[k];
    [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z]
}

/// The envelope (docs/model.md §11 for the 6-UPS) against a brute-force maximum over
/// sampled displacements of each joint (the ball's surface for `s_radial` and
/// `u_radial`, the ends of the segment of rotations about `n_i` for `u_angular`), each
/// joint's response solved through the assembled error system; the deterministic
/// error lies inside it; each joint's contribution is its own response to its take-up,
/// and the dominant joint is the largest of them (never `u_angular`).
#[test]
fn envelope_is_the_worst_case_and_names_the_joint() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let directions = common::sphere(20_000);
    let mut compared = 0;
    while compared < 12 {
        let clearance = [rng.random_range(1e-5..1e-3), rng.random_range(1e-5..1e-3), rng.random_range(1e-5..1e-3)];
        let model = random_model(&mut rng, clearance);
        let mut ws = UpsWorkspace::new(&model);
        let sample = random_sample(&mut rng, false);
        let r = solve_ups_pose(&model, &sample, Mode::Kinetostatic, &mut ws);
        if r.status != Status::Ok {
            continue;
        }
        let (_, posed) = ups_posture(&model, &sample, Mode::Kinetostatic).unwrap();
        let sol = model.assembly.solve(&posed, &mut ws.data);
        let total = r.envelope_total();
        let scale = clearance.iter().fold(0.0f64, |m, &c| m.max(c));
        let mut best = (f64::NEG_INFINITY, None);
        for k in 0..3 {
            let mut brute = [0.0f64; 8];
            for i in 0..6 {
                // The response is linear in the displacement: three solves give it all.
                let map: [[f64; 6]; 3] =
                    std::array::from_fn(|a| joint_response(&model, &posed, &mut ws, k, i, Vector3::ith(a, 1.0)));
                let apply =
                    |d: &Vector3<f64>| -> [f64; 6] { std::array::from_fn(|c| (0..3).map(|a| map[a][c] * d[a]).sum()) };
                let set: Vec<Vector3<f64>> = if k == 2 {
                    let n = ups_posture(&model, &sample, Mode::Kinetostatic).unwrap().0.n[i];
                    vec![clearance[2] * n, -clearance[2] * n]
                } else {
                    directions.iter().map(|u| clearance[k] * u).collect()
                };
                let mut joint = [0.0f64; 8];
                for d in &set {
                    let v = apply(d);
                    for c in 0..6 {
                        joint[c] = joint[c].max(v[c].abs());
                    }
                    joint[6] = joint[6].max((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
                    joint[7] = joint[7].max((v[3] * v[3] + v[4] * v[4] + v[5] * v[5]).sqrt());
                }
                for c in 0..8 {
                    brute[c] += joint[c];
                }
                let own = apply(&sol.take[k][i]);
                let own_dp = (own[0] * own[0] + own[1] * own[1] + own[2] * own[2]).sqrt();
                let got = r.contribution[k][i];
                assert!((got - own_dp).abs() <= 1e-9 * own_dp + 1e-15 * scale, "kind {k} limb {i}: {got} vs {own_dp}");
                if k < 2 && own_dp > best.0 * (1.0 + 1e-6) {
                    best = (own_dp, Some((k, i)));
                }
            }
            for (c, (&env, &brute)) in r.envelope[k].iter().zip(&brute).enumerate() {
                // The lattice's spacing (~0.025 rad) undershoots a maximum by < 1e-3.
                assert!(env >= brute * (1.0 - 1e-12) - 1e-12 * scale, "kind {k} part {c}: {env} < sampled {brute}");
                assert!(env <= brute * (1.0 + 1e-3) + 1e-12 * scale, "kind {k} part {c}: {env} > sampled {brute}");
            }
            if k == 2 {
                assert!(r.envelope[2].iter().all(|v| v.abs() <= 1e-12 * clearance[2]), "{:?}", r.envelope[2]);
            }
            let err = r.errors[k];
            let e = [
                err.dp.x,
                err.dp.y,
                err.dp.z,
                err.dalpha.x,
                err.dalpha.y,
                err.dalpha.z,
                err.dp.norm(),
                err.dalpha.norm(),
            ];
            for (c, (v, env)) in e.iter().zip(&r.envelope[k]).enumerate() {
                assert!(v.abs() <= env * (1.0 + 1e-9) + 1e-15 * scale, "kind {k} part {c} outside");
            }
        }
        for c in 0..8 {
            assert_eq!(total[c], r.envelope.iter().map(|k| k[c]).sum::<f64>());
        }
        // A joint clearly ahead of the others (not a near tie) is the dominant one.
        let second = (0..2)
            .flat_map(|k| (0..6).map(move |i| (k, i)))
            .filter(|&ki| Some(ki) != best.1)
            .map(|(k, i)| r.contribution[k][i])
            .fold(0.0f64, f64::max);
        if best.0 > second * (1.0 + 1e-6) {
            assert_eq!(r.dominant, best.1);
        }
        compared += 1;
    }
}

/// A 6-UPS whose only play is U-joint tilt has nothing that moves the platform, so no
/// joint dominates; the envelope is round-off.
#[test]
fn tilt_play_alone_names_no_joint() {
    let mut model = UpsModel::default();
    model.set_clearance([0.0, 0.0, 1e-3]);
    let mut ws = UpsWorkspace::new(&model);
    let r = solve_ups_pose(&model, &statics_sample([0.01, -0.02, 0.72, 0.1, 0.05, -0.1]), Mode::Kinetostatic, &mut ws);
    assert_eq!(r.status, Status::Ok);
    assert_eq!(r.dominant, None);
    assert!(r.envelope_total().iter().all(|v| v.abs() <= 1e-15), "{:?}", r.envelope_total());
}

/// `reduced`'s reactions are `full`'s to 1e-10 of the largest load (`f_S`, `f_U`, `μ`,
/// the radial margins), with the same take-up determinacy.
fn assert_same_loads(full: &UpsResult, reduced: &UpsResult) {
    let scale = (0..6).map(|i| full.f_s[i].norm().max(full.f_u[i].norm())).fold(0.0, f64::max);
    for i in 0..6 {
        assert!((full.f_s[i] - reduced.f_s[i]).norm() <= 1e-10 * scale, "{:?} {:?}", full.f_s[i], reduced.f_s[i]);
        assert!((full.f_u[i] - reduced.f_u[i]).norm() <= 1e-10 * scale);
        assert!((full.mu[i] - reduced.mu[i]).abs() <= 1e-10 * scale);
    }
    assert_eq!(full.kind_ok, reduced.kind_ok);
    for k in 0..2 {
        for i in 0..6 {
            assert!((full.margins[k][i] - reduced.margins[k][i]).abs() <= 1e-10 * scale);
        }
    }
}

/// The legs eliminated in closed form and the platform's 6 × 6 system give the
/// reactions of the 42 × 42 factorisation to round-off (1e-10 of the largest load),
/// the same statuses and the same take-ups, on random models (jittered layouts,
/// tilted U axes, external wrenches) in statics and dynamics.
#[test]
fn reduced_loads_equal_the_assembled_ones() {
    let mut rng = ChaCha8Rng::seed_from_u64(66);
    let mut compared = 0;
    for _ in 0..40 {
        let model = random_model(&mut rng, [1e-4, 2e-4, 1e-3]);
        let mut ws = UpsWorkspace::new(&model);
        for mode in [Mode::Kinetostatic, Mode::Dynamic] {
            for _ in 0..10 {
                let s = random_sample(&mut rng, mode == Mode::Dynamic);
                let (full, reduced) =
                    (solve_ups_loads(&model, &s, mode, &mut ws), solve_ups_loads_reduced(&model, &s, mode, &mut ws));
                assert_eq!(full.status, reduced.status);
                if full.status != Status::Ok {
                    continue;
                }
                compared += 1;
                assert_same_loads(&full, &reduced);
            }
        }
    }
    assert!(compared > 400, "{compared} poses compared");
}

/// A pose solved with the legs eliminated (reactions from the 6 × 6 platform system,
/// errors through the legs' screws) equals the same pose from the assembled 42 × 42
/// equilibrium and 30 × 30 error system (the general path): statuses, take-up
/// determinacy and dominant joints the same, reactions and margins to 1e-10 of the largest load,
/// each kind's error, the total and the envelope to 1e-10 of the clearance scale, on
/// random models in statics and dynamics, with the exact error on.
#[test]
fn reduced_poses_equal_the_assembled_ones() {
    let mut rng = ChaCha8Rng::seed_from_u64(67);
    let mut compared = 0;
    for _ in 0..40 {
        let c = [rng.random_range(1e-5..1e-3), rng.random_range(1e-5..1e-3), rng.random_range(1e-4..1e-2)];
        let mut model = random_model(&mut rng, c);
        model.exact = rng.random_bool(0.5);
        let mut ws = UpsWorkspace::new(&model);
        for mode in [Mode::Kinetostatic, Mode::Dynamic] {
            for _ in 0..10 {
                let s = random_sample(&mut rng, mode == Mode::Dynamic);
                let (full, reduced) =
                    (solve_ups_pose_assembled(&model, &s, mode, &mut ws), solve_ups_pose(&model, &s, mode, &mut ws));
                assert_eq!(full.status, reduced.status);
                if full.status != Status::Ok {
                    continue;
                }
                compared += 1;
                assert_same_loads(&full, &reduced);
                assert_eq!(full.dominant, reduced.dominant);
                let tol = 1e-10 * c[0].max(c[1]);
                let near = |a: &PoseError, b: &PoseError| {
                    (a.dp - b.dp).amax() <= tol
                        && (a.dalpha - b.dalpha).amax() <= tol
                        && (0..3).all(|q| (a.euler[q] - b.euler[q]).abs() <= tol)
                };
                for k in 0..3 {
                    assert!(
                        near(&full.errors[k], &reduced.errors[k]),
                        "kind {k}: {:?} vs {:?}",
                        full.errors[k],
                        reduced.errors[k]
                    );
                    for v in 0..8 {
                        assert!((full.envelope[k][v] - reduced.envelope[k][v]).abs() <= tol);
                    }
                }
                assert!(near(&full.total, &reduced.total));
                assert_eq!(full.exact.is_some(), reduced.exact.is_some());
                if let (Some(a), Some(b)) = (full.exact, reduced.exact) {
                    assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol), "{a:?} vs {b:?}");
                }
            }
        }
    }
    assert!(compared > 400, "{compared} poses compared");
}
