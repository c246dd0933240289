//! The continuation of a fold curve: pseudo-arclength steps on the augmented system with the
//! borders renewed after every point, steps retried where the tangent or the tested block's
//! null vector turned too far, and the turning points of the second parameter (cusps and
//! torque extrema) located by Illinois regula falsi on the tangent.

use super::augmented::{Corrected, NewtonLu, Walk, settled, unit_tangent};
use super::plane::{FoldCurve, FoldCurveEnd, FoldCurveOptions, FoldCurvePoint, FoldPlane, ParameterPoint};
use crate::hbm::balance::{At, Hbm, HbmError};
use crate::hbm::balance::{MechanismFamily, problem};
use crate::hbm::numerics::Illinois;
use nalgebra::DVector;

/// Smallest |cos| between the tested block's null vectors at successive points of a curve.
const NULL_TURN: f64 = 0.9;

impl Hbm {
    /// Follows the fold curve in `plane` through `start` (from [`Hbm::fold_at`]) in the
    /// direction of increasing s when `up`, else decreasing, until it leaves the box of `opts`.
    pub fn continue_fold(
        &mut self,
        plane: FoldPlane,
        start: &FoldCurvePoint,
        up: bool,
        opts: &FoldCurveOptions,
    ) -> Result<FoldCurve, HbmError> {
        self.continue_fold_with(plane, None, start, up, opts)
    }

    /// [`Hbm::continue_fold`] with the second parameter the torque scale (`family` None) or the
    /// mechanism parameter p of `family` (`start` from [`Hbm::singular_at_with`]; `up` then
    /// means increasing p, and `opts.scales` is p's range).
    pub fn continue_fold_with(
        &mut self,
        plane: FoldPlane,
        family: Option<&MechanismFamily<'_>>,
        start: &FoldCurvePoint,
        up: bool,
        opts: &FoldCurveOptions,
    ) -> Result<FoldCurve, HbmError> {
        let m = self.unknowns();
        let x0 = self.unknowns_from(Some(&start.solution));
        let at0 = At { order: start.order, omega: start.omega, scale: start.scale };
        let p0 = family.map(|_| start.parameter);
        let mut walk = self.walk(plane, opts.test, family, &x0, &at0, p0)?;
        walk.plane.p_ref = start.omega;
        let mut y = DVector::zeros(m + 2);
        y.rows_mut(0, m).copy_from(&DVector::from_vec(x0));
        (y[m], y[m + 1]) = (walk.plane.lambda(&at0), walk.sigma(start.parameter));
        // The tangent at the start, oriented by the requested direction of the second parameter.
        let mut e_s = DVector::zeros(m + 2);
        e_s[m + 1] = if up { 1.0 } else { -1.0 };
        let (mut t, aug) = self.with_central(&mut walk, |h, w| h.fold_tangent(&y, w, &e_s))?;
        (walk.b, walk.c) = (aug.w.normalize(), aug.v.normalize());
        if t[m + 1] * e_s[m + 1] < 0.0 {
            t = -t;
        }
        let mut points = vec![start.clone()];
        let (mut cusps, mut scale_extrema) = (Vec::new(), Vec::new());
        let mut ds = opts.ds;
        let mut s_arc = 0.0;
        let inside = |walk: &Walk, y: &DVector<f64>| {
            let (at, _) = walk.at(y[m], y[m + 1]);
            let first = match plane {
                FoldPlane::Order => at.order,
                FoldPlane::Speed { .. } => at.omega,
                FoldPlane::Torque { .. } => at.scale,
            };
            (opts.range.0..=opts.range.1).contains(&first)
                && (opts.scales.0..=opts.scales.1).contains(&walk.second(y[m + 1]))
        };
        let end = loop {
            if points.len() >= opts.max_points {
                break FoldCurveEnd::MaxPoints;
            }
            if ds < opts.ds_min {
                break FoldCurveEnd::StepTooSmall;
            }
            let pred = &y + &t * ds;
            let Corrected { y: y_new, iterations: iters, skipped, lu, aug } =
                match self.fold_correct(&pred, &t, &mut walk, opts) {
                    Ok(r) => r,
                    Err(_) => {
                        ds *= 0.5;
                        continue;
                    }
                };
            // The tangent from the last Newton matrix, factorised at the iterate before the
            // converged one (within the tolerance of it): the predictor only needs it to that
            // accuracy, and a new matrix would cost three Jacobians. Turning points of the
            // second parameter are located with exact tangents (`locate_extremum`).
            let Some(mut t_new) = unit_tangent(&lu, &aug.bordered, m) else {
                ds *= 0.5;
                continue;
            };
            if t_new.dot(&t) < 0.0 {
                t_new = -t_new;
            }
            // A step whose tested block's null vector turned far has left the curve for a
            // neighbouring one (near a turning point in the second parameter the corrector can
            // land on another curve of the same test whose states are close): retry shorter.
            if t_new.dot(&t) < 0.95 || aug.v.normalize().dot(&walk.c).abs() < NULL_TURN {
                ds *= 0.5;
                continue;
            }
            (walk.b, walk.c) = (aug.w.normalize(), aug.v.normalize());
            let chord = (&y_new - &y).norm();
            if t[m + 1] * t_new[m + 1] < 0.0
                && let Some((p, tl)) = self.with_central(&mut walk, |h, w| h.locate_extremum(&y, &t, chord, w, opts))
            {
                // At the located point |dσ/dσ_arc| ≤ 1e-10; at a cusp dλ/dσ follows it to zero
                // (the paper's rotor: 2e-11), elsewhere it stays of order one.
                if tl.abs() <= 1e-6 { cusps.push(p) } else { scale_extrema.push(p) }
            }
            s_arc += chord;
            let x_new: Vec<f64> = y_new.rows(0, m).iter().copied().collect();
            let (at, p) = walk.at(y_new[m], y_new[m + 1]);
            let solution = problem(self, &mut walk.built, family, p)?.solution_from(&x_new, &at, iters);
            points.push(walk.point(&at, y_new[m + 1], s_arc, solution));
            (y, t) = (y_new, t_new);
            if !inside(&walk, &y) {
                break FoldCurveEnd::LeftBox;
            }
            // The step rule counts a settled iterate as taken, so the curve's resolution does
            // not depend on whether the last step was verified.
            let effort = iters + usize::from(skipped);
            if effort <= 3 {
                ds = (ds * 1.5).min(opts.ds_max);
            } else if effort >= 6 {
                ds *= 0.7;
            }
        };
        Ok(FoldCurve { points, cusps, scale_extrema, end })
    }

    /// Newton's method on `R̂ = 0, g = 0, tᵀ(y − pred) = 0` from `pred`.
    fn fold_correct(
        &mut self,
        pred: &DVector<f64>,
        t: &DVector<f64>,
        walk: &mut Walk,
        opts: &FoldCurveOptions,
    ) -> Result<Corrected, HbmError> {
        let m = self.unknowns();
        let mut y = pred.clone();
        let mut previous = f64::INFINITY;
        let eliminate = walk.block.len() == m && walk.pinned.is_empty();
        for it in 1..=opts.max_iter {
            let aug = self.augmented_at(&y, walk)?;
            let lu = if eliminate {
                NewtonLu::eliminate(&aug, t).ok_or(HbmError::Singular { order: y[m] })?
            } else {
                Self::whole_newton(&aug, t)
            };
            let mut rhs = DVector::zeros(m + 2);
            rhs.rows_mut(0, m).copy_from(&aug.r);
            rhs[m] = aug.g;
            rhs[m + 1] = t.dot(&(&y - pred));
            let d = lu.solve(&rhs, &aug.bordered).ok_or(HbmError::Singular { order: y[m] })?;
            let step = d.amax();
            if !step.is_finite() || (y[m] - d[m]).is_nan() || y[m] - d[m] <= 0.0 {
                return Err(HbmError::NonFinite { order: y[m] });
            }
            y -= d;
            let skipped = step > opts.tol;
            if !skipped || settled(step, previous, opts.tol) {
                return Ok(Corrected { y, iterations: it, skipped, lu, aug });
            }
            previous = step;
        }
        Err(HbmError::NoConvergence { order: y[m], iterations: opts.max_iter, step: f64::NAN })
    }

    /// The extremum of the second parameter between y (tangent t) and the point a chord further
    /// on, where its rate along the curve changes sign: a secant (Illinois) search on the
    /// tangent's σ-component along the step. Returns the point and dλ/dσ there.
    fn locate_extremum(
        &mut self,
        y: &DVector<f64>,
        t: &DVector<f64>,
        chord: f64,
        walk: &mut Walk,
        opts: &FoldCurveOptions,
    ) -> Option<(ParameterPoint, f64)> {
        let m = self.unknowns();
        let slope = |this: &mut Self, walk: &mut Walk, sigma: f64| -> Option<(DVector<f64>, DVector<f64>)> {
            let pred = y + t * sigma;
            let yc = this.fold_correct(&pred, t, walk, opts).ok()?.y;
            let (mut tc, _) = this.fold_tangent(&yc, walk, t).ok()?;
            if tc.dot(t) < 0.0 {
                tc = -tc;
            }
            Some((tc, yc))
        };
        let f1 = slope(self, walk, chord)?.0[m + 1];
        let mut ill = Illinois::new((0.0, t[m + 1]), (chord, f1));
        let mut best = None;
        for _ in 0..60 {
            if ill.f1 == ill.f0 {
                break;
            }
            let s = ill.secant();
            let (tc, yc) = slope(self, walk, s)?;
            let f = tc[m + 1];
            let (at, _) = walk.at(yc[m], yc[m + 1]);
            let point =
                ParameterPoint { order: at.order, omega: at.omega, scale: at.scale, parameter: walk.second(yc[m + 1]) };
            best = Some((point, tc[m]));
            if f.abs() < 1e-10 || (ill.s1 - ill.s0).abs() < 1e-12 * chord.max(1e-300) {
                break;
            }
            ill.update(s, f);
        }
        best
    }
}
