//! `clearance check JOB`: validate and print the expanded plan.

use anyhow::Result;
use clearance_model::{JobSpec, MechanismKind, MechanismSpec, PROTOTYPE_LIMB_ANGLES_DEG, SamplesSpec};
use clearance_parquet::{ColumnSet, PoseSchema};

use crate::bench::kernel_rate;

pub fn check(job: &JobSpec, file: &str, timing: bool) -> Result<()> {
    let variants = job.variants(file)?;
    let n = job.sample_count();
    let modes: Vec<&str> = job.analysis.modes.iter().map(|m| m.name()).collect();
    println!("job {} ({file}): valid", job.name());
    println!("mechanism: {}", describe(&job.mechanism));
    match job.samples() {
        SamplesSpec::Grid(g) => {
            println!("samples: grid {} z × {} psi × {} theta = {n}", g.z.len(), g.psi.len(), g.theta.len())
        }
        SamplesSpec::Trajectory(t) => println!("samples: trajectory of {} times", t.time.len()),
    }
    println!("modes: {}", modes.join(", "));
    println!("variants: {}", variants.len());
    for v in variants.iter().take(20) {
        let params: Vec<String> = v.params.iter().map(|(p, x)| format!("{p} = {x}")).collect();
        println!("  variant={}: {}", v.index, if params.is_empty() { "as written".into() } else { params.join(", ") });
    }
    if variants.len() > 20 {
        println!("  ... {} more", variants.len() - 20);
    }
    let rows = n * variants.len() as u64 * modes.len() as u64;
    println!("rows: {rows}");
    for set in [ColumnSet::Minimal, ColumnSet::Standard, ColumnSet::Full] {
        let cols = PoseSchema::new(set, job.analysis.exact).names().count();
        // 8 bytes per value before compression (the default zstd makes it ~30 % less).
        let bytes = rows as f64 * cols as f64 * 8.0;
        println!("  --columns {:<8}: {cols:>3} columns, at most ~{}", set.name(), human_bytes(bytes));
    }
    if timing {
        let probe = crate::bench::bench_job(20_000);
        let rate = kernel_rate(&probe, clearance_solver::SolverKind::Fast);
        let dynamic = if modes.contains(&"dynamic") { " (dynamic poses cost somewhat more)" } else { "" };
        println!(
            "estimated compute time: {:.1} s at {:.0} poses/s measured now on {} threads{dynamic}",
            rows as f64 / rate,
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

/// One line on the robot: its kind and what sets its layout apart.
fn describe(m: &MechanismSpec) -> String {
    let mut out = m.kind.name().to_string();
    if m.kind == MechanismKind::Prs3 {
        out.push_str(&format!(", rails at {}° from vertical", m.rail_angle_deg()));
    }
    let (limbs, platform) = (m.limb_angles_deg(), m.platform_angles_deg());
    if limbs != PROTOTYPE_LIMB_ANGLES_DEG || platform != limbs {
        out.push_str(&format!(", limbs at {limbs:?}°, platform joints at {platform:?}° (parasitic motions by Newton)"));
    }
    if m.kind == MechanismKind::Rps3 {
        out.push_str(&format!(", leg stroke {} to {} m", m.min_length(), m.max_length()));
    }
    out
}
