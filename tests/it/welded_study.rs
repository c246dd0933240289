//! Studies on a mechanism with welded (Fixed) joints: a housing welded to ground ahead of the
//! rotor and a hub welded onto it, so that no joint index equals its coordinate index. The
//! independent reference is the same study on the plain rotor-CPVA with the hub's inertia merged
//! into the rotor (a welded body is its merged inertia, tests/it/joint_kinds.rs): every analysis
//! must give the same numbers.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::study::{RunOptions, Study, StudyReport, run};
use std::path::Path;

/// Canonical rotor inertia (bodies/flywheel_rotor.ron), kg·m², split into a core and a
/// hub on the axis below.
const ROTOR_I: f64 = 3.443504355127701;
const HUB_I: f64 = 0.443504355127701;

fn mechanism(welded: bool) -> String {
    // The canonical pendulum (bodies/cpva_pendulum.ron): n_t = 3.11.
    let pendulum =
        r#"Body(name: "pendulum", mass: 6.0, com: (0.015209365076836064, 0.0), inertia: 0.00021600000000000002)"#;
    let loads = r#"loads: [GroundDamper(body: "rotor", c: 5e-3)]"#;
    if welded {
        format!(
            r#"Mechanism(
    name: "welded",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "housing", mass: 40.0, com: (0.05, 0.02), inertia: 2.0),
        Body(name: "rotor", mass: 100.0, inertia: {core}),
        Body(name: "hub", mass: 10.0, inertia: {HUB_I}),
        {pendulum},
    ],
    joints: [
        Joint(name: "mount", kind: Fixed, parent: "ground", child: "housing", at: (0.3, -0.1)),
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "hub_weld", kind: Fixed, parent: "rotor", child: "hub"),
        Joint(name: "pivot", parent: "rotor", child: "pendulum", at: (0.17, 0.0), damper: 5e-4),
    ],
    {loads},
)"#,
            core = ROTOR_I - HUB_I
        )
    } else {
        format!(
            r#"Mechanism(
    name: "plain",
    speeds: AbsoluteAngularVelocities,
    bodies: [Body(name: "rotor", mass: 110.0, inertia: {ROTOR_I}), {pendulum}],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "pivot", parent: "rotor", child: "pendulum", at: (0.17, 0.0), damper: 5e-4),
    ],
    {loads},
)"#
        )
    }
}

const STUDY: &str = r#"Study(
    name: "s",
    mechanism: "m.ron",
    lock: ["pivot"],
    analyses: [
        LinearResponse(name: "lin", rpm: 1000.0, from: 2.8, to: 3.4, points: 61),
        OrderSweep(name: "sweep", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 30.0,
                   amplitudes: [40.0], directions: [Up]),
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        MultiOrder(name: "multi", order: 3.0, speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 300.0)])],
                   max_time_s: 60.0, linear: true),
    ],
)"#;

fn run_study(welded: bool) -> StudyReport {
    let tmp = scratch(&format!("welded-{welded}"));
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), mechanism(welded)).unwrap();
    std::fs::write(dir.join("s.ron"), STUDY).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    report
}

/// Largest |a − b| over the largest |b|.
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let peak = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / peak
}

#[test]
fn welded_bodies_change_no_study_result() {
    assert!(Path::new("examples").exists());
    let (w, p) = (run_study(true), run_study(false));

    // Linear: the merged inertia differs from the split one by one rounding (1e-16), which the
    // eigen-analysis and the order response carry at ~1e-14; bound 1e-10.
    let (lw, lp) = (&w.linear[0], &p.linear[0]);
    let (ntw, ntp) = (lw.n_t.unwrap(), lp.n_t.unwrap());
    println!("n_t {ntw} vs {ntp}");
    assert_abs_diff_eq!(ntw, ntp, epsilon = 1e-10 * ntp);
    let e = rel(&lw.variants[0].ratio, &lp.variants[0].ratio);
    println!("linear ratio curve: {e:.1e}");
    assert!(e <= 1e-10);
    // The modes are named by the joint that owns each coordinate, not by joint index.
    let labels = |l: &kanedyn::study::LinearResult| l.free_orders.iter().map(|o| o.1.clone()).collect::<Vec<_>>();
    assert_eq!(labels(lw), labels(lp));

    // Time domain: rounding-level model differences steer the adaptive steps (rtol 1e-9)
    // differently; over 30 s the traces agree to integration accuracy (measured 1.6e-9 of the
    // peak). Bound 1e-7.
    for (sw, sp) in w.sweeps.iter().zip(&p.sweeps) {
        assert_eq!((sw.locked, sw.traces.len()), (sp.locked, sp.traces.len()));
        for (tw, tp) in sw.traces.iter().zip(&sp.traces) {
            // The locked twin is linear: its higher-order traces are numerical noise (~1e-6 of
            // its main order) with nothing to compare.
            if sw.locked && tw.multiple != 1.0 {
                continue;
            }
            let e = rel(&tw.amplitude, &tp.amplitude);
            println!("sweep locked={} multiple {}: {e:.1e}", sw.locked, tw.multiple);
            assert!(e <= 1e-7, "{e:e}");
        }
        assert_abs_diff_eq!(
            sw.max_relative_angle,
            sp.max_relative_angle,
            epsilon = 1e-6 * sp.max_relative_angle.max(1e-3)
        );
    }

    // Harmonic balance: the branch folds and the amplitudes at its start agree to the Newton
    // tolerance (1e-10 of the unknowns); bound 1e-7.
    for (bw, bp) in w.hbm.iter().zip(&p.hbm) {
        assert_eq!(bw.folds.len(), bp.folds.len());
        for (fw, fp) in bw.folds.iter().zip(&bp.folds) {
            assert!(abs_diff_eq!(fw, fp, epsilon = 1e-7), "fold {fw} vs {fp}");
        }
        let (aw, ap) = (bw.accel[0][0], bp.accel[0][0]);
        assert_abs_diff_eq!(aw, ap, epsilon = 1e-7 * ap);
        assert_abs_diff_eq!(bw.relative_angle[0], bp.relative_angle[0], epsilon = 1e-7 * bp.relative_angle[0]);
    }

    // Multi-order steady state: time domain to 1e-6 (as the sweep), linear to 1e-10, and the
    // mean-speed correction acts on the spin coordinate (a wrong index would leave the mean speed
    // off and the amplitudes with it).
    let (mw, mp) = (&w.multi[0].speeds[0], &p.multi[0].speeds[0]);
    let (rw, rp) = (mw.response.as_ref().unwrap(), mp.response.as_ref().unwrap());
    println!("multi: {:?} vs {:?}", rw.amplitudes, rp.amplitudes);
    assert!(rel(&rw.amplitudes, &rp.amplitudes) <= 1e-6);
    assert_abs_diff_eq!(rw.speed_correction, rp.speed_correction, epsilon = 1e-6 * rp.speed_correction.abs().max(1e-3));
    assert!(rel(mw.linear.as_ref().unwrap(), mp.linear.as_ref().unwrap()) <= 1e-10);
    assert_eq!(mw.hbm.len(), mp.hbm.len());
}
