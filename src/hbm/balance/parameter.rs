//! Where the balance is evaluated ([`At`]: order, mean speed, torque scale) and which of those
//! a continuation varies ([`Parameter`]), which also names the derivative ∂R̂/∂p the assembly
//! forms beside the Jacobian.

use crate::hbm::series::HbmSolution;

/// Where the residual is evaluated: excitation order n, mean speed Ω (rad/s), torque scale s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct At {
    pub(crate) order: f64,
    pub(crate) omega: f64,
    pub(crate) scale: f64,
}

/// The parameter continued along a branch; the others keep the values of the
/// [`Hbm`](crate::hbm::Hbm) problem ([`Hbm::omega`](crate::hbm::Hbm::omega),
/// [`Hbm::torque_scale`](crate::hbm::Hbm::torque_scale)) unless the variant fixes them. Its kind
/// also names the derivative ∂R̂/∂p that the Jacobian assembly forms. (A study file names it,
/// with its range in the spec's units, as `study::HbmParameter`.)
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Parameter {
    /// The excitation order n (dimensionless).
    Order,
    /// The mean speed Ω in rad/s, at the fixed excitation order `order`.
    Speed {
        /// Excitation order n held fixed.
        order: f64,
    },
    /// The torque scale s (dimensionless; the oscillating amplitudes are s·T_k), at the fixed
    /// excitation order `order`.
    TorqueScale {
        /// Excitation order n held fixed.
        order: f64,
    },
}

impl Parameter {
    /// The value of this parameter in a solution: its order n, mean speed Ω (rad/s) or torque
    /// scale s.
    pub fn value(self, sol: &HbmSolution) -> f64 {
        match self {
            Parameter::Order => sol.order,
            Parameter::Speed { .. } => sol.omega,
            Parameter::TorqueScale { .. } => sol.torque_scale,
        }
    }
}
