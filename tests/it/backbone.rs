//! Backbones with a free rotor (issue 28, item 4): the `FreeOscillation` analysis with
//! `spin: Free` and `spin: Held` on the paper's absorber, against closed forms that share
//! nothing with either of its routes (continuation of free orbits by harmonic balance, time
//! integration):
//!
//! - the small-amplitude limit with a free rotor is the rotor eigen-order n_r of the paper's
//!   eq. (17), written out here from the mechanism's parameters;
//! - at every amplitude the free-rotor pendulum is one degree of freedom once the angular
//!   momentum H and the energy are fixed, so its order is a quadrature (below);
//! - at held spin the pendulum is a plain pendulum: order / n_t = π / (2K(sin(A/2))), K by the
//!   arithmetic–geometric mean.

use crate::support::scratch;
use kanedyn::study::{FreeOscillationResult, LoadOptions, RunOptions, Study, StudyReport, run};
use std::f64::consts::PI;

/// Loads `analyses` on the examples' mechanism `mechanism` (the study read as if it were
/// `examples/<tag>.ron`).
fn load(tag: &str, mechanism: &str, analyses: &str) -> Study {
    let text = format!(
        "Study(name: \"{tag}\", mechanism: \"{mechanism}\", spin_joint: \"spin\", response_body: \"rotor\", \
         analyses: [{analyses}])"
    );
    let src = kanedyn::io::Source::from_text(&format!("examples/{tag}.ron"), &text);
    Study::from_source(src, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `analyses` as [`load`] reads them.
fn run_free(tag: &str, mechanism: &str, analyses: &str) -> (Study, StudyReport) {
    let study = load(tag, mechanism, analyses);
    let out = scratch("backbone");
    let report = run(&study, &RunOptions { out: Some(out.path().to_path_buf()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    (study, report)
}

/// The paper's parameters read off the mechanism `examples/cpva.ron` builds: rotor inertia I_A
/// about its centre, pendulum mass m, centroidal inertia I_B, pivot radius R and pivot-to-centre
/// distance L (SI).
struct Params {
    i_a: f64,
    m: f64,
    i_b: f64,
    r: f64,
    l: f64,
}

fn params(study: &Study) -> Params {
    let mech = &study.mechanism;
    let body = |name: &str| mech.bodies.iter().find(|b| b.name == name).unwrap();
    let (rotor, pendulum) = (body("rotor"), body("pendulum"));
    let pivot = mech.joints.iter().find(|j| j.name == "pivot").unwrap();
    // Body frames start at their inboard joint: the rotor's on the axis, the pendulum's at Q.
    assert_eq!(rotor.inertia.com.norm(), 0.0, "the rotor's centre is on the axis");
    Params {
        i_a: rotor.inertia.i_com,
        m: pendulum.inertia.mass,
        i_b: pendulum.inertia.i_com,
        r: pivot.at.norm(),
        l: pendulum.inertia.com.norm(),
    }
}

/// Eq. (17): n_r² = n_t² (Ĩ + 2n_t² + 1) / (Ĩ − n_t⁴), with n_t² = m R L / (I_B + m L²)
/// (eq. 15) and Ĩ = (I_A + m R²) / (I_B + m L²) (eq. 18).
fn n_r_eq17(p: &Params) -> (f64, f64, f64) {
    let k = p.i_b + p.m * p.l * p.l;
    let nt2 = p.m * p.r * p.l / k;
    let it = (p.i_a + p.m * p.r * p.r) / k;
    ((nt2 * (it + 2.0 * nt2 + 1.0) / (it - nt2 * nt2)).sqrt(), nt2.sqrt(), it)
}

/// The free-rotor order at release amplitude A by quadrature. With rotor angle θ and pendulum
/// angle φ relative to it, T = ½(I(φ)θ̇² + 2J(φ)θ̇φ̇ + Kφ̇²), I = I_A + mR² + K + 2mRL cos φ,
/// J = K + mRL cos φ, K = I_B + mL². H = Iθ̇ + Jφ̇ and E = H²/2I + ½(K − J²/I)φ̇² are conserved;
/// released from rest at A, φ̇² = H² (1/I(A) − 1/I(φ)) / (K − J²/I). Over one period the rotor
/// turns Δθ = ∮(H − Jφ̇)/I dt = 4H ∫₀^A dφ / (I φ̇) (the ∮ J/I dφ of a closed swing is zero), and
/// the order is ω / mean speed = 2π/Δθ; H cancels. With sin(φ/2) = sin(A/2) sin ψ the root
/// singularity at A goes (1/I(A) − 1/I(φ) = 2mRL(cos φ − cos A)/(I(A) I(φ))):
///
/// order = π / (2 ∫₀^{π/2} √((K − J²/I) I(A) / (I m R L)) / cos(φ/2) dψ).
///
/// The integrand is smooth and even about both ends, so the trapezoid rule converges faster
/// than any power: 4000 panels are exact to rounding.
fn order_by_quadrature(p: &Params, a: f64) -> f64 {
    let k = p.i_b + p.m * p.l * p.l;
    let c = p.m * p.r * p.l;
    let inertia = |phi: f64| p.i_a + p.m * p.r * p.r + k + 2.0 * c * phi.cos();
    let s = (a / 2.0).sin();
    let f = |psi: f64| {
        let phi = 2.0 * (s * psi.sin()).asin();
        let (i, j) = (inertia(phi), k + c * phi.cos());
        ((k - j * j / i) * inertia(a) / (i * c)).sqrt() / (phi / 2.0).cos()
    };
    let n = 4000;
    let h = PI / 2.0 / n as f64;
    let sum: f64 = (0..=n).map(|i| f(i as f64 * h) * if i == 0 || i == n { 0.5 } else { 1.0 }).sum();
    PI / (2.0 * sum * h)
}

/// π / (2K(k)) = AGM(1, √(1 − k²)) (quadratic convergence: 8 steps are exact to rounding).
fn pi_over_2k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    for _ in 0..8 {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    a
}

const DEG30: f64 = PI / 6.0;
const DEG60: f64 = PI / 3.0;
const DEG90: f64 = PI / 2.0;

fn amplitudes() -> String {
    [1e-5, DEG30, DEG60, DEG90].map(|a| format!("{a:?}")).join(", ")
}

/// Free rotor: the backbone starts at n_r of eq. (17) (3.1908861 for the canonical parameters)
/// to 1e-8, equals the quadrature at 30°, 60° and 90° to 1e-8, the continuation and the time
/// route agree to 1e-7, and the time runs conserve the angular momentum.
///
/// Tolerances: at A = 1e-5 rad the backbone lies below n_r by about 0.07·A²·n_r ≈ 2e-11 (the
/// ratio is 0.923 at 60°, quadratic in A), so 1e-8 tests the start; the continuation keeps 24
/// harmonics, whose dropped tail at 90° is below 1e-12, and Newton stops at steps of 1e-12; the
/// time route's Hermite crossings err by ~(2π/128)⁴/384 ≈ 1.5e-8 of a period at each end of
/// 8 periods (2e-9 relative), at rtol 1e-12; DOP853 at rtol 1e-12 keeps the invariant to ~1e-11.
#[test]
fn free_rotor_backbone_starts_at_eq_17_and_agrees_with_the_quadrature_and_the_time_route() {
    let analyses = format!(
        r#"FreeOscillation(name: "free", rpm: 1000.0, joint: "pivot", spin: Free, amplitudes: [{}])"#,
        amplitudes()
    );
    let (study, report) = run_free("bb_free", "cpva.ron", &analyses);
    let r: &FreeOscillationResult = &report.free[0];
    let p = params(&study);
    let (n_r, n_t, i_tilde) = n_r_eq17(&p);
    println!("Ĩ = {i_tilde:.9}, n_t = {n_t:.10}, n_r (eq. 17) = {n_r:.10}");
    // The canonical design values (Ĩ = 2255, n_t = 3.11) and the issue's n_r.
    assert!((i_tilde - 2255.0).abs() < 1e-8 && (n_t - 3.11).abs() < 1e-12, "{i_tilde} {n_t}");
    assert!((n_r - 3.1908861).abs() < 5e-8, "{n_r}");
    println!(
        "linear order {:.10} (off eq. 17 by {:.1e}), backbone at 1e-5 rad {:.10} (off by {:.1e})",
        r.linear_order,
        (r.linear_order - n_r).abs(),
        r.orders[0],
        (r.orders[0] - n_r).abs()
    );
    assert!((r.linear_order - n_r).abs() <= 1e-8, "linear order {} vs eq. (17) {n_r}", r.linear_order);
    assert!((r.orders[0] - n_r).abs() <= 1e-8, "backbone start {} vs eq. (17) {n_r}", r.orders[0]);
    for (k, &a) in r.amplitudes.iter().enumerate() {
        let want = order_by_quadrature(&p, a);
        println!(
            "A = {:.2}°: continuation {:.10} (off the quadrature {want:.10} by {:.1e}), time {:.10}; routes \
             differ by {:.1e}, momentum drift {:.1e}",
            a.to_degrees(),
            r.orders[k],
            (r.orders[k] - want).abs(),
            r.time_orders[k],
            r.route_difference[k],
            r.momentum_drift[k]
        );
        assert!((r.orders[k] - want).abs() <= 1e-8, "A = {a}: {} vs quadrature {want}", r.orders[k]);
        assert!(r.route_difference[k] <= 1e-7, "A = {a}: routes differ by {:e}", r.route_difference[k]);
        assert!((r.orders[k] - r.time_orders[k]).abs() == r.route_difference[k]);
        assert!(r.momentum_drift[k] <= 1e-9, "A = {a}: angular momentum drifts by {:e}", r.momentum_drift[k]);
    }
    // The quadrature's own small-amplitude limit is eq. (17): the two closed forms agree.
    assert!((order_by_quadrature(&p, 1e-6) - n_r).abs() <= 1e-10);
    // Softening: the order falls with amplitude, below the held spin's at no amplitude.
    assert!(r.orders.windows(2).all(|w| w[1] < w[0]));
}

/// Held spin keeps the plain pendulum's π/(2K(sin(A/2))) to 1e-9 of the order ratio; the two
/// routes agree to 1e-7; no momentum is reported (the holding torque changes it).
#[test]
fn held_spin_backbone_is_the_plain_pendulum() {
    let analyses =
        format!(r#"FreeOscillation(name: "held", rpm: 1000.0, joint: "pivot", amplitudes: [{}])"#, amplitudes());
    let (study, report) = run_free("bb_held", "cpva.ron", &analyses);
    let r = &report.free[0];
    let (_, n_t, _) = n_r_eq17(&params(&study));
    assert!((r.linear_order - n_t).abs() <= 1e-9, "{} vs n_t {n_t}", r.linear_order);
    for (k, &a) in r.amplitudes.iter().enumerate() {
        let want = pi_over_2k((a / 2.0).sin());
        let got = r.orders[k] / n_t;
        println!(
            "A = {:.2}°: order / n_t = {got:.12}, closed form {want:.12} (off by {:.1e}), routes differ by {:.1e}",
            a.to_degrees(),
            (got - want).abs(),
            r.route_difference[k]
        );
        assert!((got - want).abs() <= 1e-9, "A = {a}: {got} vs {want}");
        assert!(r.route_difference[k] <= 1e-7, "A = {a}: routes differ by {:e}", r.route_difference[k]);
        assert!(r.momentum_drift[k].is_nan());
    }
}

/// `examples/cpva_maps.ron`: the free-rotor backbone of the two pendulums in unison at 30°, 60°
/// and 90° is the single pendulum's (the quadrature of the paper's rotor, to 1e-8), both routes
/// agree to 1e-7, and the forced branches are drawn with it.
#[test]
fn the_maps_example_shows_the_free_rotor_backbone() {
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva_maps.ron"))
        .unwrap()
        .replace("name: \"cpva_maps\"", "name: \"bb_maps\"");
    let src = kanedyn::io::Source::from_text("examples/bb_maps.ron", &text);
    let study = Study::from_source(src, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch("backbone-maps");
    let out = tmp.path();
    let report = run(&study, &RunOptions { out: Some(out.to_path_buf()), progress: false }).unwrap();
    let svg = std::fs::read_to_string(out.join("bb_maps/forced_backbone.svg")).unwrap();
    assert!(svg.contains("backbone `backbone` (free rotor, pivot_1)"));
    let r = report.free.iter().find(|r| r.name == "backbone").unwrap();
    let single = r#"FreeOscillation(name: "f", rpm: 1000.0, joint: "pivot", amplitudes: [0.5])"#;
    let p = params(&load("bb_single", "cpva.ron", single));
    assert!((r.linear_order - n_r_eq17(&p).0).abs() <= 1e-8);
    for a in [DEG30, DEG60, DEG90] {
        let k = r.amplitudes.iter().position(|&x| (x - a).abs() < 1e-15).unwrap_or_else(|| panic!("{a} missing"));
        let want = order_by_quadrature(&p, a);
        println!("maps backbone at {:.0}°: {:.10} (quadrature {want:.10})", a.to_degrees(), r.orders[k]);
        assert!((r.orders[k] - want).abs() <= 1e-8);
        assert!(r.route_difference[k] <= 1e-7 && r.momentum_drift[k] <= 1e-9);
    }
}

/// Bad input is refused where it is written, naming the field: an unknown joint, an amplitude
/// ≤ 0 or beyond the top (π for a pivot), no harmonics, `spin: Free` on a mechanism something
/// acts on from outside, and a backbone overlay naming no earlier `FreeOscillation`.
#[test]
fn bad_backbones_are_refused_with_their_field() {
    let good = r#"FreeOscillation(name: "f", rpm: 1000.0, joint: "pivot", spin: Free, amplitudes: [0.5])"#;
    let forced = r#"HarmonicBalance(name: "h", rpm: 1000.0, order_min: 3.0, order_max: 3.2, amplitudes: [40.0], backbone: Some("f"))"#;
    let load = |mechanism: &str, analyses: &str| {
        let text = format!(
            "Study(name: \"bad\", mechanism: \"{mechanism}\", spin_joint: \"spin\", response_body: \"rotor\", \
             analyses: [{analyses}])"
        );
        Study::from_source(kanedyn::io::Source::from_text("examples/bad_backbone.ron", &text), &LoadOptions::default())
    };
    load("cpva.ron", &format!("{good}, {forced}")).unwrap_or_else(|e| panic!("{e}"));
    for (from, to, field) in [
        ("joint: \"pivot\"", "joint: \"pivt\"", "analyses[0].joint"),
        ("[0.5]", "[0.5, 0.0]", "analyses[0].amplitudes[1]"),
        ("[0.5]", "[-0.5]", "analyses[0].amplitudes[0]"),
        ("[0.5]", "[3.2]", "analyses[0].amplitudes[0]"),
        ("spin: Free", "spin: Free, harmonics: 0", "analyses[0].harmonics"),
    ] {
        let bad = good.replace(from, to);
        let e = load("cpva.ron", &bad).expect_err(to).to_string();
        println!("{e}");
        assert!(e.contains(field) && e.contains("bad_backbone.ron:"), "{to}: {e}");
    }
    let e = load("cpva.ron", &format!("{forced}, {good}")).expect_err("backbone before").to_string();
    assert!(e.contains("analyses[0].backbone") && e.contains("no FreeOscillation named `f`"), "{e}");
    // A point force on the pendulum acts from outside: no free rotor (the held spin is fine).
    let tmp = scratch("backbone-bad");
    let dir = tmp.path();
    let cpva = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva.ron"))
        .unwrap()
        .replace(
            "GroundDamper(body: \"rotor\", c: 5e-3),",
            "GroundDamper(body: \"rotor\", c: 5e-3),\n PointForce(body: \"pendulum\", at: (0.01, 0.0), force: (0.0, -1.0), frame: Body),",
        );
    std::fs::write(dir.join("pushed.ron"), cpva).unwrap();
    let study = |spin: &str| {
        let text = format!(
            "Study(name: \"bad\", mechanism: \"pushed.ron\", spin_joint: \"spin\", response_body: \"rotor\", \
             analyses: [FreeOscillation(name: \"f\", rpm: 1000.0, joint: \"pivot\", spin: {spin}, amplitudes: [0.5])])"
        );
        std::fs::write(dir.join("s.ron"), text).unwrap();
        Study::from_file(&dir.join("s.ron"))
    };
    let e = study("Free").expect_err("free with a point force").to_string();
    assert!(e.contains("analyses[0].spin") && e.contains("s.ron:") && e.contains("point force"), "{e}");
    study("Held").unwrap_or_else(|e| panic!("{e}"));
}
