//! No output of any example study holds NaN or infinity in text form: a value that does not
//! exist or apply is an empty CSV cell, "undefined" (or a reason) in the summary and `null` in
//! results.json (issue 13). The scan is of the files themselves, every CSV, Markdown and JSON file
//! each example study writes.

use kanedyn::study::{RunOptions, Study, run};
use std::path::Path;

/// Whether `text` holds a NaN or an infinity as a word of its own (so "information" passes).
fn non_finite_word(text: &str) -> Option<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '+'))
        .map(|w| w.trim_start_matches(['-', '+']))
        .find(|w| {
            let l = w.to_ascii_lowercase();
            l == "nan" || l == "inf" || l == "infinity"
        })
        .map(str::to_string)
}

#[test]
fn the_scan_sees_what_it_looks_for() {
    assert_eq!(non_finite_word("1.5,NaN,2").as_deref(), Some("NaN"));
    assert_eq!(non_finite_word("| -inf |").as_deref(), Some("inf"));
    assert_eq!(non_finite_word("x = Infinity").as_deref(), Some("Infinity"));
    assert_eq!(non_finite_word("information, finite, undefined, 1e-300"), None);
}

#[test]
fn no_example_study_writes_nan_or_inf() {
    let mut scanned = 0;
    for entry in std::fs::read_dir("examples").unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        if path.extension().is_none_or(|e| e != "ron") || !text.lines().any(|l| l.starts_with("Study(")) {
            continue;
        }
        let out = std::env::temp_dir().join(format!("kanedyn_nonan_{}_{}", std::process::id(), scanned));
        let study = Study::from_file(&path).unwrap();
        let report = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
        assert!(report.failures.is_empty(), "{}: {:?}", path.display(), report.failures);
        for f in &report.files {
            if f.extension().is_some_and(|e| e == "csv" || e == "md" || e == "json") {
                let body = std::fs::read_to_string(f).unwrap();
                assert!(non_finite_word(&body).is_none(), "{} holds {:?}", f.display(), non_finite_word(&body));
                scanned += 1;
            }
        }
        std::fs::remove_dir_all(&out).ok();
    }
    println!("{scanned} files scanned");
    assert!(scanned >= 20, "expected the outputs of the three example studies, scanned {scanned}");
    assert!(Path::new("examples/cpva_paper.ron").exists());
}
