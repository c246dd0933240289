//! A multi-order analysis finds every periodic state at its operating order. Its order branches
//! only supply starting guesses (a loose corrector, long steps, one-sided Jacobians, the way back
//! skipped when it would retrace the first branch), so the states it reports are checked here
//! against an independent route: a fully analysed branch at a fine step in both directions,
//! every crossing of the operating order solved at the full tolerance.

use crate::support::cpva_hbm;
use crate::support::scratch;
use kanedyn::hbm::{ContinuationOptions, HbmOptions, HbmSolution};
use kanedyn::study::{RunOptions, Study, run};

/// The paper's rotor at 1000 rpm with 40 N·m at order 3: its folds (2.9403761, 3.1740911)
/// bracket n = 3, so three states coexist there: the low and high ones stable, the middle one
/// not.
#[test]
fn the_multi_order_states_are_the_three_states_of_a_fine_branch() {
    let tmp = scratch("multi-states");
    let dir = tmp.path().to_path_buf();
    let mech = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/cpva.ron")).unwrap();
    std::fs::write(dir.join("cpva.ron"), mech).unwrap();
    let study = String::from(
        r#"Study(name: "three", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor",
    analyses: [MultiOrder(name: "multi", order: 3.0, multiples: [1.0],
        speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 40.0)])],
        hbm: true, time_domain: false)])"#,
    );
    std::fs::write(dir.join("s.ron"), study).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let states = &report.multi[0].speeds[0].hbm;

    // The reference: the analysed branch at a step of 0.005, both ways.
    let mut hbm = cpva_hbm::cpva_hbm(&cpva_hbm::single(40.0), HbmOptions::default());
    let copts = ContinuationOptions { ds_max: 0.005, ds: 0.005, max_points: 20_000, ..Default::default() };
    let mut reference: Vec<(f64, bool)> = Vec::new();
    for (from, to) in [(3.3, 2.9), (2.9, 3.3)] {
        let branch = hbm.continue_in_order(from, to, None, &copts).unwrap();
        let guesses: Vec<HbmSolution> = branch.guesses_at(3.0).into_iter().cloned().collect();
        for g in &guesses {
            let sol = hbm.solve(3.0, Some(g)).unwrap();
            let a = sol.order_acceleration(0, 1.0);
            if !reference.iter().any(|(b, _)| (a / b - 1.0).abs() < 1e-8) {
                reference.push((a, hbm.stability(&sol).unwrap().stable));
            }
        }
    }
    reference.sort_by(|x, y| x.0.total_cmp(&y.0));
    println!("reference {reference:?}");
    println!("multi-order {:?}", states.iter().map(|s| (s.amplitudes[0], s.stable)).collect::<Vec<_>>());
    assert_eq!(reference.len(), 3, "three states at n = 3");
    assert_eq!(reference.iter().map(|r| r.1).collect::<Vec<_>>(), [true, false, true]);
    assert_eq!(states.len(), 3, "the multi-order analysis finds all three");
    // Both are Newton solutions at 1e-10 on the coefficients: the amplitudes agree to ~1e-9.
    for (s, (a, stable)) in states.iter().zip(&reference) {
        let e = (s.amplitudes[0] / a - 1.0).abs();
        assert!(e < 1e-9, "{} against {a} rad/s²: {e:e}", s.amplitudes[0]);
        assert_eq!(s.stable, Some(*stable));
    }
}
