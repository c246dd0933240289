//! Issue 49, items 2 and 10: the OpenTorsion importer (`kanedyn::opentorsion::convert`, `kanedyn
//! import`) bounded by its input and exact about its edges.
//!
//! It used to crash: a node-form file with node index 2^64 − 1 panicked (exit 101), 2^63 failed
//! with "capacity overflow", 1e12 aborted the process on allocation (and killed the Python
//! interpreter through `kanedyn.from_opentorsion`), and a 1.04 MB TORS file of 12,300 chained
//! components overflowed the stack (one recursion per connected component). And its edges: a
//! name with a newline escaped the converted RON's comment, a UTF-8 byte-order mark was refused,
//! a negative gear diameter accepted, a TORS file without `components` read as a node form.

use crate::support::cli;
use crate::support::scratch;
use kanedyn::error::Error;
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::opentorsion::convert;
use std::path::Path;

/// (line:column, field, message) of an input error.
fn located(e: Error) -> (Option<(usize, usize)>, String, String) {
    match e {
        Error::Input { location, message } => (location.line_col, location.path, message),
        other => panic!("not an input error: {other}"),
    }
}

fn load(ron: &str) -> Mechanism {
    Mechanism::from_source(&Source::from_text("m.ron", ron), &ReadPolicy::within(Path::new("")))
        .unwrap_or_else(|e| panic!("{e}\n{ron}"))
}

/// The three crash inputs of the issue, as a disk's node and as a shaft's: a located error each,
/// at the field that holds the index, before anything is sized by it; and the CLI exits 1 (an
/// error), not 101 (a panic) or by a signal (an abort).
#[test]
fn huge_node_indices_are_located_errors_not_crashes() {
    let tmp = scratch("importer-huge");
    for index in ["18446744073709551615", "9223372036854775808", "1000000000000"] {
        let text =
            format!("{{\"disks\": [{{\"node\": 0, \"inertia\": 1.0}},\n  {{\"node\": {index}, \"inertia\": 2.0}}]}}");
        let (at, field, message) = located(convert(Path::new("n.json"), &text, "n").unwrap_err());
        assert_eq!((at, field.as_str()), (Some((2, 12)), "disks[1].node"), "{message}");
        assert!(message.contains(&format!("node {index} is beyond the elements")), "{message}");
        assert!(message.contains("node 1 has no element"), "{message}");

        let text = format!("{{\"shafts\": [{{\"nl\": 0, \"nr\": {index}, \"k\": 1.0}}]}}");
        let (_, field, message) = located(convert(Path::new("n.json"), &text, "n").unwrap_err());
        assert_eq!(field, "shafts[0].nr", "{message}");

        let file = tmp.path().join(format!("n{}.json", index.len()));
        std::fs::write(&file, &text).unwrap();
        let out = cli::run(&["import", file.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{stderr}");
        assert!(stderr.contains(&format!("n{}.json:1:", index.len())) && !stderr.contains("panicked"), "{stderr}");
    }
}

/// `n` components chained end to end (`c_i.s` leads into `c_{i+1}`), each one shaft, the first
/// with a disk before it: n + 1 nodes in one line, written compactly as a generator would.
fn chain_of_components(n: usize) -> String {
    let mut text = String::from("{\"components\":[\n");
    for i in 0..n {
        let disk = if i == 0 { r#"{"name":"d","type":"Disk","inertia":1.5},"# } else { "" };
        let comma = if i + 1 < n { "," } else { "" };
        text += &format!(
            "{{\"name\":\"c{i}\",\"elements\":[{disk}{{\"name\":\"s\",\"type\":\"ShaftDiscrete\",\"stiffness\":1e5}}]}}{comma}\n"
        );
    }
    text += "],\"structure\":[\n";
    for i in 0..n - 1 {
        text += &format!("[\"c{i}.s\",\"c{}.s\"]{}\n", i + 1, if i + 2 < n { "," } else { "" });
    }
    text + "]}\n"
}

/// The issue's file of 12,300 chained components (here 1.3 MB, the issue's 1.04 MB) converts,
/// walked without recursion: on a thread with a 256 KiB stack (the recursion needed far more),
/// node by node in order.
#[test]
fn a_deep_chain_of_components_converts_on_a_small_stack() {
    let text = chain_of_components(12_300);
    let ron = std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(move || convert(Path::new("chain.json"), &text, "chain"))
        .unwrap()
        .join()
        .expect("no stack overflow or panic")
        .unwrap_or_else(|e| panic!("{e}"));
    let bodies: Vec<&str> = ron.lines().filter(|l| l.trim_start().starts_with("Body(")).collect();
    assert_eq!(bodies.len(), 12_301);
    // One line: the first node on its bearing, every further one hanging from the one before.
    assert!(bodies[12_300].contains("\"node_12300\""), "{}", bodies[12_300]);
    assert!(ron.contains("Joint(name: \"shaft_12299\", parent: \"node_12299\", child: \"node_12300\""));
}

/// A name with a newline (in a TORS element's or component's name, which the RON's comment on
/// excitations quotes) stays inside the comment: the RON loads, and no line of it starts with
/// the text after the newline.
#[test]
fn a_newline_in_a_name_stays_in_the_comment() {
    let text = r#"{"components": [{"name": "line\n)\nMechanism(name: \"evil\"", "elements": [
        {"name": "motor\nbodies: [", "type": "Disk", "inertia": 2.0, "excitation": {"x": 1}},
        {"name": "s", "type": "ShaftDiscrete", "stiffness": 1.0e4},
        {"name": "load", "type": "Disk", "inertia": 3.0}]}]}"#;
    let ron = convert(Path::new("x.json"), text, "x").unwrap_or_else(|e| panic!("{e}"));
    assert!(ron.contains(r#"(they were on: line\n)\nMechanism(name: \"evil\".motor\nbodies: [)"#), "{ron}");
    assert!(!ron.lines().any(|l| l.starts_with("bodies: [") || l.starts_with("Mechanism(name: \"evil\"")), "{ron}");
    assert_eq!(load(&ron).name, "x");
}

/// A UTF-8 byte-order mark (as Windows editors write) is skipped: the same RON as without it.
#[test]
fn a_byte_order_mark_is_skipped() {
    let text = r#"{"shafts": [{"nl": 0, "nr": 1, "k": 4.0e4}], "disks": [{"node": 0, "inertia": 2.5}, {"node": 1, "inertia": 4.0}]}"#;
    let plain = convert(Path::new("b.json"), text, "b").unwrap();
    let marked = convert(Path::new("b.json"), &format!("\u{FEFF}{text}"), "b").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(marked, plain);
    // And through the CLI, which reads the file's bytes.
    let tmp = scratch("importer-bom");
    let file = tmp.path().join("b.json");
    std::fs::write(&file, format!("\u{FEFF}{text}")).unwrap();
    let (ok, out, err) = cli::kanedyn(&["import", file.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert_eq!(out, plain);
}

/// A negative gear diameter (or tooth count) is refused at the gear, in both forms (it was
/// converted into a stage of the opposite sign).
#[test]
fn a_negative_gear_diameter_is_refused_at_the_gear() {
    let text = r#"{"components": [{"name": "box", "elements": [
        {"name": "pinion", "type": "GearElement", "inertia": 0.05, "diameter": 1.0},
        {"name": "wheel", "type": "GearElement", "inertia": 0.9, "diameter": -3.0, "parent": "pinion"}]}]}"#;
    let (at, field, message) = located(convert(Path::new("g.json"), text, "g").unwrap_err());
    assert_eq!((at, field.as_str()), (Some((3, 9)), "components[0].elements[1]"), "{message}");
    assert!(message.contains("must be finite and positive, got -3"), "{message}");
    let text = r#"{"gears": [{"node": 0, "inertia": 1.0, "radius": 2.0}, {"node": 1, "inertia": 1.0, "radius": -1.0, "parent": 0}]}"#;
    let (_, field, message) = located(convert(Path::new("g.json"), text, "g").unwrap_err());
    assert_eq!(field, "gears[1].radius", "{message}");
}

/// A TORS file without `components` is said to be one (it was read as a node form and refused
/// for an unknown field `structure`); a file of neither form names its keys.
#[test]
fn a_tors_file_without_components_is_named_as_such() {
    let text = "{\n  \"structure\": [[\"a.s\", \"b.d\"]]\n}";
    let (at, field, message) = located(convert(Path::new("t.json"), text, "t").unwrap_err());
    assert_eq!((at, field.as_str()), (Some((2, 16)), "structure"), "{message}");
    assert!(message.contains("without `components`"), "{message}");
    let text = "{\"name\": \"line\", \"elements\": []}";
    let (at, _, message) = located(convert(Path::new("t.json"), text, "t").unwrap_err());
    assert_eq!(at, Some((1, 1)), "{message}");
    assert!(message.contains("neither a TORS file") && message.contains("`elements`, `name`"), "{message}");
}
