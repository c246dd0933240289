//! The engine's torque from cylinder pressure wherever an excitation is (issue 15, item 3): in a
//! run-up (a `Transient` whose `engine` acts at the crank angle and speed of each instant) and in
//! a harmonic balance continued in speed (the forcing follows Ω along the branch). The reference
//! amplitudes are a plain DFT of `Engine::torque` over one 720° cycle, written here, not the
//! engine's own FFT series.

use approx::assert_abs_diff_eq;
use kanedyn::combustion::{Engine, EngineSpec};
use kanedyn::hbm::{ContinuationOptions, Hbm, HbmOptions, Parameter};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::study::body_accel;
use kanedyn::study::{RunOptions, Study, run};
use std::f64::consts::PI;
use std::path::Path;

/// An inline four (crank throws 0°, 180°, 180°, 0°): its reciprocating-inertia torque has order 2
/// of about 4·½ m r² Ω² = 2.4e-3 Ω² N·m, which passes its gas torque's order 2 on the way up.
const INLINE_FOUR: &str = r#"Engine(
    name: "inline_four",
    bore_m: 0.08, stroke_m: 0.09, rod_m: 0.15,
    reciprocating_mass_kg: 0.6,
    firing_order: [1, 3, 4, 2],
    pressure: Pulse(base_bar: 1.0, peak_bar: 60.0, at_deg: 14.0, width_deg: 28.0),
)"#;

/// One rigid rotor of J = 20 kg·m² on the spin joint, a small loss to ground.
const ROTOR: &str = r#"Mechanism(
    name: "rigid_rotor",
    bodies: [Body(name: "rotor", mass: 10.0, inertia: 20.0)],
    joints: [Joint(name: "spin", kind: Revolute, parent: "ground", child: "rotor", at: (0.0, 0.0))],
    loads: [GroundDamper(body: "rotor", c: 0.01)],
)"#;

const J: f64 = 20.0;
const C: f64 = 0.01;

/// A fresh folder holding the rotor and the inline four, named for the test.
fn folder(tag: &str) -> tempfile::TempDir {
    let tmp = crate::support::scratch(&format!("engine-excitation-{tag}"));
    let dir = tmp.path();
    std::fs::write(dir.join("rotor.ron"), ROTOR).unwrap();
    std::fs::write(dir.join("four.ron"), INLINE_FOUR).unwrap();
    tmp
}

fn load_engine(file: &Path) -> Engine {
    let src = Source::read_with(file, &ReadPolicy::unrestricted()).unwrap();
    Engine::new(src.parse_as::<EngineSpec>("Engine").unwrap()).unwrap()
}

/// The amplitude (N·m) and phase (rad, of `A sin(kθ + α)`) of order `k` of the engine's torque at
/// speed `omega`, by a direct DFT of `Engine::torque` over one cycle of 4π. The torque is
/// analytic in θ (the pulse is Gaussian, the slider-crank smooth), so 2048 samples resolve it to
/// rounding.
fn order_of(engine: &Engine, omega: f64, k: f64) -> (f64, f64) {
    let n = 2048;
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..n {
        let theta = 4.0 * PI * i as f64 / n as f64;
        let t = engine.torque(theta, omega);
        a += t * (k * theta).cos();
        b += t * (k * theta).sin();
    }
    let (a, b) = (2.0 * a / n as f64, 2.0 * b / n as f64);
    (a.hypot(b), a.atan2(b))
}

/// The series a run-up evaluates: with every order the engine's FFT holds, plus the mean, it is
/// the directly computed torque at any angle and speed; a phase lead shifts every harmonic of
/// `harmonics()` alike; and `split_harmonics` is its gas part plus Ω² times its inertia part.
#[test]
fn the_oscillating_series_is_the_engine_torque_at_any_speed() {
    let tmp = folder("series");
    let dir = tmp.path().to_path_buf();
    let engine = load_engine(&dir.join("four.ron"));
    let full = engine.oscillating_series(0.5, 1023.5).unwrap();
    let few = engine.oscillating_series(2.0, 8.0).unwrap();
    assert_eq!(few.orders(), vec![2.0, 4.0, 6.0, 8.0]);
    let mut worst: f64 = 0.0;
    let mut peak: f64 = 0.0;
    for rpm in [600.0, 2500.0, 6000.0] {
        let omega = rpm_to_rad_s(rpm);
        let mean = engine.orders(omega, 0.0).mean_nm;
        let (gas, per_w2) = few.split_harmonics(2.0);
        let h = few.harmonics(omega, 2.0);
        for i in 0..97 {
            let theta = 0.37 + 4.0 * PI * i as f64 / 97.0;
            let direct = engine.torque(theta, omega);
            peak = peak.max(direct.abs());
            worst = worst.max((full.torque(theta, omega, 0.0) + mean - direct).abs());
            let phase = 0.9;
            let by_harmonics: f64 =
                h.iter().map(|x| x.amplitude * (x.multiple * 2.0 * theta + x.phase + phase).sin()).sum();
            let split: f64 = gas
                .iter()
                .zip(&per_w2)
                .map(|(g, w)| {
                    let x = g.multiple * 2.0 * theta;
                    g.amplitude * (x + g.phase).sin() + omega * omega * w.amplitude * (x + w.phase).sin()
                })
                .sum();
            assert_abs_diff_eq!(few.torque(theta, omega, phase), by_harmonics, epsilon = 1e-9 * peak.max(1.0));
            assert_abs_diff_eq!(few.torque(theta, omega, 0.0), split, epsilon = 1e-9 * peak.max(1.0));
        }
    }
    println!("full series vs direct torque: {:.2e} of the peak {peak:.1} N·m", worst / peak);
    // The torque is analytic, the FFT of 4096 samples holds it to rounding; the recurrence of
    // the angles adds ~1e-13 over 2047 terms. Bound 1e-9 (the issue's).
    assert!(worst <= 1e-9 * peak, "{:e}", worst / peak);
}

/// (a) A rigid rotor run up from 1000 to 4000 rpm by the inline four: the rotor's order-2 and
/// order-4 acceleration in each block of the order–rpm map equals |T_k(Ω)|/J at the block's
/// speed, while T_2 changes several-fold over the run (a fixed amplitude would be that far off).
#[test]
fn a_run_up_follows_the_engine_orders_with_speed() {
    let tmp = folder("runup");
    let dir = tmp.path().to_path_buf();
    let study_file = dir.join("study.ron");
    std::fs::write(
        &study_file,
        r#"Study(
    name: "runup",
    mechanism: "rotor.ron",
    integration: (sample_hz: 8000.0),
    analyses: [
        Transient(name: "runup", duration_s: 120.0,
                  speed: Torque(rpm_from: 1000.0, rpm_to: 4000.0),
                  engine: (file: "four.ron", max_order: 8.0),
                  map: (samples_per_rev: 64, revs_per_block: 16, hop_revs: 16.0, max_order: 8.0, cuts: [2.0, 4.0]),
                  write_time_series: false),
        // The same engine shared out: half of it, every harmonic led by 0.7 rad.
        Transient(name: "half", duration_s: 120.0,
                  speed: Torque(rpm_from: 1000.0, rpm_to: 4000.0),
                  engine: (file: "four.ron", max_order: 8.0, excite: [(joint: "spin", scale: 0.5, phase: 0.7)]),
                  map: (samples_per_rev: 64, revs_per_block: 16, hop_revs: 16.0, max_order: 8.0, cuts: [2.0, 4.0]),
                  write_time_series: false),
    ],
)"#,
    )
    .unwrap();
    let study = Study::from_file(&study_file).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    let engine = load_engine(&dir.join("four.ron"));
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let mut worst: f64 = 0.0;
    let mut t2 = Vec::new();
    for (tr, share) in report.transient.iter().zip([1.0, 0.5]) {
        for cut in tr.cuts.iter().filter(|c| c.signal == "rotor_accel") {
            for (&rpm, &got) in tr.block_rpm.iter().zip(&cut.amplitude) {
                let (amp, _) = order_of(&engine, rpm_to_rad_s(rpm), cut.order);
                let expected = share * amp / J;
                let e = (got - expected).abs() / expected;
                worst = worst.max(e);
                if cut.order == 2.0 {
                    t2.push(amp);
                }
            }
            let n = cut.amplitude.len();
            for i in [0, n / 2, n - 1] {
                let rpm = tr.block_rpm[i];
                println!(
                    "order {} at {rpm:.1} rpm: tracked {:.6} vs |T_k|/J {:.6} rad/s²",
                    cut.order,
                    cut.amplitude[i],
                    share * order_of(&engine, rpm_to_rad_s(rpm), cut.order).0 / J
                );
            }
        }
        assert!(tr.block_rpm.len() >= 20, "{} blocks", tr.block_rpm.len());
        println!("{}: worst relative difference so far {worst:.2e} over {} blocks", tr.name, tr.block_rpm.len());
    }
    // The order-2 torque changes several-fold over the run-up: a fixed amplitude taken at either
    // end would be off by that factor somewhere along it.
    let (lo, hi) = t2.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(hi / lo > 3.0, "order-2 torque from {lo} to {hi} N·m");
    assert_eq!(report.transient.len(), 2);
    // Each block spans δ ≤ ~40 rpm of a 25 rpm/s ramp; the Hann-weighted estimate of an
    // amplitude that varies smoothly with speed differs from its value at the block's mean speed
    // in second order, ~(δ/Ω)²·(Ω² A''/A) ≲ 1e-3 at 1000 rpm, and the rotor's speed ripple
    // (|α|/(kΩ) ≈ 1e-4 of Ω with J = 20 kg·m²) shifts the inertia part by ~2e-4. The 8 kHz
    // samples keep the angle-domain resampling's own error (order 4 at 4000 rpm is 267 Hz) below
    // those. Bound 2e-3.
    assert!(worst <= 2e-3, "{worst:e}");
}

/// (b) The harmonic balance continued in speed on the rigid rotor: at every point of the branch
/// the rotor's order-2 and order-4 acceleration is the closed form `|T_k(Ω)| ω / |iωJ + c|`
/// (ω = kΩ) with T_k from the DFT at that point's speed; an `excite` share scales it.
#[test]
fn harmonic_balance_in_speed_follows_the_engine_on_a_rigid_rotor() {
    let tmp = folder("hbm_rigid");
    let dir = tmp.path().to_path_buf();
    let study_file = dir.join("study.ron");
    std::fs::write(
        &study_file,
        r#"Study(
    name: "hbm_rigid",
    mechanism: "rotor.ron",
    analyses: [
        HarmonicBalance(name: "speed", engine: "four.ron", engine_multiples: 4, harmonics: 4,
                        multiples: [1.0, 2.0],
                        parameter: Speed(order: 2.0, rpm_min: 800.0, rpm_max: 4000.0)),
        // A 0.4 share with a phase lead: 0.4 times the amplitudes.
        HarmonicBalance(name: "share", engine: "four.ron", engine_multiples: 4, harmonics: 4,
                        multiples: [1.0, 2.0], excite: [(joint: "spin", scale: 0.4, phase: 0.3)],
                        parameter: Speed(order: 2.0, rpm_min: 800.0, rpm_max: 4000.0)),
    ],
)"#,
    )
    .unwrap();
    let study = Study::from_file(&study_file).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    let engine = load_engine(&dir.join("four.ron"));
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let mut worst: f64 = 0.0;
    let mut points = 0;
    for br in &report.hbm {
        let share = if br.analysis == "share" { 0.4 } else { 1.0 };
        for (i, &rpm) in br.parameter.iter().enumerate() {
            let omega = rpm_to_rad_s(rpm);
            for (m, acc) in br.accel.iter().enumerate() {
                let k = 2.0 * (m + 1) as f64;
                let w = k * omega;
                let expected = share * order_of(&engine, omega, k).0 * w / (w * J).hypot(C);
                worst = worst.max((acc[i] - expected).abs() / expected);
            }
            points += 1;
        }
    }
    println!("{points} points, worst relative difference {worst:.2e}");
    assert!(report.hbm.iter().any(|b| b.analysis == "share"));
    assert!(points >= 20, "{points} points");
    // A linear problem: Newton's first step is exact up to the finite-difference Jacobian's
    // rounding and the second removes that; the DFT and the engine's FFT agree to rounding.
    assert!(worst <= 1e-9, "{worst:e}");
}

/// (b) On the paper's rotor-CPVA (examples/cpva.ron) driven by the inline six over 600–1800
/// rpm, continued in speed with the engine's orders 3 and 6 following Ω: at three points of the
/// branch, a harmonic balance at that fixed speed with the orders typed in (what a MultiOrder
/// analysis's harmonic balance does; amplitudes and phases from the DFT here), started from the
/// branch's state (the absorber has coexisting states near 1256 rpm), gives the same rotor
/// acceleration.
#[test]
fn harmonic_balance_in_speed_matches_fixed_speed_solves_on_the_cpva() {
    let study = Study::from_file(Path::new("examples/engine_cpva.ron")).unwrap_or_else(|e| panic!("{e}"));
    let engine = load_engine(Path::new("examples/engines/inline_six.ron"));
    let kane = Kane::new(&study.mechanism).unwrap();
    let series = engine.oscillating_series(3.0, 6.0).unwrap();
    let (gas, per_w2) = series.split_harmonics(3.0);
    let (lo, hi) = (rpm_to_rad_s(600.0), rpm_to_rad_s(1800.0));
    let mut hbm =
        Hbm::with_speed_forcing(&kane, study.spin, lo, &gas, &per_w2, &[(study.spin, 1.0, 0.0)], HbmOptions::default())
            .unwrap();
    let branch =
        hbm.continue_in(Parameter::Speed { order: 3.0 }, lo, hi, None, &ContinuationOptions::default()).unwrap();
    let p = &branch.points;
    let n = p.len();
    assert!(n >= 5, "{n} points");
    let path = study.mechanism.rotation_rates(study.body);
    let mut worst: f64 = 0.0;
    for i in [n / 6, n / 2, 5 * n / 6] {
        let sol = &p[i].solution;
        let omega = sol.omega;
        let harmonics: Vec<Harmonic> = [3.0, 6.0]
            .iter()
            .map(|&k| {
                let (amplitude, phase) = order_of(&engine, omega, k);
                Harmonic { multiple: k / 3.0, amplitude, phase }
            })
            .collect();
        let mut fixed = Hbm::new(&kane, study.spin, omega, &harmonics, HbmOptions::default()).unwrap();
        let at_speed = fixed.solve(3.0, Some(sol)).unwrap();
        for m in [1.0, 2.0] {
            let (a, b) = (body_accel(sol, &path, m), body_accel(&at_speed, &path, m));
            let e = (a - b).abs() / b;
            println!(
                "{:.2} rpm, order {}: branch {a:.6} vs fixed speed {b:.6} rad/s² ({e:.1e})",
                omega * 30.0 / PI,
                3.0 * m
            );
            worst = worst.max(e);
        }
    }
    // Both solve the same equations to Newton's tolerance (1e-10 rad on the coefficients of
    // ~1e-2 rad); the brief's bound for an independent route is 5e-3, this one far tighter: 1e-7.
    assert!(worst <= 1e-7, "{worst:e}");
}

/// (c) What cannot be honoured is refused at load, located in the study file (line:column and
/// field) or in the engine file.
#[test]
fn bad_engine_excitations_are_located() {
    let tmp = folder("bad");
    let dir = tmp.path().to_path_buf();
    let case = |analysis: &str| -> String {
        let file = dir.join("study.ron");
        std::fs::write(
            &file,
            format!("Study(\n    name: \"bad\",\n    mechanism: \"rotor.ron\",\n    analyses: [\n        {analysis},\n    ],\n)"),
        )
        .unwrap();
        match Study::from_file(&file) {
            Ok(_) => panic!("accepted: {analysis}"),
            Err(e) => e.to_string(),
        }
    };
    let transient = |engine: &str, speed: &str| {
        format!("Transient(name: \"t\", duration_s: 10.0, speed: {speed}, engine: {engine})")
    };
    let torque = "Torque(rpm_from: 1000.0, rpm_to: 2000.0)";
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            transient("(file: \"four.ron\", order: 1.3)", torque),
            vec!["study.ron:5:", "field `analyses[0].engine.order`", "multiple of ½"],
        ),
        (transient("(file: \"four.ron\", max_order: 0.25)", torque), vec!["field `analyses[0].engine.max_order`"]),
        (
            transient("(file: \"four.ron\", max_order: 65.0)", torque),
            vec!["field `analyses[0].engine.max_order`", "≤ 64"],
        ),
        (
            transient("(file: \"missing.ron\")", torque),
            vec!["field `analyses[0].engine.file`", "cannot read", "missing.ron"],
        ),
        (
            transient("(file: \"four.ron\", excite: [(joint: \"crank\")])", torque),
            vec!["field `analyses[0].engine.excite[0].joint`", "unknown joint `crank`"],
        ),
        (
            transient("(file: \"four.ron\")", "Prescribed(rpm_from: 1000.0, rpm_to: 2000.0)"),
            vec!["field `analyses[0].engine`", "prescribed"],
        ),
        (
            "HarmonicBalance(name: \"h\", engine: \"four.ron\", amplitudes: [10.0], \
             parameter: Speed(order: 2.0, rpm_min: 800.0, rpm_max: 4000.0))"
                .into(),
            vec!["field `analyses[0].amplitudes`", "not both"],
        ),
        (
            "HarmonicBalance(name: \"h\", engine: \"four.ron\", rpm: 1000.0, order_min: 1.9, order_max: 2.1)".into(),
            vec!["field `analyses[0].engine`", "Speed"],
        ),
        (
            "HarmonicBalance(name: \"h\", engine: \"four.ron\", \
             parameter: Speed(order: 0.7, rpm_min: 800.0, rpm_max: 4000.0))"
                .into(),
            vec!["field `analyses[0].parameter`", "multiple of ½"],
        ),
        (
            "HarmonicBalance(name: \"h\", engine: \"four.ron\", engine_multiples: 11, \
             parameter: Speed(order: 2.0, rpm_min: 800.0, rpm_max: 4000.0))"
                .into(),
            vec!["field `analyses[0].engine_multiples`", "harmonics = 10"],
        ),
    ];
    for (analysis, expect) in &cases {
        let msg = case(analysis);
        for e in expect {
            assert!(msg.contains(e), "`{e}` not in: {msg}");
        }
    }
    // An engine file that cannot be built is located in the engine file.
    std::fs::write(dir.join("short_rod.ron"), INLINE_FOUR.replace("rod_m: 0.15", "rod_m: 0.04")).unwrap();
    let msg = case(&transient("(file: \"short_rod.ron\")", torque));
    assert!(msg.contains("short_rod.ron:") && msg.contains("field `rod_m`"), "{msg}");
}
