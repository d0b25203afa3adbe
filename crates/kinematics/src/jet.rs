//! Second-order forward-mode automatic differentiation.
//!
//! A [`Jet`] carries a value and its first two time derivatives. Propagating the
//! trajectory inputs `(Z, Ψ, Θ)` and their analytic rates through the same closed
//! forms as the positions gives exact velocities and accelerations (docs/model.md §2
//! forbids finite differences), with no second hand-derived formula to keep in sync.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// The elementwise operations the closed forms need; implemented by `f64`, [`Jet`]
/// and the solver's batches of poses (one value per lane).
pub trait Elementary:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    fn constant(v: f64) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    /// `(sin, cos)`, the same values as the two calls.
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    fn sqrt(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn scale(self, k: f64) -> Self;
}

/// A single value: `f64` or [`Jet`] (the nominal value of a jet).
pub trait Real: Elementary {
    fn value(self) -> f64;
}

impl Real for f64 {
    #[inline(always)]
    fn value(self) -> f64 {
        self
    }
}

impl Elementary for f64 {
    #[inline(always)]
    fn constant(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn scale(self, k: f64) -> Self {
        self * k
    }
}

/// `v(t)` with `d = dv/dt` and `dd = d²v/dt²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jet {
    pub v: f64,
    pub d: f64,
    pub dd: f64,
}

impl Jet {
    pub const fn new(v: f64, d: f64, dd: f64) -> Self {
        Self { v, d, dd }
    }

    /// From `[value, rate, acceleration]`.
    pub const fn from_array(a: [f64; 3]) -> Self {
        Self { v: a[0], d: a[1], dd: a[2] }
    }
}

impl Add for Jet {
    type Output = Jet;
    #[inline(always)]
    fn add(self, o: Jet) -> Jet {
        Jet::new(self.v + o.v, self.d + o.d, self.dd + o.dd)
    }
}

impl Sub for Jet {
    type Output = Jet;
    #[inline(always)]
    fn sub(self, o: Jet) -> Jet {
        Jet::new(self.v - o.v, self.d - o.d, self.dd - o.dd)
    }
}

impl Neg for Jet {
    type Output = Jet;
    #[inline(always)]
    fn neg(self) -> Jet {
        Jet::new(-self.v, -self.d, -self.dd)
    }
}

impl Mul for Jet {
    type Output = Jet;
    #[inline(always)]
    fn mul(self, o: Jet) -> Jet {
        Jet::new(self.v * o.v, self.d * o.v + self.v * o.d, self.dd * o.v + 2.0 * self.d * o.d + self.v * o.dd)
    }
}

impl Div for Jet {
    type Output = Jet;
    #[inline(always)]
    fn div(self, o: Jet) -> Jet {
        let q = self.v / o.v;
        let qd = (self.d - q * o.d) / o.v;
        let qdd = (self.dd - 2.0 * qd * o.d - q * o.dd) / o.v;
        Jet::new(q, qd, qdd)
    }
}

impl Real for Jet {
    #[inline(always)]
    fn value(self) -> f64 {
        self.v
    }
}

impl Elementary for Jet {
    #[inline(always)]
    fn constant(v: f64) -> Self {
        Jet::new(v, 0.0, 0.0)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        Jet::new(s, c * self.d, -s * self.d * self.d + c * self.dd)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        Jet::new(c, -s * self.d, -c * self.d * self.d - s * self.dd)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        let d = self.d / (2.0 * r);
        // d/dt (v'/(2r)) = v''/(2r) − v'·r'/(2r²)
        let dd = self.dd / (2.0 * r) - self.d * d / (2.0 * r * r);
        Jet::new(r, d, dd)
    }
    #[inline(always)]
    fn atan2(self, x: Self) -> Self {
        let y = self;
        let den = x.v * x.v + y.v * y.v;
        let num = x.v * y.d - y.v * x.d;
        let num_d = x.v * y.dd - y.v * x.dd;
        let den_d = 2.0 * (x.v * x.d + y.v * y.d);
        Jet::new(y.v.atan2(x.v), num / den, (num_d * den - num * den_d) / (den * den))
    }
    #[inline(always)]
    fn scale(self, k: f64) -> Self {
        Jet::new(self.v * k, self.d * k, self.dd * k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Derivatives of a composite expression against central differences of the value.
    #[test]
    fn jet_matches_finite_differences() {
        let f = |t: Jet| -> Jet {
            let a = t.sin() * t.cos().scale(0.7) + (t * t + Jet::constant(2.0)).sqrt();
            let b = (t.scale(0.3) + Jet::constant(0.1)).atan2(t.cos() + Jet::constant(1.5));
            a / (b + Jet::constant(3.0)) - t.sin().cos()
        };
        for &t0 in &[-1.3, -0.2, 0.0, 0.4, 2.1] {
            let j = f(Jet::new(t0, 1.0, 0.0));
            let h = 1e-4;
            let v = |t: f64| f(Jet::constant(t)).v;
            let d_fd = (v(t0 + h) - v(t0 - h)) / (2.0 * h);
            let dd_fd = (v(t0 + h) - 2.0 * v(t0) + v(t0 - h)) / (h * h);
            assert!((j.d - d_fd).abs() < 1e-7, "first derivative at {t0}: {} vs {}", j.d, d_fd);
            assert!((j.dd - dd_fd).abs() < 1e-5, "second derivative at {t0}: {} vs {}", j.dd, dd_fd);
        }
    }
}
