//! The walk along a branch: the entry points ([`Hbm::continue_in`] and its order form), the
//! first point and tangent, and the predictor–corrector loop with its step control, split into
//! its steps (advance, end of range, dip aiming, fold, return to the symmetric states) and the
//! event searches run on the finished branch.

use super::branch::{Branch, BranchEnd, BranchPoint, Fold, FoldKind, bifurcations};
use super::events::{Senses, Tests, dip, test_functions};
use super::folds::Partner;
use super::options::ContinuationOptions;
use super::point::Cursor;
use crate::hbm::balance::{Chord, Hbm, HbmError, HbmOptions, Parameter, Setup, Symmetry};
use crate::hbm::series::HbmSolution;
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use nalgebra::DVector;

impl Hbm {
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
    /// rad/s; torque scale s), see the continuation room's docs, starting
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
    pub(in crate::hbm) fn follow(
        &mut self,
        su: &Setup,
        cur: Cursor,
        iterations: usize,
        (l_from, l_to): (f64, f64),
        mut newton: usize,
        copts: &ContinuationOptions,
        watch: Option<(&[f64], &Symmetry)>,
    ) -> Result<Branch, HbmError> {
        let su = *su;
        let parameter = su.param;
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
        let (mut ds, mut s) = (copts.ds, 0.0);
        // The previous point's tangent and the chord to it.
        let mut prev: Option<(DVector<f64>, f64)> = None;
        // A step already aimed at a suspected pair of crossings, and a step already tried past a
        // point where the corrector failed at every smaller step, since the last accepted point.
        let mut aim =
            Aim { aimed: None, misses: Vec::new(), quiet: Vec::new(), floor: 1e-3 * copts.ds.min(copts.ds_max) };
        let (mut jumped, mut last_chord) = (false, copts.ds);
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
            let Some(Advance { y, iters, refreshes, t, next_chord, chord }) =
                self.advance(&su, &cur, prev.as_ref(), &chord_m, ds, copts, &mut newton)
            else {
                ds *= 0.5;
                continue;
            };
            let l_new = y[m];
            // Leaving the range: finish exactly at its end by a solve at fixed parameter.
            let past_target = dir * (l_new - l_to) >= 0.0;
            let past_start = dir * (l_new - l_from) < 0.0;
            if past_target || past_start {
                let l_end = if past_target { l_to } else { l_from };
                let step = Step { cur: &cur, y: &y, t: &t, iters };
                points.push(self.end_at(&su, step, l_end, &mut s, &mut newton, copts.stability)?);
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
            if let Some(aimed_ds) = aim.retarget(&predicted, cand_tests.1.len(), s, ds, chord) {
                ds = aimed_ds;
                continue;
            }
            aim.settle(&predicted, tests.last(), &cand_tests.1);
            jumped = false;
            if let Some((c, symmetry)) = watch
                && let Some(y_r) = self.rejoin(&su, &cur, &y, c, symmetry, &mut newton)
            {
                let step = Step { cur: &cur, y: &y_r, t: &t, iters };
                points.push(self.end_at_unison(&su, step, &mut s, copts.stability)?);
                break BranchEnd::Unison;
            }
            if t[m].signum() != cur.t[m].signum() && t[m] != 0.0 && cur.t[m] != 0.0 {
                let step = Step { cur: &cur, y: &y, t: &t, iters };
                let (fold, partner) = self.fold_in_step(&su, step, (&cand, &points), (s, chord), &mut newton, copts)?;
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
            ds = next_step(ds, iters, refreshes, copts.ds_max);
        };
        let branch = Branch { parameter, points, folds, bifurcations: Vec::new(), end, newton_iterations: newton };
        Ok(self.finish_branch(&su, branch, tests, senses, copts))
    }

    /// One step from `cur`: the quadratic predictor at step `ds` (the tangent's change over the
    /// last step estimates the branch's curvature, which makes the predictor error third order
    /// in ds instead of second), the Broyden-chord corrector from it (its iterations counted in
    /// `newton`), the new point's tangent and chord matrix. None when the step must be halved: a
    /// failed corrector or tangent, a tangent that turned too far, or a chord off the tangent.
    #[allow(clippy::too_many_arguments)]
    fn advance(
        &mut self,
        su: &Setup,
        cur: &Cursor,
        prev: Option<&(DVector<f64>, f64)>,
        chord_m: &Chord,
        ds: f64,
        copts: &ContinuationOptions,
        newton: &mut usize,
    ) -> Option<Advance> {
        let m = self.unknowns();
        let mut pred = &cur.y + &cur.t * ds;
        if let Some((t_prev, h)) = prev {
            pred.axpy(0.5 * ds * ds / h, &(&cur.t - t_prev), 1.0);
        }
        let (y, iters, refreshes) = self.correct_chord(su, chord_m, &pred, &cur.t, copts.corrector_iter, 3).ok()?;
        *newton += iters;
        // The Jacobian at the new point gives its tangent and the next chord matrix.
        let at = su.at(y[m]);
        self.assemble(&su.x_of(y.as_slice(), m), &at, Some(su.param));
        let (t, next_chord) = self.tangent_chord(su, &cur.t, at.order).ok()?;
        if t.dot(&cur.t) < copts.min_cos && ds > copts.ds_min {
            return None;
        }
        let chord = (&y - &cur.y).norm();
        // The chord must follow the tangent as the tangents follow each other: a corrector
        // that lands on another sheet of an S-shaped branch (both sheets with the same
        // direction there, so the tangents agree) leaves along a chord at a large angle.
        if chord > 0.0 && (&y - &cur.y).dot(&cur.t) < copts.min_cos * chord && ds > copts.ds_min {
            return None;
        }
        Some(Advance { y, iters, refreshes, t, next_chord, chord })
    }

    /// The last point of a branch that left its range in `step`: solved at the range's end
    /// `l_end` at the fixed parameter from the state interpolated there (the corrected state
    /// itself where that solve fails), with its tangent; `s` and `newton` carried on.
    fn end_at(
        &mut self,
        su: &Setup,
        step: Step,
        l_end: f64,
        s: &mut f64,
        newton: &mut usize,
        stability: bool,
    ) -> Result<BranchPoint, HbmError> {
        let Step { cur, y, t, iters } = step;
        let m = self.unknowns();
        let (l_new, l_old) = (y[m], cur.y[m]);
        let frac = (l_end - l_old) / (l_new - l_old);
        let y_guess = &cur.y + (y - &cur.y) * frac;
        let x_guess = su.x_of(y_guess.as_slice(), m);
        let guess_sol = self.solution_from(&x_guess, &su.at(l_end), 0);
        let y_end = match self.solve_at(&su.at(l_end), Some(&guess_sol)) {
            Ok(sol) => {
                *newton += sol.iterations;
                self.y_of(su, &sol)
            }
            Err(_) => y.clone(),
        };
        *s += (&y_end - &cur.y).norm();
        // The tangent at the end point itself (for the dense output); the Jacobian is
        // the one the stability analysis needs there anyway.
        self.assemble(&su.x_of(y_end.as_slice(), m), &su.at(y_end[m]), Some(su.param));
        let t_end = self.tangent(su, t, su.at(y_end[m]).order).unwrap_or_else(|_| t.clone());
        self.branch_point(su, &y_end, Some(&t_end), *s, iters, stability)
    }

    /// The last point of a switched branch that returned to the symmetric states at `step.y`
    /// (found by [`Hbm::rejoin`]), with its tangent.
    fn end_at_unison(&mut self, su: &Setup, step: Step, s: &mut f64, stability: bool) -> Result<BranchPoint, HbmError> {
        let Step { cur, y: y_r, t, iters } = step;
        let m = self.unknowns();
        *s += (y_r - &cur.y).norm();
        self.assemble(&su.x_of(y_r.as_slice(), m), &su.at(y_r[m]), Some(su.param));
        let t_r = self.tangent(su, t, su.at(y_r[m]).order).unwrap_or_else(|_| t.clone());
        self.branch_point(su, y_r, Some(&t_r), *s, iters, stability)
    }

    /// The fold in `step`, where dλ/ds changed sign: refined by [`Hbm::refine_fold`] (its
    /// critical mode kept, and a second crossing of +1 beside it searched for: the partner
    /// point, its pairs' senses and whether it lies before the fold), or interpolated where dλ/ds
    /// vanishes linearly over the chord. `cand` is the step's new point, `points` the accepted
    /// ones, `s` the arclength so far.
    fn fold_in_step(
        &mut self,
        su: &Setup,
        step: Step,
        (cand, points): (&BranchPoint, &[BranchPoint]),
        (s, chord): (f64, f64),
        newton: &mut usize,
        copts: &ContinuationOptions,
    ) -> Result<(Fold, Option<Partner>), HbmError> {
        let Step { cur, y, t, .. } = step;
        let m = self.unknowns();
        let l_old = cur.y[m];
        let kind = if cur.t[m] > 0.0 { FoldKind::Maximum } else { FoldKind::Minimum };
        let refined = if copts.refine_folds { self.refine_fold(su, cur, chord, t[m], newton) } else { None };
        let mut partner = None;
        let fold = match refined {
            Some((yf, tf)) => {
                if copts.stability
                    && let Some(last) = points.last()
                {
                    partner = self.fold_partner(su, (cur, last), (y, cand), &yf, s);
                }
                let p = self.branch_point(su, &yf, None, 0.0, 0, false)?;
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
                    parameter: lf * su.p_ref,
                    kind,
                    after: points.len() - 1,
                    accel_main: last.map_or(0.0, |p| p.accel_main),
                    pendulum_amplitude: last.map_or(0.0, |p| p.pendulum_amplitude),
                    critical: Vec::new(),
                }
            }
        };
        Ok((fold, partner))
    }

    /// The event searches on a finished branch: pairs of crossings stepped over whole (tongues
    /// by the pairs' senses, deep minima of a test function), the Floquet bifurcations between
    /// the points, and the location of each crossing that is not a fold. Past the deadline the
    /// crossings stay where the accepted points bracket them.
    fn finish_branch(
        &mut self,
        su: &Setup,
        mut branch: Branch,
        mut tests: Tests,
        mut senses: Senses,
        copts: &ContinuationOptions,
    ) -> Branch {
        let refine = copts.refine_folds && branch.end != BranchEnd::Watchdog;
        if refine && copts.stability {
            self.split_tongues(su, &mut branch, &mut tests, &mut senses);
            self.split_narrow_pairs(su, &mut branch, &mut tests, &mut senses);
        }
        branch.bifurcations = bifurcations(&branch.points, &branch.folds);
        if refine {
            self.refine_crossings(su, &mut branch);
        }
        branch
    }
}

/// The step after a corrector of `iters` iterations and `refreshes` Jacobian refreshes: 1.5
/// times `ds` (at most `ds_max`) after at most 7 iterations and one refresh, 0.7 times after 10
/// iterations or 3 refreshes, else `ds`.
fn next_step(ds: f64, iters: usize, refreshes: usize, ds_max: f64) -> f64 {
    if iters <= 7 && refreshes <= 1 {
        (ds * 1.5).min(ds_max)
    } else if iters >= 10 || refreshes >= 3 {
        ds * 0.7
    } else {
        ds
    }
}

/// A corrected step: the new state, its corrector's iterations and Jacobian refreshes, its
/// tangent, the chord matrix bordered by it, and the chord's length.
struct Advance {
    y: DVector<f64>,
    iters: usize,
    refreshes: usize,
    t: DVector<f64>,
    next_chord: Chord,
    chord: f64,
}

/// The step being accepted: from `cur` to the state `y` with tangent `t`, `iters` corrector
/// iterations.
#[derive(Clone, Copy)]
struct Step<'a> {
    cur: &'a Cursor,
    y: &'a DVector<f64>,
    t: &'a DVector<f64>,
    iters: usize,
}

/// The step control's aim at suspected pairs of crossings: the test function a shortened step
/// is aimed at, and per test function its count of aimed steps that showed no sign change
/// (`misses`) and of points in a row without a dip (`quiet`); steps are not shortened below
/// `floor`.
struct Aim {
    aimed: Option<usize>,
    misses: Vec<u32>,
    quiet: Vec<u32>,
    floor: f64,
}

impl Aim {
    /// The shortened step that lands on the extremum of a `predicted` dip (once per step), if
    /// any: not below the floor, and by at most 5× at a time: a zero of odd multiplicity above
    /// one (a multiplier repeated by symmetry) looks like a dip from either side and would
    /// otherwise draw the steps towards it without end. `count` test functions, the step from
    /// arclength `s` of length `ds` with chord `chord`.
    fn retarget(&mut self, predicted: &[(usize, f64)], count: usize, s: f64, ds: f64, chord: f64) -> Option<f64> {
        self.misses.resize(count, 0);
        let misses = &self.misses;
        let target = predicted.iter().filter(|(j, _)| misses[*j] < 3).min_by(|a, b| a.1.total_cmp(&b.1)).copied();
        if self.aimed.is_none()
            && let Some((j, s_dip)) = target
        {
            let aimed_ds = ((s_dip - s) * ds / chord).max(0.2 * ds).max(self.floor);
            if aimed_ds < ds {
                self.aimed = Some(j);
                return Some(aimed_ds);
            }
        }
        None
    }

    /// The counts after a step is taken, whose new point's test functions are `cand` and the
    /// last accepted point's `last`.
    ///
    /// An aimed step that showed no sign change of its test function was a false alarm (a zero
    /// of higher multiplicity, a near miss, or a product of many multipliers that decays like an
    /// exponential, which a quadratic takes for a dip); after three that function is not aimed
    /// at until it changes sign or stops dipping for four points in a row, so such a zero
    /// cannot hold the steps small. (Counting only aimed steps that still dipped let 16 mistuned
    /// pendulums aim at every other step: the aimed point lands past the false extremum, the
    /// next step dips again.) Each test function keeps its own count.
    fn settle(&mut self, predicted: &[(usize, f64)], last: Option<&(f64, Vec<(f64, f64)>)>, cand: &[(f64, f64)]) {
        self.quiet.resize(cand.len(), 0);
        if let Some((_, last)) = last
            && last.len() == cand.len()
        {
            for (j, (m, q)) in self.misses.iter_mut().zip(self.quiet.iter_mut()).enumerate() {
                // An aimed step dipped at its full length; the shortened one usually does
                // not (it lands on the extremum), which is no sign of a quiet function.
                let dips = self.aimed == Some(j) || predicted.iter().any(|(k, _)| *k == j);
                *q = if dips { 0 } else { *q + 1 };
                if last[j].0 != cand[j].0 || *q >= 4 {
                    *m = 0;
                } else if self.aimed == Some(j) {
                    *m += 1;
                }
            }
        }
        self.aimed = None;
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
