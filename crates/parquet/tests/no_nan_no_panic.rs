//! Property: random valid jobs and random poses, far outside the workspace too,
//! never panic and never put NaN or infinity into the output; a value that cannot be
//! computed is null and the status says why.

use arrow::array::{Array, Float64Array, StringArray};
use clearance_grid::Sample;
use clearance_model::{JobSpec, Mode};
use clearance_parquet::{ColumnSet, PoseSchema};
use clearance_solver::{Model, Workspace, solve_pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn wild(rng: &mut ChaCha8Rng, scale: f64) -> f64 {
    match rng.random_range(0..10) {
        0 => 0.0,
        1 => scale * 1e3 * rng.random_range(-1.0..1.0),
        2 => std::f64::consts::FRAC_PI_2 * if rng.random_bool(0.5) { 1.0 } else { -1.0 },
        _ => scale * rng.random_range(-1.0..1.0),
    }
}

fn random_job(rng: &mut ChaCha8Rng) -> JobSpec {
    let small =
        |rng: &mut ChaCha8Rng| if rng.random_bool(0.2) { 0.0 } else { 10f64.powf(rng.random_range(-7.0..-2.0)) };
    let text = format!(
        "[mechanism]\nbase_radius = {}\nplatform_radius = {}\nleg_length = {}\ngravity = [{}, {}, {}]\n\
         [mass]\nplatform = {}\nleg = {}\npoints = [{{ mass = {}, at = [{}, {}, {}] }}]\n\
         [load]\nforce = [{}, {}, {}]\nmoment = [{}, {}, {}]\nat = [{}, {}, {}]\n\
         [clearance]\ns_radial = {}\nr_radial = {}\nr_axial = {}\nr_angular = {}\n\
         [analysis]\nexact = {}\nsingular_cond = {}\nmodes = [\"kinetostatic\", \"dynamic\"]\n\
         [trajectory]\ntime = 0.0\nz = 0.0\npsi = 0.0\ntheta = 0.0\n",
        rng.random_range(0.001..2.0),
        rng.random_range(0.001..2.0),
        rng.random_range(0.001..3.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(-20.0..20.0),
        rng.random_range(0.0..100.0),
        if rng.random_bool(0.2) { 0.0 } else { rng.random_range(0.0..10.0) },
        rng.random_range(0.0..50.0),
        rng.random_range(-2.0..2.0),
        rng.random_range(-2.0..2.0),
        rng.random_range(-2.0..2.0),
        rng.random_range(-500.0..500.0),
        rng.random_range(-500.0..500.0),
        rng.random_range(-500.0..500.0),
        rng.random_range(-50.0..50.0),
        rng.random_range(-50.0..50.0),
        rng.random_range(-50.0..50.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        small(rng),
        small(rng),
        small(rng),
        small(rng),
        rng.random_bool(0.5),
        10f64.powf(rng.random_range(0.5..9.0)),
    );
    // Every other job is mirror-symmetric about limb 1's plane (no side loads, masses
    // on the axis), where Ψ = 0 makes limb 1's axial load vanish: indeterminate contact.
    let text = if rng.random_bool(0.5) {
        let mut job: toml::Table = toml::from_str(&text).unwrap();
        job["mechanism"]["gravity"] = toml::Value::try_from([0.0, 0.0, -9.81]).unwrap();
        job.remove("load");
        job["mass"]["points"][0]["at"] = toml::Value::try_from([0.0, 0.0, 1.0]).unwrap();
        toml::to_string(&job).unwrap()
    } else {
        text
    };
    JobSpec::from_toml_str(&text, "random.toml").unwrap()
}

#[test]
fn random_jobs_and_poses_never_panic_or_write_nan() {
    let mut rng = ChaCha8Rng::seed_from_u64(66);
    let mut ws = Workspace::new();
    let mut statuses = std::collections::BTreeSet::new();
    for _ in 0..300 {
        let job = random_job(&mut rng);
        let mut model = Model::from_job(&job);
        model.envelope = true;
        let schema = PoseSchema::new(ColumnSet::Full, job.analysis.exact);
        for mode in [Mode::Kinetostatic, Mode::Dynamic] {
            let rows: Vec<_> = (0..40)
                .map(|i| {
                    let s = Sample {
                        index: i,
                        t: Some(i as f64),
                        z: [wild(&mut rng, 5.0), wild(&mut rng, 10.0), wild(&mut rng, 100.0)],
                        psi: [wild(&mut rng, 3.0), wild(&mut rng, 10.0), wild(&mut rng, 100.0)],
                        theta: [wild(&mut rng, 3.0), wild(&mut rng, 10.0), wild(&mut rng, 100.0)],
                    };
                    (s, solve_pose(&model, &s, mode, &mut ws))
                })
                .collect();
            let batch = schema.batch(mode, &rows);
            let status = batch.column_by_name("status").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
            for i in 0..batch.num_rows() {
                statuses.insert(status.value(i).to_string());
            }
            for (field, col) in batch.schema().fields().iter().zip(batch.columns()) {
                if let Some(f) = col.as_any().downcast_ref::<Float64Array>() {
                    for v in f.iter().flatten() {
                        assert!(v.is_finite(), "{} = {v}", field.name());
                    }
                }
            }
        }
    }
    // The property was exercised on every status.
    assert_eq!(statuses.len(), 4, "{statuses:?}");
}
