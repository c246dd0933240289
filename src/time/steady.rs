//! Steady-state detection: integrate in windows until a periodic response stops changing.
//!
//! A run at a constant mean speed Ω is continued window by window (each `window_s` long) into
//! one [`Recorder`]. After the ramp-in, two full windows and the minimum time, the response over
//! the last two windows is measured by a caller-supplied method (for a study, the order
//! amplitudes by the STFT of `crate::signal`) and the run stops when every amplitude of the last
//! window agrees with the one before to `steady_tol` (relative), or at `max_time_s`.
//!
//! The mean-speed correction: the ramp-in leaves the mean spin speed off Ω, and that rigid
//! spin-speed mode decays only with the slow time constant J/c (the locked inertia over the
//! losses). The amplitudes then creep so slowly that a two-window test passes while they still
//! sit measurably off the periodic steady state (harmonic balance shows it; figures in
//! BENCHMARKS.md, "Measured reasons behind code choices"). So after each window the measured
//! mean error δ of the spin rate is removed as a rigid rotation of the spinning subtree
//! (`u += W·e_spin·(−δ)`), and two fresh windows are required after each correction.
//!
//! The signals' swings: the order amplitudes see only the lines they track, so a free
//! oscillation left over from the start (an absorber's own mode, between or beside the tracked
//! orders) passed the test while it still rode on the response: on two absorbers tuned near
//! orders 3 and 6 a run called steady after 18 s held peaks 1.9 % above the periodic orbit's
//! while its order amplitudes agreed to 5e-5 (issue 49). So every other recorded signal's half
//! peak-to-peak swing over a window (every element's angle and rate, the largest relative
//! angle, the response) must also agree with the window before to `steady_tol`: a transient that
//! is still decaying changes the swing from window to window, a periodic motion does not (its
//! extremes are found again in every window of many periods, whatever the window's phase).
//! The steady change reported is the larger of the two.

use crate::error::{Error, Result};
use crate::kane::Kane;
use crate::time::integrate::IntegrateOptions;
use crate::time::probe::{Outcome, Recorder, simulate};

/// The amplitudes measured over the earlier and the later of two consecutive windows.
pub type WindowPair = (Vec<f64>, Vec<f64>);

/// When a windowed run counts as steady.
#[derive(Debug, Clone, Copy)]
pub struct SteadyOptions {
    /// Mean spin speed Ω the run is held at, rad/s.
    pub omega: f64,
    /// Length of the torque's ramp-in, s (no window before it ends counts).
    pub ramp_s: f64,
    /// Window length, s.
    pub window_s: f64,
    /// No comparison before this time, s.
    pub min_time_s: f64,
    /// The run stops here, steady or not, s.
    pub max_time_s: f64,
    /// Largest relative change of every amplitude, and of every other recorded signal's half
    /// peak-to-peak swing, between the last two windows.
    pub steady_tol: f64,
}

/// Where a windowed run ended.
#[derive(Debug, Clone)]
pub struct Steady {
    /// The amplitudes measured over the last window (NaN when no two windows were ever
    /// measured).
    pub amplitudes: Vec<f64>,
    /// Largest relative change of those amplitudes, or of a recorded signal's half
    /// peak-to-peak swing, between the last two windows (see the module docs).
    pub change: f64,
    /// Simulated time, s.
    pub time_s: f64,
    /// Total mean-speed error removed after the ramp-in, rad/s.
    pub speed_correction: f64,
    /// Samples in one window.
    pub window_samples: usize,
    /// The integration's counters and outcome, summed over the windows.
    pub outcome: Outcome,
}

/// Runs `kane` from `x0` at t = 0 window by window into `rec` until steady (see the module doc).
/// `spin` is the spin joint, `spin_rate` and `response` are the columns of `rec` holding its
/// rate q̇ and the measured response; `measure` maps the response over the last two windows to
/// the amplitudes of (the earlier, the later) window. Samples older than two windows are
/// dropped from `rec` as the run goes. An integration failure ends the run with its samples kept
/// and the failure in [`Steady::outcome`]; an error of `measure` is returned.
#[allow(clippy::too_many_arguments)]
pub fn settle(
    kane: &mut Kane,
    x0: &[f64],
    spin: usize,
    opts: &IntegrateOptions,
    steady: &SteadyOptions,
    rec: &mut Recorder,
    (spin_rate, response): (usize, usize),
    measure: &mut dyn FnMut(&[f64]) -> Result<WindowPair>,
    progress: &mut dyn FnMut(f64),
) -> Result<Steady> {
    let s = steady;
    let mech = kane.mechanism();
    let spin_coordinate = mech.coordinate(spin).ok_or_else(|| Error::Model {
        mechanism: mech.name.clone(),
        message: format!("steady state: the spin joint `{}` has no coordinate", mech.joints[spin].name),
    })?;
    let fs = opts.sample_rate_hz.unwrap_or(f64::NAN);
    let win = (s.window_s * fs).round() as usize;
    let (parents, speeds, n) = (mech.speed_parents(), mech.speeds, mech.ndof());
    let mut x = x0.to_vec();
    let mut t = 0.0;
    // Start comparing once the ramp is over, two full windows follow it, and the minimum time has
    // passed.
    let first = (s.ramp_s + 2.0 * s.window_s).max(s.min_time_s).min(s.max_time_s);
    let mut outcome = Outcome::default();
    let mut last: Option<(Vec<f64>, f64)> = None;
    let mut speed_correction = 0.0;
    loop {
        let t_next = if t < first { first } else { (t + s.window_s).min(s.max_time_s) };
        let chunk = simulate(kane, &x, t, t_next, opts, rec, progress);
        outcome.absorb(&chunk);
        t = chunk.t_end;
        let Some(x_end) = chunk.x_end else { break };
        x = x_end;
        let at_end = t >= s.max_time_s - 1e-9;
        let rate = &rec.columns[spin_rate];
        if rate.len() >= win && !at_end {
            let delta = rate[rate.len() - win..].iter().sum::<f64>() / win as f64 - s.omega;
            // Corrections below 1e-6 of Ω are not made: they would move the amplitudes by less
            // than ~1e-5, and at high speed the integrator's own drift of the rigid mode reaches
            // ~1e-7 of Ω per window, so a lower threshold corrected (and restarted the windows)
            // every window and never measured (NaN amplitudes; the locked rotor at 1400 rpm under
            // a six-cylinder engine's orders 3 and 6, tests/it/engine_study.rs).
            if delta.abs() > 1e-6 * s.omega {
                let mut dq = vec![0.0; n];
                dq[spin_coordinate] = -delta;
                let mut du = vec![0.0; n];
                speeds.u_from_qdot(&parents, &dq, &mut du);
                for (xi, d) in x[n..].iter_mut().zip(&du) {
                    *xi += d;
                }
                speed_correction += delta;
                rec.keep_last(0);
                continue;
            }
        }
        let signal = &rec.columns[response];
        if signal.len() < 2 * win {
            if at_end {
                break;
            }
            continue;
        }
        let (a_prev, a_last) = measure(&signal[signal.len() - 2 * win..])?;
        let change = a_prev.iter().zip(&a_last).map(|(p, l)| ((l - p) / l).abs()).fold(0.0, f64::max);
        let change = change.max(swing_change(&rec.columns, spin_rate, win));
        last = Some((a_last, change));
        if change <= s.steady_tol || at_end {
            break;
        }
        // Keep memory bounded: only the last two windows are ever analysed.
        rec.keep_last(2 * win);
    }
    let (amplitudes, change) = last.unwrap_or((Vec::new(), f64::NAN));
    Ok(Steady { amplitudes, change, time_s: t, speed_correction, window_samples: win, outcome })
}

/// The largest relative change of a recorded signal's half peak-to-peak swing between the
/// last two windows of `win` samples, over every column but `skip` (the spin rate, whose mean
/// the speed correction moves). A column that is not kept is left out, and so is one whose
/// swing is below 1e-9 of the largest (a coordinate the excitation does not reach, moving by
/// rounding only).
fn swing_change(columns: &[Vec<f64>], skip: usize, win: usize) -> f64 {
    let swing = |w: &[f64]| {
        let (lo, hi) = w.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        0.5 * (hi - lo)
    };
    let pairs: Vec<(f64, f64)> = columns
        .iter()
        .enumerate()
        .filter(|(c, col)| *c != skip && win > 0 && col.len() >= 2 * win)
        .map(|(_, col)| {
            let tail = &col[col.len() - 2 * win..];
            (swing(&tail[..win]), swing(&tail[win..]))
        })
        .collect();
    let largest = pairs.iter().fold(0.0_f64, |m, p| m.max(p.1));
    let mut change = 0.0_f64;
    for (prev, last) in pairs {
        if last > 1e-9 * largest {
            change = change.max(((last - prev) / last).abs());
        }
    }
    change
}

#[cfg(test)]
mod tests {
    use super::swing_change;
    use std::f64::consts::TAU;

    /// A steady sine has the same swing in every window, whatever its phase there; a decaying
    /// one changes by its decay over a window; the skipped column and a column of rounding noise
    /// count for nothing.
    #[test]
    fn swing_change_sees_a_decaying_oscillation() {
        let (win, fs, f) = (4000, 1000.0, 7.3);
        let t: Vec<f64> = (0..2 * win).map(|i| i as f64 / fs).collect();
        let steady: Vec<f64> = t.iter().map(|t| 0.3 + (TAU * f * t).sin()).collect();
        // Decay rate 0.01/s over a 4 s window: the swing shrinks by the factor e^(−0.04).
        let decaying: Vec<f64> = t.iter().map(|t| (-0.01 * t).exp() * (TAU * f * t).sin()).collect();
        let noise: Vec<f64> = (0..2 * win).map(|i| 1e-14 * ((i * 7919) % 13) as f64).collect();
        let alone = swing_change(std::slice::from_ref(&steady), 9, win);
        // Sampled extremes of a 7.3 Hz sine at 1 kHz over 29 periods: the worst sample phase
        // misses a peak by 1 − cos(π·7.3/1000) ≈ 2.6e-4; many periods do better.
        assert!(alone < 3e-4, "{alone}");
        assert_eq!(swing_change(&[steady.clone(), noise], 9, win), alone);
        let c = swing_change(&[steady.clone(), decaying.clone()], 9, win);
        let want = 1.0 - (0.04f64).exp();
        assert!((c - want.abs()).abs() < 3e-3, "{c} against {}", want.abs());
        assert_eq!(swing_change(&[steady, decaying], 1, win), alone);
    }
}
