//! The operating envelope as written in the study file: the plane it maps, (order or speed) ×
//! (torque amplitude, torque scale of a multi-order set, or a mechanism parameter).

use crate::model::excitation::Harmonic;
use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

/// The operating envelope at a mean speed (or at an order): the boundaries in a plane of two
/// parameters where the steady response jumps (fold curves, with their cusps) and, for identical
/// absorbers, where their unison motion is lost, each followed by two-parameter continuation
/// (`hbm::fold_curves`).
///
/// The first parameter is the excitation order n (or the mean speed, `plane`). The second is
/// one of:
/// - the torque amplitude T of a single order `T sin(nΩt)` over `torque_min`..`torque_max`
///   (N·m; the default);
/// - the common scale s (dimensionless) of a multi-order set `load`, over
///   `scale_min`..`scale_max`: the excitation is `s Σ T_k sin(m_k nΩt + α_k)`;
/// - a mechanism parameter (`parameter`, named as a design study names it) over its
///   `from`..`to`, at the fixed single-order torque `torque` (N·m) or at the set `load` as given;
/// - on an `Order` plane, the mean speed (`parameter` with `quantity: Rpm`, rpm, `rpm` left
///   out), at the fixed `torque` or `load`.
///
/// The three are exclusive: fields of another are refused at their place in the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvelopeSpec {
    /// Name (file prefix).
    pub name: String,
    /// The plane's first parameter (default `Order`: the excitation order over
    /// `order_min`..`order_max` at `rpm`).
    #[serde(default)]
    pub plane: EnvelopePlane,
    /// Mean speed, rpm (an `Order` or `Torque` plane; left out when the speed is the second
    /// parameter).
    #[serde(default)]
    pub rpm: f64,
    /// Lower end of the order range (an `Order` plane only).
    #[serde(default)]
    pub order_min: f64,
    /// Upper end of the order range (an `Order` plane only).
    #[serde(default)]
    pub order_max: f64,
    /// Smallest torque amplitude mapped, N·m (a single-order torque plane only).
    #[serde(default)]
    pub torque_min: f64,
    /// Largest torque amplitude mapped, N·m (a single-order torque plane only).
    #[serde(default)]
    pub torque_max: f64,
    /// A multi-order set `[(multiple, amplitude, phase), …]` (N·m, rad; the same harmonics as
    /// `MultiOrder`'s) in place of the single order: with `scale_min`/`scale_max` its common
    /// scale s is the plane's second parameter; with `parameter` it is applied as given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub load: Vec<Harmonic>,
    /// Smallest scale of `load` mapped (dimensionless, > 0).
    #[serde(default)]
    pub scale_min: f64,
    /// Largest scale of `load` mapped (dimensionless; 1 is the set as written).
    #[serde(default)]
    pub scale_max: f64,
    /// A mechanism parameter as the plane's second parameter (a body's or joint's quantity, as
    /// a `DesignStudy` names it), at the fixed torque `torque` or the set `load`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parameter: Option<EnvelopeParameter>,
    /// The single-order torque amplitude, N·m, held fixed on a mechanism-parameter plane.
    #[serde(default)]
    pub torque: f64,
    /// Harmonics of nΩ kept (default 10).
    #[serde(default = "default_harmonics")]
    pub harmonics: usize,
    /// Torque amplitudes (N·m) of the one-parameter order branches whose folds and unison
    /// losses start the curves (default: five from `torque_max` down to `torque_min`, evenly
    /// spaced in log T). A boundary that none of them crosses is not found.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seed_torques: Vec<f64>,
    /// The same for a scale or mechanism-parameter plane: the values of the second parameter
    /// (its unit) of the seed branches (default: five over its range, evenly in the logarithm
    /// for a scale, evenly for a mechanism parameter).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seeds: Vec<f64>,
    /// Values of the first parameter (order, or rpm on a `Speed` plane) at which every boundary's
    /// crossings are solved exactly, the second parameter free, and reported (a section of the
    /// map: the torque, scale or parameter value of each fold at that order or speed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<f64>,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone).
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
}

/// A mechanism parameter as the second parameter of an envelope's plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvelopeParameter {
    /// Column name (letters, digits, `_`, `-`, `.`); the CSV column is `<name>_<unit>`.
    pub name: String,
    /// What is varied: a body's or joint's quantity (`JointDamping("pivot")`,
    /// `TuningOrder("pivot")`, `BodyMass("pendulum")`, …), or on an `Order` plane `Rpm`, the
    /// mean speed (rpm; the plane's `rpm` is then left out); not the torque or the order.
    pub quantity: crate::study::design::Quantity,
    /// Lower end of the range, in the quantity's unit.
    pub from: f64,
    /// Upper end of the range.
    pub to: f64,
}

/// The first parameter of an envelope's plane (the second is the torque amplitude, the scale of
/// a set or a mechanism parameter).
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
    /// The torque amplitude T of a single order over `torque_min`..`torque_max` (N·m) at the
    /// excitation order `order` and the mean speed `rpm`, against a mechanism `parameter`.
    Torque {
        /// Excitation order n held fixed.
        order: f64,
        /// Smallest torque amplitude mapped, N·m.
        torque_min: f64,
        /// Largest torque amplitude mapped, N·m.
        torque_max: f64,
    },
}

impl EnvelopeSpec {
    /// Whether the plane's second parameter is the mean speed (`parameter` with `quantity: Rpm`,
    /// the (order, speed) plane at a fixed torque).
    pub(crate) fn speed_is_second(&self) -> bool {
        self.parameter.as_ref().is_some_and(|p| p.quantity == crate::study::design::Quantity::Rpm)
    }
}

fn default_harmonics() -> usize {
    10
}
