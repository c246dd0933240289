//! Harmonic balance: the full branch of the canonical CPVA at 40 N·m, 1000 rpm, continued from
//! below (2.9 → 3.3) and from above (3.3 → 2.9), with Floquet stability at every point.

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)] // the design family is for the sensitivity bench
mod cpva_hbm;

use cpva_hbm::{cpva_hbm, single};
use criterion::{Criterion, criterion_group, criterion_main};
use kanedyn::hbm::{ContinuationOptions, HbmOptions};
use std::hint::black_box;

fn branch(c: &mut Criterion) {
    let hbm = cpva_hbm(&single(40.0), HbmOptions::default());
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
