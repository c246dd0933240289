//! Streamed order tracking: the STFT of [`super::stft_order_traces`] fed one sample at a time,
//! so a long run keeps one analysis window per signal instead of the whole record.
//!
//! Method: the same windows (N samples, starts `k·hop`), the same mean removal, periodic Hann
//! window, real FFT and band summation as the batch function (both go through one
//! `HannSpectrum`), so every amplitude is the batch's to the last bit. Each channel holds the
//! samples from the next window's start on; when N have arrived the window is transformed and the
//! next one starts `hop` samples later; the samples before it are dropped once N of them have
//! gathered (with a hop longer than N the samples between windows are never kept). Several
//! channels sampled at the same instants (a response and the elements of one run) share the
//! clock, the order function and one FFT plan with its buffers: memory is under 2N samples per
//! channel plus one plan, whatever the run's length.
//!
//! Errors are those of the batch function on the same samples, reported in the same order of
//! checks when the stream is finished ([`StftStream::finish`]): a parameter error, then the first
//! non-finite sample of the channel, then a record shorter than one window, then the first
//! window whose order or band fails (no later window is transformed after that).

use super::{HannSpectrum, MAX_POINTS, OrderTrace, SignalError, StftOptions, check_common, order_checked, positive};

/// The window length in samples of [`super::stft_order_traces`] and of the stream, or the error
/// for these parameters and `nonfinite` (the first non-finite sample, checked between the
/// parameters and the window length), in that order.
pub(super) fn window_samples(
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
    /// Samples from `offset` samples before the next window's start on (fewer than 2N).
    held: Vec<f64>,
    /// The first non-finite sample, `(index, value)`.
    nonfinite: Option<(usize, f64)>,
    /// One trace per multiple.
    traces: Vec<OrderTrace>,
}

/// [`super::stft_order_traces`] of several signals sampled together, fed sample by sample:
/// [`StftStream::push`] one value per channel at each sample, then [`StftStream::finish`] for each
/// channel's traces, equal to the batch function's on the same samples to the last bit.
///
/// The same windows (N samples, starts `k·hop`), mean removal, periodic Hann window, real FFT and
/// band summation as the batch function (one shared implementation). Each channel holds the
/// samples from the next window's start on; when N have arrived the window is transformed and the
/// next one starts `hop` samples later. The channels share the clock, the order function and one
/// FFT plan with its buffers: memory is under 2N samples per channel plus one plan, whatever the
/// run's length. Errors are the batch function's on the same samples, in its order of checks (see
/// [`StftStream::finish`]).
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
    /// Where the next window starts in every channel's `held`: the samples before it are dropped
    /// once it reaches N, so each sample is moved less than once on average (dropping them
    /// after every window moved each one N/hop times, 3 % of a sweep's instructions).
    offset: usize,
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
            offset: 0,
            channels: (0..channels)
                .map(|_| Channel {
                    held: Vec::with_capacity(2 * n.unwrap_or(0)),
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
    #[inline]
    pub fn push(&mut self, values: &[f64]) {
        let i = self.count;
        self.count += 1;
        let keep = i >= self.next_start && self.window_error.is_none() && self.spectrum.is_some();
        let mut values = values.iter();
        for ch in &mut self.channels {
            let v = values.next().copied().unwrap_or(f64::NAN);
            if !v.is_finite() && ch.nonfinite.is_none() {
                ch.nonfinite = Some((i, v));
            }
            if keep {
                ch.held.push(v);
            }
        }
        if keep && self.channels.first().is_some_and(|ch| ch.held.len() == self.offset + self.window_len()) {
            self.window();
        }
    }

    /// Transforms the window that has just filled up in every channel and moves to the next.
    fn window(&mut self) {
        let Some(spec) = self.spectrum.as_mut() else { return };
        // A full window: the batch's arithmetic, channel by channel.
        let n = spec.n;
        let time_s = (self.next_start as f64 + 0.5 * n as f64) / self.fs;
        let bin_hz = self.fs / n as f64;
        let half = self.opts.half_width_bins;
        let window = self.offset..self.offset + n;
        match order_checked(self.order_at, time_s) {
            Err(e) => self.window_error = Some(e),
            Ok(order) => {
                'channels: for ch in &mut self.channels {
                    spec.transform(&ch.held[window.clone()]);
                    for trace in &mut ch.traces {
                        match spec.trace_point((trace.multiple, order, self.omega), time_s, bin_hz, half) {
                            Ok(point) => trace.push(point),
                            Err(e) => {
                                self.window_error = Some(e);
                                break 'channels;
                            }
                        }
                    }
                }
            }
        }
        self.next_start = self.next_start.saturating_add(self.hop);
        self.offset = self.offset.saturating_add(self.hop);
        if self.offset >= n {
            for ch in &mut self.channels {
                ch.held.drain(..self.offset.min(ch.held.len()));
            }
            self.offset = 0;
        }
    }

    /// Each channel's traces, or the error [`super::stft_order_traces`] gives on its samples: a
    /// parameter error, then the channel's first non-finite sample, then a record shorter than
    /// one window, then the first window whose order or band failed (no later window was
    /// transformed).
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
    #[inline]
    pub fn push(&mut self, y: f64, dy: f64) {
        let i = self.count;
        let v = (y - self.mean).abs();
        // The fold of `refined_peak`: a sample replaces the best unless the best is ≥ it (so a
        // NaN replaces, and is replaced, as there).
        let keeps = |m: f64| matches!(m.partial_cmp(&v), Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal));
        if self.best.is_none_or(|(_, m)| !keeps(m)) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::findings::refined_peak;
    use crate::signal::stft_order_traces;
    use std::f64::consts::PI;

    /// A deterministic broadband test signal: a swept line, its double and a pseudo-random
    /// part (an LCG), so that every bin of every window carries something.
    fn signal(len: usize, fs: f64, seed: u64) -> Vec<f64> {
        let mut state = seed;
        (0..len)
            .map(|i| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let noise = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                let t = i as f64 / fs;
                3.0 * (2.0 * PI * (40.0 * t + 0.5 * t * t)).sin() + 0.7 * (2.0 * PI * (80.0 * t + t * t)).cos() + noise
            })
            .collect()
    }

    /// Streamed and batch traces are the same numbers, not close ones: both transform the same
    /// samples with the same arithmetic (one `HannSpectrum`), so any difference at all would be a
    /// window taken at the wrong samples. Covered: hops shorter than, equal to and longer than
    /// the window, records ending inside a window, several channels.
    #[test]
    fn streamed_traces_are_the_batch_traces() {
        let fs = 400.0;
        let omega = 2.0 * PI * 10.0;
        let order_at = |t: f64| 4.0 + 0.1 * t;
        for (window_s, hop_s, len) in
            [(2.0, 0.25, 4000), (1.0, 1.0, 2999), (0.5, 0.8, 3001), (2.0, 0.0001, 900), (2.0, 50.0, 2000)]
        {
            let opts = StftOptions { window_s, hop_s, half_width_bins: 2 };
            let channels: Vec<Vec<f64>> = (0..3).map(|c| signal(len, fs, 7 + c)).collect();
            let mut stream = StftStream::new(3, fs, omega, &order_at, &[1.0, 2.0], &opts);
            for i in 0..len {
                let row: Vec<f64> = channels.iter().map(|c| c[i]).collect();
                stream.push(&row);
            }
            assert_eq!(stream.len(), len);
            for (c, got) in stream.finish().into_iter().enumerate() {
                let want = stft_order_traces(&channels[c], fs, omega, &order_at, &[1.0, 2.0], &opts);
                assert!(want.as_ref().is_ok_and(|t| !t[0].is_empty()), "{window_s} {hop_s}: {want:?}");
                assert_eq!(got, want, "window {window_s} s, hop {hop_s} s, {len} samples, channel {c}");
            }
        }
    }

    /// A sinusoid on a bin reads its amplitude (the Parseval calibration of the module docs, an
    /// independent closed form): 1e-12 is rounding over a 2000-point FFT.
    #[test]
    fn a_sinusoid_on_a_bin_reads_its_amplitude() {
        let (fs, omega, n) = (1000.0, 2.0 * PI * 5.0, 3.0);
        // 15 Hz on 2 s windows: bin 30.
        let opts = StftOptions::default();
        let order_at = |_: f64| n;
        let mut stream = StftStream::new(1, fs, omega, &order_at, &[1.0], &opts);
        for i in 0..6000 {
            stream.push(&[2.5 + 1.75 * (2.0 * PI * 15.0 * i as f64 / fs + 0.3).sin()]);
        }
        let traces = stream.finish().remove(0).unwrap();
        assert_eq!(traces[0].len(), (6000 - 2000) / 250 + 1);
        for a in &traces[0].amplitude {
            assert!((a - 1.75).abs() < 1e-12, "{a}");
        }
    }

    /// Each channel fails as the batch function fails on its own samples, in the batch's order of
    /// checks: a non-finite sample (only in its channel), a record shorter than a window, a
    /// refused parameter, a band off the spectrum.
    #[test]
    fn errors_are_the_batch_errors() {
        let fs = 200.0;
        let omega = 2.0 * PI;
        let run = |values: &[Vec<f64>], order: f64, opts: &StftOptions, multiples: &[f64]| {
            let order_at = move |_: f64| order;
            let mut stream = StftStream::new(values.len(), fs, omega, &order_at, multiples, opts);
            for i in 0..values[0].len() {
                let row: Vec<f64> = values.iter().map(|c| c[i]).collect();
                stream.push(&row);
            }
            let batch: Vec<_> =
                values.iter().map(|v| stft_order_traces(v, fs, omega, &order_at, multiples, opts)).collect();
            (stream.finish(), batch)
        };
        let opts = StftOptions::default();
        // 400-sample windows every 50: the last of 1020 samples ends at sample 999.
        let good = signal(1020, fs, 1);
        let mut bad = good.clone();
        bad[1010] = f64::NAN; // after the last window: the batch refuses it all the same
        let (got, want) = run(&[good.clone(), bad], 10.0, &opts, &[1.0]);
        assert!(got[0].is_ok() && matches!(got[1], Err(SignalError::NonFinite { index: 1010, .. })));
        // NaN is not equal to itself: the errors are compared as printed.
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
        for (values, order, opts, multiples) in [
            (vec![good[..300].to_vec()], 10.0, opts, vec![1.0]),
            (vec![good.clone()], 10.0, StftOptions { hop_s: -1.0, ..opts }, vec![1.0]),
            (vec![good.clone()], 10.0, StftOptions { window_s: 0.01, ..opts }, vec![1.0]),
            (vec![good.clone()], 10.0, opts, vec![]),
            (vec![good.clone()], 99.0, opts, vec![1.0]),
            (vec![good.clone()], f64::NAN, opts, vec![1.0]),
        ] {
            let (got, want) = run(&values, order, &opts, &multiples);
            assert!(want[0].is_err(), "{opts:?} {order}");
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "{opts:?} {order} {multiples:?}");
        }
    }

    /// The streamed peak is `refined_peak` of the whole record, bit for bit, wherever the largest
    /// sample falls (first, second, middle, last but one, last; ties; records of 1 to 5 samples),
    /// with slopes and without.
    #[test]
    fn streamed_peak_is_the_refined_peak() {
        let base = signal(64, 100.0, 3);
        let slopes = signal(64, 100.0, 4);
        let mut cases: Vec<Vec<f64>> = (1..=6).map(|n| base[..n].to_vec()).collect();
        for at in [0, 1, 2, 31, 61, 62, 63] {
            let mut y = base.clone();
            y[at] = 9.0;
            cases.push(y.clone());
            // A tie later on: the first of equals is the peak.
            y[(at + 5) % 64] = 9.0;
            cases.push(y.clone());
            // A NaN takes the place of the best in `refined_peak`'s fold, and loses it again.
            y[(at + 9) % 64] = f64::NAN;
            cases.push(y);
        }
        for y in &cases {
            let dy = &slopes[..y.len()];
            for (with_slopes, mean) in [(true, 0.0), (false, 0.0), (true, 0.4), (false, -0.3)] {
                let mut p = PeakStream::new(0.01, mean, with_slopes);
                for (v, d) in y.iter().zip(dy) {
                    p.push(*v, *d);
                }
                let want = refined_peak(y, with_slopes.then_some(dy), 0.01, mean);
                assert_eq!(p.finish().to_bits(), want.to_bits(), "{} samples, slopes {with_slopes}", y.len());
            }
        }
        assert!(PeakStream::new(0.01, 0.0, true).finish().is_nan());
    }
}
