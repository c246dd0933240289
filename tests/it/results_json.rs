//! `results.json` of every example study: strict JSON with no NaN or infinity anywhere, its tables
//! equal to the CSV files cell by cell (an empty cell is `null`), every CSV file in it, and its
//! statuses consistent with the failures; a study with a failing analysis keeps the others.

use crate::support::examples;

use crate::support::scratch;
use examples::copy_cpva;
use kanedyn::study::{RunOptions, Study, run};
use serde_json::Value;
use std::path::Path;
use tempfile::TempDir;

fn out_dir(tag: &str) -> TempDir {
    scratch(&format!("results-json-{tag}"))
}

/// Every number in `v`, with its JSON path.
fn numbers(v: &Value, path: &str, out: &mut Vec<(String, f64)>) {
    match v {
        Value::Number(n) => out.push((path.to_string(), n.as_f64().unwrap_or(f64::NAN))),
        Value::Array(a) => a.iter().enumerate().for_each(|(i, x)| numbers(x, &format!("{path}[{i}]"), out)),
        Value::Object(o) => o.iter().for_each(|(k, x)| numbers(x, &format!("{path}.{k}"), out)),
        _ => {}
    }
}

/// Runs `study_file` into a fresh folder and checks its `results.json` against the CSV files
/// there; returns the document.
fn check_study(study_file: &Path, tag: &str) -> Value {
    let study = Study::from_file(study_file).unwrap();
    let tmp = out_dir(tag);
    let out = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    let dir = out.join(&study.spec.name);
    let json = dir.join("results.json");
    assert!(report.files.contains(&json), "results.json not listed in {:?}", report.files);
    let text = std::fs::read_to_string(&json).unwrap();
    // serde_json refuses NaN, Infinity and out-of-range literals: parsing is the strict check.
    let doc: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{tag}: not strict JSON: {e}"));
    let mut all = Vec::new();
    numbers(&doc, "$", &mut all);
    assert!(all.len() > 100, "{tag}: only {} numbers", all.len());
    for (p, v) in &all {
        assert!(v.is_finite(), "{tag}: {p} = {v}");
    }
    assert_eq!(doc["format"], "kanedyn-results");
    assert_eq!(doc["study"]["name"], study.spec.name.as_str());

    // Every CSV file of the folder is one table, and each table equals its file cell by cell.
    let mut csv_files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| f.ends_with(".csv"))
        .collect();
    csv_files.sort();
    let analyses = doc["analyses"].as_array().unwrap();
    assert_eq!(analyses.len(), study.spec.analyses.len());
    let mut table_files = Vec::new();
    let mut cells = 0usize;
    // A comparison's analyses are entries of their own, inside its result.
    let mut entries: Vec<&Value> = Vec::new();
    for a in analyses {
        entries.push(a);
        if a["kind"] == "Compare" {
            for m in a["result"]["mechanisms"].as_array().unwrap() {
                entries.extend(m["analyses"].as_array().unwrap());
            }
        }
    }
    for a in entries {
        for t in a["tables"].as_array().unwrap() {
            let file = t["file"].as_str().unwrap();
            table_files.push(file.to_string());
            let mut r = csv::Reader::from_path(dir.join(file)).unwrap();
            let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
            let columns = t["columns"].as_array().unwrap();
            let names: Vec<&str> = columns.iter().map(|c| c["name"].as_str().unwrap()).collect();
            // A design study's CSV ends with its text columns, each row's `status` and `error`,
            // which results.json holds with the row under `result.cases`.
            let design = a["kind"] == "DesignStudy";
            let text_columns: &[&str] = if design { &["status", "error"] } else { &[] };
            assert_eq!(header, [&names[..], text_columns].concat(), "{file}: header");
            for c in columns {
                assert!(!c["unit"].as_str().unwrap().is_empty(), "{file}: {} has no unit", c["name"]);
            }
            let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
            if design {
                let cases = a["result"]["cases"].as_array().unwrap();
                assert_eq!(cases.len(), rows.len(), "{file}: cases");
                for (row, case) in rows.iter().zip(cases) {
                    assert_eq!(&row[names.len()], case["status"].as_str().unwrap(), "{file}: status");
                    assert_eq!(&row[names.len() + 1], case["error"].as_str().unwrap(), "{file}: error");
                    cells += 2;
                }
            }
            for (k, c) in columns.iter().enumerate() {
                let values = c["values"].as_array().unwrap();
                assert_eq!(values.len(), rows.len(), "{file}: column {} length", names[k]);
                for (row, v) in rows.iter().zip(values) {
                    let cell = &row[k];
                    match v {
                        Value::Null => assert_eq!(cell, "", "{file}: {} null but the cell is {cell}", names[k]),
                        Value::Number(n) => {
                            let parsed: f64 = cell.parse().unwrap_or_else(|_| panic!("{file}: cell {cell:?}"));
                            // The same bits, but for the sign of zero: a CSV writes -0 as `0` (issue 54,
                            // item 4); adding +0.0 turns -0.0 into +0.0 and leaves every other value.
                            let (csv, json) = (parsed + 0.0, n.as_f64().unwrap() + 0.0);
                            assert_eq!(csv.to_bits(), json.to_bits(), "{file}: {}", names[k]);
                        }
                        other => panic!("{file}: {} holds {other}", names[k]),
                    }
                    cells += 1;
                }
            }
        }
    }
    table_files.sort();
    assert_eq!(table_files, csv_files, "{tag}: tables vs CSV files");
    assert!(cells > 0, "{tag}: no cells compared");

    // Statuses: the document's follows the failures, an analysis's its own failures.
    let failures = doc["failures"].as_array().unwrap();
    assert_eq!(failures.len(), report.failures.len());
    assert_eq!(doc["status"], if failures.is_empty() { "complete" } else { "partial" });
    for a in analyses {
        let own = a["failures"].as_array().unwrap();
        let expected = match (a["result"].is_null(), own.is_empty()) {
            (true, _) => "failed",
            (false, true) => "complete",
            (false, false) => "partial",
        };
        assert_eq!(a["status"], expected, "{}", a["name"]);
    }
    doc
}

#[test]
fn every_example_study_writes_strict_results_json_equal_to_its_csvs() {
    let mut studies = 0;
    for e in std::fs::read_dir("examples").unwrap() {
        let p = e.unwrap().path();
        let is_study = std::fs::read_to_string(&p).is_ok_and(|t| {
            t.lines()
                .map(str::trim)
                .find(|l| !l.is_empty() && !l.starts_with("//"))
                .is_some_and(|l| l.starts_with("Study("))
        });
        if !is_study {
            continue;
        }
        let tag = p.file_stem().unwrap().to_string_lossy().into_owned();
        let doc = check_study(&p, &tag);
        assert_eq!(doc["status"], "complete", "{tag}: {}", doc["failures"]);
        studies += 1;
    }
    // cpva_paper, cpva_linear, shaft_campbell, design_study.
    assert!(studies >= 3, "{studies} example studies");
}

/// A harmonic balance that diverges at 10⁶ N·m fails alone: its entry is `partial` with its
/// failures and no branch, the analyses before and after it are complete, and the document is
/// still strict JSON equal to the CSVs.
#[test]
fn a_failing_analysis_is_reported_and_the_others_kept() {
    let tmp = out_dir("iso_src");
    let dir = tmp.path().to_path_buf();
    copy_cpva(&dir);
    let file = dir.join("iso.ron");
    std::fs::write(
        &file,
        r#"Study(
    name: "iso",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        LinearResponse(name: "before", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
        HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                        harmonics: 1, multiples: [1.0]),
        Campbell(name: "after", rpm_min: 0.0, rpm_max: 2000.0, points: 5),
    ],
)
"#,
    )
    .unwrap();
    let doc = check_study(&file, "iso");
    assert_eq!(doc["status"], "partial");
    let a = &doc["analyses"];
    assert_eq!((a[0]["status"].as_str(), a[2]["status"].as_str()), (Some("complete"), Some("complete")));
    assert_eq!(a[1]["status"], "partial");
    // Two continuations (from each end of the range): each gives a branch or a failure.
    let branches = a[1]["result"]["branches"].as_array().unwrap();
    let own = a[1]["failures"].as_array().unwrap();
    assert!(!own.is_empty());
    assert_eq!(branches.len() + own.iter().filter(|f| f.as_str().unwrap().contains("continued from")).count(), 2);
    assert_eq!(a[1]["tables"].as_array().map(Vec::len), Some(branches.len()));
    assert!(own.iter().all(|f| f.as_str().unwrap().starts_with("HarmonicBalance `diverges` (")), "{own:?}");
    // The Campbell diagram after it is found although the failing analysis came between.
    assert_eq!(a[2]["result"]["rpm"].as_array().map(Vec::len), Some(5));
    assert_eq!(a[2]["tables"][0]["file"], "after.csv");
}
