//! The backbone room: free periodic orbits (backbones) of an absorber by harmonic balance, the
//! unforced, undamped balance with the order as an unknown, closed by a phase condition and an
//! amplitude condition and unfolded after Muñoz-Almaraz et al. (2003), continued in amplitude by
//! natural continuation (`orbit`). It uses the balance and series rooms.
//!
//! Free periodic orbits (backbones) by harmonic balance with a phase condition, continued in
//! amplitude by natural continuation: the undamped, unforced periodic motions of an absorber
//! joint with the spin held or free.
//!
//! # Formulation
//!
//! The problem is the forced one of the balance room without excitation and without dampers (build
//! the [`Hbm`](crate::hbm::Hbm) from a mechanism whose dampers and joint torques are removed, with no harmonics):
//! `q_s = Ωt + p_s(τ)`, `q_k = p_k(τ)`, τ = ω₀t, ω₀ = nΩ, and n, the order of the free
//! oscillation, is now an unknown. Ω stays fixed: the equations of a mechanism without gravity,
//! springs to ground or applied torques are invariant under the time scaling t → ct (all
//! speeds × 1/c), so the orbits at another mean speed are these ones slowed or sped up and their
//! order n = ω₀/Ω is the same. Fixing Ω fixes the angular momentum level and loses nothing.
//!
//! The unknowns are the Fourier coefficients, the order n and two unfolding parameters; the
//! equations are the balanced residual and two scalar conditions at τ = 0 on the released joint
//! j (its coordinate's index `coord`):
//!
//! - phase condition `ṗ_j(0) = Σ_h h b_jh = 0`: the orbit's time origin is a turning point of the
//!   joint (an autonomous orbit shifted in time is an orbit; this picks one);
//! - amplitude condition `p_j(0) = a_j0 + Σ_h a_jh = A`: the joint is at A at that turning point,
//!   which is what the time route's "released from rest at A" means, point for point.
//!
//! A conservative system's periodic orbits come in families, so the balanced residual is
//! dependent (its combination with the velocities is the time derivative of the energy, zero
//! over a period whatever the coefficients). Following Muñoz-Almaraz et al. (2003) the dependence
//! is unfolded by a parameter that breaks the conserved quantity: a dissipation `ε` (a unit
//! viscous damper on every joint other than the spin, internal, so it leaves the angular
//! momentum alone) for the energy, and with a free rotor the rotor's mean torque T_m (the forced
//! problem's unknown in the spin's gauge slot) for the angular momentum. On an orbit both are
//! zero (to the aliasing of the discrete transforms); they are returned as a check. The system is
//! square: `n_dof(2H + 1) + 2` unknowns and equations, solved by Newton's method with a dense LU
//! (small mechanisms: an absorber and its rotor).
//!
//! - `Spin::Free`: every coordinate is balanced; the rotor's mean angle is the gauge (0) and
//!   its oscillation p_s is solved with the absorber's, so the mean rotor speed is Ω exactly.
//! - `Spin::Held`: the spin coordinate is prescribed, p_s ≡ 0 (and T_m), and the spin's
//!   equations are dropped (the torque that holds the speed is whatever it is).
//!
//! # Continuation
//!
//! [`Hbm::backbone`](crate::hbm::Hbm::backbone) starts each sign of amplitude at a small amplitude from the linear mode
//! (order and shape from the linear analysis) and steps the amplitude to each requested value
//! in steps no larger than `max_step`, each Newton solve predicted by the secant through the two
//! previous orbits (natural continuation in the amplitude: the backbone of an absorber has no
//! fold in amplitude below the top of its travel), halving a step that fails.

mod orbit;

pub use orbit::{BackboneOptions, FreeOrbit, FreeSpin, FreeStart};
