//! `clearance status DIR`: is a run complete?

use std::path::Path;
use std::process::ExitCode;

/// Exit 0 when `DIR/_SUCCESS` exists (written last, after every shard and the
/// summary); 1 otherwise, saying what is missing.
pub fn status(dir: &Path) -> ExitCode {
    if !dir.join("job.toml").exists() {
        eprintln!("{}: not a clearance run (no job.toml)", dir.display());
        return ExitCode::from(1);
    }
    if dir.join("_SUCCESS").exists() {
        println!("{}: complete", dir.display());
        return ExitCode::SUCCESS;
    }
    let mut shards: Option<u64> = None;
    let mut done = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if let Some(rest) = name.strip_prefix("_SUCCESS.shard-")
            && let Some((i, n)) = rest.split_once("-of-")
            && let (Ok(i), Ok(n)) = (i.parse::<u64>(), n.parse::<u64>())
        {
            shards = Some(n);
            done.push(i);
        }
    }
    match shards {
        Some(n) => {
            let missing: Vec<String> = (0..n).filter(|i| !done.contains(i)).map(|i| i.to_string()).collect();
            if missing.is_empty() {
                println!(
                    "{}: all {n} shards computed, but the summary and discontinuities were not written; \
                     finish with `clearance run JOB --out DIR --resume`",
                    dir.display()
                );
                ExitCode::from(1)
            } else {
                println!("{}: incomplete: shards {} of {n} not finished", dir.display(), missing.join(", "));
                ExitCode::from(1)
            }
        }
        None => {
            println!(
                "{}: incomplete (no _SUCCESS); finish it with `clearance run JOB --out DIR --resume`",
                dir.display()
            );
            ExitCode::from(1)
        }
    }
}
