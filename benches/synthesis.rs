//! Issue 50, item 3: the optimiser chosen by measurement. The paper's rotor (R and L free; 200
//! and 400 N·m at order 3, 1000 rpm; travel 0.8 rad; jump margin 1.25), one start at the box
//! centre, solved by SLSQP with the exact gradients (`Problem::optimise`) and by COBYLA (the
//! `cobyla` crate, the same author's derivative-free NLopt translation) on the same epigraph
//! form; printed: the worst response reached, the design evaluations, the harmonic-balance
//! solves and the wall time. `cargo bench --bench synthesis`.

#[path = "../tests/it/support/cpva_hbm.rs"]
#[allow(dead_code)]
mod cpva_hbm;

use cpva_hbm::Design;
use kanedyn::cpva::CpvaParams;
use kanedyn::model::excitation::rpm_to_rad_s;
use kanedyn::synthesis::{Evaluation, OptimiseOptions, Problem, Variable};
use std::cell::Cell;
use std::time::Instant;

fn problem() -> Problem {
    let mech = CpvaParams::canonical().mechanism(None).unwrap();
    Problem {
        spin: mech.joint_index("spin").unwrap(),
        absorbers: vec![mech.joint_index("pivot").unwrap()],
        mechanism: mech,
        order: 3.0,
        speeds: vec![rpm_to_rad_s(1000.0)],
        torques: vec![200.0, 400.0],
        travel: Some(0.8),
        jump_margin: Some(1.25),
        harmonics: 10,
        variables: vec![
            Variable {
                name: "R".into(),
                lower: 0.15,
                upper: 0.19,
                set: Box::new(|m, v| {
                    Design::PivotRadius.set(m, v);
                    Ok(())
                }),
            },
            Variable {
                name: "L".into(),
                lower: 0.0140,
                upper: 0.0175,
                set: Box::new(|m, v| {
                    Design::ComRadius.set(m, v);
                    Ok(())
                }),
            },
        ],
    }
}

/// The epigraph rows `g ≤ 0` of an evaluation at level t (responses, travel, jump), as the
/// optimiser forms them, from the public evaluation.
fn rows(ev: &Evaluation, a_ref: f64, t: f64) -> Vec<f64> {
    let mut out: Vec<f64> = ev.points.iter().map(|p| p.rotor_accel / a_ref - t).collect();
    out.extend(ev.points.iter().map(|p| p.absorber_peak / 0.8 - 1.0));
    out.extend(ev.jumps.iter().map(|j| j.torque_nm.map_or(-0.25, |tj| 1.0 - tj / 500.0)));
    out
}

fn main() {
    let p = problem();
    let design = |u: &[f64]| vec![0.15 + u[0] * 0.04, 0.014 + u[1] * 0.0035];

    let t = Instant::now();
    let s = p.optimise(&OptimiseOptions::default()).unwrap();
    let o = &s.optima[0];
    println!(
        "SLSQP:  worst {:.6} rad/s² at {:?}, {} evaluations, {} solves, KKT {:.1e}, {:.2} s",
        o.evaluation.worst_response(),
        o.x,
        o.history.len(),
        o.solves,
        o.kkt.residual,
        t.elapsed().as_secs_f64()
    );

    let t = Instant::now();
    let a_ref = s.response_scale;
    let (evaluations, solves) = (Cell::new(0usize), Cell::new(0usize));
    let last: std::cell::RefCell<Option<(Vec<f64>, Evaluation)>> = Default::default();
    let at = |u: &[f64]| -> Evaluation {
        if let Some((x, ev)) = last.borrow().as_ref()
            && x.as_slice() == u
        {
            return ev.clone();
        }
        let ev = p.evaluate(&design(u)).unwrap();
        evaluations.set(evaluations.get() + 1);
        solves.set(solves.get() + ev.solves);
        *last.borrow_mut() = Some((u.to_vec(), ev.clone()));
        ev
    };
    let count = rows(&at(&[0.5, 0.5]), a_ref, 1.0).len();
    let objective = |z: &[f64], _: &mut ()| z[2];
    let constraint = |k: usize| {
        let at = &at;
        move |z: &[f64], _: &mut ()| -rows(&at(&z[..2]), a_ref, z[2])[k]
    };
    let cons: Vec<_> = (0..count).map(constraint).collect();
    let z0 = [0.5, 0.5, at(&[0.5, 0.5]).worst_response() / a_ref];
    let bounds = [(0.0, 1.0), (0.0, 1.0), (0.0, 1e3)];
    let tols = cobyla::StopTols { ftol_rel: 1e-10, xtol_rel: 1e-10, ..Default::default() };
    let z = match cobyla::minimize(objective, &z0, &bounds, &cons, (), 2000, cobyla::RhoBeg::All(0.1), Some(tols)) {
        Ok((_, z, _)) | Err((_, z, _)) => z,
    };
    let ev = p.evaluate(&design(&z[..2])).unwrap();
    println!(
        "COBYLA: worst {:.6} rad/s² at {:?}, {} evaluations, {} solves, {:.2} s",
        ev.worst_response(),
        ev.x,
        evaluations.get(),
        solves.get(),
        t.elapsed().as_secs_f64()
    );
}
