//! `clearance allocate`: the cheapest clearances for an error budget, written as
//! `allocation.toml` and `allocation.json` (and, for several budgets, the trade-off
//! curve as `tradeoff.csv` and `tradeoff.png`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clearance_engine::{AllocateOptions, Allocation, Codec, ColumnSet, JobSpec, Reporter, RunOptions, Writer};

/// What the command line asked for.
pub struct Args {
    pub job: PathBuf,
    pub opts: AllocateOptions,
    pub budgets: Vec<f64>,
    pub out: Option<PathBuf>,
    pub json: bool,
    pub quiet: bool,
}

/// Writes `bytes` to `path` through a temporary sibling: a file appears whole or not at all.
fn write_file(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

fn magnitude_text(m: &clearance_model::custom::Magnitude) -> String {
    use clearance_model::custom::Magnitude;
    match m {
        Magnitude::All(v) => format!("{v:.4e}"),
        Magnitude::PerLimb(l) => format!("[{}]", l.iter().map(|v| format!("{v:.4e}")).collect::<Vec<_>>().join(", ")),
    }
}

/// The answer for a reader, on stdout.
fn summary(job: &str, a: &Allocation) -> String {
    let mut s = format!(
        "allocation for {job}: {} model, |Δp| ≤ {:.6} µm{} over {} poses ({} left out for their status), {} active-set \
         rounds, {} poses in the conic program\n",
        a.model.name(),
        a.max_dp * 1e6,
        a.max_dalpha.map(|r| format!(", |Δα| ≤ {:.6} µrad", r * 1e6)).unwrap_or_default(),
        a.poses,
        a.skipped,
        a.iterations,
        a.cones
    );
    if a.described {
        s.push_str(
            "per limb, for the job's description as a custom mechanism (`clearance describe`), whose [clearance] \
             takes one magnitude per limb:\n",
        );
    }
    for (k, m) in a.magnitudes() {
        let w = a.variables.iter().find(|v| v.kind == k).map_or(1.0, |v| v.weight);
        s.push_str(&format!("  {k:<20} {}   (weight {w})\n", magnitude_text(&m)));
    }
    for (k, m) in &a.fixed {
        let why = if a.idle.contains(k) { "kept: it moves the platform at no pose" } else { "kept" };
        s.push_str(&format!("  {k:<20} {}   ({why})\n", magnitude_text(m)));
    }
    s.push_str(&format!("cost Σ w/c = {:.6e}; one more µm of budget saves {:.6e}\n", a.cost, a.shadow_price_per_um));
    if let Some(p) = a.shadow_price_alpha_per_urad {
        s.push_str(&format!("one more µrad of the |Δα| budget saves {p:.6e}\n"));
    }
    s.push_str(&format!("largest |Δp| at these magnitudes (a fresh solve): {:.6} µm\n", a.largest_dp * 1e6));
    if let Some(r) = a.largest_dalpha {
        s.push_str(&format!("largest |Δα| at these magnitudes: {:.6} µrad\n", r * 1e6));
    }
    if let Some(b) = a.binding.first() {
        let at: Vec<String> =
            b.coords.iter().map(|(k, v)| format!("{k} = {}", clearance_engine::short_coordinate(*v))).collect();
        s.push_str(&format!(
            "{} binding poses; the costliest ({}): variant {} {} sample {} ({})\n",
            a.binding.len(),
            if b.budget == "dp" { "|Δp|" } else { "|Δα|" },
            b.variant,
            b.mode.name(),
            b.sample,
            at.join(", ")
        ));
    }
    s
}

pub fn allocate(args: &Args) -> anyhow::Result<()> {
    let file = args.job.display().to_string();
    let job = JobSpec::from_path(&args.job)?;
    let dir = args.out.clone().unwrap_or_else(|| PathBuf::from("."));
    let mut opts = args.opts.clone();
    if !args.quiet {
        opts.progress = Reporter::new(std::sync::Arc::new(crate::progress::Display::new(false)));
    }
    if args.budgets.is_empty() {
        let a = clearance_engine::allocate(&job, &file, &opts)?;
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let json = serde_json::to_string_pretty(&a.to_json()).expect("plain numbers");
        write_file(&dir.join("allocation.toml"), a.clearance_toml().as_bytes())?;
        write_file(&dir.join("allocation.json"), json.as_bytes())?;
        if args.json {
            println!("{json}");
        } else {
            print!("{}", summary(&file, &a));
        }
        if let Some(out) = &args.out {
            verify(&job, &file, &a, &out.join("verify"), args.quiet)?;
        }
        if !args.quiet {
            eprintln!("wrote allocation.toml and allocation.json in {}", dir.display());
        }
        return Ok(());
    }
    let answers = clearance_engine::allocate_budgets(&job, &file, &opts, &args.budgets)?;
    let mut csv = String::from("budget_um,cost,shadow_price_per_um,largest_dp_um");
    let kinds: Vec<String> = answers
        .iter()
        .find_map(|a| a.as_ref().ok())
        .map(|a| a.magnitudes().into_iter().map(|(k, _)| k).collect())
        .unwrap_or_default();
    for k in &kinds {
        csv.push_str(&format!(",{k}"));
    }
    csv.push_str(",note\n");
    let mut costs = Vec::new();
    let mut table = format!("{:>12} {:>14} {:>14}  magnitudes\n", "budget µm", "cost", "saves per µm");
    for (&b, a) in args.budgets.iter().zip(&answers) {
        match a {
            Ok(a) => {
                let mags: Vec<String> = a.magnitudes().iter().map(|(_, m)| magnitude_text(m)).collect();
                csv.push_str(&format!("{},{},{},{}", b * 1e6, a.cost, a.shadow_price_per_um, a.largest_dp * 1e6));
                for m in &mags {
                    csv.push_str(&format!(",\"{m}\""));
                }
                csv.push_str(",\n");
                table.push_str(&format!(
                    "{:>12.3} {:>14.6e} {:>14.6e}  {}\n",
                    b * 1e6,
                    a.cost,
                    a.shadow_price_per_um,
                    mags.join(" ")
                ));
                costs.push(Some(a.cost));
            }
            Err(e) => {
                csv.push_str(&format!("{},,,{}", b * 1e6, ",".repeat(kinds.len())));
                csv.push_str(&format!("\"{}\"\n", e.to_string().replace('"', "'")));
                table.push_str(&format!("{:>12.3}  {e}\n", b * 1e6));
                costs.push(None);
            }
        }
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    write_file(&dir.join("tradeoff.csv"), csv.as_bytes())?;
    let budgets_um: Vec<f64> = args.budgets.iter().map(|b| b * 1e6).collect();
    let title = format!("{}: least cost against the budget ({} model)", job.name(), opts.model.name());
    if costs.iter().any(Option::is_some) {
        clearance_plot::plot_tradeoff(&dir.join("tradeoff.png"), &title, &budgets_um, &costs)?;
    }
    print!("{table}");
    if !args.quiet {
        eprintln!("wrote tradeoff.csv and tradeoff.png in {}", dir.display());
    }
    Ok(())
}

/// A run of the job at the allocated magnitudes into `out`, and its check.
fn verify(job: &JobSpec, file: &str, a: &Allocation, out: &Path, quiet: bool) -> anyhow::Result<()> {
    // Per-limb magnitudes of a built-in kind are its description's.
    let mut job = if a.described { clearance_engine::describe(job, file)? } else { job.clone() };
    for (k, m) in &a.clearance {
        job.clearance.set(k, m.clone());
    }
    job.allocate = None;
    let opts = RunOptions {
        out: out.to_path_buf(),
        columns: ColumnSet::Standard,
        shard: None,
        resume: false,
        overwrite: true,
        chunk_size: 65536,
        solver: Default::default(),
        compression: Codec::default(),
        writer: Writer::default(),
        precision: clearance_engine::Precision::Double,
        progress: Reporter::default(),
        direct_io: false,
        search: true,
        poses: true,
    };
    clearance_engine::run(&job, file, &opts)?;
    if !quiet {
        eprintln!("verification run at the allocated magnitudes in {}", out.display());
    }
    Ok(())
}
