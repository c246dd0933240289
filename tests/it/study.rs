//! Study files: the examples load and run, the linear study reproduces the closed forms of the
//! paper, and bad study input gives errors naming the file, line:column and field.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::cpva::{CpvaParams, rotor_order};
use kanedyn::study::{RunOptions, Study, run};
use std::path::Path;
use tempfile::TempDir;

fn out_dir(tag: &str) -> TempDir {
    scratch(&format!("study-{tag}"))
}

#[test]
fn every_example_study_loads() {
    let mut n = 0;
    for e in std::fs::read_dir("examples").unwrap() {
        let p = e.unwrap().path();
        let text = std::fs::read_to_string(&p).unwrap_or_default();
        if p.extension().is_some_and(|x| x == "ron") && text.lines().any(|l| l.starts_with("Study(")) {
            Study::from_file(&p).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 3, "expected the paper, linear and shaft studies, found {n}");
}

#[test]
fn linear_study_gives_the_closed_forms() {
    let study = Study::from_file(Path::new("examples/cpva_linear.ron")).unwrap();
    let tmp = out_dir("linear");
    let out = tmp.path().to_path_buf();
    let r = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    for f in &r.files {
        assert!(f.exists(), "{} not written", f.display());
    }
    let lin = &r.linear[0];
    let p = CpvaParams::canonical();
    let (it, nt) = (p.i_tilde, p.n_t);
    // Eigenvalues from Richardson-extrapolated central differences: 1e-9 relative (measured 2e-14).
    assert_abs_diff_eq!(lin.n_t.unwrap(), nt, epsilon = 1e-9 * nt);
    let nr = rotor_order(nt, it);
    assert!(lin.free_orders.iter().any(|(o, _)| abs_diff_eq!(*o, nr, epsilon = 1e-9 * nr)));
    let nt2 = nt * nt;
    let asym = (it + 1.0 + 2.0 * nt2) / (it - nt2 * nt2);
    let cross = nt * (2.0 * (it + 1.0 + 2.0 * nt2) / (2.0 * it + 1.0 + 2.0 * nt2 - nt2 * nt2)).sqrt();
    for v in &lin.variants {
        // The asymptote does not depend on damping (M alone at high order): 1e-9.
        assert!(abs_diff_eq!(v.asymptote, asym, epsilon = 1e-9 * asym), "{}: {}", v.label, v.asymptote);
        // All damped curves pass near the undamped crossing (the locked rotor is the c_p → ∞
        // limit, a fixed point of the family); with c_r = 5e-3 they miss it by < 2e-7 in order.
        let c = v.crossing.unwrap();
        assert!(abs_diff_eq!(c, cross, epsilon = 1e-6 * cross), "{}: crossing {c} vs {cross}", v.label);
        // The minimum sits at n_t within the damping-broadened notch; the maximum near n_r.
        assert_abs_diff_eq!(v.min.0 / nt, 1.0, epsilon = 0.04);
        assert!(v.min.1 < 1.0);
        assert!(v.max.0 > nt && v.max.1 > 1.0);
    }
    // Lighter damping, deeper notch and higher peak (Figure 2).
    assert!(lin.variants[0].min.1 < lin.variants[1].min.1 && lin.variants[1].min.1 < lin.variants[2].min.1);
    assert!(lin.variants[0].max.1 > lin.variants[1].max.1 && lin.variants[1].max.1 > lin.variants[2].max.1);
}

/// A temp folder holding the example mechanism `cpva.ron` (its parts from the shipped catalog),
/// so a study written there may name it by relative path (studies may only read inside their
/// tree).
fn with_mechanism(tag: &str) -> TempDir {
    let dir = out_dir(tag);
    std::fs::copy("examples/cpva.ron", dir.path().join("cpva.ron")).unwrap();
    dir
}

fn study_error(name: &str, text: &str) -> String {
    let tmp = with_mechanism(&format!("err_{name}"));
    let dir = tmp.path().to_path_buf();
    let p = dir.join("s.ron");
    std::fs::write(&p, text.replace("MECH", "cpva.ron")).unwrap();
    Study::from_file(&p).err().unwrap_or_else(|| panic!("{name}: expected an error")).to_string()
}

const GOOD: &str = r#"Study(
    name: "s",
    mechanism: "MECH",
    lock: ["pivot"],
    analyses: [
        OrderSweep(name: "a", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0, amplitudes: [40.0]),
    ],
)
"#;

#[test]
fn bad_study_input_names_the_place() {
    let cases: [(&str, String, &[&str]); 7] = [
        ("syntax", GOOD.replace("rpm: 1000.0,", "rpm: 1000.0"), &["s.ron:6:"]),
        ("unknown_field", GOOD.replace("rpm:", "rmp:"), &["s.ron:6:", "rmp"]),
        ("unknown_joint", GOOD.replace("[\"pivot\"]", "[\"pivto\"]"), &["s.ron:4:", "lock[0]", "pivto"]),
        ("spin", GOOD.replace("lock:", "spin_joint: \"pivot\", lock:"), &["spin_joint", "ground"]),
        ("body", GOOD.replace("lock:", "response_body: \"rotr\", lock:"), &["response_body", "rotr"]),
        ("orders", GOOD.replace("order_min: 2.9", "order_min: 3.9"), &["s.ron:6:", "analyses[0].order_min"]),
        ("nan", GOOD.replace("[40.0]", "[NaN]"), &["analyses[0].amplitudes"]),
    ];
    for (name, text, parts) in cases {
        let msg = study_error(name, &text);
        for p in parts {
            assert!(msg.contains(p), "{name}: {msg:?} should mention {p:?}");
        }
    }
    let missing = study_error("missing", &GOOD.replace("MECH", "/nonexistent/m.ron"));
    assert!(missing.contains("mechanism") && missing.contains("/nonexistent/m.ron"), "{missing}");
}

#[test]
fn cli_run_writes_outputs_and_fails_cleanly_on_bad_input() {
    let tmp = out_dir("cli");
    let out = tmp.path().to_path_buf();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kanedyn"))
        .args(["run", "examples/shaft_campbell.ron", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("shaft_campbell/summary.md").exists());
    assert!(out.join("shaft_campbell/campbell.svg").exists());
    let o =
        std::process::Command::new(env!("CARGO_BIN_EXE_kanedyn")).args(["run", "examples/cpva.ron"]).output().unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("examples/cpva.ron") && !err.contains("panicked"), "{err}");
}

/// The `parameter` of a `HarmonicBalance` entry: continued in the torque amplitude and in the
/// mean speed at the 40 N·m up-sweep fold order n* = 3.1740911 (1000 rpm, tests/it/hbm.rs), each
/// must turn at that point, i.e. at 40 N·m and at 1000 rpm. n* is given to 8 digits, so the
/// folds move along the fold curve by ~|dT/dn|·5e-8 (|dT/dn| ~ 10³ N·m here): 1e-3 relative.
#[test]
fn harmonic_balance_in_speed_and_torque() {
    let text = r#"Study(
    name: "hbmp",
    mechanism: "MECH",
    lock: ["pivot"],
    analyses: [
        HarmonicBalance(name: "torque", rpm: 1000.0, parameter: Torque(order: 3.1740911, min: 1.0, max: 120.0)),
        HarmonicBalance(name: "speed", amplitudes: [40.0],
                        parameter: Speed(order: 3.1740911, rpm_min: 600.0, rpm_max: 1600.0)),
        HarmonicBalance(name: "fine", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0], max_step: 0.02),
        HarmonicBalance(name: "coarse", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
    ],
)
"#;
    let tmp = with_mechanism("hbm_param");
    let dir = tmp.path().to_path_buf();
    let p = dir.join("s.ron");
    std::fs::write(&p, text.replace("MECH", "cpva.ron")).unwrap();
    let study = Study::from_file(&p).unwrap();
    let r = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    for f in &r.files {
        assert!(f.exists(), "{} not written", f.display());
    }
    let near = |folds: Vec<f64>, target: f64| folds.into_iter().any(|f| abs_diff_eq!(f / target, 1.0, epsilon = 1e-3));
    let torque: Vec<f64> = r.hbm.iter().filter(|b| b.amplitude.is_nan()).flat_map(|b| b.folds.clone()).collect();
    assert!(near(torque.clone(), 40.0), "torque folds {torque:?}");
    let speed: Vec<f64> = r.hbm.iter().filter(|b| b.amplitude == 40.0).flat_map(|b| b.folds.clone()).collect();
    assert!(near(speed.clone(), 1000.0), "speed folds {speed:?}");
    // max_step caps the step: more points, the same folds (refined to the same fold either way).
    let (fine, coarse): (Vec<_>, Vec<_>) =
        r.hbm.iter().filter(|b| b.amplitude == 40.0 && b.parameter == b.order).partition(|b| b.order.len() > 80);
    assert!(!fine.is_empty() && !coarse.is_empty(), "{:?}", r.hbm.iter().map(|b| b.order.len()).collect::<Vec<_>>());
    assert_eq!((fine[0].folds.len(), coarse[0].folds.len()), (2, 2));
    for (f, c) in fine[0].folds.iter().zip(&coarse[0].folds) {
        assert!(abs_diff_eq!(f, c, epsilon = 1e-6), "folds {f} vs {c}");
    }
    // Wrong combinations name the field.
    let bad = [
        (
            "amps",
            "HarmonicBalance(name: \"h\", rpm: 1000.0, amplitudes: [1.0], parameter: Torque(order: 3.0, min: 1.0, max: 2.0))",
            "amplitudes",
        ),
        (
            "rpm",
            "HarmonicBalance(name: \"h\", rpm: 1000.0, amplitudes: [1.0], parameter: Speed(order: 3.0, rpm_min: 500.0, rpm_max: 900.0))",
            "rpm",
        ),
        (
            "range",
            "HarmonicBalance(name: \"h\", amplitudes: [1.0], parameter: Speed(order: 3.0, rpm_min: 900.0, rpm_max: 500.0))",
            "parameter",
        ),
        ("orders", "HarmonicBalance(name: \"h\", rpm: 1000.0, amplitudes: [1.0])", "order_min"),
        (
            "step",
            "HarmonicBalance(name: \"h\", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1.0], max_step: -0.1)",
            "max_step",
        ),
    ];
    for (name, entry, field) in bad {
        let msg = study_error(name, &GOOD.replace(
            "OrderSweep(name: \"a\", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0, amplitudes: [40.0]),",
            &format!("{entry},"),
        ));
        assert!(msg.contains(&format!("analyses[0].{field}")), "{name}: {msg}");
    }
}
