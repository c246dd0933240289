//! The study's glue between the engine, the integrator and order tracking: one time-domain run
//! streamed into the few signals a study needs, with progress bars.

use super::{IntegrationSpec, TrackingSpec};
use crate::error::{Error, Result};
use crate::model::mechanism::Mechanism;
use crate::signal::{OrderTrace, StftOptions, stft_order_traces};
use crate::time::integrate::IntegrateOptions;
use crate::time::probe::{Probe, Recorder};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

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
const SERIES: usize = 3;

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

/// The signals a time run records for the elements: per element its coordinate and its rate.
pub(crate) struct ElementColumns<'a> {
    /// Per element: (q, q̇) over the run's recorded samples.
    pub signals: Vec<(&'a [f64], &'a [f64])>,
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

/// The study's integration options: its tolerances and sample rate, with `ẋ` at the samples.
pub(crate) fn options(spec: &IntegrationSpec) -> IntegrateOptions {
    IntegrateOptions {
        rtol: spec.rtol,
        atol: spec.atol,
        sample_rate_hz: Some(spec.sample_hz),
        sample_derivatives: true,
        max_steps: spec.max_steps,
        deadline: spec.deadline.map(|d| (d.at, d.budget_s)),
        ..IntegrateOptions::default()
    }
}

/// Order traces of a sampled response by the STFT of docs/design.md; `mechanism` names the model in
/// an error (the study validates the bands at load, so one is an internal inconsistency).
#[allow(clippy::too_many_arguments)]
pub(crate) fn track(
    mechanism: &str,
    signal: &[f64],
    fs: f64,
    omega: f64,
    order_at: &dyn Fn(f64) -> f64,
    multiples: &[f64],
    t: &TrackingSpec,
) -> Result<Vec<OrderTrace>> {
    let opts = StftOptions { window_s: t.window_s, hop_s: t.hop_s, half_width_bins: t.half_width_bins };
    if signal.len() < (t.window_s * fs).round() as usize {
        // A run that failed before one full window has no trace; its failure is reported.
        return Ok(multiples.iter().map(|&m| OrderTrace { multiple: m, ..OrderTrace::default() }).collect());
    }
    stft_order_traces(signal, fs, omega, order_at, multiples, &opts)
        .map_err(|e| Error::Model { mechanism: mechanism.to_string(), message: format!("order tracking: {e}") })
}
