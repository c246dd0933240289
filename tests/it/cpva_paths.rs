//! Path absorbers in the nonlinear analyses: harmonic balance on an epicycloid absorber against
//! steady time integration of the full equations (DOP853 from the HBM state, then an FFT over
//! whole periods), and the free-oscillation analysis against closed forms (the circle's
//! `π / (2K(sin(φ₀/2)))`, the epicycloid's constant ñ).

use crate::support::scratch;
use approx::abs_diff_eq;
use kanedyn::hbm::{ContinuationOptions, Hbm, HbmOptions, HbmSolution};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order, rpm_to_rad_s};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use realfft::RealFftPlanner;
use std::f64::consts::PI;
use std::path::Path;

const RPM: f64 = 1000.0;

fn mechanism(file: &str) -> Mechanism {
    Mechanism::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paths").join(file)).unwrap()
}

fn single(amplitude: f64) -> Vec<Harmonic> {
    vec![Harmonic { multiple: 1.0, amplitude, phase: 0.0 }]
}

/// Rotor acceleration amplitudes at n and 2n after integrating `periods` periods from the HBM
/// state (the last `fft_periods` of them through an FFT), with the solution's full excitation.
fn time_amplitudes(mech: &Mechanism, hbm: &Hbm, h: &[Harmonic], sol: &HbmSolution) -> (f64, f64) {
    let (periods, fft_periods, per) = (60usize, 20usize, 256usize);
    let mut m = mech.clone();
    m.loads.joint_torques.clear();
    let mut kane = Kane::new(&m).unwrap();
    let exc = Excitation {
        mean: sol.mean_torque,
        rpm: sol.omega * 30.0 / PI,
        order: Order::Fixed(sol.order),
        harmonics: h.to_vec(),
        ramp_s: 0.0,
    };
    kane.set_joint_torque(m.joint_index("spin").unwrap(), exc);
    let period = 2.0 * PI / sol.base_frequency;
    let x0 = hbm.state_at(sol, 0.0);
    let n = m.ndof();
    let opts = IntegrateOptions {
        rtol: 1e-11,
        atol: 1e-12,
        sample_rate_hz: Some(per as f64 / period),
        sample_derivatives: true,
        ..IntegrateOptions::default()
    };
    let start = (periods - fft_periods) * per;
    let mut acc = Vec::with_capacity(fft_periods * per);
    // The last sample lands on t1 or just before it: one period's margin, then exactly
    // `fft_periods · per` samples are kept.
    integrate(
        |t, x, dx| kane.rhs(t, x, dx),
        &x0,
        0.0,
        (periods as f64 + 0.5) * period,
        &opts,
        |s| {
            if s.k >= start && acc.len() < fft_periods * per {
                acc.push(s.xdot.unwrap()[n]);
            }
        },
    )
    .unwrap();
    let len = acc.len();
    assert_eq!(len, fft_periods * per);
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
    let mut spec = fft.make_output_vec();
    fft.process(&mut acc, &mut spec).unwrap();
    let amp = |k: usize| 2.0 * spec[k * fft_periods].norm() / len as f64;
    (amp(1), amp(2))
}

/// Harmonic balance (10 harmonics) on the epicycloid absorber at 1000 rpm against steady time
/// integration, on the stable solutions at orders away from the folds, 40 and 200 N·m. The time
/// run starts on the HBM orbit, so any difference is HBM truncation, the remaining transient of
/// the orbit's slowest mode (|μ| close to 1 on a lightly damped absorber) and DOP853's error; the
/// issue's bound is 5e-3, as for the revolute absorber (tests/it/hbm.rs).
#[test]
fn harmonic_balance_on_an_epicycloid_absorber_matches_time_integration() {
    let mech = mechanism("epicycloid.ron");
    let mut m = mech.clone();
    m.loads.joint_torques.clear();
    let kane = Kane::new(&m).unwrap();
    let spin = m.joint_index("spin").unwrap();
    let mut worst = 0.0f64;
    for &torque in &[40.0, 200.0] {
        let h = single(torque);
        let mut hbm = Hbm::new(&kane, spin, rpm_to_rad_s(RPM), &h, HbmOptions::default()).unwrap();
        let up = hbm.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
        for &n in &[2.95, 3.0, 3.05] {
            for g in up.guesses_at(n) {
                let mut sol = hbm.solve(n, Some(g)).unwrap();
                let st = hbm.stability(&sol).unwrap();
                if !st.stable {
                    continue;
                }
                sol.stability = Some(st);
                let (t1, t2) = time_amplitudes(&m, &hbm, &h, &sol);
                let (a1, a2) = (sol.order_acceleration(0, 1.0), sol.order_acceleration(0, 2.0));
                let e1 = (t1 / a1 - 1.0).abs();
                let e2 = (t2 - a2).abs() / a2.max(0.05 * a1);
                println!(
                    "{torque} N·m n = {n}: HBM {a1:.5} / {a2:.5}, time {t1:.5} / {t2:.5} rad/s², rel. {e1:.1e} {e2:.1e}"
                );
                worst = worst.max(e1).max(e2);
            }
        }
    }
    println!("epicycloid absorber: HBM vs time integration, largest relative difference {worst:.2e}");
    assert!(worst > 0.0 && worst < 5e-3, "HBM and time integration differ by {worst:e}");
}

/// A scratch folder holding the example's path mechanisms and a study with `analyses` over them
/// (the study's outputs go there too, so the caller keeps the folder to the end of its checks).
fn scratch_study(tag: &str, analyses: &str) -> (kanedyn::study::Study, tempfile::TempDir) {
    let tmp = scratch(&format!("cpva-paths-{tag}"));
    let dir = tmp.path();
    std::fs::create_dir_all(dir.join("paths")).unwrap();
    for f in ["circle.ron", "epicycloid.ron", "overtuned.ron"] {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/paths").join(f);
        std::fs::copy(src, dir.join("paths").join(f)).unwrap();
    }
    let text = format!("Study(name: \"s\", mechanism: \"paths/circle.ron\", analyses: [\n{analyses}\n])");
    std::fs::write(dir.join("s.ron"), text).unwrap();
    (kanedyn::study::Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}")), tmp)
}

/// K(k), the complete elliptic integral of the first kind of modulus k, by the arithmetic–
/// geometric mean: K = π / (2 AGM(1, √(1 − k²))) (quadratic convergence, exact to rounding).
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    for _ in 0..40 {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    PI / (2.0 * a)
}

/// The free-oscillation analysis, through a comparison of the circle and the epicycloid, against
/// closed forms. Circle at held spin: `(I + mL²) φ̈ + m R L Ω² sin φ = 0`, a plain pendulum, so
/// the order over the linear one is π/(2K(sin(φ₀/2))) (0.982889 at 30°, 0.847213 at 90°);
/// translating body on the epicycloid: the order is ñ = 3.11 at every amplitude (to 90 % of
/// the travel: the example's end stops sit at 95 %; tests/it/path_joint.rs goes to 95 % on a bare
/// path). The analysis
/// locates zero crossings by cubic Hermite interpolation at 128 samples per period (error
/// ~(2π/128)⁴/384 ≈ 1.5e-8 of a period per crossing) and integrates at rtol 1e-12: the issue's
/// 1e-6 holds with margin.
#[test]
fn free_oscillation_orders_equal_the_closed_forms() {
    let l = 0.015209365076836064;
    let angles = [30.0f64, 60.0, 90.0, 120.0];
    let amps: Vec<String> = angles.iter().map(|a| format!("{}", l * a.to_radians())).collect();
    let s_max = 0.18520936507683606 / (3.11 * (1.0f64 + 3.11 * 3.11).sqrt());
    let (study, tmp) = scratch_study(
        "free",
        &format!(
            r#"Compare(name: "c", mechanisms: [(label: "circle", mechanism: "paths/circle.ron")],
                   analyses: [FreeOscillation(name: "free", rpm: 1000.0, joint: "path", amplitudes: [{}])]),
               Compare(name: "e", mechanisms: [(label: "epicycloid", mechanism: "paths/epicycloid.ron")],
                   analyses: [FreeOscillation(name: "free", rpm: 1000.0, joint: "path", amplitudes: [{}])])"#,
            amps.join(", "),
            [0.01, 0.25, 0.5, 0.75, 0.9].map(|f| format!("{}", f * s_max)).join(", ")
        ),
    );
    let dir = tmp.path();
    let report =
        kanedyn::study::run(&study, &kanedyn::study::RunOptions { out: Some(dir.join("out")), progress: false })
            .unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let circle = report.free.iter().find(|r| r.name == "c_circle_free").unwrap();
    let mut worst = 0.0f64;
    for (a, ratio) in angles.iter().zip(circle.order_ratios()) {
        let want = PI / (2.0 * elliptic_k((a.to_radians() / 2.0).sin()));
        println!("circle {a}°: order ratio {ratio:.9}, closed form {want:.9}");
        worst = worst.max((ratio - want).abs());
    }
    let epi = report.free.iter().find(|r| r.name == "e_epicycloid_free").unwrap();
    assert!(abs_diff_eq!(epi.linear_order, 3.11, epsilon = 1e-9), "linear order {}", epi.linear_order);
    for (a, o) in epi.amplitudes.iter().zip(&epi.orders) {
        println!("epicycloid at {:.3} of s_max: order {o:.10}", a / s_max);
        worst = worst.max((o / 3.11 - 1.0).abs());
        // The far side is the amplitude: the path and the motion are symmetric in s.
        let far = epi.far_side[epi.amplitudes.iter().position(|v| v == a).unwrap()];
        assert!(abs_diff_eq!(far / a, 1.0, epsilon = 1e-6), "far side {far} vs {a}");
    }
    println!("free oscillation: largest deviation from the closed forms {worst:.2e}");
    assert!(worst <= 1e-6, "free-oscillation order off by {worst:e}");
    assert!(dir.join("out/s/c_free.svg").exists() && dir.join("out/s/c_circle_free.csv").exists());
}

/// Main-order response trace of a sweep run after its first 5 s (ramp-in and first windows):
/// (order, amplitude in rad/s²).
fn trace(report: &kanedyn::study::StudyReport, analysis: &str, amplitude: f64, up: bool) -> Vec<(f64, f64)> {
    let dir = if up { kanedyn::study::Direction::Up } else { kanedyn::study::Direction::Down };
    let run = report
        .sweeps
        .iter()
        .find(|r| r.analysis == analysis && r.amplitude == amplitude && r.direction == dir && !r.locked)
        .unwrap_or_else(|| panic!("no run {analysis} {amplitude} {dir:?}"));
    assert!(run.sim.error.is_none(), "{analysis}: {:?}", run.sim.error);
    let t = run.trace(1.0).unwrap();
    t.time_s
        .iter()
        .zip(t.order.iter().zip(&t.amplitude))
        .filter(|(ts, _)| **ts >= 5.0)
        .map(|(_, (o, a))| (*o, *a))
        .collect()
}

/// The down sweep's amplitude at order `o` (linear between its windows).
fn at_order(down: &[(f64, f64)], o: f64) -> f64 {
    let mut pts = down.to_vec();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let k = pts.partition_point(|p| p.0 < o).clamp(1, pts.len() - 1);
    let ((o0, a0), (o1, a1)) = (pts[k - 1], pts[k]);
    a0 + (a1 - a0) * (o - o0) / (o1 - o0)
}

/// The example study `examples/cpva_paths.ron` (the issue's comparison) runs complete, and at
/// 500 N·m: the circle shows the softening fold (harmonic balance, n ≈ 3.10) and hysteresis
/// between its sweeps; the epicycloid's main-order minimum lies within 0.5 % of n_t = 3.11 in both
/// directions and its up and down sweeps agree to 1 % below the coupled resonance (from 2.92 to
/// 3.05, where the circle's differ by most of their value). Between n_t and the rotor's
/// resonance the tautochrone keeps a fold of the coupled mode (its nonlinearity comes from the
/// rotor's speed fluctuation, not from the path): measured and printed, not hidden.
#[test]
fn the_path_comparison_example_shows_the_tautochrone_without_hysteresis() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva_paths.ron");
    let study = kanedyn::study::Study::from_file(&file).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch("cpva-paths-example");
    let out = tmp.path().to_path_buf();
    let report =
        kanedyn::study::run(&study, &kanedyn::study::RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);

    // Circle: the softening fold of the harmonic balance at 500 N·m.
    let folds: Vec<f64> = report
        .hbm
        .iter()
        .filter(|b| b.analysis == "paths_circle_hbm" && b.amplitude == 500.0)
        .flat_map(|b| b.folds.clone())
        .collect();
    println!("circle, 500 N·m: folds at {folds:?}");
    assert!(folds.iter().any(|f| (3.09..=3.11).contains(f)), "no fold near 3.10: {folds:?}");

    for (label, n_t) in [("circle", 3.11), ("epicycloid", 3.11), ("overtuned", 3.2)] {
        let name = format!("paths_{label}_sweep");
        let (up, down) = (trace(&report, &name, 500.0, true), trace(&report, &name, 500.0, false));
        let min =
            |t: &[(f64, f64)]| t.iter().copied().fold((f64::NAN, f64::INFINITY), |b, p| if p.1 < b.1 { p } else { b });
        let (mu, md) = (min(&up), min(&down));
        let differ = up
            .iter()
            .filter(|(o, _)| (2.92..=3.05).contains(o))
            .map(|&(o, a)| {
                let d = at_order(&down, o);
                (a - d).abs() / d.abs()
            })
            .fold(0.0f64, f64::max);
        println!(
            "{label}, 500 N·m: minimum up {:.1} rad/s² at n = {:.4} ({:+.2e} of n_t), down {:.1} at {:.4}; up vs down from 2.92 to 3.05: {differ:.2e}",
            mu.1,
            mu.0,
            mu.0 / n_t - 1.0,
            md.1,
            md.0
        );
        match label {
            "circle" => assert!(differ > 0.5, "the circle's sweeps should differ (hysteresis): {differ}"),
            _ => {
                assert!(
                    abs_diff_eq!(mu.0 / n_t, 1.0, epsilon = 5e-3) && abs_diff_eq!(md.0 / n_t, 1.0, epsilon = 5e-3),
                    "{label}: minimum off n_t"
                );
                assert!(differ <= 1e-2, "{label}: up and down differ by {differ:e}");
            }
        }
    }
    // The backbones: the epicycloids keep their order to the end stops, the circle softens.
    for r in report.free.iter() {
        let ratios = r.order_ratios();
        let spread = ratios.iter().fold(0.0f64, |m, v| m.max((v - 1.0).abs()));
        println!(
            "{}: order over linear from {} to {} m: largest deviation {spread:.2e}",
            r.name,
            r.amplitudes[0],
            r.amplitudes.last().unwrap()
        );
        if r.name.contains("circle") {
            assert!(spread > 0.05);
        } else {
            assert!(spread <= 1e-6, "{}: {spread:e}", r.name);
        }
    }
}
