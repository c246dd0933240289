//! The study's glue between the engine, the integrator and order tracking: one time-domain run
//! streamed into the few signals a study needs, with progress bars.

use super::elements::{ElementColumns, ElementStreams, ElementTraces};
use super::spec::Integrator;
use super::track::tracked;
use super::{Deadline, ExciteAt, IntegrationSpec, Study, TrackingSpec};
use crate::error::Result;
use crate::kane::{Kane, Model};
use crate::model::mechanism::Mechanism;
use crate::signal::{OrderTrace, StftOptions, StftStream};
use crate::time::integrate::{IntegrateOptions, IntegratorChoice, Method};
use crate::time::probe::{Probe, Recorder};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Arc;

/// Progress bars on stderr, one per running simulation; drawn only when asked for and stderr is
/// a terminal (so logs and CI output stay clean).
pub(crate) struct Progress {
    multi: Option<MultiProgress>,
}

impl Progress {
    pub(crate) fn new(enabled: bool) -> Self {
        let on = enabled && std::io::stderr().is_terminal();
        Self { multi: on.then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr())) }
    }

    /// A spinner with a message line (a harmonic-balance branch: points and the parameter
    /// reached), hidden unless progress is drawn.
    pub(crate) fn spinner(&self, label: &str) -> ProgressBar {
        match &self.multi {
            None => ProgressBar::hidden(),
            Some(m) => {
                let bar = m.add(ProgressBar::new_spinner());
                bar.set_style(
                    ProgressStyle::with_template("{prefix:32} {spinner} {msg} {elapsed:>4}")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                );
                bar.set_prefix(label.to_string());
                bar
            }
        }
    }

    /// A bar counting simulated milliseconds up to `duration_s`.
    pub(crate) fn bar(&self, duration_s: f64, label: &str) -> ProgressBar {
        match &self.multi {
            None => ProgressBar::hidden(),
            Some(m) => {
                let bar = m.add(ProgressBar::new((duration_s * 1000.0) as u64));
                bar.set_style(
                    ProgressStyle::with_template("{msg:32} [{bar:30}] {percent:>3}% {elapsed:>4}")
                        .unwrap_or_else(|_| ProgressStyle::default_bar())
                        .progress_chars("=> "),
                );
                bar.set_message(label.to_string());
                bar
            }
        }
    }
}

/// Named columns sampled at the study's rate.
#[derive(Debug, Clone, Default)]
pub struct TimeSeries {
    /// Column names (with units).
    pub names: Vec<String>,
    /// The SI unit of each column.
    pub units: Vec<&'static str>,
    /// Columns, all of the same length.
    pub columns: Vec<Vec<f64>>,
}

/// Column of the response body's angular acceleration in [`recorder`]'s recorder, rad/s².
pub(crate) const ACCEL: usize = 0;
/// Column of the spin joint's rate q̇_spin, rad/s.
pub(crate) const SPIN_RATE: usize = 1;
/// Column of the largest |q| of the joints other than the spin joint, rad.
pub(crate) const RELATIVE: usize = 2;
/// Columns of the response body's angle and rate, then every coordinate, when the time series is
/// asked for.
pub(crate) const SERIES: usize = 3;

/// The study's recorder: the response body's angular acceleration, the spin rate and the largest
/// relative excursion (always); with `time_series`, the body's angle and rate and every joint
/// coordinate too; last, each of `elements`' coordinate and rate ([`element_columns`]).
pub(crate) fn recorder(
    mech: &Mechanism,
    spin: usize,
    body: usize,
    time_series: bool,
    elements: &[usize],
) -> Result<Recorder> {
    let mut probes = vec![Probe::BodyAccel(body), Probe::JointRate(spin), Probe::LargestJointAngle(spin)];
    if time_series {
        probes.extend([Probe::BodyAngle(body), Probe::BodyRate(body)]);
        probes.extend((0..mech.joints.len()).filter(|&j| mech.coordinate(j).is_some()).map(Probe::JointAngle));
    }
    for &j in elements {
        probes.extend([Probe::JointAngle(j), Probe::JointRate(j)]);
    }
    Recorder::new(mech, &probes)
}

/// The elements' (q, q̇) columns of a [`recorder`] made for `n_elements` elements.
pub(crate) fn element_columns(rec: &Recorder, n_elements: usize) -> ElementColumns<'_> {
    let base = rec.columns.len() - 2 * n_elements;
    let signals = (0..n_elements)
        .map(|e| (rec.columns[base + 2 * e].as_slice(), rec.columns[base + 2 * e + 1].as_slice()))
        .collect();
    ElementColumns { signals }
}

/// The time series of a [`recorder`] made with `time_series` for `n_elements` elements, named for
/// the CSV.
pub(crate) fn time_series(mech: &Mechanism, body: usize, mut rec: Recorder, n_elements: usize) -> Option<TimeSeries> {
    rec.columns.truncate(rec.columns.len() - 2 * n_elements);
    if rec.columns.len() <= SERIES {
        return None;
    }
    let b = &mech.bodies[body].name;
    let mut names =
        vec!["time_s".into(), format!("{b}_angle_rad"), format!("{b}_rate_rad_s"), format!("{b}_accel_rad_s2")];
    let mut units = vec!["s", "rad", "rad/s", "rad/s²"];
    for j in mech.joints.iter().filter(|j| j.coordinate.is_some()) {
        names.push(format!("{}_q_{}", j.name, j.kind.coordinate_unit()));
        units.push(j.kind.coordinate_unit());
    }
    let mut cols = rec.columns;
    let coordinates = cols.split_off(SERIES + 2);
    let rate = cols.pop().unwrap_or_default();
    let angle = cols.pop().unwrap_or_default();
    let accel = cols.swap_remove(ACCEL);
    let mut columns = vec![rec.time, angle, rate, accel];
    columns.extend(coordinates);
    Some(TimeSeries { names, units, columns })
}

/// The study's integration options: its tolerances and sample rate, with `ẋ` at the samples,
/// and the integrator it names (`Auto` as explicit: [`options_for`] decides `Auto`).
pub(crate) fn options(spec: &IntegrationSpec) -> IntegrateOptions {
    IntegrateOptions {
        rtol: spec.rtol,
        atol: spec.atol,
        sample_rate_hz: Some(spec.sample_hz),
        sample_derivatives: true,
        max_steps: spec.max_steps,
        deadline: spec.deadline,
        method: match spec.integrator {
            Integrator::Implicit => Method::Radau5,
            Integrator::Explicit | Integrator::Auto => Method::Dop853,
        },
        ..IntegrateOptions::default()
    }
}

/// DOP853's stability limit on the imaginary axis, `|hλ|` (Hairer's stability region reaches
/// about 6 there; measured on the 16-disk shaft: 235,394 steps over 60 s at a top eigenvalue of
/// |λ| = 1.9e4 1/s, |hλ| = 4.8).
pub(crate) const EXPLICIT_STABLE_HLAMBDA: f64 = 5.0;
/// DOP853 steps per period of the highest excitation line at rtol = 1e-9 when accuracy sets the
/// step (measured: the one-pendulum 60 s sweep takes 29,599 steps up to 55 Hz, 9 a period).
pub(crate) const EXPLICIT_STEPS_PER_PERIOD: f64 = 10.0;
/// How many times more steps the stability limit must force on DOP853 than accuracy asks for
/// before Radau IIA is cheaper. Measured on the 16-disk shaft's 60 s sweep at rtol = 1e-9
/// (BENCHMARKS.md, "Stiff shafts"): DOP853 4.55 s for 235,394 steps (its stability limit, 8.0× the
/// accuracy count), Radau IIA 17.95 s for 227,045 steps at the same trace accuracy (order 5 needs
/// 7.7× DOP853's accuracy count there, and a step with its Newton iterations, Jacobians and the
/// crate's LU factors costs 4× a DOP853 step). Radau's count does not grow with the top mode,
/// DOP853's does in proportion, so they break even near 8.0·17.95/4.55 = 32.
pub(crate) const IMPLICIT_BREAK_EVEN: f64 = 32.0;

/// Which integrator a study's time-domain run at spin speed `omega` (rad/s) with its highest
/// excitation line at `f_line_hz` uses, and why: the study's choice, or under `Auto` the rule of
/// docs/design/time.md ("Stiff mechanisms: the integrator choice"): the fastest eigenvalue |λ|max of
/// the mechanism linearised at `omega` (damped, spin free; [`crate::linear::LinearModel`]) bounds
/// DOP853's step at `5/|λ|max`; accuracy asks for about `1/(10 f_line)·(rtol/1e-9)^(1/8)`;
/// implicit Radau IIA when the first is more than [`IMPLICIT_BREAK_EVEN`] times shorter.
pub(crate) fn options_for(
    study: &Study,
    mech: &Mechanism,
    omega: f64,
    f_line_hz: f64,
) -> (IntegrateOptions, IntegratorChoice) {
    let spec = &study.spec.integration;
    let mut opts = options(spec);
    let lambda = fastest_eigenvalue(mech, &study.spec.spin_joint, omega);
    let h_stable = EXPLICIT_STABLE_HLAMBDA / lambda;
    let h_accurate = (spec.rtol / 1e-9).powf(0.125) / (EXPLICIT_STEPS_PER_PERIOD * f_line_hz.max(1e-3));
    let ratio = h_accurate / h_stable;
    let top_hz = lambda / std::f64::consts::TAU;
    let (method, reason) = match spec.integrator {
        Integrator::Explicit => (Method::Dop853, "set by the study".to_string()),
        Integrator::Implicit => (Method::Radau5, "set by the study".to_string()),
        Integrator::Auto if !lambda.is_finite() || lambda <= 0.0 => {
            (Method::Dop853, "auto: no linearised spectrum, explicit".to_string())
        }
        // A stability limit longer than the accuracy's step does not bind: said so, rather than
        // quoting a "fastest mode" that may be a slow decay (a locked twin's rotor damping).
        Integrator::Auto if ratio <= 1.0 => (
            Method::Dop853,
            format!(
                "auto: explicit, accuracy sets the step ({h_accurate:.3e} s); the fastest eigenvalue \
                 |λ| = {lambda:.4e} 1/s ({top_hz:.4} Hz) would allow {h_stable:.3e} s"
            ),
        ),
        Integrator::Auto => {
            let m = if ratio > IMPLICIT_BREAK_EVEN { Method::Radau5 } else { Method::Dop853 };
            let reason = format!(
                "auto: fastest mode {top_hz:.4} Hz holds an explicit step to {:.3e} s, accuracy asks {:.3e} s: \
                 {ratio:.3}× (implicit above {IMPLICIT_BREAK_EVEN}×)",
                h_stable, h_accurate
            );
            // NOTE: where stability sets DOP853's step, its controller keeps lengthening the step
            // past the limit and rejecting it (15,507 of 250,859 attempts on the 16-disk shaft);
            // capped at the limit it rejects almost none (86) for 3 % fewer right-hand sides
            // (BENCHMARKS.md, "Stiff shafts").
            if m == Method::Dop853 {
                opts.h_max = Some(opts.h_max.map_or(h_stable, |h| h.min(h_stable)));
            }
            (m, reason)
        }
    };
    opts.method = method;
    (opts, IntegratorChoice { method, fastest_mode_hz: top_hz, stability_ratio: ratio, reason })
}

/// The fastest eigenvalue modulus |λ|max (1/s) of `mech` linearised about a steady spin at `omega`
/// (damped, spin free), or NaN when it cannot be linearised; then the coarse time scales of the
/// plan (fastest spring's natural frequency, fastest damper's decay rate) stand in.
pub(crate) fn fastest_eigenvalue(mech: &Mechanism, spin_joint: &str, omega: f64) -> f64 {
    use crate::linear::{Damping, LinearModel, Spin};
    let linear =
        LinearModel::new(mech, spin_joint, omega, None).and_then(|m| m.fastest_rate(Spin::Free, Damping::Damped));
    match linear {
        Ok(l) if l.is_finite() && l > 0.0 => l,
        _ => {
            let (f, decay) = super::plan::time_scales(mech);
            let l = (std::f64::consts::TAU * f).max(decay);
            if l > 0.0 { l } else { f64::NAN }
        }
    }
}

/// What an order sweep reads off one run, computed as the run goes from the rows of a
/// [`recorder`] (so no column needs to be kept): the response's order traces, the largest
/// relative excursion and the elements' traces and peaks, each equal to the same analysis of the
/// whole record ([`super::track::track`], [`super::elements::ElementStreams`]). It holds under two tracking
/// windows per channel.
pub(crate) struct RunStream<'a> {
    stft: StftStream<'a>,
    elements: ElementStreams<'a>,
    n_elements: usize,
    relative: f64,
    channels: Vec<f64>,
    fs: f64,
    multiples: Vec<f64>,
    tracking: TrackingSpec,
}

/// A [`RunStream`]'s results: the response's order traces, the largest relative excursion (rad)
/// and the elements' traces.
pub(crate) type RunResults = (Vec<OrderTrace>, f64, Vec<ElementTraces>);

impl<'a> RunStream<'a> {
    /// The analysis of a run of `mech` sampled at `fs` with the elements `elements` (their
    /// peaks from sample `skip` on), the excitation order `order_at` at the mean speed `omega`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        mech: &'a Mechanism,
        elements: &[usize],
        fs: f64,
        omega: f64,
        order_at: &'a dyn Fn(f64) -> f64,
        multiples: &[f64],
        tracking: &TrackingSpec,
        skip: usize,
    ) -> Self {
        let elements = ElementStreams::new(mech, elements, fs, skip);
        let channels = 1 + elements.channels();
        let opts = StftOptions {
            window_s: tracking.window_s,
            hop_s: tracking.hop_s,
            half_width_bins: tracking.half_width_bins,
        };
        Self {
            stft: StftStream::new(channels, fs, omega, order_at, multiples, &opts),
            n_elements: elements.elements_len(),
            elements,
            relative: 0.0,
            channels: vec![0.0; channels],
            fs,
            multiples: multiples.to_vec(),
            tracking: *tracking,
        }
    }

    /// One sample: a row of the [`recorder`]'s values.
    pub(crate) fn push(&mut self, row: &[f64]) {
        // As `fold(0.0, f64::max)` over the column.
        self.relative = self.relative.max(row[RELATIVE]);
        self.channels[0] = row[ACCEL];
        let base = row.len() - 2 * self.n_elements;
        self.elements.push(&row[base..], &mut self.channels[1..]);
        self.stft.push(&self.channels);
    }

    /// The results; `mechanism` names the model in an order-tracking error.
    pub(crate) fn finish(self, mechanism: &str) -> Result<RunResults> {
        let len = self.stft.len();
        let (fs, multiples, tracking) = (self.fs, self.multiples, self.tracking);
        let mut results = self.stft.finish().into_iter().map(|r| tracked(mechanism, r, len, fs, &multiples, &tracking));
        let traces = results.next().unwrap_or_else(|| Ok(Vec::new()))?;
        let elements = self.elements.finish(results)?;
        Ok((traces, self.relative, elements))
    }
}

impl Study {
    /// A copy whose time runs (its comparisons' too) stop `budget_s` of wall time from now.
    pub(crate) fn with_deadline(&self, budget_s: f64) -> Study {
        let mut s = self.clone();
        let deadline = Some(Deadline::after(budget_s));
        s.spec.integration.deadline = deadline;
        for (_, subs) in &mut s.sub_studies {
            for (_, sub) in subs {
                sub.spec.integration.deadline = deadline;
            }
        }
        s
    }

    /// Mean torque that holds the spin joint's subtree in rigid rotation at `omega` (rad/s): the
    /// viscous losses at the steady rates of [`Mechanism::steady_rates`], by power. A damper whose
    /// rate is `w Ω` (a joint's relative rate, or a ground damper's body rate `Σ w` over the
    /// rotating joints on its path) dissipates `c w² Ω²`, which the spin joint supplies as the
    /// torque `c w² Ω`: on a plain rotor the spinning bodies' ground dampers and the spin joint's
    /// own damper (`Σ c·Ω`; for the CPVA `T_m = c_r·Ω`), and through a gear of factor r a driven
    /// shaft's dampers reflected as `r² c Ω`. In rigid rotation about fixed axes the inertia
    /// forces have no moment about the axes, and joint dampers inside a rigidly turning subtree
    /// see no relative rate. Nonlinear couplings (friction, stops) are not counted.
    pub fn loss_torque(mech: &Mechanism, spin: usize, omega: f64) -> f64 {
        let w = mech.steady_rates(spin);
        let joints: f64 = mech.joints.iter().zip(&w).map(|(j, w)| j.damper * w * w).sum();
        let body_rate = |b: usize| -> f64 {
            mech.path_to(b).into_iter().filter(|&j| mech.joints[j].kind.rotates()).map(|j| w[j]).sum()
        };
        let ground: f64 = mech.loads.ground_dampers.iter().map(|g| g.c * body_rate(g.body).powi(2)).sum();
        (joints + ground) * omega
    }

    /// The initial state of a sweep or steady run (docs/design/conventions.md): q = 0, the spin joint turning at
    /// `omega`, every joint geared to it at its steady rate ([`Mechanism::steady_rates`]: a shaft
    /// behind a compliant mesh turns with the train) and every other joint at rest relative to its
    /// parent.
    pub fn initial_state(mech: &Mechanism, spin: usize, omega: f64) -> Vec<f64> {
        let n = mech.ndof();
        let mut qdot = vec![0.0; n];
        for (joint, w) in mech.joints.iter().zip(mech.steady_rates(spin)) {
            if let Some(k) = joint.coordinate {
                qdot[k] = w * omega;
            }
        }
        let mut u = vec![0.0; n];
        mech.speeds.u_from_qdot(&mech.speed_parents(), &qdot, &mut u);
        let mut x = vec![0.0; 2 * n];
        x[n..].copy_from_slice(&u);
        x
    }

    /// The linear analyses' inputs for an analysis's `excite` list: its joints with their shares
    /// and phases, or the spin joint alone.
    pub(crate) fn inputs(&self, excite: &[ExciteAt]) -> Vec<crate::linear::Input> {
        if excite.is_empty() {
            return vec![crate::linear::Input::unit(self.spec.spin_joint.clone())];
        }
        excite.iter().map(|e| crate::linear::Input { joint: e.joint.clone(), scale: e.scale, phase: e.phase }).collect()
    }

    /// An analysis's `excite` list resolved in `mech` (the mechanism or its locked twin) as
    /// `(joint, scale, phase)`; the spin joint alone when the list is empty. The names were
    /// checked at load (and none is locked, see `validate`).
    pub(crate) fn excited_joints(&self, mech: &Mechanism, excite: &[ExciteAt]) -> Vec<(usize, f64, f64)> {
        let spin = mech.joint_index(&self.spec.spin_joint).unwrap_or(self.spin);
        if excite.is_empty() {
            return vec![(spin, 1.0, 0.0)];
        }
        excite.iter().filter_map(|e| mech.joint_index(&e.joint).map(|j| (j, e.scale, e.phase))).collect()
    }

    /// Sets `kane`'s joint torques for an order excitation: `base`'s mean on the spin joint and
    /// its harmonics, scaled and phase-shifted, at each excited joint (see [`ExciteAt`]).
    pub(crate) fn apply_excitation(
        &self,
        kane: &mut Kane,
        mech: &Mechanism,
        excite: &[ExciteAt],
        base: &crate::model::excitation::Excitation,
    ) {
        let spin = mech.joint_index(&self.spec.spin_joint).unwrap_or(self.spin);
        let joints = self.excited_joints(mech, excite);
        if !joints.iter().any(|j| j.0 == spin) {
            kane.set_joint_torque(spin, crate::model::excitation::Excitation { harmonics: Vec::new(), ..base.clone() });
        }
        for (j, scale, phase) in joints {
            let harmonics = base
                .harmonics
                .iter()
                .map(|h| crate::model::excitation::Harmonic {
                    amplitude: scale * h.amplitude,
                    phase: h.phase + phase,
                    ..*h
                })
                .collect();
            // The mean stays the mechanism's own on every joint but the spin joint, as in the
            // linear operating point and the harmonic balance (a preload such as an engine's
            // mean torque on a joint chain must not vanish with the oscillating part).
            let own = mech_mean(kane, j);
            let mean = if j == spin { base.mean } else { own };
            kane.set_joint_torque(j, crate::model::excitation::Excitation { mean, harmonics, ..base.clone() });
        }
    }

    /// Builds the evaluator of the mechanism (or the locked twin).
    pub(crate) fn kane(&self, locked: bool) -> Result<Kane> {
        match (locked, &self.locked) {
            (true, Some(m)) => Kane::new(m),
            _ => Kane::new(&self.mechanism),
        }
    }

    /// The built models of the mechanism and of the locked twin (when `locked_too`), once, for
    /// parallel jobs to share ([`Study::kane_from`]).
    pub(crate) fn shared_models(&self, locked_too: bool) -> SharedModels {
        let locked = if locked_too { self.locked.as_ref() } else { None };
        SharedModels {
            plain: Model::new(&self.mechanism).ok().map(Arc::new),
            locked: locked.and_then(|m| Model::new(m).ok()).map(Arc::new),
        }
    }

    /// The evaluator of [`Study::kane`] on a model from `shared`; built here when that one is
    /// missing, so a failed build reports its own error in every job, as [`Study::kane`] does.
    pub(crate) fn kane_from(&self, shared: &SharedModels, locked: bool) -> Result<Kane> {
        let model = if locked && self.locked.is_some() { &shared.locked } else { &shared.plain };
        match model {
            Some(m) => Ok(Kane::with_model(Arc::clone(m))),
            None => self.kane(locked),
        }
    }
}

/// A study's built models ([`Study::shared_models`]): parallel jobs take a handle each
/// ([`Kane::with_model`]) instead of building the mechanism again; a job that changes its
/// excitation gets its own copy of the model then (copy on write, see [`crate::kane`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct SharedModels {
    plain: Option<Arc<Model>>,
    locked: Option<Arc<Model>>,
}

/// The mean of the torque the mechanism file applies at joint `j` (0 when none).
fn mech_mean(kane: &Kane, j: usize) -> f64 {
    kane.joint_torques().iter().find(|t| t.joint == j).map_or(0.0, |t| t.excitation.mean)
}
