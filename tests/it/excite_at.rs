//! Excitation at any joint (`excite` of the analyses) against the closed form of a linear
//! drivetrain: a hub spinning free on ground and a flywheel on a torsionally elastic shaft
//! (spring k, damper c) with a viscous loss c_r to ground. The bodies sit on the axis, so nothing
//! depends on the speed and the equations are linear in the coordinates θ (hub) and φ (shaft
//! twist), the flywheel turning at θ + φ:
//!
//! `(J_h + J_r) θ̈ + J_r φ̈ + c_r (θ̇ + φ̇) = T_spin`,
//! `J_r θ̈ + J_r φ̈ + c φ̇ + k φ + c_r (θ̇ + φ̇) = T_shaft`
//!
//! (a torque at the shaft joint acts on the flywheel and back on the hub: it does work on φ
//! alone). The flywheel's angular acceleration per unit torque at ω follows from the 2 × 2
//! complex system; the linear response, the harmonic balance and the multi-order time runs of a
//! study exciting the shaft joint (and the spin and shaft joints together, with a share and a
//! phase) must all give it.

use crate::support::scratch;
use kanedyn::study::{RunOptions, Study, run};
use nalgebra::Complex as Cx;

type C = Cx<f64>;
use std::f64::consts::PI;

const J_H: f64 = 0.5;
const J_R: f64 = 3.0;
const K: f64 = 5.0e4;
const C_S: f64 = 2.0;
const C_R: f64 = 5e-3;

const MECHANISM: &str = r#"Mechanism(
    name: "shaft",
    speeds: AbsoluteAngularVelocities,
    bodies: [Body(name: "hub", mass: 20.0, inertia: 0.5), Body(name: "rotor", mass: 100.0, inertia: 3.0)],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft", parent: "hub", child: "rotor", spring: (stiffness: 5.0e4), damper: 2.0),
    ],
    loads: [GroundDamper(body: "rotor", c: 5e-3)],
)"#;

const STUDY: &str = r#"Study(
    name: "excite",
    mechanism: "m.ron",
    analyses: [
        LinearResponse(name: "shaft_only", rpm: 1000.0, from: 2.0, to: 4.5, points: 26, relative: false,
                       excite: [(joint: "shaft")]),
        LinearResponse(name: "both", rpm: 1000.0, from: 2.0, to: 4.5, points: 26, relative: false,
                       excite: [(joint: "spin"), (joint: "shaft", scale: 0.5, phase: 0.3)]),
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.5, order_max: 3.0, amplitudes: [50.0],
                        harmonics: 3, excite: [(joint: "shaft")]),
        OrderSweep(name: "sweep", rpm: 1000.0, order_min: 2.0, order_max: 2.8, duration_s: 40.0, amplitudes: [50.0],
                   directions: [Up], excite: [(joint: "shaft")]),
        MultiOrder(name: "multi", order: 3.0, excite: [(joint: "shaft")], min_time_s: 10.0, max_time_s: 60.0, hbm: true,
                   speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 50.0), (multiple: 2.0, amplitude: 20.0, phase: 0.4)])]),
    ],
)"#;

/// The shaft's twist φ̂ (rad, complex) for torques `t_spin`, `t_shaft` at ω (rad/s).
fn closed_form_twist(w: f64, t_spin: C, t_shaft: C) -> C {
    let i = C::new(0.0, 1.0);
    let (a, b) = (-w * w * (J_H + J_R) + i * w * C_R, -w * w * J_R + i * w * C_R);
    let d = -w * w * J_R + i * w * (C_S + C_R) + K;
    (a * t_shaft - b * t_spin) / (a * d - b * b)
}

/// The flywheel's angular acceleration (rad/s², complex) for torques `t_spin`, `t_shaft` (N·m,
/// complex amplitudes) at ω (rad/s).
fn closed_form(w: f64, t_spin: C, t_shaft: C) -> C {
    let i = C::new(0.0, 1.0);
    let (a, b) = (-w * w * (J_H + J_R) + i * w * C_R, -w * w * J_R + i * w * C_R);
    let d = -w * w * J_R + i * w * (C_S + C_R) + K;
    let det = a * d - b * b;
    let theta = (t_spin * d - b * t_shaft) / det;
    let phi = (a * t_shaft - b * t_spin) / det;
    -w * w * (theta + phi)
}

#[test]
fn torques_at_any_joint_give_the_closed_form_in_every_analysis() {
    let tmp = scratch("excite-at");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), MECHANISM).unwrap();
    std::fs::write(dir.join("s.ron"), STUDY).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let omega = 1000.0 * PI / 30.0;
    let one = C::new(1.0, 0.0);
    let zero = C::new(0.0, 0.0);

    // Linear response per N·m: the model is linearised numerically around its operating point,
    // but a drivetrain with its bodies on the axis has nothing to linearise; measured 2e-14.
    let mut worst: f64 = 0.0;
    for (k, weights) in [(0, (zero, one)), (1, (one, C::from_polar(0.5, 0.3)))] {
        let v = &report.linear[k].variants[0];
        for (&n, &r) in v.orders.iter().zip(&v.response) {
            let expected = closed_form(n * omega, weights.0, weights.1).norm();
            worst = worst.max((r - expected).abs() / expected);
        }
    }
    println!("linear response vs closed form: {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");
    // The shaft's twist per N·m and the torque its spring and damper transmit, (k + iωc)·φ̂,
    // for the torque at the shaft alone: φ̂ from the same 2 × 2 system.
    let v = &report.linear[0].variants[0];
    let e = &v.elements[0];
    assert_eq!(e.joint, "shaft");
    let mut worst: f64 = 0.0;
    for (i, &n) in v.orders.iter().enumerate() {
        let phi = closed_form_twist(n * omega, zero, one);
        let torque = (C::new(K, n * omega * C_S) * phi).norm();
        worst = worst.max((e.amplitude[i] - phi.norm()).abs() / phi.norm());
        worst = worst.max((e.torque[i] - torque).abs() / torque);
    }
    println!("linear shaft twist and torque vs closed form: {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");

    // Harmonic balance of a linear system: the main-order amplitude is |H|·T at every point of
    // the branch (Newton converged to ~1e-12; measured 4e-15).
    let b = &report.hbm[0];
    let mut worst: f64 = 0.0;
    // `accel` holds one series per reported multiple, the main order first.
    for (n, acc) in b.order.iter().zip(&b.accel[0]) {
        let expected = closed_form(n * omega, zero, C::new(50.0, 0.0)).norm();
        worst = worst.max((acc - expected).abs() / expected);
    }
    println!("harmonic balance vs closed form over {} points: {worst:.1e}", b.order.len());
    assert!(!b.order.is_empty() && worst <= 1e-8, "{worst:e}");

    // An order sweep 2.0 → 2.8 in 40 s at the shaft, below its resonance (order 3.23 at 1000
    // rpm): quasi-static, each window's amplitude is |H(n)|·T at the window's order up to the
    // sweep's smear over one 2 s window (0.04 orders) and the ramp-in; measured 4e-4 after 4 s.
    let run = report.sweeps.iter().find(|r| r.analysis == "sweep").unwrap();
    let tr = run.trace(1.0).unwrap();
    let mut worst: f64 = 0.0;
    for ((&t, &n), &a) in tr.time_s.iter().zip(&tr.order).zip(&tr.amplitude) {
        if !(4.0..=38.0).contains(&t) {
            continue;
        }
        let expected = closed_form(n * omega, zero, C::new(50.0, 0.0)).norm();
        worst = worst.max((a - expected).abs() / expected);
    }
    println!("order sweep vs closed form: {worst:.1e}");
    assert!(worst <= 5e-3, "{worst:e}");

    // Multi-order at 1000 rpm, orders 3 and 6 at the shaft: each harmonic through its own H.
    let s = &report.multi[0].speeds[0];
    let expected = [
        closed_form(3.0 * omega, zero, C::new(50.0, 0.0)).norm(),
        closed_form(6.0 * omega, zero, C::new(20.0, 0.0)).norm(),
    ];
    let linear = s.linear.as_ref().unwrap();
    let time = &s.response.as_ref().unwrap().amplitudes;
    let hbm = &s.hbm[0].amplitudes;
    for m in 0..2 {
        let e = |v: f64| (v - expected[m]).abs() / expected[m];
        println!(
            "multi-order {}×: linear {:.1e}, harmonic balance {:.1e}, time run {:.1e} (of {:.4} rad/s²)",
            m + 1,
            e(linear[m]),
            e(hbm[m]),
            e(time[m]),
            expected[m]
        );
        assert!(e(linear[m]) <= 1e-9 && e(hbm[m]) <= 1e-8);
        // The time run's order tracking over a 4 s window of a steady state (the 5-bin Hann sum
        // of a line on a whole number of cycles); measured 1e-7. Bound 1e-5.
        assert!(e(time[m]) <= 1e-5, "{}", e(time[m]));
    }
}

#[test]
fn a_bad_excite_entry_is_located() {
    let tmp = scratch("excite-bad");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), MECHANISM).unwrap();
    for (entry, words) in [
        (r#"(joint: "nope")"#, "unknown joint"),
        (r#"(joint: "shaft", scale: 1e9)"#, "analyses[0].excite[0].scale"),
        (r#"(joint: "shaft"), (joint: "shaft")"#, "listed twice"),
    ] {
        let text = format!(
            "Study(name: \"s\", mechanism: \"m.ron\",\n analyses: [LinearResponse(name: \"l\", rpm: 1000.0, from: 2.0, to: 4.0, relative: false, excite: [{entry}])])"
        );
        std::fs::write(dir.join("s.ron"), text).unwrap();
        let e = Study::from_file(&dir.join("s.ron")).map(|_| ()).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains("s.ron:2:") && e.contains("analyses[0].excite[") && e.contains(words), "{e}");
    }
}
