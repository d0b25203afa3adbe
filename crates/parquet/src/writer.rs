//! Parquet files that appear under their final name only when complete.

use crate::output::Output;
use crate::pages;
use std::path::{Path, PathBuf};

use arrow::array::Float64Array;
use arrow::datatypes::{DataType, Schema};
use arrow::record_batch::RecordBatch;
use std::sync::Arc;

use parquet::arrow::arrow_writer::{
    ArrowColumnChunk, ArrowColumnWriter, ArrowLeafColumn, ArrowRowGroupWriterFactory, compute_leaves,
};
use parquet::arrow::{ArrowSchemaConverter, add_encoded_arrow_schema_to_metadata};

use parquet::basic::{Compression, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::ColumnPath;
use rayon::prelude::*;

/// A file that could not be written. The temporary file is removed.
///
/// The cause is the error's `source()`, not part of its message, so that a report
/// of the whole chain (`anyhow`'s `{:#}`) names it once.
#[derive(Debug, thiserror::Error)]
pub enum ParquetError {
    /// The file system refused: full disk, no permission...
    #[error("cannot write {path}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("cannot encode {path}")]
    Encode { path: PathBuf, source: parquet::errors::ParquetError },
}

impl ParquetError {
    /// The writer reports I/O failures as `External` parquet errors; they are
    /// `Io`, whatever layer met them.
    fn from_parquet(path: &Path, e: parquet::errors::ParquetError) -> Self {
        let path = path.to_path_buf();
        match e {
            parquet::errors::ParquetError::External(inner) => match inner.downcast::<std::io::Error>() {
                Ok(io) => ParquetError::Io { path, source: *io },
                Err(inner) => ParquetError::Encode { path, source: parquet::errors::ParquetError::External(inner) },
            },
            source => ParquetError::Encode { path, source },
        }
    }
}

/// Settings shared by every file of a run.
#[derive(Clone, Debug)]
pub struct WriteOptions {
    /// Key-value metadata for every file (job, engine version, variant...).
    pub metadata: Vec<(String, String)>,
    /// Rows per row group.
    pub row_group_rows: usize,
    pub codec: Codec,
    /// `fsync` before the rename. Part files leave it off, so that writing
    /// overlaps computing: a run syncs them all before it declares itself complete
    /// (`clearance run`).
    pub durable: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self { metadata: Vec::new(), row_group_rows: 128 * 1024, codec: Codec::default(), durable: true }
    }
}

/// Page compression, with byte-stream-split doubles. On the standard part files
/// of the bench job: none 536 bytes a pose, LZ4 376, zstd (level 1) 369. Zstd costs
/// about 0.25 µs of CPU a pose, an eighth of a run's (benches/README.md), and is
/// the default: sweeps are kept and moved, often over shared file systems, where a
/// third less data counts for more, and on this machine's disk `none` is no faster
/// end to end, since the disk then takes half as much again.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Codec {
    None,
    Lz4,
    #[default]
    Zstd,
}

/// The zstd level of [`Codec::Zstd`].
pub(crate) const ZSTD_LEVEL: i32 = 1;

impl Codec {
    pub const NAMES: [&str; 3] = ["none", "lz4", "zstd"];

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "none" => Some(Codec::None),
            "lz4" => Some(Codec::Lz4),
            "zstd" => Some(Codec::Zstd),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Codec::None => "none",
            Codec::Lz4 => "lz4",
            Codec::Zstd => "zstd",
        }
    }

    pub(crate) fn compression(self) -> Compression {
        match self {
            Codec::None => Compression::UNCOMPRESSED,
            Codec::Lz4 => Compression::LZ4_RAW,
            Codec::Zstd => Compression::ZSTD(ZstdLevel::try_new(ZSTD_LEVEL).expect("the level is valid")),
        }
    }
}

fn properties(schema: &Schema, opts: &WriteOptions, extra: &[(String, String)]) -> WriterProperties {
    let kv = opts.metadata.iter().chain(extra).map(|(k, v)| KeyValue::new(k.clone(), v.clone())).collect();
    // Floats rarely repeat, so dictionaries only cost time; the two string
    // columns repeat a handful of values and keep theirs.
    let mut builder = WriterProperties::builder();
    // Top-level doubles are encoded by `pages`, with `opts.codec`; the Arrow column
    // writers made for them (and left unused) then need no compression context
    // each, which cost megabytes of allocation a part.
    for f in schema.fields().iter().filter(|f| f.data_type() == &DataType::Float64) {
        builder = builder.set_column_compression(ColumnPath::from(f.name().as_str()), Compression::UNCOMPRESSED);
    }
    builder
        .set_compression(opts.codec.compression())
        .set_dictionary_enabled(false)
        // Row-group statistics only, and no page index: the double columns are
        // written by `pages`, which keeps none per page, and the others follow.
        .set_statistics_enabled(EnabledStatistics::Chunk)
        .set_offset_index_disabled(true)
        .set_column_dictionary_enabled(ColumnPath::from("mode"), true)
        .set_column_dictionary_enabled(ColumnPath::from("status"), true)
        .set_column_dictionary_enabled(ColumnPath::from("kind"), true)
        .set_max_row_group_row_count(Some(opts.row_group_rows))
        .set_key_value_metadata(Some(kv))
        .build()
}

/// A column of a row group, to encode.
enum Job<'a> {
    Arrow(Box<(ArrowColumnWriter, ArrowLeafColumn)>),
    Doubles(parquet::schema::types::ColumnDescPtr, &'a Float64Array),
}

/// A column of a row group, encoded.
enum Chunk {
    Arrow(ArrowColumnChunk),
    Doubles(bytes::Bytes, parquet::column::writer::ColumnCloseResult),
}

/// Asks the kernel to start writing the file's dirty pages now, without waiting.
fn start_writeback(file: &std::fs::File) {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: a valid descriptor; the call only schedules I/O on it.
        unsafe {
            libc::sync_file_range(file.as_raw_fd(), 0, 0, libc::SYNC_FILE_RANGE_WRITE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = file;
}

/// Writes `batches` to `path` via a temporary sibling and an atomic rename.
/// `extra` metadata is added to the run-wide metadata for this file only.
pub fn write_parquet(
    path: &Path,
    schema: arrow::datatypes::SchemaRef,
    batches: &[RecordBatch],
    opts: &WriteOptions,
    extra: &[(String, String)],
) -> Result<(), ParquetError> {
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{file_name}.tmp-{}", std::process::id()));
    let result = (|| {
        let io = |source| ParquetError::Io { path: path.to_path_buf(), source };
        let enc = |e| ParquetError::from_parquet(path, e);
        let file = Output::create(&tmp).map_err(io)?;
        let mut props = properties(&schema, opts, extra);
        // What `ArrowWriter` does, so that readers get the Arrow types and units back.
        add_encoded_arrow_schema_to_metadata(&schema, &mut props);
        let parquet_schema =
            ArrowSchemaConverter::new().with_coerce_types(props.coerce_types()).convert(&schema).map_err(enc)?;
        let props = Arc::new(props);
        let mut writer = SerializedFileWriter::new(file, parquet_schema.root_schema_ptr(), props).map_err(enc)?;
        let factory = ArrowRowGroupWriterFactory::new(&writer, schema.clone());
        let mut row_group = 0;
        for b in batches {
            let mut offset = 0;
            while offset < b.num_rows() {
                let slice = b.slice(offset, (b.num_rows() - offset).min(opts.row_group_rows.max(1)));
                offset += slice.num_rows();
                // Columns are encoded independently, on the rayon pool: the pool's
                // threads are all the threads a run uses. Double columns are
                // written by `pages`; the others by `parquet`'s Arrow writer.
                let mut jobs = Vec::with_capacity(slice.num_columns());
                let mut arrow_writers = factory.create_column_writers(row_group).map_err(enc)?.into_iter();
                // Parquet leaves, counted apart from fields: a nested field has several.
                let mut leaf = 0;
                for (field, array) in schema.fields().iter().zip(slice.columns()) {
                    if let Some(a) = array.as_any().downcast_ref::<Float64Array>() {
                        // A top-level double is one flat leaf.
                        jobs.push(Job::Doubles(writer.schema_descr().column(leaf), a));
                        arrow_writers.next();
                        leaf += 1;
                        continue;
                    }
                    for l in compute_leaves(field, array).map_err(enc)? {
                        let w = arrow_writers.next().ok_or_else(|| {
                            enc(parquet::errors::ParquetError::General("more leaves than columns".into()))
                        })?;
                        jobs.push(Job::Arrow(Box::new((w, l))));
                        leaf += 1;
                    }
                }
                let chunks: Vec<Chunk> = jobs
                    .into_par_iter()
                    .map(|job| match job {
                        Job::Arrow(job) => {
                            let (mut w, leaf) = *job;
                            w.write(&leaf).and_then(|_| w.close()).map(Chunk::Arrow)
                        }
                        Job::Doubles(descr, a) => {
                            pages::encode_doubles(descr, a, opts.codec).map(|(b, c)| Chunk::Doubles(b, c))
                        }
                    })
                    .collect::<Result<_, _>>()
                    .map_err(enc)?;
                let mut rg = writer.next_row_group().map_err(enc)?;
                for chunk in chunks {
                    match chunk {
                        Chunk::Arrow(c) => c.append_to_row_group(&mut rg),
                        Chunk::Doubles(bytes, close) => rg.append_column(&bytes, close),
                    }
                    .map_err(enc)?;
                }
                rg.close().map_err(enc)?;
                row_group += 1;
            }
        }
        // `finish` writes the footer and flushes the buffer with the I/O error
        // intact (`into_inner` would turn a full disk into a string).
        writer.finish().map_err(enc)?;
        let out = writer.inner_mut();
        out.finish().map_err(io)?;
        if opts.durable {
            out.file().sync_all().map_err(io)?;
        } else if !out.is_direct() {
            start_writeback(out.file());
        }
        drop(writer);
        std::fs::rename(&tmp, path).map_err(io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
