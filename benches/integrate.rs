//! The 240 s order sweep of the paper's section 4.1 (n 2.9 → 3.3, 40 N·m at 1000 rpm, ramp 2 s,
//! rtol = atol = 1e-9, 2 kHz samples): DOP853 over the generic Kane engine, over the closed form
//! of eq. (7) (the integrator's own cost shows as the difference to the rhs cost × evaluations),
//! and the full `simulate` with the rotor acceleration probe (one extra rhs call per sample).

use criterion::{Criterion, criterion_group, criterion_main};
use kanedyn::cpva::CpvaParams;
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order, rpm_to_rad_s};
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use kanedyn::time::probe::{Probe, ProbeKind, Recorder, simulate};
use std::hint::black_box;

fn sweep(c: &mut Criterion) {
    let p = CpvaParams::canonical();
    let w = rpm_to_rad_s(1000.0);
    let exc = Excitation {
        mean: p.c_r * w,
        rpm: 1000.0,
        order: Order::Sweep { from: 2.9, to: 3.3, duration_s: 240.0 },
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }],
        ramp_s: 2.0,
    };
    let mech = p.mechanism(Some(exc.clone())).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let cf = p.closed_form();
    let x0 = [0.0, 0.0, w, w];
    let opts = IntegrateOptions::default();
    let probe = Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap();

    let mut g = c.benchmark_group("sweep_240s");
    g.sample_size(10);
    g.bench_function("generic_engine", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            integrate(|t, x, dx| kane.rhs(t, x, dx), &x0, 0.0, 240.0, &opts, |s| acc += s.x[2]).unwrap();
            black_box(acc)
        })
    });
    g.bench_function("closed_form", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            let rhs = |t: f64, x: &[f64], dx: &mut [f64]| {
                cf.rhs1(exc.torque(t), x, dx);
                Ok(())
            };
            integrate(rhs, &x0, 0.0, 240.0, &opts, |s| acc += s.x[2]).unwrap();
            black_box(acc)
        })
    });
    g.bench_function("simulate_rotor_accel", |b| {
        b.iter(|| {
            let mut rec = Recorder::new(&mech, &[probe]).unwrap();
            simulate(&mut kane, &x0, 0.0, 240.0, &opts, &mut rec, &mut |_| {});
            black_box(rec.columns[0][1000])
        })
    });
    g.finish();
}

/// End to end through the study runner: reading the files, integrating, order tracking, writing
/// CSV/SVG/Markdown. `paper_study` is the whole of `examples/cpva_paper.ron` on the global rayon
/// pool (as many threads as cores: 2 here); `truck_driveline` the whole of
/// `examples/truck_study.ron` likewise.
fn study(c: &mut Criterion) {
    use kanedyn::study::{RunOptions, Study, run};
    let out = std::env::temp_dir().join("kanedyn_bench_out");
    let opts = RunOptions { out: Some(out.clone()), progress: false };
    // The bench studies name the examples' mechanism: that folder is allowed, as `--allow-read`.
    let examples =
        kanedyn::study::LoadOptions { allow_read: vec!["examples".into()], ..kanedyn::study::LoadOptions::default() };
    let mut g = c.benchmark_group("study");
    g.sample_size(10);
    g.bench_function("sweep_240s_end_to_end", |b| {
        b.iter(|| {
            let s = Study::from_file_with(std::path::Path::new("benches/studies/sweep40_up.ron"), &examples).unwrap();
            black_box(run(&s, &opts).unwrap().sweeps.len())
        })
    });
    g.bench_function("paper_study", |b| {
        b.iter(|| {
            let s = Study::from_file(std::path::Path::new("examples/cpva_paper.ron")).unwrap();
            black_box(run(&s, &opts).unwrap().files.len())
        })
    });
    // Issue 15's driveline example, whole: Campbell, and at 13 speeds the linear, harmonic-balance
    // (every branch, the torque ramp, the locked twin) and time-domain multi-order response.
    g.bench_function("truck_driveline", |b| {
        b.iter(|| {
            let s = Study::from_file(std::path::Path::new("examples/truck_study.ron")).unwrap();
            black_box(run(&s, &opts).unwrap().files.len())
        })
    });
    g.finish();
    std::fs::remove_dir_all(&out).ok();
}

criterion_group!(benches, sweep, study);
criterion_main!(benches);
