//! A driver for counting instructions per right-hand-side call under callgrind (timings on a
//! shared machine are too noisy; instruction counts repeat exactly), and a robust timer.
//! The set-up (engine, closed form, state) is benches/rhs.rs's, from `support/cpva_rhs.rs`.
//!
//! ```text
//! cargo bench --bench rhs_count --no-run        # prints the binary: target/release/deps/rhs_count-<hash>
//! RHS_MODE=none    valgrind --tool=callgrind target/release/deps/rhs_count-<hash>
//! RHS_MODE=generic valgrind --tool=callgrind target/release/deps/rhs_count-<hash>
//! RHS_MODE=closed  valgrind --tool=callgrind target/release/deps/rhs_count-<hash>
//! RHS_MODE=path    valgrind --tool=callgrind target/release/deps/rhs_count-<hash>
//! cargo bench --bench rhs_count                 # RHS_MODE=time, the default
//! ```
//!
//! `RHS_MODE` is `generic` (Kane on examples/cpva.ron), `closed` (eq. (7) with the same
//! excitation), `path` (Kane on examples/cpva_epicycloid.ron), `path_circle` (Kane on its circle
//! twin, the paper's pendulum in s = Lφ; both from `support/path_cpva_rhs.rs`), `pendulums8` and
//! `couplings` (the general path: the paper's rotor with 8 pendulums, and examples/dmf.ron),
//! `none` (the loop alone, to subtract: instructions per call = (Ir − Ir_none) / calls) or `time` (all four, timed
//! in alternating chunks of 10⁴ calls, best chunk of each; the default, run without valgrind). `RHS_CALLS` sets the number of calls (default 10⁶). See
//! BENCHMARKS.md.

#[path = "support/cpva_rhs.rs"]
mod cpva_rhs;
#[path = "support/path_cpva_rhs.rs"]
mod path_cpva_rhs;

use cpva_rhs::{CpvaRhs, T, X};
use std::hint::black_box;

fn main() {
    let mode = std::env::var("RHS_MODE").unwrap_or_else(|_| "time".into());
    let calls: usize = match std::env::var("RHS_CALLS") {
        Ok(s) => s.parse().unwrap_or_else(|_| panic!("RHS_CALLS must be a whole number, got `{s}`")),
        Err(_) => 1_000_000,
    };
    let CpvaRhs { mut kane, excitation, closed: cf } = CpvaRhs::new();
    let (x, t) = (X, T);
    let mut xdot = [0.0; 4];
    let xp = path_cpva_rhs::path_state();
    let (mut epicycloid, mut circle) = (path_cpva_rhs::epicycloid_cpva(), path_cpva_rhs::circle_cpva());
    // The general path: the rotor with 8 pendulums (n = 9, the tree's factorisation) and the
    // dual-mass flywheel (couplings: the general forms at a literal n). Built for every mode, so
    // that `none` subtracts their set-up too.
    let general = |mech: kanedyn::model::mechanism::Mechanism| {
        let n = mech.ndof();
        let x: Vec<f64> = (0..2 * n).map(|i| 0.1 + 0.05 * i as f64).collect();
        (kanedyn::kane::Kane::new(&mech).unwrap(), x, vec![0.0; 2 * n])
    };
    let mut pendulums8 = general(kanedyn::cpva::CpvaParams::canonical().with_pendulums(8).mechanism(None).unwrap());
    let dmf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dmf.ron");
    let mut couplings = general(kanedyn::model::mechanism::Mechanism::from_file(&dmf).unwrap());
    let mut acc = 0.0;
    match mode.as_str() {
        "generic" => {
            for _ in 0..calls {
                kane.rhs(black_box(t), black_box(&x), &mut xdot).unwrap();
                acc += black_box(xdot[2]);
            }
        }
        "path" | "path_circle" => {
            let k = if mode == "path" { &mut epicycloid } else { &mut circle };
            for _ in 0..calls {
                k.rhs(black_box(t), black_box(&xp), &mut xdot).unwrap();
                acc += black_box(xdot[2]);
            }
        }
        "pendulums8" | "couplings" => {
            let (k, xg, xd) = if mode == "pendulums8" { &mut pendulums8 } else { &mut couplings };
            let n = k.ndof();
            for _ in 0..calls {
                k.rhs(black_box(0.5), black_box(xg), xd).unwrap();
                acc += black_box(xd[n]);
            }
        }
        "closed" => {
            // The excitation through `black_box`, as the engine reads its own from memory:
            // inlined here, its loop-invariant part (the rpm → rad/s division) was hoisted.
            for _ in 0..calls {
                let torque = black_box(&excitation).torque(black_box(t));
                cf.rhs1(torque, black_box(&x), &mut xdot);
                acc += black_box(xdot[2]);
            }
        }
        "time" => {
            // Alternating chunks, the fastest of each kind: robust against other jobs' load.
            let (mut best_g, mut best_c) = (f64::INFINITY, f64::INFINITY);
            let (mut best_p, mut best_o) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..calls / 10_000 {
                let start = std::time::Instant::now();
                for _ in 0..10_000 {
                    kane.rhs(black_box(t), black_box(&x), &mut xdot).unwrap();
                    acc += black_box(xdot[2]);
                }
                best_g = best_g.min(start.elapsed().as_secs_f64() / 1e4);
                let start = std::time::Instant::now();
                for _ in 0..10_000 {
                    let torque = black_box(&excitation).torque(black_box(t));
                    cf.rhs1(torque, black_box(&x), &mut xdot);
                    acc += black_box(xdot[2]);
                }
                best_c = best_c.min(start.elapsed().as_secs_f64() / 1e4);
                for (k, best) in [(&mut epicycloid, &mut best_p), (&mut circle, &mut best_o)] {
                    let start = std::time::Instant::now();
                    for _ in 0..10_000 {
                        k.rhs(black_box(t), black_box(&xp), &mut xdot).unwrap();
                        acc += black_box(xdot[2]);
                    }
                    *best = best.min(start.elapsed().as_secs_f64() / 1e4);
                }
            }
            println!(
                "rhs_count: best of {} chunks of 10⁴ calls: generic {:.1} ns, closed form {:.1} ns, ratio {:.2}",
                calls / 10_000,
                best_g * 1e9,
                best_c * 1e9,
                best_g / best_c
            );
            println!(
                "rhs_count: path (epicycloid) {:.1} ns, path (circle) {:.1} ns; ratios to generic {:.2} and {:.2}",
                best_p * 1e9,
                best_o * 1e9,
                best_p / best_g,
                best_o / best_g
            );
        }
        "none" => {
            for _ in 0..calls {
                acc += black_box(xdot[2]);
            }
        }
        other => panic!(
            "unknown RHS_MODE `{other}` (generic, closed, path, path_circle, pendulums8, couplings, none or time)"
        ),
    }
    black_box(acc);
    if mode != "time" {
        println!("rhs_count: RHS_MODE={mode}, {calls} calls (read the instruction count from callgrind)");
    }
}
