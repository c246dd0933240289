//! Newton's method at fixed parameters: the unknowns from a guess, the iteration on the
//! balance `R̂(x) = 0` with the Jacobian factorised by blocks or densely, and the solution record
//! with its harmonic-count indicators (the room's docs, "Harmonic count").

use super::options::HbmError;
use super::parameter::{At, Parameter};
use super::problem::Hbm;
use crate::hbm::series::HbmSolution;
use realfft::num_complex::Complex;
use std::f64::consts::PI;

impl Hbm {
    /// Unknowns vector from a solution (resampled to this problem's H), or zero.
    pub(in crate::hbm) fn unknowns_from(&self, guess: Option<&HbmSolution>) -> Vec<f64> {
        let (n, nb) = (self.n, self.nb);
        let mut x = vec![0.0; n * nb];
        if let Some(g) = guess.filter(|g| g.ndof() == n) {
            for k in 0..n {
                let src = &g.coefficients[k * g.nb()..(k + 1) * g.nb()];
                let m = src.len().min(nb);
                x[k * nb..k * nb + m].copy_from_slice(&src[..m]);
            }
            x[self.spin * nb] = g.mean_torque / self.t_scale;
        }
        x
    }

    /// The solution record for unknowns x at `at` (fills the residual norm and the harmonic
    /// check; no stability).
    pub(in crate::hbm) fn solution_from(&mut self, x: &[f64], at: &At, iterations: usize) -> HbmSolution {
        let order = at.order;
        // The residual is already in the buffer when the last assembly was at this very point
        // (as after the continuation's Jacobian at an accepted point).
        if !self.rhat_at.as_ref().is_some_and(|(xs, a)| a == at && xs.as_slice() == x) {
            self.assemble(x, at, None);
        }
        let residual = self.rhat.amax();
        let mut coefficients = x.to_vec();
        coefficients[self.spin * self.nb] = 0.0;
        let mut sol = HbmSolution {
            order,
            omega: at.omega,
            torque_scale: at.scale,
            base_frequency: self.ratio * order * at.omega,
            harmonics: self.opts.harmonics,
            spin: self.spin,
            rotation: self.rotation.clone(),
            coefficients,
            mean_torque: x[self.spin * self.nb] * self.t_scale,
            iterations,
            residual,
            top_harmonic_ratio: 0.0,
            coupling_tail: 0.0,
            needs_more_harmonics: false,
            stability: None,
        };
        sol.top_harmonic_ratio = sol.harmonic_ratio();
        sol.coupling_tail = self.coupling_tail(at);
        sol.needs_more_harmonics =
            sol.top_harmonic_ratio > self.opts.harmonic_tol || sol.coupling_tail > self.opts.coupling_tol;
        sol
    }

    /// The convergence indicator of the couplings' harmonic content at the samples of the last
    /// assembly (section "Harmonic count" of the room's docs): per coupled coordinate, the
    /// coupling force τ(q(t), q̇(t)) at the N_t samples, its discrete spectrum F_m
    /// (m ≤ N_t/2), and `(Σ_{m>H} |F_m|² / Σ_{m≥1} |F_m|²)^½`, the share of its oscillating
    /// content the balance of H harmonics drops; the largest over the couplings (0 without).
    fn coupling_tail(&mut self, at: &At) -> f64 {
        let (nt, hh) = (self.aft.nt, self.opts.harmonics);
        let w0 = self.ratio * at.order * at.omega;
        let mut spec = vec![Complex::default(); self.aft.half_len()];
        let mut worst = 0.0f64;
        for (k, law) in &self.couplings {
            let k = *k;
            for j in 0..nt {
                let t = 2.0 * PI * j as f64 / nt as f64 / w0;
                let (mut q, mut qd) = (self.qt[k * nt + j], self.qdt[k * nt + j]);
                q += self.rotation[k] * at.omega * t;
                qd += self.rotation[k] * at.omega;
                self.series[j] = law.torque(q, qd);
            }
            self.aft.spectrum(&self.series, &mut spec);
            let power = |m: &Complex<f64>| m.norm_sqr();
            let total: f64 = spec.iter().skip(1).map(power).sum();
            let tail: f64 = spec.iter().skip(hh + 1).map(power).sum();
            if total > 0.0 {
                worst = worst.max((tail / total).sqrt());
            }
        }
        worst
    }

    /// Solves for the periodic steady state at excitation order `order` by Newton's method from
    /// `guess` (a nearby solution; zero coefficients, i.e. the rigid rotation, when None: the
    /// first step is then the linear response). Stability is not computed (see
    /// [`Hbm::stability`]).
    pub fn solve(&mut self, order: f64, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        if !(order.is_finite() && order > 0.0) {
            return Err(HbmError::Invalid(format!("excitation order must be positive and finite, got {order}")));
        }
        self.solve_at(&self.at(order), guess)
    }

    /// With a non-cyclic spin angle (gravity, a world-frame force) the forces repeat every
    /// revolution, so the base period 2π/ω₀ must hold a whole number of revolutions: ω₀/Ω =
    /// ratio·n must be 1/k. An excitation at order 3 with multiples 1 and 2 has base order 3; the
    /// multiple 1/3 (amplitude 0 if need be) brings it to 1.
    pub(in crate::hbm) fn check_base(&self, order: f64) -> Result<(), HbmError> {
        if self.cyclic {
            return Ok(());
        }
        let turns = 1.0 / (self.ratio * order);
        if (turns - turns.round()).abs() > 1e-9 * turns.max(1.0) || turns.round() < 1.0 {
            return Err(HbmError::Invalid(format!(
                "with gravity or a world-frame force the base order ({}) must divide 1 (one revolution): \
                 add the multiple 1/{order} to the excitation's multiples",
                self.ratio * order
            )));
        }
        Ok(())
    }

    /// Newton's method at fixed parameters.
    pub(in crate::hbm) fn solve_at(&mut self, at: &At, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        self.solve_within(at, guess, self.opts.tol)
    }

    /// Newton's method at fixed parameters that also accepts an iterate whose steps stopped
    /// contracting (a step at least half the one before) once they are below `floor` (≥ the
    /// tolerance): beside a branch point ∂R̂/∂x is nearly singular, so rounding leaves steps of
    /// ~1e-10 that no iteration reduces, while the state is as accurate as the problem allows
    /// there. For locating events (the state only decides a count or a sign), never for the
    /// points of a branch.
    pub(in crate::hbm) fn solve_within(
        &mut self,
        at: &At,
        guess: Option<&HbmSolution>,
        floor: f64,
    ) -> Result<HbmSolution, HbmError> {
        let order = at.order;
        self.check_base(order)?;
        let mut x = self.unknowns_from(guess);
        let mut step = f64::INFINITY;
        for it in 1..=self.opts.max_iter {
            self.assemble(&x, at, Some(Parameter::Order));
            let dx = self.factor(None).solve(&self.rhat).ok_or(HbmError::Singular { order })?;
            let last = step;
            step = dx.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            for (xi, d) in x.iter_mut().zip(dx.iter()) {
                *xi -= d;
            }
            if step <= self.opts.tol || (step <= floor && step >= 0.5 * last) {
                return Ok(self.solution_from(&x, at, it));
            }
        }
        Err(HbmError::NoConvergence { order, iterations: self.opts.max_iter, step })
    }
}
