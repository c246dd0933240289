//! The fold-curves room: two-parameter continuation of the balance's singular points by the
//! minimally augmented system `R̂ = 0, g = 0` (Govaerts 2000): fold curves (the jump boundaries
//! of a response), unison-loss curves on a representative's block and period-doubling curves on
//! the half-frequency problem, with their cusps and torque extrema. It holds the plane and the
//! tested matrix (`plane`), the augmented system (`augmented`), single singular points
//! (`points`), a singular point's derivative along a third parameter (`sensitivity`) and the
//! curve's walk (`curve`). It uses the balance, sensitivity, series and numerics rooms (a
//! mechanism parameter's family of problems lives in the balance room).
//!
//! Two-parameter continuation of folds of the harmonic balance in (excitation order n or mean
//! speed Ω, torque scale s or a mechanism parameter p): the jump boundary of a response in the
//! (order, torque) plane, and its cusp, where the two folds of a jump meet and the jump
//! disappears.
//!
//! A fold of a branch in n at fixed s is a point where the Jacobian `J = ∂R̂/∂x` of the balance
//! is singular. It is followed by the minimally augmented system (Govaerts, *Numerical Methods
//! for Bifurcations of Dynamical Equilibria*, SIAM 2000, §4.3.2): with vectors b and c that keep
//! the bordered matrix regular,
//!
//! `[[J, b], [cᵀ, 0]] [v; g] = [0; 1]`, `[[Jᵀ, c], [bᵀ, 0]] [w; g] = [0; 1]`,
//!
//! g(x, n, s) vanishes exactly where J is singular, and the fold curve is the solution set of the
//! m + 1 equations `R̂(x, n, s) = 0, g(x, n, s) = 0` in the m + 2 unknowns (x, n, s), followed by
//! pseudo-arclength continuation. The derivatives of g are `∂g/∂z = −wᵀ (∂J/∂z) v`: for the
//! unknowns, `−wᵀ (J(x + hv) − J(x − hv)) / 2h` (the symmetry of second derivatives turns the
//! directional derivative of J along v into the difference of two Jacobians); for the order, the
//! same difference of `∂R̂/∂n`; for the torque scale, zero, since s multiplies the excitation,
//! which does not depend on x. Newton's iterates take the one-sided difference from J(x), which
//! they have anyway (one Jacobian instead of two; g itself is exact, so the point converged to
//! is the same), and stop once the contraction shows the next step below the tolerance
//! (`settled`); on a fold curve their (m + 2)-square matrix is solved by block elimination on
//! the bordered matrix that g already factorised (`NewtonLu`); the tangents that locate a
//! turning point of s take central differences and the whole matrix. After
//! every point b and c take the new w and v, so the bordered
//! matrices stay far from singular along the curve. A step is retried shorter when the tangent
//! turned by more than acos 0.95 or the tested block's null vector by more than acos `NULL_TURN`
//! (the corrector has then landed on a neighbouring curve, as near an onset whose two legs are
//! close in state).
//!
//! Period doublings are followed the same way on the problem of half the base frequency
//! (`Singularity::HalfPeriod`): at its states of even harmonics only (the period-1 states) the
//! odd harmonics decouple, and g is built on the odd-harmonic block of J, whose singularity is a
//! Floquet multiplier −1; the odd unknowns are pinned at zero, so the curve stays on the
//! period-1 states. Along an order-torque curve of a parametric resonance the least torque is
//! the tongue's tip (an extremum of s that is not a cusp).
//!
//! The second parameter may also be a mechanism parameter p (a pivot's damping, an absorber's
//! tuning) at a fixed torque scale, through a [`MechanismFamily`] that builds the problem at any p:
//! the same system with ∂R̂/∂p and `∂g/∂p = −wᵀ (∂J/∂p) v` by differences between problems
//! built at p ± h (one-sided in Newton's iterates, as for x), as the mechanism offers no
//! derivative in p (see its docs).
//!
//! Along the curve s has a minimum at a cusp (there the projection of the fold curve on the
//! (n, s) plane has its spike: in the normal form `x³ − s x − n = 0` the folds are
//! `s = 3x², n = −2x³`): a sign change of ds/dσ between points, located by a secant search
//! on ds/dσ to |ds/dσ| ≤ 1e-10; a cusp when dn/dσ vanishes with it.

mod augmented;
mod curve;
mod plane;
mod points;
mod sensitivity;

pub use plane::{FoldCurve, FoldCurveEnd, FoldCurveOptions, FoldCurvePoint, FoldPlane, ParameterPoint, Singularity};
pub use sensitivity::SingularSensitivity;
