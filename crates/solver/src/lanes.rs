//! Numbers that are one pose's value or a batch of [`LANES`] poses' values.
//!
//! The fast solver is written once, generic over [`Lane`]: with `f64` it solves one
//! pose, with [`F8`] eight poses at once, lane by lane, with no branch on the data
//! (pivot choices and statuses are masks). Every lane goes through the same IEEE
//! operations in the same order as the scalar instance, and the transcendental
//! functions are the same libm calls, so a pose's results are bit-identical whichever
//! batch it is solved in, and with or without SIMD (tested).

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

use clearance_kinematics::Elementary;
use nalgebra::Vector3;

/// Poses per batch: one AVX-512 register of `f64`, two of AVX2.
pub const LANES: usize = 8;

/// A per-lane condition.
pub trait Mask: Copy + BitAnd<Output = Self> + BitOr<Output = Self> + Not<Output = Self> {
    fn splat(b: bool) -> Self;
    /// Lane `i`.
    fn get(self, i: usize) -> bool;
}

impl Mask for bool {
    #[inline(always)]
    fn splat(b: bool) -> Self {
        b
    }
    #[inline(always)]
    fn get(self, _: usize) -> bool {
        self
    }
}

/// One value per lane.
pub trait Lane: Elementary {
    type M: Mask;
    /// Poses in one value: 1 for `f64`, [`LANES`] for a batch.
    const WIDTH: usize;
    fn abs(self) -> Self;
    /// `o` where `o > self`, else `self` (so NaN in `self` stays; unlike `f64::max`,
    /// whose choice between `0.0` and `-0.0` may differ between scalar and vector code).
    fn max(self, o: Self) -> Self;
    fn signum(self) -> Self;
    fn gt(self, o: Self) -> Self::M;
    fn le(self, o: Self) -> Self::M;
    fn eq(self, o: Self) -> Self::M;
    fn finite(self) -> Self::M;
    /// `a` where `m`, else `b`.
    fn select(m: Self::M, a: Self, b: Self) -> Self;
    /// Lane `i`.
    fn get(self, i: usize) -> f64;
    /// `f(i)` in lane `i` (for lanes computed one at a time).
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
}

impl Lane for f64 {
    type M = bool;
    const WIDTH: usize = 1;
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if o > self { o } else { self }
    }
    #[inline(always)]
    fn signum(self) -> Self {
        f64::signum(self)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn le(self, o: Self) -> bool {
        self <= o
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m { a } else { b }
    }
    #[inline(always)]
    fn get(self, _: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }
}

/// Eight poses' values of one quantity.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(64))]
pub struct F8(pub [f64; LANES]);

/// Eight lanes' conditions, all bits set for true (what vector compares produce).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(align(64))]
pub struct M8(pub [u64; LANES]);

#[inline(always)]
fn bits(b: bool) -> u64 {
    if b { u64::MAX } else { 0 }
}

/// `[f(0), …, f(LANES − 1)]` as a plain loop (see [`each3`]).
#[inline(always)]
fn lanes<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; LANES] {
    let mut out = [T::default(); LANES];
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(i);
    }
    out
}

macro_rules! lanewise {
    ($ty:ident, $trait:ident, $f:ident, $op:tt) => {
        impl $trait for $ty {
            type Output = $ty;
            #[inline(always)]
            fn $f(self, o: $ty) -> $ty {
                $ty(lanes(|i| self.0[i] $op o.0[i]))
            }
        }
    };
}

lanewise!(F8, Add, add, +);
lanewise!(F8, Sub, sub, -);
lanewise!(F8, Mul, mul, *);
lanewise!(F8, Div, div, /);
lanewise!(M8, BitAnd, bitand, &);
lanewise!(M8, BitOr, bitor, |);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        F8(lanes(|i| -self.0[i]))
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        M8(lanes(|i| !self.0[i]))
    }
}

impl Mask for M8 {
    #[inline(always)]
    fn splat(b: bool) -> Self {
        M8([bits(b); LANES])
    }
    #[inline(always)]
    fn get(self, i: usize) -> bool {
        self.0[i] != 0
    }
}

impl F8 {
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> F8 {
        F8(lanes(|i| f(self.0[i])))
    }

    #[inline(always)]
    fn test(self, o: F8, f: impl Fn(f64, f64) -> bool) -> M8 {
        M8(lanes(|i| bits(f(self.0[i], o.0[i]))))
    }
}

impl Elementary for F8 {
    #[inline(always)]
    fn constant(v: f64) -> Self {
        F8([v; LANES])
    }
    #[inline(always)]
    fn sin(self) -> Self {
        self.map(f64::sin)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        self.map(f64::cos)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (mut s, mut c) = ([0.0; LANES], [0.0; LANES]);
        for i in 0..LANES {
            (s[i], c[i]) = self.0[i].sin_cos();
        }
        (F8(s), F8(c))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        F8(lanes(|i| self.0[i].atan2(x.0[i])))
    }
    #[inline(always)]
    fn scale(self, k: f64) -> Self {
        self.map(|v| v * k)
    }
}

impl Lane for F8 {
    type M = M8;
    const WIDTH: usize = LANES;
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        F8::select(o.gt(self), o, self)
    }
    #[inline(always)]
    fn signum(self) -> Self {
        self.map(f64::signum)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> M8 {
        self.test(o, |a, b| a > b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> M8 {
        self.test(o, |a, b| a <= b)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> M8 {
        self.test(o, |a, b| a == b)
    }
    #[inline(always)]
    fn finite(self) -> M8 {
        M8(lanes(|i| bits(self.0[i].is_finite())))
    }
    #[inline(always)]
    fn select(m: M8, a: Self, b: Self) -> Self {
        // Bitwise, as a vector blend does it.
        F8(lanes(|i| f64::from_bits((a.0[i].to_bits() & m.0[i]) | (b.0[i].to_bits() & !m.0[i]))))
    }
    #[inline(always)]
    fn get(self, i: usize) -> f64 {
        self.0[i]
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self {
        F8(std::array::from_fn(f))
    }
}

/// `[f(0), f(1), f(2)]`, spelled out: `array::map` and `from_fn` on batches are not
/// always inlined into the vector entry points, and a call per use undoes the SIMD.
#[inline(always)]
pub fn each3<T>(mut f: impl FnMut(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// `[f(0), …, f(3)]` (see [`each3`]).
#[inline(always)]
pub fn each4<T>(mut f: impl FnMut(usize) -> T) -> [T; 4] {
    [f(0), f(1), f(2), f(3)]
}

/// `[f(0), …, f(5)]` (see [`each3`]).
#[inline(always)]
pub fn each6<T>(mut f: impl FnMut(usize) -> T) -> [T; 6] {
    [f(0), f(1), f(2), f(3), f(4), f(5)]
}

/// A 3-vector of lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

impl<L: Lane> V3<L> {
    #[inline(always)]
    pub fn new(x: L, y: L, z: L) -> Self {
        Self { x, y, z }
    }
    #[inline(always)]
    pub fn from_array(v: [L; 3]) -> Self {
        Self::new(v[0], v[1], v[2])
    }
    /// The same vector in every lane (for `f64`, the vector itself).
    #[inline(always)]
    pub fn splat(v: &Vector3<f64>) -> Self {
        Self::new(L::constant(v.x), L::constant(v.y), L::constant(v.z))
    }
    #[inline(always)]
    pub fn zero() -> Self {
        Self::splat(&Vector3::zeros())
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> L {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(self.y * o.z - self.z * o.y, self.z * o.x - self.x * o.z, self.x * o.y - self.y * o.x)
    }
    #[inline(always)]
    pub fn norm(self) -> L {
        self.dot(self).sqrt()
    }
    /// `k·self`.
    #[inline(always)]
    pub fn times(self, k: L) -> Self {
        Self::new(k * self.x, k * self.y, k * self.z)
    }
    #[inline(always)]
    pub fn scale(self, k: f64) -> Self {
        Self::new(self.x.scale(k), self.y.scale(k), self.z.scale(k))
    }
    #[inline(always)]
    pub fn select(m: L::M, a: Self, b: Self) -> Self {
        Self::new(L::select(m, a.x, b.x), L::select(m, a.y, b.y), L::select(m, a.z, b.z))
    }
    /// Lane `i`.
    #[inline(always)]
    pub fn get(self, i: usize) -> Vector3<f64> {
        Vector3::new(self.x.get(i), self.y.get(i), self.z.get(i))
    }
}

/// Lane `i` of three values (by reference and spelled out: `array::map` would copy
/// the whole batch for every lane).
#[inline(always)]
pub fn lane3<L: Lane>(a: &[L; 3], i: usize) -> [f64; 3] {
    [a[0].get(i), a[1].get(i), a[2].get(i)]
}

/// Lane `i` of three vectors.
#[inline(always)]
pub fn lane3v<L: Lane>(a: &[V3<L>; 3], i: usize) -> [Vector3<f64>; 3] {
    [a[0].get(i), a[1].get(i), a[2].get(i)]
}

impl<L: Lane> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<L: Lane> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<L: Lane> Neg for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lane of an `F8` operation equals the `f64` operation on that lane,
    /// bit for bit, on ordinary, signed-zero, infinite and NaN inputs.
    #[test]
    fn f8_is_f64_lane_by_lane() {
        let a = [1.5, -0.0, 0.0, f64::INFINITY, f64::NAN, -3.25, 1e-300, 7.0];
        let b = [0.5, 0.0, -2.0, 1.0, 2.0, f64::NAN, -1e300, 7.0];
        let (fa, fb) = (F8(a), F8(b));
        // Bit for bit; a NaN's payload is left to the hardware (and the constant folder).
        let same = |x: F8, f: &dyn Fn(f64, f64) -> f64| {
            for i in 0..LANES {
                let (got, want) = (x.0[i], f(a[i], b[i]));
                assert!(
                    got.to_bits() == want.to_bits() || got.is_nan() && want.is_nan(),
                    "lane {i}: {got} against {want}"
                );
            }
        };
        same(fa + fb, &|x, y| x + y);
        same(fa - fb, &|x, y| x - y);
        same(fa * fb, &|x, y| x * y);
        same(fa / fb, &|x, y| x / y);
        same(-fa, &|x, _| -x);
        same(Lane::max(fa, fb), &|x, y| if y > x { y } else { x });
        same(Lane::abs(fa), &|x, _| x.abs());
        same(Lane::signum(fa), &|x, _| x.signum());
        same(Elementary::sqrt(fa), &|x, _| x.sqrt());
        same(Elementary::atan2(fa, fb), &|x, y| x.atan2(y));
        let (s, c) = Elementary::sin_cos(fa);
        same(s, &|x, _| x.sin());
        same(c, &|x, _| x.cos());
        let m = fa.gt(fb) | fa.eq(fb);
        same(F8::select(m, fa, fb), &|x, y| if x >= y { x } else { y });
        let m = !fa.le(fb) & fa.finite();
        let not_le =
            |x: f64, y: f64| !matches!(x.partial_cmp(&y), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal));
        same(F8::select(m, fa, fb), &|x, y| if not_le(x, y) && x.is_finite() { x } else { y });
    }
}
