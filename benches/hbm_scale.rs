//! The general route at scale against its baseline in one run: whole harmonic-balance branches of
//! the canonical CPVA at 1000 rpm, 40 N·m, H = 10, n 2.9 → 3.3 and back, Floquet stability at
//! every point, for the one-pendulum rotor (the baseline) and for the rotor with 16 pendulums
//! mistuned by ±1 % (pendulum j's mass times `1 + 0.01 (2j/15 − 1)`, the paper's pendulum split
//! evenly as in `CpvaParams::with_pendulums`; not identical, so `RoutedHbm::new` takes the
//! general route, 17 coordinates, 357 unknowns). Best of `runs` per branch and the ratio to the
//! baseline measured in the same run.
//!
//! ```text
//! cargo bench --bench hbm_scale
//! HBM_SCALE_ONLY=16 cargo bench --bench hbm_scale     # the 16 pendulums once (for a profiler)
//! ```

#[path = "../tests/support/cpva_hbm.rs"]
mod cpva_hbm;

use cpva_hbm::{cpva_hbm, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{ContinuationOptions, HbmOptions, RoutedHbm};
use kanedyn::kane::Kane;
use std::time::Instant;

const TORQUE: f64 = 40.0;
const PENDULUMS: usize = 16;

/// One branch summary: best wall time (s), points, corrector iterations, bifurcations.
struct Run {
    best: f64,
    points: usize,
    newton: usize,
    events: usize,
}

fn one_pendulum(from: f64, to: f64, runs: usize) -> Run {
    let mut r = Run { best: f64::INFINITY, points: 0, newton: 0, events: 0 };
    for _ in 0..runs {
        let mut hbm = cpva_hbm(&single(TORQUE), HbmOptions::default());
        let t0 = Instant::now();
        let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
        r.best = r.best.min(t0.elapsed().as_secs_f64());
        (r.points, r.newton, r.events) = (b.points.len(), b.newton_iterations, b.bifurcations.len());
    }
    r
}

fn mistuned(from: f64, to: f64, runs: usize) -> Run {
    let mut mech = CpvaParams::canonical().with_pendulums(PENDULUMS).mechanism(None).unwrap();
    for j in 0..PENDULUMS {
        let body = mech.body_index(&format!("pendulum_{}", j + 1)).unwrap();
        mech.bodies[body].inertia.mass *= 1.0 + 0.01 * (2.0 * j as f64 / (PENDULUMS - 1) as f64 - 1.0);
    }
    let kane = Kane::new(&mech).unwrap();
    let forcing = (&single(TORQUE)[..], &[][..]);
    let mut r = Run { best: f64::INFINITY, points: 0, newton: 0, events: 0 };
    for _ in 0..runs {
        let mut hbm = RoutedHbm::new(&kane, 0, omega(), forcing, &[(0, 1.0, 0.0)], HbmOptions::default()).unwrap();
        assert_eq!(hbm.route().name(), "general");
        let t0 = Instant::now();
        let dsmax: f64 = std::env::var("HBM_SCALE_DSMAX").ok().and_then(|v| v.parse().ok()).unwrap_or(0.1);
        let b = hbm
            .continue_in_order(from, to, None, &ContinuationOptions { ds_max: dsmax, ..Default::default() })
            .unwrap();
        r.best = r.best.min(t0.elapsed().as_secs_f64());
        (r.points, r.newton, r.events) = (b.points.len(), b.newton_iterations, b.bifurcations.len());
        for p in b.bifurcations.iter() {
            println!("  {:?} {:.9}", p.kind, p.order);
        }
    }
    r
}

fn main() {
    let only16 = std::env::var("HBM_SCALE_ONLY").is_ok_and(|v| v == "16");
    let runs: usize = std::env::var("HBM_SCALE_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let (mut t1, mut t16) = (0.0, 0.0);
    for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
        if only16 {
            let m = mistuned(from, to, 1);
            println!(
                "hbm_scale: {PENDULUMS} mistuned, {from} → {to}: {} points, {} corrector iterations, {} events, {:.1} ms",
                m.points,
                m.newton,
                m.events,
                m.best * 1e3
            );
            continue;
        }
        let one = one_pendulum(from, to, 5 * runs);
        let m = mistuned(from, to, runs);
        t1 += one.best;
        t16 += m.best;
        println!(
            "hbm_scale: {TORQUE} N·m, {from} → {to}: 1 pendulum {} points, {} events, {:.2} ms ({:.3} ms/point); \
             {PENDULUMS} mistuned {} points, {} events, {} corrector iterations, {:.1} ms ({:.2} ms/point): ratio \
             {:.1} per branch, {:.1} per point",
            one.points,
            one.events,
            one.best * 1e3,
            one.best * 1e3 / one.points as f64,
            m.points,
            m.events,
            m.newton,
            m.best * 1e3,
            m.best * 1e3 / m.points as f64,
            m.best / one.best,
            (m.best / m.points as f64) / (one.best / one.points as f64),
        );
    }
    if !only16 {
        println!("hbm_scale: both directions, {PENDULUMS} mistuned / 1 pendulum: ratio {:.1}", t16 / t1);
    }
}
