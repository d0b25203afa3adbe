//! Double column chunks encoded by the engine: from Arrow buffers
//! ([`encode_doubles`], for `write_parquet`), or a page at a time from the rows a
//! thread has just computed ([`encode_page`], for `clearance run`'s part files).
//!
//! The Arrow writer of the `parquet` crate turns every nullable column into
//! definition levels (two bytes a value) and a vector of non-null indices (eight),
//! gathers the values through it, finds their minimum and maximum, splits them into
//! byte streams, then compresses. On a standard part file of doubles that was
//! two fifths of the work of a run (`perf`, benches/README.md). The engine's columns
//! are flat and mostly without nulls, so this module writes their pages itself, in
//! one pass over the values:
//!
//! - data pages (format v1) of at most [`PAGE_ROWS`] rows, each compressed whole;
//! - definition levels in the RLE/bit-packed hybrid: one run for a page without
//!   nulls, else the validity bitmap itself, which is their bit-packed form;
//! - values `PLAIN`, or `BYTE_STREAM_SPLIT` when compressed: the split puts the
//!   exponent bytes of neighbouring doubles together, which is what lets a codec find
//!   repeats in smooth engine output (a standard part: 536 bytes a pose uncompressed,
//!   509 with LZ4 alone, 376 with both);
//! - chunk statistics: minimum and maximum in IEEE 754 total order (the column
//!   order the file declares for doubles) of the values that are numbers, null
//!   count and NaN count, as `parquet` writes them, merged page by page.
//!
//! A chunk's pages need not be contiguous in memory: [`DoubleChunk`] hands them to
//! `parquet` as a list of slices.
//!
//! The file's footer, schema and column metadata are still written by `parquet`
//! ([`SerializedRowGroupWriter::append_column`](parquet::file::writer::SerializedRowGroupWriter::append_column)).
//! No page index is written for these columns (the row group's statistics remain).

mod labels;
mod levels;
mod segments;
mod split;
mod stats;
mod thrift;

pub(crate) use labels::label_chunk;
pub(crate) use segments::Segments;

use std::cell::RefCell;

use arrow::array::{Array, Float64Array};
use parquet::basic::Encoding;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::metadata::ColumnChunkMetaData;
use parquet::file::statistics::{Statistics, ValueStatistics};
use parquet::schema::types::ColumnDescPtr;

use crate::writer::Codec;
use levels::def_levels;
use split::split_streams_into;
use stats::Range;
use thrift::{BYTE_STREAM_SPLIT, PLAIN, page_header};

/// Rows per data page: a multiple of 8, so that each page's validity bits start on
/// a byte. `clearance run` computes a page of every column on one thread before
/// encoding it: 4 096 standard rows are 2.3 MB of doubles, a little more than the
/// 2 MB L2 cache of each of this machine's cores; 2 048 rows, which fit, were no
/// faster. Larger pages compress a little better (the bench job with zstd level 1:
/// 377.7 bytes a standard pose with 16 384 rows, 380.5 with 8 192, 386.9 with
/// 4 096), but 8 192 rows were already no faster end to end (benches/README.md).
pub const PAGE_ROWS: usize = 4 * 1024;

/// Rows per page at the end of a part file: what would be its last page of
/// [`PAGE_ROWS`] rows is cut into pages of this many. The threads sharing a part's
/// pages then run out of them within a small page of each other, where one used to
/// wait up to a whole page (a few milliseconds a part) for the other.
pub const TAIL_PAGE_ROWS: usize = PAGE_ROWS / 4;

/// The first row and the rows of each page of a part file of `rows` rows.
pub fn page_spans(rows: usize) -> Vec<(usize, usize)> {
    let tail = rows.saturating_sub(1) / PAGE_ROWS * PAGE_ROWS;
    let mut out: Vec<(usize, usize)> = (0..tail).step_by(PAGE_ROWS).map(|first| (first, PAGE_ROWS)).collect();
    out.extend((tail..rows).step_by(TAIL_PAGE_ROWS).map(|first| (first, TAIL_PAGE_ROWS.min(rows - first))));
    out
}

/// Per-thread buffers, reused from page to page and column to column.
#[derive(Default)]
struct Scratch {
    compact: Vec<f64>,
    /// A page narrowed to `f32` ([`encode_page_single`]).
    single: Vec<f32>,
    bits: Vec<u8>,
    payload: Vec<u8>,
    /// A page's definition levels, before its values' streams ([`write_page`]).
    levels: Vec<u8>,
    compressed: Vec<u8>,
    zstd: Option<zstd::bulk::Compressor<'static>>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// What a column chunk's metadata needs to know of one of its pages.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PageStats {
    /// Bytes of the page in the file: header and body.
    pub(crate) bytes: usize,
    /// The same with the body uncompressed.
    uncompressed: usize,
    rows: usize,
    nulls: usize,
    range: Range,
}

/// The pages of one double column chunk, as they are encoded.
#[derive(Default)]
pub(crate) struct DoubleChunk<'a> {
    segments: Vec<&'a [u8]>,
    bytes: usize,
    uncompressed: usize,
    rows: usize,
    nulls: usize,
    range: Range,
}

impl<'a> DoubleChunk<'a> {
    /// Appends pages with the `stats` of each.
    pub(crate) fn push(&mut self, bytes: &'a [u8], stats: &[PageStats]) {
        debug_assert_eq!(bytes.len(), stats.iter().map(|p| p.bytes).sum::<usize>());
        self.segments.push(bytes);
        for p in stats {
            self.bytes += p.bytes;
            self.uncompressed += p.uncompressed;
            self.rows += p.rows;
            self.nulls += p.nulls;
            self.range.merge(&p.range);
        }
    }

    /// The chunk's bytes and what `append_column` takes, for the column `descr`.
    pub(crate) fn close(
        self,
        descr: ColumnDescPtr,
        codec: Codec,
    ) -> Result<(Segments<'a>, ColumnCloseResult), ParquetError> {
        let optional = flat_double(&descr)?;
        if self.nulls > 0 && !optional {
            return Err(ParquetError::General(format!("nulls in the required column {}", descr.path())));
        }
        let (min, max) = self.range.bounds();
        let (nulls, nans) = (Some(self.nulls as u64), Some(self.range.nans));
        fn value_statistics<T>(
            min: Option<T>,
            max: Option<T>,
            nulls: Option<u64>,
            nans: Option<u64>,
        ) -> ValueStatistics<T> {
            ValueStatistics::new(min, max, None, nulls, false)
                .with_nan_count(nans)
                .with_backwards_compatible_min_max(true)
        }
        // A column of floats holds the `f32` values its range was taken over.
        let statistics = if descr.physical_type() == parquet::basic::Type::FLOAT {
            let narrow = |v: Option<f64>| v.map(|v| v as f32);
            Statistics::Float(value_statistics(narrow(min), narrow(max), nulls, nans))
        } else {
            Statistics::Double(value_statistics(min, max, nulls, nans))
        };
        let mut encodings = vec![if codec == Codec::None { Encoding::PLAIN } else { Encoding::BYTE_STREAM_SPLIT }];
        if optional {
            encodings.push(Encoding::RLE);
        }
        let metadata = ColumnChunkMetaData::builder(descr)
            .set_compression(codec.compression())
            .set_encodings(encodings)
            .set_total_compressed_size(self.bytes as i64)
            .set_total_uncompressed_size(self.uncompressed as i64)
            .set_num_values(self.rows as i64)
            .set_data_page_offset(0)
            .set_statistics(statistics)
            .build()?;
        let close = ColumnCloseResult {
            bytes_written: self.bytes as u64,
            rows_written: self.rows as u64,
            metadata,
            bloom_filter: None,
            column_index: None,
            offset_index: None,
        };
        Ok((Segments(self.segments), close))
    }
}

/// Whether `descr` is a flat double (or float, [`encode_page_single`]) column that
/// may hold nulls; an error if it is not a flat double or float.
fn flat_double(descr: &ColumnDescPtr) -> Result<bool, ParquetError> {
    use parquet::basic::Type;
    let flat = matches!(descr.physical_type(), Type::DOUBLE | Type::FLOAT)
        && descr.max_rep_level() == 0
        && descr.max_def_level() <= 1;
    if !flat {
        return Err(ParquetError::General(format!("{} is not a flat double column", descr.path())));
    }
    Ok(descr.max_def_level() == 1)
}

/// The encoded chunk of `array` (all of it) for the column `descr`: its bytes, with
/// offsets counted from 0, and the result `append_column` takes.
pub(crate) fn encode_doubles(
    descr: &ColumnDescPtr,
    array: &Float64Array,
    codec: Codec,
) -> Result<(Vec<u8>, Vec<PageStats>), ParquetError> {
    let optional = flat_double(descr)?;
    let values: &[f64] = array.values();
    let nulls = array.nulls().filter(|n| n.null_count() > 0);
    if nulls.is_some() && !optional {
        return Err(ParquetError::General(format!("nulls in the required column {}", descr.path())));
    }
    let mut out = Vec::with_capacity(values.len() * 8 / if codec == Codec::None { 1 } else { 2 } + 64);
    let mut pages = Vec::new();
    SCRATCH.with_borrow_mut(|s| -> Result<(), ParquetError> {
        for start in (0..values.len()).step_by(PAGE_ROWS) {
            let rows = PAGE_ROWS.min(values.len() - start);
            let page_nulls = nulls.map(|n| n.slice(start, rows)).filter(|n| n.null_count() > 0);
            let page = &values[start..start + rows];
            let mut compact = std::mem::take(&mut s.compact);
            let present: &[f64] = match &page_nulls {
                None => page,
                Some(n) => {
                    compact.clear();
                    compact.extend(n.valid_indices().map(|i| page[i]));
                    &compact
                }
            };
            let mut range = Range::default();
            range.extend(present);
            let bits = page_nulls.as_ref().map(|n| n.inner().sliced());
            let page =
                write_page(s, &mut out, rows, optional, bits.as_ref().map(|b| b.as_slice()), present, range, codec);
            s.compact = compact;
            pages.push(page?);
        }
        Ok(())
    })?;
    Ok((out, pages))
}

/// One page of the values of an optional double column, appended to `out`, with
/// every value that is not finite written as a null (the engine's rule for its
/// `poses` columns).
pub(crate) fn encode_page(values: &[f64], codec: Codec, out: &mut Vec<u8>) -> Result<PageStats, ParquetError> {
    let mut range = Range::default();
    range.extend(values);
    // Every value is finite exactly when the extremes are and no NaN was met.
    if range.nans == 0 && range.lo.is_finite() && range.hi.is_finite() {
        return SCRATCH.with_borrow_mut(|s| write_page(s, out, values.len(), true, None, values, range, codec));
    }
    SCRATCH.with_borrow_mut(|s| {
        let mut bits = std::mem::take(&mut s.bits);
        let mut compact = std::mem::take(&mut s.compact);
        validity(values, f64::is_finite, &mut bits);
        compact.clear();
        compact.extend(values.iter().copied().filter(|v| v.is_finite()));
        let mut range = Range::default();
        range.extend(&compact);
        let page = write_page(s, out, values.len(), true, Some(&bits), &compact, range, codec);
        (s.bits, s.compact) = (bits, compact);
        page
    })
}

/// The validity bitmap of `values` into `bits` (cleared first): bit j of byte k set
/// where `valid(values[8k + j])`, the bit-packed form of a page's definition levels.
fn validity<T: Copy>(values: &[T], valid: impl Fn(T) -> bool, bits: &mut Vec<u8>) {
    bits.clear();
    for c in values.chunks(8) {
        bits.push(c.iter().enumerate().fold(0u8, |b, (j, v)| b | (u8::from(valid(*v)) << j)));
    }
}

/// One data page appended to `out`: `rows` rows whose values are `present`, with
/// `valid` the validity bits of the rows when some are null. `range` is that of
/// `present`.
#[allow(clippy::too_many_arguments)]
fn write_page(
    s: &mut Scratch,
    out: &mut Vec<u8>,
    rows: usize,
    optional: bool,
    valid: Option<&[u8]>,
    present: &[f64],
    range: Range,
    codec: Codec,
) -> Result<PageStats, ParquetError> {
    if codec != Codec::None {
        // Every byte of the payload is written again: resized rather than cleared, the
        // buffer's 32 kB are not zeroed first for each page.
        s.levels.clear();
        if optional {
            def_levels(&mut s.levels, rows, valid, present.len());
        }
        let levels = s.levels.len();
        s.payload.resize(levels + 8 * present.len(), 0);
        s.payload[..levels].copy_from_slice(&s.levels);
        split_streams_into(present, &mut s.payload[levels..]);
    } else {
        s.payload.clear();
        if optional {
            def_levels(&mut s.payload, rows, valid, present.len());
        }
        s.payload.extend(present.iter().flat_map(|v| v.to_le_bytes()));
    }
    finish_page(s, out, rows, present.len(), range, codec)
}

/// The page whose levels and values are in `s.payload`, compressed with `codec` and
/// appended to `out` after its header: `rows` rows, `present` of them values.
fn finish_page(
    s: &mut Scratch,
    out: &mut Vec<u8>,
    rows: usize,
    present: usize,
    range: Range,
    codec: Codec,
) -> Result<PageStats, ParquetError> {
    let split = codec != Codec::None;
    let encoding = if split { BYTE_STREAM_SPLIT } else { PLAIN };
    let before = out.len();
    let body = match codec {
        Codec::Zstd => zstd_page(s, out, rows, encoding)?,
        Codec::None | Codec::Lz4 => {
            let body: &[u8] = if codec == Codec::Lz4 {
                s.compressed.resize(lz4_flex::block::get_maximum_output_size(s.payload.len()), 0);
                let n = lz4_flex::block::compress_into(&s.payload, &mut s.compressed)
                    .map_err(|e| ParquetError::External(Box::new(e)))?;
                &s.compressed[..n]
            } else {
                &s.payload
            };
            page_header(out, s.payload.len(), body.len(), rows, encoding);
            out.extend_from_slice(body);
            body.len()
        }
    };
    let bytes = out.len() - before;
    Ok(PageStats { bytes, uncompressed: bytes - body + s.payload.len(), rows, nulls: rows - present, range })
}

/// [`encode_page`] for a column stored as `float`s (`--precision single`): each value
/// rounded to the nearest `f32`, and a value whose `f32` is not finite (not finite
/// already, or beyond the range of `f32`) written as a null. The page's range is
/// that of the `f32` values (as doubles, exactly).
pub(crate) fn encode_page_single(values: &[f64], codec: Codec, out: &mut Vec<u8>) -> Result<PageStats, ParquetError> {
    SCRATCH.with_borrow_mut(|s| {
        let (mut single, mut bits, mut compact) =
            (std::mem::take(&mut s.single), std::mem::take(&mut s.bits), std::mem::take(&mut s.compact));
        single.clear();
        single.extend(values.iter().map(|&v| v as f32));
        let all = single.iter().all(|v| v.is_finite());
        if !all {
            validity(&single, f32::is_finite, &mut bits);
            single.retain(|v| v.is_finite());
        }
        compact.clear();
        compact.extend(single.iter().map(|&v| f64::from(v)));
        let mut range = Range::default();
        range.extend(&compact);
        s.payload.clear();
        def_levels(&mut s.payload, values.len(), (!all).then_some(&bits[..]), single.len());
        if codec == Codec::None {
            s.payload.extend(single.iter().flat_map(|v| v.to_le_bytes()));
        } else {
            split_streams_single(&single, &mut s.payload);
        }
        let page = finish_page(s, out, values.len(), single.len(), range, codec);
        (s.single, s.bits, s.compact) = (single, bits, compact);
        page
    })
}

/// `BYTE_STREAM_SPLIT` of `float`s appended to `out`: byte k of value i at `k·len + i`.
fn split_streams_single(values: &[f32], out: &mut Vec<u8>) {
    let (m, base) = (values.len(), out.len());
    out.resize(base + 4 * m, 0);
    let dst = &mut out[base..];
    for (i, v) in values.iter().enumerate() {
        for (k, b) in v.to_le_bytes().into_iter().enumerate() {
            dst[k * m + i] = b;
        }
    }
}

/// Appends the page header and the zstd-compressed `s.payload` to `out`; returns
/// the body's length. The body is compressed into scratch memory, which stays in
/// the cache, and copied after the header once its length is known. Compressing
/// straight into `out` after a header sized for the largest body, then moving the
/// body up by the byte or two the real header saved, was 7 % of a run (`perf`):
/// `memmove` between nearby overlapping addresses is slow.
fn zstd_page(s: &mut Scratch, out: &mut Vec<u8>, rows: usize, encoding: i32) -> Result<usize, ParquetError> {
    if s.zstd.is_none() {
        s.zstd = Some(zstd::bulk::Compressor::new(crate::writer::PAGE_ZSTD_LEVEL)?);
    }
    s.compressed.clear();
    s.compressed.reserve(zstd::zstd_safe::compress_bound(s.payload.len()));
    let n = s.zstd.as_mut().expect("just made").compress_to_buffer(&s.payload, &mut s.compressed)?;
    page_header(out, s.payload.len(), n, rows, encoding);
    out.extend_from_slice(&s.compressed[..n]);
    Ok(n)
}
