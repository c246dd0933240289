//! Gear pairs and fixed-ratio couplings (issue 15, item 1), against independent routes: the
//! hand-reduced models of geared drivelines (closed forms and eigenvalues of matrices written
//! here), the energy balance of a time run, the textbook reduction `TᵀMT`, `TᵀF` of the
//! unconstrained tree on random trees (T built here from the file's couplings, the tree loaded
//! without them), located input errors, and a study on a geared mechanism.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::kane::kinematics::kinetic_energy;
use kanedyn::linear::{Damping, LinearModel, Spin};
use kanedyn::model::excitation::Excitation;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::path::Path;

fn load(text: &str) -> Mechanism {
    Mechanism::from_source(&Source::from_text("gears.ron", text), &ReadPolicy::within(Path::new("")))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Two shafts on ground, J₁ (`input`) and J₂ (`output`, 0.3 m away), joined by `gear`.
fn pair(j1: f64, j2: f64, gear: &str) -> String {
    format!(
        r#"Mechanism(
    name: "pair",
    speeds: JointRates,
    bodies: [Body(name: "pinion", mass: 2.0, inertia: {j1:e}), Body(name: "wheel", mass: 5.0, inertia: {j2:e})],
    joints: [
        Joint(name: "input", parent: "ground", child: "pinion"),
        Joint(name: "output", parent: "ground", child: "wheel", at: (0.3, 0.0)),
    ],
    gears: [{gear}],
)"#
    )
}

#[test]
fn rigid_pair_is_the_reflected_inertia() {
    let (j1, j2, r) = (0.7, 2.3, -3.2);
    let mech = load(&pair(j1, j2, &format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e})")));
    assert_eq!(mech.ndof(), 1);
    assert_eq!(mech.joints[1].coordinate, None);
    let mut kane = Kane::new(&mech).unwrap();
    let expected = j1 + r * r * j2;
    // Torques on both sides: the output's reaches the input coordinate times the ratio (Aᵀ F_d).
    let (t_in, t_out) = (3.0, -1.25);
    kane.set_joint_torque(0, Excitation::constant(t_in));
    kane.set_joint_torque(1, Excitation::constant(t_out));
    let mut rng = StdRng::seed_from_u64(15);
    for _ in 0..10 {
        let (q, u) = (rng.random_range(-5.0..5.0), rng.random_range(-50.0..50.0));
        let (m, f) = kane.mass_matrix_and_forcing(0.0, &[q], &[u]);
        // The reduced M is J₁ + r² J₂, a sum of three products: 1e-12 relative is rounding.
        assert!(abs_diff_eq!(m[(0, 0)], expected, epsilon = 1e-12 * expected), "M {} vs {expected}", m[(0, 0)]);
        let f_expected = t_in + r * t_out;
        assert!(abs_diff_eq!(f[0], f_expected, epsilon = 1e-12 * f_expected.abs()), "F {} vs {f_expected}", f[0]);
        // The driven joint stays readable from the reduced state.
        assert_eq!(mech.joint_coordinate(1, &[q]), Some(r * q));
        assert_eq!(mech.joint_rate(1, &[u]), Some(r * u));
    }
}

/// Natural frequencies (rad/s) of the undamped linear model at standstill, spin joint `spin`
/// free or held, lowest first, zero (rigid-body) frequencies dropped.
fn frequencies(mech: &Mechanism, spin: &str, held: bool) -> Vec<f64> {
    let lin = LinearModel::new(mech, spin, 0.0, None).unwrap_or_else(|e| panic!("{e}"));
    let modal = lin.modes(if held { Spin::Held } else { Spin::Free }, Damping::Undamped).unwrap();
    let mut f: Vec<f64> = modal.modes.iter().map(|m| m.natural_frequency_rad_s).collect();
    f.sort_by(f64::total_cmp);
    let top = f.last().copied().unwrap_or(0.0);
    f.retain(|&x| x > 1e-6 * top);
    f
}

/// [`pair`]'s two shafts on a housing (the spin joint's body) instead of ground: held at
/// standstill the housing is the ground of [`pair`].
fn pair_on_housing(j1: f64, j2: f64, gear: &str) -> String {
    pair(j1, j2, gear)
        .replace("bodies: [", "bodies: [Body(name: \"housing\", mass: 50.0, inertia: 4.0), ")
        .replace("joints: [", "joints: [\n        Joint(name: \"mount\", parent: \"ground\", child: \"housing\"),")
        .replace("parent: \"ground\", child: \"pinion\"", "parent: \"housing\", child: \"pinion\"")
        .replace("parent: \"ground\", child: \"wheel\"", "parent: \"housing\", child: \"wheel\"")
}

#[test]
fn compliant_mesh_frequency_is_the_closed_form() {
    let (j1, j2, r, k) = (0.7, 2.3, -3.2, 4.0e4);
    let gear = format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e}, mesh: (stiffness: {k:e}))");
    // On ground with the pinion as spin joint the pair turns as a whole along z = (1, r) (issue
    // 29, item 1): the free spin has the rigid rotation and the mesh mode, at 0 and 300 rpm.
    let on_ground = load(&pair(j1, j2, &gear));
    let expected = (k * (j1 + r * r * j2) / (j1 * r * r * j2)).sqrt();
    for rpm in [0.0, 300.0] {
        let lin = LinearModel::new(&on_ground, "input", rpm * std::f64::consts::PI / 30.0, None).unwrap();
        assert_eq!(lin.op.rotation, vec![1.0, r]);
        let modal = lin.modes(Spin::Free, Damping::Undamped).unwrap();
        assert_eq!(modal.modes.len(), 1);
        assert_abs_diff_eq!(modal.modes[0].natural_frequency_rad_s, expected, epsilon = 1e-12 * expected);
    }
    let mech = load(&pair_on_housing(j1, j2, &gear));
    assert_eq!(mech.ndof(), 3);
    let f = frequencies(&mech, "mount", true);
    println!("mesh mode {} rad/s vs {expected}", f[0]);
    assert_eq!(f.len(), 1);
    // A 2×2 eigenproblem of exact (linear) forcing differences: rounding, bound 1e-12.
    assert_abs_diff_eq!(f[0], expected, epsilon = 1e-12 * expected);
}

/// Generalized eigenfrequencies √λ of K x = λ M x (M symmetric positive definite), lowest first,
/// the rigid-body zeros dropped.
fn hand_frequencies(m: &DMatrix<f64>, k: &DMatrix<f64>) -> Vec<f64> {
    let l = m.clone().cholesky().unwrap().l();
    let li = l.clone().try_inverse().unwrap();
    let a = &li * k * li.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let mut ev: Vec<f64> = a.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(f64::total_cmp);
    let top = ev[ev.len() - 1];
    ev.into_iter().filter(|&x| x > 1e-9 * top).map(f64::sqrt).collect()
}

fn assert_same_frequencies(got: &[f64], want: &[f64], tol: f64) {
    println!("kanedyn {got:?}\nhand    {want:?}");
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert!(abs_diff_eq!(g, w, epsilon = tol * w), "{g} vs {w}: {:.2e}", (g - w).abs() / w);
    }
}

#[test]
fn geared_chain_has_the_hand_reduced_frequencies() {
    // Engine J₁ —k₁— pinion J₂ ⇒ (rigid gear, ratio r) ⇒ wheel J₃ —k₂— J₄ —k₃— vehicle J₅. The
    // pinion and wheel turn on ground, so their joint rates are their absolute rates; the engine
    // hangs on the pinion and the output shafts on the wheel (relative coordinates).
    let (j1, j2, j3, j4, j5) = (1.2, 0.05, 0.3, 0.8, 25.0);
    let (k1, k2, k3, r) = (3.0e4, 8.0e4, 1.5e4, -0.28);
    let text = format!(
        r#"Mechanism(
    name: "chain",
    bodies: [
        Body(name: "engine", inertia: {j1:e}), Body(name: "pinion", inertia: {j2:e}),
        Body(name: "wheel", inertia: {j3:e}), Body(name: "hub", inertia: {j4:e}), Body(name: "vehicle", inertia: {j5:e}),
    ],
    joints: [
        Joint(name: "pinion_axle", parent: "ground", child: "pinion"),
        Joint(name: "crank", parent: "pinion", child: "engine", spring: (stiffness: {k1:e})),
        Joint(name: "wheel_axle", parent: "ground", child: "wheel", at: (0.4, 0.0)),
        Joint(name: "shaft", parent: "wheel", child: "hub", spring: (stiffness: {k2:e})),
        Joint(name: "axle", parent: "hub", child: "vehicle", spring: (stiffness: {k3:e})),
    ],
    gears: [Gear(joint: "wheel_axle", follows: "pinion_axle", ratio: {r:e})],
)"#
    );
    let mech = load(&text);
    assert_eq!(mech.ndof(), 4);
    let got = frequencies(&mech, "pinion_axle", false);
    // Hand reduction in absolute angles (θ₁, θ₂, θ₄, θ₅), θ₃ = r θ₂: the wheel reflects as r² J₃
    // onto the pinion, the shaft k₂ twists by θ₄ − r θ₂.
    let m = DMatrix::from_diagonal(&DVector::from_vec(vec![j1, j2 + r * r * j3, j4, j5]));
    #[rustfmt::skip]
    let k = DMatrix::from_row_slice(4, 4, &[
        k1,  -k1,                 0.0,      0.0,
        -k1, k1 + r * r * k2,     -r * k2,  0.0,
        0.0, -r * k2,             k2 + k3,  -k3,
        0.0, 0.0,                 -k3,      k3,
    ]);
    // Two eigen-solvers on a condition number ~1e3: 1e-10 relative.
    assert_same_frequencies(&got, &hand_frequencies(&m, &k), 1e-10);
}

#[test]
fn four_inertias_three_shafts_through_a_compliant_stage() {
    // J₁ —k₁— J₂ ⇒ (stage, ratio r, k₂ at the driving side) ⇒ J₃ —k₃— J₄: the textbook chain,
    // in a housing held at standstill (the spin joint; see `pair_on_housing`).
    let (j1, j2, j3, j4) = (1.2, 0.35, 0.3, 25.0);
    let (k1, k2, k3, r) = (3.0e4, 8.0e4, 1.5e4, 2.7);
    let text = format!(
        r#"Mechanism(
    name: "chain4",
    bodies: [
        Body(name: "housing", inertia: 10.0),
        Body(name: "engine", inertia: {j1:e}), Body(name: "input", inertia: {j2:e}),
        Body(name: "output", inertia: {j3:e}), Body(name: "vehicle", inertia: {j4:e}),
    ],
    joints: [
        Joint(name: "mount", parent: "ground", child: "housing"),
        Joint(name: "input_axle", parent: "housing", child: "input"),
        Joint(name: "crank", parent: "input", child: "engine", spring: (stiffness: {k1:e})),
        Joint(name: "output_axle", parent: "housing", child: "output", at: (0.4, 0.0)),
        Joint(name: "axle", parent: "output", child: "vehicle", spring: (stiffness: {k3:e})),
    ],
    gears: [Gear(joint: "output_axle", follows: "input_axle", ratio: {r:e}, mesh: (stiffness: {k2:e}))],
)"#
    );
    let mech = load(&text);
    assert_eq!(mech.ndof(), 5);
    let got = frequencies(&mech, "mount", true);
    // (θ₁, θ₂, θ₃, θ₄): ½ k₂ (θ₂ − θ₃/r)².
    let m = DMatrix::from_diagonal(&DVector::from_vec(vec![j1, j2, j3, j4]));
    let ri = 1.0 / r;
    #[rustfmt::skip]
    let k = DMatrix::from_row_slice(4, 4, &[
        k1,  -k1,      0.0,                0.0,
        -k1, k1 + k2,  -k2 * ri,           0.0,
        0.0, -k2 * ri, k2 * ri * ri + k3,  -k3,
        0.0, 0.0,      -k3,                k3,
    ]);
    assert_same_frequencies(&got, &hand_frequencies(&m, &k), 1e-10);
}

#[test]
fn power_in_equals_power_out_across_an_ideal_mesh() {
    // A torque drives the pinion; the wheel carries a pendulum (q-dependent inertia, centripetal
    // forces) and a load torque. With no losses, the work of both applied torques must equal the
    // kinetic energy of the whole geared system, computed here body by body on the unconstrained
    // tree (loaded from the same text without the coupling) at the expanded state.
    let r = -2.5;
    let text = |gears: &str| {
        format!(
            r#"Mechanism(
    name: "power",
    bodies: [
        Body(name: "pinion", mass: 1.0, inertia: 0.02),
        Body(name: "wheel", mass: 4.0, inertia: 0.3),
        Body(name: "bob", mass: 0.5, com: (0.08, 0.0), inertia: 1e-3),
    ],
    joints: [
        Joint(name: "input", parent: "ground", child: "pinion"),
        Joint(name: "output", parent: "ground", child: "wheel", at: (0.25, 0.0)),
        Joint(name: "pivot", parent: "wheel", child: "bob", at: (0.12, 0.0)),
    ],
    gears: [{gears}],
)"#
        )
    };
    let mech = load(&text(&format!("Gear(joint: \"output\", follows: \"input\", ratio: {r:e})")));
    let full = load(&text(""));
    let (t_in, t_out) = (2.0, 0.3);
    let mut kane = Kane::new(&mech).unwrap();
    kane.set_joint_torque(0, Excitation::constant(t_in));
    kane.set_joint_torque(1, Excitation::constant(t_out));
    // Reduced state [q_input, q_pivot; q̇_input, q̇_pivot], starting with the pendulum swung out.
    let x0 = [0.0, 0.6, 0.0, 0.0];
    let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, sample_rate_hz: Some(200.0), ..Default::default() };
    let expand = |x: &[f64]| ([x[0], r * x[0], x[1]], [x[2], r * x[2], x[3]]);
    let (q0, v0) = expand(&x0);
    let ke0 = kinetic_energy(&full, &q0, &v0);
    let mut worst: f64 = 0.0;
    let mut peak: f64 = 0.0;
    integrate(
        |t, x, dx| kane.rhs(t, x, dx),
        &x0,
        0.0,
        2.0,
        &opts,
        |s| {
            let (q, v) = expand(s.x);
            let work = t_in * (q[0] - q0[0]) + t_out * (q[1] - q0[1]);
            let ke = kinetic_energy(&full, &q, &v) - ke0;
            worst = worst.max((ke - work).abs());
            peak = peak.max(ke.abs());
        },
    )
    .unwrap();
    println!("energy balance: {worst:.2e} of {peak:.3e} J");
    // DOP853 at rtol 1e-12 over 2 s: 1e-9 of the kinetic energy reached.
    assert!(peak > 1.0, "the run must do real work ({peak} J)");
    assert!(worst <= 1e-9 * peak, "work − ΔKE = {worst:e} J of {peak:e} J");
}

/// A random tree of revolute and prismatic joints with random couplings (some compliant), as
/// text with and without its `gears`, and the couplings as (driven, driver, ratio, offset, mesh).
type Coupling = (usize, usize, f64, f64, Option<(f64, f64)>);

fn random_geared(seed: u64) -> (String, String, Vec<Coupling>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let nb = rng.random_range(3..=7);
    let mut bodies = String::new();
    let mut joints = String::new();
    for j in 0..nb {
        let (m, i) = (rng.random_range(0.2..3.0), rng.random_range(0.01..0.5));
        let (cx, cy) = (rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2));
        bodies += &format!("Body(name: \"b{j}\", mass: {m:e}, com: ({cx:e}, {cy:e}), inertia: {i:e}),\n");
        let parent =
            if j == 0 || rng.random_bool(0.3) { "ground".to_string() } else { format!("b{}", rng.random_range(0..j)) };
        let (ax, ay) = (rng.random_range(-0.3..0.3), rng.random_range(-0.3..0.3));
        let kind = if rng.random_bool(0.25) {
            format!("Prismatic(axis: ({:e}, {:e}))", rng.random_range(0.1..1.0), rng.random_range(-1.0..1.0))
        } else {
            "Revolute".into()
        };
        let (k, c) = (rng.random_range(0.0..50.0), rng.random_range(0.0..0.5));
        joints += &format!(
            "Joint(name: \"j{j}\", kind: {kind}, parent: \"{parent}\", child: \"b{j}\", at: ({ax:e}, {ay:e}), \
             spring: (stiffness: {k:e}, free_angle: 0.1), damper: {c:e}),\n"
        );
    }
    // Each joint after the first may follow an earlier one (so the follows-graph has no loop).
    let mut couplings = Vec::new();
    for j in 1..nb {
        if rng.random_bool(0.5) {
            let follows = rng.random_range(0..j);
            let ratio = rng.random_range(0.3..3.0) * if rng.random_bool(0.5) { -1.0 } else { 1.0 };
            let offset = rng.random_range(-0.2..0.2);
            let mesh = rng.random_bool(0.3).then(|| (rng.random_range(10.0..500.0), rng.random_range(0.0..1.0)));
            couplings.push((j, follows, ratio, offset, mesh));
        }
    }
    let gears: String = couplings
        .iter()
        .map(|&(j, f, r, o, mesh)| {
            let mesh = mesh.map_or(String::new(), |(k, c)| format!(", mesh: (stiffness: {k:e}, damping: {c:e})"));
            format!("Gear(joint: \"j{j}\", follows: \"j{f}\", ratio: {r:e}, offset: {o:e}{mesh}),\n")
        })
        .collect();
    let torques: String = (0..nb)
        .map(|j| format!("JointTorque(joint: \"j{j}\", excitation: (mean: {:e})),\n", rng.random_range(-2.0..2.0)))
        .collect();
    let g = rng.random_range(-9.81..9.81);
    let make = |gears: &str| {
        format!(
            "Mechanism(name: \"tree{seed}\", speeds: JointRates, gravity: (0.0, {g:e}),\nbodies: [\n{bodies}],\njoints: [\n{joints}],\nloads: [\n{torques}GroundDamper(body: \"b0\", c: 0.3),\n],\ngears: [\n{gears}],\n)"
        )
    };
    (make(&gears), make(""), couplings)
}

#[test]
fn reduced_equations_are_the_textbook_reduction_on_random_trees() {
    let mut checked = 0;
    for seed in 0..40 {
        let (geared_text, free_text, couplings) = random_geared(seed);
        if couplings.is_empty() {
            continue;
        }
        let geared = load(&geared_text);
        let free = load(&free_text);
        let nb = free.joints.len();
        // T and the offsets from the couplings (rigid ones only), joint by joint in file order
        // (which is tree order here: parents come first): q_j = factor · q_root + offset.
        let mut follow: Vec<(usize, f64, f64)> = (0..nb).map(|j| (j, 1.0, 0.0)).collect();
        for j in 0..nb {
            if let Some(&(_, f, r, o, None)) = couplings.iter().find(|c| c.0 == j) {
                let (root, a, b) = follow[f];
                follow[j] = (root, r * a, r * b + o);
            }
        }
        let n = geared.ndof();
        let nf = free.ndof();
        let mut t = DMatrix::zeros(nf, n);
        let mut offset = DVector::zeros(nf);
        for (j, &(root, a, b)) in follow.iter().enumerate() {
            let name = format!("j{root}");
            let (Some(fr), Some(red)) = (free.coordinate_index(&format!("j{j}")), geared.coordinate_index(&name))
            else {
                panic!("seed {seed}: joint j{j} or its root {name} has no coordinate");
            };
            t[(fr, red)] = a;
            offset[fr] = b;
        }
        let mut rng = StdRng::seed_from_u64(1000 + seed);
        let mut kg = Kane::new(&geared).unwrap();
        let mut kf = Kane::new(&free).unwrap();
        for _ in 0..3 {
            let q = DVector::from_fn(n, |_, _| rng.random_range(-0.5..0.5));
            let u = DVector::from_fn(n, |_, _| rng.random_range(-3.0..3.0));
            let (qf, uf) = (&t * &q + &offset, &t * &u);
            let (mf, ff) = kf.mass_matrix_and_forcing(0.0, qf.as_slice(), uf.as_slice());
            let (mf, mut ff) = (mf.clone(), ff.clone());
            // The compliant meshes' forces, on the deflection at the driver.
            for &(j, f, r, o, mesh) in &couplings {
                if let Some((k, c)) = mesh {
                    let (a, b) = (
                        free.coordinate_index(&format!("j{j}")).unwrap(),
                        free.coordinate_index(&format!("j{f}")).unwrap(),
                    );
                    let force = k * (qf[b] - (qf[a] - o) / r) + c * (uf[b] - uf[a] / r);
                    ff[b] -= force;
                    ff[a] += force / r;
                }
            }
            let m_ref = t.transpose() * &mf * &t;
            let f_ref = t.transpose() * &ff;
            let (mg, fg) = kg.mass_matrix_and_forcing(0.0, q.as_slice(), u.as_slice());
            let em = (mg - &m_ref).amax() / m_ref.amax();
            let ef = (fg - &f_ref).amax() / (1.0 + f_ref.amax());
            // Sums of the same products in another order: rounding, 1e-12.
            assert!(em <= 1e-12 && ef <= 1e-12, "seed {seed}: M {em:.1e}, F {ef:.1e}");
        }
        checked += 1;
    }
    assert!(checked >= 30, "only {checked} trees had couplings");
}

fn error_of(dir: &str, text: &str) -> String {
    let tmp = scratch(&format!("gears-{dir}"));
    let p = tmp.path().join("m.ron");
    std::fs::write(&p, text).unwrap();
    match Mechanism::from_file(&p) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Three shafts on ground and a welded disc; each test adds couplings to it.
fn three(gears: &str) -> String {
    format!(
        r#"Mechanism(
    name: "m",
    bodies: [
        Body(name: "a", inertia: 1.0), Body(name: "b", inertia: 1.0), Body(name: "c", inertia: 1.0),
        Body(name: "d", inertia: 1.0),
    ],
    joints: [
        Joint(name: "ja", parent: "ground", child: "a"),
        Joint(name: "jb", parent: "ground", child: "b", at: (0.2, 0.0)),
        Joint(name: "jc", parent: "ground", child: "c", at: (0.4, 0.0)),
        Joint(name: "weld", kind: Fixed, parent: "a", child: "d"),
    ],
    gears: [
{gears}
    ],
)"#
    )
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "error message {msg:?} should mention {p:?}");
    }
}

#[test]
fn bad_couplings_are_located_errors() {
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "unknown",
            r#"        Gear(joint: "jx", follows: "ja", ratio: 2.0),"#,
            &["m.ron:14:", "gears[0].joint", "unknown joint `jx`"],
        ),
        (
            "unknown-driver",
            r#"        Gear(joint: "jb", follows: "nope", ratio: 2.0),"#,
            &["m.ron:14:", "gears[0].follows", "unknown joint `nope`"],
        ),
        (
            "fixed",
            r#"        Gear(joint: "weld", follows: "ja", ratio: 2.0),"#,
            &["m.ron:14:", "gears[0].joint", "Fixed"],
        ),
        (
            "zero",
            r#"        Gear(joint: "jb", follows: "ja", ratio: 0.0),"#,
            &["m.ron:14:", "gears[0].ratio", "non-zero"],
        ),
        ("nan", r#"        Gear(joint: "jb", follows: "ja", ratio: NaN),"#, &["m.ron:14:", "gears[0].ratio", "finite"]),
        ("inf", r#"        Gear(joint: "jb", follows: "ja", ratio: inf),"#, &["m.ron:14:", "gears[0].ratio", "finite"]),
        (
            "twice",
            "        Gear(joint: \"jb\", follows: \"ja\", ratio: 2.0),\n        Gear(joint: \"jb\", follows: \"jc\", ratio: 3.0),",
            &["m.ron:15:", "gears[1].joint", "already driven by gears[0]"],
        ),
        (
            "loop",
            "        Gear(joint: \"jb\", follows: \"ja\", ratio: 2.0),\n        Gear(joint: \"jc\", follows: \"jb\", ratio: 3.0),\n        Gear(joint: \"ja\", follows: \"jc\", ratio: 0.2),",
            &["m.ron:16:", "gears[2].ratio", "loop", "multiply to 1.2"],
        ),
        (
            "mesh",
            r#"        Gear(joint: "jb", follows: "ja", ratio: 2.0, mesh: (stiffness: -5.0)),"#,
            &["m.ron:14:", "gears[0].mesh.stiffness"],
        ),
    ];
    for (dir, gears, parts) in cases {
        let msg = error_of(dir, &three(gears));
        println!("{msg}");
        assert_mentions(&msg, parts);
    }
    // Couplings fix joint rates: absolute angular velocities as speeds are refused.
    let abs = three(r#"        Gear(joint: "jb", follows: "ja", ratio: 2.0),"#)
        .replace("name: \"m\",", "name: \"m\", speeds: AbsoluteAngularVelocities,");
    assert_mentions(&error_of("abs", &abs), &["gears[0]", "JointRates"]);
    // A joint cannot follow itself.
    assert_mentions(
        &error_of("self", &three(r#"        Gear(joint: "ja", follows: "ja", ratio: 1.0),"#)),
        &["gears[0].follows", "itself"],
    );
}

#[test]
fn a_consistent_loop_is_reduced() {
    // ja → jb (×2), jb → jc (×3), and jc → ja (×1/6) closes the loop consistently: redundant.
    let gears = "        Gear(joint: \"jb\", follows: \"ja\", ratio: 2.0),\n        Gear(joint: \"jc\", follows: \"jb\", ratio: 3.0),\n        Gear(joint: \"ja\", follows: \"jc\", ratio: 0.16666666666666666),";
    let mech = load(&three(gears));
    assert_eq!(mech.ndof(), 1);
    assert_eq!(mech.gears.len(), 2);
    let mut kane = Kane::new(&mech).unwrap();
    let m = kane.mass_matrix(&[0.0])[(0, 0)];
    // a and d (welded) on ja, b at 2×, c at 6×: 2 + 4 + 36.
    assert_abs_diff_eq!(m, 42.0, epsilon = 1e-12 * 42.0);
}

#[test]
fn locking_a_geared_joint_locks_its_train() {
    // A carrier on ground holds two gear shafts; locking either shaft (to the carrier) locks both.
    let text = r#"Mechanism(
    name: "carrier",
    bodies: [
        Body(name: "carrier", inertia: 2.0),
        Body(name: "sun", mass: 1.0, inertia: 0.1),
        Body(name: "planet", mass: 0.5, inertia: 0.05),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "carrier"),
        Joint(name: "sun_axle", parent: "carrier", child: "sun"),
        Joint(name: "planet_axle", parent: "carrier", child: "planet", at: (0.3, 0.0)),
    ],
    gears: [Gear(joint: "planet_axle", follows: "sun_axle", ratio: -2.0)],
)"#;
    let mech = load(text);
    assert_eq!(mech.ndof(), 2);
    for name in ["sun_axle", "planet_axle"] {
        let locked = mech.lock(name, 0.0).unwrap();
        assert_eq!(locked.ndof(), 1, "locking {name}");
        assert!(locked.gears.is_empty());
        // Everything turns with the carrier: 2 + 0.1 + 0.05 + 0.5 · 0.3².
        let m = Kane::new(&locked).unwrap().mass_matrix(&[0.0])[(0, 0)];
        let expected = 2.0 + 0.1 + 0.05 + 0.5 * 0.09;
        assert_abs_diff_eq!(m, expected, epsilon = 1e-12 * expected);
    }
}

#[test]
fn geared_driveline_study_runs() {
    let study = Study::from_file(Path::new("examples/geared_driveline.ron")).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch("geared");
    let out = tmp.path().to_path_buf();
    let r = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    assert!(r.failures.is_empty(), "{:?}", r.failures);
    for f in &r.files {
        assert!(f.exists(), "{} not written", f.display());
    }
    // The absorber's tuning order is the pendulum's own (eq. 15), whatever the gears downstream.
    let lin = &r.linear[0];
    let nt = lin.n_t.unwrap();
    let expected = kanedyn::cpva::CpvaParams::canonical().n_t;
    println!("n_t {nt} vs {expected}");
    assert_abs_diff_eq!(nt, expected, epsilon = 1e-9 * expected);
}

/// A study reports driven joints through their gear (issue 15): with the wheel below the driven
/// joint `output` as response body, harmonic balance's order-n acceleration is |r| times the
/// flywheel's at every branch point (the same solution read through the gear: 1e-12), and the
/// element `output` has |r| times the flywheel angle's amplitude, the flywheel's acceleration
/// over (nΩ)² (1e-12). A transient with reactions at `output` records the mesh torque, which
/// equals the output's Newton–Euler moment (the wheel's only torque is the mesh's; two routes,
/// 1e-12 of the largest value for rounding in sums of a few terms), and the spin joint gets no
/// mesh column.
#[test]
fn a_study_reports_driven_joints_through_their_gear() {
    let tmp = scratch("geared-reports");
    let dir = tmp.path().to_path_buf();
    // The example with its catalog parts written inline (parts must sit below the file).
    let mech = std::fs::read_to_string("examples/geared_cpva.ron")
        .unwrap()
        .replace("part: \"catalog:bodies/flywheel_rotor.ron\"", "mass: 110.0, inertia: 3.44")
        .replace("part: \"catalog:bodies/cpva_pendulum.ron\"", "mass: 6.0, com: (0.0152, 0.0), inertia: 2.16e-4")
        .replace("part: \"catalog:joints/cpva_pivot.ron\", ", "damper: 5e-4, ");
    std::fs::write(dir.join("m.ron"), mech).unwrap();
    let ratio = -0.3125f64;
    let mut reports = Vec::new();
    for body in ["wheel", "rotor"] {
        std::fs::write(
            dir.join("s.ron"),
            format!(
                r#"Study(name: "s", mechanism: "m.ron", response_body: "{body}", lock: ["pivot"], elements: ["output", "pivot"],
 analyses: [HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0], harmonics: 6),
            Transient(name: "t", duration_s: 3.0, speed: Torque(rpm_from: 500.0, rpm_to: 600.0),
                      torques: [(joint: "spin", order: 3.0, harmonics: [(multiple: 1.0, amplitude: 50.0)], ramp_s: 0.5)],
                      reactions: ["output", "spin"], map: (revs_per_block: 4, hop_revs: 1.0, max_order: 4.0, cuts: [3.0]))])"#
            ),
        )
        .unwrap();
        let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
        let r = run(&study, &RunOptions { out: Some(dir.join(format!("out_{body}"))), progress: false }).unwrap();
        assert!(r.failures.is_empty(), "{:?}", r.failures);
        reports.push(r);
    }
    let (wheel, rotor) = (&reports[0].hbm[0], &reports[1].hbm[0]);
    assert_eq!(wheel.order, rotor.order);
    let omega = 1000.0 * std::f64::consts::PI / 30.0;
    for (i, &n) in wheel.order.iter().enumerate() {
        let (aw, ar) = (wheel.accel[0][i], rotor.accel[0][i]);
        assert!(abs_diff_eq!(aw, ratio.abs() * ar, epsilon = 1e-12 * ar), "point {i}: {aw} vs |r| {ar}");
        let out = &wheel.elements[i][0];
        assert_eq!(out.joint, "output");
        let expected = ratio.abs() * ar / (n * omega).powi(2);
        assert!(
            abs_diff_eq!(out.amplitude[0], expected, epsilon = 1e-12 * expected),
            "point {i}: {} vs {expected}",
            out.amplitude[0]
        );
    }
    let t = &reports[0].transient[0];
    let (name, [_, _, moment]) = &t.reaction_series[0];
    assert_eq!(name, "output");
    let (mesh_name, mesh) = &t.mesh_series[0];
    assert_eq!((mesh_name.as_str(), t.mesh_series.len()), ("output", 1));
    let top = mesh.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(top > 1.0, "mesh torque {top}");
    let worst = mesh.iter().zip(moment).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!("transient: mesh torque up to {top:.1} N·m, vs the output's moment {:.1e} of it", worst / top);
    assert!(worst <= 1e-12 * top);
    assert!(t.reaction_ranges[0].mesh_torque_nm.is_some() && t.reaction_ranges[1].mesh_torque_nm.is_none());
}

#[test]
fn the_cli_runs_and_checks_the_geared_example() {
    let bin = env!("CARGO_BIN_EXE_kanedyn");
    let tmp = scratch("geared-cli");
    let out = tmp.path().to_path_buf();
    let run = std::process::Command::new(bin)
        .args(["run", "examples/geared_driveline.ron", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.join("geared_driveline/summary.md").exists());
    let check = std::process::Command::new(bin).args(["check", "examples/geared_cpva.ron"]).output().unwrap();
    let text = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success());
    assert!(text.contains("degrees of freedom: 3"), "{text}");
    assert!(text.contains("output follows spin: ratio -0.3125, offset 0 (rigid)"), "{text}");
}
