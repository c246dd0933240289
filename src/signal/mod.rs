//! Order tracking of a sampled response signal (the rotor angular acceleration, rad/s², in the
//! studies): the amplitude of the excitation order n and its multiples (2n, …) as the order is held
//! or swept, §4.1 of the paper ("5-frequency-bin summation").
//!
//! Two methods, both returning one [`OrderTrace`] per harmonic multiple:
//! - [`stft_order_traces`] (time domain, the study convention of docs/design/conventions.md): a short-time Fourier
//!   transform with periodic Hann windows; per window the bin nearest `m·n(t_c)·Ω/2π` and
//!   `half_width_bins` neighbours each side.
//! - [`angle_domain_order_traces`] (angle domain, a cross-check): the signal is resampled at
//!   constant increments of the simulated rotor angle θ, so FFT bins of a block are orders
//!   (cycles per revolution) directly and speed fluctuations do not smear them.
//!
//! The transforms are real-input FFTs planned by `realfft` (rustfft underneath, which picks
//! radix, mixed-radix or Bluestein's algorithm per length), one plan per block length reused
//! over the blocks.
//!
//! # Amplitude calibration
//! Both methods report the peak amplitude of the equivalent sinusoid,
//! `A = 2·sqrt(Σ_band |X_k|² / (N·Σw²))`, with N the block length in samples and `w` the
//! window. For `x_j = A sin(2π k₀ j/N + α)` on a bin, the periodic Hann window's DFT has exactly
//! three non-zero bins (N/2 and −N/4 twice), so all the energy of the positive-frequency line,
//! `(A/2)²·Σ_k|W_k|² = (A/2)²·N·Σw²` by Parseval, falls inside a band of ±1 bin and the formula
//! is exact. Between bins the Hann kernel leaks outside ±2 bins; the worst case (half a bin off)
//! loses 5·10⁻⁴ of the energy, i.e. the amplitude reads 2.6·10⁻⁴ low (unit test
//! `calibration_of_a_pure_sinusoid`). The negative-frequency image is ignored, so the band must sit
//! well away from DC and Nyquist (enforced: it must lie within bins 1..N/2−1).
//!
//! [`StftStream`] is the STFT fed sample by sample (several signals sharing one clock and one
//! FFT plan), with the batch function's amplitudes to the last bit; with [`PeakStream`] (the
//! refined peak of [`findings::refined_peak`], streamed) it lets a long run keep one analysis
//! window per signal instead of its whole record.
//!
//! [`findings`] reads the traces: minima after the ramp-in, where the up and the down sweep
//! differ, and where a sweep jumps.

mod angle;
pub mod findings;
mod order_map;
mod stft;
mod stream;

pub use angle::{AngleOptions, AngleSamples, angle_domain_order_traces, resample_at_constant_angle};
pub use order_map::{OrderMap, order_rpm_map};
pub use stft::{StftOptions, stft_order_traces};
pub use stream::{PeakStream, StftStream};

/// The most points one analysis window (STFT window, angle-domain block) or one angle-resampled
/// signal may have: 2²⁶ = 67 108 864 (a 2²⁶-point window costs ~1.5 GB of FFT buffers; a
/// resampled signal of 2²⁶ points 1 GB). Far above the studies' needs (a 2 s window at 2 kHz is
/// 4000 samples; 240 s at 1000 rpm and 64 points per revolution is 256 000 points). Larger
/// requests are refused with [`SignalError::InvalidParameter`] rather than allocated.
///
/// # Common mistake
/// Sample counts are computed in f64 (`window_s·fs_hz`, revolutions·`samples_per_rev`) and
/// compared with this cap *before* any conversion to an integer: an `as usize` of 1e19 saturates
/// and the following `+ 1` or `k + half` wraps.
pub const MAX_POINTS: usize = 1 << 26;

use realfft::num_complex::Complex;
use realfft::{RealFftPlanner, RealToComplex};
use std::f64::consts::PI;
use std::sync::Arc;

/// Errors of the order-tracking functions: bad options or data, reported with the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SignalError {
    /// An option or argument out of its valid range.
    #[error("{name} = {value}: {reason}")]
    InvalidParameter {
        /// Name of the option or argument.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        reason: &'static str,
    },
    /// No harmonic multiples were requested.
    #[error("no harmonic multiples requested (pass e.g. [1.0, 2.0])")]
    NoMultiples,
    /// The signal is shorter than one analysis window or block.
    #[error("{what} has {got} samples, fewer than one analysis window of {needed} samples")]
    TooShort {
        /// Which signal (`signal`, or `angle-resampled signal`).
        what: &'static str,
        /// Its length.
        got: usize,
        /// The window (block) length.
        needed: usize,
    },
    /// Two arrays that must be sample-aligned have different lengths.
    #[error("signal has {signal} samples but theta has {theta}; they must be sampled at the same times")]
    LengthMismatch {
        /// Length of the signal.
        signal: usize,
        /// Length of the angle array.
        theta: usize,
    },
    /// A non-finite sample.
    #[error("{what}[{index}] is not finite ({value})")]
    NonFinite {
        /// Which array.
        what: &'static str,
        /// Index of the sample.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The rotor angle does not increase strictly (the angle-domain method needs θ⁻¹).
    #[error(
        "theta must increase strictly: theta[{index}] = {before} rad, theta[{}] = {after} rad (negative rotor speed?)",
        index + 1
    )]
    NotIncreasing {
        /// Index of the sample before the fault.
        index: usize,
        /// θ at `index`, rad.
        before: f64,
        /// θ at `index + 1`, rad.
        after: f64,
    },
    /// The order function returned a non-finite or negative value.
    #[error("order_at({time_s} s) = {order}: the excitation order must be finite and non-negative")]
    BadOrder {
        /// Window centre time, s.
        time_s: f64,
        /// The returned order.
        order: f64,
    },
    /// The band around a tracked line falls off the usable spectrum (too close to DC, or beyond
    /// Nyquist).
    #[error(
        "multiple {multiple} at t = {time_s} s: the tracked line at {value} {unit} needs bins \
         {lo}..={hi} but only bins 1..={last} are usable (resolution {resolution} {unit}): \
         near DC lengthen the window, beyond Nyquist raise the sample rate (samples per revolution)"
    )]
    OutOfBand {
        /// The harmonic multiple m.
        multiple: f64,
        /// Window centre time, s.
        time_s: f64,
        /// The tracked frequency (Hz) or order (cycles/rev).
        value: f64,
        /// `Hz` or `orders`.
        unit: &'static str,
        /// First bin of the band (may be negative).
        lo: i64,
        /// Last bin of the band.
        hi: i64,
        /// Last usable bin (N/2 − 1).
        last: usize,
        /// Width of one bin in `unit`.
        resolution: f64,
    },
}

/// The amplitude of one harmonic multiple of the excitation order, window by window.
///
/// All vectors have one entry per analysis window (block), in time order.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, schemars::JsonSchema)]
pub struct OrderTrace {
    /// The harmonic multiple m (1 = the excitation order n itself, 2 = 2n, …).
    pub multiple: f64,
    /// Window (block) centre time t_c, s.
    pub time_s: Vec<f64>,
    /// The excitation order n(t_c), cycles/rev. NOTE: n, not m·n, so the traces of all multiples
    /// share one abscissa (as in Figures 3 and 4 of the paper); the tracked order is `multiple·n`.
    pub order: Vec<f64>,
    /// Frequency of the tracked line `m·n·Ω/2π`, Hz (angle domain: with Ω the block's mean speed).
    pub freq_hz: Vec<f64>,
    /// Peak amplitude of the equivalent sinusoid, in signal units (rad/s² for rotor acceleration).
    pub amplitude: Vec<f64>,
}

/// One window of an [`OrderTrace`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TracePoint {
    /// Window centre time, s.
    pub time_s: f64,
    /// Excitation order n, cycles/rev.
    pub order: f64,
    /// Tracked frequency, Hz.
    pub freq_hz: f64,
    /// Amplitude, signal units.
    pub amplitude: f64,
}

impl OrderTrace {
    fn new(multiple: f64, capacity: usize) -> Self {
        Self {
            multiple,
            time_s: Vec::with_capacity(capacity),
            order: Vec::with_capacity(capacity),
            freq_hz: Vec::with_capacity(capacity),
            amplitude: Vec::with_capacity(capacity),
        }
    }

    fn push(&mut self, p: TracePoint) {
        self.time_s.push(p.time_s);
        self.order.push(p.order);
        self.freq_hz.push(p.freq_hz);
        self.amplitude.push(p.amplitude);
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.amplitude.len()
    }

    /// True when the trace has no windows.
    pub fn is_empty(&self) -> bool {
        self.amplitude.is_empty()
    }

    /// Window `i`, if it exists.
    pub fn point(&self, i: usize) -> Option<TracePoint> {
        (i < self.len()).then(|| TracePoint {
            time_s: self.time_s[i],
            order: self.order[i],
            freq_hz: self.freq_hz[i],
            amplitude: self.amplitude[i],
        })
    }

    /// The window of smallest amplitude (the absorber's best order in a sweep), or `None` if empty.
    pub fn min(&self) -> Option<TracePoint> {
        self.extreme(|a, b| a < b)
    }

    /// The window of largest amplitude (a resonance in a sweep), or `None` if empty.
    pub fn max(&self) -> Option<TracePoint> {
        self.extreme(|a, b| a > b)
    }

    fn extreme(&self, better: impl Fn(f64, f64) -> bool) -> Option<TracePoint> {
        let mut best: Option<usize> = None;
        for (i, &a) in self.amplitude.iter().enumerate() {
            if best.is_none_or(|b| better(a, self.amplitude[b])) {
                best = Some(i);
            }
        }
        best.and_then(|i| self.point(i))
    }

    /// The amplitude at excitation order `n`, linearly interpolated between the first pair of
    /// consecutive windows (in time order) whose orders bracket `n`; `None` if no pair does.
    ///
    /// For a sweep that goes up and then down, this is the first passage; slice the trace for the
    /// other branch.
    pub fn amplitude_at_order(&self, n: f64) -> Option<f64> {
        for i in 0..self.len().saturating_sub(1) {
            let (a, b) = (self.order[i], self.order[i + 1]);
            if (a <= n && n <= b) || (b <= n && n <= a) {
                let span = b - a;
                let s = if span == 0.0 { 0.0 } else { (n - a) / span };
                return Some(self.amplitude[i] + s * (self.amplitude[i + 1] - self.amplitude[i]));
            }
        }
        // A single window, or a fixed order that matches exactly.
        (self.len() == 1 && self.order[0] == n).then(|| self.amplitude[0])
    }
}

/// A planned real FFT with a periodic Hann window and reusable buffers: one per analysis call, so
/// the windows themselves allocate nothing.
struct HannSpectrum {
    n: usize,
    window: Vec<f64>,
    /// `N·Σw²`, the Parseval normalisation of the band energy.
    norm: f64,
    fft: Arc<dyn RealToComplex<f64>>,
    input: Vec<f64>,
    output: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl HannSpectrum {
    fn new(n: usize) -> Self {
        // Periodic (DFT-even) Hann: w_j = ½(1 − cos 2πj/N); its DFT is exactly three bins, which
        // is what makes the calibration exact on a bin. Σw² = 3N/8.
        let window: Vec<f64> = (0..n).map(|j| 0.5 * (1.0 - (2.0 * PI * j as f64 / n as f64).cos())).collect();
        let sum_w2: f64 = window.iter().map(|w| w * w).sum();
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        let input = fft.make_input_vec();
        let output = fft.make_output_vec();
        let scratch = fft.make_scratch_vec();
        Self { n, window, norm: n as f64 * sum_w2, fft, input, output, scratch }
    }

    /// Index of the last usable bin: the Nyquist bin N/2 is excluded (its one-sided energy is not
    /// doubled like the others).
    fn last_bin(&self) -> usize {
        (self.n / 2).saturating_sub(1)
    }

    /// Transforms one block: its mean removed (so a DC offset cannot leak into low bins), then
    /// windowed.
    fn transform(&mut self, block: &[f64]) {
        debug_assert_eq!(block.len(), self.n, "internal: block length differs from the planned FFT");
        let mean = fast_sum(block) / self.n as f64;
        for ((x, &s), &w) in self.input.iter_mut().zip(block).zip(&self.window) {
            *x = (s - mean) * w;
        }
        // Lengths match by construction, so the FFT cannot fail.
        self.fft
            .process_with_scratch(&mut self.input, &mut self.output, &mut self.scratch)
            .expect("internal: FFT buffer lengths");
    }

    /// Peak amplitude from the energy of bins `centre − half ..= centre + half` of the last
    /// transform (see the module docs for the calibration).
    fn band_amplitude(&self, centre: usize, half: usize) -> f64 {
        let energy: f64 = self.output[centre - half..=centre + half].iter().map(|c| c.norm_sqr()).sum();
        2.0 * (energy / self.norm).sqrt()
    }

    /// The time-domain trace point of multiple `multiple` in the last transform, the window
    /// centred at `time_s` with excitation order `order` at the speed `omega` (rad/s), bins
    /// `bin_hz` wide: the band around `multiple·order·Ω/2π` and its amplitude, or the
    /// out-of-band error naming the line.
    fn trace_point(
        &self,
        (multiple, order, omega): (f64, f64, f64),
        time_s: f64,
        bin_hz: f64,
        half: usize,
    ) -> Result<TracePoint, SignalError> {
        let freq_hz = multiple * order * omega / (2.0 * PI);
        let centre = self.band(freq_hz / bin_hz, half).map_err(|(lo, hi)| SignalError::OutOfBand {
            multiple,
            time_s,
            value: freq_hz,
            unit: "Hz",
            lo,
            hi,
            last: self.last_bin(),
            resolution: bin_hz,
        })?;
        Ok(TracePoint { time_s, order, freq_hz, amplitude: self.band_amplitude(centre, half) })
    }

    /// The band's centre bin for a line at `bins` (fractional bin position), or the out-of-band
    /// bounds `(lo, hi)` if it does not fit in 1..=last_bin.
    ///
    /// NOTE: the test is done in f64, before any conversion: a line at 1e19 bins (a huge rpm,
    /// order or multiple) saturates `as i64`, and `k + half` then wraps to a negative bin that
    /// passed the old integer test. Here `k ± half` are exact in f64 (half ≤ 64, the last bin
    /// < 2²⁵), a NaN fails both comparisons, and the error bounds saturate.
    fn band(&self, bins: f64, half: usize) -> Result<usize, (i64, i64)> {
        let k = bins.round();
        let h = half as f64;
        if k - h >= 1.0 && k + h <= self.last_bin() as f64 {
            Ok(k as usize)
        } else {
            let k = k as i64; // saturating; only reported
            Err((k.saturating_sub(half as i64), k.saturating_add(half as i64)))
        }
    }
}

/// Sum with eight independent accumulators: a plain `iter().sum()` is one serial chain of adds
/// (the compiler may not reassociate floating point), which made the window mean cost as much
/// as half the FFT.
fn fast_sum(x: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let chunks = x.chunks_exact(8);
    let tail: f64 = chunks.remainder().iter().sum();
    for c in chunks {
        for k in 0..8 {
            acc[k] += c[k];
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// Shared checks of the public entry points.
fn check_common(signal: &[f64], multiples: &[f64], half_width_bins: usize) -> Result<(), SignalError> {
    if multiples.is_empty() {
        return Err(SignalError::NoMultiples);
    }
    for &m in multiples {
        if !(m.is_finite() && m > 0.0) {
            return Err(SignalError::InvalidParameter { name: "multiple", value: m, reason: "must be finite and > 0" });
        }
    }
    if half_width_bins > 64 {
        return Err(SignalError::InvalidParameter {
            name: "half_width_bins",
            value: half_width_bins as f64,
            reason: "must be at most 64 (2 is the 5-bin convention)",
        });
    }
    if let Some((index, &value)) = signal.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(SignalError::NonFinite { what: "signal", index, value });
    }
    Ok(())
}

/// Checks a positive finite parameter.
fn positive(name: &'static str, value: f64) -> Result<f64, SignalError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SignalError::InvalidParameter { name, value, reason: "must be finite and > 0" })
    }
}

/// Evaluates the order function with a check.
fn order_checked(order_at: &dyn Fn(f64) -> f64, time_s: f64) -> Result<f64, SignalError> {
    let order = order_at(time_s);
    if order.is_finite() && order >= 0.0 { Ok(order) } else { Err(SignalError::BadOrder { time_s, order }) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::{abs_diff_eq, assert_abs_diff_eq};

    /// Parseval with the periodic Hann window: on a bin the 5-bin (indeed 3-bin) amplitude is the
    /// sinusoid's amplitude to rounding; half a bin off, the Hann kernel's leakage outside ±2 bins
    /// costs 2.6e-4 of the amplitude (sum of |W(ν)|² over ν = −2.5, ±3.5, ±4.5, … relative to the
    /// total 3/2·(N/2)²), so 3e-4 bounds every offset.
    #[test]
    fn calibration_of_a_pure_sinusoid() {
        let n = 4000;
        let mut spec = HannSpectrum::new(n);
        let sum_w2: f64 = spec.window.iter().map(|w| w * w).sum();
        assert!(abs_diff_eq!(sum_w2, 3.0 * n as f64 / 8.0, epsilon = 1e-9), "Σw² = {sum_w2}");
        let amp = 7.3;
        let mut worst: f64 = 0.0;
        let mut block = vec![0.0; n];
        for step in 0..=10 {
            let delta = -0.5 + 0.1 * step as f64; // offset from bin 100, bins
            let k0 = 100.0 + delta;
            for (j, x) in block.iter_mut().enumerate() {
                *x = 1.25 + amp * (2.0 * PI * k0 * j as f64 / n as f64 + 0.4).sin();
            }
            spec.transform(&block);
            let centre = spec.band(k0, 2).unwrap();
            let rel = spec.band_amplitude(centre, 2) / amp - 1.0;
            if delta == 0.0 {
                assert!(abs_diff_eq!(rel, 0.0, epsilon = 1e-12), "on-bin error {rel:e}");
            }
            assert!(rel <= 1e-12 && rel > -3e-4, "delta = {delta}: relative error {rel:e}");
            worst = worst.max(rel.abs());
        }
        // Half a bin off is the worst case, close to the predicted 2.6e-4.
        assert!(worst > 2.0e-4, "worst {worst:e}");
    }

    #[test]
    fn band_limits() {
        let spec = HannSpectrum::new(64);
        assert_eq!(spec.band(3.0, 2), Ok(3));
        assert_eq!(spec.band(2.4, 2), Err((0, 4)));
        assert_eq!(spec.band(29.0, 2), Ok(29));
        assert_eq!(spec.band(30.0, 2), Err((28, 32)));
        // Used to: wrap `k + half` past i64::MAX to a negative bin, accept the band and panic on
        // the slice (a multiple of 1e20).
        assert_eq!(spec.band(1e20, 2), Err((i64::MAX - 2, i64::MAX)));
        assert_eq!(spec.band(f64::INFINITY, 2), Err((i64::MAX - 2, i64::MAX)));
        assert_eq!(spec.band(-1e20, 2), Err((i64::MIN, i64::MIN + 2)));
        assert_eq!(spec.band(f64::NAN, 2), Err((-2, 2)));
    }

    #[test]
    fn trace_helpers() {
        let t = OrderTrace {
            multiple: 1.0,
            time_s: vec![0.0, 1.0, 2.0, 3.0],
            order: vec![3.0, 3.1, 3.2, 3.3],
            freq_hz: vec![50.0, 51.0, 52.0, 53.0],
            amplitude: vec![4.0, 1.0, 2.0, 5.0],
        };
        assert_eq!(t.min().unwrap().order, 3.1);
        assert_eq!(t.max().unwrap().time_s, 3.0);
        assert_abs_diff_eq!(t.amplitude_at_order(3.15).unwrap(), 1.5, epsilon = 1e-12);
        assert_eq!(t.amplitude_at_order(3.5), None);
        assert_eq!(OrderTrace::default().min(), None);
    }
}
