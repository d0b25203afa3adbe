//! A 6-UPS run (docs/model.md §10.3): the same plan, directory, shards and resume as
//! the 3-limb kinds ([`run`](crate::run())), and the run loop of every mechanism
//! solved as record batches ([`run_units`]), with the six-input samples, the
//! legs-eliminated 6 × 6 solve of [`solve_ups_par`] and the kind's own tables.
//!
//! A unit (variant, mode, chunk) is solved whole on the pool and written as one part
//! file with its statistics beside it. When every unit is in, the discontinuity
//! search (docs/model.md §8) follows every grid line of every swept input, or the
//! trajectory, for the vector loads `f_Si` (`s_radial`) and `f_Ui` (`u_radial`). It
//! reads at samples what the pass solved, where this process computed them and they
//! fit in memory, and solves the rest again (it keeps no traces, so it needs nothing
//! from the parts and a resumed or sharded run finds the same switches). The rule for
//! each load along each path is [`vector_load::path_switches`]: minima refined and
//! polished from the load vectors, directions read where the magnitude has risen back
//! to twice the minimum, located between samples; samples whose load is indeterminate
//! are left out.

use std::time::Instant;

use arrow::record_batch::RecordBatch;
use clearance_discontinuity::vector_load::{self, Reading, SampledLoad, VectorRule};
use clearance_grid::SampleSource;
use clearance_model::{InputSpec, JobSpec, Mode, RangeSpec, SamplesSpec, Variant};
use clearance_parquet::{
    ColumnSet, UPS_INPUTS, UpsRow, UpsSchema, UpsStats, UpsSummaryRow, UpsSwitch, WriteOptions,
    ups_discontinuity_batch, ups_summary_batch, write_parquet,
};
use clearance_solver::Status;
use clearance_solver::ups::{
    UpsLoads, UpsModel, UpsResult, UpsSample, UpsWorkspace, solve_ups_errors, solve_ups_leg_loads, solve_ups_par,
};
use rayon::prelude::*;

use crate::error::EngineError;
use crate::groups::{Group, membership};
use crate::layout::Layout;
use crate::run::{RunOptions, RunReport, StageTimes, Unit, Work, prepare_run, read_merged_stats, unit_complete};
use crate::solve::Poses;
use crate::units::{PartRows, UnitRun, run_units};

type Result<T, E = EngineError> = std::result::Result<T, E>;

/// Samples solved by one worker at a time.
const BLOCK: usize = 64;

/// The samples `range` of a 6-UPS source: their rows (identity and inputs) and the
/// solver's samples (inputs with rates).
fn samples(source: &SampleSource, range: std::ops::Range<u64>) -> (Vec<UpsRow>, Vec<UpsSample>) {
    samples_of(|i| source.sample6(i), range)
}

/// [`samples`] of any source of samples: `sample6(i)` is sample i's time and six inputs
/// with their rates.
fn samples_of(
    sample6: impl Fn(u64) -> (Option<f64>, UpsSample) + Sync,
    range: std::ops::Range<u64>,
) -> (Vec<UpsRow>, Vec<UpsSample>) {
    // On the pool: a unit's samples are some 13 MB, serial time the other cores spent idle.
    let first = range.start;
    (0..(range.end - first) as usize)
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|k| {
            let i = first + k as u64;
            let (t, s) = sample6(i);
            (UpsRow { sample: i, t, inputs: s.map(|v| v[0]) }, s)
        })
        .unzip()
}

/// Solves `rows` of one mode on the current rayon pool, into `out`, a vector of an
/// earlier unit's results (every result is written again): a unit's results are some
/// 80 MB, and fresh memory costs a page fault every 4 KiB.
fn solve_rows(model: &UpsModel, samples: &[UpsSample], mode: Mode, mut out: Vec<UpsResult>) -> Vec<UpsResult> {
    solve_ups_par(model, samples, mode, BLOCK, &mut out);
    out
}

/// The poses of a 6-UPS job as record batches, one per (variant, mode), in memory:
/// a `variant` column, then the columns of a run's part files.
/// `range` (default: every sample) limits each variant to those samples; `poses`, where
/// given (all six coordinates, checked by the caller), replace the job's grid or
/// trajectory.
pub(crate) fn solve_ups(
    job: &JobSpec,
    file: &str,
    columns: ColumnSet,
    range: Option<std::ops::Range<u64>>,
    poses: Option<&Poses>,
) -> Result<Vec<RecordBatch>> {
    let schema = UpsSchema::new(columns, job.analysis.exact);
    let mut out = Vec::new();
    for v in job.variants(file)? {
        let model = UpsModel::from_job(&v.job);
        let (rows, samples) = match poses {
            Some(p) => samples_of(|i| p.sample6(i), range.clone().unwrap_or(0..p.len() as u64)),
            None => {
                let source = SampleSource::new(&v.job);
                samples(&source, range.clone().unwrap_or(0..source.len()))
            }
        };
        for &mode in &v.job.analysis.modes {
            let batch = schema.batch(mode, &rows, &solve_rows(&model, &samples, mode, Vec::new()));
            out.push(crate::solve::with_variant(&batch, v.index));
        }
    }
    Ok(out)
}

/// Runs a 6-UPS `job` into `opts.out` (see [`run`](crate::run())).
pub(crate) fn run_ups(job: &JobSpec, job_file: &str, opts: &RunOptions) -> Result<RunReport> {
    let setup = prepare_run(job, job_file, opts, unit_complete::<UpsStats>)?;
    // Per group, the job it is solved as.
    let models: Vec<(UpsModel, SampleSource)> = setup
        .groups
        .iter()
        .map(|g| {
            let job = g.job(&setup.variants);
            (UpsModel::from_job(&job), SampleSource::new(&job))
        })
        .collect();
    let mut r = UpsRun {
        job,
        variants: &setup.variants,
        groups: &setup.groups,
        models,
        schema: UpsSchema::new(opts.columns, job.analysis.exact),
        known: KnownSamples::default(),
    };
    run_units(&mut r, opts, &setup)
}

/// A 6-UPS run's part in [`run_units`]: a work is its group's samples, solved once and
/// scaled to each member's magnitudes.
struct UpsRun<'a> {
    job: &'a JobSpec,
    variants: &'a [Variant],
    groups: &'a [Group],
    /// Per group, its model and samples.
    models: Vec<(UpsModel, SampleSource)>,
    schema: UpsSchema,
    known: KnownSamples,
}

impl UnitRun for UpsRun<'_> {
    /// The work's rows and their results with the group's magnitudes.
    type Solved = (Vec<UpsRow>, Vec<UpsResult>);
    type Found = Found;

    fn solve(&self, w: &Work, spare: Option<Self::Solved>) -> Self::Solved {
        let u0 = &w.units[0];
        let (model, source) = &self.models[w.group];
        let (rows, samples) = samples(source, u0.range.clone());
        (rows, solve_rows(model, &samples, u0.mode, spare.map(|(_, results)| results).unwrap_or_default()))
    }

    fn solved(&mut self, w: &Work, (_, solved): &Self::Solved) {
        let u0 = &w.units[0];
        self.known.keep(w.group, u0.mode, self.models[w.group].1.len(), u0.range.start, solved);
    }

    fn unit(
        &mut self,
        w: &Work,
        k: usize,
        (rows, solved): &mut Self::Solved,
        poses: bool,
    ) -> (Option<PartRows>, Vec<u8>) {
        let (u, group) = (&w.units[k], &self.groups[w.group]);
        let scaled: Vec<UpsResult>;
        let results = if group.alone() {
            &*solved
        } else {
            let [s0, s1, s2, _] = group.scales[group.member(u.variant)];
            scaled = solved.par_iter().map(|r| r.scaled(&[s0, s1, s2])).collect();
            &scaled
        };
        // The statistics on this thread while the pool builds the columns.
        let (batch, stats) = rayon::join(
            || poses.then(|| PartRows::Batch(self.schema.batch(u.mode, rows, results))),
            || {
                let mut stats = UpsStats::default();
                for r in results {
                    stats.push(r);
                }
                stats.flush();
                stats
            },
        );
        (batch, serde_json::to_vec(&stats).expect("statistics are plain numbers"))
    }

    fn done(&mut self, solved: Self::Solved) -> Option<Self::Solved> {
        Some(solved)
    }

    fn searches(&mut self) -> (Found, f64) {
        searches(self.job, self.variants, self.groups, &self.models, &self.known)
    }

    fn finalize(
        &self,
        layout: &Layout,
        all: &[Unit],
        write_opts: &WriteOptions,
        found: Found,
        stages: &mut StageTimes,
    ) -> Result<()> {
        finalize(layout, self.job, self.variants, self.groups, all, write_opts, &found, stages)
    }
}

/// The switches of each (group, mode), keyed so: every group searched once, with its
/// first member's job and the group's magnitudes; and the seconds it took.
fn searches(
    job: &JobSpec,
    variants: &[Variant],
    groups: &[Group],
    models: &[(UpsModel, SampleSource)],
    known: &KnownSamples,
) -> (Found, f64) {
    let searching = Instant::now();
    let mut found = Found::new();
    for (g, (group, (model, source))) in groups.iter().zip(models).enumerate() {
        let first = &variants[group.first() as usize];
        for &mode in &job.analysis.modes {
            found.insert((g, mode), search(&first.job, group.clearance, model, source, mode, known.get(g, mode)));
        }
    }
    (found, searching.elapsed().as_secs_f64())
}

/// The switches of each (group, mode) ([`searches`]).
type Found = std::collections::HashMap<(usize, Mode), Vec<UpsSwitch>>;

/// The summary and the discontinuities of a run whose units are all written: each
/// group's switches (`found`, [`searches`]; none where a group is missing) scaled to
/// each member.
#[allow(clippy::too_many_arguments)]
fn finalize(
    layout: &Layout,
    job: &JobSpec,
    variants: &[Variant],
    groups: &[Group],
    all: &[Unit],
    write_opts: &WriteOptions,
    found: &Found,
    stages: &mut StageTimes,
) -> Result<()> {
    let mut summary = Vec::new();
    let mut switches = Vec::new();
    let member_of = membership(groups, variants.len());
    for variant in variants {
        let (g, m) = member_of[variant.index as usize];
        let group = &groups[g];
        for &mode in &job.analysis.modes {
            let units: Vec<&Unit> = all.iter().filter(|u| u.variant == variant.index && u.mode == mode).collect();
            let stats = read_merged_stats(layout, &units, UpsStats::default(), UpsStats::merge)?;
            let found = found.get(&(g, mode)).map_or(&[][..], Vec::as_slice);
            // The member's kinds, jumps scaled (`UpsSwitch::kind` is s_radial or u_radial).
            let scale = group.scales[m];
            let found: Vec<UpsSwitch> = found
                .iter()
                .filter(|s| scale[s.kind] != 0.0)
                .map(|s| UpsSwitch { variant: variant.index, jump: s.jump.map(|v| v * scale[s.kind]), ..s.clone() })
                .collect();
            let mut counts = [0u64; 2];
            for s in &found {
                counts[s.kind] += 1;
            }
            switches.extend(found);
            summary.push(UpsSummaryRow {
                variant: variant.index,
                mode: mode.name(),
                params: variant.params.iter().map(|(_, v)| *v).collect(),
                stats,
                switches: counts,
            });
        }
    }
    let writing = Instant::now();
    let batch = ups_discontinuity_batch(&switches);
    write_parquet(&layout.discontinuities(), batch.schema(), &[batch], write_opts, &[])?;
    let names: Vec<String> = job.sweep.iter().map(|s| s.param.clone()).collect();
    let batch = ups_summary_batch(&names, &summary);
    write_parquet(&layout.summary(), batch.schema(), &[batch], write_opts, &[])?;
    stages.writing += writing.elapsed().as_secs_f64();
    Ok(())
}

/// One path of the search: the samples it passes, in order, and any point between.
pub(crate) struct UpsPath {
    /// The input it varies (`t` along a trajectory).
    pub(crate) along: &'static str,
    /// Index of the varying input among the six (`None`: time).
    axis: Option<usize>,
    /// The varying input's range (or the time range).
    range: RangeSpec,
    origin: u64,
    stride: u64,
    pub(crate) len: usize,
}

impl UpsPath {
    pub(crate) fn index(&self, k: usize) -> u64 {
        self.origin + k as u64 * self.stride
    }

    /// The sample at path parameter `p` (in sample steps, `0..len − 1`): time and the
    /// six inputs with their rates.
    pub(crate) fn sample_at(
        &self,
        source: &SampleSource,
        trajectory: Option<&[&InputSpec; 6]>,
        p: f64,
    ) -> (Option<f64>, UpsSample) {
        let value = |r: &RangeSpec| match *r {
            RangeSpec::Value(v) => v,
            RangeSpec::Range { start, stop, n } => {
                if n <= 1 {
                    start
                } else {
                    start + (stop - start) * p / ((n - 1) as f64)
                }
            }
        };
        match (self.axis, trajectory) {
            (None, Some(inputs)) => {
                let t = value(&self.range);
                (Some(t), inputs.map(|i| i.eval(t)))
            }
            (Some(axis), _) => {
                let (_, mut s) = source.sample6(self.origin);
                s[axis] = [value(&self.range), 0.0, 0.0];
                (None, s)
            }
            (None, None) => source.sample6(self.origin),
        }
    }
}

/// Every path of a source: the trajectory, or each grid line of each input with
/// more than one value (docs/model.md §8).
pub(crate) fn ups_paths(job: &JobSpec, source: &SampleSource) -> Vec<UpsPath> {
    match job.samples() {
        SamplesSpec::Trajectory(t) => vec![UpsPath {
            along: "t",
            axis: None,
            range: t.time.clone(),
            origin: 0,
            stride: 1,
            len: source.len() as usize,
        }],
        SamplesSpec::Grid(g) => {
            let axes = g.axes6();
            let lens = axes.map(|r| r.len());
            let mut out = Vec::new();
            for k in 0..6 {
                if lens[k] < 2 {
                    continue;
                }
                let stride: u64 = lens[k + 1..].iter().product();
                let total: u64 = lens.iter().product();
                for origin in 0..total {
                    if (origin / stride).is_multiple_of(lens[k]) {
                        out.push(UpsPath {
                            along: UPS_INPUTS[k],
                            axis: Some(k),
                            range: axes[k].clone(),
                            origin,
                            stride,
                            len: lens[k] as usize,
                        });
                    }
                }
            }
            out
        }
    }
}

/// The loads deciding each kind (0 `s_radial`, 1 `u_radial`) of each limb at one
/// sample, where the pose has reactions: what the search reads of a sample.
type SampleLoads = [[Option<nalgebra::Vector3<f64>>; 6]; 2];

/// The most memory the search's table of every sample's loads may take (384 bytes a
/// sample: about 700 000 samples), and the pass's tables of what it solved (in all).
const SHARED_LOADS_BYTES: u64 = 1 << 28;

/// What the search reads of a sample the pass solved: its loads and each searched
/// kind's error (`s_radial`, `u_radial`), as [`sample_loads`] and [`kind_error`] give them.
#[derive(Clone, Copy, Debug)]
struct Known {
    loads: SampleLoads,
    errors: [Option<[f64; 6]>; 2],
}

/// The samples the pass solved, per (group, mode), kept for the search while they
/// fit in [`SHARED_LOADS_BYTES`] in all: a run that computes every unit reads them
/// instead of solving them again; samples it did not compute (a resumed or
/// sharded run) are solved by the search as before, with the same values.
#[derive(Default)]
struct KnownSamples {
    tables: std::collections::HashMap<(usize, Mode), Vec<Option<Known>>>,
    /// The groups and modes whose table would not fit.
    refused: std::collections::HashSet<(usize, Mode)>,
}

impl KnownSamples {
    fn keep(&mut self, group: usize, mode: Mode, len: u64, first: u64, solved: &[UpsResult]) {
        if self.refused.contains(&(group, mode)) {
            return;
        }
        if !self.tables.contains_key(&(group, mode)) {
            let entry = std::mem::size_of::<Option<Known>>() as u64;
            let held: u64 = self.tables.values().map(|t| t.capacity() as u64 * entry).sum();
            if held.saturating_add(len.saturating_mul(entry)) > SHARED_LOADS_BYTES {
                self.refused.insert((group, mode));
                return;
            }
            // Reserved, not filled: a table is some 500 bytes a sample, and filling it
            // ahead on one thread was a serial stretch of the run (the memory's page
            // faults); each unit's samples are appended on the pool as they come.
            self.tables.insert((group, mode), Vec::with_capacity(len as usize));
        }
        let table = self.tables.get_mut(&(group, mode)).expect("inserted above");
        let (first, end) = (first as usize, first as usize + solved.len());
        let known =
            |r: &UpsResult| Some(Known { loads: sample_loads(r), errors: [kind_error(r, 0), kind_error(r, 1)] });
        if table.len() <= first {
            // Samples before `first` that this run did not compute are unknown.
            table.par_extend(rayon::iter::repeat_n(None, first - table.len()));
            table.par_extend(solved.par_iter().map(known));
        } else {
            if table.len() < end {
                table.par_extend(rayon::iter::repeat_n(None, end - table.len()));
            }
            table[first..end].par_iter_mut().zip(solved).for_each(|(slot, r)| *slot = known(r));
        }
    }

    /// The table of a group and mode: sample i at index i; samples past its end (or
    /// `None` in it) were not computed by this run.
    fn get(&self, group: usize, mode: Mode) -> Option<&[Option<Known>]> {
        self.tables.get(&(group, mode)).map(Vec::as_slice)
    }
}

/// [`sample_loads`] of a sample solved for its loads alone: the same bits as the
/// pass's (the search of a shard solves the samples it did not compute).
fn leg_sample_loads(r: &UpsLoads) -> SampleLoads {
    let ok = loaded(r.status);
    [r.f_s.map(|f| ok.then_some(f)), r.f_u.map(|f| ok.then_some(f))]
}

fn sample_loads(r: &UpsResult) -> SampleLoads {
    std::array::from_fn(|kind| std::array::from_fn(|l| load(r, kind, l)))
}

/// The load deciding kind `kind` (0 `s_radial`, 1 `u_radial`) of limb `l`, and that
/// kind's error `[Δp; Δα]`, where the pose has reactions.
fn load(r: &UpsResult, kind: usize, l: usize) -> Option<nalgebra::Vector3<f64>> {
    loaded(r.status).then(|| if kind == 0 { r.f_s[l] } else { r.f_u[l] })
}

/// Whether a pose of this status has reactions.
fn loaded(status: Status) -> bool {
    matches!(status, Status::Ok | Status::IndeterminateContact)
}

fn kind_error(r: &UpsResult, kind: usize) -> Option<[f64; 6]> {
    let e = &r.errors[kind];
    (loaded(r.status) && r.kind_ok[kind]).then(|| [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z])
}

/// The switches of one (group, mode) with the group's magnitudes (`clearance`, as
/// [`crate::groups::magnitudes`] orders them): every path, in order, on the rayon pool.
fn search(
    job: &JobSpec,
    clearance: [f64; 4],
    model: &UpsModel,
    source: &SampleSource,
    mode: Mode,
    known: Option<&[Option<Known>]>,
) -> Vec<UpsSwitch> {
    let kinds: Vec<usize> = (0..2).filter(|&k| clearance[k] > 0.0).collect();
    if kinds.is_empty() {
        return Vec::new();
    }
    let floor = model.assembly.floor;
    let rule = VectorRule { threshold: job.analysis.discontinuity_load_fraction * model.weight(), floor };
    let trajectory = job.trajectory.as_ref().map(|t| t.inputs6());
    let paths = ups_paths(job, source);
    // Every sample lies on a line of each input that varies: its loads are solved once
    // for all of them where the table fits in memory, else again on each line.
    let n = source.len();
    let mut inputs: Vec<&str> = paths.iter().map(|p| p.along).collect();
    inputs.dedup();
    let fits = n.saturating_mul(std::mem::size_of::<SampleLoads>() as u64) <= SHARED_LOADS_BYTES;
    // What the pass kept of a sample, where it kept it.
    let kept = |i: u64| known.and_then(|k| k.get(i as usize)?.as_ref());
    let complete = known.is_some_and(|k| k.len() as u64 == n && k.iter().all(Option::is_some));
    let shared: Option<Vec<SampleLoads>> = (inputs.len() > 1 && fits && !complete).then(|| {
        (0..n)
            .into_par_iter()
            .map_init(
                || UpsWorkspace::new(model),
                |ws, i| match kept(i) {
                    Some(known) => known.loads,
                    None => leg_sample_loads(&solve_ups_leg_loads(model, &source.sample6(i).1, mode, ws)),
                },
            )
            .collect()
    });
    let found: Vec<Vec<UpsSwitch>> = paths
        .par_iter()
        .map_init(
            || UpsWorkspace::new(model),
            |ws, path| {
                // The loads decide everything but the jumps: the error system is solved
                // only at the two points a switch's jump is read from.
                // Between samples, the legs eliminated in closed form (the same loads
                // to round-off); at samples, the pass's values or the same solve as its.
                let loads_at = |ws: &mut UpsWorkspace, p: f64| {
                    let (_, s) = path.sample_at(source, trajectory.as_ref(), p);
                    solve_ups_leg_loads(model, &s, mode, ws)
                };
                let sample = |k: usize| source.sample6(path.index(k)).1;
                let loads: Vec<SampleLoads> = (0..path.len)
                    .map(|k| match (&shared, kept(path.index(k))) {
                        (Some(all), _) => all[path.index(k) as usize],
                        (None, Some(known)) => known.loads,
                        (None, None) => leg_sample_loads(&solve_ups_leg_loads(model, &sample(k), mode, ws)),
                    })
                    .collect();
                let mut out = Vec::new();
                for &kind in &kinds {
                    for l in 0..6 {
                        let mags: Vec<SampledLoad> = loads.iter().map(|r| r[kind][l].map(|f| (f.norm(), f))).collect();
                        let at = |p: f64| {
                            let r = loads_at(ws, p);
                            let f = if kind == 0 { r.f_s[l] } else { r.f_u[l] };
                            loaded(r.status).then_some([f.x, f.y, f.z])
                        };
                        for found in vector_load::path_switches(&mags, &rule, at) {
                            // The kind's error where each direction was read: the
                            // pass's (or the same solve) at a sample, solved between.
                            let mut error = |r: &Reading| match (r.sample, r.sample.and_then(|k| kept(path.index(k)))) {
                                (_, Some(known)) => known.errors[kind],
                                (Some(k), None) => kind_error(&solve_ups_errors(model, &sample(k), mode, ws), kind),
                                (None, None) => {
                                    let (_, s) = path.sample_at(source, trajectory.as_ref(), r.at);
                                    kind_error(&solve_ups_errors(model, &s, mode, ws), kind)
                                }
                            };
                            let jump = match (error(&found.before), error(&found.after)) {
                                (Some(b), Some(a)) => std::array::from_fn(|i| a[i] - b[i]),
                                _ => [f64::NAN; 6],
                            };
                            let (t, s) = path.sample_at(source, trajectory.as_ref(), found.at);
                            out.push(UpsSwitch {
                                variant: 0, // set per member by `finalize`
                                mode,
                                limb: l + 1,
                                kind,
                                along: path.along,
                                t,
                                coords: s.map(|v| v[0]),
                                margin: found.margin,
                                jump,
                            });
                        }
                    }
                }
                out
            },
        )
        .collect();
    found.into_iter().flatten().collect()
}
