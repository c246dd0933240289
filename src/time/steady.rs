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
    /// Largest relative change of every amplitude between the last two windows.
    pub steady_tol: f64,
}

/// Where a windowed run ended.
#[derive(Debug, Clone)]
pub struct Steady {
    /// The amplitudes measured over the last window (NaN when no two windows were ever
    /// measured).
    pub amplitudes: Vec<f64>,
    /// Largest relative change of those amplitudes between the last two windows.
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
