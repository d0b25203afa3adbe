//! Chunk statistics of double columns: minimum and maximum in IEEE 754 total
//! order, and the NaN count.

#[cfg(target_arch = "x86_64")]
use clearance_solver::Isa;

/// Minimum and maximum in IEEE 754 total order (−0 below +0), and the NaN count.
/// Compared as doubles (which vectorises, where 64-bit integer comparisons do not
/// before SSE 4.2); a zero extreme then takes its sign from the values.
#[derive(Clone, Copy, Debug)]
pub(super) struct Range {
    pub(super) lo: f64,
    pub(super) hi: f64,
    /// Valid values seen, NaN included.
    count: usize,
    pub(super) nans: u64,
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
    pub(super) fn extend(&mut self, values: &[f64]) {
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
    pub(super) fn merge(&mut self, other: &Range) {
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
    pub(super) fn bounds(self) -> (Option<f64>, Option<f64>) {
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

#[cfg(test)]
mod tests {
    use super::*;

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
