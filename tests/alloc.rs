//! The evaluator does no heap allocation per call after construction: a counting global allocator
//! (per thread, so the test harness's own threads do not interfere) sees zero allocations over
//! many `rhs`, `mass_matrix` and `forcing` calls.

use kanedyn::kane::Kane;
use kanedyn::model::mechanism::Mechanism;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;

struct Counting;

thread_local! {
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCS.with(|a| a.set(a.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCS.with(|a| a.set(a.get() + 1));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCS.with(Cell::get);
    f();
    ALLOCS.with(Cell::get) - before
}

#[test]
fn evaluating_does_not_allocate() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in ["examples/cpva.ron", "examples/cpva4.ron", "examples/triple_pendulum.ron"] {
        let mech = Mechanism::from_file(&root.join(file)).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        let n = mech.ndof();
        let mut x: Vec<f64> = (0..2 * n).map(|i| 0.1 * i as f64 + 0.3).collect();
        let mut xdot = vec![0.0; 2 * n];
        let count = allocations_during(|| {
            for step in 0..1000 {
                let t = step as f64 * 1e-3;
                kane.rhs(t, &x, &mut xdot).unwrap();
                x[1] += 1e-3 * xdot[1];
                let (q, u) = x.split_at(n);
                let _ = kane.mass_matrix(q)[(0, 0)];
                let _ = kane.forcing(t, q, u)[0];
                let _ = kane.mass_matrix_and_forcing(t, q, u);
            }
        });
        assert_eq!(count, 0, "{file}: {count} heap allocations in 1000 evaluations");
    }
    // Issue 30: the rotor with 1, 8, 32 and 64 pendulums (n = 2, 9, 33, 65), by the
    // articulated-body route and by the formed M (solved along the tree above n = 6).
    for pendulums in [1, 8, 32, 64] {
        let mech = kanedyn::cpva::CpvaParams::canonical().with_pendulums(pendulums).mechanism(None).unwrap();
        let mut tree = Kane::new(&mech).unwrap();
        tree.use_mass_matrix();
        let mut articulated = tree.clone();
        assert!(articulated.use_articulated_bodies());
        assert_eq!(tree.factorises_along_tree(), pendulums > 1, "{pendulums} pendulums");
        assert!(articulated.solves_articulated() && !tree.solves_articulated());
        for (route, mut kane) in [("articulated", articulated), ("tree", tree)] {
            let n = mech.ndof();
            let mut x: Vec<f64> = (0..2 * n).map(|i| 0.01 * i as f64 + 0.3).collect();
            let mut xdot = vec![0.0; 2 * n];
            let count = allocations_during(|| {
                for _ in 0..200 {
                    kane.rhs(0.1, &x, &mut xdot).unwrap();
                    x[1] += 1e-3 * xdot[1];
                }
            });
            assert_eq!(count, 0, "{pendulums} pendulums, {route}: {count} heap allocations in 200 evaluations");
        }
    }
    // The counter does see allocations (a test that cannot fail is worthless).
    assert!(allocations_during(|| drop(std::hint::black_box(vec![1.0; 8]))) >= 1);
}
