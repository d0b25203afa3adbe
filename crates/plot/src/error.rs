//! What can go wrong while plotting a run. Every variant names the file.

use std::path::PathBuf;

/// A run directory that cannot be plotted, or a figure that cannot be written. The
/// cause is the `source()`, not part of the message, so that `{:#}` names it once.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The directory is not a complete `clearance run` output.
    #[error("{dir} is not a finished clearance run: {why}")]
    NotARun { dir: PathBuf, why: String },
    /// `job.toml` does not parse or validate.
    #[error(transparent)]
    Job(#[from] clearance_model::JobError),
    #[error("cannot access {path}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("cannot read {path}")]
    Parquet { path: PathBuf, source: parquet::errors::ParquetError },
    #[error("cannot read {path}")]
    Arrow { path: PathBuf, source: arrow::error::ArrowError },
    /// A column is missing or holds something that does not fit the job.
    #[error("{path}: column `{column}`: {why}")]
    Column { path: PathBuf, column: String, why: String },
    /// plotters or the PNG encoder failed.
    #[error("cannot draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
    /// The run holds nothing a figure can show: a 6-UPS grid with fewer than two
    /// swept inputs (its maps need two).
    #[error("{dir}: {why}")]
    Unsupported { dir: PathBuf, why: String },
    /// The embedded font (data/fonts/DejaVuSans.ttf) is not a usable TrueType file.
    #[error("the embedded font cannot be loaded")]
    Font,
}

impl PlotError {
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> PlotError {
        let path = path.into();
        move |source| PlotError::Io { path, source }
    }

    pub(crate) fn draw<E: std::fmt::Display>(path: impl Into<PathBuf>) -> impl FnOnce(E) -> PlotError {
        let path = path.into();
        move |e| PlotError::Draw { path, message: e.to_string() }
    }
}
