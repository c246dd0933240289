//! Issue 29, item 3: honest peaks. Every element reports its mean, lowest, highest and largest
//! absolute value (the wind-up included), for the coordinate and the transmitted torque, in
//! harmonic-balance states, time windows and the linear multi-order response.
//!
//! References written here: one period of DOP853 at 1e-12 from each harmonic-balance state,
//! sampled at 20 000 instants (the max |q| of a sampled smooth orbit is low by at most
//! ~(π/20000)²/2 ≈ 1.2e-8 of its amplitude), and the mean wind-up of a shaft that carries the
//! rotor's ground-damper loss, `T = c Ω`, `q̄ = −c Ω / k`.

use kanedyn::hbm::{ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use std::f64::consts::PI;

use crate::support::wound_shaft::WOUND;

const C_ROTOR: f64 = 2.0;
const K_SHAFT: f64 = 5.0e4;
const RPM: f64 = 1000.0;
const TORQUE: f64 = 40.0;

fn folder(tag: &str) -> tempfile::TempDir {
    let tmp = crate::support::scratch(&format!("honest-peaks-{tag}"));
    let dir = tmp.path();
    std::fs::write(dir.join("m.ron"), WOUND).unwrap();
    tmp
}

/// On both stable states of the absorber's jump region (n = 3.02, high and low branch), the
/// largest |q| of the pendulum and of the wound-up shaft from the harmonic-balance series equal
/// the largest |q| over one period of the time equations from that state, to 1e-6 relative;
/// the shaft's includes its mean wind-up −cΩ/k (to 1e-9 relative).
#[test]
fn harmonic_balance_extremes_equal_a_period_of_the_time_equations_on_both_branches() {
    let tmp = folder("hbm");
    let dir = tmp.path().to_path_buf();
    let mech = Mechanism::from_file(&dir.join("m.ron")).unwrap();
    let spin = mech.joint_index("spin").unwrap();
    let omega = RPM * PI / 30.0;
    let harmonics = vec![Harmonic { multiple: 1.0, amplitude: TORQUE, phase: 0.0 }];
    let mut hbm = Hbm::new(&Kane::new(&mech).unwrap(), spin, omega, &harmonics, HbmOptions::default()).unwrap();
    let down = hbm.continue_in_order(3.4, 2.8, None, &ContinuationOptions::default()).unwrap();
    let up = hbm.continue_in_order(2.8, 3.4, None, &ContinuationOptions::default()).unwrap();
    // Between the high branch's Neimark–Sacker point (2.995) and the low branch's fold (3.042)
    // both are stable (found so by this continuation; the middle state is unstable).
    let order = 3.02;
    let mut stable = Vec::new();
    for guess in down.guesses_at(order).into_iter().chain(up.guesses_at(order)) {
        let mut sol = hbm.solve(order, Some(guess)).unwrap();
        sol.stability = Some(hbm.stability(&sol).unwrap());
        if sol.stability.as_ref().unwrap().stable {
            stable.push(sol);
        }
    }
    assert_eq!(stable.len(), 2, "two stable states between the folds");
    let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, ..IntegrateOptions::default() };
    let n = mech.ndof();
    let mut pendulum_peaks = Vec::new();
    for sol in &stable {
        let period = 2.0 * PI / sol.base_frequency;
        let mut kane = Kane::new(&mech).unwrap();
        let exc = Excitation {
            mean: sol.mean_torque,
            rpm: RPM,
            order: Order::Fixed(order),
            harmonics: harmonics.clone(),
            ramp_s: 0.0,
        };
        kane.set_joint_torque(spin, exc);
        let samples = 20_000;
        let mut x = hbm.state_at(sol, 0.0);
        let mut max_abs = vec![0.0f64; n];
        for i in 0..samples {
            let (t0, t1) = (period * i as f64 / samples as f64, period * (i + 1) as f64 / samples as f64);
            x = integrate(|t, x, dx| kane.rhs(t, x, dx), &x, t0, t1, &opts, |_| {}).unwrap().x_end;
            for k in 1..n {
                max_abs[k] = max_abs[k].max(x[k].abs());
            }
        }
        for (k, name) in [(1, "shaft"), (2, "pivot")] {
            let nb = 2 * sol.harmonics + 1;
            let mean = sol.coefficients[k * nb];
            let (lo, hi) = sol.oscillation_range(k);
            let series = (mean + lo).abs().max((mean + hi).abs());
            let rel = (series - max_abs[k]).abs() / max_abs[k];
            println!("{name}: max|q| series {series:.10e}, time {:.10e} ({rel:.1e}); mean {mean:.6e}", max_abs[k]);
            assert!(rel <= 1e-6, "{name}: {rel:e}");
            if k == 1 {
                // The shaft carries the rotor's loss: its mean twist is −cΩ/k (the pendulum's
                // pivot damper averages out), and its largest |q| is that plus the oscillation.
                let want = -C_ROTOR * omega / K_SHAFT;
                assert!((mean - want).abs() <= 1e-9 * want.abs(), "{mean} vs {want}");
                assert!(series >= want.abs() + (-lo).min(hi) - 1e-12, "the wind-up is in the largest |q|");
            } else {
                pendulum_peaks.push(series);
            }
        }
    }
    // The two states are the absorber's low and high responses.
    assert!(
        pendulum_peaks[0].max(pendulum_peaks[1]) > 2.0 * pendulum_peaks[0].min(pendulum_peaks[1]),
        "{pendulum_peaks:?}"
    );
}

/// The study reports the extremes at every point of a harmonic-balance branch, in a steady time
/// run and in the linear multi-order response, for the coordinate and the torque, the wind-up
/// included: the shaft's mean torque is the rotor's loss cΩ (to 1e-9 in harmonic balance and
/// the linear response, to the steady run's 1e-4), and the CSV columns carry them.
#[test]
fn the_study_reports_honest_extremes_everywhere() {
    let tmp = folder("study");
    let dir = tmp.path().to_path_buf();
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "m.ron", spin_joint: "spin", response_body: "rotor", elements: ["shaft", "pivot"],
    analyses: [
        HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        MultiOrder(name: "m", order: 3.0, multiples: [1.0], max_time_s: 200.0,
                   speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 40.0)])]),
    ])"#,
    )
    .unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let loss = C_ROTOR * RPM * PI / 30.0;
    let check = |e: &kanedyn::study::ElementResponse, tol: f64, what: &str| {
        let r = e.range;
        assert!(r.min <= r.mean && r.mean <= r.max, "{what} {}: {r:?}", e.joint);
        assert_eq!(r.max_abs, r.min.abs().max(r.max.abs()));
        if e.joint == "shaft" {
            let t = e.torque.as_ref().unwrap().range;
            assert!((t.mean + loss).abs() <= tol * loss, "{what}: shaft mean torque {} vs −{loss}", t.mean);
            assert!((r.mean + loss / K_SHAFT).abs() <= tol * loss / K_SHAFT, "{what}: wind-up {}", r.mean);
            assert!(r.max_abs >= r.mean.abs(), "{what}: {r:?}");
        }
    };
    for b in &report.hbm {
        for point in &b.elements {
            for e in point {
                check(e, 1e-9, "HBM");
            }
        }
    }
    let speed = &report.multi[0].speeds[0];
    for e in &speed.response.as_ref().unwrap().elements {
        check(e, 1e-4, "time run");
    }
    for e in &speed.linear_elements {
        check(e, 1e-9, "linear");
    }
    let csv = std::fs::read_to_string(dir.join("out/s/m.csv")).unwrap();
    let head = csv.lines().next().unwrap();
    for col in
        ["shaft_max_abs_rad", "shaft_mean_rad", "shaft_torque_mean_Nm", "linear_shaft_max_abs_rad", "pivot_min_rad"]
    {
        assert!(head.split(',').any(|c| c == col), "{col} missing from {head}");
    }
}
