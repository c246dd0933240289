//! The free oscillation (backbone) as written in the study file.

use serde::{Deserialize, Serialize};

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
