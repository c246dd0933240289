//! The stability room: Floquet stability of a harmonic-balance solution, the eigenvalues of the
//! monodromy matrix Φ(T) of the variational equations `C δq̈ + B δq̇ + A δq = 0` about the orbit.
//! It holds the analysis (`analysis`: [`Hbm::stability`](crate::hbm::Hbm::stability), the
//! multipliers per block, the pairs' senses), the dense route's RK4 monodromy (`dense`), the
//! tree route's sparse one (`tree`), Butcher's sixth-order method and its step rule
//! (`butcher`), and the eigenvalue kernels (`eigen`). It uses the balance room (the per-sample
//! derivatives of the last Jacobian) and the series room (the solution, the Floquet record,
//! the interpolation).
//!
//! The variational equations of `R(q, q̇, q̈, t) = 0` about the periodic orbit are
//! `C δq̈ + B δq̇ + A δq = 0` with the per-sample derivatives A, B, C of the harmonic balance
//! (`C = M W` is invertible). In the state `z = (δq, δq̇)` they read `ż = 𝒜(t) z`,
//! `𝒜 = [[0, I], [−C⁻¹A, −C⁻¹B]]`. A, B, C are those of the last Jacobian of the harmonic balance
//! at the solution (N_t samples; no new engine calls when the continuation just assembled it);
//! `K = C⁻¹A` and `L = C⁻¹B` are formed at those samples and carried to N_s equally spaced
//! instants of the period T = 2π/ω₀ by trigonometric interpolation, one FFT pair per entry
//! (they are smooth periodic functions, band-limited to far below N_t/2 on the branches
//! checked), and the monodromy matrix Φ(T) is integrated by the classical fourth-order
//! Runge–Kutta method with steps 2T/N_s and 4T/N_s, whose stages fall exactly on the samples
//! (t, t + h/2, t + h), and Richardson-extrapolated, `(16 Φ_h − Φ_2h)/15`, which leaves a
//! sixth-order error. Measured on the canonical CPVA's 40 N·m branch: N_s = 256 agrees with
//! N_s = 2048 to 9e-8 (plain RK4 at 256 was off by 1.7e-5, too close to the margin below),
//! and the multipliers agree with a monodromy matrix differenced from time integrations to
//! 2e-6 (tests/it/hbm.rs).
//!
//! Beyond six coordinates the whole mechanism is integrated by its tree instead (`tree_monodromy`):
//! in the states `(δq, δu)`, `δu = W δq̇`, with A, B W⁻¹ and W⁻¹ kept sparse and the mass matrix
//! `M = C W⁻¹` applied through its LDLᵀ factors, which a leaves-first order leaves as sparse as
//! the tree, at a cost per stage that grows with the tree's non-zeros instead of with n³. There
//! the period is integrated once by Butcher's seven-stage sixth-order Runge–Kutta method
//! (`rk6_period`), from N_s/4 steps up, its coefficients interpolated to a grid of six instants
//! per step (the stages sit at 0, 1/3, 1/2, 2/3 and 1 of a step), instead of the fine and coarse
//! RK4 runs: 448 derivative evaluations instead of 768 at the default N_s = 256, and more
//! accurate on the rotors measured (16 pendulums mistuned by ±1 % at 40 N·m: the multipliers
//! within 2.9e-9–6.9e-9 of a dense monodromy at N_s = 2048, where RK4 with Richardson at
//! N_s = 256 was within 1.1e-8–2.3e-8; unit tests). An explicit method is accurate and stable
//! only while the step times the fastest rate stays small, and Butcher's method leaves the unit
//! disc on the imaginary axis sooner than RK4 with Richardson does: the step count comes from
//! the fastest eigenvalue of the mechanism linearised about its steady spin, computed once per
//! problem (`butcher6_steps`: no less accurate on that mode than RK4 with Richardson, by their
//! stability functions), and where that would take more derivatives than RK4 with Richardson
//! (a stiff shaft, as in the OpenTorsion marine plant) the tree route runs RK4 with Richardson.
//! Either integration is compiled a second time for AVX2 and taken where the processor has it:
//! the same element-wise operations on four doubles instead of two (no fused multiply-adds), so
//! the same bits (a unit test).
//!
//! The spin angle is cyclic: its column of A is zero, so `δq_s` feeds nothing and the column of
//! Φ for it is the unit vector — the trivial multiplier +1 (a shift of the spin angle is again a
//! solution). Deleting that row and column leaves the 2n_dof − 1 physical multipliers. One of
//! them belongs to the mean spin speed and sits just inside the unit circle,
//! `≈ exp(−c_r T / J_locked)` (for the canonical CPVA 1 − 3·10⁻⁵), so the integration must be
//! accurate well below that margin; the tests compare the multipliers with a monodromy matrix
//! obtained by differencing full time integrations.

mod analysis;
mod butcher;
mod dense;
mod eigen;
mod tree;

pub use analysis::solve_periodic;
