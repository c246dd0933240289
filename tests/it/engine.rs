//! Engine torque from cylinder pressure (`kanedyn::combustion`) against closed forms written here:
//! the slider-crank's piston travel, the indicated work as ∮p dV, the order cancellation of an
//! inline six and the classical first-order reciprocating-inertia amplitudes.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::combustion::{Engine, EngineSpec, Pressure};
use std::f64::consts::PI;

fn spec(cylinders: Vec<usize>, stroke: f64, rod: f64, mass: f64, pressure: Pressure) -> EngineSpec {
    EngineSpec {
        name: "test".into(),
        bore_m: 0.13,
        stroke_m: stroke,
        rod_m: rod,
        reciprocating_mass_kg: mass,
        firing_order: cylinders,
        offsets_deg: None,
        pressure,
    }
}

fn pulse() -> Pressure {
    Pressure::Pulse { base_bar: 1.0, peak_bar: 150.0, at_deg: 12.0, width_deg: 28.0 }
}

/// The order series of an inline six (gas and inertia at 1500 rpm) evaluated between its
/// samples equals the torque computed directly: the pulse is smooth, so its orders decay like
/// e^{−(order·width)²/2} and the 2048 orders of the transform hold it to rounding.
#[test]
fn the_order_series_reproduces_the_torque() {
    let e = Engine::new(spec(vec![1, 5, 3, 6, 2, 4], 0.16, 0.26, 2.5, pulse())).unwrap();
    let omega = 1500.0 * PI / 30.0;
    let series = e.orders(omega, 1000.0);
    let mut worst: f64 = 0.0;
    let mut peak: f64 = 0.0;
    for k in 0..997 {
        let theta = 4.0 * PI * (k as f64 + 0.37) / 997.0;
        let direct = e.torque(theta, omega);
        peak = peak.max(direct.abs());
        worst = worst.max((series.torque(theta) - direct).abs());
    }
    println!("series vs direct: {:.1e} of the peak {peak:.1} N·m", worst / peak);
    assert!(worst <= 1e-9 * peak);
}

/// The mean gas torque is the indicated work per cycle over 4π, with the work ∮p dV summed here
/// over the volume the piston sweeps, V = A·x(θ), x from the slider-crank written out.
#[test]
fn the_mean_gas_torque_is_the_indicated_work_over_four_pi() {
    let (stroke, rod, bore) = (0.16, 0.26, 0.13);
    let e = Engine::new(spec(vec![1, 5, 3, 6, 2, 4], stroke, rod, 0.0, pulse())).unwrap();
    let (r, l) = (0.5 * stroke, rod);
    let area = 0.25 * PI * bore * bore;
    let x = |t: f64| r * (1.0 - t.cos()) + l - (l * l - r * r * t.sin().powi(2)).sqrt();
    // ∮ p dV by the midpoint rule in V over 10⁶ steps of one cylinder's cycle (error ~1e-11).
    let steps = 1_000_000;
    let mut work = 0.0;
    for i in 0..steps {
        let (t0, t1) = (4.0 * PI * i as f64 / steps as f64, 4.0 * PI * (i + 1) as f64 / steps as f64);
        work += e.pressure(0.5 * (t0 + t1)) * area * (x(t1) - x(t0));
    }
    let expected = 6.0 * work / (4.0 * PI);
    let mean = e.orders(0.0, 24.0).mean_nm;
    println!("mean gas torque {mean:.9} N·m, indicated work / 4π {expected:.9} N·m");
    assert_abs_diff_eq!(mean, expected, epsilon = 1e-8 * expected.abs());
}

/// An inline six firing 1-5-3-6-2-4 every 120°: the cylinders' torques sum to a function of
/// period 120°, so every order that is not a multiple of 3 cancels (gas and inertia alike).
#[test]
fn an_inline_six_keeps_only_the_multiples_of_three() {
    let e = Engine::new(spec(vec![1, 5, 3, 6, 2, 4], 0.16, 0.26, 2.5, pulse())).unwrap();
    let series = e.orders(1800.0 * PI / 30.0, 24.0);
    let largest = series.harmonics.iter().fold(0.0f64, |m, h| m.max(h.amplitude));
    let (mut kept, mut cancelled) = (0.0f64, 0.0f64);
    for h in &series.harmonics {
        let order = 0.5 * h.multiple;
        if (order / 3.0 - (order / 3.0).round()).abs() < 1e-9 {
            kept = kept.max(h.amplitude);
        } else {
            cancelled = cancelled.max(h.amplitude);
        }
    }
    println!("largest order {largest:.3} N·m; largest not a multiple of 3: {:.1e} of it", cancelled / largest);
    assert!(kept == largest && cancelled <= 1e-12 * largest, "{cancelled:e}");
    assert!(series.amplitude(3.0) > 0.1 * largest && series.amplitude(6.0) > 0.0);
    // A single cylinder keeps every half order.
    let one = Engine::new(spec(vec![1], 0.16, 0.26, 2.5, pulse())).unwrap().orders(1800.0 * PI / 30.0, 24.0);
    assert!(one.amplitude(0.5) > 1e-3 * one.amplitude(1.0) && one.amplitude(1.5) > 0.0);
}

/// One cylinder's reciprocating-inertia torque: to first order in λ = r/l its amplitudes in
/// orders 1, 2 and 3 are λ/4, 1/2 and 3λ/4 times m r² Ω²; at λ = 0.01 the next terms are
/// O(λ²) relative, so 1e-3 holds. Its exact series at λ = 0.3 reproduces the torque.
#[test]
fn reciprocating_inertia_has_the_classical_orders() {
    let (m, omega, r) = (2.0, 2000.0 * PI / 30.0, 0.08);
    let zero = Pressure::Pulse { base_bar: 0.0, peak_bar: 0.0, at_deg: 0.0, width_deg: 10.0 };
    let e = Engine::new(spec(vec![1], 2.0 * r, r / 0.01, m, zero.clone())).unwrap();
    let series = e.orders(omega, 10.0);
    let unit = m * r * r * omega * omega;
    for (order, expected) in [(1.0, 0.01 / 4.0), (2.0, 0.5), (3.0, 3.0 * 0.01 / 4.0)] {
        let got = series.amplitude(order) / unit;
        println!("order {order}: {got:.6e} vs {expected:.6e}");
        assert!(abs_diff_eq!(got, expected, epsilon = 1e-3 * expected), "order {order}: {got} vs {expected}");
    }
    assert_abs_diff_eq!(series.mean_nm, 0.0, epsilon = 1e-12 * unit);
    let e = Engine::new(spec(vec![1], 2.0 * r, r / 0.3, m, zero)).unwrap();
    let series = e.orders(omega, 1000.0);
    let worst = (0..500)
        .map(|k| 4.0 * PI * (k as f64 + 0.5) / 500.0)
        .map(|t| (series.torque(t) - e.inertia_torque(t, omega)).abs())
        .fold(0.0, f64::max);
    println!("λ = 0.3: series vs direct {:.1e} of m r² Ω²", worst / unit);
    assert!(worst <= 1e-9 * unit);
}

#[test]
fn bad_engines_are_refused_with_the_field() {
    let cases: Vec<(EngineSpec, &str)> = vec![
        (spec(vec![1, 2, 2], 0.16, 0.26, 1.0, pulse()), "firing_order[2]"),
        (spec(vec![1], 0.16, 0.05, 1.0, pulse()), "rod_m"),
        (spec(vec![1], -0.16, 0.26, 1.0, pulse()), "stroke_m"),
        (spec(vec![1], 0.16, 0.26, f64::NAN, pulse()), "reciprocating_mass_kg"),
        (spec(vec![1], 0.16, 0.26, 1.0, Pressure::Table(vec![(0.0, 1.0); 3])), "pressure"),
        (
            spec(vec![1], 0.16, 0.26, 1.0, Pressure::Table((0..10).map(|i| (80.0 * i as f64, 1.0)).collect())),
            "pressure",
        ),
    ];
    for (s, field) in cases {
        let (f, m) = Engine::new(s).unwrap_err();
        println!("{f}: {m}");
        assert!(f.starts_with(field), "{f} vs {field}");
    }
}

/// A measured cycle given as a table: the periodic spline through a smooth curve's samples gives
/// the same mean torque as the curve itself (to the spline's O(h⁴) accuracy at 2° steps).
#[test]
fn a_pressure_table_follows_its_curve() {
    let curve = Engine::new(spec(vec![1], 0.16, 0.26, 0.0, pulse())).unwrap();
    let table: Vec<(f64, f64)> =
        (0..360).map(|i| (2.0 * i as f64, curve.pressure((2.0 * i as f64).to_radians()) / 1e5)).collect();
    let tabled = Engine::new(spec(vec![1], 0.16, 0.26, 0.0, Pressure::Table(table))).unwrap();
    let (a, b) = (curve.orders(0.0, 50.0), tabled.orders(0.0, 50.0));
    println!("mean torque: curve {:.6} N·m, table {:.6} N·m", a.mean_nm, b.mean_nm);
    assert_abs_diff_eq!(a.mean_nm, b.mean_nm, epsilon = 1e-4 * a.mean_nm.abs());
    assert_abs_diff_eq!(a.amplitude(0.5), b.amplitude(0.5), epsilon = 1e-4 * a.amplitude(0.5));
}

/// Issue 29, item 6: for each pressure form (the Gaussian `Pulse`, and a measured-style `Table`
/// through the periodic spline) the engine's order torques T_k at a speed equal a direct DFT of
/// its own torque over the 720° cycle written here, harmonic by harmonic, to 1e-10 of the
/// largest. T(θ) = mean + Σ_j A_j sin(jθ/2 + φ_j) gives A_j sin φ_j = (2/N) Σ T cos(jθ_i/2) and
/// A_j cos φ_j = (2/N) Σ T sin(jθ_i/2) over N equally spaced θ_i; N = 16384 keeps the DFT's own
/// aliasing below 1e-13 for both (the pulse's orders decay like a Gaussian, the cubic spline's
/// like j⁻⁴ from a table at 1° steps).
#[test]
fn each_pressure_form_s_orders_equal_a_dft_of_its_torque() {
    let table: Vec<(f64, f64)> = (0..720)
        .map(|i| {
            let deg = i as f64;
            // A compression-and-firing shape: a peak after TDC on a polytropic-like background.
            let x = (deg - 10.0 + 360.0).rem_euclid(720.0) - 360.0;
            (deg, 1.0 + 120.0 * (-0.5 * (x / 25.0).powi(2)).exp() + 8.0 * (deg.to_radians() / 2.0).cos().powi(2))
        })
        .collect();
    for (form, pressure) in [("Pulse", pulse()), ("Table", Pressure::Table(table))] {
        let e = Engine::new(spec(vec![1, 5, 3, 6, 2, 4], 0.16, 0.26, 2.5, pressure)).unwrap();
        let omega = 1200.0 * PI / 30.0;
        let series = e.orders(omega, 12.0);
        let n = 16384;
        let samples: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let theta = 4.0 * PI * i as f64 / n as f64;
                (theta, e.torque(theta, omega))
            })
            .collect();
        let mean = samples.iter().map(|s| s.1).sum::<f64>() / n as f64;
        let largest = series.harmonics.iter().map(|h| h.amplitude).fold(0.0, f64::max);
        assert!(
            abs_diff_eq!(series.mean_nm, mean, epsilon = 1e-10 * largest),
            "{form}: mean {} vs {mean}",
            series.mean_nm
        );
        let mut worst: f64 = 0.0;
        for h in &series.harmonics {
            // Multiple j of order ½ (order j/2): the argument is j θ/2.
            let j = h.multiple;
            let (mut c, mut s) = (0.0, 0.0);
            for &(theta, t) in &samples {
                let (sn, cs) = (j * theta / 2.0).sin_cos();
                c += t * cs;
                s += t * sn;
            }
            let (c, s) = (2.0 * c / n as f64, 2.0 * s / n as f64);
            let err = (h.amplitude * h.phase.sin() - c).hypot(h.amplitude * h.phase.cos() - s);
            worst = worst.max(err);
        }
        println!(
            "{form}: {} harmonics, largest {largest:.3} N·m, worst {:.1e} of it",
            series.harmonics.len(),
            worst / largest
        );
        assert!(series.harmonics.len() >= 20, "{form}");
        assert!(worst <= 1e-10 * largest, "{form}: worst {worst} N·m");
    }
}
