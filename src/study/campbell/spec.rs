//! The Campbell diagram as written in the study file.

use serde::{Deserialize, Serialize};

/// A Campbell diagram: damped natural frequencies over a speed range, modes tracked by shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CampbellSpec {
    /// Name (file prefix).
    pub name: String,
    /// Lowest speed, rpm.
    pub rpm_min: f64,
    /// Highest speed, rpm.
    pub rpm_max: f64,
    /// Number of speeds (default 61).
    #[serde(default = "default_campbell_points")]
    pub points: usize,
    /// Engine orders drawn as lines `f = n·rpm/60` (default 1.5, 3, 4.5, 6).
    #[serde(default = "default_engine_orders")]
    pub orders: Vec<f64>,
    /// Hold the spin speed (prescribed) instead of leaving it free (default false).
    #[serde(default)]
    pub spin_held: bool,
    /// Damped frequencies |Im λ|/2π instead of the undamped natural frequencies (default false:
    /// a Campbell diagram shows the undamped ones, whose order lines are exact).
    #[serde(default)]
    pub damped: bool,
    /// Modal damping, by default in place of the mechanism's dampers (`All(ζ)` or `PerMode([…])`, modes
    /// taken with the spin as `spin_held` says); the frequencies are then the damped ones.
    #[serde(default)]
    pub modal_damping: Option<crate::linear::ModalDamping>,
    /// How `modal_damping` meets the joint dampers: `Replace` (absent) or `Add` (on top of them).
    /// Only with `modal_damping`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_combination: Option<crate::linear::ModalCombination>,
    /// The joint whose speed the rpm range, the order lines and the crossings refer to (default
    /// the spin joint): a shaft geared or meshed to the spin joint, turning at |r| times its
    /// speed in the steady rotation (its steady rate, `Mechanism::steady_rates`), e.g. a
    /// turbine's shaft behind a reduction gear whose orders are its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_of: Option<String>,
}

impl CampbellSpec {
    /// The named shaft's speed per unit spin speed, |r| (1 without `speed_of`); None when the
    /// joint is unknown or does not turn with the spin.
    pub fn speed_ratio(&self, mech: &crate::model::mechanism::Mechanism, spin: usize) -> Option<f64> {
        let Some(name) = &self.speed_of else { return Some(1.0) };
        let j = mech.joint_index(name)?;
        let r = mech.steady_rates(spin)[j].abs();
        (r > 0.0 && r.is_finite()).then_some(r)
    }
}

impl CampbellSpec {
    /// The modal damping in force with its combination (absent combination: `Replace`).
    pub fn modal(&self) -> Option<(&crate::linear::ModalDamping, crate::linear::ModalCombination)> {
        self.modal_damping.as_ref().map(|z| (z, self.modal_combination.unwrap_or_default()))
    }
}

fn default_campbell_points() -> usize {
    61
}

fn default_engine_orders() -> Vec<f64> {
    vec![1.5, 3.0, 4.5, 6.0]
}
