//! Issue 50, items 2–3 (first step): absorber synthesis on the paper's rotor at 1000 rpm,
//! order 3, torques 200 and 400 N·m, the pivot radius R and the centre-of-mass distance L free.
//! The design's gradients against differences of whole evaluations (each a continuation from
//! rest, a fold solve and polished states), and the optimum against the best case of a 20 × 20
//! grid of whole evaluations over the same box.

use crate::support::cpva_hbm::Design;
use kanedyn::cpva::CpvaParams;
use kanedyn::model::excitation::rpm_to_rad_s;
use kanedyn::synthesis::{Evaluation, OptimiseOptions, Problem, SynthesisError, Variable};

/// The paper's rotor at 1000 rpm, order 3, torques `torques`, pivot and centre-of-mass radius
/// free in the given boxes.
fn problem(torques: Vec<f64>, travel: Option<f64>, margin: Option<f64>, r: (f64, f64), l: (f64, f64)) -> Problem {
    let mech = CpvaParams::canonical().mechanism(None).unwrap();
    Problem {
        spin: mech.joint_index("spin").unwrap(),
        absorbers: vec![mech.joint_index("pivot").unwrap()],
        mechanism: mech,
        order: 3.0,
        speeds: vec![rpm_to_rad_s(1000.0)],
        torques,
        travel,
        jump_margin: margin,
        harmonics: 10,
        variables: vec![
            Variable {
                name: "R".into(),
                lower: r.0,
                upper: r.1,
                set: Box::new(|m, v| {
                    Design::PivotRadius.set(m, v);
                    Ok(())
                }),
            },
            Variable {
                name: "L".into(),
                lower: l.0,
                upper: l.1,
                set: Box::new(|m, v| {
                    Design::ComRadius.set(m, v);
                    Ok(())
                }),
            },
        ],
    }
}

/// The test's problem: torques 200 and 400 N·m, travel 0.8 rad, jump margin 1.25, R in
/// [0.15, 0.19] m, L in [0.0140, 0.0175] m (n_t from about 3.35 down to 3.0).
fn paper_problem() -> Problem {
    problem(vec![200.0, 400.0], Some(0.8), Some(1.25), (0.15, 0.19), (0.0140, 0.0175))
}

/// Richardson's extrapolation of central differences with steps δ and δ/2 (error O(δ⁴)).
fn richardson(f: &dyn Fn(f64) -> f64, p: f64, delta: f64) -> f64 {
    let d = |h: f64| (f(p + h) - f(p - h)) / (2.0 * h);
    (4.0 * d(delta / 2.0) - d(delta)) / 3.0
}

/// The gradients of the rotor response, the absorber peak and the jump torque equal
/// differences of whole evaluations. δ = 1e-4 of each variable: Richardson leaves O(δ⁴) ≈ 1e-16
/// of truncation; the states converge to ~1e-13 rad, which a difference over δ/2 turns into
/// ~1e-9 of the values; the fold's located to the same. So 1e-6 (the bound) holds with
/// a margin of 1e3 where the gradient is not itself near zero.
#[test]
fn design_gradients_match_differences_of_whole_evaluations() {
    let p = paper_problem();
    // The paper's own design (no jump below the searched torque) and a longer L (a jump at
    // about 600 N·m, inside the search).
    for x0 in [[0.17, 0.0152093650768], [0.17, 0.0165]] {
        let ev = p.evaluate(&x0).unwrap();
        for i in 0..2 {
            let at = |v: f64| -> Evaluation {
                let mut x = x0;
                x[i] = v;
                p.evaluate(&x).unwrap()
            };
            for k in 0..ev.points.len() {
                let fd_accel = richardson(&|v| at(v).points[k].rotor_accel, x0[i], 1e-4 * x0[i]);
                let fd_peak = richardson(&|v| at(v).points[k].absorber_peak, x0[i], 1e-4 * x0[i]);
                let (accel, peak) = (ev.points[k].rotor_accel_gradient[i], ev.points[k].absorber_peak_gradient[i]);
                println!(
                    "x {x0:?} var {i} point {k}: accel {accel:.10e} / {fd_accel:.10e}, peak {peak:.10e} / {fd_peak:.10e}"
                );
                assert!((accel - fd_accel).abs() <= 1e-6 * fd_accel.abs(), "{accel} vs {fd_accel}");
                assert!((peak - fd_peak).abs() <= 1e-6 * fd_peak.abs(), "{peak} vs {fd_peak}");
            }
            if let Some(tj) = ev.jumps[0].torque_nm {
                let fd = richardson(&|v| at(v).jumps[0].torque_nm.unwrap(), x0[i], 1e-4 * x0[i]);
                let g = ev.jumps[0].gradient[i];
                println!("x {x0:?} var {i}: jump {tj} N·m, dT/dx {g:.10e} / {fd:.10e}");
                assert!((g - fd).abs() <= 1e-6 * fd.abs(), "{g} vs {fd}");
            }
        }
    }
}

/// The optimum of two starts is one design, a first-order optimum (KKT residual ≤ 1e-6 in the
/// scaled variables), feasible, and at least as good as the best feasible case of a 20 × 20 grid
/// of whole evaluations over the same box (the independent route: no derivative, no optimiser).
#[test]
fn synthesis_is_at_least_as_good_as_the_best_case_of_a_grid() {
    let p = paper_problem();
    let (mut grid_best, mut grid_solves) = (f64::INFINITY, 0);
    for i in 0..20 {
        for j in 0..20 {
            let x = [0.15 + 0.04 * i as f64 / 19.0, 0.014 + 0.0035 * j as f64 / 19.0];
            let e = p.evaluate(&x).unwrap();
            grid_solves += e.solves;
            let met = e.points.iter().all(|q| !q.beyond_jump && q.absorber_peak <= 0.8)
                && e.jumps.iter().all(|j| j.torque_nm.is_none_or(|t| t >= 1.25 * 400.0));
            if met {
                grid_best = grid_best.min(e.worst_response());
            }
        }
    }
    let s = p.optimise(&OptimiseOptions { starts: 2, ..OptimiseOptions::default() }).unwrap();
    let best = &s.optima[s.best];
    for o in &s.optima {
        println!(
            "start {:?}: x {:?}, worst {} rad/s², KKT {:e}, {} ({} evaluations, {} solves)",
            o.start,
            o.x,
            o.evaluation.worst_response(),
            o.kkt.residual,
            o.status,
            o.history.len(),
            o.solves
        );
    }
    println!("grid best {grid_best} rad/s² with {grid_solves} solves");
    assert_eq!(
        s.distinct.len(),
        1,
        "both starts reach one design: {:?}",
        s.optima.iter().map(|o| &o.x).collect::<Vec<_>>()
    );
    assert!(best.feasible(0.0), "{:?}", best.constraints);
    assert!(best.kkt.residual <= 1e-6, "{:?}", best.kkt);
    assert!(best.evaluation.worst_response() <= grid_best, "{} vs grid {grid_best}", best.evaluation.worst_response());
    // Each start spends fewer solves than the grid (measured: about a fifth to a third).
    assert!(s.optima.iter().all(|o| o.solves < grid_solves), "{grid_solves}");
}

/// Ill-posed problems are refused before any solve, naming what is wrong.
#[test]
fn an_ill_posed_synthesis_is_refused_by_name() {
    let reversed = problem(vec![200.0], None, None, (0.19, 0.15), (0.014, 0.0175));
    let e = reversed.optimise(&OptimiseOptions::default()).unwrap_err();
    assert!(matches!(&e, SynthesisError::Invalid(m) if m.contains("`R`") && m.contains("increasing")), "{e}");
    let mut empty = paper_problem();
    empty.torques.clear();
    let e = empty.optimise(&OptimiseOptions::default()).unwrap_err();
    assert!(e.to_string().contains("operating set"), "{e}");
}
