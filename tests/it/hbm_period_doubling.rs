//! Period doubling on a harmonic-balance branch (issue 26, item 2: a −1 crossing checked by an
//! independent periodic-orbit solver).
//!
//! The example: the paper's rotor with its pendulum tuned to n_t = 1.55, half the excitation
//! order's neighbourhood, at 1000 rpm under 400 N·m of order n. Near n = 2 n_t = 3.1 the rotor's
//! order-n oscillation pumps the pendulum parametrically (a Mathieu resonance): its Floquet pair
//! meets on the negative real axis and one multiplier leaves the unit circle through −1, so the
//! order-n response loses stability to a motion of period 2·(2π/nΩ) in a narrow tongue
//! (≈ 4e-4 wide in n at this torque and pivot damping), and regains it at the tongue's far side.

use crate::support::cpva_hbm;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use crate::support::shooting::shooting_multipliers;
use cpva_hbm::{RPM, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{BifurcationClass, Branch, ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Order};
use std::f64::consts::PI;

/// Torque amplitude, N·m.
const TORQUE: f64 = 400.0;

fn params() -> CpvaParams {
    CpvaParams { n_t: 1.55, ..CpvaParams::canonical() }
}

/// The order branch from `from` to `to` with the step limit `ds_max`.
fn branch(from: f64, to: f64, ds_max: f64) -> (Hbm, Branch) {
    let kane = Kane::new(&params().mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(TORQUE), HbmOptions::default()).unwrap();
    let copts = ContinuationOptions {
        ds_max,
        ds: ContinuationOptions::default().ds.min(ds_max),
        max_points: 20_000,
        ..Default::default()
    };
    let b = hbm.continue_in_order(from, to, None, &copts).unwrap();
    (hbm, b)
}

fn period_doublings(b: &Branch) -> Vec<f64> {
    let mut v: Vec<f64> =
        b.bifurcations.iter().filter(|x| x.class == BifurcationClass::PeriodDoubling).map(|x| x.order).collect();
    v.sort_by(f64::total_cmp);
    v
}

/// Both edges of the tongue are found and classified as period doublings; at each, checked by a
/// shooting solver written here (DOP853 at 1e-12, the monodromy by central differences of whole
/// periods): 2e-6 on the stable side every physical multiplier lies inside the unit circle, 2e-6
/// on the other side exactly one lies outside, real and below −1. The margin: the crossing
/// multiplier sits 2.7e-6 from −1 at 2e-6 from either edge (measured: −0.9999972 and −1.0000027
/// around the first), and the differenced monodromy is good to ~1e-7; the harmonic balance's own
/// multipliers equal these to ~1e-9.
#[test]
fn a_period_doubling_is_a_minus_one_multiplier_of_shooting() {
    let (mut hbm, b) = branch(2.8, 3.4, 0.1);
    let pd = period_doublings(&b);
    println!("period doublings {pd:?}");
    assert_eq!(pd.len(), 2, "{:?}", b.bifurcations);
    assert!(abs_diff_eq!(pd[0], 3.1, epsilon = 0.01) && pd[1] - pd[0] > 0.0 && pd[1] - pd[0] < 1e-3, "{pd:?}");
    for (edge, inside_after) in [(pd[0], true), (pd[1], false)] {
        let mut outside = Vec::new();
        for n in [edge - 2e-6, edge + 2e-6] {
            let sol = hbm.solve(n, b.guesses_at(n).first().copied()).unwrap();
            let exc = Excitation {
                mean: sol.mean_torque,
                rpm: RPM,
                order: Order::Fixed(n),
                harmonics: single(TORQUE),
                ramp_s: 0.0,
            };
            let mut kane = Kane::new(&params().mechanism(Some(exc)).unwrap()).unwrap();
            let mu = shooting_multipliers(&mut kane, &hbm.state_at(&sol, 0.0), 2.0 * PI / sol.base_frequency);
            println!("n = {n:.8}: shooting multipliers {mu:?}");
            let out: Vec<_> = mu.iter().filter(|m| m.norm() > 1.0).collect();
            assert!(out.iter().all(|m| m.im == 0.0 && m.re < -1.0), "n = {n}: {mu:?}");
            outside.push(out.len());
        }
        assert_eq!(outside, if inside_after { vec![0, 1] } else { vec![1, 0] }, "edge {edge}");
    }
}

/// The tongue's edges do not depend on the continuation's step limit (issue 26, item 2): at the
/// default limit (0.1), 0.02 and 0.001 the branch finds both period doublings at the same
/// orders to 1e-8 (each is located on the multipliers to the corrector's tolerance). The tongue
/// is 4.3e-4 wide: at every limit here both edges can fall inside one step.
#[test]
fn period_doublings_do_not_depend_on_the_step() {
    let mut found: Vec<Vec<f64>> = Vec::new();
    for ds_max in [0.1, 0.02, 0.001] {
        let (_, b) = branch(2.8, 3.4, ds_max);
        let pd = period_doublings(&b);
        println!("ds_max {ds_max}: {} points, period doublings {pd:?}", b.points.len());
        assert_eq!(pd.len(), 2, "ds_max {ds_max}: {:?}", b.bifurcations);
        found.push(pd);
    }
    for pd in &found[1..] {
        for (a, b) in pd.iter().zip(&found[0]) {
            assert_abs_diff_eq!(a, b, epsilon = 1e-8);
        }
    }
}
