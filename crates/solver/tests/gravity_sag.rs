//! docs/model.md §5: under gravity alone the platform sags (ΔZ < 0). At the home pose
//! the sag follows from geometry alone: by symmetry the platform only translates,
//! by (0, 0, −δ); each vertex is its leg tip (which can only turn about y_j, so it
//! moves along n_j ⟂ e_j) plus the take-up −s·f̂_j. Projecting on e_j gives
//! δ = s·(f̂_j·e_j)/e_j,z, a little more than s because the legs lean.

mod common;

use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Status, Workspace, solve_pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn dead_weight_sags_the_platform() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let s = 1e-4;
    for kind in ["s_radial", "r_radial"] {
        let job = JobSpec::from_toml_str(
            &format!("[clearance]\n{kind} = {s}\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n"),
            "sag.toml",
        )
        .unwrap();
        let model = Model::from_job(&job);
        let mut ws = Workspace::new();
        for _ in 0..200 {
            let sample = common::static_sample(
                rng.random_range(1.9..2.2),
                rng.random_range(-0.5..0.5),
                rng.random_range(-0.5..0.5),
            );
            let r = solve_pose(&model, &sample, Mode::Kinetostatic, &mut ws);
            assert_eq!(r.status, Status::Ok);
            // Legs lean at most ~30° here, so the sag stays within 1.2·s.
            assert!(r.total.dp.z < 0.0 && r.total.dp.z >= -1.2 * s, "{kind}: ΔZ = {}", r.total.dp.z);
        }
    }
}

#[test]
fn home_pose_sag_is_the_vertical_take_up() {
    let s = 1e-4;
    let job = JobSpec::from_toml_str(
        &format!("[clearance]\ns_radial = {s}\n[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n"),
        "home.toml",
    )
    .unwrap();
    let model = Model::from_job(&job);
    let geom = &model.geometry;
    let r = solve_pose(&model, &common::static_sample(2.05, 0.0, 0.0), Mode::Kinetostatic, &mut Workspace::new());
    let pose = clearance_kinematics::inverse_kinematics(geom, 2.05, 0.0, 0.0).unwrap();
    for j in 0..3 {
        let f = r.reactions.f_s[j].normalize();
        assert!(f.dot(&geom.y[j]).abs() < 1e-14, "home-pose loads stay in the limb planes");
        let delta = s * f.dot(&pose.e[j]) / pose.e[j].z;
        assert!((r.total.dp.z + delta).abs() < 1e-15, "ΔZ = {} vs −{delta}", r.total.dp.z);
    }
    assert!(r.total.dp.xy().norm() < 1e-18 && r.total.dalpha.norm() < 1e-15);
}
