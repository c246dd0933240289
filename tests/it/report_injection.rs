//! Issue 49, item 1: text from the study and mechanism files cannot script `report.html`.
//!
//! It used to: a variant label `<img src=x onerror=…>` became a live element, and a joint named
//! ``piv`<svg onload=…>` `` closed the Markdown code span that quotes it in `summary.md`, whose
//! raw HTML the report passed through (8 live `<svg onload>` in one report). The page is checked
//! by tokenizing it as a browser does (html5gum, a WHATWG tokenizer), not by searching its text:
//! exactly the page's own script, no event-handler attribute, no `javascript:` address, and the
//! hostile texts still there as text. Names with control characters are refused where they are
//! written, and CSV cells a spreadsheet would run as formulas are neutralised.

use crate::support::scratch;
use html5gum::{DefaultEmitter, Token, Tokenizer};
use kanedyn::error::Error;
use kanedyn::io::{ReadPolicy, Source};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use std::path::Path;

/// What a browser would find in a page: its script elements' start tags (with the script's
/// first characters), the event-handler attributes (`on…`), the attribute values that are
/// `javascript:` addresses, and the page's text.
#[derive(Default, Debug)]
struct Live {
    scripts: Vec<String>,
    handlers: Vec<String>,
    js_urls: Vec<String>,
    text: String,
}

fn live(html: &str) -> Live {
    let mut emitter = DefaultEmitter::default();
    // A script's or style's content is raw text, as the browser's tree builder switches the
    // tokenizer there; without it a `<` in the page's own script would read as a tag.
    emitter.naively_switch_states(true);
    let mut out = Live::default();
    let mut in_script = false;
    for token in Tokenizer::new_with_emitter(html, emitter) {
        match token.expect("a string never fails to read") {
            Token::StartTag(tag) => {
                let name = String::from_utf8_lossy(&tag.name).to_ascii_lowercase();
                for (attr, value) in &tag.attributes {
                    let attr = String::from_utf8_lossy(attr).to_ascii_lowercase();
                    let value = String::from_utf8_lossy(value).into_owned();
                    if attr.starts_with("on") {
                        out.handlers.push(format!("<{name} {attr}=\"{value}\">"));
                    }
                    let squeezed: String = value.chars().filter(|c| !c.is_whitespace()).collect();
                    if squeezed.to_ascii_lowercase().starts_with("javascript:") {
                        out.js_urls.push(format!("<{name} {attr}=\"{value}\">"));
                    }
                }
                if name == "script" {
                    out.scripts.push(String::new());
                    in_script = true;
                }
            }
            Token::EndTag(_) => in_script = false,
            Token::String(s) => {
                let s = String::from_utf8_lossy(&s);
                match out.scripts.last_mut() {
                    Some(script) if in_script => script.push_str(&s),
                    _ => out.text.push_str(&s),
                }
            }
            _ => {}
        }
    }
    out
}

/// The checker itself finds what it must: a live handler, a script, a `javascript:` link (so
/// the report's zero counts below are not zero by construction).
#[test]
fn the_checker_sees_live_elements() {
    let page = live(
        "<p>x <img src=x onerror=alert(1)> <a href=' javascript:alert(2)'>y</a></p>\
                     <svg><g onload=\"alert(3)\"></g></svg><script>if (a < b) {}</script>",
    );
    assert_eq!(page.handlers.len(), 2, "{page:?}");
    assert_eq!(page.js_urls.len(), 1, "{page:?}");
    assert_eq!(page.scripts, ["if (a < b) {}"]);
    assert_eq!(live("<p>&lt;img src=x onerror=alert(1)&gt;</p>").handlers.len(), 0);
}

/// The paper's rotor and pendulum with hostile names: a joint whose name closes a code span,
/// a body whose name is a script, a mechanism whose name is an element with a handler, a
/// spin joint whose name is a spreadsheet formula.
const MECHANISM: &str = r#"Mechanism(
    name: "cpva<img src=x onerror=alert('mechanism')>",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "rotor<script>alert('body')</script>", part: "catalog:bodies/flywheel_rotor.ron"),
        Body(name: "pend\"onmouseover=\"alert('quote')", part: "catalog:bodies/cpva_pendulum.ron"),
    ],
    joints: [
        Joint(name: "=HYPERLINK(\"http://x\",\"spin\")", kind: Revolute, parent: "ground",
              child: "rotor<script>alert('body')</script>", at: (0.0, 0.0)),
        Joint(name: "piv`<svg onload=alert('joint')>`", part: "catalog:joints/cpva_pivot.ron",
              parent: "rotor<script>alert('body')</script>", child: "pend\"onmouseover=\"alert('quote')",
              at: (0.17, 0.0)),
    ],
    loads: [GroundDamper(body: "rotor<script>alert('body')</script>", c: 5e-3)],
)"#;

/// The hostile variant label (at most 64 characters): an element with a handler, and a
/// `javascript:` Markdown link.
const LABEL: &str = "<img src=x onerror=alert(1)> [x](javascript:alert(2))";

#[test]
fn hostile_names_and_labels_reach_the_report_as_text_only() {
    let tmp = scratch("report-injection");
    let dir = tmp.path();
    std::fs::write(dir.join("m.ron"), MECHANISM).unwrap();
    let joint = "piv`<svg onload=alert('joint')>`";
    let spin = "=HYPERLINK(\"http://x\",\"spin\")";
    let body = "rotor<script>alert('body')</script>";
    let study = format!(
        r#"Study(name: "s", mechanism: "m.ron", response_body: {body:?}, spin_joint: {spin:?},
                 elements: [{spin:?}, {joint:?}], lock: [{joint:?}], analyses: [
            LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31,
                           variants: [(label: {LABEL:?}, dampers: [({joint:?}, 5e-4)])]),
            Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11),
        ])"#
    );
    std::fs::write(dir.join("s.ron"), study).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let file = |name: &str| report.files.iter().find(|f| f.ends_with(name)).unwrap_or_else(|| panic!("{name}"));
    let html = std::fs::read_to_string(file("report.html")).unwrap();

    let page = live(&html);
    assert_eq!(page.scripts.len(), 1, "the page's own script only: {:?}", page.scripts);
    assert!(page.scripts[0].trim_start().starts_with("//") || page.scripts[0].contains("kd-panel"));
    assert_eq!(page.handlers, Vec::<String>::new());
    assert_eq!(page.js_urls, Vec::<String>::new());
    // The hostile texts are shown, not dropped: each is in the page's text as written (the
    // summary quotes names, the figures' legends the label).
    for shown in ["<svg onload=alert('joint')>", "<script>alert('body')</script>", "<img src=x onerror=alert(1)>"] {
        assert!(page.text.contains(shown), "`{shown}` is not in the page's text");
    }
    // The same holds for the figures on their own (plotters escapes the text it draws).
    for svg in report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")) {
        let figure = live(&std::fs::read_to_string(svg).unwrap());
        assert!(figure.scripts.is_empty() && figure.handlers.is_empty(), "{}: {figure:?}", svg.display());
    }

    // No CSV cell starts a formula: the spin joint, an element, names columns, neutralised with
    // `'`; every data cell is still a number (or empty: none exists).
    let mut quoted = 0;
    for csv in report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "csv")) {
        let mut reader = csv::ReaderBuilder::new().has_headers(false).from_path(csv).unwrap();
        for (r, record) in reader.records().enumerate() {
            for cell in record.unwrap().iter() {
                let number = cell.parse::<f64>().is_ok_and(f64::is_finite);
                assert!(
                    number || !cell.starts_with(['=', '+', '-', '@', '\t', '\r']),
                    "{}: `{cell}` would run as a formula",
                    csv.display()
                );
                quoted += usize::from(cell.starts_with("'=HYPERLINK("));
                assert!(r == 0 || cell.is_empty() || number, "{}: data cell `{cell}`", csv.display());
            }
        }
    }
    assert!(quoted >= 2, "the spin joint's columns are not neutralised ({quoted})");
}

/// Where an input error is: (file, line:column, field, message).
fn located(e: Error) -> (String, Option<(usize, usize)>, String, String) {
    match e {
        Error::Input { location, message } => {
            (location.file.display().to_string(), location.line_col, location.path, message)
        }
        other => panic!("not an input error: {other}"),
    }
}

/// Body and joint names with a newline, tab, DEL or C1 control character are refused at their
/// field, with the file, line and column (they used to load, and a newline split the summary's
/// table rows and the converted RON's comments).
#[test]
fn names_with_control_characters_are_refused_where_they_are_written() {
    let load =
        |text: &str| Mechanism::from_source(&Source::from_text("m.ron", text), &ReadPolicy::within(Path::new("")));
    let mechanism = |body: &str, joint: &str| {
        format!(
            "Mechanism(\n    name: \"m\",\n    bodies: [\n        Body(name: \"{body}\", mass: 1.0, inertia: 1.0),\n    ],\n    \
             joints: [\n        Joint(name: \"{joint}\", kind: Revolute, parent: \"ground\", child: \"{body}\"),\n    ],\n)"
        )
    };
    load(&mechanism("rotor", "spin")).unwrap_or_else(|e| panic!("the plain names load: {e}"));
    // RON escapes, so the file itself is printable text.
    for (bad, shown) in
        [("rotor\\nx", "'\\n'"), ("rotor\\tx", "'\\t'"), ("rotor\\u{7f}", "U+007F"), ("ro\\u{85}tor", "U+0085")]
    {
        let (file, at, field, message) = located(load(&mechanism(bad, "spin")).unwrap_err());
        assert_eq!((file.as_str(), at, field.as_str()), ("m.ron", Some((4, 20)), "bodies[0].name"), "{message}");
        assert!(message.contains("control character") && message.contains(shown), "{message}");
        let (_, at, field, message) = located(load(&mechanism("rotor", bad)).unwrap_err());
        assert_eq!((at, field.as_str()), (Some((7, 21)), "joints[0].name"), "{message}");
        // The mechanism's own name reaches the same places (headings, the digest).
        let text = mechanism("rotor", "spin").replacen("name: \"m\"", &format!("name: \"m{bad}\""), 1);
        let (_, at, field, message) = located(load(&text).unwrap_err());
        assert_eq!((at, field.as_str()), (Some((2, 11)), "name"), "{message}");
    }
}
