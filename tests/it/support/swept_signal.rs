//! The synthetic signals of tests/it/order_tracking.rs, shared with its timing driver
//! benches/order_tracking.rs (included there with `#[path]`).

use kanedyn::model::excitation::{Order, rpm_to_rad_s};

/// Sample rate of the synthetic signals, Hz.
pub const FS: f64 = 2000.0;

/// Sample times `i / FS` over `duration_s`, s.
pub fn times(duration_s: f64) -> Vec<f64> {
    (0..(duration_s * FS).round() as usize).map(|i| i as f64 / FS).collect()
}

/// The swept signal of load case 4.1 (§4.1, eq. 23) with a second multiple:
/// `0.7 + A₁(n) sin Φ + A₂(n) sin(2Φ − 0.32)`, Φ = Ω ∫n dt as `Order::integral` computes it,
/// n from 2.9 to 3.3 over 240 s at 1000 rpm, the rotor turning at exactly Ω.
/// Returns the order, Ω (rad/s), the samples and the rotor angle θ at each sample (rad).
pub fn swept_signal(a1: impl Fn(f64) -> f64, a2: impl Fn(f64) -> f64) -> (Order, f64, Vec<f64>, Vec<f64>) {
    let order = Order::Sweep { from: 2.9, to: 3.3, duration_s: 240.0 };
    let omega = rpm_to_rad_s(1000.0);
    let t = times(240.0);
    let x = t
        .iter()
        .map(|&t| {
            let (n, phi) = (order.at(t), omega * order.integral(t));
            0.7 + a1(n) * phi.sin() + a2(n) * (2.0 * phi - 0.32).sin()
        })
        .collect();
    let theta = t.iter().map(|&t| omega * t).collect();
    (order, omega, x, theta)
}
