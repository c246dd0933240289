//! The design study as written in the study file: its varied quantities, their sampling and the analysis run per case.

use crate::study::AnalysisSpec;
use serde::{Deserialize, Serialize};

/// A design study as written in the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Name (file prefix of `<name>.csv`).
    pub name: String,
    /// The varied quantities, 1 to [`MAX_PARAMETERS`](crate::study::design::MAX_PARAMETERS).
    pub parameters: Vec<DesignParameter>,
    /// How the cases are drawn (default `Grid`).
    #[serde(default)]
    pub sampling: Sampling,
    /// The analysis run per case: `HarmonicBalance(…)` or `LinearResponse(…)`, written as in
    /// `analyses`; the parameters replace its fields and the mechanism's values case by case.
    pub analysis: Box<AnalysisSpec>,
    /// Mechanism file the cases vary, relative to the study file (default: the study's own): a
    /// design study of another mechanism than the study's other analyses (a set of four
    /// absorbers next to maps of two). It must have the study's spin joint and response body.
    #[serde(default)]
    pub mechanism: Option<String>,
    /// With `mechanism`: its joints locked for the reference twin (the study's `lock` names the
    /// study's own mechanism; default none).
    #[serde(default)]
    pub lock: Vec<String>,
    /// With `mechanism`: its joints reported element by element (default: every joint with a
    /// coordinate other than the spin joint).
    #[serde(default)]
    pub elements: Vec<String>,
    /// The operating range `(from, to)` of a harmonic balance's continued parameter (order, rpm
    /// or N·m) inside which a case's jumps and losses of unison are counted (default: the
    /// analysis's whole range).
    #[serde(default)]
    pub operating: Option<(f64, f64)>,
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
    /// How random sampling spreads the values over `from`..`to` (default `Uniform`).
    #[serde(default)]
    pub distribution: Distribution,
}

/// The distribution a random sampling draws a parameter from, on `from`..`to`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum Distribution {
    /// Uniform on `from`..`to` (in the logarithm with `log: true`).
    #[default]
    Uniform,
    /// A normal distribution of this mean and standard deviation (the parameter's unit)
    /// truncated to `from`..`to`: a production spread, with the tolerance band as the limits.
    /// A case at fraction t ∈ [0, 1) of the sampling's unit interval takes the value
    /// `mean + sd Φ⁻¹(Φ(α) + t (Φ(β) − Φ(α)))`, α and β the limits in standard deviations, so a
    /// Latin hypercube's strata are equally probable.
    Normal {
        /// Mean, in the parameter's unit.
        mean: f64,
        /// Standard deviation, in the parameter's unit (> 0).
        sd: f64,
    },
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
    /// The linear tuning order n_t of a revolute pendulum on a rotor (a joint whose child
    /// body carries nothing further), set through the distance L of the child's centre of mass
    /// from the pivot along its direction in the file, its mass, centroidal inertia I and the
    /// pivot radius R kept: `n_t² = m R L / (I + m L²)` solved for the root on the file's side
    /// of `√(I/m)`.
    TuningOrder(String),
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
    pub(crate) fn suffix(&self, slide: bool) -> &'static str {
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
            Quantity::Order | Quantity::TuningOrder(_) => "",
        }
    }

    /// The SI unit (`"1"` for an order).
    pub(crate) fn unit(&self, slide: bool) -> &'static str {
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
            Quantity::Order | Quantity::TuningOrder(_) => "1",
        }
    }

    /// The joint it names, if any.
    pub(crate) fn joint(&self) -> Option<&str> {
        match self {
            Quantity::JointStiffness(j)
            | Quantity::JointDamping(j)
            | Quantity::JointRadius(j)
            | Quantity::TuningOrder(j) => Some(j),
            _ => None,
        }
    }

    /// The body it names, if any.
    pub(crate) fn body(&self) -> Option<&str> {
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
            Quantity::TuningOrder(j) => format!("tuning order of `{j}`"),
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
