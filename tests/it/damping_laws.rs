//! Issue 29, items 2 and 6, in studies: modal damping added to the joint dampers in LinearResponse
//! and in MultiOrder's linear part, amplitude laws in speed for an excited joint, and a
//! MultiOrder driven by an engine reporting its order torques T_k per speed.
//!
//! References written here: a 2-DOF shaft (hub and rotor discs on the axis, spin free) as
//! `(−ω²M + iωC + K) x = F` in the absolute disc angles, with `C = C_dampers + C_modal` and
//! `C_modal = M Φ diag(2ζω) Φᵀ M` from this test's own eigen-solve of (M, K); and the engine's
//! order torques by a plain DFT of `Engine::torque` over its 720° cycle.

use crate::support::scratch;
use approx::{assert_abs_diff_eq, assert_relative_eq};
use kanedyn::combustion::{Engine, EngineSpec};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::study::{AmplitudeLaw, RunOptions, Study, StudyReport, run};
use nalgebra::{Complex, DMatrix, DVector, SymmetricEigen};
use std::f64::consts::PI;
use tempfile::TempDir;

type C = Complex<f64>;

const J_H: f64 = 0.5;
const J_R: f64 = 3.0;
const K: f64 = 5.0e4;
const C_S: f64 = 2.0;
const ZETA: f64 = 0.004;

/// Hub on the spin joint, rotor on a damped torsion shaft; both on the axis (no centrifugal or
/// Coriolis terms), so the linear model about any speed is the textbook 2-DOF shaft.
const SHAFT: &str = r#"Mechanism(
    name: "shaft",
    speeds: AbsoluteAngularVelocities,
    bodies: [Body(name: "hub", mass: 20.0, inertia: 0.5), Body(name: "rotor", mass: 100.0, inertia: 3.0)],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft", parent: "hub", child: "rotor", spring: (stiffness: 5.0e4), damper: 2.0),
    ],
)"#;

fn folder(tag: &str) -> TempDir {
    scratch(&format!("damping-laws-{tag}"))
}

fn run_study(dir: &std::path::Path, text: &str) -> StudyReport {
    std::fs::write(dir.join("s.ron"), text).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    report
}

/// The rotor's angular acceleration (complex, rad/s²) per N·m on the hub at ω (rad/s), for a
/// shaft damper `c_shaft` plus modal ratio `zeta` on the one vibration mode, by hand.
fn hand_response(w: f64, c_shaft: f64, zeta: f64, torque_at_shaft: bool) -> C {
    let m = DMatrix::from_diagonal(&DVector::from_vec(vec![J_H, J_R]));
    let k = DMatrix::from_row_slice(2, 2, &[K, -K, -K, K]);
    let c_d = DMatrix::from_row_slice(2, 2, &[c_shaft, -c_shaft, -c_shaft, c_shaft]);
    // Mass-normalised modes from M^{-1/2} K M^{-1/2}; the rigid mode (ω = 0) takes no damping.
    let m_half_inv = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0 / J_H.sqrt(), 1.0 / J_R.sqrt()]));
    let eig = SymmetricEigen::new(&m_half_inv * &k * &m_half_inv);
    let mut c_m = DMatrix::zeros(2, 2);
    for i in 0..2 {
        let w2 = eig.eigenvalues[i];
        if w2 > 1e-6 {
            let mphi = &m * (&m_half_inv * eig.eigenvectors.column(i));
            c_m += (2.0 * zeta * w2.sqrt()) * &mphi * mphi.transpose();
        }
    }
    let c = &c_d + &c_m;
    let a: DMatrix<C> = DMatrix::from_fn(2, 2, |i, j| C::new(-w * w * m[(i, j)] + k[(i, j)], w * c[(i, j)]));
    // A torque on the shaft joint acts on the rotor and reacts on the hub.
    let f = if torque_at_shaft {
        DVector::from_vec(vec![C::new(-1.0, 0.0), C::new(1.0, 0.0)])
    } else {
        DVector::from_vec(vec![C::new(1.0, 0.0), C::new(0.0, 0.0)])
    };
    let x = a.lu().solve(&f).unwrap();
    -w * w * x[1]
}

/// LinearResponse, MultiOrder's linear part and Campbell with modal damping added to the
/// dampers: the response equals the hand-built `(−ω²M + iωC + K)⁻¹` with
/// `C = C_dampers + C_modal`, for the mechanism's damper and for a damper variant (allowed beside
/// Add), and with Replace the ratio alone; the modes table and the Campbell tracks carry
/// ζ + c·ω_n/(2K). The model of a drivetrain on its axis has nothing to linearise, so what remains is the
/// two eigen-solves and the 2 × 2 solve: measured 1.0e-14 (LinearResponse) and 1.4e-15
/// (MultiOrder), bound 1e-9 relative. The modes table's damped ratio is ζ + c·ω_n/(2K) in closed
/// form (measured to 1e-12 digits printed; bound 1e-9).
#[test]
fn added_modal_damping_matches_the_hand_built_damping_matrix() {
    let tmp = folder("add");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), SHAFT).unwrap();
    let report = run_study(
        &dir,
        r#"Study(name: "add", mechanism: "m.ron", analyses: [
    LinearResponse(name: "lin", rpm: 1000.0, from: 2.0, to: 4.0, points: 9, relative: false,
                   modal_damping: All(0.004), modal_combination: Add,
                   variants: [(label: "as built", dampers: []), (label: "c5", dampers: [("shaft", 5.0)])]),
    LinearResponse(name: "replaced", rpm: 1000.0, from: 2.0, to: 4.0, points: 9, relative: false,
                   modal_damping: All(0.004)),
    MultiOrder(name: "multi", order: 3.0, time_domain: false, linear: true, multiples: [1.0, 2.0],
               modal_damping: All(0.004), modal_combination: Add,
               speeds: [(rpm: 800.0, harmonics: [(multiple: 1.0, amplitude: 50.0), (multiple: 2.0, amplitude: 20.0)]),
                        (rpm: 1100.0, harmonics: [(multiple: 1.0, amplitude: 50.0), (multiple: 2.0, amplitude: 20.0)])]),
    Campbell(name: "campbell", rpm_min: 0.0, rpm_max: 2000.0, points: 5, orders: [3.0],
             modal_damping: All(0.004), modal_combination: Add),
])"#,
    );
    let omega = 1000.0 * PI / 30.0;
    let mut worst: f64 = 0.0;
    for (v, c_shaft) in report.linear[0].variants.iter().zip([C_S, 5.0]) {
        for (&n, &r) in v.orders.iter().zip(&v.response) {
            let want = hand_response(n * omega, c_shaft, ZETA, false).norm();
            worst = worst.max((r - want).abs() / want);
        }
    }
    // Replace: the shaft damper is gone, the ratio alone remains.
    for (&n, &r) in report.linear[1].variants[0].orders.iter().zip(&report.linear[1].variants[0].response) {
        let want = hand_response(n * omega, 0.0, ZETA, false).norm();
        worst = worst.max((r - want).abs() / want);
    }
    println!("LinearResponse (Add, two variants; Replace) vs hand-built C: {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");
    // Near the resonance (order 3 at 1000 rpm is 0.92 of ω_n) adding matters: the two differ.
    let at3 = |k: usize| report.linear[k].variants[0].response[4];
    assert!((at3(0) - at3(1)).abs() > 1e-3 * at3(1), "{} vs {}", at3(0), at3(1));

    let mut worst: f64 = 0.0;
    for s in &report.multi[0].speeds {
        let lin = s.linear.as_ref().unwrap();
        for (k, (m, t)) in [(1.0, 50.0), (2.0, 20.0)].into_iter().enumerate() {
            let w = m * 3.0 * s.rpm * PI / 30.0;
            let want = t * hand_response(w, C_S, ZETA, false).norm();
            worst = worst.max((lin[k] - want).abs() / want);
        }
    }
    println!("MultiOrder linear part (Add) vs hand-built C: {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");

    // The summary says which damping is in force, in words and in the modes table.
    assert!(
        report
            .summary
            .contains("- modal damping: ζ = 0.004 for every vibration mode (added to the mechanism's dampers)"),
        "{}",
        report.summary
    );
    assert!(report.summary.contains("| free | dampers + modal |"), "{}", report.summary);
    assert!(report.summary.contains("Modal damping of the linear columns: ζ = 0.004"), "{}", report.summary);
    // The damped free mode's ratio in that table is the hand-built state matrix's −Re λ/|λ|.
    let row = report.linear[0].modes.iter().find(|m| !m.spin_held && m.damped && m.order > 0.0).unwrap();
    let wn2 = K * (1.0 / J_H + 1.0 / J_R);
    // One vibration mode, so C_modal = 2ζω_n M φ φᵀ M acts on it alone: its modal damping is
    // 2ζω_n plus the damper's c·(φ_h − φ_r)² = c·ω_n²/K, i.e. ζ_total = ζ + c·ω_n/(2K).
    let zeta_total = ZETA + C_S * wn2.sqrt() / (2.0 * K);
    println!("free damped mode: ζ {:.12} vs ζ + cω_n/(2K) = {zeta_total:.12}", row.damping_ratio);
    assert_relative_eq!(row.damping_ratio, zeta_total, max_relative = 1e-9);
    // The Campbell diagram with the same damping: that ratio at every speed (nothing on the axis
    // depends on speed), and the damped frequency ω_n √(1 − ζ²).
    let c = &report.campbell[0];
    assert_eq!(c.tracks.len(), 1);
    let f_d = wn2.sqrt() * (1.0 - zeta_total * zeta_total).sqrt() / (2.0 * PI);
    for (&z, &f) in c.tracks[0].damping_ratio.iter().zip(&c.tracks[0].frequency_hz) {
        assert_relative_eq!(z, zeta_total, max_relative = 1e-9);
        assert_relative_eq!(f, f_d, max_relative = 1e-9);
    }
    assert!(
        report.summary.contains(
            "Modal damping: ζ = 0.004 for every vibration mode (added to the mechanism's dampers; damped frequencies)."
        ),
        "{}",
        report.summary
    );
}

/// Amplitude laws in speed: ∝ rpm² gives the factor (rpm/rpm_ref)² exactly in the law and, the
/// response being linear in the torque, the same factor between a constant and an rpm² share at
/// every speed (1e-12: the two runs differ by that factor only, rounding of one product); a
/// table interpolates linearly (0.5 → 2 over 500 → 1500 rpm gives 1.25 at 1000); a speed outside
/// a table, or a law in an analysis that does not take one, is a located error.
#[test]
fn amplitude_laws_scale_the_excited_share_with_speed() {
    let rpm2 = AmplitudeLaw::Rpm2 { reference_rpm: 1000.0 };
    assert_eq!(rpm2.factor(2000.0), Some(4.0));
    assert_eq!(rpm2.factor(1000.0), Some(1.0));
    let table = AmplitudeLaw::Table(vec![(500.0, 0.5), (1500.0, 2.0), (2000.0, 2.0)]);
    assert_abs_diff_eq!(table.factor(1000.0).unwrap(), 1.25, epsilon = 1e-15);
    assert_eq!(table.factor(1750.0), Some(2.0));
    assert_eq!(table.factor(2000.0), Some(2.0));
    assert_eq!(table.factor(499.0), None);

    let tmp = folder("laws");

    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), SHAFT).unwrap();
    let speeds = r#"speeds: [(rpm: 700.0, harmonics: [(multiple: 1.0, amplitude: 50.0)]),
                        (rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 50.0)]),
                        (rpm: 1400.0, harmonics: [(multiple: 1.0, amplitude: 50.0)])]"#;
    let report = run_study(
        &dir,
        &format!(
            r#"Study(name: "laws", mechanism: "m.ron", analyses: [
    MultiOrder(name: "constant", order: 5.0, time_domain: false, multiples: [1.0], excite: [(joint: "shaft")], {speeds}),
    MultiOrder(name: "rpm2", order: 5.0, time_domain: false, multiples: [1.0],
               excite: [(joint: "shaft", law: Rpm2(reference_rpm: 1000.0))], {speeds}),
    MultiOrder(name: "table", order: 5.0, time_domain: false, multiples: [1.0],
               excite: [(joint: "shaft", scale: 2.0, law: Table([(500.0, 0.5), (1500.0, 2.0)]))], {speeds}),
    LinearResponse(name: "lin_rpm2", rpm: 1400.0, from: 4.0, to: 6.0, points: 5, relative: false,
                   excite: [(joint: "shaft", law: Rpm2(reference_rpm: 1000.0))]),
])"#
        ),
    );
    let (constant, rpm2, table) = (&report.multi[0], &report.multi[1], &report.multi[2]);
    let mut worst: f64 = 0.0;
    for ((c, r), t) in constant.speeds.iter().zip(&rpm2.speeds).zip(&table.speeds) {
        let (c, r, t, rpm) =
            (c.linear.as_ref().unwrap()[0], r.linear.as_ref().unwrap()[0], t.linear.as_ref().unwrap()[0], c.rpm);
        // The constant share against the closed form (the torque on the shaft joint).
        let want = 50.0 * hand_response(5.0 * rpm * PI / 30.0, C_S, 0.0, true).norm();
        worst = worst.max((c - want).abs() / want);
        let factor = (rpm / 1000.0f64).powi(2);
        println!("{rpm} rpm: rpm² share / constant = {:.15} (want {factor})", r / c);
        assert_relative_eq!(r / c, factor, max_relative = 1e-12);
        let interp = 2.0 * (0.5 + 1.5 * (rpm - 500.0) / 1000.0);
        assert_relative_eq!(t / c, interp, max_relative = 1e-12);
    }
    println!("constant share vs closed form: {worst:.1e}");
    assert!(worst <= 1e-9, "{worst:e}");
    // Between two speeds the rpm² response scales as (rpm₂/rpm₁)² times the transfer's ratio.
    let ratio = |k: usize| rpm2.speeds[k].linear.as_ref().unwrap()[0] / constant.speeds[k].linear.as_ref().unwrap()[0];
    assert_relative_eq!(ratio(2) / ratio(0), (1400.0f64 / 700.0).powi(2), max_relative = 1e-12);
    // The summaries give the share in force.
    assert!(report.summary.contains("| 1400 | 1.960000 |"), "{}", report.summary);
    assert!(
        report
            .summary
            .contains("- excitation share at `shaft` at 1400 rpm: 1.960000 (1 × 1.960000 by its law in speed)"),
        "{}",
        report.summary
    );
    // LinearResponse at 1400 rpm: per N·m times (1400/1000)².
    let v = &report.linear[0].variants[0];
    for (&n, &r) in v.orders.iter().zip(&v.response) {
        let want = 1.96 * hand_response(n * 1400.0 * PI / 30.0, C_S, 0.0, true).norm();
        assert_relative_eq!(r, want, max_relative = 1e-9);
    }

    // Located refusals: a speed outside the table, a falling table, a law where none is taken.
    let base = |analysis: &str| format!("Study(name: \"bad\", mechanism: \"m.ron\", analyses: [\n    {analysis}])");
    for (name, analysis, words) in [
        (
            "outside.ron",
            format!(
                r#"MultiOrder(name: "t", order: 5.0, time_domain: false, excite: [(joint: "shaft", law: Table([(800.0, 1.0), (1200.0, 2.0)]))], {speeds})"#
            ),
            "covers 800 to 1200 rpm, not the analysis's speed 700 rpm",
        ),
        (
            "falling.ron",
            r#"LinearResponse(name: "l", rpm: 1000.0, from: 2.0, to: 4.0, relative: false, excite: [(joint: "shaft", law: Table([(800.0, 1.0), (700.0, 2.0)]))])"#.to_string(),
            "does not increase",
        ),
        (
            "elsewhere.ron",
            r#"HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.5, order_max: 3.0, amplitudes: [50.0], excite: [(joint: "shaft", law: Rpm2(reference_rpm: 1000.0))])"#.to_string(),
            "taken by LinearResponse and MultiOrder only",
        ),
        (
            "combination_alone.ron",
            r#"Campbell(name: "c", rpm_min: 0.0, rpm_max: 2000.0, modal_combination: Add)"#.to_string(),
            "modal_combination: Add without modal_damping",
        ),
        (
            "modal_without_linear.ron",
            format!(r#"MultiOrder(name: "m", order: 5.0, linear: false, modal_damping: All(0.01), {speeds})"#),
            "acts on the linear part only",
        ),
    ] {
        std::fs::write(dir.join(name), base(&analysis)).unwrap();
        let e = Study::from_file(&dir.join(name)).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains(&format!("{name}:2:")) && e.contains(words), "{e}");
    }
}

/// An inline four whose inertia torque makes order 2 depend on speed.
const INLINE_FOUR: &str = r#"Engine(
    name: "inline_four",
    bore_m: 0.08, stroke_m: 0.09, rod_m: 0.15,
    reciprocating_mass_kg: 0.6,
    firing_order: [1, 3, 4, 2],
    pressure: Pulse(base_bar: 1.0, peak_bar: 60.0, at_deg: 14.0, width_deg: 28.0),
)"#;

/// Amplitude of order `k` of the engine torque at `omega` by a direct DFT over the 720° cycle.
/// The torque is analytic in θ (Gaussian pulse, smooth slider-crank): 2048 samples resolve it to
/// rounding.
fn dft_order(engine: &Engine, omega: f64, k: f64) -> f64 {
    let n = 2048;
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..n {
        let theta = 4.0 * PI * i as f64 / n as f64;
        let t = engine.torque(theta, omega);
        a += t * (k * theta).cos();
        b += t * (k * theta).sin();
    }
    (2.0 * a / n as f64).hypot(2.0 * b / n as f64)
}

/// MultiOrder with an engine: per speed, the summary table and the CSV give the engine's order
/// torques T_k, equal to a DFT of its torque written here. The engine's FFT (4096 samples) and
/// this DFT (2048) both hold the analytic torque to rounding; measured 3.6e-16 of the largest
/// T_k, bound 1e-9 of it (the issue's).
#[test]
fn multi_order_reports_the_engine_order_torques_per_speed() {
    let tmp = folder("engine");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), SHAFT).unwrap();
    std::fs::write(dir.join("four.ron"), INLINE_FOUR).unwrap();
    let rpms = [1500.0, 3000.0, 6000.0];
    let report = run_study(
        &dir,
        r#"Study(name: "engine", mechanism: "m.ron", analyses: [
    MultiOrder(name: "multi", order: 2.0, engine: "four.ron", engine_multiples: 2, time_domain: false, multiples: [1.0, 2.0],
               speeds: [(rpm: 1500.0), (rpm: 3000.0), (rpm: 6000.0)]),
])"#,
    );
    let src = Source::read_with(&dir.join("four.ron"), &ReadPolicy::unrestricted()).unwrap();
    let engine = Engine::new(src.parse_as::<EngineSpec>("Engine").unwrap()).unwrap();
    let csv = std::fs::read_to_string(dir.join("out").join("engine").join("multi.csv"))
        .or_else(|_| std::fs::read_to_string(dir.join("out").join("multi.csv")))
        .unwrap();
    let header: Vec<&str> = csv.lines().find(|l| l.starts_with("rpm")).unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("{name} in {header:?}"));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
        .map(|l| l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect())
        .collect();
    let mut worst: f64 = 0.0;
    let mut top: f64 = 0.0;
    for (i, (s, &rpm)) in report.multi[0].speeds.iter().zip(&rpms).enumerate() {
        let omega = rpm * PI / 30.0;
        for order in [2.0, 4.0] {
            let want = dft_order(&engine, omega, order);
            top = top.max(want);
            let got = s.engine_torque(order);
            let in_csv = rows[i][col(&format!("engine_T_order{order}_Nm"))];
            println!("{rpm} rpm, order {order}: T = {got:.9} N·m (CSV {in_csv:.9}), DFT {want:.9}");
            worst = worst.max((got - want).abs());
            // The CSV writes the shortest text that reads back to the same f64.
            assert_eq!(in_csv, got);
        }
    }
    println!("engine T_k vs DFT: {:.1e} of the largest", worst / top);
    assert!(worst <= 1e-9 * top, "{worst:e}");
    assert!(report.summary.contains("The engine's order torques T_k at each speed"), "{}", report.summary);
    assert!(report.summary.contains("| rpm | T order 2 (N·m) | T order 4 (N·m) |"), "{}", report.summary);
}

/// One rigid rotor on the spin joint with a small loss to ground.
const ROTOR: &str = r#"Mechanism(
    name: "rigid_rotor",
    bodies: [Body(name: "rotor", mass: 10.0, inertia: 20.0)],
    joints: [Joint(name: "spin", kind: Revolute, parent: "ground", child: "rotor", at: (0.0, 0.0))],
    loads: [GroundDamper(body: "rotor", c: 0.01)],
)"#;

/// A run-up with an engine: its cuts CSV gives the engine's T_k at every block's speed and the
/// summary at the run's first and last speed, equal to the DFT above at those speeds (the same
/// bound as the MultiOrder's: 1e-9 of the largest T_k; rounding is what remains).
#[test]
fn a_run_up_reports_the_engine_order_torques_per_block_speed() {
    let tmp = folder("runup");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("rotor.ron"), ROTOR).unwrap();
    std::fs::write(dir.join("four.ron"), INLINE_FOUR).unwrap();
    let report = run_study(
        &dir,
        r#"Study(name: "runup", mechanism: "rotor.ron", analyses: [
    Transient(name: "runup", duration_s: 12.0, speed: Torque(rpm_from: 1500.0, rpm_to: 3000.0),
              engine: (file: "four.ron", max_order: 4.0),
              map: (samples_per_rev: 64, revs_per_block: 16, hop_revs: 16.0, max_order: 8.0),
              write_time_series: false),
])"#,
    );
    let src = Source::read_with(&dir.join("four.ron"), &ReadPolicy::unrestricted()).unwrap();
    let engine = Engine::new(src.parse_as::<EngineSpec>("Engine").unwrap()).unwrap();
    let csv = std::fs::read_to_string(dir.join("out").join("runup").join("runup_cuts.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("{name} in {header:?}"));
    let (rpm, t2, t4) = (col("rpm"), col("engine_T_order2_Nm"), col("engine_T_order4_Nm"));
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect()).collect();
    assert!(rows.len() > 10, "{} blocks", rows.len());
    let (mut worst, mut top): (f64, f64) = (0.0, 0.0);
    for row in &rows {
        let omega = row[rpm] * PI / 30.0;
        for (c, order) in [(t2, 2.0), (t4, 4.0)] {
            let want = dft_order(&engine, omega, order);
            top = top.max(want);
            worst = worst.max((row[c] - want).abs());
        }
    }
    println!("run-up T_k over {} blocks vs DFT: {:.1e} of the largest", rows.len(), worst / top);
    assert!(worst <= 1e-9 * top, "{worst:e}");
    let t = &report.transient[0];
    let start = dft_order(&engine, t.rpm_start * PI / 30.0, 2.0);
    let line = format!("| {:.1} | {:.4} |", t.rpm_start, start);
    assert!(report.summary.contains(&line), "{line} in {}", report.summary);
}
