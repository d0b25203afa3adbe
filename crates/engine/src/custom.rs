//! A custom mechanism's run (docs/model.md §12): the same plan, directory, shards and
//! resume as the built-in kinds ([`run`](crate::run())) and the 6-UPS's run loop
//! ([`run_units`]), the mechanism's inputs as samples, [`solve_custom`] per pose, and tables built from the model
//! ([`CustomSchema`]).
//!
//! The discontinuity search follows every grid line of every input, or the trajectory,
//! for every joint group with play (docs/model.md §8, by the load's dimension): a
//! scalar load (R axial, U angular, backlash) switches where its sign changes, between
//! samples or twice between two samples of one sign ([`scalar_load::crossings`]); a
//! vector load by the rule of every mechanism ([`vector_load::path_switches`]: refined
//! minima, directions read where the magnitude has risen to twice the minimum, located
//! between samples). Both leave out the samples whose load is indeterminate (their
//! neighbours are consecutive) and stop at the poses that cannot be solved. Groups that
//! cannot move the platform are never searched.

use std::collections::HashMap;
use std::time::Instant;

use arrow::record_batch::RecordBatch;
use clearance_discontinuity::scalar_load::{self, Side};
use clearance_discontinuity::vector_load::{self, Reading, SampledLoad, VectorRule};
use clearance_grid::SampleSource;
use clearance_kinematics::custom::Configuration;
use clearance_model::{JobError, JobSpec, Mode, Variant};
use clearance_parquet::{
    Codec, ColumnSet, CustomPages, CustomPart, CustomRow, CustomSchema, CustomStats, CustomSummaryRow, CustomSwitch,
    Precision, WriteOptions, Writer, custom_discontinuity_batch, custom_summary_batch, write_parquet,
};
use clearance_solver::custom::{
    CustomModel, CustomResult, LargestCond, MembersSolved, Wanted, drop_spare_results, group_load_near, preset_members,
    recycle, solve_members_near,
};
use rayon::prelude::*;

use crate::error::EngineError;
use crate::groups::Group;
use crate::layout::Layout;
use crate::run::{RunOptions, RunReport, StageTimes, Unit, Work, prepare_run, read_merged_stats, unit_complete};
use crate::solve::Poses;
use crate::units::{PartRows, UnitRun, run_units};
use crate::ups::{UpsPath, ups_paths};

/// The location tolerance of a scalar load's root, in the path parameter (sample steps).
const LOCATE_TOL: f64 = 1e-10;

type Result<T, E = EngineError> = std::result::Result<T, E>;

/// The model of a custom job, or its refusal as a job error (exit 2). A description
/// that is a built-in 3-PRS's or 6-UPS's is given that kind's kernel (docs/model.md §12.10).
pub(crate) fn model_of(job: &JobSpec, file: &str) -> Result<CustomModel, JobError> {
    let mut model = CustomModel::from_job(job, file)?;
    model.preset = crate::preset::preset_of(job, &model);
    Ok(model)
}

/// Where a custom job's samples come from: its grid or trajectory, or poses given.
#[derive(Clone, Copy)]
enum Samples<'a> {
    Job(&'a SampleSource),
    Given(&'a Poses),
}

impl Samples<'_> {
    fn len(&self) -> u64 {
        match self {
            Samples::Job(s) => s.len(),
            Samples::Given(p) => p.len() as u64,
        }
    }

    fn sample6(&self, i: u64) -> (Option<f64>, [[f64; 3]; 6]) {
        match self {
            Samples::Job(s) => s.sample6(i),
            Samples::Given(p) => p.sample6(i),
        }
    }
}

/// A pose's inputs (at most the six coordinates), each one's value, rate and
/// acceleration, in canonical order: on the stack (a vector a pose, and three more a
/// point of the search, were about 300 000 allocations and frees of a described
/// 3-PRS's 301 × 301 grid, callgrind).
#[derive(Clone, Copy)]
struct Inputs {
    n: usize,
    at: [[f64; 3]; 6],
}

impl Inputs {
    /// The inputs of `model` at the coordinates `s` (values, rates, accelerations).
    fn of(model: &CustomModel, s: &[[f64; 3]; 6]) -> Self {
        debug_assert!(model.geom.inputs.len() <= 6, "the inputs are some of the six coordinates");
        let mut at = [[0.0; 3]; 6];
        for (to, &k) in at.iter_mut().zip(&model.geom.inputs) {
            *to = s[k];
        }
        Inputs { n: model.geom.inputs.len(), at }
    }
}

impl std::ops::Deref for Inputs {
    type Target = [[f64; 3]];
    fn deref(&self) -> &[[f64; 3]] {
        &self.at[..self.n]
    }
}

/// The inputs of sample `i` (values, rates, accelerations) and its time.
fn inputs_of(model: &CustomModel, source: Samples, i: u64) -> (Option<f64>, Inputs) {
    let (t, s) = source.sample6(i);
    (t, Inputs::of(model, &s))
}

/// Solves one pose from its inputs' values, rates and accelerations, its configuration
/// continued from `near` where that is close (see [`solve_custom_near`]), giving what
/// `wanted` asks ([`solve_members_near`]).
fn solve_inputs(
    models: &[&CustomModel],
    inputs: &[[f64; 3]],
    mode: Mode,
    near: Option<&Configuration>,
    wanted: Wanted,
) -> (Vec<CustomResult>, Option<Configuration>) {
    let ([x, v, a], n) = split(inputs);
    solve_members_near(models, &x[..n], Some((&v[..n], &a[..n])), mode, near, wanted)
}

/// The inputs' values, rates and accelerations, each in canonical order (the first `n`
/// of each, returned with them).
fn split(inputs: &[[f64; 3]]) -> ([[f64; 6]; 3], usize) {
    let mut out = [[0.0; 6]; 3];
    for (i, v) in inputs.iter().enumerate() {
        for k in 0..3 {
            out[k][i] = v[k];
        }
    }
    (out, inputs.len())
}

/// Group `g`'s deciding load at one pose, as [`group_load`] reads it of a full solve.
fn load_of(
    model: &CustomModel,
    inputs: &[[f64; 3]],
    mode: Mode,
    near: Option<&Configuration>,
    g: usize,
) -> (Option<[f64; 3]>, Option<Configuration>) {
    let ([x, v, a], n) = split(inputs);
    group_load_near(model, &x[..n], Some((&v[..n], &a[..n])), mode, near, g)
}

/// Samples are solved in runs of this many, aligned on multiples of it: each continued
/// from the one before it in its run (neighbours on a grid line or a trajectory), the
/// first of a run from home. A sample's result depends only on its run, whatever the
/// chunks, shards or threads.
const RUN: u64 = 64;

/// Solves samples `range` of one mode on the current rayon pool.
fn solve_rows(
    model: &CustomModel,
    source: Samples,
    range: std::ops::Range<u64>,
    mode: Mode,
    each_cond: bool,
) -> (Vec<CustomRow>, Vec<CustomResult>) {
    let (rows, mut results) = solve_members(&[model], source, range, mode, each_cond);
    (rows, results.pop().expect("one model"))
}

/// [`solve_rows`] for the members of a clearance sweep (models equal but for their
/// clearances): each pose's kinematics and reactions once, each member's take-up.
/// Returns the rows and, per member, its results. Without `each_cond`, a pose that a
/// preset's kernel solves has its `cond` only where it may be the largest of the poses
/// solved here ([`preset_members`]; its runs share what they found, [`LargestCond`]):
/// all that the statistics read of it where no column holds it.
fn solve_members(
    models: &[&CustomModel],
    source: Samples,
    range: std::ops::Range<u64>,
    mode: Mode,
    each_cond: bool,
) -> (Vec<CustomRow>, Vec<Vec<CustomResult>>) {
    let first = range.start - range.start % RUN;
    let largest = LargestCond::default();
    let runs: Vec<(Vec<CustomRow>, Vec<Vec<CustomResult>>)> = (first..range.end)
        .step_by(RUN as usize)
        .collect::<Vec<u64>>()
        .into_par_iter()
        .map(|start| {
            let run = start.max(range.start)..(start + RUN).min(range.end);
            let (times, inputs): (Vec<Option<f64>>, Vec<Inputs>) =
                run.clone().map(|i| inputs_of(models[0], source, i)).unzip();
            // A preset's kernel solves the run at once, each member's results in place;
            // a pose it does not answer, and every pose of another description, goes
            // through `solve_inputs`.
            let MembersSolved { answered, mut results } = preset_members(models, &inputs, mode, each_cond, &largest)
                .unwrap_or_else(|| MembersSolved::unanswered(models.len(), inputs.len()));
            let mut near = None;
            let mut rows = Vec::with_capacity(inputs.len());
            for i in start..run.end {
                if i < range.start {
                    // Continuation runs from the run's first sample, whatever the range.
                    let (_, inputs) = inputs_of(models[0], source, i);
                    near = solve_inputs(models, &inputs, mode, near.as_ref(), Wanted::WithoutCond).1;
                    continue;
                }
                let k = (i - run.start) as usize;
                if answered[k] {
                    near = None;
                } else {
                    let (all, reached) = solve_inputs(models, &inputs[k], mode, near.as_ref(), Wanted::Whole);
                    for (to, r) in results.iter_mut().zip(all) {
                        to[k] = r;
                    }
                    near = reached;
                }
                rows.push(CustomRow { sample: i, t: times[k] });
            }
            (rows, results)
        })
        .collect();
    let mut rows = Vec::with_capacity((range.end - range.start) as usize);
    let mut results: Vec<Vec<CustomResult>> = models.iter().map(|_| Vec::with_capacity(rows.capacity())).collect();
    for (run_rows, mut run_results) in runs {
        rows.extend(run_rows);
        for (to, from) in results.iter_mut().zip(&mut run_results) {
            to.append(from);
        }
    }
    (rows, results)
}

/// The poses of a custom job as record batches, one per (variant, mode), in memory:
/// its grid's or trajectory's, or `poses` (checked: its inputs' values). `range`
/// (default: every sample) limits each variant to those samples.
pub(crate) fn solve_custom_job(
    job: &JobSpec,
    file: &str,
    columns: ColumnSet,
    range: Option<std::ops::Range<u64>>,
    poses: Option<&Poses>,
) -> Result<Vec<RecordBatch>> {
    let mut out = Vec::new();
    for v in job.variants(file)? {
        let model = model_of(&v.job, file)?;
        let schema = CustomSchema::new(&model, columns, job.analysis.exact);
        let own = SampleSource::new(&v.job);
        let source = match poses {
            Some(p) => Samples::Given(p),
            None => Samples::Job(&own),
        };
        for &mode in &v.job.analysis.modes {
            let (rows, results) =
                solve_rows(&model, source, range.clone().unwrap_or(0..source.len()), mode, columns >= ColumnSet::Full);
            out.push(crate::solve::with_variant(&schema.batch(mode, &rows, &results), v.index));
        }
    }
    Ok(out)
}

/// Runs a custom `job` into `opts.out` (see [`run`](crate::run())).
pub(crate) fn run_custom(job: &JobSpec, job_file: &str, opts: &RunOptions) -> Result<RunReport> {
    // Every variant's description is checked before anything is written.
    let variants = job.variants(job_file)?;
    let models: Vec<CustomModel> = variants.iter().map(|v| model_of(&v.job, job_file)).collect::<Result<_, _>>()?;
    let setup = prepare_run(job, job_file, opts, unit_complete::<CustomStats>)?;
    let mut r = CustomRun {
        job,
        variants: &setup.variants,
        groups: &setup.groups,
        sources: setup.variants.iter().map(|v| SampleSource::new(&v.job)).collect(),
        schemas: models.iter().map(|m| CustomSchema::new(m, opts.columns, job.analysis.exact)).collect(),
        models,
        search: opts.search,
        poses: opts.poses,
        pages: (opts.writer == Writer::Engine).then_some((setup.write_opts.codec, opts.precision)),
        each_cond: opts.poses && opts.columns >= ColumnSet::Full,
        tables: HashMap::new(),
        kept: 0,
        merged: HashMap::new(),
    };
    let report = run_units(&mut r, opts, &setup);
    rayon::broadcast(|_| drop_spare_results());
    report
}

/// A custom run's part in [`run_units`]: a work's units are the members of one
/// clearance sweep (or one variant) for one (mode, part), whose poses' kinematics and
/// reactions are solved once.
struct CustomRun<'a> {
    job: &'a JobSpec,
    variants: &'a [Variant],
    groups: &'a [Group],
    /// Per variant.
    models: Vec<CustomModel>,
    sources: Vec<SampleSource>,
    schemas: Vec<CustomSchema>,
    search: bool,
    /// Whether the units' part files are written (their rows built).
    poses: bool,
    /// With the engine's encoder, the codec and precision the part files' pages are
    /// encoded with as they are solved; with Arrow's (`--writer arrow`), none: the
    /// part's columns are built whole.
    pages: Option<(Codec, Precision)>,
    /// Whether they hold each pose's condition number (else the statistics read only
    /// the largest: [`solve_members`]).
    each_cond: bool,
    /// What the search reads of each sample, kept from the pose pass where every unit
    /// of a (variant, mode) is computed here and the table fits (else the search
    /// solves them).
    tables: HashMap<(u64, Mode), Table>,
    /// Bytes the tables take.
    kept: u64,
    /// Per (variant, mode), the statistics of the units written here merged in the
    /// order they came, and their chunks in that order: where these are all the
    /// (variant, mode)'s units in the run's order, the summary takes them as they are
    /// rather than parsing every unit's statistics file again (a described 3-PRS's file
    /// took 16 M instructions to parse, a serial stretch at the end of a run of many
    /// units).
    merged: HashMap<(u64, Mode), (CustomStats, Vec<u64>)>,
}

/// Rows of a work solved at a time: each block's results become its rows of the
/// part's columns (filled in place), statistics and search table before the next
/// block is solved. A result is some 2 kB of vectors; a whole part's (65 536 rows)
/// held at once came as fresh pages, a fault every few poses, and was freed on the
/// pool afterwards. Blocks of 8 192 (some 20 MB of results, and as much again kept
/// for reuse) were read back for the columns and the statistics from beyond the
/// caches: with 2 048 a described 6-UPS or 3-PRS took 12–15 % less CPU (512 no less
/// than 2 048). A multiple of [`RUN`], so that no run of continued samples straddles
/// two blocks (a sample's result depends only on its run).
const BLOCK: u64 = 2 * 1024;

/// One member's unit of a solved work: its part's rows (when written), its statistics
/// (every pose pushed in sample order) and what the search reads of each of its
/// samples (where the pass keeps it: [`CustomRun::keeps_table`]).
#[derive(Default)]
struct MemberSolved {
    part: Option<Part>,
    stats: CustomStats,
    sampled: Option<Sampled>,
}

/// A unit's rows as they are filled: encoded page by page for the engine's encoder,
/// columns whole for Arrow's.
enum Part {
    Pages(CustomPages),
    Columns(CustomPart),
}

impl CustomRun<'_> {
    /// The bytes of the search's table of variant `v`'s samples, about.
    fn table_bytes(&self, v: usize) -> u64 {
        self.sources[v].len().saturating_mul(table_entry(&self.models[v]))
    }

    /// Whether the pass keeps what the search reads of unit `u`'s samples: the run
    /// searches, and the table of its (variant, mode) is kept already or fits beside
    /// those kept.
    fn keeps_table(&self, u: &Unit) -> bool {
        self.search
            && (self.tables.contains_key(&(u.variant, u.mode))
                || self.kept.saturating_add(self.table_bytes(u.variant as usize)) <= SHARED_BYTES)
    }
}

impl UnitRun for CustomRun<'_> {
    /// Per member (unit of the work), in unit order.
    type Solved = Vec<MemberSolved>;
    type Found = HashMap<(u64, Mode), Vec<CustomSwitch>>;

    fn solve(&self, w: &Work, _spare: Option<Self::Solved>) -> Self::Solved {
        let first = &w.units[0];
        let members: Vec<&CustomModel> = w.units.iter().map(|u| &self.models[u.variant as usize]).collect();
        let source = Samples::Job(&self.sources[first.variant as usize]);
        let range = first.range.clone();
        let mut out: Vec<MemberSolved> = w
            .units
            .iter()
            .zip(&members)
            .map(|(u, m)| MemberSolved {
                part: self.poses.then(|| {
                    let (schema, len) = (&self.schemas[u.variant as usize], (range.end - range.start) as usize);
                    match self.pages {
                        Some((codec, precision)) => Part::Pages(schema.pages(u.mode, len, codec, precision)),
                        None => Part::Columns(schema.part(u.mode, len)),
                    }
                }),
                stats: CustomStats::new(m.kinds.len(), m.groups.len()),
                sampled: self.keeps_table(u).then(|| Sampled::with_capacity(m, (range.end - range.start) as usize)),
            })
            .collect();
        let mut start = range.start;
        while start < range.end {
            let end = (start - start % BLOCK + BLOCK).min(range.end);
            let (rows, results) = solve_members(&members, source, start..end, first.mode, self.each_cond);
            for ((u, part), results) in w.units.iter().zip(&mut out).zip(results) {
                let schema = &self.schemas[u.variant as usize];
                // The statistics and the search's samples on this thread while the pool
                // builds the columns.
                let MemberSolved { part, stats, sampled } = part;
                rayon::join(
                    || match part {
                        Some(Part::Pages(part)) => schema.fill_pages(part, &rows, &results),
                        Some(Part::Columns(part)) => schema.fill(part, &rows, &results),
                        None => {}
                    },
                    || {
                        for r in &results {
                            stats.push(r);
                        }
                        if let Some(sampled) = sampled {
                            sampled.extend(&results);
                        }
                    },
                );
                // Each result holds a few vectors: let go of on the pool, not on this
                // thread, each thread keeping its share of a block's for the next block's
                // results (`recycle`).
                let most = (BLOCK as usize).div_ceil(rayon::current_num_threads()) + RUN as usize;
                results.into_par_iter().with_min_len(RUN as usize).for_each(|r| recycle(r, most));
            }
            start = end;
        }
        out
    }

    fn unit(&mut self, w: &Work, k: usize, solved: &mut Self::Solved, poses: bool) -> (Option<PartRows>, Vec<u8>) {
        let u = &w.units[k];
        let v = u.variant as usize;
        let MemberSolved { part, mut stats, sampled } = std::mem::take(&mut solved[k]);
        // Kept where `solve` judged it would be: the tables kept since only grow, so a
        // table it judged not to fit does not fit now.
        if let Some(sampled) = sampled {
            let key = (u.variant, u.mode);
            if self.keeps_table(u) && !self.tables.contains_key(&key) {
                self.kept += self.table_bytes(v);
                self.tables.insert(key, Table::default());
            }
            if let Some(table) = self.tables.get_mut(&key) {
                table.put(u.range.start, sampled);
            }
        }
        stats.flush();
        let batch = poses.then(|| match part.expect("a part where its rows are written") {
            Part::Pages(pages) => PartRows::Pages(Box::new(pages)),
            Part::Columns(part) => PartRows::Batch(self.schemas[v].finish(part)),
        });
        let bytes = serde_json::to_vec(&stats).expect("statistics are plain numbers");
        let model = &self.models[v];
        let (merged, chunks) = self
            .merged
            .entry((u.variant, u.mode))
            .or_insert_with(|| (CustomStats::new(model.kinds.len(), model.groups.len()), Vec::new()));
        merged.merge(&stats);
        chunks.push(u.chunk);
        (batch, bytes)
    }

    fn searches(&mut self) -> (Self::Found, f64) {
        // Only the complete tables: a table with samples this run did not compute
        // (a resumed or sharded run) is solved by the search.
        let sources = &self.sources;
        let tables: HashMap<(u64, Mode), Table> = std::mem::take(&mut self.tables)
            .into_iter()
            .filter(|((v, _), t)| t.filled() == sources[*v as usize].len())
            .collect();
        searches(self.job, self.variants, self.groups, &self.models, &self.sources, tables)
    }

    fn finalize(
        &self,
        layout: &Layout,
        all: &[Unit],
        write_opts: &WriteOptions,
        found: Self::Found,
        stages: &mut StageTimes,
    ) -> Result<()> {
        let run = (self.job, self.variants, &self.models[..], &self.merged);
        finalize(layout, run, all, write_opts, found, stages)
    }
}

/// The switches of each (variant, mode), searched group by group, and the seconds it took.
fn searches(
    job: &JobSpec,
    variants: &[Variant],
    groups: &[Group],
    models: &[CustomModel],
    sources: &[SampleSource],
    mut tables: HashMap<(u64, Mode), Table>,
) -> (HashMap<(u64, Mode), Vec<CustomSwitch>>, f64) {
    let searching = Instant::now();
    let mut found = HashMap::new();
    for group in groups {
        let first = group.first() as usize;
        let members: Vec<&CustomModel> = group.members.iter().map(|&v| &models[v as usize]).collect();
        for &mode in &job.analysis.modes {
            let kept = group.members.iter().map(|&v| tables.remove(&(v, mode))).collect();
            let per_member = search(&variants[first].job, &members, &sources[first], mode, kept);
            for (&v, switches) in group.members.iter().zip(per_member) {
                found.insert((v, mode), switches);
            }
        }
    }
    (found, searching.elapsed().as_secs_f64())
}

/// What [`finalize`] reads of a custom run: its job, variants and models, and the
/// statistics merged as its units were written ([`CustomRun::merged`]).
type Finalizing<'r> =
    (&'r JobSpec, &'r [Variant], &'r [CustomModel], &'r HashMap<(u64, Mode), (CustomStats, Vec<u64>)>);

/// The summary and the discontinuities of a run whose units are all written, with the
/// switches `found` ([`searches`]; none where a variant is missing).
fn finalize(
    layout: &Layout,
    (job, variants, models, merged): Finalizing<'_>,
    all: &[Unit],
    write_opts: &WriteOptions,
    mut found: HashMap<(u64, Mode), Vec<CustomSwitch>>,
    stages: &mut StageTimes,
) -> Result<()> {
    let mut summary = Vec::new();
    let mut switches = Vec::new();
    for variant in variants {
        let model = &models[variant.index as usize];
        for &mode in &job.analysis.modes {
            // Merged in the units' order from an empty start, in memory as here: the
            // same sums either way (the files hold each unit's statistics exactly).
            let units: Vec<&Unit> = all.iter().filter(|u| u.variant == variant.index && u.mode == mode).collect();
            let stats = match merged.get(&(variant.index, mode)) {
                Some((stats, chunks)) if chunks.iter().eq(units.iter().map(|u| &u.chunk)) => stats.clone(),
                _ => {
                    let empty = CustomStats::new(model.kinds.len(), model.groups.len());
                    read_merged_stats(layout, &units, empty, CustomStats::merge)?
                }
            };
            let own = found.remove(&(variant.index, mode)).unwrap_or_default();
            let mut counts = vec![0u64; model.kinds.len()];
            for s in &own {
                counts[s.kind] += 1;
            }
            switches.extend(own.into_iter().map(|s| CustomSwitch { variant: variant.index, mode, ..s }));
            summary.push(CustomSummaryRow {
                variant: variant.index,
                mode: mode.name(),
                params: variant.params.iter().map(|(_, v)| *v).collect(),
                stats,
                switches: counts,
            });
        }
    }
    let writing = Instant::now();
    // Every variant has the same columns: the description's joints and kinds do not move
    // with a swept number.
    let batch = custom_discontinuity_batch(&models[0], &switches);
    write_parquet(&layout.discontinuities(), batch.schema(), &[batch], write_opts, &[])?;
    let names: Vec<String> = job.sweep.iter().map(|s| s.param.clone()).collect();
    let batch = custom_summary_batch(&models[0], &names, &summary);
    write_parquet(&layout.summary(), batch.schema(), &[batch], write_opts, &[])?;
    stages.writing += writing.elapsed().as_secs_f64();
    Ok(())
}

/// What the search reads of one group at one pose: its deciding load where the pose
/// has loads and the group can move the platform.
fn group_load(r: &CustomResult, g: usize) -> Option<[f64; 3]> {
    (r.loaded() && r.takes[g].mobile).then(|| r.takes[g].load)
}

fn kind_error(r: &CustomResult, kind: usize) -> Option<[f64; 6]> {
    r.loaded().then(|| r.kind_errors[kind].map(|e| [e[0], e[1], e[2], e[3], e[4], e[5]])).flatten()
}

/// What the search reads of samples in order: each group's deciding load and each
/// kind's error, sample after sample in two flat tables. Two vectors a sample were two
/// allocations a pose, freed only after the search: 5 % of a described 3-PRS's CPU
/// (`perf`).
#[derive(Default)]
struct Sampled {
    len: usize,
    groups: usize,
    kinds: usize,
    loads: Vec<Option<[f64; 3]>>,
    errors: Vec<Option<[f64; 6]>>,
}

/// One sample of a [`Sampled`].
#[derive(Clone, Copy)]
struct SampledRef<'a> {
    loads: &'a [Option<[f64; 3]>],
    errors: &'a [Option<[f64; 6]>],
}

impl Sampled {
    /// No samples yet, with room for `n`.
    fn with_capacity(model: &CustomModel, n: usize) -> Self {
        let (groups, kinds) = (model.groups.len(), model.kinds.len());
        Sampled { len: 0, groups, kinds, loads: Vec::with_capacity(n * groups), errors: Vec::with_capacity(n * kinds) }
    }

    /// The samples of `results`, in order.
    fn of<'r>(model: &CustomModel, results: impl ExactSizeIterator<Item = &'r CustomResult>) -> Self {
        let mut out = Self::with_capacity(model, results.len());
        out.extend(results);
        out
    }

    /// Appends the samples of `results`.
    fn extend<'r>(&mut self, results: impl IntoIterator<Item = &'r CustomResult>) {
        for r in results {
            self.loads.extend((0..self.groups).map(|g| group_load(r, g)));
            self.errors.extend((0..self.kinds).map(|k| kind_error(r, k)));
            self.len += 1;
        }
    }

    /// Sample `i`.
    fn get(&self, i: usize) -> SampledRef<'_> {
        SampledRef {
            loads: &self.loads[i * self.groups..][..self.groups],
            errors: &self.errors[i * self.kinds..][..self.kinds],
        }
    }
}

/// The bytes of one sample of a [`Sampled`].
fn table_entry(model: &CustomModel) -> u64 {
    (model.groups.len() * size_of::<Option<[f64; 3]>>() + model.kinds.len() * size_of::<Option<[f64; 6]>>()) as u64
}

/// The search's table of every sample of a (variant, mode): each unit's samples as the
/// pose pass left them (not copied into one table: with a unit's copy beside it, that
/// raised a described 6-UPS's peak memory by a third). Complete once every sample is in.
#[derive(Default)]
struct Table {
    /// Each unit's first sample and samples, by first sample.
    units: Vec<(u64, Sampled)>,
}

impl Table {
    /// A table of one unit, from sample 0.
    fn whole(sampled: Sampled) -> Self {
        let mut t = Table::default();
        t.put(0, sampled);
        t
    }

    /// Samples put in so far (units do not overlap).
    fn filled(&self) -> u64 {
        self.units.iter().map(|(_, u)| u.len as u64).sum()
    }

    /// A unit's samples, from sample `start`.
    fn put(&mut self, start: u64, unit: Sampled) {
        let at = self.units.partition_point(|(s, _)| *s < start);
        self.units.insert(at, (start, unit));
    }

    /// Sample `i` (in a unit put).
    fn get(&self, i: u64) -> SampledRef<'_> {
        let (start, unit) = &self.units[self.units.partition_point(|(s, _)| *s <= i) - 1];
        unit.get((i - start) as usize)
    }
}

/// The most memory the table of every sample's loads and errors may take; beyond, each
/// path solves its samples again.
const SHARED_BYTES: u64 = 1 << 29;

/// The switches of one (group of variants, mode), per member: every path, in order, on
/// the rayon pool. The members of a custom clearance sweep have the same loads (they
/// differ only in their clearances), so the paths are searched once, for every joint
/// group that has play in some member, and each member keeps the switches of its own
/// groups with play, their jumps read from its own errors. Every sample lies on a line
/// of each input that varies: its loads are solved once for all of them where the
/// tables fit in memory (`tables`: the members' tables where the pose pass kept them).
fn search(
    job: &JobSpec,
    models: &[&CustomModel],
    source: &SampleSource,
    mode: Mode,
    tables: Vec<Option<Table>>,
) -> Vec<Vec<CustomSwitch>> {
    let model = models[0];
    // The groups with play in some member, each with the first such member: the
    // members' loads are the same, but a member without the play leaves the group
    // immobile, so the search reads that member's.
    let groups: Vec<(usize, usize)> = (0..model.groups.len())
        .filter_map(|g| Some((g, models.iter().position(|m| m.groups[g].magnitude > 0.0)?)))
        .collect();
    if groups.is_empty() {
        return vec![Vec::new(); models.len()];
    }
    let threshold = job.analysis.discontinuity_load_fraction * model.weight;
    let floor = model.floor;
    let trajectory = job.trajectory.as_ref().map(|t| t.inputs6());
    let paths = ups_paths(job, source);
    let n = source.len();
    let bytes = n.saturating_mul(table_entry(model)).saturating_mul(models.len() as u64);
    let shared: Option<Vec<Table>> = match tables.into_iter().collect::<Option<Vec<_>>>() {
        Some(kept) => Some(kept),
        None => (bytes <= SHARED_BYTES).then(|| {
            let (_, results) = solve_members(models, Samples::Job(source), 0..n, mode, false);
            results.iter().zip(models).map(|(rs, m)| Table::whole(Sampled::of(m, rs.iter()))).collect()
        }),
    };
    let found: Vec<Vec<Vec<CustomSwitch>>> = paths
        .par_iter()
        .map(|path| {
            // Each point the search solves continues from the nearest along the path of
            // those it solved last on this path (the path's own order: the same
            // whatever the threads).
            let trail = std::cell::RefCell::new(Trail::default());
            // The path's point `p`, and its inputs' values, rates and accelerations.
            let point = |p: f64| {
                let (t, s) = path.sample_at(source, trajectory.as_ref(), p);
                let inputs = Inputs::of(model, &s);
                (t, s, inputs)
            };
            // What the search reads of a pose (its status, coordinates, loads and errors)
            // needs no condition number; at a switch and where its jump is read, it reads
            // one kind.
            let solve_wanted = |p: f64, wanted: Wanted| {
                let (t, s, inputs) = point(p);
                let (r, reached) = solve_inputs(models, &inputs, mode, trail.borrow().nearest(p), wanted);
                trail.borrow_mut().keep(p, reached);
                (t, s, r)
            };
            let solve_at = |p: f64| solve_wanted(p, Wanted::WithoutCond);
            // Per member, its samples along the path.
            let own: Vec<Sampled>;
            let samples: Vec<Vec<SampledRef<'_>>> = match &shared {
                Some(all) => all.iter().map(|t| (0..path.len).map(|k| t.get(path.index(k))).collect()).collect(),
                None => {
                    let solved: Vec<Vec<CustomResult>> = (0..path.len).map(|k| solve_at(k as f64).2).collect();
                    own = models
                        .iter()
                        .enumerate()
                        .map(|(m, model)| Sampled::of(model, solved.iter().map(|r| &r[m])))
                        .collect();
                    own.iter().map(|t| (0..path.len).map(|k| t.get(k)).collect()).collect()
                }
            };
            let mut out: Vec<Vec<CustomSwitch>> = vec![Vec::new(); models.len()];
            for &(g, played) in &groups {
                let def = &model.groups[g];
                let loads: Vec<Option<[f64; 3]>> = samples[played].iter().map(|r| r.loads[g]).collect();
                let at = |p: f64| {
                    let (.., inputs) = point(p);
                    let (load, reached) = load_of(model, &inputs, mode, trail.borrow().nearest(p), g);
                    trail.borrow_mut().keep(p, reached);
                    load
                };
                let solve_at = |p: f64| solve_wanted(p, Wanted::Kind(def.kind));
                let found = if model.scalar(g) {
                    scalar_switches(path, &loads, floor, def.limb, &at, &solve_at, def.kind, (g, played))
                } else {
                    // The switch's own point: its coordinates and whether it has loads.
                    let posed_at = |p: f64| solve_wanted(p, Wanted::Posed);
                    vector_switches(path, &loads, &VectorRule { threshold, floor }, def.kind, def.limb, &at, &posed_at)
                };
                // Each member's jump: its kind's error after minus before, from its own
                // samples, or solved (once for all members) between them.
                for (switch, before, after) in found {
                    let read = |r: Side| -> Vec<Option<[f64; 6]>> {
                        match r {
                            Side::Sample(k) => samples.iter().map(|s| s[k].errors[def.kind]).collect(),
                            Side::At(p) => solve_at(p).2.iter().map(|r| kind_error(r, def.kind)).collect(),
                        }
                    };
                    let (b, a) = (read(before), read(after));
                    for (m, member) in models.iter().enumerate() {
                        if member.groups[g].magnitude <= 0.0 {
                            continue;
                        }
                        let jump = match (b[m], a[m]) {
                            (Some(b), Some(a)) => std::array::from_fn(|i| a[i] - b[i]),
                            _ => [f64::NAN; 6],
                        };
                        out[m].push(CustomSwitch { jump, ..switch.clone() });
                    }
                }
            }
            out
        })
        .collect();
    let mut per_member: Vec<Vec<CustomSwitch>> = vec![Vec::new(); models.len()];
    for path in found {
        for (to, switches) in per_member.iter_mut().zip(path) {
            to.extend(switches);
        }
    }
    per_member
}

/// The configurations a path's search solved last, by path parameter (sample steps):
/// a point continues from the nearest of them. The search visits a path once per
/// joint group, and within a group goes back and forth (the refined intervals, then
/// the polish, the readings): continued from the point solved just before, a point
/// several samples away often missed the branch and was continued from home.
#[derive(Default)]
struct Trail {
    points: Vec<(f64, Configuration)>,
    /// The next slot to overwrite once [`TRAIL`] are held.
    next: usize,
}

/// Configurations a [`Trail`] holds (a few kB each).
const TRAIL: usize = 64;

impl Trail {
    fn nearest(&self, p: f64) -> Option<&Configuration> {
        self.points.iter().min_by(|a, b| (a.0 - p).abs().total_cmp(&(b.0 - p).abs())).map(|(_, c)| c)
    }

    fn keep(&mut self, p: f64, reached: Option<Configuration>) {
        let Some(c) = reached else { return };
        if self.points.len() < TRAIL {
            self.points.push((p, c));
        } else {
            self.points[self.next] = (p, c);
            self.next = (self.next + 1) % TRAIL;
        }
    }
}

type SolveAt<'a> = dyn Fn(f64) -> (Option<f64>, [[f64; 3]; 6], Vec<CustomResult>) + 'a;

/// The rule for a scalar load ([`scalar_load::crossings`]): a switch where its sign
/// changes between consecutive determinate samples, and two where an interval beside a
/// sampled minimum of its magnitude holds a point of the other sign; each located to
/// [`LOCATE_TOL`] in the path. The jump is read at the samples either side, or at the
/// point of the other sign between a pair. A crossing whose point the search cannot
/// solve again (its continuation from the points it solved last does not reach the
/// pose, or the group's load is not the search's there) is dropped, as a point that
/// cannot be solved cuts an interval: its margin and parasitic coordinates would be
/// unknown.
#[allow(clippy::too_many_arguments)]
fn scalar_switches(
    path: &UpsPath,
    loads: &[Option<[f64; 3]>],
    floor: f64,
    limb: usize,
    at: &dyn Fn(f64) -> Option<[f64; 3]>,
    solve_at: &SolveAt,
    kind: usize,
    (group, played): (usize, usize),
) -> Vec<(CustomSwitch, Side, Side)> {
    // A scalar load sits in its first component.
    let values: Vec<Option<f64>> = loads.iter().map(|l| l.map(|v| v[0])).collect();
    scalar_load::crossings(&values, floor, LOCATE_TOL, |p| at(p).map(|v| v[0]))
        .into_iter()
        .filter_map(|c| {
            let (t, s, r) = solve_at(c.at);
            // |load| of the pose just solved (of the member `played`, which has the
            // group's play); none where it cannot be solved there.
            let v = group_load(&r[played], group)?;
            let margin = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            Some((switch(path, limb, kind, t, &s, &r[0], margin), c.before, c.after))
        })
        .collect()
}

/// A switch at a solved point, its jump not yet read.
fn switch(
    path: &UpsPath,
    limb: usize,
    kind: usize,
    t: Option<f64>,
    s: &[[f64; 3]; 6],
    r: &CustomResult,
    margin: f64,
) -> CustomSwitch {
    // Parasitic coordinates from the solve there; inputs as the path gives them.
    let coords: [f64; 6] = std::array::from_fn(|k| if r.coords[k].is_finite() { r.coords[k] } else { s[k][0] });
    CustomSwitch {
        variant: 0,
        mode: Mode::Kinetostatic,
        limb: limb + 1,
        kind,
        along: path.along,
        t,
        coords,
        margin,
        jump: [f64::NAN; 6],
    }
}

/// The vector rule of docs/model.md §8 on one group's loads along one path; the jump
/// is the kind's error between the two points where the directions were read. A
/// switch whose point the search cannot solve again is dropped (as in
/// [`scalar_switches`]); `posed_at` solves the point for its coordinates and whether
/// it has loads ([`Wanted::Posed`]: the margin is the located minimum's).
fn vector_switches(
    path: &UpsPath,
    loads: &[Option<[f64; 3]>],
    rule: &VectorRule,
    kind: usize,
    limb: usize,
    at: &dyn Fn(f64) -> Option<[f64; 3]>,
    posed_at: &SolveAt,
) -> Vec<(CustomSwitch, Side, Side)> {
    let mags: Vec<SampledLoad> = loads.iter().map(|l| l.map(nalgebra::Vector3::from).map(|v| (v.norm(), v))).collect();
    let place = |r: &Reading| match r.sample {
        Some(k) => Side::Sample(k),
        None => Side::At(r.at),
    };
    vector_load::path_switches(&mags, rule, at)
        .into_iter()
        .filter_map(|found| {
            let (t, s, r) = posed_at(found.at);
            r[0].loaded().then(|| {
                (switch(path, limb, kind, t, &s, &r[0], found.margin), place(&found.before), place(&found.after))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use clearance_solver::Status;

    /// A job of `jobs/` as its custom description, and its model (a preset where the
    /// description is a built-in's).
    fn described(file: &str) -> CustomModel {
        described_job(file).1
    }

    /// The job of [`described`] too.
    fn described_job(file: &str) -> (JobSpec, CustomModel) {
        let text = std::fs::read_to_string(format!("{}/../../jobs/{file}", env!("CARGO_MANIFEST_DIR"))).unwrap();
        let job = JobSpec::from_toml_str(&text, file).unwrap();
        let job = if job.mechanism.kind == clearance_model::MechanismKind::Custom {
            job
        } else {
            crate::describe(&job, file).unwrap()
        };
        let model = model_of(&job, file).unwrap();
        (job, model)
    }

    /// What the search reads of one kind at a pose (`Wanted::Kind`) is what the whole
    /// pose's solve gives: the coordinates, whether it has loads, each group of the
    /// kind's take-up and the kind's error, bit for bit, for every kind; and of a
    /// switch's own point (`Wanted::Posed`) the coordinates and whether it has loads;
    /// on a 3-PRS and a 6-UPS (their kernels) and a 3-RRS (the general path), both
    /// modes, two members of a clearance sweep.
    #[test]
    fn the_search_reads_one_kind_as_the_whole_pose_gives_it() {
        for file in ["fig08_r_radial.toml", "ups_orientation_grid.toml", "custom_3rrs_grid.toml"] {
            let model = described(file);
            let mut loose = model.clone();
            for g in &mut loose.groups {
                g.magnitude *= 2.0;
            }
            let members = [&model, &loose];
            let n = model.geom.inputs.len();
            let home: Vec<f64> = model.geom.inputs.iter().map(|&k| model.geom.home[k]).collect();
            let rates: Vec<f64> = (0..n).map(|k| 0.2 + 0.05 * k as f64).collect();
            let mut read = 0;
            for i in 0..40 {
                let t = i as f64 / 39.0;
                let x: Vec<f64> =
                    (0..n).map(|k| home[k] + if k < n.saturating_sub(2) { 0.0 } else { 0.9 * (t - 0.5) }).collect();
                for mode in [Mode::Kinetostatic, Mode::Dynamic] {
                    let solve = |wanted| solve_members_near(&members, &x, Some((&rates, &rates)), mode, None, wanted).0;
                    let whole = solve(Wanted::WithoutCond);
                    // A switch's own point: the coordinates and whether it has loads.
                    for (w, p) in whole.iter().zip(&solve(Wanted::Posed)) {
                        let at = format!("{file} at {x:?} ({mode:?}), posed");
                        assert_eq!(p.loaded(), w.loaded(), "{at}");
                        assert_eq!(p.coords.map(f64::to_bits), w.coords.map(f64::to_bits), "{at}");
                    }
                    for kind in 0..model.kinds.len() {
                        let one = solve(Wanted::Kind(kind));
                        for (w, o) in whole.iter().zip(&one) {
                            let at = format!("{file} at {x:?} ({mode:?}), kind {kind}");
                            assert_eq!(o.loaded(), w.loaded(), "{at}");
                            assert_eq!(o.coords.map(f64::to_bits), w.coords.map(f64::to_bits), "{at}");
                            let bits = |e: Option<[f64; 9]>| e.map(|e| e.map(f64::to_bits));
                            if !w.loaded() {
                                continue;
                            }
                            assert_eq!(bits(o.kind_errors[kind]), bits(w.kind_errors[kind]), "{at}");
                            for (g, def) in model.groups.iter().enumerate().filter(|(_, d)| d.kind == kind) {
                                assert_eq!(
                                    format!("{:?}", o.takes[g]),
                                    format!("{:?}", w.takes[g]),
                                    "{at}: {}",
                                    def.label
                                );
                            }
                            read += usize::from(w.kind_errors[kind].is_some());
                        }
                    }
                }
            }
            assert!(read > 40 * 2 * model.kinds.len(), "{file}: {read} kinds' errors read");
        }
    }

    /// The 6-UPS kernel keeps the poses the search solved last on each thread: a pose
    /// solved again after other presets', modes' and samples' on the same thread, read
    /// whole or by one group's load, has the bits that a thread which solved nothing
    /// before gives. The two presets differ in their platform's mass only, so that a
    /// pose kept for one and read for the other would show in its loads.
    #[test]
    fn a_kept_kernel_pose_is_a_fresh_solve() {
        let (job, light) = described_job("ups_orientation_grid.toml");
        let mut heavier = job.clone();
        heavier.mass.platform *= 2.0;
        let heavy = model_of(&heavier, "heavier.toml").unwrap();
        assert!(light.preset.is_some() && heavy.preset.is_some());
        let home: Vec<f64> = light.geom.home.to_vec();
        let rates = [0.1, -0.2, 0.05, 0.3, 0.0, -0.1];
        let x = |i: usize| -> Vec<f64> {
            home.iter().enumerate().map(|(k, h)| h + if k >= 3 { 0.02 * i as f64 } else { 0.0 }).collect()
        };
        type Read = (String, String);
        // The whole pose and group 1's load, as text (floats as their shortest round trip).
        let read = |m: &CustomModel, x: &[f64], mode: Mode| -> Read {
            let whole = solve_members_near(&[m], x, Some((&rates, &rates)), mode, None, Wanted::WithoutCond).0;
            let load = group_load_near(m, x, Some((&rates, &rates)), mode, None, 1).0;
            (format!("{whole:?}"), format!("{load:?}"))
        };
        let order: Vec<(bool, usize, Mode)> = [0, 1, 0, 2, 1, 0]
            .into_iter()
            .flat_map(|i| [(false, i, Mode::Kinetostatic), (true, i, Mode::Kinetostatic), (false, i, Mode::Dynamic)])
            .collect();
        let mut solved = 0;
        for &(heavy_one, i, mode) in &order {
            let m = if heavy_one { &heavy } else { &light };
            let here = read(m, &x(i), mode);
            let fresh = std::thread::scope(|s| s.spawn(|| read(m, &x(i), mode)).join().unwrap());
            assert_eq!(here, fresh, "{} preset, pose {i}, {mode:?}", if heavy_one { "heavy" } else { "light" });
            solved += usize::from(here.1 != "None");
        }
        assert_eq!(solved, order.len(), "every pose has the group's load");
        // The presets' loads differ: a pose read for the wrong one would be caught.
        assert_ne!(read(&light, &x(0), Mode::Kinetostatic), read(&heavy, &x(0), Mode::Kinetostatic));
    }

    /// Where no column holds the condition number, a preset's poses compute it only
    /// where it may be the largest of the poses solved at once (runs of [`RUN`] settled
    /// on the pool, sharing the largest found): every field of every result the same
    /// bits as with each pose's but `cond`, the largest `cond` the same bits, and every
    /// pose left without one below it. Most poses are left without. The 3-PRS and the
    /// 6-UPS (their kernels), two members of a clearance sweep, `singular_cond` among
    /// the poses' own condition numbers so that some poses are refused (and solved the
    /// general way).
    #[test]
    fn a_solve_without_its_condition_numbers_keeps_its_largest() {
        for file in ["fig08_r_radial.toml", "ups_orientation_grid.toml"] {
            let (job, mut model) = described_job(file);
            assert!(model.preset.is_some(), "{file}");
            let source = SampleSource::new(&job);
            let n = source.len().min(8 * RUN);
            let (_, all) = solve_members(&[&model], Samples::Job(&source), 0..n, Mode::Kinetostatic, true);
            let mut conds: Vec<f64> = all[0].iter().map(|r| r.cond).filter(|c| c.is_finite()).collect();
            conds.sort_by(f64::total_cmp);
            assert!(conds.len() as u64 == n && conds[0] < conds[conds.len() - 1], "{file}: {conds:?}");
            model.singular_cond = conds[conds.len() * 9 / 10];
            let mut loose = model.clone();
            for g in &mut loose.groups {
                g.magnitude *= 2.0;
            }
            let members = [&model, &loose];
            let solved = |each: bool| solve_members(&members, Samples::Job(&source), 0..n, Mode::Kinetostatic, each).1;
            let (with, without) = (solved(true), solved(false));
            let (mut open, mut refused) = (0, 0);
            let largest = |rs: &[CustomResult]| {
                rs.iter()
                    .filter(|r| r.status != Status::Unreachable && r.cond.is_finite())
                    .map(|r| r.cond)
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            for (with, without) in with.iter().zip(&without) {
                let top = largest(with);
                assert_eq!(top.to_bits(), largest(without).to_bits(), "{file}");
                for (k, (a, b)) in with.iter().zip(without).enumerate() {
                    let mut b = b.clone();
                    if b.cond.is_nan() && !a.cond.is_nan() {
                        assert!(a.cond < top, "{file}: pose {k}: {} left open, the largest {top}", a.cond);
                        open += 1;
                        b.cond = a.cond;
                    }
                    refused += usize::from(a.status == Status::NearSingular);
                    assert_eq!(format!("{b:?}"), format!("{a:?}"), "{file}: pose {k}");
                }
            }
            assert!(open as u64 > n && refused > 0, "{file}: {open} open, {refused} refused of {n}");
        }
    }

    /// What the search solves without the condition number (`Wanted::WithoutCond`) is the
    /// whole pose's solve, bit for bit, but for `cond`: NaN where the bound accepted the
    /// pose, else `κ₂` itself. `singular_cond` is set among the poses' own condition
    /// numbers so that poses are accepted by the bound, by `κ₂` and refused, on a
    /// 3-PRS and a 6-UPS (their kernels) and a 3-RRS (the general path), in both modes.
    #[test]
    fn the_search_solves_poses_as_the_pass_but_for_the_condition_number() {
        for (file, preset) in
            [("fig08_r_radial.toml", true), ("ups_orientation_grid.toml", true), ("custom_3rrs_grid.toml", false)]
        {
            let mut model = described(file);
            assert_eq!(model.preset.is_some(), preset, "{file}");
            let n = model.geom.inputs.len();
            let home: Vec<f64> = model.geom.inputs.iter().map(|&k| model.geom.home[k]).collect();
            let poses: Vec<Vec<f64>> = (0..60)
                .map(|i| {
                    let t = i as f64 / 59.0;
                    (0..n).map(|k| home[k] + if k < n.saturating_sub(2) { 0.0 } else { 0.9 * (t - 0.5) }).collect()
                })
                .collect();
            let rates: Vec<f64> = (0..n).map(|k| 0.2 + 0.05 * k as f64).collect();
            let solve = |m: &CustomModel, x: &[f64], mode: Mode, with_cond: bool| {
                let wanted = if with_cond { Wanted::Whole } else { Wanted::WithoutCond };
                solve_members_near(&[m], x, Some((&rates, &rates)), mode, None, wanted).0.pop().unwrap()
            };
            let mut conds: Vec<f64> = poses
                .iter()
                .map(|x| solve(&model, x, Mode::Kinetostatic, true).cond)
                .filter(|c| c.is_finite())
                .collect();
            conds.sort_by(f64::total_cmp);
            assert!(conds.len() > 40 && conds[conds.len() - 1] < model.singular_cond, "{file}: {conds:?}");
            // The description's limit (the bound accepts every pose), then half the
            // poses above the limit (the bound, which exceeds κ₂ by up to six times,
            // decides none of the rest).
            let (mut by_bound, mut by_cond, mut refused) = (0, 0, 0);
            for limit in [model.singular_cond, conds[conds.len() / 2]] {
                model.singular_cond = limit;
                for mode in [Mode::Kinetostatic, Mode::Dynamic] {
                    for x in &poses {
                        let (with, mut without) = (solve(&model, x, mode, true), solve(&model, x, mode, false));
                        if without.cond.is_nan() && !with.cond.is_nan() {
                            by_bound += 1;
                            without.cond = with.cond;
                        } else if with.loaded() {
                            by_cond += 1;
                        } else {
                            refused += 1;
                        }
                        assert_eq!(format!("{without:?}"), format!("{with:?}"), "{file} at {x:?} ({mode:?})");
                    }
                }
            }
            assert!(by_bound > 0 && by_cond > 0 && refused > 0, "{file}: {by_bound} {by_cond} {refused}");
        }
    }
}
