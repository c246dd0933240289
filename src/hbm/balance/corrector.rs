//! The pseudo-arclength corrector that the continuation steps with, with the scaled parameter λ = p/p_ref
//! it works in ([`Setup`]): the bordered system
//! `[[∂R̂/∂x, ∂R̂/∂λ], [tᵀ]]` that stays regular through turning points, the unit tangent it
//! yields, Newton's method on it, and the Newton–chord iteration with good-Broyden updates
//! (Kelley §7.3) that reuses one factorisation per point.

use super::options::HbmError;
use super::parameter::{At, Parameter};
use super::problem::Hbm;
use crate::hbm::numerics::{BlockLu, Factor};
use crate::hbm::series::HbmSolution;
use nalgebra::{DMatrix, DVector};

/// A continuation's parameter, its scale and the values held fixed, and the weights of its
/// arclength: the continuation works in `y = (w ⊙ x, λ)`, w = 1 on the spin coordinate's
/// unknowns (its harmonics and the mean torque) and `weight` on every other coordinate's.
#[derive(Debug, Clone, Copy)]
pub(in crate::hbm) struct Setup {
    pub(in crate::hbm) param: Parameter,
    pub(in crate::hbm) p_ref: f64,
    pub(in crate::hbm) base: At,
    /// The weight of the coordinates other than the spin one: 1/√(n_dof − 1), so that the
    /// arclength measures their root mean square. N absorbers moving alike then take the steps of
    /// one (without it a step in the parameter shrank as 1/√N: 16 mistuned pendulums took four
    /// times the points of one); 1 for the paper's rotor and every two-coordinate problem.
    pub(in crate::hbm) weight: f64,
    /// The spin coordinate's unknowns, `spin·nb..(spin + 1)·nb`.
    pub(in crate::hbm) spin: (usize, usize),
}

impl Setup {
    /// The setup of `hbm` for `param` (scale `p_ref`, fixed values `base`).
    pub(in crate::hbm) fn new(hbm: &Hbm, param: Parameter, p_ref: f64, base: At) -> Self {
        let weight = if hbm.n > 2 { 1.0 / ((hbm.n - 1) as f64).sqrt() } else { 1.0 };
        Self { param, p_ref, base, weight, spin: (hbm.spin * hbm.nb, (hbm.spin + 1) * hbm.nb) }
    }

    /// The arclength weight of unknown i.
    pub(in crate::hbm) fn w(&self, i: usize) -> f64 {
        if (self.spin.0..self.spin.1).contains(&i) { 1.0 } else { self.weight }
    }

    /// The unknowns x of a continuation state y (its first `m` entries divided by the weights).
    pub(in crate::hbm) fn x_of(&self, y: &[f64], m: usize) -> Vec<f64> {
        y[..m].iter().enumerate().map(|(i, v)| v / self.w(i)).collect()
    }

    /// The residual's parameters at scaled parameter λ.
    pub(in crate::hbm) fn at(&self, lambda: f64) -> At {
        let mut at = self.base;
        match self.param {
            Parameter::Order => at.order = lambda,
            Parameter::Speed { .. } => at.omega = lambda * self.p_ref,
            Parameter::TorqueScale { .. } => at.scale = lambda,
        }
        at
    }

    /// λ of a solution.
    pub(in crate::hbm) fn lambda(&self, sol: &HbmSolution) -> f64 {
        match self.param {
            Parameter::Order => sol.order,
            Parameter::Speed { .. } => sol.omega / self.p_ref,
            Parameter::TorqueScale { .. } => sol.torque_scale,
        }
    }

    /// A scaled parameter the residual can be evaluated at.
    pub(in crate::hbm) fn valid(&self, lambda: f64) -> bool {
        lambda.is_finite() && (lambda > 0.0 || matches!(self.param, Parameter::TorqueScale { .. }))
    }
}

/// A factorised bordered matrix for the chord iterations. The matrix bordered by the new tangent
/// t differs from the one factorised for computing t (bordered by the previous tangent t₀) in
/// the last row only, so it is applied by the Sherman–Morrison formula instead of a second
/// factorisation: with `z = B₀⁻¹ e_last` (the unnormalised tangent, t₀ᵀz = 1) and `d = t − t₀`,
/// `B⁻¹r = B₀⁻¹r − z (dᵀB₀⁻¹r) / (1 + dᵀz)`, and `1 + dᵀz = tᵀz = |z| > 0`.
pub(in crate::hbm) struct Chord {
    pub(in crate::hbm) lu: Factor,
    pub(in crate::hbm) update: Option<(DVector<f64>, DVector<f64>, f64)>,
}

impl Chord {
    pub(in crate::hbm) fn solve(&self, r: &DVector<f64>) -> Option<DVector<f64>> {
        let mut y = self.lu.solve(r)?;
        if let Some((z, d, denom)) = &self.update {
            let f = d.dot(&y) / denom;
            y.axpy(-f, z, 1.0);
        }
        Some(y)
    }
}

impl Hbm {
    /// The Jacobian in the buffers factorised, bordered by `[∂R̂/∂λ; rowᵀ]` when `row` is given:
    /// by block elimination along the tree where its pattern allows it (more than two
    /// coordinates; `blocklu`), densely otherwise (the paper's rotor, two coordinates, stays on
    /// the dense LU).
    pub(in crate::hbm) fn factor(&self, border: Option<(&Setup, &DVector<f64>)>) -> Factor {
        if self.n > 6 {
            let col = border.map(|(su, _)| &self.gp * su.p_ref);
            // The blocks the last assembly left zero are not read: reading them (most of 357²
            // entries on 16 absorbers) only to find them zero was a quarter of the
            // factorisation.
            let zero = Some(&self.zero_blocks[..]);
            let block = match (&col, border) {
                (Some(col), Some((su, row))) => {
                    let scale: Vec<f64> = (0..self.n * self.nb).map(|i| 1.0 / su.w(i)).collect();
                    BlockLu::new(&self.jac, Some((col, row, &scale)), self.n, self.nb, self.spin, zero)
                }
                _ => BlockLu::new(&self.jac, None, self.n, self.nb, self.spin, zero),
            };
            if let Some(b) = block {
                return Factor::Block(Box::new(b));
            }
        }
        match border {
            Some((su, row)) => Factor::Dense(self.bordered(su, row).lu()),
            None => Factor::Dense(self.jac.clone().lu()),
        }
    }

    /// The bordered matrix `[[J, ∂R̂/∂λ], [rowᵀ]]` from the work buffers (∂R̂/∂λ = p_ref ∂R̂/∂p).
    pub(in crate::hbm) fn bordered(&self, su: &Setup, row: &DVector<f64>) -> DMatrix<f64> {
        let m = self.unknowns();
        let mut b = DMatrix::zeros(m + 1, m + 1);
        b.view_mut((0, 0), (m, m)).copy_from(&self.jac);
        // ∂R̂/∂y = ∂R̂/∂x / w: the continuation's unknowns are weighted (`Setup`).
        if su.weight != 1.0 {
            for c in 0..m {
                let w = su.w(c);
                if w != 1.0 {
                    b.view_mut((0, c), (m, 1)).scale_mut(1.0 / w);
                }
            }
        }
        b.view_mut((0, m), (m, 1)).copy_from(&(&self.gp * su.p_ref));
        b.view_mut((m, 0), (1, m + 1)).copy_from(&row.transpose());
        b
    }

    /// Unit tangent from the buffers' Jacobian, oriented by `row` (previous tangent).
    pub(in crate::hbm) fn tangent(&self, su: &Setup, row: &DVector<f64>, order: f64) -> Result<DVector<f64>, HbmError> {
        Ok(self.tangent_chord(su, row, order)?.0)
    }

    /// Like [`Hbm::tangent`], also returning the chord matrix bordered by the new tangent.
    pub(in crate::hbm) fn tangent_chord(
        &self,
        su: &Setup,
        row: &DVector<f64>,
        order: f64,
    ) -> Result<(DVector<f64>, Chord), HbmError> {
        let m = self.unknowns();
        let mut rhs = DVector::zeros(m + 1);
        rhs[m] = 1.0;
        let lu = self.factor(Some((su, row)));
        let z = lu.solve(&rhs).ok_or(HbmError::Singular { order })?;
        let norm = z.norm();
        if !norm.is_finite() || norm == 0.0 {
            return Err(HbmError::NonFinite { order });
        }
        let t = &z / norm;
        let d = &t - row;
        Ok((t, Chord { lu, update: Some((z, d, norm)) }))
    }

    /// Pseudo-arclength corrector from `pred` on the hyperplane normal to `t`.
    pub(in crate::hbm) fn correct(
        &mut self,
        su: &Setup,
        pred: &DVector<f64>,
        t: &DVector<f64>,
        max_iter: usize,
    ) -> Result<(DVector<f64>, usize), HbmError> {
        let m = self.unknowns();
        let mut y = pred.clone();
        let mut step = f64::INFINITY;
        for it in 1..=max_iter {
            let at = su.at(y[m]);
            let order = at.order;
            if !su.valid(y[m]) {
                return Err(HbmError::NonFinite { order });
            }
            let x = su.x_of(y.as_slice(), m);
            self.assemble(&x, &at, Some(su.param));
            let mut rhs = DVector::zeros(m + 1);
            rhs.rows_mut(0, m).copy_from(&self.rhat);
            rhs[m] = t.dot(&(&y - pred));
            let dy = self.factor(Some((su, t))).solve(&rhs).ok_or(HbmError::Singular { order })?;
            step = dy.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            y -= dy;
            if step <= self.opts.tol {
                return Ok((y, it));
            }
        }
        Err(HbmError::NoConvergence { order: su.at(y[m]).order, iterations: max_iter, step })
    }

    /// Newton–chord corrector with Broyden updates: like [`Hbm::correct`], but it iterates with
    /// the bordered matrix factorised at the previous point (`chord`), so an iteration costs one
    /// residual (N_t engine calls) instead of a Jacobian. The chord steps are improved by good
    /// Broyden rank-one updates of the inverse, kept as the step vectors only (Kelley, *Iterative
    /// Methods for Linear and Nonlinear Equations*, SIAM 1995, §7.3): superlinear instead of linear
    /// convergence for O(m) work per stored step (fewer corrector iterations, and fewer points as
    /// the step control sees fewer iterations; counts in `BENCHMARKS.md`).
    /// When a step contracts by less than half, the Jacobian is refreshed at the
    /// current iterate (at most `max_refresh` times) and the updates restart from it. Returns the
    /// point, the iterations and the refreshes.
    pub(in crate::hbm) fn correct_chord(
        &mut self,
        su: &Setup,
        chord: &Chord,
        pred: &DVector<f64>,
        t: &DVector<f64>,
        max_iter: usize,
        max_refresh: usize,
    ) -> Result<(DVector<f64>, usize, usize), HbmError> {
        let m = self.unknowns();
        let mut y = pred.clone();
        let mut x = vec![0.0; m];
        let mut rhs = DVector::zeros(m + 1);
        let mut last = f64::INFINITY;
        let mut fresh: Option<Chord> = None;
        let mut refreshes = 0;
        // Broyden steps s_j taken since the last (re)start, and |s_j|².
        let mut steps: Vec<(DVector<f64>, f64)> = Vec::new();
        for it in 1..=max_iter {
            let at = su.at(y[m]);
            let order = at.order;
            if !su.valid(y[m]) {
                return Err(HbmError::NonFinite { order });
            }
            for (i, (xi, yi)) in x.iter_mut().zip(&y.as_slice()[..m]).enumerate() {
                *xi = yi / su.w(i);
            }
            self.assemble(&x, &at, None);
            rhs.rows_mut(0, m).copy_from(&self.rhat);
            rhs[m] = t.dot(&(&y - pred));
            // Step s = −B⁻¹g with B the Broyden-updated chord matrix.
            let mut s = -fresh.as_ref().unwrap_or(chord).solve(&rhs).ok_or(HbmError::Singular { order })?;
            for w in steps.windows(2) {
                let f = w[0].0.dot(&s) / w[0].1;
                s.axpy(f, &w[1].0, 1.0);
            }
            if let Some((sn, nn)) = steps.last() {
                let denom = 1.0 - sn.dot(&s) / nn;
                if denom.abs() > 1e-12 {
                    s /= denom;
                }
            }
            let mut step = s.amax();
            if it > 1 && step > 0.5 * last && refreshes < max_refresh {
                self.assemble(&x, &at, Some(su.param));
                let f = Chord { lu: self.factor(Some((su, t))), update: None };
                s = -f.solve(&rhs).ok_or(HbmError::Singular { order })?;
                step = s.amax();
                fresh = Some(f);
                refreshes += 1;
                steps.clear();
            } else if it > 1 && step > 0.5 * last {
                return Err(HbmError::NoConvergence { order, iterations: it, step });
            }
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            y += &s;
            if step <= self.opts.tol {
                return Ok((y, it, refreshes));
            }
            let nn = s.norm_squared();
            steps.push((s, nn));
            last = step;
        }
        Err(HbmError::NoConvergence { order: su.at(y[m]).order, iterations: max_iter, step: last })
    }
}
