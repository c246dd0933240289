//! Harmonic balance in a study: branches of periodic steady states continued in the excitation
//! order (or the mean speed, or the torque amplitude), stable and unstable, with their folds,
//! drawn over the time-domain sweeps.

mod analysis;
mod spec;
pub use spec::*;

use super::elements::{ElementResponse, from_hbm};
use super::sweep::SweepRun;
use super::table::Table;
use super::{Direction, Output, Study};
use crate::error::{Error, Result};
use crate::hbm::{
    BifurcationClass, Branch, BranchEnd, ContinuationOptions, HbmError, HbmOptions, HbmSolution, Parameter, PointHook,
    RoutedHbm, Symmetry,
};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::model::mechanism::Mechanism;
use crate::plot::{LineStyle, Panel, PointLabel, Series, num};
use crate::signal::OrderTrace;

/// The corrector's tolerance on a branch whose points only serve as starting guesses (max norm
/// of the Newton step, rad): each guess is solved again at the full tolerance where it is used.
pub(crate) const GUESS_TOL: f64 = 1e-6;

/// The smallest cosine between successive tangents on a branch of guesses (25.8°; 11.5° on an
/// analysed branch): the quadratic predictor and the chord's check against another sheet keep
/// such steps on the branch, and the truck study's order branches take half the points.
pub(crate) const GUESS_MIN_COS: f64 = 0.9;
use crate::signal::findings::jump_order;
use std::fmt::Write as _;
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

/// The summary's warning when a branch's coupling forces have not converged in H: the worst
/// point's share above H and where it is, or None.
fn coupling_warning(spec: &HbmSpec, br: &HbmBranch) -> Option<String> {
    let tol = HbmOptions::default().coupling_tol;
    let (i, worst) =
        br.coupling_tail.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).filter(|&(_, t)| t > tol)?;
    let count = br.coupling_tail.iter().filter(|&&t| t > tol).count();
    let ax = axis(spec);
    Some(format!(
        "> **Warning** (branch from {}): the joint couplings' harmonic content has not converged at H = {}: at \
         {count} of {} points more than {:.0} % of a coupling force's oscillating part lies above the balanced \
         harmonics (worst {:.1} % at {} = {:.4}); raise `harmonics` and compare.\n",
        br.from,
        spec.harmonics,
        br.coupling_tail.len(),
        100.0 * tol,
        100.0 * worst,
        ax.column,
        br.parameter.get(i).copied().unwrap_or(f64::NAN),
    ))
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

/// Share of a path's travel at which a stalled branch counts as having reached the end of the
/// path: the corrector fails there because the periodic state approaches the path's end, where
/// the motion stiffens without bound (the path examples' 500 N·m branches stall at 90–91 % of
/// their travel; 0.8 leaves room for coarser harmonics).
const AT_TRAVEL_END: f64 = 0.8;

/// Why a branch ending at `sol` stalled, when it is the end of an absorber's path: the joint and
/// the share of its travel its peak reaches (at least [`AT_TRAVEL_END`]).
fn travel_end(mech: &Mechanism, sol: &HbmSolution) -> Option<String> {
    (0..mech.ndof())
        .filter_map(|k| {
            let joint = &mech.joints[mech.joint_of(k)];
            let travel = joint.kind.travel();
            let share = sol.peak_amplitude(k) / travel;
            (travel.is_finite() && share >= AT_TRAVEL_END).then_some((share, joint.name.clone(), travel))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(share, name, travel)| {
            format!(
                "absorber `{name}` reaches {:.0} % of its travel ({travel:.4e} m): the steady state leaves its path",
                100.0 * share
            )
        })
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
        files.push(backbone_figure(spec, &branches, bb, dir)?);
    }
    Ok(Output { markdown, files, failures, results: Box::new(branches) })
}

/// Every branch, continued from each end of the range per amplitude, with its stability, folds
/// and bifurcations, and the drawn curve; a failed continuation is listed, never lost with the
/// others.
pub(crate) fn compute(study: &Study, spec: &HbmSpec) -> (Vec<HbmBranch>, Vec<String>) {
    compute_with(study, spec, None)
}

/// [`compute`] with a progress line per branch on a terminal (points and the parameter reached).
fn compute_with(
    study: &Study,
    spec: &HbmSpec,
    progress: Option<&super::sim::Progress>,
) -> (Vec<HbmBranch>, Vec<String>) {
    let path = study.mechanism.rotation_rates(study.body);
    let ax = axis(spec);
    // One case per amplitude (order and speed), or one with T_n = 1 N·m scaled (torque).
    let parameter = spec.parameter.continued();
    let (omega, scale) = match spec.parameter {
        HbmParameter::Speed { rpm_min, .. } => (rpm_to_rad_s(rpm_min), rpm_to_rad_s(1.0)),
        _ => (rpm_to_rad_s(spec.rpm), 1.0),
    };
    let mut branches = Vec::new();
    let mut failures = Vec::new();
    for amp in cases(spec) {
        let (harmonics, per_omega2) = forcing(spec, amp);
        // From above, the continuation follows the branch that comes down from high values; from
        // below, the one that comes up from low values. Where the response is S-shaped and a fold
        // lies outside the range, each reaches sheets the other cannot.
        let (lo, hi) = ax.range;
        for (from, to) in [(hi, lo), (lo, hi)] {
            let what = if amp.is_nan() { String::new() } else { format!(" {amp} N·m") };
            if let Some(d) = study.spec.integration.deadline.filter(|d| d.passed()) {
                failures.push(format!(
                    "{}{what}, continued from {from}: not run: {} (stopped by the watchdog)",
                    spec.name,
                    crate::deadline::Deadline::overran(d.budget_s)
                ));
                continue;
            }
            let bar = progress.map(|pr| pr.spinner(&format!("{}{what} from {from}", spec.name)));
            let hook = bar.clone().map(|bar| {
                let (to_unit, unit) = (ax.to_unit, ax.unit);
                PointHook(std::sync::Arc::new(move |k: usize, p: f64| {
                    bar.set_message(format!("{k} points, at {:.5} {unit}", p * to_unit));
                    bar.tick();
                }))
            });
            let solved = branch_in(
                study,
                omega,
                (&harmonics, &per_omega2),
                &spec.excite,
                spec.harmonics,
                parameter,
                from * scale,
                to * scale,
                spec.max_step,
                hook,
                spec.route,
            );
            if let Some(bar) = &bar {
                bar.finish_and_clear();
            }
            let (hbm, b, wall_s) = match solved {
                Ok(x) => x,
                Err(e) => {
                    let what = if amp.is_nan() { String::new() } else { format!(" at {amp} N·m") };
                    failures.push(format!("{}{what}, continued from {from}: {e}", spec.name));
                    continue;
                }
            };
            // The unison branch, then (`switch`, once per amplitude: on the upward
            // continuation) the non-unison branches switched at its branch points.
            let mut rows = Vec::new();
            if spec.switch && from == lo {
                let range = (lo * scale, hi * scale);
                rows = switched(study, spec, (omega, &harmonics, &per_omega2), &b, range, &mut failures, &what);
            }
            rows.insert(0, (hbm, b, wall_s, None, false));
            for (mut hbm, b, wall_s, switched_at, period_doubled) in rows {
                let from = switched_at.map_or(from, |v: f64| v * ax.to_unit);
                let p = &b.points;
                // A branch that could not go on says why and where in the summary (its points are
                // kept). Where the last state takes an absorber to the end of its path (within
                // `AT_TRAVEL_END`), the stall is the mechanism's own limit and stays a note; any other
                // stall is also a failure (below).
                let at_travel_end = p.last().and_then(|last| travel_end(&study.mechanism, &last.solution));
                let stopped = match b.end {
                    BranchEnd::StepTooSmall if at_travel_end.is_some() => at_travel_end.as_deref(),
                    BranchEnd::StepTooSmall => Some("the corrector failed at every step down to the smallest"),
                    BranchEnd::MaxPoints => Some("it reached the largest number of points"),
                    BranchEnd::Watchdog => Some("the analysis overran its time budget (stopped by the watchdog)"),
                    BranchEnd::ReachedTarget | BranchEnd::LeftRange | BranchEnd::Unison => None,
                };
                // Where the branch got to: ` at order = 3.1765350 after 669 points`.
                let reached = p.last().map_or(String::new(), |last| {
                    format!(
                        " at {} = {:.7}{} after {} points",
                        ax.column,
                        last.parameter * ax.to_unit,
                        ax.suffix(),
                        p.len()
                    )
                });
                if b.end == BranchEnd::Watchdog {
                    let budget = study.spec.integration.deadline.map_or(f64::NAN, |d| d.budget_s);
                    let at = &reached;
                    failures.push(format!(
                    "{}{what}, continued from {from}: stopped by the watchdog{at}: {} (the points reached are kept)",
                    spec.name,
                    crate::deadline::Deadline::overran(budget)
                ));
                }
                let stopped_short = match (stopped, p.last()) {
                    (Some(reason), Some(_)) => Some(format!("stopped because {reason},{reached}")),
                    _ => None,
                };
                // A branch that stalled (or hit its point cap) short of its range is a failure of
                // the analysis: the jump or fold the user asked about may lie beyond it. (The
                // watchdog's stop is listed above.)
                if matches!(b.end, BranchEnd::StepTooSmall | BranchEnd::MaxPoints)
                    && at_travel_end.is_none()
                    && let Some(why) = &stopped_short
                {
                    failures.push(format!(
                        "{}{what}, continued from {from}: {why} (the points reached are kept)",
                        spec.name
                    ));
                }
                let (mut curve_parameter, mut curve_stable) = (Vec::new(), Vec::new());
                let mut curve_accel = vec![Vec::new(); spec.multiples.len()];
                let mut add = |sol: &HbmSolution, stable: Option<bool>| {
                    curve_parameter.push(parameter.value(sol) * ax.to_unit);
                    for (acc, &m) in curve_accel.iter_mut().zip(&spec.multiples) {
                        acc.push(body_accel(sol, &path, m));
                    }
                    curve_stable.push(stable);
                };
                for i in 0..p.len() {
                    add(&p[i].solution, p[i].stable);
                    if i + 1 == p.len() {
                        break;
                    }
                    for j in 1..CURVE_SUBDIVISION {
                        let sigma = j as f64 / CURVE_SUBDIVISION as f64;
                        if let Some(sol) = b.interpolate(i, sigma) {
                            add(&sol, if sigma < 0.5 { p[i].stable } else { p[i + 1].stable });
                        }
                    }
                }
                let orbits = orbits_on(study, spec, &mut hbm, &b, (&path, scale));
                branches.push(HbmBranch {
                    orbits,
                    stopped_short,
                    analysis: spec.name.clone(),
                    curve_parameter,
                    curve_accel,
                    curve_stable,
                    amplitude: amp,
                    order: p.iter().map(|x| x.order).collect(),
                    parameter: p.iter().map(|x| x.parameter * ax.to_unit).collect(),
                    accel: spec
                        .multiples
                        .iter()
                        .map(|&m| p.iter().map(|x| body_accel(&x.solution, &path, m)).collect())
                        .collect(),
                    relative_angle: p.iter().map(|x| x.solution.max_peak_amplitude()).collect(),
                    elements: p
                        .iter()
                        .map(|x| from_hbm(&study.mechanism, &study.elements, &x.solution, &spec.multiples))
                        .collect(),
                    stable: p.iter().map(|x| x.stable).collect(),
                    coupling_tail: p.iter().map(|x| x.solution.coupling_tail).collect(),
                    max_multiplier: p
                        .iter()
                        .map(|x| x.solution.stability.as_ref().map_or(f64::NAN, |st| st.max_modulus))
                        .collect(),
                    folds: b.folds.iter().map(|f| f.parameter * ax.to_unit).collect(),
                    unison_lost: unison_lost(&study.mechanism, &b, ax.to_unit),
                    bifurcations: b
                        .bifurcations
                        .iter()
                        .map(|x| (x.parameter * ax.to_unit, x.class.words().to_string()))
                        .collect(),
                    wall_s,
                    route: hbm.route().name().to_string(),
                    route_detail: hbm.route().to_string(),
                    end: format!("{:?}", b.end),
                    from,
                    switched_at: switched_at.map(|v| v * ax.to_unit),
                    goes: switched_at.map(|_| goes(&b, ax.to_unit, period_doubled)),
                    period_doubled,
                });
            }
        }
    }

    for br in &branches {
        if br.accel.iter().flatten().chain(&br.relative_angle).any(|v| !v.is_finite()) {
            failures.push(format!(
                "{} branch from {}: a solution is not finite (left empty in the CSV)",
                spec.name, br.from
            ));
        }
    }
    (branches, failures)
}

/// The permutation of the coordinates that swaps the two identical absorbers of `route`'s one
/// identical set (for [`crate::hbm::Hbm::switch_at`]), or why there is none.
pub(crate) fn switch_mirror(mech: &Mechanism, route: &crate::hbm::Route) -> std::result::Result<Vec<usize>, String> {
    let crate::hbm::Route::Cyclic { sets } = route else {
        return Err(format!("the mechanism `{}` has no identical absorbers to leave unison ({route})", mech.name));
    };
    let [set] = &sets[..] else {
        return Err(format!("switching takes one identical set, the mechanism has {}", sets.len()));
    };
    if set.members.len() != 2 || set.member_dof != 1 {
        return Err(format!(
            "switching takes two identical one-coordinate absorbers (a one-dimensional kernel), the set is {set} with {} coordinate(s) each",
            set.member_dof
        ));
    }
    let coord = |name: &str| mech.joint_index(name).and_then(|j| mech.joints[j].coordinate);
    let (Some(a), Some(b)) = (coord(&set.members[0]), coord(&set.members[1])) else {
        return Err(format!("the members of {set} have no coordinates"));
    };
    let mut mirror: Vec<usize> = (0..mech.ndof()).collect();
    mirror.swap(a, b);
    Ok(mirror)
}

/// The branches switched at the branch points of the unison branch `b` (the non-unison ones)
/// and at its period doublings (the period-doubled ones), in the solver's parameter `range`,
/// each with its wall time, the point it was switched at and whether it is period-doubled; a
/// failure (naming the analysis and the field `switch`) for a branch with neither and for every
/// switch that fails.
fn switched(
    study: &Study,
    spec: &HbmSpec,
    (omega, harmonics, per_omega2): (f64, &[Harmonic], &[Harmonic]),
    b: &Branch,
    range: (f64, f64),
    failures: &mut Vec<String>,
    what: &str,
) -> Vec<SwitchedRow> {
    let of = |class: BifurcationClass| -> Vec<f64> {
        b.bifurcations.iter().filter(|x| x.class == class).map(|x| x.parameter).collect()
    };
    let (points, doublings) = (of(BifurcationClass::BranchPoint), of(BifurcationClass::PeriodDoubling));
    if points.is_empty() && doublings.is_empty() {
        failures.push(format!(
            "{}{what}: `switch` ({}): the branch has no branch point (a multiplier through +1 that is not a fold) \
             and no period doubling (through −1) in the range: no branch switch exists here",
            spec.name,
            switch_field(study, spec)
        ));
        return Vec::new();
    }
    let mut out = Vec::new();
    let fail = |e: String| format!("{}{what}: `switch` ({}): {e}", spec.name, switch_field(study, spec));
    let kane = match study.kane(false) {
        Ok(k) => k,
        Err(e) => {
            failures.push(fail(e.to_string()));
            return out;
        }
    };
    let inputs = study.excited_joints(&study.mechanism, &spec.excite);
    let input_joints: Vec<usize> = inputs.iter().map(|i| i.0).collect();
    let mirror = if points.is_empty() {
        None
    } else {
        match switch_mirror(&study.mechanism, &crate::hbm::route_for(&kane, study.spin, &input_joints)) {
            Ok(m) => Some(m),
            Err(e) => {
                failures.push(fail(e));
                None
            }
        }
    };
    let opts = HbmOptions { harmonics: spec.harmonics, ..HbmOptions::default() };
    let defaults = ContinuationOptions::default();
    let ds_max = spec.max_step.unwrap_or(defaults.ds_max);
    let copts = ContinuationOptions {
        ds_max,
        ds: defaults.ds.min(ds_max),
        deadline: study.spec.integration.deadline,
        ..defaults
    };
    // A period-doubled branch is solved on the problem of half the base frequency, with twice
    // the harmonics (the same resolution of the excitation's own harmonics).
    let base = b.points.first().map(|p| p.solution.base_frequency / (p.solution.order * p.solution.omega));
    let mut halved = harmonics.to_vec();
    halved.push(Harmonic { multiple: 0.5 * base.unwrap_or(1.0), amplitude: 0.0, phase: 0.0 });
    let switches = mirror
        .iter()
        .flat_map(|m| points.iter().map(move |&at| (at, Symmetry::Swap(m.clone()))))
        .chain(doublings.iter().map(|&at| (at, Symmetry::HalfPeriod)));
    for (at, symmetry) in switches {
        let start = std::time::Instant::now();
        let Some(guess) = b.guesses_at(at).first().map(|g| (*g).clone()) else { continue };
        let doubled = symmetry == Symmetry::HalfPeriod;
        let (forcing, opts) = if doubled {
            ((&halved[..], per_omega2), HbmOptions { harmonics: 2 * spec.harmonics, ..opts })
        } else {
            ((harmonics, per_omega2), opts)
        };
        let solved = RoutedHbm::new_general(&kane, study.spin, omega, forcing, &inputs, opts).and_then(|mut hbm| {
            let sw = hbm.hbm_mut().switch_at(b.parameter, at, &guess, &symmetry, range, &copts)?;
            Ok((hbm, sw))
        });
        match solved {
            Ok((hbm, sw)) => out.push((hbm, sw, start.elapsed().as_secs_f64(), Some(at), doubled)),
            Err(e) => failures.push(fail(format!("the switch at {at}: {e}"))),
        }
    }
    out
}

/// Where the study file sets the analysis's `switch` (file:line:col).
fn switch_field(study: &Study, spec: &HbmSpec) -> String {
    // A design study's own analysis is not in the list: its study's `analyses` then.
    let field = match study.spec.analyses.iter().position(|a| a.name() == spec.name) {
        Some(k) => format!("analyses[{k}].switch"),
        None => "analyses".into(),
    };
    study.source.locate(&field).to_string()
}

/// A row of [`switched`]: the problem, the branch, its wall time (s), the point it was switched
/// at, and whether it is period-doubled.
type SwitchedRow = (RoutedHbm, Branch, f64, Option<f64>, bool);

/// Where a switched branch goes, in words, in the continued parameter's unit (`to_unit`); a
/// period-doubled one returns to the period-1 branch rather than to unison.
fn goes(b: &Branch, to_unit: f64, period_doubled: bool) -> String {
    let Some(last) = b.points.last() else { return "no point".into() };
    let at = last.parameter * to_unit;
    let folds = if b.folds.is_empty() {
        String::new()
    } else {
        format!(", after folds at {}", list(&b.folds.iter().map(|f| f.parameter * to_unit).collect::<Vec<_>>()))
    };
    match b.end {
        BranchEnd::Unison if period_doubled => {
            format!("returns to the period-1 branch at {at:.7} (a period doubling of it){folds}")
        }
        BranchEnd::Unison => format!("returns to unison at {at:.7} (a branch point of the unison branch){folds}"),
        BranchEnd::ReachedTarget | BranchEnd::LeftRange => format!("leaves the range at {at:.7}{folds}"),
        BranchEnd::StepTooSmall => format!("stops at {at:.7}: the corrector failed at every step{folds}"),
        BranchEnd::MaxPoints => format!("stops at {at:.7}: the largest number of points{folds}"),
        BranchEnd::Watchdog => format!("stops at {at:.7}: the time budget{folds}"),
    }
}

/// The values of branch `b`'s continued parameter (times `to_unit`) where absorbers leave
/// unison: its branch points and its folds that [`parts_absorbers`], ascending.
fn unison_lost(mech: &Mechanism, b: &crate::hbm::Branch, to_unit: f64) -> Vec<f64> {
    let nb = b.points.first().map_or(0, |p| 2 * p.solution.harmonics + 1);
    let points = b.bifurcations.iter().filter(|x| x.class == BifurcationClass::BranchPoint).map(|x| x.parameter);
    let folds = b.folds.iter().filter(|f| parts_absorbers(mech, &f.critical, nb)).map(|f| f.parameter);
    let mut out: Vec<f64> = points.chain(folds).map(|v| v * to_unit).collect();
    out.sort_by(f64::total_cmp);
    out
}

/// Whether a critical motion (Fourier coefficients, `nb` per coordinate, in the layout of
/// [`HbmSolution::coefficients`]) moves the absorbers of some rotor apart rather than together:
/// for the absorbers hung on one body (two or more), the energy of their deviations from their
/// mean motion, `Σ_k ‖v_k − v̄‖²`, exceeds half their total `Σ_k ‖v_k‖²`. In unison every v_k is
/// the same (ratio 0); in a pure out-of-unison mode of identical absorbers the mean is zero
/// (ratio 1). A mistuned set sits near one or the other, which is why half separates them.
pub fn parts_absorbers(mech: &Mechanism, critical: &[f64], nb: usize) -> bool {
    if critical.is_empty() || nb == 0 {
        return false;
    }
    let absorbers = crate::model::absorber::absorbers(mech);
    let mut parents: Vec<Option<usize>> = Vec::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for a in &absorbers {
        let Some(j) = mech.joint_index(&a.joint) else { continue };
        let Some(k) = mech.coordinate(j).filter(|&k| (k + 1) * nb <= critical.len()) else { continue };
        let parent = mech.joints[j].parent;
        match parents.iter().position(|p| *p == parent) {
            Some(g) => groups[g].push(k),
            None => {
                parents.push(parent);
                groups.push(vec![k]);
            }
        }
    }
    groups.iter().filter(|g| g.len() >= 2).any(|g| {
        let slice = |k: usize| &critical[k * nb..(k + 1) * nb];
        let mean: Vec<f64> = (0..nb).map(|i| g.iter().map(|&k| slice(k)[i]).sum::<f64>() / g.len() as f64).collect();
        let total: f64 = g.iter().map(|&k| slice(k).iter().map(|v| v * v).sum::<f64>()).sum();
        let apart: f64 =
            g.iter().map(|&k| slice(k).iter().zip(&mean).map(|(v, m)| (v - m) * (v - m)).sum::<f64>()).sum();
        total > 0.0 && apart > 0.5 * total
    })
}

/// The states branch `b` crosses at each of `spec.orbits_at` (in the axis unit; `scale` takes it
/// to the continued parameter), each solved there from its nearer branch point and its stability
/// computed; a crossing whose solve fails is left out (the branch's points stay).
fn orbits_on(
    study: &Study,
    spec: &HbmSpec,
    hbm: &mut crate::hbm::RoutedHbm,
    b: &crate::hbm::Branch,
    (path, scale): (&[(usize, f64)], f64),
) -> Vec<HbmOrbit> {
    let mut out = Vec::new();
    for &at in &spec.orbits_at {
        let value = at * scale;
        for guess in b.guesses_at(value) {
            let solved = match spec.parameter {
                HbmParameter::Order => hbm.solve(value, Some(guess)),
                HbmParameter::Speed { order, .. } => hbm.set_speed(value).and_then(|()| hbm.solve(order, Some(guess))),
                HbmParameter::Torque { order, .. } => {
                    hbm.set_torque_scale(value).and_then(|()| hbm.solve(order, Some(guess)))
                }
            };
            let Ok(mut sol) = solved else { continue };
            sol.stability = hbm.stability(&sol).ok();
            out.push(HbmOrbit {
                at,
                accel: spec.multiples.iter().map(|&m| body_accel(&sol, path, m)).collect(),
                relative_angle: sol.max_peak_amplitude(),
                stable: sol.stability.as_ref().map(|st| st.stable),
                max_multiplier: sol.stability.as_ref().map_or(f64::NAN, |st| st.max_modulus),
                elements: from_hbm(&study.mechanism, &study.elements, &sol, &spec.multiples),
            });
        }
    }
    out
}

/// One CSV table per branch: the continued parameter, the acceleration per reported multiple,
/// the largest relative angle, stability (1 stable, 0 unstable, empty unknown) and the largest
/// Floquet multiplier modulus at each solved point.
pub(crate) fn tables(mech: &Mechanism, spec: &HbmSpec, branches: &[&HbmBranch]) -> Vec<Table> {
    let ax = axis(spec);
    branches
        .iter()
        .map(|br| {
            // A switched branch is named by its branch point (`hb_500Nm_switched_3.08137`).
            let dir_tag = match br.switched_at {
                Some(at) => format!("switched_{at:.5}"),
                None if br.from > ax.range.0 => "from_above".into(),
                None => "from_below".into(),
            };
            let mut table = if br.amplitude.is_nan() {
                Table::new(format!("{}_{dir_tag}", spec.name))
            } else {
                Table::new(format!("{}_{}Nm_{dir_tag}", spec.name, super::sweep::fmt_num(br.amplitude)))
            };
            table.push(ax.column, ax.unit, br.parameter.clone());
            for (k, m) in spec.multiples.iter().enumerate() {
                table.push(format!("accel_{m}x_rad_s2"), "rad/s²", br.accel[k].clone());
            }
            table.push("max_relative_angle_rad", "rad", br.relative_angle.clone());
            let stable = br.stable.iter().map(|s| s.map_or(f64::NAN, |s| if s { 1.0 } else { 0.0 })).collect();
            table.push("stable", "1", stable);
            table.push("max_floquet_modulus", "1", br.max_multiplier.clone());
            // Each reported element at every point, after the branch's own columns.
            for (e, first) in br.elements.first().map_or(&[][..], Vec::as_slice).iter().enumerate() {
                let el = |f: &dyn Fn(&ElementResponse) -> f64| {
                    br.elements.iter().map(|pt| pt.get(e).map_or(f64::NAN, f)).collect::<Vec<f64>>()
                };
                if let Some(joint) = mech.joints.iter().find(|j| j.name == first.joint) {
                    super::elements::push_element_columns(
                        &mut table,
                        joint,
                        &spec.multiples,
                        first.torque.is_some(),
                        "",
                        &el,
                    );
                }
            }
            table
        })
        .collect()
}

/// What the summary counts per branch (also in `results.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct BranchFindings {
    /// Solved points.
    pub points: usize,
    /// Points found stable.
    pub stable: usize,
    /// Points found unstable.
    pub unstable: usize,
    /// The orders where the overlaid up and down sweeps of the same amplitude jump (None: no
    /// overlay with both directions; an inner None: that sweep does not jump).
    pub sweep_jumps: Option<(Option<f64>, Option<f64>)>,
}

/// The summary's readings of each branch, in order ([`BranchFindings`]); `overlay` is the sweeps
/// drawn under the branches ([`overlay_of`]), whose jumps are read next to them.
pub(crate) fn findings(study: &Study, branches: &[&HbmBranch], overlay: &[&SweepRun]) -> Vec<BranchFindings> {
    let lag = jump_lag(study);
    branches
        .iter()
        .map(|br| BranchFindings {
            points: br.order.len(),
            stable: br.stable.iter().filter(|s| **s == Some(true)).count(),
            unstable: br.stable.iter().filter(|s| **s == Some(false)).count(),
            sweep_jumps: jump_orders(overlay, br.amplitude, lag),
        })
        .collect()
}

/// `<name>_backbone.svg`: per amplitude, each branch's largest peak relative angle of the
/// non-spin joints (the absorber's amplitude, rad) against the order, the branch from each end
/// of the range solid and dashed, with the backbone `bb` (its order against release amplitude,
/// the peak angle of the free orbit, from the linear order at zero) over them: the forced
/// response leans along it.
fn backbone_figure(
    spec: &HbmSpec,
    branches: &[HbmBranch],
    bb: &super::backbone::FreeOscillationResult,
    dir: &Path,
) -> Result<PathBuf> {
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let spin = match bb.spin {
        crate::hbm::FreeSpin::Held => "held spin",
        crate::hbm::FreeSpin::Free => "free rotor",
    };
    let panels: Vec<Panel> = cases(spec)
        .into_iter()
        .map(|amp| {
            let mut series = Vec::new();
            for (b, br) in branches.iter().filter(|b| same(b.amplitude, amp)).enumerate() {
                series.push(Series {
                    label: if b == 0 { format!("forced, T_n = {amp} N·m") } else { String::new() },
                    x: br.parameter.clone(),
                    y: br.relative_angle.clone(),
                    color: 0,
                    style: if b == 0 { LineStyle::Solid } else { LineStyle::Dashed },
                });
            }
            // The backbone leaves the axis at the linear order.
            series.push(Series {
                label: format!("backbone `{}` ({spin}, {})", bb.name, bb.joint),
                x: std::iter::once(bb.linear_order).chain(bb.orders.iter().copied()).collect(),
                y: std::iter::once(0.0).chain(bb.amplitudes.iter().copied()).collect(),
                color: 1,
                style: LineStyle::Dashed,
            });
            series.push(Series {
                label: String::new(),
                x: bb.orders.clone(),
                y: bb.amplitudes.clone(),
                color: 1,
                style: LineStyle::Points,
            });
            Panel {
                title: format!("Forced branches and the backbone, T_n = {amp} N·m, {} rpm", spec.rpm),
                x_label: "excitation order n".into(),
                y_label: format!("largest peak joint angle, {}", bb.unit),
                x_range: Some((spec.order_min, spec.order_max)),
                series,
                ..Panel::default()
            }
        })
        .collect();
    let svg = dir.join(format!("{}_backbone.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 460)?;
    Ok(svg)
}

/// The sweeps drawn under the branches, out of the runs of the analyses before it: the runs of
/// the order sweep the spec names as its `overlay`, the locked twin left out.
pub(crate) fn overlay_of<'a>(spec: &HbmSpec, sweeps: &'a [SweepRun]) -> Vec<&'a SweepRun> {
    match &spec.overlay {
        Some(name) => sweeps.iter().filter(|r| &r.analysis == name && !r.locked).collect(),
        None => Vec::new(),
    }
}

/// Writes one CSV per branch and the figure with the overlaid sweeps (the paper's Figs. 3 and 4
/// with every periodic state), and returns the summary section with the files written.
pub(crate) fn render(
    study: &Study,
    spec: &HbmSpec,
    branches: &[HbmBranch],
    overlay: &[&SweepRun],
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let ax = axis(spec);
    let mut files = Vec::new();
    let refs: Vec<&HbmBranch> = branches.iter().collect();
    for t in tables(&study.mechanism, spec, &refs) {
        files.push(t.write_csv(dir)?);
    }

    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let panels: Vec<Panel> = cases(spec)
        .into_iter()
        .map(|amp| {
            let mut series = Vec::new();
            for r in overlay.iter().filter(|r| r.amplitude == amp) {
                for (k, t) in r.traces.iter().enumerate() {
                    let dir = if r.direction == Direction::Up { "up" } else { "down" };
                    series.push(Series {
                        label: format!("sweep {dir}, {}", super::sweep::order_name(t.multiple)),
                        x: t.order.clone(),
                        y: t.amplitude.clone(),
                        color: 2 + 2 * k + usize::from(r.direction == Direction::Down),
                        style: LineStyle::Dotted,
                    });
                }
            }
            let mut labelled = [false; 2];
            let mut labels: Vec<PointLabel> = Vec::new();
            for br in branches.iter().filter(|b| same(b.amplitude, amp)) {
                for k in 0..spec.multiples.len() {
                    push_segments(&mut series, br, k, k == 0, &mut labelled);
                }
                // Each fold and bifurcation marked on the main-order curve where it happens and
                // named with its parameter value to five digits (as the README quotes the folds);
                // the branches from both ends of the range find the same ones, named once.
                let points = br.folds.iter().map(|&f| (f, "fold".to_string())).chain(br.bifurcations.iter().cloned());
                for (at, kind) in points {
                    let y = value_at_turn(br, at);
                    let seen = labels.iter().any(|l| (l.x - at).abs() < 1e-3 * ax.range.1.abs().max(1.0));
                    if y.is_finite() && y > 0.0 && !seen {
                        labels.push(PointLabel { x: at, y, text: format!("{kind} {}", num(at, 5)), marker: true });
                    }
                }
            }
            // Where the overlaid up and down sweeps jump (the summary's "sweep jumps"), on their
            // main-order traces.
            if let Some((up, down)) = jump_orders(overlay, amp, jump_lag(study)) {
                for (dir, at) in [(Direction::Up, up), (Direction::Down, down)] {
                    let trace =
                        overlay.iter().find(|r| r.amplitude == amp && r.direction == dir).and_then(|r| r.trace(1.0));
                    if let (Some(at), Some(trace)) = (at, trace) {
                        let y = trace_value(trace, at);
                        if y.is_finite() && y > 0.0 {
                            let name = if dir == Direction::Up { "up-sweep" } else { "down-sweep" };
                            labels.push(PointLabel {
                                x: at,
                                y,
                                text: format!("{name} jumps at {}", num(at, 4)),
                                marker: true,
                            });
                        }
                    }
                }
            }
            let mut markers: Vec<(f64, String)> = branches
                .iter()
                .filter(|b| same(b.amplitude, amp))
                .flat_map(|b| b.folds.iter().map(|&f| (f, String::new())))
                .collect();
            markers.sort_by(|a, b| a.0.total_cmp(&b.0));
            markers.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
            let title = match spec.parameter {
                HbmParameter::Order => format!("Harmonic balance, T_n = {amp} N·m, {} rpm", spec.rpm),
                HbmParameter::Speed { order, .. } => match &spec.engine {
                    Some(e) => format!("Harmonic balance, engine {e}, n = {order}"),
                    None => format!("Harmonic balance, T_n = {amp} N·m, n = {order}"),
                },
                HbmParameter::Torque { order, .. } => format!("Harmonic balance, n = {order}, {} rpm", spec.rpm),
            };
            Panel {
                title,
                x_label: ax.label.into(),
                y_label: format!("{} angular acceleration, rad/s²", study.spec.response_body),
                log_y: true,
                x_range: Some(ax.range),
                markers,
                series,
                labels,
                ..Panel::default()
            }
        })
        .collect();
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 460)?;
    files.push(svg);
    // The elements along each branch: their main-order amplitude (first reported multiple),
    // one panel per amplitude, the branch from each end solid and dashed.
    if branches.iter().any(|b| b.elements.iter().any(|p| !p.is_empty())) {
        let panels: Vec<Panel> = cases(spec)
            .into_iter()
            .map(|amp| {
                let mut series = Vec::new();
                for (b, br) in branches.iter().filter(|b| same(b.amplitude, amp)).enumerate() {
                    let names: Vec<&str> =
                        br.elements.first().map(|p| p.iter().map(|e| e.joint.as_str()).collect()).unwrap_or_default();
                    for (e, name) in names.iter().enumerate() {
                        let y = br
                            .elements
                            .iter()
                            .map(|p| p.get(e).and_then(|el| el.amplitude.first().copied()).unwrap_or(f64::NAN))
                            .collect();
                        series.push(Series {
                            label: if b == 0 { (*name).to_string() } else { String::new() },
                            x: br.parameter.clone(),
                            y,
                            color: e,
                            style: if b == 0 { LineStyle::Solid } else { LineStyle::Dashed },
                        });
                    }
                }
                Panel {
                    title: format!("Elements at the {}, T_n = {amp} N·m", super::sweep::order_name(spec.multiples[0])),
                    x_label: ax.label.into(),
                    y_label: "amplitude, rad (m for slides)".into(),
                    log_y: true,
                    x_range: Some(ax.range),
                    series,
                    ..Panel::default()
                }
            })
            .collect();
        let svg = dir.join(format!("{}_elements.svg", spec.name));
        crate::plot::write_svg(&svg, &panels, 640, 460)?;
        files.push(svg);
    }

    let mut md = String::new();
    let head = match spec.parameter {
        HbmParameter::Order => {
            format!("{} rpm, n from {} down to {} and back", spec.rpm, spec.order_max, spec.order_min)
        }
        HbmParameter::Speed { order, rpm_min, rpm_max } => {
            format!("n = {order}, speed from {rpm_max} down to {rpm_min} rpm and back")
        }
        HbmParameter::Torque { order, min, max } => {
            format!("n = {order}, {} rpm, T_n from {max} down to {min} N·m and back", spec.rpm)
        }
    };
    let _ = writeln!(md, "## Harmonic balance `{}`: {head}, H = {}\n", spec.name, spec.harmonics);
    let _ = writeln!(
        md,
        "| T_n (N·m) | continued from ({}) | points | route | stable / unstable | folds | other bifurcations | sweep jumps (up, down) | continuation time (ms) | per point (ms) | end |",
        ax.column
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    for (br, f) in branches.iter().zip(findings(study, &refs, overlay)) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} / {} | {} | {} | {} | {:.1} | {:.3} | {} |",
            match (&spec.engine, br.amplitude.is_nan()) {
                (Some(_), _) => "engine".to_string(),
                (None, true) => "continued".to_string(),
                (None, false) => br.amplitude.to_string(),
            },
            // A switched branch starts at a located crossing: the list's precision, and what
            // it was.
            match br.switched_at {
                Some(at) if br.period_doubled => format!("{at:.5} (period doubling)"),
                Some(at) => format!("{at:.5} (branch point)"),
                None => br.from.to_string(),
            },
            f.points,
            br.route_detail,
            f.stable,
            f.unstable,
            list(&br.folds),
            if br.bifurcations.is_empty() {
                "none".into()
            } else {
                br.bifurcations.iter().map(|(o, k)| format!("{k} at {o:.5}")).collect::<Vec<_>>().join(", ")
            },
            f.sweep_jumps.map_or("–".into(), |(u, d)| format!(
                "{}, {}",
                u.map_or("none".into(), |v| format!("{v:.4}")),
                d.map_or("none".into(), |v| format!("{v:.4}"))
            )),
            1e3 * br.wall_s,
            // The cost per point, which the route and the mechanism's size set (the points
            // count the branch's shape).
            1e3 * br.wall_s / f.points.max(1) as f64,
            br.end
        );
    }
    md.push('\n');
    for br in branches {
        if let Some(w) = coupling_warning(spec, br) {
            let _ = writeln!(md, "{w}");
        }
        if let (Some(at), Some(goes)) = (br.switched_at, &br.goes) {
            let what = if br.amplitude.is_nan() { String::new() } else { format!(" at {} N·m", br.amplitude) };
            let (st, un) = (
                br.stable.iter().filter(|s| **s == Some(true)).count(),
                br.stable.iter().filter(|s| **s == Some(false)).count(),
            );
            let (kind, point) =
                if br.period_doubled { ("period-doubled", "period doubling") } else { ("non-unison", "branch point") };
            let _ = writeln!(
                md,
                "- The {kind} branch{what} switched at the {point} {at:.7} ({st} stable, {un} unstable points) {goes}."
            );
        }
        if let Some(why) = &br.stopped_short {
            let what = if br.amplitude.is_nan() { String::new() } else { format!(" at {} N·m", br.amplitude) };
            let _ = writeln!(md, "- The branch{what} continued from {} {why}; its points are shown.", br.from);
        }
    }
    md += &orbit_table(spec, branches, ax.column);
    Ok((md, files))
}

/// The summary's table of the states at the requested values (`orbits_at`): every distinct
/// state the branches of one amplitude cross there (the two directions of continuation often
/// cross the same one: states whose accelerations and largest angle agree to 1e-6 relative count
/// once), with its stability.
fn orbit_table(spec: &HbmSpec, branches: &[HbmBranch], column: &str) -> String {
    if spec.orbits_at.is_empty() {
        return String::new();
    }
    let mut md = format!(
        "States at the requested values of {column} (every periodic state the branches cross there, solved \
         at that value):\n\n| T_n (N·m) | {column} | states | stable / unstable | main-order acceleration \
         (rad/s²) and largest angle (rad) of each, stability |\n|---|---|---|---|---|\n"
    );
    let same = |a: &HbmOrbit, b: &HbmOrbit| {
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs()).max(1e-12);
        a.accel.iter().zip(&b.accel).all(|(x, y)| close(*x, *y)) && close(a.relative_angle, b.relative_angle)
    };
    let mut amplitudes: Vec<f64> = Vec::new();
    for br in branches {
        if !amplitudes.iter().any(|a| a.to_bits() == br.amplitude.to_bits()) {
            amplitudes.push(br.amplitude);
        }
    }
    for amp in amplitudes {
        for &at in &spec.orbits_at {
            let mut found: Vec<&HbmOrbit> = Vec::new();
            for o in branches
                .iter()
                .filter(|b| b.amplitude.to_bits() == amp.to_bits())
                .flat_map(|b| &b.orbits)
                .filter(|o| o.at == at)
            {
                if !found.iter().any(|f| same(f, o)) {
                    found.push(o);
                }
            }
            found.sort_by(|a, b| a.relative_angle.total_cmp(&b.relative_angle));
            let stable = found.iter().filter(|o| o.stable == Some(true)).count();
            let unstable = found.iter().filter(|o| o.stable == Some(false)).count();
            let each: Vec<String> = found
                .iter()
                .map(|o| {
                    let st = match o.stable {
                        Some(true) => "stable",
                        Some(false) => "unstable",
                        None => "?",
                    };
                    format!("{:.5e}, {:.5}, {st}", o.accel.first().copied().unwrap_or(f64::NAN), o.relative_angle)
                })
                .collect();
            let amp = if amp.is_nan() { "–".to_string() } else { amp.to_string() };
            let _ = writeln!(md, "| {amp} | {at} | {} | {stable} / {unstable} | {} |", found.len(), each.join("; "));
        }
    }
    md.push('\n');
    md
}

fn list(v: &[f64]) -> String {
    if v.is_empty() { "none".into() } else { v.iter().map(|x| format!("{x:.5}")).collect::<Vec<_>>().join(", ") }
}

/// Splits a branch's drawn curve into runs of equal stability, solid when stable, dashed when
/// not; only the first stable and first unstable segment of the main order get a legend entry.
fn push_segments(series: &mut Vec<Series>, br: &HbmBranch, k: usize, legend: bool, labelled: &mut [bool; 2]) {
    let len = br.curve_parameter.len();
    let mut i = 0;
    while i < len {
        let s = br.curve_stable[i] != Some(false);
        let mut j = i;
        while j + 1 < len && (br.curve_stable[j + 1] != Some(false)) == s {
            j += 1;
        }
        // Overlap one point so the segments join.
        let end = (j + 1).min(len - 1);
        let idx = usize::from(!s);
        series.push(Series {
            label: if let (Some(at), true, 0) = (br.switched_at, legend, i) {
                format!("{}, switched at {at:.5}", if br.period_doubled { "period-doubled" } else { "non-unison" })
            } else if labelled[idx] || !legend || br.switched_at.is_some() {
                String::new()
            } else {
                format!("HBM, {}", if s { "stable" } else { "unstable" })
            },
            x: br.curve_parameter[i..=end].to_vec(),
            y: br.curve_accel[k][i..=end].to_vec(),
            color: if br.switched_at.is_some() { k + 3 } else { k },
            // A switched (non-unison) branch: dotted where unstable, in its own colour.
            style: match (s, br.switched_at.is_some()) {
                (true, _) => LineStyle::Solid,
                (false, false) => LineStyle::Dashed,
                (false, true) => LineStyle::Dotted,
            },
        });
        // A switched branch has its own legend entry: the unison branches' stays to be drawn.
        if legend && br.switched_at.is_none() {
            labelled[idx] = true;
        }
        i = j + 1;
    }
}

/// The main-order amplitude on branch `br`'s drawn curve at its turning point nearest the
/// parameter value `at` (a fold turns the continuation back; a bifurcation elsewhere falls back
/// to the nearest point), NaN on an empty branch.
fn value_at_turn(br: &HbmBranch, at: f64) -> f64 {
    let (p, Some(y)) = (&br.curve_parameter, br.curve_accel.first()) else { return f64::NAN };
    let distance = |i: &usize| (p[*i] - at).abs();
    let turn = (1..p.len().saturating_sub(1))
        .filter(|&i| (p[i] - p[i - 1]) * (p[i + 1] - p[i]) <= 0.0)
        .filter(|i| distance(i) < 1e-2 * at.abs().max(1e-9))
        .min_by(|a, b| distance(a).total_cmp(&distance(b)));
    turn.or_else(|| (0..p.len()).min_by(|a, b| distance(a).total_cmp(&distance(b)))).map_or(f64::NAN, |i| y[i])
}

/// A sweep trace's amplitude at the order `at`: its sample nearest that order.
fn trace_value(t: &OrderTrace, at: f64) -> f64 {
    let before = t.order.iter().zip(&t.amplitude).filter(|(o, a)| o.is_finite() && a.is_finite());
    before.min_by(|a, b| (a.0 - at).abs().total_cmp(&(b.0 - at).abs())).map_or(f64::NAN, |(_, a)| *a)
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
