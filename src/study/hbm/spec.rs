//! Harmonic balance as written in the study file: the continued parameter, its range and the excitation.

use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

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
    #[serde(default = "crate::study::spec::default_multiples")]
    pub multiples: Vec<f64>,
    /// Name of an `OrderSweep` of the same study whose traces are drawn under the branches (an
    /// `Order` continuation only).
    #[serde(default)]
    pub overlay: Option<String>,
    /// Name of a `FreeOscillation` of the same study (before this analysis) whose backbone,
    /// order against release amplitude, is drawn over the branches' peak absorber angle
    /// against order in `<name>_backbone.svg` (an `Order` continuation only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backbone: Option<String>,
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
    #[serde(default = "crate::study::spec::default_engine_multiples")]
    pub engine_multiples: usize,
    /// The route (default `Auto`: the cyclic one where the absorbers are identical, see
    /// `hbm::cyclic`). `Cyclic` declares the absorbers identical: a set that is not is refused
    /// at load with the difference found. `General` solves every coordinate (the reference).
    #[serde(default)]
    pub route: HbmRoute,
    /// Values of the continued parameter (order, rpm or N·m, as `parameter` says) at which every
    /// periodic state the branches cross is solved exactly and reported with its stability
    /// (issue 29, item 7): coexisting orbits, such as a gravity-loaded rotor's at one speed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub orbits_at: Vec<f64>,
    /// Switch at every branch point of the unison branch (a Floquet multiplier through +1 where
    /// two identical absorbers leave unison) onto the non-unison branch, and at every period
    /// doubling (a multiplier through −1) onto the period-doubled branch, and follow each with
    /// its stability (default false; issue 28, item 3; `hbm::switch`). Each switched branch is an
    /// extra row (route `general`, every coordinate an unknown), drawn dotted in the figure, with
    /// where it goes in the summary; a period-doubled one (`period_doubled` in results.json) is
    /// solved with twice the harmonics of half the base frequency, and `multiples` may then hold
    /// halves (0.5: the order n/2 of its subharmonic). Branch points need one set of exactly two
    /// identical one-coordinate absorbers; a branch with neither crossing in the range is a
    /// failure of the analysis naming this field at its line.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub switch: bool,
    /// The engine's series, filled when the study is loaded (not part of the file).
    #[serde(skip)]
    pub engine_series: Option<crate::combustion::OscillatingSeries>,
}

/// How a `HarmonicBalance` analysis is solved (see `hbm::cyclic`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum HbmRoute {
    /// The cyclic route where the mechanism's absorbers form identical sets, else the general.
    #[default]
    Auto,
    /// The cyclic route, declared: the absorbers must form identical sets (a located error
    /// otherwise, naming the difference).
    Cyclic,
    /// The general route whatever the mechanism (every coordinate an unknown).
    General,
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
