//! Harmonic balance, continuation and Floquet stability on the canonical rotor-CPVA (1000 rpm),
//! checked against independent references: the linear frequency response of the paper's
//! linearised equations (13) and (22) written here in closed form, time integration of the full
//! equations (a fixed-step RK4 over the Kane engine) with an FFT over whole periods, a monodromy
//! matrix obtained by differencing time integrations, and the balance of angular momentum.

use crate::support::cpva_hbm;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use cpva_hbm::{RPM, cpva_hbm, omega, single};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{
    BifurcationKind, Branch, BranchEnd, ContinuationOptions, FoldKind, Hbm, HbmOptions, HbmSolution, Parameter,
};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order, rpm_to_rad_s};
use nalgebra::{Complex, DMatrix};
use realfft::RealFftPlanner;
use std::f64::consts::PI;

/// Main-order rotor acceleration amplitude (rad/s²) of the linearised equations (13), solved as
/// in eq. (22) for x = x̂ e^{iωt}, ω = nΩ:
/// rotor `a θ̈ + b(θ̈ + φ̈) − bΩ²φ = c_p φ̇ + T − c_r θ̇`,
/// pendulum `c(θ̈ + φ̈) + b θ̈ + bΩ²φ = −c_p φ̇`,
/// with `a = I_A + m R²`, `b = m R L`, `c = I_B + m L²`.
fn linear_rotor_acceleration(n: f64, torque: f64) -> f64 {
    let p = CpvaParams::canonical();
    let (m, r, l) = (p.pendulum_mass, p.pivot_radius, p.l());
    let a = p.i_a() + m * r * r;
    let b = m * r * l;
    let c = p.i_b() + m * l * l;
    let (w, om) = (n * omega(), omega());
    let i = Complex::new(0.0, 1.0);
    let m11 = Complex::new(-w * w * (a + b), 0.0) + i * w * p.c_r;
    let m12 = Complex::new(-w * w * b - b * om * om, 0.0) - i * w * p.c_p;
    let m21 = Complex::new(-w * w * (c + b), 0.0);
    let m22 = Complex::new(-w * w * c + b * om * om, 0.0) + i * w * p.c_p;
    // Cramer's rule for θ̂ with right-hand side (T, 0).
    let theta = m22 * torque / (m11 * m22 - m12 * m21);
    w * w * theta.norm()
}

#[test]
fn small_amplitude_limit_is_the_linear_frequency_response() {
    let torque = 0.01;
    let mut hbm = cpva_hbm(&single(torque), HbmOptions { stability_samples: 0, ..HbmOptions::default() });
    let mut worst = 0.0f64;
    let mut guess: Option<HbmSolution> = None;
    for k in 0..=40 {
        let n = 2.9 + 0.01 * k as f64;
        let sol = hbm.solve(n, guess.as_ref()).unwrap();
        let hbm_acc = sol.order_acceleration(0, 1.0);
        let lin = linear_rotor_acceleration(n, torque);
        worst = worst.max((hbm_acc / lin - 1.0).abs());
        // Angular momentum over a period: mean torque = c_r Ω exactly (the pendulum damper is
        // internal); only rounding separates them.
        let tm = CpvaParams::canonical().c_r * omega();
        assert!(
            abs_diff_eq!(sol.mean_torque, tm, epsilon = 1e-9 * tm),
            "n = {n}: T_m = {} vs c_r Ω = {tm}",
            sol.mean_torque
        );
        guess = Some(sol);
    }
    println!("small-amplitude limit: largest relative difference to the linear FRF {worst:.3e}");
    // The neglected terms are of relative order φ² ≈ (T/(m R L Ω² (n² + 1)))² < 1e-9 here, so
    // the 0.1 % of the brief is a loose bound; what remains is the linearisation itself.
    assert!(worst < 1e-3, "HBM at 0.01 N·m differs from eq. (22) by {worst:e}");
}

/// Fixed-step RK4 over the engine; calls `sample(t, x, ẋ)` at the start of every step.
fn rk4(kane: &mut Kane, x: &mut [f64], t0: f64, h: f64, steps: usize, mut sample: impl FnMut(f64, &[f64], &[f64])) {
    let d = x.len();
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) =
        (vec![0.0; d], vec![0.0; d], vec![0.0; d], vec![0.0; d], vec![0.0; d]);
    for s in 0..steps {
        let t = t0 + s as f64 * h;
        kane.rhs(t, x, &mut k1).unwrap();
        sample(t, x, &k1);
        for i in 0..d {
            tmp[i] = x[i] + 0.5 * h * k1[i];
        }
        kane.rhs(t + 0.5 * h, &tmp, &mut k2).unwrap();
        for i in 0..d {
            tmp[i] = x[i] + 0.5 * h * k2[i];
        }
        kane.rhs(t + 0.5 * h, &tmp, &mut k3).unwrap();
        for i in 0..d {
            tmp[i] = x[i] + h * k3[i];
        }
        kane.rhs(t + h, &tmp, &mut k4).unwrap();
        for i in 0..d {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

/// The engine with the full excitation of a solution: mean T_m plus the oscillating terms.
fn excited_kane(harmonics: &[Harmonic], sol: &HbmSolution) -> Kane {
    let exc = Excitation {
        mean: sol.mean_torque,
        rpm: sol.omega * 30.0 / PI,
        order: Order::Fixed(sol.order),
        harmonics: harmonics.to_vec(),
        ramp_s: 0.0,
    };
    let mech = CpvaParams::canonical().mechanism(Some(exc)).unwrap();
    Kane::new(&mech).unwrap()
}

/// Steps per period of the reference integrations: RK4's error per period scales as
/// (2π h_max/200)⁴/120 with h_max ≈ 5 the highest harmonic that matters, about 1e-8.
const STEPS: usize = 200;

struct TimeCheck {
    main: f64,
    second: f64,
    periodicity: f64,
}

/// Integrates from the HBM state at t = 0 (plus `perturb` times the pendulum amplitude on the
/// pendulum angle) for `periods`
/// periods; returns the rotor acceleration amplitudes at n and 2n from an FFT of the last
/// `fft_periods` periods, and the relative periodicity defect after the first period without
/// perturbation.
fn time_check(
    hbm: &Hbm,
    harmonics: &[Harmonic],
    sol: &HbmSolution,
    perturb: f64,
    periods: usize,
    fft_periods: usize,
) -> TimeCheck {
    let mut kane = excited_kane(harmonics, sol);
    let period = 2.0 * PI / sol.base_frequency;
    let h = period / STEPS as f64;
    // Periodicity defect over one period (φ, u1, u2; the spin angle advances by ΩT).
    let x0 = hbm.state_at(sol, 0.0);
    let mut x = x0.clone();
    // 10 times finer than the amplitude runs: RK4's own defect drops to ~1e-10.
    rk4(&mut kane, &mut x, 0.0, h / 10.0, 10 * STEPS, |_, _, _| {});
    let scale = [1.0, x0[1].abs().max(1e-3), 1.0, 1.0];
    let mut periodicity = 0.0f64;
    for i in 1..4 {
        let expect = x0[i];
        periodicity = periodicity.max((x[i] - expect).abs() / scale[i].max(expect.abs()));
    }
    // Steady state with a perturbation, then the FFT over whole periods.
    let mut x = x0;
    x[1] += perturb * sol.peak_amplitude(1);
    let n_fft = fft_periods * STEPS;
    let start = (periods - fft_periods) * STEPS;
    let mut acc = Vec::with_capacity(n_fft);
    let mut step = 0;
    rk4(&mut kane, &mut x, 0.0, h, periods * STEPS, |_, _, xd| {
        if step >= start {
            acc.push(xd[2]);
        }
        step += 1;
    });
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n_fft);
    let mut spec = fft.make_output_vec();
    fft.process(&mut acc, &mut spec).unwrap();
    let amp = |k: usize| 2.0 * spec[k * fft_periods].norm() / n_fft as f64;
    TimeCheck { main: amp(1), second: amp(2), periodicity }
}

fn branch(amplitude: f64, from: f64, to: f64) -> (Hbm, Branch) {
    let mut hbm = cpva_hbm(&single(amplitude), HbmOptions::default());
    let b = hbm.continue_in_order(from, to, None, &ContinuationOptions::default()).unwrap();
    (hbm, b)
}

/// All stable solutions at order n found from the branches' points.
fn stable_solutions(hbm: &mut Hbm, branches: &[&Branch], n: f64) -> Vec<HbmSolution> {
    let mut out: Vec<HbmSolution> = Vec::new();
    for b in branches {
        for g in b.guesses_at(n) {
            let mut sol = hbm.solve(n, Some(g)).unwrap();
            sol.stability = Some(hbm.stability(&sol).unwrap());
            let dup = out.iter().any(|o| {
                (o.order_acceleration(0, 1.0) - sol.order_acceleration(0, 1.0)).abs()
                    < 1e-6 * o.order_acceleration(0, 1.0)
            });
            if sol.stability.as_ref().unwrap().stable && !dup {
                out.push(sol);
            }
        }
    }
    out
}

#[test]
fn stable_branches_match_time_integration() {
    let mut worst_amp = 0.0f64;
    let mut worst_periodic = 0.0f64;
    for &torque in &[40.0, 500.0] {
        let h = single(torque);
        let (mut hbm, up) = branch(torque, 2.9, 3.3);
        let (_, down) = branch(torque, 3.3, 2.9);
        for &n in &[3.0, 3.05, 3.15, 3.25] {
            let sols = stable_solutions(&mut hbm, &[&up, &down], n);
            assert!(!sols.is_empty(), "no stable solution at {torque} N·m, n = {n}");
            for sol in &sols {
                // A perturbation of 1e-3 of the pendulum amplitude: on a stable orbit it stays
                // that small (the slowest decay is the pendulum's, |μ| ≈ 0.997 per period).
                let tc = time_check(&hbm, &h, sol, 1e-3, 60, 20);
                let (a1, a2) = (sol.order_acceleration(0, 1.0), sol.order_acceleration(0, 2.0));
                let e1 = (tc.main / a1 - 1.0).abs();
                // The second order can be tiny (0.007 rad/s² at 40 N·m, n = 2.9): compare it
                // relative to the main order there.
                let e2 = (tc.second - a2).abs() / a2.max(0.05 * a1);
                println!(
                    "{torque:5} N·m n = {n:.2}: HBM a_n {a1:9.4} a_2n {a2:8.4} | time a_n {:9.4} a_2n {:8.4} | rel. diff {e1:.1e} {e2:.1e}, periodicity {:.1e}",
                    tc.main, tc.second, tc.periodicity
                );
                worst_amp = worst_amp.max(e1).max(e2);
                worst_periodic = worst_periodic.max(tc.periodicity);
            }
        }
    }
    println!("largest relative amplitude difference {worst_amp:.2e}, periodicity defect {worst_periodic:.2e}");
    // The perturbation alone moves the amplitudes by up to ~1e-3 relative; 0.5 % is the bound
    // asked for.
    assert!(worst_amp < 5e-3, "HBM and time integration differ by {worst_amp:e}");
    // The HBM state returns to itself after one period to within the truncation at H = 10
    // (measured 2.3e-6 on the 500 N·m upper branch at n = 3.0, 2e-10 with H = 16) and the RK4
    // error (~1e-10 with 2000 steps per period).
    assert!(worst_periodic < 1e-5, "periodicity defect {worst_periodic:e}");
}

/// Floquet multipliers against a monodromy matrix built by central differences of one-period
/// RK4 integrations of the full equations (ε = 1e-4 on each of θ, φ, u1, u2).
#[test]
fn floquet_multipliers_match_differenced_monodromy() {
    let torque = 40.0;
    let h = single(torque);
    let mut hbm = cpva_hbm(&h, HbmOptions::default());
    let (_, up) = branch(torque, 2.9, 3.3);
    // One stable point on each of the lower and upper branch, one unstable on the middle branch.
    let mut worst = 0.0f64;
    for g in up.guesses_at(3.05) {
        let mut sol = hbm.solve(3.05, Some(g)).unwrap();
        let st = hbm.stability(&sol).unwrap();
        sol.stability = Some(st.clone());
        let mut kane = excited_kane(&h, &sol);
        let period = 2.0 * PI / sol.base_frequency;
        let steps = 4000;
        let x0 = hbm.state_at(&sol, 0.0);
        // Not smaller: the pendulum pair sits close to coalescing, where an eigenvalue moves
        // like the square root of the matrix error, and with ε = 1e-6 the rounding of u1 ≈ 105
        // rad/s (1e-8 per entry) already shows at 3e-5; ε = 1e-4 leaves ε² ≈ 1e-8 nonlinearity.
        let eps = 1e-4;
        let mut phi = DMatrix::zeros(4, 4);
        for c in 0..4 {
            let mut xp = x0.clone();
            xp[c] += eps;
            rk4(&mut kane, &mut xp, 0.0, period / steps as f64, steps, |_, _, _| {});
            let mut xm = x0.clone();
            xm[c] -= eps;
            rk4(&mut kane, &mut xm, 0.0, period / steps as f64, steps, |_, _, _| {});
            for r in 0..4 {
                phi[(r, c)] = (xp[r] - xm[r]) / (2.0 * eps);
            }
        }
        // The speeds are absolute (u1, u2) while the HBM's state is (q, q̇); the multipliers do
        // not depend on the coordinates. Drop the cyclic spin angle θ.
        let reduced = phi.remove_row(0).remove_column(0);
        let mut mu: Vec<Complex<f64>> = reduced.complex_eigenvalues().iter().copied().collect();
        mu.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let mut diff = 0.0f64;
        for m in &mu {
            let nearest = st.multipliers.iter().map(|s| (s - m).norm()).fold(f64::INFINITY, f64::min);
            diff = diff.max(nearest);
        }
        println!(
            "n = 3.05, a_n {:8.3}: HBM |μ| max {:.7} stable {} | differenced {:?} → max diff {diff:.1e}",
            sol.order_acceleration(0, 1.0),
            st.max_modulus,
            st.stable,
            mu.iter().map(|m| format!("{m:.9}")).collect::<Vec<_>>()
        );
        assert_eq!(st.stable, mu[0].norm() < 1.0);
        worst = worst.max(diff);
    }
    // The HBM multipliers do not move by 1e-8 when H, N_t, N_s or the difference step change;
    // the differenced reference moves by ~2e-6 between ε = 1e-4 and 1e-5 and step counts
    // 2000/8000 (measured), so 1e-5 bounds the comparison.
    assert!(worst < 1e-5, "Floquet multipliers differ by {worst:e}");
}

#[test]
fn continuation_finds_the_jump_orders() {
    let n_t = CpvaParams::canonical().n_t;
    // 40 N·m: an S-shaped branch (softening): the up-sweep jumps at the fold of largest order
    // near the rotor order, the down-sweep falls back at the fold of smallest order, below n_t
    // and above 2.9 (paper, Fig. 3).
    let (_, b40) = branch(40.0, 2.9, 3.3);
    assert_eq!(b40.end, BranchEnd::ReachedTarget);
    assert_eq!(b40.folds.len(), 2, "{:?}", b40.folds);
    let (up, down) = (&b40.folds[0], &b40.folds[1]);
    assert_eq!(up.kind, FoldKind::Maximum);
    assert_eq!(down.kind, FoldKind::Minimum);
    assert!(up.order > n_t && up.order < 3.3, "up-sweep jump at {}", up.order);
    assert!(down.order > 2.9 && down.order < n_t, "down-sweep jump at {}", down.order);
    // Stability changes exactly at the folds: the Floquet multipliers (computed independently
    // of the tangent that locates a fold) change stability in the very step that holds each
    // fold, by a real multiplier through +1, and nowhere else.
    assert_eq!(b40.bifurcations.len(), 2);
    for (f, bif) in b40.folds.iter().zip(&b40.bifurcations) {
        assert_eq!(f.after, bif.after, "fold at {} vs stability change at {}", f.order, bif.order);
        assert_eq!(bif.kind, BifurcationKind::PlusOne);
    }
    // 500 N·m: the branch from 2.9 turns back at its fold and leaves the range at 2.9 on the
    // upper branch (no fall-back within the range, paper Fig. 4); the main-order minimum moves
    // below n_t (softening) and the second order exceeds the main order near it.
    let (mut h500, b500) = branch(500.0, 2.9, 3.3);
    assert_eq!(b500.end, BranchEnd::LeftRange);
    assert_eq!(b500.folds.len(), 1);
    assert_eq!(b500.folds[0].kind, FoldKind::Maximum);
    let lower: Vec<_> = b500.points.iter().take_while(|p| p.order_slope > 0.0).collect();
    let min = lower.iter().min_by(|a, b| a.accel_main.total_cmp(&b.accel_main)).unwrap();
    assert!(min.order < n_t - 0.005, "main-order minimum at {}", min.order);
    // The branch points are as sparse as the step control allows, so the second-order excess is
    // looked for by solves on the low branch every 0.0025 from n_t − 0.05 to its fold.
    let fine: Vec<(f64, f64, f64)> = (0..=20)
        .map(|k| n_t - 0.05 + 0.0025 * k as f64)
        .filter(|&n| n < b500.folds[0].order)
        .map(|n| {
            let sol = h500.solve(n, b500.guesses_at(n).first().copied()).unwrap();
            (n, sol.order_acceleration(0, 1.0), sol.order_acceleration(0, 2.0))
        })
        .collect();
    assert!(fine.iter().any(|&(_, main, second)| second > main), "{fine:?}");
    println!(
        "40 N·m folds: up-sweep jump {:.5}, down-sweep jump {:.5}; 500 N·m fold {:.5}, main-order minimum {:.4} at n = {:.4}",
        up.order, down.order, b500.folds[0].order, min.accel_main, min.order
    );
}

/// More harmonics change nothing at the 1e-6 level on the large-amplitude upper branch, and
/// too few are reported.
#[test]
fn harmonic_count_is_checked() {
    let h = single(500.0);
    let mut h10 = cpva_hbm(&h, HbmOptions::default());
    let (_, down) = branch(500.0, 3.3, 2.9);
    let g = down.guesses_at(3.0)[0];
    let s10 = h10.solve(3.0, Some(g)).unwrap();
    let mut h16 = cpva_hbm(&h, HbmOptions { harmonics: 16, ..HbmOptions::default() });
    let s16 = h16.solve(3.0, Some(&s10)).unwrap();
    for m in [1.0, 2.0] {
        let (a, b) = (s10.order_acceleration(0, m), s16.order_acceleration(0, m));
        assert!(abs_diff_eq!(a / b, 1.0, epsilon = 1e-6), "order {m}n: H = 10 {a} vs H = 16 {b}");
    }
    assert!(!s10.needs_more_harmonics, "ratio {}", s10.top_harmonic_ratio);
    let mut h3 = cpva_hbm(&h, HbmOptions { harmonics: 3, ..HbmOptions::default() });
    let s3 = h3.solve(3.0, Some(&s10)).unwrap();
    assert!(s3.needs_more_harmonics, "H = 3: top-harmonic ratio {}", s3.top_harmonic_ratio);
}

/// Any mechanism: four synchronous pendulums carrying the same total mass give the same rotor
/// response as one (a 5-DOF problem), and a two-order excitation (n, 2n with the paper's phase)
/// keeps the base frequency nΩ and matches time integration.
#[test]
fn four_pendulums_and_two_orders() {
    let h = vec![
        Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 },
        Harmonic { multiple: 2.0, amplitude: 20.0, phase: -0.32 },
    ];
    let p4 = CpvaParams::canonical().with_pendulums(4);
    let mech4 = p4.mechanism(None).unwrap();
    let kane4 = Kane::new(&mech4).unwrap();
    let opts = HbmOptions { stability_samples: 0, ..HbmOptions::default() };
    let mut hbm4 = Hbm::new(&kane4, 0, omega(), &h, opts).unwrap();
    let mut hbm1 = cpva_hbm(&h, opts);
    let s1 = hbm1.solve(3.0, None).unwrap();
    let s4 = hbm4.solve(3.0, None).unwrap();
    assert_abs_diff_eq!(s1.base_frequency, 3.0 * omega(), epsilon = 1e-12);
    for m in [1.0, 2.0] {
        let (a, b) = (s1.order_acceleration(0, m), s4.order_acceleration(0, m));
        assert!(abs_diff_eq!(a / b, 1.0, epsilon = 1e-8), "order {m}n: N = 1 {a} vs N = 4 {b}");
    }
    let tc = time_check(&hbm1, &h, &s1, 0.0, 40, 20);
    let e = (tc.main / s1.order_acceleration(0, 1.0) - 1.0)
        .abs()
        .max((tc.second / s1.order_acceleration(0, 2.0) - 1.0).abs());
    println!(
        "two orders: HBM {:.5} {:.5}, time {:.5} {:.5}",
        s1.order_acceleration(0, 1.0),
        s1.order_acceleration(0, 2.0),
        tc.main,
        tc.second
    );
    assert!(e < 1e-4, "two-order excitation: HBM vs time integration {e:e}");
    // A half order makes the base frequency nΩ/2.
    let half = vec![
        Harmonic { multiple: 0.5, amplitude: 5.0, phase: 0.0 },
        Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 },
    ];
    let s = cpva_hbm(&half, opts).solve(3.0, None).unwrap();
    assert_abs_diff_eq!(s.base_frequency, 1.5 * omega(), epsilon = 1e-12);
    assert_eq!(s.harmonic_of(1.0), Some(2));
}

/// The 40 N·m order folds, seen from the other two parameters. A fold of the order branch at
/// (n*, 40 N·m, 1000 rpm) is a point where ∂R̂/∂x is singular; a continuation in the torque scale
/// at fixed n* or in the mean speed at fixed n* passes through the same point, and (∂R̂/∂p not in
/// the range of ∂R̂/∂x, the generic case) turns there too. So each must find a fold at exactly
/// T = 40 N·m, resp. Ω = 1000 rpm. Each fold is refined to |dλ/ds| < 1e-6, which places it
/// within ~1e-12/κ of the true fold (κ the curvature of λ(s)), and the Newton tolerance (1e-10
/// on the unknowns) moves it by a comparable amount; 1e-7 relative leaves a wide margin (the
/// measured agreement is printed).
#[test]
fn torque_and_speed_continuations_find_the_order_folds() {
    let (_, b40) = branch(40.0, 2.9, 3.3);
    let up = b40.folds.iter().find(|f| f.kind == FoldKind::Maximum).unwrap().order;
    let down = b40.folds.iter().find(|f| f.kind == FoldKind::Minimum).unwrap().order;
    let copts = ContinuationOptions::default();
    // Upper fold: from small torque at n = n*, the non-resonant sheet rises until 40 N·m, where it
    // turns back onto the unstable middle sheet (which turns again, onto the resonant sheet, at a
    // smaller torque).
    let mut hbm = cpva_hbm(&single(40.0), HbmOptions::default());
    let bt = hbm.continue_in(Parameter::TorqueScale { order: up }, 0.02, 3.0, None, &copts).unwrap();
    assert_eq!(bt.end, BranchEnd::ReachedTarget);
    assert_eq!(bt.folds.len(), 2, "{:?}", bt.folds);
    assert_eq!(bt.folds[0].kind, FoldKind::Maximum);
    assert!(bt.folds[1].parameter < 1.0);
    let t_fold = 40.0 * bt.folds[0].parameter;
    assert!(abs_diff_eq!(t_fold / 40.0, 1.0, epsilon = 1e-7), "torque fold at n = {up}: {t_fold} N·m");
    // Lower fold: the resonant sheet at n = n* exists above 40 N·m only; start on it at 60 N·m
    // (from the order branch continued down from 3.3, whose end sheet is the resonant one) and
    // continue the torque scale down.
    let mut h60 = cpva_hbm(&single(40.0), HbmOptions::default());
    h60.set_torque_scale(1.5).unwrap();
    let b60 = h60.continue_in_order(3.3, 2.9, None, &copts).unwrap();
    let start = b60
        .guesses_at(down)
        .into_iter()
        .max_by(|a, b| a.order_acceleration(0, 1.0).total_cmp(&b.order_acceleration(0, 1.0)))
        .unwrap()
        .clone();
    let bd = h60.continue_in(Parameter::TorqueScale { order: down }, 1.5, 0.5, Some(&start), &copts).unwrap();
    let fd = bd.folds.first().unwrap_or_else(|| panic!("no torque fold at n = {down}: {:?}", bd.end));
    assert_eq!(fd.kind, FoldKind::Minimum);
    assert!(abs_diff_eq!(fd.parameter, 1.0, epsilon = 1e-7), "torque fold at n = {down}: {} N·m", 40.0 * fd.parameter);
    // Speed at the upper fold order: the single-order CPVA depends on Ω through T/Ω² and the
    // damping ratios, so slowing down at 40 N·m acts like raising the torque: the non-resonant
    // sheet, continued down from 1600 rpm, ends at 1000 rpm and turns back (a speed minimum).
    let w = |rpm: f64| rpm_to_rad_s(rpm);
    let bs = hbm.continue_in(Parameter::Speed { order: up }, w(1600.0), w(600.0), None, &copts).unwrap();
    let fs = bs.folds.first().unwrap_or_else(|| panic!("no speed fold at n = {up}: {:?}", bs.end));
    assert_eq!(fs.kind, FoldKind::Minimum);
    assert!(
        abs_diff_eq!(fs.parameter / w(1000.0), 1.0, epsilon = 1e-7),
        "speed fold at n = {up}: {} rad/s",
        fs.parameter
    );
    println!(
        "order folds {up:.7} / {down:.7}: torque folds {t_fold:.9} / {:.9} N·m; speed fold {:.7} rpm",
        40.0 * fd.parameter,
        fs.parameter * 30.0 / PI
    );
    // Any point of a speed branch is the fixed-speed solution there: solve at its Ω from the
    // previous point's solution (another speed) and compare the coefficients.
    let mut worst = 0.0f64;
    for w2 in bs.points.windows(2).step_by(5) {
        let mut fixed = cpva_hbm(&single(40.0), HbmOptions { stability_samples: 0, ..HbmOptions::default() });
        fixed.set_speed(w2[1].parameter).unwrap();
        let sol = fixed.solve(up, Some(&w2[0].solution)).unwrap();
        let diff = sol
            .coefficients
            .iter()
            .zip(&w2[1].solution.coefficients)
            .map(|(a, b)| (a - b).abs())
            .fold((sol.mean_torque - w2[1].solution.mean_torque).abs(), f64::max);
        worst = worst.max(diff);
    }
    println!("speed branch vs fixed-speed solves: largest coefficient difference {worst:.1e}");
    // Both converge to 1e-10 on the step (Newton converges quadratically, so the error is far
    // smaller); 1e-9 rad (N·m for the mean torque) is the bound asked for.
    assert!(worst < 1e-9, "speed branch and fixed-speed solves differ by {worst:e}");
}

/// The multi-order load case at 600 rpm (paper section 4.2, Table 1, Fig. 5: n = 3,
/// T_n = 670 N·m, T_2n = 430 N·m, α_2n = −0.32 rad) has a single periodic state: the
/// low-amplitude (absorbing) branch ends at a fold before the Table 1 torques are reached, so the
/// response must sit on the upper branch — the paper's "jump" at 600 rpm. Shown three ways, each
/// continuing from the low-amplitude end: in the torque scale s (both torques × s) at 600 rpm,
/// in the speed with the 600 rpm torques held, and in the order at 600 rpm; then the one state
/// against time integration.
#[test]
fn multi_order_600_rpm_has_only_the_upper_state() {
    let h = vec![
        Harmonic { multiple: 1.0, amplitude: 670.0, phase: 0.0 },
        Harmonic { multiple: 2.0, amplitude: 430.0, phase: -0.32 },
    ];
    let mech = CpvaParams::canonical().mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let copts = ContinuationOptions::default();
    let w600 = rpm_to_rad_s(600.0);
    let mut hbm = Hbm::new(&kane, 0, w600, &h, HbmOptions::default()).unwrap();
    // Torque: the low branch rises to a fold at s* < 1, the unstable middle branch returns to
    // small s and turns onto the upper branch, which alone reaches s = 1.
    let bt = hbm.continue_in(Parameter::TorqueScale { order: 3.0 }, 0.01, 1.5, None, &copts).unwrap();
    assert_eq!(bt.end, BranchEnd::ReachedTarget);
    assert_eq!(bt.folds.len(), 2, "{:?}", bt.folds);
    let s_fold = bt.folds[0].parameter;
    assert_eq!(bt.folds[0].kind, FoldKind::Maximum);
    assert!(s_fold < 0.95 && bt.folds[1].parameter < s_fold, "folds {:?}", bt.folds);
    // Speed with the 600 rpm torques: coming down from 900 rpm, the low branch turns back above
    // 600 rpm.
    let bs = hbm.continue_in(Parameter::Speed { order: 3.0 }, rpm_to_rad_s(900.0), w600, None, &copts).unwrap();
    let f_speed = bs.folds.first().unwrap_or_else(|| panic!("no speed fold: {:?}", bs.end));
    assert_eq!(f_speed.kind, FoldKind::Minimum);
    let rpm_fold = f_speed.parameter * 30.0 / PI;
    assert!(rpm_fold > 610.0, "speed fold at {rpm_fold} rpm");
    // The two folds are one point of the fold curve: at the fold speed, the torque continuation
    // from small torque must turn at s = 1 (same argument and tolerance as for the 40 N·m folds).
    let mut at_fold = Hbm::new(&kane, 0, f_speed.parameter, &h, HbmOptions::default()).unwrap();
    let bf = at_fold.continue_in(Parameter::TorqueScale { order: 3.0 }, 0.01, 1.5, None, &copts).unwrap();
    assert!(
        abs_diff_eq!(bf.folds[0].parameter, 1.0, epsilon = 1e-7),
        "torque fold at {rpm_fold} rpm: s = {}",
        bf.folds[0].parameter
    );
    // Order at 600 rpm: the branch from low orders turns back below n = 3.
    let bo = hbm.continue_in(Parameter::Order, 2.6, 3.4, None, &copts).unwrap();
    let f_order = bo.folds.first().unwrap();
    assert_eq!(f_order.kind, FoldKind::Maximum);
    assert!(f_order.order < 3.0, "order fold {}", f_order.order);
    println!(
        "600 rpm, n = 3: low branch ends at s = {s_fold:.5} (T_n = {:.1}, T_2n = {:.1} N·m), at {rpm_fold:.2} rpm with the \
         600 rpm torques, at n = {:.5} at 600 rpm",
        670.0 * s_fold,
        430.0 * s_fold,
        f_order.order
    );
    // Every sheet of every branch gives the same single state at the Table 1 torques.
    let mut states: Vec<HbmSolution> = Vec::new();
    let cands: Vec<HbmSolution> = bt
        .guesses_at(1.0)
        .into_iter()
        .chain(bo.guesses_at(3.0))
        .chain(hbm.continue_in(Parameter::Order, 3.4, 2.6, None, &copts).unwrap().guesses_at(3.0))
        .cloned()
        .collect();
    for g in &cands {
        let sol = hbm.solve(3.0, Some(g)).unwrap();
        if !states.iter().any(|o| (o.order_acceleration(0, 1.0) / sol.order_acceleration(0, 1.0) - 1.0).abs() < 1e-8) {
            states.push(sol);
        }
    }
    assert_eq!(
        states.len(),
        1,
        "states at 600 rpm: {:?}",
        states.iter().map(|s| s.order_acceleration(0, 1.0)).collect::<Vec<_>>()
    );
    let mut sol = states.pop().unwrap();
    sol.stability = Some(hbm.stability(&sol).unwrap());
    assert!(sol.stability.as_ref().unwrap().stable);
    // Time integration from the HBM state with a 1e-3 perturbation of the pendulum angle.
    let tc = time_check(&hbm, &h, &sol, 1e-3, 60, 20);
    let (a1, a2) = (sol.order_acceleration(0, 1.0), sol.order_acceleration(0, 2.0));
    let e = (tc.main / a1 - 1.0).abs().max((tc.second / a2 - 1.0).abs());
    println!("600 rpm upper state: HBM {a1:.4} {a2:.4} rad/s², time {:.4} {:.4}: {e:.1e}", tc.main, tc.second);
    assert!(e < 5e-3, "600 rpm: HBM vs time integration {e:e}");
}

/// The dense output between branch points: at the middle of every segment of the 40 N·m
/// branch (the segments holding a fold excepted, where a fixed-order solve is ill-conditioned),
/// the Hermite-interpolated state against a Newton solve at the same order started from it.
/// Cubic Hermite interpolation errs by O(h⁴) in the coefficients. The worst segment is the one
/// across the main-order antiresonance (n ≈ 3.07, measured 1.2 % of the local amplitude): the
/// rotor's coefficients are ~1e-3 of the pendulum's, so the arclength, and with it the step,
/// hardly sees them. Bound 2 % there; the linear interpolation of the amplitudes, what a plot
/// of the points alone draws, must be at least 10× worse (measured 28 %).
#[test]
fn hermite_dense_output_matches_solves_between_points() {
    let (mut hbm, b) = branch(40.0, 2.9, 3.3);
    let (mut worst, mut worst_linear) = (0.0f64, 0.0f64);
    for i in 0..b.points.len() - 1 {
        if b.folds.iter().any(|f| f.after == i) {
            continue;
        }
        let mid = b.interpolate(i, 0.5).unwrap();
        let sol = hbm.solve(mid.order, Some(&mid)).unwrap();
        let (a0, a1) = (b.points[i].accel_main, b.points[i + 1].accel_main);
        let exact = sol.order_acceleration(0, 1.0);
        let scale = exact.max(a0).max(a1);
        let e = (mid.order_acceleration(0, 1.0) - exact).abs() / scale;
        let e2 = (mid.order_acceleration(0, 2.0) - sol.order_acceleration(0, 2.0)).abs() / scale;
        worst = worst.max(e).max(e2);
        worst_linear = worst_linear.max((0.5 * (a0 + a1) - exact).abs() / scale);
        assert!(mid.residual.is_nan() && mid.stability.is_none());
    }
    println!("dense output: worst mid-segment error {worst:.2e} of the local amplitude (linear: {worst_linear:.2e})");
    assert!(worst < 2e-2, "Hermite mid-segment error {worst:e}");
    assert!(worst_linear > 10.0 * worst, "linear {worst_linear:e} vs Hermite {worst:e}");
    assert!(b.interpolate(b.points.len() - 1, 0.5).is_none());
}
/// The monodromy's time step: along the whole 40 N·m branch, the multipliers at the default
/// N_s = 256 against N_s = 2048 (both Richardson-extrapolated RK4, sixth order: the 128 → 256
/// error ratio measured 60 ≈ 2⁶). Measured worst 8.7e-8; the bound 1e-6 stays far inside the
/// 3e-5 margin of the mean-speed multiplier (module docs of `hbm::stability`), so no verdict
/// can flip on the step. Plain RK4 at 256 was off by 1.7e-5, half that margin.
#[test]
fn floquet_multipliers_converge_in_the_step() {
    let (_, b) = branch(40.0, 2.9, 3.3);
    let mut fine = cpva_hbm(&single(40.0), HbmOptions { stability_samples: 2048, ..HbmOptions::default() });
    let mut worst = 0.0f64;
    for p in &b.points {
        let a = p.solution.stability.as_ref().unwrap();
        let c = fine.stability(&p.solution).unwrap();
        assert_eq!(a.stable, c.stable, "n = {}", p.order);
        for x in &a.multipliers {
            let d = c.multipliers.iter().map(|y| (x - y).norm()).fold(f64::INFINITY, f64::min);
            worst = worst.max(d);
        }
    }
    println!("multipliers N_s = 256 vs 2048: worst {worst:.2e}");
    assert!(worst < 1e-6, "{worst:e}");
}

/// Two synchronous pendulums (half the mass each) at 40 N·m: the unison branch is the
/// one-pendulum branch (same folds to 1e-8), and the extra, antisymmetric multipliers stay
/// inside the unit circle over 2.9–3.3: the only crossings are the two folds (no symmetry
/// breaking of the unison response in the paper's range; with 2 pendulums the monodromy is
/// 6 × 6, so this also runs the padded fixed-size integration).
#[test]
fn two_pendulums_keep_unison_between_the_folds() {
    let p2 = CpvaParams::canonical().with_pendulums(2);
    let kane2 = Kane::new(&p2.mechanism(None).unwrap()).unwrap();
    let mut hbm2 = Hbm::new(&kane2, 0, omega(), &single(40.0), HbmOptions::default()).unwrap();
    let b2 = hbm2.continue_in_order(2.9, 3.3, None, &ContinuationOptions::default()).unwrap();
    let (_, b1) = branch(40.0, 2.9, 3.3);
    assert_eq!(b2.folds.len(), 2);
    for (f1, f2) in b1.folds.iter().zip(&b2.folds) {
        assert!(abs_diff_eq!(f1.order, f2.order, epsilon = 1e-8), "folds {} vs {}", f1.order, f2.order);
    }
    let kinds: Vec<_> = b2.bifurcations.iter().map(|b| (b.kind, b.unstable_after)).collect();
    assert_eq!(kinds, vec![(BifurcationKind::PlusOne, 1), (BifurcationKind::PlusOne, 0)]);
    for (f, bif) in b2.folds.iter().zip(&b2.bifurcations) {
        assert_eq!(f.after, bif.after);
    }
    // Five physical multipliers with two pendulums (2·3 − 1), three with one.
    assert!(b2.points.iter().all(|p| p.solution.stability.as_ref().unwrap().multipliers.len() == 5));
}
/// Symmetry breaking of the unison response, found by the multipliers and confirmed by time
/// integration. With two synchronous pendulums at 500 N·m the lower branch loses stability
/// inside 2.9–3.3 by a real multiplier through +1 *before* its fold (one pendulum at the same
/// torque stays stable there up to the fold): the pendulums' antisymmetric motion, which the
/// unison solution does not excite, grows. Time integration from the HBM state with an
/// antisymmetric perturbation of 1e-7 rad (φ₁ + ε, φ₂ − ε) shows φ₁ − φ₂ growing by the largest
/// multiplier per period inside the interval, and its envelope decaying outside it. The growth is read from
/// the period ends 150–250: the other antisymmetric multipliers have moduli up to ≈ 0.99, so
/// their share has fallen to ~1e-2 by then and moves the 100-period mean by ~1e-4; RK4 with 200
/// steps per period and the remaining nonlinearity (φ₁ − φ₂ stays below 1e-4 rad) add less. Bound
/// 1e-3 relative to μ (measured difference printed).
#[test]
fn two_pendulums_break_unison_between_the_multiplier_crossings() {
    let torque = 500.0;
    let p2 = CpvaParams::canonical().with_pendulums(2);
    let kane2 = Kane::new(&p2.mechanism(None).unwrap()).unwrap();
    let mut hbm2 = Hbm::new(&kane2, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
    // Crossings are seen between successive points, and the unstable interval is only ~0.02
    // wide in n: the default step (up to 0.1 in the unknowns' norm) can step over it, so the
    // step is capped here (ContinuationOptions::ds_max).
    let copts = ContinuationOptions { ds_max: 0.02, ..ContinuationOptions::default() };
    let b2 = hbm2.continue_in_order(2.9, 3.3, None, &copts).unwrap();
    let (_, b1) = branch(torque, 2.9, 3.3);
    assert!(b1.bifurcations.iter().all(|x| b1.folds.iter().any(|f| f.after == x.after)), "{:?}", b1.bifurcations);
    let fold = b2.folds[0].order;
    let off_fold: Vec<_> = b2.bifurcations.iter().filter(|x| !b2.folds.iter().any(|f| f.after == x.after)).collect();
    assert_eq!(off_fold.len(), 2, "{:?}", b2.bifurcations);
    assert!(off_fold.iter().all(|x| x.kind == BifurcationKind::PlusOne));
    let (n_lose, n_regain) = (off_fold[0].order, off_fold[1].order);
    assert!(off_fold[0].unstable_after == 1 && off_fold[1].unstable_after == 0);
    assert!(2.9 < n_lose && n_lose < n_regain && n_regain < fold, "{n_lose} {n_regain} {fold}");
    println!("unison lost at n = {n_lose:.7}, regained at {n_regain:.7}, fold at {fold:.5}");
    // The crossings are located by bisection: 1e-5 to either side, fixed-order solves from the
    // branch have the other number of multipliers outside.
    let outside = |hbm: &mut Hbm, n: f64| {
        let sol = hbm.solve(n, b2.guesses_at(n).first().copied()).unwrap();
        hbm.stability(&sol).unwrap().multipliers.iter().filter(|m| m.norm() > 1.0).count()
    };
    for (n, before, after) in [(n_lose, 0, 1), (n_regain, 1, 0)] {
        assert_eq!((outside(&mut hbm2, n - 1e-5), outside(&mut hbm2, n + 1e-5)), (before, after), "crossing at {n}");
    }

    for (n, inside) in [(0.5 * (n_lose + n_regain), true), (n_lose - 0.03, false)] {
        let guess = b2.guesses_at(n)[0].clone();
        let mut sol = hbm2.solve(n, Some(&guess)).unwrap();
        sol.stability = Some(hbm2.stability(&sol).unwrap());
        let mu = sol.stability.as_ref().unwrap().max_modulus;
        let exc = Excitation {
            mean: sol.mean_torque,
            rpm: RPM,
            order: Order::Fixed(n),
            harmonics: single(torque),
            ramp_s: 0.0,
        };
        let mut kane = Kane::new(&p2.mechanism(Some(exc)).unwrap()).unwrap();
        let mut x = hbm2.state_at(&sol, 0.0);
        let eps = 1e-7;
        x[1] += eps;
        x[2] -= eps;
        let period = 2.0 * PI / sol.base_frequency;
        let h = period / STEPS as f64;
        let mut ends = Vec::new();
        let mut step = 0;
        rk4(&mut kane, &mut x, 0.0, h, 251 * STEPS, |_, x, _| {
            if step % STEPS == 0 {
                ends.push((x[1] - x[2]).abs());
            }
            step += 1;
        });
        let growth = (ends[250] / ends[150]).powf(1.0 / 100.0);
        println!(
            "n = {n:.5}: largest multiplier {mu:.6}, φ₁ − φ₂ grows by {growth:.6} per period ({:.1e} off), reaches {:.1e} rad",
            (growth / mu - 1.0).abs(),
            ends[250]
        );
        if inside {
            assert!(mu > 1.0 && growth > 1.0, "inside: μ {mu}, growth {growth}");
            assert!(abs_diff_eq!(growth / mu, 1.0, epsilon = 1e-3), "growth {growth} vs μ {mu}");
        } else {
            // Outside, the antisymmetric multipliers are a complex pair (|μ| ≈ 0.997): φ₁ − φ₂
            // decays while it oscillates from period to period, so its envelope is compared.
            let envelope = |r: std::ops::RangeInclusive<usize>| ends[r].iter().fold(0.0f64, |m, v| m.max(*v));
            let (early, late) = (envelope(0..=50), envelope(200..=250));
            println!("   outside: envelope of φ₁ − φ₂ {early:.2e} (periods 0–50) → {late:.2e} (200–250)");
            assert!(mu < 1.0 && late < 0.9 * early, "outside: μ {mu}, envelope {early:e} → {late:e}");
        }
    }
}
