//! The events of a branch: the test functions whose sign changes mark folds, branch points,
//! period doublings and Neimark–Sacker points, and how a crossing is found when a step hides
//! it and located once bracketed: `test_functions` (the functions, the dip of one inside a
//! step, the insertion of a found point), `tongues` (pairs of crossings stepped over whole,
//! by a deep minimum or by a Floquet pair's flipped sense) and `locate` (bisection on the
//! multiplier count, then the root of det ∂R̂/∂x). The rest of the continuation room is above.

mod locate;
mod test_functions;
mod tongues;

pub(in crate::hbm::continuation) use test_functions::{PairSenses, Senses, Tests, dip, test_functions};
