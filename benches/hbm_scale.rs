//! The general route at scale against its baseline in one run: whole harmonic-balance branches of
//! the canonical CPVA at 1000 rpm, 40 N·m, H = 10, n 2.9 → 3.3 and back, Floquet stability at
//! every point, for the one-pendulum rotor (the baseline) and for the rotor with 16 pendulums
//! mistuned by ±1 % (pendulum j's mass times `1 + 0.01 (2j/15 − 1)`, j = 0…15, the paper's
//! pendulum split evenly as in `CpvaParams::with_pendulums`; not identical, so `RoutedHbm::new`
//! takes the general route: 17 coordinates, 357 unknowns). Best of 5·`runs` (one pendulum) and
//! of `runs` (16) per branch, and the ratios to the baseline measured in the same run.
//!
//! ```text
//! cargo bench --bench hbm_scale
//! HBM_SCALE_ONLY=16 cargo bench --bench hbm_scale     # the 16 pendulums once (for a profiler)
//! HBM_SCALE_RUNS=1 cargo bench --bench hbm_scale      # fewer repetitions (default 3)
//! HBM_SCALE_FLOOR=1 cargo bench --bench hbm_scale     # and the per-point floor (below)
//! ```
//!
//! The floor: the work every accepted point of a branch with events at any step must do, summed
//! over the 16-pendulum branches' points and set against the one-pendulum branches — its Floquet
//! analysis (`stability` called a second time at the point, so the Jacobian it reuses is not
//! counted) and one Newton solve from the converged point (one Jacobian, one factorisation, the
//! tangent's share), each timed alone.

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)] // the design family is for the sensitivity bench
mod cpva_hbm;

use cpva_hbm::{cpva_hbm, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{Branch, ContinuationOptions, HbmOptions, RoutedHbm};
use kanedyn::kane::Kane;
use std::time::Instant;

const TORQUE: f64 = 40.0;
const PENDULUMS: usize = 16;

/// One branch's figures: best wall time (s), points, corrector iterations, and its bifurcations
/// in words.
struct Run {
    best: f64,
    points: usize,
    newton: usize,
    events: Vec<String>,
    /// The floor's two parts summed over the points (s): Floquet analyses, converged re-solves.
    floor: (f64, f64),
}

impl Run {
    fn new() -> Self {
        Self { best: f64::INFINITY, points: 0, newton: 0, events: Vec::new(), floor: (0.0, 0.0) }
    }

    fn record(&mut self, seconds: f64, b: &Branch) {
        self.best = self.best.min(seconds);
        (self.points, self.newton) = (b.points.len(), b.newton_iterations);
        self.events = b.bifurcations.iter().map(|e| format!("{} at {:.7}", e.class.words(), e.order)).collect();
    }
}

fn one_pendulum(from: f64, to: f64, runs: usize) -> Run {
    let mut r = Run::new();
    for _ in 0..runs {
        let mut hbm = cpva_hbm(&single(TORQUE), HbmOptions::default());
        let t0 = Instant::now();
        let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
        r.record(t0.elapsed().as_secs_f64(), &b);
    }
    r
}

fn mistuned(from: f64, to: f64, runs: usize, floor: bool) -> Run {
    let mut mech = CpvaParams::canonical().with_pendulums(PENDULUMS).mechanism(None).unwrap();
    for j in 0..PENDULUMS {
        let body = mech.body_index(&format!("pendulum_{}", j + 1)).unwrap();
        mech.bodies[body].inertia.mass *= 1.0 + 0.01 * (2.0 * j as f64 / (PENDULUMS - 1) as f64 - 1.0);
    }
    let kane = Kane::new(&mech).unwrap();
    let forcing = (&single(TORQUE)[..], &[][..]);
    let mut r = Run::new();
    for _ in 0..runs {
        let mut hbm = RoutedHbm::new(&kane, 0, omega(), forcing, &[(0, 1.0, 0.0)], HbmOptions::default()).unwrap();
        assert_eq!(hbm.route().name(), "general");
        let t0 = Instant::now();
        let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
        r.record(t0.elapsed().as_secs_f64(), &b);
        if floor {
            r.floor = (0.0, 0.0);
            for p in &b.points {
                hbm.stability(&p.solution).unwrap();
                let t = Instant::now();
                hbm.stability(&p.solution).unwrap();
                r.floor.0 += t.elapsed().as_secs_f64();
                let t = Instant::now();
                hbm.solve(p.order, Some(&p.solution)).unwrap();
                r.floor.1 += t.elapsed().as_secs_f64();
            }
        }
    }
    r
}

fn main() {
    let only16 = std::env::var("HBM_SCALE_ONLY").is_ok_and(|v| v == "16");
    let runs: usize = std::env::var("HBM_SCALE_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let floor = std::env::var("HBM_SCALE_FLOOR").is_ok();
    let (mut t1, mut t16) = (0.0, 0.0);
    let (mut floor16, mut points16) = ((0.0, 0.0), 0);
    for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
        let m = mistuned(from, to, if only16 { 1 } else { runs }, floor);
        floor16 = (floor16.0 + m.floor.0, floor16.1 + m.floor.1);
        points16 += m.points;
        println!(
            "hbm_scale: {PENDULUMS} mistuned, {from} → {to}: {} points, {} corrector iterations, {:.1} ms \
             ({:.2} ms/point); {}",
            m.points,
            m.newton,
            m.best * 1e3,
            m.best * 1e3 / m.points as f64,
            m.events.join(", ")
        );
        if only16 {
            continue;
        }
        let one = one_pendulum(from, to, 5 * runs);
        t1 += one.best;
        t16 += m.best;
        println!(
            "hbm_scale: 1 pendulum, {from} → {to}: {} points, {} corrector iterations, {:.2} ms ({:.3} ms/point); {}",
            one.points,
            one.newton,
            one.best * 1e3,
            one.best * 1e3 / one.points as f64,
            one.events.join(", ")
        );
        println!(
            "hbm_scale: {TORQUE} N·m, {from} → {to}: {PENDULUMS} mistuned / 1 pendulum: {:.1} per branch, {:.1} per point",
            m.best / one.best,
            (m.best / m.points as f64) / (one.best / one.points as f64),
        );
    }
    if !only16 {
        println!("hbm_scale: both directions, {PENDULUMS} mistuned / 1 pendulum: {:.1}", t16 / t1);
        if floor {
            let per = |s: f64| s * 1e3 / points16 as f64;
            println!(
                "hbm_scale: floor over the {points16} points: Floquet {:.2} ms/point, one solve {:.2} ms/point; \
                 their sum / 1 pendulum's branches: {:.1} ({:.1} at 100 points per branch)",
                per(floor16.0),
                per(floor16.1),
                (floor16.0 + floor16.1) / t1,
                (floor16.0 + floor16.1) / t1 * 200.0 / points16 as f64
            );
        }
    }
}
