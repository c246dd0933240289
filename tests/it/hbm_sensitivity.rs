//! Issue 50, item 1: sensitivities of harmonic-balance states and of folds by the implicit
//! function theorem ([`Hbm::state_sensitivities`], [`Hbm::singular_sensitivities`]), against an
//! independent route: central differences of whole Newton solves (and of whole fold solves) of
//! problems built at p ± δ, extrapolated by Richardson. On the paper's rotor (the canonical CPVA
//! at 1000 rpm) at 40 and 500 N·m, with respect to the pivot radius, the centre-of-mass radius,
//! the pendulum mass and the pivot damping.

use crate::support::cpva_hbm::{Design, base_value, problem};
use kanedyn::hbm::{
    ContinuationOptions, DesignPoint, Direction, FoldPlane, HbmSolution, MechanismFamily, Parameter, Singularity,
};

/// Richardson's extrapolation of central differences of `f` at p with steps δ and δ/2:
/// `(4 D(δ/2) − D(δ)) / 3`, whose error is O(δ⁴) of f's fifth derivative.
fn richardson(f: &mut dyn FnMut(f64) -> f64, p: f64, delta: f64) -> f64 {
    let mut d = |h: f64| (f(p + h) - f(p - h)) / (2.0 * h);
    let (coarse, fine) = (d(delta), d(delta / 2.0));
    (4.0 * fine - coarse) / 3.0
}

/// Relative difference, against the reference b.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The relative step of the differences: δ = 1e-3 of the parameter. Richardson's O(δ⁴) leaves
/// ~1e-12 of the derivative on these smooth responses; the solves converge to ~1e-13 rad, which
/// a difference over δ/2 turns into ~1e-10 of the response; the damping moves the response
/// off resonance by ~1e-4 of its size per unit relative change, so its differences lose
/// four more digits there (~1e-7), still inside the tolerance.
const DELTA: f64 = 1e-3;

/// The tolerance the issue sets for states and folds.
const TOL: f64 = 1e-6;

#[test]
fn state_sensitivities_match_differences_of_solves() {
    let spin = 0;
    for torque in [40.0, 500.0] {
        for design in Design::ALL {
            let p0 = base_value(design);
            let mut hbm = problem(design, p0, torque).unwrap();
            let sol = hbm.solve(3.0, None).unwrap();
            assert_eq!(sol.spin, spin);
            let build = move |p: f64| problem(design, p, torque);
            let family = MechanismFamily { build: &build, scale: 1.0, reference: p0, speed: false };
            let point = DesignPoint::new(&family, p0).unwrap();
            let s = hbm.state_sensitivities(&sol, &[Direction::Design(&point)]).unwrap().remove(0);
            let solve_at =
                |p: f64| -> HbmSolution { problem(design, p, torque).unwrap().solve(3.0, Some(&sol)).unwrap() };
            let fd_accel = richardson(&mut |p| solve_at(p).order_acceleration(spin, 1.0), p0, DELTA * p0);
            let fd_peak = richardson(&mut |p| solve_at(p).peak_amplitude(1), p0, DELTA * p0);
            let fd_torque = richardson(&mut |p| solve_at(p).mean_torque, p0, DELTA * p0);
            let (accel, peak) = (s.order_acceleration(&sol, spin, 1.0), s.peak_amplitude(&sol, 1));
            println!(
                "{torque} N·m, {design:?}: d(rotor main order)/dp {accel:.10e} vs {fd_accel:.10e} ({:.1e}); \
                 d(pendulum peak)/dp {peak:.10e} vs {fd_peak:.10e} ({:.1e}); dT_m/dp {:.3e} vs {fd_torque:.3e}",
                rel(accel, fd_accel),
                rel(peak, fd_peak),
                s.mean_torque
            );
            assert!(rel(accel, fd_accel) <= TOL, "{torque} N·m, {design:?}: {accel} vs {fd_accel}");
            assert!(rel(peak, fd_peak) <= TOL, "{torque} N·m, {design:?}: {peak} vs {fd_peak}");
            // T_m = c_r Ω exactly (the pivot damper is internal): no design parameter here moves
            // it, so both derivatives vanish to rounding: the residual's differences over
            // h = 1e-5 p leave ~1e-11 / 1e-5 of its ~1 N·m mean rows, so 1e-8 of T_m per relative
            // change of p bounds them.
            let bound = 1e-8 * sol.mean_torque.abs() / p0;
            assert!(s.mean_torque.abs() <= bound && fd_torque.abs() <= bound, "{} / {fd_torque}", s.mean_torque);
        }
    }
}

/// The operating parameters against the same differences: the order (which also moves the
/// base frequency, so the acceleration's derivative carries 2|c|·(hω₀)²/n) and the torque scale.
#[test]
fn operating_sensitivities_match_differences_of_solves() {
    let mut hbm = problem(Design::PivotDamping, base_value(Design::PivotDamping), 40.0).unwrap();
    let sol = hbm.solve(3.0, None).unwrap();
    let dirs = [Direction::Operating(Parameter::Order), Direction::Operating(Parameter::TorqueScale { order: 3.0 })];
    let s = hbm.state_sensitivities(&sol, &dirs).unwrap();
    let fd_order = richardson(&mut |n| hbm.solve(n, Some(&sol)).unwrap().order_acceleration(0, 1.0), 3.0, 3e-3);
    let mut scaled = |s: f64| {
        let mut h = problem(Design::PivotDamping, base_value(Design::PivotDamping), 40.0 * s).unwrap();
        h.solve(3.0, Some(&sol)).unwrap().order_acceleration(0, 1.0)
    };
    let fd_scale = richardson(&mut scaled, 1.0, 1e-3);
    let (d_order, d_scale) = (s[0].order_acceleration(&sol, 0, 1.0), s[1].order_acceleration(&sol, 0, 1.0));
    println!("d/dn {d_order:.10e} vs {fd_order:.10e}; d/ds {d_scale:.10e} vs {fd_scale:.10e}");
    assert!(rel(d_order, fd_order) <= TOL, "{d_order} vs {fd_order}");
    assert!(rel(d_scale, fd_scale) <= TOL, "{d_scale} vs {fd_scale}");
}

#[test]
fn fold_order_sensitivities_match_differences_of_fold_solves() {
    for (torque, expected_folds) in [(40.0, 2), (500.0, 1)] {
        let p_damping = base_value(Design::PivotDamping);
        let mut base = problem(Design::PivotDamping, p_damping, torque).unwrap();
        let branch = base.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
        assert_eq!(branch.folds.len(), expected_folds, "{torque} N·m: {:?}", branch.folds);
        for fold in &branch.folds {
            let guess = branch.points[fold.after].solution.clone();
            for design in Design::ALL {
                let p0 = base_value(design);
                let mut hbm = problem(design, p0, torque).unwrap();
                let point = hbm.fold_at(FoldPlane::Order, 1.0, &guess).unwrap();
                let build = move |p: f64| problem(design, p, torque);
                let family = MechanismFamily { build: &build, scale: 1.0, reference: p0, speed: false };
                let design_point = DesignPoint::new(&family, p0).unwrap();
                let s = hbm
                    .singular_sensitivities(
                        FoldPlane::Order,
                        Singularity::Jacobian,
                        &point,
                        &[Direction::Design(&design_point)],
                    )
                    .unwrap()
                    .remove(0);
                let mut fold_order = |p: f64| {
                    problem(design, p, torque).unwrap().fold_at(FoldPlane::Order, 1.0, &point.solution).unwrap().order
                };
                let fd = richardson(&mut fold_order, p0, DELTA * p0);
                println!(
                    "{torque} N·m fold at n = {:.7}, {design:?}: dn/dp {:.10e} vs {fd:.10e} ({:.1e})",
                    point.order,
                    s.parameter,
                    rel(s.parameter, fd)
                );
                assert!(rel(s.parameter, fd) <= TOL, "{torque} N·m, {design:?}: {} vs {fd}", s.parameter);
                // The left-null-vector form (no ∂g/∂p, one Jacobian) must agree as well.
                let short =
                    hbm.fold_sensitivities(FoldPlane::Order, &point, &[Direction::Design(&design_point)]).unwrap();
                assert!(rel(short[0], fd) <= TOL, "{torque} N·m, {design:?}: wᵀ form {} vs {fd}", short[0]);
            }
        }
    }
}
