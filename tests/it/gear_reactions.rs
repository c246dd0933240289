//! Reactions and mesh torques of geared mechanisms, driven joints as outputs and inputs, and the
//! study's loss torque through gears (issue 15, items 1 and 5), against independent routes: the
//! hand-reduced two- and three-shaft trains (closed forms of the accelerations and of each
//! shaft's Newton–Euler balance), Hooke's law on a compliant mesh, the energy balance of the
//! driven side of a time run, a steady time run against harmonic balance, the gear relation on
//! recorded driven-joint probes, and the hand-reduced loss torque.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::hbm::{Hbm, HbmOptions};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::kane::reactions::joint_reactions;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::Study;
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use kanedyn::time::probe::{Probe, ProbeKind, Recorder, simulate};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;
use std::path::Path;

fn load(text: &str) -> Mechanism {
    Mechanism::from_source(&Source::from_text("gears.ron", text), &ReadPolicy::within(Path::new("")))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Two shafts on ground, J₁ (`input`) and J₂ (`output`, 0.3 m away), joined by `gear`; `extra`
/// goes into the output joint (a damper, say).
fn pair(j1: f64, j2: f64, gear: &str, extra: &str) -> String {
    format!(
        r#"Mechanism(
    name: "pair",
    speeds: JointRates,
    bodies: [Body(name: "pinion", mass: 2.0, inertia: {j1:e}), Body(name: "wheel", mass: 5.0, inertia: {j2:e})],
    joints: [
        Joint(name: "input", parent: "ground", child: "pinion"),
        Joint(name: "output", parent: "ground", child: "wheel", at: (0.3, 0.0){extra}),
    ],
    gears: [{gear}],
)"#
    )
}

/// `ẋ` of `kane` at (t, x).
fn xdot(kane: &mut Kane, t: f64, x: &[f64]) -> Vec<f64> {
    let mut d = vec![0.0; x.len()];
    kane.rhs(t, x, &mut d).unwrap();
    d
}

/// A rigid pair with torques T₁ on the input and T₂ on the output and a damper c₂ on the output:
/// the reduced equation (J₁ + r²J₂) θ̈ = T₁ + r (T₂ − c₂ r θ̇) gives θ̈; the output shaft's own
/// balance J₂ θ̈₂ = T₂ − c₂ θ̇₂ + λ gives the mesh torque λ, and the input's J₁ θ̈ = T₁ − r λ.
/// Each revolute joint's Newton–Euler moment is then the shaft's J θ̈ (its torques plus the
/// mesh's). All are a few products of exact inputs: 1e-12 relative is rounding.
#[test]
fn rigid_pair_mesh_torque_is_the_hand_reduced_one() {
    let (j1, j2, r, c2) = (0.7, 2.3, -3.2, 0.15);
    let gear = format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e})");
    for (t1, t2, c) in [(3.0, 0.0, 0.0), (3.0, -1.25, c2)] {
        let mech = load(&pair(j1, j2, &gear, &format!(", damper: {c:e}")));
        let mut kane = Kane::new(&mech).unwrap();
        kane.set_joint_torque(0, Excitation::constant(t1));
        kane.set_joint_torque(1, Excitation::constant(t2));
        let mut rng = StdRng::seed_from_u64(15);
        for _ in 0..10 {
            let x = [rng.random_range(-5.0..5.0), rng.random_range(-50.0..50.0)];
            let d = xdot(&mut kane, 0.0, &x);
            let acc = (t1 + r * (t2 - c * r * x[1])) / (j1 + r * r * j2);
            let lambda = j2 * r * acc - t2 + c * r * x[1];
            let scale = t1.abs() + (r * t2).abs() + (c * r * r * x[1]).abs();
            assert!(abs_diff_eq!(d[1], acc, epsilon = 1e-12 * scale / j1), "θ̈ {} vs {acc}", d[1]);
            let mesh = kane.gear_torques(0.0, &x[..1], &x[1..], &d[1..]);
            assert_eq!(mesh.len(), 1);
            assert!(abs_diff_eq!(mesh[0], lambda, epsilon = 1e-12 * scale), "λ {} vs {lambda}", mesh[0]);
            if t2 == 0.0 && c == 0.0 {
                // The brief's closed form: λ = r J₂ T/(J₁ + r² J₂).
                let closed = r * j2 * t1 / (j1 + r * r * j2);
                assert!(abs_diff_eq!(mesh[0], closed, epsilon = 1e-12 * t1.abs()), "λ {} vs {closed}", mesh[0]);
            }
            // The reflected torque on the input, −r λ, closes the input shaft's balance.
            assert_abs_diff_eq!(j1 * acc, t1 - r * mesh[0], epsilon = 1e-12 * scale);
            let reactions = joint_reactions(&mech, &x[..1], &x[1..], &d[1..]);
            assert!(abs_diff_eq!(reactions[1].moment, j2 * r * acc, epsilon = 1e-12 * scale), "output moment");
            assert!(abs_diff_eq!(reactions[0].moment, j1 * acc, epsilon = 1e-12 * scale), "input moment");
            // The output moment is its own torques plus the mesh torque.
            assert_abs_diff_eq!(reactions[1].moment, t2 - c * r * x[1] + mesh[0], epsilon = 1e-12 * scale);
        }
    }
}

/// A chain a → b (r₁) → c (r₂) with a torque on a: θ̈_a = T/(J_a + r₁²J_b + r₁²r₂²J_c),
/// λ_c = J_c r₁r₂ θ̈_a (c's balance), λ_b = J_b r₁ θ̈_a + r₂ λ_c (b's balance with the reflection
/// −r₂λ_c of c's mesh). 1e-12 relative: rounding.
#[test]
fn a_gear_chain_passes_its_reflected_torques_back() {
    let (ja, jb, jc, r1, r2, t) = (0.9, 0.4, 1.7, -2.5, 0.6, 7.0);
    let mech = load(&format!(
        r#"Mechanism(
    name: "chain",
    speeds: JointRates,
    bodies: [Body(name: "a", mass: 1.0, inertia: {ja:e}), Body(name: "b", mass: 1.0, inertia: {jb:e}),
             Body(name: "c", mass: 1.0, inertia: {jc:e})],
    joints: [
        Joint(name: "ja", parent: "ground", child: "a"),
        Joint(name: "jb", parent: "ground", child: "b", at: (0.2, 0.0)),
        Joint(name: "jc", parent: "ground", child: "c", at: (0.5, 0.0)),
    ],
    gears: [Gear(joint: "jc", follows: "jb", ratio: {r2:e}), Gear(joint: "jb", follows: "ja", ratio: {r1:e})],
)"#
    ));
    let mut kane = Kane::new(&mech).unwrap();
    kane.set_joint_torque(0, Excitation::constant(t));
    let x = [0.3, 12.0];
    let d = xdot(&mut kane, 0.0, &x);
    let acc = t / (ja + r1 * r1 * jb + r1 * r1 * r2 * r2 * jc);
    assert_abs_diff_eq!(d[1], acc, epsilon = 1e-12 * acc.abs());
    let lc = jc * r1 * r2 * acc;
    let lb = jb * r1 * acc + r2 * lc;
    let mesh = kane.gear_torques(0.0, &x[..1], &x[1..], &d[1..]);
    // gears[0] drives jc, gears[1] drives jb (the file's order).
    println!("chain: λ_c {} vs {lc}, λ_b {} vs {lb}", mesh[0], mesh[1]);
    assert_abs_diff_eq!(mesh[0], lc, epsilon = 1e-12 * t.abs());
    assert_abs_diff_eq!(mesh[1], lb, epsilon = 1e-12 * t.abs());
    let re = joint_reactions(&mech, &x[..1], &x[1..], &d[1..]);
    assert_abs_diff_eq!(re[2].moment, lc, epsilon = 1e-12 * t.abs());
    assert_abs_diff_eq!(re[1].moment, lb - r2 * lc, epsilon = 1e-12 * t.abs());
    assert_abs_diff_eq!(re[0].moment, t - r1 * lb, epsilon = 1e-12 * t.abs());
}

/// A compliant mesh: at random states its torque on the driven joint is (k e + c ė)/r with the
/// deflection e = q_in − (q_out − o)/r at the driving joint, so the driving joint receives
/// −(k e + c ė) (Hooke's law and the damper at the driver, written here); and the driven joint's
/// Newton–Euler moment is J₂ q̈₂ (its only torque is the mesh's).
#[test]
fn a_compliant_mesh_carries_k_times_its_deflection() {
    let (j1, j2, r, k, c, o) = (0.7, 2.3, -3.2, 4.0e4, 3.0, 0.05);
    let gear = format!(
        "Gear(joint: \"output\", follows: \"input\", ratio: {r:e}, offset: {o:e}, mesh: (stiffness: {k:e}, damping: {c:e}))"
    );
    let mech = load(&pair(j1, j2, &gear, ""));
    assert_eq!(mech.ndof(), 2);
    let mut kane = Kane::new(&mech).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    for _ in 0..20 {
        let x: Vec<f64> = (0..4).map(|_| rng.random_range(-2.0..2.0)).collect();
        let d = xdot(&mut kane, 0.0, &x);
        let (e, edot) = (x[0] - (x[1] - o) / r, x[2] - x[3] / r);
        let driver = k * e + c * edot;
        let mesh = kane.gear_torques(0.0, &x[..2], &x[2..], &d[2..]);
        // The driving joint receives −r τ = −(k e + c ė).
        assert_abs_diff_eq!(r * mesh[0], driver, epsilon = 1e-12 * (k * e.abs() + c * edot.abs()));
        let re = joint_reactions(&mech, &x[..2], &x[2..], &d[2..]);
        assert_abs_diff_eq!(re[1].moment, j2 * d[3], epsilon = 1e-12 * (driver / r).abs().max(1.0));
        assert_abs_diff_eq!(re[1].moment, mesh[0], epsilon = 1e-12 * (driver / r).abs().max(1.0));
    }
}

/// The geared CPVA (examples/geared_cpva.ron) under an order-3 torque on its flywheel: per sample
/// of a time run, the power the mesh delivers to the driven side, τ·θ̇_out, equals the rate of
/// that side's energy (wheel and vehicle turning about the wheel's fixed axis, the drive shaft's
/// spring) plus the shaft damper's dissipation, each from the recorded driven-side probes (body
/// rates and accelerations below the driven joint, the shaft's q and q̇). The reflected torque
/// −r τ times the flywheel's rate is the same power with the opposite sign. Both balances are
/// exact identities of the equations at each state; the bound, 1e-12 of the largest term, is
/// rounding in sums of a few terms (measured 1e-15).
#[test]
fn power_balances_across_the_mesh_in_a_time_run() {
    let mech = Mechanism::from_file(Path::new("examples/geared_cpva.ron")).unwrap();
    let r = mech.gears[0].ratio;
    let (jw, jv) = (mech.bodies[2].inertia.i_com, mech.bodies[3].inertia.i_com);
    let (kd, cd) = (mech.joints[3].spring.unwrap().stiffness, mech.joints[3].damper);
    let mut kane = Kane::new(&mech).unwrap();
    let exc = Excitation {
        mean: 0.5,
        rpm: 1000.0,
        order: Order::Fixed(3.0),
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: 200.0, phase: 0.0 }],
        ramp_s: 0.2,
    };
    kane.set_joint_torque(0, exc);
    let kinds = [
        (ProbeKind::GearMeshTorque, "output"),
        (ProbeKind::JointRate, "output"),
        (ProbeKind::JointRate, "spin"),
        (ProbeKind::BodyRate, "wheel"),
        (ProbeKind::BodyAccel, "wheel"),
        (ProbeKind::BodyRate, "vehicle"),
        (ProbeKind::BodyAccel, "vehicle"),
        (ProbeKind::JointAngle, "driveshaft"),
        (ProbeKind::JointRate, "driveshaft"),
    ];
    let probes: Vec<Probe> = kinds.iter().map(|&(k, n)| Probe::resolve(&mech, k, n).unwrap()).collect();
    let mut rec = Recorder::new(&mech, &probes).unwrap();
    let omega = 1000.0 * PI / 30.0;
    let x0 = Study::initial_state(&mech, 0, omega);
    let opts = IntegrateOptions { sample_rate_hz: Some(2000.0), ..IntegrateOptions::default() };
    let out = simulate(&mut kane, &x0, 0.0, 0.5, &opts, &mut rec, &mut |_| {});
    assert!(out.error.is_none(), "{:?}", out.error);
    let mut worst = 0.0f64;
    for s in 0..rec.time.len() {
        // One sample across the columns.
        let v: Vec<f64> = rec.columns.iter().map(|col| col[s]).collect();
        let (tau, w_out, w_in) = (v[0], v[1], v[2]);
        // The driven joint's rate is the gear's r times the driver's, the wheel's body rate too.
        assert_eq!(w_out, r * w_in);
        assert_eq!(v[3], w_out);
        let p_mesh = tau * w_out;
        let terms = [jw * v[3] * v[4], jv * v[5] * v[6], kd * v[7] * v[8], cd * v[8] * v[8]];
        let scale = terms.iter().map(|t| t.abs()).fold(p_mesh.abs(), f64::max);
        worst = worst.max((p_mesh - terms.iter().sum::<f64>()).abs() / scale);
        // Reflected on the driving shaft: −r τ θ̇_in = −τ θ̇_out.
        assert_abs_diff_eq!(r * tau * w_in, p_mesh, epsilon = 1e-15 * scale);
    }
    println!("power across the mesh: worst mismatch {worst:.2e} of the largest term over {} samples", rec.time.len());
    assert!(worst <= 1e-12, "{worst:e}");
}

/// Driven-joint probes are the gear relation of the followed joint's: a driven joint's angle is
/// r q + offset, its rate r q̇, and the body below it turns with it, recorded at every sample of
/// a run (exact: one product and one sum each).
#[test]
fn driven_joint_probes_follow_the_gear() {
    let (r, o) = (-0.3125, 0.2);
    let mech =
        load(&pair(0.7, 2.3, &format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e}, offset: {o:e})"), ""));
    let mut kane = Kane::new(&mech).unwrap();
    kane.set_joint_torque(
        0,
        Excitation {
            mean: 1.0,
            rpm: 600.0,
            order: Order::Fixed(2.0),
            harmonics: vec![Harmonic { multiple: 1.0, amplitude: 5.0, phase: 0.0 }],
            ramp_s: 0.0,
        },
    );
    let kinds = [
        (ProbeKind::JointAngle, "output"),
        (ProbeKind::JointRate, "output"),
        (ProbeKind::BodyAngle, "wheel"),
        (ProbeKind::BodyRate, "wheel"),
        (ProbeKind::BodyAccel, "wheel"),
        (ProbeKind::JointAngle, "input"),
        (ProbeKind::JointRate, "input"),
        (ProbeKind::BodyAccel, "pinion"),
    ];
    let probes: Vec<Probe> = kinds.iter().map(|&(k, n)| Probe::resolve(&mech, k, n).unwrap()).collect();
    let mut rec = Recorder::new(&mech, &probes).unwrap();
    let opts = IntegrateOptions { sample_rate_hz: Some(500.0), ..IntegrateOptions::default() };
    simulate(&mut kane, &[0.1, 20.0], 0.0, 0.2, &opts, &mut rec, &mut |_| {});
    assert!(rec.time.len() > 90);
    for s in 0..rec.time.len() {
        // One sample across the columns.
        let v: Vec<f64> = rec.columns.iter().map(|col| col[s]).collect();
        assert_eq!(v[0], r * v[5] + o);
        assert_eq!(v[2], v[0]);
        assert_eq!(v[1], r * v[6]);
        assert_eq!(v[3], v[1]);
        assert_eq!(v[4], r * v[7]);
    }
    // A joint no gear drives has no mesh torque: a located refusal names the driven joints.
    let e = Probe::resolve(&mech, ProbeKind::GearMeshTorque, "input").unwrap_err().to_string();
    assert!(e.contains("no gear drives joint `input`") && e.contains("output"), "{e}");
}

/// A torque at a driven joint is the same as its reflection r·T at the joint it follows (the
/// generalized force mapped through Tᵀ): harmonic balance excited at the wheel of the geared
/// CPVA with amplitude T equals the one excited at the flywheel with r·T (the same equations,
/// assembled two ways: 1e-9 of the response, the Newton tolerance).
#[test]
fn excitation_at_a_driven_joint_is_its_reflection() {
    let mech = Mechanism::from_file(Path::new("examples/geared_cpva.ron")).unwrap();
    let r = mech.gears[0].ratio;
    let out = mech.joint_index("output").unwrap();
    let kane = Kane::new(&mech).unwrap();
    let omega = 1000.0 * PI / 30.0;
    let h = [Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }];
    let mut at_wheel = Hbm::with_inputs(&kane, 0, omega, &h, &[(out, 1.0, 0.0)], HbmOptions::default()).unwrap();
    let mut at_spin = Hbm::with_inputs(&kane, 0, omega, &h, &[(0, r, 0.0)], HbmOptions::default()).unwrap();
    let a = at_wheel.solve(3.0, None).unwrap();
    let b = at_spin.solve(3.0, None).unwrap();
    let scale = b.coefficients.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = a.coefficients.iter().zip(&b.coefficients).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    println!("driven-joint excitation vs its reflection: {:.2e} of the largest coefficient", diff / scale);
    assert!(diff <= 1e-9 * scale);
}

/// Harmonic balance's mesh-torque harmonics on the geared CPVA (order 3 at 1000 rpm, 40 N·m)
/// against a steady time run started on the orbit (DOP853 at rtol 1e-11, the mesh torque from
/// the engine's own ẋ at every sample, an FFT over 20 whole periods), and against the driven
/// joint's reaction moment from `reaction_harmonics` (the wheel's only torque is the mesh's, so
/// the two are one quantity by two routes). The driven side has no loss to ground, so no mean
/// torque crosses the mesh. Bound against the time run: 1e-9 of the order-3 amplitude, the
/// orbit's accuracy at rtol 1e-11 over 40 periods with a margin (measured 4e-11).
#[test]
fn harmonic_balance_mesh_torque_matches_a_time_run() {
    use realfft::RealFftPlanner;
    let mech = Mechanism::from_file(Path::new("examples/geared_cpva.ron")).unwrap();
    let out = mech.joint_index("output").unwrap();
    let kane = Kane::new(&mech).unwrap();
    let omega = 1000.0 * PI / 30.0;
    let h = [Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }];
    let mut hbm = Hbm::new(&kane, 0, omega, &h, HbmOptions::default()).unwrap();
    let sol = hbm.solve(3.0, None).unwrap();
    let mh = sol.mesh_torque_harmonics(&mut Kane::new(&mech).unwrap(), 0).unwrap();
    let rh = sol.reaction_harmonics(&mech, out);
    let amp = mh.amplitudes[0];
    assert!(amp > 1.0, "order-3 mesh torque {amp}");
    let same = (mh.mean - rh.mean[2])
        .abs()
        .max(mh.amplitudes.iter().zip(&rh.amplitudes).fold(0.0f64, |m, (a, b)| m.max((a - b[2]).abs())));
    println!(
        "HBM mesh torque: mean {:.3e} N·m, order 3 {amp:.4} N·m; vs the output's reaction moment {same:.2e}",
        mh.mean
    );
    assert!(same <= 1e-9 * amp);
    assert!(abs_diff_eq!(mh.mean, 0.0, epsilon = 1e-12 * amp), "mean mesh torque {}", mh.mean);

    let mut k = Kane::new(&mech).unwrap();
    let exc =
        Excitation { mean: sol.mean_torque, rpm: 1000.0, order: Order::Fixed(3.0), harmonics: h.to_vec(), ramp_s: 0.0 };
    k.set_joint_torque(0, exc);
    let mut probe_engine = Kane::new(&mech).unwrap();
    let n = mech.ndof();
    let period = 2.0 * PI / sol.base_frequency;
    let (periods, keep, per) = (40usize, 20usize, 128usize);
    let opts = IntegrateOptions {
        rtol: 1e-11,
        atol: 1e-12,
        sample_rate_hz: Some(per as f64 / period),
        sample_derivatives: true,
        ..IntegrateOptions::default()
    };
    let mut series = Vec::new();
    let start = (periods - keep) * per;
    integrate(
        |t, x, dx| k.rhs(t, x, dx),
        &hbm.state_at(&sol, 0.0),
        0.0,
        (periods as f64 + 0.5) * period,
        &opts,
        |s| {
            if s.k >= start && series.len() < keep * per {
                let d = s.xdot.unwrap();
                series.push(probe_engine.gear_torques(s.t, &s.x[..n], &s.x[n..], &d[n..])[0]);
            }
        },
    )
    .unwrap();
    let len = keep * per;
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
    let mut spec = fft.make_output_vec();
    fft.process(&mut series, &mut spec).unwrap();
    let mut worst = (spec[0].re / len as f64 - mh.mean).abs();
    for hh in 1..=4 {
        let a = 2.0 * spec[hh * keep].norm() / len as f64;
        worst = worst.max((a - mh.amplitudes[hh - 1]).abs());
    }
    println!("HBM mesh torque vs time run: {:.2e} of the order-3 amplitude", worst / amp);
    assert!(worst <= 1e-9 * amp, "{:e}", worst / amp);
}

/// The loss torque of rigid rotation through gears, against the hand-reduced value: a flywheel
/// with c_r to ground driving, through r, a shaft whose joint damper c_o and ground damper c_w
/// turn at rΩ, with a second body on it (ground damper c_v, also at rΩ), and through a compliant
/// mesh of ratio r₂ a third shaft with damper c_3 at r r₂ Ω: T = (c_r + r²(c_o + c_w + c_v)
/// + r² r₂² c_3) Ω (power c w² Ω² at rate wΩ, supplied at Ω). Rounding: 1e-14 relative.
#[test]
fn loss_torque_counts_driven_shafts_reflected() {
    let (cr, co, cw, cv, c3, r, r2) = (5e-3, 0.2, 0.05, 0.01, 0.3, -0.3125, 2.0);
    let mech = load(&format!(
        r#"Mechanism(
    name: "losses",
    speeds: JointRates,
    bodies: [Body(name: "rotor", mass: 1.0, inertia: 2.0), Body(name: "wheel", mass: 1.0, inertia: 0.5),
             Body(name: "hub", mass: 1.0, inertia: 0.1), Body(name: "third", mass: 1.0, inertia: 0.2)],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "output", parent: "ground", child: "wheel", at: (0.6, 0.0), damper: {co:e}),
        Joint(name: "weld", kind: Fixed, parent: "wheel", child: "hub"),
        Joint(name: "shaft3", parent: "ground", child: "third", at: (0.0, 0.8), damper: {c3:e}),
    ],
    loads: [GroundDamper(body: "rotor", c: {cr:e}), GroundDamper(body: "wheel", c: {cw:e}),
            GroundDamper(body: "hub", c: {cv:e})],
    gears: [Gear(joint: "output", follows: "spin", ratio: {r:e}),
            Gear(joint: "shaft3", follows: "output", ratio: {r2:e}, mesh: (stiffness: 1e4))],
)"#
    ));
    let omega = 100.0;
    let expected = (cr + r * r * (co + cw + cv) + r * r * r2 * r2 * c3) * omega;
    let got = Study::loss_torque(&mech, 0, omega);
    println!("loss torque through gears {got} N·m vs hand-reduced {expected}");
    assert_abs_diff_eq!(got, expected, epsilon = 1e-14 * expected);
    // The initial state turns the compliant shaft with its train (no start-up mesh deflection rate).
    let x0 = Study::initial_state(&mech, 0, omega);
    assert_eq!(x0[2..], [omega, r * r2 * omega]);
    // Without gears the formula is the old Σ c·Ω over the spinning subtree and the spin joint.
    let plain = kanedyn::cpva::CpvaParams::canonical().mechanism(None).unwrap();
    assert_eq!(Study::loss_torque(&plain, 0, omega), 5e-3 * omega);
}

/// Regression: a nonlinear coupling on an independent joint of a geared mechanism was counted
/// twice (by the reduced engine and again by the unconstrained tree it evaluates). Friction
/// T_f tanh(q̇/ε) well above ε is T_f: on the driving joint it enters F once, −T_f; on the driven
/// joint (rate r q̇) it reaches the driving coordinate as r · (−T_f sign(r q̇)). tanh(100) = 1 in
/// floating point, so both are exact.
#[test]
fn a_coupling_on_a_geared_joint_counts_once() {
    let r = -2.0;
    let gear = format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e})");
    let friction = "friction: (torque: 1.5, smoothing: 1.0)";
    let on_input = pair(0.7, 2.3, &gear, "").replace("child: \"pinion\")", &format!("child: \"pinion\", {friction})"));
    let on_output = pair(0.7, 2.3, &gear, &format!(", {friction}"));
    for (text, expected) in [(on_input, -1.5), (on_output, r * 1.5)] {
        let mut kane = Kane::new(&load(&text)).unwrap();
        let (_, f) = kane.mass_matrix_and_forcing(0.0, &[0.0], &[100.0]);
        assert_eq!(f[0], expected);
    }
}
