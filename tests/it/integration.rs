//! Time integration (DOP853 with the streaming sampler) and probes, checked against conservation
//! laws, the closed form of eq. (7), the N-pendulum invariance and deliberate failures.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::cpva::CpvaParams;
use kanedyn::error::EngineError;
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order, rpm_to_rad_s};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::time::integrate::{IntegrateError, IntegrateOptions, Sample, integrate};
use kanedyn::time::probe::{Outcome, Probe, ProbeKind, Recorder, simulate, simulate_streamed};
use std::path::Path;

/// 1000 rpm, the speed of the paper's order sweeps (section 4.1).
fn omega() -> f64 {
    rpm_to_rad_s(1000.0)
}

/// Mean torque c_r·Ω (holds the mean speed) plus `amplitude` N·m at order `order`, ramped in over
/// 2 s (docs/design/conventions.md study conventions).
fn excitation(p: &CpvaParams, amplitude: f64, order: f64) -> Excitation {
    Excitation {
        mean: p.c_r * omega(),
        rpm: 1000.0,
        order: Order::Fixed(order),
        harmonics: vec![Harmonic { multiple: 1.0, amplitude, phase: 0.0 }],
        ramp_s: 2.0,
    }
}

/// Tight tolerances for comparisons: two different step sequences (or right-hand sides that
/// differ by rounding) agree only to the integration error, so it must sit well below the 1e-8
/// the tests ask for; rtol 1e-12 gives a few 1e-11 over these runs.
fn tight() -> IntegrateOptions {
    IntegrateOptions { rtol: 1e-12, atol: 1e-12, ..IntegrateOptions::default() }
}

/// Kinetic energy (J) and angular momentum about O (N·m·s) of the rotor-CPVA, body by body from
/// positions and velocities built here from R, L, ψ_i (not from the engine):
/// `H_O = Σ_j I_j ω_j + m_j (r_j × v_j)`, `T = Σ_j ½ I_j ω_j² + ½ m_j |v_j|²`, with the
/// pendulum's centre at `r = R e(θ+ψ) + L e(θ+ψ+φ)` and the rotor's centre on O.
fn energy_and_momentum(p: &CpvaParams, x: &[f64]) -> (f64, f64) {
    let n = p.n_pendulums;
    let (theta, u1) = (x[0], x[n + 1]);
    let (m, i_b) = (p.pendulum_mass / n as f64, p.i_b() / n as f64);
    let (r, l) = (p.pivot_radius, p.l());
    let mut t = 0.5 * p.i_a() * u1 * u1;
    let mut h = p.i_a() * u1;
    for i in 0..n {
        let (phi, u) = (x[1 + i], x[n + 2 + i]);
        let a = theta + p.pivot_angle(i);
        let b = a + phi;
        let pos = [r * a.cos() + l * b.cos(), r * a.sin() + l * b.sin()];
        let vel = [-r * u1 * a.sin() - l * u * b.sin(), r * u1 * a.cos() + l * u * b.cos()];
        t += 0.5 * i_b * u * u + 0.5 * m * (vel[0] * vel[0] + vel[1] * vel[1]);
        h += i_b * u + m * (pos[0] * vel[1] - pos[1] * vel[0]);
    }
    (t, h)
}

#[test]
fn undamped_cpva_conserves_energy_and_angular_momentum() {
    let p = CpvaParams { c_p: 0.0, c_r: 0.0, ..CpvaParams::canonical() };
    let mech = p.mechanism(None).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    // φ = 0.5 rad and a relative rate of 3 rad/s: a large nonlinear swing.
    let x0 = [0.0, 0.5, w, w + 3.0];
    let (t0, h0) = energy_and_momentum(&p, &x0);
    // The engine's ½uᵀMu and 1ᵀMu (for absolute speeds with the rotor on O, a rigid rotation about
    // O is δu = (1, 1), so Σ_r (Mu)_r is H_O) agree with the body-by-body values.
    let mm = kane.mass_matrix(&x0[..2]).clone();
    let u = nalgebra::DVector::from_column_slice(&x0[2..]);
    let mu = &mm * &u;
    assert!(abs_diff_eq!(0.5 * u.dot(&mu), t0, epsilon = 1e-13 * t0), "½uᵀMu {} vs {t0}", 0.5 * u.dot(&mu));
    assert!(abs_diff_eq!(mu.sum(), h0, epsilon = 1e-13 * h0), "Σ(Mu) {} vs {h0}", mu.sum());

    let (mut de, mut dh) = (0.0f64, 0.0f64);
    let run = integrate(
        |t, x, dx| kane.rhs(t, x, dx),
        &x0,
        0.0,
        10.0,
        &tight(),
        |s| {
            let (t, h) = energy_and_momentum(&p, s.x);
            de = de.max((t - t0).abs() / t0);
            dh = dh.max((h - h0).abs() / h0);
        },
    )
    .unwrap();
    println!("conservation over 10 s: energy {de:.2e}, momentum {dh:.2e}; {}", run.stats);
    // 10 s at rtol 1e-12 (≈ 25,000 steps): the accumulated local errors were measured at 4.8e-12
    // (energy) and 2.4e-12 (momentum); 1e-9 leaves a wide margin for other platforms.
    assert!(de < 1e-9, "relative energy drift {de:e}");
    assert!(dh < 1e-9, "relative angular-momentum drift {dh:e}");
    assert_eq!(run.stats.samples, 20_001);
}

#[test]
fn rotor_damping_removes_exactly_its_angular_impulse() {
    // Pivot damping c_p is internal (equal and opposite on rotor and pendulum) and leaves H_O
    // alone; the rotor's loss to ground c_r·u1 is the only external torque:
    // H_O(t) = H_O(0) − c_r ∫₀ᵗ u1 dτ.
    let p = CpvaParams::canonical();
    let mech = p.mechanism(None).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    let x0 = [0.0, 0.5, w, w];
    let (_, h0) = energy_and_momentum(&p, &x0);
    let (mut h, mut u1, mut theta) = (Vec::new(), Vec::new(), Vec::new());
    integrate(
        |t, x, dx| kane.rhs(t, x, dx),
        &x0,
        0.0,
        10.0,
        &tight(),
        |s| {
            h.push(energy_and_momentum(&p, s.x).1);
            u1.push(s.x[2]);
            theta.push(s.x[0]);
        },
    )
    .unwrap();
    // Composite Simpson on the 2 kHz samples: u1 carries a ~0.5 rad/s ripple at n_t·Ω ≈ 326
    // rad/s, so ωh = 0.16 and the rule errs by ≈ (ωh)⁴/180 · ripple/ω ≈ 1e-8 rad, i.e. 5e-11
    // N·m·s once times c_r — far below the 1e-9·H_O ≈ 4e-7 N·m·s asked for.
    let dt = 1.0 / 2000.0;
    let mut worst = 0.0f64;
    let mut integral = 0.0;
    for k in (2..u1.len()).step_by(2) {
        integral += dt / 3.0 * (u1[k - 2] + 4.0 * u1[k - 1] + u1[k]);
        worst = worst.max((h[k] - h0 + p.c_r * integral).abs());
    }
    let loss = p.c_r * integral;
    println!("H0 = {h0} N·m·s, rotor loss over 10 s = {loss} N·m·s, worst balance error {worst:.2e}");
    assert!(loss > 5.0, "the loss must be visible: {loss}");
    assert!(worst < 1e-9 * h0, "angular-momentum balance off by {worst:e} N·m·s");
    // The same balance with θ = ∫u1 dt, integrated along with the state: exact up to the
    // integration error at every sample.
    let worst_theta = h.iter().zip(&theta).fold(0.0f64, |a, (h, th)| a.max((h - h0 + p.c_r * th).abs()));
    assert!(worst_theta < 1e-9 * h0, "balance with θ off by {worst_theta:e}");
}

/// Rotor rate and acceleration over a 5 s, 500 N·m run at order 3 from rest relative to Ω.
fn rotor_response(n_pendulums: usize) -> (Vec<f64>, Vec<f64>) {
    let p = CpvaParams::canonical().with_pendulums(n_pendulums);
    let mech = p.mechanism(Some(excitation(&p, 500.0, 3.0))).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let n = n_pendulums + 1;
    let mut x0 = vec![0.0; 2 * n];
    x0[n..].iter_mut().for_each(|u| *u = omega());
    let probes = [
        Probe::resolve(&mech, ProbeKind::BodyRate, "rotor").unwrap(),
        Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap(),
    ];
    let (r, out) = run(&mut kane, &x0, 0.0, 5.0, &tight(), &probes);
    assert!(out.error.is_none(), "{:?}", out.error);
    assert_eq!(r.names(), ["rotor.rate", "rotor.accel"]);
    assert_eq!(out.stats.sample_rhs_evals, r.time.len());
    let mut cols = r.columns.into_iter();
    (cols.next().unwrap(), cols.next().unwrap())
}

/// One `simulate` into a fresh recorder of `probes`.
fn run(
    kane: &mut Kane,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    probes: &[Probe],
) -> (Recorder, Outcome) {
    let mut rec = Recorder::new(kane.mechanism(), probes).unwrap();
    let out = simulate(kane, x0, t0, t1, opts, &mut rec, &mut |_| {});
    (rec, out)
}

fn range(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn four_synchronous_pendulums_act_as_one() {
    let (u1_1, a1_1) = rotor_response(1);
    let (u1_4, a1_4) = rotor_response(4);
    // Scales: the swing of u1 (its peak-to-peak, stricter than |u1| ≈ Ω) and the peak of u̇1.
    let (du, da) = (max_diff(&u1_1, &u1_4) / range(&u1_1), max_diff(&a1_1, &a1_4) / range(&a1_1));
    println!("N = 4 vs N = 1: u1 {du:.2e}, u̇1 {da:.2e} (relative to peak-to-peak {}, {})", range(&u1_1), range(&a1_1));
    // The systems are identical in exact arithmetic; they differ by the integration error of two
    // different step sequences (10 vs 4 states in the error norm) at rtol 1e-12.
    assert!(du < 1e-8, "u1 differs by {du:e}");
    assert!(da < 1e-8, "u̇1 differs by {da:e}");
}

/// θ, φ, u1, u2 and u̇1 of a sample.
fn row(s: &Sample<'_>) -> [f64; 5] {
    [s.x[0], s.x[1], s.x[2], s.x[3], s.xdot.unwrap()[2]]
}

#[test]
fn generic_engine_follows_the_closed_form_eq7() {
    let p = CpvaParams::canonical();
    let exc = excitation(&p, 500.0, 3.0);
    let mech = p.mechanism(Some(exc.clone())).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let cf = p.closed_form();
    let w = omega();
    let x0 = [0.0, 1.0, w, w];
    let opts = IntegrateOptions { sample_derivatives: true, ..tight() };
    let (mut a, mut b) = (Vec::new(), Vec::new());
    integrate(|t, x, dx| kane.rhs(t, x, dx), &x0, 0.0, 5.0, &opts, |s| a.push(row(s))).unwrap();
    integrate(
        |t, x, dx| {
            cf.rhs1(exc.torque(t), x, dx);
            Ok(())
        },
        &x0,
        0.0,
        5.0,
        &opts,
        |s| b.push(row(s)),
    )
    .unwrap();
    assert_eq!(a.len(), 10_001);
    let names = ["θ", "φ", "u1", "u2", "u̇1"];
    for c in 0..5 {
        let (ca, cb): (Vec<f64>, Vec<f64>) = a.iter().zip(&b).map(|(x, y)| (x[c], y[c])).unzip();
        // Scale: the component's range over the run (θ: ≈ 520 rad; φ, u: their swings).
        let rel = max_diff(&ca, &cb) / range(&ca);
        println!("{}: max difference {rel:.2e} of its range {}", names[c], range(&ca));
        assert!(rel < 1e-8, "{} differs by {rel:e} of its range", names[c]);
    }
}

#[test]
fn failures_name_the_time_and_keep_the_samples() {
    let opts = IntegrateOptions::default();
    // (a) A right-hand side that turns NaN after 0.5 s.
    let mut times = Vec::new();
    let err = integrate(
        |t, x, dx| {
            dx[0] = x[1];
            dx[1] = if t > 0.5 { f64::NAN } else { -100.0 * x[0] };
            Ok(())
        },
        &[1.0, 0.0],
        0.0,
        2.0,
        &opts,
        |s| times.push(s.t),
    )
    .unwrap_err();
    let IntegrateError::NonFinite { what, t_eval, t_reached, stats } = &err else { panic!("{err}") };
    println!("{err}");
    assert_eq!(*what, "derivative");
    assert!(*t_eval > 0.5 && *t_reached <= 0.5 && *t_reached > 0.45, "{err}");
    assert!(err.to_string().contains(&format!("t = {t_reached} s")));
    // Every sample up to the time reached was delivered, none after.
    assert_eq!(times.len(), (t_reached * 2000.0).floor() as usize + 1);
    assert_eq!(stats.samples, times.len());
    assert!(times.iter().all(|t| t <= t_reached));

    // (b) An engine error (e.g. a mass matrix that stops being positive definite) after 0.3 s.
    let err = integrate(
        |t, x, dx| {
            if t > 0.3 {
                return Err(EngineError::NotPositiveDefinite { dof: 1, joint: "pivot".into(), pivot: 0.0 });
            }
            dx[0] = x[1];
            dx[1] = -x[0];
            Ok(())
        },
        &[1.0, 0.0],
        0.0,
        1.0,
        &opts,
        |_| {},
    )
    .unwrap_err();
    println!("{err}");
    assert!(matches!(&err, IntegrateError::Engine { source: EngineError::NotPositiveDefinite { .. }, .. }), "{err}");
    assert!(err.t_reached() <= 0.3 && err.to_string().contains("not positive definite"));

    // (c) The step limit, through `simulate` on the CPVA: partial columns survive.
    let p = CpvaParams::canonical();
    let mech = p.mechanism(Some(excitation(&p, 500.0, 3.0))).unwrap();
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    let probe = Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap();
    let short = IntegrateOptions { max_steps: 10, ..opts };
    let (r, out) = run(&mut kane, &[0.0, 0.0, w, w], 0.0, 5.0, &short, &[probe]);
    let err = out.error.as_ref().expect("must stop at the step limit");
    println!("{err}");
    assert!(matches!(err, IntegrateError::MaxSteps { max_steps: 10, .. }));
    assert_eq!(out.stats.accepted + out.stats.rejected, 10);
    assert!(err.t_reached() > 0.0 && out.x_end.is_none());
    assert_eq!(r.time.len(), (err.t_reached() * 2000.0).floor() as usize + 1);
    assert_eq!(r.columns[0].len(), r.time.len());
}

#[test]
fn probes_resolve_by_name_and_read_the_state() {
    let p = CpvaParams::canonical();
    let mech = p.mechanism(Some(excitation(&p, 500.0, 3.0))).unwrap();
    let e = Probe::resolve(&mech, ProbeKind::BodyRate, "rotr").unwrap_err().to_string();
    assert!(e.contains("unknown body `rotr`") && e.contains("rotor, pendulum"), "{e}");
    let e = Probe::resolve(&mech, ProbeKind::JointAngle, "pendulum").unwrap_err().to_string();
    assert!(e.contains("unknown joint `pendulum`") && e.contains("spin, pivot"), "{e}");

    let kinds = [ProbeKind::BodyAngle, ProbeKind::BodyRate, ProbeKind::BodyAccel];
    let mut probes: Vec<Probe> = kinds.iter().map(|&k| Probe::resolve(&mech, k, "pendulum").unwrap()).collect();
    probes.push(Probe::resolve(&mech, ProbeKind::JointAngle, "pivot").unwrap());
    probes.push(Probe::resolve(&mech, ProbeKind::BodyRate, "rotor").unwrap());
    probes.push(Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap());
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    let x0 = [0.0, 0.3, w, w];
    // Accelerations are checked against a 5-point central difference of the recorded rates, so
    // sample finely (20 kHz) and integrate tightly (rtol 1e-12). Truncation: h⁴/30·|u⁽⁵⁾|; at
    // 2 kHz it was measured at 1.1e-4 of the peak (the φ = 0.3 swing and the order-3 torque put
    // harmonics up to ~1000 rad/s in u̇1), so at 20 kHz ≈ 1e-8. Noise: the stencil multiplies
    // the rate's integration error (~1e-12·105 rad/s) by 1.5/h = 3e4, i.e. ~3e-6 rad/s² ≈ 2e-8
    // of the peak. Bound 1e-6.
    let fine = IntegrateOptions { sample_rate_hz: Some(20_000.0), ..tight() };
    let h = 1.0 / 20_000.0;
    let (r, out) = run(&mut kane, &x0, 0.0, 1.0, &fine, &probes);
    assert!(out.error.is_none());
    assert_eq!(r.units(), ["rad", "rad/s", "rad/s²", "rad", "rad/s", "rad/s²"]);
    let col = |name: &str| r.column(name).unwrap();
    // The pendulum's absolute angle is θ + φ; at t = 0 it is 0.3 and it moves with u2.
    assert_eq!(col("pendulum.angle")[0], 0.3);
    assert_eq!(col("pivot.q")[0], 0.3);
    assert_eq!(col("pendulum.rate")[0], w);
    for (rate, accel) in [("rotor.rate", "rotor.accel"), ("pendulum.rate", "pendulum.accel")] {
        let (v, a) = (col(rate), col(accel));
        let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let worst = (2..v.len() - 2).fold(0.0f64, |m, k| {
            let fd = (v[k - 2] - 8.0 * v[k - 1] + 8.0 * v[k + 1] - v[k + 2]) / (12.0 * h);
            m.max((fd - a[k]).abs())
        });
        println!("{accel}: finite-difference mismatch {:.2e} of peak {peak:.1}", worst / peak);
        assert!(worst < 1e-6 * peak, "{accel}: {worst:e} vs peak {peak}");
    }
    // Body angle = θ + φ sample by sample: the angle probes add up.
    let beta = col("pendulum.angle");
    let phi = col("pivot.q");
    assert!(beta.iter().zip(phi).all(|(b, f)| b - f >= -1e-12));

    // Joint rates (triple pendulum): absolute rate of the lowest link is the sum of the joint
    // rates along its path, its angle the sum of the joint angles.
    let tri =
        Mechanism::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/triple_pendulum.ron")).unwrap();
    let probes = [
        Probe::resolve(&tri, ProbeKind::BodyAngle, "lower").unwrap(),
        Probe::resolve(&tri, ProbeKind::BodyRate, "lower").unwrap(),
        Probe::resolve(&tri, ProbeKind::BodyAccel, "lower").unwrap(),
    ];
    let mut kane = Kane::new(&tri).unwrap();
    let x0 = [0.1, 0.2, 0.3, 1.0, -2.0, 0.5];
    let (r, out) = run(&mut kane, &x0, 0.0, 1.0, &fine, &probes);
    assert!(out.error.is_none());
    assert_abs_diff_eq!(r.columns[0][0], 0.6, epsilon = 1e-15);
    assert_abs_diff_eq!(r.columns[1][0], -0.5, epsilon = 1e-15);
    let (v, a) = (&r.columns[1], &r.columns[2]);
    let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = (2..v.len() - 2).fold(0.0f64, |m, k| {
        let fd = (v[k - 2] - 8.0 * v[k - 1] + 8.0 * v[k + 1] - v[k + 2]) / (12.0 * h);
        m.max((fd - a[k]).abs())
    });
    println!("triple pendulum lower.accel: finite-difference mismatch {:.2e} of peak {peak:.1}", worst / peak);
    assert!(worst < 1e-6 * peak);
}

/// A streamed run hands its sink every sample a recorder keeps, value for value, and keeps only
/// the columns asked for: the reference is the same run recorded whole (identical steps, so
/// identical numbers), and a run continued in chunks streams the boundary sample once.
#[test]
fn a_streamed_run_hands_on_what_a_recorder_keeps() {
    let p = CpvaParams::canonical().with_pendulums(2);
    let mech = p.mechanism(Some(excitation(&p, 500.0, 3.0))).unwrap();
    let probes = [
        Probe::resolve(&mech, ProbeKind::JointRate, "spin").unwrap(),
        Probe::resolve(&mech, ProbeKind::JointAngle, "pivot_1").unwrap(),
        Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap(),
    ];
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    let x0 = [0.0, 0.2, -0.3, w, w + 1.5, w - 2.0];
    let opts = tight();
    let (whole, _) = run(&mut kane, &x0, 0.0, 1.0, &opts, &probes);
    let mut rec = Recorder::new(&mech, &probes).unwrap();
    rec.store_only(|c| c == 1);
    let mut rows: Vec<(f64, Vec<f64>)> = Vec::new();
    let mut x = x0.to_vec();
    for k in 0..2 {
        let t0 = 0.5 * k as f64;
        let chunk = simulate_streamed(
            &mut kane,
            &x,
            t0,
            t0 + 0.5,
            &opts,
            &mut rec,
            &mut |t, row| rows.push((t, row.to_vec())),
            &mut |_| {},
        );
        x = chunk.x_end.expect("chunk completes");
    }
    assert_eq!(rows.len(), whole.time.len(), "the boundary sample is streamed once");
    assert!(rec.columns[0].is_empty() && rec.columns[2].is_empty());
    assert_eq!((rec.time.len(), rec.columns[1].len()), (rows.len(), rows.len()));
    // The first chunk is the whole run's first half to the bit; the second starts from the
    // chunk's end state, so it agrees to the integration's accuracy (the bound of
    // `joint_rate_and_excursion_probes_and_chunked_runs`).
    for (i, (t, row)) in rows.iter().enumerate() {
        assert_eq!(*t, rec.time[i]);
        assert_eq!(row[1], rec.columns[1][i]);
        for (c, (&a, column)) in row.iter().zip(&whole.columns).enumerate() {
            let b = column[i];
            if *t < 0.5 {
                assert_eq!(a, b, "column {c} at {t} s");
            } else {
                let peak = column.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                assert!((a - b).abs() < 1e-9 * peak, "column {c} at {t} s: {a} vs {b}");
            }
        }
    }
}

/// The joint-rate and largest-excursion probes read the state as their definitions say, and a
/// run continued in chunks into one recorder records the same sample times as one run, with
/// values equal to integration accuracy. References: `q̇_pivot = u2 − u1` for absolute angular
/// velocities (eq. 1 of the design doc's speed choice), `max_k≠spin |q_k|` written out here,
/// and the single run.
#[test]
fn joint_rate_and_excursion_probes_and_chunked_runs() {
    let p = CpvaParams::canonical().with_pendulums(2);
    let mech = p.mechanism(Some(excitation(&p, 500.0, 3.0))).unwrap();
    let spin = mech.joint_index("spin").unwrap();
    let probes = [
        Probe::resolve(&mech, ProbeKind::JointRate, "spin").unwrap(),
        Probe::resolve(&mech, ProbeKind::JointRate, "pivot_1").unwrap(),
        Probe::resolve(&mech, ProbeKind::LargestJointAngle, "spin").unwrap(),
        Probe::resolve(&mech, ProbeKind::BodyAccel, "rotor").unwrap(),
    ];
    assert_eq!(probes[2], Probe::LargestJointAngle(spin));
    let mut kane = Kane::new(&mech).unwrap();
    let w = omega();
    let x0 = [0.0, 0.2, -0.3, w, w + 1.5, w - 2.0];
    let opts = tight();
    let (one, out) = run(&mut kane, &x0, 0.0, 2.0, &opts, &probes);
    assert!(out.error.is_none());
    assert_eq!(one.units(), ["rad/s", "rad/s", "rad", "rad/s²"]);
    assert_eq!(one.names()[2], "max_abs_q_except_spin");
    // At t = 0, straight from x0.
    assert_eq!(one.columns[0][0], w);
    assert_eq!(one.columns[1][0], 1.5);
    assert_eq!(one.columns[2][0], 0.3);

    // The same 2 s as four chunks of 0.5 s into one recorder.
    let mut rec = Recorder::new(&mech, &probes).unwrap();
    let mut x = x0.to_vec();
    let mut total = Outcome::default();
    for k in 0..4 {
        let t0 = 0.5 * k as f64;
        let chunk = simulate(&mut kane, &x, t0, t0 + 0.5, &opts, &mut rec, &mut |_| {});
        total.absorb(&chunk);
        x = chunk.x_end.expect("chunk completes");
    }
    assert!(total.error.is_none());
    assert_abs_diff_eq!(total.t_end, 2.0, epsilon = 1e-12);
    assert_eq!(rec.time.len(), one.time.len(), "boundary samples are recorded once");
    let dt = rec.time.iter().zip(&one.time).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(dt < 1e-12, "sample times differ by {dt:e} s");
    // Both runs hold rtol = atol = 1e-12 per step and differ only in where the steps fall after
    // each chunk boundary; over 2 s the accumulated difference was measured at ≤ 2e-11 of each
    // signal's peak. Bound 1e-9: 50× that, yet far below any physical change of the response.
    for (c, name) in [(0, "spin rate"), (1, "pivot_1 rate"), (2, "excursion"), (3, "rotor accel")] {
        let peak = one.columns[c].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = rec.columns[c].iter().zip(&one.columns[c]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        println!("{name}: chunked vs one run {:.1e} of peak {peak:.3}", worst / peak);
        assert!(worst < 1e-9 * peak, "{name}: {worst:e}");
    }
    // The excursion column is the largest |pendulum angle| at every sample.
    let pendula: Vec<Probe> =
        ["pivot_1", "pivot_2"].iter().map(|j| Probe::resolve(&mech, ProbeKind::JointAngle, j).unwrap()).collect();
    let (angles, _) = run(&mut kane, &x0, 0.0, 2.0, &opts, &pendula);
    for i in 0..one.time.len() {
        let expect = angles.columns[0][i].abs().max(angles.columns[1][i].abs());
        assert_eq!(one.columns[2][i], expect);
    }
}
