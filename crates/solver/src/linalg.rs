//! The faer path: in-place partial-pivoting LU with scratch sized once.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::perm::PermRef;
use faer::{Mat, MatMut, MatRef, Par};

/// A reusable dense solver for one matrix size: factorisation and solve. Nothing
/// allocates after [`LuSolver::new`].
pub struct LuSolver {
    lu: Mat<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buf: MemBuffer,
    /// A vector and the previous sign pattern for [`LuSolver::cond_one_estimate`].
    x: Mat<f64>,
    sign: Vec<f64>,
}

impl LuSolver {
    /// Scratch for `n × n` systems with up to `max_rhs` right-hand sides.
    pub fn new(n: usize, max_rhs: usize) -> Self {
        let req = StackReq::any_of(&[
            factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default()),
            solve::solve_in_place_scratch::<usize, f64>(n, max_rhs.max(n), Par::Seq),
            solve::solve_transpose_in_place_scratch::<usize, f64>(n, 1, Par::Seq),
        ]);
        Self {
            lu: Mat::zeros(n, n),
            perm: vec![0; n],
            perm_inv: vec![0; n],
            buf: MemBuffer::new(req),
            x: Mat::zeros(n, 1),
            sign: vec![0.0; n],
        }
    }

    /// Solves `M·X = rhs` in place; `false` when a pivot is zero or not finite (then
    /// `rhs` is left unspecified).
    #[track_caller]
    pub fn solve(&mut self, m: MatRef<'_, f64>, mut rhs: MatMut<'_, f64>) -> bool {
        let n = self.lu.nrows();
        assert!(m.nrows() == n && m.ncols() == n, "matrix must be {n} × {n}");
        assert!(rhs.nrows() == n, "right-hand side must have {n} rows");
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
                return false;
            }
        }
        solve::solve_in_place(self.lu.as_ref(), self.lu.as_ref(), perm, rhs.as_mut(), Par::Seq, stack);
        true
    }
}

impl LuSolver {
    /// Factors `m` and keeps its LU for [`LuSolver::solve_factored`] and
    /// [`LuSolver::cond_one`]; `false` when a pivot is zero or not finite.
    #[track_caller]
    pub fn factor(&mut self, m: MatRef<'_, f64>) -> bool {
        let n = self.lu.nrows();
        assert!(m.nrows() == n && m.ncols() == n, "matrix must be {n} × {n}");
        self.lu.copy_from(m);
        let stack = MemStack::new(&mut self.buf);
        factor::lu_in_place(self.lu.as_mut(), &mut self.perm, &mut self.perm_inv, Par::Seq, stack, Default::default());
        (0..n).all(|i| {
            let d = self.lu[(i, i)];
            d != 0.0 && d.is_finite()
        })
    }

    /// Solves with the last [`LuSolver::factor`]ed matrix, in place.
    #[track_caller]
    pub fn solve_factored(&mut self, mut rhs: MatMut<'_, f64>) {
        let n = self.lu.nrows();
        assert!(rhs.nrows() == n, "right-hand side must have {n} rows");
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let stack = MemStack::new(&mut self.buf);
        solve::solve_in_place(self.lu.as_ref(), self.lu.as_ref(), perm, rhs.as_mut(), Par::Seq, stack);
    }

    /// `‖M‖₁·est`, `est` Higham's estimate of `‖M⁻¹‖₁` (LAPACK's `dlacn2`: at most five
    /// solves with `M` or `Mᵀ` and one more against an alternating vector) for the last
    /// factored `m`. A lower bound, rarely below a third of [`LuSolver::cond_one`], at
    /// a fraction of its cost (`O(n²)` after the factorisation, not `O(n³)`). Infinite
    /// where not finite.
    pub fn cond_one_estimate(&mut self, m: MatRef<'_, f64>) -> f64 {
        let n = self.lu.nrows();
        assert!(m.nrows() == n && m.ncols() == n, "matrix must be {n} × {n}");
        let norm_m = (0..n).map(|k| (0..n).map(|i| m[(i, k)].abs()).sum::<f64>()).fold(0.0f64, f64::max);
        let k = norm_m * self.inverse_norm_estimate();
        if k.is_finite() { k } else { f64::INFINITY }
    }

    /// `x ← M⁻¹·x` (`transpose`: `M⁻ᵀ·x`) on the work vector.
    fn solve_work(&mut self, transpose: bool) {
        let n = self.lu.nrows();
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let stack = MemStack::new(&mut self.buf);
        let (lu, x) = (self.lu.as_ref(), self.x.as_mut());
        if transpose {
            solve::solve_transpose_in_place(lu, lu, perm, x, Par::Seq, stack);
        } else {
            solve::solve_in_place(lu, lu, perm, x, Par::Seq, stack);
        }
    }

    fn inverse_norm_estimate(&mut self) -> f64 {
        let n = self.lu.nrows();
        let norm1 = |x: &Mat<f64>| (0..n).map(|i| x[(i, 0)].abs()).sum::<f64>();
        let argmax = |x: &Mat<f64>| (0..n).fold(0, |j, i| if x[(i, 0)].abs() > x[(j, 0)].abs() { i } else { j });
        let sign = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
        for i in 0..n {
            self.x[(i, 0)] = 1.0 / n as f64;
        }
        self.solve_work(false);
        let mut est = norm1(&self.x);
        if n > 1 {
            for i in 0..n {
                self.sign[i] = sign(self.x[(i, 0)]);
                self.x[(i, 0)] = self.sign[i];
            }
            self.solve_work(true);
            let mut j = argmax(&self.x);
            for iter in 2..=5 {
                self.x.fill(0.0);
                self.x[(j, 0)] = 1.0;
                self.solve_work(false);
                let old = est;
                est = norm1(&self.x);
                let repeated = (0..n).all(|i| sign(self.x[(i, 0)]) == self.sign[i]);
                if repeated || est <= old {
                    est = est.max(old);
                    break;
                }
                for i in 0..n {
                    self.sign[i] = sign(self.x[(i, 0)]);
                    self.x[(i, 0)] = self.sign[i];
                }
                self.solve_work(true);
                let last = j;
                j = argmax(&self.x);
                if self.x[(last, 0)] == self.x[(j, 0)].abs() || iter == 5 {
                    break;
                }
            }
            // An alternating vector catches what the iteration can miss.
            for i in 0..n {
                let s = if i % 2 == 0 { 1.0 } else { -1.0 };
                self.x[(i, 0)] = s * (1.0 + i as f64 / (n - 1) as f64);
            }
            self.solve_work(false);
            est = est.max(2.0 * norm1(&self.x) / (3.0 * n as f64));
        }
        est
    }

    /// `κ₁ = ‖M‖₁·‖M⁻¹‖₁` of the last factored `m`, the inverse formed column by column
    /// in `inv` (`n × n` scratch): exact, as the fast path's condition numbers are.
    /// Infinite where the inverse is not finite.
    #[track_caller]
    pub fn cond_one(&mut self, m: MatRef<'_, f64>, mut inv: MatMut<'_, f64>) -> f64 {
        let n = self.lu.nrows();
        assert!(inv.nrows() == n && inv.ncols() == n, "inverse scratch must be {n} × {n}");
        inv.fill(0.0);
        for i in 0..n {
            inv[(i, i)] = 1.0;
        }
        self.solve_factored(inv.as_mut());
        let col_norm =
            |a: MatRef<'_, f64>| (0..n).map(|k| (0..n).map(|i| a[(i, k)].abs()).sum::<f64>()).fold(0.0f64, f64::max);
        let k = col_norm(m) * col_norm(inv.as_ref());
        if k.is_finite() { k } else { f64::INFINITY }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Residual of random well-conditioned systems; a singular one is reported.
    #[test]
    fn solves_and_reports_singular_matrices() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 24;
        let mut lu = LuSolver::new(n, 4);
        for _ in 0..20 {
            let m = Mat::from_fn(n, n, |i, j| rng.random_range(-1.0..1.0) + if i == j { 4.0 } else { 0.0 });
            let b = Mat::from_fn(n, 4, |_, _| rng.random_range(-1.0..1.0));
            let mut x = b.clone();
            assert!(lu.solve(m.as_ref(), x.as_mut()));
            let r = &m * &x - &b;
            let res = r.norm_max();
            assert!(res < 1e-12, "residual {res}");
        }
        let mut x = Mat::<f64>::zeros(n, 1);
        let z = Mat::<f64>::zeros(n, n);
        assert!(!lu.solve(z.as_ref(), x.as_mut()), "a singular matrix is reported");
    }

    /// Factor once, solve twice: the same solution as [`LuSolver::solve`], and `κ₁` of a
    /// diagonal matrix is the ratio of its extreme entries.
    #[test]
    fn factored_solves_and_condition() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = 30;
        let mut lu = LuSolver::new(n, n);
        let m = Mat::from_fn(n, n, |i, j| rng.random_range(-1.0..1.0) + if i == j { 4.0 } else { 0.0 });
        let b = Mat::from_fn(n, 3, |_, _| rng.random_range(-1.0..1.0));
        let (mut x, mut y) = (b.clone(), b.clone());
        assert!(lu.solve(m.as_ref(), x.as_mut()));
        assert!(lu.factor(m.as_ref()));
        lu.solve_factored(y.as_mut());
        assert_eq!(x, y);
        let d = Mat::from_fn(n, n, |i, j| if i == j { 1.0 + i as f64 } else { 0.0 });
        let mut inv = Mat::zeros(n, n);
        assert!(lu.factor(d.as_ref()));
        let k = lu.cond_one(d.as_ref(), inv.as_mut());
        assert!((k - n as f64).abs() < 1e-12 * n as f64, "{k}");
        assert_eq!(lu.cond_one_estimate(d.as_ref()), k);
    }

    /// The estimate is a lower bound within a factor 3 of the exact `κ₁`, on random
    /// matrices of several sizes and conditionings.
    #[test]
    fn condition_estimate_brackets_the_exact_value() {
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        for n in [2, 6, 12, 24, 30, 42] {
            let mut lu = LuSolver::new(n, n);
            let mut inv = Mat::zeros(n, n);
            for t in 0..40 {
                let shift = [0.0, 1.0, 4.0][t % 3];
                let scale: Vec<f64> = (0..n).map(|_| 10f64.powf(rng.random_range(-3.0..3.0))).collect();
                let m = Mat::from_fn(n, n, |i, j| {
                    (rng.random_range(-1.0..1.0) + if i == j { shift } else { 0.0 }) * scale[j]
                });
                assert!(lu.factor(m.as_ref()));
                let est = lu.cond_one_estimate(m.as_ref());
                let exact = lu.cond_one(m.as_ref(), inv.as_mut());
                assert!(est <= exact * (1.0 + 1e-10) && est >= exact / 3.0, "n {n}: {est:e} vs {exact:e}");
            }
        }
    }
}
