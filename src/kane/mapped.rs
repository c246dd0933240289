//! The composite-body form ([`super::rates`]) for absolute angular velocities on a tree that is
//! not purely revolute: the joint-rate form evaluated at `q̇ = W⁻¹u`, then mapped to the speeds.
//!
//! With `q̇ = B u` (B = W⁻¹, constant), the partial velocities for the speeds are those for the
//! joint rates times B, so Kane's sums become `M ← Bᵀ M B` and `F ← Bᵀ F`; `Ḃ = 0` adds no
//! velocity term.

use super::{Model, Workspace};

impl Model {
    /// [`super::Form::MappedRates`]: the joint-rate form at `q̇ = W⁻¹u`, mapped to the speeds.
    ///
    /// NOTE: kept out of line so the code of this rarer form does not crowd the pair form's
    /// registers in the hot, literal-n evaluation (measured, BENCHMARKS.md).
    #[inline(never)]
    pub(super) fn evaluate_mapped(&self, ws: &mut Workspace, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let mut rates = std::mem::take(&mut ws.qdot);
        if forcing {
            self.speeds.qdot(&self.speed_parent, &u[..self.n], &mut rates);
        }
        self.evaluate_rates::<0>(ws, t, q, &rates, forcing);
        if !self.rollers.is_empty() {
            self.add_rollers(ws, q, &rates, forcing);
        }
        ws.qdot = rates;
        self.map_rates_to_speeds(ws, forcing);
    }

    /// Maps M and F from joint rates to absolute angular velocities: with `q̇ = B u`,
    /// `M ← Bᵀ M B` and `F ← Bᵀ F`. B has ones on the diagonal and `B[k][p] = −1` for each
    /// coordinate k with speed parent p < k, so column (then row) p takes away column (row) k,
    /// in increasing k so that every column subtracted is still the original one.
    fn map_rates_to_speeds(&self, ws: &mut Workspace, forcing: bool) {
        let n = self.n;
        let (m, f) = (&mut ws.m[..n * n], &mut ws.f[..n]);
        for k in 0..n {
            if let Some(p) = self.speed_parent[k] {
                for r in 0..n {
                    m[r * n + p] -= m[r * n + k];
                }
            }
        }
        for k in 0..n {
            if let Some(p) = self.speed_parent[k] {
                for c in 0..n {
                    m[p * n + c] -= m[k * n + c];
                }
                if forcing {
                    f[p] -= f[k];
                }
            }
        }
        // Bᵀ M B is symmetric, but the two passes round its halves differently: mirror the lower.
        for r in 0..n {
            for c in 0..r {
                m[c * n + r] = m[r * n + c];
            }
        }
    }
}
