//! Parquet files that appear under their final name only when complete.

use crate::output::{Landing, Output};
use crate::pages::{self, DoubleChunk};
use std::path::{Path, PathBuf};

use crate::custom::CustomPages;
use crate::schema::{PartPages, PoseSchema};
use arrow::array::{ArrayRef, Float64Array, UInt64Array};
use arrow::datatypes::{DataType, Schema};
use arrow::record_batch::RecordBatch;
use bytes::Bytes;
use clearance_model::Mode;
use clearance_solver::Status;
use std::sync::Arc;

use parquet::arrow::arrow_writer::{
    ArrowColumnChunk, ArrowColumnWriter, ArrowLeafColumn, ArrowRowGroupWriterFactory, compute_leaves,
};
use parquet::arrow::{ArrowSchemaConverter, add_encoded_arrow_schema_to_metadata};

use parquet::basic::{Compression, ZstdLevel};
use parquet::column::writer::ColumnCloseResult;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{EnabledStatistics, WriterProperties};
use parquet::file::writer::{SerializedFileWriter, SerializedRowGroupWriter};
use parquet::schema::types::{ColumnDescPtr, ColumnPath};
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
    pub(crate) fn from_parquet(path: &Path, e: parquet::errors::ParquetError) -> Self {
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
    /// Write past the page cache (`O_DIRECT`) on local disks: the copy into the
    /// cache costs a run's CPU (benches/README.md). The binary turns it off when
    /// `CLEARANCE_BUFFERED_IO` is set.
    pub direct_io: bool,
    /// Where files that are not `durable` are written in the background: a direct
    /// file's writes, its tail and its rename on a thread of its own, so that the
    /// caller does not wait on the disk. The run waits with [`Landing::wait`] before it
    /// syncs or reads them. `None`: every file is in place when its call returns.
    pub landing: Option<Arc<Landing>>,
}

impl Default for WriteOptions {
    fn default() -> Self {
        Self {
            metadata: Vec::new(),
            row_group_rows: 128 * 1024,
            codec: Codec::default(),
            durable: true,
            direct_io: true,
            landing: None,
        }
    }
}

/// Page compression, with byte-stream-split doubles. On the standard part files
/// of the bench job: none 536 bytes a pose, LZ4 395, zstd 380–386. Zstd is the
/// default: sweeps are kept and moved, often over shared file systems, where a
/// third less data counts for more, and end to end `none` and LZ4 are only about
/// 5 % faster on this machine (benches/README.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Codec {
    None,
    Lz4,
    #[default]
    Zstd,
}

/// The zstd level of [`Codec::Zstd`] for the columns `parquet` writes (strings and
/// integers; the level is not recorded in the file).
const ZSTD_LEVEL: i32 = 1;

/// The zstd level of the double columns' pages ([`pages`]): zstd's first "fast"
/// level. On byte-stream-split pages of 4 096 engine rows it compresses as well
/// as level 1 (380.6 against 381.0 bytes a pose) in 64 % of the time, as fast as
/// LZ4, which gives 385.6 (`python3` with `zstandard`, benches/README.md).
pub(crate) const PAGE_ZSTD_LEVEL: i32 = -1;

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

    /// The compression of the double columns' pages ([`PAGE_ZSTD_LEVEL`] for zstd),
    /// for a writer that takes it as a `parquet` setting.
    pub(crate) fn page_compression(self) -> Compression {
        match self {
            Codec::Zstd => Compression::ZSTD(ZstdLevel::try_new(PAGE_ZSTD_LEVEL).expect("the level is valid")),
            other => other.compression(),
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
        .set_column_dictionary_enabled(ColumnPath::from("dominant"), true)
        .set_column_dictionary_enabled(ColumnPath::from("kind"), true)
        .set_max_row_group_row_count(Some(opts.row_group_rows))
        .set_key_value_metadata(Some(kv))
        .build()
}

/// A top-level column of a row group, to write.
pub(crate) enum Column<'a> {
    Array(&'a ArrayRef),
    /// A double column whose pages are encoded already.
    Doubles(DoubleChunk<'a>),
    /// A required string column of few distinct values: row `i` holds
    /// `dict[index[i]]` ([`pages::label_chunk`]).
    Labels(&'a [&'a str], Vec<u8>),
}

/// A column of a row group, to encode.
enum Job<'a> {
    Arrow(Box<(ArrowColumnWriter, ArrowLeafColumn)>),
    Array(ColumnDescPtr, &'a Float64Array),
    Doubles(ColumnDescPtr, DoubleChunk<'a>),
    Labels(ColumnDescPtr, &'a [&'a str], Vec<u8>),
}

/// A column of a row group, encoded.
enum Chunk<'a> {
    Arrow(Box<ArrowColumnChunk>),
    /// The pages of a double column, and each page's statistics.
    Pages(ColumnDescPtr, Vec<u8>, Vec<pages::PageStats>),
    Doubles(ColumnDescPtr, DoubleChunk<'a>),
    /// A whole chunk's bytes, with offsets from 0.
    Encoded(Box<(Bytes, ColumnCloseResult)>),
}

impl<'a> Job<'a> {
    fn encode(self, codec: Codec) -> Result<Chunk<'a>, parquet::errors::ParquetError> {
        match self {
            Job::Arrow(job) => {
                let (mut w, leaf) = *job;
                w.write(&leaf).and_then(|_| w.close()).map(|c| Chunk::Arrow(Box::new(c)))
            }
            Job::Array(descr, a) => pages::encode_doubles(&descr, a, codec).map(|(b, p)| Chunk::Pages(descr, b, p)),
            Job::Doubles(descr, chunk) => Ok(Chunk::Doubles(descr, chunk)),
            Job::Labels(descr, dict, index) => pages::label_chunk(descr, dict, &index)
                .map(|(bytes, close)| Chunk::Encoded(Box::new((bytes.into(), close)))),
        }
    }
}

/// Appends one row group of `columns` (the top-level fields of `schema`, in order).
/// Columns are encoded on the rayon pool when `parallel`, else on this thread.
fn append_row_group<W: std::io::Write + Send>(
    writer: &mut SerializedFileWriter<W>,
    factory: &ArrowRowGroupWriterFactory,
    row_group: usize,
    schema: &Schema,
    columns: Vec<Column<'_>>,
    codec: Codec,
    parallel: bool,
) -> Result<(), parquet::errors::ParquetError> {
    let mut jobs = Vec::with_capacity(columns.len());
    let mut arrow_writers = factory.create_column_writers(row_group)?.into_iter();
    // Parquet leaves, counted apart from fields: a nested field has several.
    let mut leaf = 0;
    for (field, column) in schema.fields().iter().zip(columns) {
        let array = match column {
            Column::Doubles(chunk) => {
                jobs.push(Job::Doubles(writer.schema_descr().column(leaf), chunk));
                arrow_writers.next();
                leaf += 1;
                continue;
            }
            Column::Labels(dict, index) => {
                jobs.push(Job::Labels(writer.schema_descr().column(leaf), dict, index));
                arrow_writers.next();
                leaf += 1;
                continue;
            }
            Column::Array(a) => a,
        };
        if let Some(a) = array.as_any().downcast_ref::<Float64Array>() {
            // A top-level double is one flat leaf.
            jobs.push(Job::Array(writer.schema_descr().column(leaf), a));
            arrow_writers.next();
            leaf += 1;
            continue;
        }
        for l in compute_leaves(field, array)? {
            let w = arrow_writers
                .next()
                .ok_or_else(|| parquet::errors::ParquetError::General("more leaves than columns".into()))?;
            jobs.push(Job::Arrow(Box::new((w, l))));
            leaf += 1;
        }
    }
    let chunks: Vec<Chunk> = if parallel {
        jobs.into_par_iter().map(|job| job.encode(codec)).collect::<Result<_, _>>()?
    } else {
        jobs.into_iter().map(|job| job.encode(codec)).collect::<Result<_, _>>()?
    };
    let mut rg = writer.next_row_group()?;
    let append_doubles = |rg: &mut SerializedRowGroupWriter<'_, W>, descr, chunk: DoubleChunk<'_>| {
        let (segments, close) = chunk.close(descr, codec)?;
        rg.append_column(&segments, close)
    };
    for chunk in chunks {
        match chunk {
            Chunk::Arrow(c) => c.append_to_row_group(&mut rg)?,
            Chunk::Pages(descr, bytes, stats) => {
                let mut chunk = DoubleChunk::default();
                chunk.push(&bytes, &stats);
                append_doubles(&mut rg, descr, chunk)?
            }
            Chunk::Doubles(descr, chunk) => append_doubles(&mut rg, descr, chunk)?,
            Chunk::Encoded(chunk) => {
                let (bytes, close) = *chunk;
                rg.append_column(&bytes, close)?
            }
        }
    }
    rg.close()?;
    Ok(())
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
    write_file(path, &schema, opts, extra, |writer, factory| {
        let mut row_group = 0;
        for b in batches {
            let mut offset = 0;
            while offset < b.num_rows() {
                let slice = b.slice(offset, (b.num_rows() - offset).min(opts.row_group_rows.max(1)));
                offset += slice.num_rows();
                // Columns are encoded independently, on the rayon pool: the pool's
                // threads are all the threads a run uses.
                let columns = slice.columns().iter().map(Column::Array).collect();
                append_row_group(writer, factory, row_group, &schema, columns, opts.codec, true)?;
                row_group += 1;
            }
        }
        Ok(())
    })
}

/// Writes a part file of `poses` whose pages are all encoded ([`PartPages`]),
/// as one row group, via a temporary sibling and an atomic rename, as
/// [`write_parquet`] does. Only the string and sample columns are encoded here,
/// on this thread.
pub fn write_part(
    path: &Path,
    schema: &PoseSchema,
    part: &PartPages,
    opts: &WriteOptions,
    extra: &[(String, String)],
) -> Result<(), ParquetError> {
    let enc = |msg: String| encode_error(path, msg);
    let PartPages { mode, sample, status, dominant, pages } = part;
    let doubles = schema.doubles();
    let mut chunks: Vec<DoubleChunk> = (0..doubles).map(|_| DoubleChunk::default()).collect();
    for (k, page) in pages.iter().enumerate() {
        let page = page.as_ref().ok_or_else(|| enc(format!("page {k} of the part was never computed")))?;
        if page.stats.len() != doubles {
            return Err(enc(format!("page {k} has {} double columns, the schema {doubles}", page.stats.len())));
        }
        let mut at = 0;
        for (chunk, stats) in chunks.iter_mut().zip(&page.stats) {
            chunk.push(&page.bytes[at..at + stats.bytes], std::slice::from_ref(stats));
            at += stats.bytes;
        }
    }
    let dominant = schema.has_dominant().then(|| crate::schema::dominant_column(dominant));
    let labels = Labels { mode: *mode, sample, status, dominant };
    write_encoded(path, &schema.schema(), labels, chunks, opts, extra)
}

/// The columns of a part file besides its doubles: `mode`, `sample`, `status` and,
/// where the schema has it, `dominant`.
struct Labels<'a> {
    mode: Mode,
    sample: &'a [u64],
    status: &'a [Status],
    dominant: Option<ArrayRef>,
}

/// Writes a part file whose double columns are encoded (`chunks`: `t`, then the
/// float columns, in schema order) as one row group, with its `labels`, via a
/// temporary sibling and an atomic rename. The string and sample columns are
/// encoded here, on this thread.
fn write_encoded(
    path: &Path,
    arrow_schema: &arrow::datatypes::SchemaRef,
    labels: Labels<'_>,
    chunks: Vec<DoubleChunk<'_>>,
    opts: &WriteOptions,
    extra: &[(String, String)],
) -> Result<(), ParquetError> {
    let Labels { mode, sample, status, dominant } = labels;
    let rows = sample.len();
    let sample: ArrayRef = Arc::new(UInt64Array::from(sample.to_vec()));
    let modes = [mode.name()];
    let statuses = Status::ALL.map(|s| s.name());
    let status_index = status.iter().map(|s| s.index() as u8).collect();
    // In schema order (`label_columns`): mode, sample, t, status, dominant (standard
    // and full sets), then the floats.
    let mut chunks = chunks.into_iter();
    let t = chunks.next().ok_or_else(|| encode_error(path, "no t column".into()))?;
    let mut columns = vec![
        Column::Labels(&modes, vec![0; rows]),
        Column::Array(&sample),
        Column::Doubles(t),
        Column::Labels(&statuses, status_index),
    ];
    if let Some(dominant) = &dominant {
        columns.push(Column::Array(dominant));
    }
    columns.extend(chunks.map(Column::Doubles));
    let opts = WriteOptions { row_group_rows: rows.max(1), ..opts.clone() };
    write_file(path, arrow_schema, &opts, extra, |writer, factory| {
        append_row_group(writer, factory, 0, arrow_schema, columns, opts.codec, false)
    })
}

/// A part file that cannot be encoded as it stands: `msg` says why.
fn encode_error(path: &Path, msg: String) -> ParquetError {
    ParquetError::Encode { path: path.to_path_buf(), source: parquet::errors::ParquetError::General(msg) }
}

/// Writes a custom run's part file whose pages are all encoded ([`CustomPages`]), as
/// [`write_part`] writes a 3-limb run's.
pub fn write_custom_part(
    path: &Path,
    part: &CustomPages,
    opts: &WriteOptions,
    extra: &[(String, String)],
) -> Result<(), ParquetError> {
    let enc = |msg: String| encode_error(path, msg);
    if let Some(e) = &part.failed {
        return Err(enc(format!("encoding the part's pages: {e}")));
    }
    if part.codec != opts.codec {
        return Err(enc(format!("pages encoded with {}, the file is {}", part.codec.name(), opts.codec.name())));
    }
    if part.sample.len() != part.len || part.staged > 0 {
        return Err(enc(format!("{} of the part's {} rows encoded", part.sample.len() - part.staged, part.len)));
    }
    let doubles = part.doubles();
    let mut chunks: Vec<DoubleChunk> = (0..doubles).map(|_| DoubleChunk::default()).collect();
    for page in &part.pages {
        for (chunk, (bytes, stats)) in chunks.iter_mut().zip(page) {
            chunk.push(bytes, std::slice::from_ref(stats));
        }
    }
    let labels =
        Labels { mode: part.mode, sample: &part.sample, status: &part.status, dominant: part.dominant_column() };
    write_encoded(path, &part.schema, labels, chunks, opts, extra)
}

/// The key-value metadata in the footer of the Parquet file at `path` (`None` where
/// it cannot be read as one), keys without a value left out.
pub fn key_values(path: &Path) -> Option<Vec<(String, String)>> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(std::fs::File::open(path).ok()?).ok()?;
    let kv = reader.metadata().file_metadata().key_value_metadata().cloned().unwrap_or_default();
    Some(kv.into_iter().filter_map(|k| Some((k.key, k.value?))).collect())
}

/// Writes `bytes` to `path` via a temporary sibling and an atomic rename, past the
/// page cache where the file system allows it (as Parquet files are), and, when
/// `opts.durable`, on the disk before this returns (with `opts.landing` and not
/// durable, a file of a megabyte or more is put in place in the background). For a
/// run's side files (statistics, traces): through the page cache, their copy cost a
/// run 2 % of its CPU (`perf`).
pub fn write_bytes(path: &Path, bytes: &[u8], opts: &WriteOptions) -> Result<(), ParquetError> {
    atomically(path, opts, |tmp| {
        let io = |source| ParquetError::Io { path: path.to_path_buf(), source };
        let mut out = opts.output(tmp).map_err(io)?;
        std::io::Write::write_all(&mut out, bytes).map_err(io)?;
        Ok(out)
    })
}

impl WriteOptions {
    /// The file to write at `tmp`: direct where these options and the file system
    /// allow it, in the background with the landing where the file is not durable.
    pub(crate) fn output(&self, tmp: &Path) -> std::io::Result<Output> {
        let landing = self.landing.as_ref().filter(|_| !self.durable);
        Ok(Output::create(tmp, self.direct_io)?.in_background(landing))
    }
}

/// Runs `write` on the temporary sibling of `path`, then completes the file it
/// returns and renames it to `path` ([`Output::complete`]; in the background where
/// `opts` say so); removes it on any failure seen here.
pub(crate) fn atomically(
    path: &Path,
    opts: &WriteOptions,
    write: impl FnOnce(&Path) -> Result<Output, ParquetError>,
) -> Result<(), ParquetError> {
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{file_name}.tmp-{}", std::process::id()));
    let result = write(&tmp).and_then(|out| {
        out.complete(path, opts.durable).map_err(|source| ParquetError::Io { path: path.to_path_buf(), source })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Creates the temporary sibling of `path`, lets `body` write its row groups, then
/// writes the footer and renames the file into place; removes it on any failure.
fn write_file(
    path: &Path,
    schema: &arrow::datatypes::SchemaRef,
    opts: &WriteOptions,
    extra: &[(String, String)],
    body: impl FnOnce(
        &mut SerializedFileWriter<Output>,
        &ArrowRowGroupWriterFactory,
    ) -> Result<(), parquet::errors::ParquetError>,
) -> Result<(), ParquetError> {
    atomically(path, opts, |tmp| {
        let io = |source| ParquetError::Io { path: path.to_path_buf(), source };
        let enc = |e| ParquetError::from_parquet(path, e);
        let file = opts.output(tmp).map_err(io)?;
        let mut props = properties(schema, opts, extra);
        // What `ArrowWriter` does, so that readers get the Arrow types and units back.
        add_encoded_arrow_schema_to_metadata(schema, &mut props);
        let parquet_schema =
            ArrowSchemaConverter::new().with_coerce_types(props.coerce_types()).convert(schema).map_err(enc)?;
        let props = Arc::new(props);
        let mut writer = SerializedFileWriter::new(file, parquet_schema.root_schema_ptr(), props).map_err(enc)?;
        let factory = ArrowRowGroupWriterFactory::new(&writer, schema.clone());
        body(&mut writer, &factory).map_err(enc)?;
        // `finish` writes the footer and flushes the buffer with the I/O error
        // intact (`into_inner` would turn a full disk into a string, and write the
        // footer again).
        writer.finish().map_err(enc)?;
        Ok(writer.inner_mut().take())
    })
}
