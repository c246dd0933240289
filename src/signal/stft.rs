//! Time-domain order tracking by short-time Fourier transform (the study convention of docs/design/conventions.md).

use super::{HannSpectrum, OrderTrace, SignalError, order_checked};

/// Options of [`stft_order_traces`]. The defaults are the study convention of docs/design/conventions.md.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StftOptions {
    /// Window length, s (default 2 s: 0.5 Hz bins). Rounded to a whole number of samples N.
    pub window_s: f64,
    /// Hop between window starts, s (default 0.25 s). Rounded to whole samples, at least one.
    pub hop_s: f64,
    /// Bins summed on each side of the nearest bin (default 2: the 5-bin summation of §4.1).
    pub half_width_bins: usize,
}

impl Default for StftOptions {
    fn default() -> Self {
        Self { window_s: 2.0, hop_s: 0.25, half_width_bins: 2 }
    }
}

/// Order traces of `signal` by STFT, one [`OrderTrace`] per entry of `multiples`.
///
/// - `signal`: samples at times `i / fs_hz`, i = 0, 1, … (the first sample at t = 0).
/// - `fs_hz`: sample rate, Hz.
/// - `omega_rad_s`: reference speed Ω, rad/s, that turns orders into frequencies `f = m·n·Ω/2π`
///   (the nominal speed, as in `Excitation::omega`, not the instantaneous one).
/// - `order_at`: the excitation order n(t) as a function of time, s (e.g. `&|t| order.at(t)` for
///   a [`crate::model::excitation::Order`]); evaluated at each window centre.
/// - `multiples`: harmonic multiples m to track (e.g. `[1.0, 2.0]` for n and 2n).
///
/// Each window of N samples (N = round(window_s·fs)) starts `round(hop_s·fs)` samples after the
/// previous one; windows that would run past the end are dropped. Its mean is removed, it is
/// multiplied by a periodic Hann window and transformed; its centre time is `t_c = (start + N/2)/fs`
/// (the periodic Hann window is symmetric about sample N/2). For each multiple the bin nearest
/// `m·n(t_c)·Ω/2π` and `half_width_bins` neighbours each side give `A = 2·sqrt(Σ|X_k|²/(N·Σw²))`,
/// the peak amplitude of the equivalent sinusoid (exact on a bin, ≤ 2.6·10⁻⁴ low between bins;
/// see the [module docs](super)).
///
/// # Errors
/// Non-positive or non-finite `fs_hz`, `omega_rad_s`, `window_s`, `hop_s` or multiple; a window
/// of more than [`MAX_POINTS`](super::MAX_POINTS) (2²⁶) samples; no multiples; a non-finite
/// sample; a signal shorter than one window; `order_at` returning a negative or non-finite order;
/// a band that does not fit between DC and Nyquist, including a line too far out to count in bins
/// (the message names the multiple, time and frequency).
///
/// # Common mistake
/// Ω is in rad/s: pass `rpm_to_rad_s(1000.0)`, not 1000.
pub fn stft_order_traces(
    signal: &[f64],
    fs_hz: f64,
    omega_rad_s: f64,
    order_at: &dyn Fn(f64) -> f64,
    multiples: &[f64],
    opts: &StftOptions,
) -> Result<Vec<OrderTrace>, SignalError> {
    // The parameters and the samples' finiteness, checked as the streamed STFT checks them.
    let nonfinite = signal.iter().enumerate().find(|(_, x)| !x.is_finite()).map(|(i, &x)| (i, x));
    let n = super::stream::window_samples(fs_hz, omega_rad_s, multiples, opts, nonfinite)?;
    let (fs, omega, hop_s) = (fs_hz, omega_rad_s, opts.hop_s);
    if signal.len() < n {
        return Err(SignalError::TooShort { what: "signal", got: signal.len(), needed: n });
    }
    // A hop beyond the signal gives one window, as any hop ≥ len − N + 1 does.
    let hop = (hop_s * fs).round().clamp(1.0, signal.len() as f64) as usize;
    let windows = (signal.len() - n) / hop + 1;

    let mut spec = HannSpectrum::new(n);
    let bin_hz = fs / n as f64;
    let mut traces: Vec<OrderTrace> = multiples.iter().map(|&m| OrderTrace::new(m, windows)).collect();
    for w in 0..windows {
        let start = w * hop;
        let time_s = (start as f64 + 0.5 * n as f64) / fs;
        let order = order_checked(order_at, time_s)?;
        spec.transform(&signal[start..start + n]);
        for trace in &mut traces {
            trace.push(spec.trace_point((trace.multiple, order, omega), time_s, bin_hz, opts.half_width_bins)?);
        }
    }
    Ok(traces)
}
