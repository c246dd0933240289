//! Harmonic balance (HBM) for periodic steady states under order excitation, with pseudo-arclength
//! continuation in the excitation order, the mean speed or the torque amplitude, and Floquet
//! stability: the faster route to the steady responses that the paper obtains by long time
//! integration (sections 4 and 5; its conclusion names harmonic balance as the method to come).
//!
//! The method lives in rooms, each a folder that imports only the rooms below it; their public
//! items are re-exported here, so every path `crate::hbm::X` is the one to use. Design notes:
//! `docs/design/hbm.md` (the rooms) and `docs/design/hbm-notes.md` (four of them in detail). From
//! the ground up:
//!
//! - **numerics**: the kernels the method rests on and that know nothing of it: dense LU with
//!   a transposed solve, block Gaussian elimination along the mechanism's tree with its Schur
//!   complements, and the Illinois variant of regula falsi.
//! - **series**: one periodic state as truncated Fourier series in every coordinate
//!   ([`HbmSolution`]) and what is read from it: the real FFTs of alternating frequency/time,
//!   trigonometric interpolation, harmonic amplitudes, true peaks by Clenshaw's recurrence,
//!   element torques, joint reactions as order harmonics ([`ReactionHarmonics`]), and the
//!   Floquet record a solution carries ([`Stability`]).
//! - **balance**: the problem [`Hbm`] and its equations, the Galerkin projection
//!   `R̂(x, p) = 0` of Kane's equations evaluated by alternating frequency/time, with the
//!   spectral Jacobian and ∂R̂/∂p; Newton's method at fixed parameters and the pseudo-arclength
//!   corrector on the bordered Jacobian; the continued [`Parameter`] and the [`Symmetry`] a
//!   branch switch breaks. Its docs hold the formulation (unknowns, gauge, residual, Jacobian,
//!   harmonic count).
//! - **sensitivity**: derivatives of a state and its read-outs along an operating or a design
//!   parameter ([`Direction`]) by the implicit function theorem on `R̂(x, p) = 0`, one
//!   factorisation of ∂R̂/∂x for every parameter ([`Hbm::state_sensitivities`],
//!   [`StateSensitivity`]).
//! - **stability**: Floquet multipliers, the eigenvalues of the monodromy matrix of the
//!   variational equations `C δq̈ + B δq̇ + A δq = 0`, integrated densely by RK4 with
//!   Richardson's extrapolation or, on a large tree, sparsely by Butcher's sixth-order method
//!   ([`Hbm::stability`], [`solve_periodic`]).
//! - **continuation**: the branch ([`Branch`]) by pseudo-arclength continuation with a quadratic
//!   predictor, a Broyden-chord corrector and step control ([`Hbm::continue_in`]); its folds, and
//!   its Floquet bifurcations found by the sign changes of test functions and located on the
//!   multiplier count and det ∂R̂/∂x.
//! - **fold_curves**: two-parameter curves of singular points by the minimally augmented system
//!   `R̂ = 0, g = 0`: folds (jump boundaries) with their cusps, losses of unison and period
//!   doublings ([`Hbm::continue_fold`], [`FoldCurve`]).
//! - **backbone**: free periodic orbits of an absorber with a phase condition, unfolded by a
//!   dissipation, continued in amplitude ([`Hbm::backbone`], [`FreeOrbit`]).
//! - **cyclic**: the cyclic-symmetry route, N identical absorbers solved by one scaled
//!   representative plus one non-unison Floquet block per set ([`RoutedHbm`], [`Route`]).
//! - **switch**: branch switching at a symmetry-breaking branch point by the antisymmetric null
//!   vector of ∂R̂/∂x, onto the non-unison or the period-doubled branch ([`Hbm::switch_at`]).
//!
//! The stability, continuation, fold-curve, backbone and switch rooms extend [`Hbm`] with
//! `impl` blocks of their own; the balance room that defines it never calls into them.

mod backbone;
mod balance;
mod continuation;
mod cyclic;
mod fold_curves;
mod numerics;
mod sensitivity;
mod series;
mod stability;
mod switch;

pub use backbone::{BackboneOptions, FreeOrbit, FreeSpin, FreeStart};
pub use balance::{Hbm, HbmError, HbmOptions, MechanismFamily, Parameter, PointHook, Symmetry};
pub use continuation::{
    Bifurcation, BifurcationClass, BifurcationKind, Branch, BranchEnd, BranchPoint, ContinuationOptions, Fold,
    FoldKind, continue_in_order,
};
pub use cyclic::{CyclicSet, Route, RoutedHbm, detect, route_for};
pub use fold_curves::{
    FoldCurve, FoldCurveEnd, FoldCurveOptions, FoldCurvePoint, FoldPlane, ParameterPoint, SingularSensitivity,
    Singularity,
};
pub use sensitivity::{DesignPoint, Direction, StateSensitivity};
pub use series::{FloquetBlock, HbmSolution, MeshTorqueHarmonics, ReactionHarmonics, Stability};
pub use stability::solve_periodic;
