//! docs/model.md §9: the linear error equals the exact error to second order as the
//! clearances shrink: `|exact − linear| ≤ K·c²`, so the relative difference falls
//! tenfold per decade of clearance.

mod common;

use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Status, Workspace, solve_pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn difference(job_text: &str, c: f64, sample: &clearance_grid::Sample) -> Option<(f64, f64)> {
    let text = job_text.replace("CLR", &format!("{c:e}"));
    difference_of(&JobSpec::from_toml_str(&text, "j.toml").unwrap(), sample)
}

/// `(max |exact − linear|, max |linear|)` over the six components, for an `ok` pose.
fn difference_of(job: &JobSpec, sample: &clearance_grid::Sample) -> Option<(f64, f64)> {
    let model = Model::from_job(job);
    let r = solve_pose(&model, sample, Mode::Kinetostatic, &mut Workspace::new());
    if r.status != Status::Ok {
        return None;
    }
    let e = r.exact.expect("exact error converges");
    let lin = [r.total.dalpha.x, r.total.dalpha.y, r.total.dalpha.z, r.total.dp.x, r.total.dp.y, r.total.dp.z];
    let diff = e.iter().zip(lin).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let size = lin.iter().map(|v| v.abs()).fold(0.0, f64::max);
    Some((diff, size))
}

#[test]
fn exact_and_linear_agree_to_second_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let mut checked = 0;
    for _ in 0..30 {
        let base = common::random_job_toml(
            &mut rng,
            [0.0; 4],
            "[analysis]\nexact = true\n[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n",
        );
        // All four kinds at the common scale c.
        let text = ["s_radial", "r_radial", "r_axial", "r_angular"]
            .iter()
            .fold(base, |t, k| t.replace(&format!("{k} = 0\n"), &format!("{k} = CLR\n")));
        assert_eq!(text.matches("CLR").count(), 4);
        let sample =
            common::static_sample(rng.random_range(1.9..2.2), rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4));
        let Some((d3, s3)) = difference(&text, 1e-3, &sample) else {
            continue;
        };
        let (d4, s4) = difference(&text, 1e-4, &sample).unwrap();
        let (d5, s5) = difference(&text, 1e-5, &sample).unwrap();
        // The linear error scales with c.
        assert!((s3 / s4 - 10.0).abs() < 1e-6 && (s4 / s5 - 10.0).abs() < 1e-6, "linear error is linear");
        // Second order: the gap shrinks ~100× per decade (allow 60–140×).
        for (a, b) in [(d3, d4), (d4, d5)] {
            let ratio = a / b;
            assert!((60.0..140.0).contains(&ratio), "gap ratio {ratio} ({a:e} → {b:e})");
        }
        // And it is small: relative gap of the order of clearance / mechanism size.
        assert!(d4 / s4 < 20.0 * 1e-4, "relative gap {} at c = 1e-4", d4 / s4);
        checked += 1;
    }
    assert!(checked >= 20, "only {checked} random poses were ok");
}

/// The same across the family: inclined and horizontal rails, uneven limbs, and the
/// 3-RPS, whose locked legs keep their nominal length in the exact closure.
#[test]
fn exact_and_linear_agree_to_second_order_across_the_family() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let mut checked = 0;
    for case in 0..common::FAMILY.len() {
        for _ in 0..6 {
            let (mut job, z) = common::family_job(&mut rng, case, [0.0; 4]);
            job.analysis.exact = true;
            let sample = common::static_sample(
                z + rng.random_range(-0.05..0.05),
                rng.random_range(-0.25..0.25),
                rng.random_range(-0.25..0.25),
            );
            let at = |job: &mut JobSpec, c: f64| {
                (job.clearance.s_radial, job.clearance.r_radial, job.clearance.r_axial, job.clearance.r_angular) =
                    (c, c, c, c);
                difference_of(job, &sample)
            };
            let Some((d3, s3)) = at(&mut job, 1e-3) else { continue };
            let (d4, s4) = at(&mut job, 1e-4).unwrap();
            let (d5, s5) = at(&mut job, 1e-5).unwrap();
            assert!(
                (s3 / s4 - 10.0).abs() < 1e-6 && (s4 / s5 - 10.0).abs() < 1e-6,
                "case {case}: linear error is linear"
            );
            for (a, b) in [(d3, d4), (d4, d5)] {
                let ratio = a / b;
                assert!((60.0..140.0).contains(&ratio), "case {case}: gap ratio {ratio} ({a:e} → {b:e})");
            }
            checked += 1;
        }
    }
    assert!(checked >= 25, "only {checked} random poses were ok");
}
