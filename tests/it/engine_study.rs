//! A multi-order study driven by an engine file (`examples/engine_cpva.ron`): the harmonics it
//! applies are the engine's orders 3 and 6 at each speed, and the locked twin (one rigid rotor
//! with its loss to ground) answers each with the closed form `|α̂| = T ω / |iωJ + c|`. The
//! twin at 1400 rpm used to end without a measurement: the steady-state search corrected the
//! integrator's tiny mean-speed drift every window and restarted its windows each time.

use crate::support::scratch;
use kanedyn::combustion::{Engine, EngineSpec};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::study::{AnalysisSpec, RunOptions, Study, run};
use std::f64::consts::PI;
use std::path::Path;

#[test]
fn engine_orders_drive_the_multi_order_study() {
    let study = Study::from_file(Path::new("examples/engine_cpva.ron")).unwrap_or_else(|e| panic!("{e}"));
    let AnalysisSpec::MultiOrder(spec) = &study.spec.analyses[0] else { panic!("a MultiOrder analysis") };
    let src = Source::read_with(Path::new("examples/engines/inline_six.ron"), &ReadPolicy::unrestricted()).unwrap();
    let engine = Engine::new(src.parse_as::<EngineSpec>("Engine").unwrap()).unwrap();
    for p in &spec.speeds {
        let series = engine.orders(p.rpm * PI / 30.0, 6.0);
        let got: Vec<(f64, f64)> = p.harmonics.iter().map(|h| (h.multiple, h.amplitude)).collect();
        assert_eq!(got, vec![(1.0, series.amplitude(3.0)), (2.0, series.amplitude(6.0))], "{} rpm", p.rpm);
    }
    let tmp = scratch("engine-study");
    let dir = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    // The locked twin: rotor (3.4435 kg·m²) with the pendulum welded at φ = 0, its centre of mass
    // R + L from the axis, and the rotor's loss c_r = 5e-3 N·m·s/rad.
    let (m, r, l, ic) = (6.0, 0.17, 0.015209365076836064, 0.000216);
    let j = 3.443504355127701 + m * (r + l) * (r + l) + ic;
    let c = 5e-3;
    let mut worst: f64 = 0.0;
    for (s, p) in report.multi[0].speeds.iter().zip(&spec.speeds) {
        let locked = s.locked.as_ref().expect("a locked run");
        for (k, h) in p.harmonics.iter().enumerate() {
            let w = h.multiple * 3.0 * p.rpm * PI / 30.0;
            let expected = h.amplitude * w / (w * j).hypot(c);
            let e = (locked.amplitudes[k] - expected).abs() / expected;
            println!(
                "{} rpm, order {}: locked {:.6} vs {expected:.6} rad/s² ({e:.1e})",
                p.rpm,
                3.0 * h.multiple,
                locked.amplitudes[k]
            );
            worst = worst.max(e);
        }
    }
    // Whole-period windows of a linear steady state: the 5-bin sum holds a whole-window line to
    // rounding; measured ≤ 1.7e-12. Bound 1e-9.
    assert!(worst <= 1e-9, "{worst:e}");
}
