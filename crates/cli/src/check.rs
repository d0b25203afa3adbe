//! `clearance check JOB`: validate and print the expanded plan.

use anyhow::Result;
use clearance_engine::{JobSpec, Samples, SolverKind, bench_job, kernel_rate, plan, ups_kernel_rate};

pub fn check(job: &JobSpec, file: &str, timing: bool) -> Result<()> {
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
        println!("  --columns {:<8}: {:>3} columns, at most ~{}", c.set, c.columns, human_bytes(c.bytes as f64));
    }
    if timing {
        let rate = if job.mechanism.kind == clearance_engine::MechanismKind::Ups6 {
            ups_kernel_rate(2_000)
        } else {
            kernel_rate(&bench_job(20_000), SolverKind::Fast)
        };
        let dynamic = if plan.modes.contains(&"dynamic") { " (dynamic poses cost somewhat more)" } else { "" };
        println!(
            "estimated compute time: {:.1} s at {:.0} poses/s measured now on {} threads{dynamic}",
            plan.rows as f64 / rate,
            rate,
            rayon::current_num_threads()
        );
    }
    Ok(())
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
