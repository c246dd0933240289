//! Harmonic-balance sensitivities (issue 50): the derivative of the paper's rotor's state at
//! n = 3.0, 500 N·m, along one design parameter (the pivot radius) and along all four of
//! `Design::ALL` in one call, the design points (the problems at p ± h) built beforehand as an
//! operating set shares them, against the central difference it replaces (the problems built at
//! p ± δ and two Newton solves from the state); a design point's own build; and a fold's order
//! derivative (with the fold's state, and alone by the left null vector) against two fold solves. BENCHMARKS.md records the ratios ("Sensitivities").

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)]
mod cpva_hbm;

use cpva_hbm::{Design, base_value, problem};
use criterion::{Criterion, criterion_group, criterion_main};
use kanedyn::hbm::{ContinuationOptions, DesignPoint, Direction, FoldPlane, MechanismFamily, Singularity};
use std::hint::black_box;

const TORQUE: f64 = 500.0;

fn sensitivities(c: &mut Criterion) {
    let d = Design::PivotRadius;
    let p0 = base_value(d);
    let mut hbm = problem(d, p0, TORQUE).unwrap();
    let sol = hbm.solve(3.0, None).unwrap();
    let builds: Vec<Box<dyn Fn(f64) -> _>> =
        Design::ALL.iter().map(|&d| Box::new(move |p: f64| problem(d, p, TORQUE)) as Box<dyn Fn(f64) -> _>).collect();
    let families: Vec<MechanismFamily> = Design::ALL
        .iter()
        .zip(&builds)
        .map(|(&d, b)| MechanismFamily { build: b.as_ref(), scale: 1.0, reference: base_value(d), speed: false })
        .collect();
    let points: Vec<DesignPoint> =
        families.iter().zip(Design::ALL).map(|(f, d)| DesignPoint::new(f, base_value(d)).unwrap()).collect();
    let all: Vec<Direction> = points.iter().map(Direction::Design).collect();
    c.bench_function("sensitivity/design_point_1", |b| {
        b.iter(|| black_box(DesignPoint::new(&families[0], p0).unwrap()))
    });
    c.bench_function("sensitivity/build_problem", |b| b.iter(|| black_box(problem(d, p0, TORQUE).unwrap())));
    c.bench_function("sensitivity/build_mechanism_kane", |b| {
        b.iter(|| {
            let mut mech = kanedyn::cpva::CpvaParams::canonical().mechanism(None).unwrap();
            d.set(&mut mech, p0);
            black_box(kanedyn::kane::Kane::new(&mech).unwrap())
        })
    });
    c.bench_function("sensitivity/state_1", |b| {
        b.iter(|| black_box(hbm.state_sensitivities(&sol, &all[..1]).unwrap()))
    });
    c.bench_function("sensitivity/state_4", |b| b.iter(|| black_box(hbm.state_sensitivities(&sol, &all).unwrap())));
    c.bench_function("sensitivity/state_difference_1", |b| {
        b.iter(|| {
            let h = 1e-3 * p0;
            let up = problem(d, p0 + h, TORQUE).unwrap().solve(3.0, Some(&sol)).unwrap();
            let down = problem(d, p0 - h, TORQUE).unwrap().solve(3.0, Some(&sol)).unwrap();
            black_box((up.order_acceleration(0, 1.0) - down.order_acceleration(0, 1.0)) / (2.0 * h))
        })
    });
    let branch = hbm.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
    let guess = branch.points[branch.folds[0].after].solution.clone();
    let point = hbm.fold_at(FoldPlane::Order, 1.0, &guess).unwrap();
    c.bench_function("sensitivity/fold_1", |b| {
        b.iter(|| {
            black_box(hbm.singular_sensitivities(FoldPlane::Order, Singularity::Jacobian, &point, &all[..1]).unwrap())
        })
    });
    c.bench_function("sensitivity/fold_order_1", |b| {
        b.iter(|| black_box(hbm.fold_sensitivities(FoldPlane::Order, &point, &all[..1]).unwrap()))
    });
    c.bench_function("sensitivity/fold_order_4", |b| {
        b.iter(|| black_box(hbm.fold_sensitivities(FoldPlane::Order, &point, &all).unwrap()))
    });
    c.bench_function("sensitivity/fold_difference_1", |b| {
        b.iter(|| {
            let h = 1e-3 * p0;
            let up = problem(d, p0 + h, TORQUE).unwrap().fold_at(FoldPlane::Order, 1.0, &point.solution).unwrap();
            let down = problem(d, p0 - h, TORQUE).unwrap().fold_at(FoldPlane::Order, 1.0, &point.solution).unwrap();
            black_box((up.order - down.order) / (2.0 * h))
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = sensitivities
}
criterion_main!(benches);
