//! `clearance check JOB`: validate and print the expanded plan.

use anyhow::Result;
use clearance_engine::{JobSpec, RunOptions, Samples, estimate, plan};

/// Validates `job` and prints its plan; with `timing`, the run options of the run to
/// estimate (its output directory the calibration runs' scratch).
pub fn check(job: &JobSpec, file: &str, timing: Option<&RunOptions>) -> Result<()> {
    let plan = plan(job, file)?;
    println!("job {} ({file}): valid", plan.name);
    println!("mechanism: {}", plan.mechanism);
    let n = plan.sample_count;
    match plan.samples {
        Samples::Grid { z, psi, theta } => println!("samples: grid {z} z × {psi} psi × {theta} theta = {n}"),
        Samples::Trajectory { times } => println!("samples: trajectory of {times} times"),
        Samples::Grid6 { x, y, z, phi, psi, theta } => {
            println!("samples: grid {x} x × {y} y × {z} z × {phi} phi × {psi} psi × {theta} theta = {n}")
        }
    }
    println!("modes: {}", plan.modes.join(", "));
    println!("variants: {}", plan.variants.len());
    for v in plan.variants.iter().take(20) {
        let params: Vec<String> = v.params.iter().map(|(p, x)| format!("{p} = {x}")).collect();
        println!("  variant={}: {}", v.index, if params.is_empty() { "as written".into() } else { params.join(", ") });
    }
    if plan.variants.len() > 20 {
        println!("  ... {} more", plan.variants.len() - 20);
    }
    println!("rows: {}", plan.rows);
    for c in &plan.columns {
        println!(
            "  --columns {:<8}: {:>3} columns, at most ~{} (~{} with --precision single)",
            c.set,
            c.columns,
            human_bytes(c.bytes as f64),
            human_bytes(c.bytes_single as f64)
        );
    }
    if let Some(opts) = timing {
        let est = estimate(job, file, opts, CALIBRATION_SECONDS)?;
        let (rows, secs) = est.runs.iter().fold((0, 0.0), |(r, t), c| (r + c.rows, t + c.seconds));
        let what = if est.runs.last().is_some_and(|c| c.rows >= est.rows) {
            "measured: the whole job ran".to_string()
        } else {
            format!("from {} calibration runs of this job's own poses, {rows} rows in {secs:.2} s", est.runs.len())
        };
        println!(
            "estimated wall time: {} ({what}; solve, switch search and writing, {} columns, {} threads)",
            human_seconds(est.seconds),
            opts.columns.name(),
            est.threads
        );
    }
    Ok(())
}

/// Seconds the calibration runs of `check` grow to (the last one's wall time).
const CALIBRATION_SECONDS: f64 = 0.5;

fn human_seconds(s: f64) -> String {
    match s {
        s if s < 10.0 => format!("{s:.3} s"),
        s if s < 120.0 => format!("{s:.1} s"),
        s if s < 7200.0 => format!("{:.1} min", s / 60.0),
        s => format!("{:.1} h", s / 3600.0),
    }
}

fn human_bytes(b: f64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b;
    let mut i = 0;
    while v >= 1024.0 && i + 1 < units.len() {
        v /= 1024.0;
        i += 1;
    }
    format!("{v:.1} {}", units[i])
}
