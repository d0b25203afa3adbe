//! `allocate` against independent computations: the optimum of the same convex
//! program found by a dense search over directions (2 kinds), the KKT conditions at
//! the answer from unit errors solved kind by kind, every pose within the budget in a
//! fresh solve at the allocated magnitudes, a budget just under the answer binding at
//! a pose, the shadow price against a finite difference, and the refusals.

use arrow::array::{Array, Float64Array, RecordBatch, StringArray};
use clearance_engine::{AllocModel, AllocateOptions, EngineError, JobSpec, SolveOptions, allocate, solve};

const PAPER: &str = "[mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
    [clearance]\ns_radial = 1e-5\nr_radial = 1e-5\nr_axial = 1e-5\nr_angular = 1e-5\n\
    [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 9 }\ntheta = { start = -0.5, stop = 0.5, n = 9 }\n";

fn job(extra: &str) -> JobSpec {
    JobSpec::from_toml_str(&format!("{PAPER}{extra}"), "job.toml").unwrap()
}

fn col<'a>(b: &'a RecordBatch, name: &str) -> &'a Float64Array {
    b.column_by_name(name).unwrap().as_any().downcast_ref().unwrap()
}

/// The rows the budget holds at: `ok`, or `indeterminate_contact` (the kinds whose
/// take-up is indeterminate count with their envelope there).
fn rows(b: &RecordBatch) -> Vec<usize> {
    let st: &StringArray = b.column_by_name("status").unwrap().as_any().downcast_ref().unwrap();
    (0..b.num_rows()).filter(|&i| matches!(st.value(i), "ok" | "indeterminate_contact")).collect()
}

/// One kind's part of `|Δp|` at a pose: a vector where its take-up is decided, a
/// bound (its envelope) where it is indeterminate.
#[derive(Clone, Copy, Debug)]
enum Part {
    Error([f64; 3]),
    Envelope(f64),
}

/// Kind `k`'s parts at the rows of `b`, divided by `scale`.
fn parts(b: &RecordBatch, k: &str, scale: f64) -> Vec<Part> {
    let e = |c: &str| col(b, &format!("err_{k}_{c}"));
    let (x, y, z, env) = (e("x"), e("y"), e("z"), col(b, &format!("env_{k}_p")));
    rows(b)
        .into_iter()
        .map(|i| match x.is_valid(i) {
            true => Part::Error([x.value(i) / scale, y.value(i) / scale, z.value(i) / scale]),
            false => Part::Envelope(env.value(i) / scale),
        })
        .collect()
}

/// The bounded `|Δp|`: `|Σ errors| + Σ envelopes`, and the summed error vector.
fn bounded(parts: impl IntoIterator<Item = (f64, Part)>) -> (f64, [f64; 3]) {
    let (mut v, mut env) = ([0.0; 3], 0.0);
    for (c, p) in parts {
        match p {
            Part::Error(e) => (0..3).for_each(|i| v[i] += c * e[i]),
            Part::Envelope(b) => env += c * b,
        }
    }
    (norm(v) + env, v)
}

/// Every pose's parts with `kind` alone at magnitude 1 (a solve at 1e-5, scaled).
fn unit_errors(base: &JobSpec, kind: &str) -> Vec<Part> {
    let mut j = base.clone();
    j.allocate = None;
    for k in ["s_radial", "r_radial", "r_axial", "r_angular"] {
        j.clearance.set(k, clearance_model::custom::Magnitude::All(if k == kind { 1e-5 } else { 0.0 }));
    }
    let b = &solve(&j, "job.toml", &SolveOptions::default()).unwrap()[0];
    parts(b, kind, 1e-5)
}

/// The largest bounded `|Δp|` over the poses of `base` at the magnitudes `set`.
fn largest_dp(base: &JobSpec, set: &[(String, clearance_model::custom::Magnitude)]) -> f64 {
    let mut j = base.clone();
    j.allocate = None;
    for (k, m) in set {
        j.clearance.set(k, m.clone());
    }
    let b = &solve(&j, "job.toml", &SolveOptions::default()).unwrap()[0];
    let all: Vec<Vec<Part>> = set.iter().map(|(k, _)| parts(b, k, 1.0)).collect();
    (0..all[0].len()).map(|p| bounded(all.iter().map(|k| (1.0, k[p]))).0).fold(0.0, f64::max)
}

fn norm(e: [f64; 3]) -> f64 {
    (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
}

#[test]
fn two_kinds_match_a_dense_search_over_directions() {
    // r_radial and r_axial allocated, the other two rigid: |c1·e1 + c2·e2| ≤ B.
    let base = job("[allocate]\nkinds = [\"r_radial\", \"r_axial\"]\nweights = { r_radial = 1.0, r_axial = 2.5 }\n");
    let mut rigid = base.clone();
    rigid.clearance.set("s_radial", clearance_model::custom::Magnitude::All(0.0));
    rigid.clearance.set("r_angular", clearance_model::custom::Magnitude::All(0.0));
    let budget = 8e-5;
    let a = allocate(&rigid, "job.toml", &AllocateOptions::new(budget)).unwrap();
    let (e1, e2) = (unit_errors(&rigid, "r_radial"), unit_errors(&rigid, "r_axial"));
    // Along the direction (cos φ, sin φ) the largest feasible step is B / max_p |M_p·d|;
    // the cost there is (w1 / cos φ + w2 / sin φ) / step. Dense in φ, then refined.
    let cost_at = |phi: f64| {
        let d = [phi.cos(), phi.sin()];
        let worst = e1.iter().zip(&e2).map(|(a, b)| bounded([(d[0], *a), (d[1], *b)]).0).fold(0.0, f64::max);
        let step = budget / worst;
        (1.0 / (step * d[0]) + 2.5 / (step * d[1]), step * d[0], step * d[1])
    };
    let n = 20000;
    let mut best = (f64::INFINITY, 0.0);
    for i in 1..n {
        let phi = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
        let c = cost_at(phi).0;
        if c < best.0 {
            best = (c, phi);
        }
    }
    let h = std::f64::consts::FRAC_PI_2 / n as f64;
    let (mut lo, mut hi) = (best.1 - h, best.1 + h);
    for _ in 0..100 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if cost_at(m1).0 < cost_at(m2).0 { hi = m2 } else { lo = m1 }
    }
    let (dense, c1, c2) = cost_at(0.5 * (lo + hi));
    assert!((a.cost - dense).abs() <= 1e-6 * dense, "allocate {} against the dense search {dense}", a.cost);
    let mags: Vec<f64> = a.variables.iter().map(|v| v.magnitude).collect();
    assert!((mags[0] - c1).abs() <= 1e-4 * c1 && (mags[1] - c2).abs() <= 1e-4 * c2, "{mags:?} against {c1}, {c2}");
}

#[test]
fn the_answer_meets_the_kkt_conditions_and_the_budget_everywhere() {
    let base = job("[allocate]\nweights = { s_radial = 1.0, r_radial = 2.0, r_axial = 0.5, r_angular = 1.0 }\n");
    let budget = 1e-4;
    let a = allocate(&base, "job.toml", &AllocateOptions::new(budget)).unwrap();
    // Primal feasibility, in a fresh solve at the allocated magnitudes.
    let largest = largest_dp(&base, &a.clearance);
    assert!(largest <= budget * (1.0 + 1e-9), "largest |Δp| {largest} over the budget {budget}");
    assert!(largest >= budget * (1.0 - 1e-6), "the budget does not bind: {largest}");
    // Stationarity: −w_k / c_k² + Σ_p μ_p ∂|Δp_p|/∂c_k = 0 over the binding poses,
    // μ_p the duals (cost per m), the gradients from unit errors solved kind by kind.
    let kinds = ["s_radial", "r_radial", "r_axial", "r_angular"];
    let unit: Vec<Vec<Part>> = kinds.iter().map(|k| unit_errors(&base, k)).collect();
    // Every sample of this grid is ok or indeterminate_contact: row p is sample p.
    assert_eq!(unit[0].len(), 81);
    let c: Vec<f64> = a.variables.iter().map(|v| v.magnitude).collect();
    let mut grad = [0.0; 4];
    for b in &a.binding {
        let p = b.sample as usize;
        let (size, dp) = bounded((0..4).map(|k| (c[k], unit[k][p])));
        // Complementary slackness: a pose with a multiplier is on the budget.
        assert!((size - budget).abs() <= 1e-7 * budget, "binding pose {p} at {size}");
        for k in 0..4 {
            let d = match unit[k][p] {
                Part::Error(e) => (0..3).map(|i| dp[i] * e[i]).sum::<f64>() / norm(dp),
                Part::Envelope(b) => b,
            };
            grad[k] += b.dual * 1e6 * d;
        }
    }
    for (k, v) in a.variables.iter().enumerate() {
        let cost_grad = v.weight / (v.magnitude * v.magnitude);
        assert!((grad[k] - cost_grad).abs() <= 1e-5 * cost_grad, "{}: {} against {cost_grad}", v.kind, grad[k]);
        assert!(b_positive(&a.binding));
    }
}

fn b_positive(b: &[clearance_engine::Binding]) -> bool {
    !b.is_empty() && b.iter().all(|b| b.dual > 0.0)
}

#[test]
fn a_tighter_budget_binds_and_costs_what_the_shadow_price_says() {
    let base = job("[allocate]\nkinds = [\"s_radial\", \"r_radial\", \"r_axial\"]\nmin = { r_axial = 4e-6 }\n");
    let budget = 1e-4;
    let a = allocate(&base, "job.toml", &AllocateOptions::new(budget)).unwrap();
    let tight = budget * (1.0 - 1e-3);
    let b = allocate(&base, "job.toml", &AllocateOptions::new(tight)).unwrap();
    assert!(b.binding.iter().any(|p| (p.value - tight).abs() <= 1e-7 * tight), "no pose binds at {tight}");
    assert!((b.largest_dp - tight).abs() <= 1e-7 * tight);
    let looser = allocate(&base, "job.toml", &AllocateOptions::new(budget * (1.0 + 1e-3))).unwrap();
    let central = (b.cost - looser.cost) / (2e-3 * budget * 1e6);
    assert!(
        (a.shadow_price_per_um - central).abs() <= 1e-3 * central,
        "shadow price {} against the finite difference {central}",
        a.shadow_price_per_um
    );
}

#[test]
fn the_envelope_model_bounds_the_envelope() {
    let base = job("");
    let budget = 1.5e-4;
    let mut opts = AllocateOptions::new(budget);
    opts.model = AllocModel::Envelope;
    let a = allocate(&base, "job.toml", &opts).unwrap();
    let mut j = base.clone();
    for (k, m) in &a.clearance {
        j.clearance.set(k, m.clone());
    }
    let b = &solve(&j, "job.toml", &SolveOptions::default()).unwrap()[0];
    let env = col(b, "env_p");
    let largest = (0..b.num_rows()).filter(|&i| env.is_valid(i)).map(|i| env.value(i)).fold(0.0, f64::max);
    assert!(largest <= budget * (1.0 + 1e-9) && largest >= budget * (1.0 - 1e-6), "envelope {largest}");
    // Any take-up is one admissible take-up: the take-up answer is cheaper.
    let t = allocate(&base, "job.toml", &AllocateOptions::new(budget)).unwrap();
    assert!(t.cost < a.cost);
}

#[test]
fn impossible_budgets_and_bad_requests_are_refused_with_the_reason() {
    let refuse = |text: &str, opts: &AllocateOptions| match allocate(&job(text), "job.toml", opts) {
        Err(e @ EngineError::Allocation(_)) => {
            assert!(e.is_usage());
            e.to_string()
        }
        other => panic!("not refused: {other:?}"),
    };
    // The kept kinds alone exceed 1 µm.
    let why = refuse("[allocate]\nkinds = [\"r_radial\"]\n", &AllocateOptions::new(1e-6));
    assert!(why.contains("not allocated") && why.contains("s_radial"), "{why}");
    let why = refuse("[allocate]\nkinds = [\"r_radial\"]\nmin = { r_radial = 1e-3 }\n", &AllocateOptions::new(1e-3));
    assert!(why.contains("lower bounds"), "{why}");
    let why = refuse("[[sweep]]\nparam = \"clearance.r_radial\"\nvalues = [1e-5, 2e-5]\n", &AllocateOptions::new(1e-4));
    assert!(why.contains("sweep"), "{why}");
    // A 6-UPS's u_angular moves nothing: no finite magnitude is cheapest. Named, it
    // is refused; chosen by default, it keeps the job's magnitude.
    let ups = "[mechanism]\nkind = \"6-UPS\"\n[clearance]\ns_radial = 1e-5\nu_radial = 1e-5\nu_angular = 1e-5\n\
        [grid]\nx = { start = -0.1, stop = 0.1, n = 3 }\ny = 0.0\nz = 0.7\nphi = 0.0\npsi = 0.0\ntheta = 0.0\n";
    let named = format!("{ups}[allocate]\nkinds = [\"u_radial\", \"u_angular\"]\n");
    let j = JobSpec::from_toml_str(&named, "job.toml").unwrap();
    let why = allocate(&j, "job.toml", &AllocateOptions::new(1e-4)).unwrap_err().to_string();
    assert!(why.contains("u_angular") && why.contains("allocate.max.u_angular"), "{why}");
    let j = JobSpec::from_toml_str(ups, "job.toml").unwrap();
    let a = allocate(&j, "job.toml", &AllocateOptions::new(1e-4)).unwrap();
    assert_eq!(a.idle, ["u_angular"]);
    assert!(a.variables.iter().all(|v| v.kind != "u_angular"));
    assert!(a.fixed.iter().any(|(k, m)| k == "u_angular" && *m == clearance_model::custom::Magnitude::All(1e-5)));
    // Job-file mistakes are the job's errors.
    let bad = JobSpec::from_toml_str(&format!("{PAPER}[allocate]\nkinds = [\"u_radial\"]\n"), "job.toml").unwrap_err();
    assert!(bad.to_string().contains("allocate.kinds.0"), "{bad}");
    let bad = JobSpec::from_toml_str(
        &format!("{PAPER}[allocate]\nmin = {{ r_radial = 2e-5 }}\nmax = {{ r_radial = 1e-5 }}\n"),
        "job.toml",
    )
    .unwrap_err();
    assert!(bad.to_string().contains("allocate.max.r_radial"), "{bad}");
}

#[test]
fn per_limb_magnitudes_of_a_built_in_kind_are_its_descriptions() {
    let base = job("[allocate]\nkinds = [\"r_radial\", \"r_axial\"]\n");
    let budget = 1e-4;
    let shared = allocate(&base, "job.toml", &AllocateOptions::new(budget)).unwrap();
    let mut opts = AllocateOptions::new(budget);
    opts.per_limb = true;
    let each = allocate(&base, "job.toml", &opts).unwrap();
    assert!(each.described && !shared.described);
    assert_eq!(each.variables.len(), 6);
    assert!(each.cost <= 3.0 * shared.cost * (1.0 + 1e-8), "{} against 3 × {}", each.cost, shared.cost);
    // The description at the per-limb answer meets the budget in a fresh solve.
    let mut d = clearance_engine::describe(&base, "job.toml").unwrap();
    d.allocate = None;
    for (k, m) in &each.clearance {
        d.clearance.set(k, m.clone());
    }
    let b = &solve(&d, "job.toml", &SolveOptions::default()).unwrap()[0];
    let all: Vec<Vec<Part>> = each.clearance.iter().map(|(k, _)| parts(b, k, 1.0)).collect();
    let largest = (0..all[0].len()).map(|p| bounded(all.iter().map(|k| (1.0, k[p]))).0).fold(0.0, f64::max);
    assert!(largest <= budget * (1.0 + 1e-9) && largest >= budget * (1.0 - 1e-6), "{largest}");
    // A custom kind given as one number is split over the limbs that have the joint.
    let custom = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml"))
        .unwrap()
        .replace("n = 61", "n = 5")
        + "\n[allocate]\nkinds = [\"knee_radial\", \"s_radial\"]\n";
    let j = JobSpec::from_toml_str(&custom, "job.toml").unwrap();
    let mut opts = AllocateOptions::new(3e-4);
    opts.per_limb = true;
    let a = allocate(&j, "job.toml", &opts).unwrap();
    assert!(!a.described);
    let limbs: Vec<(String, Option<usize>)> = a.variables.iter().map(|v| (v.kind.clone(), v.limb)).collect();
    let expected: Vec<(String, Option<usize>)> =
        ["knee_radial", "s_radial"].iter().flat_map(|k| (0..3).map(move |j| (k.to_string(), Some(j)))).collect();
    assert_eq!(limbs, expected);
    assert!(a.largest_dp <= 3e-4 * (1.0 + 1e-9));
}

#[test]
fn per_limb_magnitudes_of_a_custom_mechanism_meet_the_budget_and_cost_no_more() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml"))
        .unwrap()
        .replace("knee_radial = 5e-5", "knee_radial = [5e-5, 5e-5, 5e-5]")
        .replace("s_radial = 2e-5", "s_radial = [2e-5, 2e-5, 2e-5]")
        .replace("n = 61", "n = 7")
        + "\n[allocate]\nkinds = [\"knee_radial\", \"s_radial\"]\nweights = { s_radial = 2.0 }\n";
    let j = JobSpec::from_toml_str(&text, "job.toml").unwrap();
    let budget = 3e-4;
    let shared = allocate(&j, "job.toml", &AllocateOptions::new(budget)).unwrap();
    let mut opts = AllocateOptions::new(budget);
    opts.per_limb = true;
    let each = allocate(&j, "job.toml", &opts).unwrap();
    assert_eq!(each.variables.len(), 6);
    // Three limbs at the shared magnitudes are one feasible per-limb answer.
    assert!(each.cost <= 3.0 * shared.cost * (1.0 + 1e-8), "{} against 3 × {}", each.cost, shared.cost);
    for a in [&shared, &each] {
        assert!(a.largest_dp <= budget * (1.0 + 1e-9) && a.largest_dp >= budget * (1.0 - 1e-6), "{}", a.largest_dp);
    }
}

/// Weights twelve orders of magnitude apart: every magnitude positive (the first
/// version returned a negative one, inside the solver's tolerance), the budget met
/// and binding, the cost the weights' sum at the answer.
#[test]
fn weights_far_apart_still_give_a_feasible_optimum() {
    let base = job("[allocate]\nkinds = [\"s_radial\", \"r_radial\", \"r_axial\"]\n\
        weights = { s_radial = 1e-6, r_radial = 1e6, r_axial = 1.0 }\n");
    let budget = 1e-4;
    let a = allocate(&base, "job.toml", &AllocateOptions::new(budget)).unwrap();
    assert!(a.variables.iter().all(|v| v.magnitude > 0.0 && v.magnitude.is_finite()), "{:?}", a.variables);
    let cost: f64 = a.variables.iter().map(|v| v.weight / v.magnitude).sum();
    assert!((cost - a.cost).abs() <= 1e-12 * cost);
    let largest = largest_dp(&base, &a.clearance);
    assert!(largest <= budget * (1.0 + 1e-9) && largest >= budget * (1.0 - 1e-6), "{largest}");
    // The expensive kind takes most of the budget.
    let r = a.variables.iter().find(|v| v.kind == "r_radial").unwrap().magnitude;
    assert!(a.variables.iter().all(|v| v.magnitude <= r));
}
