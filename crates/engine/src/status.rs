//! Is a run directory complete? (`clearance status`)

use std::path::Path;

use crate::layout::Layout;

/// Where a run directory stands.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunStatus {
    /// No `job.toml`: not a clearance run.
    NotARun,
    /// `_SUCCESS` is there: every part, the summary and the discontinuities.
    Complete,
    /// A sharded run of `shards` shards; `missing` lists those not finished. When
    /// none is missing, the summary and discontinuities are still to be written.
    Shards { shards: u64, missing: Vec<u64> },
    /// An unsharded run that did not finish.
    Incomplete,
}

/// The state of the run in `dir`, from its markers ([`Layout`]).
pub fn status(dir: &Path) -> RunStatus {
    let layout = Layout::new(dir);
    if !layout.job().exists() {
        return RunStatus::NotARun;
    }
    if layout.success().exists() {
        return RunStatus::Complete;
    }
    let mut shards: Option<u64> = None;
    let mut done = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        if let Some((i, n)) = Layout::parse_shard_marker(&e.file_name().to_string_lossy()) {
            shards = Some(n);
            done.push(i);
        }
    }
    match shards {
        Some(n) => RunStatus::Shards { shards: n, missing: (0..n).filter(|i| !done.contains(i)).collect() },
        None => RunStatus::Incomplete,
    }
}
