//! `clearance bench`: solver and end-to-end throughput on this machine.

use std::time::Instant;

use anyhow::Result;
use clearance_engine::{Codec, ColumnSet, Isa, JobSpec, RunOptions, SolverKind, bench_job, kernel_rate, run};
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

/// The fastest of `rates` (the run least slowed by whatever else the machine
/// was doing), and all of them as a JSON list.
fn best(rates: &[f64]) -> (f64, String) {
    let list = rates.iter().map(|r| format!("{r:.1}")).collect::<Vec<_>>().join(", ");
    (rates.iter().copied().fold(0.0, f64::max), format!("[{list}]"))
}

/// Each measurement is made `repeat` times; the fastest is reported, and every
/// run is listed in the JSON (`*_runs`).
///
/// `job` replaces the prototype's grid: its first variant, as written, kinetostatic
/// (a robot of the family, say).
pub fn bench(
    poses: u64,
    json: bool,
    solver: SolverKind,
    compression: Codec,
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
    let kernels: Vec<f64> = (0..repeat).map(|_| kernel_rate(&job, SolverKind::Fast)).collect();
    let kernel_general = kernel_rate(&general_job, SolverKind::General);
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
        progress: Default::default(),
        direct_io: crate::buffered_io_not_asked(),
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
        println!("kernel (kinetostatic, 4 kinds, no I/O): {kernel:>12.0} poses/s");
        println!("kernel, general faer path:              {kernel_general:>12.0} poses/s");
        println!("end to end (grid -> Parquet, standard):  {e2e:>12.0} poses/s");
        println!("Parquet written ({}):                {bytes_per_pose:>12.1} bytes/pose", compression.name());
    }
    Ok(())
}
