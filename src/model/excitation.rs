//! Torque signals for order excitation: a mean torque plus order harmonics with phases, a fixed
//! order or a linear order sweep with integrated phase, and a smooth ramp-in.
//!
//! `T(t) = T_m + r(t) · Σ_k T_k · sin(k · Φ(t) + α_k)` with `Φ(t) = Ω ∫₀ᵗ n(τ) dτ`, where Ω is the
//! reference speed (rad/s, given in rpm), n the excitation order, k the harmonic multiple (1 for
//! the main order n, 2 for 2n, …) and r the cubic ramp `3x² − 2x³`, x = t / t_ramp.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Converts rpm to rad/s.
/// The cubic ramp-in factor `3x² − 2x³` at `x = t / ramp_s` (0 before t = 0, 1 from `ramp_s`
/// on, and 1 throughout when `ramp_s ≤ 0`): zero slope at both ends, so the ramp starts no step
/// transient.
#[inline]
pub fn ramp_in(t: f64, ramp_s: f64) -> f64 {
    if ramp_s <= 0.0 || t >= ramp_s {
        1.0
    } else if t <= 0.0 {
        0.0
    } else {
        let x = t / ramp_s;
        x * x * (3.0 - 2.0 * x)
    }
}

/// A speed in rpm as an angular velocity in rad/s (× 2π/60).
pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * 2.0 * PI / 60.0
}

/// The excitation order as a function of time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Order {
    /// A fixed order n (cycles per revolution).
    Fixed(f64),
    /// n(t) linear from `from` to `to` over `duration_s` seconds, then held at `to`.
    Sweep {
        /// Order at t = 0.
        from: f64,
        /// Order at t = duration_s and after.
        to: f64,
        /// Sweep time, s.
        duration_s: f64,
    },
}

impl Order {
    /// The order n(t).
    #[inline]
    pub fn at(&self, t: f64) -> f64 {
        match *self {
            Order::Fixed(n) => n,
            Order::Sweep { from, to, duration_s } => {
                if t >= duration_s {
                    to
                } else {
                    from + (to - from) * t.max(0.0) / duration_s
                }
            }
        }
    }

    /// `∫₀ᵗ n(τ) dτ` (revolutions of excitation per revolution of reference, times t): the phase
    /// must be this integral, not n(t)·t, or a sweep would excite at `n + t·ṅ` instead of n.
    #[inline]
    pub fn integral(&self, t: f64) -> f64 {
        match *self {
            Order::Fixed(n) => n * t,
            Order::Sweep { from, to, duration_s } => {
                if t <= duration_s {
                    from * t + 0.5 * (to - from) * t * t / duration_s
                } else {
                    0.5 * (from + to) * duration_s + to * (t - duration_s)
                }
            }
        }
    }
}

/// One order harmonic `T_k sin(k Φ + α_k)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Harmonic {
    /// Multiple k of the excitation order (1 = main order n, 2 = 2n, may be fractional).
    pub multiple: f64,
    /// Amplitude T_k, N·m.
    pub amplitude: f64,
    /// Phase α_k, rad.
    #[serde(default)]
    pub phase: f64,
}

/// A torque excitation (N·m) as a function of time. See the module docs for the formula.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Excitation {
    /// Mean torque T_m, N·m, applied from t = 0 (not ramped).
    #[serde(default)]
    pub mean: f64,
    /// Reference speed Ω in rpm that turns orders into frequencies (rad/s = rpm·2π/60).
    #[serde(default)]
    pub rpm: f64,
    /// Excitation order n (fixed or swept).
    #[serde(default = "default_order")]
    pub order: Order,
    /// The order harmonics.
    #[serde(default)]
    pub harmonics: Vec<Harmonic>,
    /// Duration of the cubic ramp-in of the oscillating part, s (0 = no ramp).
    #[serde(default)]
    pub ramp_s: f64,
}

fn default_order() -> Order {
    Order::Fixed(1.0)
}

impl Excitation {
    /// A constant torque, N·m.
    pub fn constant(torque: f64) -> Self {
        Self { mean: torque, rpm: 0.0, order: Order::Fixed(1.0), harmonics: Vec::new(), ramp_s: 0.0 }
    }

    /// Reference speed Ω, rad/s.
    pub fn omega(&self) -> f64 {
        rpm_to_rad_s(self.rpm)
    }

    /// The ramp factor r(t) ∈ [0, 1]: the cubic step `3x² − 2x³` (zero slope at both ends, so the
    /// ramp starts no step transient).
    #[inline]
    pub fn ramp(&self, t: f64) -> f64 {
        ramp_in(t, self.ramp_s)
    }

    /// The excitation phase Φ(t) = Ω ∫₀ᵗ n dτ, rad.
    #[inline]
    pub fn phase(&self, t: f64) -> f64 {
        self.omega() * self.order.integral(t)
    }

    /// The torque T(t), N·m.
    #[inline]
    pub fn torque(&self, t: f64) -> f64 {
        if self.harmonics.is_empty() {
            return self.mean;
        }
        let phi = self.phase(t);
        let mut osc = 0.0;
        for h in &self.harmonics {
            osc += h.amplitude * (h.multiple * phi + h.phase).sin();
        }
        self.mean + self.ramp(t) * osc
    }

    /// Checks that every number is finite and the durations are sensible; returns the name of the
    /// offending field and the problem.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let bad = |f: &str, m: &str| Err((f.to_string(), m.to_string()));
        if !self.mean.is_finite() {
            return bad("mean", "must be a finite number");
        }
        if !self.rpm.is_finite() || self.rpm < 0.0 {
            return bad("rpm", "must be a finite, non-negative speed in rpm");
        }
        if !self.harmonics.is_empty() && self.rpm == 0.0 {
            return bad("rpm", "order harmonics need a reference speed (rpm > 0)");
        }
        if !self.ramp_s.is_finite() || self.ramp_s < 0.0 {
            return bad("ramp_s", "must be a finite, non-negative duration in s");
        }
        match self.order {
            Order::Fixed(n) if !n.is_finite() => return bad("order", "must be finite"),
            Order::Sweep { from, to, duration_s } => {
                if !from.is_finite() || !to.is_finite() {
                    return bad("order", "sweep limits must be finite");
                }
                if !(duration_s.is_finite() && duration_s > 0.0) {
                    return bad("order.duration_s", "must be a finite, positive duration in s");
                }
            }
            _ => {}
        }
        for (i, h) in self.harmonics.iter().enumerate() {
            if !(h.multiple.is_finite() && h.amplitude.is_finite() && h.phase.is_finite()) {
                return bad(&format!("harmonics[{i}]"), "multiple, amplitude and phase must be finite");
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::{abs_diff_eq, assert_abs_diff_eq};

    #[test]
    fn sweep_phase_is_the_integral_of_the_order() {
        let o = Order::Sweep { from: 2.9, to: 3.3, duration_s: 240.0 };
        // Central difference of the integral gives back n(t) (exact for a quadratic).
        for &t in &[0.5, 100.0, 239.0, 300.0] {
            let d = (o.integral(t + 1e-3) - o.integral(t - 1e-3)) / 2e-3;
            assert!(abs_diff_eq!(d, o.at(t), epsilon = 1e-9), "t = {t}: {d} vs {}", o.at(t));
        }
        assert_abs_diff_eq!(o.integral(240.0), 0.5 * (2.9 + 3.3) * 240.0, epsilon = 1e-9);
    }

    #[test]
    fn ramp_is_a_smooth_cubic_step() {
        let e = Excitation { ramp_s: 2.0, ..Excitation::constant(0.0) };
        assert_eq!(e.ramp(0.0), 0.0);
        assert_eq!(e.ramp(1.0), 0.5);
        assert_eq!(e.ramp(2.0), 1.0);
        assert_abs_diff_eq!(e.ramp(0.5), 3.0 * 0.0625 - 2.0 * 0.015625, epsilon = 1e-15);
    }

    #[test]
    fn torque_is_mean_plus_harmonics() {
        let e = Excitation {
            mean: 10.0,
            rpm: 1000.0,
            order: Order::Fixed(3.0),
            harmonics: vec![
                Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 },
                Harmonic { multiple: 2.0, amplitude: 5.0, phase: -0.32 },
            ],
            ramp_s: 0.0,
        };
        let t = 0.0123;
        let w = 1000.0 * 2.0 * PI / 60.0;
        let expect = 10.0 + 40.0 * (3.0 * w * t).sin() + 5.0 * (6.0 * w * t - 0.32).sin();
        assert_abs_diff_eq!(e.torque(t), expect, epsilon = 1e-12);
    }
}
