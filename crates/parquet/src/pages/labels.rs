//! Required string columns of few distinct values (`mode`, `status`): a dictionary
//! page and one run-length-encoded page of indices.

use parquet::basic::Encoding;
use parquet::column::writer::ColumnCloseResult;
use parquet::errors::ParquetError;
use parquet::file::metadata::ColumnChunkMetaData;
use parquet::file::statistics::{Statistics, ValueStatistics};
use parquet::schema::types::ColumnDescPtr;

use super::thrift::{RLE_DICTIONARY, dictionary_page_header, page_header, varint};

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
