//! Dense LU factorisation with partial pivoting (Golub & Van Loan, *Matrix Computations*, 4th
//! ed., Algorithm 3.4.1, the outer-product form) of the fold curves' bordered matrices, with
//! solves in both `A x = b` and `Aᵀ x = b`.
//!
//! Written here for a measured reason: nalgebra's `LU` gives no transposed solve, and the route
//! through its `l()` and `u()` builds two new matrices per call, which cost the paper's envelope
//! map more than its factorisations did (BENCHMARKS.md, issue 28). The elimination does
//! nalgebra's operations in nalgebra's order (pivot on the first largest |a_ik|, the column
//! scaled by the reciprocal of the pivot, each later column updated by an axpy), so the factors
//! are its factors to the bit (unit test).

use nalgebra::{DMatrix, DVector};

/// `P A = L U` of a square matrix, L unit lower and U upper triangular, packed column-major.
pub(in crate::hbm) struct DenseLu {
    n: usize,
    /// L below the diagonal, U on and above it; column j at `j n .. (j + 1) n`.
    packed: Vec<f64>,
    /// Row i was swapped with row `swaps[i]` ≥ i at step i.
    swaps: Vec<usize>,
}

impl DenseLu {
    /// The factorisation of `a` (square). A column without a non-zero pivot is left as it is,
    /// and the solves then return None.
    pub(in crate::hbm) fn new(a: &DMatrix<f64>) -> Self {
        let n = a.nrows();
        debug_assert_eq!(n, a.ncols());
        let mut packed = a.as_slice().to_vec();
        let mut swaps: Vec<usize> = (0..n).collect();
        for i in 0..n {
            let col = &packed[i * n + i..(i + 1) * n];
            let (mut p, mut best) = (0, col[0].abs());
            for (k, v) in col.iter().enumerate().skip(1) {
                if v.abs() > best {
                    (p, best) = (k, v.abs());
                }
            }
            let piv = p + i;
            let diag = packed[i * n + piv];
            if diag == 0.0 {
                continue;
            }
            if piv != i {
                swaps[i] = piv;
                for j in 0..n {
                    packed.swap(j * n + i, j * n + piv);
                }
            }
            let inv = 1.0 / diag;
            for v in &mut packed[i * n + i + 1..(i + 1) * n] {
                *v *= inv;
            }
            let (left, right) = packed.split_at_mut((i + 1) * n);
            let l = &left[i * n + i + 1..(i + 1) * n];
            for col in right.chunks_exact_mut(n) {
                let f = -col[i];
                for (y, x) in col[i + 1..].iter_mut().zip(l) {
                    *y += f * x;
                }
            }
        }
        Self { n, packed, swaps }
    }

    /// x with `A x = b`; None where U has a zero on its diagonal or x is not finite.
    pub(in crate::hbm) fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.n;
        let mut out = b.clone();
        let x = out.as_mut_slice();
        for (i, &s) in self.swaps.iter().enumerate() {
            x.swap(i, s);
        }
        // L y = P b, column by column.
        for (j, col) in self.packed.chunks_exact(n).enumerate() {
            let (head, tail) = x.split_at_mut(j + 1);
            let xj = head[j];
            for (v, l) in tail.iter_mut().zip(&col[j + 1..]) {
                *v -= l * xj;
            }
        }
        // U x = y, column by column from the last.
        for (j, col) in self.packed.chunks_exact(n).enumerate().rev() {
            let d = col[j];
            if d == 0.0 {
                return None;
            }
            let (head, tail) = x.split_at_mut(j);
            tail[0] /= d;
            let xj = tail[0];
            for (v, u) in head.iter_mut().zip(&col[..j]) {
                *v -= u * xj;
            }
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// x with `Aᵀ x = b` (`Uᵀ Lᵀ P x = b`); None as for [`DenseLu::solve`].
    pub(in crate::hbm) fn solve_transposed(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.n;
        let mut out = b.clone();
        let x = out.as_mut_slice();
        // Uᵀ z = b: row j of Uᵀ is column j of U down to the diagonal.
        for (j, col) in self.packed.chunks_exact(n).enumerate() {
            let d = col[j];
            if d == 0.0 {
                return None;
            }
            let (head, tail) = x.split_at_mut(j);
            let dot: f64 = col[..j].iter().zip(head.iter()).map(|(u, v)| u * v).sum();
            tail[0] = (tail[0] - dot) / d;
        }
        // Lᵀ w = z: row j of Lᵀ is column j of L below the diagonal.
        for (j, col) in self.packed.chunks_exact(n).enumerate().rev() {
            let (head, tail) = x.split_at_mut(j + 1);
            let dot: f64 = col[j + 1..].iter().zip(tail.iter()).map(|(l, v)| l * v).sum();
            head[j] -= dot;
        }
        // x = Pᵀ w: the swaps undone in reverse order.
        for (i, &s) in self.swaps.iter().enumerate().rev() {
            x.swap(i, s);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix(n: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        DMatrix::from_fn(n, n, |_, _| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
    }

    /// The factors are nalgebra's to the bit (the same operations in the same order), and both
    /// solves satisfy their systems to 1e-13 relative (the residual, an independent check), on
    /// sizes 1–60 with pivoting throughout.
    #[test]
    fn factors_are_nalgebras_and_solves_satisfy_their_systems() {
        for n in [1, 2, 3, 7, 43, 44, 60] {
            let a = matrix(n, 7 + n as u64);
            let ours = DenseLu::new(&a);
            let theirs = a.clone().lu();
            let (l, u) = (theirs.l(), theirs.u());
            for j in 0..n {
                for i in 0..n {
                    let want = if i > j { l[(i, j)] } else { u[(i, j)] };
                    assert_eq!(ours.packed[j * n + i].to_bits(), want.to_bits(), "n = {n}, ({i}, {j})");
                }
            }
            let b = DVector::from_fn(n, |i, _| (i as f64 * 0.7).sin() + 0.5);
            let x = ours.solve(&b).unwrap();
            let xt = ours.solve_transposed(&b).unwrap();
            let scale = a.amax() * x.amax().max(xt.amax());
            assert!((&a * &x - &b).amax() <= 1e-13 * scale, "n = {n}");
            assert!((a.transpose() * &xt - &b).amax() <= 1e-13 * scale, "n = {n}");
        }
    }

    /// A singular matrix (a zero column) gives no solution, not infinities.
    #[test]
    fn a_singular_matrix_has_no_solution() {
        let mut a = matrix(5, 3);
        a.column_mut(2).fill(0.0);
        let lu = DenseLu::new(&a);
        let b = DVector::from_element(5, 1.0);
        assert!(lu.solve(&b).is_none() && lu.solve_transposed(&b).is_none());
    }
}
