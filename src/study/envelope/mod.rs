//! The operating envelope (issue 28, items 1 and 2): the boundaries of the steady response in a
//! plane of two parameters, each a curve of codimension-one points followed by two-parameter
//! continuation (`hbm::fold2`, the minimally augmented systems of Govaerts 2000, §4.3.2), with the
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

mod analysis;
mod spec;

pub use spec::{EnvelopeParameter, EnvelopePlane, EnvelopeSpec};

use super::analysis::Output;
use super::hbm::hbm_error;
use super::table::Table;
use super::{Study, StudyReport};
use crate::error::Result;
use crate::hbm::{
    ContinuationOptions, FoldCurve, FoldCurveOptions, FoldCurvePoint, FoldPlane, Hbm, HbmError, HbmOptions,
    HbmSolution, MechanismFamily, Parameter, RoutedHbm, Singularity,
};
use crate::kane::Kane;
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::plot::{LineStyle, Panel, PointLabel, Series, num};
use schemars::JsonSchema;
use serde::Serialize;
use std::fmt::Write as _;
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

/// The orders where boundary `b`'s polyline crosses the second parameter's value `t` (linear
/// between points in the chart's coordinate `f`: log T, or the value itself), ascending.
fn crossings(b: &Boundary, t: f64, f: impl Fn(f64) -> f64) -> Vec<f64> {
    let lt = f(t);
    let mut out: Vec<f64> = b
        .values
        .windows(2)
        .zip(b.second_values.windows(2))
        .filter_map(|(n, tq)| {
            let (a, c) = (f(tq[0]) - lt, f(tq[1]) - lt);
            if a * c > 0.0 || a == c {
                return None;
            }
            let w = a / (a - c);
            Some(n[0] + w * (n[1] - n[0]))
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    out
}

/// The CSV column of a multi-order set's scale.
const SCALE_COLUMN: &str = "scale_of_set";

/// `SEEDS` values from `hi` down to `lo`, evenly in the logarithm (both ends included).
fn log_spaced(lo: f64, hi: f64) -> Vec<f64> {
    let (lo, hi) = (lo.ln(), hi.ln());
    (0..SEEDS).map(|k| (hi - (hi - lo) * k as f64 / (SEEDS - 1) as f64).exp()).collect()
}

/// The plane's second parameter as the continuation sees it (the torque scale s of the
/// problem's excitation) and as the results give it.
struct Second {
    /// The excitation the problem is built with (its s = 1).
    harmonics: Vec<Harmonic>,
    /// Results' unit per unit of s: the reference torque of a single order (N·m), 1 for a set.
    per_scale: f64,
    /// Whether s is the mean speed, rad/s (given in rpm).
    speed: bool,
    /// A mechanism parameter's range as written (a speed's would not come back exactly from
    /// rad/s).
    shown: Option<(f64, f64)>,
    /// The range of s.
    range: (f64, f64),
    /// The seed branches' values of s.
    seeds: Vec<f64>,
    column: String,
    unit: String,
    label: String,
    /// Whether the chart spaces it logarithmically.
    log: bool,
    /// What a mechanism parameter's plane holds fixed, in words (empty otherwise).
    fixed: String,
}

impl Second {
    fn of(study: &Study, spec: &EnvelopeSpec) -> Self {
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
    fn value(&self, s: f64) -> f64 {
        if self.speed { s * 60.0 / (2.0 * std::f64::consts::PI) } else { s * self.per_scale }
    }

    /// A value in the results' unit, in words.
    fn words(&self, v: f64) -> String {
        match self.column.as_str() {
            TORQUE_COLUMN => format!("{} N·m", num(v, 6)),
            SCALE_COLUMN => format!("scale {}", num(v, 6)),
            column => format!("{column} = {} {}", num(v, 6), self.unit),
        }
    }
}

/// The study's mechanism with the envelope's parameter `par` at `p` (its unit), checked.
fn mechanism_at(study: &Study, par: &EnvelopeParameter, p: f64) -> Result<crate::model::mechanism::Mechanism> {
    let err = |m: String| crate::error::Error::Model {
        mechanism: study.mechanism.name.clone(),
        message: format!("{} = {p}: {m}", par.name),
    };
    let mut mech = study.mechanism.clone();
    super::design::set_quantity(&mut mech, &par.quantity, p).map_err(err)?;
    super::design::check_masses(&mech).map_err(err)?;
    Ok(mech)
}

/// A curve being mapped: its kind, its test, and the walks from its start both ways.
struct Walked {
    kind: BoundaryKind,
    set: Option<String>,
    test: Singularity,
    /// The down walk reversed, then the up walk (its start dropped).
    points: Vec<FoldCurvePoint>,
    curves: Vec<FoldCurve>,
    ends: [String; 2],
}

/// The plane's first parameter as the continuation sees it (n, or Ω in rad/s) and as the
/// results give it (n, or rpm).
#[derive(Debug, Clone, Copy)]
struct Axis {
    fold: FoldPlane,
    param: Parameter,
    /// Its range, n or rad/s.
    range: (f64, f64),
    /// The mean speed the problem is built at, rad/s.
    omega: f64,
    /// Results' unit per continuation unit (1, or rpm per rad/s).
    to_unit: f64,
}

impl Axis {
    fn of(spec: &EnvelopeSpec) -> Self {
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
    fn value(&self, order: f64, omega: f64, scale: f64) -> f64 {
        match self.fold {
            FoldPlane::Order => order,
            FoldPlane::Speed { .. } => omega * self.to_unit,
            FoldPlane::Torque { .. } => scale * self.to_unit,
        }
    }
}

/// The singular points of `test` on `branch` (torque scale s): folds for the Jacobian, sign
/// changes of the block's determinant otherwise; each localised at s from the nearer state.
fn seeds_on(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    test: Singularity,
    branch: &crate::hbm::Branch,
    s: f64,
) -> Vec<FoldCurvePoint> {
    let guesses: Vec<HbmSolution> = match test {
        Singularity::Jacobian => branch.folds.iter().map(|f| branch.points[f.after].solution.clone()).collect(),
        Singularity::Block { .. } => {
            let signs: Vec<f64> = branch.points.iter().map(|p| hbm.singularity_sign(&p.solution, test)).collect();
            signs
                .windows(2)
                .enumerate()
                .filter(|(_, w)| w[0] * w[1] < 0.0)
                .map(|(i, _)| branch.points[i].solution.clone())
                .collect()
        }
        // The envelope draws no period-doubling curves yet (they are continued on the problem of
        // half the base frequency, which its seed branches are not).
        Singularity::HalfPeriod | Singularity::HalfPeriodBlock { .. } => Vec::new(),
    };
    guesses.iter().filter_map(|g| hbm.singular_at_with(ax.fold, family, test, s, g).ok()).collect()
}

/// The values `solve` gives from the walked curve `w`'s nearer point of each pair of consecutive
/// points across which `offset` changes sign, repeats within `tol` dropped, ascending.
fn solved_crossings(
    w: &Walked,
    offset: impl Fn(&FoldCurvePoint) -> f64,
    mut solve: impl FnMut(&FoldCurvePoint) -> Option<f64>,
    tol: f64,
) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for pair in w.points.windows(2) {
        let (a, b) = (offset(&pair[0]), offset(&pair[1]));
        if a * b > 0.0 {
            continue;
        }
        let near = if a.abs() < b.abs() { &pair[0] } else { &pair[1] };
        if let Some(v) = solve(near)
            && !out.iter().any(|&n| (n - v).abs() <= tol)
        {
            out.push(v);
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

/// The values (axis unit) where the walked curve `w` crosses the second parameter's value `s`
/// (the torque scale, or p on a mechanism plane): each solved at `s`, repeats (within
/// [`SAME_CURVE`] of the range) dropped, ascending.
fn crossings_at(hbm: &mut Hbm, ax: &Axis, family: Option<&MechanismFamily<'_>>, w: &Walked, s: f64) -> Vec<f64> {
    let solve = |near: &FoldCurvePoint| {
        let p = hbm.singular_at_with(ax.fold, family, w.test, s, &near.solution).ok()?;
        Some(ax.value(p.order, p.omega, p.scale))
    };
    solved_crossings(w, |p| p.parameter - s, solve, SAME_CURVE * ax.range.1 * ax.to_unit)
}

/// The second parameter (s, or p) where the walked curve `w` crosses the first parameter's
/// value `v` (results' unit: order, or rpm): each solved at `v`, the second parameter free,
/// those inside `range` kept, repeats (within [`SAME_CURVE`] of it) dropped, ascending.
fn sections_at(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    range: (f64, f64),
    w: &Walked,
    v: f64,
) -> Vec<f64> {
    let solve = |near: &FoldCurvePoint| {
        let p =
            hbm.singular_at_value_with(ax.fold, family, w.test, v / ax.to_unit, near.parameter, &near.solution).ok()?;
        (range.0..=range.1).contains(&p.parameter).then_some(p.parameter)
    };
    solved_crossings(w, |p| ax.value(p.order, p.omega, p.scale) - v, solve, SAME_CURVE * range.1.abs())
}

/// Whether `seed` lies on one of `walked` (same test): one of the curve's crossings of the
/// seed's second parameter is the seed.
fn covered(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    walked: &[Walked],
    test: Singularity,
    seed: &FoldCurvePoint,
) -> bool {
    let v = ax.value(seed.order, seed.omega, seed.scale);
    walked.iter().filter(|w| w.test == test).any(|w| {
        crossings_at(hbm, ax, family, w, seed.parameter)
            .iter()
            .any(|&n| (n - v).abs() <= SAME_CURVE * ax.range.1 * ax.to_unit)
    })
}

/// One boundary through `seed`, followed both ways in the second parameter on `hk` (its kind,
/// identical set and test); each walk that fails is a failure after `origin` (where it was
/// seeded).
#[allow(clippy::too_many_arguments)]
fn walk_boundary(
    hk: &mut Hbm,
    ax: &Axis,
    fam: Option<&MechanismFamily<'_>>,
    seed: &FoldCurvePoint,
    (kind, set, test): (BoundaryKind, Option<String>, Singularity),
    fopts: &FoldCurveOptions,
    failures: &mut Vec<String>,
    origin: &str,
) -> Walked {
    let fo = FoldCurveOptions { test, ..*fopts };
    let mut w =
        Walked { kind, set, test, points: Vec::new(), curves: Vec::new(), ends: [String::new(), String::new()] };
    for (k, up) in [false, true].into_iter().enumerate() {
        match hk.continue_fold_with(ax.fold, fam, seed, up, &fo) {
            Ok(c) => {
                w.ends[k] = end_words(&c);
                if up {
                    w.points.extend(c.points.iter().skip(1).cloned());
                } else {
                    w.points.extend(c.points.iter().rev().cloned());
                }
                w.curves.push(c);
            }
            Err(e) => {
                w.ends[k] = format!("failed: {e}");
                if !up {
                    w.points.push(seed.clone());
                }
                failures.push(format!("{origin}, {} in the second parameter: {e}", if up { "up" } else { "down" }));
            }
        }
    }
    w
}

/// Sub-intervals per step of a seed branch at which [`doubling_seeds`] tests for a period
/// doubling: a tongue is often narrower than the seed branch's step (0.05 wide in n at 2000 N·m
/// on the paper's rotor against steps of 0.1), and the states between points come from the
/// branch's Hermite interpolation, without a solve.
const DOUBLING_SUBSTEPS: usize = 10;

/// The period doublings of the seed branch `branch` (on the problem at the base frequency, at
/// scale `s`, or at p = `s` of a mechanism family), each solved on the problem of half the base
/// frequency `h2` (at that s or p; `family` the half-frequency problems' family) with its test: where
/// the sign of a test's determinant (the odd-harmonic block, or its part of an identical set's
/// representative) changes between two of the branch's points or interpolated states.
fn doubling_seeds(
    h2: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    branch: &crate::hbm::Branch,
    s: f64,
    tests: &[Singularity],
) -> Vec<(Singularity, FoldCurvePoint)> {
    let mut states: Vec<HbmSolution> = Vec::new();
    for i in 0..branch.points.len() {
        states.push(branch.points[i].solution.clone());
        if i + 1 < branch.points.len() {
            states.extend(
                (1..DOUBLING_SUBSTEPS).filter_map(|j| branch.interpolate(i, j as f64 / DOUBLING_SUBSTEPS as f64)),
            );
        }
    }
    let doubled: Vec<HbmSolution> = states.iter().filter_map(|p| h2.on_doubled_period(p, p.order).ok()).collect();
    let signs: Vec<Vec<f64>> = doubled.iter().map(|d| h2.singularity_signs(d, tests)).collect();
    let mut seeds = Vec::new();
    for (k, &test) in tests.iter().enumerate() {
        for (i, w) in signs.windows(2).enumerate() {
            if w[0][k] * w[1][k] < 0.0
                && let Ok(p) = h2.singular_at_with(ax.fold, family, test, s, &doubled[i])
            {
                seeds.push((test, p));
            }
        }
    }
    seeds
}

/// How far (as a factor either way) a period-doubling tongue is looked for from the linear
/// parametric resonance it grows from: the amplitude shifts an absorber's tuning (a circular
/// path's order falls by 15 % at a 90° swing) and a tongue widens with the pump.
const DOUBLING_MARGIN: f64 = 1.3;

/// Whether the map can hold a period doubling, from the linearised mechanism (free spin, no
/// damping) at the map's mean speeds: a multiplier −1 over the base period T_b grows from the
/// parametric resonance of a mode of eigen-order o with a pump of order e (a harmonic of the
/// response, the excitation's own orders first) where o ≈ k·e/2 for k = 1 (the principal
/// Mathieu tongue) or 3, and only where k·e/e_b is odd (e_b the base order: an even multiple
/// makes the mode's motion repeat over T_b, a +1 tongue). Ok(words) when some resonance lies
/// within [`DOUBLING_MARGIN`] of the map's orders (and when the linear model fails: then the
/// search runs), Err(words) when none does and the search is skipped. `mechanisms`: the study's
/// mechanism, or on a mechanism parameter's plane the mechanism at both ends of its range;
/// `speeds`: the map's (rad/s); each eigen-order's range spans every pair of the two.
fn doubling_screen(
    mechanisms: &[crate::model::mechanism::Mechanism],
    spin_joint: &str,
    ax: &Axis,
    speeds: &[f64],
    harmonics: &[Harmonic],
    ratio: f64,
) -> std::result::Result<String, String> {
    use crate::linear::{Damping, LinearModel, ModeKind, Spin};
    let searched = "searched along the seed branches".to_string();
    // The base order's range (the eigen-orders are taken at each of `speeds`, rad/s).
    let n = match ax.fold {
        FoldPlane::Order => ax.range,
        FoldPlane::Speed { order } | FoldPlane::Torque { order } => (order, order),
    };
    let cases = mechanisms.iter().flat_map(|m| speeds.iter().map(move |&omega| (m, omega)));
    let mut orders: Vec<(f64, f64)> = Vec::new();
    for (i, (mech, omega)) in cases.enumerate() {
        let modal =
            LinearModel::new(mech, spin_joint, omega, None).and_then(|m| m.modes(Spin::Free, Damping::Undamped));
        let Ok(modal) = modal else { return Ok(searched) };
        let vib = modal.modes.iter().filter(|m| m.kind == ModeKind::Vibration && m.order.is_finite());
        for (j, o) in vib.map(|m| m.order).enumerate() {
            if i == 0 {
                orders.push((o, o));
            } else if let Some(r) = orders.get_mut(j) {
                *r = (r.0.min(o), r.1.max(o));
            }
        }
    }
    for h in harmonics.iter().filter(|h| h.amplitude != 0.0) {
        let m = (h.multiple / ratio).round() as i64;
        for k in [1_i64, 3] {
            if (k * m) % 2 == 0 {
                continue;
            }
            let lo = 0.5 * k as f64 * h.multiple * n.0.min(n.1) / DOUBLING_MARGIN;
            let hi = 0.5 * k as f64 * h.multiple * n.0.max(n.1) * DOUBLING_MARGIN;
            if let Some(o) = orders.iter().find(|o| o.1 >= lo && o.0 <= hi) {
                return Ok(format!(
                    "{searched}: the linear eigen-order {} is near {k}/2 of the excitation's order {}",
                    num(o.0, 5),
                    num(h.multiple * 0.5 * (n.0 + n.1), 5)
                ));
            }
        }
    }
    Err(format!(
        "not searched: no linear eigen-order lies within a factor {DOUBLING_MARGIN} of k/2 of an excitation order \
         (k = 1, 3, the parametric resonances that double the period)"
    ))
}

/// Where the unison-loss curve `c` (its test `test`, a representative's block) meets a fold:
/// its states where the whole Jacobian of the unison problem is singular too. Along the curve
/// the sign of that determinant changes there (the curve crosses the fold line of the
/// response surface); each change between two of its points is bisected in the second
/// parameter, the states solved on the curve at each value from the nearer point, until the
/// bracket is [`MEET_TOL`] of the value wide. On a mechanism parameter's plane (`family`) each
/// state's determinant is that of the problem built at its own p (the layouts are the same, so
/// the sign is continuous along the curve).
fn meets_fold(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    test: Singularity,
    c: &FoldCurve,
) -> Vec<FoldCurvePoint> {
    let sign = |hbm: &mut Hbm, p: &FoldCurvePoint| -> Option<f64> {
        match family {
            None => Some(hbm.singularity_sign(&p.solution, Singularity::Jacobian)),
            Some(f) => {
                let mut at = (f.build)(p.parameter).ok()?;
                at.set_torque_scale(f.scale).ok()?;
                Some(at.singularity_sign(&p.solution, Singularity::Jacobian))
            }
        }
    };
    let signs: Vec<Option<f64>> = c.points.iter().map(|p| sign(hbm, p)).collect();
    let mut out = Vec::new();
    for (i, w) in signs.windows(2).enumerate() {
        let (Some(sign_a), Some(sign_b)) = (w[0], w[1]) else { continue };
        if sign_a * sign_b >= 0.0 {
            continue;
        }
        let (mut a, mut b) = (c.points[i].clone(), c.points[i + 1].clone());
        while (a.parameter - b.parameter).abs() > MEET_TOL * a.parameter.abs().max(b.parameter.abs()) {
            let mid = 0.5 * (a.parameter + b.parameter);
            let near = if (mid - a.parameter).abs() <= (mid - b.parameter).abs() { &a } else { &b };
            let Ok(m) = hbm.singular_at_with(ax.fold, family, test, mid, &near.solution) else { break };
            match sign(hbm, &m) {
                Some(s) if s == sign_a => a = m,
                Some(_) => b = m,
                None => break,
            }
        }
        out.push(b);
    }
    out
}

/// Relative width in the second parameter to which [`meets_fold`] brackets a meeting.
const MEET_TOL: f64 = 1e-10;

fn end_words(c: &FoldCurve) -> String {
    match c.end {
        crate::hbm::FoldCurveEnd::LeftBox => "left the map",
        crate::hbm::FoldCurveEnd::MaxPoints => "most points",
        crate::hbm::FoldCurveEnd::StepTooSmall => "step too small",
    }
    .into()
}

/// Largest arclength step of a seed branch, twice the default: the seeds' crossings are found
/// by sign changes of test functions at any step (`hbm::continuation`), and each seed is then
/// solved exactly on its curve, so a coarser branch finds the same boundaries (on the paper's
/// map the same points to the bit; BENCHMARKS.md has the cost).
const SEED_DS_MAX: f64 = 0.2;

/// The map: every boundary its seeds reach, with its codimension-two points; a seed branch or a
/// walk that fails is listed and the rest kept.
pub(crate) fn compute(study: &Study, spec: &EnvelopeSpec) -> Result<(EnvelopeResult, Vec<String>)> {
    let start = std::time::Instant::now();
    let kane = study.kane(false)?;
    let inputs = study.excited_joints(&study.mechanism, &spec.excite);
    let second = Second::of(study, spec);
    let opts = HbmOptions { harmonics: spec.harmonics, stability_samples: 0, ..HbmOptions::default() };
    let mut ax = Axis::of(spec);
    if spec.speed_is_second() {
        // The layout problem's speed (each state's own is the second parameter).
        ax.omega = second.range.0;
    }
    let forcing = (&second.harmonics[..], &[][..]);
    let (mut routed, general) = match &spec.parameter {
        None => (RoutedHbm::new(&kane, study.spin, ax.omega, forcing, &inputs, opts).map_err(hbm_error(study))?, false),
        Some(par) => {
            // One route along the whole range: the cyclic one only where the mechanism keeps its
            // identical sets at both ends (a parameter of one absorber of a set parts them).
            let at = |p: f64| -> Result<RoutedHbm> {
                let k = Kane::new(&mechanism_at(study, par, p)?)?;
                RoutedHbm::new(&k, study.spin, ax.omega, forcing, &inputs, opts).map_err(hbm_error(study))
            };
            let (lo, hi) = (at(par.from)?, at(par.to)?);
            let cyclic = |r: &RoutedHbm| matches!(r.route(), crate::hbm::Route::Cyclic { .. });
            if cyclic(&lo) && cyclic(&hi) && lo.hbm().unknowns() == hi.hbm().unknowns() {
                (lo, false)
            } else {
                let k = Kane::new(&mechanism_at(study, par, par.from)?)?;
                (
                    RoutedHbm::new_general(&k, study.spin, ax.omega, forcing, &inputs, opts)
                        .map_err(hbm_error(study))?,
                    true,
                )
            }
        }
    };
    let route = routed.route().to_string();
    // The problem of half the base frequency (the extra multiple at zero amplitude, twice the
    // harmonics), on which period doublings are followed.
    let ratio = routed.hbm().base_frequency(1.0) / routed.hbm().omega();
    let mut halved = second.harmonics.clone();
    halved.push(Harmonic { multiple: 0.5 * ratio, amplitude: 0.0, phase: 0.0 });
    let opts2 = HbmOptions { harmonics: 2 * spec.harmonics, ..opts };
    // The problem at a value of a mechanism parameter, on the route chosen, with the forcing
    // and options given (the base frequency's, or half of it).
    let build_with = |p: f64, forcing, opts| -> std::result::Result<Hbm, HbmError> {
        let par = spec.parameter.as_ref().ok_or_else(|| HbmError::Invalid("no mechanism parameter".into()))?;
        // The speed's problems share the study's mechanism; a mechanism parameter's are at the
        // map's speed.
        let rebuilt;
        let (k, omega) = if spec.speed_is_second() {
            (&kane, p)
        } else {
            let mech = mechanism_at(study, par, p).map_err(|e| HbmError::Invalid(e.to_string()))?;
            rebuilt = Kane::new(&mech).map_err(|e| HbmError::Invalid(format!("{} = {p}: {e}", par.name)))?;
            (&rebuilt, ax.omega)
        };
        let r = if general {
            RoutedHbm::new_general(k, study.spin, omega, forcing, &inputs, opts)?
        } else {
            RoutedHbm::new(k, study.spin, omega, forcing, &inputs, opts)?
        };
        Ok(r.hbm().clone())
    };
    let build = |p: f64| build_with(p, forcing, opts);
    let build_half = |p: f64| build_with(p, (&halved[..], &[][..]), opts2);
    let (reference, speed) = (second.range.0.abs().max(second.range.1.abs()), spec.speed_is_second());
    let family = spec.parameter.as_ref().map(|_| MechanismFamily { build: &build, scale: 1.0, reference, speed });
    let family_half =
        spec.parameter.as_ref().map(|_| MechanismFamily { build: &build_half, scale: 1.0, reference, speed });
    let (fam, fam_half) = (family.as_ref(), family_half.as_ref());
    let hbm = routed.hbm_mut();
    let mut tests = vec![(BoundaryKind::Jump, None, Singularity::Jacobian)];
    tests.extend(hbm.unison_loss_tests().into_iter().map(|(l, t)| (BoundaryKind::UnisonLoss, Some(l), t)));
    let fopts = FoldCurveOptions { range: ax.range, scales: second.range, ..FoldCurveOptions::default() };
    // On a mechanism parameter's plane the linear screen looks at the mechanism at both ends of
    // the range, and the half-frequency problems are the family's too.
    let screened = match &spec.parameter {
        Some(par) if !speed => [par.from, par.to].iter().filter_map(|&p| mechanism_at(study, par, p).ok()).collect(),
        _ => vec![study.mechanism.clone()],
    };
    let speeds = match ax.fold {
        FoldPlane::Order if speed => vec![second.range.0, second.range.1],
        FoldPlane::Order | FoldPlane::Torque { .. } => vec![ax.omega],
        FoldPlane::Speed { .. } => vec![ax.range.0, ax.range.1],
    };
    let screen = doubling_screen(&screened, &study.spec.spin_joint, &ax, &speeds, &second.harmonics, ratio);
    // The half-frequency problem the period-doubling curves are evaluated on (on a mechanism
    // parameter's plane the one at its lower end, for the layout only).
    let mut half: Option<Hbm> = match (&screen, &spec.parameter) {
        (Err(_), _) => None,
        (Ok(_), None) => RoutedHbm::new(&kane, study.spin, ax.omega, (&halved[..], &[][..]), &inputs, opts2)
            .ok()
            .map(|r| r.hbm().clone()),
        (Ok(_), Some(_)) => build_half(second.range.0).ok(),
    };
    // The seed branches only supply starting points (each seed is solved exactly on its curve
    // by `singular_at`): guesses at a loose corrector tolerance with one-sided derivatives, as
    // the multi-order analysis's order branches (`study::hbm::branch`).
    let copts = ContinuationOptions {
        stability: false,
        refine_folds: false,
        one_sided: true,
        corrector_tol: Some(super::hbm::GUESS_TOL),
        deadline: study.spec.integration.deadline,
        ds_max: SEED_DS_MAX,
        ..ContinuationOptions::default()
    };
    let mut failures = Vec::new();
    let mut walked: Vec<Walked> = Vec::new();
    // A speed branch starts at the highest speed, where the torque is smallest against the
    // centrifugal stiffness (∝ Ω²) and the one state there is the small one: from the lowest,
    // it may start on a large state that never folds back (the Table 1 set at 500 rpm). If it
    // fails, from the other end.
    let ends = match ax.fold {
        FoldPlane::Order | FoldPlane::Torque { .. } => ax.range,
        FoldPlane::Speed { .. } => (ax.range.1, ax.range.0),
    };
    for &s in &second.seeds {
        // The seed's problem: this one at torque scale s, or the family's at p = s.
        let mut own;
        let hk: &mut Hbm = match fam {
            None => &mut *hbm,
            Some(f) => match (f.build)(s) {
                Ok(h) => {
                    own = h;
                    &mut own
                }
                Err(e) => {
                    failures.push(format!("{}: seed branch at {}: {e}", spec.name, second.words(s)));
                    continue;
                }
            },
        };
        let scale = fam.map_or(s, |f| f.scale);
        let branch = hk
            .set_torque_scale(scale)
            .and_then(|()| hk.continue_in(ax.param, ends.0, ends.1, None, &copts))
            .or_else(|e| hk.continue_in(ax.param, ends.1, ends.0, None, &copts).map_err(|_| e));
        let branch = match branch {
            Ok(b) => b,
            Err(e) => {
                failures.push(format!("{}: seed branch at {}: {e}", spec.name, second.words(second.value(s))));
                continue;
            }
        };
        // Where a boundary was seeded, for its failures.
        let origin = |kind: BoundaryKind, seed: &FoldCurvePoint| {
            format!(
                "{}: {} boundary from {} at {}",
                spec.name,
                kind.words(),
                num(ax.value(seed.order, seed.omega, seed.scale), 8),
                second.words(second.value(s))
            )
        };
        for (kind, set, test) in &tests {
            for seed in seeds_on(hk, &ax, fam, *test, &branch, s) {
                if covered(hk, &ax, fam, &walked, *test, &seed) {
                    continue;
                }
                let origin = origin(*kind, &seed);
                let w = walk_boundary(hk, &ax, fam, &seed, (*kind, set.clone(), *test), &fopts, &mut failures, &origin);
                walked.push(w);
            }
        }
        // Period doublings, on the problem of half the base frequency at the same scale (or
        // the family's at the same p).
        let mut own_half;
        let h2: Option<&mut Hbm> = match (fam_half, half.as_mut()) {
            (_, None) => None,
            (None, Some(h2)) => Some(h2),
            (Some(f), Some(_)) => match (f.build)(s) {
                Ok(h) => {
                    own_half = h;
                    Some(&mut own_half)
                }
                Err(e) => {
                    failures.push(format!("{}: half-frequency problem at {}: {e}", spec.name, second.words(s)));
                    None
                }
            },
        };
        if let Some(h2) = h2
            && h2.set_torque_scale(scale).is_ok()
        {
            // The set's label of a non-unison doubling (its test the set's representative's
            // block at half the base frequency).
            let mut halves = vec![(None, Singularity::HalfPeriod)];
            halves.extend(h2.unison_loss_tests().into_iter().map(|(l, t)| (Some(l), t.halved())));
            let tests: Vec<Singularity> = halves.iter().map(|h| h.1).collect();
            for (test, seed) in doubling_seeds(h2, &ax, fam_half, &branch, s, &tests) {
                if covered(h2, &ax, fam_half, &walked, test, &seed) {
                    continue;
                }
                let kind = BoundaryKind::PeriodDoubling;
                let set = halves.iter().find(|h| h.1 == test).and_then(|h| h.0.clone());
                let origin = origin(kind, &seed);
                let w = walk_boundary(h2, &ax, fam_half, &seed, (kind, set, test), &fopts, &mut failures, &origin);
                walked.push(w);
            }
        }
    }
    let mut boundaries = Vec::new();
    let mut points = Vec::new();
    for (i, w) in walked.iter().enumerate() {
        // A period-doubling curve lives on the problem of half the base frequency.
        let (hbm, fam): (&mut Hbm, _) = match (w.test, half.as_mut()) {
            (t, Some(h2)) if t.on_half_period() => (h2, fam_half),
            _ => (&mut *hbm, fam),
        };
        let at_top = crossings_at(hbm, &ax, fam, w, second.range.1);
        for c in &w.curves {
            for p in &c.cusps {
                points.push(MapPoint {
                    kind: MapPointKind::Cusp,
                    boundary: i,
                    value: ax.value(p.order, p.omega, p.scale),
                    second_value: second.value(p.parameter),
                });
            }
            if w.kind == BoundaryKind::UnisonLoss {
                for p in meets_fold(hbm, &ax, fam, w.test, c) {
                    points.push(MapPoint {
                        kind: MapPointKind::UnisonLossMeetsJump,
                        boundary: i,
                        value: ax.value(p.order, p.omega, p.scale),
                        second_value: second.value(p.parameter),
                    });
                }
            }
            for p in &c.scale_extrema {
                let kind = match w.kind {
                    BoundaryKind::Jump => MapPointKind::JumpOnset,
                    BoundaryKind::UnisonLoss => MapPointKind::UnisonLossOnset,
                    BoundaryKind::PeriodDoubling => MapPointKind::PeriodDoublingOnset,
                };
                points.push(MapPoint {
                    kind,
                    boundary: i,
                    value: ax.value(p.order, p.omega, p.scale),
                    second_value: second.value(p.parameter),
                });
            }
        }
        let sections = spec
            .sections
            .iter()
            .map(|&v| Section {
                value: v,
                second_values: sections_at(hbm, &ax, fam, second.range, w, v)
                    .into_iter()
                    .map(|s| second.value(s))
                    .collect(),
            })
            .collect();
        boundaries.push(Boundary {
            sections,
            kind: w.kind,
            set: w.set.clone(),
            values: w.points.iter().map(|p| ax.value(p.order, p.omega, p.scale)).collect(),
            second_values: w.points.iter().map(|p| second.value(p.parameter)).collect(),
            at_second_max: at_top,
            ends: w.ends.clone(),
        });
    }
    let result = EnvelopeResult {
        name: spec.name.clone(),
        parameter: match spec.plane {
            EnvelopePlane::Order => "order".into(),
            EnvelopePlane::Speed { .. } => "speed_rpm".into(),
            EnvelopePlane::Torque { .. } => TORQUE_COLUMN.into(),
        },
        held: match spec.plane {
            EnvelopePlane::Order => spec.rpm,
            EnvelopePlane::Speed { order, .. } | EnvelopePlane::Torque { order, .. } => order,
        },
        range: match spec.plane {
            EnvelopePlane::Torque { torque_min, torque_max, .. } => [torque_min, torque_max],
            _ => [ax.range.0 * ax.to_unit, ax.range.1 * ax.to_unit],
        },
        second_range: second
            .shown
            .map_or([second.value(second.range.0), second.value(second.range.1)], |(lo, hi)| [lo, hi]),
        second: second.column.clone(),
        second_unit: second.unit.clone(),
        second_label: second.label.clone(),
        fixed: second.fixed.clone(),
        log_second: second.log,
        route,
        seeds: second.seeds.iter().map(|&s| second.value(s)).collect(),
        boundaries,
        points,
        period_doubling_search: match screen {
            Ok(w) | Err(w) => w,
        },
        time_s: start.elapsed().as_secs_f64(),
    };
    Ok((result, failures))
}

/// Runs the map, writes its CSV and SVG and returns its summary section.
pub(crate) fn run(study: &Study, spec: &EnvelopeSpec, dir: &Path) -> Result<Output> {
    let (r, failures) = compute(study, spec)?;
    let csv = r.table().write_csv(dir)?;
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel(&r)], 720, 520)?;
    Ok(Output { markdown: markdown(&r), files: vec![csv, svg], failures, results: Box::new(r) })
}

/// A point of the map in unit coordinates: u along the first parameter, v along the second
/// (its logarithm on a logarithmic axis).
type Unit = (f64, f64);

/// The map's unit coordinates of (first, second), and back.
struct Frame {
    n: (f64, f64),
    lt: (f64, f64),
    log: bool,
}

impl Frame {
    fn of(r: &EnvelopeResult) -> Self {
        let log = r.log_second;
        let f = |t: f64| if log { t.ln() } else { t };
        Self { n: (r.range[0], r.range[1]), lt: (f(r.second_range[0]), f(r.second_range[1])), log }
    }
    /// The chart's coordinate of a second-parameter value.
    fn f(&self, t: f64) -> f64 {
        if self.log { t.ln() } else { t }
    }
    fn unit(&self, n: f64, t: f64) -> Unit {
        ((n - self.n.0) / (self.n.1 - self.n.0), (self.f(t) - self.lt.0) / (self.lt.1 - self.lt.0))
    }
    fn back(&self, (u, v): Unit) -> (f64, f64) {
        let t = self.lt.0 + v * (self.lt.1 - self.lt.0);
        (self.n.0 + u * (self.n.1 - self.n.0), if self.log { t.exp() } else { t })
    }
}

/// The position of a point of the unit square's edge along its perimeter, counter-clockwise
/// from the lower-left corner (bottom 0–1, right 1–2, top 2–3, left 3–4), from the nearest edge.
fn perimeter((u, v): Unit) -> f64 {
    let d = [v, 1.0 - u, 1.0 - v, u];
    let edge = (0..4).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
    match edge {
        0 => u,
        1 => 1.0 + v,
        2 => 3.0 - u,
        _ => 4.0 - v,
    }
}

/// The curve (unit coordinates, clamped into the square) closed along the square's edge from
/// its last point back to its first, counter-clockwise when `ccw`, through the corners between.
fn closed(curve: &[Unit], ccw: bool) -> Vec<Unit> {
    const CORNERS: [(f64, Unit); 4] = [(0.0, (0.0, 0.0)), (1.0, (1.0, 0.0)), (2.0, (1.0, 1.0)), (3.0, (0.0, 1.0))];
    let mut out = curve.to_vec();
    let (Some(&last), Some(&first)) = (curve.last(), curve.first()) else { return out };
    let (a, b) = (perimeter(last), perimeter(first));
    // Distance travelled along the perimeter from a, in the walk's direction.
    let along = |t: f64| if ccw { (t - a).rem_euclid(4.0) } else { (a - t).rem_euclid(4.0) };
    let mut corners: Vec<(f64, Unit)> =
        CORNERS.iter().map(|&(t, p)| (along(t), p)).filter(|&(d, _)| d > 0.0 && d < along(b)).collect();
    corners.sort_by(|x, y| x.0.total_cmp(&y.0));
    out.extend(corners.into_iter().map(|(_, p)| p));
    out
}

/// Even–odd point-in-polygon test.
fn contains(poly: &[Unit], (x, y): Unit) -> bool {
    let mut inside = false;
    for (i, &(xa, ya)) in poly.iter().enumerate() {
        let (xb, yb) = poly[(i + 1) % poly.len()];
        if (ya > y) != (yb > y) && x < xa + (y - ya) / (yb - ya) * (xb - xa) {
            inside = !inside;
        }
    }
    inside
}

/// The widest interval of the polygon along the line v = `v` (even–odd), as its midpoint.
fn widest_inside(poly: &[Unit], v: f64) -> Option<Unit> {
    let mut xs: Vec<f64> = (0..poly.len())
        .filter_map(|i| {
            let ((xa, ya), (xb, yb)) = (poly[i], poly[(i + 1) % poly.len()]);
            ((ya > v) != (yb > v)).then(|| xa + (v - ya) / (yb - ya) * (xb - xa))
        })
        .collect();
    xs.sort_by(f64::total_cmp);
    xs.chunks_exact(2).max_by(|a, b| (a[1] - a[0]).total_cmp(&(b[1] - b[0]))).map(|w| (0.5 * (w[0] + w[1]), v))
}

/// A boundary's region as a closed polygon in unit coordinates: the curve closed along the
/// map's edge on the side that holds the region just past one of its codimension-two points
/// (between the two crossings nearest its order, both close to it: inside a jump wedge above
/// its cusp in torque, below it in a damping, inside a unison-loss tongue above its onset).
/// The points are tried from the lowest up, above before below. None for a boundary without
/// such a point, whose inside the map alone cannot tell.
fn region(r: &EnvelopeResult, frame: &Frame, i: usize) -> Option<Vec<Unit>> {
    let b = &r.boundaries[i];
    let mut points: Vec<&MapPoint> = r.points.iter().filter(|p| p.boundary == i).collect();
    points.sort_by(|a, c| a.second_value.total_cmp(&c.second_value));
    let curve: Vec<Unit> = b
        .values
        .iter()
        .zip(&b.second_values)
        .map(|(&n, &t)| {
            let (u, v) = frame.unit(n, t);
            (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0))
        })
        .collect();
    // Just past the point (a hundredth of the way to the map's edge), between the two
    // crossings nearest its order (both lie on one side of a cusp, which is a spike), both within
    // a tenth of the map's width of it.
    let inside = |p: &MapPoint, up: bool| -> Option<Unit> {
        let (up_, vp) = frame.unit(p.value, p.second_value);
        let v = if up { vp + 0.01 * (1.0 - vp) } else { vp - 0.01 * vp };
        let t = frame.back((0.0, v)).1;
        let mut x = crossings(b, t, |t| frame.f(t));
        x.sort_by(|a, c| (a - p.value).abs().total_cmp(&(c - p.value).abs()));
        let (&a, &c) = (x.first()?, x.get(1)?);
        let q = frame.unit(0.5 * (a + c), t);
        let near = |n: f64| (frame.unit(n, t).0 - up_).abs() < 0.1;
        (near(a) && near(c)).then_some(q)
    };
    let q = points.iter().find_map(|p| inside(p, true).or_else(|| inside(p, false)))?;
    [true, false].into_iter().map(|ccw| closed(&curve, ccw)).find(|poly| contains(poly, q))
}

/// The chart: each boundary's region tinted and named, the boundaries drawn, the
/// codimension-two points marked.
fn panel(r: &EnvelopeResult) -> Panel {
    let frame = Frame::of(r);
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let color = |k: BoundaryKind| match k {
        BoundaryKind::Jump => 1,
        BoundaryKind::UnisonLoss => 3,
        BoundaryKind::PeriodDoubling => 5,
    };
    let mut legend = [true, true, true];
    let mut jump_regions = Vec::new();
    for (i, b) in r.boundaries.iter().enumerate() {
        let c = color(b.kind);
        if let Some(poly) = region(r, &frame, i) {
            let (x, y): (Vec<f64>, Vec<f64>) = poly.iter().map(|&p| frame.back(p)).unzip();
            series.push(Series { label: String::new(), x, y, color: c, style: LineStyle::Region });
            // The region's name three quarters of the way up from its lowest point, in its
            // widest part there.
            let low = poly.iter().map(|p| p.1).fold(1.0, f64::min);
            let high = poly.iter().map(|p| p.1).fold(0.0, f64::max);
            // (A region that narrows upwards, a jump wedge below its cusp in a damping, is named a
            // quarter of the way up instead.)
            let at = widest_inside(&poly, low + 0.75 * (high - low))
                .filter(|&q| contains(&poly, q))
                .or_else(|| widest_inside(&poly, low + 0.25 * (high - low)));
            if let Some(at) = at {
                let (x, y) = frame.back(at);
                let text = match b.kind {
                    BoundaryKind::Jump => "several states: jump possible",
                    BoundaryKind::UnisonLoss => "unison lost",
                    BoundaryKind::PeriodDoubling if b.set.is_some() => "period doubled, out of unison",
                    BoundaryKind::PeriodDoubling => "period doubled",
                };
                labels.push(PointLabel { x, y, text: text.into(), marker: false });
            }
            if b.kind == BoundaryKind::Jump {
                jump_regions.push(poly);
            }
        }
        let k = match b.kind {
            BoundaryKind::Jump => 0,
            BoundaryKind::UnisonLoss => 1,
            BoundaryKind::PeriodDoubling => 2,
        };
        let label = if std::mem::take(&mut legend[k]) {
            match b.kind {
                BoundaryKind::Jump => "jump boundary (folds)".to_string(),
                BoundaryKind::UnisonLoss => "unison-loss boundary (+1 branch points)".to_string(),
                BoundaryKind::PeriodDoubling => "period-doubling boundary (−1 multipliers)".to_string(),
            }
        } else {
            String::new()
        };
        let style = if b.kind == BoundaryKind::Jump { LineStyle::Solid } else { LineStyle::Dashed };
        series.push(Series { label, x: b.values.clone(), y: b.second_values.clone(), color: c, style });
    }
    for p in &r.points {
        labels.push(PointLabel {
            x: p.value,
            y: p.second_value,
            text: format!("{} {}, {}", p.kind.words(), r.value_words(p.value, 6), r.second_words(p.second_value, 4)),
            marker: true,
        });
    }
    // "One steady state" where no jump region reaches: the first free one of a few places.
    for at in [(0.2, 0.15), (0.8, 0.15), (0.5, 0.05), (0.15, 0.85), (0.85, 0.85)] {
        if jump_regions.iter().all(|poly| !contains(poly, at)) {
            let (x, y) = frame.back(at);
            labels.push(PointLabel { x, y, text: "one steady state".into(), marker: false });
            break;
        }
    }
    Panel {
        title: format!("Operating envelope {}", r.held_words()),
        x_label: match r.parameter.as_str() {
            "order" => "excitation order n",
            TORQUE_COLUMN => "torque amplitude T, N·m",
            _ => "mean speed, rpm",
        }
        .into(),
        y_label: r.second_label.clone(),
        log_y: r.log_second,
        x_range: Some((r.range[0], r.range[1])),
        y_range: Some((r.second_range[0], r.second_range[1])),
        series,
        labels,
        ..Panel::default()
    }
}

/// Its summary section.
fn markdown(r: &EnvelopeResult) -> String {
    let mut md = format!("## Operating envelope `{}`\n\n", r.name);
    let _ = writeln!(
        md,
        "{}{} over {} {}–{}{} and {} {}–{}, route {}: {} from {} seed branches ({}) in {} s. \
         Each boundary is a curve of folds, of +1 branch points or of period doublings (−1) followed in the \
         plane by two-parameter continuation; figure `{}.svg`, points in `{}.csv` (kind 1: jump boundary, \
         2: unison-loss boundary, 3: period-doubling boundary, 10: cusp, 11: jump onset, 12: unison-loss \
         onset, 13: period-doubling onset, 14: unison loss meets jump).\n",
        if r.speed_is_second() {
            format!("At {}", r.fixed)
        } else if r.parameter == "order" {
            format!("At {} rpm", num(r.held, 6))
        } else {
            format!("At order {}", num(r.held, 6))
        },
        if r.fixed.is_empty() || r.speed_is_second() { String::new() } else { format!(" and {}", r.fixed) },
        match r.parameter.as_str() {
            "order" => "orders",
            TORQUE_COLUMN => "torques",
            _ => "speeds",
        },
        num(r.range[0], 6),
        num(r.range[1], 6),
        r.first_unit(),
        r.second_label,
        num(r.second_range[0], 6),
        num(r.second_range[1], 6),
        r.route,
        super::digest::count(r.boundaries.len(), "boundary", "boundaries"),
        r.seeds.len(),
        r.seeds.iter().map(|t| r.second_words(*t, 4)).collect::<Vec<_>>().join(", "),
        num(r.time_s, 2),
        r.name,
        r.name
    );
    let _ = writeln!(md, "Period doublings: {}.\n", r.period_doubling_search);
    if r.boundaries.is_empty() {
        md += "No boundary crosses the map: one steady state everywhere (no jump, no loss of unison, no period \
               doubling on the seed branches).\n\n";
        return md;
    }
    let _ = writeln!(
        md,
        "| boundary | kind | points | range of the {} | {} at its largest | ends |\n|---|---|---|---|---|---|",
        r.second_label,
        match r.parameter.as_str() {
            "order" => "orders",
            TORQUE_COLUMN => "torques (N·m)",
            _ => "speeds (rpm)",
        }
    );
    for (i, b) in r.boundaries.iter().enumerate() {
        let extra = || r.points.iter().filter(|p| p.boundary == i).map(|p| p.second_value);
        let lo = b.second_values.iter().copied().chain(extra()).fold(f64::INFINITY, f64::min).max(r.second_range[0]);
        let hi =
            b.second_values.iter().copied().chain(extra()).fold(f64::NEG_INFINITY, f64::max).min(r.second_range[1]);
        let kind = match &b.set {
            Some(set) if b.kind == BoundaryKind::PeriodDoubling => format!("{}, out of unison ({set})", b.kind.words()),
            Some(set) => format!("{} ({set})", b.kind.words()),
            None => b.kind.words().to_string(),
        };
        let top: Vec<String> = b.at_second_max.iter().map(|n| num(*n, 8)).collect();
        let _ = writeln!(
            md,
            "| {} | {kind} | {} | {}–{} | {} | {}; {} |",
            i + 1,
            b.values.len(),
            num(lo, 5),
            num(hi, 5),
            if top.is_empty() { "none".into() } else { top.join(", ") },
            b.ends[0],
            b.ends[1]
        );
    }
    md.push('\n');
    let sections: Vec<String> = r
        .boundaries
        .iter()
        .enumerate()
        .flat_map(|(i, b)| {
            b.sections.iter().map(move |sec| {
                let at: Vec<String> = sec.second_values.iter().map(|&v| r.second_words(v, 9)).collect();
                format!(
                    "boundary {} at {}: {}",
                    i + 1,
                    r.value_words(sec.value, 9),
                    if at.is_empty() { "none".into() } else { at.join(", ") }
                )
            })
        })
        .collect();
    if !sections.is_empty() {
        let _ = writeln!(md, "Sections (solved exactly there): {}.\n", sections.join("; "));
    }
    if !r.points.is_empty() {
        let _ = writeln!(
            md,
            "Codimension-two points:\n\n| point | boundary | {} | {} | meaning |\n|---|---|---|---|---|",
            match r.parameter.as_str() {
                "order" => "order",
                TORQUE_COLUMN => "torque (N·m)",
                _ => "speed (rpm)",
            },
            r.second_label
        );
        for p in &r.points {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                p.kind.words(),
                p.boundary + 1,
                num(p.value, 8),
                num(p.second_value, 7),
                p.kind.meaning()
            );
        }
        md.push('\n');
    }
    md += "Regions: one steady state outside the jump boundaries; inside one, three steady states coexist and the \
           response jumps at its edges";
    if r.boundaries.iter().any(|b| b.kind == BoundaryKind::UnisonLoss) {
        md += "; inside a unison-loss boundary the identical absorbers' unison motion is unstable (a non-unison \
               motion takes over)";
    }
    if r.boundaries.iter().any(|b| b.kind == BoundaryKind::PeriodDoubling) {
        md += "; inside a period-doubling boundary the response is unstable against a motion of twice its period \
               (a swing at half the order takes over: see `switch: true` on a harmonic balance)";
    }
    md += ".\n\n";
    md
}

impl super::analysis::Kept for EnvelopeResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.envelopes.push(*self);
    }
}
