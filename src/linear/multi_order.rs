//! The linear steady response to a multi-order torque (eq. 24, the load cases of Table 1, §4.2)
//! ([`multi_order_response`]): each harmonic `T_k sin(k·nΩt + α_k)` passes through the
//! order-domain frequency response (eq. 22) at its own order k·n, the harmonics are superposed
//! and the peak over a revolution sampled, with the locked comparison (Fig. 5 in the linear
//! approximation). With gravity, its order-1 response (the `gravity` submodule) is one more line
//! of the superposition: the peak is then taken over the common period of all the lines in the
//! rotor angle (one revolution for integer orders, d revolutions for orders in steps of 1/d).

use super::{
    C64, ElementLaw, Input, LinResult, LinearError, ModalCombination, ModalDamping, OrderResponse, ResponseSpec, Spin,
    element_law,
};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::model::mechanism::Mechanism;
use std::f64::consts::{FRAC_PI_2, PI};

/// Samples per revolution of the base-order phase for the peak of a multi-order response.
const PEAK_SAMPLES: usize = 4096;
/// Largest denominator d tried for a common period of the lines with gravity (orders in steps
/// of 1/d: half orders of a four-stroke engine have d = 2).
const MAX_PERIOD_REVOLUTIONS: usize = 24;
/// Most samples of one peak search with gravity (beyond it, no peak is given).
const MAX_PEAK_SAMPLES: usize = 1 << 22;

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
    /// The order-1 response to gravity (and world-frame forces), when the mechanism has it
    /// (see the `gravity` submodule); included in `peak` and `locked_peak`.
    pub gravity: Option<GravityLine>,
    /// The elements of [`MultiOrderOptions::elements`], in their order (gravity's line not
    /// included).
    pub elements: Vec<ElementLines>,
}

/// The linear steady response of one element (a joint's coordinate, and the torque its spring
/// and damper transmit) to the harmonics of a multi-order torque, each `amplitude·sin(k·nΩt +
/// phase)` as in [`HarmonicResponse`].
#[derive(Debug, Clone, PartialEq)]
pub struct ElementLines {
    /// The joint (tree index).
    pub joint: usize,
    /// Per harmonic, the amplitude of the joint's coordinate, rad (m for a slide).
    pub amplitude: Vec<f64>,
    /// Per harmonic, its phase, rad.
    pub phase: Vec<f64>,
    /// Per harmonic, the amplitude of the torque the joint's spring, damper and driving compliant
    /// mesh transmit ([`super::ElementLaw`]; the dampers left out where modal damping replaces
    /// them), N·m (N for a slide); empty for a joint with a staged spring, friction or end stops,
    /// whose torque is not linear.
    pub torque: Vec<f64>,
    /// Per harmonic, the torque's phase, rad.
    pub torque_phase: Vec<f64>,
    /// Peak |q − q⁰| of the superposed harmonics over one revolution of the base order, rad (m);
    /// None when a multiple is not an integer.
    pub peak: Option<f64>,
    /// The same for the torque, N·m (N); None as for `peak`, or without a linear torque.
    pub peak_torque: Option<f64>,
    /// The coordinate at the operating point q⁰ (its mean in the steady state), rad (m).
    pub mean: f64,
    /// The lowest and highest value of the superposed oscillation about `mean`, rad (m); None as
    /// for `peak`.
    pub range: Option<(f64, f64)>,
    /// The torque's mean at the operating point q⁰, `k (q⁰ − q_free)` and the mesh's (the
    /// dampers add nothing on average), N·m (N).
    pub mean_torque: f64,
    /// The same as `range` for the torque, N·m (N).
    pub torque_range: Option<(f64, f64)>,
}

/// The steady order-1 line of a body's angular acceleration forced by gravity at the nominal
/// rotation, in the convention of [`HarmonicResponse`]: `amplitude·sin(Ωt + phase)`, the spin
/// angle 0 at t = 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GravityLine {
    /// Amplitude of the body's angular acceleration, rad/s².
    pub amplitude: f64,
    /// Its phase, rad.
    pub phase: f64,
    /// Amplitude for the locked mechanism, rad/s².
    pub locked_amplitude: f64,
    /// Phase for the locked mechanism, rad.
    pub locked_phase: f64,
}

impl SpeedResponse {
    /// The amplitude of the body's acceleration at excitation order `order` (rad/s²), and the
    /// locked mechanism's: every line at that order (harmonics and gravity's order 1) added as
    /// phasors; 0 when none is there.
    pub fn line(&self, order: f64) -> (f64, f64) {
        let same = |o: f64| (o - order).abs() <= 1e-12 * order.abs().max(1.0);
        let (mut a, mut l) = (C64::new(0.0, 0.0), C64::new(0.0, 0.0));
        for h in self.harmonics.iter().filter(|h| same(h.order)) {
            a += C64::from_polar(h.amplitude, h.phase);
            l += C64::from_polar(h.locked_amplitude, h.locked_phase);
        }
        if let Some(g) = self.gravity.filter(|_| same(1.0)) {
            a += C64::from_polar(g.amplitude, g.phase);
            l += C64::from_polar(g.locked_amplitude, g.locked_phase);
        }
        (a.norm(), l.norm())
    }
}

/// The lowest and highest value of `Σ a sin(k φ + p)` over the lines `(k, a, p)` (integer
/// multiples k of the base-order phase φ), sampled as [`superposed_peak`]; one line gives
/// `(−|a|, |a|)` exactly. None when a multiple is not an integer.
fn superposed_range(h: &[(f64, f64, f64)]) -> Option<(f64, f64)> {
    if let [(_, a, _)] = h {
        return Some((-a.abs(), a.abs()));
    }
    sampled_range(h)
}

/// The lowest and highest of the sampled superposition (see [`superposed_peak`]); None when a
/// multiple is not an integer.
fn sampled_range(h: &[(f64, f64, f64)]) -> Option<(f64, f64)> {
    if h.iter().any(|&(k, _, _)| (k - k.round()).abs() > 1e-12) {
        return None;
    }
    let kmax = h.iter().fold(1.0f64, |a, &(k, _, _)| a.max(k.abs()));
    let samples = PEAK_SAMPLES * kmax.ceil() as usize;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..samples {
        let phi = 2.0 * PI * i as f64 / samples as f64;
        let v: f64 = h.iter().map(|&(k, a, p)| a * (k * phi + p).sin()).sum();
        (lo, hi) = (lo.min(v), hi.max(v));
    }
    Some((lo, hi))
}

/// Peak of `Σ a sin(o ψ + p)` over the lines `(o, a, p)` (orders in the rotor angle ψ), sampled
/// over their common period: `d` revolutions, d the smallest of 1..=24 that makes every `o·d` an
/// integer, with 4096 samples per period of the highest line. None when there is no such d.
fn peak_in_rotor_angle(lines: &[(f64, f64, f64)]) -> Option<f64> {
    let d = (1..=MAX_PERIOD_REVOLUTIONS)
        .find(|&d| lines.iter().all(|&(o, _, _)| (o * d as f64 - (o * d as f64).round()).abs() <= 1e-9))?;
    let top = lines.iter().fold(1.0f64, |a, &(o, _, _)| a.max((o * d as f64).abs()));
    let samples = PEAK_SAMPLES * top.round() as usize;
    if samples > MAX_PEAK_SAMPLES {
        return None;
    }
    let span = 2.0 * PI * d as f64;
    let mut peak = 0.0f64;
    for i in 0..samples {
        let psi = span * i as f64 / samples as f64;
        let v: f64 = lines.iter().map(|&(o, a, p)| a * (o * psi + p).sin()).sum();
        peak = peak.max(v.abs());
    }
    Some(peak)
}

fn superposed_peak(h: &[(f64, f64, f64)]) -> Option<f64> {
    // max |v| over the samples, the larger of the highest and minus the lowest (same samples).
    sampled_range(h).map(|(lo, hi)| hi.max(-lo).max(0.0))
}

/// Each element's lines at one speed: the coordinate amplitudes q̂ per N·m under the weighted
/// inputs (eq. 22, one solve per input and harmonic for all coordinates), times each harmonic's
/// torque; the transmitted torque is `(k + i·kΩ·c)·q̂` at the harmonic's frequency.
fn element_lines(
    mech: &Mechanism,
    resp: &OrderResponse,
    elements: &[usize],
    base_order: f64,
    omega: f64,
    harmonics: &[Harmonic],
    dampers: bool,
) -> LinResult<Vec<ElementLines>> {
    if elements.is_empty() {
        return Ok(Vec::new());
    }
    let per_harmonic =
        harmonics.iter().map(|h| resp.coordinate_responses(h.multiple * base_order)).collect::<LinResult<Vec<_>>>()?;
    let mut out = Vec::with_capacity(elements.len());
    for &j in elements {
        let Some(c) = mech.coordinate(j) else { continue };
        let joint = &mech.joints[j];
        // A joint without spring, damper or driving mesh transmits nothing: its torque is 0.
        let law = element_law(mech, j, dampers).unwrap_or(ElementLaw { terms: Vec::new(), constant: 0.0 });
        let linear = joint.couplings.is_empty();
        let mean = resp.model.op.q[c];
        let mut e = ElementLines {
            joint: j,
            amplitude: Vec::new(),
            phase: Vec::new(),
            torque: Vec::new(),
            torque_phase: Vec::new(),
            peak: None,
            peak_torque: None,
            mean,
            range: None,
            // The dampers add nothing on average.
            mean_torque: law.at(&resp.model.op.q, &vec![0.0; resp.model.op.q.len()]),
            torque_range: None,
        };
        for (h, q) in harmonics.iter().zip(&per_harmonic) {
            let turn = if h.amplitude < 0.0 { PI } else { 0.0 };
            let qh = q[c] * h.amplitude.abs();
            e.amplitude.push(qh.norm());
            e.phase.push(h.phase + qh.arg() + turn);
            if linear {
                let w = h.multiple * base_order * omega;
                let t = law.phasor(q.as_slice(), w) * h.amplitude.abs();
                e.torque.push(t.norm());
                e.torque_phase.push(h.phase + t.arg() + turn);
            }
        }
        let lines = |a: &[f64], p: &[f64]| -> Vec<(f64, f64, f64)> {
            harmonics.iter().zip(a.iter().zip(p)).map(|(h, (&a, &p))| (h.multiple, a, p)).collect()
        };
        // One line peaks at its amplitude, exactly (and whatever its multiple).
        let peak = |l: Vec<(f64, f64, f64)>| if let [(_, a, _)] = l[..] { Some(a) } else { superposed_peak(&l) };
        e.peak = peak(lines(&e.amplitude, &e.phase));
        e.range = superposed_range(&lines(&e.amplitude, &e.phase));
        if linear {
            e.peak_torque = peak(lines(&e.torque, &e.torque_phase));
            e.torque_range = superposed_range(&lines(&e.torque, &e.torque_phase));
        }
        out.push(e);
    }
    Ok(out)
}

/// The linear steady-state response per order of `spec.body`'s angular acceleration to the
/// multi-order torque of each speed case (eq. 24 at base order `base_order`), superposing the
/// harmonics each through the frequency response at its own order, with the locked comparison
/// (Fig. 5 in the linear approximation), and with gravity its order-1 line
/// ([`SpeedResponse::gravity`]). Each speed is linearised from the previous one's equilibrium.
pub fn multi_order_response(
    mech: &Mechanism,
    spec: &ResponseSpec,
    base_order: f64,
    cases: &[SpeedCase],
    guess: Option<&[f64]>,
) -> LinResult<Vec<SpeedResponse>> {
    multi_order_response_with(mech, spec, base_order, cases, guess, &MultiOrderOptions::default())
}

/// What [`multi_order_response_with`] changes from the mechanism as built.
#[derive(Debug, Clone, Copy, Default)]
pub struct MultiOrderOptions<'a> {
    /// Modal damping of the mechanism and of its locked twin at every speed (modes with the spin
    /// free), replacing the dampers or added to them.
    pub modal: Option<(&'a ModalDamping, ModalCombination)>,
    /// The excited joints of each speed case, in the order of the cases, in place of
    /// `spec.inputs` (shares that follow the speed, such as a propeller's torque ∝ rpm²).
    pub inputs: Option<&'a [Vec<Input>]>,
    /// Joints (tree indices) whose coordinate and spring-and-damper torque are reported at every
    /// speed ([`SpeedResponse::elements`]); a joint without coordinate is skipped.
    pub elements: &'a [usize],
}

/// [`multi_order_response`] with modal damping and per-speed inputs ([`MultiOrderOptions`]).
pub fn multi_order_response_with(
    mech: &Mechanism,
    spec: &ResponseSpec,
    base_order: f64,
    cases: &[SpeedCase],
    guess: Option<&[f64]>,
    options: &MultiOrderOptions<'_>,
) -> LinResult<Vec<SpeedResponse>> {
    if let Some(inputs) = options.inputs
        && inputs.len() != cases.len()
    {
        return Err(LinearError::Invalid(format!(
            "{} input lists for {} speed cases: give one per case",
            inputs.len(),
            cases.len()
        )));
    }
    let mut guess: Option<Vec<f64>> = guess.map(<[f64]>::to_vec);
    let mut out = Vec::with_capacity(cases.len());
    for (i, case) in cases.iter().enumerate() {
        let omega = rpm_to_rad_s(case.rpm);
        let resp = match options.inputs {
            Some(inputs) => {
                let at = ResponseSpec { inputs: inputs[i].clone(), ..spec.clone() };
                OrderResponse::new(mech, &at, omega, guess.as_deref())?
            }
            None => OrderResponse::new(mech, spec, omega, guess.as_deref())?,
        };
        let mut resp = resp;
        if let Some((z, how)) = options.modal {
            resp.model = resp.model.with_modal_damping_combined(Spin::Free, z, how)?;
            resp.locked = resp.locked.with_modal_damping_combined(Spin::Free, z, how)?;
        }
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
        // Gravity's order-1 line: Re(α̂ e^{iΩt}) = |α̂| sin(Ωt + arg α̂ + π/2).
        let gravity = if resp.model.has_gravity() {
            let (a, l) = (resp.gravity_response()?, resp.gravity_locked_response()?);
            Some(GravityLine {
                amplitude: a.norm(),
                phase: a.arg() + FRAC_PI_2,
                locked_amplitude: l.norm(),
                locked_phase: l.arg() + FRAC_PI_2,
            })
        } else {
            None
        };
        let (peak, locked_peak) = match gravity {
            None => (
                superposed_peak(&harmonics.iter().map(|h| (h.multiple, h.amplitude, h.phase)).collect::<Vec<_>>()),
                superposed_peak(
                    &harmonics.iter().map(|h| (h.multiple, h.locked_amplitude, h.locked_phase)).collect::<Vec<_>>(),
                ),
            ),
            Some(g) => {
                let lines = |locked: bool| {
                    let mut v: Vec<(f64, f64, f64)> = harmonics
                        .iter()
                        .map(|h| {
                            if locked {
                                (h.order, h.locked_amplitude, h.locked_phase)
                            } else {
                                (h.order, h.amplitude, h.phase)
                            }
                        })
                        .collect();
                    v.push(if locked {
                        (1.0, g.locked_amplitude, g.locked_phase)
                    } else {
                        (1.0, g.amplitude, g.phase)
                    });
                    v
                };
                (peak_in_rotor_angle(&lines(false)), peak_in_rotor_angle(&lines(true)))
            }
        };
        // Modal damping in place of the dampers leaves them out of the transmitted torque too.
        let dampers = !matches!(options.modal, Some((_, ModalCombination::Replace)));
        let elements = element_lines(mech, &resp, options.elements, base_order, omega, &case.harmonics, dampers)?;
        out.push(SpeedResponse {
            rpm: case.rpm,
            omega,
            mean_torque: resp.model.op.mean_spin_torque,
            harmonics,
            peak,
            locked_peak,
            gravity,
            elements,
        });
    }
    Ok(out)
}
