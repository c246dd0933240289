//! The leaves-first LDLᵀ factorisation and solve of `M u̇ = F` along the speeds' tree, and the
//! choice of it at build.
//!
//! The factorisation is `M = Lᵀ D L` of a matrix with branch-induced sparsity (Featherstone,
//! *Rigid Body Dynamics Algorithms*, §6.5): M_kj ≠ 0 only when one of speeds k and j is an
//! ancestor of the other, and eliminating a leaf first changes only entries between its
//! ancestors, which are already in the pattern, so L keeps M's pattern (no fill-in) and the work
//! is Σ_k (depth_k + 1)² rather than n³/6: linear in n for a rotor carrying many absorbers.

use super::{Form, GROUND_PARENT, Model, NO_COORD, NONE, PIVOT_TOL, Workspace};
use crate::error::EngineError;

impl Model {
    /// The speeds' tree (each speed's nearest speed above it) when the right-hand side should
    /// factorise M along it: M of a tree is nonzero only between a speed and its ancestors, so
    /// the leaves-first factorisation costs Σ_k (depth_k + 1)² instead of the dense n³/6, and
    /// is chosen beyond the fixed-size instances (n > 6) where it halves the work at least (a
    /// rotor with 8 pendulums on: measured in BENCHMARKS.md). A geared mechanism's reduced M couples across branches: dense.
    pub(super) fn tree_order(&self) -> Option<Vec<usize>> {
        let n = self.n;
        if n <= 6 || self.form == Form::Geared {
            return None;
        }
        let above = self.speed_tree();
        if above.iter().enumerate().any(|(k, &a)| a != NONE && a >= k) {
            return None;
        }
        let mut cost = 0.0;
        for k in 0..n {
            let (mut depth, mut a) = (1.0, above[k]);
            while a != NONE {
                depth += 1.0;
                a = above[a];
            }
            cost += depth * depth;
        }
        let dense = (n * n * n) as f64 / 6.0;
        (2.0 * cost < dense).then_some(above)
    }

    /// Per speed, the nearest speed above it in the tree (`NONE` for none): the parent in the
    /// tree of M's sparsity.
    pub(super) fn speed_tree(&self) -> Vec<usize> {
        (0..self.n)
            .map(|k| {
                let mut b = self.nodes[self.joint_of[k]].parent;
                while b != GROUND_PARENT && self.nodes[b].coord == NO_COORD {
                    b = self.nodes[b].parent;
                }
                if b == GROUND_PARENT { NONE } else { self.nodes[b].coord }
            })
            .collect()
    }

    /// Solves `M x = F` by the leaves-first factorisation `M = Lᵀ D L` along the speeds' tree
    /// (`self.tree`; see the module doc), L stored in place of M's below-diagonal entries in
    /// `l`, D⁻¹ in `d_inv`. Only entries between a speed and its ancestors are read.
    pub(super) fn factor_solve_tree(&self, ws: &mut Workspace, x: &mut [f64]) -> Result<(), EngineError> {
        let n = self.n;
        let Some(above) = self.tree.as_deref() else { return self.factor_solve_n::<0>(ws, x) };
        let (m, h, f) = (&ws.m[..n * n], &mut ws.l[..n * n], &ws.f[..n]);
        let (d_inv, x) = (&mut ws.d_inv[..n], &mut x[..n]);
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
        // NOTE: a speed whose only ancestor is a root p (a rotor's pendulums) updates h_pp alone;
        // over a run of such speeds with the same p, h_pp is kept in a register (`run`): the
        // same subtractions in the same order, without a store and a reload per speed on the
        // chain of dependent updates (measured, BENCHMARKS.md). Flushed before anything else
        // reads or writes h_pp.
        let star = |k: usize| above[k] != NONE && above[above[k]] == NONE;
        let mut run: Option<(usize, f64)> = None;
        for k in (0..n).rev() {
            let p = above[k];
            if let Some((rp, v)) = run
                && (rp != p || !star(k))
            {
                h[rp * n + rp] = v;
                run = None;
            }
            let d = h[k * n + k];
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(self.pivot_error(k, d));
            }
            let dk_inv = 1.0 / d;
            d_inv[k] = dk_inv;
            if star(k) {
                let v = run.map_or(h[p * n + p], |r| r.1);
                let lkp = h[k * n + p] * dk_inv;
                run = Some((p, v - lkp * h[k * n + p]));
                h[k * n + p] = lkp;
                continue;
            }
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
        if let Some((rp, v)) = run {
            h[rp * n + rp] = v;
        }
        // Lᵀ z = F (leaves first: z_k is final once its descendants are done), D, then L x = z;
        // the first with the same register run as the factorisation.
        x.copy_from_slice(f);
        let mut run: Option<(usize, f64)> = None;
        for k in (0..n).rev() {
            let p = above[k];
            if let Some((rp, v)) = run
                && (rp != p || !star(k))
            {
                x[rp] = v;
                run = None;
            }
            let xk = x[k];
            if star(k) {
                let v = run.map_or(x[p], |r| r.1);
                run = Some((p, v - h[k * n + p] * xk));
                continue;
            }
            let mut i = above[k];
            while i != NONE {
                x[i] -= h[k * n + i] * xk;
                i = above[i];
            }
        }
        if let Some((rp, v)) = run {
            x[rp] = v;
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
}
