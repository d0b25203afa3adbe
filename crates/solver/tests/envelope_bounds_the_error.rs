//! The worst-case envelope (docs/model.md §11): the deterministic error
//! lies inside it at every pose, and it equals a brute-force maximum over sampled
//! take-up displacements, each joint's response computed with the assembled 12 × 12
//! error system (not the reduction the envelope is built from).

mod common;

use clearance_kinematics::{Geometry, Posture, inverse_kinematics};
use clearance_model::{JobSpec, KINDS, Mode};
use clearance_solver::error_system::{assemble, errors_from};
use clearance_solver::{DOMINANT_TIE, LuSolver, Model, PoseResult, Status, TakeUp, Workspace, solve_pose};
use faer::Mat;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `[Δp; Δα]` for one joint's displacement `d` (kind `k`, limb `j`), the others rigid.
fn response(geom: &Geometry, pose: &Posture, k: usize, j: usize, d: Vector3<f64>) -> [f64; 6] {
    let mut take = TakeUp::default();
    match k {
        0 => take.s[j] = d,
        1 => take.r_radial[j] = d,
        2 => take.r_axial[j] = d,
        _ => take.r_angular[j] = d,
    }
    let (mut jp, mut dq) = (Mat::zeros(12, 12), Mat::zeros(12, 4));
    assemble(pose, &geom.y, &take, jp.as_mut(), dq.as_mut());
    assert!(LuSolver::new(12, 4).solve(jp.as_ref(), dq.as_mut()));
    let e = errors_from(geom, pose, &take, &dq)[k];
    [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z]
}

/// Each joint's admissible displacements, sampled: the ball's surface, the circle
/// `⟂ y_j`, the segment's ends along `y_j` (the maxima of a linear map lie on them).
fn samples(geom: &Geometry, k: usize, j: usize, size: f64) -> Vec<Vector3<f64>> {
    let y = geom.y[j];
    let (a, b) = (geom.x[j], Vector3::z());
    match k {
        0 => common::sphere(20_000).into_iter().map(|u| size * u).collect(),
        2 => vec![size * y, -size * y],
        _ => (0..4000)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / 4000.0;
                size * (t.cos() * a + t.sin() * b)
            })
            .collect(),
    }
}

fn check_pose(model: &Model, pose: &Posture, r: &PoseResult) -> usize {
    let clearance = model.clearance;
    let mut compared = 0;
    for (k, &size) in clearance.iter().enumerate() {
        // The brute-force maximum of each component, |Δp| and |Δα|, summed over limbs.
        let mut brute = [0.0f64; 8];
        for j in 0..3 {
            let mut best = [0.0f64; 8];
            for d in samples(&model.geometry, k, j, size) {
                let e = response(&model.geometry, pose, k, j, d);
                for c in 0..6 {
                    best[c] = best[c].max(e[c].abs());
                }
                best[6] = best[6].max((e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt());
                best[7] = best[7].max((e[3] * e[3] + e[4] * e[4] + e[5] * e[5]).sqrt());
            }
            for c in 0..8 {
                brute[c] += best[c];
            }
        }
        let env = r.envelope[k];
        let scale = env.iter().fold(0.0f64, |m, v| m.max(*v));
        for c in 0..8 {
            // Sampling can only fall short: by (1 − cos) of the spacing, 3e-4 on the
            // 20 000-point sphere, 1e-6 on the 4000-point circle.
            assert!(brute[c] <= env[c] + 1e-12 * scale, "kind {k}, component {c}: sampled {} > {}", brute[c], env[c]);
            assert!(
                brute[c] >= env[c] * (1.0 - 5e-4) - 1e-12 * scale,
                "kind {k}, component {c}: {} vs {}",
                brute[c],
                env[c]
            );
        }
        // The deterministic error is one admissible take-up: inside the envelope.
        let e = &r.errors[k];
        let det = [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z, e.dp.norm(), e.dalpha.norm()];
        for c in 0..8 {
            assert!(det[c].abs() <= env[c] * (1.0 + 1e-12) + 1e-15 * scale, "kind {k}, component {c} outside");
        }
        compared += 1;
    }
    // And all kinds together.
    let total = r.envelope_total();
    let t = &r.total;
    let det = [t.dp.x, t.dp.y, t.dp.z, t.dalpha.x, t.dalpha.y, t.dalpha.z, t.dp.norm(), t.dalpha.norm()];
    for c in 0..8 {
        assert!(det[c].abs() <= total[c] * (1.0 + 1e-12), "total, component {c} outside");
    }
    // The dominant joint's contribution is the largest up to the tie tolerance, and
    // every joint before it in kind, then limb order is smaller than that.
    assert_eq!(r.dominant, r.dominant_of(&clearance));
    if let Some((k, j)) = r.dominant {
        let max = r.contribution.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        let tie = max * (1.0 - DOMINANT_TIE);
        assert!(r.contribution[k][j] >= tie);
        for before in (0..k * 3 + j).map(|i| r.contribution[i / 3][i % 3]) {
            assert!(before < tie, "{before} ties with {max} but was passed over");
        }
    }
    compared
}

/// With the paper's Fig. 6 clearances (`a = 1e-4 m`, `θ = 1e-4 rad`) and legs of 1 m,
/// a limb's axial and angular take-ups move `A_j` alike: equal contributions, which
/// round-off must not split. Ties go to `r_axial`, at every pose.
#[test]
fn axial_and_angular_tie_goes_to_axial() {
    let job = JobSpec::from_toml_str(
        "[clearance]\nr_axial = 1e-4\nr_angular = 1e-4\n[grid]\nz = 2.05\n\
         psi = { start = -0.5, stop = 0.5, n = 41 }\ntheta = { start = -0.5, stop = 0.5, n = 41 }\n",
        "tie.toml",
    )
    .unwrap();
    let mut model = Model::from_job(&job);
    model.envelope = true;
    let source = clearance_grid::SampleSource::new(&job);
    let mut ws = Workspace::new();
    let (mut axial, mut close) = (0, 0);
    for i in 0..source.len() {
        let r = solve_pose(&model, &source.sample(i), Mode::Kinetostatic, &mut ws);
        let Some((k, j)) = r.dominant else { continue };
        let (a, t) = (r.contribution[2][j], r.contribution[3][j]);
        // The two are equal to round-off, not by a margin the rule could see.
        close += usize::from((a - t).abs() <= 1e-12 * a);
        assert_eq!(KINDS[k].name(), "r_axial", "sample {i}: axial {a}, angular {t}");
        axial += 1;
    }
    assert!(axial > 1500 && close == axial, "{axial} ok poses, {close} with equal contributions");
}

#[test]
fn envelope_is_the_worst_case_and_holds_the_error() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let mut ws = Workspace::new();
    let mut compared = 0;
    for case in 0..=common::FAMILY.len() {
        for _ in 0..2 {
            let clearance = [
                rng.random_range(1e-5..1e-3),
                rng.random_range(1e-5..1e-3),
                rng.random_range(1e-5..1e-3),
                rng.random_range(1e-5..1e-3),
            ];
            let (job, z) = if case == common::FAMILY.len() {
                (common::grid_job(&mut rng, clearance), 2.0)
            } else {
                common::family_job(&mut rng, case, clearance)
            };
            let mut model = Model::from_job(&job);
            model.envelope = true;
            let (zz, psi, theta) =
                (z + rng.random_range(-0.05..0.05), rng.random_range(-0.3..0.3), rng.random_range(-0.3..0.3));
            let r = solve_pose(&model, &common::static_sample(zz, psi, theta), Mode::Kinetostatic, &mut ws);
            if r.status != Status::Ok {
                continue;
            }
            let pose = inverse_kinematics(&model.geometry, zz, psi, theta).unwrap();
            compared += check_pose(&model, &pose, &r);
        }
    }
    assert!(compared >= 40, "{compared}");
}
