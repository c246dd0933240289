//! The free oscillation (backbone) as written in the study file.

use serde::{Deserialize, Serialize};

pub use crate::hbm::FreeSpin;

/// The free oscillation of one joint with every damper removed, the spin held or free, released
/// from rest at each amplitude: its order against amplitude (the backbone curve), by
/// continuation of free periodic orbits (harmonic balance with a phase condition) and checked by
/// time integration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeOscillationSpec {
    /// Name (file prefix).
    pub name: String,
    /// The spin speed, rpm: held there, or with a free rotor its mean speed.
    pub rpm: f64,
    /// The joint released (an absorber's pivot or path joint).
    pub joint: String,
    /// Release amplitudes in the joint's unit (rad, or m of arc length for a path joint),
    /// positive: the joint's coordinate at the instant it is at rest.
    pub amplitudes: Vec<f64>,
    /// Full periods measured per amplitude by the time route (default 8).
    #[serde(default = "default_periods")]
    pub periods: usize,
    /// The rotor: `Held` at `rpm` (the default), or `Free` (no torque on it, its angular
    /// momentum conserved; the order is the frequency over its mean speed).
    #[serde(default)]
    pub spin: FreeSpin,
    /// Harmonics of the free oscillation kept by the continuation (default 24).
    #[serde(default = "default_harmonics")]
    pub harmonics: usize,
}

fn default_periods() -> usize {
    8
}

fn default_harmonics() -> usize {
    24
}
