//! The settings of a harmonic-balance problem ([`HbmOptions`]), the failures its solves
//! report ([`HbmError`]) and the progress hook a continuation calls ([`PointHook`]).

/// Failures of the harmonic balance.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HbmError {
    /// The problem is not set up correctly (names the problem).
    #[error("harmonic balance: {0}")]
    Invalid(String),
    /// Newton's method did not converge.
    #[error(
        "harmonic balance at order {order}: Newton did not converge in {iterations} iterations (last step {step:e})"
    )]
    NoConvergence {
        /// Excitation order n.
        order: f64,
        /// Iterations done.
        iterations: usize,
        /// Size of the last Newton step (max norm of the unknowns).
        step: f64,
    },
    /// The Jacobian could not be factorised (a fold at fixed order, or a free coordinate).
    #[error(
        "harmonic balance at order {order}: singular Jacobian (at a fold, or a coordinate without restoring force?)"
    )]
    Singular {
        /// Excitation order n.
        order: f64,
    },
    /// The eigenvalues of the monodromy matrix could not be found within the iteration cap.
    #[error("harmonic balance at order {order}: the Floquet multipliers ({dim} × {dim} monodromy) did not converge")]
    Eigen {
        /// Excitation order n.
        order: f64,
        /// Size of the eigenproblem.
        dim: usize,
    },
    /// The iteration produced a non-finite number.
    #[error("harmonic balance at order {order}: non-finite value (diverged)")]
    NonFinite {
        /// Excitation order n.
        order: f64,
    },
}

/// Numerical settings of the harmonic balance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HbmOptions {
    /// Number of harmonics H of the base frequency ω₀ kept in every coordinate.
    pub harmonics: usize,
    /// Time samples per period N_t for the residual (0: automatic, 4(H + 1)); at least 2H + 1.
    pub time_samples: usize,
    /// Newton tolerance on the step: max norm over the Fourier coefficients (rad) and the scaled
    /// mean torque `T_m / T_scale` (T_scale = max(Σ|T_k|, 1 N·m)).
    pub tol: f64,
    /// Maximum Newton iterations for a solve at fixed order.
    pub max_iter: usize,
    /// Largest acceptable share of the top harmonic (see [`HbmSolution::top_harmonic_ratio`](crate::hbm::HbmSolution::top_harmonic_ratio)).
    pub harmonic_tol: f64,
    /// Largest acceptable share of a joint coupling's force in the harmonics above H (see
    /// [`HbmSolution::coupling_tail`](crate::hbm::HbmSolution::coupling_tail)).
    pub coupling_tol: f64,
    /// Central-difference step for the per-sample derivatives: rad for angles, and relative
    /// (times max(1, |q̇|)) for rates.
    pub fd_step: f64,
    /// Samples per period N_s for the Floquet monodromy (a multiple of 4, ≥ 8; 0 disables
    /// stability): RK4 with steps 2T/N_s and 4T/N_s (T = 2π/ω₀), Richardson-extrapolated, on the
    /// variational equations, whose coefficients are interpolated from the N_t samples of the
    /// harmonic balance.
    pub stability_samples: usize,
}

impl Default for HbmOptions {
    fn default() -> Self {
        Self {
            harmonics: 10,
            time_samples: 0,
            tol: 1e-10,
            max_iter: 30,
            harmonic_tol: 1e-5,
            coupling_tol: 1e-2,
            fd_step: 1e-6,
            stability_samples: 256,
        }
    }
}

/// Called by a continuation after each accepted point with the number of points so far and
/// the continued parameter's value there (its units: n, rad/s or the torque scale), for a
/// progress line. Shared, so that an [`Hbm`](super::problem::Hbm) stays `Clone`.
#[derive(Clone)]
pub struct PointHook(pub std::sync::Arc<dyn Fn(usize, f64) + Send + Sync>);

impl std::fmt::Debug for PointHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PointHook")
    }
}
