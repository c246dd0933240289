//! The cyclic room: the cyclic-symmetry route of the harmonic balance, N identical absorbers
//! solved by one scaled representative (the unison response, exact) plus one small Floquet
//! block per identical set for the non-unison wavenumbers. It holds the detection of identical
//! sets and the route (`detect`), the reduced mechanism (`reduce`) and [`RoutedHbm`], which
//! solves, continues and analyses the reduced problem and returns full-size results
//! (`routed`). It uses the continuation, stability, balance and series rooms.
//!
//! # Method
//!
//! Take N identical subtrees (absorbers) hanging from one parent body whose origin is fixed in
//! the world (every joint from ground to it is revolute or fixed, and all but the root sit at
//! their parent's origin): same topology, joint kinds, masses, inertias, springs, dampers,
//! couplings and own torques, differing only by a rotation θ_j of their whole geometry about the
//! parent's origin (joint points, centres of mass, slide axes and path mounts turned by θ_j).
//! Without gravity or world-frame forces a member's equations do not depend on θ_j, and the
//! parent and every ancestor feel a member only through its torque about that fixed origin,
//! which does not depend on θ_j either. Hence:
//!
//! 1. **Unison.** In a motion where every member has the same coordinates, the ancestors feel N
//!    times one member. Every term of a member's equations (inertia, springs, dampers,
//!    couplings, own torques) is linear in its mass, inertia and force parameters, so one
//!    *representative* with all of them multiplied by N has N times one member's equations,
//!    which have the same solutions, and exerts N times its torque on the parent. The harmonic
//!    balance of the *reduced* mechanism (the others removed) is therefore the unison response
//!    exactly, not approximately; [`RoutedHbm`] expands each solution to the full mechanism
//!    (every member gets the representative's Fourier coefficients), so every consumer sees a
//!    full-size [`HbmSolution`](crate::hbm::HbmSolution).
//! 2. **Non-unison stability.** A member's rows of the variational equations
//!    `C δq̈ + B δq̇ + A δq = 0` involve only its own coordinates and its ancestors' (a speed's
//!    partial velocities are non-zero only on the bodies it moves, for joint rates and absolute
//!    angular velocities alike), and the ancestors' rows see the members only through
//!    `Σ_j δq_j`, each member entering with the same coefficients in unison. Deviations with
//!    `Σ_j δq_j = 0` and the ancestors held therefore solve the equations: each member then obeys
//!    `C_ss δq̈ + B_ss δq̇ + A_ss δq = 0` with its own rows and columns only, the same for every
//!    member and, up to the common factor N, the representative's rows and columns of the
//!    reduced problem. Its 2m multipliers (m coordinates per member) stand for the N − 1
//!    independent non-unison combinations (the wavenumbers k = 1..N−1 of the set's discrete
//!    Fourier transform), and the reduced problem's own multipliers are the unison ones: together
//!    `2(n_reduced) − 1 + 2m(N − 1) = 2n − 1`, the general route's count. Members are coupled only
//!    through the parent (a joint's spring, damper and couplings act inside it), so one block
//!    serves all k ≠ 0.
//!
//! The monodromy of the full problem has these multipliers with multiplicity N − 1; the general
//! route must resolve them from a 2n × 2n eigenproblem (and locates their crossings on the
//! repeated values), the cyclic route computes them once from a 2m × 2m one.
//!
//! # Detection
//!
//! [`detect`](fn@detect) groups the children of each eligible parent by their shape (subtree topology and
//! joint kinds). A group of two or more whose members are all identical to the first becomes a
//! [`CyclicSet`]; a group whose members are alike but not identical is a mistuned set, and the
//! whole mechanism takes the general route (it stays the reference), as it does with gravity or
//! a world-frame force, with gears, with a point force on a member, or with an excitation input
//! inside a member. Identical means: joint kinds, path shapes, couplings, rollers and own torques
//! equal; scalars (masses, inertias, stiffnesses, dampers, free angles, ground dampers) equal to
//! a relative 1e-12; vectors equal after the rotation θ_j (found from the first non-zero vector)
//! to 1e-12 of the members' largest vector. Splitting one mass over N pendulums, or placing
//! them by `cos`/`sin` of 2πj/N, differs from exact by a few roundings (≈1e-16 relative), far
//! inside; a deliberate mistuning of 1e-9 (to run the general solver on a set) is far outside.
//! The tolerance is harmless on the other side too: a difference of 1e-12 in a parameter moves
//! the solution and its (non-defective, symmetry-repeated) multipliers by O(1e-12), two

mod detect;
mod reduce;
mod routed;

pub use detect::{CyclicSet, Route, detect, route_for};
pub use routed::RoutedHbm;
