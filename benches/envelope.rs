//! Timing of the operating envelope (issue 28's speed criterion): the jump boundary of the
//! paper's rotor (one pendulum) at 1000 rpm over n 2.9–3.3 and 1–500 N·m, whole analysis through
//! the study driver (seed branches, curve, cusp, CSV, SVG), against the grid of up and down order
//! sweeps that would show the same boundary, estimated from one 240 s sweep end to end timed in
//! the same run. Best of 5 each, since the machine may be shared.
//!
//! The grid: one torque level per boundary point inside the map (the curve's own resolution in
//! T), each swept up and down. At the paper's rate (0.4 orders in 240 s) a sweep places the fold
//! it jumps at only to its lag behind the fold (printed, from the up sweep at 40 N·m against the
//! fold 3.1740911); a sweep ten times slower is timed too, with its lag. The curve gives each
//! fold to 1e-10 and its cusp to 1e-10 in dT/dσ, which no grid of sweeps does: the ratios
//! printed are lower bounds.
//!
//! ```text
//! cargo bench --bench envelope
//! ```

use kanedyn::io::Source;
use kanedyn::study::{LoadOptions, RunOptions, Study, run};
use std::time::Instant;

/// The up sweep's jump at 40 N·m: the order after the largest drop of its main-order trace.
fn jump(report: &kanedyn::study::StudyReport) -> f64 {
    let t = report.sweeps[0].trace(1.0).unwrap();
    let k = (1..t.amplitude.len())
        .max_by(|&a, &b| (t.amplitude[a - 1] - t.amplitude[a]).total_cmp(&(t.amplitude[b - 1] - t.amplitude[b])))
        .unwrap();
    t.order[k]
}

/// Best of `runs` runs of the study `text` (read as `examples/<name>.ron`), s, with its report.
fn best_of(runs: usize, name: &str, text: &str) -> (f64, kanedyn::study::StudyReport) {
    let src = Source::from_text(&format!("examples/{name}.ron"), text);
    let study = Study::from_source(src, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let out = std::env::temp_dir().join(format!("kanedyn_bench_envelope_{}", std::process::id()));
    let mut best = f64::INFINITY;
    let mut report = None;
    for _ in 0..runs {
        let t0 = Instant::now();
        let r = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
        best = best.min(t0.elapsed().as_secs_f64());
        assert!(r.failures.is_empty(), "{:?}", r.failures);
        report = Some(r);
    }
    std::fs::remove_dir_all(&out).ok();
    (best, report.unwrap())
}

fn main() {
    let (t_map, map) = best_of(
        5,
        "bench_envelope",
        r#"Study(name: "bench_envelope", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor",
            analyses: [Envelope(name: "envelope", rpm: 1000.0, order_min: 2.9, order_max: 3.3, torque_min: 1.0, torque_max: 500.0)])"#,
    );
    let sweep = |duration: f64| {
        format!(
            r#"Study(name: "bench_sweep", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor",
            analyses: [OrderSweep(name: "sweep", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: {duration}, amplitudes: [40.0], directions: [Up])])"#
        )
    };
    let (t_sweep, paper) = best_of(5, "bench_sweep", &sweep(240.0));
    let (t_slow, slow) = best_of(2, "bench_sweep", &sweep(2400.0));
    let r = &map.envelopes[0];
    let levels: usize =
        r.boundaries.iter().map(|b| b.second_values.iter().filter(|&&t| (1.0..=500.0).contains(&t)).count()).sum();
    println!(
        "envelope: jump boundary over n 2.9–3.3, 1–500 N·m: {:.1} ms (best of 5), {levels} boundary points, {} cusp(s)",
        t_map * 1e3,
        r.points.len()
    );
    for (label, t, rep) in [("240 s", t_sweep, &paper), ("2400 s", t_slow, &slow)] {
        let grid = levels as f64 * 2.0 * t;
        println!(
            "envelope: one {label} sweep end to end {:.1} ms, jump lags the fold by {:.1e}; grid of {levels} levels × up and down {:.1} s = {:.0} × the envelope",
            t * 1e3,
            jump(rep) - 3.1740911,
            grid,
            grid / t_map
        );
    }
}
