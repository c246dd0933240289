//! Pseudo-arclength continuation of harmonic-balance solutions in a parameter p: the excitation
//! order n, the mean speed Ω (at fixed n) or the torque scale s (at fixed n; every oscillating
//! amplitude T_k becomes s·T_k), see [`Parameter`].
//!
//! The branch is the curve `R̂(x, λ) = 0` in the space `y = (w ⊙ x, λ)` of the Fourier unknowns
//! (rad; the scaled mean torque) and the scaled parameter `λ = p / p_ref` (p_ref = 1 for n and s,
//! the starting speed for Ω, so that arclength steps mean the same for each). The weights w are
//! 1 on the spin coordinate's unknowns and 1/√(n_dof − 1) on every other coordinate's: the
//! arclength measures the root mean square of the other coordinates, so that N absorbers moving
//! alike take the steps of one instead of steps 1/√N as long in the parameter (two coordinates,
//! the paper's rotor, have weight 1). ∂R̂/∂p is exact (see
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
//! (Illinois) on `dλ/ds = 0` along the arclength. A fold's own real multiplier passes +1 there,
//! so a second crossing of +1 in the fold's step (a loss of unison beside the fold) leaves
//! Π(μ − 1) with one sign at both ends; it shows instead as an even change of the count of
//! multipliers outside the unit circle across the step, and a state between it and the fold is
//! searched for and inserted as a point (`Hbm::fold_partner`).
//!
//! Events at any step. Each point carries test functions: dλ/ds, and per Floquet block the
//! products Π(μ − 1), Π(μ + 1) and Π_{i<j}(μ_i μ_j − 1), whose sign changes mark a fold or
//! branch point, a period doubling and a Neimark–Sacker point (the classical test functions of
//! periodic orbits, as in Seydel's *Practical Bifurcation and Stability Analysis*). A pair of
//! crossings inside one step leaves every sign unchanged; the quadratic through the test
//! function's last three values then has an extremum of the other sign inside the step, and the
//! step is shortened to land on it (once per step, by at most 5×, not below a floor), so the two
//! crossings become sign changes between accepted points.
//!
//! A narrow tongue (a pair through −1 and back: a Mathieu tongue of period doubling; or through
//! +1 and back: a short loss of unison) can still fit inside one step without a dip the
//! quadratic sees. Such a pair is told by its sense of turning instead: for every complex pair
//! of a Floquet block within ½ of ±1 (a cheap screen: elsewhere nothing is computed), the
//! eigenvector v of the member with Im μ > 0 is found by inverse iteration on the block's
//! monodromy, and the sign of `Σ_k Im(conj(v_qk) v_uk)` over the coordinates (angle and rate of
//! each) says which way the motion turns in its phase planes (phase-invariant). Across a tongue
//! the pair's rotation number ωT/2π passes ½ (or an integer), the member with Im μ > 0 becomes
//! the conjugate of the old one and the sign flips; a pair that comes near ±1 and leaves keeps
//! it (for lightly damped motion the sign changes only where the pair meets on the real axis,
//! like a Krein signature). The same pair is recognised at the next point that holds
//! it (up to three points on, the ones in between holding it on the real axis) by its
//! eigenvector, parallel up to conjugation. Where the sense flipped but the block's Π(μ ± 1)
//! kept its sign, the segment is bisected on the sense (states from [`Branch::interpolate`]
//! solved at the fixed parameter) until a state inside the tongue is found, or one with the
//! pair on the real axis (the real stretch is a little wider than the tongue), from which a
//! golden section on the test function's magnitude finds the tongue; that state is inserted as
//! a point, so the tongue's two edges are sign changes between accepted points (pairs met on the
//! real axis inside the unit circle flip the sense too and cost a search that finds nothing).
//! Last, where a test function's magnitude has a deep minimum at an accepted point, and so has
//! its factor nearest to zero, the two segments around it are searched the same way by golden
//! section.
//!
//! Crossings are bracketed by the count of multipliers outside the unit circle (bisection along
//! the segment); a branch point is then located on det ∂R̂/∂x, which vanishes there exactly for
//! the truncated problem, at its own sign change (searched outward from the count's bracket when
//! the monodromy's error put the count's crossing beside it). Beside a branch point Newton's
//! steps at fixed parameter stall above the tolerance; while locating, a solve whose steps stop
//! contracting below 1000× the tolerance is taken as converged (`Hbm::solve_within`).

use super::blocklu::Factor;
use super::branch::bifurcations;
use super::corrector::{Chord, Setup};
use super::stability::PairSense;
use super::{BifurcationKind, Branch, BranchEnd, BranchPoint, Fold, FoldKind, Parameter};
use super::{Hbm, HbmError, HbmOptions, HbmSolution, Stability};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use nalgebra::DVector;

/// Settings of the continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationOptions {
    /// Initial arclength step (in the norm of (coefficients in rad, scaled parameter λ), the
    /// coefficients of the coordinates other than the spin one weighted by 1/√(n_dof − 1): see
    /// the module docs).
    pub ds: f64,
    /// Smallest step before giving up.
    pub ds_min: f64,
    /// Largest step. Events do not depend on it: a pair of crossings inside one step (two
    /// pendulums at 500 N·m are unstable only for n ≈ 3.081–3.095) shows as a dip of a test
    /// function, and the step is aimed at it (`tests/it/hbm_events.rs` sweeps 0.1, 0.02, 0.001);
    /// a narrow tongue of period doubling or of loss of unison stepped over whole shows as a
    /// flip of the sense of the Floquet pair near ±1 (module docs; `tests/it/hbm_tongue.rs`).
    pub ds_max: f64,
    /// Largest number of points on a branch (a bound on the work, and the plan's: the paper's
    /// branches take 16–60 points at the default `ds_max`, up to ~1600 at 0.001; raise it with a
    /// smaller step).
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
    /// The watchdog's stop time: past it the branch ends with [`BranchEnd::Watchdog`] and the
    /// points it reached (checked before every step; `None`: no deadline).
    pub deadline: Option<crate::deadline::Deadline>,
    /// The corrector's tolerance along the branch, in place of [`HbmOptions::tol`](super::HbmOptions::tol)
    /// (None: that one). A branch whose points only serve as starting guesses, each solved again
    /// at the full tolerance where it is used, takes a looser one: the corrector then needs half
    /// the iterations, so the step control lengthens the steps (fewer points, each with one
    /// Jacobian fewer).
    pub corrector_tol: Option<f64>,
    /// Difference the per-sample derivatives one-sidedly along the branch (half the engine
    /// calls of a Jacobian; about 1e-8 relative): for a branch of guesses (with `corrector_tol`),
    /// never where the Jacobian decides a result (stability, located events).
    pub one_sided: bool,
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
            deadline: None,
            corrector_tol: None,
            one_sided: false,
        }
    }
}

/// Unit tangent and state carried along the branch.
pub(super) struct Cursor {
    pub(super) y: DVector<f64>,
    pub(super) t: DVector<f64>,
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
            d_coefficients = su.x_of(t.as_slice(), m);
            let gauge = self.spin * self.nb;
            d_mean_torque = d_coefficients[gauge] * self.t_scale;
            d_coefficients[gauge] = 0.0;
        }
        let x = su.x_of(y.as_slice(), m);
        let mut sol = self.solution_from(&x, &su.at(y[m]), iterations);
        self.pair_senses.clear();
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

    pub(super) fn y_of(&self, su: &Setup, sol: &HbmSolution) -> DVector<f64> {
        let m = self.unknowns();
        let x = self.unknowns_from(Some(sol));
        let mut y = DVector::from_fn(m + 1, |i, _| if i < m { x[i] * su.w(i) } else { 0.0 });
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
    ) -> Option<(DVector<f64>, DVector<f64>)> {
        let m = self.unknowns();
        let mut ill = Illinois::new((0.0, a.t[m]), (chord, slope_b));
        let mut best = None;
        let mut lu: Option<Chord> = None;
        for _ in 0..20 {
            if ill.f1 == ill.f0 {
                break;
            }
            let s = ill.secant();
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
            self.assemble(&su.x_of(y.as_slice(), m), &su.at(y[m]), Some(su.param));
            let (t, c) = self.tangent_chord(su, &a.t, order).ok()?;
            lu = Some(Chord { lu: c.lu, update: None });
            let f = t[m];
            best = Some((y, t));
            if f.abs() < 1e-6 {
                break;
            }
            ill.update(s, f);
        }
        best
    }

    /// A crossing of +1 in the same segment as a fold, which the sign changes cannot show: the
    /// fold's own real multiplier passes +1 there, so the count of multipliers outside the unit
    /// circle changes by an odd number across a segment holding the fold alone; an even change
    /// (none, or two) means another real multiplier crossed +1 in the segment too (a loss of
    /// unison beside the fold), and the two cancel in Π(μ − 1). The states on either side of
    /// the refined fold `yf`, ever closer to it (a quarter of the way to the segment's end, then
    /// a sixteenth, …, 1/256; pseudo-arclength corrections along the chord), are searched for
    /// one whose count differs from its end's: the other crossing lies between that end and
    /// it. That state, returned as a point with its pair senses and whether it lies before the
    /// fold, is then inserted, so the crossing is a change between accepted points and located
    /// and classified as any other. None when the counts change by an odd number, or no such
    /// state is found (the crossing then stays unseen, as before).
    fn fold_partner(
        &mut self,
        su: &Setup,
        (a, pa): (&Cursor, &BranchPoint),
        (yb, pb): (&DVector<f64>, &BranchPoint),
        yf: &DVector<f64>,
        s: f64,
    ) -> Option<(BranchPoint, PairSenses, bool)> {
        let count = |p: &BranchPoint| p.solution.stability.as_ref().map(|st| st.outside());
        let (na, nb) = (count(pa)?, count(pb)?);
        if (na + nb) % 2 == 1 {
            return None;
        }
        let m = self.unknowns();
        for frac in [0.25, 1.0 / 16.0, 1.0 / 64.0, 1.0 / 256.0] {
            for (end, n_end, before) in [(&a.y, na, true), (yb, nb, false)] {
                let d = end - yf;
                let norm = d.norm();
                if !(norm > 0.0 && norm.is_finite()) {
                    continue;
                }
                let pred = yf + &d * frac;
                let Ok((y, it)) = self.correct(su, &pred, &(&d / norm), self.opts.max_iter) else { continue };
                // A corrector that left the segment's neighbourhood found another sheet.
                if (&y - &pred).norm() > norm {
                    continue;
                }
                let order = su.at(y[m]).order;
                self.assemble(&su.x_of(y.as_slice(), m), &su.at(y[m]), Some(su.param));
                let Ok(t) = self.tangent(su, &a.t, order) else { continue };
                let Ok(p) = self.branch_point(su, &y, Some(&t), s + (&y - &a.y).norm(), it, true) else { continue };
                if count(&p).is_some_and(|c| c != n_end) {
                    return Some((p, std::mem::take(&mut self.pair_senses), before));
                }
            }
        }
        None
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
        let (tol, one_sided) = (self.opts.tol, self.ev.one_sided);
        self.opts.tol = copts.corrector_tol.unwrap_or(tol);
        self.ev.one_sided = copts.one_sided;
        let branch = self.continue_with_tol(parameter, from, to, guess, copts);
        (self.opts.tol, self.ev.one_sided) = (tol, one_sided);
        branch
    }

    /// [`Hbm::continue_in`] with the corrector's tolerance and the differences already set.
    fn continue_with_tol(
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
        let su = Setup::new(self, parameter, p_ref, self.at(order));
        let (l_from, l_to) = (from / p_ref, to / p_ref);
        let m = self.unknowns();
        let dir = (l_to - l_from).signum();
        let mut newton = 0;
        let sol0 = self.solve_at(&su.at(l_from), guess)?;
        newton += sol0.iterations;
        let y0 = self.y_of(&su, &sol0);
        // Initial tangent: the row e_λ fixes dλ = 1, then the sign follows the direction.
        self.assemble(&su.x_of(y0.as_slice(), m), &su.at(l_from), Some(parameter));
        let mut e_l = DVector::zeros(m + 1);
        e_l[m] = 1.0;
        let t0 = self.tangent(&su, &e_l, order)? * dir;
        self.follow(&su, Cursor { y: y0, t: t0 }, sol0.iterations, (l_from, l_to), newton, copts, None)
    }

    /// The continuation proper from the point `cur` (on the branch, with its unit tangent
    /// pointing the way to go; `iterations` its corrector's), inside the parameter range
    /// `(l_from, l_to)` (scaled; the branch ends on leaving either end). With `watch` =
    /// (c, mirror) it also ends where the branch returns to the symmetric (unison) states: where
    /// cᵀx changes sign (c antisymmetric, so cᵀx = 0 on every symmetric state) at a state
    /// the mirror permutation of the unknowns leaves unchanged (see `switch`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn follow(
        &mut self,
        su: &Setup,
        cur: Cursor,
        iterations: usize,
        (l_from, l_to): (f64, f64),
        mut newton: usize,
        copts: &ContinuationOptions,
        watch: Option<(&[f64], &super::Symmetry)>,
    ) -> Result<Branch, HbmError> {
        let su = *su;
        let parameter = su.param;
        let p_ref = su.p_ref;
        let m = self.unknowns();
        let dir = (l_to - l_from).signum();
        let mut cur = cur;
        let mut chord_m = Chord { lu: self.factor(Some((&su, &cur.t))), update: None };
        let mut points = vec![self.branch_point(&su, &cur.y, Some(&cur.t), 0.0, iterations, copts.stability)?];
        // The accepted points' arclengths and test functions (each computed once).
        let mut tests = vec![(0.0, test_functions(&points[0]))];
        // And their Floquet pairs near ±1 with the senses they turn in.
        let mut senses = vec![std::mem::take(&mut self.pair_senses)];
        let mut folds = Vec::new();
        let mut ds = copts.ds;
        let mut s = 0.0;
        // The previous point's tangent and the chord to it.
        let mut prev: Option<(DVector<f64>, f64)> = None;
        // A step already aimed at a suspected pair of crossings, and a step already tried past a
        // point where the corrector failed at every smaller step, since the last accepted point.
        let (mut aimed, mut jumped, mut misses): (Option<usize>, bool, Vec<u32>) = (None, false, Vec::new());
        let mut quiet: Vec<u32> = Vec::new();
        let aim_floor = 1e-3 * copts.ds.min(copts.ds_max);
        let mut last_chord = copts.ds;
        let end = loop {
            if points.len() >= copts.max_points {
                break BranchEnd::MaxPoints;
            }
            if crate::deadline::Deadline::passed_opt(copts.deadline) {
                break BranchEnd::Watchdog;
            }
            if ds < copts.ds_min {
                // The corrector fails at every step close to the last point (a branch point of
                // several coinciding branches, where the bordered matrix is singular in more than
                // one direction): try once to step across it, then give up.
                if jumped {
                    break BranchEnd::StepTooSmall;
                }
                jumped = true;
                ds = (4.0 * last_chord).min(copts.ds_max);
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
            self.assemble(&su.x_of(y.as_slice(), m), &at, Some(parameter));
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
            // The chord must follow the tangent as the tangents follow each other: a corrector
            // that lands on another sheet of an S-shaped branch (both sheets with the same
            // direction there, so the tangents agree) leaves along a chord at a large angle.
            if chord > 0.0 && (&y - &cur.y).dot(&cur.t) < copts.min_cos * chord && ds > copts.ds_min {
                ds *= 0.5;
                continue;
            }
            let (l_new, l_old) = (y[m], cur.y[m]);
            // Leaving the range: finish exactly at its end by a solve at fixed parameter.
            let past_target = dir * (l_new - l_to) >= 0.0;
            let past_start = dir * (l_new - l_from) < 0.0;
            if past_target || past_start {
                let l_end = if past_target { l_to } else { l_from };
                let frac = (l_end - l_old) / (l_new - l_old);
                let y_guess = &cur.y + (&y - &cur.y) * frac;
                let x_guess = su.x_of(y_guess.as_slice(), m);
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
                self.assemble(&su.x_of(y_end.as_slice(), m), &su.at(y_end[m]), Some(parameter));
                let t_end = self.tangent(&su, &t, su.at(y_end[m]).order).unwrap_or(t);
                points.push(self.branch_point(&su, &y_end, Some(&t_end), s, iters, copts.stability)?);
                break if past_target { BranchEnd::ReachedTarget } else { BranchEnd::LeftRange };
            }
            let cand = self.branch_point(&su, &y, Some(&t), s + chord, iters, copts.stability)?;
            let cand_senses = std::mem::take(&mut self.pair_senses);
            // A pair of crossings (two folds, or a multiplier out of the unit circle and back)
            // inside one step leaves the test functions with the same sign at both ends; the
            // quadratic through the last two points and this one shows the dip. Aim the step at
            // the dip's extremum instead (once per step): a crossing there is then a sign
            // change between accepted points, whatever the step limit.
            let cand_tests = (cand.arclength, test_functions(&cand));
            let predicted = if points.len() >= 2 {
                dip(&tests[tests.len() - 2], &tests[tests.len() - 1], &cand_tests)
            } else {
                Vec::new()
            };
            misses.resize(cand_tests.1.len(), 0);
            let target = predicted.iter().filter(|(j, _)| misses[*j] < 3).min_by(|a, b| a.1.total_cmp(&b.1)).copied();
            if aimed.is_none()
                && let Some((j, s_dip)) = target
            {
                // Not below a floor, and by at most 5× at a time: a zero of odd multiplicity
                // above one (a multiplier repeated by symmetry) looks like a dip from either side
                // and would otherwise draw the steps towards it without end.
                let aimed_ds = ((s_dip - s) * ds / chord).max(0.2 * ds).max(aim_floor);
                if aimed_ds < ds {
                    aimed = Some(j);
                    ds = aimed_ds;
                    continue;
                }
            }
            // An aimed step that showed no sign change of its test function was a false alarm (a
            // zero of higher multiplicity, a near miss, or a product of many multipliers that
            // decays like an exponential, which a quadratic takes for a dip); after three that
            // function is not aimed at until it changes sign or stops dipping for four points in
            // a row, so such a zero cannot hold the steps small. (Counting only aimed steps that
            // still dipped let 16 mistuned pendulums aim at every other step: the aimed point
            // lands past the false extremum, the next step dips again.) Each test function keeps
            // its own count.
            quiet.resize(cand_tests.1.len(), 0);
            if let Some((_, last)) = tests.last()
                && last.len() == cand_tests.1.len()
            {
                for (j, (m, q)) in misses.iter_mut().zip(quiet.iter_mut()).enumerate() {
                    // An aimed step dipped at its full length; the shortened one usually does
                    // not (it lands on the extremum), which is no sign of a quiet function.
                    let dips = aimed == Some(j) || predicted.iter().any(|(k, _)| *k == j);
                    *q = if dips { 0 } else { *q + 1 };
                    if last[j].0 != cand_tests.1[j].0 || *q >= 4 {
                        *m = 0;
                    } else if aimed == Some(j) {
                        *m += 1;
                    }
                }
            }
            aimed = None;
            jumped = false;
            if let Some((c, symmetry)) = watch
                && let Some(y_r) = self.rejoin(&su, &cur, &y, c, symmetry, &mut newton)
            {
                s += (&y_r - &cur.y).norm();
                self.assemble(&su.x_of(y_r.as_slice(), m), &su.at(y_r[m]), Some(parameter));
                let t_r = self.tangent(&su, &t, su.at(y_r[m]).order).unwrap_or_else(|_| t.clone());
                points.push(self.branch_point(&su, &y_r, Some(&t_r), s, iters, copts.stability)?);
                break BranchEnd::Unison;
            }
            if t[m].signum() != cur.t[m].signum() && t[m] != 0.0 && cur.t[m] != 0.0 {
                let kind = if cur.t[m] > 0.0 { FoldKind::Maximum } else { FoldKind::Minimum };
                let refined =
                    if copts.refine_folds { self.refine_fold(&su, &cur, chord, t[m], &mut newton) } else { None };
                let mut partner = None;
                let fold = match refined {
                    Some((yf, tf)) => {
                        if copts.stability
                            && let Some(last) = points.last()
                        {
                            partner = self.fold_partner(&su, (&cur, last), (&y, &cand), &yf, s);
                        }
                        let p = self.branch_point(&su, &yf, None, 0.0, 0, false)?;
                        let mut critical = su.x_of(tf.as_slice(), m);
                        critical[self.spin * self.nb] = 0.0;
                        Fold {
                            order: p.order,
                            parameter: p.parameter,
                            kind,
                            after: points.len() - 1,
                            accel_main: p.accel_main,
                            pendulum_amplitude: p.pendulum_amplitude,
                            critical,
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
                            critical: Vec::new(),
                        }
                    }
                };
                folds.push(fold);
                // A second crossing of +1 in the fold's segment becomes a segment of its own.
                if let Some((point, ps, before)) = partner {
                    if before && let Some(f) = folds.last_mut() {
                        f.after += 1;
                    }
                    tests.push((point.arclength, test_functions(&point)));
                    senses.push(ps);
                    points.push(point);
                }
            }
            s += chord;
            last_chord = chord;
            tests.push(cand_tests);
            senses.push(cand_senses);
            if let Some(hook) = &self.on_point {
                (hook.0)(points.len() + 1, cand.parameter);
            }
            points.push(cand);
            prev = Some((std::mem::replace(&mut cur, Cursor { y, t }).t, chord));
            chord_m = next_chord;
            if iters <= 7 && refreshes <= 1 {
                ds = (ds * 1.5).min(copts.ds_max);
            } else if iters >= 10 || refreshes >= 3 {
                ds *= 0.7;
            }
        };
        let mut branch = Branch { parameter, points, folds, bifurcations: Vec::new(), end, newton_iterations: newton };
        // Past the deadline the crossings stay where the accepted points bracket them.
        let refine = copts.refine_folds && branch.end != BranchEnd::Watchdog;
        if refine && copts.stability {
            self.split_tongues(&su, &mut branch, &mut tests, &mut senses);
            self.split_narrow_pairs(&su, &mut branch, &mut tests, &mut senses);
        }
        branch.bifurcations = bifurcations(&branch.points, &branch.folds);
        if refine {
            self.refine_crossings(&su, &mut branch);
        }
        Ok(branch)
    }

    /// Pairs of crossings that one step stepped over whole: a multiplier that leaves the unit
    /// circle and comes back inside a stretch shorter than the step (a narrow Mathieu tongue of
    /// period doubling, a short loss of unison) leaves its test function with one sign at every
    /// accepted point, but with a deep minimum of its magnitude at the point nearest the
    /// stretch. Where a test function's magnitude at an accepted point is below a quarter of
    /// both neighbours' (same sign at all three), and its factor nearest to zero
    /// ([`nearest_factor`]) below half of theirs, its minimum over the two segments around the
    /// point is searched (golden section in arclength, states from [`Branch::interpolate`]
    /// solved at the fixed parameter, 16 evaluations at most); a state where the function has
    /// the other sign is inserted as a point, so that the pair shows as two changes of sign
    /// between accepted points and is located and classified like any other. Segments with a
    /// fold are left alone (the parameter is not monotone there).
    fn split_narrow_pairs(&mut self, su: &Setup, branch: &mut Branch, tests: &mut Tests, senses: &mut Senses) {
        const DEPTH: f64 = std::f64::consts::LN_2 * 2.0;
        let mut i = 1;
        // `tests` holds every accepted point's test functions but the end point's, made by a
        // solve at fixed parameter: the two agree index by index up to there.
        while i + 1 < tests.len() && tests.len() <= branch.points.len() {
            let (a, b, c) = (&tests[i - 1].1, &tests[i].1, &tests[i + 1].1);
            let near_fold = branch.folds.iter().any(|f| f.after + 1 == i || f.after == i);
            // The slope (index 0) is the folds' own test, kept by the tangents.
            let suspect = (1..b.len()).find(|&j| {
                a.len() == b.len()
                    && c.len() == b.len()
                    && b[j].0 != 0.0
                    && a[j].0 == b[j].0
                    && c[j].0 == b[j].0
                    && b[j].1 + DEPTH < a[j].1.min(c[j].1)
            });
            let (Some(j), false) = (suspect, near_fold) else {
                i += 1;
                continue;
            };
            // A product over many multipliers (33 on 16 pendulums: 528 factors in the
            // Neimark–Sacker test) dips by far more than this from the small motions of factors
            // nowhere near zero; a pair that passes through its critical value and back drags its
            // own factor down with it. So the nearest factor must dip too (by half the depth: a
            // conjugate pair's two factors have the same magnitude and make the product's dip
            // twice its own).
            let nearest = |k: usize| nearest_factor(&branch.points[k], j);
            if nearest(i) + 0.5 * DEPTH >= nearest(i - 1).min(nearest(i + 1)) {
                i += 1;
                continue;
            }
            let sign = b[j].0;
            // t in [0, 2]: segment i−1 for t < 1, segment i beyond; t = 1 is point i.
            let at = |t: f64| if t < 1.0 { (i - 1, t) } else { (i, t - 1.0) };
            let Some((t, found)) = self.golden_for_sign(su, branch, &at, (0.0, 1.0, 2.0), b[j].1, j, sign) else {
                i += 1;
                continue;
            };
            let at = if t < 1.0 { i } else { i + 1 };
            insert_point(branch, tests, senses, at, found);
            // Past the inserted point and its neighbours: they now straddle the changes.
            i = at + 2;
        }
    }

    /// Tongues stepped over whole, told by the sense of a pair near ±1 (see
    /// `stability::PairSense`): where the member with Im μ > 0 of a pair near −1 (+1) turns the
    /// other way at the end of a segment than at its start (the same pair: eigenvectors parallel
    /// up to conjugation) while the block's Π(μ + 1) (Π(μ − 1)) kept its sign, the pair met on
    /// the real axis inside the segment, and passed through −1 (+1) and back there unless it met
    /// inside the unit circle. The segment is bisected on the sense (states from
    /// [`Branch::interpolate`] solved at the fixed parameter) until a state inside the tongue is
    /// found, or one where the pair is real but the test function has its old sign (the real
    /// stretch is wider than the tongue): then its magnitude is minimised by golden section
    /// between the two senses' states. A state where the test function has the other sign is
    /// inserted as a point, so the pair becomes two changes of sign between accepted points.
    /// Segments with a fold are left alone, and so are flips whose pair match is ambiguous or
    /// whose senses are faint (`clear_flip`: clustered pairs).
    fn split_tongues(&mut self, su: &Setup, branch: &mut Branch, tests: &mut Tests, senses: &mut Senses) {
        let mut i = 0;
        while i + 1 < tests.len() && tests.len() <= branch.points.len() && senses.len() == tests.len() {
            let Some((j, block, pair, span)) = flipped(tests, senses, i) else {
                i += 1;
                continue;
            };
            if branch.folds.iter().any(|f| f.after >= i && f.after < i + span) {
                i += 1;
                continue;
            }
            let sign = tests[i].1[j].0;
            let found = if span == 1 {
                self.bisect_on_sense(su, branch, i, (j, block, sign), &pair)
            } else {
                // The points in between hold the pair on the real axis: the tongue, if any, is
                // around the one where the test function is least.
                let m = (1..span).min_by(|&a, &b| tests[i + a].1[j].1.total_cmp(&tests[i + b].1[j].1)).unwrap_or(1);
                let at = |t: f64| {
                    let k = (t.floor() as usize).min(span - 1);
                    (i + k, t - k as f64)
                };
                self.golden_for_sign(su, branch, &at, (0.0, m as f64, span as f64), tests[i + m].1[j].1, j, sign)
            };
            let Some((t, point)) = found else {
                i += 1;
                continue;
            };
            let at = i + (t.floor() as usize).min(span - 1) + 1;
            insert_point(branch, tests, senses, at, point);
            i += span + 1;
        }
    }

    /// Bisection of segment i on the sense of `pair` (of `block`, at point i) until a state
    /// where test function j has the other sign than `sign`, or the pair is on the real axis
    /// (then golden section on the test function between the two senses' states): that σ and
    /// state.
    fn bisect_on_sense(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        (j, block, sign): (usize, usize, f64),
        pair: &PairSense,
    ) -> Option<(f64, (BranchPoint, PairSenses))> {
        let (mut lo, mut hi) = (0.0, 1.0);
        let mut reference = pair.v.clone();
        let at = |t: f64| (i, t);
        for _ in 0..40 {
            if hi - lo < 1e-9 {
                break;
            }
            let mid = 0.5 * (lo + hi);
            let (point, ps) = self.point_on_segment(su, branch, i, mid)?;
            let f = test_functions(&point)[j];
            if f.0 != sign && f.0 != 0.0 {
                return Some((mid, (point, ps)));
            }
            match ps.get(block).and_then(|b| same_pair(b, pair.side, &reference)) {
                Some(p) if p.sense * pair.sense > 0.0 => {
                    lo = mid;
                    reference = p.v.clone();
                }
                Some(_) => hi = mid,
                None => return self.golden_for_sign(su, branch, &at, (lo, mid, hi), f.1, j, sign),
            }
        }
        None
    }

    /// The solution at fraction σ of segment `seg`, solved at the interpolated parameter, as a
    /// branch point with its stability (no tangent), and its pairs' senses.
    fn point_on_segment(
        &mut self,
        su: &Setup,
        branch: &Branch,
        seg: usize,
        sigma: f64,
    ) -> Option<(BranchPoint, PairSenses)> {
        let guess = branch.interpolate(seg, sigma)?;
        let lambda = su.param.value(&guess) / su.p_ref;
        let sol = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()).ok()?;
        let y = self.y_of(su, &sol);
        let (sa, sb) = (branch.points[seg].arclength, branch.points[seg + 1].arclength);
        let point = self.branch_point(su, &y, None, sa + sigma * (sb - sa), sol.iterations, true).ok()?;
        Some((point, std::mem::take(&mut self.pair_senses)))
    }

    /// Golden section on ln |f_j| (test function j) over the bracket (lo, mid, hi) of a
    /// parameter t that `at` maps to (segment, σ), `f_mid` its value at mid, until a state
    /// where f_j has the other sign than `sign` (16 evaluations at most): that t and state.
    #[allow(clippy::too_many_arguments)]
    fn golden_for_sign(
        &mut self,
        su: &Setup,
        branch: &Branch,
        at: &dyn Fn(f64) -> (usize, f64),
        (mut lo, mut mid, mut hi): (f64, f64, f64),
        mut f_mid: f64,
        j: usize,
        sign: f64,
    ) -> Option<(f64, (BranchPoint, PairSenses))> {
        let golden = 0.381_966_011_250_105_2;
        for _ in 0..16 {
            let t = if mid - lo > hi - mid { mid - golden * (mid - lo) } else { mid + golden * (hi - mid) };
            let (seg, sigma) = at(t);
            let (point, ps) = self.point_on_segment(su, branch, seg, sigma)?;
            let (sg, lg) = *test_functions(&point).get(j)?;
            if sg != sign && sg != 0.0 {
                return Some((t, (point, ps)));
            }
            if lg < f_mid {
                if t < mid {
                    hi = mid;
                } else {
                    lo = mid;
                }
                (mid, f_mid) = (t, lg);
            } else if t < mid {
                lo = t;
            } else {
                hi = t;
            }
        }
        None
    }

    /// Locates each crossing that is not a fold by bisection along its segment: states from
    /// [`Branch::interpolate`] as guesses, solved at the fixed parameter (the segment holds no
    /// fold, so the parameter is monotone along it and the solve is regular), the count of
    /// multipliers outside the unit circle deciding the side, halved until 1e-11 of the
    /// parameter.
    /// A branch point (+1) is then finished by a secant search (Illinois) on the determinant of
    /// ∂R̂/∂x, which vanishes where the periodic problem has a second solution direction: its
    /// location is then limited by the corrector's tolerance, not by the monodromy's accuracy
    /// (~1e-7 in the multipliers, which moves a crossing by ~1e-6 in the order). A crossing
    /// whose bisection fails keeps its interpolated location; when the determinant keeps its sign
    /// (a multiplier repeated an even number of times by symmetry) the bisection's.
    fn refine_crossings(&mut self, su: &Setup, branch: &mut Branch) {
        for k in 0..branch.bifurcations.len() {
            let i = branch.bifurcations[k].after;
            if branch.folds.iter().any(|f| f.after == i) {
                continue;
            }
            let Some(before) = branch.points[i].solution.stability.as_ref().map(Stability::outside) else { continue };
            if branch.bifurcations[k].kind == BifurcationKind::PlusOne
                && !self.non_unison.is_empty()
                && let Some((order, parameter)) = self.secant_on_block(su, branch, i)
            {
                let b = &mut branch.bifurcations[k];
                (b.order, b.parameter) = (order, parameter);
                continue;
            }
            let (mut lo, mut hi) = (0.0, 1.0);
            let mut found = None;
            // Halved until the bracket is 1e-11 of the parameter wide (a crossing to ≤ 1e-8
            // whatever the segment's length), 60 halvings at most.
            let width = (branch.points[i + 1].parameter - branch.points[i].parameter).abs();
            let target = 1e-11 * (1.0 + branch.points[i].parameter.abs());
            for _ in 0..60 {
                if (hi - lo) * width <= target {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                let Some(guess) = branch.interpolate(i, mid) else { break };
                let lambda = su.param.value(&guess) / su.p_ref;
                let Ok(sol) = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()) else { break };
                let Ok(st) = self.stability(&sol) else { break };
                if st.outside() == before {
                    lo = mid;
                } else {
                    hi = mid;
                }
                found = Some((sol.order, lambda * su.p_ref));
            }
            if branch.bifurcations[k].kind == BifurcationKind::PlusOne
                && found.is_some()
                && let Some(at) = self.root_of_determinant(su, branch, i, lo, hi)
            {
                found = Some(at);
            }
            if let Some((order, parameter)) = found {
                let b = &mut branch.bifurcations[k];
                (b.order, b.parameter) = (order, parameter);
            }
        }
    }

    /// The step below which a Newton solve that stopped contracting is taken as converged while
    /// locating an event ([`Hbm::solve_within`]): 1000 times the tolerance. Beside a branch
    /// point the steps stall at 1e-10–1e-9 (a tolerance of 1e-10); a state that close decides a
    /// count of multipliers or the sign of a determinant as well as a converged one, where a
    /// failed solve used to end the bisection with the bracket as wide as it then was.
    fn stall_floor(&self) -> f64 {
        1e3 * self.opts.tol
    }

    /// The solution at fraction σ of segment i, solved at the interpolated parameter, and the
    /// sign and ln |·| of the determinant there of the whole ∂R̂/∂x (`block` None) or of the rows
    /// and columns of one non-unison set of the cyclic route (`block` Some(k): the Galerkin form
    /// of that set's variational equations with the parent held, whose determinant vanishes
    /// where its Floquet block has a multiplier +1).
    fn determinant_at(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        sigma: f64,
        block: Option<usize>,
    ) -> Option<(HbmSolution, f64, f64)> {
        let guess = branch.interpolate(i, sigma)?;
        let lambda = su.param.value(&guess) / su.p_ref;
        let sol = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()).ok()?;
        let x = self.unknowns_from(Some(&sol));
        self.assemble(&x, &su.at(lambda), Some(su.param));
        let (sign, log) = match block {
            None => self.factor(None).determinant(),
            Some(k) => {
                let nb = self.nb;
                let idx: Vec<usize> =
                    self.non_unison.get(k)?.coordinates.iter().flat_map(|&c| c * nb..(c + 1) * nb).collect();
                let matrix = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |r, c| self.jac[(idx[r], idx[c])]);
                Factor::Dense(matrix.lu()).determinant()
            }
        };
        log.is_finite().then_some((sol, sign, log))
    }

    /// A branch point of a non-unison set on the cyclic route: Illinois regula falsi along
    /// segment i on the determinant of the set's block of ∂R̂/∂x, when it changes sign between
    /// the segment's ends. The reduced problem itself stays regular there (the non-unison motion
    /// is not among its unknowns), so every solve converges and no Floquet analysis is needed:
    /// a few solves instead of the count's bisection. To 1e-12 of the segment or 40 solves.
    fn secant_on_block(&mut self, su: &Setup, branch: &Branch, i: usize) -> Option<(f64, f64)> {
        for k in 0..self.non_unison.len() {
            let (_, sa, la) = self.determinant_at(su, branch, i, 0.0, Some(k))?;
            let (_, sb, lb) = self.determinant_at(su, branch, i, 1.0, Some(k))?;
            if sa == sb {
                continue;
            }
            let reference = la.max(lb);
            let mut ill = Illinois::new((0.0, sa * (la - reference).exp()), (1.0, sb * (lb - reference).exp()));
            let mut best = None;
            for _ in 0..40 {
                if (ill.s1 - ill.s0).abs() <= 1e-12 || ill.f1 == ill.f0 {
                    break;
                }
                let s = ill.secant().clamp(ill.s0.min(ill.s1), ill.s0.max(ill.s1));
                let (sol, sg, lg) = self.determinant_at(su, branch, i, s, Some(k))?;
                best = Some((sol.order, su.param.value(&sol)));
                let f = sg * (lg - reference).exp();
                if f == 0.0 {
                    break;
                }
                ill.update(s, f);
            }
            if best.is_some() {
                return best;
            }
        }
        None
    }

    /// det ∂R̂/∂x at fraction σ of segment i (solved at the interpolated parameter), as a
    /// [`DetSample`].
    fn determinant_sample(&mut self, su: &Setup, branch: &Branch, i: usize, sigma: f64) -> Option<DetSample> {
        let (sol, sign, log) = self.determinant_at(su, branch, i, sigma, None)?;
        Some(DetSample { sigma, lambda: su.lambda(&sol), sign, log, order: sol.order })
    }

    /// A bracket [lo, hi] of segment i (fractions) across which det ∂R̂/∂x changes sign, grown
    /// from the multiplier count's bracket (lo, hi) when the determinant has one sign there: the
    /// count comes from the monodromy, whose error (~1e-7 in the multipliers) can put its
    /// crossing ~1e-6 in the order away from the determinant's root, and a bracket of 1e-11
    /// then misses it. The bracket grows fourfold on each side until one side changes sign (at
    /// most 24 times, to the segment's ends), then is shrunk by bisection back to the width it
    /// started with, or until a solve beside the root fails. Its two ends' samples; None when no
    /// sign change is found.
    fn determinant_bracket(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        lo: f64,
        hi: f64,
    ) -> Option<(DetSample, DetSample)> {
        let (s_lo, s_hi) = (self.determinant_sample(su, branch, i, lo)?, self.determinant_sample(su, branch, i, hi)?);
        if s_lo.sign != s_hi.sign {
            return Some((s_lo, s_hi));
        }
        let sign = s_lo.sign;
        let w0 = (hi - lo).max(1e-14);
        let (mut a, mut b) = (s_lo, s_hi);
        let mut bracket = None;
        for k in 1..=24 {
            let w = w0 * 4f64.powi(k);
            let (na, nb) = ((lo - w).max(0.0), (hi + w).min(1.0));
            // A solve that fails (stalls right beside the root) leaves that side where it was:
            // the next, wider end brackets the root instead.
            for (end, held) in [(na, &mut a), (nb, &mut b)] {
                if end == held.sigma {
                    continue;
                }
                match self.determinant_sample(su, branch, i, end) {
                    Some(x) if x.sign != sign => {
                        bracket = Some(if end < held.sigma { (x, *held) } else { (*held, x) });
                        break;
                    }
                    Some(x) => *held = x,
                    None => {}
                }
            }
            if bracket.is_some() || (a.sigma <= 0.0 && b.sigma >= 1.0) {
                break;
            }
        }
        let (mut a, mut b) = bracket?;
        while b.sigma - a.sigma > w0 {
            // Right beside the root the solve may stall above its floor: the cubic through the
            // samples around the bracket reaches in from there.
            let Some(m) = self.determinant_sample(su, branch, i, 0.5 * (a.sigma + b.sigma)) else { break };
            if m.sign == a.sign {
                a = m;
            } else {
                b = m;
            }
        }
        Some((a, b))
    }

    /// det ∂R̂/∂x = 0 near [lo, hi] of segment i (a bracket of the multiplier count's
    /// bisection, moved to the determinant's own sign change by [`Hbm::determinant_bracket`]):
    /// the cubic through the determinant at lo, hi and one bracket width beyond each,
    /// as a function of the parameter, and its root in the bracket; the order and parameter
    /// there. Newton at fixed parameter does not converge to 1e-10 right at the branch point (its
    /// Jacobian is singular there), so the determinant is sampled where it does and interpolated
    /// in between: over a bracket of ~1e-6 of the segment it is linear to many digits. None when
    /// no sign change is found near the bracket, or a solve at a node fails.
    fn root_of_determinant(&mut self, su: &Setup, branch: &Branch, i: usize, lo: f64, hi: f64) -> Option<(f64, f64)> {
        let (s_lo, s_hi) = self.determinant_bracket(su, branch, i, lo, hi)?;
        let (lo, hi) = (s_lo.sigma, s_hi.sigma);
        let w = hi - lo;
        // Two nodes beside the bracket, inside the segment and distinct from the bracket's ends
        // (clamping lo − w or hi + w to the segment's end repeated a node, and the cubic through
        // a repeated node is not defined).
        let mut samples = vec![s_lo, s_hi];
        for sigma in [lo - w, hi + w, lo - 2.0 * w, hi + 2.0 * w, lo + w / 3.0, lo + 2.0 * w / 3.0]
            .into_iter()
            .filter(|s| (0.0..=1.0).contains(s))
            .take(2)
        {
            samples.push(self.determinant_sample(su, branch, i, sigma)?);
        }
        if samples.len() < 4 {
            return None;
        }
        samples.sort_by(|x, y| x.sigma.total_cmp(&y.sigma));
        let (l_lo, l_hi) = (s_lo.lambda, s_hi.lambda);
        if samples.windows(2).any(|p| p[0].lambda == p[1].lambda) {
            return None;
        }
        // Values relative to the largest magnitude, so that the interpolation sees O(1) numbers.
        let reference = samples.iter().map(|x| x.log).fold(f64::NEG_INFINITY, f64::max);
        let pts: Vec<(f64, f64)> = samples.iter().map(|x| (x.lambda, x.sign * (x.log - reference).exp())).collect();
        let cubic = |l: f64| {
            pts.iter()
                .enumerate()
                .map(|(k, &(lk, fk))| {
                    fk * pts
                        .iter()
                        .enumerate()
                        .filter(|&(j, _)| j != k)
                        .map(|(_, &(lj, _))| (l - lj) / (lk - lj))
                        .product::<f64>()
                })
                .sum::<f64>()
        };
        let (mut a, mut b) = (l_lo, l_hi);
        let fa = cubic(a);
        if fa.signum() == cubic(b).signum() {
            return None;
        }
        for _ in 0..100 {
            let mid = 0.5 * (a + b);
            if cubic(mid).signum() == fa.signum() {
                a = mid;
            } else {
                b = mid;
            }
        }
        let lambda = 0.5 * (a + b);
        // The order: n itself on an order branch, the fixed order otherwise.
        let order = if su.param == Parameter::Order { lambda } else { s_lo.order };
        Some((order, lambda * su.p_ref))
    }
}

/// det ∂R̂/∂x at fraction `sigma` of a segment: the scaled parameter λ of the state solved there,
/// the determinant's sign and ln |det|, and the order.
#[derive(Debug, Clone, Copy)]
struct DetSample {
    sigma: f64,
    lambda: f64,
    sign: f64,
    log: f64,
    order: f64,
}

/// Each accepted point's arclength and [`test_functions`].
type Tests = Vec<(f64, Vec<(f64, f64)>)>;
/// One point's pairs near ±1, per Floquet block.
type PairSenses = Vec<Vec<PairSense>>;
/// Each accepted point's [`PairSenses`].
type Senses = Vec<PairSenses>;

/// Inserts a point found inside a segment before index `at`, with its test functions and
/// senses, and moves the folds after it along.
fn insert_point(
    branch: &mut Branch,
    tests: &mut Tests,
    senses: &mut Senses,
    at: usize,
    (point, ps): (BranchPoint, PairSenses),
) {
    tests.insert(at, (point.arclength, test_functions(&point)));
    if senses.len() >= at {
        senses.insert(at, ps);
    }
    branch.points.insert(at, point);
    for f in &mut branch.folds {
        if f.after >= at {
            f.after += 1;
        }
    }
}

/// The pair of `pairs` on `side` whose eigenvector is nearest to parallel to `v` or to its
/// conjugate (|vᴴw| or |vᵀw|, both unit vectors), if that overlap exceeds ½: the same pair at a
/// nearby state, whichever member has Im μ > 0 there.
fn same_pair<'a>(pairs: &'a [PairSense], side: f64, v: &DVector<nalgebra::Complex<f64>>) -> Option<&'a PairSense> {
    pairs
        .iter()
        .filter(|p| p.side == side && p.v.len() == v.len())
        .map(|p| (overlap(v, &p.v), p))
        .filter(|(o, _)| *o > 0.5)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
}

/// |vᴴw| or |vᵀw|, whichever is larger: the overlap of two unit eigenvectors of a pair whatever
/// their phase and whichever member of the conjugate pair each is.
fn overlap(v: &DVector<nalgebra::Complex<f64>>, w: &DVector<nalgebra::Complex<f64>>) -> f64 {
    let plain: nalgebra::Complex<f64> = v.iter().zip(w.iter()).map(|(a, b)| a.conj() * b).sum();
    let conj: nalgebra::Complex<f64> = v.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
    plain.norm().max(conj.norm())
}

/// Whether the flip of sense from pair p to its match q (among `pairs`, the next point's pairs
/// of the same block) is worth a search: the match is unambiguous (overlap at least 0.9, no
/// other pair of that side above 0.5) and both senses are clear (|sense| ≥ 0.5). A cluster of
/// nearly equal pairs, as slightly mistuned identical absorbers have (15 pairs within 1e-3 of
/// each other), mixes its eigenvectors from point to point, so senses "flip" with no pair near
/// the real axis: there the matches measured 0.54–0.99 with runners-up up to 0.69 and senses
/// down to 6e-5, where every flip that held a tongue in the tests matched at ≥ 0.957 with
/// runners-up ≤ 0.24 and senses ≥ 0.91 (BENCHMARKS.md, issue 26).
fn clear_flip(pairs: &[PairSense], p: &PairSense, q: &PairSense) -> bool {
    let mut overlaps: Vec<f64> =
        pairs.iter().filter(|r| r.side == p.side && r.v.len() == p.v.len()).map(|r| overlap(&p.v, &r.v)).collect();
    overlaps.sort_by(|a, b| b.total_cmp(a));
    overlaps.first().is_some_and(|&o| o >= 0.9)
        && overlaps.get(1).is_none_or(|&o| o <= 0.5)
        && p.sense.abs() >= 0.5
        && q.sense.abs() >= 0.5
}

/// A pair near ±1 at point i whose sense differs at the next point that holds it (within three
/// points: in between it may sit on the real axis) while its block's test function for that
/// side kept its sign: that test function's index, the block, the pair at i and the number of
/// segments spanned.
fn flipped(tests: &Tests, senses: &Senses, i: usize) -> Option<(usize, usize, PairSense, usize)> {
    let ta = &tests.get(i)?.1;
    let sa = senses.get(i)?;
    if ta.len() != 1 + 3 * sa.len() {
        return None;
    }
    for (k, pa) in sa.iter().enumerate() {
        for p in pa {
            // Index of Π(μ − 1) or Π(μ + 1) of block k (see `test_functions`).
            let j = 1 + 3 * k + usize::from(p.side < 0.0);
            for span in 1..=3 {
                let (Some((_, tb)), Some(sb)) = (tests.get(i + span), senses.get(i + span)) else { break };
                if tb.len() != ta.len() || sb.len() != sa.len() || tb[j].0 != ta[j].0 {
                    break;
                }
                if let Some(q) = same_pair(&sb[k], p.side, &p.v) {
                    if q.sense * p.sense < 0.0 && clear_flip(&sb[k], p, q) {
                        return Some((j, k, p.clone(), span));
                    }
                    break;
                }
            }
        }
    }
    None
}

/// The test functions of a branch point whose sign changes mark the events of a branch, each as
/// (sign, ln |value|) so that products over many multipliers neither overflow nor underflow:
/// dλ/ds (folds), and per Floquet block Π(μ − 1) (a real multiplier through +1), Π(μ + 1)
/// (through −1) and Π_{i<j}(μ_i μ_j − 1) (a complex pair through the unit circle: Neimark–Sacker;
/// it also vanishes at a neutral saddle, μ_i μ_j = 1 with both real). Products of all the
/// block's multipliers are symmetric functions of them, so they stay smooth where a complex
/// pair meets on the real axis and splits.
fn test_functions(p: &BranchPoint) -> Vec<(f64, f64)> {
    let mut out = vec![(p.slope.signum(), p.slope.abs().ln())];
    let Some(st) = &p.solution.stability else { return out };
    let product = |fs: &mut dyn Iterator<Item = nalgebra::Complex<f64>>| {
        let (mut sign, mut log) = (nalgebra::Complex::new(1.0, 0.0), 0.0);
        for f in fs {
            let r = f.norm();
            log += r.ln();
            if r > 0.0 {
                sign *= f / r;
            }
        }
        (sign.re.signum(), log)
    };
    let one = nalgebra::Complex::new(1.0, 0.0);
    for b in &st.blocks {
        let mu = &b.multipliers;
        out.push(product(&mut mu.iter().map(|m| m - one)));
        out.push(product(&mut mu.iter().map(|m| m + one)));
        out.push(product(
            &mut (0..mu.len()).flat_map(|i| (i + 1..mu.len()).map(move |j| (i, j))).map(|(i, j)| mu[i] * mu[j] - one),
        ));
    }
    out
}

/// ln of the smallest factor's magnitude in test function j of [`test_functions`] at `p` (the
/// multiplier, or product of two, nearest to its critical value); +∞ when `p` has none.
fn nearest_factor(p: &BranchPoint, j: usize) -> f64 {
    let Some(st) = &p.solution.stability else { return f64::INFINITY };
    let (Some(block), kind) = (j.checked_sub(1).map(|k| k / 3), j.checked_sub(1).map_or(0, |k| k % 3)) else {
        return f64::INFINITY;
    };
    let Some(b) = st.blocks.get(block) else { return f64::INFINITY };
    let mu = &b.multipliers;
    let one = nalgebra::Complex::new(1.0, 0.0);
    let least = match kind {
        0 => mu.iter().map(|m| (m - one).norm()).fold(f64::INFINITY, f64::min),
        1 => mu.iter().map(|m| (m + one).norm()).fold(f64::INFINITY, f64::min),
        _ => (0..mu.len())
            .flat_map(|a| (a + 1..mu.len()).map(move |c| (a, c)))
            .map(|(a, c)| (mu[a] * mu[c] - one).norm())
            .fold(f64::INFINITY, f64::min),
    };
    least.ln()
}

/// Where a test function is suspected to dip through zero and back between `b` and `c` (both
/// with the same sign): the extremum of the quadratic through the three points' values (in
/// arclength), when it lies between b and c and has the other sign. Each point is its arclength
/// and [`test_functions`]; the values are taken relative to b's magnitude. Each dipping test
/// function's index with its extremum's arclength.
fn dip(a: &(f64, Vec<(f64, f64)>), b: &(f64, Vec<(f64, f64)>), c: &(f64, Vec<(f64, f64)>)) -> Vec<(usize, f64)> {
    let ((s0, ta), (s1, tb), (s2, tc)) = (a, b, c);
    let (s0, s1, s2) = (*s0, *s1, *s2);
    if ta.len() != tb.len() || tb.len() != tc.len() || !(s0 < s1 && s1 < s2) {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (j, ((fa, fb), fc)) in ta.iter().zip(tb).zip(tc).enumerate() {
        if fb.0 != fc.0 || fb.0 == 0.0 || !(fa.1.is_finite() && fb.1.is_finite() && fc.1.is_finite()) {
            continue;
        }
        let v = |f: &(f64, f64)| f.0 * (f.1 - fb.1).clamp(-700.0, 700.0).exp();
        let (y0, y1, y2) = (v(fa), v(fb), v(fc));
        // Newton's divided differences: q(s) = y1 + d1 (s − s1) + d2 (s − s1)(s − s2).
        let d1 = (y2 - y1) / (s2 - s1);
        let d2 = ((y2 - y1) / (s2 - s1) - (y1 - y0) / (s1 - s0)) / (s2 - s0);
        if d2 == 0.0 || !d2.is_finite() {
            continue;
        }
        // q'(s) = d1 + d2 (2s − s1 − s2) = 0.
        let s_ext = 0.5 * (s1 + s2) - 0.5 * d1 / d2;
        if !(s1 < s_ext && s_ext < s2) {
            continue;
        }
        let q = y1 + d1 * (s_ext - s1) + d2 * (s_ext - s1) * (s_ext - s2);
        if q.signum() != fb.0 {
            out.push((j, s_ext));
        }
    }
    out
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

/// The Illinois variant of the secant method on a bracket `[s0, s1]` with values `f0`, `f1` of
/// opposite sign: the new point replaces the end whose value has its sign, and when the same end
/// is replaced twice running the other end's value is halved, so the bracket keeps shrinking from
/// both sides (used for folds, branch points and cusps alike).
pub(super) struct Illinois {
    pub(super) s0: f64,
    pub(super) f0: f64,
    pub(super) s1: f64,
    pub(super) f1: f64,
    /// Which end was replaced last (−1: s0, +1: s1, 0: none yet).
    side: i8,
}

impl Illinois {
    pub(super) fn new((s0, f0): (f64, f64), (s1, f1): (f64, f64)) -> Self {
        Self { s0, f0, s1, f1, side: 0 }
    }

    /// The secant's zero through both ends.
    pub(super) fn secant(&self) -> f64 {
        self.s1 - self.f1 * (self.s1 - self.s0) / (self.f1 - self.f0)
    }

    /// Takes the value f at s into the bracket.
    pub(super) fn update(&mut self, s: f64, f: f64) {
        if f.signum() == self.f0.signum() {
            (self.s0, self.f0) = (s, f);
            if self.side == -1 {
                self.f1 *= 0.5;
            }
            self.side = -1;
        } else {
            (self.s1, self.f1) = (s, f);
            if self.side == 1 {
                self.f0 *= 0.5;
            }
            self.side = 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::dip;
    use approx::abs_diff_eq;

    /// A test function as (sign, ln |value|).
    fn tf(v: f64) -> (f64, f64) {
        (v.signum(), v.abs().ln())
    }

    /// `(s − 1)² − 0.01` is positive at s = −1, 0 and 2 but negative around s = 1: the dip is
    /// found at the parabola's vertex, s = 1 (exact, the quadratic is the function); a monotone
    /// function and one whose vertex keeps the sign give none.
    #[test]
    fn a_dip_between_points_is_found_at_its_vertex() {
        let f = |s: f64| (s - 1.0) * (s - 1.0) - 0.01;
        let p = |s: f64, g: &dyn Fn(f64) -> f64| (s, vec![tf(g(s))]);
        let found = dip(&p(-1.0, &f), &p(0.0, &f), &p(2.0, &f));
        assert_eq!(found.len(), 1);
        assert!(found[0].0 == 0 && abs_diff_eq!(found[0].1, 1.0, epsilon = 1e-12), "{found:?}");
        let g = |s: f64| 1.0 + s;
        assert!(dip(&p(-0.5, &g), &p(0.0, &g), &p(2.0, &g)).is_empty());
        let h = |s: f64| (s - 1.0) * (s - 1.0) + 0.01;
        assert!(dip(&p(-1.0, &h), &p(0.0, &h), &p(2.0, &h)).is_empty());
    }
}
