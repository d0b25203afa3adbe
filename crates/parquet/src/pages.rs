//! Double column chunks encoded straight from their Arrow buffers.
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
//!   count and NaN count, as `parquet` writes them.
//!
//! The file's footer, schema and column metadata are still written by `parquet`
//! ([`SerializedRowGroupWriter::append_column`](parquet::file::writer::SerializedRowGroupWriter::append_column)).
//! No page index is written for these columns (the row group's statistics remain).

use std::cell::RefCell;

use arrow::array::{Array, Float64Array};
use arrow::buffer::NullBuffer;
use bytes::Bytes;
use parquet::basic::Encoding;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::metadata::ColumnChunkMetaData;
use parquet::file::statistics::{Statistics, ValueStatistics};
use parquet::schema::types::ColumnDescPtr;

use crate::writer::Codec;

/// Rows per data page: 128 KiB of doubles, near `parquet`'s default of 20 000
/// rows, and a multiple of 8 so that each page's validity bits start on a byte.
pub(crate) const PAGE_ROWS: usize = 16 * 1024;

/// Thrift encoding numbers (parquet.thrift).
const PLAIN: i32 = 0;
const RLE: i32 = 3;
const BYTE_STREAM_SPLIT: i32 = 9;

/// Per-thread buffers, reused from page to page and column to column.
#[derive(Default)]
struct Scratch {
    compact: Vec<f64>,
    payload: Vec<u8>,
    compressed: Vec<u8>,
    zstd: Option<zstd::bulk::Compressor<'static>>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// The encoded chunk of `array` (all of it) for the column `descr`: its bytes, with
/// offsets counted from 0, and the result `append_column` takes.
pub(crate) fn encode_doubles(
    descr: ColumnDescPtr,
    array: &Float64Array,
    codec: Codec,
) -> Result<(Bytes, ColumnCloseResult), ParquetError> {
    let flat = descr.physical_type() == parquet::basic::Type::DOUBLE
        && descr.max_rep_level() == 0
        && descr.max_def_level() <= 1;
    if !flat {
        return Err(ParquetError::General(format!("{} is not a flat double column", descr.path())));
    }
    let values: &[f64] = array.values();
    let nulls = array.nulls().filter(|n| n.null_count() > 0);
    let optional = descr.max_def_level() == 1;
    if nulls.is_some() && !optional {
        return Err(ParquetError::General(format!("nulls in the required column {}", descr.path())));
    }
    let split = codec != Codec::None;
    let mut out = Vec::with_capacity(values.len() * 8 / if split { 2 } else { 1 } + 64);
    let mut uncompressed_total = 0usize;
    let mut range = Range::default();
    SCRATCH.with_borrow_mut(|s| -> Result<(), ParquetError> {
        for start in (0..values.len()).step_by(PAGE_ROWS) {
            let rows = PAGE_ROWS.min(values.len() - start);
            let page_nulls = nulls.map(|n| n.slice(start, rows)).filter(|n| n.null_count() > 0);
            s.payload.clear();
            if optional {
                def_levels(&mut s.payload, rows, page_nulls.as_ref());
            }
            let page = &values[start..start + rows];
            let present: &[f64] = match &page_nulls {
                None => page,
                Some(n) => {
                    s.compact.clear();
                    s.compact.extend(n.valid_indices().map(|i| page[i]));
                    &s.compact
                }
            };
            range.extend(present);
            if split {
                split_streams(present, &mut s.payload);
            } else {
                s.payload.extend(present.iter().flat_map(|v| v.to_le_bytes()));
            }
            let body: &[u8] = match codec {
                Codec::None => &s.payload,
                Codec::Lz4 => {
                    s.compressed.resize(lz4_flex::block::get_maximum_output_size(s.payload.len()), 0);
                    let n = lz4_flex::block::compress_into(&s.payload, &mut s.compressed)
                        .map_err(|e| ParquetError::External(Box::new(e)))?;
                    &s.compressed[..n]
                }
                Codec::Zstd => {
                    if s.zstd.is_none() {
                        s.zstd = Some(zstd::bulk::Compressor::new(crate::writer::ZSTD_LEVEL)?);
                    }
                    let zstd = s.zstd.as_mut().expect("just made");
                    s.compressed.clear();
                    s.compressed.reserve(zstd::zstd_safe::compress_bound(s.payload.len()));
                    zstd.compress_to_buffer(&s.payload, &mut s.compressed)?;
                    &s.compressed
                }
            };
            let before = out.len();
            let encoding = if split { BYTE_STREAM_SPLIT } else { PLAIN };
            page_header(&mut out, s.payload.len(), body.len(), rows, encoding);
            uncompressed_total += out.len() - before + s.payload.len();
            out.extend_from_slice(body);
        }
        Ok(())
    })?;

    let null_count = nulls.map_or(0, |n| n.null_count()) as u64;
    let (min, max) = range.bounds();
    let statistics = ValueStatistics::new(min, max, None, Some(null_count), false)
        .with_nan_count(Some(range.nans))
        .with_backwards_compatible_min_max(true);
    let mut encodings = vec![if split { Encoding::BYTE_STREAM_SPLIT } else { Encoding::PLAIN }];
    if optional {
        encodings.push(Encoding::RLE);
    }
    let metadata = ColumnChunkMetaData::builder(descr)
        .set_compression(codec.compression())
        .set_encodings(encodings)
        .set_total_compressed_size(out.len() as i64)
        .set_total_uncompressed_size(uncompressed_total as i64)
        .set_num_values(values.len() as i64)
        .set_data_page_offset(0)
        .set_statistics(Statistics::Double(statistics))
        .build()?;
    let close = ColumnCloseResult {
        bytes_written: out.len() as u64,
        rows_written: values.len() as u64,
        metadata,
        bloom_filter: None,
        column_index: None,
        offset_index: None,
    };
    Ok((Bytes::from(out), close))
}

/// The definition levels of a page, with their 4-byte length in front (data page
/// v1): one RLE run when every row has a value or none has, else the validity bits
/// as bit-packed runs of at most 63 groups of 8 (so every run header is one byte,
/// as some readers expect). Bits past the page's rows pad the last group.
fn def_levels(out: &mut Vec<u8>, rows: usize, nulls: Option<&NullBuffer>) {
    let at = out.len();
    out.extend_from_slice(&[0; 4]);
    match nulls {
        Some(n) if n.null_count() < rows => {
            let bits = n.inner().sliced();
            for run in bits.as_slice()[..rows.div_ceil(8)].chunks(63) {
                out.push(((run.len() as u8) << 1) | 1);
                out.extend_from_slice(run);
            }
        }
        _ => {
            varint(out, (rows as u64) << 1);
            out.push(u8::from(nulls.is_none()));
        }
    }
    let len = (out.len() - at - 4) as u32;
    out[at..at + 4].copy_from_slice(&len.to_le_bytes());
}

/// The byte streams of `values` appended to `out`: byte k of value i at
/// `k·len + i` (`BYTE_STREAM_SPLIT`). Eight values at a time are transposed as an
/// 8 × 8 byte matrix in three rounds of block swaps.
fn split_streams(values: &[f64], out: &mut Vec<u8>) {
    let m = values.len();
    let base = out.len();
    out.resize(base + 8 * m, 0);
    let dst = &mut out[base..];
    let mut chunks = values.chunks_exact(8);
    let mut i = 0;
    for c in &mut chunks {
        let mut w = [0u64; 8];
        for (w, v) in w.iter_mut().zip(c) {
            *w = v.to_bits();
        }
        transpose8(&mut w);
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
    fn extend(&mut self, values: &[f64]) {
        // Eight running extremes, so the loop vectorises; a NaN never replaces one.
        let (mut lo, mut hi, mut nans) = ([f64::INFINITY; 8], [f64::NEG_INFINITY; 8], [0u64; 8]);
        let mut chunks = values.chunks_exact(8);
        for c in &mut chunks {
            for j in 0..8 {
                let v = c[j];
                lo[j] = if v < lo[j] { v } else { lo[j] };
                hi[j] = if v > hi[j] { v } else { hi[j] };
                nans[j] += u64::from(v.is_nan());
            }
        }
        for &v in chunks.remainder() {
            lo[0] = if v < lo[0] { v } else { lo[0] };
            hi[0] = if v > hi[0] { v } else { hi[0] };
            nans[0] += u64::from(v.is_nan());
        }
        let (lo, hi) = (lo.into_iter().fold(f64::INFINITY, f64::min), hi.into_iter().fold(f64::NEG_INFINITY, f64::max));
        if lo == 0.0 || hi == 0.0 {
            // Only zeros can tie: which signs are present decides the extremes.
            self.neg_zero |= values.iter().any(|v| v.to_bits() == (-0.0f64).to_bits());
            self.pos_zero |= values.iter().any(|v| v.to_bits() == 0);
        }
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
        self.count += values.len();
        self.nans += nans.iter().sum::<u64>();
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
}
