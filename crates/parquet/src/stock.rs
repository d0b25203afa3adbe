//! The stock writer: a part file of `poses` written by `parquet`'s own
//! [`ArrowWriter`] from a record batch, with the settings closest to the engine's
//! page encoder (`pages/`), all through [`WriterProperties`]:
//!
//! - doubles `BYTE_STREAM_SPLIT` (`PLAIN` without compression), compressed with the
//!   codec and level of the engine's double pages (zstd −1), no dictionary;
//! - `mode`, `status`, `dominant` dictionary-encoded, like the engine's labels;
//! - data pages of at most [`PAGE_ROWS`] rows, one row group per part;
//! - row-group statistics (min, max, null and NaN counts), no page index.
//!
//! It is there to be measured against the engine's encoder (`clearance run --writer
//! arrow`, `clearance bench --suite --writer arrow`) and as a reference a reader can
//! trust: both give the same table (tested value for value, nulls included).

use std::path::Path;

use arrow::datatypes::{DataType, Schema};
use arrow::record_batch::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::basic::Encoding;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::schema::types::ColumnPath;

use crate::pages::PAGE_ROWS;
use crate::writer::{Codec, ParquetError, WriteOptions, atomically};

/// Which encoder writes the `poses` part files of a run (`--writer`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Writer {
    /// The engine's own page encoder: each page encoded by the thread that computed
    /// its rows, as soon as they are in ([`PageWriter`](crate::PageWriter)).
    #[default]
    Engine,
    /// `parquet`'s [`ArrowWriter`] on the writer thread, from a record batch of the
    /// whole part ([`write_batch_arrow`]).
    Arrow,
}

impl Writer {
    /// The names `--writer` takes; `fast` is another name of `engine`.
    pub const NAMES: [&str; 2] = ["engine", "arrow"];

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "engine" | "fast" => Some(Writer::Engine),
            "arrow" => Some(Writer::Arrow),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Writer::Engine => "engine",
            Writer::Arrow => "arrow",
        }
    }
}

/// The properties of [`write_batch_arrow`] for a file of `schema`.
pub fn arrow_properties(schema: &Schema, opts: &WriteOptions, extra: &[(String, String)]) -> WriterProperties {
    let kv = opts.metadata.iter().chain(extra).map(|(k, v)| KeyValue::new(k.clone(), v.clone())).collect();
    let double_encoding = if opts.codec == Codec::None { Encoding::PLAIN } else { Encoding::BYTE_STREAM_SPLIT };
    let mut builder = WriterProperties::builder()
        .set_compression(opts.codec.compression())
        .set_dictionary_enabled(false)
        .set_statistics_enabled(EnabledStatistics::Chunk)
        .set_offset_index_disabled(true)
        .set_data_page_row_count_limit(PAGE_ROWS)
        .set_max_row_group_row_count(Some(opts.row_group_rows.max(1)))
        .set_key_value_metadata(Some(kv));
    for f in schema.fields() {
        let path = ColumnPath::from(f.name().as_str());
        builder = match f.data_type() {
            DataType::Float64 => builder
                .set_column_encoding(path.clone(), double_encoding)
                .set_column_compression(path, opts.codec.page_compression()),
            DataType::Utf8 => builder.set_column_dictionary_enabled(path, true),
            _ => builder,
        };
    }
    builder.build()
}

/// Writes `batch` to `path` with [`ArrowWriter`] and [`arrow_properties`], via a
/// temporary sibling and an atomic rename, as [`write_part`](crate::write_part) does.
pub fn write_batch_arrow(
    path: &Path,
    batch: &RecordBatch,
    opts: &WriteOptions,
    extra: &[(String, String)],
) -> Result<(), ParquetError> {
    atomically(path, opts, |tmp| {
        let io = |source| ParquetError::Io { path: path.to_path_buf(), source };
        let enc = |e| ParquetError::from_parquet(path, e);
        let file = opts.output(tmp).map_err(io)?;
        let schema = batch.schema();
        let props = arrow_properties(&schema, opts, extra);
        let mut writer = ArrowWriter::try_new(file, schema, Some(props)).map_err(enc)?;
        writer.write(batch).map_err(enc)?;
        // `finish`, not `into_inner`: the footer is written and the I/O error kept.
        writer.finish().map_err(enc)?;
        Ok(writer.inner_mut().take())
    })
}
