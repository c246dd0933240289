//! No output of any example study holds NaN or infinity in text form: a value that does not
//! exist or apply is an empty CSV cell, "undefined" (or a reason) in the summary and `null` in
//! results.json (issue 13). The scan is of the files themselves, every CSV, Markdown and JSON file
//! each example study writes.

use crate::support::examples;
use crate::support::scratch;

use examples::copy_dir;
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
        let tmp = scratch("nonan");
        let out = tmp.path().to_path_buf();
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
    }
    println!("{scanned} files scanned");
    assert!(scanned >= 20, "expected the outputs of the three example studies, scanned {scanned}");
    assert!(Path::new("examples/cpva_paper.ron").exists());
}

/// Issue 25: failing studies must keep the promise too. The first one used to print
/// "NaN (locked 1.7e-14)" in summary.md's steadiness column (and so in report.html): the free
/// rotor's steady run at 1000 rpm under the six-cylinder engine ends before two windows can be
/// compared, while its failure was listed. The others fail each in their own way (a diverging
/// harmonic balance, step limits in a sweep, a transient and a comparison, failing cases of a
/// design study). Every file each writes is scanned, figures included.
#[test]
fn no_failing_study_writes_nan_or_inf() {
    let tmp = scratch("nonan-fail");
    let root = tmp.path().to_path_buf();
    copy_dir(Path::new("examples"), &root);
    let studies = [
        (
            "cpva.ron",
            "",
            r#"MultiOrder(name: "engine_orders", order: 3.0, engine: "engines/inline_six.ron", engine_multiples: 2,
                speeds: [(rpm: 1000.0)], multiples: [1.0, 2.0], min_time_s: 5.0, max_time_s: 20.0, linear: true)"#,
        ),
        (
            "cpva.ron",
            "",
            r#"HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                harmonics: 1, multiples: [1.0])"#,
        ),
        (
            "cpva.ron",
            "integration: (max_steps: 500),",
            r#"OrderSweep(name: "sw", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0, amplitudes: [40.0]),
               Transient(name: "tr", duration_s: 5.0, speed: Torque(rpm_from: 600.0, rpm_to: 1800.0)),
               MultiOrder(name: "mo", order: 3.0, speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 40.0)])],
                          min_time_s: 5.0, max_time_s: 20.0, hbm: true)"#,
        ),
        (
            "paths/circle.ron",
            "integration: (max_steps: 300),",
            r#"Compare(name: "c", mechanisms: [(label: "circle", mechanism: "paths/circle.ron"),
                                               (label: "epi", mechanism: "paths/epicycloid.ron")],
                analyses: [FreeOscillation(name: "free", rpm: 1000.0, joint: "path", amplitudes: [0.005, 0.01]),
                           OrderSweep(name: "sw", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0,
                                      amplitudes: [40.0])])"#,
        ),
        (
            "cpva.ron",
            "",
            r#"DesignStudy(name: "d", parameters: [(name: "T_n", quantity: TorqueAmplitude, values: [40.0, 1e6])],
                sampling: Grid, analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3,
                amplitudes: [40.0], harmonics: 1, multiples: [1.0]))"#,
        ),
    ];
    let mut scanned = 0;
    for (i, (mechanism, settings, analyses)) in studies.iter().enumerate() {
        let text = format!(
            "Study(name: \"f{i}\", mechanism: \"{mechanism}\", lock: [{}], {settings}\n analyses: [{analyses}])\n",
            if mechanism == &"cpva.ron" { "\"pivot\"" } else { "" }
        );
        let path = root.join(format!("f{i}.ron"));
        std::fs::write(&path, &text).unwrap();
        let study = Study::from_file(&path).unwrap_or_else(|e| panic!("study {i}: {e}"));
        let report = run(&study, &RunOptions { out: Some(root.join("out")), progress: false }).unwrap();
        assert!(!report.failures.is_empty(), "study {i} was meant to fail:\n{text}");
        for f in &report.files {
            let body = std::fs::read_to_string(f).unwrap();
            assert!(non_finite_word(&body).is_none(), "study {i}: {} holds {:?}", f.display(), non_finite_word(&body));
            scanned += 1;
        }
    }
    println!("{scanned} files of failing studies scanned");
    assert!(scanned >= 25, "scanned only {scanned} files");
}

/// Every file under `dir`, recursively.
fn every_file(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(every_file(&path));
        } else {
            out.push(path);
        }
    }
    out
}

/// Issue 49, item 4: a harmonic balance continued in torque has no one amplitude per case (NaN
/// inside), and its figures' titles used to read "T_n = NaN N·m" in the SVGs and so in
/// report.html. With elements (their figure) and in both continuation kinds, every file the run
/// leaves, of every type (CSV, JSON, Markdown, SVG, HTML), is free of NaN and infinity words,
/// and the elements figure names the continuation instead.
#[test]
fn a_harmonic_balance_in_torque_with_elements_writes_no_nan_in_any_file() {
    let tmp = scratch("nonan-torque");
    let root = tmp.path().to_path_buf();
    copy_dir(Path::new("examples"), &root);
    std::fs::write(
        root.join("t.ron"),
        r#"Study(name: "t", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor", elements: ["pivot"],
    analyses: [HarmonicBalance(name: "h", rpm: 1000.0, parameter: Torque(order: 3.1740911, min: 1.0, max: 120.0))])"#,
    )
    .unwrap();
    let study = Study::from_file(&root.join("t.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(root.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let files = every_file(&root.join("out"));
    let mut kinds = std::collections::BTreeSet::new();
    for f in &files {
        let body = std::fs::read_to_string(f).unwrap();
        assert!(non_finite_word(&body).is_none(), "{} holds {:?}", f.display(), non_finite_word(&body));
        kinds.insert(f.extension().unwrap().to_string_lossy().to_string());
    }
    for kind in ["csv", "html", "json", "md", "svg"] {
        assert!(kinds.contains(kind), "no {kind} file among {kinds:?}");
    }
    let elements = std::fs::read_to_string(root.join("out/t/h_elements.svg")).unwrap();
    assert!(elements.contains("T_n continued at n = 3.1740911"), "the elements figure names the continuation");
}
