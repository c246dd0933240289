//! Issue 30's stiff case, timed in one process: the 60 s order sweep (n 2.9–3.3, 40 N·m, 1000
//! rpm) on one pendulum (`benches/studies/sweep60_p1.ron`, the yardstick) and on the pendulum at
//! the end of a 16-disk elastic shaft (top mode 3.0 kHz) with explicit DOP853
//! (`sweep60_shaft16.ron`, where `Auto` picks it) and with implicit Radau IIA
//! (`sweep60_shaft16_implicit.ron`). The three run in turn `STIFF_ROUNDS` times (default 3); the
//! median of each and the ratios to the one-pendulum sweep are printed, with each run's steps.
//! The whole-process figures of BENCHMARKS.md ("Stiff shafts") come from whole-process runs
//! alternated (`/usr/bin/time -v`) on the same three files.
//!
//! ```text
//! cargo bench --bench stiff
//! ```

use kanedyn::study::{RunOptions, Study, run};
use std::path::Path;
use std::time::Instant;

fn main() {
    let rounds: usize = std::env::var("STIFF_ROUNDS").ok().and_then(|v| v.parse().ok()).unwrap_or(3);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/studies");
    let out = std::env::temp_dir().join(format!("kanedyn_bench_stiff_{}", std::process::id()));
    let cases = ["sweep60_p1.ron", "sweep60_shaft16.ron", "sweep60_shaft16_implicit.ron"];
    let studies: Vec<Study> =
        cases.iter().map(|f| Study::from_file(&root.join(f)).unwrap_or_else(|e| panic!("{e}"))).collect();
    let mut times = vec![Vec::new(); cases.len()];
    for _ in 0..rounds {
        for (k, study) in studies.iter().enumerate() {
            let t0 = Instant::now();
            let report = run(study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
            times[k].push(t0.elapsed().as_secs_f64());
            assert!(report.failures.is_empty(), "{:?}", report.failures);
            let sim = &report.sweeps[0].sim;
            if times[k].len() == 1 {
                let why = sim.integrator.as_ref().map_or(String::new(), |c| format!("{:?}: {}", c.method, c.reason));
                println!("{:32} {}; {why}", cases[k], sim.stats);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let m: Vec<f64> = times.iter_mut().map(median).collect();
    for (k, case) in cases.iter().enumerate() {
        println!("{case:32} median {:8.3} s over {rounds} runs  = {:6.1}× one pendulum", m[k], m[k] / m[0]);
    }
    let _ = std::fs::remove_dir_all(&out);
}
