//! The study's glue between the engine, the integrator and order tracking: one time-domain run
//! streamed into the few signals a study needs, with progress bars.

use super::{IntegrationSpec, TrackingSpec};
use crate::error::{Error, Result};
use crate::kane::Kane;
use crate::model::mechanism::Mechanism;
use crate::signal::{OrderTrace, StftOptions, stft_order_traces};
use crate::time::integrate::{IntegrateOptions, Sample, integrate};
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

/// Statistics and outcome of one simulation (or of several consecutive chunks).
#[derive(Debug, Clone, Default)]
pub struct SimInfo {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Right-hand-side evaluations by the integrator plus one per sample (accelerations).
    pub rhs_evals: usize,
    /// Wall-clock time, s.
    pub wall_s: f64,
    /// Why the run stopped early (its samples up to there are kept).
    pub error: Option<String>,
    /// Time reached, s.
    pub t_end: f64,
    /// State reached.
    pub x_end: Vec<f64>,
    /// The sampled time series, when recorded.
    pub time_series: Option<TimeSeries>,
}

impl SimInfo {
    /// Adds a later chunk's counters and takes its end state and outcome.
    pub(crate) fn absorb(&mut self, c: &SimInfo) {
        self.accepted += c.accepted;
        self.rejected += c.rejected;
        self.rhs_evals += c.rhs_evals;
        self.wall_s += c.wall_s;
        self.t_end = c.t_end;
        self.x_end = c.x_end.clone();
        if c.error.is_some() {
            self.error = c.error.clone();
        }
    }
}

/// Named columns sampled at the study's rate.
#[derive(Debug, Clone, Default)]
pub struct TimeSeries {
    /// Column names (with units).
    pub names: Vec<String>,
    /// Columns, all of the same length.
    pub columns: Vec<Vec<f64>>,
}

/// Collects, at each sample: the response body's angular acceleration (always), the largest
/// |q| of the joints other than the spin joint, and optionally the full time series.
pub(crate) struct Recorder {
    parents: Vec<Option<usize>>,
    speeds: crate::model::speeds::Speeds,
    /// The coordinates of the rotating joints on the response body's path
    /// ([`Mechanism::rotation_coordinates`]): its angle, rate and acceleration are their sums.
    rotation: Vec<usize>,
    spin: usize,
    n: usize,
    qdd: Vec<f64>,
    last_t: f64,
    /// Response angular acceleration, rad/s², one per sample.
    pub accel: Vec<f64>,
    /// Spin joint rate q̇_spin (the spin body's angular velocity), rad/s, one per sample.
    pub spin_rate: Vec<f64>,
    /// Per sample, the largest |q| of the non-spin joints, rad.
    rel: Vec<f64>,
    /// Largest |q| of the non-spin joints over the whole run, rad.
    pub max_relative_angle: f64,
    series: Option<TimeSeries>,
}

impl Recorder {
    pub(crate) fn new(mech: &Mechanism, spin: usize, body: usize, time_series: bool) -> Self {
        let n = mech.ndof();
        let series = time_series.then(|| {
            let b = &mech.bodies[body].name;
            let mut names =
                vec!["time_s".into(), format!("{b}_angle_rad"), format!("{b}_rate_rad_s"), format!("{b}_accel_rad_s2")];
            names.extend(
                mech.joints
                    .iter()
                    .filter(|j| j.coordinate.is_some())
                    .map(|j| format!("{}_q_{}", j.name, j.kind.coordinate_unit())),
            );
            TimeSeries { columns: vec![Vec::new(); names.len()], names }
        });
        Recorder {
            parents: mech.speed_parents(),
            speeds: mech.speeds,
            rotation: mech.rotation_coordinates(body),
            spin,
            n,
            qdd: vec![0.0; n],
            last_t: f64::NEG_INFINITY,
            accel: Vec::new(),
            spin_rate: Vec::new(),
            rel: Vec::new(),
            max_relative_angle: 0.0,
            series,
        }
    }

    fn record(&mut self, s: &Sample<'_>, fs: f64) {
        // Consecutive chunks share their boundary sample: keep the first.
        if s.t <= self.last_t + 0.5 / fs {
            return;
        }
        self.last_t = s.t;
        let n = self.n;
        let (q, u) = s.x.split_at(n);
        let Some(xd) = s.xdot else { return };
        // ω̇_body = Σ q̈_k over the rotating joints of its path, q̈ = W⁻¹ u̇ (W is constant).
        self.speeds.qdot(&self.parents, &xd[n..], &mut self.qdd);
        let acc: f64 = self.rotation.iter().map(|&k| self.qdd[k]).sum();
        self.accel.push(acc);
        let rel = (0..n).filter(|&k| k != self.spin).map(|k| q[k].abs()).fold(0.0, f64::max);
        self.rel.push(rel);
        self.spin_rate.push(xd[self.spin]);
        self.max_relative_angle = self.max_relative_angle.max(rel);
        if let Some(ts) = &mut self.series {
            let angle: f64 = self.rotation.iter().map(|&k| q[k]).sum();
            let rate: f64 = self.rotation.iter().map(|&k| xd[k]).sum();
            let _ = u;
            let row = [s.t, angle, rate, acc];
            for (c, v) in ts.columns.iter_mut().zip(row.iter().chain(q.iter())) {
                c.push(*v);
            }
        }
    }

    /// Drops all but the last `keep` samples of the acceleration and angle records.
    pub(crate) fn keep_last(&mut self, keep: usize) {
        for v in [&mut self.accel, &mut self.rel, &mut self.spin_rate] {
            if v.len() > keep {
                v.drain(..v.len() - keep);
            }
        }
    }

    /// Largest |q| of the non-spin joints over the last `samples` samples, rad.
    pub(crate) fn max_relative_angle_recent(&self, samples: usize) -> f64 {
        self.rel[self.rel.len().saturating_sub(samples)..].iter().copied().fold(0.0, f64::max)
    }

    pub(crate) fn into_time_series(self) -> Option<TimeSeries> {
        self.series
    }
}

/// Integrates from `(t0, x0)` to `t1`, streaming samples into `rec`. Never fails: an integration
/// error is returned in [`SimInfo::error`] with the time reached, and the samples up to there stay
/// in the recorder.
pub(crate) fn simulate(
    kane: &mut Kane,
    x0: &[f64],
    t0: f64,
    t1: f64,
    spec: &IntegrationSpec,
    rec: &mut Recorder,
    bar: &ProgressBar,
) -> SimInfo {
    let opts = IntegrateOptions {
        rtol: spec.rtol,
        atol: spec.atol,
        sample_rate_hz: Some(spec.sample_hz),
        sample_derivatives: true,
        max_steps: spec.max_steps,
        ..IntegrateOptions::default()
    };
    let fs = spec.sample_hz;
    let start = std::time::Instant::now();
    let tick = (spec.sample_hz as usize / 10).max(1);
    let result = integrate(
        |t, x, xd| kane.rhs(t, x, xd),
        x0,
        t0,
        t1,
        &opts,
        |s: &Sample<'_>| {
            rec.record(s, fs);
            if s.k.is_multiple_of(tick) {
                bar.set_position((s.t * 1000.0) as u64);
            }
        },
    );
    let wall_s = start.elapsed().as_secs_f64();
    match result {
        Ok(done) => SimInfo {
            accepted: done.stats.accepted,
            rejected: done.stats.rejected,
            rhs_evals: done.stats.rhs_evals + done.stats.sample_rhs_evals,
            wall_s,
            error: None,
            t_end: done.t_end,
            x_end: done.x_end,
            time_series: None,
        },
        Err(e) => {
            let st = e.stats();
            SimInfo {
                accepted: st.accepted,
                rejected: st.rejected,
                rhs_evals: st.rhs_evals + st.sample_rhs_evals,
                wall_s,
                error: Some(e.to_string()),
                t_end: e.t_reached(),
                x_end: x0.to_vec(),
                time_series: None,
            }
        }
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
