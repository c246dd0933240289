//! Body mass properties computed from shapes, against closed forms, and the errors bad shapes give.
//!
//! Tolerance: 1e-12 relative throughout. Each value is a few dozen floating-point operations
//! (parry stores 1/m and 1/I, parallel-axis shifts, a subtraction for holes whose result is at
//! least a third of the operands), each good to 2⁻⁵³ ≈ 1.1e-16, so the honest error is ~1e-15;
//! a wrong formula (a factor 2, a missing parallel-axis term) is off by O(1). The largest error
//! met is printed (`--nocapture`).

use approx::{assert_abs_diff_eq, assert_relative_eq};
use kanedyn::io::Source;
use kanedyn::model::body::BodySpec;
use kanedyn::model::inertia::PlanarInertia;
use kanedyn::model::math::Vec2;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::model::shape::{PlacedShape, ShapeSpec};
use std::f64::consts::PI;
use std::path::Path;

const TOL: f64 = 1e-12;

/// Mass properties of a body written in RON (as a catalog part would be: field paths start at `.`).
fn body(text: &str) -> kanedyn::error::Result<PlanarInertia> {
    let src = Source::from_text("body.ron", text);
    let spec: BodySpec = src.parse()?;
    spec.check_numbers(&src, "")?;
    spec.inertia_props(&src, "")
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// Asserts `got` equals mass `m`, centre of mass `com` and centroidal inertia `i` to TOL; the
/// centre of mass relative to the body's size `scale` (it may be exactly zero).
fn assert_props(what: &str, got: PlanarInertia, m: f64, com: (f64, f64), i: f64, scale: f64) {
    let e_m = rel(got.mass, m);
    let e_c = (got.com - Vec2::new(com.0, com.1)).norm() / scale;
    let e_i = rel(got.i_com, i);
    eprintln!("{what}: relative errors mass {e_m:.1e}, com {e_c:.1e}, inertia {e_i:.1e}");
    assert!(e_m <= TOL, "{what}: mass {} vs {m}", got.mass);
    assert!(e_c <= TOL, "{what}: com {:?} vs {com:?}", got.com);
    assert!(e_i <= TOL, "{what}: inertia {} vs {i}", got.i_com);
}

#[test]
fn disc_matches_closed_form() {
    // Steel disc r = 0.2 m, 20 mm thick: m = ρ t π r², I = m r²/2.
    let (rho, t, r) = (7850.0, 0.02, 0.2);
    let m = rho * t * PI * r * r;
    let p = body("Body(shape: Disc(radius: 0.2), density: 7850.0, thickness: 0.02)").unwrap();
    assert_props("disc", p, m, (0.0, 0.0), m * r * r / 2.0, r);
}

#[test]
fn annulus_matches_closed_form_and_equals_disc_minus_disc() {
    // m = ρ_A π (r_o² − r_i²), I = m (r_i² + r_o²)/2.
    let (rho_a, ri, ro) = (150.0, 0.05, 0.2);
    let m = rho_a * PI * (ro * ro - ri * ri);
    let i = m * (ri * ri + ro * ro) / 2.0;
    let p = body("Body(shape: Annulus(inner_radius: 0.05, outer_radius: 0.2), areal_density: 150.0)").unwrap();
    assert_props("annulus", p, m, (0.0, 0.0), i, ro);
    let holed = body(
        "Body(shape: Compound(parts: [
            Placed(shape: Disc(radius: 0.2)),
            Placed(shape: Disc(radius: 0.05), hole: true),
        ]), areal_density: 150.0)",
    )
    .unwrap();
    assert_props("disc − disc", holed, m, (0.0, 0.0), i, ro);
}

#[test]
fn rectangle_matches_closed_form() {
    // m = ρ_A w h, I = m (w² + h²)/12 (full sizes, centred).
    let (rho_a, w, h) = (20.0, 0.5, 0.04);
    let m = rho_a * w * h;
    let p = body("Body(shape: Rectangle(width: 0.5, height: 0.04), areal_density: 20.0)").unwrap();
    assert_props("rectangle", p, m, (0.0, 0.0), m * (w * w + h * h) / 12.0, w);
}

#[test]
fn convex_polygons_match_closed_forms() {
    // Right triangle with legs a on x and b on y at the origin: area ab/2, centroid (a/3, b/3),
    // polar moment about the centroid m (a² + b²)/18.
    let (a, b) = (0.3, 0.1);
    let m = a * b / 2.0;
    let tri = ShapeSpec::ConvexPolygon { points: vec![(0.0, 0.0), (a, 0.0), (0.0, b)] };
    assert_props(
        "right triangle",
        tri.mass_properties(1.0).unwrap(),
        m,
        (a / 3.0, b / 3.0),
        m * (a * a + b * b) / 18.0,
        a,
    );
    // The same triangle listed clockwise gives the same properties.
    let cw = ShapeSpec::ConvexPolygon { points: vec![(0.0, 0.0), (0.0, b), (a, 0.0)] };
    assert_props(
        "right triangle, clockwise",
        cw.mass_properties(1.0).unwrap(),
        m,
        (a / 3.0, b / 3.0),
        m * (a * a + b * b) / 18.0,
        a,
    );
    // Regular hexagon of circumradius s (= side), centred at (1, 2): area 3√3 s²/2, polar moment
    // about the centre 5√3 s⁴/8, i.e. m · 5 s²/12.
    let (s, rho_a) = (0.25, 3.0);
    let pts = (0..6).map(|k| (1.0 + s * (k as f64 * PI / 3.0).cos(), 2.0 + s * (k as f64 * PI / 3.0).sin())).collect();
    let m = rho_a * 3.0 * 3f64.sqrt() * s * s / 2.0;
    let hex = ShapeSpec::ConvexPolygon { points: pts }.mass_properties(rho_a).unwrap();
    assert_props("hexagon", hex, m, (1.0, 2.0), m * 5.0 * s * s / 12.0, 2.0);
}

#[test]
fn three_shifted_rectangles_equal_one_long_rectangle() {
    // parry's own algebra check, through our placement: three 0.1 × 0.02 m blocks side by side
    // (the middle one given as 0.02 × 0.1 turned by a quarter turn) are one 0.3 × 0.02 m bar.
    let rect = |w, h| ShapeSpec::Rectangle { width: w, height: h };
    let placed = |shape, x: f64, angle| PlacedShape { shape, at: (x, 0.0), angle, hole: false };
    let three = ShapeSpec::Compound {
        parts: vec![
            placed(rect(0.1, 0.02), -0.1, 0.0),
            placed(rect(0.02, 0.1), 0.0, PI / 2.0),
            placed(rect(0.1, 0.02), 0.1, 0.0),
        ],
    };
    let one = rect(0.3, 0.02).mass_properties(7.0).unwrap();
    let m = 7.0 * 0.3 * 0.02;
    assert_props("closed form bar", one, m, (0.0, 0.0), m * (0.09 + 0.0004) / 12.0, 0.3);
    assert_props("three blocks", three.mass_properties(7.0).unwrap(), one.mass, (0.0, 0.0), one.i_com, 0.3);
}

#[test]
fn density_times_thickness_equals_areal_density() {
    let shape = "Rectangle(width: 0.3, height: 0.1)";
    let a = body(&format!("Body(shape: {shape}, density: 2700.0, thickness: 0.004)")).unwrap();
    let b = body(&format!("Body(shape: {shape}, areal_density: 10.8)")).unwrap();
    assert_props("ρ·t vs areal", a, b.mass, (0.0, 0.0), b.i_com, 0.3);
}

#[test]
fn placing_a_shape_moves_the_centre_of_mass() {
    // A disc whose centre is 0.1 m out on x: com there, centroidal inertia unchanged, the moment
    // about the joint (the body origin) grows by m d² (parallel axis).
    let (r, d, rho_a) = (0.05, 0.1, 40.0);
    let m = rho_a * PI * r * r;
    let p =
        body("Body(shape: Compound(parts: [Placed(shape: Disc(radius: 0.05), at: (0.1, 0.0))]), areal_density: 40.0)")
            .unwrap();
    assert_props("placed disc", p, m, (d, 0.0), m * r * r / 2.0, d);
    assert_relative_eq!(p.about(Vec2::zeros()), m * r * r / 2.0 + m * d * d, max_relative = TOL);
    // A turned placement rotates the part's own offsets: a triangle's centroid (a/3, b/3) turned
    // by +90° lands at (−b/3, a/3) from `at`.
    let p = body(
        "Body(shape: Compound(parts: [Placed(shape: ConvexPolygon(points: [(0.0, 0.0), (0.3, 0.0), (0.0, 0.1)]),
                                           at: (1.0, 0.0), angle: 1.5707963267948966)]), areal_density: 1.0)",
    )
    .unwrap();
    assert_props("turned triangle", p, 0.015, (1.0 - 0.1 / 3.0, 0.1), 0.015 * (0.09 + 0.01) / 18.0, 1.0);
}

#[test]
fn an_off_centre_hole_shifts_the_centre_of_mass_away() {
    // Plate w × h with a hole of radius r at (e, 0): com_x = −A_h e / (A_p − A_h); inertia about
    // the origin is the difference of the two, then shifted to the com.
    let (w, h, r, e) = (0.4, 0.2, 0.05, 0.1);
    let (ap, ah) = (w * h, PI * r * r);
    let m = ap - ah;
    let x = -ah * e / m;
    let i_o = ap * (w * w + h * h) / 12.0 - (ah * r * r / 2.0 + ah * e * e);
    let p = body(
        "Body(shape: Compound(parts: [
            Placed(shape: Rectangle(width: 0.4, height: 0.2)),
            Placed(shape: Disc(radius: 0.05), at: (0.1, 0.0), hole: true),
        ]), areal_density: 1.0)",
    )
    .unwrap();
    assert_props("holed plate", p, m, (x, 0.0), i_o - m * x * x, w);
}

#[test]
fn catalog_flywheel_and_an_override_of_its_density() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = Source::read(&root.join("bodies/steel_disc_flywheel.ron")).unwrap();
    let spec: BodySpec = src.parse().unwrap();
    let steel = spec.inertia_props(&src, "").unwrap();
    let (rho, t, ro, ri) = (7850.0, 0.025, 0.2, 0.03);
    let m = rho * t * PI * (ro * ro - ri * ri);
    assert_props("steel flywheel", steel, m, (0.0, 0.0), m * (ro * ro + ri * ri) / 2.0, ro);
    // Through a mechanism, overriding the density (aluminium) scales mass and inertia alike.
    let tmp = folder("override");
    let dir = tmp.path();
    std::fs::copy(root.join("bodies/steel_disc_flywheel.ron"), dir.join("fw.ron")).unwrap();
    let mech = dir.join("m.ron");
    std::fs::write(
        &mech,
        r#"Mechanism(name: "m", bodies: [Body(part: "fw.ron", density: 2700.0)],
                   joints: [Joint(name: "spin", parent: "ground", child: "flywheel")])"#,
    )
    .unwrap();
    let alu = Mechanism::from_file(&mech).unwrap().bodies[0].inertia;
    let k = 2700.0 / 7850.0;
    assert_props("aluminium flywheel", alu, m * k, (0.0, 0.0), steel.i_com * k, ro);
}

fn folder(name: &str) -> tempfile::TempDir {
    crate::support::scratch(&format!("shapes-{name}"))
}

/// 1-based line:column of the first occurrence of `marker` in `text`.
fn place(text: &str, marker: &str) -> String {
    let off = text.find(marker).unwrap_or_else(|| panic!("marker {marker:?} not in the text"));
    let before = &text[..off];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().unwrap().chars().count() + 1;
    format!("{line}:{col}")
}

/// `text` must fail with a message naming `body.ron:line:col` of `marker`, the field `path` and
/// each of `words`.
fn expect_error(text: &str, marker: &str, path: &str, words: &[&str]) {
    let msg = match body(text) {
        Ok(p) => panic!("expected an error for {text}, got {p:?}"),
        Err(e) => e.to_string(),
    };
    let at = format!("body.ron:{}", place(text, marker));
    let field = format!("(field `{path}`)");
    for w in [at.as_str(), field.as_str()].iter().chain(words) {
        assert!(msg.contains(w), "error {msg:?} should mention {w:?}");
    }
}

#[test]
fn bad_sizes_name_the_field_and_its_place() {
    expect_error("Body(\n  shape: Disc(radius: -0.1),\n  areal_density: 1.0)", "-0.1", ".shape.radius", &["positive"]);
    expect_error("Body(shape: Disc(radius: 0.0), areal_density: 1.0)", "0.0)", ".shape.radius", &["positive"]);
    expect_error(
        "Body(shape: Rectangle(width: 0.1, height: NaN), areal_density: 1.0)",
        "NaN",
        ".shape.height",
        &["finite"],
    );
    expect_error(
        "Body(shape: Annulus(inner_radius: 0.2, outer_radius: 0.1), areal_density: 1.0)",
        "0.2",
        ".shape.inner_radius",
        &["smaller than the outer radius"],
    );
    expect_error(
        "Body(shape: Annulus(inner_radius: -0.01, outer_radius: 0.1), areal_density: 1.0)",
        "-0.01",
        ".shape.inner_radius",
        &["negative"],
    );
}

#[test]
fn bad_polygons_are_rejected() {
    expect_error(
        "Body(shape: ConvexPolygon(points: [(0.0, 0.0), (1.0, 0.0)]), areal_density: 1.0)",
        "[(",
        ".shape.points",
        &["at least 3 points"],
    );
    // A dart (arrowhead): the turn at the notch (point 2) goes the other way.
    expect_error(
        "Body(shape: ConvexPolygon(points: [(0.0, 0.0), (1.0, 0.5), (0.3, 0.5), (1.0, 1.0)]),\n areal_density: 1.0)",
        "(0.3",
        ".shape.points[2]",
        &["not convex"],
    );
    // Zero area: all points on one line.
    expect_error(
        "Body(shape: ConvexPolygon(points: [(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]), areal_density: 1.0)",
        "(0.0, 0.0)",
        ".shape.points[0]",
        &["collinear"],
    );
    // A repeated point.
    expect_error(
        "Body(shape: ConvexPolygon(points: [(0.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.0, 1.0)]), areal_density: 1.0)",
        "(1.0, 0.0)",
        ".shape.points[1]",
        &["repeated"],
    );
    // A bow tie (points out of order) crosses itself.
    expect_error(
        "Body(shape: ConvexPolygon(points: [(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]), areal_density: 1.0)",
        "(1.0, 1.0)",
        ".shape.points[1]",
        &["not convex"],
    );
    // A pentagram: every vertex turns the same way, yet it winds round twice.
    let star: Vec<String> = (0..5)
        .map(|k| {
            let a = 4.0 * PI * k as f64 / 5.0;
            format!("({:?}, {:?})", a.cos(), a.sin())
        })
        .collect();
    expect_error(
        &format!("Body(shape: ConvexPolygon(points: [{}]), areal_density: 1.0)", star.join(", ")),
        "[(",
        ".shape.points",
        &["crosses itself"],
    );
}

#[test]
fn bad_densities_and_mixed_sources_are_rejected() {
    expect_error(
        "Body(shape: Disc(radius: 0.1), density: -7850.0, thickness: 0.01)",
        "-7850",
        ".density",
        &["non-negative"],
    );
    expect_error(
        "Body(shape: Disc(radius: 0.1), density: 7850.0, thickness: 0.0)",
        "0.0)",
        ".thickness",
        &["positive"],
    );
    expect_error(
        "Body(shape: Disc(radius: 0.1), areal_density: 10.0, density: 7850.0, thickness: 0.01)",
        "7850",
        ".density",
        &["cannot be given with `areal_density`"],
    );
    expect_error(
        "Body(\n    mass: 2.0,\n    shape: Disc(radius: 0.1),\n    areal_density: 10.0,\n)",
        "2.0",
        ".mass",
        &["cannot be given with `shape`"],
    );
    expect_error(
        "Body(com: (0.1, 0.0), shape: Disc(radius: 0.1), areal_density: 10.0)",
        "(0.1, 0.0)",
        ".com",
        &["`com`"],
    );
    expect_error("Body(shape: Disc(radius: 0.1))", "Disc", ".shape", &["needs a density"]);
    expect_error("Body(shape: Disc(radius: 0.1), density: 7850.0)", "7850", ".density", &["needs a `thickness`"]);
    expect_error("Body(mass: 1.0, areal_density: 10.0)", "10.0", ".areal_density", &["no `shape`"]);
}

#[test]
fn bad_compounds_name_the_part() {
    let text = "Body(
    shape: Compound(parts: [
        Placed(shape: Rectangle(width: 0.3, height: 0.02)),
        Placed(shape: Compound(parts: [Placed(shape: Disc(radius: -0.01))]), at: (0.1, 0.0)),
    ]),
    areal_density: 10.0,
)";
    expect_error(text, "-0.01", ".shape.parts[1].shape.parts[0].shape.radius", &["positive"]);
    expect_error(
        "Body(shape: Compound(parts: [Placed(shape: Disc(radius: 0.1), at: (inf, 0.0))]), areal_density: 1.0)",
        "(inf",
        ".shape.parts[0].at",
        &["finite"],
    );
    expect_error(
        "Body(shape: Compound(parts: [
            Placed(shape: Disc(radius: 0.1)),
            Placed(shape: Disc(radius: 0.2), hole: true),
        ]), areal_density: 1.0)",
        "Compound",
        ".shape",
        &["leave no area"],
    );
    expect_error("Body(shape: Compound(parts: []), areal_density: 1.0)", "[]", ".shape.parts", &["at least one part"]);
}

#[test]
fn unknown_shape_fields_are_rejected_with_their_line() {
    let src = Source::from_text("body.ron", "Body(\n  shape: Disc(diameter: 0.2),\n  areal_density: 1.0)");
    let msg = src.parse::<BodySpec>().unwrap_err().to_string();
    assert!(msg.contains("body.ron:2:") && msg.contains("diameter"), "{msg}");
}

#[test]
fn mechanism_errors_carry_the_body_path() {
    let tmp = folder("mech");
    let dir = tmp.path();
    let text = r#"Mechanism(
    name: "m",
    bodies: [
        Body(name: "rotor", mass: 10.0, inertia: 1.0),
        Body(name: "arm", areal_density: 5.0,
             shape: Compound(parts: [Placed(shape: Rectangle(width: 0.2, height: -0.02), at: (0.1, 0.0))])),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "pivot", parent: "rotor", child: "arm", at: (0.2, 0.0)),
    ],
)
"#;
    std::fs::write(dir.join("m.ron"), text).unwrap();
    let msg = Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string();
    let want = format!("m.ron:{} (field `bodies[1].shape.parts[0].shape.height`)", place(text, "-0.02"));
    assert!(msg.contains(&want) && msg.contains("positive"), "{msg} should contain {want}");
    // The good version loads, with the arm's com at the rectangle's centre.
    std::fs::write(dir.join("m.ron"), text.replace("-0.02", "0.02")).unwrap();
    let m = Mechanism::from_file(&dir.join("m.ron")).unwrap();
    assert_relative_eq!(m.bodies[1].inertia.com.x, 0.1, max_relative = TOL);
    assert_abs_diff_eq!(m.bodies[1].inertia.com.y, 0.0, epsilon = TOL * 0.1);
}
