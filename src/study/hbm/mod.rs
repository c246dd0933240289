//! Harmonic balance in a study: branches of periodic steady states continued in the excitation
//! order (or the mean speed, or the torque amplitude), stable and unstable, with their folds,
//! drawn over the time-domain sweeps.
//!
//! The room: `compute.rs` (the branches, continued from each end of the range per amplitude),
//! `switch.rs` (branch switching at branch points and period doublings), `tables.rs` (the CSV
//! tables and the counts per branch), `figures.rs` (the branches over the sweeps, the elements,
//! the backbone), `summary.rs` (the section), with `spec.rs` and `analysis.rs`; here the shared
//! continuation helpers (`branch`, `branch_in`), the axis and the cases.

mod analysis;
mod compute;
mod figures;
mod spec;
mod summary;
mod switch;
mod tables;
pub use spec::*;

use compute::compute_with;
pub use compute::parts_absorbers;
pub use tables::BranchFindings;
pub(crate) use tables::{findings, tables};

use super::elements::ElementResponse;
use super::sweep::SweepRun;
use super::{Direction, Output, Study};
use crate::error::{Error, Result};
use crate::hbm::{Branch, ContinuationOptions, HbmError, HbmOptions, HbmSolution, Parameter, PointHook, RoutedHbm};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::signal::OrderTrace;

/// The corrector's tolerance on a branch whose points only serve as starting guesses (max norm
/// of the Newton step, rad): each guess is solved again at the full tolerance where it is used.
pub(crate) const GUESS_TOL: f64 = 1e-6;

/// The smallest cosine between successive tangents on a branch of guesses (25.8°; 11.5° on an
/// analysed branch): the quadratic predictor and the chord's check against another sheet keep
/// such steps on the branch, and the truck study's order branches take half the points.
pub(crate) const GUESS_MIN_COS: f64 = 0.9;
use crate::signal::findings::jump_order;
use std::path::{Path, PathBuf};

/// A periodic state the branch crosses at one of the analysis's `orbits_at` values, solved there
/// by Newton's method from the nearer branch point, with its Floquet stability.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct HbmOrbit {
    /// The value of the continued parameter (order, rpm or N·m).
    pub at: f64,
    /// Response-body acceleration amplitude per reported multiple, rad/s².
    pub accel: Vec<f64>,
    /// Largest peak |relative angle| of the non-spin joints, rad.
    pub relative_angle: f64,
    /// Floquet stability (None: not computed).
    pub stable: Option<bool>,
    /// Largest Floquet multiplier modulus (NaN: not computed).
    pub max_multiplier: f64,
    /// Each reported element, from the Fourier series.
    pub elements: Vec<ElementResponse>,
}

/// One branch of one amplitude.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct HbmBranch {
    /// The analysis name.
    pub analysis: String,
    /// Why and where the branch stopped short of its range (None: it reached an end of it).
    pub stopped_short: Option<String>,
    /// Torque amplitude T_n, N·m (NaN on a torque branch and with an engine).
    pub amplitude: f64,
    /// Orders of the branch points, in continuation order.
    pub order: Vec<f64>,
    /// The continued parameter at the branch points: the order, the speed in rpm, or T_n in N·m.
    pub parameter: Vec<f64>,
    /// Response-body acceleration amplitude per reported multiple (outer index), rad/s².
    pub accel: Vec<Vec<f64>>,
    /// Largest peak |relative angle| of the non-spin joints, rad.
    pub relative_angle: Vec<f64>,
    /// Each reported element at each branch point (outer index: point), from the Fourier series.
    pub elements: Vec<Vec<ElementResponse>>,
    /// Floquet stability per point (None: not computed).
    pub stable: Vec<Option<bool>>,
    /// The states this branch crosses at each of the analysis's `orbits_at` values (empty
    /// without them; and then left out of `results.json`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub orbits: Vec<HbmOrbit>,
    /// Largest Floquet multiplier modulus per point (NaN: not computed): the stability margin,
    /// how far below 1 a stable point sits.
    pub max_multiplier: Vec<f64>,
    /// Fold (turning-point) values of the continued parameter (orders on an order branch).
    pub folds: Vec<f64>,
    /// Other bifurcations: (order, kind) in words.
    pub bifurcations: Vec<(f64, String)>,
    /// Where the absorbers leave unison on this branch, ascending, in the continued parameter's
    /// unit: its branch points (identical absorbers) and the folds whose critical motion moves
    /// the absorbers of one rotor apart ([`parts_absorbers`]: a mistuned set, where the branch
    /// point of the identical set has become a fold). The other folds are jumps in unison.
    pub unison_lost: Vec<f64>,
    /// Wall time of the continuation, s.
    pub wall_s: f64,
    /// How the branch was solved: `general` (every coordinate an unknown) or `cyclic` (identical
    /// absorbers by one scaled representative, [`crate::hbm::Route`]).
    pub route: String,
    /// The route in words: the identical sets (`cyclic (4 × pivot_1…pivot_4 on rotor)`), or why
    /// the general route was taken (`general (no identical absorbers)`).
    pub route_detail: String,
    /// How the branch ended, in words.
    pub end: String,
    /// The parameter value the continuation started from (a switched branch: the branch
    /// point).
    pub from: f64,
    /// A switched (non-unison) branch: the unison branch point it was switched at, in the
    /// continued parameter's unit (`switch: true`; None, and left out of `results.json`, for
    /// the unison branches).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub switched_at: Option<f64>,
    /// A switched branch: where it goes, in words (leaves the range at …, returns to unison at
    /// …, stops because …).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goes: Option<String>,
    /// A switched branch started at a period doubling of the branch (a multiplier through −1):
    /// its states repeat every two excitation periods, so the order n/2 (reported multiple 0.5)
    /// is present; false, and left out of `results.json`, otherwise.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub period_doubled: bool,
    /// The drawn curve: the branch points with `CURVE_SUBDIVISION` − 1 Hermite-interpolated
    /// states ([`Branch::interpolate`]) between each two, in the parameter's units.
    pub curve_parameter: Vec<f64>,
    /// Acceleration amplitudes along the drawn curve, per reported multiple, rad/s².
    pub curve_accel: Vec<Vec<f64>>,
    /// Stability along the drawn curve (an interpolated state takes its nearer point's).
    pub curve_stable: Vec<Option<bool>>,
    /// Per point, the share of a joint coupling's force above the balanced harmonics
    /// ([`HbmSolution::coupling_tail`]); all zero, and left out of `results.json`, without
    /// couplings.
    #[serde(skip_serializing_if = "no_coupling")]
    pub coupling_tail: Vec<f64>,
}

fn no_coupling(tail: &[f64]) -> bool {
    tail.iter().all(|&t| t == 0.0)
}

/// Parts per branch segment in the drawn curve. The step control follows the whole unknown
/// vector, dominated by the pendulum coefficients, so across an antiresonance of the rotor the
/// solved points lie far apart on the rotor's amplitude curve (in the 40 N·m case the straight
/// line between two points misses the solved mid-state by 28 % of the amplitude, the Hermite
/// mid-state by 1.2 %, `tests/it/hbm.rs`); eight parts draw it smoothly at the cost of no solve.
pub(crate) const CURVE_SUBDIVISION: usize = 8;

pub(crate) fn hbm_error(study: &Study) -> impl Fn(HbmError) -> Error + '_ {
    move |e| Error::Model { mechanism: study.mechanism.name.clone(), message: format!("harmonic balance: {e}") }
}

/// Acceleration amplitude of the response body (Σ factor · its path's coordinates, `path` as
/// [`crate::model::mechanism::Mechanism::rotation_rates`] gives it: factor 1 except through a
/// gear) at order m·n, rad/s²; 0 when the solution has no harmonic at that multiple.
pub fn body_accel(sol: &HbmSolution, path: &[(usize, f64)], multiple: f64) -> f64 {
    let Some(h) = sol.harmonic_of(multiple) else { return 0.0 };
    let (a, b) = path.iter().fold((0.0, 0.0), |(a, b), &(k, factor)| {
        let (ak, bk) = sol.coefficient(k, h);
        (a + factor * ak, b + factor * bk)
    });
    let w = h as f64 * sol.base_frequency;
    w * w * a.hypot(b)
}

/// Continues the periodic solution in order from `from` to `to` for the excitation `harmonics`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn branch(
    study: &Study,
    omega: f64,
    harmonics: &[Harmonic],
    excite: &[super::ExciteAt],
    h: usize,
    from: f64,
    to: f64,
) -> Result<(RoutedHbm, Branch, f64)> {
    // Its points serve as guesses only (the multi-order analysis solves each state at its order
    // and analyses that one): no Floquet analysis per point and no localisation of the events,
    // which were most of the harmonic balance's cost in the truck study.
    branch_with(
        study,
        omega,
        (harmonics, &[]),
        excite,
        h,
        Parameter::Order,
        (from, to),
        None,
        None,
        (false, HbmRoute::Auto),
    )
}

/// Continues the periodic solution in `parameter` from `from` to `to` (its units: order, rad/s,
/// torque scale) for the excitation `forcing` at mean speed `omega` (rad/s), with the largest
/// step `max_step` (None: the default). The forcing is `(harmonics, per Ω²)`: the terms in N·m
/// and those that scale with the speed squared (an engine's inertia torque; empty otherwise).
/// The route is chosen here ([`RoutedHbm::new`]): identical absorbers are solved by one scaled
/// representative, and the branch is returned full-size either way.
#[allow(clippy::too_many_arguments)]
pub(crate) fn branch_in(
    study: &Study,
    omega: f64,
    forcing: (&[Harmonic], &[Harmonic]),
    excite: &[super::ExciteAt],
    h: usize,
    parameter: Parameter,
    from: f64,
    to: f64,
    max_step: Option<f64>,
    on_point: Option<PointHook>,
    route: HbmRoute,
) -> Result<(RoutedHbm, Branch, f64)> {
    branch_with(study, omega, forcing, excite, h, parameter, (from, to), max_step, on_point, (true, route))
}

/// [`branch_in`], with the stability of every point and the events located when `analysed`.
#[allow(clippy::too_many_arguments)]
fn branch_with(
    study: &Study,
    omega: f64,
    forcing: (&[Harmonic], &[Harmonic]),
    excite: &[super::ExciteAt],
    h: usize,
    parameter: Parameter,
    (from, to): (f64, f64),
    max_step: Option<f64>,
    on_point: Option<PointHook>,
    (analysed, route): (bool, HbmRoute),
) -> Result<(RoutedHbm, Branch, f64)> {
    let kane = study.kane(false)?;
    let opts = HbmOptions { harmonics: h, ..HbmOptions::default() };
    let inputs = study.excited_joints(&study.mechanism, excite);
    // With gravity (a world-frame force) the forces repeat every revolution: the multiple 1/n
    // (amplitude 0) puts the base order at a divisor of 1, so `h` counts harmonics of the
    // rotation (validation allows this only at a fixed order).
    let (harmonics, per_omega2) = forcing;
    let mut harmonics = harmonics.to_vec();
    if study.mechanism.loads.needs_world_orientation()
        && let Parameter::Speed { order } | Parameter::TorqueScale { order } = parameter
        && !harmonics.iter().any(|x| (x.multiple * order - 1.0).abs() < 1e-12)
    {
        harmonics.push(Harmonic { multiple: 1.0 / order, amplitude: 0.0, phase: 0.0 });
    }
    let forcing = (&harmonics[..], per_omega2);
    let mut hbm = match route {
        HbmRoute::General => RoutedHbm::new_general(&kane, study.spin, omega, forcing, &inputs, opts),
        // A declared cyclic route was checked at load (`check_route`).
        HbmRoute::Auto | HbmRoute::Cyclic => RoutedHbm::new(&kane, study.spin, omega, forcing, &inputs, opts),
    }
    .map_err(hbm_error(study))?;
    hbm.set_on_point(on_point);
    let start = std::time::Instant::now();
    let defaults = ContinuationOptions::default();
    let ds_max = max_step.unwrap_or(defaults.ds_max);
    let copts = ContinuationOptions {
        ds_max,
        ds: defaults.ds.min(ds_max),
        stability: analysed,
        refine_folds: analysed,
        deadline: study.spec.integration.deadline,
        corrector_tol: (!analysed).then_some(GUESS_TOL),
        one_sided: !analysed,
        min_cos: if analysed { defaults.min_cos } else { GUESS_MIN_COS },
        ..defaults
    };
    let b = hbm.continue_in(parameter, from, to, None, &copts).map_err(hbm_error(study))?;
    Ok((hbm, b, start.elapsed().as_secs_f64()))
}

/// The continued parameter's range in the spec's units (order, rpm, N·m), the conversion of a
/// branch's parameter values to those units, the axis label and the CSV column name.
struct Axis {
    range: (f64, f64),
    to_unit: f64,
    label: &'static str,
    column: &'static str,
    unit: &'static str,
}

/// Points planned per branch: a base of 100 (folds, refined crossings, the steps cut short near
/// them) plus the branch's arclength over the largest step, the arclength taken as the span of
/// the scaled parameter λ (relative to the lower speed for `Speed`) plus 4 for the response's
/// own excursion; capped at [`ContinuationOptions::max_points`]. The paper's branches (n 2.9–3.3,
/// default step 0.1) take 16–60 points against 144 planned; at a step of 0.001 about 1600
/// against the cap of 2000.
pub(crate) fn planned_points(spec: &HbmSpec) -> f64 {
    let (lo, hi) = axis(spec).range;
    let span = match spec.parameter {
        HbmParameter::Speed { .. } => (hi - lo).abs() / lo.abs().max(f64::MIN_POSITIVE),
        _ => (hi - lo).abs(),
    };
    let defaults = ContinuationOptions::default();
    let ds_max = spec.max_step.unwrap_or(defaults.ds_max).max(f64::MIN_POSITIVE);
    let points = 100.0 + (4.0 + span) / ds_max;
    if points.is_finite() { points.min(defaults.max_points as f64) } else { defaults.max_points as f64 }
}

impl Axis {
    /// The unit after a value (` rpm`), nothing for the dimensionless order.
    fn suffix(&self) -> String {
        if self.unit == "1" { String::new() } else { format!(" {}", self.unit) }
    }
}

fn axis(spec: &HbmSpec) -> Axis {
    match spec.parameter {
        HbmParameter::Order => {
            let range = (spec.order_min, spec.order_max);
            Axis { range, to_unit: 1.0, label: "excitation order n", column: "order", unit: "1" }
        }
        HbmParameter::Speed { rpm_min, rpm_max, .. } => Axis {
            range: (rpm_min, rpm_max),
            to_unit: 1.0 / rpm_to_rad_s(1.0),
            label: "mean speed, rpm",
            column: "rpm",
            unit: "rpm",
        },
        HbmParameter::Torque { min, max, .. } => Axis {
            range: (min, max),
            to_unit: 1.0,
            label: "torque amplitude T_n, N·m",
            column: "torque_Nm",
            unit: "N·m",
        },
    }
}

/// The amplitudes continued: one case per amplitude (order and speed), or one with T_n = 1 N·m
/// scaled (torque, NaN here), or one with the engine's amplitudes (NaN here too).
fn cases(spec: &HbmSpec) -> Vec<f64> {
    match spec.parameter {
        HbmParameter::Torque { .. } => vec![f64::NAN],
        _ if spec.engine.is_some() => vec![f64::NAN],
        _ => spec.amplitudes.clone(),
    }
}

/// The forcing of one case: `T_n sin(nΩt)`, or the engine's orders as harmonics of n split into
/// the gas part (N·m) and the inertia part per Ω² (N·m·s²/rad²), which follow the speed.
fn forcing(spec: &HbmSpec, amp: f64) -> (Vec<Harmonic>, Vec<Harmonic>) {
    if let (Some(series), HbmParameter::Speed { order, .. }) = (&spec.engine_series, spec.parameter) {
        return series.split_harmonics(order);
    }
    (vec![Harmonic { multiple: 1.0, amplitude: if amp.is_nan() { 1.0 } else { amp }, phase: 0.0 }], Vec::new())
}

/// Runs the branches ([`compute`]) and writes their outputs over `overlay`, the runs of the
/// order sweep the spec names ([`overlay_of`]; empty when it names none), as [`render`] does,
/// and with `backbone` (the free oscillation the spec names) the backbone figure
/// ([`backbone_figure`]).
pub(crate) fn run(
    study: &Study,
    spec: &HbmSpec,
    overlay: &[&SweepRun],
    backbone: Option<&super::backbone::FreeOscillationResult>,
    dir: &Path,
    progress: &super::sim::Progress,
) -> Result<Output> {
    let (branches, failures) = compute_with(study, spec, Some(progress));
    let (markdown, mut files) = render(study, spec, &branches, overlay, dir)?;
    if let Some(bb) = backbone {
        files.push(figures::backbone_figure(spec, &branches, bb, dir)?);
    }
    Ok(Output { markdown, files, failures, results: Box::new(branches) })
}

/// Every branch, continued from each end of the range per amplitude, with its stability, folds
/// and bifurcations, and the drawn curve; a failed continuation is listed, never lost with the
/// others.
pub(crate) fn compute(study: &Study, spec: &HbmSpec) -> (Vec<HbmBranch>, Vec<String>) {
    compute_with(study, spec, None)
}

/// The sweeps drawn under the branches, out of the runs of the analyses before it: the runs of
/// the order sweep the spec names as its `overlay`, the locked twin left out.
pub(crate) fn overlay_of<'a>(spec: &HbmSpec, sweeps: &'a [SweepRun]) -> Vec<&'a SweepRun> {
    match &spec.overlay {
        Some(name) => sweeps.iter().filter(|r| &r.analysis == name && !r.locked).collect(),
        None => Vec::new(),
    }
}

/// Writes one CSV per branch ([`tables`]), the figure with the overlaid sweeps (the paper's Figs.
/// 3 and 4 with every periodic state) and with elements their figure, and returns the summary
/// section with the files written.
pub(crate) fn render(
    study: &Study,
    spec: &HbmSpec,
    branches: &[HbmBranch],
    overlay: &[&SweepRun],
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let mut files = Vec::new();
    let refs: Vec<&HbmBranch> = branches.iter().collect();
    for t in tables(&study.mechanism, spec, &refs) {
        files.push(t.write_csv(dir)?);
    }
    files.push(figures::response_figure(study, spec, branches, overlay, dir)?);
    if branches.iter().any(|b| b.elements.iter().any(|p| !p.is_empty())) {
        files.push(figures::elements_figure(spec, branches, dir)?);
    }
    Ok((summary::summary(study, spec, branches, overlay), files))
}

/// The lag, in order-tracking windows, over which a sweep's jump is read: windows overlap, so a
/// jump spreads over window/hop of them, and windows that far apart are compared.
fn jump_lag(study: &Study) -> usize {
    let t = study.spec.order_tracking;
    ((t.window_s / t.hop_s).round() as usize).max(1)
}

/// The orders where the up and the down sweep of `amplitude` jump ([`jump_order`] on their
/// main-order traces, after 5 s: the ramp-in and the first windows).
pub fn jump_orders(sweeps: &[&SweepRun], amplitude: f64, lag: usize) -> Option<(Option<f64>, Option<f64>)> {
    let find = |dir: Direction| sweeps.iter().find(|r| r.amplitude == amplitude && r.direction == dir);
    let (up, down) = (find(Direction::Up)?, find(Direction::Down)?);
    let jump = |t: &OrderTrace| jump_order(t, lag, 5.0);
    Some((up.trace(1.0).and_then(jump), down.trace(1.0).and_then(jump)))
}
