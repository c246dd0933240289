//! Every RON snippet of the README and the user guide (`docs/guide/src/*.md`) is loaded and
//! validated as `kanedyn check` would, so the documentation cannot drift from the formats:
//!
//! - a `Mechanism(…)` is built (parts resolved against a copy of `examples/`); one whose first
//!   line names an example file (`// examples/cpva.ron …`) must build the same mechanism as that
//!   file, apart from the file it was read from;
//! - a `Study(…)` is loaded with every check `run` makes and planned;
//! - `Body(…)` and `Joint(…)` items are catalog parts: each is written as a part file and built
//!   into a small mechanism that names it (a joint between two plain bodies);
//! - an `Engine(…)` is built (its pressure table, firing order and geometry checked);
//! - anything else is a list of analyses, loaded inside a study of `examples/cpva.ron`.
//!
//! The Python snippets are run by `python/tests/test_doc_snippets.py`, the Rust one of the library
//! chapter as a doc test (`src/lib.rs`).

use kanedyn::combustion::{Engine, EngineSpec};
use kanedyn::io::Source;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::Study;
use std::path::{Path, PathBuf};

use crate::support::examples;

/// The Markdown files whose snippets are checked.
fn documents() -> Vec<PathBuf> {
    let mut out = vec![PathBuf::from("README.md"), PathBuf::from("python/README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir("docs/guide/src")
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    guide.sort();
    out.extend(guide);
    out
}

/// The fenced blocks of `lang` in `text`, with the line each starts on.
fn blocks(text: &str, lang: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        match &mut current {
            None if line.trim_end() == format!("```{lang}") => current = Some((i + 2, String::new())),
            Some(_) if line.starts_with("```") => out.push(current.take().unwrap()),
            Some((_, body)) => {
                body.push_str(line);
                body.push('\n');
            }
            None => {}
        }
    }
    assert!(current.is_none(), "an unclosed ```{lang} block");
    out
}

/// The top-level items of a RON snippet (`Name(…)` at bracket depth 0), each with the name.
fn items(code: &str) -> Vec<(String, String)> {
    let bytes = code.as_bytes();
    let (mut out, mut depth, mut start, mut i) = (Vec::new(), 0i32, None::<usize>, 0);
    while i < bytes.len() {
        match bytes[i] {
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
            }
            b'(' | b'[' => depth += 1,
            b')' | b']' => {
                depth -= 1;
                if depth == 0
                    && let Some(s) = start.take()
                {
                    let text = &code[s..=i];
                    let name = text[..text.find('(').unwrap()].trim().to_string();
                    out.push((name, text.to_string()));
                }
            }
            c if depth == 0 && start.is_none() && c.is_ascii_alphabetic() => start = Some(i),
            _ => {}
        }
        i += 1;
    }
    out
}

/// Checks one snippet in the scratch copy `dir` of `examples/`; `Err` says what is wrong.
fn check(dir: &Path, snippet: &str) -> Result<(), String> {
    let err = |e: kanedyn::error::Error| format!("{e:#}");
    let items = items(snippet);
    if items.is_empty() {
        return Err("no RON item in the block".into());
    }
    match items[0].0.as_str() {
        "Mechanism" => {
            let file = dir.join("snippet_mechanism.ron");
            std::fs::write(&file, snippet).unwrap();
            let mech = Mechanism::from_file(&file).map_err(err)?;
            let first = snippet.lines().next().unwrap_or("");
            if let Some(example) = first.strip_prefix("// examples/").and_then(|r| r.split([' ', ',', ':']).next()) {
                let mut original = Mechanism::from_file(&dir.join(example)).map_err(err)?;
                original.file = mech.file.clone();
                if original != mech {
                    return Err(format!("does not build the same mechanism as examples/{example}"));
                }
            }
        }
        "Study" => {
            let file = dir.join("snippet_study.ron");
            std::fs::write(&file, snippet).unwrap();
            Study::from_file(&file).map_err(err)?.plan();
        }
        "Body" | "Joint" => {
            for (k, (kind, text)) in items.iter().enumerate() {
                let part = format!("snippet_part_{k}.ron");
                std::fs::write(dir.join(&part), text).unwrap();
                let (bodies, joint) = match kind.as_str() {
                    "Body" => (
                        format!("Body(name: \"b\", part: \"{part}\")"),
                        "Joint(name: \"j\", kind: Revolute, parent: \"ground\", child: \"b\")".to_string(),
                    ),
                    "Joint" => (
                        "Body(name: \"p\", mass: 1.0, inertia: 0.01), Body(name: \"c\", mass: 1.0, inertia: 1e-3)"
                            .to_string(),
                        format!(
                            "Joint(name: \"root\", kind: Revolute, parent: \"ground\", child: \"p\"), \
                             Joint(name: \"j\", part: \"{part}\", parent: \"p\", child: \"c\")"
                        ),
                    ),
                    other => return Err(format!("a `{other}` item among catalog parts")),
                };
                let text = format!("Mechanism(name: \"snippet\", bodies: [{bodies}], joints: [{joint}])");
                let file = dir.join(format!("snippet_with_part_{k}.ron"));
                std::fs::write(&file, text).unwrap();
                Mechanism::from_file(&file).map_err(|e| format!("item {k}: {}", err(e)))?;
            }
        }
        "Engine" => {
            let spec: EngineSpec = Source::from_text("snippet.ron", snippet).parse_as("Engine").map_err(err)?;
            Engine::new(spec).map_err(|(field, msg)| format!("{field}: {msg}"))?;
        }
        _ => {
            let study = format!(
                "Study(name: \"snippet\", mechanism: \"cpva.ron\", spin_joint: \"spin\", response_body: \"rotor\", \
                 lock: [\"pivot\"], analyses: [\n{snippet}\n])"
            );
            let file = dir.join("snippet_analyses.ron");
            std::fs::write(&file, study).unwrap();
            Study::from_file(&file).map_err(err)?.plan();
        }
    }
    Ok(())
}

#[test]
fn every_ron_snippet_of_the_documentation_loads() {
    let tmp = crate::support::scratch("doc-snippets");
    let scratch = tmp.path().to_path_buf();
    examples::copy_dir(Path::new("examples"), &scratch);
    let (mut checked, mut failures) = (0, Vec::new());
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (line, snippet) in blocks(&text, "ron") {
            checked += 1;
            if let Err(e) = check(&scratch, &snippet) {
                failures.push(format!("{}:{line}: {e}", doc.display()));
            }
        }
    }
    assert!(failures.is_empty(), "{} of {checked} snippets fail:\n{}", failures.len(), failures.join("\n"));
    // The README's two and the guide's: a guard against the scan finding nothing.
    assert!(checked >= 20, "only {checked} RON snippets found");
}

/// The checker itself: a snippet with a misspelt field, an unknown joint in a study, or a
/// mechanism that claims to be an example file it differs from is refused.
#[test]
fn a_wrong_snippet_is_refused() {
    let tmp = crate::support::scratch("doc-snippets-bad");
    let scratch = tmp.path().to_path_buf();
    examples::copy_dir(Path::new("examples"), &scratch);
    let cpva = std::fs::read_to_string("examples/cpva.ron").unwrap();
    let claimed = format!("// examples/cpva.ron, changed\n{}", cpva.replace("c: 5e-3", "c: 5e-2"));
    let wrong = [
        "Joint(kind: Revolute, dampr: 5e-4)".to_string(),
        "Study(name: \"s\", mechanism: \"cpva.ron\", lock: [\"pivt\"], analyses: [])".to_string(),
        claimed,
        "Campbell(name: \"c\", rpm_min: 0.0, rpm_max: 2000.0, points: 1, orders: [3.0])".to_string(),
    ];
    for snippet in &wrong {
        assert!(check(&scratch, snippet).is_err(), "accepted:\n{snippet}");
    }
    // The same claim with the example's own text is accepted.
    assert_eq!(check(&scratch, &format!("// examples/cpva.ron, as is\n{cpva}")), Ok(()));
}
