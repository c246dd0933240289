//! Timing of whole harmonic-balance branches of the canonical CPVA at 1000 rpm: 2.9 → 3.3 and
//! 3.3 → 2.9 at 40 and 500 N·m, Floquet stability at every point; per branch the best of 5 runs,
//! with its points and corrector iterations. Under callgrind its instruction count is the
//! repeatable figure of BENCHMARKS.md's harmonic-balance section.
//!
//! ```text
//! cargo bench --bench hbm_branches
//! cargo bench --bench hbm_branches --no-run     # then: valgrind --tool=callgrind target/release/deps/hbm_branches-<hash>
//! ```

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)] // the design family is for the sensitivity bench
mod cpva_hbm;

use cpva_hbm::{cpva_hbm, single};
use kanedyn::hbm::{ContinuationOptions, HbmOptions};
use std::time::Instant;

fn main() {
    for &torque in &[40.0, 500.0] {
        for (from, to) in [(2.9, 3.3), (3.3, 2.9)] {
            let mut best = f64::INFINITY;
            let (mut pts, mut newton) = (0, 0);
            for _ in 0..5 {
                let mut hbm = cpva_hbm(&single(torque), HbmOptions::default());
                let t0 = Instant::now();
                let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
                best = best.min(t0.elapsed().as_secs_f64());
                pts = b.points.len();
                newton = b.newton_iterations;
            }
            println!(
                "hbm_branches: {torque} N·m: branch {from} → {to} with {pts} points in {:.1} ms (best of 5), {newton} corrector iterations",
                best * 1e3
            );
        }
    }
}
