//! Per-element results: for each reported joint (`Study::elements`), its coordinate's amplitude
//! at each tracked order and the peak of its oscillation, and the torque its spring and damper
//! transmit, `T = k (q − q_free) + c q̇` (N·m; N for a slide), per order and at its peak. From a
//! harmonic-balance solution they are read off the Fourier series (peaks are the series' true
//! maxima, [`HbmSolution::peak_amplitude`]); from a time run, by the study's order tracking over
//! the last window, with the peak of the oscillating part over that window, refined between the
//! samples ([`crate::signal::findings::refined_peak`]).

use super::spec::TrackingSpec;
use super::table::{Table, fmt_num};
use super::track::track;
use crate::error::Result;
use crate::hbm::HbmSolution;
use crate::model::mechanism::Mechanism;
use crate::plot::num;
use crate::signal::OrderTrace;
use crate::signal::PeakStream;
use crate::signal::findings::refined_peak;
use serde::Serialize;
use std::fmt::Write as _;

/// The torque an element's spring and damper transmit.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ElementTorque {
    /// Amplitude per tracked multiple of the order, N·m (N for a slide).
    pub amplitude: Vec<f64>,
    /// Peak of the oscillating part, N·m (N for a slide).
    pub peak: f64,
    /// The torque's mean, lowest, highest and largest absolute value, the spring's preload
    /// `k (q − q_free)` included (what loads the element), N·m (N for a slide).
    #[serde(flatten)]
    pub range: Range,
}

/// The honest extremes of a steady quantity (issue 29, item 3): its mean, lowest and highest
/// value, the largest absolute value `max(|min|, |max|)`, mean included (a wound-up spring's
/// clearance to its stop is the largest |q|, not the oscillation about its mean), and the
/// largest departure from the mean `max(max − mean, mean − min)` (a shaft's alternating torque,
/// what fatigue sees, which a large mean torque hides in `max_abs`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Range {
    /// Mean over the steady state.
    pub mean: f64,
    /// Lowest value.
    pub min: f64,
    /// Highest value.
    pub max: f64,
    /// `max(|min|, |max|)`.
    pub max_abs: f64,
    /// `max(max − mean, mean − min)`: the largest |value − mean|, the alternating part's peak.
    pub alt_max: f64,
}

impl Range {
    /// From the mean and the oscillating part's signed extremes `(lo, hi)` about it.
    pub fn about(mean: f64, (lo, hi): (f64, f64)) -> Self {
        let (min, max) = (mean + lo, mean + hi);
        Range { mean, min, max, max_abs: min.abs().max(max.abs()), alt_max: hi.max(-lo) }
    }

    /// Of samples over a window, the extremes refined between the samples as
    /// [`refined_peak`] does (`slope`: the samples' time derivative, if known; `dt` their step).
    fn of_samples(y: &[f64], slope: Option<&[f64]>, dt: f64) -> Self {
        let mean = y.iter().sum::<f64>() / y.len().max(1) as f64;
        let (lo, hi) = y.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
        // `refined_peak` refines the largest |y − m|: with m below every sample that is the
        // highest point, with m above every sample the lowest.
        let span = (hi - lo).max(1e-300) + hi.abs().max(lo.abs());
        let top = lo - span + refined_peak(y, slope, dt, lo - span);
        let bottom = hi + span - refined_peak(y, slope, dt, hi + span);
        Range::about(mean, (bottom.min(lo) - mean, top.max(hi) - mean))
    }

    /// Shifted by a constant (a preload).
    fn shifted(self, by: f64) -> Self {
        let (min, max) = (self.min + by, self.max + by);
        Range { mean: self.mean + by, min, max, max_abs: min.abs().max(max.abs()), alt_max: self.alt_max }
    }
}

/// What one element does in a steady state.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ElementResponse {
    /// The joint's name.
    pub joint: String,
    /// Unit of the coordinate: `rad`, or `m` for a slide.
    pub unit: &'static str,
    /// Amplitude of the coordinate per tracked multiple of the order.
    pub amplitude: Vec<f64>,
    /// Peak of the coordinate's oscillation about its mean, in `unit`.
    pub peak: f64,
    /// The coordinate's mean, lowest, highest and largest absolute value (rad; m for a slide):
    /// its wind-up included.
    #[serde(flatten)]
    pub range: Range,
    /// The transmitted torque, when the joint has a spring or a damper.
    pub torque: Option<ElementTorque>,
}

/// The spring stiffness and damping of joint `j` (0 when absent).
fn stiffness_damping(mech: &Mechanism, j: usize) -> (f64, f64) {
    let joint = &mech.joints[j];
    (joint.spring.map_or(0.0, |s| s.stiffness), joint.damper)
}

/// The torque an element transmits at (q, q̇), N·m (N for a slide): its linear spring and
/// damper, `k q + c q̇`, and its nonlinear couplings (stages, friction, stops), whose
/// generalized force on the child is the reverse of what they transmit.
struct TorqueLaw<'m> {
    stiff: f64,
    damp: f64,
    couplings: &'m crate::model::coupling::Couplings,
}

impl TorqueLaw<'_> {
    /// The torque at (q, q̇).
    fn at(&self, q: f64, qd: f64) -> f64 {
        self.stiff * q + self.damp * qd - self.couplings.torque(q, qd)
    }
}

/// Joint `j`'s [`TorqueLaw`]; None when the joint has no spring, damper or coupling.
fn element_torque(mech: &Mechanism, j: usize) -> Option<TorqueLaw<'_>> {
    let (stiff, damp) = stiffness_damping(mech, j);
    let couplings = &mech.joints[j].couplings;
    (stiff != 0.0 || damp != 0.0 || !couplings.is_empty()).then_some(TorqueLaw { stiff, damp, couplings })
}

/// Per-element results of a harmonic-balance solution at the orders `multiples`·n.
pub(crate) fn from_hbm(
    mech: &Mechanism,
    elements: &[usize],
    sol: &HbmSolution,
    multiples: &[f64],
) -> Vec<ElementResponse> {
    elements
        .iter()
        .filter_map(|&j| {
            // A rigidly driven joint moves as factor · its followed coordinate (plus a constant
            // offset, which no amplitude or peak about the mean sees).
            let f = mech.follow_map()[j]?;
            let (k, a) = (f.coordinate, f.factor);
            let (stiff, damp) = stiffness_damping(mech, j);
            let amplitude = multiples
                .iter()
                .map(|&m| {
                    sol.harmonic_of(m).filter(|&h| h <= sol.harmonics).map_or(0.0, |h| a.abs() * sol.amplitude(k, h))
                })
                .collect();
            let couplings = &mech.joints[j].couplings;
            let free = mech.joints[j].spring.map_or(0.0, |sp| sp.free_angle);
            // The joint's coordinate is a·p_k + offset: its extremes swap with the sign of a.
            let signed = |(lo, hi): (f64, f64)| if a >= 0.0 { (a * lo, a * hi) } else { (a * hi, a * lo) };
            let coefficients = &sol.coefficients[k * (2 * sol.harmonics + 1)..];
            let range = Range::about(a * coefficients[0] + f.offset, signed(sol.oscillation_range(k)));
            // The series is k·a·p (mean k·a·a₀): the preload k (offset − free) completes the mean.
            let torque_range =
                |series: &[f64]| Range::about(series[0] + stiff * (f.offset - free), sol.series_range(series));
            let torque = if !couplings.is_empty() {
                // The couplings have no closed form in the coefficients: sampled along the motion
                // (a driven joint's own coordinate is factor · q + offset).
                let mut series = sol.element_torque_series(k, a * stiff, a * damp);
                let nonlinear = sol.force_series(k, &|q, qd| -couplings.torque(a * q + f.offset, a * qd));
                series.iter_mut().zip(&nonlinear).for_each(|(s, b)| *s += b);
                let (amplitude, peak) = sol.series_torques(&series, multiples);
                Some(ElementTorque { amplitude, peak, range: torque_range(&series) })
            } else {
                (stiff != 0.0 || damp != 0.0).then(|| {
                    let (amplitude, peak) = sol.element_torques(k, a * stiff, a * damp, multiples);
                    let series = sol.element_torque_series(k, a * stiff, a * damp);
                    ElementTorque { amplitude, peak, range: torque_range(&series) }
                })
            };
            Some(ElementResponse {
                joint: mech.joints[j].name.clone(),
                unit: mech.joints[j].kind.coordinate_unit(),
                amplitude,
                peak: a.abs() * sol.peak_amplitude(k),
                range,
                torque,
            })
        })
        .collect()
}

/// Per-element results over the last window of `window` samples of a steady run at mean speed
/// `omega` (rad/s) and order `order`: amplitudes by the study's order tracking with the window
/// as the block (as the steady-state test measures the response), peaks of the oscillating
/// parts over that window.
#[allow(clippy::too_many_arguments)]
pub(crate) fn from_window(
    mech: &Mechanism,
    elements: &[usize],
    cols: &ElementColumns<'_>,
    window: usize,
    fs: f64,
    (omega, order): (f64, f64),
    multiples: &[f64],
    tracking: &TrackingSpec,
) -> Result<Vec<ElementResponse>> {
    let mut out = Vec::with_capacity(elements.len());
    for (&j, &(q, qd)) in elements.iter().zip(&cols.signals) {
        // The last two windows, as in the steady-state test; the amplitude of the later one.
        let span = q.len().min(2 * window);
        let (q2, qd2) = (&q[q.len() - span..], &qd[qd.len() - span..]);
        let amplitudes = |signal: &[f64]| -> Result<Vec<f64>> {
            let traces = track(&mech.name, signal, fs, omega, &move |_| order, multiples, tracking)?;
            Ok(traces.iter().map(|t| *t.amplitude.last().unwrap_or(&f64::NAN)).collect())
        };
        // The peak of the oscillating part over the last window, between the samples too
        // (`refined_peak`: Hermite with q̇ for the coordinate, Catmull–Rom for the torque).
        let peak = |signal: &[f64], slope: Option<&[f64]>| {
            let from = signal.len().saturating_sub(window);
            let last = &signal[from..];
            let mean = last.iter().sum::<f64>() / last.len().max(1) as f64;
            refined_peak(last, slope.map(|d| &d[from..]), 1.0 / fs, mean)
        };
        let last = |signal: &[f64]| signal.len().saturating_sub(window);
        let preload = mech.joints[j].spring.map_or(0.0, |sp| -sp.stiffness * sp.free_angle);
        let torque = if let Some(f) = element_torque(mech, j) {
            let t: Vec<f64> = q2.iter().zip(qd2).map(|(&q, &qd)| f.at(q, qd)).collect();
            let range = Range::of_samples(&t[last(&t)..], None, 1.0 / fs).shifted(preload);
            Some(ElementTorque { amplitude: amplitudes(&t)?, peak: peak(&t, None), range })
        } else {
            None
        };
        let from = last(q2);
        out.push(ElementResponse {
            joint: mech.joints[j].name.clone(),
            unit: mech.joints[j].kind.coordinate_unit(),
            amplitude: amplitudes(q2)?,
            peak: peak(q2, Some(qd2)),
            range: Range::of_samples(&q2[from..], Some(&qd2[from..]), 1.0 / fs),
            torque,
        });
    }
    Ok(out)
}

/// The signals a time run records for the elements: per element its coordinate and its rate
/// (`sim::element_columns` reads them off the run's recorder).
pub(crate) struct ElementColumns<'a> {
    /// Per element: (q, q̇) over the run's recorded samples.
    pub signals: Vec<(&'a [f64], &'a [f64])>,
}

/// One element's order traces over a sweep.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ElementTraces {
    /// The joint's name.
    pub joint: String,
    /// Unit of the coordinate: `rad`, or `m` for a slide.
    pub unit: &'static str,
    /// The coordinate's order traces, one per tracked multiple (same windows as the response's).
    pub traces: Vec<OrderTrace>,
    /// Largest |q| after the ramp-in, in `unit`.
    pub peak: f64,
    /// The spring-and-damper torque's order traces (N·m; N for a slide), when the joint has one.
    pub torque: Option<Vec<OrderTrace>>,
    /// Largest |torque| after the ramp-in (its preload `−k·q_free` left out), N·m or N.
    pub torque_peak: f64,
}

/// Per-element order traces of a sweep run, from its recorded (q, q̇) columns; `order_at` is the
/// excitation order over time and samples before `skip` (the ramp-in) do not count for peaks.
/// The sweep computes them as it goes ([`ElementStreams`]); this whole-record route is the
/// tests' reference.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn traces(
    mech: &Mechanism,
    elements: &[usize],
    cols: &ElementColumns<'_>,
    fs: f64,
    omega: f64,
    order_at: &dyn Fn(f64) -> f64,
    multiples: &[f64],
    tracking: &TrackingSpec,
    skip: usize,
) -> Result<Vec<ElementTraces>> {
    let mut out = Vec::with_capacity(elements.len());
    for (&j, &(q, qd)) in elements.iter().zip(&cols.signals) {
        // The largest |value| after the ramp-in, between the samples too (see `refined_peak`).
        let peak = |v: &[f64], slope: Option<&[f64]>| {
            let from = skip.min(v.len());
            refined_peak(&v[from..], slope.map(|d| &d[from..]), 1.0 / fs, 0.0)
        };
        let (torque, torque_peak) = if let Some(f) = element_torque(mech, j) {
            let t: Vec<f64> = q.iter().zip(qd).map(|(&q, &qd)| f.at(q, qd)).collect();
            (Some(track(&mech.name, &t, fs, omega, order_at, multiples, tracking)?), peak(&t, None))
        } else {
            (None, 0.0)
        };
        out.push(ElementTraces {
            joint: mech.joints[j].name.clone(),
            unit: mech.joints[j].kind.coordinate_unit(),
            traces: track(&mech.name, q, fs, omega, order_at, multiples, tracking)?,
            peak: peak(q, Some(qd)),
            torque,
            torque_peak,
        });
    }
    Ok(out)
}

/// Per-element order traces of a sweep run computed as the run goes: [`traces`] of the whole
/// record to the last bit, from one sample of each element's (q, q̇) at a time. The coordinate's
/// and the torque's traces are channels of the run's [`crate::signal::StftStream`] (laid out per
/// element: q, then the torque when the joint has one); the peaks after the ramp-in are
/// [`PeakStream`]s.
pub(crate) struct ElementStreams<'m> {
    mech: &'m Mechanism,
    elements: Vec<usize>,
    laws: Vec<Option<TorqueLaw<'m>>>,
    /// Per element: the coordinate's peak (Hermite with q̇) and the torque's (Catmull–Rom).
    peaks: Vec<(PeakStream, Option<PeakStream>)>,
    /// Samples before this index (the ramp-in) do not count for the peaks.
    skip: usize,
    count: usize,
}

impl<'m> ElementStreams<'m> {
    /// Streams for `elements` of `mech` sampled at `fs`, peaks from sample `skip` on.
    pub(crate) fn new(mech: &'m Mechanism, elements: &[usize], fs: f64, skip: usize) -> Self {
        let laws: Vec<Option<TorqueLaw<'m>>> = elements.iter().map(|&j| element_torque(mech, j)).collect();
        let peaks = laws
            .iter()
            .map(|law| {
                (PeakStream::new(1.0 / fs, 0.0, true), law.as_ref().map(|_| PeakStream::new(1.0 / fs, 0.0, false)))
            })
            .collect();
        Self { mech, elements: elements.to_vec(), laws, peaks, skip, count: 0 }
    }

    /// The number of elements.
    pub(crate) fn elements_len(&self) -> usize {
        self.elements.len()
    }

    /// The STFT channels the elements take.
    pub(crate) fn channels(&self) -> usize {
        self.laws.iter().map(|l| 1 + usize::from(l.is_some())).sum()
    }

    /// One sample: `qs` holds each element's (q, q̇) in turn; writes the elements' channel values
    /// into `out` (in [`ElementStreams::channels`]' layout).
    pub(crate) fn push(&mut self, qs: &[f64], out: &mut [f64]) {
        let counts = self.count >= self.skip;
        self.count += 1;
        let mut c = 0;
        for ((law, (q_peak, t_peak)), pair) in self.laws.iter().zip(&mut self.peaks).zip(qs.chunks_exact(2)) {
            let (q, qd) = (pair[0], pair[1]);
            out[c] = q;
            c += 1;
            if counts {
                q_peak.push(q, qd);
            }
            if let (Some(law), Some(t_peak)) = (law, t_peak.as_mut()) {
                let t = law.at(q, qd);
                out[c] = t;
                c += 1;
                if counts {
                    t_peak.push(t, 0.0);
                }
            }
        }
    }

    /// The elements' traces from their channels' results (in the layout of
    /// [`ElementStreams::channels`]), each through `tracked` (the study's reading of a channel:
    /// empty traces for a record shorter than a window, an order-tracking error as the model's);
    /// errors come in [`traces`]' order: an element's torque before its coordinate.
    pub(crate) fn finish(
        self,
        results: impl IntoIterator<Item = Result<Vec<OrderTrace>>>,
    ) -> Result<Vec<ElementTraces>> {
        let mut results = results.into_iter();
        let mut next = || results.next().unwrap_or_else(|| Ok(Vec::new()));
        let mut out = Vec::with_capacity(self.elements.len());
        for ((&j, law), (q_peak, t_peak)) in self.elements.iter().zip(&self.laws).zip(&self.peaks) {
            let q = next();
            let (torque, torque_peak) = match (law, t_peak) {
                (Some(_), Some(p)) => (Some(next()?), p.finish()),
                _ => (None, 0.0),
            };
            out.push(ElementTraces {
                joint: self.mech.joints[j].name.clone(),
                unit: self.mech.joints[j].kind.coordinate_unit(),
                traces: q?,
                peak: q_peak.finish(),
                torque,
                torque_peak,
            });
        }
        Ok(out)
    }
}

/// A column of one element over the table's rows, from a read-out of one [`ElementResponse`].
pub(crate) type ElementColumn<'a> = dyn Fn(&dyn Fn(&ElementResponse) -> f64) -> Vec<f64> + 'a;

/// Appends one element's columns to `table`: per multiple `<prefix><joint>_<m>x_<unit>`, then
/// `<prefix><joint>_peak_<unit>`, the [`Range`]'s `_mean_`, `_min_`, `_max_`, `_max_abs_` and
/// `_alt_max_`, and with `torque` the same for `<prefix><joint>_torque_…_Nm` (`_N` for a slide);
/// `prefix` tells sources apart (`""`, `hbm_`, `hbm_locked_`). `value` reads one number of an
/// [`ElementResponse`] for every row.
pub(crate) fn push_element_columns(
    table: &mut Table,
    joint: &crate::model::joint::Joint,
    multiples: &[f64],
    torque: bool,
    prefix: &str,
    value: &ElementColumn<'_>,
) {
    let (name, unit) = (format!("{prefix}{}", joint.name), joint.kind.coordinate_unit());
    let (force, force_unit) = if joint.kind.rotates() { ("Nm", "N·m") } else { ("N", "N") };
    for (k, m) in multiples.iter().enumerate() {
        table.push(format!("{name}_{}x_{unit}", fmt_num(*m)), unit, value(&|x| x.amplitude[k]));
    }
    table.push(format!("{name}_peak_{unit}"), unit, value(&|x| x.peak));
    for (tag, read) in RANGE_COLUMNS {
        table.push(format!("{name}_{tag}_{unit}"), unit, value(&|x| read(&x.range)));
    }
    if torque {
        for (k, m) in multiples.iter().enumerate() {
            let v = value(&|x| x.torque.as_ref().map_or(f64::NAN, |t| t.amplitude[k]));
            table.push(format!("{name}_torque_{}x_{force}", fmt_num(*m)), force_unit, v);
        }
        table.push(
            format!("{name}_torque_peak_{force}"),
            force_unit,
            value(&|x| x.torque.as_ref().map_or(f64::NAN, |t| t.peak)),
        );
        for (tag, read) in RANGE_COLUMNS {
            let v = value(&|x| x.torque.as_ref().map_or(f64::NAN, |t| read(&t.range)));
            table.push(format!("{name}_torque_{tag}_{force}"), force_unit, v);
        }
    }
}

/// A read-out of one number of a [`Range`].
type RangeField = fn(&Range) -> f64;

/// The CSV columns of a [`Range`]: tag and read-out.
const RANGE_COLUMNS: [(&str, RangeField); 5] = [
    ("mean", |r| r.mean),
    ("min", |r| r.min),
    ("max", |r| r.max),
    ("max_abs", |r| r.max_abs),
    ("alt_max", |r| r.alt_max),
];

/// The summary's table of elements in steady states: one row per (speed in rpm, element), with
/// the amplitudes at `multiples`·n, the peak and the torque; empty when there is no row.
pub(crate) fn element_table<'a>(rows: impl Iterator<Item = (f64, &'a ElementResponse)>, multiples: &[f64]) -> String {
    labelled_element_table("rpm", rows.map(|(rpm, e)| (rpm.to_string(), e)), multiples)
}

/// [`element_table`] with rows labelled `label` (a speed and a state, say), its column headed
/// `first`.
pub(crate) fn labelled_element_table<'a>(
    first: &str,
    rows: impl Iterator<Item = (String, &'a ElementResponse)>,
    multiples: &[f64],
) -> String {
    let mut body = String::new();
    // The figures' number form (five significant digits, exponents only below 1e-3 or from 1e5
    // on), so that an angle reads 0.38677 here as in the other tables, not 3.8677e-1.
    let v = |x: f64| num(x, 5);
    for (label, e) in rows {
        let amps: Vec<String> = e.amplitude.iter().map(|a| v(*a)).collect();
        let torque = e.torque.as_ref().map_or("–".to_string(), |t| {
            let per: Vec<String> = t.amplitude.iter().map(|a| v(*a)).collect();
            format!(
                "{}; peak {}; max abs {}; alt max {}",
                per.join(", "),
                v(t.peak),
                v(t.range.max_abs),
                v(t.range.alt_max)
            )
        });
        let r = &e.range;
        let _ = writeln!(
            body,
            "| {label} | `{}` | {} {} | {} | {} [{}, {}] | {} | {torque} |",
            e.joint,
            amps.join(", "),
            e.unit,
            v(e.peak),
            v(r.mean),
            v(r.min),
            v(r.max),
            v(r.max_abs)
        );
    }
    if body.is_empty() {
        return body;
    }
    let tags: Vec<String> = multiples.iter().map(|m| format!("{}n", fmt_num(*m))).collect();
    format!(
        "Elements, steady state over the last window (amplitudes at {}; torques of their spring and damper, \
         N·m, N for a slide; mean [min, max] and the largest |q| include the wind-up):\n\n| {first} | joint | \
         amplitude | peak | mean [min, max] | max abs | torque |\n|---|---|---|---|---|---|---|\n{body}\n",
        tags.join(", ")
    )
}
