//! Issue 15's truck driveline (`examples/truck_study.ron` on `examples/truck_driveline.ron`):
//! the mean engine torque takes the path through the dual-mass flywheel, the input shaft and the
//! gear stage that the closed forms of a statically loaded chain give, and the three routes to
//! the steady response (harmonic balance, time integration, and for the elements' torques the
//! sampled coupling law against the time-domain torque) agree at every speed.

use crate::support::scratch;
use approx::abs_diff_eq;
use kanedyn::linear::LinearModel;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use std::f64::consts::PI;
use std::path::Path;

/// The engine's mean torque (`examples/engines/inline_six.ron`), as the mechanism file applies it.
const T_ENGINE: f64 = 690.7810274851327;

/// The operating point is a statically loaded chain: the engine torque T on the crank against the
/// road load on the vehicle winds each spring by the torque it carries over its stiffness. The
/// arc spring carries T in its first stage (2000 N·m/rad up to 0.45 rad: T/k = 0.345 rad), the
/// input shaft T (15 kN·m/rad), the propshaft the torque through the 2.5 : 1 stage, 2.5 T
/// (25 kN·m/rad); the pendulum hangs at φ = 0 (the flywheel does not accelerate). The linear
/// analysis replaces the spin joint's own torque by the mean torque it solves for, which is then
/// that joint's share of the engine torque, T, plus the gearbox input's loss to ground, c Ω.
/// Newton's residual is ~1e-13 of the torques: bound 1e-9 relative.
#[test]
fn the_mean_torque_winds_the_driveline_as_a_loaded_chain() {
    let mech = Mechanism::from_file(Path::new("examples/truck_driveline.ron")).unwrap_or_else(|e| panic!("{e}"));
    for rpm in [600.0, 1200.0, 1800.0] {
        let omega = rpm * PI / 30.0;
        let lin = LinearModel::new(&mech, "input", omega, None).unwrap_or_else(|e| panic!("{e}"));
        let q = |name: &str| lin.op.q[mech.coordinate(mech.joint_index(name).unwrap()).unwrap()];
        let cases = [
            ("arc", T_ENGINE / 2000.0),
            ("clutch", T_ENGINE / 1.5e4),
            ("propshaft", -2.5 * T_ENGINE / 2.5e4),
            ("pivot", 0.0),
        ];
        for (name, expect) in cases {
            let got = q(name);
            println!("{rpm} rpm: {name} {got:.12e} rad vs {expect:.12e}");
            assert!(abs_diff_eq!(got, expect, epsilon = 1e-9 * expect.abs().max(1e-3)), "{name}: {got} vs {expect}");
        }
        let t_m = lin.op.mean_spin_torque;
        let expect = T_ENGINE + 0.01 * omega;
        assert!(abs_diff_eq!(t_m, expect, epsilon = 1e-9 * T_ENGINE), "mean spin torque {t_m} vs {expect}");
    }
}

/// Harmonic balance (the state a slow torque ramp reaches, H = 10) and time integration to
/// steady state (DOP853 at 1e-9, order tracking over 4 s windows) give the same main-order
/// response of the gearbox input at every speed from 600 to 1800 rpm, with the absorber free and
/// locked; and the arc spring's order-3 torque, which harmonic balance gets by sampling the
/// staged spring, friction and stops along its Fourier series, equals the order-tracked torque of
/// the time run, which evaluates the same law sample by sample. Both routes carry errors of the
/// steadiness test (1e-3 between windows) and of truncation at H = 10: bound 1e-2, the issue's
/// HBM-vs-time tolerance for couplings.
#[test]
fn harmonic_balance_and_time_runs_agree_on_the_driveline() {
    let study = Study::from_file(Path::new("examples/truck_study.ron")).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch("truck");
    let dir = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let multi = &report.multi[0];
    let (mut worst, mut worst_torque): (f64, f64) = (0.0, 0.0);
    for s in &multi.speeds {
        let time = s.response.as_ref().expect("a time run");
        let hbm = s.hbm_ramp.as_ref().expect("the torque ramp reaches the full torques");
        let e = (time.amplitudes[0] - hbm.amplitudes[0]).abs() / hbm.amplitudes[0];
        let locked = s.locked.as_ref().expect("a locked run");
        let hbm_locked = s.hbm_locked.as_ref().expect("the locked twin's ramp");
        let el = (locked.amplitudes[0] - hbm_locked.amplitudes[0]).abs() / hbm_locked.amplitudes[0];
        macro_rules! arc {
            ($els:expr) => {
                $els.iter().find(|e| e.joint == "arc").and_then(|e| e.torque.as_ref()).map(|t| t.amplitude[0]).unwrap()
            };
        }
        let (ta, th) = (arc!(time.elements), arc!(hbm.elements));
        let et = (ta - th).abs() / th;
        println!(
            "{} rpm: gearbox input {:.5} (time) vs {:.5} (HBM) rad/s², {e:.1e}; locked {el:.1e}; arc torque {ta:.4} vs {th:.4} N·m, {et:.1e}",
            s.rpm, time.amplitudes[0], hbm.amplitudes[0]
        );
        worst = worst.max(e).max(el);
        worst_torque = worst_torque.max(et);
    }
    assert!(worst <= 1e-2, "response: {worst:e}");
    assert!(worst_torque <= 1e-2, "arc torque: {worst_torque:e}");
}
