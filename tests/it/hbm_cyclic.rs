//! The cyclic route of the harmonic balance (src/hbm/cyclic/) on the canonical rotor with N
//! identical pendulums (the paper's pendulum split evenly, `CpvaParams::with_pendulums`), 1000
//! rpm, H = 10, n 2.9 → 3.3, checked against routes that do not share its reduction:
//!
//! - the unison branch against the branch of the *one*-pendulum mechanism (a different
//!   mechanism, solved by the general route: the paper's remark that N synchronous pendulums act
//!   as one);
//! - the Floquet multipliers against the general solver on the *full* N-pendulum mechanism,
//!   solved again at each point's order from the expanded solution;
//! - the symmetry-breaking crossings of two pendulums against the general route's;
//! - a mistuned set, gravity: the general route.

use crate::support::cpva_hbm;
use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use cpva_hbm::{cpva_hbm, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{BifurcationKind, Branch, ContinuationOptions, Hbm, HbmOptions, HbmSolution, Route, RoutedHbm};
use kanedyn::kane::Kane;
use kanedyn::model::mechanism::Mechanism;
use nalgebra::Complex;
use std::time::Instant;

const COUNTS: [usize; 8] = [1, 2, 3, 4, 6, 8, 16, 32];

fn mechanism(n: usize) -> Mechanism {
    CpvaParams::canonical().with_pendulums(n).mechanism(None).unwrap()
}

/// The routed problem of `mech` under T sin(nΩt) on the spin joint, default options.
fn routed(mech: &Mechanism, torque: f64) -> RoutedHbm {
    let kane = Kane::new(mech).unwrap();
    RoutedHbm::new(&kane, 0, omega(), (&single(torque), &[]), &[(0, 1.0, 0.0)], HbmOptions::default()).unwrap()
}

fn sets(route: &Route) -> Vec<usize> {
    match route {
        Route::Cyclic { sets } => sets.iter().map(|s| s.members.len()).collect(),
        Route::General { .. } => Vec::new(),
    }
}

/// The largest difference between a cyclic branch and the one-absorber problem: every point of
/// `b` is solved again on the one-absorber problem by `solve` (at the point's order, from the
/// point's rotor and first member as the guess), and each member's coefficients, the rotor's and
/// the mean torque are compared with that independent solve (rad; relative on the torque); the
/// folds are compared with the one-absorber branch `one`'s (absolute in n). The points
/// themselves need not coincide with `one`'s: the cyclic branch also aims its steps at the
/// non-unison block's events, which the one-absorber problem does not have. Also returns the
/// re-solved solutions, for the multipliers. None when the fold counts differ or a solve fails.
fn branch_difference(
    b: &Branch,
    one: &Branch,
    solve: &mut dyn FnMut(f64, &HbmSolution) -> Option<HbmSolution>,
) -> Option<(f64, Vec<HbmSolution>)> {
    if b.folds.len() != one.folds.len() {
        return None;
    }
    let mut worst = 0.0f64;
    let mut solved = Vec::with_capacity(b.points.len());
    for p in &b.points {
        let s = &p.solution;
        let nb = 2 * s.harmonics + 1;
        let guess = HbmSolution { coefficients: s.coefficients[..2 * nb].to_vec(), ..one.points[0].solution.clone() };
        let guess = HbmSolution { order: s.order, mean_torque: s.mean_torque, ..guess };
        let s1 = solve(p.order, &guess)?;
        worst = worst.max((s.mean_torque - s1.mean_torque).abs() / s1.mean_torque.abs().max(1.0));
        for k in 0..s.ndof() {
            let k1 = k.min(1);
            for h in 0..nb {
                worst = worst.max((s.coefficients[k * nb + h] - s1.coefficients[k1 * nb + h]).abs());
            }
        }
        solved.push(s1);
    }
    for (f, g) in b.folds.iter().zip(&one.folds) {
        worst = worst.max((f.order - g.order).abs());
    }
    Some((worst, solved))
}

/// Every N finishes, and its unison branch is the one-pendulum branch. The one-pendulum
/// mechanism differs from the reduced one only by rounding (the representative's mass is N ·
/// (m_p/N), its damper N · (c_p/N)), so every point re-solved on it from the cyclic solution
/// agrees to the rounding amplified by the solve, bound 1e-10 (rad on the coefficients, relative on
/// the mean torque, absolute on the orders and folds). The multipliers of the unison block are
/// the one-pendulum problem's (same bound, 1e-10 would be the same argument; 1e-9 leaves room for
/// the eigenvalue solver near the repeated pair at a fold).
#[test]
fn every_count_finishes_and_its_unison_branch_is_the_one_pendulum_branch() {
    let copts = ContinuationOptions::default();
    for torque in [40.0, 500.0] {
        let t0 = Instant::now();
        let mut one = cpva_hbm(&single(torque), HbmOptions::default());
        let b1 = one.continue_in_order(2.9, 3.3, None, &copts).unwrap();
        let base = t0.elapsed().as_secs_f64();
        for n in COUNTS {
            let mech = mechanism(n);
            let mut hbm = routed(&mech, torque);
            let expect: Vec<usize> = if n == 1 { Vec::new() } else { vec![n] };
            assert_eq!(sets(hbm.route()), expect, "N = {n}: {}", hbm.route());
            let t0 = Instant::now();
            let b = hbm.continue_in_order(2.9, 3.3, None, &copts).unwrap();
            let wall = t0.elapsed().as_secs_f64();
            assert_eq!(b.points[0].solution.ndof(), n + 1);
            let (diff, solved) = branch_difference(&b, &b1, &mut |order, guess| one.solve(order, Some(guess)).ok())
                .unwrap_or_else(|| panic!("N = {n}, {torque} N·m: {} folds vs {}", b.folds.len(), b1.folds.len()));
            let mut worst_mu = 0.0f64;
            for (p, q) in b.points.iter().zip(&solved) {
                let st = p.solution.stability.as_ref().unwrap();
                let st1 = one.stability(q).unwrap();
                assert_eq!(st.multipliers.len(), 2 * (n + 1) - 1);
                for (x, y) in st.blocks[0].multipliers.iter().zip(&st1.multipliers) {
                    worst_mu = worst_mu.max((x - y).norm());
                }
            }
            println!(
                "N = {n:2}, {torque} N·m: {} points, {} folds, {} crossings, branch vs one pendulum {diff:.1e}, \
                 unison multipliers {worst_mu:.1e}, {:.1} ms ({:.2}× one pendulum), route {}",
                b.points.len(),
                b.folds.len(),
                b.bifurcations.len(),
                wall * 1e3,
                wall / base,
                hbm.route()
            );
            assert!(diff <= 1e-10, "N = {n}, {torque} N·m: {diff:e}");
            // At 500 N·m two or more pendulums lose unison (n ≈ 3.08137 to 3.09461): the cyclic
            // route sees both +1 crossings in the non-unison block at the default step too.
            if torque == 500.0 && n > 1 {
                let off: Vec<f64> = b
                    .bifurcations
                    .iter()
                    .filter(|x| x.kind == BifurcationKind::PlusOne && !b.folds.iter().any(|f| f.after == x.after))
                    .map(|x| x.order)
                    .collect();
                assert_eq!(off.len(), 2, "N = {n}: {:?}", b.bifurcations);
                for (x, quoted) in off.iter().zip([3.08137, 3.09461]) {
                    assert!(abs_diff_eq!(*x, quoted, epsilon = 1e-5), "N = {n}: {x} vs {quoted}");
                }
            }
            assert!(worst_mu <= 1e-9, "N = {n}, {torque} N·m: {worst_mu:e}");
        }
    }
}

/// Largest distance from each of `a` to its nearest unused one in `b` (both the same length).
fn multiset_distance(a: &[Complex<f64>], b: &[Complex<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut used = vec![false; b.len()];
    let mut worst = 0.0f64;
    for x in a {
        let (k, d) = b
            .iter()
            .enumerate()
            .filter(|(k, _)| !used[*k])
            .map(|(k, y)| (k, (x - y).norm()))
            .min_by(|p, q| p.1.total_cmp(&q.1))
            .unwrap();
        used[k] = true;
        worst = worst.max(d);
    }
    worst
}

/// The cyclic route's multipliers (unison block once, non-unison block N − 1 times) are the
/// general solver's on the full mechanism at every point of the branch. The general problem is
/// solved again at the point's order from the expanded solution (Newton at tolerance 1e-10), so
/// its solution also checks the expansion: it stays in unison to that tolerance. Both monodromies
/// use the same N_s = 256 RK4 steps on equivalent linear systems (RK4 maps the invariant
/// non-unison subspace to itself step by step), so they differ only by the per-sample
/// derivatives' difference rounding (central differences, ~1e-10 relative) and the eigenvalue
/// solver's rounding on the repeated multipliers; bound 1e-8.
#[test]
fn cyclic_multipliers_are_the_general_solvers() {
    for (n, torque) in [(2, 40.0), (2, 500.0), (3, 40.0), (3, 500.0), (4, 40.0), (4, 500.0)] {
        let mech = mechanism(n);
        let mut cyc = routed(&mech, torque);
        assert_eq!(sets(cyc.route()), vec![n]);
        let b = cyc.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
        let kane = Kane::new(&mech).unwrap();
        let mut general_hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
        let (mut worst_mu, mut worst_x, mut checked) = (0.0f64, 0.0f64, 0);
        let t0 = Instant::now();
        for p in &b.points {
            let sol: HbmSolution = match general_hbm.solve(p.order, Some(&p.solution)) {
                Ok(s) => s,
                // At a fold the fixed-order Jacobian is singular: checked at the expanded state.
                Err(_) => p.solution.clone(),
            };
            for (x, y) in sol.coefficients.iter().zip(&p.solution.coefficients) {
                worst_x = worst_x.max((x - y).abs());
            }
            let general = general_hbm.stability(&sol).unwrap();
            let cyclic = p.solution.stability.as_ref().unwrap();
            assert_eq!(cyclic.blocks.len(), 2);
            assert_eq!((cyclic.blocks[0].multiplicity, cyclic.blocks[1].multiplicity), (1, n - 1));
            worst_mu = worst_mu.max(multiset_distance(&cyclic.multipliers, &general.multipliers));
            assert_eq!(cyclic.stable, general.stable, "N = {n}, n = {}", p.order);
            checked += 1;
        }
        println!(
            "N = {n}, {torque} N·m: {checked} points, multipliers cyclic vs general {worst_mu:.1e}, general \
             re-solve moved the expanded solution by {worst_x:.1e} rad ({:.0} ms general)",
            t0.elapsed().as_secs_f64() * 1e3
        );
        assert!(worst_mu <= 1e-8, "N = {n}, {torque} N·m: {worst_mu:e}");
        assert!(worst_x <= 1e-9, "N = {n}, {torque} N·m: {worst_x:e}");
    }
}

/// A set that is not identical takes the general route: one pendulum's mass +1 % (and +1e-9,
/// the perturbation that puts a symmetric set on the general solver on purpose), and the
/// identical set under gravity.
#[test]
fn a_mistuned_set_or_gravity_takes_the_general_route() {
    for rel in [1e-2, 1e-9] {
        for n in [2, 4] {
            let mut mech = mechanism(n);
            mech.bodies[2].inertia.mass *= 1.0 + rel;
            let hbm = routed(&mech, 40.0);
            match hbm.route() {
                Route::General { reason } => {
                    assert!(reason.contains("mistuned") && reason.contains("mass"), "{reason}")
                }
                r => panic!("N = {n}, mass + {rel}: {r}"),
            }
        }
    }
    let mut mech = mechanism(3);
    mech.loads.gravity = nalgebra::Vector2::new(0.0, -9.81);
    let kane = Kane::new(&mech).unwrap();
    let h = RoutedHbm::new(&kane, 0, omega(), (&single(40.0), &[]), &[(0, 1.0, 0.0)], HbmOptions::default()).unwrap();
    assert!(matches!(h.route(), Route::General { reason } if reason.contains("gravity")), "{}", h.route());
}

/// Two pendulums at 500 N·m lose unison between n ≈ 3.08137 and 3.09461 (tests/it/hbm.rs confirms
/// it by time integration): the cyclic route finds both real multipliers through +1 in the
/// non-unison block, at the general route's locations. Both located by bisection to ~1e-9 on the
/// same step (`ds_max` 0.02, as the general test needs until crossing detection is
/// step-independent); bound 1e-7 between the routes and 1e-5 to the quoted values.
#[test]
fn two_pendulums_lose_unison_on_the_cyclic_route() {
    let mech = mechanism(2);
    let copts = ContinuationOptions { ds_max: 0.02, ..ContinuationOptions::default() };
    let mut cyc = routed(&mech, 500.0);
    let b = cyc.continue_in_order(2.9, 3.3, None, &copts).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let mut general_hbm = Hbm::new(&kane, 0, omega(), &single(500.0), HbmOptions::default()).unwrap();
    let g = general_hbm.continue_in_order(2.9, 3.3, None, &copts).unwrap();
    let off_fold = |b: &Branch| -> Vec<f64> {
        b.bifurcations
            .iter()
            .filter(|x| x.kind == BifurcationKind::PlusOne && !b.folds.iter().any(|f| f.after == x.after))
            .map(|x| x.order)
            .collect()
    };
    let (c, r) = (off_fold(&b), off_fold(&g));
    println!("+1 crossings off the folds: cyclic {c:?}, general {r:?}");
    assert_eq!(c.len(), 2, "{:?}", b.bifurcations);
    assert_eq!(r.len(), 2, "{:?}", g.bifurcations);
    for ((x, y), quoted) in c.iter().zip(&r).zip([3.08137, 3.09461]) {
        assert_abs_diff_eq!(x, y, epsilon = 1e-7);
        assert_abs_diff_eq!(*x, quoted, epsilon = 1e-5);
    }
    // Between them the growing multiplier is the non-unison block's; the unison block is stable.
    let mid = 0.5 * (c[0] + c[1]);
    let guess = b.guesses_at(mid)[0].clone();
    let sol = cyc.solve(mid, Some(&guess)).unwrap();
    let st = cyc.stability(&sol).unwrap();
    assert!(!st.stable);
    assert!(st.blocks[0].multipliers.iter().all(|m| m.norm() < 1.0), "{:?}", st.blocks[0]);
    assert!(st.blocks[1].multipliers.iter().any(|m| m.norm() > 1.0 && m.im == 0.0 && m.re > 0.0), "{:?}", st.blocks[1]);
}

/// A study on four identical pendulums (examples/cpva4.ron) takes the cyclic route on its own,
/// says so per branch in the summary and in the results, and its branches are full-size: the
/// rotor's accelerations equal those of the same study on the single pendulum of
/// examples/cpva.ron (the general route), point by point to 1e-9 relative (the same bound
/// argument as above, through the summary's rounding-free numbers).
#[test]
fn a_study_reports_its_route_per_branch() {
    use kanedyn::io::Source;
    use kanedyn::study::{LoadOptions, RunOptions, Study, run};
    let text = |mech: &str| {
        format!(
            r#"Study(
    name: "cyclic_route",
    mechanism: "{mech}",
    spin_joint: "spin",
    response_body: "rotor",
    analyses: [
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [500.0], harmonics: 10),
    ],
)"#
        )
    };
    let mut runs = Vec::new();
    for mech in ["cpva4.ron", "cpva.ron"] {
        let src = Source::from_text("examples/cyclic_route_test.ron", &text(mech));
        let study = Study::from_source(src, &LoadOptions::default()).unwrap();
        let tmp = scratch(&format!("cyclic-{mech}"));
        let out = tmp.path().to_path_buf();
        let r = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
        runs.push(r);
    }
    let (four, one) = (&runs[0], &runs[1]);
    assert_eq!(four.hbm.len(), 2);
    for (b, b1) in four.hbm.iter().zip(&one.hbm) {
        assert_eq!((b.route.as_str(), b1.route.as_str()), ("cyclic", "general"));
        assert!(b.route_detail.contains("4 × pivot_1…pivot_4 on rotor"), "{}", b.route_detail);
        assert_eq!(b.accel[0].len(), b1.accel[0].len());
        for (x, y) in b.accel[0].iter().zip(&b1.accel[0]) {
            assert_abs_diff_eq!(x, y, epsilon = 1e-9 * y.abs());
        }
        assert_eq!(b.elements.len(), b1.elements.len());
    }
    assert!(four.summary.contains("| route |"), "{}", four.summary);
    assert!(four.summary.contains("cyclic (4 × pivot_1…pivot_4 on rotor)"), "{}", four.summary);
}

/// Identical path absorbers (translating, on the tautochronic epicycloid of
/// examples/paths/epicycloid.ron, end stops included) mounted at 0, 2π/3 and 4π/3: the route
/// finds the set through the path mounts (their joint point is the rotor axis), its unison
/// branch is the single absorber's of the example (the stops' stiffness and damping split by 3
/// round back to the example's: bound 1e-10 as above), and its multipliers are the general
/// solver's on the three absorbers at every point (bound 1e-8 as above).
#[test]
fn identical_path_absorbers_take_the_cyclic_route() {
    use kanedyn::io::{ReadPolicy, Source};
    let absorber = |k: usize, mount: f64| {
        format!(
            r#"Joint(name: "path_{k}", kind: Path(shape: Epicycloid(rho0: 0.18520936507683606, n_tilde: 3.11), mount: {mount:?}),
                parent: "rotor", child: "absorber_{k}", at: (0.0, 0.0), damper: 0.72,
                stops: (lower: -0.0165, upper: 0.0165, stiffness: {:?}, damping: {:?})),"#,
            1.0e9 / 3.0,
            4.6e4 / 3.0
        )
    };
    let third = 2.0 * std::f64::consts::PI / 3.0;
    let text = format!(
        r#"Mechanism(
    name: "three_paths",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "rotor", mass: 110.0, com: (0.0, 0.0), inertia: 3.443504355127701),
        Body(name: "absorber_1", mass: 2.0, com: (0.0, 0.0), inertia: 0.00007200000000000001),
        Body(name: "absorber_2", mass: 2.0, com: (0.0, 0.0), inertia: 0.00007200000000000001),
        Body(name: "absorber_3", mass: 2.0, com: (0.0, 0.0), inertia: 0.00007200000000000001),
    ],
    joints: [
        Joint(name: "spin", kind: Revolute, parent: "ground", child: "rotor", at: (0.0, 0.0)),
        {} {} {}
    ],
    loads: [GroundDamper(body: "rotor", c: 5e-3)],
)"#,
        absorber(1, 0.0),
        absorber(2, third),
        absorber(3, 2.0 * third)
    );
    let three =
        Mechanism::from_source(&Source::from_text("three_paths.ron", &text), &ReadPolicy::unrestricted()).unwrap();
    let one = Mechanism::from_file(std::path::Path::new("examples/paths/epicycloid.ron")).unwrap();
    let copts = ContinuationOptions::default();
    let mut cyc = routed(&three, 40.0);
    assert_eq!(sets(cyc.route()), vec![3], "{}", cyc.route());
    let b = cyc.continue_in_order(2.9, 3.3, None, &copts).unwrap();
    let mut one_hbm = routed(&one, 40.0);
    let b1 = one_hbm.continue_in_order(2.9, 3.3, None, &copts).unwrap();
    let (diff, _) = branch_difference(&b, &b1, &mut |order, guess| one_hbm.solve(order, Some(guess)).ok())
        .expect("same folds, every point solved");
    let kane = Kane::new(&three).unwrap();
    let mut general_hbm = Hbm::new(&kane, 0, omega(), &single(40.0), HbmOptions::default()).unwrap();
    let mut worst_mu = 0.0f64;
    for p in &b.points {
        let sol = general_hbm.solve(p.order, Some(&p.solution)).unwrap_or_else(|_| p.solution.clone());
        let general = general_hbm.stability(&sol).unwrap();
        worst_mu =
            worst_mu.max(multiset_distance(&p.solution.stability.as_ref().unwrap().multipliers, &general.multipliers));
    }
    println!(
        "three path absorbers: {} points, branch vs one absorber {diff:.1e}, multipliers vs general {worst_mu:.1e}",
        b.points.len()
    );
    // This branch has points close to its two folds, where the general solver's solve at fixed
    // order is fixed only to the Newton tolerance (1e-10) over the Jacobian's smallest singular
    // value, and its multipliers move with it: 2.4e-8 measured at the worst point, bound 1e-7
    // (the pendulum sets above hold 1e-8).
    assert!(diff <= 1e-10, "{diff:e}");
    assert!(worst_mu <= 1e-7, "{worst_mu:e}");
}

/// `route` in the study file: `Cyclic` declares the absorbers identical, and a set that is not
/// (one pendulum 1e-6 heavier) is refused at load, at the field, naming the difference; on the
/// identical set it runs the cyclic route. `General` forces the reference route on the identical
/// set, and the folds it finds equal the cyclic route's (both refined to |dλ/ds| < 1e-6; the
/// fold orders then agree to ~1e-9, asserted at 1e-7; the two routes take different points, as
/// their arclengths are weighted differently).
#[test]
fn a_declared_route_is_checked_and_taken() {
    use kanedyn::io::Source;
    use kanedyn::study::{LoadOptions, RunOptions, Study, run};
    let text = |mech: &str, route: &str| {
        format!(
            r#"Study(
    name: "declared_route",
    mechanism: "{mech}",
    spin_joint: "spin",
    response_body: "rotor",
    analyses: [
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0], harmonics: 10,
                        route: {route}),
    ],
)"#
        )
    };
    let tmp = scratch("declared-route");
    let dir = tmp.path().to_path_buf();
    crate::support::examples::copy_dir(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), &dir);
    let four = std::fs::read_to_string(dir.join("cpva4.ron")).unwrap();
    let mistuned = four.replacen("mass: 1.5,", "mass: 1.500001,", 1);
    assert_ne!(four, mistuned);
    std::fs::write(dir.join("cpva4_mistuned.ron"), mistuned).unwrap();
    let load = |mech: &str, route: &str| {
        let src = Source::from_text(&dir.join("s.ron").to_string_lossy(), &text(mech, route));
        Study::from_source(src, &LoadOptions::default())
    };
    let e = load("cpva4_mistuned.ron", "Cyclic").map(|_| ()).unwrap_err().to_string();
    println!("{e}");
    assert!(e.contains("(field `analyses[0].route`)") && e.contains("s.ron:8:"), "{e}");
    assert!(e.contains("not identical") || e.contains("mistuned"), "{e}");
    assert!(e.contains("pendulum_2") || e.contains("pivot_2") || e.contains("mass"), "{e}");
    let mut routes = Vec::new();
    for route in ["Cyclic", "General"] {
        let study = load("cpva4.ron", route).unwrap();
        let out = dir.join(format!("out_{route}"));
        let r = run(&study, &RunOptions { out: Some(out), progress: false }).unwrap();
        assert!(r.failures.is_empty(), "{:?}", r.failures);
        routes.push(r);
    }
    let (cyclic, general) = (&routes[0], &routes[1]);
    for (c, g) in cyclic.hbm.iter().zip(&general.hbm) {
        assert_eq!((c.route.as_str(), g.route.as_str()), ("cyclic", "general"));
        println!("folds: cyclic {:?}, general {:?}", c.folds, g.folds);
        assert_eq!(c.folds.len(), 2);
        assert_eq!(c.folds.len(), g.folds.len());
        for (x, y) in c.folds.iter().zip(&g.folds) {
            assert_abs_diff_eq!(x, y, epsilon = 1e-7);
        }
    }
}
