//! The operating envelope (issue 28, items 1 and 2): the boundaries of the steady response in a
//! plane of two parameters, each a curve of codimension-one points followed by two-parameter
//! continuation (`hbm::fold_curves`, the minimally augmented systems of Govaerts 2000, §4.3.2), with the
//! codimension-two points where they end or turn. The first parameter is the excitation order n
//! at a mean speed (or the speed at an order, or the torque at an order and speed); the second
//! the torque amplitude T of a single order, the common scale s of a multi-order set, the mean
//! speed, or a mechanism parameter p at a fixed torque (the problem rebuilt at each p,
//! `hbm::MechanismFamily`; a second family rebuilds the problem of half the base frequency for
//! the period-doubling curves).
//!
//! - **Jump boundary**: the fold curve. Inside its wedge three periodic states coexist at each
//!   (n, T) and the response jumps at the wedge's edges; its cusp is the least torque at which a
//!   jump exists (the normal form `x³ − s x − n = 0` has folds `s = 3x², n = −2x³`).
//! - **Unison-loss boundary** of each set of identical absorbers: on the unison problem (one
//!   representative, `hbm::cyclic`), the curve where the representative's own block of the
//!   Jacobian is singular: a +1 branch point of the full set, where a non-unison motion branches
//!   off. Its least torque is the onset: below it the absorbers stay in unison at every order.
//!
//! The curves start from the folds and the block's determinant sign changes on a few
//! one-parameter order branches (the seeds, at torques spread evenly in log T); each seed not
//! already on a curve is localised (Newton's method on the augmented system at its torque) and
//! followed both ways until the curve leaves the map. A region is the curve closed along the map's
//! edge, on the side that holds the points just above its cusp or onset.
//!
//! The room: `plane.rs` (the two parameters as the continuation and the results see them),
//! `curves.rs` (seeds, walks and what is read off a walked curve), `doubling.rs` (the
//! period-doubling screen and seeds), `compute.rs` (the map), `figure.rs` (the chart),
//! `summary.rs` (the section), with `spec.rs` and `analysis.rs` (checks, plan, findings).

mod analysis;
mod compute;
mod curves;
mod doubling;
mod figure;
mod plane;
mod spec;
mod summary;

use compute::compute;
use figure::panel;
use summary::markdown;

pub use spec::{EnvelopeParameter, EnvelopePlane, EnvelopeSpec};

use super::analysis::Output;
use super::table::Table;
use super::{Study, StudyReport};
use crate::error::Result;
use crate::plot::num;
use schemars::JsonSchema;
use serde::Serialize;
use std::path::Path;

/// The CSV column of a single order's torque amplitude (the first or the second parameter).
const TORQUE_COLUMN: &str = "torque_N_m";

/// Default number of seed branches (torques evenly spaced in log T, both ends included).
const SEEDS: usize = 5;

/// A seed closer than this (relative to the range's upper end, at its torque) to a curve
/// already followed is on it: both are solved to the corrector's 1e-10, so only the same curve
/// comes this close.
const SAME_CURVE: f64 = 1e-6;

/// What a boundary separates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
pub enum BoundaryKind {
    /// A fold curve: the response jumps across it (several steady states inside).
    Jump,
    /// A unison-loss curve: an identical set's unison motion is unstable against non-unison
    /// motion inside it (a +1 branch point on its edge).
    UnisonLoss,
    /// A period-doubling curve: inside it the response is unstable against a motion of twice
    /// its period (a −1 multiplier on its edge; a parametric resonance's tongue).
    PeriodDoubling,
}

impl BoundaryKind {
    /// Its code in the CSV's `kind` column.
    fn code(self) -> f64 {
        match self {
            BoundaryKind::Jump => 1.0,
            BoundaryKind::UnisonLoss => 2.0,
            BoundaryKind::PeriodDoubling => 3.0,
        }
    }

    fn words(self) -> &'static str {
        match self {
            BoundaryKind::Jump => "jump (folds)",
            BoundaryKind::UnisonLoss => "unison lost",
            BoundaryKind::PeriodDoubling => "period doubled",
        }
    }
}

/// What a codimension-two point of the map is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, JsonSchema)]
pub enum MapPointKind {
    /// Two folds meet: below its torque the response has no jump there.
    Cusp,
    /// The least torque of a jump boundary without a cusp (where an isola is born, say).
    JumpOnset,
    /// The least torque of a unison-loss boundary: below it the set keeps unison at every order.
    UnisonLossOnset,
    /// The least torque of a period-doubling boundary (a tongue's tip): below it the response
    /// keeps its period at every order of the map.
    PeriodDoublingOnset,
    /// A unison-loss boundary meets the jump boundary: the branch point reaches a fold of the
    /// unison response (on one side of it the set loses unison before the response jumps, on
    /// the other only after).
    UnisonLossMeetsJump,
}

impl MapPointKind {
    /// Its code in the CSV's `kind` column.
    fn code(self) -> f64 {
        match self {
            MapPointKind::Cusp => 10.0,
            MapPointKind::JumpOnset => 11.0,
            MapPointKind::UnisonLossOnset => 12.0,
            MapPointKind::PeriodDoublingOnset => 13.0,
            MapPointKind::UnisonLossMeetsJump => 14.0,
        }
    }

    fn words(self) -> &'static str {
        match self {
            MapPointKind::Cusp => "cusp",
            MapPointKind::JumpOnset => "jump onset",
            MapPointKind::UnisonLossOnset => "unison-loss onset",
            MapPointKind::PeriodDoublingOnset => "period-doubling onset",
            MapPointKind::UnisonLossMeetsJump => "unison loss meets jump",
        }
    }

    fn meaning(self) -> &'static str {
        match self {
            MapPointKind::Cusp => "the two folds of the jump meet: past this value the response does not jump",
            MapPointKind::JumpOnset => "the extreme value of this jump region (it has no cusp)",
            MapPointKind::UnisonLossOnset => "past this value the set keeps unison at every order of the map",
            MapPointKind::PeriodDoublingOnset => {
                "past this value the response keeps its period at every order of the map"
            }
            MapPointKind::UnisonLossMeetsJump => {
                "the loss of unison reaches the fold: on one side unison is lost on the branch before the jump, on the other only past it"
            }
        }
    }
}

/// One boundary of the map, as followed.
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct Boundary {
    /// What it separates.
    pub kind: BoundaryKind,
    /// For a unison-loss boundary, or a period doubling that breaks the unison (the absorbers
    /// swing at half the order against each other), the identical set it belongs to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub set: Option<String>,
    /// The first parameter of its points (excitation order n, or mean speed in rpm), in the
    /// order followed.
    pub values: Vec<f64>,
    /// The second parameter of its points, in the result's `second_unit` (torque amplitude in
    /// N·m, scale of the set, or the mechanism parameter's unit).
    pub second_values: Vec<f64>,
    /// Where it crosses the largest value of the map's second parameter (order, or rpm), solved
    /// there.
    pub at_second_max: Vec<f64>,
    /// Why each end stopped (`left the map`, `most points`, `step too small`).
    pub ends: [String; 2],
    /// Where it crosses each of the analysis's `sections`, solved there.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<Section>,
}

/// A boundary's crossings of one value of the first parameter (a section of the map).
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct Section {
    /// The first parameter's value: excitation order n, or mean speed in rpm.
    pub value: f64,
    /// The second parameter where the boundary crosses it, ascending, in the result's
    /// `second_unit`; each solved exactly with the second parameter free.
    pub second_values: Vec<f64>,
}

/// A codimension-two point of the map.
#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct MapPoint {
    /// What it is.
    pub kind: MapPointKind,
    /// The boundary it lies on (index into the result's boundaries).
    pub boundary: usize,
    /// The first parameter: excitation order n, or mean speed in rpm.
    pub value: f64,
    /// The second parameter, in the result's `second_unit`.
    pub second_value: f64,
}

/// An operating envelope's result.
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct EnvelopeResult {
    /// The analysis's name.
    pub name: String,
    /// The plane's first parameter: `order` (at `held` rpm), `speed_rpm` (at order `held`) or
    /// `torque_N_m` (at order `held`, the speed in `fixed`).
    pub parameter: String,
    /// The other of mean speed (rpm) and order, held fixed (0 on the (order, speed) plane, whose
    /// second parameter is the speed).
    pub held: f64,
    /// The map's range of its first parameter (order, rpm or N·m).
    pub range: [f64; 2],
    /// The second parameter's CSV column: `torque_N_m` (a single order's amplitude),
    /// `scale_of_set` (the common scale of a multi-order set, dimensionless) or
    /// `<name>_<unit>` (a mechanism parameter).
    pub second: String,
    /// The second parameter's unit: `N·m`, `1 (scale of the set)` or the parameter's SI unit.
    pub second_unit: String,
    /// The second parameter in words (the chart's axis).
    pub second_label: String,
    /// What the plane holds fixed besides `held` (the torque of a mechanism-parameter plane),
    /// empty otherwise.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub fixed: String,
    /// The map's range of its second parameter, in `second_unit`.
    pub second_range: [f64; 2],
    /// Whether the chart's second axis is logarithmic.
    pub log_second: bool,
    /// The harmonic-balance route (`cyclic (…)` with the identical sets, or `general (why)`).
    pub route: String,
    /// The seed branches' values of the second parameter, in `second_unit`.
    pub seeds: Vec<f64>,
    /// The boundaries.
    pub boundaries: Vec<Boundary>,
    /// The codimension-two points.
    pub points: Vec<MapPoint>,
    /// Where period doublings were searched, in words: along the seed branches, or why not
    /// (no linear parametric resonance near the map).
    pub period_doubling_search: String,
    /// Wall time of the whole map, s.
    pub time_s: f64,
}

impl EnvelopeResult {
    /// "at R rpm" or "at order n", what the plane holds fixed.
    fn held_words(&self) -> String {
        if self.speed_is_second() {
            format!("at {}", self.fixed)
        } else if self.parameter == "order" {
            format!("at {} rpm", num(self.held, 6))
        } else {
            format!("at order {}", num(self.held, 6))
        }
    }

    /// Whether the second parameter is the mean speed (the (order, speed) plane: nothing of
    /// `held`, the torque in `fixed`).
    fn speed_is_second(&self) -> bool {
        self.second_unit == "rpm"
    }

    /// Whether the second parameter is a mechanism parameter (not a torque or a scale).
    fn on_mechanism(&self) -> bool {
        !matches!(self.second.as_str(), TORQUE_COLUMN | SCALE_COLUMN)
    }

    /// A value of the second parameter in words: `3.6 N·m`, `s = 0.93` or `c_p = 0.002 N·m·s/rad`.
    fn second_words(&self, v: f64, sig: usize) -> String {
        match self.second.as_str() {
            TORQUE_COLUMN => format!("{} N·m", num(v, sig)),
            SCALE_COLUMN => format!("s = {}", num(v, sig)),
            column => format!("{column} = {} {}", num(v, sig), self.second_unit),
        }
    }

    /// A value of the first parameter in words: `n = 3.1`, `812 rpm` or `40 N·m`.
    fn value_words(&self, v: f64, sig: usize) -> String {
        format!("{}{}", num(v, sig), self.first_unit())
    }

    /// The first parameter's unit as a suffix: nothing for an order, ` rpm`, ` N·m`.
    fn first_unit(&self) -> &'static str {
        match self.parameter.as_str() {
            "order" => "",
            TORQUE_COLUMN => " N·m",
            _ => " rpm",
        }
    }

    /// Its CSV table: one row per boundary point, then one per codimension-two point; columns
    /// `boundary`, `kind`, the first parameter (`order` or `speed_rpm`) and the second
    /// (`torque_N_m`, `scale_of_set` or the mechanism parameter's column).
    pub fn table(&self) -> Table {
        let (mut curve, mut kind, mut order, mut torque) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (i, b) in self.boundaries.iter().enumerate() {
            for (&n, &t) in b.values.iter().zip(&b.second_values) {
                curve.push((i + 1) as f64);
                kind.push(b.kind.code());
                order.push(n);
                torque.push(t);
            }
        }
        for p in &self.points {
            curve.push((p.boundary + 1) as f64);
            kind.push(p.kind.code());
            order.push(p.value);
            torque.push(p.second_value);
        }
        let mut t = Table::new(self.name.clone());
        t.push("boundary", "1", curve);
        t.push("kind", "1", kind);
        let unit = match self.parameter.as_str() {
            "order" => "1",
            TORQUE_COLUMN => "N·m",
            _ => "rpm",
        };
        t.push(self.parameter.clone(), unit, order);
        // The table's units are static strings: the second's is one of the quantities' own.
        const UNITS: [&str; 9] = ["N·m", "kg", "kg·m²", "m", "N·m/rad", "N/m", "N·s/m", "N·m·s/rad", "rpm"];
        let unit = UNITS.into_iter().find(|u| *u == self.second_unit).unwrap_or("1");
        t.push(self.second.clone(), unit, torque);
        t
    }
}

/// The CSV column of a multi-order set's scale.
const SCALE_COLUMN: &str = "scale_of_set";

/// Runs the map, writes its CSV and SVG and returns its summary section.
pub(crate) fn run(study: &Study, spec: &EnvelopeSpec, dir: &Path) -> Result<Output> {
    let (r, failures) = compute(study, spec)?;
    let csv = r.table().write_csv(dir)?;
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel(&r)], 720, 520)?;
    Ok(Output { markdown: markdown(&r), files: vec![csv, svg], failures, results: Box::new(r) })
}

impl super::analysis::Kept for EnvelopeResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.envelopes.push(*self);
    }
}
