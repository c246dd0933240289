//! The order–rpm map of a run-up or run-down: the angle-domain spectrum of every block of whole
//! revolutions against the block's mean speed, which is how test engineers look at torsionals.
//!
//! The signal is resampled at constant crank-angle increments
//! ([`resample_at_constant_angle`]), cut into blocks of R revolutions every `hop_revs`, and each
//! block transformed as in [`super::angle_domain_order_traces`] (mean removed, periodic Hann):
//! bin k is order k/R. Each map cell is the band amplitude of bins `k − h ..= k + h` (the same
//! calibration as the traces, so a pure order line reads its amplitude at its own bin whatever
//! the leakage), for every k whose band fits inside bins 1..N/2 − 1, up to `max_order`.
//!
//! The map's speed resolution is the spread of speeds inside one block: a block spans R
//! revolutions, so through a run-up at `dΩ/dt` its speeds differ by about `R·2π·(dΩ/dt)/Ω`
//! (see [`OrderMap::speed_resolution_rpm`]).

use super::{AngleOptions, resample_at_constant_angle};
use super::{HannSpectrum, MAX_POINTS, SignalError, positive};

/// Amplitude over (block, order): see the module docs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OrderMap {
    /// Block centre times, s.
    pub time_s: Vec<f64>,
    /// Mean speed of each block, rpm.
    pub rpm: Vec<f64>,
    /// Lowest and highest speed inside each block, rpm (from the times of its first and last
    /// revolution).
    pub rpm_span: Vec<(f64, f64)>,
    /// The orders of the map's columns, cycles/rev (bin k is order k/R).
    pub orders: Vec<f64>,
    /// `amplitude[block][column]`, peak amplitude in signal units.
    pub amplitude: Vec<Vec<f64>>,
}

impl OrderMap {
    /// The largest spread of speeds inside one block, rpm: the resolution of the map's speed axis.
    pub fn speed_resolution_rpm(&self) -> f64 {
        self.rpm_span.iter().map(|(lo, hi)| (hi - lo).abs()).fold(0.0, f64::max)
    }

    /// The cut of the map at the column nearest `order`: the amplitude of each block, or `None`
    /// when the map has no column within half a bin of it.
    pub fn cut(&self, order: f64) -> Option<Vec<f64>> {
        let step = if self.orders.len() > 1 { self.orders[1] - self.orders[0] } else { f64::INFINITY };
        let (c, d) =
            self.orders.iter().enumerate().map(|(c, o)| (c, (o - order).abs())).min_by(|a, b| a.1.total_cmp(&b.1))?;
        (d <= 0.5 * step + 1e-12).then(|| self.amplitude.iter().map(|row| row[c]).collect())
    }
}

/// The order–rpm map of `signal` (samples at times `i / fs_hz`, with the crank at the unwrapped
/// angle `theta_rad[i]`, rad), up to `max_order`.
///
/// # Errors
/// As [`resample_at_constant_angle`]; a non-finite sample; fewer resampled points than one
/// block; bad options; a `max_order` below the first usable column; or more than
/// [`MAX_POINTS`](super::MAX_POINTS) map cells.
pub fn order_rpm_map(
    signal: &[f64],
    theta_rad: &[f64],
    fs_hz: f64,
    max_order: f64,
    opts: &AngleOptions,
) -> Result<OrderMap, SignalError> {
    positive("max_order", max_order)?;
    positive("hop_revs", opts.hop_revs)?;
    if let Some((index, &value)) = signal.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(SignalError::NonFinite { what: "signal", index, value });
    }
    let (p, r, h) = (opts.samples_per_rev, opts.revs_per_block, opts.half_width_bins);
    if r == 0 {
        return Err(SignalError::InvalidParameter { name: "revs_per_block", value: 0.0, reason: "must be at least 1" });
    }
    let resampled = resample_at_constant_angle(signal, theta_rad, fs_hz, p)?;
    let Some(m_len) = r.checked_mul(p).filter(|&m| m <= MAX_POINTS && m >= 4 * h + 8) else {
        return Err(SignalError::InvalidParameter {
            name: "revs_per_block",
            value: r as f64,
            reason: "times samples_per_rev must lie in 4·half_width_bins + 8 ..= 2^26 points",
        });
    };
    let (times, values) = (&resampled.time_s, &resampled.value);
    if values.len() < m_len {
        return Err(SignalError::TooShort { what: "angle-resampled signal", got: values.len(), needed: m_len });
    }
    let hop = (opts.hop_revs * p as f64).round().clamp(1.0, values.len() as f64) as usize;
    let blocks = (values.len() - m_len) / hop + 1;
    let mut spec = HannSpectrum::new(m_len);
    // Columns: bins whose band fits in 1..=last, up to max_order.
    let first = h + 1;
    let last = (spec.last_bin() - h).min((max_order * r as f64).floor() as usize);
    if last < first {
        return Err(SignalError::InvalidParameter {
            name: "max_order",
            value: max_order,
            reason: "is below the first order whose band fits in the block's spectrum",
        });
    }
    let columns = last - first + 1;
    if blocks.saturating_mul(columns) > MAX_POINTS {
        return Err(SignalError::InvalidParameter {
            name: "hop_revs",
            value: opts.hop_revs,
            reason: "gives more than 2^26 map cells (blocks × orders); raise the hop or lower max_order",
        });
    }
    let orders = (first..=last).map(|k| k as f64 / r as f64).collect();
    let rpm_of = |revs: f64, dt: f64| 60.0 * revs / dt;
    let mut map = OrderMap { orders, ..OrderMap::default() };
    for b in 0..blocks {
        let start = b * hop;
        let block_times = &times[start..start + m_len];
        map.time_s.push(block_times[m_len / 2]);
        map.rpm.push(rpm_of((m_len - 1) as f64 / p as f64, block_times[m_len - 1] - block_times[0]));
        // First and last revolution of the block: their mean speeds bound the block's.
        let ends = [
            rpm_of(1.0, block_times[p] - block_times[0]),
            rpm_of(1.0, block_times[m_len - 1] - block_times[m_len - 1 - p]),
        ];
        map.rpm_span.push((ends[0].min(ends[1]), ends[0].max(ends[1])));
        spec.transform(&values[start..start + m_len]);
        map.amplitude.push((first..=last).map(|k| spec.band_amplitude(k, h)).collect());
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::abs_diff_eq;
    use std::f64::consts::PI;

    /// A run-up at constant angular acceleration with two order lines of known amplitude: each
    /// line reads its amplitude at its own column (the band calibration), and the blocks' mean
    /// speeds follow the ramp.
    #[test]
    fn order_lines_of_a_run_up_read_their_amplitudes() {
        let (fs, w0, alpha) = (2000.0, 2.0 * PI * 10.0, 2.0 * PI * 0.5); // 600 rpm + 30 rpm/s
        let t: Vec<f64> = (0..(40.0 * fs) as usize).map(|i| i as f64 / fs).collect();
        let theta: Vec<f64> = t.iter().map(|&t| w0 * t + 0.5 * alpha * t * t).collect();
        let signal: Vec<f64> = theta.iter().map(|&th| 2.0 * (3.0 * th).sin() + 0.5 * (6.0 * th + 0.3).cos()).collect();
        let map = order_rpm_map(&signal, &theta, fs, 10.0, &AngleOptions::default()).unwrap();
        let cut3 = map.cut(3.0).unwrap();
        let cut6 = map.cut(6.0).unwrap();
        // Catmull–Rom resampling at ωΔt ≤ 0.35 costs < 2e-4 of amplitude (see resample's docs);
        // the Hann band holds the rest to rounding.
        assert!(cut3.iter().all(|&a| abs_diff_eq!(a, 2.0, epsilon = 2e-3 * 2.0)), "{cut3:?}");
        assert!(cut6.iter().all(|&a| abs_diff_eq!(a, 0.5, epsilon = 2e-3 * 0.5)));
        // Away from the lines (order 4.5, more than h bins off either) only leakage is left.
        let cut45 = map.cut(4.5).unwrap();
        assert!(cut45.iter().all(|&a| a < 1e-3), "{cut45:?}");
        for (k, &rpm) in map.rpm.iter().enumerate() {
            let exact = 60.0 * (w0 + alpha * map.time_s[k]) / (2.0 * PI);
            // The block's mean speed is that at its centre in angle, not in time: within its span.
            let (lo, hi) = map.rpm_span[k];
            assert!(lo <= rpm && rpm <= hi && abs_diff_eq!(rpm, exact, epsilon = hi - lo), "{rpm} vs {exact}");
        }
        assert!(map.speed_resolution_rpm() > 0.0);
        assert!(map.cut(100.0).is_none());
    }

    #[test]
    fn bad_options_are_refused() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 0.01).collect();
        let s = vec![0.0; t.len()];
        assert!(order_rpm_map(&s, &t, 1000.0, 0.0, &AngleOptions::default()).is_err());
        assert!(order_rpm_map(&s, &t, 1000.0, 5.0, &AngleOptions { revs_per_block: 0, ..Default::default() }).is_err());
        let mut bad = s.clone();
        bad[3] = f64::NAN;
        assert!(order_rpm_map(&bad, &t, 1000.0, 5.0, &AngleOptions::default()).is_err());
    }
}
