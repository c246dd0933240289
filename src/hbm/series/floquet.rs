//! The Floquet record of a solution: its multipliers and verdict ([`Stability`]) by the blocks
//! they were computed in ([`FloquetBlock`]), and the sense of turning of the complex pairs near
//! ±1 ([`PairSense`]) by which the continuation tells a tongue stepped over whole. The
//! stability room computes them; they live here, beside the solution that carries them.

use nalgebra::{Complex, DVector};

/// Floquet multipliers of a periodic solution and the verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct Stability {
    /// The 2n_dof − 1 physical Floquet multipliers (the trivial +1 of the cyclic spin angle is
    /// removed), by decreasing modulus; a block's multipliers appear `multiplicity` times.
    pub multipliers: Vec<Complex<f64>>,
    /// The groups the multipliers were computed in: one block holding all of them on the general
    /// route; on a cyclic route the unison block and the non-unison (wavenumber) blocks, each
    /// standing for `multiplicity` identical copies. Bifurcation test functions are evaluated per
    /// block, so a multiplier repeated by symmetry crosses once, not `multiplicity` times.
    pub blocks: Vec<FloquetBlock>,
    /// Largest modulus of the multipliers.
    pub max_modulus: f64,
    /// True when every multiplier lies inside the unit circle (asymptotically stable).
    pub stable: bool,
}

/// Floquet multipliers computed together from one block of the variational equations.
#[derive(Debug, Clone, PartialEq)]
pub struct FloquetBlock {
    /// What the block describes (`all`, `unison`, `wavenumbers 1..N-1`, …).
    pub label: String,
    /// How many identical copies of this block the full problem holds (1 on the general route).
    pub multiplicity: usize,
    /// The block's multipliers, by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
}

impl Stability {
    /// A verdict from blocks: the multipliers of every block, repeated by its multiplicity.
    pub fn from_blocks(blocks: Vec<FloquetBlock>) -> Self {
        let mut multipliers: Vec<Complex<f64>> =
            blocks.iter().flat_map(|b| (0..b.multiplicity).flat_map(|_| b.multipliers.iter().copied())).collect();
        multipliers.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let max_modulus = multipliers.first().map_or(0.0, |m| m.norm());
        Self { multipliers, max_modulus, stable: max_modulus < 1.0, blocks }
    }

    /// The multiplier of largest modulus (the critical one when unstable).
    pub fn critical(&self) -> Option<Complex<f64>> {
        self.multipliers.first().copied()
    }

    /// Number of multipliers outside the unit circle (0: stable).
    pub fn outside(&self) -> usize {
        self.multipliers.iter().filter(|m| m.norm() > 1.0).count()
    }
}

/// A complex pair of Floquet multipliers near +1 or −1 and the sense in which its eigenvector
/// turns. Along a branch the member with Im μ > 0 of a lightly damped pair belongs to a motion
/// that turns one way in the phase plane of each coordinate (δq̇ ≈ iω δq for a mode of frequency
/// ω whose multiplier is e^{iωT}); when the pair passes through ±1 (meets on the real axis,
/// splits, meets again and leaves: a tongue of period doubling or of loss of unison) the
/// rotation number ωT/2π passes through ½ or an integer and the member with Im μ > 0 becomes the
/// conjugate of the old one, so the sense flips. A pair that comes near ±1 and leaves without
/// meeting on the real axis keeps it. This sign is the continuation's test for a tongue
/// stepped over whole (the continuation room's docs).
#[derive(Debug, Clone)]
pub(in crate::hbm) struct PairSense {
    /// +1 or −1: the real multiplier the pair is near.
    pub(in crate::hbm) side: f64,
    /// `Σ_k Im(conj(v_qk) v_uk) / (|v_q| |v_u|)` over the coordinates k with both an angle and a
    /// rate in the state: the sign says the sense of turning (phase-invariant, in [−1, 1]).
    pub(in crate::hbm) sense: f64,
    /// The unit eigenvector of the member with Im μ > 0, to recognise the same pair at the next
    /// point.
    pub(in crate::hbm) v: DVector<Complex<f64>>,
}
