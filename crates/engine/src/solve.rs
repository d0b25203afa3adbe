//! A job computed in memory: the rows of a run's `poses` as Arrow record batches,
//! no files (the Python package's `solve`).

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use arrow::array::{ArrayRef, RecordBatch, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use clearance_grid::{Sample, SampleSource};
use clearance_model::{JobSpec, Mode};
use clearance_parquet::{BlockSink, ColumnSet, PoseSchema};
use clearance_solver::{Blocks, Model, SolverKind};

use crate::error::EngineError;
use crate::progress::Reporter;

/// Poses given in place of the job's grid or trajectory, as values of the platform's
/// coordinates `x, y, z, φ, ψ, θ` (m, rad), each given or not: a 3-limb job takes
/// `z, ψ, θ` ([`Poses::new`]), a 6-UPS all six, a custom mechanism exactly its inputs.
/// Sample `i` has no time and no rates, so only kinetostatics can solve them. [`solve`]
/// refuses arrays of different lengths, values that are not finite and coordinates the
/// job does not take.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Poses {
    pub coords: [Option<Vec<f64>>; 6],
}

/// The coordinates' names, as a job and the Python package write them.
pub(crate) const COORDS: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];

impl Poses {
    /// `z`, `psi` and `theta`, the inputs of the 3-limb kinds.
    pub fn new(z: Vec<f64>, psi: Vec<f64>, theta: Vec<f64>) -> Self {
        Self { coords: [None, None, Some(z), None, Some(psi), Some(theta)] }
    }

    pub fn len(&self) -> usize {
        self.coords.iter().flatten().map(Vec::len).next().unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn value(&self, k: usize, i: usize) -> f64 {
        self.coords[k].as_ref().map_or(0.0, |v| v[i])
    }

    fn sample(&self, i: u64) -> Sample {
        let k = i as usize;
        Sample {
            index: i,
            t: None,
            z: [self.value(2, k), 0.0, 0.0],
            psi: [self.value(4, k), 0.0, 0.0],
            theta: [self.value(5, k), 0.0, 0.0],
        }
    }

    /// Sample `i` as every coordinate's value, rate and acceleration (zero where not given).
    pub(crate) fn sample6(&self, i: u64) -> (Option<f64>, [[f64; 3]; 6]) {
        (None, std::array::from_fn(|k| [self.value(k, i as usize), 0.0, 0.0]))
    }

    /// Refuses poses that `job` cannot take: coordinates it does not take or that are
    /// missing, arrays of different lengths, values that are not finite, a job with
    /// dynamics.
    fn check(&self, job: &JobSpec, file: &str) -> Result<(), EngineError> {
        use clearance_model::MechanismKind;
        let given: Vec<usize> = (0..6).filter(|&k| self.coords[k].is_some()).collect();
        let names = |ks: &[usize]| list(&ks.iter().map(|&k| COORDS[k]).collect::<Vec<_>>());
        let (wanted, whose): (Vec<usize>, String) = match job.mechanism.kind {
            MechanismKind::Custom => {
                let d = job.description(file).ok_or_else(|| EngineError::Samples("not a custom job".into()))??;
                (d.inputs.clone(), "this custom mechanism's inputs".into())
            }
            MechanismKind::Ups6 => ((0..6).collect(), "a 6-UPS's poses".into()),
            _ => (vec![2, 4, 5], "the poses of a 3-limb kind".into()),
        };
        if let Some(&k) = given.iter().find(|k| !wanted.contains(k)) {
            return Err(EngineError::Samples(format!(
                "{} is not one of {whose} ({}): give those, or none of them for the job's own poses",
                COORDS[k],
                names(&wanted)
            )));
        }
        let missing: Vec<usize> = wanted.iter().copied().filter(|k| !given.contains(k)).collect();
        if !missing.is_empty() {
            return Err(EngineError::Samples(format!(
                "{} missing: give all of {} (a number is broadcast), or none of them for the job's own poses",
                missing.iter().map(|&k| COORDS[k]).collect::<Vec<_>>().join(" and "),
                names(&wanted)
            )));
        }
        let lengths: Vec<usize> = given.iter().map(|&k| self.coords[k].as_ref().map_or(0, Vec::len)).collect();
        if lengths.iter().any(|&n| n != lengths[0]) {
            return Err(EngineError::Samples(format!(
                "{} must have the same length, got {}",
                names(&given),
                list(&lengths.iter().map(usize::to_string).collect::<Vec<_>>())
            )));
        }
        // A NaN or infinite input is the caller's mistake, refused before anything
        // is computed, as the job's own inputs are: solved, it would come back as
        // rows of a status that blames the mechanism.
        for &k in &given {
            let values = self.coords[k].as_ref().expect("given");
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(EngineError::Samples(format!(
                    "{}[{i}] is {}: a pose's {} must be finite numbers",
                    COORDS[k],
                    values[i],
                    names(&given)
                )));
            }
        }
        if job.analysis.modes.contains(&Mode::Dynamic) {
            return Err(EngineError::Samples(format!(
                "poses given as {} have no velocities: set `analysis.modes = [\"kinetostatic\"]` \
                 or solve the job's trajectory",
                given.iter().map(|&k| COORDS[k]).collect::<Vec<_>>().join(", ")
            )));
        }
        Ok(())
    }
}

/// `a`, `a and b`, `a, b and c`.
fn list<S: AsRef<str>>(items: &[S]) -> String {
    match items {
        [] => String::new(),
        [one] => one.as_ref().to_string(),
        [rest @ .., last] => {
            format!("{} and {}", rest.iter().map(|s| s.as_ref()).collect::<Vec<_>>().join(", "), last.as_ref())
        }
    }
}

/// How to solve a job in memory.
#[derive(Clone, Debug)]
pub struct SolveOptions {
    /// The columns, as `--columns` of a run (default: standard).
    pub columns: ColumnSet,
    pub solver: SolverKind,
    /// Samples in place of the job's (`None`: the job's grid or trajectory).
    pub poses: Option<Poses>,
    /// Told how far the computation is; nothing by default.
    pub progress: Reporter,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self { columns: ColumnSet::Standard, solver: SolverKind::Fast, poses: None, progress: Reporter::default() }
    }
}

thread_local! {
    /// This thread's buffers for solving a block, kept from call to call: fresh ones
    /// are hundreds of kilobytes of results to allocate and fault in, once for each
    /// piece of each call of an optimiser's loop.
    static BLOCKS: std::cell::RefCell<Blocks> = std::cell::RefCell::default();
}

/// `f` with this thread's [`BLOCKS`] (fresh ones if they are in use).
fn with_blocks<T>(f: impl FnOnce(&mut Blocks) -> T) -> T {
    BLOCKS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut blocks) => f(&mut blocks),
        Err(_) => f(&mut Blocks::default()),
    })
}

/// Calls `fill` on every block (with its index), on the calling thread and the
/// pool's threads at once, each taking the next block not yet taken.
///
/// The calling thread starts at once. Handing every block to the pool made each
/// call wait for the pool's threads to wake, 30 to 50 µs (measured), a tenth of
/// a call of a few thousand poses. A call from inside the pool counts its own
/// thread among the pool's.
fn fill_blocks<'a>(sinks: Vec<BlockSink<'a>>, fill: impl Fn((usize, BlockSink<'a>)) + Sync) {
    let count = sinks.len();
    let blocks: Vec<Mutex<Option<BlockSink<'a>>>> = sinks.into_iter().map(|s| Mutex::new(Some(s))).collect();
    let next = AtomicUsize::new(0);
    let work = || {
        loop {
            let b = next.fetch_add(1, Ordering::Relaxed);
            let Some(block) = blocks.get(b) else { break };
            let sink = block.lock().unwrap_or_else(|e| e.into_inner()).take().expect("each block is taken once");
            fill((b, sink));
        }
    };
    let pool = rayon::current_num_threads();
    let helpers = if rayon::current_thread_index().is_some() { pool - 1 } else { pool };
    rayon::in_place_scope(|scope| {
        for _ in 0..helpers.min(count.saturating_sub(1)) {
            scope.spawn(|_| work());
        }
        work();
    });
}

/// At most this many samples are solved and put into columns at a time, by one thread.
const BLOCK: usize = 1024;

/// Rows a thread takes at a time for `n` rows: at most [`BLOCK`], and small enough
/// that a call of a few thousand rows (an optimiser's loop) gives every thread a
/// dozen blocks or more, so that they finish together; multiples of 64 (the
/// batched kernel takes eight at a time).
fn block_rows(n: usize) -> usize {
    n.div_ceil(16 * rayon::current_num_threads()).next_multiple_of(64).clamp(64, BLOCK)
}

/// The `poses` schema of a column set, and the batches' schema (a `variant` column
/// first), built once a process: a loop of small calls would otherwise spend a
/// good part of its time naming columns.
fn schemas(set: ColumnSet, exact: bool) -> &'static (PoseSchema, SchemaRef) {
    static SCHEMAS: [[OnceLock<(PoseSchema, SchemaRef)>; 2]; 3] = [const { [const { OnceLock::new() }; 2] }; 3];
    SCHEMAS[set as usize][exact as usize].get_or_init(|| {
        let schema = PoseSchema::new(set, exact);
        let mut fields = vec![Arc::new(Field::new("variant", DataType::UInt64, false))];
        fields.extend(schema.schema().fields().iter().cloned());
        let out = Arc::new(Schema::new_with_metadata(fields, schema.schema().metadata().clone()));
        (schema, out)
    })
}

/// Every (variant, mode) of `job` solved on the current rayon pool, one record
/// batch each, in the order of a run's units: a `variant` column (UInt64), then
/// exactly the columns, values and nulls of the run's part files (tested).
pub fn solve(job: &JobSpec, file: &str, opts: &SolveOptions) -> Result<Vec<RecordBatch>, EngineError> {
    solve_range(job, file, opts, None)
}

/// [`solve`] of the samples `range` of the job's grid or trajectory (all of them for
/// `None`), each variant and mode: a long job a piece at a time.
pub(crate) fn solve_range(
    job: &JobSpec,
    file: &str,
    opts: &SolveOptions,
    range: Option<std::ops::Range<u64>>,
) -> Result<Vec<RecordBatch>, EngineError> {
    crate::run::check_solver(job, opts.solver)?;
    if let Some(p) = &opts.poses {
        p.check(job, file)?;
    }
    if job.mechanism.kind == clearance_model::MechanismKind::Custom {
        return crate::custom::solve_custom_job(job, file, opts.columns, range, opts.poses.as_ref());
    }
    if job.mechanism.kind == clearance_model::MechanismKind::Ups6 {
        return crate::ups::solve_ups(job, file, opts.columns, range, opts.poses.as_ref());
    }
    let variants = job.variants(file)?;
    let n = opts.poses.as_ref().map_or(job.sample_count(), |p| p.len() as u64);
    let range = range.unwrap_or(0..n);
    let (offset, n) = (range.start, range.end.min(n).saturating_sub(range.start));
    let (schema, out_schema) = schemas(opts.columns, job.analysis.exact);
    let block = block_rows(n as usize);
    let progress = opts.progress.get();
    progress.start(n * variants.len() as u64 * job.analysis.modes.len() as u64, 0);
    let done = AtomicU64::new(0);
    let mut batches = Vec::new();
    for v in &variants {
        let mut model = Model::from_job(&v.job);
        model.solver = opts.solver;
        // The envelope and the dominant joint are columns of the standard set.
        model.envelope = opts.columns >= ColumnSet::Standard;
        // The minimal set reads the totals alone, and nothing here searches.
        model.totals_only = opts.columns == ColumnSet::Minimal;
        let source = SampleSource::new(&v.job);
        let sample = |i: u64| match &opts.poses {
            Some(p) => p.sample(i),
            None => source.sample(i),
        };
        for &mode in &job.analysis.modes {
            progress.stage(&format!("variant {} {}", v.index, mode.name()));
            let mut cols = schema.columns(n as usize);
            let fill = |blocks: &mut Blocks, (b, mut sink): (usize, BlockSink<'_>)| {
                let first = offset + (b * block) as u64;
                let (samples, results) =
                    blocks.solve_samples(&model, (first..first + sink.len() as u64).map(sample), mode);
                for (i, (s, r)) in samples.iter().zip(results.iter()).enumerate() {
                    sink.put(i, s, r);
                }
                let len = samples.len() as u64;
                progress.advance(len, done.fetch_add(len, Ordering::Relaxed) + len);
            };
            fill_blocks(cols.blocks(schema, block), |b| with_blocks(|blocks| fill(blocks, b)));
            let batch = schema.finish(mode, cols);
            let mut columns: Vec<ArrayRef> = vec![Arc::new(UInt64Array::from_value(v.index, batch.num_rows()))];
            columns.extend(batch.columns().iter().cloned());
            batches.push(RecordBatch::try_new(out_schema.clone(), columns).expect("columns match the schema"));
        }
    }
    progress.finish();
    Ok(batches)
}

/// `batch` with a leading `variant` column (UInt64) holding `variant`: a row of
/// [`solve`]'s output, as a run's part file is read back with its Hive path.
pub(crate) fn with_variant(batch: &RecordBatch, variant: u64) -> RecordBatch {
    use arrow::array::{ArrayRef, UInt64Array};
    use arrow::datatypes::{DataType, Field, Schema};
    use std::sync::Arc;
    let mut fields = vec![Arc::new(Field::new("variant", DataType::UInt64, false))];
    fields.extend(batch.schema().fields().iter().cloned());
    let mut columns: Vec<ArrayRef> = vec![Arc::new(UInt64Array::from_value(variant, batch.num_rows()))];
    columns.extend(batch.columns().iter().cloned());
    RecordBatch::try_new(Arc::new(Schema::new(fields)), columns).expect("columns match the schema")
}
