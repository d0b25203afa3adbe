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

use std::cell::RefCell;

#[cfg(target_arch = "x86_64")]
use clearance_solver::Isa;

use arrow::array::{Array, Float64Array};
use bytes::Bytes;
use parquet::basic::Encoding;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::metadata::ColumnChunkMetaData;
use parquet::file::reader::{ChunkReader, Length};
use parquet::file::statistics::{Statistics, ValueStatistics};
use parquet::schema::types::ColumnDescPtr;

use crate::writer::Codec;

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

/// Thrift encoding numbers (parquet.thrift).
const PLAIN: i32 = 0;
const RLE: i32 = 3;
const BYTE_STREAM_SPLIT: i32 = 9;
const RLE_DICTIONARY: i32 = 8;

/// Per-thread buffers, reused from page to page and column to column.
#[derive(Default)]
struct Scratch {
    compact: Vec<f64>,
    bits: Vec<u8>,
    payload: Vec<u8>,
    compressed: Vec<u8>,
    zstd: Option<zstd::bulk::Compressor<'static>>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// The bytes of a column chunk as a list of buffers, in file order, for
/// [`append_column`](parquet::file::writer::SerializedRowGroupWriter::append_column):
/// the pages of a chunk encoded block by block need not be copied together first.
pub(crate) struct Segments<'a>(Vec<&'a [u8]>);

impl Segments<'_> {
    fn total(&self) -> u64 {
        self.0.iter().map(|b| b.len() as u64).sum()
    }
}

impl Length for Segments<'_> {
    fn len(&self) -> u64 {
        self.total()
    }
}

impl<'a> ChunkReader for Segments<'a> {
    type T = SegmentsRead<'a>;

    fn get_read(&self, start: u64) -> Result<SegmentsRead<'a>, ParquetError> {
        let mut read = SegmentsRead { segments: self.0.clone().into(), skip: start };
        read.seek();
        Ok(read)
    }

    fn get_bytes(&self, start: u64, length: usize) -> Result<Bytes, ParquetError> {
        let mut out = Vec::with_capacity(length);
        std::io::Read::read_to_end(&mut std::io::Read::take(self.get_read(start)?, length as u64), &mut out)?;
        if out.len() != length {
            return Err(ParquetError::EOF(format!("{length} bytes from {start} past the end of the chunk")));
        }
        Ok(out.into())
    }
}

/// A reader over [`Segments`].
pub(crate) struct SegmentsRead<'a> {
    segments: std::collections::VecDeque<&'a [u8]>,
    /// Bytes still to skip before the first one read.
    skip: u64,
}

impl SegmentsRead<'_> {
    fn seek(&mut self) {
        while let Some(front) = self.segments.front_mut() {
            if (front.len() as u64) > self.skip {
                *front = &front[self.skip as usize..];
                self.skip = 0;
                return;
            }
            self.skip -= front.len() as u64;
            self.segments.pop_front();
        }
    }
}

impl std::io::Read for SegmentsRead<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while let Some(front) = self.segments.front_mut() {
            if front.is_empty() {
                self.segments.pop_front();
                continue;
            }
            let n = front.len().min(buf.len());
            buf[..n].copy_from_slice(&front[..n]);
            *front = &front[n..];
            return Ok(n);
        }
        Ok(0)
    }
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
        let statistics = ValueStatistics::new(min, max, None, Some(self.nulls as u64), false)
            .with_nan_count(Some(self.range.nans))
            .with_backwards_compatible_min_max(true);
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
            .set_statistics(Statistics::Double(statistics))
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

/// Whether `descr` is a flat double column that may hold nulls; an error if it is
/// not a flat double.
fn flat_double(descr: &ColumnDescPtr) -> Result<bool, ParquetError> {
    let flat = descr.physical_type() == parquet::basic::Type::DOUBLE
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
        bits.clear();
        compact.clear();
        for c in values.chunks(8) {
            let mut b = 0u8;
            for (j, v) in c.iter().enumerate() {
                b |= u8::from(v.is_finite()) << j;
            }
            bits.push(b);
        }
        compact.extend(values.iter().copied().filter(|v| v.is_finite()));
        let mut range = Range::default();
        range.extend(&compact);
        let page = write_page(s, out, values.len(), true, Some(&bits), &compact, range, codec);
        (s.bits, s.compact) = (bits, compact);
        page
    })
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
    let split = codec != Codec::None;
    s.payload.clear();
    if optional {
        def_levels(&mut s.payload, rows, valid, present.len());
    }
    if split {
        split_streams(present, &mut s.payload);
    } else {
        s.payload.extend(present.iter().flat_map(|v| v.to_le_bytes()));
    }
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
    Ok(PageStats { bytes, uncompressed: bytes - body + s.payload.len(), rows, nulls: rows - present.len(), range })
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

/// The chunk of a required string column of few distinct values, row `i` holding
/// `dict[index[i]]`, encoded as `parquet`'s writer encodes such a
/// column but without its hash table: a PLAIN dictionary page of the entries used
/// (the column's `status` and `mode` labels) and one RLE_DICTIONARY data page of
/// their indices, run-length encoded and uncompressed (a part's labels change a few
/// times at most, and take a few bytes). Returns the chunk's bytes, offsets from 0,
/// and the result `append_column` takes. Interning each label cost the writer a
/// quarter of its time (`perf`).
pub(crate) fn label_chunk(
    descr: ColumnDescPtr,
    dict: &[&str],
    index: &[u8],
) -> Result<(Vec<u8>, ColumnCloseResult), ParquetError> {
    let rows = index.len();
    let flat = descr.physical_type() == parquet::basic::Type::BYTE_ARRAY
        && descr.max_rep_level() == 0
        && descr.max_def_level() == 0;
    if !flat {
        return Err(ParquetError::General(format!("{} is not a required flat string column", descr.path())));
    }
    if dict.len() > 256 {
        return Err(ParquetError::General(format!("{} labels for {}: at most 256", dict.len(), descr.path())));
    }
    // The entries used, in `dict` order, and each one's place among them.
    let mut used = vec![false; dict.len()];
    for &k in index {
        let slot = used.get_mut(k as usize);
        *slot.ok_or_else(|| ParquetError::General(format!("label {k} of {} has no entry", descr.path())))? = true;
    }
    let mut place = vec![0u8; dict.len()];
    let mut entries: Vec<&str> = Vec::new();
    for (k, e) in dict.iter().enumerate() {
        if used[k] {
            place[k] = entries.len() as u8;
            entries.push(e);
        }
    }

    let mut out = Vec::new();
    let mut body = Vec::new();
    for e in &entries {
        body.extend_from_slice(&(e.len() as u32).to_le_bytes());
        body.extend_from_slice(e.as_bytes());
    }
    dictionary_page_header(&mut out, body.len(), entries.len());
    out.extend_from_slice(&body);
    let dictionary = out.len();

    // One byte of bit width, then a run header and a one-byte value per run.
    let width = usize::BITS - entries.len().saturating_sub(1).leading_zeros();
    body.clear();
    body.push(width.max(1) as u8);
    for run in index.chunk_by(|a, b| a == b) {
        varint(&mut body, (run.len() as u64) << 1);
        body.push(place[run[0] as usize]);
    }
    page_header(&mut out, body.len(), body.len(), rows, RLE_DICTIONARY);
    out.extend_from_slice(&body);

    let bytes = |e: Option<&&str>| e.map(|e| parquet::data_type::ByteArray::from(e.as_bytes().to_vec()));
    let min = entries.iter().min();
    let max = entries.iter().max();
    let statistics = ValueStatistics::new(bytes(min), bytes(max), None, Some(0), false);
    let metadata = ColumnChunkMetaData::builder(descr)
        .set_compression(parquet::basic::Compression::UNCOMPRESSED)
        .set_encodings(vec![Encoding::PLAIN, Encoding::RLE, Encoding::RLE_DICTIONARY])
        .set_total_compressed_size(out.len() as i64)
        .set_total_uncompressed_size(out.len() as i64)
        .set_num_values(rows as i64)
        .set_dictionary_page_offset(Some(0))
        .set_data_page_offset(dictionary as i64)
        .set_statistics(Statistics::ByteArray(statistics))
        .build()?;
    let close = ColumnCloseResult {
        bytes_written: out.len() as u64,
        rows_written: rows as u64,
        metadata,
        bloom_filter: None,
        column_index: None,
        offset_index: None,
    };
    Ok((out, close))
}

/// The definition levels of a page, with their 4-byte length in front (data page
/// v1): one RLE run when every row has a value or none has, else the validity bits
/// as bit-packed runs of at most 63 groups of 8 (so every run header is one byte,
/// as some readers expect). Bits past the page's rows pad the last group.
fn def_levels(out: &mut Vec<u8>, rows: usize, valid: Option<&[u8]>, present: usize) {
    let at = out.len();
    out.extend_from_slice(&[0; 4]);
    match valid {
        Some(bits) if present > 0 && present < rows => {
            for run in bits[..rows.div_ceil(8)].chunks(63) {
                out.push(((run.len() as u8) << 1) | 1);
                out.extend_from_slice(run);
            }
        }
        _ => {
            varint(out, (rows as u64) << 1);
            out.push(u8::from(present == rows));
        }
    }
    let len = (out.len() - at - 4) as u32;
    out[at..at + 4].copy_from_slice(&len.to_le_bytes());
}

/// The byte streams of `values` appended to `out`: byte k of value i at
/// `k·len + i` (`BYTE_STREAM_SPLIT`). Eight values at a time are transposed as an
/// 8 × 8 byte matrix: by one byte permutation where the CPU has AVX-512 VBMI and the
/// kernel's choice (`Isa::best`, capped by `cap_isa`) is AVX-512, else in three
/// rounds of block swaps (23 instructions a value, callgrind).
fn split_streams(values: &[f64], out: &mut Vec<u8>) {
    let m = values.len();
    let base = out.len();
    out.resize(base + 8 * m, 0);
    let dst = &mut out[base..];
    #[cfg(target_arch = "x86_64")]
    if Isa::best() == Isa::Avx512 && std::arch::is_x86_feature_detected!("avx512vbmi") {
        // SAFETY: the CPU has AVX-512 F (`Isa::best`) and VBMI.
        return unsafe { split_streams_vbmi(values, dst) };
    }
    split_into(values, dst, transpose8);
}

/// [`split_streams`] into `dst` (`8·values.len()` bytes), eight values at a time
/// transposed by `transpose` ([`transpose8`]'s contract).
#[inline(always)]
fn split_into(values: &[f64], dst: &mut [u8], mut transpose: impl FnMut(&mut [u64; 8])) {
    let m = values.len();
    let mut chunks = values.chunks_exact(8);
    let mut i = 0;
    for c in &mut chunks {
        let mut w = [0u64; 8];
        for (w, v) in w.iter_mut().zip(c) {
            *w = v.to_bits();
        }
        transpose(&mut w);
        for (k, w) in w.iter().enumerate() {
            dst[k * m + i..k * m + i + 8].copy_from_slice(&w.to_le_bytes());
        }
        i += 8;
    }
    for (j, v) in chunks.remainder().iter().enumerate() {
        for (k, b) in v.to_le_bytes().into_iter().enumerate() {
            dst[k * m + i + j] = b;
        }
    }
}

/// [`split_streams`] with the 8 × 8 transposition as one `vpermb`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vbmi")]
fn split_streams_vbmi(values: &[f64], dst: &mut [u8]) {
    use std::arch::x86_64::*;
    // Byte 8r + c of the result is byte 8c + r of the eight words.
    let index: [u8; 64] = std::array::from_fn(|b| (8 * (b % 8) + b / 8) as u8);
    // SAFETY: 64 bytes read from a 64-byte array.
    let index = unsafe { _mm512_loadu_si512(index.as_ptr().cast()) };
    split_into(values, dst, |w| {
        // SAFETY: 64 bytes read from and written to the 8 words of `w`.
        unsafe {
            let v = _mm512_loadu_si512(w.as_ptr().cast());
            _mm512_storeu_si512(w.as_mut_ptr().cast(), _mm512_permutexvar_epi8(index, v));
        }
    });
}

/// Transposes the 8 × 8 byte matrix whose row r is `w[r]` (byte c of the word is
/// column c): afterwards byte c of `w[r]` is byte r of the original `w[c]`.
#[inline(always)]
fn transpose8(w: &mut [u64; 8]) {
    #[inline(always)]
    fn swap(w: &mut [u64; 8], a: usize, b: usize, shift: u32, mask: u64) {
        let t = ((w[a] >> shift) ^ w[b]) & mask;
        w[a] ^= t << shift;
        w[b] ^= t;
    }
    for r in 0..4 {
        swap(w, r, r + 4, 32, 0x0000_0000_FFFF_FFFF);
    }
    for r in [0, 1, 4, 5] {
        swap(w, r, r + 2, 16, 0x0000_FFFF_0000_FFFF);
    }
    for r in [0, 2, 4, 6] {
        swap(w, r, r + 1, 8, 0x00FF_00FF_00FF_00FF);
    }
}

/// Minimum and maximum in IEEE 754 total order (−0 below +0), and the NaN count.
/// Compared as doubles (which vectorises, where 64-bit integer comparisons do not
/// before SSE 4.2); a zero extreme then takes its sign from the values.
#[derive(Clone, Copy, Debug)]
struct Range {
    lo: f64,
    hi: f64,
    /// Valid values seen, NaN included.
    count: usize,
    nans: u64,
    /// Whether −0 and +0 were among the values: set only when an extreme is zero.
    neg_zero: bool,
    pos_zero: bool,
}

impl Default for Range {
    fn default() -> Self {
        Self { lo: f64::INFINITY, hi: f64::NEG_INFINITY, count: 0, nans: 0, neg_zero: false, pos_zero: false }
    }
}

impl Range {
    /// Takes in `values`, on AVX2 where the kernel's choice (`Isa::best`) allows it.
    fn extend(&mut self, values: &[f64]) {
        #[cfg(target_arch = "x86_64")]
        if Isa::best() >= Isa::Avx2 {
            // SAFETY: the CPU has AVX2 (`Isa::best`).
            let (lo, hi, all_finite) = unsafe { extremes_avx2(values) };
            return self.take(values, lo, hi, all_finite);
        }
        let (lo, hi, all_finite) = extremes(values);
        self.take(values, lo, hi, all_finite)
    }

    /// Takes in `values`, whose extremes (NaN aside) are `lo` and `hi`.
    fn take(&mut self, values: &[f64], lo: f64, hi: f64, all_finite: bool) {
        let nans = if all_finite { 0 } else { values.iter().filter(|v| v.is_nan()).count() as u64 };
        if lo == 0.0 || hi == 0.0 {
            // Only zeros can tie: which signs are present decides the extremes.
            self.neg_zero |= values.iter().any(|v| v.to_bits() == (-0.0f64).to_bits());
            self.pos_zero |= values.iter().any(|v| v.to_bits() == 0);
        }
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
        self.count += values.len();
        self.nans += nans;
    }

    /// Takes in the values `other` has seen.
    fn merge(&mut self, other: &Range) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
        self.count += other.count;
        self.nans += other.nans;
        // A zero extreme of the union is one of each part holding a zero, whose
        // flags were then set.
        self.neg_zero |= other.neg_zero;
        self.pos_zero |= other.pos_zero;
    }

    /// `(min, max)`, `None` when no value is a number.
    fn bounds(self) -> (Option<f64>, Option<f64>) {
        if self.count as u64 == self.nans {
            return (None, None);
        }
        let lo = if self.lo == 0.0 { if self.neg_zero { -0.0 } else { 0.0 } } else { self.lo };
        let hi = if self.hi == 0.0 { if self.pos_zero { 0.0 } else { -0.0 } } else { self.hi };
        (Some(lo), Some(hi))
    }
}

/// [`extremes`] with AVX2: eight values an iteration in two registers, where
/// the compiler's own vectorisation of that loop shuffled lanes back and forth
/// (`objdump`). `min` and `max` keep the running extreme when the value is NaN,
/// as the comparisons there do, so both give the same result.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn extremes_avx2(values: &[f64]) -> (f64, f64, bool) {
    use std::arch::x86_64::*;
    let (mut lo, mut hi, mut odd) =
        ([_mm256_set1_pd(f64::INFINITY); 2], [_mm256_set1_pd(f64::NEG_INFINITY); 2], [_mm256_setzero_pd(); 2]);
    let mut chunks = values.chunks_exact(8);
    for c in &mut chunks {
        for h in 0..2 {
            // SAFETY: four doubles from `c[4h]`, within the chunk of eight.
            let v = unsafe { _mm256_loadu_pd(c.as_ptr().add(4 * h)) };
            // `minpd a, b` is `a < b ? a : b`: a NaN `v` leaves the extreme.
            lo[h] = _mm256_min_pd(v, lo[h]);
            hi[h] = _mm256_max_pd(v, hi[h]);
            odd[h] = _mm256_add_pd(odd[h], _mm256_sub_pd(v, v));
        }
    }
    let lanes = |x: [__m256d; 2]| {
        let mut out = [0.0; 8];
        // SAFETY: two stores of four doubles into eight.
        unsafe {
            _mm256_storeu_pd(out.as_mut_ptr(), x[0]);
            _mm256_storeu_pd(out.as_mut_ptr().add(4), x[1]);
        }
        out
    };
    let (lo, hi, odd) = (lanes(lo), lanes(hi), lanes(odd));
    fold_extremes(lo, hi, odd, chunks.remainder())
}

/// The least and greatest of `values` as doubles compare (NaN aside: ±∞ when none
/// is a number), and whether every value is finite. Eight running extremes, so the
/// loop vectorises; a NaN never replaces one. `v − v` is 0 for a finite value and
/// NaN for any other, so their sums say whether NaNs need counting at all: counting
/// each value's `is_nan` did not vectorise.
#[allow(clippy::eq_op)]
fn extremes(values: &[f64]) -> (f64, f64, bool) {
    let (mut lo, mut hi, mut odd) = ([f64::INFINITY; 8], [f64::NEG_INFINITY; 8], [0.0f64; 8]);
    let mut chunks = values.chunks_exact(8);
    for c in &mut chunks {
        for j in 0..8 {
            let v = c[j];
            lo[j] = if v < lo[j] { v } else { lo[j] };
            hi[j] = if v > hi[j] { v } else { hi[j] };
            odd[j] += v - v;
        }
    }
    fold_extremes(lo, hi, odd, chunks.remainder())
}

/// [`extremes`] from eight running extremes and sums of `v − v`, and the values
/// left over.
#[inline(always)]
#[allow(clippy::eq_op)]
fn fold_extremes(mut lo: [f64; 8], mut hi: [f64; 8], mut odd: [f64; 8], rest: &[f64]) -> (f64, f64, bool) {
    for &v in rest {
        lo[0] = if v < lo[0] { v } else { lo[0] };
        hi[0] = if v > hi[0] { v } else { hi[0] };
        odd[0] += v - v;
    }
    let fold = |x: [f64; 8], f: fn(f64, f64) -> f64| x.into_iter().reduce(f).expect("eight lanes");
    (fold(lo, f64::min), fold(hi, f64::max), odd.iter().all(|&o| o == 0.0))
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// An i32 field of a Thrift compact struct, `delta` after the previous field.
fn i32_field(out: &mut Vec<u8>, delta: u8, v: i32) {
    out.push((delta << 4) | 5);
    varint(out, ((v << 1) ^ (v >> 31)) as u32 as u64);
}

/// A `PageHeader` of a dictionary page of `entries` PLAIN values (parquet.thrift),
/// uncompressed, Thrift compact protocol.
fn dictionary_page_header(out: &mut Vec<u8>, size: usize, entries: usize) {
    i32_field(out, 1, 2); // 1: type = DICTIONARY_PAGE
    i32_field(out, 1, size as i32); // 2: uncompressed_page_size
    i32_field(out, 1, size as i32); // 3: compressed_page_size
    out.push((4 << 4) | 12); // 7: dictionary_page_header, a struct
    i32_field(out, 1, entries as i32); // 1: num_values
    i32_field(out, 1, PLAIN); // 2: encoding
    out.push(0); // end of DictionaryPageHeader
    out.push(0); // end of PageHeader
}

/// A `PageHeader` of a v1 data page (parquet.thrift), Thrift compact protocol.
fn page_header(out: &mut Vec<u8>, uncompressed: usize, compressed: usize, rows: usize, encoding: i32) {
    i32_field(out, 1, 0); // 1: type = DATA_PAGE
    i32_field(out, 1, uncompressed as i32); // 2: uncompressed_page_size
    i32_field(out, 1, compressed as i32); // 3: compressed_page_size
    out.push((2 << 4) | 12); // 5: data_page_header, a struct
    i32_field(out, 1, rows as i32); // 1: num_values, nulls included
    i32_field(out, 1, encoding); // 2: encoding
    i32_field(out, 1, RLE); // 3: definition_level_encoding
    i32_field(out, 1, RLE); // 4: repetition_level_encoding
    out.push(0); // end of DataPageHeader
    out.push(0); // end of PageHeader
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transposed_streams_match_the_definition() {
        // The portable transposition, whatever `split_streams` chose on this CPU.
        for m in [0usize, 3, 8, 17] {
            let values: Vec<f64> = (0..m).map(|i| (i as f64 * 1.37 + 0.1).ln() * 1e5).collect();
            let (mut portable, mut chosen) = (vec![0u8; 8 * m], vec![0xAB]);
            split_into(&values, &mut portable, transpose8);
            split_streams(&values, &mut chosen);
            assert_eq!(chosen[1..], portable[..], "{m} values");
        }
        for m in [0usize, 1, 7, 8, 9, 16, 61] {
            let values: Vec<f64> =
                (0..m).map(|i| (i as f64 * 0.7311 - 3.0).exp() * if i % 3 == 0 { -1.0 } else { 1.0 }).collect();
            let mut out = vec![0xAB];
            split_streams(&values, &mut out);
            assert_eq!(out.len(), 1 + 8 * m);
            for (i, v) in values.iter().enumerate() {
                for (k, b) in v.to_le_bytes().into_iter().enumerate() {
                    assert_eq!(out[1 + k * m + i], b, "value {i} byte {k} of {m}");
                }
            }
        }
    }

    #[test]
    fn range_is_total_order_without_nans() {
        let mut values =
            vec![3.5, -0.0, 0.0, -2.0, f64::NAN, f64::MIN_POSITIVE, -f64::MAX, 1e300, -1e-300, f64::INFINITY];
        let mut r = Range::default();
        r.extend(&values[..5]);
        r.extend(&values[5..]);
        values.retain(|v| !v.is_nan());
        values.sort_by(f64::total_cmp);
        let (lo, hi) = r.bounds();
        assert_eq!(
            (lo.unwrap().to_bits(), hi.unwrap().to_bits()),
            (values[0].to_bits(), values[values.len() - 1].to_bits())
        );
        assert_eq!(r.nans, 1);
        for (zeros, lo, hi) in [
            (vec![-0.0, 0.0], -0.0, 0.0),
            (vec![0.0; 9], 0.0, 0.0),
            (vec![-0.0; 11], -0.0, -0.0),
            (vec![-1.0, 0.0, -0.0], -1.0, 0.0),
            (vec![-0.0, 2.0], -0.0, 2.0),
        ] {
            let mut r = Range::default();
            r.extend(&zeros);
            let (a, b) = r.bounds();
            assert_eq!((a.unwrap().to_bits(), b.unwrap().to_bits()), (f64::to_bits(lo), f64::to_bits(hi)), "{zeros:?}");
        }
        assert_eq!(Range::default().bounds(), (None, None));
        let mut r = Range::default();
        r.extend(&[f64::NAN; 3]);
        assert_eq!((r.bounds(), r.nans), ((None, None), 3));
    }

    /// A range taken in pieces of any length (so that the vector loop's remainder
    /// and the scan for signed zeros meet every offset) has the bounds, NaN count
    /// and length of the range of the whole, and those of a plain sort and count;
    /// infinities are not NaNs.
    #[test]
    fn range_in_pieces_is_the_range_of_the_whole() {
        let specials = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0];
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for n in [0usize, 1, 7, 8, 9, 33, 100, 257] {
            for density in [0u64, 3, 50] {
                let values: Vec<f64> = (0..n)
                    .map(|_| {
                        let r = next();
                        if r % 100 < density {
                            specials[(r >> 8) as usize % specials.len()]
                        } else {
                            (r >> 11) as f64 * 1e-12 - 4e3
                        }
                    })
                    .collect();
                let mut whole = Range::default();
                whole.extend(&values);
                let bounds = |r: &Range| r.bounds().0.map(f64::to_bits).zip(r.bounds().1.map(f64::to_bits));
                // The vector code that `extend` chose gives the portable code's result.
                let bits = |(lo, hi, finite): (f64, f64, bool)| (lo.to_bits(), hi.to_bits(), finite);
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2.
                    assert_eq!(bits(unsafe { extremes_avx2(&values) }), bits(extremes(&values)));
                }
                for piece in [1usize, 5, 8, 32] {
                    let mut parts = Range::default();
                    for c in values.chunks(piece) {
                        parts.extend(c);
                    }
                    assert_eq!((bounds(&parts), parts.nans, parts.count), (bounds(&whole), whole.nans, whole.count));
                }
                let mut numbers: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
                numbers.sort_by(f64::total_cmp);
                let expected = numbers.first().map(|v| v.to_bits()).zip(numbers.last().map(|v| v.to_bits()));
                assert_eq!(bounds(&whole), expected, "{n} values, {density} % special");
                assert_eq!(whole.nans as usize, values.len() - numbers.len());
            }
        }
    }
}
