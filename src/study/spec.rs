//! The study file's frame (RON): the mechanism, the joint that spins, the body whose response
//! is reported, the joints locked in the reference twin, the settings every analysis shares, and
//! the list of analyses. Each analysis's own fields are declared in its room
//! (`study/<analysis>/spec.rs`); the list of kinds is [`AnalysisSpec`](super::AnalysisSpec).

use super::AnalysisSpec;
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
    /// Which integrator the time-domain runs use (default `Auto`: chosen from the linearised
    /// spectrum, see [`Integrator`]).
    pub integrator: Integrator,
    /// How long the analysis running now may take, derived from its plan by the study runner
    /// (the watchdog of [`super::run`]); never read from a file.
    #[serde(skip)]
    pub deadline: Option<Deadline>,
    /// How generous the watchdog is (from the load options' [`super::plan::Limits`]); never read
    /// from a file.
    #[serde(skip)]
    pub watchdog: super::plan::Watchdog,
}

pub use crate::deadline::Deadline;

/// The integrator of a study's time-domain runs (order sweeps, multi-order runs, transients).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
pub enum Integrator {
    /// Explicit DOP853 unless the linearised mechanism has a mode so fast that DOP853's
    /// stability limit, not the tolerance, would set its step (docs/design/time.md, "Stiff
    /// mechanisms: the integrator choice"); then implicit Radau IIA.
    #[default]
    Auto,
    /// Explicit DOP853 (Dormand–Prince 8(5,3)).
    Explicit,
    /// Implicit Radau IIA of order 5 (L-stable; for stiff elastic shafts).
    Implicit,
}

impl Default for IntegrationSpec {
    fn default() -> Self {
        Self {
            rtol: 1e-9,
            atol: 1e-9,
            sample_hz: 2000.0,
            max_steps: 50_000_000,
            integrator: Integrator::Auto,
            deadline: None,
            watchdog: super::plan::Watchdog::default(),
        }
    }
}

/// Short-time FFT order-tracking settings (docs/design/conventions.md: 2 s Hann windows, 0.25 s hop, 5 bins).
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

/// The default shared by the analyses that name it.
pub(crate) fn default_true() -> bool {
    true
}

/// The default shared by the analyses that name it.
pub(crate) fn default_multiples() -> Vec<f64> {
    vec![1.0, 2.0]
}

/// The default shared by the analyses that name it.
pub(crate) fn default_ramp() -> f64 {
    2.0
}

/// The default shared by the analyses that name it.
pub(crate) fn default_engine_multiples() -> usize {
    4
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
    /// How its share follows the mean speed (default `Constant`): the torque there is
    /// `scale · law(rpm) · T_k`. Taken by LinearResponse (at its speed) and MultiOrder (at each of
    /// its speeds); the other analyses refuse a law other than `Constant`.
    #[serde(default, skip_serializing_if = "AmplitudeLaw::is_constant")]
    pub law: AmplitudeLaw,
}

fn default_scale() -> f64 {
    1.0
}

/// A factor on an excited joint's share as a function of the mean speed, e.g. a propeller's
/// blade-pass torque, which grows with the square of the speed.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum AmplitudeLaw {
    /// The same share at every speed (factor 1).
    #[default]
    Constant,
    /// Factor `(rpm / reference_rpm)²`: the share is `scale` at `reference_rpm`.
    Rpm2 {
        /// The speed at which the share is `scale`, rpm.
        reference_rpm: f64,
    },
    /// `(rpm, factor)` pairs in ascending rpm, interpolated linearly; a speed outside the first
    /// and last rpm is refused when the study is read (no extrapolation).
    Table(Vec<(f64, f64)>),
}

impl AmplitudeLaw {
    /// Whether this is the constant law (the default, left out when written).
    pub fn is_constant(&self) -> bool {
        matches!(self, AmplitudeLaw::Constant)
    }

    /// The factor at `rpm`; None outside a table's speed range.
    pub fn factor(&self, rpm: f64) -> Option<f64> {
        match self {
            AmplitudeLaw::Constant => Some(1.0),
            AmplitudeLaw::Rpm2 { reference_rpm } => Some((rpm / reference_rpm).powi(2)),
            AmplitudeLaw::Table(points) => {
                let (first, last) = (points.first()?, points.last()?);
                if !(rpm >= first.0 && rpm <= last.0) {
                    return None;
                }
                let i = points.windows(2).position(|w| rpm <= w[1].0)?;
                let ((r0, f0), (r1, f1)) = (points[i], points[i + 1]);
                Some(f0 + (f1 - f0) * (rpm - r0) / (r1 - r0))
            }
        }
    }
}

/// An `excite` list with each joint's law evaluated at `rpm` into its share (every law then
/// `Constant`); a speed outside a table was refused when the study was read, and reads as a
/// NaN share here rather than a silent extrapolation.
pub(crate) fn excite_at_rpm(excite: &[ExciteAt], rpm: f64) -> Vec<ExciteAt> {
    excite
        .iter()
        .map(|e| ExciteAt {
            scale: e.scale * e.law.factor(rpm).unwrap_or(f64::NAN),
            law: AmplitudeLaw::Constant,
            ..e.clone()
        })
        .collect()
}
