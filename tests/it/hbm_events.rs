//! Events of harmonic-balance branches found at any step (issue 26, item 2): folds and branch
//! points do not depend on the continuation's step limit, the two directions of continuation
//! agree, symmetric absorber sets never stall the stability analysis, and a branch point sits
//! where an independent shooting solver's monodromy matrix has a multiplier through +1.
//!
//! Reference values: the folds of the canonical rotor at 1000 rpm (40 N·m: 2.9403761 and
//! 3.1740911; 5 N·m: 3.1861538 and 3.1871418) were obtained by independent shooting and are
//! quoted in issue 26; the unison-loss points of two pendulums at 500 N·m (3.08137, 3.09461) are
//! the README's, confirmed below by shooting.

use crate::support::cpva_hbm;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use crate::support::shooting::shooting_multipliers;
use cpva_hbm::{RPM, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{BifurcationClass, Branch, BranchEnd, ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Order};
use std::f64::consts::PI;

/// The order branch of `pendulums` identical pendulums (total mass as in the paper) under
/// `torque` N·m, continued from `from` to `to` with the step limit `ds_max`.
fn branch(pendulums: usize, torque: f64, from: f64, to: f64, ds_max: f64) -> (Hbm, Branch) {
    let p = CpvaParams::canonical().with_pendulums(pendulums);
    let kane = Kane::new(&p.mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
    // At the smallest step limit a branch takes up to ~1600 points: room for them.
    let copts = ContinuationOptions {
        ds_max,
        ds: ContinuationOptions::default().ds.min(ds_max),
        max_points: 20_000,
        ..Default::default()
    };
    let b = hbm.continue_in_order(from, to, None, &copts).unwrap();
    (hbm, b)
}

fn of_class(b: &Branch, class: BifurcationClass) -> Vec<f64> {
    let mut v: Vec<f64> = b.bifurcations.iter().filter(|x| x.class == class).map(|x| x.order).collect();
    v.sort_by(f64::total_cmp);
    v
}

/// The step limits swept: the default (0.1), a fifth of it, and a hundredth.
const STEPS: [f64; 3] = [0.1, 0.02, 0.001];

/// Two pendulums at 500 N·m lose unison between two branch points before the fold. At the
/// default step the whole unstable stretch (0.013 wide in n) used to fit inside one step and
/// went unseen. Now every step limit finds both, classified as branch points, at the same
/// orders to 1e-8 (they are located on det ∂R̂/∂x, to the corrector's tolerance), within 1e-5
/// of the README's 3.08137 and 3.09461 (its five digits); the fold is classified as a fold.
#[test]
fn branch_points_do_not_depend_on_the_step() {
    let mut found: Vec<Vec<f64>> = Vec::new();
    for ds_max in STEPS {
        let (_, b) = branch(2, 500.0, 2.9, 3.3, ds_max);
        let bp = of_class(&b, BifurcationClass::BranchPoint);
        println!("ds_max {ds_max}: branch points {bp:?}, folds {:?}", of_class(&b, BifurcationClass::Fold));
        assert_eq!(bp.len(), 2, "ds_max {ds_max}: {:?}", b.bifurcations);
        assert!(abs_diff_eq!(bp[0], 3.08137, epsilon = 1e-5) && abs_diff_eq!(bp[1], 3.09461, epsilon = 1e-5), "{bp:?}");
        let folds = of_class(&b, BifurcationClass::Fold);
        assert_eq!(folds.len(), 1);
        assert_abs_diff_eq!(folds[0], b.folds[0].order, epsilon = 1e-12);
        found.push(bp);
    }
    for bp in &found[1..] {
        for (a, b) in bp.iter().zip(&found[0]) {
            assert_abs_diff_eq!(a, b, epsilon = 1e-8);
        }
    }
}

/// The folds of one pendulum at 40 N·m and at 5 N·m (near the cusp, where the two folds are
/// only 0.001 apart in n) at every step limit and from both ends of the range: within 1e-6 of
/// the shooting values.
#[test]
fn folds_do_not_depend_on_the_step_or_the_direction() {
    for (torque, expected) in [(40.0, [2.9403761, 3.1740911]), (5.0, [3.1861538, 3.1871418])] {
        for ds_max in STEPS {
            for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
                let (_, b) = branch(1, torque, from, to, ds_max);
                let mut folds: Vec<f64> = b.folds.iter().map(|f| f.order).collect();
                folds.sort_by(f64::total_cmp);
                assert_eq!(folds.len(), 2, "{torque} N·m, ds_max {ds_max}, from {from}: {folds:?}");
                for (f, e) in folds.iter().zip(expected) {
                    assert!(
                        abs_diff_eq!(*f, e, epsilon = 1e-6),
                        "{torque} N·m, ds_max {ds_max}, from {from}: fold {f} vs {e}"
                    );
                }
                assert_eq!(of_class(&b, BifurcationClass::Fold), folds);
                assert!(matches!(b.end, BranchEnd::ReachedTarget | BranchEnd::LeftRange), "{:?}", b.end);
            }
        }
    }
}

/// Regression: with 4 identical pendulums at 500 N·m (and 8 at 40 N·m) the monodromy has
/// multipliers repeated 3 (7) times, and nalgebra's uncapped QR never returned on them (minutes
/// without output). Both branches now finish on the general route, with the one-pendulum
/// branch's folds to 1e-8 (the unison response is the one-pendulum response).
#[test]
fn identical_pendulums_never_stall() {
    for (n, torque) in [(4, 500.0), (8, 40.0)] {
        let (_, b) = branch(n, torque, 2.9, 3.3, 0.1);
        let (_, b1) = branch(1, torque, 2.9, 3.3, 0.1);
        assert!(matches!(b.end, BranchEnd::ReachedTarget | BranchEnd::LeftRange), "N = {n}: {:?}", b.end);
        assert_eq!(b.folds.len(), b1.folds.len(), "N = {n}");
        for (f, g) in b.folds.iter().zip(&b1.folds) {
            assert!(abs_diff_eq!(f.order, g.order, epsilon = 1e-8), "N = {n}: fold {} vs {}", f.order, g.order);
        }
        let st = b.points.last().unwrap().solution.stability.as_ref().unwrap();
        assert_eq!(st.multipliers.len(), 2 * (n + 1) - 1);
    }
}

/// The first branch point of two pendulums at 500 N·m, checked by a periodic-orbit solver
/// written here (shooting with DOP853 at 1e-12, the monodromy by central differences of whole
/// periods): 2e-6 below the located order every physical multiplier of the shooting monodromy
/// lies inside the unit circle, 2e-6 above one real multiplier has passed +1. The margin: the
/// crossing multiplier moves by ~4.5e-5 over 2e-6 in n (measured 2.3e-4 over 1e-5), the
/// differenced monodromy is good to ~1e-6 (DOP853 at 1e-12 differenced over 1e-6).
#[test]
fn a_branch_point_is_a_plus_one_multiplier_of_shooting() {
    let (mut hbm, b) = branch(2, 500.0, 2.9, 3.3, 0.1);
    let n_bp = of_class(&b, BifurcationClass::BranchPoint)[0];
    let p2 = CpvaParams::canonical().with_pendulums(2);
    let mut outside = Vec::new();
    for n in [n_bp - 2e-6, n_bp + 2e-6] {
        let sol = hbm.solve(n, b.guesses_at(n).first().copied()).unwrap();
        let exc = Excitation {
            mean: sol.mean_torque,
            rpm: RPM,
            order: Order::Fixed(n),
            harmonics: single(500.0),
            ramp_s: 0.0,
        };
        let mut kane = Kane::new(&p2.mechanism(Some(exc)).unwrap()).unwrap();
        let mu = shooting_multipliers(&mut kane, &hbm.state_at(&sol, 0.0), 2.0 * PI / sol.base_frequency);
        println!("n = {n:.8}: shooting multipliers {mu:?}");
        outside.push(mu.iter().filter(|m| m.norm() > 1.0).count());
    }
    assert_eq!(outside, vec![0, 1]);
}
