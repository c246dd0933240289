//! Branch switching at a symmetry-breaking branch point (a Floquet multiplier through +1 of a
//! symmetric, e.g. unison, branch that is not a fold): the start of the branch of non-symmetric
//! solutions that crosses the symmetric one there, followed by the ordinary continuation.
//!
//! The method (a pitchfork of a problem equivariant under a permutation P of identical
//! absorbers; Seydel, *Practical Bifurcation and Stability Analysis*, §5.6, "branch switching by
//! the null vector"):
//!
//! 1. The symmetric solution y* at the located branch point is solved by Newton at the fixed
//!    parameter from the symmetric branch's point, each step projected on the symmetric states,
//!    Δx ← (Δx + P Δx)/2, so that no round-off of the nearly singular solve leaks into the
//!    antisymmetric directions (the symmetric problem is regular there).
//! 2. The null vector φ of ∂R̂/∂x there: the right singular vector of the smallest singular value
//!    of the dense Jacobian (the sets where switching is asked are small: three coordinates for
//!    two pendulums). It must be antisymmetric (Pφ = −φ; a symmetric null vector is a fold, not
//!    a symmetry breaking) and isolated: σ₁ ≤ 1e-3 σ₂ (a one-dimensional kernel; more identical
//!    absorbers than two give a kernel of dimension two, which this method does not split).
//!    Because the unison branch's tangent is symmetric, φ is orthogonal to it.
//! 3. Predictor y* + ε φ with ε = 2 % of the weighted norm of the non-spin unknowns of y* (the
//!    absorbers' root-mean-square amplitude in rad): large enough that the corrector cannot
//!    return to the symmetric branch (it is held on the hyperplane φᵀ(y − y_pred) = 0, which
//!    the symmetric states cross only at φ-coordinate 0, ε away), small enough that the new
//!    branch's parameter is still within ~1e-5 of the branch point (it moves as ε²).
//! 4. One pseudo-arclength correction on that hyperplane, the parameter free, then the ordinary
//!    continuation ([`Hbm::continue_in`]'s loop, with its events and stability) with the tangent
//!    oriented along +φ, i.e. away from the branch point. By the symmetry the branch started
//!    along −φ is the mirror image (the absorbers swapped), so one side is followed.
//!
//! The switched branch ends where the parameter leaves the range, at any of the ordinary ends,
//! or where it returns to the symmetric states ([`BranchEnd::Unison`](super::BranchEnd)): φᵀx
//! vanishes on every symmetric state (Pφ = −φ), so its change of sign between two points marks
//! the return; it is located by an Illinois search on φᵀx along the step and accepted when the
//! state found is symmetric to 1e-3 of its size (else the branch only crossed the hyperplane
//! φᵀx = 0 elsewhere, and it goes on). Past that point the continuation would follow the mirror
//! image of the same branch back.

use super::continuation::{Cursor, Illinois};
use super::corrector::Setup;
use super::{Branch, ContinuationOptions, Hbm, HbmError, HbmSolution, Parameter};
use nalgebra::DVector;

/// The predictor's offset along the null vector, as a fraction of the weighted norm of the
/// non-spin unknowns at the branch point (module docs, step 3).
const EPS_FRACTION: f64 = 0.02;

/// The largest ratio σ₁/σ₂ of the two smallest singular values of ∂R̂/∂x accepted as a branch
/// point with a one-dimensional kernel (module docs, step 2). At a located branch point σ₁ is
/// of the order of the location's error times dσ₁/dp, ~1e-8 relative.
const KERNEL_RATIO: f64 = 1e-3;

/// A state symmetric to this fraction of its size counts as back on the symmetric branch.
const UNISON_DEFECT: f64 = 1e-3;

impl Hbm {
    /// Switches at a symmetry-breaking branch point onto the non-symmetric branch and continues
    /// it in `parameter` inside the range `range` = (from, to) (order n; Ω in rad/s; torque
    /// scale s), with stability when `copts.stability`: see the module docs of the `switch`
    /// submodule. `value` is the branch point's parameter (as located on the symmetric branch),
    /// `guess` a solution of the symmetric branch near it (this problem's layout: every
    /// coordinate an unknown), `mirror` the permutation of the coordinates that swaps identical
    /// absorbers (mirror\[k\] the coordinate k is mapped to; the spin coordinate fixed).
    ///
    /// Errors name the failure: no branch point at `value` (the Jacobian is regular there, or
    /// its kernel is symmetric: a fold), a kernel of dimension two, a correction that did not
    /// converge.
    pub fn switch_at(
        &mut self,
        parameter: Parameter,
        value: f64,
        guess: &HbmSolution,
        mirror: &[usize],
        range: (f64, f64),
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let (tol, one_sided) = (self.opts.tol, self.ev.one_sided);
        self.opts.tol = copts.corrector_tol.unwrap_or(tol);
        self.ev.one_sided = false;
        let branch = self.switch_with_tol(parameter, value, guess, mirror, range, copts);
        (self.opts.tol, self.ev.one_sided) = (tol, one_sided);
        branch
    }

    fn switch_with_tol(
        &mut self,
        parameter: Parameter,
        value: f64,
        guess: &HbmSolution,
        mirror: &[usize],
        (from, to): (f64, f64),
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let bad = |m: String| Err(HbmError::Invalid(format!("branch switch at {value}: {m}")));
        let (n, nb) = (self.n, self.nb);
        let mut seen = vec![false; n];
        for &k in mirror {
            if k < n {
                seen[k] = true;
            }
        }
        if mirror.len() != n || seen.iter().any(|s| !s) || mirror[self.spin] != self.spin {
            return bad(format!("the mirror {mirror:?} is not a permutation of the {n} coordinates fixing the spin"));
        }
        if mirror.iter().enumerate().all(|(i, &k)| i == k) {
            return bad("the mirror permutation is the identity: no symmetry to break".into());
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
        let permute = |x: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; x.len()];
            for (k, &j) in mirror.iter().enumerate() {
                out[j * nb..(j + 1) * nb].copy_from_slice(&x[k * nb..(k + 1) * nb]);
            }
            out
        };
        // 1. The symmetric solution at the branch point, symmetrised.
        let l_star = value / p_ref;
        let symmetric = |x: &[f64]| -> Vec<f64> { x.iter().zip(permute(x)).map(|(a, b)| 0.5 * (a + b)).collect() };
        let mut x_star = symmetric(&self.unknowns_from(Some(guess)));
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
        self.follow(&su, Cursor { y: y1, t: t1 }, it, (l_from, l_to), it, copts, Some((&phi, mirror)))
    }

    /// The return of a switched branch to the symmetric states inside the step from `cur` to
    /// the accepted point `y`, if φᵀx (`c` = φ) changes sign there and the state where it
    /// vanishes is symmetric (module docs): that state. Illinois regula falsi on φᵀx along the
    /// step (correctors on the hyperplanes normal to cur's tangent), 30 evaluations at most,
    /// until |φᵀx| is 1e-6 of its value at the ends.
    pub(super) fn rejoin(
        &mut self,
        su: &Setup,
        cur: &Cursor,
        y: &DVector<f64>,
        c: &[f64],
        mirror: &[usize],
        newton: &mut usize,
    ) -> Option<DVector<f64>> {
        let m = self.unknowns();
        let nb = self.nb;
        let cx = |y: &DVector<f64>| -> f64 { su.x_of(y.as_slice(), m).iter().zip(c).map(|(a, b)| a * b).sum() };
        let (ca, cb) = (cx(&cur.y), cx(y));
        if ca.signum() == cb.signum() || ca == 0.0 {
            return None;
        }
        let scale = ca.abs().max(cb.abs());
        let mut ill = Illinois::new((0.0, ca), (cur.t.dot(&(y - &cur.y)), cb));
        let mut best = y.clone();
        let mut best_f = cb.abs();
        for _ in 0..30 {
            if ill.f1 == ill.f0 {
                break;
            }
            let s = ill.secant();
            let pred = &cur.y + &cur.t * s;
            let Ok((ys, it)) = self.correct(su, &pred, &cur.t, self.opts.max_iter) else { break };
            *newton += it;
            let f = cx(&ys);
            if f.abs() < best_f {
                (best, best_f) = (ys, f.abs());
            }
            if f.abs() <= 1e-6 * scale {
                break;
            }
            ill.update(s, f);
        }
        // Symmetric to UNISON_DEFECT of its size (the spin coordinate excluded)?
        let x = su.x_of(best.as_slice(), m);
        let (mut defect, mut size) = (0.0, 0.0);
        for (k, &j) in mirror.iter().enumerate() {
            if k == self.spin {
                continue;
            }
            for h in 0..nb {
                defect += (x[k * nb + h] - x[j * nb + h]).powi(2);
                size += x[k * nb + h].powi(2);
            }
        }
        (defect.sqrt() <= UNISON_DEFECT * size.sqrt()).then_some(best)
    }
}
