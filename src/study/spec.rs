//! The study file (RON): a mechanism, the joint that spins, the body whose response is reported,
//! the joints locked in the reference twin, and a list of analyses.
//!
//! One idea, one file: the file format as serde types, every field with its unit and default.
//! It runs past 600 lines because each analysis's fields are documented where they are
//! declared, and because the design study's types are here too: a design study holds an
//! analysis and the analyses hold design studies, and recursive types split over two files would
//! import each other.

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
    /// How long the analysis running now may take, derived from its plan by the study runner
    /// (the watchdog of [`super::run`]); never read from a file.
    #[serde(skip)]
    pub deadline: Option<Deadline>,
    /// How generous the watchdog is (from the load options' [`super::plan::Limits`]); never read
    /// from a file.
    #[serde(skip)]
    pub watchdog: super::plan::Watchdog,
}

/// When a running analysis must stop, and the time budget that gave that instant (for the
/// message).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadline {
    /// The instant past which every loop that checks it stops.
    pub at: std::time::Instant,
    /// The budget, s of wall time from the analysis's start.
    pub budget_s: f64,
}

impl Deadline {
    /// Whether the deadline has passed.
    pub fn passed(&self) -> bool {
        std::time::Instant::now() >= self.at
    }
}

impl Default for IntegrationSpec {
    fn default() -> Self {
        Self {
            rtol: 1e-9,
            atol: 1e-9,
            sample_hz: 2000.0,
            max_steps: 50_000_000,
            deadline: None,
            watchdog: super::plan::Watchdog::default(),
        }
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
    DesignStudy(DesignSpec),
    /// A transient from a given state: free, or through a run-up or run-down of the spin speed
    /// (driven by a torque or prescribed), with an order–rpm map of the response.
    Transient(TransientSpec),
    /// The free oscillation of one joint at held spin, undamped, against its release amplitude:
    /// the absorber's backbone curve (see [`super::backbone`]).
    FreeOscillation(FreeOscillationSpec),
    /// The same analyses run on several mechanisms (e.g. absorber paths), their results overlaid
    /// per analysis in one figure and compared in one table (see [`super::compare`]).
    Compare(CompareSpec),
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
            AnalysisSpec::Transient(t) => &t.name,
            AnalysisSpec::FreeOscillation(f) => &f.name,
            AnalysisSpec::Compare(c) => &c.name,
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
            AnalysisSpec::Transient(_) => "Transient",
            AnalysisSpec::FreeOscillation(_) => "FreeOscillation",
            AnalysisSpec::Compare(_) => "Compare",
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
    /// unknowns in rad and the scaled parameter). Folds and multiplier crossings are found at any
    /// step (see `ContinuationOptions::ds_max`); it sets how densely the branch is drawn.
    #[serde(default)]
    pub max_step: Option<f64>,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
    /// An engine file (RON `Engine(...)`, relative to the study file) whose torque replaces
    /// `amplitudes` in a `Speed` continuation: its orders that are the multiples
    /// 1..=`engine_multiples` of the parameter's `order`, with amplitudes and phases that follow
    /// the speed along the branch (the gas part fixed, the reciprocating-inertia part ∝ Ω²).
    /// The engine's mean torque is not applied (the solved mean torque holds the speed).
    #[serde(default)]
    pub engine: Option<String>,
    /// Highest multiple of the order taken from the engine (default 4).
    #[serde(default = "default_engine_multiples")]
    pub engine_multiples: usize,
    /// The engine's series, filled when the study is loaded (not part of the file).
    #[serde(skip)]
    pub engine_series: Option<crate::engine::OscillatingSeries>,
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
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
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
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
}

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
    /// An engine file (RON `Engine(...)`, relative to the study file, see `kanedyn::engine`)
    /// whose torque from cylinder pressure gives every speed's harmonics: its orders that are the
    /// multiples 1..=`engine_multiples` of `order`, with their phases, computed when the study is
    /// loaded (results.json's spec shows them). The engine's mean torque is not applied: the
    /// driven load holds the speed, as `mean_torque` (default the losses) says.
    #[serde(default)]
    pub engine: Option<String>,
    /// Highest multiple of `order` taken from the engine (default 4).
    #[serde(default = "default_engine_multiples")]
    pub engine_multiples: usize,
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
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
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

/// A transient: the nonlinear equations integrated from a given initial state over
/// `duration_s`, the spin speed free or run up (or down) linearly, with torques at any joints
/// whose orders follow the spin joint's angle, and the response tracked into an order–rpm map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransientSpec {
    /// Name (file prefix).
    pub name: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// How the spin speed evolves.
    pub speed: SpeedProfile,
    /// Initial joint coordinates `(joint, q)`, rad (m for a slide); joints not named start at 0.
    #[serde(default)]
    pub angles: Vec<(String, f64)>,
    /// Initial joint rates `(joint, q̇)` relative to the parent, rad/s (m/s for a slide); joints
    /// not named start at rest relative to their parent. The spin joint starts at the speed
    /// profile's first speed and is not named here.
    #[serde(default)]
    pub rates: Vec<(String, f64)>,
    /// Torques at joints (child against parent), each with its own base order, harmonics and
    /// phases, the orders counted per revolution of the spin joint (locked to its angle). They
    /// replace the mechanism's own joint torques.
    #[serde(default)]
    pub torques: Vec<JointTorqueSpec>,
    /// Order–rpm map and order cuts of the response (default: as `OrderMapSpec`'s defaults).
    #[serde(default)]
    pub map: OrderMapSpec,
    /// Write the sampled time series (time, spin speed, response, elements) as CSV (default
    /// true).
    #[serde(default = "default_true")]
    pub write_time_series: bool,
    /// Joints whose reaction is recorded: the force (radial and tangential, N) and moment (N·m)
    /// the parent exerts on the child, in the time series and the summary (default none).
    #[serde(default)]
    pub reactions: Vec<String>,
    /// An engine whose oscillating torque from cylinder pressure acts through the run, at the
    /// spin joint's angle (the crank angle) and its speed at each instant (default none).
    #[serde(default)]
    pub engine: Option<EngineExcitation>,
}

/// An engine's oscillating torque in a time run: at every instant the order series of
/// [`crate::engine::Engine`] at the crank angle θ (the spin joint's angle, from cylinder 1's
/// firing TDC) and the crank speed Ω (the spin joint's rate),
/// `T̃(θ, Ω) = Σ_j A_j(Ω) sin(jθ/2 + α_j(Ω))` over the orders j/2 that are multiples of `order` up
/// to `max_order`, with the gas part fixed and the reciprocating-inertia part ∝ Ω². The
/// engine's mean torque is not applied: the speed profile's drive holds the speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EngineExcitation {
    /// The engine file (RON `Engine(...)`), relative to the study file.
    pub file: String,
    /// Base order: the engine's orders that are its whole multiples are kept (default ½: every
    /// order the engine has). Must be a multiple of ½.
    #[serde(default = "default_half")]
    pub order: f64,
    /// Highest order kept, cycles per crank revolution (default 12).
    #[serde(default = "default_engine_max_order")]
    pub max_order: f64,
    /// Ramp-in of the torque, s (default 0: none).
    #[serde(default)]
    pub ramp_s: f64,
    /// The joints the torque acts at, each with its share and phase lead (default: the spin
    /// joint alone).
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
    /// The engine's series, filled when the study is loaded (not part of the file).
    #[serde(skip)]
    pub series: Option<crate::engine::OscillatingSeries>,
}

fn default_half() -> f64 {
    0.5
}

fn default_engine_max_order() -> f64 {
    12.0
}

/// The spin speed of a [`TransientSpec`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum SpeedProfile {
    /// The spin joint starts at `rpm` and then moves as the torques and the mechanism drive it.
    Free {
        /// Initial speed, rpm.
        rpm: f64,
    },
    /// A run-up or run-down driven by a mean torque on the spin joint: the rigid-rotation
    /// feed-forward `J·α + Σc·Ω_ref(t)` that takes the mean speed linearly from `rpm_from` to
    /// `rpm_to` over `ramp_s` (default: the whole run) and holds `rpm_to` after; the speed
    /// itself stays free (it wavers with the torsional motion and the absorbers' mean torques).
    Torque {
        /// Speed at t = 0, rpm.
        rpm_from: f64,
        /// Speed at the end of the ramp, rpm.
        rpm_to: f64,
        /// Length of the ramp, s (default: the whole run).
        #[serde(default)]
        ramp_s: Option<f64>,
        /// Time constant of a proportional speed governor, s: adds `J/τ·(Ω_ref − Ω)` to the
        /// torque so that the mean speed follows the ramp through resonances that would
        /// otherwise hold it back (the Sommerfeld effect). It acts on the instantaneous spin
        /// rate, so it also damps the spin joint against ground (`J/τ` N·m·s/rad). Default:
        /// none (pure feed-forward).
        #[serde(default)]
        governor_s: Option<f64>,
    },
    /// The spin joint's speed prescribed (a test-bench drive): linear from `rpm_from` to
    /// `rpm_to` over `ramp_s` (default: the whole run), then constant. Its torque is the drive's
    /// reaction, reported.
    Prescribed {
        /// Speed at t = 0, rpm.
        rpm_from: f64,
        /// Speed at the end of the ramp, rpm.
        rpm_to: f64,
        /// Length of the ramp, s (default: the whole run).
        #[serde(default)]
        ramp_s: Option<f64>,
    },
}

impl SpeedProfile {
    /// `(first, last)` speed, rpm.
    pub fn rpm_range(&self) -> (f64, f64) {
        match *self {
            SpeedProfile::Free { rpm } => (rpm, rpm),
            SpeedProfile::Torque { rpm_from, rpm_to, .. } | SpeedProfile::Prescribed { rpm_from, rpm_to, .. } => {
                (rpm_from, rpm_to)
            }
        }
    }
}

/// A torque at a joint whose orders are locked to the spin joint's angle:
/// `T = mean + r(t)·Σ T_k sin(m_k·order·θ_spin + α_k)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointTorqueSpec {
    /// The joint it acts at.
    pub joint: String,
    /// Mean torque, N·m (default 0; on the spin joint of a `Free` or `Torque` profile it adds to
    /// the losses at the first speed, which the run always gets).
    #[serde(default)]
    pub mean: f64,
    /// Base order n, cycles per revolution of the spin joint (default 1).
    #[serde(default = "default_order_one")]
    pub order: f64,
    /// Harmonics of n: `(multiple, amplitude N·m, phase rad)`.
    #[serde(default)]
    pub harmonics: Vec<Harmonic>,
    /// Ramp-in of the oscillating part, s (default 0: none).
    #[serde(default)]
    pub ramp_s: f64,
}

fn default_engine_multiples() -> usize {
    4
}

fn default_order_one() -> f64 {
    1.0
}

/// The order–rpm map of a transient: angle-domain blocks of whole revolutions of the spin joint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OrderMapSpec {
    /// Resampled points per revolution (default 64).
    pub samples_per_rev: usize,
    /// Revolutions per block: the order resolution is 1/R (default 32).
    pub revs_per_block: usize,
    /// Revolutions between blocks (default 4).
    pub hop_revs: f64,
    /// Highest order shown in the map (default 12).
    pub max_order: f64,
    /// Orders cut out of the map and plotted against speed (default: every harmonic of every
    /// torque, at most 8).
    pub cuts: Vec<f64>,
}

impl Default for OrderMapSpec {
    fn default() -> Self {
        Self { samples_per_rev: 64, revs_per_block: 32, hop_revs: 4.0, max_order: 12.0, cuts: Vec::new() }
    }
}

/// A joint an analysis's oscillating torque acts at: it carries `scale·T_k sin(m_k·n·Ω·t + α_k +
/// phase)` for every harmonic T_k of the analysis (child against parent), e.g. a propeller's or a
/// gearbox's share of the excitation next to the engine's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExciteAt {
    /// The joint.
    pub joint: String,
    /// Its share of the torque (default 1).
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Its phase lead, rad (default 0).
    #[serde(default)]
    pub phase: f64,
}

fn default_scale() -> f64 {
    1.0
}

/// A design study as written in the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Name (file prefix of `<name>.csv`).
    pub name: String,
    /// The varied quantities, 1 to [`MAX_PARAMETERS`](super::design::MAX_PARAMETERS).
    pub parameters: Vec<DesignParameter>,
    /// How the cases are drawn (default `Grid`).
    #[serde(default)]
    pub sampling: Sampling,
    /// The analysis run per case: `HarmonicBalance(…)` or `LinearResponse(…)`, written as in
    /// `analyses`; the parameters replace its fields and the mechanism's values case by case.
    pub analysis: Box<AnalysisSpec>,
}

/// One varied quantity and its values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignParameter {
    /// Column name (letters, digits, `_`, `-`, `.`); the CSV column is `<name>_<unit>`.
    pub name: String,
    /// What is varied.
    pub quantity: Quantity,
    /// Lower end of the range, in the quantity's unit.
    #[serde(default)]
    pub from: Option<f64>,
    /// Upper end of the range.
    #[serde(default)]
    pub to: Option<f64>,
    /// Number of grid values from `from` to `to`, both included (`Grid` only).
    #[serde(default)]
    pub points: Option<usize>,
    /// The grid values themselves, in place of `from`/`to`/`points` (`Grid` only).
    #[serde(default)]
    pub values: Option<Vec<f64>>,
    /// Space the values (or strata) evenly in the logarithm (needs `from > 0`; default false).
    #[serde(default)]
    pub log: bool,
}

/// A quantity a design study can vary, with its SI unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Quantity {
    /// A body's mass, kg (its centre of mass and centroidal inertia kept).
    BodyMass(String),
    /// A body's centroidal moment of inertia, kg·m².
    BodyInertia(String),
    /// The distance of a body's centre of mass from its inboard joint point (its frame's origin),
    /// m, in the direction it has in the file (the CPVA pendulum's L).
    BodyComRadius(String),
    /// A joint spring's stiffness, N·m/rad (N/m for a slide); a joint without a spring gets one
    /// relaxed at q = 0.
    JointStiffness(String),
    /// A joint's viscous damping, N·m·s/rad (N·s/m for a slide).
    JointDamping(String),
    /// The distance of a joint's point from its parent's origin, m, in the direction it has in
    /// the file (the CPVA's pivot radius R).
    JointRadius(String),
    /// The analysis's mean speed, rpm.
    Rpm,
    /// The analysis's torque amplitude T_n, N·m (harmonic balance in order or speed).
    TorqueAmplitude,
    /// The analysis's fixed excitation order (harmonic balance in speed or torque).
    Order,
}

impl Quantity {
    /// The unit as the CSV column suffix: `kg`, `kg_m2`, `m`, `Nm_per_rad`, …; empty for an
    /// order. `slide`: the joint is prismatic.
    pub(super) fn suffix(&self, slide: bool) -> &'static str {
        match self {
            Quantity::BodyMass(_) => "kg",
            Quantity::BodyInertia(_) => "kg_m2",
            Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => "m",
            Quantity::JointStiffness(_) if slide => "N_per_m",
            Quantity::JointStiffness(_) => "Nm_per_rad",
            Quantity::JointDamping(_) if slide => "Ns_per_m",
            Quantity::JointDamping(_) => "Nms_per_rad",
            Quantity::Rpm => "rpm",
            Quantity::TorqueAmplitude => "Nm",
            Quantity::Order => "",
        }
    }

    /// The SI unit (`"1"` for an order).
    pub(super) fn unit(&self, slide: bool) -> &'static str {
        match self {
            Quantity::BodyMass(_) => "kg",
            Quantity::BodyInertia(_) => "kg·m²",
            Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => "m",
            Quantity::JointStiffness(_) if slide => "N/m",
            Quantity::JointStiffness(_) => "N·m/rad",
            Quantity::JointDamping(_) if slide => "N·s/m",
            Quantity::JointDamping(_) => "N·m·s/rad",
            Quantity::Rpm => "rpm",
            Quantity::TorqueAmplitude => "N·m",
            Quantity::Order => "1",
        }
    }

    /// The joint it names, if any.
    pub(super) fn joint(&self) -> Option<&str> {
        match self {
            Quantity::JointStiffness(j) | Quantity::JointDamping(j) | Quantity::JointRadius(j) => Some(j),
            _ => None,
        }
    }

    /// The body it names, if any.
    pub(super) fn body(&self) -> Option<&str> {
        match self {
            Quantity::BodyMass(b) | Quantity::BodyInertia(b) | Quantity::BodyComRadius(b) => Some(b),
            _ => None,
        }
    }

    /// The quantity in words, for the summary and messages.
    pub fn describe(&self) -> String {
        match self {
            Quantity::BodyMass(b) => format!("mass of `{b}`"),
            Quantity::BodyInertia(b) => format!("centroidal inertia of `{b}`"),
            Quantity::BodyComRadius(b) => format!("centre-of-mass radius of `{b}`"),
            Quantity::JointStiffness(j) => format!("stiffness of `{j}`"),
            Quantity::JointDamping(j) => format!("damping of `{j}`"),
            Quantity::JointRadius(j) => format!("radius of joint `{j}`"),
            Quantity::Rpm => "speed".into(),
            Quantity::TorqueAmplitude => "torque amplitude T_n".into(),
            Quantity::Order => "excitation order".into(),
        }
    }
}

/// How the cases of a design study are drawn (see the module docs for the exact algorithm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Sampling {
    /// Every combination of the parameters' values.
    #[default]
    Grid,
    /// `n` cases, each parameter's `n` strata hit once each.
    LatinHypercube {
        /// Number of cases.
        n: usize,
        /// Seed of the random stream.
        seed: u64,
    },
    /// `n` independent uniform cases.
    MonteCarlo {
        /// Number of cases.
        n: usize,
        /// Seed of the random stream.
        seed: u64,
    },
}

/// The free oscillation of one joint at held spin with every damper removed, released from rest
/// at each amplitude: its order against amplitude (the backbone curve).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeOscillationSpec {
    /// Name (file prefix).
    pub name: String,
    /// The held spin speed, rpm.
    pub rpm: f64,
    /// The joint released (an absorber's pivot or path joint).
    pub joint: String,
    /// Release amplitudes in the joint's unit: rad, or m of arc length for a path joint.
    pub amplitudes: Vec<f64>,
    /// Full periods measured per amplitude (default 8).
    #[serde(default = "default_periods")]
    pub periods: usize,
}

fn default_periods() -> usize {
    8
}

/// One mechanism of a [`CompareSpec`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareMechanism {
    /// Legend and file label (letters, digits, `_`, `-`, `.`).
    pub label: String,
    /// Mechanism file, relative to the study file. It must have the study's spin joint and
    /// response body and the joints the analyses name.
    pub mechanism: String,
    /// Joints locked for this mechanism's reference twin (default: the study's `lock`).
    #[serde(default)]
    pub lock: Option<Vec<String>>,
    /// Joints reported element by element (default: the study's `elements`).
    #[serde(default)]
    pub elements: Option<Vec<String>>,
}

/// The same analyses run on several mechanisms. Each mechanism's outputs are written as by the
/// analyses themselves, with file names `<name>_<label>_<analysis>…`; the comparison adds one
/// figure per analysis, `<name>_<analysis>.svg`, with every mechanism overlaid, and one table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareSpec {
    /// Name (file prefix).
    pub name: String,
    /// The mechanisms compared, 1 to 8.
    pub mechanisms: Vec<CompareMechanism>,
    /// The analyses run on each: `OrderSweep`, `HarmonicBalance`, `FreeOscillation`,
    /// `LinearResponse`, `MultiOrder` or `Transient`, written as in the study's `analyses`.
    pub analyses: Vec<AnalysisSpec>,
}
