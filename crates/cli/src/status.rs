//! `clearance status DIR`: is a run complete?

use std::path::Path;
use std::process::ExitCode;

use clearance_engine::RunStatus;

/// Exit 0 when the run is complete (`_SUCCESS`, written last, after every shard and
/// the summary); 1 otherwise, saying what is missing.
pub fn status(dir: &Path) -> ExitCode {
    let d = dir.display();
    match clearance_engine::status(dir) {
        RunStatus::NotARun => {
            eprintln!("{d}: not a clearance run (no job.toml)");
            ExitCode::from(1)
        }
        RunStatus::Complete => {
            println!("{d}: complete");
            ExitCode::SUCCESS
        }
        RunStatus::Shards { shards: n, missing } if missing.is_empty() => {
            println!(
                "{d}: all {n} shards computed, but the summary and discontinuities were not written; \
                 finish with `clearance run JOB --out DIR --resume`"
            );
            ExitCode::from(1)
        }
        RunStatus::Shards { shards: n, missing } => {
            let missing: Vec<String> = missing.iter().map(|i| i.to_string()).collect();
            println!("{d}: incomplete: shards {} of {n} not finished", missing.join(", "));
            ExitCode::from(1)
        }
        RunStatus::Incomplete => {
            println!("{d}: incomplete (no _SUCCESS); finish it with `clearance run JOB --out DIR --resume`");
            ExitCode::from(1)
        }
    }
}
