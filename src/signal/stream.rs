//! Streamed order tracking: the STFT of [`super::stft_order_traces`] fed one sample at a time,
//! so a long run keeps one analysis window per signal instead of the whole record.
//!
//! Method: the same windows (N samples, starts `k·hop`), the same mean removal, periodic Hann
//! window, real FFT and band summation as the batch function (both go through one
//! `HannSpectrum`), so every amplitude is the batch's to the last bit. Each channel holds the
//! samples from the next window's start on; when N have arrived the window is transformed and the
//! first `hop` samples are dropped (with a hop longer than N the samples between windows are never
//! kept). Several channels sampled at the same instants (a response and the elements of one run)
//! share the clock, the order function and one FFT plan with its buffers: memory is N samples per
//! channel plus one plan, whatever the run's length.
//!
//! Errors are those of the batch function on the same samples, reported in the same order of
//! checks when the stream is finished ([`StftStream::finish`]): a parameter error, then the first
//! non-finite sample of the channel, then a record shorter than one window, then the first
//! window whose order or band fails (no later window is transformed after that).

use super::{
    HannSpectrum, MAX_POINTS, OrderTrace, SignalError, StftOptions, TracePoint, check_common, order_checked, positive,
};
use std::f64::consts::PI;

/// The window length in samples of [`super::stft_order_traces`], or the error it gives for these
/// parameters before it looks at the samples (`nonfinite`: the first non-finite sample, which the
/// batch checks between the parameters and the window length).
fn window_samples(
    fs_hz: f64,
    omega_rad_s: f64,
    multiples: &[f64],
    opts: &StftOptions,
    nonfinite: Option<(usize, f64)>,
) -> Result<usize, SignalError> {
    let fs = positive("fs_hz", fs_hz)?;
    positive("omega_rad_s", omega_rad_s)?;
    let window_s = positive("window_s", opts.window_s)?;
    positive("hop_s", opts.hop_s)?;
    check_common(&[], multiples, opts.half_width_bins)?;
    if let Some((index, value)) = nonfinite {
        return Err(SignalError::NonFinite { what: "signal", index, value });
    }
    // NOTE: compared in f64 before the conversion (see [`MAX_POINTS`]).
    let n_f = (window_s * fs).round();
    if n_f > MAX_POINTS as f64 {
        return Err(SignalError::InvalidParameter {
            name: "window_s",
            value: window_s,
            reason: "times fs_hz exceeds the cap of 2^26 samples per window (MAX_POINTS)",
        });
    }
    let n = n_f as usize;
    if n < 4 * opts.half_width_bins + 8 {
        return Err(SignalError::InvalidParameter {
            name: "window_s",
            value: window_s,
            reason: "is too short for the band: it must span at least 4·half_width_bins + 8 samples",
        });
    }
    Ok(n)
}

/// One signal of an [`StftStream`].
struct Channel {
    /// Samples from the next window's start on (at most N).
    held: Vec<f64>,
    /// The first non-finite sample, `(index, value)`.
    nonfinite: Option<(usize, f64)>,
    /// One trace per multiple.
    traces: Vec<OrderTrace>,
}

/// [`super::stft_order_traces`] of several signals sampled together, fed sample by sample (see the
/// [module docs](self)): `push` one value per channel at each sample, then `finish` for each
/// channel's traces, equal to the batch function's on the same samples.
pub struct StftStream<'a> {
    fs: f64,
    omega: f64,
    order_at: &'a dyn Fn(f64) -> f64,
    multiples: Vec<f64>,
    opts: StftOptions,
    /// The spectrum of N-sample windows; `None` when the parameters are refused.
    spectrum: Option<HannSpectrum>,
    hop: usize,
    /// Samples pushed so far.
    count: usize,
    /// Index of the next window's first sample.
    next_start: usize,
    channels: Vec<Channel>,
    /// The first window that failed; no window is transformed after it.
    window_error: Option<SignalError>,
}

impl<'a> StftStream<'a> {
    /// A stream of `channels` signals sampled at `fs_hz` with the arguments of
    /// [`super::stft_order_traces`]. Never fails: refused parameters are reported by
    /// [`StftStream::finish`], as the batch function reports them.
    pub fn new(
        channels: usize,
        fs_hz: f64,
        omega_rad_s: f64,
        order_at: &'a dyn Fn(f64) -> f64,
        multiples: &[f64],
        opts: &StftOptions,
    ) -> Self {
        let n = window_samples(fs_hz, omega_rad_s, multiples, opts, None).ok();
        // The batch clamps the hop to the record's length: any hop beyond `len − N` gives the one
        // window at 0, which this unclamped hop gives too. `as usize` saturates.
        let hop = (opts.hop_s * fs_hz).round().max(1.0) as usize;
        Self {
            fs: fs_hz,
            omega: omega_rad_s,
            order_at,
            multiples: multiples.to_vec(),
            opts: *opts,
            spectrum: n.map(HannSpectrum::new),
            hop,
            count: 0,
            next_start: 0,
            channels: (0..channels)
                .map(|_| Channel {
                    held: Vec::with_capacity(n.unwrap_or(0)),
                    nonfinite: None,
                    traces: multiples.iter().map(|&m| OrderTrace::new(m, 0)).collect(),
                })
                .collect(),
            window_error: None,
        }
    }

    /// Samples pushed so far.
    pub fn len(&self) -> usize {
        self.count
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The window length N in samples (0 when the parameters are refused).
    pub fn window_len(&self) -> usize {
        self.spectrum.as_ref().map_or(0, |s| s.n)
    }

    /// Adds one sample of every channel (`values[c]` for channel c; missing values count as NaN).
    pub fn push(&mut self, values: &[f64]) {
        let i = self.count;
        self.count += 1;
        let Some(spec) = self.spectrum.as_mut() else { return };
        let keep = i >= self.next_start && self.window_error.is_none();
        for (c, ch) in self.channels.iter_mut().enumerate() {
            let v = values.get(c).copied().unwrap_or(f64::NAN);
            if !v.is_finite() && ch.nonfinite.is_none() {
                ch.nonfinite = Some((i, v));
            }
            if keep {
                ch.held.push(v);
            }
        }
        if !keep || self.channels.first().is_none_or(|ch| ch.held.len() < spec.n) {
            return;
        }
        // A full window: the batch's arithmetic, channel by channel.
        let n = spec.n;
        let time_s = (self.next_start as f64 + 0.5 * n as f64) / self.fs;
        let bin_hz = self.fs / n as f64;
        let half = self.opts.half_width_bins;
        match order_checked(self.order_at, time_s) {
            Err(e) => self.window_error = Some(e),
            Ok(order) => {
                'channels: for ch in &mut self.channels {
                    spec.transform(&ch.held);
                    for trace in &mut ch.traces {
                        let freq_hz = trace.multiple * order * self.omega / (2.0 * PI);
                        match spec.band(freq_hz / bin_hz, half) {
                            Ok(centre) => {
                                let amplitude = spec.band_amplitude(centre, half);
                                trace.push(TracePoint { time_s, order, freq_hz, amplitude });
                            }
                            Err((lo, hi)) => {
                                self.window_error = Some(SignalError::OutOfBand {
                                    multiple: trace.multiple,
                                    time_s,
                                    value: freq_hz,
                                    unit: "Hz",
                                    lo,
                                    hi,
                                    last: spec.last_bin(),
                                    resolution: bin_hz,
                                });
                                break 'channels;
                            }
                        }
                    }
                }
            }
        }
        self.next_start = self.next_start.saturating_add(self.hop);
        for ch in &mut self.channels {
            ch.held.drain(..self.hop.min(n));
        }
    }

    /// Each channel's traces, or the error [`super::stft_order_traces`] gives on its samples.
    pub fn finish(self) -> Vec<Result<Vec<OrderTrace>, SignalError>> {
        let (count, window_error) = (self.count, self.window_error);
        let (fs, omega, multiples, opts) = (self.fs, self.omega, self.multiples, self.opts);
        self.channels
            .into_iter()
            .map(|ch| {
                let n = window_samples(fs, omega, &multiples, &opts, ch.nonfinite)?;
                if count < n {
                    return Err(SignalError::TooShort { what: "signal", got: count, needed: n });
                }
                match &window_error {
                    Some(e) => Err(e.clone()),
                    None => Ok(ch.traces),
                }
            })
            .collect()
    }
}

/// The largest `|y − mean|` of a sampled signal refined between its samples, fed sample by
/// sample: [`super::findings::refined_peak`] of the whole record, to the last bit. The refinement
/// reads the two samples each side of the largest one (and their slopes), so the stream keeps the
/// last two samples and, from each new largest sample on, the five around it.
#[derive(Debug, Clone)]
pub struct PeakStream {
    mean: f64,
    dt: f64,
    count: usize,
    /// The last two samples `(y, dy)`, the older first.
    recent: [(f64, f64); 2],
    /// Index and `|y − mean|` of the largest sample so far (the first of equals).
    best: Option<(usize, f64)>,
    /// Samples from `best − 2` (or 0) on, at most five.
    around: Vec<(f64, f64)>,
    /// Where `best` sits in `around`.
    at: usize,
    slopes: bool,
}

impl PeakStream {
    /// A stream of samples `dt` s apart, about `mean`; `slopes`: each sample comes with its time
    /// derivative (Hermite refinement), else Catmull–Rom from the neighbours.
    pub fn new(dt: f64, mean: f64, slopes: bool) -> Self {
        Self { mean, dt, count: 0, recent: [(0.0, 0.0); 2], best: None, around: Vec::with_capacity(5), at: 0, slopes }
    }

    /// Adds one sample `y` with its slope `dy` (ignored without slopes).
    pub fn push(&mut self, y: f64, dy: f64) {
        let i = self.count;
        let v = (y - self.mean).abs();
        // The fold of `refined_peak`: a sample replaces the best unless the best is ≥ it.
        if self.best.is_none_or(|(_, m)| !(m >= v)) {
            self.best = Some((i, v));
            self.around.clear();
            let before = i.min(2);
            self.around.extend_from_slice(&self.recent[2 - before..]);
            self.around.push((y, dy));
            self.at = before;
        } else if self.around.len() < self.at + 3 {
            self.around.push((y, dy));
        }
        self.recent = [self.recent[1], (y, dy)];
        self.count += 1;
    }

    /// The refined peak (NaN before any sample).
    pub fn finish(&self) -> f64 {
        let Some((_, best)) = self.best else { return f64::NAN };
        let y: Vec<f64> = self.around.iter().map(|p| p.0).collect();
        let dy: Vec<f64> = self.around.iter().map(|p| p.1).collect();
        super::findings::refine_peak_at(&y, self.slopes.then_some(&dy[..]), self.dt, self.mean, self.at, best)
    }
}
