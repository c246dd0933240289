//! The gravity-forced linear response (issue 15 item 4; `kanedyn::linear`, the `gravity`
//! submodule): gravity acting on the mechanism at its nominal steady rotation is an order-1
//! forcing, passed through the linear transfer of eq. (22). Checked against
//! - a closed form written here: the paper's pendulum (eq. 15 tuning) on a rotor held at Ω in a
//!   vertical plane, and the paper's eq. (13) with the gravity forces added (spin free);
//! - harmonic balance with gravity (the full nonlinear equations): at small gravity and torque the
//!   linear order-1 and order-3 amplitudes agree, and the difference falls like the neglected
//!   second-order terms when g is halved;
//! - the cancellation for N = 4 equally spaced absorbers (Mu, Shaw et al., "The Effects of
//!   Gravity on the Response of Centrifugal Pendulum Vibration Absorbers", J. Vib. Acoust. 143(6),
//!   2021): the rotor's order-1 gravity response vanishes to rounding;
//! - a study with gravity: MultiOrder's linear part, LinearResponse and Campbell run, write no
//!   NaN, and report the library's figures.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::linear::{C64, LinearModel, OrderResponse, ResponseSpec, Spin};
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::model::math::Vec2;
use kanedyn::model::mechanism::Mechanism;

fn mechanism(n: usize, gravity: (f64, f64)) -> Mechanism {
    let mut m = CpvaParams::canonical().with_pendulums(n).mechanism(None).unwrap();
    m.loads.gravity = Vec2::new(gravity.0, gravity.1);
    m
}

fn spec(n: usize) -> ResponseSpec {
    let p = CpvaParams::canonical().with_pendulums(n);
    ResponseSpec {
        spin_joint: "spin".into(),
        inputs: vec![kanedyn::linear::Input::unit("spin")],
        body: "rotor".into(),
        lock: (0..n).map(|i| p.pivot_name(i)).collect(),
    }
}

fn rel(a: C64, b: C64) -> f64 {
    (a - b).norm() / b.norm()
}

/// The pendulum on a rotor held at Ω: with the rotor angle ψ = Ωt and the pendulum's centre of
/// mass at `R e(ψ) + L e(ψ + φ)` (e(a) = (cos a, sin a)), the weight's generalized force on φ is
/// `m g·L e'(ψ + φ) = m L (g_y cos ψ − g_x sin ψ)` at φ = 0, i.e. `Re(m L (g_y + i g_x) e^{iΩt})`.
/// The linear pendulum equation `J_B φ̈ + c_p φ̇ + m R L Ω² φ = that` (J_B = I_B + m L², eq. 14
/// with n_t² = m R L / J_B, eq. 15) gives `φ̂ = m L (g_y + i g_x) / (m R L Ω² − J_B Ω² + i c_p Ω)`.
/// The engine's generalized forces are evaluated numerically and the Jacobians by Richardson
/// differences (1e-12 relative in `tests/it/linear.rs`), so 1e-10 relative is a safe bound.
#[test]
fn held_rotor_pendulum_equals_the_forced_pendulum_equation() {
    let p = CpvaParams::canonical();
    let (m, r, l, jb, cp) = (p.pendulum_mass, p.pivot_radius, p.l(), p.j_b(), p.c_p);
    for (rpm, g) in [(300.0, (0.0, -9.81)), (1000.0, (1.3, -9.81)), (600.0, (-4.0, 0.0))] {
        let w = rpm_to_rad_s(rpm);
        let model = LinearModel::new(&mechanism(1, g), "spin", w, None).unwrap();
        assert!(model.has_gravity());
        let x = model.gravity_state_response(Spin::Held).unwrap();
        let want = C64::new(m * l * g.1, m * l * g.0) / C64::new(m * r * l * w * w - jb * w * w, cp * w);
        let e = rel(x[1], want);
        println!("{rpm} rpm, g = {g:?}: φ̂ = {:.9e} (closed form {:.9e}), rel. {e:.1e}", x[1], want);
        assert!(e <= 1e-10, "{e:e}");
        assert_eq!(x[0], C64::new(0.0, 0.0), "held spin: no rotor motion");
    }
}

/// Spin free: eq. (13) with the weight's generalized forces added, in the paper's speeds
/// u1 = θ̇, u2 = θ̇ + φ̇. The pendulum's centre of mass moves with partial velocities `R e'(ψ)`
/// (u1) and `L e'(ψ)` (u2) at φ = 0; the rotor's centre is on the axis. So the forcing is
/// `F̂ = (g_y + i g_x) m (R, L)` and, with `a = I_A + m R²`, `b = m R L`, `c = I_B + m L²`,
/// ω = Ω (order 1), `u = iω(θ̂, θ̂ + φ̂)`:
/// `iω a u1 + iω b u2 − bΩ² φ̂ = c_p(u2 − u1) − c_r u1 + F̂1`,
/// `iω b u1 + iω c u2 + bΩ² φ̂ = −c_p(u2 − u1) + F̂2`, solved here by Cramer's rule.
#[test]
fn free_rotor_and_pendulum_equal_eq13_with_the_weight() {
    let p = CpvaParams::canonical();
    let (m, r, l) = (p.pendulum_mass, p.pivot_radius, p.l());
    let (a, b, c) = (p.i_a() + m * r * r, m * r * l, p.i_b() + m * l * l);
    let (cp, cr) = (p.c_p, p.c_r);
    for (rpm, g) in [(300.0, (0.0, -9.81)), (1500.0, (2.0, -9.81))] {
        let w = rpm_to_rad_s(rpm);
        let iw = C64::new(0.0, w);
        let gc = C64::new(g.1, g.0);
        let (f1, f2) = (gc * m * r, gc * m * l);
        // Unknowns (θ̂, φ̂): rows of the two equations with u1 = iωθ̂, u2 = iω(θ̂ + φ̂).
        let k11 = iw * iw * a + iw * iw * b + iw * cr;
        let k12 = iw * iw * b - b * w * w - iw * cp;
        let k21 = iw * iw * b + iw * iw * c;
        let k22 = iw * iw * c + b * w * w + iw * cp;
        let det = k11 * k22 - k12 * k21;
        let theta = (f1 * k22 - k12 * f2) / det;
        let phi = (k11 * f2 - k21 * f1) / det;
        let model = LinearModel::new(&mechanism(1, g), "spin", w, None).unwrap();
        let x = model.gravity_state_response(Spin::Free).unwrap();
        let alpha = model.gravity_acceleration(0).unwrap();
        let e = [rel(x[0], theta), rel(x[1], phi), rel(alpha, -theta * w * w)];
        println!("{rpm} rpm: θ̂ {:.6e}, φ̂ {:.6e}, α̂ {:.6e}; rel. {e:?}", x[0], x[1], alpha);
        assert!(e.iter().all(|&v| v <= 1e-10), "{e:?}");
    }
}

/// One absorber, rotor free, order-3 torque `T sin 3Ωt` and gravity `g` in the rotor plane:
/// harmonic balance of the full equations (base order 1: the multiple 1/3 joins the
/// excitation, 24 harmonics of the rotation) against the linear model, at 300 rpm. Returns the
/// relative differences of (rotor order 1, pendulum order 1, rotor order 3, pendulum order 3).
fn linear_vs_hbm(g: f64, torque: f64) -> [f64; 4] {
    let rpm = 300.0;
    let w = rpm_to_rad_s(rpm);
    let mech = mechanism(1, (0.0, -g));
    let kane = Kane::new(&mech).unwrap();
    let harmonics = [
        Harmonic { multiple: 1.0 / 3.0, amplitude: 0.0, phase: 0.0 },
        Harmonic { multiple: 1.0, amplitude: torque, phase: 0.0 },
    ];
    let opts = HbmOptions { harmonics: 24, tol: 1e-13, ..HbmOptions::default() };
    let mut hbm = Hbm::new(&kane, 0, w, &harmonics, opts).unwrap();
    let sol = hbm.solve(3.0, None).unwrap();
    let resp = OrderResponse::new(&mech, &spec(1), w, None).unwrap();
    let lin = [
        resp.gravity_response().unwrap().norm(),
        resp.gravity_coordinates().unwrap()[1].norm(),
        resp.response(3.0).unwrap().norm() * torque,
        resp.coordinate_responses(3.0).unwrap()[1].norm() * torque,
    ];
    let non = [
        sol.order_acceleration(0, 1.0 / 3.0),
        sol.amplitude(1, 1),
        sol.order_acceleration(0, 1.0),
        sol.amplitude(1, 3),
    ];
    println!("g = {g} m/s², T = {torque} N·m: linear {lin:?}, harmonic balance {non:?}");
    std::array::from_fn(|i| (lin[i] - non[i]).abs() / non[i])
}

/// The linear model neglects the gravity × deflection (parametric) terms and the nonlinearity,
/// both second order in the small quantities (here the pendulum's order-1 amplitude
/// ≈ 6e-3 rad at g/10, T = 1 N·m): the differences are of order that amplitude squared, well
/// under 1e-4, and fall about fourfold when g is halved (asserted ≥ 3× at T = 0.5 N·m, where the
/// gravity terms dominate). At the full g and 10 N·m at 300 rpm they stay under 5e-3.
#[test]
fn linear_gravity_response_agrees_with_harmonic_balance() {
    let e = linear_vs_hbm(0.981, 1.0);
    println!("  rel. differences {e:?}");
    assert!(e.iter().all(|&v| v <= 1e-4), "{e:?}");
    let (full, half) = (linear_vs_hbm(0.981, 0.5), linear_vs_hbm(0.4905, 0.5));
    let falls: Vec<f64> = full.iter().zip(&half).map(|(a, b)| a / b).collect();
    println!("  halving g divides the differences by {falls:?}");
    assert!(falls.iter().all(|&f| f >= 3.0), "{falls:?}");
    let e = linear_vs_hbm(9.81, 10.0);
    println!("  rel. differences at full gravity {e:?}");
    assert!(e.iter().all(|&v| v <= 5e-3), "{e:?}");
}

/// N = 4 equally spaced absorbers (same total mass and inertia as the one): the weights' order-1
/// forces on the rotor cancel (Σ e^{i2πk/4} = 0), and so do the absorbers' reactions, whose
/// motions are the same but for the phase e^{i2πk/4}; so the rotor's order-1 response vanishes
/// (to rounding: ≤ 1e-12 of the single absorber's), the locked rotor is balanced, and each
/// absorber moves as on a held rotor: the forced pendulum of the first test, φ̂_k = φ̂ e^{i2πk/4}
/// (≤ 1e-10 relative, as there).
#[test]
fn four_absorbers_cancel_the_rotors_order_1_gravity_response() {
    let p = CpvaParams::canonical();
    let (m, r, l, jb, cp) = (p.pendulum_mass, p.pivot_radius, p.l(), p.j_b(), p.c_p);
    for rpm in [300.0, 1000.0] {
        let w = rpm_to_rad_s(rpm);
        let one = OrderResponse::new(&mechanism(1, (0.0, -9.81)), &spec(1), w, None).unwrap();
        let four = OrderResponse::new(&mechanism(4, (0.0, -9.81)), &spec(4), w, None).unwrap();
        let (a1, a4) = (one.gravity_response().unwrap().norm(), four.gravity_response().unwrap().norm());
        let (l1, l4) = (one.gravity_locked_response().unwrap().norm(), four.gravity_locked_response().unwrap().norm());
        println!(
            "{rpm} rpm: rotor order 1: one absorber {a1:.6e} rad/s² (locked {l1:.6e}), four {a4:.3e} (locked {l4:.3e})"
        );
        assert!(a4 <= 1e-12 * a1 && l4 <= 1e-12 * l1, "{a4:e} {l4:e}");
        let held = C64::new(m * l * -9.81, 0.0) / C64::new(m * r * l * w * w - jb * w * w, cp * w);
        let q = four.gravity_coordinates().unwrap();
        for k in 0..4 {
            let want = held * C64::from_polar(1.0, p.with_pendulums(4).pivot_angle(k));
            let e = rel(q[1 + k], want);
            assert!(e <= 1e-10, "absorber {k}: {} vs {want} ({e:e})", q[1 + k]);
        }
    }
}

/// A folder holding `examples/cpva.ron` in a vertical plane (gravity (0, −9.81) m/s²) with its
/// catalog parts, and the study `text` as `s.ron`.
fn study_dir(tag: &str, text: &str) -> tempfile::TempDir {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let tmp = crate::support::scratch(&format!("gravity-linear-{tag}"));
    let dir = tmp.path();
    let mech = std::fs::read_to_string(root.join("cpva.ron")).unwrap().replacen(
        "speeds: AbsoluteAngularVelocities,",
        "speeds: AbsoluteAngularVelocities,\n    gravity: (0.0, -9.81),",
        1,
    );
    assert!(mech.contains("gravity: (0.0, -9.81)"));
    std::fs::write(dir.join("m.ron"), mech).unwrap();
    std::fs::write(dir.join("s.ron"), text).unwrap();
    tmp
}

const MULTI: &str = r#"MultiOrder(name: "multi", order: 3.0, multiples: [1.0, 2.0, 0.3333333333333333], linear: true,
    time_domain: false, speeds: [
        (rpm: 600.0, harmonics: [(multiple: 1.0, amplitude: 670.0), (multiple: 2.0, amplitude: 430.0, phase: -0.32)]),
        (rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 1600.0), (multiple: 2.0, amplitude: 900.0, phase: -0.32)]),
    ])"#;

/// The paper's rotor with one absorber in a vertical plane: MultiOrder (linear part, tracking
/// order 1 as the multiple 1/3 as well), LinearResponse and Campbell run without failure or
/// NaN, and report the library's order-1 gravity response (checked against the closed forms
/// above), the torque lines unchanged by gravity. MultiOrder's time-domain part with gravity is
/// refused, located at its field.
#[test]
fn a_study_reports_the_gravity_forced_linear_response() {
    let text = format!(
        r#"Study(name: "g", mechanism: "m.ron", lock: ["pivot"], analyses: [
            {MULTI},
            LinearResponse(name: "lin", rpm: 1000.0, from: 2.5, to: 4.0, points: 31),
            Campbell(name: "campbell", rpm_min: 0.0, rpm_max: 2000.0, points: 11, orders: [1.0, 3.0]),
        ])"#
    );
    let tmp = study_dir("run", &text);
    let dir = tmp.path().to_path_buf();
    let study = kanedyn::study::Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.join("out");
    let report = kanedyn::study::run(&study, &kanedyn::study::RunOptions { out: Some(out.clone()), progress: false })
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let mech = Mechanism::from_file(&dir.join("m.ron")).unwrap();
    let plain = {
        let mut m = mech.clone();
        m.loads.gravity = Vec2::zeros();
        m
    };
    // Same mechanism and speeds in the library: the rotor's order-1 gravity line, and the order-3
    // torque line (which gravity does not change at this order).
    let close = |a: f64, b: f64| abs_diff_eq!(a, b, epsilon = 1e-9 * b.abs());
    let multi = &report.multi[0];
    for (s, (rpm, t3)) in multi.speeds.iter().zip([(600.0, 670.0), (1000.0, 1600.0)]) {
        let w = rpm_to_rad_s(rpm);
        let resp = OrderResponse::new(&mech, &spec(1), w, None).unwrap();
        let g = resp.gravity_response().unwrap().norm();
        let gl = resp.gravity_locked_response().unwrap().norm();
        let a3 = OrderResponse::new(&plain, &spec(1), w, None).unwrap().response(3.0).unwrap().norm() * t3;
        let lin = s.linear.as_ref().unwrap();
        println!(
            "{rpm} rpm: gravity order 1 {:?} (library {g:.9e}), locked {:?} ({gl:.9e}); order 3 {:.9e} ({a3:.9e})",
            s.linear_gravity, s.linear_gravity_locked, lin[0]
        );
        assert!(close(s.linear_gravity.unwrap(), g) && close(s.linear_gravity_locked.unwrap(), gl));
        assert!(close(lin[2], g), "the tracked order 1 is gravity's line: {} vs {g}", lin[2]);
        assert!(close(lin[0], a3));
    }
    let lr = &report.linear[0].variants[0];
    let gr = lr.gravity.as_ref().expect("the gravity response of LinearResponse");
    let resp = OrderResponse::new(&mech, &spec(1), rpm_to_rad_s(1000.0), None).unwrap();
    let q = resp.gravity_coordinates().unwrap();
    println!(
        "LinearResponse: gravity order 1 {:.9e} rad/s², locked {:.9e}, elements {:?}",
        gr.accel, gr.locked, gr.elements
    );
    assert!(close(gr.accel, resp.gravity_response().unwrap().norm()));
    assert!(close(gr.locked, resp.gravity_locked_response().unwrap().norm()));
    assert!(close(gr.elements[0], q[1].norm()), "the pivot's order-1 amplitude");
    assert!(!report.campbell[0].tracks.is_empty());
    for phrase in [
        "order 1 gravity linear",
        "Gravity (0, -9.81) m/s² forces the rotation at order 1",
        "these modes about the steady rotation",
    ] {
        assert!(report.summary.contains(phrase), "summary lacks `{phrase}`:\n{}", report.summary);
    }
    let csv = std::fs::read_to_string(out.join("g").join("multi.csv")).unwrap();
    assert!(csv.contains("linear_gravity_order1_rad_s2"));
    for f in &report.files {
        if f.extension().is_some_and(|e| e == "csv" || e == "md" || e == "json") {
            // NaN or an infinity as a word of its own ("resonance" passes).
            let t = std::fs::read_to_string(f).unwrap();
            let bad = t
                .split(|c: char| !(c.is_ascii_alphanumeric() || c == '.'))
                .any(|w| ["nan", "inf", "infinity"].contains(&w.to_ascii_lowercase().as_str()));
            assert!(!bad, "{} holds a NaN or inf", f.display());
        }
    }
}

/// MultiOrder's steady time runs and its order-continued harmonic balance assume a steady spin:
/// with gravity they are refused with an error at their field (file, line:column, field path).
#[test]
fn multi_order_time_runs_with_gravity_are_refused_at_their_field() {
    for (field, extra) in [("time_domain", ""), ("hbm", "time_domain: false, hbm: true,")] {
        let multi = MULTI.replacen("time_domain: false,", extra, 1);
        let tmp =
            study_dir(field, &format!(r#"Study(name: "g", mechanism: "m.ron", lock: ["pivot"], analyses: [{multi}])"#));
        let dir = tmp.path();
        let err = kanedyn::study::Study::from_file(&dir.join("s.ron")).unwrap_err().to_string();
        println!("{err}");
        assert!(
            err.contains("s.ron:") && err.contains(&format!("analyses[0].{field}")) && err.contains("gravity"),
            "{err}"
        );
    }
}

/// A world-frame point force is the same kind of forcing: the force `m g` at the pendulum's
/// centre of mass (the rotor's is on the axis, so its weight does nothing) gives the gravity
/// response exactly (≤ 1e-12 relative: the same engine terms evaluated twice). A body that does
/// not turn with the spin joint (a pendulum hung from the ground beside the rotor) makes the
/// weight a static load plus order 0, not an order-1 forcing: refused, naming the mechanism.
#[test]
fn world_forces_force_at_order_1_and_a_non_turning_weight_is_refused() {
    use kanedyn::model::body::BodySpec;
    use kanedyn::model::joint::{JointKind, JointSpec};
    use kanedyn::model::loads::{ForceFrame, LoadSpec};
    let p = CpvaParams::canonical();
    let w = rpm_to_rad_s(800.0);
    let mut spec_f = p.spec(None);
    spec_f.loads.push(LoadSpec::PointForce {
        body: "pendulum".into(),
        at: (p.l(), 0.0),
        force: (0.0, -9.81 * p.pendulum_mass),
        frame: ForceFrame::World,
    });
    let by_force = LinearModel::new(&Mechanism::from_spec(&spec_f).unwrap(), "spin", w, None).unwrap();
    let by_weight = LinearModel::new(&mechanism(1, (0.0, -9.81)), "spin", w, None).unwrap();
    let (a, b) =
        (by_force.gravity_state_response(Spin::Free).unwrap(), by_weight.gravity_state_response(Spin::Free).unwrap());
    let e = (&a - &b).norm() / b.norm();
    println!("world force vs weight: {e:e}");
    assert!(by_force.has_gravity() && e <= 1e-12, "{e:e}");

    let mut spec_g = p.spec(None);
    spec_g.gravity = (0.0, -9.81);
    spec_g.bodies.push(BodySpec {
        name: Some("bob".into()),
        mass: Some(1.0),
        com: Some((0.0, -0.1)),
        inertia: Some(1e-3),
        ..BodySpec::default()
    });
    spec_g.joints.push(JointSpec {
        name: Some("hang".into()),
        kind: Some(JointKind::Revolute),
        parent: Some("ground".into()),
        child: Some("bob".into()),
        at: Some((1.0, 0.0)),
        ..JointSpec::default()
    });
    let err = LinearModel::new(&Mechanism::from_spec(&spec_g).unwrap(), "spin", w, None).unwrap_err();
    println!("{err}");
    assert!(
        matches!(err, kanedyn::linear::LinearError::WorldOrientation { .. }) && err.to_string().contains("cpva"),
        "{err}"
    );
}

/// The multi-order response superposes gravity's order-1 line with the torque's orders: its
/// order-1 line is the gravity response, and the peak is that of the sum over the common period
/// in the rotor angle (one revolution at base order 3; two at base order 1.5, whose multiples are
/// half orders), checked against a brute-force sampling here of 2·10⁶ points per revolution
/// (both sample a smooth sum; their difference is bounded by the coarser grid's 4096 points per
/// period of the top line: ≤ (π/4096)²/2 · Σ amplitudes · (top order)² relative, ≈ 1e-5 here;
/// asserted ≤ 1e-5 of the sum of the amplitudes).
#[test]
fn multi_order_superposes_gravity_with_the_engine_orders() {
    use kanedyn::linear::{SpeedCase, multi_order_response};
    let mech = mechanism(1, (0.0, -9.81));
    for (base, revolutions) in [(3.0, 1.0), (1.5, 2.0)] {
        let cases = [SpeedCase {
            rpm: 800.0,
            harmonics: vec![
                Harmonic { multiple: 1.0, amplitude: 400.0, phase: 0.0 },
                Harmonic { multiple: 2.0, amplitude: 250.0, phase: -0.32 },
            ],
        }];
        let r = &multi_order_response(&mech, &spec(1), base, &cases, None).unwrap()[0];
        let g = r.gravity.expect("a gravity line");
        let want = OrderResponse::new(&mech, &spec(1), rpm_to_rad_s(800.0), None).unwrap().gravity_response().unwrap();
        assert_abs_diff_eq!(g.amplitude, want.norm(), epsilon = 1e-12 * want.norm());
        assert_abs_diff_eq!(r.line(1.0).0, g.amplitude, epsilon = 1e-12 * g.amplitude);
        let mut lines: Vec<(f64, f64, f64)> = r.harmonics.iter().map(|h| (h.order, h.amplitude, h.phase)).collect();
        lines.push((1.0, g.amplitude, g.phase));
        let total: f64 = lines.iter().map(|l| l.1).sum();
        let samples = (2e6 * revolutions) as usize;
        let brute = (0..samples)
            .map(|i| {
                let psi = 2.0 * std::f64::consts::PI * revolutions * i as f64 / samples as f64;
                lines.iter().map(|&(o, a, p)| a * (o * psi + p).sin()).sum::<f64>().abs()
            })
            .fold(0.0, f64::max);
        let peak = r.peak.expect("a common period");
        println!("base order {base}: peak {peak:.9} rad/s², brute force {brute:.9}, sum of amplitudes {total:.6}");
        assert_abs_diff_eq!(peak, brute, epsilon = 1e-5 * total);
        assert!(r.locked_peak.is_some());
    }
}
