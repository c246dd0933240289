//! Period doubling on a harmonic-balance branch (issue 26, item 2: a −1 crossing checked by an
//! independent periodic-orbit solver), and the period-doubled branch switched there (issue 28,
//! item 3, the −1 case).
//!
//! The example: the paper's rotor with its pendulum tuned to n_t = 1.55, half the excitation
//! order's neighbourhood, at 1000 rpm under 400 N·m of order n. Near n = 2 n_t = 3.1 the rotor's
//! order-n oscillation pumps the pendulum parametrically (a Mathieu resonance): its Floquet pair
//! meets on the negative real axis and one multiplier leaves the unit circle through −1, so the
//! order-n response loses stability to a motion of period 2·(2π/nΩ) in a narrow tongue
//! (≈ 4e-4 wide in n at this torque and pivot damping), and regains it at the tongue's far side.

use crate::support::cpva_hbm;
use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use crate::support::shooting::{shooting_multipliers, time_run_defects};
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

/// Torque amplitude of the switching tests, N·m: the paper's largest single-order load.
const SWITCH_TORQUE: f64 = 500.0;

/// The canonical rotor's order branch over n 6.0–6.8 at [`SWITCH_TORQUE`] (its pendulum's
/// parametric resonance near n = 2 × 3.19, the rotor-coupled eigen-order: a tongue of period
/// doubling), and the period-doubled branch switched at its `which`-th period doubling: the
/// problem of half the base frequency (the extra multiple 1/2 at zero amplitude) with H = 20,
/// the period-1 problem's resolution of the order-n harmonics.
fn switched_pd(which: usize) -> (Hbm, f64, Branch) {
    use kanedyn::hbm::{Parameter, Symmetry};
    use kanedyn::model::excitation::Harmonic;
    let kane = Kane::new(&CpvaParams::canonical().mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(SWITCH_TORQUE), HbmOptions::default()).unwrap();
    let copts = ContinuationOptions::default();
    let b = hbm.continue_in_order(6.0, 6.8, None, &copts).unwrap();
    let pd = period_doublings(&b);
    assert_eq!(pd.len(), 2, "{:?}", b.bifurcations);
    let mut halved = single(SWITCH_TORQUE);
    halved.push(Harmonic { multiple: 0.5, amplitude: 0.0, phase: 0.0 });
    let mut doubled =
        Hbm::new(&kane, 0, omega(), &halved, HbmOptions { harmonics: 20, ..HbmOptions::default() }).unwrap();
    let guess = b.guesses_at(pd[which])[0].clone();
    let sw = doubled.switch_at(Parameter::Order, pd[which], &guess, &Symmetry::HalfPeriod, (6.0, 6.8), &copts).unwrap();
    (doubled, pd[which], sw)
}

/// The mechanism with the excitation of `sol` for a time integration (its mean torque, order
/// and amplitude).
fn excited_kane(sol: &kanedyn::hbm::HbmSolution) -> Kane {
    let exc = Excitation {
        mean: sol.mean_torque,
        rpm: RPM,
        order: Order::Fixed(sol.order),
        harmonics: single(SWITCH_TORQUE),
        ramp_s: 0.0,
    };
    Kane::new(&CpvaParams::canonical().mechanism(Some(exc)).unwrap()).unwrap()
}

/// Both period-doubled branches start at their period doubling (the first point within 1e-5 in
/// n: the predictor's offset moves the order by its square) with a small subharmonic, the
/// pendulum's order-n/2 amplitude, that grows along the branch, while the state after one
/// excitation period differs from the start (the motion repeats only after two). Each branch's
/// stability is that of shooting with period 2·(2π/nΩ) written in the test: at its ninth point
/// the branch from the lower edge has a multiplier more than 1e-3 outside the unit circle (far
/// beyond the differenced monodromy's ~1e-7), the one from the upper edge none (the largest
/// there is the rotor speed's, just below 1: the mean torque is held in the time equations).
#[test]
fn period_doubled_branches_start_at_the_doublings_and_carry_the_half_order() {
    for which in [0, 1] {
        let (hbm, at, sw) = switched_pd(which);
        let first = &sw.points[0];
        let half = |p: &kanedyn::hbm::BranchPoint| p.solution.amplitude(1, 1);
        println!(
            "from {at:.8}: first n {:.8}, half-order amplitude {:.2e} → {:.3} rad at n {:.5}, end {:?}",
            first.order,
            half(first),
            half(&sw.points[4]),
            sw.points[4].order,
            sw.end
        );
        assert!((first.order - at).abs() < 1e-5, "{} vs {at}", first.order);
        assert!(half(first) > 0.0 && half(first) < 0.01, "{}", half(first));
        assert!(half(&sw.points[4]) > 10.0 * half(first), "the subharmonic grows along the branch");
        let sol = &sw.points[8].solution;
        let period = 2.0 * PI / (sol.order * omega());
        let (x0, x1) = (hbm.state_at(sol, 0.0), hbm.state_at(sol, period));
        assert!((x0[1] - x1[1]).abs() > 0.05, "period 2: pendulum {} vs {}", x0[1], x1[1]);
        let mut kane = excited_kane(sol);
        let mu = shooting_multipliers(&mut kane, &x0, 2.0 * period);
        let largest = mu.iter().map(|m| m.norm()).fold(0.0, f64::max);
        println!("  shooting multipliers at n {:.6}: {mu:?}; HBM stable {:?}", sol.order, sw.points[8].stable);
        if which == 0 {
            assert!(largest > 1.0 + 1e-3 && sw.points[8].stable == Some(false), "{mu:?}");
        } else {
            assert!(largest < 1.0 && sw.points[8].stable == Some(true), "{mu:?}");
        }
    }
}

/// The stable period-doubled branch agrees with a time integration started on it (the issue's
/// bound for a switched branch): DOP853 at 1e-10 from its state at the point with the largest
/// subharmonic below 0.5 rad, 100 doubled periods, then over one doubled period at 24 instants
/// every state but the spin angle (a gauge) matches the harmonic balance to 5e-3 of its own
/// largest magnitude (the rotor speed to 5e-3 of its oscillation).
#[test]
fn the_period_doubled_branch_agrees_with_time_integration() {
    let (hbm, _, sw) = switched_pd(1);
    let point = sw
        .points
        .iter()
        .filter(|p| p.stable == Some(true) && p.solution.amplitude(1, 1) < 0.5)
        .max_by(|a, b| a.solution.amplitude(1, 1).total_cmp(&b.solution.amplitude(1, 1)))
        .expect("a stable point");
    let sol = &point.solution;
    println!("n = {:.7}: half-order amplitude {:.4} rad", sol.order, sol.amplitude(1, 1));
    let worst = time_run_defects(&hbm, sol, &mut excited_kane(sol), 100.0);
    println!("relative differences per state (spin angle skipped): {worst:?}");
    assert!(worst.iter().all(|w| *w <= 5e-3), "{worst:?}");
}

/// A half-period switch needs the problem of half the base frequency, and a period doubling
/// where it is asked: on the period-1 problem it is refused (naming the extra multiple), and on
/// the doubled problem at an order inside no tongue (6.2) the Jacobian is regular.
#[test]
fn a_half_period_switch_is_refused_without_its_problem_or_its_crossing() {
    use kanedyn::hbm::{Parameter, Symmetry};
    use kanedyn::model::excitation::Harmonic;
    let kane = Kane::new(&CpvaParams::canonical().mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(SWITCH_TORQUE), HbmOptions::default()).unwrap();
    let copts = ContinuationOptions::default();
    let guess = hbm.solve(6.2, None).unwrap();
    let e = hbm.switch_at(Parameter::Order, 6.2, &guess, &Symmetry::HalfPeriod, (6.0, 6.8), &copts).unwrap_err();
    println!("{e}");
    assert!(e.to_string().contains("extra multiple"), "{e}");
    let mut halved = single(SWITCH_TORQUE);
    halved.push(Harmonic { multiple: 0.5, amplitude: 0.0, phase: 0.0 });
    let mut doubled =
        Hbm::new(&kane, 0, omega(), &halved, HbmOptions { harmonics: 20, ..HbmOptions::default() }).unwrap();
    let e = doubled.switch_at(Parameter::Order, 6.2, &guess, &Symmetry::HalfPeriod, (6.0, 6.8), &copts).unwrap_err();
    println!("{e}");
    assert!(e.to_string().contains("regular"), "{e}");
}

/// The period doublings of the one-parameter order branch over 6.0–6.8 at `torque` N·m.
fn doublings_at(torque: f64) -> Vec<f64> {
    let kane = Kane::new(&CpvaParams::canonical().mechanism(None).unwrap()).unwrap();
    let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
    period_doublings(&hbm.continue_in_order(6.0, 6.8, None, &ContinuationOptions::default()).unwrap())
}

/// The period-doubling curve in (order, torque): the singularity of the odd-harmonic block of
/// the problem of half the base frequency, followed at states of even harmonics
/// (`Singularity::HalfPeriod`), from the lower edge of the 500 N·m tongue down to the tongue's
/// tip and up its other side. Checked against one-parameter order branches computed apart: it
/// passes through their period doublings at 500 and 2000 N·m (the edges 6.37625/6.38706 and
/// 6.35508/6.40473) to 1e-6 in n, and its least torque (the tip, below which the response never
/// period-doubles) lies inside a bisection on "has a period doubling or not" to 1e-4 relative.
#[test]
fn the_period_doubling_curve_passes_through_the_branches_doublings_and_its_tip() {
    use kanedyn::hbm::{FoldCurveOptions, FoldPlane, Singularity};
    use kanedyn::model::excitation::Harmonic;
    const T_REF: f64 = 500.0;
    let kane = Kane::new(&CpvaParams::canonical().mechanism(None).unwrap()).unwrap();
    let mut one = Hbm::new(&kane, 0, omega(), &single(T_REF), HbmOptions::default()).unwrap();
    let b = one.continue_in_order(6.0, 6.8, None, &ContinuationOptions::default()).unwrap();
    let pd = period_doublings(&b);
    let mut halved = single(T_REF);
    halved.push(Harmonic { multiple: 0.5, amplitude: 0.0, phase: 0.0 });
    let opts = HbmOptions { harmonics: 20, stability_samples: 0, ..HbmOptions::default() };
    let mut doubled = Hbm::new(&kane, 0, omega(), &halved, opts).unwrap();
    let guess = doubled.on_doubled_period(b.guesses_at(pd[0])[0], pd[0]).unwrap();
    let start = doubled.singular_at(FoldPlane::Order, Singularity::HalfPeriod, 1.0, &guess).unwrap();
    println!("start: n {:.9} (branch {:.9})", start.order, pd[0]);
    assert!((start.order - pd[0]).abs() < 1e-6);
    let fopts = FoldCurveOptions {
        range: (6.0, 6.8),
        scales: (0.01, 8.0),
        test: Singularity::HalfPeriod,
        ..FoldCurveOptions::default()
    };
    let down = doubled.continue_fold(FoldPlane::Order, &start, false, &fopts).unwrap();
    let up = doubled.continue_fold(FoldPlane::Order, &start, true, &fopts).unwrap();
    println!(
        "down: {} points, end {:?}, extrema {:?}; up: {} points, end {:?}",
        down.points.len(),
        down.end,
        down.scale_extrema,
        up.points.len(),
        up.end
    );
    // The curve's orders where it crosses torque scale s: from the point before each crossing,
    // solved at that scale.
    let crossings = |doubled: &mut Hbm, s: f64| -> Vec<f64> {
        let all: Vec<_> = down.points.windows(2).chain(up.points.windows(2)).collect();
        let mut v: Vec<f64> = all
            .iter()
            .filter(|w| (w[0].scale - s) * (w[1].scale - s) <= 0.0)
            .map(|w| doubled.singular_at(FoldPlane::Order, Singularity::HalfPeriod, s, &w[0].solution).unwrap().order)
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        v
    };
    for torque in [500.0, 2000.0] {
        let on_curve = crossings(&mut doubled, torque / T_REF);
        let reference = doublings_at(torque);
        println!("{torque} N·m: curve {on_curve:?}, branch {reference:?}");
        assert_eq!(on_curve.len(), 2, "{on_curve:?}");
        for (a, b) in on_curve.iter().zip(&reference) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }
    let tip = down.scale_extrema.first().expect("the tongue's tip");
    let t_tip = tip.scale * T_REF;
    let (mut lo, mut hi) = (0.5 * t_tip, 2.0 * t_tip);
    assert!(doublings_at(lo).is_empty() && doublings_at(hi).len() == 2);
    while hi / lo - 1.0 > 2e-5 {
        let mid = 0.5 * (lo + hi);
        if doublings_at(mid).is_empty() { lo = mid } else { hi = mid }
    }
    println!("tip: curve {t_tip:.6} N·m at n {:.7}; bisection ({lo:.6}, {hi:.6}) N·m", tip.order);
    assert!(t_tip / lo - 1.0 > -1e-4 && t_tip / hi - 1.0 < 1e-4, "{t_tip} vs ({lo}, {hi})");
}

/// The `Envelope` analysis over orders 6.0–6.8 and 100–2000 N·m maps the period-doubling tongue:
/// one boundary of kind `PeriodDoubling` whose orders at 2000 N·m are the one-parameter
/// branch's doublings (1e-6), and its onset, the tongue's tip, inside the bisection on branches
/// of `the_period_doubling_curve_passes_through_the_branches_doublings_and_its_tip`
/// (250.879859–250.882730 N·m; here checked against a fresh bracket of 1e-4 relative).
#[test]
fn the_envelope_maps_the_period_doubling_tongue() {
    let report = envelope_map("pd_map", "cpva.ron", (6.0, 6.8), (100.0, 2000.0));
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let r = &report.envelopes[0];
    assert!(r.period_doubling_search.starts_with("searched"), "{}", r.period_doubling_search);
    let pd: Vec<_> = r.boundaries.iter().filter(|b| format!("{:?}", b.kind) == "PeriodDoubling").collect();
    assert_eq!(pd.len(), 1);
    let reference = doublings_at(2000.0);
    println!("at 2000 N·m: map {:?}, branch {reference:?}", pd[0].at_second_max);
    assert_eq!(pd[0].at_second_max.len(), 2);
    for (a, b) in pd[0].at_second_max.iter().zip(&reference) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
    let tip = r.points.iter().find(|p| format!("{:?}", p.kind) == "PeriodDoublingOnset").expect("the tip");
    println!("tip {} N·m at n {}", tip.second_value, tip.value);
    let (lo, hi) = (tip.second_value * (1.0 - 1e-4), tip.second_value * (1.0 + 1e-4));
    assert!(doublings_at(lo).is_empty() && doublings_at(hi).len() == 2, "tip {}", tip.second_value);
}

/// The envelope skips the search for period doublings where no linear parametric resonance is
/// near (the paper's map over 2.9–3.3, whose eigen-orders 3.11–3.19 lie far from n/2 and 3n/2).
/// That costs nothing there: the order branches at the map's extreme torques, with stability at
/// every point and crossings found at any step, have no period doubling.
#[test]
fn the_envelope_skips_the_doubling_search_only_where_none_exists() {
    let report = envelope_map("pd_skip", "cpva.ron", (2.9, 3.3), (1.0, 500.0));
    let r = &report.envelopes[0];
    assert!(r.period_doubling_search.starts_with("not searched"), "{}", r.period_doubling_search);
    let kane = Kane::new(&CpvaParams::canonical().mechanism(None).unwrap()).unwrap();
    for torque in [1.0, 40.0, 500.0] {
        let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
        for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
            let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
            assert!(period_doublings(&b).is_empty(), "{torque} N·m {from}→{to}: {:?}", period_doublings(&b));
        }
    }
}

/// Two identical pendulums (the paper's split in two, `examples/cpva2.ron`, cyclic route) over
/// orders 6.0–6.8 and 100–2000 N·m: besides the unison tongue of the one-pendulum rotor, the
/// pendulums swing at half the order against each other in a tongue of their own, near twice
/// their tuning order 3.11 (the rotor does not take part, so it sits lower than the unison one
/// at 2 × 3.19). The map follows it on the representative's odd-harmonic block
/// (`Singularity::HalfPeriodBlock`). Checked against the general solver (every pendulum an
/// unknown, both tongues in one Jacobian), whose order branch at 2000 N·m, at a step fine
/// enough to see both tongues, has its period doublings at the four orders the map gives at
/// 2000 N·m (1e-6), and the non-unison tongue's tip lies inside a bracket of 1e-4 relative
/// on the general solver's branches.
#[test]
fn the_envelope_maps_the_non_unison_period_doubling_of_two_pendulums() {
    let report = envelope_map("pd_map2", "cpva2.ron", (6.0, 6.8), (100.0, 2000.0));
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let r = &report.envelopes[0];
    assert!(r.route.starts_with("cyclic"), "{}", r.route);
    let pd: Vec<_> = r.boundaries.iter().filter(|b| format!("{:?}", b.kind) == "PeriodDoubling").collect();
    assert_eq!(pd.len(), 2, "{:?}", r.boundaries.iter().map(|b| (&b.kind, &b.set)).collect::<Vec<_>>());
    let non_unison = pd.iter().find(|b| b.set.is_some()).expect("a non-unison tongue");
    let mut mapped: Vec<f64> = pd.iter().flat_map(|b| b.at_second_max.iter().copied()).collect();
    mapped.sort_by(f64::total_cmp);
    let general = |torque: f64| -> Vec<f64> {
        let kane = Kane::new(&CpvaParams::canonical().with_pendulums(2).mechanism(None).unwrap()).unwrap();
        let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
        let copts = ContinuationOptions { ds_max: 0.005, ..ContinuationOptions::default() };
        period_doublings(&hbm.continue_in_order(6.0, 6.8, None, &copts).unwrap())
    };
    let reference = general(2000.0);
    println!("at 2000 N·m: map {mapped:?}, general solver {reference:?}");
    assert_eq!(reference.len(), 4, "{reference:?}");
    for (a, b) in mapped.iter().zip(&reference) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
    // The non-unison tip: the general branch below it has only the unison tongue's two
    // doublings (the unison tip is higher), above it two more.
    let tip = r
        .points
        .iter()
        .find(|p| format!("{:?}", p.kind) == "PeriodDoublingOnset" && r.boundaries[p.boundary].set.is_some())
        .expect("the non-unison tip");
    println!("non-unison tip {} N·m at n {} ({:?})", tip.second_value, tip.value, non_unison.set);
    let (below, above) = (general(tip.second_value * (1.0 - 1e-4)), general(tip.second_value * (1.0 + 1e-4)));
    println!("below: {below:?}, above: {above:?}");
    assert!(below.is_empty() && above.len() == 2, "below {below:?}, above {above:?}");
}

/// Runs a study of one `Envelope` analysis named `env` at 1000 rpm on the example mechanism
/// `mechanism` over `orders` and `torques` (N·m), read as `examples/<name>.ron`, into a fresh
/// folder removed afterwards.
fn envelope_map(name: &str, mechanism: &str, orders: (f64, f64), torques: (f64, f64)) -> kanedyn::study::StudyReport {
    use kanedyn::study::{LoadOptions, RunOptions, Study, run};
    let text = format!(
        "Study(name: \"{name}\", mechanism: \"{mechanism}\", spin_joint: \"spin\", response_body: \"rotor\",\n\
         analyses: [Envelope(name: \"env\", rpm: 1000.0, order_min: {:?}, order_max: {:?}, torque_min: {:?}, \
         torque_max: {:?})])\n",
        orders.0, orders.1, torques.0, torques.1
    );
    let src = kanedyn::io::Source::from_text(&format!("examples/{name}.ron"), &text);
    let study = Study::from_source(src, &LoadOptions::default()).unwrap();
    let tmp = scratch(name);
    let out = tmp.path().to_path_buf();
    run(&study, &RunOptions { out: Some(out), progress: false }).unwrap()
}
