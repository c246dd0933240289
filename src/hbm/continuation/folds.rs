//! The folds of a branch: each refined by Illinois regula falsi on dλ/ds along the arclength,
//! and the search beside a refined fold for a second crossing of +1 in its step, which the
//! test functions' signs cannot show.

use super::branch::BranchPoint;
use super::events::PairSenses;
use super::point::Cursor;
use crate::hbm::balance::{Chord, Hbm, Setup};
use crate::hbm::numerics::Illinois;
use nalgebra::DVector;

/// A point inserted beside a refined fold for a second crossing of +1 in its step, with its
/// pairs' senses and whether it lies before the fold.
pub(super) type Partner = (BranchPoint, PairSenses, bool);

impl Hbm {
    /// Bracketing secant search for `dλ/ds = 0` between a (s = 0) and b (s = `chord`) along a's
    /// tangent. Regula falsi with the Illinois modification (an end kept twice has its value
    /// halved), which keeps the bracket but converges superlinearly where plain regula falsi
    /// moves one end only (fewer searches per fold; counts in `BENCHMARKS.md`). After the
    /// first search, the corrector is the Broyden chord on the bordered matrix factorised for the
    /// previous search's tangent, which has the same last row aᵀ.
    pub(super) fn refine_fold(
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
    pub(super) fn fold_partner(
        &mut self,
        su: &Setup,
        (a, pa): (&Cursor, &BranchPoint),
        (yb, pb): (&DVector<f64>, &BranchPoint),
        yf: &DVector<f64>,
        s: f64,
    ) -> Option<Partner> {
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
}
