//! A 6-UPS run (docs/model.md §10.3): the same plan, directory, shards and resume as
//! the 3-limb kinds ([`run`](crate::run())), with the six-input samples, the
//! legs-eliminated 6 × 6 solve of [`solve_ups_par`] and the kind's own tables.
//!
//! A unit (variant, mode, chunk) is solved whole on the pool and written as one part
//! file with its statistics beside it. When every unit is in, the discontinuity
//! search (docs/model.md §8) follows every grid line of every swept input, or the
//! trajectory, for the vector loads `f_Si` (`s_radial`) and `f_Ui` (`u_radial`). It
//! reads at samples what the pass solved, where this process computed them and they
//! fit in memory, and solves the rest again (it keeps no traces, so it needs nothing
//! from the parts and a resumed or sharded run finds the same switches). The rule for
//! each load along each path is [`vector_load::switches`]: minima refined and polished
//! from the load vectors, directions read where the magnitude has risen back to
//! twice the minimum, located between samples.

use std::path::Path;
use std::time::Instant;

use arrow::record_batch::RecordBatch;
use clearance_discontinuity::vector_load::{self, Reading, SampledLoad, VectorRule};
use clearance_grid::SampleSource;
use clearance_model::{InputSpec, JobSpec, Mode, RangeSpec, SamplesSpec, Variant};
use clearance_parquet::{
    ColumnSet, UPS_INPUTS, UpsRow, UpsSchema, UpsStats, UpsSummaryRow, UpsSwitch, WriteOptions,
    ups_discontinuity_batch, ups_summary_batch, write_bytes, write_parquet,
};
use clearance_solver::Status;
use clearance_solver::ups::{
    UpsLoads, UpsModel, UpsResult, UpsSample, UpsWorkspace, solve_ups_errors, solve_ups_leg_loads, solve_ups_par,
};
use rayon::prelude::*;

use crate::error::EngineError;
use crate::groups::{Group, membership};
use crate::layout::Layout;
use crate::run::{
    RunOptions, RunReport, Setup, StageTimes, Unit, mark_shard_done, part_complete, part_metadata, prepare_run,
    sync_units, write_marker,
};

type Result<T, E = EngineError> = std::result::Result<T, E>;

/// Samples solved by one worker at a time.
const BLOCK: usize = 64;

/// The samples `range` of a 6-UPS source: their rows (identity and inputs) and the
/// solver's samples (inputs with rates).
fn samples(source: &SampleSource, range: std::ops::Range<u64>) -> (Vec<UpsRow>, Vec<UpsSample>) {
    // On the pool: a unit's samples are some 13 MB, serial time the other cores spent idle.
    let first = range.start;
    (0..(range.end - first) as usize)
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|k| {
            let i = first + k as u64;
            let (t, s) = source.sample6(i);
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
/// `range` (default: every sample) limits each variant to those samples.
pub(crate) fn solve_ups(
    job: &JobSpec,
    file: &str,
    columns: ColumnSet,
    range: Option<std::ops::Range<u64>>,
) -> Result<Vec<RecordBatch>> {
    let schema = UpsSchema::new(columns, job.analysis.exact);
    let mut out = Vec::new();
    for v in job.variants(file)? {
        let model = UpsModel::from_job(&v.job);
        let source = SampleSource::new(&v.job);
        let (rows, samples) = samples(&source, range.clone().unwrap_or(0..source.len()));
        for &mode in &v.job.analysis.modes {
            let batch = schema.batch(mode, &rows, &solve_rows(&model, &samples, mode, Vec::new()));
            out.push(crate::solve::with_variant(&batch, v.index));
        }
    }
    Ok(out)
}

fn read_stats(path: &Path) -> Result<UpsStats> {
    let text = std::fs::read(path).map_err(|source| EngineError::MissingStats { path: path.to_path_buf(), source })?;
    serde_json::from_slice(&text).map_err(|source| EngineError::Corrupt { path: path.to_path_buf(), source })
}

fn unit_complete(layout: &Layout, u: &Unit, poses: bool) -> bool {
    (!poses || part_complete(&layout.part(u.variant, u.mode, u.chunk)))
        && read_stats(&layout.stats(u.variant, u.mode, u.chunk)).is_ok()
}

/// Runs a 6-UPS `job` into `opts.out` (see [`run`](crate::run())).
pub(crate) fn run_ups(job: &JobSpec, job_file: &str, opts: &RunOptions) -> Result<RunReport> {
    let Setup { variants, groups, layout, mine, all, todo_work, mine_poses, todo_poses, total, write_opts, .. } =
        prepare_run(job, job_file, opts, unit_complete)?;
    let layout = &layout;
    let schema = UpsSchema::new(opts.columns, job.analysis.exact);
    // Per group, the job it is solved as.
    let models: Vec<(UpsModel, SampleSource)> = groups
        .iter()
        .map(|g| {
            let job = g.job(&variants);
            (UpsModel::from_job(&job), SampleSource::new(&job))
        })
        .collect();

    let progress = opts.progress.get();
    progress.start(mine_poses, mine_poses - todo_poses);
    let start = Instant::now();
    let mut done = mine_poses - todo_poses;
    let mut stages = StageTimes::default();
    let mut known = KnownSamples::default();
    // A unit's part file and statistics, written by `write_unit` (which returns its
    // poses and the seconds it took, for `written`): the last unit of each work item
    // is written while the pool solves the next item's poses, so that writing a part,
    // partly serial (the file, its footer), does not leave cores idle.
    struct Written {
        part: std::path::PathBuf,
        stats_path: std::path::PathBuf,
        stats: UpsStats,
        batch: Option<RecordBatch>,
        meta: Vec<(String, String)>,
        poses: u64,
    }
    let write_unit = |w: Written| -> Result<(u64, f64)> {
        let writing = Instant::now();
        for dir in [w.part.parent().filter(|_| w.batch.is_some()), w.stats_path.parent()].into_iter().flatten() {
            std::fs::create_dir_all(dir).map_err(EngineError::io("create", dir))?;
        }
        write_bytes(&w.stats_path, &serde_json::to_vec(&w.stats).expect("statistics are plain numbers"), &write_opts)?;
        if let Some(batch) = &w.batch {
            crate::run::write_part_batch(opts.writer, opts.precision, &w.part, batch, &write_opts, &w.meta)?;
        }
        Ok((w.poses, writing.elapsed().as_secs_f64()))
    };
    let written = |stages: &mut StageTimes, done: &mut u64, (poses, secs): (u64, f64)| {
        stages.writing += secs;
        *done += poses;
        progress.advance(poses, *done);
    };
    let mut pending: Option<Written> = None;
    // The results of the work item before, to solve the next one's into.
    let mut spare: Vec<UpsResult> = Vec::new();
    for w in &todo_work {
        let u0 = &w.units[0];
        progress.stage(&format!("variant {} {}", u0.variant, u0.mode.name()));
        let pose_pass = Instant::now();
        let (group, (model, source)) = (&groups[w.group], &models[w.group]);
        let (rows, samples) = samples(source, u0.range.clone());
        let earlier = pending.take();
        let reused = std::mem::take(&mut spare);
        let (solved, earlier) =
            rayon::join(|| solve_rows(model, &samples, u0.mode, reused), || earlier.map(write_unit));
        if let Some(earlier) = earlier {
            written(&mut stages, &mut done, earlier?);
        }
        known.keep(w.group, u0.mode, source.len(), u0.range.start, &solved);
        stages.pose_pass += pose_pass.elapsed().as_secs_f64();
        for (k, u) in w.units.iter().enumerate() {
            let pose_pass = Instant::now();
            let scaled: Vec<UpsResult>;
            let results = if group.alone() {
                &solved
            } else {
                let [s0, s1, s2, _] = group.scales[group.member(u.variant)];
                scaled = solved.par_iter().map(|r| r.scaled(&[s0, s1, s2])).collect();
                &scaled
            };
            // The statistics on this thread while the pool builds the columns.
            let (batch, stats) = rayon::join(
                || opts.poses.then(|| schema.batch(u.mode, &rows, results)),
                || {
                    let mut stats = UpsStats::default();
                    for r in results {
                        stats.push(r);
                    }
                    stats.flush();
                    stats
                },
            );
            stages.pose_pass += pose_pass.elapsed().as_secs_f64();
            let unit = Written {
                part: layout.part(u.variant, u.mode, u.chunk),
                stats_path: layout.stats(u.variant, u.mode, u.chunk),
                stats,
                batch,
                meta: part_metadata(&variants[u.variant as usize]),
                poses: u.range.end - u.range.start,
            };
            if k + 1 < w.units.len() {
                written(&mut stages, &mut done, write_unit(unit)?);
            } else {
                pending = Some(unit);
            }
        }
        spare = solved;
    }
    // Without shards the run is complete once its last unit is written: the search,
    // which reads the samples the pass kept rather than the files, runs while it is
    // (writing a part is partly serial: its file, its footer).
    let early = opts.shard.is_none() && opts.search && pending.is_some();
    let (last, searched) = rayon::join(
        || pending.take().map(write_unit),
        || early.then(|| searches(job, &variants, &groups, &models, &known)),
    );
    if let Some(last) = last {
        written(&mut stages, &mut done, last?);
    }
    progress.finish();
    let syncing = Instant::now();
    sync_units(layout, &mine, &[])?;
    stages.writing += syncing.elapsed().as_secs_f64();
    let complete = mark_shard_done(layout, opts)?;
    if complete {
        progress.searching();
        let durable = WriteOptions { durable: true, ..write_opts.clone() };
        // Searched here where it did not run beside the last write (shards, resumed
        // runs with nothing left to compute); not at all without `RunOptions::search`.
        let (found, seconds) = searched.unwrap_or_else(|| {
            if opts.search { searches(job, &variants, &groups, &models, &known) } else { (Found::new(), 0.0) }
        });
        stages.search += seconds;
        finalize(layout, job, &variants, &groups, &all, &durable, &found, &mut stages)?;
        write_marker(&layout.success())?;
    }
    Ok(RunReport { computed: todo_poses, total, seconds: start.elapsed().as_secs_f64(), complete, stages })
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
            // Read on the pool (each file is parsed, a serial stretch at the end of a
            // run), merged in the units' order: the same sums.
            let units: Vec<&Unit> = all.iter().filter(|u| u.variant == variant.index && u.mode == mode).collect();
            let parts: Vec<UpsStats> = units
                .par_iter()
                .map(|u| read_stats(&layout.stats(u.variant, u.mode, u.chunk)))
                .collect::<Result<_>>()?;
            let mut stats = UpsStats::default();
            for part in &parts {
                stats.merge(part);
            }
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
                        let mags: Vec<SampledLoad> = loads
                            .iter()
                            .map(|r| r[kind][l].map(|f| (f.norm(), f)).filter(|(m, _)| *m > floor))
                            .collect();
                        let at = |p: f64| {
                            let r = loads_at(ws, p);
                            let f = if kind == 0 { r.f_s[l] } else { r.f_u[l] };
                            loaded(r.status).then_some([f.x, f.y, f.z])
                        };
                        for found in vector_load::switches(&mags, &rule, at) {
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
                                inputs: s.map(|v| v[0]),
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
