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

    /// True when the speeds' tree `above` is roots and leaves alone: every speed with a speed
    /// above it hangs from a root and has none below it (a rotor carrying pendulums), the case
    /// of [`Model::factor_solve_star`].
    pub(super) fn is_star(above: &[usize]) -> bool {
        let mut has_child = vec![false; above.len()];
        for &a in above {
            if a != NONE {
                has_child[a] = true;
            }
        }
        above.iter().enumerate().all(|(k, &a)| a == NONE || (above[a] == NONE && !has_child[k]))
    }

    /// [`Model::factor_solve_tree`] for a tree of roots and leaves ([`Model::is_star`]): the same
    /// operations in the same order, so the same result to the bit, in one pass over the leaves
    /// that eliminates each leaf and updates its root's right-hand side together.
    ///
    /// NOTE: the general loop's cost at 32 pendulums was its bookkeeping (the ancestor walks'
    /// tests, the run's flushes, a serial chain of `max` for the pivot scale), not its
    /// arithmetic (measured, BENCHMARKS.md); here a leaf's pivot is its own diagonal entry and
    /// its one factor entry is kept in `row`.
    fn factor_solve_star(&self, ws: &mut Workspace, above: &[usize], x: &mut [f64]) -> Result<(), EngineError> {
        let n = self.n;
        let (m, f) = (&ws.m[..n * n], &ws.f[..n]);
        let (d_inv, l, x, above) = (&mut ws.d_inv[..n], &mut ws.row[..n], &mut x[..n], &above[..n]);
        // The largest diagonal entry, in four independent maxima (max is exact, so the order
        // does not matter).
        let mut sc = [0.0f64; 4];
        for k in 0..n {
            sc[k % 4] = sc[k % 4].max(m[k * n + k].abs());
        }
        let scale = sc[0].max(sc[1]).max(sc[2].max(sc[3]));
        x.copy_from_slice(f);
        // A root's pivot is accumulated in its `d_inv` entry until its turn; over a run of its
        // leaves (descending index: a leaf's root has a smaller one) it and the root's
        // right-hand side stay in registers instead.
        for k in 0..n {
            if above[k] == NONE {
                d_inv[k] = m[k * n + k];
            }
        }
        let (mut rp, mut hv, mut zv) = (NONE, 0.0, 0.0);
        for k in (0..n).rev() {
            let p = above[k];
            if p == NONE {
                if rp == k {
                    (d_inv[k], x[k], rp) = (hv, zv, NONE);
                }
                let d = d_inv[k];
                if d.is_nan() || d <= PIVOT_TOL * scale {
                    return Err(self.pivot_error(k, d));
                }
                d_inv[k] = 1.0 / d;
                continue;
            }
            if rp != p {
                if rp != NONE {
                    (d_inv[rp], x[rp]) = (hv, zv);
                }
                (rp, hv, zv) = (p, d_inv[p], x[p]);
            }
            let d = m[k * n + k];
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(self.pivot_error(k, d));
            }
            let dk_inv = 1.0 / d;
            d_inv[k] = dk_inv;
            let mkp = m[k * n + p];
            let lkp = mkp * dk_inv;
            hv -= lkp * mkp;
            zv -= lkp * x[k];
            l[k] = lkp;
        }
        for k in 0..n {
            let p = above[k];
            x[k] *= d_inv[k];
            if p != NONE {
                x[k] -= l[k] * x[p];
            }
        }
        Ok(())
    }

    /// Solves `M x = F` by the leaves-first factorisation `M = Lᵀ D L` along the speeds' tree
    /// (`self.tree`; see the module doc), L stored in place of M's below-diagonal entries in
    /// `l`, D⁻¹ in `d_inv`. Only entries between a speed and its ancestors are read.
    pub(super) fn factor_solve_tree(&self, ws: &mut Workspace, x: &mut [f64]) -> Result<(), EngineError> {
        let n = self.n;
        let Some(above) = self.tree.as_deref() else { return self.factor_solve_n::<0>(ws, x) };
        if self.star {
            return self.factor_solve_star(ws, above, x);
        }
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
