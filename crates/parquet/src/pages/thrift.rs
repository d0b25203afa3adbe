//! Page headers in the Thrift compact protocol (parquet.thrift), written by hand:
//! a few bytes a page, where a generic encoder costs more than the page's values.

/// Thrift encoding numbers (parquet.thrift).
pub(super) const PLAIN: i32 = 0;
const RLE: i32 = 3;
pub(super) const BYTE_STREAM_SPLIT: i32 = 9;
pub(super) const RLE_DICTIONARY: i32 = 8;

pub(super) fn varint(out: &mut Vec<u8>, mut v: u64) {
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
pub(super) fn dictionary_page_header(out: &mut Vec<u8>, size: usize, entries: usize) {
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
pub(super) fn page_header(out: &mut Vec<u8>, uncompressed: usize, compressed: usize, rows: usize, encoding: i32) {
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
