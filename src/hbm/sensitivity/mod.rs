//! The sensitivity room: derivatives of a periodic steady state, and of what is read from it,
//! with respect to any parameter of the balance, by the implicit function theorem on
//! `R̂(x, p) = 0`: `J dx/dp = −∂R̂/∂p`, one factorisation of the Jacobian J = ∂R̂/∂x at the
//! state for every parameter (a back-solve each), not a pair of perturbed Newton solves per
//! parameter. It uses the balance and series rooms; the fold-curves room extends it to singular
//! points (folds, losses of unison, period doublings) on their augmented systems.
//!
//! The parameter is a [`Direction`]: an operating parameter (the order n, the mean speed Ω, the
//! torque scale s), whose ∂R̂/∂p the assembly forms exactly beside the Jacobian, or a design
//! parameter of the mechanism (a mass, a radius, a damping, a path coefficient) through a
//! [`MechanismFamily`](crate::hbm::MechanismFamily). The engine builds a mechanism once and carries no derivative in its
//! data, so a design parameter's ∂R̂/∂p is the central difference of the *residual* at the fixed
//! state between the problems built at p ± h, h = 10⁻⁵ · the family's reference: the residual is
//! smooth in p, the difference errs by O(h²) of its third derivative (and is exact up to
//! rounding where p enters linearly: a mass, an inertia, a damping), and no Newton iteration
//! enters it. This is the semi-analytic form of the direct method: the state's derivative itself
//! comes from the linear solve, not from differences of solutions, whose accuracy would be held
//! to the Newton tolerance and the branch's conditioning.
//!
//! What a state's derivative gives ([`StateSensitivity`]): every Fourier coefficient and the mean
//! torque; a harmonic's amplitude `|c| = (a² + b²)^½` by the chain rule; an order's acceleration
//! amplitude `(hω₀)²|c|` with ω₀'s own derivative where n or Ω moves; a coordinate's true peak
//! `max_τ |p(τ)|` as the derivative of the series at the instant τ* of the peak (p′(τ*) = 0,
//! so τ*'s own motion does not enter: the envelope theorem).

mod state;

pub(in crate::hbm) use state::DESIGN_STEP;
pub use state::{DesignPoint, Direction, StateSensitivity};
