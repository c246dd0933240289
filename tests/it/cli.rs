//! The command-line tool: `check` and `eom` on the examples, and clean failures on bad input.

use crate::support::cli;
use approx::assert_abs_diff_eq;
use cli::kanedyn;

#[test]
fn check_prints_dofs_and_mass() {
    let (ok, out, _) = kanedyn(&["check", "examples/cpva4.ron"]);
    assert!(ok);
    assert!(out.contains("degrees of freedom: 5"));
    assert!(out.contains("total mass: 116 kg"));
    assert!(out.contains("pivot_4"));
}

#[test]
fn eom_prints_round_tripping_json_equal_to_eq7() {
    let (ok, out, err) =
        kanedyn(&["eom", "examples/cpva.ron", "--q", "12.5,-0.4", "--u", "104.7,-20", "--joint-torque", "spin=250"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let m: Vec<Vec<f64>> = serde_json::from_value(v["mass_matrix"].clone()).unwrap();
    let f: Vec<f64> = serde_json::from_value(v["forcing"].clone()).unwrap();
    let udot: Vec<f64> = serde_json::from_value(v["udot"].clone()).unwrap();
    let qdot: Vec<f64> = serde_json::from_value(v["qdot"].clone()).unwrap();
    // The constant 250 N·m replaces the excitation; the rotor damper to ground stays.
    let cf = kanedyn::cpva::CpvaParams::canonical().closed_form();
    let (mc, fc) = cf.mass_matrix_and_forcing(&[12.5, -0.4], &[104.7, -20.0], 250.0);
    for r in 0..2 {
        assert_abs_diff_eq!(f[r], fc[r], epsilon = 1e-12 * fc.amax());
        for c in 0..2 {
            assert_abs_diff_eq!(m[r][c], mc[(r, c)], epsilon = 1e-12 * mc.amax());
        }
    }
    assert_eq!(qdot, vec![104.7, -20.0 - 104.7]);
    let mut xd = [0.0; 4];
    cf.rhs1(250.0, &[12.5, -0.4, 104.7, -20.0], &mut xd);
    assert_abs_diff_eq!(udot[0], xd[2], epsilon = 1e-10 * xd[2].abs());
    assert_abs_diff_eq!(udot[1], xd[3], epsilon = 1e-10 * xd[3].abs());
    // Printed numbers parse back to the very bits the library computes.
    let mech = kanedyn::model::mechanism::Mechanism::from_file(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/cpva.ron"
    )))
    .unwrap();
    let mut k = kanedyn::kane::Kane::new(&mech).unwrap();
    k.set_joint_torque(0, kanedyn::model::excitation::Excitation::constant(250.0));
    let mut xd = [0.0; 4];
    k.rhs(0.0, &[12.5, -0.4, 104.7, -20.0], &mut xd).unwrap();
    assert_eq!(udot[0].to_bits(), xd[2].to_bits());
    assert_eq!(udot[1].to_bits(), xd[3].to_bits());
    let (lm, lf) = k.mass_matrix_and_forcing(0.0, &[12.5, -0.4], &[104.7, -20.0]);
    assert_eq!(m[0][1].to_bits(), lm[(0, 1)].to_bits());
    assert_eq!(f[1].to_bits(), lf[1].to_bits());
}

#[test]
fn bad_input_fails_cleanly() {
    for args in [
        vec!["check", "examples/does-not-exist.ron"],
        vec!["eom", "examples/cpva.ron", "--q", "0", "--u", "1,2"],
        vec!["eom", "examples/cpva.ron", "--q", "0,x", "--u", "1,2"],
        vec!["eom", "examples/cpva.ron", "--q", "0,NaN", "--u", "1,2"],
        vec!["eom", "examples/cpva.ron", "--q", "0,0", "--u", "1,2", "--joint-torque", "spn=3"],
        vec!["eom", "examples/cpva.ron", "--q", "0,0", "--u", "1,2", "--joint-torque", "spin"],
    ] {
        let (ok, _, err) = kanedyn(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(err.starts_with("error:"), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    let (_, _, err) = kanedyn(&["eom", "examples/cpva.ron", "--q", "0,0", "--u", "1,2", "--joint-torque", "spn=3"]);
    assert!(err.contains("unknown joint `spn`") && err.contains("spin, pivot"));
}
