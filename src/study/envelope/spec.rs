//! The operating envelope as written in the study file: the (order, torque) or (speed, torque)
//! plane it maps.

use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

/// The operating envelope of a single-order excitation `T sin(nΩt)` at a mean speed: the
/// boundaries in the (excitation order n, torque amplitude T) plane where the steady response
/// jumps (fold curves, with their cusps) and, for identical absorbers, where their unison
/// motion is lost, each followed by two-parameter continuation (`hbm::fold2`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvelopeSpec {
    /// Name (file prefix).
    pub name: String,
    /// The plane's first parameter (default `Order`: the excitation order over
    /// `order_min`..`order_max` at `rpm`).
    #[serde(default)]
    pub plane: EnvelopePlane,
    /// Mean speed, rpm (an `Order` plane only).
    #[serde(default)]
    pub rpm: f64,
    /// Lower end of the order range (an `Order` plane only).
    #[serde(default)]
    pub order_min: f64,
    /// Upper end of the order range (an `Order` plane only).
    #[serde(default)]
    pub order_max: f64,
    /// Smallest torque amplitude mapped, N·m.
    pub torque_min: f64,
    /// Largest torque amplitude mapped, N·m.
    pub torque_max: f64,
    /// Harmonics of nΩ kept (default 10).
    #[serde(default = "default_harmonics")]
    pub harmonics: usize,
    /// Torque amplitudes (N·m) of the one-parameter order branches whose folds and unison
    /// losses start the curves (default: five from `torque_max` down to `torque_min`, evenly
    /// spaced in log T). A boundary that none of them crosses is not found.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seed_torques: Vec<f64>,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone).
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
}

/// The first parameter of an envelope's plane (the second is the torque amplitude).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum EnvelopePlane {
    /// The excitation order, over `order_min`..`order_max` at `rpm`.
    #[default]
    Order,
    /// The mean speed over `rpm_min`..`rpm_max` (rpm) at the excitation order `order`.
    Speed {
        /// Excitation order n held fixed.
        order: f64,
        /// Lower end of the speed range, rpm.
        rpm_min: f64,
        /// Upper end of the speed range, rpm.
        rpm_max: f64,
    },
}

fn default_harmonics() -> usize {
    10
}
