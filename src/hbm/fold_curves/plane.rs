//! The plane a fold curve lies in ([`FoldPlane`], scaled as `Plane`), the matrix it keeps
//! singular ([`Singularity`]), its settings and what it returns (points, cusps, extrema, end).

use crate::hbm::balance::{At, Parameter};
use crate::hbm::series::HbmSolution;

/// The plane of a fold curve: the torque scale s and either the excitation order n (at the
/// problem's mean speed) or the mean speed Ω (at a fixed order); or the torque scale against a
/// [`MechanismFamily`](crate::hbm::MechanismFamily)'s p at a fixed order and speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FoldPlane {
    /// (n, s) at the problem's mean speed.
    Order,
    /// (Ω, s) at excitation order `order`.
    Speed {
        /// The fixed excitation order n.
        order: f64,
    },
    /// (s, p) at excitation order `order` and the problem's mean speed: the torque scale is the
    /// first parameter, so the second must be a family's p.
    Torque {
        /// The fixed excitation order n.
        order: f64,
    },
}

/// A plane with the scale of its first parameter: λ = n, or λ = Ω/Ω_ref (so that both
/// parameters and the coefficients in rad weigh alike in the arclength).
#[derive(Debug, Clone, Copy)]
pub(super) struct Plane {
    pub(super) kind: FoldPlane,
    pub(super) p_ref: f64,
    /// Ω of an order plane.
    pub(super) omega: f64,
}

impl Plane {
    pub(super) fn at(&self, lambda: f64, scale: f64) -> At {
        match self.kind {
            FoldPlane::Order => At { order: lambda, omega: self.omega, scale },
            FoldPlane::Speed { order } => At { order, omega: lambda * self.p_ref, scale },
            FoldPlane::Torque { order } => At { order, omega: self.omega, scale: lambda },
        }
    }

    pub(super) fn lambda(&self, at: &At) -> f64 {
        match self.kind {
            FoldPlane::Order => at.order,
            FoldPlane::Speed { .. } => at.omega / self.p_ref,
            FoldPlane::Torque { .. } => at.scale,
        }
    }

    pub(super) fn param(&self) -> Parameter {
        match self.kind {
            FoldPlane::Order => Parameter::Order,
            FoldPlane::Speed { order } => Parameter::Speed { order },
            FoldPlane::Torque { order } => Parameter::TorqueScale { order },
        }
    }

    /// ∂λ/∂(the parameter's own unit): Ω_ref on a speed plane (λ = Ω/Ω_ref), else 1.
    pub(super) fn per_unit(&self) -> f64 {
        match self.kind {
            FoldPlane::Speed { .. } => self.p_ref,
            FoldPlane::Order | FoldPlane::Torque { .. } => 1.0,
        }
    }

    pub(super) fn point(&self, at: &At, arclength: f64, solution: HbmSolution) -> FoldCurvePoint {
        FoldCurvePoint { order: at.order, omega: at.omega, scale: at.scale, parameter: at.scale, arclength, solution }
    }
}

/// One point of a fold curve.
#[derive(Debug, Clone)]
pub struct FoldCurvePoint {
    /// Excitation order n.
    pub order: f64,
    /// Mean speed Ω, rad/s.
    pub omega: f64,
    /// Torque scale s (the excitation amplitudes are s·T_k).
    pub scale: f64,
    /// The plane's second parameter: s on a torque-scale plane, the mechanism parameter p (its
    /// unit) on a [`MechanismFamily`](crate::hbm::MechanismFamily)'s.
    pub parameter: f64,
    /// Arclength along the curve, in the norm of (coefficients in rad, n, s or p / reference).
    pub arclength: f64,
    /// The periodic state at the fold.
    pub solution: HbmSolution,
}

/// A point of a fold curve's plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterPoint {
    /// Excitation order n.
    pub order: f64,
    /// Mean speed Ω, rad/s.
    pub omega: f64,
    /// Torque scale s.
    pub scale: f64,
    /// The plane's second parameter: s, or the mechanism parameter p.
    pub parameter: f64,
}

/// Why a fold curve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoldCurveEnd {
    /// The curve left the (n, s) box it was asked for.
    LeftBox,
    /// The largest number of points was reached.
    MaxPoints,
    /// The corrector failed at every step down to the smallest.
    StepTooSmall,
}

/// A fold curve in (n, s).
#[derive(Debug, Clone)]
pub struct FoldCurve {
    /// The points, in the order followed.
    pub points: Vec<FoldCurvePoint>,
    /// The cusps met, located: two folds meet there, and on the far side in s the response has
    /// no jump (ds/dσ and dn/dσ vanish together along the curve).
    pub cusps: Vec<ParameterPoint>,
    /// The other extrema of s along the curve (dn/dσ not zero there): the least or largest
    /// torque of a jump region's boundary without a cusp (where an isola is born, say).
    pub scale_extrema: Vec<ParameterPoint>,
    /// Why it ended.
    pub end: FoldCurveEnd,
}

/// Settings of a fold-curve continuation.
#[derive(Debug, Clone, Copy)]
pub struct FoldCurveOptions {
    /// Range of the plane's first parameter, n or Ω in rad/s (the curve ends on leaving it).
    pub range: (f64, f64),
    /// Range of the second parameter, the torque scale s or a mechanism parameter p in its
    /// unit (likewise).
    pub scales: (f64, f64),
    /// First and largest arclength step.
    pub ds: f64,
    /// Largest arclength step.
    pub ds_max: f64,
    /// Smallest step before giving up.
    pub ds_min: f64,
    /// Largest number of points.
    pub max_points: usize,
    /// Newton iterations per corrector.
    pub max_iter: usize,
    /// Newton tolerance on the step (max norm, rad and the parameters).
    pub tol: f64,
    /// The matrix kept singular along the curve.
    pub test: Singularity,
}

impl Default for FoldCurveOptions {
    fn default() -> Self {
        Self {
            range: (0.0, f64::INFINITY),
            scales: (0.0, f64::INFINITY),
            ds: 0.01,
            ds_max: 0.05,
            ds_min: 1e-8,
            max_points: 2000,
            max_iter: 12,
            tol: 1e-10,
            test: Singularity::Jacobian,
        }
    }
}

/// Which matrix a curve keeps singular.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Singularity {
    /// The whole Jacobian: folds.
    #[default]
    Jacobian,
    /// The diagonal block of coordinates `first..first + count`: on the unison problem of
    /// identical absorbers (one representative, [`RoutedHbm`](crate::hbm::RoutedHbm)'s reduction),
    /// the representative absorber's own block is the Jacobian of every non-unison wavenumber
    /// (the absorbers couple only through the rotor, which those motions leave alone), so its
    /// singularity is the loss of unison (a +1 branch point of the full set).
    Block {
        /// First coordinate of the block.
        first: usize,
        /// Number of coordinates.
        count: usize,
    },
    /// On the problem of half the base frequency ([`Symmetry::HalfPeriod`](crate::hbm::Symmetry::HalfPeriod)),
    /// the block of the odd harmonics at states of even harmonics only (the period-1 states):
    /// there the odd harmonics decouple from the even ones at linear order, and the odd block is
    /// the Jacobian of the perturbations that change sign every excitation period, so its
    /// singularity is a period doubling (a Floquet multiplier −1 of the period-1 state). The
    /// curve's states are held on the even harmonics (the odd unknowns pinned at zero).
    HalfPeriod,
    /// Both at once: on the half-frequency problem of identical absorbers (one representative),
    /// the odd harmonics of the representative's own block (coordinates `first..first + count`):
    /// the Jacobian of the non-unison perturbations that change sign every excitation period, so
    /// its singularity is a period doubling that also breaks the unison (the absorbers swing at
    /// half the order against each other). The odd unknowns of every coordinate are pinned, as
    /// for [`Singularity::HalfPeriod`].
    HalfPeriodBlock {
        /// First coordinate of the block.
        first: usize,
        /// Number of coordinates.
        count: usize,
    },
}

impl Singularity {
    /// Whether the curve lives on the problem of half the base frequency (its odd unknowns
    /// pinned at zero).
    pub fn on_half_period(self) -> bool {
        matches!(self, Singularity::HalfPeriod | Singularity::HalfPeriodBlock { .. })
    }

    /// The test at half the base frequency of a unison-loss test (`Block` → `HalfPeriodBlock`;
    /// the whole Jacobian → `HalfPeriod`).
    pub fn halved(self) -> Singularity {
        match self {
            Singularity::Block { first, count } | Singularity::HalfPeriodBlock { first, count } => {
                Singularity::HalfPeriodBlock { first, count }
            }
            Singularity::Jacobian | Singularity::HalfPeriod => Singularity::HalfPeriod,
        }
    }
}
