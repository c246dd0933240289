//! The general path `ρ² = ρ₀² − ñ²s² + x₄s⁴ + …` with the rotation law `α = α₁s + α₃s³ + …`
//! (issue 14), the travel limit and the absorber properties, against numbers from outside the
//! engine: the epicycloid's closed form (a general path with only ρ₀, ñ is one), an independent
//! Gauss–Legendre quadrature of θ' = √(1 − ρ'²)/ρ, finite differences of the curve, the
//! closed-form tuning orders (eq. 15, R/L, m ñ²/(m + I α₁²)) and the linear analysis' eigenvalue
//! at held spin, the compound pendulum's exact frequency (elliptic integral) for the nonlinear
//! coefficient, and located errors for bad input.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::error::EngineError;
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::kane::Kane;
use kanedyn::linear::{Damping, LinearModel, Spin};
use kanedyn::model::absorber::{Tautochronism, absorbers, markdown, roller_tuning_order_squared};
use kanedyn::model::body::BodySpec;
use kanedyn::model::joint::{JointKind, JointSpec};
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::path::PathShape;
use kanedyn::model::speeds::Speeds;
use kanedyn::time::drive_laws::{Drive, Prescribed};
use kanedyn::time::integrate::{IntegrateOptions, integrate};
use std::f64::consts::PI;

fn body(name: &str, mass: f64, inertia: Option<f64>) -> BodySpec {
    BodySpec { name: Some(name.into()), mass: Some(mass), com: Some((0.0, 0.0)), inertia, ..BodySpec::default() }
}

/// A rotor (10 kg, 0.36 kg·m²) carrying one body (m, I) on a path joint `path` about its axis.
fn rotor_with(kind: JointKind, m: f64, i_b: Option<f64>) -> Mechanism {
    let joint = |name: &str, kind: JointKind, parent: &str, child: &str| JointSpec {
        name: Some(name.into()),
        kind: Some(kind),
        parent: Some(parent.into()),
        child: Some(child.into()),
        at: Some((0.0, 0.0)),
        ..JointSpec::default()
    };
    Mechanism::from_spec(&MechanismSpec {
        base: None,
        name: "general".into(),
        speeds: Speeds::AbsoluteAngularVelocities,
        gravity: (0.0, 0.0),
        bodies: vec![body("rotor", 10.0, Some(0.36)), body("absorber", m, i_b)],
        joints: vec![joint("spin", JointKind::Revolute, "ground", "rotor"), joint("path", kind, "rotor", "absorber")],
        loads: vec![],
        gears: vec![],
    })
    .unwrap()
}

fn path(shape: PathShape) -> JointKind {
    JointKind::Path { shape, mount: 0.0, travel: None }
}

/// A general path with only ρ₀ and ñ is the epicycloid: position, tangent and curvature agree
/// with the closed form to 1e-13 (relative to ρ₀, 1 and the curvature) from the vertex to 99.9 %
/// of the cusp, and its end is the cusp s_max = ρ₀/(ñ√(1+ñ²)) to 1e-13. The table's own error is
/// ≈ 1e-15 (rounding of its sums); the curvature's w' = −ρ'ρ''/w loses digits only as w → 0.
#[test]
fn general_with_rho0_and_n_tilde_is_the_epicycloid() {
    let mut worst = [0.0f64; 3];
    for (rho0, n) in [(0.185, 3.11), (0.5, 0.7), (0.1, 1.5), (0.3, 8.0)] {
        let epi = PathShape::Epicycloid { rho0, n_tilde: n, alpha1: 0.0 };
        let general = PathShape::general(rho0, n, &[], &[]);
        let s_max = epi.travel();
        assert!(
            abs_diff_eq!(general.travel(), s_max, epsilon = 1e-13 * s_max),
            "end {} vs cusp {s_max}",
            general.travel()
        );
        let PathShape::General(g) = general else { unreachable!() };
        for k in -20..=20 {
            let f = 0.999 * k as f64 / 20.0;
            let (a, b) = (epi.at(f * s_max), general.at(f * s_max));
            worst[0] = worst[0].max((a.position - b.position).norm() / rho0);
            worst[1] = worst[1].max((a.tangent - b.tangent).norm());
            worst[2] = worst[2].max((a.curvature - b.curvature).norm() / a.curvature.norm());
        }
        println!("ρ₀ {rho0}, ñ {n}: θ table of {} terms", g.table_terms());
    }
    println!("general vs epicycloid: position {:.1e}, tangent {:.1e}, curvature {:.1e}", worst[0], worst[1], worst[2]);
    assert!(worst[0] <= 1e-13 && worst[1] <= 1e-13, "{worst:?}");
    assert!(worst[2] <= 1e-11, "curvature {worst:?}");
}

/// θ(s) by an independent route: composite 20-point Gauss–Legendre quadrature (nodes by Newton
/// on the Legendre recurrence) of θ' = √(1 − ρ'²)/ρ, ρ' from the polynomial, on 64 panels up to
/// 0.9 s_end, where the integrand is smooth (its square root is 0 only at s_end): the quadrature
/// error is far below rounding. The path's polar angle atan2(y, x) agrees to 1e-13. Also: |t| = 1,
/// ρ² is the declared polynomial, and the tangent, curvature, α' and α'' are central
/// differences of the position and α (step 1e-6 m: truncation ~1e-12·|r'''|, rounding ~1e-10).
#[test]
fn general_curve_is_the_declared_polynomial_path() {
    let (rho0, n, x4, x6) = (0.2, 2.5, -900.0, 4.0e5);
    let alpha = [3.0, -2000.0];
    let shape = PathShape::general(rho0, n, &[x4, x6], &alpha);
    let s_end = shape.travel();
    assert!(s_end.is_finite() && s_end > 0.0);
    let rho2 = |s: f64| rho0 * rho0 - n * n * s * s + x4 * s.powi(4) + x6 * s.powi(6);
    let drho2 = |s: f64| -2.0 * n * n * s + 4.0 * x4 * s.powi(3) + 6.0 * x6 * s.powi(5);
    let dtheta = |s: f64| {
        let r2 = rho2(s);
        let dr = drho2(s) / (2.0 * r2.sqrt());
        (1.0 - dr * dr).sqrt() / r2.sqrt()
    };
    // |dρ/ds| = 1 at the end: the polynomial's own condition, checked there.
    let dr_end = drho2(s_end) / (2.0 * rho2(s_end).sqrt());
    assert!(abs_diff_eq!(dr_end.abs(), 1.0, epsilon = 1e-6), "|dρ/ds| at the end: {dr_end}");
    let (nodes, weights) = gauss_legendre(20);
    let mut worst = 0.0f64;
    for f in [0.1, 0.3, 0.6, 0.9] {
        let s = f * s_end;
        let panels = 64;
        let h = s / panels as f64;
        let mut theta = 0.0;
        for p in 0..panels {
            let mid = (p as f64 + 0.5) * h;
            for (x, w) in nodes.iter().zip(&weights) {
                theta += 0.5 * h * w * dtheta(mid + 0.5 * h * x);
            }
        }
        let pt = shape.at(s);
        let got = pt.position.y.atan2(pt.position.x);
        worst = worst.max((got - theta).abs() / theta);
        assert!(abs_diff_eq!(pt.position.norm_squared(), rho2(s), epsilon = 1e-15), "ρ² at {s}");
        assert_abs_diff_eq!(pt.tangent.norm(), 1.0, epsilon = 1e-14);
        let hh = 1e-6;
        let (a, b) = (shape.at(s + hh), shape.at(s - hh));
        assert!(((a.position - b.position) / (2.0 * hh) - pt.tangent).norm() <= 1e-8, "tangent at {s}");
        assert!(((a.tangent - b.tangent) / (2.0 * hh) - pt.curvature).norm() <= 1e-7 * pt.curvature.norm(), "κ at {s}");
        let al = |s: f64| alpha[0] * s + alpha[1] * s.powi(3);
        assert_abs_diff_eq!(pt.alpha, al(s), epsilon = 1e-15);
        assert_abs_diff_eq!((a.alpha - b.alpha) / (2.0 * hh), pt.dalpha, epsilon = 1e-8);
        assert_abs_diff_eq!((a.dalpha - b.dalpha) / (2.0 * hh), pt.ddalpha, epsilon = 1e-6);
    }
    println!("θ: table vs Gauss–Legendre, worst relative {worst:.1e}");
    assert!(worst <= 1e-13, "θ differs from the quadrature by {worst:e}");
    assert!(shape.at(1.0001 * s_end).position.x.is_nan() && shape.at(f64::NAN).tangent.x.is_nan());
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n from the Chebyshev guesses).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = Vec::new();
    let mut weights = Vec::new();
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let k = k as f64;
                (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        nodes.push(x);
        weights.push(2.0 / ((1.0 - x * x) * dp * dp));
    }
    (nodes, weights)
}

/// Linear tuning order at held spin from the linear analysis against the closed forms and the
/// absorber properties: general path with a rotation law → m ñ²/(m + I α₁²) (x₄, α₃ do not
/// enter), bifilar → R/L whatever the inertia, circle → eq. (15) m R L/(I + m L²). Bound 1e-12
/// (the Jacobians are Richardson-extrapolated differences; the s-row's curvature terms are exact
/// polynomials of the step).
#[test]
fn tuning_orders_equal_closed_forms_and_the_linear_analysis() {
    let omega = 150.0;
    let (m, i_b) = (6.0, 2.0e-3);
    let (r, l) = (0.17, 0.0152);
    let (n, a1) = (1.7, 40.0);
    let cases = [
        ("general α₁, x₄, α₃", PathShape::general(0.185, n, &[-300.0], &[a1, 500.0]), m * n * n / (m + i_b * a1 * a1)),
        ("general, translating", PathShape::general(0.185, 3.11, &[800.0], &[]), 3.11 * 3.11),
        ("bifilar", PathShape::Bifilar { radius: r, length: l }, r / l),
        ("circle (eq. 15)", PathShape::Circle { radius: r, length: l }, m * r * l / (i_b + m * l * l)),
    ];
    let mut report = Vec::new();
    for (label, shape, want) in cases {
        let mech = rotor_with(path(shape), m, Some(i_b));
        let lin = LinearModel::new(&mech, "spin", omega, None).unwrap();
        let held = lin.modes(Spin::Held, Damping::Undamped).unwrap();
        let got = held.modes[0].order.powi(2);
        let props = &absorbers(&mech)[0];
        let (rel, rel_props) = ((got - want).abs() / want, (props.tuning_order_squared - want).abs() / want);
        report.push(format!("{label}: linear {rel:.1e}, properties {rel_props:.1e}"));
        assert!(rel <= 1e-12, "{label}: n_t² {got} vs {want}");
        assert!(rel_props <= 1e-14, "{label}: properties n_t² {} vs {want}", props.tuning_order_squared);
    }
    // The bifilar's order does not depend on the inertia; the properties say so too.
    let heavy = rotor_with(path(PathShape::Bifilar { radius: r, length: l }), m, Some(100.0 * i_b));
    assert_abs_diff_eq!(absorbers(&heavy)[0].tuning_order_squared, r / l, epsilon = 1e-14 * r / l);
    println!("n_t²: {}", report.join("; "));
}

/// Complete elliptic integral K(k) by the arithmetic-geometric mean.
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    for _ in 0..8 {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    PI / (2.0 * a)
}

/// The nonlinear coefficient κ of `n(A) ≈ n_t (1 + κA²)`: for the compound pendulum (circle,
/// and the revolute CPVA) the exact ratio π/(2K(sin(φ₀/2))) = 1 − φ₀²/16 + O(φ₀⁴), so κ must be
/// −1/(16 L²) (checked against the elliptic integral's slope at φ₀ = 0.01, whose O(φ₀²) remainder
/// is ~1e-5 relative). For a general path with x₄ and α₃, κ is checked against the engine's
/// free oscillation at held spin at A = 1 mm, where the O(A⁴) remainder is ~(κA²)² relative.
#[test]
fn nonlinear_coefficient_matches_the_free_oscillation() {
    let (r, l) = (0.17, 0.0152);
    let circle = rotor_with(path(PathShape::Circle { radius: r, length: l }), 6.0, Some(2.16e-4));
    let kappa = absorbers(&circle)[0].nonlinear;
    let phi0: f64 = 0.01;
    let slope = (PI / (2.0 * elliptic_k((0.5 * phi0).sin())) - 1.0) / (phi0 * phi0);
    assert!(
        abs_diff_eq!(kappa * l * l, slope, epsilon = 1e-4 / 16.0),
        "κL² = {} vs the elliptic slope {slope}",
        kappa * l * l
    );
    assert_abs_diff_eq!(kappa * l * l, -1.0 / 16.0, epsilon = 1e-15);
    // The general path: measure the order after 10 periods (phase of (s, −ṡ/ω)).
    let (m, i_b, omega) = (6.0, 2.0e-3, 150.0);
    let shape = PathShape::general(0.185, 2.0, &[-3000.0], &[20.0, 4000.0]);
    let mech = rotor_with(path(shape), m, Some(i_b));
    let props = &absorbers(&mech)[0];
    let want_kappa = -0.75 * -3000.0 / 4.0 - 1.5 * i_b * 20.0 * 4000.0 / (m + i_b * 400.0);
    assert_abs_diff_eq!(props.nonlinear, want_kappa, epsilon = 1e-12 * want_kappa.abs());
    assert_eq!(props.tautochronic, Tautochronism::No);
    let w0 = props.tuning_order() * omega;
    let a = 1e-3;
    let kane = Kane::new(&mech).unwrap();
    let mut drive = Drive::new(kane, 0, vec![], Some(Prescribed { joint: 0, accel: 0.0, until_s: 0.0 })).unwrap();
    let periods = 10.0;
    let t1 = periods * 2.0 * PI / w0;
    let opts = IntegrateOptions { rtol: 1e-13, atol: 1e-16, sample_rate_hz: None, ..IntegrateOptions::default() };
    let run = integrate(|t, x, dx| drive.rhs(t, x, dx), &[0.0, a, omega, 0.0], 0.0, t1, &opts, |_| {}).unwrap();
    let angle = (-run.x_end[3] / w0).atan2(run.x_end[1]);
    let ratio = 1.0 + angle / (2.0 * PI * periods);
    let measured = (ratio - 1.0) / (a * a);
    println!("κ: closed form {want_kappa:.6}, free oscillation {measured:.6} (1/m²)");
    assert!(
        abs_diff_eq!(measured, want_kappa, epsilon = 0.02 * want_kappa.abs()),
        "κ measured {measured} vs {want_kappa}"
    );
}

/// Tautochronism: the epicycloid (named or general, translating or with a linear rotation law)
/// is exactly tautochronic at held spin; circle, bifilar and a path with x₄ are not.
#[test]
fn tautochronism_is_reported() {
    let cases = [
        (PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 0.0 }, Tautochronism::Exact),
        (PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 10.0 }, Tautochronism::Exact),
        (PathShape::general(0.185, 3.11, &[], &[10.0]), Tautochronism::Exact),
        (PathShape::general(0.185, 3.11, &[100.0], &[]), Tautochronism::No),
        (PathShape::Circle { radius: 0.17, length: 0.0152 }, Tautochronism::No),
        (PathShape::Bifilar { radius: 0.17, length: 0.0152 }, Tautochronism::No),
    ];
    for (shape, want) in cases {
        let mech = rotor_with(path(shape), 6.0, Some(2.16e-4));
        assert_eq!(absorbers(&mech)[0].tautochronic, want, "{shape:?}");
    }
    // The paper's revolute pendulum is reported too, with eq. (15): n_t² = m R L / (I + m L²),
    // R the pivot's distance from the axis, L the pendulum's centre of mass from the pivot.
    let paper = Mechanism::from_file(std::path::Path::new("examples/cpva.ron")).unwrap();
    let md = markdown(&paper);
    assert!(md.contains("## Absorbers") && md.contains("Revolute pendulum"), "{md}");
    let j = paper.joints.iter().position(|j| j.parent.is_some()).unwrap();
    let (r, b) = (paper.joints[j].at.norm(), paper.bodies[j].inertia);
    let (m, l, i) = (b.mass, b.com.norm(), b.i_com);
    let want = m * r * l / (i + m * l * l);
    let got = absorbers(&paper)[0].tuning_order_squared;
    assert!(abs_diff_eq!(got, want, epsilon = 1e-14 * want), "revolute pendulum n_t² {got} vs eq. (15) {want}");
}

/// `kanedyn check` prints the absorbers' table (here for the epicycloid example: n_t = ñ = 3.11,
/// tautochronic).
#[test]
fn check_prints_the_absorbers() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kanedyn"))
        .args(["check", "examples/cpva_epicycloid.ron"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("## Absorbers") && text.contains("| `path` | Epicycloid |"), "{text}");
    assert!(text.contains("| 3.110000 |") && text.contains("| yes |"), "{text}");
}

/// A travel limit stops the engine and a run with an error naming the joint, the arc length and
/// the limit; the integrator's error adds the time.
#[test]
fn travel_limit_stops_a_run_with_a_named_error() {
    let shape = PathShape::general(0.185, 3.11, &[500.0], &[]);
    let limit = 0.5 * shape.travel();
    let mech = rotor_with(JointKind::Path { shape, mount: 0.0, travel: Some(limit) }, 6.0, Some(2.16e-4));
    let mut kane = Kane::new(&mech).unwrap();
    let mut xd = [0.0; 4];
    assert!(kane.rhs(0.0, &[0.0, 0.99 * limit, 100.0, 0.0], &mut xd).is_ok());
    let err = kane.rhs(0.0, &[0.0, 1.01 * limit, 100.0, 0.0], &mut xd).unwrap_err();
    assert!(matches!(&err, EngineError::OutOfTravel { joint, limit: true, .. } if joint == "path"), "{err}");
    // Released at the vertex fast enough to pass the limit.
    let x0 = [0.0, 0.0, 100.0, 3.11 * 100.0 * 1.5 * limit];
    let run = integrate(|t, x, dx| kane.rhs(t, x, dx), &x0, 0.0, 1.0, &IntegrateOptions::default(), |_| {});
    let msg = run.unwrap_err().to_string();
    assert!(
        msg.contains("joint `path` left its path") && msg.contains("travel limit") && msg.contains("at t = "),
        "{msg}"
    );
    println!("{msg}");
}

fn load(text: &str) -> Result<Mechanism, String> {
    Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::unrestricted()).map_err(|e| e.to_string())
}

fn with_path_kind(kind: &str) -> String {
    format!(
        "Mechanism(\n    name: \"m\",\n    bodies: [\n        Body(name: \"rotor\", mass: 1.0, inertia: 0.1),\n        Body(name: \"mass\", mass: 0.5, inertia: 0.001),\n    ],\n    joints: [\n        Joint(name: \"spin\", parent: \"ground\", child: \"rotor\"),\n        Joint(name: \"absorber\", parent: \"rotor\", child: \"mass\",\n            kind: {kind}),\n    ],\n)\n"
    )
}

/// Bad general-path and travel input: located errors naming the joint and the field.
#[test]
fn bad_general_path_input_is_a_located_error() {
    assert!(
        load(&with_path_kind("Path(shape: General(rho0: 0.185, n_tilde: 3.11, x: [100.0], alpha: [1.0]))")).is_ok()
    );
    assert!(load(&with_path_kind("Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11), travel: Some(0.015))")).is_ok());
    let cases = [
        ("Path(shape: General(rho0: 0.0, n_tilde: 3.11))", "shape.rho0", "ρ₀"),
        ("Path(shape: General(rho0: 0.185, n_tilde: -1.0))", "shape.n_tilde", "ñ"),
        ("Path(shape: General(rho0: 0.185, n_tilde: 3.11, x: [NaN]))", "shape.x", "finite"),
        ("Path(shape: General(rho0: 0.185, n_tilde: 3.11, alpha: [1.0, inf]))", "shape.alpha", "finite"),
        ("Path(shape: General(rho0: 0.185, n_tilde: 3.11, x: [1,2,3,4,5,6,7,8,9]))", "shape.x", "at most"),
        // The cusp is at 17.7 mm: a limit beyond it.
        ("Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11), travel: Some(0.02))", "travel", "beyond the path's end"),
        // x₄ < 0 bends the path back before 15 mm (|dρ/ds| reaches 1 at 11.8 mm).
        (
            "Path(shape: General(rho0: 0.185, n_tilde: 3.11, x: [-20000.0]), travel: Some(0.015))",
            "travel",
            "|dρ/ds| reaches 1",
        ),
        ("Path(shape: Circle(radius: 0.17, length: 0.01), travel: Some(-1.0))", "travel", "positive"),
        ("Path(shape: Bifilar(radius: 0.17, length: 0.01), travel: Some(NaN))", "travel", "finite"),
    ];
    for (kind, field, words) in cases {
        let msg = load(&with_path_kind(kind)).expect_err(kind);
        assert!(msg.starts_with("m.ron:10:"), "{kind}: not located at line 10: {msg}");
        assert!(msg.contains(&format!("`joints[1].kind.{field}`")), "{kind}: field {field}: {msg}");
        assert!(msg.contains("joint `absorber`") && msg.contains(words), "{kind}: {msg}");
    }
}

/// The catalog's general-path part loads in a mechanism, and its properties are the closed forms.
#[test]
fn catalog_general_part_loads() {
    let text = "Mechanism(\n    name: \"m\",\n    bodies: [\n        Body(name: \"rotor\", mass: 10.0, inertia: 0.36),\n        Body(name: \"absorber\", mass: 6.0, inertia: 2.16e-4),\n    ],\n    joints: [\n        Joint(name: \"spin\", parent: \"ground\", child: \"rotor\"),\n        Joint(name: \"path\", part: \"catalog:joints/path_general.ron\", parent: \"rotor\", child: \"absorber\"),\n    ],\n)\n";
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let file = dir.join("general_part_test.ron");
    let src = Source::from_text(file.to_str().unwrap(), text);
    let mech = Mechanism::from_source(&src, &ReadPolicy::unrestricted()).unwrap();
    let j = mech.joint_index("path").unwrap();
    let JointKind::Path { shape: PathShape::General(g), travel: Some(t), .. } = mech.joints[j].kind else {
        panic!("not a general path with a limit: {:?}", mech.joints[j].kind);
    };
    assert!(t < g.end());
    let props = &absorbers(&mech)[0];
    let (n, a1) = (g.n_tilde, g.alpha[0]);
    let want = 6.0 * n * n / (6.0 + 2.16e-4 * a1 * a1);
    assert_abs_diff_eq!(props.tuning_order_squared, want, epsilon = 1e-14 * want);
    println!("{}", markdown(&mech));
}

/// The rollers' closed-form tuning order (docs/design/paths.md, "Rollers") against the reduced
/// Lagrangian built here from the rolling kinematics on the actual curve: every roller centre at
/// c̄(s) = ½(P + r(s)) (P the vertex's centre of curvature, from r''(0)), moving at ½ṡ, turning
/// at −ṡ/(2r_r) relative to the rotor. At held spin the s-inertia is m + N(m_r/4 + I_r/(4r_r²))
/// and the potential −½Ω²(m ρ² + N m_r |c̄|²); n_t² = V''(0)/M(0) by central differences of
/// steps h and 2h, h = 1 % of the travel, Richardson-extrapolated (truncation ~(h/L)⁴/360 ≈ 1e-10,
/// rounding ~1e-16·V/(h²V'') ≈ 1e-10 relative: the 1e-8 bound has margin).
#[test]
fn roller_tuning_order_equals_the_rolling_kinematics() {
    let (m, count, m_r, r_r) = (6.0, 2.0, 0.08, 0.006);
    let i_r = 0.5 * m_r * r_r * r_r;
    for shape in [
        PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 0.0 },
        PathShape::Bifilar { radius: 0.17, length: 0.0152 },
        PathShape::general(0.185, 2.0, &[-3000.0], &[]),
    ] {
        let vertex = shape.at(0.0);
        let centre = vertex.position + vertex.curvature / vertex.curvature.norm_squared();
        let potential = |s: f64| {
            let p = shape.at(s).position;
            let c = 0.5 * (centre + p);
            -0.5 * (m * p.norm_squared() + count * m_r * c.norm_squared())
        };
        let h = 1e-2 * shape.travel().min(0.0152);
        let second = |h: f64| (potential(h) - 2.0 * potential(0.0) + potential(-h)) / (h * h);
        let stiffness = (4.0 * second(h) - second(2.0 * h)) / 3.0;
        let inertia = m + count * (0.25 * m_r + 0.25 * i_r / (r_r * r_r));
        let want = stiffness / inertia;
        let (_, n2, _, _) = shape.taylor();
        let got = roller_tuning_order_squared(m, n2, count, m_r, i_r, r_r);
        println!("{shape:?}: rollers n_t² {got:.9} (without {n2:.9}), kinematics {want:.9}");
        assert!(abs_diff_eq!(got, want, epsilon = 1e-8 * want), "{shape:?}: {got} vs {want}");
        assert!(got > n2, "uniform-disc rollers raise the order");
    }
}

/// A body probe below a path joint whose carried body turns (circle, epicycloid with α₁ ≠ 0,
/// general with a rotation law) is refused, naming the joint: the probes add revolute angles
/// only and would leave α(s) out of the body's angle. A translating absorber (bifilar, α = 0)
/// and the rotor above any path are accepted.
#[test]
fn body_probes_below_a_turning_path_are_refused() {
    use kanedyn::time::probe::{Probe, Recorder};
    let turning = [
        PathShape::Circle { radius: 0.1, length: 0.02 },
        PathShape::Epicycloid { rho0: 0.1, n_tilde: 3.0, alpha1: 5.0 },
        PathShape::general(0.1, 3.0, &[], &[5.0]),
    ];
    for shape in turning {
        let mech = rotor_with(path(shape), 1.0, Some(1e-4));
        for p in [Probe::BodyAngle(1), Probe::BodyRate(1), Probe::BodyAccel(1)] {
            let err = Recorder::new(&mech, &[p]).err().unwrap_or_else(|| panic!("{shape:?}: {p:?} accepted"));
            assert!(err.to_string().contains("path joint `path`"), "{err}");
        }
        assert!(Recorder::new(&mech, &[Probe::BodyAccel(0)]).is_ok(), "{shape:?}: the rotor's probe");
    }
    for shape in [
        PathShape::Bifilar { radius: 0.1, length: 0.02 },
        PathShape::Epicycloid { rho0: 0.1, n_tilde: 3.0, alpha1: 0.0 },
    ] {
        let mech = rotor_with(path(shape), 1.0, Some(1e-4));
        assert!(Recorder::new(&mech, &[Probe::BodyAccel(1)]).is_ok(), "{shape:?}: a translating absorber");
    }
}

/// The same refusal at the study level: a study whose response body rides a circular path is a
/// located error at `response_body`, naming the path joint.
#[test]
fn a_response_body_on_a_turning_path_is_a_located_study_error() {
    let tmp = scratch("turning");
    let dir = tmp.path().to_path_buf();
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy("examples/paths/circle.ron", dir.join("circle.ron")).unwrap();
    let study = "Study(\n    name: \"turning\",\n    mechanism: \"circle.ron\",\n    spin_joint: \"spin\",\n    \
                 response_body: \"absorber\",\n    analyses: [],\n)\n";
    std::fs::write(dir.join("study.ron"), study).unwrap();
    let Err(err) = kanedyn::study::Study::from_file(&dir.join("study.ron")) else { panic!("accepted") };
    let err = err.to_string();
    assert!(err.contains("study.ron:5:") && err.contains("response_body") && err.contains("`path`"), "{err}");
}
