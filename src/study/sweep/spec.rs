//! The order sweep as written in the study file: load case 1 of the paper.

use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

/// Direction of an order sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
pub enum Direction {
    /// From the lower order to the higher.
    Up,
    /// From the higher order to the lower.
    Down,
}

/// Load case 1: `T = T_m + T_n sin(Ω∫n dt)`, n swept linearly, for each amplitude and direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Name (file prefix).
    pub name: String,
    /// Mean speed, rpm.
    pub rpm: f64,
    /// Lower end of the order range.
    pub order_min: f64,
    /// Upper end of the order range.
    pub order_max: f64,
    /// Sweep duration, s.
    pub duration_s: f64,
    /// Torque amplitudes T_n, N·m; one run per amplitude and direction.
    pub amplitudes: Vec<f64>,
    /// Directions (default both).
    #[serde(default = "both_directions")]
    pub directions: Vec<Direction>,
    /// Harmonic multiples m of the excitation order to track (default 1 and 2: main and second order).
    #[serde(default = "crate::study::spec::default_multiples")]
    pub multiples: Vec<f64>,
    /// Ramp-in of the oscillating torque, s (default 2).
    #[serde(default = "crate::study::spec::default_ramp")]
    pub ramp_s: f64,
    /// Mean torque T_m, N·m; default: the losses at the operating speed.
    #[serde(default)]
    pub mean_torque: Option<f64>,
    /// Write the sampled time series (time, rotor angle, rate, acceleration, joint angles) as CSV.
    #[serde(default)]
    pub write_time_series: bool,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
}

fn both_directions() -> Vec<Direction> {
    vec![Direction::Up, Direction::Down]
}
