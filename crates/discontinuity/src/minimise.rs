//! One-dimensional root and minimum refinement.

use crate::{dot, norm};

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

/// A sign change of a smooth `f` in `[a, b]` (`fa = f(a)` and `fb = f(b)` of
/// opposite signs), by interpolation steps from the bracket: regula falsi first,
/// then inverse quadratic interpolation through the three latest points. It stops
/// at an evaluated point once the next step would move less than a twentieth of
/// `tol` (the step approximates the point's distance to the root, the steps
/// converging superlinearly), in three or four evaluations on an interval of a
/// grid where [`brent_root`], which stops only on a bracket `tol` wide, takes six
/// to eight. A step that would leave the bracket hands the bracket so far to
/// [`brent_root`], as does a tenth step; a point where `f` is zero is returned as
/// it is met (where an unsolvable stretch reads zero, a point of it, as with Brent).
pub fn interpolated_root(a: f64, b: f64, fa: f64, fb: f64, tol: f64, f: impl FnMut(f64) -> f64) -> f64 {
    interpolated_root_from(a, b, fa, fb, None, tol, f)
}

/// [`interpolated_root`] whose first step goes to `guess` (where it lies inside the
/// bracket) rather than regula falsi's point: a root read off more samples than the
/// bracket's two ([`inverse_interpolation`]) is often within `tol` already, and the
/// next step, which would move less than a twentieth of it, then ends the search
/// after one evaluation.
pub(crate) fn interpolated_root_from(
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
    guess: Option<f64>,
    tol: f64,
    mut f: impl FnMut(f64) -> f64,
) -> f64 {
    if fa == 0.0 {
        return a;
    }
    let (mut lo, mut hi, mut flo, mut fhi) = if a < b { (a, b, fa, fb) } else { (b, a, fb, fa) };
    // The latest points, newest last.
    let mut points = [(a, fa), (a, fa), (b, fb)];
    let mut last: Option<f64> = None;
    for step in 0..10 {
        let x = if step == 0 {
            guess.filter(|g| *g > lo && *g < hi).unwrap_or(lo - flo * (hi - lo) / (fhi - flo))
        } else {
            inverse_lagrange(&points)
        };
        if !(x > lo && x < hi) {
            break;
        }
        if let Some(last) = last
            && (x - last).abs() <= 0.05 * tol
        {
            return last;
        }
        let fx = f(x);
        if fx == 0.0 {
            return x;
        }
        if (fx < 0.0) == (flo < 0.0) {
            (lo, flo) = (x, fx);
        } else {
            (hi, fhi) = (x, fx);
        }
        points = [points[1], points[2], (x, fx)];
        last = Some(x);
    }
    brent_root(lo, hi, flo, fhi, tol, f)
}

/// [`brent_min_below`] started from values in hand (`known`, `(x, f(x))`, finite,
/// inside or beside `[lo, hi]`): successive parabolic interpolation through the
/// three lowest points, each step to the vertex, until a value is below `enough`
/// (returned at once) or the vertex comes within `xtol` of a point already
/// evaluated (the least value inside `[lo, hi]` is returned); a vertex beyond an
/// end is looked for just inside it. Three to five evaluations where Brent's
/// method, which stops on a bracket `2·xtol` wide, takes up to twenty; Brent takes
/// over where the parabola opens downwards or eight steps do not settle.
pub(crate) fn parabolic_min_below(
    known: &[(f64, f64)],
    lo: f64,
    hi: f64,
    xtol: f64,
    enough: f64,
    mut f: impl FnMut(f64) -> f64,
) -> (f64, f64) {
    const STEPS: usize = 8;
    const HELD: usize = 16;
    let mut points = [(0.0, 0.0); HELD];
    let mut n = 0;
    for &(x, y) in known.iter().filter(|(x, y)| x.is_finite() && y.is_finite()).take(HELD - STEPS) {
        points[n] = (x, y);
        n += 1;
    }
    for _ in 0..STEPS {
        let held = &mut points[..n];
        held.sort_by(|p, q| p.1.total_cmp(&q.1));
        let [(x0, y0), (x1, y1), (x2, y2)] = match *held {
            [a, b, c, ..] if a.0 != b.0 && a.0 != c.0 && b.0 != c.0 => [a, b, c],
            _ => break,
        };
        let d01 = (y1 - y0) / (x1 - x0);
        let d012 = ((y2 - y1) / (x2 - x1) - d01) / (x2 - x0);
        if d012.is_nan() || d012 <= 0.0 {
            break;
        }
        // A vertex beyond an end: the least value is at that end, as far as the
        // parabola tells; looked at just inside it.
        let vertex = (0.5 * (x0 + x1) - d01 / (2.0 * d012)).clamp(lo + xtol, hi - xtol);
        if !(vertex > lo && vertex < hi) {
            break;
        }
        if held.iter().any(|(x, _)| (x - vertex).abs() <= xtol) {
            let inside = held.iter().filter(|(x, _)| *x >= lo && *x <= hi);
            if let Some(&best) = inside.min_by(|p, q| p.1.total_cmp(&q.1)) {
                return best;
            }
            break;
        }
        let y = f(vertex);
        if y < enough {
            return (vertex, y);
        }
        points[n] = (vertex, y);
        n += 1;
    }
    brent_min_below(lo, hi, xtol, enough, f)
}

/// Where the function through `points` (`(x, f(x))`, three or four, in order of
/// `x`) is zero, by interpolating `x` as a polynomial in `f`: the root to the order
/// of the samples' spacing to the fourth power (four points). `None` where `f` is
/// not strictly monotone over the points (the inverse is then no function) or the
/// result is not finite.
pub(crate) fn inverse_interpolation(points: &[(f64, f64)]) -> Option<f64> {
    let rising = points.windows(2).all(|w| w[1].1 > w[0].1);
    let falling = points.windows(2).all(|w| w[1].1 < w[0].1);
    if !(rising || falling) {
        return None;
    }
    let x = inverse_lagrange(points);
    x.is_finite().then_some(x)
}

/// The `x` at which the polynomial in `f` through `points` (`(x, f(x))`) gives
/// `f = 0`, in Lagrange's form: `Σᵢ xᵢ·Πₖ (−fₖ) / Πₖ (fᵢ − fₖ)` over `k ≠ i`. Inverse
/// quadratic interpolation through three points, and its first step from four.
fn inverse_lagrange(points: &[(f64, f64)]) -> f64 {
    let term = |i: usize| {
        let (xi, fi) = points[i];
        let (mut num, mut den) = (xi, 1.0);
        for (k, &(_, fk)) in points.iter().enumerate() {
            if k != i {
                num *= -fk;
                den *= fi - fk;
            }
        }
        num / den
    };
    (1..points.len()).fold(term(0), |x, i| x + term(i))
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

/// The steps [`vector_min`] takes before it gives up (its caller then minimises the
/// magnitude alone).
const VECTOR_STEPS: usize = 24;

/// Values of a load that agree to this, relative to the largest of them, are one
/// value to round-off (a load that does not change along the path: the legs of a
/// mechanism that an actuated translation carries unchanged).
pub(crate) const FLAT: f64 = 1e-12;

/// The minimum of `|f|` on `[a, b]` for a smooth vector `f`, from its values at the
/// two ends and at a third point (inside or beyond the interval): each step fits
/// the quadratic through three values, component by component, and evaluates `f`
/// where the model's magnitude is least on `[a, b]`, in place of the value farthest
/// from there. It stops when the model's minimum lies within `xtol` of a point
/// where `f` was evaluated (or given), and returns that point and `f` there: an end
/// where `|f|` falls all the way to it. The steps converge like Müller's method (order
/// about 1.8); while the model still leans on distant values, its slope, and so
/// the point, is good to the model's error only: [`vector_polish`] takes it from
/// there. Where the model puts the minimum at an end before `f` was evaluated
/// inside, the middle of `[a, b]` is evaluated first, so that a dip the three
/// values do not show is looked for there too. Where the three values, one of them
/// inside, are one value to round-off (to 1e-12 of their size), `f` is flat there and has no
/// minimum to locate: the least of the points on `[a, b]` is returned (the model's
/// minimum would wander with the round-off, never settling). `None` where `f` has no
/// value (an unsolvable pose) or the steps do not settle; the caller then falls back
/// to [`brent_min`].
pub fn vector_min(
    a: (f64, [f64; 3]),
    b: (f64, [f64; 3]),
    third: (f64, [f64; 3]),
    xtol: f64,
    mut f: impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<(f64, [f64; 3])> {
    let (lo, hi) = if a.0 < b.0 { (a.0, b.0) } else { (b.0, a.0) };
    let mut points = [a, b, third];
    let mut looked_inside = lo < third.0 && third.0 < hi;
    for _ in 0..VECTOR_STEPS {
        if looked_inside && flat(&points) {
            return points
                .iter()
                .filter(|p| (lo..=hi).contains(&p.0))
                .min_by(|p, q| norm(p.1).total_cmp(&norm(q.1)))
                .copied();
        }
        let mut s = model_min(&points, lo, hi)?;
        if let Some(p) = points.iter().find(|p| (lo..=hi).contains(&p.0) && (p.0 - s).abs() <= xtol) {
            if looked_inside {
                return Some(*p);
            }
            s = 0.5 * (lo + hi);
        }
        looked_inside |= s > lo && s < hi;
        let fs = f(s)?;
        replace_farthest(&mut points, (s, fs));
    }
    None
}

/// Whether three values of a load are one value to round-off ([`FLAT`]).
fn flat(points: &[(f64, [f64; 3]); 3]) -> bool {
    let scale = points.iter().map(|p| norm(p.1)).fold(0.0, f64::max);
    points.iter().all(|p| (0..3).all(|i| (p.1[i] - points[0].1[i]).abs() <= FLAT * scale))
}

/// The minimum of `|f|` near `p` (where `f` is `fp`), within `[lo, hi]`: the
/// minimum of the quadratic through the values at `p − width`, `p` and `p + width`,
/// recentred there while it moves by more than an eighth of `width` (at most 24
/// times). The stencil may reach beyond `[lo, hi]`, and keeps its width: values
/// closer together would give the model's slope from their round-off. With the model's
/// slope from values `width` apart, the point is good to about `ε·|f|/(width·|f'|)`
/// (plus the model's truncation, of order `width²`), where a minimiser of `|f|²`
/// alone is resolved to about `√ε` of the dip's width. Two evaluations a step;
/// `None` where `f` has no value (an unsolvable pose) or the model's minimum is
/// at an end of `[lo, hi]` or of the stencil.
///
/// Returns the point and the model's value there, which is `f`'s to the model's
/// error (`|f'''|·width³/6` at most inside the stencil's middle quarter: below the
/// round-off of `f` for the loads and widths of the search), so that the point
/// needs no evaluation of its own.
pub fn vector_polish(
    p: f64,
    fp: [f64; 3],
    width: f64,
    (lo, hi): (f64, f64),
    mut f: impl FnMut(f64) -> Option<[f64; 3]>,
) -> Option<(f64, [f64; 3])> {
    let (mut p, mut fp) = (p, fp);
    for step in 0..VECTOR_STEPS {
        let (a, b) = (p - width, p + width);
        let stencil = [(a, f(a)?), (p, fp), (b, f(b)?)];
        let s = model_min(&stencil, a.max(lo), b.min(hi))?;
        if s <= a.max(lo) || s >= b.min(hi) {
            return None;
        }
        if (s - p).abs() <= 0.125 * width {
            return Some((s, model_at(&stencil, s)));
        }
        if step + 1 == VECTOR_STEPS {
            return Some((s, f(s)?));
        }
        (p, fp) = (s, f(s)?);
    }
    None
}

/// The value at `s` of the quadratic through three vector values.
fn model_at(points: &[(f64, [f64; 3]); 3], s: f64) -> [f64; 3] {
    let [(s0, f0), (s1, _), _] = *points;
    let (d01, d012) = divided_differences(points);
    std::array::from_fn(|i| f0[i] + (s - s0) * (d01[i] + (s - s1) * d012[i]))
}

/// The first and second divided differences of three vector values: the quadratic
/// through them is `f0 + (s − s0)·(d01 + (s − s1)·d012)`.
fn divided_differences(points: &[(f64, [f64; 3]); 3]) -> ([f64; 3], [f64; 3]) {
    let [(s0, f0), (s1, f1), (s2, f2)] = *points;
    let d01: [f64; 3] = std::array::from_fn(|i| (f1[i] - f0[i]) / (s1 - s0));
    let d12: [f64; 3] = std::array::from_fn(|i| (f2[i] - f1[i]) / (s2 - s1));
    (d01, std::array::from_fn(|i| (d12[i] - d01[i]) / (s2 - s0)))
}

fn replace_farthest(points: &mut [(f64, [f64; 3]); 3], new: (f64, [f64; 3])) {
    let far = (0..3).max_by(|&i, &j| (points[i].0 - new.0).abs().total_cmp(&(points[j].0 - new.0).abs()));
    points[far.expect("three points")] = new;
}

/// Where on `[lo, hi]` the magnitude of the quadratic through three vector values
/// is least; `None` where two of the points coincide or the model is not finite.
fn model_min(points: &[(f64, [f64; 3]); 3], lo: f64, hi: f64) -> Option<f64> {
    let [(s0, f0), (s1, _), (s2, _)] = *points;
    let (h1, h2, h12) = (s1 - s0, s2 - s0, s2 - s1);
    if h1 == 0.0 || h2 == 0.0 || h12 == 0.0 {
        return None;
    }
    // Newton's form in u = s − s0, then powers: q(u) = A + B·u + C·u².
    let (d01, c) = divided_differences(points);
    let bv: [f64; 3] = std::array::from_fn(|i| d01[i] - c[i] * h1);
    // ½·d|q|²/du = g0 + g1·u + g2·u² + g3·u³.
    let g = [dot(f0, bv), dot(bv, bv) + 2.0 * dot(f0, c), 3.0 * dot(bv, c), 2.0 * dot(c, c)];
    if !g.iter().all(|x| x.is_finite()) {
        return None;
    }
    let slope = |u: f64| g[0] + u * (g[1] + u * (g[2] + u * g[3]));
    let value = |u: f64| {
        let q: [f64; 3] = std::array::from_fn(|i| f0[i] + u * (bv[i] + u * c[i]));
        dot(q, q)
    };
    let (ulo, uhi) = (lo - s0, hi - s0);
    // The slope is monotone between the roots of its derivative g1 + 2·g2·u + 3·g3·u².
    let mut cuts = [ulo, uhi, uhi, uhi];
    let mut n = 1;
    let (qa, qb, qc) = (3.0 * g[3], 2.0 * g[2], g[1]);
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            let r = -0.5 * (qb + disc.sqrt().copysign(qb));
            let (x, y) = (r / qa, if r != 0.0 { qc / r } else { r / qa });
            for u in [x.min(y), x.max(y)] {
                if u > ulo && u < uhi {
                    cuts[n] = u;
                    n += 1;
                }
            }
        }
    } else if qb != 0.0 {
        let u = -qc / qb;
        if u > ulo && u < uhi {
            cuts[n] = u;
            n += 1;
        }
    }
    cuts[n] = uhi;
    let curvature = |u: f64| g[1] + u * (2.0 * g[2] + u * 3.0 * g[3]);
    let mut best = if value(ulo) <= value(uhi) { ulo } else { uhi };
    for w in cuts[..=n].windows(2) {
        let (mut x, mut y) = (w[0], w[1]);
        // A minimum where the slope rises through zero: Newton's steps on the slope,
        // kept inside the bracket (a bisection where a step would leave it).
        if !(slope(x) < 0.0 && slope(y) > 0.0) {
            continue;
        }
        let mut u = 0.5 * (x + y);
        for _ in 0..100 {
            let gu = slope(u);
            if gu == 0.0 {
                break;
            }
            if gu < 0.0 {
                x = u;
            } else {
                y = u;
            }
            let newton = u - gu / curvature(u);
            let next = if newton > x && newton < y { newton } else { 0.5 * (x + y) };
            if next == u || (next - u).abs() <= 4.0 * f64::EPSILON * u.abs().max(y - x) {
                u = next;
                break;
            }
            u = next;
        }
        if value(u) < value(best) {
            best = u;
        }
    }
    Some((s0 + best).clamp(lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn norm2(v: [f64; 3]) -> f64 {
        dot(v, v)
    }

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

    /// `f(s) = (s − s*, 0.3·(s − s*)² + 1e-9, cos s − cos s*)`: a load through (nearly)
    /// zero whose magnitude is a V; the minimum of `|f|²`, by bisection of its exact
    /// derivative, is the yardstick.
    #[test]
    fn vector_min_and_polish_locate_a_load_through_zero() {
        let star = 0.412_345_678_9;
        let f = |s: f64| [s - star, 0.3 * (s - star).powi(2) + 1e-9, s.cos() - star.cos()];
        let df = |s: f64| [1.0, 0.6 * (s - star), -s.sin()];
        let slope = |s: f64| {
            let (v, d) = (f(s), df(s));
            v[0] * d[0] + v[1] * d[1] + v[2] * d[2]
        };
        let exact = bisect(0.3, 0.5, slope(0.3), 1e-15, slope);
        let (a, b, c) = (0.4, 0.42, 0.44);
        let mut calls = 0;
        let (p, fp) = vector_min((a, f(a)), (b, f(b)), (c, f(c)), 1e-4 * (b - a), |s| {
            calls += 1;
            Some(f(s))
        })
        .expect("settles");
        assert!((p - exact).abs() < 1e-4 * (b - a), "{p} {exact}");
        assert_eq!(fp, f(p));
        let (polished, there) = vector_polish(p, f(p), 1e-5, (a, b), |s| {
            calls += 1;
            Some(f(s))
        })
        .expect("settles");
        assert!((polished - exact).abs() < 1e-13, "{polished} {exact}");
        // The model's value is the load's to its round-off.
        let load = f(polished);
        assert!((0..3).all(|i| (there[i] - load[i]).abs() <= 1e-13 * norm2(f(a)).sqrt()), "{there:?} {load:?}");
        let mut brent_calls = 0;
        brent_min(a, b, 1e-4 * (b - a), |s| {
            brent_calls += 1;
            norm2(f(s))
        });
        assert!(calls * 2 < brent_calls, "{calls} evaluations against Brent's {brent_calls}");
    }

    /// A magnitude falling all the way to an end gives that end, exactly; a dip the
    /// three values do not show (a narrow one in the middle) is found by the look
    /// inside the interval.
    #[test]
    fn vector_min_gives_an_end_or_a_hidden_dip() {
        let f = |s: f64| [1.0 + s, 0.01, 0.0];
        let (p, fp) = vector_min((0.0, f(0.0)), (1.0, f(1.0)), (2.0, f(2.0)), 1e-4, |s| Some(f(s))).expect("settles");
        assert_eq!((p, fp), (0.0, f(0.0)));
        let g = |s: f64| [1.0 + s - 1.45 * (-((s - 0.5) / 0.1f64).powi(2)).exp(), 0.01, 0.0];
        let (p, gp) = vector_min((0.0, g(0.0)), (1.0, g(1.0)), (2.0, g(2.0)), 1e-9, |s| Some(g(s))).expect("settles");
        let (m2, (q, n2)) = (norm2(gp), brent_min(0.3, 0.7, 1e-12, |s| norm2(g(s))));
        assert!((p - q).abs() < 1e-6 && (m2 - n2).abs() < 1e-12, "{p} {q} {m2} {n2}");
        // No value (an unsolvable pose): no answer, the caller falls back.
        assert!(vector_min((0.0, g(0.0)), (1.0, g(1.0)), (2.0, g(2.0)), 1e-9, |_| None).is_none());
    }

    /// A load that does not change along the path (its values differ by round-off
    /// only: a leg carried unchanged by an actuated translation) has no minimum to
    /// locate: the least value on the interval comes back after one look inside,
    /// where the steps used to chase the round-off until they gave up (24
    /// evaluations, then Brent's). A load that changes by a few parts in 10¹⁰ over
    /// the interval is not flat: its minimum is located.
    #[test]
    fn vector_min_of_a_flat_load_is_its_least_value() {
        let noise = |s: f64| 4e-15 * (1e3 * s).sin();
        let f = |s: f64| [2.855 + noise(s), -11.49 - noise(2.0 * s), 32.23 + noise(3.0 * s)];
        let mut calls = 0;
        let (p, fp) = vector_min((0.0, f(0.0)), (1.0, f(1.0)), (2.0, f(2.0)), 1e-6, |s| {
            calls += 1;
            Some(f(s))
        })
        .expect("a flat load has its value");
        assert_eq!(calls, 1, "one look inside");
        assert!((0.0..=1.0).contains(&p));
        let least = [0.0, 0.5, 1.0].map(|s| norm(f(s))).into_iter().fold(f64::MAX, f64::min);
        assert_eq!(norm(fp), least);
        let g = |s: f64| [34.0 + 1e-8 * (s - 0.3) * (s - 0.3), 0.0, 0.0];
        let (p, _) = vector_min((0.0, g(0.0)), (1.0, g(1.0)), (2.0, g(2.0)), 1e-4, |s| Some(g(s))).expect("settles");
        assert!((p - 0.3).abs() < 1e-4, "{p}");
    }

    /// A shallow dip (the load stays 2.4 N) whose values carry round-off of 1e-13:
    /// the polish, from values a stencil's width apart, lands within 1e-10 of the
    /// exact minimum, where the minimum of `|f|²` alone by Brent's method does not.
    #[test]
    fn vector_polish_resolves_a_shallow_dip_beyond_root_epsilon() {
        let star = -0.435_366_343_342_577;
        let noise = |s: f64| 1e-13 * (1e7 * s).sin();
        let f = |s: f64| {
            let u = s - star;
            [-2.39 - 4.32 * u + 3.8 * u * u + noise(s), 0.0, 0.29 - 35.34 * u + 9.8 * u * u + noise(2.0 * s)]
        };
        // The exact minimum of the noise-free load.
        let clean = |s: f64| {
            let u = s - star;
            [-2.39 - 4.32 * u + 3.8 * u * u, 0.0, 0.29 - 35.34 * u + 9.8 * u * u]
        };
        let slope = |s: f64| {
            let (v, u) = (clean(s), s - star);
            v[0] * (-4.32 + 7.6 * u) + v[2] * (-35.34 + 19.6 * u)
        };
        let exact = bisect(star - 0.01, star + 0.01, slope(star - 0.01), 1e-16, slope);
        let (lo, hi) = (star - 0.008, star + 0.009);
        let start = exact + 2e-9;
        let (p, _) = vector_polish(start, f(start), 1e-5, (lo, hi), |s| Some(f(s))).expect("settles");
        assert!((p - exact).abs() < 1e-10, "{:e}", p - exact);
        let (q, _) = brent_min(lo, hi, 1e-12, |s| norm2(f(s)));
        assert!((q - exact).abs() > 1e-10, "Brent on |f|² alone: {:e}", q - exact);
    }

    /// Smooth roots, from brackets of a grid's width and wider: within `tol` of the
    /// root, in fewer evaluations than Brent's method; a step of `f` (an unsolvable
    /// stretch reads 0) still gives where it starts.
    #[test]
    fn interpolated_root_is_within_tol_in_fewer_steps() {
        type Case = (fn(f64) -> f64, f64, f64);
        let cases: [Case; 3] = [
            (|x| x * x - 2.0, 1.4, 1.45),
            (|x| (3.0 * x).sin() - 0.3 * x - 0.1, 0.0, 0.3),
            (|x| (x - 0.123_456_789).powi(3) + 0.01 * (x - 0.123_456_789), 0.1, 0.13),
        ];
        for (f, a, b) in cases {
            let exact = bisect(a, b, f(a), 1e-15, f);
            let (mut ours, mut brents) = (0, 0);
            let r = interpolated_root(a, b, f(a), f(b), 1e-9, |x| {
                ours += 1;
                f(x)
            });
            let q = brent_root(a, b, f(a), f(b), 1e-9, |x| {
                brents += 1;
                f(x)
            });
            assert!((r - exact).abs() < 1e-9 && (q - exact).abs() < 1e-9, "{r} {q} {exact}");
            assert!(ours < brents, "{ours} evaluations against Brent's {brents}");
        }
        // As for Brent: a point where the load reads zero.
        let r = interpolated_root(0.0, 1.0, -1.0, 1.0, 1e-9, |x| if x < 0.3 { -1.0 } else { 0.0 });
        assert!(r >= 0.3, "{r}");
    }

    /// A first step from four samples (the bracket and one beyond each end) lands a
    /// hundred times closer to the root than regula falsi's, and the search ends
    /// within `tol` of it in fewer evaluations than one from the bracket alone;
    /// samples that are not monotone give no first step.
    #[test]
    fn a_root_read_off_four_samples_takes_fewer_evaluations() {
        let f = |x: f64| (3.0 * x).sin() - 0.3 * x - 0.1 + 0.2 * x * x * x;
        // A 101-node grid's spacing.
        let h = 0.01;
        let (mut ours, mut bracket_only) = (0, 0);
        for i in 0..40 {
            // Brackets of a grid's spacing, the root anywhere inside them.
            let exact = bisect(0.0, 0.3, f(0.0), 1e-15, f);
            let a = exact - h * (i as f64 + 0.5) / 40.0;
            let xs = [a - h, a, a + h, a + 2.0 * h];
            let points = xs.map(|x| (x, f(x)));
            let guess = inverse_interpolation(&points);
            let falsi = a - f(a) * h / (f(a + h) - f(a));
            let off = guess.map(|g| (g - exact).abs()).unwrap_or(f64::INFINITY);
            assert!(off * 100.0 < (falsi - exact).abs(), "{guess:?} {falsi} {exact}");
            let r = interpolated_root_from(a, a + h, f(a), f(a + h), guess, 1e-9, |x| {
                ours += 1;
                f(x)
            });
            let q = interpolated_root(a, a + h, f(a), f(a + h), 1e-9, |x| {
                bracket_only += 1;
                f(x)
            });
            assert!((r - exact).abs() < 1e-10 && (q - exact).abs() < 1e-10, "{r} {q} {exact}");
        }
        assert!(ours * 4 < bracket_only * 3, "{ours} evaluations against {bracket_only}");
        assert_eq!(inverse_interpolation(&[(0.0, 1.0), (1.0, -1.0), (2.0, -0.5), (3.0, -2.0)]), None);
    }

    /// From the values in hand, the minimum to `xtol` (or a value below `enough`) in
    /// fewer evaluations than Brent's, half as many in all, on dips that stay clear,
    /// that cross, and that end at the interval's end; a parabola opening downwards
    /// hands over to Brent.
    #[test]
    fn parabolic_steps_find_the_least_value_in_few_evaluations() {
        type Case = (fn(f64) -> f64, f64);
        let cases: [Case; 3] = [
            // Clear of zero, the minimum inside (0.2, 0.3).
            (|x| 0.2 + 4.0 * (x - 0.262).powi(2) + (x - 0.262).powi(3), f64::NEG_INFINITY),
            // Below zero between the samples: any value below -1e-9 will do.
            (|x| 0.01 + 3.0 * (x - 0.27).powi(2) - 0.0003 * (-(x - 0.255).powi(2) / 1e-4).exp() * 40.0, -1e-9),
            // Clear, the minimum near the sample at 0.3.
            (|x| 1.0 + (x - 0.299).powi(2) * (2.0 + x), f64::NEG_INFINITY),
        ];
        let (mut total, mut total_brent) = (0, 0);
        for (f, enough) in cases {
            let (lo, hi, xtol) = (0.2, 0.3, 1e-4 * 0.1);
            let known = [0.1, 0.2, 0.25, 0.3].map(|x| (x, f(x)));
            let (mut ours, mut brents) = (0, 0);
            let (x, y) = parabolic_min_below(&known, lo, hi, xtol, enough, |x| {
                ours += 1;
                f(x)
            });
            let (bx, by) = brent_min_below(lo, hi, xtol, enough, |x| {
                brents += 1;
                f(x)
            });
            assert_eq!(y, f(x));
            if enough.is_finite() {
                assert!(y < enough && by < enough, "{y} {by}");
            } else {
                assert!((x - bx).abs() < 2.0 * xtol && (y - by).abs() < 1e-9, "{x} {bx} {y} {by}");
            }
            assert!(ours < brents, "{ours} evaluations against Brent's {brents}");
            (total, total_brent) = (total + ours, total_brent + brents);
        }
        assert!(total * 2 <= total_brent, "{total} evaluations against Brent's {total_brent}");
        // Concave: Brent's answer, with Brent's evaluations.
        let f = |x: f64| 1.0 - (x - 0.25).powi(2);
        let known = [0.2, 0.25, 0.3].map(|x| (x, f(x)));
        let ours = parabolic_min_below(&known, 0.2, 0.3, 1e-5, f64::NEG_INFINITY, f);
        assert_eq!(ours, brent_min_below(0.2, 0.3, 1e-5, f64::NEG_INFINITY, f));
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
