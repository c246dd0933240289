//! The cost of one right-hand-side evaluation: the generic Kane engine on examples/cpva.ron
//! against the hand-written closed form of eq. (7) at the same state and time (both
//! allocation-free, both evaluating the same excitation torque), the same rotor with its absorber
//! on a path joint (the epicycloid of examples/cpva_epicycloid.ron, and the circle that is the
//! paper's pendulum in s = Lφ), planar chains of N links (the route chosen at build, and beside
//! it the formed M and the articulated-body route), and the paper's rotor carrying N pendulums
//! by the articulated-body route, with M formed and solved along the tree (chosen at build), and
//! densely.

#[path = "support/cpva_rhs.rs"]
mod cpva_rhs;
#[path = "support/path_cpva_rhs.rs"]
mod path_cpva_rhs;

use cpva_rhs::{CpvaRhs, T, X};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kanedyn::kane::Kane;
use kanedyn::model::body::BodySpec;
use kanedyn::model::joint::JointSpec;
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::speeds::Speeds;
use std::hint::black_box;

fn chain(n: usize) -> Mechanism {
    let bodies = (0..n)
        .map(|i| BodySpec {
            name: Some(format!("link{i}")),
            mass: Some(1.0),
            com: Some((0.25, 0.0)),
            inertia: Some(1.0 / 48.0),
            ..BodySpec::default()
        })
        .collect();
    let joints = (0..n)
        .map(|i| JointSpec {
            name: Some(format!("j{i}")),
            parent: Some(if i == 0 { "ground".into() } else { format!("link{}", i - 1) }),
            child: Some(format!("link{i}")),
            at: Some((if i == 0 { 0.0 } else { 0.5 }, 0.0)),
            damper: Some(0.01),
            ..JointSpec::default()
        })
        .collect();
    let spec = MechanismSpec {
        base: None,
        name: format!("chain{n}"),
        speeds: Speeds::JointRates,
        gravity: (0.0, -9.81),
        bodies,
        joints,
        loads: vec![],
        gears: Vec::new(),
    };
    Mechanism::from_spec(&spec).unwrap()
}

fn rhs(c: &mut Criterion) {
    let mut g = c.benchmark_group("rhs");
    let CpvaRhs { mut kane, excitation, closed: cf } = CpvaRhs::new();
    let (x, t) = (X, T);
    let mut xdot = [0.0; 4];
    g.bench_function("generic_cpva", |b| {
        b.iter(|| {
            kane.rhs(black_box(t), black_box(&x), &mut xdot).unwrap();
            black_box(xdot[2])
        })
    });
    // The path-joint CPVAs, beside the revolute one (issue 14's speed criterion is their ratio).
    let xp = path_cpva_rhs::path_state();
    for (name, mut k) in
        [("path_cpva", path_cpva_rhs::epicycloid_cpva()), ("path_circle_cpva", path_cpva_rhs::circle_cpva())]
    {
        g.bench_function(name, |b| {
            b.iter(|| {
                k.rhs(black_box(t), black_box(&xp), &mut xdot).unwrap();
                black_box(xdot[2])
            })
        });
    }
    g.bench_function("closed_form_cpva", |b| {
        // The excitation through `black_box`, as the engine reads its own from memory: inlined
        // here, its loop-invariant part (the rpm → rad/s division) was hoisted out of the loop.
        b.iter(|| {
            let torque = black_box(&excitation).torque(black_box(t));
            cf.rhs1(torque, black_box(&x), &mut xdot);
            black_box(xdot[2])
        })
    });
    for n in [2, 4, 8, 16, 32, 64] {
        let m = chain(n);
        let chosen = Kane::new(&m).unwrap();
        let mut formed = chosen.clone();
        formed.use_mass_matrix();
        let mut articulated = chosen.clone();
        articulated.use_articulated_bodies();
        let x: Vec<f64> = (0..2 * n).map(|i| 0.1 + 0.05 * i as f64).collect();
        let mut xd = vec![0.0; 2 * n];
        // The route chosen at build, and beside it the formed M and the articulated-body route.
        let mut routes = vec![("chain", chosen), ("chain_formed", formed)];
        if n > 6 {
            routes.push(("chain_aba", articulated));
        }
        for (route, mut k) in routes {
            g.bench_with_input(BenchmarkId::new(route, n), &n, |b, _| {
                b.iter(|| {
                    k.rhs(black_box(0.5), black_box(&x), &mut xd).unwrap();
                    black_box(xd[n])
                })
            });
        }
    }
    // A rotor with N identical pendulums: M is an arrowhead, which the tree's factorisation
    // solves in O(N) and the dense LDLᵀ in O(N³).
    for pendulums in [8, 16, 32, 64] {
        let mech = kanedyn::cpva::CpvaParams::canonical().with_pendulums(pendulums).mechanism(None).unwrap();
        let n = mech.ndof();
        let x: Vec<f64> = (0..2 * n).map(|i| 0.1 + 0.05 * i as f64).collect();
        let mut xd = vec![0.0; 2 * n];
        let mut tree = Kane::new(&mech).unwrap();
        tree.use_mass_matrix();
        let mut articulated = tree.clone();
        articulated.use_articulated_bodies();
        let mut dense = tree.clone();
        dense.use_dense_factorisation();
        for (route, mut k) in [("pendulums_aba", articulated), ("pendulums_tree", tree), ("pendulums_dense", dense)] {
            g.bench_with_input(BenchmarkId::new(route, pendulums), &pendulums, |b, _| {
                b.iter(|| {
                    k.rhs(black_box(0.5), black_box(&x), &mut xd).unwrap();
                    black_box(xd[n])
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = rhs
}
criterion_main!(benches);
