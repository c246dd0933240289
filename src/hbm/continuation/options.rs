//! The settings of a continuation ([`ContinuationOptions`]): its steps, bounds, corrector and
//! events.

/// Settings of the continuation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationOptions {
    /// Initial arclength step (in the norm of (coefficients in rad, scaled parameter λ), the
    /// coefficients of the coordinates other than the spin one weighted by 1/√(n_dof − 1): see
    /// the continuation room's docs).
    pub ds: f64,
    /// Smallest step before giving up.
    pub ds_min: f64,
    /// Largest step. Events do not depend on it: a pair of crossings inside one step (two
    /// pendulums at 500 N·m are unstable only for n ≈ 3.081–3.095) shows as a dip of a test
    /// function, and the step is aimed at it (`tests/it/hbm_events.rs` sweeps 0.1, 0.02, 0.001);
    /// a narrow tongue of period doubling or of loss of unison stepped over whole shows as a
    /// flip of the sense of the Floquet pair near ±1 (the room's docs; `tests/it/hbm_tongue.rs`).
    pub ds_max: f64,
    /// Largest number of points on a branch (a bound on the work, and the plan's: the paper's
    /// branches take 16–60 points at the default `ds_max`, up to ~1600 at 0.001; raise it with a
    /// smaller step).
    pub max_points: usize,
    /// Newton iterations allowed per corrector.
    pub corrector_iter: usize,
    /// Smallest accepted cosine between successive tangents.
    pub min_cos: f64,
    /// Compute the Floquet stability of every point.
    pub stability: bool,
    /// Refine each fold to `|dλ/ds| < 1e-6` by a secant search, and locate each other multiplier
    /// crossing by bisection.
    pub refine_folds: bool,
    /// The watchdog's stop time: past it the branch ends with [`BranchEnd::Watchdog`](crate::hbm::BranchEnd::Watchdog) and the
    /// points it reached (checked before every step; `None`: no deadline).
    pub deadline: Option<crate::deadline::Deadline>,
    /// The corrector's tolerance along the branch, in place of [`HbmOptions::tol`](crate::hbm::HbmOptions::tol)
    /// (None: that one). A branch whose points only serve as starting guesses, each solved again
    /// at the full tolerance where it is used, takes a looser one: the corrector then needs half
    /// the iterations, so the step control lengthens the steps (fewer points, each with one
    /// Jacobian fewer).
    pub corrector_tol: Option<f64>,
    /// Difference the per-sample derivatives one-sidedly along the branch (half the engine
    /// calls of a Jacobian; about 1e-8 relative): for a branch of guesses (with `corrector_tol`),
    /// never where the Jacobian decides a result (stability, located events).
    pub one_sided: bool,
}

impl Default for ContinuationOptions {
    fn default() -> Self {
        Self {
            ds: 0.01,
            ds_min: 1e-7,
            ds_max: 0.1,
            max_points: 2000,
            corrector_iter: 14,
            min_cos: 0.98,
            stability: true,
            refine_folds: true,
            deadline: None,
            corrector_tol: None,
            one_sided: false,
        }
    }
}
