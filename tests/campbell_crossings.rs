//! The resonance table of a Campbell diagram: every crossing of an order line with a mode,
//! located by bisection on the eigen-orders. Reference: a branched drivetrain of coaxial discs on
//! torsion shafts with the spin held, whose natural frequencies do not depend on speed and follow
//! in closed form (tests/support/branched.rs), so order n crosses mode i at exactly
//! `rpm = 60 f_i / n`.

#[path = "support/branched.rs"]
mod branched;

use branched::{J_B, J_C, K_A, K_B, K_C, closed_form_rad_s, drivetrain};
use kanedyn::linear::{Damping, Spin, campbell};
use std::f64::consts::PI;

/// Natural frequencies with the hub held, Hz, ascending ([`closed_form_rad_s`]).
fn closed_form_hz() -> Vec<f64> {
    closed_form_rad_s().iter().map(|w| w / (2.0 * PI)).collect()
}

#[test]
fn every_order_line_crossing_is_listed_where_the_closed_form_puts_it() {
    let mech = drivetrain("JointRates", false);
    let f = closed_form_hz();
    println!("closed-form frequencies {f:?} Hz");
    let (rpm_min, rpm_max) = (100.0, 6000.0);
    let rpm: Vec<f64> = (0..60).map(|i| rpm_min + (rpm_max - rpm_min) * i as f64 / 59.0).collect();
    let orders = [1.0, 2.0, 3.0, 6.0, 12.0];
    let c = campbell(&mech, "spin", &rpm, &orders, Spin::Held, Damping::Undamped, None, None).unwrap();

    // Modes in frequency order at every speed, each equal to the closed form to 1e-9 (the
    // operating point and the eigen-solver work near rounding here).
    assert_eq!(c.tracks.len(), 3);
    for (t, tr) in c.tracks.iter().enumerate() {
        for (i, &fi) in tr.frequency_hz.iter().enumerate() {
            assert!((fi - f[t]).abs() <= 1e-9 * f[t], "mode {t} at {} rpm: {fi} vs {}", rpm[i], f[t]);
            if t > 0 {
                assert!(c.tracks[t - 1].frequency_hz[i] < fi);
            }
        }
    }
    // Labels by where the potential energy is: the branch-b mode twists shaft b only; a chain
    // mode has disc angles x_c/x_a = k_c/(k_c − ω²J_c) (second row of (K − ω²M)x = 0), so its
    // strain energies are ½k_a x_a² in shaft a and ½k_c (x_c − x_a)² in shaft c.
    let wb = (K_B / J_B).sqrt() / (2.0 * PI);
    for (t, &fi) in f.iter().enumerate() {
        let expect = if (fi - wb).abs() < 1e-9 * wb {
            "shaft_b"
        } else {
            let w2 = (2.0 * PI * fi).powi(2);
            let ratio = K_C / (K_C - w2 * J_C);
            if K_A > K_C * (ratio - 1.0).powi(2) { "shaft_a" } else { "shaft_c" }
        };
        assert_eq!(c.tracks[t].label, expect, "mode {t} at {fi} Hz");
    }

    // Every crossing inside the range, and nothing else.
    let mut expected = Vec::new();
    for (t, &fi) in f.iter().enumerate() {
        for &n in &orders {
            let r = 60.0 * fi / n;
            if r > rpm_min && r <= rpm_max {
                expected.push((n, t, r));
            }
        }
    }
    assert_eq!(c.crossings.len(), expected.len(), "{:?}", c.crossings);
    for (n, t, r) in expected {
        let x = c.crossings.iter().find(|x| x.order == n && x.track == t).expect("crossing listed");
        let e = (x.rpm - r).abs() / r;
        println!("order {n} × mode {} ({}): {:.6} rpm vs {r:.6} ({e:.1e})", t + 1, x.label, x.rpm);
        // Issue 13 asks for 1e-6; the bisection stops at 1e-9 and the eigen-orders are exact to
        // ~1e-10 here (measured ≤ 4.3e-10).
        assert!(e <= 1e-6, "order {n}, mode {t}: {} vs {r}", x.rpm);
        assert!((x.frequency_hz - f[t]).abs() <= 1e-6 * f[t]);
    }
    assert!(c.crossings.windows(2).all(|w| w[0].rpm <= w[1].rpm), "listed by speed");
}
