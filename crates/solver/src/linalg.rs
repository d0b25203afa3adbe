//! The faer path: in-place partial-pivoting LU with scratch sized once.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::{Mat, MatMut, MatRef, Par};

/// A reusable dense solver for one matrix size: factorisation and solve. Nothing
/// allocates after [`LuSolver::new`].
pub struct LuSolver {
    lu: Mat<f64>,
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
        Self { lu: Mat::zeros(n, n), perm: vec![0; n], perm_inv: vec![0; n], buf: MemBuffer::new(req) }
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
}
