//! The transient as written in the study file: speed profile, torques, engine and order map.

use crate::model::excitation::Harmonic;
use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

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
    #[serde(default = "crate::study::spec::default_true")]
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
/// [`crate::combustion::Engine`] at the crank angle θ (the spin joint's angle, from cylinder 1's
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
    pub series: Option<crate::combustion::OscillatingSeries>,
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
