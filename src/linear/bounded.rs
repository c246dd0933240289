//! The dense decompositions of the linear analyses with a bound on their work: the singular
//! value decomposition (Golub–Kahan–Reinsch, as nalgebra implements it) and the symmetric
//! eigen-decomposition (implicit QL), each capped at `6·n² + 100` sweeps — the cap LAPACK's
//! `dbdsqr` uses — and refused outright on a matrix with an entry that is not finite. The
//! convergence tolerances are nalgebra's defaults (5ε for the SVD, ε for the eigen-solver), so a
//! decomposition that converges is the one `svd()` and `SymmetricEigen::new` give, bit for bit.
//!
//! nalgebra's plain `svd` and `SymmetricEigen::new` iterate until convergence with no bound, and a
//! matrix holding an infinity never converges (the shift becomes NaN): the call would never
//! return. Here such a matrix is a [`LinearError::Eigen`] instead.

use super::{LinResult, LinearError};
use nalgebra::{ComplexField, DMatrix, SVD, SymmetricEigen};

/// Sweep cap for an `n × n` decomposition (LAPACK's `dbdsqr`: 6n²).
fn max_sweeps(n: usize) -> usize {
    6 * n * n + 100
}

/// Whether every entry of `m` is finite.
fn finite<T: ComplexField<RealField = f64>>(m: &DMatrix<T>) -> bool {
    m.iter().all(|v| v.clone().real().is_finite() && v.clone().imaginary().is_finite())
}

/// The SVD of `m` (with U and/or Vᵀ as asked), or [`LinearError::Eigen`] when `m` is not finite
/// or the iteration exceeds its cap.
pub(crate) fn svd<T: ComplexField<RealField = f64>>(
    m: DMatrix<T>,
    compute_u: bool,
    compute_v: bool,
) -> LinResult<SVD<T, nalgebra::Dyn, nalgebra::Dyn>> {
    let dim = m.nrows().max(m.ncols());
    if !finite(&m) {
        return Err(LinearError::Eigen { dim });
    }
    SVD::try_new(m, compute_u, compute_v, 5.0 * f64::EPSILON, max_sweeps(dim)).ok_or(LinearError::Eigen { dim })
}

/// The eigen-decomposition of the symmetric `m`, or [`LinearError::Eigen`] when `m` is not
/// finite or the iteration exceeds its cap.
pub(crate) fn symmetric_eigen(m: DMatrix<f64>) -> LinResult<SymmetricEigen<f64, nalgebra::Dyn>> {
    let dim = m.nrows();
    if !finite(&m) {
        return Err(LinearError::Eigen { dim });
    }
    SymmetricEigen::try_new(m, f64::EPSILON, max_sweeps(dim)).ok_or(LinearError::Eigen { dim })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The decompositions agree with nalgebra's unbounded ones on an ordinary matrix: the
    /// singular values of a diagonal matrix are its entries' magnitudes, and the eigenvalues of
    /// [[2, 1], [1, 2]] are 1 and 3 (closed forms).
    #[test]
    fn ordinary_matrices_decompose_as_before() {
        let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![3.0, -2.0, 0.5]));
        let s = svd(d, true, true).unwrap();
        let mut sv: Vec<f64> = s.singular_values.iter().copied().collect();
        sv.sort_by(f64::total_cmp);
        approx::assert_abs_diff_eq!(sv.as_slice(), [0.5, 2.0, 3.0].as_slice(), epsilon = 1e-15);
        let e = symmetric_eigen(DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0])).unwrap();
        let mut ev: Vec<f64> = e.eigenvalues.iter().copied().collect();
        ev.sort_by(f64::total_cmp);
        approx::assert_abs_diff_eq!(ev.as_slice(), [1.0, 3.0].as_slice(), epsilon = 1e-14);
    }

    /// A matrix with an infinity or a NaN is refused at once; nalgebra's `svd(true, true)` on the
    /// 3 × 3 matrix here does not return (the bulge-chasing shift turns NaN and the convergence
    /// test never passes).
    #[test]
    fn a_matrix_that_is_not_finite_is_refused_not_iterated_forever() {
        let mut m = DMatrix::from_element(3, 3, 1.0);
        m[(0, 0)] = f64::INFINITY;
        assert!(matches!(svd(m.clone(), true, true), Err(LinearError::Eigen { dim: 3 })));
        m[(0, 0)] = f64::NAN;
        assert!(matches!(symmetric_eigen(m), Err(LinearError::Eigen { dim: 3 })));
    }
}
