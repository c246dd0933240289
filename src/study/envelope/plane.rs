//! The map's two parameters as the continuation sees them and as the results give them: the
//! first ([`Axis`]: the order n, the mean speed Ω in rad/s, or the torque scale) and the second
//! ([`Second`]: the torque scale s of the problem's excitation, or a mechanism parameter p, or
//! the mean speed), with the seed values of the second.

use super::{EnvelopePlane, EnvelopeSpec, SCALE_COLUMN, SEEDS, TORQUE_COLUMN};
use crate::hbm::{FoldPlane, Parameter};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::plot::num;
use crate::study::Study;

/// `SEEDS` values from `hi` down to `lo`, evenly in the logarithm (both ends included).
fn log_spaced(lo: f64, hi: f64) -> Vec<f64> {
    let (lo, hi) = (lo.ln(), hi.ln());
    (0..SEEDS).map(|k| (hi - (hi - lo) * k as f64 / (SEEDS - 1) as f64).exp()).collect()
}

/// The plane's second parameter as the continuation sees it (the torque scale s of the
/// problem's excitation) and as the results give it.
pub(super) struct Second {
    /// The excitation the problem is built with (its s = 1).
    pub(super) harmonics: Vec<Harmonic>,
    /// Results' unit per unit of s: the reference torque of a single order (N·m), 1 for a set.
    pub(super) per_scale: f64,
    /// Whether s is the mean speed, rad/s (given in rpm).
    pub(super) speed: bool,
    /// A mechanism parameter's range as written (a speed's would not come back exactly from
    /// rad/s).
    pub(super) shown: Option<(f64, f64)>,
    /// The range of s.
    pub(super) range: (f64, f64),
    /// The seed branches' values of s.
    pub(super) seeds: Vec<f64>,
    pub(super) column: String,
    pub(super) unit: String,
    pub(super) label: String,
    /// Whether the chart spaces it logarithmically.
    pub(super) log: bool,
    /// What a mechanism parameter's plane holds fixed, in words (empty otherwise).
    pub(super) fixed: String,
}

impl Second {
    pub(super) fn of(study: &Study, spec: &EnvelopeSpec) -> Self {
        if let Some(par) = &spec.parameter {
            let slide = par
                .quantity
                .joint()
                .and_then(|j| study.mechanism.joint_index(j))
                .is_some_and(|j| study.mechanism.joints[j].kind.slide_axis().is_some());
            let (suffix, unit) = (par.quantity.suffix(slide), par.quantity.unit(slide));
            let (harmonics, fixed) = if let EnvelopePlane::Torque { torque_max, .. } = spec.plane {
                // The torque is the first parameter: the problem's s = 1 is the largest mapped.
                let h = vec![Harmonic { multiple: 1.0, amplitude: torque_max, phase: 0.0 }];
                (h, format!("{} rpm", num(spec.rpm, 6)))
            } else if spec.load.is_empty() {
                let h = vec![Harmonic { multiple: 1.0, amplitude: spec.torque, phase: 0.0 }];
                (h, format!("torque {} N·m", num(spec.torque, 6)))
            } else {
                (spec.load.clone(), "the torque set as written".to_string())
            };
            // The continuation's p is Ω in rad/s for the speed, the quantity's unit otherwise.
            let speed = spec.speed_is_second();
            let si = |v: f64| if speed { rpm_to_rad_s(v) } else { v };
            // Evenly spaced, from the top down: a damping's jump lies at its low end.
            let (lo, hi) = (si(par.from), si(par.to));
            let seeds = if spec.seeds.is_empty() {
                (0..SEEDS).map(|k| hi - (hi - lo) * k as f64 / (SEEDS - 1) as f64).collect()
            } else {
                spec.seeds.iter().map(|&v| si(v)).collect()
            };
            return Second {
                harmonics,
                per_scale: 1.0,
                speed,
                shown: Some((par.from, par.to)),
                range: (lo, hi),
                seeds,
                column: if suffix.is_empty() { par.name.clone() } else { format!("{}_{suffix}", par.name) },
                unit: unit.into(),
                label: format!("{} {}, {unit}", par.quantity.describe(), par.name),
                log: false,
                fixed,
            };
        }
        if spec.load.is_empty() {
            // A single order: s scales the largest torque mapped.
            let t_ref = spec.torque_max;
            let seeds = if spec.seed_torques.is_empty() {
                log_spaced(spec.torque_min, spec.torque_max)
            } else {
                spec.seed_torques.clone()
            };
            Second {
                harmonics: vec![Harmonic { multiple: 1.0, amplitude: t_ref, phase: 0.0 }],
                per_scale: t_ref,
                speed: false,
                shown: None,
                range: (spec.torque_min / t_ref, 1.0),
                seeds: seeds.iter().map(|t| t / t_ref).collect(),
                column: TORQUE_COLUMN.into(),
                unit: "N·m".into(),
                label: "torque amplitude T, N·m".into(),
                log: true,
                fixed: String::new(),
            }
        } else {
            let range = (spec.scale_min, spec.scale_max);
            Second {
                harmonics: spec.load.clone(),
                per_scale: 1.0,
                speed: false,
                shown: None,
                range,
                seeds: if spec.seeds.is_empty() { log_spaced(range.0, range.1) } else { spec.seeds.clone() },
                column: SCALE_COLUMN.into(),
                unit: "1 (scale of the set)".into(),
                label: "scale s of the torque set (1: as written)".into(),
                log: range.1 >= 10.0 * range.0,
                fixed: String::new(),
            }
        }
    }

    /// A value of s in the results' unit.
    pub(super) fn value(&self, s: f64) -> f64 {
        if self.speed { s * 60.0 / (2.0 * std::f64::consts::PI) } else { s * self.per_scale }
    }

    /// A value in the results' unit, in words.
    pub(super) fn words(&self, v: f64) -> String {
        match self.column.as_str() {
            TORQUE_COLUMN => format!("{} N·m", num(v, 6)),
            SCALE_COLUMN => format!("scale {}", num(v, 6)),
            column => format!("{column} = {} {}", num(v, 6), self.unit),
        }
    }
}

/// The plane's first parameter as the continuation sees it (n, or Ω in rad/s) and as the
/// results give it (n, or rpm).
#[derive(Debug, Clone, Copy)]
pub(super) struct Axis {
    pub(super) fold: FoldPlane,
    pub(super) param: Parameter,
    /// Its range, n or rad/s.
    pub(super) range: (f64, f64),
    /// The mean speed the problem is built at, rad/s.
    pub(super) omega: f64,
    /// Results' unit per continuation unit (1, or rpm per rad/s).
    pub(super) to_unit: f64,
}

impl Axis {
    pub(super) fn of(spec: &EnvelopeSpec) -> Self {
        match spec.plane {
            EnvelopePlane::Order => Axis {
                fold: FoldPlane::Order,
                param: Parameter::Order,
                range: (spec.order_min, spec.order_max),
                omega: rpm_to_rad_s(spec.rpm),
                to_unit: 1.0,
            },
            EnvelopePlane::Speed { order, rpm_min, rpm_max } => Axis {
                fold: FoldPlane::Speed { order },
                param: Parameter::Speed { order },
                range: (rpm_to_rad_s(rpm_min), rpm_to_rad_s(rpm_max)),
                omega: rpm_to_rad_s(rpm_min),
                to_unit: 1.0 / rpm_to_rad_s(1.0),
            },
            // The torque scale s of the largest torque mapped (its problem's T = torque_max).
            EnvelopePlane::Torque { order, torque_min, torque_max } => Axis {
                fold: FoldPlane::Torque { order },
                param: Parameter::TorqueScale { order },
                range: (torque_min / torque_max, 1.0),
                omega: rpm_to_rad_s(spec.rpm),
                to_unit: torque_max,
            },
        }
    }

    /// A point's first parameter in the results' unit.
    pub(super) fn value(&self, order: f64, omega: f64, scale: f64) -> f64 {
        match self.fold {
            FoldPlane::Order => order,
            FoldPlane::Speed { .. } => omega * self.to_unit,
            FoldPlane::Torque { .. } => scale * self.to_unit,
        }
    }
}
