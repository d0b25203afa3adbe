//! # clearance-parquet
//!
//! The output of a run as Arrow record batches and Parquet files
//! (docs/interface.md, "Output directory"):
//!
//! - [`PoseSchema`]: the `poses` columns of a column set (`minimal`, `standard`,
//!   `full`), each with its unit in the field metadata, and the rules that turn a
//!   [`PoseResult`](clearance_solver::PoseResult) into nulls where its status
//!   cannot fill a column (docs/conventions.md). No NaN is ever written: a value
//!   that is not finite is null.
//! - [`discontinuity_batch`] and [`summary_batch`]: `discontinuities.parquet` (one row
//!   per refined switch) and `summary.parquet` (one row per variant and mode, from
//!   mergeable [`SummaryStats`]).
//! - [`UpsSchema`], [`ups_summary_batch`], [`ups_discontinuity_batch`]: the same
//!   tables for the 6-UPS (six inputs, six limbs, its own clearance kinds).
//! - [`write_parquet`]: one file written under a temporary name and renamed when
//!   complete, with the job and engine version in the key-value metadata.
//! - Part files of `poses` by one of two [`Writer`]s: the engine's own page encoder
//!   ([`PageWriter`], [`write_part`]; pages encoded as their rows are computed), or
//!   `parquet`'s stock `ArrowWriter` from a record batch ([`write_batch_arrow`]).
//!   Both give the same table.
//! - [`Precision`]: `--precision single` stores the error, envelope and margin columns
//!   of the part files as `float32` ([`with_precision`]).
//!
//! ```
//! use clearance_parquet::{ColumnSet, PoseSchema};
//! let schema = PoseSchema::new(ColumnSet::Minimal, false);
//! assert!(schema.names().any(|n| n == "err_theta"));
//! assert!(!schema.names().any(|n| n == "q1"));
//! ```

mod custom;
mod output;
mod pages;
mod precision;
mod schema;
mod stock;
mod summary;
mod tables;
mod ups;
mod writer;

pub use custom::{
    CustomPages, CustomPart, CustomRow, CustomSchema, CustomStats, CustomSummaryRow, CustomSwitch,
    custom_discontinuity_batch, custom_summary_batch,
};
pub use output::Landing;
pub use pages::{PAGE_ROWS, TAIL_PAGE_ROWS, page_spans};
pub use precision::{Precision, stored_single, with_precision};
pub use schema::{BlockSink, ColumnSet, PageBuffer, PageWriter, PartPages, PoseSchema, UnitColumns};
pub use stock::{Writer, arrow_properties, write_batch_arrow};
pub use summary::{Series, SummaryRow, SummaryStats, summary_batch};
pub use tables::discontinuity_batch;
pub use ups::{
    SixSwitch, UPS_INPUTS, UPS_SWITCH_KINDS, UpsRow, UpsSchema, UpsStats, UpsSummaryRow, UpsSwitch,
    ups_discontinuity_batch, ups_summary_batch,
};
pub use writer::{
    Codec, ParquetError, WriteOptions, key_values, write_bytes, write_custom_part, write_parquet, write_part,
};

/// The engine version written into every file's metadata.
pub const ENGINE_VERSION: &str = env!("CARGO_PKG_VERSION");
