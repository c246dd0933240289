//! The harmonic-balance problem [`Hbm`]: the mechanism's evaluator, the spin coordinate, the
//! excitation tabulated at the samples, the parameters of the fixed-parameter solves and the
//! work buffers that the assembly, the factorisations and the Floquet analysis share (so that
//! a branch's points reuse one set of buffers, and the stability of a point reuses the
//! per-sample derivatives its Jacobian just formed).

use super::options::{HbmError, HbmOptions, PointHook};
use super::parameter::At;
use super::sample::{Evaluator, SampleLin};
use crate::hbm::series::{Aft, HbmSolution, PairSense, Upsampler};
use crate::model::coupling::Couplings;
use nalgebra::{DMatrix, DVector};
use realfft::num_complex::Complex;

/// A harmonic-balance problem: one mechanism, its spin joint, the mean speed Ω and the order
/// excitation terms; the excitation order n is the free parameter of every solve.
///
/// Build once, then [`Hbm::solve`] at fixed orders or [`continue_in_order`](crate::hbm::continue_in_order) along a branch.
/// `Clone` it to work on several threads.
#[derive(Debug, Clone)]
pub struct Hbm {
    pub(in crate::hbm) ev: Evaluator,
    pub(in crate::hbm) n: usize,
    pub(in crate::hbm) spin: usize,
    /// The spin angle is cyclic (no gravity, no world-frame force): its column of ∂R/∂q is zero
    /// and its shift gives the trivial Floquet multiplier +1.
    pub(in crate::hbm) cyclic: bool,
    /// Each coordinate's share of the mean rotation Ωt (see [`HbmSolution::rotation`](crate::hbm::HbmSolution::rotation)).
    pub(in crate::hbm) rotation: Vec<f64>,
    /// The spin angle alone moves no force (cyclic, and no joint meshed to it), so its column
    /// of ∂R/∂q is zero and is not differenced; with meshes only the shift along `rotation` is
    /// free of force.
    pub(in crate::hbm) spin_column_zero: bool,
    pub(in crate::hbm) omega: f64,
    /// Torque scale s of the fixed-parameter solves.
    pub(in crate::hbm) scale: f64,
    /// ω₀ = ratio · n · Ω.
    pub(in crate::hbm) ratio: f64,
    pub(in crate::hbm) t_scale: f64,
    pub(in crate::hbm) opts: HbmOptions,
    pub(in crate::hbm) nb: usize,
    pub(in crate::hbm) aft: Aft,
    /// The generalized force of the oscillating excitation torques at the N_t samples, per
    /// equation (`exc[r·N_t + j]`), N·m.
    pub(in crate::hbm) exc: Vec<f64>,
    /// The same for the forcing per Ω² (N·m·s²/rad²; empty without one): the generalized force
    /// is `exc + Ω² exc2` ([`Hbm::with_speed_forcing`]).
    pub(in crate::hbm) exc2: Vec<f64>,
    // Work buffers: p, ṗ, p̈ per coordinate, R and ∂R/∂n per equation, each N_t samples.
    pub(in crate::hbm) qt: Vec<f64>,
    pub(in crate::hbm) qdt: Vec<f64>,
    pub(in crate::hbm) qddt: Vec<f64>,
    pub(in crate::hbm) rt: Vec<f64>,
    pub(in crate::hbm) dpt: Vec<f64>,
    /// One coefficient series (N_t) and the half spectra of the 3n² series of `samples`.
    pub(in crate::hbm) series: Vec<f64>,
    pub(in crate::hbm) spectra: Vec<Complex<f64>>,
    /// `(C_m, S_m)`, m = −2H..=2H, of each of those series.
    pub(in crate::hbm) unfolded: Vec<(f64, f64)>,
    /// Which of those series were zero at every sample in the last assembly.
    pub(in crate::hbm) zero_series: Vec<bool>,
    /// Which n × n blocks of `jac` are zero (left unwritten by the last Jacobian assembly; a
    /// block of the spin column holds a mean-torque entry and is never marked): the next
    /// assembly clears only the blocks it does not write and that are not marked, and the block
    /// LU does not read the marked ones.
    pub(in crate::hbm) zero_blocks: Vec<bool>,
    pub(in crate::hbm) q: Vec<f64>,
    pub(in crate::hbm) qd: Vec<f64>,
    pub(in crate::hbm) qdd: Vec<f64>,
    pub(in crate::hbm) lin: SampleLin,
    /// Per-sample `[A | B | C]` (3n² each, row-major blocks) of the last Jacobian assembly, and
    /// the point (unknowns, order) it belongs to: the stability analysis reuses them.
    pub(in crate::hbm) samples: Vec<f64>,
    pub(in crate::hbm) samples_at: Option<(Vec<f64>, At)>,
    /// The point (unknowns, parameters) of the residual in `rhat`.
    pub(in crate::hbm) rhat_at: Option<(Vec<f64>, At)>,
    /// Trigonometric interpolation from the N_t residual samples to the N_s stability samples.
    pub(in crate::hbm) upsampler: Upsampler,
    /// The same to the grid of the tree route's monodromy (`tree_monodromy` of the stability room),
    /// planned on its first use.
    pub(in crate::hbm) tree_upsampler: Option<Upsampler>,
    /// The largest eigenvalue modulus (1/s) of the mechanism linearised about its steady spin,
    /// and the speed Ω₀ (rad/s) it was linearised at: the tree route's monodromy chooses its
    /// integration from it (`butcher6_steps` of the stability room). None below seven coordinates (no tree
    /// route) or where the linearisation fails (then RK4 with Richardson's extrapolation).
    pub(in crate::hbm) tree_rate: Option<(f64, f64)>,
    /// The tree route's work arrays (M and B W⁻¹ at the samples, the interpolated series, the
    /// instants), kept from one monodromy to the next.
    pub(in crate::hbm) tree_buffers: [Vec<f64>; 4],
    pub(in crate::hbm) rhat: DVector<f64>,
    pub(in crate::hbm) jac: DMatrix<f64>,
    /// ∂R̂/∂p of the last Jacobian assembly, for the parameter it was asked for.
    pub(in crate::hbm) gp: DVector<f64>,
    /// The joint couplings by coordinate, for their harmonic content ([`Hbm::coupling_tail`]).
    pub(in crate::hbm) couplings: Vec<(usize, Couplings)>,
    /// On the cyclic route, the reduced problem's non-unison Floquet blocks, one per identical
    /// set (the cyclic route fills them); empty otherwise.
    pub(in crate::hbm) non_unison: Vec<NonUnison>,
    /// Told of every accepted point of a continuation (a progress line), if set.
    pub(in crate::hbm) on_point: Option<PointHook>,
    /// The complex Floquet pairs near ±1 of the last stability analysis, per block, with the
    /// sense in which their eigenvectors turn ([`PairSense`]): the continuation's
    /// test for a tongue stepped over whole.
    pub(in crate::hbm) pair_senses: Vec<Vec<PairSense>>,
}

/// The non-unison block of one identical set in a reduced problem: the representative's
/// coordinates (reduced numbering) and how many independent combinations it stands for. The
/// cyclic route fills these in; the stability analysis, the event location and the unison-loss
/// tests read them.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NonUnison {
    pub(crate) label: String,
    pub(crate) coordinates: Vec<usize>,
    pub(crate) multiplicity: usize,
}

impl Hbm {
    /// The options in use.
    pub fn options(&self) -> &HbmOptions {
        &self.opts
    }

    /// Time samples per period used for the residual.
    pub fn time_samples(&self) -> usize {
        self.aft.nt
    }

    /// Number of unknowns n_dof (2H + 1).
    pub fn unknowns(&self) -> usize {
        self.n * self.nb
    }

    /// Base frequency ω₀ at order n and the current mean speed, rad/s.
    pub fn base_frequency(&self, order: f64) -> f64 {
        self.ratio * order * self.omega
    }

    /// Mean speed Ω of the fixed-parameter solves, rad/s.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// Sets the mean speed Ω (rad/s) of the fixed-parameter solves ([`Hbm::solve`]).
    pub fn set_speed(&mut self, omega: f64) -> Result<(), HbmError> {
        if !(omega.is_finite() && omega > 0.0) {
            return Err(HbmError::Invalid(format!("mean speed must be positive and finite, got {omega} rad/s")));
        }
        self.omega = omega;
        Ok(())
    }

    /// Torque scale s of the fixed-parameter solves (the excitation amplitudes are s·T_k).
    pub fn torque_scale(&self) -> f64 {
        self.scale
    }

    /// Sets the torque scale s (dimensionless, finite) of the fixed-parameter solves.
    pub fn set_torque_scale(&mut self, scale: f64) -> Result<(), HbmError> {
        if !scale.is_finite() {
            return Err(HbmError::Invalid(format!("torque scale must be finite, got {scale}")));
        }
        self.scale = scale;
        Ok(())
    }

    /// The current fixed parameters at order n.
    pub(in crate::hbm) fn at(&self, order: f64) -> At {
        At { order, omega: self.omega, scale: self.scale }
    }

    /// Sets (or clears) the hook told of every accepted point of the continuations.
    pub fn set_on_point(&mut self, hook: Option<PointHook>) {
        self.on_point = hook;
    }

    /// Whether the spin angle is cyclic (no gravity and no world-frame force).
    pub fn is_cyclic(&self) -> bool {
        self.cyclic
    }

    /// The state `x = [q; u]` of the mechanism at time t on a solution (for starting a time
    /// integration on the orbit).
    pub fn state_at(&self, sol: &HbmSolution, t: f64) -> Vec<f64> {
        let n = self.n;
        let (q, qd) = sol.coordinates_at(t);
        let mut u = vec![0.0; n];
        self.ev.speeds.u_from_qdot(&self.ev.parents, &qd, &mut u);
        let mut x = q;
        x.extend_from_slice(&u);
        x
    }
}
