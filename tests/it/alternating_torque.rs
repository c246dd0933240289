//! Issue 49, item 9: a shaft's alternating torque beside its largest absolute torque. A rotor
//! driven at constant mean speed turns a disk through a shaft; both drag on ground dampers, so
//! the shaft carries a large mean torque (the disk's drag `−c₂Ω`) under a small order torque at
//! the rotor. In closed form the steady state is the rigid rotation plus the 2-DOF response of
//! the absolute angles' deviations x₁, x₂ to `T sin(nΩt)` at the rotor:
//! `[k − ω²J₁ + iωc₁, −k; −k, k − ω²J₂ + iωc₂] x̂ = (T, 0)`, the shaft torque's alternating
//! amplitude is `k |x̂₂ − x̂₁|`, its mean `−c₂Ω` (`k q̄` with the twist `q̄ = −c₂Ω/k`), and so its
//! largest departure from the mean (`alt_max`) is the amplitude and its largest absolute value
//! (`max_abs`) `c₂Ω + k |x̂₂ − x̂₁|`.

use crate::support::scratch;
use kanedyn::study::{RunOptions, Study, run};
use nalgebra::{Complex, Matrix2, Vector2};
use std::f64::consts::PI;

const J1: f64 = 1.0;
const J2: f64 = 2.0;
const K: f64 = 1.0e4;
const C1: f64 = 5.0;
const C2: f64 = 20.0;
const RPM: f64 = 600.0;
const TORQUE: f64 = 50.0;

const MECHANISM: &str = r#"Mechanism(
    name: "rotor_disk",
    bodies: [Body(name: "rotor", inertia: 1.0), Body(name: "disk", inertia: 2.0)],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "shaft", parent: "rotor", child: "disk", spring: (stiffness: 1.0e4)),
    ],
    loads: [GroundDamper(body: "rotor", c: 5.0), GroundDamper(body: "disk", c: 20.0)],
)"#;

/// The shaft torque's alternating amplitude at order `n` of 600 rpm, N·m (closed form above).
fn amplitude(n: f64) -> f64 {
    let w = n * RPM * PI / 30.0;
    let c = |re: f64, im: f64| Complex::new(re, im);
    let z = Matrix2::new(c(K - w * w * J1, w * C1), c(-K, 0.0), c(-K, 0.0), c(K - w * w * J2, w * C2));
    let x = z.lu().solve(&Vector2::new(c(TORQUE, 0.0), c(0.0, 0.0))).unwrap();
    K * (x[1] - x[0]).norm()
}

/// The alternating and absolute maxima of the shaft torque equal the closed form in the three
/// steady routes: the linear multi-order response and harmonic balance to 1e-9 relative (both
/// exact for this linear plant up to rounding and the Newton tolerance), and the steady time run
/// to 1e-6 (its amplitudes settle to `steady_tol` = 1e-7 between windows, and its extremes are
/// samples refined between them by cubic interpolation, whose error at the default 2 kHz, about
/// 130 samples per period of order 1.5 at 600 rpm, is of order (2π/130)⁴/384 ≈ 1e-8 of the
/// amplitude).
/// The CSV carries the same numbers as results.json, and the summary's element table names both.
#[test]
fn alternating_and_absolute_torque_maxima_equal_the_closed_form() {
    let tmp = scratch("alternating");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), MECHANISM).unwrap();
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "m.ron", spin_joint: "spin", response_body: "rotor", elements: ["shaft"],
    analyses: [
        HarmonicBalance(name: "h", rpm: 600.0, order_min: 1.4, order_max: 1.6, amplitudes: [50.0]),
        MultiOrder(name: "m", order: 1.5, multiples: [1.0], window_s: 1.0, min_time_s: 10.0, max_time_s: 120.0,
                   steady_tol: 1e-7, speeds: [(rpm: 600.0, harmonics: [(multiple: 1.0, amplitude: 50.0)])]),
    ])"#,
    )
    .unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let mean = -C2 * RPM * PI / 30.0;
    let check = |e: &kanedyn::study::ElementResponse, n: f64, tol: f64, what: &str| {
        let t = e.torque.as_ref().expect("a spring").range;
        let alt = amplitude(n);
        println!(
            "{what} at n = {n}: mean {:.9e} ({mean:.9e}), alt max {:.9e} ({alt:.9e}), max abs {:.9e}",
            t.mean, t.alt_max, t.max_abs
        );
        assert!((t.mean - mean).abs() <= tol * mean.abs(), "{what}: mean {}", t.mean);
        assert!((t.alt_max - alt).abs() <= tol * alt, "{what}: alt max {} vs {alt}", t.alt_max);
        let abs = mean.abs() + alt;
        assert!((t.max_abs - abs).abs() <= tol * abs, "{what}: max abs {} vs {abs}", t.max_abs);
    };
    let b = &report.hbm[0];
    assert!(b.order.len() > 3, "{:?}", b.order);
    for (n, point) in b.order.iter().zip(&b.elements) {
        check(&point[0], *n, 1e-9, "harmonic balance");
    }
    let speed = &report.multi[0].speeds[0];
    check(&speed.linear_elements[0], 1.5, 1e-9, "linear");
    let steady = &speed.response.as_ref().expect("a time run").elements[0];
    check(steady, 1.5, 1e-6, "time run");

    // The CSV and results.json carry the same numbers; the summary names both maxima.
    let csv = std::fs::read_to_string(dir.join("out/s/m.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<f64> = lines.next().unwrap().split(',').map(|x| x.parse().unwrap()).collect();
    let col = |name: &str| row[head.iter().position(|h| *h == name).unwrap_or_else(|| panic!("{name}: {head:?}"))];
    let t = steady.torque.as_ref().unwrap().range;
    assert_eq!(col("shaft_torque_alt_max_Nm"), t.alt_max);
    assert_eq!(col("shaft_torque_max_abs_Nm"), t.max_abs);
    let lt = speed.linear_elements[0].torque.as_ref().unwrap().range;
    assert_eq!(col("linear_shaft_torque_alt_max_Nm"), lt.alt_max);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/s/results.json")).unwrap()).unwrap();
    let text = json.to_string();
    assert!(text.contains("\"alt_max\""), "results.json has no alt_max");
    let summary = std::fs::read_to_string(dir.join("out/s/summary.md")).unwrap();
    assert!(summary.contains("alt max"), "{summary}");
}
