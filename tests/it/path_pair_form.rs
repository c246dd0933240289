//! The pair form of a rotor carrying one path absorber (`Model::rhs_path_pair` in
//! `src/kane/path_pair.rs`, issue 14's speed criterion) against the general composite-body
//! form: on seeded random rotors with every path kind, rotation laws, mounting angles, springs,
//! dampers, ground dampers and excitation torques on either joint, ẋ agrees to rounding, and
//! beyond the end of the path (or a travel limit, or at a NaN) both fail with the same error.
//!
//! The reference is the same mechanism with a zero point force added on the rotor, which keeps
//! the engine on its general form (point forces are outside every fixed-size form); that form is
//! itself checked against Lagrange's equations and Kane's sums body by body in
//! `tests/it/random_trees.rs`.

use kanedyn::kane::Kane;
use kanedyn::model::body::BodySpec;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::joint::{JointKind, JointSpec, Spring};
use kanedyn::model::loads::{ForceFrame, LoadSpec};
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::path::PathShape;
use kanedyn::model::speeds::Speeds;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A random path of each kind in turn (`k % 4`): circle, bifilar, epicycloid (with a rotation
/// law every other time) or a general polynomial path with a cubic rotation law.
fn random_shape(k: u64, rng: &mut StdRng) -> PathShape {
    match k % 4 {
        0 => PathShape::Circle { radius: rng.random_range(0.05..0.3), length: rng.random_range(0.01..0.1) },
        1 => PathShape::Bifilar { radius: rng.random_range(0.05..0.3), length: rng.random_range(0.01..0.1) },
        2 => PathShape::Epicycloid {
            rho0: rng.random_range(0.05..0.3),
            n_tilde: rng.random_range(0.5..5.0),
            alpha1: if k % 8 == 2 { rng.random_range(-50.0..50.0) } else { 0.0 },
        },
        _ => {
            // x₄ a fraction of the quadratic term at the epicycloid's end, as in random_trees.rs.
            let (rho0, n): (f64, f64) = (rng.random_range(0.05..0.3), rng.random_range(0.5..5.0));
            let s_epi2 = rho0 * rho0 / (n * n * (1.0 + n * n));
            let x4 = rng.random_range(-0.3..0.3) * n * n / s_epi2;
            PathShape::general(rho0, n, &[x4], &[rng.random_range(-50.0..50.0), rng.random_range(-500.0..500.0)])
        }
    }
}

/// A rotor (any centre of mass) on a revolute joint, carrying one absorber (centre of mass at
/// its frame origin) on a path drawn about the rotor axis: the tree the pair form serves. With
/// `limit`, the joint gets a travel limit of that fraction of the path's end (of L for a circle).
fn rotor_spec(seed: u64, limit: Option<f64>) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let shape = random_shape(seed, &mut rng);
    let end = if shape.travel().is_finite() { shape.travel() } else { shape.length_scale() };
    let travel = limit.map(|f| f * end);
    let excitation = |rng: &mut StdRng| Excitation {
        mean: rng.random_range(-5.0..5.0),
        rpm: rng.random_range(500.0..3000.0),
        order: Order::Fixed(rng.random_range(1.0..4.0)),
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: rng.random_range(0.0..50.0), phase: 0.3 }],
        ramp_s: 0.0,
    };
    let mut loads = Vec::new();
    for (body, joint) in [("rotor", "spin"), ("absorber", "path")] {
        if rng.random_bool(0.5) {
            loads.push(LoadSpec::GroundDamper { body: body.into(), c: rng.random_range(0.0..0.1) });
        }
        if rng.random_bool(0.6) {
            loads.push(LoadSpec::JointTorque { joint: joint.into(), excitation: excitation(&mut rng) });
        }
    }
    let joint = |name: &str, parent: &str, child: &str, kind: JointKind, rng: &mut StdRng| JointSpec {
        name: Some(name.into()),
        kind: Some(kind),
        parent: Some(parent.into()),
        child: Some(child.into()),
        at: Some((0.0, 0.0)),
        spring: rng
            .random_bool(0.4)
            .then(|| Spring { stiffness: rng.random_range(0.0..100.0), free_angle: rng.random_range(-0.01..0.01) }),
        damper: rng.random_bool(0.5).then(|| rng.random_range(0.0..0.5)),
        ..JointSpec::default()
    };
    let mount = rng.random_range(-3.0..3.0);
    let joints = vec![
        joint("spin", "ground", "rotor", JointKind::Revolute, &mut rng),
        joint("path", "rotor", "absorber", JointKind::Path { shape, mount, travel }, &mut rng),
    ];
    let bodies = vec![
        BodySpec {
            name: Some("rotor".into()),
            mass: Some(rng.random_range(1.0..50.0)),
            com: Some((rng.random_range(-0.01..0.01), rng.random_range(-0.01..0.01))),
            inertia: Some(rng.random_range(0.05..5.0)),
            ..BodySpec::default()
        },
        BodySpec {
            name: Some("absorber".into()),
            mass: Some(rng.random_range(0.1..10.0)),
            com: Some((0.0, 0.0)),
            inertia: if rng.random_bool(0.2) { None } else { Some(rng.random_range(1e-5..1e-2)) },
            ..BodySpec::default()
        },
    ];
    MechanismSpec {
        base: None,
        name: format!("rotor{seed}"),
        speeds: Speeds::AbsoluteAngularVelocities,
        gravity: (0.0, 0.0),
        bodies,
        joints,
        loads,
        gears: Vec::new(),
    }
}

/// The engine on `spec` (the pair form) and on `spec` with a zero point force on the rotor (the
/// general form).
fn engines(spec: &MechanismSpec) -> (Kane, Kane) {
    let mut general = spec.clone();
    general.loads.push(LoadSpec::PointForce {
        body: "rotor".into(),
        at: (0.1, 0.0),
        force: (0.0, 0.0),
        frame: ForceFrame::Body,
    });
    let build = |s: &MechanismSpec| Kane::new(&Mechanism::from_spec(s).unwrap()).unwrap();
    (build(spec), build(&general))
}

/// The difference of two right-hand sides at state `x` on `shape`, relative to the size of the
/// terms they are made of: the absorber's accelerations `u̇₁` and `ρ u̇₀` (m/s²) against the
/// largest of them and of the velocity-product acceleration of the absorber's centre,
/// `ω²ρ + 2|ωṡ| + ṡ²|κ|`.
///
/// NOTE: relative to |u̇| alone would be wrong near equilibrium: where r·t ≈ 0 (the vertex) the
/// general form's F₁ = t·(m ω² r + …) is a cancellation of terms of size m ω² ρ (its rounding,
/// ε m ω² ρ, is not an error of the pair form's, which gets m ω² (r·t) = −m ω² ñ² s from s).
fn difference(x: &[f64; 4], xp: &[f64; 4], xg: &[f64; 4], shape: PathShape) -> f64 {
    let at = shape.at(x[1]);
    let (rho, kappa) = (at.position.norm(), at.curvature.norm());
    let (w, sd) = (x[2], x[3]);
    let accel = w * w * rho + 2.0 * (w * sd).abs() + sd * sd * kappa;
    let scale = accel.max((rho * xg[2]).abs()).max(xg[3].abs());
    (rho * (xp[2] - xg[2])).abs().max((xp[3] - xg[3]).abs()) / scale
}

/// Both forms agree to rounding at random states (arc length within 95 % of the travel, or
/// ±2 rad of a circle's arm; speeds up to 300 rad/s and the matching path speeds).
///
/// Tolerance: both forms build M and F from the same data in O(10) roundings per entry, but
/// not the same ones: the general form sums vector components as large as the largest
/// acceleration term, this form rotation-invariant products. With ε = 2.2e-16, ~10ε of the
/// largest term, passed through the 2 × 2 solve of these well-conditioned rotor-absorber pairs
/// (the absorber's inertia a small part of the rotor's), stays below 2e-14 in the measure of
/// [`difference`]; the measured worst is printed.
#[test]
fn pair_form_equals_the_composite_body_form_on_random_rotors() {
    let (mut states, mut differ) = (0, 0);
    let mut worst: f64 = 0.0;
    for seed in 0..200 {
        let mut differ_here = 0;
        let spec = rotor_spec(seed, None);
        let (mut pair, mut general) = engines(&spec);
        let shape = match spec.joints[1].kind {
            Some(JointKind::Path { shape, .. }) => shape,
            _ => unreachable!(),
        };
        let reach = if shape.travel().is_finite() { 0.95 * shape.travel() } else { 2.0 * shape.length_scale() };
        let mut rng = StdRng::seed_from_u64(9000 + seed);
        for _ in 0..25 {
            let s = rng.random_range(-1.0..1.0) * reach;
            let omega = rng.random_range(-300.0..300.0);
            let x = [rng.random_range(-10.0..10.0), s, omega, rng.random_range(-1.0..1.0) * 0.5 * omega * reach];
            let t = rng.random_range(0.0..10.0);
            let (mut xp, mut xg) = ([0.0; 4], [0.0; 4]);
            pair.rhs(t, &x, &mut xp).unwrap();
            general.rhs(t, &x, &mut xg).unwrap();
            assert_eq!(xp[..2], xg[..2], "rotor {seed}: q̇");
            let err = difference(&x, &xp, &xg, shape);
            assert!(err <= 2e-14, "rotor {seed} ({shape:?}) at {x:?}: u̇ {xp:?} vs {xg:?} (rel {err:e})");
            worst = worst.max(err);
            states += 1;
            differ_here += usize::from(xp != xg);
        }
        // The composite-body instance equals the general form to the bit (random_trees.rs); the
        // pair form's other arithmetic shows in the last bits of some state of every rotor,
        // which is how this test knows that the pair form was chosen for each.
        assert!(differ_here > 0, "rotor {seed}: every state identical to the bit: is the pair form chosen?");
        differ += differ_here;
    }
    println!("pair form vs composite-body form: {states} states, {differ} not identical to the bit, worst {worst:e}");
}

/// At and beyond the end of the path, beyond a travel limit, and at a NaN arc length, the pair
/// form reports what the general form reports (`OutOfTravel` naming the joint, or the pivot
/// error), and inside a travel limit it agrees as before.
#[test]
fn pair_form_fails_as_the_general_form_off_the_path() {
    for seed in 0..40 {
        let spec = rotor_spec(seed, (seed % 2 == 1).then_some(0.6));
        let (mut pair, mut general) = engines(&spec);
        let (shape, end) = match spec.joints[1].kind {
            Some(JointKind::Path { shape, travel, .. }) => (shape, travel.unwrap_or(shape.travel())),
            _ => unreachable!(),
        };
        let mut offs = vec![f64::NAN, f64::INFINITY];
        if end.is_finite() {
            offs.extend([end, -end, 1.01 * end, -3.0 * end]);
        }
        for s in offs {
            let x = [0.2, s, 100.0, 0.01];
            let (mut xp, mut xg) = ([0.0; 4], [0.0; 4]);
            let (ep, eg) = (pair.rhs(0.1, &x, &mut xp), general.rhs(0.1, &x, &mut xg));
            assert!(ep.is_err(), "rotor {seed} at s = {s}: {xp:?}");
            assert_eq!(format!("{ep:?}"), format!("{eg:?}"), "rotor {seed} at s = {s}");
        }
        if end.is_finite() {
            let x = [0.2, 0.9 * end, 100.0, 0.01];
            let (mut xp, mut xg) = ([0.0; 4], [0.0; 4]);
            pair.rhs(0.1, &x, &mut xp).unwrap();
            general.rhs(0.1, &x, &mut xg).unwrap();
            assert!(difference(&x, &xp, &xg, shape) <= 2e-14, "rotor {seed}");
        }
    }
}

/// The benchmark's mechanism, examples/cpva_epicycloid.ron, at the benchmark's state and across
/// its travel: the pair form agrees with the general form to 2e-14 (see above).
#[test]
fn pair_form_on_the_epicycloid_cpva_example() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva_epicycloid.ron");
    let mech = Mechanism::from_file(&file).unwrap();
    let mut pair = Kane::new(&mech).unwrap();
    let mut general = Kane::new_world_frame(&mech).unwrap();
    let JointKind::Path { shape, .. } = mech.joints[1].kind else { panic!("the path joint") };
    let travel = shape.travel();
    for f in [-0.99, -0.5, 0.0, 0.33, 0.8, 0.99] {
        let x = [1234.5, f * travel, 104.9, 0.05];
        let (mut xp, mut xg) = ([0.0; 4], [0.0; 4]);
        pair.rhs(0.7, &x, &mut xp).unwrap();
        general.rhs(0.7, &x, &mut xg).unwrap();
        let err = difference(&x, &xp, &xg, shape);
        assert!(err <= 2e-14, "s = {f} s_max: {xp:?} vs {xg:?} (rel {err:e})");
    }
}
