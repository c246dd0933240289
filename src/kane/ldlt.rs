//! The in-place dense LDLᵀ factorisation and solve of `M u̇ = F` (M symmetric positive definite),
//! `M = L D Lᵀ` row by row with L unit lower triangular, fused with the forward substitution. The factorisation along the tree's branches is [`super::tree`].

use super::{Model, PIVOT_TOL, Workspace, dot};
use crate::error::EngineError;

impl Model {
    /// Factors `M = L D Lᵀ` (L unit lower triangular, row-major in `l`; `d_inv` = D⁻¹) and
    /// solves `M x = F` into `x`.
    ///
    /// NOTE: written here rather than calling nalgebra's `Cholesky` (LLᵀ) so the factorisation works in
    /// place on the preallocated buffer (no allocation per call) and a failure names the speed
    /// (joint) whose pivot vanished. LDLᵀ rather than LLᵀ: no square roots, and one division per
    /// pivot that the solve reuses as a multiplication (n divisions in all, as many as Cramer's
    /// rule in the closed form for n = 2). Its pivots d_j are exactly Cholesky's squared ones.
    /// The forward substitution runs row by row with the factorisation, so each row of L is used
    /// while still in registers (the evaluation is latency bound, not flop bound; BENCHMARKS.md).
    pub(super) fn factor_solve(&self, ws: &mut Workspace, x: &mut [f64]) -> Result<(), EngineError> {
        if self.nb == self.n {
            with_literal_n!(self.n, self.factor_solve_n(ws, x))
        } else {
            self.factor_solve_n::<0>(ws, x)
        }
    }

    #[inline(always)]
    pub(super) fn factor_solve_n<const N: usize>(&self, ws: &mut Workspace, x: &mut [f64]) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (m, l, f) = (&ws.m[..n * n], &mut ws.l[..n * n], &ws.f[..n]);
        let (d_inv, a, x) = (&mut ws.d_inv[..n], &mut ws.row[..n], &mut x[..n]);
        let mut scale = 0.0f64;
        for i in 0..n {
            scale = scale.max(m[i * n + i].abs());
        }
        for i in 0..n {
            // Row i of M = Σ_k L_ik d_k L_jk: first a_j = L_ij d_j for j < i, then L_ij, d_i;
            // and y_i = F_i − Σ_j L_ij y_j (L y = F).
            for j in 0..i {
                a[j] = m[i * n + j] - dot(&a[..j], &l[j * n..j * n + j]);
            }
            let (mut d, mut y) = (m[i * n + i], f[i]);
            for j in 0..i {
                let lij = a[j] * d_inv[j];
                l[i * n + j] = lij;
                d -= a[j] * lij;
                y -= lij * x[j];
            }
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(self.pivot_error(i, d));
            }
            d_inv[i] = 1.0 / d;
            x[i] = y;
        }
        // D z = y, then Lᵀ x = z by rows of L, so the inner loop reads L contiguously.
        for i in 0..n {
            x[i] *= d_inv[i];
        }
        for i in (0..n).rev() {
            let (head, tail) = x.split_at_mut(i);
            let xi = tail[0];
            for (xk, lik) in head.iter_mut().zip(&l[i * n..i * n + i]) {
                *xk -= lik * xi;
            }
        }
        Ok(())
    }

    /// The error of a vanished (or NaN) pivot `d` of speed `i`.
    #[cold]
    #[inline(never)]
    pub(super) fn pivot_error(&self, i: usize, d: f64) -> EngineError {
        if d.is_nan() {
            EngineError::NonFinite { what: "mass matrix", index: i }
        } else {
            EngineError::NotPositiveDefinite {
                dof: i,
                joint: self.mech.joints[self.joint_of[i]].name.clone(),
                pivot: d,
            }
        }
    }
}
