//! The in-place LDLᵀ factorisation and solve of `M u̇ = F` (M symmetric positive definite), dense
//! or along the tree.
//!
//! The tree's factorisation is the leaves-first `M = Lᵀ D L` of a matrix with branch-induced
//! sparsity (Featherstone, *Rigid Body Dynamics Algorithms*, §6.5): M_kj ≠ 0 only when one of
//! speeds k and j is an ancestor of the other, and eliminating a leaf first changes only entries
//! between its ancestors, which are already in the pattern, so L keeps M's pattern (no fill-in)
//! and the work is Σ_k (depth_k + 1)² rather than n³/6: linear in n for a rotor carrying many
//! absorbers.

use super::{Kane, NONE, PIVOT_TOL, dot};
use crate::error::EngineError;

impl Kane {
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
    pub(super) fn factor_solve(&mut self, x: &mut [f64]) -> Result<(), EngineError> {
        if self.nb == self.n { with_literal_n!(self.n, self.factor_solve_n(x)) } else { self.factor_solve_n::<0>(x) }
    }

    #[inline(always)]
    pub(super) fn factor_solve_n<const N: usize>(&mut self, x: &mut [f64]) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (m, l, f) = (&self.m[..n * n], &mut self.l[..n * n], &self.f[..n]);
        let (d_inv, a, x) = (&mut self.d_inv[..n], &mut self.row[..n], &mut x[..n]);
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

    /// Solves `M x = F` by the leaves-first factorisation `M = Lᵀ D L` along the speeds' tree
    /// (`self.tree`; see the module doc), L stored in place of M's below-diagonal entries in
    /// `l`, D⁻¹ in `d_inv`. Only entries between a speed and its ancestors are read.
    pub(super) fn factor_solve_tree(&mut self, x: &mut [f64]) -> Result<(), EngineError> {
        let n = self.n;
        let Some(above) = self.tree.as_deref() else { return self.factor_solve_n::<0>(x) };
        let (m, h, f) = (&self.m[..n * n], &mut self.l[..n * n], &self.f[..n]);
        let (d_inv, x) = (&mut self.d_inv[..n], &mut x[..n]);
        let mut scale = 0.0f64;
        for k in 0..n {
            h[k * n + k] = m[k * n + k];
            scale = scale.max(m[k * n + k].abs());
            let mut a = above[k];
            while a != NONE {
                h[k * n + a] = m[k * n + a];
                a = above[a];
            }
        }
        // Leaves first: eliminating speed k updates the rows of its ancestors i (their entries
        // with their own ancestors j, still unscaled in row k), then row k becomes L's.
        for k in (0..n).rev() {
            let d = h[k * n + k];
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(self.pivot_error(k, d));
            }
            let dk_inv = 1.0 / d;
            d_inv[k] = dk_inv;
            let mut i = above[k];
            while i != NONE {
                let lki = h[k * n + i] * dk_inv;
                let mut j = i;
                while j != NONE {
                    h[i * n + j] -= lki * h[k * n + j];
                    j = above[j];
                }
                h[k * n + i] = lki;
                i = above[i];
            }
        }
        // Lᵀ z = F (leaves first: z_k is final once its descendants are done), D, then L x = z.
        x.copy_from_slice(f);
        for k in (0..n).rev() {
            let xk = x[k];
            let mut i = above[k];
            while i != NONE {
                x[i] -= h[k * n + i] * xk;
                i = above[i];
            }
        }
        for (xk, d) in x.iter_mut().zip(d_inv.iter()) {
            *xk *= d;
        }
        for k in 0..n {
            let (mut s, mut i) = (x[k], above[k]);
            while i != NONE {
                s -= h[k * n + i] * x[i];
                i = above[i];
            }
            x[k] = s;
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
