//! Eigenvalues of the reduced monodromy (nalgebra's real Schur form with an iteration cap, faer's
//! where it stops), and the LU of a shifted upper Hessenberg matrix for the pairs' inverse
//! iteration on the Schur form.

use nalgebra::{Complex, DMatrix, DVector};

/// True when every entry below the first subdiagonal is zero.
pub(super) fn is_hessenberg(t: &DMatrix<f64>) -> bool {
    (0..t.ncols()).all(|j| (j + 2..t.nrows()).all(|i| t[(i, j)] == 0.0))
}

/// LU with partial pivoting of `H − s I`, H real upper Hessenberg: each column has one entry
/// below the diagonal, so a step swaps at most two adjacent rows and updates one.
pub(super) struct HessenbergLu {
    /// U in the upper triangle; the multiplier of step k at (k + 1, k).
    lu: DMatrix<Complex<f64>>,
    /// Whether step k swapped rows k and k + 1.
    swapped: Vec<bool>,
}

impl HessenbergLu {
    /// None when a pivot is zero or not finite.
    pub(super) fn new(h: &DMatrix<f64>, s: Complex<f64>) -> Option<Self> {
        let d = h.nrows();
        if d == 0 {
            return None;
        }
        let mut lu = h.map(|x| Complex::new(x, 0.0));
        for k in 0..d {
            lu[(k, k)] -= s;
        }
        let mut swapped = vec![false; d];
        for k in 0..d.saturating_sub(1) {
            if lu[(k + 1, k)].norm() > lu[(k, k)].norm() {
                // From column k on: left of it row k holds the previous step's multiplier and
                // row k + 1 zeros.
                for j in k..d {
                    lu.swap((k, j), (k + 1, j));
                }
                swapped[k] = true;
            }
            let p = lu[(k, k)];
            if !(p.norm() > 0.0 && p.norm().is_finite()) {
                return None;
            }
            let l = lu[(k + 1, k)] / p;
            lu[(k + 1, k)] = l;
            for j in k + 1..d {
                let u = lu[(k, j)];
                lu[(k + 1, j)] -= l * u;
            }
        }
        let last = lu[(d - 1, d - 1)].norm();
        (last > 0.0 && last.is_finite()).then_some(Self { lu, swapped })
    }

    /// `(H − s I)⁻¹ b`; None when not finite.
    pub(super) fn solve(&self, b: &DVector<Complex<f64>>) -> Option<DVector<Complex<f64>>> {
        let d = b.len();
        let mut x = b.clone();
        for k in 0..d.saturating_sub(1) {
            if self.swapped[k] {
                x.swap_rows(k, k + 1);
            }
            let v = x[k];
            x[k + 1] -= self.lu[(k + 1, k)] * v;
        }
        for i in (0..d).rev() {
            let mut v = x[i];
            for j in i + 1..d {
                v -= self.lu[(i, j)] * x[j];
            }
            x[i] = v / self.lu[(i, i)];
        }
        x.iter().all(|c| c.re.is_finite() && c.im.is_finite()).then_some(x)
    }
}

/// Eigenvalues of a real square matrix by methods bounded in work; None when neither converges.
/// First nalgebra's real Schur form with an iteration cap (30 sweeps per row): on the sizes of
/// the paper's absorbers it costs a third of faer's instructions (`BENCHMARKS.md`). Its Francis
/// QR has no exceptional shifts, though, and never returned on the repeated multipliers of 4
/// identical pendulums at 500 N·m (issue 26); where the cap stops it, faer's real Schur form
/// (Hessenberg reduction, Francis double-shift QR with exceptional shifts and aggressive early
/// deflation, as LAPACK's dhseqr, itself capped) takes over.
///
/// Also returns the real Schur form `(Q, T)` when nalgebra's gave the eigenvalues.
#[allow(clippy::type_complexity)]
pub(super) fn eigen(m: DMatrix<f64>) -> Option<(Vec<Complex<f64>>, Option<(DMatrix<f64>, DMatrix<f64>)>)> {
    let d = m.nrows();
    if d == 0 {
        return Some((Vec::new(), None));
    }
    let finite = |v: &[Complex<f64>]| v.iter().all(|c| c.re.is_finite() && c.im.is_finite());
    if let Some(s) = nalgebra::Schur::try_new(m.clone(), f64::EPSILON, 30 * d) {
        let out: Vec<Complex<f64>> = s.complex_eigenvalues().iter().copied().collect();
        if finite(&out) {
            return Some((out, Some(s.unpack())));
        }
    }
    let f = faer::Mat::<f64>::from_fn(d, d, |i, j| m[(i, j)]);
    let ev = f.eigenvalues().ok()?;
    let out: Vec<Complex<f64>> = ev.iter().map(|c| Complex::new(c.re, c.im)).collect();
    finite(&out).then_some((out, None))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Hessenberg LU solves `(H − s I) x = b` to rounding (residual below 1e-13 relative)
    /// when its pivoting swaps rows: the subdiagonal of this H exceeds its diagonal.
    #[test]
    fn hessenberg_lu_solves_with_row_swaps() {
        let d = 6;
        let h = DMatrix::from_fn(d, d, |i, j| {
            if i == j + 1 {
                2.0 + i as f64
            } else if i <= j {
                ((i * 5 + j * 3) % 7) as f64 * 0.1 - 0.3
            } else {
                0.0
            }
        });
        let s = Complex::new(0.05, 0.02);
        let lu = HessenbergLu::new(&h, s).unwrap();
        assert!(lu.swapped.iter().filter(|&&x| x).count() >= 3, "{:?}", lu.swapped);
        let b = DVector::from_fn(d, |i, _| Complex::new(1.0 + i as f64, -0.5 * i as f64));
        let x = lu.solve(&b).unwrap();
        let a = DMatrix::from_fn(d, d, |i, j| {
            Complex::new(h[(i, j)], 0.0) - if i == j { s } else { Complex::new(0.0, 0.0) }
        });
        let r = (&a * &x - &b).norm() / b.norm();
        println!("{} swaps, residual {r:.1e}", lu.swapped.iter().filter(|&&x| x).count());
        assert!(r <= 1e-13, "{r:e}");
    }
}
