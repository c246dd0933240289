//! A driver for counting instructions per right-hand-side call under callgrind (timings on a
//! shared machine are too noisy; instruction counts repeat exactly). Ignored in normal runs:
//!
//! ```text
//! cargo test --release --test rhs_count --no-run
//! RHS_MODE=generic valgrind --tool=callgrind target/release/deps/rhs_count-<hash> --ignored --exact count
//! ```
//!
//! `RHS_MODE` is `generic` (Kane on examples/cpva.ron), `closed` (eq. (7) with the same
//! excitation), `none` (the loop alone, to subtract) or `time` (both, timed in alternating
//! chunks of 10⁴ calls, best chunk of each; run without valgrind, with `--nocapture`);
//! `RHS_CALLS` sets the number of calls (default 10⁶). See BENCHMARKS.md.

use kanedyn::cpva::CpvaParams;
use kanedyn::kane::Kane;
use kanedyn::model::mechanism::Mechanism;
use std::hint::black_box;
use std::path::Path;

#[test]
#[ignore = "instruction-count driver for callgrind, not a test"]
fn count() {
    let mode = std::env::var("RHS_MODE").unwrap_or_else(|_| "none".into());
    let calls: usize = std::env::var("RHS_CALLS").map_or(1_000_000, |s| s.parse().unwrap());
    let mech = Mechanism::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva.ron")).unwrap();
    let excitation = mech.loads.joint_torques[0].excitation.clone();
    let mut kane = Kane::new(&mech).unwrap();
    let cf = CpvaParams::canonical().closed_form();
    // The state of benches/rhs.rs.
    let x = [1234.5, 0.4, 104.9, 108.2];
    let t = 12.345;
    let mut xdot = [0.0; 4];
    let mut acc = 0.0;
    match mode.as_str() {
        "generic" => {
            for _ in 0..calls {
                kane.rhs(black_box(t), black_box(&x), &mut xdot).unwrap();
                acc += black_box(xdot[2]);
            }
        }
        "closed" => {
            for _ in 0..calls {
                let torque = excitation.torque(black_box(t));
                cf.rhs1(torque, black_box(&x), &mut xdot);
                acc += black_box(xdot[2]);
            }
        }
        "time" => {
            // Alternating chunks, the fastest of each kind: robust against other jobs' load.
            let (mut best_g, mut best_c) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..calls / 10_000 {
                let start = std::time::Instant::now();
                for _ in 0..10_000 {
                    kane.rhs(black_box(t), black_box(&x), &mut xdot).unwrap();
                    acc += black_box(xdot[2]);
                }
                best_g = best_g.min(start.elapsed().as_secs_f64() / 1e4);
                let start = std::time::Instant::now();
                for _ in 0..10_000 {
                    let torque = excitation.torque(black_box(t));
                    cf.rhs1(torque, black_box(&x), &mut xdot);
                    acc += black_box(xdot[2]);
                }
                best_c = best_c.min(start.elapsed().as_secs_f64() / 1e4);
            }
            println!(
                "generic {:.1} ns, closed form {:.1} ns, ratio {:.2}",
                best_g * 1e9,
                best_c * 1e9,
                best_g / best_c
            );
        }
        "none" => {
            for _ in 0..calls {
                acc += black_box(xdot[2]);
            }
        }
        other => panic!("unknown RHS_MODE `{other}`"),
    }
    black_box(acc);
}
