//! Definition levels of flat optional columns (data page v1).

use super::thrift::varint;

/// The definition levels of a page, with their 4-byte length in front (data page
/// v1): one RLE run when every row has a value or none has, else the validity bits
/// as bit-packed runs of at most 63 groups of 8 (so every run header is one byte,
/// as some readers expect). Bits past the page's rows pad the last group.
pub(super) fn def_levels(out: &mut Vec<u8>, rows: usize, valid: Option<&[u8]>, present: usize) {
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
