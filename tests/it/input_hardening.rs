//! Issue 11, reliability and security of study runs: input files are data from someone else.
//! Each test says what used to go wrong.

use kanedyn::io::{ReadPolicy, Source, line_col, locate};
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// A fresh, empty temporary folder for one test.
fn folder(name: &str) -> tempfile::TempDir {
    crate::support::scratch(&format!("hardening-{name}"))
}

/// A one-body mechanism whose body is the catalog part `part`.
fn with_part(part: &str) -> String {
    format!(
        r#"Mechanism(
    name: "m",
    bodies: [Body(name: "rotor", part: "{part}")],
    joints: [Joint(name: "spin", parent: "ground", child: "rotor")],
)
"#
    )
}

use crate::support::cli;
use cli::kanedyn;

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "error message {msg:?} should mention {p:?}");
    }
}

const SECRET: &str = "root:x:0:0:hunter2:/root:/bin/bash\n";

#[test]
fn parts_outside_the_mechanism_folder_are_refused_alike_whether_or_not_they_exist() {
    // Used to: read any file a part path named, `/etc/passwd` or `../../x`, and say whether it
    // existed ("No such file" against a parse error), so a study file could probe the disk.
    let tmp = folder("escape");
    let root = tmp.path().to_path_buf();
    let dir = root.join("mech");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("outside.ron"), "Body(mass: 1.0, inertia: 1.0)").unwrap();
    let err = |part: &str| {
        std::fs::write(dir.join("m.ron"), with_part(part)).unwrap();
        Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string()
    };
    let exists = err("../outside.ron");
    let missing = err("../missing.ron");
    assert_mentions(&exists, &["m.ron:3:", "bodies[0].part", "--allow-read DIR", "--allow-any-path", "outside"]);
    assert_eq!(exists.replace("outside.ron", "X"), missing.replace("missing.ron", "X"));
    // Lexical normalisation: a detour that climbs out is refused too, one that stays is not.
    let detour = err("sub/../../outside.ron");
    assert_mentions(&detour, &["--allow-read DIR"]);
    for absolute in ["/etc/passwd", "/nonexistent/x.ron"] {
        let msg = err(absolute);
        assert_mentions(&msg, &["--allow-read DIR", "absolute"]);
        assert!(!msg.contains("root:"), "{msg}");
    }
    std::fs::write(dir.join("inside.ron"), "Body(mass: 1.0, inertia: 1.0)").unwrap();
    std::fs::write(dir.join("m.ron"), with_part("sub/../inside.ron")).unwrap();
    Mechanism::from_file(&dir.join("m.ron")).unwrap();
    // Another root, or no restriction, lets the outside part in.
    std::fs::write(dir.join("m.ron"), with_part("../outside.ron")).unwrap();
    Mechanism::from_file_with(&dir.join("m.ron"), &ReadPolicy::within(&dir).allow(&root)).unwrap();
    Mechanism::from_file_with(&dir.join("m.ron"), &ReadPolicy::unrestricted()).unwrap();
}

#[cfg(unix)]
#[test]
fn a_symbolic_link_out_of_the_folder_is_refused() {
    // Used to: follow `part: "link.ron"` wherever the link pointed.
    let tmp = folder("symlink");
    let root = tmp.path().to_path_buf();
    let dir = root.join("mech");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("secret.ron"), "Body(mass: 1.0, inertia: 1.0)").unwrap();
    std::os::unix::fs::symlink(root.join("secret.ron"), dir.join("link.ron")).unwrap();
    std::fs::write(dir.join("m.ron"), with_part("link.ron")).unwrap();
    let msg = Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string();
    assert_mentions(&msg, &["bodies[0].part", "symbolic link", "--allow-read DIR"]);
    // A link that stays inside is fine.
    std::fs::write(dir.join("real.ron"), "Body(mass: 1.0, inertia: 1.0)").unwrap();
    std::os::unix::fs::symlink(dir.join("real.ron"), dir.join("ok.ron")).unwrap();
    std::fs::write(dir.join("m.ron"), with_part("ok.ron")).unwrap();
    Mechanism::from_file(&dir.join("m.ron")).unwrap();
}

#[test]
fn resolve_answers_before_looking_and_canonicalises_after() {
    let tmp = folder("resolve");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("a.ron"), "").unwrap();
    let policy = ReadPolicy::within(&dir);
    assert_eq!(policy.resolve(&dir, "x/../a.ron").unwrap(), std::fs::canonicalize(dir.join("a.ron")).unwrap());
    let missing = policy.resolve(&dir, "b.ron").unwrap_err();
    assert!(missing.starts_with("cannot read") && missing.matches("No such file").count() <= 1, "{missing}");
    assert!(policy.resolve(&dir, "../a.ron").unwrap_err().contains("--allow-any-path"));
    assert!(ReadPolicy::unrestricted().resolve(&dir, "/etc/hostname").is_ok());
    assert_eq!(ReadPolicy::within(&dir).max_file_bytes, ReadPolicy::DEFAULT_MAX_FILE_BYTES);
    assert_eq!(ReadPolicy::unrestricted().with_max_bodies(7).max_bodies, 7);
}

#[test]
fn large_and_special_files_are_refused_without_reading_them_whole() {
    // Used to: `read_to_string` whatever was named, so `/dev/zero` (or a FIFO, or a huge file)
    // exhausted memory or hung.
    let tmp = folder("size");
    let dir = tmp.path().to_path_buf();
    let p = dir.join("big.ron");
    std::fs::write(&p, vec![b' '; 101]).unwrap();
    let policy = ReadPolicy::within(&dir).with_max_file_bytes(100);
    let msg = Source::read_with(&p, &policy).unwrap_err().to_string();
    assert_mentions(&msg, &["big.ron", "101 bytes", "limit of 100 bytes", "with_max_file_bytes"]);
    std::fs::write(&p, vec![b' '; 100]).unwrap();
    Source::read_with(&p, &policy).unwrap();
    let msg = Source::read(&dir).unwrap_err().to_string();
    assert_mentions(&msg, &["not a regular file", "folder"]);
    #[cfg(unix)]
    {
        let start = Instant::now();
        let msg = Source::read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_mentions(&msg, &["/dev/zero", "not a regular file"]);
        assert!(start.elapsed() < Duration::from_secs(1));
        // A part that is a FIFO would block the open; it is refused from its stat.
        let fifo = dir.join("fifo.ron");
        if Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            std::fs::write(dir.join("m.ron"), with_part("fifo.ron")).unwrap();
            let msg = Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string();
            assert_mentions(&msg, &["bodies[0].part", "not a regular file"]);
        }
    }
}

#[test]
fn a_file_of_another_kind_is_not_echoed() {
    // Used to: "expected struct `Mechanism` but found `root`", and for a part the same with the
    // first word of whatever file the part path named.
    let tmp = folder("echo");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), SECRET).unwrap();
    let msg = Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string();
    assert_mentions(&msg, &["m.ron:1:1", "not a `Mechanism` file: it must begin with `Mechanism(`"]);
    assert!(!msg.contains("root") && !msg.contains("hunter2"), "{msg}");
    std::fs::write(dir.join("p.ron"), SECRET).unwrap();
    std::fs::write(dir.join("m.ron"), with_part("p.ron")).unwrap();
    let msg = Mechanism::from_file(&dir.join("m.ron")).unwrap_err().to_string();
    assert_mentions(&msg, &["p.ron:1:1", "not a `Body` file"]);
    assert!(!msg.contains("root") && !msg.contains("hunter2"), "{msg}");
    // Comments and attributes may come first; a joint file is not a body file.
    let src = Source::from_text("j.ron", "#![enable(implicit_some)]\n// a joint\nJoint(name: \"j\")");
    let msg = src.parse_as::<kanedyn::model::body::BodySpec>("Body").unwrap_err().to_string();
    assert_mentions(&msg, &["j.ron:3:1", "not a `Body` file"]);
    // The plain `parse` does not quote the first word of a mismatched file either.
    for text in ["Secret(name: \"m\")", "hunter2 x", "12345", "\"hunter2\""] {
        let msg = Source::from_text("s.ron", text).parse::<MechanismSpec>().unwrap_err().to_string();
        assert!(!msg.contains("Secret") && !msg.contains("hunter2") && !msg.contains("12345"), "{msg}");
    }
}

#[test]
fn invalid_utf8_is_reported_once_with_its_position() {
    // Used to: "stream did not contain valid UTF-8: stream did not contain valid UTF-8", no line.
    let tmp = folder("utf8");
    let dir = tmp.path().to_path_buf();
    let p = dir.join("m.ron");
    std::fs::write(&p, b"Mechanism(\n  name: \"\xff\")").unwrap();
    let msg = Mechanism::from_file(&p).unwrap_err().to_string();
    assert_mentions(&msg, &["m.ron:2:10: not UTF-8 text (invalid byte 0xff)"]);
    assert_eq!(msg.matches("UTF-8").count(), 1, "{msg}");
}

#[test]
fn the_cli_prints_an_os_error_once() {
    // Used to: "cannot read: No such file or directory (os error 2): No such file or directory
    // (os error 2)" (the error's text and anyhow's cause chain both carried the reason).
    let (ok, _, err) = kanedyn(&["check", "examples/no-such-file.ron"]);
    assert!(!ok);
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    let (ok, _, err) = kanedyn(&["check", "examples"]);
    assert!(!ok);
    assert_mentions(&err, &["examples", "not a regular file"]);
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn catalog_parts_load_with_the_default_policy() {
    // Used to: name `../bodies/…`, which the default policy now refuses.
    let (ok, out, err) = kanedyn(&["check", "examples/cpva.ron"]);
    assert!(ok, "{err}");
    assert!(out.contains("OK"));
}

#[test]
fn an_empty_mechanism_is_refused() {
    // Used to: pass `check` with zero degrees of freedom.
    let src = Source::from_text("m.ron", "Mechanism(name: \"m\", bodies: [], joints: [])");
    let msg = Mechanism::from_source(&src, &ReadPolicy::unrestricted()).unwrap_err().to_string();
    assert_mentions(&msg, &["m.ron:1:30 (field `bodies`)", "no bodies: nothing to simulate"]);
}

#[test]
fn too_many_bodies_fail_fast() {
    // Used to: validate 10,001 bodies one by one, order the tree in O(n²) and factor a
    // 10,001² mass matrix before anything could go wrong: minutes, not an error.
    let n = 10_001;
    let mut text = String::from("Mechanism(name: \"chain\", bodies: [\n");
    for i in 0..n {
        text += &format!("Body(name: \"b{i}\", mass: 1.0, com: (0.5, 0.0), inertia: 0.1),\n");
    }
    text += "], joints: [\n";
    for i in 0..n {
        let parent = if i == 0 { "ground".to_string() } else { format!("b{}", i - 1) };
        text += &format!("Joint(name: \"j{i}\", parent: \"{parent}\", child: \"b{i}\", at: (1.0, 0.0)),\n");
    }
    text += "])\n";
    let src = Source::from_text("chain.ron", &text);
    let start = Instant::now();
    let msg = Mechanism::from_source(&src, &ReadPolicy::unrestricted()).unwrap_err().to_string();
    let took = start.elapsed();
    assert_mentions(&msg, &["chain.ron:1:34 (field `bodies`)", "10001 bodies", "limit of 1000", "--max-bodies N"]);
    assert!(took < Duration::from_millis(500), "took {took:?}");
    // Loads have their own, larger cap.
    let loads: Vec<String> = (0..11).map(|_| "GroundDamper(body: \"a\", c: 1.0)".to_string()).collect();
    let text = format!(
        "Mechanism(name: \"m\", bodies: [Body(name: \"a\", mass: 1.0)], \
         joints: [Joint(name: \"j\", parent: \"ground\", child: \"a\")], loads: [{}])",
        loads.join(", ")
    );
    let policy = ReadPolicy::unrestricted().with_max_bodies(1);
    let msg = Mechanism::from_source(&Source::from_text("m.ron", &text), &policy).unwrap_err().to_string();
    assert_mentions(&msg, &["field `loads`", "11 loads", "limit of 10"]);
}

/// The error of a one-body mechanism whose body is `body`.
fn body_error(body: &str) -> String {
    let text = format!(
        "Mechanism(\n  name: \"m\",\n  bodies: [\n    {body},\n  ],\n  joints: [Joint(name: \"j\", parent: \"ground\", child: \"b\")],\n)"
    );
    match Mechanism::from_source(&Source::from_text("m.ron", &text), &ReadPolicy::unrestricted()) {
        Ok(_) => panic!("expected an error for {body}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn non_finite_mass_properties_name_the_body_field() {
    // Used to: "m.ron:1:1: mass matrix is not positive definite: pivot NaN…" or no error at all,
    // with no field, for numbers each finite but whose product overflows.
    let msg = body_error("Body(name: \"b\", shape: Disc(radius: 10.0), areal_density: 1e308)");
    assert_mentions(
        &msg,
        &["m.ron:4:63 (field `bodies[0].areal_density`)", "mass properties overflow", "mass inf kg", "1e308 kg/m²"],
    );
    // parry keeps 1/mass, so an infinite area used to come back as a body without mass.
    let msg = body_error("Body(name: \"b\", shape: Disc(radius: 1e200), areal_density: 1.0)");
    assert_mentions(&msg, &["(field `bodies[0].shape.radius`)", "too large"]);
    let msg = body_error(
        "Body(name: \"b\", shape: ConvexPolygon(points: [(0.0, 0.0), (1e200, 0.0), (0.0, 1.0)]), areal_density: 1.0)",
    );
    assert_mentions(&msg, &["(field `bodies[0].shape.points[1]`)", "too large"]);
    // Sizes that fit, placed too far out: the shape's own moment overflows.
    let msg = body_error(
        "Body(name: \"b\", shape: Compound(parts: [Placed(shape: Disc(radius: 1.0), at: (1e200, 0.0))]), areal_density: 1.0)",
    );
    assert_mentions(&msg, &["(field `bodies[0].shape`)", "overflow"]);
    let msg = body_error("Body(name: \"b\", shape: Disc(radius: 1.0), density: 1e200, thickness: 1e200)");
    assert_mentions(&msg, &["m.ron:4:56 (field `bodies[0].density`)", "overflows"]);
    // Finite mass and centre of mass, but m·|c|² (the inertia about the joint) overflows.
    let msg = body_error("Body(name: \"b\", mass: 1e300, com: (1e200, 0.0))");
    assert_mentions(&msg, &["(field `bodies[0].com`)", "overflows"]);
    // Each body finite, the mass matrix not: a heavy body far out on its joint.
    let text = "Mechanism(name: \"m\", bodies: [Body(name: \"a\", mass: 1.0, inertia: 1.0), \
                Body(name: \"b\", mass: 1e300, inertia: 1.0)], joints: [Joint(name: \"j\", parent: \"ground\", \
                child: \"a\"), Joint(name: \"k\", parent: \"a\", child: \"b\", at: (1e200, 0.0))])";
    let msg =
        Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::unrestricted()).unwrap_err().to_string();
    assert_mentions(&msg, &["(field `joints[", "not finite"]);
    assert!(!msg.contains("m.ron:1:1 "), "{msg}");
}

#[test]
fn eom_refuses_to_print_null() {
    // Used to: print `"forcing":[…,null]` and exit 0 (serde_json writes NaN and ∞ as null).
    let (ok, out, err) = kanedyn(&["eom", "examples/cpva.ron", "--q", "0,0", "--u", "1e200,0"]);
    assert!(!ok && !out.contains("null"), "{out}");
    assert_mentions(&err, &["overflow", "F["]);
    for (flag, args) in [
        ("--t", ["--q", "0,0", "--u", "0,0", "--t", "x"]),
        ("--q", ["--q", "0,y", "--u", "0,0", "--t", "0"]),
        ("--u", ["--q", "0,0", "--u", "inf,0", "--t", "0"]),
    ] {
        let mut all = vec!["eom", "examples/cpva.ron"];
        all.extend(args);
        let (ok, _, err) = kanedyn(&all);
        assert!(!ok && err.contains(flag), "{flag}: {err}");
    }
}

#[test]
fn deep_nesting_cannot_overflow_the_stack() {
    // ron's recursion limit (128) is in force through `Source::parse`; the location scanner is
    // iterative. Run on a small stack so that a recursion without a limit would show.
    let run = || {
        let mut shape = String::from("Disc(radius: 1.0)");
        for _ in 0..5000 {
            shape = format!("Compound(parts: [Placed(shape: {shape})])");
        }
        let text = format!("Body(name: \"b\", areal_density: 1.0, shape: {shape})");
        let msg = Source::from_text("b.ron", &text).parse_as::<kanedyn::model::body::BodySpec>("Body").unwrap_err();
        assert!(msg.to_string().contains("recursion limit"), "{msg}");
        let brackets = format!("Mechanism(name: \"m\", bodies: {}", "[".repeat(100_000));
        let src = Source::from_text("m.ron", &brackets);
        assert!(Mechanism::from_source(&src, &ReadPolicy::unrestricted()).is_err());
        // The scanner walks a deep path without recursing.
        let deep_path = "[0]".repeat(100_000);
        let _ = locate(&"[".repeat(100_000), &deep_path);
    };
    std::thread::Builder::new().stack_size(1 << 20).spawn(run).unwrap().join().unwrap();
}

#[test]
fn long_lines_and_long_lists_are_quick() {
    let start = Instant::now();
    // A 1 MB name on one line; the error about it must still come with its place.
    let name = "n".repeat(1 << 20);
    let text = format!(
        "Mechanism(name: \"m\", bodies: [Body(name: \"{name}\", mass: 1.0), Body(name: \"{name}\", mass: 1.0)], joints: [])"
    );
    let msg = Mechanism::from_source(&Source::from_text("m.ron", &text), &ReadPolicy::unrestricted())
        .unwrap_err()
        .to_string();
    assert_mentions(&msg, &["bodies[1].name", "duplicate body name"]);
    // A polygon of 100,000 points (convex: on a circle).
    let points: Vec<String> = (0..100_000)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 100_000.0;
            format!("({}, {})", a.cos(), a.sin())
        })
        .collect();
    let text = format!("Body(name: \"b\", areal_density: 1.0, shape: ConvexPolygon(points: [{}]))", points.join(","));
    let src = Source::from_text("b.ron", &text);
    let spec: kanedyn::model::body::BodySpec = src.parse_as("Body").unwrap();
    let _ = spec.check_numbers(&src, "");
    let _ = src.locate("shape.points[99999]");
    assert!(start.elapsed() < Duration::from_secs(1), "took {:?}", start.elapsed());
}

#[test]
fn locate_never_panics_on_truncated_or_garbled_text() {
    let text = r##"#![enable(implicit_some)]
/* a /* nested */ comment */ Mechanism(
    name: r#"raw "name""#, // line comment
    bodies: [Body(name: "a\"b", mass: 1.0, shape: Compound(parts: [Placed(shape: Disc(radius: 1.0))]))],
    joints: [Joint(name: 'c', parent: "ground")], gravity: (0.0, -9.81), "é": ß,
)"##;
    let paths = ["", "name", "bodies[0].shape.parts[0].shape.radius", "joints[0].parent", "gravity[1]", "é", "x[3].y"];
    let mut cuts: Vec<String> =
        (0..=text.len()).filter(|&i| text.is_char_boundary(i)).map(|i| text[..i].to_string()).collect();
    // Garbled: a fixed pseudo-random soup of the characters the scanner cares about.
    let alphabet: Vec<char> = "()[]{}\"'r#/*\\:, \nab0é".chars().collect();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for len in 0..400 {
        let s: String = (0..len % 60)
            .map(|_| {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                alphabet[(seed % alphabet.len() as u64) as usize]
            })
            .collect();
        cuts.push(s);
    }
    for t in &cuts {
        for p in paths {
            if let Some(off) = locate(t, p) {
                assert!(off <= t.len());
            }
            let _ = line_col(t, usize::MAX);
            let _ = Source::from_text("t.ron", t).locate(p);
        }
    }
}
