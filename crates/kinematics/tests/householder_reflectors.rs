//! The Householder QR that the custom kinematics and statics share
//! (`clearance_kinematics::custom::householder`), kept as reflectors, against the
//! matrix it factors: `Q·[R; 0]` gives the columns back, `Q` is orthogonal, and the
//! rows `n..6` of `Qᵀ` are orthogonal to every column (the wrench basis of a limb).

use clearance_kinematics::custom::householder;
use nalgebra::{Matrix6, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Round-off allowance for products of unit-sized 6 × 6 factors.
const TOL: f64 = 1e-13;

fn random_columns(rng: &mut ChaCha8Rng, n: usize) -> Matrix6<f64> {
    let mut a = Matrix6::zeros();
    for c in 0..n {
        for r in 0..6 {
            a[(r, c)] = rng.random_range(-1.0..1.0);
        }
    }
    a
}

#[test]
fn reflectors_rebuild_the_columns_and_span_their_complement() {
    let mut rng = ChaCha8Rng::seed_from_u64(38);
    for trial in 0..200 {
        let n = 1 + trial % 6;
        let a = random_columns(&mut rng, n);
        let mut r = a;
        let q = householder(&mut r, n).expect("random columns are independent");
        assert_eq!(q.n, n);
        for c in 0..n {
            // R is upper triangular in the columns factored.
            for row in c + 1..6 {
                assert!(r[(row, c)].abs() < TOL, "trial {trial}: R[{row},{c}] = {}", r[(row, c)]);
            }
            // Q·[R; 0] is the column again.
            let mut rc = Vector6::zeros();
            for row in 0..=c {
                rc[row] = r[(row, c)];
            }
            let back = q.apply_q(&rc);
            assert!((back - a.column(c)).amax() < TOL, "trial {trial}, column {c}: {back} against {}", a.column(c));
            // Qᵀ·a_c is R's column, and Qᵀ's rows agree with apply_qt.
            let qta = q.apply_qt(&a.column(c).into_owned());
            for row in 0..6 {
                let want = if row <= c { r[(row, c)] } else { 0.0 };
                assert!((qta[row] - want).abs() < TOL, "trial {trial}: (Qᵀa)[{row}] = {}", qta[row]);
                assert!((q.qt_row(row).dot(&a.column(c)) - want).abs() < TOL);
            }
        }
        // Q is orthogonal: its rows are orthonormal, and Qᵀ undoes Q.
        for i in 0..6 {
            for j in 0..6 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((q.qt_row(i).dot(&q.qt_row(j)) - want).abs() < TOL, "trial {trial}: rows {i}, {j}");
            }
        }
        let x = Vector6::from_fn(|i, _| (i as f64 + 1.0) * 0.3 - 1.0);
        assert!((q.apply_qt(&q.apply_q(&x)) - x).amax() < TOL);
    }
}

#[test]
fn a_zero_or_non_finite_column_is_refused() {
    let mut rng = ChaCha8Rng::seed_from_u64(39);
    let mut a = random_columns(&mut rng, 3);
    a.set_column(1, &Vector6::zeros());
    assert!(householder(&mut a, 3).is_none());
    let mut b = random_columns(&mut rng, 3);
    b[(4, 2)] = f64::NAN;
    assert!(householder(&mut b, 3).is_none());
    // The same columns without the bad one factor.
    let mut c = random_columns(&mut rng, 3);
    assert!(householder(&mut c, 3).is_some());
}
