//! The symmetries of the balance that a branch switch breaks ([`Symmetry`]): the swap of
//! identical absorbers and the shift by half the base period, as maps of the unknowns.

/// The symmetry of a problem that a branch switch breaks.
#[derive(Debug, Clone, PartialEq)]
pub enum Symmetry {
    /// The permutation of the coordinates that swaps identical absorbers (`mirror[k]` is the
    /// coordinate k is mapped to; the spin coordinate fixed): their unison branch's +1 branch
    /// points.
    Swap(Vec<usize>),
    /// The shift by half the base period, τ → τ + π (harmonic h of ω₀ times (−1)^h), of a
    /// problem whose base frequency is half that of the excitation (built with an extra multiple
    /// of half the excitation's base, amplitude zero): on it a period doubling (a multiplier
    /// through −1) of the period-1 branch is a symmetry-breaking branch point, and the branch
    /// switched there is the period-doubled one.
    HalfPeriod,
}

impl Symmetry {
    /// The image of the unknowns `x` (`n` coordinates of `nb` coefficients each, in the layout
    /// of [`HbmSolution::coefficients`](crate::hbm::HbmSolution::coefficients)).
    pub fn apply(&self, x: &[f64], n: usize, nb: usize) -> Vec<f64> {
        let mut out = vec![0.0; x.len()];
        match self {
            Symmetry::Swap(mirror) => {
                for (k, &j) in mirror.iter().enumerate().take(n) {
                    out[j * nb..(j + 1) * nb].copy_from_slice(&x[k * nb..(k + 1) * nb]);
                }
            }
            Symmetry::HalfPeriod => {
                for (i, (o, v)) in out.iter_mut().zip(x).enumerate() {
                    // Index i % nb: 0 the mean, 2h − 1 and 2h the cosine and sine of harmonic h.
                    let h = (i % nb).div_ceil(2);
                    *o = if h % 2 == 1 { -v } else { *v };
                }
            }
        }
        out
    }

    /// `(‖x − S x‖, ‖x‖)` over the coordinates that move (the spin coordinate left out of a
    /// swap, which fixes it; its mean slot, the scaled mean torque, out of both).
    pub(in crate::hbm) fn defect(&self, x: &[f64], n: usize, nb: usize, spin: usize) -> (f64, f64) {
        let image = self.apply(x, n, nb);
        let (mut defect, mut size) = (0.0, 0.0);
        for (i, (a, b)) in x.iter().zip(&image).enumerate() {
            let in_spin = i / nb == spin;
            if in_spin && (matches!(self, Symmetry::Swap(_)) || i % nb == 0) {
                continue;
            }
            defect += (a - b) * (a - b);
            size += a * a;
        }
        (defect.sqrt(), size.sqrt())
    }
}
