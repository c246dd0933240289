//! The joint interface, proven by its three kinds against closed forms written out here:
//! - Kane's method body by body (`kane::reference`) equals the paper's eq. (7) for N = 1, 2, 4;
//! - a cart sliding on a tilted prismatic joint under a pendulum (the slider-pendulum), and a
//!   bead sliding along a spinning rod, each against its equations from Lagrange's method;
//! - a body welded by a fixed joint equals the parent with the merged (parallel-axis) inertia;
//! - bad joint input (zero axis, fixed joint with spring or torque, unknown kind) is a located
//!   error naming the joint.
//!
//! Tolerances: the engine and the closed forms sum the same few terms in another order, so they
//! agree to rounding, ≤ 1e-12 relative to the largest entry.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::cpva::CpvaParams;
use kanedyn::io::ReadPolicy;
use kanedyn::io::Source;
use kanedyn::kane::{Kane, reference};
use kanedyn::model::body::BodySpec;
use kanedyn::model::excitation::Excitation;
use kanedyn::model::inertia::PlanarInertia;
use kanedyn::model::joint::{JointKind, JointSpec, Spring};
use kanedyn::model::loads::LoadSpec;
use kanedyn::model::math::{Vec2, rot2};
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

fn relv(a: &DVector<f64>, b: &DVector<f64>, scale: f64) -> f64 {
    (a - b).amax() / b.amax().max(scale)
}

fn body(name: &str, mass: f64, com: (f64, f64), inertia: f64) -> BodySpec {
    BodySpec {
        name: Some(name.into()),
        mass: Some(mass),
        com: Some(com),
        inertia: Some(inertia),
        ..BodySpec::default()
    }
}

fn joint(name: &str, kind: JointKind, parent: &str, child: &str, at: (f64, f64)) -> JointSpec {
    JointSpec {
        name: Some(name.into()),
        kind: Some(kind),
        parent: Some(parent.into()),
        child: Some(child.into()),
        at: Some(at),
        ..JointSpec::default()
    }
}

#[test]
fn reference_equals_eq_7() {
    // The textbook route on the generic CPVA mechanism against eq. (7) written by hand
    // (cpva::ClosedForm), at random states, with the rotor torque in effect.
    let mut rng = StdRng::seed_from_u64(7);
    let torque = 123.0;
    for n in [1, 2, 4] {
        let p = CpvaParams::canonical().with_pendulums(n);
        let mech = p.mechanism(Some(Excitation::constant(torque))).unwrap();
        let cf = p.closed_form();
        for _ in 0..50 {
            let q: Vec<f64> = (0..=n).map(|_| rng.random_range(-3.0..3.0)).collect();
            let u: Vec<f64> = (0..=n).map(|_| rng.random_range(-200.0..200.0)).collect();
            let (m_ref, f_ref) = reference::mass_matrix_and_forcing(&mech, &mech.loads.joint_torques, 0.0, &q, &u);
            let (m_cf, f_cf) = cf.mass_matrix_and_forcing(&q, &u, torque);
            assert!(rel(&m_ref, &m_cf) <= 1e-12, "N = {n}: M {m_ref} vs eq. (7) {m_cf}");
            assert!(relv(&f_ref, &f_cf, 1.0) <= 1e-12, "N = {n}: F {f_ref} vs eq. (7) {f_cf}");
        }
    }
}

/// A cart of mass `mc` slides along the unit axis `a = (cos γ, sin γ)` through the origin (a
/// spring k to x = x₀, a damper c, a force P along the axis), carrying a pendulum (mass m, centre
/// at distance L along its body x, centroidal inertia I, pivot damper c_p) under gravity
/// g = (0, −g). With x the slide and φ the pendulum's angle from the world x axis, Lagrange's
/// method gives, for u = (ẋ, φ̇),
///
/// `M = [[mc + m, m L (a·e_φ')], [m L (a·e_φ'), I + m L²]]` with `e_φ' = (−sin φ, cos φ)`, and
/// `F₀ = m L φ̇² (a·e_φ) − (mc + m) g a_y − k (x − x₀) − c ẋ + P`,
/// `F₁ = −m g L cos φ − c_p φ̇`, with `e_φ = (cos φ, sin φ)`.
#[test]
fn slider_pendulum_equals_lagrange() {
    let (mc, m, l, i, g) = (3.0, 0.7, 0.4, 0.02, 9.81);
    let (k, x0, c, cp, p) = (250.0, 0.1, 1.5, 0.05, 4.0);
    let mut rng = StdRng::seed_from_u64(1);
    for gamma in [0.0, 0.4, -1.1] {
        // The axis is given at length 2 to show it is normalised.
        let axis = (2.0 * f64::cos(gamma), 2.0 * f64::sin(gamma));
        let a = Vec2::new(gamma.cos(), gamma.sin());
        for speeds in [Speeds::JointRates, Speeds::AbsoluteAngularVelocities] {
            let spec = MechanismSpec {
                base: None,
                name: "slider_pendulum".into(),
                speeds,
                gravity: (0.0, -g),
                bodies: vec![body("cart", mc, (0.0, 0.0), 0.1), body("pendulum", m, (l, 0.0), i)],
                joints: vec![
                    JointSpec {
                        spring: Some(Spring { stiffness: k, free_angle: x0 }),
                        damper: Some(c),
                        ..joint("slide", JointKind::Prismatic { axis }, "ground", "cart", (0.0, 0.0))
                    },
                    JointSpec {
                        damper: Some(cp),
                        ..joint("pivot", JointKind::Revolute, "cart", "pendulum", (0.0, 0.0))
                    },
                ],
                loads: vec![LoadSpec::JointTorque { joint: "slide".into(), excitation: Excitation::constant(p) }],
                gears: Vec::new(),
            };
            let mech = Mechanism::from_spec(&spec).unwrap();
            let mut kane = Kane::new(&mech).unwrap();
            for _ in 0..20 {
                let (x, phi): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-3.0..3.0));
                let (xd, phid) = (rng.random_range(-5.0..5.0), rng.random_range(-20.0..20.0));
                let e = Vec2::new(phi.cos(), phi.sin());
                let e_perp = Vec2::new(-phi.sin(), phi.cos());
                let m01 = m * l * a.dot(&e_perp);
                let m_cf = DMatrix::from_row_slice(2, 2, &[mc + m, m01, m01, i + m * l * l]);
                let f_cf = DVector::from_row_slice(&[
                    m * l * phid * phid * a.dot(&e) - (mc + m) * g * a.y - k * (x - x0) - c * xd + p,
                    -m * g * l * phi.cos() - cp * phid,
                ]);
                // The pendulum's joint angle is its world angle (the cart does not turn), and
                // with no rotating joint above it its absolute speed is φ̇ too: u = (ẋ, φ̇).
                let (mk, fk) = kane.mass_matrix_and_forcing(0.0, &[x, phi], &[xd, phid]);
                assert!(rel(mk, &m_cf) <= 1e-12, "γ = {gamma}: M {mk} vs {m_cf}");
                assert!(relv(fk, &f_cf, 1.0) <= 1e-12, "γ = {gamma}: F {fk} vs {f_cf}");
            }
        }
    }
}

/// A rod spinning about ground (inertia J about its axis) carries a bead (mass m, centroidal
/// inertia I_b) on a prismatic joint along the rod's body x axis from radius r₀; the bead's
/// spring k holds it at s = 0. With θ the rod angle and s the slide (r = r₀ + s):
/// `M = [[J + I_b + m r², 0], [0, m]]`, `F = [−2 m r ṡ θ̇ + T, m r θ̇² − k s]`.
/// Under absolute angular velocities the bead (which turns with the rod) has no own rotation
/// coordinate, so u = (θ̇, ṡ) either way.
#[test]
fn bead_on_a_spinning_rod_equals_lagrange() {
    let (j, m, ib, r0, k, torque) = (0.5, 0.3, 0.001, 0.2, 800.0, 2.5);
    let mut rng = StdRng::seed_from_u64(2);
    for speeds in [Speeds::JointRates, Speeds::AbsoluteAngularVelocities] {
        let spec = MechanismSpec {
            base: None,
            name: "bead".into(),
            speeds,
            gravity: (0.0, 0.0),
            bodies: vec![body("rod", 1.0, (0.0, 0.0), j), body("bead", m, (0.0, 0.0), ib)],
            joints: vec![
                joint("spin", JointKind::Revolute, "ground", "rod", (0.0, 0.0)),
                JointSpec {
                    spring: Some(Spring { stiffness: k, free_angle: 0.0 }),
                    ..joint("slide", JointKind::Prismatic { axis: (1.0, 0.0) }, "rod", "bead", (r0, 0.0))
                },
            ],
            loads: vec![LoadSpec::JointTorque { joint: "spin".into(), excitation: Excitation::constant(torque) }],
            gears: Vec::new(),
        };
        let mech = Mechanism::from_spec(&spec).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        for _ in 0..20 {
            let (th, s) = (rng.random_range(-50.0..50.0), rng.random_range(-0.1..0.1));
            let (w, sd) = (rng.random_range(-300.0..300.0), rng.random_range(-3.0..3.0));
            let r = r0 + s;
            let m_cf = DMatrix::from_row_slice(2, 2, &[j + ib + m * r * r, 0.0, 0.0, m]);
            let f_cf = DVector::from_row_slice(&[-2.0 * m * r * sd * w + torque, m * r * w * w - k * s]);
            let (mk, fk) = kane.mass_matrix_and_forcing(0.0, &[th, s], &[w, sd]);
            assert!(rel(mk, &m_cf) <= 1e-12, "M {mk} vs {m_cf}");
            assert!(relv(fk, &f_cf, 1.0) <= 1e-12, "F {fk} vs {f_cf}");
        }
    }
}

/// A rotor with a disc welded off-centre (a fixed joint at an offset, the disc's centre further
/// off) and a pendulum hanging from the disc equals the rotor carrying the disc's inertia merged
/// by the parallel-axis theorem, with the pendulum's pivot moved into the rotor frame; in both
/// speed choices, with gravity, a torque and dampers.
#[test]
fn welded_body_equals_merged_inertia() {
    let (at_w, disc_com, pivot) = ((0.12, -0.05), (0.03, 0.02), (0.08, 0.01));
    let rotor = PlanarInertia::new(4.0, Vec2::new(0.01, 0.0), 0.05);
    let disc = PlanarInertia::new(1.5, Vec2::new(disc_com.0, disc_com.1), 0.004);
    // The disc's inertia moved into the rotor frame (the weld keeps the frames parallel).
    let merged = rotor + PlanarInertia::new(disc.mass, Vec2::new(at_w.0, at_w.1) + disc.com, disc.i_com);
    let pend = body("pendulum", 0.4, (0.1, 0.0), 0.002);
    let loads = vec![
        LoadSpec::JointTorque { joint: "spin".into(), excitation: Excitation::constant(30.0) },
        LoadSpec::GroundDamper { body: "rotor".into(), c: 0.2 },
    ];
    let spin = || JointSpec { damper: Some(0.1), ..joint("spin", JointKind::Revolute, "ground", "rotor", (0.0, 0.0)) };
    let mut rng = StdRng::seed_from_u64(3);
    for speeds in [Speeds::JointRates, Speeds::AbsoluteAngularVelocities] {
        let welded = MechanismSpec {
            base: None,
            name: "welded".into(),
            speeds,
            gravity: (0.3, -9.81),
            bodies: vec![
                body("rotor", rotor.mass, (rotor.com.x, rotor.com.y), rotor.i_com),
                body("disc", disc.mass, disc_com, disc.i_com),
                pend.clone(),
            ],
            joints: vec![
                spin(),
                joint("weld", JointKind::Fixed, "rotor", "disc", at_w),
                JointSpec { damper: Some(0.01), ..joint("pivot", JointKind::Revolute, "disc", "pendulum", pivot) },
            ],
            loads: loads.clone(),
            gears: Vec::new(),
        };
        let merged_spec = MechanismSpec {
            base: None,
            name: "merged".into(),
            bodies: vec![body("rotor", merged.mass, (merged.com.x, merged.com.y), merged.i_com), pend.clone()],
            joints: vec![
                spin(),
                JointSpec {
                    damper: Some(0.01),
                    ..joint("pivot", JointKind::Revolute, "rotor", "pendulum", (at_w.0 + pivot.0, at_w.1 + pivot.1))
                },
            ],
            ..welded.clone()
        };
        let (a, b) = (Mechanism::from_spec(&welded).unwrap(), Mechanism::from_spec(&merged_spec).unwrap());
        assert_eq!((a.ndof(), b.ndof(), a.bodies.len()), (2, 2, 3));
        let (mut ka, mut kb) = (Kane::new(&a).unwrap(), Kane::new(&b).unwrap());
        for _ in 0..20 {
            let q = [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)];
            let u = [rng.random_range(-100.0..100.0), rng.random_range(-100.0..100.0)];
            let (ma, fa) = ka.mass_matrix_and_forcing(0.0, &q, &u);
            let (ma, fa) = (ma.clone(), fa.clone());
            let (mb, fb) = kb.mass_matrix_and_forcing(0.0, &q, &u);
            assert!(rel(&ma, mb) <= 1e-12, "M {ma} vs merged {mb}");
            assert!(relv(&fa, fb, 1.0) <= 1e-12, "F {fa} vs merged {fb}");
            // And the state derivative, which also maps coordinates past the welded body.
            let (mut xa, mut xb) = ([0.0; 4], [0.0; 4]);
            let x = [q[0], q[1], u[0], u[1]];
            ka.rhs(0.0, &x, &mut xa).unwrap();
            kb.rhs(0.0, &x, &mut xb).unwrap();
            for (p, r) in xa.iter().zip(&xb) {
                assert!(abs_diff_eq!(p, r, epsilon = 1e-11 * r.abs().max(1.0)), "ẋ {xa:?} vs merged {xb:?}");
            }
        }
        // The welded body's pose follows its parent's.
        let poses = kanedyn::kane::kinematics::world_poses(&a, &[0.7, 0.0]);
        let expect = rot2(0.7) * Vec2::new(at_w.0, at_w.1);
        assert!((poses[1].origin - expect).norm() < 1e-15);
        assert_abs_diff_eq!(poses[1].angle, 0.7, epsilon = 1e-15);
    }
}

/// Loads `text` as a mechanism file and returns its error message.
fn load_error(text: &str) -> String {
    match Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::unrestricted()) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

const BODIES: &str = r#"bodies: [
        Body(name: "rotor", mass: 1.0, inertia: 0.1),
        Body(name: "arm", mass: 0.5, com: (0.1, 0.0), inertia: 0.01),
    ],"#;

fn with_second_joint(joint: &str, loads: &str) -> String {
    format!(
        "Mechanism(\n    name: \"m\",\n    {BODIES}\n    joints: [\n        Joint(name: \"spin\", parent: \"ground\", child: \"rotor\"),\n        {joint},\n    ],\n    loads: [{loads}],\n)\n"
    )
}

#[test]
fn bad_joint_kinds_are_located_errors() {
    let cases = [
        (
            with_second_joint(
                r#"Joint(name: "slide", kind: Prismatic(axis: (0.0, 0.0)), parent: "rotor", child: "arm")"#,
                "",
            ),
            "m.ron:9:",
            "joints[1].kind.axis",
            "joint `slide`: a prismatic joint needs a finite, non-zero slide axis",
        ),
        (
            with_second_joint(
                r#"Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm", spring: Spring(stiffness: 10.0))"#,
                "",
            ),
            "m.ron:9:",
            "joints[1].spring",
            "joint `weld` is Fixed (welded, no coordinate): it cannot have a spring",
        ),
        (
            with_second_joint(r#"Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm", damper: 0.3)"#, ""),
            "m.ron:9:",
            "joints[1].damper",
            "cannot have a damper",
        ),
        (
            with_second_joint(
                r#"Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm")"#,
                r#"JointTorque(joint: "weld", excitation: (mean: 1.0))"#,
            ),
            "m.ron:11:",
            "loads[0].joint",
            "joint `weld` is Fixed: it has no coordinate for a torque to drive",
        ),
        (
            with_second_joint(r#"Joint(name: "hinge", kind: Helical, parent: "rotor", child: "arm")"#, ""),
            "m.ron:9:",
            "joints[1].kind",
            "Helical",
        ),
    ];
    for (text, at, field, words) in cases {
        let msg = load_error(&text);
        assert!(msg.starts_with(at), "expected at {at}: {msg}\n{text}");
        assert!(msg.contains(&format!("`{field}`")), "expected field {field}: {msg}");
        assert!(msg.contains(words), "expected `{words}`: {msg}");
    }
    // Welding every joint leaves nothing to move.
    let all_fixed = "Mechanism(name: \"m\", bodies: [Body(name: \"b\", mass: 1.0, inertia: 0.1)], joints: [Joint(name: \"w\", kind: Fixed, parent: \"ground\", child: \"b\")])";
    assert!(load_error(all_fixed).contains("no coordinate to move"));
}

/// Every joint kind's columns and bias terms are the derivatives of its own transform.
///
/// `JointKind::motion` returns the child frame's pose (origin, angle) and, separately, the
/// motion columns (∂origin/∂q, ∂angle/∂q) and bias terms (their second derivatives ∂²/∂q²) that
/// the engine's forms use. Here each column is held against a fourth-order central difference of
/// the pose, and each bias term against the same difference of the columns, at several
/// coordinates of every kind (each path shape mounted at a skew angle, and a path's rollers).
/// The difference's truncation error is O(h⁴)·|f⁽⁵⁾| ≈ 1e-15 at h = 1e-3 of the coordinate's
/// scale and its rounding ≈ 1e-16/h ≈ 1e-13 relative: 1e-9 relative to the quantity's scale
/// leaves room for both and fails on any wrong sign, factor or missing term.
#[test]
fn every_kind_s_columns_and_bias_are_the_derivatives_of_its_transform() {
    use kanedyn::model::joint::JointMotion;
    use kanedyn::model::path::{PathShape, Rollers};

    // Adding a kind breaks this match: give it samples below.
    let covered = |k: JointKind| match k {
        JointKind::Revolute | JointKind::Prismatic { .. } | JointKind::Fixed | JointKind::Path { .. } => (),
    };
    let path = |shape| JointKind::Path { shape, mount: 0.7, travel: None };
    let kinds = [
        JointKind::Revolute,
        JointKind::Prismatic { axis: (0.6, -0.8) },
        JointKind::Fixed,
        path(PathShape::Circle { radius: 0.17, length: 0.0152 }),
        path(PathShape::Bifilar { radius: 0.17, length: 0.0152 }),
        path(PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 0.0 }),
        path(PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 10.0 }),
        path(PathShape::general(0.185, 3.11, &[100.0], &[1.0])),
    ];
    let at = Vec2::new(0.03, -0.02);
    let angle = |m: &JointMotion| m.sin.atan2(m.cos);
    // f(q + kh) for k = -2..=2 into the fourth-order central difference.
    let d4 = |f: &dyn Fn(f64) -> [f64; 3], q: f64, h: f64| -> [f64; 3] {
        let (a, b, c, d) = (f(q - 2.0 * h), f(q - h), f(q + h), f(q + 2.0 * h));
        std::array::from_fn(|i| (a[i] - 8.0 * b[i] + 8.0 * c[i] - d[i]) / (12.0 * h))
    };
    let mut checked = 0;
    for kind in kinds {
        covered(kind);
        let scale = kind.coordinate_scale();
        let travel = kind.travel().min(10.0 * scale);
        let pose_scale = 0.2_f64.max(at.norm());
        let mut motions: Vec<Box<dyn Fn(f64) -> JointMotion>> = vec![Box::new(move |q| kind.motion(at, q))];
        if let Some(p) = kind.path()
            && !p.shape.turns()
        {
            let rollers = Rollers { count: 2, mass: 0.1, inertia: 1e-5, radius: 0.006, spread: 0.0 };
            let centre = Rollers::vertex_centre(p.shape);
            motions.push(Box::new(move |q| kind.roller_motion(at, q, centre, rollers.turn_rate())));
        }
        for motion in &motions {
            for f in [-0.6, -0.1, 0.0, 0.35, 0.8] {
                let q = f * travel;
                let h = 1e-3 * scale;
                let m = motion(q);
                let pose = |q: f64| {
                    let m = motion(q);
                    // Unwrapped against the angle at q, so the difference never crosses ±π.
                    let a = angle(&m);
                    let a0 = angle(&motion(q - 1e-9));
                    [
                        m.origin.x,
                        m.origin.y,
                        a0 + (a - a0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI,
                    ]
                };
                let columns = |q: f64| {
                    let m = motion(q);
                    [m.velocity.x, m.velocity.y, m.omega]
                };
                let (dp, dc) = (d4(&pose, q, h), d4(&columns, q, h));
                let col = [m.velocity.x, m.velocity.y, m.omega];
                let bias = [m.bias_acc.x, m.bias_acc.y, m.bias_alpha];
                let col_scale = 1.0_f64.max(pose_scale / scale);
                let bias_scale = col_scale / scale;
                for i in 0..3 {
                    assert!(
                        abs_diff_eq!(col[i], dp[i], epsilon = 1e-9 * col_scale),
                        "{} at q = {q}: column {i} {} vs difference {}",
                        kind.name(),
                        col[i],
                        dp[i]
                    );
                    assert!(
                        abs_diff_eq!(bias[i], dc[i], epsilon = 1e-9 * bias_scale),
                        "{} at q = {q}: bias {i} {} vs difference {}",
                        kind.name(),
                        bias[i],
                        dc[i]
                    );
                }
                checked += 1;
            }
        }
    }
    // 8 kinds and 2 roller sets (on the bifilar and the plain epicycloid, the paths that do not
    // turn their body), 5 coordinates each.
    assert_eq!(checked, 50);
}
