//! What one integration run takes and gives: its options, the samples handed to the caller,
//! the step counters, the completed run and the errors that end one early. Re-exported by
//! [`crate::time::integrate`], where [`crate::time::integrate::integrate`] uses them; the driver
//! loop (`dop853.rs`) fills them in.

use crate::error::EngineError;
use std::fmt;

/// Options of [`crate::time::integrate::integrate`]. `Default` gives rtol = atol = 1e-9, 2 kHz sampling, 10⁸ steps.
#[derive(Debug, Clone, PartialEq)]
pub struct IntegrateOptions {
    /// Relative tolerance of the local error per step (DOP853's mixed norm, Hairer's `rtol`).
    pub rtol: f64,
    /// Absolute tolerance (same units as each state component: rad, rad/s).
    pub atol: f64,
    /// Sample rate fs, Hz: samples at `t0 + k/fs` for every k with `t_k ≤ t1`, including t0 (and
    /// t1 when it falls on the grid). `None`: no samples, only the final state (e.g. Floquet
    /// monodromy columns).
    pub sample_rate_hz: Option<f64>,
    /// Evaluate `ẋ` at every sample state (one extra right-hand-side call per sample, counted in
    /// [`IntegrateStats::sample_rhs_evals`]) and pass it in [`Sample::xdot`]; needed for
    /// accelerations.
    pub sample_derivatives: bool,
    /// Limit on the number of step attempts (accepted + rejected). The crate's default of 10,000
    /// would stop a 240 s sweep after a few seconds of simulated time.
    pub max_steps: usize,
    /// Initial step size, s (`None`: the crate's estimate from f(t0, x0), two extra calls).
    pub h0: Option<f64>,
    /// Largest step size, s (`None`: unbounded).
    pub h_max: Option<f64>,
    /// The watchdog's deadline, past which the run stops with [`IntegrateError::Deadline`]
    /// (`None`: no deadline). The study's watchdog sets it.
    pub deadline: Option<crate::deadline::Deadline>,
    /// The integration method (default [`Method::Dop853`]).
    pub method: Method,
}

/// The integration method of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize, schemars::JsonSchema)]
pub enum Method {
    /// Explicit Dormand–Prince 8(5,3) (DOP853): the cheapest per step, its step bounded by the
    /// stability limit `|hλ| ≲ 5` of the fastest mode as well as by the tolerance.
    #[default]
    Dop853,
    /// Implicit Radau IIA of order 5 (RADAU5): L-stable, its step set by the tolerance alone,
    /// for mechanisms with stiff modes far above the excitation (`src/time/radau.rs`).
    Radau5,
}

impl Default for IntegrateOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-9,
            atol: 1e-9,
            sample_rate_hz: Some(2000.0),
            sample_derivatives: false,
            max_steps: 100_000_000,
            h0: None,
            h_max: None,
            deadline: None,
            method: Method::Dop853,
        }
    }
}

/// Which integrator a study's run used and why (the study's `integration.integrator`, or the
/// `Auto` rule of docs/design/time.md, "Stiff mechanisms: the integrator choice").
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct IntegratorChoice {
    /// The method that ran.
    pub method: Method,
    /// The mechanism's fastest linearised mode, |λ|max/2π, Hz (NaN without a linear model).
    pub fastest_mode_hz: f64,
    /// The step accuracy asks of DOP853 over the step its stability allows (`5/|λ|max`).
    pub stability_ratio: f64,
    /// Why, in words.
    pub reason: String,
}

/// One sample handed to the caller's callback.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Sample index k (t = t0 + k/fs).
    pub k: usize,
    /// Sample time t_k, s.
    pub t: f64,
    /// The state x(t_k) from the DOP853 interpolant (exact at t0).
    pub x: &'a [f64],
    /// `ẋ(t_k) = f(t_k, x(t_k))` when [`IntegrateOptions::sample_derivatives`] is set.
    pub xdot: Option<&'a [f64]>,
}

/// Counters of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, schemars::JsonSchema)]
pub struct IntegrateStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps (error estimate above tolerance, step retried smaller).
    pub rejected: usize,
    /// Right-hand-side evaluations made by the integrator (initial step estimate, stages, and the
    /// three extra dense-output stages of every accepted step).
    pub rhs_evals: usize,
    /// Right-hand-side evaluations at sample states (for accelerations), counted apart.
    pub sample_rhs_evals: usize,
    /// Samples delivered to the callback.
    pub samples: usize,
    /// The method that ran.
    pub method: Method,
}

impl fmt::Display for IntegrateStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} steps accepted, {} rejected, {} rhs evaluations (+{} at samples), {} samples",
            self.accepted, self.rejected, self.rhs_evals, self.sample_rhs_evals, self.samples
        )?;
        if self.method == Method::Radau5 { write!(f, " (Radau IIA)") } else { Ok(()) }
    }
}

/// A completed run.
#[derive(Debug, Clone, PartialEq)]
pub struct Integrated {
    /// Final time (= t1), s.
    pub t_end: f64,
    /// State at t_end.
    pub x_end: Vec<f64>,
    /// Counters.
    pub stats: IntegrateStats,
}

/// Why a run ended early. Every variant names the time reached (the last accepted step) and
/// carries the counters; the samples up to there have already been delivered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntegrateError {
    /// Inconsistent arguments; nothing was integrated.
    #[error("invalid integration input: {message}")]
    InvalidInput {
        /// What is wrong.
        message: String,
    },
    /// The step size fell below what the time resolution allows (a singularity, a discontinuity
    /// or a tolerance tighter than rounding).
    #[error("step size underflow at t = {t_reached} s (h = {h:e} s); {stats}")]
    StepSizeUnderflow {
        /// Time reached, s.
        t_reached: f64,
        /// The step size that was refused, s.
        h: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The state or its derivative became NaN or infinite.
    #[error("non-finite {what} at t = {t_eval} s (integration reached t = {t_reached} s); {stats}")]
    NonFinite {
        /// `state` or `derivative`.
        what: &'static str,
        /// Time of the offending evaluation, s.
        t_eval: f64,
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The step limit [`IntegrateOptions::max_steps`] was hit.
    #[error("step limit of {max_steps} reached at t = {t_reached} s (raise max_steps or loosen rtol); {stats}")]
    MaxSteps {
        /// The limit.
        max_steps: usize,
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The right-hand side failed (e.g. a mass matrix that is not positive definite).
    #[error("equations of motion failed at t = {t_eval} s (integration reached t = {t_reached} s): {source}; {stats}")]
    Engine {
        /// The engine's error.
        source: EngineError,
        /// Time of the failing evaluation, s.
        t_eval: f64,
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The crate's stiffness detector fired (DOP853 is explicit: use a stiff method).
    #[error("problem became stiff at t = {t_reached} s; {stats}")]
    Stiff {
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The implicit method's Newton matrix `I/(γh) − J` was singular at five step sizes in a row
    /// (a Jacobian with NaN, or a step that cannot be solved): the implicit run gives up.
    #[error("implicit solver: singular Newton matrix at t = {t_reached} s (h = {h:e} s); {stats}")]
    SingularNewton {
        /// Time reached, s.
        t_reached: f64,
        /// The step size tried last, s.
        h: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// The run went past [`IntegrateOptions::deadline`]: its analysis overran its time budget.
    #[error(
        "stopped by the watchdog at t = {t_reached} s: {} (a multiple of its planned CPU time, see `kanedyn \
         check`); {stats}",
        crate::deadline::Deadline::overran(*budget_s)
    )]
    Deadline {
        /// The budget, s.
        budget_s: f64,
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
    /// Any other failure reported by the ODE crate.
    #[error("integrator failed at t = {t_reached} s: {message}; {stats}")]
    Solver {
        /// The crate's message.
        message: String,
        /// Time reached, s.
        t_reached: f64,
        /// Counters.
        stats: IntegrateStats,
    },
}

impl IntegrateError {
    /// The time reached (last accepted step), s; `NaN` for invalid input.
    pub fn t_reached(&self) -> f64 {
        match self {
            Self::InvalidInput { .. } => f64::NAN,
            Self::StepSizeUnderflow { t_reached, .. }
            | Self::NonFinite { t_reached, .. }
            | Self::MaxSteps { t_reached, .. }
            | Self::Engine { t_reached, .. }
            | Self::Stiff { t_reached, .. }
            | Self::SingularNewton { t_reached, .. }
            | Self::Deadline { t_reached, .. }
            | Self::Solver { t_reached, .. } => *t_reached,
        }
    }

    /// The counters up to the failure.
    pub fn stats(&self) -> IntegrateStats {
        match self {
            Self::InvalidInput { .. } => IntegrateStats::default(),
            Self::StepSizeUnderflow { stats, .. }
            | Self::NonFinite { stats, .. }
            | Self::MaxSteps { stats, .. }
            | Self::Engine { stats, .. }
            | Self::Stiff { stats, .. }
            | Self::SingularNewton { stats, .. }
            | Self::Deadline { stats, .. }
            | Self::Solver { stats, .. } => *stats,
        }
    }
}
