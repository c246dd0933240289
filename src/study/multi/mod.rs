//! Load case 2 (paper section 4.2, Table 1, Fig. 5): a multi-order torque held at each operating
//! speed until the response is steady; the steady amplitude of each tracked order, with the locked
//! twin for comparison.

mod analysis;
mod spec;
pub use spec::*;

mod columns;
mod report;

use super::elements::{ElementResponse, Range, from_hbm, from_window};
use super::sim::{self, Progress};
use super::{Output, Study};
use crate::error::Result;
use crate::model::excitation::{Excitation, Order, rpm_to_rad_s};
use crate::study::TrackingSpec;
use crate::time::probe::Outcome;
use crate::time::steady::{SteadyOptions, WindowPair, settle};
use columns::table;
use rayon::prelude::*;
use report::render;
use std::path::Path;

/// The steady state at one speed (of the mechanism or of its locked twin).
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct Steady {
    /// Amplitude of each tracked multiple over the last window, rad/s².
    pub amplitudes: Vec<f64>,
    /// Largest relative change of those amplitudes between the last two windows (steadiness).
    pub change: f64,
    /// Simulated time, s.
    pub time_s: f64,
    /// Largest |q| of the joints other than the spin joint over the last window, rad.
    pub max_relative_angle: f64,
    /// Total mean-speed error removed after the ramp-in, rad/s (see `crate::time::steady`).
    pub speed_correction: f64,
    /// Each reported element over the last window (none for the locked twin).
    pub elements: Vec<ElementResponse>,
    /// The simulation's statistics and outcome.
    pub sim: Outcome,
}

/// One operating speed.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct SpeedResult {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// The mechanism's steady state (when the time-domain run is asked for).
    pub response: Option<Steady>,
    /// The locked twin's, when the study locks joints.
    pub locked: Option<Steady>,
    /// Linear amplitudes per tracked multiple (eq. 22, one harmonic per multiple), rad/s².
    pub linear: Option<Vec<f64>>,
    /// The locked twin's linear amplitudes, rad/s².
    pub linear_locked: Option<Vec<f64>>,
    /// With gravity: the linear order-1 amplitude of the watched body's acceleration that
    /// gravity forces at the nominal rotation (`linear::gravity`), rad/s²; None without gravity
    /// or without the linear part.
    pub linear_gravity: Option<f64>,
    /// The locked twin's, rad/s².
    pub linear_gravity_locked: Option<f64>,
    /// Each reported element in the linear response (eq. 22 per harmonic, superposed): its
    /// amplitude per tracked multiple and peak, and the torque of its spring and damper. Empty
    /// without the linear part or without elements (and then left out of `results.json`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub linear_elements: Vec<ElementResponse>,
    /// Every periodic steady state found by harmonic balance at this speed.
    pub hbm: Vec<HbmState>,
    /// The torque scale s < 1 (every harmonic's amplitude times s) at which the low-amplitude
    /// branch, continued up from s = 0.01 at this speed and order, turns back at a fold: with
    /// the full torques (s = 1) that state no longer exists. None when it reaches s = 1 (or
    /// harmonic balance was not asked for).
    pub hbm_lower_fold: Option<f64>,
    /// The harmonic-balance state a slow run-up of the torques reaches: the low-amplitude
    /// branch continued in torque scale from s = 0.01 to the full torques (None when it folds
    /// first, see `hbm_lower_fold`, or harmonic balance was not asked for).
    pub hbm_ramp: Option<HbmState>,
    /// The locked twin's state by the same continuation (None without a locked twin, or when
    /// its branch folds before the full torques: see `hbm_locked_fold`).
    pub hbm_locked: Option<HbmState>,
    /// Where the locked twin's low-amplitude branch folds below s = 1, as `hbm_lower_fold`.
    pub hbm_locked_fold: Option<f64>,
    /// With an engine: its order torques T_k at this speed, `(order, N·m)` for each order the
    /// analysis takes from it (k·n, k = 1..=`engine_multiples`), before any joint's share.
    /// Empty without an engine (and then left out of `results.json`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub engine_torques: Vec<(f64, f64)>,
}

/// One periodic steady state by harmonic balance.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct HbmState {
    /// Amplitude per tracked multiple, rad/s².
    pub amplitudes: Vec<f64>,
    /// Floquet stability.
    pub stable: Option<bool>,
    /// Largest peak |relative angle| of the non-spin joints, rad.
    pub max_relative_angle: f64,
    /// Each reported element, from the Fourier series.
    pub elements: Vec<ElementResponse>,
}

impl SpeedResult {
    /// The stable harmonic-balance state closest to the time-domain steady state, and the largest
    /// relative difference of their tracked amplitudes.
    pub fn hbm_match(&self) -> Option<(&HbmState, f64)> {
        let r = self.response.as_ref()?;
        // A run without finite amplitudes matches nothing (a NaN would read as agreement).
        if r.amplitudes.iter().any(|a| !a.is_finite()) {
            return None;
        }
        self.hbm
            .iter()
            .filter(|h| h.stable == Some(true))
            .map(|h| {
                let d = h.amplitudes.iter().zip(&r.amplitudes).map(|(a, b)| ((a - b) / b).abs()).fold(0.0, f64::max);
                (h, d)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The locked twin's largest tracked amplitude: the scale below which its lines are noise
    /// (0 when not run).
    fn locked_scale(&self) -> f64 {
        self.locked.as_ref().map_or(0.0, |l| l.amplitudes.iter().copied().fold(0.0, f64::max))
    }

    /// Nonlinear amplitude of multiple k (NaN when not run).
    pub fn amplitude(&self, k: usize) -> f64 {
        self.response.as_ref().map_or(f64::NAN, |s| s.amplitudes[k])
    }
    /// The locked twin's nonlinear amplitude of multiple k (NaN when not run).
    pub fn locked_amplitude(&self, k: usize) -> f64 {
        self.locked.as_ref().map_or(f64::NAN, |s| s.amplitudes[k])
    }
    /// Nonlinear amplitude of multiple k over the locked twin's, NaN when undefined (see
    /// `study::ratio`).
    pub fn ratio(&self, k: usize) -> f64 {
        super::ratio(self.amplitude(k), self.locked_amplitude(k), self.locked_scale())
    }

    /// Linear amplitude of multiple k over the locked twin's linear amplitude, NaN when undefined.
    pub fn linear_ratio(&self, k: usize) -> f64 {
        let scale = self.linear_locked.as_ref().map_or(0.0, |l| l.iter().copied().fold(0.0, f64::max));
        super::ratio(self.linear_amplitude(k, false), self.linear_amplitude(k, true), scale)
    }

    fn linear_amplitude(&self, k: usize, locked: bool) -> f64 {
        let v = if locked { &self.linear_locked } else { &self.linear };
        v.as_ref().map_or(f64::NAN, |v| v[k])
    }

    /// Harmonic-balance amplitude of multiple k on the torque ramp's branch, of the mechanism or
    /// of its locked twin (NaN when there is none).
    pub fn hbm_amplitude(&self, k: usize, locked: bool) -> f64 {
        let s = if locked { &self.hbm_locked } else { &self.hbm_ramp };
        s.as_ref().map_or(f64::NAN, |s| s.amplitudes[k])
    }

    /// The torque ramp's harmonic-balance amplitude of multiple k over the locked twin's, NaN
    /// when undefined.
    pub fn hbm_ratio(&self, k: usize) -> f64 {
        let scale = self.hbm_locked.as_ref().map_or(0.0, |l| l.amplitudes.iter().copied().fold(0.0, f64::max));
        super::ratio(self.hbm_amplitude(k, false), self.hbm_amplitude(k, true), scale)
    }
}

/// A multi-order analysis over speed.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct MultiOrderResult {
    /// Analysis name.
    pub name: String,
    /// Base order n.
    pub order: f64,
    /// Tracked multiples (1 = n, 2 = 2n).
    pub multiples: Vec<f64>,
    /// One result per speed, in the file's order.
    pub speeds: Vec<SpeedResult>,
}

/// Runs the multi-order analysis ([`compute`]) and writes its outputs ([`render`]).
pub(crate) fn run(study: &Study, spec: &MultiOrderSpec, dir: &Path, progress: &Progress) -> Result<Output> {
    let (result, failures) = compute(study, spec, progress);
    let (markdown, files) = render(study, spec, &result, dir)?;
    Ok(Output { markdown, files, failures, results: Box::new(result) })
}

/// The steady states at every speed (time domain, with the locked twin), the linear amplitudes
/// and every harmonic-balance state, as asked for; a failed part is listed, never lost with the
/// others.
pub(crate) fn compute(study: &Study, spec: &MultiOrderSpec, progress: &Progress) -> (MultiOrderResult, Vec<String>) {
    let mut jobs: Vec<(usize, bool)> =
        if spec.time_domain { (0..spec.speeds.len()).map(|i| (i, false)).collect() } else { Vec::new() };
    if study.locked.is_some() && spec.time_domain {
        jobs.extend((0..spec.speeds.len()).map(|i| (i, true)));
    }
    // One build of each mechanism for every parallel job below.
    let shared = study.shared_models(study.locked.is_some());
    let done: Vec<Result<Steady>> =
        jobs.par_iter().map(|&(i, locked)| steady(study, &shared, spec, i, locked, progress)).collect();
    let mut failures = Vec::new();
    let mut response: Vec<Option<Steady>> = vec![None; spec.speeds.len()];
    let mut locked: Vec<Option<Steady>> = vec![None; spec.speeds.len()];
    for (&(i, l), r) in jobs.iter().zip(done) {
        match r {
            Ok(s) if l => locked[i] = Some(s),
            Ok(s) => response[i] = Some(s),
            Err(e) => failures.push(format!(
                "{} at {} rpm{}: {e}",
                spec.name,
                spec.speeds[i].rpm,
                if l { " locked" } else { "" }
            )),
        }
    }
    let (linear, linear_locked, gravity, linear_elements) = if spec.linear {
        linear_amplitudes(study, spec).unwrap_or_else(|e| {
            failures.push(format!("{} linear response: {e}", spec.name));
            (Vec::new(), Vec::new(), Vec::new(), Vec::new())
        })
    } else {
        (Vec::new(), Vec::new(), Vec::new(), Vec::new())
    };
    let speeds: Vec<SpeedResult> = spec
        .speeds
        .iter()
        .enumerate()
        .zip(response.into_iter().zip(locked))
        .map(|((i, p), (response, locked))| SpeedResult {
            rpm: p.rpm,
            response,
            locked,
            linear: linear.get(i).cloned(),
            linear_locked: linear_locked.get(i).cloned(),
            linear_gravity: gravity.get(i).copied().flatten().map(|g| g.0),
            linear_gravity_locked: gravity.get(i).copied().flatten().map(|g| g.1),
            linear_elements: linear_elements.get(i).cloned().unwrap_or_default(),
            hbm: Vec::new(),
            hbm_lower_fold: None,
            hbm_ramp: None,
            hbm_locked: None,
            hbm_locked_fold: None,
            engine_torques: engine_torques(spec, p),
        })
        .collect();
    let mut speeds = speeds;
    if spec.hbm {
        let states: Vec<Result<(Vec<HbmState>, Ramp)>> =
            spec.speeds.par_iter().map(|p| hbm_states(study, &shared, spec, p)).collect();
        for (s, st) in speeds.iter_mut().zip(states) {
            match st {
                Ok((states, ramp)) => {
                    s.hbm = states;
                    (s.hbm_ramp, s.hbm_lower_fold) = ramp;
                }
                Err(e) => failures.push(format!("{} harmonic balance at {} rpm: {e}", spec.name, s.rpm)),
            }
        }
        if study.locked.is_some() {
            let locked: Vec<Result<Ramp>> =
                spec.speeds.par_iter().map(|p| ramp(study, &shared, spec, p, true)).collect();
            for (s, r) in speeds.iter_mut().zip(locked) {
                match r {
                    Ok(r) => (s.hbm_locked, s.hbm_locked_fold) = r,
                    Err(e) => failures.push(format!("{} harmonic balance at {} rpm locked: {e}", spec.name, s.rpm)),
                }
            }
        }
    }
    let result =
        MultiOrderResult { name: spec.name.clone(), order: spec.order, multiples: spec.multiples.clone(), speeds };

    for s in &result.speeds {
        for (what, st) in [("", s.response.as_ref()), (" locked", s.locked.as_ref())] {
            let Some(st) = st else { continue };
            if let Some(e) = &st.sim.error {
                failures.push(format!("{} at {} rpm{what}: {e}", spec.name, s.rpm));
            } else if st.amplitudes.iter().any(|a| !a.is_finite()) {
                failures.push(format!(
                    "{} at {} rpm{what}: the steady amplitudes are not finite (left empty)",
                    spec.name, s.rpm
                ));
            }
        }
        let lin =
            s.linear.iter().chain(&s.linear_locked).flatten().chain(&s.linear_gravity).chain(&s.linear_gravity_locked);
        if lin.clone().any(|a| !a.is_finite()) {
            failures.push(format!("{} at {} rpm: the linear amplitudes are not finite (left empty)", spec.name, s.rpm));
        }
    }

    (result, failures)
}

/// The engine's order torques at a speed, `(order, N·m)`: the harmonics the study's loading put
/// there from the engine (empty without one).
fn engine_torques(spec: &MultiOrderSpec, p: &SpeedPoint) -> Vec<(f64, f64)> {
    if spec.engine.is_none() {
        return Vec::new();
    }
    p.harmonics.iter().map(|h| (h.multiple * spec.order, h.amplitude)).collect()
}

/// The orders of the engine torques over every speed, ascending (empty without an engine).
pub(crate) fn engine_orders(result: &MultiOrderResult) -> Vec<f64> {
    let mut orders: Vec<f64> = Vec::new();
    for (o, _) in result.speeds.iter().flat_map(|s| &s.engine_torques) {
        if !orders.iter().any(|x| (x - o).abs() <= 1e-12 * o.abs()) {
            orders.push(*o);
        }
    }
    orders.sort_by(f64::total_cmp);
    orders
}

impl SpeedResult {
    /// The engine's order torque T at `order` at this speed, N·m (NaN when it has none there).
    pub fn engine_torque(&self, order: f64) -> f64 {
        self.engine_torques.iter().find(|(o, _)| (o - order).abs() <= 1e-12 * order.abs()).map_or(f64::NAN, |t| t.1)
    }
}

/// What the summary computes per speed beyond the results (also in `results.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct SpeedFindings {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// Per tracked multiple, the nonlinear amplitude over the locked twin's (NaN: undefined).
    pub ratio: Vec<f64>,
    /// Per tracked multiple, the linear amplitude over the locked twin's linear one (NaN:
    /// undefined).
    pub linear_ratio: Vec<f64>,
    /// The largest relative difference of the tracked amplitudes between the time-domain steady
    /// state and the nearest stable harmonic-balance state (None: either is missing).
    pub hbm_match: Option<f64>,
}

/// The summary's per-speed readings (see [`SpeedFindings`]).
pub(crate) fn findings(result: &MultiOrderResult) -> Vec<SpeedFindings> {
    let k = result.multiples.len();
    result
        .speeds
        .iter()
        .map(|s| SpeedFindings {
            rpm: s.rpm,
            ratio: (0..k).map(|i| s.ratio(i)).collect(),
            linear_ratio: (0..k).map(|i| s.linear_ratio(i)).collect(),
            hbm_match: s.hbm_match().map(|(_, d)| d),
        })
        .collect()
}

/// All periodic steady states at the operating order: the response is continued in order from
/// `order + 0.4` down to `order − 0.4` and back up (a branch crosses the operating order once per
/// sheet of an S-shaped response, and each direction reaches the sheets connected to its start;
/// the way back is skipped when the first branch ended on the state it would start from), and
/// each crossing is solved exactly at the order; with the torque ramp's state ([`ramp`]).
fn hbm_states(
    study: &Study,
    shared: &sim::SharedModels,
    spec: &MultiOrderSpec,
    p: &super::SpeedPoint,
) -> Result<(Vec<HbmState>, Ramp)> {
    let omega = rpm_to_rad_s(p.rpm);
    let path = study.mechanism.rotation_rates(study.body);
    let mut out: Vec<HbmState> = Vec::new();
    let excite = crate::study::excite_at_rpm(&spec.excite, p.rpm);
    let (lo, hi) = (spec.order - 0.4, spec.order + 0.4);
    for (from, to) in [(hi, lo), (lo, hi)] {
        let (mut hbm, branch, _) = super::hbm::branch(study, omega, &p.harmonics, &excite, 10, from, to)?;
        for guess in branch.guesses_at(spec.order) {
            let sol = hbm.solve(spec.order, Some(guess)).map_err(super::hbm::hbm_error(study))?;
            let stable = hbm.stability(&sol).ok().map(|s| s.stable);
            let amplitudes: Vec<f64> = spec.multiples.iter().map(|&m| super::hbm::body_accel(&sol, &path, m)).collect();
            let same = |h: &HbmState| (h.amplitudes[0] - amplitudes[0]).abs() <= 1e-6 * amplitudes[0].abs();
            if !out.iter().any(same) {
                let elements = from_hbm(&study.mechanism, &study.elements, &sol, &spec.multiples);
                out.push(HbmState { amplitudes, stable, max_relative_angle: sol.max_peak_amplitude(), elements });
            }
        }
        // The way back starts where a branch from the rigid rotation at `lo` starts: when this
        // branch reached `lo` at that very state, the way back would retrace it.
        if from == hi
            && branch.end == crate::hbm::BranchEnd::ReachedTarget
            && let Some(end) = branch.points.last()
            && hbm.solve(lo, None).is_ok_and(|start| same_state(&start, &end.solution))
        {
            break;
        }
    }
    out.sort_by(|a, b| a.amplitudes[0].total_cmp(&b.amplitudes[0]));
    Ok((out, ramp(study, shared, spec, p, false)?))
}

/// Whether two harmonic-balance states at one order are the same periodic motion: their
/// Fourier coefficients (rad) agree to 1e-6 of the larger one's largest.
fn same_state(a: &crate::hbm::HbmSolution, b: &crate::hbm::HbmSolution) -> bool {
    let scale = a.coefficients.iter().chain(&b.coefficients).fold(0.0_f64, |m, c| m.max(c.abs()));
    a.coefficients.len() == b.coefficients.len()
        && a.coefficients.iter().zip(&b.coefficients).all(|(x, y)| (x - y).abs() <= 1e-6 * scale.max(1e-12))
}

/// The torque ramp's state and, when its branch folds first, the torque scale of the fold.
type Ramp = (Option<HbmState>, Option<f64>);

/// The state a slow run-up of the torques settles in, by harmonic balance on the mechanism or
/// its locked twin: every harmonic scaled together by s, continued from s = 0.01 (where the
/// response is the linear one) up to the table's torques, s = 1, at the operating order. A fold
/// of maximum kind before s = 1 means that state stops existing on the way (the run jumps): the
/// fold's s is returned instead of a state. The locked twin reports the study's elements that
/// it keeps.
fn ramp(
    study: &Study,
    shared: &sim::SharedModels,
    spec: &MultiOrderSpec,
    p: &super::SpeedPoint,
    locked: bool,
) -> Result<Ramp> {
    use crate::hbm::{ContinuationOptions, FoldKind, HbmOptions, Parameter, RoutedHbm};
    let omega = rpm_to_rad_s(p.rpm);
    let mech = if locked { study.locked.as_ref().unwrap_or(&study.mechanism) } else { &study.mechanism };
    let body = if locked { study.locked_body.unwrap_or(study.body) } else { study.body };
    let spin = mech.joint_index(&study.spec.spin_joint).unwrap_or(study.spin);
    let kane = study.kane_from(shared, locked)?;
    let inputs = study.excited_joints(mech, &crate::study::excite_at_rpm(&spec.excite, p.rpm));
    let opts = HbmOptions { harmonics: 10, ..HbmOptions::default() };
    let err = super::hbm::hbm_error(study);
    let mut hbm = RoutedHbm::new(&kane, spin, omega, (&p.harmonics, &[]), &inputs, opts).map_err(&err)?;
    let param = Parameter::TorqueScale { order: spec.order };
    // Only the end state's stability is reported (solved again below), and the folds need none.
    // The ramp is short and mostly straight (λ from 0.01 to 1): it starts at the largest default
    // step and may take steps of a quarter of it; a fold is a sign change of dλ/ds between
    // points, and a pair inside one step shows as a dip the step is aimed at.
    let copts = ContinuationOptions {
        deadline: study.spec.integration.deadline,
        stability: false,
        ds: 0.1,
        ds_max: 0.25,
        ..ContinuationOptions::default()
    };
    let up = hbm.continue_in(param, 0.01, 1.0, None, &copts).map_err(&err)?;
    if up.end == crate::hbm::BranchEnd::Watchdog {
        let budget = study.spec.integration.deadline.map_or(f64::NAN, |d| d.budget_s);
        return Err(err(crate::hbm::HbmError::Invalid(format!(
            "the torque ramp at {} rpm was stopped by the watchdog: {}",
            p.rpm,
            crate::deadline::Deadline::overran(budget)
        ))));
    }
    let fold = up.folds.first().filter(|f| f.kind == FoldKind::Maximum).map(|f| f.parameter);
    if fold.is_some() {
        return Ok((None, fold));
    }
    let Some(guess) = up.guesses_at(1.0).into_iter().next().cloned() else { return Ok((None, None)) };
    hbm.set_torque_scale(1.0).map_err(&err)?;
    let sol = hbm.solve(spec.order, Some(&guess)).map_err(&err)?;
    let stable = hbm.stability(&sol).ok().map(|s| s.stable);
    let path = mech.rotation_rates(body);
    let amplitudes = spec.multiples.iter().map(|&m| super::hbm::body_accel(&sol, &path, m)).collect();
    let elements: Vec<usize> = if locked {
        let names = study.elements.iter().map(|&j| &study.mechanism.joints[j].name);
        names.filter_map(|n| mech.joint_index(n)).collect()
    } else {
        study.elements.clone()
    };
    let elements = from_hbm(mech, &elements, &sol, &spec.multiples);
    Ok((Some(HbmState { amplitudes, stable, max_relative_angle: sol.max_peak_amplitude(), elements }), None))
}

/// Amplitudes indexed `[speed][multiple]`, rad/s².
type PerSpeed = Vec<Vec<f64>>;
/// Per speed, gravity's order-1 amplitude of the mechanism and of its locked twin, rad/s².
type GravityPerSpeed = Vec<Option<(f64, f64)>>;

/// Linear amplitudes per speed and tracked multiple, of the mechanism and of its locked twin:
/// each harmonic through the order-domain response of eq. (22); a multiple at order 1 also
/// holds gravity's line, added as a phasor. With gravity, its order-1 line per speed.
fn linear_amplitudes(
    study: &Study,
    spec: &MultiOrderSpec,
) -> Result<(PerSpeed, PerSpeed, GravityPerSpeed, Vec<Vec<ElementResponse>>)> {
    let rspec = crate::linear::ResponseSpec {
        spin_joint: study.spec.spin_joint.clone(),
        inputs: study.inputs(&spec.excite),
        body: study.spec.response_body.clone(),
        lock: study.spec.lock.clone(),
    };
    let cases: Vec<crate::linear::SpeedCase> =
        spec.speeds.iter().map(|p| crate::linear::SpeedCase { rpm: p.rpm, harmonics: p.harmonics.clone() }).collect();
    let mech = &study.mechanism;
    // Each speed's shares, where a joint's law makes them follow the speed.
    let per_speed: Vec<Vec<crate::linear::Input>> =
        spec.speeds.iter().map(|p| study.inputs(&crate::study::excite_at_rpm(&spec.excite, p.rpm))).collect();
    let laws = spec.excite.iter().any(|e| !e.law.is_constant());
    let options = crate::linear::MultiOrderOptions {
        modal: spec.modal(),
        inputs: laws.then_some(per_speed.as_slice()),
        elements: &study.elements,
    };
    let res =
        crate::linear::multi_order_response_with(mech, &rspec, spec.order, &cases, None, &options).map_err(|e| {
            crate::error::Error::Model {
                mechanism: mech.name.clone(),
                message: format!("linear multi-order response: {e}"),
            }
        })?;
    let pick = |r: &crate::linear::SpeedResponse, locked: bool| -> Vec<f64> {
        spec.multiples
            .iter()
            .map(|m| {
                let (a, l) = r.line(m * spec.order);
                if locked { l } else { a }
            })
            .collect()
    };
    let gravity = res.iter().map(|r| r.gravity.map(|g| (g.amplitude, g.locked_amplitude))).collect();
    let elements = res.iter().map(|r| linear_elements(mech, spec, r)).collect();
    Ok((res.iter().map(|r| pick(r, false)).collect(), res.iter().map(|r| pick(r, true)).collect(), gravity, elements))
}

/// The elements of one speed's linear response as the study reports them: per tracked multiple,
/// the lines at that order added as phasors (0 where none is), and the superposed peaks.
fn linear_elements(
    mech: &crate::model::mechanism::Mechanism,
    spec: &MultiOrderSpec,
    r: &crate::linear::SpeedResponse,
) -> Vec<ElementResponse> {
    let per_multiple = |a: &[f64], p: &[f64]| -> Vec<f64> {
        spec.multiples
            .iter()
            .map(|m| {
                let same = |h: &crate::linear::HarmonicResponse| (h.multiple - m).abs() <= 1e-12 * m.abs().max(1.0);
                let sum: crate::linear::C64 = r
                    .harmonics
                    .iter()
                    .zip(a.iter().zip(p))
                    .filter(|(h, _)| same(h))
                    .map(|(_, (&a, &p))| crate::linear::C64::from_polar(a, p))
                    .sum();
                sum.norm()
            })
            .collect()
    };
    r.elements
        .iter()
        .map(|e| {
            let joint = &mech.joints[e.joint];
            ElementResponse {
                joint: joint.name.clone(),
                unit: joint.kind.coordinate_unit(),
                amplitude: per_multiple(&e.amplitude, &e.phase),
                peak: e.peak.unwrap_or(f64::NAN),
                range: Range::about(e.mean, e.range.unwrap_or((f64::NAN, f64::NAN))),
                torque: (!e.torque.is_empty() && crate::linear::element_law(mech, e.joint, true).is_some()).then(
                    || super::elements::ElementTorque {
                        amplitude: per_multiple(&e.torque, &e.torque_phase),
                        peak: e.peak_torque.unwrap_or(f64::NAN),
                        range: Range::about(e.mean_torque, e.torque_range.unwrap_or((f64::NAN, f64::NAN))),
                    },
                ),
            }
        })
        .collect()
}

/// Integrates in windows of `window_s` until the amplitudes of the last two windows agree to
/// `steady_tol` (relative) or `max_time_s` is reached.
fn steady(
    study: &Study,
    shared: &sim::SharedModels,
    spec: &MultiOrderSpec,
    i: usize,
    locked: bool,
    progress: &Progress,
) -> Result<Steady> {
    let point = &spec.speeds[i];
    let omega = rpm_to_rad_s(point.rpm);
    let mech = if locked { study.locked.as_ref().unwrap_or(&study.mechanism) } else { &study.mechanism };
    let body = if locked { study.locked_body.unwrap_or(study.body) } else { study.body };
    let spin = mech.joint_index(&study.spec.spin_joint).unwrap_or(study.spin);
    // Start at the linear analysis's operating point when it has one: every coordinate at its
    // relative equilibrium under the mechanism's mean torques (a wound-up spring needs no
    // transient to get there), and the mean spin torque that holds the speed against every
    // loss and constant torque of the mechanism, which the dampers' estimate alone misses.
    let op = crate::linear::LinearModel::new(mech, &study.spec.spin_joint, omega, None).ok().map(|m| m.op);
    let excitation = Excitation {
        mean: spec.mean_torque.unwrap_or_else(|| {
            op.as_ref().map_or_else(|| Study::loss_torque(mech, spin, omega), |op| op.mean_spin_torque)
        }),
        rpm: point.rpm,
        order: Order::Fixed(spec.order),
        harmonics: point.harmonics.clone(),
        ramp_s: spec.ramp_s,
    };
    let mut kane = study.kane_from(shared, locked)?;
    study.apply_excitation(&mut kane, mech, &crate::study::excite_at_rpm(&spec.excite, point.rpm), &excitation);
    let fs = study.spec.integration.sample_hz;
    let label = format!("{} {} rpm{}", spec.name, point.rpm, if locked { " locked" } else { "" });
    let bar = progress.bar(spec.max_time_s, &label);
    // The elements are the mechanism's joints; the locked twin reports none.
    let elements: &[usize] = if locked { &[] } else { &study.elements };
    let mut rec = sim::recorder(mech, spin, body, false, elements)?;
    let x0 = op.as_ref().map_or_else(|| Study::initial_state(mech, spin, omega), |op| [&op.q[..], &op.u[..]].concat());
    let tracking = TrackingSpec { window_s: spec.window_s, hop_s: spec.window_s, half_width_bins: 2 };
    let order = spec.order;
    let mut measure = |tail: &[f64]| -> Result<WindowPair> {
        let traces = super::track::track(&mech.name, tail, fs, omega, &move |_| order, &spec.multiples, &tracking)?;
        let first = traces.iter().map(|tr| tr.amplitude[0]).collect();
        let last = traces.iter().map(|tr| *tr.amplitude.last().unwrap_or(&f64::NAN)).collect();
        Ok((first, last))
    };
    let options = SteadyOptions {
        omega,
        ramp_s: spec.ramp_s,
        window_s: spec.window_s,
        min_time_s: spec.min_time_s,
        max_time_s: spec.max_time_s,
        steady_tol: spec.steady_tol,
    };
    let top_multiple = spec.multiples.iter().fold(1.0_f64, |a, &m| a.max(m));
    let (opts, choice) = sim::options_for(study, mech, omega, top_multiple * order * omega / std::f64::consts::TAU);
    let mut run = settle(
        &mut kane,
        &x0,
        spin,
        &opts,
        &options,
        &mut rec,
        (sim::SPIN_RATE, sim::ACCEL),
        &mut measure,
        &mut |t| bar.set_position((t * 1000.0) as u64),
    )?;
    bar.finish_and_clear();
    run.outcome.integrator = Some(choice);
    let elements = if run.amplitudes.is_empty() || run.outcome.error.is_some() {
        Vec::new()
    } else {
        let cols = sim::element_columns(&rec, elements.len());
        from_window(mech, elements, &cols, run.window_samples, fs, (omega, order), &spec.multiples, &tracking)?
    };
    let relative = &rec.columns[sim::RELATIVE];
    Ok(Steady {
        amplitudes: if run.amplitudes.is_empty() { vec![f64::NAN; spec.multiples.len()] } else { run.amplitudes },
        change: run.change,
        time_s: run.time_s,
        max_relative_angle: relative.iter().rev().take(run.window_samples).copied().fold(0.0, f64::max),
        speed_correction: run.speed_correction,
        elements,
        sim: run.outcome,
    })
}
