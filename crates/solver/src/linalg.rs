//! The faer path: in-place partial-pivoting LU with scratch sized once.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::{Mat, MatMut, MatRef, Par};

/// A reusable dense solver for one matrix size: factorisation, solve and the exact
/// 1-norm condition number `‖M‖₁·‖M⁻¹‖₁`. Nothing allocates after [`LuSolver::new`].
pub struct LuSolver {
    lu: Mat<f64>,
    inv: Mat<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buf: MemBuffer,
}

impl LuSolver {
    /// Scratch for `n × n` systems with up to `max_rhs` right-hand sides.
    pub fn new(n: usize, max_rhs: usize) -> Self {
        let req = StackReq::any_of(&[
            factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default()),
            solve::solve_in_place_scratch::<usize, f64>(n, max_rhs.max(n), Par::Seq),
        ]);
        Self {
            lu: Mat::zeros(n, n),
            inv: Mat::zeros(n, n),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            buf: MemBuffer::new(req),
        }
    }

    /// Solves `M·X = rhs` in place and returns `κ₁(M)`, or `f64::INFINITY` when a
    /// pivot is zero or not finite (then `rhs` is left unspecified).
    #[track_caller]
    pub fn solve_with_cond(&mut self, m: MatRef<'_, f64>, mut rhs: MatMut<'_, f64>) -> f64 {
        let n = self.lu.nrows();
        assert!(m.nrows() == n && m.ncols() == n, "matrix must be {n} × {n}");
        assert!(rhs.nrows() == n, "right-hand side must have {n} rows");
        let mut norm = 0.0f64;
        for j in 0..n {
            let mut s = 0.0;
            for i in 0..n {
                s += m[(i, j)].abs();
            }
            norm = norm.max(s);
        }
        self.lu.copy_from(m);
        let stack = MemStack::new(&mut self.buf);
        let (_, perm) = factor::lu_in_place(
            self.lu.as_mut(),
            &mut self.perm,
            &mut self.perm_inv,
            Par::Seq,
            stack,
            Default::default(),
        );
        for i in 0..n {
            let d = self.lu[(i, i)];
            if d == 0.0 || !d.is_finite() {
                return f64::INFINITY;
            }
        }
        solve::solve_in_place(self.lu.as_ref(), self.lu.as_ref(), perm, rhs.as_mut(), Par::Seq, stack);
        self.inv.fill(0.0);
        for i in 0..n {
            self.inv[(i, i)] = 1.0;
        }
        solve::solve_in_place(self.lu.as_ref(), self.lu.as_ref(), perm, self.inv.as_mut(), Par::Seq, stack);
        let mut inv_norm = 0.0f64;
        for j in 0..n {
            let mut s = 0.0;
            for i in 0..n {
                s += self.inv[(i, j)].abs();
            }
            inv_norm = inv_norm.max(s);
        }
        let cond = norm * inv_norm;
        if cond.is_finite() { cond } else { f64::INFINITY }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Residual of random well-conditioned systems, and κ₁ of a diagonal matrix.
    #[test]
    fn solves_and_measures_condition() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 24;
        let mut lu = LuSolver::new(n, 4);
        for _ in 0..20 {
            let m = Mat::from_fn(n, n, |i, j| rng.random_range(-1.0..1.0) + if i == j { 4.0 } else { 0.0 });
            let b = Mat::from_fn(n, 4, |_, _| rng.random_range(-1.0..1.0));
            let mut x = b.clone();
            let cond = lu.solve_with_cond(m.as_ref(), x.as_mut());
            let r = &m * &x - &b;
            let res = r.norm_max();
            assert!(res < 1e-13 * cond, "residual {res} with cond {cond}");
        }
        let d = Mat::from_fn(n, n, |i, j| if i == j { (i + 1) as f64 } else { 0.0 });
        let mut x = Mat::<f64>::zeros(n, 1);
        let cond = lu.solve_with_cond(d.as_ref(), x.as_mut());
        assert!((cond - 24.0).abs() < 1e-12);
        let z = Mat::<f64>::zeros(n, n);
        assert_eq!(lu.solve_with_cond(z.as_ref(), x.as_mut()), f64::INFINITY);
    }
}
