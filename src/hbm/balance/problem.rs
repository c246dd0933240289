//! Harmonic balance (HBM) for periodic steady states under order excitation, with pseudo-arclength
//! continuation in the excitation order, the mean speed or the torque amplitude, and Floquet
//! stability: the faster route to the steady responses that the paper obtains by long time
//! integration (sections 4 and 5; its conclusion names harmonic balance as the method to come).
//!
//! This module holds the problem ([`Hbm`]) and Newton's method at fixed parameters (one idea: a
//! third of its length is the formulation below, written where the code that follows it is); the parts
//! are in submodules, their public items re-exported here: `solution` ([`HbmSolution`] and its
//! read-outs), `sample` (the residual and its derivatives at one time sample), `assembly` (the
//! AFT residual and the spectral Jacobian), `blocklu` (the Jacobian's factorisation by blocks
//! along the mechanism's tree), `aft` (the real FFTs), `branch` (the branch data
//! model and the continued [`Parameter`]), `continuation` (the pseudo-arclength walk),
//! `stability` (Floquet multipliers), `cyclic` (identical absorbers by one representative,
//! [`RoutedHbm`] and its [`Route`]) and `fold2` (fold curves in order and torque, and their
//! cusps: [`Hbm::continue_fold`]).
//!
//! # Formulation
//!
//! A mechanism (any revolute tree) has a *spin joint* s: a root joint whose angle is cyclic (no
//! gravity, no world-frame force, no spring on it), driven by the order excitation
//! `T(t) = T_m + Σ_k T_k sin(m_k n Ω t + α_k)` at mean speed Ω. A periodic steady state is sought as
//!
//! - `q_s(t) = Ω t + p_s(t)` for the spin coordinate and `q_k(t) = p_k(t)` for every other one,
//! - each `p_k` a truncated Fourier series in the normalised time `τ = ω₀ t ∈ [0, 2π)`:
//!   `p_k = a_k0 + Σ_{h=1..H} a_kh cos hτ + b_kh sin hτ`,
//!
//! where the base frequency `ω₀ = n Ω g / d` is the greatest common divisor of the excited
//! frequencies `m_k n Ω` (the multiples m_k are rational with denominator d ≤ 12, and g is the
//! greatest common divisor of the integers `m_k d`): for a single order n, and for orders n and
//! 2n, ω₀ = nΩ.
//!
//! The constant `a_s0` of the spin angle is a gauge (the angle is cyclic, so shifting it changes
//! nothing) and is fixed at 0. Its slot is taken by the mean torque `T_m`, which is *solved*: the
//! mean speed is Ω by construction, and T_m is whatever torque sustains it. The mean of the
//! excitation given by the user is therefore not used. For the CPVA the balance of angular
//! momentum over one period gives `T_m = c_r Ω` exactly (the pendulum damper is internal), which
//! the tests check. Other applied torques of the mechanism must be constant in time (an
//! oscillating torque elsewhere is rejected), the spin joint's own torque is replaced by T.
//!
//! # Residual (alternating frequency/time)
//!
//! With speeds `u = W q̇` (W constant for both speed choices of kanedyn) Kane's equations read
//! `R(t) = M(q) W q̈ − F(q, W q̇, t) − g·T(t) = 0`, with g the generalized force of a unit torque in
//! the spin joint. `R` is evaluated by the engine at `N_t` equally spaced samples of one period
//! and projected on the Fourier basis (mean, cos hτ, sin hτ for h ≤ H): `n_dof (2H + 1)` equations
//! for as many unknowns. Both transforms are real FFTs (realfft, planned once in [`Hbm::new`],
//! buffers preallocated, no allocation per residual): the coordinates and their two derivatives
//! by 3 n_dof inverse transforms of the (derivative-weighted) half spectra, the residual by n_dof
//! forward transforms. `N_t ≥ 2H + 1` makes the projection exact for a band-limited residual; the
//! default `4(H + 1)` (44 for H = 10, an even length, 4·11: realfft halves it to a complex FFT of
//! 22) keeps the aliasing of the nonlinear terms (sin φ, u² sin φ) below the truncation error.
//! Any N_t is allowed (realfft handles odd lengths too; no power-of-two padding).
//!
//! # Jacobian
//!
//! Per sample, the derivatives `A = ∂R/∂q`, `B = ∂R/∂q̇` are formed by central differences of the
//! engine (4 n_dof − 2 evaluations; the spin angle is cyclic so its column of A is zero), and
//! `C = ∂R/∂q̈ = M W` is exact. The Fourier-domain Jacobian projects `A e + ω₀ B e' + ω₀² C e''`
//! for every basis function e (1, cos lτ, sin lτ): about 4·N_t·n_dof engine calls instead of the
//! `2·N_t·n_dof·(2H + 1)` of central differences of the whole residual (for the CPVA with
//! H = 10: 308 instead of 3696), and each difference sees one time sample only. The projections
//! are not summed over the samples: each entry A_ik(τ)·cos lτ projected on cos hτ is
//! `C_{h−l} + C_{h+l}` of the discrete Fourier coefficients of A_ik (and likewise for the other
//! products), so one forward FFT per coefficient series (3 n_dof²) and O(1) work per entry give
//! the same matrix, aliasing included, up to rounding.
//!
//! NOTE: the residual uses real FFTs, not explicit DFT tables, and the Jacobian the spectral form,
//! not per-sample tables (the tables cost N_t·(2H + 1)² multiply-adds per block, the spectral
//! form (2H + 1)² lookups plus 3 n_dof² FFTs): both measured faster on the canonical CPVA
//! (H = 10, N_t = 44), see `BENCHMARKS.md`, so the tables were not kept.
//!
//! A unit test checks the assembled Jacobian and ∂R̂/∂n against central differences of the
//! whole residual (agreement to 1e-6 of the largest entry). The derivative with respect to the
//! order n, needed by the continuation, follows exactly from the same B and C, because in
//! normalised time n enters only through `d/dt = ω₀ d/dτ`. Likewise for the mean speed
//! (`∂R/∂Ω = B (q̇_per/Ω + e_s) + 2 C q̈/Ω`: Ω also sets the mean spin rate, while the spin angle
//! Ωt = τ/(ratio·n) is cyclic) and the torque scale s (`∂R/∂s = −g T_osc(τ)`, the torque enters
//! linearly); the unit test checks all three against differences of the residual. A forcing that
//! follows the speed, `T_osc = T_0(τ) + Ω² T_2(τ)` (an engine: gas torque and reciprocating
//! inertia, [`Hbm::with_speed_forcing`]), adds `−2Ω s g T_2(τ)` to ∂R/∂Ω; a second unit test
//! checks that one.
//!
//! # Harmonic count
//!
//! [`HbmSolution::top_harmonic_ratio`] is the share of the top harmonic in the acceleration
//! spectrum of each coordinate, `H² |c_H| / (Σ_h h⁴ |c_h|²)^½`, maximised over the coordinates;
//! when it exceeds [`HbmOptions::harmonic_tol`], more harmonics are needed
//! ([`HbmSolution::needs_more_harmonics`]).
//!
//! The joint couplings (staged springs, friction, end stops; [`crate::model::coupling`]) are not
//! smooth: they go through the AFT like every force, sampled at the N_t instants, but their
//! spectra decay slowly (as 1/h² past a kink, 1/h for friction close to Coulomb's). Their own
//! indicator, [`HbmSolution::coupling_tail`], is the share of each coupling force's oscillating
//! content (its discrete spectrum up to N_t/2 from the same samples) that lies above H, where
//! the balance drops it: `(Σ_{h>H} |F_h|² / Σ_{h≥1} |F_h|²)^½`. Above
//! [`HbmOptions::coupling_tol`] the solution needs more harmonics too, and a study's summary says
//! so. The response converges faster than this share (the dynamics filter the dropped force by
//! about 1/h²), so the indicator is on the safe side.

mod aft;
mod assembly;
mod blocklu;
mod branch;
mod continuation;
mod corrector;
mod cyclic;
mod fold2;
mod free;
mod lu;
mod reaction;
mod sample;
mod solution;
mod stability;
mod switch;

pub use branch::{
    Bifurcation, BifurcationClass, BifurcationKind, Branch, BranchEnd, BranchPoint, Fold, FoldKind, Parameter,
};
pub use continuation::{ContinuationOptions, continue_in_order};
pub use cyclic::{CyclicSet, Route, RoutedHbm, detect, route_for};
pub use fold2::{
    FoldCurve, FoldCurveEnd, FoldCurveOptions, FoldCurvePoint, FoldPlane, MechanismFamily, ParameterPoint, Singularity,
};
pub use free::{BackboneOptions, FreeOrbit, FreeSpin, FreeStart};
pub use reaction::{MeshTorqueHarmonics, ReactionHarmonics};
pub use solution::HbmSolution;
pub use stability::{FloquetBlock, Stability};
pub use switch::Symmetry;

use crate::kane::Kane;
use crate::model::coupling::Couplings;
use crate::model::excitation::{Excitation, Harmonic};
use nalgebra::{DMatrix, DVector};
use realfft::num_complex::Complex;
use sample::{Evaluator, SampleLin};
use std::f64::consts::PI;

/// Failures of the harmonic balance.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HbmError {
    /// The problem is not set up correctly (names the problem).
    #[error("harmonic balance: {0}")]
    Invalid(String),
    /// Newton's method did not converge.
    #[error(
        "harmonic balance at order {order}: Newton did not converge in {iterations} iterations (last step {step:e})"
    )]
    NoConvergence {
        /// Excitation order n.
        order: f64,
        /// Iterations done.
        iterations: usize,
        /// Size of the last Newton step (max norm of the unknowns).
        step: f64,
    },
    /// The Jacobian could not be factorised (a fold at fixed order, or a free coordinate).
    #[error(
        "harmonic balance at order {order}: singular Jacobian (at a fold, or a coordinate without restoring force?)"
    )]
    Singular {
        /// Excitation order n.
        order: f64,
    },
    /// The eigenvalues of the monodromy matrix could not be found within the iteration cap.
    #[error("harmonic balance at order {order}: the Floquet multipliers ({dim} × {dim} monodromy) did not converge")]
    Eigen {
        /// Excitation order n.
        order: f64,
        /// Size of the eigenproblem.
        dim: usize,
    },
    /// The iteration produced a non-finite number.
    #[error("harmonic balance at order {order}: non-finite value (diverged)")]
    NonFinite {
        /// Excitation order n.
        order: f64,
    },
}

/// Numerical settings of the harmonic balance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HbmOptions {
    /// Number of harmonics H of the base frequency ω₀ kept in every coordinate.
    pub harmonics: usize,
    /// Time samples per period N_t for the residual (0: automatic, 4(H + 1)); at least 2H + 1.
    pub time_samples: usize,
    /// Newton tolerance on the step: max norm over the Fourier coefficients (rad) and the scaled
    /// mean torque `T_m / T_scale` (T_scale = max(Σ|T_k|, 1 N·m)).
    pub tol: f64,
    /// Maximum Newton iterations for a solve at fixed order.
    pub max_iter: usize,
    /// Largest acceptable share of the top harmonic (see [`HbmSolution::top_harmonic_ratio`]).
    pub harmonic_tol: f64,
    /// Largest acceptable share of a joint coupling's force in the harmonics above H (see
    /// [`HbmSolution::coupling_tail`]).
    pub coupling_tol: f64,
    /// Central-difference step for the per-sample derivatives: rad for angles, and relative
    /// (times max(1, |q̇|)) for rates.
    pub fd_step: f64,
    /// Samples per period N_s for the Floquet monodromy (a multiple of 4, ≥ 8; 0 disables
    /// stability): RK4 with steps 2T/N_s and 4T/N_s (T = 2π/ω₀), Richardson-extrapolated, on the
    /// variational equations, whose coefficients are interpolated from the N_t samples of the
    /// harmonic balance.
    pub stability_samples: usize,
}

impl Default for HbmOptions {
    fn default() -> Self {
        Self {
            harmonics: 10,
            time_samples: 0,
            tol: 1e-10,
            max_iter: 30,
            harmonic_tol: 1e-5,
            coupling_tol: 1e-2,
            fd_step: 1e-6,
            stability_samples: 256,
        }
    }
}

/// Called by a continuation after each accepted point with the number of points so far and
/// the continued parameter's value there (its units: n, rad/s or the torque scale), for a
/// progress line. Shared, so that an [`Hbm`] stays `Clone`.
#[derive(Clone)]
pub struct PointHook(pub std::sync::Arc<dyn Fn(usize, f64) + Send + Sync>);

impl std::fmt::Debug for PointHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PointHook")
    }
}

/// Where the residual is evaluated: excitation order n, mean speed Ω (rad/s), torque scale s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct At {
    pub order: f64,
    pub omega: f64,
    pub scale: f64,
}

/// One excitation term in normalised time: `amplitude · sin(index·τ + phase)` (tabulated at the
/// samples in [`Hbm::new`]).
#[derive(Debug, Clone, Copy)]
struct Term {
    index: f64,
    amplitude: f64,
    phase: f64,
}

/// A harmonic-balance problem: one mechanism, its spin joint, the mean speed Ω and the order
/// excitation terms; the excitation order n is the free parameter of every solve.
///
/// Build once, then [`Hbm::solve`] at fixed orders or [`continue_in_order`] along a branch.
/// `Clone` it to work on several threads.
#[derive(Debug, Clone)]
pub struct Hbm {
    ev: Evaluator,
    n: usize,
    spin: usize,
    /// The spin angle is cyclic (no gravity, no world-frame force): its column of ∂R/∂q is zero
    /// and its shift gives the trivial Floquet multiplier +1.
    cyclic: bool,
    /// Each coordinate's share of the mean rotation Ωt (see [`HbmSolution::rotation`]).
    rotation: Vec<f64>,
    /// The spin angle alone moves no force (cyclic, and no joint meshed to it), so its column
    /// of ∂R/∂q is zero and is not differenced; with meshes only the shift along `rotation` is
    /// free of force.
    spin_column_zero: bool,
    omega: f64,
    /// Torque scale s of the fixed-parameter solves.
    scale: f64,
    /// ω₀ = ratio · n · Ω.
    ratio: f64,
    t_scale: f64,
    opts: HbmOptions,
    nb: usize,
    aft: aft::Aft,
    /// The generalized force of the oscillating excitation torques at the N_t samples, per
    /// equation (`exc[r·N_t + j]`), N·m.
    exc: Vec<f64>,
    /// The same for the forcing per Ω² (N·m·s²/rad²; empty without one): the generalized force
    /// is `exc + Ω² exc2` ([`Hbm::with_speed_forcing`]).
    exc2: Vec<f64>,
    // Work buffers: p, ṗ, p̈ per coordinate, R and ∂R/∂n per equation, each N_t samples.
    qt: Vec<f64>,
    qdt: Vec<f64>,
    qddt: Vec<f64>,
    rt: Vec<f64>,
    dpt: Vec<f64>,
    /// One coefficient series (N_t) and the half spectra of the 3n² series of `samples`.
    series: Vec<f64>,
    spectra: Vec<Complex<f64>>,
    /// `(C_m, S_m)`, m = −2H..=2H, of each of those series.
    unfolded: Vec<(f64, f64)>,
    /// Which of those series were zero at every sample in the last assembly.
    zero_series: Vec<bool>,
    /// Which n × n blocks of `jac` are zero (left unwritten by the last Jacobian assembly; a
    /// block of the spin column holds a mean-torque entry and is never marked): the next
    /// assembly clears only the blocks it does not write and that are not marked, and the block
    /// LU does not read the marked ones.
    zero_blocks: Vec<bool>,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    lin: SampleLin,
    /// Per-sample `[A | B | C]` (3n² each, row-major blocks) of the last Jacobian assembly, and
    /// the point (unknowns, order) it belongs to: the stability analysis reuses them.
    samples: Vec<f64>,
    samples_at: Option<(Vec<f64>, At)>,
    /// The point (unknowns, parameters) of the residual in `rhat`.
    rhat_at: Option<(Vec<f64>, At)>,
    /// Trigonometric interpolation from the N_t residual samples to the N_s stability samples.
    upsampler: aft::Upsampler,
    /// The same to the grid of the tree route's monodromy (`stability::Hbm::tree_monodromy`),
    /// planned on its first use.
    tree_upsampler: Option<aft::Upsampler>,
    /// The largest eigenvalue modulus (1/s) of the mechanism linearised about its steady spin,
    /// and the speed Ω₀ (rad/s) it was linearised at: the tree route's monodromy chooses its
    /// integration from it (`stability::butcher6_steps`). None below seven coordinates (no tree
    /// route) or where the linearisation fails (then RK4 with Richardson's extrapolation).
    tree_rate: Option<(f64, f64)>,
    /// The tree route's work arrays (M and B W⁻¹ at the samples, the interpolated series, the
    /// instants), kept from one monodromy to the next.
    tree_buffers: [Vec<f64>; 4],
    rhat: DVector<f64>,
    jac: DMatrix<f64>,
    /// ∂R̂/∂p of the last Jacobian assembly, for the parameter it was asked for.
    gp: DVector<f64>,
    /// The joint couplings by coordinate, for their harmonic content ([`Hbm::coupling_tail`]).
    couplings: Vec<(usize, Couplings)>,
    /// On the cyclic route, the reduced problem's non-unison Floquet blocks, one per identical
    /// set ([`cyclic`]); empty otherwise.
    non_unison: Vec<cyclic::NonUnison>,
    /// Told of every accepted point of a continuation (a progress line), if set.
    on_point: Option<PointHook>,
    /// The complex Floquet pairs near ±1 of the last stability analysis, per block, with the
    /// sense in which their eigenvectors turn (`stability::PairSense`): the continuation's
    /// test for a tongue stepped over whole.
    pair_senses: Vec<Vec<stability::PairSense>>,
}

impl Hbm {
    /// Sets up the problem for `kane`'s mechanism (cloned), spin joint index `spin_joint`, mean
    /// speed `omega` (rad/s) and the excitation terms `T_k sin(m_k n Ω t + α_k)` of `harmonics`
    /// (multiple m_k, amplitude T_k in N·m, phase α_k in rad).
    ///
    /// Errors when the spin joint is not a root joint with a cyclic angle (gravity or a
    /// world-frame force, or a spring on it), when another joint carries an oscillating torque,
    /// when a multiple is not a positive rational with denominator ≤ 12, or when the options are
    /// inconsistent.
    pub fn new(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::with_inputs(kane, spin_joint, omega, harmonics, &[(spin_joint, 1.0, 0.0)], options)
    }

    /// [`Hbm::new`] with the oscillating torque acting at several joints: joint `j` of each
    /// `(j, scale, phase)` of `inputs` carries `scale · T_k sin(m_k n Ω t + α_k + phase)` (child
    /// against parent; the mean torque stays on the spin joint). Each joint's torque enters the
    /// residual through its own generalized force `∂q̇_j/∂u`. The joints' own oscillating
    /// torques, if any, are replaced.
    pub fn with_inputs(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::with_speed_forcing(kane, spin_joint, omega, harmonics, &[], inputs, options)
    }

    /// [`Hbm::with_inputs`] with a forcing that follows the mean speed, as an engine's does:
    /// `Σ T_k sin(m_k n Ω t + α_k) + Ω² Σ T'_k sin(m'_k n Ω t + α'_k)`, the terms T'_k of
    /// `per_omega2` in N·m·s²/rad² (an engine's reciprocating-inertia torque per Ω², its gas
    /// torque in `harmonics`, see [`crate::combustion::OscillatingSeries::split_harmonics`]). A
    /// continuation in [`Parameter::Speed`] then carries the forcing along, and its ∂R̂/∂Ω holds
    /// the forcing's derivative `2Ω Σ T'_k sin(…)`.
    pub fn with_speed_forcing(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        per_omega2: &[Harmonic],
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let bad = |m: String| Err(HbmError::Invalid(m));
        let mech = kane.mechanism();
        let n = kane.ndof();
        if spin_joint >= mech.joints.len() {
            return bad(format!(
                "spin joint index {spin_joint} out of range (mechanism has {} joints)",
                mech.joints.len()
            ));
        }
        let sj = &mech.joints[spin_joint];
        if sj.parent.is_some() {
            return bad(format!("spin joint `{}` must connect a body to ground", sj.name));
        }
        // The unknowns are per coordinate: the spin's is its joint's (a welded joint has none).
        let Some(spin) = sj.coordinate.filter(|_| sj.kind.rotates()) else {
            return bad(format!("spin joint `{}` does not rotate: it cannot spin", sj.name));
        };
        if sj.spring.is_some_and(|s| s.stiffness != 0.0) {
            return bad(format!("spin joint `{}` has a spring: its angle is not cyclic", sj.name));
        }
        if sj.couplings.stages.is_some() || sj.couplings.stops.is_some() {
            return bad(format!("spin joint `{}` has a staged spring or end stops: its angle is not cyclic", sj.name));
        }
        // Gravity or a world-frame force: the spin angle is not cyclic, the forces depend on it
        // with period 2π, and a periodic solution needs a base period that is a whole number of
        // revolutions (checked per solve, see `check_base`).
        let cyclic = !mech.loads.needs_world_orientation();
        // The mean rotation of every coordinate (1 at the spin, the ratios through meshes): a
        // geared train turns as a whole (issue 29, item 1).
        let rotation = mech.rigid_rotation(spin_joint).map_err(HbmError::Invalid)?;
        if !cyclic && rotation.iter().enumerate().any(|(k, &z)| k != spin && z != 0.0) {
            return bad("gravity or a world-frame force with joints meshed to the spin joint: they turn at other \
                        rates, so the forcing has no common period"
                .into());
        }
        if !(omega.is_finite() && omega > 0.0) {
            return bad(format!("mean speed must be positive and finite, got {omega} rad/s"));
        }
        // A rigidly driven joint is excited through its gear: its torque reaches the coordinate it
        // follows times the factor (Tᵀ, docs/design.md "Gears").
        let follow = mech.follow_map();
        for &(j, scale, phase) in inputs {
            if follow.get(j).copied().flatten().is_none() {
                return bad(format!("excitation input: joint #{j} has no coordinate (Fixed or out of range)"));
            }
            if !(scale.is_finite() && phase.is_finite()) {
                return bad(format!(
                    "excitation input at joint `{}`: scale and phase must be finite",
                    mech.joints[j].name
                ));
            }
        }
        // A geared engine's unconstrained tree holds every joint torque, the driven joints' too.
        let torques = kane.unconstrained().map_or(kane.joint_torques(), |u| u.joint_torques()).to_vec();
        for jt in &torques {
            let replaced = jt.joint == spin_joint || inputs.iter().any(|i| i.0 == jt.joint);
            if !replaced && jt.excitation.harmonics.iter().any(|h| h.amplitude != 0.0) {
                return bad(format!(
                    "joint `{}` carries an oscillating torque; only the spin joint may be excited",
                    mech.joints[jt.joint].name
                ));
            }
        }
        let opts = options;
        if opts.harmonics == 0 {
            return bad("at least one harmonic is needed".into());
        }
        let nt = if opts.time_samples == 0 { 4 * (opts.harmonics + 1) } else { opts.time_samples };
        if nt < 2 * opts.harmonics + 1 {
            return bad(format!("{nt} time samples cannot resolve {} harmonics (need ≥ 2H + 1)", opts.harmonics));
        }
        if opts.stability_samples != 0 && (opts.stability_samples < 8 || !opts.stability_samples.is_multiple_of(4)) {
            return bad(format!(
                "stability_samples must be a multiple of 4 and ≥ 8 (or 0), got {}",
                opts.stability_samples
            ));
        }
        // Base frequency: the multiples as fractions k_i/d with a common denominator d ≤ 12.
        let mut ratio = 1.0;
        let mut terms = Vec::new();
        let all: Vec<Harmonic> = harmonics.iter().chain(per_omega2).copied().collect();
        if !all.is_empty() {
            let harmonics = &all;
            for h in harmonics {
                if !(h.multiple.is_finite() && h.multiple > 0.0 && h.amplitude.is_finite() && h.phase.is_finite()) {
                    return bad(format!("excitation term {h:?}: multiple must be positive, all numbers finite"));
                }
            }
            let d = (1..=12u64)
                .find(|&d| {
                    harmonics.iter().all(|h| (h.multiple * d as f64 - (h.multiple * d as f64).round()).abs() < 1e-9)
                })
                .ok_or_else(|| {
                    HbmError::Invalid("excitation multiples must be rationals with denominator ≤ 12".into())
                })?;
            let ints: Vec<u64> = harmonics.iter().map(|h| (h.multiple * d as f64).round() as u64).collect();
            let g = ints.iter().fold(0, |a, &b| gcd(a, b));
            ratio = g as f64 / d as f64;
            terms = harmonics
                .iter()
                .zip(&ints)
                .map(|(h, &k)| Term { index: (k / g) as f64, amplitude: h.amplitude, phase: h.phase })
                .collect();
        }
        // The terms of `per_omega2` follow those of `harmonics` in `terms`.
        let terms2 = terms.split_off(terms.len().min(harmonics.len()));
        let t_scale = (harmonics.iter().map(|h| h.amplitude.abs()).sum::<f64>()
            + omega * omega * per_omega2.iter().map(|h| h.amplitude.abs()).sum::<f64>())
        .max(1.0);
        let mut kane = kane.clone();
        for &(j, _, _) in inputs {
            let mean = torques.iter().find(|t| t.joint == j).map_or(0.0, |t| t.excitation.mean);
            kane.set_joint_torque(j, Excitation::constant(mean));
        }
        kane.set_joint_torque(spin_joint, Excitation::constant(0.0));
        let parents = mech.speed_parents();
        let speeds = mech.speeds;
        let w = speeds.w_matrix(&parents);
        // g_r = ∂q̇_s/∂u_r: a spin torque τ does τ q̇_s of power.
        let mut g = vec![0.0; n];
        let (mut e, mut qd) = (vec![0.0; n], vec![0.0; n]);
        for r in 0..n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[r] = 1.0;
            speeds.qdot(&parents, &e, &mut qd);
            g[r] = qd[spin];
        }
        // The oscillating torque's generalized force at every sample: Σ_inputs g_j · T_j(τ), with
        // g_j[r] = ∂q̇_j/∂u_r (a torque τ at joint j does τ q̇_j of power).
        let mut exc = vec![0.0; n * nt];
        let mut exc2 = vec![0.0; if terms2.is_empty() { 0 } else { n * nt }];
        for &(joint, scale, phase) in inputs {
            let (c, factor) = follow[joint].map_or((spin, 1.0), |f| (f.coordinate, f.factor));
            let mut gj = vec![0.0; n];
            for (r, g) in gj.iter_mut().enumerate() {
                e.iter_mut().for_each(|x| *x = 0.0);
                e[r] = 1.0;
                speeds.qdot(&parents, &e, &mut qd);
                *g = factor * qd[c];
            }
            for j in 0..nt {
                let tau = 2.0 * PI * j as f64 / nt as f64;
                let t: f64 = terms.iter().map(|t| t.amplitude * (t.index * tau + t.phase + phase).sin()).sum();
                let t2: f64 = terms2.iter().map(|t| t.amplitude * (t.index * tau + t.phase + phase).sin()).sum();
                for (r, g) in gj.iter().enumerate() {
                    exc[r * nt + j] += scale * g * t;
                    if !exc2.is_empty() {
                        exc2[r * nt + j] += scale * g * t2;
                    }
                }
            }
        }
        let nb = 2 * opts.harmonics + 1;
        let couplings = mech
            .joints
            .iter()
            .filter_map(|j| j.coordinate.filter(|_| !j.couplings.is_empty()).map(|k| (k, j.couplings.clone())))
            .collect();
        let ev = Evaluator::new(kane, speeds, parents, (0..n * n).map(|i| w[(i / n, i % n)]).collect(), g);
        let tree_rate = if 2 * n > 12 {
            use crate::linear::{Damping, LinearModel, Spin};
            LinearModel::new(mech, &mech.joints[spin_joint].name, omega, None)
                .and_then(|m| m.fastest_rate(Spin::Free, Damping::Damped))
                .ok()
                .filter(|r| r.is_finite())
                .map(|r| (r, omega))
        } else {
            None
        };
        Ok(Self {
            couplings,
            non_unison: Vec::new(),
            on_point: None,
            pair_senses: Vec::new(),
            ev,
            n,
            spin,
            spin_column_zero: cyclic && rotation.iter().enumerate().all(|(k, &z)| k == spin || z == 0.0),
            rotation,
            cyclic,
            omega,
            scale: 1.0,
            ratio,
            t_scale,
            opts,
            nb,
            aft: aft::Aft::new(nt, opts.harmonics),
            exc,
            exc2,
            qt: vec![0.0; n * nt],
            qdt: vec![0.0; n * nt],
            qddt: vec![0.0; n * nt],
            rt: vec![0.0; n * nt],
            dpt: vec![0.0; n * nt],
            series: vec![0.0; nt],
            spectra: vec![Complex::default(); 3 * n * n * (nt / 2 + 1)],
            unfolded: vec![(0.0, 0.0); 3 * n * n * (4 * opts.harmonics + 1)],
            zero_series: vec![false; 3 * n * n],
            zero_blocks: vec![false; n * n],
            q: vec![0.0; n],
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            lin: SampleLin::new(n),
            samples: vec![0.0; nt * 3 * n * n],
            samples_at: None,
            rhat_at: None,
            upsampler: aft::Upsampler::new(opts.stability_samples.max(2)),
            tree_upsampler: None,
            tree_rate,
            tree_buffers: Default::default(),
            rhat: DVector::zeros(n * nb),
            jac: DMatrix::zeros(n * nb, n * nb),
            gp: DVector::zeros(n * nb),
        })
    }

    /// Like [`Hbm::new`], taking Ω (from `rpm`) and the terms from an [`Excitation`]; its mean
    /// (solved instead), order (the free parameter) and ramp (steady state) are not used.
    pub fn from_excitation(
        kane: &Kane,
        spin_joint: usize,
        excitation: &Excitation,
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::new(kane, spin_joint, excitation.omega(), &excitation.harmonics, options)
    }

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
    fn at(&self, order: f64) -> At {
        At { order, omega: self.omega, scale: self.scale }
    }

    /// Unknowns vector from a solution (resampled to this problem's H), or zero.
    fn unknowns_from(&self, guess: Option<&HbmSolution>) -> Vec<f64> {
        let (n, nb) = (self.n, self.nb);
        let mut x = vec![0.0; n * nb];
        if let Some(g) = guess.filter(|g| g.ndof() == n) {
            for k in 0..n {
                let src = &g.coefficients[k * g.nb()..(k + 1) * g.nb()];
                let m = src.len().min(nb);
                x[k * nb..k * nb + m].copy_from_slice(&src[..m]);
            }
            x[self.spin * nb] = g.mean_torque / self.t_scale;
        }
        x
    }

    /// The solution record for unknowns x at `at` (fills the residual norm and the harmonic
    /// check; no stability).
    fn solution_from(&mut self, x: &[f64], at: &At, iterations: usize) -> HbmSolution {
        let order = at.order;
        // The residual is already in the buffer when the last assembly was at this very point
        // (as after the continuation's Jacobian at an accepted point).
        if !self.rhat_at.as_ref().is_some_and(|(xs, a)| a == at && xs.as_slice() == x) {
            self.assemble(x, at, None);
        }
        let residual = self.rhat.amax();
        let mut coefficients = x.to_vec();
        coefficients[self.spin * self.nb] = 0.0;
        let mut sol = HbmSolution {
            order,
            omega: at.omega,
            torque_scale: at.scale,
            base_frequency: self.ratio * order * at.omega,
            harmonics: self.opts.harmonics,
            spin: self.spin,
            rotation: self.rotation.clone(),
            coefficients,
            mean_torque: x[self.spin * self.nb] * self.t_scale,
            iterations,
            residual,
            top_harmonic_ratio: 0.0,
            coupling_tail: 0.0,
            needs_more_harmonics: false,
            stability: None,
        };
        sol.top_harmonic_ratio = sol.harmonic_ratio();
        sol.coupling_tail = self.coupling_tail(at);
        sol.needs_more_harmonics =
            sol.top_harmonic_ratio > self.opts.harmonic_tol || sol.coupling_tail > self.opts.coupling_tol;
        sol
    }

    /// The convergence indicator of the couplings' harmonic content at the samples of the last
    /// assembly (section "Harmonic count" of the module docs): per coupled coordinate, the
    /// coupling force τ(q(t), q̇(t)) at the N_t samples, its discrete spectrum F_m
    /// (m ≤ N_t/2), and `(Σ_{m>H} |F_m|² / Σ_{m≥1} |F_m|²)^½`, the share of its oscillating
    /// content the balance of H harmonics drops; the largest over the couplings (0 without).
    fn coupling_tail(&mut self, at: &At) -> f64 {
        let (nt, hh) = (self.aft.nt, self.opts.harmonics);
        let w0 = self.ratio * at.order * at.omega;
        let mut spec = vec![Complex::default(); self.aft.half_len()];
        let mut worst = 0.0f64;
        for (k, law) in &self.couplings {
            let k = *k;
            for j in 0..nt {
                let t = 2.0 * PI * j as f64 / nt as f64 / w0;
                let (mut q, mut qd) = (self.qt[k * nt + j], self.qdt[k * nt + j]);
                q += self.rotation[k] * at.omega * t;
                qd += self.rotation[k] * at.omega;
                self.series[j] = law.torque(q, qd);
            }
            self.aft.spectrum(&self.series, &mut spec);
            let power = |m: &Complex<f64>| m.norm_sqr();
            let total: f64 = spec.iter().skip(1).map(power).sum();
            let tail: f64 = spec.iter().skip(hh + 1).map(power).sum();
            if total > 0.0 {
                worst = worst.max((tail / total).sqrt());
            }
        }
        worst
    }

    /// Solves for the periodic steady state at excitation order `order` by Newton's method from
    /// `guess` (a nearby solution; zero coefficients, i.e. the rigid rotation, when None: the
    /// first step is then the linear response). Stability is not computed (see
    /// [`Hbm::stability`]).
    pub fn solve(&mut self, order: f64, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        if !(order.is_finite() && order > 0.0) {
            return Err(HbmError::Invalid(format!("excitation order must be positive and finite, got {order}")));
        }
        self.solve_at(&self.at(order), guess)
    }

    /// With a non-cyclic spin angle (gravity, a world-frame force) the forces repeat every
    /// revolution, so the base period 2π/ω₀ must hold a whole number of revolutions: ω₀/Ω =
    /// ratio·n must be 1/k. An excitation at order 3 with multiples 1 and 2 has base order 3; the
    /// multiple 1/3 (amplitude 0 if need be) brings it to 1.
    fn check_base(&self, order: f64) -> Result<(), HbmError> {
        if self.cyclic {
            return Ok(());
        }
        let turns = 1.0 / (self.ratio * order);
        if (turns - turns.round()).abs() > 1e-9 * turns.max(1.0) || turns.round() < 1.0 {
            return Err(HbmError::Invalid(format!(
                "with gravity or a world-frame force the base order ({}) must divide 1 (one revolution): \
                 add the multiple 1/{order} to the excitation's multiples",
                self.ratio * order
            )));
        }
        Ok(())
    }

    /// Sets (or clears) the hook told of every accepted point of the continuations.
    pub fn set_on_point(&mut self, hook: Option<PointHook>) {
        self.on_point = hook;
    }

    /// Whether the spin angle is cyclic (no gravity and no world-frame force).
    pub fn is_cyclic(&self) -> bool {
        self.cyclic
    }

    /// Newton's method at fixed parameters.
    fn solve_at(&mut self, at: &At, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        self.solve_within(at, guess, self.opts.tol)
    }

    /// Newton's method at fixed parameters that also accepts an iterate whose steps stopped
    /// contracting (a step at least half the one before) once they are below `floor` (≥ the
    /// tolerance): beside a branch point ∂R̂/∂x is nearly singular, so rounding leaves steps of
    /// ~1e-10 that no iteration reduces, while the state is as accurate as the problem allows
    /// there. For locating events (the state only decides a count or a sign), never for the
    /// points of a branch.
    pub(super) fn solve_within(
        &mut self,
        at: &At,
        guess: Option<&HbmSolution>,
        floor: f64,
    ) -> Result<HbmSolution, HbmError> {
        let order = at.order;
        self.check_base(order)?;
        let mut x = self.unknowns_from(guess);
        let mut step = f64::INFINITY;
        for it in 1..=self.opts.max_iter {
            self.assemble(&x, at, Some(Parameter::Order));
            let dx = self.factor(None).solve(&self.rhat).ok_or(HbmError::Singular { order })?;
            let last = step;
            step = dx.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            for (xi, d) in x.iter_mut().zip(dx.iter()) {
                *xi -= d;
            }
            if step <= self.opts.tol || (step <= floor && step >= 0.5 * last) {
                return Ok(self.solution_from(&x, at, it));
            }
        }
        Err(HbmError::NoConvergence { order, iterations: self.opts.max_iter, step })
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

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// One-call convenience: the periodic steady state of `kane`'s mechanism at order `order` (see
/// [`Hbm::new`] for the arguments), with its Floquet stability when
/// `options.stability_samples > 0`.
pub fn solve_periodic(
    kane: &Kane,
    spin_joint: usize,
    omega: f64,
    harmonics: &[Harmonic],
    order: f64,
    guess: Option<&HbmSolution>,
    options: HbmOptions,
) -> Result<HbmSolution, HbmError> {
    let mut hbm = Hbm::new(kane, spin_joint, omega, harmonics, options)?;
    let mut sol = hbm.solve(order, guess)?;
    if options.stability_samples > 0 {
        sol.stability = Some(hbm.stability(&sol)?);
    }
    Ok(sol)
}

/// The canonical CPVA at 1000 rpm under one order of amplitude `amplitude` (N·m), with
/// `time_samples` (0: automatic) and the speeds `speeds`: the problem of the unit tests.
#[cfg(test)]
fn test_problem(amplitude: f64, time_samples: usize, speeds: crate::model::speeds::Speeds) -> Hbm {
    let mut mech = crate::cpva::CpvaParams::canonical().mechanism(None).unwrap();
    mech.speeds = speeds;
    let kane = Kane::new(&mech).unwrap();
    let h = [Harmonic { multiple: 1.0, amplitude, phase: 0.0 }];
    let omega = crate::model::excitation::rpm_to_rad_s(1000.0);
    Hbm::new(&kane, 0, omega, &h, HbmOptions { time_samples, ..HbmOptions::default() }).unwrap()
}
