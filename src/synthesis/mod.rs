//! Absorber synthesis: the design that minimises a rotor's largest order response over an
//! operating set, under an absorber travel and a margin against the jump, found from exact
//! sensitivities (issue 50).
//!
//! - [`problem`]: the design variables (numbers of a mechanism, each with bounds and a setter),
//!   the operating set (speeds × torque amplitudes at one order), and a design's evaluation: per
//!   speed the branch from rest continued in torque past the operating torques, its first fold
//!   (the jump) located by the minimally augmented system, the operating states polished on the
//!   branch, and every value's gradient by the implicit function theorem (the hbm sensitivity
//!   room: the state's `J dx/dp = −∂R̂/∂p`, the fold's `ds/dp = −wᵀ∂R̂/∂p / wᵀ∂R̂/∂s`).
//! - [`optimise`]: SLSQP on the min–max problem's epigraph form in scaled variables, several
//!   starts on threads, the distinct optima.
//! - [`kkt`]: the multipliers of the active constraints and bounds and the first-order
//!   optimality residual of a reported design.

pub mod kkt;
pub mod optimise;
pub mod problem;

pub use kkt::Kkt;
pub use optimise::{ConstraintValue, Iterate, OptimiseOptions, Optimum, Synthesis};
pub use problem::{Evaluation, JumpValue, OperatingValue, Problem, Setter, SynthesisError, Variable};
