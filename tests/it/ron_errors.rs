//! Bad input gives a clear error naming the file, the line:column and the field, never a panic.

use crate::support::scratch;
use kanedyn::model::mechanism::Mechanism;
use std::path::{Path, PathBuf};

/// Writes `text` to the file `name` in `dir` (a test's scratch folder) and returns its path.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn error_of(dir: &str, text: &str) -> String {
    let tmp = scratch(&format!("ron-errors-{dir}"));
    let p = write(tmp.path(), "m.ron", text);
    match Mechanism::from_file(&p) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// A valid two-body file; each test breaks one thing in it.
const GOOD: &str = r#"Mechanism(
    name: "m",
    bodies: [
        Body(name: "rotor", mass: 10.0, inertia: 1.0),
        Body(name: "arm", mass: 1.0, com: (0.1, 0.0), inertia: 0.01),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "pivot", parent: "rotor", child: "arm", at: (0.2, 0.0)),
    ],
)
"#;

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "error message {msg:?} should mention {p:?}");
    }
}

#[test]
fn the_good_file_loads() {
    let tmp = scratch("ron-errors-good");
    let p = write(tmp.path(), "m.ron", GOOD);
    let m = Mechanism::from_file(&p).unwrap();
    assert_eq!(m.ndof(), 2);
}

#[test]
fn malformed_ron_names_line_and_column() {
    let msg = error_of("syntax", &GOOD.replace("inertia: 1.0)", "inertia: 1.0"));
    assert_mentions(&msg, &["m.ron:5:"]);
}

#[test]
fn unknown_field_is_rejected_with_its_place() {
    let msg = error_of("unknown-field", &GOOD.replace("mass: 10.0", "mas: 10.0"));
    assert_mentions(&msg, &["m.ron:4:", "bodies[0]", "mas"]);
}

#[test]
fn unknown_body_name_points_at_the_value() {
    let msg = error_of("unknown-body", &GOOD.replace(r#"parent: "rotor""#, r#"parent: "rotr""#));
    assert_mentions(&msg, &["m.ron:9:38", "joints[1].parent", "unknown parent body `rotr`", "rotor, arm"]);
}

#[test]
fn duplicate_names_are_rejected() {
    let msg = error_of("dup-body", &GOOD.replace(r#"name: "arm""#, r#"name: "rotor""#));
    assert_mentions(&msg, &["m.ron:5:", "bodies[1].name", "duplicate body name `rotor`"]);
    let msg = error_of("dup-joint", &GOOD.replace(r#"name: "pivot""#, r#"name: "spin""#));
    assert_mentions(&msg, &["joints[1].name", "duplicate joint name `spin`"]);
}

#[test]
fn a_body_with_two_parents_or_none_is_rejected() {
    let two = GOOD.replace(
        r#"        Joint(name: "pivot""#,
        r#"        Joint(name: "extra", parent: "ground", child: "arm"),
        Joint(name: "pivot""#,
    );
    let msg = error_of("two-parents", &two);
    assert_mentions(&msg, &["joints[2].child", "body `arm` has two parents", "extra", "pivot"]);
    let none = GOOD.replace(r#"        Joint(name: "pivot", parent: "rotor", child: "arm", at: (0.2, 0.0)),"#, "");
    let msg = error_of("no-parent", &none);
    assert_mentions(&msg, &["m.ron:5:", "bodies[1]", "body `arm` is not attached"]);
}

#[test]
fn cycles_are_rejected() {
    let cyc = GOOD.replace(
        r#"Joint(name: "spin", parent: "ground", child: "rotor")"#,
        r#"Joint(name: "spin", parent: "arm", child: "rotor")"#,
    );
    let msg = error_of("cycle", &cyc);
    assert_mentions(&msg, &["cycle", "rotor, arm"]);
    let self_loop = GOOD.replace(r#"parent: "rotor", child: "arm""#, r#"parent: "arm", child: "arm""#);
    assert_mentions(&error_of("self", &self_loop), &["joints[1].parent", "to itself"]);
}

#[test]
fn bad_numbers_are_rejected() {
    let msg = error_of("massless", &GOOD.replace("mass: 1.0, com: (0.1, 0.0), inertia: 0.01", "com: (0.1, 0.0)"));
    assert_mentions(&msg, &["m.ron:5:9", "bodies[1]", "no mass and no inertia"]);
    let msg = error_of("negative-mass", &GOOD.replace("mass: 10.0", "mass: -10.0"));
    assert_mentions(&msg, &["m.ron:4:35", "bodies[0].mass", "negative mass"]);
    let msg = error_of("negative-inertia", &GOOD.replace("inertia: 0.01", "inertia: -0.01"));
    assert_mentions(&msg, &["bodies[1].inertia", "negative moment of inertia"]);
    let msg = error_of("nan", &GOOD.replace("mass: 10.0", "mass: NaN"));
    assert_mentions(&msg, &["bodies[0].mass", "finite"]);
    let msg = error_of("inf", &GOOD.replace("at: (0.2, 0.0)", "at: (inf, 0.0)"));
    assert_mentions(&msg, &["joints[1].at", "finite"]);
    let msg = error_of("neg-damper", &GOOD.replace("at: (0.2, 0.0)", "at: (0.2, 0.0), damper: -1.0"));
    assert_mentions(&msg, &["joints[1].damper", "non-negative"]);
}

#[test]
fn singular_mass_matrix_names_the_joint() {
    // A point mass on its own pivot has no inertia about that joint.
    let msg = error_of("singular", &GOOD.replace("mass: 1.0, com: (0.1, 0.0), inertia: 0.01", "mass: 1.0"));
    assert_mentions(&msg, &["m.ron:9:", "joints[1]", "not positive definite", "pivot"]);
}

#[test]
fn loads_name_known_bodies_and_joints() {
    let with_loads = |l: &str| GOOD.replace("    ],\n)", &format!("    ],\n    loads: [{l}],\n)"));
    let msg = error_of("load-body", &with_loads(r#"GroundDamper(body: "rotorr", c: 1.0)"#));
    assert_mentions(&msg, &["loads[0].body", "unknown body `rotorr`"]);
    let msg = error_of("load-joint", &with_loads(r#"JointTorque(joint: "spinn", excitation: (mean: 1.0))"#));
    assert_mentions(&msg, &["loads[0].joint", "unknown joint `spinn`"]);
    let msg = error_of(
        "load-rpm",
        &with_loads(r#"JointTorque(joint: "spin", excitation: (harmonics: [(multiple: 1.0, amplitude: 2.0)]))"#),
    );
    assert_mentions(&msg, &["loads[0].excitation.rpm", "reference speed"]);
}

#[test]
fn missing_and_bad_parts_name_the_part() {
    let msg = error_of(
        "part-missing",
        &GOOD.replace(r#"Body(name: "rotor", mass: 10.0, inertia: 1.0)"#, r#"Body(name: "rotor", part: "nope.ron")"#),
    );
    assert_mentions(&msg, &["m.ron:4:", "bodies[0].part", "nope.ron"]);
    let tmp = scratch("ron-errors-part-bad");
    let part = write(tmp.path(), "p.ron", "Body(mass: -3.0)");
    assert!(part.exists());
    let p = write(
        tmp.path(),
        "m.ron",
        &GOOD.replace(r#"Body(name: "rotor", mass: 10.0, inertia: 1.0)"#, r#"Body(name: "rotor", part: "p.ron")"#),
    );
    let msg = Mechanism::from_file(&p).unwrap_err().to_string();
    assert_mentions(&msg, &["p.ron:1:", "negative mass"]);
}

#[test]
fn a_missing_file_is_an_error_not_a_panic() {
    let msg = Mechanism::from_file(Path::new("/nonexistent/kanedyn.ron")).unwrap_err().to_string();
    assert_mentions(&msg, &["/nonexistent/kanedyn.ron", "cannot read"]);
}
