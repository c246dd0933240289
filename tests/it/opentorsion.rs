//! Issue 31, item 6: OpenTorsion models read into kanedyn (kanedyn::opentorsion, `kanedyn
//! import`) and absorbers attached by an overlay (a mechanism with `base:`).
//!
//! References written here: the free-free three-inertia chain's natural frequencies in closed
//! form, `ω² = (b ± √(b² − 4ac)) / 2a` with `a = J1 J2 J3`, `b = k1 J3 (J1 + J2) + k2 J1 (J2 + J3)`,
//! `c = k1 k2 (J1 + J2 + J3)` (the roots of det(K − ω²M) = 0 after the rigid rotation's ω = 0); a
//! gear stage of ratio R reflects the inertias and stiffness behind it by 1/R². The marine plant
//! of Gunter & Chen's Example 8.1 as a TORS file is compared with kanedyn's own hand-written
//! model of it (examples/marine_driveline.ron).

use crate::support::{cli, scratch};
use kanedyn::error::Error;
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::linear::{Damping, LinearModel, Spin};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::opentorsion::convert;
use std::path::Path;

/// The converted mechanism of a TORS text, loaded.
fn load(tors: &str) -> (String, Mechanism) {
    let ron = convert(Path::new("model.json"), tors, "model").unwrap_or_else(|e| panic!("{e}"));
    let mech = Mechanism::from_source(&Source::from_text("model.ron", &ron), &ReadPolicy::within(Path::new("")))
        .unwrap_or_else(|e| panic!("{e}\n{ron}"));
    (ron, mech)
}

/// Free undamped natural frequencies (rad/s) about `spin` at rest.
fn free_modes(mech: &Mechanism, spin: &str) -> Vec<f64> {
    let model = LinearModel::new(mech, spin, 0.0, None).unwrap_or_else(|e| panic!("{e}"));
    model.modes(Spin::Free, Damping::Undamped).unwrap().modes.iter().map(|m| m.natural_frequency_rad_s).collect()
}

/// The free-free chain J1 –k1– J2 –k2– J3: its two natural frequencies, rad/s.
fn chain(j1: f64, k1: f64, j2: f64, k2: f64, j3: f64) -> [f64; 2] {
    let a = j1 * j2 * j3;
    let b = k1 * j3 * (j1 + j2) + k2 * j1 * (j2 + j3);
    let c = k1 * k2 * (j1 + j2 + j3);
    let d = (b * b - 4.0 * a * c).sqrt();
    [((b - d) / (2.0 * a)).sqrt(), ((b + d) / (2.0 * a)).sqrt()]
}

fn assert_close(got: &[f64], want: &[f64], tol: f64) {
    assert_eq!(got.len(), want.len(), "{got:?} against {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(((g - w) / w).abs() <= tol, "{g} against {w} (relative {:e})", (g - w) / w);
    }
}

/// A plain shaft line: three disks on two discrete shafts, with dampers; the first node turns
/// on the bearing and the shafts are joint springs.
#[test]
fn three_inertia_chain_equals_the_closed_form() {
    let tors = r#"{
      "components": [{"name": "line", "elements": [
        {"name": "motor", "type": "Disk", "inertia": 2.5, "damping": 0.1},
        {"name": "coupling", "type": "ShaftDiscrete", "stiffness": 4.0e4, "damping": 0.5},
        {"name": "hub", "type": "Disk", "inertia": 0.8, "damping": 0.0},
        {"name": "shaft", "type": "ShaftDiscrete", "stiffness": 1.5e4, "damping": 0.0},
        {"name": "load", "type": "Disk", "inertia": 4.0, "damping": 0.0}
      ]}],
      "structure": []
    }"#;
    let (ron, mech) = load(tors);
    assert!(
        ron.contains(
            r#"Joint(name: "shaft_0", parent: "node_0", child: "node_1", spring: (stiffness: 40000.0), damper: 0.5)"#
        ),
        "{ron}"
    );
    assert!(ron.contains(r#"GroundDamper(body: "node_0", c: 0.1)"#), "{ron}");
    assert_eq!(mech.ndof(), 3);
    assert_close(&free_modes(&mech, "node_0"), &chain(2.5, 4.0e4, 0.8, 1.5e4, 4.0), 1e-9);
}

/// Two components joined by the `structure` (numbering continues after the connected element),
/// and a gear stage of diameters 1 and 3: the output side is reflected by (1/3)².
#[test]
fn gear_stage_across_components_equals_the_reflected_chain() {
    let tors = r#"{
      "components": [
        {"name": "motor", "elements": [
          {"name": "rotor", "type": "Disk", "inertia": 1.2, "damping": 0.0},
          {"name": "shaft", "type": "ShaftDiscrete", "stiffness": 2.0e4, "damping": 0.0}
        ]},
        {"name": "gearbox", "elements": [
          {"name": "pinion", "type": "GearElement", "inertia": 0.05, "diameter": 1.0},
          {"name": "wheel", "type": "GearElement", "inertia": 0.9, "diameter": 3.0, "parent": "pinion"},
          {"name": "output", "type": "ShaftDiscrete", "stiffness": 9.0e4, "damping": 0.0},
          {"name": "drum", "type": "Disk", "inertia": 30.0, "damping": 0.0}
        ]}
      ],
      "structure": [["motor.shaft", "gearbox.pinion"]]
    }"#;
    let (ron, mech) = load(tors);
    // Nodes: rotor 0, pinion 1, wheel 2 (a gear with a parent starts a node), drum 3.
    assert!(ron.contains(r#"Gear(joint: "node_2", follows: "node_1", ratio: -0.3333333333333333)"#), "{ron}");
    let want = chain(1.2, 2.0e4, 0.05 + 0.9 / 9.0, 9.0e4 / 9.0, 30.0 / 9.0);
    // The spin joint may be any bearing: the modes do not depend on it.
    assert_close(&free_modes(&mech, "node_1"), &want, 1e-9);
}

/// Gunter & Chen's Example 8.1 as a TORS file: the converted RON is the one checked in next to
/// it (so the example cannot go stale), and its free modes equal kanedyn's hand-written model of
/// the same plant to rounding.
#[test]
fn marine_plant_equals_the_checked_in_ron_and_the_hand_written_model() {
    let json = std::fs::read_to_string("examples/opentorsion_marine.json").unwrap();
    let ron = convert(Path::new("opentorsion_marine.json"), &json, "opentorsion_marine").unwrap();
    assert_eq!(ron, std::fs::read_to_string("examples/opentorsion_marine.ron").unwrap());
    let imported = Mechanism::from_file(Path::new("examples/opentorsion_marine.ron")).unwrap();
    let hand = Mechanism::from_file(Path::new("examples/marine_driveline.ron")).unwrap();
    let want = free_modes(&hand, "bull");
    assert_eq!(want.len(), 5);
    assert_close(&free_modes(&imported, "node_1"), &want, 1e-12);

    // The CLI writes the same text, to stdout or to `-o`.
    let (ok, stdout, stderr) = cli::kanedyn(&["import", "examples/opentorsion_marine.json"]);
    assert!(ok, "{stderr}");
    assert_eq!(stdout, ron);
    let tmp = scratch("import");
    let out = tmp.path().join("import.ron");
    let (ok, _, stderr) =
        cli::kanedyn(&["import", "examples/opentorsion_marine.json", "-o", out.to_str().unwrap(), "--name", "x"]);
    assert!(ok, "{stderr}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), ron.replace("name: \"opentorsion_marine\"", "name: \"x\""));
}

/// Where an error is: (file, line, column, field) of an input error.
fn located(e: &Error) -> (String, Option<(usize, usize)>, String, String) {
    match e {
        Error::Input { location, message } => {
            (location.file.display().to_string(), location.line_col, location.path.clone(), message.clone())
        }
        other => panic!("not an input error: {other}"),
    }
}

#[test]
fn bad_tors_files_give_located_errors() {
    let convert_err = |text: &str| located(&convert(Path::new("bad.json"), text, "bad").unwrap_err());
    // Syntax: the missing comma is on line 3.
    let (file, at, _, msg) = convert_err("{\n  \"components\": [\n    {\"name\": \"a\" \"elements\": []}\n  ]\n}");
    assert_eq!(file, "bad.json");
    assert_eq!(at.map(|a| a.0), Some(3), "{msg}");
    // A wrong type names the field.
    let text = "{\"components\": [{\"name\": \"a\", \"elements\": [\n  {\"name\": \"d\", \"type\": \"Disk\", \"inertia\": \"big\"}]}]}";
    let (_, at, path, msg) = convert_err(text);
    assert_eq!(path, "components[0].elements[0].inertia", "{msg}");
    assert_eq!(at.map(|a| a.0), Some(2));
    // An element type OpenTorsion's parser does not know.
    let (_, _, path, msg) =
        convert_err("{\"components\": [{\"name\": \"a\", \"elements\": [{\"name\": \"x\", \"type\": \"Spring\"}]}]}");
    assert_eq!(path, "components[0].elements[0].type", "{msg}");
    assert!(msg.contains("unknown element type `Spring`"), "{msg}");
    // A number the converter refuses, at the element's own field, line and column.
    let text = "{\"components\": [{\"name\": \"a\", \"elements\": [\n  {\"name\": \"d\", \"type\": \"Disk\", \"inertia\": 1.0},\n  {\"name\": \"s\", \"type\": \"ShaftDiscrete\", \"stiffness\": -5.0, \"damping\": 0.0}]}]}";
    let (_, at, path, msg) = convert_err(text);
    assert_eq!(path, "components[0].elements[1].stiffness");
    assert_eq!(at, Some((3, 55)), "{msg}");
    assert!(msg.contains("stiffness must be finite and positive"), "{msg}");
    // A parent gear that is not there.
    let text = "{\"components\": [{\"name\": \"a\", \"elements\": [\n  {\"name\": \"g\", \"type\": \"GearElement\", \"inertia\": 1.0, \"diameter\": 2.0, \"parent\": \"nope\"}]}]}";
    let (_, at, path, msg) = convert_err(text);
    assert_eq!(path, "components[0].elements[0].parent");
    assert_eq!(at.map(|a| a.0), Some(2));
    assert!(msg.contains("parent `nope`"), "{msg}");
    // A connection to a component that does not exist.
    let text = "{\"components\": [{\"name\": \"a\", \"elements\": [{\"name\": \"d\", \"type\": \"Disk\", \"inertia\": 1.0}]}],\n \"structure\": [[\"a.d\", \"b.x\"]]}";
    let (_, at, path, msg) = convert_err(text);
    assert_eq!((path.as_str(), at.map(|a| a.0)), ("structure[0][1]", Some(2)), "{msg}");
    assert!(msg.contains("unknown component `b`"), "{msg}");
    // The CLI says it on stderr with the location, and fails.
    let tmp = scratch("overlay-cli");
    let dir = tmp.path().to_path_buf();
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{\"components\": [\n}").unwrap();
    let (ok, _, stderr) = cli::kanedyn(&["import", bad.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("bad.json:2:1"), "{stderr}");
}

/// The README's overlay (examples/opentorsion_marine_cpva.ron): at most 15 lines, it adds
/// one pendulum to the imported plant, tuned to order √(R/L) = 5.
#[test]
fn overlay_adds_an_absorber_to_the_imported_plant() {
    let path = Path::new("examples/opentorsion_marine_cpva.ron");
    assert!(std::fs::read_to_string(path).unwrap().lines().count() <= 15);
    let base = Mechanism::from_file(Path::new("examples/opentorsion_marine.ron")).unwrap();
    let mech = Mechanism::from_file(path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mech.name, "opentorsion_marine_cpva");
    assert_eq!(mech.ndof(), base.ndof() + 1);
    assert_eq!(mech.bodies.len(), base.bodies.len() + 1);
    assert_eq!(mech.gears.len(), base.gears.len());
    assert_eq!(mech.loads.ground_dampers.len(), base.loads.ground_dampers.len());
    let absorbers = kanedyn::model::absorber::absorbers(&mech);
    assert_eq!(absorbers.len(), 1);
    assert!((absorbers[0].tuning_order() - 5.0).abs() < 1e-12, "{}", absorbers[0].tuning_order());
}

#[test]
fn bad_overlays_give_located_errors() {
    let tmp = scratch("overlay-bad");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("base.ron"), std::fs::read_to_string("examples/opentorsion_marine.ron").unwrap()).unwrap();
    let overlay = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        located(&Mechanism::from_file(&p).unwrap_err())
    };
    let body = "Body(name: \"cpva\", mass: 2000.0, com: (0.04, 0.0))";
    let joint = |parent: &str| format!("Joint(name: \"pivot\", parent: \"{parent}\", child: \"cpva\", at: (1.0, 0.0))");
    // An unknown base file: at the overlay's `base`.
    let (file, at, path, msg) = overlay(
        "a.ron",
        &format!(
            "Mechanism(\n    name: \"a\",\n    base: \"missing.ron\",\n    bodies: [{body}],\n    joints: [{}],\n)",
            joint("node_1")
        ),
    );
    assert!(file.ends_with("a.ron"), "{file}");
    assert_eq!((at, path.as_str()), (Some((3, 11)), "base"), "{msg}");
    assert!(msg.contains("missing.ron"), "{msg}");
    // A name the base has already: at the overlay's name.
    let (file, at, path, msg) = overlay(
        "b.ron",
        &format!(
            "Mechanism(\n    name: \"b\",\n    base: \"base.ron\",\n    bodies: [Body(name: \"node_0\", mass: 1.0)],\n    joints: [{}],\n)",
            joint("node_1")
        ),
    );
    assert!(file.ends_with("b.ron"), "{file}");
    assert_eq!((at.map(|a| a.0), path.as_str()), (Some(4), "bodies[0].name"), "{msg}");
    assert!(msg.contains("`node_0` is already a name in the base `base.ron`"), "{msg}");
    // An unknown parent: at the overlay's joint, with the overlay's own index.
    let (file, at, path, msg) = overlay(
        "c.ron",
        &format!(
            "Mechanism(\n    name: \"c\",\n    base: \"base.ron\",\n    bodies: [{body}],\n    joints: [\n        {}],\n)",
            joint("rotor")
        ),
    );
    assert!(file.ends_with("c.ron"), "{file}");
    assert_eq!((at.map(|a| a.0), path.as_str()), (Some(6), "joints[0].parent"), "{msg}");
    assert!(msg.contains("unknown parent body `rotor`"), "{msg}");
    // A base that is itself broken: the error is in the base's file.
    std::fs::write(
        dir.join("broken.ron"),
        "Mechanism(\n    name: \"x\",\n    bodies: [Body(name: \"a\", inertia: -1.0)],\n    joints: [],\n)",
    )
    .unwrap();
    let (file, at, _, msg) = overlay(
        "d.ron",
        &format!("Mechanism(name: \"d\", base: \"broken.ron\", bodies: [{body}], joints: [{}])", joint("a")),
    );
    assert!(file.ends_with("broken.ron"), "{file}: {msg}");
    assert_eq!(at.map(|a| a.0), Some(3), "{msg}");
    // Overlays do not nest.
    let (file, _, path, msg) = overlay(
        "e.ron",
        &format!("Mechanism(name: \"e\", base: \"c.ron\", bodies: [{body}], joints: [{}])", joint("node_1")),
    );
    assert!(file.ends_with("c.ron") && path == "base", "{file} {path}: {msg}");
    assert!(msg.contains("overlays do not nest"), "{msg}");
    // The base's speeds apply.
    let (_, _, path, msg) = overlay(
        "f.ron",
        &format!(
            "Mechanism(name: \"f\", base: \"base.ron\", speeds: AbsoluteAngularVelocities, bodies: [{body}], joints: [{}])",
            joint("node_1")
        ),
    );
    assert_eq!(path, "speeds", "{msg}");
    // Used to be ignored without a word (issue 49, item 10): an overlay that writes the default
    // `speeds: JointRates` on a base with other speeds, or `gravity: (0.0, 0.0)` on a base with
    // gravity, sets them as much as any other value does.
    let absolute = "Mechanism(name: \"base\", speeds: AbsoluteAngularVelocities, gravity: (0.0, -9.81), \
                    bodies: [Body(name: \"node_1\", mass: 1.0, inertia: 1.0)], \
                    joints: [Joint(name: \"spin\", kind: Revolute, parent: \"ground\", child: \"node_1\")])";
    std::fs::write(dir.join("base_absolute.ron"), absolute).unwrap();
    for (field, value) in [("speeds", "JointRates"), ("gravity", "(0.0, 0.0)")] {
        let (file, at, path, msg) = overlay(
            &format!("h_{field}.ron"),
            &format!(
                "Mechanism(name: \"h\", base: \"base_absolute.ron\", {field}: {value}, bodies: [{body}], joints: [{}])",
                joint("node_1")
            ),
        );
        assert!(file.ends_with(&format!("h_{field}.ron")), "{file}: {msg}");
        assert_eq!(path, field, "{msg}");
        assert!(at.is_some() && msg.contains(&format!("remove `{field}`")), "{msg}");
    }
    // A base outside the overlay's folder tree is refused like any other file.
    let (_, _, path, msg) = overlay(
        "g.ron",
        &format!("Mechanism(name: \"g\", base: \"../x.ron\", bodies: [{body}], joints: [{}])", joint("node_1")),
    );
    assert_eq!(path, "base", "{msg}");
    assert!(msg.contains("outside"), "{msg}");
}

/// A shaft line whose middle node lies between two gear stages (so it turns on a bearing of its
/// own and both its shafts are couplings of ratio 1), and a continuous shaft whose inertia is
/// lumped to its ends: the free modes equal the hand-reduced absolute-angle model, built here
/// from the element definitions (θ_child = −R_parent/R_child · θ_parent eliminated by hand).
#[test]
fn core_node_between_gear_stages_and_a_lumped_shaft_equal_the_hand_reduced_model() {
    let tors = r#"{"components": [{"name": "line", "elements": [
        {"name": "motor", "type": "Disk", "inertia": 0.6, "damping": 0.0},
        {"name": "s0", "type": "ShaftDiscrete", "stiffness": 3.0e4, "damping": 0.0},
        {"name": "a", "type": "GearElement", "inertia": 0.02, "diameter": 2.0},
        {"name": "b", "type": "GearElement", "inertia": 0.01, "diameter": 1.0, "parent": "a"},
        {"name": "s1", "type": "ShaftDiscrete", "stiffness": 2.0e4, "damping": 0.0},
        {"name": "middle", "type": "Disk", "inertia": 0.3, "damping": 0.0},
        {"name": "s2", "type": "ShaftDiscrete", "stiffness": 5.0e4, "damping": 0.0},
        {"name": "c", "type": "GearElement", "inertia": 0.05, "diameter": 3.0},
        {"name": "d", "type": "GearElement", "inertia": 0.02, "diameter": 1.5, "parent": "c"},
        {"name": "s3", "type": "ShaftContinuous", "length": 500.0, "innerDiameter": 0.0, "outerDiameter": 60.0},
        {"name": "load", "type": "Disk", "inertia": 1.5, "damping": 0.0}
    ]}], "structure": []}"#;
    let (ron, mech) = load(tors);
    assert!(ron.contains(r#"Joint(name: "node_3", parent: "ground", child: "node_3")"#), "{ron}");
    assert!(
        ron.contains(r#"Gear(joint: "node_3", follows: "node_2", ratio: 1.0, mesh: (stiffness: 20000.0))"#),
        "{ron}"
    );
    assert!(ron.contains("NOTE: shafts with inertia have it lumped"), "{ron}");
    // The continuous shaft: J = πd⁴/32, k = G J / L, mass factor ρ J L / 6 (G = 80 GPa, ρ = 8000).
    let j = std::f64::consts::PI * 0.06f64.powi(4) / 32.0;
    let (k3, m3) = (80e9 * j / 0.5, 8000.0 * j * 0.5 / 6.0);
    let inertia = [0.6, 0.02, 0.01, 0.3, 0.05, 0.02 + 3.0 * m3, 1.5 + 3.0 * m3];
    let shafts = [(0, 1, 3.0e4), (2, 3, 2.0e4), (3, 4, 5.0e4), (5, 6, k3)];
    // Independent angles θ0, θ1, θ3, θ4, θ6; θ2 = −2 θ1, θ5 = −2 θ4.
    let mut t = nalgebra::DMatrix::<f64>::zeros(7, 5);
    for (row, col, v) in [(0, 0, 1.0), (1, 1, 1.0), (2, 1, -2.0), (3, 2, 1.0), (4, 3, 1.0), (5, 3, -2.0), (6, 4, 1.0)] {
        t[(row, col)] = v;
    }
    let m = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&inertia));
    let mut k = nalgebra::DMatrix::<f64>::zeros(7, 7);
    for (a, b, s) in shafts {
        k[(a, a)] += s;
        k[(b, b)] += s;
        k[(a, b)] -= s;
        k[(b, a)] -= s;
    }
    let (mr, kr) = (t.transpose() * &m * &t, t.transpose() * &k * &t);
    let l_inv = mr.cholesky().unwrap().l().try_inverse().unwrap();
    let eig = nalgebra::SymmetricEigen::new(&l_inv * kr * l_inv.transpose());
    let mut want: Vec<f64> = eig.eigenvalues.iter().map(|l| l.max(0.0).sqrt()).collect();
    want.sort_by(f64::total_cmp);
    assert!(want[0] < 1e-6 * want[1], "one rigid rotation: {want:?}");
    assert_close(&free_modes(&mech, "node_1"), &want[1..], 1e-9);
}

/// The node form (`kanedyn.from_opentorsion`'s JSON) is read by the same converter: a
/// two-disk shaft is sqrt(k (1/J1 + 1/J2)), and a bad element is located at its own field.
#[test]
fn node_form_converts_and_locates_its_errors() {
    let (_, mech) = load(
        r#"{"shafts": [{"nl": 0, "nr": 1, "k": 4.0e4}], "disks": [{"node": 0, "inertia": 2.5}, {"node": 1, "inertia": 4.0}]}"#,
    );
    assert_close(&free_modes(&mech, "node_0"), &[(4.0e4f64 * (1.0 / 2.5 + 1.0 / 4.0)).sqrt()], 1e-12);
    let text = "{\"shafts\": [\n  {\"nl\": 0, \"nr\": 0, \"k\": 1.0}]}";
    let (_, at, path, msg) = located(&convert(Path::new("n.json"), text, "n").unwrap_err());
    assert_eq!((path.as_str(), at), ("shafts[0].nr", Some((2, 19))), "{msg}");
    assert!(msg.contains("joins node 0 to itself"), "{msg}");
    let text = "{\"disks\": [{\"node\": 2, \"inertia\": 1.0}]}";
    let (_, _, _, msg) = located(&convert(Path::new("n.json"), text, "n").unwrap_err());
    assert!(msg.contains("node 0 has no element"), "{msg}");
}
