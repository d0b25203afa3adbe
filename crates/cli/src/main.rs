//! `clearance`: pose errors of parallel robots (the three built-in kinds, or any mechanism
//! described by its joints) due to joint clearances, from a job file to a Parquet dataset.
//! See README.md and docs/interface.md.

mod allocate;
mod bench;
mod check;
mod progress;
mod status;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use clearance_engine::{
    Codec, ColumnSet, EngineError, Isa, JobError, JobSpec, Precision, Reporter, RunOptions, SolverKind, Writer, cap_isa,
};

#[derive(Parser)]
#[command(
    name = "clearance",
    version,
    about = "Pose error of parallel robots due to joint clearances: the 3-PRS, 3-RPS and 6-UPS, or any mechanism described by its joints"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a job into an output directory of Parquet files.
    Run {
        /// The job file (TOML).
        job: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Compute shard I of N (0-based), e.g. `--shard 3/8`.
        #[arg(long, value_parser = parse_shard)]
        shard: Option<(u64, u64)>,
        /// The shard count N when the shard index comes from JOB_COMPLETION_INDEX (Kubernetes).
        #[arg(long)]
        shard_count: Option<u64>,
        /// Finish an interrupted run: keep complete part files, compute the rest.
        #[arg(long, conflicts_with = "overwrite")]
        resume: bool,
        /// Replace an earlier run in the output directory.
        #[arg(long)]
        overwrite: bool,
        /// Column set: minimal, standard or full; none writes no pose files, only the
        /// summary and the switches.
        #[arg(long, default_value = "standard", value_parser = parse_run_columns)]
        columns: (ColumnSet, bool),
        /// Samples per part file.
        #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u64).range(1..))]
        chunk_size: u64,
        /// `fast` (6 × 6 reduced systems) or `general` (the assembled 24 × 24 and 12 × 12, faer).
        #[arg(long, default_value = "fast", value_parser = parse_solver)]
        solver: SolverKind,
        /// Parquet page compression: none, lz4 or zstd (benches/README.md has the trade-off).
        #[arg(long, default_value = "zstd", value_parser = parse_codec)]
        compression: Codec,
        /// Encoder of the part files: `engine` (its own pages) or `arrow` (parquet's ArrowWriter); the same table.
        #[arg(long, default_value = "engine", value_parser = parse_writer)]
        writer: Writer,
        /// `double`, or `single`: the error, envelope and margin columns of the pose files as float32 (relative rounding at most 6e-8).
        #[arg(long, default_value = "double", value_parser = parse_precision)]
        precision: Precision,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Validate a job and print the expanded plan.
    Check {
        job: PathBuf,
        /// Skip the short calibration runs behind the time estimate.
        #[arg(long)]
        no_timing: bool,
        /// The column set of the run to estimate.
        #[arg(long, default_value = "standard", value_parser = parse_columns)]
        columns: ColumnSet,
        /// Worker threads of the run to estimate (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// The solver of the run to estimate.
        #[arg(long, default_value = "fast", value_parser = parse_solver)]
        solver: SolverKind,
    },
    /// Print any job as a custom mechanism described by its joints (a job that runs
    /// and gives the same values; docs/model.md §12).
    Describe { job: PathBuf },
    /// PNG error maps and trajectory plots from a finished run.
    Plot {
        dir: PathBuf,
        /// Where to write the figures (default: DIR/plots).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The cheapest clearance of each joint kind for an error budget over every pose
    /// of the job (its `[allocate]` table: kinds, weights, bounds; docs/model.md §13).
    Allocate {
        /// The job file (TOML).
        job: PathBuf,
        /// Budget on |Δp| at every pose (m), e.g. 1e-4.
        #[arg(long, required_unless_present = "budgets", value_parser = parse_budget)]
        max_dp: Option<f64>,
        /// Budget on |Δα| at every pose (rad).
        #[arg(long, value_parser = parse_budget)]
        max_dalpha: Option<f64>,
        /// `takeup` (the loads decide each joint's take-up) or `envelope` (any take-up).
        #[arg(long, default_value = "takeup", value_parser = parse_model)]
        model: clearance_engine::AllocModel,
        /// One magnitude per limb of each allocated kind (the job gives each as a list).
        #[arg(long)]
        per_limb: bool,
        /// The trade-off curve instead: budgets on |Δp| (m), comma-separated, e.g. 5e-5,1e-4,2e-4.
        #[arg(long, value_delimiter = ',', value_parser = parse_budget, conflicts_with = "max_dp")]
        budgets: Vec<f64>,
        /// Where to write the answer (default: the current directory); also runs the job
        /// at the allocated magnitudes into OUT/verify.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print allocation.json on stdout instead of the summary.
        #[arg(long)]
        json: bool,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress output.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Is the run in DIR (or every shard of it) complete? Exit 0 if so.
    Status { dir: PathBuf },
    /// Solver and end-to-end throughput, poses/s.
    Bench {
        /// Poses per measurement.
        #[arg(long, default_value_t = 400_000)]
        poses: u64,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
        /// Solver of the end-to-end measurement (the kernel is measured with both).
        #[arg(long, default_value = "fast", value_parser = parse_solver)]
        solver: SolverKind,
        /// Parquet compression of the end-to-end measurement.
        #[arg(long, default_value = "zstd", value_parser = parse_codec)]
        compression: Codec,
        /// Encoder of the part files of the end-to-end measurements: `engine` or `arrow`.
        #[arg(long, default_value = "engine", value_parser = parse_writer)]
        writer: Writer,
        /// Run the suite of benches/suite/ (every kind of job) instead of the prototype's grid.
        #[arg(long, conflicts_with_all = ["job", "poses"])]
        suite: bool,
        /// With --suite: about this many times each suite job's samples (e.g. 0.1).
        #[arg(long, default_value_t = 1.0, requires = "suite", value_parser = parse_scale)]
        scale: f64,
        /// Runs of each measurement; the fastest is reported, and the JSON lists them all.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=100))]
        repeat: u64,
        /// Measure this job's grid (first variant, kinetostatic) instead of the prototype's
        /// (--poses is then ignored).
        #[arg(long)]
        job: Option<std::path::PathBuf>,
        /// The kernel and end-to-end rates at 1, 2, 4 … threads and every core, side by
        /// side, with each stage's share of the end-to-end run.
        #[arg(long, conflicts_with_all = ["suite", "threads"])]
        scaling: bool,
        /// With --scaling: the thread counts, e.g. 1,2,8,16 (default 1, 2, 4 … every core).
        #[arg(long, value_delimiter = ',', requires = "scaling", value_parser = clap::value_parser!(u64).range(1..=4096))]
        thread_counts: Vec<u64>,
        /// With --scaling: the column set of the end-to-end runs (none: no pose files).
        #[arg(long, default_value = "standard", requires = "scaling", value_parser = parse_run_columns)]
        columns: (ColumnSet, bool),
    },
}

fn parse_budget(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        _ => Err(format!("budget `{s}` is not a positive number (m or rad)")),
    }
}

fn parse_model(s: &str) -> Result<clearance_engine::AllocModel, String> {
    clearance_engine::AllocModel::parse(s).ok_or_else(|| format!("unknown model `{s}`; use takeup or envelope"))
}

fn parse_solver(s: &str) -> Result<SolverKind, String> {
    match s {
        "fast" => Ok(SolverKind::Fast),
        "general" => Ok(SolverKind::General),
        _ => Err(format!("unknown solver `{s}`; use fast or general")),
    }
}

fn parse_shard(s: &str) -> Result<(u64, u64), String> {
    let (i, n) = s.split_once('/').ok_or("expected I/N, e.g. 0/4")?;
    let i: u64 = i.trim().parse().map_err(|_| format!("shard index `{i}` is not a whole number"))?;
    let n: u64 = n.trim().parse().map_err(|_| format!("shard count `{n}` is not a whole number"))?;
    if n == 0 || i >= n {
        return Err(format!("shard {i}/{n}: need 0 <= I < N"));
    }
    Ok((i, n))
}

fn parse_writer(s: &str) -> Result<Writer, String> {
    Writer::parse(s).ok_or_else(|| format!("unknown writer `{s}`; use {}", Writer::NAMES.join(" or ")))
}

fn parse_scale(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        _ => Err(format!("scale `{s}` is not a positive number")),
    }
}

fn parse_precision(s: &str) -> Result<Precision, String> {
    Precision::parse(s).ok_or_else(|| format!("unknown precision `{s}`; use {}", Precision::NAMES.join(", ")))
}

fn parse_codec(s: &str) -> Result<Codec, String> {
    Codec::parse(s).ok_or_else(|| format!("unknown compression `{s}`; use {}", Codec::NAMES.join(", ")))
}

/// A run's `--columns`: the set, and whether pose files are written (`none`: the
/// standard set's quantities for the summary, no pose file).
fn parse_run_columns(s: &str) -> Result<(ColumnSet, bool), String> {
    match s {
        "none" => Ok((ColumnSet::Standard, false)),
        _ => ColumnSet::parse(s)
            .map(|set| (set, true))
            .ok_or_else(|| format!("unknown column set `{s}`; use none, minimal, standard or full")),
    }
}

fn parse_columns(s: &str) -> Result<ColumnSet, String> {
    ColumnSet::parse(s).ok_or_else(|| format!("unknown column set `{s}`; use minimal, standard or full"))
}

/// The shard from the flag, or from the scheduler's environment.
fn resolve_shard(flag: Option<(u64, u64)>, count: Option<u64>) -> Result<Option<(u64, u64)>, String> {
    if flag.is_some() {
        return Ok(flag);
    }
    let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
    if let (Some(i), Some(n)) = (var("SLURM_ARRAY_TASK_ID"), var("SLURM_ARRAY_TASK_COUNT")) {
        return parse_shard(&format!("{i}/{n}")).map(Some).map_err(|e| format!("SLURM_ARRAY_TASK_ID/COUNT: {e}"));
    }
    if let Some(i) = var("JOB_COMPLETION_INDEX") {
        let n = count.ok_or("JOB_COMPLETION_INDEX is set: give the number of shards with --shard-count N")?;
        return parse_shard(&format!("{i}/{n}")).map(Some).map_err(|e| format!("JOB_COMPLETION_INDEX: {e}"));
    }
    if count.is_some() {
        return Err("--shard-count needs JOB_COMPLETION_INDEX (or use --shard I/N)".into());
    }
    Ok(None)
}

fn init_threads(threads: Option<usize>) -> anyhow::Result<()> {
    if let Some(n) = threads {
        rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global()?;
    }
    Ok(())
}

fn load_job(path: &std::path::Path) -> Result<JobSpec, JobError> {
    JobSpec::from_path(path)
}

/// Makes glibc's allocator keep memory that is freed for the next allocation
/// rather than give it back to the system. A run allocates and frees megabytes a
/// part (column buffers, encoded pages); given back, each comes again as fresh
/// pages that fault in one by one: 200 000 faults and a tenth of the CPU of a
/// 2 M-pose run, against 45 000 (benches/README.md). Allocations up to 64 MiB come
/// from the heap, which is trimmed only past 1 GiB free. `MALLOC_MMAP_THRESHOLD_`
/// or `MALLOC_TRIM_THRESHOLD_` in the environment take precedence.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    for (name, param, value) in [
        ("MALLOC_MMAP_THRESHOLD_", libc::M_MMAP_THRESHOLD, 64 << 20),
        ("MALLOC_TRIM_THRESHOLD_", libc::M_TRIM_THRESHOLD, 1 << 30),
    ] {
        if std::env::var_os(name).is_none() {
            // SAFETY: sets an allocator parameter before any other thread exists.
            unsafe {
                libc::mallopt(param, value);
            }
        }
    }
}

/// `CLEARANCE_ISA=portable|avx2|avx512` caps the kernel's vector instructions
/// (docs/interface.md); a value that names none is ignored with a warning.
fn cap_isa_from_env() {
    if let Ok(v) = std::env::var("CLEARANCE_ISA") {
        match Isa::parse(&v) {
            Some(isa) => cap_isa(isa),
            None => eprintln!("clearance: CLEARANCE_ISA={v:?} is not portable, avx2 or avx512; ignored"),
        }
    }
}

/// `CLEARANCE_BUFFERED_IO` set (to anything) writes every file through the page cache.
fn buffered_io_not_asked() -> bool {
    std::env::var_os("CLEARANCE_BUFFERED_IO").is_none()
}

fn main() -> ExitCode {
    // Die quietly like other Unix tools when the reader of stdout goes away
    // (`clearance check JOB | head`), instead of panicking on a broken pipe.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    keep_freed_memory();
    cap_isa_from_env();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            job,
            out,
            threads,
            shard,
            shard_count,
            resume,
            overwrite,
            columns,
            chunk_size,
            solver,
            compression,
            writer,
            precision,
            quiet,
        } => {
            let spec = match load_job(&job) {
                Ok(s) => s,
                Err(e) => return usage(e),
            };
            let shard = match resolve_shard(shard, shard_count) {
                Ok(s) => s,
                Err(e) => return usage(e),
            };
            let direct_io = buffered_io_not_asked();
            let (columns, poses) = columns;
            let opts = RunOptions {
                out,
                columns,
                shard,
                resume,
                overwrite,
                chunk_size,
                solver,
                compression,
                writer,
                precision,
                progress: Reporter::new(std::sync::Arc::new(progress::Display::new(quiet))),
                direct_io,
                search: true,
                poses,
            };
            let run = |()| clearance_engine::run(&spec, &job.display().to_string(), &opts).map_err(anyhow::Error::from);
            init_threads(threads).and_then(run).map(|r| {
                if !quiet {
                    eprintln!(
                        "computed {} of {} poses in {:.2} s{}; output in {}",
                        r.computed,
                        r.total,
                        r.seconds,
                        if r.complete { "" } else { " (other shards still to finish)" },
                        opts.out.display()
                    );
                }
            })
        }
        Command::Check { job, no_timing, columns, threads, solver } => match load_job(&job) {
            Ok(spec) => {
                // The calibration runs are real runs of the job, scaled down, into scratch.
                let opts = RunOptions {
                    out: clearance_engine::calibration_dir(&std::env::temp_dir()),
                    columns,
                    shard: None,
                    resume: false,
                    overwrite: true,
                    chunk_size: 65536,
                    solver,
                    compression: Codec::default(),
                    writer: Writer::default(),
                    precision: clearance_engine::Precision::Double,
                    progress: Reporter::default(),
                    direct_io: buffered_io_not_asked(),
                    search: true,
                    poses: true,
                };
                let timing = (!no_timing).then_some(&opts);
                init_threads(threads).and_then(|()| check::check(&spec, &job.display().to_string(), timing))
            }
            Err(e) => return usage(e),
        },
        Command::Describe { job } => {
            match load_job(&job).and_then(|spec| clearance_engine::describe(&spec, &job.display().to_string())) {
                Ok(described) => {
                    print!("{}", described.to_toml_string());
                    Ok(())
                }
                Err(e) => return usage(e),
            }
        }
        Command::Allocate { job, max_dp, max_dalpha, model, per_limb, budgets, out, json, threads, quiet } => {
            if let Err(e) = load_job(&job) {
                return usage(e);
            }
            let mut opts = clearance_engine::AllocateOptions::new(max_dp.unwrap_or(f64::NAN));
            opts.max_dalpha = max_dalpha;
            opts.model = model;
            opts.per_limb = per_limb;
            let args = allocate::Args { job, opts, budgets, out, json, quiet };
            init_threads(threads).and_then(|()| allocate::allocate(&args))
        }
        Command::Status { dir } => return status::status(&dir),
        Command::Plot { dir, out } => {
            let out = out.unwrap_or_else(|| clearance_engine::Layout::new(&dir).plots());
            clearance_plot::plot_run(&dir, &out).map_err(anyhow::Error::from).map(|files| {
                for f in &files {
                    println!("{}", f.display());
                }
                eprintln!("{} figures in {}", files.len(), out.display());
            })
        }
        Command::Bench {
            poses,
            json,
            threads,
            solver,
            compression,
            writer,
            suite,
            scale,
            repeat,
            job,
            scaling,
            thread_counts,
            columns,
        } => {
            let job = match job.map(|p| JobSpec::from_path(&p)).transpose() {
                Ok(job) => job,
                Err(e) => return usage(e),
            };
            let repeat = repeat as usize;
            if scaling {
                let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
                let threads = if thread_counts.is_empty() {
                    bench::default_thread_counts(cores)
                } else {
                    thread_counts.iter().map(|&t| t as usize).collect()
                };
                let o =
                    bench::ScalingOptions { poses, json, solver, compression, writer, columns, repeat, threads, job };
                return finish(bench::scaling(&o));
            }
            init_threads(threads).and_then(|_| {
                if suite {
                    bench::suite(&bench::SuiteOptions { scale, repeat, solver, compression, writer, json })
                } else {
                    bench::bench(poses, json, solver, compression, writer, repeat, job)
                }
            })
        }
    };
    finish(result)
}

/// The exit code of a command's result, its error printed: 2 for the caller's
/// mistakes, 1 for the rest.
fn finish(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e)
            if e.downcast_ref::<EngineError>().is_some_and(EngineError::is_usage)
                || e.downcast_ref::<JobError>().is_some() =>
        {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn usage(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(2)
}
