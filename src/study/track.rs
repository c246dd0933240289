//! Order tracking as a study reads it: the STFT order traces of docs/design/conventions.md of a whole
//! sampled record ([`track`]), and one channel of a streamed run's STFT read the same way
//! ([`tracked`]): no trace for a record shorter than one window, an order-tracking error as the
//! model's. Both the time runs (`sim`) and the elements (`elements`) take it from here, so
//! neither needs the other for it.

use super::spec::TrackingSpec;
use crate::error::{Error, Result};
use crate::signal::{OrderTrace, StftOptions, stft_order_traces};

/// Order traces of a sampled response by the STFT of docs/design/conventions.md; `mechanism` names the model in
/// an error (the study validates the bands at load, so one is an internal inconsistency).
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
    let traces = stft_order_traces(signal, fs, omega, order_at, multiples, &opts);
    tracked(mechanism, traces, signal.len(), fs, multiples, t)
}

/// The study's reading of one channel of a run's [`crate::signal::StftStream`]: [`track`] of its
/// whole record (`len` samples): no trace when the run failed before one window, an
/// order-tracking error as the model's.
pub(crate) fn tracked(
    mechanism: &str,
    result: std::result::Result<Vec<OrderTrace>, crate::signal::SignalError>,
    len: usize,
    fs: f64,
    multiples: &[f64],
    t: &TrackingSpec,
) -> Result<Vec<OrderTrace>> {
    if len < (t.window_s * fs).round() as usize {
        // A run that failed before one full window has no trace; its failure is reported.
        return Ok(multiples.iter().map(|&m| OrderTrace { multiple: m, ..OrderTrace::default() }).collect());
    }
    result.map_err(|e| Error::Model { mechanism: mechanism.to_string(), message: format!("order tracking: {e}") })
}
