//! Harmonic balance: the full branch of the canonical CPVA at 40 N·m, 1000 rpm, continued from
//! below (2.9 → 3.3) and from above (3.3 → 2.9), with Floquet stability at every point.

use criterion::{Criterion, criterion_group, criterion_main};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{ContinuationOptions, Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use std::hint::black_box;

fn branch(c: &mut Criterion) {
    let mech = CpvaParams::canonical().mechanism(None).expect("canonical CPVA");
    let kane = Kane::new(&mech).expect("engine");
    let h = [Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }];
    let hbm = Hbm::new(&kane, 0, rpm_to_rad_s(1000.0), &h, HbmOptions::default()).expect("problem");
    let copts = ContinuationOptions::default();
    c.bench_function("hbm/branch_40", |b| {
        b.iter(|| {
            let mut p = hbm.clone();
            black_box(p.continue_in_order(2.9, 3.3, None, &copts).expect("branch"))
        })
    });
    c.bench_function("hbm/branch_40_from_above", |b| {
        b.iter(|| {
            let mut p = hbm.clone();
            black_box(p.continue_in_order(3.3, 2.9, None, &copts).expect("branch"))
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = branch
}
criterion_main!(benches);
