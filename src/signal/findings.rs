//! Findings read off order traces: the windows after the ramp-in, a trace's minimum, the order
//! intervals where the up and the down sweep differ (the two branches of a softening or
//! hardening response, the paper's Figs. 3 and 4), and the order where a sweep jumps between
//! them.

use super::OrderTrace;

/// The trace's amplitude at order `n` (NaN outside its range).
pub fn at_order(t: &OrderTrace, n: f64) -> f64 {
    t.amplitude_at_order(n).unwrap_or(f64::NAN)
}

/// Order and amplitude of a trace's minimum, ignoring the windows before `skip_before_s` (the
/// ramp-in, where the amplitude is still growing).
pub fn trace_minimum(t: &OrderTrace, skip_before_s: f64) -> Option<(f64, f64)> {
    skip_ramp(t, skip_before_s).min().map(|p| (p.order, p.amplitude))
}

/// The order intervals where trace `b` exceeds trace `a` (windows of the same run: a higher order
/// above the main one), ignoring the windows before `skip_before_s`.
pub fn exceeds(a: &OrderTrace, b: &OrderTrace, skip_before_s: f64) -> Vec<(f64, f64)> {
    let mut pairs: Vec<(f64, bool)> = a
        .time_s
        .iter()
        .zip(a.order.iter().zip(a.amplitude.iter().zip(&b.amplitude)))
        .filter(|(t, _)| **t >= skip_before_s)
        .map(|(_, (&n, (&a1, &a2)))| (n, a2 > a1))
        .collect();
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let orders: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    // Orders of one sweep are distinct, so the first pair at an order is its own.
    intervals(&orders, |n| pairs.iter().find(|p| p.0 == n).is_some_and(|p| p.1))
}

/// Order intervals where `pred(order)` holds, sampled on `orders` (sorted ascending).
pub fn intervals(orders: &[f64], pred: impl Fn(f64) -> bool) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::new();
    let mut start: Option<f64> = None;
    let mut last = f64::NAN;
    for &n in orders {
        if pred(n) {
            start.get_or_insert(n);
            last = n;
        } else if let Some(s) = start.take() {
            out.push((s, last));
        }
    }
    if let Some(s) = start {
        out.push((s, last));
    }
    out
}

/// Where the up and down main-order traces differ by more than `factor` (either way), on an
/// order grid of step 0.002 over the common range.
pub fn branch_differences(up: &OrderTrace, down: &OrderTrace, factor: f64) -> Vec<(f64, f64)> {
    let lo = up.order.iter().chain(&down.order).copied().fold(f64::INFINITY, f64::min);
    let hi = up.order.iter().chain(&down.order).copied().fold(f64::NEG_INFINITY, f64::max);
    let grid = order_grid(lo, hi);
    let (u_lo, u_hi) = minmax(&up.order);
    let (d_lo, d_hi) = minmax(&down.order);
    intervals(&grid, |n| {
        if n < u_lo.max(d_lo) || n > u_hi.min(d_hi) {
            return false;
        }
        let (a, b) = (at_order(up, n), at_order(down, n));
        a > factor * b || b > factor * a
    })
}

/// An order grid of step about 0.002 from `lo` to `hi` (empty unless both are finite).
pub fn order_grid(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let steps = ((hi - lo) / 0.002).ceil() as usize;
    (0..=steps).map(|i| lo + (hi - lo) * i as f64 / steps.max(1) as f64).collect()
}

/// Smallest and largest value.
fn minmax(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
}

/// The trace without its windows inside the ramp-in (their amplitudes are still growing).
pub fn skip_ramp(t: &OrderTrace, skip_before_s: f64) -> OrderTrace {
    let keep: Vec<usize> = (0..t.time_s.len()).filter(|&i| t.time_s[i] >= skip_before_s).collect();
    let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    OrderTrace {
        multiple: t.multiple,
        time_s: pick(&t.time_s),
        order: pick(&t.order),
        freq_hz: pick(&t.freq_hz),
        amplitude: pick(&t.amplitude),
    }
}

/// The order where a sweep jumps: the largest change (at least 2×) of the trace's amplitude
/// between windows `lag` apart (overlapping windows spread a jump over window/hop of them),
/// ignoring the windows before `skip_before_s`; the order halfway between those windows.
pub fn jump_order(t: &OrderTrace, lag: usize, skip_before_s: f64) -> Option<f64> {
    let t = skip_ramp(t, skip_before_s);
    let a = &t.amplitude;
    (lag.max(1)..a.len())
        .map(|i| (i, (a[i] / a[i - lag.max(1)]).ln().abs()))
        .filter(|(_, r)| *r > std::f64::consts::LN_2)
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(i, _)| 0.5 * (t.order[i] + t.order[i - lag.max(1)]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::{abs_diff_eq, assert_abs_diff_eq};

    /// A sweep trace over orders 3.0, 3.1, … (one window per second) with the given amplitudes.
    fn trace(amplitude: &[f64]) -> OrderTrace {
        let k = amplitude.len();
        OrderTrace {
            multiple: 1.0,
            time_s: (0..k).map(|i| i as f64).collect(),
            order: (0..k).map(|i| 3.0 + 0.1 * i as f64).collect(),
            freq_hz: vec![0.0; k],
            amplitude: amplitude.to_vec(),
        }
    }

    #[test]
    fn minimum_skips_the_ramp() {
        // The smallest value sits inside the ramp (t = 0 s) and must be ignored.
        let t = trace(&[0.1, 5.0, 4.0, 2.0, 3.0]);
        assert_eq!(skip_ramp(&t, 1.0).amplitude, [5.0, 4.0, 2.0, 3.0]);
        let (n, a) = trace_minimum(&t, 1.0).unwrap();
        assert_abs_diff_eq!(n, 3.3, epsilon = 1e-12);
        assert!(a == 2.0);
        assert_eq!(trace_minimum(&t, 10.0), None);
    }

    #[test]
    fn intervals_where_a_higher_order_exceeds_the_main() {
        let main = trace(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
        let second = trace(&[2.0, 0.5, 2.0, 2.0, 0.5, 2.0]);
        let iv = exceeds(&main, &second, 1.0);
        assert_eq!(iv.len(), 2);
        assert_abs_diff_eq!(iv[0].0, 3.2, epsilon = 1e-12);
        assert_abs_diff_eq!(iv[0].1, 3.3, epsilon = 1e-12);
        assert_abs_diff_eq!(iv[1].0, 3.5, epsilon = 1e-12);
        assert_abs_diff_eq!(iv[1].1, 3.5, epsilon = 1e-12);
    }

    #[test]
    fn branches_differ_where_one_is_beyond_the_factor() {
        // Up 1 everywhere; down 3 (beyond 1.5×) between the orders 3.2 and 3.3; the grid's step
        // of 0.002 resolves the interval to within one step of the linear crossings
        // 3.1 + 0.1·(1.5 − 1)/2 = 3.125 and 3.3 + 0.1·(3 − 1.5)/2 = 3.375.
        let up = trace(&[1.0; 6]);
        let down = trace(&[1.0, 1.0, 3.0, 3.0, 1.0, 1.0]);
        let iv = branch_differences(&up, &down, 1.5);
        assert_eq!(iv.len(), 1);
        assert!(
            abs_diff_eq!(iv[0].0, 3.125, epsilon = 0.002) && abs_diff_eq!(iv[0].1, 3.375, epsilon = 0.002),
            "{iv:?}"
        );
    }

    #[test]
    fn a_jump_is_halfway_between_the_windows_it_spans() {
        // With lag 2 the largest change is 13/1.5 from 3.3 to 3.5 (12/1.5 from 3.2 to 3.4 is
        // smaller); changes below 2× never count.
        let t = trace(&[1.0, 1.5, 1.5, 1.5, 12.0, 13.0, 13.0]);
        let n = jump_order(&t, 2, 0.0).unwrap();
        assert_abs_diff_eq!(n, 3.4, epsilon = 1e-12);
        assert_eq!(jump_order(&trace(&[1.0, 1.5, 2.0, 2.5]), 1, 0.0), None);
    }
}

/// The largest `|y(t) − mean|` of a sampled signal between its samples, not only at them: the
/// largest sample, refined on the two intervals beside it by a cubic through the samples, Hermite
/// with the given slopes `dy` (signal units per s, e.g. q̇ next to q: error O(h⁴)) or Catmull–Rom
/// from the neighbours without them (O(h³)). `dt` is the sample step, s. A sample maximum alone
/// misses a line at ω by up to `1 − cos(ωh/2)`: 2.7 % for 150 Hz at 2 kHz; the refined one by
/// ~(ωh)⁴/400.
pub fn refined_peak(y: &[f64], dy: Option<&[f64]>, dt: f64, mean: f64) -> f64 {
    let Some((k, best)) =
        y.iter().map(|v| (v - mean).abs()).enumerate().fold(None, |b: Option<(usize, f64)>, (i, v)| match b {
            Some((_, m)) if m >= v => b,
            _ => Some((i, v)),
        })
    else {
        return f64::NAN;
    };
    refine_peak_at(y, dy, dt, mean, k, best)
}

/// The refinement of [`refined_peak`] about its largest sample `k`, whose `|y − mean|` is `best`:
/// it reads `y` and `dy` at `k − 2 ..= k + 2` only, and where they end, so the five samples around
/// the peak give the whole record's answer (the streamed peak, [`super::PeakStream`]).
pub(crate) fn refine_peak_at(y: &[f64], dy: Option<&[f64]>, dt: f64, mean: f64, k: usize, mut best: f64) -> f64 {
    let n = y.len();
    // Slopes in sample-index units at i.
    let slope = |i: usize| match dy {
        Some(d) => d[i] * dt,
        None if i == 0 => y[1.min(n - 1)] - y[0],
        None if i + 1 == n => y[i] - y[i - 1],
        None => 0.5 * (y[i + 1] - y[i - 1]),
    };
    for i in [k.wrapping_sub(1), k] {
        if i >= n.saturating_sub(1) {
            continue;
        }
        let (y0, y1, m0, m1) = (y[i], y[i + 1], slope(i), slope(i + 1));
        // p'(u) = a u² + b u + c of the Hermite cubic on [0, 1].
        let (a, b, c) = (6.0 * (y0 - y1) + 3.0 * (m0 + m1), -6.0 * (y0 - y1) - 4.0 * m0 - 2.0 * m1, m0);
        let roots: Vec<f64> = if a.abs() < 1e-300 {
            if b != 0.0 { vec![-c / b] } else { Vec::new() }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc < 0.0 {
                Vec::new()
            } else {
                let s = disc.sqrt();
                vec![(-b + s) / (2.0 * a), (-b - s) / (2.0 * a)]
            }
        };
        for u in roots.into_iter().filter(|u| (0.0..=1.0).contains(u)) {
            let (u2, u3) = (u * u, u * u * u);
            let p = (2.0 * u3 - 3.0 * u2 + 1.0) * y0
                + (u3 - 2.0 * u2 + u) * m0
                + (3.0 * u2 - 2.0 * u3) * y1
                + (u3 - u2) * m1;
            best = best.max((p - mean).abs());
        }
    }
    best
}

#[cfg(test)]
mod peak_tests {
    use super::refined_peak;
    use approx::assert_abs_diff_eq;

    /// A 150 Hz sine sampled at 2 kHz with its crest between samples: the sample maximum misses
    /// it by up to 1 − cos(ωh/2) (2.7 %); the Hermite refinement with the exact slopes is within
    /// (ωh)⁴/384 ≈ 1.3e-4, Catmull–Rom within a few 1e-3.
    #[test]
    fn the_crest_between_samples_is_found() {
        let (w, dt) = (2.0 * std::f64::consts::PI * 150.0, 5e-4);
        let phase = 0.5 * w * dt + 1.3; // a crest halfway between two samples
        let t: Vec<f64> = (0..200).map(|i| i as f64 * dt).collect();
        let y: Vec<f64> = t.iter().map(|&t| 0.7 + 2.0 * (w * t + phase).sin()).collect();
        let dy: Vec<f64> = t.iter().map(|&t| 2.0 * w * (w * t + phase).cos()).collect();
        let sampled = y.iter().map(|v| (v - 0.7).abs()).fold(0.0, f64::max);
        let hermite = refined_peak(&y, Some(&dy), dt, 0.7);
        let catmull = refined_peak(&y, None, dt, 0.7);
        println!(
            "sampled {:.2e}, Hermite {:.2e}, Catmull–Rom {:.2e}",
            1.0 - sampled / 2.0,
            (hermite - 2.0).abs() / 2.0,
            (catmull - 2.0).abs() / 2.0
        );
        assert_abs_diff_eq!(hermite, 2.0, epsilon = 2e-4 * 2.0);
        assert_abs_diff_eq!(catmull, 2.0, epsilon = 1e-2 * 2.0);
        assert!(hermite > sampled && catmull > sampled);
    }
}
