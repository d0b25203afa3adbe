//! What can go wrong in a run. Each variant's message names what failed; the
//! cause is its `source()`, never repeated in the message, so that a report of
//! the whole chain (`{:#}` of `anyhow`) says each thing once.

use std::path::PathBuf;

use clearance_model::JobError;
use clearance_parquet::ParquetError;

#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// The job file is not valid (the message names the file, the key and the reason).
    #[error(transparent)]
    Job(#[from] JobError),
    /// The output directory cannot take this run: nothing was written.
    #[error(transparent)]
    OutputDir(#[from] OutputDirError),
    /// The samples given in place of the job's do not fit it.
    #[error("{0}")]
    Samples(String),
    /// The file system refused.
    #[error("cannot {action} {}", path.display())]
    Io { action: &'static str, path: PathBuf, source: std::io::Error },
    /// A part's statistics file is missing: the run did not finish.
    #[error("missing {}: finish the run with --resume", path.display())]
    MissingStats { path: PathBuf, source: std::io::Error },
    /// A statistics file does not parse.
    #[error("corrupt {}", path.display())]
    Corrupt { path: PathBuf, source: serde_json::Error },
    /// A Parquet or side file could not be written or encoded.
    #[error(transparent)]
    Write(#[from] ParquetError),
    /// `allocate` was asked for what no magnitudes can give, or what the job cannot
    /// allocate (the message says which and why).
    #[error("{0}")]
    Allocation(String),
    /// An option that the job's mechanism cannot honour (the message says which and why).
    #[error("{0}")]
    Unsupported(String),
    /// The conic solver of `allocate` stopped without an answer.
    #[error("the conic solver stopped without an answer: {0}")]
    Solver(String),
}

/// Why an output directory cannot take a run. The messages name the command
/// line's flags (`--resume`, `--overwrite`, `--out`); another door words the
/// remedy in its own terms from the variant.
#[derive(Debug, thiserror::Error)]
pub enum OutputDirError {
    /// Not empty, and neither resume, overwrite nor a shard was asked for.
    #[error("{} is not empty; pass --resume to finish it, --overwrite to replace it, or choose another --out", dir.display())]
    NotEmpty { dir: PathBuf },
    /// Asked to resume (or to add a shard) where a run of another job is.
    #[error("{} holds a different job; use --overwrite to replace it, or another --out", dir.display())]
    OtherJob { dir: PathBuf },
    /// Asked to resume (or to add a shard) where files that are not a run are.
    #[error("{} holds files that are not a clearance run; use --overwrite to replace it, or another --out", dir.display())]
    NotARun { dir: PathBuf },
    /// Asked to resume (or to add a shard) with another `--columns` or `--precision`
    /// than the run's part files were written with: the parts would not share a schema.
    #[error("{} holds part files written with {option} {was}; resume it with the same (this run asks for {now}), or use --overwrite", dir.display())]
    OtherOptions { dir: PathBuf, option: &'static str, was: String, now: String },
    /// Asked to resume (or to add a shard) with another `--chunk-size` than the run's
    /// parts were cut with: a part of the same name would hold other samples.
    #[error("{} holds parts cut with another --chunk-size ({part} has {was} samples, {now} with --chunk-size {chunk}); resume it with the --chunk-size it was started with, or use --overwrite", dir.display())]
    OtherChunks { dir: PathBuf, part: String, was: u64, now: u64, chunk: u64 },
    /// Asked to overwrite files that are not a run (no `job.toml`): they stay.
    #[error("{} is not empty and holds no clearance run (no job.toml); refusing to overwrite it", dir.display())]
    NotARunToOverwrite { dir: PathBuf },
}

impl EngineError {
    /// Whether the error is the caller's (a bad job or output directory: exit code
    /// 2 in the binary) rather than the machine's.
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            EngineError::Job(_)
                | EngineError::OutputDir(_)
                | EngineError::Samples(_)
                | EngineError::Allocation(_)
                | EngineError::Unsupported(_)
        )
    }

    pub(crate) fn io(action: &'static str, path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| EngineError::Io { action, path, source }
    }
}
