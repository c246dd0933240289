//! An independent periodic-orbit solver for the harmonic-balance tests (tests/it/hbm_events.rs,
//! tests/it/hbm_period_doubling.rs): shooting with DOP853 at 1e-12 and the monodromy by central
//! differences of whole periods.

use kanedyn::kane::Kane;
use kanedyn::time::integrate::{IntegrateOptions, integrate};

/// The physical Floquet multipliers of the periodic orbit through (near) `x0` with period
/// `period` under the mechanism's own excitation: Newton on `x(P) = x(0)` for every state but
/// the spin angle (it advances by ΩP, and its value is a gauge), then the eigenvalues of the flow's Jacobian with the spin
/// angle's row and column removed (its trivial +1).
pub fn shooting_multipliers(kane: &mut Kane, x0: &[f64], period: f64) -> Vec<nalgebra::Complex<f64>> {
    let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, ..IntegrateOptions::default() };
    let dim = x0.len();
    let free: Vec<usize> = (1..dim).collect();
    let mut flow = |x: &[f64]| -> Vec<f64> {
        integrate(|t, x, dx| kane.rhs(t, x, dx), x, 0.0, period, &opts, |_| {}).unwrap().x_end
    };
    let mut x = x0.to_vec();
    let mut jac = nalgebra::DMatrix::zeros(free.len(), free.len());
    for _ in 0..6 {
        let end = flow(&x);
        let r: Vec<f64> = free.iter().map(|&i| end[i] - x[i]).collect();
        for (c, &i) in free.iter().enumerate() {
            let h = 1e-6 * (1.0 + x[i].abs());
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[i] += h;
            xm[i] -= h;
            let (ep, em) = (flow(&xp), flow(&xm));
            for (row, &k) in free.iter().enumerate() {
                jac[(row, c)] = (ep[k] - em[k]) / (2.0 * h);
            }
        }
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if norm < 1e-11 {
            break;
        }
        let newton = &jac - nalgebra::DMatrix::identity(free.len(), free.len());
        let dx = newton.lu().solve(&nalgebra::DVector::from_vec(r)).expect("a regular shooting Jacobian");
        for (c, &i) in free.iter().enumerate() {
            x[i] -= dx[c];
        }
    }
    nalgebra::Schur::try_new(jac, f64::EPSILON, 10_000)
        .expect("converged")
        .complex_eigenvalues()
        .iter()
        .copied()
        .collect()
}

/// The monodromy Φ of a flow map (one period of the time equations), by central differences of
/// whole periods about `x0` with steps 1e-6·(1 + |x0_i|): good to ~1e-6 for DOP853 at 1e-12.
pub fn differenced_monodromy(flow: &mut impl FnMut(&[f64]) -> Vec<f64>, x0: &[f64]) -> nalgebra::DMatrix<f64> {
    let d = x0.len();
    let mut phi = nalgebra::DMatrix::zeros(d, d);
    for c in 0..d {
        let h = 1e-6 * (1.0 + x0[c].abs());
        let (mut xp, mut xm) = (x0.to_vec(), x0.to_vec());
        xp[c] += h;
        xm[c] -= h;
        let (ep, em) = (flow(&xp), flow(&xm));
        for r in 0..d {
            phi[(r, c)] = (ep[r] - em[r]) / (2.0 * h);
        }
    }
    phi
}

/// How far a time integration started on the harmonic-balance state `sol` of `hbm` strays from
/// it: DOP853 at 1e-10 on `kane` (the mechanism with `sol`'s excitation) for `periods` base
/// periods, then over one more period at 24 instants each state but the spin angle (a gauge)
/// against the harmonic balance's, relative to its own largest magnitude over the period (the
/// spin speed, Ω plus a small oscillation, relative to its oscillation). Index 0 is 0.
pub fn time_run_defects(
    hbm: &kanedyn::hbm::Hbm,
    sol: &kanedyn::hbm::HbmSolution,
    kane: &mut Kane,
    periods: f64,
) -> Vec<f64> {
    let opts = IntegrateOptions { rtol: 1e-10, atol: 1e-10, ..IntegrateOptions::default() };
    let period = 2.0 * std::f64::consts::PI / sol.base_frequency;
    let t0 = periods * period;
    let mut x = hbm.state_at(sol, 0.0);
    x = integrate(|t, x, dx| kane.rhs(t, x, dx), &x, 0.0, t0, &opts, |_| {}).unwrap().x_end;
    let samples = 24;
    let (mut hb, mut td): (Vec<Vec<f64>>, Vec<Vec<f64>>) = (Vec::new(), Vec::new());
    for j in 0..samples {
        let (a, b) = (t0 + period * j as f64 / samples as f64, t0 + period * (j + 1) as f64 / samples as f64);
        hb.push(hbm.state_at(sol, a - t0));
        td.push(x.clone());
        x = integrate(|t, x, dx| kane.rhs(t, x, dx), &x, a, b, &opts, |_| {}).unwrap().x_end;
    }
    let dof = x.len() / 2;
    let mut worst = vec![0.0f64; x.len()];
    for i in 1..x.len() {
        let mean = hb.iter().map(|h| h[i]).sum::<f64>() / samples as f64;
        let scale = if i == dof {
            hb.iter().map(|h| (h[i] - mean).abs()).fold(0.0, f64::max)
        } else {
            hb.iter().map(|h| h[i].abs()).fold(0.0, f64::max)
        };
        worst[i] = hb.iter().zip(&td).map(|(h, t)| (h[i] - t[i]).abs()).fold(0.0, f64::max) / scale;
    }
    worst
}
