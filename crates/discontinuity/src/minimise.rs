//! One-dimensional root and minimum refinement.

/// Bisection of a sign change of `f` in `[a, b]` (`f(a)` and `f(b)` of opposite
/// signs) until the bracket is at most `tol` wide; returns its midpoint. The
/// yardstick that [`brent_root`] is tested against.
#[cfg(test)]
fn bisect(mut a: f64, mut b: f64, fa: f64, tol: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
    let mut sa = fa.signum();
    while (b - a).abs() > tol {
        let m = 0.5 * (a + b);
        let fm = f(m);
        if fm == 0.0 {
            return m;
        }
        if fm.signum() == sa {
            a = m;
            sa = fm.signum();
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Brent's root finder (inverse quadratic interpolation, secant and bisection
/// steps) on a sign change of `f` in `[a, b]`, `fa = f(a)` and `fb = f(b)` of
/// opposite signs. Returns a point within `tol` of the root's bracket, in a handful
/// of evaluations on a smooth `f` where bisection takes twenty.
pub fn brent_root(a: f64, b: f64, fa: f64, fb: f64, tol: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
    let (mut a, mut b, mut fa, mut fb) = (a, b, fa, fb);
    if fa == 0.0 {
        return a;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) {
            (c, fc) = (a, fa);
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            (a, fa) = (b, fb);
            (b, fb) = (c, fc);
            (c, fc) = (a, fa);
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q) = if a == c {
                (2.0 * xm * s, 1.0 - s)
            } else {
                let (qa, r) = (fa / fc, fb / fc);
                (s * (2.0 * xm * qa * (qa - r) - (b - a) * (r - 1.0)), (qa - 1.0) * (r - 1.0) * (s - 1.0))
            };
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        (a, fa) = (b, fb);
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
    }
    b
}

/// Brent's bounded minimisation of `f` on `[a, b]` (golden section with parabolic
/// steps), to an absolute tolerance `xtol` in x. Returns `(x, f(x))`.
pub fn brent_min(a: f64, b: f64, xtol: f64, f: impl FnMut(f64) -> f64) -> (f64, f64) {
    brent_min_below(a, b, xtol, f64::NEG_INFINITY, f)
}

/// [`brent_min`] that stops at the first point where `f` is below `enough`: a
/// search for a value of the other sign needs one, not the extremum.
pub(crate) fn brent_min_below(a: f64, b: f64, xtol: f64, enough: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    const GOLDEN: f64 = 0.381_966_011_250_105_1; // (3 − √5)/2
    let (mut a, mut b) = if a < b { (a, b) } else { (b, a) };
    let mut x = a + GOLDEN * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    if fx < enough {
        return (x, fx);
    }
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        let tol1 = 1e-12 * x.abs() + xtol / 3.0;
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // Parabola through (v, fv), (w, fw), (x, fx).
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let e_old = e;
            e = d;
            if p.abs() < (0.5 * q * e_old).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if m >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= m { a - x } else { b - x };
            d = GOLDEN * e;
        }
        let u = if d.abs() >= tol1 { x + d } else { x + tol1.copysign(d) };
        let fu = f(u);
        if fu < enough {
            return (u, fu);
        }
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bisection_finds_the_root() {
        let r = bisect(0.0, 2.0, -1.0, 1e-12, |x| x * x - 2.0);
        assert!((r - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn brent_root_matches_bisection_in_fewer_steps() {
        for (a, b) in [(0.0, 2.0), (2.0, 0.0), (1.0, 1.5)] {
            let f = |x: f64| x * x - 2.0;
            let mut calls = 0;
            let r = brent_root(a, b, f(a), f(b), 1e-12, |x| {
                calls += 1;
                f(x)
            });
            assert!((r - 2f64.sqrt()).abs() < 1e-12, "{r}");
            let mut bisections = 0;
            bisect(a.min(b), a.max(b), f(a.min(b)), 1e-12, |x| {
                bisections += 1;
                f(x)
            });
            assert!(calls < bisections / 2, "{calls} vs {bisections}");
        }
        // A step (an unsolvable stretch reads 0): the root is where f is 0.
        let r = brent_root(0.0, 1.0, -1.0, 1.0, 1e-9, |x| if x < 0.3 { -1.0 } else { 0.0 });
        assert!((0.3..0.3 + 1e-9).contains(&r) || r >= 0.3, "{r}");
    }

    #[test]
    fn brent_finds_smooth_and_kinked_minima() {
        let (x, _) = brent_min(0.0, 3.0, 1e-10, |x| (x - 1.234_567).powi(2) + 0.5);
        assert!((x - 1.234_567).abs() < 1e-9);
        // A load vector passing near zero: |f| has a sharp V.
        let (x, fx) = brent_min(-1.0, 1.0, 1e-10, |x| ((x - 0.3141).powi(2) + 1e-14).sqrt());
        assert!((x - 0.3141).abs() < 1e-9 && fx < 1e-6, "{x} {fx}");
    }
}
