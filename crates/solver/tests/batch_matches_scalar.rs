//! The batched kinetostatic kernel (eight poses per call, SIMD) gives every pose the
//! same bits as `solve_pose` on that pose alone, whatever the batch around it, its
//! length, and the instruction set: statuses, reactions, margins, errors, condition
//! numbers and exact errors alike.

mod common;

use clearance_grid::Sample;
use clearance_kinematics::Geometry;
use clearance_model::Mode;
use clearance_solver::fast::Pose;
use clearance_solver::{
    Isa, Model, PoseResult, Workspace, solve_batches, solve_pose, solve_poses, solve_poses_posed,
    solve_reactions_if_solvable, solve_reactions_posed,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Every field, floats by their shortest round-trip form: equal strings are equal
/// bits (NaN aside, whose payload is not a result).
fn bits(r: &PoseResult) -> String {
    format!("{r:?}")
}

/// `n` kinetostatic samples: Z within `dz` of `z`, Ψ and Θ within `angle` of zero.
fn samples_near(rng: &mut impl Rng, n: usize, z: f64, dz: f64, angle: f64) -> Vec<Sample> {
    (0..n)
        .map(|_| {
            common::static_sample(
                z + rng.random_range(-dz..dz),
                rng.random_range(-angle..angle),
                rng.random_range(-angle..angle),
            )
        })
        .collect()
}

#[test]
fn batches_give_each_pose_its_scalar_bits() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut ws = Workspace::new();
    let isas = Isa::available();
    let mut seen = [0usize; 4];
    for case in 0..60 {
        // Some kinds rigid, so their per-kind errors are exactly zero.
        let clearance = [0, 1, 2, 3].map(|_| if rng.random_bool(0.2) { 0.0 } else { rng.random_range(1e-5..1e-3) });
        let job = common::grid_job(&mut rng, clearance);
        let mut model = Model::from_job(&job);
        model.exact = case % 3 == 0;
        // Tight thresholds, so that near-singular and indeterminate poses occur.
        model.singular_cond = rng.random_range(20.0..400.0);
        model.indeterminate_floor = model.weight * rng.random_range(0.0..0.1);
        if case % 4 == 1 {
            // Legs short enough that tilted poses cannot be reached.
            let g = &model.geometry;
            model.geometry = Geometry::new(g.base_radius, g.platform_radius, rng.random_range(0.15..0.3));
        }
        let n = rng.random_range(1..40);
        let samples: Vec<Sample> = (0..n)
            .map(|_| {
                // Cos Ψ = 0 (singular Euler rates) now and then, and heights out of reach.
                let psi = if rng.random_bool(0.05) { std::f64::consts::FRAC_PI_2 } else { rng.random_range(-1.2..1.2) };
                common::static_sample(rng.random_range(1.2..2.6), psi, rng.random_range(-1.2..1.2))
            })
            .collect();
        let scalar: Vec<String> =
            samples.iter().map(|s| bits(&solve_pose(&model, s, Mode::Kinetostatic, &mut ws))).collect();
        for &isa in &isas {
            // From every offset, so each pose sits in several batches and positions.
            for skip in 0..n.min(9) {
                let mut out = vec![PoseResult::default(); n - skip];
                solve_batches(&model, &samples[skip..], &mut out, isa);
                for (i, r) in out.iter().enumerate() {
                    assert_eq!(bits(r), scalar[skip + i], "case {case}, {isa:?}, pose {}", skip + i);
                }
            }
        }
        let mut out = vec![PoseResult::default(); n];
        solve_poses(&model, &samples, Mode::Kinetostatic, &mut ws, &mut out);
        for (r, s) in out.iter().zip(&scalar) {
            assert_eq!(&bits(r), s);
            seen[r.status.index()] += 1;
        }
    }
    // Every status went through the masks, and exact errors were compared.
    assert!(seen.iter().all(|&k| k > 5), "statuses seen: {seen:?}");
}

/// The points the batched kernel gives beside its results (what a described 3-PRS
/// reads of a posture) are, bit for bit, those of the posture computed alone from the
/// sample, in statics and in dynamics (where they are the kinetostatic posture's); the
/// results are `solve_poses`' and the reactions with points `solve_reactions_if_solvable`'s.
#[test]
fn batches_give_each_pose_its_points() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut ws = Workspace::new();
    for case in 0..20 {
        let job = common::grid_job(&mut rng, [1e-4; 4]);
        let model = Model::from_job(&job);
        let n = rng.random_range(1..40);
        let mut samples = samples_near(&mut rng, n, 2.0, 0.4, 0.8);
        let mode = if case % 4 == 3 { Mode::Dynamic } else { Mode::Kinetostatic };
        if mode == Mode::Dynamic {
            for s in &mut samples {
                s.psi[1] = rng.random_range(-1.0..1.0);
                s.theta[2] = rng.random_range(-1.0..1.0);
            }
        }
        let alone = |s: &Sample| Pose::<f64>::new(&model.geometry, s.z[0], s.psi[0], s.theta[0]).points(0);
        let (mut plain, mut posed) = (vec![PoseResult::default(); n], vec![PoseResult::default(); n]);
        let mut points = vec![Default::default(); n];
        solve_poses(&model, &samples, mode, &mut ws, &mut plain);
        solve_poses_posed(&model, &samples, mode, &mut ws, &mut posed, &mut points);
        for (i, s) in samples.iter().enumerate() {
            assert_eq!(bits(&posed[i]), bits(&plain[i]), "case {case}, pose {i}");
            assert_eq!(format!("{:?}", points[i]), format!("{:?}", alone(s)), "case {case}, pose {i}");
            let mut at = None;
            let reactions = solve_reactions_posed(&model, s, mode, &mut ws, &mut at);
            assert_eq!(reactions, solve_reactions_if_solvable(&model, s, mode, &mut ws), "case {case}, pose {i}");
            match (mode, reactions) {
                (Mode::Kinetostatic, Some(_)) => assert_eq!(format!("{:?}", at), format!("{:?}", Some(alone(s)))),
                (Mode::Dynamic, _) => assert!(at.is_none()),
                _ => {}
            }
        }
    }
}

/// The family's layouts (Newton solved lane by lane, stroke limits, legs across
/// their rails) give each pose the same bits in a batch as alone.
#[test]
fn family_batches_give_each_pose_its_scalar_bits() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let mut ws = Workspace::new();
    let mut seen = [0usize; 4];
    for case in 0..common::FAMILY.len() {
        for round in 0..6 {
            let (job, z) = common::family_job(&mut rng, case, [1e-4, 2e-4, 0.0, 3e-4]);
            let mut model = Model::from_job(&job);
            model.exact = round % 2 == 0;
            model.singular_cond = rng.random_range(20.0..400.0);
            let n = rng.random_range(1..30);
            let samples = samples_near(&mut rng, n, z, 0.6, 0.9);
            let scalar: Vec<String> =
                samples.iter().map(|s| bits(&solve_pose(&model, s, Mode::Kinetostatic, &mut ws))).collect();
            for isa in Isa::available() {
                for skip in 0..n.min(9) {
                    let mut out = vec![PoseResult::default(); n - skip];
                    solve_batches(&model, &samples[skip..], &mut out, isa);
                    for (i, r) in out.iter().enumerate() {
                        assert_eq!(bits(r), scalar[skip + i], "case {case}, {isa:?}, pose {}", skip + i);
                        seen[r.status.index()] += usize::from(skip == 0);
                    }
                }
            }
        }
    }
    assert!(seen[0] > 50 && seen[1] > 5 && seen[2] > 5, "statuses seen: {seen:?}");
}

/// The fields that `Model::totals_only` names, of one result.
fn totals(r: &PoseResult) -> String {
    format!(
        "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
        r.status, r.x, r.y, r.phi, r.q, r.kind_ok, r.total, r.cond_a, r.cond_jp, r.dominant
    )
}

/// `Model::totals_only` (the minimal columns in memory) gives the named fields the
/// bits of the whole solve, alone and in batches on every instruction set, and
/// leaves a solvable pose's other fields as they were; with exact errors or the
/// envelope on, it is ignored.
#[test]
fn totals_only_gives_the_totals_bits_and_leaves_the_rest() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let mut ws = Workspace::new();
    let mut seen = [0usize; 4];
    // Left in every slot before solving: a result no pose has.
    let mut stale = PoseResult::default();
    stale.reactions.f_r[1][2] = 12345.0;
    stale.margins.s[0] = -1.0;
    stale.errors[2].dp.x = 7.0;
    stale.exact = Some([9.0; 6]);
    stale.envelope[1][3] = 3.0;
    // The prototype's cases, then each member of the family's.
    for case in 0..40 + 2 * common::FAMILY.len() {
        let clearance = [0, 1, 2, 3].map(|_| if rng.random_bool(0.2) { 0.0 } else { rng.random_range(1e-5..1e-3) });
        let (job, z) = match case.checked_sub(40) {
            None => (common::grid_job(&mut rng, clearance), 1.9),
            Some(member) => common::family_job(&mut rng, member / 2, clearance),
        };
        let mut model = Model::from_job(&job);
        model.singular_cond = rng.random_range(20.0..400.0);
        model.indeterminate_floor = model.weight * rng.random_range(0.0..0.1);
        if case % 4 == 1 && case < 40 {
            let g = &model.geometry;
            model.geometry = Geometry::new(g.base_radius, g.platform_radius, rng.random_range(0.15..0.3));
        }
        // Every fourth case computes exact errors, every fourth the envelope: ignored.
        let (ignored_exact, ignored_envelope) = (case % 4 == 2, case % 4 == 3);
        model.exact = ignored_exact;
        model.envelope = ignored_envelope;
        let n = rng.random_range(1..40);
        let samples = samples_near(&mut rng, n, z, 0.7, 1.2);
        let whole: Vec<PoseResult> =
            samples.iter().map(|s| solve_pose(&model, s, Mode::Kinetostatic, &mut ws)).collect();
        let slim = Model { totals_only: true, ..model.clone() };
        for isa in Isa::available() {
            let mut out = vec![stale; n];
            solve_batches(&slim, &samples, &mut out, isa);
            for (i, (r, w)) in out.iter().zip(&whole).enumerate() {
                let what = format!("case {case}, {isa:?}, pose {i}, {:?}", w.status);
                assert_eq!(totals(r), totals(w), "{what}");
                let solvable =
                    matches!(w.status, clearance_solver::Status::Ok | clearance_solver::Status::IndeterminateContact);
                if ignored_exact || ignored_envelope || !solvable {
                    assert_eq!(bits(r), bits(w), "{what}");
                } else {
                    // The rest is the stale result's: nothing was spent on it.
                    let rest = |r: &PoseResult| {
                        format!("{:?} {:?} {:?} {:?} {:?}", r.reactions, r.margins, r.errors, r.exact, r.envelope)
                    };
                    assert_eq!(rest(r), rest(&stale), "{what}");
                }
                seen[w.status.index()] += 1;
            }
        }
        for (s, w) in samples.iter().zip(&whole) {
            assert_eq!(totals(&solve_pose(&slim, s, Mode::Kinetostatic, &mut ws)), totals(w));
        }
    }
    assert!(seen.iter().all(|&k| k > 5), "statuses seen: {seen:?}");
}
