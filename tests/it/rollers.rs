//! Roller-type absorbers (issue 14, item 4; docs/design/paths.md, "Rollers"): a translating absorber on a
//! path joint carried by N rollers that roll without slip between a rotor track and an absorber
//! track. Each roller centre moves relative to the rotor by half the absorber's displacement and
//! turns by ψ = −s/(2 r_r); their centroid is c̄(s) = ½(P + r(s)), P the vertex's centre of
//! curvature; their spread about it adds N m_r spread² to the rotor.
//!
//! Every number here comes from a route written in this file: the tuning order from the closed
//! form ñ²(m + N m_r/2)/(m + N(m_r + I_r/r_r²)/4) against the linear analysis at held spin; M and
//! F against Lagrange's equations of a kinetic energy built here from the rolling kinematics; the
//! energy and the locked rotor from the same expressions.

use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::kane::kinematics::kinetic_energy;
use kanedyn::linear::{Damping, LinearModel, Spin};
use kanedyn::model::absorber::{Tautochronism, absorbers, markdown};
use kanedyn::model::joint::JointKind;
use kanedyn::model::math::{Vec2, perp, rot2};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::model::path::PathShape;
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The rotor's and the absorber's numbers (the canonical CPVA's rotor inertia, its 6 kg absorber).
const I_A: f64 = 3.44350435513;
const M_ABS: f64 = 6.0;
const I_ABS: f64 = 2.16e-4;

/// A roller set: count, mass (kg), inertia (kg·m²), radius (m), spread (m).
#[derive(Debug, Clone, Copy)]
struct Set {
    n: f64,
    m_r: f64,
    i_r: f64,
    r_r: f64,
    spread: f64,
}

/// Two steel-like rollers, uniform discs (I_r = ½ m_r r_r²), 30 mm from their centroid.
const DISCS: Set = Set { n: 2.0, m_r: 0.3, i_r: 0.5 * 0.3 * 0.008 * 0.008, r_r: 0.008, spread: 0.03 };

/// The path kinds of the tests, as written in RON, with the shape and the vertex's centre of
/// curvature P in closed form (epicycloid: ρ_v = ρ₀/(1 + ñ²); bifilar: the circle's centre).
fn paths() -> Vec<(&'static str, &'static str, PathShape, Vec2)> {
    let (rho0, nt) = (0.185, 3.11);
    let (r, l) = (0.17, 0.0152);
    vec![
        (
            "epicycloid",
            "Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11), mount: 0.4)",
            PathShape::Epicycloid { rho0, n_tilde: nt, alpha1: 0.0 },
            Vec2::new(rho0 - rho0 / (1.0 + nt * nt), 0.0),
        ),
        (
            "bifilar",
            "Path(shape: Bifilar(radius: 0.17, length: 0.0152), mount: -1.0)",
            PathShape::Bifilar { radius: r, length: l },
            Vec2::new(r, 0.0),
        ),
    ]
}

fn mount_of(label: &str) -> f64 {
    if label == "epicycloid" { 0.4 } else { -1.0 }
}

fn rollers_ron(s: Set) -> String {
    format!(
        "Rollers(count: {}, mass: {:e}, inertia: {:e}, radius: {:e}, spread: {:e})",
        s.n as u32, s.m_r, s.i_r, s.r_r, s.spread
    )
}

/// The rotor with one absorber on path `kind` carried by `rollers` (RON text, or none), with a
/// path damper `c` (N·s/m), a constant spin torque `torque` (N·m) and gravity `g` (m/s², −y).
fn text(kind: &str, rollers: Option<&str>, speeds: &str, c: f64, torque: f64, g: f64) -> String {
    let rollers = rollers.map_or(String::new(), |r| format!(", rollers: {r}"));
    format!(
        "Mechanism(\n    name: \"rollers\",\n    speeds: {speeds},\n    gravity: (0.0, {}),\n    bodies: [\n        \
         Body(name: \"rotor\", mass: 110.0, inertia: {I_A:e}),\n        Body(name: \"absorber\", mass: {M_ABS:e}, \
         inertia: {I_ABS:e}),\n    ],\n    joints: [\n        Joint(name: \"spin\", parent: \"ground\", child: \
         \"rotor\"),\n        Joint(name: \"path\", parent: \"rotor\", child: \"absorber\", damper: {c:e},\n            \
         kind: {kind}{rollers}),\n    ],\n    loads: [JointTorque(joint: \"spin\", excitation: (mean: {torque:e}))],\n)\n",
        -g
    )
}

fn load(text: &str) -> Result<Mechanism, String> {
    Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::unrestricted()).map_err(|e| e.to_string())
}

/// The test's own model of rotor + absorber + rollers: kinetic and potential energy from the
/// rolling kinematics of the design note, at q = (θ, s) and q̇ = (θ̇, ṡ).
struct Lagrange {
    shape: PathShape,
    mount: f64,
    centre: Vec2,
    set: Set,
    g: f64,
}

impl Lagrange {
    /// (T, V), J.
    fn energies(&self, q: [f64; 2], qd: [f64; 2]) -> (f64, f64) {
        let ([th, s], [thd, sd]) = (q, qd);
        let p = self.shape.at(s);
        let turn = rot2(th + self.mount);
        // Absorber: translates with the rotor's angle (α = 0), its centre of mass on the path.
        let r = turn * p.position;
        let t = turn * p.tangent;
        let v_abs = thd * perp(r) + sd * t;
        // Rollers: centroid halfway between P and the path's point, moving at ½ṡ t relative to
        // the rotor and turning at −ṡ/(2 r_r) relative to it; the spread turns with the rotor.
        let Set { n, m_r, i_r, r_r, spread } = self.set;
        let c = turn * (0.5 * (self.centre + p.position));
        let v_c = thd * perp(c) + 0.5 * sd * t;
        let w_r = thd - sd / (2.0 * r_r);
        let kinetic = 0.5 * I_A * thd * thd
            + 0.5 * M_ABS * v_abs.norm_squared()
            + 0.5 * I_ABS * thd * thd
            + 0.5 * n * m_r * v_c.norm_squared()
            + 0.5 * n * i_r * w_r * w_r
            + 0.5 * n * m_r * spread * spread * thd * thd;
        // Gravity along −y on the absorber and the rollers (the rotor's centre is on the axis).
        let potential = self.g * (M_ABS * r.y + n * m_r * c.y);
        (kinetic, potential)
    }

    /// M by polarisation of the quadratic form T(q̇): exact up to rounding.
    fn mass_matrix(&self, q: [f64; 2]) -> [[f64; 2]; 2] {
        let t = |qd: [f64; 2]| self.energies(q, qd).0;
        let (t0, t1, t01) = (t([1.0, 0.0]), t([0.0, 1.0]), t([1.0, 1.0]));
        [[2.0 * t0, t01 - t0 - t1], [t01 - t0 - t1, 2.0 * t1]]
    }

    /// F of `M q̈ = F` from Lagrange's equations, `F = Q + ∂L/∂q − Ṁ q̇` (L = T − V), with the
    /// derivatives by central differences extrapolated once (Richardson: error O(h⁴)).
    fn forcing(&self, q: [f64; 2], qd: [f64; 2], q_gen: [f64; 2], scale: f64) -> [f64; 2] {
        let lag = |q: [f64; 2]| {
            let (t, v) = self.energies(q, qd);
            t - v
        };
        let richardson = |f: &dyn Fn(f64) -> f64, h: f64| {
            let d = |h: f64| (f(h) - f(-h)) / (2.0 * h);
            (4.0 * d(0.5 * h) - d(h)) / 3.0
        };
        let mut out = q_gen;
        // ∂L/∂q_k: steps 1e-3 rad in θ and 1e-3 of the path's scale in s.
        for (k, h) in [(0, 1e-3), (1, 1e-3 * scale)] {
            let f = |e: f64| {
                let mut qq = q;
                qq[k] += e;
                lag(qq)
            };
            out[k] += richardson(&f, h);
        }
        // Ṁ q̇ = d/dε [M(q + ε q̇) q̇] at ε = 0, a step that moves θ by ≤ 1e-3 rad and s by ≤ 1e-3 scale.
        let h = (1e-3 / qd[0].abs()).min(1e-3 * scale / qd[1].abs());
        for k in 0..2 {
            let f = |e: f64| {
                let m = self.mass_matrix([q[0] + e * qd[0], q[1] + e * qd[1]]);
                m[k][0] * qd[0] + m[k][1] * qd[1]
            };
            out[k] -= richardson(&f, h);
        }
        out
    }
}

/// M and F of the engine (both speed choices; for this tree u = q̇ either way: the path joint
/// does not rotate) equal Lagrange's equations of the kinetic energy written above, at 40 random
/// states per path, with a path damper, a spin torque and gravity on the absorber and rollers.
/// M by polarisation is exact to rounding (1e-12); F carries the O(h⁴) truncation of the
/// extrapolated differences, (1e-3)⁴ relative, and their rounding, 1e-16 · T/h ≈ 1e-10 of F:
/// the bound 1e-7 holds with margin.
#[test]
fn mass_matrix_and_forcing_equal_lagrange_with_rollers() {
    let mut rng = StdRng::seed_from_u64(14);
    let (c, torque, g) = (3.0, 250.0, 9.81);
    let mut worst = (0.0f64, 0.0f64);
    for (label, kind, shape, centre) in paths() {
        let model = Lagrange { shape, mount: mount_of(label), centre, set: DISCS, g };
        let scale = shape.length_scale().min(0.1 * shape.travel());
        for speeds in ["JointRates", "AbsoluteAngularVelocities"] {
            let mech = load(&text(kind, Some(&rollers_ron(DISCS)), speeds, c, torque, g)).unwrap();
            let mut kane = Kane::new(&mech).unwrap();
            for _ in 0..40 {
                let s_max = 0.9 * shape.travel().min(0.02);
                let q = [rng.random_range(-3.0..3.0), rng.random_range(-s_max..s_max)];
                let qd = [rng.random_range(-300.0..300.0), rng.random_range(-3.0..3.0)];
                let (m, f) = kane.mass_matrix_and_forcing(0.0, &q, &qd);
                let m_l = model.mass_matrix(q);
                let f_l = model.forcing(q, qd, [torque, -c * qd[1]], scale);
                let m_err =
                    (0..2).flat_map(|r| (0..2).map(move |k| (r, k))).map(|(r, k)| (m[(r, k)] - m_l[r][k]).abs());
                let m_rel = m_err.fold(0.0, f64::max) / m_l[0][0].abs().max(m_l[1][1].abs());
                let f_norm = f_l[0].hypot(f_l[1]);
                let f_rel = (f[0] - f_l[0]).hypot(f[1] - f_l[1]) / f_norm;
                worst = (worst.0.max(m_rel), worst.1.max(f_rel));
                assert!(m_rel <= 1e-12, "{label} {speeds} at {q:?}: M {m} vs {m_l:?} ({m_rel:e})");
                assert!(f_rel <= 1e-7, "{label} {speeds} at {q:?} {qd:?}: F {f} vs {f_l:?} ({f_rel:e})");
            }
        }
    }
    println!("largest relative difference to Lagrange: M {:.2e}, F {:.2e}", worst.0, worst.1);
}

/// ½uᵀMu equals the kinetic energy summed body by body with the rollers
/// (`kane::kinematics::kinetic_energy`), and the test's own T, to rounding (1e-12), at random
/// states; without gravity so that the evaluation uses the rotor's own frame.
#[test]
fn half_u_m_u_is_the_kinetic_energy_with_rollers() {
    let mut rng = StdRng::seed_from_u64(41);
    let mut worst = 0.0f64;
    for (label, kind, shape, centre) in paths() {
        let model = Lagrange { shape, mount: mount_of(label), centre, set: DISCS, g: 0.0 };
        let mech = load(&text(kind, Some(&rollers_ron(DISCS)), "JointRates", 0.0, 0.0, 0.0)).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        for _ in 0..40 {
            let s_max = 0.9 * shape.travel().min(0.02);
            let q = [rng.random_range(-3.0..3.0), rng.random_range(-s_max..s_max)];
            let u = [rng.random_range(-300.0..300.0), rng.random_range(-3.0..3.0)];
            let m = kane.mass_matrix(&q);
            let half_umu =
                0.5 * (u[0] * (m[(0, 0)] * u[0] + m[(0, 1)] * u[1]) + u[1] * (m[(1, 0)] * u[0] + m[(1, 1)] * u[1]));
            let summed = kinetic_energy(&mech, &q, &u);
            let own = model.energies(q, u).0;
            for (what, e) in [("kinematics::kinetic_energy", summed), ("the test's T", own)] {
                let rel = (half_umu - e).abs() / e;
                worst = worst.max(rel);
                assert!(rel <= 1e-12, "{label}: ½uᵀMu {half_umu} vs {what} {e} ({rel:e})");
            }
        }
    }
    println!("½uᵀMu against the summed kinetic energy: largest relative difference {worst:.2e}");
}

/// The tuning order with rollers: at held spin the absorber's s-inertia is
/// m + N(m_r + I_r/r_r²)/4 and its centrifugal stiffness Ω²ñ²(m + N m_r/2) (design note), so
/// n_t² = ñ²(m + N m_r/2)/(m + N(m_r + I_r/r_r²)/4). The linear analysis with the spin held
/// (the closed form's assumption: constant Ω) equals it to 1e-12 relative (Richardson-extrapolated
/// differences; the path's s-row is linear in s up to O(s³) terms the extrapolation removes), and
/// so does the reported n_t (`kanedyn check`, study summaries, Python's `check()`).
#[test]
fn held_spin_tuning_order_with_rollers_equals_the_closed_form() {
    let omega = 1000.0 * std::f64::consts::PI / 30.0;
    let heavy = Set { n: 3.0, m_r: 0.5, i_r: 2.0e-5, r_r: 0.01, spread: 0.0 };
    let mut report = Vec::new();
    for (label, kind, shape, _) in paths() {
        let (_, n2, _, _) = shape.taylor();
        for set in [DISCS, heavy] {
            let Set { n, m_r, i_r, r_r, .. } = set;
            let want2 = n2 * (M_ABS + 0.5 * n * m_r) / (M_ABS + 0.25 * n * (m_r + i_r / (r_r * r_r)));
            let want = want2.sqrt();
            let mech = load(&text(kind, Some(&rollers_ron(set)), "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
            let lin = LinearModel::new(&mech, "spin", omega, None).unwrap();
            let held = lin.modes(Spin::Held, Damping::Undamped).unwrap();
            assert_eq!(held.modes.len(), 1);
            let got = held.modes[0].order;
            let rel = (got - want).abs() / want;
            report.push(format!(
                "{label} N={n}: n_t {got:.9} (closed form {want:.9}, without rollers {:.9}, {rel:.1e})",
                n2.sqrt()
            ));
            assert!(rel <= 1e-12, "{label} {set:?}: n_t {got} vs closed form {want} ({rel:e})");
            let props = &absorbers(&mech)[0];
            assert!(
                abs_diff_eq!(props.tuning_order_squared, want2, epsilon = 1e-14 * want2),
                "{label}: reported {props:?}"
            );
            assert_abs_diff_eq!(props.plain_tuning_order_squared, n2, epsilon = 1e-14 * n2);
            assert!(props.rollers.is_some());
        }
    }
    println!("{}", report.join("\n"));
}

/// The reported nonlinear coefficient with rollers, κ = (3/8)K₂/K₀ (design note), against the
/// s⁴ coefficient of the held-spin potential V(s) = −½(m ρ² + N m_r |c̄|²) computed here from the
/// curve: (V(s) − V(0) − ½K₀s²)/s⁴ → K₂/4, at s = h and 2h, extrapolated (truncation
/// O((h/s_max)⁴) ≈ 1e-6; rounding 1e-17·|V|/h⁴ ≈ 2e-5 of K₂/4 at h = 5e-4 m): 1e-4 relative.
/// Massive rollers make even the epicycloid non-tautochronic, which the report says.
#[test]
fn nonlinear_coefficient_with_rollers_equals_the_potential() {
    for (label, kind, shape, centre) in paths() {
        let (_, n2, _, _) = shape.taylor();
        let Set { n, m_r, .. } = DISCS;
        let k0 = n2 * (M_ABS + 0.5 * n * m_r);
        let potential = |s: f64| {
            let p = shape.at(s).position;
            let c = 0.5 * (centre + p);
            -0.5 * (M_ABS * p.norm_squared() + n * m_r * c.norm_squared())
        };
        let quartic = |h: f64| (potential(h) - potential(0.0) - 0.5 * k0 * h * h) / h.powi(4);
        let h = 5e-4;
        let k2 = 4.0 * (4.0 * quartic(h) - quartic(2.0 * h)) / 3.0;
        let want = 0.375 * k2 / k0;
        let mech = load(&text(kind, Some(&rollers_ron(DISCS)), "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
        let props = &absorbers(&mech)[0];
        let rel = (props.nonlinear - want).abs() / want.abs();
        println!("{label}: κ with rollers {:.6e} 1/m², from the potential {want:.6e} ({rel:.1e})", props.nonlinear);
        assert!(rel <= 1e-4, "{label}: κ {} vs {want}", props.nonlinear);
        assert_eq!(props.tautochronic, Tautochronism::No, "{label}");
        let md = markdown(&mech);
        assert!(md.contains("on 2 rollers") && md.contains("Rollers included for `path`"), "{md}");
    }
}

/// A free, undamped run (spin free at 100 rad/s, absorber released at half its travel, no
/// torque): the kinetic energy with the rollers is conserved. DOP853 at rtol = atol = 1e-12 over
/// 1 s (about 50 absorber periods); 1e-9 is the bound.
#[test]
fn free_undamped_run_with_rollers_conserves_energy() {
    for (label, kind, shape, _) in paths() {
        let mech = load(&text(kind, Some(&rollers_ron(DISCS)), "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        let s0 = 0.5 * shape.travel().min(0.02);
        let x0 = [0.0, s0, 100.0, 0.0];
        let energy = |x: &[f64]| kinetic_energy(&mech, &x[..2], &x[2..]);
        let e0 = energy(&x0);
        let mut worst = 0.0f64;
        let opts =
            IntegrateOptions { rtol: 1e-12, atol: 1e-12, sample_rate_hz: Some(500.0), ..IntegrateOptions::default() };
        integrate(
            |t, x, dx| kane.rhs(t, x, dx),
            &x0,
            0.0,
            1.0,
            &opts,
            |smp| {
                worst = worst.max((energy(smp.x) - e0).abs() / e0);
            },
        )
        .unwrap();
        println!("{label}: largest relative energy change {worst:.2e}");
        assert!(worst <= 1e-9, "{label}: energy drifted by {worst:e}");
    }
}

/// Rollers of zero mass and inertia change nothing: M, F and ẋ equal the plain path joint's at
/// random states (the rollers' node adds exact zeros to the same sums; only the sign of a zero
/// may differ), and so does the held-spin tuning order.
#[test]
fn massless_rollers_reproduce_the_plain_path_joint() {
    let mut rng = StdRng::seed_from_u64(3);
    let ghost = Set { n: 4.0, m_r: 0.0, i_r: 0.0, r_r: 0.01, spread: 0.02 };
    for (label, kind, shape, _) in paths() {
        for speeds in ["JointRates", "AbsoluteAngularVelocities"] {
            let plain = load(&text(kind, None, speeds, 2.0, 100.0, 9.81)).unwrap();
            let with = load(&text(kind, Some(&rollers_ron(ghost)), speeds, 2.0, 100.0, 9.81)).unwrap();
            let (mut kp, mut kw) = (Kane::new(&plain).unwrap(), Kane::new(&with).unwrap());
            for _ in 0..20 {
                let s_max = 0.9 * shape.travel().min(0.02);
                let x = [
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-s_max..s_max),
                    rng.random_range(-300.0..300.0),
                    rng.random_range(-3.0..3.0),
                ];
                let (mp, fp) = kp.mass_matrix_and_forcing(0.0, &x[..2], &x[2..]);
                let (mp, fp) = (mp.clone(), fp.clone());
                let (mw, fw) = kw.mass_matrix_and_forcing(0.0, &x[..2], &x[2..]);
                assert_eq!(&mp, mw, "{label} {speeds}: M");
                assert_eq!(&fp, fw, "{label} {speeds}: F");
                let (mut dp, mut dw) = ([0.0; 4], [0.0; 4]);
                kp.rhs(0.0, &x, &mut dp).unwrap();
                kw.rhs(0.0, &x, &mut dw).unwrap();
                assert_eq!(dp, dw, "{label} {speeds}: ẋ");
            }
        }
        let plain = load(&text(kind, None, "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
        let with = load(&text(kind, Some(&rollers_ron(ghost)), "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
        let order = |m: &Mechanism| {
            LinearModel::new(m, "spin", 100.0, None).unwrap().modes(Spin::Held, Damping::Undamped).unwrap().modes[0]
                .order
        };
        assert_eq!(order(&plain), order(&with), "{label}: held-spin order");
        assert_eq!(absorbers(&with)[0].tautochronic, absorbers(&plain)[0].tautochronic);
    }
}

/// Locking the path joint welds the rollers with the absorber: the locked rotor's inertia is
/// I_A + I + m ρ₀² + N m_r |c̄(0)|² + N I_r + N m_r spread² (c̄(0) = ½(P + r(0)) at ½(P_x + ρ₀)
/// from the axis), to rounding; the total mass counts the rollers.
#[test]
fn locking_welds_the_rollers() {
    for (label, kind, shape, centre) in paths() {
        let mech = load(&text(kind, Some(&rollers_ron(DISCS)), "AbsoluteAngularVelocities", 0.0, 0.0, 0.0)).unwrap();
        let locked = mech.lock("path", 0.0).unwrap();
        let m = Kane::new(&locked).unwrap().mass_matrix(&[0.0])[(0, 0)];
        let rho0 = shape.at(0.0).position.x;
        let Set { n, m_r, i_r, spread, .. } = DISCS;
        let c0 = 0.5 * (centre.x + rho0);
        let want = I_A + I_ABS + M_ABS * rho0 * rho0 + n * m_r * c0 * c0 + n * i_r + n * m_r * spread * spread;
        assert!(abs_diff_eq!(m, want, epsilon = 1e-13 * want), "{label}: locked {m} vs {want}");
        assert_abs_diff_eq!(mech.total_mass(), 110.0 + M_ABS + n * m_r, epsilon = 1e-12);
    }
}

/// Bad rollers are located errors naming the field (and, for the placement, the joint): a path
/// that turns its body (the derivation holds for a translating absorber only), rollers on a
/// revolute joint, count 0, negative mass or inertia, radius ≤ 0, NaN, a negative spread.
#[test]
fn bad_rollers_are_located_errors() {
    let good = "Rollers(count: 2, mass: 0.3, inertia: 1e-5, radius: 0.008)";
    let epi = "Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11))";
    assert!(load(&text(epi, Some(good), "JointRates", 0.0, 0.0, 0.0)).is_ok());
    let cases = [
        ("Path(shape: Circle(radius: 0.17, length: 0.0152))", good, "rollers", "translating absorber"),
        ("Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11, alpha1: 5.0))", good, "rollers", "translating absorber"),
        ("Path(shape: General(rho0: 0.185, n_tilde: 3.2, alpha: [5.0]))", good, "rollers", "translating absorber"),
        ("Revolute", good, "rollers", "path absorber"),
        (epi, "Rollers(count: 0, mass: 0.3, inertia: 1e-5, radius: 0.008)", "rollers.count", "at least one"),
        (epi, "Rollers(count: 2, mass: -0.3, inertia: 1e-5, radius: 0.008)", "rollers.mass", "non-negative"),
        (epi, "Rollers(count: 2, mass: 0.3, inertia: -1e-5, radius: 0.008)", "rollers.inertia", "non-negative"),
        (epi, "Rollers(count: 2, mass: NaN, inertia: 1e-5, radius: 0.008)", "rollers.mass", "NaN"),
        (epi, "Rollers(count: 2, mass: 0.3, inertia: 1e-5, radius: 0.0)", "rollers.radius", "positive"),
        (epi, "Rollers(count: 2, mass: 0.3, inertia: 1e-5, radius: -0.008)", "rollers.radius", "positive"),
        (epi, "Rollers(count: 2, mass: 0.3, inertia: 1e-5, radius: inf)", "rollers.radius", "finite"),
        (
            epi,
            "Rollers(count: 2, mass: 0.3, inertia: 1e-5, radius: 0.008, spread: -0.1)",
            "rollers.spread",
            "non-negative",
        ),
    ];
    for (kind, rollers, field, words) in cases {
        let msg = load(&text(kind, Some(rollers), "JointRates", 0.0, 0.0, 0.0)).expect_err(rollers);
        assert!(msg.starts_with("m.ron:1"), "{kind} {rollers}: not located: {msg}");
        assert!(msg.contains(&format!("`joints[1].{field}`")), "{kind} {rollers}: field {field}: {msg}");
        assert!(msg.contains(words), "{kind} {rollers}: {msg}");
        if field == "rollers" {
            assert!(msg.contains("joint `path`"), "{msg}");
        }
        println!("{msg}");
    }
    // A negative count is not a count: the parser refuses it where it is written.
    let msg = load(&text(
        epi,
        Some("Rollers(count: -2, mass: 0.3, inertia: 1e-5, radius: 0.008)"),
        "JointRates",
        0.0,
        0.0,
        0.0,
    ))
    .unwrap_err();
    assert!(msg.starts_with("m.ron:1") && msg.contains("count"), "{msg}");
}

/// The catalog part (the README's example) loads in a mechanism and reports the closed form.
#[test]
fn catalog_rollers_part_loads() {
    let text = "Mechanism(\n    name: \"m\",\n    speeds: AbsoluteAngularVelocities,\n    bodies: [\n        \
                Body(name: \"rotor\", part: \"catalog:bodies/flywheel_rotor.ron\"),\n        Body(name: \"absorber\", mass: 6.0, \
                inertia: 2.16e-4),\n    ],\n    joints: [\n        Joint(name: \"spin\", parent: \"ground\", child: \
                \"rotor\"),\n        Joint(name: \"path\", part: \"catalog:joints/path_rollers.ron\", parent: \"rotor\", child: \
                \"absorber\"),\n    ],\n)\n";
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let file = dir.join("rollers_part_test.ron");
    let src = Source::from_text(file.to_str().unwrap(), text);
    let mech = Mechanism::from_source(&src, &ReadPolicy::unrestricted()).unwrap();
    let j = mech.joint_index("path").unwrap();
    let r = mech.joints[j].rollers.expect("the part declares rollers");
    let JointKind::Path { shape, .. } = mech.joints[j].kind else { panic!("not a path joint") };
    let (_, n2, _, _) = shape.taylor();
    let (n, m_r, i_r, r_r) = (f64::from(r.count), r.mass, r.inertia, r.radius);
    let want = n2 * (6.0 + 0.5 * n * m_r) / (6.0 + 0.25 * n * (m_r + i_r / (r_r * r_r)));
    let props = &absorbers(&mech)[0];
    assert_abs_diff_eq!(props.tuning_order_squared, want, epsilon = 1e-14 * want);
    let lin = LinearModel::new(&mech, "spin", 100.0, None).unwrap();
    let got = lin.modes(Spin::Held, Damping::Undamped).unwrap().modes[0].order;
    assert!(abs_diff_eq!(got * got, want, epsilon = 1e-11 * want), "{got} vs {}", want.sqrt());
    println!("{}", markdown(&mech));
}

/// Joint reactions with rollers (Newton–Euler after the accelerations): the spin bearing carries
/// the rate of change of the whole linear momentum less the weight, rollers included, and the
/// path joint passes to the absorber its own m a − m g (the rollers sit in the rotor's subtree).
/// The momenta come from the test's kinematics, differentiated along the motion (q + εq̇ + ½ε²q̈,
/// q̇ + εq̈) by central differences extrapolated once: truncation O(ε⁴), rounding 1e-16·|P|/ε;
/// 1e-7 of the force.
#[test]
fn reactions_include_the_rollers() {
    use kanedyn::kane::reactions::joint_reactions;
    let mut rng = StdRng::seed_from_u64(5);
    let g = 9.81;
    for (label, kind, shape, centre) in paths() {
        let model = Lagrange { shape, mount: mount_of(label), centre, set: DISCS, g };
        let mech = load(&text(kind, Some(&rollers_ron(DISCS)), "JointRates", 3.0, 250.0, g)).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        // Linear momenta (absorber, rollers) from the kinematics written in `Lagrange::energies`.
        let momenta = |q: [f64; 2], qd: [f64; 2]| {
            let p = shape.at(q[1]);
            let turn = rot2(q[0] + model.mount);
            let (r, t) = (turn * p.position, turn * p.tangent);
            let c = turn * (0.5 * (centre + p.position));
            let v_abs = qd[0] * perp(r) + qd[1] * t;
            let v_c = qd[0] * perp(c) + 0.5 * qd[1] * t;
            (M_ABS * v_abs, DISCS.n * DISCS.m_r * v_c)
        };
        for _ in 0..10 {
            let s_max = 0.9 * shape.travel().min(0.02);
            let x = [
                rng.random_range(-3.0..3.0),
                rng.random_range(-s_max..s_max),
                rng.random_range(-300.0..300.0),
                rng.random_range(-3.0..3.0),
            ];
            let mut xd = [0.0; 4];
            kane.rhs(0.0, &x, &mut xd).unwrap();
            let (q, qd, qdd) = ([x[0], x[1]], [x[2], x[3]], [xd[2], xd[3]]);
            let along = |e: f64| {
                let qe = [q[0] + e * qd[0] + 0.5 * e * e * qdd[0], q[1] + e * qd[1] + 0.5 * e * e * qdd[1]];
                momenta(qe, [qd[0] + e * qdd[0], qd[1] + e * qdd[1]])
            };
            let rate = |h: f64| {
                let ((a1, r1), (a0, r0)) = (along(h), along(-h));
                ((a1 - a0) / (2.0 * h), (r1 - r0) / (2.0 * h))
            };
            let h = 1e-3 / qd[0].abs().max(qd[1].abs() / 1e-2);
            let ((a_h, r_h), (a_2h, r_2h)) = (rate(0.5 * h), rate(h));
            let (dp_abs, dp_rol) = ((4.0 * a_h - a_2h) / 3.0, (4.0 * r_h - r_2h) / 3.0);
            let weight = Vec2::new(0.0, -g);
            let want_path = dp_abs - M_ABS * weight;
            let want_spin = dp_abs + dp_rol - (110.0 + M_ABS + DISCS.n * DISCS.m_r) * weight;
            let re = joint_reactions(&mech, &q, &qd, &qdd);
            for (what, got, want) in [("spin", re[0].force_world, want_spin), ("path", re[1].force_world, want_path)] {
                let rel = (got - want).norm() / want.norm();
                assert!(rel <= 1e-7, "{label} {what}: {got:?} vs {want:?} ({rel:e})");
            }
        }
    }
}

/// A geared mechanism's unconstrained tree carries the rollers: a shaft geared to the spin
/// (joint rates, as gears require) leaves the held-spin tuning order at the closed form (1e-12).
#[test]
fn geared_mechanism_keeps_the_rollers() {
    let (label, kind, shape, _) = paths().swap_remove(0);
    let plain = text(kind, Some(&rollers_ron(DISCS)), "JointRates", 0.0, 0.0, 0.0);
    let geared = plain
        .replace(
            "    ],\n    joints: [",
            "        Body(name: \"shaft\", mass: 2.0, inertia: 0.01),\n    ],\n    joints: [\n        \
             Joint(name: \"drive\", parent: \"ground\", child: \"shaft\", at: (0.5, 0.0)),",
        )
        .replace("    loads:", "    gears: [Gear(joint: \"drive\", follows: \"spin\", ratio: -2.5)],\n    loads:");
    let mech = load(&geared).unwrap();
    assert!(mech.is_geared() && mech.ndof() == 2, "{geared}");
    let (_, n2, _, _) = shape.taylor();
    let Set { n, m_r, i_r, r_r, .. } = DISCS;
    let want = (n2 * (M_ABS + 0.5 * n * m_r) / (M_ABS + 0.25 * n * (m_r + i_r / (r_r * r_r)))).sqrt();
    let lin = LinearModel::new(&mech, "spin", 100.0, None).unwrap();
    let got = lin.modes(Spin::Held, Damping::Undamped).unwrap().modes[0].order;
    assert!(abs_diff_eq!(got, want, epsilon = 1e-12 * want), "{label}: {got} vs {want}");
}
