//! Nonlinear joint couplings (issue 15, item 2): staged springs, regularised Coulomb friction and
//! compliant end stops, checked against closed forms written here (the linear spring, the
//! Coulomb loop's 4 T_f A, a spring-dashpot contact's restitution), the joint-torque route of
//! their generalized forces, the linear model's local stiffness, and harmonic balance against
//! steady time integration.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::hbm::{Hbm, HbmOptions, HbmSolution};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::linear::{Damping, LinearModel};
use kanedyn::model::coupling::{Couplings, EndStops, Friction, Stage, StageSpring};
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::model::speeds::Speeds;
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use std::f64::consts::PI;
use std::path::Path;

fn load(text: &str) -> Mechanism {
    let src = Source::from_text("test.ron", text);
    Mechanism::from_source(&src, &ReadPolicy::within(Path::new(""))).unwrap_or_else(|e| panic!("{e}"))
}

fn example(file: &str) -> Mechanism {
    Mechanism::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file)).unwrap_or_else(|e| panic!("{e}"))
}

/// A small seeded stream in [−1, 1) (no dependence on a crate's value stability).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// A rotor, an arm on a revolute joint, a slider on a prismatic joint and an absorber on a path
/// joint, each joint with `coupling` spliced in (`SPRING` is replaced per joint by the text).
fn tree(speeds: &str, coupling: &dyn Fn(f64) -> String) -> Mechanism {
    load(&format!(
        r#"Mechanism(
    name: "tree",
    speeds: {speeds},
    bodies: [
        Body(name: "rotor", mass: 10.0, inertia: 1.0),
        Body(name: "arm", mass: 1.0, com: (0.1, 0.02), inertia: 0.01),
        Body(name: "slider", mass: 0.5, inertia: 0.002),
        Body(name: "absorber", mass: 0.3, inertia: 1e-4),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor", damper: 0.1),
        Joint(name: "arc", parent: "rotor", child: "arm", at: (0.2, 0.0), {}),
        Joint(name: "slide", kind: Prismatic(axis: (0.6, 0.8)), parent: "arm", child: "slider", at: (0.1, 0.0), {}),
        Joint(name: "path", kind: Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11), mount: 0.3),
              parent: "rotor", child: "absorber", {}),
    ],
)"#,
        coupling(1.0),
        coupling(30.0),
        coupling(500.0)
    ))
}

/// F at seeded random states of both mechanisms; the largest difference relative to the
/// largest |F| seen.
fn max_forcing_difference(a: &Mechanism, b: &Mechanism, spread: &[f64]) -> f64 {
    let (mut ka, mut kb) = (Kane::new(a).unwrap(), Kane::new(b).unwrap());
    let mut rng = Lcg(7);
    let (mut worst, mut scale) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let q: Vec<f64> = spread.iter().map(|s| s * rng.next()).collect();
        let u: Vec<f64> = (0..q.len()).map(|_| 5.0 * rng.next()).collect();
        let fa = ka.forcing(0.3, &q, &u).clone();
        let fb = kb.forcing(0.3, &q, &u).clone();
        worst = worst.max((fa - &fb).amax());
        scale = scale.max(fb.amax());
    }
    worst / scale
}

#[test]
fn equal_stages_equal_the_linear_spring() {
    // Stiffness k per joint (N·m/rad or N/m), free position 0.05 of the coordinate's scale; the
    // stage tables break at several places on both sides, with the same k everywhere.
    let linear = |k: f64| format!("spring: (stiffness: {k}, free_angle: 0.004)");
    let staged = |k: f64| {
        format!(
            "stages: (free_angle: 0.004, drive: [(from: 0.0, stiffness: {k}), (from: 0.003, stiffness: {k}), \
             (from: 0.2, stiffness: {k})], coast: [(from: 0.0, stiffness: {k}), (from: 0.01, stiffness: {k})])"
        )
    };
    // Angles over ±1 rad cross every breakpoint; the path's arc length stays inside its travel.
    let spread = [3.0, 1.0, 0.3, 0.012];
    for speeds in ["JointRates", "AbsoluteAngularVelocities"] {
        let d = max_forcing_difference(&tree(speeds, &staged), &tree(speeds, &linear), &spread);
        println!("{speeds}: equal stages vs linear spring, max |ΔF|/max|F| = {d:.2e}");
        // The stage sums add the same k·(x − from) pieces the linear spring multiplies in one
        // go: only rounding of a few terms separates them.
        assert!(d <= 1e-12, "{speeds}: {d:e}");
    }
}

/// The closed-form laws, written here independently of the module: the staged spring as the
/// integral of its stiffness table, Coulomb with tanh, and the stop contact.
fn hand_torque(q: f64, qd: f64) -> f64 {
    // drive (q < 0.01): k 100 to 0.1, then 400; coast (q > 0.01): k 50 to 0.05, 200 to 0.2, then 0.
    let d = q - 0.01;
    let spring = if d < 0.0 {
        let x = -d;
        100.0 * x.min(0.1) + 400.0 * (x - 0.1).max(0.0)
    } else {
        -(50.0 * d.min(0.05) + 200.0 * (d.min(0.2) - 0.05).max(0.0))
    };
    let friction = -3.0 * (qd / 0.5).tanh();
    let stop = if q > 0.3 {
        -(1e4 * (q - 0.3) + 20.0 * qd).max(0.0)
    } else if q < -0.4 {
        (1e4 * (-0.4 - q) - 20.0 * qd).max(0.0)
    } else {
        0.0
    };
    spring + friction + stop
}

fn hand_couplings() -> Couplings {
    let st = |from, stiffness| Stage { from, stiffness };
    Couplings {
        stages: Some(StageSpring {
            free_angle: 0.01,
            drive: vec![st(0.0, 100.0), st(0.1, 400.0)],
            coast: Some(vec![st(0.0, 50.0), st(0.05, 200.0), st(0.2, 0.0)]),
        }),
        friction: Some(Friction { torque: 3.0, smoothing: 0.5 }),
        stops: Some(EndStops { lower: -0.4, upper: 0.3, stiffness: 1e4, damping: 20.0 }),
    }
}

#[test]
fn coupling_forces_take_the_joint_torque_route() {
    // Two-body chain with absolute angular velocities: τ of the arc joint must enter F as +τ in
    // the arm's row and −τ in the rotor's (q̇_arc = u_arm − u_rotor), i.e. Bᵀ e_arc τ.
    let text = |c: &str| {
        format!(
            r#"Mechanism(name: "chain", speeds: AbsoluteAngularVelocities,
    bodies: [Body(name: "rotor", mass: 10.0, inertia: 1.0), Body(name: "arm", mass: 1.0, com: (0.1, 0.0), inertia: 0.01)],
    joints: [Joint(name: "spin", parent: "ground", child: "rotor"),
             Joint(name: "arc", parent: "rotor", child: "arm", at: (0.2, 0.0) {c})])"#
        )
    };
    let mut with = load(&text(""));
    with.joints[1].couplings = hand_couplings();
    let without = load(&text(""));
    let (mut kw, mut ko) = (Kane::new(&with).unwrap(), Kane::new(&without).unwrap());
    let mut rng = Lcg(11);
    let mut worst = 0.0f64;
    for i in 0..400 {
        // Sweep the arc angle across every breakpoint and both stops.
        let qa = -0.5 + 0.9 * i as f64 / 399.0;
        let q = [2.0 * rng.next(), qa];
        let u = [3.0 * rng.next(), 3.0 * rng.next()];
        let tau = hand_torque(qa, u[1] - u[0]);
        let d = kw.forcing(0.0, &q, &u).clone() - ko.forcing(0.0, &q, &u);
        worst = worst.max((d[1] - tau).abs().max((d[0] + tau).abs()) / tau.abs().max(1.0));
        // The same through the engine's reference (textbook) route.
        let (_, fr) = kanedyn::kane::reference::mass_matrix_and_forcing(&with, &[], 0.0, &q, &u);
        worst = worst.max((fr - kw.forcing(0.0, &q, &u)).amax() / tau.abs().max(1.0));
    }
    println!("coupling force route: worst relative error {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
}

/// One mass (kg) or inertia on a joint to ground with the given couplings text.
fn single(kind: &str, mass: f64, coupling: &str) -> Mechanism {
    load(&format!(
        r#"Mechanism(name: "single", bodies: [Body(name: "b", mass: {mass}, inertia: {mass})],
    joints: [Joint(name: "j", kind: {kind}, parent: "ground", child: "b", {coupling})])"#
    ))
}

#[test]
fn friction_loop_dissipates_four_tf_a() {
    // Slow harmonic motion q = A sin ωt imposed on a friction joint; the loop integral
    // W = −∮ F dq = −∫ F q̇ dt over one period from the engine's forcing.
    let (tf, amp, w) = (7.5, 0.2, 3.0);
    let mut last_err = f64::INFINITY;
    for ratio in [0.1, 0.03, 0.01, 0.003] {
        let eps = ratio * amp * w;
        let mech = single("Revolute", 0.5, &format!("friction: (torque: {tf}, smoothing: {eps})"));
        let mut kane = Kane::new(&mech).unwrap();
        // Trapezoid rule over a period: spectrally accurate for a smooth periodic integrand once
        // the samples resolve the reversal band (width ε/(Aω²) in time): 2·10⁵ samples, 1/ratio
        // ≤ 333 of them across it at the smallest ε.
        let n = 200_000;
        let h = 2.0 * PI / w / n as f64;
        let mut work = 0.0;
        for k in 0..n {
            let t = k as f64 * h;
            let (q, qd) = (amp * (w * t).sin(), amp * w * (w * t).cos());
            work -= kane.forcing(t, &[q], &[qd])[0] * qd * h;
        }
        let coulomb = 4.0 * tf * amp;
        let err = (work / coulomb - 1.0).abs();
        // The smoothed reversals lose π²ε²/(24 A²ω²) of it (module doc of `coupling`).
        let predicted = PI * PI * ratio * ratio / 24.0;
        println!(
            "ε/(Aω) = {ratio}: W = {work:.6} J vs 4 T_f A = {coulomb:.6} J, deficit {err:.3e} (predicted {predicted:.3e})"
        );
        assert!(err < last_err, "the loop converges to Coulomb's as ε → 0");
        assert!(abs_diff_eq!(err / predicted, 1.0, epsilon = 0.02), "deficit {err:e} vs {predicted:e}");
        last_err = err;
    }
    // The acceptance bound: within 1 % of 4 T_f A once ε is small (here 0.3 % of Aω).
    assert!(last_err <= 1e-2);
}

/// The restitution of a spring-dashpot contact whose damping may not pull (docs/design/model.md):
/// contact ends when k p + c ṗ = 0, at ω_d t = π − 2 arcsin ζ, with ṗ = −v₀ e^{−ζ ω_n t}.
fn restitution(zeta: f64) -> f64 {
    (-zeta * (PI - 2.0 * zeta.asin()) / (1.0 - zeta * zeta).sqrt()).exp()
}

#[test]
fn end_stop_rebound_matches_the_contact_closed_form() {
    let (m, k, v0): (f64, f64, f64) = (2.0, 1.0e4, 1.5);
    for zeta in [0.02, 0.1, 0.3, 0.6] {
        let c = 2.0 * zeta * (k * m).sqrt();
        let mech = single(
            "Prismatic(axis: (1.0, 0.0))",
            m,
            &format!("stops: (lower: -1.0, upper: 0.0, stiffness: {k}, damping: {c})"),
        );
        let mut kane = Kane::new(&mech).unwrap();
        // From 0.05 m before the upper stop at v₀; the contact lasts about π/ω_n = 0.044 s and
        // the mass is back at the start, moving away, well before 0.3 s.
        let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, sample_rate_hz: None, ..IntegrateOptions::default() };
        let run = integrate(|t, x, xd| kane.rhs(t, x, xd), &[-0.05, v0], 0.0, 0.3, &opts, |_| {}).unwrap();
        let e = -run.x_end[1] / v0;
        let expect = restitution(zeta);
        println!("ζ = {zeta}: e = {e:.7} vs closed form {expect:.7}; {}", run.stats);
        assert!(abs_diff_eq!(e, expect, epsilon = 1e-3), "ζ = {zeta}: e = {e} vs {expect}");
        // Plain linear contact (damping allowed to pull) would give exp(−ζπ/√(1−ζ²)): distinct.
        if zeta >= 0.1 {
            let linear = (-zeta * PI / (1.0 - zeta * zeta).sqrt()).exp();
            assert!((e - linear).abs() > 1e-2, "ζ = {zeta}: the stop must not pull");
        }
    }
}

#[test]
fn linear_model_sees_the_local_stage_stiffness_and_the_viscous_friction_limit() {
    // The DMF example: the drag c Ω winds the arc spring to the drive side; at 1500 rpm the
    // mean torque 36.1 N·m sits in the first stage (300 N·m/rad, breakpoint at 0.45 rad ↔ 135
    // N·m); at 6000 rpm (144.5 N·m) in the second (1800 N·m/rad).
    let mech = example("examples/dmf.ron");
    let arc = mech.coordinate_index("arc").unwrap();
    for (rpm, k_expect, q_expect) in [(1500.0, 300.0, -0.23 * 1500.0 * PI / 30.0 / 300.0), (6000.0, 1800.0, f64::NAN)] {
        let omega = rpm * PI / 30.0;
        let lin = LinearModel::new(&mech, "spin", omega, None).unwrap();
        let second = lin.second_order(Damping::Damped);
        println!("{rpm} rpm: K[arc][arc] = {}, C[arc][arc] = {}", second.k[(arc, arc)], second.c[(arc, arc)]);
        assert_abs_diff_eq!(second.k[(arc, arc)] / k_expect, 1.0, epsilon = 1e-9);
        // Friction at zero relative rate: T_f/ε = 6/0.2 = 30, plus the damper 0.3 N·m·s/rad and
        // the drag 0.23 N·m·s/rad on the secondary, whose speed is u_spin + q̇_arc.
        assert_abs_diff_eq!(second.c[(arc, arc)] / 30.53, 1.0, epsilon = 1e-9);
        if q_expect.is_finite() {
            assert_abs_diff_eq!(lin.op.q[arc] / q_expect, 1.0, epsilon = 1e-9);
        }
    }
}

/// Amplitudes of harmonics 1..=hmax of coordinate `k` by DFT over `periods` whole periods of a
/// DOP853 run from the HBM state, after `settle` periods.
fn time_harmonics(mech: &Mechanism, hbm: &Hbm, sol: &HbmSolution, k: usize, hmax: usize) -> (Vec<f64>, f64) {
    let (settle, periods, per) = (60usize, 8usize, 256usize);
    let mut kane = Kane::new(mech).unwrap();
    let exc = Excitation {
        mean: sol.mean_torque,
        rpm: sol.omega * 30.0 / PI,
        order: Order::Fixed(sol.order),
        harmonics: mech.loads.joint_torques[0].excitation.harmonics.clone(),
        ramp_s: 0.0,
    };
    kane.set_joint_torque(0, exc);
    let period = 2.0 * PI / sol.base_frequency;
    let x0 = hbm.state_at(sol, 0.0);
    let fs = per as f64 / period;
    let opts = IntegrateOptions { rtol: 1e-11, atol: 1e-11, sample_rate_hz: Some(fs), ..IntegrateOptions::default() };
    let mut samples = Vec::with_capacity(periods * per);
    let start = settle * per;
    let t1 = (settle + periods) as f64 * period;
    let run = integrate(
        |t, x, xd| kane.rhs(t, x, xd),
        &x0,
        0.0,
        t1,
        &opts,
        |s| {
            if s.k >= start && s.k < start + periods * per {
                samples.push(s.x[k]);
            }
        },
    )
    .unwrap();
    assert_eq!(samples.len(), periods * per);
    let n = samples.len() as f64;
    let amp = (1..=hmax)
        .map(|h| {
            let m = (h * periods) as f64;
            let (mut c, mut s) = (0.0, 0.0);
            for (j, x) in samples.iter().enumerate() {
                let a = 2.0 * PI * m * j as f64 / n;
                c += x * a.cos();
                s += x * a.sin();
            }
            2.0 * c.hypot(s) / n
        })
        .collect();
    let (lo, hi) = samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
    println!("time run: {}", run.stats);
    (amp, hi - lo)
}

/// The DMF example with its arc coupling replaced, solved by HBM at `rpm` and order 2 with
/// `harmonics`, and compared with a steady time run on the arc coordinate's harmonics 1..3 and
/// its peak-to-peak.
fn hbm_vs_time(couplings: Couplings, damper: f64, torque: f64, rpm: f64, harmonics: usize) -> (f64, f64) {
    let mut mech = example("examples/dmf.ron");
    let arc = mech.coordinate_index("arc").unwrap();
    mech.joints[1].couplings = couplings;
    mech.joints[1].damper = damper;
    mech.loads.joint_torques[0].excitation.harmonics[0].amplitude = torque;
    let kane = Kane::new(&mech).unwrap();
    let omega = rpm * PI / 30.0;
    let h = [Harmonic { multiple: 1.0, amplitude: torque, phase: 0.0 }];
    let opts = HbmOptions { harmonics, stability_samples: 0, ..HbmOptions::default() };
    let mut hbm = Hbm::new(&kane, 0, omega, &h, opts).unwrap();
    let sol = hbm.solve(2.0, None).unwrap();
    let (amp, p2p) = time_harmonics(&mech, &hbm, &sol, arc, 3);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for j in 0..4096 {
        let t = 2.0 * PI / sol.base_frequency * j as f64 / 4096.0;
        let q = sol.coordinates_at(t).0[arc];
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let p2p_hbm = hi - lo;
    let a1 = sol.amplitude(arc, 1);
    let mut worst = (p2p_hbm / p2p - 1.0).abs();
    for (h, a) in amp.iter().enumerate() {
        let ah = sol.amplitude(arc, h + 1);
        println!("  harmonic {}: HBM {ah:.6e} rad, time {a:.6e} rad", h + 1);
        // Relative to the main harmonic (a small harmonic is compared on the main one's scale).
        worst = worst.max((ah - a).abs() / a1);
    }
    println!(
        "  peak-to-peak HBM {p2p_hbm:.6} rad, time {p2p:.6} rad; mean arc {:.4} rad; coupling tail {:.2e}; worst {worst:.2e}",
        sol.coefficient(arc, 0).0,
        sol.coupling_tail
    );
    (worst, sol.coupling_tail)
}

#[test]
fn harmonic_balance_matches_time_integration_on_a_stage_spring() {
    // 1000 rpm, order 2 (105 rad/s): between the first-stage mode (78 rad/s) and the second
    // (191 rad/s); 400 N·m swings the arc about its mean windup (−0.08 rad) through the drive
    // breakpoint at −0.1 rad.
    let st = |from, stiffness| Stage { from, stiffness };
    let stages = StageSpring {
        free_angle: 0.0,
        drive: vec![st(0.0, 300.0), st(0.1, 1800.0)],
        coast: Some(vec![st(0.0, 300.0), st(0.06, 1200.0)]),
    };
    let c = Couplings { stages: Some(stages), ..Couplings::default() };
    let (worst, tail) = hbm_vs_time(c, 3.0, 1000.0, 2000.0, 24);
    assert!(worst <= 1e-2, "stage spring: HBM vs time {worst:e}");
    assert!(tail < HbmOptions::default().coupling_tol);
}

#[test]
fn harmonic_balance_matches_time_integration_with_friction() {
    // Linear arc spring with friction 6 N·m smoothed over 2 rad/s; the relative rate swings
    // over about ±10 rad/s, so the friction torque is nearly rectangular.
    let c = Couplings {
        stages: Some(StageSpring { free_angle: 0.0, drive: vec![Stage { from: 0.0, stiffness: 300.0 }], coast: None }),
        friction: Some(Friction { torque: 6.0, smoothing: 2.0 }),
        stops: None,
    };
    let (worst, _) = hbm_vs_time(c.clone(), 0.3, 300.0, 1000.0, 40);
    assert!(worst <= 1e-2, "friction: HBM vs time {worst:e}");
    // With too few harmonics the indicator says so.
    let mut mech = example("examples/dmf.ron");
    mech.joints[1].couplings = c;
    let kane = Kane::new(&mech).unwrap();
    let h = [Harmonic { multiple: 1.0, amplitude: 300.0, phase: 0.0 }];
    let opts = HbmOptions { harmonics: 3, stability_samples: 0, ..HbmOptions::default() };
    let sol = Hbm::new(&kane, 0, 1000.0 * PI / 30.0, &h, opts).unwrap().solve(2.0, None).unwrap();
    println!("H = 3: coupling tail {:.3}", sol.coupling_tail);
    assert!(sol.coupling_tail > HbmOptions::default().coupling_tol && sol.needs_more_harmonics);
}

#[test]
fn the_dmf_example_loads_with_its_arc_spring() {
    let mech = example("examples/dmf.ron");
    let c = &mech.joints[mech.joint_index("arc").unwrap()].couplings;
    assert_eq!(c.stages.as_ref().map(|s| s.drive.len()), Some(2));
    assert_eq!(c.friction.map(|f| f.torque), Some(6.0));
    assert!(c.stops.is_some());
    assert_eq!(mech.speeds, Speeds::JointRates);
}

/// Writes `text` to a fresh file and returns the load error.
fn error_of(dir: &str, text: &str) -> String {
    let tmp = scratch(&format!("couplings-{dir}"));
    let p = tmp.path().join("m.ron");
    std::fs::write(&p, text).unwrap();
    match Mechanism::from_file(&p) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

const GOOD: &str = r#"Mechanism(
    name: "m",
    bodies: [
        Body(name: "primary", mass: 10.0, inertia: 0.14),
        Body(name: "secondary", mass: 8.0, inertia: 0.075),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "primary"),
        Joint(name: "arc", parent: "primary", child: "secondary",
            stages: (drive: [(from: 0.0, stiffness: 300.0), (from: 0.45, stiffness: 1800.0)]),
            friction: (torque: 6.0, smoothing: 0.2),
            stops: (lower: -0.8, upper: 0.5, stiffness: 5.0e4, damping: 20.0)),
    ],
)
"#;

#[test]
fn bad_couplings_are_located() {
    let tmp = scratch("couplings-good");
    let p = tmp.path().join("good.ron");
    std::fs::write(&p, GOOD).unwrap();
    Mechanism::from_file(&p).unwrap();
    for (name, from, to, parts) in [
        (
            "not-increasing",
            "(from: 0.45, stiffness: 1800.0)",
            "(from: 0.0, stiffness: 1800.0)",
            &["m.ron:10:", "joints[1].stages.drive[1].from", "must increase"][..],
        ),
        (
            "first-stage",
            "[(from: 0.0, stiffness: 300.0)",
            "[(from: 0.1, stiffness: 300.0)",
            &["stages.drive[0].from"][..],
        ),
        (
            "negative-stiffness",
            "stiffness: 300.0",
            "stiffness: -300.0",
            &["m.ron:10:", "stages.drive[0].stiffness"][..],
        ),
        ("nan-stiffness", "stiffness: 1800.0", "stiffness: NaN", &["stages.drive[1].stiffness"][..]),
        ("negative-friction", "torque: 6.0", "torque: -6.0", &["m.ron:11:", "joints[1].friction.torque"][..]),
        ("zero-smoothing", "smoothing: 0.2", "smoothing: 0.0", &["m.ron:11:", "friction.smoothing", "ε"][..]),
        (
            "inverted-stops",
            "lower: -0.8, upper: 0.5",
            "lower: 0.5, upper: -0.8",
            &["m.ron:12:", "stops.upper", "inverted"][..],
        ),
        ("stop-stiffness", "stiffness: 5.0e4", "stiffness: 0.0", &["joints[1].stops.stiffness"][..]),
        ("stop-damping", "damping: 20.0", "damping: -1.0", &["joints[1].stops.damping"][..]),
        ("nan-limit", "lower: -0.8", "lower: NaN", &["joints[1].stops.lower"][..]),
        (
            "empty-table",
            "drive: [(from: 0.0, stiffness: 300.0), (from: 0.45, stiffness: 1800.0)]",
            "drive: []",
            &["stages.drive", "at least one stage"][..],
        ),
        ("fixed", r#"child: "secondary","#, r#"child: "secondary", kind: Fixed,"#, &["joints[1].stages", "Fixed"][..]),
    ] {
        let msg = error_of(name, &GOOD.replace(from, to));
        for p in parts {
            assert!(msg.contains(p), "{name}: error message {msg:?} should mention {p:?}");
        }
    }
}

/// Steps of a DOP853 run of the DMF at 2000 rpm, order 2, 1000 N·m over 100 periods from rest
/// in the drive windup, with the arc law `couplings` (default tolerances, 10⁻⁹).
fn steps_of(couplings: Couplings, tol: f64) -> (kanedyn::time::integrate::IntegrateStats, usize) {
    let mut mech = example("examples/dmf.ron");
    mech.joints[1].couplings = couplings;
    mech.joints[1].damper = 3.0;
    let omega = 2000.0 * PI / 30.0;
    let exc = Excitation {
        mean: 0.23 * omega,
        rpm: 2000.0,
        order: Order::Fixed(2.0),
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: 1000.0, phase: 0.0 }],
        ramp_s: 0.0,
    };
    let mut kane = Kane::new(&mech).unwrap();
    kane.set_joint_torque(0, exc);
    let t1 = 100.0 * 2.0 * PI / (2.0 * omega);
    // Samples at 100 per period, to count the breakpoint crossings.
    let opts = IntegrateOptions {
        sample_rate_hz: Some(100.0 / t1 * 100.0),
        rtol: tol,
        atol: tol,
        ..IntegrateOptions::default()
    };
    let x0 = [0.0, -0.1, omega, 0.0];
    let (mut crossings, mut below) = (0, true);
    let run = integrate(
        |t, x, xd| kane.rhs(t, x, xd),
        &x0,
        0.0,
        t1,
        &opts,
        |s| {
            let b = s.x[1] < -0.1;
            crossings += usize::from(b != below);
            below = b;
        },
    );
    (run.unwrap().stats, crossings)
}

#[test]
fn stage_kinks_keep_the_step_count_bounded() {
    let st = |from, stiffness| Stage { from, stiffness };
    let spring = |drive: Vec<Stage>| Couplings {
        stages: Some(StageSpring { free_angle: 0.0, drive, coast: None }),
        ..Couplings::default()
    };
    let attempts = |s: kanedyn::time::integrate::IntegrateStats| (s.accepted + s.rejected) as f64;
    for tol in [1e-6, 1e-9, 1e-12] {
        let (smooth, _) = steps_of(spring(vec![st(0.0, 300.0)]), tol);
        let (equal, _) = steps_of(spring(vec![st(0.0, 300.0), st(0.1, 300.0)]), tol);
        let (kinked, crossings) = steps_of(spring(vec![st(0.0, 300.0), st(0.1, 1800.0)]), tol);
        let (stiff, _) = steps_of(spring(vec![st(0.0, 1800.0)]), tol);
        let extra = (attempts(kinked) - attempts(smooth).max(attempts(stiff))) / crossings as f64;
        println!(
            "tol {tol:e}: linear 300: {smooth}\n  equal stages: {equal}\n  two-stage 300/1800 ({crossings} crossings): \
             {kinked}\n  linear 1800: {stiff}\n  extra step attempts per crossing: {extra:.1}"
        );
        assert_eq!(smooth, equal, "equal stages are the linear spring, step for step");
        // Each crossing costs a bounded number of extra attempts (the controller shrinks the
        // step over the kink and grows it back), not a collapse, which would cost hundreds.
        assert!(crossings >= 150 && extra < 40.0, "{extra} extra attempts per crossing");
    }
}

#[test]
fn a_study_warns_when_the_coupling_harmonics_have_not_converged() {
    // The DMF with friction near Coulomb's (ε = 0.2 rad/s against relative rates of several
    // rad/s), balanced with 4 harmonics only: the summary must say the coupling force has not
    // converged.
    let tmp = scratch("couplings-study");
    let dir = tmp.path();
    // The arc spring comes from the shipped catalog.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    std::fs::copy(root.join("dmf.ron"), dir.join("dmf.ron")).unwrap();
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(
    name: "dmf",
    mechanism: "dmf.ron",
    response_body: "secondary",
    analyses: [
        HarmonicBalance(name: "branch", rpm: 1000.0, order_min: 1.9, order_max: 2.1, amplitudes: [300.0], harmonics: 4),
    ],
)"#,
    )
    .unwrap();
    let study = kanedyn::study::Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let opts = kanedyn::study::RunOptions { out: Some(dir.join("out")), progress: false };
    let report = kanedyn::study::run(&study, &opts).unwrap();
    println!("{}", report.summary);
    assert!(
        report.summary.contains("harmonic content has not converged at H = 4"),
        "the summary should warn:\n{}",
        report.summary
    );
}

#[test]
fn the_closed_form_residual_jacobian_includes_the_couplings() {
    // Absolute angular velocities on a revolute chain: the engine's exact ∂r/∂q, ∂r/∂u of
    // r = M u̇ − F against central differences of the same residual, at states away from the
    // kinks (the arc angle inside a stage, in contact with a stop or not).
    let mut mech = load(
        r#"Mechanism(name: "chain", speeds: AbsoluteAngularVelocities,
    bodies: [Body(name: "rotor", mass: 10.0, inertia: 1.0), Body(name: "arm", mass: 1.0, com: (0.1, 0.0), inertia: 0.01)],
    joints: [Joint(name: "spin", parent: "ground", child: "rotor"),
             Joint(name: "arc", parent: "rotor", child: "arm", at: (0.2, 0.0))])"#,
    );
    mech.joints[1].couplings = hand_couplings();
    let mut kane = Kane::new(&mech).unwrap();
    assert!(kane.has_residual_jacobian());
    let n = 2;
    let residual = |kane: &mut Kane, q: &[f64], u: &[f64], ud: &[f64]| {
        let (m, f) = kane.mass_matrix_and_forcing(0.0, q, u);
        (m * nalgebra::DVector::from_column_slice(ud) - f).as_slice().to_vec()
    };
    let mut worst = 0.0f64;
    for qa in [-0.45, -0.2, 0.0, 0.03, 0.1, 0.35] {
        let (q, u, ud) = ([0.7, qa], [1.3, 0.4], [0.2, -0.5]);
        let (mut r, mut dq, mut du, mut m) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
        assert!(kane.residual_jacobian(0.0, &q, &u, &ud, &mut r, &mut dq, &mut du, &mut m));
        let h = 1e-6;
        for k in 0..n {
            let (mut qp, mut qm, mut up, mut um) = (q, q, u, u);
            qp[k] += h;
            qm[k] -= h;
            up[k] += h;
            um[k] -= h;
            let (rqp, rqm) = (residual(&mut kane, &qp, &u, &ud), residual(&mut kane, &qm, &u, &ud));
            let (rup, rum) = (residual(&mut kane, &q, &up, &ud), residual(&mut kane, &q, &um, &ud));
            for i in 0..n {
                let scale = 1.0 + dq[i * n + k].abs().max(du[i * n + k].abs());
                worst = worst.max(((rqp[i] - rqm[i]) / (2.0 * h) - dq[i * n + k]).abs() / scale);
                worst = worst.max(((rup[i] - rum[i]) / (2.0 * h) - du[i * n + k]).abs() / scale);
            }
        }
    }
    println!("residual Jacobian with couplings vs differences: {worst:.2e}");
    // Central differences of step 1e-6 on terms of size up to 1e4 N·m/rad: truncation about
    // 1e-12, rounding about 1e-16·1e4/1e-6 = 1e-6 relative.
    assert!(worst < 1e-5, "{worst:e}");
}
