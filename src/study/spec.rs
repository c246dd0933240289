//! The study file (RON): a mechanism, the joint that spins, the body whose response is reported,
//! the joints locked in the reference twin, and a list of analyses.

use crate::model::excitation::Harmonic;
use serde::{Deserialize, Serialize};

/// A study as written. Paths are relative to the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Study", deny_unknown_fields)]
pub struct StudySpec {
    /// Name: the output folder is `<out>/<name>/`.
    pub name: String,
    /// Mechanism file, relative to the study file.
    pub mechanism: String,
    /// The joint driven by the excitation torque and spinning at the operating speed (default `spin`).
    #[serde(default = "default_spin")]
    pub spin_joint: String,
    /// The body whose angular acceleration is the reported response (default `rotor`).
    #[serde(default = "default_body")]
    pub response_body: String,
    /// Joints locked (child merged into parent at q = 0) to make the reference twin, e.g. the
    /// pendulum pivots: the paper's "locked pendulum" rotor. Empty: no locked comparison.
    #[serde(default)]
    pub lock: Vec<String>,
    /// The joints reported element by element (their coordinate's amplitude per order and peak,
    /// and the torque their spring and damper transmit). Empty (the default): every joint with a
    /// coordinate other than the spin joint.
    #[serde(default)]
    pub elements: Vec<String>,
    /// Time-integration settings.
    #[serde(default)]
    pub integration: IntegrationSpec,
    /// Order-tracking settings.
    #[serde(default)]
    pub order_tracking: TrackingSpec,
    /// The analyses, run in parallel where independent.
    pub analyses: Vec<AnalysisSpec>,
}

fn default_spin() -> String {
    "spin".into()
}
fn default_body() -> String {
    "rotor".into()
}

/// DOP853 settings shared by every time-domain run of a study.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntegrationSpec {
    /// Relative tolerance (default 1e-9).
    pub rtol: f64,
    /// Absolute tolerance (default 1e-9).
    pub atol: f64,
    /// Output sample rate of the dense-output sampler, Hz (default 2000).
    pub sample_hz: f64,
    /// Step limit per run (default 50 million).
    pub max_steps: usize,
}

impl Default for IntegrationSpec {
    fn default() -> Self {
        Self { rtol: 1e-9, atol: 1e-9, sample_hz: 2000.0, max_steps: 50_000_000 }
    }
}

/// Short-time FFT order-tracking settings (docs/design.md: 2 s Hann windows, 0.25 s hop, 5 bins).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackingSpec {
    /// Window length, s.
    pub window_s: f64,
    /// Hop between windows, s.
    pub hop_s: f64,
    /// Bins summed each side of the tracked bin (2 → 5 bins).
    pub half_width_bins: usize,
}

impl Default for TrackingSpec {
    fn default() -> Self {
        Self { window_s: 2.0, hop_s: 0.25, half_width_bins: 2 }
    }
}

/// Direction of an order sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Direction {
    /// From the lower order to the higher.
    Up,
    /// From the higher order to the lower.
    Down,
}

/// One analysis of a study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AnalysisSpec {
    /// Single-order excitation swept in order (the paper's load case 1, Figs. 3 and 4).
    OrderSweep(SweepSpec),
    /// Multi-order excitation at steady speeds (the paper's load case 2, Table 1, Fig. 5).
    MultiOrder(MultiOrderSpec),
    /// Linear order-domain frequency response normalised by the locked twin (eq. 22, Fig. 2).
    LinearResponse(LinearResponseSpec),
    /// Natural frequencies against spin speed with engine-order lines.
    Campbell(CampbellSpec),
    /// Periodic steady states by harmonic balance, continued in the excitation order, with
    /// stability: the branches behind the sweeps' jumps.
    HarmonicBalance(HbmSpec),
    /// One analysis run over many cases of varied mechanism and excitation parameters (a grid, a
    /// Latin hypercube or Monte Carlo), collected in one table (see [`super::design`]).
    DesignStudy(super::design::DesignSpec),
}

impl AnalysisSpec {
    /// The analysis name (its file prefix).
    pub fn name(&self) -> &str {
        match self {
            AnalysisSpec::OrderSweep(s) => &s.name,
            AnalysisSpec::MultiOrder(m) => &m.name,
            AnalysisSpec::LinearResponse(l) => &l.name,
            AnalysisSpec::Campbell(c) => &c.name,
            AnalysisSpec::HarmonicBalance(h) => &h.name,
            AnalysisSpec::DesignStudy(d) => &d.name,
        }
    }

    /// The analysis kind as written in the study file (`OrderSweep`, …).
    pub fn kind(&self) -> &'static str {
        match self {
            AnalysisSpec::OrderSweep(_) => "OrderSweep",
            AnalysisSpec::MultiOrder(_) => "MultiOrder",
            AnalysisSpec::LinearResponse(_) => "LinearResponse",
            AnalysisSpec::Campbell(_) => "Campbell",
            AnalysisSpec::HarmonicBalance(_) => "HarmonicBalance",
            AnalysisSpec::DesignStudy(_) => "DesignStudy",
        }
    }
}

/// Harmonic balance of a single-order excitation `T_n sin(nΩt)`, continued in the excitation
/// order (the default), the mean speed or the torque amplitude, from each end of the range (so
/// an S-shaped branch is traced whole).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HbmSpec {
    /// Name (file prefix).
    pub name: String,
    /// Mean speed, rpm (not given for a `Speed` continuation).
    #[serde(default)]
    pub rpm: f64,
    /// Lower end of the order range (an `Order` continuation only).
    #[serde(default)]
    pub order_min: f64,
    /// Upper end of the order range (an `Order` continuation only).
    #[serde(default)]
    pub order_max: f64,
    /// Torque amplitudes T_n, N·m, one pair of branches each (not given for a `Torque`
    /// continuation).
    #[serde(default)]
    pub amplitudes: Vec<f64>,
    /// Harmonics of nΩ kept (default 10).
    #[serde(default = "default_harmonics")]
    pub harmonics: usize,
    /// Harmonic multiples reported (default 1 and 2).
    #[serde(default = "default_multiples")]
    pub multiples: Vec<f64>,
    /// Name of an `OrderSweep` of the same study whose traces are drawn under the branches (an
    /// `Order` continuation only).
    #[serde(default)]
    pub overlay: Option<String>,
    /// The continued parameter (default `Order`).
    #[serde(default)]
    pub parameter: HbmParameter,
    /// Largest arclength step of the continuation (default 0.1, in the norm of the Fourier
    /// unknowns in rad and the scaled parameter). Stability changes are found between points, so
    /// lower it to resolve short unstable stretches (see `ContinuationOptions::ds_max`).
    #[serde(default)]
    pub max_step: Option<f64>,
}

/// What a `HarmonicBalance` analysis continues, and over which range in the spec's units: the
/// study file's form of [`crate::hbm::Parameter`] (see [`HbmParameter::continued`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum HbmParameter {
    /// The excitation order, over `order_min`..`order_max` at `rpm`, per amplitude.
    #[default]
    Order,
    /// The mean speed over `rpm_min`..`rpm_max` (rpm) at the fixed excitation order `order`, per
    /// amplitude.
    Speed {
        /// Excitation order n held fixed.
        order: f64,
        /// Lower end of the speed range, rpm.
        rpm_min: f64,
        /// Upper end of the speed range, rpm.
        rpm_max: f64,
    },
    /// The torque amplitude T_n over `min`..`max` (N·m) at the fixed excitation order `order`
    /// and `rpm`.
    Torque {
        /// Excitation order n held fixed.
        order: f64,
        /// Lower end of the amplitude range, N·m.
        min: f64,
        /// Upper end of the amplitude range, N·m.
        max: f64,
    },
}

impl HbmParameter {
    /// The harmonic balance's continued parameter, with the order it holds fixed (the range
    /// stays here): `Torque` continues the torque scale of a 1 N·m excitation, in N·m.
    pub fn continued(self) -> crate::hbm::Parameter {
        use crate::hbm::Parameter;
        match self {
            HbmParameter::Order => Parameter::Order,
            HbmParameter::Speed { order, .. } => Parameter::Speed { order },
            HbmParameter::Torque { order, .. } => Parameter::TorqueScale { order },
        }
    }
}

fn default_harmonics() -> usize {
    10
}

/// Joint dampers replaced for one variant of a linear analysis (e.g. the pivot damping c_p).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    /// Legend and file label.
    pub label: String,
    /// `(joint, damping in N·m·s/rad)` pairs.
    pub dampers: Vec<(String, f64)>,
}

/// The linear frequency response of the response body's angular acceleration under a torque on
/// the spin joint, `|α̂(n)| / |α̂_locked(n)|`, over an order range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearResponseSpec {
    /// Name (file prefix).
    pub name: String,
    /// Mean speed, rpm.
    pub rpm: f64,
    /// Lower end of the order range (in units of the tuning order n_t when `relative`).
    pub from: f64,
    /// Upper end of the order range.
    pub to: f64,
    /// Number of orders evaluated (default 1201).
    #[serde(default = "default_points")]
    pub points: usize,
    /// Give `from`/`to` and plot in units of the tuning order n_t: the undamped eigen-order of the
    /// first locked joint's mode with the spin held (eq. 15 for the CPVA). Default true.
    #[serde(default = "default_true")]
    pub relative: bool,
    /// Damping variants (default: the mechanism as it is).
    #[serde(default)]
    pub variants: Vec<Variant>,
    /// Modal damping in place of the mechanism's dampers: `All(ζ)` or `PerMode([ζ1, ζ2, …])`
    /// (lowest frequency first; modes of the mechanism with the spin free, and of its locked
    /// twin). Default: the dampers as built. Not together with damper variants.
    #[serde(default)]
    pub modal_damping: Option<crate::linear::ModalDamping>,
}

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
    /// Modal damping in place of the mechanism's dampers (`All(ζ)` or `PerMode([…])`, modes
    /// taken with the spin as `spin_held` says); the frequencies are then the damped ones.
    #[serde(default)]
    pub modal_damping: Option<crate::linear::ModalDamping>,
}

fn default_points() -> usize {
    1201
}
fn default_true() -> bool {
    true
}
fn default_campbell_points() -> usize {
    61
}
fn default_engine_orders() -> Vec<f64> {
    vec![1.5, 3.0, 4.5, 6.0]
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
    #[serde(default = "default_multiples")]
    pub multiples: Vec<f64>,
    /// Ramp-in of the oscillating torque, s (default 2).
    #[serde(default = "default_ramp")]
    pub ramp_s: f64,
    /// Mean torque T_m, N·m; default: the losses at the operating speed.
    #[serde(default)]
    pub mean_torque: Option<f64>,
    /// Write the sampled time series (time, rotor angle, rate, acceleration, joint angles) as CSV.
    #[serde(default)]
    pub write_time_series: bool,
}

/// One operating speed of a multi-order load case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedPoint {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// The order harmonics at this speed (`multiple` 1 = order n, 2 = 2n), N·m and rad.
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
    /// The operating speeds and their harmonics.
    pub speeds: Vec<SpeedPoint>,
    /// Harmonic multiples m tracked (default 1 and 2).
    #[serde(default = "default_multiples")]
    pub multiples: Vec<f64>,
    /// Ramp-in of the oscillating torque, s (default 2).
    #[serde(default = "default_ramp")]
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
    /// Integrate the nonlinear equations to steady state at each speed (default true).
    #[serde(default = "default_true")]
    pub time_domain: bool,
    /// Also give the linear response (superposed harmonics through eq. 22), plotted dashed next
    /// to the nonlinear one (default true).
    #[serde(default = "default_true")]
    pub linear: bool,
    /// Also find every periodic steady state by harmonic balance (continued in order through the
    /// operating order, so coexisting branches all appear) with their stability (default false).
    #[serde(default)]
    pub hbm: bool,
}

fn both_directions() -> Vec<Direction> {
    vec![Direction::Up, Direction::Down]
}
fn default_multiples() -> Vec<f64> {
    vec![1.0, 2.0]
}
fn default_ramp() -> f64 {
    2.0
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
