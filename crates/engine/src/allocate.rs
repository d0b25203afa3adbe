//! Clearance allocation (`clearance allocate`): the magnitudes of the chosen
//! clearance kinds that cost least, `Σ_k w_k / c_k`, while the error stays within a
//! budget at every pose of the job (docs/model.md §13).
//!
//! For fixed masses, loads and pose the take-up directions do not depend on the
//! magnitudes, so a pose's error is linear in them: `ΔΓ(p) = f(p) + Σ_k c_k·e_k(p)`,
//! `e_k` the error of kind k at unit magnitude and `f` that of the kinds kept at the
//! job's values. A budget on `|Δp|` is one second-order cone per pose; under the
//! envelope model (any take-up) it is one linear inequality per pose. The cost is
//! convex, so the program has one optimum. It is solved by clarabel (interior
//! point) on an active set of poses: solve on a few, check every pose, add the
//! violated ones, again until none is.
//!
//! The unit errors come from the engine's own in-memory solve (the `err_<kind>_*`
//! and `env_<kind>_*` columns of the standard set) with each allocated kind at the
//! budget's size, so every mechanism kind, every variant and every mode of the job
//! takes the same path. Memory: 4·(1 + 4n) doubles per pose and budget (n the
//! allocated magnitudes), plus one variant's columns while it is solved.

use arrow::array::{Array, Float64Array, RecordBatch, StringArray, UInt64Array};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
use clearance_model::custom::Magnitude;
use clearance_model::{JobSpec, MechanismKind, Mode};
use clearance_parquet::ColumnSet;
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::error::EngineError;
use crate::progress::Reporter;
use crate::solve::{SolveOptions, solve_range};

type Result<T> = std::result::Result<T, EngineError>;

/// Which take-up the budget is met under.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AllocModel {
    /// The loads decide each joint's take-up (the error the engine computes); a
    /// kind whose take-up is indeterminate at a pose counts with its envelope there.
    #[default]
    TakeUp,
    /// Any take-up: the budget bounds the envelope (docs/model.md §11).
    Envelope,
}

impl AllocModel {
    pub fn name(self) -> &'static str {
        match self {
            Self::TakeUp => "takeup",
            Self::Envelope => "envelope",
        }
    }

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "takeup" => Some(Self::TakeUp),
            "envelope" => Some(Self::Envelope),
            _ => None,
        }
    }
}

/// What to allocate for: the budget and the model. Which kinds, their weights and
/// bounds are the job's `[allocate]` table.
#[derive(Clone, Debug)]
pub struct AllocateOptions {
    /// Budget on `|Δp|` at every pose (m).
    pub max_dp: f64,
    /// Budget on `|Δα|` at every pose (rad), if any.
    pub max_dalpha: Option<f64>,
    pub model: AllocModel,
    /// One magnitude per limb of each allocated kind (the job must give the kind as
    /// a list of one value per limb).
    pub per_limb: bool,
    /// Told how far the solves of the job are.
    pub progress: Reporter,
}

impl AllocateOptions {
    pub fn new(max_dp: f64) -> Self {
        Self { max_dp, max_dalpha: None, model: AllocModel::TakeUp, per_limb: false, progress: Reporter::default() }
    }
}

/// One allocated magnitude: a kind, or one limb's joint of a kind with `--per-limb`.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// The `[clearance]` key.
    pub kind: String,
    /// Among the limbs that have the joint, from 0 (`None`: every limb).
    pub limb: Option<usize>,
    pub weight: f64,
    pub min: f64,
    pub max: Option<f64>,
    /// The answer (m or rad).
    pub magnitude: f64,
}

/// A pose where the budget binds at the answer.
#[derive(Clone, Debug, PartialEq)]
pub struct Binding {
    pub variant: u64,
    pub mode: Mode,
    pub sample: u64,
    /// The pose's coordinates (the run's columns `t`, `x` … `theta` that it has).
    pub coords: Vec<(String, f64)>,
    /// `"dp"` or `"dalpha"`: which budget binds.
    pub budget: &'static str,
    /// The bounded quantity there (m or rad): `|Δp|`, with the envelopes of the
    /// kinds that are indeterminate there.
    pub value: f64,
    /// The constraint's multiplier: the cost that one more µm (µrad) of budget at
    /// this pose alone would save.
    pub dual: f64,
}

/// The cheapest magnitudes for a budget, and what certifies them.
#[derive(Clone, Debug)]
pub struct Allocation {
    pub model: AllocModel,
    pub max_dp: f64,
    pub max_dalpha: Option<f64>,
    pub per_limb: bool,
    pub variables: Vec<Variable>,
    /// The kinds not allocated, at the job's magnitudes.
    pub fixed: Vec<(String, Magnitude)>,
    /// Kinds left out of the default choice because they move the platform at no
    /// pose (kept at the job's magnitudes, among `fixed`).
    pub idle: Vec<String>,
    /// `Σ w_k / c_k` over the variables.
    pub cost: f64,
    /// Cost saved by one more µm of `max_dp`.
    pub shadow_price_per_um: f64,
    /// Cost saved by one more µrad of `max_dalpha`.
    pub shadow_price_alpha_per_urad: Option<f64>,
    /// The largest bounded `|Δp|` (and `|Δα|`) over the poses, from a fresh solve of
    /// the job at the allocated magnitudes.
    pub largest_dp: f64,
    pub largest_dalpha: Option<f64>,
    /// Poses constrained (every variant and mode), and poses left out for their
    /// status (not `ok` nor `indeterminate_contact`).
    pub poses: u64,
    pub skipped: u64,
    /// Active-set rounds, and poses in the conic program at the end.
    pub iterations: usize,
    pub cones: usize,
    pub binding: Vec<Binding>,
    /// The whole `[clearance]` table at the answer, in the job's key order.
    pub clearance: Vec<(String, Magnitude)>,
    /// Whether the answer is for the job's description (`clearance describe`): per-limb
    /// magnitudes of a built-in kind, which only a custom mechanism takes.
    pub described: bool,
}

impl Allocation {
    /// The allocated magnitude of each kind: a number, or one per limb.
    pub fn magnitudes(&self) -> Vec<(String, Magnitude)> {
        let mut out: Vec<(String, Magnitude)> = Vec::new();
        for v in &self.variables {
            match (v.limb, out.iter_mut().find(|(k, _)| *k == v.kind)) {
                (Some(_), Some((_, Magnitude::PerLimb(list)))) => list.push(v.magnitude),
                (Some(_), None) => out.push((v.kind.clone(), Magnitude::PerLimb(vec![v.magnitude]))),
                _ => out.push((v.kind.clone(), Magnitude::All(v.magnitude))),
            }
        }
        out
    }

    /// `allocation.toml`: the `[clearance]` table to paste into the job.
    pub fn clearance_toml(&self) -> String {
        let mut s = format!(
            "# clearance allocate: {} model, max_dp = {:e} m{}, cost {:.6e}\n[clearance]\n",
            self.model.name(),
            self.max_dp,
            self.max_dalpha.map(|a| format!(", max_dalpha = {a:e} rad")).unwrap_or_default(),
            self.cost
        );
        for (k, m) in &self.clearance {
            let value = match m {
                Magnitude::All(v) => format!("{v:e}"),
                Magnitude::PerLimb(l) => {
                    format!("[{}]", l.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(", "))
                }
            };
            let note = if self.variables.iter().any(|v| v.kind == *k) { "allocated" } else { "kept" };
            s.push_str(&format!("{k} = {value}   # {note}\n"));
        }
        s
    }

    /// `allocation.json` (docs/interface.md, "clearance allocate").
    pub fn to_json(&self) -> Value {
        let magnitude = |m: &Magnitude| match m {
            Magnitude::All(v) => json!(v),
            Magnitude::PerLimb(l) => json!(l),
        };
        let map =
            |list: &[(String, Magnitude)]| Value::Object(list.iter().map(|(k, m)| (k.clone(), magnitude(m))).collect());
        let mut weights = serde_json::Map::new();
        let (mut min, mut max) = (serde_json::Map::new(), serde_json::Map::new());
        for v in &self.variables {
            weights.insert(v.kind.clone(), json!(v.weight));
            min.insert(v.kind.clone(), json!(v.min));
            max.insert(v.kind.clone(), json!(v.max));
        }
        let binding: Vec<Value> = self
            .binding
            .iter()
            .map(|b| {
                json!({
                    "variant": b.variant,
                    "mode": b.mode.name(),
                    "sample": b.sample,
                    "coords": Value::Object(b.coords.iter().map(|(k, v)| (k.clone(), json!(v))).collect()),
                    "budget": b.budget,
                    "value": b.value,
                    "dual": b.dual,
                })
            })
            .collect();
        json!({
            "model": self.model.name(),
            "max_dp": self.max_dp,
            "max_dalpha": self.max_dalpha,
            "per_limb": self.per_limb,
            "magnitudes": map(&self.magnitudes()),
            "fixed": map(&self.fixed),
            "idle": self.idle,
            "weights": weights,
            "min": min,
            "max": max,
            "cost": self.cost,
            "shadow_price_per_um": self.shadow_price_per_um,
            "shadow_price_alpha_per_urad": self.shadow_price_alpha_per_urad,
            "largest_dp": self.largest_dp,
            "largest_dalpha": self.largest_dalpha,
            "poses": self.poses,
            "skipped": self.skipped,
            "iterations": self.iterations,
            "cones": self.cones,
            "binding": binding,
            "clearance": map(&self.clearance),
            "described": self.described,
        })
    }
}

/// The cheapest magnitudes of the job's `[allocate]` kinds for `opts`' budget.
pub fn allocate(job: &JobSpec, file: &str, opts: &AllocateOptions) -> Result<Allocation> {
    let mut all = allocate_budgets(job, file, opts, &[opts.max_dp])?;
    all.pop().expect("one budget")
}

/// [`allocate`] for each budget on `|Δp|` of `budgets` (the trade-off curve), the
/// job solved once: an infeasible budget is its own error, the others still answer.
/// `opts.max_dp` is ignored.
pub fn allocate_budgets(
    job: &JobSpec,
    file: &str,
    opts: &AllocateOptions,
    budgets: &[f64],
) -> Result<Vec<Result<Allocation>>> {
    for &b in budgets.iter().chain(opts.max_dalpha.as_ref()) {
        if !(b.is_finite() && b > 0.0) {
            return Err(EngineError::Allocation(format!("a budget must be a positive number, got {b:?}")));
        }
    }
    // Per-limb magnitudes: a built-in kind is allocated on the job's description (a
    // custom mechanism whose [clearance] takes lists, giving the same errors); an
    // allocated kind given as one number starts from it on every limb with the joint.
    let described;
    let describe = opts.per_limb && job.mechanism.kind != MechanismKind::Custom;
    let job = if opts.per_limb {
        let mut d = if describe { crate::describe(job, file)? } else { job.clone() };
        let limbs = clearance_model::custom::expand(d.mechanism.limb.as_deref().unwrap_or_default());
        let kinds = clearance_model::custom::all_kinds(&limbs);
        let spec = job.allocate.clone().unwrap_or_default();
        let chosen = if spec.kinds.is_empty() { d.clearance.keys(MechanismKind::Custom) } else { spec.kinds };
        for k in chosen {
            let count = kinds
                .iter()
                .find(|c| c.key == k)
                .map_or(0, |c| clearance_model::custom::limbs_with(&limbs, &c.joint, c.group).len());
            if let (Some(Magnitude::All(v)), true) = (d.clearance.magnitude(&k), count > 0) {
                d.clearance.set(&k, Magnitude::PerLimb(vec![v; count]));
            }
        }
        described = d;
        &described
    } else {
        job
    };
    let mut problem = Problem::new(job, file, opts)?;
    problem.described = describe;
    // Unit errors at the size of the largest budget: magnitudes near the answer's.
    let scale = budgets.iter().copied().fold(0.0, f64::max);
    let mut data = problem.collect(job, file, scale, &opts.progress)?;
    // Kinds chosen by default that move nothing (a 6-UPS's u_angular) keep their
    // magnitudes; named in `allocate.kinds`, they are refused below.
    let idle = problem.idle(&data);
    if problem.defaulted && !idle.is_empty() && idle.len() < problem.vars.len() {
        problem = problem.without(&idle);
        data = problem.collect(job, file, scale, &opts.progress)?;
    }
    problem.check_influence(&data)?;
    Ok(budgets
        .iter()
        .map(|&budget| {
            let solved = problem.optimise(&data, budget)?;
            problem.answer(job, file, &data, budget, solved)
        })
        .collect())
}

/// One solve of the job behind the constraints: the `[clearance]` it sets, and the
/// variables whose unit errors it gives.
type Solve = (Vec<(String, Magnitude)>, Vec<usize>);

/// The variables, the kinds kept, and what each solve of the job sets.
struct Problem {
    model: AllocModel,
    max_dalpha: Option<f64>,
    per_limb: bool,
    vars: Vec<Variable>,
    fixed: Vec<(String, Magnitude)>,
    /// Every `[clearance]` key of the job, in order, with the job's magnitude.
    keys: Vec<(String, Magnitude)>,
    /// Whether the kinds are the default (no `allocate.kinds`).
    defaulted: bool,
    /// Kinds of the default left at the job's magnitudes: they move nothing.
    idle: Vec<String>,
    /// Whether the job is a built-in kind's description (per-limb magnitudes).
    described: bool,
}

/// One pose's constraint for one budget, in units of the solve's scale `S`:
/// `|f + M·x| + lin·x + g ≤ β`, `x = c / S`.
const fn stride(n: usize) -> usize {
    4 + 4 * n
}

/// The poses' constraints, flat: per pose and budget `[f (3), g, M (3 × n, row
/// major), lin (n)]`.
struct Data {
    scale: f64,
    n: usize,
    budgets: usize,
    values: Vec<f64>,
    ids: Vec<(u64, Mode, u64)>,
    /// Each variant's samples (by variant index) and the job's inputs (name, place
    /// among x, y, z, phi, psi, theta): a pose's coordinates, found again when named.
    sources: Vec<clearance_grid::SampleSource>,
    inputs: Vec<(String, usize)>,
    /// Whether the poses' constraints are kept, or only the largest bounded error
    /// of each budget (a check of the answer).
    keep: bool,
    largest: [f64; 2],
    skipped: u64,
}

const SIX: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];
const P_PARTS: [&str; 3] = ["x", "y", "z"];
const A_PARTS: [&str; 3] = ["rx", "ry", "rz"];

impl Data {
    fn row(&self, pose: usize, budget: usize) -> &[f64] {
        let s = stride(self.n);
        let at = (pose * self.budgets + budget) * s;
        &self.values[at..at + s]
    }

    fn len(&self) -> usize {
        self.ids.len()
    }

    /// `|f + M·x| + lin·x + g` of one pose and budget (units of the scale).
    fn value(&self, pose: usize, budget: usize, x: &[f64]) -> f64 {
        let r = self.row(pose, budget);
        let n = self.n;
        let mut v = [r[0], r[1], r[2]];
        for (i, vi) in v.iter_mut().enumerate() {
            for (k, xk) in x.iter().enumerate() {
                *vi += r[4 + i * n + k] * xk;
            }
        }
        let lin: f64 = r[4 + 3 * n..].iter().zip(x).map(|(a, b)| a * b).sum();
        (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() + lin + r[3]
    }
}

/// The conic program's answer on the scale's units.
struct Solved {
    x: Vec<f64>,
    /// Active poses with their budget and dual value (scaled).
    duals: Vec<(usize, usize, f64)>,
    iterations: usize,
    cones: usize,
}

impl Problem {
    fn new(job: &JobSpec, file: &str, opts: &AllocateOptions) -> Result<Self> {
        let kind = job.mechanism.kind;
        let spec = job.allocate.clone().unwrap_or_default();
        let keys: Vec<(String, Magnitude)> = if kind == MechanismKind::Custom {
            job.clearance.given.clone()
        } else {
            kind.clearance_keys()
                .iter()
                .map(|k| (k.to_string(), job.clearance.magnitude(k).expect("a kind's own key")))
                .collect()
        };
        let chosen = if spec.kinds.is_empty() { job.clearance.keys(kind) } else { spec.kinds.clone() };
        if chosen.is_empty() {
            return Err(EngineError::Allocation(format!(
                "{file}: nothing to allocate: [clearance] gives no magnitude and [allocate] names no kinds"
            )));
        }
        for s in &job.sweep {
            if let Some(k) = s.param.strip_prefix("clearance.").filter(|k| chosen.iter().any(|c| c == k)) {
                return Err(EngineError::Allocation(format!(
                    "{file}: a sweep sets clearance.{k}, which allocate chooses; remove that sweep or leave {k} out of \
                     allocate.kinds"
                )));
            }
        }
        let mut vars = Vec::new();
        for k in &chosen {
            let (weight, min, max) = (
                spec.weights.get(k).copied().unwrap_or(1.0),
                spec.min.get(k).copied().unwrap_or(0.0),
                spec.max.get(k).copied(),
            );
            let var = |limb| Variable { kind: k.clone(), limb, weight, min, max, magnitude: f64::NAN };
            if opts.per_limb {
                match keys.iter().find(|(key, _)| key == k).map(|(_, m)| m) {
                    Some(Magnitude::PerLimb(list)) => vars.extend((0..list.len()).map(|j| var(Some(j)))),
                    _ => {
                        let hint = if kind == MechanismKind::Custom {
                            String::new()
                        } else {
                            " (a built-in kind takes one magnitude for every limb: `clearance describe` gives the job as \
                             a custom mechanism, whose [clearance] takes lists)"
                                .into()
                        };
                        return Err(EngineError::Allocation(format!(
                            "{file}: --per-limb needs clearance.{k} as a list of one magnitude per limb{hint}"
                        )));
                    }
                }
            } else {
                vars.push(var(None));
            }
        }
        let fixed = keys.iter().filter(|(k, _)| !chosen.contains(k)).cloned().collect();
        Ok(Self {
            model: opts.model,
            max_dalpha: opts.max_dalpha,
            per_limb: opts.per_limb,
            vars,
            fixed,
            keys,
            defaulted: spec.kinds.is_empty(),
            idle: Vec::new(),
            described: false,
        })
    }

    /// The solves of the job that give the unit errors: each sets its variables to
    /// `scale`, the other allocated ones to zero and the kept kinds to the job's
    /// values; the first also gives the kept kinds' errors.
    fn solves(&self, scale: f64) -> Vec<Solve> {
        let groups: Vec<Vec<usize>> = if self.per_limb {
            (0..self.vars.len()).map(|k| vec![k]).collect()
        } else {
            vec![(0..self.vars.len()).collect()]
        };
        groups
            .into_iter()
            .map(|group| {
                let mut set: Vec<(String, Magnitude)> = self.fixed.clone();
                for (i, v) in self.vars.iter().enumerate() {
                    let on = |k: usize| if group.contains(&k) { scale } else { 0.0 };
                    match v.limb {
                        None => set.push((v.kind.clone(), Magnitude::All(on(i)))),
                        // The kind's first limb gives the whole list.
                        Some(0) => {
                            let list = (i..self.vars.len()).take_while(|&k| self.vars[k].kind == v.kind).map(on);
                            set.push((v.kind.clone(), Magnitude::PerLimb(list.collect())));
                        }
                        Some(_) => {}
                    }
                }
                (set, group)
            })
            .collect()
    }

    /// Every pose's constraints, from solves of every variant of the job.
    fn collect(&self, job: &JobSpec, file: &str, scale: f64, progress: &Reporter) -> Result<Data> {
        let solves = self.solves(scale);
        collect(job, file, self, &solves, scale, progress, CHUNK, true)
    }

    /// Refuses a variable that moves the platform at no pose: with no upper bound,
    /// the cheapest magnitude would be infinite.
    fn check_influence(&self, data: &Data) -> Result<()> {
        if let Some(&k) = self.idle(data).first() {
            let v = &self.vars[k];
            return Err(EngineError::Allocation(format!(
                "{} moves the platform at no pose of the job (its error is zero to round-off), so no finite \
                 magnitude is cheapest: give allocate.max.{} or leave it out of allocate.kinds",
                name(v),
                v.kind
            )));
        }
        if data.len() == 0 {
            return Err(EngineError::Allocation(format!(
                "no pose of the job is ok or indeterminate_contact ({} left out for their status): nothing to \
                 allocate for",
                data.skipped
            )));
        }
        Ok(())
    }

    /// The variables without an upper bound that move the platform at no pose (their
    /// largest error at unit magnitude is zero to round-off against the others').
    fn idle(&self, data: &Data) -> Vec<usize> {
        let n = data.n;
        let mut reach = vec![0.0f64; n];
        for p in 0..data.len() {
            for b in 0..data.budgets {
                let r = data.row(p, b);
                for (k, reach) in reach.iter_mut().enumerate() {
                    let m = (0..3).map(|i| r[4 + i * n + k].powi(2)).sum::<f64>().sqrt() + r[4 + 3 * n + k];
                    *reach = reach.max(m);
                }
            }
        }
        let largest = reach.iter().copied().fold(0.0, f64::max);
        // (A NaN reach counts as none.)
        let none = |r: f64| r.partial_cmp(&(1e-9 * largest)) != Some(std::cmp::Ordering::Greater);
        (0..n).filter(|&k| none(reach[k]) && self.vars[k].max.is_none()).collect()
    }

    /// The problem with the kinds of `idle` variables kept at the job's magnitudes.
    fn without(&self, idle: &[usize]) -> Self {
        let kinds: Vec<&str> = idle.iter().map(|&k| self.vars[k].kind.as_str()).collect();
        let mut out = Self {
            model: self.model,
            max_dalpha: self.max_dalpha,
            per_limb: self.per_limb,
            vars: self.vars.iter().filter(|v| !kinds.contains(&v.kind.as_str())).cloned().collect(),
            fixed: Vec::new(),
            keys: self.keys.clone(),
            defaulted: self.defaulted,
            idle: self.idle.clone(),
            described: self.described,
        };
        out.fixed = self.keys.iter().filter(|(k, _)| !out.vars.iter().any(|v| v.kind == *k)).cloned().collect();
        for k in kinds {
            if !out.idle.iter().any(|i| i == k) {
                out.idle.push(k.to_string());
            }
        }
        out
    }

    /// The budgets of a pose's constraints, on the scale's units.
    fn betas(&self, data: &Data, budget: f64) -> Vec<f64> {
        let mut b = vec![budget / data.scale];
        if let Some(a) = self.max_dalpha {
            b.push(a / data.scale);
        }
        b
    }

    /// The conic program on an active set of poses, grown until no pose is violated.
    fn optimise(&self, data: &Data, budget: f64) -> Result<Solved> {
        let n = data.n;
        let betas = self.betas(data, budget);
        let lo: Vec<f64> = self.vars.iter().map(|v| v.min / data.scale).collect();
        let hi: Vec<Option<f64>> = self.vars.iter().map(|v| v.max.map(|m| m / data.scale)).collect();
        // Start: each variable's most sensitive pose, and the worst at x = 1.
        let mut active: Vec<(usize, usize)> = Vec::new();
        for (b, &beta) in betas.iter().enumerate() {
            for k in 0..n {
                let reach = |p: usize| {
                    let r = data.row(p, b);
                    (0..3).map(|i| r[4 + i * n + k].powi(2)).sum::<f64>().sqrt() + r[4 + 3 * n + k]
                };
                if let Some(p) = argmax(data.len(), reach) {
                    push_unique(&mut active, (p, b));
                }
            }
            for p in top(&ratios(data, b, &vec![1.0; n], beta), 32) {
                push_unique(&mut active, (p, b));
            }
        }
        const TOL: f64 = 1e-8;
        for round in 1..=200 {
            // Solved, then solved again in units of the first answer: the magnitudes
            // (and their costs) may span orders of magnitude that one scale of the
            // variables would leave to the solver's tolerance.
            let (mut status, mut x, mut z) = conic(self, data, &active, &betas, &lo, &hi, &vec![1.0; n]);
            if matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved)
                && x.iter().all(|v| v.is_finite() && *v > 0.0)
            {
                (status, x, z) = conic(self, data, &active, &betas, &lo, &hi, &x);
            }
            match status {
                SolverStatus::Solved | SolverStatus::AlmostSolved => {}
                SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                    return Err(self.infeasible(data, budget, &betas, &lo, &active));
                }
                other => return Err(EngineError::Solver(format!("{other:?} after {round} active-set rounds"))),
            }
            if !x.iter().all(|v| v.is_finite() && *v > 0.0) {
                return Err(EngineError::Solver(format!(
                    "a magnitude came out as {x:?} (in units of the budget): the weights may span too many orders \
                     of magnitude"
                )));
            }
            // Every pose checked at the answer; the most violated join the program.
            let mut violated: Vec<(f64, usize, usize)> = Vec::new();
            for (b, &beta) in betas.iter().enumerate() {
                for (p, r) in ratios(data, b, &x, beta).into_iter().enumerate() {
                    if r > 1.0 + TOL && !active.contains(&(p, b)) {
                        violated.push((r, p, b));
                    }
                }
            }
            if violated.is_empty() {
                let x = polish(data, &betas, &lo, x);
                let duals = active.iter().zip(z).map(|(&(p, b), z)| (p, b, z)).collect();
                return Ok(Solved { x, duals, iterations: round, cones: active.len() });
            }
            violated.sort_by(|a, b| b.0.total_cmp(&a.0));
            for &(_, p, b) in violated.iter().take(128) {
                active.push((p, b));
            }
        }
        Err(EngineError::Solver("the active set did not settle in 200 rounds".into()))
    }

    /// Why no magnitudes meet the budget: the kept kinds alone, the lower bounds, or
    /// else the poses that conflict.
    fn infeasible(
        &self,
        data: &Data,
        budget: f64,
        betas: &[f64],
        lo: &[f64],
        active: &[(usize, usize)],
    ) -> EngineError {
        let worst = |x: &[f64]| {
            let mut w = (0.0, 0, 0);
            for (b, &beta) in betas.iter().enumerate() {
                for p in 0..data.len() {
                    let r = data.value(p, b, x) / beta;
                    if r > w.0 {
                        w = (r, p, b);
                    }
                }
            }
            w
        };
        let what = |b: usize| if b == 0 { "|Δp|" } else { "|Δα|" };
        let limit = |b: usize| {
            if b == 0 {
                format!("max_dp = {budget:e} m")
            } else {
                format!("max_dalpha = {:e} rad", self.max_dalpha.unwrap_or(0.0))
            }
        };
        let (r0, p0, b0) = worst(&vec![0.0; data.n]);
        if r0 > 1.0 {
            let kept: Vec<&str> = self.fixed.iter().map(|(k, _)| k.as_str()).collect();
            return EngineError::Allocation(format!(
                "infeasible budget: the kinds not allocated ({}) alone give {} = {:e} at {}, over {}",
                kept.join(", "),
                what(b0),
                r0 * betas[b0] * data.scale,
                pose_name(data, p0),
                limit(b0)
            ));
        }
        let (r1, p1, b1) = worst(lo);
        if r1 > 1.0 {
            return EngineError::Allocation(format!(
                "infeasible budget: at the lower bounds of allocate.min alone {} = {:e} at {}, over {}",
                what(b1),
                r1 * betas[b1] * data.scale,
                pose_name(data, p1),
                limit(b1)
            ));
        }
        EngineError::Allocation(format!(
            "infeasible budget: no magnitudes within the bounds meet {} at the {} poses of the program together",
            limit(0),
            active.len()
        ))
    }

    /// The answer in the job's units, checked by a solve at the allocated magnitudes.
    fn answer(&self, job: &JobSpec, file: &str, data: &Data, budget: f64, solved: Solved) -> Result<Allocation> {
        let mut vars = self.vars.clone();
        for (v, x) in vars.iter_mut().zip(&solved.x) {
            v.magnitude = x * data.scale;
        }
        let cost = vars.iter().map(|v| v.weight / v.magnitude).sum();
        // d cost / d budget: the duals of the budget rows, on the scale's units.
        let per = 1e-6 / (data.scale * data.scale);
        let price = |budget: usize| solved.duals.iter().filter(|d| d.1 == budget).map(|d| d.2).sum::<f64>() * per;
        let clearance = self.clearance_at(&vars);
        // The check: the job solved at the answer, every kind kept.
        let check = Problem {
            model: self.model,
            max_dalpha: self.max_dalpha,
            per_limb: self.per_limb,
            vars: Vec::new(),
            fixed: clearance.clone(),
            keys: self.keys.clone(),
            defaulted: false,
            idle: Vec::new(),
            described: false,
        };
        let verify = collect(
            job,
            file,
            &check,
            &[(clearance.clone(), Vec::new())],
            data.scale,
            &Reporter::default(),
            CHUNK,
            false,
        )?;
        let largest = |b: usize| verify.largest[b] * verify.scale;
        let largest_dalpha = self.max_dalpha.map(|_| largest(1));
        let betas = self.betas(data, budget);
        let top = solved.duals.iter().map(|d| d.2).fold(0.0, f64::max);
        let mut binding: Vec<Binding> = solved
            .duals
            .iter()
            .filter(|d| d.2 > 1e-7 * top && d.2 > 0.0)
            .map(|&(p, b, z)| Binding {
                variant: data.ids[p].0,
                mode: data.ids[p].1,
                sample: data.ids[p].2,
                coords: coords(data, p),
                budget: if b == 0 { "dp" } else { "dalpha" },
                value: data.value(p, b, &solved.x) * data.scale,
                dual: z * per,
            })
            .collect();
        binding.sort_by(|a, b| b.dual.total_cmp(&a.dual));
        let _ = betas;
        Ok(Allocation {
            model: self.model,
            max_dp: budget,
            max_dalpha: self.max_dalpha,
            per_limb: self.per_limb,
            fixed: self.fixed.clone(),
            idle: self.idle.clone(),
            cost,
            shadow_price_per_um: price(0),
            shadow_price_alpha_per_urad: self.max_dalpha.map(|_| price(1)),
            largest_dp: largest(0),
            largest_dalpha,
            poses: data.len() as u64,
            skipped: data.skipped,
            iterations: solved.iterations,
            cones: solved.cones,
            binding,
            clearance,
            variables: vars,
            described: self.described,
        })
    }

    /// Every `[clearance]` key at the answer: allocated ones at their magnitudes.
    fn clearance_at(&self, vars: &[Variable]) -> Vec<(String, Magnitude)> {
        self.keys
            .iter()
            .map(|(k, m)| {
                let mine: Vec<&Variable> = vars.iter().filter(|v| v.kind == *k).collect();
                let m = match mine.as_slice() {
                    [] => m.clone(),
                    [one] if one.limb.is_none() => Magnitude::All(one.magnitude),
                    many => Magnitude::PerLimb(many.iter().map(|v| v.magnitude).collect()),
                };
                (k.clone(), m)
            })
            .collect()
    }
}

fn name(v: &Variable) -> String {
    match v.limb {
        Some(j) => format!("{} (limb {})", v.kind, j + 1),
        None => v.kind.clone(),
    }
}

fn push_unique(list: &mut Vec<(usize, usize)>, item: (usize, usize)) {
    if !list.contains(&item) {
        list.push(item);
    }
}

fn argmax(n: usize, f: impl Fn(usize) -> f64 + Sync) -> Option<usize> {
    (0..n).into_par_iter().map(|p| (f(p), p)).max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1))).map(|(_, p)| p)
}

/// The indices of the `count` largest of `values`, largest first.
fn top(values: &[f64], count: usize) -> Vec<usize> {
    let mut all: Vec<usize> = (0..values.len()).collect();
    let count = count.min(all.len());
    if count == 0 {
        return Vec::new();
    }
    let by = |a: &usize, b: &usize| values[*b].total_cmp(&values[*a]).then(a.cmp(b));
    all.select_nth_unstable_by(count - 1, by);
    all.truncate(count);
    all.sort_by(by);
    all
}

/// Every pose's bounded error for `budget` at `x`, over the budget's size `beta`:
/// above 1 is over the budget. On the rayon pool.
fn ratios(data: &Data, budget: usize, x: &[f64], beta: f64) -> Vec<f64> {
    (0..data.len()).into_par_iter().map(|p| data.value(p, budget, x) / beta).collect()
}

/// A pose's time (on a trajectory) and inputs.
fn coords(data: &Data, p: usize) -> Vec<(String, f64)> {
    let (variant, _, sample) = data.ids[p];
    let (t, six) = data.sources[variant as usize].sample6(sample);
    t.map(|t| ("t".to_string(), t))
        .into_iter()
        .chain(data.inputs.iter().map(|(k, i)| (k.clone(), six[*i][0])))
        .collect()
}

fn pose_name(data: &Data, p: usize) -> String {
    let (variant, mode, sample) = data.ids[p];
    let c: Vec<String> = coords(data, p).iter().map(|(k, v)| format!("{k} = {}", short(*v))).collect();
    format!("variant {variant} {} sample {sample} ({})", mode.name(), c.join(", "))
}

/// A coordinate for a message: six decimals at most, round-off shown as 0.
pub fn short(v: f64) -> String {
    let s = format!("{:.6}", if v.abs() < 5e-7 { 0.0 } else { v });
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// The magnitudes scaled down (towards the lower bounds) until no pose exceeds its
/// budget: the interior-point answer may overshoot by its tolerance.
fn polish(data: &Data, betas: &[f64], lo: &[f64], x: Vec<f64>) -> Vec<f64> {
    let at = |s: f64| x.iter().zip(lo).map(|(x, lo)| (x * s).max(*lo)).collect::<Vec<_>>();
    let worst = |x: &[f64]| {
        (0..data.budgets).map(|b| ratios(data, b, x, betas[b]).into_iter().fold(0.0, f64::max)).fold(0.0, f64::max)
    };
    let over = worst(&x);
    if over <= 1.0 {
        return x;
    }
    // With no kept kinds and no lower bound every error scales with the magnitudes:
    // 1 / over is the largest scale that fits; otherwise a bisection finds it.
    if worst(&at(1.0 / over)) <= 1.0 {
        let (mut good, mut bad) = (1.0 / over, 1.0);
        for _ in 0..8 {
            let mid = 0.5 * (good + bad);
            if worst(&at(mid)) <= 1.0 { good = mid } else { bad = mid }
        }
        return at(good);
    }
    let (mut good, mut bad) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (good + bad);
        if worst(&at(mid)) <= 1.0 { good = mid } else { bad = mid }
    }
    at(good)
}

/// Solves the program on the `active` poses: variables `[x (n), t (n)]`, minimise
/// `Σ w_k t_k` with `t_k ≥ 1 / x_k` (a second-order cone each). Returns the status,
/// `x` and the dual value of each active pose's budget row.
fn conic(
    problem: &Problem,
    data: &Data,
    active: &[(usize, usize)],
    betas: &[f64],
    lo: &[f64],
    hi: &[Option<f64>],
    unit: &[f64],
) -> (SolverStatus, Vec<f64>, Vec<f64>) {
    let n = data.n;
    // Costs relative to the largest weight; the duals are scaled back at the end.
    let top = problem.vars.iter().map(|v| v.weight).fold(0.0, f64::max);
    let (mut rows, mut cols, mut vals, mut b) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut cones = Vec::new();
    let mut row = 0usize;
    // Column k of the magnitudes is y_k, x_k = unit_k·y_k.
    let mut put = |r: usize, c: usize, v: f64, rows: &mut Vec<usize>| {
        let v = if c < n { v * unit[c] } else { v };
        if v != 0.0 {
            rows.push(r);
            cols.push(c);
            vals.push(v);
        }
    };
    // Bounds: x_k − lo_k ≥ 0 where lo_k > 0, hi_k − x_k ≥ 0.
    let mut nonneg = 0;
    for k in 0..n {
        if lo[k] > 0.0 {
            put(row, k, -1.0, &mut rows);
            b.push(-lo[k]);
            row += 1;
            nonneg += 1;
        }
        if let Some(h) = hi[k] {
            put(row, k, 1.0, &mut rows);
            b.push(h);
            row += 1;
            nonneg += 1;
        }
    }
    let envelope = problem.model == AllocModel::Envelope;
    // Envelope model: β − g − lin·x ≥ 0 per active pose.
    let mut budget_rows = Vec::with_capacity(active.len());
    if envelope {
        for &(p, bud) in active {
            let r = data.row(p, bud);
            for k in 0..n {
                put(row, k, r[4 + 3 * n + k], &mut rows);
            }
            b.push(betas[bud] - r[3]);
            budget_rows.push(row);
            row += 1;
            nonneg += 1;
        }
    }
    if nonneg > 0 {
        cones.push(SupportedConeT::NonnegativeConeT(nonneg));
    }
    // Cost: (t + y, 2√a, t − y) in the second-order cone, i.e. t ≥ a / y with
    // a = w / (top·unit): Σ t = Σ w / x / top.
    for (k, &u) in unit.iter().enumerate() {
        let a = problem.vars[k].weight / (top * u);
        put(row, k, -1.0 / u, &mut rows);
        put(row, n + k, -1.0, &mut rows);
        b.extend([0.0, 2.0 * a.sqrt(), 0.0]);
        put(row + 2, k, 1.0 / u, &mut rows);
        put(row + 2, n + k, -1.0, &mut rows);
        row += 3;
        cones.push(SupportedConeT::SecondOrderConeT(3));
    }
    // Take-up model: (β − g − lin·x, f + M·x) in the second-order cone per pose.
    if !envelope {
        for &(p, bud) in active {
            let r = data.row(p, bud);
            for k in 0..n {
                put(row, k, r[4 + 3 * n + k], &mut rows);
            }
            b.push(betas[bud] - r[3]);
            budget_rows.push(row);
            for i in 0..3 {
                for k in 0..n {
                    put(row + 1 + i, k, -r[4 + i * n + k], &mut rows);
                }
                b.push(r[i]);
            }
            row += 4;
            cones.push(SupportedConeT::SecondOrderConeT(4));
        }
    }
    let a = CscMatrix::new_from_triplets(row, 2 * n, rows, cols, vals);
    let p = CscMatrix::zeros((2 * n, 2 * n));
    let q: Vec<f64> = (0..2 * n).map(|i| if i < n { 0.0 } else { 1.0 }).collect();
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-10)
        .tol_gap_rel(1e-10)
        .tol_feas(1e-10)
        .max_iter(500)
        .build()
        .expect("valid settings");
    let mut solver = match DefaultSolver::new(&p, &q, &a, &b, &cones, settings) {
        Ok(s) => s,
        Err(_) => return (SolverStatus::NumericalError, vec![0.0; n], vec![0.0; active.len()]),
    };
    solver.solve();
    let s = &solver.solution;
    let z = budget_rows.iter().map(|&r| s.z[r] * top).collect();
    (s.status, s.x[..n].iter().zip(unit).map(|(y, u)| y * u).collect(), z)
}

/// The constraints of every pose of every variant and mode: the job solved once
/// per entry of `solves` (its `[clearance]` and the variables it gives), at `scale`,
/// `chunk` samples at a time; `keep`: the constraints, else only the largest errors.
#[allow(clippy::too_many_arguments)]
fn collect(
    job: &JobSpec,
    file: &str,
    problem: &Problem,
    solves: &[Solve],
    scale: f64,
    progress: &Reporter,
    chunk: u64,
    keep: bool,
) -> Result<Data> {
    let n = problem.vars.len();
    let budgets = 1 + problem.max_dalpha.is_some() as usize;
    let variants = job.variants(file)?;
    let progress = progress.get();
    let per = job.sample_count() * job.analysis.modes.len() as u64;
    progress.start(per * variants.len() as u64 * solves.len() as u64, 0);
    let mut done = 0;
    let mut data = Data {
        scale,
        n,
        budgets,
        values: Vec::new(),
        ids: Vec::new(),
        sources: variants.iter().map(|v| clearance_grid::SampleSource::new(&v.job)).collect(),
        inputs: input_names(job).into_iter().filter_map(|k| SIX.iter().position(|s| *s == k).map(|i| (k, i))).collect(),
        keep,
        largest: [0.0; 2],
        skipped: 0,
    };
    // The group's jobs of each variant, solved a chunk of samples at a time: memory
    // holds one chunk's columns, not the job's.
    let samples = job.sample_count();
    for v in &variants {
        progress.stage(&format!("variant {}", v.index));
        let jobs: Vec<JobSpec> = solves
            .iter()
            .map(|(set, _)| {
                let mut vjob = v.job.clone();
                // Its magnitudes are no longer the ones `[allocate]` was checked against.
                vjob.allocate = None;
                for (k, m) in set {
                    vjob.clearance.set(k, m.clone());
                }
                vjob
            })
            .collect();
        for start in (0..samples).step_by(chunk as usize) {
            let chunk = start..(start + chunk).min(samples);
            let opts = SolveOptions { columns: ColumnSet::Standard, ..SolveOptions::default() };
            let solved: Vec<Vec<RecordBatch>> =
                jobs.iter().map(|j| solve_range(j, file, &opts, Some(chunk.clone()))).collect::<Result<_>>()?;
            let poses = (chunk.end - chunk.start) * job.analysis.modes.len() as u64 * jobs.len() as u64;
            done += poses;
            progress.advance(poses, done);
            read_chunk(&mut data, problem, solves, &solved, v.index)?;
        }
    }
    progress.finish();
    Ok(data)
}

/// The job's inputs: a custom mechanism's `inputs`, a built-in kind's.
fn input_names(job: &JobSpec) -> Vec<String> {
    match (&job.mechanism.inputs, job.mechanism.kind) {
        (Some(names), MechanismKind::Custom) => names.clone(),
        (_, kind) => kind.inputs().iter().map(|k| k.to_string()).collect(),
    }
}

/// Samples solved at a time by [`collect`].
const CHUNK: u64 = 1 << 16;

/// The constraints of one chunk's poses (`solved`: per entry of `solves`, a batch per
/// mode) appended to `data`.
fn read_chunk(
    data: &mut Data,
    problem: &Problem,
    solves: &[Solve],
    solved: &[Vec<RecordBatch>],
    variant: u64,
) -> Result<()> {
    let (n, budgets, scale) = (data.n, data.budgets, data.scale);
    let s = stride(n);
    let envelope = problem.model == AllocModel::Envelope;
    for m in 0..solved[0].len() {
        let batches: Vec<&RecordBatch> = solved.iter().map(|s| &s[m]).collect();
        let rows = batches[0].num_rows();
        if rows == 0 {
            continue;
        }
        let mode = match str_col(batches[0], "mode").value(0) {
            "dynamic" => Mode::Dynamic,
            _ => Mode::Kinetostatic,
        };
        let sample = batches[0].column_by_name("sample").and_then(|c| c.as_any().downcast_ref::<UInt64Array>());
        let statuses: Vec<&StringArray> = batches.iter().map(|b| str_col(b, "status")).collect();
        // Each kind's columns, found once per batch: (budget, the kept kinds from the
        // first solve, then each solve's variables with their index).
        let mut kept = Vec::new();
        let mut vars = Vec::new();
        for (parts, env) in [(P_PARTS, "p"), (A_PARTS, "alpha")].into_iter().take(budgets) {
            let cols: Result<Vec<KindColumns>> =
                problem.fixed.iter().map(|(k, _)| KindColumns::of(batches[0], k, &parts, env)).collect();
            kept.push(cols?);
            let mut mine = Vec::new();
            for (batch, (_, group)) in batches.iter().zip(solves) {
                for &k in group {
                    mine.push((k, KindColumns::of(batch, &problem.vars[k].kind, &parts, env)?));
                }
            }
            vars.push(mine);
        }
        let mut row = vec![0.0; s];
        for i in 0..rows {
            if !statuses.iter().all(|st| matches!(st.value(i), "ok" | "indeterminate_contact")) {
                data.skipped += 1;
                continue;
            }
            for budget in 0..budgets {
                row.fill(0.0);
                for cols in &kept[budget] {
                    let (e, lin) = cols.at(i, envelope);
                    for c in 0..3 {
                        row[c] += e[c] / scale;
                    }
                    row[3] += lin / scale;
                }
                for (k, cols) in &vars[budget] {
                    let (e, lin) = cols.at(i, envelope);
                    for c in 0..3 {
                        row[4 + c * n + k] = e[c] / scale;
                    }
                    row[4 + 3 * n + k] = lin / scale;
                }
                if data.keep {
                    data.values.extend_from_slice(&row);
                } else {
                    let v = (row[0] * row[0] + row[1] * row[1] + row[2] * row[2]).sqrt() + row[3];
                    data.largest[budget] = data.largest[budget].max(v);
                }
            }
            if data.keep {
                data.ids.push((variant, mode, sample.map_or(i as u64, |s| s.value(i))));
            }
        }
    }
    Ok(())
}

/// One kind's error columns (`err_<k>_x|y|z` or `_rx|ry|rz`) and envelope column
/// (`env_<k>_p` or `_alpha`) in a batch.
struct KindColumns<'a> {
    err: [&'a Float64Array; 3],
    env: &'a Float64Array,
}

impl<'a> KindColumns<'a> {
    fn of(batch: &'a RecordBatch, k: &str, parts: &[&str; 3], env: &str) -> Result<Self> {
        let get = |name: String| {
            f64_col(batch, &name).ok_or_else(|| {
                EngineError::Allocation(format!(
                    "the job's output has no column {name}: {k} is no clearance kind of it"
                ))
            })
        };
        Ok(Self {
            err: [
                get(format!("err_{k}_{}", parts[0]))?,
                get(format!("err_{k}_{}", parts[1]))?,
                get(format!("err_{k}_{}", parts[2]))?,
            ],
            env: get(format!("env_{k}_{env}"))?,
        })
    }

    /// The error at row `i` and its linear part: under the take-up model the
    /// envelope where the take-up is indeterminate (the error is null there), under
    /// the envelope model always.
    fn at(&self, i: usize, envelope: bool) -> ([f64; 3], f64) {
        let bound = if self.env.is_valid(i) { self.env.value(i) } else { 0.0 };
        if envelope || self.err.iter().any(|c| !c.is_valid(i)) {
            return ([0.0; 3], bound);
        }
        (self.err.map(|c| c.value(i)), 0.0)
    }
}

fn f64_col<'a>(batch: &'a RecordBatch, name: &str) -> Option<&'a Float64Array> {
    batch.column_by_name(name).and_then(|c| c.as_any().downcast_ref::<Float64Array>())
}

fn str_col<'a>(batch: &'a RecordBatch, name: &str) -> &'a StringArray {
    batch.column_by_name(name).and_then(|c| c.as_any().downcast_ref::<StringArray>()).expect("a solve's label column")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job read a few samples at a time gives the constraints of the whole job at
    /// once, pose for pose (a 3-limb grid in two modes' worth of variants, a 6-UPS).
    #[test]
    fn chunks_give_the_constraints_of_the_whole_job() {
        let prs = "[clearance]\ns_radial = 1e-5\nr_radial = 2e-5\nr_axial = 1e-5\n\
            [mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
            [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 7 }\ntheta = { start = -0.5, stop = 0.5, n = 5 }\n\
            [[sweep]]\nparam = \"mass.platform\"\nvalues = [9.8, 30.0]\n\
            [allocate]\nkinds = [\"r_radial\", \"s_radial\"]\n";
        let ups = "[mechanism]\nkind = \"6-UPS\"\n[clearance]\ns_radial = 1e-5\nu_radial = 1e-5\n\
            [grid]\nx = { start = -0.1, stop = 0.1, n = 5 }\ny = { start = -0.1, stop = 0.1, n = 5 }\nz = 0.7\n\
            phi = 0.0\npsi = 0.1\ntheta = 0.0\n";
        for text in [prs, ups] {
            let job = JobSpec::from_toml_str(text, "job.toml").unwrap();
            let mut opts = AllocateOptions::new(1e-4);
            opts.max_dalpha = Some(1e-4);
            let problem = Problem::new(&job, "job.toml", &opts).unwrap();
            let solves = problem.solves(1e-4);
            let go =
                |chunk| collect(&job, "job.toml", &problem, &solves, 1e-4, &Reporter::default(), chunk, true).unwrap();
            let (whole, pieces) = (go(CHUNK), go(4));
            assert!(whole.len() > 20);
            let order = |d: &Data| {
                let mut ids: Vec<usize> = (0..d.len()).collect();
                ids.sort_by_key(|&p| (d.ids[p].0, d.ids[p].1 == Mode::Dynamic, d.ids[p].2));
                ids
            };
            let (a, b) = (order(&whole), order(&pieces));
            assert_eq!(a.len(), b.len());
            for (&p, &q) in a.iter().zip(&b) {
                assert_eq!(whole.ids[p], pieces.ids[q]);
                for budget in 0..2 {
                    assert_eq!(whole.row(p, budget), pieces.row(q, budget));
                }
            }
        }
    }
}
