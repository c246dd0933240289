//! The cyclic route against its baseline in one run: whole harmonic-balance branches of the
//! canonical CPVA at 1000 rpm, 500 N·m, H = 10, n 2.9 → 3.3 and back, Floquet stability at every
//! point, for the one-pendulum rotor (the baseline, general route) and the rotor with 32
//! identical pendulums (cyclic route, chosen by `RoutedHbm::new`); best of 5 per branch, and the
//! ratio to the baseline measured in the same run. Once, for scale, the 32 pendulums on the
//! general route (2.9 → 3.3 only: seconds). Each branch also without the localisation of its
//! folds and crossings (`refine_folds: false`): 32 identical pendulums have two symmetry-breaking
//! crossings on the 2.9 → 3.3 branch that one pendulum does not have, and locating them (30
//! bisection solves each, `continuation.rs`) is most of the difference there.
//!
//! ```text
//! cargo bench --bench hbm_cyclic
//! ```

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)] // the design family is for the sensitivity bench
mod cpva_hbm;

use cpva_hbm::{cpva_hbm, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{ContinuationOptions, HbmOptions, RoutedHbm};
use kanedyn::kane::Kane;
use std::time::Instant;

const TORQUE: f64 = 500.0;

/// Best-of-`runs` wall time (s) and the point and crossing counts of the branch from `from` to
/// `to` for N pendulums, on the automatic route or the general one (N = 1: the plain `Hbm` of
/// the tests, the baseline).
fn time(n: usize, from: f64, to: f64, general: bool, runs: usize, copts: &ContinuationOptions) -> (f64, usize, usize) {
    let mech = CpvaParams::canonical().with_pendulums(n).mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let forcing = (&single(TORQUE)[..], &[][..]);
    let (mut best, mut points, mut crossings) = (f64::INFINITY, 0, 0);
    for _ in 0..runs {
        let opts = HbmOptions::default();
        if n == 1 {
            let mut hbm = cpva_hbm(&single(TORQUE), opts);
            let t0 = Instant::now();
            let b = hbm.continue_in_order(from, to, None, copts).unwrap();
            best = best.min(t0.elapsed().as_secs_f64());
            (points, crossings) = (b.points.len(), b.bifurcations.len());
            continue;
        }
        let mut hbm = if general {
            RoutedHbm::new_general(&kane, 0, omega(), forcing, &[(0, 1.0, 0.0)], opts)
        } else {
            RoutedHbm::new(&kane, 0, omega(), forcing, &[(0, 1.0, 0.0)], opts)
        }
        .unwrap();
        let t0 = Instant::now();
        let b = hbm.continue_in_order(from, to, None, copts).unwrap();
        best = best.min(t0.elapsed().as_secs_f64());
        (points, crossings) = (b.points.len(), b.bifurcations.len());
        assert_eq!(hbm.route().name(), if general { "general" } else { "cyclic" });
    }
    (best, points, crossings)
}

fn main() {
    let located = ContinuationOptions::default();
    let plain = ContinuationOptions { refine_folds: false, ..located };
    for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
        for (what, copts) in [("located", &located), ("not located", &plain)] {
            let (t1, p1, c1) = time(1, from, to, false, 5, copts);
            let (t32, p32, c32) = time(32, from, to, false, 5, copts);
            println!(
                "hbm_cyclic: {TORQUE} N·m, {from} → {to}, crossings {what}: 1 pendulum {p1} points, {c1} crossings, \
                 {:.2} ms; 32 pendulums (cyclic) {p32} points, {c32} crossings, {:.2} ms: ratio {:.2} (best of 5 each)",
                t1 * 1e3,
                t32 * 1e3,
                t32 / t1
            );
            if from < to && copts.refine_folds {
                let (tg, pg, cg) = time(32, from, to, true, 1, copts);
                println!(
                    "hbm_cyclic: {TORQUE} N·m, {from} → {to}: 32 pendulums on the general route {pg} points, {cg} \
                     crossings, {:.0} ms (one run): ratio {:.0} to 1 pendulum, {:.0} to the cyclic route",
                    tg * 1e3,
                    tg / t1,
                    tg / t32
                );
            }
        }
    }
}
