//! A run: a job → a directory of Parquet files ([`Layout`]).
//!
//! The work is cut into units (variant, mode, chunk of samples). A unit is one part
//! file, `poses/variant=K/part-<mode>-<chunk>.parquet`, written under a temporary
//! name and renamed when complete, so a unit either exists whole or not at all:
//! `--resume` skips the units that exist. Variants that differ only in their
//! clearance magnitudes form a [`Group`] solved once ([`crate::groups`]): the units
//! of a group for one (mode, chunk) are one [`Work`], and a shard `I/N` computes the
//! work whose number is `I` modulo `N`. Within a work, poses are spread over the
//! rayon pool; each unit's part goes to a writer thread as soon as it is concluded,
//! and the grid lines the work completes are searched for discontinuities
//! ([`Search`]), once for its group, in batches that the threads take up as the
//! next work's computation runs out of pages.

use std::path::{Path, PathBuf};
use std::sync::mpsc::sync_channel;
use std::time::Instant;

use arrow::record_batch::RecordBatch;
use clearance_discontinuity::{
    BATCHES_PER_THREAD, Batch, Discontinuity, Loads, Sampled, Search, SearchOptions, Trace, axes,
    find_discontinuities_read, keep_local_minima, keep_local_minima_of, searched_along, trace_into,
};
use clearance_grid::{SampleSource, chunks};
use clearance_model::{JobSpec, Mode, Variant};
use clearance_parquet::{
    BlockSink, Codec, ColumnSet, ENGINE_VERSION, PAGE_ROWS, PageBuffer, PageWriter, PartPages, PoseSchema, Precision,
    SummaryRow, SummaryStats, TAIL_PAGE_ROWS, WriteOptions, Writer, discontinuity_batch, summary_batch, with_precision,
    write_batch_arrow, write_bytes, write_parquet, write_part,
};
use clearance_solver::{Blocks, Model, SolverKind};
use rayon::prelude::*;

use crate::error::{EngineError, OutputDirError};
use crate::groups::{Group, groups, membership};
use crate::layout::Layout;
use crate::progress::Reporter;

type Result<T, E = EngineError> = std::result::Result<T, E>;

/// How to run a job.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub out: PathBuf,
    pub columns: ColumnSet,
    /// `(I, N)`: compute only shard I of N.
    pub shard: Option<(u64, u64)>,
    pub resume: bool,
    pub overwrite: bool,
    /// Samples per part file.
    pub chunk_size: u64,
    pub solver: SolverKind,
    pub compression: Codec,
    /// The encoder of the `poses` part files: the engine's own pages (the default)
    /// or `parquet`'s `ArrowWriter`. Both give the same table.
    pub writer: Writer,
    /// How the error, envelope and margin columns of the part files are stored
    /// (`--precision`): `float64`, or `float32` ([`Precision::Single`]).
    pub precision: Precision,
    /// Told how far the run is; nothing by default.
    pub progress: Reporter,
    /// Part files past the page cache where the disk allows ([`WriteOptions::direct_io`]).
    pub direct_io: bool,
    /// Whether the run searches for switches: true for every run a user makes. False
    /// only to measure what the search costs (`clearance bench --suite` runs each job
    /// both ways): the run is then written whole but for its switches, and
    /// `discontinuities.parquet` is empty.
    pub search: bool,
    /// Whether the poses' rows are written (`poses/` part files). False for
    /// `--columns none`: every pose is still computed with the standard columns'
    /// quantities, for `summary.parquet` and the switches of
    /// `discontinuities.parquet`, but no part file is written.
    pub poses: bool,
}

/// What a run did.
#[derive(Clone, Debug, Default)]
pub struct RunReport {
    /// Poses this invocation computed (resumed and other shards' units excluded).
    pub computed: u64,
    /// Poses of the whole job.
    pub total: u64,
    pub seconds: f64,
    pub complete: bool,
    /// Where the time went.
    pub stages: StageTimes,
}

/// Busy seconds of each stage of a run, measured on the run's own clock. The stages
/// overlap (the writer thread works beside the pool, a work is concluded while the
/// next computes, and the grid lines it completes are searched as that computation
/// runs out of pages), so their sum may exceed [`RunReport::seconds`]; each against
/// it is the share of the run's wall time that stage was under way.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Solving the poses and putting them into columns, on the pool; with
    /// [`Writer::Engine`] this includes encoding their pages, which the thread that
    /// computed the rows does at once.
    pub pose_pass: f64,
    /// The discontinuity search: taking each work's traces in, and from the start of
    /// the first batch of the grid lines or path they complete to the end of the last
    /// ([`run`]); the search at the end of a sharded, resumed or very long run.
    pub search: f64,
    /// The writer threads (part files, statistics and trace files; with
    /// [`Writer::Arrow`] the part's encoding too; their mean busy time, when there
    /// are several), `discontinuities.parquet` and `summary.parquet`, and the sync
    /// of every file before `_SUCCESS`. The last two may be written while the
    /// writers finish the last parts, so this busy time can exceed the run's wall
    /// time (at most twice it).
    pub writing: f64,
    /// The step that finishes the run once every part is in, on its own: the search
    /// of whatever was not searched as it was computed (everything, after a resumed
    /// run), or the merge of the shards' switches, and the run's final files. After
    /// shards, only the invocation that finishes the run has it.
    pub finish: f64,
    /// The thread-seconds the pool's threads spent in the run's tasks (computing
    /// pages, concluding units, searching batches of grid lines), over the number of
    /// threads: against the wall time, the share of the pool's time that had work.
    /// Beside the process's CPU time it tells idle threads (no task to take) from
    /// threads in a task but off the CPU (blocked on a lock, a page fault, the
    /// disk). Counted by the 3-limb path; 0 for the other kinds.
    pub pool_tasks: f64,
    /// The seconds pool threads spent blocked handing finished parts to the writer
    /// threads, whose queue was full (included in [`StageTimes::pool_tasks`] ×
    /// threads). Counted by the 3-limb path; 0 for the other kinds.
    pub queue_wait: f64,
}

/// One part file's worth of work.
#[derive(Clone, Debug)]
pub(crate) struct Unit {
    pub(crate) variant: u64,
    pub(crate) mode: Mode,
    pub(crate) chunk: u64,
    pub(crate) range: std::ops::Range<u64>,
}

/// The units that share one solve: the parts of a [`Group`]'s variants (or of as
/// many of them as [`SHARED_ROWS`] and [`SHARED_PARTS`] allow) for one (mode,
/// chunk). Work is numbered in the order (group, mode, chunk), and shard `I/N`
/// computes the work whose number is `I` modulo `N`; a job whose variants are all
/// alone numbers its units as (variant, mode, chunk).
#[derive(Clone, Debug)]
pub(crate) struct Work {
    pub(crate) number: u64,
    /// Index of its group among the run's.
    pub(crate) group: usize,
    /// The units to compute, in member order (with `--resume`, those not complete).
    pub(crate) units: Vec<Unit>,
}

/// The most rows of parts, and the most parts, one [`Work`] holds: a group with
/// more members than fit is solved once per batch of members. A work's parts are in
/// memory until written (encoded, about 60 % of 8 bytes a value, in page buffers of
/// their own), and two works are in flight at once.
const SHARED_ROWS: u64 = 1 << 18;
const SHARED_PARTS: u64 = 16;

pub(crate) fn works(job: &JobSpec, groups: &[Group], chunk_size: u64) -> Vec<Work> {
    let n = job.sample_count();
    let per_work = (SHARED_ROWS / chunk_size.min(n).max(1)).clamp(1, SHARED_PARTS) as usize;
    let mut out = Vec::new();
    for (g, group) in groups.iter().enumerate() {
        for &mode in &job.analysis.modes {
            for (chunk, range) in chunks(n, chunk_size).enumerate() {
                for members in group.members.chunks(per_work) {
                    let units = members
                        .iter()
                        .map(|&variant| Unit { variant, mode, chunk: chunk as u64, range: range.clone() })
                        .collect();
                    out.push(Work { number: out.len() as u64, group: g, units });
                }
            }
        }
    }
    out
}

/// Whether a part file is whole: Parquet's magic at both ends and a footer that
/// fits. Parts are renamed into place before they reach the disk (the run syncs
/// them before `_SUCCESS`), so after a power cut a part can exist and be empty or
/// torn; `--resume` computes such a part again.
pub(crate) fn part_complete(path: &Path) -> bool {
    use std::io::{Read, Seek, SeekFrom};
    let check = || -> std::io::Result<bool> {
        let mut f = std::fs::File::open(path)?;
        let len = f.metadata()?.len();
        if len < 12 {
            return Ok(false);
        }
        let (mut head, mut tail) = ([0u8; 4], [0u8; 8]);
        f.read_exact(&mut head)?;
        f.seek(SeekFrom::End(-8))?;
        f.read_exact(&mut tail)?;
        let footer = u64::from(u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]));
        Ok(&head == b"PAR1" && &tail[4..] == b"PAR1" && footer + 12 <= len)
    };
    check().unwrap_or(false)
}

/// The statistics file of a part, parsed (each kind of mechanism has its statistics).
pub(crate) fn read_stats<S: serde::de::DeserializeOwned>(path: &Path) -> Result<S> {
    let text = std::fs::read(path).map_err(|source| EngineError::MissingStats { path: path.to_path_buf(), source })?;
    serde_json::from_slice(&text).map_err(|source| EngineError::Corrupt { path: path.to_path_buf(), source })
}

/// The statistics of `units` from their files, parsed on the pool (each file read one
/// after another was a serial stretch at the end of a run of many units), merged into
/// `into` in the units' order: the same sums whatever the threads.
pub(crate) fn read_merged_stats<S: serde::de::DeserializeOwned + Send>(
    layout: &Layout,
    units: &[&Unit],
    mut into: S,
    merge: impl Fn(&mut S, &S),
) -> Result<S> {
    let parts: Vec<S> =
        units.par_iter().map(|u| read_stats(&layout.stats(u.variant, u.mode, u.chunk))).collect::<Result<_>>()?;
    for part in &parts {
        merge(&mut into, part);
    }
    Ok(into)
}

/// Whether `--resume` can keep a unit: its part is whole and its statistics file
/// (written before it, and like it synced only at the end) parses. A missing trace
/// is rebuilt at the end instead.
/// `S`: the kind's statistics.
pub(crate) fn unit_complete<S: serde::de::DeserializeOwned>(layout: &Layout, u: &Unit, poses: bool) -> bool {
    (!poses || part_complete(&layout.part(u.variant, u.mode, u.chunk)))
        && read_stats::<S>(&layout.stats(u.variant, u.mode, u.chunk)).is_ok()
}

/// Flushes the files of `units` (those that exist), the `others`, and their
/// directories to the disk, so that a marker written after this covers data that
/// survives a power cut. The files are flushed from several threads at once: each
/// `fsync` mostly waits for the disk, and one after another they were a run's last
/// 2 % (benches/README.md).
pub(crate) fn sync_units(layout: &Layout, units: &[Unit], others: &[PathBuf]) -> Result<()> {
    let files: Vec<PathBuf> = units
        .iter()
        .flat_map(|u| {
            [
                layout.part(u.variant, u.mode, u.chunk),
                layout.stats(u.variant, u.mode, u.chunk),
                layout.trace(u.variant, u.mode, u.chunk),
            ]
        })
        .chain(others.iter().cloned())
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let sync_some = || -> Result<std::collections::BTreeSet<PathBuf>> {
        let mut dirs = std::collections::BTreeSet::new();
        while let Some(path) = files.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed)) {
            match std::fs::File::open(path) {
                Ok(f) => f.sync_all().map_err(EngineError::io("write", path))?,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(EngineError::io("read", path)(e)),
            }
            if let Some(dir) = path.parent() {
                dirs.insert(dir.to_path_buf());
            }
        }
        Ok(dirs)
    };
    let mut dirs = std::collections::BTreeSet::new();
    std::thread::scope(|scope| -> Result<()> {
        let threads: Vec<_> = (0..SYNC_THREADS.min(files.len())).map(|_| scope.spawn(sync_some)).collect();
        for t in threads {
            dirs.extend(t.join().expect("a sync thread does not panic")?);
        }
        Ok(())
    })?;
    dirs.insert(layout.root().to_path_buf());
    for dir in dirs {
        // Directories sync on Linux; elsewhere opening one may fail, which is harmless.
        if let Ok(d) = std::fs::File::open(&dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// Threads that flush a run's files at its end.
const SYNC_THREADS: usize = 8;

/// Bytes of one trace in a trace file (little-endian).
const TRACE_BYTES: usize = std::mem::size_of::<Trace>();

fn encode_traces(traces: &[Trace]) -> Vec<u8> {
    traces.iter().flat_map(|t| t.to_le_bytes()).collect()
}

/// Rows per block of summary statistics, merged in order. Fixed, so results never
/// depend on the thread count. A unit's pages ([`PAGE_ROWS`] rows, the last few
/// [`TAIL_PAGE_ROWS`]) are each computed and encoded on one thread, a whole number
/// of blocks at a time.
const BLOCK: usize = 1024;
const _: () = assert!(PAGE_ROWS.is_multiple_of(BLOCK) && TAIL_PAGE_ROWS.is_multiple_of(BLOCK));

/// Samples solved at once within a block (eight batches of `LANES`): their results,
/// about 1 KB each, are still in the core's cache when they are written out.
const SOLVE: usize = 64;

/// Whether `name` is the temporary file of a process writing a run's job file, which
/// becomes `job.toml` when it is whole.
fn job_in_flight(name: &str) -> bool {
    name.starts_with(".job.toml.tmp-")
}

/// Makes `layout`'s directory ready for a run of `job_toml` cut into the units `all`:
/// refuses what it holds unless the options let the run take it, and writes the job.
pub(crate) fn prepare_dir(layout: &Layout, job_toml: &str, opts: &RunOptions, all: &[Unit]) -> Result<()> {
    let out = layout.root();
    let entries: Vec<_> = match std::fs::read_dir(out) {
        Ok(rd) => rd.filter_map(|e| e.ok()).collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => {
            return Err(EngineError::io("read the output directory", out)(e));
        }
    };
    // The shards of a cluster start together: one may find the directory that
    // another has just made holding that shard's job file on its way in, and nothing
    // else. It is a fresh run's; this shard writes the same job file.
    let starting = opts.shard.is_some() && entries.iter().all(|e| job_in_flight(&e.file_name().to_string_lossy()));
    if !entries.is_empty() && !starting {
        let existing = std::fs::read_to_string(layout.job()).ok();
        let same_job = existing.as_deref() == Some(job_toml);
        if opts.overwrite {
            if existing.is_none() {
                return Err(OutputDirError::NotARunToOverwrite { dir: out.to_path_buf() }.into());
            }
            for path in Layout::RUN_FILES.iter().map(|f| out.join(f)).chain(layout.final_files()) {
                let _ = std::fs::remove_file(path);
            }
            for e in &entries {
                if Layout::parse_shard_marker(&e.file_name().to_string_lossy()).is_some() {
                    let _ = std::fs::remove_file(e.path());
                }
            }
            for dir in Layout::RUN_DIRS {
                let path = out.join(dir);
                if path.exists() {
                    std::fs::remove_dir_all(&path).map_err(EngineError::io("remove", &path))?;
                }
            }
        } else if opts.resume || opts.shard.is_some() {
            if !same_job {
                let dir = out.to_path_buf();
                let e =
                    if existing.is_some() { OutputDirError::OtherJob { dir } } else { OutputDirError::NotARun { dir } };
                return Err(e.into());
            }
            same_part_options(layout, opts)?;
            same_chunks(layout, all, opts.chunk_size)?;
        } else {
            return Err(OutputDirError::NotEmpty { dir: out.to_path_buf() }.into());
        }
    }
    std::fs::create_dir_all(out).map_err(EngineError::io("create the output directory", out))?;
    let opts = WriteOptions { durable: false, direct_io: opts.direct_io, ..WriteOptions::default() };
    Ok(write_bytes(&layout.job(), job_toml.as_bytes(), &opts)?)
}

/// The `--columns` a run's files say they were written with (`none`: no pose files).
fn columns_name(opts: &RunOptions) -> &'static str {
    if opts.poses { opts.columns.name() } else { "none" }
}

/// Refuses to resume (or add a shard to) a run whose part files were written with
/// another `--columns` or `--precision` than `opts` asks for, as the first readable one
/// says (`clearance.columns`, `clearance.precision`; a part without the key is not held
/// to it, one without `clearance.precision` is double): the dataset's parts would not
/// share a schema. A run without readable part files (`--columns none`, none written
/// yet, or only torn ones, which `--resume` computes again) has nothing to hold.
fn same_part_options(layout: &Layout, opts: &RunOptions) -> Result<()> {
    /// The first part below `dir` (in name order) whose footer can be read, and its
    /// key-value metadata.
    fn first_readable(dir: &Path) -> Option<Vec<(String, String)>> {
        let mut entries: Vec<_> = std::fs::read_dir(dir).ok()?.filter_map(|e| e.ok()).map(|e| e.path()).collect();
        entries.sort();
        entries.into_iter().find_map(|path| {
            let name = path.file_name()?.to_string_lossy().into_owned();
            if path.is_dir() {
                first_readable(&path)
            } else if name.starts_with("part-") && name.ends_with(".parquet") {
                clearance_parquet::key_values(&path)
            } else {
                None
            }
        })
    }
    let Some(kv) = first_readable(&layout.root().join("poses")) else { return Ok(()) };
    let value = |key: &str| kv.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone());
    let held = [
        ("--columns", value("clearance.columns"), columns_name(opts)),
        ("--precision", value("clearance.precision").or_else(|| Some("double".into())), opts.precision.name()),
    ];
    for (option, was, now) in held {
        if let Some(was) = was.filter(|was| was != now) {
            let dir = layout.root().to_path_buf();
            return Err(OutputDirError::OtherOptions { dir, option, was, now: now.to_string() }.into());
        }
    }
    Ok(())
}

/// Refuses to resume (or add a shard to) a run whose units were cut with another
/// `--chunk-size` than `chunk`: a unit's files are named by its chunk's number, so
/// another cutting would keep or merge files of other samples under those names (two
/// shards of one run with different sizes gave a "complete" run with samples twice
/// and others missing). Each unit's statistics say how many samples it holds; a file
/// that cannot be read is a torn one, which `--resume` computes again. Under two
/// cuttings every unit but the last of a (variant, mode) differs in length, so the
/// first few files read settle it: a run of many thousand parts on a shared file
/// system is not read whole by every shard that starts.
fn same_chunks(layout: &Layout, all: &[Unit], chunk: u64) -> Result<()> {
    const READ: usize = 8;
    let read = all.iter().filter_map(|u| {
        let path = layout.stats(u.variant, u.mode, u.chunk);
        std::fs::read(&path).ok().and_then(|bytes| stats_samples(&bytes)).map(|was| (u, path, was))
    });
    for (u, path, was) in read.take(READ) {
        let now = u.range.end - u.range.start;
        if was != now {
            let part = path.strip_prefix(layout.root()).unwrap_or(&path).display().to_string();
            let dir = layout.root().to_path_buf();
            return Err(OutputDirError::OtherChunks { dir, part, was, now, chunk }.into());
        }
    }
    Ok(())
}

/// The sample count a unit's statistics file gives (every kind's has `samples`).
fn stats_samples(bytes: &[u8]) -> Option<u64> {
    #[derive(serde::Deserialize)]
    struct Samples {
        samples: u64,
    }
    serde_json::from_slice::<Samples>(bytes).ok().map(|s| s.samples)
}

/// An empty completion marker, on the disk before this returns.
pub(crate) fn write_marker(path: &Path) -> Result<()> {
    write_bytes(path, b"", &WriteOptions::default())?;
    if let Some(dir) = path.parent() {
        let _ = std::fs::File::open(dir).and_then(|d| d.sync_all());
    }
    Ok(())
}

/// One part file and its statistics, on their way to the writer thread.
struct Part {
    path: PathBuf,
    stats_path: PathBuf,
    trace_path: PathBuf,
    traces: Vec<Trace>,
    body: Body,
    stats: SummaryStats,
    extra: Vec<(String, String)>,
}

/// The rows of a part file, as its writer takes them.
enum Body {
    /// Encoded already, page by page ([`Writer::Engine`]).
    Pages(PartPages),
    /// A record batch, for `ArrowWriter` ([`Writer::Arrow`]).
    Batch(RecordBatch),
}

pub(crate) fn search_options(variant: &Variant) -> SearchOptions {
    SearchOptions { dip_threshold: variant.job.analysis.discontinuity_load_fraction * variant.job.weight() }
}

/// Poses whose traces a run keeps in memory (8 bytes each): up to this many in a
/// (variant, mode), a run that computes every unit searches its paths as their
/// units come in. Beyond, and after a sharded or resumed run, the search at the
/// end reads them back from the parts' trace files, [`SEARCH_TRACES`] at a time.
const KEEP_TRACES: u64 = 1 << 24;

/// Traces the search at the end holds at once (8 bytes each; a path longer than
/// this is read whole): what bounds its memory, whatever the pose count.
const SEARCH_TRACES: usize = 1 << 22;

/// What this invocation computed, kept for the search and summary at the end so
/// that they need not read it back from `_stats/`.
#[derive(Default)]
struct Kept<'a> {
    /// Per (variant, mode): the statistics of its units merged in unit order, and
    /// how many units that was.
    stats: std::collections::HashMap<(u64, Mode), (SummaryStats, usize)>,
    /// How traces are kept.
    keep: KeepTraces,
    /// Per (group, mode), with [`KeepTraces::Search`]: its search so far.
    searches: std::collections::HashMap<(usize, Mode), Search<'a>>,
    /// Per (group, mode), with [`KeepTraces::Search`]: its switches, once all its
    /// work is in.
    found: std::collections::HashMap<(usize, Mode), Vec<Discontinuity>>,
    /// Per (group, mode), with [`KeepTraces::Search`]: the last samples of its work so
    /// far, unsettled, with their loads ([`Kept::settle`]).
    seams: std::collections::HashMap<(usize, Mode), Seam>,
    /// Buffers of [`Sampled`] values the searches let go of, for the next works.
    spare_sampled: Vec<Vec<Sampled>>,
}

/// The last samples of a (group, mode)'s work so far, from `start` on: their traces
/// before [`keep_local_minima`] and their loads, so that the next unit's samples settle
/// with their neighbours along every axis in hand, and these with theirs in the next
/// unit.
struct Seam {
    start: u64,
    traces: Vec<Trace>,
    loads: Vec<Loads>,
}

/// The most samples a [`Seam`] keeps (152 bytes each, 20 MB): grids whose longest
/// stride the search follows is at most half this (a Z-plane of 65 536 samples).
const SEAM_SAMPLES: usize = 1 << 17;

/// The most samples before a unit's whose values the search keeps for the lines that
/// reach back into earlier units (144 bytes each, 19 MB).
const KNOWN_SAMPLES: u64 = 1 << 17;

/// Whether a path the search follows ends at a sample of `range`.
fn ends_a_path(model: &Model, source: &SampleSource, range: std::ops::Range<u64>) -> bool {
    let end = range.end.min(source.len());
    axes(source).iter().filter(|a| searched_along(model, a.along)).any(|a| {
        // The paths along `a` end at the samples whose node along it is the last.
        let (span, last) = (a.stride * a.n, a.stride * (a.n - 1));
        let first_end = if range.start % span >= last { range.start } else { range.start / span * span + last };
        first_end < end
    })
}

/// How many samples before a unit's the search keeps the values of
/// ([`Search::extend_known`]): as far back as a searched line reaches (its stride
/// times its length), if that is at most [`KNOWN_SAMPLES`], else none (the lines
/// that reach further read the values of the unit that completes them, and solve
/// the rest).
fn known_reach(model: &Model, source: &SampleSource) -> u64 {
    let axes = axes(source);
    let reach = axes.iter().filter(|a| searched_along(model, a.along)).map(|a| a.stride * a.n.saturating_sub(1)).max();
    reach.filter(|&r| r <= KNOWN_SAMPLES).unwrap_or(0)
}

/// The values a unit stored for the search ([`Sampled`]) and how many the search read
/// while it took that unit's traces (of it and of the units before it still held).
#[derive(Clone, Copy, Debug)]
struct KnownReads {
    stored: u64,
    read: u64,
}

impl KnownReads {
    /// Whether storing the values paid for itself: at least one read for every
    /// [`STORED_PER_READ`] stored. A read spares a solve of 230 to 450 ns, a stored
    /// value costs 144 bytes written, and fresh memory to fault in at first.
    fn paid(&self) -> bool {
        self.read * STORED_PER_READ >= self.stored
    }
}

/// See [`KnownReads::paid`].
const STORED_PER_READ: u64 = 4;

/// What [`Kept`] does with the traces of the units it is given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum KeepTraces {
    /// Nothing: the search at the end reads them back from the parts' trace files.
    #[default]
    No,
    /// Searches the paths they complete at once. Work must come in order, each
    /// (group, mode) whole.
    Search,
}

impl<'a> Kept<'a> {
    fn add_stats(&mut self, unit: &Unit, stats: &SummaryStats) {
        let (merged, count) = self.stats.entry((unit.variant, unit.mode)).or_default();
        merged.merge(stats);
        // Bins, not values: a run's total stays the size of its histogram.
        merged.flush();
        *count += 1;
    }

    /// The traces of the samples `start..` (`traces`, as [`trace_into`] gives them, with
    /// their `loads`) settled by [`keep_local_minima`] with the last samples of the
    /// same (group, mode) before them in hand, where those are kept: a grid line that
    /// crosses from one unit into the next then has its neighbours in hand at the seam
    /// (a Z-line of a 3-D grid crosses a seam at every other node or so). Those earlier
    /// samples within a stride of the seam, settled again, refine the search's traces
    /// (its paths not searched yet see fewer candidates; the switches are the same):
    /// returned with the first of them, for [`Search::refine`] once the search is
    /// done with the paths of the unit before.
    /// Keeps the last samples for the next unit: twice the longest stride of an input
    /// the search follows, if that is at most [`SEAM_SAMPLES`].
    fn settle(
        &mut self,
        key: (usize, Mode),
        (model, source): (&Model, &SampleSource),
        start: u64,
        traces: &[Trace],
        loads: &[Loads],
    ) -> (Vec<Trace>, Option<(u64, Vec<Trace>)>) {
        let axes = axes(source);
        let stride = axes.iter().filter(|a| searched_along(model, a.along)).map(|a| a.stride as usize).max();
        // Beyond the cap, the longest stride's neighbours would not be in hand: none kept.
        let keep = match stride {
            Some(s) if 2 * s <= SEAM_SAMPLES => 2 * s,
            _ => 0,
        };
        let (seam_start, mut seam_traces, mut seam_loads) = match self.seams.remove(&key) {
            Some(seam) if seam.start + seam.traces.len() as u64 == start => (seam.start, seam.traces, seam.loads),
            _ => (start, Vec::new(), Vec::new()),
        };
        let (before, n, half) = (seam_traces.len(), traces.len(), keep / 2);
        // The seam and the first samples of this unit: enough for each sample within a
        // stride of the seam to have its neighbours in hand.
        seam_traces.extend_from_slice(&traces[..n.min(keep)]);
        seam_loads.extend_from_slice(&loads[..n.min(keep)]);
        let across = |which| keep_local_minima_of(&axes, seam_start, &seam_traces, &seam_loads, which);
        let again = before.saturating_sub(half);
        let refine = (again < before).then(|| (seam_start + again as u64, across(again..before)));
        let mut settled = across(before..before + n.min(half));
        // The rest of the unit has its neighbours in hand within it.
        settled.extend(keep_local_minima_of(&axes, start, traces, loads, n.min(half)..n));
        if keep > 0 && start + (n as u64) < source.len() {
            let seam = if n >= keep {
                Seam {
                    start: start + (n - keep) as u64,
                    traces: traces[n - keep..].to_vec(),
                    loads: loads[n - keep..].to_vec(),
                }
            } else {
                let from = seam_traces.len().saturating_sub(keep);
                seam_traces.drain(..from);
                seam_loads.drain(..from);
                Seam { start: seam_start + from as u64, traces: seam_traces, loads: seam_loads }
            };
            self.seams.insert(key, seam);
        }
        (settled, refine)
    }

    /// The traces of a work's samples, which its group's variants share, and the
    /// values the pass solved there (`sampled`), once its search is done with the
    /// paths of the work before (`refine`, from [`Kept::settle`], first): the paths
    /// they complete, as [`Search::batches`] for the tasks of the next step.
    #[allow(clippy::too_many_arguments)]
    fn receive(
        &mut self,
        key: (usize, Mode),
        refine: Option<(u64, Vec<Trace>)>,
        traces: &[Trace],
        sampled: Vec<Sampled>,
        model: &'a Model,
        source: &'a SampleSource,
        opts: &SearchOptions,
    ) -> Pending<'a> {
        let mut search = self.searches.remove(&key).unwrap_or_else(|| Search::new(model, source, key.1, opts));
        if let Some((first, settled)) = refine {
            search.refine(first, &settled);
        }
        let stored = sampled.len() as u64;
        let spare = search.receive(traces, sampled);
        self.spare_sampled.extend(spare);
        let batches = search.batches(BATCHES_PER_THREAD * rayon::current_num_threads());
        Pending { key, search, batches, stored, keep: known_reach(model, source) }
    }

    /// Takes the switches of a search's batches (`found`, one vector per batch): its
    /// search goes back with the others, or is finished; returns how many values the
    /// pass stored for it and its paths read.
    fn searched(&mut self, p: Pending<'a>, found: Vec<Vec<Discontinuity>>) -> KnownReads {
        let Pending { key, mut search, batches, stored, keep } = p;
        let spare = search.searched(&batches, found, keep);
        self.spare_sampled.extend(spare);
        let reads = KnownReads { stored, read: search.known_reads() };
        if search.is_complete() {
            self.spare_sampled.extend(search.let_go_known());
            self.found.insert(key, search.finish());
        } else {
            self.searches.insert(key, search);
        }
        reads
    }
}

/// A search whose next paths are ready, as batches for the threads of the pool as
/// the pass leaves them ([`run`]).
struct Pending<'a> {
    key: (usize, Mode),
    search: Search<'a>,
    batches: Vec<Batch>,
    /// Values the pass stored for the work that completed these paths.
    stored: u64,
    /// How many samples back the search keeps values ([`known_reach`]).
    keep: u64,
}

/// The discontinuity search and the summary, then `discontinuities.parquet` and
/// `summary.parquet`. What this invocation computed comes from `kept`, the rest
/// from the files of the parts, which must then all be written. Each group is
/// searched once (`models` are the groups'), its switches scaled to each member.
#[allow(clippy::too_many_arguments)]
fn finalize(
    layout: &Layout,
    job: &JobSpec,
    variants: &[Variant],
    groups: &[Group],
    models: &[(Model, SampleSource)],
    all: &[Unit],
    opts: &RunOptions,
    write_opts: &WriteOptions,
    mut kept: Kept,
    stages: &mut StageTimes,
) -> Result<()> {
    opts.progress.get().searching();
    let mut found_by_group = std::mem::take(&mut kept.found);
    // After shards, their own searches: merged, not searched again.
    if let Some(mut owned) = opts.shard.and_then(|(_, n)| crate::owned::read_owned(layout, &job.analysis.modes, n)) {
        for g in 0..groups.len() {
            for &mode in &job.analysis.modes {
                found_by_group.insert((g, mode), owned.remove(&(g, mode)).unwrap_or_default());
            }
        }
    }
    for (g, (group, (model, source))) in groups.iter().zip(models).enumerate() {
        let first = group.first();
        let search = search_options(&variants[first as usize]);
        for &mode in &job.analysis.modes {
            if found_by_group.contains_key(&(g, mode)) {
                continue;
            }
            let units: Vec<&Unit> = all.iter().filter(|u| u.variant == first && u.mode == mode).collect();
            let start = Instant::now();
            let found = if opts.search {
                search_after(layout, model, source, mode, &search, &units, opts)?
            } else {
                Vec::new()
            };
            stages.search += start.elapsed().as_secs_f64();
            found_by_group.insert((g, mode), found);
        }
    }
    let member_of = membership(groups, variants.len());
    let mut switches = Vec::new();
    let mut summary = Vec::new();
    for variant in variants {
        let (g, m) = member_of[variant.index as usize];
        let group = &groups[g];
        for &mode in &job.analysis.modes {
            let units: Vec<&Unit> = all.iter().filter(|u| u.variant == variant.index && u.mode == mode).collect();
            // Merged in unit order, as `Kept::add_stats` does, so both give the same sums.
            let stats = match kept.stats.remove(&(variant.index, mode)) {
                Some((stats, count)) if count == units.len() => stats,
                _ => read_merged_stats(layout, &units, SummaryStats::default(), SummaryStats::merge)?,
            };
            let found = if group.alone() {
                found_by_group.remove(&(g, mode)).expect("every group searched")
            } else {
                group.switches(m, &found_by_group[&(g, mode)])
            };
            let mut counts = [0u64; 4];
            for d in &found {
                counts[d.kind.index()] += 1;
            }
            summary.push(SummaryRow {
                variant: variant.index,
                mode: mode.name(),
                params: variant.params.iter().map(|(_, v)| *v).collect(),
                stats,
                switches: counts,
            });
            switches.extend(found.into_iter().map(|d| (variant.index, d)));
        }
    }
    let start = Instant::now();
    let [discontinuities, summary_file] = layout.final_files();
    let batch = discontinuity_batch(&switches);
    write_parquet(&discontinuities, batch.schema(), &[batch], write_opts, &[])?;
    let names: Vec<String> = job.sweep.iter().map(|s| s.param.clone()).collect();
    let batch = summary_batch(&names, &summary);
    write_parquet(&summary_file, batch.schema(), &[batch], write_opts, &[])?;
    stages.writing += start.elapsed().as_secs_f64();
    Ok(())
}

/// The switches of one (variant, mode) from the traces written beside its
/// `units` (all of them, in sample order), read a batch of grid lines at a time.
/// A part written without its traces (by an engine from before them, or whose
/// trace file is lost) has its poses solved again and its trace file written.
fn search_after(
    layout: &Layout,
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    search: &SearchOptions,
    units: &[&Unit],
    opts: &RunOptions,
) -> Result<Vec<Discontinuity>> {
    let paths: Vec<PathBuf> = units.iter().map(|u| layout.trace(u.variant, u.mode, u.chunk)).collect();
    for u in units {
        rebuild_traces(layout, model, source, u, search, opts)?;
    }
    let mut files = TraceFiles::new(units.iter().map(|u| u.range.clone()).collect(), paths);
    find_discontinuities_read(model, source, mode, search, SEARCH_TRACES, |range, dst| files.read(range, dst))
}

/// The traces of `unit`'s samples, from its trace file ([`rebuild_traces`] first).
pub(crate) fn unit_traces(
    layout: &Layout,
    model: &Model,
    source: &SampleSource,
    unit: &Unit,
    search: &SearchOptions,
    opts: &RunOptions,
) -> Result<Vec<Trace>> {
    if let Some(traces) = rebuild_traces(layout, model, source, unit, search, opts)? {
        return Ok(traces);
    }
    let path = layout.trace(unit.variant, unit.mode, unit.chunk);
    let mut traces = vec![0; (unit.range.end - unit.range.start) as usize];
    TraceFiles::new(vec![unit.range.clone()], vec![path]).read(unit.range.clone(), &mut traces)?;
    Ok(traces)
}

/// Solves `unit`'s poses again and writes its trace file where that file is missing
/// or not whole (a part written by an engine from before traces, or a lost file);
/// returns the traces it computed.
fn rebuild_traces(
    layout: &Layout,
    model: &Model,
    source: &SampleSource,
    unit: &Unit,
    search: &SearchOptions,
    opts: &RunOptions,
) -> Result<Option<Vec<Trace>>> {
    let path = layout.trace(unit.variant, unit.mode, unit.chunk);
    let bytes = TRACE_BYTES as u64 * (unit.range.end - unit.range.start);
    if std::fs::metadata(&path).map(|m| m.len()).ok() == Some(bytes) {
        return Ok(None);
    }
    let traces = clearance_discontinuity::traces(model, source, unit.mode, unit.range.clone(), search);
    let opts = WriteOptions { durable: false, direct_io: opts.direct_io, ..WriteOptions::default() };
    write_bytes(&path, &encode_traces(&traces), &opts)?;
    Ok(Some(traces))
}

/// The trace files of consecutive ranges of samples, read as one array.
struct TraceFiles {
    /// Each file's samples, in order, without gaps.
    ranges: Vec<std::ops::Range<u64>>,
    paths: Vec<PathBuf>,
    /// The file read last, by position, and the offset it is at: a batch of paths
    /// reads along a file before moving on.
    open: Option<(usize, std::fs::File, u64)>,
    bytes: Vec<u8>,
}

impl TraceFiles {
    fn new(ranges: Vec<std::ops::Range<u64>>, paths: Vec<PathBuf>) -> Self {
        Self { ranges, paths, open: None, bytes: vec![0; 1 << 16] }
    }

    /// The traces of the samples in `range` into `dst` (of its length).
    fn read(&mut self, range: std::ops::Range<u64>, mut dst: &mut [Trace]) -> Result<()> {
        use std::io::{Read, Seek, SeekFrom};
        let mut at = range.start;
        while at < range.end {
            let k = self.ranges.partition_point(|r| r.end <= at);
            let (file_range, path) = (&self.ranges[k], &self.paths[k]);
            let count = (range.end.min(file_range.end) - at).min((self.bytes.len() / TRACE_BYTES) as u64) as usize;
            let cannot = || EngineError::io("read", path);
            let (_, file, offset) = match &mut self.open {
                Some(open) if open.0 == k => open,
                _ => self.open.insert((k, std::fs::File::open(path).map_err(cannot())?, 0)),
            };
            let wanted = TRACE_BYTES as u64 * (at - file_range.start);
            if *offset != wanted {
                *offset = file.seek(SeekFrom::Start(wanted)).map_err(cannot())?;
            }
            let bytes = &mut self.bytes[..TRACE_BYTES * count];
            file.read_exact(bytes).map_err(cannot())?;
            *offset += bytes.len() as u64;
            let (here, rest) = std::mem::take(&mut dst).split_at_mut(count);
            for (t, b) in here.iter_mut().zip(bytes.chunks_exact(TRACE_BYTES)) {
                *t = Trace::from_le_bytes(b.try_into().expect("one trace's bytes"));
            }
            dst = rest;
            at += count as u64;
        }
        Ok(())
    }
}

/// What computing a work needs besides the work.
struct Ctx<'a> {
    schema: &'a PoseSchema,
    /// Per group, the model it is solved with and its samples.
    models: &'a [(Model, SampleSource)],
    groups: &'a [Group],
    variants: &'a [Variant],
    opts: &'a RunOptions,
    layout: &'a Layout,
    /// Buffers of written pages, to encode pages into.
    spare: &'a std::sync::Mutex<Vec<Vec<u8>>>,
    /// Nanoseconds the pool's threads spent in the run's tasks
    /// ([`StageTimes::pool_tasks`]).
    tasks_ns: &'a std::sync::atomic::AtomicU64,
    /// A solver's and a page's working buffers for each page being computed, kept
    /// from page to page: rayon calls `map_init`'s init for every piece it splits
    /// off, and a fresh page buffer is megabytes to zero and fault in.
    workers: &'a std::sync::Mutex<Vec<(Blocks, PageBuffer)>>,
    /// How the run keeps its traces.
    keep: KeepTraces,
    /// Whether units still store what the search reads ([`Ctx::reads_sampled`]): on a
    /// grid until a unit's values are read less than they cost
    /// ([`KnownReads::paid`]); never on a trajectory, finely sampled, whose search reads
    /// a few samples around each of its few switches.
    store_sampled: std::sync::atomic::AtomicBool,
}

impl Ctx<'_> {
    /// Runs `f`, one task of the pool, counting its time ([`StageTimes::pool_tasks`]).
    fn task<R>(&self, f: impl FnOnce() -> R) -> R {
        timed(self.tasks_ns, f)
    }

    /// Whether the run searches `work` as it computes: it searches at all
    /// ([`RunOptions::search`]), keeps its traces for the search, and the work is its
    /// group's first member's (whose traces the search follows; the other members
    /// share them). Everything the pass does for the search alone (settling the
    /// traces' minima across units, storing what the search reads) hangs on this.
    fn searched_now(&self, work: &Work) -> bool {
        self.opts.search && self.keep == KeepTraces::Search && work.units[0].variant == self.groups[work.group].first()
    }

    /// Whether the search reads what the pass solved at the samples of `work`: it
    /// searches `work` as the run computes ([`Ctx::searched_now`]), the work's parts
    /// are at most [`KNOWN_SAMPLES`] long (the values take 144 bytes a pose), and a
    /// path it searches ends within the work or within reach of it ([`known_reach`];
    /// the first parts of a long trajectory are not worth the stores).
    fn reads_sampled(&self, work: &Work) -> bool {
        let (model, source) = &self.models[work.group];
        let range = &work.units[0].range;
        self.searched_now(work)
            && self.store_sampled.load(std::sync::atomic::Ordering::Relaxed)
            && range.end - range.start <= KNOWN_SAMPLES
            && ends_a_path(model, source, range.start..range.end + known_reach(model, source))
    }

    fn take_worker(&self) -> (Blocks, PageBuffer) {
        let worker = self.workers.lock().expect("no panic while held").pop();
        worker.unwrap_or_else(|| (Blocks::default(), self.schema.page_buffer()))
    }

    fn put_worker(&self, worker: (Blocks, PageBuffer)) {
        self.workers.lock().expect("no panic while held").push(worker);
    }
}

/// Runs `f`, adding its nanoseconds to `ns`.
fn timed<R>(ns: &std::sync::atomic::AtomicU64, f: impl FnOnce() -> R) -> R {
    let start = Instant::now();
    let out = f();
    ns.fetch_add(start.elapsed().as_nanos() as u64, std::sync::atomic::Ordering::Relaxed);
    out
}

/// A work computed, its pages encoded, before its traces are pruned and its
/// statistics merged ([`conclude`]).
struct Computed<'a> {
    work: &'a Work,
    /// Per unit, its rows.
    bodies: Vec<Body>,
    /// The samples' traces, which every unit of the work shares.
    traces: Vec<Trace>,
    /// The load magnitudes of each pose.
    loads: Vec<Loads>,
    /// What the search reads at each pose, where the run searches as it computes
    /// (else empty).
    sampled: Vec<Sampled>,
    /// Per unit, per page, the statistics of each of its blocks.
    block_stats: Vec<Vec<Vec<SummaryStats>>>,
}

/// Solves the poses of `work` on the pool into the rows its writer takes, with
/// `buffers` to reuse.
///
/// `idle` is called when a thread finds no page of the work left to compute (at
/// the end, with the arrow writer): what the pool does next fills the time until the
/// last page is done.
fn compute<'a>(ctx: &Ctx<'_>, work: &'a Work, buffers: Buffers, idle: &(dyn Fn() + Sync)) -> Result<Computed<'a>> {
    match ctx.opts.writer {
        Writer::Engine => compute_pages(ctx, work, buffers, idle),
        Writer::Arrow => compute_batch(ctx, work, buffers),
    }
}

/// A work's per-pose buffers, reused from work to work.
#[derive(Default)]
struct Buffers {
    loads: Vec<Loads>,
    sampled: Vec<Sampled>,
}

impl Buffers {
    /// Sized for `n` poses; `sampled` only where the run's search reads them (else
    /// empty, and never written).
    ///
    /// New rows are filled on the pool: a unit's are tens of megabytes, and filled
    /// on one thread (its pages touched for the first time) they left the others
    /// idle at the start of a run for as long as the pool took to solve a tenth of
    /// the unit.
    fn sized(mut self, n: usize, sampled: bool) -> Self {
        fn sized<T: Default + Clone + Send + Sync>(v: &mut Vec<T>, n: usize) {
            v.truncate(n);
            if v.len() < n {
                v.reserve_exact(n - v.len());
                v.par_extend(rayon::iter::repeat_n(T::default(), n - v.len()).with_min_len(4096));
            }
        }
        sized(&mut self.loads, n);
        sized(&mut self.sampled, if sampled { n } else { 0 });
        self
    }
}

/// The first `rows` of `rest` (fewer if it has fewer), the rest left in `rest`.
fn take_rows<'s, T>(rest: &mut &'s mut [T], rows: usize) -> &'s mut [T] {
    let rows = rows.min(rest.len());
    let (head, tail) = std::mem::take(rest).split_at_mut(rows);
    *rest = tail;
    head
}

/// Solves one block of samples, from sample `first`, into rows `row..` of `sink`,
/// with each pose's trace and load magnitudes, and what the search reads there
/// (`traces`, `loads` and `sampled` are the block's; `sampled` may be empty); the
/// block's statistics. For a variant solved as itself.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn solve_block(
    blocks: &mut Blocks,
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    first: u64,
    sink: &mut BlockSink<'_>,
    row: usize,
    traces: &mut [Trace],
    loads: &mut [Loads],
    mut sampled: &mut [Sampled],
) -> SummaryStats {
    let mut stats = SummaryStats::with_capacity(traces.len());
    // A few batches at a time, so that results are used while in cache.
    for (k, (ts, ls)) in traces.chunks_mut(SOLVE).zip(loads.chunks_mut(SOLVE)).enumerate() {
        let (at, start) = (row + k * SOLVE, first + (k * SOLVE) as u64);
        let (samples, results) = blocks.solve(model, source, start..start + ts.len() as u64, mode);
        let rows = samples.iter().zip(results).zip(ts.iter_mut().zip(ls));
        for (i, ((s, r), (t, l))) in rows.enumerate() {
            sink.put(at + i, s, r);
            stats.push(r);
            *t = trace_into(r, model, l);
        }
        for (out, r) in take_rows(&mut sampled, ts.len()).iter_mut().zip(results) {
            *out = Sampled::of(r);
        }
    }
    stats
}

/// Solves the samples from `first` (as many as `traces`) once for a group, with
/// their traces and load magnitudes; a [`Shared`] solve to write each member from.
#[allow(clippy::too_many_arguments)]
fn solve_shared<'b>(
    blocks: &'b mut Blocks,
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    first: u64,
    traces: &mut [Trace],
    loads: &mut [Loads],
    sampled: &mut [Sampled],
) -> Shared<'b> {
    let (samples, results) = blocks.solve(model, source, first..first + traces.len() as u64, mode);
    for ((r, t), l) in results.iter().zip(traces).zip(loads) {
        *t = trace_into(r, model, l);
    }
    for (out, r) in sampled.iter_mut().zip(results) {
        *out = Sampled::of(r);
    }
    Shared { samples, results }
}

/// A group's solve of consecutive samples.
struct Shared<'b> {
    samples: &'b [clearance_grid::Sample],
    results: &'b [clearance_solver::PoseResult],
}

impl Shared<'_> {
    /// Samples `rows` of the solve, scaled by `scale` (a member's [`Group::scales`]),
    /// into the same rows of `sink`; their statistics.
    fn put(&self, scale: &[f64; 4], sink: &mut BlockSink<'_>, rows: std::ops::Range<usize>) -> SummaryStats {
        let mut stats = SummaryStats::with_capacity(rows.len());
        for i in rows {
            let r = self.results[i].scaled(scale);
            sink.put(i, &self.samples[i], &r);
            stats.push(&r);
        }
        stats
    }
}

/// [`compute`] for the engine's writer: a page at a time, each page encoded as
/// soon as its rows are in. A group's page is solved once and written for each
/// member.
fn compute_pages<'a>(
    ctx: &Ctx<'_>,
    work: &'a Work,
    buffers: Buffers,
    idle: &(dyn Fn() + Sync),
) -> Result<Computed<'a>> {
    let (model, source) = &ctx.models[work.group];
    let group = &ctx.groups[work.group];
    let (mode, range) = (work.units[0].mode, work.units[0].range.clone());
    let n = (range.end - range.start) as usize;
    let mut parts: Vec<PartPages> = work.units.iter().map(|_| ctx.schema.part(mode, n)).collect();
    let mut traces: Vec<Trace> = vec![0; n];
    let Buffers { mut loads, mut sampled } = buffers.sized(n, ctx.reads_sampled(work));
    // Each page with its rows' traces and loads: per page, every unit's writer of it.
    let mut writers: Vec<std::vec::IntoIter<PageWriter<'_>>> =
        parts.iter_mut().map(|p| p.pages(ctx.schema).into_iter()).collect();
    let (mut rest_traces, mut rest_loads, mut rest_sampled) = (&mut traces[..], &mut loads[..], &mut sampled[..]);
    let mut work_pages = Vec::new();
    while let Some(pages) = writers.iter_mut().map(|w| w.next()).collect::<Option<Vec<_>>>() {
        let rows = pages[0].rows();
        let page_traces = take_rows(&mut rest_traces, rows);
        let page_loads = take_rows(&mut rest_loads, rows);
        let page_sampled = take_rows(&mut rest_sampled, rows);
        work_pages.push((work_pages.len(), pages, page_traces, page_loads, page_sampled));
    }
    // Pages are handed out in order, each to the next thread free, so that the
    // short pages at the end go last (`page_spans`): rayon's halving of a list of
    // pages let one thread finish a whole page before the other.
    let queue = std::sync::Mutex::new(work_pages.into_iter());
    let next_page = || {
        let page = queue.lock().expect("no panic while held").next();
        if page.is_none() {
            idle();
        }
        page
    };
    let compute_page = |pages: Vec<PageWriter<'_>>,
                        page_traces: &mut [Trace],
                        page_loads: &mut [Loads],
                        mut page_sampled: &mut [Sampled]| {
        let (mut blocks, mut buf) = ctx.take_worker();
        let first = range.start + pages[0].first() as u64;
        let spare = || ctx.spare.lock().expect("no panic while held").pop().unwrap_or_default();
        let codec = ctx.opts.compression;
        // Without pose files the pages are filled (their rows' sample and status) but
        // not encoded: nothing writes them.
        let poses = ctx.opts.poses;
        let written: Vec<_> = if group.alone() {
            let page = pages.into_iter().next().expect("a page per unit");
            let fill = |sink: &mut BlockSink<'_>| {
                let mut all = Vec::with_capacity(PAGE_ROWS / BLOCK);
                let blocks_of = page_traces.chunks_mut(BLOCK).zip(page_loads.chunks_mut(BLOCK));
                for (b, (block_traces, block_loads)) in blocks_of.enumerate() {
                    let row = b * BLOCK;
                    let start = first + row as u64;
                    all.push(solve_block(
                        &mut blocks,
                        model,
                        source,
                        mode,
                        start,
                        sink,
                        row,
                        block_traces,
                        block_loads,
                        take_rows(&mut page_sampled, BLOCK),
                    ));
                }
                all
            };
            vec![if poses { page.write(&mut buf, codec, spare(), fill) } else { Ok(page.discard(&mut buf, fill)) }]
        } else {
            let rows = page_traces.len();
            let shared = solve_shared(&mut blocks, model, source, mode, first, page_traces, page_loads, page_sampled);
            let fill = |m: usize, sink: &mut BlockSink<'_>| {
                let scale = &group.scales[group.member(work.units[m].variant)];
                (0..rows).step_by(BLOCK).map(|row| shared.put(scale, sink, row..rows.min(row + BLOCK))).collect()
            };
            if poses {
                PageWriter::write_members(pages, &mut buf, codec, spare, fill)
            } else {
                pages
                    .into_iter()
                    .enumerate()
                    .map(|(m, page)| Ok(page.discard(&mut buf, |sink| fill(m, sink))))
                    .collect()
            }
        };
        ctx.put_worker((blocks, buf));
        written
    };
    let by_thread: Vec<Vec<_>> = (0..rayon::current_num_threads())
        .into_par_iter()
        .map(|_| {
            let mut done = Vec::new();
            while let Some((p, pages, page_traces, page_loads, page_sampled)) = next_page() {
                done.push((p, ctx.task(|| compute_page(pages, page_traces, page_loads, page_sampled))));
            }
            done
        })
        .collect();
    let mut done: Vec<_> = by_thread.into_iter().flatten().collect();
    done.sort_unstable_by_key(|(p, _)| *p);
    // Per unit, per page.
    let mut block_stats: Vec<Vec<Vec<SummaryStats>>> = work.units.iter().map(|_| Vec::new()).collect();
    for (_, per_unit) in done {
        for ((stats, unit), out) in per_unit.into_iter().zip(&work.units).zip(&mut block_stats) {
            let stats = stats.map_err(|source| clearance_parquet::ParquetError::Encode {
                path: ctx.layout.part(unit.variant, unit.mode, unit.chunk),
                source,
            })?;
            out.push(stats);
        }
    }
    let bodies = parts.into_iter().map(Body::Pages).collect();
    Ok(Computed { work, bodies, traces, loads, sampled, block_stats })
}

/// [`compute`] for `ArrowWriter`: blocks of rows into column buffers on the pool,
/// then one record batch per unit. A group's block is solved once and written for
/// each member.
fn compute_batch<'a>(ctx: &Ctx<'_>, work: &'a Work, buffers: Buffers) -> Result<Computed<'a>> {
    let (model, source) = &ctx.models[work.group];
    let group = &ctx.groups[work.group];
    let (mode, range) = (work.units[0].mode, work.units[0].range.clone());
    let n = (range.end - range.start) as usize;
    let mut columns: Vec<_> = work.units.iter().map(|_| ctx.schema.columns(n)).collect();
    let mut traces: Vec<Trace> = vec![0; n];
    let Buffers { mut loads, mut sampled } = buffers.sized(n, ctx.reads_sampled(work));
    let mut sinks: Vec<std::vec::IntoIter<BlockSink<'_>>> =
        columns.iter_mut().map(|c| c.blocks(ctx.schema, BLOCK).into_iter()).collect();
    let mut per_block = Vec::new();
    while let Some(block_sinks) = sinks.iter_mut().map(|s| s.next()).collect::<Option<Vec<_>>>() {
        per_block.push(block_sinks);
    }
    drop(sinks);
    let mut rest_sampled = &mut sampled[..];
    let work_blocks: Vec<_> = per_block
        .into_iter()
        .zip(traces.chunks_mut(BLOCK).zip(loads.chunks_mut(BLOCK)))
        .map(|(sinks, (t, l))| (sinks, (t, l, take_rows(&mut rest_sampled, BLOCK))))
        .enumerate()
        .collect();
    // Per block, each unit's statistics.
    let stats: Vec<Vec<SummaryStats>> = work_blocks
        .into_par_iter()
        .map(|(b, (mut block_sinks, (block_traces, block_loads, block_sampled)))| {
            ctx.task(|| {
                let (mut blocks, buf) = ctx.take_worker();
                let first = range.start + (b * BLOCK) as u64;
                let stats = if group.alone() {
                    vec![solve_block(
                        &mut blocks,
                        model,
                        source,
                        mode,
                        first,
                        &mut block_sinks[0],
                        0,
                        block_traces,
                        block_loads,
                        block_sampled,
                    )]
                } else {
                    let rows = block_traces.len();
                    let shared =
                        solve_shared(&mut blocks, model, source, mode, first, block_traces, block_loads, block_sampled);
                    block_sinks
                        .iter_mut()
                        .zip(&work.units)
                        .map(|(sink, unit)| shared.put(&group.scales[group.member(unit.variant)], sink, 0..rows))
                        .collect()
                };
                ctx.put_worker((blocks, buf));
                stats
            })
        })
        .collect();
    // One block's statistics per page entry, in block order, as `compute_pages` gives them.
    let mut block_stats: Vec<Vec<Vec<SummaryStats>>> = work.units.iter().map(|_| Vec::new()).collect();
    for per_unit in stats {
        for (s, out) in per_unit.into_iter().zip(&mut block_stats) {
            out.push(vec![s]);
        }
    }
    let bodies = columns.into_iter().map(|c| Body::Batch(ctx.schema.finish(mode, c))).collect();
    Ok(Computed { work, bodies, traces, loads, sampled, block_stats })
}

/// A computed work's parts, for the writer, with its traces pruned and each unit's
/// statistics merged (and kept in `kept`); the pruned traces; and its per-pose
/// buffers, to reuse.
fn conclude(ctx: &Ctx<'_>, c: Computed<'_>, kept: &mut Kept) -> Concluded {
    let Computed { work, bodies, traces, loads, sampled, block_stats } = c;
    let (model, source) = &ctx.models[work.group];
    // With the whole unit in hand, most samples are seen not to be load
    // minima, so the search solves only the others.
    let start = work.units[0].range.start;
    // The search follows a group's first member (`add_traces`): its traces settle
    // across the seams of its units.
    let (traces, refine) = if ctx.searched_now(work) {
        kept.settle((work.group, work.units[0].mode), (model, source), start, &traces, &loads[..traces.len()])
    } else {
        (keep_local_minima(&axes(source), start, &traces, &loads[..traces.len()]), None)
    };
    let layout = ctx.layout;
    let parts = work
        .units
        .iter()
        .zip(bodies)
        .zip(block_stats)
        .map(|((unit, body), block_stats)| {
            let mut stats = SummaryStats::with_capacity(traces.len());
            for b in block_stats.iter().flatten() {
                stats.merge(b);
            }
            // Once, here: the statistics file and the run's total both want it flushed.
            stats.flush();
            kept.add_stats(unit, &stats);
            Part {
                path: layout.part(unit.variant, unit.mode, unit.chunk),
                stats_path: layout.stats(unit.variant, unit.mode, unit.chunk),
                trace_path: layout.trace(unit.variant, unit.mode, unit.chunk),
                traces: traces.clone(),
                body,
                stats,
                extra: part_metadata(&ctx.variants[unit.variant as usize]),
            }
        })
        .collect();
    Concluded { parts, traces, refine, buffers: Buffers { loads, sampled } }
}

/// The search of one step of a run ([`run`]): the paths the work concluded in it
/// completes, searched in batches on the pool once both they are ready and the
/// pass has run out of pages.
struct StepSearch<'a> {
    start: Instant,
    /// The search's paths, and the seconds it took the work's traces in
    /// ([`Kept::receive`]).
    ready: std::sync::OnceLock<(Pending<'a>, f64)>,
    /// How many of the two (ready, out of pages) have happened.
    arrived: std::sync::atomic::AtomicU8,
    /// Each batch's switches, with its index.
    found: std::sync::Mutex<Vec<(usize, Vec<Discontinuity>)>>,
    /// Nanoseconds from `start` to the start of the first batch and to the end of
    /// the last.
    from: std::sync::atomic::AtomicU64,
    to: std::sync::atomic::AtomicU64,
    /// The run's count of its pool's time in tasks, to which its batches add
    /// ([`StageTimes::pool_tasks`]).
    tasks_ns: &'a std::sync::atomic::AtomicU64,
}

impl<'a> StepSearch<'a> {
    fn new(tasks_ns: &'a std::sync::atomic::AtomicU64) -> Self {
        Self {
            start: Instant::now(),
            ready: std::sync::OnceLock::new(),
            arrived: std::sync::atomic::AtomicU8::new(0),
            found: std::sync::Mutex::new(Vec::new()),
            from: std::sync::atomic::AtomicU64::new(u64::MAX),
            to: std::sync::atomic::AtomicU64::new(0),
            tasks_ns,
        }
    }

    fn since_start(&self, at: Instant) -> u64 {
        at.saturating_duration_since(self.start).as_nanos() as u64
    }

    /// The search's paths, ready after `receive` seconds taking the work's traces in.
    fn ready(&self, pending: Pending<'a>, receive: f64) {
        assert!(self.ready.set((pending, receive)).is_ok(), "one search a step");
    }

    /// One of the two has happened (the work concluded, with or without a search;
    /// the pass out of pages): at the second, the batches go out on `scope`.
    fn arrive<'s>(&'s self, scope: &rayon::ScopeFifo<'s>) {
        if self.arrived.fetch_add(1, std::sync::atomic::Ordering::AcqRel) != 1 {
            return;
        }
        let Some((p, _)) = self.ready.get() else { return };
        for (i, batch) in p.batches.iter().enumerate() {
            scope.spawn_fifo(move |_| {
                self.from.fetch_min(self.since_start(Instant::now()), std::sync::atomic::Ordering::Relaxed);
                let switches = timed(self.tasks_ns, || p.search.search_batch(batch));
                self.found.lock().expect("no panic while held").push((i, switches));
                self.to.fetch_max(self.since_start(Instant::now()), std::sync::atomic::Ordering::Relaxed);
            });
        }
    }

    /// The search with its batches' switches in order, and its seconds: taking the
    /// work's traces in, and from the start of its first batch to the end of its
    /// last; `None` without a search.
    fn into_found(self) -> Option<(Pending<'a>, Vec<Vec<Discontinuity>>, f64)> {
        let (p, receive) = self.ready.into_inner()?;
        let mut found = self.found.into_inner().expect("no panic while held");
        found.sort_unstable_by_key(|(i, _)| *i);
        let (from, to) = (self.from.into_inner(), self.to.into_inner());
        let seconds = to.saturating_sub(from) as f64 * 1e-9 + receive;
        Some((p, found.into_iter().map(|(_, f)| f).collect(), seconds))
    }
}

/// A work concluded: its parts for the writer, its settled traces and the
/// refinement of the traces before them ([`Kept::settle`]), its buffers to reuse.
struct Concluded {
    parts: Vec<Part>,
    traces: Vec<Trace>,
    refine: Option<(u64, Vec<Trace>)>,
    buffers: Buffers,
}

/// What a run of any kind starts from: its variants and their groups, the prepared
/// output directory, the units (all, this shard's) and the work still to compute,
/// with their pose counts, and the options of the files it writes.
pub(crate) struct Setup {
    pub variants: Vec<Variant>,
    pub groups: Vec<Group>,
    pub layout: Layout,
    pub all: Vec<Unit>,
    pub mine: Vec<Unit>,
    /// This shard's work still to compute, each with its units still to compute.
    pub todo_work: Vec<Work>,
    pub mine_poses: u64,
    pub todo_poses: u64,
    pub total: u64,
    pub write_opts: WriteOptions,
}

/// Expands `job`'s variants and groups them ([`groups`]), prepares `opts.out` and
/// plans the work; `complete` says whether `--resume` can keep a unit's files.
pub(crate) fn prepare_run(
    job: &JobSpec,
    job_file: &str,
    opts: &RunOptions,
    complete: fn(&Layout, &Unit, bool) -> bool,
) -> Result<Setup> {
    let variants: Vec<Variant> = job.variants(job_file)?;
    let groups = groups(&variants);
    let job_toml = job.to_toml_string();
    let layout = Layout::new(&opts.out);
    let work = works(job, &groups, opts.chunk_size);
    let all: Vec<Unit> = work.iter().flat_map(|w| w.units.iter().cloned()).collect();
    prepare_dir(&layout, &job_toml, opts, &all)?;
    let mine_work: Vec<Work> = work.into_iter().filter(|w| opts.shard.is_none_or(|(i, n)| w.number % n == i)).collect();
    let mine: Vec<Unit> = mine_work.iter().flat_map(|w| w.units.iter().cloned()).collect();
    let todo_work: Vec<Work> = mine_work
        .into_iter()
        .filter_map(|mut w| {
            w.units.retain(|u| !(opts.resume && complete(&layout, u, opts.poses)));
            (!w.units.is_empty()).then_some(w)
        })
        .collect();
    let todo: Vec<Unit> = todo_work.iter().flat_map(|w| w.units.iter().cloned()).collect();
    let poses = |units: &[Unit]| units.iter().map(|u| u.range.end - u.range.start).sum();
    let (mine_poses, todo_poses) = (poses(&mine), poses(&todo));
    let total = job.sample_count() * job.variant_count() * job.analysis.modes.len() as u64;
    let write_opts = WriteOptions {
        metadata: vec![
            ("clearance.job".into(), job_toml),
            ("clearance.version".into(), ENGINE_VERSION.into()),
            ("clearance.git_commit".into(), env!("CLEARANCE_GIT_COMMIT").into()),
            ("clearance.columns".into(), columns_name(opts).into()),
            ("clearance.precision".into(), opts.precision.name().into()),
        ],
        row_group_rows: opts.chunk_size as usize,
        codec: opts.compression,
        durable: false,
        direct_io: opts.direct_io,
        landing: None,
    };
    Ok(Setup { variants, groups, layout, all, mine, todo_work, mine_poses, todo_poses, total, write_opts })
}

/// Writes this shard's marker (with `--shard`) and tells whether every part of the run
/// is done: the process that sees so finishes the run; with shards, at least the last
/// one to write its marker does (two doing it write the same files).
pub(crate) fn mark_shard_done(layout: &Layout, opts: &RunOptions) -> Result<bool> {
    if let Some((i, n)) = opts.shard {
        write_marker(&layout.shard_marker(i, n))?;
    }
    Ok(match opts.shard {
        None => true,
        Some((_, n)) => (0..n).all(|i| layout.shard_marker(i, n).exists()),
    })
}

/// The `clearance.variant` and `clearance.params` metadata of a variant's part files.
pub(crate) fn part_metadata(variant: &Variant) -> Vec<(String, String)> {
    vec![
        ("clearance.variant".to_string(), variant.index.to_string()),
        (
            "clearance.params".to_string(),
            variant.params.iter().map(|(p, v)| format!("{p}={v}")).collect::<Vec<_>>().join(","),
        ),
    ]
}

/// The general solver assembles the 3-limb kinds' 24 × 24 and 12 × 12 systems; a
/// 6-UPS or a custom mechanism has its own systems only, so it is refused there
/// rather than ignored.
pub(crate) fn check_solver(job: &JobSpec, solver: SolverKind) -> Result<()> {
    if solver == SolverKind::General && !job.mechanism.kind.has_general_solver() {
        return Err(EngineError::Unsupported(format!(
            "the general solver (the assembled 24 × 24 and 12 × 12 systems) is for the 3-limb kinds; a {} job is solved by its own systems: use the fast solver",
            job.mechanism.kind.name()
        )));
    }
    Ok(())
}

/// Writes one part file of `batch` with the encoder `writer` names (the same table).
pub(crate) fn write_part_batch(
    writer: Writer,
    precision: Precision,
    path: &std::path::Path,
    batch: &RecordBatch,
    opts: &WriteOptions,
    meta: &[(String, String)],
) -> Result<()> {
    let batch = &with_precision(batch, precision);
    match writer {
        Writer::Engine => write_parquet(path, batch.schema(), std::slice::from_ref(batch), opts, meta)?,
        Writer::Arrow => write_batch_arrow(path, batch, opts, meta)?,
    }
    Ok(())
}

/// The threads that write a 3-limb run's part files beside the pool: one for up to
/// four pool threads, one more for each four more, at most four
/// (`CLEARANCE_WRITERS` overrides it, for measurements).
fn writer_threads() -> usize {
    std::env::var("CLEARANCE_WRITERS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| rayon::current_num_threads().div_ceil(4).clamp(1, 4))
}

/// Runs `job` (read from `job_file`, named in messages) into `opts.out`, computing
/// the units of `opts.shard` on the current rayon pool.
pub fn run(job: &JobSpec, job_file: &str, opts: &RunOptions) -> Result<RunReport> {
    check_solver(job, opts.solver)?;
    if job.mechanism.kind == clearance_model::MechanismKind::Custom {
        return crate::custom::run_custom(job, job_file, opts);
    }
    if job.mechanism.kind == clearance_model::MechanismKind::Ups6 {
        return crate::ups::run_ups(job, job_file, opts);
    }
    let Setup { variants, groups, layout, all, mine, todo_work, mine_poses, todo_poses, total, write_opts, .. } =
        prepare_run(job, job_file, opts, unit_complete::<SummaryStats>)?;
    let layout = &layout;
    // Without pose files (`--columns none`) the pages hold the fewest columns, and
    // are not written: the statistics come from the poses' results.
    let schema = PoseSchema::new(if opts.poses { opts.columns } else { ColumnSet::Minimal }, job.analysis.exact)
        .with_precision(opts.precision);
    // Per group, the job it is solved as.
    let models: Vec<(Model, SampleSource)> = groups
        .iter()
        .map(|g| {
            let job = g.job(&variants);
            let mut model = Model::from_job(&job);
            model.solver = opts.solver;
            // The envelope and the dominant joint are columns of the standard set,
            // and statistics of the summary without pose files.
            model.envelope = opts.columns >= ColumnSet::Standard || !opts.poses;
            (model, SampleSource::new(&job))
        })
        .collect();

    let progress = opts.progress.get();
    progress.start(mine_poses, mine_poses - todo_poses);
    let start = Instant::now();
    let mut done = mine_poses - todo_poses;
    // Without shards or resumed parts, and up to `KEEP_TRACES` poses, the search
    // follows the computation and has everything it needs in memory: the rest runs
    // while the writer finishes the last parts. Otherwise it reads the trace files
    // at the end.
    let computes_all = todo_work.iter().map(|w| w.units.len()).sum::<usize>() == all.len();
    let keep = if opts.shard.is_none() && computes_all && job.sample_count() <= KEEP_TRACES {
        KeepTraces::Search
    } else {
        KeepTraces::No
    };
    let mut kept = Kept { keep, ..Kept::default() };
    let mut stages = StageTimes::default();
    // The buffers of written pages, for pages still to encode.
    let spare = &std::sync::Mutex::new(Vec::<Vec<u8>>::new());
    // The run's own files are on the disk before `_SUCCESS`: synced with the parts
    // when written before them, else as they are written.
    let durable = WriteOptions { durable: true, ..write_opts.clone() };
    // After a writer's failure every writer stops; the receiver goes with the last,
    // and the run's next send fails.
    let failed = &std::sync::atomic::AtomicBool::new(false);
    // What the pool's threads spent in tasks, and of it blocked on the writers' queue.
    let (tasks_ns, queue_ns) = (&std::sync::atomic::AtomicU64::new(0), &std::sync::atomic::AtomicU64::new(0));
    let finalized = std::thread::scope(|scope| -> Result<bool> {
        // Writer threads take the parts in turn: one thread wrote every part, and
        // with many threads it paced the run (issue 39: at 16 threads it was busy
        // 80 % of the wall time, the pool half idle). Each holds at most one part,
        // and the channel as many more, so memory stays bounded.
        let writers = writer_threads();
        let (tx, rx) = sync_channel::<Part>(writers);
        let rx = std::sync::Arc::new(std::sync::Mutex::new(rx));
        let (schema, write_opts) = (&schema, &write_opts);
        let write = move |part: Part| -> Result<()> {
            for dir in [part.path.parent().filter(|_| opts.poses), part.stats_path.parent()].into_iter().flatten() {
                std::fs::create_dir_all(dir).map_err(EngineError::io("create", dir))?;
            }
            write_bytes(&part.trace_path, &encode_traces(&part.traces), write_opts)?;
            write_bytes(
                &part.stats_path,
                &serde_json::to_vec(&part.stats).expect("statistics are plain numbers"),
                write_opts,
            )?;
            match part.body {
                Body::Pages(pages) => {
                    if opts.poses {
                        write_part(&part.path, schema, &pages, write_opts, &part.extra)?;
                    }
                    spare.lock().expect("no panic while held").extend(pages.into_buffers());
                }
                Body::Batch(batch) if opts.poses => {
                    write_part_batch(opts.writer, opts.precision, &part.path, &batch, write_opts, &part.extra)?
                }
                Body::Batch(_) => {}
            }
            Ok(())
        };
        // Each returns its busy seconds.
        let writer_handles: Vec<_> = (0..writers)
            .map(|_| {
                let rx = std::sync::Arc::clone(&rx);
                scope.spawn(move || -> Result<f64> {
                    let mut busy = 0.0;
                    while !failed.load(std::sync::atomic::Ordering::Relaxed) {
                        // The lock is let go before the part is written.
                        let Ok(part) = rx.lock().expect("no panic while held").recv() else { break };
                        let start = Instant::now();
                        if let Err(e) = write(part) {
                            failed.store(true, std::sync::atomic::Ordering::Relaxed);
                            return Err(e);
                        }
                        busy += start.elapsed().as_secs_f64();
                    }
                    Ok(busy)
                })
            })
            .collect();
        drop(rx);
        let workers = &std::sync::Mutex::new(Vec::new());
        let ctx = Ctx {
            schema,
            models: &models,
            groups: &groups,
            variants: &variants,
            opts,
            layout,
            spare,
            tasks_ns,
            workers,
            keep: kept.keep,
            store_sampled: (!models.iter().any(|(_, source)| source.is_trajectory())).into(),
        };
        // Per-pose buffers of units (load magnitudes, the search's values), reused
        // from unit to unit.
        let mut spare_buffers: Vec<Buffers> = Vec::new();
        let mut previous: Option<Computed> = None;
        let mut writer_failed = false;
        for work in todo_work.iter().map(Some).chain([None]) {
            if let Some(w) = work {
                let u = &w.units[0];
                let shared = match w.units.len() {
                    1 => String::new(),
                    n => format!(" (and {} more sharing its solve)", n - 1),
                };
                progress.stage(&format!("variant {} {}{shared}", u.variant, u.mode.name()));
            }
            let mut buffers = spare_buffers.pop().unwrap_or_default();
            if buffers.sampled.capacity() == 0 {
                // The search holds the last ones: one it let go of, if any.
                buffers.sampled = kept.spare_sampled.pop().unwrap_or_default();
            }
            // One step on the pool. The previous work is concluded while this one
            // computes (alone, its few milliseconds would leave the other threads
            // idle), and its parts go to the writer at once rather than after this
            // work: at the end of the run the writer then has one part left to write,
            // not two. The paths it completes are then searched in batches, which
            // the threads take up as the pass runs out of pages: beside the pass, on
            // one thread while the pass had the others, the search was under way for
            // a quarter of a sweep's wall time; this way it fills the time the last
            // pages leave the other threads, then has every thread.
            let tx = &tx;
            let step = StepSearch::new(tasks_ns);
            let mut concluded = None;
            let mut computed = None;
            rayon::scope_fifo(|s| {
                let (ctx, step, concluded, kept, previous) = (&ctx, &step, &mut concluded, &mut kept, &mut previous);
                let (models, variants, groups) = (&models, &variants, &groups);
                s.spawn_fifo(move |s| {
                    *concluded = previous.take().map(|c| {
                        ctx.task(|| {
                            let work = c.work;
                            let Concluded { parts, traces, refine, mut buffers } = conclude(ctx, c, kept);
                            let n = (traces.len() * parts.len()) as u64;
                            let sent = timed(queue_ns, || parts.into_iter().all(|part| tx.send(part).is_ok()));
                            // A group's traces once, from the work of its first member.
                            if ctx.searched_now(work) {
                                let start = Instant::now();
                                let (model, source) = &models[work.group];
                                let opts = search_options(&variants[groups[work.group].first() as usize]);
                                let key = (work.group, work.units[0].mode);
                                let sampled = std::mem::take(&mut buffers.sampled);
                                let pending = kept.receive(key, refine, &traces, sampled, model, source, &opts);
                                step.ready(pending, start.elapsed().as_secs_f64());
                            }
                            (n, buffers, sent)
                        })
                    });
                    step.arrive(s);
                });
                let computed = &mut computed;
                s.spawn_fifo(move |s| {
                    let start = Instant::now();
                    let once = std::sync::Once::new();
                    let idle = || once.call_once(|| step.arrive(s));
                    let result = work.map(|w| compute(ctx, w, buffers, &idle)).transpose();
                    let pose_pass = start.elapsed().as_secs_f64();
                    idle();
                    *computed = Some((result, pose_pass));
                });
            });
            let (computed, pose_pass) = computed.expect("the step computes");
            stages.pose_pass += pose_pass;
            let start = Instant::now();
            if let Some((p, found, seconds)) = step.into_found() {
                let reads = kept.searched(p, found);
                if reads.stored > 0 && !reads.paid() {
                    ctx.store_sampled.store(false, std::sync::atomic::Ordering::Relaxed);
                }
                stages.search += seconds + start.elapsed().as_secs_f64();
            }
            previous = computed?;
            if let Some((n, buffers, sent)) = concluded {
                spare_buffers.push(buffers);
                if !sent {
                    writer_failed = true; // its error is reported below
                    break;
                }
                done += n;
                progress.advance(n, done);
            }
        }
        drop(tx);
        let finalized = (kept.keep == KeepTraces::Search && !writer_failed).then(|| {
            progress.finish();
            let kept = std::mem::take(&mut kept);
            let start = Instant::now();
            let done = finalize(layout, job, &variants, &groups, &models, &all, opts, write_opts, kept, &mut stages);
            stages.finish += start.elapsed().as_secs_f64();
            done
        });
        // The writer's error first: a search over parts that failed to be written means nothing.
        let busy: Vec<Result<f64>> =
            writer_handles.into_iter().map(|w| w.join().expect("a writer thread does not panic")).collect();
        // The writers' mean busy time: the share of the wall time they were busy.
        stages.writing += busy.into_iter().sum::<Result<f64>>()? / writers as f64;
        let threads = rayon::current_num_threads() as f64;
        stages.pool_tasks = tasks_ns.load(std::sync::atomic::Ordering::Relaxed) as f64 * 1e-9 / threads;
        stages.queue_wait = queue_ns.load(std::sync::atomic::Ordering::Relaxed) as f64 * 1e-9;
        finalized.transpose().map(|f| f.is_some())
    })?;
    progress.finish();

    if let Some(shard) = opts.shard.filter(|_| opts.search) {
        let start = Instant::now();
        crate::owned::search_owned(layout, job, &variants, &groups, &models, opts, shard)?;
        stages.search += start.elapsed().as_secs_f64();
    }
    let finals: Vec<PathBuf> = if finalized { layout.final_files().into() } else { Vec::new() };
    let syncing = Instant::now();
    sync_units(layout, &mine, &finals)?;
    stages.writing += syncing.elapsed().as_secs_f64();
    let complete = mark_shard_done(layout, opts)?;
    if complete {
        if !finalized {
            let start = Instant::now();
            finalize(layout, job, &variants, &groups, &models, &all, opts, &durable, kept, &mut stages)?;
            stages.finish += start.elapsed().as_secs_f64();
        }
        write_marker(&layout.success())?;
    }
    Ok(RunReport { computed: todo_poses, total, seconds: start.elapsed().as_secs_f64(), complete, stages })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ranges read across files of different lengths, in any order, give the
    /// traces written.
    #[test]
    fn trace_files_read_as_one_array() {
        let dir = tempfile::tempdir().unwrap();
        // The third file is read in several pieces.
        let lens = [5u64, 1, 40_000, 3];
        let all: Vec<Trace> = (0..lens.iter().sum::<u64>()).map(|i| i.wrapping_mul(0x9e37_79b9_7f4a_7c15)).collect();
        let (mut ranges, mut paths, mut start) = (Vec::new(), Vec::new(), 0);
        for (k, len) in lens.into_iter().enumerate() {
            let path = dir.path().join(format!("{k}.trace"));
            std::fs::write(&path, encode_traces(&all[start as usize..(start + len) as usize])).unwrap();
            ranges.push(start..start + len);
            paths.push(path);
            start += len;
        }
        let mut files = TraceFiles::new(ranges, paths);
        for range in [0..40_009, 3..7, 6..39_000, 5..6, 40_004..40_009, 1000..40_006, 0..1, 4..5, 20..30] {
            let mut dst = vec![0; (range.end - range.start) as usize];
            files.read(range.clone(), &mut dst).unwrap();
            assert_eq!(dst, all[range.start as usize..range.end as usize], "{range:?}");
        }
    }
}
