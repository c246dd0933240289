//! The multi-order load case as written in the study file: steady speeds under several orders.

use crate::model::excitation::Harmonic;
use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

/// One operating speed of a multi-order load case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedPoint {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// The order harmonics at this speed (`multiple` 1 = order n, 2 = 2n), N·m and rad. Left
    /// out when the analysis names an `engine`, which gives them.
    #[serde(default)]
    pub harmonics: Vec<Harmonic>,
}

/// Evenly spaced operating speeds with the same harmonics at each (a torsional engineer's forced
/// response over speed, the harmonics' amplitudes following the speed through the excited
/// joints' laws); expanded into `speeds` when the study is loaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedRange {
    /// Lowest speed, rpm (> 0).
    pub rpm_min: f64,
    /// Highest speed, rpm.
    pub rpm_max: f64,
    /// Number of speeds, 2 or more, ends included.
    pub points: usize,
    /// The order harmonics at every speed (`multiple` 1 = order n), N·m and rad; left out with
    /// an `engine`, which gives them.
    #[serde(default)]
    pub harmonics: Vec<Harmonic>,
}

/// Load case 2: `T = T_m + Σ T_k sin(k n Ω t + α_k)` held at each speed until steady.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MultiOrderSpec {
    /// Name (file prefix).
    pub name: String,
    /// Base excitation order n.
    pub order: f64,
    /// The operating speeds and their harmonics (or `speed_range`).
    #[serde(default)]
    pub speeds: Vec<SpeedPoint>,
    /// Evenly spaced speeds instead of the list `speeds` (not both).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_range: Option<SpeedRange>,
    /// Harmonic multiples m tracked (default 1 and 2).
    #[serde(default = "crate::study::spec::default_multiples")]
    pub multiples: Vec<f64>,
    /// Ramp-in of the oscillating torque, s (default 2).
    #[serde(default = "crate::study::spec::default_ramp")]
    pub ramp_s: f64,
    /// Length of each steadiness window, s (default 4: the last two windows are compared).
    #[serde(default = "default_window")]
    pub window_s: f64,
    /// Relative agreement of the last two windows that counts as steady (default 1e-3).
    #[serde(default = "default_steady_tol")]
    pub steady_tol: f64,
    /// Shortest simulated time per speed, s (default 60): about ten decay times of the canonical
    /// pendulum's free motion (c_p/J_B ≈ 0.31 s⁻¹), whose frequency can sit close enough to the
    /// tracked orders for two windows to agree by chance while it still decays.
    #[serde(default = "default_min_time")]
    pub min_time_s: f64,
    /// Longest simulated time per speed, s (default 400).
    #[serde(default = "default_max_time")]
    pub max_time_s: f64,
    /// Mean torque T_m, N·m; default: the losses at each operating speed.
    #[serde(default)]
    pub mean_torque: Option<f64>,
    /// An engine file (RON `Engine(...)`, relative to the study file, see `kanedyn::combustion`)
    /// whose torque from cylinder pressure gives every speed's harmonics: its orders that are the
    /// multiples 1..=`engine_multiples` of `order`, with their phases, computed when the study is
    /// loaded (results.json's spec shows them). The engine's mean torque is not applied: the
    /// driven load holds the speed, as `mean_torque` (default the losses) says.
    #[serde(default)]
    pub engine: Option<String>,
    /// Highest multiple of `order` taken from the engine (default 4).
    #[serde(default = "crate::study::spec::default_engine_multiples")]
    pub engine_multiples: usize,
    /// Integrate the nonlinear equations to steady state at each speed (default true).
    #[serde(default = "crate::study::spec::default_true")]
    pub time_domain: bool,
    /// Also give the linear response (superposed harmonics through eq. 22), plotted dashed next
    /// to the nonlinear one (default true).
    #[serde(default = "crate::study::spec::default_true")]
    pub linear: bool,
    /// Also find every periodic steady state by harmonic balance (continued in order through the
    /// operating order, so coexisting branches all appear) with their stability (default false).
    #[serde(default)]
    pub hbm: bool,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
    /// Modal damping of the linear part (`linear: true`): `All(ζ)` or `PerMode([…])`, modes with
    /// the spin free, of the mechanism and of its locked twin at each speed. The time runs and
    /// the harmonic balance keep the mechanism's own dampers (their equations are nonlinear, the
    /// modes are not theirs). Default: the dampers as built.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_damping: Option<crate::linear::ModalDamping>,
    /// How `modal_damping` meets the joint dampers: `Replace` (absent) or `Add` (on top of them).
    /// Only with `modal_damping`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_combination: Option<crate::linear::ModalCombination>,
}

impl MultiOrderSpec {
    /// The modal damping in force with its combination (absent combination: `Replace`).
    pub fn modal(&self) -> Option<(&crate::linear::ModalDamping, crate::linear::ModalCombination)> {
        self.modal_damping.as_ref().map(|z| (z, self.modal_combination.unwrap_or_default()))
    }
}

fn default_window() -> f64 {
    4.0
}

fn default_steady_tol() -> f64 {
    1e-3
}

fn default_min_time() -> f64 {
    60.0
}

fn default_max_time() -> f64 {
    400.0
}
