//! The switch room: branch switching at a symmetry-breaking branch point by the null vector
//! of ∂R̂/∂x (Seydel, §5.6), onto the non-symmetric branch, which the continuation room then
//! follows. It uses the continuation room (the walk and its return to the symmetric states),
//! the balance room (the corrector, the symmetries) and the series room.
//!
//! Branch switching at a symmetry-breaking branch point (a Floquet multiplier through +1 of a
//! symmetric, e.g. unison, branch that is not a fold): the start of the branch of non-symmetric
//! solutions that crosses the symmetric one there, followed by the ordinary continuation.
//!
//! Two symmetries S ([`Symmetry`](crate::hbm::Symmetry)) are broken this way:
//! - a permutation P of identical absorbers: the unison branch's +1 branch points, where the
//!   non-unison branch starts;
//! - the shift by half the base period on the problem of half the base frequency (twice the
//!   period of the excitation): there the period-1 states are those with even harmonics only,
//!   their odd harmonics decouple at linear order, and a period doubling of the period-1 branch
//!   (a multiplier through −1) is a branch point whose null vector holds odd harmonics only. The
//!   branch switched there is the period-doubled one (the subharmonic of order n/2), and its
//!   return to the symmetric states is a return to the period-1 branch (at another period
//!   doubling). A period-1 guess is carried to the doubled problem (harmonic h becomes 2h).
//!
//! The method (a pitchfork of a problem equivariant under S; Seydel, *Practical Bifurcation and
//! Stability Analysis*, §5.6, "branch switching by the null vector"), written below for the
//! permutation P; for the half-period shift read S for P:
//!
//! 1. The symmetric solution y* at the located branch point is solved by Newton at the fixed
//!    parameter from the symmetric branch's point, each step projected on the symmetric states,
//!    Δx ← (Δx + P Δx)/2, so that no round-off of the nearly singular solve leaks into the
//!    antisymmetric directions (the symmetric problem is regular there).
//! 2. The null vector φ of ∂R̂/∂x there: the right singular vector of the smallest singular value
//!    of the dense Jacobian (the sets where switching is asked are small: three coordinates for
//!    two pendulums). It must be antisymmetric (Pφ = −φ; a symmetric null vector is a fold, not
//!    a symmetry breaking) and isolated: σ₁ ≤ 1e-3 σ₂ (a one-dimensional kernel; more identical
//!    absorbers than two give a kernel of dimension two, which this method does not split).
//!    Because the unison branch's tangent is symmetric, φ is orthogonal to it.
//! 3. Predictor y* + ε φ with ε = 2 % of the weighted norm of the non-spin unknowns of y* (the
//!    absorbers' root-mean-square amplitude in rad): large enough that the corrector cannot
//!    return to the symmetric branch (it is held on the hyperplane φᵀ(y − y_pred) = 0, which
//!    the symmetric states cross only at φ-coordinate 0, ε away), small enough that the new
//!    branch's parameter is still within ~1e-5 of the branch point (it moves as ε²).
//! 4. One pseudo-arclength correction on that hyperplane, the parameter free, then the ordinary
//!    continuation ([`Hbm::continue_in`](crate::hbm::Hbm::continue_in)'s loop, with its events and stability) with the tangent
//!    oriented along +φ, i.e. away from the branch point. By the symmetry the branch started
//!    along −φ is the mirror image (the absorbers swapped), so one side is followed.
//!
//! The switched branch ends where the parameter leaves the range, at any of the ordinary ends,
//! or where it returns to the symmetric states ([`BranchEnd::Unison`](crate::hbm::BranchEnd::Unison)): φᵀx
//! vanishes on every symmetric state (Pφ = −φ), so its change of sign between two points marks
//! the return; it is located by an Illinois search on φᵀx along the step and accepted when the
//! state found is symmetric to 1e-3 of its size (else the branch only crossed the hyperplane
//! φᵀx = 0 elsewhere, and it goes on). Past that point the continuation would follow the mirror
//! image of the same branch back.

mod null_vector;
