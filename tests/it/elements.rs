//! Per-element results of a multi-order study on a truck-type driveline: an engine flywheel, an
//! arc spring with damping to the secondary flywheel, and two absorber groups on it tuned near
//! orders 3 and 6. Every element is reported on its own, and two independent routes agree: the
//! time-domain steady state (DOP853 run, order tracking over the last window) and harmonic balance
//! (Fourier series); the spring torque is the complex stiffness times the twist.

use crate::support::scratch;
use kanedyn::hbm::{Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::study::{RunOptions, Study, run};
use kanedyn::time::integrate::{IntegrateOptions, integrate};

const K: f64 = 2.0e3; // arc spring, N·m/rad
const C: f64 = 1.0; // its damping, N·m·s/rad

const MECHANISM: &str = r#"Mechanism(
    name: "truck",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "primary", mass: 20.0, inertia: 0.8),
        Body(name: "secondary", mass: 15.0, inertia: 0.3),
        // Tuned slightly above their orders, as absorbers are: n_t ≈ 3.09 and 6.15.
        Body(name: "abs3", mass: 2.0, com: (0.0175, 0.0), inertia: 1e-5),
        Body(name: "abs6", mass: 2.0, com: (-0.002, 0.0), inertia: 1e-5),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "primary"),
        Joint(name: "arc_spring", parent: "primary", child: "secondary", spring: (stiffness: 2000.0, free_angle: 0.0), damper: 1.0),
        Joint(name: "pivot_3", parent: "secondary", child: "abs3", at: (0.17, 0.0), damper: 2e-4),
        Joint(name: "pivot_6", parent: "secondary", child: "abs6", at: (-0.17, 0.0), damper: 1e-4),
    ],
    loads: [GroundDamper(body: "secondary", c: 5e-3)],
)"#;

const STUDY: &str = r#"Study(
    name: "truck",
    mechanism: "m.ron",
    response_body: "secondary",
    analyses: [
        MultiOrder(name: "multi", order: 3.0, multiples: [1.0, 2.0],
            speeds: [(rpm: 1500.0, harmonics: [(multiple: 1.0, amplitude: 60.0), (multiple: 2.0, amplitude: 30.0, phase: 0.4)])],
            window_s: 2.0, steady_tol: 1e-6, min_time_s: 20.0, max_time_s: 200.0, hbm: true),
        HarmonicBalance(name: "branch", rpm: 1500.0, order_min: 2.8, order_max: 3.3, amplitudes: [60.0]),
    ],
)"#;

#[test]
fn every_element_is_reported_and_both_routes_agree() {
    let tmp = scratch("elements");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), MECHANISM).unwrap();
    std::fs::write(dir.join("s.ron"), STUDY).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let csv = std::fs::read_to_string(dir.join("out/truck/multi.csv")).unwrap();
    println!("{}", report.summary);

    let s = &report.multi[0].speeds[0];
    let td = s.response.as_ref().unwrap();
    let names: Vec<&str> = td.elements.iter().map(|e| e.joint.as_str()).collect();
    assert_eq!(names, ["arc_spring", "pivot_3", "pivot_6"], "every non-spin joint by default");
    for col in ["arc_spring_1x_rad", "pivot_3_1x_rad", "pivot_6_2x_rad", "arc_spring_torque_peak_Nm"] {
        assert!(csv.lines().next().unwrap().split(',').any(|h| h == col), "CSV column {col}");
    }
    let (hbm, d) = s.hbm_match().expect("a stable periodic state");
    println!("rotor: time domain vs harmonic balance {d:.1e}");

    // Both absorber groups move, each mostly at its own order.
    let group = |name: &str| td.elements.iter().find(|e| e.joint == name).unwrap();
    assert!(group("pivot_3").amplitude[0] > group("pivot_3").amplitude[1]);
    assert!(group("pivot_6").amplitude[1] > group("pivot_6").amplitude[0]);

    // Time domain against harmonic balance, element by element and order by order. The windows
    // hold whole periods (2 s at 75 and 150 Hz), so the 5-bin amplitudes are exact for a periodic
    // signal, and the runs settle to 1e-6 between windows; measured ≤ 1.1e-5; bound 1e-4.
    for (t, h) in td.elements.iter().zip(&hbm.elements) {
        assert_eq!(t.joint, h.joint);
        for k in 0..2 {
            let e = (t.amplitude[k] - h.amplitude[k]).abs() / h.amplitude[k];
            println!(
                "{} order {}n: time {:.6e} vs HBM {:.6e} ({e:.1e})",
                t.joint,
                3 * (k + 1),
                t.amplitude[k],
                h.amplitude[k]
            );
            assert!(e <= 1e-4, "{} order {}: {e:e}", t.joint, k + 1);
        }
        // The time-domain peak is refined between the samples (Hermite with q̇, error
        // ~(ωh)⁴/400 = 1e-4 of the 150 Hz share at 2 kHz); the series' is exact. Measured ≤ 1.2e-4
        // (a sample maximum was off by up to 3 %); bound 1e-3.
        let e = (t.peak - h.peak).abs() / h.peak;
        println!("{} peak: time {:.6e} vs HBM {:.6e} ({e:.1e})", t.joint, t.peak, h.peak);
        assert!(e <= 1e-3, "{} peak {e:e}", t.joint);
    }

    // The spring's torque is (k + i hω c) times its twist at each order, to rounding.
    let spring = hbm.elements.iter().find(|e| e.joint == "arc_spring").unwrap();
    let torque = spring.torque.as_ref().expect("the arc spring transmits a torque");
    let omega = 1500.0 * 2.0 * std::f64::consts::PI / 60.0;
    for (k, m) in [1.0, 2.0].iter().enumerate() {
        let w = m * 3.0 * omega;
        let expect = K.hypot(C * w) * spring.amplitude[k];
        let e = (torque.amplitude[k] - expect).abs() / expect;
        println!("arc spring torque at {m}·3: {:.9e} N·m ({e:.1e})", torque.amplitude[k]);
        assert!(e <= 1e-9);
    }
    let absorber = hbm.elements.iter().find(|e| e.joint == "pivot_6").unwrap();
    assert!(absorber.torque.is_some(), "its damper transmits a torque");

    // The branch's element columns at every point equal a harmonic balance solved here, apart
    // from the study, at that point's order (Newton to 1e-10 from its default start; the response
    // is single-valued at this torque): 1e-6 relative, as issue 13 asks; measured 7.8e-12.
    let mech = &study.mechanism;
    let kane = Kane::new(mech).unwrap();
    let harmonics = [Harmonic { multiple: 1.0, amplitude: 60.0, phase: 0.0 }];
    let mut hbm = Hbm::new(&kane, mech.joint_index("spin").unwrap(), omega, &harmonics, HbmOptions::default()).unwrap();
    let branch = &report.hbm[0];
    let mut worst = 0.0f64;
    for (i, &order) in branch.order.iter().enumerate().step_by(3) {
        let sol = hbm.solve(order, None).unwrap();
        for el in &branch.elements[i] {
            let k = mech.coordinate_index(&el.joint).unwrap();
            let h = sol.harmonic_of(1.0).unwrap();
            let reference = sol.amplitude(k, h);
            let e = (el.amplitude[0] - reference).abs() / reference;
            worst = worst.max(e);
            assert!(e <= 1e-6, "{} at n = {order}: {} vs {reference}", el.joint, el.amplitude[0]);
        }
    }
    println!("branch elements vs an independent solve: worst {worst:.1e}");

    // The periodic orbit by shooting, written below: the time run's and the harmonic balance's
    // element amplitudes must both equal its own, order by order. The time run settles to 1e-6
    // between whole-period windows: measured ≤ 1.1e-5 against the orbit; bound 1e-4, as issue 13
    // asks. The harmonic balance (H = 10) is exact to its truncation: measured ≤ 1.8e-8; bound
    // 1e-6.
    let spin = mech.joint_index("spin").unwrap();
    let mut kane = Kane::new(mech).unwrap();
    let harmonics = vec![
        Harmonic { multiple: 1.0, amplitude: 60.0, phase: 0.0 },
        Harmonic { multiple: 2.0, amplitude: 30.0, phase: 0.4 },
    ];
    // The study's default mean torque: the secondary's loss to ground at Ω.
    let mean = 5e-3 * omega;
    kane.set_joint_torque(spin, Excitation { mean, rpm: 1500.0, order: Order::Fixed(3.0), harmonics, ramp_s: 0.0 });
    let period = 2.0 * std::f64::consts::PI / (3.0 * omega);
    let x_end = td.sim.x_end.as_ref().expect("the time run completed");
    let orbit = periodic_orbit(&mut kane, x_end, td.sim.t_end, period, omega, mech.coordinate(spin).unwrap());
    let (mut worst_td, mut worst_hbm) = (0.0f64, 0.0f64);
    let (state, _) = s.hbm_match().expect("a stable periodic state");
    for (t, h) in td.elements.iter().zip(&state.elements) {
        let k = mech.coordinate_index(&t.joint).unwrap();
        let series: Vec<f64> = orbit.iter().map(|q| q[k]).collect();
        for m in 0..2 {
            let reference = harmonic_amplitude(&series, m + 1);
            let (e_td, e_hbm) =
                ((t.amplitude[m] - reference).abs() / reference, (h.amplitude[m] - reference).abs() / reference);
            println!("{} order {}n vs shooting {reference:.6e}: time run {e_td:.1e}, HBM {e_hbm:.1e}", t.joint, m + 1);
            worst_td = worst_td.max(e_td);
            worst_hbm = worst_hbm.max(e_hbm);
        }
    }
    assert!(worst_td <= 1e-4, "time run vs shooting {worst_td:e}");
    assert!(worst_hbm <= 1e-6, "harmonic balance vs shooting {worst_hbm:e}");
}

/// A periodic orbit of the driveline by shooting, written here apart from the library's harmonic
/// balance and the study's time runs: under `T(t) = c·Ω + Σ T_k sin(k·nΩt + α_k)` (period
/// P = 2π/(nΩ)) with the spin angle cyclic, the orbit satisfies `x(t0 + P) = x(t0) + ΩP·e_spin`.
/// Newton on every state but the spin angle (a gauge), the Jacobian by central differences of
/// one-period integrations (DOP853 at 1e-12), from the study's end state. Returns the orbit's
/// coordinates at N equally spaced instants of one period.
fn periodic_orbit(kane: &mut Kane, x_start: &[f64], t0: f64, period: f64, omega: f64, spin: usize) -> Vec<Vec<f64>> {
    const N: usize = 256;
    let opts = |fs: Option<f64>| IntegrateOptions {
        rtol: 1e-12,
        atol: 1e-12,
        sample_rate_hz: fs,
        ..IntegrateOptions::default()
    };
    let dim = x_start.len();
    let free: Vec<usize> = (0..dim).filter(|&i| i != spin).collect();
    let mut flow = |x: &[f64]| -> Vec<f64> {
        integrate(|t, x, dx| kane.rhs(t, x, dx), x, t0, t0 + period, &opts(None), |_| {}).unwrap().x_end
    };
    let residual = |x: &[f64], end: &[f64]| -> Vec<f64> {
        free.iter().map(|&i| end[i] - x[i] - if i == spin { omega * period } else { 0.0 }).collect()
    };
    let mut x = x_start.to_vec();
    for _ in 0..8 {
        let r = residual(&x, &flow(&x));
        let norm = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if norm < 1e-12 {
            break;
        }
        let m = free.len();
        let mut jac = nalgebra::DMatrix::zeros(m, m);
        for (c, &i) in free.iter().enumerate() {
            let h = 1e-6 * (1.0 + x[i].abs());
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[i] += h;
            xm[i] -= h;
            let (rp, rm) = (residual(&xp, &flow(&xp)), residual(&xm, &flow(&xm)));
            for row in 0..m {
                jac[(row, c)] = (rp[row] - rm[row]) / (2.0 * h);
            }
        }
        let dx = jac.lu().solve(&nalgebra::DVector::from_vec(r)).expect("a regular shooting Jacobian");
        for (c, &i) in free.iter().enumerate() {
            x[i] -= dx[c];
        }
    }
    let mut samples = Vec::with_capacity(N + 1);
    integrate(
        |t, x, dx| kane.rhs(t, x, dx),
        &x,
        t0,
        t0 + period,
        &opts(Some(N as f64 / period)),
        |s| samples.push(s.x[..dim / 2].to_vec()),
    )
    .unwrap();
    samples.truncate(N);
    samples
}

/// Amplitude of harmonic h of one period sampled at N equal steps (discrete Fourier transform).
fn harmonic_amplitude(v: &[f64], h: usize) -> f64 {
    let n = v.len() as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for (j, x) in v.iter().enumerate() {
        let a = 2.0 * std::f64::consts::PI * (h * j) as f64 / n;
        re += x * a.cos();
        im -= x * a.sin();
    }
    2.0 * re.hypot(im) / n
}
