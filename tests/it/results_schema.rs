//! docs/results.schema.json is generated from the result types (`kanedyn schema`, i.e.
//! `study::json::schema`) and cannot drift from them: the file must equal the generated schema,
//! the schema must be valid draft 2020-12, every example study's `results.json` must validate
//! against it, and documents broken in the ways a writer or a hand edit could break them must not.

use crate::support::cli::kanedyn;
use crate::support::scratch;
use kanedyn::study::{RunOptions, Study, run};
use serde_json::Value;
use std::path::{Path, PathBuf};

const SCHEMA_FILE: &str = "docs/results.schema.json";

/// The example studies: every `examples/*.ron` that holds a `Study(`. All of them together run in
/// about 15 s in release (the path comparison and the truck driveline are the slow ones), well
/// under a minute, so every one is validated.
fn example_studies() -> Vec<PathBuf> {
    let mut studies: Vec<PathBuf> = std::fs::read_dir("examples")
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .filter(|p| std::fs::read_to_string(p).unwrap().lines().any(|l| l.trim_start().starts_with("Study(")))
        .collect();
    studies.sort();
    studies
}

fn validator() -> jsonschema::Validator {
    jsonschema::validator_for(&kanedyn::study::json::schema()).expect("the generated schema compiles")
}

/// Every error of `doc` against the schema, one line each with its place in the document.
fn errors(v: &jsonschema::Validator, doc: &Value) -> Vec<String> {
    v.iter_errors(doc).map(|e| format!("{}: {e}", e.instance_path())).collect()
}

#[test]
fn the_schema_file_is_the_generated_schema() {
    let generated = kanedyn::study::json::schema();
    let text = std::fs::read_to_string(SCHEMA_FILE).unwrap();
    let regenerate = "regenerate it: cargo run --release -- schema > docs/results.schema.json";
    let file: Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{SCHEMA_FILE} is not JSON ({e}); {regenerate}"));
    assert!(file == generated, "{SCHEMA_FILE} differs from the schema of the result types; {regenerate}");
    // The file is the CLI's output byte for byte, so regenerating it leaves no diff behind.
    let (ok, printed, err) = kanedyn(&["schema"]);
    assert!(ok, "{err}");
    assert_eq!(printed, text, "{SCHEMA_FILE} is not `kanedyn schema`'s output; {regenerate}");
    assert_eq!(file["$schema"], "https://json-schema.org/draft/2020-12/schema");
    jsonschema::meta::validate(&file).unwrap_or_else(|e| panic!("not a valid JSON Schema: {e}"));
}

#[test]
fn the_schema_names_every_kind_and_describes_every_field() {
    let schema = kanedyn::study::json::schema();
    let defs = schema["$defs"].as_object().unwrap();
    let entry = &defs["AnalysisEntry"];
    let kinds: Vec<&str> =
        entry["properties"]["kind"]["enum"].as_array().unwrap().iter().map(|k| k.as_str().unwrap()).collect();
    assert_eq!(kinds, kanedyn::study::AnalysisSpec::kinds());
    assert_eq!(kinds.len(), 10, "{kinds:?}");
    // One layout of result and findings per kind, and the failed-status rule.
    let conditions = entry["allOf"].as_array().unwrap();
    assert_eq!(conditions.len(), kinds.len() + 1);
    // Every field says what it is (and its unit): the descriptions are the types' doc comments.
    let mut undocumented = Vec::new();
    for (name, def) in defs {
        for (field, s) in def["properties"].as_object().into_iter().flatten() {
            if s.get("description").and_then(Value::as_str).is_none_or(|d| d.trim().is_empty()) {
                undocumented.push(format!("{name}.{field}"));
            }
        }
    }
    assert!(undocumented.is_empty(), "fields without a description: {undocumented:?}");
}

#[test]
fn a_partial_results_json_validates_against_the_schema() {
    // A harmonic balance that diverges from one end: its entry is `partial`, the document too.
    let tmp = scratch("results-schema-partial");
    let dir = tmp.path().to_path_buf();
    crate::support::examples::copy_cpva(&dir);
    let study = dir.join("iso.ron");
    std::fs::write(
        &study,
        r#"Study(name: "iso", mechanism: "cpva.ron", lock: ["pivot"], analyses: [
    LinearResponse(name: "before", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
    HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                    harmonics: 1, multiples: [1.0]),
])"#,
    )
    .unwrap();
    let doc = results_json(&study, &dir.join("out"));
    assert_eq!(doc["status"], "partial");
    assert_eq!(doc["analyses"][1]["status"], "partial");
    assert_eq!(doc["analyses"][1]["failures"].as_array().map(Vec::len), Some(1));
    let v = validator();
    assert_eq!(errors(&v, &doc), Vec::<String>::new());
    // An entry's status is one of three words.
    let mut d = doc.clone();
    d["analyses"][1]["status"] = "stopped".into();
    assert!(!v.is_valid(&d));
}

/// Runs `study` into `out` and returns its results.json.
fn results_json(study: &Path, out: &Path) -> Value {
    let s = Study::from_file(study).unwrap_or_else(|e| panic!("{}: {e}", study.display()));
    run(&s, &RunOptions { out: Some(out.to_path_buf()), progress: false }).unwrap();
    let text = std::fs::read_to_string(out.join(&s.spec.name).join("results.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// The kinds of the entries of `doc`, a comparison's inner entries included.
fn kinds_in(entries: &Value, into: &mut Vec<String>) {
    for a in entries.as_array().into_iter().flatten() {
        into.push(a["kind"].as_str().unwrap().to_string());
        for m in a["result"]["mechanisms"].as_array().into_iter().flatten() {
            kinds_in(&m["analyses"], into);
        }
    }
}

#[test]
fn every_example_results_json_validates_against_the_schema() {
    let v = validator();
    let tmp = scratch("results-schema");
    let out = tmp.path().to_path_buf();
    let studies = example_studies();
    assert!(studies.len() >= 9, "{studies:?}");
    let mut kinds = Vec::new();
    let mut paper = None;
    for study in &studies {
        let doc = results_json(study, &out);
        let errs = errors(&v, &doc);
        assert!(
            errs.is_empty(),
            "{}: {} errors, first: {:#?}",
            study.display(),
            errs.len(),
            &errs[..errs.len().min(5)]
        );
        kinds_in(&doc["analyses"], &mut kinds);
        if study.ends_with("cpva_paper.ron") {
            paper = Some(doc);
        }
    }
    // Every kind's layout was exercised by a real document.
    for kind in kanedyn::study::AnalysisSpec::kinds() {
        assert!(kinds.iter().any(|k| k == kind), "no example has a {kind} analysis: its layout is unchecked");
    }

    // Broken documents fail, so the check above is not vacuous.
    let doc = paper.expect("examples/cpva_paper.ron is an example");
    let kind_at = |k: usize| doc["analyses"][k]["kind"].as_str().unwrap().to_string();
    assert_eq!(
        (kind_at(0), kind_at(3), kind_at(4)),
        ("OrderSweep".into(), "Campbell".into(), "HarmonicBalance".into())
    );
    // Each with the place its error is reported at (a kind's layout fails as a whole, at the
    // entry's result or findings).
    type Break = Box<dyn Fn(&mut Value)>;
    let broken: Vec<(&str, &str, Break)> = vec![
        (
            "a NaN written as text in a column",
            "/analyses/0/tables/0/columns/2/values/5",
            Box::new(|d| d["analyses"][0]["tables"][0]["columns"][2]["values"][5] = "NaN".into()),
        ),
        (
            "a column without its unit",
            "/analyses/1/tables/0/columns/0",
            Box::new(|d| {
                d["analyses"][1]["tables"][0]["columns"][0].as_object_mut().unwrap().remove("unit");
            }),
        ),
        (
            "a sweep's result in a Campbell entry",
            "/analyses/3/result",
            Box::new(|d| d["analyses"][3]["result"] = d["analyses"][0]["result"].clone()),
        ),
        ("an unknown document status", "/status", Box::new(|d| d["status"] = "fine".into())),
        (
            "a failed analysis that still has a result",
            "/analyses/2/",
            Box::new(|d| d["analyses"][2]["status"] = "failed".into()),
        ),
        ("an unknown kind", "/analyses/2/kind", Box::new(|d| d["analyses"][2]["kind"] = "Linear".into())),
        (
            "a field the types do not have",
            "/analyses/0/result",
            Box::new(|d| d["analyses"][0]["result"]["runs"][0]["extra"] = 1.0.into()),
        ),
        (
            "a renamed field deep in a result",
            "/analyses/4/result",
            Box::new(|d| {
                let branch = d["analyses"][4]["result"]["branches"][0].as_object_mut().unwrap();
                let folds = branch.remove("folds").unwrap();
                branch.insert("fold_orders".into(), folds);
            }),
        ),
        (
            "a number written as a string",
            "/analyses/4/result",
            Box::new(|d| d["analyses"][4]["result"]["branches"][0]["order"][0] = "3.1".into()),
        ),
        (
            "a count that is negative",
            "/analyses/4/findings",
            Box::new(|d| d["analyses"][4]["findings"]["branches"][0]["points"] = (-1).into()),
        ),
        ("a wrong format", "/format", Box::new(|d| d["format"] = "results".into())),
    ];
    for (what, at, breaks) in &broken {
        let mut d = doc.clone();
        breaks(&mut d);
        assert_ne!(d, doc, "{what}: the document did not change");
        let errs = errors(&v, &d);
        assert!(!errs.is_empty(), "a document with {what} passed the schema");
        assert!(errs.iter().all(|e| e.starts_with(at)), "{what}: errors elsewhere than {at}: {errs:?}");
    }
    // null stands for a number that does not exist (NaN in memory) wherever a number may be.
    let mut d = doc.clone();
    d["analyses"][4]["result"]["branches"][0]["order"][0] = Value::Null;
    assert!(v.is_valid(&d), "{:?}", errors(&v, &d));
}
