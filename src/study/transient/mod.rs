//! Transients and run-ups: the nonlinear equations integrated from a given initial state, the
//! spin speed free, driven through a linear run-up (or run-down) by a feed-forward torque, or
//! prescribed (`time::drive_laws`), with torques at any joints whose orders are locked to the spin
//! joint's angle; the response and every element tracked into an order–rpm map
//! (`signal::order_rpm_map`: angle-domain blocks of whole revolutions) and cut along orders.
//! An `engine` adds its torque from cylinder pressure, crank-locked like the torques, its
//! amplitudes and phases following the spin joint's rate at each instant (`time::drive_laws::EngineTorque`).
//!
//! The feed-forward torque of a `Torque` run-up is the rigid-rotation torque
//! `T(t) = J·α + Σc·Ω_ref(t)`: J the polar inertia of everything the spin joint carries turning
//! rigidly (`uᵀMu` at the initial configuration), α the ramp's acceleration and `Σc·Ω` the
//! viscous losses of rigid rotation (`Study::loss_torque`).

mod analysis;
mod spec;
pub use spec::*;

/// Highest order of a transient's engine series: engine orders that matter for torsional
/// vibration stay below ~50, and each kept order costs a term in every right-hand side.
pub const MAX_ENGINE_ORDER: f64 = 64.0;

mod report;

use super::sim::Progress;
use super::{Output, Study};
use crate::error::Result;
use crate::model::excitation::{Excitation, rpm_to_rad_s};
use crate::signal::{AngleOptions, OrderMap, order_rpm_map};
use crate::time::drive_laws::{Drive, EngineTorque, Governor, LockedTorque, Prescribed, rigid_inertia};
use crate::time::probe::{Outcome, Probe, Recorder, simulate_rhs};
use report::render;
pub(crate) use report::tables;
use serde::Serialize;
use std::f64::consts::PI;
use std::path::Path;

/// One order cut of the map: the amplitude of one signal at one order against the blocks' speed.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct OrderCut {
    /// The signal: the response body's acceleration (`<body>_accel`) or an element's coordinate
    /// (`<joint>_q`).
    pub signal: String,
    /// Its unit (rad/s² for the response, rad or m for an element).
    pub unit: &'static str,
    /// The order cut, cycles per spin revolution.
    pub order: f64,
    /// Amplitude per block, signal units.
    pub amplitude: Vec<f64>,
    /// The largest amplitude of the cut.
    pub peak: f64,
    /// The blocks' mean speed at that peak, rpm.
    pub peak_rpm: f64,
}

/// An element's largest excursion over the run.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ElementPeak {
    /// The joint.
    pub joint: String,
    /// Unit of its coordinate (rad or m).
    pub unit: &'static str,
    /// Largest |q| over the run, in `unit`.
    pub peak: f64,
    /// When it occurred, s.
    pub at_time_s: f64,
    /// The spin speed then, rpm.
    pub at_rpm: f64,
}

/// What a transient produced. Serialised into `results.json` without the sampled signals and the
/// map's cells (which are there as tables, like their CSV files).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TransientResult {
    /// The analysis name.
    pub name: String,
    /// Polar moment of inertia of the spin joint's load in rigid rotation, kg·m² (the
    /// feed-forward's J).
    pub rigid_inertia_kg_m2: f64,
    /// Spin speed at the start of the run, rpm.
    pub rpm_start: f64,
    /// Spin speed at the end of the run (as reached, which a torque-driven run-up may miss), rpm.
    pub rpm_end: f64,
    /// The map's speed resolution: the widest spread of speeds inside one block, rpm.
    pub map_speed_resolution_rpm: f64,
    /// The map's order resolution 1/R, cycles/rev.
    pub map_order_resolution: f64,
    /// The order cuts of the response, then of each element.
    pub cuts: Vec<OrderCut>,
    /// Each element's largest excursion.
    pub elements: Vec<ElementPeak>,
    /// The simulation's statistics and outcome.
    pub sim: Outcome,
    /// Sample times, s.
    #[serde(skip)]
    pub time_s: Vec<f64>,
    /// Spin speed at the samples, rpm.
    #[serde(skip)]
    pub spin_rpm: Vec<f64>,
    /// The response body's angular acceleration at the samples, rad/s².
    #[serde(skip)]
    pub response: Vec<f64>,
    /// Per element: (q, q̇) at the samples.
    #[serde(skip)]
    pub element_series: Vec<(Vec<f64>, Vec<f64>)>,
    /// Per joint of `reactions`: its name and the radial force (N), tangential force (N) and
    /// moment (N·m) its parent exerts on its child at the samples.
    #[serde(skip)]
    pub reaction_series: Vec<(String, [Vec<f64>; 3])>,
    /// Per joint of `reactions` that a gear drives: its name and the torque its mesh exerts on
    /// it at the samples, N·m (N on a slide).
    #[serde(skip)]
    pub mesh_series: Vec<(String, Vec<f64>)>,
    /// Per joint of `reactions`: the smallest and largest radial force, tangential force and
    /// moment after the first second (N, N, N·m).
    pub reaction_ranges: Vec<ReactionRange>,
    /// The prescribed drive's torque at the samples, N·m (empty unless `Prescribed`).
    #[serde(skip)]
    pub drive_torque: Vec<f64>,
    /// The response's order–rpm map (None when the run did not give one block).
    #[serde(skip)]
    pub map: Option<OrderMap>,
    /// Why there is no map (or no map of some element), for the summary: a run too short or
    /// turning the wrong way for the map's blocks is a note, not a failure, since the time
    /// series, peaks and reactions stand without it.
    #[serde(skip)]
    pub map_note: Option<String>,
    /// Block speeds of the map, rpm.
    pub block_rpm: Vec<f64>,
    /// Block centre times of the map, s.
    pub block_time_s: Vec<f64>,
}

/// Runs the transient ([`compute`]) and writes its outputs ([`render`]).
pub(crate) fn run(study: &Study, spec: &TransientSpec, dir: &Path, progress: &Progress) -> Result<Output> {
    let (result, failures) = compute(study, spec, progress)?;
    let (markdown, files) = render(study, spec, &result, dir)?;
    Ok(Output { markdown, files, failures, results: Box::new(result) })
}

/// The cut orders: as given, or every harmonic of every torque (at most 8, lowest first).
pub(crate) fn cut_orders(spec: &TransientSpec) -> Vec<f64> {
    if !spec.map.cuts.is_empty() {
        return spec.map.cuts.clone();
    }
    let mut orders: Vec<f64> =
        spec.torques.iter().flat_map(|t| t.harmonics.iter().map(move |h| h.multiple * t.order)).collect();
    orders.extend(engine_orders(spec));
    orders.sort_by(f64::total_cmp);
    orders.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    orders.truncate(8);
    orders
}

/// The engine's orders that carry torque at the profile's highest speed: above 1e-6 of the
/// largest (a balanced engine's cancelled orders are left out; they sit at rounding level).
fn engine_orders(spec: &TransientSpec) -> Vec<f64> {
    let Some(series) = spec.engine.as_ref().and_then(|e| e.series.as_ref()) else { return Vec::new() };
    let (a, b) = spec.speed.rpm_range();
    let h = series.harmonics(rpm_to_rad_s(a.max(b)), 0.5);
    let largest = h.iter().fold(0.0f64, |m, x| m.max(x.amplitude));
    h.iter().filter(|x| x.amplitude > 1e-6 * largest).map(|x| 0.5 * x.multiple).collect()
}

/// `(α in rad/s², ramp length in s)` of a run-up profile; zero for `Free`.
fn ramp(spec: &TransientSpec) -> (f64, f64) {
    match spec.speed {
        SpeedProfile::Free { .. } => (0.0, 0.0),
        SpeedProfile::Torque { rpm_from, rpm_to, ramp_s, .. }
        | SpeedProfile::Prescribed { rpm_from, rpm_to, ramp_s } => {
            let d = ramp_s.unwrap_or(spec.duration_s);
            ((rpm_to_rad_s(rpm_to) - rpm_to_rad_s(rpm_from)) / d, d)
        }
    }
}

/// The initial state `[q; u]`: the named angles, the spin joint at the profile's first speed and
/// the joints meshed to it at their steady rates ([`Mechanism::steady_rates`]: a train behind a
/// compliant mesh starts turning with it, not against its mesh), the named rates relative to
/// their parents, every other joint at rest relative to its parent.
///
/// [`Mechanism::steady_rates`]: crate::model::mechanism::Mechanism::steady_rates
pub(crate) fn initial_state(study: &Study, spec: &TransientSpec) -> Vec<f64> {
    let mech = &study.mechanism;
    let n = mech.ndof();
    let coord = |name: &str| mech.joint_index(name).and_then(|j| mech.coordinate(j));
    let mut x = vec![0.0; 2 * n];
    let mut qdot = vec![0.0; n];
    let start = rpm_to_rad_s(spec.speed.rpm_range().0);
    for (joint, w) in mech.joints.iter().zip(mech.steady_rates(study.spin)) {
        if let Some(k) = joint.coordinate {
            qdot[k] = w * start;
        }
    }
    for (name, q) in &spec.angles {
        if let Some(c) = coord(name) {
            x[c] = *q;
        }
    }
    for (name, r) in &spec.rates {
        if let Some(c) = coord(name) {
            qdot[c] = *r;
        }
    }
    if let Some(c) = mech.coordinate(study.spin) {
        qdot[c] = start;
    }
    mech.speeds.u_from_qdot(&mech.speed_parents(), &qdot, &mut x[n..]);
    x
}

/// A torque of the study file as the drive's crank-locked torque.
fn locked(study: &Study, t: &JointTorqueSpec) -> LockedTorque {
    LockedTorque {
        joint: study.mechanism.joint_index(&t.joint).unwrap_or(study.spin),
        mean_nm: t.mean,
        mean_slope_nm_s: 0.0,
        mean_until_s: 0.0,
        order: t.order,
        harmonics: t.harmonics.clone(),
        ramp_s: t.ramp_s,
    }
}

/// A transient ready to run: the drive with its torques (or the prescribed speed), the
/// recorder of the response, the spin joint, the elements and the reactions, and the state it
/// starts from.
struct Rig {
    drive: Drive,
    rec: Recorder,
    x0: Vec<f64>,
    /// The rigid-rotation inertia of the spin joint's load, kg·m².
    inertia: f64,
    /// Whether the spin speed is prescribed.
    prescribed: bool,
    /// The first speed, rad/s.
    omega0: f64,
    /// The joints whose reactions are recorded.
    reaction_joints: Vec<usize>,
}

/// Whether a gear mesh drives joint `j` (its reaction comes with the mesh's torque).
fn meshed(study: &Study, j: usize) -> bool {
    matches!(study.mechanism.gear_driving(j), Ok(Some(_)))
}

/// The drive, the recorder and the initial state of the transient: the analysis's torques in
/// place of the mechanism's own, the feed-forward torque (losses and J·α through the ramp) or
/// the prescribed speed, the engine and the governor.
fn rig(study: &Study, spec: &TransientSpec) -> Result<Rig> {
    let mech = &study.mechanism;
    let spin = study.spin;
    let mut kane = study.kane(false)?;
    // The analysis's torques replace the mechanism's own (a geared engine's unconstrained tree
    // lists the driven joints' too).
    for jt in kane.unconstrained().map_or(kane.joint_torques(), |u| u.joint_torques()).to_vec() {
        kane.set_joint_torque(jt.joint, Excitation::constant(0.0));
    }
    let x0 = initial_state(study, spec);
    let n = mech.ndof();
    let (alpha, ramp_s) = ramp(spec);
    let omega0 = rpm_to_rad_s(spec.speed.rpm_range().0);
    let mut torques: Vec<LockedTorque> = spec.torques.iter().map(|t| locked(study, t)).collect();
    let prescribed = match spec.speed {
        SpeedProfile::Prescribed { .. } => Some(Prescribed { joint: spin, accel: alpha, until_s: ramp_s }),
        _ => None,
    };
    let inertia = rigid_inertia(&mut kane, spin, &x0[..n]).unwrap_or(f64::NAN);
    if prescribed.is_none() {
        // The losses of rigid rotation at the reference speed, plus J·α through the ramp.
        let c = Study::loss_torque(mech, spin, 1.0);
        torques.push(LockedTorque {
            joint: spin,
            mean_nm: c * omega0 + inertia * alpha,
            mean_slope_nm_s: c * alpha,
            mean_until_s: ramp_s,
            order: 1.0,
            harmonics: Vec::new(),
            ramp_s: 0.0,
        });
    }
    let reaction_joints: Vec<usize> = spec.reactions.iter().filter_map(|r| mech.joint_index(r)).collect();
    let mut rec = recorder(study, &reaction_joints)?;
    // A mesh torque balances the torques at driven joints as this run applies them.
    rec.use_torques_of(&kane);
    let mut drive = Drive::new(kane, spin, torques, prescribed)?;
    if let Some(e) = &spec.engine {
        // Resolved at load; a spec built without loading has no series and no engine torque.
        let series = e.series.clone().unwrap_or_default();
        let shares = study.excited_joints(mech, &e.excite);
        let engine = shares
            .into_iter()
            .map(|(joint, scale, phase)| EngineTorque { joint, scale, phase, ramp_s: e.ramp_s, series: series.clone() })
            .collect();
        drive = drive.with_engine_torques(engine)?;
    }
    if let SpeedProfile::Torque { governor_s: Some(tau), .. } = spec.speed {
        drive = drive.with_governor(Governor {
            joint: spin,
            gain: inertia / tau,
            rate0: omega0,
            accel: alpha,
            until_s: ramp_s,
        })?;
    }
    Ok(Rig { drive, rec, x0, inertia, prescribed: prescribed.is_some(), omega0, reaction_joints })
}

/// The transient's recorder: the response body's acceleration, the spin joint's angle and
/// rate, each element's (q, q̇), and each reaction joint's radial and tangential force and
/// moment (with its gear mesh's torque when a mesh drives it).
fn recorder(study: &Study, reaction_joints: &[usize]) -> Result<Recorder> {
    let spin = study.spin;
    let mut probes = vec![Probe::BodyAccel(study.body), Probe::JointAngle(spin), Probe::JointRate(spin)];
    for &j in &study.elements {
        probes.extend([Probe::JointAngle(j), Probe::JointRate(j)]);
    }
    for &j in reaction_joints {
        probes.extend([Probe::JointForceRadial(j), Probe::JointForceTangential(j), Probe::JointMoment(j)]);
        if meshed(study, j) {
            probes.push(Probe::GearMeshTorque(j));
        }
    }
    Recorder::new(&study.mechanism, &probes)
}

/// A transient's recorded signals, by name.
struct Recorded {
    time_s: Vec<f64>,
    response: Vec<f64>,
    theta: Vec<f64>,
    spin_rpm: Vec<f64>,
    element_series: Vec<(Vec<f64>, Vec<f64>)>,
    reaction_series: Vec<(String, [Vec<f64>; 3])>,
    mesh_series: Vec<(String, Vec<f64>)>,
}

impl Recorded {
    /// The columns of `rec` (made by [`recorder`] for `reaction_joints`), taken out of it.
    fn take(study: &Study, rec: &mut Recorder, reaction_joints: &[usize]) -> Self {
        let mech = &study.mechanism;
        let to_rpm = 60.0 / (2.0 * PI);
        let time_s = std::mem::take(&mut rec.time);
        let mut cols = std::mem::take(&mut rec.columns).into_iter();
        let response = cols.next().unwrap_or_default();
        let theta = cols.next().unwrap_or_default();
        let spin_rpm: Vec<f64> = cols.next().unwrap_or_default().iter().map(|w| w * to_rpm).collect();
        let element_series: Vec<(Vec<f64>, Vec<f64>)> =
            study.elements.iter().map(|_| (cols.next().unwrap_or_default(), cols.next().unwrap_or_default())).collect();
        let mut mesh_series = Vec::new();
        let reaction_series: Vec<(String, [Vec<f64>; 3])> = reaction_joints
            .iter()
            .map(|&j| {
                let mut next = || cols.next().unwrap_or_default();
                let forces = [next(), next(), next()];
                if meshed(study, j) {
                    mesh_series.push((mech.joints[j].name.clone(), next()));
                }
                (mech.joints[j].name.clone(), forces)
            })
            .collect();
        Self { time_s, response, theta, spin_rpm, element_series, reaction_series, mesh_series }
    }

    /// Each reaction's range after the first second.
    fn reaction_ranges(&self) -> Vec<ReactionRange> {
        let skip = self.time_s.iter().position(|&t| t >= 1.0).unwrap_or(0);
        let range =
            |v: &[f64]| v.iter().skip(skip).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        self.reaction_series
            .iter()
            .map(|(name, [r, t, m])| ReactionRange {
                joint: name.clone(),
                radial_n: range(r),
                tangential_n: range(t),
                moment_nm: range(m),
                mesh_torque_nm: self.mesh_series.iter().find(|(n, _)| n == name).map(|(_, v)| range(v)),
            })
            .collect()
    }

    /// Each element's largest excursion, refined between the samples (Hermite with q̇), with the
    /// time and speed of its largest sample.
    fn element_peaks(&self, study: &Study) -> Vec<ElementPeak> {
        let (mech, fs) = (&study.mechanism, study.spec.integration.sample_hz);
        study
            .elements
            .iter()
            .zip(&self.element_series)
            .map(|(&j, (q, qd))| {
                let (k, _) = q
                    .iter()
                    .enumerate()
                    .map(|(k, v)| (k, v.abs()))
                    .fold((0, f64::NAN), |a, b| if b.1 > a.1 || a.1.is_nan() { b } else { a });
                // Between the samples too (Hermite with q̇).
                let peak = crate::signal::findings::refined_peak(q, Some(qd), 1.0 / fs, 0.0);
                ElementPeak {
                    joint: mech.joints[j].name.clone(),
                    unit: mech.joints[j].kind.coordinate_unit(),
                    peak,
                    at_time_s: self.time_s.get(k).copied().unwrap_or(f64::NAN),
                    at_rpm: self.spin_rpm.get(k).copied().unwrap_or(f64::NAN),
                }
            })
            .collect()
    }

    /// The order–rpm map of the response over the spin joint's angle, with the cuts of it and of
    /// each element's own map at the analysis's orders, and a note for a map that cannot be made
    /// (the time series do not depend on it).
    fn order_map(&self, study: &Study, spec: &TransientSpec) -> (Option<OrderMap>, Vec<OrderCut>, Option<String>) {
        let mech = &study.mechanism;
        let fs = study.spec.integration.sample_hz;
        let opts_map = AngleOptions {
            samples_per_rev: spec.map.samples_per_rev,
            revs_per_block: spec.map.revs_per_block,
            hop_revs: spec.map.hop_revs,
            half_width_bins: study.spec.order_tracking.half_width_bins,
        };
        let orders = cut_orders(spec);
        let mut cuts = Vec::new();
        let mut map = None;
        let mut map_notes: Vec<String> = Vec::new();
        let body = &study.spec.response_body;
        match order_rpm_map(&self.response, &self.theta, fs, spec.map.max_order, &opts_map) {
            Ok(m) => {
                cuts.extend(cuts_of(&m, &orders, &format!("{body}_accel"), "rad/s²"));
                for (e, &j) in study.elements.iter().enumerate() {
                    let joint = &mech.joints[j];
                    match order_rpm_map(&self.element_series[e].0, &self.theta, fs, spec.map.max_order, &opts_map) {
                        Ok(em) => cuts.extend(cuts_of(
                            &em,
                            &orders,
                            &format!("{}_q", joint.name),
                            joint.kind.coordinate_unit(),
                        )),
                        Err(err) => map_notes.push(format!("no order map of `{}` ({err})", joint.name)),
                    }
                }
                map = Some(m);
            }
            Err(e) => map_notes.push(format!(
                "no order–rpm map ({e}): it needs the spin joint turning forwards through at least one block of {} \
                 revolutions (`map.revs_per_block`)",
                spec.map.revs_per_block
            )),
        }
        (map, cuts, (!map_notes.is_empty()).then(|| map_notes.join("; ")))
    }
}

/// Integrates the transient and tracks its map; the run's failure (if any) is listed and its
/// samples up to there kept, and a map that cannot be made is listed without costing the time
/// series.
pub(crate) fn compute(
    study: &Study,
    spec: &TransientSpec,
    progress: &Progress,
) -> Result<(TransientResult, Vec<String>)> {
    let mech = &study.mechanism;
    let n = mech.ndof();
    let Rig { mut drive, mut rec, x0, inertia, prescribed, omega0, reaction_joints } = rig(study, spec)?;
    // The highest excitation line: the top of the speed range at the engine's highest order (the
    // speed itself without an engine).
    let top_omega = {
        let (a, b) = spec.speed.rpm_range();
        rpm_to_rad_s(a.max(b))
    };
    let top_order = spec.engine.as_ref().map_or(1.0, |e| e.max_order.max(e.order));
    let (mut opts, choice) = super::sim::options_for(study, mech, omega0, top_order * top_omega / (2.0 * PI));
    // Reactions need the accelerations at the samples.
    opts.sample_derivatives |= rec.needs_derivatives();
    let bar = progress.bar(spec.duration_s, &spec.name);
    let sim = simulate_rhs(|t, x, dx| drive.rhs(t, x, dx), n, &x0, 0.0, spec.duration_s, &opts, &mut rec, &mut |t| {
        bar.set_position((t * 1000.0) as u64)
    });
    bar.finish_and_clear();
    let mut sim = sim;
    sim.integrator = Some(choice);
    let mut failures = Vec::new();
    if let Some(e) = &sim.error {
        failures.push(format!("{}: {e} (the samples up to there are kept)", spec.name));
    }
    let r = Recorded::take(study, &mut rec, &reaction_joints);
    let reaction_ranges = r.reaction_ranges();
    // The drive's torque at the samples, from the state rebuilt out of every joint's (q, q̇)
    // would need them all; the recorded ones are the spin and the elements, so it is evaluated
    // from a full state only when every coordinate is recorded.
    let mut drive_torque = Vec::new();
    if prescribed {
        drive_torque = reaction(&mut drive, study, &r.time_s, &r.theta, &r.spin_rpm, &r.element_series);
    }
    let (map, cuts, map_note) = r.order_map(study, spec);
    let elements = r.element_peaks(study);
    let Recorded { time_s, response, spin_rpm, element_series, reaction_series, mesh_series, .. } = r;
    let result = TransientResult {
        name: spec.name.clone(),
        rigid_inertia_kg_m2: inertia,
        rpm_start: spin_rpm.first().copied().unwrap_or(f64::NAN),
        rpm_end: spin_rpm.last().copied().unwrap_or(f64::NAN),
        map_speed_resolution_rpm: map.as_ref().map_or(f64::NAN, OrderMap::speed_resolution_rpm),
        map_order_resolution: 1.0 / spec.map.revs_per_block as f64,
        cuts,
        elements,
        sim,
        block_rpm: map.as_ref().map(|m| m.rpm.clone()).unwrap_or_default(),
        block_time_s: map.as_ref().map(|m| m.time_s.clone()).unwrap_or_default(),
        time_s,
        spin_rpm,
        response,
        element_series,
        reaction_series,
        mesh_series,
        reaction_ranges,
        drive_torque,
        map,
        map_note,
    };
    Ok((result, failures))
}

/// The range of one joint's reaction over a transient (after its first second).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ReactionRange {
    /// The joint.
    pub joint: String,
    /// Smallest and largest radial force, N.
    pub radial_n: (f64, f64),
    /// Smallest and largest tangential force, N.
    pub tangential_n: (f64, f64),
    /// Smallest and largest moment, N·m.
    pub moment_nm: (f64, f64),
    /// Smallest and largest torque of the gear mesh driving the joint, N·m (N on a slide);
    /// absent when no gear drives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh_torque_nm: Option<(f64, f64)>,
}

/// The drive's torque at every sample, when the recorded joints (spin and elements) are all the
/// mechanism's coordinates; otherwise empty.
fn reaction(
    drive: &mut Drive,
    study: &Study,
    time_s: &[f64],
    theta: &[f64],
    spin_rpm: &[f64],
    element_series: &[(Vec<f64>, Vec<f64>)],
) -> Vec<f64> {
    let mech = &study.mechanism;
    let n = mech.ndof();
    // A rigidly driven element has no coordinate of its own: it cannot complete the state.
    if study.elements.len() + 1 != n || study.elements.iter().any(|&j| mech.coordinate(j).is_none()) {
        return Vec::new();
    }
    let parents = mech.speed_parents();
    let mut coords = vec![mech.coordinate(study.spin).unwrap_or(0)];
    coords.extend(study.elements.iter().map(|&j| mech.coordinate(j).unwrap_or(0)));
    let mut x = vec![0.0; 2 * n];
    let mut qdot = vec![0.0; n];
    (0..time_s.len())
        .map(|k| {
            x[coords[0]] = theta[k];
            qdot[coords[0]] = spin_rpm[k] * 2.0 * PI / 60.0;
            for (e, (q, qd)) in element_series.iter().enumerate() {
                x[coords[e + 1]] = q[k];
                qdot[coords[e + 1]] = qd[k];
            }
            mech.speeds.u_from_qdot(&parents, &qdot, &mut x[n..]);
            drive.drive_torque(time_s[k], &x).unwrap_or(f64::NAN)
        })
        .collect()
}

/// The cuts of `map` at `orders` for one signal.
fn cuts_of(map: &OrderMap, orders: &[f64], signal: &str, unit: &'static str) -> Vec<OrderCut> {
    orders
        .iter()
        .filter_map(|&order| {
            let amplitude = map.cut(order)?;
            let (k, peak) = amplitude
                .iter()
                .copied()
                .enumerate()
                .fold((0, f64::NAN), |a, b| if b.1 > a.1 || a.1.is_nan() { b } else { a });
            Some(OrderCut { signal: signal.to_string(), unit, order, peak, peak_rpm: map.rpm[k], amplitude })
        })
        .collect()
}
