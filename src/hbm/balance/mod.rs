//! The balance room: the harmonic-balance problem [`Hbm`] and the equations it solves, the
//! Galerkin projection `R̂(x, p) = 0` of Kane's equations on a truncated Fourier series, by
//! alternating frequency/time. It holds the problem's construction (`build`), the per-sample
//! evaluator of the residual and its derivatives (`sample`), the AFT residual and the spectral
//! Jacobian with ∂R̂/∂p (`assembly`), Newton's method at fixed parameters (`newton`), and the
//! pseudo-arclength corrector on the bordered Jacobian that the continuation, the branch switch
//! and the event location step with (`corrector`), with the continued [`Parameter`], the
//! symmetries a branch switch breaks ([`Symmetry`]), the options and the errors. It uses the
//! series room (the solution record, the FFTs) and the numerics room (the factorisations).
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
//! [`HbmSolution::top_harmonic_ratio`](crate::hbm::HbmSolution::top_harmonic_ratio) is the share of the top harmonic in the acceleration
//! spectrum of each coordinate, `H² |c_H| / (Σ_h h⁴ |c_h|²)^½`, maximised over the coordinates;
//! when it exceeds [`HbmOptions::harmonic_tol`], more harmonics are needed
//! ([`HbmSolution::needs_more_harmonics`](crate::hbm::HbmSolution::needs_more_harmonics)).
//!
//! The joint couplings (staged springs, friction, end stops; [`crate::model::coupling`]) are not
//! smooth: they go through the AFT like every force, sampled at the N_t instants, but their
//! spectra decay slowly (as 1/h² past a kink, 1/h for friction close to Coulomb's). Their own
//! indicator, [`HbmSolution::coupling_tail`](crate::hbm::HbmSolution::coupling_tail), is the share of each coupling force's oscillating
//! content (its discrete spectrum up to N_t/2 from the same samples) that lies above H, where
//! the balance drops it: `(Σ_{h>H} |F_h|² / Σ_{h≥1} |F_h|²)^½`. Above
//! [`HbmOptions::coupling_tol`] the solution needs more harmonics too, and a study's summary says
//! so. The response converges faster than this share (the dynamics filter the dropped force by
//! about 1/h²), so the indicator is on the safe side.

mod assembly;
mod build;
mod corrector;
mod family;
mod newton;
mod options;
mod parameter;
mod problem;
mod sample;
mod symmetry;

pub(in crate::hbm) use corrector::{Chord, Setup};
pub use family::MechanismFamily;
pub(in crate::hbm) use family::{Built, on_family, problem};
pub use options::{HbmError, HbmOptions, PointHook};
pub(crate) use parameter::At;
pub use parameter::Parameter;
pub use problem::Hbm;
pub(crate) use problem::NonUnison;
pub use symmetry::Symmetry;

#[cfg(test)]
pub(in crate::hbm) use build::test_problem;
