//! The linear steady response to a multi-order torque (eq. 24, the load cases of Table 1, §4.2)
//! ([`multi_order_response`]): each harmonic `T_k sin(k·nΩt + α_k)` passes through the
//! order-domain frequency response (eq. 22) at its own order k·n, the harmonics are superposed
//! and the peak over a revolution sampled, with the locked comparison (Fig. 5 in the linear
//! approximation).

use super::{LinResult, OrderResponse, ResponseSpec};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::model::mechanism::Mechanism;
use std::f64::consts::PI;

/// Samples per revolution of the base-order phase for the peak of a multi-order response.
const PEAK_SAMPLES: usize = 4096;

/// The torque harmonics at one speed of a multi-order load case (the paper's Table 1 row).
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedCase {
    /// Spin speed, rpm.
    pub rpm: f64,
    /// Harmonics `T_k sin(k·nΩt + α_k)` of the base order n (multiple k, amplitude N·m, phase rad).
    pub harmonics: Vec<Harmonic>,
}

/// The steady response to one harmonic of a multi-order torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarmonicResponse {
    /// Multiple k of the base order.
    pub multiple: f64,
    /// Excitation order k·n.
    pub order: f64,
    /// Torque amplitude T_k, N·m.
    pub torque: f64,
    /// Amplitude of the body's angular acceleration at this order, rad/s².
    pub amplitude: f64,
    /// Its phase: the response is `amplitude·sin(k·nΩt + phase)`, rad.
    pub phase: f64,
    /// Amplitude for the locked mechanism, rad/s².
    pub locked_amplitude: f64,
    /// Phase for the locked mechanism, rad.
    pub locked_phase: f64,
}

/// The linear steady multi-order response at one speed.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedResponse {
    /// Speed, rpm.
    pub rpm: f64,
    /// Speed, rad/s.
    pub omega: f64,
    /// Mean torque holding the speed, N·m.
    pub mean_torque: f64,
    /// Per harmonic.
    pub harmonics: Vec<HarmonicResponse>,
    /// Peak |α(t)| of the superposed harmonics over one revolution of the base-order phase
    /// (sampled at 4096 points per revolution, times the largest multiple); None when a multiple
    /// is not an integer (no common period).
    pub peak: Option<f64>,
    /// The same for the locked mechanism.
    pub locked_peak: Option<f64>,
}

fn superposed_peak(h: &[(f64, f64, f64)]) -> Option<f64> {
    if h.iter().any(|&(k, _, _)| (k - k.round()).abs() > 1e-12) {
        return None;
    }
    let kmax = h.iter().fold(1.0f64, |a, &(k, _, _)| a.max(k.abs()));
    let samples = PEAK_SAMPLES * kmax.ceil() as usize;
    let mut peak = 0.0f64;
    for i in 0..samples {
        let phi = 2.0 * PI * i as f64 / samples as f64;
        let v: f64 = h.iter().map(|&(k, a, p)| a * (k * phi + p).sin()).sum();
        peak = peak.max(v.abs());
    }
    Some(peak)
}

/// The linear steady-state response per order of `spec.body`'s angular acceleration to the
/// multi-order torque of each speed case (eq. 24 at base order `base_order`), superposing the
/// harmonics each through the frequency response at its own order, with the locked comparison
/// (Fig. 5 in the linear approximation). Each speed is linearised from the previous one's
/// equilibrium.
pub fn multi_order_response(
    mech: &Mechanism,
    spec: &ResponseSpec,
    base_order: f64,
    cases: &[SpeedCase],
    guess: Option<&[f64]>,
) -> LinResult<Vec<SpeedResponse>> {
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut out = Vec::with_capacity(cases.len());
    for case in cases {
        let omega = rpm_to_rad_s(case.rpm);
        let resp = OrderResponse::new(mech, spec, omega, guess.as_deref())?;
        guess = Some(resp.model.op.q.clone());
        let mut harmonics = Vec::with_capacity(case.harmonics.len());
        for h in &case.harmonics {
            let order = h.multiple * base_order;
            // sin(ψ + α) = Im e^{i(ψ+α)}: the response is Im(H T e^{i(ψ+α)}).
            let a = resp.response(order)?;
            let l = resp.locked_response(order)?;
            harmonics.push(HarmonicResponse {
                multiple: h.multiple,
                order,
                torque: h.amplitude,
                amplitude: a.norm() * h.amplitude.abs(),
                phase: h.phase + a.arg() + if h.amplitude < 0.0 { PI } else { 0.0 },
                locked_amplitude: l.norm() * h.amplitude.abs(),
                locked_phase: h.phase + l.arg() + if h.amplitude < 0.0 { PI } else { 0.0 },
            });
        }
        let peak = superposed_peak(&harmonics.iter().map(|h| (h.multiple, h.amplitude, h.phase)).collect::<Vec<_>>());
        let locked_peak = superposed_peak(
            &harmonics.iter().map(|h| (h.multiple, h.locked_amplitude, h.locked_phase)).collect::<Vec<_>>(),
        );
        out.push(SpeedResponse {
            rpm: case.rpm,
            omega,
            mean_torque: resp.model.op.mean_spin_torque,
            harmonics,
            peak,
            locked_peak,
        });
    }
    Ok(out)
}
