//! The native half of the Python package `clearance` (python/clearance/__init__.py
//! is the other): the engine's `solve`, `run`, `plan` and the plots, with the GIL
//! released while they compute. Record batches reach pyarrow through Arrow's C
//! data interface: the buffers are handed over, not copied.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use arrow::array::{Array, RecordBatch, StructArray};
use arrow::datatypes::SchemaRef;
use arrow::ffi::{FFI_ArrowArray, FFI_ArrowSchema};
use clearance_engine::{
    Codec, ColumnSet, EngineError, JobSpec, OutputDirError, Poses, Precision, Progress, Reporter, RunOptions,
    SolveOptions, SolverKind, Writer,
};
use clearance_plot::PlotError;
use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyMapping, PyString, PyTuple};

create_exception!(_clearance, JobError, PyValueError, "A job that is not valid; the message is the CLI's.");

/// A job as the engine takes it: the spec and the name its messages use.
struct Job {
    spec: JobSpec,
    file: String,
}

/// The jobs given as text most recently, by (kind, text): an optimiser calls
/// `solve` in a loop with a few jobs, and parsing and checking one is a good part
/// of a small call.
static RECENT_JOBS: Mutex<Vec<(String, String, Arc<Job>)>> = Mutex::new(Vec::new());

/// Jobs [`RECENT_JOBS`] keeps.
const RECENT: usize = 8;

/// [`load_job`], from [`RECENT_JOBS`] when the same text was given lately. A job
/// file is read each time: it may have changed.
fn cached_job(kind: &str, value: &str) -> PyResult<Arc<Job>> {
    if kind == "path" {
        return load_job(kind, value).map(Arc::new);
    }
    let mut recent = RECENT_JOBS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = recent.iter().position(|(k, v, _)| k == kind && v == value) {
        let hit = recent.remove(i);
        let job = hit.2.clone();
        recent.push(hit);
        return Ok(job);
    }
    let job = Arc::new(load_job(kind, value)?);
    keep_newest(&mut recent, (kind.to_string(), value.to_string(), job.clone()), RECENT);
    Ok(job)
}

/// Adds `item` to the newest end of `store`, dropping the oldest beyond `kept`: the
/// module's stores of jobs, pools and schemas.
fn keep_newest<T>(store: &mut Vec<T>, item: T, kept: usize) {
    if store.len() == kept {
        store.remove(0);
    }
    store.push(item);
}

/// `kind` is `path` (a TOML file) or `toml` (its text, or a dict's from [`dict_toml`]).
fn load_job(kind: &str, value: &str) -> PyResult<Job> {
    let job_error = |e: clearance_engine::JobError| JobError::new_err(e.to_string());
    match kind {
        "path" => {
            let spec = JobSpec::from_path(std::path::Path::new(value)).map_err(job_error)?;
            Ok(Job { spec, file: value.to_string() })
        }
        "toml" => Ok(Job { spec: JobSpec::from_toml_str(value, "job").map_err(job_error)?, file: "job".into() }),
        _ => Err(PyValueError::new_err(format!("unknown job kind {kind:?}"))),
    }
}

/// A job given as a dict, as TOML text. Not through JSON: it has no NaN, and a NaN
/// must reach the job's own check (`must be a finite number`) as it does from a
/// file. A value a job cannot hold is named by where it is (`job['grid']['z']`).
#[pyfunction]
fn dict_toml(job: &Bound<'_, PyAny>) -> PyResult<String> {
    let value = toml_value(job, "job", false)?;
    toml::to_string(&value).map_err(|e| JobError::new_err(format!("job: {e}")))
}

/// `v` as a TOML value; `at` is where it is in the job. NumPy scalars and arrays
/// are taken through their `tolist()` (once: `converted`).
fn toml_value(v: &Bound<'_, PyAny>, at: &str, converted: bool) -> PyResult<toml::Value> {
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(toml::Value::Boolean(b.is_true()));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_cow()?.into_owned()));
    }
    if v.cast::<PyInt>().is_ok() {
        return v
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| PyValueError::new_err(format!("{at}: {v} does not fit in a 64-bit integer")));
    }
    if let Ok(f) = v.cast::<PyFloat>() {
        return Ok(toml::Value::Float(f.value()));
    }
    if let Ok(m) = v.cast::<PyMapping>() {
        let mut table = toml::Table::new();
        for item in m.items()?.iter() {
            let (key, value): (Bound<'_, PyAny>, Bound<'_, PyAny>) = item.extract()?;
            let Ok(key) = key.cast::<PyString>() else {
                let kind = key.get_type().name()?;
                return Err(PyTypeError::new_err(format!("{at}: keys must be strings, got {key} ({kind})")));
            };
            let key = key.to_cow()?;
            table.insert(key.to_string(), toml_value(&value, &format!("{at}['{key}']"), false)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if v.cast::<PyList>().is_ok() || v.cast::<PyTuple>().is_ok() {
        let items = v.try_iter()?.enumerate().map(|(i, item)| toml_value(&item?, &format!("{at}[{i}]"), false));
        return items.collect::<PyResult<_>>().map(toml::Value::Array);
    }
    if v.is_none() {
        return Err(PyTypeError::new_err(format!("{at}: None is not a value of a job; leave the key out")));
    }
    if !converted && v.hasattr("tolist")? {
        return toml_value(&v.call_method0("tolist")?, at, true);
    }
    let kind = v.get_type().name()?;
    Err(PyTypeError::new_err(format!("{at}: a job holds numbers, strings, bools, lists and dicts, not {kind}")))
}

/// An error and its causes, each once, joined by `: `.
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut msg = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        msg.push_str(": ");
        msg.push_str(&s.to_string());
        source = s.source();
    }
    msg
}

/// An engine error as a Python exception, its causes once each. The engine's
/// messages name the command line's flags; those about the arguments of `run`
/// are worded here with the Python ones.
fn to_py(e: EngineError) -> PyErr {
    match e {
        EngineError::Job(_) => JobError::new_err(with_causes(&e)),
        EngineError::OutputDir(e) => PyValueError::new_err(out_dir_message(&e)),
        EngineError::Samples(_) | EngineError::Allocation(_) | EngineError::Unsupported(_) => {
            PyValueError::new_err(with_causes(&e))
        }
        EngineError::MissingStats { path, source } => {
            PyOSError::new_err(format!("missing {}: finish the run with resume=True: {source}", path.display()))
        }
        EngineError::Io { .. } => PyOSError::new_err(with_causes(&e)),
        _ => PyRuntimeError::new_err(with_causes(&e)),
    }
}

/// Why `out` cannot take the run, and what to pass instead.
fn out_dir_message(e: &OutputDirError) -> String {
    match e {
        OutputDirError::NotEmpty { dir } => format!(
            "out: {} is not empty; pass resume=True to finish the run in it, overwrite=True to replace it, \
             or choose another out",
            dir.display()
        ),
        OutputDirError::OtherJob { dir } => {
            format!(
                "out: {} holds a different job; pass overwrite=True to replace it, or choose another out",
                dir.display()
            )
        }
        // overwrite=True would refuse too (NotARunToOverwrite): only another folder will do.
        OutputDirError::NotARun { dir } => {
            format!("out: {} holds files that are not a clearance run; choose another out", dir.display())
        }
        OutputDirError::NotARunToOverwrite { dir } => format!(
            "out: {} holds files that are not a clearance run (no job.toml); overwrite=True replaces only a run: \
             choose another out",
            dir.display()
        ),
        OutputDirError::OtherOptions { dir, option, was, now } => {
            let arg = option.trim_start_matches('-');
            format!(
                "out: {} holds part files written with {arg}='{was}'; resume it with the same (this run asks for \
                 {arg}='{now}'), or pass overwrite=True",
                dir.display()
            )
        }
        OutputDirError::OtherChunks { dir, part, was, now, chunk } => format!(
            "out: {} holds parts cut with another chunk_size ({part} has {was} samples, {now} with \
             chunk_size={chunk}); resume it with the chunk_size it was started with, or pass overwrite=True",
            dir.display()
        ),
    }
}

/// A plot error as a Python exception: a folder that is no finished run is the
/// `dir` given.
fn plot_to_py(e: PlotError) -> PyErr {
    let msg = with_causes(&e);
    match e {
        PlotError::NotARun { .. } | PlotError::Unsupported { .. } => PyValueError::new_err(format!("dir: {msg}")),
        PlotError::Job(_) => JobError::new_err(msg),
        PlotError::Io { .. } | PlotError::Parquet { .. } | PlotError::Arrow { .. } => PyOSError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

/// `'a', 'b' or 'c'`.
fn one_of(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
    match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

fn columns(name: &str) -> PyResult<ColumnSet> {
    ColumnSet::parse(name).ok_or_else(|| {
        PyValueError::new_err(format!("columns must be {}, got '{name}'", one_of(&["minimal", "standard", "full"])))
    })
}

fn solver(name: &str) -> PyResult<SolverKind> {
    match name {
        "fast" => Ok(SolverKind::Fast),
        "general" => Ok(SolverKind::General),
        _ => Err(PyValueError::new_err(format!("solver must be {}, got '{name}'", one_of(&["fast", "general"])))),
    }
}

/// Calls `callback(done, total)` at most every 100 ms and once at the end, from
/// whichever pool thread has news, taking the GIL only then.
struct PyProgress {
    callback: Py<PyAny>,
    state: Mutex<(Instant, u64)>,
}

impl PyProgress {
    fn reporter(callback: Option<Py<PyAny>>) -> Reporter {
        match callback {
            None => Reporter::default(),
            Some(callback) => Reporter::new(Arc::new(PyProgress {
                callback,
                state: Mutex::new((Instant::now() - Duration::from_secs(1), 0)),
            })),
        }
    }

    fn call(&self, done: u64, total: u64) {
        Python::attach(|py| {
            // A failing callback must not stop the computation.
            let _ = self.callback.call1(py, (done, total));
        });
    }
}

impl Progress for PyProgress {
    fn start(&self, total: u64, done: u64) {
        *self.state.lock().expect("no panic while held") = (Instant::now(), total);
        self.call(done, total);
    }

    fn advance(&self, _n: u64, done: u64) {
        let mut state = self.state.lock().expect("no panic while held");
        let total = state.1;
        if state.0.elapsed() >= Duration::from_millis(100) || done == total {
            state.0 = Instant::now();
            drop(state);
            self.call(done, total);
        }
    }
}

/// Runs `f` on a pool of `threads` threads, or on the global pool.
///
/// Starting threads on every call would cost a loop of small calls more than its
/// poses, so pools are kept. A call takes a pool of its size out of the store
/// and puts it back when done: calls from several Python threads each get a pool
/// of their own and overlap.
fn on_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    /// Idle pools, by size; at most [`KEPT`].
    static IDLE: Mutex<Vec<(usize, rayon::ThreadPool)>> = Mutex::new(Vec::new());
    const KEPT: usize = 4;
    let Some(n) = threads.map(|n| n.max(1)) else { return Ok(f()) };
    let idle = || IDLE.lock().unwrap_or_else(|e| e.into_inner());
    let kept = {
        let mut pools = idle();
        pools.iter().position(|(size, _)| *size == n).map(|i| pools.swap_remove(i).1)
    };
    let pool = match kept {
        Some(pool) => pool,
        None => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?,
    };
    let out = pool.install(f);
    keep_newest(&mut idle(), (n, pool), KEPT);
    Ok(out)
}

/// A record batch as a `pyarrow.RecordBatch`, its buffers moved, not copied.
fn to_pyarrow<'py>(py: Python<'py>, batch: RecordBatch) -> PyResult<Bound<'py, PyAny>> {
    let schema = pyarrow_schema(py, &batch.schema())?;
    let data = StructArray::from(batch).into_data();
    let array = Box::new(FFI_ArrowArray::new(&data));
    let class = py.import("pyarrow")?.getattr("RecordBatch")?;
    // pyarrow moves the structure out (its release callback goes with it); the
    // emptied box is dropped here.
    class.call_method1("_import_from_c", (&*array as *const FFI_ArrowArray as usize, schema))
}

/// `schema` as a `pyarrow.Schema`, imported once for each schema: importing a
/// hundred fields with their units took a good part of a small `solve` call.
fn pyarrow_schema<'py>(py: Python<'py>, schema: &SchemaRef) -> PyResult<Bound<'py, PyAny>> {
    static IMPORTED: Mutex<Vec<(SchemaRef, Py<PyAny>)>> = Mutex::new(Vec::new());
    const KEPT: usize = 16;
    // Not held while Python runs: another thread may hold the GIL and wait for it.
    let imported = || IMPORTED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, py_schema)) = imported().iter().find(|(s, _)| Arc::ptr_eq(s, schema) || **s == **schema) {
        return Ok(py_schema.bind(py).clone());
    }
    let ffi = Box::new(FFI_ArrowSchema::try_from(schema.as_ref()).map_err(|e| PyRuntimeError::new_err(e.to_string()))?);
    let py_schema = py
        .import("pyarrow")?
        .getattr("Schema")?
        .call_method1("_import_from_c", (&*ffi as *const FFI_ArrowSchema as usize,))?;
    keep_newest(&mut imported(), (schema.clone(), py_schema.clone().unbind()), KEPT);
    Ok(py_schema)
}

#[pyfunction]
#[pyo3(signature = (kind, value, columns_name, solver_name, x=None, y=None, z=None, phi=None, psi=None, theta=None, threads=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn solve<'py>(
    py: Python<'py>,
    kind: &str,
    value: &str,
    columns_name: &str,
    solver_name: &str,
    x: Option<&[u8]>,
    y: Option<&[u8]>,
    z: Option<&[u8]>,
    phi: Option<&[u8]>,
    psi: Option<&[u8]>,
    theta: Option<&[u8]>,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let job = cached_job(kind, value)?;
    let floats = |b: &[u8]| -> Vec<f64> {
        b.chunks_exact(8).map(|c| f64::from_ne_bytes(c.try_into().expect("8 bytes"))).collect()
    };
    let coords = [x, y, z, phi, psi, theta].map(|b| b.map(floats));
    let poses = coords.iter().any(Option::is_some).then_some(Poses { coords });
    let opts = SolveOptions {
        columns: columns(columns_name)?,
        solver: solver(solver_name)?,
        poses,
        progress: PyProgress::reporter(progress),
    };
    let batches =
        py.detach(|| on_pool(threads, || clearance_engine::solve(&job.spec, &job.file, &opts)))?.map_err(to_py)?;
    let list = PyList::empty(py);
    for b in batches {
        list.append(to_pyarrow(py, b)?)?;
    }
    Ok(list)
}

#[pyfunction]
#[pyo3(signature = (kind, value, out, threads=None, shard=None, resume=false, overwrite=false, columns_name="standard", compression="zstd", precision="double", chunk_size=65536, direct_io=true, progress=None, solver_name="fast", writer_name="engine"))]
#[allow(clippy::too_many_arguments)]
fn run(
    py: Python<'_>,
    kind: &str,
    value: &str,
    out: PathBuf,
    threads: Option<usize>,
    shard: Option<(u64, u64)>,
    resume: bool,
    overwrite: bool,
    columns_name: &str,
    compression: &str,
    precision: &str,
    chunk_size: u64,
    direct_io: bool,
    progress: Option<Py<PyAny>>,
    solver_name: &str,
    writer_name: &str,
) -> PyResult<(u64, u64, f64, bool)> {
    let job = load_job(kind, value)?;
    let writer = Writer::parse(writer_name).ok_or_else(|| {
        PyValueError::new_err(format!("writer must be {}, got '{writer_name}'", one_of(&Writer::NAMES)))
    })?;
    let precision = Precision::parse(precision).ok_or_else(|| {
        PyValueError::new_err(format!("precision must be {}, got '{precision}'", one_of(&Precision::NAMES)))
    })?;
    if let Some((i, n)) = shard
        && i >= n
    {
        return Err(PyValueError::new_err(format!("shard must be a pair (i, n) with 0 <= i < n, got ({i}, {n})")));
    }
    if chunk_size == 0 {
        return Err(PyValueError::new_err("chunk_size must be a positive int, got 0"));
    }
    // "none": the standard set's quantities for the summary, no pose file.
    let poses = columns_name != "none";
    let opts = RunOptions {
        out,
        columns: if poses { columns(columns_name)? } else { ColumnSet::Standard },
        shard,
        resume,
        overwrite,
        chunk_size,
        solver: solver(solver_name)?,
        compression: Codec::parse(compression).ok_or_else(|| {
            PyValueError::new_err(format!("compression must be {}, got '{compression}'", one_of(&Codec::NAMES)))
        })?,
        writer,
        precision,
        progress: PyProgress::reporter(progress),
        direct_io,
        search: true,
        poses,
    };
    let r = py.detach(|| on_pool(threads, || clearance_engine::run(&job.spec, &job.file, &opts)))?.map_err(to_py)?;
    Ok((r.computed, r.total, r.seconds, r.complete))
}

/// The plan as JSON text.
#[pyfunction]
fn check(kind: &str, value: &str) -> PyResult<String> {
    let job = load_job(kind, value)?;
    let plan = clearance_engine::plan(&job.spec, &job.file).map_err(to_py)?;
    Ok(serde_json::to_string(&plan).expect("a plan is plain data"))
}

#[pyfunction]
#[pyo3(signature = (dir, out=None))]
fn plot(py: Python<'_>, dir: PathBuf, out: Option<PathBuf>) -> PyResult<Vec<PathBuf>> {
    let out = out.unwrap_or_else(|| clearance_engine::Layout::new(&dir).plots());
    py.detach(|| clearance_plot::plot_run(&dir, &out)).map_err(plot_to_py)
}

/// Caps the vector instruction set (`portable`, `avx2`, `avx512`) of the whole process.
#[pyfunction]
fn cap_isa(name: &str) -> PyResult<()> {
    let isa = clearance_engine::Isa::parse(name)
        .ok_or_else(|| PyValueError::new_err(format!("{name:?} is not portable, avx2 or avx512")))?;
    clearance_engine::cap_isa(isa);
    Ok(())
}

/// `clearance allocate` in memory: `allocation.json` as text.
#[pyfunction]
#[pyo3(signature = (kind, value, max_dp, max_dalpha=None, model="takeup", per_limb=false, threads=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn allocate(
    py: Python<'_>,
    kind: &str,
    value: &str,
    max_dp: f64,
    max_dalpha: Option<f64>,
    model: &str,
    per_limb: bool,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let job = cached_job(kind, value)?;
    let model = clearance_engine::AllocModel::parse(model).ok_or_else(|| {
        PyValueError::new_err(format!("model must be {}, got {model:?}", one_of(&["takeup", "envelope"])))
    })?;
    let mut opts = clearance_engine::AllocateOptions::new(max_dp);
    opts.max_dalpha = max_dalpha;
    opts.model = model;
    opts.per_limb = per_limb;
    opts.progress = PyProgress::reporter(progress);
    let a =
        py.detach(|| on_pool(threads, || clearance_engine::allocate(&job.spec, &job.file, &opts)))?.map_err(to_py)?;
    Ok(a.to_json().to_string())
}

#[pymodule]
fn _clearance(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("JobError", m.py().get_type::<JobError>())?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(allocate, m)?)?;
    m.add_function(wrap_pyfunction!(plot, m)?)?;
    m.add_function(wrap_pyfunction!(cap_isa, m)?)?;
    m.add_function(wrap_pyfunction!(dict_toml, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
