//! The continuation room: pseudo-arclength continuation of the balance `R̂(x, λ) = 0` along a
//! branch, with a quadratic predictor, the bordered Broyden-chord corrector and step control,
//! and the branch's events: folds, and Floquet bifurcations found by sign changes of test
//! functions and located on the multiplier count and det ∂R̂/∂x. It holds the branch data model
//! (`branch`), the options, the walk (`follow`, from the first point over `point`), the folds
//! (`folds`), the event searches (`events`) and the end of a switched branch at the symmetric
//! states (`rejoin`). It uses the stability room (every point's multipliers), the balance room,
//! the series room and the numerics room.
//!
//! Pseudo-arclength continuation of harmonic-balance solutions in a parameter p: the excitation
//! order n, the mean speed Ω (at fixed n) or the torque scale s (at fixed n; every oscillating
//! amplitude T_k becomes s·T_k), see [`Parameter`](crate::hbm::Parameter).
//!
//! The branch is the curve `R̂(x, λ) = 0` in the space `y = (w ⊙ x, λ)` of the Fourier unknowns
//! (rad; the scaled mean torque) and the scaled parameter `λ = p / p_ref` (p_ref = 1 for n and s,
//! the starting speed for Ω, so that arclength steps mean the same for each). The weights w are
//! 1 on the spin coordinate's unknowns and 1/√(n_dof − 1) on every other coordinate's: the
//! arclength measures the root mean square of the other coordinates, so that N absorbers moving
//! alike take the steps of one instead of steps 1/√N as long in the parameter (two coordinates,
//! the paper's rotor, have weight 1). ∂R̂/∂p is exact (see
//! the balance room's docs). From a point y with unit tangent t, the predictor is
//! `y + Δs t + ½ Δs² κ` with the curvature κ estimated from the change of the tangent over the
//! last step, and the corrector solves `R̂ = 0` together with `tᵀ(y − y_pred) = 0` on the
//! bordered Jacobian `[[∂R̂/∂x, ∂R̂/∂λ], [tᵀ]]`, which stays regular through turning points. The
//! new tangent solves `[[∂R̂/∂x, ∂R̂/∂n], [t_oldᵀ]] t = [0, 1]` (so it keeps the orientation),
//! normalised.
//!
//! The corrector is a Newton–chord iteration with Broyden updates: it starts from the bordered
//! matrix factorised at the previous point (its Jacobian is needed there anyway for the tangent
//! and the stability; bordered by the new tangent through a rank-one update of the tangent's
//! factorisation) and improves it by good-Broyden rank-one updates kept as step vectors, so an
//! iteration costs one residual; when a step contracts by less than half, the Jacobian is
//! refreshed at the current iterate (at most 3 times) and the updates restart. With light damping
//! the Jacobian changes quickly along the branch near resonance, so about one refresh per point
//! is typical there. (The bordered systems and both correctors are in the balance room's `corrector`.)
//!
//! Step control: the step grows by 1.5 after a corrector of at most 7 iterations with at most
//! one refresh, and shrinks by 0.7 after 10 iterations or 3 refreshes; a failed corrector, or a
//! tangent that turned by more than `acos(min_cos)`, halves the step and retries (the turning
//! guard keeps the corrector from jumping to a neighbouring branch near a fold). Between the
//! points, [`Branch::interpolate`](crate::hbm::Branch::interpolate) gives cubic Hermite states from the stored tangents.
//!
//! Folds are the points where `dλ/ds` changes sign: there the branch turns back in p and a sweep
//! in p jumps, so the fold orders of an order branch are the jump orders of the paper's up- and
//! down-sweeps (Figs. 3, 4). Each detected fold is refined by a bracketing secant search
//! (Illinois) on `dλ/ds = 0` along the arclength. A fold's own real multiplier passes +1 there,
//! so a second crossing of +1 in the fold's step (a loss of unison beside the fold) leaves
//! Π(μ − 1) with one sign at both ends; it shows instead as an even change of the count of
//! multipliers outside the unit circle across the step, and a state between it and the fold is
//! searched for and inserted as a point (`fold_partner`).
//!
//! Events at any step. Each point carries test functions: dλ/ds, and per Floquet block the
//! products Π(μ − 1), Π(μ + 1) and Π_{i<j}(μ_i μ_j − 1), whose sign changes mark a fold or
//! branch point, a period doubling and a Neimark–Sacker point (the classical test functions of
//! periodic orbits, as in Seydel's *Practical Bifurcation and Stability Analysis*). A pair of
//! crossings inside one step leaves every sign unchanged; the quadratic through the test
//! function's last three values then has an extremum of the other sign inside the step, and the
//! step is shortened to land on it (once per step, by at most 5×, not below a floor), so the two
//! crossings become sign changes between accepted points.
//!
//! A narrow tongue (a pair through −1 and back: a Mathieu tongue of period doubling; or through
//! +1 and back: a short loss of unison) can still fit inside one step without a dip the
//! quadratic sees. Such a pair is told by its sense of turning instead: for every complex pair
//! of a Floquet block within ½ of ±1 (a cheap screen: elsewhere nothing is computed), the
//! eigenvector v of the member with Im μ > 0 is found by inverse iteration on the block's
//! monodromy, and the sign of `Σ_k Im(conj(v_qk) v_uk)` over the coordinates (angle and rate of
//! each) says which way the motion turns in its phase planes (phase-invariant). Across a tongue
//! the pair's rotation number ωT/2π passes ½ (or an integer), the member with Im μ > 0 becomes
//! the conjugate of the old one and the sign flips; a pair that comes near ±1 and leaves keeps
//! it (for lightly damped motion the sign changes only where the pair meets on the real axis,
//! like a Krein signature). The same pair is recognised at the next point that holds
//! it (up to three points on, the ones in between holding it on the real axis) by its
//! eigenvector, parallel up to conjugation. Where the sense flipped but the block's Π(μ ± 1)
//! kept its sign, the segment is bisected on the sense (states from [`Branch::interpolate`](crate::hbm::Branch::interpolate)
//! solved at the fixed parameter) until a state inside the tongue is found, or one with the
//! pair on the real axis (the real stretch is a little wider than the tongue), from which a
//! golden section on the test function's magnitude finds the tongue; that state is inserted as
//! a point, so the tongue's two edges are sign changes between accepted points (pairs met on the
//! real axis inside the unit circle flip the sense too and cost a search that finds nothing).
//! Last, where a test function's magnitude has a deep minimum at an accepted point, and so has
//! its factor nearest to zero, the two segments around it are searched the same way by golden
//! section.
//!
//! Crossings are bracketed by the count of multipliers outside the unit circle (bisection along
//! the segment); a branch point is then located on det ∂R̂/∂x, which vanishes there exactly for
//! the truncated problem, at its own sign change (searched outward from the count's bracket when
//! the monodromy's error put the count's crossing beside it). Beside a branch point Newton's
//! steps at fixed parameter stall above the tolerance; while locating, a solve whose steps stop
//! contracting below 1000× the tolerance is taken as converged (`solve_within`).

mod branch;
mod events;
mod folds;
mod follow;
mod options;
mod point;
mod rejoin;

pub use branch::{Bifurcation, BifurcationClass, BifurcationKind, Branch, BranchEnd, BranchPoint, Fold, FoldKind};
pub use follow::continue_in_order;
pub use options::ContinuationOptions;
pub(in crate::hbm) use point::Cursor;
