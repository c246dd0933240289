//! The Illinois variant of regula falsi: the root finder that refines folds, branch points,
//! cusps and a switched branch's return to the symmetric states.

/// The Illinois variant of the secant method on a bracket `[s0, s1]` with values `f0`, `f1` of
/// opposite sign: the new point replaces the end whose value has its sign, and when the same end
/// is replaced twice running the other end's value is halved, so the bracket keeps shrinking from
/// both sides (used for folds, branch points and cusps alike).
pub(in crate::hbm) struct Illinois {
    pub(in crate::hbm) s0: f64,
    pub(in crate::hbm) f0: f64,
    pub(in crate::hbm) s1: f64,
    pub(in crate::hbm) f1: f64,
    /// Which end was replaced last (−1: s0, +1: s1, 0: none yet).
    side: i8,
}

impl Illinois {
    pub(in crate::hbm) fn new((s0, f0): (f64, f64), (s1, f1): (f64, f64)) -> Self {
        Self { s0, f0, s1, f1, side: 0 }
    }

    /// The secant's zero through both ends.
    pub(in crate::hbm) fn secant(&self) -> f64 {
        self.s1 - self.f1 * (self.s1 - self.s0) / (self.f1 - self.f0)
    }

    /// Takes the value f at s into the bracket.
    pub(in crate::hbm) fn update(&mut self, s: f64, f: f64) {
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
