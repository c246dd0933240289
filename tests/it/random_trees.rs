//! Invariants of the engine on seeded random trees (up to 10 bodies, random branching, offsets,
//! masses, inertias, gravity, springs, dampers and point forces): revolute trees, and trees that
//! mix revolute, prismatic and fixed joints. Each is checked against an independent route:
//! world-frame velocity recursion, finite differences of positions, Lagrange's equations by
//! numeric differentiation of the kinetic and potential energy, and Kane's sums body by body
//! (`kane::reference`) for the fast forms.

use approx::assert_abs_diff_eq;
use kanedyn::error::EngineError;
use kanedyn::kane::Kane;
use kanedyn::kane::kinematics::{kinetic_energy, potential_energy, world_poses, world_velocities};
use kanedyn::kane::reference;
use kanedyn::model::body::BodySpec;
use kanedyn::model::coupling::Friction;
use kanedyn::model::excitation::{Excitation, Harmonic, Order};
use kanedyn::model::joint::{JointKind, JointSpec, Spring};
use kanedyn::model::loads::{ForceFrame, LoadSpec};
use kanedyn::model::math::{Vec2, rot2};
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::path::PathShape;
use kanedyn::model::path::Rollers;
use kanedyn::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const TREES: u64 = 60;

/// Seeds at or above this make trees that mix the joint kinds.
const MIXED: u64 = 1000;

/// Seeds at or above this make mixed trees in which path joints (issue 14) also appear.
const PATHS: u64 = 2000;

/// The seeds of every test: 60 revolute trees, 60 mixed ones and 60 mixed with path joints.
fn seeds() -> impl Iterator<Item = u64> {
    (0..TREES).chain(MIXED..MIXED + TREES).chain(PATHS..PATHS + TREES)
}

/// A random absorber path: circle, bifilar, epicycloid (with a rotation law half the time) or a
/// general polynomial path with a cubic rotation law, mounted at a random angle.
fn random_path(rng: &mut StdRng) -> JointKind {
    let shape = match rng.random_range(0..4) {
        0 => PathShape::Circle { radius: rng.random_range(0.1..1.0), length: rng.random_range(0.2..1.0) },
        1 => PathShape::Bifilar { radius: rng.random_range(0.1..1.0), length: rng.random_range(0.2..1.0) },
        2 => PathShape::Epicycloid {
            rho0: rng.random_range(0.3..1.0),
            n_tilde: rng.random_range(0.5..3.0),
            alpha1: if rng.random_bool(0.5) { rng.random_range(-2.0..2.0) } else { 0.0 },
        },
        3 => {
            // x₄ of either sign, scaled so that the quartic term is a fraction of the quadratic
            // one at the epicycloid's end (the path stays a path well past the drawn states).
            let (rho0, n): (f64, f64) = (rng.random_range(0.3..1.0), rng.random_range(0.5..3.0));
            let s_epi2 = rho0 * rho0 / (n * n * (1.0 + n * n));
            let x4 = rng.random_range(-0.3..0.3) * n * n / s_epi2;
            let alpha = [rng.random_range(-2.0..2.0), rng.random_range(-5.0..5.0)];
            PathShape::general(rho0, n, &[x4], &alpha)
        }
        _ => unreachable!(),
    };
    JointKind::Path { shape, mount: rng.random_range(-3.0..3.0), travel: None }
}

fn random_tree(seed: u64) -> Mechanism {
    Mechanism::from_spec(&random_spec(seed)).unwrap()
}

fn random_spec(seed: u64) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let mixed = seed >= MIXED;
    let paths = seed >= PATHS;
    let n = rng.random_range(1..=10);
    let name = |i: usize| format!("b{i}");
    let mut bodies = Vec::new();
    let mut joints = Vec::new();
    let mut loads = Vec::new();
    for i in 0..n {
        let point_mass = rng.random_bool(0.2);
        bodies.push(BodySpec {
            name: Some(name(i)),
            mass: Some(rng.random_range(0.1..10.0)),
            com: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            inertia: if point_mass { None } else { Some(rng.random_range(0.01..1.0)) },
            ..BodySpec::default()
        });
        // Roughly one tree in five has a second root on ground.
        let parent = if i == 0 || rng.random_bool(0.1) { "ground".to_string() } else { name(rng.random_range(0..i)) };
        // Mixed trees: a fifth of the joints slide along a random (not unit) axis, a sixth are
        // welded; in path trees a quarter follow a random absorber path; the first joint always has a
        // coordinate.
        let kind = match rng.random_range(0.0..1.0) {
            x if mixed && x < 0.2 => {
                JointKind::Prismatic { axis: (rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)) }
            }
            x if mixed && i > 0 && x > 5.0 / 6.0 => JointKind::Fixed,
            x if paths && x < 0.45 => random_path(&mut rng),
            _ => JointKind::Revolute,
        };
        let moves = kind != JointKind::Fixed;
        joints.push(JointSpec {
            name: Some(format!("j{i}")),
            kind: mixed.then_some(kind),
            parent: Some(parent),
            child: Some(name(i)),
            at: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            spring: (rng.random_bool(0.5) && moves)
                .then(|| Spring { stiffness: rng.random_range(0.0..50.0), free_angle: rng.random_range(-1.0..1.0) }),
            damper: (rng.random_bool(0.5) && moves).then(|| rng.random_range(0.0..2.0)),
            ..JointSpec::default()
        });
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::GroundDamper { body: name(i), c: rng.random_range(0.0..1.0) });
        }
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::PointForce {
                body: name(i),
                at: (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)),
                force: (rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)),
                frame: if rng.random_bool(0.5) { ForceFrame::World } else { ForceFrame::Body },
            });
        }
        if rng.random_bool(0.3) && moves {
            loads.push(LoadSpec::JointTorque {
                joint: format!("j{i}"),
                excitation: Excitation::constant(rng.random_range(-5.0..5.0)),
            });
        }
    }
    let gravity =
        if rng.random_bool(0.7) { (rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0)) } else { (0.0, 0.0) };
    let speeds = if rng.random_bool(0.5) { Speeds::JointRates } else { Speeds::AbsoluteAngularVelocities };
    MechanismSpec { base: None, name: format!("tree{seed}"), speeds, gravity, bodies, joints, loads, gears: Vec::new() }
}

fn random_state(mech: &Mechanism, rng: &mut StdRng) -> (Vec<f64>, Vec<f64>) {
    let n = mech.ndof();
    // A path's arc length is drawn inside 90 % of its travel (of ±3 m for a circle): the same
    // draw, scaled, so the other trees keep their states.
    let q = (0..n)
        .map(|k| {
            let x = rng.random_range(-3.0..3.0);
            let travel = mech.joints[mech.joint_of(k)].kind.travel();
            if travel.is_finite() { 0.3 * x * travel } else { x }
        })
        .collect();
    let u = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
    (q, u)
}

fn qdot_of(mech: &Mechanism, u: &[f64]) -> Vec<f64> {
    let mut qd = vec![0.0; u.len()];
    mech.speeds.qdot(&mech.speed_parents(), u, &mut qd);
    qd
}

#[test]
fn mass_matrix_is_symmetric_positive_definite_and_gives_kinetic_energy() {
    let mut worst: f64 = 0.0;
    for seed in seeds() {
        let mech = random_tree(seed);
        let mut kane = Kane::new(&mech).unwrap();
        let mut rng = StdRng::seed_from_u64(1000 + seed);
        for _ in 0..10 {
            let (q, u) = random_state(&mech, &mut rng);
            let m = kane.mass_matrix(&q).clone();
            assert!((&m - m.transpose()).amax() == 0.0, "tree {seed}: M not symmetric");
            let eig = m.clone().symmetric_eigen().eigenvalues;
            assert!(eig.min() > 0.0, "tree {seed}: M has eigenvalue {}", eig.min());
            let uv = DVector::from_column_slice(&u);
            let t_kane = 0.5 * (uv.transpose() * &m * &uv)[0];
            let t_bodies = kinetic_energy(&mech, &q, &qdot_of(&mech, &u));
            let rel = (t_kane - t_bodies).abs() / t_bodies;
            worst = worst.max(rel);
            assert!(rel < 1e-12, "tree {seed}: ½uᵀMu = {t_kane}, Σ bodies = {t_bodies}");
        }
    }
    println!("largest relative kinetic-energy difference: {worst:e}");
}

#[test]
fn partial_velocities_equal_finite_differences_of_body_velocities() {
    let mut worst: f64 = 0.0;
    for seed in seeds() {
        let mech = random_tree(seed);
        let kane = Kane::new_world_frame(&mech).unwrap();
        let mut rng = StdRng::seed_from_u64(2000 + seed);
        let (q, u) = random_state(&mech, &mut rng);
        let n = mech.ndof();
        // The velocity recursion itself is checked against positions: v ≈ Δr/Δt along q̇.
        let qd = qdot_of(&mech, &u);
        let h = 1e-6;
        let qp: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + h * b).collect();
        let qm: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a - h * b).collect();
        let (pp, pm) = (world_poses(&mech, &qp), world_poses(&mech, &qm));
        let vel = world_velocities(&mech, &q, &qd);
        let nb = mech.bodies.len();
        for j in 0..nb {
            let v_fd = (pp[j].com - pm[j].com) / (2.0 * h);
            let w_fd = (pp[j].angle - pm[j].angle) / (2.0 * h);
            assert!((v_fd - vel[j].1).norm() < 1e-6 * (1.0 + vel[j].1.norm()), "tree {seed} body {j}: velocity");
            assert_abs_diff_eq!(w_fd, vel[j].0, epsilon = 1e-6 * (1.0 + vel[j].0.abs()));
        }
        // ∂v_j/∂u_r by central differences in u (exact up to rounding: v is linear in u).
        for j in 0..nb {
            let (pv, pw) = kane.partial_velocities(&q, j);
            for r in 0..n {
                let mut up = u.clone();
                let mut um = u.clone();
                up[r] += 0.5;
                um[r] -= 0.5;
                let vp = world_velocities(&mech, &q, &qdot_of(&mech, &up));
                let vm = world_velocities(&mech, &q, &qdot_of(&mech, &um));
                let dv = vp[j].1 - vm[j].1;
                let dw = vp[j].0 - vm[j].0;
                let err = (dv - pv[r]).norm() + (dw - pw[r]).abs();
                worst = worst.max(err);
                assert!(err < 1e-12, "tree {seed}: ∂v_{j}/∂u_{r} = {:?}, finite difference {:?}", pv[r], dv);
            }
        }
    }
    println!("largest partial-velocity difference: {worst:e}");
}

/// Generalized forces in joint-rate space by Lagrange's equations, from the energies only:
/// `Q = −d/dt(∂T/∂q̇)|_{q̈=0} + ∂T/∂q − ∂V/∂q + Q_nc`.
fn lagrange_forcing(mech: &Mechanism, t: f64, q: &[f64], qd: &[f64]) -> DVector<f64> {
    let n = q.len();
    // The step resolves the shortest length over which the kinematics change: 1 rad, 1 m, or a
    // path's length scale (an epicycloid of a few cm ends within its travel; with 1e-5 m and
    // rates of 5 m/s, the truncation error would reach 1e-6 there).
    let scale = mech.joints.iter().map(|j| j.kind.coordinate_scale()).fold(1.0, f64::min);
    let h = 1e-5 * scale;
    let t_of = |q: &[f64], qd: &[f64]| kinetic_energy(mech, q, qd);
    // ∂T/∂q̇ by central differences (T is quadratic in q̇, so exact up to rounding).
    let dt_dqd = |q: &[f64], qd: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let mut a = qd.to_vec();
                let mut b = qd.to_vec();
                a[k] += 0.5;
                b[k] -= 0.5;
                t_of(q, &a) - t_of(q, &b)
            })
            .collect()
    };
    let qp: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a + h * b).collect();
    let qm: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a - h * b).collect();
    let (pp, pm) = (dt_dqd(&qp, qd), dt_dqd(&qm, qd));
    let mut out = DVector::zeros(n);
    for k in 0..n {
        let mut a = q.to_vec();
        let mut b = q.to_vec();
        a[k] += h;
        b[k] -= h;
        let dt_dq = (t_of(&a, qd) - t_of(&b, qd)) / (2.0 * h);
        let dv_dq = (potential_energy(mech, &a) - potential_energy(mech, &b)) / (2.0 * h);
        out[k] = -(pp[k] - pm[k]) / (2.0 * h) + dt_dq - dv_dq;
    }
    // Non-conservative generalized forces, each by its virtual power along e_k in q̇.
    let poses = world_poses(mech, q);
    let vel = world_velocities(mech, q, qd);
    for k in 0..n {
        let mut e = vec![0.0; n];
        e[k] = 1.0;
        let ve = world_velocities(mech, q, &e);
        let joint = mech.joint_of(k);
        out[k] -= mech.joints[joint].damper * qd[k];
        for g in &mech.loads.ground_dampers {
            out[k] -= g.c * vel[g.body].0 * ve[g.body].0;
        }
        for pf in &mech.loads.point_forces {
            let b = pf.body;
            let arm = rot2(poses[b].angle) * pf.at + poses[b].origin - poses[b].com;
            let f = match pf.frame {
                ForceFrame::World => pf.force,
                ForceFrame::Body => rot2(poses[b].angle) * pf.force,
            };
            let v_point = ve[b].1 + ve[b].0 * Vec2::new(-arm.y, arm.x);
            out[k] += f.dot(&v_point);
        }
        for jt in &mech.loads.joint_torques {
            if jt.joint == joint {
                out[k] += jt.excitation.torque(t);
            }
        }
    }
    out
}

#[test]
fn forcing_agrees_with_lagrange_route() {
    let mut worst: f64 = 0.0;
    for seed in seeds() {
        let mech = random_tree(seed);
        let mut kane = Kane::new(&mech).unwrap();
        let mut rng = StdRng::seed_from_u64(3000 + seed);
        let (q, u) = random_state(&mech, &mut rng);
        let qd = qdot_of(&mech, &u);
        let f = kane.forcing(0.0, &q, &u).clone();
        // Kane's F in the mechanism's speeds equals W⁻ᵀ Q_rates: compare in joint-rate space,
        // F_rates = Wᵀ F_u.
        let w = mech.speeds.w_matrix(&mech.speed_parents());
        let f_rates = w.transpose() * f;
        let f_lag = lagrange_forcing(&mech, 0.0, &q, &qd);
        let scale = f_lag.amax().max(1.0);
        let err = (&f_rates - &f_lag).amax() / scale;
        worst = worst.max(err);
        assert!(err <= 1e-7, "tree {seed}: Kane {f_rates:?} vs Lagrange {f_lag:?} (rel {err:e})");
    }
    println!("largest relative difference to the Lagrange route: {worst:e}");
}

#[test]
fn rhs_solves_m_udot_equals_f() {
    for seed in seeds() {
        let mech = random_tree(seed);
        let mut kane = Kane::new(&mech).unwrap();
        let mut rng = StdRng::seed_from_u64(4000 + seed);
        let (q, u) = random_state(&mech, &mut rng);
        let n = mech.ndof();
        let x: Vec<f64> = q.iter().chain(&u).copied().collect();
        let mut xd = vec![0.0; 2 * n];
        kane.rhs(0.0, &x, &mut xd).unwrap();
        let (m, f) = kane.mass_matrix_and_forcing(0.0, &q, &u);
        let (m, f): (DMatrix<f64>, DVector<f64>) = (m.clone(), f.clone());
        let resid = &m * DVector::from_column_slice(&xd[n..]) - &f;
        assert!(resid.amax() <= 1e-10 * f.amax().max(1.0), "tree {seed}: residual {}", resid.amax());
        assert_eq!(&xd[..n], &qdot_of(&mech, &u)[..]);
    }
}

/// The fixed-size right-hand side of small trees (`kane::small`: absolute speeds on a revolute
/// tree of at most six speeds, no point forces) against the general pair form's, which the same
/// mechanism takes with one point force of zero magnitude (it adds exact zeros): the random
/// revolute trees recast to absolute speeds without their point forces, with an order
/// excitation set on one joint after construction, in the engine's basis and the world frame.
/// Both sum the same terms in the same order and solve by the same LDLᵀ, so they agree to the
/// bit, except that with joint torques listed out of joint order the small path still sums them
/// by joint (a rounding difference); each leaves a residual at rounding level, and a NaN angle
/// fails alike in both.
#[test]
fn small_tree_rhs_equals_the_general_path() {
    let mut worst: f64 = 0.0;
    let (mut trees, mut identical) = (0, 0);
    for seed in 0..TREES {
        let mut spec = random_spec(seed);
        spec.speeds = Speeds::AbsoluteAngularVelocities;
        spec.loads.retain(|l| !matches!(l, LoadSpec::PointForce { .. }));
        if spec.joints.len() > 6 {
            continue;
        }
        trees += 1;
        let small = Mechanism::from_spec(&spec).unwrap();
        spec.loads.push(LoadSpec::PointForce {
            body: "b0".into(),
            at: (0.3, -0.2),
            force: (0.0, 0.0),
            frame: ForceFrame::World,
        });
        let general = Mechanism::from_spec(&spec).unwrap();
        let n = small.ndof();
        let mut rng = StdRng::seed_from_u64(6000 + seed);
        let excitation = Excitation {
            mean: 1.5,
            rpm: 1000.0,
            order: Order::Fixed(3.0),
            harmonics: vec![Harmonic { multiple: 1.0, amplitude: 4.0, phase: 0.3 }],
            ramp_s: 0.0,
        };
        let joint = rng.random_range(0..n);
        for world in [false, true] {
            let build = |m: &Mechanism| if world { Kane::new_world_frame(m) } else { Kane::new(m) }.unwrap();
            let (mut ks, mut kg) = (build(&small), build(&general));
            ks.set_joint_torque(joint, excitation.clone());
            kg.set_joint_torque(joint, excitation.clone());
            for _ in 0..3 {
                let (q, u) = random_state(&small, &mut rng);
                let t = rng.random_range(0.0..10.0);
                let x: Vec<f64> = q.iter().chain(&u).copied().collect();
                let (mut xs, mut xg) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
                ks.rhs(t, &x, &mut xs).unwrap();
                kg.rhs(t, &x, &mut xg).unwrap();
                let torques: Vec<usize> = ks.joint_torques().iter().map(|t| t.joint).collect();
                if torques.is_sorted() {
                    assert_eq!(xs, xg, "tree {seed}");
                    identical += 1;
                }
                assert_eq!(&xs[..n], &xg[..n], "tree {seed}: q̇");
                let (m, f) = ks.mass_matrix_and_forcing(t, &q, &u);
                let resid = m * DVector::from_column_slice(&xs[n..]) - f;
                assert!(resid.amax() <= 1e-12 * f.amax().max(m.amax()), "tree {seed}: residual {}", resid.amax());
                let scale = xg[n..].iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let err = xs[n..].iter().zip(&xg[n..]).fold(0.0f64, |a, (s, g)| a.max((s - g).abs())) / scale;
                worst = worst.max(err);
                assert!(err <= 1e-12, "tree {seed}: u̇ {:?} vs {:?} (rel {err:e})", &xs[n..], &xg[n..]);
                // A NaN angle fails (or not) alike, naming the same speed.
                let mut x = x;
                x[n - 1] = f64::NAN;
                let (es, eg) = (ks.rhs(t, &x, &mut xs), kg.rhs(t, &x, &mut xg));
                assert_eq!(format!("{es:?}"), format!("{eg:?}"), "tree {seed}");
            }
        }
    }
    println!(
        "small-tree rhs vs the general path: {trees} trees, {identical} states identical to the bit, worst relative difference {worst:e}"
    );
    assert!(trees >= 20 && identical >= 100);
}

/// The fast forms (the pair form for absolute speeds on revolute trees, the composite-body form
/// for joint rates, the mapped composite-body form for absolute speeds on mixed trees) against
/// Kane's sums written body by body in `kane::reference`, M and F, in the engine's own basis and
/// in the world frame. Both routes sum the same terms in another order, so they agree to
/// rounding: 1e-12 relative to the largest entry leaves two to three decades of margin.
#[test]
fn fast_forms_equal_the_reference() {
    let mut worst: f64 = 0.0;
    for seed in seeds() {
        let mech = random_tree(seed);
        let mut rng = StdRng::seed_from_u64(5000 + seed);
        for world in [false, true] {
            let mut kane = if world { Kane::new_world_frame(&mech) } else { Kane::new(&mech) }.unwrap();
            for _ in 0..3 {
                let (q, u) = random_state(&mech, &mut rng);
                let t = rng.random_range(0.0..10.0);
                let (m_ref, f_ref) = reference::mass_matrix_and_forcing(&mech, kane.joint_torques(), t, &q, &u);
                let (m, f) = kane.mass_matrix_and_forcing(t, &q, &u);
                let em = (m - &m_ref).amax() / m_ref.amax();
                let ef = (f - &f_ref).amax() / f_ref.amax().max(m_ref.amax());
                worst = worst.max(em).max(ef);
                assert!(em <= 1e-12, "tree {seed}: M differs from the reference by {em:e}");
                assert!(ef <= 1e-12, "tree {seed}: F differs from the reference by {ef:e}\n{f}\n{f_ref}");
            }
        }
    }
    // The mixed trees must exercise every kind, together.
    let kinds = |k: fn(&JointKind) -> bool| {
        (MIXED..MIXED + TREES).filter(|&s| random_tree(s).joints.iter().any(|j| k(&j.kind))).count()
    };
    let (prismatic, fixed) = (kinds(|k| matches!(k, JointKind::Prismatic { .. })), kinds(|k| *k == JointKind::Fixed));
    let all_three = (MIXED..MIXED + TREES)
        .filter(|&s| {
            let m = random_tree(s);
            let has = |k: fn(&JointKind) -> bool| m.joints.iter().any(|j| k(&j.kind));
            has(|k| matches!(k, JointKind::Prismatic { .. }))
                && has(|k| *k == JointKind::Fixed)
                && has(|k| *k == JointKind::Revolute)
        })
        .count();
    println!(
        "fast forms vs reference: worst {worst:.1e}; mixed trees with prismatic {prismatic}, fixed {fixed}, all three {all_three}"
    );
    assert!(prismatic >= 20 && fixed >= 20 && all_three >= 10);
    let with_path = (PATHS..PATHS + TREES)
        .filter(|&s| random_tree(s).joints.iter().any(|j| matches!(j.kind, JointKind::Path { .. })))
        .count();
    let path_joints: usize = (PATHS..PATHS + TREES)
        .map(|s| random_tree(s).joints.iter().filter(|j| matches!(j.kind, JointKind::Path { .. })).count())
        .sum();
    println!("trees with path joints: {with_path} of {TREES}, {path_joints} path joints");
    assert!(with_path >= 30);
}

/// `Kane::residual_jacobian` (closed-form derivatives of the pair terms) against central
/// differences of `M(q) u̇ − F(q, u)` on every random tree, recast with absolute speeds and
/// without gravity and point forces (where the closed form applies), at random states and
/// accelerations. Differences with step 1e-5 err by ~1e-10 relative (truncation h² times third
/// derivatives of trigonometric terms, rounding 1e-16/h); 1e-7 leaves a wide margin. The
/// excluded cases must answer false.
#[test]
fn residual_jacobian_equals_central_differences() {
    let mut rng = StdRng::seed_from_u64(11);
    let mut worst = 0.0f64;
    for seed in seeds() {
        let mut spec = random_spec(seed);
        let full = Mechanism::from_spec(&spec).unwrap();
        let mut kane = Kane::new(&full).unwrap();
        let n = full.ndof();
        let (mut r, mut a, mut b, mut m) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
        let (q, u) = random_state(&full, &mut rng);
        let revolute = full.joints.iter().all(|j| j.kind == JointKind::Revolute);
        let supported = full.speeds == Speeds::AbsoluteAngularVelocities
            && revolute
            && spec.gravity == (0.0, 0.0)
            && !spec.loads.iter().any(|l| matches!(l, LoadSpec::PointForce { .. }));
        assert_eq!(kane.residual_jacobian(0.3, &q, &u, &u, &mut r, &mut a, &mut b, &mut m), supported, "tree {seed}");
        if !revolute {
            continue;
        }

        spec.speeds = Speeds::AbsoluteAngularVelocities;
        spec.gravity = (0.0, 0.0);
        spec.loads.retain(|l| !matches!(l, LoadSpec::PointForce { .. }));
        let mech = Mechanism::from_spec(&spec).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        let (q, u) = random_state(&mech, &mut rng);
        let ud: Vec<f64> = (0..n).map(|_| rng.random_range(-50.0..50.0)).collect();
        assert!(kane.residual_jacobian(0.3, &q, &u, &ud, &mut r, &mut a, &mut b, &mut m));
        let res = |kane: &mut Kane, q: &[f64], u: &[f64]| -> Vec<f64> {
            let (mm, f) = kane.mass_matrix_and_forcing_rows(0.3, q, u);
            (0..n).map(|i| (0..n).map(|j| mm[i * n + j] * ud[j]).sum::<f64>() - f[i]).collect()
        };
        let r0 = res(&mut kane, &q, &u);
        let scale = r0.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        let h = 1e-5;
        for l in 0..n {
            let (mut qp, mut qm, mut up, mut um) = (q.clone(), q.clone(), u.clone(), u.clone());
            qp[l] += h;
            qm[l] -= h;
            up[l] += h;
            um[l] -= h;
            let (rqp, rqm) = (res(&mut kane, &qp, &u), res(&mut kane, &qm, &u));
            let (rup, rum) = (res(&mut kane, &q, &up), res(&mut kane, &q, &um));
            for i in 0..n {
                let eq = (a[i * n + l] - (rqp[i] - rqm[i]) / (2.0 * h)).abs() / scale;
                let eu = (b[i * n + l] - (rup[i] - rum[i]) / (2.0 * h)).abs() / scale;
                worst = worst.max(eq).max(eu);
                assert!(eq < 1e-7 && eu < 1e-7, "tree {seed}: ∂r_{i}/∂q_{l} off by {eq:e}, ∂r_{i}/∂u_{l} by {eu:e}");
            }
            assert_abs_diff_eq!(r[l], r0[l], epsilon = 1e-12 * scale);
        }
        let (mm, _) = kane.mass_matrix_and_forcing_rows(0.3, &q, &u);
        assert_eq!(&m[..], mm);
    }
    println!("residual Jacobian vs central differences: worst {worst:.1e} (relative to max |r|)");
}

/// Energy is conserved in free, undamped runs of the path trees (every path kind, the general
/// path with its rotation law included): dampers, torques and point forces removed, springs and
/// gravity kept (both in the potential energy). Random state (paths inside 90 % of their travel,
/// speeds a tenth of the other tests'), 0.3 s by DOP853 at rtol 1e-12: the drift of T + V
/// relative to T + |V| must stay ≤ 1e-9. A run that reaches a path's end stops with the named
/// error and is not counted.
#[test]
fn free_undamped_runs_of_path_trees_conserve_energy() {
    use kanedyn::time::integrate::{IntegrateOptions, integrate};
    let (mut runs, mut general, mut worst) = (0, 0, 0.0f64);
    for seed in PATHS..PATHS + TREES {
        let mut mech = random_tree(seed);
        if !mech.joints.iter().any(|j| matches!(j.kind, JointKind::Path { .. })) {
            continue;
        }
        mech.loads.ground_dampers.clear();
        mech.loads.point_forces.clear();
        mech.loads.joint_torques.clear();
        for j in &mut mech.joints {
            j.damper = 0.0;
        }
        let mut rng = StdRng::seed_from_u64(seed + 77);
        let (q, mut u) = random_state(&mech, &mut rng);
        u.iter_mut().for_each(|v| *v *= 0.1);
        let energy = |x: &[f64]| {
            let n = mech.ndof();
            let t = kinetic_energy(&mech, &x[..n], &qdot_of(&mech, &x[n..]));
            let v = potential_energy(&mech, &x[..n]);
            (t + v, t + v.abs())
        };
        let x0: Vec<f64> = q.iter().chain(&u).copied().collect();
        let mut kane = Kane::new(&mech).unwrap();
        let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-14, sample_rate_hz: None, ..IntegrateOptions::default() };
        let Ok(run) = integrate(|t, x, dx| kane.rhs(t, x, dx), &x0, 0.0, 0.3, &opts, |_| {}) else { continue };
        let ((e0, scale), (e1, _)) = (energy(&x0), energy(&run.x_end));
        let drift = (e1 - e0).abs() / scale;
        worst = worst.max(drift);
        assert!(drift <= 1e-9, "tree {seed}: energy drifted by {drift:e}");
        runs += 1;
        if mech.joints.iter().any(|j| matches!(j.kind, JointKind::Path { shape: PathShape::General(_), .. })) {
            general += 1;
        }
    }
    println!("free undamped runs of path trees: {runs} ({general} with a general path), worst drift {worst:.1e}");
    assert!(runs >= 20 && general >= 5, "{runs} runs, {general} with a general path");
}

/// The fixed-size right-hand side of small trees of any joint kind with a coordinate
/// (`kane::small_rates`: absolute speeds mapped from joint rates, at most six speeds, no fixed
/// joint, no point forces) against the general mapped form's, which the same mechanism takes
/// with one point force of zero magnitude (it adds exact zeros): the random trees with path
/// joints (and the mixed ones, for prismatic joints without paths) recast to absolute speeds,
/// without their point forces and welded joints, with an order excitation set on one joint,
/// in the engine's basis and the world frame. The fixed-size form evaluates the same terms in
/// the same order and solves by the same LDLᵀ; where it skips a rotation by exactly (1, 0) or
/// the zero acceleration of a basis root, it differs at most in the sign of a zero. So the two
/// agree to the bit when the joint torques are listed in joint order (with them out of order
/// the small form sums them by joint: rounding). A path joint taken beyond its end fails alike
/// in both, naming the joint (`EngineError::OutOfTravel`), and so does a NaN coordinate.
#[test]
fn small_tree_rhs_with_path_joints_equals_the_general_path() {
    let (mut trees, mut with_path, mut identical) = (0, 0, 0);
    let mut worst: f64 = 0.0;
    for seed in (MIXED..MIXED + TREES).chain(PATHS..PATHS + TREES) {
        let mut spec = random_spec(seed);
        spec.speeds = Speeds::AbsoluteAngularVelocities;
        spec.loads.retain(|l| !matches!(l, LoadSpec::PointForce { .. }));
        for j in &mut spec.joints {
            if j.kind == Some(JointKind::Fixed) {
                j.kind = Some(JointKind::Revolute);
            }
        }
        if spec.joints.len() > 6 || spec.joints.iter().all(|j| matches!(j.kind, Some(JointKind::Revolute) | None)) {
            continue;
        }
        trees += 1;
        let small = Mechanism::from_spec(&spec).unwrap();
        let paths: Vec<usize> =
            (0..small.joints.len()).filter(|&j| matches!(small.joints[j].kind, JointKind::Path { .. })).collect();
        with_path += usize::from(!paths.is_empty());
        spec.loads.push(LoadSpec::PointForce {
            body: "b0".into(),
            at: (0.3, -0.2),
            force: (0.0, 0.0),
            // In the body frame, so that the general engine keeps the same basis.
            frame: ForceFrame::Body,
        });
        let general = Mechanism::from_spec(&spec).unwrap();
        let n = small.ndof();
        let mut rng = StdRng::seed_from_u64(7000 + seed);
        let excitation = Excitation {
            mean: 1.5,
            rpm: 1000.0,
            order: Order::Fixed(3.0),
            harmonics: vec![Harmonic { multiple: 1.0, amplitude: 4.0, phase: 0.3 }],
            ramp_s: 0.0,
        };
        let joint = rng.random_range(0..n);
        for world in [false, true] {
            let build = |m: &Mechanism| if world { Kane::new_world_frame(m) } else { Kane::new(m) }.unwrap();
            let (mut ks, mut kg) = (build(&small), build(&general));
            ks.set_joint_torque(joint, excitation.clone());
            kg.set_joint_torque(joint, excitation.clone());
            for _ in 0..3 {
                let (q, u) = random_state(&small, &mut rng);
                let t = rng.random_range(0.0..10.0);
                let x: Vec<f64> = q.iter().chain(&u).copied().collect();
                let (mut xs, mut xg) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
                ks.rhs(t, &x, &mut xs).unwrap();
                kg.rhs(t, &x, &mut xg).unwrap();
                let torques: Vec<usize> = ks.joint_torques().iter().map(|t| t.joint).collect();
                if torques.is_sorted() {
                    assert_eq!(xs, xg, "tree {seed}");
                    identical += 1;
                }
                assert_eq!(&xs[..n], &xg[..n], "tree {seed}: q̇");
                let scale = xg[n..].iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let err = xs[n..].iter().zip(&xg[n..]).fold(0.0f64, |a, (s, g)| a.max((s - g).abs())) / scale;
                worst = worst.max(err);
                assert!(err <= 1e-13, "tree {seed}: u̇ {:?} vs {:?} (rel {err:e})", &xs[n..], &xg[n..]);
                // Beyond the end of a path (or at a NaN coordinate) both fail with the same error.
                let mut bad = x.clone();
                match paths.first() {
                    Some(&j) => {
                        let k = small.joints[j].coordinate.unwrap();
                        let travel = small.joints[j].kind.travel();
                        bad[k] = if travel.is_finite() { 1.01 * travel } else { f64::NAN };
                    }
                    None => bad[n - 1] = f64::NAN,
                }
                let (es, eg) = (ks.rhs(t, &bad, &mut xs), kg.rhs(t, &bad, &mut xg));
                assert_eq!(format!("{es:?}"), format!("{eg:?}"), "tree {seed}");
                if let Some(&j) = paths.first()
                    && small.joints[j].kind.travel().is_finite()
                {
                    assert!(
                        matches!(&es, Err(EngineError::OutOfTravel { joint, .. }) if *joint == small.joints[j].name),
                        "tree {seed}: {es:?}"
                    );
                }
            }
        }
    }
    println!(
        "small-tree rhs with path joints vs the general path: {trees} trees ({with_path} with path joints), {identical} states identical to the bit, worst relative difference {worst:e}"
    );
    assert!(trees >= 20 && with_path >= 15 && identical >= 100);
}

/// A bushy tree of `n` bodies: a root on ground, every other body hung from the root (three in
/// five) or from one of the root's children, so most of M is zero and the right-hand side takes
/// the tree's factorisation. Joint kinds as in the mixed trees with paths.
fn bushy_spec(seed: u64, n: usize) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let name = |i: usize| format!("b{i}");
    let (mut bodies, mut joints, mut loads) = (Vec::new(), Vec::new(), Vec::new());
    let mut first_level = Vec::new();
    for i in 0..n {
        bodies.push(BodySpec {
            name: Some(name(i)),
            mass: Some(rng.random_range(0.1..10.0)),
            com: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            inertia: Some(rng.random_range(0.01..1.0)),
            ..BodySpec::default()
        });
        let parent = match i {
            0 => "ground".to_string(),
            _ if first_level.is_empty() || rng.random_bool(0.6) => {
                first_level.push(i);
                name(0)
            }
            _ => name(first_level[rng.random_range(0..first_level.len())]),
        };
        let kind = match rng.random_range(0.0..1.0) {
            _ if i == 0 => JointKind::Revolute,
            x if x < 0.2 => JointKind::Prismatic { axis: (rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)) },
            x if x > 0.9 => JointKind::Fixed,
            x if x < 0.5 => random_path(&mut rng),
            _ => JointKind::Revolute,
        };
        let moves = kind != JointKind::Fixed;
        joints.push(JointSpec {
            name: Some(format!("j{i}")),
            kind: Some(kind),
            parent: Some(parent),
            child: Some(name(i)),
            at: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            spring: moves.then(|| Spring { stiffness: rng.random_range(0.0..50.0), free_angle: 0.0 }),
            damper: moves.then(|| rng.random_range(0.0..2.0)),
            ..JointSpec::default()
        });
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::GroundDamper { body: name(i), c: rng.random_range(0.0..1.0) });
        }
    }
    let speeds = if rng.random_bool(0.5) { Speeds::JointRates } else { Speeds::AbsoluteAngularVelocities };
    MechanismSpec {
        base: None,
        name: format!("bushy{seed}"),
        speeds,
        gravity: (0.0, -9.81),
        bodies,
        joints,
        loads,
        gears: Vec::new(),
    }
}

/// Issue 30: the tree's factorisation of M (leaves first, no fill-in) against the dense LDLᵀ on
/// bushy trees of 9, 17, 33 and 65 bodies with every joint kind and both speed choices: the same
/// u̇ to 1e-12 of its largest entry (two exact factorisations of one matrix differ by rounding
/// times its condition, here ≲ 1e4), and the same q̇ exactly.
#[test]
fn the_tree_factorisation_equals_the_dense_one() {
    let mut worst: f64 = 0.0;
    let mut along_tree = 0;
    for n in [9, 17, 33, 65] {
        for seed in 0..12 {
            let mech = Mechanism::from_spec(&bushy_spec(100 * n as u64 + seed, n)).unwrap();
            let mut tree = Kane::new(&mech).unwrap();
            // The formed M solved along the tree, not the articulated-body route these trees take.
            tree.use_mass_matrix();
            let mut dense = tree.clone();
            dense.use_dense_factorisation();
            along_tree += usize::from(tree.factorises_along_tree());
            let mut rng = StdRng::seed_from_u64(7000 + seed);
            let (q, u) = random_state(&mech, &mut rng);
            let dof = mech.ndof();
            let x: Vec<f64> = q.iter().chain(&u).copied().collect();
            let (mut a, mut b) = (vec![0.0; 2 * dof], vec![0.0; 2 * dof]);
            tree.rhs(0.3, &x, &mut a).unwrap();
            dense.rhs(0.3, &x, &mut b).unwrap();
            assert_eq!(a[..dof], b[..dof]);
            let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = a[dof..].iter().zip(&b[dof..]).fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
            worst = worst.max(diff / size);
            assert!(diff <= 1e-12 * size, "n = {n}, seed {seed}: {diff:e} of {size:e}");
        }
    }
    println!("largest difference: {worst:e} of the largest u̇; {along_tree} of 48 along the tree");
    // Every tree of 17 bodies and more takes the tree's route (at 9 some are too deep).
    assert!(along_tree >= 36, "{along_tree}");
}

/// A deep tree of `n` bodies: each body hung from the one before (four in five) or from any
/// earlier one, so the depth grows with n and M is nearly full. Joint kinds as in the bushy
/// trees; a non-turning path joint carries rollers half the time, a moving joint has friction
/// (a coupling) one time in five; gravity, point forces, ground dampers and joint torques.
fn deep_spec(seed: u64, n: usize) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let name = |i: usize| format!("d{i}");
    let (mut bodies, mut joints, mut loads) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        bodies.push(BodySpec {
            name: Some(name(i)),
            mass: Some(rng.random_range(0.5..5.0)),
            com: Some((rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5))),
            inertia: Some(rng.random_range(0.05..1.0)),
            ..BodySpec::default()
        });
        let parent = match i {
            0 => "ground".to_string(),
            _ if rng.random_bool(0.8) => name(i - 1),
            _ => name(rng.random_range(0..i)),
        };
        let kind = match rng.random_range(0.0..1.0) {
            _ if i == 0 => JointKind::Revolute,
            x if x < 0.15 => JointKind::Prismatic { axis: (rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)) },
            x if x > 0.9 => JointKind::Fixed,
            x if x < 0.4 => random_path(&mut rng),
            _ => JointKind::Revolute,
        };
        let moves = kind != JointKind::Fixed;
        let turns = matches!(kind, JointKind::Path { shape, .. } if shape.turns());
        let path = matches!(kind, JointKind::Path { .. });
        let rollers = (path && !turns && rng.random_bool(0.5)).then(|| Rollers {
            count: rng.random_range(1..4),
            mass: rng.random_range(0.05..0.5),
            inertia: rng.random_range(1e-5..1e-3),
            radius: rng.random_range(0.005..0.02),
            spread: rng.random_range(0.0..0.05),
        });
        joints.push(JointSpec {
            name: Some(format!("j{i}")),
            kind: Some(kind),
            parent: Some(parent),
            child: Some(name(i)),
            at: Some((rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5))),
            spring: moves.then(|| Spring { stiffness: rng.random_range(0.0..50.0), free_angle: 0.0 }),
            damper: moves.then(|| rng.random_range(0.0..2.0)),
            friction: (moves && rng.random_bool(0.2))
                .then(|| Friction { torque: rng.random_range(0.1..2.0), smoothing: rng.random_range(0.1..1.0) }),
            rollers,
            ..JointSpec::default()
        });
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::GroundDamper { body: name(i), c: rng.random_range(0.0..1.0) });
        }
        if rng.random_bool(0.2) {
            loads.push(LoadSpec::PointForce {
                body: name(i),
                at: (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5)),
                force: (rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)),
                frame: if rng.random_bool(0.5) { ForceFrame::World } else { ForceFrame::Body },
            });
        }
        if rng.random_bool(0.3) && moves {
            loads.push(LoadSpec::JointTorque {
                joint: format!("j{i}"),
                excitation: Excitation::constant(rng.random_range(-5.0..5.0)),
            });
        }
    }
    let speeds = if rng.random_bool(0.5) { Speeds::JointRates } else { Speeds::AbsoluteAngularVelocities };
    MechanismSpec {
        base: None,
        name: format!("deep{seed}"),
        speeds,
        gravity: (rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0)),
        bodies,
        joints,
        loads,
        gears: Vec::new(),
    }
}

/// Issue 30: the articulated-body route (`kane::articulated`, M never formed) against the dense
/// LDLᵀ of the formed M, itself checked against Kane's sums body by body and Lagrange's
/// equations above, on bushy and deep trees of 9, 17, 33 and 65 bodies with every joint kind
/// (revolute, prismatic, fixed, paths of every shape, rollers), friction couplings, both speed
/// choices, and deep revolute trees in absolute speeds (the pair form's model): the same q̇
/// exactly and the same u̇ to 1e-12 of its largest entry. Two exact solutions of one system
/// differ by rounding (1e-16) times M's condition number; the trees' masses and offsets are
/// drawn within a decade or two, so the condition stays ≲ 1e4.
#[test]
fn the_articulated_body_route_equals_the_dense_one() {
    let (mut worst, mut rollers, mut absolute, mut kinds): (f64, usize, usize, [usize; 4]) = (0.0, 0, 0, [0; 4]);
    let mut chosen = 0;
    for n in [9, 17, 33, 65] {
        for seed in 0..12 {
            // Deep revolute trees in absolute speeds: the pair form's model (`kane::absolute`).
            let mut revolute = deep_spec(5000 + 100 * n as u64 + seed, n);
            for j in &mut revolute.joints {
                (j.kind, j.rollers, j.friction) = (Some(JointKind::Revolute), None, None);
            }
            revolute.speeds = Speeds::AbsoluteAngularVelocities;
            for (shape, spec) in [
                ("bushy", bushy_spec(100 * n as u64 + seed, n)),
                ("deep", deep_spec(9000 + 100 * n as u64 + seed, n)),
                ("revolute", revolute),
            ] {
                let mech = Mechanism::from_spec(&spec).unwrap();
                let mut aba = Kane::new(&mech).unwrap();
                chosen += usize::from(aba.solves_articulated());
                assert!(aba.use_articulated_bodies(), "{shape} n = {n}, seed {seed}");
                let mut dense = aba.clone();
                dense.use_dense_factorisation();
                assert!(!dense.solves_articulated());
                rollers += mech.roller_sets().len();
                absolute += usize::from(mech.speeds == Speeds::AbsoluteAngularVelocities);
                for j in &mech.joints {
                    kinds[match j.kind {
                        JointKind::Revolute => 0,
                        JointKind::Prismatic { .. } => 1,
                        JointKind::Fixed => 2,
                        _ => 3,
                    }] += 1;
                }
                let mut rng = StdRng::seed_from_u64(7000 + seed);
                let (q, u) = random_state(&mech, &mut rng);
                let dof = mech.ndof();
                let x: Vec<f64> = q.iter().chain(&u).copied().collect();
                let (mut a, mut b) = (vec![0.0; 2 * dof], vec![0.0; 2 * dof]);
                aba.rhs(0.3, &x, &mut a).unwrap();
                dense.rhs(0.3, &x, &mut b).unwrap();
                assert_eq!(a[..dof], b[..dof]);
                let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let diff = a[dof..].iter().zip(&b[dof..]).fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
                worst = worst.max(diff / size);
                assert!(diff <= 1e-12 * size, "{shape} n = {n}, seed {seed}: {diff:e} of {size:e}");
                if !mech.roller_sets().is_empty() {
                    // The rollers below other joints: the dense route's M is Kane's sums body by
                    // body (it counted the rollers' mass twice above their parent before).
                    let (m_ref, _) = reference::mass_matrix_and_forcing(&mech, dense.joint_torques(), 0.3, &q, &u);
                    let em = (dense.mass_matrix(&q) - &m_ref).amax() / m_ref.amax();
                    assert!(em <= 1e-12, "{shape} n = {n}, seed {seed}: M differs from the reference by {em:e}");
                }
            }
        }
    }
    println!(
        "largest difference: {worst:e} of the largest u̇; joints revolute/prismatic/fixed/path {kinds:?}, {rollers} roller sets, {absolute} of 144 trees in absolute speeds, {chosen} take the route by default"
    );
    assert!(kinds.iter().all(|&k| k >= 20) && rollers >= 10 && absolute >= 68);
}

/// A rotor on the ground carrying `n − 1` revolute leaves (random pivots, centres of mass,
/// masses, inertias, springs, dampers and ground dampers; absolute speeds, no gravity), with a
/// harmonic torque on the rotor's joint and a constant one on a leaf's.
fn star_spec(seed: u64, n: usize) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let name = |i: usize| format!("b{i}");
    let (mut bodies, mut joints, mut loads) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        bodies.push(BodySpec {
            name: Some(name(i)),
            mass: Some(rng.random_range(0.1..10.0)),
            com: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            inertia: Some(rng.random_range(0.01..1.0)),
            ..BodySpec::default()
        });
        joints.push(JointSpec {
            name: Some(format!("j{i}")),
            kind: Some(JointKind::Revolute),
            parent: Some(if i == 0 { "ground".to_string() } else { name(0) }),
            child: Some(name(i)),
            at: Some((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))),
            spring: Some(Spring { stiffness: rng.random_range(0.0..50.0), free_angle: rng.random_range(-0.5..0.5) }),
            damper: Some(rng.random_range(0.0..2.0)),
            ..JointSpec::default()
        });
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::GroundDamper { body: name(i), c: rng.random_range(0.0..1.0) });
        }
    }
    swept(format!("star{seed}"), bodies, joints, loads, "j0", &format!("j{}", n / 2))
}

/// A mechanism in absolute speeds without gravity from its parts, with an order sweep's torque
/// (n 2.9–3.3 over 60 s, 40 N·m at 1000 rpm, mean 3 N·m) on joint `swept` and a constant 0.7 N·m
/// on joint `held`.
fn swept(
    name: String,
    bodies: Vec<BodySpec>,
    joints: Vec<JointSpec>,
    mut loads: Vec<LoadSpec>,
    swept: &str,
    held: &str,
) -> MechanismSpec {
    let harmonic = Excitation {
        mean: 3.0,
        rpm: 1000.0,
        order: Order::Sweep { from: 2.9, to: 3.3, duration_s: 60.0 },
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: 40.0, phase: 0.3 }],
        ramp_s: 0.0,
    };
    loads.push(LoadSpec::JointTorque { joint: swept.into(), excitation: harmonic });
    loads.push(LoadSpec::JointTorque { joint: held.into(), excitation: Excitation::constant(0.7) });
    MechanismSpec {
        base: None,
        name,
        speeds: Speeds::AbsoluteAngularVelocities,
        gravity: (0.0, 0.0),
        bodies,
        joints,
        loads,
        gears: Vec::new(),
    }
}

/// Issue 30: the one-pass right-hand side of a rotor carrying leaves (`kane::star`) against the
/// dense LDLᵀ, for 7 to 13 leaves (every remainder of the four-leaf rounds) and 32, 64: the same
/// q̇ exactly and u̇ to 1e-12 of its largest entry (the two differ by the order of the root's
/// sums and by rounding times M's condition), at random states with angles of any size (the
/// sines' reduction in every quadrant).
#[test]
fn the_rotor_and_leaves_pass_equals_the_dense_factorisation() {
    let mut worst: f64 = 0.0;
    for n in (8..=14).chain([33, 65]) {
        for seed in 0..6 {
            let mech = Mechanism::from_spec(&star_spec(500 * n as u64 + seed, n)).unwrap();
            let mut star = Kane::new(&mech).unwrap();
            assert!(star.solves_rotor_and_leaves(), "n = {n}");
            let mut dense = star.clone();
            dense.use_dense_factorisation();
            assert!(!dense.solves_rotor_and_leaves());
            let mut rng = StdRng::seed_from_u64(9000 + seed);
            let dof = mech.ndof();
            let x: Vec<f64> = (0..2 * dof)
                .map(|i| if i < dof { rng.random_range(-7.0..7.0) } else { rng.random_range(-50.0..50.0) })
                .collect();
            let (mut a, mut b) = (vec![0.0; 2 * dof], vec![0.0; 2 * dof]);
            star.rhs(0.3, &x, &mut a).unwrap();
            dense.rhs(0.3, &x, &mut b).unwrap();
            assert_eq!(a[..dof], b[..dof]);
            let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = a[dof..].iter().zip(&b[dof..]).fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
            worst = worst.max(diff / size);
            assert!(diff <= 1e-12 * size, "n = {n}, seed {seed}: {diff:e} of {size:e}");
        }
    }
    println!("largest difference: {worst:e} of the largest u̇");
}

/// A rotor carrying leaves with friction on one leaf's pivot (a coupling, so not the one-pass
/// form): the tree's factorisation of roots and leaves (`tree::factor_solve_star`) against the
/// dense LDLᵀ, to 1e-12 of the largest u̇ as above.
#[test]
fn roots_and_leaves_with_a_coupling_equal_the_dense_factorisation() {
    for n in [9, 14, 33] {
        for seed in 0..4 {
            let mut spec = star_spec(700 * n as u64 + seed, n);
            spec.joints[n - 1].friction = Some(Friction { torque: 0.8, smoothing: 0.3 });
            let mech = Mechanism::from_spec(&spec).unwrap();
            let mut tree = Kane::new(&mech).unwrap();
            assert!(tree.factorises_along_tree() && !tree.solves_rotor_and_leaves(), "n = {n}");
            let mut dense = tree.clone();
            dense.use_dense_factorisation();
            let mut rng = StdRng::seed_from_u64(9500 + seed);
            let dof = mech.ndof();
            let x: Vec<f64> = (0..2 * dof)
                .map(|i| if i < dof { rng.random_range(-7.0..7.0) } else { rng.random_range(-50.0..50.0) })
                .collect();
            let (mut a, mut b) = (vec![0.0; 2 * dof], vec![0.0; 2 * dof]);
            tree.rhs(0.3, &x, &mut a).unwrap();
            dense.rhs(0.3, &x, &mut b).unwrap();
            assert_eq!(a[..dof], b[..dof]);
            let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = a[dof..].iter().zip(&b[dof..]).fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
            assert!(diff <= 1e-12 * size, "n = {n}, seed {seed}: {diff:e} of {size:e}");
        }
    }
}

/// Bodies turning on one axis (a random tree of disks, each pivoted at its parent's joint point
/// with its centre of mass there: an elastic crankshaft's throws, a branched torsional model)
/// and `leaves` revolute leaves pivoted off the axis on random disks (pendulums), some leaves
/// carrying a disk at their own pivot; absolute speeds, random springs, dampers and ground
/// dampers, a harmonic torque on the first disk's joint and a constant one on a leaf's.
fn axial_spec(seed: u64, disks: usize, leaves: usize) -> MechanismSpec {
    axial_tree(seed, disks, leaves, false)
}

/// [`axial_spec`]'s bodies, as one chain when `chain` (each disk on the one before, one leaf at
/// the end: a crankshaft with its flywheel and a pendulum).
fn axial_tree(seed: u64, disks: usize, leaves: usize, chain: bool) -> MechanismSpec {
    let mut rng = StdRng::seed_from_u64(seed);
    let (mut bodies, mut joints, mut loads) = (Vec::new(), Vec::new(), Vec::new());
    let body = |name: String, com: (f64, f64), rng: &mut StdRng| BodySpec {
        name: Some(name),
        mass: Some(rng.random_range(0.1..10.0)),
        com: Some(com),
        inertia: Some(rng.random_range(0.01..1.0)),
        ..BodySpec::default()
    };
    let joint = |name: String, parent: String, child: String, at: (f64, f64), rng: &mut StdRng| JointSpec {
        name: Some(name),
        kind: Some(JointKind::Revolute),
        parent: Some(parent),
        child: Some(child),
        at: Some(at),
        spring: Some(Spring { stiffness: rng.random_range(0.0..5e4), free_angle: rng.random_range(-0.5..0.5) }),
        damper: Some(rng.random_range(0.0..2.0)),
        ..JointSpec::default()
    };
    for i in 0..disks {
        let parent = match i {
            0 => "ground".to_string(),
            _ if chain => format!("d{}", i - 1),
            _ => format!("d{}", rng.random_range(0..i)),
        };
        bodies.push(body(format!("d{i}"), (0.0, 0.0), &mut rng));
        joints.push(joint(format!("s{i}"), parent, format!("d{i}"), (0.0, 0.0), &mut rng));
    }
    for i in 0..leaves {
        let hub = format!("d{}", if chain { disks - 1 } else { rng.random_range(0..disks) });
        let com = (rng.random_range(-0.3..0.3), rng.random_range(-0.3..0.3));
        let at = (rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
        bodies.push(body(format!("p{i}"), com, &mut rng));
        joints.push(joint(format!("pj{i}"), hub, format!("p{i}"), at, &mut rng));
        if !chain && rng.random_bool(0.3) {
            bodies.push(body(format!("pd{i}"), (0.0, 0.0), &mut rng));
            joints.push(joint(format!("pdj{i}"), format!("p{i}"), format!("pd{i}"), (0.0, 0.0), &mut rng));
        }
    }
    for b in &bodies {
        if rng.random_bool(0.3) {
            loads.push(LoadSpec::GroundDamper { body: b.name.clone().unwrap(), c: rng.random_range(0.0..1.0) });
        }
    }
    swept(format!("axial{seed}"), bodies, joints, loads, "s0", "pj0")
}

/// Issue 30: the one-pass right-hand side of bodies on one axis carrying leaves (`kane::axial`)
/// against the dense LDLᵀ and the articulated-body route, on random trees of 3–40 disks with
/// 1–8 leaves (branched, leaves with and without a disk of their own) and on chains of 6–21
/// disks with a pendulum at the end (the chain's vector pass, every remainder of its four-body
/// rounds): q̇ equal to the bit (the same subtraction), u̇ within 1e-12 of its largest entry (the
/// routes sum in different orders, and rounding grows with M's condition), at random states with
/// angles of any size.
#[test]
fn the_axial_pass_equals_the_dense_factorisation_and_the_articulated_route() {
    let mut worst: f64 = 0.0;
    let mut taken = 0;
    let cases = [(3, 4, false), (6, 1, false), (8, 2, false), (16, 1, false), (16, 8, false), (40, 3, false)];
    let chains = (6..=21).map(|d| (d, 1, true));
    for (disks, leaves, chain) in cases.into_iter().chain(chains) {
        for seed in 0..6 {
            let spec = axial_tree(800 * disks as u64 + 7 * leaves as u64 + seed, disks, leaves, chain);
            let mech = Mechanism::from_spec(&spec).unwrap();
            let axial = Kane::new(&mech).unwrap();
            assert!(axial.solves_axial(), "{disks} disks, {leaves} leaves, seed {seed}");
            taken += 1;
            let mut dense = axial.clone();
            dense.use_dense_factorisation();
            let mut aba = axial.clone();
            assert!(aba.use_articulated_bodies());
            assert!(!dense.solves_axial() && !aba.solves_axial());
            let mut rng = StdRng::seed_from_u64(9700 + seed);
            let dof = mech.ndof();
            let x: Vec<f64> = (0..2 * dof)
                .map(|i| if i < dof { rng.random_range(-7.0..7.0) } else { rng.random_range(-50.0..50.0) })
                .collect();
            let mut a = vec![0.0; 2 * dof];
            let mut axial = axial;
            axial.rhs(0.3, &x, &mut a).unwrap();
            for (route, other) in [("dense", &mut dense), ("articulated", &mut aba)] {
                let mut b = vec![0.0; 2 * dof];
                other.rhs(0.3, &x, &mut b).unwrap();
                assert_eq!(a[..dof], b[..dof], "{route}");
                let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let diff = a[dof..].iter().zip(&b[dof..]).fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
                worst = worst.max(diff / size);
                assert!(
                    diff <= 1e-12 * size,
                    "{route}, {disks} disks, {leaves} leaves, seed {seed}: {diff:e} of {size:e}"
                );
            }
        }
    }
    println!("largest difference: {worst:e} of the largest u̇ over {taken} mechanisms");
}

/// Where a body's centre of mass is off its pivot below a joint off the axis, it couples with
/// an ancestor that is not its parent, and a leaf hanging a second leaf off its own pivot is a
/// hub and a leaf at once: the axial pass must not take either mechanism (the route taken then
/// still agrees with the dense one). A disk pivoted off the axis with its centre of mass at its
/// pivot couples with nothing (its mass is its parent's, at the pivot) and is taken.
#[test]
fn the_axial_pass_refuses_couplings_beyond_a_leaf_and_its_hub() {
    let add = |spec: &mut MechanismSpec, name: &str, parent: &str, at: (f64, f64), com: (f64, f64)| {
        spec.bodies.push(BodySpec {
            name: Some(name.into()),
            mass: Some(1.0),
            com: Some(com),
            inertia: Some(0.1),
            ..BodySpec::default()
        });
        spec.joints.push(JointSpec {
            name: Some(format!("{name}j")),
            kind: Some(JointKind::Revolute),
            parent: Some(parent.into()),
            child: Some(name.into()),
            at: Some(at),
            spring: Some(Spring { stiffness: 30.0, free_angle: 0.0 }),
            ..JointSpec::default()
        });
    };
    let mut off_axis = axial_spec(11, 8, 2);
    add(&mut off_axis, "r", "d0", (0.1, 0.0), (0.0, 0.0));
    assert!(Kane::new(&Mechanism::from_spec(&off_axis).unwrap()).unwrap().solves_axial());
    add(&mut off_axis, "r2", "r", (0.0, 0.0), (0.05, 0.0));
    let mut leaf_on_leaf = axial_spec(12, 8, 2);
    add(&mut leaf_on_leaf, "q", "p0", (0.1, 0.0), (0.2, 0.0));
    for spec in [off_axis, leaf_on_leaf] {
        let mech = Mechanism::from_spec(&spec).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        assert!(!kane.solves_axial());
        let dof = mech.ndof();
        let x: Vec<f64> = (0..2 * dof).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut a, mut b) = (vec![0.0; 2 * dof], vec![0.0; 2 * dof]);
        kane.rhs(0.1, &x, &mut a).unwrap();
        kane.use_dense_factorisation();
        kane.rhs(0.1, &x, &mut b).unwrap();
        let size = b[dof..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(a.iter().zip(&b).all(|(p, r)| (p - r).abs() <= 1e-12 * size));
    }
}
