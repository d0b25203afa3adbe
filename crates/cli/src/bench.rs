//! `clearance bench`: solver and end-to-end throughput on this machine, on the
//! prototype's grid or (`--suite`) on each kind of job users run.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use clearance_engine::{
    Codec, ColumnSet, Isa, JobSpec, MechanismKind, RunOptions, RunReport, SolveOptions, SolverKind, Writer, bench_job,
    kernel_rate, run, scaled, solve,
};
use clearance_model::Mode;

/// Bytes of the files under `dir`, recursively (0 if it is missing).
fn dir_size(dir: &std::path::Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    entries
        .filter_map(|e| e.ok())
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => dir_size(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}

/// CPU seconds this process has used so far, user and system, every thread (the
/// pool, the writer threads, the caller's); `None` where the system will not say.
fn process_cpu_seconds() -> Option<f64> {
    // SAFETY: `getrusage` only writes the `rusage` it is given, which is plain data.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return None;
    }
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
}

/// Runs `f`, returning its result and the CPU seconds the process used meanwhile
/// (NaN where the system will not say).
fn with_cpu<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let before = process_cpu_seconds();
    let out = f();
    let used = before.zip(process_cpu_seconds()).map_or(f64::NAN, |(b, a)| a - b);
    (out, used)
}

/// The fastest of `rates` (the run least slowed by whatever else the machine
/// was doing), and all of them as a JSON list.
fn best(rates: &[f64]) -> (f64, String) {
    let list = rates.iter().map(|r| format!("{r:.1}")).collect::<Vec<_>>().join(", ");
    (rates.iter().copied().fold(0.0, f64::max), format!("[{list}]"))
}

/// Poses/s of `job`'s poses without I/O. The 3-limb kinds: the batched kernel
/// ([`kernel_rate`]). A 6-UPS, which `kernel_rate` cannot pose and which has one
/// solver (the assembled 42 × 42 and 30 × 30 systems, whatever `solver` says): its
/// samples solved in memory on the pool into the minimal columns
/// ([`clearance_engine::solve`], the pose pass of `clearance run` without the parts,
/// the search or the summary).
fn kernel_of(job: &JobSpec, solver: SolverKind) -> Result<f64> {
    if job.mechanism.kind.has_general_solver() {
        return Ok(kernel_rate(job, solver));
    }
    // A 6-UPS or custom job has one solver, its own (the general one is refused there):
    // both figures are its pose pass.
    let opts = SolveOptions { columns: ColumnSet::Minimal, solver: SolverKind::Fast, ..Default::default() };
    let start = Instant::now();
    let batches = solve(job, "bench job", &opts)?;
    let secs = start.elapsed().as_secs_f64();
    let rows: usize = std::hint::black_box(&batches).iter().map(|b| b.num_rows()).sum();
    Ok(rows as f64 / secs)
}

/// Each measurement is made `repeat` times; the fastest is reported, and every
/// run is listed in the JSON (`*_runs`).
///
/// `job` replaces the prototype's grid: its first variant, as written, kinetostatic
/// (a robot of the family, say; for a 6-UPS or custom job the kernel is its pose pass in memory,
/// [`kernel_of`]).
#[allow(clippy::too_many_arguments)]
pub fn bench(
    poses: u64,
    json: bool,
    solver: SolverKind,
    compression: Codec,
    writer: Writer,
    repeat: usize,
    job: Option<JobSpec>,
) -> Result<()> {
    // The general path is slower: the prototype's is measured on a tenth of the poses.
    let (job, general_job) = match job {
        None => (bench_job(poses), bench_job(poses / 10)),
        Some(job) => {
            let mut first = job.variants("bench job")?.swap_remove(0).job;
            first.analysis.modes = vec![Mode::Kinetostatic];
            (first.clone(), first)
        }
    };
    let isa = Isa::best().name();
    let n = job.sample_count();
    let threads = rayon::current_num_threads();
    kernel_rate(&bench_job(10_000), SolverKind::Fast); // warm up
    let kernels: Vec<f64> = (0..repeat).map(|_| kernel_of(&job, SolverKind::Fast)).collect::<Result<_>>()?;
    let kernel_general = kernel_of(&general_job, SolverKind::General)?;
    let dir = std::env::temp_dir().join(format!("clearance-bench-{}", std::process::id()));
    let opts = RunOptions {
        out: dir.clone(),
        columns: ColumnSet::Standard,
        shard: None,
        resume: false,
        overwrite: false,
        chunk_size: 65536,
        solver,
        compression,
        writer,
        precision: clearance_engine::Precision::Double,
        progress: Default::default(),
        direct_io: crate::buffered_io_not_asked(),
        search: true,
        poses: true,
    };
    let mut e2es = Vec::with_capacity(repeat);
    let mut bytes = 0;
    for _ in 0..repeat {
        let _ = std::fs::remove_dir_all(&dir);
        let start = Instant::now();
        let report = run(&job, "bench.toml", &opts);
        let secs = start.elapsed().as_secs_f64();
        bytes = dir_size(&dir.join("poses"));
        let _ = std::fs::remove_dir_all(&dir);
        report?;
        e2es.push(n as f64 / secs);
    }
    let (kernel, kernel_runs) = best(&kernels);
    let (e2e, e2e_runs) = best(&e2es);
    // What the disk must take per pose: with the disk's write rate, a ceiling on
    // end-to-end throughput that no amount of computing lifts.
    let bytes_per_pose = bytes as f64 / n as f64;
    if json {
        println!(
            "{{\"job\": \"{}\", \"mechanism\": \"{}\", \"kernel_poses_per_s\": {kernel:.1}, \"kernel_general_poses_per_s\": {kernel_general:.1}, \"end_to_end_poses_per_s\": {e2e:.1}, \"threads\": {threads}, \"poses\": {n}, \"solver\": \"{}\", \"compression\": \"{}\", \"bytes_per_pose\": {bytes_per_pose:.1}, \"isa\": \"{isa}\", \"repeat\": {repeat}, \"kernel_runs\": {kernel_runs}, \"end_to_end_runs\": {e2e_runs}}}",
            job.name(),
            job.mechanism.kind.name(),
            if solver == SolverKind::Fast { "fast" } else { "general" },
            compression.name()
        );
    } else {
        println!("job: {} ({})", job.name(), job.mechanism.kind.name());
        println!("poses per measurement: {n}, threads: {threads}, vector instructions: {isa}, best of {repeat}");
        if job.mechanism.kind == MechanismKind::Ups6 {
            println!("pose pass in memory (minimal columns, no I/O): {kernel:>12.0} poses/s");
        } else {
            println!("kernel (kinetostatic, 4 kinds, no I/O): {kernel:>12.0} poses/s");
        }
        println!("kernel, general faer path:              {kernel_general:>12.0} poses/s");
        println!("end to end (grid -> Parquet, standard):  {e2e:>12.0} poses/s (writer: {})", writer.name());
        println!("Parquet written ({}):                {bytes_per_pose:>12.1} bytes/pose", compression.name());
    }
    Ok(())
}

/// One job of the suite: a job file of `benches/suite/`, run with a column set.
pub struct SuiteJob {
    /// The job's name in the suite's report.
    pub name: &'static str,
    /// The job file, from the repository's root.
    pub file: &'static str,
    /// Its text, compiled in: an installed binary runs the suite without the repository.
    pub text: &'static str,
    pub columns: ColumnSet,
}

macro_rules! suite_job {
    ($name:literal, $file:literal, $columns:ident) => {
        SuiteJob {
            name: $name,
            file: concat!("benches/suite/", $file),
            text: include_str!(concat!("../../../benches/suite/", $file)),
            columns: ColumnSet::$columns,
        }
    };
}

/// The jobs of `clearance bench --suite`, in the order they run. Each file is a
/// plain job: `clearance run benches/suite/<file> --out DIR --columns <set>` runs
/// exactly what the suite measures (at `--scale 1`).
pub const SUITE: &[SuiteJob] = &[
    suite_job!("grid_2d", "grid_2d.toml", Standard),
    suite_job!("grid_2d_minimal", "grid_2d.toml", Minimal),
    suite_job!("grid_2d_full", "grid_2d.toml", Full),
    suite_job!("grid_3d", "grid_3d.toml", Standard),
    suite_job!("sweep_16", "sweep_16.toml", Standard),
    suite_job!("sweep_masses_4", "sweep_masses_4.toml", Standard),
    suite_job!("sweep_masses_clearances_12", "sweep_masses_clearances_12.toml", Standard),
    suite_job!("trajectory_dynamic", "trajectory_dynamic.toml", Standard),
    suite_job!("prs_inclined", "prs_inclined.toml", Standard),
    suite_job!("rps_grid", "rps_grid.toml", Standard),
    suite_job!("ups_grid", "ups_grid.toml", Standard),
    suite_job!("prs_builtin", "prs_builtin.toml", Standard),
    suite_job!("prs_described", "prs_described.toml", Standard),
    suite_job!("ups_described", "ups_described.toml", Standard),
    suite_job!("custom_3rrs", "custom_3rrs.toml", Standard),
    suite_job!("custom_6pus", "custom_6pus.toml", Standard),
];

impl SuiteJob {
    /// The job, its samples scaled by `scale` ([`scaled`]).
    pub fn job(&self, scale: f64) -> Result<JobSpec> {
        Ok(scaled(JobSpec::from_toml_str(self.text, self.file)?, scale))
    }
}

/// A directory removed when dropped, whatever happened in between.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One suite job measured.
struct Measured {
    job: &'static SuiteJob,
    mechanism: &'static str,
    rows: u64,
    variants: u64,
    modes: usize,
    /// Poses/s of each run, end to end.
    rates: Vec<f64>,
    /// The report of the fastest run.
    best: RunReport,
    bytes_per_pose: f64,
    /// Wall seconds of the fastest run of the job without its search
    /// ([`RunOptions::search`]).
    without_search: f64,
    /// CPU seconds (every thread) of the run that used the least, with its search
    /// and without it.
    cpu: f64,
    cpu_without_search: f64,
}

impl Measured {
    /// The share of the fastest run's wall time that its search adds: one less the
    /// wall time of the fastest run without it against that of the fastest with it
    /// (noise can make it slightly negative).
    fn search_added(&self) -> f64 {
        if self.best.seconds > 0.0 && self.without_search.is_finite() {
            1.0 - self.without_search / self.best.seconds
        } else {
            0.0
        }
    }

    /// The share of the run's CPU time (every thread) that its search costs: one less
    /// the least CPU seconds of a run without it against the least of a run with it.
    /// Unlike the wall time, this does not depend on what the search overlaps.
    fn search_cpu(&self) -> f64 {
        if self.cpu > 0.0 && self.cpu_without_search.is_finite() {
            1.0 - self.cpu_without_search / self.cpu
        } else {
            0.0
        }
    }

    fn rate(&self) -> f64 {
        self.rates.iter().copied().fold(0.0, f64::max)
    }

    /// A stage's busy time against the fastest run's wall time.
    fn share(&self, seconds: f64) -> f64 {
        if self.best.seconds > 0.0 { seconds / self.best.seconds } else { 0.0 }
    }

    /// Whether the run timed its stages (`RunReport::stages` not all zero): its
    /// shares say nothing otherwise.
    fn stages_timed(&self) -> bool {
        let st = &self.best.stages;
        st.pose_pass > 0.0 || st.search > 0.0 || st.writing > 0.0
    }
}

/// The wall time of the 12-variant masses × clearances sweep over that of its 4
/// mass variants alone, both fastest runs of this invocation: what the extra
/// clearance variants cost when they share their group's solve and search.
fn clearance_sweep_cost(measured: &[Measured]) -> Option<f64> {
    let seconds = |name: &str| measured.iter().find(|m| m.job.name == name).map(|m| m.best.seconds);
    Some(seconds("sweep_masses_clearances_12")? / seconds("sweep_masses_4")?)
}

/// Each custom description of a built-in kind with its built-in twin in the suite (the
/// same grid): the name of the kind, the described job's and the built-in job's.
const DESCRIBED: [(&str, &str, &str); 2] =
    [("3-PRS", "prs_described", "prs_builtin"), ("6-UPS", "ups_described", "ups_grid")];

/// Per kind of [`DESCRIBED`] measured, the described job's fastest wall time over its
/// built-in twin's (the custom pipeline's cost against the kind's own path; issue 38
/// asks at most 2 for the 3-PRS).
fn described_cost(measured: &[Measured]) -> Vec<(&'static str, f64)> {
    let seconds = |name: &str| measured.iter().find(|m| m.job.name == name).map(|m| m.best.seconds);
    DESCRIBED
        .iter()
        .filter_map(|&(kind, described, builtin)| Some((kind, seconds(described)? / seconds(builtin)?)))
        .collect()
}

/// The suite's 3-D grid run as a cluster would run it, its shards one after another.
struct Sharded {
    job: &'static str,
    shards: u64,
    /// Wall seconds of all the shards' invocations.
    seconds: f64,
    /// Of which the step that finishes the run ([`clearance_engine::StageTimes::finish`]).
    finish: f64,
}

impl Sharded {
    fn finish_share(&self) -> f64 {
        if self.seconds > 0.0 { self.finish / self.seconds } else { 0.0 }
    }

    fn json(&self) -> String {
        format!(
            "{{\"job\": \"{}\", \"shards\": {}, \"seconds\": {:.4}, \"finish_seconds\": {:.4}, \"finish_share\": {:.4}}}",
            self.job,
            self.shards,
            self.seconds,
            self.finish,
            self.finish_share()
        )
    }
}

/// The shards of the suite's `grid_3d`, one after another into `dir`, the fastest of
/// `repeat` such runs: where a cluster's serial tail would show, in the last shard.
fn sharded_run(o: &SuiteOptions, dir: &std::path::Path) -> Result<Sharded> {
    const SHARDS: u64 = 8;
    let s = SUITE.iter().find(|s| s.name == "grid_3d").expect("the suite has a 3-D grid");
    let job = s.job(o.scale)?;
    let mut best = Sharded { job: s.name, shards: SHARDS, seconds: f64::INFINITY, finish: 0.0 };
    for _ in 0..o.repeat.max(1) {
        let _ = std::fs::remove_dir_all(dir);
        let (mut seconds, mut finish) = (0.0, 0.0);
        for i in 0..SHARDS {
            let opts = o.run_options(dir, s.columns, Some((i, SHARDS)));
            let start = Instant::now();
            let report = run(&job, s.file, &opts)?;
            seconds += start.elapsed().as_secs_f64();
            finish += report.stages.finish;
        }
        if seconds < best.seconds {
            (best.seconds, best.finish) = (seconds, finish);
        }
    }
    let _ = std::fs::remove_dir_all(dir);
    Ok(best)
}

/// How the suite runs.
pub struct SuiteOptions {
    pub scale: f64,
    pub repeat: usize,
    pub solver: SolverKind,
    pub compression: Codec,
    pub writer: Writer,
    pub json: bool,
}

impl SuiteOptions {
    /// How `clearance run` would run a suite job into `out`.
    fn run_options(&self, out: &std::path::Path, columns: ColumnSet, shard: Option<(u64, u64)>) -> RunOptions {
        RunOptions {
            out: out.to_path_buf(),
            columns,
            shard,
            resume: false,
            overwrite: false,
            chunk_size: 65536,
            solver: self.solver,
            compression: self.compression,
            writer: self.writer,
            precision: clearance_engine::Precision::Double,
            progress: Default::default(),
            direct_io: crate::buffered_io_not_asked(),
            search: true,
            poses: true,
        }
    }

    /// [`run_options`](Self::run_options) for `job`: a 6-UPS or custom job has one
    /// solver, its own (`--solver general` is for the 3-limb kinds).
    fn run_options_for(
        &self,
        job: &JobSpec,
        out: &std::path::Path,
        columns: ColumnSet,
        shard: Option<(u64, u64)>,
    ) -> RunOptions {
        let mut opts = self.run_options(out, columns, shard);
        if !job.mechanism.kind.has_general_solver() {
            opts.solver = SolverKind::Fast;
        }
        opts
    }
}

/// `clearance bench --suite`: every job of [`SUITE`] end to end through the
/// engine, as `clearance run` runs it, into a temporary directory removed
/// afterwards; each the fastest of `repeat` runs. Then the kernel on the 2-D grid.
pub fn suite(o: &SuiteOptions) -> Result<()> {
    let isa = Isa::best().name();
    let threads = rayon::current_num_threads();
    let dir = TempDir(std::env::temp_dir().join(format!("clearance-bench-suite-{}", std::process::id())));
    let mut measured = Vec::with_capacity(SUITE.len());
    for s in SUITE {
        let job = s.job(o.scale)?;
        let opts = o.run_options_for(&job, &dir.0, s.columns, None);
        let rows = job.sample_count() * job.variant_count() * job.analysis.modes.len() as u64;
        let mut rates = Vec::with_capacity(o.repeat);
        let (mut best, mut bytes, mut without_search) = (RunReport::default(), 0, f64::INFINITY);
        let (mut cpu, mut cpu_without_search) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..o.repeat.max(1) {
            let _ = std::fs::remove_dir_all(&dir.0);
            let start = Instant::now();
            let (report, used) = with_cpu(|| run(&job, s.file, &opts));
            let report = report?;
            cpu = cpu.min(used);
            let rate = rows as f64 / start.elapsed().as_secs_f64();
            if rate > rates.iter().copied().fold(0.0, f64::max) {
                best = report;
                bytes = dir_size(&dir.0.join("poses"));
            }
            rates.push(rate);
            // The same run without its search, alternated with the runs above: the wall
            // time the search adds, where its busy time overlaps the other stages.
            let _ = std::fs::remove_dir_all(&dir.0);
            let off = RunOptions { search: false, ..opts.clone() };
            let (report, used) = with_cpu(|| run(&job, s.file, &off));
            without_search = without_search.min(report?.seconds);
            cpu_without_search = cpu_without_search.min(used);
        }
        let _ = std::fs::remove_dir_all(&dir.0);
        measured.push(Measured {
            job: s,
            mechanism: job.mechanism.kind.name(),
            rows,
            variants: job.variant_count(),
            modes: job.analysis.modes.len(),
            rates,
            best,
            bytes_per_pose: bytes as f64 / rows.max(1) as f64,
            without_search,
            cpu,
            cpu_without_search,
        });
    }
    let sharded = sharded_run(o, &dir.0)?;
    let kernel_job = SUITE[0].job(o.scale)?;
    let kernel = (0..o.repeat.max(1)).map(|_| kernel_rate(&kernel_job, SolverKind::Fast)).fold(0.0, f64::max);
    if o.json {
        let records: Vec<String> = measured
            .iter()
            .map(|m| {
                let st = &m.best.stages;
                format!(
                    "{{\"job\": \"{}\", \"file\": \"{}\", \"mechanism\": \"{}\", \"columns\": \"{}\", \"poses\": {}, \"variants\": {}, \"modes\": {}, \"poses_per_s\": {:.1}, \"seconds\": {:.4}, \"share_pose_pass\": {:.4}, \"share_search\": {:.4}, \"share_search_added\": {:.4}, \"seconds_without_search\": {:.4}, \"share_search_cpu\": {:.4}, \"cpu_seconds\": {:.6}, \"cpu_seconds_without_search\": {:.6}, \"share_writing\": {:.4}, \"stages_timed\": {}, \"bytes_per_pose\": {:.1}, \"threads\": {threads}, \"isa\": \"{isa}\", \"writer\": \"{}\", \"runs\": {}}}",
                    m.job.name,
                    m.job.file,
                    m.mechanism,
                    m.job.columns.name(),
                    m.rows,
                    m.variants,
                    m.modes,
                    m.rate(),
                    m.best.seconds,
                    m.share(st.pose_pass),
                    m.share(st.search),
                    m.search_added(),
                    m.without_search,
                    m.search_cpu(),
                    m.cpu,
                    m.cpu_without_search,
                    m.share(st.writing),
                    m.stages_timed(),
                    m.bytes_per_pose,
                    o.writer.name(),
                    best(&m.rates).1,
                )
            })
            .collect();
        println!(
            "{{\"suite\": [{}], \"kernel\": {{\"job\": \"{}\", \"poses\": {}, \"poses_per_s\": {kernel:.1}, \"isa\": \"{isa}\"}}, \"clearance_sweep_cost\": {}, \"described_cost\": {{{}}}, \"sharded\": {}, \"threads\": {threads}, \"isa\": \"{isa}\", \"writer\": \"{}\", \"solver\": \"{}\", \"compression\": \"{}\", \"scale\": {}, \"repeat\": {}}}",
            records.join(", "),
            SUITE[0].name,
            kernel_job.sample_count(),
            clearance_sweep_cost(&measured).map_or("null".to_string(), |c| format!("{c:.3}")),
            described_cost(&measured).iter().map(|(k, c)| format!("\"{k}\": {c:.3}")).collect::<Vec<_>>().join(", "),
            sharded.json(),
            o.writer.name(),
            if o.solver == SolverKind::Fast { "fast" } else { "general" },
            o.compression.name(),
            o.scale,
            o.repeat,
        );
    } else {
        println!(
            "suite: {} jobs, threads {threads}, vector instructions {isa}, writer {}, compression {}, best of {}, scale {}",
            measured.len(),
            o.writer.name(),
            o.compression.name(),
            o.repeat,
            o.scale
        );
        println!(
            "{:<27} {:<6} {:<9} {:>9} {:>12} {:>10} {:>7} {:>12} {:>11} {:>8} {:>11}",
            "job",
            "kind",
            "columns",
            "poses",
            "poses/s",
            "pose pass",
            "search",
            "search adds",
            "search CPU",
            "writing",
            "bytes/pose"
        );
        for m in &measured {
            let st = &m.best.stages;
            let pct = |x: f64| if m.stages_timed() { format!("{:.0} %", 100.0 * x) } else { "-".into() };
            println!(
                "{:<27} {:<6} {:<9} {:>9} {:>12.0} {:>10} {:>7} {:>12} {:>11} {:>8} {:>11.1}",
                m.job.name,
                m.mechanism,
                m.job.columns.name(),
                m.rows,
                m.rate(),
                pct(m.share(st.pose_pass)),
                pct(m.share(st.search)),
                format!("{:.0} %", 100.0 * m.search_added()),
                format!("{:.0} %", 100.0 * m.search_cpu()),
                pct(m.share(st.writing)),
                m.bytes_per_pose
            );
        }
        println!("kernel ({}, {} poses, no I/O): {kernel:.0} poses/s", SUITE[0].name, kernel_job.sample_count());
        if let Some(cost) = clearance_sweep_cost(&measured) {
            println!("12 masses x clearances variants against their 4 mass variants alone: {cost:.2} x the wall time");
        }
        for (kind, cost) in described_cost(&measured) {
            println!(
                "the {kind} described as a custom mechanism against the built-in kind, same grid: {cost:.2} x the wall time"
            );
        }
        println!(
            "{} in {} shards, one after another: {:.2} s in all, {:.1} % of it ({:.3} s) in the step that finishes the run",
            sharded.job,
            sharded.shards,
            sharded.seconds,
            100.0 * sharded.finish_share(),
            sharded.finish
        );
        println!(
            "shares: each stage's busy time against the run's wall time; the stages overlap, so they may add up to more than 100 %"
        );
        println!(
            "search adds: one less the wall time of the job's fastest run without its search against its fastest with it, alternated"
        );
        println!(
            "search CPU: the same with the CPU seconds of the process (every thread), the least of each: the search's share of the work"
        );
        if measured.iter().any(|m| !m.stages_timed()) {
            println!("-: the run timed no stage");
        }
    }
    Ok(())
}

/// What `clearance bench --scaling` measures.
pub struct ScalingOptions {
    pub poses: u64,
    pub json: bool,
    pub solver: SolverKind,
    pub compression: Codec,
    pub writer: Writer,
    /// The end-to-end runs' column set, and whether they write pose files (`none`).
    pub columns: (ColumnSet, bool),
    pub repeat: usize,
    /// The thread counts (default 1, 2, 4 … and every core).
    pub threads: Vec<usize>,
    pub job: Option<JobSpec>,
}

/// `--columns`' name: `none` without pose files.
fn columns_name((set, poses): (ColumnSet, bool)) -> &'static str {
    if poses { set.name() } else { "none" }
}

/// 1, 2, 4 … below `cores`, and `cores`.
pub fn default_thread_counts(cores: usize) -> Vec<usize> {
    let mut out: Vec<usize> = std::iter::successors(Some(1usize), |t| Some(t * 2)).take_while(|&t| t < cores).collect();
    out.push(cores.max(1));
    out
}

/// One thread count's figures.
struct Scaled {
    threads: usize,
    kernel: f64,
    e2e: f64,
    /// CPU seconds over wall seconds of the fastest end-to-end run.
    busy: f64,
    stages: clearance_engine::StageTimes,
    seconds: f64,
}

impl Scaled {
    /// The pool's time in tasks (over its thread time) and its waits on the writers'
    /// queue (over the wall time), where the run counted them (the 3-limb path).
    fn pool(&self) -> Option<(f64, f64)> {
        let s = &self.stages;
        (s.pool_tasks > 0.0).then(|| (s.pool_tasks / self.seconds, s.queue_wait / self.seconds))
    }
}

/// The kernel and end-to-end rates at each thread count, side by side, on a pool of
/// that many threads each (the run's writer threads come on top), with where the
/// end-to-end run's time went.
pub fn scaling(o: &ScalingOptions) -> Result<()> {
    let job = match &o.job {
        None => bench_job(o.poses),
        Some(job) => {
            let mut first = job.variants("bench job")?.swap_remove(0).job;
            first.analysis.modes = vec![Mode::Kinetostatic];
            first
        }
    };
    let n = job.sample_count();
    let dir = std::env::temp_dir().join(format!("clearance-scaling-{}", std::process::id()));
    let opts = RunOptions {
        out: dir.clone(),
        columns: o.columns.0,
        shard: None,
        resume: false,
        overwrite: false,
        chunk_size: 65536,
        solver: o.solver,
        compression: o.compression,
        writer: o.writer,
        precision: clearance_engine::Precision::Double,
        progress: Default::default(),
        direct_io: crate::buffered_io_not_asked(),
        search: true,
        poses: o.columns.1,
    };
    kernel_rate(&bench_job(10_000), SolverKind::Fast); // warm up
    let mut rows = Vec::new();
    for &threads in &o.threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
        let row = pool.install(|| -> Result<Scaled> {
            // The kernel doing what the column set needs: the envelope and the dominant
            // joint but for the minimal set (a 6-UPS's pose pass computes them always).
            let envelope = o.columns.0 >= ColumnSet::Standard || !o.columns.1;
            // A 6-UPS's or custom job's kernel is its pose pass in memory ([`kernel_of`]):
            // the 3-limb kernel would pose the prototype's 3-PRS in its place (a custom
            // job's "kernel" read 9–15 M poses/s).
            let kernel = |job: &JobSpec| -> Result<f64> {
                if job.mechanism.kind.has_general_solver() {
                    Ok(clearance_engine::kernel_rate_with(job, o.solver, envelope))
                } else {
                    kernel_of(job, o.solver)
                }
            };
            let kernels: Vec<f64> = (0..o.repeat).map(|_| kernel(&job)).collect::<Result<_>>()?;
            let mut fastest: Option<(f64, f64, RunReport)> = None;
            for _ in 0..o.repeat {
                let _ = std::fs::remove_dir_all(&dir);
                let start = Instant::now();
                let (report, cpu) = with_cpu(|| run(&job, "bench.toml", &opts));
                let secs = start.elapsed().as_secs_f64();
                let _ = std::fs::remove_dir_all(&dir);
                let report = report?;
                if fastest.as_ref().is_none_or(|f| secs < f.0) {
                    fastest = Some((secs, cpu, report));
                }
            }
            let (secs, cpu, report) = fastest.expect("at least one run");
            Ok(Scaled {
                threads,
                kernel: best(&kernels).0,
                e2e: n as f64 / secs,
                busy: cpu / secs,
                stages: report.stages,
                seconds: secs,
            })
        })?;
        rows.push(row);
    }
    let one = rows.first().map_or(f64::NAN, |r| r.e2e);
    if o.json {
        let list: Vec<String> = rows
            .iter()
            .map(|r| {
                let share = |s: f64| s / r.seconds;
                format!(
                    "{{\"threads\": {}, \"kernel_poses_per_s\": {:.1}, \"end_to_end_poses_per_s\": {:.1}, \"end_to_end_over_kernel\": {:.4}, \"cpu_over_wall\": {:.3}, \"share_pose_pass\": {:.4}, \"share_search\": {:.4}, \"share_writing\": {:.4}, \"share_finish\": {:.4}, \"pool_in_tasks\": {}, \"share_queue_wait\": {}}}",
                    r.threads,
                    r.kernel,
                    r.e2e,
                    r.e2e / r.kernel,
                    r.busy,
                    share(r.stages.pose_pass),
                    share(r.stages.search),
                    share(r.stages.writing),
                    share(r.stages.finish),
                    r.pool().map_or("null".into(), |(t, _)| format!("{t:.4}")),
                    r.pool().map_or("null".into(), |(_, q)| format!("{q:.4}"))
                )
            })
            .collect();
        println!(
            "{{\"job\": \"{}\", \"poses\": {n}, \"columns\": \"{}\", \"compression\": \"{}\", \"writer\": \"{}\", \"isa\": \"{}\", \"repeat\": {}, \"scaling\": [{}]}}",
            job.name(),
            columns_name(o.columns),
            o.compression.name(),
            o.writer.name(),
            Isa::best().name(),
            o.repeat,
            list.join(", ")
        );
        return Ok(());
    }
    println!(
        "job: {} ({} poses), end to end with {} columns, {} pages, writer {}, vector instructions {}, best of {}",
        job.name(),
        n,
        columns_name(o.columns),
        o.compression.name(),
        o.writer.name(),
        Isa::best().name(),
        o.repeat
    );
    println!(
        "{:>7} {:>14} {:>14} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "threads",
        "kernel /s",
        "end to end /s",
        "e2e/kern",
        "speed-up",
        "cpu/wall",
        "pass %",
        "search %",
        "write %",
        "finish %",
        "tasks %",
        "queue %"
    );
    for r in &rows {
        let pct = |s: f64| 100.0 * s / r.seconds;
        println!(
            "{:>7} {:>14.0} {:>14.0} {:>9.2} {:>9.2} {:>8.2} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>8} {:>8}",
            r.threads,
            r.kernel,
            r.e2e,
            r.e2e / r.kernel,
            r.e2e / one,
            r.busy,
            pct(r.stages.pose_pass),
            pct(r.stages.search),
            pct(r.stages.writing),
            pct(r.stages.finish),
            r.pool().map_or("-".into(), |(t, _)| format!("{:.1}", 100.0 * t)),
            r.pool().map_or("-".into(), |(_, q)| format!("{:.1}", 100.0 * q))
        );
    }
    println!(
        "(the kernel does what the column set needs, the envelope and the dominant joint but for minimal, without I/O; \
         stage shares are busy time over the run's wall time, and overlap: the writer threads work beside the pool; \
         tasks % is the share of the pool's thread time in the run's tasks, queue % the time its threads waited on \
         the writers' full queue, both counted by the 3-limb path only)"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clearance_model::RangeSpec;

    /// Every file of `benches/suite/` is a valid job (so `clearance run` takes it)
    /// and in the suite, and the suite's texts are those files.
    #[test]
    fn the_suite_is_the_files_of_benches_suite() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut files: Vec<String> = std::fs::read_dir(root.join("benches/suite"))
            .unwrap()
            .map(|e| format!("benches/suite/{}", e.unwrap().file_name().to_string_lossy()))
            .collect();
        files.sort();
        let mut listed: Vec<String> = SUITE.iter().map(|s| s.file.to_string()).collect();
        listed.sort();
        listed.dedup();
        assert_eq!(files, listed);
        for s in SUITE {
            assert_eq!(std::fs::read_to_string(root.join(s.file)).unwrap(), s.text, "{}", s.file);
            let job = JobSpec::from_path(&root.join(s.file)).unwrap();
            job.variants(s.file).unwrap();
        }
    }

    /// The suite runs the jobs the issue names, at their sizes.
    #[test]
    fn the_suite_has_every_kind_of_job() {
        let job = |name: &str| SUITE.iter().find(|s| s.name == name).unwrap().job(1.0).unwrap();
        assert_eq!(job("grid_2d").sample_count(), 633 * 633);
        assert_eq!(job("grid_3d").sample_count(), 400_000);
        assert!(job("sweep_16").variant_count() >= 16);
        let t = job("trajectory_dynamic");
        assert!(t.trajectory.is_some() && t.analysis.modes.contains(&Mode::Dynamic));
        assert_eq!(job("prs_inclined").mechanism.rail_angle_deg(), 30.0);
        assert_eq!(job("rps_grid").mechanism.kind.name(), "3-RPS");
        let ups = job("ups_grid");
        assert_eq!(ups.mechanism.kind.name(), "6-UPS");
        assert!((100_000..=200_000).contains(&ups.sample_count()), "{}", ups.sample_count());
        let sets: Vec<ColumnSet> =
            SUITE.iter().filter(|s| s.file.ends_with("grid_2d.toml")).map(|s| s.columns).collect();
        assert_eq!(sets, [ColumnSet::Standard, ColumnSet::Minimal, ColumnSet::Full]);
    }

    /// `--scale` scales the samples, not the variants or modes, and keeps every
    /// range at two values or more.
    #[test]
    fn scaling_keeps_variants_modes_and_ranges() {
        for s in SUITE {
            let full = s.job(1.0).unwrap();
            for scale in [0.1, 0.01, 1e-9] {
                let job = s.job(scale).unwrap();
                assert_eq!((job.variant_count(), &job.analysis.modes), (full.variant_count(), &full.analysis.modes));
                let (n, want) = (job.sample_count() as f64, full.sample_count() as f64 * scale);
                if scale >= 0.01 {
                    assert!((n / want - 1.0).abs() < 0.25, "{}: {n} samples at {scale}, about {want} wanted", s.name);
                } else {
                    assert!(n >= 2.0, "{}", s.name);
                }
            }
        }
    }

    /// `clearance bench --job` on a 6-UPS job measures the 6-UPS pose pass (the
    /// 3-limb kernel cannot pose it: it panicked), for the general solver's figure too
    /// (the 6-UPS has one solver; asked for the general one, `solve` refuses).
    #[test]
    fn the_kernel_of_a_6ups_job_is_its_pose_pass() {
        for name in ["ups_grid", "custom_3rrs"] {
            let job = JobSpec::from_toml_str(SUITE.iter().find(|s| s.name == name).unwrap().text, "job.toml").unwrap();
            let small = scaled(job, 1e-3);
            assert!(small.sample_count() < 1000);
            for solver in [SolverKind::Fast, SolverKind::General] {
                let rate = kernel_of(&small, solver).unwrap();
                assert!(rate.is_finite() && rate > 0.0, "{name}: {rate}");
            }
        }
    }

    /// A grid over all six inputs (a 6-UPS grid) scales in each of them: `x`, `y`
    /// and `phi` count as ranges like `z`, `psi` and `theta`, so a quarter of the
    /// samples is a quarter, not the three 3-PRS ranges' share of it.
    #[test]
    fn scaling_a_six_input_grid_scales_every_range() {
        let text = r#"
            name = "six_inputs"
            [mechanism]
            kind = "6-UPS"
            [grid]
            x = { start = -0.1, stop = 0.1, n = 20 }
            y = { start = -0.1, stop = 0.1, n = 20 }
            z = { start = 0.6, stop = 0.8, n = 20 }
            phi = { start = -0.1, stop = 0.1, n = 20 }
            psi = { start = -0.1, stop = 0.1, n = 20 }
            theta = { start = -0.1, stop = 0.1, n = 20 }
        "#;
        let full = JobSpec::from_toml_str(text, "six_inputs.toml").unwrap();
        assert_eq!(full.sample_count(), 20u64.pow(6));
        for scale in [0.5, 0.1, 0.01] {
            let job = scaled(full.clone(), scale);
            let (n, want) = (job.sample_count() as f64, full.sample_count() as f64 * scale);
            assert!((n / want - 1.0).abs() < 0.25, "{n} samples at {scale}, about {want} wanted");
            let g = job.grid.as_ref().unwrap();
            for r in [g.x.as_ref().unwrap(), &g.z, g.phi.as_ref().unwrap()] {
                let RangeSpec::Range { n, .. } = r else { panic!("a range became a value") };
                assert!(*n < 20, "every range shrinks at {scale}: {n}");
            }
        }
        // x, y, z over a fixed orientation (the suite's ups_grid): only the three ranges scale.
        let xyz = r#"
            name = "xyz"
            [mechanism]
            kind = "6-UPS"
            [grid]
            x = { start = -0.1, stop = 0.1, n = 20 }
            y = { start = -0.1, stop = 0.1, n = 20 }
            z = { start = 0.6, stop = 0.8, n = 20 }
            phi = 0.05
            psi = 0.1
            theta = -0.1
        "#;
        let full = JobSpec::from_toml_str(xyz, "xyz.toml").unwrap();
        assert_eq!(full.sample_count(), 8000);
        let job = scaled(full, 0.25);
        let n = job.sample_count() as f64;
        assert!((n / 2000.0 - 1.0).abs() < 0.25, "{n} samples at 0.25, about 2000 wanted");
        let g = job.grid.as_ref().unwrap();
        let sizes: Vec<u64> = [g.x.as_ref().unwrap(), g.y.as_ref().unwrap(), &g.z].iter().map(|r| r.len()).collect();
        assert!(sizes.iter().all(|&n| (12..=13).contains(&n)), "x, y, z shrink alike: {sizes:?}");
    }
}
