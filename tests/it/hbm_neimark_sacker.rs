//! Issue 26, item 2: a Neimark–Sacker point found by harmonic balance, checked by the shooting
//! solver written for these tests (`support::shooting`: DOP853 at 1e-12, the monodromy by central
//! differences of whole periods). The example: the paper's absorber on an elastic shaft behind a
//! spinning hub (examples/shaft_cpva.ron) with a rotor loss of 2 N·m·s/rad, 1000 rpm, 40 N·m at
//! order n; continued down from n = 3.4, its high-amplitude branch loses stability to a complex
//! pair of multipliers near n = 2.995 (the absorber's swing beats against the shaft mode).

use crate::support::scratch;
use crate::support::shooting::shooting_multipliers;
use crate::support::wound_shaft::WOUND;
use kanedyn::hbm::{BifurcationClass, ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::mechanism::Mechanism;
use std::f64::consts::PI;

/// The located Neimark–Sacker point does not depend on the step (0.1, 0.02: to 1e-7; measured
/// 2e-11), and 5e-4 either side of it the shooting monodromy's multipliers are all inside the
/// unit circle (stable side) and a complex pair (Im ≠ 0, the same modulus) is outside (unstable
/// side). The pair's modulus moves by 3e-5 over that distance (measured 0.99997 and 1.00003),
/// thirty times the differenced monodromy's accuracy (~1e-6).
#[test]
fn a_neimark_sacker_point_is_a_complex_pair_through_the_unit_circle_of_shooting() {
    let tmp = scratch("ns");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), WOUND).unwrap();
    let mech = Mechanism::from_file(&dir.join("m.ron")).unwrap();
    let spin = mech.joint_index("spin").unwrap();
    let (rpm, torque) = (1000.0, 40.0);
    let harmonics = vec![Harmonic { multiple: 1.0, amplitude: torque, phase: 0.0 }];
    let mut hbm =
        Hbm::new(&Kane::new(&mech).unwrap(), spin, rpm * PI / 30.0, &harmonics, HbmOptions::default()).unwrap();
    let mut found = Vec::new();
    for ds_max in [0.1, 0.02] {
        let copts =
            ContinuationOptions { ds_max, ds: ContinuationOptions::default().ds.min(ds_max), ..Default::default() };
        let b = hbm.continue_in_order(3.4, 2.8, None, &copts).unwrap();
        let ns: Vec<f64> =
            b.bifurcations.iter().filter(|x| x.class == BifurcationClass::NeimarkSacker).map(|x| x.order).collect();
        println!("ds_max {ds_max}: Neimark–Sacker at {ns:?}");
        found.push((ns.iter().copied().fold(f64::NAN, f64::max), b));
    }
    let (n_ns, branch) = (found[0].0, &found[0].1);
    assert!((n_ns - 2.995).abs() < 0.01, "{n_ns}");
    assert!((found[1].0 - n_ns).abs() <= 1e-7, "{} vs {n_ns}", found[1].0);
    let mut outside = Vec::new();
    for n in [n_ns + 5e-4, n_ns - 5e-4] {
        let guess = branch.guesses_at(n).into_iter().next().expect("the branch passes n");
        let sol = hbm.solve(n, Some(guess)).unwrap();
        let exc = Excitation {
            mean: sol.mean_torque,
            rpm,
            order: Order::Fixed(n),
            harmonics: harmonics.clone(),
            ramp_s: 0.0,
        };
        let mut kane = Kane::new(&mech).unwrap();
        kane.set_joint_torque(spin, exc);
        let mu = shooting_multipliers(&mut kane, &hbm.state_at(&sol, 0.0), 2.0 * PI / sol.base_frequency);
        let out: Vec<_> = mu.iter().filter(|m| m.norm() > 1.0).copied().collect();
        println!(
            "n = {n:.7}: shooting multipliers {mu:?}, moduli {:?}",
            mu.iter().map(|m| m.norm()).collect::<Vec<_>>()
        );
        outside.push(out);
    }
    assert!(outside[0].is_empty(), "stable above the point: {:?}", outside[0]);
    assert_eq!(outside[1].len(), 2, "a pair outside below it: {:?}", outside[1]);
    let (a, b) = (outside[1][0], outside[1][1]);
    assert!(a.im.abs() > 0.01 && (a - b.conj()).norm() <= 1e-9 * a.norm(), "a complex pair: {a} {b}");
}
