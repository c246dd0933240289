//! [`Hbm::switch_at`]: the symmetric state at the branch point, its antisymmetric null vector,
//! the predictor along it and the start of the continuation (the steps of the room's docs).

use crate::hbm::balance::{Hbm, HbmError, Parameter, Setup, Symmetry};
use crate::hbm::continuation::{Branch, ContinuationOptions, Cursor};
use crate::hbm::series::HbmSolution;
use nalgebra::DVector;

/// The predictor's offset along the null vector, as a fraction of the weighted norm of the
/// non-spin unknowns at the branch point (the room's docs, step 3).
const EPS_FRACTION: f64 = 0.02;

/// The largest ratio σ₁/σ₂ of the two smallest singular values of ∂R̂/∂x accepted as a branch
/// point with a one-dimensional kernel (the room's docs, step 2). At a located branch point σ₁ is
/// of the order of the location's error times dσ₁/dp, ~1e-8 relative.
const KERNEL_RATIO: f64 = 1e-3;

impl Hbm {
    /// Switches at a symmetry-breaking branch point onto the non-symmetric branch and continues
    /// it in `parameter` inside the range `range` = (from, to) (order n; Ω in rad/s; torque
    /// scale s), with stability when `copts.stability`: see the switch room's docs.
    /// `value` is the branch point's parameter (as located on the symmetric branch),
    /// `guess` a solution of the symmetric branch near it (every coordinate an unknown; for
    /// [`Symmetry::HalfPeriod`] a state of the period-1 problem or of this one), `symmetry` the
    /// symmetry broken there: identical absorbers swapped, or (on the problem of half the base
    /// frequency) the half-period shift, at a period doubling.
    ///
    /// Errors name the failure: no branch point at `value` (the Jacobian is regular there, or
    /// its kernel is symmetric: a fold), a kernel of dimension two, a correction that did not
    /// converge.
    pub fn switch_at(
        &mut self,
        parameter: Parameter,
        value: f64,
        guess: &HbmSolution,
        symmetry: &Symmetry,
        range: (f64, f64),
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let (tol, one_sided) = (self.opts.tol, self.ev.one_sided);
        self.opts.tol = copts.corrector_tol.unwrap_or(tol);
        self.ev.one_sided = false;
        let branch = self.switch_with_tol(parameter, value, guess, symmetry, range, copts);
        (self.opts.tol, self.ev.one_sided) = (tol, one_sided);
        branch
    }

    fn switch_with_tol(
        &mut self,
        parameter: Parameter,
        value: f64,
        guess: &HbmSolution,
        symmetry: &Symmetry,
        (from, to): (f64, f64),
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let bad = |m: String| Err(HbmError::Invalid(format!("branch switch at {value}: {m}")));
        let (n, nb) = (self.n, self.nb);
        if let Err(why) = self.admits(symmetry) {
            return bad(why);
        }
        if !(value.is_finite() && from.is_finite() && to.is_finite() && from != to) {
            return bad(format!("the range {from} → {to} must be finite and non-empty"));
        }
        let (lo, hi) = (from.min(to), from.max(to));
        if !(lo..=hi).contains(&value) {
            return bad(format!("the branch point lies outside the range {from} → {to}"));
        }
        let (p_ref, order) = match parameter {
            Parameter::Order => (1.0, value),
            Parameter::Speed { order } => (from.abs(), order),
            Parameter::TorqueScale { order } => (1.0, order),
        };
        self.check_base(order)?;
        let su = Setup::new(self, parameter, p_ref, self.at(order));
        let m = self.unknowns();
        let permute = |x: &[f64]| symmetry.apply(x, n, nb);
        // 1. The symmetric solution at the branch point, symmetrised.
        let l_star = value / p_ref;
        let symmetric = |x: &[f64]| -> Vec<f64> { x.iter().zip(permute(x)).map(|(a, b)| 0.5 * (a + b)).collect() };
        let guess = match symmetry {
            Symmetry::HalfPeriod => self.on_doubled_period(guess, order)?,
            Symmetry::Swap(_) => guess.clone(),
        };
        let mut x_star = symmetric(&self.unknowns_from(Some(&guess)));
        let mut converged = false;
        let mut step = f64::INFINITY;
        for _ in 0..self.opts.max_iter.max(20) {
            self.assemble(&x_star, &su.at(l_star), Some(parameter));
            let dx = self.jac.clone().lu().solve(&self.rhat).ok_or(HbmError::Singular { order })?;
            // Newton restricted to the symmetric states: ∂R̂/∂x is singular at the branch point
            // only along the antisymmetric φ, which the projection removes (plain Newton stalls
            // there at a step of ~1e-6, the round-off amplified along φ).
            let dx = symmetric(dx.as_slice());
            step = dx.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            for (x, d) in x_star.iter_mut().zip(&dx) {
                *x -= d;
            }
            if step <= self.opts.tol {
                converged = true;
                break;
            }
        }
        if !converged {
            return bad(format!("the symmetric solution at the branch point did not converge (last step {step:.3e})"));
        }
        // 2. The null vector of ∂R̂/∂x.
        self.assemble(&x_star, &su.at(l_star), Some(parameter));
        let svd = self.jac.clone().svd(false, true);
        let v_t = svd.v_t.as_ref().ok_or(HbmError::Singular { order })?;
        let mut idx: Vec<usize> = (0..svd.singular_values.len()).collect();
        idx.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
        let (s1, s2) = (svd.singular_values[idx[0]], svd.singular_values[idx[1]]);
        if s1 > KERNEL_RATIO * s2 {
            return bad(format!(
                "no branch point here: ∂R̂/∂x is regular (its smallest singular values {s1:.3e} and {s2:.3e})"
            ));
        }
        let v: Vec<f64> = v_t.row(idx[0]).iter().copied().collect();
        let pv = permute(&v);
        let phi: Vec<f64> = v.iter().zip(&pv).map(|(a, b)| 0.5 * (a - b)).collect();
        let anti = phi.iter().map(|a| a * a).sum::<f64>().sqrt();
        if anti < 0.5 {
            return bad(format!(
                "the null vector of ∂R̂/∂x is symmetric (antisymmetric part {anti:.3}): a fold, not a symmetry breaking"
            ));
        }
        if s2 <= KERNEL_RATIO * svd.singular_values[idx[2.min(idx.len() - 1)]] {
            return bad("the kernel of ∂R̂/∂x is two-dimensional (more than two identical absorbers?)".into());
        }
        // 3. Predictor along φ (in the continuation's weighted unknowns).
        let mut phi_y = DVector::from_fn(m + 1, |i, _| if i < m { phi[i] * su.w(i) } else { 0.0 });
        phi_y /= phi_y.norm();
        let mut y_star = DVector::from_fn(m + 1, |i, _| if i < m { x_star[i] * su.w(i) } else { l_star });
        y_star[m] = l_star;
        let size = (0..m).filter(|i| !(su.spin.0..su.spin.1).contains(i)).map(|i| y_star[i] * y_star[i]).sum::<f64>();
        let eps = EPS_FRACTION * size.sqrt();
        if eps <= 0.0 {
            return bad("the absorbers do not move at the branch point".into());
        }
        let pred = &y_star + &phi_y * eps;
        // 4. One correction on the hyperplane φᵀ(y − y_pred) = 0, then the continuation.
        let (y1, it) = self.correct(&su, &pred, &phi_y, self.opts.max_iter.max(20)).map_err(|e| {
            HbmError::Invalid(format!("branch switch at {value}: the corrector off the branch point failed ({e})"))
        })?;
        let (l_from, l_to) = (from / p_ref, to / p_ref);
        if !((l_from.min(l_to))..=(l_from.max(l_to))).contains(&y1[m]) {
            return bad(format!("the switched branch starts outside the range, at {}", y1[m] * p_ref));
        }
        self.assemble(&su.x_of(y1.as_slice(), m), &su.at(y1[m]), Some(parameter));
        let t1 = self.tangent(&su, &phi_y, su.at(y1[m]).order)?;
        self.follow(&su, Cursor { y: y1, t: t1 }, it, (l_from, l_to), it, copts, Some((&phi, symmetry)))
    }

    /// Why this problem does not have `symmetry`, if it does not.
    fn admits(&self, symmetry: &Symmetry) -> Result<(), String> {
        let n = self.n;
        match symmetry {
            Symmetry::Swap(mirror) => {
                let mut seen = vec![false; n];
                for &k in mirror {
                    if k < n {
                        seen[k] = true;
                    }
                }
                if mirror.len() != n || seen.iter().any(|s| !s) || mirror[self.spin] != self.spin {
                    return Err(format!(
                        "the mirror {mirror:?} is not a permutation of the {n} coordinates fixing the spin"
                    ));
                }
                if mirror.iter().enumerate().all(|(i, &k)| i == k) {
                    return Err("the mirror permutation is the identity: no symmetry to break".into());
                }
            }
            Symmetry::HalfPeriod => {
                // The forcing must repeat after half the base period: an even number of samples
                // and every excitation series equal to itself shifted by half of them.
                let nt = self.aft.nt;
                let half_periodic = |e: &[f64]| {
                    e.chunks(nt).all(|row| {
                        (0..nt / 2).all(|j| (row[j] - row[j + nt / 2]).abs() <= 1e-12 * (1.0 + row[j].abs()))
                    })
                };
                if !self.cyclic {
                    return Err(
                        "a period-doubled branch needs a cyclic spin angle (no gravity, no world-frame force)".into()
                    );
                }
                if !nt.is_multiple_of(2) || !half_periodic(&self.exc) || !half_periodic(&self.exc2) {
                    return Err("the problem's base frequency is not half the excitation's: build it with the extra \
                                multiple of half the excitation's base (amplitude zero) to switch at a period doubling"
                        .into());
                }
            }
        }
        Ok(())
    }

    /// `guess` on this problem's base: as it is when both bases agree; a state of the
    /// period-1 problem (base twice this one's, as on the problem of half the base frequency
    /// that [`Symmetry::HalfPeriod`] needs) with its harmonic h moved to 2h. An error names any
    /// other ratio (`order` is the excitation order, for the message).
    pub fn on_doubled_period(&self, guess: &HbmSolution, order: f64) -> Result<HbmSolution, HbmError> {
        let ratio = |s: &HbmSolution| s.base_frequency / (s.order * s.omega);
        let r = ratio(guess) / self.ratio;
        if (r - 1.0).abs() < 1e-9 {
            return Ok(guess.clone());
        }
        if (r - 2.0).abs() > 1e-9 {
            return Err(HbmError::Invalid(format!(
                "branch switch at {order}: the guess's base frequency is {r} times this problem's (1 or 2 expected)"
            )));
        }
        let (n, nb, h_max) = (guess.ndof(), self.nb, self.opts.harmonics);
        let mut coefficients = vec![0.0; n * nb];
        for k in 0..n {
            coefficients[k * nb] = guess.coefficient(k, 0).0;
            for h in 1..=guess.harmonics.min(h_max / 2) {
                let (a, b) = guess.coefficient(k, h);
                (coefficients[k * nb + 4 * h - 1], coefficients[k * nb + 4 * h]) = (a, b);
            }
        }
        Ok(HbmSolution {
            base_frequency: guess.base_frequency / 2.0,
            harmonics: h_max,
            coefficients,
            stability: None,
            ..guess.clone()
        })
    }
}
