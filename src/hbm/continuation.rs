//! Pseudo-arclength continuation of harmonic-balance solutions in a parameter p: the excitation
//! order n, the mean speed Ω (at fixed n) or the torque scale s (at fixed n; every oscillating
//! amplitude T_k becomes s·T_k), see [`Parameter`].
//!
//! The branch is the curve `R̂(x, λ) = 0` in the space `y = (x, λ)` of the Fourier unknowns (rad;
//! the scaled mean torque) and the scaled parameter `λ = p / p_ref` (p_ref = 1 for n and s, the
//! starting speed for Ω, so that arclength steps mean the same for each). ∂R̂/∂p is exact (see
//! the module docs of [`crate::hbm`]). From a point y with unit tangent t, the predictor is
//! `y + Δs t + ½ Δs² κ` with the curvature κ estimated from the change of the tangent over the
//! last step, and the corrector solves `R̂ = 0` together with `tᵀ(y − y_pred) = 0` on the
//! bordered Jacobian `[[∂R̂/∂x, ∂R̂/∂λ], [tᵀ]]`, which stays regular through turning points. The
//! new tangent solves `[[∂R̂/∂x, ∂R̂/∂n], [t_oldᵀ]] t = [0, 1]` (so it keeps the orientation),
//! normalised.
//!
//! The corrector is a Newton–chord iteration with Broyden updates: it starts from the bordered
//! matrix factorised at the previous point (its Jacobian is needed there anyway for the tangent
//! and the stability; bordered by the new tangent through a rank-one update of the tangent's
//! factorisation) and improves it by good-Broyden rank-one updates kept as step vectors, so an
//! iteration costs one residual; when a step contracts by less than half, the Jacobian is
//! refreshed at the current iterate (at most 3 times) and the updates restart. With light damping
//! the Jacobian changes quickly along the branch near resonance, so about one refresh per point
//! is typical there. (The bordered systems and both correctors are in `corrector`.)
//!
//! Step control: the step grows by 1.5 after a corrector of at most 7 iterations with at most
//! one refresh, and shrinks by 0.7 after 10 iterations or 3 refreshes; a failed corrector, or a
//! tangent that turned by more than `acos(min_cos)`, halves the step and retries (the turning
//! guard keeps the corrector from jumping to a neighbouring branch near a fold). Between the
//! points, [`Branch::interpolate`] gives cubic Hermite states from the stored tangents.
//!
//! Folds are the points where `dλ/ds` changes sign: there the branch turns back in p and a sweep
//! in p jumps, so the fold orders of an order branch are the jump orders of the paper's up- and
//! down-sweeps (Figs. 3, 4). Each detected fold is refined by a bracketing secant search
//! (Illinois) on `dλ/ds = 0` along the arclength.

use super::branch::bifurcations;
use super::corrector::{Chord, Setup};
use super::{Branch, BranchEnd, BranchPoint, Fold, FoldKind, Parameter};
use super::{Hbm, HbmError, HbmOptions, HbmSolution, Stability};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use nalgebra::DVector;

/// Settings of the continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationOptions {
    /// Initial arclength step (in the norm of (coefficients in rad, scaled parameter λ)).
    pub ds: f64,
    /// Smallest step before giving up.
    pub ds_min: f64,
    /// Largest step. Multiplier crossings are found between successive points, so a stretch of
    /// instability shorter than a step can pass unseen (two pendulums at 500 N·m: the unison
    /// response is unstable only for n ≈ 3.081–3.095, which the default 0.1 can step over and
    /// 0.02 resolves, `tests/hbm.rs`); lower it where such stretches matter.
    pub ds_max: f64,
    /// Largest number of points on a branch.
    pub max_points: usize,
    /// Newton iterations allowed per corrector.
    pub corrector_iter: usize,
    /// Smallest accepted cosine between successive tangents.
    pub min_cos: f64,
    /// Compute the Floquet stability of every point.
    pub stability: bool,
    /// Refine each fold to `|dλ/ds| < 1e-6` by a secant search, and locate each other multiplier
    /// crossing by bisection.
    pub refine_folds: bool,
}

impl Default for ContinuationOptions {
    fn default() -> Self {
        Self {
            ds: 0.01,
            ds_min: 1e-7,
            ds_max: 0.1,
            max_points: 2000,
            corrector_iter: 14,
            min_cos: 0.98,
            stability: true,
            refine_folds: true,
        }
    }
}

/// Unit tangent and state carried along the branch.
struct Cursor {
    y: DVector<f64>,
    t: DVector<f64>,
}

impl Hbm {
    fn branch_point(
        &mut self,
        su: &Setup,
        y: &DVector<f64>,
        tangent: Option<&DVector<f64>>,
        s: f64,
        iterations: usize,
        stability: bool,
    ) -> Result<BranchPoint, HbmError> {
        let m = self.unknowns();
        let slope = tangent.map_or(0.0, |t| t[m]);
        let (mut d_coefficients, mut d_mean_torque) = (Vec::new(), 0.0);
        if let Some(t) = tangent {
            d_coefficients = t.as_slice()[..m].to_vec();
            let gauge = self.spin * self.nb;
            d_mean_torque = d_coefficients[gauge] * self.t_scale;
            d_coefficients[gauge] = 0.0;
        }
        let x: Vec<f64> = y.rows(0, m).iter().copied().collect();
        let mut sol = self.solution_from(&x, &su.at(y[m]), iterations);
        if stability && self.opts.stability_samples > 0 {
            sol.stability = Some(self.stability(&sol)?);
        }
        Ok(BranchPoint {
            order: sol.order,
            parameter: y[m] * su.p_ref,
            arclength: s,
            slope,
            order_slope: if su.param == Parameter::Order { slope } else { 0.0 },
            accel_main: sol.order_acceleration(self.spin, 1.0),
            accel_second: sol.order_acceleration(self.spin, 2.0),
            pendulum_amplitude: sol.max_peak_amplitude(),
            stable: sol.stability.as_ref().map(|st| st.stable),
            solution: sol,
            d_coefficients,
            d_mean_torque,
            d_parameter: slope * su.p_ref,
        })
    }

    fn y_of(&self, su: &Setup, sol: &HbmSolution) -> DVector<f64> {
        let m = self.unknowns();
        let x = self.unknowns_from(Some(sol));
        let mut y = DVector::zeros(m + 1);
        y.rows_mut(0, m).copy_from_slice(&x);
        y[m] = su.lambda(sol);
        y
    }

    /// Bracketing secant search for `dλ/ds = 0` between a (s = 0) and b (s = `chord`) along a's
    /// tangent. Regula falsi with the Illinois modification (an end kept twice has its value
    /// halved), which keeps the bracket but converges superlinearly where plain regula falsi
    /// moves one end only (fewer searches per fold; counts in `BENCHMARKS.md`). After the
    /// first search, the corrector is the Broyden chord on the bordered matrix factorised for the
    /// previous search's tangent, which has the same last row aᵀ.
    fn refine_fold(
        &mut self,
        su: &Setup,
        a: &Cursor,
        chord: f64,
        slope_b: f64,
        iterations: &mut usize,
    ) -> Option<DVector<f64>> {
        let m = self.unknowns();
        let (mut s0, mut f0) = (0.0, a.t[m]);
        let (mut s1, mut f1) = (chord, slope_b);
        let mut best = None;
        let mut lu: Option<Chord> = None;
        // Which end was replaced last (−1: s0, +1: s1), for the Illinois halving.
        let mut side = 0;
        for _ in 0..20 {
            if f1 == f0 {
                break;
            }
            let s = s1 - f1 * (s1 - s0) / (f1 - f0);
            let pred = &a.y + &a.t * s;
            let (y, it) = match &lu {
                Some(c) => {
                    let (y, it, _) = self.correct_chord(su, c, &pred, &a.t, self.opts.max_iter, 3).ok()?;
                    (y, it)
                }
                None => self.correct(su, &pred, &a.t, self.opts.max_iter).ok()?,
            };
            *iterations += it;
            let order = su.at(y[m]).order;
            self.assemble(&y.as_slice()[..m], &su.at(y[m]), Some(su.param));
            let (t, c) = self.tangent_chord(su, &a.t, order).ok()?;
            lu = Some(Chord { lu: c.lu, update: None });
            let f = t[m];
            best = Some(y);
            if f.abs() < 1e-6 {
                break;
            }
            if f.signum() == f0.signum() {
                s0 = s;
                f0 = f;
                if side == -1 {
                    f1 *= 0.5;
                }
                side = -1;
            } else {
                s1 = s;
                f1 = f;
                if side == 1 {
                    f0 *= 0.5;
                }
                side = 1;
            }
        }
        best
    }

    /// Continues the periodic solution from order `n_from` towards `n_to` at the problem's mean
    /// speed and torque scale: [`Hbm::continue_in`] with [`Parameter::Order`].
    pub fn continue_in_order(
        &mut self,
        n_from: f64,
        n_to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        self.continue_in(Parameter::Order, n_from, n_to, guess, copts)
    }

    /// Continues the periodic solution in `parameter` from `from` towards `to` (order n; Ω in
    /// rad/s; torque scale s), see the module docs of the `continuation` submodule, starting
    /// from `guess` or from the rigid rotation. The parameters not continued keep the problem's
    /// values ([`Hbm::omega`], [`Hbm::torque_scale`]) or the variant's fixed order. The branch
    /// may turn back at folds; it ends on reaching `to`, on leaving the range at `from`, or when
    /// the step control gives up (the points found are kept).
    pub fn continue_in(
        &mut self,
        parameter: Parameter,
        from: f64,
        to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let bad = |m: String| Err(HbmError::Invalid(m));
        let range_ok = from.is_finite() && to.is_finite() && from != to;
        let (p_ref, order) = match parameter {
            Parameter::Order => {
                if !(range_ok && from > 0.0 && to > 0.0) {
                    return bad(format!("order range {from} → {to} must be positive and non-empty"));
                }
                (1.0, from)
            }
            Parameter::Speed { order } => {
                if !(range_ok && from > 0.0 && to > 0.0) {
                    return bad(format!("speed range {from} → {to} rad/s must be positive and non-empty"));
                }
                (from.abs(), order)
            }
            Parameter::TorqueScale { order } => {
                if !range_ok {
                    return bad(format!("torque-scale range {from} → {to} must be finite and non-empty"));
                }
                (1.0, order)
            }
        };
        if !(order.is_finite() && order > 0.0) {
            return bad(format!("excitation order must be positive and finite, got {order}"));
        }
        if !self.cyclic && parameter == Parameter::Order {
            return bad(
                "with gravity or a world-frame force the motion is periodic only at orders whose base divides one \
                 revolution: continue in speed or torque at a fixed order instead of in order"
                    .into(),
            );
        }
        self.check_base(order)?;
        let su = Setup { param: parameter, p_ref, base: self.at(order) };
        let (l_from, l_to) = (from / p_ref, to / p_ref);
        let m = self.unknowns();
        let dir = (l_to - l_from).signum();
        let mut newton = 0;
        let sol0 = self.solve_at(&su.at(l_from), guess)?;
        newton += sol0.iterations;
        let y0 = self.y_of(&su, &sol0);
        // Initial tangent: the row e_λ fixes dλ = 1, then the sign follows the direction.
        self.assemble(&y0.as_slice()[..m], &su.at(l_from), Some(parameter));
        let mut e_l = DVector::zeros(m + 1);
        e_l[m] = 1.0;
        let t0 = self.tangent(&su, &e_l, order)? * dir;
        let mut cur = Cursor { y: y0, t: t0 };
        let mut chord_m = Chord { lu: self.bordered(&su, &cur.t).lu(), update: None };
        let mut points = vec![self.branch_point(&su, &cur.y, Some(&cur.t), 0.0, sol0.iterations, copts.stability)?];
        let mut folds = Vec::new();
        let mut ds = copts.ds;
        let mut s = 0.0;
        // The previous point's tangent and the chord to it.
        let mut prev: Option<(DVector<f64>, f64)> = None;
        let end = loop {
            if points.len() >= copts.max_points {
                break BranchEnd::MaxPoints;
            }
            if ds < copts.ds_min {
                break BranchEnd::StepTooSmall;
            }
            // Quadratic predictor: the tangent's change over the last step estimates the branch's
            // curvature, which makes the predictor error third order in ds instead of second.
            let mut pred = &cur.y + &cur.t * ds;
            if let Some((t_prev, h)) = &prev {
                pred.axpy(0.5 * ds * ds / h, &(&cur.t - t_prev), 1.0);
            }
            let (y, iters, refreshes) = match self.correct_chord(&su, &chord_m, &pred, &cur.t, copts.corrector_iter, 3)
            {
                Ok(r) => r,
                Err(_) => {
                    ds *= 0.5;
                    continue;
                }
            };
            newton += iters;
            // The Jacobian at the new point gives its tangent and the next chord matrix.
            let at = su.at(y[m]);
            self.assemble(&y.as_slice()[..m], &at, Some(parameter));
            let (t, next_chord) = match self.tangent_chord(&su, &cur.t, at.order) {
                Ok(r) => r,
                Err(_) => {
                    ds *= 0.5;
                    continue;
                }
            };
            if t.dot(&cur.t) < copts.min_cos && ds > copts.ds_min {
                ds *= 0.5;
                continue;
            }
            let chord = (&y - &cur.y).norm();
            let (l_new, l_old) = (y[m], cur.y[m]);
            // Leaving the range: finish exactly at its end by a solve at fixed parameter.
            let past_target = dir * (l_new - l_to) >= 0.0;
            let past_start = dir * (l_new - l_from) < 0.0;
            if past_target || past_start {
                let l_end = if past_target { l_to } else { l_from };
                let frac = (l_end - l_old) / (l_new - l_old);
                let y_guess = &cur.y + (&y - &cur.y) * frac;
                let x_guess: Vec<f64> = y_guess.rows(0, m).iter().copied().collect();
                let guess_sol = self.solution_from(&x_guess, &su.at(l_end), 0);
                let y_end = match self.solve_at(&su.at(l_end), Some(&guess_sol)) {
                    Ok(sol) => {
                        newton += sol.iterations;
                        self.y_of(&su, &sol)
                    }
                    Err(_) => y.clone(),
                };
                s += (&y_end - &cur.y).norm();
                // The tangent at the end point itself (for the dense output); the Jacobian is
                // the one the stability analysis needs there anyway.
                self.assemble(&y_end.as_slice()[..m], &su.at(y_end[m]), Some(parameter));
                let t_end = self.tangent(&su, &t, su.at(y_end[m]).order).unwrap_or(t);
                points.push(self.branch_point(&su, &y_end, Some(&t_end), s, iters, copts.stability)?);
                break if past_target { BranchEnd::ReachedTarget } else { BranchEnd::LeftRange };
            }
            if t[m].signum() != cur.t[m].signum() && t[m] != 0.0 && cur.t[m] != 0.0 {
                let kind = if cur.t[m] > 0.0 { FoldKind::Maximum } else { FoldKind::Minimum };
                let refined =
                    if copts.refine_folds { self.refine_fold(&su, &cur, chord, t[m], &mut newton) } else { None };
                let fold = match refined {
                    Some(yf) => {
                        let p = self.branch_point(&su, &yf, None, 0.0, 0, false)?;
                        Fold {
                            order: p.order,
                            parameter: p.parameter,
                            kind,
                            after: points.len() - 1,
                            accel_main: p.accel_main,
                            pendulum_amplitude: p.pendulum_amplitude,
                        }
                    }
                    None => {
                        // dλ/ds linear over the chord: the fold where it vanishes.
                        let f = cur.t[m] / (cur.t[m] - t[m]);
                        let lf = l_old + 0.5 * cur.t[m] * f * chord;
                        let last = points.last();
                        Fold {
                            order: su.at(lf).order,
                            parameter: lf * p_ref,
                            kind,
                            after: points.len() - 1,
                            accel_main: last.map_or(0.0, |p| p.accel_main),
                            pendulum_amplitude: last.map_or(0.0, |p| p.pendulum_amplitude),
                        }
                    }
                };
                folds.push(fold);
            }
            s += chord;
            points.push(self.branch_point(&su, &y, Some(&t), s, iters, copts.stability)?);
            prev = Some((std::mem::replace(&mut cur, Cursor { y, t }).t, chord));
            chord_m = next_chord;
            if iters <= 7 && refreshes <= 1 {
                ds = (ds * 1.5).min(copts.ds_max);
            } else if iters >= 10 || refreshes >= 3 {
                ds *= 0.7;
            }
        };
        let bifurcations = bifurcations(&points, &folds);
        let mut branch = Branch { parameter, points, folds, bifurcations, end, newton_iterations: newton };
        if copts.refine_folds {
            self.refine_crossings(&su, &mut branch);
        }
        Ok(branch)
    }

    /// Locates each crossing that is not a fold by bisection along its segment: states from
    /// [`Branch::interpolate`] as guesses, solved at the fixed parameter (the segment holds no
    /// fold, so the parameter is monotone along it and the solve is regular), the count of
    /// multipliers outside the unit circle deciding the side, 30 halvings (the segment to 1e-9).
    /// A crossing whose bisection fails keeps its interpolated location.
    fn refine_crossings(&mut self, su: &Setup, branch: &mut Branch) {
        for k in 0..branch.bifurcations.len() {
            let i = branch.bifurcations[k].after;
            if branch.folds.iter().any(|f| f.after == i) {
                continue;
            }
            let Some(before) = branch.points[i].solution.stability.as_ref().map(Stability::outside) else { continue };
            let (mut lo, mut hi) = (0.0, 1.0);
            let mut found = None;
            for _ in 0..30 {
                let mid = 0.5 * (lo + hi);
                let Some(guess) = branch.interpolate(i, mid) else { break };
                let lambda = su.param.value(&guess) / su.p_ref;
                let Ok(sol) = self.solve_at(&su.at(lambda), Some(&guess)) else { break };
                let Ok(st) = self.stability(&sol) else { break };
                if st.outside() == before {
                    lo = mid;
                } else {
                    hi = mid;
                }
                found = Some((sol.order, lambda * su.p_ref));
            }
            if let Some((order, parameter)) = found {
                let b = &mut branch.bifurcations[k];
                (b.order, b.parameter) = (order, parameter);
            }
        }
    }
}

/// One-call convenience: the branch of periodic solutions of `kane`'s mechanism from order
/// `n_from` to `n_to` (see [`Hbm::new`] and [`Hbm::continue_in_order`]).
#[allow(clippy::too_many_arguments)]
pub fn continue_in_order(
    kane: &Kane,
    spin_joint: usize,
    omega: f64,
    harmonics: &[Harmonic],
    n_from: f64,
    n_to: f64,
    options: HbmOptions,
    copts: &ContinuationOptions,
) -> Result<Branch, HbmError> {
    Hbm::new(kane, spin_joint, omega, harmonics, options)?.continue_in_order(n_from, n_to, None, copts)
}
