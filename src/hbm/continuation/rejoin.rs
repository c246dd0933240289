//! The end of a switched branch where it returns to the symmetric states: φᵀx changes sign
//! along a step at a state that the symmetry leaves unchanged.

use super::point::Cursor;
use crate::hbm::balance::{Hbm, Setup, Symmetry};
use crate::hbm::numerics::Illinois;
use nalgebra::DVector;

/// A state symmetric to this fraction of its size counts as back on the symmetric branch.
const UNISON_DEFECT: f64 = 1e-3;

impl Hbm {
    /// The return of a switched branch to the symmetric states inside the step from `cur` to
    /// the accepted point `y`, if φᵀx (`c` = φ) changes sign there and the state where it
    /// vanishes is symmetric (the switch room's docs): that state. Illinois regula falsi on φᵀx along the
    /// step (correctors on the hyperplanes normal to cur's tangent), 30 evaluations at most,
    /// until |φᵀx| is 1e-6 of its value at the ends.
    pub(super) fn rejoin(
        &mut self,
        su: &Setup,
        cur: &Cursor,
        y: &DVector<f64>,
        c: &[f64],
        symmetry: &Symmetry,
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
        // Symmetric to UNISON_DEFECT of its size?
        let x = su.x_of(best.as_slice(), m);
        let (defect, size) = symmetry.defect(&x, self.n, nb, self.spin);
        (defect <= UNISON_DEFECT * size).then_some(best)
    }
}
