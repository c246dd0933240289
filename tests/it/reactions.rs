//! Joint reactions (`kane::reactions`, a Newton–Euler pass after Kane's accelerations) against
//! statics, the centripetal force of uniform rotation, the moment a revolute joint can carry (only
//! its spring, damper and applied torque), and the rattle threshold of a pendulum absorber under
//! gravity in a study run-up.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::kane::reactions::joint_reactions;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use std::f64::consts::PI;

const G: f64 = 9.81;

fn load(text: &str) -> Mechanism {
    Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::unrestricted())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// q̇ and q̈ (joint rates) and the reactions at state (q, u) from the engine's own ẋ.
fn reactions_at(mech: &Mechanism, q: &[f64], u: &[f64]) -> Vec<kanedyn::kane::reactions::Reaction> {
    let n = mech.ndof();
    let mut kane = Kane::new(mech).unwrap();
    let x: Vec<f64> = q.iter().chain(u).copied().collect();
    let mut xd = vec![0.0; 2 * n];
    kane.rhs(0.0, &x, &mut xd).unwrap();
    let parents = mech.speed_parents();
    let (mut qdot, mut qddot) = (vec![0.0; n], vec![0.0; n]);
    mech.speeds.qdot(&parents, u, &mut qdot);
    mech.speeds.qdot(&parents, &xd[n..], &mut qddot);
    joint_reactions(mech, q, &qdot, &qddot)
}

/// A pendulum hanging at rest under gravity: the pivot carries its weight, upwards, and no
/// moment (exact statics; 1e-12 relative leaves room for cos(−π/2) ≠ 0 in floating point).
#[test]
fn a_hanging_pendulum_carries_its_weight() {
    let m = load(
        r#"Mechanism(name: "hang", bodies: [Body(name: "p", mass: 2.5, com: (0.4, 0.0), inertia: 0.03)],
           joints: [Joint(name: "pivot", kind: Revolute, parent: "ground", child: "p", at: (0.0, 0.0))],
           loads: [], gravity: (0.0, -9.81))"#,
    );
    let r = reactions_at(&m, &[-PI / 2.0], &[0.0])[0];
    let weight = 2.5 * G;
    println!("hanging pendulum: pivot force {:?}, moment {:e}", r.force_world, r.moment);
    assert!(
        abs_diff_eq!(r.force_world.y, weight, epsilon = 1e-12 * weight),
        "vertical {} vs {weight}",
        r.force_world.y
    );
    assert_abs_diff_eq!(r.force_world.x, 0.0, epsilon = 1e-12 * weight);
    assert_abs_diff_eq!(r.moment, 0.0, epsilon = 1e-12 * weight);
}

/// The paper's pendulum at φ = 0 on its rotor turning at Ω = 1000 rpm: the rotor's acceleration
/// is zero there (symmetry), so the pendulum's centre of mass moves on a circle of radius R + L
/// and the pivot pulls it inwards with m (R + L) Ω²; the spin bearing carries the same force.
#[test]
fn a_pendulum_on_a_spinning_rotor_carries_its_centripetal_force() {
    let m = Mechanism::from_file(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva.ron")).unwrap();
    let mut m = m;
    // Constant Ω: no torque and no loss on the rotor.
    m.loads.joint_torques.clear();
    m.loads.ground_dampers.clear();
    let omega = 1000.0 * PI / 30.0;
    let (mass, r, l) = (6.0, 0.17, 0.015209365076836064);
    let want = mass * (r + l) * omega * omega;
    // Absolute angular velocities: both bodies turn at Ω.
    let rs = reactions_at(&m, &[0.3, 0.0], &[omega, omega]);
    let pivot = rs[m.joint_index("pivot").unwrap()];
    let bearing = rs[m.joint_index("spin").unwrap()];
    println!(
        "pivot radial {} tangential {} (want −{want}); bearing |F| {}",
        pivot.radial,
        pivot.tangential,
        bearing.force_world.norm()
    );
    assert!(abs_diff_eq!(pivot.radial, -want, epsilon = 1e-12 * want), "radial {} vs −{want}", pivot.radial);
    assert_abs_diff_eq!(pivot.tangential, 0.0, epsilon = 1e-12 * want);
    assert_abs_diff_eq!(pivot.moment, 0.0, epsilon = 1e-12 * want);
    assert_abs_diff_eq!(bearing.force_world.norm(), want, epsilon = 1e-12 * want);
}

/// A revolute joint's constraint carries no moment, so at any state the Newton–Euler moment at
/// each pivot of a spring-loaded, damped triple pendulum under gravity and a joint torque must
/// equal that joint's spring, damper and applied torque: −k(q − q₀) − c q̇ + T. The accelerations
/// come from Kane's equations, the moments from Newton–Euler: two independent routes.
#[test]
fn revolute_moments_are_the_joint_torques_at_random_states() {
    let m = load(
        r#"Mechanism(name: "tri", speeds: JointRates,
           bodies: [Body(name: "a", mass: 3.0, com: (0.3, 0.05), inertia: 0.04),
                    Body(name: "b", mass: 1.5, com: (0.2, -0.02), inertia: 0.01),
                    Body(name: "c", mass: 0.7, com: (0.15, 0.01), inertia: 0.004)],
           joints: [Joint(name: "j0", kind: Revolute, parent: "ground", child: "a", at: (0.0, 0.0), spring: (stiffness: 40.0, free_angle: 0.2), damper: 0.3),
                    Joint(name: "j1", kind: Revolute, parent: "a", child: "b", at: (0.5, 0.0), spring: (stiffness: 25.0), damper: 0.1),
                    Joint(name: "j2", kind: Revolute, parent: "b", child: "c", at: (0.35, 0.02), damper: 0.05)],
           loads: [JointTorque(joint: "j1", excitation: (mean: 1.7, rpm: 0.0, order: Fixed(1.0), harmonics: [], ramp_s: 0.0)),
                   GroundDamper(body: "c", c: 0.2)],
           gravity: (0.0, -9.81))"#,
    );
    let mut seed = 7u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let q = [3.0 * rnd(), 3.0 * rnd(), 3.0 * rnd()];
        let u = [5.0 * rnd(), 5.0 * rnd(), 5.0 * rnd()];
        let rs = reactions_at(&m, &q, &u);
        let expect = [-40.0 * (q[0] - 0.2) - 0.3 * u[0], -25.0 * q[1] - 0.1 * u[1] + 1.7, -0.05 * u[2]];
        for (r, e) in rs.iter().zip(expect) {
            // Relative to the size of the inertial terms at play.
            let scale = r.force_world.norm().max(1.0);
            worst = worst.max((r.moment - e).abs() / scale);
        }
    }
    println!("revolute moments vs joint torques: largest difference {worst:.2e} (per N of force)");
    assert!(worst <= 1e-12, "revolute moment differs from its joint torque by {worst:e}");
}

/// The rattle threshold: a pendulum absorber on the paper's rotor in a vertical plane (gravity
/// −y), its spin prescribed from 40 to 100 rpm over 60 s, the pivot's reaction recorded by the
/// study. At the top of its turn the pendulum's centre of mass, at r_c from the axis, needs
/// m r_c Ω² towards the axis and gravity gives m g, so the pivot pushes it outwards below
/// Ω = √(g/r_c) and pulls it inwards above: the radial reaction at the top changes sign there.
/// The crossing is found from the samples nearest the top of each turn, so it is resolved to the
/// speed gained in one revolution (about 1 rpm). Returns (speed before, speed after, √(g/r_c)),
/// rpm, and the largest pivot swing, rad.
fn rattle(tag: &str, pivot_spring: &str) -> (f64, f64, f64, f64) {
    let tmp = scratch(&format!("reactions-{tag}"));
    let dir = tmp.path().to_path_buf();
    std::fs::write(
        dir.join("m.ron"),
        format!(
            r#"Mechanism(name: "cpva_vertical", speeds: AbsoluteAngularVelocities,
           bodies: [Body(name: "rotor", mass: 110.0, com: (0.0, 0.0), inertia: 3.443504355127701),
                    Body(name: "pendulum", mass: 6.0, com: (0.015209365076836064, 0.0), inertia: 0.000216)],
           joints: [Joint(name: "spin", kind: Revolute, parent: "ground", child: "rotor", at: (0.0, 0.0)),
                    Joint(name: "pivot", kind: Revolute, parent: "rotor", child: "pendulum", at: (0.17, 0.0), damper: 5e-4{pivot_spring})],
           loads: [GroundDamper(body: "rotor", c: 5e-3)], gravity: (0.0, -9.81))"#
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "m.ron", elements: ["pivot"], integration: (rtol: 1e-10, atol: 1e-10, sample_hz: 2000.0),
           analyses: [Transient(name: "rattle", duration_s: 60.0, speed: Prescribed(rpm_from: 40.0, rpm_to: 100.0),
                      reactions: ["pivot"], map: (revs_per_block: 4, hop_revs: 1.0, max_order: 4.0, cuts: [1.0]))])"#,
    )
    .unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let r = &report.transient[0];
    let (_, [radial, _, _]) = &r.reaction_series[0];
    // The rotor angle θ (prescribed speed from θ = 0): the pivot is at the top where
    // θ ≡ π/2 (mod 2π). Per turn, the radial force at the sample nearest the top.
    let fs = 2000.0;
    let (w0, a) = (40.0 * PI / 30.0, (60.0 * PI / 30.0) / 60.0);
    let mut tops = Vec::new();
    for k in 0.. {
        let theta = PI / 2.0 + 2.0 * PI * k as f64;
        // θ(t) = w0 t + a t²/2.
        let t = (-w0 + (w0 * w0 + 2.0 * a * theta).sqrt()) / a;
        let i = (t * fs).round() as usize;
        if t > 60.0 || i >= radial.len() {
            break;
        }
        tops.push((r.spin_rpm[i], radial[i]));
    }
    let first_negative = tops.iter().position(|&(_, f)| f < 0.0).expect("the radial force never turns inwards");
    assert!(first_negative > 0 && tops[..first_negative].iter().all(|&(_, f)| f > 0.0));
    let swing = r.element_series[0].0.iter().fold(0.0f64, |m, q| m.max(q.abs()));
    let want = (G / (0.17 + 0.015209365076836064)).sqrt() * 30.0 / PI;
    (tops[first_negative - 1].0, tops[first_negative].0, want, swing)
}

/// The absorber held near its vertex by a stiff pivot spring (gravity deflects it by
/// m g L / k ≈ 1e-4 rad), so r_c stays R + L: the sign change lies within one revolution's
/// speed step of √(g/r_c) = 69.50 rpm.
#[test]
fn the_pivot_force_at_the_top_changes_sign_at_the_rattle_threshold() {
    let (before, after, want, swing) = rattle("held", ", spring: (stiffness: 1e4)");
    println!(
        "held absorber: sign change between {before:.2} and {after:.2} rpm; √(g/r_c) = {want:.2} rpm; swing {swing:.1e} rad"
    );
    let step = after - before;
    assert!(before - step <= want && want <= after + step, "crossing [{before}, {after}] vs {want}");
}

/// The free pendulum of the paper is not held by the centrifugal field at these speeds: below
/// the threshold gravity exceeds R Ω² and the pendulum turns over relative to the rotor (its
/// recorded excursion grows to hundreds of radians: the rattling the threshold is named after),
/// and near it the pendulum's own motion changes its centre of mass's acceleration at the top,
/// so the sign change moves off √(g/(R + L)). Reported, and bounded to a few per cent.
#[test]
fn the_swinging_pendulum_crosses_near_the_threshold() {
    let (before, after, want, swing) = rattle("free", "");
    println!(
        "free absorber: sign change between {before:.2} and {after:.2} rpm; √(g/r_c) = {want:.2} rpm; swing {swing:.2} rad"
    );
    assert!(swing > 2.0 * PI, "the free pendulum should turn over below the threshold, {swing} rad");
    assert!(abs_diff_eq!(after / want, 1.0, epsilon = 0.05), "crossing at {after} rpm vs {want}");
}

/// Harmonic balance's reaction harmonics (Newton–Euler on the Fourier series' q, q̇, q̈) against
/// the same reactions on a steady time run started on the orbit (DOP853, ẋ from the engine at
/// every sample, an FFT over 20 whole periods): the pivot of the paper's CPVA at 1000 rpm,
/// order 3, 40 N·m. The time run resolves the orbit to ~1e-9 (tests/it/cpva_paths.rs); 1e-6 of the
/// mean radial force bounds the harmonics.
#[test]
fn harmonic_balance_reactions_match_a_time_run() {
    use kanedyn::hbm::{Hbm, HbmOptions};
    use kanedyn::model::excitation::{Excitation, Harmonic, Order};
    use kanedyn::time::integrate::{IntegrateOptions, integrate};
    use realfft::RealFftPlanner;
    let mech = kanedyn::cpva::CpvaParams::canonical().mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    let omega = 1000.0 * PI / 30.0;
    let h = [Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.0 }];
    let mut hbm = Hbm::new(&kane, 0, omega, &h, HbmOptions::default()).unwrap();
    let sol = hbm.solve(3.0, None).unwrap();
    let pivot = mech.joint_index("pivot").unwrap();
    let rh = sol.reaction_harmonics(&mech, pivot);

    let mut k = Kane::new(&mech).unwrap();
    let exc =
        Excitation { mean: sol.mean_torque, rpm: 1000.0, order: Order::Fixed(3.0), harmonics: h.to_vec(), ramp_s: 0.0 };
    k.set_joint_torque(0, exc);
    let n = mech.ndof();
    let parents = mech.speed_parents();
    let period = 2.0 * PI / sol.base_frequency;
    let (periods, keep, per) = (40usize, 20usize, 128usize);
    let opts = IntegrateOptions {
        rtol: 1e-11,
        atol: 1e-12,
        sample_rate_hz: Some(per as f64 / period),
        sample_derivatives: true,
        ..IntegrateOptions::default()
    };
    let mut series = [Vec::new(), Vec::new(), Vec::new()];
    let start = (periods - keep) * per;
    integrate(
        |t, x, dx| k.rhs(t, x, dx),
        &hbm.state_at(&sol, 0.0),
        0.0,
        (periods as f64 + 0.5) * period,
        &opts,
        |s| {
            if s.k >= start && series[0].len() < keep * per {
                let (mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n]);
                mech.speeds.qdot(&parents, &s.x[n..], &mut qd);
                mech.speeds.qdot(&parents, &s.xdot.unwrap()[n..], &mut qdd);
                let r = joint_reactions(&mech, &s.x[..n], &qd, &qdd)[pivot];
                series[0].push(r.radial);
                series[1].push(r.tangential);
                series[2].push(r.moment);
            }
        },
    )
    .unwrap();
    let len = keep * per;
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(len);
    let scale = rh.mean[0].abs();
    let mut worst = 0.0f64;
    for (c, s) in series.iter_mut().enumerate() {
        let mut spec = fft.make_output_vec();
        fft.process(s, &mut spec).unwrap();
        let mean = spec[0].re / len as f64;
        worst = worst.max((mean - rh.mean[c]).abs() / scale);
        for hh in 1..=4 {
            let a = 2.0 * spec[hh * keep].norm() / len as f64;
            worst = worst.max((a - rh.amplitudes[hh - 1][c]).abs() / scale);
        }
    }
    println!(
        "HBM pivot reaction: mean radial {:.3} N, order-3 radial {:.4} N, tangential {:.4} N; vs time run {worst:.2e} of the mean",
        rh.mean[0], rh.amplitudes[0][0], rh.amplitudes[0][1]
    );
    assert!(worst <= 1e-6, "HBM reactions vs time run: {worst:e}");
}
