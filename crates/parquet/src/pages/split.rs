//! `BYTE_STREAM_SPLIT` of doubles: byte k of every value in stream k.

#[cfg(target_arch = "x86_64")]
use clearance_solver::Isa;

/// The byte streams of `values` written to `dst` (`8·values.len()` bytes, every one
/// of them written): byte k of value i at `k·len + i` (`BYTE_STREAM_SPLIT`). Eight
/// values at a time are transposed as an 8 × 8 byte matrix: by one byte permutation
/// where the CPU has AVX-512 VBMI and the kernel's choice (`Isa::best`, capped by
/// `cap_isa`) is AVX-512, else in three rounds of block swaps (23 instructions a
/// value, callgrind).
pub(super) fn split_streams_into(values: &[f64], dst: &mut [u8]) {
    assert_eq!(dst.len(), 8 * values.len(), "eight bytes a value");
    #[cfg(target_arch = "x86_64")]
    if Isa::best() == Isa::Avx512 && std::arch::is_x86_feature_detected!("avx512vbmi") {
        // SAFETY: the CPU has AVX-512 F (`Isa::best`) and VBMI.
        return unsafe { split_streams_vbmi(values, dst) };
    }
    split_into(values, dst, transpose8);
}

/// [`split_streams_into`]'s work, eight values at a time transposed by `transpose`
/// ([`transpose8`]'s contract).
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

/// [`split_streams_into`] with the 8 × 8 transposition as one `vpermb`.
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

#[cfg(test)]
mod tests {
    use super::*;

    /// [`split_streams_into`] appended to `out`.
    fn split_streams(values: &[f64], out: &mut Vec<u8>) {
        let base = out.len();
        out.resize(base + 8 * values.len(), 0);
        split_streams_into(values, &mut out[base..]);
    }

    #[test]
    fn transposed_streams_match_the_definition() {
        // The portable transposition, whatever `split_streams_into` chose on this CPU.
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
}
